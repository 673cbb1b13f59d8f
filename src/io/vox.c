/* MagicaVoxel .vox and Slab6 .slab.vox reader/writer; see include/geosynth/vox.h.
 *
 * The parser never trusts a size: each read goes through a cursor that knows
 * how many bytes remain in the current chunk, and every declared count is
 * compared with those bytes before anything is allocated.
 */
#include "geosynth/vox.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "geosynth/file.h"

#define VOX_MAX_FILE ((size_t)1 << 30)
#define VOX_MAX_GRAPH_DEPTH 64
#define VOX_MAX_INSTANCES 65536
#define VOX_MAX_TRANSLATION 1000000000LL
#define VOX_ROT_IDENTITY 4 /* row0 -> x, row1 -> y, all signs positive */

static const uint32_t default_palette[256] = {
    0x00000000, 0xffffffff, 0xffccffff, 0xff99ffff, 0xff66ffff, 0xff33ffff, 0xff00ffff, 0xffffccff, 0xffccccff, 0xff99ccff, 0xff66ccff, 0xff33ccff, 0xff00ccff, 0xffff99ff, 0xffcc99ff, 0xff9999ff,
    0xff6699ff, 0xff3399ff, 0xff0099ff, 0xffff66ff, 0xffcc66ff, 0xff9966ff, 0xff6666ff, 0xff3366ff, 0xff0066ff, 0xffff33ff, 0xffcc33ff, 0xff9933ff, 0xff6633ff, 0xff3333ff, 0xff0033ff, 0xffff00ff,
    0xffcc00ff, 0xff9900ff, 0xff6600ff, 0xff3300ff, 0xff0000ff, 0xffffffcc, 0xffccffcc, 0xff99ffcc, 0xff66ffcc, 0xff33ffcc, 0xff00ffcc, 0xffffcccc, 0xffcccccc, 0xff99cccc, 0xff66cccc, 0xff33cccc,
    0xff00cccc, 0xffff99cc, 0xffcc99cc, 0xff9999cc, 0xff6699cc, 0xff3399cc, 0xff0099cc, 0xffff66cc, 0xffcc66cc, 0xff9966cc, 0xff6666cc, 0xff3366cc, 0xff0066cc, 0xffff33cc, 0xffcc33cc, 0xff9933cc,
    0xff6633cc, 0xff3333cc, 0xff0033cc, 0xffff00cc, 0xffcc00cc, 0xff9900cc, 0xff6600cc, 0xff3300cc, 0xff0000cc, 0xffffff99, 0xffccff99, 0xff99ff99, 0xff66ff99, 0xff33ff99, 0xff00ff99, 0xffffcc99,
    0xffcccc99, 0xff99cc99, 0xff66cc99, 0xff33cc99, 0xff00cc99, 0xffff9999, 0xffcc9999, 0xff999999, 0xff669999, 0xff339999, 0xff009999, 0xffff6699, 0xffcc6699, 0xff996699, 0xff666699, 0xff336699,
    0xff006699, 0xffff3399, 0xffcc3399, 0xff993399, 0xff663399, 0xff333399, 0xff003399, 0xffff0099, 0xffcc0099, 0xff990099, 0xff660099, 0xff330099, 0xff000099, 0xffffff66, 0xffccff66, 0xff99ff66,
    0xff66ff66, 0xff33ff66, 0xff00ff66, 0xffffcc66, 0xffcccc66, 0xff99cc66, 0xff66cc66, 0xff33cc66, 0xff00cc66, 0xffff9966, 0xffcc9966, 0xff999966, 0xff669966, 0xff339966, 0xff009966, 0xffff6666,
    0xffcc6666, 0xff996666, 0xff666666, 0xff336666, 0xff006666, 0xffff3366, 0xffcc3366, 0xff993366, 0xff663366, 0xff333366, 0xff003366, 0xffff0066, 0xffcc0066, 0xff990066, 0xff660066, 0xff330066,
    0xff000066, 0xffffff33, 0xffccff33, 0xff99ff33, 0xff66ff33, 0xff33ff33, 0xff00ff33, 0xffffcc33, 0xffcccc33, 0xff99cc33, 0xff66cc33, 0xff33cc33, 0xff00cc33, 0xffff9933, 0xffcc9933, 0xff999933,
    0xff669933, 0xff339933, 0xff009933, 0xffff6633, 0xffcc6633, 0xff996633, 0xff666633, 0xff336633, 0xff006633, 0xffff3333, 0xffcc3333, 0xff993333, 0xff663333, 0xff333333, 0xff003333, 0xffff0033,
    0xffcc0033, 0xff990033, 0xff660033, 0xff330033, 0xff000033, 0xffffff00, 0xffccff00, 0xff99ff00, 0xff66ff00, 0xff33ff00, 0xff00ff00, 0xffffcc00, 0xffcccc00, 0xff99cc00, 0xff66cc00, 0xff33cc00,
    0xff00cc00, 0xffff9900, 0xffcc9900, 0xff999900, 0xff669900, 0xff339900, 0xff009900, 0xffff6600, 0xffcc6600, 0xff996600, 0xff666600, 0xff336600, 0xff006600, 0xffff3300, 0xffcc3300, 0xff993300,
    0xff663300, 0xff333300, 0xff003300, 0xffff0000, 0xffcc0000, 0xff990000, 0xff660000, 0xff330000, 0xff0000ee, 0xff0000dd, 0xff0000bb, 0xff0000aa, 0xff000088, 0xff000077, 0xff000055, 0xff000044,
    0xff000022, 0xff000011, 0xff00ee00, 0xff00dd00, 0xff00bb00, 0xff00aa00, 0xff008800, 0xff007700, 0xff005500, 0xff004400, 0xff002200, 0xff001100, 0xffee0000, 0xffdd0000, 0xffbb0000, 0xffaa0000,
    0xff880000, 0xff770000, 0xff550000, 0xff440000, 0xff220000, 0xff110000, 0xffeeeeee, 0xffdddddd, 0xffbbbbbb, 0xffaaaaaa, 0xff888888, 0xff777777, 0xff555555, 0xff444444, 0xff222222, 0xff111111};

void gs_vox_default_palette(uint8_t palette[256][4])
{
    /* The spec lists 0xAABBGGRR words: bytes R, G, B, A in little-endian order. */
    for (int i = 0; i < 256; i++)
        for (int c = 0; c < 4; c++)
            palette[i][c] = (uint8_t)(default_palette[i] >> (8 * c));
}

void gs_vox_destroy(gs_vox *v)
{
    if (!v)
        return;
    for (int i = 0; i < v->nmodels && v->models; i++)
        gs_free(v->models[i].labels);
    gs_free(v->models);
    gs_free(v->instances);
    memset(v, 0, sizeof *v);
}

static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static int32_t get_i32(const uint8_t *p)
{
    uint32_t u = get_u32(p);
    int32_t s;
    memcpy(&s, &u, sizeof s);
    return s;
}

/* ---------------------------------------------------------------- parsing */

/* A bounded cursor over one chunk's content. */
typedef struct cursor {
    const uint8_t *p;
    size_t len, pos;
    const char *name;  /* file name */
    const char *chunk; /* chunk id (4 chars + NUL) */
    size_t base;       /* byte offset of p in the file */
} cursor;

static gs_err cur_i32(cursor *c, const char *what, int32_t *out)
{
    GS_CHECK(c->len - c->pos >= 4, GS_ERR_FORMAT,
             "%s: chunk %s at byte %zu ends before its %s (needs 4 bytes, %zu remain)", c->name,
             c->chunk, c->base, what, c->len - c->pos);
    *out = get_i32(c->p + c->pos);
    c->pos += 4;
    return GS_OK;
}

/* STRING: int32 size + bytes (no NUL). Returns a pointer into the buffer. */
static gs_err cur_string(cursor *c, const uint8_t **s, size_t *n)
{
    int32_t len;
    GS_CALL(cur_i32(c, "string length", &len));
    GS_CHECK(len >= 0 && (size_t)len <= c->len - c->pos, GS_ERR_FORMAT,
             "%s: chunk %s at byte %zu has a string of %d bytes but only %zu bytes remain",
             c->name, c->chunk, c->base, len, c->len - c->pos);
    *s = c->p + c->pos;
    *n = (size_t)len;
    c->pos += (size_t)len;
    return GS_OK;
}

static int key_is(const uint8_t *k, size_t kn, const char *want)
{
    return kn == strlen(want) && memcmp(k, want, kn) == 0;
}

/* Parses up to 3 blank-separated integers from a non-terminated string. */
static int scan_ints(const uint8_t *s, size_t n, int count, int64_t lo, int64_t hi, int64_t *out)
{
    char tmp[96];
    if (n >= sizeof tmp)
        return 0;
    memcpy(tmp, s, n);
    tmp[n] = '\0';
    const char *p = tmp;
    for (int i = 0; i < count; i++) {
        while (*p == ' ')
            p++;
        if (!gs_scan_i64(&p, lo, hi, &out[i]))
            return 0;
    }
    while (*p == ' ')
        p++;
    return *p == '\0';
}

/* DICT. For frame dictionaries, picks up _t and _r. */
typedef struct frame_attrs {
    int64_t t[3];
    int64_t r;
} frame_attrs;

static gs_err cur_dict(cursor *c, frame_attrs *fa)
{
    int32_t n;
    GS_CALL(cur_i32(c, "dictionary size", &n));
    /* each pair needs at least 8 bytes: refuse absurd counts before looping */
    GS_CHECK(n >= 0 && (size_t)n <= (c->len - c->pos) / 8, GS_ERR_FORMAT,
             "%s: chunk %s at byte %zu declares %d dictionary entries but only %zu bytes remain",
             c->name, c->chunk, c->base, n, c->len - c->pos);
    for (int32_t i = 0; i < n; i++) {
        const uint8_t *k, *v;
        size_t kn, vn;
        GS_CALL(cur_string(c, &k, &kn));
        GS_CALL(cur_string(c, &v, &vn));
        if (!fa)
            continue;
        if (key_is(k, kn, "_t")) {
            GS_CHECK(scan_ints(v, vn, 3, -VOX_MAX_TRANSLATION, VOX_MAX_TRANSLATION, fa->t),
                     GS_ERR_FORMAT,
                     "%s: chunk %s at byte %zu: translation _t is not three integers in "
                     "[-%lld, %lld]",
                     c->name, c->chunk, c->base, VOX_MAX_TRANSLATION, VOX_MAX_TRANSLATION);
        } else if (key_is(k, kn, "_r")) {
            GS_CHECK(scan_ints(v, vn, 1, 0, 127, &fa->r), GS_ERR_FORMAT,
                     "%s: chunk %s at byte %zu: rotation _r is not an integer in [0, 127]",
                     c->name, c->chunk, c->base);
        }
    }
    return GS_OK;
}

typedef enum node_kind { NODE_TRN, NODE_GRP, NODE_SHP } node_kind;

typedef struct vox_node {
    int32_t id;
    node_kind kind;
    int32_t child;        /* TRN: child id; SHP: model id */
    size_t first, count;  /* GRP: range in the children array */
    int64_t t[3];
    int rotated;
    size_t offset;        /* byte offset of the chunk, for messages */
} vox_node;

typedef struct parse_state {
    const char *name;
    gs_vox v;
    int models_cap;
    size_t cells;
    int pending_size; /* a SIZE was read and waits for its XYZI */
    int psize[3];
    size_t psize_offset;
    vox_node *nodes;
    size_t nnodes, nodes_cap;
    int32_t *children;
    size_t nchildren, children_cap;
} parse_state;

static gs_err grow(void **arr, size_t *cap, size_t need, size_t elem, const char *what)
{
    if (need <= *cap)
        return GS_OK;
    size_t ncap = *cap ? *cap * 2 : 16;
    while (ncap < need)
        ncap *= 2;
    size_t bytes;
    GS_CHECK(gs_mul_size(ncap, elem, &bytes), GS_ERR_MEM, "%s: too many entries", what);
    void *p = gs_realloc(*arr, bytes);
    GS_CHECK(p, GS_ERR_MEM, "%s: cannot allocate %zu bytes", what, bytes);
    *arr = p;
    *cap = ncap;
    return GS_OK;
}

static gs_err parse_size(parse_state *st, cursor *c)
{
    GS_CHECK(!st->pending_size, GS_ERR_FORMAT,
             "%s: chunk SIZE at byte %zu follows the SIZE at byte %zu without an XYZI chunk "
             "between them",
             st->name, c->base, st->psize_offset);
    int32_t s[3];
    for (int a = 0; a < 3; a++)
        GS_CALL(cur_i32(c, "size", &s[a]));
    for (int a = 0; a < 3; a++)
        GS_CHECK(s[a] >= 1 && s[a] <= GS_VOX_MAX_AXIS, GS_ERR_FORMAT,
                 "%s: chunk SIZE at byte %zu declares %dx%dx%d voxels: expected sizes in "
                 "[1, %d]",
                 st->name, c->base, s[0], s[1], s[2], GS_VOX_MAX_AXIS);
    size_t cells = (size_t)s[0] * (size_t)s[1] * (size_t)s[2];
    GS_CHECK(st->cells + cells <= GS_VOX_MAX_CELLS, GS_ERR_FORMAT,
             "%s: chunk SIZE at byte %zu brings the models to %zu cells, more than the %zu "
             "accepted per file",
             st->name, c->base, st->cells + cells, GS_VOX_MAX_CELLS);
    st->pending_size = 1;
    memcpy(st->psize, s, sizeof s);
    st->psize_offset = c->base;
    return GS_OK;
}

static gs_err parse_xyzi(parse_state *st, cursor *c)
{
    GS_CHECK(st->pending_size, GS_ERR_FORMAT,
             "%s: chunk XYZI at byte %zu has no SIZE chunk before it", st->name, c->base);
    int32_t n;
    GS_CALL(cur_i32(c, "voxel count", &n));
    GS_CHECK(n >= 0 && (size_t)n <= (c->len - c->pos) / 4, GS_ERR_FORMAT,
             "%s: chunk XYZI at byte %zu declares %d voxels but holds room for %zu", st->name,
             c->base, n, (c->len - c->pos) / 4);
    size_t need = (size_t)st->v.nmodels + 1, cap = (size_t)st->models_cap;
    GS_CALL(grow((void **)&st->v.models, &cap, need, sizeof(gs_vox_model), st->name));
    st->models_cap = (int)cap;
    int nx = st->psize[0], ny = st->psize[1], nz = st->psize[2];
    size_t cells = (size_t)nx * (size_t)ny * (size_t)nz;
    uint8_t *labels = NULL;
    GS_CALL(gs_alloc_array((void **)&labels, cells, 1, "vox model lattice"));
    const uint8_t *p = c->p + c->pos;
    for (int32_t i = 0; i < n; i++, p += 4) {
        if (p[0] >= nx || p[1] >= ny || p[2] >= nz || p[3] == 0) {
            gs_free(labels);
            GS_CHECK(p[3] != 0, GS_ERR_FORMAT,
                     "%s: chunk XYZI at byte %zu, voxel %d at (%d,%d,%d) has colour index 0: "
                     "expected 1..255",
                     st->name, c->base, i, p[0], p[1], p[2]);
            GS_RAISE(GS_ERR_FORMAT,
                     "%s: chunk XYZI at byte %zu, voxel %d at (%d,%d,%d) lies outside the model "
                     "size %dx%dx%d",
                     st->name, c->base, i, p[0], p[1], p[2], nx, ny, nz);
        }
        labels[p[0] + (size_t)nx * (p[1] + (size_t)ny * p[2])] = p[3];
    }
    st->v.models[st->v.nmodels++] = (gs_vox_model){nx, ny, nz, labels};
    st->cells += cells;
    st->pending_size = 0;
    return GS_OK;
}

static gs_err new_node(parse_state *st, cursor *c, node_kind kind, vox_node **out)
{
    GS_CALL(grow((void **)&st->nodes, &st->nodes_cap, st->nnodes + 1, sizeof(vox_node),
                 st->name));
    vox_node *nd = &st->nodes[st->nnodes++];
    memset(nd, 0, sizeof *nd);
    nd->kind = kind;
    nd->offset = c->base;
    GS_CALL(cur_i32(c, "node id", &nd->id));
    GS_CHECK(nd->id >= 0, GS_ERR_FORMAT, "%s: chunk %s at byte %zu has node id %d < 0",
             st->name, c->chunk, c->base, nd->id);
    GS_CALL(cur_dict(c, NULL)); /* node attributes (_name, _hidden) */
    *out = nd;
    return GS_OK;
}

static gs_err parse_trn(parse_state *st, cursor *c)
{
    vox_node *nd;
    GS_CALL(new_node(st, c, NODE_TRN, &nd));
    int32_t reserved, layer, nframes;
    GS_CALL(cur_i32(c, "child node id", &nd->child));
    GS_CALL(cur_i32(c, "reserved id", &reserved));
    GS_CALL(cur_i32(c, "layer id", &layer));
    GS_CALL(cur_i32(c, "frame count", &nframes));
    GS_CHECK(nframes >= 1, GS_ERR_FORMAT,
             "%s: chunk nTRN at byte %zu declares %d frames: expected at least 1", st->name,
             c->base, nframes);
    frame_attrs fa = {{0, 0, 0}, VOX_ROT_IDENTITY};
    GS_CALL(cur_dict(c, &fa)); /* frame 0 is the static placement */
    memcpy(nd->t, fa.t, sizeof fa.t);
    nd->rotated = fa.r != VOX_ROT_IDENTITY;
    return GS_OK; /* further frames (animation) are ignored */
}

static gs_err parse_grp(parse_state *st, cursor *c)
{
    vox_node *nd;
    GS_CALL(new_node(st, c, NODE_GRP, &nd));
    int32_t n;
    GS_CALL(cur_i32(c, "child count", &n));
    GS_CHECK(n >= 0 && (size_t)n <= (c->len - c->pos) / 4, GS_ERR_FORMAT,
             "%s: chunk nGRP at byte %zu declares %d children but holds room for %zu", st->name,
             c->base, n, (c->len - c->pos) / 4);
    size_t first = st->nchildren;
    GS_CALL(grow((void **)&st->children, &st->children_cap, first + (size_t)n, sizeof(int32_t),
                 st->name));
    for (int32_t i = 0; i < n; i++)
        GS_CALL(cur_i32(c, "child id", &st->children[first + (size_t)i]));
    st->nchildren += (size_t)n;
    nd->first = first;
    nd->count = (size_t)n;
    return GS_OK;
}

static gs_err parse_shp(parse_state *st, cursor *c)
{
    vox_node *nd;
    GS_CALL(new_node(st, c, NODE_SHP, &nd));
    int32_t n;
    GS_CALL(cur_i32(c, "model count", &n));
    GS_CHECK(n >= 1, GS_ERR_FORMAT,
             "%s: chunk nSHP at byte %zu declares %d models: expected at least 1", st->name,
             c->base, n);
    GS_CALL(cur_i32(c, "model id", &nd->child)); /* frame 0's model */
    GS_CALL(cur_dict(c, NULL));
    return GS_OK;
}

static int node_cmp(const void *a, const void *b)
{
    const vox_node *x = a, *y = b;
    return (x->id > y->id) - (x->id < y->id);
}

static const vox_node *find_node(const parse_state *st, int32_t id)
{
    vox_node key;
    key.id = id;
    return bsearch(&key, st->nodes, st->nnodes, sizeof *st->nodes, node_cmp);
}

typedef struct walk_item {
    const vox_node *node;
    int64_t t[3];
    int rotated;
    int depth;
} walk_item;

/* Resolves the scene graph into instances (depth-first from node 0). */
static gs_err resolve_scene(parse_state *st)
{
    if (st->nnodes == 0)
        return GS_OK;
    qsort(st->nodes, st->nnodes, sizeof *st->nodes, node_cmp);
    for (size_t i = 1; i < st->nnodes; i++)
        GS_CHECK(st->nodes[i].id != st->nodes[i - 1].id, GS_ERR_FORMAT,
                 "%s: scene graph node id %d is used twice (chunks at bytes %zu and %zu)",
                 st->name, st->nodes[i].id, st->nodes[i - 1].offset, st->nodes[i].offset);
    const vox_node *root = find_node(st, 0);
    GS_CHECK(root, GS_ERR_FORMAT, "%s: scene graph has no root node (id 0)", st->name);

    gs_err err = GS_OK;
    walk_item *stack = NULL;
    size_t nstack = 0, stack_cap = 0, visits = 0, inst_cap = 0;
    GS_TRY(err, grow((void **)&stack, &stack_cap, 1, sizeof *stack, st->name), done);
    stack[nstack++] = (walk_item){root, {0, 0, 0}, 0, 0};
    while (nstack) {
        walk_item it = stack[--nstack];
        const vox_node *nd = it.node;
        GS_TRY_CHECK(err, it.depth <= VOX_MAX_GRAPH_DEPTH && ++visits <= VOX_MAX_INSTANCES,
                     GS_ERR_FORMAT, done,
                     "%s: scene graph is deeper than %d or has more than %d nodes on its paths "
                     "(cycle?) at node %d",
                     st->name, VOX_MAX_GRAPH_DEPTH, VOX_MAX_INSTANCES, nd->id);
        if (nd->kind == NODE_TRN) {
            const vox_node *ch = find_node(st, nd->child);
            GS_TRY_CHECK(err, ch, GS_ERR_FORMAT, done,
                         "%s: nTRN node %d (byte %zu) refers to missing node %d", st->name,
                         nd->id, nd->offset, nd->child);
            walk_item next = {ch, {it.t[0] + nd->t[0], it.t[1] + nd->t[1], it.t[2] + nd->t[2]},
                              it.rotated || nd->rotated, it.depth + 1};
            GS_TRY(err, grow((void **)&stack, &stack_cap, nstack + 1, sizeof *stack, st->name),
                   done);
            stack[nstack++] = next;
        } else if (nd->kind == NODE_GRP) {
            GS_TRY(err,
                   grow((void **)&stack, &stack_cap, nstack + nd->count, sizeof *stack, st->name),
                   done);
            /* push in reverse so children are visited in file order */
            for (size_t k = nd->count; k-- > 0;) {
                const vox_node *ch = find_node(st, st->children[nd->first + k]);
                GS_TRY_CHECK(err, ch, GS_ERR_FORMAT, done,
                             "%s: nGRP node %d (byte %zu) refers to missing node %d", st->name,
                             nd->id, nd->offset, st->children[nd->first + k]);
                stack[nstack++] = (walk_item){ch, {it.t[0], it.t[1], it.t[2]}, it.rotated,
                                              it.depth + 1};
            }
        } else {
            GS_TRY_CHECK(err, nd->child >= 0 && nd->child < st->v.nmodels, GS_ERR_FORMAT, done,
                         "%s: nSHP node %d (byte %zu) refers to model %d but the file has %d "
                         "models",
                         st->name, nd->id, nd->offset, nd->child, st->v.nmodels);
            const gs_vox_model *m = &st->v.models[nd->child];
            int64_t x0 = it.t[0] - m->nx / 2, y0 = it.t[1] - m->ny / 2, z0 = it.t[2] - m->nz / 2;
            /* translations are bounded by VOX_MAX_TRANSLATION * depth, well inside int64 */
            GS_TRY_CHECK(err,
                         llabs(x0) < INT_MAX / 2 && llabs(y0) < INT_MAX / 2 &&
                             llabs(z0) < INT_MAX / 2,
                         GS_ERR_FORMAT, done,
                         "%s: nSHP node %d (byte %zu) is placed at (%lld,%lld,%lld), beyond "
                         "the supported range",
                         st->name, nd->id, nd->offset, (long long)x0, (long long)y0,
                         (long long)z0);
            size_t ninst = (size_t)st->v.ninstances;
            GS_TRY(err,
                   grow((void **)&st->v.instances, &inst_cap, ninst + 1, sizeof(gs_vox_instance),
                        st->name),
                   done);
            st->v.instances[st->v.ninstances++] =
                (gs_vox_instance){nd->child, (int)x0, (int)y0, (int)z0, it.rotated};
        }
    }
done:
    gs_free(stack);
    return err;
}

static gs_err parse_slab(parse_state *st, const uint8_t *buf, size_t len)
{
    size_t need_min = 12 + 768;
    GS_CHECK(len >= need_min, GS_ERR_FORMAT,
             "%s: not a MagicaVoxel file ('VOX ' magic missing) and too short (%zu bytes) for "
             "a Slab6 .slab.vox file",
             st->name, len);
    uint32_t s[3] = {get_u32(buf), get_u32(buf + 4), get_u32(buf + 8)};
    size_t cells = 0;
    int ok = s[0] >= 1 && s[1] >= 1 && s[2] >= 1 && s[0] <= INT_MAX && s[1] <= INT_MAX &&
             s[2] <= INT_MAX && gs_mul_size(s[0], s[1], &cells) &&
             gs_mul_size(cells, s[2], &cells) && cells <= GS_VOX_MAX_CELLS;
    GS_CHECK(ok && len - need_min == cells, GS_ERR_FORMAT,
             "%s: not a MagicaVoxel file ('VOX ' magic missing) and not a Slab6 .slab.vox "
             "file either (header %ux%ux%u voxels needs %s bytes, file has %zu)",
             st->name, s[0], s[1], s[2], ok ? "12 + cells + 768" : "an impossible number of",
             len);
    GS_CALL(grow((void **)&st->v.models, &(size_t){0}, 1, sizeof(gs_vox_model), st->name));
    int nx = (int)s[0], ny = (int)s[1], nz = (int)s[2];
    uint8_t *labels = NULL;
    GS_CALL(gs_alloc_array((void **)&labels, cells, 1, "slab lattice"));
    const uint8_t *p = buf + 12;
    for (int x = 0; x < nx; x++)
        for (int y = 0; y < ny; y++)
            for (int zs = 0; zs < nz; zs++) {
                uint8_t c = *p++;
                int z = nz - 1 - zs; /* slab z points down */
                labels[x + (size_t)nx * (y + (size_t)ny * z)] = c == 255 ? 0 : (uint8_t)(c + 1);
            }
    st->v.models[0] = (gs_vox_model){nx, ny, nz, labels};
    st->v.nmodels = 1;
    memset(st->v.palette, 0, sizeof st->v.palette);
    for (int k = 0; k < 255; k++)
        for (int ch = 0; ch < 3; ch++) {
            unsigned v6 = p[3 * k + ch] & 63u;
            st->v.palette[k + 1][ch] = (uint8_t)((v6 * 255u + 31u) / 63u);
        }
    for (int k = 1; k < 256; k++)
        st->v.palette[k][3] = 255;
    return GS_OK;
}

static gs_err parse_vox(parse_state *st, const uint8_t *buf, size_t len)
{
    GS_CHECK(len >= 8 + 12, GS_ERR_FORMAT,
             "%s: %zu bytes is too short for a .vox file (header + MAIN chunk need 20)",
             st->name, len);
    GS_CHECK(memcmp(buf + 8, "MAIN", 4) == 0, GS_ERR_FORMAT,
             "%s: chunk at byte 8 is not MAIN: expected the MAIN chunk after the header",
             st->name);
    uint32_t n = get_u32(buf + 12), m = get_u32(buf + 16);
    size_t rem = len - 20;
    GS_CHECK(n <= rem && m <= rem - n, GS_ERR_FORMAT,
             "%s: chunk MAIN at byte 8 declares %u content + %u children bytes but only %zu "
             "bytes follow",
             st->name, n, m, rem);
    gs_vox_default_palette(st->v.palette);
    size_t pos = 20 + n, end = pos + m;
    while (pos < end) {
        GS_CHECK(end - pos >= 12, GS_ERR_FORMAT,
                 "%s: truncated chunk header at byte %zu (%zu bytes left in MAIN, 12 needed)",
                 st->name, pos, end - pos);
        char id[5];
        memcpy(id, buf + pos, 4);
        id[4] = '\0';
        for (int i = 0; i < 4; i++)
            if ((unsigned char)id[i] < 32 || (unsigned char)id[i] > 126)
                id[i] = '?';
        uint32_t cn = get_u32(buf + pos + 4), cm = get_u32(buf + pos + 8);
        size_t crem = end - pos - 12;
        GS_CHECK(cn <= crem && cm <= crem - cn, GS_ERR_FORMAT,
                 "%s: chunk %s at byte %zu declares %u content + %u children bytes but only "
                 "%zu bytes remain in MAIN",
                 st->name, id, pos, cn, cm, crem);
        cursor c = {buf + pos + 12, cn, 0, st->name, id, pos};
        if (!strcmp(id, "SIZE"))
            GS_CALL(parse_size(st, &c));
        else if (!strcmp(id, "XYZI"))
            GS_CALL(parse_xyzi(st, &c));
        else if (!strcmp(id, "RGBA")) {
            GS_CHECK(cn >= 1024, GS_ERR_FORMAT,
                     "%s: chunk RGBA at byte %zu has %u bytes: expected 1024", st->name, pos,
                     cn);
            memset(st->v.palette[0], 0, 4);
            for (int j = 0; j < 255; j++)
                memcpy(st->v.palette[j + 1], c.p + 4 * j, 4);
        } else if (!strcmp(id, "nTRN"))
            GS_CALL(parse_trn(st, &c));
        else if (!strcmp(id, "nGRP"))
            GS_CALL(parse_grp(st, &c));
        else if (!strcmp(id, "nSHP"))
            GS_CALL(parse_shp(st, &c));
        /* PACK, MATL, MATT, LAYR, rOBJ, rCAM, NOTE, IMAP and unknown ids: skipped */
        pos += 12 + (size_t)cn + cm;
    }
    GS_CHECK(!st->pending_size, GS_ERR_FORMAT,
             "%s: chunk SIZE at byte %zu has no XYZI chunk after it", st->name,
             st->psize_offset);
    GS_CHECK(st->v.nmodels > 0, GS_ERR_FORMAT, "%s: no model (SIZE + XYZI chunks) in the file",
             st->name);
    GS_CALL(resolve_scene(st));
    return GS_OK;
}

gs_err gs_vox_parse(const uint8_t *buf, size_t len, const char *name, gs_vox *out)
{
    parse_state st;
    memset(&st, 0, sizeof st);
    st.name = name ? name : "(vox buffer)";
    memset(out, 0, sizeof *out);
    gs_err err;
    if (len >= 8 && memcmp(buf, "VOX ", 4) == 0)
        err = parse_vox(&st, buf, len);
    else
        err = parse_slab(&st, buf, len);
    gs_free(st.nodes);
    gs_free(st.children);
    if (err != GS_OK) {
        gs_error_push_frame(__FILE__, __LINE__, __func__);
        gs_vox_destroy(&st.v);
        return err;
    }
    *out = st.v;
    return GS_OK;
}

gs_err gs_vox_read(const char *path, gs_vox *out)
{
    memset(out, 0, sizeof *out);
    uint8_t *buf = NULL;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, VOX_MAX_FILE, (char **)&buf, &len));
    gs_err err = gs_vox_parse(buf, len, path, out);
    gs_free(buf);
    GS_CALL(err);
    return GS_OK;
}

/* ---------------------------------------------------------------- flatten */

gs_err gs_vox_flatten(const gs_vox *v, int *nx, int *ny, int *nz, uint8_t **labels,
                      int origin[3])
{
    GS_CHECK(v && v->nmodels > 0, GS_ERR_ARG, "voxel file holds no model to flatten");
    int ninst = v->ninstances > 0 ? v->ninstances : v->nmodels;
    int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX}, hi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
    for (int i = 0; i < ninst; i++) {
        gs_vox_instance in = v->ninstances > 0 ? v->instances[i] : (gs_vox_instance){i, 0, 0, 0, 0};
        GS_CHECK(in.model >= 0 && in.model < v->nmodels, GS_ERR_ARG,
                 "instance %d refers to model %d of %d", i, in.model, v->nmodels);
        GS_CHECK(!in.rotated, GS_ERR_FORMAT,
                 "instance %d of model %d is rotated in the scene graph: rotated models are "
                 "not supported when flattening",
                 i, in.model);
        const gs_vox_model *m = &v->models[in.model];
        int64_t a[3] = {in.x0, in.y0, in.z0}, s[3] = {m->nx, m->ny, m->nz};
        for (int k = 0; k < 3; k++) {
            lo[k] = a[k] < lo[k] ? a[k] : lo[k];
            hi[k] = a[k] + s[k] > hi[k] ? a[k] + s[k] : hi[k];
        }
    }
    int64_t d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    GS_CHECK(d[0] <= (int64_t)GS_VOX_MAX_CELLS && d[1] <= (int64_t)GS_VOX_MAX_CELLS &&
                 d[2] <= (int64_t)GS_VOX_MAX_CELLS &&
                 (uint64_t)d[0] * (uint64_t)d[1] <= GS_VOX_MAX_CELLS &&
                 (uint64_t)d[0] * (uint64_t)d[1] * (uint64_t)d[2] <= GS_VOX_MAX_CELLS,
             GS_ERR_FORMAT,
             "placed models span %lldx%lldx%lld cells, more than the %zu accepted",
             (long long)d[0], (long long)d[1], (long long)d[2], GS_VOX_MAX_CELLS);
    size_t cells = (size_t)d[0] * (size_t)d[1] * (size_t)d[2];
    uint8_t *out = NULL;
    GS_CALL(gs_alloc_array((void **)&out, cells, 1, "flattened vox lattice"));
    for (int i = 0; i < ninst; i++) {
        gs_vox_instance in = v->ninstances > 0 ? v->instances[i] : (gs_vox_instance){i, 0, 0, 0, 0};
        const gs_vox_model *m = &v->models[in.model];
        size_t ox = (size_t)(in.x0 - lo[0]), oy = (size_t)(in.y0 - lo[1]),
               oz = (size_t)(in.z0 - lo[2]);
        for (int z = 0; z < m->nz; z++)
            for (int y = 0; y < m->ny; y++)
                for (int x = 0; x < m->nx; x++) {
                    uint8_t c = m->labels[x + (size_t)m->nx * (y + (size_t)m->ny * z)];
                    if (c)
                        out[(ox + x) + (size_t)d[0] * ((oy + y) + (size_t)d[1] * (oz + z))] = c;
                }
    }
    *nx = (int)d[0];
    *ny = (int)d[1];
    *nz = (int)d[2];
    *labels = out;
    if (origin) {
        origin[0] = (int)lo[0];
        origin[1] = (int)lo[1];
        origin[2] = (int)lo[2];
    }
    return GS_OK;
}

/* ---------------------------------------------------------------- writing */

typedef struct wbuf {
    uint8_t *p;
    size_t len, cap;
} wbuf;

static gs_err put(wbuf *w, const void *data, size_t n)
{
    GS_CALL(grow((void **)&w->p, &w->cap, w->len + n, 1, "vox encoder"));
    memcpy(w->p + w->len, data, n);
    w->len += n;
    return GS_OK;
}

static gs_err put_i32(wbuf *w, int32_t v)
{
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    uint8_t b[4] = {(uint8_t)u, (uint8_t)(u >> 8), (uint8_t)(u >> 16), (uint8_t)(u >> 24)};
    return put(w, b, 4);
}

static gs_err put_str(wbuf *w, const char *s)
{
    GS_CALL(put_i32(w, (int32_t)strlen(s)));
    return put(w, s, strlen(s));
}

/* Starts a chunk; returns the offset of its header for end_chunk. */
static gs_err begin_chunk(wbuf *w, const char *id, size_t *at)
{
    *at = w->len;
    GS_CALL(put(w, id, 4));
    GS_CALL(put_i32(w, 0));
    return put_i32(w, 0);
}

static void end_chunk(wbuf *w, size_t at)
{
    uint32_t n = (uint32_t)(w->len - at - 12);
    for (int i = 0; i < 4; i++)
        w->p[at + 4 + i] = (uint8_t)(n >> (8 * i));
}

static gs_err encode_body(const gs_vox *v, wbuf *w)
{
    size_t at;
    int ninst = v->ninstances > 0 ? v->ninstances : v->nmodels;
    for (int i = 0; i < v->nmodels; i++) {
        const gs_vox_model *m = &v->models[i];
        GS_CHECK(m->nx >= 1 && m->ny >= 1 && m->nz >= 1 && m->nx <= GS_VOX_MAX_AXIS &&
                     m->ny <= GS_VOX_MAX_AXIS && m->nz <= GS_VOX_MAX_AXIS && m->labels,
                 GS_ERR_ARG,
                 "model %d is %dx%dx%d: MagicaVoxel models must be 1..%d per axis (use "
                 "gs_vox_from_lattice to split larger lattices)",
                 i, m->nx, m->ny, m->nz, GS_VOX_MAX_AXIS);
        GS_CALL(begin_chunk(w, "SIZE", &at));
        GS_CALL(put_i32(w, m->nx));
        GS_CALL(put_i32(w, m->ny));
        GS_CALL(put_i32(w, m->nz));
        end_chunk(w, at);
        GS_CALL(begin_chunk(w, "XYZI", &at));
        size_t count_at = w->len;
        GS_CALL(put_i32(w, 0));
        uint32_t count = 0;
        for (int z = 0; z < m->nz; z++)
            for (int y = 0; y < m->ny; y++)
                for (int x = 0; x < m->nx; x++) {
                    uint8_t c = m->labels[x + (size_t)m->nx * (y + (size_t)m->ny * z)];
                    if (!c)
                        continue;
                    uint8_t rec[4] = {(uint8_t)x, (uint8_t)y, (uint8_t)z, c};
                    GS_CALL(put(w, rec, 4));
                    count++;
                }
        for (int k = 0; k < 4; k++)
            w->p[count_at + k] = (uint8_t)(count >> (8 * k));
        end_chunk(w, at);
    }
    /* scene graph: T(0) -> G(1) -> { T(2+2k) -> S(3+2k) } */
    GS_CALL(begin_chunk(w, "nTRN", &at));
    GS_CALL(put_i32(w, 0));
    GS_CALL(put_i32(w, 0)); /* empty dict */
    GS_CALL(put_i32(w, 1));
    GS_CALL(put_i32(w, -1));
    GS_CALL(put_i32(w, -1));
    GS_CALL(put_i32(w, 1));
    GS_CALL(put_i32(w, 0));
    end_chunk(w, at);
    GS_CALL(begin_chunk(w, "nGRP", &at));
    GS_CALL(put_i32(w, 1));
    GS_CALL(put_i32(w, 0));
    GS_CALL(put_i32(w, ninst));
    for (int k = 0; k < ninst; k++)
        GS_CALL(put_i32(w, 2 + 2 * k));
    end_chunk(w, at);
    for (int k = 0; k < ninst; k++) {
        gs_vox_instance in = v->ninstances > 0 ? v->instances[k] : (gs_vox_instance){k, 0, 0, 0, 0};
        GS_CHECK(in.model >= 0 && in.model < v->nmodels && !in.rotated, GS_ERR_ARG,
                 "instance %d: model %d of %d%s", k, in.model, v->nmodels,
                 in.rotated ? " is rotated (not supported by the writer)" : "");
        const gs_vox_model *m = &v->models[in.model];
        char t[64];
        snprintf(t, sizeof t, "%d %d %d", in.x0 + m->nx / 2, in.y0 + m->ny / 2,
                 in.z0 + m->nz / 2);
        GS_CALL(begin_chunk(w, "nTRN", &at));
        GS_CALL(put_i32(w, 2 + 2 * k));
        GS_CALL(put_i32(w, 0));
        GS_CALL(put_i32(w, 3 + 2 * k));
        GS_CALL(put_i32(w, -1));
        GS_CALL(put_i32(w, 0)); /* layer 0 */
        GS_CALL(put_i32(w, 1));
        GS_CALL(put_i32(w, 1)); /* frame dict: _t */
        GS_CALL(put_str(w, "_t"));
        GS_CALL(put_str(w, t));
        end_chunk(w, at);
        GS_CALL(begin_chunk(w, "nSHP", &at));
        GS_CALL(put_i32(w, 3 + 2 * k));
        GS_CALL(put_i32(w, 0));
        GS_CALL(put_i32(w, 1));
        GS_CALL(put_i32(w, in.model));
        GS_CALL(put_i32(w, 0));
        end_chunk(w, at);
    }
    GS_CALL(begin_chunk(w, "LAYR", &at));
    GS_CALL(put_i32(w, 0));
    GS_CALL(put_i32(w, 0));
    GS_CALL(put_i32(w, -1));
    end_chunk(w, at);
    GS_CALL(begin_chunk(w, "RGBA", &at));
    for (int j = 0; j < 255; j++)
        GS_CALL(put(w, v->palette[j + 1], 4));
    GS_CALL(put_i32(w, 0));
    end_chunk(w, at);
    return GS_OK;
}

gs_err gs_vox_encode(const gs_vox *v, uint8_t **buf, size_t *len)
{
    GS_CHECK(v && v->nmodels > 0 && v->models, GS_ERR_ARG, "no model to write");
    wbuf w = {NULL, 0, 0};
    gs_err err = GS_OK;
    GS_TRY(err, put(&w, "VOX ", 4), fail);
    GS_TRY(err, put_i32(&w, 150), fail);
    GS_TRY(err, put(&w, "MAIN", 4), fail);
    GS_TRY(err, put_i32(&w, 0), fail);
    GS_TRY(err, put_i32(&w, 0), fail);
    GS_TRY(err, encode_body(v, &w), fail);
    GS_TRY_CHECK(err, w.len - 20 <= UINT32_MAX, GS_ERR_ARG, fail,
                 "voxel data of %zu bytes exceeds the 4 GiB a .vox chunk can hold", w.len);
    uint32_t m = (uint32_t)(w.len - 20);
    for (int i = 0; i < 4; i++)
        w.p[16 + i] = (uint8_t)(m >> (8 * i));
    *buf = w.p;
    *len = w.len;
    return GS_OK;
fail:
    gs_free(w.p);
    return err;
}

gs_err gs_vox_write(const char *path, const gs_vox *v)
{
    uint8_t *buf = NULL;
    size_t len = 0;
    gs_err err = gs_vox_encode(v, &buf, &len);
    if (err != GS_OK) {
        gs_error_add_context("while writing %s", path);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    err = gs_file_write_atomic(path, buf, len);
    gs_free(buf);
    GS_CALL(err);
    return GS_OK;
}

gs_err gs_vox_from_lattice(int nx, int ny, int nz, const uint8_t *labels,
                           const uint8_t (*palette)[4], gs_vox *out)
{
    GS_CHECK(nx >= 1 && ny >= 1 && nz >= 1 && labels, GS_ERR_ARG,
             "lattice %dx%dx%d: expected positive sizes and labels", nx, ny, nz);
    memset(out, 0, sizeof *out);
    int tx = (nx + GS_VOX_MAX_AXIS - 1) / GS_VOX_MAX_AXIS;
    int ty = (ny + GS_VOX_MAX_AXIS - 1) / GS_VOX_MAX_AXIS;
    int tz = (nz + GS_VOX_MAX_AXIS - 1) / GS_VOX_MAX_AXIS;
    size_t ntiles = (size_t)tx * (size_t)ty * (size_t)tz;
    GS_CHECK(ntiles <= VOX_MAX_INSTANCES, GS_ERR_ARG,
             "lattice %dx%dx%d needs %zu tiles of 256^3, more than %d", nx, ny, nz, ntiles,
             VOX_MAX_INSTANCES);
    gs_vox v;
    memset(&v, 0, sizeof v);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&v.models, ntiles, sizeof *v.models, "vox models"),
           fail);
    GS_TRY(err,
           gs_alloc_array((void **)&v.instances, ntiles, sizeof *v.instances, "vox instances"),
           fail);
    for (int bz = 0; bz < tz; bz++)
        for (int by = 0; by < ty; by++)
            for (int bx = 0; bx < tx; bx++) {
                int x0 = bx * GS_VOX_MAX_AXIS, y0 = by * GS_VOX_MAX_AXIS,
                    z0 = bz * GS_VOX_MAX_AXIS;
                int sx = nx - x0 < GS_VOX_MAX_AXIS ? nx - x0 : GS_VOX_MAX_AXIS;
                int sy = ny - y0 < GS_VOX_MAX_AXIS ? ny - y0 : GS_VOX_MAX_AXIS;
                int sz = nz - z0 < GS_VOX_MAX_AXIS ? nz - z0 : GS_VOX_MAX_AXIS;
                uint8_t *t = NULL;
                GS_TRY(err,
                       gs_alloc_array((void **)&t, (size_t)sx * sy * sz, 1, "vox tile lattice"),
                       fail);
                for (int z = 0; z < sz; z++)
                    for (int y = 0; y < sy; y++)
                        memcpy(t + (size_t)sx * (y + (size_t)sy * z),
                               labels + x0 + (size_t)nx * ((y0 + y) + (size_t)ny * (z0 + z)),
                               (size_t)sx);
                v.models[v.nmodels] = (gs_vox_model){sx, sy, sz, t};
                v.instances[v.nmodels] = (gs_vox_instance){v.nmodels, x0, y0, z0, 0};
                v.nmodels++;
                v.ninstances++;
            }
    if (palette)
        memcpy(v.palette, palette, sizeof v.palette);
    else
        gs_vox_default_palette(v.palette);
    *out = v;
    return GS_OK;
fail:
    gs_vox_destroy(&v);
    return err;
}

gs_err gs_vox_write_lattice(const char *path, int nx, int ny, int nz, const uint8_t *labels,
                            const uint8_t (*palette)[4])
{
    gs_vox v;
    GS_CALL(gs_vox_from_lattice(nx, ny, nz, labels, palette, &v));
    gs_err err = gs_vox_write(path, &v);
    gs_vox_destroy(&v);
    GS_CALL(err);
    return GS_OK;
}
