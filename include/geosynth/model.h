/* model: example-based model synthesis on label lattices (Merrell, i3D 2007,
 * "Example-Based Model Synthesis"; docs/ARCHITECTURE.md).
 *
 * Conventions
 * - A lattice holds one uint16 label per cell, index x + nx*(y + ny*z)
 *   (x fastest). Label 0 is empty space. Axis z points up; the example's
 *   lowest layer is the ground.
 * - Directions: 0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z, 6 +t, 7 -t (opposite =
 *   d ^ 1). Time (paper Sec. 4.3, 4D): a lattice of frames > 1 time steps
 *   holds them stacked along z, frame t at z in [t*fz, (t+1)*fz) with fz =
 *   nz / frames (so the memory, files and regions of a 3D lattice carry it
 *   unchanged); +z/-z never cross from one frame into the next, +t/-t join
 *   cell (x, y, z) of frame t to the same cell of frame t +- 1. Transitions
 *   along t are learned from the example's frames like those along x, y, z;
 *   a 3D lattice (frames 0 or 1) has no t neighbours.
 * - Transition function (paper Eq. 1): label b may sit at v+e_d next to
 *   label a at v iff that ordered pair occurs somewhere inside the example.
 *   Only pairs of cells that are both inside the example count: the outside
 *   of the example imposes nothing and is never a label (as in the author's
 *   parseTiledModel.cpp). A label that never had a neighbour in direction d
 *   in the example can therefore only sit on the output face on that side.
 * - Outside the output is unconstrained (free boundary), as in the author's
 *   implementation. With fix_z_faces (default for nz >= 3, the author's 3D
 *   convention) the bottom and top layers keep the labels of the initial
 *   model (ground below, empty above) and are never relabelled; without it
 *   they are synthesized, optionally limited to label sets (zface: the
 *   engine's model.fix_z_faces = auto for examples whose ground layer holds
 *   several labels).
 *
 * Algorithm (paper Table 2, "modifying in blocks"): start from a trivial
 * consistent model; pick a region B, forget its labels, recompute the
 * candidate sets C(M') by arc consistency inside B with the one-cell shell
 * around B fixed to the current labels, then label the cells of B one at a
 * time, propagating after each choice. Unlike the paper, a wipe-out first
 * undoes the latest choices (chronological backtracking, at most
 * `backtracks` undos per attempt; AC-3 only); an attempt that runs out of
 * budget is retried with a fresh random stream (the undo budget doubles
 * every quarter of the tries, up to x8); after `attempts` failed attempts the
 * region is split into 2x2 sub-boxes tried in a fixed order with their
 * resampled siblings fixed (split_depth levels); cells of sub-boxes that
 * still fail keep their old (consistent) content.
 *
 * Extensions (paper Sec. 5-6): hard constraints (params.pins: a pinned cell's
 * candidates are its label only), periodic outputs (params.periodic: shells
 * and whole-axis regions wrap), mirror-symmetric outputs (params.mirror with
 * gs_model_rules_symmetrize(): the lower half is synthesized with a mirror
 * face, then mirrored), rotation-symmetric outputs (params.rotate_map with
 * gs_model_rules_rotation(): the lower-left quarter with its +x face joined
 * to its +y face, then turned three times), 4D lattices (frames, +-t
 * transitions learned from the example's frames), and a tiled start
 * (gs_model_initial_tiled(): a periodic block repeated, so region shells are
 * not all one column).
 *
 * Cell order inside a region (measured on the author's samples, see the
 * bench program): ENTROPY (fewest candidates first, random tie-break) is the
 * default: it succeeded where the author's scan failed (castle 100x100 in
 * 20x20 regions) and does not streak; SCAN (the author's order, z fastest)
 * makes runs along x up to 2.5x longer than in the example (city). Regions overlap (by default stride half the region edge, see
 * gs_model_params.overlap) and
 * are swept pass after pass until every cell has been in `min_changes`
 * accepted regions or `max_passes` is reached.
 *
 * Parallel shape: regions of one pass carry a colour; regions of one colour
 * are separated by at least one cell (with resemblance, at least the window
 * radius w), so none reads what another writes and they can run on
 * different ranks. gs_model_region_run() depends only on (lattice
 * state, box, params, region id, pass) and writes the region's new labels;
 * applying the results of a colour in id order, colours in order, gives the
 * same lattice as the serial driver gs_model_synthesize() for any rank count.
 *
 * Memory: rules hold 8*L*ceil(L/64) words (8 directions) (L = largest label + 1). A solver
 * holds per region cell ceil(L/64)*8 + 48 bytes (AC-3) plus 16*L bytes for
 * AC-4 support counts (only when AC-4 is selected); above 128 labels also the
 * rules' non-zero words twice (rows and reverse rows, 10 bytes each) and, up
 * to 512 labels, a cache of 1024 unions (576 KiB at 512 labels).
 * Cost: per region cell roughly one propagation of its choice, each revise
 * O(|D| * L/64) word operations (AC-3; above 128 labels the rows' non-zero
 * words only, and a cell that lost few labels is revised by those: about
 * O(removed) row words plus a test per neighbour label they supported) or
 * O(removed * L/64) (AC-4).
 */
#ifndef GEOSYNTH_MODEL_H
#define GEOSYNTH_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

/* ---- label lattice ------------------------------------------------------ */

typedef struct gs_model_lattice {
    int nx, ny, nz;
    uint16_t *labels; /* nx*ny*nz, x fastest; owned */
    int frames;       /* time steps stacked along z (4D); 0 or 1 = a 3D lattice */
} gs_model_lattice;

/* Cells per frame along z (nz for a 3D lattice). */
static inline int gs_model_frame_nz(const gs_model_lattice *l)
{
    return l->frames > 1 ? l->nz / l->frames : l->nz;
}
/* z of the neighbour of a cell at height z along direction d (4..7; x and
 * y directions keep z), or -1 when it lies outside the lattice or, along
 * +z/-z, in another frame. */
static inline int gs_model_step_z(const gs_model_lattice *l, int z, int d)
{
    const int fz = gs_model_frame_nz(l);
    int q = d == 4 ? z + 1 : d == 5 ? z - 1 : d == 6 ? z + fz : d == 7 ? z - fz : z;
    if (q < 0 || q >= l->nz || (d >= 6 && l->frames <= 1))
        return -1;
    if ((d == 4 || d == 5) && q / fz != z / fz)
        return -1;
    return q;
}

/* Allocates a zero-filled (all empty) 3D lattice (frames = 1; a 4D one sets
 * frames afterwards, nz a multiple of it); dims in [1, 2^20] and the cell
 * count below 2^31. On error *lat is left unchanged. Free with
 * gs_model_lattice_destroy(). */
gs_err gs_model_lattice_create(gs_model_lattice *lat, int nx, int ny, int nz);
void gs_model_lattice_destroy(gs_model_lattice *lat);
static inline size_t gs_model_lattice_index(const gs_model_lattice *l, int x, int y, int z)
{
    return (size_t)x + (size_t)l->nx * ((size_t)y + (size_t)l->ny * (size_t)z);
}
/* 4D: frame t of l as a 3D lattice (out allocated; free it). */
gs_err gs_model_lattice_frame(const gs_model_lattice *l, int t, gs_model_lattice *out);
/* 4D: the first min(frames, max_frames) frames side by side along x, gap
 * empty columns between them (a 3D lattice to render or mesh; frame 0 at x
 * = 0). A 3D lattice comes out as a copy. */
gs_err gs_model_lattice_filmstrip(const gs_model_lattice *l, int gap, int max_frames,
                                  gs_model_lattice *out);
/* Digest of the labels (gs_digest_bytes over the array plus dims; plus the
 * frames of a 4D lattice). */
uint64_t gs_model_lattice_digest(const gs_model_lattice *lat);

/* Reads Paul Merrell's samples/NAME.txt format: three free header lines, then
 * "X Y Z" extents, then X*Y*Z integers read z outermost, then x, then y
 * innermost; an optional "<Objects>" section ends the labels and is ignored.
 * A 4D lattice (geosynth's extension, Sec. 4.3) has a fourth extent T on
 * the same line, "X Y Z T", and T frames of X*Y*Z labels, frame 0 first,
 * each in the order above (read as frames = T, nz = Z*T).
 * Errors name the file and line ("castle.txt:7: expected a label in
 * [0, 65535], got 'a'"). On error *out is left unchanged. */
gs_err gs_model_read_merrell_txt(const char *path, gs_model_lattice *out);
/* Same as above from a memory buffer; name is used in messages. */
gs_err gs_model_parse_merrell_txt(const char *text, size_t len, const char *name,
                                  gs_model_lattice *out);
/* Writes a lattice in the same format (readable by the reader above and by
 * the author's editor scripts, without an <Objects> section; a 4D lattice
 * with its fourth extent). */
gs_err gs_model_write_merrell_txt(const char *path, const gs_model_lattice *lat);

/* Reads DeBroglie's CSV lattice format (its samples/merrell/NAME.csv, the
 * input of DeBroglie's CsvImporter): rows of comma-separated integer labels
 * (blanks around them allowed), one row per y, one column per x; layers of
 * rows, z = 0 first, separated by blank lines (several blank lines, or blank
 * lines at the start or end, separate nothing more). Every row has the same
 * number of labels and every layer the same number of rows. Labels are in
 * [0, 65535], 0 = empty as in Merrell's lattices. DeBroglie's copies of
 * Merrell's escheresque and parliament hold the same integers as his .txt
 * files, so read this way they are his lattices with x and y swapped (a
 * mirror image: DeBroglie's x is his y). Errors name the file and line
 * ("parliament.csv:23: field 7: expected a label in [0, 65535], got 'a'").
 * On error *out is left unchanged. */
gs_err gs_model_read_debroglie_csv(const char *path, gs_model_lattice *out);
/* Same as above from a memory buffer; name is used in messages. */
gs_err gs_model_parse_debroglie_csv(const char *text, size_t len, const char *name,
                                    gs_model_lattice *out);

/* ---- rules learned from the example ------------------------------------- */

enum { GS_MODEL_DIRS = 8 }; /* +-x, +-y, +-z, +-t */
#define GS_MODEL_FREE 0xffffu /* "no label": unpinned cell */

typedef struct gs_model_rules *gs_model_rules_t;

/* Learns the transition bitsets and label frequencies from an example.
 * The example must contain at least one label. Caller frees with
 * gs_model_rules_destroy(). On error *out is left unchanged. */
gs_err gs_model_rules_learn(const gs_model_lattice *example, gs_model_rules_t *out);
void gs_model_rules_destroy(gs_model_rules_t *rules);
/* Label symmetry (paper Sec. 4.1, T' = S.T): S[l] is the label that label l
 * becomes when the model is mirrored along axis ax (S[S[l]] = l), -1 = no
 * image. Learned from the transition function: b is a candidate image of a
 * when b's neighbour sets along every direction d equal a's along d mirrored
 * (neighbour counts first, then refined until every neighbour of a has a
 * candidate image among b's neighbours); an exact involution (every pair
 * (a, d, b) has its image (S a, d', S b)) is searched with labels mapping to
 * themselves first; when none is found within a budget, *exact = 0 and each
 * label takes its first consistent candidate or none. S has nlabels entries. */
gs_err gs_model_rules_learn_mirror(const gs_model_rules_t rules, int ax, int *S, int *exact);
/* ax = 3: the mirror across the diagonal x = y (x and y directions swap);
 * a 90-degree turn about z is that mirror followed by the x mirror, R l =
 * Sx(Sdiag l).
 * Rotation-symmetric model (90 degrees about z, paper Sec. 4.1): keeps a
 * pair (a, d, b) only when (R a, d turned, R b) is allowed too, until
 * nothing changes, and sets directions 6/7 (unused by a 3D lattice) to the
 * quarter's rotation face: b in allow[a][6] when R b may sit at +x of a
 * (the cell beyond the +x face of the lower-left quarter at (h-1, y) is the
 * turned image of the quarter's cell (y, h-1); gs_model_params.rotate_map).
 * R[l] = -1: l has no image and loses its pairs. Modifies rules in place. */
gs_err gs_model_rules_rotation(gs_model_rules_t rules, const int *R, size_t *dropped);
/* An involution S for an example whose pairs are not exactly symmetric
 * (castle.txt: its walls along x are longer than along y, so no exact
 * diagonal S exists): starting from the identity, a label swaps with
 * another found at the same layers of ex when that keeps more of the
 * example's pairs (a, d, b) with an allowed image (S a, d', S b), until no
 * swap helps. *kept / *total (may be NULL): pairs kept, all pairs. */
gs_err gs_model_rules_learn_mirror_near(const gs_model_rules_t rules, const gs_model_lattice *ex,
                                        int ax, int *S, size_t *kept, size_t *total);
/* S from label pairs "A B, C D" (config key named in errors): listed labels
 * swap, other present labels map to themselves, absent ones to -1. */
gs_err gs_model_rules_mirror_pairs(const gs_model_rules_t rules, const char *key,
                                   const char *text, int *S);
/* Symmetric model: along every axis with axes[a] set, keeps a pair (a, d, b)
 * only when its mirror image (S a, d mirrored, S b) is allowed too (maps[a]
 * = S along that axis; maps or maps[a] NULL = identity), until nothing
 * changes, so any consistent model stays consistent when mirrored and its
 * labels mapped by S (needed for gs_model_params.mirror). *dropped (may be
 * NULL) = pairs removed. Modifies rules in place. */
gs_err gs_model_rules_symmetrize(gs_model_rules_t rules, const int axes[3], const int *const maps[3],
                                 size_t *dropped);
/* Number of label values (largest label + 1). */
int gs_model_rules_nlabels(const gs_model_rules_t rules);
/* 1 when label b may sit at v+e_dir next to label a at v. */
int gs_model_rules_allows(const gs_model_rules_t rules, int dir, int a, int b);
/* Occurrences of label in the example (0 for absent labels). */
uint64_t gs_model_rules_count(const gs_model_rules_t rules, int label);
/* Number of adjacent pairs of lat that the rules forbid (fast, uses the
 * learned bitsets; the independent check is gs_model_check()). */
size_t gs_model_rules_violations(const gs_model_rules_t rules, const gs_model_lattice *lat);

/* ---- independent checker ------------------------------------------------- */

typedef struct gs_model_violation {
    int x, y, z;   /* first cell */
    int dir;       /* 0 +x, 2 +y, 4 +z, 6 +t: the second cell is at +1 along that
                      axis (+t: the same cell of the next frame) */
    uint16_t a, b; /* labels of the first and second cell */
} gs_model_violation;

/* Lists the adjacent pairs of output that never occur in example along the
 * same direction (4D lattices: along t too, the same cell of consecutive
 * frames; along z only inside a frame), recomputing the allowed pairs from the example directly
 * (shares no code with the synthesizer). Also flags cells whose label never
 * occurs in the example (reported as a pair with itself, dir = -1).
 * Writes at most cap entries to out (out may be NULL when cap == 0) and the
 * total count to *count. */
gs_err gs_model_check(const gs_model_lattice *example, const gs_model_lattice *output,
                      gs_model_violation *out, size_t cap, size_t *count);

/* ---- parameters ----------------------------------------------------------- */

typedef enum gs_model_order {
    GS_MODEL_ORDER_SCAN = 0,    /* author's scan: z fastest, then y, then x */
    GS_MODEL_ORDER_RANDOM = 1,  /* a random permutation of the region's cells */
    GS_MODEL_ORDER_ENTROPY = 2, /* fewest candidates first, random tie-break */
    GS_MODEL_ORDER_ENTROPY_LOG = 3, /* fewest candidates by binary order of magnitude
                                       (2-3, 4-7, ...), fresh random tie-break per
                                       update: less front growth along one axis */
    GS_MODEL_ORDER_ENTROPY_LAYERS = 4, /* fewest candidates first; ties go to the
                                          lowest layer, then to the cell nearest a
                                          region face with output beyond it, then at
                                          random (the output grows up from the ground
                                          and in from the decided shell) */
    GS_MODEL_ORDER_ENTROPY_COLUMNS = 5 /* fewest candidates first; ties go to the
                                          cell nearest a region face with output
                                          beyond it, then to the lowest layer, then at
                                          random (the region grows in from its decided
                                          shell ring by ring, each ring's columns from
                                          the ground up) */
} gs_model_order;

typedef enum gs_model_weights {
    GS_MODEL_WEIGHTS_UNIFORM = 0,   /* every candidate equally likely (author) */
    GS_MODEL_WEIGHTS_FREQUENCY = 1  /* proportional to occurrences in the example */
} gs_model_weights;

typedef enum gs_model_ac {
    GS_MODEL_AC3 = 3, /* bitset AC-3 over cells (default: faster here) */
    GS_MODEL_AC4 = 4  /* support counts (Mohr-Henderson) */
} gs_model_ac;

typedef struct gs_model_params {
    uint64_t seed;
    int region[3];      /* region edge per axis; 0 or >= extent = whole axis */
    int overlap;        /* cells shared by neighbouring regions along an axis
                           (stride = edge - overlap, at least 1); -1 = half
                           the edge (default) */
    int region_jitter;  /* > 0 (with overlap 0): x and y region edges drawn per
                           region around edge (+-J; rows of regions whose x cuts
                           are staggered, staircase lines between rows: no line
                           crosses the output), keyed by (seed, pass): no regular
                           grid (synth.c jitter_plan) */
    int attempts;       /* tries per region before keeping the old content */
    int min_changes;    /* accepted regions each active cell must be part of */
    int max_passes;     /* sweeps at most */
    int fix_z_faces;    /* keep bottom/top layers of the initial model (nz >= 3) */
    int backtracks;     /* undo budget per attempt (AC-3 only); 0 = none, as in the paper */
    int backjump;       /* > 0: on a wipe-out undo back to the latest decision within this
                           many cells (each axis) of the emptied cell and refute that one,
                           not the latest decision (0 = chronological, as before) */
    int rewinds;        /* > 0: when the undo budget runs out, undo the latest 30% of the
                           decisions unrefuted and go on with a fresh budget, up to this
                           many times per try, before the try fails (0 = fail, as before) */
    gs_model_order order;
    gs_model_weights weights;
    gs_model_ac ac;
    int split_depth;    /* a region whose tries all fail is split into 2x2
                           sub-boxes (x, y halves), each tried again with its
                           resampled siblings fixed; failing sub-boxes split
                           again, up to this many levels (0 = off, as before) */
    const uint16_t *pins; /* hard constraints: one entry per lattice cell (x
                           fastest), GS_MODEL_FREE or the label the cell must
                           take; a region containing a pinned cell only keeps
                           that label there (NULL = none; not owned) */
    const uint8_t *support_empty; /* [labels] 1 = the label is empty space: a region try
                           is rejected when one of its non-empty cells has no 6-connected
                           path of non-empty cells to the ground layer (z = 0) or to a
                           non-empty cell next to the region (floating structure); NULL =
                           no such check. Set for model.overlap3d when the example has no
                           unsupported structure (not owned). The cells next to the region
                           may have lost their own support to the region: exact only in
                           whole-grid mode (or with support_global); the engine repairs
                           what regions left floating after the passes */
    const uint8_t *support_above; /* [labels] with support_empty: bit k - 1 = the cell k
                           layers above a top-layer cell holding the label is non-empty
                           (the N - 1 layers model.overlap3d decodes over the top pattern
                           layer), for gs_model_support_floating; NULL = none */
    int support_layers_above; /* how many such layers (0..7) */
    int support_global;   /* with support_empty: the try's check follows paths through
                           the whole lattice (exact; cost linear in the lattice), not
                           only through the box to the cells next to it (the model
                           engine's repair of floating structure after the passes) */
    const float *shape; /* soft constraint (paper Sec. 4.2): nx*ny target values in
                           [0, 1] (x fastest), 1 = structure belongs in the column,
                           0 = none. Two parts: the constraint-weighted label choice
                           (Eq. 6 modified): a structure label (see structure) gets
                           weight exp(g*(2m-1)), any other exp(-g*(2m-1)), g =
                           shape_weight, times its resemblance multiplicity when
                           resem is set; and the Metropolis step: a resampled
                           region is accepted with probability min(1, f(M')/f(M)),
                           f(M) = exp(shape_mh * sum over cells of s(c)*(2m-1)),
                           s(c) = 1 for a structure label. NULL = none; not owned */
    double shape_weight;
    double shape_mh;    /* beta of f(M) per cell; 0 = every consistent region
                           accepted (no Metropolis step) */
    int shape_slack;    /* with resem: where the target is below 0.5 the choice
                           also considers neighbourhoods up to this much farther
                           than the closest (d0 + shape_slack), weighted as above */
    const uint8_t *structure; /* [nlabels] 1 = structure label
                           (gs_model_structure_labels); required with shape */
    int mirror[3];      /* 1 = the lattice is the lower half of an output that is
                           mirror-symmetric along that axis: the cell beyond the
                           upper face is the face cell's mirror image (itself
                           when the full extent is even, mirror_odd[a] = 0; its
                           lower neighbour when odd), its label mapped by
                           mirror_map. Output = half + S(mirror). */
    int mirror_odd[3];
    const int *mirror_map[3]; /* label symmetry S along each mirrored axis
                           (gs_model_rules_learn_mirror; NULL = identity): the
                           mirror half holds S(label); a face cell's label l
                           needs (l, S l) allowed across the face (even extent)
                           or S l = l (odd: the shared centre). Not owned */
    const int *rotate_map; /* 90-degree rotation symmetry (NULL = none): the
                           lattice is the lower-left h x h quarter of an output
                           that looks the same turned by 90 degrees about z,
                           the label of a cell turned mapped by rotate_map (R);
                           rules from gs_model_rules_rotation; the cell (h-1, y)
                           and (y, h-1) are joined along direction 6/7 (a region
                           must span the whole quarter in x and y). Not owned */
    const uint64_t *ground; /* overlapping model `ground` (WFC samples.xml): label
                           bitset (nlabels bits, 64 per word) the cells of the
                           lattice's last y row (the picture's bottom) are
                           limited to; NULL = none. Not owned */
    const uint64_t *ground_only; /* labels banned from every other row (patterns
                           found only on the sample's bottom row); NULL = none */
    const uint64_t *zface[2]; /* without fix_z_faces: label bitsets the cells of the
                           bottom (z = 0) and top (z = nz - 1) layers are limited to
                           (the labels of the example's own bottom and top layers);
                           NULL = none. Not owned */
    const uint64_t *xyface[4]; /* label bitsets the cells of the output's x = 0,
                           x = nx - 1, y = 0, y = ny - 1 faces are limited to (the
                           engine's model.fix_xy_faces: the example's own face labels);
                           NULL = none. Not owned */
    const uint16_t *outside_column; /* the cells past the output's x and y faces
                           hold this column (nz labels, bottom first; the engine's
                           model.fix_xy_faces with model.overlap3d: the start model's
                           own column, Merrell's trivial model around the output), so
                           face cells must sit next to it; NULL = free. Not owned */
    int periodic[3];    /* 1 = the output wraps along that axis (x, y; z only
                           without fix_z_faces): cell n-1 is adjacent to cell 0
                           and the rules hold across the wrap */
    const struct gs_model_resem *resem; /* resemblance (paper Sec. 3.3): the label
                           of a cell is the centre of an example neighbourhood
                           drawn among those closest to the cell's decided
                           neighbours (gs_model_resem_build); replaces
                           `weights` (shape, when set, takes precedence).
                           NULL = off; not owned */
} gs_model_params;

/* ---- resemblance (paper Sec. 3.3, Eqs. 2-6) -------------------------------- */

/* Index of the example's (2w+1)^3 neighbourhoods (w = 1 or 2). When a cell v
 * is labelled, every example location v' with E[v'] a candidate of v is
 * compared with the cell's neighbourhood in the model: the decided cells
 * (outside the region: the current labels; inside: cells with one candidate
 * left; outside the output: nothing) that equal E at the same offset from v'
 * are matches, d = |window| - matches - 1 (Eq. 3 with (v, E[v']) added).
 * The locations with d <= d0, d0 = the smallest d + slack (the paper: the
 * minimum), are the L(k) of Eq. 4 for k = E[v'] (Eq. 5: only candidates),
 * and k is drawn with P(k) = L(k) / sum L (Eq. 6). Unlike Eq. 4 a location
 * counts only for its own centre label (a location matching equally well
 * with another centre would add the same count to every label). Neighbours
 * past the example's faces match nothing by default (half a match, a
 * match, or a match against the face background with gs_model_resem_set_outside). With no decided neighbour every
 * location ties, so P(k) is the example's frequency of k.
 * layers != 0 (an extension, not in the paper): output and example stand on
 * the same ground, so a cell at height z only considers the locations of
 * example layer min(z, example nz - 1) (all locations when none of them has
 * a candidate centre): structure stays at the heights where the example has
 * it instead of hanging from the fixed empty top.
 * Cost per choice: O(Q * words of the candidate patterns); memory Q*L*4 +
 * (distinct (offset, label) pairs) * P/8 bytes, P = distinct patterns. */
typedef struct gs_model_resem *gs_model_resem_t;
gs_err gs_model_resem_build(const gs_model_lattice *example, int w, int slack, int layers,
                            gs_model_resem_t *out);
/* The same with wrap_xy != 0: the example taken as a tile (repeated along x and
 * y), so a neighbour past its x/y faces is the example's cell a period away;
 * past its z faces it is outside as above. */
gs_err gs_model_resem_build_wrap(const gs_model_lattice *example, int w, int slack, int layers,
                                 int wrap_xy, gs_model_resem_t *out);
/* What a neighbourhood cell past the example's faces scores against a decided
 * output neighbour: 0 a mismatch (as a defined different label), 1 half a
 * match, 2 a match (the paper's distance over defined cells only), 3 a match
 * when the output neighbour is the example's face background of its layer
 * (the commonest label on the example's x/y faces there: what the example
 * most likely holds past them) and a mismatch otherwise. A defined equal
 * label scores a match. The default after build is 0. With
 * gs_model_resem_build_wrap only cells past the z faces are outside. */
void gs_model_resem_set_outside(gs_model_resem_t r, int weight);
/* Label-frequency soft constraint on the choice (paper Sec. 4.2: Eq. 6 modified
 * so that labels that fit the constraint better are likelier): every drawn
 * neighbourhood's weight is multiplied by ((t*D + 1) / (n + 1))^beta for its
 * centre label k, D = the decided cells of the cell's layer in the region, n =
 * those holding k, t = k's share of the matching example layer (min(z, nz - 1),
 * as the layers option) or, layers off, of the whole example: a label the layer
 * so far holds less often than the example's layer does is drawn more often,
 * one it holds too often less. The counts are refreshed every n/64 choices
 * (decided by propagation too). beta = 0 (the build's default): off. */
gs_err gs_model_resem_set_frequency(gs_model_resem_t r, const gs_model_lattice *example,
                                    double beta);
void gs_model_resem_destroy(gs_model_resem_t *r);
/* Distinct neighbourhood patterns of the index (0 for NULL). */
int gs_model_resem_patterns(const gs_model_resem_t r);

/* Defaults: whole grid, overlap -1 (half the edge), attempts 20, min_changes 1, max_passes 4,
 * fix_z_faces 1, backtracks 1000 (x1, x2, x4, x8 over the quarters of the
 * tries), split_depth 2, order ENTROPY, weights UNIFORM, AC3, seed 1, not
 * periodic. */
void gs_model_params_default(gs_model_params *p);

/* ---- initial model -------------------------------------------------------- */

/* Builds the trivial consistent start: every column equal to one column of
 * labels, each horizontally self-tileable (T_x(l,l) and T_y(l,l)) with valid
 * vertical transitions. The column is searched by dynamic programming over
 * z, preferring the example's corner column (padded with empty above) and
 * then labels frequent in the same example layer. column (nz labels) may
 * be NULL for the inferred one; a given column is only verified. Fails with
 * GS_ERR_ARG naming the offending pair when no consistent column exists.
 * out must already have the output dims; all its labels are overwritten. */
gs_err gs_model_initial(const gs_model_rules_t rules, const gs_model_lattice *example,
                        const uint16_t *column, gs_model_lattice *out);
/* Same, the inferred column's bottom label in the label bitset bottom and
 * its top label in top (NULL = any): the 3D overlapping model's z faces. */
gs_err gs_model_initial_faces(const gs_model_rules_t rules, const gs_model_lattice *example,
                              const uint16_t *column, const uint64_t *bottom,
                              const uint64_t *top, gs_model_lattice *out);
/* Same, the inferred column preferring prefer (the example's nz labels, bottom
 * first; NULL = its corner column) over the corner column. */
gs_err gs_model_initial_prefer(const gs_model_rules_t rules, const gs_model_lattice *example,
                               const uint16_t *column, const uint16_t *prefer,
                               const uint64_t *bottom, const uint64_t *top,
                               gs_model_lattice *out);
/* The example's commonest column (nz labels, bottom first, into col; ties: the
 * lowest labels from the bottom up): model.start_column_from = commonest. */
gs_err gs_model_commonest_column(const gs_model_lattice *example, int faces, uint16_t *col);

/* Tiled start with real variety: synthesizes a tile*tile*nz block that is
 * periodic in x and y (whole block, start = the trivial column model, fixed z
 * faces as p says, attempts/backtracks of p, random stream keyed by p->seed)
 * and repeats it over out. Because the tile is periodic the repeated model is
 * consistent, and the shell of every region offers the example's variety
 * instead of one column's few horizontal neighbours (city: the trivial
 * column forces every region). When no attempt succeeds, out is the trivial
 * column model and *tiled = 0. out must have its dims; labels overwritten. */
gs_err gs_model_initial_tiled(const gs_model_rules_t rules, const gs_model_lattice *example,
                              const gs_model_params *p, int tile, gs_model_lattice *out,
                              int *tiled);

/* Pinned cells (p->pins) whose label in lat differs from the pin. */
size_t gs_model_pins_unmet(const gs_model_params *p, const gs_model_lattice *lat);

/* Violations like gs_model_rules_violations(), also counting the pairs across
 * the wrap on the axes with periodic[a] != 0. */
size_t gs_model_rules_violations_wrap(const gs_model_rules_t rules, const gs_model_lattice *lat,
                                      const int periodic[3]);

/* ---- regions and the serial driver ---------------------------------------- */

typedef struct gs_model_box {
    int x0, y0, z0; /* inclusive */
    int x1, y1, z1; /* exclusive */
} gs_model_box;

typedef struct gs_model_region {
    gs_model_box box;
    uint32_t id;     /* index in the pass plan; plans are sorted by (color, id) */
    uint32_t color;  /* regions of one color never touch (gap >= 1 cell) */
} gs_model_region;

/* The regions of one pass for an nx*ny*nz output. Odd passes shift the
 * region grid by a quarter region so seams move. Caller frees *regions with
 * gs_free(). */
gs_err gs_model_plan(const gs_model_params *p, int nx, int ny, int nz, int pass,
                     gs_model_region **regions, size_t *nregions, int *ncolors);
/* Cells of the plan's largest box (0 for an empty plan). */
size_t gs_model_plan_max_cells(const gs_model_region *plan, size_t n);

/* Merrell's modify in blocks for a sweep after the first (model.open_blocks,
 * issue #18): each region of plan[0..n), in plan order, grows along x and y
 * over every structure of lat with a column in it or in its face-neighbour
 * shell (the structure's bounding box grown by one), repeated until no more
 * such structure fits in cap cells per axis (larger ones it rebuilds across);
 * it is kept only if it interacts with no region kept before it and, with
 * claim (model.open_blocks_largest), meets (a column in its box or shell) no
 * structure a region kept before it meets; then the kept regions are put
 * largest first (x/y cells; ties: plan order) and owner[nx * ny] (if not
 * NULL) gets, per column, the kept region meeting its structure (-1 none).
 * A structure = an 8-connected set of columns with a non-empty cell above layer ground
 * (the example's lowest layer holding an empty cell). The kept regions, one
 * colour, are moved to the front of plan and renumbered; *n and *ncolors
 * (1) set. With overlap 0 every region of the first sweep closes its
 * structures inside it; these regions straddle its lines. */
gs_err gs_model_plan_open_blocks(const gs_model_params *p, const gs_model_lattice *lat,
                                 int ground, int cap, int claim, gs_model_region *plan,
                                 size_t *n, int *ncolors, int32_t *owner);

/* 1 when regions a and b of an nx*ny*nz output interact: one writes a cell
 * the other reads (its box and the face neighbours around it, across
 * periodic wraps and mirror faces as gs_model_region_run reads them; with
 * p->resem also the box grown by the window radius w along every axis at
 * once, edges and corners included: the resemblance window of a box cell).
 * Symmetric. Regions of
 * one colour of a plan never interact; the parallel engine runs regions of
 * different colours at once when they do not. */
int gs_model_regions_interact(const gs_model_params *p, int nx, int ny, int nz,
                              const gs_model_box *a, const gs_model_box *b);

/* The interacting pairs of plan[0..n) (sorted by colour, as gs_model_plan
 * makes them): for region i, ids[offsets[i] .. offsets[i+1]) are the ids
 * of the regions j < i of a lower colour with gs_model_regions_interact,
 * in ascending j: the list gs_regions_set_conflicts takes. O(n) through
 * buckets of the region edge, not a test of every pair. Caller frees
 * *offsets ([n + 1]) and *ids with gs_free. */
gs_err gs_model_plan_conflicts(const gs_model_params *p, int nx, int ny, int nz,
                               const gs_model_region *plan, size_t n, int64_t **offsets,
                               int64_t **ids);

typedef struct gs_model_solver *gs_model_solver_t;

/* Scratch space for region synthesis (grows on demand). One per thread. */
/* Floating structure of a lattice of labels (nx*ny*nz, x fastest): st
 * (nx*ny*(nz + layers above), see gs_model_params.support_above) gets 0 for
 * empty (p->support_empty), 2 for a non-empty cell with a 6-connected path
 * of non-empty cells to z = 0 (x / y wrapping where p->periodic), 1 for a
 * floating one. Returns how many float, SIZE_MAX when out of memory. */
size_t gs_model_support_floating(const uint16_t *labels, int nx, int ny, int nz,
                                 const gs_model_params *p, uint8_t *st);

gs_err gs_model_solver_create(const gs_model_rules_t rules, gs_model_ac ac,
                              gs_model_solver_t *out);
void gs_model_solver_destroy(gs_model_solver_t *s);

typedef struct gs_model_region_result {
    int ok;               /* 1 = new labels in out, 0 = gave up somewhere (see partial) */
    int partial;          /* ok = 0 but sub-boxes succeeded: out mixes new labels with
                             kept_cells old ones, consistent; apply it */
    int split;            /* the whole-box tries failed and the box was split */
    uint64_t kept_cells;  /* cells that kept their old labels */
    int attempts;         /* tries used (over the box and its sub-boxes) */
    uint64_t choices;     /* labels picked at random (over all attempts) */
    uint64_t backtracks;  /* decisions undone (over all attempts) */
    int mh_rejected;      /* ok = partial = 0: the new labels were consistent but the
                             Metropolis step (params.shape_mh) kept the old ones */
} gs_model_region_result;

/* Synthesizes one region: reads lat (box and its one-cell shell), writes
 * (x1-x0)*(y1-y0)*(z1-z0) labels to out (x fastest within the box). Depends
 * only on (lat, box, p, region_id, pass); randomness from gs_rng streams
 * keyed by (p->seed, region id, pass, attempt). Does not modify lat. */
gs_err gs_model_region_run(gs_model_solver_t s, const gs_model_lattice *lat,
                           const gs_model_box *box, const gs_model_params *p,
                           uint64_t region_id, uint64_t pass, uint16_t *out,
                           gs_model_region_result *res);
/* Copies a region's labels into lat. */
void gs_model_region_apply(gs_model_lattice *lat, const gs_model_box *box,
                           const uint16_t *labels);

typedef struct gs_model_stats {
    uint64_t regions;    /* region runs */
    uint64_t accepted;   /* regions whose new labels were applied */
    uint64_t failed;     /* regions where some cells kept their old content after all
                            attempts (whole box and sub-boxes) */
    uint64_t split;      /* regions rescued or partly rescued by splitting */
    uint64_t kept_cells; /* cells of failed regions that kept their old labels */
    uint64_t attempts;   /* tries over all regions (retries = attempts - regions) */
    uint64_t choices;    /* random label choices */
    uint64_t backtracks; /* decisions undone */
    uint64_t mh_rejected; /* consistent regions the Metropolis step did not accept */
    int passes;          /* sweeps done */
    uint64_t min_coverage; /* fewest accepted regions over any active cell */
    double seconds;
} gs_model_stats;

/* Serial driver: sweeps the plan pass after pass over lat (which must be
 * consistent, e.g. from gs_model_initial) until every active cell has been in
 * p->min_changes accepted regions or p->max_passes passes ran. stats may be
 * NULL. lat stays consistent whatever the outcome. */
gs_err gs_model_synthesize(const gs_model_rules_t rules, const gs_model_params *p,
                           gs_model_lattice *lat, gs_model_stats *stats);

/* ---- statistics ------------------------------------------------------------ */

/* Mean length of runs of equal non-empty labels along each axis (x, y, z);
 * a streaking output has longer runs than its example along the scan axes. */
void gs_model_run_lengths(const gs_model_lattice *lat, double mean[3]);

#endif
