/* Quality measures shared by every engine (src/measure/): computed from an
 * output and its example alone, never from an engine's own bookkeeping, so a
 * reviewer holding the two files gets the same figures. Engine-specific
 * measures (lattice windows, copied regions, seams, realized contact
 * distributions) live in src/measure/ too, one file per kind of data, and
 * build on these.
 *
 * Conventions: distributions are non-negative counts or weights; an L1
 * distance compares them after normalizing each to sum 1, so it lies in
 * [0, 2] (0 = the same mix, 2 = disjoint). A KS distance is the largest
 * difference of two empirical cumulative distributions, in [0, 1].
 * Nothing here uses MPI or allocates on success paths beyond what is stated.
 *
 * Mesh validity of an output file (open, non-manifold and misoriented edges,
 * pinched vertices, duplicate and coincident faces, enclosed volume, counted
 * on the indices as the file stores them) is analysis/mesh_validity.py, the
 * one implementation the tests use for every engine's meshes.
 */
#ifndef GEOSYNTH_MEASURE_H
#define GEOSYNTH_MEASURE_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

/* L1 distance of two distributions over n bins after normalizing each to sum
 * 1: sum |a_i/A - b_i/B|. Both empty: 0; one empty: 2. */
double gs_measure_l1(const double *a, const double *b, size_t n);

/* Two-sample Kolmogorov-Smirnov distance sup_t |F_x(t) - F_y(t)| of samples
 * x (nx values) and y (ny values); NaNs are ignored. Both empty: 0; one
 * empty: 1. Sorts copies (O((nx + ny) log)); GS_ERR_MEM when they cannot be
 * allocated. */
gs_err gs_measure_ks(const double *x, size_t nx, const double *y, size_t ny, double *out);

/* Connected components of the set cells (mask != 0) of an nx*ny*nz grid, x
 * fastest (cell (x, y, z) at x + nx*(y + ny*z)), 6-connected (face
 * neighbours); periodic[k] != 0 wraps axis k. label[i] receives the
 * component of cell i numbered 1 .. *ncomp in order of each component's
 * lowest cell index, 0 for unset cells. *sizes (gs_malloc'ed, *ncomp + 1
 * entries, [0] unused) receives the cell count of each; pass NULL to skip.
 * Memory: label plus one queue of up to nx*ny*nz uint32. Cost: O(cells).
 * Grids of 2^32 - 1 cells or more are GS_ERR_ARG. */
gs_err gs_measure_components3(const uint8_t *mask, int nx, int ny, int nz, const int periodic[3],
                              uint32_t *label, uint32_t *ncomp, uint64_t **sizes);

/* Euler characteristic of each 6-connected component of label (as
 * gs_measure_components3 fills it, not periodic; ncomp components): euler[c]
 * (c = 1 .. ncomp, [0] unused, ncomp + 1 entries) = cells - face-adjacent
 * pairs + 2x2 squares - 2x2x2 cubes of the component, the Euler
 * characteristic of the cubical complex that 6-connectivity describes:
 * 1 for a solid ball, 0 for a solid ring (one handle), 1 - g for g handles
 * (a component without cavities: handles = 1 - euler). Cost: O(cells). */
void gs_measure_component_euler3(const uint32_t *label, int nx, int ny, int nz, uint32_t ncomp,
                                 int64_t *euler);

/* The components of two nested sets of a grid in one labelling: v (n[0] x
 * n[1] x n[2] values, x fastest) classed by cls[v]: 0 neither, 1 the outer
 * set only, 2 both (the inner set lies within the outer one, e.g. the core
 * of the inside of a distance field). outer[1 .. nouter] are the
 * 6-connected components of the samples of class >= 1, inner[1 .. ninner]
 * those of class 2, each numbered in order of its lowest sample index ([0]
 * unused) as gs_measure_components3 numbers them, so every figure equals
 * that of labelling each set alone (src/measure/stats.c checks it in
 * unit/test_measure). Per component: size, faces (bit 2a: a sample on the
 * low face of axis a, 2a + 1: on its high face; an axis of one sample sets
 * both), the sums of the samples' x, y, z and the radius, the largest
 * distance of a sample from the centre sum / size (inner only: the layout's
 * objects) and, with euler, the Euler characteristic as
 * gs_measure_component_euler3 gives it (outer only). One raster pass with a
 * union-find over provisional labels (each holds samples of one class), one
 * pass to number the roots, one to count and one for the radii; memory 4
 * bytes per sample plus 9 per provisional label (no mask, no queue). Grids
 * of 2^32 - 1 samples or more are GS_ERR_ARG. */
typedef struct gs_measure_component {
    uint64_t size;
    double sum[3], radius;
    int64_t euler;
    uint8_t faces;
} gs_measure_component;
typedef struct gs_measure_nested {
    uint32_t nouter, ninner;
    gs_measure_component *outer, *inner; /* gs_malloc'ed, n + 1 entries */
} gs_measure_nested;
gs_err gs_measure_components_nested3(const uint8_t *v, const int64_t n[3], const uint8_t cls[256],
                                     int euler, gs_measure_nested *r);
void gs_measure_nested_free(gs_measure_nested *r);

/* Share of set samples (mask != 0, n[0] x n[1] x n[2], x fastest) in every
 * window of w[0] x w[1] x w[2] samples of the mask continued periodically
 * (one window per offset within one period): *lo, *hi the smallest and the
 * largest. What a source gives over a box of the output's size: a period-16
 * lattice measures 0.142-0.185 in 48x40x32 windows, its whole 0.163. Cost
 * O(cells) (wrapped prefix sums one axis at a time). */
gs_err gs_measure_window_share_range(const uint8_t *mask, const int64_t n[3], const int64_t w[3],
                                     double *lo, double *hi);

/* Layout of separate objects: the 6-connected components of the set samples
 * of an output mask (on[0] x on[1] x on[2], x fastest) and of its example's
 * (sn), their centres (mean sample position) and sizes (samples). An object
 * that touches a face of its grid (an axis of one sample has none) is cut by
 * the box: it counts as a neighbour but is not measured. Per measured
 * object, nn = the distance of its centre to the nearest other object's
 * centre. close_share: measured objects whose nn is below the example's
 * smallest (crowded closer than any two in the example: clumps; the
 * example's own 0); fused_share: measured objects larger than `fused` times
 * the example's largest measured one (objects glued into one); nn_ks the KS
 * distance of the two nn distributions. Quantiles: the sorted value at
 * round(p (k - 1)). analysis/field_layout.py computes the same. Cost
 * O(cells) plus the nearest-neighbour sweep (O(n log n) typically); memory
 * 9 bytes per sample (gs_measure_components3's labels and queue).
 * (src/measure/layout.c) */
typedef struct gs_measure_objlayout_side {
    int64_t objects;        /* measured (inner) objects */
    double nn_p10, nn_p50;  /* nearest-neighbour centre distance, samples */
    double close_share, fused_share;
    /* measured objects smaller than 3/4 of the example's smallest measured
     * one (a piece of an object: a crescent or sliver a later block left) */
    double fragment_share;
    /* measured objects reaching farther from their centre than the example's
     * largest object radius (largest distance of a sample from its object's
     * centre) plus half a sample: merged (two objects glued into one that is
     * not larger than `fused` times, or one with a piece of another at a
     * seam: an elongated or bulging disc) */
    double merged_share;
} gs_measure_objlayout_side;
typedef struct gs_measure_objlayout {
    gs_measure_objlayout_side out, src;
    double nn_ks;
    /* The same over the output's guarded objects: measured ones whose centre
     * lies at least `guard` (the example's largest nn plus the largest
     * distance of one of its objects' samples from its centre) from every
     * face, so every object within the example's spacing of them is whole
     * (one the box cuts has a centre moved off its own: texture.ini, most
     * close pairs left by field.object_spacing had one); nn_ks_guarded
     * against the example's nn. */
    gs_measure_objlayout_side out_guarded;
    double nn_ks_guarded, guard;
} gs_measure_objlayout;
gs_err gs_measure_object_layout(const uint8_t *out, const int64_t on[3], const uint8_t *src,
                                const int64_t sn[3], double fused, gs_measure_objlayout *r);
/* The same from components labelled elsewhere: out[1 .. nout] of an output
 * grid of on samples and src[1 .. nsrc] of its example's, with their sizes,
 * coordinate sums, faces and radii (gs_measure_components_nested3's inner set, so a
 * grid labelled once for another measure needs no labelling of its own):
 * the figures of gs_measure_object_layout on masks of those components. */
gs_err gs_measure_object_layout_components(const gs_measure_component *out, uint32_t nout,
                                           const int64_t on[3], const gs_measure_component *src,
                                           uint32_t nsrc, const int64_t sn[3], double fused,
                                           gs_measure_objlayout *r);

/* Connected components of a point cloud: points i and j are linked when
 * |p_i - p_j| <= radius; point i is xyz[i * stride .. + 3) (stride >= 3
 * doubles, e.g. 6 for x y z nx ny nz). label[i] (n entries) receives the
 * component of point i, numbered 1 .. *ncomp in order of each component's
 * lowest point index; *sizes (gs_malloc'ed, *ncomp + 1 entries, [0] unused)
 * the point count of each, NULL to skip. Cost O(n log n) plus the pairs
 * within radius; memory ~ 40 bytes per point (src/measure/pointset.c). */
gs_err gs_measure_point_components(const double *xyz, size_t stride, size_t n, double radius,
                                   uint32_t *label, uint32_t *ncomp, uint64_t **sizes);

/* Distance from each point of a cloud (xyz, stride doubles apart, n
 * points) to its nearest other point, into dist[i]; INFINITY when none lies
 * within radius (the cell size of the search). Coincident points give 0.
 * Cost O(n) cells of radius (27 around each point). */
gs_err gs_measure_point_nearest(const double *xyz, size_t stride, size_t n, double radius,
                                double *dist);

/* Pieces of a point cloud inside the xy box [lo, hi): the components
 * (gs_measure_point_components, link radius) of the points inside it,
 * except those with a point within radius of one of its four sides: a
 * piece the box's border cuts is no piece of the cloud (an example cropped
 * to its box and an output trimmed to its size are measured alike). Counts
 * the inner pieces, those of fewer than small points (specks) and their
 * points, and the pieces left out at the border. density and
 * small_density are pieces per unit area without the border's bias
 * (minus-sampling): each inner piece of xy extent w counts 1 / ((L_x - w_x
 * - 2 radius) (L_y - w_y - 2 radius)), the area where it could lie without
 * being left out, so a box of 4 x 4 and one of 10 x 10 give the same
 * density of flowers 0.5 wide (plain counts per area differ by 15%). */
typedef struct gs_measure_pieces {
    uint32_t pieces, small, border;
    uint64_t small_points;
    double density, small_density;
} gs_measure_pieces;
gs_err gs_measure_point_pieces(const double *xyz, size_t stride, size_t n, double radius,
                               const double lo[2], const double hi[2], uint64_t small,
                               gs_measure_pieces *out);

/* Seams of a point set made of patches, from a patch id per point: how well
 * the surface of one patch continues on its neighbour's, against the same
 * inside one patch. v[6 i .. 6 i + 5] = x y z nx ny nz of point i (unit
 * normals, z up), id[i] its patch. A seam point has a point of another patch
 * within band in x y, at any height (the other patch: that of the nearest
 * such point; a surface that ends at the seam with none across it is a seam
 * point, and open); its fit is
 * the MLS frame (weights (1 - d^2/R^2)^4, R = radius, as the points engine's
 * surface) at it of the other patch's points within R: centroid a, unit mean
 * normal n. seam_dist = mean |(p - a).n| (distance to the other patch's
 * surface), seam_angle = mean angle in degrees between the point's normal and
 * n; seam_dist_p90 the 90th percentile of the distances; seam_open the share
 * of seam points whose fit weighs less than min_weight (no surface across).
 * The inside figures are the same with, for each point with no other patch
 * within R, the frame of its own patch's points beyond a virtual seam (four
 * fits: a line across +x, -x, +y, -y at a distance u from the point, u spread
 * evenly over [0, band), a fit kept when a point beyond the line lies within
 * band in x y, as a seam point is found): the seam's one-sided geometry at
 * its distances, so a seamless output has seam_* close to inside_* also on a
 * curved surface. inside_fits counts those fits. seam_broken (inside_broken):
 * the share of seam points (inside fits) that are open or lie farther than
 * far_dist from the other side's surface; far_dist as passed to
 * gs_measure_point_seams_far (e.g. the example's inside_dist_p90), else the
 * points' own inside_dist_p90. Unlike seam_dist and seam_angle, which are
 * means over the matched points only, it counts the points a seam leaves
 * with no surface across, so closing a seam cannot raise it by adding its
 * hardest points to the mean. Serial;
 * O(n log n) plus the pairs within radius (src/measure/pointset.c). */
typedef struct gs_measure_seams {
    double seam_dist, seam_angle, seam_dist_p90, seam_open;
    double inside_dist, inside_angle, inside_dist_p90, inside_open;
    double seam_broken, inside_broken, far_dist;
    uint64_t seam_points, inside_fits;
} gs_measure_seams;
gs_err gs_measure_point_seams(const double *v, size_t n, const int32_t *id, double radius,
                              double band, double min_weight, gs_measure_seams *out);
/* The same with the broken shares against far_dist (> 0; 0 = the points' own
 * inside_dist_p90). */
gs_err gs_measure_point_seams_far(const double *v, size_t n, const int32_t *id, double radius,
                                  double band, double min_weight, double far_dist,
                                  gs_measure_seams *out);

/* ------------------------------------------ geodesics on triangle meshes -- */

/* Fast-marching workspace over a triangle mesh (src/measure/geodesic.c):
 * pos float[3 nverts], tris uint32[3 ntris] (kept by pointer: must outlive
 * g), lengths multiplied by scale (> 0, e.g. distribution units per model
 * unit). Memory ~ 70 bytes per vertex + 16 per triangle. Isotropic distances
 * (planar wavefront updates, first order in the edge length), not a graph's
 * polygonal metric. */
typedef struct gs_measure_geo *gs_measure_geo_t;
gs_err gs_measure_geo_create(const float *pos, size_t nverts, const uint32_t *tris, size_t ntris, double scale,
                             gs_measure_geo_t *g);
void gs_measure_geo_destroy(gs_measure_geo_t *g);
/* Geodesic distance of every vertex from the nearest source (vertex src[i]
 * starting at src_dist[i], or 0 when src_dist is NULL), up to radius
 * (INFINITY: everything reachable). Vertices beyond radius or unreachable
 * read +inf. Cost O(k log k) in the k vertices reached (earlier results are
 * reset lazily). */
gs_err gs_measure_geo_march(gs_measure_geo_t g, const uint32_t *src, const double *src_dist, size_t nsrc,
                            double radius);
const double *gs_measure_geo_vertex_dist(gs_measure_geo_t g);
/* Per reached vertex: the index i (into src) of the source its value came
 * from (the front's origin). */
const uint32_t *gs_measure_geo_origin(gs_measure_geo_t g);
/* Distance at triangle t's centroid: the mean of its vertices' (exact for a
 * planar front; for a triangle on an interface edge, its height / 3). */
double gs_measure_geo_tri_dist(gs_measure_geo_t g, size_t t);

/* Realized contact distribution of a two-region labelling of g's triangles
 * (side[t] != 0: positive region, 0: negative). The interface is where the
 * regions meet: the edges with a triangle of each region on their two sides.
 * tri_dist[t] receives the geodesic distance of t's centroid to the
 * interface (scaled units), +inf everywhere when there is no interface;
 * *nsrc (optional) the number of vertices on the interface. Triangles with
 * a vertex on it get the straight distance of their centroid to the nearest
 * interface edge around them, the others the fast-marching value. foot[t]
 * (optional) receives the interface vertex t is nearest to (UINT32_MAX
 * without an interface): the triangles of one foot are that stretch of the
 * interface's "fibre", what moves when the interface moves there. This looks only at the
 * regions and the surface, never at the values a reconstruction assigned. */
gs_err gs_measure_interface_dist(gs_measure_geo_t g, const uint8_t *side, double *tri_dist, size_t *nsrc,
                                 uint32_t *foot);
/* Histogram of those distances the way a contact distribution is binned:
 * pos[k] / neg[k] count the triangles of each region at distance [k, k+1),
 * k < nbins; distances >= nbins (and +inf) count in bin nbins - 1 and in
 * *beyond (optional). */
void gs_measure_contact_hist(const double *tri_dist, const uint8_t *side, size_t ntris, uint32_t nbins,
                             int64_t *pos, int64_t *neg, uint64_t *beyond);
/* ---- sorted sets of 64-bit keys (src/measure/keys.c) -------------------------
 * The lookups of the lattice measures and the model checkers ("does the
 * example hold this window / this adjacent pair"): sort once, then binary
 * search. */
void gs_measure_keys_sort(uint64_t *keys, size_t n);
/* Sorts and drops repeats; returns the new count. */
size_t gs_measure_keys_sort_unique(uint64_t *keys, size_t n);
/* Whether the sorted keys[0..n) hold key. */
int gs_measure_keys_has(const uint64_t *keys, size_t n, uint64_t key);

/* ---- label lattices (uint16 labels, 0 = empty, x fastest, z up) -------------
 *
 * A lattice is labels[x + nx*(y + ny*z)] with dims {nx, ny, nz}; z = 0 is the
 * ground layer. Window measures use windows of k x k x k cells, the extent
 * clipped per axis to min(k, example extent, output extent) (a 2D lattice
 * gets k x k x 1). Windows are compared by a 64-bit digest of their labels
 * (XXH3, gs_digest_bytes; a collision would overstate a share by one window
 * in about 2^-64 per pair). */

/* Digest of every window of extent w[3] of a lattice, at lower corner
 * (x, y, z) in x-fastest order: keys[(nx-w0+1)*(...)] (the caller sizes it
 * with gs_measure_window_count). nonempty (may be NULL) gets 1 where the
 * window holds a non-zero label. w[a] in [1, dims[a]], w0*w1*w2 <= 4096. */
size_t gs_measure_window_count(const int dims[3], const int w[3]);
gs_err gs_measure_window_keys(const uint16_t *labels, const int dims[3], const int w[3],
                              uint64_t *keys, uint8_t *nonempty);

typedef struct gs_measure_windows {
    int extent[3];            /* window extent used per axis */
    uint64_t output_windows;  /* all windows of the output */
    uint64_t output_nonempty; /* windows holding some non-empty cell */
    uint64_t found;           /* non-empty output windows that occur in the example */
    double found_share;       /* found / output_nonempty (0 when there is none) */
    double found_share_all;   /* windows found / all windows, empty ones included
                                 (the old resemblance figure; all-empty windows inflate it) */
    uint64_t example_distinct;/* distinct non-empty windows of the example */
    uint64_t example_covered; /* of those, the ones that occur in the output */
    double completeness;      /* example_covered / example_distinct */
} gs_measure_windows;

/* Window resemblance of an output to its example with k x k x k windows
 * (k in 1..16). Cost O(cells * k^3) plus sorts of the keys; memory 9 bytes
 * per window of each lattice. */
gs_err gs_measure_lattice_windows(const uint16_t *example, const int edims[3],
                                  const uint16_t *output, const int odims[3], int k,
                                  gs_measure_windows *out);

/* Label histogram (counts of labels 0 .. nlabels-1; labels >= nlabels are
 * counted in the last bin) of a lattice. hist must have nlabels entries. */
void gs_measure_label_hist(const uint16_t *labels, size_t ncells, double *hist, size_t nlabels);

typedef struct gs_measure_profile {
    int nz;                 /* output layers */
    double *fill_output;    /* [nz] share of non-empty cells per output layer */
    double *fill_example;   /* [nz] the example's per layer; layers above the example's
                               top count as empty (Merrell's convention: padded with empty) */
    double fill_mean_abs;   /* mean over layers of |fill_output - fill_example| */
    double label_l1_mean;   /* mean over layers of the L1 distance of the layer's label mix
                               to the example layer's (an empty-padded layer is all label 0) */
    int top_output;         /* highest layer holding a non-empty cell, -1 when none */
    int top_example;        /* the same for the example */
} gs_measure_profile;

/* Height profile of output vs example (layer z of one against layer z of
 * the other: both stand on the ground at z = 0). Free with
 * gs_measure_profile_free. */
gs_err gs_measure_height_profile(const uint16_t *example, const int edims[3],
                                 const uint16_t *output, const int odims[3],
                                 gs_measure_profile *out);
void gs_measure_profile_free(gs_measure_profile *p);

/* Unsupported structure: the non-empty cells with no 6-connected path of
 * non-empty cells down to a non-empty cell of the ground layer z = 0
 * (floating pieces). *unsupported and *nonempty receive the counts (a
 * lattice with nz == 1 has none). */
gs_err gs_measure_unsupported(const uint16_t *labels, const int dims[3], uint64_t *unsupported,
                              uint64_t *nonempty);

/* Enclosure of one layer (courtyards inside closed walls): the empty cells
 * (label 0) of layer z that are not 4-connected through empty cells of that
 * layer to the layer's border. Those cells form the yards (their 4-connected
 * components). min_large: a yard of at least this many cells is "large"
 * (quality figures use half the example's largest yard). Cost O(layer cells). */
typedef struct gs_measure_enclosure {
    int layer;              /* z measured */
    uint64_t cells;         /* cells of the layer (nx * ny) */
    uint64_t enclosed;      /* enclosed empty cells */
    uint64_t yards;         /* their 4-connected components */
    uint64_t yard_max;      /* cells of the largest yard, 0 when none */
    uint64_t large;         /* enclosed cells in yards of >= min_large cells */
} gs_measure_enclosure;
gs_err gs_measure_enclosure_layer(const uint16_t *labels, const int dims[3], int z,
                                  uint64_t min_large, gs_measure_enclosure *out);

/* How broad the raised land is (issue #18: a terrain's round domes, not a
 * village's houses or a fortress's walls): with h = each column's top
 * non-empty layer (-1 empty), over every level z above the lowest column's
 * top, the columns with h >= z whose 4 column neighbours have h >= z too
 * (past the lattice's sides counts as high), over the columns with h >= z;
 * 0 when no column rises above the lowest. analysis/lattice_measures.py
 * land() (interior). Untuned examples 121-160: terrain 0.41-0.76, village
 * 0.24-0.36, fortress 0.01-0.11. */
gs_err gs_measure_land_interior(const uint16_t *labels, const int dims[3], double *interior);

/* The lowest layer holding an empty cell (label 0): the first layer above the
 * ground, where yards are measured; -1 when no layer has one. */
int gs_measure_ground_layer(const uint16_t *labels, const int dims[3]);

/* Large-scale layout above the ground (issue #18: castles on open ground, not
 * a labyrinth), of the layers z >= ground (pass the example's
 * gs_measure_ground_layer for both lattices). A column (x, y) is open when it
 * holds no non-empty cell at z >= ground; clear when it and its 8 column
 * neighbours inside the lattice are open (room to stand, not a one-cell gap
 * between walls). Structures are the 6-connected components of the non-empty
 * cells at z >= ground that hold a cell above the ground layer (built more
 * than one cell high: walls, keeps, houses; not flat cover such as bushes
 * alone). size_median is cell-weighted: half the structure cells are in
 * structures of at least this many cells. large_cells: structure cells in
 * structures of more than large_min cells (0 = none counted). A structure is
 * nested when none of its columns is on the lattice's border or next to a
 * column of the outside (the columns holding no structure cell that are
 * 4-connected through such columns to the border): a keep inside a ring wall
 * (castle.txt: the keep, 96 of 216 structure cells). Non-periodic.
 * Cost O(cells) (src/measure/lattice.c; analysis/lattice_measures.py layout). */
typedef struct gs_measure_layout {
    int ground;                /* lowest layer measured */
    uint64_t columns;          /* nx * ny */
    uint64_t open, clear;      /* open and clear columns */
    uint64_t structures;       /* their count */
    uint64_t structure_cells;  /* cells in structures */
    uint64_t largest;          /* cells of the largest structure, 0 when none */
    uint64_t size_median;      /* cell-weighted median structure size, 0 when none */
    uint64_t large_cells;      /* cells in structures of more than large_min cells */
    uint64_t nested_cells;     /* cells in nested structures (a keep inside a ring wall) */
} gs_measure_layout;
gs_err gs_measure_layout_lattice(const uint16_t *labels, const int dims[3], int ground,
                                 uint64_t large_min, gs_measure_layout *out);

/* A layout on a regular grid (issue #18: one castle per region, open streets
 * along the region lines). A column is a structure column when it holds a
 * non-empty cell at z >= ground. Of the pairs of x- (y-) neighbouring columns,
 * those across a grid line (x = k * period[0], 0 < x < nx; y likewise) and
 * those across any other line; both_* count the pairs that are both
 * structure columns. ratio = (on_both / on_pairs) / (off_both / off_pairs):
 * 1 when structures ignore the grid, near 0 when they never cross its lines.
 * period <= 0 or >= the extent: no line along that axis. Cost O(cells)
 * (analysis/lattice_measures.py grid_crossing). */
typedef struct gs_measure_grid_crossing {
    uint64_t on_pairs, on_both, off_pairs, off_both;
    double ratio; /* 0 when a rate is undefined (no pairs, or no structure pair off the lines) */
} gs_measure_grid_crossing;
gs_err gs_measure_grid_crossing_lattice(const uint16_t *labels, const int dims[3], int ground,
                                        const int period[2], gs_measure_grid_crossing *out);

/* Copying in a synthesized 3D grid of bytes (x fastest), measured from the
 * output and its example alone. Every window of k^3 samples of out whose
 * content occurs exactly once in src (windows that occur more than once, e.g.
 * constant empty space, say nothing about where a sample came from) is
 * "copied" from that source position; it has the offset source position -
 * output position. A window that occurs more than once in src (not constant)
 * takes the offset of a lower face neighbour (x, then y, then z) when the
 * source window one step on from that neighbour's equals it (verified), else
 * its first occurrence: so a verbatim copy of a repetitive source (grid.ini:
 * most windows repeat) stays one region. A copied region is a set of window
 * positions connected through face neighbours with the same offset (a piece
 * moved verbatim: every window in it equals the source's at that offset).
 * Sizes count window positions (the k-1 samples at a region's upper faces
 * are not counted). large: a region of more than `large` positions counts
 * as large (e.g. one synthesis block, B^3: bigger regions were copied by
 * more than one step). cell: completeness is measured over the source cells
 * of cell^3 window positions (a grid from the origin) holding a unique
 * window: the share of them whose windows occur in out at least once.
 * A periodic source (periods below) is measured modulo its periods:
 * uniqueness, offsets and completeness. k in 2..8. Memory: two planes of output positions (a
 * region's size is counted when its last plane is done: 12 bytes per position of a plane), per
 * source position 2-4 hash slots of 24 bytes, 4 bytes (its slot's first occurrence) and 2
 * bytes; cost O(k^2) per position (up to four window comparisons for a repeated window; an
 * output window found one step on from a lower neighbour's source position needs no table
 * lookup, and one absent from the source mostly none: a bit filter). */
typedef struct gs_measure_copy {
    int window;                     /* k */
    int64_t positions;              /* output window positions */
    double matched_share;           /* share of them with a unique exact source match */
    int64_t regions;                /* copied regions (of >= 1 position; windows that
                                       occur more than once in src included) */
    int64_t largest_region;         /* positions of the largest region */
    double largest_region_of_source; /* largest_region / source window positions */
    double large_share;             /* share of output positions in regions > large */
    double completeness;            /* share of informative source cells represented */
    double source_unique_share;     /* share of source windows that are unique */
    int periods;                    /* exact periods found in src (translations v with
                                       src[x + v] == src[x] wherever both are inside): a
                                       periodic source is measured modulo them, windows
                                       unique and offsets equal up to a period, so a tiling
                                       of it is one region; 0 = none */
    double shortest_period;         /* length of the shortest (samples; 0 = none) */
} gs_measure_copy;
gs_err gs_measure_copy3(const uint8_t *out, const int64_t on[3], const uint8_t *src,
                        const int64_t sn[3], int k, int64_t large, int cell, gs_measure_copy *m);
/* The same figures with every output window looked up in the source's
 * table (no continuation of a neighbour's source position, no filter of
 * absent windows): slower, the reference gs_measure_copy3 is tested against. */
gs_err gs_measure_copy3_reference(const uint8_t *out, const int64_t on[3], const uint8_t *src,
                                  const int64_t sn[3], int k, int64_t large, int cell,
                                  gs_measure_copy *m);

/* Large-scale repetition of a height map out (onx x ony, x fastest)
 * against its example src (snx x sny): "the same mountain twice", which
 * the exact copy measure above misses when each repeat was copied at
 * another offset or blended. Windows of w x w samples, w = the first lag at
 * which the example's autocorrelation falls below 1/e (its feature size),
 * each reduced to its residual after the least squares plane; NCC = the
 * normalized cross-correlation of two residuals. Windows whose residual RMS
 * is below the median of the example's (relief) are left out (flat plains
 * are alike everywhere). Example windows at every position, output windows
 * every `stride` = max(1, w/4) samples; two windows overlap when their
 * origins are less than w apart along both axes.
 * ncc_src: the highest NCC between two example windows that do not overlap
 * (how alike two places of the example are); ncc_out: the same over output
 * windows whose origins are at most reach = the example's larger side apart
 * along each axis (a tiling of the example: 1). recur_out: the largest
 * number of output windows, none overlapping another, that match one
 * example window with an NCC >= ncc_src (closer than any other place of the
 * example comes to it): how many times one example feature recurs (the
 * example's own figure is 1; a 2x2 tiling 4).
 * ncc_out is a maximum over pairs and an output larger than the example holds
 * more of them: non-repeating random relief of the example's spectrum and
 * heights (analysis/field_repeats.py --surrogates) scores 0.81 mean at the
 * example's 64^2 (the example 0.80) and 0.89 at 128^2 (0.85-0.95 over 30).
 * ncc_out_area, the equal-area figure: the same within each example-sized
 * crop of the output (crops every half the example's side and flush with the
 * far faces: 9 for 64^2 -> 128^2), the median over the crops that hold a
 * pair (-1: none), ncc_out_area_max their highest; the random relief's
 * 0.82 mean at 128^2. It compares with ncc_src; a repeat farther apart than
 * a crop (a 2x2 tiling of the example: crops score as the example) is left
 * to ncc_out and recur_out. Cost O(windows^2 w^2): about 0.3 s for 64^2 ->
 * 128^2. analysis/field_repeats.py computes the same from field.h5. */
typedef struct gs_measure_repeats {
    int window, stride;
    int64_t reach;
    double relief;                     /* the floor: median residual RMS of the example's windows */
    int64_t windows_src, windows_out;  /* windows at or above the floor */
    double ncc_src, ncc_out;
    double ncc_out_area, ncc_out_area_max; /* over the example-sized crops of the output */
    int crops;
    int recur_out;
} gs_measure_repeats;
gs_err gs_measure_repeats2(const double *out, int64_t onx, int64_t ony, const double *src,
                           int64_t snx, int64_t sny, gs_measure_repeats *m);

/* Height distribution of a height map out (nout heights) against its
 * example src (nsrc): how common the example's low and high ground is in the
 * output (#19: terrain.ini's outputs held the example's highest ground about
 * half as often as the example). level[k]: the example's heights at the
 * percentiles gs_measure_height_percentiles (10, 90, 95, 99; numpy's linear
 * interpolation); low_*: the share at or below level[0]; high_*[k - 1]: the
 * share at or above level[k] (at or above: an example whose top is a flat
 * plateau holds more than 1% at its 99th percentile). ks: the two-sample
 * Kolmogorov-Smirnov distance of the two height sets. An output with the
 * example's distribution scores the example's shares (about 0.10, 0.10,
 * 0.05, 0.01 where heights do not tie) and ks 0. */
#define GS_MEASURE_HEIGHT_LEVELS 4
extern const double gs_measure_height_percentiles[GS_MEASURE_HEIGHT_LEVELS];
typedef struct gs_measure_heights_t {
    double level[GS_MEASURE_HEIGHT_LEVELS];
    double low_out, low_src;
    double high_out[GS_MEASURE_HEIGHT_LEVELS - 1], high_src[GS_MEASURE_HEIGHT_LEVELS - 1];
    double ks;
} gs_measure_heights_t;
gs_err gs_measure_heights(const double *out, size_t nout, const double *src, size_t nsrc,
                          gs_measure_heights_t *m);

/* Outline roughness of a two-sided labelling of a triangle mesh's vertices
 * (side[v] != 0: one side), e.g. micro's regions as mesh.ply shows them.
 * Positions pos (3 floats per vertex) times scale give distances in the
 * units rho is in. The colour boundary runs through the midpoints of the
 * edges whose ends differ; `length` is its length, `smoothed_length` that
 * of the same labelling opened by balls of radius rho (a side vertex is
 * kept when no other-side vertex lies closer than rho, then the kept ones
 * grow back by rho). A union of discs of radii >= rho loses nothing to the
 * opening, so `roughness` = length / smoothed_length is near 1 for it (both
 * drawn on the same mesh, the edges' staircase cancels: 1.01-1.06 for
 * Boolean unions of discs of radii in [a, 2a], a 1.5-3 units, coverage
 * 0.3-0.7, on a grid of 0.25 units); spikes and jagged steps of the side
 * narrower than 2 rho are cut, so it grows with them. Not a closing as well:
 * that bridges every gap under 2 rho between neighbouring discs, 1.1-2.5 on
 * the same ideal unions. A sphere
 * displaced along its normals (radial spread under 10% of the mean radius:
 * `on_sphere`) is measured on the sphere of its median radius under the
 * relief. No boundary: roughness NaN. GS_ERR_ARG for rho or scale <= 0,
 * GS_ERR_MEM. The same measure as analysis/micro_outline.py's roughness. */
typedef struct gs_measure_outline_t {
    double length, smoothed_length, roughness;
    int on_sphere;
} gs_measure_outline_t;
gs_err gs_measure_outline(const float *pos, size_t nv, const uint32_t *tris, size_t nt, double scale,
                          const uint8_t *side, double rho, gs_measure_outline_t *out);

#endif
