/* Side-by-side preview pictures (see include/geosynth/preview.h). */
#include <string.h>

#include "geosynth/image.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/preview.h"
#include "geosynth/render.h"

#define GUTTER 4

/* A y-up copy of a z-up mesh: (x, y, z) -> (x, z, -y), triangles shared. */
static gs_err y_up_copy(const gs_mesh *m, gs_mesh *out, float **pos)
{
    GS_CALL(gs_alloc_array((void **)pos, m->nverts, 3 * sizeof **pos, "preview positions"));
    for (size_t v = 0; v < m->nverts; v++) {
        (*pos)[3 * v + 0] = m->pos[3 * v + 0];
        (*pos)[3 * v + 1] = m->pos[3 * v + 2];
        (*pos)[3 * v + 2] = -m->pos[3 * v + 1];
    }
    memset(out, 0, sizeof *out);
    out->nverts = m->nverts;
    out->ntris = m->ntris;
    out->pos = *pos;
    out->tris = m->tris;
    return GS_OK;
}

/* (x, y, z) -> (x, z, -y) in place, and back: (x, y, z) -> (x, -z, y). */
static void turn_y_up(gs_mesh *m)
{
    for (size_t v = 0; v < m->nverts; v++) {
        float *p = m->pos + 3 * v, y = p[1];
        p[1] = p[2];
        p[2] = -y;
    }
}

static void turn_z_up(gs_mesh *m)
{
    for (size_t v = 0; v < m->nverts; v++) {
        float *p = m->pos + 3 * v, y = p[1];
        p[1] = -p[2];
        p[2] = y;
    }
}

gs_err gs_preview_write(const char *path, const gs_preview_panel *panels, int n, int side)
{
    GS_CHECK(n >= 1 && n <= GS_PREVIEW_MAX_PANELS, GS_ERR_ARG,
             "preview %s: %d panels, expected 1 .. %d", path, n, GS_PREVIEW_MAX_PANELS);
    GS_CHECK(side >= 16 && side <= 2048, GS_ERR_ARG,
             "preview %s: panel side %d pixels, expected 16 .. 2048", path, side);
    gs_render_opts o;
    gs_render_defaults(&o, side, side);
    gs_image all = {0};
    int width = n * side + (n - 1) * GUTTER;
    GS_CALL(gs_image_alloc(&all, width, side, 3, 8));
    for (int y = 0; y < side; y++)
        for (int x = 0; x < width; x++) {
            int gutter = (x % (side + GUTTER)) >= side;
            uint8_t *px = all.data8 + 3 * ((size_t)y * width + x);
            for (int c = 0; c < 3; c++)
                px[c] = gutter ? 150 : o.background[c];
        }
    gs_err err = GS_OK;
    for (int i = 0; i < n && !err; i++) {
        const gs_mesh *m = panels[i].mesh;
        if (!m || m->ntris == 0)
            continue;
        GS_TRY_CHECK(err, !panels[i].turn || panels[i].turn == m, GS_ERR_ARG, done,
                     "preview %s: panel %d's turn is not its mesh", path, i);
        gs_mesh up;
        float *pos = NULL;
        gs_image pic = {0};
        if (panels[i].turn) { /* the same positions as the copy's, no copy */
            turn_y_up(panels[i].turn);
            up = *panels[i].turn;
            up.normals = NULL;
        } else {
            GS_TRY(err, y_up_copy(m, &up, &pos), next);
        }
        o.colors = panels[i].colors;
        err = gs_render_mesh(&up, &o, &pic, NULL);
        if (panels[i].turn)
            turn_z_up(panels[i].turn);
        GS_TRY(err, err, next);
        for (int y = 0; y < side; y++)
            memcpy(all.data8 + 3 * ((size_t)y * width + (size_t)i * (side + GUTTER)),
                   pic.data8 + 3 * (size_t)y * side, 3 * (size_t)side);
    next:
        gs_image_destroy(&pic);
        gs_free(pos);
    }
    if (!err)
        GS_TRY(err, gs_image_write_png(path, &all), done);
done:
    gs_image_destroy(&all);
    if (err)
        gs_error_add_context("while writing the preview %s", path);
    return err;
}

gs_err gs_preview_write_optional(const char *path, const gs_preview_panel *panels, int n,
                                 int side, int *written)
{
    *written = 0;
    gs_err err = gs_preview_write(path, panels, n, side);
    if (err == GS_ERR_LIB) {
        gs_log(GS_LOG_WARN, "preview.png not written: %s", gs_error_message());
        gs_error_clear();
        return GS_OK;
    }
    *written = err == GS_OK;
    return err;
}
