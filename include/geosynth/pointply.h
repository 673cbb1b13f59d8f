/* Oriented point sets in PLY files: vertices with x y z and normals nx ny nz,
 * no faces needed (gs_mesh_read needs faces; both readers share the bounded
 * PLY layer src/io/ply.c).
 *
 * Reading: "format ascii 1.0", "binary_little_endian 1.0" and
 * "binary_big_endian 1.0". The "vertex" element must have
 * properties x, y, z; nx, ny, nz (or normal_x, normal_y, normal_z) are read
 * when present. Property types char/uchar/short/ushort/int/uint/float/double
 * (and the int8..float64 spellings); other vertex properties, list
 * properties and other elements (faces, edges, before or after the
 * vertices) are skipped. Values are converted to double exactly. Numbers in
 * ASCII files are parsed with include/geosynth/parse.h.
 *
 * Layout of the result: v[6*i .. 6*i+5] = x y z nx ny nz of vertex i (the
 * same layout as gs_opoint in points.h). Normals are rescaled to unit length.
 *
 * Errors (all name the file): missing/unreadable file GS_ERR_IO; anything
 * wrong with the content GS_ERR_FORMAT, with the header line number ("line
 * 4: unknown property type 'float128'"), the ASCII data line, or for binary
 * data the byte offset and vertex ("byte 1234: file ends inside vertex 55
 * of 100"). Non-finite coordinates, and zero or non-finite normals when
 * normals are required, name the vertex. A file without normals when
 * require_normals != 0: GS_ERR_FORMAT "... has no normals (nx ny nz):
 * oriented points are needed".
 *
 * Writing: atomic (path.tmp + rename); binary little endian or ASCII, float
 * properties (the doubles rounded to nearest float32; ASCII with 9
 * significant digits, which give that float back), optionally one int
 * property per vertex after them (a patch id). Memory: the reader holds the whole file
 * plus 48 bytes per vertex.
 */
#ifndef GEOSYNTH_POINTPLY_H
#define GEOSYNTH_POINTPLY_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

#define GS_POINTPLY_MAX_POINTS ((size_t)1 << 31)

typedef struct gs_pointply {
    size_t n;        /* vertices */
    double *v;       /* 6 * n doubles: x y z nx ny nz (gs_malloc) */
    int has_normals; /* 0: the file had none (normals are 0 then) */
} gs_pointply;

/* Reads path (see above). On error *out is zeroed. */
gs_err gs_pointply_read(const char *path, int require_normals, gs_pointply *out);
/* The same over a file image in memory (name is used in messages). */
gs_err gs_pointply_parse(const char *data, size_t len, const char *name, int require_normals,
                         gs_pointply *out);
/* Frees v and zeroes *p. Safe on a zeroed struct. */
void gs_pointply_destroy(gs_pointply *p);

typedef enum gs_pointply_format { GS_POINTPLY_BINARY = 0, GS_POINTPLY_ASCII = 1 } gs_pointply_format;

/* Writes n points from v (6 doubles each as above; normals written when
 * with_normals != 0) atomically. */
gs_err gs_pointply_write(const char *path, const double *v, size_t n, int with_normals,
                         gs_pointply_format format);
/* The same with an int vertex property id_name (id[i] for vertex i) after
 * the others; id NULL: none (gs_pointply_write). Readers that do not know
 * the property skip it (this reader does). */
gs_err gs_pointply_write_ids(const char *path, const double *v, size_t n, int with_normals,
                             const char *id_name, const int32_t *id, gs_pointply_format format);

#endif
