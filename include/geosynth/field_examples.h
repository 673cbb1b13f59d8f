/* Example inputs of the field engine: built-in generators (the paper's
 * GRID, CHAINMAIL, BALLS and FIBERS examples, made procedurally) and
 * loaders that turn meshes, OpenVDB level sets, height-map images and
 * HDF5 fields into signed distance fields; plus the geometry outputs
 * (contour, copied source triangles). Implemented in src/field/examples.c
 * and src/field/geometry.c.
 *
 * Conventions: fields follow include/geosynth/field.h (x fastest, signed,
 * negative inside, world units: origin + spacing * index). Generated
 * fields have spacing 1 and origin 0 and are exact distances within
 * GS_EXAMPLE_BAND samples of the surface, clamped to +-GS_EXAMPLE_BAND
 * beyond (quantization ranges are much narrower, default +-3 samples).
 * Every generator is deterministic in (kind, n, seed).
 *
 * Memory: one float per sample (4 n^3 bytes), plus O(objects).
 */
#ifndef GEOSYNTH_FIELD_EXAMPLES_H
#define GEOSYNTH_FIELD_EXAMPLES_H

#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/field.h"
#include "geosynth/mesh.h"

#define GS_EXAMPLE_BAND 8.0

/* The generator names, in --help order. */
#define GS_EXAMPLE_KINDS "grid|chainmail|balls|fibers|spheres|chainmail_jittered"

/* n^3 signed distance field of a built-in example; n in [8, 1024].
 *  grid:      cylinders along x, y, z on a jittered lattice, balls at the crossings (period 16)
 *  chainmail: rows of linked tori in alternating orientation (period 12)
 *  balls:     balls of radius 3..5 dropped one by one into the box: each falls
 *             straight down until it rests on the floor or on another ball, so
 *             no two overlap (ballistic deposition), until the box is full
 *  fibers:    long fibers along x on a jittered (y, z) lattice (period 9), each
 *             with its own radius 1.4..2.4, thickness variation and wobble
 *  spheres:   a few random large spheres
 *  chainmail_jittered: chainmail's rings, each with its own centre (moved
 *             up to 0.6 samples along each axis), major radius (x 0.88..1.12)
 *             and minor radius (1.15..1.45): not periodic
 * Unknown kinds are GS_ERR_ARG naming the kind and the choices. On error
 * *out is unchanged; caller frees with gs_field_destroy(). */
gs_err gs_field_example_make(const char *kind, int64_t n, uint64_t seed, gs_field **out);

/* The example's surface as a closed triangle mesh (the field padded with
 * one outside sample, so shapes cut by the box are capped), contoured with
 * OpenVDB at 0; vertices in sample units (spacing 1, origin 0). */
gs_err gs_field_example_mesh(const char *kind, int64_t n, uint64_t seed, gs_mesh *out);

/* ---- loaders (geometry.c); what names the input in messages ---- */

/* Triangle mesh -> distance field through OpenVDB with `samples` samples
 * along the longest side of the bounding box plus margin (margin in
 * samples; the box grows by margin on each side). is_signed = 1 needs a
 * closed mesh (GS_ERR_ARG naming the file and the open edges otherwise);
 * an unsigned distance d becomes the solid shell d - shell*spacing, so a
 * surface of any mesh turns into a thin solid with a zero level set. */
gs_err gs_field_from_mesh(const gs_mesh *m, const char *what, int64_t samples, double margin,
                          int is_signed, double shell, gs_field **out);
/* Float grid of an OpenVDB file (grid NULL or "" = the first level set,
 * else the first float grid). */
gs_err gs_field_from_vdb(const char *path, const char *grid, gs_field **out);
/* float32 3D dataset {nz, ny, nx} of an HDF5 file written by geosynth (or any
 * HDF5 file with a /geosynth group); spacing and origin from the dataset's
 * attributes "spacing", "origin_x/y/z" when present (else 1 and 0). */
gs_err gs_field_from_h5(const char *path, const char *dataset, gs_field **out);
/* Height-map image (PNG/JPEG, grey or colour = luma) -> signed distance to
 * the height-field surface z = h(x, y): the image is box-filtered to `size`
 * samples along its longer side, h = (depth - height)/2 + height * grey,
 * image row 0 is the largest y. Below the surface is inside (negative).
 * Distance = min(|z - h(x,y)|, distance to the surface points of the
 * columns within GS_EXAMPLE_BAND), exact up to the height step between
 * neighbouring columns. */
gs_err gs_field_from_heightmap(const char *path, int64_t size, int64_t depth, double height,
                               gs_field **out);

/* ---- geometry outputs (geometry.c) ---- */

/* Iso-surface of f at iso (OpenVDB), vertices in world units. */
gs_err gs_field_contour(const gs_field *f, double iso, double adaptivity, gs_mesh *out);

/* The paper's output mode (section 5.3), made a valid mesh: the geometry
 * of the source copied along the synthesis' provenance onto the connectivity
 * of base, the contour of the synthesized field target (its values read in
 * target sample units, whatever its spacing) in target sample units (one
 * welded, manifold sheet; copying the source's own triangles leaves cracks,
 * overlaps and doubled walls at every seam, and no welding tolerance closes
 * them). Each base vertex p inside the target box takes, for each of the 8
 * target samples t around it, the point of the source surface nearest to
 * p - (t - prov[t]) (within snap samples; else p), translated back, blended
 * with trilinear weights: inside a copied block that is the source's surface
 * itself. Vertices within a sample of the box's faces (where the contour
 * closes the box) stay. prov[t] is a linear index into the source of size sn (x fastest,
 * -1 = none), t one into the target. Vertices whose samples come
 * from more than one source offset (seams) then get `relax` Laplacian
 * iterations of weight 0.5 (the paper's mesh relaxation). No vertex moves
 * more than 0.45 of the distance to the next surface of target along its
 * gradient (facing sheets cannot pass through each other). Vertices of
 * triangles that would fold over (normal turned by more than 60 degrees,
 * area below a hundredth of the base's) or of vertices moved onto one
 * another are pulled back towards base until none does. src_mesh is in
 * source sample units (spacing 1, origin 0); its triangles reaching out of
 * the source box are ignored. */
typedef struct gs_field_copy_stats {
    int64_t seam_vertices;   /* samples around them from more than one source offset */
    int64_t copied_vertices; /* moved onto the source surface of a copy */
    int64_t pulled_back;     /* vertices pulled back towards base to unfold it */
    double mean_shift;       /* mean distance moved from base, in samples */
} gs_field_copy_stats;
gs_err gs_field_copy_geometry(const gs_mesh *src_mesh, const int64_t sn[3], const int32_t *prov,
                              const gs_field *target, const gs_mesh *base, double snap, int relax,
                              gs_mesh *out, gs_field_copy_stats *st);
/* The room the copy gives a vertex at p (sample units) on the zero level
 * of f: the distance along f's gradient, either way, to the first of the
 * steps 0.05, 0.10, ... 2 on the other sign (2 if none); the copy moves a
 * vertex by at most 0.45 of it. The copy skips the steps f's slope bound
 * says cannot change sign; walk_every_step = 1 looks at each (the
 * reference the skipping must equal). */
double gs_field_copy_room(const gs_field *f, const double p[3], int walk_every_step);
/* The provenance packed (the copy's, kept beside the meshes: 4 bytes a
 * sample unpacked, 537 MB at 512^3): each row (y, z) of the target as runs
 * along x, a run being either a stretch of one source row copied in order
 * (prov[t + 1] = prov[t] + 1) or a stretch of one negative value. Lossless:
 * gs_field_prov_at(p, t) is prov[t] for every t. Memory: 8 bytes a row plus
 * 8 bytes a run (runs: ~ the samples over the copied pieces' widths). */
typedef struct gs_field_prov {
    int64_t n[3];   /* target samples x, y, z */
    int64_t *row;   /* n[1] n[2] + 1: the first run of each row (y + n[1] z) */
    int32_t *run;   /* per run: its first x, its first value */
    int64_t runs;
} gs_field_prov;
gs_err gs_field_prov_pack(const int32_t *prov, const int64_t n[3], gs_field_prov *out);
int32_t gs_field_prov_at(const gs_field_prov *p, int64_t t);
size_t gs_field_prov_bytes(const gs_field_prov *p);
void gs_field_prov_destroy(gs_field_prov *p);

/* The same as gs_field_copy_geometry, from the packed provenance and with
 * base and prov consumed: the copy takes base's triangles (they are the
 * same) instead of a second array of them, prov is destroyed as soon as the
 * copy no longer reads it (before the relaxation, the room and the
 * unfolding), and base is destroyed on success (its memory freed before the
 * copy is written). Same mesh and figures, bit for bit. */
gs_err gs_field_copy_geometry_consume(const gs_mesh *src_mesh, const int64_t sn[3],
                                      gs_field_prov *prov, const gs_field *target, gs_mesh *base,
                                      double snap, int relax, gs_mesh *out,
                                      gs_field_copy_stats *st);

/* The paper's Figure 7c: the surface height of every column (x, y) of f,
 * the highest sign change from inside (< 0) below to outside above, linear
 * between samples (nz - 1 when the column is inside to the top, 0 when it
 * is outside throughout), in samples, written as a 16-bit grey PNG with
 * level = round((z - base) / height * 65535) clamped, row 0 = largest y:
 * with the base and relief gs_field_from_heightmap used (base = (depth -
 * height) / 2) the inverse of reading a height map. */
gs_err gs_field_write_heightmap(const gs_field *f, double base, double height, const char *path);
/* The surface heights of gs_field_write_heightmap, in samples: h[x + nx * y]
 * (row 0 = y 0), nx * ny doubles. */
void gs_field_surface_heights(const gs_field *f, double *h);

#endif
