/* micro driver, output pass: per instance the displacement (paper 4.5),
 * the independent verifier, and the files of RUN_DIR/instance-XXXX/:
 *   mesh.ply (and/or mesh.obj)  displaced mesh, normals, PLY vertex property
 *                               "label" (uchar, see below), region colours
 *   mesh.glb                    the same as glTF binary (COLOR_0 = the colours)
 *   micro.h5                    /micro/triangle_label uint16 [n], triangle_value
 *                               float64 [n], vertex_value float64 [nv],
 *                               vertex_label uint8 [nv], target_count int64 [2K],
 *                               target_prob float64 [2K], achieved_count int64
 *                               [2K], bin_error int64 [2K] (achieved - target),
 *                               dist_pos / dist_neg float64 [K]; attributes with
 *                               the checks. Histogram index order: the signed
 *                               axis of micro.h (0 = most negative bin).
 * Vertex label = 128 + floor(vertex value) clamped to [0, 255]: >= 128 is the
 * positive region, < 128 the negative one, and the distance to 128 the bin
 * (the vertex value is the mean of the incident triangles' values).
 *   thumb.png                   (gallery candidates, job->thumbnail > 0) the
 *                               displaced mesh rendered off-screen
 *                               (geosynth/render.h), positive region warm,
 *                               negative region blue
 * The instance digest covers the triangle labels and values, the displaced
 * positions and the vertex labels. */
#include <limits.h>
#include <stdlib.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/file.h"
#include "geosynth/h5.h"
#include "geosynth/log.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/render.h"
#include "micro/engine_impl.h"

void micro_instance_dir(int64_t id, char *out, size_t len)
{
    snprintf(out, len, "instance-%04lld", (long long)id);
}

static gs_err write_h5(const micro_job *job, const micro_instance *in, const char *path,
                       const uint16_t *label, const double *value, const double *vvalue, const uint8_t *vlabel, const gs_micro_report *rep,
                       const micro_result *res, const int64_t *realized, const double *tdist)
{
    const micro_mesh_in *mi = &job->meshes[in->mesh];
    gs_ckpt_meta meta = {"micro", in->seed, job->run->config_text};
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_create(MPI_COMM_NULL, path, &meta, &h));
    uint64_t n = mi->m.ntris, nv = mi->m.nverts, K = in->hist.nbins;
    gs_h5_shape s_u16 = {GS_H5_U16, 1, {n}}, s_tf = {GS_H5_F64, 1, {n}}, s_vf = {GS_H5_F64, 1, {nv}},
                s_vl = {GS_H5_U8, 1, {nv}}, s_hi = {GS_H5_I64, 1, {2 * K}},
                s_hf = {GS_H5_F64, 1, {2 * K}}, s_d = {GS_H5_F64, 1, {K}};
    gs_h5_write_opts z = {4, 0};
    char hex[17];
    gs_digest_hex(res->digest, hex);
    gs_err err = GS_OK;
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/triangle_label", &s_u16, label, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/triangle_value", &s_tf, value, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/vertex_value", &s_vf, vvalue, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/vertex_label", &s_vl, vlabel, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/target_count", &s_hi, in->hist.count, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/target_prob", &s_hf, in->hist.prob, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/achieved_count", &s_hi, rep->achieved, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/bin_error", &s_hi, rep->error, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/realized_count", &s_hi, realized, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/triangle_distance", &s_tf, tdist, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/dist_pos", &s_d, in->dist.pos, &z), fail);
    GS_TRY(err, gs_ckpt_write_whole(h, "/micro/dist_neg", &s_d, in->dist.neg, &z), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/micro/triangle_label", "index_order",
                                "one per triangle of mesh.ply, in its face order"), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/micro/triangle_value", "units",
                                "distribution units (units_per_model per model unit); > 0 positive region"),
           fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/micro/triangle_distance", "units",
                                "distribution units (units_per_model per model unit); > 0 positive region"),
           fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/micro/vertex_value", "index_order",
                                "one per vertex of mesh.ply, in its vertex order"), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/micro", "up_axis", "as the input mesh (mesh_source)"), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, "/micro", "instance", in->id), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/micro", "mesh_source", mi->source), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/micro", "units_per_model", mi->upm), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/micro", "half_extent", mi->half_extent), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/micro", "max_edge_units", mi->max_edge_units), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/micro", "min_angle_deg", mi->min_angle_deg), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, "/micro", "violations", rep->violations), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, "/micro", "pairs_checked", rep->pairs_checked), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/micro", "max_excess", rep->max_excess), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/micro", "unassigned_share", rep->unassigned_share), fail);
    GS_TRY(err, gs_ckpt_set_i64(h, "/micro", "abs_bin_error", rep->abs_error_sum), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/micro", "realized_l1", res->realized_l1), fail);
    GS_TRY(err, gs_ckpt_set_u64(h, "/micro", "realized_beyond", res->realized_beyond), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/micro", "digest", hex), fail);
    GS_TRY(err, gs_ckpt_commit(&h), fail);
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

/* The region of a triangle: the side of its label (a filled one: of its value). */
static inline uint8_t micro_side(uint16_t label, double value, uint32_t K)
{
    return label < 2 * K ? label >= K : value > 0;
}

gs_err micro_realized(const micro_mesh_in *mi, const gs_micro_hist *h, const uint16_t *label,
                      const double *value, int64_t *realized, double *tri_dist, uint64_t *beyond, double *l1)
{
    uint32_t n = mi->m.ntris, K = h->nbins;
    uint8_t *side = NULL;
    double *dist = NULL;
    int64_t *pos = NULL, *neg = NULL;
    gs_measure_geo_t g = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&side, n, 1, "triangle regions"), done);
    GS_TRY(err, gs_alloc_array((void **)&dist, n, sizeof *dist, "interface distances"), done);
    GS_TRY(err, gs_alloc_array((void **)&pos, K, sizeof *pos, "realized histogram"), done);
    GS_TRY(err, gs_alloc_array((void **)&neg, K, sizeof *neg, "realized histogram"), done);
    for (uint32_t t = 0; t < n; t++)
        side[t] = micro_side(label[t], value[t], K);
    GS_TRY(err, gs_measure_geo_create(mi->m.pos, mi->m.nverts, mi->m.tris, n, mi->upm, &g), done);
    GS_TRY(err, gs_measure_interface_dist(g, side, dist, NULL, NULL), done);
    gs_measure_contact_hist(dist, side, n, K, pos, neg, beyond);
    double sum = 0;
    for (uint32_t k = 0; k < K; k++) {
        realized[gs_micro_bin_index(K, 0, k)] = pos[k];
        realized[gs_micro_bin_index(K, 1, k)] = neg[k];
    }
    for (uint32_t i = 0; i < 2 * K; i++)
        sum += (double)llabs(realized[i] - h->count[i]);
    *l1 = n ? sum / n : 0;
    if (tri_dist)
        for (uint32_t t = 0; t < n; t++)
            tri_dist[t] = side[t] ? dist[t] : -dist[t];
done:
    gs_measure_geo_destroy(&g);
    gs_free(side);
    gs_free(dist);
    gs_free(pos);
    gs_free(neg);
    return err;
}

/* Region colours of the vertices (mesh.ply, thumb.png, preview.png):
 * positive region (vertex value > 0) sand, negative blue, both darker
 * further from the interface (linear in |value| / K, to 55% at K), so the
 * distance bins show. */
static void vertex_colors(const double *vvalue, size_t nv, uint32_t K, uint8_t *rgb)
{
    static const uint8_t warm[3] = {232, 178, 112}, cool[3] = {104, 150, 214};
    for (size_t v = 0; v < nv; v++) {
        double x = vvalue[v], a = fabs(x) / (K ? K : 1);
        double shade = 1.0 - 0.45 * (a > 1 ? 1.0 : a);
        for (int c = 0; c < 3; c++)
            rgb[3 * v + c] = (uint8_t)((x > 0 ? warm : cool)[c] * shade + 0.5);
    }
}

/* The displaced mesh rendered off-screen in its region colours. */
static gs_err write_render(const gs_mesh *om, const uint8_t *rgb, int size, const char *path)
{
    gs_render_opts o;
    gs_render_defaults(&o, size, size);
    o.colors = rgb;
    GS_CALL(gs_render_mesh_png(om, &o, path));
    return GS_OK;
}

/* The displaced mesh as a gs_mesh with outward normals and vertex labels. */
static gs_err write_meshes(const micro_job *job, const micro_instance *in, const char *dir,
                           const float *pos, const uint8_t *vlabel, const double *vvalue)
{
    uint8_t *rgb = NULL;
    const micro_mesh_in *mi = &job->meshes[in->mesh];
    gs_mesh om;
    GS_CALL(gs_micro_mesh_to_mesh(&mi->m, &om));
    gs_err err = GS_OK;
    memcpy(om.pos, pos, (size_t)mi->m.nverts * 3 * sizeof *om.pos);
    GS_TRY(err, gs_mesh_compute_normals(&om), done);
    GS_TRY(err, gs_alloc_array((void **)&om.label, om.nverts, 1, "vertex labels"), done);
    memcpy(om.label, vlabel, om.nverts);
    GS_TRY(err, gs_alloc_array((void **)&rgb, om.nverts, 3, "vertex colours"), done);
    vertex_colors(vvalue, om.nverts, in->hist.nbins, rgb);
    const char *fmt = job->cfg->output_format;
    char path[PATH_MAX + 32];
    const gs_mesh_meta meta = {"geosynth micro", "the input mesh's units",
                               "the input surface displaced by the synthesized microstructure; "
                               "vertex colours: positive region sand, negative blue, darker with the distance bin"};
    if (strcmp(fmt, "obj") != 0) {
        snprintf(path, sizeof path, "%s/mesh.ply", dir);
        GS_TRY(err, gs_mesh_write_meta(path, &om, "label", rgb, &meta), done);
    }
    if (strcmp(fmt, "ply") != 0) {
        snprintf(path, sizeof path, "%s/mesh.obj", dir);
        GS_TRY(err, gs_mesh_write_meta(path, &om, NULL, NULL, &meta), done);
    }
    snprintf(path, sizeof path, "%s/mesh.glb", dir);
    GS_TRY(err, gs_mesh_write_glb(path, &om, rgb, &meta), done);
    if (job->thumbnail > 0) {
        snprintf(path, sizeof path, "%s/thumb.png", dir);
        GS_TRY(err, write_render(&om, rgb, job->thumbnail, path), done);
    } else if (job->cfg->preview > 0) {
        snprintf(path, sizeof path, "%s/preview.png", dir);
        GS_TRY(err, write_render(&om, rgb, (int)job->cfg->preview, path), done);
    }
done:
    gs_free(rgb);
    gs_mesh_destroy(&om);
    return err;
}

gs_err micro_output_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng, gs_region_out *out)
{
    (void)color, (void)pass, (void)rng;
    micro_job *job = ctx;
    micro_instance *in = &job->inst[id];
    micro_mesh_in *mi = &job->meshes[in->mesh];
    GS_CHECK(micro_instance_done(in), GS_ERR_INTERNAL, "instance %lld is not reconstructed",
             (long long)id);
    double t0 = gs_time_now();
    uint32_t nv = mi->m.nverts, n = mi->m.ntris;
    double *vvalue = NULL, *tdist = NULL, *cvalue = NULL;
    uint8_t *side = NULL, *vside = NULL;
    uint16_t *clabel = NULL;
    int64_t *realized = NULL;
    float *pos = NULL;
    uint8_t *vlabel = NULL;
    gs_micro_report rep;
    memset(&rep, 0, sizeof rep);
    micro_result res;
    memset(&res, 0, sizeof res);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&vvalue, nv, sizeof *vvalue, "vertex values"), done);
    GS_TRY(err, gs_alloc_array((void **)&pos, (size_t)nv * 3, sizeof *pos, "displaced vertices"), done);
    GS_TRY(err, gs_alloc_array((void **)&vlabel, nv, 1, "vertex labels"), done);
    GS_TRY(err, gs_alloc_array((void **)&tdist, n, sizeof *tdist, "interface distances"), done);
    GS_TRY(err, gs_alloc_array((void **)&realized, 2 * (size_t)in->hist.nbins, sizeof *realized,
                               "realized histogram"), done);
    /* The correction pass (correct.c): the regions move until their true
     * distances match the target; labels and values are then those
     * distances (so the displacement follows them). */
    const uint16_t *label = in->st.label;
    const double *value = in->st.value;
    uint32_t K = in->hist.nbins;
    res.recon_unassigned_share = 0;
    for (uint32_t t = 0; t < n; t++)
        res.recon_unassigned_share += in->st.label[t] >= 2 * K;
    res.recon_unassigned_share = n ? res.recon_unassigned_share / n : 0;
    if (job->cfg->correct) {
        GS_TRY(err, gs_alloc_array((void **)&side, n, 1, "triangle regions"), done);
        GS_TRY(err, gs_alloc_array((void **)&cvalue, n, sizeof *cvalue, "corrected values"), done);
        GS_TRY(err, gs_alloc_array((void **)&clabel, n, sizeof *clabel, "corrected labels"), done);
        for (uint32_t t = 0; t < n; t++)
            side[t] = micro_side(in->st.label[t], in->st.value[t], K);
        gs_micro_correct_stats cst;
        gs_micro_correct_opts co = job->copts;
        co.init_value = in->st.value;
        GS_TRY(err, gs_micro_correct(&mi->m, mi->upm, &in->hist, &co, side, cvalue, &cst), done);
        GS_TRY(err, gs_micro_lipschitz(&mi->dual, cvalue), done);
        for (uint32_t t = 0; t < n; t++) {
            double x = cvalue[t];
            if (side[t] ? x < 0 : x > 0)
                x = 0; /* the region stays the measured one */
            cvalue[t] = x == 0 ? 0.0 : x;
            double a = fabs(x);
            uint32_t k = !(a < (double)K) ? K - 1 : (uint32_t)a;
            clabel[t] = (uint16_t)gs_micro_bin_index(K, side[t] ? 0 : 1, k);
        }
        res.recon_realized_l1 = cst.l1_before;
        res.correct_rounds = cst.rounds;
        res.correct_flips = cst.flips;
        label = clabel;
        value = cvalue;
    }
    /* The mesh has its normals (setup), so displace does not modify it. */
    GS_TRY(err, gs_micro_displace(&mi->m, value, &job->disp, vvalue, pos), done);
    for (uint32_t v = 0; v < nv; v++) {
        double l = 128.0 + floor(vvalue[v]);
        vlabel[v] = (uint8_t)(l < 0 ? 0 : l > 255 ? 255 : l);
    }
    gs_rng vr;
    gs_rng_init(&vr, (uint64_t)job->cfg->run.seed,
                gs_rng_stream_id(MICRO_DOMAIN_VERIFY, (uint64_t)id, 0, 0));
    uint32_t samples = job->cfg->verify_samples == 0 || job->cfg->verify_samples >= n
                           ? n
                           : (uint32_t)job->cfg->verify_samples;
    GS_TRY(err, gs_micro_verify(&mi->m, mi->upm, &in->hist, value, label, samples, &vr,
                                &rep),
           done);
    gs_digest dg;
    GS_TRY_CHECK(err, gs_digest_init(&dg), GS_ERR_MEM, done, "digest state");
    gs_digest_update(&dg, label, (size_t)n * sizeof *label);
    gs_digest_update(&dg, value, (size_t)n * sizeof *value);
    gs_digest_update(&dg, pos, (size_t)nv * 3 * sizeof *pos);
    gs_digest_update(&dg, vlabel, nv);
    res.digest = gs_digest_final(&dg);
    /* The coasts as mesh.ply shows them (vertex labels >= 128 positive). */
    GS_TRY(err, gs_alloc_array((void **)&vside, nv, 1, "vertex regions"), done);
    for (uint32_t v = 0; v < nv; v++)
        vside[v] = vlabel[v] >= 128;
    gs_measure_outline_t ol;
    GS_TRY(err, gs_measure_outline(pos, nv, mi->m.tris, n, mi->upm, vside, MICRO_OUTLINE_RHO, &ol), done);
    res.outline_length = ol.length;
    res.outline_roughness = ol.roughness;
    res.nverts = nv;
    res.ntris = n;
    res.nbins = in->hist.nbins;
    res.pairs_checked = rep.pairs_checked;
    res.violations = rep.violations;
    res.unassigned = rep.unassigned;
    res.abs_error_sum = rep.abs_error_sum;
    for (uint32_t i = 0; i < 2 * rep.nbins; i++) {
        int64_t e = rep.error[i] < 0 ? -rep.error[i] : rep.error[i];
        res.max_bin_error = e > res.max_bin_error ? e : res.max_bin_error;
    }
    res.max_excess = rep.max_excess;
    res.unassigned_share = rep.unassigned_share;
    res.error_share = n ? (double)rep.abs_error_sum / (double)n : 0;
    GS_TRY(err, micro_realized(mi, &in->hist, label, value, realized, tdist,
                               &res.realized_beyond, &res.realized_l1), done);
    int64_t npos = 0;
    for (uint32_t k = 0; k < in->hist.nbins; k++)
        npos += realized[in->hist.nbins + k];
    res.realized_pos_share = n ? (double)npos / n : 0;
    if (!job->cfg->correct)
        res.recon_realized_l1 = res.realized_l1;
    if (in->hist.nbins <= MICRO_RESULT_BINS) {
        memcpy(res.target, in->hist.count, 2 * (size_t)in->hist.nbins * sizeof *res.target);
        memcpy(res.realized, realized, 2 * (size_t)in->hist.nbins * sizeof *res.realized);
    }

    char rel[64], dir[PATH_MAX], path[PATH_MAX + 32];
    micro_instance_dir(id, rel, sizeof rel);
    if (job->flat_output)
        snprintf(dir, sizeof dir, "%s", job->run->dir);
    else
        gs_run_path(job->run, rel, dir, sizeof dir);
    GS_TRY(err, gs_mkdir_p(dir), done);
    GS_TRY(err, write_meshes(job, in, dir, pos, vlabel, vvalue), done);
    snprintf(path, sizeof path, "%s/micro.h5", dir);
    GS_TRY(err, write_h5(job, in, path, label, value, vvalue, vlabel, &rep, &res, realized, tdist), done);
    res.seconds = gs_time_now() - t0;
    GS_TRY(err, gs_region_out_append(out, &res, sizeof res), done);
done:
    gs_micro_report_free(&rep);
    gs_free(vvalue);
    gs_free(tdist);
    gs_free(realized);
    gs_free(cvalue);
    gs_free(clabel);
    gs_free(side);
    gs_free(vside);
    gs_free(pos);
    gs_free(vlabel);
    return err;
}

gs_err micro_output_apply(void *ctx, int64_t id, const void *buf, size_t len)
{
    micro_job *job = ctx;
    GS_CHECK(len == sizeof(micro_result), GS_ERR_INTERNAL, "instance %lld: %zu output bytes",
             (long long)id, len);
    memcpy(&job->inst[id].res, buf, sizeof(micro_result));
    return GS_OK;
}

gs_err micro_json_write(gs_json *j, const char *path)
{
    gs_err err = GS_OK;
    if (j->failed) {
        err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__, "%s: JSON too large", path);
    } else {
        size_t n = j->len;
        j->buf[n] = '\n';
        err = gs_file_write_atomic(path, j->buf, n + 1);
    }
    gs_json_free(j);
    return err;
}

void micro_result_json(gs_json *j, const micro_result *r)
{
    gs_json_u64(j, "triangles", r->ntris);
    gs_json_u64(j, "vertices", r->nverts);
    gs_json_u64(j, "bins_per_region", r->nbins);
    gs_json_u64(j, "violations", r->violations);
    gs_json_u64(j, "pairs_checked", r->pairs_checked);
    gs_json_f64(j, "max_excess", r->max_excess);
    gs_json_u64(j, "unassigned", r->unassigned);
    gs_json_f64(j, "unassigned_share", r->unassigned_share);
    gs_json_i64(j, "abs_bin_error", r->abs_error_sum);
    gs_json_i64(j, "max_bin_error", r->max_bin_error);
    gs_json_f64(j, "bin_error_share", r->error_share);
    gs_json_f64(j, "realized_l1", r->realized_l1);
    gs_json_u64(j, "realized_beyond", r->realized_beyond);
    gs_json_f64(j, "realized_pos_share", r->realized_pos_share);
    gs_json_f64(j, "recon_realized_l1", r->recon_realized_l1);
    gs_json_f64(j, "recon_unassigned_share", r->recon_unassigned_share);
    gs_json_u64(j, "correct_rounds", r->correct_rounds);
    gs_json_u64(j, "correct_flips", r->correct_flips);
    gs_json_f64(j, "outline_length", r->outline_length);
    gs_json_f64(j, "outline_roughness", r->outline_roughness);
    micro_result_counts_json(j, r);
}

void micro_result_counts_json(gs_json *j, const micro_result *r)
{
    if (r->nbins > MICRO_RESULT_BINS)
        return;
    gs_json_begin_array(j, "target_count");
    for (uint64_t i = 0; i < 2 * r->nbins; i++)
        gs_json_i64(j, NULL, r->target[i]);
    gs_json_end_array(j);
    gs_json_begin_array(j, "realized_count");
    for (uint64_t i = 0; i < 2 * r->nbins; i++)
        gs_json_i64(j, NULL, r->realized[i]);
    gs_json_end_array(j);
}

void micro_outline_init(micro_outline_sum *s)
{
    s->coast = s->smoothed = 0;
    s->max = NAN;
}

void micro_outline_add(micro_outline_sum *s, const micro_result *r)
{
    if (!isfinite(r->outline_roughness))
        return;
    s->max = isnan(s->max) ? r->outline_roughness : fmax(s->max, r->outline_roughness);
    s->coast += r->outline_length;
    s->smoothed += r->outline_length / r->outline_roughness;
}

void micro_outline_metrics(gs_run *run, const micro_outline_sum *s)
{
    /* The regions' outlines in mesh.ply (src/measure/outline.c): coast length
     * over the coast opened at MICRO_OUTLINE_RHO units, over all results'
     * coasts and the worst result (NaN: no coast anywhere). */
    gs_run_metric_f64(run, "outline_roughness", s->smoothed > 0 ? s->coast / s->smoothed : NAN);
    gs_run_metric_f64(run, "outline_roughness_max", s->max);
    gs_run_metric_f64(run, "outline_rho_units", MICRO_OUTLINE_RHO);
}

void micro_result_warn(const micro_result *r, const char *what, int corrected)
{
    if (r->realized_l1 <= MICRO_REALIZED_L1_OK)
        return;
    if (!corrected) {
        gs_log(GS_LOG_WARN, "%s: the realized contact distribution misses the target by L1/n %.3f "
               "(> %.2f): micro.correct = no keeps the reconstruction's regions, whose labels are "
               "not distances to their interface (micro.correct = yes moves the interface)",
               what, r->realized_l1, MICRO_REALIZED_L1_OK);
        return;
    }
    if (r->nbins > MICRO_RESULT_BINS || r->nbins == 0) {
        gs_log(GS_LOG_WARN, "%s: the realized contact distribution misses the target by L1/n %.3f "
               "(> %.2f): the table may ask for what no two-region partition of this surface gives",
               what, r->realized_l1, MICRO_REALIZED_L1_OK);
        return;
    }
    uint64_t K = r->nbins, worst = 0;
    for (uint64_t i = 1; i < 2 * K; i++)
        if (llabs(r->realized[i] - r->target[i]) > llabs(r->realized[worst] - r->target[worst]))
            worst = i;
    int pos = worst >= K;
    uint64_t bin = pos ? worst - K : K - 1 - worst;
    /* signed axis: K-1 is negative bin 0, K positive bin 0 */
    gs_log(GS_LOG_WARN, "%s: the realized contact distribution misses the target by L1/n %.3f "
           "(> %.2f): the table may ask for what no two-region partition of this surface gives. "
           "Both sides share one coast, yet the table puts %lld triangles in negative bin 0 and "
           "%lld in positive bin 0 (a round island of radius R has (2R+1)/(2R-1) times more sea "
           "than land within 1 unit of it); the worst bin, %s %llu, wants %lld and got %lld. "
           "micro.dist = image or random draws a distribution from a real partition",
           what, r->realized_l1, MICRO_REALIZED_L1_OK, (long long)r->target[K - 1],
           (long long)r->target[K], pos ? "positive" : "negative", (unsigned long long)bin,
           (long long)r->target[worst], (long long)r->realized[worst]);
}
