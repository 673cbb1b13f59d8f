/* model: 2D inputs in the style of WaveFunctionCollapse (mxgmn): the simple
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
    gs_model_pair *pairs; /* allowed (dir 0 / 2) pairs, sorted, unique */
    size_t npairs;
    int tile_w, tile_h;   /* pixels (0 when images were not loaded) */
    uint8_t *pixels;      /* [ntiles][tile_h][tile_w][4] RGBA, NULL without images */
} gs_model_tileset;

/* Parses the tile set at path restricted to subset (NULL or "" = every
 * tile), expands the symmetries, and when images is 1 loads and orients the
 * tile PNGs. *out must be zeroed; on error it stays zeroed. */
gs_err gs_model_tileset_load(const char *path, const char *subset, int images,
                             gs_model_tileset *out);
void gs_model_tileset_destroy(gs_model_tileset *ts);
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

/* ---- overlapping model ----------------------------------------------------- */

typedef struct gs_model_patterns {
    int n;              /* pattern edge N */
    int npatterns;      /* label of pattern i = i + 1 */
    uint32_t *colors;   /* palette, RGBA packed 0xAABBGGRR */
    int ncolors;
    uint8_t *pat;       /* [npatterns][N*N] colour indices, row-major (row 0 top) */
    uint64_t *count;    /* [npatterns] occurrences (weights) */
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

#endif
