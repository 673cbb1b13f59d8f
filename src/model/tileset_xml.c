/* The small XML reader of the tile-set loaders (tileset_impl.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "tileset_impl.h"

#define XML_MAX_BYTES (64u << 20)

/* ---- minimal XML ------------------------------------------------------------ */


void gs_tsxml_free(xml_doc *d)
{
    gs_free(d->buf);
    gs_free(d->e);
    memset(d, 0, sizeof *d);
}

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }
static int is_name(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.' || c == ':' || (unsigned char)c >= 0x80;
}

/* Decodes entities of s in place (the result is never longer). */
static gs_err xml_unescape(const xml_doc *d, int line, char *s)
{
    char *w = s;
    for (char *p = s; *p;) {
        if (*p != '&') {
            *w++ = *p++;
            continue;
        }
        char *semi = strchr(p, ';');
        GS_CHECK(semi && semi - p <= 10, GS_ERR_FORMAT, "%s:%d: '&' without a ';' entity end",
                 d->file, line);
        *semi = '\0';
        const char *ent = p + 1;
        if (!strcmp(ent, "amp"))
            *w++ = '&';
        else if (!strcmp(ent, "lt"))
            *w++ = '<';
        else if (!strcmp(ent, "gt"))
            *w++ = '>';
        else if (!strcmp(ent, "quot"))
            *w++ = '"';
        else if (!strcmp(ent, "apos"))
            *w++ = '\'';
        else if (ent[0] == '#') {
            int64_t v;
            char why[96];
            int ok = 0;
            if (ent[1] != 'x' && ent[1] != 'X')
                ok = gs_parse_i64(ent + 1, 1, 127, &v, why, sizeof why);
            if (ent[1] == 'x' || ent[1] == 'X') {
                v = 0;
                ok = ent[2] != '\0';
                for (const char *h = ent + 2; *h && ok; h++) {
                    int dv = *h >= '0' && *h <= '9'   ? *h - '0'
                             : *h >= 'a' && *h <= 'f' ? *h - 'a' + 10
                             : *h >= 'A' && *h <= 'F' ? *h - 'A' + 10
                                                      : -1;
                    ok = dv >= 0 && (v = v * 16 + dv) < 128;
                }
                ok = ok && v > 0;
            }
            GS_CHECK(ok, GS_ERR_FORMAT, "%s:%d: character reference &%s; unsupported (ASCII only)",
                     d->file, line, ent);
            *w++ = (char)v;
        } else {
            GS_RAISE(GS_ERR_FORMAT, "%s:%d: unknown entity &%s;", d->file, line, ent);
        }
        p = semi + 1;
    }
    *w = '\0';
    return GS_OK;
}

gs_err gs_tsxml_parse(const char *path, xml_doc *d)
{
    memset(d, 0, sizeof *d);
    d->file = path;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, XML_MAX_BYTES, &d->buf, &len));
    gs_err err = GS_OK;
    char *p = d->buf, *end = d->buf + len;
    int line = 1, cur = -1, depth = 0;
    d->cap = 64;
    GS_TRY(err, gs_alloc_array((void **)&d->e, (size_t)d->cap, sizeof *d->e, "xml elements"), fail);
#define ADV()                                                                                      \
    do {                                                                                           \
        if (*p == '\n')                                                                            \
            line++;                                                                                \
        p++;                                                                                       \
    } while (0)
    while (p < end) {
        if (*p != '<') {
            GS_TRY_CHECK(err, *p != '\0', GS_ERR_FORMAT, fail, "%s:%d: NUL byte in the file", path,
                         line);
            ADV();
            continue;
        }
        int tag_line = line;
        if (end - p >= 4 && !strncmp(p, "<!--", 4)) {
            char *q = strstr(p + 4, "-->");
            GS_TRY_CHECK(err, q, GS_ERR_FORMAT, fail, "%s:%d: comment '<!--' is never closed",
                         path, tag_line);
            while (p < q + 3)
                ADV();
            continue;
        }
        if (p[1] == '?' || p[1] == '!') {
            char *q = strchr(p, '>');
            GS_TRY_CHECK(err, q, GS_ERR_FORMAT, fail, "%s:%d: '<%c' is never closed by '>'", path,
                         tag_line, p[1]);
            while (p <= q)
                ADV();
            continue;
        }
        if (p[1] == '/') {
            p += 2;
            char *name = p;
            while (p < end && is_name(*p))
                p++;
            char *name_end = p;
            while (p < end && is_space(*p))
                ADV();
            GS_TRY_CHECK(err, p < end && *p == '>', GS_ERR_FORMAT, fail,
                         "%s:%d: closing tag: expected '>'", path, tag_line);
            *name_end = '\0';
            GS_TRY_CHECK(err, cur >= 0 && !strcmp(d->e[cur].name, name), GS_ERR_FORMAT, fail,
                         "%s:%d: closing tag </%s> does not match the open <%s> (line %d)", path,
                         tag_line, name, cur >= 0 ? d->e[cur].name : "(none)",
                         cur >= 0 ? d->e[cur].line : 0);
            cur = d->e[cur].parent;
            depth--;
            p++;
            continue;
        }
        /* start tag */
        p++;
        char *name = p;
        while (p < end && is_name(*p))
            p++;
        GS_TRY_CHECK(err, p > name, GS_ERR_FORMAT, fail, "%s:%d: '<' not followed by a tag name",
                     path, tag_line);
        GS_TRY_CHECK(err, cur >= 0 || d->n == 0, GS_ERR_FORMAT, fail,
                     "%s:%d: second top-level element <%.*s>: expected one root", path, tag_line,
                     (int)(p - name), name);
        if (d->n == d->cap) {
            d->cap *= 2;
            void *ne = gs_realloc(d->e, (size_t)d->cap * sizeof *d->e);
            GS_TRY_CHECK(err, ne, GS_ERR_MEM, fail, "%s: out of memory for elements", path);
            d->e = ne;
        }
        xml_elem *el = &d->e[d->n];
        memset(el, 0, sizeof *el);
        el->name = name;
        el->parent = cur;
        el->line = tag_line;
        char *name_end = p;
        int closed = 0;
        for (;;) {
            while (p < end && is_space(*p))
                ADV();
            GS_TRY_CHECK(err, p < end, GS_ERR_FORMAT, fail, "%s:%d: tag <%.*s> is never closed",
                         path, tag_line, (int)(name_end - name), name);
            if (*p == '>') {
                p++;
                break;
            }
            if (*p == '/') {
                GS_TRY_CHECK(err, p + 1 < end && p[1] == '>', GS_ERR_FORMAT, fail,
                             "%s:%d: expected '/>'", path, line);
                p += 2;
                closed = 1;
                break;
            }
            char *key = p;
            while (p < end && is_name(*p))
                p++;
            GS_TRY_CHECK(err, p > key, GS_ERR_FORMAT, fail,
                         "%s:%d: in <%.*s>: expected an attribute name, got '%c'", path, line,
                         (int)(name_end - name), name, *p);
            char *key_end = p;
            while (p < end && is_space(*p))
                ADV();
            GS_TRY_CHECK(err, p < end && *p == '=', GS_ERR_FORMAT, fail,
                         "%s:%d: attribute %.*s: expected '=' and a quoted value", path, line,
                         (int)(key_end - key), key);
            p++;
            while (p < end && is_space(*p))
                ADV();
            GS_TRY_CHECK(err, p < end && (*p == '"' || *p == '\''), GS_ERR_FORMAT, fail,
                         "%s:%d: attribute %.*s: expected a quoted value", path, line,
                         (int)(key_end - key), key);
            char quote = *p++;
            char *val = p;
            int vline = line;
            while (p < end && *p != quote) {
                GS_TRY_CHECK(err, *p != '<', GS_ERR_FORMAT, fail,
                             "%s:%d: attribute %.*s: '<' inside the value (missing quote?)", path,
                             vline, (int)(key_end - key), key);
                ADV();
            }
            GS_TRY_CHECK(err, p < end, GS_ERR_FORMAT, fail,
                         "%s:%d: attribute %.*s: value is never closed", path, vline,
                         (int)(key_end - key), key);
            *p++ = '\0';
            GS_TRY_CHECK(err, el->nattr < XML_MAX_ATTRS, GS_ERR_FORMAT, fail,
                         "%s:%d: more than %d attributes", path, vline, XML_MAX_ATTRS);
            *key_end = '\0';
            GS_TRY(err, xml_unescape(d, vline, val), fail);
            el->key[el->nattr] = key;
            el->val[el->nattr] = val;
            el->nattr++;
        }
        *name_end = '\0';
        d->n++;
        if (!closed) {
            cur = d->n - 1;
            depth++;
        }
    }
#undef ADV
    GS_TRY_CHECK(err, d->n > 0, GS_ERR_FORMAT, fail, "%s: no XML element found", path);
    GS_TRY_CHECK(err, cur < 0, GS_ERR_FORMAT, fail,
                 "%s:%d: end of file inside <%s> opened at line %d", path, line, d->e[cur].name,
                 d->e[cur].line);
    (void)depth;
    return GS_OK;
fail:
    gs_tsxml_free(d);
    return err;
}

const char *gs_tsxml_attr(const xml_elem *e, const char *key)
{
    for (int i = 0; i < e->nattr; i++)
        if (!strcmp(e->key[i], key))
            return e->val[i];
    return NULL;
}

