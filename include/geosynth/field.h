/* field engine core: distance-field geometry synthesis after Lagae, Dumont,
 * Dutré, "Geometry Synthesis" (KU Leuven CW 381, 2004).
 *
 * Conventions (all arrays in this module):
 *  - index order x fastest: v[x + nx*(y + ny*z)]; the same for blocks
 *    (B^3 samples, b[i + B*(j + B*k)]) and for block indices (below);
 *  - distances are signed, negative inside the geometry; spacing is the edge
 *    of one cell in world units, origin the world position of sample (0,0,0);
 *  - quantization maps [lo, hi] linearly onto 0..255 with rounding, values
 *    outside clamp (the paper quantizes to 256 levels); a quantized sample q
 *    stands for lo + q*(hi-lo)/255, and it is "inside" when that is < 0.
 *
 * Source blocks. For block size B (a power of two, 2..32) the candidate
 * blocks of a quantized source of size nx*ny*nz are all B^3 windows at
 * positions p = (px,py,pz), 0 <= p < n - B + 1, overlapping; the block index
 * is px + bx*(py + by*pz) with bx = nx-B+1, by = ny-B+1. Ties in distance
 * are always broken by the lowest block index.
 *
 * Distance (paper eq. 1, without the 1/N^3 factor so it is an exact integer):
 *   dist(q, b) = wk * SSD(known samples) + wu * SSD(unknown samples),
 * SSD = sum of (q[s] - b[s])^2. A query is a B^3 block of quantized samples,
 * an optional "known" mask (NULL = all known) and seed_weight w in 0..256
 * (the weight of unknown samples in 1/256): (wk, wu) = (1, 0) for w = 0
 * (unknown samples ignored), (1, 1) for w = 256 or no mask (the paper's
 * whole block), (256, w) otherwise (an exact integer form of SSD(known) +
 * w/256 * SSD(unknown)). Every lower bound below is multiplied by the
 * weight of its cell: wk for cells whose samples are all known, wu for the
 * others (the minimum weight over the cell, so bounds stay valid and stay
 * monotone under refinement; single samples carry their exact weight).
 *
 * Global pyramid (gs_field_pyramid_*): level m holds, for every position x,
 * the SUM of the 2^m-cube of quantized samples starting at x (kept as exact
 * integers, i.e. the paper's averages times 8^m, so the bounds below are
 * exact). Level m is stored at the stride of the source (positions within
 * 2^m of the upper faces are unused). Block pyramid level k (paper level
 * k+1, 0 = one cell of B^3 samples, log2 B = L = single samples) of the
 * block at p has (2^k)^3 cells of side s = B/2^k = 2^m, m = L-k, and cell
 * (i,j,l) of that level is entry p + s*(i,j,l) of global level m. So one
 * global pyramid serves every overlapping block position exactly; nothing is
 * stored per block.
 *
 * Level lower bound (paper eq. 2): with S the cell sums and c = s^3,
 *   lb_k(q, b) = sum over cells of level k whose samples are all known of
 *                (Sq - Sb)^2 / c  <=  lb_{k+1}  <=  dist(q, b) = lb_L.
 * (Cauchy-Schwarz on the known samples; cells with unknown samples add 0.)
 * The pyramid also holds each cell's spread sqrt(v), v = c*Q - S^2 (Q the
 * sum of squares; v is c times the squared deviations from the cell mean),
 * as a float, and the search adds to each cell the spread term
 * (sqrt(vq) - sqrt(vb))^2 / c: sum (q-s)^2 = (Sq-Sb)^2/c +
 * |dq - ds|^2 >= (Sq-Sb)^2/c + (|dq| - |ds|)^2. It sees random seed samples
 * and coarse copies that cell means cannot (exact for cells where either
 * side is constant), stays monotone under refinement, and is rounded down
 * with a margin over the float's rounding so every comparison stays exact.
 *
 * Search tree (gs_field_tree_*): the blocks' pyramids are revealed in a
 * fixed sequence of steps: steps 0..7 reveal the floor means of octants
 * 0..7 in Morton order (at most 256 values each, so the root has at most
 * 256 children -- the units split over ranks), step 8 the exact sums and
 * spreads of the 8 octants, then each further step refines one cell of
 * level k >= 1 into its 8 cells of level k+1 (levels in order, cells of a
 * level in Morton order; a cell is revealed as (sum, spread)).
 * Octants first (rather than the paper's level-0 mean) keep queries with an
 * unknown octant selective from the first step. Blocks with identical
 * content up to a step share one node (the paper's merging of identical
 * nodes); a node that ends inside a level is one of the paper's extra
 * parents for partially identical nodes, which cut the branching factor;
 * nodes with one child are merged into it (path compression). Leaves are
 * the distinct full-resolution blocks and list every source block index
 * with that content. Nodes refer to the global pyramid through a
 * representative block index; no block data is copied. Each node that ends
 * within the octant floor means (a "trie node") also keeps an octant box:
 * per octant, the range of the octant means and of the octant standard
 * deviations of all blocks below (48 bytes).
 *
 * Best-first search (paper fig. 4): a priority queue of (lower bound, lowest
 * block index below, node, step) in this total order, holding inner nodes.
 * A trie node is queued with the bound of its box (all 8 octants, means and
 * spread terms, for every block below); any other node with the bound of
 * its exact octants (step 8) or, below those, its parent's bound. A popped
 * entry is refined step by step (the incremental distance evaluation of
 * paper 4.4) while it stays at the front. When a node is expanded, its leaf
 * children are not queued but evaluated at once, in the order of their
 * octant bounds, against the best distance found so far: whole-level bounds
 * (levels 2 .. L-2), then the exact distance, given up as soon as a partial
 * sum passes the best. The search ends when the front's bound passes the
 * best (or equals it with a higher lowest index, in the lowest-index tie
 * order): the best is then the exact best match, the lowest index or the
 * lowest tie rank (gs_field_search_opts.tie_key) among equals
 * (src/field/search.c). With a tie key a node whose bound equals the best
 * is still opened (its blocks' ranks are not known before), and a leaf at
 * that bound is dropped when its lowest member rank is above the best's.
 *
 * Costs: pyramid 1 + 8*L bytes per source sample (sums and spreads); tree build O(M log M)
 * block comparisons (M = number of blocks) plus O(n) hashing; tree memory
 * about 24 bytes per node (< 2 per distinct block), 48 bytes per trie node
 * (about one per 5 distinct blocks) + 4 bytes per block.
 * Search workspace per searcher: O(B^3) + the queue.
 */
#ifndef GEOSYNTH_FIELD_H
#define GEOSYNTH_FIELD_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/measure.h"
#include "geosynth/rng.h"

/* ---------------------------------------------------------------- fields */

/* Dense float field. Owns v (nx*ny*nz floats, x fastest). */
typedef struct gs_field {
    int64_t nx, ny, nz;
    double origin[3];
    double spacing;
    float *v;
} gs_field;

/* Creates a zeroed field with origin 0 and spacing 1. Sizes in [1, 4096].
 * Caller frees with gs_field_destroy(). On error *out is unchanged. */
gs_err gs_field_create(int64_t nx, int64_t ny, int64_t nz, gs_field **out);
void gs_field_destroy(gs_field **f);
/* Copy of f cut down to a multiple of mult samples per axis (the low
 * corner kept, same origin and spacing): what a synthesis of log2(mult)+1
 * iterations needs. GS_ERR_ARG when an axis is shorter than mult. */
gs_err gs_field_crop(const gs_field *f, int64_t mult, gs_field **out);

/* Quantized field: 256 levels over [lo, hi]. Owns q (x fastest). */
typedef struct gs_qfield {
    int64_t nx, ny, nz;
    double lo, hi;
    double origin[3];
    double spacing;
    uint8_t *q;
} gs_qfield;

gs_err gs_qfield_create(int64_t nx, int64_t ny, int64_t nz, double lo, double hi,
                        gs_qfield **out);
void gs_qfield_destroy(gs_qfield **q);

/* Quantizes f over [lo, hi] (lo < hi, both finite): round((v-lo)/(hi-lo)*255)
 * clamped to 0..255. NaN samples are an error naming the first index. */
gs_err gs_field_quantize(const gs_field *f, double lo, double hi, gs_qfield **out);
/* Distance value a quantized sample stands for. */
double gs_qfield_value(const gs_qfield *q, uint8_t level);
/* The float field of the quantized values (same geometry). */
gs_err gs_qfield_dequantize(const gs_qfield *q, gs_field **out);
/* Averages factor^3 cubes (factor a power of two dividing every size), rounding
 * to nearest: the paper's subsampling of the source for coarse iterations.
 * Spacing is multiplied by factor. */
gs_err gs_qfield_downsample(const gs_qfield *q, int factor, gs_qfield **out);

/* Analytic test geometry (signed distance, spacing 1, negative inside),
 * n^3 samples. Deterministic in (kind, n, seed). */
typedef enum gs_field_shape {
    GS_FIELD_SPHERES = 0,   /* a few random spheres */
    GS_FIELD_GRID = 1,      /* cylinders along x, y, z on a jittered grid, balls at crossings */
    GS_FIELD_CHAINMAIL = 2, /* rows of tori in alternating orientation, linked */
    GS_FIELD_BALLS = 3      /* many random non-overlapping-ish balls ("dropped balls") */
} gs_field_shape;
gs_err gs_field_make_shape(gs_field_shape kind, int64_t n, uint64_t seed, gs_field **out);
const char *gs_field_shape_name(gs_field_shape kind);

/* ------------------------------------------------------- global pyramid */

typedef struct gs_field_pyramid *gs_field_pyramid_t;

/* Builds levels 0..levels-1 (levels in [1, 6]) of the global sum pyramid of
 * src (see top). The pyramid keeps a pointer to src: src must outlive it and
 * stay unchanged. Cost O(levels * samples). */
gs_err gs_field_pyramid_create(const gs_qfield *src, int levels, gs_field_pyramid_t *out);
void gs_field_pyramid_destroy(gs_field_pyramid_t *p);
/* Sum of the 2^m cube at (x,y,z) (0 <= m < levels, cube inside the field). */
uint32_t gs_field_pyramid_sum(gs_field_pyramid_t p, int m, int64_t x, int64_t y, int64_t z);
/* Bytes held by the pyramid. */
size_t gs_field_pyramid_bytes(gs_field_pyramid_t p);

/* Block pyramid level k of source block `index` for block size B, scaled by
 * 8^L so it is an integer: returns lb_k(query, block) * 8^L (lb_L * 8^L =
 * dist * 8^L). The pyramid needs at least L+1 levels. For tests and tools;
 * the tree computes the same quantities incrementally. */
typedef struct gs_field_query {
    int block;               /* B, power of two in [2, 32] */
    const uint8_t *values;   /* B^3 quantized samples, x fastest */
    const uint8_t *known;    /* B^3 flags, nonzero = known; NULL = all known */
    int seed_weight;         /* 0..256: weight of unknown samples in 1/256 (see top) */
} gs_field_query;
/* The (wk, wu) weights of a query (see top). */
void gs_field_query_weights(const gs_field_query *q, uint64_t *wk, uint64_t *wu);
/* Number of known samples of a query (B^3 without a mask). */
int64_t gs_field_query_known(const gs_field_query *q);
gs_err gs_field_level_bound(gs_field_pyramid_t p, int64_t index, const gs_field_query *q,
                            int level, uint64_t *out);

/* Number of candidate blocks of size B in src (0 when B exceeds a size). */
int64_t gs_field_block_count(const gs_qfield *src, int block);
/* Position of block `index`. */
void gs_field_block_position(const gs_qfield *src, int block, int64_t index, int64_t pos[3]);
/* Copies block `index` into out[B^3]. */
void gs_field_block_copy(const gs_qfield *src, int block, int64_t index, uint8_t *out);
/* Copies the B^3 samples of f starting at sample pos (x, y, z) into out. */
void gs_qfield_block_at(const gs_qfield *f, int block, const int64_t pos[3], uint8_t *out);
/* dist(q, block index) as defined at top. */
uint64_t gs_field_block_distance(const gs_qfield *src, int64_t index, const gs_field_query *q);

/* ------------------------------------------------------------ matching */

typedef struct gs_field_match {
    int found;          /* 0: nothing within the bound */
    int64_t index;      /* best source block index (among equals: the lowest, or the
                           lowest tie rank of opts->tie_key) */
    uint64_t dist;      /* its distance (weighted sum of squared differences, see top) */
    int64_t known;      /* number of known query samples */
    uint64_t pops;      /* queue entries popped and leaves evaluated (tree) / blocks scanned (brute) */
    uint64_t pushes;    /* queue entries pushed (tree) */
    uint64_t refinements; /* bounds evaluated (tree): refinement steps, nodes opened,
                             whole-level leaf bounds and leaf completions */
    size_t queue_peak;  /* largest queue size (tree) */
    int truncated;      /* tree search stopped at opts->max_pops: no answer */
} gs_field_match;

/* Reference: linear scan over blocks [begin, end) of src in index order,
 * keeping the first block with the smallest distance (the lowest index
 * among equals). Blocks whose distance exceeds *bound are ignored; on
 * return *bound = min(*bound, best). */
gs_err gs_field_brute_search(const gs_qfield *src, const gs_field_query *q, int64_t begin,
                             int64_t end, uint64_t *bound, gs_field_match *out);
/* The same, skipping the blocks whose position lies in one of nexclude
 * boxes {lo x, lo y, lo z, hi x, hi y, hi z} (inclusive): the reference for
 * gs_field_search_opts.exclude. */
gs_err gs_field_brute_search_excluding(const gs_qfield *src, const gs_field_query *q,
                                       const int64_t (*exclude)[6], int nexclude, int64_t begin,
                                       int64_t end, uint64_t *bound, gs_field_match *out);
/* The same with ties in the order of tie_key (gs_field_tie_rank): the
 * reference for gs_field_search_opts.tie_key. */
gs_err gs_field_brute_search_keyed(const gs_qfield *src, const gs_field_query *q,
                                   const int64_t (*exclude)[6], int nexclude, uint64_t tie_key,
                                   int64_t begin, int64_t end, uint64_t *bound,
                                   gs_field_match *out);
/* The same with ties in the order of tie_class, then tie_key
 * (gs_field_tie_rank_of; tie_class NULL: as _keyed). */
gs_err gs_field_brute_search_classed(const gs_qfield *src, const gs_field_query *q,
                                     const int64_t (*exclude)[6], int nexclude, uint64_t tie_key,
                                     const uint8_t *tie_class, int64_t begin, int64_t end,
                                     uint64_t *bound, gs_field_match *out);
/* The same under opts' exclude, exclude_mask, tie_key and tie_class (the
 * rest of opts is ignored; opts may be NULL): the reference for the tree
 * search with every exclusion and tie order. */
struct gs_field_search_opts;
gs_err gs_field_brute_search_opts(const gs_qfield *src, const gs_field_query *q,
                                  const struct gs_field_search_opts *opts, int64_t begin,
                                  int64_t end, uint64_t *bound, gs_field_match *out);

typedef struct gs_field_tree *gs_field_tree_t;

typedef struct gs_field_tree_info {
    int block, levels;              /* B and L+1 */
    int64_t blocks;                 /* candidate blocks M */
    int64_t distinct;               /* distinct blocks = leaves */
    int64_t nodes;                  /* all nodes incl. leaves and root */
    int64_t top;                    /* top-level subtrees (see search) */
    int64_t level_full[7];          /* nodes ending exactly at pyramid level k (k = 0..L) */
    int64_t level_partial[7];       /* extra parents ending inside the refinement to level k
                                       (level 1 includes the octant floor-mean steps) */
    int64_t steps;                  /* refinement steps from root to leaf */
    int source_step_max;            /* largest |difference| of 6-neighbours in the source */
    size_t tree_bytes;              /* nodes + member lists */
    size_t pyramid_bytes;           /* the global pyramid */
    double build_seconds;           /* pyramid + hashing + sorting + linking */
    double pyramid_seconds, dedup_seconds, sort_seconds;
} gs_field_tree_info;

/* Builds the search tree of all blocks of size B (power of two, 2..32) in src
 * (at most 2^31 blocks). Keeps a pointer to src: src must outlive the tree.
 * Caller frees with gs_field_tree_destroy(). On error *out is unchanged. */
gs_err gs_field_tree_build(const gs_qfield *src, int block, gs_field_tree_t *out);
/* Slab tree: the tree of the blocks of src whose z position is in [z0, z1)
 * (0 <= z0 < z1 <= nz - B + 1), built on a private copy of the samples they
 * cover (z0 .. z1 + B - 2), so its pyramid and nodes hold only that share of
 * the source. Searches report global block indices of src; distances are
 * those of the whole tree, and reducing the answers of slabs that split
 * [0, nz - B + 1) in (dist, index) order gives the whole tree's answer. The
 * copy is counted in info.tree_bytes.
 * Slabs are how the engine spreads the tree over ranks so that memory per
 * rank falls with the rank count (field.tree = sharded). */
gs_err gs_field_tree_build_slab(const gs_qfield *src, int block, int64_t z0, int64_t z1,
                                gs_field_tree_t *out);
/* Shard `shard` of `shards` (> 1): the slab of its share of the z positions
 * (gs_partition, by count); *out = NULL when that share is empty (more
 * shards than positions). shards <= 1: the whole tree. */
gs_err gs_field_tree_build_shard(const gs_qfield *src, int block, int shards, int shard,
                                 gs_field_tree_t *out);
void gs_field_tree_destroy(gs_field_tree_t *t);
void gs_field_tree_get_info(gs_field_tree_t t, gs_field_tree_info *info);
int gs_field_tree_block(gs_field_tree_t t);

/* Top-level subtrees: the children of the root (the root itself when all
 * blocks are identical), numbered 0..top-1 in content order. They are the
 * units to split over MPI ranks; gs_field_tree_top_blocks gives the number
 * of source blocks under each (for balancing). */
int64_t gs_field_tree_top_count(gs_field_tree_t t);
int64_t gs_field_tree_top_blocks(gs_field_tree_t t, int64_t top);

/* Searcher: per-thread query workspace (query pyramid, queue). */
typedef struct gs_field_searcher *gs_field_searcher_t;
gs_err gs_field_searcher_create(gs_field_tree_t t, gs_field_searcher_t *out);
void gs_field_searcher_destroy(gs_field_searcher_t *s);

typedef struct gs_field_search_opts {
    /* Queue pruning with an upper bound (paper eq. 3): for a cell of side s
     * whose samples differ from their mean by at most d, dist over the cell
     * <= (Sq-Sb)^2/c + c*(dq+db)^2, and d <= 3(s-1)*K where K is the largest
     * difference of 6-neighbours. The paper takes K from the source and
     * assumes the query is a distance field too, which is false while the
     * query holds random seed samples; here K is measured on the source and
     * on the query separately, so the bound is always valid (with random
     * seeds it is merely too loose to prune). Applied only to fully known
     * queries. Results are identical with or without it. It is applied when
     * a node past the octant steps is expanded, which the tree as built
     * never asks for (leaves are completed as their parent trie node is
     * expanded), so it never prunes: the synthesis prunes with start_bound
     * instead (field.upper_bound, src/field/synth.c candidate_bound). */
    int use_upper_bound;
    /* > 0: an upper bound on the best distance known before the search (the
     * exact distance of a candidate block in the tree, e.g. the continuation
     * of the neighbouring block's match): subtrees whose lower bound passes
     * it are dropped from the start. The answer is the same (ties still go by
     * tie_key: blocks at exactly this distance are kept); a search
     * over part of the tree that holds no block within it finds nothing. */
    uint64_t start_bound;
    /* Called every poll_every pops (when poll != NULL) with the shared bound;
     * it may lower *bound (e.g. to the best distance other ranks found). */
    void (*poll)(void *ctx, uint64_t *bound);
    void *poll_ctx;
    uint64_t poll_every;
    /* > 0: give up after this many pops (out->truncated = 1, out->found = 0).
     * Deterministic: the same query on the same tree stops at the same pop,
     * so every rank can try a query locally and agree, without talking,
     * whether to spread it over the ranks (src/field/engine_match.c). */
    uint64_t max_pops;
    /* Source block positions no match may take: nexclude boxes {lo x, lo y,
     * lo z, hi x, hi y, hi z} (inclusive, block positions of the searched
     * source). The cost there is infinite, nothing else changes: the answer is
     * the exact best of the other blocks, ties by tie_key, as
     * gs_field_brute_search_keyed finds it. start_bound must then be the
     * distance of a block that is not excluded. The synthesis uses it to end
     * a copy that has grown too large (field.copy_limit, src/field/synth.c). */
    const int64_t (*exclude)[6];
    int nexclude;
    /* Tie order among blocks at the same distance (gs_field_tie_rank): 0 =
     * the lowest index (the quality measure); otherwise the lowest rank of
     * a hash of (tie_key, index), so that exact ties (a periodic source,
     * flat or empty regions, blocks that differ only where the query is
     * unknown) go to a block chosen at random per key, not to the one
     * nearest the source's start. The synthesis keys it by the seed, the
     * iteration and the target block (src/field/synth.c match_block). The
     * answer is still an exact best: only which of the equals differs. */
    uint64_t tie_key;
    /* Optional, one per block index (global): a class that goes before the
     * tie_key order among blocks at the same distance (the lowest class
     * first; gs_field_tie_rank_of). Blocks of equal content must share a
     * class. The synthesis' field.keep_volume gives exact ties to the blocks
     * that bring the volume fraction toward the source's (src/field/synth.c).
     * NULL: the tie_key order alone. */
    const uint8_t *tie_class;
    /* Optional, one per block index (global): 1 = no match may take this
     * block (as if it lay in an exclude box). The cost there is infinite,
     * nothing else changes: the answer is the exact best of the other
     * blocks (gs_field_brute_search_opts is the reference). The synthesis'
     * field.object_spacing excludes with it the blocks that would put an
     * object too close to one already in the output (src/field/synth.c).
     * NULL: none. */
    const uint8_t *exclude_mask;
} gs_field_search_opts;

/* Rank of block `index` (< 2^32) in the tie order of tie_key: the index
 * itself for tie_key 0, else a 31-bit hash of (tie_key, index) above the
 * index (bits 32-62), so ranks are distinct, below 2^63 (they reduce as
 * int64 across ranks) and gs_field_tie_index gives the index back. A match
 * is the lowest (dist, rank) pair: a total order, so disjoint parts of the
 * tree reduced in it give the whole tree's answer. */
uint64_t gs_field_tie_rank(uint64_t tie_key, int64_t index);
/* The tie rank under o: gs_field_tie_rank(o->tie_key, index) without
 * o->tie_class, else the class (bits 55-62) above 23 bits of the tie_key
 * hash (bits 32-54) above the index. */
uint64_t gs_field_tie_rank_of(const gs_field_search_opts *o, int64_t index);
static inline int64_t gs_field_tie_index(uint64_t rank)
{
    return (int64_t)(rank & 0xffffffffu);
}

/* Exact best match of q among the blocks under top-level subtrees
 * [top_begin, top_end), considering only distances <= *bound (pass
 * UINT64_MAX for none). Pruning is strictly "lower bound > *bound", so
 * candidates tied with the bound survive; on return *bound = min(*bound,
 * best found, upper bounds met). out->found = 0 when no block is within the
 * bound. Reducing the (dist, gs_field_tie_rank(opts->tie_key, index)) pairs
 * of disjoint ranges in lexicographic order gives exactly the answer of the
 * whole range, for any
 * split and any exchange of bounds between ranges: this is the contract the
 * MPI layer builds on. opts may be NULL. */
gs_err gs_field_tree_search(gs_field_searcher_t s, int64_t top_begin, int64_t top_end,
                            const gs_field_query *q, const gs_field_search_opts *opts,
                            uint64_t *bound, gs_field_match *out);
/* Whole tree, no bound. */
gs_err gs_field_tree_best_match(gs_field_searcher_t s, const gs_field_query *q,
                                const gs_field_search_opts *opts, gs_field_match *out);

/* ----------------------------------------------------------- synthesis */

#define GS_FIELD_MAX_ITER 6

typedef struct gs_field_synth_config {
    int iterations;                  /* 1..GS_FIELD_MAX_ITER (paper: 3) */
    int64_t target[3];               /* final target size; each divisible by 2^(iterations-1) */
    int block[GS_FIELD_MAX_ITER];    /* block size per iteration, coarse to fine (paper: last 16) */
    uint64_t seed;                   /* seeds the random source samples of iteration 0 and, with
                                        mask_unsynthesized, the random source block a block
                                        with nothing synthesized around it takes */
    int mask_unsynthesized;          /* 0 (paper): match whole blocks, the random seeds of
                                        iteration 0 at weight GS_FIELD_PAPER_SEED_WEIGHT
                                        (src/field/field_impl.h), later the coarse result fully;
                                        1: unsynthesized samples are unknown in the query,
                                        weighted by seed_weight */
    int seed_weight;                 /* 0..256 (1/256): weight of the unsynthesized samples
                                        (random seeds, coarse result) in masked matching, see
                                        gs_field_query; 0 = ignored (copies the source almost
                                        verbatim), 256 = the paper's whole block */
    int coarse_weight;               /* 0..256 (1/256): weight of the unsynthesized samples of
                                        iterations >= 1 (the upsampled coarse result) in masked
                                        matching; 256 = as much as the synthesized ones (the
                                        paper: the coarse result weighs in every match) */
    int seed_blocks;                 /* 1: iteration 0 seeds the target with random source
                                        blocks (tiles of block[0]) instead of random samples */
    int use_upper_bound;             /* queue pruning, see gs_field_search_opts */
    double copy_limit;               /* > 0: no copy of one source offset grows past this share
                                        of the source's samples (its bounding box, at each
                                        iteration's resolution): the continuation of such a
                                        neighbour's offset (+- block/4 positions) is excluded
                                        from the match (src/field/synth.c); 0 = the paper (off) */
    int copy_limit_reach;            /* >= 1: the continuation excluded by copy_limit is
                                        +- this many positions instead of +- block/4 */
    int blend;                       /* > 0 (needs prov): after the last iteration every
                                        sample within `blend` samples of a seam (a neighbour
                                        copied from another source offset) becomes the mean of
                                        the source continued by each offset of its
                                        (2*blend+1)^3 neighbourhood (overlap blending, paper
                                        5.3); 0 = off (the paper) */
    int repeat_reach;                /* > 0: in the last iteration a block may not take a
                                        source block within this many positions (each axis)
                                        of one a lower neighbour took (the same source block
                                        again a stride on); < block/2; 0 = off (the paper) */
    int repeat_span;                 /* > 0 (with repeat_reach): in every iteration a block
                                        may not take a source block within the level's reach
                                        (repeat_reach halved per coarser level) of a feature
                                        block (relief at or above the median) taken by a
                                        block b + d, d in [-repeat_span, repeat_span]^3, that
                                        is matched before b in every order and does not
                                        overlap b, while half the source stays free
                                        (src/field/synth.c repeat_span_exclusions); 0 = off */
    int repeat_pairs;                /* > 0: in every iteration a block may not take, next
                                        to a lower neighbour, a source block within this
                                        many positions (halved per coarser level) of the
                                        one an earlier block took next to a neighbour (the
                                        same direction) whose source block lies within as
                                        many of that lower neighbour's: no two-block
                                        composite recurs; 0 = off */
    double repeat_free;              /* the share of the source blocks repeat_span and
                                        repeat_pairs leave free (0.05-1; 0 = 0.5, the
                                        share before it was a setting) */
    int height_match;                /* bits, height-field examples only: 1 = the coarse
                                        result, before it guides the next iteration, 2 = the
                                        result of the last iteration (after the blend and the
                                        seam correction, in the output phase:
                                        gs_field_synth_height_match), has its column heights mapped onto
                                        the level source's height distribution (rank for
                                        rank; each column shifted along z: src/field/synth.c
                                        height_match); 0 = off (the paper) */
    int seam_gradient;               /* 1 (needs prov): after the blend, a screened Poisson
                                        correction makes the steps across seams the mean of
                                        the two pieces' own steps there (src/field/synth.c
                                        seam_gradient); 0 = off (the paper) */
    int seam_cut;                    /* 1: a block takes the samples of its box that a
                                        minimum cut between the old content and the new
                                        block gives it, not only the unsynthesized ones
                                        (min-error boundary cut in 3D, src/field/synth.c
                                        cut_block); with target regions the same at any
                                        rank count; 0 = off (the paper) */
    int seam_columns;                /* with seam_cut: the cut keeps every column (x, y)
                                        of a block whole (a height field's objects are
                                        columns: a cut between them in z left discs of
                                        mixed columns); 0 = the 3D cut */
    int complete_objects;            /* 1 (needs prov): after the last iteration (and the
                                        blend), when most of the source's core (samples deeper
                                        than one sample) is in whole objects (core components
                                        touching none of its faces), the output is rebuilt
                                        from them: each core component of the target is
                                        replaced by the whole source object its samples were
                                        mostly copied from, at that offset; an example of long
                                        objects (fibers: most of the inside runs through along
                                        one axis) is rebuilt as tracks of whole source fibers,
                                        slab by slab along that axis (see src/field/fibers.c);
                                        0 = off (the paper) */
    int keep_volume;                 /* 1: exact ties of a match go to the blocks that bring
                                        the synthesized samples' volume fraction toward the
                                        level source's (the most inside first while the
                                        target is short of it, else the fewest; then the
                                        tie_key order); with target regions the volume
                                        a region's block reads is its box's plus the samples
                                        outside every box of its colour (src/field/synth.c
                                        region_volume: the same for any rank count). 0 = off */
    double object_spacing;           /* > 0 (needs prov, raster order): in the last iteration
                                        a block may not take a source block that would put a
                                        source object (gs_field_layout_mask's components) whose
                                        samples reach the block's unsynthesized box at a centre
                                        between a quarter and this share of the source's
                                        smallest centre spacing from one already in the target
                                        (centres read through prov); exact best of the rest,
                                        while an eighth of the source stays free
                                        (src/field/synth.c object_exclusions); 0 = off (the
                                        paper) */
    double object_same;              /* with object_spacing: centres nearer than this share of
                                        the spacing count as the same object continued (not
                                        excluded); in (0, 1), 0 = 0.25 (field.object_same's
                                        default) */
    int object_continue;             /* with object_spacing: a block may only take a source
                                        block that continues every target object reaching its
                                        unsynthesized box (one of the source's objects within
                                        object_same of its centre), while one outside the
                                        exclusions does (src/field/synth.c object_continue);
                                        nothing without object_spacing */
    int wrap;                        /* bit a set: the source is periodic along axis a (a
                                        tile): each iteration's source is continued by
                                        block - 1 samples of itself past its high face, so
                                        source blocks wrap around and every source sample
                                        lies in as many blocks; prov stays within the
                                        source. 0 = off (the paper: blocks inside it) */
    int tree_shards, tree_shard;     /* > 1: this synthesis holds only slab tree_shard
                                        (0-based) of tree_shards z-slabs of each iteration's
                                        tree (gs_field_tree_build_shard, split by count; shards
                                        beyond the z positions hold none, tree NULL). Needs a
                                        match hook that combines the shards' answers; the
                                        region functions are refused. 0 or 1: whole tree */
    int region_blocks;               /* target regions (see below): block positions per region
                                        along each axis, >= 2; 0 = one region, the paper's
                                        raster order */
    int32_t *prov;                   /* optional, final target size: the source sample each
                                        sample of the last iteration was copied from (-1: none);
                                        owned by the caller, kept across resume by the caller */
    /* Optional (NULL = local search): called for every block that
     * gs_field_synth_run synthesizes (not by the region functions) instead of
     * gs_field_tree_best_match(searcher, q, opts, out), with the iteration
     * and its tree. It must give exactly that answer (found, index, dist,
     * known); the engine (src/field/engine_match.c) uses it to spread the search
     * over MPI ranks. */
    gs_err (*match)(void *ctx, gs_field_tree_t tree, gs_field_searcher_t searcher, int iteration,
                    const gs_field_query *q, const gs_field_search_opts *opts,
                    gs_field_match *out);
    void *match_ctx;
} gs_field_synth_config;

/* Paper setting: 3 iterations, blocks 8, 8, 16, target = 2x source size. */
void gs_field_synth_config_default(gs_field_synth_config *c, const gs_qfield *src);

/* Everything needed to resume a synthesis exactly (with the same source and
 * config): the checkpoint writes these fields and gs_field_synth_resume()
 * takes them back. target/mask are owned by the synthesis. */
typedef struct gs_field_synth_state {
    int iteration;                   /* current iteration (== iterations: finished) */
    int64_t cursor;                  /* next block of the iteration's visit order */
    int64_t blocks_in_iteration;     /* length of the visit order */
    int64_t tn[3];                   /* current target size */
    uint8_t *target;                 /* tn[0]*tn[1]*tn[2] quantized samples */
    uint8_t *mask;                   /* 1 = synthesized in this iteration */
    int64_t *matches;                /* per block position of the iteration: matched source
                                        block + 1 (0 = not yet); blocks_in_iteration entries,
                                        read for [0, cursor) of the visit order on resume
                                        (copy_limit needs them) */
    /* per-block match statistics of each iteration (normalized distance =
     * dist / known samples, in squared quantization levels) */
    int64_t stat_count[GS_FIELD_MAX_ITER];
    double stat_sum[GS_FIELD_MAX_ITER];
    double stat_min[GS_FIELD_MAX_ITER];
    double stat_max[GS_FIELD_MAX_ITER];
    uint64_t stat_pops[GS_FIELD_MAX_ITER];
    uint64_t stat_pushes[GS_FIELD_MAX_ITER];
    /* after iteration 0: copied samples whose sign (inside/outside) differs
     * from the upsampled coarse result they replace, and the copied samples
     * (how closely the coarse iterations guide the finer ones) */
    uint64_t stat_coarse_flips[GS_FIELD_MAX_ITER];
    uint64_t stat_coarse_n[GS_FIELD_MAX_ITER];
    /* gs_field_synth_complete_objects (run by the output phase, after the
     * synthesis, so not checkpointed): source objects pasted, target objects
     * left out (no whole source object, or on an object already pasted) */
    int64_t objects_completed, objects_removed;
} gs_field_synth_state;

typedef struct gs_field_synth *gs_field_synth_t;

/* Validates the config (errors name the key: "field.block[2] = 12: expected
 * a power of two in [2, 32] not larger than the source at that iteration")
 * and seeds iteration 0. src must outlive the synthesis. */
gs_err gs_field_synth_create(const gs_qfield *src, const gs_field_synth_config *c,
                             gs_field_synth_t *out);
/* Recreates a synthesis from a saved state (copied). */
gs_err gs_field_synth_resume(const gs_qfield *src, const gs_field_synth_config *c,
                             const gs_field_synth_state *st, gs_field_synth_t *out);
void gs_field_synth_destroy(gs_field_synth_t *s);
/* Synthesizes up to max_blocks blocks (< 0: until finished), crossing
 * iterations as needed. *finished = 1 when the last iteration is complete. */
gs_err gs_field_synth_run(gs_field_synth_t s, int64_t max_blocks, int *finished);
/* Current state (pointers into the synthesis; valid until the next run). */
const gs_field_synth_state *gs_field_synth_get_state(gs_field_synth_t s);
/* Copy of the final (or current) target as a quantized field with the
 * source's range, spacing and origin 0. */
gs_err gs_field_synth_result(gs_field_synth_t s, gs_qfield **out);
/* The same values once the synthesis is finished, without a copy: the
 * target is handed over to *out and the mask freed (memory of the output
 * phase: 2 bytes a sample less). Afterwards the synthesis keeps only its
 * statistics (get_state's target and mask are NULL): it can be destroyed,
 * not run, checkpointed or asked for its result again (GS_ERR_ARG). */
gs_err gs_field_synth_take_result(gs_field_synth_t s, gs_qfield **out);
/* field.complete_objects (cfg.complete_objects and cfg.prov given) once the
 * synthesis is finished: rebuilds the target from the source's whole objects
 * (src/field/synth.c), the same on every rank. *before receives the
 * synthesized target as it was (gs_field_synth_result's form), so that what
 * the synthesis itself did can still be measured; NULL when nothing was
 * rebuilt (the option off, an example not of separate objects, or called
 * before). Not part of the checkpointed state: a run resumed after the
 * synthesis rebuilds in its output phase as one that was not stopped. */
gs_err gs_field_synth_complete_objects(gs_field_synth_t s, gs_qfield **before);
/* cfg.height_match's last step (bit 2) once the synthesis is finished: the
 * result's column heights mapped onto the level source's (src/field/synth.c
 * height_match), the same on every rank. *before receives the target as the
 * synthesis made it (gs_field_synth_result's form): a monotone remap of the
 * heights moves every column along z, so the output's levels no longer
 * equal the source's where a piece was copied verbatim and the copy measure
 * reads the synthesis from *before (#19: "measures that cannot be fooled").
 * NULL when nothing was matched (bit 2 off, or called before). Not part of
 * the checkpointed state, as gs_field_synth_complete_objects. */
gs_err gs_field_synth_height_match(gs_field_synth_t s, gs_qfield **before);

/* Target regions (DESIGN.md). With region_blocks = R > 0 an iteration's block
 * positions (a grid of npos[0] x npos[1] x npos[2], stride B/2) are cut into
 * regions of R x R x R positions (a last region of fewer than 3 positions
 * joins the one before). Region (rx, ry, rz) has id rx + nrx * (ry + nry *
 * rz) and color rx + ry + rz (a wavefront). Its blocks cover the sample box
 * [lo, hi); it synthesizes its core, the box without the B/2 samples at its
 * low faces, which its lower neighbours synthesized: the cores tile the
 * target and a region reads only its own core and lower-colored ones. The
 * visit order is: colors ascending, regions of a color by id, blocks of a
 * region in raster order (x fastest). It gives exactly the result of the
 * raster order over the whole target (R = 0, the paper's), see
 * src/field/synth.c. One color's regions never read what another writes, so
 * they may be computed in any order or in parallel
 * (gs_field_synth_region_run on a private copy of the region's box) and
 * then applied in id order (gs_field_synth_region_apply), with exactly the
 * result of gs_field_synth_run. */
typedef struct gs_field_region {
    int64_t id;                      /* gs_regions_grid id in this iteration */
    int color;
    int64_t first, count;            /* its blocks: order[first .. first+count) */
    int64_t lo[3], hi[3];            /* sample box of its blocks, [lo, hi) */
} gs_field_region;

/* The color that the cursor is in: cursor range [*begin, *end) and its
 * regions reg[*first_region .. + *nregions) (the array stays valid until the
 * iteration changes). Advances to the next iteration first when the cursor
 * is at the end of one. *finished = 1 (and nothing else set) at the end. */
gs_err gs_field_synth_color(gs_field_synth_t s, int64_t *begin, int64_t *end,
                            const gs_field_region **regions, int64_t *first_region,
                            int64_t *nregions, int *finished);
/* The current iteration's (slab) tree, NULL when finished or when this
 * shard has no blocks. For reports. */
gs_field_tree_t gs_field_synth_tree(gs_field_synth_t s);
/* Bytes of a region's result. */
size_t gs_field_synth_region_bytes(gs_field_synth_t s, int64_t region);
/* Synthesizes region `region` of the current iteration on a private copy of
 * its box (the synthesis state is not modified) and writes its result (one
 * record per block, gs_field_synth_region_bytes) to out. Local search only
 * (the config's match hook is not called). */
gs_err gs_field_synth_region_run(gs_field_synth_t s, int64_t region, void *out);
/* Applies a region's result: the cursor must be at the region's first block
 * (regions are applied in visit order); advances it past the region. */
gs_err gs_field_synth_region_apply(gs_field_synth_t s, int64_t region, const void *buf, size_t len);

/* Quality metrics of an output against its source. */
typedef struct gs_field_quality {
    double volume_fraction_out, volume_fraction_src;      /* share of inside samples */
    double surface_per_volume_out, surface_per_volume_src; /* sign changes between 6-neighbours
                                                              per sample / spacing (area per volume) */
    double coherence;        /* mean over output blocks (grid of stride B) of the
                                normalized distance to the nearest source block: over
                                every block up to GS_FIELD_COHERENCE_BLOCKS, else over
                                whole rows of blocks along x, the first in the order of
                                a fixed hash of the row number until that many blocks */
    int64_t coherence_blocks;      /* blocks it is the mean over */
    int64_t coherence_grid_blocks; /* blocks of the grid */
    double coherence_stderr; /* the sample's standard error of that mean (sample
                                standard deviation / sqrt(blocks) times the finite
                                population factor sqrt(1 - blocks / grid blocks)); 0
                                when every block was searched. Grid 256^3 (4096 blocks,
                                1024 searched): error 0.44 of 50.18, 0.5 stderr */
    double verbatim;         /* share of all the grid's blocks that exist exactly in the
                                source (every block looked up exactly, no sample) */
    int64_t longest_run;     /* longest run of verbatim blocks along x whose source blocks
                                are consecutive too (a copied slab), in blocks */
} gs_field_quality;
/* Coherence searches at most this many output blocks (about 1/3 of the
 * synthesis' CPU at grid 256^3 when all 4096 were searched, 1/8 at 512^3). */
#define GS_FIELD_COHERENCE_BLOCKS 1024
/* tree: built on src with the block size to measure coherence with. */
gs_err gs_field_quality_measure(const gs_qfield *out, const gs_qfield *src, gs_field_tree_t tree,
                                gs_field_quality *q);
/* The same with any exact matcher of blocks of size B on src (global block
 * indices), e.g. slab trees on several ranks combined (src/field/engine_match.c);
 * every rank of such a matcher calls it. */
gs_err gs_field_quality_measure_with(const gs_qfield *out, const gs_qfield *src, int B,
                                     gs_err (*match)(void *ctx, const gs_field_query *q,
                                                     gs_field_match *m),
                                     void *ctx, gs_field_quality *qm);

/* Measures of the geometry of an output against its source, from the two
 * quantized fields alone (src/field/report.c): copying (gs_measure_copy3 with
 * windows of GS_FIELD_COPY_WINDOW^3, regions larger than one block of B^3
 * counted as large, completeness over source cells of B^3), the inside
 * components (face-connected inside samples, gs_measure_components3; those
 * touching a face of the grid are left out, in the output and the source
 * alike, as the box may cut them) and the
 * steps between 6-neighbours (a distance field changes by at most one sample
 * between neighbours; steps above 1.5 samples are violations). */
#define GS_FIELD_COPY_WINDOW 4
typedef struct gs_field_geometry_report {
    gs_measure_copy copy;
    int64_t components_out, components_src;
    double components_per_msample_out, components_per_msample_src; /* per 10^6 samples */
    double component_median_out, component_median_src;             /* samples */
    double component_size_ks;        /* KS distance of the two size distributions */
    double fragment_share_out, fragment_share_src; /* share of components smaller than a
                                                      quarter of the source's median */
    /* topology of the same interior components (rings: #19 item 3): handles
     * = 1 - Euler characteristic (gs_measure_component_euler3; a whole ring
     * 1, an arc or a ball 0, g rings that touch g or more). genus_*[k]:
     * components with k handles (k = 0..3), [4]: 4 or more; ring_share: the
     * share of components with a handle (whole rings, alone or touching);
     * open_per_msample: components without one (arcs, short pieces, balls) per
     * 10^6 samples; handles_per_kinside: their handles per 1000 of their
     * inside samples (a ring cut into arcs loses its handle, an arc grown on
     * a ring adds samples, not handles); handles_all_per_kinside: the same
     * over every inside component, those at the faces too */
    int64_t genus_out[5], genus_src[5];
    double ring_share_out, ring_share_src;
    double open_per_msample_out, open_per_msample_src;
    double handles_per_kinside_out, handles_per_kinside_src;
    double handles_all_per_kinside_out, handles_all_per_kinside_src;
    double step_violations_out, step_violations_src; /* share of 6-neighbour pairs whose
                                                        values differ by > 1.5 samples */
    /* largest inscribed spheres (objects that touch each other, as balls in a
     * pile, or the box, as fibers, have them too): the inside samples at
     * least one sample from the grid's faces whose distance to the nearest
     * outside sample (exact Euclidean distance transform of the inside, not
     * clipped by the quantization band) is a maximum over their 26
     * neighbours (a ball's centre, a fiber's axis), in samples: quantiles
     * and the KS distance of the two distributions */
    int64_t inscribed_out, inscribed_src;
    double inscribed_p10_out, inscribed_p50_out, inscribed_p90_out;
    double inscribed_p10_src, inscribed_p50_src, inscribed_p90_src;
    double inscribed_ks;
    /* objects that run through (fibers): the grid cut into slabs of
     * crossing_slab samples (half the source's smallest side) along each
     * axis, the share of the inside samples of whole slabs in components
     * (within their slab) that reach both of its faces along that axis; the
     * axis with the largest share of the source, output and source measured
     * along it. A fiber cut where pieces meet ends inside a slab. */
    int crossing_axis;
    int64_t crossing_slab;
    double crossing_share_out, crossing_share_src;
    /* seams (analysis/field_seams.py's seam_ratio, the same figure): the
     * last iteration copies blocks at a stride of seam_period = B/2 samples,
     * so its pieces meet between samples i and i + 1 with i % seam_period ==
     * seam_period - 1 along each axis; the mean |level step| of neighbours
     * across those planes over the mean across all others (1: no seams, a
     * rectangular patchwork well above 1), over the axes of the output
     * longer than 2 seam_period samples (seam_axes, bit a = axis a: a slab
     * one block deep has no seams across it). The source has no pieces: its
     * largest ratio over the seam_period phases, on the same axes, is how
     * far chance goes. */
    int seam_period, seam_axes;
    double seam_ratio_out, seam_ratio_src_max;
    /* layout of separate objects (gs_measure_object_layout, fused = 1.5;
     * analysis/field_layout.py): for a height field (every sample of the
     * source's bottom plane inside: layout_height_field = 1) the objects are
     * the 4-connected components of the columns whose height (the inside
     * extent along z, sum of clip(0.5 - d, 0, 1), d in samples) is below the
     * mid-range of that map's heights (texture.ini's discs), else the
     * 6-connected components of the core (deeper than one sample: balls that
     * touch are apart there, as for field.complete_objects) */
    int layout_height_field;
    gs_measure_objlayout layout;
    double seconds;
} gs_field_geometry_report;
gs_err gs_field_geometry_measure(const gs_qfield *out, const gs_qfield *src, int B,
                                 gs_field_geometry_report *r);
/* ratio[p] for p < period (<= GS_FIELD_SEAM_PERIOD_MAX): the mean |level
 * step| between 6-neighbours i, i + 1 with i % period == p along the axes
 * in the bit mask axes (bit a: axis a) over the mean of the other steps
 * along them (gs_field_geometry_report's seams); the axes where pieces
 * meet: those longer than 2 periods (gs_field_seam_axes). */
#define GS_FIELD_SEAM_PERIOD_MAX 32
int gs_field_seam_axes(const gs_qfield *q, int period);
void gs_field_seam_ratios(const gs_qfield *q, int period, int axes, double *ratio);
/* The step share of a float field in units of spacing (any field). */
double gs_field_step_violations(const float *v, const int64_t n[3], double spacing, double limit);

#endif
