/* Triangle meshes: read (OBJ, PLY, STL, OFF), write (OBJ, binary
 * PLY), bounding box, closedness check, normals, welding.
 *
 * gs_mesh is a plain struct the caller may fill directly (or with
 * gs_mesh_alloc); every array is allocated with gs_malloc and owned by the
 * struct; gs_mesh_destroy frees them all and zeroes the struct.
 * Vertex i is pos[3i..3i+2]; triangle t is tris[3t..3t+2] (counter-clockwise
 * seen from outside = outward normal by the right-hand rule).
 *
 * Reading (src/io/meshread.c): bounded readers of our own, picked by the
 * extension (.ply ascii/binary either endian with vertex x y z and face
 * vertex_indices; .off and its C/N/ST variants; .stl binary or text; .obj v
 * and f lines, negative indices, /uv/normal suffixes). Every header count is
 * checked against the bytes left before allocating; memory grows with what
 * the file holds; time is linear in the file size. Polygons are triangulated
 * (quads split at a concave corner, as assimp did; larger ones fanned);
 * points and lines are dropped. Vertices come in the order the triangles
 * first use them (unused ones dropped) and are welded by exact position, so
 * topology checks see the real connectivity (the same result as the assimp
 * importer used before). File normals are discarded; normals is NULL after
 * reading (call gs_mesh_compute_normals when needed).
 * Errors name the file and the line or byte and what is wrong: missing or
 * unreadable file (GS_ERR_IO), unknown extension, not a mesh, a count past
 * the end of the file, an index out of range, no triangles, NaN or infinite
 * coordinates, more than GS_MESH_MAX_ELEMS vertices or triangles
 * (GS_ERR_FORMAT).
 *
 * Writing is atomic (path.tmp + rename). OBJ: v, vn (when normals), f (1-based,
 * v//vn with normals). PLY: binary little endian, x y z float, optional
 * nx ny nz float, optional one per-vertex property (scalar: float, label:
 * uchar), optional uchar red green blue, faces as "list uchar int
 * vertex_indices". glTF binary: src/io/glb.c.
 */
#ifndef GEOSYNTH_MESH_H
#define GEOSYNTH_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define GS_MESH_MAX_ELEMS ((size_t)1 << 30) /* vertices or triangles per mesh */

typedef struct gs_mesh {
    size_t nverts, ntris;
    float *pos;       /* 3*nverts */
    float *normals;   /* 3*nverts or NULL */
    uint32_t *tris;   /* 3*ntris */
    float *scalar;    /* nverts per-vertex value (output property) or NULL */
    uint8_t *label;   /* nverts per-vertex label (output property) or NULL */
} gs_mesh;

/* Allocates a zeroed mesh of nverts/ntris (normals too when with_normals).
 * On error *m is zeroed. */
gs_err gs_mesh_alloc(gs_mesh *m, size_t nverts, size_t ntris, int with_normals);

/* Frees every array and zeroes *m. Safe on a zeroed struct. */
void gs_mesh_destroy(gs_mesh *m);

/* Checks sizes, index ranges and finite coordinates; what names the mesh. */
gs_err gs_mesh_validate(const gs_mesh *m, const char *what);

/* Reads a triangle mesh (see above). On error *out is zeroed. */
gs_err gs_mesh_read(const char *path, gs_mesh *out);
/* The same over a file image data[len] in memory; name gives the format (its
 * extension) and is used in messages. */
gs_err gs_mesh_parse(const char *data, size_t len, const char *name, gs_mesh *out);

/* Writes OBJ / PLY (atomically). prop_name names the PLY per-vertex property
 * written from m->scalar (float) or else m->label (uchar); NULL or an absent
 * array writes none. gs_mesh_write picks the format from the extension
 * (.obj or .ply, case-insensitive). */
gs_err gs_mesh_write_obj(const char *path, const gs_mesh *m);
gs_err gs_mesh_write_ply(const char *path, const gs_mesh *m, const char *prop_name);
/* The same with per-vertex colours rgb[3 nverts] (uchar red green blue,
 * after the property; NULL: none), which mesh viewers show directly. */
gs_err gs_mesh_write_ply_rgb(const char *path, const gs_mesh *m, const char *prop_name, const uint8_t *rgb);
gs_err gs_mesh_write(const char *path, const gs_mesh *m, const char *prop_name);

/* What an output mesh is, for its readers: the units of its coordinates and
 * one line on what it holds (the up axis is always z). PLY: header comments
 * "up_axis z; units: ..." and the line; OBJ: the same as '#' lines; glTF:
 * asset.extras (include/geosynth/glb.h). NULL members are left out. */
typedef struct gs_mesh_meta {
    const char *name;  /* glTF node name */
    const char *units;
    const char *about;
} gs_mesh_meta;
/* gs_mesh_write / gs_mesh_write_ply_rgb with meta (NULL: none); by extension
 * .ply, .obj or .glb (rgb: per-vertex colours, PLY and glTF only). */
gs_err gs_mesh_write_meta(const char *path, const gs_mesh *m, const char *prop_name, const uint8_t *rgb,
                          const gs_mesh_meta *meta);
/* glTF binary of m (one primitive; normals when m has them; rgb per-vertex
 * colours or NULL): include/geosynth/glb.h. */
gs_err gs_mesh_write_glb(const char *path, const gs_mesh *m, const uint8_t *rgb, const gs_mesh_meta *meta);

/* Axis-aligned bounding box (lo = hi = 0 for an empty mesh). */
void gs_mesh_bbox(const gs_mesh *m, float lo[3], float hi[3]);

typedef struct gs_mesh_topology {
    size_t edges;              /* distinct undirected edges */
    size_t boundary_edges;     /* used by exactly one triangle */
    size_t nonmanifold_edges;  /* used by three or more triangles */
    size_t misoriented_edges;  /* used twice in the same direction */
    size_t degenerate_tris;    /* repeated vertex index (skipped in the counts) */
    int closed;                /* all of the above zero (watertight, oriented) */
} gs_mesh_topology;

/* Edge census of m. O(ntris log ntris) time, 48 bytes per triangle scratch. */
gs_err gs_mesh_topology_check(const gs_mesh *m, gs_mesh_topology *topo);

/* GS_OK when m is closed; otherwise GS_ERR_ARG with a message naming what
 * (e.g. the file), the counts, and purpose ("signed distance field"). */
gs_err gs_mesh_require_closed(const gs_mesh *m, const char *what, const char *purpose);

/* Area-weighted vertex normals (unit length; zero for isolated vertices).
 * Allocates m->normals when NULL. Each vertex's sum is taken in double, in
 * triangle order; the sums of at most 2^22 vertices are held at once (larger
 * meshes: one pass over the triangles per range of vertices, same bits). */
gs_err gs_mesh_compute_normals(gs_mesh *m);
/* The same with ranges of `range` vertices (>= 1): equal bits for any range
 * (tests/unit/test_mesh.c checks this). */
gs_err gs_mesh_compute_normals_ranged(gs_mesh *m, size_t range);

/* Merges vertices within tol (tol = 0: identical positions): in vertex
 * order, a vertex joins the lowest kept vertex within tol, or is kept (with
 * its scalar/label). Drops triangles that become degenerate and vertices no
 * triangle uses (a point set, ntris = 0, keeps every kept vertex);
 * recomputes normals when m had them. Deterministic. O(nverts) expected
 * with a hash grid of cells 2*tol wide (8 cells looked up per vertex). On
 * error m is unchanged. */
gs_err gs_mesh_weld(gs_mesh *m, float tol);

/* Total surface area and signed enclosed volume (positive for outward
 * orientation of a closed mesh). */
double gs_mesh_area(const gs_mesh *m);
double gs_mesh_volume(const gs_mesh *m);

#ifdef __cplusplus
}
#endif
#endif
