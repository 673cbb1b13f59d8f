/* model driver, output: the mirrored / turned / decoded full lattice,
 * lattice.h5 (+ .xmf, label table), lattice.vox, lattice.txt, the mesh, the
 * pictures (lattice.png, tiles.png, image.png, preview.png), the quality
 * measures and the run's metrics in summary.json. */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "model/engine_impl.h"

/* The label table of lattice.h5: the labels the lattice uses, in increasing
 * order, with their colours (as lattice.vox and mesh.ply colour them) and
 * names (the tile's name and orientation for a tile set, the palette index
 * of a .vox example, else "label N"), and a colour per cell for ParaView. */
static gs_err write_label_table(gs_ckpt_t h, const model_engine *e)
{
    const size_t cells = lattice_cells(&e->lat);
    uint8_t *seen = gs_calloc(65536, 1);
    GS_CHECK(seen != NULL, GS_ERR_MEM, "label table: out of memory");
    size_t n = 0;
    for (size_t i = 0; i < cells; i++)
        seen[e->lat.labels[i]] = 1;
    for (int l = 1; l < 65536; l++)
        n += seen[l];
    uint16_t *id = NULL;
    uint8_t *rgb = NULL, *cell_rgb = NULL;
    char *names = NULL;
    gs_err err = GS_OK;
    size_t nn = n ? n : 1, names_len = 0, names_cap = 80 * nn + 1;
    GS_TRY(err, gs_alloc_array((void **)&id, nn, sizeof *id, "label table"), done);
    GS_TRY(err, gs_alloc_array((void **)&rgb, nn, 3, "label table"), done);
    GS_TRY(err, gs_alloc_array((void **)&names, names_cap, 1, "label table"), done);
    GS_TRY(err, gs_alloc_array((void **)&cell_rgb, cells, 3, "cell colours"), done);
    names[0] = '\0';
    n = 0;
    for (int l = 1; l < 65536; l++) {
        if (!seen[l])
            continue;
        id[n] = (uint16_t)l;
        gs_model_label_rgb(&e->pal, (uint16_t)l, rgb + 3 * n);
        const char *tile = e->cfg->tileset[0] && l <= e->ts.ntiles && e->ts.names ? e->ts.names[l - 1] : NULL;
        if (tile)
            names_len += (size_t)snprintf(names + names_len, names_cap - names_len, "%s\n", tile);
        else if (e->pal.from_file)
            names_len += (size_t)snprintf(names + names_len, names_cap - names_len, "palette %d\n", l);
        else
            names_len += (size_t)snprintf(names + names_len, names_cap - names_len, "label %d\n", l);
        n++;
    }
    if (names_len)
        names[names_len - 1] = '\0'; /* one name a line, no trailing newline */
    for (size_t i = 0; i < cells; i++) {
        uint16_t l = e->lat.labels[i];
        if (l)
            gs_model_label_rgb(&e->pal, l, cell_rgb + 3 * i);
        else
            cell_rgb[3 * i] = cell_rgb[3 * i + 1] = cell_rgb[3 * i + 2] = 255; /* empty: white */
    }
    gs_h5_write_opts opts = {4, 0};
    if (n) {
        gs_h5_shape is = {GS_H5_U16, 1, {(uint64_t)n}}, rs = {GS_H5_U8, 2, {(uint64_t)n, 3}};
        GS_TRY(err, gs_ckpt_write_whole(h, "/model/label_table/id", &is, id, &opts), done);
        GS_TRY(err, gs_ckpt_write_whole(h, "/model/label_table/rgb", &rs, rgb, &opts), done);
    } else {
        GS_TRY(err, gs_ckpt_group(h, "/model/label_table"), done);
    }
    GS_TRY(err, gs_ckpt_set_i64(h, "/model/label_table", "labels", (int64_t)n), done);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/label_table", "names", names), done);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/label_table", "index_order",
                                "row k: label id[k], colour rgb[k] (0-255), name = line k of @names; "
                                "label 0 (empty) is not listed"),
           done);
    const gs_h5_shape ls = model_lattice_shape(&e->lat);
    gs_h5_shape cs = {GS_H5_U8, ls.rank + 1, {0}};
    for (int i = 0; i < ls.rank; i++)
        cs.dims[i] = ls.dims[i];
    cs.dims[ls.rank] = 3;
    GS_TRY(err, gs_ckpt_write_whole(h, "/model/colour", &cs, cell_rgb, &opts), done);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/colour", "index_order",
                                e->lat.frames > 1
                                    ? "colour[t][z][y][x][c]; c = red, green, blue (0-255); x "
                                      "fastest, z up, t = frame; the label's colour, empty cells white"
                                    : "colour[z][y][x][c]; c = red, green, blue (0-255); x fastest, z up; "
                                      "the label's colour, empty cells white"),
           done);
done:
    gs_free(seen);
    gs_free(id);
    gs_free(rgb);
    gs_free(names);
    gs_free(cell_rgb);
    return err;
}

static gs_err write_lattice_h5(gs_run *run, const model_engine *e, const char *path)
{
    gs_ckpt_meta meta = {"model", e->params.seed, run->config_text};
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_create(MPI_COMM_NULL, path, &meta, &h));
    gs_h5_shape ls = model_lattice_shape(&e->lat);
    gs_h5_write_opts opts = {4, 0};
    gs_err err = GS_OK;
    char hex[17];
    gs_digest_hex(gs_model_lattice_digest(&e->lat), hex);
    GS_TRY(err, gs_ckpt_write_whole(h, "/model/labels", &ls, e->lat.labels, &opts), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/labels", "index_order",
                                e->lat.frames > 1
                                    ? "labels[t][z][y][x]; x fastest, z up, t = frame (time step); "
                                      "0 = empty"
                                    : "labels[z][y][x]; x fastest, z up; 0 = empty"),
           fail);
    if (e->lat.frames > 1)
        GS_TRY(err, gs_ckpt_set_i64(h, "/model", "frames", e->lat.frames), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model/labels", "units", "label id (see /model/label_table)"), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model", "up_axis", "z"), fail);
    GS_TRY(err, gs_ckpt_set_f64(h, "/model", "voxel_size", e->cfg->voxel_size), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model", "units",
                                "cell (x, y, z) is [x, x+1] x [y, y+1] x [z, z+1] times voxel_size "
                                "(model.voxel_size, the example's units per cell)"),
           fail);
    GS_TRY(err, write_label_table(h, e), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model", "digest", hex), fail);
    GS_TRY(err, gs_ckpt_set_str(h, "/model", "example",
                                e->cfg->tileset[0] ? e->cfg->tileset
                                : e->cfg->sample[0] ? e->cfg->sample : e->cfg->example),
           fail);
    GS_TRY(err, gs_ckpt_commit(&h), fail);
    gs_xdmf_grid grid = {"model lattice", GS_XDMF_CELL,
                         {(uint64_t)gs_model_frame_nz(&e->lat), (uint64_t)e->lat.ny, (uint64_t)e->lat.nx},
                         {0, 0, 0},
                         {e->cfg->voxel_size, e->cfg->voxel_size, e->cfg->voxel_size},
                         (uint64_t)(e->lat.frames > 1 ? e->lat.frames : 1)};
    gs_xdmf_attr attr[2] = {{"label", "/model/labels", GS_H5_U16, 1},
                            {"colour", "/model/colour", GS_H5_U8, 3}};
    GS_CALL(gs_xdmf_write(path, &grid, attr, 2));
    return GS_OK;
fail:
    gs_ckpt_discard(&h);
    return err;
}

/* The mesh (model.mesh), on the last rank: with 2 or more ranks it is
 * written while rank 0 checks the lattice and writes the other files
 * (every rank holds the whole lattice). */
static gs_err write_mesh(gs_run *run, const model_engine *e, int64_t counts[2])
{
    const model_config *c = e->cfg;
    counts[0] = counts[1] = 0;
    if (!strcmp(c->mesh, "none"))
        return GS_OK;
    gs_model_lattice vox = {0};
    gs_model_palette vpal = {{{0}}, 1};
    const gs_model_lattice *lat = &e->lat;
    const gs_model_palette *pal = &e->pal;
    double voxel = c->voxel_size;
    if (e->lat.frames > 1) { /* 4D: every frame, side by side along x */
        GS_CALL(gs_model_lattice_filmstrip(&e->lat, 1, 0, &vox));
        lat = &vox;
    } else if (e->ts.dim == 3) { /* the tiles' voxels, not one cube per tile */
        GS_CALL(gs_model_tileset_assemble(&e->ts, &e->lat, &vox, vpal.rgba));
        lat = &vox;
        pal = &vpal;
        voxel = c->voxel_size / e->ts.vx;
    }
    gs_model_quads quads = {NULL, 0, 0};
    gs_model_polymesh m;
    memset(&m, 0, sizeof m);
    gs_err err = gs_model_mesh_quads(lat, voxel, &quads);
    if (err == GS_OK)
        err = gs_model_mesh_weld(lat, &quads, voxel, &m);
    if (err == GS_OK) {
        counts[0] = (int64_t)quads.n;
        counts[1] = (int64_t)quads.unit_faces;
        char name[16], path[PATH_MAX];
        snprintf(name, sizeof name, "mesh.%s", c->mesh);
        gs_run_path(run, name, path, sizeof path);
        err = gs_model_write_mesh(path, &m, pal);
        if (err == GS_OK) {
            gs_run_path(run, "mesh.glb", path, sizeof path);
            err = gs_model_write_mesh(path, &m, pal);
        }
    }
    gs_model_polymesh_free(&m);
    gs_model_quads_free(&quads);
    gs_model_lattice_destroy(&vox);
    return err;
}

/* The result perr of writing preview.png: without a renderer here
 * (GS_ERR_LIB) the run is still good, so a warning; else perr, and a written
 * preview is listed in the outputs when record. */
static gs_err preview_written(gs_run *run, gs_err perr, int record)
{
    if (perr == GS_ERR_LIB) {
        gs_log(GS_LOG_WARN, "preview.png not written: %s (model.preview = false skips it)",
               gs_error_message());
        gs_error_clear();
        return GS_OK;
    }
    GS_CALL(perr);
    if (record)
        gs_run_output(run, "preview", "preview", "preview.png", NULL);
    return GS_OK;
}

/* Rank 0: every output file but the mesh, and the quality measures. */
static gs_err write_outputs(gs_run *run, const model_engine *e, model_quality *q)
{
    const model_config *c = e->cfg;
    char path[PATH_MAX];
    memset(q, 0, sizeof *q);
    gs_model_violation v[MODEL_VIOLATION_LIST];
    if (c->tileset[0])
        GS_CALL(gs_model_tileset_check(&e->ts, &e->lat, v, MODEL_VIOLATION_LIST, &q->violations));
    else if (c->sample[0])
        GS_CALL(gs_model_patterns_check(&e->pats, &e->lat, &q->violations));
    else /* overlap3d: e->example is the example's labels again, e->lat decoded */
        GS_CALL(gs_model_check(&e->example, &e->lat, v, MODEL_VIOLATION_LIST, &q->violations));
    for (size_t i = 0; i < q->violations && i < MODEL_VIOLATION_LIST && !c->sample[0]; i++)
        gs_log(GS_LOG_WARN, "violation: cell (%d, %d, %d) label %u, dir %d label %u", v[i].x,
               v[i].y, v[i].z, v[i].a, v[i].dir, v[i].b);
    q->rule_violations = c->overlap3d > 0
                             ? gs_model_patterns3d_check(&e->p3, &e->plat, e->params.periodic)
                             : gs_model_rules_violations_wrap(e->rules, &e->lat, e->params.periodic);
    if (!c->tileset[0] && !c->sample[0]) { /* no example lattice to compare with */
        GS_CALL(gs_model_quality(&e->example, &e->lat, &q->fig));
        for (int a = 0; a < 2; a++) /* lines only where regions split the axis */
            q->fig.grid_period[a] = c->region[a] > 0 && c->region[a] < c->size[a]
                                        ? (int)c->region[a] : 0;
        if (q->fig.layout.ground >= 0 && (q->fig.grid_period[0] || q->fig.grid_period[1])) {
            const int od[3] = {e->lat.nx, e->lat.ny, e->lat.nz};
            GS_CALL(gs_measure_grid_crossing_lattice(e->lat.labels, od, q->fig.layout.ground,
                                                     q->fig.grid_period, &q->fig.grid));
        } else {
            q->fig.grid_period[0] = q->fig.grid_period[1] = 0;
        }
        q->has_figures = 1;
        q->resemblance3 = q->fig.w3.found_share;
        q->resemblance2 = q->fig.w2.found_share;
    }
    gs_model_run_lengths(&e->lat, q->run_out);
    gs_model_run_lengths(&e->example, q->run_ex);
    {
        uint8_t *seen = gs_calloc(65536, 1);
        GS_CHECK(seen != NULL, GS_ERR_MEM, "out of memory");
        for (size_t i = 0; i < lattice_cells(&e->lat); i++)
            seen[e->lat.labels[i]] = 1;
        for (int l = 1; l < 65536; l++)
            q->labels_used += seen[l];
        gs_free(seen);
    }

    int64_t dims[3] = {e->lat.nx, e->lat.ny, e->lat.nz};
    gs_run_path(run, "lattice.h5", path, sizeof path);
    GS_CALL(write_lattice_h5(run, e, path));
    gs_run_output(run, "h5", "lattice", "lattice.h5", dims);
    gs_run_output(run, "xdmf", "lattice", "lattice.xmf", dims);
    if (c->schedule_log && e->windows_run > 0) /* written during synthesis (engine_sched.c) */
        gs_run_output(run, "json", "schedule", "schedule.jsonl", NULL);
    if (c->vox && e->lat.frames > 1) { /* 4D: one .vox per frame */
        gs_model_lattice fr = {0};
        int64_t fdims[3] = {e->lat.nx, e->lat.ny, gs_model_frame_nz(&e->lat)};
        for (int t = 0; t < e->lat.frames; t++) {
            char name[32];
            snprintf(name, sizeof name, "frame_%03d.vox", t);
            gs_run_path(run, name, path, sizeof path);
            GS_CALL(gs_model_lattice_frame(&e->lat, t, &fr));
            gs_err ferr = gs_model_write_vox(path, &fr, &e->pal, &q->vox_renumbered);
            gs_model_lattice_destroy(&fr);
            GS_CALL(ferr);
            gs_run_output(run, "vox", "frame", name, fdims);
        }
    } else if (c->vox) {
        gs_run_path(run, "lattice.vox", path, sizeof path);
        GS_CALL(gs_model_write_vox(path, &e->lat, &e->pal, &q->vox_renumbered));
        gs_run_output(run, "vox", "lattice", "lattice.vox", dims);
        if (q->vox_renumbered)
            gs_log(GS_LOG_WARN, "lattice.vox: labels above 255 renumbered 1..%d in order",
                   q->labels_used);
    }
    if (strcmp(c->mesh, "none")) {
        char name[16];
        snprintf(name, sizeof name, "mesh.%s", c->mesh);
        gs_run_output(run, "mesh", "lattice", name, NULL); /* written by write_mesh */
        gs_run_output(run, "mesh", "lattice", "mesh.glb", NULL);
    }
    if (e->lat.nz == 1) {
        gs_run_path(run, "lattice.png", path, sizeof path);
        GS_CALL(gs_model_write_png(path, &e->lat, &e->pal));
        gs_run_output(run, "image", "lattice", "lattice.png", NULL);
    }
    if (c->preview && e->lat.nz > 1 && !c->tileset[0] && !c->sample[0]) {
        gs_run_path(run, "preview.png", path, sizeof path);
        gs_err perr = GS_OK;
        if (e->lat.frames > 1) { /* 4D: the frames side by side, example and output */
            gs_model_lattice exs = {0}, outs = {0};
            GS_CALL(gs_model_lattice_filmstrip(&e->example, 1, MODEL_PREVIEW_FRAMES, &exs));
            perr = gs_model_lattice_filmstrip(&e->lat, 1, MODEL_PREVIEW_FRAMES, &outs);
            if (perr == GS_OK)
                perr = gs_model_write_preview(path, &exs, &outs, &e->pal, (int)c->preview_size);
            gs_model_lattice_destroy(&exs);
            gs_model_lattice_destroy(&outs);
        } else {
            perr = gs_model_write_preview(path, &e->example, &e->lat, &e->pal, (int)c->preview_size);
        }
        GS_CALL(preview_written(run, perr, 1));
    }
    if (e->ts.dim == 3 && c->tile_image) {
        char ppath[PATH_MAX];
        gs_run_path(run, "tiles.vox", path, sizeof path);
        gs_run_path(run, "preview.png", ppath, sizeof ppath);
        GS_CALL(preview_written(run, gs_model_tileset_write_voxels(&e->ts, &e->lat, path,
                                                                   c->preview ? ppath : NULL,
                                                                   (int)c->preview_size),
                                (int)c->preview));
        gs_run_output(run, "vox", "tiles", "tiles.vox", NULL); /* dimensions from the file */
    } else if (c->tileset[0] && c->tile_image) {
        gs_run_path(run, "tiles.png", path, sizeof path);
        GS_CALL(gs_model_tileset_write_png(path, &e->ts, &e->lat));
        gs_run_output(run, "image", "tiles", "tiles.png", NULL);
    }
    if (c->sample[0] && c->tile_image) {
        gs_run_path(run, "image.png", path, sizeof path);
        GS_CALL(gs_model_patterns_write_png(path, &e->pats, &e->lat));
        gs_run_output(run, "image", "patterns", "image.png", NULL);
    }
    if (c->txt) {
        gs_run_path(run, "lattice.txt", path, sizeof path);
        GS_CALL(gs_model_write_merrell_txt(path, &e->lat));
        gs_run_output(run, "text", "lattice", "lattice.txt", dims);
    }
    return GS_OK;
}

/* The quality figures of gs_model_quality into summary.json (docs/FORMATS.md). */
static void write_figures(gs_run *run, const gs_model_quality_figures *f)
{
    const gs_measure_windows *w[2] = {&f->w3, &f->w2};
    static const char *key[2][5] = {
        {"resemblance_3x3x3", "resemblance_3x3x3_with_empty", "completeness_3x3x3",
         "windows_3x3x3_nonempty", "windows_3x3x3_example_distinct"},
        {"resemblance_2x2x2", "resemblance_2x2x2_with_empty", "completeness_2x2x2",
         "windows_2x2x2_nonempty", "windows_2x2x2_example_distinct"}};
    for (int k = 0; k < 2; k++) {
        gs_run_metric_f64(run, key[k][0], w[k]->found_share);
        gs_run_metric_f64(run, key[k][1], w[k]->found_share_all);
        gs_run_metric_f64(run, key[k][2], w[k]->completeness);
        gs_run_metric_i64(run, key[k][3], (int64_t)w[k]->output_nonempty);
        gs_run_metric_i64(run, key[k][4], (int64_t)w[k]->example_distinct);
    }
    gs_run_metric_f64(run, "label_l1", f->label_l1);
    gs_run_metric_i64(run, "labels_example", f->labels_example);
    gs_run_metric_f64(run, "empty_share", f->empty_share);
    gs_run_metric_f64(run, "empty_share_example", f->empty_share_example);
    gs_run_metric_f64(run, "unsupported_share", f->unsupported_share);
    gs_run_metric_f64(run, "unsupported_share_example", f->unsupported_share_example);
    gs_run_metric_i64(run, "enclosed_layer", f->enclosure.layer);
    if (f->enclosure.layer >= 0) {
        const gs_measure_enclosure *en[2] = {&f->enclosure, &f->enclosure_example};
        static const char *ekey[2][5] = {
            {"enclosed_share", "enclosed_yards", "enclosed_yards_per_kcell", "enclosed_yard_max",
             "enclosed_large_share"},
            {"enclosed_share_example", "enclosed_yards_example",
             "enclosed_yards_per_kcell_example", "enclosed_yard_max_example",
             "enclosed_large_share_example"}};
        for (int k = 0; k < 2; k++) {
            const double cells = en[k]->cells ? (double)en[k]->cells : 1;
            gs_run_metric_f64(run, ekey[k][0], (double)en[k]->enclosed / cells);
            gs_run_metric_i64(run, ekey[k][1], (int64_t)en[k]->yards);
            gs_run_metric_f64(run, ekey[k][2], 1000.0 * (double)en[k]->yards / cells);
            gs_run_metric_i64(run, ekey[k][3], (int64_t)en[k]->yard_max);
            gs_run_metric_f64(run, ekey[k][4], (double)en[k]->large / cells);
        }
    }
    if (f->layout.ground >= 0) {
        gs_run_metric_i64(run, "layout_ground_layer", f->layout.ground);
        const gs_measure_layout *la[2] = {&f->layout, &f->layout_example};
        static const char *lkey[2][8] = {
            {"open_ground_share", "open_ground_clear_share", "structures_per_kcell",
             "structure_max", "structure_size_median", "structure_large_share", "structures",
             "structure_nested_share"},
            {"open_ground_share_example", "open_ground_clear_share_example",
             "structures_per_kcell_example", "structure_max_example",
             "structure_size_median_example", "structure_large_share_example",
             "structures_example", "structure_nested_share_example"}};
        for (int k = 0; k < 2; k++) {
            const double cols = la[k]->columns ? (double)la[k]->columns : 1;
            const double sc = la[k]->structure_cells ? (double)la[k]->structure_cells : 1;
            gs_run_metric_f64(run, lkey[k][0], (double)la[k]->open / cols);
            gs_run_metric_f64(run, lkey[k][1], (double)la[k]->clear / cols);
            gs_run_metric_f64(run, lkey[k][2], 1000.0 * (double)la[k]->structures / cols);
            gs_run_metric_i64(run, lkey[k][3], (int64_t)la[k]->largest);
            gs_run_metric_i64(run, lkey[k][4], (int64_t)la[k]->size_median);
            gs_run_metric_f64(run, lkey[k][5], (double)la[k]->large_cells / sc);
            gs_run_metric_i64(run, lkey[k][6], (int64_t)la[k]->structures);
            gs_run_metric_f64(run, lkey[k][7], (double)la[k]->nested_cells / sc);
        }
        if (f->grid_period[0] || f->grid_period[1]) {
            const gs_measure_grid_crossing *g = &f->grid;
            gs_run_metric_i64(run, "region_grid_period_x", f->grid_period[0]);
            gs_run_metric_i64(run, "region_grid_period_y", f->grid_period[1]);
            gs_run_metric_f64(run, "region_grid_crossing",
                              g->on_pairs ? (double)g->on_both / (double)g->on_pairs : 0);
            gs_run_metric_f64(run, "region_grid_crossing_other",
                              g->off_pairs ? (double)g->off_both / (double)g->off_pairs : 0);
            gs_run_metric_f64(run, "region_grid_crossing_ratio", g->ratio);
        }
        gs_run_metric_f64(run, "structure_max_ratio",
                          f->layout_example.largest
                              ? (double)f->layout.largest / (double)f->layout_example.largest
                              : 0);
    }
    gs_run_metric_f64(run, "height_fill_mean_abs", f->profile.fill_mean_abs);
    gs_run_metric_f64(run, "height_label_l1_mean", f->profile.label_l1_mean);
    gs_run_metric_i64(run, "top_layer", f->profile.top_output);
    gs_run_metric_i64(run, "top_layer_example", f->profile.top_example);
    const double *arr[2] = {f->profile.fill_output, f->profile.fill_example};
    static const char *akey[2] = {"height_fill", "height_fill_example"};
    for (int k = 0; k < 2; k++) {
        gs_json_begin_array(&run->metrics, akey[k]);
        for (int z = 0; z < f->profile.nz; z++)
            gs_json_f64(&run->metrics, NULL, round(arr[k][z] * 1e4) / 1e4);
        gs_json_end_array(&run->metrics);
    }
}

/* Collective: the mirrored half or the turned quarter into the full output. */
static gs_err expand_symmetry(model_engine *e)
{
    gs_err err = GS_OK;
    if (e->cfg->overlap3d > 0) {
        /* every rank: the patterns decode to their origin cells; the example's
         * labels come back for the checks, measures and preview */
        e->plat = e->lat;
        memset(&e->lat, 0, sizeof e->lat);
        GS_TRY(err, gs_model_patterns3d_decode(&e->p3, &e->plat, !e->params.periodic[2], &e->lat), fail);
        gs_model_lattice_destroy(&e->example);
        e->example = e->src;
        memset(&e->src, 0, sizeof e->src);
    }
    if (e->params.mirror[0] || e->params.mirror[1]) {
        /* mirror the synthesized lower half into the full output */
        gs_model_lattice full = {0};
        GS_TRY(err, gs_model_lattice_create(&full, e->full[0], e->full[1], e->full[2]), fail);
        for (int z = 0; z < full.nz; z++)
            for (int y = 0; y < full.ny; y++)
                for (int x = 0; x < full.nx; x++) {
                    int hx = x < e->lat.nx ? x : full.nx - 1 - x;
                    int hy = y < e->lat.ny ? y : full.ny - 1 - y;
                    int l = e->lat.labels[gs_model_lattice_index(&e->lat, hx, hy, z)];
                    /* the mirrored half holds S(l) (Sec. 4.1) */
                    if (hy != y && e->mirror_map[1] && e->mirror_map[1][l] >= 0)
                        l = e->mirror_map[1][l];
                    if (hx != x && e->mirror_map[0] && e->mirror_map[0][l] >= 0)
                        l = e->mirror_map[0][l];
                    full.labels[gs_model_lattice_index(&full, x, y, z)] = (uint16_t)l;
                }
        gs_model_lattice_destroy(&e->lat);
        e->lat = full;
    }
    if (e->rotate_map) {
        /* turn the synthesized quarter three times into the full output:
         * the cell reached from quarter cell q by k turns holds R^k(label) */
        gs_model_lattice full = {0};
        GS_TRY(err, gs_model_lattice_create(&full, e->full[0], e->full[1], e->full[2]), fail);
        const int N = full.nx, h = e->lat.nx;
        for (int z = 0; z < full.nz; z++)
            for (int y = 0; y < full.ny; y++)
                for (int x = 0; x < full.nx; x++) {
                    int px = x, py = y, k = 0;
                    while (px >= h || py >= h) { /* turn back: (x, y) -> (y, N-1-x) */
                        int t = px;
                        px = py;
                        py = N - 1 - t;
                        k++;
                    }
                    int l = e->lat.labels[gs_model_lattice_index(&e->lat, px, py, z)];
                    for (int i = 0; i < k && e->rotate_map[l] >= 0; i++)
                        l = e->rotate_map[l];
                    full.labels[gs_model_lattice_index(&full, x, y, z)] = (uint16_t)l;
                }
        gs_model_lattice_destroy(&e->lat);
        e->lat = full;
    }
fail:
    return err;
}

/* Rank 0: the run's metrics and log lines. */
static void report_metrics(gs_run *run, model_drive *d)
{
    model_engine *e = &d->e;
    model_quality *q = &d->q;
    const double cells = (double)lattice_cells(&e->lat);
    if (run->rank == 0) {
        gs_run_metric_i64(run, "violations", (int64_t)q->violations);
        gs_run_metric_i64(run, "rule_violations", (int64_t)q->rule_violations);
        gs_run_metric_i64(run, "pins_unmet", (int64_t)gs_model_pins_unmet(&e->params, &e->lat));
        gs_run_metric_i64(run, "passes", e->stats.passes);
        gs_run_metric_i64(run, "regions", (int64_t)e->stats.regions);
        gs_run_metric_i64(run, "accepted_regions", (int64_t)e->stats.accepted);
        gs_run_metric_i64(run, "failed_regions", (int64_t)e->stats.failed);
        gs_run_metric_i64(run, "z_faces_fixed", e->params.fix_z_faces && e->lat.nz >= 3);
        if (e->cfg->overlap3d > 0) {
            gs_run_metric_i64(run, "overlap3d_patterns", e->p3.npatterns);
            gs_run_metric_i64(run, "overlap3d_pairs", (int64_t)e->p3.npairs);
        }
        gs_run_metric_i64(run, "retries", (int64_t)(e->stats.attempts - e->stats.regions));
        gs_run_metric_i64(run, "rejected_attempts",
                          (int64_t)(e->stats.attempts - e->stats.accepted));
        gs_run_metric_i64(run, "backtracks", (int64_t)e->stats.backtracks);
        gs_run_metric_i64(run, "min_coverage", (int64_t)e->stats.min_coverage);
        if (e->params.shape) { /* soft constraint: structure inside vs outside the target */
            const int nl = gs_model_rules_nlabels(e->rules);
            double sin = 0, sout = 0, sex = 0;
            gs_model_structure_shares(&e->lat, e->structure, nl, e->shape, &sin, &sout);
            const size_t ne = lattice_cells(&e->example); /* the example's own share */
            for (size_t i = 0; i < ne; i++)
                sex += e->example.labels[i] < nl && e->structure[e->example.labels[i]];
            sex = ne ? sex / (double)ne : 0;
            gs_run_metric_i64(run, "structure_labels", e->nstructure_labels);
            gs_run_metric_f64(run, "structure_share_inside", sin);
            gs_run_metric_f64(run, "structure_share_outside", sout);
            gs_run_metric_f64(run, "structure_share_example", sex);
            gs_run_metric_i64(run, "mh_rejected_regions", (int64_t)e->stats.mh_rejected);
            gs_log(GS_LOG_INFO, "shape: structure share inside the target %.3f, outside %.3f "
                   "(example %.3f); %llu regions not accepted by the Metropolis step", sin, sout,
                   sex, (unsigned long long)e->stats.mh_rejected);
        }
        if (q->has_figures)
            write_figures(run, &q->fig);
        static const char *axis_key[3][3] = {
            {"run_length_x", "run_length_x_example", "run_length_x_ratio"},
            {"run_length_y", "run_length_y_example", "run_length_y_ratio"},
            {"run_length_z", "run_length_z_example", "run_length_z_ratio"}};
        for (int a = 0; a < 3; a++) {
            gs_run_metric_f64(run, axis_key[a][0], q->run_out[a]);
            gs_run_metric_f64(run, axis_key[a][1], q->run_ex[a]);
            gs_run_metric_f64(run, axis_key[a][2],
                              q->run_ex[a] > 0 ? q->run_out[a] / q->run_ex[a] : 0.0);
        }
        gs_run_metric_f64(run, "synthesis_seconds", e->synth_seconds);
        /* this process's share (a resumed run: since the resume) */
        const double *qs = d->qr.sum, *qm = d->qr.max;
        gs_run_metric_f64(run, "region_seconds_total", qs[Q_COMPUTE]);
        gs_run_metric_f64(run, "region_seconds_max_rank", qm[Q_COMPUTE]);
        gs_run_metric_f64(run, "ideal_speedup", qm[Q_COMPUTE] > 0 ? qs[Q_COMPUTE] / qm[Q_COMPUTE] : 0);
        gs_run_metric_f64(run, "queue_wait_seconds_max_rank", qm[Q_WAIT]);
        gs_run_metric_f64(run, "tail_wait_seconds_max_rank", qm[Q_TAIL]);
        gs_run_metric_f64(run, "exchange_seconds_max_rank", qm[Q_EXCHANGE]);
        gs_run_metric_f64(run, "apply_seconds_max_rank", qm[Q_APPLY]);
        gs_run_metric_f64(run, "window_setup_seconds_max_rank", qm[Q_WINDOW_SETUP]);
        gs_run_metric_f64(run, "outside_windows_seconds_max_rank", qm[Q_OUTSIDE]);
        gs_run_metric_i64(run, "duplicate_regions", (int64_t)qs[Q_DUPLICATES]);
        gs_run_metric_f64(run, "synthesis_cpu_seconds_max_rank", qm[Q_CPU]);
        /* engine_sched.c: the schedule in CPU seconds, no waits for a core */
        const model_sched *sc = &e->sched;
        if (sc->windows > 0 && sc->cpu > 0) {
            gs_run_metric_f64(run, "schedule_region_cpu_seconds", sc->cpu);
            gs_run_metric_f64(run, "schedule_critical_path_seconds", sc->crit);
            gs_run_metric_f64(run, "schedule_speedup_bound_2ranks", sc->cpu / sc->bound2);
            gs_run_metric_f64(run, "schedule_speedup_policy_2ranks", sc->cpu / sc->policy2);
            gs_run_metric_f64(run, "schedule_speedup_replay", sc->cpu / sc->replay);
            gs_log(GS_LOG_INFO,
                   "schedule (region CPU %.3f s, no waits for a core): 2 ranks at best %.3fx "
                   "(longest chain %.3f s), the dataflow's rule on 2 ranks %.3fx, this run's "
                   "schedule on %d rank%s %.3fx",
                   sc->cpu, sc->cpu / sc->bound2, sc->crit, sc->cpu / sc->policy2, run->size,
                   run->size == 1 ? "" : "s", sc->cpu / sc->replay);
        }
        gs_log(GS_LOG_INFO,
               "regions: %.3f s of region runs over %d ranks (%.3f s on the busiest: ideal "
               "speed-up %.2f); per rank at most %.3f s waiting, %.3f s exchanging, %.3f s "
               "applying, %.3f s CPU",
               qs[Q_COMPUTE], run->size, qm[Q_COMPUTE],
               qm[Q_COMPUTE] > 0 ? qs[Q_COMPUTE] / qm[Q_COMPUTE] : 0, qm[Q_WAIT], qm[Q_EXCHANGE],
               qm[Q_APPLY], qm[Q_CPU]);
        gs_run_metric_f64(run, "cells_per_second", e->synth_seconds > 0 ? cells / e->synth_seconds : 0);
        gs_run_metric_f64(run, "region_cells_per_second",
                          e->synth_seconds > 0 ? (double)e->region_cells / e->synth_seconds : 0);
        gs_run_metric_i64(run, "labels_used", q->labels_used);
        gs_run_metric_i64(run, "mesh_quads", (int64_t)q->quads);
        gs_run_metric_i64(run, "mesh_unit_faces", (int64_t)q->unit_faces);
        gs_log(GS_LOG_INFO,
               "%d passes, %llu regions: %llu accepted, %llu failed, %llu retries; "
               "%.0f cells/s",
               e->stats.passes, (unsigned long long)e->stats.regions,
               (unsigned long long)e->stats.accepted, (unsigned long long)e->stats.failed,
               (unsigned long long)(e->stats.attempts - e->stats.regions),
               e->synth_seconds > 0 ? cells / e->synth_seconds : 0.0);
        gs_log(GS_LOG_INFO,
               "adjacency violations (independent checker): %zu; resemblance (non-empty "
               "windows found in the example) 3x3x3 %.3f, 2x2x2 %.3f; run lengths x/y/z %.2f/%.2f/%.2f (example %.2f/%.2f/%.2f)",
               q->violations, q->resemblance3, q->resemblance2, q->run_out[0], q->run_out[1],
               q->run_out[2], q->run_ex[0], q->run_ex[1], q->run_ex[2]);
    }
}

gs_err model_output_op(void *state, gs_run *run, gs_json *phase, uint64_t *digest)
{
    model_drive *d = state;
    model_engine *e = &d->e;
    model_quality *q = &d->q;
    GS_CALL(expand_symmetry(e));
    int64_t mesh_counts[2] = {0, 0};
    gs_err err = GS_OK;
    if (run->rank == 0)
        err = write_outputs(run, e, q);
    if (err == GS_OK && run->rank == run->size - 1)
        err = write_mesh(run, e, mesh_counts);
    GS_CALL(gs_par_agree(run->comm, err));
    GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &mesh_counts, run->size - 1));
    q->quads = (size_t)mesh_counts[0];
    q->unit_faces = (size_t)mesh_counts[1];
    gs_json_u64(phase, "violations", q->violations);
    gs_json_u64(phase, "quads", q->quads);
    gs_json_u64(phase, "unit_faces", q->unit_faces);
    if (run->rank == 0)
        report_metrics(run, d);
    *digest = gs_model_lattice_digest(&e->lat);
    return GS_OK;
}
