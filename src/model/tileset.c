/* Simple tiled model input: mxgmn tile set XML -> oriented tiles, allowed
 * pairs, weights, tile images; the tile-set checker and the assembled PNG.
 * See include/geosynth/model_tiles.h.
 *
 * The XML reader is deliberately small: elements with attributes, comments,
 * <?...?> and <!...> declarations, the five predefined entities and numeric
 * character references; text content is ignored. That covers mxgmn's and
 * MarkovJunior's tile sets. Errors name file and line. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/model_tiles.h"
#include "geosynth/parse.h"

#define XML_MAX_BYTES (64u << 20)
#define XML_MAX_ATTRS 16

/* ---- minimal XML ------------------------------------------------------------ */

typedef struct xml_elem {
    char *name;
    int nattr;
    char *key[XML_MAX_ATTRS];
    char *val[XML_MAX_ATTRS];
    int parent; /* index, -1 for the root */
    int line;
} xml_elem;

typedef struct xml_doc {
    char *buf; /* the file, names and values are cut out of it in place */
    xml_elem *e;
    int n, cap;
    const char *file;
} xml_doc;

static void xml_free(xml_doc *d)
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

static gs_err xml_parse(const char *path, xml_doc *d)
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
    xml_free(d);
    return err;
}

static const char *xml_attr(const xml_elem *e, const char *key)
{
    for (int i = 0; i < e->nattr; i++)
        if (!strcmp(e->key[i], key))
            return e->val[i];
    return NULL;
}

/* ---- tile set ------------------------------------------------------------------ */

typedef struct tile_def {
    const char *name;
    int first;       /* first oriented tile */
    int card;        /* orientations */
    int line;
} tile_def;

/* mxgmn's symmetry actions: a = rotate 90 degrees, b = reflect. */
static int sym_card(char s)
{
    switch (s) {
    case 'L': case 'T': return 4;
    case 'I': case '\\': return 2;
    case 'F': return 8;
    default: return 1;
    }
}
static int sym_a(char s, int i)
{
    switch (s) {
    case 'L': case 'T': return (i + 1) % 4;
    case 'I': case '\\': return 1 - i;
    case 'F': return i < 4 ? (i + 1) % 4 : 4 + (i - 1) % 4;
    default: return i;
    }
}
static int sym_b(char s, int i)
{
    switch (s) {
    case 'L': return i % 2 == 0 ? i + 1 : i - 1;
    case 'T': return i % 2 == 0 ? i : 4 - i;
    case 'I': return i;
    case '\\': return 1 - i;
    case 'F': return i < 4 ? i + 4 : i - 4;
    default: return i;
    }
}

static int cmp_pair(const void *pa, const void *pb)
{
    const gs_model_pair *a = pa, *b = pb;
    uint64_t ka = ((uint64_t)a->dir << 32) | ((uint64_t)a->a << 16) | a->b;
    uint64_t kb = ((uint64_t)b->dir << 32) | ((uint64_t)b->a << 16) | b->b;
    return (ka > kb) - (ka < kb);
}

static int in_subset(const xml_doc *d, int subset_elem, const char *tile)
{
    if (subset_elem < 0)
        return 1;
    for (int i = subset_elem + 1; i < d->n; i++)
        if (d->e[i].parent == subset_elem && !strcmp(d->e[i].name, "tile")) {
            const char *nm = xml_attr(&d->e[i], "name");
            if (nm && !strcmp(nm, tile))
                return 1;
        }
    return 0;
}

/* "corner 1" -> tile index and orientation; *skip = 1 when the tile is not in
 * the subset. */
static gs_err parse_ref(const xml_doc *d, const xml_elem *el, const char *attr, const tile_def *defs,
                        int ndefs, int subset_elem, int *tile, int *orient, int *skip)
{
    const char *v = xml_attr(el, attr);
    GS_CHECK(v, GS_ERR_FORMAT, "%s:%d: <neighbor> without %s=\"TILE [ORIENTATION]\"", d->file,
             el->line, attr);
    char name[72];
    const char *sp = strchr(v, ' ');
    size_t nl = sp ? (size_t)(sp - v) : strlen(v);
    GS_CHECK(nl > 0 && nl < sizeof name, GS_ERR_FORMAT, "%s:%d: %s=\"%s\": expected a tile name",
             d->file, el->line, attr, v);
    memcpy(name, v, nl);
    name[nl] = '\0';
    int64_t o = 0;
    if (sp) {
        char why[96];
        GS_CHECK(gs_parse_i64(sp + 1, 0, 7, &o, why, sizeof why), GS_ERR_FORMAT,
                 "%s:%d: %s=\"%s\": orientation %s", d->file, el->line, attr, v, why);
    }
    *skip = 0;
    for (int t = 0; t < ndefs; t++)
        if (!strcmp(defs[t].name, name)) {
            *tile = t;
            *orient = (int)o;
            return GS_OK;
        }
    /* Not a kept tile: fine when a subset left it out, an error otherwise. */
    if (subset_elem >= 0) {
        for (int i = 0; i < d->n; i++)
            if (!strcmp(d->e[i].name, "tile") && d->e[d->e[i].parent].name &&
                !strcmp(d->e[d->e[i].parent].name, "tiles")) {
                const char *nm = xml_attr(&d->e[i], "name");
                if (nm && !strcmp(nm, name)) {
                    *skip = 1;
                    return GS_OK;
                }
            }
    }
    GS_RAISE(GS_ERR_FORMAT, "%s:%d: %s=\"%s\": no tile named '%s' in <tiles>", d->file, el->line,
             attr, v, name);
}

static gs_err load_rgba(const char *path, gs_image *img, int *w, int *h, uint8_t *dst_or_null)
{
    GS_CALL(gs_image_read(path, img));
    if (*w == 0) {
        *w = img->width;
        *h = img->height;
    }
    if (img->width != *w || img->height != *h) {
        int iw = img->width, ih = img->height;
        gs_image_destroy(img);
        GS_RAISE(GS_ERR_FORMAT, "%s: %dx%d pixels: expected %dx%d like the first tile", path, iw,
                 ih, *w, *h);
    }
    if (!dst_or_null) {
        gs_image_destroy(img);
        return GS_OK;
    }
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            uint8_t px[4] = {0, 0, 0, 255};
            for (int c = 0; c < img->channels; c++) {
                size_t i = ((size_t)y * (size_t)img->width + (size_t)x) * (size_t)img->channels + (size_t)c;
                uint8_t v = img->bits == 8 ? img->data8[i] : (uint8_t)(img->data16[i] >> 8);
                if (img->channels <= 2)
                    px[c == 0 ? 0 : 3] = v;
                else
                    px[c] = v;
            }
            if (img->channels <= 2)
                px[1] = px[2] = px[0];
            memcpy(dst_or_null + ((size_t)y * (size_t)*w + (size_t)x) * 4, px, 4);
        }
    gs_image_destroy(img);
    return GS_OK;
}

gs_err gs_model_tileset_load(const char *path, const char *subset, int images,
                             gs_model_tileset *out)
{
    xml_doc d;
    GS_CALL(xml_parse(path, &d));
    gs_err err = GS_OK;
    tile_def *defs = NULL;
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    int (*action)[8] = NULL;
    char *symc = NULL;
    gs_image img;
    memset(&img, 0, sizeof img);

    GS_TRY_CHECK(err, !strcmp(d.e[0].name, "set"), GS_ERR_FORMAT, fail,
                 "%s:%d: root element <%s>: expected <set> (a WaveFunctionCollapse tile set)", path,
                 d.e[0].line, d.e[0].name);
    int unique = 0;
    const char *u = xml_attr(&d.e[0], "unique");
    if (u) {
        char why[96];
        GS_TRY_CHECK(err, gs_parse_bool(u, &unique, why, sizeof why), GS_ERR_FORMAT, fail,
                     "%s:%d: unique=\"%s\": %s", path, d.e[0].line, u, why);
    }
    int subset_elem = -1;
    if (subset && subset[0]) {
        for (int i = 0; i < d.n && subset_elem < 0; i++)
            if (!strcmp(d.e[i].name, "subset") && d.e[i].parent >= 0 &&
                !strcmp(d.e[d.e[i].parent].name, "subsets")) {
                const char *nm = xml_attr(&d.e[i], "name");
                if (nm && !strcmp(nm, subset))
                    subset_elem = i;
            }
        if (subset_elem < 0) {
            char names[512] = "";
            for (int i = 0; i < d.n; i++)
                if (!strcmp(d.e[i].name, "subset") && xml_attr(&d.e[i], "name") &&
                    strlen(names) + strlen(xml_attr(&d.e[i], "name")) + 4 < sizeof names) {
                    if (names[0])
                        strcat(names, ", ");
                    strcat(names, xml_attr(&d.e[i], "name"));
                }
            GS_TRY_CHECK(err, 0, GS_ERR_ARG, fail, "%s: no subset named '%s' (subsets: %s)", path,
                         subset, names[0] ? names : "none");
        }
    }
    /* tiles */
    int ndefs = 0, T = 0;
    GS_TRY(err, gs_alloc_array((void **)&defs, (size_t)d.n, sizeof *defs, "tile list"), fail);
    GS_TRY(err, gs_alloc_array((void **)&symc, (size_t)d.n, 1, "tile list"), fail);
    GS_TRY(err, gs_alloc_array((void **)&action, (size_t)d.n * 8, sizeof *action, "tile actions"), fail);
    GS_TRY(err, gs_alloc_array((void **)&ts.weight, (size_t)d.n * 8, sizeof *ts.weight, "weights"), fail);
    GS_TRY(err, gs_alloc_array((void **)&ts.names, (size_t)d.n * 8, sizeof *ts.names, "tile names"), fail);
    for (int i = 0; i < d.n; i++) {
        const xml_elem *el = &d.e[i];
        if (strcmp(el->name, "tile") || el->parent < 0 || strcmp(d.e[el->parent].name, "tiles"))
            continue;
        const char *nm = xml_attr(el, "name");
        GS_TRY_CHECK(err, nm && nm[0] && strlen(nm) < 60 && !strchr(nm, ' '), GS_ERR_FORMAT, fail,
                     "%s:%d: <tile> needs name=\"...\" (no spaces, under 60 characters)", path,
                     el->line);
        for (int t = 0; t < ndefs; t++)
            GS_TRY_CHECK(err, strcmp(defs[t].name, nm), GS_ERR_FORMAT, fail,
                         "%s:%d: tile '%s' is already defined at line %d", path, el->line, nm,
                         defs[t].line);
        if (!in_subset(&d, subset_elem, nm))
            continue;
        const char *sy = xml_attr(el, "symmetry");
        char s = 'X';
        if (sy) {
            GS_TRY_CHECK(err, strlen(sy) == 1 && strchr("XILT\\F", sy[0]), GS_ERR_FORMAT, fail,
                         "%s:%d: tile %s: symmetry=\"%s\": expected X, I, L, T, \\ or F", path,
                         el->line, nm, sy);
            s = sy[0];
        }
        double w = 1.0;
        const char *ws = xml_attr(el, "weight");
        if (ws) {
            char why[96];
            GS_TRY_CHECK(err, gs_parse_f64(ws, 1e-9, 1e9, &w, why, sizeof why), GS_ERR_FORMAT,
                         fail, "%s:%d: tile %s: weight=\"%s\": %s", path, el->line, nm, ws, why);
        }
        int card = sym_card(s);
        defs[ndefs] = (tile_def){nm, T, card, el->line};
        symc[ndefs] = s;
        ndefs++;
        for (int t = 0; t < card; t++) {
            int *m = action[T + t];
            m[0] = t;
            m[1] = sym_a(s, t);
            m[2] = sym_a(s, sym_a(s, t));
            m[3] = sym_a(s, sym_a(s, sym_a(s, t)));
            m[4] = sym_b(s, t);
            m[5] = sym_b(s, sym_a(s, t));
            m[6] = sym_b(s, sym_a(s, sym_a(s, t)));
            m[7] = sym_b(s, sym_a(s, sym_a(s, sym_a(s, t))));
            for (int k = 0; k < 8; k++)
                m[k] += T;
            ts.weight[T + t] = w;
            snprintf(ts.names[T + t], sizeof ts.names[T + t], "%s %d", nm, t);
        }
        T += card;
    }
    GS_TRY_CHECK(err, T > 0, GS_ERR_FORMAT, fail, "%s: no <tile> in <tiles>%s%s", path,
                 subset_elem >= 0 ? " of subset " : "", subset_elem >= 0 ? subset : "");
    GS_TRY_CHECK(err, T < 65535, GS_ERR_FORMAT, fail, "%s: %d oriented tiles: at most 65534", path, T);
    ts.ntiles = T;
    /* neighbours, expanded exactly as mxgmn's SimpleTiledModel */
    size_t cap = 64, np = 0;
    GS_TRY(err, gs_alloc_array((void **)&ts.pairs, cap, sizeof *ts.pairs, "pairs"), fail);
    for (int i = 0; i < d.n; i++) {
        const xml_elem *el = &d.e[i];
        if (strcmp(el->name, "neighbor") || el->parent < 0 || strcmp(d.e[el->parent].name, "neighbors"))
            continue;
        int lt = 0, lo = 0, rt = 0, ro = 0, s1 = 0, s2 = 0;
        GS_TRY(err, parse_ref(&d, el, "left", defs, ndefs, subset_elem, &lt, &lo, &s1), fail);
        GS_TRY(err, parse_ref(&d, el, "right", defs, ndefs, subset_elem, &rt, &ro, &s2), fail);
        if (s1 || s2)
            continue;
        /* "name k": k indexes the 8 symmetry actions of the first orientation
         * (mxgmn: action[firstOccurrence[name]][k]), so it may exceed the
         * orientation count (e.g. "b_i 3" of an I tile is orientation 1). */
        int L = action[defs[lt].first][lo], D = action[L][1];
        int R = action[defs[rt].first][ro], U = action[R][1];
        /* mxgmn: propagator[0][R][L] (L left of R), [1][U][D] (D below U in
         * the picture, i.e. U at y, D at y+1). Ours: (dir 0, left, right),
         * (dir 2, upper, lower). */
        int hp[4][2] = {{L, R}, {action[L][6], action[R][6]}, {action[R][4], action[L][4]},
                        {action[R][2], action[L][2]}};
        /* mxgmn sets densePropagator[1][X][Y] (Y below X) for (U, D),
         * (D6, U6), (U4, D4), (D2, U2): action 6 flips up/down, 4 left/right. */
        int vp[4][2] = {{U, D}, {action[D][6], action[U][6]}, {action[U][4], action[D][4]},
                        {action[D][2], action[U][2]}};
        if (np + 8 > cap) {
            cap *= 2;
            void *nb = gs_realloc(ts.pairs, cap * sizeof *ts.pairs);
            GS_TRY_CHECK(err, nb, GS_ERR_MEM, fail, "%s: out of memory for pairs", path);
            ts.pairs = nb;
        }
        for (int k = 0; k < 4; k++) {
            ts.pairs[np++] = (gs_model_pair){0, (uint16_t)(hp[k][0] + 1), (uint16_t)(hp[k][1] + 1)};
            ts.pairs[np++] = (gs_model_pair){2, (uint16_t)(vp[k][0] + 1), (uint16_t)(vp[k][1] + 1)};
        }
    }
    qsort(ts.pairs, np, sizeof *ts.pairs, cmp_pair);
    size_t m = 0;
    for (size_t i = 0; i < np; i++)
        if (m == 0 || cmp_pair(&ts.pairs[i], &ts.pairs[m - 1]))
            ts.pairs[m++] = ts.pairs[i];
    ts.npairs = m;
    GS_TRY_CHECK(err, m > 0, GS_ERR_FORMAT, fail, "%s: no <neighbor> pair between kept tiles",
                 path);
    if (images) {
        /* folder = path without ".xml" */
        char dir[4096];
        size_t pl = strlen(path);
        GS_TRY_CHECK(err, pl > 4 && pl < sizeof dir, GS_ERR_ARG, fail, "%s: path too long", path);
        memcpy(dir, path, pl - 4);
        dir[pl - 4] = '\0';
        char file[4200];
        for (int t = 0; t < ndefs; t++) {
            int first = defs[t].first;
            if (unique) {
                for (int k = 0; k < defs[t].card; k++) {
                    snprintf(file, sizeof file, "%s/%s %d.png", dir, defs[t].name, k);
                    GS_TRY(err, load_rgba(file, &img, &ts.tile_w, &ts.tile_h, NULL), fail);
                    if (!ts.pixels)
                        GS_TRY(err, gs_alloc_array((void **)&ts.pixels,
                                                   (size_t)T * (size_t)ts.tile_w * (size_t)ts.tile_h,
                                                   4, "tile pixels"),
                               fail);
                    gs_image_destroy(&img);
                    GS_TRY(err, load_rgba(file, &img, &ts.tile_w, &ts.tile_h,
                                          ts.pixels + (size_t)(first + k) * (size_t)ts.tile_w *
                                                          (size_t)ts.tile_h * 4),
                           fail);
                    gs_image_destroy(&img);
                }
                continue;
            }
            snprintf(file, sizeof file, "%s/%s.png", dir, defs[t].name);
            GS_TRY(err, load_rgba(file, &img, &ts.tile_w, &ts.tile_h, NULL), fail);
            GS_TRY_CHECK(err, ts.tile_w == ts.tile_h, GS_ERR_FORMAT, fail,
                         "%s: %dx%d pixels: rotated tiles must be square", file, ts.tile_w,
                         ts.tile_h);
            if (!ts.pixels)
                GS_TRY(err, gs_alloc_array((void **)&ts.pixels,
                                           (size_t)T * (size_t)ts.tile_w * (size_t)ts.tile_h, 4,
                                           "tile pixels"),
                       fail);
            const size_t S = (size_t)ts.tile_w, tb = S * S * 4;
            GS_TRY(err, load_rgba(file, &img, &ts.tile_w, &ts.tile_h, ts.pixels + (size_t)first * tb),
                   fail);
            gs_image_destroy(&img);
            /* mxgmn: t in 1..3 rotate(tile t-1), t >= 4 reflect(tile t-4);
             * rotate: out[x + y*S] = in[S-1-y + x*S]; reflect: out[x + y*S] =
             * in[S-1-x + y*S]. */
            for (int k = 1; k < defs[t].card; k++) {
                const uint8_t *src = ts.pixels + (size_t)(first + (k <= 3 ? k - 1 : k - 4)) * tb;
                uint8_t *dst = ts.pixels + (size_t)(first + k) * tb;
                for (size_t y = 0; y < S; y++)
                    for (size_t x = 0; x < S; x++) {
                        size_t from = k <= 3 ? (S - 1 - y) + x * S : (S - 1 - x) + y * S;
                        memcpy(dst + (x + y * S) * 4, src + from * 4, 4);
                    }
            }
        }
    }
    (void)symc;
    gs_free(defs);
    gs_free(symc);
    gs_free(action);
    xml_free(&d);
    *out = ts;
    return GS_OK;
fail:
    gs_image_destroy(&img);
    gs_free(defs);
    gs_free(symc);
    gs_free(action);
    gs_model_tileset_destroy(&ts);
    xml_free(&d);
    return err;
}

void gs_model_tileset_destroy(gs_model_tileset *ts)
{
    if (!ts)
        return;
    gs_free(ts->names);
    gs_free(ts->weight);
    gs_free(ts->pairs);
    gs_free(ts->pixels);
    memset(ts, 0, sizeof *ts);
}

gs_err gs_model_tileset_rules(const gs_model_tileset *ts, gs_model_rules_t *out)
{
    uint64_t *counts = NULL;
    GS_CALL(gs_alloc_array((void **)&counts, (size_t)ts->ntiles + 1, sizeof *counts, "weights"));
    counts[0] = 0;
    for (int t = 0; t < ts->ntiles; t++) {
        double c = ts->weight[t] * 1e6;
        counts[t + 1] = c < 1 ? 1 : (uint64_t)(c + 0.5);
    }
    gs_err err = gs_model_rules_from_pairs(ts->ntiles + 1, ts->pairs, ts->npairs, counts, out);
    gs_free(counts);
    return err;
}

gs_err gs_model_tileset_write_png(const char *path, const gs_model_tileset *ts,
                                  const gs_model_lattice *lat)
{
    GS_CHECK(ts->pixels, GS_ERR_ARG, "%s: tile images were not loaded", path);
    const int S = ts->tile_w, H = ts->tile_h;
    GS_CHECK((int64_t)lat->nx * S <= GS_IMAGE_MAX_SIDE && (int64_t)lat->ny * H <= GS_IMAGE_MAX_SIDE,
             GS_ERR_ARG, "%s: %dx%d tiles of %dx%d pixels exceed %d pixels per side", path, lat->nx,
             lat->ny, S, H, GS_IMAGE_MAX_SIDE);
    gs_image img;
    GS_CALL(gs_image_alloc(&img, lat->nx * S, lat->ny * H, 4, 8));
    const size_t W = (size_t)img.width;
    for (int y = 0; y < lat->ny; y++)
        for (int x = 0; x < lat->nx; x++) {
            int l = lat->labels[gs_model_lattice_index(lat, x, y, 0)];
            for (int py = 0; py < H; py++) {
                uint8_t *row = img.data8 + (((size_t)y * (size_t)H + (size_t)py) * W + (size_t)x * (size_t)S) * 4;
                if (l < 1 || l > ts->ntiles)
                    memset(row, 0, (size_t)S * 4);
                else
                    memcpy(row, ts->pixels + (((size_t)(l - 1) * (size_t)H + (size_t)py) * (size_t)S) * 4,
                           (size_t)S * 4);
            }
        }
    gs_err err = gs_image_write_png(path, &img);
    gs_image_destroy(&img);
    return err;
}

/* ---- independent checker --------------------------------------------------------- */

static uint64_t key3(unsigned axis, unsigned a, unsigned b)
{
    return ((uint64_t)axis << 32) | ((uint64_t)a << 16) | (uint64_t)b;
}

static int cmp_u64(const void *pa, const void *pb)
{
    uint64_t a = *(const uint64_t *)pa, b = *(const uint64_t *)pb;
    return (a > b) - (a < b);
}

static int has_key(const uint64_t *keys, size_t n, uint64_t k)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (keys[mid] < k)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && keys[lo] == k;
}

gs_err gs_model_tileset_check(const gs_model_tileset *ts, const gs_model_lattice *lat,
                              gs_model_violation *out, size_t cap, size_t *count)
{
    uint64_t *keys = NULL;
    GS_CALL(gs_alloc_array((void **)&keys, ts->npairs + 1, sizeof *keys, "checker pairs"));
    for (size_t i = 0; i < ts->npairs; i++)
        keys[i] = key3(ts->pairs[i].dir / 2u, ts->pairs[i].a, ts->pairs[i].b);
    qsort(keys, ts->npairs, sizeof *keys, cmp_u64);
    size_t found = 0;
    for (int z = 0; z < lat->nz; z++)
        for (int y = 0; y < lat->ny; y++)
            for (int x = 0; x < lat->nx; x++) {
                uint16_t a = lat->labels[gs_model_lattice_index(lat, x, y, z)];
                gs_model_violation v = {x, y, z, -1, a, a};
                if (a < 1 || a > ts->ntiles) {
                    if (found < cap)
                        out[found] = v;
                    found++;
                }
                for (int axis = 0; axis < 3; axis++) {
                    int qx = x + (axis == 0), qy = y + (axis == 1), qz = z + (axis == 2);
                    if (qx >= lat->nx || qy >= lat->ny || qz >= lat->nz)
                        continue;
                    uint16_t b = lat->labels[gs_model_lattice_index(lat, qx, qy, qz)];
                    if (has_key(keys, ts->npairs, key3((unsigned)axis, a, b)))
                        continue;
                    v.dir = 2 * axis;
                    v.b = b;
                    if (found < cap)
                        out[found] = v;
                    found++;
                }
            }
    gs_free(keys);
    *count = found;
    return GS_OK;
}
