/* Headless mesh rendering: a shaded picture of a triangle mesh, for
 * thumbnails (the micro engine's gallery). The one module that talks to
 * OpenGL: Mesa's OSMesa (off-screen, software, no display, no GPU; MIT
 * licence), legacy fixed-function GL.
 *
 * Picture: one directional light from behind the viewer's left shoulder plus
 * ambient, two-sided lighting (open meshes show their back faces lit too),
 * vertex normals (computed here when the mesh has none), optional per-vertex
 * RGB colours (else light grey), depth test, optional supersampling (the
 * picture is rendered k times larger and box-filtered down).
 * Camera: perspective, vertical field of view 30 degrees, looking at the
 * centre of the mesh's bounding box from the direction given by azimuth
 * (around +y, 0 = from +z) and elevation (above the xz plane); the distance
 * is chosen so the bounding box's circumscribed sphere fits the picture, then
 * the view is zoomed until the mesh's vertices span 92% of the narrower side,
 * so any mesh fills the frame without clipping.
 *
 * Cost: O(triangles) on the CPU (llvmpipe or softpipe), a 256^2 thumbnail of
 * a 100k-triangle mesh takes well under a second. Memory: width * height *
 * k^2 * 8 bytes (colour + depth) plus the image.
 * Not thread-safe (one GL context is current per process during a call).
 */
#ifndef GEOSYNTH_RENDER_H
#define GEOSYNTH_RENDER_H

#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/image.h"
#include "geosynth/mesh.h"

#define GS_RENDER_MAX_SIDE 4096 /* pixels per side of the output picture */

typedef struct gs_render_opts {
    int width, height;        /* output pixels, 1 .. GS_RENDER_MAX_SIDE */
    int supersample;          /* 1 .. 4 (1 = none) */
    double azimuth_deg;       /* camera direction around +y (0 = from +z) */
    double elevation_deg;     /* camera direction above the xz plane, (-90, 90) */
    uint8_t background[3];    /* RGB */
    uint8_t base_color[3];    /* RGB of vertices without a colour */
    const uint8_t *colors;    /* optional RGB per vertex (3 * nverts bytes), NULL = base */
} gs_render_opts;

/* Defaults: width x height, supersample 2, azimuth 30, elevation 25, a dark
 * blue-grey background, light grey mesh, no vertex colours. */
void gs_render_defaults(gs_render_opts *o, int width, int height);

/* The camera of a picture: column-major 4x4 view and projection matrices
 * (OpenGL conventions) and the output size. */
typedef struct gs_render_camera {
    double view[16], proj[16];
    int width, height;
} gs_render_camera;

/* The camera for a mesh with this bounding box before the zoom to the
 * vertices (gs_render_mesh reports the zoomed one it used). */
void gs_render_camera_fit(const float lo[3], const float hi[3], const gs_render_opts *o,
                          gs_render_camera *cam);

/* Pixel coordinates of a model-space point in the picture: x to the right,
 * y down from the top row (row 0 = top, as in gs_image), pixel centres at
 * +0.5. Returns 0 when the point is behind the camera. */
int gs_render_project(const gs_render_camera *cam, const double p[3], double *x, double *y);

/* Renders m into *out (RGB, 8 bit, width x height). cam (optional) receives
 * the camera used. Errors: GS_ERR_ARG for a bad size/option or a mesh with
 * no triangles, GS_ERR_LIB when OSMesa cannot create a context. On error
 * *out is zeroed. Caller frees with gs_image_destroy. */
gs_err gs_render_mesh(const gs_mesh *m, const gs_render_opts *o, gs_image *out,
                      gs_render_camera *cam);

/* gs_render_mesh + gs_image_write_png (atomic write). */
gs_err gs_render_mesh_png(const gs_mesh *m, const gs_render_opts *o, const char *path);

#endif
