/* PLY point sets (vertices with normals); see include/geosynth/pointply.h. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "geosynth/pointply.h"

#define MAX_ELEMS 32
#define MAX_PROPS 64
#define MAX_FILE_BYTES ((size_t)1 << 36)

enum { T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_F32, T_F64, T_COUNT };

static const struct {
    const char *name, *alias;
    size_t size;
} types[T_COUNT] = {
    {"char", "int8", 1},    {"uchar", "uint8", 1},    {"short", "int16", 2},
    {"ushort", "uint16", 2}, {"int", "int32", 4},      {"uint", "uint32", 4},
    {"float", "float32", 4}, {"double", "float64", 8},
};

typedef struct ply_prop {
    int type;       /* value type */
    int list;       /* 1: list property */
    int count_type; /* list count type */
    int role;       /* 0..5 = x y z nx ny nz, -1 = skipped */
} ply_prop;

typedef struct ply_elem {
    char name[64];
    size_t count;
    ply_prop props[MAX_PROPS];
    int nprops;
    int line;
} ply_elem;

typedef struct ply_reader {
    const char *name;
    const char *data;
    size_t len, pos;
    int line; /* ASCII: current line (1-based) */
} ply_reader;

static int type_from_name(const char *s)
{
    for (int t = 0; t < T_COUNT; t++)
        if (!strcmp(s, types[t].name) || !strcmp(s, types[t].alias))
            return t;
    return -1;
}

static int role_from_name(const char *s)
{
    static const char *names[6] = {"x", "y", "z", "nx", "ny", "nz"};
    static const char *alt[6] = {"", "", "", "normal_x", "normal_y", "normal_z"};
    for (int r = 0; r < 6; r++)
        if (!strcmp(s, names[r]) || (alt[r][0] && !strcmp(s, alt[r])))
            return r;
    return -1;
}

/* Splits a header line into at most 8 words (in place in buf). */
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

/* Little-endian value of type t at p, as double (exact for every type). */
static double load_le(const unsigned char *p, int t)
{
    uint64_t u = 0;
    for (size_t i = 0; i < types[t].size; i++)
        u |= (uint64_t)p[i] << (8 * i);
    switch (t) {
    case T_I8:
        return (double)(int8_t)u;
    case T_U8:
        return (double)(uint8_t)u;
    case T_I16:
        return (double)(int16_t)u;
    case T_U16:
        return (double)(uint16_t)u;
    case T_I32:
        return (double)(int32_t)(uint32_t)u;
    case T_U32:
        return (double)(uint32_t)u;
    case T_F32: {
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

/* Skips ASCII blanks and line ends, counting lines. */
static void skip_blanks(ply_reader *r)
{
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
static int next_token(ply_reader *r, char *tok, size_t cap, int *too_long)
{
    *too_long = 0;
    skip_blanks(r);
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

/* One ASCII value of a property (count == 1 for a list count). */
static gs_err ascii_value(ply_reader *r, const ply_elem *e, size_t item, const char *what,
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
        GS_CHECK(gs_parse_i64(tok, 0, 1000000, &v, why, sizeof why), GS_ERR_FORMAT,
                 "%s: line %d: %s %zu: list length of %s: %s", r->name, r->line, e->name, item,
                 what, why);
        *out = (double)v;
        return GS_OK;
    }
    GS_CHECK(gs_parse_f64(tok, -INFINITY, INFINITY, out, why, sizeof why), GS_ERR_FORMAT,
             "%s: line %d: %s %zu: %s: %s", r->name, r->line, e->name, item, what, why);
    return GS_OK;
}

/* Reads (or skips) one item of element e; role values go to vals[6]. */
static gs_err read_item(ply_reader *r, int ascii, const ply_elem *e, size_t item, double vals[6])
{
    for (int k = 0; k < e->nprops; k++) {
        const ply_prop *pr = &e->props[k];
        if (ascii) {
            size_t cnt = 1;
            if (pr->list) {
                double c;
                GS_CALL(ascii_value(r, e, item, "a list", 1, &c));
                cnt = (size_t)c;
            }
            for (size_t j = 0; j < cnt; j++) {
                double v;
                GS_CALL(ascii_value(r, e, item, pr->role >= 0 ? "a coordinate" : "a property", 0,
                                    &v));
                if (!pr->list && pr->role >= 0)
                    vals[pr->role] = v;
            }
        } else {
            size_t cnt = 1;
            if (pr->list) {
                size_t cs = types[pr->count_type].size;
                GS_CHECK(r->len - r->pos >= cs, GS_ERR_FORMAT,
                         "%s: byte %zu: file ends inside %s %zu of %zu", r->name, r->pos, e->name,
                         item, e->count);
                double c = load_le((const unsigned char *)r->data + r->pos, pr->count_type);
                GS_CHECK(c >= 0 && c <= 1000000, GS_ERR_FORMAT,
                         "%s: byte %zu: %s %zu has a list of length %g: expected 0..1000000",
                         r->name, r->pos, e->name, item, c);
                r->pos += cs;
                cnt = (size_t)c;
            }
            size_t vs = types[pr->type].size;
            GS_CHECK((r->len - r->pos) / vs >= cnt, GS_ERR_FORMAT,
                     "%s: byte %zu: file ends inside %s %zu of %zu", r->name, r->pos, e->name,
                     item, e->count);
            if (!pr->list && pr->role >= 0)
                vals[pr->role] = load_le((const unsigned char *)r->data + r->pos, pr->type);
            r->pos += cnt * vs;
        }
    }
    return GS_OK;
}

/* Parses the header; on success r->pos is the first data byte. */
static gs_err parse_header(ply_reader *r, ply_elem *elems, int *nelems, int *ascii)
{
    char line[512];
    char *w[9];
    int lineno = 0, have_format = 0;
    *nelems = 0;
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
                     "%s: line %d: expected 'format ascii|binary_little_endian 1.0'", r->name,
                     lineno);
            if (!strcmp(w[1], "ascii"))
                *ascii = 1;
            else if (!strcmp(w[1], "binary_little_endian"))
                *ascii = 0;
            else if (!strcmp(w[1], "binary_big_endian"))
                GS_RAISE(GS_ERR_FORMAT,
                         "%s: line %d: binary_big_endian PLY is not supported: convert it to "
                         "ascii or binary_little_endian", r->name, lineno);
            else
                GS_RAISE(GS_ERR_FORMAT, "%s: line %d: unknown PLY format '%s'", r->name, lineno,
                         w[1]);
            have_format = 1;
            continue;
        }
        if (!strcmp(w[0], "element")) {
            GS_CHECK(nw == 3, GS_ERR_FORMAT, "%s: line %d: expected 'element NAME COUNT'", r->name,
                     lineno);
            GS_CHECK(*nelems < MAX_ELEMS, GS_ERR_FORMAT, "%s: line %d: more than %d elements",
                     r->name, lineno, MAX_ELEMS);
            ply_elem *el = &elems[(*nelems)++];
            memset(el, 0, sizeof *el);
            snprintf(el->name, sizeof el->name, "%s", w[1]);
            el->line = lineno;
            int64_t c;
            char why[128];
            GS_CHECK(gs_parse_i64(w[2], 0, (int64_t)GS_POINTPLY_MAX_POINTS, &c, why, sizeof why),
                     GS_ERR_FORMAT, "%s: line %d: element %s count: %s", r->name, lineno, w[1], why);
            el->count = (size_t)c;
            continue;
        }
        if (!strcmp(w[0], "property")) {
            GS_CHECK(*nelems > 0, GS_ERR_FORMAT, "%s: line %d: property before any element",
                     r->name, lineno);
            ply_elem *el = &elems[*nelems - 1];
            GS_CHECK(el->nprops < MAX_PROPS, GS_ERR_FORMAT,
                     "%s: line %d: element %s has more than %d properties", r->name, lineno,
                     el->name, MAX_PROPS);
            ply_prop *pr = &el->props[el->nprops];
            memset(pr, 0, sizeof *pr);
            pr->role = -1;
            const char *pname;
            if (nw >= 2 && !strcmp(w[1], "list")) {
                GS_CHECK(nw == 5, GS_ERR_FORMAT,
                         "%s: line %d: expected 'property list COUNT_TYPE ITEM_TYPE NAME'",
                         r->name, lineno);
                pr->list = 1;
                pr->count_type = type_from_name(w[2]);
                pr->type = type_from_name(w[3]);
                GS_CHECK(pr->count_type >= 0 && pr->count_type != T_F32 && pr->count_type != T_F64,
                         GS_ERR_FORMAT, "%s: line %d: list count type '%s': expected an integer type",
                         r->name, lineno, w[2]);
                GS_CHECK(pr->type >= 0, GS_ERR_FORMAT, "%s: line %d: unknown property type '%s'",
                         r->name, lineno, w[3]);
                pname = w[4];
            } else {
                GS_CHECK(nw == 3, GS_ERR_FORMAT, "%s: line %d: expected 'property TYPE NAME'",
                         r->name, lineno);
                pr->type = type_from_name(w[1]);
                GS_CHECK(pr->type >= 0, GS_ERR_FORMAT, "%s: line %d: unknown property type '%s'",
                         r->name, lineno, w[1]);
                pname = w[2];
            }
            if (!strcmp(el->name, "vertex")) {
                int role = role_from_name(pname);
                if (role >= 0) {
                    GS_CHECK(!pr->list, GS_ERR_FORMAT,
                             "%s: line %d: vertex property %s is a list: expected a scalar",
                             r->name, lineno, pname);
                    for (int k = 0; k < el->nprops; k++)
                        GS_CHECK(el->props[k].role != role, GS_ERR_FORMAT,
                                 "%s: line %d: vertex property %s appears twice", r->name, lineno,
                                 pname);
                    pr->role = role;
                }
            }
            el->nprops++;
            continue;
        }
        GS_RAISE(GS_ERR_FORMAT, "%s: line %d: unexpected header line starting with '%s'", r->name,
                 lineno, w[0]);
    }
    GS_CHECK(have_format, GS_ERR_FORMAT, "%s: the header has no 'format' line", r->name);
    r->line = lineno + 1;
    return GS_OK;
}

gs_err gs_pointply_parse(const char *data, size_t len, const char *name, int require_normals,
                         gs_pointply *out)
{
    memset(out, 0, sizeof *out);
    ply_elem *elems = NULL;
    GS_CALL(gs_alloc_array((void **)&elems, MAX_ELEMS, sizeof *elems, "PLY header"));
    ply_reader r = {name, data, len, 0, 1};
    int nelems = 0, ascii = 0;
    double *v = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, parse_header(&r, elems, &nelems, &ascii), done);
    int vi = -1;
    for (int i = 0; i < nelems; i++)
        if (!strcmp(elems[i].name, "vertex")) {
            vi = i;
            break;
        }
    GS_TRY_CHECK(err, vi >= 0, GS_ERR_FORMAT, done,
                 "%s: the header declares no 'vertex' element: expected points with x y z", name);
    const ply_elem *ve = &elems[vi];
    int has[6] = {0};
    for (int k = 0; k < ve->nprops; k++)
        if (ve->props[k].role >= 0)
            has[ve->props[k].role] = 1;
    static const char *rn[6] = {"x", "y", "z", "nx", "ny", "nz"};
    for (int k = 0; k < 3; k++)
        GS_TRY_CHECK(err, has[k], GS_ERR_FORMAT, done,
                     "%s: line %d: element vertex has no property %s: expected x y z", name,
                     ve->line, rn[k]);
    int normals = has[3] + has[4] + has[5];
    GS_TRY_CHECK(err, normals == 0 || normals == 3, GS_ERR_FORMAT, done,
                 "%s: line %d: element vertex has only some of nx ny nz", name, ve->line);
    GS_TRY_CHECK(err, normals == 3 || !require_normals, GS_ERR_FORMAT, done,
                 "%s: line %d: element vertex has no normals (nx ny nz): oriented points are "
                 "needed (estimate and orient normals first, or give a mesh)", name, ve->line);
    GS_TRY_CHECK(err, ve->count > 0, GS_ERR_FORMAT, done, "%s: element vertex has 0 points", name);
    if (!ascii) {
        /* A cheap bound before allocating: every vertex needs its fixed bytes. */
        size_t rec = 0;
        for (int k = 0; k < ve->nprops; k++)
            rec += ve->props[k].list ? types[ve->props[k].count_type].size
                                     : types[ve->props[k].type].size;
        GS_TRY_CHECK(err, rec == 0 || (len - r.pos) / rec >= ve->count, GS_ERR_FORMAT, done,
                     "%s: byte %zu: %zu vertices of %zu bytes need more data than the %zu bytes "
                     "left in the file", name, r.pos, ve->count, rec, len - r.pos);
    }
    GS_TRY(err, gs_alloc_array((void **)&v, ve->count, 6 * sizeof *v, "PLY points"), done);
    for (int i = 0; i < nelems && i <= vi; i++) {
        const ply_elem *el = &elems[i];
        for (size_t item = 0; item < el->count; item++) {
            double vals[6] = {0, 0, 0, 0, 0, 0};
            if (ascii)
                skip_blanks(&r);
            size_t at = r.pos;
            int at_line = r.line;
            GS_TRY(err, read_item(&r, ascii, el, item, vals), done);
            if (i != vi)
                continue;
            double *o = v + 6 * item;
            memcpy(o, vals, sizeof vals);
            for (int k = 0; k < 3; k++)
                if (!isfinite(o[k])) {
                    if (ascii)
                        err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                             "%s: line %d: vertex %zu has a non-finite coordinate",
                                             name, at_line, item);
                    else
                        err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                             "%s: byte %zu: vertex %zu has a non-finite coordinate",
                                             name, at, item);
                    goto done;
                }
            if (normals) {
                double l = sqrt(o[3] * o[3] + o[4] * o[4] + o[5] * o[5]);
                if (!(l > 0 && isfinite(l))) {
                    if (ascii)
                        err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                             "%s: line %d: vertex %zu has a zero or non-finite "
                                             "normal (%g, %g, %g)", name, at_line, item, o[3], o[4],
                                             o[5]);
                    else
                        err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                             "%s: byte %zu: vertex %zu has a zero or non-finite "
                                             "normal (%g, %g, %g)", name, at, item, o[3], o[4], o[5]);
                    goto done;
                }
                if (l != 1.0)
                    for (int k = 3; k < 6; k++)
                        o[k] /= l;
            }
        }
    }
    out->n = ve->count;
    out->v = v;
    out->has_normals = normals == 3;
    v = NULL;
done:
    gs_free(v);
    gs_free(elems);
    return err;
}

gs_err gs_pointply_read(const char *path, int require_normals, gs_pointply *out)
{
    memset(out, 0, sizeof *out);
    char *data = NULL;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, MAX_FILE_BYTES, &data, &len));
    gs_err err = gs_pointply_parse(data, len, path, require_normals, out);
    gs_free(data);
    GS_CALL(err);
    return GS_OK;
}

void gs_pointply_destroy(gs_pointply *p)
{
    gs_free(p->v);
    memset(p, 0, sizeof *p);
}

gs_err gs_pointply_write(const char *path, const double *v, size_t n, int with_normals,
                         gs_pointply_format format)
{
    GS_CHECK(n <= GS_POINTPLY_MAX_POINTS, GS_ERR_ARG, "%s: %zu points, at most %zu can be written",
             path, n, GS_POINTPLY_MAX_POINTS);
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    FILE *f = af.f;
    int ok = fprintf(f, "ply\nformat %s 1.0\ncomment geosynth oriented point set\n"
                        "element vertex %zu\nproperty double x\nproperty double y\n"
                        "property double z\n%send_header\n",
                     format == GS_POINTPLY_ASCII ? "ascii" : "binary_little_endian", n,
                     with_normals ? "property double nx\nproperty double ny\nproperty double nz\n"
                                  : "") > 0;
    int nv = with_normals ? 6 : 3;
    for (size_t i = 0; i < n && ok; i++) {
        const double *o = v + 6 * i;
        if (format == GS_POINTPLY_ASCII) {
            for (int k = 0; k < nv && ok; k++)
                ok = fprintf(f, k + 1 < nv ? "%.17g " : "%.17g\n", o[k]) > 0;
        } else {
            unsigned char b[48];
            for (int k = 0; k < nv; k++) {
                uint64_t u;
                memcpy(&u, &o[k], sizeof u);
                for (int j = 0; j < 8; j++)
                    b[8 * k + j] = (unsigned char)(u >> (8 * j));
            }
            ok = fwrite(b, 8, (size_t)nv, f) == (size_t)nv;
        }
    }
    if (!ok) {
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_IO, "%s: write failed (disk full?)", path);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}
