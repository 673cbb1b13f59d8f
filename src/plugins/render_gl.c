/* The render plugin geosynth-render.so (include/geosynth/plugin.h): draws a
 * mesh with OSMesa and legacy GL into an RGBA buffer for src/io/render.c,
 * which owns the camera, the options' checks and the picture. */
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <stdint.h>
#include <string.h>

#include "geosynth/render.h"
#include "plugins/plugin_api.h"

#define DRAW_CHUNK_TRIS ((size_t)1 << 24) /* glDrawElements counts are GLsizei */

/* Draws the mesh into the current context (state set by the caller). */
static void draw_mesh(const gs_mesh *m, const float *normals, const gs_render_opts *o)
{
    glEnableClientState(GL_VERTEX_ARRAY);
    glEnableClientState(GL_NORMAL_ARRAY);
    glVertexPointer(3, GL_FLOAT, 0, m->pos);
    glNormalPointer(GL_FLOAT, 0, normals);
    if (o->colors) {
        glEnableClientState(GL_COLOR_ARRAY);
        glColorPointer(3, GL_UNSIGNED_BYTE, 0, o->colors);
    } else {
        glColor3ub(o->base_color[0], o->base_color[1], o->base_color[2]);
    }
    for (size_t t0 = 0; t0 < m->ntris; t0 += DRAW_CHUNK_TRIS) {
        size_t n = m->ntris - t0 < DRAW_CHUNK_TRIS ? m->ntris - t0 : DRAW_CHUNK_TRIS;
        glDrawElements(GL_TRIANGLES, (GLsizei)(3 * n), GL_UNSIGNED_INT, m->tris + 3 * t0);
    }
    glDisableClientState(GL_COLOR_ARRAY);
    glDisableClientState(GL_NORMAL_ARRAY);
    glDisableClientState(GL_VERTEX_ARRAY);
}

static void set_state(const gs_render_camera *cam, const gs_render_opts *o, int w, int h)
{
    glViewport(0, 0, w, h);
    glClearColor(o->background[0] / 255.0f, o->background[1] / 255.0f, o->background[2] / 255.0f,
                 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);
    glShadeModel(GL_SMOOTH);
    glMatrixMode(GL_PROJECTION);
    glLoadMatrixd(cam->proj);
    glMatrixMode(GL_MODELVIEW);
    glLoadIdentity();
    /* Light in eye space (identity modelview when set): from the upper left,
     * slightly behind the viewer; w = 0 makes it directional. */
    const GLfloat light_dir[4] = {-0.45f, 0.6f, 0.66f, 0.0f};
    const GLfloat diffuse[4] = {0.85f, 0.85f, 0.85f, 1.0f};
    const GLfloat ambient[4] = {0.22f, 0.22f, 0.22f, 1.0f};
    const GLfloat specular[4] = {0.25f, 0.25f, 0.25f, 1.0f};
    const GLfloat black[4] = {0, 0, 0, 1};
    glLightfv(GL_LIGHT0, GL_POSITION, light_dir);
    glLightfv(GL_LIGHT0, GL_DIFFUSE, diffuse);
    glLightfv(GL_LIGHT0, GL_SPECULAR, specular);
    glLightfv(GL_LIGHT0, GL_AMBIENT, black);
    glLightModelfv(GL_LIGHT_MODEL_AMBIENT, ambient);
    glLightModeli(GL_LIGHT_MODEL_TWO_SIDE, GL_TRUE);
    glEnable(GL_LIGHTING);
    glEnable(GL_LIGHT0);
    glEnable(GL_NORMALIZE);
    glEnable(GL_COLOR_MATERIAL);
    glColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
    glMaterialfv(GL_FRONT_AND_BACK, GL_SPECULAR, specular);
    glMaterialf(GL_FRONT_AND_BACK, GL_SHININESS, 24.0f);
    glLoadMatrixd(cam->view);
}

gs_err gs_renderp_draw(const gs_mesh *m, const float *normals, const gs_render_camera *cam,
                       const gs_render_opts *o, int W, int H, uint8_t *rgba)
{
    gs_err err = GS_OK;
    OSMesaContext ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, NULL);
    GS_TRY_CHECK(err, ctx != NULL, GS_ERR_LIB, done,
                 "OSMesa: cannot create an off-screen GL context (libOSMesa from Mesa)");
    GS_TRY_CHECK(err, OSMesaMakeCurrent(ctx, rgba, GL_UNSIGNED_BYTE, W, H), GS_ERR_LIB, done,
                 "OSMesa: cannot bind a %d x %d buffer", W, H);
    set_state(cam, o, W, H);
    draw_mesh(m, normals, o);
    glFinish();
    GLenum glerr = glGetError();
    GS_TRY_CHECK(err, glerr == GL_NO_ERROR, GS_ERR_LIB, done, "OpenGL error 0x%x while rendering",
                 (unsigned)glerr);
done:
    if (ctx)
        OSMesaDestroyContext(ctx);
    return err;
}
