/* Lenient JSON reader of the DeBroglie tile-set loader (tileset_impl.h):
 * RFC 8259 values plus line (//) and block comments and trailing commas (DeBroglie's
 * samples use both). Strings: the escapes \" \\ \/ \b \f \n \r \t and \uXXXX
 * below 128. Errors name file and line. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "tileset_impl.h"

#define TSJ_MAX_BYTES (16u << 20)
#define TSJ_MAX_DEPTH 64

typedef struct jp {
    tsjson_doc *d;
    char *p, *end;
    int line;
} jp;

void gs_tsjson_free(tsjson_doc *d)
{
    gs_free(d->buf);
    gs_free(d->n);
    memset(d, 0, sizeof *d);
}

static gs_err skip_ws(jp *j)
{
    for (;;) {
        while (j->p < j->end && (*j->p == ' ' || *j->p == '\t' || *j->p == '\r' || *j->p == '\n')) {
            if (*j->p == '\n')
                j->line++;
            j->p++;
        }
        if (j->end - j->p >= 2 && j->p[0] == '/' && j->p[1] == '/') {
            while (j->p < j->end && *j->p != '\n')
                j->p++;
            continue;
        }
        if (j->end - j->p >= 2 && j->p[0] == '/' && j->p[1] == '*') {
            int at = j->line;
            j->p += 2;
            while (j->end - j->p >= 2 && !(j->p[0] == '*' && j->p[1] == '/')) {
                if (*j->p == '\n')
                    j->line++;
                j->p++;
            }
            GS_CHECK(j->end - j->p >= 2, GS_ERR_FORMAT, "%s:%d: comment '/*' is never closed",
                     j->d->file, at);
            j->p += 2;
            continue;
        }
        return GS_OK;
    }
}

static gs_err new_node(jp *j, int type, int *idx)
{
    tsjson_doc *d = j->d;
    if (d->count == d->cap) {
        int cap = d->cap ? 2 * d->cap : 64;
        void *nn = gs_realloc(d->n, (size_t)cap * sizeof *d->n);
        GS_CHECK(nn, GS_ERR_MEM, "%s: out of memory for JSON values", d->file);
        d->n = nn;
        d->cap = cap;
    }
    *idx = d->count++;
    tsjson_node *n = &d->n[*idx];
    memset(n, 0, sizeof *n);
    n->type = type;
    n->first = n->next = -1;
    n->line = j->line;
    return GS_OK;
}

/* Decodes the string at j->p (after the opening quote) in place. */
static gs_err parse_string(jp *j, char **out)
{
    char *w = j->p, *start = j->p;
    int at = j->line;
    while (j->p < j->end && *j->p != '"') {
        char c = *j->p++;
        GS_CHECK(c != '\n' && c != '\0', GS_ERR_FORMAT, "%s:%d: string is never closed",
                 j->d->file, at);
        if (c != '\\') {
            *w++ = c;
            continue;
        }
        GS_CHECK(j->p < j->end, GS_ERR_FORMAT, "%s:%d: string is never closed", j->d->file, at);
        char e = *j->p++;
        switch (e) {
        case '"': case '\\': case '/': *w++ = e; break;
        case 'b': *w++ = '\b'; break;
        case 'f': *w++ = '\f'; break;
        case 'n': *w++ = '\n'; break;
        case 'r': *w++ = '\r'; break;
        case 't': *w++ = '\t'; break;
        case 'u': {
            unsigned v = 0;
            for (int k = 0; k < 4; k++) {
                char h = j->p < j->end ? *j->p++ : 0;
                int dv = h >= '0' && h <= '9' ? h - '0' : h >= 'a' && h <= 'f' ? h - 'a' + 10
                         : h >= 'A' && h <= 'F' ? h - 'A' + 10 : -1;
                GS_CHECK(dv >= 0, GS_ERR_FORMAT, "%s:%d: \\u needs four hex digits", j->d->file,
                         j->line);
                v = v * 16 + (unsigned)dv;
            }
            GS_CHECK(v > 0 && v < 128, GS_ERR_FORMAT, "%s:%d: \\u%04x unsupported (ASCII only)",
                     j->d->file, j->line, v);
            *w++ = (char)v;
            break;
        }
        default:
            GS_RAISE(GS_ERR_FORMAT, "%s:%d: unknown escape \\%c in a string", j->d->file, j->line, e);
        }
    }
    GS_CHECK(j->p < j->end, GS_ERR_FORMAT, "%s:%d: string is never closed", j->d->file, at);
    j->p++; /* closing quote (w <= its position, so the terminator fits) */
    *w = '\0';
    *out = start;
    return GS_OK;
}

static gs_err parse_value(jp *j, int depth, int *idx);

static gs_err parse_container(jp *j, int depth, int obj, int self)
{
    char close = obj ? '}' : ']';
    int prev = -1;
    for (;;) {
        GS_CALL(skip_ws(j));
        GS_CHECK(j->p < j->end, GS_ERR_FORMAT, "%s:%d: end of file inside %s opened at line %d",
                 j->d->file, j->line, obj ? "an object" : "an array", j->d->n[self].line);
        if (*j->p == close) {
            j->p++;
            return GS_OK;
        }
        char *key = NULL;
        if (obj) {
            GS_CHECK(*j->p == '"', GS_ERR_FORMAT, "%s:%d: expected a quoted member name or '}', got '%c'",
                     j->d->file, j->line, *j->p);
            j->p++;
            GS_CALL(parse_string(j, &key));
            GS_CALL(skip_ws(j));
            GS_CHECK(j->p < j->end && *j->p == ':', GS_ERR_FORMAT,
                     "%s:%d: expected ':' after \"%s\"", j->d->file, j->line, key);
            j->p++;
        }
        int child;
        GS_CALL(parse_value(j, depth + 1, &child));
        j->d->n[child].key = key;
        if (prev < 0)
            j->d->n[self].first = child;
        else
            j->d->n[prev].next = child;
        prev = child;
        GS_CALL(skip_ws(j));
        GS_CHECK(j->p < j->end && (*j->p == ',' || *j->p == close), GS_ERR_FORMAT,
                 "%s:%d: expected ',' or '%c'", j->d->file, j->line, close);
        if (*j->p == ',')
            j->p++;
    }
}

static gs_err parse_value(jp *j, int depth, int *idx)
{
    GS_CHECK(depth < TSJ_MAX_DEPTH, GS_ERR_FORMAT, "%s:%d: nested deeper than %d", j->d->file,
             j->line, TSJ_MAX_DEPTH);
    GS_CALL(skip_ws(j));
    GS_CHECK(j->p < j->end, GS_ERR_FORMAT, "%s:%d: expected a value, got the end of the file",
             j->d->file, j->line);
    char c = *j->p;
    if (c == '{' || c == '[') {
        j->p++;
        GS_CALL(new_node(j, c == '{' ? TSJ_OBJ : TSJ_ARR, idx));
        return parse_container(j, depth, c == '{', *idx);
    }
    if (c == '"') {
        j->p++;
        GS_CALL(new_node(j, TSJ_STR, idx));
        char *s;
        GS_CALL(parse_string(j, &s));
        j->d->n[*idx].str = s;
        return GS_OK;
    }
    static const char *const word[3] = {"true", "false", "null"};
    for (int k = 0; k < 3; k++) {
        size_t l = strlen(word[k]);
        if ((size_t)(j->end - j->p) >= l && !strncmp(j->p, word[k], l)) {
            GS_CALL(new_node(j, k == 2 ? TSJ_NULL : TSJ_BOOL, idx));
            j->d->n[*idx].num = k == 0;
            j->p += l;
            return GS_OK;
        }
    }
    char *q = j->p;
    while (q < j->end && strchr("+-0123456789.eE", *q))
        q++;
    GS_CHECK(q > j->p && q - j->p < 64, GS_ERR_FORMAT, "%s:%d: unexpected '%c': expected a value",
             j->d->file, j->line, c);
    char tmp[64];
    memcpy(tmp, j->p, (size_t)(q - j->p));
    tmp[q - j->p] = '\0';
    char *e = NULL;
    double v = strtod(tmp, &e);
    GS_CHECK(e && *e == '\0' && isfinite(v), GS_ERR_FORMAT, "%s:%d: '%s' is not a number",
             j->d->file, j->line, tmp);
    GS_CALL(new_node(j, TSJ_NUM, idx));
    j->d->n[*idx].num = v;
    j->p = q;
    return GS_OK;
}

gs_err gs_tsjson_parse(const char *path, tsjson_doc *d)
{
    memset(d, 0, sizeof *d);
    d->file = path;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, TSJ_MAX_BYTES, &d->buf, &len));
    jp j = {d, d->buf, d->buf + len, 1};
    int root = -1;
    gs_err err = parse_value(&j, 0, &root);
    if (!err)
        err = skip_ws(&j);
    if (!err && j.p < j.end)
        err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                             "%s:%d: text after the top-level value", path, j.line);
    if (!err && d->n[0].type != TSJ_OBJ)
        err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                             "%s:1: expected an object at the top level", path);
    if (err) {
        gs_tsjson_free(d);
        return err;
    }
    return GS_OK;
}

int gs_tsjson_get(const tsjson_doc *d, int obj, const char *key)
{
    if (obj < 0 || d->n[obj].type != TSJ_OBJ)
        return -1;
    for (int c = d->n[obj].first; c >= 0; c = d->n[c].next)
        if (d->n[c].key && !strcmp(d->n[c].key, key))
            return c;
    return -1;
}
