/* PLY header and items, shared by the point-set and mesh readers; see
 * src/io/ply_internal.h. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "io/ply_internal.h"

static const struct {
    const char *name, *alias;
    size_t size;
} types[GS_PLY_NTYPES] = {
    {"char", "int8", 1},    {"uchar", "uint8", 1},    {"short", "int16", 2},
    {"ushort", "uint16", 2}, {"int", "int32", 4},      {"uint", "uint32", 4},
    {"float", "float32", 4}, {"double", "float64", 8},
};

static int type_from_name(const char *s)
{
    for (int t = 0; t < GS_PLY_NTYPES; t++)
        if (!strcmp(s, types[t].name) || !strcmp(s, types[t].alias))
            return t;
    return -1;
}

/* Splits a header line into at most max words (in place in buf). */
static int split_words(char *buf, char **w, int max)
{
    int n = 0;
    char *p = buf;
    while (*p) {
        while (*p == ' ' || *p == '\t')
            p++;
        if (!*p)
            break;
        if (n == max)
            return max + 1;
        w[n++] = p;
        while (*p && *p != ' ' && *p != '\t')
            p++;
        if (*p)
            *p++ = '\0';
    }
    return n;
}

/* Value of type t at p (byte order of r), as double (exact for every type). */
static double load(const gs_ply *r, const unsigned char *p, int t)
{
    uint64_t u = 0;
    size_t n = types[t].size;
    for (size_t i = 0; i < n; i++)
        u |= (uint64_t)p[r->big_endian ? n - 1 - i : i] << (8 * i);
    switch (t) {
    case GS_PLY_I8:
        return (double)(int8_t)u;
    case GS_PLY_U8:
        return (double)(uint8_t)u;
    case GS_PLY_I16:
        return (double)(int16_t)u;
    case GS_PLY_U16:
        return (double)(uint16_t)u;
    case GS_PLY_I32:
        return (double)(int32_t)(uint32_t)u;
    case GS_PLY_U32:
        return (double)(uint32_t)u;
    case GS_PLY_F32: {
        uint32_t w = (uint32_t)u;
        float f;
        memcpy(&f, &w, sizeof f);
        return (double)f;
    }
    default: {
        double d;
        memcpy(&d, &u, sizeof d);
        return d;
    }
    }
}

void gs_ply_skip_blanks(gs_ply *r)
{
    if (!r->ascii)
        return;
    while (r->pos < r->len) {
        char c = r->data[r->pos];
        if (c != ' ' && c != '\t' && c != '\r' && c != '\n')
            break;
        if (c == '\n')
            r->line++;
        r->pos++;
    }
}

/* Next whitespace-separated ASCII token into tok[cap]; 0 at end of data. */
static int next_token(gs_ply *r, char *tok, size_t cap, int *too_long)
{
    *too_long = 0;
    gs_ply_skip_blanks(r);
    if (r->pos >= r->len)
        return 0;
    size_t n = 0;
    while (r->pos < r->len) {
        char c = r->data[r->pos];
        if (c == ' ' || c == '\t' || c == '\r' || c == '\n')
            break;
        if (n + 1 < cap)
            tok[n++] = c;
        else
            *too_long = 1;
        r->pos++;
    }
    tok[n] = '\0';
    return 1;
}

/* One ASCII value of a property (is_count: a list length). */
static gs_err ascii_value(gs_ply *r, const gs_ply_elem *e, size_t item, const char *what,
                          int is_count, double *out)
{
    char tok[96], why[160];
    int too_long;
    GS_CHECK(next_token(r, tok, sizeof tok, &too_long), GS_ERR_FORMAT,
             "%s: line %d: file ends inside %s %zu of %zu (reading %s)", r->name, r->line,
             e->name, item, e->count, what);
    GS_CHECK(!too_long, GS_ERR_FORMAT, "%s: line %d: %s %zu: value of %s is too long", r->name,
             r->line, e->name, item, what);
    if (is_count) {
        int64_t v;
        GS_CHECK(gs_parse_i64(tok, 0, GS_PLY_MAX_LIST, &v, why, sizeof why), GS_ERR_FORMAT,
                 "%s: line %d: %s %zu: list length of %s: %s", r->name, r->line, e->name, item,
                 what, why);
        *out = (double)v;
        return GS_OK;
    }
    GS_CHECK(gs_parse_f64(tok, -INFINITY, INFINITY, out, why, sizeof why), GS_ERR_FORMAT,
             "%s: line %d: %s %zu: %s: %s", r->name, r->line, e->name, item, what, why);
    return GS_OK;
}

gs_err gs_ply_item(gs_ply *r, const gs_ply_elem *e, size_t item, double *vals, double *list,
                   size_t list_cap, size_t *list_n)
{
    if (list_n)
        *list_n = 0;
    gs_ply_skip_blanks(r);
    for (int k = 0; k < e->nprops; k++) {
        const gs_ply_prop *pr = &e->props[k];
        size_t cnt = 1;
        if (r->ascii) {
            if (pr->list) {
                double c;
                GS_CALL(ascii_value(r, e, item, "a list", 1, &c));
                cnt = (size_t)c;
            }
        } else if (pr->list) {
            size_t cs = types[pr->count_type].size;
            GS_CHECK(r->len - r->pos >= cs, GS_ERR_FORMAT,
                     "%s: byte %zu: file ends inside %s %zu of %zu", r->name, r->pos, e->name,
                     item, e->count);
            double c = load(r, (const unsigned char *)r->data + r->pos, pr->count_type);
            GS_CHECK(c >= 0 && c <= GS_PLY_MAX_LIST, GS_ERR_FORMAT,
                     "%s: byte %zu: %s %zu has a list of length %g: expected 0..%d", r->name,
                     r->pos, e->name, item, c, GS_PLY_MAX_LIST);
            r->pos += cs;
            cnt = (size_t)c;
        }
        int keep_list = pr->list && pr->role == GS_PLY_ROLE_LIST && list;
        if (keep_list) {
            GS_CHECK(cnt <= list_cap, GS_ERR_FORMAT,
                     "%s: %s %zu: list %s of %zu values: at most %zu are supported", r->name,
                     e->name, item, pr->name, cnt, list_cap);
            *list_n = cnt;
        }
        if (r->ascii) {
            for (size_t j = 0; j < cnt; j++) {
                double v;
                GS_CALL(ascii_value(r, e, item, pr->role >= 0 ? "a coordinate" : "a property", 0,
                                    &v));
                if (!pr->list && pr->role >= 0)
                    vals[pr->role] = v;
                else if (keep_list)
                    list[j] = v;
            }
        } else {
            size_t vs = types[pr->type].size;
            GS_CHECK((r->len - r->pos) / vs >= cnt, GS_ERR_FORMAT,
                     "%s: byte %zu: file ends inside %s %zu of %zu", r->name, r->pos, e->name,
                     item, e->count);
            const unsigned char *p = (const unsigned char *)r->data + r->pos;
            if (!pr->list && pr->role >= 0)
                vals[pr->role] = load(r, p, pr->type);
            else if (keep_list)
                for (size_t j = 0; j < cnt; j++)
                    list[j] = load(r, p + j * vs, pr->type);
            r->pos += cnt * vs;
        }
    }
    return GS_OK;
}

gs_err gs_ply_skip_elem(gs_ply *r, const gs_ply_elem *e)
{
    if (e->nprops == 0)
        return GS_OK;
    for (size_t item = 0; item < e->count; item++)
        GS_CALL(gs_ply_item(r, e, item, NULL, NULL, 0, NULL));
    return GS_OK;
}

gs_err gs_ply_check_fits(const gs_ply *r, const gs_ply_elem *e)
{
    size_t rec = 0;
    for (int k = 0; k < e->nprops; k++)
        rec += r->ascii ? 2
                        : (e->props[k].list ? types[e->props[k].count_type].size
                                            : types[e->props[k].type].size);
    /* ascii: the last value may end the file without a blank after it */
    size_t left = r->len - r->pos + (r->ascii ? 1 : 0);
    GS_CHECK(rec == 0 || left / rec >= e->count, GS_ERR_FORMAT,
             "%s: byte %zu: %zu items of element %s of at least %zu bytes each need more data "
             "than the %zu bytes left in the file",
             r->name, r->pos, e->count, e->name, rec, r->len - r->pos);
    return GS_OK;
}

int gs_ply_find_elem(const gs_ply *r, const char *name)
{
    for (int i = 0; i < r->nelems; i++)
        if (!strcmp(r->elems[i].name, name))
            return i;
    return -1;
}

int gs_ply_find_prop(const gs_ply_elem *e, const char *const *names, int n)
{
    for (int k = 0; k < e->nprops; k++)
        for (int j = 0; j < n; j++)
            if (!strcmp(e->props[k].name, names[j]))
                return k;
    return -1;
}

static gs_err parse_header(gs_ply *r)
{
    char line[512];
    char *w[9];
    int lineno = 0, have_format = 0;
    r->nelems = 0;
    for (;;) {
        GS_CHECK(r->pos < r->len, GS_ERR_FORMAT,
                 "%s: line %d: file ends inside the header (no end_header)", r->name, lineno);
        size_t e = r->pos;
        while (e < r->len && r->data[e] != '\n')
            e++;
        size_t n = e - r->pos;
        lineno++;
        GS_CHECK(n < sizeof line, GS_ERR_FORMAT, "%s: line %d: header line longer than %zu bytes",
                 r->name, lineno, sizeof line - 1);
        memcpy(line, r->data + r->pos, n);
        line[n] = '\0';
        if (n && line[n - 1] == '\r')
            line[--n] = '\0';
        r->pos = e < r->len ? e + 1 : e;
        for (size_t i = 0; i < n; i++)
            GS_CHECK(line[i] != '\0', GS_ERR_FORMAT, "%s: line %d: NUL byte in the header", r->name,
                     lineno);
        if (lineno == 1) {
            GS_CHECK(!strcmp(line, "ply"), GS_ERR_FORMAT,
                     "%s: line 1: not a PLY file (expected the magic line 'ply')", r->name);
            continue;
        }
        int nw = split_words(line, w, 8);
        if (nw == 0)
            continue;
        if (!strcmp(w[0], "comment") || !strcmp(w[0], "obj_info"))
            continue;
        if (!strcmp(w[0], "end_header"))
            break;
        if (!strcmp(w[0], "format")) {
            GS_CHECK(nw == 3 && !strcmp(w[2], "1.0"), GS_ERR_FORMAT,
                     "%s: line %d: expected 'format ascii|binary_little_endian|"
                     "binary_big_endian 1.0'", r->name, lineno);
            if (!strcmp(w[1], "ascii"))
                r->ascii = 1;
            else if (!strcmp(w[1], "binary_little_endian"))
                r->ascii = 0;
            else if (!strcmp(w[1], "binary_big_endian"))
                r->ascii = 0, r->big_endian = 1;
            else
                GS_RAISE(GS_ERR_FORMAT, "%s: line %d: unknown PLY format '%.64s'", r->name,
                         lineno, w[1]);
            have_format = 1;
            continue;
        }
        if (!strcmp(w[0], "element")) {
            GS_CHECK(nw == 3, GS_ERR_FORMAT, "%s: line %d: expected 'element NAME COUNT'", r->name,
                     lineno);
            GS_CHECK(r->nelems < GS_PLY_MAX_ELEMS, GS_ERR_FORMAT,
                     "%s: line %d: more than %d elements", r->name, lineno, GS_PLY_MAX_ELEMS);
            gs_ply_elem *el = &r->elems[r->nelems++];
            memset(el, 0, sizeof *el);
            snprintf(el->name, sizeof el->name, "%s", w[1]);
            el->line = lineno;
            int64_t c;
            char why[128];
            GS_CHECK(gs_parse_i64(w[2], 0, (int64_t)GS_PLY_MAX_COUNT, &c, why, sizeof why),
                     GS_ERR_FORMAT, "%s: line %d: element %s count: %s", r->name, lineno, el->name,
                     why);
            el->count = (size_t)c;
            continue;
        }
        if (!strcmp(w[0], "property")) {
            GS_CHECK(r->nelems > 0, GS_ERR_FORMAT, "%s: line %d: property before any element",
                     r->name, lineno);
            gs_ply_elem *el = &r->elems[r->nelems - 1];
            GS_CHECK(el->nprops < GS_PLY_MAX_PROPS, GS_ERR_FORMAT,
                     "%s: line %d: element %s has more than %d properties", r->name, lineno,
                     el->name, GS_PLY_MAX_PROPS);
            gs_ply_prop *pr = &el->props[el->nprops];
            memset(pr, 0, sizeof *pr);
            pr->role = GS_PLY_ROLE_SKIP;
            const char *pname;
            if (nw >= 2 && !strcmp(w[1], "list")) {
                GS_CHECK(nw == 5, GS_ERR_FORMAT,
                         "%s: line %d: expected 'property list COUNT_TYPE ITEM_TYPE NAME'",
                         r->name, lineno);
                pr->list = 1;
                pr->count_type = type_from_name(w[2]);
                pr->type = type_from_name(w[3]);
                GS_CHECK(pr->count_type >= 0 && pr->count_type != GS_PLY_F32 &&
                             pr->count_type != GS_PLY_F64,
                         GS_ERR_FORMAT, "%s: line %d: list count type '%.64s': expected an integer type",
                         r->name, lineno, w[2]);
                GS_CHECK(pr->type >= 0, GS_ERR_FORMAT, "%s: line %d: unknown property type '%.64s'",
                         r->name, lineno, w[3]);
                pname = w[4];
            } else {
                GS_CHECK(nw == 3, GS_ERR_FORMAT, "%s: line %d: expected 'property TYPE NAME'",
                         r->name, lineno);
                pr->type = type_from_name(w[1]);
                GS_CHECK(pr->type >= 0, GS_ERR_FORMAT, "%s: line %d: unknown property type '%.64s'",
                         r->name, lineno, w[1]);
                pname = w[2];
            }
            snprintf(pr->name, sizeof pr->name, "%s", pname);
            for (int k = 0; k < el->nprops; k++)
                GS_CHECK(strcmp(el->props[k].name, pr->name), GS_ERR_FORMAT,
                         "%s: line %d: %s property %s appears twice", r->name, lineno, el->name,
                         pr->name);
            el->nprops++;
            continue;
        }
        GS_RAISE(GS_ERR_FORMAT, "%s: line %d: unexpected header line starting with '%.64s'",
                 r->name, lineno, w[0]);
    }
    GS_CHECK(have_format, GS_ERR_FORMAT, "%s: the header has no 'format' line", r->name);
    r->line = lineno + 1;
    return GS_OK;
}

gs_err gs_ply_begin(gs_ply *r, const char *data, size_t len, const char *name)
{
    memset(r, 0, sizeof *r);
    r->name = name;
    r->data = data;
    r->len = len;
    r->line = 1;
    GS_CALL(gs_alloc_array((void **)&r->elems, GS_PLY_MAX_ELEMS, sizeof *r->elems, "PLY header"));
    gs_err err = parse_header(r);
    if (err)
        gs_ply_end(r);
    GS_CALL(err);
    return GS_OK;
}

void gs_ply_end(gs_ply *r)
{
    GS_FREE(r->elems);
}
