/* Bounded readers of our own for triangle meshes in PLY, OFF, STL and OBJ;
 * see include/geosynth/mesh.h.
 *
 * Every count in a header is checked against the bytes left before anything
 * is allocated, arrays grow only with what the file really holds (so memory
 * is a small multiple of the file size), and every loop advances through the
 * file: a mutated or truncated file costs at most linear time and gives an
 * error naming the file and the line or byte, never an abort, a crash or a
 * spin (the assimp importer used before did all three on mutated meshes).
 *
 * The result matches what assimp gave (triangulation, identical-vertex
 * joining, pre-transformed vertices): PLY and OFF vertices in file order, OBJ
 * and STL ones in the order faces first use them; unused ones dropped,
 * welded by exact position, degenerate triangles dropped. Coordinates are
 * correctly rounded to float (assimp's were an ulp off for a few). Quads are split as assimp splits them (at a concave
 * corner when there is one); larger polygons are fanned from their first
 * corner.
 */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/parse.h"
#include "io/ply_internal.h"

#define MESH_MAX_FILE_BYTES ((size_t)1 << 34)
#define MESH_MAX_POLY 65536 /* corners of one polygon */

/* ------------------------------------------------------------ growing arrays */

typedef struct raw_mesh {
    const char *name;
    float *pos;
    size_t nv, cap_v;
    uint32_t *tris;
    size_t nt, cap_t;
    uint32_t poly[MESH_MAX_POLY]; /* the polygon being triangulated */
} raw_mesh;

static gs_err grow(void **p, size_t *cap, size_t need, size_t elem, const char *what)
{
    if (need <= *cap)
        return GS_OK;
    size_t c = *cap ? *cap : 1024;
    while (c < need)
        c *= 2;
    GS_CHECK(c / 3 <= GS_MESH_MAX_ELEMS, GS_ERR_FORMAT,
             "more than %zu mesh %s: at most that many are supported", GS_MESH_MAX_ELEMS, what);
    void *q = NULL;
    GS_CALL(gs_alloc_array(&q, c, elem, what));
    if (*cap)
        memcpy(q, *p, *cap * elem);
    gs_free(*p);
    *p = q;
    *cap = c;
    return GS_OK;
}

static gs_err add_vertex(raw_mesh *m, double x, double y, double z, const char *where)
{
    GS_CHECK(isfinite(x) && isfinite(y) && isfinite(z) && fabs(x) <= 3.4e38 &&
                 fabs(y) <= 3.4e38 && fabs(z) <= 3.4e38,
             GS_ERR_FORMAT,
             "%s: %s: vertex %zu has a non-finite coordinate (%g %g %g): expected finite numbers",
             m->name, where, m->nv, x, y, z);
    GS_CHECK(m->nv < GS_MESH_MAX_ELEMS, GS_ERR_FORMAT,
             "%s: %s: more than %zu vertices: at most that many are supported", m->name, where,
             GS_MESH_MAX_ELEMS);
    GS_CALL(grow((void **)&m->pos, &m->cap_v, 3 * (m->nv + 1), sizeof(float), "vertices"));
    float *p = m->pos + 3 * m->nv++;
    p[0] = (float)x;
    p[1] = (float)y;
    p[2] = (float)z;
    return GS_OK;
}

static gs_err add_tri(raw_mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    GS_CHECK(m->nt < GS_MESH_MAX_ELEMS, GS_ERR_FORMAT,
             "%s: more than %zu triangles: at most that many are supported", m->name,
             GS_MESH_MAX_ELEMS);
    GS_CALL(grow((void **)&m->tris, &m->cap_t, 3 * (m->nt + 1), sizeof(uint32_t), "triangles"));
    uint32_t *t = m->tris + 3 * m->nt++;
    t[0] = a;
    t[1] = b;
    t[2] = c;
    return GS_OK;
}

/* assimp's quad split: from the first concave corner, else corner 0. Needs
 * the four positions, so the indices must be in range (checked by callers). */
static int quad_start(const raw_mesh *m, const uint32_t *q)
{
    for (int i = 0; i < 4; i++) {
        const float *v = m->pos + 3 * (size_t)q[i], *v0 = m->pos + 3 * (size_t)q[(i + 3) % 4],
                    *v1 = m->pos + 3 * (size_t)q[(i + 2) % 4],
                    *v2 = m->pos + 3 * (size_t)q[(i + 1) % 4];
        float l[3], d[3], r[3];
        for (int k = 0; k < 3; k++) {
            l[k] = v0[k] - v[k];
            d[k] = v1[k] - v[k];
            r[k] = v2[k] - v[k];
        }
        float ll = sqrtf(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]),
              dl = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]),
              rl = sqrtf(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
        if (!(ll > 0 && dl > 0 && rl > 0))
            continue;
        float cl = (l[0] * d[0] + l[1] * d[1] + l[2] * d[2]) / (ll * dl),
              cr = (r[0] * d[0] + r[1] * d[1] + r[2] * d[2]) / (rl * dl);
        cl = cl > 1 ? 1 : cl < -1 ? -1 : cl;
        cr = cr > 1 ? 1 : cr < -1 ? -1 : cr;
        if (acosf(cl) + acosf(cr) > 3.14159265358979f)
            return i;
    }
    return 0;
}

/* Triangulates m->poly[0..n-1] (indices already checked < m->nv when
 * checked != 0; OBJ checks them at the end and passes 0). Polygons of fewer
 * than 3 corners (points, lines) are dropped. */
static gs_err add_poly(raw_mesh *m, size_t n, int checked)
{
    const uint32_t *p = m->poly;
    if (n < 3)
        return GS_OK;
    if (n == 4 && checked) {
        int s = quad_start(m, p);
        GS_CALL(add_tri(m, p[s], p[(s + 1) % 4], p[(s + 2) % 4]));
        GS_CALL(add_tri(m, p[s], p[(s + 2) % 4], p[(s + 3) % 4]));
        return GS_OK;
    }
    for (size_t k = 1; k + 1 < n; k++)
        GS_CALL(add_tri(m, p[0], p[k], p[k + 1]));
    return GS_OK;
}

static void raw_free(raw_mesh *m)
{
    gs_free(m->pos);
    gs_free(m->tris);
    m->pos = NULL;
    m->tris = NULL;
}

/* ------------------------------------------------------------ text scanning */

typedef struct text {
    const char *name, *s;
    size_t len, pos;
    int line;
} text;

/* Skips blanks (not line ends). */
static void skip_sp(text *t)
{
    while (t->pos < t->len && (t->s[t->pos] == ' ' || t->s[t->pos] == '\t' ||
                               t->s[t->pos] == '\r' || t->s[t->pos] == '\f' ||
                               t->s[t->pos] == '\v'))
        t->pos++;
}

/* Moves past the end of the current line. */
static void next_line(text *t)
{
    const char *nl = t->pos < t->len ? memchr(t->s + t->pos, '\n', t->len - t->pos) : NULL;
    t->pos = nl ? (size_t)(nl - t->s) + 1 : t->len;
    t->line++;
}

static int at_eol(text *t)
{
    skip_sp(t);
    return t->pos >= t->len || t->s[t->pos] == '\n';
}

/* Next token of the current line into tok[cap] (0: none left on the line;
 * tokens longer than cap-1 are cut and flagged). */
static int token(text *t, char *tok, size_t cap, int *too_long)
{
    *too_long = 0;
    if (at_eol(t))
        return 0;
    size_t n = 0;
    while (t->pos < t->len) {
        char c = t->s[t->pos];
        if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v')
            break;
        if (n + 1 < cap)
            tok[n++] = c;
        else
            *too_long = 1;
        t->pos++;
    }
    tok[n] = '\0';
    return 1;
}

/* A coordinate, parsed straight to the nearest float (strtof: correctly
 * rounded; assimp's fast_atof was off by an ulp on some inputs). */
static gs_err number(text *t, const char *what, double *out)
{
    char tok[96];
    int too_long;
    GS_CHECK(token(t, tok, sizeof tok, &too_long), GS_ERR_FORMAT,
             "%s: line %d: %s is missing", t->name, t->line, what);
    GS_CHECK(!too_long, GS_ERR_FORMAT, "%s: line %d: %s is longer than %zu characters", t->name,
             t->line, what, sizeof tok - 1);
    char *end;
    errno = 0;
    float v = strtof(tok, &end);
    GS_CHECK(end != tok && *end == '\0', GS_ERR_FORMAT, "%s: line %d: %s: expected a number, got '%s'",
             t->name, t->line, what, tok);
    GS_CHECK(isfinite(v), GS_ERR_FORMAT,
             "%s: line %d: %s: '%s' is not a finite single-precision number", t->name, t->line,
             what, tok);
    *out = v;
    return GS_OK;
}

static gs_err integer(text *t, const char *what, int64_t lo, int64_t hi, int64_t *out)
{
    char tok[32], why[160];
    int too_long;
    GS_CHECK(token(t, tok, sizeof tok, &too_long), GS_ERR_FORMAT,
             "%s: line %d: %s is missing", t->name, t->line, what);
    GS_CHECK(!too_long, GS_ERR_FORMAT, "%s: line %d: %s is too long", t->name, t->line, what);
    GS_CHECK(gs_parse_i64(tok, lo, hi, out, why, sizeof why), GS_ERR_FORMAT,
             "%s: line %d: %s: %s", t->name, t->line, what, why);
    return GS_OK;
}

/* ------------------------------------------------------------ PLY */

static gs_err parse_ply(raw_mesh *m, const char *data, size_t len)
{
    gs_ply r;
    GS_CALL(gs_ply_begin(&r, data, len, m->name));
    gs_err err = GS_OK;
    double *list = NULL;
    int vi = gs_ply_find_elem(&r, "vertex"), fi = gs_ply_find_elem(&r, "face");
    GS_TRY_CHECK(err, vi >= 0 && fi >= 0, GS_ERR_FORMAT, done,
                 "%s: the header declares no '%s' element: expected a triangle mesh (vertex and "
                 "face elements)", m->name, vi < 0 ? "vertex" : "face");
    GS_TRY_CHECK(err, vi < fi, GS_ERR_FORMAT, done,
                 "%s: the face element comes before the vertex element: not supported", m->name);
    gs_ply_elem *ve = &r.elems[vi], *fe = &r.elems[fi];
    static const char *axis[3] = {"x", "y", "z"};
    for (int c = 0; c < 3; c++) {
        int k = gs_ply_find_prop(ve, &axis[c], 1);
        GS_TRY_CHECK(err, k >= 0 && !ve->props[k].list, GS_ERR_FORMAT, done,
                     "%s: line %d: element vertex has no scalar property %s: expected x y z",
                     m->name, ve->line, axis[c]);
        ve->props[k].role = c;
    }
    static const char *idx_names[2] = {"vertex_indices", "vertex_index"};
    int k = gs_ply_find_prop(fe, idx_names, 2);
    GS_TRY_CHECK(err, k >= 0 && fe->props[k].list, GS_ERR_FORMAT, done,
                 "%s: line %d: element face has no list property vertex_indices", m->name,
                 fe->line);
    fe->props[k].role = GS_PLY_ROLE_LIST;
    for (int i = 0; i < fi; i++) {
        const gs_ply_elem *e = &r.elems[i];
        if (i != vi) {
            GS_TRY(err, gs_ply_skip_elem(&r, e), done);
            continue;
        }
        GS_TRY(err, gs_ply_check_fits(&r, e), done);
        for (size_t item = 0; item < e->count; item++) {
            double v[3] = {0, 0, 0};
            gs_ply_skip_blanks(&r);
            char where[64];
            if (r.ascii)
                snprintf(where, sizeof where, "line %d", r.line);
            else
                snprintf(where, sizeof where, "byte %zu", r.pos);
            GS_TRY(err, gs_ply_item(&r, e, item, v, NULL, 0, NULL), done);
            GS_TRY(err, add_vertex(m, v[0], v[1], v[2], where), done);
        }
    }
    GS_TRY(err, gs_ply_check_fits(&r, fe), done);
    GS_TRY(err, gs_alloc_array((void **)&list, MESH_MAX_POLY, sizeof *list, "PLY face"), done);
    for (size_t item = 0; item < fe->count; item++) {
        size_t n = 0;
        GS_TRY(err, gs_ply_item(&r, fe, item, NULL, list, MESH_MAX_POLY, &n), done);
        for (size_t j = 0; j < n; j++) {
            GS_TRY_CHECK(err, list[j] >= 0 && list[j] < (double)m->nv && list[j] == floor(list[j]),
                         GS_ERR_FORMAT, done,
                         "%s: face %zu uses vertex %.17g but the file has %zu vertices (0 to "
                         "%zu)", m->name, item, list[j], m->nv, m->nv ? m->nv - 1 : 0);
            m->poly[j] = (uint32_t)list[j];
        }
        GS_TRY(err, add_poly(m, n, 1), done);
    }
done:
    gs_free(list);
    gs_ply_end(&r);
    return err;
}

/* ------------------------------------------------------------ OFF */

/* Skips blank lines and # comments. */
static int off_next_record(text *t)
{
    for (;;) {
        skip_sp(t);
        if (t->pos >= t->len)
            return 0;
        char c = t->s[t->pos];
        if (c == '\n' || c == '#') {
            next_line(t);
            continue;
        }
        return 1;
    }
}

static gs_err parse_off(raw_mesh *m, const char *data, size_t len)
{
    text t = {m->name, data, len, 0, 1};
    char tok[32];
    int too_long;
    off_next_record(&t);
    GS_CHECK(token(&t, tok, sizeof tok, &too_long) && !too_long, GS_ERR_FORMAT,
             "%s: line %d: not an OFF file (expected OFF, COFF, NOFF, CNOFF or STOFF)", m->name,
             t.line);
    size_t tl = strlen(tok);
    GS_CHECK(tl >= 3 && !strcmp(tok + tl - 3, "OFF") &&
                 (tl == 3 || !strcmp(tok, "COFF") || !strcmp(tok, "NOFF") ||
                  !strcmp(tok, "CNOFF") || !strcmp(tok, "NCOFF") || !strcmp(tok, "STOFF") ||
                  !strcmp(tok, "STCOFF") || !strcmp(tok, "STNOFF") || !strcmp(tok, "STCNOFF")),
             GS_ERR_FORMAT,
             "%s: line %d: '%.31s': not an OFF file, or a variant that is not supported "
             "(4OFF, nOFF; expected OFF, COFF, NOFF, CNOFF or STOFF)", m->name, t.line, tok);
    GS_CHECK(at_eol(&t) || (t.s[t.pos] != 'B' && t.s[t.pos] != 'b'), GS_ERR_FORMAT,
             "%s: line %d: binary OFF is not supported: convert it to text OFF", m->name, t.line);
    if (at_eol(&t)) {
        next_line(&t);
        GS_CHECK(off_next_record(&t), GS_ERR_FORMAT,
                 "%s: line %d: file ends before the counts line 'VERTICES FACES EDGES'", m->name,
                 t.line);
    }
    int64_t nv, nf, ne = 0;
    /* Each vertex and face takes a line of at least 2 bytes. */
    int64_t most = (int64_t)(len / 2 + 1);
    GS_CALL(integer(&t, "vertex count", 0, most, &nv));
    GS_CALL(integer(&t, "face count", 0, most - nv, &nf));
    if (!at_eol(&t))
        GS_CALL(integer(&t, "edge count", 0, INT64_MAX, &ne));
    next_line(&t);
    for (int64_t i = 0; i < nv; i++) {
        GS_CHECK(off_next_record(&t), GS_ERR_FORMAT,
                 "%s: line %d: file ends at vertex %lld of %lld", m->name, t.line, (long long)i,
                 (long long)nv);
        double v[3];
        for (int c = 0; c < 3; c++)
            GS_CALL(number(&t, "a vertex coordinate", &v[c]));
        char where[32];
        snprintf(where, sizeof where, "line %d", t.line);
        GS_CALL(add_vertex(m, v[0], v[1], v[2], where));
        next_line(&t); /* normals, colours, texture coordinates */
    }
    for (int64_t i = 0; i < nf; i++) {
        GS_CHECK(off_next_record(&t), GS_ERR_FORMAT,
                 "%s: line %d: file ends at face %lld of %lld", m->name, t.line, (long long)i,
                 (long long)nf);
        int64_t n;
        GS_CALL(integer(&t, "the face's corner count", 0, MESH_MAX_POLY, &n));
        for (int64_t j = 0; j < n; j++) {
            int64_t ix;
            GS_CALL(integer(&t, "a face's vertex index", 0, (int64_t)m->nv - 1, &ix));
            m->poly[j] = (uint32_t)ix;
        }
        GS_CALL(add_poly(m, (size_t)n, 1));
        next_line(&t); /* colour */
    }
    return GS_OK;
}

/* ------------------------------------------------------------ STL */

static float le_f32(const unsigned char *p)
{
    uint32_t u = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                 (uint32_t)p[3] << 24;
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static gs_err parse_stl_binary(raw_mesh *m, const unsigned char *d, size_t n)
{
    GS_CHECK(n <= GS_MESH_MAX_ELEMS / 3, GS_ERR_FORMAT,
             "%s: %zu facets: at most %zu are supported", m->name, n, GS_MESH_MAX_ELEMS / 3);
    for (size_t i = 0; i < n; i++) {
        const unsigned char *f = d + 84 + 50 * i + 12;
        for (int c = 0; c < 3; c++) {
            char where[48];
            snprintf(where, sizeof where, "byte %zu (facet %zu)", 84 + 50 * i + 12 + 12 * c, i);
            GS_CALL(add_vertex(m, le_f32(f + 12 * c), le_f32(f + 12 * c + 4),
                               le_f32(f + 12 * c + 8), where));
        }
        GS_CALL(add_tri(m, (uint32_t)(m->nv - 3), (uint32_t)(m->nv - 2), (uint32_t)(m->nv - 1)));
    }
    return GS_OK;
}

static gs_err parse_stl_ascii(raw_mesh *m, const char *data, size_t len)
{
    text t = {m->name, data, len, 0, 1};
    char tok[32];
    int too_long;
    size_t corners = 0;
    int in_loop = 0;
    for (;;) {
        if (at_eol(&t)) {
            if (t.pos >= t.len)
                break;
            next_line(&t);
            continue;
        }
        token(&t, tok, sizeof tok, &too_long);
        for (char *p = tok; *p; p++)
            *p = (char)tolower((unsigned char)*p);
        if (!strcmp(tok, "vertex")) {
            GS_CHECK(in_loop, GS_ERR_FORMAT, "%s: line %d: 'vertex' outside 'outer loop'",
                     m->name, t.line);
            GS_CHECK(corners < MESH_MAX_POLY, GS_ERR_FORMAT,
                     "%s: line %d: a facet of more than %d corners", m->name, t.line,
                     MESH_MAX_POLY);
            double v[3];
            for (int c = 0; c < 3; c++)
                GS_CALL(number(&t, "a vertex coordinate", &v[c]));
            char where[32];
            snprintf(where, sizeof where, "line %d", t.line);
            GS_CALL(add_vertex(m, v[0], v[1], v[2], where));
            m->poly[corners++] = (uint32_t)(m->nv - 1);
        } else if (!strcmp(tok, "outer")) {
            GS_CHECK(!in_loop, GS_ERR_FORMAT, "%s: line %d: 'outer loop' inside a loop", m->name,
                     t.line);
            in_loop = 1;
            corners = 0;
        } else if (!strcmp(tok, "endloop")) {
            GS_CHECK(in_loop, GS_ERR_FORMAT, "%s: line %d: 'endloop' without 'outer loop'",
                     m->name, t.line);
            in_loop = 0;
            GS_CALL(add_poly(m, corners, 1));
        }
        /* solid, facet normal, endfacet, endsolid and their words: skipped */
        next_line(&t);
    }
    GS_CHECK(!in_loop, GS_ERR_FORMAT, "%s: line %d: file ends inside a facet's loop", m->name,
             t.line);
    return GS_OK;
}

static gs_err parse_stl(raw_mesh *m, const char *data, size_t len)
{
    const unsigned char *d = (const unsigned char *)data;
    if (len >= 84) {
        uint64_t n = (uint64_t)d[80] | (uint64_t)d[81] << 8 | (uint64_t)d[82] << 16 |
                     (uint64_t)d[83] << 24;
        if (84 + 50 * n == len)
            return parse_stl_binary(m, d, (size_t)n);
    }
    size_t i = 0;
    while (i < len && isspace((unsigned char)data[i]))
        i++;
    GS_CHECK(len - i >= 5 && !strncmp(data + i, "solid", 5), GS_ERR_FORMAT,
             "%s: not an STL file: neither binary (84 + 50 x facets bytes, the header says %s) "
             "nor text (starting with 'solid')", m->name,
             len >= 84 ? "another size" : "nothing: the file is shorter than 84 bytes");
    return parse_stl_ascii(m, data, len);
}

/* ------------------------------------------------------------ OBJ */

static gs_err parse_obj(raw_mesh *m, const char *data, size_t len, int64_t **idx_line)
{
    text t = {m->name, data, len, 0, 1};
    char tok[128];
    int too_long;
    /* OBJ faces may name vertices defined later: indices are checked at the
     * end, with the line of the first face using each triangle for messages. */
    size_t cap_l = 0;
    for (;;) {
        if (t.pos >= t.len)
            break;
        if (!token(&t, tok, sizeof tok, &too_long)) {
            next_line(&t);
            continue;
        }
        if (!strcmp(tok, "v")) {
            double v[3];
            for (int c = 0; c < 3; c++)
                GS_CALL(number(&t, "a vertex coordinate", &v[c]));
            char where[32];
            snprintf(where, sizeof where, "line %d", t.line);
            GS_CALL(add_vertex(m, v[0], v[1], v[2], where));
        } else if (!strcmp(tok, "f")) {
            size_t n = 0;
            while (token(&t, tok, sizeof tok, &too_long)) {
                GS_CHECK(!too_long, GS_ERR_FORMAT, "%s: line %d: face corner is too long",
                         m->name, t.line);
                GS_CHECK(n < MESH_MAX_POLY, GS_ERR_FORMAT,
                         "%s: line %d: a face of more than %d corners", m->name, t.line,
                         MESH_MAX_POLY);
                const char *p = tok;
                int64_t ix;
                GS_CHECK(gs_scan_i64(&p, -(int64_t)GS_MESH_MAX_ELEMS, (int64_t)GS_MESH_MAX_ELEMS,
                                     &ix) &&
                             (*p == '\0' || *p == '/') && ix != 0,
                         GS_ERR_FORMAT,
                         "%s: line %d: face corner '%s': expected a vertex number (1 = the "
                         "first, -1 = the last so far) optionally followed by /uv/normal",
                         m->name, t.line, tok);
                if (ix < 0) {
                    GS_CHECK((uint64_t)-ix <= m->nv, GS_ERR_FORMAT,
                             "%s: line %d: face corner %lld refers back past the %zu vertices "
                             "defined so far", m->name, t.line, (long long)ix, m->nv);
                    ix = (int64_t)m->nv + ix;
                } else {
                    ix -= 1;
                }
                m->poly[n++] = (uint32_t)ix;
            }
            int in_range = 1; /* vertices defined before the face: quads split like assimp */
            for (size_t j = 0; j < n; j++)
                in_range &= m->poly[j] < m->nv;
            size_t t0 = m->nt;
            GS_CALL(add_poly(m, n, in_range));
            if (m->nt > t0) {
                GS_CALL(grow((void **)idx_line, &cap_l, m->nt, sizeof(int64_t), "face lines"));
                for (size_t k = t0; k < m->nt; k++)
                    (*idx_line)[k] = t.line;
            }
        }
        /* vt, vn, vp, l, p, o, g, s, usemtl, mtllib, comments: skipped */
        next_line(&t);
    }
    for (size_t k = 0; k < 3 * m->nt; k++)
        GS_CHECK(m->tris[k] < m->nv, GS_ERR_FORMAT,
                 "%s: line %lld: face uses vertex %lu but the file has %zu vertices", m->name,
                 (long long)(*idx_line)[k / 3], (unsigned long)m->tris[k] + 1, m->nv);
    return GS_OK;
}

/* ------------------------------------------------------------ common */

/* Keeps the vertices in the order triangles first use them (drops unused). */
static gs_err compact(raw_mesh *m, int file_order, gs_mesh *out)
{
    uint32_t *newidx = NULL;
    GS_CALL(gs_alloc_array((void **)&newidx, m->nv ? m->nv : 1, sizeof *newidx, "vertex map"));
    memset(newidx, 0xff, (m->nv ? m->nv : 1) * sizeof *newidx);
    size_t nn = 0;
    if (file_order) /* unused vertices go in the weld */
        for (; nn < m->nv; nn++)
            newidx[nn] = (uint32_t)nn;
    for (size_t k = 0; k < 3 * m->nt; k++)
        if (newidx[m->tris[k]] == UINT32_MAX)
            newidx[m->tris[k]] = (uint32_t)nn++;
    gs_err err = gs_mesh_alloc(out, nn, m->nt, 0);
    if (!err) {
        for (size_t i = 0; i < m->nv; i++)
            if (newidx[i] != UINT32_MAX)
                memcpy(out->pos + 3 * (size_t)newidx[i], m->pos + 3 * i, 3 * sizeof(float));
        for (size_t k = 0; k < 3 * m->nt; k++)
            out->tris[k] = newidx[m->tris[k]];
    }
    gs_free(newidx);
    return err;
}

gs_err gs_mesh_parse(const char *data, size_t len, const char *name, gs_mesh *out)
{
    memset(out, 0, sizeof *out);
    char ext[8];
    gs_path_ext(name, ext, sizeof ext);
    raw_mesh *m = NULL;
    GS_CALL(gs_alloc_array((void **)&m, 1, sizeof *m, "mesh reader"));
    memset(m, 0, sizeof *m);
    m->name = name;
    int64_t *lines = NULL;
    gs_err err = GS_OK;
    if (!strcmp(ext, "ply"))
        err = parse_ply(m, data, len);
    else if (!strcmp(ext, "off"))
        err = parse_off(m, data, len);
    else if (!strcmp(ext, "stl"))
        err = parse_stl(m, data, len);
    else if (!strcmp(ext, "obj"))
        err = parse_obj(m, data, len, &lines);
    else
        err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                             "%s: unknown mesh extension '.%s': expected .ply, .off, .stl or .obj",
                             name, ext);
    gs_free(lines);
    GS_TRY(err, err, done);
    GS_TRY_CHECK(err, m->nt > 0, GS_ERR_FORMAT, done,
                 "%s: no triangles (%zu vertices, no face of 3 or more corners): expected a "
                 "triangle mesh", name, m->nv);
    /* assimp kept PLY and OFF vertices in file order, and gave OBJ and STL
     * ones in the order faces use them */
    GS_TRY(err, compact(m, !strcmp(ext, "ply") || !strcmp(ext, "off"), out), done);
    GS_TRY(err, gs_mesh_validate(out, name), done);
    GS_TRY(err, gs_mesh_weld(out, 0.0f), done);
    GS_TRY_CHECK(err, out->ntris > 0, GS_ERR_FORMAT, done,
                 "%s: every triangle is degenerate (repeated vertex): expected a triangle mesh",
                 name);
done:
    if (err)
        gs_mesh_destroy(out);
    raw_free(m);
    gs_free(m);
    return err;
}

gs_err gs_mesh_read(const char *path, gs_mesh *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(path && path[0], GS_ERR_ARG, "mesh path is empty");
    char *data = NULL;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, MESH_MAX_FILE_BYTES, &data, &len));
    gs_err err = gs_mesh_parse(data, len, path, out);
    gs_free(data);
    GS_CALL(err);
    return GS_OK;
}
