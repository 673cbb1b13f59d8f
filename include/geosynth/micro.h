/* micro: stochastic microgeometry from contact distributions
 * (Schroeder, Breen, Cera, Regli, "Stochastic Microgeometry for Displacement
 * Mapping", SMI 2005; docs/ARCHITECTURE.md).
 *
 * Pipeline (each step a pure function of its inputs; nothing here calls MPI):
 *   1. mesh      gs_micro_mesh_sphere/disk/bar, or any triangle mesh; refine with
 *                gs_micro_mesh_subdivide until every edge is <= a bound.
 *   2. dual      gs_micro_dual_build: edge-adjacent triangles, edge weight =
 *                centroid-to-centroid distance in DISTRIBUTION UNITS (mesh units
 *                times units_per_model), and the ring graph: every triangle
 *                sharing a vertex, same weights. Geodesic distance between
 *                triangles (gs_micro_geo_*) = shortest path in the ring graph
 *                (the paper, 4.2, takes the dual graph: hexagons, see geo.c).
 *   3. dist      two radial contact distributions (positive, negative region),
 *                unit-width bins: bin k holds the probability that a random
 *                point lies at distance [k, k+1) from the region boundary.
 *                From an image (gs_micro_dist_from_image), a random draw
 *                (gs_micro_dist_random) or a table (gs_micro_dist_create).
 *   4. hist      gs_micro_hist_from_dist: merged signed histogram of triangle
 *                counts (paper 4.3, Fig. 9).
 *   5. recon     gs_micro_recon_*: labels every triangle with a signed distance
 *                value (paper 4.4), resumable from a gs_micro_state.
 *   6. displace  gs_micro_displace: vertex value = mean of incident triangles,
 *                offset along the vertex normal (paper 4.5, Table 1).
 *   7. verify    gs_micro_verify: independent check of the result.
 *
 * Signed histogram layout ("signed axis", Fig. 9): 2K bins, index i in [0, 2K).
 *   i >= K: positive bin k = i-K, values in [k, k+1)
 *   i <  K: negative bin k = K-1-i, values in (-(k+1), -k]
 * so index 0 is the most negative bin and 2K-1 the most positive one.
 *
 * Memory (n triangles): dual + ring graph ~ 190 n bytes, reconstruction state ~ 34 n
 * bytes, geodesic buffers ~ 24 n bytes. Cost: see gs_micro_recon_run.
 * All arrays are allocated with gs_malloc; every create has a destroy(&h).
 */
#ifndef GEOSYNTH_MICRO_H
#define GEOSYNTH_MICRO_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/rng.h"

/* ---------------------------------------------------------------- mesh -- */

/* In-memory triangle mesh. pos: float[3*nverts] (x,y,z per vertex), tris:
 * uint32[3*ntris] (counter-clockwise seen from outside), normals: optional
 * float[3*nverts] (NULL until gs_micro_mesh_normals). Field names and layout
 * match the future gs_mesh {nverts, ntris, pos, normals, tris}. The struct
 * owns its arrays; free with gs_micro_mesh_free. */
typedef struct gs_micro_mesh {
    uint32_t nverts, ntris;
    float *pos;
    float *normals;
    uint32_t *tris;
} gs_micro_mesh;

/* Conversion to and from the shared mesh type (include/geosynth/mesh.h), so
 * files are read and written only by gs_mesh_read / gs_mesh_write. The two
 * structs are NOT layout-identical (gs_mesh counts are size_t and it carries
 * optional per-vertex scalar/label arrays), so these copy: O(n), no sharing.
 * from_mesh: pos, tris and normals (when present) are copied; a mesh beyond
 * 2^32 - 1 vertices or triangles is GS_ERR_ARG. to_mesh: *out gets pos, tris
 * and normals (when m has them); scalar/label stay NULL for the caller to
 * fill. Caller frees with gs_micro_mesh_free / gs_mesh_destroy. On error the
 * output is left unchanged (from_mesh) or zeroed (to_mesh). */
struct gs_mesh;
gs_err gs_micro_mesh_from_mesh(const struct gs_mesh *in, gs_micro_mesh *out);
gs_err gs_micro_mesh_to_mesh(const gs_micro_mesh *in, struct gs_mesh *out);

/* Allocates a mesh with room for nverts/ntris (arrays zeroed, normals NULL).
 * On error *m is left unchanged. */
gs_err gs_micro_mesh_alloc(gs_micro_mesh *m, uint32_t nverts, uint32_t ntris);
void gs_micro_mesh_free(gs_micro_mesh *m);

/* Built-in shapes (paper figures). Each picks its resolution so that every
 * edge is <= max_edge (model units) and reports it through the mesh.
 *  sphere ("planet"): octahedron with s segments per edge projected to the
 *      sphere, 8 s^2 triangles, min angle ~ 38 deg.
 *  disk: hexagonal rings in the z = 0 plane, normal +z, 6 r^2 triangles.
 *  bar: closed axis-aligned box sx*sy*sz centred at 0 ("candy bar"), square
 *      cells split along alternating diagonals (min angle 45 deg, watertight).
 * Errors: GS_ERR_ARG for non-positive sizes or a resolution beyond 2^31
 * triangles. */
gs_err gs_micro_mesh_sphere(gs_micro_mesh *m, double radius, double max_edge);
gs_err gs_micro_mesh_disk(gs_micro_mesh *m, double radius, double max_edge);
gs_err gs_micro_mesh_bar(gs_micro_mesh *m, double sx, double sy, double sz, double max_edge);
/* Sphere with exactly 8 s^2 triangles (benchmarks). */
gs_err gs_micro_mesh_sphere_segments(gs_micro_mesh *m, double radius, uint32_t segments);

/* Refines until every edge is <= max_edge: whole 1-to-4 splits while the
 * longest edge exceeds 2 max_edge, then conforming longest-edge bisection
 * (every triangle with a too long edge is bisected across its longest edge,
 * and neighbours are split conformingly), which keeps the minimum angle above
 * half the input's. Replaces m's arrays (normals dropped). stats (optional):
 * passes run, final longest edge and minimum angle in degrees. New vertices
 * are edge midpoints (flat facets are kept; shapes that should stay curved
 * come from the generators at the right resolution). Cost O(n) per pass,
 * O(log(longest/max_edge)) passes. On error m is unchanged. */
typedef struct gs_micro_subdiv_stats {
    int uniform_passes, bisect_passes;
    double max_edge, min_angle_deg;
} gs_micro_subdiv_stats;
gs_err gs_micro_mesh_subdivide(gs_micro_mesh *m, double max_edge, gs_micro_subdiv_stats *stats);

/* Longest edge and smallest interior angle (degrees) of the mesh. */
void gs_micro_mesh_edge_stats(const gs_micro_mesh *m, double *max_edge, double *min_angle_deg);
/* Half the largest bounding-box extent (the paper scales models into a box of
 * edge 2 ScaleUnits, so units_per_model = ScaleUnits / half_extent). */
double gs_micro_mesh_half_extent(const gs_micro_mesh *m);
/* (Re)computes area-weighted unit vertex normals into m->normals. */
gs_err gs_micro_mesh_normals(gs_micro_mesh *m);

/* ------------------------------------------------- dual graph, geodesic -- */

/* Triangle adjacency in CSR form: neighbours of t are adj[off[t] .. off[t+1])
 * with weights w[] (centroid distance in distribution units). Triangles that
 * share an edge are adjacent (non-manifold edges connect every pair). The
 * ring graph roff/radj/rw: every other triangle sharing a vertex with t,
 * ascending, weight = centroid distance (12 neighbours on a regular mesh). */
typedef struct gs_micro_dual {
    uint32_t ntris;
    uint32_t *off; /* ntris+1 */
    uint32_t *adj;
    double *w;
    double mean_w; /* mean edge weight */
    uint32_t *roff; /* ntris+1 */
    uint32_t *radj;
    double *rw;
} gs_micro_dual;

/* Builds the dual graph. units_per_model > 0 converts model lengths into
 * distribution units. O(n). On error *d is unchanged. */
gs_err gs_micro_dual_build(const gs_micro_mesh *m, double units_per_model, gs_micro_dual *d);
void gs_micro_dual_free(gs_micro_dual *d);

/* Bounded Dijkstra over the ring graph with reusable buffers: memory O(n)
 * once, each query costs O(k log k) in the k triangles it reaches (buffers
 * are reset lazily). A true metric (the reconstruction's propagation relies
 * on the triangle inequality), never longer than the dual graph's (the
 * verifier's), and isotropic within 3.5% on a regular mesh where the dual
 * graph's paths run 15-36% longer than the straight line off its directions. */
typedef struct gs_micro_geo *gs_micro_geo_t;
gs_err gs_micro_geo_create(const gs_micro_dual *d, gs_micro_geo_t *g);
void gs_micro_geo_destroy(gs_micro_geo_t *g);
/* Every triangle within geodesic distance <= radius of src, in increasing
 * distance order: *count entries in *tris / *dist (owned by g, valid until the
 * next query). */
gs_err gs_micro_geo_ball(gs_micro_geo_t g, uint32_t src, double radius,
                         const uint32_t **tris, const double **dist, size_t *count);

/* ------------------------------------------------------- distributions -- */

/* Two radial contact distributions with K unit-width bins each. pos[k]/neg[k]
 * are probabilities (>= 0); their relative total mass is the area share of
 * each region (the image acquisition divides both by the pixel count, so
 * together they sum to 1). */
typedef struct gs_micro_dist {
    uint32_t nbins;
    double *pos, *neg;
} gs_micro_dist;

gs_err gs_micro_dist_create(gs_micro_dist *d, uint32_t nbins, const double *pos, const double *neg);
void gs_micro_dist_free(gs_micro_dist *d);

/* Reads a distribution table from a CSV file: one row per distance bin,
 * "bin, positive, negative" with bin = 0, 1, 2, ... in order (the bin's
 * probability for the positive and the negative region). Blank lines and
 * lines starting with '#' are skipped; a first row whose first field is not a
 * number is a header (e.g. "bin,pos,neg"). Numbers through parse.h.
 * Errors (GS_ERR_ARG, "PATH:LINE: ..."): wrong field count, a bin out of
 * order, a probability outside [0, 1], no rows, more than 16384 rows, all
 * zero; GS_ERR_IO when the file cannot be read. The sums are not checked
 * here (gs_micro_dist_check_sum). On error *d is unchanged. */
gs_err gs_micro_dist_read_csv(const char *path, gs_micro_dist *d);

/* Checks that a table sums to something sensible: positive + negative = 1
 * (the image acquisition's convention: the sums are the regions' area
 * shares), or positive = 1 and negative = 1 (each side normalized on its
 * own: the regions get equal area), each within tol. what names the source
 * in the message. GS_ERR_ARG otherwise, naming both sums. */
gs_err gs_micro_dist_check_sum(const double *pos, size_t npos, const double *neg, size_t nneg,
                               double tol, const char *what);

/* Image-based acquisition (paper 5.3). pix: w*h grey values, row-major, x
 * fastest. Pixels >= threshold are white = positive, others black = negative
 * (threshold 128 for a black-and-white image). For every pixel the nearest
 * pixel of the opposite colour is found (an exact Euclidean distance
 * transform: the same answer as the paper's radial search, in O(w h)); the
 * boundary lies half a pixel before it, so the pixel's distance to the
 * boundary is (D - 0.5) * units_per_pixel and it counts in bin floor of that.
 * Counts are divided by the pixel count. max_bins caps K (larger distances go
 * to the last bin). Errors: GS_ERR_ARG for an empty image, a one-colour image
 * (no boundary) or units_per_pixel <= 0. */
gs_err gs_micro_dist_from_image(gs_micro_dist *d, uint32_t w, uint32_t h, const uint8_t *pix,
                                uint8_t threshold, double units_per_pixel, uint32_t max_bins);

/* Random distribution from a parameter range (paper 5.1), drawn as the
 * contact distribution of a random set (3.2) so that both sides describe one
 * partition: a Boolean model (discs of radii uniform in [R/2, R] units at
 * uniform centres, added until the positive share s is reached) on a flat
 * torus of the surface's area, measured by the radial search of 5.3.
 * R is drawn in [min_bins, max_bins] (the positive side's depth in bins),
 * capped so 4 discs fit the positive area and at least 1; s in
 * [min_pos_share, max_pos_share]; area: the surface's area in distribution
 * units (0: a 64 x 64 unit torus). Tables drawn bin by bin for each side on
 * its own ask for coasts the two sides do not share (issue 20). */
typedef struct gs_micro_dist_range {
    uint32_t min_bins, max_bins;
    double min_pos_share, max_pos_share;
    double area;
} gs_micro_dist_range;
gs_err gs_micro_dist_random(gs_micro_dist *d, const gs_micro_dist_range *range, gs_rng *rng);

/* Test image of a Boolean model (stochastic geometry's standard random set):
 * white disks with radii uniform in [rmin, rmax] pixels at uniform random
 * centres (wrapping around the image edges), added until the white share
 * reaches coverage; black background. pix: caller-allocated w*h bytes
 * (255 white, 0 black). */
gs_err gs_micro_image_boolean(uint32_t w, uint32_t h, double rmin, double rmax, double coverage, gs_rng *rng,
                              uint8_t *pix);

/* Signed histogram of triangle counts (layout in the file comment). */
typedef struct gs_micro_hist {
    uint32_t nbins;  /* K per side; 2K entries */
    int64_t *count;  /* target triangle counts, sum == ntris */
    double *prob;    /* merged probabilities, sum == 1 */
} gs_micro_hist;

/* Merge (paper 4.3): the negative distribution is reflected onto the negative
 * axis, both are divided by their joint mass, and bin count = ntris * bin
 * probability, rounded by largest remainder (ties to the lower index) so the
 * counts sum to exactly ntris. Errors: GS_ERR_ARG when the mass is 0. */
gs_err gs_micro_hist_from_dist(gs_micro_hist *h, const gs_micro_dist *d, uint32_t ntris);
void gs_micro_hist_free(gs_micro_hist *h);
/* Index into the signed layout: side 0 positive, 1 negative, magnitude k. */
static inline uint32_t gs_micro_bin_index(uint32_t nbins, int side, uint32_t k)
{
    return side == 0 ? nbins + k : nbins - 1 - k;
}

/* ------------------------------------------------------ reconstruction -- */

#define GS_MICRO_UNASSIGNED 0xFFFFu /* label: not labelled (yet) */
#define GS_MICRO_FILLED 0xFFFEu     /* label: value from the neighbour fill */

/* Algorithm switches. Defaults (gs_micro_recon_defaults): capacity = 1. */
typedef struct gs_micro_recon_opts {
    /* 1: a random placement is accepted only if the triangles it forces into
     * lower bins still fit their counts, and those it keeps off the other
     * side's bins >= 1 fit that side's bin 0 and its own bins; once the next
     * lower bin is full, seeds come from next to existing structures (see
     * recon.c); 0: the paper as printed (random placements unchecked,
     * overflow left for the fill). */
    int capacity;
    /* Upper bound on rejected candidates per bin (0 = no bound). */
    uint64_t max_rejects_per_bin;
} gs_micro_recon_opts;
void gs_micro_recon_defaults(gs_micro_recon_opts *o);

/* Complete, serializable reconstruction state: save every array and scalar
 * to checkpoint, hand it back to gs_micro_recon_resume to continue with a
 * bit-identical result. Steps: 0 .. 2K-1 are bins in processing order
 * (magnitude K-1 down to 0, positive before negative), step 2K is the
 * neighbour fill, 2K+1 means done. lo/hi are the admissible ranges the
 * propagation maintains (exact where they can still matter, see recon.c). */
typedef struct gs_micro_state {
    uint64_t seed;
    uint32_t ntris, nbins;
    uint32_t step;
    gs_rng_state rng;      /* stream of the current step */
    int64_t *placed;       /* [2K] triangles labelled from each bin so far */
    double *value;         /* [n] signed distance value (0 where unassigned) */
    uint16_t *label;       /* [n] bin index, GS_MICRO_UNASSIGNED or GS_MICRO_FILLED */
    double *lo, *hi;       /* [n] admissible range */
} gs_micro_state;

typedef struct gs_micro_recon *gs_micro_recon_t;

/* Starts a reconstruction of h on the dual graph d (both must outlive rec;
 * h->count must sum to d->ntris). The result is a pure function of (mesh,
 * units, histogram, opts, seed): randomness comes from gs_rng streams keyed by
 * (seed, step), so many instances (seeds) can run on any ranks. */
gs_err gs_micro_recon_create(const gs_micro_dual *d, const gs_micro_hist *h,
                             const gs_micro_recon_opts *opts, uint64_t seed, gs_micro_recon_t *rec);
/* Continues from a saved state (arrays are copied; the caller keeps st). */
gs_err gs_micro_recon_resume(const gs_micro_dual *d, const gs_micro_hist *h,
                             const gs_micro_recon_opts *opts, const gs_micro_state *st,
                             gs_micro_recon_t *rec);
void gs_micro_recon_destroy(gs_micro_recon_t *rec);
/* Runs at most max_steps steps (0 = to the end); *done = 1 when finished.
 * Cost: forced assignments O(1) each, random placements one pruned Dijkstra
 * each (reach ~ value + current magnitude), plus one O(n) scan per bin; the
 * fill costs a Dijkstra of radius 2K per filled triangle. */
gs_err gs_micro_recon_run(gs_micro_recon_t rec, uint32_t max_steps, int *done);
/* Current state (owned by rec; valid until the next run/destroy). */
const gs_micro_state *gs_micro_recon_state(gs_micro_recon_t rec);
/* Counters since create/resume: random placements tried/accepted, forced. */
typedef struct gs_micro_recon_counters {
    uint64_t forced, random_accepted, random_rejected, filled, dijkstra_nodes;
} gs_micro_recon_counters;
gs_micro_recon_counters gs_micro_recon_counters_get(gs_micro_recon_t rec);

/* Deep copy of a state (for checkpoints / tests); free with gs_micro_state_free. */
gs_err gs_micro_state_copy(gs_micro_state *dst, const gs_micro_state *src);
void gs_micro_state_free(gs_micro_state *st);
/* Digest of the labels and values (the engine's output digest). */
uint64_t gs_micro_state_digest(const gs_micro_state *st);

/* One instance, start to end: value[n] and label[n] are filled (caller
 * allocates). */
gs_err gs_micro_reconstruct(const gs_micro_dual *d, const gs_micro_hist *h,
                            const gs_micro_recon_opts *opts, uint64_t seed, double *value,
                            uint16_t *label);

/* ----------------------------------------------------------- correction -- */

/* Correction pass (correct.c): moves the interface between the regions
 * until their realized contact distribution (true geodesic distance of each
 * triangle to the interface, gs_measure_interface_dist) is within target_l1
 * (L1 / n over the signed axis) of h, or max_rounds rounds (one fast march
 * each) are done, or no move improves. side[n] (1 positive, 0 negative) is
 * updated in place to the best labelling seen; dist_out[n] receives its
 * signed distances (> 0 positive region, distribution units). */
typedef struct gs_micro_correct_opts {
    uint32_t max_rounds;
    double target_l1;
    /* Basin hopping after the greedy rounds: at most hops times, the best
     * labelling opened and closed (1, 2, 3, 5 units), a region short of its
     * deepest bins deepened around its deepest triangle (1, 2, 3 units),
     * hop_rounds greedy rounds after each (0 hops: none), while the best
     * L1 / n is above hop_above. */
    uint32_t hops, hop_rounds;
    double hop_above;
    /* Optional [n] values (the reconstruction's): when side[] holds one
     * region only, the target's positive share of triangles with the
     * largest values starts as the positive region. */
    const double *init_value;
    /* Nonzero: side[] is replaced by separate discs before the first
     * round (micro.correct_discs): n discs of radius R + 1/2 for each step
     * of the positive table's slope at its bin R - 1 (a disc of radius r
     * holds 2 pi (r - k - 1/2) units^2 in bin k), centres placed farthest-
     * point by geodesic clearance to the discs placed (the largest first;
     * the first at the largest init_value, else vertex 0), each disc the
     * triangles within its radius (fast marching). stats->l1_before stays
     * the L1/n of the side[] given. 2: overlapping discs instead, a Boolean
     * model fitted to the tables (micro.correct_boolean). */
    int disc_seed;
} gs_micro_correct_opts;
typedef struct gs_micro_correct_stats {
    uint32_t rounds;
    uint64_t flips;
    double l1_before, l1_after;
} gs_micro_correct_stats;
void gs_micro_correct_defaults(gs_micro_correct_opts *o);
gs_err gs_micro_correct(const gs_micro_mesh *m, double units_per_model, const gs_micro_hist *h,
                        const gs_micro_correct_opts *o, uint8_t *side, double *dist_out,
                        gs_micro_correct_stats *stats);
/* Largest function <= value[] that is 1-Lipschitz in the dual graph's
 * metric (min over j of value_j + d(i, j), one Dijkstra from every triangle
 * at once), so measured distances also obey the paper's constraint
 * |x_i - x_j| <= d(i, j) that gs_micro_verify checks (a centroid chord can
 * be a hair shorter than the surface path). O(n log n). */
gs_err gs_micro_lipschitz(const gs_micro_dual *d, double *value);

/* -------------------------------------------------------- displacement -- */

typedef enum gs_micro_func {
    GS_MICRO_LINEAR = 0, /* f(x) = x */
    GS_MICRO_SQRT,       /* f(x) = sqrt(x), rounds ridges and crevices */
    GS_MICRO_SQUARE,     /* f(x) = x^2 */
    GS_MICRO_CBRT,       /* f(x) = x^(1/3) */
    GS_MICRO_STEP        /* f(x) = 1 for x > 0: plateaus */
} gs_micro_func;

/* Paper Table 1, per region (index 0 positive, 1 negative): direction s in
 * {+1 out, -1 in, 0 none}, scale k, function f. A vertex with value x is
 * moved by s k f(|x|) * half_extent along its normal (half_extent: see
 * gs_micro_mesh_half_extent; Table 1's k are relative to a model scaled to
 * the box [-1, 1]^3). */
typedef struct gs_micro_displace_params {
    int direction[2];
    double scale[2];
    gs_micro_func func[2];
} gs_micro_displace_params;

/* vertex_value[nverts] (optional out, caller-allocated) = mean of incident
 * triangle values; out_pos[3*nverts] (caller-allocated) = displaced
 * positions. Computes normals into m if missing. */
gs_err gs_micro_displace(gs_micro_mesh *m, const double *tri_value,
                         const gs_micro_displace_params *p, double *vertex_value, float *out_pos);
double gs_micro_func_eval(gs_micro_func f, double x);

/* -------------------------------------------------------------- checks -- */

/* Independent verifier (own adjacency, own Dijkstra; shares no code with the
 * reconstruction). For nsample triangles drawn from rng (all when nsample >=
 * n) it visits every triangle within geodesic radius (2K, where any
 * violation could occur) and counts pairs with |x_i - x_j| > d(i,j) + tol.
 * Also: unassigned share (labels that are not histogram bins), achieved
 * histogram and per-bin error achieved - target. */
typedef struct gs_micro_report {
    uint64_t pairs_checked, violations;
    double max_excess;       /* largest |x_i - x_j| - d(i,j) seen */
    uint64_t unassigned;     /* GS_MICRO_FILLED or GS_MICRO_UNASSIGNED */
    double unassigned_share;
    uint32_t nbins;
    int64_t *achieved;       /* [2K] */
    int64_t *error;          /* [2K] achieved - target */
    int64_t abs_error_sum;
} gs_micro_report;
gs_err gs_micro_verify(const gs_micro_mesh *m, double units_per_model, const gs_micro_hist *h,
                       const double *value, const uint16_t *label, uint32_t nsample, gs_rng *rng,
                       gs_micro_report *r);
void gs_micro_report_free(gs_micro_report *r);

#endif
