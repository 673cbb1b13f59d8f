/* Voxel label lattices in MagicaVoxel .vox files (and Slab6 .slab.vox).
 *
 * Our own parser (it is fuzzed: tests/fuzz/fuzz_vox.c). Every chunk size and
 * count is checked against the bytes that remain before it is used, so a
 * damaged file gives an error naming the chunk and byte offset, never a read
 * out of bounds.
 *
 * Lattice convention (all of geosynth): labels[x + nx*(y + ny*z)], x fastest,
 * z up (MagicaVoxel's gravity axis). Label 0 = empty, 1..255 = palette index.
 * palette[i] is the RGBA colour of label i (palette[0] unused, {0,0,0,0}).
 *
 * MagicaVoxel .vox ("VOX " + version, then a MAIN chunk):
 *   read:  PACK (ignored, models are counted), SIZE/XYZI pairs (several models),
 *          RGBA (entry j = colour of label j+1; default palette when absent),
 *          nTRN/nGRP/nSHP scene graph (translations -> model placement, see
 *          gs_vox_instance); every other chunk (MATL, LAYR, rOBJ, rCAM, NOTE,
 *          IMAP, MATT, unknown ids) is skipped by its declared sizes.
 *          Model sizes must lie in [1, 256] per axis; voxel coordinates must
 *          lie inside SIZE; colour index 0 in XYZI is an error.
 *   write: version 150; one SIZE/XYZI per model; scene graph
 *          nTRN(0) -> nGRP(1) -> { nTRN -> nSHP } per model, each model placed
 *          at its (x0,y0,z0); RGBA palette. gs_vox_write_lattice splits a
 *          lattice larger than 256 per axis into tiles of at most 256^3 placed
 *          by the scene graph (gs_vox_flatten reassembles them exactly).
 *          MagicaVoxel itself edits at most 256^3 per model, so such files open
 *          as several adjacent objects in its world editor.
 *
 * Slab6 .slab.vox (VoxModSynth exemplars, detected when the file does not start
 * with "VOX "): int32 sx, sy, sz; sx*sy*sz bytes, x outer, y, z inner, z down;
 * 768 bytes palette, 6-bit RGB. Converted to our convention: z flipped (z up),
 * slab index 255 -> label 0 (empty), slab index k < 255 -> label k + 1
 * (MagicaVoxel's own mapping; VoxModSynth's "ground" 254 becomes label 255).
 * Slab sizes are bounded by GS_VOX_MAX_CELLS, not by 256.
 *
 * Memory: one byte per lattice cell per model. The total over all models of a
 * file is bounded by GS_VOX_MAX_CELLS (a file declaring more is refused).
 */
#ifndef GEOSYNTH_VOX_H
#define GEOSYNTH_VOX_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

#define GS_VOX_MAX_AXIS 256                  /* MagicaVoxel per-model limit */
#define GS_VOX_MAX_CELLS ((size_t)1 << 28)   /* total cells per file (256 MiB) */

typedef struct gs_vox_model {
    int nx, ny, nz;    /* SIZE */
    uint8_t *labels;   /* nx*ny*nz, x fastest; 0 = empty */
} gs_vox_model;

/* One placement of a model in the scene (from nSHP under nTRN transforms).
 * (x0,y0,z0) is the world position of the model's voxel (0,0,0): MagicaVoxel
 * stores the translation of the model centre, t, and places voxel (0,0,0) at
 * t - floor(size/2). Rotations other than identity are reported in rotated. */
typedef struct gs_vox_instance {
    int model;
    int x0, y0, z0;
    int rotated; /* 1 when a transform on the path has a non-identity _r */
} gs_vox_instance;

typedef struct gs_vox {
    int nmodels;
    gs_vox_model *models;
    int ninstances;           /* 0 when the file has no scene graph */
    gs_vox_instance *instances;
    uint8_t palette[256][4];  /* RGBA of label i */
} gs_vox;

/* Reads a .vox or .slab.vox file. On success *out owns its arrays (free with
 * gs_vox_destroy). On error *out is zeroed. Errors: GS_ERR_IO (missing or
 * unreadable), GS_ERR_FORMAT (damaged: message names file, chunk, byte offset),
 * GS_ERR_MEM. Cost: O(file size + cells). */
gs_err gs_vox_read(const char *path, gs_vox *out);

/* Same as gs_vox_read on a memory buffer; name is used in messages. */
gs_err gs_vox_parse(const uint8_t *buf, size_t len, const char *name, gs_vox *out);

/* Writes v as MagicaVoxel .vox (every model <= 256 per axis, GS_ERR_ARG
 * otherwise), atomically (path.tmp + rename). Instances: v->instances when
 * ninstances > 0, else model i is placed at the origin. */
gs_err gs_vox_write(const char *path, const gs_vox *v);

/* Encodes v into a new buffer (*buf, *len; caller frees with gs_free). */
gs_err gs_vox_encode(const gs_vox *v, uint8_t **buf, size_t *len);

/* Builds a gs_vox from one lattice of any size: split into tiles of at most
 * 256 per axis (one model + one instance each), the palette copied (NULL: the
 * MagicaVoxel default palette). Empty tiles are still stored so the extent
 * survives a round trip. *out owns its arrays. */
gs_err gs_vox_from_lattice(int nx, int ny, int nz, const uint8_t *labels,
                           const uint8_t (*palette)[4], gs_vox *out);

/* gs_vox_from_lattice + gs_vox_write. */
gs_err gs_vox_write_lattice(const char *path, int nx, int ny, int nz, const uint8_t *labels,
                            const uint8_t (*palette)[4]);

/* Composites every instance (or, without a scene graph, every model at the
 * origin) into one lattice covering their bounding box: *labels (gs_free),
 * dims, and the world position of its cell (0,0,0) in origin (may be NULL).
 * Later instances overwrite earlier non-empty cells. Rotated instances are
 * refused (GS_ERR_FORMAT). Bounded by GS_VOX_MAX_CELLS. */
gs_err gs_vox_flatten(const gs_vox *v, int *nx, int *ny, int *nz, uint8_t **labels,
                      int origin[3]);

/* Frees v's arrays and zeroes it. Safe on a zeroed struct. */
void gs_vox_destroy(gs_vox *v);

/* MagicaVoxel default palette (RGBA of label i). */
void gs_vox_default_palette(uint8_t palette[256][4]);

#endif
