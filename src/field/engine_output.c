/* field driver, output: the result redistanced, field.h5 (+ field.xmf),
 * field.vdb, the contoured and copied meshes, the quality measures (matched
 * with the distributed matcher) and the pictures, into summary.json. */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/field_examples.h"
#include "geosynth/file.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/partition.h"
#include "geosynth/preview.h"
#include "geosynth/vdb.h"
#include "field/engine_impl.h"

/* One output step's wall and CPU seconds (this rank, its threads included)
 * into the phase record as NAME_seconds and NAME_cpu_seconds, and this
 * rank's tracked peak memory and peak resident size so far as
 * NAME_mem_peak_bytes and NAME_rss_peak_bytes (where a peak is reached: the
 * first step whose figure equals the run's). */
typedef struct step_clock {
    double t, c;
} step_clock;

static step_clock step_start(void)
{
    return (step_clock){gs_time_now(), gs_cpu_now()};
}

static void step_end(gs_json *pm, const char *name, step_clock s)
{
    char k[96];
    snprintf(k, sizeof k, "%s_seconds", name);
    gs_json_f64(pm, k, gs_time_now() - s.t);
    snprintf(k, sizeof k, "%s_cpu_seconds", name);
    gs_json_f64(pm, k, gs_cpu_now() - s.c);
    snprintf(k, sizeof k, "%s_mem_peak_bytes", name);
    gs_json_u64(pm, k, (uint64_t)gs_mem_peak());
    snprintf(k, sizeof k, "%s_rss_peak_bytes", name);
    gs_json_u64(pm, k, (uint64_t)gs_mem_rss_peak());
}

static gs_err write_field_h5(gs_run *run, const gs_qfield *res, const gs_field *f,
                             const gs_qfield *src, const gs_qfield *synthesized)
{
    char path[PATH_MAX];
    gs_run_path(run, "field.h5", path, sizeof path);
    gs_ckpt_meta meta = {"field", run->seed, run->config_text};
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_create(run->comm, path, &meta, &h));
    int64_t n[3] = {res->nx, res->ny, res->nz};
    gs_err err = GS_OK;
    GS_TRY(err, field_write_slabs(h, run, "/field/distance", n, GS_H5_F32, f->v), fail);
    GS_TRY(err, field_write_slabs(h, run, "/field/levels", n, GS_H5_U8, res->q), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/distance", "spacing", f->spacing), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/distance", "origin_x", 0), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/distance", "origin_y", 0), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/distance", "origin_z", 0), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/levels", "lo", res->lo), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/field/levels", "hi", res->hi), fail);
    static const char order[] = "data[z][y][x]; x fastest, z up; sample (x, y, z) at spacing * (x, y, z)";
    GS_TRY(err, gs_ckpt_set_str(h, "/field/distance", "index_order", order), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/field/distance", "units",
                                "signed distance in the example's units (spacing per sample), "
                                "negative inside"),
           fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/field/levels", "index_order", order), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/field/levels", "units",
                                "quantized distance: level q is lo + q * (hi - lo) / 255"),
           fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/field", "up_axis", "z"), fail);
    /* the quantized (cropped) example, so that any measure of the output
     * against its example can be taken from this file alone */
    int64_t sn[3] = {src->nx, src->ny, src->nz};
    GS_TRY(err, field_write_slabs(h, run, "/source/levels", sn, GS_H5_U8, src->q), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/source/levels", "lo", src->lo), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/source/levels", "hi", src->hi), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/source/levels", "index_order", order), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/source/levels", "units",
                                "quantized distance of the cropped example: lo + q * (hi - lo) / 255"),
           fail);
    if (synthesized) {
        /* field.complete_objects or field.height_match: the synthesized
         * field before the rebuild or the height match, so the synthesis'
         * own copying and seams can be measured from this file too
         * (analysis/field_seams.py --dataset /synthesis/levels) */
        GS_TRY(err, field_write_slabs(h, run, "/synthesis/levels", n, GS_H5_U8, synthesized->q), fail);
        GS_TRY(err, gs_ckpt_set_f64(h, "/synthesis/levels", "lo", synthesized->lo), fail);
        GS_TRY(err, gs_ckpt_set_f64(h, "/synthesis/levels", "hi", synthesized->hi), fail);
        GS_TRY(err, gs_ckpt_set_str(h, "/synthesis/levels", "index_order", order), fail);
        GS_TRY(err, gs_ckpt_set_str(h, "/synthesis/levels", "units",
                                    "quantized distance of the synthesized field before "
                                    "field.height_match or field.complete_objects changed it: "
                                    "lo + q * (hi - lo) / 255"),
               fail);
    }
    GS_CALL(gs_ckpt_commit(&h));
    err = GS_OK;
    if (run->rank == 0) {
        gs_xdmf_grid g = {"field", GS_XDMF_NODE, {(uint64_t)n[2], (uint64_t)n[1], (uint64_t)n[0]},
                          {0, 0, 0}, {f->spacing, f->spacing, f->spacing}, 1};
        gs_xdmf_attr at[2] = {{"distance", "/field/distance", GS_H5_F32, 1},
                              {"levels", "/field/levels", GS_H5_U8, 1}};
        err = gs_xdmf_write(path, &g, at, 2);
        gs_run_output(run, "h5", "field", "field.h5", n);
        gs_run_output(run, "xdmf", "field", "field.xmf", n);
    }
    GS_CALL(gs_par_agree(run->comm, err));
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

/* The synthesized field f redistanced into a distance field (the distance
 * to its zero surface, as OpenVDB volumeToMesh meshes it, within
 * field.range samples, signed as f, on the field padded with its edge
 * values so the surface stays open at the box faces, then bounded so no neighbour step exceeds a
 * sample; gs_vdb_redistance), in place on every rank. Each rank rebuilds the
 * z-planes it writes into field.h5 (field_write_slabs' partition), in pieces
 * of at most FIELD_REDIST_SAMPLES samples, so memory is bounded by a piece
 * and the ranks share the work; any split gives the same values. The pieces
 * meet once, gathered in place (every rank holds the field for the file and
 * the meshes). field.vdb (grid `surface`, class level set, background = band
 * width, voxel size = sample spacing; output.vdb = yes) is written with the
 * meshes (write_geometry). */
#define FIELD_REDIST_SAMPLES ((int64_t)16 << 20)
static int field_redistance_pad(const field_config *c)
{
    return (int)ceil(c->range) + 1;
}
static gs_err redistance(gs_run *run, const field_config *c, gs_field *f, gs_json *pm)
{
    step_clock ts = step_start();
    const int pad = field_redistance_pad(c);
    const int64_t plane = f->nx * f->ny;
    int64_t z0, z1;
    GS_CALL(gs_partition(f->nz, run->size, run->rank, &z0, &z1));
    gs_vdb_dense d = {(size_t)f->nx, (size_t)f->ny, (size_t)f->nz,
                      {f->origin[0], f->origin[1], f->origin[2]}, f->spacing,
                      (float)(c->range * f->spacing), f->v};
    float *mine = NULL;
    gs_err err = GS_OK;
    if (z1 > z0)
        err = gs_alloc_array((void **)&mine, (size_t)((z1 - z0) * plane), sizeof *mine,
                             "redistanced planes");
    int64_t step = FIELD_REDIST_SAMPLES / plane;
    step = step < 1 ? 1 : step;
    for (int64_t z = z0; !err && z < z1; z += step) {
        int64_t e = z + step < z1 ? z + step : z1;
        err = gs_vdb_redistance(&d, pad, c->range, (size_t)z, (size_t)e, mine + (z - z0) * plane);
    }
    if (run->rank == 0)
        step_end(pm, "redistance_planes", ts);
    ts = step_start();
    GS_TRY(err, gs_par_agree(run->comm, err), done);
    if (run->rank == 0)
        step_end(pm, "redistance_wait", ts);
    ts = step_start();
    /* every rank has read the synthesized values it needs: its planes replace them */
    if (z1 > z0)
        memcpy(f->v + z0 * plane, mine, (size_t)((z1 - z0) * plane) * sizeof *mine);
    gs_free(mine);
    mine = NULL;
    if (run->size > 1) {
        int *counts = NULL, *displs = NULL;
        GS_TRY(err, gs_alloc_array((void **)&counts, 2 * (size_t)run->size, sizeof *counts,
                                   "gather counts"), done);
        displs = counts + run->size;
        for (int r = 0; r < run->size; r++) {
            int64_t a, b;
            gs_partition(f->nz, run->size, r, &a, &b);
            counts[r] = (int)(b - a), displs[r] = (int)a;
        }
        err = gs_par_allgatherv_items(run->comm, f->v, (size_t)plane * sizeof *f->v, counts, displs);
        gs_free(counts);
        GS_TRY(err, gs_par_agree(run->comm, err), done);
    }
    if (run->rank == 0)
        step_end(pm, "redistance_gather", ts);
    /* field.vdb: written by write_geometry's contour rank, listed here (the
     * outputs' order is the digest's) */
    if (run->rank == 0 && c->vdb)
        gs_run_output(run, "vdb", "field", "field.vdb", (int64_t[3]){f->nx, f->ny, f->nz});
done:
    gs_free(mine);
    return err;
}

/* Writes m (target sample units) in the world units of f, and the same as
 * glTF binary next to it (NAME.glb, with smooth normals). last: m is not
 * used after (its positions are turned into world units in place, no copy
 * of them; m->pos is then left in world units). */
static gs_err write_world_mesh(const char *path, gs_mesh *m, const gs_field *f, const char *about,
                               int last)
{
    float *world = NULL, *unit = m->pos;
    if (last)
        world = m->pos;
    else
        GS_CALL(gs_alloc_array((void **)&world, 3 * m->nverts + 3, sizeof *world, "world mesh"));
    for (size_t v = 0; v < m->nverts; v++)
        for (int a = 0; a < 3; a++)
            world[3 * v + a] = (float)(f->origin[a] + unit[3 * v + a] * f->spacing);
    m->pos = world;
    const gs_mesh_meta meta = {"geosynth field", "the example's units (field.h5 /field/distance spacing)", about};
    gs_err err = gs_mesh_write_meta(path, m, NULL, NULL, &meta);
    if (err == GS_OK && m->ntris) {
        char glb[PATH_MAX];
        gs_path_with_ext(path, "glb", glb, sizeof glb);
        gs_mesh g = *m;
        g.normals = NULL;
        err = gs_mesh_compute_normals(&g);
        if (err == GS_OK)
            err = gs_mesh_write_glb(glb, &g, NULL, &meta);
        gs_free(g.normals);
    }
    if (!last) {
        m->pos = unit;
        gs_free(world);
    }
    return err;
}

/* output.geometry makes the copied mesh (rank 0's, from the provenance) */
static int field_geometry_copies(const field_config *c)
{
    return !strcmp(c->geometry, "copy") || !strcmp(c->geometry, "both");
}

#define GEOM_STEPS 3
/* What write_geometry's contour rank wrote, for rank 0 to list (the
 * outputs in the order of the digest) and report. */
typedef struct field_geometry_done {
    int contour, contour_glb;    /* the contour rank's */
    int preview, copied, copied_glb; /* rank 0's */
    int64_t contour_triangles;
    double contour_area;
    double secs[GEOM_STEPS][4]; /* the contour rank's steps: wall, CPU seconds (-1: not run),
                                   its tracked and resident peaks after the step (bytes) */
} field_geometry_done;

/* the contour rank's steps, as the phase record names them */
enum { GEOM_VDB, GEOM_CONTOUR, GEOM_CONTOUR_WRITE };
static const char *const geom_step_names[GEOM_STEPS] = {"vdb_write", "contour", "contour_write"};

static void geom_step_end(field_geometry_done *done, int k, step_clock s)
{
    done->secs[k][0] = gs_time_now() - s.t;
    done->secs[k][1] = gs_cpu_now() - s.c;
    done->secs[k][2] = (double)gs_mem_peak();
    done->secs[k][3] = (double)gs_mem_rss_peak();
}

/* The meshes, field.vdb and preview.png, shared by two ranks at np > 1:
 * the copy (the longest) and preview.png (the example's mesh is there) on
 * rank 0, field.vdb and contour.ply on the contour rank crank (the last;
 * each rank contours the field itself: the same mesh). At np = 1 rank 0
 * does both parts. Rank 0's figures go into the phase record pm and the
 * metrics; the contour rank's into *done, which rank 0 lists after the
 * ranks met (field_geometry_list). */
static gs_err write_geometry(gs_run *run, const field_config *c, const field_source *src,
                             const gs_field *f, gs_field_prov *prov, gs_json *pm, int crank,
                             field_geometry_done *done)
{
    char path[PATH_MAX], name[64];
    int contour = !strcmp(c->geometry, "contour") || !strcmp(c->geometry, "both");
    int copy = field_geometry_copies(c);
    const int mine_contour = run->rank == crank, mine_copy = run->rank == 0 && copy;
    memset(done, 0, sizeof *done);
    for (int k = 0; k < GEOM_STEPS; k++)
        done->secs[k][0] = done->secs[k][1] = -1;
    gs_err err = GS_OK;
    if (mine_contour && c->vdb) {
        step_clock tv = step_start();
        gs_vdb_dense d = {(size_t)f->nx, (size_t)f->ny, (size_t)f->nz,
                          {f->origin[0], f->origin[1], f->origin[2]}, f->spacing,
                          (float)(c->range * f->spacing), f->v};
        gs_run_path(run, "field.vdb", path, sizeof path);
        GS_CALL(gs_vdb_level_set_write(&d, field_redistance_pad(c), c->range, "surface", path));
        geom_step_end(done, GEOM_VDB, tv);
    }
    /* preview.png on rank 0, which holds the example's mesh */
    const int mine_preview = run->rank == 0 && c->preview;
    const int contour_side = mine_contour && contour;
    if (!contour_side && !mine_copy && !mine_preview)
        return GS_OK;
    /* the contour in sample units: contour.ply, the copy's connectivity and
     * the preview (also with output.geometry = none: a picture of every run) */
    gs_field unit = *f;
    unit.spacing = 1, unit.origin[0] = unit.origin[1] = unit.origin[2] = 0;
    gs_mesh base;
    step_clock ts = step_start();
    GS_CALL(gs_field_contour(&unit, 0.0, copy ? 0.0 : c->adaptivity, &base));
    if (contour_side)
        geom_step_end(done, GEOM_CONTOUR, ts);
    else /* rank 0's own contour, for the copy and the preview */
        step_end(pm, "contour_rank0", ts);
    gs_mesh m;
    memset(&m, 0, sizeof m);
    if (mine_preview) {
        /* The example next to the output's contour (also for output.geometry
         * = copy: the copy lies on it), each fitted to its own box. */
        /* the output's contour turned y-up in place, not copied (12 bytes
         * a vertex; ~280 MB at 512^3) */
        gs_preview_panel panels[2] = {{&src->mesh, NULL, NULL}, {&base, NULL, &base}};
        gs_run_path(run, "preview.png", path, sizeof path);
        ts = step_start();
        GS_TRY(err, gs_preview_write_optional(path, panels, 2, 512, &done->preview), out);
        step_end(pm, "preview", ts);
    }
    if (contour_side && contour) {
        if (copy && c->adaptivity > 0)
            GS_TRY(err, gs_field_contour(&unit, 0.0, c->adaptivity, &m), out);
        gs_mesh *cm = copy && c->adaptivity > 0 ? &m : &base;
        snprintf(name, sizeof name, "contour.%s", c->mesh_format);
        gs_run_path(run, name, path, sizeof path);
        /* (the area in sample units: before a last write turns them into world units) */
        done->contour_area = gs_mesh_area(cm) * f->spacing * f->spacing;
        ts = step_start();
        GS_TRY(err, write_world_mesh(path, cm, f, "the zero level set of the synthesized field (contoured by OpenVDB)", cm != &base || !mine_copy), out);
        geom_step_end(done, GEOM_CONTOUR_WRITE, ts);
        done->contour = 1;
        done->contour_triangles = (int64_t)cm->ntris;
        done->contour_glb = cm->ntris > 0;
        gs_mesh_destroy(&m);
    }
    if (mine_copy) {
        const gs_qfield *q = src->q;
        int64_t sn[3] = {q->nx, q->ny, q->nz};
        gs_field_copy_stats st;
        ts = step_start();
        /* base and prov are not used after: the copy takes base's
         * triangles, frees prov once read and base's positions before the
         * copy is written (peak memory) */
        GS_TRY(err, gs_field_copy_geometry_consume(&src->mesh, sn, prov, &unit, &base, c->snap,
                                                   (int)c->relax, &m, &st), out);
        step_end(pm, "copy", ts);
        snprintf(name, sizeof name, "copied.%s", c->mesh_format);
        gs_run_path(run, name, path, sizeof path);
        ts = step_start();
        GS_TRY(err, write_world_mesh(path, &m, f, "the example's surface copied along the synthesis (copied geometry)", 1), out);
        step_end(pm, "copy_write", ts);
        gs_json_i64(pm, "copied_triangles", (int64_t)m.ntris);
        gs_run_metric_i64(run, "copied_triangles", (int64_t)m.ntris);
        gs_run_metric_i64(run, "copied_seam_vertices", st.seam_vertices);
        gs_json_i64(pm, "copied_seam_vertices", st.seam_vertices);
        double share = m.nverts ? (double)st.copied_vertices / (double)m.nverts : 0;
        gs_run_metric_f64(run, "copied_vertex_share", share);
        gs_json_f64(pm, "copied_vertex_share", share);
        gs_run_metric_f64(run, "copied_mean_shift", st.mean_shift);
        gs_run_metric_i64(run, "copied_pulled_back", st.pulled_back);
        gs_json_i64(pm, "copied_pulled_back", st.pulled_back);
        gs_json_f64(pm, "copied_mean_shift", st.mean_shift);
        done->copied = 1;
        done->copied_glb = m.ntris > 0;
    }
out:
    gs_mesh_destroy(&m);
    gs_mesh_destroy(&base);
    return err;
}

/* Rank 0, after the ranks met: the contour rank's figures (done) and every
 * mesh and picture in summary.json's outputs, in the order of the digest. */
static void field_geometry_list(gs_run *run, const field_config *c, const field_geometry_done *done,
                                gs_json *pm)
{
    char name[64];
    for (int k = 0; k < GEOM_STEPS; k++)
        if (done->secs[k][0] >= 0) {
            char key[96];
            snprintf(key, sizeof key, "%s_seconds", geom_step_names[k]);
            gs_json_f64(pm, key, done->secs[k][0]);
            snprintf(key, sizeof key, "%s_cpu_seconds", geom_step_names[k]);
            gs_json_f64(pm, key, done->secs[k][1]);
            snprintf(key, sizeof key, "%s_mem_peak_bytes", geom_step_names[k]);
            gs_json_u64(pm, key, (uint64_t)done->secs[k][2]);
            snprintf(key, sizeof key, "%s_rss_peak_bytes", geom_step_names[k]);
            gs_json_u64(pm, key, (uint64_t)done->secs[k][3]);
        }
    if (done->preview)
        gs_run_output(run, "preview", "preview", "preview.png", NULL);
    if (done->contour) {
        gs_json_f64(pm, "contour_area", done->contour_area);
        gs_json_i64(pm, "contour_triangles", done->contour_triangles);
        gs_run_metric_i64(run, "contour_triangles", done->contour_triangles);
        snprintf(name, sizeof name, "contour.%s", c->mesh_format);
        gs_run_output(run, "mesh", "contour", name, NULL);
        if (done->contour_glb)
            gs_run_output(run, "mesh", "contour", "contour.glb", NULL);
    }
    if (done->copied) {
        snprintf(name, sizeof name, "copied.%s", c->mesh_format);
        gs_run_output(run, "mesh", "copied", name, NULL);
        if (done->copied_glb)
            gs_run_output(run, "mesh", "copied", "copied.glb", NULL);
    }
}

/* The synthesis' own copying and seams (synthesis_*): measured on the
 * field before field.height_match moved its columns along z or
 * field.complete_objects rebuilt it from whole source objects (syn; both
 * written to field.h5's /synthesis/levels), else the output's figures, as
 * that is what the synthesis made. A verbatim copy whose heights were then
 * remapped no longer equals the source sample for sample, so the output's
 * copy_* read ~0 where the synthesis copied (field39): with a height match
 * the synthesis_copy_* are the honest figures of copying. */
static gs_err measure_synthesized(const gs_qfield *syn, const gs_qfield *src, int B,
                                  const gs_field_geometry_report *g, gs_measure_copy *cp_out,
                                  double *seam_out)
{
    *cp_out = g->copy;
    *seam_out = g->seam_ratio_out;
    if (syn) {
        const int64_t on[3] = {syn->nx, syn->ny, syn->nz}, sn[3] = {src->nx, src->ny, src->nz};
        GS_CALL(gs_measure_copy3(syn->q, on, src->q, sn, GS_FIELD_COPY_WINDOW, (int64_t)B * B * B,
                                 B, cp_out));
        double ph[GS_FIELD_SEAM_PERIOD_MAX];
        gs_field_seam_ratios(syn, g->seam_period, g->seam_axes, ph);
        *seam_out = ph[g->seam_period - 1];
    }
    return GS_OK;
}

/* Rank 0: the figures of measure_synthesized (rebuilt: the rebuild ran,
 * matched: the height match). */
static void report_synthesized(gs_run *run, int rebuilt, int matched, const gs_measure_copy *cpp,
                               double seam, const gs_field_geometry_report *g, gs_json *pm)
{
    const gs_measure_copy cp = *cpp;
    gs_run_metric_i64(run, "objects_rebuilt", rebuilt);
    gs_run_metric_i64(run, "heights_matched", matched);
    gs_run_metric_f64(run, "synthesis_copy_matched_share", cp.matched_share);
    gs_run_metric_f64(run, "synthesis_copy_large_share", cp.large_share);
    gs_run_metric_f64(run, "synthesis_copy_largest_region_of_source", cp.largest_region_of_source);
    gs_run_metric_i64(run, "synthesis_copy_regions", cp.regions);
    gs_run_metric_f64(run, "synthesis_copy_completeness", cp.completeness);
    gs_run_metric_f64(run, "synthesis_seam_ratio", seam);
    gs_json_i64(pm, "objects_rebuilt", rebuilt);
    gs_json_i64(pm, "heights_matched", matched);
    if (rebuilt || matched)
        gs_log(GS_LOG_INFO,
               "the synthesis before the %s: %.3f in regions of one offset "
               "larger than a block, largest region %.3f of the source, completeness %.3f, seam "
               "ratio %.3f (the output: %.3f, %.3f, %.3f, %.3f; source up to %.3f)",
               rebuilt && matched ? "height match and the whole-object rebuild"
               : matched ? "height match (the copy figures to judge copying by)"
                         : "whole-object rebuild",
               cp.large_share, cp.largest_region_of_source, cp.completeness, seam,
               g->copy.large_share, g->copy.largest_region_of_source, g->copy.completeness,
               g->seam_ratio_out, g->seam_ratio_src_max);
}

/* Large-scale repetition of a height-field run (#19: "the same mountain
 * twice", which the copy measure misses when each repeat was copied at
 * another offset or blended): gs_measure_repeats2 on the surface heights of
 * the output's levels and the example's (analysis/field_repeats.py: the
 * same from field.h5's /field/levels and /source/levels). */
static gs_err report_repeats(gs_run *run, const gs_qfield *out, const gs_qfield *src, gs_json *pm)
{
    gs_field *fo = NULL, *fs = NULL;
    double *ho = NULL, *hs = NULL, t0 = gs_cpu_now();
    gs_measure_repeats m;
    gs_err err = GS_OK;
    GS_TRY(err, gs_qfield_dequantize(out, &fo), done);
    GS_TRY(err, gs_qfield_dequantize(src, &fs), done);
    GS_TRY(err, gs_alloc_array((void **)&ho, (size_t)(out->nx * out->ny), sizeof *ho, "heights"), done);
    GS_TRY(err, gs_alloc_array((void **)&hs, (size_t)(src->nx * src->ny), sizeof *hs, "heights"), done);
    gs_field_surface_heights(fo, ho);
    gs_field_surface_heights(fs, hs);
    GS_TRY(err, gs_measure_repeats2(ho, out->nx, out->ny, hs, src->nx, src->ny, &m), done);
    gs_run_metric_i64(run, "repeat_window", m.window);
    gs_run_metric_f64(run, "repeat_relief", m.relief);
    gs_run_metric_f64(run, "repeat_ncc_out", m.ncc_out);
    gs_run_metric_f64(run, "repeat_ncc_src", m.ncc_src);
    gs_run_metric_f64(run, "repeat_ncc_out_area", m.ncc_out_area);
    gs_run_metric_f64(run, "repeat_ncc_out_area_max", m.ncc_out_area_max);
    gs_run_metric_i64(run, "repeat_crops", m.crops);
    gs_run_metric_i64(run, "repeat_recur_out", m.recur_out);
    gs_json_f64(pm, "repeat_measure_cpu_seconds", gs_cpu_now() - t0);
    gs_log(GS_LOG_INFO,
           "repetition (%dx%d windows, feature size): two places of the output alike to NCC "
           "%.3f (the example's most alike two %.3f), %.3f within example-sized crops (median of "
           "%d, highest %.3f); one example feature recurs %d times (%.2f s)", m.window, m.window,
           m.ncc_out, m.ncc_src, m.ncc_out_area, m.crops, m.ncc_out_area_max, m.recur_out,
           gs_cpu_now() - t0);
    /* the height distribution (#19: the example's highest ground half as
     * common in terrain.ini's outputs) */
    gs_measure_heights_t hd;
    GS_TRY(err, gs_measure_heights(ho, (size_t)(out->nx * out->ny), hs, (size_t)(src->nx * src->ny), &hd),
           done);
    static const char *const high[GS_MEASURE_HEIGHT_LEVELS - 1] = {"p90", "p95", "p99"};
    gs_run_metric_f64(run, "height_below_p10_out", hd.low_out);
    gs_run_metric_f64(run, "height_below_p10_src", hd.low_src);
    for (int k = 0; k < GS_MEASURE_HEIGHT_LEVELS - 1; k++) {
        char key[64];
        snprintf(key, sizeof key, "height_above_%s_out", high[k]);
        gs_run_metric_f64(run, key, hd.high_out[k]);
        snprintf(key, sizeof key, "height_above_%s_src", high[k]);
        gs_run_metric_f64(run, key, hd.high_src[k]);
    }
    gs_run_metric_f64(run, "height_ks", hd.ks);
    gs_log(GS_LOG_INFO,
           "heights: at or below the example's 10th percentile (%.2f samples) %.3f (example %.3f), "
           "at or above its 90th/95th/99th (%.2f/%.2f/%.2f) %.3f/%.3f/%.4f (example "
           "%.3f/%.3f/%.4f), KS %.3f", hd.level[0], hd.low_out, hd.low_src, hd.level[1], hd.level[2],
           hd.level[3], hd.high_out[0], hd.high_out[1], hd.high_out[2], hd.high_src[0],
           hd.high_src[1], hd.high_src[2], hd.ks);
done:
    gs_field_destroy(&fo);
    gs_field_destroy(&fs);
    gs_free(ho);
    gs_free(hs);
    return err;
}

/* Copying, whole objects and distance steps (gs_field_geometry_measure) as
 * run metrics and in the output phase record. */
static void report_geometry(gs_run *run, const gs_field_geometry_report *g, gs_json *pm)
{
    const gs_measure_copy *cp = &g->copy;
    gs_run_metric_f64(run, "copy_matched_share", cp->matched_share);
    gs_run_metric_f64(run, "copy_large_share", cp->large_share);
    gs_run_metric_f64(run, "copy_largest_region_of_source", cp->largest_region_of_source);
    gs_run_metric_i64(run, "copy_largest_region", cp->largest_region);
    gs_run_metric_i64(run, "copy_regions", cp->regions);
    gs_run_metric_f64(run, "copy_completeness", cp->completeness);
    /* the source's exact periods: copying is measured modulo them */
    gs_run_metric_i64(run, "copy_source_periods", cp->periods);
    gs_run_metric_f64(run, "copy_source_shortest_period", cp->shortest_period);
    gs_run_metric_i64(run, "components_out", g->components_out);
    gs_run_metric_i64(run, "components_src", g->components_src);
    gs_run_metric_f64(run, "components_per_msample_out", g->components_per_msample_out);
    gs_run_metric_f64(run, "components_per_msample_src", g->components_per_msample_src);
    gs_run_metric_f64(run, "component_median_out", g->component_median_out);
    gs_run_metric_f64(run, "component_median_src", g->component_median_src);
    gs_run_metric_f64(run, "component_size_ks", g->component_size_ks);
    gs_run_metric_f64(run, "fragment_share_out", g->fragment_share_out);
    gs_run_metric_f64(run, "fragment_share_src", g->fragment_share_src);
    for (int k = 0; k < 5; k++) { /* interior components by handles: 0..3, 4 or more */
        char name[32];
        snprintf(name, sizeof name, "genus%d_out", k);
        gs_run_metric_i64(run, name, g->genus_out[k]);
        snprintf(name, sizeof name, "genus%d_src", k);
        gs_run_metric_i64(run, name, g->genus_src[k]);
    }
    gs_run_metric_f64(run, "ring_share_out", g->ring_share_out);
    gs_run_metric_f64(run, "ring_share_src", g->ring_share_src);
    gs_run_metric_f64(run, "open_per_msample_out", g->open_per_msample_out);
    gs_run_metric_f64(run, "open_per_msample_src", g->open_per_msample_src);
    gs_run_metric_f64(run, "handles_per_kinside_out", g->handles_per_kinside_out);
    gs_run_metric_f64(run, "handles_per_kinside_src", g->handles_per_kinside_src);
    gs_run_metric_f64(run, "handles_all_per_kinside_out", g->handles_all_per_kinside_out);
    gs_run_metric_f64(run, "handles_all_per_kinside_src", g->handles_all_per_kinside_src);
    gs_run_metric_f64(run, "step_violations_out", g->step_violations_out);
    gs_run_metric_f64(run, "step_violations_src", g->step_violations_src);
    gs_run_metric_i64(run, "inscribed_out", g->inscribed_out);
    gs_run_metric_i64(run, "inscribed_src", g->inscribed_src);
    gs_run_metric_f64(run, "inscribed_p10_out", g->inscribed_p10_out);
    gs_run_metric_f64(run, "inscribed_p50_out", g->inscribed_p50_out);
    gs_run_metric_f64(run, "inscribed_p90_out", g->inscribed_p90_out);
    gs_run_metric_f64(run, "inscribed_p10_src", g->inscribed_p10_src);
    gs_run_metric_f64(run, "inscribed_p50_src", g->inscribed_p50_src);
    gs_run_metric_f64(run, "inscribed_p90_src", g->inscribed_p90_src);
    gs_run_metric_f64(run, "inscribed_ks", g->inscribed_ks);
    gs_run_metric_i64(run, "crossing_axis", g->crossing_axis);
    gs_run_metric_i64(run, "crossing_slab", g->crossing_slab);
    gs_run_metric_f64(run, "crossing_share_out", g->crossing_share_out);
    gs_run_metric_f64(run, "crossing_share_src", g->crossing_share_src);
    gs_run_metric_i64(run, "seam_period", g->seam_period);
    gs_run_metric_i64(run, "seam_axes", g->seam_axes);
    gs_run_metric_f64(run, "seam_ratio_out", g->seam_ratio_out);
    gs_run_metric_f64(run, "seam_ratio_src_max", g->seam_ratio_src_max);
    gs_run_metric_i64(run, "layout_height_field", g->layout_height_field);
    const gs_measure_objlayout_side *ls[2] = {&g->layout.out, &g->layout.src};
    for (int k = 0; k < 2; k++) {
        const char *tag = k ? "src" : "out";
        char key[64];
        snprintf(key, sizeof key, "layout_objects_%s", tag);
        gs_run_metric_i64(run, key, ls[k]->objects);
        snprintf(key, sizeof key, "layout_nn_p10_%s", tag);
        gs_run_metric_f64(run, key, ls[k]->nn_p10);
        snprintf(key, sizeof key, "layout_nn_p50_%s", tag);
        gs_run_metric_f64(run, key, ls[k]->nn_p50);
        snprintf(key, sizeof key, "layout_close_share_%s", tag);
        gs_run_metric_f64(run, key, ls[k]->close_share);
        snprintf(key, sizeof key, "layout_fused_share_%s", tag);
        gs_run_metric_f64(run, key, ls[k]->fused_share);
        snprintf(key, sizeof key, "layout_fragment_share_%s", tag);
        gs_run_metric_f64(run, key, ls[k]->fragment_share);
        snprintf(key, sizeof key, "layout_merged_share_%s", tag);
        gs_run_metric_f64(run, key, ls[k]->merged_share);
    }
    gs_run_metric_f64(run, "layout_nn_ks", g->layout.nn_ks);
    gs_run_metric_f64(run, "layout_guard", g->layout.guard);
    gs_run_metric_i64(run, "layout_guarded_objects_out", g->layout.out_guarded.objects);
    gs_run_metric_f64(run, "layout_guarded_close_share_out", g->layout.out_guarded.close_share);
    gs_run_metric_f64(run, "layout_guarded_fragment_share_out",
                      g->layout.out_guarded.fragment_share);
    gs_run_metric_f64(run, "layout_guarded_merged_share_out", g->layout.out_guarded.merged_share);
    gs_run_metric_f64(run, "layout_guarded_nn_ks", g->layout.nn_ks_guarded);
    gs_json_f64(pm, "geometry_measure_seconds", g->seconds);
    gs_log(GS_LOG_INFO,
           "copying: %.3f of the output in exact unique %d^3 source windows, %.3f in regions of "
           "one offset larger than a block, largest region %.3f of the source, completeness %.3f%s",
           cp->matched_share, cp->window, cp->large_share, cp->largest_region_of_source,
           cp->completeness, cp->periods ? " (modulo the source's periods)" : "");
    gs_log(GS_LOG_INFO,
           "objects: %lld inside components (%.1f per 10^6 samples; source %lld, %.1f), median "
           "size %.0f (source %.0f), size KS %.3f, fragments %.3f (source %.3f); steps > 1.5 "
           "samples %.4f (source %.4f) (%.2f s)",
           (long long)g->components_out, g->components_per_msample_out,
           (long long)g->components_src, g->components_per_msample_src, g->component_median_out,
           g->component_median_src, g->component_size_ks, g->fragment_share_out,
           g->fragment_share_src, g->step_violations_out, g->step_violations_src, g->seconds);
    gs_log(GS_LOG_INFO,
           "topology: interior components with 0/1/2/3/4+ handles %lld/%lld/%lld/%lld/%lld "
           "(source %lld/%lld/%lld/%lld/%lld), with a handle %.3f (source %.3f), without one "
           "%.1f per 10^6 samples (source %.1f); handles per 1000 inside samples %.2f (source "
           "%.2f), of every component %.2f (source %.2f)",
           (long long)g->genus_out[0], (long long)g->genus_out[1], (long long)g->genus_out[2],
           (long long)g->genus_out[3], (long long)g->genus_out[4], (long long)g->genus_src[0],
           (long long)g->genus_src[1], (long long)g->genus_src[2], (long long)g->genus_src[3],
           (long long)g->genus_src[4], g->ring_share_out, g->ring_share_src,
           g->open_per_msample_out, g->open_per_msample_src, g->handles_per_kinside_out,
           g->handles_per_kinside_src, g->handles_all_per_kinside_out,
           g->handles_all_per_kinside_src);
    gs_log(GS_LOG_INFO,
           "inscribed spheres: radius p10/p50/p90 %.2f/%.2f/%.2f samples (source "
           "%.2f/%.2f/%.2f), KS %.3f; through slabs of %lld along axis %d: %.3f of the inside "
           "(source %.3f)",
           g->inscribed_p10_out, g->inscribed_p50_out, g->inscribed_p90_out,
           g->inscribed_p10_src, g->inscribed_p50_src, g->inscribed_p90_src, g->inscribed_ks,
           (long long)g->crossing_slab, g->crossing_axis, g->crossing_share_out,
           g->crossing_share_src);
    gs_log(GS_LOG_INFO,
           "layout (%s): %lld objects (source %lld), nearest centre p10/p50 %.2f/%.2f samples "
           "(source %.2f/%.2f), KS %.3f; closer than any two of the source %.3f, larger than "
           "1.5x its largest %.3f, smaller than 3/4 of its smallest (fragments) %.3f (guarded %.3f), "
           "reaching half a sample past its largest radius (merged) %.3f (guarded %.3f)",
           g->layout_height_field ? "discs of the height map" : "cores",
           (long long)g->layout.out.objects, (long long)g->layout.src.objects,
           g->layout.out.nn_p10, g->layout.out.nn_p50, g->layout.src.nn_p10,
           g->layout.src.nn_p50, g->layout.nn_ks, g->layout.out.close_share,
           g->layout.out.fused_share, g->layout.out.fragment_share,
           g->layout.out_guarded.fragment_share, g->layout.out.merged_share,
           g->layout.out_guarded.merged_share);
}

/* The measures of one run, computed on one rank (field_output_op). */
typedef struct field_measures {
    gs_field_quality qm;
    double quality_s, quality_cpu; /* the quality measure's seconds, its tree included */
    gs_field_geometry_report gr;
    double geometry_measure_cpu; /* gs_field_geometry_measure and measure_synthesized */
    gs_measure_copy syn_copy; /* the synthesis' own copying (measure_synthesized) */
    double syn_seam;
    gs_field_quality syn_qm; /* verbatim blocks and coherence of the field before
                                field.height_match or field.complete_objects changed it */
} field_measures;

/* The result, redistanced (each rank its planes, gathered once), field.h5, the quality
 * measures with the distributed matcher, the meshes and pictures (rank 0). */
/* The source's volume fraction over every box of the output's size (the
 * source continued periodically, one box per offset within it): the range a
 * window of the source itself gives. quick.ini's period-16 lattice measures
 * 0.142-0.185 over 48x40x32 (2.5 periods along y), its whole 0.163, so an
 * output is judged against this range, not the whole's value alone. */
static gs_err report_source_windows(gs_run *run, const gs_qfield *q, const int64_t target[3])
{
    int64_t n[3] = {q->nx, q->ny, q->nz}, cells = q->nx * q->ny * q->nz;
    uint8_t *mask = NULL;
    GS_CALL(gs_alloc_array((void **)&mask, (size_t)cells, 1, "source inside"));
    for (int64_t i = 0; i < cells; i++)
        mask[i] = gs_qfield_value(q, q->q[i]) < 0;
    double lo = 0, hi = 0;
    gs_err err = gs_measure_window_share_range(mask, n, target, &lo, &hi);
    gs_free(mask);
    GS_CALL(err);
    gs_run_metric_f64(run, "volume_fraction_src_window_min", lo);
    gs_run_metric_f64(run, "volume_fraction_src_window_max", hi);
    return GS_OK;
}

gs_err field_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest_out)
{
    field_drive *d = state;
    const field_config *c = d->c;
    const gs_qfield *q = d->src.q;
    const gs_field_synth_state *st = gs_field_synth_get_state(d->synth);
    gs_err err = GS_OK;
    gs_qfield *synthesized = NULL, *unmatched = NULL;
    gs_field_prov packed;
    memset(&packed, 0, sizeof packed);
    /* the last result's height match (field.height_match final or both),
     * then whole objects (field.complete_objects): every rank alike. The
     * synthesis' own measures read the field before either changed it. */
    GS_TRY(err, gs_field_synth_height_match(d->synth, &unmatched), fail);
    GS_TRY(err, gs_field_synth_complete_objects(d->synth, &synthesized), fail);
    const int rebuilt = synthesized != NULL, matched = unmatched != NULL;
    if (unmatched) {
        gs_qfield_destroy(&synthesized);
        synthesized = unmatched;
        unmatched = NULL;
    }
    if (run->rank == 0 && d->sc.complete_objects) {
        gs_log(GS_LOG_INFO, "objects: %lld source objects pasted whole, %lld left out "
               "(field.complete_objects)", (long long)st->objects_completed,
               (long long)st->objects_removed);
        gs_run_metric_i64(run, "objects_completed", st->objects_completed);
        gs_run_metric_i64(run, "objects_removed", st->objects_removed);
    }
    /* the target handed over and the mask freed: not held beside the
     * meshes (2 bytes a sample; 268 MB at 512^3) */
    GS_TRY(err, gs_field_synth_take_result(d->synth, &d->res), fail);
    /* the provenance: only rank 0's copied mesh needs it from here on, and
     * packed (runs along x, lossless: gs_field_prov_pack), not 4 bytes a
     * sample (537 MB at 512^3) beside the field and the meshes; the
     * synthesis, done, no longer reads it */
    if (run->rank == 0 && field_geometry_copies(c)) {
        const int64_t tn[3] = {d->res->nx, d->res->ny, d->res->nz};
        GS_TRY(err, gs_field_prov_pack(d->ctx.prov, tn, &packed), fail);
        gs_json_i64(phase, "provenance_runs", packed.runs);
        gs_json_u64(phase, "provenance_packed_bytes", (uint64_t)gs_field_prov_bytes(&packed));
    }
    gs_free(d->ctx.prov);
    d->ctx.prov = NULL;
    d->res->spacing = q->spacing;
    GS_TRY(err, gs_qfield_dequantize(d->res, &d->resf), fail);
    uint64_t digest = gs_digest_bytes(d->res->q, (size_t)(d->res->nx * d->res->ny * d->res->nz));
    double step_synth = 0, step_redist = 0, t_redist = gs_time_now(), c_redist = gs_cpu_now();
    int64_t rn[3] = {d->resf->nx, d->resf->ny, d->resf->nz};
    if (run->rank == 0)
        step_synth = gs_field_step_violations(d->resf->v, rn, d->resf->spacing, 1.5);
    GS_TRY(err, redistance(run, c, d->resf, phase), fail);
    if (run->rank == 0)
        step_redist = gs_field_step_violations(d->resf->v, rn, d->resf->spacing, 1.5);
    t_redist = gs_time_now() - t_redist;
    c_redist = gs_cpu_now() - c_redist;
    GS_TRY(err, write_field_h5(run, d->res, d->resf, q, synthesized), fail);
    /* The measures (quality, geometry measures, the synthesis' own copying)
     * and the meshes. Quality: coherence needs the nearest source block of
     * every output block. With one rank or a sharded tree (each rank
     * searches its slab) every rank runs it with the distributed matcher of
     * the synthesis (field_match_block). Otherwise (np > 1, whole tree) the
     * last rank alone measures everything with its own exact matcher (the
     * serial answer the distributed one gives too) while rank 0 writes the
     * meshes, and sends the figures to rank 0: the measures then cost no
     * wall time beside the meshes, and no rank repeats another's work. Same
     * figures on every rank count. */
    field_measures mp;
    memset(&mp, 0, sizeof mp);
    const int alone = run->size > 1 && !d->ctx.sharded;
    const int mrank = alone ? run->size - 1 : 0;
    gs_err merr = GS_OK;
    if (!alone || run->rank == mrank) {
        double tq = gs_time_now(), cq = gs_cpu_now();
        merr = gs_field_tree_build_shard(q, (int)c->block, d->ctx.sharded ? run->size : 1,
                                         run->rank, &d->ctx.qtree);
        if (!merr && d->ctx.qtree)
            merr = gs_field_searcher_create(d->ctx.qtree, &d->ctx.qsearcher);
        /* verbatim blocks and coherence of the synthesis too, before the
         * height match changed it (synthesis_verbatim_share,
         * synthesis_coherence): a verbatim block whose columns the height
         * match moved along z is no longer in the source sample for sample,
         * so the output's verbatim_share reads ~0 whatever was copied. Not
         * after the whole-object rebuild alone: a second quality measure
         * doubled its cost there (balls.ini 128^3: measures 0.185 of the
         * synthesis' CPU), and the rebuild's copying is judged by
         * synthesis_copy_* (measure_synthesized) */
        if (!alone) {
            GS_TRY(err, gs_par_agree(run->comm, merr), fail);
            GS_TRY(err, gs_field_quality_measure_with(d->res, q, (int)c->block, field_quality_match,
                                                      &d->ctx, &mp.qm), fail);
            if (matched)
                GS_TRY(err, gs_field_quality_measure_with(synthesized, q, (int)c->block,
                                                          field_quality_match, &d->ctx, &mp.syn_qm),
                       fail);
        } else if (!merr) {
            merr = gs_field_quality_measure(d->res, q, d->ctx.qtree, &mp.qm);
            if (!merr && matched)
                merr = gs_field_quality_measure(synthesized, q, d->ctx.qtree, &mp.syn_qm);
        }
        mp.quality_s = gs_time_now() - tq, mp.quality_cpu = gs_cpu_now() - cq;
        /* done with the quality tree: not kept beside the meshes */
        gs_field_searcher_destroy(&d->ctx.qsearcher);
        gs_field_tree_destroy(&d->ctx.qtree);
    }
    /* the quantized result and the synthesized field before the rebuild:
     * only the measures' rank (and rank 0's repeat figures of a height map)
     * read them from here on, not held beside another rank's meshes */
    if (run->rank != mrank) {
        gs_qfield_destroy(&synthesized);
        if (!(run->rank == 0 && field_is_heightmap_example(c)))
            gs_qfield_destroy(&d->res);
    }
    /* the meshes: the copy on rank 0, the rest on the last rank (write_geometry) */
    gs_err lerr = GS_OK;
    const int crank = run->size - 1;
    field_geometry_done gd;
    memset(&gd, 0, sizeof gd);
    if (run->rank == 0 || run->rank == crank) {
        step_clock tg = step_start();
        lerr = write_geometry(run, c, &d->src, d->resf, &packed, phase, crank, &gd);
        if (!lerr && run->rank == 0 && field_is_heightmap_example(c)) {
            /* Figure 7c: the synthesized height map as the example was read */
            char hp[PATH_MAX];
            gs_run_path(run, "heightmap.png", hp, sizeof hp);
            lerr = gs_field_write_heightmap(d->resf, ((double)c->depth - c->height) / 2, c->height, hp);
        }
        if (run->rank == 0)
            step_end(phase, "geometry", tg);
    }
    if (run->rank == mrank && !merr && !lerr) {
        double cm = gs_cpu_now();
        merr = gs_field_geometry_measure(d->res, q, (int)c->block, &mp.gr);
        if (!merr)
            merr = measure_synthesized(synthesized, q, (int)c->block, &mp.gr, &mp.syn_copy,
                                       &mp.syn_seam);
        mp.geometry_measure_cpu = gs_cpu_now() - cm;
    }
    if (alone) {
        /* the figures to rank 0 (every rank agrees first: none is left waiting) */
        GS_TRY(err, gs_par_agree(run->comm, merr ? merr : lerr), fail);
        GS_TRY(err, GS_PAR_BCAST_VALUE(run->comm, &mp, mrank), fail);
    }
    if (run->size > 1) {
        /* the contour rank's outputs and figures to rank 0 (after every rank agreed) */
        field_geometry_done own = gd;
        GS_TRY(err, gs_par_agree(run->comm, merr ? merr : lerr), fail);
        GS_TRY(err, GS_PAR_BCAST_VALUE(run->comm, &gd, crank), fail);
        gd.preview = own.preview, gd.copied = own.copied, gd.copied_glb = own.copied_glb;
    }
    if (run->rank == 0 && !lerr) {
        field_geometry_list(run, c, &gd, phase);
        if (field_is_heightmap_example(c))
            gs_run_output(run, "image", "heightmap", "heightmap.png", NULL);
    }
    if (run->rank == 0 && !lerr)
        lerr = merr;
    if (run->rank == 0) {
        gs_json_f64(phase, "redistance_seconds", t_redist);
        gs_json_f64(phase, "redistance_cpu_seconds", c_redist);
        gs_run_metric_f64(run, "step_violations_synthesized", step_synth);
        gs_run_metric_f64(run, "step_violations_redistanced", step_redist);
        gs_log(GS_LOG_INFO, "redistanced into a level set (%.2f s): steps > 1.5 samples between "
                            "neighbours %.4f -> %.4f", t_redist, step_synth, step_redist);
        /* quality of the output against the source */
        for (int i = 0; i < d->sc.iterations; i++) {
            char k[64];
            double mean = st->stat_count[i] ? st->stat_sum[i] / (double)st->stat_count[i] : 0;
            snprintf(k, sizeof k, "match_mean_it%d", i);
            gs_run_metric_f64(run, k, mean);
            snprintf(k, sizeof k, "match_min_it%d", i);
            gs_run_metric_f64(run, k, st->stat_count[i] ? st->stat_min[i] : 0);
            snprintf(k, sizeof k, "match_max_it%d", i);
            gs_run_metric_f64(run, k, st->stat_max[i]);
            snprintf(k, sizeof k, "match_blocks_it%d", i);
            gs_run_metric_i64(run, k, st->stat_count[i]);
            /* search work: queue pops, and pushes (best-first, the upper
             * bound of eq. 3 cannot save pops, only the entries it keeps out
             * of the queue) */
            snprintf(k, sizeof k, "match_pops_it%d", i);
            gs_run_metric_i64(run, k, (int64_t)st->stat_pops[i]);
            snprintf(k, sizeof k, "match_pushes_it%d", i);
            gs_run_metric_i64(run, k, (int64_t)st->stat_pushes[i]);
        }
        int last = d->sc.iterations - 1;
        gs_run_metric_f64(run, "match_mean", st->stat_sum[last] / (double)(st->stat_count[last] ? st->stat_count[last] : 1));
        /* coarse guidance: share of the copied samples whose sign differs
         * from the upsampled coarse result they replace, over the share
         * expected between two unrelated samples of the source, 2 v (1 - v)
         * (v: its volume fraction): ~0 follows the coarse result, ~1 ignores it */
        {
            int64_t nq = q->nx * q->ny * q->nz, in = 0;
            for (int64_t i = 0; i < nq; i++)
                in += gs_qfield_value(q, q->q[i]) < 0;
            double v = (double)in / (double)nq, unrelated = 2 * v * (1 - v), worst = 0;
            for (int i = 1; i < d->sc.iterations; i++) {
                char k[64];
                double dep = st->stat_coarse_n[i] && unrelated > 0
                                 ? (double)st->stat_coarse_flips[i] / (double)st->stat_coarse_n[i] /
                                       unrelated
                                 : 0;
                snprintf(k, sizeof k, "coarse_departure_it%d", i);
                gs_run_metric_f64(run, k, dep);
                if (dep > worst)
                    worst = dep;
            }
            gs_run_metric_f64(run, "coarse_departure", worst);
        }
        gs_json_f64(phase, "geometry_measure_cpu_seconds", mp.geometry_measure_cpu);
        if (!lerr)
            report_geometry(run, &mp.gr, phase);
        if (!lerr)
            report_synthesized(run, rebuilt, matched, &mp.syn_copy, mp.syn_seam, &mp.gr, phase);
        if (!lerr && field_is_heightmap_example(c))
            lerr = report_repeats(run, d->res, q, phase);
        /* seconds: rank 0's mesh outputs, the quality measure (its tree included;
         * measured on the rank that ran it) */
        gs_json_f64(phase, "quality_seconds", mp.quality_s);
        gs_json_f64(phase, "quality_cpu_seconds", mp.quality_cpu);
        gs_json_i64(phase, "measures_rank", mrank);
        {
            /* the measures' CPU against the synthesis' (all ranks; of this
             * run's share of it when resumed): #19's scale target. Timings:
             * in the phase record, not among the figures (those are the
             * same at any rank count) */
            double syn_cpu = 0, mcpu = mp.quality_cpu + mp.geometry_measure_cpu;
            for (int i = 0; i < run->nphases; i++)
                if (!strcmp(run->phases[i].name, "synthesis"))
                    syn_cpu = run->phases[i].cpu_sum;
            gs_json_f64(phase, "measures_cpu_seconds", mcpu);
            gs_json_f64(phase, "measures_cpu_share", syn_cpu > 0 ? mcpu / syn_cpu : 0);
            gs_log(GS_LOG_INFO, "measures: CPU %.2f s (quality %.2f s, geometry %.2f s), %.3f of "
                   "the synthesis' %.2f s", mcpu, mp.quality_cpu, mp.geometry_measure_cpu,
                   syn_cpu > 0 ? mcpu / syn_cpu : 0, syn_cpu);
        }
        if (!lerr) {
            const gs_field_quality qm = mp.qm;
            gs_run_metric_f64(run, "volume_fraction_out", qm.volume_fraction_out);
            gs_run_metric_f64(run, "volume_fraction_src", qm.volume_fraction_src);
            lerr = report_source_windows(run, q, c->target);
            gs_run_metric_f64(run, "surface_per_volume_out", qm.surface_per_volume_out);
            gs_run_metric_f64(run, "surface_per_volume_src", qm.surface_per_volume_src);
            gs_run_metric_f64(run, "coherence", qm.coherence);
            gs_run_metric_i64(run, "coherence_blocks", qm.coherence_blocks);
            gs_run_metric_i64(run, "coherence_grid_blocks", qm.coherence_grid_blocks);
            gs_run_metric_f64(run, "coherence_stderr", qm.coherence_stderr);
            gs_run_metric_f64(run, "verbatim_share", qm.verbatim);
            gs_run_metric_i64(run, "verbatim_run", qm.longest_run);
            /* the synthesis' own (the output's when nothing changed it after) */
            /* the synthesis' own (the output's when nothing changed it
             * after; -1: not measured, the rebuild alone changed it) */
            const gs_field_quality *sq = matched ? &mp.syn_qm : rebuilt ? NULL : &mp.qm;
            gs_run_metric_f64(run, "synthesis_verbatim_share", sq ? sq->verbatim : -1.0);
            gs_run_metric_i64(run, "synthesis_verbatim_run", sq ? sq->longest_run : -1);
            gs_run_metric_f64(run, "synthesis_coherence", sq ? sq->coherence : -1.0);
            if (matched)
                gs_log(GS_LOG_INFO, "the synthesis before the height match: coherence %.2f, "
                       "verbatim blocks %.3f (longest copied run %lld)",
                       sq->coherence, sq->verbatim, (long long)sq->longest_run);
            gs_log(GS_LOG_INFO,
                   "quality: volume fraction %.4f (source %.4f), surface/volume %.4f (source "
                   "%.4f), coherence %.2f (+- %.2f over %lld of %lld blocks), verbatim blocks "
                   "%.3f (longest copied run %lld), "
                   "mean match %.2f (%.1f s, CPU %.1f s on this rank)",
                   qm.volume_fraction_out, qm.volume_fraction_src, qm.surface_per_volume_out,
                   qm.surface_per_volume_src, qm.coherence, qm.coherence_stderr,
                   (long long)qm.coherence_blocks, (long long)qm.coherence_grid_blocks,
                   qm.verbatim, (long long)qm.longest_run,
                   st->stat_sum[last] / (double)(st->stat_count[last] ? st->stat_count[last] : 1),
                   mp.quality_s, mp.quality_cpu);
        }
    }
    err = gs_par_agree(run->comm, lerr);
    *digest_out = digest;
fail:
    gs_field_prov_destroy(&packed);
    gs_qfield_destroy(&synthesized);
    return err;
}
