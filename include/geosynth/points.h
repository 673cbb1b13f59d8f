/* points engine core: patch-based synthesis of geometry textures on
 * point-set surfaces (Duranleau and Poulin, "Patch-based Synthesis of
 * Geometry Textures with Point-set Surfaces",
 * docs/ARCHITECTURE.md).
 *
 * Pure C, no MPI and no file I/O: the CLI, checkpoints and the distributed
 * search runtime call into this module.
 *
 * Conventions
 *  - Positions and normals are double (the output digest is over doubles;
 *    the search fields are float, as in the paper).
 *  - The reference plane is z = const: a texture's box is axis-aligned, its
 *    height is its z extent, synthesis runs over x and y. An example with a
 *    different reference plane is permuted by the caller before it gets here.
 *  - Normals are unit length and point out of the solid (up for height
 *    fields). The MLS signed distance is positive on the normal side.
 *  - Scan-line order: patch k sits at column k % cols, row k / cols; columns
 *    grow along +x, rows along +y, so the overlap of a patch with earlier
 *    output is its left strip (x low) and/or bottom strip (y low).
 *  - Input textures must carry geometry beyond every side of their box
 *    (paper section 3); gs_points_texture_check() says which side is short.
 *
 * Memory: a gs_points owns its array (gs_points_free); a synthesizer owns
 * copies of everything it needs (the texture may be freed after create).
 * Cost per patch: O(patches * overlap samples) search, O(pairs^3) spline
 * solve, O(points in the patch * pairs) warp, O(overlap points) blend.
 */
#ifndef GEOSYNTH_POINTS_H
#define GEOSYNTH_POINTS_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/rng.h"

/* ---------------------------------------------------------------- point set */

/* One oriented sample: position and unit normal. */
typedef struct gs_opoint {
    double p[3];
    double n[3];
} gs_opoint;

/* A growable oriented point set (array of gs_opoint). Zero-initialize, then
 * push; free with gs_points_free. */
typedef struct gs_points {
    gs_opoint *v;
    size_t n, cap;
} gs_points;

gs_err gs_points_reserve(gs_points *s, size_t cap);
gs_err gs_points_push(gs_points *s, const double p[3], const double n[3]);
gs_err gs_points_append(gs_points *s, const gs_opoint *v, size_t n);
void gs_points_free(gs_points *s);
/* XXH3 of the raw array (the value determinism tests compare). */
uint64_t gs_points_digest(const gs_points *s);

/* --------------------------------------------------------------- bucket grid */

/* Uniform grid of buckets over fixed bounds, for adding, removing and
 * finding points quickly. Points outside the bounds go to the border
 * buckets, so queries stay exact everywhere (only slower far outside).
 * Within a bucket points keep insertion order; every traversal goes over
 * buckets in x-fastest order, so results are deterministic. */
typedef struct gs_points_grid gs_points_grid;
typedef gs_points_grid *gs_points_grid_t;

/* cell > 0; lo < hi componentwise. On error *out is unchanged. */
gs_err gs_points_grid_create(const double lo[3], const double hi[3], double cell,
                             gs_points_grid_t *out);
void gs_points_grid_destroy(gs_points_grid_t *g);
gs_err gs_points_grid_add(gs_points_grid_t g, const gs_opoint *pt);
/* Removes the points equal (position and normal, bit for bit) to pts[0..n)
 * from g, keeping the order of the rest; returns how many were found. */
size_t gs_points_grid_remove_points(gs_points_grid_t g, const gs_opoint *pts, size_t n);
/* Removes every point with lo[0] <= x < hi[0] and lo[1] <= y < hi[1]
 * (all heights: regions are extruded along z). Returns how many. */
size_t gs_points_grid_remove_xy(gs_points_grid_t g, const double lo[2], const double hi[2]);
/* 1 when some point of g lies closer than r to c (|p - c| < r), else 0. */
int gs_points_grid_any_within(const gs_points_grid *g, const double c[3], double r);
/* Appends to out every point within radius r of c (|p - c| <= r). */
gs_err gs_points_grid_query(const gs_points_grid *g, const double c[3], double r, gs_points *out);
/* Appends every point with lo <= p < hi in x and y (any z). */
gs_err gs_points_grid_query_xy(const gs_points_grid *g, const double lo[2], const double hi[2],
                               gs_points *out);
size_t gs_points_grid_count(const gs_points_grid *g);
/* Appends all points in bucket order. */
gs_err gs_points_grid_collect(const gs_points_grid *g, gs_points *out);

/* Buckets of the indices of a fixed point array, for queries that need to
 * know which point they found (the grid above holds copies). pts must
 * outlive the grid; bounds and cell as for gs_points_grid_create. Answers
 * come in bucket order (x fastest), increasing index within a bucket. */
typedef struct gs_points_index_grid gs_points_index_grid;
typedef struct gs_points_indices {
    size_t *v; /* gs_free */
    size_t n, cap;
} gs_points_indices;
gs_err gs_points_index_grid_create(const gs_opoint *pts, size_t n, const double lo[3],
                                   const double hi[3], double cell, gs_points_index_grid **out);
void gs_points_index_grid_destroy(gs_points_index_grid **g);
/* Appends to out the index of every point within radius r of c (|p - c| <= r). */
gs_err gs_points_index_grid_query(const gs_points_index_grid *g, const double c[3], double r,
                                  gs_points_indices *out);

/* ------------------------------------------------------------ input texture */

/* An input geometry texture T_in: uniformly sampled oriented points, its
 * box B_Tin (z range = the texture's height) and the sampling spacing
 * (Poisson-disk radius: no two points closer than spacing). */
typedef struct gs_points_texture {
    gs_points pts;
    double box_lo[3], box_hi[3];
    double spacing;
} gs_points_texture;

void gs_points_texture_free(gs_points_texture *t);

/* Checks that geometry continues at least `need` past each of the four
 * sides of the box: the strip beyond each side, and its outer half, must
 * hold at least a quarter of the box's points per unit area. Raises
 * GS_ERR_ARG naming the side, how far geometry reaches and what is needed. */
gs_err gs_points_texture_check(const gs_points_texture *t, double need);

/* A parallel "for" over independent items: fn(ctx, lo, hi, out_lo) writes
 * items [lo, hi) (bytes each) starting at out_lo. A map hook computes items
 * [0, n) spread over processes (each calls fn on its part) and returns with
 * all n items in out on every process, exactly what fn(ctx, 0, n, out)
 * gives, so results do not depend on the split. Used for the example
 * generators' dart throwing, the query field nodes, the warp, the blend and
 * the relaxation; if the hook is collective, so are the generators,
 * gs_points_synth_step and gs_points_synth_finish. */
typedef gs_err (*gs_points_range_fn)(void *ctx, size_t lo, size_t hi, void *out_lo);
typedef gs_err (*gs_points_map_fn)(void *user, size_t n, size_t bytes, gs_points_range_fn fn,
                                   void *ctx, void *out);

/* Generators of the paper's kinds of example (figures 4, 5, 7, 8). The box
 * is [0, size_x] x [0, size_y] x [z range of the geometry]; geometry covers
 * [-pad, size + pad] in x and y. Points are a dart-throwing Poisson-disk
 * sampling (radius spacing) of the union of the primitives (samples inside
 * another primitive are dropped), with analytic orientation of normals.
 * Randomness: gs_rng(seed, stream per generator). */
typedef struct gs_points_gen_params {
    double size[2];   /* box extent in x and y, > 0 */
    double pad;       /* geometry beyond each side, >= 0 */
    double spacing;   /* sampling radius, > 0 */
    uint64_t seed;
    /* Chain mail and weave: 0 (the paper's kind of example, not tileable):
     * rings and threads jittered off their lattice, with varying sizes
     * (gs_rng(seed)); 1: exactly on the lattice (tileable by the lattice
     * period). Flowers are always scattered at random. */
    int periodic;
    /* Optional (NULL: all in this process): the per-try work of the dart
     * throwing through a map hook, and agree(map_user, local), which returns
     * the status every process gets (a failure anywhere fails all). With
     * collective hooks every process calls the generator, each one makes
     * the same hook calls whatever fails, and all get the same points (the
     * same as without hooks) or the same error. */
    gs_points_map_fn map;
    void *map_user;
    gs_err (*agree)(void *map_user, gs_err local);
} gs_points_gen_params;

/* Height field from an image of w x h pixels (x fastest, row 0 at y low),
 * given as uint8 (u8 != NULL) or float (f32 != NULL, exactly one of them).
 * The image is stretched over [-pad, size+pad]^2, bilinearly interpolated;
 * pixel value v maps to height v * height_scale (uint8 values are /255). */
gs_err gs_points_gen_heightfield(const gs_points_gen_params *gp, int w, int h,
                                 const uint8_t *u8, const float *f32, double height_scale,
                                 gs_points_texture *out);
/* Chain mail: tori on a square lattice (cells across the box) leaning
 * alternately, with small bumps around the tube. */
gs_err gs_points_gen_chainmail(const gs_points_gen_params *gp, int cells, gs_points_texture *out);
/* Plain weave of round threads along x and y (cells threads across). */
gs_err gs_points_gen_weave(const gs_points_gen_params *gp, int cells, gs_points_texture *out);
/* Disconnected flowers (center ball + petals) scattered with minimum
 * distance size/cells. */
gs_err gs_points_gen_flowers(const gs_points_gen_params *gp, int cells, gs_points_texture *out);

/* Uniform Poisson-disk sampling of a triangle mesh (vertices pos[3i..3i+2],
 * triangles tris[3t..3t+2], counter-clockwise = outward): dart throwing by
 * area (about 9 tries per accepted point), no two samples closer than
 * spacing; normals are the barycentric blend of area-weighted vertex
 * normals (the face normal where they cancel). Appends to out in bucket
 * order. Randomness: gs_rng(seed, "PTSA" stream). what names the mesh in
 * messages. Cost O(area / spacing^2). */
gs_err gs_points_sample_mesh(const float *pos, size_t nverts, const uint32_t *tris, size_t ntris,
                             double spacing, uint64_t seed, const char *what, gs_points *out);

/* Sampling spacing (Poisson-disk radius) of a point set: the median
 * nearest-neighbour distance / 1.08 over up to 20000 points (calibrated on
 * this module's samplers; a sparser sampling gives a larger value). */
gs_err gs_points_estimate_spacing(const gs_points *pts, double *spacing);

/* Reference plane: the core works with z up. up (0 = x, 1 = y, 2 = z) is the
 * axis normal to the example's reference plane; these cyclic permutations
 * (which keep handedness, so outward normals stay outward) move it to z and
 * back: up = x maps (x, y, z) to (y, z, x), up = y maps it to (z, x, y). */
void gs_points_permute_to_z(gs_points *pts, int up);
void gs_points_permute_from_z(gs_points *pts, int up);
void gs_points_permute_vec_to_z(double v[3], int up);

/* Implicit function of an oriented point set for meshing: on samples
 * origin + voxel * (i, j, k) (i < nx fastest, out has nx*ny*nz floats),
 * f = sum w n.(x - p) / sum w over points within R (weights as the MLS
 * surface), clamped to [-R, R], positive on the normal side; samples no
 * point reaches get +-R with the sign of the nearest known sample above in
 * their z column (+ at the top). Contour at 0 (gs_vdb_dense_to_mesh).
 * Cost O(points * (R/voxel)^3); 16 bytes per sample of scratch. */
gs_err gs_points_implicit_grid(const gs_points *pts, double R, const double origin[3],
                               double voxel, size_t nx, size_t ny, size_t nz, float *out);

/* -------------------------------------------------------- MLS point surface */

/* Adamson-Alexa point-set surface with explicit normals: weighted average
 * a(x) and normalized weighted normal n(x), weights (1 - r^2/R^2)^4 within
 * radius R (a compactly supported stand-in for their Gaussian, h ~ R/2),
 * surface {x : n(x).(x - a(x)) = 0}. Projection is their almost orthogonal
 * projection y <- x - ((x - a(y)).n(y)) n(y), iterated from start. */
typedef struct gs_points_mls_result {
    double y[3];     /* projected point */
    double n[3];     /* surface normal at y */
    double dist;     /* signed distance (x - a(y)).n(y) */
    int iterations;
    int ok;          /* 0: no points within R of the iterate */
} gs_points_mls_result;

/* Projects x onto the surface of the points in g (radius R). scratch is a
 * reusable buffer (may be empty). Far points (nothing within R) start from
 * their nearest sample within max_reach. */
gs_err gs_points_mls_project(const gs_points_grid *g, double R, double max_reach,
                             const double x[3], gs_points *scratch,
                             gs_points_mls_result *res);

/* Signed distance and its gradient (normal at the projection) sampled on
 * nodes lo + (i*step[0], j*step[1], k*step[2]), i < nx fastest. Distance is
 * divided by trunc and clamped to [-1, 1]. out has 4 floats per node
 * (d, gx, gy, gz). Nodes with no geometry within max_reach get (1, 0, 0, 0). */
gs_err gs_points_field(const gs_points_grid *g, double R, double trunc, double max_reach,
                       const double lo[3], const double step[3], int nx, int ny, int nz,
                       float *out);

/* Surface variation lambda0 / (lambda0 + lambda1 + lambda2) of the
 * covariance of the points within radius r of c (Pauly et al.), in
 * [0, 1/3]; 0 when fewer than 3 points. */
double gs_points_surface_variation(const gs_points *nbrs, const double c[3], double r);

/* ----------------------------------------------------- thin-plate spline 3D */

/* W(x) = A x + b + sum_i w_i |x - c_i| (the 3D biharmonic kernel), solved
 * with LAPACK dgesv so that W(src_i) = dst_i (+ lambda smoothing on the
 * diagonal; lambda = 0 interpolates exactly). Needs >= 4 non-coplanar
 * sources. */
typedef struct gs_points_tps {
    int n;
    double *c;   /* 3n control points */
    double *w;   /* 3n kernel weights */
    double A[9]; /* row-major */
    double b[3];
} gs_points_tps;

/* On error *out is unchanged (GS_ERR_ARG for a singular system). */
gs_err gs_points_tps_fit(const double *src, const double *dst, int n, double lambda,
                         gs_points_tps *out);
void gs_points_tps_free(gs_points_tps *t);
/* y = W(x); J (row-major 3x3 Jacobian) when J != NULL. */
void gs_points_tps_eval(const gs_points_tps *t, const double x[3], double y[3], double J[9]);
/* Normal through the spline: (J u x J v) / |J u x J v| with u, v tangents of n. */
void gs_points_tps_normal(const double J[9], const double n[3], double out[3]);

/* ------------------------------------------------------------------ search */

/* Overlap modes of a patch with the output so far. */
enum { GS_POINTS_OVERLAP_LEFT = 1, GS_POINTS_OVERLAP_BOTTOM = 2, GS_POINTS_OVERLAP_BOTH = 3 };

/* Layout of one patch's overlap field (same for every patch and for the
 * query): the nodes (a, b, k) of the patch-local grid with a < oc or b < oc,
 * packed as [corner a<oc,b<oc | left a<oc,b>=oc | bottom a>=oc,b<oc], each
 * node 4 floats, within a block k (z) fastest, then a, then b. */
typedef struct gs_points_layout {
    int pc, oc, nz;              /* patch cells, overlap cells, z nodes */
    size_t n_corner, n_left, n_bottom; /* floats in each block */
} gs_points_layout;

void gs_points_layout_init(gs_points_layout *l, int pc, int oc, int nz);
size_t gs_points_layout_floats(const gs_points_layout *l);
/* Patch-local node (a, b) of packed node index i (for building queries). */
void gs_points_layout_node(const gs_points_layout *l, size_t node, int *a, int *b, int *k);

/* A share of the candidates: patches [first, first + count) of the input
 * field, their overlap fields unpacked (precomputed) for a fast scan. Each
 * rank of a distributed search holds one share. */
typedef struct gs_points_bank gs_points_bank;
typedef gs_points_bank *gs_points_bank_t;

/* field: nx*ny*nz*4 floats (gs_points_field of the input box); patch index
 * = j * (nx - pc) + i for the patch whose corner node is (i, j). */
gs_err gs_points_bank_create(const float *field, int nx, int ny, const gs_points_layout *l,
                             size_t first, size_t count, gs_points_bank_t *out);
void gs_points_bank_destroy(gs_points_bank_t *b);
size_t gs_points_bank_total(int nx, int ny, const gs_points_layout *l);

typedef struct gs_points_cand {
    double dist;
    uint64_t index;
} gs_points_cand;

typedef struct gs_points_cands {
    gs_points_cand *v;
    size_t n, cap;
    double best; /* +inf when empty */
} gs_points_cands;

void gs_points_cands_free(gs_points_cands *c);

/* Local search over this share: squared distance between the query and
 * each patch over the overlap blocks of `mode`, keeping every patch within
 * (1 + eps) * best seen (bound: best known elsewhere, +inf if none; used to
 * prune partial sums). Each distance is summed in a fixed order, so a
 * patch's value does not depend on how candidates are partitioned. */
gs_err gs_points_search_local(const gs_points_bank *b, const float *query, int mode, double eps,
                              double bound, gs_points_cands *out);
/* Merges shares (as gathered from ranks), keeps dist <= (1+eps)*global best,
 * sorted by (dist, index): exactly the serial candidate set Psi_k. */
gs_err gs_points_search_merge(const gs_points_cands *parts, int nparts, double eps,
                              gs_points_cands *out);
/* Chooses one candidate uniformly with r. */
uint64_t gs_points_search_pick(const gs_points_cands *c, gs_rng *r);

/* Bounded scan for a distributed search (gs_psearch callbacks): visits the
 * bank's patches with global index in [lo, hi) (within the bank's share) in
 * index order; bound(user) is the current pruning threshold and a patch is
 * dropped only when a partial sum exceeds it STRICTLY (partial sums only
 * grow, so they are lower bounds); every other patch is reported with
 * offer(user, d, index), d being exactly the value gs_points_search_local
 * computes. The bound is read once per patch. */
typedef double (*gs_points_bound_fn)(void *user);
typedef void (*gs_points_offer_fn)(void *user, double dist, uint64_t index);
gs_err gs_points_search_scan(const gs_points_bank *b, const float *query, int mode, uint64_t lo,
                             uint64_t hi, gs_points_bound_fn bound, gs_points_offer_fn offer,
                             void *user);
/* The bank's share [*first, *first + *count). */
void gs_points_bank_share(const gs_points_bank *b, size_t *first, size_t *count);

/* --------------------------------------------------------------- synthesis */

typedef struct gs_points_params {
    double out_size[2];   /* final output extent in x, y */
    double field_step;    /* node spacing of the distance fields */
    int patch_cells;      /* patch edge in field steps */
    int overlap_cells;    /* overlap strip width in field steps */
    int extra_cells;      /* w_E in field steps */
    double mls_radius;    /* R of the MLS weights */
    double trunc;         /* distance truncation of the fields */
    double eps;           /* candidate tolerance */
    double warp_margin;   /* F_k extension before warping */
    /* pairing (eq. 2 and g): positions measured in units of spacing */
    double w_p, w_n, w_v, w_l, w_d;
    double max_pair_dist; /* world units */
    double max_normal;    /* max (1 - n.n)/2 */
    double max_variation; /* max |v_s - v_q| */
    double coherence_sigma; /* theta width, world units */
    int greedy_iterations;
    int cluster_max;      /* points per cluster of Q (at least) */
    int max_pairs;        /* clusters grow so |Q| stays near this (spline size) */
    double variation_radius;
    double tps_lambda;
    double warp_fade;     /* the warp fades to none ((b / warp_fade)^2) where the blend
                             weight b falls below this, to 0 at the strips' inner edge;
                             0 = the spline everywhere */
    int warp_height_bound; /* 1: a warped point stays within the example's height range
                              (or where it was, when it was already beyond) */
    int warp_select;      /* 1: each patch takes the spline (pairs as they are, or their
                             normal parts) or no warp, whichever leaves it closest to N_k */
    int warp_select_seams; /* with warp_select: judged by the seams of the blended patch
                              with N_k (distance, normal angle, open seam points), not the
                              strip gap */
    int blend;            /* 1: the overlap strips blend onto N_k (section 5.3); 0: pasted as
                             warped (for measuring what the blend does) */
    int ray_blend;        /* 1: ray intersection for the blend, 0: projection */
    int blend_resample;   /* 1: the blend resamples the links of F' it tears (points added
                             along them, gs_points_blend_bridge); 0: the paper's blend */
    int blend_keep_outer; /* 1: the outer half of each active strip keeps N_k's own points
                             (F' dropped there) and F' blends over the inner half with weight
                             2 t; 0: the paper's blend over the whole strip */
    int blend_fill;       /* 1: N_k's own points in the active strips fill the holes the
                             blend tore in the pasted sheet (synth.c fill_strip_holes); 0:
                             the paper's blend */
    int blend_implicit;   /* 1: the strips blend as the zero set of (1 - t) f_F + t f_N,
                             continuous signed distances to F' and N_k (blend.c); 0: each
                             point by its neighbours' nearest-point targets (the paper's) */
    int drop_strip_specks; /* 1: the finish drops pieces of < GS_POINTS_SPECK_POINTS points
                              lying wholly in the overlap strips or within the link radius
                              outside their seam edges (a safety net after the blend; the
                              count is gs_points_synth_strip_specks) */
    int strip_resample;   /* 1 (default): the finish resamples the overlap strips as dart
                             throwing sampled the example (synth.c resample_strips); 0: the
                             strips' points as the blend and relaxation leave them */
    int objects;          /* 1: the example's disconnected objects (components no wider than
                             a patch core, away from its edges, of at least
                             GS_POINTS_SPECK_POINTS points) are pasted whole or not at
                             all, each by the patch holding its centre (no cut flowers or
                             rings at the seams); 0: every point by its position (the paper) */
    int relax_iterations;
    uint64_t seed;
} gs_points_params;

/* A piece (component of points linked within 2 spacings) of fewer points
 * than this is a speck: a few samples, not an object. A Poisson-disk
 * sampling leaves such pieces on a connected surface too, where a hole in
 * the sampling is a little wider than 2 spacings (the heightfield.ini
 * example has 17 in its box, 1-3 points each, all within 0.5 spacing of
 * the surface next to them). The fragment measures count them; the
 * synthesis never treats them as objects. */
#define GS_POINTS_SPECK_POINTS 30

/* Defaults scaled to an example box of lx x ly and sampling spacing
 * (output 2x the box side, chain mail weights of table 1). */
void gs_points_params_default(double lx, double ly, double spacing, gs_points_params *p);
/* Fills every scale-dependent member that is 0 (out_size, field_step,
 * patch_cells, overlap_cells, extra_cells, mls_radius, trunc, warp_margin,
 * max_pair_dist, coherence_sigma, variation_radius) from the others with the
 * formulas of gs_points_params_default, in dependency order; nonzero
 * members are kept (so a user's patch_cells also sets the default overlap). */
void gs_points_params_complete(double lx, double ly, double spacing, gs_points_params *p);
/* How far geometry must extend past the example's box for these params:
 * patches are taken from half an overlap strip past each side of the box,
 * plus the extra region, the warp margin and the MLS radius. */
double gs_points_params_padding(const gs_points_params *p);

typedef struct gs_points_patch_metrics {
    uint64_t chosen;       /* input patch index */
    double best_dist;      /* min d over patches (0 for the seed patch) */
    double chosen_dist;
    uint32_t candidates;   /* |Psi_k| */
    uint32_t rank;         /* the chosen one's place in Psi_k sorted by (distance, index) */
    uint32_t continuations; /* how many of Psi_k continue the left or bottom neighbour's
                               source verbatim (the patch next to its source in the example) */
    uint32_t pairs;        /* pairs used by the warp (without anchors) */
    uint32_t warp;         /* the warp applied: 0 none, 1 the pairs' spline, 2 their
                              normal parts' spline (see warp_select) */
    double pair_gap;       /* mean |s - q| before warping */
    double warp_residual;  /* mean |MLS distance| of warped overlap points to N_k */
} gs_points_patch_metrics;

typedef struct gs_points_times {
    double search, warp, blend, other, relax;
} gs_points_times;

typedef struct gs_points_synth gs_points_synth;
typedef gs_points_synth *gs_points_synth_t;

/* Replaces the built-in search of a synthesizer (a distributed search):
 * given the query (layout floats) and the overlap mode, fill *out with the
 * candidate set Psi_k exactly as gs_points_search_merge would over all
 * patches: every patch with dist <= (1 + eps) * best, sorted by (dist,
 * index), out->best = the smallest distance. out arrives empty (n == 0) and
 * may be grown with gs_realloc. Called once per placed patch from
 * gs_points_synth_step; if the hook is collective, so is stepping. */
typedef gs_err (*gs_points_search_fn)(void *user, const gs_points_synth *s, const float *query,
                                      int mode, double eps, gs_points_cands *out);


/* Which patches this synthesizer's bank holds and who searches them.
 * count == 0 means all patches [0, total); fn == NULL the built-in serial
 * search over the bank (then the bank must hold all patches); map == NULL
 * runs every per-item loop in this process. */
typedef struct gs_points_synth_share {
    size_t first, count;
    gs_points_search_fn fn;
    void *user;
    gs_points_map_fn map;
    void *map_user;
} gs_points_synth_share;

/* Number of input patches (the candidates of every search) for this
 * texture and these parameters, without building anything. Raises
 * GS_ERR_ARG when the box has no room for a patch. */
gs_err gs_points_patch_count(const gs_points_texture *tex, const gs_points_params *p,
                             size_t *count);

/* Precomputes D(T_in), the patch bank and surface variations. Checks the
 * parameters and the example's padding (names what is wrong). */
gs_err gs_points_synth_create(const gs_points_texture *tex, const gs_points_params *p,
                              gs_points_synth_t *out);
/* The same with a share of the bank and a search hook (NULL = create). */
gs_err gs_points_synth_create_share(const gs_points_texture *tex, const gs_points_params *p,
                                    const gs_points_synth_share *share, gs_points_synth_t *out);
/* This synthesizer's patch bank (the share given at create). */
const gs_points_bank *gs_points_synth_bank(const gs_points_synth *s);
void gs_points_synth_destroy(gs_points_synth_t *s);
uint64_t gs_points_synth_total(const gs_points_synth *s);  /* patches to place */
uint64_t gs_points_synth_cursor(const gs_points_synth *s); /* patches placed */
/* Patch k (k < n) takes source patch chosen[k] in place of its own pick
 * (points.choices): the search and the pick's draw still run, so all else
 * is as without. chosen must outlive s; n must equal gs_points_synth_total
 * and each entry be below the bank's patch count (GS_ERR_ARG otherwise). */
gs_err gs_points_synth_set_choices(gs_points_synth_t s, const uint64_t *chosen, size_t n);
/* Places the next patch (search, warp, blend, paste). */
gs_err gs_points_synth_step(gs_points_synth_t s);
/* Steps until cursor == total. */
gs_err gs_points_synth_run(gs_points_synth_t s);
/* After the last step: relaxation, border trimming (w_E), translation to
 * [0, out_size]. Appends the result to out. Does not change the state. */
gs_err gs_points_synth_finish(gs_points_synth_t s, gs_points *out);
/* The same, and *patch (gs_malloc'ed, one entry per point appended to out,
 * NULL to skip) receives each point's patch id: the index k (raster order)
 * of the patch whose paste put the point in the output (its blend strip
 * included; a whole object keeps the id of the patch that brought it);
 * UINT32_MAX for a point of a resumed run whose checkpoint held no ids. */
gs_err gs_points_synth_finish_labeled(gs_points_synth_t s, gs_points *out, uint32_t **patch);

const gs_points_patch_metrics *gs_points_synth_metrics(const gs_points_synth *s, size_t *n);
gs_points_times gs_points_synth_times(const gs_points_synth *s);
/* Points per unit area (xy) of the example inside its box. */
double gs_points_synth_input_density(const gs_points_synth *s);
size_t gs_points_synth_input_patches(const gs_points_synth *s);
/* Pieces and points the finish dropped as strip specks (params
 * drop_strip_specks; 0 before gs_points_synth_finish or when off). */
void gs_points_synth_strip_specks(const gs_points_synth *s, uint64_t *pieces, uint64_t *points);
/* Whether p (output coordinates, z up, as gs_points_synth_finish gives
 * them) lies in an overlap strip of the output, where a patch was blended
 * with what was there (or within the link radius outside its seam edge). */
int gs_points_synth_in_strip(const gs_points_synth *s, const double p[3]);

/* Whether input patch `chosen` for output patch k continues the source of
 * its left or bottom neighbour verbatim (the example's next patch along x
 * or y, as a paste of one larger piece would give). m: metrics [0, k). */
int gs_points_synth_is_continuation(const gs_points_synth *s, const gs_points_patch_metrics *m,
                                    uint64_t k, uint64_t chosen);

/* Vertical lines x = x[i] and y = y[j] in the output plane (the patch
 * seams, or lines through the middle of the patches), cut into segments
 * of length seg (one patch edge: the patch step) for the seam measure. */
typedef struct gs_points_lines {
    double *x, *y;
    int nx, ny;
    double seg;
} gs_points_lines;
void gs_points_lines_free(gs_points_lines *l);

/* The lines of the finished output (gs_points_synth_finish coordinates)
 * strictly inside (0, out_size): inside == 0 the seams, where a patch's
 * points end and the next patch's blend strip begins (x = c * step - w_E,
 * c >= 1); inside == 1 the middles of the patches' own (unblended) parts,
 * x = c * step + patch / 2 - w_E; inside == 2 lines as far apart as the
 * seams across the example's box (the example's own value of the measure). */
gs_err gs_points_synth_lines(const gs_points_synth *s, int inside, gs_points_lines *out);

/* Seam measure: for each point within `band` of a line, the MLS frame
 * (radius R) of its neighbours on the other side of the line; dist =
 * |(p - a).n| and normal = (1 - n_p.n) / 2, averaged over the points with
 * a frame of enough weight (the others are `unmatched`: a hole or an end
 * of the surface at the line). seam_* over the seam lines, inside_* over
 * the inside lines: a seamless output has seam_* close to inside_*.
 *
 * Locally, per segment (a patch edge, lines.seg long, of 10 band points
 * or more): open_p90 is the 90th percentile of the segments' unmatched
 * share over the inside lines, seam_open_segments the share of seam
 * segments whose unmatched share is above it (0.1 when the seams are like
 * the inside; a seam where rings or threads end, an arc of a ring cut by
 * it, or a surface that does not continue, raises it). The blend pulls a
 * patch onto N_k at the seam itself, so dist and normal stay low there
 * even when the patches do not match; what does not continue shows as
 * unmatched points, segment by segment. */
/* The weight an MLS frame of the points across a seam must reach for a
 * point to count as matched (one point at 0.5 R weighs 0.32, at 0.6 R 0.17):
 * the line measure below and gs_measure_point_seams. */
#define GS_POINTS_SEAM_MIN_WEIGHT 0.15
typedef struct gs_points_seam_stats {
    double seam_dist, seam_normal, seam_unmatched;
    double inside_dist, inside_normal, inside_unmatched;
    double seam_open_segments, inside_open_p90;
    size_t seam_points, inside_points, seam_segments, inside_segments;
} gs_points_seam_stats;
gs_err gs_points_seam_measure(const gs_points *pts, double R, double band,
                              const gs_points_lines *seams, const gs_points_lines *inside,
                              gs_points_seam_stats *out);

/* Everything needed to resume exactly: with the same texture and params,
 * resume(save(s)) continues bit-identically. */
typedef struct gs_points_synth_state {
    uint64_t cursor;
    gs_rng_state rng;
    gs_points out;                   /* output points in bucket order */
    gs_points_patch_metrics *metrics; /* cursor entries */
    uint32_t *patch;                  /* out.n entries: each point's patch id (NULL: none) */
} gs_points_synth_state;

gs_err gs_points_synth_save(const gs_points_synth *s, gs_points_synth_state *st);
void gs_points_synth_state_free(gs_points_synth_state *st);
gs_err gs_points_synth_resume(const gs_points_texture *tex, const gs_points_params *p,
                              const gs_points_synth_state *st, gs_points_synth_t *out);
gs_err gs_points_synth_resume_share(const gs_points_texture *tex, const gs_points_params *p,
                                    const gs_points_synth_share *share,
                                    const gs_points_synth_state *st, gs_points_synth_t *out);

#endif
