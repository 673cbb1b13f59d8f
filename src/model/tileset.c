/* Simple tiled model input: mxgmn tile set XML -> oriented tiles, allowed
 * pairs, weights, tile images; the tile-set checker and the assembled PNG.
 * See include/geosynth/model_tiles.h.
 *
 * The XML reader is in tileset_xml.c; the 3D (voxel) sets in tileset3d.c. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/file.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/model_tiles.h"
#include "geosynth/parse.h"
#include "tileset_impl.h"

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
            const char *nm = gs_tsxml_attr(&d->e[i], "name");
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
    const char *v = gs_tsxml_attr(el, attr);
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
                const char *nm = gs_tsxml_attr(&d->e[i], "name");
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
    gs_err noted = gs_input_note("model.tileset", path); /* resume checks it (#25) */
    if (noted) {
        gs_image_destroy(img);
        GS_CALL(noted);
    }
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

size_t gs_tileset_pairs_unique(gs_model_pair *pairs, size_t n)
{
    if (n == 0) /* pairs may be NULL then (a set without neighbours; fuzz_tileset) */
        return 0;
    qsort(pairs, n, sizeof *pairs, cmp_pair);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (m == 0 || cmp_pair(&pairs[i], &pairs[m - 1]))
            pairs[m++] = pairs[i];
    return m;
}

gs_err gs_model_tileset_load(const char *path, const char *subset, int images,
                             gs_model_tileset *out)
{
    return gs_model_tileset_load_any(path, subset, NULL, images, out);
}

gs_err gs_model_tileset_load_any(const char *path, const char *subset, const char *folder,
                                 int images, gs_model_tileset *out)
{
    size_t plen = strlen(path);
    if (plen > 5 && !strcmp(path + plen - 5, ".json")) {
        GS_CHECK(!subset || !subset[0], GS_ERR_ARG,
                 "%s: a DeBroglie tile set has no subsets (model.subset = %s)", path, subset);
        return gs_tileset3d_load_debroglie(path, out);
    }
    xml_doc d;
    GS_CALL(gs_tsxml_parse(path, &d));
    if (!strcmp(d.e[0].name, "tileset")) {
        gs_err e3 = GS_OK;
        if (subset && subset[0])
            e3 = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                "%s: a MarkovJunior tile set has no subsets (model.subset = %s)",
                                path, subset);
        if (!e3)
            e3 = gs_tileset3d_load_mj(path, &d, folder, out);
        gs_tsxml_free(&d);
        return e3;
    }
    if (folder && folder[0]) {
        gs_tsxml_free(&d);
        GS_RAISE(GS_ERR_ARG, "%s: a tile folder applies to MarkovJunior tile sets only, this is a "
                             "<%s>", path, "set");
    }
    gs_err err = GS_OK;
    tile_def *defs = NULL;
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    int (*action)[8] = NULL;
    char *symc = NULL;
    gs_image img;
    memset(&img, 0, sizeof img);

    ts.dim = 2;
    GS_TRY_CHECK(err, !strcmp(d.e[0].name, "set"), GS_ERR_FORMAT, fail,
                 "%s:%d: root element <%s>: expected <set> (a WaveFunctionCollapse tile set) or "
                 "<tileset> (MarkovJunior)", path,
                 d.e[0].line, d.e[0].name);
    int unique = 0;
    const char *u = gs_tsxml_attr(&d.e[0], "unique");
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
                const char *nm = gs_tsxml_attr(&d.e[i], "name");
                if (nm && !strcmp(nm, subset))
                    subset_elem = i;
            }
        if (subset_elem < 0) {
            char names[512] = "";
            for (int i = 0; i < d.n; i++)
                if (!strcmp(d.e[i].name, "subset") && gs_tsxml_attr(&d.e[i], "name") &&
                    strlen(names) + strlen(gs_tsxml_attr(&d.e[i], "name")) + 4 < sizeof names) {
                    if (names[0])
                        strcat(names, ", ");
                    strcat(names, gs_tsxml_attr(&d.e[i], "name"));
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
        const char *nm = gs_tsxml_attr(el, "name");
        GS_TRY_CHECK(err, nm && nm[0] && strlen(nm) < 60 && !strchr(nm, ' '), GS_ERR_FORMAT, fail,
                     "%s:%d: <tile> needs name=\"...\" (no spaces, under 60 characters)", path,
                     el->line);
        for (int t = 0; t < ndefs; t++)
            GS_TRY_CHECK(err, strcmp(defs[t].name, nm), GS_ERR_FORMAT, fail,
                         "%s:%d: tile '%s' is already defined at line %d", path, el->line, nm,
                         defs[t].line);
        if (!in_subset(&d, subset_elem, nm))
            continue;
        const char *sy = gs_tsxml_attr(el, "symmetry");
        char s = 'X';
        if (sy) {
            GS_TRY_CHECK(err, strlen(sy) == 1 && strchr("XILT\\F", sy[0]), GS_ERR_FORMAT, fail,
                         "%s:%d: tile %s: symmetry=\"%s\": expected X, I, L, T, \\ or F", path,
                         el->line, nm, sy);
            s = sy[0];
        }
        double w = 1.0;
        const char *ws = gs_tsxml_attr(el, "weight");
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
    size_t m = gs_tileset_pairs_unique(ts.pairs, np);
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
    gs_tsxml_free(&d);
    *out = ts;
    return GS_OK;
fail:
    gs_image_destroy(&img);
    gs_free(defs);
    gs_free(symc);
    gs_free(action);
    gs_model_tileset_destroy(&ts);
    gs_tsxml_free(&d);
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
    gs_free(ts->voxels);
    gs_free(ts->base);
    gs_free(ts->orient);
    gs_free(ts->fixed);
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

gs_err gs_model_tileset_check(const gs_model_tileset *ts, const gs_model_lattice *lat,
                              gs_model_violation *out, size_t cap, size_t *count)
{
    uint64_t *keys = NULL;
    GS_CALL(gs_alloc_array((void **)&keys, ts->npairs + 1, sizeof *keys, "checker pairs"));
    for (size_t i = 0; i < ts->npairs; i++)
        keys[i] = key3(ts->pairs[i].dir / 2u, ts->pairs[i].a, ts->pairs[i].b);
    gs_measure_keys_sort(keys, ts->npairs);
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
                    if (gs_measure_keys_has(keys, ts->npairs, key3((unsigned)axis, a, b)))
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
