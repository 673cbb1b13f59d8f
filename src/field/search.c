/* Best-first tree search (paper fig. 4 with incremental evaluation, 4.4,
 * and leaves evaluated as their parent is expanded) and the brute-force
 * reference; see include/geosynth/field.h.
 *
 * Bounds are kept as exact integers scaled by 8^L: a level-k cell of c =
 * 8^(L-k) samples contributes (Sq - Sb)^2 / c, i.e. (Sq - Sb)^2 * 8^k
 * scaled, and a leaf sample (k = L) (q - b)^2 * 8^L, so the bound of a
 * complete leaf is exactly dist * 8^L and comparisons involve no rounding.
 * The spread term of cell_term() is the one floating-point part: it is
 * rounded down with a margin, so bounds stay valid and leaves stay exact. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "field_impl.h"
#include "geosynth/digest.h"
#include "geosynth/mem.h"

/* Leaves are not queued: when a node is expanded, its leaf children are
 * evaluated on the spot, in the order of their octant bounds, against the
 * best distance found so far: the bound of each staged level (2 .. L-2, one
 * pass over its cells each) and then the exact distance, summed a chunk of
 * z-slices at a time and given up once it passes the best. Only inner nodes
 * go through the queue. Queueing every leaf (the paper's scheme) fills the
 * queue with hundreds of thousands of entries on queries far from every
 * block, whose sift-downs then miss the caches; evaluated at once, most
 * leaves cost their octants and one level, and the best so far stays close
 * to the final one because the first nodes expanded hold the blocks closest
 * in their octants. Recorded synthesis queries (bench_field inputs)
 * replayed one after another, per query, queued leaves -> eager leaves on
 * the same machine, same answers: armadillo 128^3/16 paper setting 6.1 ->
 * 4.5 ms (worst 146 -> 74 ms), weighted 2.5 -> 2.2 ms; 256^3/32 weighted
 * 141 -> 84 ms, paper setting 29 -> 19 ms; fibers 49 -> 24 ms. Timed
 * inside the synthesis (bench_field), the 128^3/16 paper queries take
 * about the same either way (6.0-6.9 -> 6.1 ms), the 256^3/32 ones gain
 * as above. Staged levels for 32^3 leaves: 2 and 3 (level 2 alone: 93 ms,
 * none: 185 ms on the weighted ones); for 16^3: 2. */
static int leaf_stage_max(int L)
{
    return L - 2;
}

/* Queue entry, 16 bytes so that a node's four children in the 4-ary heap
 * share about one cache line (the queue outgrows the caches on synthesis
 * queries, and its sift-downs were a third of the search time). The lowest
 * block index below the node, the second key, is nodes[node].rep. */
typedef struct entry {
    uint64_t lb;    /* scaled lower bound after `step` steps */
    uint32_t node;
    uint32_t step;
} entry;
_Static_assert(sizeof(entry) == 16, "queue entries stay 16 bytes");

struct gs_field_searcher {
    struct gs_field_tree *tree;
    uint32_t *qsum[GS_FIELD_MAX_LEVEL + 1];  /* query cell sums per level, Morton order */
    uint8_t *qfull[GS_FIELD_MAX_LEVEL + 1];  /* 1 = every sample of the cell known */
    double *qdev[GS_FIELD_MAX_LEVEL + 1];    /* sqrt(c * sum q^2 - (sum q)^2), c = cell samples */
    entry *heap;
    size_t heap_n, heap_cap;
    struct cand *cand;   /* leaf children of the node being expanded */
    size_t cand_cap;
    int64_t known;
    uint64_t wk, wu;     /* weights of fully known cells / all other cells (field.h) */
    int query_step_max;
    /* upper bound extra per level-boundary state, unscaled (see ub_extra) */
    uint64_t samples_dev2[GS_FIELD_MAX_LEVEL + 1]; /* per-sample (3(s_k-1)K)^2 */
    const gs_field_query *q;                       /* the query being searched */
};

/* Queue order: (lower bound, lowest block index below, node). */
static inline int entry_less(const struct gs_field_searcher *s, const entry *a, const entry *b)
{
    if (a->lb != b->lb)
        return a->lb < b->lb;
    uint32_t ra = s->tree->nodes[a->node].rep, rb = s->tree->nodes[b->node].rep;
    if (ra != rb)
        return ra < rb;
    return a->node < b->node;
}

/* 4-ary min-heap: children of i at 4i+1 .. 4i+4. */
static gs_err heap_push(struct gs_field_searcher *s, entry e)
{
    if (s->heap_n == s->heap_cap) {
        size_t cap = s->heap_cap ? 2 * s->heap_cap : 1024;
        entry *h = gs_realloc(s->heap, cap * sizeof *h);
        GS_CHECK(h, GS_ERR_MEM, "out of memory for a search queue of %zu entries", cap);
        s->heap = h;
        s->heap_cap = cap;
    }
    size_t i = s->heap_n++;
    while (i > 0) {
        size_t p = (i - 1) / 4;
        if (!entry_less(s, &e, &s->heap[p]))
            break;
        s->heap[i] = s->heap[p];
        i = p;
    }
    s->heap[i] = e;
    return GS_OK;
}

static entry heap_pop(struct gs_field_searcher *s)
{
    entry top = s->heap[0];
    entry last = s->heap[--s->heap_n];
    size_t n = s->heap_n, i = 0;
    for (;;) {
        size_t c = 4 * i + 1;
        if (c >= n)
            break;
        size_t best = c, end = c + 4 < n ? c + 4 : n;
        for (size_t j = c + 1; j < end; j++)
            if (entry_less(s, &s->heap[j], &s->heap[best]))
                best = j;
        if (!entry_less(s, &s->heap[best], &last))
            break;
        s->heap[i] = s->heap[best];
        i = best;
    }
    if (n > 0)
        s->heap[i] = last;
    return top;
}

gs_err gs_field_searcher_create(gs_field_tree_t t, gs_field_searcher_t *out)
{
    struct gs_field_searcher *s = gs_calloc(1, sizeof *s);
    GS_CHECK(s, GS_ERR_MEM, "out of memory for a searcher");
    s->tree = t;
    gs_err err = GS_OK;
    for (int k = 0; k <= t->lay.L; k++) {
        size_t cells = (size_t)1 << (3 * k);
        GS_TRY(err, gs_alloc_array((void **)&s->qsum[k], cells, sizeof(uint32_t), "query pyramid"),
               fail);
        GS_TRY(err, gs_alloc_array((void **)&s->qfull[k], cells, 1, "query pyramid"), fail);
        GS_TRY(err, gs_alloc_array((void **)&s->qdev[k], cells, sizeof(double), "query pyramid"),
               fail);
    }
    *out = s;
    return GS_OK;
fail:
    gs_field_searcher_destroy(&s);
    return err;
}

void gs_field_searcher_destroy(gs_field_searcher_t *sp)
{
    if (!sp || !*sp)
        return;
    for (int k = 0; k <= GS_FIELD_MAX_LEVEL; k++) {
        gs_free((*sp)->qsum[k]);
        gs_free((*sp)->qfull[k]);
        gs_free((*sp)->qdev[k]);
    }
    gs_free((*sp)->heap);
    gs_free((*sp)->cand);
    GS_FREE(*sp);
}

/* Query block pyramid in Morton order, known counts and step maximum. */
static void prepare_query(struct gs_field_searcher *s, const gs_field_query *q)
{
    const gs_step_layout *lay = &s->tree->lay;
    int L = lay->L, B = lay->B;
    int64_t n = (int64_t)1 << (3 * L);
    s->known = 0;
    gs_field_query_weights(q, &s->wk, &s->wu);
    /* sums of squares ride in qdev until the deviations are formed below */
    for (int64_t j = 0; j < n; j++) {
        int64_t o = lay->qcell_off[L][j];
        s->qsum[L][j] = q->values[o];
        s->qdev[L][j] = (double)q->values[o] * q->values[o];
        s->qfull[L][j] = q->known ? q->known[o] != 0 : 1;
        s->known += s->qfull[L][j];
    }
    for (int k = L - 1; k >= 0; k--) {
        int64_t cells = (int64_t)1 << (3 * k);
        for (int64_t j = 0; j < cells; j++) {
            uint32_t sum = 0;
            double sq = 0;
            uint8_t full = 1;
            for (int c = 0; c < 8; c++) {
                sum += s->qsum[k + 1][8 * j + c];
                sq += s->qdev[k + 1][8 * j + c];
                full &= s->qfull[k + 1][8 * j + c];
            }
            s->qsum[k][j] = sum;
            s->qfull[k][j] = full;
            s->qdev[k][j] = sq; /* exact: integers below 2^53 */
        }
    }
    for (int k = 0; k <= L; k++) {
        int64_t cells = (int64_t)1 << (3 * k), c = (int64_t)1 << (3 * (L - k));
        for (int64_t j = 0; j < cells; j++) {
            int64_t S = s->qsum[k][j];
            s->qdev[k][j] = sqrt((double)(c * (int64_t)s->qdev[k][j] - S * S));
        }
    }
    int kmax = 0;
    for (int z = 0; z < B; z++)
        for (int y = 0; y < B; y++)
            for (int x = 0; x < B; x++) {
                int i = x + B * (y + B * z), v = q->values[i], d;
                if (x + 1 < B && (d = abs(v - q->values[i + 1])) > kmax)
                    kmax = d;
                if (y + 1 < B && (d = abs(v - q->values[i + B])) > kmax)
                    kmax = d;
                if (z + 1 < B && (d = abs(v - q->values[i + B * B])) > kmax)
                    kmax = d;
            }
    s->query_step_max = kmax;
    uint64_t K = (uint64_t)(kmax + s->tree->source_step_max);
    for (int k = 0; k <= L; k++) {
        uint64_t dev = 3 * (((uint64_t)B >> k) - 1) * K;
        s->samples_dev2[k] = dev * dev;
    }
}

static inline uint64_t sq_scaled(int64_t d, int k)
{
    return (uint64_t)(d * d) << (3 * k);
}

/* Weight of cell j of level k: wk when all its samples are known, else wu
 * (the smallest weight of its samples, so weighted bounds stay valid). */
static inline uint64_t cell_weight(const struct gs_field_searcher *s, int k, int64_t j)
{
    return s->qfull[k][j] ? s->wk : s->wu;
}

/* Scaled lower bound (times 8^L) of the distance over one fully known cell
 * of level k < L (c = 8^(L-k) samples) whose source sum is Sb and spread b
 * (gs_pyr_cell): with v = c*Q - S^2 (c times the sum of squared deviations
 * from the cell mean), a = sqrt(vq) and b = sqrt(vb),
 *   sum (q - s)^2 = ((Sq - Sb)^2 + |dq - ds|^2 * c) / c
 *                >= ((Sq - Sb)^2 + (a - b)^2) / c          (Cauchy-Schwarz),
 * scaled: 8^k * ((Sq - Sb)^2 + (a - b)^2). The first term is the paper's
 * eq. 2; the second sees the spread of the samples (random seeds, a coarse
 * copy against a fine source) that cell averages cannot. |a - b| is rounded
 * down with a margin above the errors of a (a correctly rounded root, a <
 * 2^23) and of the stored b (GS_PYR_DEV_EPS), so the sum stays a valid
 * bound; it is monotone under refinement (the children's deviation vectors
 * split the parent's orthogonally) up to that margin. */
static inline uint64_t cell_term(int64_t Sq, double a, uint32_t Sb, float bf, int k)
{
    int64_t d = Sq - (int64_t)Sb;
    uint64_t t = (uint64_t)(d * d);
    double b = bf;
    double e = fabs(a - b) - (4e-16 * a + GS_PYR_DEV_EPS * b);
    if (e > 0)
        t += (uint64_t)(e * e * (1 - 4e-16));
    return t << (3 * k);
}

/* Advances e by one step for the block at base; returns the new bound.
 * Entries in the queue are past the exact octants (step > GS_FIELD_QSTEPS)
 * or are trie nodes bounded by their box, which are never refined. */
static inline uint64_t refine(const struct gs_field_searcher *s, int64_t base, const entry *e)
{
    const struct gs_field_tree *t = s->tree;
    const gs_step_layout *lay = &t->lay;
    const struct gs_field_pyramid *p = t->pyr;
    int L = lay->L;
    uint64_t lb = e->lb;
    int64_t r = (int64_t)e->step - GS_FIELD_QSTEPS;
    int k = 1; /* refinement r >= 1 splits a cell of level k >= 1 */
    while (r >= lay->level_first[k + 2])
        k++;
    int64_t j = r - lay->level_first[k + 1];
    int m = L - k;
    int64_t cell = base + lay->cell_off[k][j];
    if (cell_weight(s, k, j))
        lb -= cell_weight(s, k, j) *
              cell_term(s->qsum[k][j], s->qdev[k][j], gs_pyr_at(p, m, cell), gs_pyr_dev_at(p, m, cell), k);
    const int64_t *off = lay->cell_off[k + 1] + 8 * j;
    const uint32_t *qs = s->qsum[k + 1] + 8 * j;
    const double *qd = s->qdev[k + 1] + 8 * j;
    const uint8_t *qf = s->qfull[k + 1] + 8 * j;
    const uint64_t wk = s->wk, wu = s->wu;
    if (m == 1) {
        const uint8_t *v = t->src->q + base;
        for (int c = 0; c < 8; c++) {
            uint64_t w = qf[c] ? wk : wu;
            if (w)
                lb += w * sq_scaled((int64_t)qs[c] - v[off[c]], k + 1);
        }
    } else {
        const gs_pyr_cell *v = p->cell[m - 1] + base;
        for (int c = 0; c < 8; c++) {
            uint64_t w = qf[c] ? wk : wu;
            if (w)
                lb += w * cell_term(qs[c], qd[c], v[off[c]].sum, v[off[c]].dev, k + 1);
        }
    }
    return lb;
}

/* Valid upper bound (unscaled) on dist of every block below an entry at
 * `step` with scaled bound lb, for fully known queries (see field.h). */
static uint64_t upper_bound(const struct gs_field_searcher *s, uint64_t lb, uint32_t step)
{
    const gs_step_layout *lay = &s->tree->lay;
    int L = lay->L;
    int64_t R = (int64_t)step - GS_FIELD_QSTEPS;
    if (R >= lay->level_first[L + 1])
        return lb >> (3 * L); /* complete: exact */
    int k = 0;
    while (R >= lay->level_first[k + 2])
        k++;
    /* frontier: level-k cells not yet refined, and level-(k+1) cells from the
     * refinements done inside level k */
    int64_t done_in_k = R - lay->level_first[k + 1];
    int64_t cells_k = ((int64_t)1 << (3 * k)) - done_in_k;
    int64_t samples_per_k = (int64_t)1 << (3 * (L - k));
    uint64_t extra = (uint64_t)(cells_k * samples_per_k) * s->samples_dev2[k];
    extra += (uint64_t)(done_in_k * samples_per_k) * s->samples_dev2[k + 1];
    return (lb >> (3 * L)) + extra * s->wk;
}

static uint64_t leaf_exact(const struct gs_field_searcher *s, int64_t base, int k0, int k1);

/* Scaled lower bound of every block below a trie node from its octant box
 * (field_impl.h): per octant, the distance of the query's sum Sq to the
 * box's sum interval and of its deviation a to the box's deviation interval
 * stand in for |Sq - Sb| and |a - b| in cell_term(), which they cannot
 * exceed for any block below. It bounds all 8 octants at once, the spread
 * included, where the floor means that the trie splits on bound only the
 * octants revealed so far and see no spread: a subtree whose blocks are all
 * too smooth (or too rough) for the query is dropped without touching the
 * pyramid. Rounded down like cell_term(). */
static uint64_t box_bound(const struct gs_field_searcher *s, const gs_tree_box *bx)
{
    int sh = 3 * (s->tree->lay.L - 1);
    double cs = (double)((int64_t)1 << sh) / 256;
    uint64_t lb = 0;
    /* branch-free: the query falls on either side of a box at random */
    for (int o = 0; o < 8; o++) {
        int64_t Sq = s->qsum[1][o], lo = (int64_t)bx->mlo[o] << sh, hi = (int64_t)bx->mhi[o] << sh;
        int64_t d = lo - Sq > Sq - hi ? lo - Sq : Sq - hi;
        d = d > 0 ? d : 0;
        double a = s->qdev[1][o], bl = bx->slo[o] * cs, bh = bx->shi[o] * cs;
        double e = bl - a > a - bh ? bl - a : a - bh;
        e -= 4e-16 * (a + bh);
        e = e > 0 ? e : 0;
        uint64_t t = (uint64_t)(d * d) + (uint64_t)(e * e * (1 - 4e-16));
        lb += cell_weight(s, 1, o) * (t << 3);
    }
    return lb;
}

/* Scaled bound of the block at base from all cells of level k (1 <= k <
 * L), computed in one pass: the state after the refinements of every cell
 * of level k - 1 (step GS_FIELD_QSTEPS + level_first[k + 1]), the same
 * integer as those refinements one by one give. k = 1: its exact octants
 * (the state after step GS_FIELD_QSTEPS), computed for every child opened,
 * which is why this is always inlined: the call with k = 1 unrolls. */
static inline __attribute__((always_inline)) uint64_t level_bound(const struct gs_field_searcher *s, int64_t base, int k)
{
    const struct gs_field_tree *t = s->tree;
    int m = t->lay.L - k;
    int64_t cells = (int64_t)1 << (3 * k);
    const int64_t *off = t->lay.cell_off[k];
    uint64_t lb = 0;
    for (int64_t j = 0; j < cells; j++) {
        uint64_t w = cell_weight(s, k, j);
        if (w) {
            int64_t x = base + off[j];
            lb += w * cell_term(s->qsum[k][j], s->qdev[k][j], gs_pyr_at(t->pyr, m, x),
                                gs_pyr_dev_at(t->pyr, m, x), k);
        }
    }
    return lb;
}

/* Queue entry of node id, whose parent was popped with bound lb after
 * `step` steps: a trie node is bounded by its box; a node past the parent's
 * steps inherits them; any other node starts from its exact octants. */
static entry open_node(const struct gs_field_searcher *s, uint32_t id, uint64_t lb, uint32_t step)
{
    const struct gs_field_tree *t = s->tree;
    const gs_tree_node *nd = &t->nodes[id];
    if (t->box_of[id] != GS_TREE_NO_BOX)
        return (entry){box_bound(s, &t->boxes[t->box_of[id]]), id, nd->end};
    if (step > GS_FIELD_QSTEPS)
        return (entry){lb, id, step};
    return (entry){level_bound(s, gs_tree_block_base(t, nd->rep), 1), id, GS_FIELD_QSTEPS + 1};
}

/* Starts loading what open_node(id) will read: a node's box, or its
 * block's octant sums and spreads in the pyramid (scattered over the
 * source: the children of a node are expanded in a row, so their loads
 * overlap instead of waiting one by one). */
static inline void prefetch_node(const struct gs_field_searcher *s, uint32_t id)
{
    const struct gs_field_tree *t = s->tree;
    if (t->box_of[id] != GS_TREE_NO_BOX) {
        __builtin_prefetch(&t->boxes[t->box_of[id]]);
        return;
    }
    int m = t->lay.L - 1;
    if (m == 0)
        return;
    int64_t base = gs_tree_block_base(t, t->nodes[id].rep);
    const int64_t *off = t->lay.cell_off[1];
    for (int o = 0; o < 8; o++) {
        __builtin_prefetch(t->pyr->cell[m] + base + off[o]);
    }
}

/* A leaf child of the node being expanded: its bound after `step` steps
 * and its block (the leaf's lowest index), sorted by (lb, rep). */
typedef struct cand {
    uint64_t lb;
    uint32_t rep, step, node;
} cand;

static int cand_cmp(const void *pa, const void *pb)
{
    const cand *a = pa, *b = pb;
    if (a->lb != b->lb)
        return a->lb < b->lb ? -1 : 1;
    return a->rep < b->rep ? -1 : a->rep > b->rep;
}

/* Does block position p lie in one of the boxes? */
static int in_boxes(const int64_t (*box)[6], int n, const int64_t p[3])
{
    for (int i = 0; i < n; i++)
        if (p[0] >= box[i][0] && p[0] <= box[i][3] && p[1] >= box[i][1] && p[1] <= box[i][4] &&
            p[2] >= box[i][2] && p[2] <= box[i][5])
            return 1;
    return 0;
}

uint64_t gs_field_tie_rank(uint64_t tie_key, int64_t index)
{
    if (!tie_key)
        return (uint64_t)index;
    uint64_t h = gs_hash_mix64(tie_key ^ gs_hash_mix64((uint64_t)index + 0x9e3779b97f4a7c15ULL));
    return (h >> 33) << 32 | (uint64_t)(uint32_t)index;
}

uint64_t gs_field_tie_rank_of(const gs_field_search_opts *o, int64_t index)
{
    if (!o->tie_class)
        return gs_field_tie_rank(o->tie_key, index);
    uint64_t h = o->tie_key ? gs_field_tie_rank(o->tie_key, index) >> 40 : 0; /* 23 bits */
    return (uint64_t)o->tie_class[index] << 55 | h << 32 | (uint64_t)(uint32_t)index;
}

/* The block of leaf node nd a match may take: of its members outside
 * opts->exclude (members share their content, so their distance), the
 * lowest in the tie order of opts->tie_key (global indices), or -1; *rank
 * its tie rank. */
static int64_t leaf_pick(const struct gs_field_tree *t, const gs_field_search_opts *o,
                         const gs_tree_node *nd, uint64_t *rank)
{
    if (!o->nexclude && !o->exclude_mask && !o->tie_key && !o->tie_class) {
        *rank = (uint64_t)((int64_t)nd->rep + t->index_offset);
        return nd->rep;
    }
    int64_t pick = -1;
    for (uint32_t i = 0; i < nd->count; i++) {
        int64_t g = (int64_t)t->members[nd->first + i] + t->index_offset;
        if (o->exclude_mask && o->exclude_mask[g])
            continue;
        if (o->nexclude) {
            int64_t p[3] = {g % t->bx, g / t->bx % t->by, g / (t->bx * t->by)};
            if (in_boxes(o->exclude, o->nexclude, p))
                continue;
        }
        uint64_t r = gs_field_tie_rank_of(o, g);
        if (pick < 0 || r < *rank) {
            pick = t->members[nd->first + i];
            *rank = r;
            if (!o->tie_key)
                break; /* members ascend (and share a class): the first is the lowest */
        }
    }
    return pick;
}

/* Exact distance of the leaf whose block is at base, from a state after
 * `step` steps, if it is at most bnd: the bounds of the staged levels are
 * checked first, then the samples are summed a chunk of z-slices at a time
 * and the sum is given up as soon as it passes bnd. */
static int leaf_eval(const struct gs_field_searcher *s, int64_t base, uint32_t step, uint64_t bnd,
                     uint64_t bnd_scaled, int smax, gs_field_match *out, uint64_t *dist)
{
    const gs_step_layout *lay = &s->tree->lay;
    int L = lay->L, B = lay->B;
    for (int k = 2; k < L && k <= smax; k++) {
        if (step >= GS_FIELD_QSTEPS + lay->level_first[k + 1])
            continue;
        out->refinements++;
        if (level_bound(s, base, k) > bnd_scaled)
            return 0;
    }
    uint64_t part = 0;
    int chunk = B >= 8 ? B / 8 : 1;
    for (int z = 0; z < B;) {
        int z1 = z + chunk < B ? z + chunk : B;
        part += leaf_exact(s, base, z, z1);
        z = z1;
        if (part > bnd)
            return 0;
    }
    out->refinements++;
    *dist = part;
    return 1;
}

gs_err gs_field_tree_search(gs_field_searcher_t s, int64_t top_begin, int64_t top_end,
                            const gs_field_query *q, const gs_field_search_opts *opts,
                            uint64_t *bound, gs_field_match *out)
{
    struct gs_field_tree *t = s->tree;
    const gs_step_layout *lay = &t->lay;
    int L = lay->L;
    GS_CHECK(q->block == lay->B, GS_ERR_ARG, "query block %d: the tree holds blocks of %d",
             q->block, lay->B);
    GS_CHECK(top_begin >= 0 && top_begin <= top_end && top_end <= t->ntop, GS_ERR_ARG,
             "top-level range [%lld, %lld): expected within [0, %lld]", (long long)top_begin,
             (long long)top_end, (long long)t->ntop);
    gs_field_search_opts none = {0};
    if (!opts)
        opts = &none;
    prepare_query(s, q);
    s->q = q;
    memset(out, 0, sizeof *out);
    out->known = s->known;
    int use_ub = opts->use_upper_bound && s->known == ((int64_t)1 << (3 * L));
    uint64_t bnd = *bound;
    if (opts->start_bound && opts->start_bound < bnd)
        bnd = opts->start_bound;
    const uint64_t inf = UINT64_MAX;
#define SCALED(b) ((b) > (inf >> (3 * L)) ? inf : (b) << (3 * L))
    uint64_t bnd_scaled = SCALED(bnd);
    s->heap_n = 0;
    for (int64_t i = top_begin; i < top_end; i++) {
        GS_CALL(heap_push(s, open_node(s, t->top[i], 0, 0)));
        out->pushes++;
    }
    uint64_t steps_total = (uint64_t)lay->steps;
    int smax = leaf_stage_max(L);
    int have = 0;
    uint64_t best_d = 0, best_rank = 0;
    uint32_t best_rep = 0;
    const int keyed = opts->tie_key != 0 || opts->tie_class;
#define CONSIDER(d, rep, rank)                                                                     \
    do {                                                                                           \
        if (!have || (d) < best_d || ((d) == best_d && (rank) < best_rank)) {                      \
            have = 1;                                                                              \
            best_d = (d);                                                                          \
            best_rep = (rep);                                                                      \
            best_rank = (rank);                                                                    \
            if (best_d < bnd) {                                                                    \
                bnd = best_d;                                                                      \
                bnd_scaled = SCALED(bnd);                                                          \
            }                                                                                      \
        }                                                                                          \
    } while (0)
    /* nothing below an entry of bound lb and lowest index rep can beat the
     * best so far (lowest-index ties: rep is the lowest index below; with a
     * tie key the ranks below are unknown, so an entry at the bound stays) */
#define WORSE(lb, rep)                                                                             \
    ((lb) > bnd_scaled ||                                                                          \
     (!keyed && (lb) == bnd_scaled && have && best_d == bnd && (rep) > best_rep))
    /* a leaf at the bound whose pick ranks above the best's cannot win */
#define TIE_LOSES(lb, rank) ((lb) == bnd_scaled && have && best_d == bnd && (rank) > best_rank)
    /* out->pops counts queue pops and leaves evaluated at once: the units of
     * work that polling and the pop budget are measured in */
    uint64_t next_poll = opts->poll_every;
    while (s->heap_n > 0) {
        if (s->heap_n > out->queue_peak)
            out->queue_peak = s->heap_n;
        if (opts->poll && opts->poll_every && out->pops >= next_poll) {
            opts->poll(opts->poll_ctx, &bnd);
            bnd_scaled = SCALED(bnd);
            next_poll = out->pops + opts->poll_every;
        }
        if (opts->max_pops && out->pops >= opts->max_pops) {
            out->truncated = 1;
            break;
        }
        entry e = heap_pop(s);
        out->pops++;
        const gs_tree_node *nd = &t->nodes[e.node];
        if (WORSE(e.lb, nd->rep))
            break; /* everything left is worse */
        int64_t base = gs_tree_block_base(t, nd->rep);
        uint64_t d;
        if (nd->end == steps_total) {
            uint64_t rank = 0;
            int64_t pick = leaf_pick(t, opts, nd, &rank);
            if (pick >= 0 && !TIE_LOSES(e.lb, rank) &&
                leaf_eval(s, base, e.step, bnd, bnd_scaled, smax, out, &d))
                CONSIDER(d, (uint32_t)pick, rank);
            continue;
        }
        int requeued = 0, dropped = 0;
        while (e.step < nd->end) {
            e.lb = refine(s, base, &e);
            e.step++;
            out->refinements++;
            if (e.lb > bnd_scaled) {
                dropped = 1;
                break;
            }
            if (s->heap_n > 0 && entry_less(s, &s->heap[0], &e)) {
                GS_CALL(heap_push(s, e));
                out->pushes++;
                requeued = 1;
                break;
            }
        }
        if (requeued || dropped)
            continue;
        if (use_ub && e.step > GS_FIELD_QSTEPS) {
            uint64_t ub = upper_bound(s, e.lb, e.step);
            if (ub < bnd) {
                bnd = ub;
                bnd_scaled = SCALED(bnd);
            }
        }
        /* children prefetched ahead: inside a synthesis (bench_field), the
         * armadillo 128^3/16 paper-setting queries took 4.0-4.8 ms with 4,
         * 3.4-3.7 ms with 8 (four alternating runs); 256^3/32 and the
         * weighted queries are even; 16 is no better than 8 */
        enum { PREFETCH_AHEAD = 8 };
        for (uint32_t c = 0; c < nd->count && c < PREFETCH_AHEAD; c++)
            prefetch_node(s, nd->first + c);
        size_t nc = 0;
        for (uint32_t c = 0; c < nd->count; c++) {
            if (c + PREFETCH_AHEAD < nd->count)
                prefetch_node(s, nd->first + c + PREFETCH_AHEAD);
            uint32_t id = nd->first + c;
            entry ce = open_node(s, id, e.lb, e.step);
            out->refinements++;
            if (ce.lb > bnd_scaled)
                continue;
            if (t->nodes[id].end == steps_total) {
                if (nc == s->cand_cap) {
                    size_t cap = s->cand_cap ? 2 * s->cand_cap : 256;
                    cand *a = gs_realloc(s->cand, cap * sizeof *a);
                    GS_CHECK(a, GS_ERR_MEM, "out of memory for %zu search candidates", cap);
                    s->cand = a;
                    s->cand_cap = cap;
                }
                s->cand[nc++] = (cand){ce.lb, t->nodes[id].rep, ce.step, id};
                continue;
            }
            GS_CALL(heap_push(s, ce));
            out->pushes++;
        }
        if (nc > 1)
            qsort(s->cand, nc, sizeof *s->cand, cand_cmp);
        for (size_t i = 0; i < nc; i++) {
            const cand *cd = &s->cand[i];
            if (WORSE(cd->lb, cd->rep))
                break;
            if (opts->max_pops && out->pops >= opts->max_pops) {
                out->truncated = 1;
                break;
            }
            out->pops++;
            uint64_t rank = 0;
            int64_t pick = leaf_pick(t, opts, &t->nodes[cd->node], &rank);
            if (pick >= 0 && !TIE_LOSES(cd->lb, rank) &&
                leaf_eval(s, gs_tree_block_base(t, cd->rep), cd->step, bnd, bnd_scaled, smax, out, &d))
                CONSIDER(d, (uint32_t)pick, rank);
        }
        if (out->truncated)
            break;
    }
#undef TIE_LOSES
#undef WORSE
#undef CONSIDER
#undef SCALED
    if (have && best_d <= bnd && !out->truncated) {
        out->found = 1;
        out->index = (int64_t)best_rep + t->index_offset;
        out->dist = best_d;
    }
    *bound = bnd;
    return GS_OK;
}

gs_err gs_field_tree_best_match(gs_field_searcher_t s, const gs_field_query *q,
                                const gs_field_search_opts *opts, gs_field_match *out)
{
    uint64_t bound = UINT64_MAX;
    GS_CALL(gs_field_tree_search(s, 0, s->tree->ntop, q, opts, &bound, out));
    GS_CHECK(out->found, GS_ERR_INTERNAL, "tree search without a bound found no block");
    return GS_OK;
}

/* ---------------------------------------------------------- brute force */

/* Weighted sum of squared differences of z-slices [k0, k1) of one block; B
 * fixed per instantiation so the inner loop vectorizes, built for AVX2 as
 * well as the baseline and chosen at load time (glibc ifunc): the exact
 * completion of leaves is most of a 32^3 search (256^3/32 synthesis queries:
 * 0.26 -> 0.15 s per query). */
#define DEFINE_SSD(NAME, BB)                                                                       \
    __attribute__((target_clones("avx2", "default"))) static uint64_t NAME(                       \
        const uint8_t *src, int64_t nx, int64_t nxy, const uint8_t *q, const uint8_t *known,       \
        uint64_t wk, uint64_t wu, int B_, int k0, int k1)                                          \
    {                                                                                              \
        const int B = (BB) ? (BB) : B_;                                                            \
        uint64_t d = 0;                                                                            \
        for (int k = k0; k < k1; k++)                                                              \
            for (int j = 0; j < B; j++) {                                                          \
                const uint8_t *row = src + nx * j + nxy * k;                                       \
                const uint8_t *qr = q + B * (j + B * k);                                           \
                uint32_t acc = 0;                                                                  \
                if (known) {                                                                       \
                    const uint8_t *kr = known + B * (j + B * k);                                   \
                    uint32_t acu = 0;                                                              \
                    for (int i = 0; i < B; i++) {                                                  \
                        int e = (int)qr[i] - (int)row[i];                                          \
                        uint32_t e2 = (uint32_t)(e * e);                                           \
                        acc += e2;                                                                 \
                        acu += e2 & (0u - (uint32_t)(kr[i] == 0));                                 \
                    }                                                                              \
                    d += wk * (acc - acu) + wu * acu;                                              \
                    continue;                                                                      \
                } else {                                                                           \
                    for (int i = 0; i < B; i++) {                                                  \
                        int e = (int)qr[i] - (int)row[i];                                          \
                        acc += (uint32_t)(e * e);                                                  \
                    }                                                                              \
                }                                                                                  \
                d += acc;                                                                          \
            }                                                                                      \
        return d;                                                                                  \
    }
DEFINE_SSD(ssd_any, 0)
DEFINE_SSD(ssd_8, 8)
DEFINE_SSD(ssd_16, 16)
DEFINE_SSD(ssd_32, 32)

typedef uint64_t (*ssd_fn)(const uint8_t *, int64_t, int64_t, const uint8_t *, const uint8_t *,
                           uint64_t, uint64_t, int, int, int);

static ssd_fn ssd_for(int B)
{
    return B == 8 ? ssd_8 : B == 16 ? ssd_16 : B == 32 ? ssd_32 : ssd_any;
}

/* Exact weighted distance of the searched query over z-slices [k0, k1) of
 * the block at base. */
static uint64_t leaf_exact(const struct gs_field_searcher *s, int64_t base, int k0, int k1)
{
    const struct gs_field_tree *t = s->tree;
    int B = t->lay.B;
    return ssd_for(B)(t->src->q + base, t->src->nx, t->src->nx * t->src->ny, s->q->values,
                      s->q->known, s->wk, s->wu, B, k0, k1);
}

gs_err gs_field_brute_search(const gs_qfield *src, const gs_field_query *q, int64_t begin,
                             int64_t end, uint64_t *bound, gs_field_match *out)
{
    return gs_field_brute_search_excluding(src, q, NULL, 0, begin, end, bound, out);
}

gs_err gs_field_brute_search_excluding(const gs_qfield *src, const gs_field_query *q,
                                       const int64_t (*exclude)[6], int nexclude, int64_t begin,
                                       int64_t end, uint64_t *bound, gs_field_match *out)
{
    return gs_field_brute_search_keyed(src, q, exclude, nexclude, 0, begin, end, bound, out);
}

gs_err gs_field_brute_search_keyed(const gs_qfield *src, const gs_field_query *q,
                                   const int64_t (*exclude)[6], int nexclude, uint64_t tie_key,
                                   int64_t begin, int64_t end, uint64_t *bound,
                                   gs_field_match *out)
{
    return gs_field_brute_search_classed(src, q, exclude, nexclude, tie_key, NULL, begin, end,
                                         bound, out);
}

gs_err gs_field_brute_search_classed(const gs_qfield *src, const gs_field_query *q,
                                     const int64_t (*exclude)[6], int nexclude, uint64_t tie_key,
                                     const uint8_t *tie_class, int64_t begin, int64_t end,
                                     uint64_t *bound, gs_field_match *out)
{
    gs_field_search_opts o = {0};
    o.exclude = exclude, o.nexclude = nexclude, o.tie_key = tie_key, o.tie_class = tie_class;
    return gs_field_brute_search_opts(src, q, &o, begin, end, bound, out);
}

gs_err gs_field_brute_search_opts(const gs_qfield *src, const gs_field_query *q,
                                  const gs_field_search_opts *opts, int64_t begin, int64_t end,
                                  uint64_t *bound, gs_field_match *out)
{
    gs_field_search_opts o = {0};
    if (opts)
        o.exclude = opts->exclude, o.nexclude = opts->nexclude, o.tie_key = opts->tie_key,
        o.tie_class = opts->tie_class, o.exclude_mask = opts->exclude_mask;
    int B = q->block;
    int64_t M = gs_field_block_count(src, B);
    GS_CHECK(M > 0, GS_ERR_ARG, "query block %d does not fit the source", B);
    GS_CHECK(begin >= 0 && begin <= end && end <= M, GS_ERR_ARG,
             "block range [%lld, %lld): expected within [0, %lld]", (long long)begin,
             (long long)end, (long long)M);
    ssd_fn ssd = ssd_for(B);
    memset(out, 0, sizeof *out);
    out->known = gs_field_query_known(q);
    uint64_t wk, wu;
    gs_field_query_weights(q, &wk, &wu);
    int64_t bx = src->nx - B + 1, by = src->ny - B + 1, nxy = src->nx * src->ny;
    uint64_t best = *bound, best_rank = 0;
    for (int64_t idx = begin; idx < end; idx++) {
        int64_t p[3] = {idx % bx, idx / bx % by, idx / (bx * by)};
        if ((o.exclude_mask && o.exclude_mask[idx]) || in_boxes(o.exclude, o.nexclude, p))
            continue;
        uint64_t d = ssd(src->q + gs_block_base(bx, by, src->nx, src->ny, idx), src->nx, nxy,
                         q->values, q->known, wk, wu, B, 0, B);
        if (d > best)
            continue;
        uint64_t rank = gs_field_tie_rank_of(&o, idx);
        if (!out->found || d < out->dist || rank < best_rank) {
            out->found = 1;
            out->index = idx;
            out->dist = d;
            best = d;
            best_rank = rank;
        }
    }
    out->pops = (uint64_t)(end - begin);
    *bound = best;
    return GS_OK;
}
