/* Headless mesh rendering (see include/geosynth/render.h): camera,
 * projection and the picture here; the drawing with OSMesa and legacy GL in
 * the render plugin (src/plugins/render_gl.c, loaded on first use, see
 * include/geosynth/plugin.h). The matrices are computed here rather than
 * with glFrustum/gluLookAt so that gs_render_project gives exactly the
 * projection the picture was drawn with (tests check lit pixels against it). */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/plugin.h"
#include "geosynth/render.h"
#include "plugins/plugin_api.h"

#define FOV_Y_DEG 30.0
#define PI 3.14159265358979323846

void gs_render_defaults(gs_render_opts *o, int width, int height)
{
    memset(o, 0, sizeof *o);
    o->width = width;
    o->height = height;
    o->supersample = 2;
    o->azimuth_deg = 30;
    o->elevation_deg = 25;
    o->background[0] = 38, o->background[1] = 42, o->background[2] = 52;
    o->base_color[0] = o->base_color[1] = o->base_color[2] = 200;
}

static void normalize3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0)
        v[0] /= l, v[1] /= l, v[2] /= l;
}

static void cross3(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

void gs_render_camera_fit(const float lo[3], const float hi[3], const gs_render_opts *o,
                          gs_render_camera *cam)
{
    double c[3], r = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * ((double)lo[k] + hi[k]);
        double h = 0.5 * ((double)hi[k] - lo[k]);
        r += h * h;
    }
    r = sqrt(r);
    if (!(r > 0))
        r = 1; /* a single point: any frame will do */
    double aspect = (double)o->width / o->height;
    double ty = tan(0.5 * FOV_Y_DEG * PI / 180.0);
    double t = aspect < 1 ? ty * aspect : ty; /* the narrower half-angle */
    double dist = r * sqrt(1 + t * t) / t;     /* sphere of radius r fits the cone */
    double az = o->azimuth_deg * PI / 180.0, el = o->elevation_deg * PI / 180.0;
    double back[3] = {cos(el) * sin(az), sin(el), cos(el) * cos(az)}; /* eye - centre */
    double eye[3] = {c[0] + dist * back[0], c[1] + dist * back[1], c[2] + dist * back[2]};
    double up[3] = {0, 1, 0}, side[3], upv[3];
    cross3(up, back, side);
    normalize3(side);
    cross3(back, side, upv);
    double *V = cam->view;
    memset(V, 0, 16 * sizeof *V);
    for (int k = 0; k < 3; k++) {
        V[4 * k + 0] = side[k];
        V[4 * k + 1] = upv[k];
        V[4 * k + 2] = back[k];
    }
    V[12] = -(side[0] * eye[0] + side[1] * eye[1] + side[2] * eye[2]);
    V[13] = -(upv[0] * eye[0] + upv[1] * eye[1] + upv[2] * eye[2]);
    V[14] = -(back[0] * eye[0] + back[1] * eye[1] + back[2] * eye[2]);
    V[15] = 1;
    double n = fmax(dist - 1.01 * r, 1e-3 * dist), f = dist + 1.01 * r;
    double *P = cam->proj;
    memset(P, 0, 16 * sizeof *P);
    P[0] = 1 / (ty * aspect);
    P[5] = 1 / ty;
    P[10] = -(f + n) / (f - n);
    P[11] = -1;
    P[14] = -2 * f * n / (f - n);
    cam->width = o->width;
    cam->height = o->height;
}

static void mat_vec(const double *M, const double v[4], double out[4])
{
    for (int r = 0; r < 4; r++)
        out[r] = M[r] * v[0] + M[4 + r] * v[1] + M[8 + r] * v[2] + M[12 + r] * v[3];
}

int gs_render_project(const gs_render_camera *cam, const double p[3], double *x, double *y)
{
    double v[4] = {p[0], p[1], p[2], 1}, e[4], c[4];
    mat_vec(cam->view, v, e);
    mat_vec(cam->proj, e, c);
    if (!(c[3] > 0))
        return 0;
    *x = (c[0] / c[3] + 1) * 0.5 * cam->width;
    *y = (1 - c[1] / c[3]) * 0.5 * cam->height;
    return 1;
}

/* Zooms the camera (same position, narrower field of view) so the mesh's
 * own vertices, not just its bounding sphere, fill the frame with a small
 * margin: a sphere would otherwise cover only ~58% of the picture's height.
 * O(vertices). The depth range is unchanged, so nothing is clipped. */
static void frame_vertices(const gs_mesh *m, gs_render_camera *cam)
{
    double ext = 0;
    for (size_t v = 0; v < m->nverts; v++) {
        double p[4] = {m->pos[3 * v], m->pos[3 * v + 1], m->pos[3 * v + 2], 1}, e[4], c[4];
        mat_vec(cam->view, p, e);
        mat_vec(cam->proj, e, c);
        if (c[3] > 0)
            ext = fmax(ext, fmax(fabs(c[0] / c[3]), fabs(c[1] / c[3])));
    }
    if (ext > 0 && ext < 1) {
        double zoom = 0.92 / ext;
        cam->proj[0] *= zoom;
        cam->proj[5] *= zoom;
    }
}

gs_err gs_render_mesh(const gs_mesh *m, const gs_render_opts *o, gs_image *out,
                      gs_render_camera *cam_out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(o->width >= 1 && o->width <= GS_RENDER_MAX_SIDE && o->height >= 1 &&
                 o->height <= GS_RENDER_MAX_SIDE,
             GS_ERR_ARG, "render size %d x %d: each side must be in [1, %d]", o->width, o->height,
             GS_RENDER_MAX_SIDE);
    GS_CHECK(o->supersample >= 1 && o->supersample <= 4, GS_ERR_ARG,
             "render supersample %d: expected 1 .. 4", o->supersample);
    GS_CHECK(o->elevation_deg > -90 && o->elevation_deg < 90, GS_ERR_ARG,
             "render elevation %g: expected a value in (-90, 90) degrees", o->elevation_deg);
    GS_CHECK(m->ntris > 0 && m->pos && m->tris, GS_ERR_ARG, "render: the mesh has no triangles");
    int k = o->supersample, W = o->width * k, H = o->height * k;
    float lo[3], hi[3];
    gs_mesh_bbox(m, lo, hi);
    gs_render_camera cam;
    gs_render_camera_fit(lo, hi, o, &cam);
    frame_vertices(m, &cam);
    if (cam_out)
        *cam_out = cam;

    gs_err err = GS_OK;
    float *normals = m->normals;
    gs_mesh tmp = *m;
    uint8_t *rgba = NULL;
    gs_renderp_draw_fn *draw;
    void *sym;
    GS_TRY(err, gs_plugin_sym("render", "gs_renderp_draw", &sym), done);
    memcpy(&draw, &sym, sizeof draw);
    if (!normals) {
        tmp.normals = NULL;
        GS_TRY(err, gs_mesh_compute_normals(&tmp), done);
        normals = tmp.normals;
    }
    GS_TRY(err, gs_alloc_array((void **)&rgba, (size_t)W * H, 4, "render buffer"), done);
    GS_TRY(err, draw(m, normals, &cam, o, W, H, rgba), done);
    GS_TRY(err, gs_image_alloc(out, o->width, o->height, 3, 8), done);
    /* OSMesa's row 0 is the bottom row; gs_image's is the top. Box filter. */
    for (int y = 0; y < o->height; y++) {
        for (int x = 0; x < o->width; x++) {
            unsigned sum[3] = {0, 0, 0};
            for (int sy = 0; sy < k; sy++) {
                const uint8_t *row = rgba + (size_t)(H - 1 - (y * k + sy)) * W * 4;
                for (int sx = 0; sx < k; sx++)
                    for (int c = 0; c < 3; c++)
                        sum[c] += row[(size_t)(x * k + sx) * 4 + c];
            }
            uint8_t *px = out->data8 + ((size_t)y * o->width + x) * 3;
            for (int c = 0; c < 3; c++)
                px[c] = (uint8_t)((sum[c] + (unsigned)(k * k) / 2) / (unsigned)(k * k));
        }
    }
done:
    gs_free(rgba);
    if (tmp.normals != m->normals)
        gs_free(tmp.normals);
    if (err)
        gs_image_destroy(out);
    return err;
}

gs_err gs_render_mesh_png(const gs_mesh *m, const gs_render_opts *o, const char *path)
{
    gs_image img;
    GS_CALL(gs_render_mesh(m, o, &img, NULL));
    gs_err err = gs_image_write_png(path, &img);
    gs_image_destroy(&img);
    if (err) {
        gs_error_add_context("thumbnail %s", path);
        GS_CALL(err);
    }
    return GS_OK;
}
