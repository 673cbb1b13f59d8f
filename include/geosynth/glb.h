/* glTF 2.0 binary (.glb) writer: meshes for Blender, three.js and game
 * engines (docs/FORMATS.md, "glTF binary").
 *
 * One file: the 12-byte header, a JSON chunk and a BIN chunk (each padded
 * to 4 bytes), one buffer, one scene with one node holding one mesh. The
 * mesh shares one vertex list (POSITION, optional NORMAL and COLOR_0) among
 * its primitives: one per part, each with its triangle indices and its own
 * material, so a face colour per label is a material per label and the
 * welded vertices stay shared. No part: one POINTS primitive of every vertex.
 *
 * Axes: glTF is y-up; geosynth's outputs are z-up, so positions and normals
 * are stored as (x, z, -y) (a rotation about x: right-handed, lengths and
 * orientation kept). Blender's importer turns them back into its z-up
 * frame, so coordinates there equal the PLY's. Colours are sRGB bytes in,
 * stored linear as glTF asks (baseColorFactor, COLOR_0 float RGB).
 * asset.extras holds the source up axis, the units, the counts and a text.
 * Everything is written in a fixed order with fixed number formats:
 * identical inputs give identical files. Atomic write (path.tmp + rename).
 */
#ifndef GEOSYNTH_GLB_H
#define GEOSYNTH_GLB_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct gs_glb_part {
    const uint32_t *tris; /* 3 * ntris indices into the vertices */
    size_t ntris;
    const char *name;     /* material name (NULL: "surface") */
    const uint8_t *rgb;   /* material colour, sRGB bytes (NULL: light grey 200) */
} gs_glb_part;

typedef struct gs_glb_desc {
    const float *pos;        /* 3 * nverts, z-up */
    size_t nverts;
    const float *normals;    /* 3 * nverts unit vectors or NULL (viewers shade flat) */
    const uint8_t *vertex_rgb; /* 3 * nverts sRGB bytes or NULL */
    const gs_glb_part *parts;
    size_t nparts;           /* 0: the vertices as points */
    const char *name;        /* node and mesh name */
    const char *units;       /* what one unit of the coordinates is */
    const char *about;       /* one line on what the mesh is (NULL: none) */
} gs_glb_desc;

/* Writes d as .glb to path. GS_ERR_ARG on an index out of range, a
 * non-finite coordinate or more than 2^31 bytes of buffer; GS_ERR_IO when
 * the write fails (the file is then not created). */
gs_err gs_glb_write(const char *path, const gs_glb_desc *d);

/* sRGB byte -> linear [0, 1] (the IEC 61966-2-1 curve). */
double gs_srgb_to_linear(uint8_t c);

#ifdef __cplusplus
}
#endif
#endif
