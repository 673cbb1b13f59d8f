/* Internal layout of the field engine's handles (see include/geosynth/field.h). */
#ifndef GEOSYNTH_FIELD_IMPL_H
#define GEOSYNTH_FIELD_IMPL_H

#include "geosynth/field.h"

/* Weight (1/256) of the random seeds of iteration 0 in the paper's
 * whole-block matching (mask_unsynthesized = no). The paper (5.1) seeds the
 * target with random source samples because "these will match approximately
 * equally well with any block in the source, so the matching process is
 * dominated by the overlap". In squared distance they do not: a seed X costs
 * a candidate value b on average (b - mu)^2 + var(X), and the quantized
 * truncated distance field is bimodal (quick.ini: mu = 200 of 255, so a seed
 * costs an inside value 43,900 and an outside one 4,000-6,900 per sample,
 * while the best overlap costs about 72 per sample). At weight 1 the 1/8 of
 * seeds outweighs the 7/8 of overlap ~100 times and every match is pulled
 * towards blocks near the source's mean, i.e. outside: quick.ini volume
 * fraction 0.067 vs the source's 0.163 (single resolution 0.009). For the
 * seeds to leave the overlap in charge, their cost spread over the source's
 * values (~4e4 per seed) times their weight must stay below one level^2 per
 * overlap sample (7 per seed): w < 2e-4, below the smallest weight the exact
 * integer distance holds (1/256). So they weigh 1/256: they break ties
 * among equally good overlaps (the randomness the paper wants them for),
 * nothing more. From iteration 1 on there are no random seeds and the whole
 * block counts, as in the paper. */
#define GS_FIELD_PAPER_SEED_WEIGHT 1

#define GS_FIELD_MAX_LEVEL 5 /* log2 of the largest block size (32) */

/* A pyramid cell of c = 8^m samples: their sum S and their spread
 * dev = sqrt(c*Q - S^2) (Q the sum of their squares; c times their standard
 * deviation), side by side so that a bound reads one cache line per cell,
 * not two. dev is the exact square root rounded to float (relative error
 * below 2^-23, see GS_PYR_DEV_EPS): the search's spread term reads it
 * instead of taking a square root per cell, its most frequent operation. */
typedef struct gs_pyr_cell {
    uint32_t sum;
    float dev;
} gs_pyr_cell;

/* Relative error bound of gs_pyr_cell.dev against the exact square root. */
#define GS_PYR_DEV_EPS 1.2e-7

struct gs_field_pyramid {
    const gs_qfield *src;
    int levels;
    int64_t nx, ny, nz;
    gs_pyr_cell *cell[GS_FIELD_MAX_LEVEL + 1]; /* cell[0] unused: level 0 is src->q */
    size_t bytes;
};

/* Value of global pyramid level m at linear position x (x fastest, source
 * stride). */
static inline uint32_t gs_pyr_at(const struct gs_field_pyramid *p, int m, int64_t x)
{
    return m == 0 ? p->src->q[x] : p->cell[m][x].sum;
}

/* Spread sqrt(c*Q - S^2) of the 2^m cube at linear position x (0 for a
 * single sample), as stored: see gs_pyr_cell. */
static inline float gs_pyr_dev_at(const struct gs_field_pyramid *p, int m, int64_t x)
{
    return m == 0 ? 0.0f : p->cell[m][x].dev;
}

/* Tree node: all blocks below share content for steps [0, end). rep is the
 * lowest block index below (also the representative whose content the node
 * reads from the pyramid). Internal: children nodes [first, first+count);
 * leaf (end == steps): member block indices [first, first+count) ascending. */
typedef struct gs_tree_node {
    uint32_t end;
    uint32_t rep;
    uint32_t first;
    uint32_t count;
} gs_tree_node;

/* Octant box of a trie node (one that ends within the octant floor means,
 * end <= GS_FIELD_QSTEPS): for every octant o, bounds that hold for every
 * block below: its octant sum S lies in [mlo[o] * c, mhi[o] * c] (c =
 * 8^(L-1) samples per octant) and its octant's standard deviation
 * sqrt(c*Q - S^2) / c in [slo[o], shi[o]] / 256 (rounded outwards). The
 * search bounds a whole subtree with them before it opens it
 * (src/field/search.c, box_bound). */
typedef struct gs_tree_box {
    uint16_t slo[8], shi[8];
    uint8_t mlo[8], mhi[8];
} gs_tree_box;

#define GS_TREE_NO_BOX UINT32_MAX

/* Block-relative layout of the step sequence, shared by tree and searcher. */
typedef struct gs_step_layout {
    int B, L;
    int64_t steps;                 /* GS_FIELD_QSTEPS + (8^L - 1)/7 */
    int64_t level_first[GS_FIELD_MAX_LEVEL + 2]; /* first refinement step revealing level k (k >= 1) */
    int64_t *cell_off[GS_FIELD_MAX_LEVEL + 1];   /* per level k: source offsets of cells (Morton) */
    int64_t *qcell_off[GS_FIELD_MAX_LEVEL + 1];  /* per level k: block-relative offsets (B stride) */
} gs_step_layout;

struct gs_field_tree {
    const gs_qfield *src;
    struct gs_field_pyramid *pyr;
    gs_step_layout lay;
    int64_t bx, by, bz, blocks;
    gs_tree_node *nodes;
    int64_t nnodes;
    uint32_t root;
    uint32_t *members;             /* leaf member lists */
    gs_tree_box *boxes;            /* octant boxes of the trie nodes */
    uint32_t *box_of;              /* per node: its box, or GS_TREE_NO_BOX */
    int64_t nboxes;
    uint32_t *top;                 /* top-level subtree node ids */
    int64_t *top_blocks;
    int64_t ntop;
    int source_step_max;
    gs_qfield *own_src;            /* slab trees: the private copy src points to */
    int64_t index_offset;          /* slab trees: global index of local block 0 */
    gs_field_tree_info info;
};

/* Steps of the sequence (see field.h): t < GS_FIELD_QSTEPS reveals the
 * floor mean of octant t (its sum >> 3(L-1)); GS_FIELD_QSTEPS + r is
 * refinement r (r = 0: the exact sums and spreads of the 8
 * octants; then each cell of level k >= 1 into its 8 children). */
#define GS_FIELD_QSTEPS 8

/* Linear source position of block idx (x fastest; bx, by block positions
 * per row and plane; nx, ny source samples per row and plane). */
static inline int64_t gs_block_base(int64_t bx, int64_t by, int64_t nx, int64_t ny, int64_t idx)
{
    int64_t px = idx % bx, py = idx / bx % by, pz = idx / (bx * by);
    return px + nx * (py + ny * pz);
}

static inline int64_t gs_tree_block_base(const struct gs_field_tree *t, uint32_t idx)
{
    return gs_block_base(t->bx, t->by, t->src->nx, t->src->ny, idx);
}

/* Helpers in pyramid.c. */
gs_err gs_step_layout_init(gs_step_layout *lay, int B, int64_t nx, int64_t ny);
void gs_step_layout_free(gs_step_layout *lay);

/* Minimum-error boundary cut of one B^3 block (field.seam_cut,
 * src/field/seamcut.c): term[i] ties sample i (x fastest) to the old content
 * (GS_CUT_OLD), to the new block (GS_CUT_NEW) or to neither (GS_CUT_FREE);
 * cost[i] is the disagreement of old and new at i (an edge costs the sum of
 * its ends', an edge from a GS_CUT_NEW sample to another twice the other's).
 * take_new[i] = 1 where the minimum cut gives the sample to the
 * new block (always for GS_CUT_NEW, never for GS_CUT_OLD). Deterministic.
 * columns: every edge along z costs GS_CUT_COLUMN, more than all the other
 * edges of a 32^3 block together (32^3 x 6 edges of at most 2 x (255 + 1275)
 * levels, the sign term's 1275 at field.range 0.1: < 2^30), so the cut
 * keeps each column (x, y) whole unless its own ties force it apart: the cut
 * of the column sums, a height field's seams vertical (field.seam_columns). */
enum { GS_CUT_FREE = 0, GS_CUT_OLD = 1, GS_CUT_NEW = 2 };
#define GS_CUT_COLUMN (1u << 30)
typedef struct gs_field_cut_scratch {
    int B;
    uint32_t *cap;                /* residual capacity per node and direction */
    int32_t *level, *queue, *path;
    uint8_t *arc;                 /* current arc per node */
} gs_field_cut_scratch;
gs_err gs_field_cut_scratch_init(gs_field_cut_scratch *c, int B);
void gs_field_cut_scratch_free(gs_field_cut_scratch *c);
gs_err gs_field_seam_cut(gs_field_cut_scratch *c, const uint8_t *term, const uint32_t *cost,
                         int columns, uint8_t *take_new);

/* Distance to a torus with major radius R, minor r, centre c, axis a (0..2):
 * the chain mail rings of src/field/shapes.c and src/field/examples.c. */
double gs_field_dist_torus(const double p[3], const double c[3], int axis, double R, double r);

/* Whole objects (synth.c, fibers.c): sample i of an n grid (x fastest) as
 * coordinates; source offsets packed 21 bits an axis; source sample r of an
 * sn grid moved by -o into a tn grid: its index there (t its coordinates),
 * -1 outside. */
static inline void gs_field_coords(int64_t i, const int64_t n[3], int64_t v[3])
{
    v[0] = i % n[0], v[1] = i / n[0] % n[1], v[2] = i / (n[0] * n[1]);
}

#define GS_FIELD_OFF_H ((int64_t)1 << 20)
static inline int64_t gs_field_pack_offset(const int64_t o[3])
{
    return ((o[0] + GS_FIELD_OFF_H) << 42) | ((o[1] + GS_FIELD_OFF_H) << 21) |
           (o[2] + GS_FIELD_OFF_H);
}

static inline void gs_field_unpack_offset(int64_t p, int64_t o[3])
{
    o[0] = (p >> 42) - GS_FIELD_OFF_H;
    o[1] = ((p >> 21) & (2 * GS_FIELD_OFF_H - 1)) - GS_FIELD_OFF_H;
    o[2] = (p & (2 * GS_FIELD_OFF_H - 1)) - GS_FIELD_OFF_H;
}

static inline int64_t gs_field_offset_target(const int64_t sn[3], const int64_t tn[3], int64_t r,
                                             const int64_t o[3], int64_t t[3])
{
    int64_t v[3];
    gs_field_coords(r, sn, v);
    for (int d = 0; d < 3; d++) {
        t[d] = v[d] - o[d];
        if (t[d] < 0 || t[d] >= tn[d])
            return -1;
    }
    return t[0] + tn[0] * (t[1] + tn[1] * t[2]);
}

/* Whole objects (synth.c, fibers.c): the samples of an sn grid within 3
 * (Euclidean) of seeds[0 .. ns), with coordinate along axis in [lo, hi) (axis
 * -1: no such bound), not yet stamped with mark and that keep(r, u) accepts:
 * stamped and appended to out[m ..]; returns the new count. */
int64_t gs_field_near3(const int64_t sn[3], const int64_t *seeds, int64_t ns, int axis,
                       int64_t lo, int64_t hi, uint32_t *stamp, uint32_t mark,
                       int (*keep)(int64_t r, const void *u), const void *u, int64_t *out,
                       int64_t m);

/* field.complete_objects on long objects (src/field/fibers.c): rebuilds
 * target (levels of src, tn samples) from whole fibers of src running along
 * axis, chained slab by slab (slabs S samples thick), guided by prov (the
 * source sample each target sample was copied from; updated where pasted).
 * *completed: parts pasted, *removed: fibers that end inside the output. */
gs_err gs_field_fibers_rebuild(const gs_qfield *src, const int64_t tn[3], uint8_t *target,
                               int32_t *prov, int axis, int64_t S, int64_t *completed,
                               int64_t *removed);

/* Objects of separate-object examples (src/field/report.c): whether q is a
 * height field (every sample of its bottom plane inside), and the objects'
 * mask (*m, n samples per axis): for a height field the columns lower than
 * the mid-range of q's heights (n = {nx, ny, 1}), else the core (deeper than
 * one sample). The layout measure and field.object_spacing read them. */
int gs_field_height_field(const gs_qfield *q);
gs_err gs_field_layout_mask(const gs_qfield *q, int height, uint8_t **m, int64_t n[3]);

#endif
