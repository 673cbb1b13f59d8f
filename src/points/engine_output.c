/* points driver, output: points.ply, patches.csv, mesh.ply / mesh.glb,
 * preview.png, and the measures of the output against the example (seams,
 * whole objects: heights, fragments) into summary.json. */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "geosynth/file.h"
#include "geosynth/log.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/pointply.h"
#include "geosynth/preview.h"
#include "geosynth/vdb.h"
#include "geosynth/sort.h"
#include "points/engine_impl.h"

static gs_err write_patch_csv(const char *path, const gs_points_patch_metrics *m, size_t n)
{
    gs_atomic_file af;
    GS_CALL(gs_atomic_begin(path, &af));
    int ok = fprintf(af.f, "patch,chosen,candidates,best_dist,chosen_dist,pairs,pair_gap,"
                           "warp_residual,warp,rank,continuations\n") > 0;
    for (size_t k = 0; k < n && ok; k++)
        ok = fprintf(af.f, "%zu,%llu,%u,%.9g,%.9g,%u,%.9g,%.9g,%u,%u,%u\n", k,
                     (unsigned long long)m[k].chosen, m[k].candidates, m[k].best_dist,
                     m[k].chosen_dist, m[k].pairs, m[k].pair_gap, m[k].warp_residual,
                     m[k].warp, m[k].rank, m[k].continuations) > 0;
    if (!ok) {
        gs_atomic_abort(&af);
        GS_RAISE(GS_ERR_IO, "%s: write failed", path);
    }
    GS_CALL(gs_atomic_commit(&af));
    return GS_OK;
}

/* Mesh of the output (z-up points) written with the original axes. */
/* A z-up triangle mesh of pts: the implicit function of the points
 * (gs_points_implicit_grid) on a grid of `voxel`, contoured by OpenVDB, then
 * trimmed to the points' own extent: the grid reaches 2 R past the points,
 * where the function keeps the sign of the column above it (inside below a
 * height field), so contouring closed the solid with vertical walls along
 * the borders and a floor at the grid's bottom; triangles whose centroid
 * is outside the points' xy range or more than R below the lowest point are
 * dropped (the surface ends open at the borders, as the points do). */
static gs_err mesh_points(const gs_points *pts, double voxel, double R, double spacing,
                          double max_samples, gs_mesh *m)
{
    memset(m, 0, sizeof *m);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < pts->n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], pts->v[i].p[a]);
            hi[a] = fmax(hi[a], pts->v[i].p[a]);
        }
    GS_CHECK(pts->n > 0, GS_ERR_ARG, "mesh: no points");
    double plo[3], phi[3];
    memcpy(plo, lo, sizeof plo);
    memcpy(phi, hi, sizeof phi);
    size_t dim[3];
    double samples = 1;
    for (int a = 0; a < 3; a++) {
        lo[a] -= 2 * R;
        hi[a] += 2 * R;
        dim[a] = (size_t)ceil((hi[a] - lo[a]) / voxel) + 1;
        samples *= (double)dim[a];
    }
    GS_CHECK(samples <= max_samples, GS_ERR_ARG,
             "output.mesh: the grid would have %zu x %zu x %zu = %.3g samples (%.1f GiB), above "
             "output.mesh_max_samples = %.3g: raise output.mesh_voxel or the limit, or set "
             "output.mesh = false", dim[0], dim[1], dim[2], samples, samples * 20 / 1073741824.0,
             max_samples);
    gs_log(GS_LOG_INFO, "mesh: implicit grid %zu x %zu x %zu, voxel %g (%.1f MiB)", dim[0], dim[1],
           dim[2], voxel, samples * 20 / 1048576.0);
    gs_vdb_dense d;
    GS_CALL(gs_vdb_dense_alloc(&d, dim[0], dim[1], dim[2]));
    memcpy(d.origin, lo, sizeof d.origin);
    d.voxel = voxel;
    d.background = (float)R;
    gs_err err = GS_OK;
    gs_points_grid_t g = NULL;
    gs_points nb = {0};
    GS_TRY(err, gs_points_implicit_grid(pts, R, lo, voxel, dim[0], dim[1], dim[2], d.v), done);
    GS_TRY(err, gs_vdb_dense_to_mesh(&d, 0.0, 0.0, m), done);
    /* Also dropped: triangles farther than max(2 voxels, 2 spacings) from
     * every point. Below an open piece of surface (a flower or a ring cut
     * at a seam) the column rule makes the solid continue down, and the
     * contour hung curtains under it, away from any point. */
    double near = fmax(2 * voxel, 2 * spacing);
    GS_TRY(err, gs_points_grid_create(plo, phi, near, &g), done);
    for (size_t i = 0; i < pts->n; i++)
        GS_TRY(err, gs_points_grid_add(g, &pts->v[i]), done);
    size_t kept = 0;
    for (size_t t = 0; t < m->ntris; t++) {
        const uint32_t *v = m->tris + 3 * t;
        double c[3] = {0, 0, 0};
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++)
                c[a] += m->pos[3 * (size_t)v[k] + a] / 3.0;
        if (c[0] < plo[0] || c[0] > phi[0] || c[1] < plo[1] || c[1] > phi[1] ||
            c[2] < plo[2] - R)
            continue;
        nb.n = 0;
        GS_TRY(err, gs_points_grid_query(g, c, near, &nb), done);
        if (nb.n == 0)
            continue;
        memmove(m->tris + 3 * kept++, v, 3 * sizeof *v);
    }
    m->ntris = kept;
done:
    gs_points_grid_destroy(&g);
    gs_points_free(&nb);
    gs_vdb_dense_destroy(&d);
    if (err != GS_OK)
        gs_mesh_destroy(m);
    return err;
}

static gs_err write_mesh(const points_config *c, const gs_points *pts, double spacing, double R,
                         const char *path, size_t *ntris)
{
    gs_mesh m;
    GS_CALL(mesh_points(pts, c->mesh_voxel * spacing, R, spacing, c->mesh_max_samples, &m));
    /* trimming to the points leaves vertices no triangle uses (4,619 of
     * 19,442 on quick.ini): readers keep them as loose points */
    gs_err err = gs_mesh_weld(&m, 0.0f);
    if (err) {
        gs_mesh_destroy(&m);
        return err;
    }
    /* Back to the example's axes: the inverse cyclic permutation (a rotation,
     * so triangle orientation is kept). */
    int up = up_axis(c);
    for (size_t i = 0; i < m.nverts && up != 2; i++) {
        float *v = m.pos + 3 * i, a = v[0], b = v[1], cc = v[2];
        if (up == 0) {
            v[0] = cc;
            v[1] = a;
            v[2] = b;
        } else {
            v[0] = b;
            v[1] = cc;
            v[2] = a;
        }
    }
    const gs_mesh_meta meta = {"geosynth points surface", "the example's units",
                               "surface reconstructed from the synthesized points (output.mesh)"};
    GS_TRY(err, gs_mesh_write_meta(path, &m, NULL, NULL, &meta), done);
    if (m.ntris) {
        char glb[PATH_MAX];
        gs_path_with_ext(path, "glb", glb, sizeof glb);
        GS_TRY(err, gs_mesh_write_glb(glb, &m, NULL, &meta), done);
    }
    *ntris = m.ntris;
done:
    gs_mesh_destroy(&m);
    return err;
}

/* Whether p lies over the example's box B_Tin (x y). */
static int in_example_box(const gs_points_texture *t, const double *p)
{
    return p[0] >= t->box_lo[0] && p[0] < t->box_hi[0] && p[1] >= t->box_lo[1] &&
           p[1] < t->box_hi[1];
}

/* RUN_DIR/preview.png: the example (inside its box) and the output
 * cropped to twice the example's extent, meshed (mesh_points) at 1.5
 * spacings at least and rendered side by side. *written = 0 without a
 * renderer (a warning, the run goes on). */
static gs_err write_preview(const points_config *c, const gs_points_texture *tex,
                            const gs_points *zup, double R, const char *path, int *written)
{
    *written = 0;
    gs_points ex = {0}, out = {0};
    gs_mesh me, mo;
    memset(&me, 0, sizeof me);
    memset(&mo, 0, sizeof mo);
    double bx = tex->box_hi[0] - tex->box_lo[0], by = tex->box_hi[1] - tex->box_lo[1];
    gs_err err = GS_OK;
    for (size_t i = 0; i < tex->pts.n; i++) {
        const double *p = tex->pts.v[i].p;
        if (in_example_box(tex, p))
            GS_TRY(err, gs_points_append(&ex, &tex->pts.v[i], 1), done);
    }
    for (size_t i = 0; i < zup->n; i++) {
        const double *p = zup->v[i].p;
        if (p[0] < 2 * bx && p[1] < 2 * by)
            GS_TRY(err, gs_points_append(&out, &zup->v[i], 1), done);
    }
    double voxel = fmax(c->mesh_voxel, 1.5) * tex->spacing;
    GS_TRY(err, mesh_points(&ex, voxel, R, tex->spacing, c->mesh_max_samples, &me), done);
    GS_TRY(err, mesh_points(&out, voxel, R, tex->spacing, c->mesh_max_samples, &mo), done);
    gs_preview_panel panels[2] = {{&me, NULL, NULL}, {&mo, NULL, NULL}};
    err = gs_preview_write_optional(path, panels, 2, 512, written);
done:
    gs_points_free(&ex);
    gs_points_free(&out);
    gs_mesh_destroy(&me);
    gs_mesh_destroy(&mo);
    return err;
}

/* Distinct input patches among the chosen ones (0 on no memory). */
static size_t distinct_sources(const gs_points_patch_metrics *m, size_t n)
{
    uint64_t *v = gs_malloc(n ? n * sizeof *v : 1);
    if (!v)
        return 0;
    for (size_t k = 0; k < n; k++)
        v[k] = m[k].chosen;
    gs_sort_u64(v, n);
    size_t d = 0;
    for (size_t k = 0; k < n; k++)
        d += k == 0 || v[k] != v[k - 1];
    gs_free(v);
    return d;
}

/* Pieces of pts (link radius r) inside the xy box [lo, hi), leaving out
 * those the box's border cuts (gs_measure_point_pieces), and the specks
 * among them (fewer than GS_POINTS_SPECK_POINTS points), with their
 * densities per unit area (pieces, specks; minus-sampling). The output is
 * measured inside its size, the example inside its box, alike: before, the
 * output's pieces cut by its border counted as specks (heightfield.ini
 * seed 1: 24 of 225) and the example's were counted whole. */
static gs_err count_fragments(const gs_points *pts, double r, const double *lo, const double *hi,
                              uint32_t *all, uint32_t *small, uint64_t *small_points,
                              double density[2])
{
    gs_measure_pieces pc;
    GS_CALL(gs_measure_point_pieces((const double *)pts->v, 6, pts->n, r, lo, hi,
                                    GS_POINTS_SPECK_POINTS, &pc));
    *all = pc.pieces;
    *small = pc.small;
    if (small_points)
        *small_points = pc.small_points;
    density[0] = pc.density;
    density[1] = pc.small_density;
    return GS_OK;
}

/* Shares of v[0, n) below lo and above hi, and its median (sorts v). */
static void nn_figures(double *v, size_t n, double lo, double hi, double *close, double *far,
                       double *median)
{
    size_t a = 0, b = 0;
    for (size_t i = 0; i < n; i++) {
        a += v[i] < lo;
        b += v[i] > hi;
    }
    *close = n ? (double)a / (double)n : 0;
    *far = n ? (double)b / (double)n : 0;
    gs_sort_f64(v, n);
    *median = n ? v[n / 2] : 0;
}

/* The nearest-neighbour spacing of the output's strip points and of its
 * other points against the example's (objects_stats nn_*): each point's
 * distance to its nearest other point, for the points at least the link
 * radius (2 spacings) in from the border (output) or the box's sides
 * (example; their neighbours beyond counted). What the blend leaves shows
 * there: points packed closer than the example's dart radius, or alone. */
static gs_err spacing_measures(run_state *rs, const gs_points *zup)
{
    objects_stats *o = &rs->obj;
    const gs_points_texture *t = &rs->tex;
    double sp = t->spacing, link = 2 * sp, reach = 4 * sp;
    double *d = NULL, *v[2] = {NULL, NULL}, *e = NULL, *h[2] = {NULL, NULL};
    size_t nv[2] = {0, 0}, ne = 0, nh[2] = {0, 0};
    size_t nmax = zup->n > t->pts.n ? zup->n : t->pts.n;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&d, nmax ? nmax : 1, sizeof *d, "spacing"), done);
    for (int k = 0; k < 2; k++) {
        GS_TRY(err, gs_alloc_array((void **)&v[k], nmax ? nmax : 1, sizeof *d, "spacing"), done);
        GS_TRY(err, gs_alloc_array((void **)&h[k], nmax ? nmax : 1, sizeof *d, "spacing"), done);
    }
    GS_TRY(err, gs_alloc_array((void **)&e, nmax ? nmax : 1, sizeof *d, "spacing"), done);
    GS_TRY(err, gs_measure_point_nearest((const double *)zup->v, 6, zup->n, reach, d), done);
    const double *os = rs->params.out_size;
    for (size_t i = 0; i < zup->n; i++) {
        const double *p = zup->v[i].p;
        if (p[0] < link || p[1] < link || p[0] > os[0] - link || p[1] > os[1] - link)
            continue;
        int k = gs_points_synth_in_strip(rs->synth, p) ? 0 : 1;
        v[k][nv[k]++] = d[i];
    }
    GS_TRY(err, gs_measure_point_nearest((const double *)t->pts.v, 6, t->pts.n, reach, d), done);
    double mid = 0.5 * (t->box_lo[0] + t->box_hi[0]);
    for (size_t i = 0; i < t->pts.n; i++) {
        const double *p = t->pts.v[i].p;
        if (p[0] < t->box_lo[0] + link || p[1] < t->box_lo[1] + link ||
            p[0] > t->box_hi[0] - link || p[1] > t->box_hi[1] - link)
            continue;
        e[ne++] = d[i];
        int k = p[0] < mid ? 0 : 1;
        h[k][nh[k]++] = d[i];
    }
    for (int k = 0; k < 2; k++) {
        o->nn_points[k] = nv[k];
        GS_TRY(err, gs_measure_ks(v[k], nv[k], e, ne, &o->nn_ks[k]), done);
        nn_figures(v[k], nv[k], 0.5 * sp, link, &o->nn_close[k], &o->nn_far[k], &o->nn_median[k]);
    }
    GS_TRY(err, gs_measure_ks(h[0], nh[0], h[1], nh[1], &o->example_nn_ks_halves), done);
    nn_figures(e, ne, 0.5 * sp, link, &o->example_nn_close, &o->example_nn_far,
               &o->example_nn_median);
done:
    gs_free(d);
    gs_free(e);
    for (int k = 0; k < 2; k++) {
        gs_free(v[k]);
        gs_free(h[k]);
    }
    return err;
}

/* Heights (KS against the example's inside its box) and fragments. */
static gs_err object_measures(run_state *rs, const gs_points *zup)
{
    objects_stats *o = &rs->obj;
    memset(o, 0, sizeof *o);
    const gs_points_texture *t = &rs->tex;
    double *hx = NULL, *hy = NULL;
    size_t ny = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&hx, zup->n ? zup->n : 1, sizeof *hx, "heights"), done);
    GS_TRY(err, gs_alloc_array((void **)&hy, t->pts.n ? t->pts.n : 1, sizeof *hy, "heights"), done);
    o->example_height_max = -INFINITY;
    for (size_t i = 0; i < t->pts.n; i++) {
        const double *p = t->pts.v[i].p;
        if (in_example_box(t, p)) {
            hy[ny++] = p[2];
            o->example_height_max = fmax(o->example_height_max, p[2]);
        }
    }
    o->height_max = -INFINITY;
    for (size_t i = 0; i < zup->n; i++) {
        hx[i] = zup->v[i].p[2];
        o->height_max = fmax(o->height_max, hx[i]);
        o->above_example_max += hx[i] > o->example_height_max;
    }
    GS_TRY(err, gs_measure_ks(hx, zup->n, hy, ny, &o->height_ks), done);
    {
        /* How far two pieces of the example itself differ: the scale a
         * height KS of the output is to be read against. */
        size_t na = 0, nb = 0;
        double mid = 0.5 * (t->box_lo[0] + t->box_hi[0]);
        for (size_t i = 0; i < t->pts.n; i++) {
            const double *p = t->pts.v[i].p;
            if (in_example_box(t, p)) {
                if (p[0] < mid)
                    hx[na++] = p[2];
                else
                    hy[nb++] = p[2];
            }
        }
        GS_TRY(err, gs_measure_ks(hx, na, hy, nb, &o->example_height_ks_halves), done);
    }
    double r = 2 * t->spacing;
    double olo[2] = {0, 0}, ohi[2] = {rs->params.out_size[0], rs->params.out_size[1]};
    GS_TRY(err, count_fragments(zup, r, olo, ohi, &o->fragments, &o->small_fragments,
                                &o->small_fragment_points, o->density), done);
    GS_TRY(err, count_fragments(&t->pts, r, t->box_lo, t->box_hi, &o->example_fragments,
                                &o->example_small_fragments, NULL, o->example_density), done);
    GS_TRY(err, spacing_measures(rs, zup), done);
done:
    gs_free(hx);
    gs_free(hy);
    return err;
}

/* The seam measure of the output (z-up points) and of the example. */
/* The patch-id seam measure of the example's points inside its box, cut
 * into cells by the lines ex (as far apart as the output's seams): what
 * the measure gives where no seam is, its own chance level. */
static gs_err example_patch_seams(run_state *rs, const gs_points_lines *ex, double band)
{
    const gs_points_texture *t = &rs->tex;
    gs_points in = {0};
    gs_points all = {0};
    int32_t *id = NULL, *ida = NULL;
    gs_err err = GS_OK;
    for (size_t i = 0; i < t->pts.n; i++) {
        const double *p = t->pts.v[i].p;
        if (in_example_box(t, p))
            GS_TRY(err, gs_points_append(&in, &t->pts.v[i], 1), done);
    }
    GS_TRY(err, gs_alloc_array((void **)&id, in.n ? in.n : 1, sizeof *id, "example cells"), done);
    for (size_t i = 0; i < in.n; i++) {
        int cx = 0, cy = 0;
        while (cx < ex->nx && in.v[i].p[0] >= ex->x[cx])
            cx++;
        while (cy < ex->ny && in.v[i].p[1] >= ex->y[cy])
            cy++;
        id[i] = cx + (ex->nx + 1) * cy;
    }
    GS_TRY(err, gs_measure_point_seams((const double *)in.v, in.n, id, rs->params.mls_radius, band,
                                       GS_POINTS_SEAM_MIN_WEIGHT, &rs->pseam_ex), done);
    /* The same over every place a seam can fall: the lines shifted by each
     * field step within a patch step (an output's seams lie at every such
     * offset from the example's features), one copy of the points per
     * shift, the copies set apart so that no two are within reach of the
     * measure, pooled in one call. On weave.ini the single cut's angle
     * ratio is 0.81, each of the 12 shifts alone 0.81-1.66, pooled 1.26. */
    if (rs->c->example_seam_shifts != 1) {
        double R = rs->params.mls_radius, g = rs->params.field_step;
        int steps = (int)lround(ex->seg / g), nph = (int)rs->c->example_seam_shifts;
        steps = steps < 1 ? 1 : steps;
        nph = nph == 0 || nph > steps ? steps : nph;
        double gap = t->box_hi[0] - t->box_lo[0] + 4 * R;
        int32_t ncell = (int32_t)((ex->nx + 1) * (ex->ny + 1));
        GS_TRY_CHECK(err, (double)in.n * nph < 4e9 && (double)ncell * nph < 2e9, GS_ERR_ARG,
                     done, "example seams: %zu points x %d shifts, too many", in.n, nph);
        GS_TRY(err, gs_points_reserve(&all, in.n * (size_t)nph), done);
        size_t na = in.n * (size_t)nph;
        GS_TRY(err, gs_alloc_array((void **)&ida, na ? na : 1, sizeof *ida, "example cells"), done);
        for (int j = 0; j < nph; j++) {
            double sh = (double)((j * steps) / nph) * g; /* whole field steps, evenly spread */
            for (size_t i = 0; i < in.n; i++) {
                gs_opoint q = in.v[i];
                int cx = 0, cy = 0;
                while (cx < ex->nx && q.p[0] >= ex->x[cx] - sh)
                    cx++;
                while (cy < ex->ny && q.p[1] >= ex->y[cy] - sh)
                    cy++;
                ida[all.n] = ncell * j + cx + (int32_t)(ex->nx + 1) * cy;
                q.p[0] += j * gap;
                GS_TRY(err, gs_points_append(&all, &q, 1), done);
            }
        }
        GS_TRY(err, gs_measure_point_seams_far((const double *)all.v, all.n, ida, R, band,
                                               GS_POINTS_SEAM_MIN_WEIGHT,
                                               rs->pseam_ex.inside_dist_p90, &rs->pseam_ex_all),
               done);
    }
done:
    gs_points_free(&all);
    gs_free(ida);
    gs_points_free(&in);
    gs_free(id);
    return err;
}

static gs_err seam_measures(run_state *rs, const gs_points *zup)
{
    gs_points_lines seams = {0}, inside = {0}, ex = {0}, none = {0};
    double R = rs->params.mls_radius, band = rs->tex.spacing;
    /* Seams from the patch ids: a point of another patch within 1.5
     * spacings, the other patch's surface within mls_radius, the
     * unmatched weight of the line measure. */
    double pband = fmin(1.5 * rs->tex.spacing, R);
    gs_err err = GS_OK;
    GS_TRY(err, gs_points_synth_lines(rs->synth, 0, &seams), done);
    GS_TRY(err, gs_points_synth_lines(rs->synth, 1, &inside), done);
    GS_TRY(err, gs_points_synth_lines(rs->synth, 2, &ex), done);
    GS_TRY(err, gs_points_seam_measure(zup, R, band, &seams, &inside, &rs->seam), done);
    GS_TRY(err, gs_points_seam_measure(&rs->tex.pts, R, band, &ex, &none, &rs->seam_ex), done);
    /* The example first: its inside fits' 90th percentile distance is
     * where the output's seam and inside points count as broken. */
    GS_TRY(err, example_patch_seams(rs, &ex, pband), done);
    GS_TRY(err, gs_measure_point_seams_far((const double *)zup->v, zup->n, rs->out_id, R, pband,
                                           GS_POINTS_SEAM_MIN_WEIGHT, rs->pseam_ex.inside_dist_p90,
                                           &rs->pseam), done);
done:
    gs_points_lines_free(&seams);
    gs_points_lines_free(&inside);
    gs_points_lines_free(&ex);
    return err;
}

/* The example's seam figures (example_patch_seam_*SUFFIX). */
static void example_seam_metrics(gs_run *run, const gs_measure_seams *pe, const char *suffix)
{
    char k[96];
    snprintf(k, sizeof k, "example_patch_seam_dist_ratio%s", suffix);
    gs_run_metric_f64(run, k, pe->inside_dist > 0 ? pe->seam_dist / pe->inside_dist : 0);
    snprintf(k, sizeof k, "example_patch_seam_angle_ratio%s", suffix);
    gs_run_metric_f64(run, k, pe->inside_angle > 0 ? pe->seam_angle / pe->inside_angle : 0);
    snprintf(k, sizeof k, "example_patch_seam_open%s", suffix);
    gs_run_metric_f64(run, k, pe->seam_open);
    snprintf(k, sizeof k, "example_patch_seam_broken%s", suffix);
    gs_run_metric_f64(run, k, pe->seam_broken);
}

static void record_metrics(gs_run *run, const points_config *c, run_state *rs, double dens_out)
{
    gs_points_synth_t s = rs->synth;
    size_t nm;
    const gs_points_patch_metrics *m = gs_points_synth_metrics(s, &nm);
    double sd = 0, sdmax = 0, cd = 0, res = 0, resmax = 0, gap = 0, cand = 0, pairs = 0;
    size_t searched = 0, warped = 0, nwarp[3] = {0, 0, 0}, verbatim = 0;
    double expect_verbatim = 0;
    for (size_t k = 0; k < nm; k++) {
        cand += m[k].candidates;
        if (k == 0)
            continue; /* the seed patch: picked at random, no search */
        searched++;
        sd += m[k].best_dist;
        sdmax = fmax(sdmax, m[k].best_dist);
        cd += m[k].chosen_dist;
        /* The residual over every blended patch, warped or not (a mean over
         * the warped ones alone compared different patches with and without
         * the warp). */
        res += m[k].warp_residual;
        resmax = fmax(resmax, m[k].warp_residual);
        nwarp[m[k].warp < 3 ? m[k].warp : 0]++;
        verbatim += gs_points_synth_is_continuation(s, m, k, m[k].chosen);
        if (m[k].candidates > 0)
            expect_verbatim += (double)m[k].continuations / m[k].candidates;
        if (m[k].warp > 0) {
            warped++;
            gap += m[k].pair_gap;
            pairs += m[k].pairs;
        }
    }
    gs_points_times tm = gs_points_synth_times(s);
    double din = gs_points_synth_input_density(s);
    gs_run_metric_str(run, "input_kind", c->kind);
    gs_run_metric_i64(run, "input_points", (int64_t)rs->tex.pts.n);
    gs_run_metric_f64(run, "input_spacing", rs->tex.spacing);
    gs_run_metric_i64(run, "input_patches", (int64_t)gs_points_synth_input_patches(s));
    uint64_t sp[2];
    gs_points_synth_strip_specks(s, &sp[0], &sp[1]);
    gs_run_metric_i64(run, "strip_specks_dropped", (int64_t)sp[0]);
    gs_run_metric_i64(run, "strip_speck_points_dropped", (int64_t)sp[1]);
    gs_run_metric_i64(run, "patches", (int64_t)nm);
    gs_run_metric_i64(run, "patches_searched", (int64_t)searched);
    gs_run_metric_i64(run, "patches_warped", (int64_t)warped);
    gs_run_metric_i64(run, "patches_warp_pairs", (int64_t)nwarp[1]);
    gs_run_metric_i64(run, "patches_warp_normal", (int64_t)nwarp[2]);
    gs_run_metric_i64(run, "patches_warp_none", (int64_t)nwarp[0]);
    gs_run_metric_f64(run, "out_size_x", rs->params.out_size[0]);
    gs_run_metric_f64(run, "out_size_y", rs->params.out_size[1]);
    gs_run_metric_i64(run, "output_points", (int64_t)rs->out.n);
    gs_run_metric_f64(run, "density_in", din);
    gs_run_metric_f64(run, "density_out", dens_out);
    gs_run_metric_f64(run, "density_ratio", din > 0 ? dens_out / din : 0);
    gs_run_metric_f64(run, "search_distance_mean", searched ? sd / searched : 0);
    gs_run_metric_f64(run, "search_distance_max", sdmax);
    gs_run_metric_f64(run, "chosen_distance_mean", searched ? cd / searched : 0);
    gs_run_metric_f64(run, "candidates_mean", nm ? cand / nm : 0);
    /* Variety: distinct source patches, and the share of patches that
     * continue a neighbour's source verbatim, against what a uniform pick
     * in each Psi_k gives (the mean of continuations / candidates). */
    gs_run_metric_i64(run, "source_patches", (int64_t)distinct_sources(m, nm));
    gs_run_metric_f64(run, "verbatim_share", searched ? (double)verbatim / searched : 0);
    gs_run_metric_f64(run, "verbatim_share_random", searched ? expect_verbatim / searched : 0);
    gs_run_metric_f64(run, "pairs_mean", warped ? pairs / warped : 0);
    gs_run_metric_f64(run, "pair_gap_mean", warped ? gap / warped : 0);
    gs_run_metric_f64(run, "warp_residual_mean", searched ? res / searched : 0);
    gs_run_metric_f64(run, "warp_residual_max", resmax);
    const gs_points_seam_stats *se = &rs->seam;
    gs_run_metric_f64(run, "seam_dist", se->seam_dist);
    gs_run_metric_f64(run, "seam_normal", se->seam_normal);
    gs_run_metric_f64(run, "seam_unmatched", se->seam_unmatched);
    gs_run_metric_f64(run, "inside_dist", se->inside_dist);
    gs_run_metric_f64(run, "inside_normal", se->inside_normal);
    gs_run_metric_f64(run, "inside_unmatched", se->inside_unmatched);
    gs_run_metric_f64(run, "seam_open_segments", se->seam_open_segments);
    gs_run_metric_f64(run, "inside_open_p90", se->inside_open_p90);
    gs_run_metric_i64(run, "seam_segments", (int64_t)se->seam_segments);
    gs_run_metric_f64(run, "seam_dist_ratio", se->inside_dist > 0 ? se->seam_dist / se->inside_dist : 0);
    gs_run_metric_f64(run, "seam_normal_ratio",
                      se->inside_normal > 0 ? se->seam_normal / se->inside_normal : 0);
    gs_run_metric_f64(run, "seam_unmatched_excess", se->seam_unmatched - se->inside_unmatched);
    const gs_measure_seams *ps = &rs->pseam;
    gs_run_metric_i64(run, "patch_seam_points", (int64_t)ps->seam_points);
    gs_run_metric_f64(run, "patch_seam_dist", ps->seam_dist);
    gs_run_metric_f64(run, "patch_inside_dist", ps->inside_dist);
    gs_run_metric_f64(run, "patch_seam_dist_p90", ps->seam_dist_p90);
    gs_run_metric_f64(run, "patch_inside_dist_p90", ps->inside_dist_p90);
    gs_run_metric_f64(run, "patch_seam_angle", ps->seam_angle);
    gs_run_metric_f64(run, "patch_inside_angle", ps->inside_angle);
    gs_run_metric_f64(run, "patch_seam_open", ps->seam_open);
    gs_run_metric_f64(run, "patch_inside_open", ps->inside_open);
    gs_run_metric_f64(run, "patch_seam_dist_ratio",
                      ps->inside_dist > 0 ? ps->seam_dist / ps->inside_dist : 0);
    gs_run_metric_f64(run, "patch_seam_angle_ratio",
                      ps->inside_angle > 0 ? ps->seam_angle / ps->inside_angle : 0);
    /* Broken: open or farther from the other side's surface than 9 in 10
     * of the example's inside fits (patch_far_dist), seams and inside. */
    gs_run_metric_f64(run, "patch_far_dist", ps->far_dist);
    gs_run_metric_f64(run, "patch_seam_broken", ps->seam_broken);
    gs_run_metric_f64(run, "patch_inside_broken", ps->inside_broken);
    example_seam_metrics(run, &rs->pseam_ex, "");
    gs_run_metric_f64(run, "example_patch_inside_open", rs->pseam_ex.inside_open);
    gs_run_metric_f64(run, "example_patch_inside_broken", rs->pseam_ex.inside_broken);
    if (rs->c->example_seam_shifts != 1)
        example_seam_metrics(run, &rs->pseam_ex_all, "_shifted");
    gs_run_metric_f64(run, "example_line_dist", rs->seam_ex.seam_dist);
    gs_run_metric_f64(run, "example_line_normal", rs->seam_ex.seam_normal);
    gs_run_metric_f64(run, "example_line_unmatched", rs->seam_ex.seam_unmatched);
    const objects_stats *ob = &rs->obj;
    gs_run_metric_f64(run, "height_ks", ob->height_ks);
    gs_run_metric_f64(run, "example_height_ks_halves", ob->example_height_ks_halves);
    gs_run_metric_f64(run, "height_max", ob->height_max);
    gs_run_metric_f64(run, "example_height_max", ob->example_height_max);
    gs_run_metric_i64(run, "points_above_example_max", (int64_t)ob->above_example_max);
    gs_run_metric_i64(run, "fragments", ob->fragments);
    gs_run_metric_f64(run, "fragments_per_area", ob->density[0]);
    gs_run_metric_f64(run, "example_fragments_per_area", ob->example_density[0]);
    gs_run_metric_i64(run, "small_fragments", ob->small_fragments);
    gs_run_metric_i64(run, "small_fragment_points", (int64_t)ob->small_fragment_points);
    gs_run_metric_f64(run, "small_fragments_per_area", ob->density[1]);
    gs_run_metric_f64(run, "example_small_fragments_per_area", ob->example_density[1]);
    static const char *const part[2] = {"strip", "inside"};
    for (int k = 0; k < 2; k++) {
        char key[64];
        snprintf(key, sizeof key, "nn_points_%s", part[k]);
        gs_run_metric_i64(run, key, (int64_t)ob->nn_points[k]);
        snprintf(key, sizeof key, "nn_close_%s", part[k]);
        gs_run_metric_f64(run, key, ob->nn_close[k]);
        snprintf(key, sizeof key, "nn_far_%s", part[k]);
        gs_run_metric_f64(run, key, ob->nn_far[k]);
        snprintf(key, sizeof key, "nn_median_%s", part[k]);
        gs_run_metric_f64(run, key, ob->nn_median[k]);
        snprintf(key, sizeof key, "nn_ks_%s", part[k]);
        gs_run_metric_f64(run, key, ob->nn_ks[k]);
    }
    gs_run_metric_f64(run, "example_nn_close", ob->example_nn_close);
    gs_run_metric_f64(run, "example_nn_far", ob->example_nn_far);
    gs_run_metric_f64(run, "example_nn_median", ob->example_nn_median);
    gs_run_metric_f64(run, "example_nn_ks_halves", ob->example_nn_ks_halves);
    gs_run_metric_f64(run, "search_seconds", tm.search);
    gs_run_metric_f64(run, "warp_seconds", tm.warp);
    gs_run_metric_f64(run, "blend_seconds", tm.blend);
    gs_run_metric_f64(run, "other_seconds", tm.other);
    gs_run_metric_f64(run, "relax_seconds", tm.relax);
}

gs_err points_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest)
{
    run_state *rs = state;
    const points_config *c = rs->c;
    *digest = gs_points_digest(&rs->out);
    gs_err local = GS_OK;
    if (run->rank == 0) { /* patch ids as the PLY stores them: -1 for none */
        local = gs_alloc_array((void **)&rs->out_id, rs->out.n ? rs->out.n : 1,
                               sizeof *rs->out_id, "patch ids");
        for (size_t i = 0; local == GS_OK && i < rs->out.n; i++)
            rs->out_id[i] = rs->out_patch[i] == UINT32_MAX ? -1 : (int32_t)rs->out_patch[i];
    }
    size_t ntris = 0;
    if (run->rank == 0) {
        char path[PATH_MAX];
        gs_pointply_format fmt = strcmp(c->ply_format, "ascii") ? GS_POINTPLY_BINARY
                                                                : GS_POINTPLY_ASCII;
        if (c->write_points && local == GS_OK) {
            gs_run_path(run, "points.ply", path, sizeof path);
            local = gs_pointply_write_ids(path, (const double *)rs->out.v, rs->out.n, 1,
                                          "patch", rs->out_id, fmt);
            if (local == GS_OK)
                gs_run_output(run, "points", "points", "points.ply", NULL);
        }
        if (c->patch_csv && local == GS_OK) {
            size_t nm;
            const gs_points_patch_metrics *m = gs_points_synth_metrics(rs->synth, &nm);
            gs_run_path(run, "patches.csv", path, sizeof path);
            local = write_patch_csv(path, m, nm);
            if (local == GS_OK)
                gs_run_output(run, "csv", "patch_metrics", "patches.csv", NULL);
        }
        /* The measures and the mesh work on the z-up points; write_mesh
         * restores the axes. */
        gs_points zup = {0};
        if (local == GS_OK)
            local = gs_points_append(&zup, rs->out.v, rs->out.n);
        if (local == GS_OK) {
            gs_points_permute_to_z(&zup, kind_is_user(c) ? up_axis(c) : 2);
            local = seam_measures(rs, &zup);
            if (local == GS_OK)
                local = object_measures(rs, &zup);
        }
        if (c->mesh && local == GS_OK) {
            gs_run_path(run, "mesh.ply", path, sizeof path);
            local = write_mesh(c, &zup, rs->tex.spacing, rs->params.mls_radius, path, &ntris);
            if (local == GS_OK)
                gs_run_output(run, "mesh", "surface", "mesh.ply", NULL);
            if (local == GS_OK && ntris)
                gs_run_output(run, "mesh", "surface", "mesh.glb", NULL);
        }
        if (c->preview && local == GS_OK) {
            int written = 0;
            gs_run_path(run, "preview.png", path, sizeof path);
            local = write_preview(c, &rs->tex, &zup, rs->params.mls_radius, path, &written);
            if (local == GS_OK && written)
                gs_run_output(run, "preview", "preview", "preview.png", NULL);
        }
        gs_points_free(&zup);
        if (local == GS_OK)
            record_metrics(run, c, rs, rs->dens_out);
    }
    GS_CALL(points_agree(&rs->together, run->comm, local));
    gs_json_u64(phase, "mesh_triangles", ntris);
    gs_log(GS_LOG_INFO, "output: %zu points, density %.4g per unit area (example %.4g, ratio "
           "%.3f)", rs->out.n, rs->dens_out, gs_points_synth_input_density(rs->synth),
           rs->dens_out / gs_points_synth_input_density(rs->synth));
    return GS_OK;
}
