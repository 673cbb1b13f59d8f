/* Preview pictures of a run's result: one PNG with the example and the
 * output side by side (or any number of panels), so a user sees at once
 * whether the output resembles the example. Shared by every engine.
 *
 * Each panel is a triangle mesh rendered with the built-in renderer
 * (include/geosynth/render.h) from the same camera direction, fitted to its
 * own bounding box, optionally with per-vertex RGB colours. geosynth's
 * geometry is z-up; the renderer is y-up, so panels are turned z-up -> y-up
 * (x, y, z) -> (x, z, -y) before drawing (the picture shows +z at the top):
 * into a copy, or, for a panel that gives its mesh as `turn`, in place and
 * back afterwards (a swap and a negation: exact, the same picture). Panels are placed left
 * to right in the order given (by convention: example first, then output),
 * separated by a 4-pixel light gutter. A panel with no mesh (NULL or no
 * triangles) is left as background.
 *
 * Cost: one render per panel (see render.h). Memory: the copies of the
 * positions of the meshes not given as `turn` (12 bytes a vertex), the
 * normals of the one being drawn (12 bytes a vertex, plus
 * gs_mesh_compute_normals' sums of at most 2^22 vertices) and the pictures.
 */
#ifndef GEOSYNTH_PREVIEW_H
#define GEOSYNTH_PREVIEW_H

#include <stdint.h>

#include "geosynth/error.h"
#include "geosynth/mesh.h"

typedef struct gs_preview_panel {
    const gs_mesh *mesh;    /* z-up mesh, or NULL for an empty panel */
    const uint8_t *colors;  /* RGB per vertex (3 * nverts bytes) or NULL (grey) */
    gs_mesh *turn;          /* NULL, or mesh itself, writable: turned y-up in place for
                               the drawing and back (no copy; its normals are ignored and
                               left as they were); its positions must not be read by
                               another thread meanwhile */
} gs_preview_panel;

#define GS_PREVIEW_MAX_PANELS 8

/* Renders n panels (1 .. GS_PREVIEW_MAX_PANELS) of side x side pixels each
 * (16 .. 2048) into one PNG at path (written atomically). Errors: GS_ERR_ARG
 * for bad counts or sizes, GS_ERR_LIB when the renderer is unavailable,
 * GS_ERR_IO when the file cannot be written. */
gs_err gs_preview_write(const char *path, const gs_preview_panel *panels, int n, int side);

/* gs_preview_write for a run's optional picture: without a renderer
 * (GS_ERR_LIB) it logs one warning and returns GS_OK with *written = 0;
 * *written = 1 when the file was written; other errors are returned. */
gs_err gs_preview_write_optional(const char *path, const gs_preview_panel *panels, int n,
                                 int side, int *written);

#endif
