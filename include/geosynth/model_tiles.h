/* model: tile-set and sample inputs in the style of WaveFunctionCollapse
 * (3D voxel tile sets: see "3D tile sets" below). 2D (mxgmn): the simple
 * tiled model (a tile set XML with explicit tiles, symmetries and neighbour
 * lists) and the overlapping model (N x N patterns learned from a sample
 * image). Both become an ordinary gs_model_rules over labels, so the core
 * solver (model.h) and the region runner synthesize them unchanged.
 *
 * Labels: oriented tile (or pattern) i is label i + 1; label 0 stays "empty"
 * and never occurs in these rules.
 *
 * Orientation convention: lattice x = image column, lattice y = image row
 * (row 0 at the top of the output PNG), i.e. direction 2 (+y) is "down" in
 * the picture, as in mxgmn's code (dy = +1 is down).
 *
 * Tile set XML (mxgmn's format, tilesets/NAME.xml):
 *   <set unique="False|True">            unique: one PNG per orientation
 *     <tiles><tile name="corner" symmetry="L" weight="0.5"/> ...</tiles>
 *     <neighbors><neighbor left="corner 1" right="t"/> ...</neighbors>
 *     <subsets><subset name="Standard"><tile name="corner"/>...</subset></subsets>
 *   </set>
 * symmetry X (1 orientation), I and \ (2), L and T (4), F (8); the default
 * is X, the default weight 1. "name k" is orientation k of a tile (k counted
 * as mxgmn: 1..3 = 90-degree rotations, 4..7 = their mirror images). A
 * neighbour pair "left right" allows right to the right of left and, by
 * symmetry, the rotated and mirrored pairs exactly as mxgmn expands them.
 * Tile images: NAME.png in the folder named after the XML (without .xml) next
 * to it, or "NAME k.png" per orientation when unique="True".
 * Errors name the file and line ("Knots.xml:14: neighbor left=\"corner 9\":
 * tile corner has 4 orientations").
 */
#ifndef GEOSYNTH_MODEL_TILES_H
#define GEOSYNTH_MODEL_TILES_H

#include <mpi.h>
#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/image.h"
#include "geosynth/model.h"

/* One allowed adjacency: label b at v + e_dir next to label a at v, dir 0
 * (+x) or 2 (+y). */
typedef struct gs_model_pair {
    uint8_t dir;
    uint16_t a, b;
} gs_model_pair;

/* Builds rules from explicit allowed pairs (both orders are derived: a pair
 * (+x, a, b) also allows a at -x of b). counts[l] (l < nlabels) are the
 * choice weights used by GS_MODEL_WEIGHTS_FREQUENCY; a label with count 0
 * is absent (never chosen). Pairs with labels >= nlabels or dir not in
 * {0, 2, 4} are GS_ERR_ARG. Free with gs_model_rules_destroy(). */
gs_err gs_model_rules_from_pairs(int nlabels, const gs_model_pair *pairs, size_t npairs,
                                 const uint64_t *counts, gs_model_rules_t *out);

typedef struct gs_model_tileset {
    int ntiles;           /* oriented tiles; label of tile i = i + 1 */
    char (*names)[72];    /* "corner 1" */
    double *weight;       /* [ntiles] */
    gs_model_pair *pairs; /* allowed (dir 0 / 2, and 4 in 3D) pairs, sorted, unique */
    size_t npairs;
    int tile_w, tile_h;   /* pixels (0 when images were not loaded) */
    uint8_t *pixels;      /* [ntiles][tile_h][tile_w][4] RGBA, NULL without images */
    /* Voxel (3D) tile sets, see "3D tile sets" below; dim = 2 otherwise and
     * the fields below stay zero. */
    int dim;              /* 2: mxgmn PNG tiles (z = 1 only), 3: voxel tiles */
    int vx, vy, vz;       /* voxels per tile */
    uint8_t *voxels;      /* [ntiles][vz][vy][vx] colour index (0 empty) of vox_palette */
    uint8_t vox_palette[256][4];
    int group;            /* symmetry group order: 1, 2, 4, 8 (about z) or 48 (cube) */
    int nbase;            /* declared tiles; oriented tile i is orientation orient[i]
                             (an element of the group) of declared tile base[i] */
    int *base, *orient;   /* [ntiles] */
    int ground;           /* label on the whole z = 0 layer and nowhere else; 0 = none */
    int border;           /* label on the cells of the border sides; 0 = none */
    unsigned border_sides; /* bits 0-5: the sides (xmin xmax ymin ymax zmin zmax)
                              a border cell lies on one of; bits 6-11: sides
                              it lies on none of */
    int nfixed;
    int (*fixed)[4];      /* [nfixed] x y z label */
} gs_model_tileset;

/* Parses the tile set at path restricted to subset (NULL or "" = every
 * tile), expands the symmetries, and when images is 1 loads and orients the
 * tile PNGs. *out must be zeroed; on error it stays zeroed. */
gs_err gs_model_tileset_load(const char *path, const char *subset, int images,
                             gs_model_tileset *out);
/* Same, for any tile set: path ending in .json is a DeBroglie voxSet config,
 * an XML whose root is <tileset> a MarkovJunior set (3D), <set> mxgmn's (2D).
 * folder: MarkovJunior's tile folder relative to the XML's directory (its
 * "tiles" attribute, e.g. "Knots3D/3"); NULL or "" = the XML's name. Voxel
 * tiles are loaded whatever images says (their faces decide adjacency). */
gs_err gs_model_tileset_load_any(const char *path, const char *subset, const char *folder,
                                 int images, gs_model_tileset *out);
void gs_model_tileset_destroy(gs_model_tileset *ts);
/* Collective: the tile set root parsed (gs_model_tileset_load_any) reaches
 * every rank of comm, whose *ts must be zeroed: every field but the tile
 * images (pixels stay on root, tile_w = tile_h = 0 elsewhere, as loading
 * without images gives). Inputs are parsed on rank 0 only (#25). Call it
 * after the parse's status was agreed. On error the receivers' *ts is
 * zeroed and every rank returns the same code. */
gs_err gs_model_tileset_bcast(MPI_Comm comm, int root, gs_model_tileset *ts);
/* Rules of the tile set; counts = weight scaled to integers (weight *
 * 10^6, at least 1). */
gs_err gs_model_tileset_rules(const gs_model_tileset *ts, gs_model_rules_t *out);
/* Writes the z = 0 layer as an RGBA PNG assembled from the tile images
 * (label 0 or out-of-range cells transparent). Needs images. */
gs_err gs_model_tileset_write_png(const char *path, const gs_model_tileset *ts,
                                  const gs_model_lattice *lat);

/* Independent checker: lists the adjacent pairs of lat (every z layer, x and
 * y neighbours, and any z neighbours) that the tile set's neighbour list
 * does not allow, and cells whose label is no tile (dir -1). Uses only the
 * parsed pair list (sorted keys, binary search), not the solver's bitsets.
 * Same output contract as gs_model_check(). */
gs_err gs_model_tileset_check(const gs_model_tileset *ts, const gs_model_lattice *lat,
                              gs_model_violation *out, size_t cap, size_t *count);

/* ---- 3D tile sets ---------------------------------------------------------
 *
 * Voxel tiles (each a MagicaVoxel .vox of vx x vy x vz voxels, all the same
 * size; colours merged into one palette by RGBA) under a symmetry group G of
 * signed axis permutations: G = the 48 rotations and mirrors of the cube
 * (MarkovJunior fullSymmetry="True", cubic tiles), or the 8 (DeBroglie
 * "symmetry": 8; MarkovJunior without fullSymmetry) / 4 / 2 / 1 rotations and
 * mirrors about z. A voxel at centred position c of a tile goes to M c under
 * the group element M. The orientations of a tile are its distinct voxel
 * contents under G (the first element of G giving each is orient[]), so a
 * tile's stabilizer comes from its voxels; every allowed pair (a, b, +axis)
 * brings (M a, M b, M axis) for every M in G (b, a when M axis is negative).
 *
 * MarkovJunior (resources/tilesets/NAME.xml):
 *   <tileset fullSymmetry="True"> <tiles><tile name="Line" weight="2"/>...
 *   <neighbors><neighbor left="Line" right="z Turn"/> <neighbor top="A"
 *   bottom="B"/>...</neighbors></tileset>; tiles in NAME/TILE.vox. "xz Turn"
 *   = the tile Turn rotated by z then x: x, y, z turn by 90 degrees about that
 *   axis (x: +y to +z, y: +x to +z, z: +x to +y). left/right: right at +x of
 *   left; top/bottom: top at +z of bottom (sets without fullSymmetry).
 * DeBroglie (samples/castle/castle.json, "srcType": "voxSet"): tiles[] (src,
 *   value = name, tileSymmetry: checked against the voxels, multiplyFrequency
 *   = weight), "symmetry" (even: reflections + symmetry/2 rotations, odd:
 *   rotations only), "autoAdjacency" (b at +axis of a when a's last voxel
 *   layer along the axis equals b's first, voxel for voxel), "adjacencies"
 *   (left/right, up/down: down at +y, above/below: below at -z; every
 *   listed tile with every other), "ground" (that tile on the z = 0 layer
 *   and banned above: every pair putting it at +z of a tile is dropped),
 *   "constraints": border (tile on the sides, "excludeSides" cells not on
 *   them) and fixedTile (tile at point {x, y, z}). Comments and trailing
 *   commas are accepted as DeBroglie's reader does. Other keys are ignored;
 *   other constraint types and rotated tile names ("tile!90") are refused.
 */

/* Assembles the voxels of lat's tiles into one lattice of
 * (nx*vx) x (ny*vy) x (nz*vz) voxels (label = colour index, 0 empty) and its
 * palette. Cells whose label is no tile stay empty. */
gs_err gs_model_tileset_assemble(const gs_model_tileset *ts, const gs_model_lattice *lat,
                                 gs_model_lattice *out, uint8_t palette[256][4]);
/* Writes the assembled voxels as MagicaVoxel .vox (vox_path) and, when
 * preview_path is not NULL, the picture of the tiles (left, declared tiles in
 * a row) and the assembled output (right) with the built-in renderer, side
 * pixels per panel. GS_ERR_LIB when no renderer is available (the .vox is
 * written then). */
gs_err gs_model_tileset_write_voxels(const gs_model_tileset *ts, const gs_model_lattice *lat,
                                     const char *vox_path, const char *preview_path, int side);
/* Writes the tile set's constraints for an nx x ny x nz output (dims) into
 * pins (one entry per cell, GS_MODEL_FREE = free): the border tile on the
 * cells of the border sides and the fixed tiles at their points, on the
 * active layers (all of them, or 1..nz-2 when fixed_z_faces and nz >= 3:
 * the start model holds those); with fixed_z_faces = 0 also the ground tile
 * on the z = 0 layer. A fixed point outside the output is GS_ERR_ARG naming
 * file. */
gs_err gs_model_tileset_pins(const gs_model_tileset *ts, const char *file, const int dims[3],
                             int fixed_z_faces, uint16_t *pins);
/* The declared tiles side by side along x (one tile apart), each in its
 * first orientation: the picture of the "example" of a voxel tile set. */
gs_err gs_model_tileset_catalogue(const gs_model_tileset *ts, gs_model_lattice *out);

/* ---- overlapping model ----------------------------------------------------- */

typedef struct gs_model_patterns {
    int n;              /* pattern edge N */
    int npatterns;      /* label of pattern i = i + 1 */
    uint32_t *colors;   /* palette, RGBA packed 0xAABBGGRR */
    int ncolors;
    uint8_t *pat;       /* [npatterns][N*N] colour indices, row-major (row 0 top) */
    uint64_t *count;    /* [npatterns] occurrences (weights) */
    uint64_t *bottom;   /* [npatterns] of those, windows on the sample's bottom row
                           (origin y = H - N, as is or mirrored in x): ground */
    gs_model_pair *pairs;
    size_t npairs;
} gs_model_patterns;

/* Learns the N x N patterns of a sample image (colours exact, at most 255
 * colours and 65534 patterns): every N x N window (wrapping around when
 * periodic_input), with symmetry in 1..8 variants (1 = as is, 2 = + mirror,
 * up to 8 = all rotations and mirrors, mxgmn order), counted in order of
 * first occurrence; two patterns may be neighbours along +x / +y when they
 * agree on their overlap (N-1 columns / rows). *out zeroed on error.
 * Cost O(patterns^2 * N^2) for the adjacency. */
gs_err gs_model_patterns_learn(const char *png, int n, int symmetry, int periodic_input,
                               gs_model_patterns *out);
void gs_model_patterns_destroy(gs_model_patterns *p);
/* Collective: the patterns root learned reach every rank of comm (whose *p
 * must be zeroed), as gs_model_tileset_bcast. */
gs_err gs_model_patterns_bcast(MPI_Comm comm, int root, gs_model_patterns *p);
gs_err gs_model_patterns_rules(const gs_model_patterns *p, gs_model_rules_t *out);
/* Output image of a pattern lattice (z = 0): pixel (x, y) = top-left pixel
 * of the pattern at cell (x, y); the last N-1 columns/rows come from the
 * patterns of the border cells, so the image is (nx + N - 1) x (ny + N - 1). */
gs_err gs_model_patterns_write_png(const char *path, const gs_model_patterns *p,
                                   const gs_model_lattice *lat);
/* Independent checker for a pattern lattice: re-derives agreement of
 * every adjacent pair from the pattern pixels (no pair list). */
gs_err gs_model_patterns_check(const gs_model_patterns *p, const gs_model_lattice *lat,
                               size_t *count);

/* Rank 0, before the synthesis (#25): refuses, naming the file, the key and
 * the limit, an output the run could only fail to write after it, or write
 * unreadable: a 2D output (size z = 1) past GS_IMAGE_MAX_SIDE pixels per side
 * (lattice.png); with vox, an output past GS_VOX_MAX_CELLS cells (lattice.vox,
 * or each frame_NNN.vox of a 4D output, which has size's cells: a .vox
 * geosynth could not read back); with tile_image, the picture of a 2D tile
 * set's tiles (tiles.png, ts with its images), of the patterns (image.png, p)
 * past GS_IMAGE_MAX_SIDE, or a voxel tile set's tiles.vox past
 * GS_VOX_MAX_CELLS voxels. ts, p may be NULL; input names the tile set or
 * sample. GS_ERR_ARG. */
gs_err gs_model_check_output_sizes(const int64_t size[3], const gs_model_tileset *ts,
                                   const gs_model_patterns *p, const char *input, int tile_image,
                                   int vox);

/* Rank 0, before the synthesis (#25): with vox, refuses an example lattice
 * (read from input) holding more distinct non-empty labels than a .vox
 * palette's 255: the output draws from the example's labels, and
 * lattice.vox renumbers them 1..255 in order, so only such an example can
 * make an output it cannot write. GS_ERR_ARG naming input and model.vox. */
gs_err gs_model_check_vox_labels(const gs_model_lattice *example, const char *input, int vox);

/* ---- 3D overlapping model (model.overlap3d = N) ---------------------------
 *
 * Every N x N x N window of an example lattice lying wholly inside it (the
 * example is not wrapped: Merrell's examples are not periodic) is a pattern;
 * pattern i is label i + 1. Pattern b may lie at +x (+y, +z) of pattern a
 * when a's cells at coordinate 1..N-1 along that axis equal b's at 0..N-2
 * (their (N-1)-thick overlap). The synthesized lattice of patterns decodes
 * to each cell's pattern's origin cell (offset 0, 0, 0), and along a
 * non-periodic z its last layer's patterns also give the N - 1 layers above
 * (the lattice of patterns is N - 1 lower than the output, as the example's
 * window origins are N - 1 fewer than its layers), so every output window
 * of edge k <= N is a window of the example. */
typedef struct gs_model_patterns3d {
    int n;                 /* pattern edge N */
    int npatterns;
    uint16_t *pat;         /* [npatterns][N^3] example labels, x fastest, then y, z */
    uint64_t *count;       /* [npatterns] windows of the example with that content */
    gs_model_pair *pairs;  /* allowed (dir 0 / 2 / 4, a, b), a and b labels */
    size_t npairs;
    gs_model_lattice windows; /* (nx-N+1) x (ny-N+1) x (nz-N+1): the pattern label
                                 of the example's window at each origin */
    uint8_t *support_empty;   /* [npatterns + 1] by pattern label: 1 = its origin cell
                                 is empty (label 0), when the example has no unsupported
                                 structure (gs_measure_unsupported); NULL otherwise.
                                 For gs_model_params.support_empty */
    uint8_t *support_above;   /* [npatterns + 1] with support_empty: bit k - 1 = the
                                 pattern's cell (0, 0, k) is non-empty, k = 1..N-1 (what
                                 gs_model_patterns3d_decode shows over the top layer).
                                 For gs_model_params.support_above */
} gs_model_patterns3d;

/* Learns the patterns of ex (name for messages); more than max_patterns
 * distinct windows is GS_ERR_ARG. *out must be zeroed. */
gs_err gs_model_patterns3d_learn(const gs_model_lattice *ex, int n, int max_patterns,
                                 const char *name, gs_model_patterns3d *out);
void gs_model_patterns3d_destroy(gs_model_patterns3d *p);
/* Rules over the pattern labels from the overlap pairs; counts = windows. */
gs_err gs_model_patterns3d_rules(const gs_model_patterns3d *p, gs_model_rules_t *out);
/* out (created here) = each cell's pattern's origin label; top = 1 (z not
 * periodic) adds the N - 1 layers above plat's last layer, taken from that
 * layer's patterns' upper slices (out->nz = plat->nz + N - 1): the output's
 * top N layers show one whole window, as the example's do. */
gs_err gs_model_patterns3d_decode(const gs_model_patterns3d *p, const gs_model_lattice *plat,
                                  int top, gs_model_lattice *out);
/* Independent checker: face-adjacent pattern pairs of plat (across the wrap
 * where periodic[axis], which may be NULL) whose overlaps disagree, plus
 * cells holding no pattern; compares pattern contents, not the rules. */
size_t gs_model_patterns3d_check(const gs_model_patterns3d *p, const gs_model_lattice *plat,
                                 const int periodic[3]);

#endif
