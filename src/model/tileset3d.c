/* 3D (voxel) tile sets: MarkovJunior's tile-set XML and DeBroglie's voxSet
 * JSON -> oriented voxel tiles under a cube (or square) symmetry group,
 * allowed pairs along x, y and z, weights and constraints; the assembled
 * voxel output. See "3D tile sets" in include/geosynth/model_tiles.h.
 *
 * Orientations come from the voxels: the images of a tile under the group
 * are compared voxel for voxel, the distinct ones are its orientations, and
 * the action of every group element on every oriented tile (act[]) is found
 * the same way. Pairs are closed under the group from that action, so a
 * declared pair brings every rotated and mirrored copy of itself. */
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/model_io.h"
#include "geosynth/model_tiles.h"
#include "geosynth/vox.h"
#include "tileset_impl.h"

#define MAX_GROUP 48
#define MAX_TILE_SIDE 64
#define MAX_ORIENTED 4096

typedef struct gmat {
    int m[3][3]; /* new position = m * old position (centred) */
} gmat;

static int mat_eq(const gmat *a, const gmat *b) { return !memcmp(a, b, sizeof *a); }

static gmat mat_mul(const gmat *a, const gmat *b)
{
    gmat c;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            c.m[i][j] = 0;
            for (int k = 0; k < 3; k++)
                c.m[i][j] += a->m[i][k] * b->m[k][j];
        }
    return c;
}

static const gmat ID = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
/* MarkovJunior's x, y, z: 90 degrees about that axis (+y to +z, +x to +z,
 * +x to +y); and the mirror x -> -x. */
static const gmat ROT_X = {{{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}};
static const gmat ROT_Y = {{{0, 0, -1}, {0, 1, 0}, {1, 0, 0}}};
static const gmat ROT_Z = {{{0, -1, 0}, {1, 0, 0}, {0, 0, 1}}};
static const gmat MIRROR_X = {{{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};

/* full: the 48 signed permutations (identity first); else rot (1, 2, 4)
 * rotations about z, each also followed by the x mirror when refl. */
static int build_group(int full, int rot, int refl, gmat *g)
{
    int n = 0;
    if (full) {
        static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
        for (int p = 0; p < 6; p++)
            for (int s = 0; s < 8; s++) {
                gmat m;
                memset(&m, 0, sizeof m);
                for (int i = 0; i < 3; i++)
                    m.m[i][perm[p][i]] = (s >> i) & 1 ? -1 : 1;
                g[n++] = m;
            }
        return n;
    }
    gmat step = rot == 4 ? ROT_Z : rot == 2 ? mat_mul(&ROT_Z, &ROT_Z) : ID;
    gmat r = ID;
    for (int k = 0; k < rot; k++) {
        g[n++] = r;
        r = mat_mul(&step, &r);
    }
    for (int k = 0; refl && k < rot; k++)
        g[n++] = mat_mul(&g[k], &MIRROR_X);
    return n;
}

static int group_index(const gmat *g, int ng, const gmat *m)
{
    for (int i = 0; i < ng; i++)
        if (mat_eq(&g[i], m))
            return i;
    return -1;
}

/* dst = m applied to src (tile of s[0] x s[1] x s[2]; m keeps that shape). */
static void transform(const gmat *m, const int s[3], const uint8_t *src, uint8_t *dst)
{
    for (int z = 0; z < s[2]; z++)
        for (int y = 0; y < s[1]; y++)
            for (int x = 0; x < s[0]; x++) {
                int n[3] = {x, y, z}, c[3], o[3];
                for (int i = 0; i < 3; i++)
                    c[i] = 2 * n[i] - (s[i] - 1);
                for (int j = 0; j < 3; j++) {
                    int v = 0;
                    for (int i = 0; i < 3; i++)
                        v += m->m[i][j] * c[i]; /* old = m^T new */
                    o[j] = (v + s[j] - 1) / 2;
                }
                dst[x + s[0] * (y + s[1] * z)] = src[o[0] + s[0] * (o[1] + s[1] * o[2])];
            }
}

/* ---- building state ------------------------------------------------------- */

typedef struct builder {
    const char *path;
    gmat g[MAX_GROUP];
    int ng;
    int s[3];           /* tile voxels */
    size_t tv;          /* voxels per tile */
    gs_model_tileset ts;
    int cap;            /* oriented tiles allocated */
    char (*base_name)[64];
    int *base_first, *base_card;
    int nbase_cap;
    int ncolors;        /* palette entries used (1..ncolors) */
    int *act;           /* [ng][ntiles] */
    size_t npairs, pcap;
} builder;

static void builder_free(builder *b)
{
    gs_model_tileset_destroy(&b->ts);
    gs_free(b->base_name);
    gs_free(b->base_first);
    gs_free(b->base_card);
    gs_free(b->act);
    memset(b, 0, sizeof *b);
}

static gs_err grow_tiles(builder *b, int need)
{
    if (need <= b->cap)
        return GS_OK;
    GS_CHECK(need <= MAX_ORIENTED, GS_ERR_FORMAT, "%s: more than %d oriented tiles", b->path,
             MAX_ORIENTED);
    int cap = b->cap ? 2 * b->cap : 64;
    while (cap < need)
        cap *= 2;
    gs_model_tileset *t = &b->ts;
    void *p;
#define GROW(ptr, elem)                                                                            \
    p = gs_realloc(ptr, (size_t)cap * (elem));                                                     \
    GS_CHECK(p, GS_ERR_MEM, "%s: out of memory for tiles", b->path);                              \
    ptr = p;
    GROW(t->names, sizeof *t->names);
    GROW(t->weight, sizeof *t->weight);
    GROW(t->base, sizeof *t->base);
    GROW(t->orient, sizeof *t->orient);
    GROW(t->voxels, b->tv);
#undef GROW
    b->cap = cap;
    return GS_OK;
}

static gs_err grow_bases(builder *b)
{
    if (b->ts.nbase < b->nbase_cap)
        return GS_OK;
    int cap = b->nbase_cap ? 2 * b->nbase_cap : 16;
    void *p;
#define GROW(ptr)                                                                                  \
    p = gs_realloc(ptr, (size_t)cap * sizeof *(ptr));                                              \
    GS_CHECK(p, GS_ERR_MEM, "%s: out of memory for tiles", b->path);                              \
    ptr = p;
    GROW(b->base_name);
    GROW(b->base_first);
    GROW(b->base_card);
#undef GROW
    b->nbase_cap = cap;
    return GS_OK;
}

/* Reads one tile .vox (one model), maps its colours into the shared palette
 * into vox (b->tv voxels; sets b->s from the first tile). */
static gs_err read_tile(builder *b, const char *file, int line, uint8_t **vox)
{
    gs_vox v;
    GS_CALL(gs_vox_read(file, &v));
    gs_err err = GS_OK;
    GS_TRY(err, gs_input_note("model.tileset", file), done); /* resume checks it (#25) */
    GS_TRY_CHECK(err, v.nmodels == 1, GS_ERR_FORMAT, done,
                 "%s (tile of %s:%d): %d models: expected one", file, b->path, line, v.nmodels);
    const gs_vox_model *m = &v.models[0];
    if (b->tv == 0) {
        GS_TRY_CHECK(err, m->nx <= MAX_TILE_SIDE && m->ny <= MAX_TILE_SIDE && m->nz <= MAX_TILE_SIDE,
                     GS_ERR_FORMAT, done, "%s: %dx%dx%d voxels: tiles of at most %d per side",
                     file, m->nx, m->ny, m->nz, MAX_TILE_SIDE);
        b->s[0] = m->nx;
        b->s[1] = m->ny;
        b->s[2] = m->nz;
        b->tv = (size_t)m->nx * (size_t)m->ny * (size_t)m->nz;
    }
    GS_TRY_CHECK(err, m->nx == b->s[0] && m->ny == b->s[1] && m->nz == b->s[2], GS_ERR_FORMAT, done,
                 "%s (tile of %s:%d): %dx%dx%d voxels: expected %dx%dx%d like the first tile", file,
                 b->path, line, m->nx, m->ny, m->nz, b->s[0], b->s[1], b->s[2]);
    GS_TRY(err, gs_alloc_array((void **)vox, b->tv, 1, "tile voxels"), done);
    int map[256];
    for (int c = 0; c < 256; c++)
        map[c] = -1;
    for (size_t i = 0; i < b->tv; i++) {
        int c = m->labels[i];
        if (c && map[c] < 0) {
            int k = 1;
            while (k <= b->ncolors && memcmp(b->ts.vox_palette[k], v.palette[c], 4))
                k++;
            if (k > b->ncolors) {
                GS_TRY_CHECK(err, b->ncolors < 255, GS_ERR_FORMAT, done,
                             "%s: the tiles use more than 255 colours", b->path);
                memcpy(b->ts.vox_palette[k], v.palette[c], 4);
                b->ts.vox_palette[k][3] = 255;
                b->ncolors = k;
            }
            map[c] = k;
        }
        (*vox)[i] = c ? (uint8_t)map[c] : 0;
    }
done:
    if (err) {
        gs_free(*vox);
        *vox = NULL;
    }
    gs_vox_destroy(&v);
    return err;
}

/* Adds a declared tile: its distinct images under the group. */
static gs_err add_base(builder *b, const char *name, int line, double weight, const uint8_t *vox)
{
    GS_CHECK(name[0] && strlen(name) < 60 && !strchr(name, ' '), GS_ERR_FORMAT,
             "%s:%d: tile name '%s': expected 1 to 59 characters, no spaces", b->path, line, name);
    for (int t = 0; t < b->ts.nbase; t++)
        GS_CHECK(strcmp(b->base_name[t], name), GS_ERR_FORMAT,
                 "%s:%d: tile '%s' is declared twice", b->path, line, name);
    GS_CALL(grow_bases(b));
    int first = b->ts.ntiles, card = 0;
    uint8_t *img = gs_malloc(b->tv);
    GS_CHECK(img, GS_ERR_MEM, "out of memory");
    gs_err err = GS_OK;
    for (int k = 0; k < b->ng; k++) {
        transform(&b->g[k], b->s, vox, img);
        int seen = 0;
        for (int o = first; o < first + card && !seen; o++)
            seen = !memcmp(b->ts.voxels + (size_t)o * b->tv, img, b->tv);
        if (seen)
            continue;
        GS_TRY(err, grow_tiles(b, first + card + 1), done);
        int t = first + card;
        memcpy(b->ts.voxels + (size_t)t * b->tv, img, b->tv);
        snprintf(b->ts.names[t], sizeof b->ts.names[t], "%s %d", name, card);
        b->ts.weight[t] = weight;
        b->ts.base[t] = b->ts.nbase;
        b->ts.orient[t] = k;
        card++;
    }
    snprintf(b->base_name[b->ts.nbase], sizeof b->base_name[0], "%s", name);
    b->base_first[b->ts.nbase] = first;
    b->base_card[b->ts.nbase] = card;
    b->ts.nbase++;
    b->ts.ntiles = first + card;
done:
    gs_free(img);
    return err;
}

/* act[g][t]: the oriented tile that group element g makes of t. */
static gs_err build_action(builder *b)
{
    const int T = b->ts.ntiles;
    GS_CALL(gs_alloc_array((void **)&b->act, (size_t)b->ng * (size_t)T, sizeof *b->act, "tile action"));
    uint8_t *img = gs_malloc(b->tv);
    GS_CHECK(img, GS_ERR_MEM, "out of memory");
    for (int t = 0; t < T; t++) {
        int bs = b->ts.base[t], f = b->base_first[bs], c = b->base_card[bs];
        for (int k = 0; k < b->ng; k++) {
            transform(&b->g[k], b->s, b->ts.voxels + (size_t)t * b->tv, img);
            int hit = -1;
            for (int o = f; o < f + c && hit < 0; o++)
                if (!memcmp(b->ts.voxels + (size_t)o * b->tv, img, b->tv))
                    hit = o;
            if (hit < 0) { /* cannot happen: the orbit of a tile is closed */
                gs_free(img);
                GS_RAISE(GS_ERR_INTERNAL, "%s: orientation of %s not found", b->path,
                         b->ts.names[t]);
            }
            b->act[(size_t)k * (size_t)T + (size_t)t] = hit;
        }
    }
    gs_free(img);
    return GS_OK;
}

static gs_err push_pair(builder *b, int dir, int a, int c)
{
    if (b->npairs == b->pcap) {
        size_t cap = b->pcap ? 2 * b->pcap : 256;
        void *p = gs_realloc(b->ts.pairs, cap * sizeof *b->ts.pairs);
        GS_CHECK(p, GS_ERR_MEM, "%s: out of memory for pairs", b->path);
        b->ts.pairs = p;
        b->pcap = cap;
    }
    b->ts.pairs[b->npairs++] = (gs_model_pair){(uint8_t)dir, (uint16_t)(a + 1), (uint16_t)(c + 1)};
    return GS_OK;
}

/* Oriented tile c at +axis of a, and every image of that pair under the group. */
static gs_err add_closed(builder *b, int a, int c, int axis)
{
    const size_t T = (size_t)b->ts.ntiles;
    for (int k = 0; k < b->ng; k++) {
        int j = 0;
        while (!b->g[k].m[j][axis])
            j++;
        int A = b->act[(size_t)k * T + (size_t)a], C = b->act[(size_t)k * T + (size_t)c];
        if (b->g[k].m[j][axis] > 0)
            GS_CALL(push_pair(b, 2 * j, A, C));
        else
            GS_CALL(push_pair(b, 2 * j, C, A));
    }
    return GS_OK;
}

static int find_base(const builder *b, const char *name)
{
    for (int t = 0; t < b->ts.nbase; t++)
        if (!strcmp(b->base_name[t], name))
            return t;
    return -1;
}

/* Sorts and dedups the pairs, drops those putting the ground tile above
 * anything, hands the tile set over. */
static gs_err finish(builder *b, gs_model_tileset *out)
{
    gs_model_tileset *t = &b->ts;
    if (t->ground) {
        size_t m = 0;
        for (size_t i = 0; i < b->npairs; i++)
            if (!(t->pairs[i].dir == 4 && t->pairs[i].b == t->ground))
                t->pairs[m++] = t->pairs[i];
        b->npairs = m;
    }
    t->npairs = gs_tileset_pairs_unique(t->pairs, b->npairs);
    GS_CHECK(t->npairs > 0, GS_ERR_FORMAT, "%s: no allowed pair of tiles", b->path);
    t->dim = 3;
    t->vx = b->s[0];
    t->vy = b->s[1];
    t->vz = b->s[2];
    t->group = b->ng;
    *out = *t;
    memset(t, 0, sizeof *t);
    return GS_OK;
}

static gs_err check_shape(builder *b, int full)
{
    GS_CHECK(b->s[0] == b->s[1] && (!full || b->s[0] == b->s[2]), GS_ERR_FORMAT,
             "%s: tiles of %dx%dx%d voxels: the %s symmetry needs %s", b->path, b->s[0], b->s[1],
             b->s[2], full ? "cube" : "square", full ? "cubes" : "square x-y sides");
    return GS_OK;
}

/* ---- MarkovJunior --------------------------------------------------------- */

/* "xz Turn" -> oriented tile (the tile's first orientation turned by z, then x). */
static gs_err mj_ref(builder *b, const xml_elem *el, const char *attr, int *out)
{
    const char *v = gs_tsxml_attr(el, attr);
    GS_CHECK(v, GS_ERR_FORMAT, "%s:%d: <neighbor> without %s=\"[ROTATIONS] TILE\"", b->path,
             el->line, attr);
    const char *sp = strchr(v, ' ');
    const char *name = sp ? sp + 1 : v;
    int bs = find_base(b, name);
    GS_CHECK(bs >= 0, GS_ERR_FORMAT, "%s:%d: %s=\"%s\": no tile named '%s' in <tiles>", b->path,
             el->line, attr, v, name);
    int t = b->base_first[bs];
    const size_t T = (size_t)b->ts.ntiles;
    for (const char *p = sp ? sp - 1 : NULL; p && p >= v; p--) {
        const gmat *m = *p == 'x' ? &ROT_X : *p == 'y' ? &ROT_Y : *p == 'z' ? &ROT_Z : NULL;
        GS_CHECK(m, GS_ERR_FORMAT, "%s:%d: %s=\"%s\": '%c' is no rotation (x, y or z)", b->path,
                 el->line, attr, v, *p);
        int k = group_index(b->g, b->ng, m);
        GS_CHECK(k >= 0, GS_ERR_FORMAT,
                 "%s:%d: %s=\"%s\": rotation about %c needs fullSymmetry=\"True\"", b->path,
                 el->line, attr, v, *p);
        t = b->act[(size_t)k * T + (size_t)t];
    }
    *out = t;
    return GS_OK;
}

static int parse_bool_attr(const char *s, int *v)
{
    if (!s)
        return 1;
    if (!strcmp(s, "True") || !strcmp(s, "true")) {
        *v = 1;
        return 1;
    }
    if (!strcmp(s, "False") || !strcmp(s, "false")) {
        *v = 0;
        return 1;
    }
    return 0;
}

gs_err gs_tileset3d_load_mj(const char *path, const xml_doc *d, const char *folder,
                            gs_model_tileset *out)
{
    builder b;
    memset(&b, 0, sizeof b);
    b.path = path;
    gs_err err = GS_OK;
    uint8_t *vox = NULL;
    int full = 0;
    const char *fs = gs_tsxml_attr(&d->e[0], "fullSymmetry");
    GS_TRY_CHECK(err, parse_bool_attr(fs, &full), GS_ERR_FORMAT, fail,
                 "%s:%d: fullSymmetry=\"%s\": expected True or False", path, d->e[0].line, fs);
    b.ng = build_group(full, 4, 1, b.g);
    /* tile folder: folder, else the XML path without ".xml" */
    char dir[4096];
    size_t pl = strlen(path);
    const char *slash = strrchr(path, '/');
    size_t dl = slash ? (size_t)(slash - path) + 1 : 0;
    if (folder && folder[0])
        snprintf(dir, sizeof dir, "%.*s%s", (int)dl, path, folder);
    else {
        GS_TRY_CHECK(err, pl > 4 && !strcmp(path + pl - 4, ".xml"), GS_ERR_ARG, fail,
                     "%s: expected a .xml file name (its tiles are in the folder of that name)",
                     path);
        snprintf(dir, sizeof dir, "%.*s", (int)(pl - 4), path);
    }
    for (int i = 0; i < d->n; i++) {
        const xml_elem *el = &d->e[i];
        if (strcmp(el->name, "tile") || el->parent < 0 || strcmp(d->e[el->parent].name, "tiles"))
            continue;
        const char *nm = gs_tsxml_attr(el, "name");
        GS_TRY_CHECK(err, nm, GS_ERR_FORMAT, fail, "%s:%d: <tile> needs name=\"...\"", path,
                     el->line);
        double w = 1.0;
        const char *ws = gs_tsxml_attr(el, "weight");
        if (ws) {
            char *e = NULL;
            w = strtod(ws, &e);
            GS_TRY_CHECK(err, e && *e == '\0' && w > 0 && w < 1e9, GS_ERR_FORMAT, fail,
                         "%s:%d: tile %s: weight=\"%s\": expected a number in (0, 1e9)", path,
                         el->line, nm, ws);
        }
        char file[4200];
        snprintf(file, sizeof file, "%s/%s.vox", dir, nm);
        GS_TRY(err, read_tile(&b, file, el->line, &vox), fail);
        if (b.ts.nbase == 0)
            GS_TRY(err, check_shape(&b, full), fail);
        GS_TRY(err, add_base(&b, nm, el->line, w, vox), fail);
        GS_FREE(vox);
    }
    GS_TRY_CHECK(err, b.ts.nbase > 0, GS_ERR_FORMAT, fail, "%s: no <tile> in <tiles>", path);
    GS_TRY(err, build_action(&b), fail);
    for (int i = 0; i < d->n; i++) {
        const xml_elem *el = &d->e[i];
        if (strcmp(el->name, "neighbor") || el->parent < 0 ||
            strcmp(d->e[el->parent].name, "neighbors"))
            continue;
        int a, c;
        if (gs_tsxml_attr(el, "left") || gs_tsxml_attr(el, "right")) {
            GS_TRY(err, mj_ref(&b, el, "left", &a), fail);
            GS_TRY(err, mj_ref(&b, el, "right", &c), fail);
            GS_TRY(err, add_closed(&b, a, c, 0), fail);
        } else {
            GS_TRY_CHECK(err, !full, GS_ERR_FORMAT, fail,
                         "%s:%d: <neighbor> needs left=\"...\" right=\"...\" (fullSymmetry)", path,
                         el->line);
            GS_TRY(err, mj_ref(&b, el, "bottom", &a), fail);
            GS_TRY(err, mj_ref(&b, el, "top", &c), fail);
            GS_TRY(err, add_closed(&b, a, c, 2), fail);
        }
    }
    GS_TRY(err, finish(&b, out), fail);
    builder_free(&b);
    return GS_OK;
fail:
    gs_free(vox);
    builder_free(&b);
    return err;
}

/* ---- DeBroglie ------------------------------------------------------------ */

static const char *jstr(const tsjson_doc *d, int obj, const char *key)
{
    int i = gs_tsjson_get(d, obj, key);
    return i >= 0 && d->n[i].type == TSJ_STR ? d->n[i].str : NULL;
}

static gs_err db_tile(builder *b, const tsjson_doc *d, int node, const char *what, int *label)
{
    GS_CHECK(node >= 0 && d->n[node].type == TSJ_STR, GS_ERR_FORMAT,
             "%s:%d: %s: expected a tile name (a string)", b->path,
             node >= 0 ? d->n[node].line : 0, what);
    const char *nm = d->n[node].str;
    GS_CHECK(!strchr(nm, '!'), GS_ERR_FORMAT,
             "%s:%d: %s \"%s\": rotated tile names are not supported, name the tile", b->path,
             d->n[node].line, what, nm);
    int bs = find_base(b, nm);
    GS_CHECK(bs >= 0, GS_ERR_FORMAT, "%s:%d: %s \"%s\": no tile of that value in \"tiles\"",
             b->path, d->n[node].line, what, nm);
    *label = b->base_first[bs];
    return GS_OK;
}

/* "zmin", "xmin, ymax", "all" -> side bits; -1 on an unknown word. */
static int db_sides(const char *s)
{
    static const char *const nm[6] = {"xmin", "xmax", "ymin", "ymax", "zmin", "zmax"};
    unsigned bits = 0;
    while (*s) {
        while (*s == ' ' || *s == ',' || *s == '|')
            s++;
        if (!*s)
            break;
        char w[16];
        size_t k = 0;
        while (*s && *s != ' ' && *s != ',' && *s != '|') {
            if (k + 1 < sizeof w)
                w[k++] = (char)tolower((unsigned char)*s);
            s++;
        }
        w[k] = '\0';
        int hit = 0;
        for (int i = 0; i < 6; i++)
            if (!strcmp(w, nm[i])) {
                bits |= 1u << i;
                hit = 1;
            }
        if (!strcmp(w, "all")) {
            bits |= 63u;
            hit = 1;
        }
        if (!strcmp(w, "none"))
            hit = 1;
        if (!hit)
            return -1;
    }
    return (int)bits;
}

/* Every tile of list src with every tile of list dst, dst at +axis of src
 * (sign -1: at -axis). */
static gs_err db_adjacency(builder *b, const tsjson_doc *d, int src, int dst, int axis, int sign)
{
    for (int s = src >= 0 ? d->n[src].first : -1; s >= 0; s = d->n[s].next)
        for (int t = d->n[dst].first; t >= 0; t = d->n[t].next) {
            int a, c;
            GS_CALL(db_tile(b, d, s, "adjacency", &a));
            GS_CALL(db_tile(b, d, t, "adjacency", &c));
            GS_CALL(sign > 0 ? add_closed(b, a, c, axis) : add_closed(b, c, a, axis));
        }
    return GS_OK;
}

/* Orientation counts the DeBroglie letters declare under 4 rotations + mirrors. */
static int db_letter_card(const char *s)
{
    if (!s || strlen(s) != 1)
        return 0;
    switch (s[0]) {
    case 'X': return 1;
    case 'I': case '\\': return 2;
    case 'T': case 'L': case 'E': case 'Q': return 4;
    case 'F': case 'N': return 8;
    default: return 0;
    }
}

gs_err gs_tileset3d_load_debroglie(const char *path, gs_model_tileset *out)
{
    builder b;
    memset(&b, 0, sizeof b);
    b.path = path;
    tsjson_doc d;
    GS_CALL(gs_tsjson_parse(path, &d));
    gs_err err = GS_OK;
    uint8_t *vox = NULL;
    const char *st = jstr(&d, 0, "srcType");
    GS_TRY_CHECK(err, st && !strcmp(st, "voxSet"), GS_ERR_FORMAT, fail,
                 "%s: \"srcType\": \"%s\": expected \"voxSet\" (a set of .vox tiles)", path,
                 st ? st : "(missing)");
    int sym = 1, si = gs_tsjson_get(&d, 0, "symmetry");
    if (si >= 0) {
        GS_TRY_CHECK(err, d.n[si].type == TSJ_NUM, GS_ERR_FORMAT, fail,
                     "%s:%d: \"symmetry\": expected a number", path, d.n[si].line);
        sym = (int)d.n[si].num;
        GS_TRY_CHECK(err, sym == d.n[si].num && (sym == 1 || sym == 2 || sym == 4 || sym == 8),
                     GS_ERR_FORMAT, fail,
                     "%s:%d: \"symmetry\": %g: expected 1, 2, 4 or 8 (the lattice's rotations "
                     "and mirrors about z)",
                     path, d.n[si].line, d.n[si].num);
    }
    b.ng = build_group(0, sym % 2 ? sym : sym / 2, sym % 2 == 0, b.g);
    int tiles = gs_tsjson_get(&d, 0, "tiles");
    GS_TRY_CHECK(err, tiles >= 0 && d.n[tiles].type == TSJ_ARR, GS_ERR_FORMAT, fail,
                 "%s: \"tiles\": expected an array of {\"src\": FILE.vox, \"value\": NAME}", path);
    const char *slash = strrchr(path, '/');
    int dl = slash ? (int)(slash - path) + 1 : 0;
    for (int t = d.n[tiles].first; t >= 0; t = d.n[t].next) {
        const char *src = jstr(&d, t, "src"), *val = jstr(&d, t, "value");
        GS_TRY_CHECK(err, d.n[t].type == TSJ_OBJ && src && val, GS_ERR_FORMAT, fail,
                     "%s:%d: tile: expected {\"src\": FILE.vox, \"value\": NAME}", path, d.n[t].line);
        double w = 1.0;
        int mf = gs_tsjson_get(&d, t, "multiplyFrequency");
        if (mf >= 0) {
            char *e = NULL;
            if (d.n[mf].type == TSJ_NUM)
                w = d.n[mf].num;
            else if (d.n[mf].type == TSJ_STR) {
                w = strtod(d.n[mf].str, &e);
                if (e && *e == '%')
                    w /= 100, e++;
            }
            GS_TRY_CHECK(err, (d.n[mf].type == TSJ_NUM || (e && *e == '\0')) && w > 0 && w < 1e9,
                         GS_ERR_FORMAT, fail,
                         "%s:%d: tile %s: \"multiplyFrequency\": expected a number in (0, 1e9) or "
                         "a percentage",
                         path, d.n[mf].line, val);
        }
        char file[4200];
        snprintf(file, sizeof file, "%.*s%s", dl, path, src);
        GS_TRY(err, read_tile(&b, file, d.n[t].line, &vox), fail);
        if (b.ts.nbase == 0)
            GS_TRY(err, check_shape(&b, 0), fail);
        GS_TRY(err, add_base(&b, val, d.n[t].line, w, vox), fail);
        GS_FREE(vox);
        const char *letter = jstr(&d, t, "tileSymmetry");
        int want = db_letter_card(letter), got = b.base_card[b.ts.nbase - 1];
        if (want && b.ng == 8 && want != got)
            gs_log(GS_LOG_WARN,
                   "%s:%d: tile %s: tileSymmetry %s declares %d orientations, its voxels have %d "
                   "(the voxels are used)",
                   path, d.n[t].line, val, letter, want, got);
    }
    GS_TRY_CHECK(err, b.ts.nbase > 0, GS_ERR_FORMAT, fail, "%s: \"tiles\" is empty", path);
    GS_TRY(err, build_action(&b), fail);
    const int T = b.ts.ntiles;
    int ai = gs_tsjson_get(&d, 0, "autoAdjacency");
    if (ai >= 0 && d.n[ai].type == TSJ_BOOL && d.n[ai].num) {
        /* b at +axis of a when a's last layer along axis equals b's first */
        const int *s = b.s;
        for (int axis = 0; axis < 3; axis++)
            for (int a = 0; a < T; a++)
                for (int c = 0; c < T; c++) {
                    const uint8_t *va = b.ts.voxels + (size_t)a * b.tv, *vc = b.ts.voxels + (size_t)c * b.tv;
                    int same = 1;
                    int u = (axis + 1) % 3, w = (axis + 2) % 3;
                    for (int i = 0; i < s[u] && same; i++)
                        for (int j = 0; j < s[w] && same; j++) {
                            int pa[3], pc[3];
                            pa[axis] = s[axis] - 1;
                            pc[axis] = 0;
                            pa[u] = pc[u] = i;
                            pa[w] = pc[w] = j;
                            same = va[pa[0] + s[0] * (pa[1] + s[1] * pa[2])] ==
                                   vc[pc[0] + s[0] * (pc[1] + s[1] * pc[2])];
                        }
                    if (same)
                        GS_TRY(err, push_pair(&b, 2 * axis, a, c), fail);
                }
    }
    int adj = gs_tsjson_get(&d, 0, "adjacencies");
    for (int a = adj >= 0 ? d.n[adj].first : -1; a >= 0; a = d.n[a].next) {
        static const char *const keys[3][2] = {{"left", "right"}, {"up", "down"}, {"above", "below"}};
        int done_one = 0;
        for (int k = 0; k < 3; k++) {
            int s = gs_tsjson_get(&d, a, keys[k][0]), t = gs_tsjson_get(&d, a, keys[k][1]);
            if (s < 0 && t < 0)
                continue;
            GS_TRY_CHECK(err, s >= 0 && t >= 0 && d.n[s].type == TSJ_ARR && d.n[t].type == TSJ_ARR,
                         GS_ERR_FORMAT, fail,
                         "%s:%d: adjacency: \"%s\" and \"%s\" must both be lists of tile names",
                         path, d.n[a].line, keys[k][0], keys[k][1]);
            /* left/right: right at +x; up/down: down at +y; above/below: below at -z */
            GS_TRY(err, db_adjacency(&b, &d, s, t, k, k == 2 ? -1 : 1), fail);
            done_one = 1;
        }
        GS_TRY_CHECK(err, done_one, GS_ERR_FORMAT, fail,
                     "%s:%d: adjacency: expected left/right, up/down or above/below", path,
                     d.n[a].line);
    }
    int gi = gs_tsjson_get(&d, 0, "ground");
    if (gi >= 0) {
        int l;
        GS_TRY(err, db_tile(&b, &d, gi, "\"ground\"", &l), fail);
        b.ts.ground = l + 1;
    }
    int cons = gs_tsjson_get(&d, 0, "constraints");
    for (int c = cons >= 0 ? d.n[cons].first : -1; c >= 0; c = d.n[c].next) {
        const char *type = jstr(&d, c, "type");
        GS_TRY_CHECK(err, type, GS_ERR_FORMAT, fail, "%s:%d: constraint without \"type\"", path,
                     d.n[c].line);
        if (!strcmp(type, "border")) {
            int l;
            GS_TRY_CHECK(err, !b.ts.border, GS_ERR_FORMAT, fail,
                         "%s:%d: only one border constraint is supported", path, d.n[c].line);
            GS_TRY(err, db_tile(&b, &d, gs_tsjson_get(&d, c, "tile"), "border \"tile\"", &l), fail);
            const char *sides = jstr(&d, c, "sides"), *ex = jstr(&d, c, "excludeSides");
            int in = sides ? db_sides(sides) : 63, out_ = ex ? db_sides(ex) : 0;
            GS_TRY_CHECK(err, in >= 0 && out_ >= 0, GS_ERR_FORMAT, fail,
                         "%s:%d: border sides \"%s\" / excludeSides \"%s\": expected words of "
                         "xmin xmax ymin ymax zmin zmax all none",
                         path, d.n[c].line, sides ? sides : "", ex ? ex : "");
            int inv = gs_tsjson_get(&d, c, "invertArea"), ban = gs_tsjson_get(&d, c, "ban");
            GS_TRY_CHECK(err, (inv < 0 || !d.n[inv].num) && (ban < 0 || !d.n[ban].num),
                         GS_ERR_FORMAT, fail,
                         "%s:%d: border: invertArea and ban are not supported", path, d.n[c].line);
            b.ts.border = l + 1;
            /* cells on a side of in and none of out_: kept as two masks */
            b.ts.border_sides = (unsigned)in | ((unsigned)out_ << 6);
        } else if (!strcmp(type, "fixedTile")) {
            int l, pt = gs_tsjson_get(&d, c, "point");
            GS_TRY(err, db_tile(&b, &d, gs_tsjson_get(&d, c, "tile"), "fixedTile \"tile\"", &l), fail);
            int xyz[3];
            for (int k = 0; k < 3; k++) {
                int v = gs_tsjson_get(&d, pt, k == 0 ? "x" : k == 1 ? "y" : "z");
                GS_TRY_CHECK(err, v >= 0 && d.n[v].type == TSJ_NUM && d.n[v].num >= 0 &&
                                      d.n[v].num < 1e6 && d.n[v].num == (int)d.n[v].num,
                             GS_ERR_FORMAT, fail,
                             "%s:%d: fixedTile: expected \"point\": {\"x\": X, \"y\": Y, \"z\": Z} "
                             "(integers >= 0)",
                             path, d.n[c].line);
                xyz[k] = (int)d.n[v].num;
            }
            void *p = gs_realloc(b.ts.fixed, (size_t)(b.ts.nfixed + 1) * sizeof *b.ts.fixed);
            GS_TRY_CHECK(err, p, GS_ERR_MEM, fail, "out of memory");
            b.ts.fixed = p;
            b.ts.fixed[b.ts.nfixed][0] = xyz[0];
            b.ts.fixed[b.ts.nfixed][1] = xyz[1];
            b.ts.fixed[b.ts.nfixed][2] = xyz[2];
            b.ts.fixed[b.ts.nfixed][3] = l + 1;
            b.ts.nfixed++;
        } else {
            GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, fail,
                         "%s:%d: constraint type \"%s\": only border and fixedTile are supported",
                         path, d.n[c].line, type);
        }
    }
    GS_TRY(err, finish(&b, out), fail);
    builder_free(&b);
    gs_tsjson_free(&d);
    return GS_OK;
fail:
    gs_free(vox);
    builder_free(&b);
    gs_tsjson_free(&d);
    return err;
}

/* ---- output --------------------------------------------------------------- */

gs_err gs_model_tileset_assemble(const gs_model_tileset *ts, const gs_model_lattice *lat,
                                 gs_model_lattice *out, uint8_t palette[256][4])
{
    GS_CHECK(ts->dim == 3 && ts->voxels, GS_ERR_ARG, "not a voxel tile set");
    const int vx = ts->vx, vy = ts->vy, vz = ts->vz;
    GS_CHECK((int64_t)lat->nx * vx < (1 << 20) && (int64_t)lat->ny * vy < (1 << 20) &&
                 (int64_t)lat->nz * vz < (1 << 20) &&
                 (double)lat->nx * vx * (double)lat->ny * vy * (double)lat->nz * vz < 4e9,
             GS_ERR_ARG, "%dx%dx%d tiles of %dx%dx%d voxels: too many voxels to assemble",
             lat->nx, lat->ny, lat->nz, vx, vy, vz);
    GS_CALL(gs_model_lattice_create(out, lat->nx * vx, lat->ny * vy, lat->nz * vz));
    const size_t tv = (size_t)vx * vy * vz;
    for (int z = 0; z < lat->nz; z++)
        for (int y = 0; y < lat->ny; y++)
            for (int x = 0; x < lat->nx; x++) {
                int l = lat->labels[gs_model_lattice_index(lat, x, y, z)];
                const uint8_t *v = l >= 1 && l <= ts->ntiles ? ts->voxels + (size_t)(l - 1) * tv : NULL;
                for (int k = 0; k < vz; k++)
                    for (int j = 0; j < vy; j++)
                        for (int i = 0; i < vx; i++)
                            out->labels[gs_model_lattice_index(out, x * vx + i, y * vy + j, z * vz + k)] =
                                v ? v[i + vx * (j + vy * k)] : 0;
            }
    memcpy(palette, ts->vox_palette, sizeof ts->vox_palette);
    return GS_OK;
}

gs_err gs_model_tileset_catalogue(const gs_model_tileset *ts, gs_model_lattice *out)
{
    GS_CHECK(ts->dim == 3 && ts->voxels && ts->nbase > 0, GS_ERR_ARG, "not a voxel tile set");
    gs_model_lattice row = {0};
    GS_CALL(gs_model_lattice_create(&row, 2 * ts->nbase - 1, 1, 1));
    int b = 0;
    for (int t = 0; t < ts->ntiles && b < ts->nbase; t++)
        if (ts->base[t] == b && ts->orient[t] == 0)
            row.labels[2 * b++] = (uint16_t)(t + 1);
    /* gaps are label 0: nothing is drawn there */
    uint8_t pal[256][4];
    gs_err err = gs_model_tileset_assemble(ts, &row, out, pal);
    gs_model_lattice_destroy(&row);
    return err;
}

gs_err gs_model_tileset_write_voxels(const gs_model_tileset *ts, const gs_model_lattice *lat,
                                     const char *vox_path, const char *preview_path, int side)
{
    gs_model_lattice vox = {0}, cat = {0};
    gs_model_palette pal = {{{0}}, 1};
    GS_CALL(gs_model_tileset_assemble(ts, lat, &vox, pal.rgba));
    gs_err err = gs_model_write_vox(vox_path, &vox, &pal, NULL);
    if (!err && preview_path)
        err = gs_model_tileset_catalogue(ts, &cat);
    if (!err && preview_path)
        err = gs_model_write_preview(preview_path, &cat, &vox, &pal, side);
    gs_model_lattice_destroy(&cat);
    gs_model_lattice_destroy(&vox);
    return err;
}

gs_err gs_model_tileset_pins(const gs_model_tileset *ts, const char *file, const int dims[3],
                             int fixed_z_faces, uint16_t *pins)
{
    const int nx = dims[0], ny = dims[1], nz = dims[2];
    const int fix = fixed_z_faces && nz >= 3;
    const size_t sx = (size_t)nx, sxy = (size_t)nx * (size_t)ny;
    if (ts->ground && !fix)
        for (size_t i = 0; i < sxy; i++)
            pins[i] = (uint16_t)ts->ground;
    if (ts->border) {
        unsigned in = ts->border_sides & 63u, out = (ts->border_sides >> 6) & 63u;
        for (int z = fix; z < nz - fix; z++)
            for (int y = 0; y < ny; y++)
                for (int x = 0; x < nx; x++) {
                    unsigned on = (x == 0) | (x == nx - 1) << 1 | (y == 0) << 2 |
                                  (y == ny - 1) << 3 | (z == 0) << 4 | (z == nz - 1) << 5;
                    if ((on & in) && !(on & out))
                        pins[(size_t)x + sx * (size_t)y + sxy * (size_t)z] = (uint16_t)ts->border;
                }
    }
    for (int f = 0; f < ts->nfixed; f++) {
        const int *p = ts->fixed[f];
        GS_CHECK(p[0] < nx && p[1] < ny && p[2] < nz, GS_ERR_ARG,
                 "%s: fixedTile %s at (%d, %d, %d) lies outside the %dx%dx%d output (model.size)",
                 file, ts->names[p[3] - 1], p[0], p[1], p[2], nx, ny, nz);
        GS_CHECK(p[2] >= fix && p[2] < nz - fix, GS_ERR_ARG,
                 "%s: fixedTile %s at z = %d lies on a layer the start model keeps "
                 "(model.fix_z_faces)",
                 file, ts->names[p[3] - 1], p[2]);
        pins[(size_t)p[0] + sx * (size_t)p[1] + sxy * (size_t)p[2]] = (uint16_t)p[3];
    }
    return GS_OK;
}
