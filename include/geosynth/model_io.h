/* model engine I/O and quality measures around the core (model.h):
 * example loading in three formats, colours, the voxel-cube mesh with merged
 * faces, PNG for 2D lattices, resemblance, and the file-level checker behind
 * `geosynth model-check EXAMPLE OUTPUT`.
 *
 * Lattice convention as in model.h: labels[x + nx*(y + ny*z)], z up, label
 * 0 = empty.
 *
 * Example formats (gs_model_load; format "auto" infers it from the name):
 *   txt   Paul Merrell's samples/NAME.txt (gs_model_read_merrell_txt);
 *   csv   DeBroglie's CSV lattices, e.g. its copies of Merrell's escheresque
 *         and parliament (gs_model_read_debroglie_csv: column x, row y,
 *         blank-line-separated layers z);
 *   vox   MagicaVoxel .vox (palette index = label; several models or a scene
 *         graph are composited with gs_vox_flatten) and Slab6 .slab.vox
 *         (VoxModSynth: empty 255 -> 0, index k -> k + 1, ground -> 255);
 *   h5    a geosynth HDF5 file (gs_ckpt reader: the file needs the /geosynth
 *         group, e.g. a model run's lattice.h5 or a checkpoint.h5) holding a
 *         uint16 dataset of shape {nz, ny, nx} (default "/model/labels"),
 *         or {nt, nz, ny, nx}: a 4D lattice of nt frames (a 4D run's
 *         lattice.h5), read with frames = nt and the frames stacked along z.
 *         Plain HDF5 files from other tools are not read: write them with a
 *         /geosynth group or convert them to .vox/.txt.
 *
 * Colours: a .vox example brings its palette (label i -> palette[i]); other
 * labels get a fixed colour derived from the label number (the same in every
 * output and every run).
 *
 * Errors name the file and what was expected. On error outputs are unchanged
 * (lattices) or zeroed (meshes). All functions are local (no MPI).
 */
#ifndef GEOSYNTH_MODEL_IO_H
#define GEOSYNTH_MODEL_IO_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "geosynth/error.h"
#include "geosynth/measure.h"
#include "geosynth/model.h"

typedef struct gs_model_palette {
    uint8_t rgba[256][4]; /* colour of label i < 256 when from_file */
    int from_file;        /* 1: taken from a .vox example */
} gs_model_palette;

/* Colour of label (label 0 gets black; never drawn). */
void gs_model_label_rgb(const gs_model_palette *pal, uint16_t label, uint8_t rgb[3]);

/* format: "auto", "txt", "csv", "vox" or "h5"; dataset: HDF5 dataset path for h5
 * (NULL or "" = "/model/labels"). pal may be NULL. *out must be zeroed; free
 * with gs_model_lattice_destroy(). */
gs_err gs_model_load(const char *path, const char *format, const char *dataset,
                     gs_model_lattice *out, gs_model_palette *pal);

/* The format "auto" picks for path ("txt", "csv", "vox" or "h5"), or NULL. */
const char *gs_model_format_of(const char *path);

/* Writes lat as MagicaVoxel .vox (tiles of <= 256 per axis). Labels above
 * 255 are renumbered 1..255 in increasing order (GS_ERR_ARG when more than
 * 255 distinct non-empty labels); *renumbered tells whether that happened. */
gs_err gs_model_write_vox(const char *path, const gs_model_lattice *lat,
                          const gs_model_palette *pal, int *renumbered);

/* Writes the z = 0 layer as an RGB PNG, one pixel per cell, y up (row 0 of
 * the image is y = ny - 1); empty cells white. */
gs_err gs_model_write_png(const char *path, const gs_model_lattice *lat,
                          const gs_model_palette *pal);

/* ---- voxel-cube mesh with merged faces --------------------------------- */

/* Largest side of a merged rectangle, in cells: its polygon then has at most
 * 8 * GS_MODEL_QUAD_MAX corners (lattice points and edge midpoints on its
 * sides), which a PLY "list uchar" can hold. */
#define GS_MODEL_QUAD_MAX 31

/* One axis-aligned rectangle of the surface, corners counter-clockwise seen
 * from outside (outward normal by the right-hand rule). */
typedef struct gs_model_quad {
    float p[4][3];
    int32_t lo[3], hi[3]; /* its lattice-point box (lo[a] = hi[a] on its axis a) */
    uint16_t label;
    uint8_t dir; /* outward normal: 0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z */
} gs_model_quad;

typedef struct gs_model_quads {
    gs_model_quad *q; /* gs_malloc'ed */
    size_t n;
    size_t unit_faces; /* cube faces before merging */
} gs_model_quads;

/* The surface of the filled cells: a face of a filled cell is kept when the
 * cell across it is empty or outside (faces between two labels are inside
 * the solid and left out); per slice, coplanar faces of one label and
 * direction are merged greedily into rectangles of at most
 * GS_MODEL_QUAD_MAX cells a side (grow along the first in-plane axis, then
 * the second). Cell (x, y, z) occupies [x, x+1] x [y, y+1] x [z, z+1] times
 * voxel. Free with gs_model_quads_free(). O(cells) time, O(largest slice)
 * scratch. */
gs_err gs_model_mesh_quads(const gs_model_lattice *lat, double voxel, gs_model_quads *out);
void gs_model_quads_free(gs_model_quads *q);

/* The rectangles of q (made from lat) as one welded polygon mesh: shared
 * vertices, every edge used by exactly two faces in opposite directions, no
 * T-junctions (a rectangle's polygon lists, in order, every vertex of its
 * neighbours that lies on its edges), and a 2-manifold: where filled cells
 * touch only along an edge or at a corner, the surface is kept apart (each
 * cube keeps its own faces there: solid cells are joined through faces
 * only), so such a lattice point has one vertex per sheet of surface through
 * it, and an edge where two cubes touch gets one extra vertex in its middle
 * per cube (the two sheets then never share an edge, even when they share
 * both ends). Polygon f is corner[start[f] .. start[f+1]) (at most
 * 8 * GS_MODEL_QUAD_MAX corners), counter-clockwise seen from outside,
 * label[f] its cell's label. Vertices in the order the rectangles first
 * use them (deterministic). Free with gs_model_polymesh_free(). */
typedef struct gs_model_polymesh {
    float *pos;      /* 3 * nv */
    size_t nv, nf;
    uint32_t *start; /* nf + 1 */
    uint32_t *corner;
    uint16_t *label; /* nf */
} gs_model_polymesh;
gs_err gs_model_mesh_weld(const gs_model_lattice *lat, const gs_model_quads *q, double voxel,
                          gs_model_polymesh *out);
void gs_model_polymesh_free(gs_model_polymesh *m);

/* The polygons of in as faces every reader takes as they are: a polygon of
 * 4 corners (a plain rectangle) stays a quad; one with more (its
 * neighbours' vertices on its edges) becomes triangles by ear clipping that
 * never cuts a zero-area triangle (a fan from one corner, as MeshLab and
 * three.js do with polygons, makes zero-area triangles along the sides and
 * edges shared by 3 or more triangles). Same vertices, every triangle and
 * quad of a polygon keeps its label and orientation; still a closed
 * 2-manifold. Free with gs_model_polymesh_free(). */
gs_err gs_model_polymesh_triangulate(const gs_model_polymesh *in, gs_model_polymesh *out);

/* Writes the welded mesh, triangulated as above, as binary PLY (vertex
 * float x y z; faces "list uchar int vertex_indices" + uchar red green blue
 * + ushort label: face colours from the palette, as in lattice.vox), as OBJ
 * with an MTL file next to it (one material "label_N" per label, Kd from the
 * palette; faces grouped by label) or as glTF binary (one primitive and
 * material "label_N" per label over the shared vertices; include/geosynth/
 * glb.h). Picks by extension (.ply / .obj / .glb). Atomic writes. */
gs_err gs_model_write_mesh(const char *path, const gs_model_polymesh *m,
                           const gs_model_palette *pal);

/* Writes the preview picture of a run: the example (left) and the output
 * (right) as coloured voxel cubes, colours as in lattice.vox (pal), each
 * fitted to a side x side panel, rendered with the built-in renderer
 * (include/geosynth/preview.h). GS_ERR_LIB when no renderer is available. */
gs_err gs_model_write_preview(const char *path, const gs_model_lattice *example,
                              const gs_model_lattice *output, const gs_model_palette *pal,
                              int side);

/* ---- quality ------------------------------------------------------------ */

/* Share of ALL the output's w x w x w windows, all-empty ones included (an
 * empty output scores high: gs_model_quality's w3.found_share counts only
 * non-empty windows). Window extent clipped to
 * min(w, example extent, output extent) per axis, so a 2D lattice uses
 * w x w x 1) whose labels occur as a window somewhere in the example.
 * 1.0 = every local neighbourhood is copied from the example. Cost:
 * O(cells * w^3) plus a sort of the example's windows. */
gs_err gs_model_resemblance(const gs_model_lattice *example, const gs_model_lattice *output,
                            int w, double *share);

/* The quality figures every run of a lattice example writes to summary.json
 * (docs/FORMATS.md), from the output and the example alone. */
typedef struct gs_model_quality_figures {
    gs_measure_windows w3, w2;   /* 3x3x3 and 2x2x2 window measures */
    double label_l1;             /* L1 of the label mixes (empty included), 0..2 */
    double empty_share, empty_share_example;
    int labels_used, labels_example; /* distinct non-empty labels */
    gs_measure_profile profile;  /* owned: gs_measure_profile_free */
    double unsupported_share, unsupported_share_example; /* of the non-empty cells */
    /* yards: both lattices at the example's ground layer (its lowest layer holding
     * an empty cell; enclosure.layer = -1 when it has none or the output is lower),
     * large = yards of >= half the example's largest (gs_measure_enclosure_layer) */
    gs_measure_enclosure enclosure, enclosure_example;
    /* layout above the example's ground layer (gs_measure_layout_lattice; layout.ground
     * = -1 when not measured, as enclosure.layer); large = structures of more than
     * twice the example's largest */
    gs_measure_layout layout, layout_example;
    /* the output's structure columns across the region grid's lines (issue #18;
     * gs_measure_grid_crossing_lattice at layout.ground, period = model.region
     * along x and y; grid_period[0] = grid_period[1] = 0: not measured) */
    int grid_period[2];
    gs_measure_grid_crossing grid;
} gs_model_quality_figures;

gs_err gs_model_quality(const gs_model_lattice *example, const gs_model_lattice *output,
                        gs_model_quality_figures *q);

/* Structure labels of an example (soft constraints, paper Sec. 4.2: "structure
 * inside the target, none outside"), from the example alone: empty is the
 * commonest label of its top layer; ground are the labels of the layers below
 * the first layer holding empty (the terrain); a structure label is neither and
 * stands on or carries another such label somewhere in the example (it is part
 * of something built more than one cell high: walls, towers, roofs; not grass,
 * bushes or flat roads). out[l] = 1 for a structure label, l < nlabels; *count
 * receives how many. */
gs_err gs_model_structure_labels(const gs_model_lattice *example, int nlabels, uint8_t *out,
                                 int *count);

/* Share of structure cells (structure[label] = 1, labels >= nlabels count as
 * none) in the columns inside the target (shape[x + nx*y] >= 0.5) and outside,
 * over all layers; a side with no column gets 0. */
void gs_model_structure_shares(const gs_model_lattice *lat, const uint8_t *structure,
                               int nlabels, const float *shape, double *inside,
                               double *outside);

/* Loads both files (formats inferred), runs gs_model_check (or, when example
 * is a WFC tile set "TILES.xml" / "TILES.xml#SUBSET", gs_model_tileset_check
 * from model_tiles.h) and prints a report to out: one line per violation up to cap, then the total. *count
 * is the number of violations. */
gs_err gs_model_check_files(const char *example, const char *output, FILE *out, size_t cap,
                            size_t *count);

#endif
