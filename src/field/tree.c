/* Search tree construction (paper 4.1, 4.4); see include/geosynth/field.h.
 *
 * Build: (1) global pyramid; (2) identical blocks grouped through an exact
 * polynomial hash of every block window (equal content => equal hash; every
 * group is verified sample by sample, so collisions only cost time);
 * (3) the distinct blocks sorted by their step sequence (octant floor
 * means first, then coarse-to-fine refinements) with the step of first difference to the
 * predecessor (LCP); (4) the compressed tree linked from sorted order + LCP
 * with a stack, as a suffix tree is built from a suffix array; (5) nodes
 * relaid breadth first so every node's children are contiguous. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "field_impl.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/partition.h"

/* ------------------------------------------------------ block hashing */

static const uint64_t HASH_A = 0x9e3779b97f4a7c15ULL, HASH_B = 0xc2b2ae3d27d4eb4fULL,
                      HASH_C = 0x165667b19e3779f9ULL;

/* Exact polynomial hash of every B^3 window: out[x] = sum over the window at
 * x of v * A^i * B^j * C^k (mod 2^64), computed axis by axis. Entries whose
 * window leaves the field hold wrapped garbage and are never read. Two
 * arrays of n u64 (ping-pong). */
static gs_err hash_blocks(const gs_qfield *src, int B, uint64_t **out)
{
    int64_t nx = src->nx, nxy = src->nx * src->ny, n = nxy * src->nz;
    uint64_t *a = NULL, *b = NULL;
    GS_CALL(gs_alloc_array((void **)&a, (size_t)n, sizeof *a, "block hashes"));
    gs_err err = gs_alloc_array((void **)&b, (size_t)n, sizeof *b, "block hashes");
    if (err != GS_OK) {
        gs_free(a);
        GS_CALL(err);
    }
    uint64_t pw[3][32];
    const uint64_t mul[3] = {HASH_A, HASH_B, HASH_C};
    for (int ax = 0; ax < 3; ax++) {
        pw[ax][0] = 1;
        for (int i = 1; i < B; i++)
            pw[ax][i] = pw[ax][i - 1] * mul[ax];
    }
    int64_t lim = n - (int64_t)(B - 1) * 1;
    for (int64_t x = 0; x < lim; x++) {
        uint64_t h = 0;
        for (int i = 0; i < B; i++)
            h += src->q[x + i] * pw[0][i];
        a[x] = h;
    }
    lim = n - (int64_t)(B - 1) * nx;
    for (int64_t x = 0; x < lim; x++) {
        uint64_t h = 0;
        for (int j = 0; j < B; j++)
            h += a[x + nx * j] * pw[1][j];
        b[x] = h;
    }
    lim = n - (int64_t)(B - 1) * nxy;
    for (int64_t x = 0; x < lim; x++) {
        uint64_t h = 0;
        for (int k = 0; k < B; k++)
            h += b[x + nxy * k] * pw[2][k];
        a[x] = h;
    }
    gs_free(b);
    *out = a;
    return GS_OK;
}

typedef struct hash_pair {
    uint64_t h;
    uint32_t idx;
} hash_pair;

static int cmp_hash_pair(const void *a, const void *b)
{
    const hash_pair *x = a, *y = b;
    if (x->h != y->h)
        return x->h < y->h ? -1 : 1;
    return x->idx < y->idx ? -1 : x->idx > y->idx;
}

/* ------------------------------------------------------- build context */

typedef struct build_ctx {
    const struct gs_field_pyramid *pyr;
    const gs_step_layout *lay;
    const gs_qfield *src;
    int64_t bx, by;
} build_ctx;

static int64_t block_base(const build_ctx *c, uint32_t idx)
{
    return gs_block_base(c->bx, c->by, c->src->nx, c->src->ny, idx);
}

/* 1 when the block at base has one value throughout: no spread (the root
 * of a positive integer is at least 1, so a zero spread is exact). */
static int block_constant(const build_ctx *c, int64_t base)
{
    return gs_pyr_dev_at(c->pyr, c->lay->L, base) == 0.0f;
}

static int blocks_identical(const build_ctx *c, uint32_t a, uint32_t b)
{
    int B = c->lay->B;
    int64_t pa = block_base(c, a), pb = block_base(c, b);
    /* Constant blocks (the empty space away from the surface, where the
     * distance is clamped) form the largest groups by far; the pyramid's
     * whole-block sums decide them without reading B^3 samples
     * (armadillo 256^3/32: millions of them). */
    int ca = block_constant(c, pa), cb = block_constant(c, pb);
    if (ca || cb)
        return ca && cb && gs_pyr_at(c->pyr, c->lay->L, pa) == gs_pyr_at(c->pyr, c->lay->L, pb);
    for (int k = 0; k < B; k++)
        for (int j = 0; j < B; j++) {
            int64_t o = c->src->nx * (j + c->src->ny * (int64_t)k);
            if (memcmp(c->src->q + pa + o, c->src->q + pb + o, (size_t)B) != 0)
                return 0;
        }
    return 1;
}

/* First step at which blocks a and b differ (steps when identical); *sign
 * gets the order (-1: a first). Steps (field_impl.h): t < 8 the floor mean
 * of octant t, then refinement r at step 8 + r; a revealed cell is the pair
 * (sum, spread), compared in that order: blocks that agree on both have
 * the same bounds at that step (search.c reads nothing else). */
static int64_t first_difference(const build_ctx *c, uint32_t a, uint32_t b, int *sign)
{
    const gs_step_layout *lay = c->lay;
    const struct gs_field_pyramid *p = c->pyr;
    int L = lay->L;
    int64_t pa = block_base(c, a), pb = block_base(c, b);
    const int64_t *off1 = lay->cell_off[1];
    for (int t = 0; t < 8; t++) {
        uint32_t va = gs_pyr_at(p, L - 1, pa + off1[t]) >> (3 * (L - 1));
        uint32_t vb = gs_pyr_at(p, L - 1, pb + off1[t]) >> (3 * (L - 1));
        if (va != vb) {
            *sign = va < vb ? -1 : 1;
            return t;
        }
    }
    for (int k = 1; k <= L; k++) {
        int m = L - k;
        int64_t cells = (int64_t)1 << (3 * k);
        const int64_t *off = lay->cell_off[k];
        if (m == 0) {
            const uint8_t *q = c->src->q;
            for (int64_t t = 0; t < cells; t++) {
                uint8_t va = q[pa + off[t]], vb = q[pb + off[t]];
                if (va != vb) {
                    *sign = va < vb ? -1 : 1;
                    return GS_FIELD_QSTEPS + lay->level_first[k] + (t >> 3);
                }
            }
        } else {
            const gs_pyr_cell *q = p->cell[m];
            for (int64_t t = 0; t < cells; t++) {
                gs_pyr_cell ca = q[pa + off[t]], cb = q[pb + off[t]];
                if (ca.sum != cb.sum || ca.dev != cb.dev) {
                    *sign = ca.sum != cb.sum ? (ca.sum < cb.sum ? -1 : 1) : (ca.dev < cb.dev ? -1 : 1);
                    return GS_FIELD_QSTEPS + lay->level_first[k] + (t >> 3);
                }
            }
        }
    }
    *sign = 0;
    return lay->steps;
}

/* Bottom-up merge sort of idx[0..n) by step sequence. */
static void sort_by_content(const build_ctx *c, const uint32_t *rep, uint32_t *idx, uint32_t *tmp,
                            int64_t n)
{
    for (int64_t w = 1; w < n; w *= 2) {
        for (int64_t lo = 0; lo < n; lo += 2 * w) {
            int64_t mid = lo + w < n ? lo + w : n, hi = lo + 2 * w < n ? lo + 2 * w : n;
            int64_t i = lo, j = mid, o = lo;
            while (i < mid && j < hi) {
                int sign;
                first_difference(c, rep[idx[i]], rep[idx[j]], &sign);
                tmp[o++] = sign <= 0 ? idx[i++] : idx[j++];
            }
            while (i < mid)
                tmp[o++] = idx[i++];
            while (j < hi)
                tmp[o++] = idx[j++];
        }
        memcpy(idx, tmp, (size_t)n * sizeof *idx);
    }
}

typedef struct key_pair {
    uint64_t key; /* the 8 octant floor means, octant 0 in the high byte */
    uint32_t idx;
} key_pair;

static int cmp_key_pair(const void *a, const void *b)
{
    const key_pair *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->idx < y->idx ? -1 : x->idx > y->idx;
}

/* Temporary node while linking (children as a linked list). */
typedef struct tmp_node {
    uint32_t end, rep, first_child, last_child, next, nchild, group;
} tmp_node;

#define NONE UINT32_MAX

static void append_child(tmp_node *tn, uint32_t parent, uint32_t child)
{
    tmp_node *p = &tn[parent];
    if (p->first_child == NONE)
        p->first_child = child;
    else
        tn[p->last_child].next = child;
    p->last_child = child;
    p->nchild++;
    if (tn[child].rep < p->rep)
        p->rep = tn[child].rep;
}

/* Pyramid level a node ending after `end` steps belongs to; *full = 1 when
 * that level is completely revealed (a merged node of the paper), 0 for an
 * extra parent inside the refinement to that level (ends 1..8, the octant
 * floor means, count as partial level 1). */
static int level_of_end(const gs_step_layout *lay, int64_t end, int *full)
{
    *full = 0;
    if (end <= GS_FIELD_QSTEPS)
        return end == 0 ? 0 : 1;
    int64_t R = end - GS_FIELD_QSTEPS; /* refinements done; level k complete at R == level_first[k+1] */
    for (int k = 1; k <= lay->L; k++) {
        if (R <= lay->level_first[k + 1]) {
            *full = R == lay->level_first[k + 1];
            return k;
        }
    }
    *full = 1;
    return lay->L;
}

/* ------------------------------------------------------- octant boxes */

static void box_empty(gs_tree_box *b)
{
    for (int o = 0; o < 8; o++)
        b->mlo[o] = UINT8_MAX, b->mhi[o] = 0, b->slo[o] = UINT16_MAX, b->shi[o] = 0;
}

static void box_merge(gs_tree_box *b, const gs_tree_box *c)
{
    for (int o = 0; o < 8; o++) {
        if (c->mlo[o] < b->mlo[o])
            b->mlo[o] = c->mlo[o];
        if (c->mhi[o] > b->mhi[o])
            b->mhi[o] = c->mhi[o];
        if (c->slo[o] < b->slo[o])
            b->slo[o] = c->slo[o];
        if (c->shi[o] > b->shi[o])
            b->shi[o] = c->shi[o];
    }
}

/* The box of the single block at base: the octant floor and ceiling means,
 * and the octant deviations rounded outwards to 1/256 (the stored spreads
 * are within GS_PYR_DEV_EPS of the exact root; the margins cover it). */
static void box_of_block(const struct gs_field_tree *t, int64_t base, gs_tree_box *b)
{
    int L = t->lay.L, sh = 3 * (L - 1);
    int64_t c = (int64_t)1 << sh;
    for (int o = 0; o < 8; o++) {
        int64_t x = base + t->lay.cell_off[1][o];
        int64_t S = gs_pyr_at(t->pyr, L - 1, x);
        b->mlo[o] = (uint8_t)(S >> sh);
        b->mhi[o] = (uint8_t)((S + c - 1) >> sh);
        double dev = (double)gs_pyr_dev_at(t->pyr, L - 1, x) / (double)c * 256;
        double lo = floor(dev * (1 - 2 * GS_PYR_DEV_EPS)), hi = ceil(dev * (1 + 2 * GS_PYR_DEV_EPS));
        b->slo[o] = (uint16_t)(lo < 0 ? 0 : lo);
        b->shi[o] = (uint16_t)(hi > UINT16_MAX ? UINT16_MAX : hi);
    }
}

/* Boxes of every trie node, bottom-up: children follow their parents in
 * the breadth-first layout, so a trie child's box is ready when its parent
 * merges it; other children (which share their exact octants with every
 * block below) contribute their representative's box. */
static gs_err build_boxes(struct gs_field_tree *t)
{
    int64_t n = 0;
    for (int64_t i = 0; i < t->nnodes; i++)
        n += t->nodes[i].end <= GS_FIELD_QSTEPS;
    GS_CALL(gs_alloc_array((void **)&t->box_of, (size_t)t->nnodes, sizeof *t->box_of,
                           "tree box index"));
    GS_CALL(gs_alloc_array((void **)&t->boxes, (size_t)(n ? n : 1), sizeof *t->boxes,
                           "tree boxes"));
    t->nboxes = n;
    n = 0;
    for (int64_t i = 0; i < t->nnodes; i++)
        t->box_of[i] = t->nodes[i].end <= GS_FIELD_QSTEPS ? (uint32_t)n++ : GS_TREE_NO_BOX;
    for (int64_t i = t->nnodes - 1; i >= 0; i--) {
        if (t->box_of[i] == GS_TREE_NO_BOX)
            continue;
        const gs_tree_node *nd = &t->nodes[i];
        gs_tree_box *b = &t->boxes[t->box_of[i]], cb;
        box_empty(b);
        for (uint32_t c = 0; c < nd->count; c++) {
            uint32_t id = nd->first + c;
            if (t->box_of[id] != GS_TREE_NO_BOX) {
                box_merge(b, &t->boxes[t->box_of[id]]);
            } else {
                box_of_block(t, gs_tree_block_base(t, t->nodes[id].rep), &cb);
                box_merge(b, &cb);
            }
        }
    }
    return GS_OK;
}

gs_err gs_field_tree_build(const gs_qfield *src, int block, gs_field_tree_t *out)
{
    double t0 = gs_time_now();
    int64_t M = gs_field_block_count(src, block);
    GS_CHECK(M > 0, GS_ERR_ARG, "block size %d does not fit the %lldx%lldx%lld source", block,
             (long long)src->nx, (long long)src->ny, (long long)src->nz);
    GS_CHECK(M < (int64_t)INT32_MAX, GS_ERR_ARG,
             "%lld blocks of size %d: the tree indexes at most 2^31 blocks", (long long)M, block);
    struct gs_field_tree *t = gs_calloc(1, sizeof *t);
    GS_CHECK(t, GS_ERR_MEM, "out of memory for a tree header");
    gs_err err = GS_OK;
    uint64_t *hashes = NULL;
    hash_pair *pairs = NULL;
    uint8_t *assigned = NULL;
    uint32_t *gstart = NULL, *reps = NULL, *order = NULL, *tmp = NULL, *lcp = NULL, *stack = NULL;
    uint32_t *bfs = NULL;
    key_pair *sp = NULL;
    tmp_node *tn = NULL;
    int64_t *cnt = NULL;

    t->src = src;
    GS_TRY(err, gs_step_layout_init(&t->lay, block, src->nx, src->ny), fail);
    int L = t->lay.L;
    GS_TRY(err, gs_field_pyramid_create(src, L + 1, &t->pyr), fail);
    t->bx = src->nx - block + 1, t->by = src->ny - block + 1, t->bz = src->nz - block + 1;
    t->blocks = M;
    double t1 = gs_time_now();

    /* largest 6-neighbour step of the source (for the upper bound) */
    {
        int kmax = 0;
        int64_t nx = src->nx, nxy = src->nx * src->ny;
        for (int64_t z = 0; z < src->nz; z++)
            for (int64_t y = 0; y < src->ny; y++)
                for (int64_t x = 0; x < nx; x++) {
                    int64_t i = x + nx * y + nxy * z;
                    int v = src->q[i], d;
                    if (x + 1 < nx && (d = abs(v - src->q[i + 1])) > kmax)
                        kmax = d;
                    if (y + 1 < src->ny && (d = abs(v - src->q[i + nx])) > kmax)
                        kmax = d;
                    if (z + 1 < src->nz && (d = abs(v - src->q[i + nxy])) > kmax)
                        kmax = d;
                }
        t->source_step_max = kmax;
    }

    build_ctx ctx = {t->pyr, &t->lay, src, t->bx, t->by};

    /* identical blocks -> groups (members ascending, group leader = lowest index) */
    GS_TRY(err, hash_blocks(src, block, &hashes), fail);
    GS_TRY(err, gs_alloc_array((void **)&pairs, (size_t)M, sizeof *pairs, "block hash pairs"), fail);
    for (int64_t i = 0; i < M; i++) {
        pairs[i].idx = (uint32_t)i;
        pairs[i].h = hashes[block_base(&ctx, (uint32_t)i)];
    }
    GS_FREE(hashes);
    qsort(pairs, (size_t)M, sizeof *pairs, cmp_hash_pair);
    GS_TRY(err, gs_alloc_array((void **)&assigned, (size_t)M, 1, "dedup flags"), fail);
    GS_TRY(err, gs_alloc_array((void **)&t->members, (size_t)M, sizeof *t->members, "leaf members"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&gstart, (size_t)M + 1, sizeof *gstart, "groups"), fail);
    int64_t G = 0, nm = 0;
    for (int64_t a = 0; a < M;) {
        int64_t b = a + 1;
        while (b < M && pairs[b].h == pairs[a].h)
            b++;
        for (int64_t i = a; i < b; i++) {
            if (assigned[i])
                continue;
            gstart[G++] = (uint32_t)nm;
            t->members[nm++] = pairs[i].idx;
            assigned[i] = 1;
            for (int64_t j = i + 1; j < b; j++)
                if (!assigned[j] && blocks_identical(&ctx, pairs[i].idx, pairs[j].idx)) {
                    t->members[nm++] = pairs[j].idx;
                    assigned[j] = 1;
                }
        }
        a = b;
    }
    gstart[G] = (uint32_t)nm;
    GS_FREE(pairs);
    GS_FREE(assigned);
    GS_TRY(err, gs_alloc_array((void **)&reps, (size_t)G, sizeof *reps, "group representatives"),
           fail);
    for (int64_t g = 0; g < G; g++)
        reps[g] = t->members[gstart[g]];
    double t2 = gs_time_now();

    /* distinct blocks in content order: by the octant floor means, then step by step */
    GS_TRY(err, gs_alloc_array((void **)&sp, (size_t)G, sizeof *sp, "sort keys"), fail);
    for (int64_t g = 0; g < G; g++) {
        int64_t base = block_base(&ctx, reps[g]);
        uint64_t key = 0;
        for (int o = 0; o < 8; o++)
            key = key << 8 | gs_pyr_at(t->pyr, L - 1, base + t->lay.cell_off[1][o]) >> (3 * (L - 1));
        sp[g].key = key;
        sp[g].idx = (uint32_t)g;
    }
    qsort(sp, (size_t)G, sizeof *sp, cmp_key_pair);
    GS_TRY(err, gs_alloc_array((void **)&order, (size_t)G, sizeof *order, "sorted groups"), fail);
    GS_TRY(err, gs_alloc_array((void **)&tmp, (size_t)G, sizeof *tmp, "sort buffer"), fail);
    for (int64_t g = 0; g < G; g++)
        order[g] = sp[g].idx;
    for (int64_t a = 0; a < G;) {
        int64_t b = a + 1;
        while (b < G && sp[b].key == sp[a].key)
            b++;
        if (b - a > 1)
            sort_by_content(&ctx, reps, order + a, tmp, b - a);
        a = b;
    }
    GS_FREE(sp);
    GS_FREE(tmp);
    GS_TRY(err, gs_alloc_array((void **)&lcp, (size_t)G, sizeof *lcp, "lcp"), fail);
    for (int64_t i = 1; i < G; i++) {
        int sign;
        int64_t d = first_difference(&ctx, reps[order[i - 1]], reps[order[i]], &sign);
        GS_TRY_CHECK(err, sign < 0 && d < t->lay.steps, GS_ERR_INTERNAL, fail,
                     "tree build: groups %u and %u out of order (step %lld, sign %d)",
                     order[i - 1], order[i], (long long)d, sign);
        lcp[i] = (uint32_t)d;
    }
    double t3 = gs_time_now();

    /* link: leaves 0..G-1 (sorted position), internal nodes after */
    GS_TRY(err, gs_alloc_array((void **)&tn, (size_t)(2 * G + 1), sizeof *tn, "tree nodes"), fail);
    GS_TRY(err, gs_alloc_array((void **)&stack, (size_t)(G + 1), sizeof *stack, "tree stack"), fail);
    int64_t ntn = G;
    for (int64_t i = 0; i < G; i++) {
        tn[i] = (tmp_node){(uint32_t)t->lay.steps, reps[order[i]], NONE, NONE, NONE, 0, order[i]};
    }
#define NEW_INTERNAL(depth)                                                                        \
    (tn[ntn] = (tmp_node){(uint32_t)(depth), UINT32_MAX, NONE, NONE, NONE, 0, NONE}, (uint32_t)ntn++)
    int64_t sp_top = 0;
    stack[sp_top++] = NEW_INTERNAL(0);
    uint32_t pending = 0;
    for (int64_t i = 1; i < G; i++) {
        uint32_t h = lcp[i];
        while (tn[stack[sp_top - 1]].end > h) {
            uint32_t node = stack[--sp_top];
            append_child(tn, node, pending);
            pending = node;
        }
        if (tn[stack[sp_top - 1]].end == h) {
            append_child(tn, stack[sp_top - 1], pending);
        } else {
            uint32_t nn = NEW_INTERNAL(h);
            append_child(tn, nn, pending);
            stack[sp_top++] = nn;
        }
        pending = (uint32_t)i;
    }
    while (sp_top > 0) {
        uint32_t node = stack[--sp_top];
        append_child(tn, node, pending);
        pending = node;
    }
#undef NEW_INTERNAL
    uint32_t root = pending;
    while (tn[root].group == NONE && tn[root].nchild == 1)
        root = tn[root].first_child;
    GS_FREE(stack);
    GS_FREE(lcp);

    /* breadth-first relayout */
    t->nnodes = 0;
    GS_TRY(err, gs_alloc_array((void **)&bfs, (size_t)ntn, sizeof *bfs, "tree order"), fail);
    GS_TRY(err, gs_alloc_array((void **)&t->nodes, (size_t)ntn, sizeof *t->nodes, "tree nodes"), fail);
    int64_t next = 1;
    bfs[0] = root;
    for (int64_t pos = 0; pos < next; pos++) {
        const tmp_node *u = &tn[bfs[pos]];
        gs_tree_node *o = &t->nodes[pos];
        o->end = u->end;
        o->rep = u->rep;
        if (u->group != NONE) {
            o->first = gstart[u->group];
            o->count = gstart[u->group + 1] - gstart[u->group];
        } else {
            o->first = (uint32_t)next;
            o->count = u->nchild;
            for (uint32_t c = u->first_child; c != NONE; c = tn[c].next)
                bfs[next++] = c;
        }
    }
    t->nnodes = next;
    t->root = 0;
    GS_FREE(tn);
    GS_FREE(bfs);
    GS_FREE(order);
    GS_FREE(reps);
    GS_FREE(gstart);
    GS_TRY(err, build_boxes(t), fail);

    /* blocks per subtree, top-level subtrees, statistics */
    GS_TRY(err, gs_alloc_array((void **)&cnt, (size_t)t->nnodes, sizeof *cnt, "subtree sizes"), fail);
    gs_field_tree_info *info = &t->info;
    for (int64_t i = t->nnodes - 1; i >= 0; i--) {
        const gs_tree_node *nd = &t->nodes[i];
        if (nd->end == t->lay.steps) {
            cnt[i] = nd->count;
        } else {
            cnt[i] = 0;
            for (uint32_t c = 0; c < nd->count; c++)
                cnt[i] += cnt[nd->first + c];
        }
        if (i == 0)
            continue;
        int full;
        int k = level_of_end(&t->lay, nd->end, &full);
        if (full)
            info->level_full[k]++;
        else
            info->level_partial[k]++;
    }
    const gs_tree_node *rt = &t->nodes[0];
    int root_leaf = rt->end == t->lay.steps;
    t->ntop = root_leaf ? 1 : rt->count;
    GS_TRY(err, gs_alloc_array((void **)&t->top, (size_t)t->ntop, sizeof *t->top, "top subtrees"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&t->top_blocks, (size_t)t->ntop, sizeof *t->top_blocks,
                               "top subtree sizes"),
           fail);
    for (int64_t i = 0; i < t->ntop; i++) {
        t->top[i] = root_leaf ? 0 : rt->first + (uint32_t)i;
        t->top_blocks[i] = cnt[t->top[i]];
    }
    GS_FREE(cnt);

    info->block = block;
    info->levels = L + 1;
    info->blocks = M;
    info->distinct = G;
    info->nodes = t->nnodes;
    info->top = t->ntop;
    info->steps = t->lay.steps;
    info->source_step_max = t->source_step_max;
    info->tree_bytes = (size_t)t->nnodes * (sizeof(gs_tree_node) + sizeof(uint32_t)) +
                       (size_t)t->nboxes * sizeof(gs_tree_box) + (size_t)M * sizeof(uint32_t) +
                       (size_t)t->ntop * (sizeof(uint32_t) + sizeof(int64_t));
    info->pyramid_bytes = t->pyr->bytes;
    info->pyramid_seconds = t1 - t0;
    info->dedup_seconds = t2 - t1;
    info->sort_seconds = t3 - t2;
    info->build_seconds = gs_time_now() - t0;
    *out = t;
    return GS_OK;
fail:
    gs_free(hashes);
    gs_free(pairs);
    gs_free(assigned);
    gs_free(gstart);
    gs_free(reps);
    gs_free(order);
    gs_free(tmp);
    gs_free(lcp);
    gs_free(stack);
    gs_free(bfs);
    gs_free(sp);
    gs_free(tn);
    gs_free(cnt);
    gs_field_tree_destroy(&t);
    return err;
}

gs_err gs_field_tree_build_slab(const gs_qfield *src, int block, int64_t z0, int64_t z1,
                                gs_field_tree_t *out)
{
    int64_t bz = src->nz - block + 1;
    GS_CHECK(block >= 1 && bz >= 1 && z0 >= 0 && z0 < z1 && z1 <= bz, GS_ERR_ARG,
             "tree slab of block z positions [%lld, %lld): expected a non-empty range within "
             "[0, %lld) for blocks of %d in a %lldx%lldx%lld source",
             (long long)z0, (long long)z1, (long long)(bz > 0 ? bz : 0), block,
             (long long)src->nx, (long long)src->ny, (long long)src->nz);
    /* samples z0 .. z1 + B - 2: every block of the slab and nothing else */
    gs_qfield *slab = NULL;
    int64_t nzs = z1 - z0 + block - 1, plane = src->nx * src->ny;
    GS_CALL(gs_qfield_create(src->nx, src->ny, nzs, src->lo, src->hi, &slab));
    memcpy(slab->q, src->q + plane * z0, (size_t)(plane * nzs));
    slab->spacing = src->spacing;
    memcpy(slab->origin, src->origin, sizeof slab->origin);
    slab->origin[2] += src->spacing * (double)z0;
    gs_field_tree_t t = NULL;
    gs_err err = gs_field_tree_build(slab, block, &t);
    if (err != GS_OK) {
        gs_qfield_destroy(&slab);
        return err;
    }
    t->own_src = slab;
    t->index_offset = (src->nx - block + 1) * (src->ny - block + 1) * z0;
    t->info.tree_bytes += (size_t)(plane * nzs); /* the slab copy */
    *out = t;
    return GS_OK;
}

gs_err gs_field_tree_build_shard(const gs_qfield *src, int block, int shards, int shard,
                                 gs_field_tree_t *out)
{
    if (shards <= 1)
        return gs_field_tree_build(src, block, out);
    int64_t z0, z1;
    GS_CALL(gs_partition(src->nz - block + 1, shards, shard, &z0, &z1));
    *out = NULL;
    return z1 > z0 ? gs_field_tree_build_slab(src, block, z0, z1, out) : GS_OK;
}

void gs_field_tree_destroy(gs_field_tree_t *tp)
{
    if (!tp || !*tp)
        return;
    struct gs_field_tree *t = *tp;
    gs_qfield_destroy(&t->own_src);
    gs_field_pyramid_destroy(&t->pyr);
    gs_step_layout_free(&t->lay);
    gs_free(t->nodes);
    gs_free(t->members);
    gs_free(t->boxes);
    gs_free(t->box_of);
    gs_free(t->top);
    gs_free(t->top_blocks);
    GS_FREE(*tp);
}

void gs_field_tree_get_info(gs_field_tree_t t, gs_field_tree_info *info)
{
    *info = t->info;
}

int gs_field_tree_block(gs_field_tree_t t)
{
    return t->lay.B;
}

int64_t gs_field_tree_top_count(gs_field_tree_t t)
{
    return t->ntop;
}

int64_t gs_field_tree_top_blocks(gs_field_tree_t t, int64_t top)
{
    return top >= 0 && top < t->ntop ? t->top_blocks[top] : 0;
}
