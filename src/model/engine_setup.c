/* model driver, setup: the example, start lattice, tile set or sample read
 * on rank 0 and broadcast; then on every rank the rules, the symmetries
 * (mirror, rotation), ground and z faces, pins and shape, the solver and the
 * start model (deterministic, so no broadcast). See engine_impl.h. */
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "model/engine_impl.h"

static gs_err engine_params(const model_config *c, gs_model_params *p)
{
    gs_model_params_default(p);
    p->seed = (uint64_t)c->run.seed;
    for (int a = 0; a < 3; a++)
        p->region[a] = (int)c->region[a];
    p->overlap = (int)c->overlap;
    p->region_jitter = (int)c->region_jitter;
    p->attempts = (int)c->attempts;
    p->min_changes = c->passes < 0 ? 1 : (int)c->passes; /* auto: see model_setup */
    p->max_passes = (int)c->max_passes;
    p->fix_z_faces = strcmp(c->fix_z_faces, "false") != 0 && !strchr(c->periodic, 'z');
    p->backtracks = (int)c->backtracks;
    p->backjump = (int)c->backjump;
    p->rewinds = (int)c->rewinds;
    p->order = !strcmp(c->order, "scan")          ? GS_MODEL_ORDER_SCAN
               : !strcmp(c->order, "random")      ? GS_MODEL_ORDER_RANDOM
               : !strcmp(c->order, "entropy_log") ? GS_MODEL_ORDER_ENTROPY_LOG
               : !strcmp(c->order, "entropy_layers") ? GS_MODEL_ORDER_ENTROPY_LAYERS
               : !strcmp(c->order, "entropy_columns") ? GS_MODEL_ORDER_ENTROPY_COLUMNS
                                                  : GS_MODEL_ORDER_ENTROPY; /* auto:
                                                  model_setup, after decide_z_faces */
    p->weights = !strcmp(c->weights, "frequency") ? GS_MODEL_WEIGHTS_FREQUENCY
                                                  : GS_MODEL_WEIGHTS_UNIFORM;
    p->ac = !strcmp(c->ac, "ac4") ? GS_MODEL_AC4 : GS_MODEL_AC3;
    p->split_depth = (int)c->split_depth;
    p->periodic[0] = strchr(c->periodic, 'x') != NULL;
    p->periodic[1] = strchr(c->periodic, 'y') != NULL;
    p->periodic[2] = strchr(c->periodic, 'z') != NULL;
    return GS_OK;
}

/* Collective: rank 0's lattice (and its load status) to every rank. */
static gs_err bcast_lattice(MPI_Comm comm, gs_model_lattice *l, gs_err loaded)
{
    GS_CALL(gs_par_agree(comm, loaded));
    int dims[4] = {l->nx, l->ny, l->nz, l->frames};
    GS_CALL(GS_PAR_BCAST_VALUE(comm, &dims, 0));
    /* agreed: a rank that cannot allocate must not leave rank 0 in the broadcast */
    GS_CALL(gs_par_agree(comm, l->labels ? GS_OK
                                         : gs_model_lattice_create(l, dims[0], dims[1], dims[2])));
    l->frames = dims[3];
    GS_CALL(gs_par_bcast_bytes(comm, l->labels, lattice_cells(l) * sizeof *l->labels, 0));
    return GS_OK;
}

/* Tile sets and patterns have no example lattice: the start model needs a
 * label that may sit next to itself along x and y. The 1x1x1 "example"
 * holds the heaviest such label (first on ties), which gs_model_initial
 * prefers. */
static gs_err pseudo_example(model_engine *e)
{
    const char *what = e->cfg->tileset[0] ? e->cfg->tileset : e->cfg->sample;
    int L = gs_model_rules_nlabels(e->rules), best = -1;
    for (int l = 1; l < L; l++) {
        if (!gs_model_rules_count(e->rules, l) || !gs_model_rules_allows(e->rules, 0, l, l) ||
            !gs_model_rules_allows(e->rules, 2, l, l))
            continue;
        if (best < 0 || gs_model_rules_count(e->rules, l) > gs_model_rules_count(e->rules, best))
            best = l;
    }
    if (e->cfg->start_tile[0]) {
        char want[80];
        snprintf(want, sizeof want, "%s%s", e->cfg->start_tile,
                 strchr(e->cfg->start_tile, ' ') ? "" : " 0");
        best = -1;
        for (int t = 0; t < e->ts.ntiles && best < 0; t++)
            if (!strcmp(e->ts.names[t], want))
                best = t + 1;
        GS_CHECK(best > 0, GS_ERR_ARG, "model.start_tile = %s: no such tile in %s%s%s",
                 e->cfg->start_tile, what, e->cfg->subset[0] ? " subset " : "", e->cfg->subset);
        GS_CHECK(gs_model_rules_allows(e->rules, 0, best, best) &&
                     gs_model_rules_allows(e->rules, 2, best, best),
                 GS_ERR_ARG,
                 "model.start_tile = %s: the tile may not sit next to itself along x and y in "
                 "%s, so it cannot fill the start model",
                 e->cfg->start_tile, what);
    }
    GS_CHECK(best > 0 || e->cfg->start[0], GS_ERR_ARG,
             "%s: no %s may sit next to itself along both x and y, so there is no trivial "
             "consistent start model; give one with model.start",
             what, e->cfg->tileset[0] ? "tile" : "pattern");
    /* a voxel tile set's ground lies under the start tile (gs_model_initial
     * then prefers that column) */
    int ground = e->ts.ground && e->cfg->size[2] > 1;
    GS_CALL(gs_model_lattice_create(&e->example, 1, 1, 1 + ground));
    e->example.labels[0] = (uint16_t)(ground ? e->ts.ground : best > 0 ? best : 1);
    if (ground)
        e->example.labels[1] = (uint16_t)(best > 0 ? best : 1);
    return GS_OK;
}

/* Default mode: when the example has no floating structure (every non-empty
 * cell has a 6-connected non-empty path to z = 0; label 0 is empty), the
 * output must have none either: e->repair_empty marks label 0 for the repair
 * after the passes (support_repair), the regions themselves do not check
 * (a check per try: village share 0.539 -> 0.487, 7x the time;
 * configs/model/DEFAULTS.md). */
static gs_err repair_setup(model_engine *e)
{
    const gs_model_lattice *x = &e->example;
    const int L = gs_model_rules_nlabels(e->rules);
    GS_CALL(gs_alloc_array((void **)&e->repair_empty, (size_t)L + 1, 1, "repair labels"));
    e->repair_empty[0] = 1;
    const size_t n = (size_t)x->nx * (size_t)x->ny * (size_t)x->nz;
    uint8_t *st = gs_malloc(n ? n : 1);
    GS_CHECK(st != NULL, GS_ERR_MEM, "support of the example: cannot allocate");
    gs_model_params p = {0};
    p.support_empty = e->repair_empty;
    size_t nf = gs_model_support_floating(x->labels, x->nx, x->ny, x->nz, &p, st);
    gs_free(st);
    GS_CHECK(nf != SIZE_MAX, GS_ERR_MEM, "support of the example: cannot allocate");
    if (nf) { /* the example has floating structure: nothing to repair */
        gs_free(e->repair_empty);
        e->repair_empty = NULL;
    }
    return GS_OK;
}

/* model.overlap3d (every rank, from the broadcast example): patterns,
 * their overlap rules; e->example becomes the lattice of the example's
 * window patterns (its bottom / top layers give the z face patterns, its
 * columns the start model's preference), the example itself moves to src. */
static gs_err overlap3d_setup(model_engine *e)
{
    const model_config *c = e->cfg;
    GS_CALL(gs_model_patterns3d_learn(&e->example, (int)c->overlap3d,
                                      MODEL_OVERLAP3D_MAX_PATTERNS, c->example, &e->p3));
    GS_CALL(gs_model_patterns3d_rules(&e->p3, &e->rules));
    e->params.support_empty = e->p3.support_empty; /* no floating structure: the example has none */
    if (!e->params.periodic[2]) { /* the decoded layers over the top pattern layer */
        e->params.support_above = e->p3.support_above;
        e->params.support_layers_above = (int)c->overlap3d - 1;
    }
    e->src = e->example;
    memset(&e->example, 0, sizeof e->example);
    const gs_model_lattice *w = &e->p3.windows;
    GS_CALL(gs_model_lattice_create(&e->example, w->nx, w->ny, w->nz));
    memcpy(e->example.labels, w->labels, lattice_cells(w) * sizeof *w->labels);
    const int L = gs_model_rules_nlabels(e->rules);
    gs_log(GS_LOG_INFO,
           "overlap3d: %d distinct %dx%dx%d windows of the example's %zu (%dx%dx%d origins), "
           "%zu overlap pairs, rules %.1f MiB",
           e->p3.npatterns, e->p3.n, e->p3.n, e->p3.n, lattice_cells(w), w->nx, w->ny, w->nz,
           e->p3.npairs, 8.0 * L * (double)((L + 63) / 64) * 8 / 1048576.0);
    return GS_OK;
}

/* The rules are bit sets indexed by label id, sized by the largest id: one
 * id 65534 in a 4x4x6 example asked for 4 GB of transition sets. Ids are
 * not renumbered (outputs keep the example's ids), so a sparse set whose
 * rules would take more than 64 MiB and more than 64 times what the labels
 * present need with ids 1..k is refused here, naming the label and a cell
 * holding it. */
#define MODEL_SPARSE_RULES_MIB 64
static gs_err check_label_ids(const char *path, const gs_model_lattice *ex)
{
    size_t n = lattice_cells(ex), at = 0;
    uint8_t *seen = gs_calloc(65536, 1);
    GS_CHECK(seen, GS_ERR_MEM, "label set: cannot allocate");
    int maxl = 0, k = 0;
    for (size_t i = 0; i < n; i++) {
        int l = ex->labels[i];
        if (!seen[l]) {
            seen[l] = 1;
            k++;
        }
        if (l > maxl) {
            maxl = l;
            at = i;
        }
    }
    gs_free(seen);
    double need = (double)(maxl + 1) * GS_MODEL_DIRS * (double)((maxl + 64) / 64) * 8;
    double dense = (double)k * GS_MODEL_DIRS * (double)((k + 63) / 64) * 8;
    if (need <= MODEL_SPARSE_RULES_MIB * 1048576.0 || need <= 64 * dense)
        return GS_OK;
    const size_t plane = (size_t)ex->nx * (size_t)ex->ny;
    GS_RAISE(GS_ERR_FORMAT,
             "%s: label %d (at x %zu y %zu z %zu) among %d distinct labels: rules are sized by "
             "the largest label id, %.0f MiB here (more than %d MiB); renumber the labels "
             "densely (1, 2, 3, ...; 0 stays empty)",
             path, maxl, at % (size_t)ex->nx, at % plane / (size_t)ex->nx, at / plane, k,
             need / 1048576.0, MODEL_SPARSE_RULES_MIB);
}

static gs_err load_inputs(gs_run *run, model_engine *e)
{
    const model_config *c = e->cfg;
    gs_err err = GS_OK;
    if (c->tileset[0] || c->sample[0]) {
        /* Parsed on rank 0 and broadcast (#25); the tile images stay there. */
        if (run->rank == 0)
            err = c->tileset[0] ? gs_model_tileset_load_any(c->tileset, c->subset, c->tile_folder,
                                                            1, &e->ts)
                                : gs_model_patterns_learn(c->sample, (int)c->overlap_n,
                                                          (int)c->symmetry, c->periodic_input,
                                                          &e->pats);
        if (!err && c->tileset[0] && e->ts.dim == 2 && c->size[2] != 1)
            err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                 "model.size z = %lld: %s is a 2D tile set, expected z = 1",
                                 (long long)c->size[2], c->tileset);
        /* pictures and voxel files written after the synthesis (rank 0 holds
         * the tile images) */
        if (!err && run->rank == 0)
            err = gs_model_check_output_sizes(c->size, c->tileset[0] ? &e->ts : NULL,
                                              c->sample[0] ? &e->pats : NULL,
                                              c->tileset[0] ? c->tileset : c->sample,
                                              c->tile_image, c->vox);
        GS_CALL(gs_par_agree(run->comm, err));
        GS_CALL(c->tileset[0] ? gs_model_tileset_bcast(run->comm, 0, &e->ts)
                              : gs_model_patterns_bcast(run->comm, 0, &e->pats));
        GS_CALL(c->tileset[0] ? gs_model_tileset_rules(&e->ts, &e->rules)
                              : gs_model_patterns_rules(&e->pats, &e->rules));
        GS_CALL(pseudo_example(e));
    } else {
        if (run->rank == 0)
            err = gs_model_load(c->example, c->format, c->dataset, &e->example, &e->pal);
        if (run->rank == 0 && !err)
            err = check_label_ids(c->example, &e->example);
        if (run->rank == 0 && !err)
            err = gs_model_check_output_sizes(c->size, NULL, NULL, c->example, c->tile_image,
                                              c->vox);
        if (run->rank == 0 && !err)
            err = gs_model_check_vox_labels(&e->example, c->example, c->vox);
        GS_CALL(bcast_lattice(run->comm, &e->example, err));
        GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &e->pal, 0));
        if (c->overlap3d > 0)
            GS_CALL(overlap3d_setup(e));
    }
    if (c->start[0]) {
        if (run->rank == 0) {
            err = gs_model_load(c->start, "auto", c->dataset, &e->start, NULL);
            if (!err && (e->start.nx != c->size[0] || e->start.ny != c->size[1] ||
                         e->start.nz != c->size[2]))
                err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                     "model.start = %s is %dx%dx%d: expected the output size "
                                     "model.size = %lldx%lldx%lld",
                                     c->start, e->start.nx, e->start.ny, e->start.nz,
                                     (long long)c->size[0], (long long)c->size[1],
                                     (long long)c->size[2]);
        }
        GS_CALL(bcast_lattice(run->comm, &e->start, err));
    }
    e->example_digest = gs_model_lattice_digest(&e->example);
    /* Pair lists by value (the struct has padding bytes), plus the weights. */
    const gs_model_pair *pairs = e->ts.npairs   ? e->ts.pairs
                                 : e->p3.npairs ? e->p3.pairs
                                                : e->pats.pairs;
    size_t np = e->ts.npairs ? e->ts.npairs : e->p3.npairs ? e->p3.npairs : e->pats.npairs;
    if (np) {
        uint64_t *keys = NULL;
        GS_CALL(gs_alloc_array((void **)&keys, np, sizeof *keys, "input digest"));
        for (size_t i = 0; i < np; i++)
            keys[i] = (uint64_t)pairs[i].dir << 32 | (uint64_t)pairs[i].a << 16 | pairs[i].b;
        e->example_digest ^= gs_digest_bytes(keys, np * sizeof *keys);
        gs_free(keys);
        int L = gs_model_rules_nlabels(e->rules);
        for (int l = 0; l < L; l++)
            e->example_digest = e->example_digest * 31 + gs_model_rules_count(e->rules, l);
    }
    return GS_OK;
}

/* model.ground start: one label per row, each next to itself along x, the
 * last row a ground pattern, no ground-only pattern above it, valid +y
 * transitions; the most frequent feasible label per row, top down. */
static gs_err ground_start(model_engine *e)
{
    gs_model_lattice *lat = &e->lat;
    const int L = gs_model_rules_nlabels(e->rules), ny = lat->ny;
    uint8_t *reach = NULL;
    GS_CALL(gs_alloc_array((void **)&reach, (size_t)ny * (size_t)L, 1, "ground start"));
    memset(reach, 0, (size_t)ny * (size_t)L);
    const uint64_t *g = e->params.ground, *only = e->params.ground_only;
#define GBIT(set, l) (((set)[(l) >> 6] >> ((l) & 63)) & 1)
    for (int y = ny - 1; y >= 0; y--)
        for (int l = 1; l < L; l++) {
            if (!gs_model_rules_count(e->rules, l) || !gs_model_rules_allows(e->rules, 0, l, l) ||
                (y == ny - 1 ? !GBIT(g, l) : GBIT(only, l)))
                continue;
            int ok = y == ny - 1;
            for (int m = 1; m < L && !ok; m++)
                ok = reach[(size_t)(y + 1) * L + m] && gs_model_rules_allows(e->rules, 2, l, m);
            reach[(size_t)y * L + l] = (uint8_t)ok;
        }
#undef GBIT
    int prev = -1;
    gs_err err = GS_OK;
    for (int y = 0; y < ny && !err; y++) {
        int best = -1;
        for (int l = 1; l < L; l++)
            if (reach[(size_t)y * L + l] && (prev < 0 || gs_model_rules_allows(e->rules, 2, prev, l)) &&
                (best < 0 || gs_model_rules_count(e->rules, l) > gs_model_rules_count(e->rules, best)))
                best = l;
        if (best < 0)
            err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                 "model.ground: no start model: no rows of one pattern each lead "
                                 "down to a ground pattern of %s that repeats along x",
                                 e->cfg->sample);
        for (int x = 0; x < lat->nx && !err; x++)
            for (int z = 0; z < lat->nz; z++)
                lat->labels[gs_model_lattice_index(lat, x, y, z)] = (uint16_t)best;
        prev = best;
    }
    gs_free(reach);
    return err;
}

/* The 3D overlapping model's start: a column of layer-filling patterns, its
 * bottom and top found at the example's bottom and top (the z face masks;
 * none with fix_z_faces = false). With model.fix_xy_faces it prefers the
 * commonest window column on the example's x/y faces: the ground outside
 * the fortress's walls, not the yard's ground inside them (the commonest
 * layer-filling windows; as the output's surroundings they let an output
 * be one yard's inside with keeps and no wall: fortress seeds 1 and 4). */
static gs_err overlap3d_start(model_engine *e, gs_model_lattice *out)
{
    const size_t W = ((size_t)gs_model_rules_nlabels(e->rules) + 63) / 64;
    const uint64_t *bottom = e->zface, *top = e->zface ? e->zface + W : NULL;
    if (!e->cfg->fix_xy_faces)
        return gs_model_initial_faces(e->rules, &e->example, NULL, bottom, top, out);
    uint16_t *prefer = NULL;
    GS_CALL(gs_alloc_array((void **)&prefer, (size_t)gs_model_frame_nz(&e->example),
                           sizeof *prefer, "face column"));
    gs_err err = gs_model_commonest_column(&e->example, 1, prefer);
    if (!err)
        err = gs_model_initial_prefer(e->rules, &e->example, NULL, prefer, bottom, top, out);
    gs_free(prefer);
    return err;
}

/* Start model on every rank (deterministic, so no broadcast). */
static gs_err build_start(model_engine *e)
{
    const model_config *c = e->cfg;
    if (c->ground && !c->start[0])
        return ground_start(e);
    if (c->start[0]) {
        memcpy(e->lat.labels, e->start.labels, lattice_cells(&e->lat) * sizeof(uint16_t));
        size_t nv = gs_model_rules_violations(e->rules, &e->lat);
        GS_CHECK(nv == 0, GS_ERR_ARG,
                 "model.start = %s: %zu adjacent pairs never occur in the example %s; the start "
                 "model must be consistent (check it with geosynth model-check)",
                 c->start, nv, c->example);
        return GS_OK;
    }
    if (c->start_column[0]) {
        uint16_t *col = NULL;
        GS_CALL(gs_alloc_array((void **)&col, (size_t)e->lat.nz, sizeof *col, "start column"));
        char why[160];
        (void)model_parse_column(c->start_column, col, e->lat.nz, why, sizeof why);
        gs_err err = gs_model_initial(e->rules, &e->example, col, &e->lat);
        gs_free(col);
        if (err)
            gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    if (c->overlap3d > 0) {
        gs_err err = overlap3d_start(e, &e->lat);
        if (err)
            gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    if (c->start_block > 0) {
        int tiled = 0;
        GS_CALL(gs_model_initial_tiled(e->rules, &e->example, &e->params, (int)c->start_block,
                                       &e->lat, &tiled));
        gs_log(GS_LOG_INFO, "start model: %s", tiled ? "periodic tile repeated"
                                                     : "tile failed, one column repeated");
        GS_CHECK(!(e->params.periodic[0] || e->params.periodic[1]) ||
                     gs_model_rules_violations_wrap(e->rules, &e->lat, e->params.periodic) == 0,
                 GS_ERR_ARG, "model.start_block = %lld must divide the periodic output extents",
                 (long long)c->start_block);
        return GS_OK;
    }
    if (e->start_commonest) {
        uint16_t *col = NULL;
        GS_CALL(gs_alloc_array((void **)&col, (size_t)gs_model_frame_nz(&e->example), sizeof *col,
                               "commonest column"));
        gs_err err = gs_model_commonest_column(&e->example, e->start_commonest == 2, col);
        if (!err)
            err = gs_model_initial_prefer(e->rules, &e->example, NULL, col, NULL, NULL, &e->lat);
        if (!err) {
            char txt[256];
            size_t n = 0;
            for (int z = 0; z < e->lat.nz && n + 8 < sizeof txt; z++)
                n += (size_t)snprintf(txt + n, sizeof txt - n, "%s%u", z ? " " : "",
                                      (unsigned)e->lat.labels[gs_model_lattice_index(&e->lat, 0, 0, z)]);
            gs_log(GS_LOG_INFO, "start model: column %s (preferring the example's commonest "
                   "column%s, model.start_column_from)", txt,
                   e->start_commonest == 2 ? " on its x/y faces" : "");
        }
        gs_free(col);
        if (err)
            gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    return gs_model_initial(e->rules, &e->example, NULL, &e->lat);
}

void model_engine_free(model_engine *e)
{
    gs_model_lattice_destroy(&e->example);
    gs_model_lattice_destroy(&e->lat);
    gs_model_lattice_destroy(&e->start);
    gs_model_rules_destroy(&e->rules);
    gs_model_resem_destroy(&e->resem);
    gs_model_tileset_destroy(&e->ts);
    gs_model_patterns_destroy(&e->pats);
    gs_model_patterns3d_destroy(&e->p3);
    gs_model_lattice_destroy(&e->src);
    gs_model_lattice_destroy(&e->plat);
    gs_model_solver_destroy(&e->solver);
    gs_free(e->coverage);
    gs_free(e->rec);
    gs_free(e->pins);
    gs_free(e->shape);
    gs_free(e->structure);
    gs_free(e->repair_empty);
    gs_free(e->keep_keys);
    gs_free(e->rotate_map);
    gs_free(e->mirror_map[0]);
    gs_free(e->mirror_map[1]);
    gs_free(e->ground);
    gs_free(e->zface);
    gs_free(e->xyface);
    gs_free(e->outside_col);
    gs_free(e->buf);
    gs_free(e->plan);
    gs_free(e->open_owner);
    gs_free(e->open_seen);
    gs_free(e->open_queue);
    gs_free(e->region_status);
    gs_free(e->region_attempts);
}

/* Label symmetry S of each mirrored axis (given pairs or learned), the rules
 * restricted to S-symmetric pairs (paper Sec. 4.1: T' = S.T). */
static gs_err mirror_setup(model_engine *e)
{
    const model_config *c = e->cfg;
    const int L = gs_model_rules_nlabels(e->rules);
    const int *maps[3] = {NULL, NULL, NULL};
    for (int a = 0; a < 2; a++) {
        if (!e->params.mirror[a])
            continue;
        GS_CALL(gs_alloc_array((void **)&e->mirror_map[a], (size_t)L, sizeof(int), "label symmetry"));
        int *S = e->mirror_map[a];
        const char *pairs = a ? c->mirror_y_pairs : c->mirror_x_pairs;
        int exact = 1;
        if (pairs[0])
            GS_CALL(gs_model_rules_mirror_pairs(e->rules, a ? "model.mirror_y_pairs"
                                                            : "model.mirror_x_pairs",
                                                pairs, S));
        else
            GS_CALL(gs_model_rules_learn_mirror(e->rules, a, S, &exact));
        int moved = 0, lost = 0, present = 0;
        char list[512] = "";
        size_t len = 0;
        for (int l = 0; l < L; l++) {
            if (!gs_model_rules_count(e->rules, l))
                continue;
            present++;
            lost += S[l] < 0;
            if (S[l] > l) {
                moved += 2;
                if (len + 16 < sizeof list)
                    len += (size_t)snprintf(list + len, sizeof list - len, "%s%d<->%d",
                                            len ? " " : "", l, S[l]);
            }
        }
        gs_log(GS_LOG_INFO,
               "mirror %c: label symmetry S %s%s: %d of %d labels change (%s), %d fixed, %d "
               "without an image",
               "xy"[a], pairs[0] ? "from the config" : "learned from the example",
               exact ? "" : " (no exact involution: greedy)", moved, present, len ? list : "none",
               present - moved - lost, lost);
        maps[a] = S;
        e->params.mirror_map[a] = S;
    }
    if (e->mirror_map[0] && e->mirror_map[1]) {
        /* both mirrors: the corner quarter holds Sx(Sy l), which needs Sx Sy = Sy Sx */
        int *Sx = e->mirror_map[0], *Sy = e->mirror_map[1], bad = 0;
        for (int l = 0; l < L; l++)
            if (Sx[l] >= 0 && Sy[l] >= 0 && (Sy[Sx[l]] < 0 || Sx[Sy[l]] < 0 ||
                                              Sx[Sy[l]] != Sy[Sx[l]])) {
                Sx[l] = Sy[l] = -1;
                bad++;
            }
        if (bad)
            gs_log(GS_LOG_WARN, "mirror xy: %d labels whose x and y images do not commute left out",
                   bad);
    }
    size_t dropped = 0;
    GS_CALL(gs_model_rules_symmetrize(e->rules, e->params.mirror, maps, &dropped));
    gs_log(GS_LOG_INFO, "mirror: %zu transition pairs without an allowed mirror image removed",
           dropped);
    return GS_OK;
}

/* model.rotate = 90: R = Sx . Sdiag, both learned like the mirrors; a label
 * whose orbit under R does not close after 4 turns (or meets a label without
 * an image) gets none and leaves the model. */
static gs_err rotation_setup(model_engine *e)
{
    const int L = gs_model_rules_nlabels(e->rules);
    int *Sx = NULL, *Sd = NULL;
    gs_err err = GS_OK;
    GS_CALL(gs_alloc_array((void **)&e->rotate_map, (size_t)L, sizeof(int), "label rotation"));
    GS_TRY(err, gs_alloc_array((void **)&Sx, (size_t)L, sizeof(int), "label symmetry"), done);
    GS_TRY(err, gs_alloc_array((void **)&Sd, (size_t)L, sizeof(int), "label symmetry"), done);
    int ex = 1, ed = 1;
    GS_TRY(err, gs_model_rules_learn_mirror(e->rules, 0, Sx, &ex), done);
    GS_TRY(err, gs_model_rules_learn_mirror(e->rules, 3, Sd, &ed), done);
    if (!ed) { /* not exactly symmetric: the involution keeping most pairs */
        size_t kept = 0, total = 0;
        GS_TRY(err, gs_model_rules_learn_mirror_near(e->rules, &e->example, 3, Sd, &kept, &total),
               done);
        gs_log(GS_LOG_INFO, "rotate 90: no exact diagonal mirror in the example; the nearest keeps "
               "%zu of %zu pairs", kept, total);
    }
    int *R = e->rotate_map;
    for (int l = 0; l < L; l++)
        R[l] = Sd[l] >= 0 ? Sx[Sd[l]] : -1;
    int moved = 0, lost = 0, present = 0, fixed = 0;
    for (int l = 0; l < L; l++) {
        if (!gs_model_rules_count(e->rules, l))
            continue;
        int k = l, n = 0;
        while (n < 4 && k >= 0) {
            k = R[k];
            n++;
        }
        if (k != l) /* no closed orbit within four turns */
            R[l] = -1;
    }
    for (int l = 0; l < L; l++) {
        if (!gs_model_rules_count(e->rules, l))
            continue;
        present++;
        lost += R[l] < 0;
        moved += R[l] >= 0 && R[l] != l;
        fixed += R[l] == l;
    }
    size_t dropped = 0;
    GS_TRY(err, gs_model_rules_rotation(e->rules, R, &dropped), done);
    e->params.rotate_map = R;
    gs_log(GS_LOG_INFO,
           "rotate 90: label rotation R = Sx.Sdiag learned from the example%s: %d of %d labels "
           "turn into another, %d are their own image, %d without an image; %zu transition pairs "
           "without an allowed turned image removed",
           ex && ed ? "" : " (no exact involution: greedy)", moved, present, fixed, lost, dropped);
done:
    gs_free(Sx);
    gs_free(Sd);
    return err;
}

/* model.ground: label sets of the bottom row and of the patterns banned above
 * it (pattern i = label i + 1). */
static gs_err ground_setup(model_engine *e)
{
    const int L = gs_model_rules_nlabels(e->rules), W = (L + 63) / 64;
    GS_CALL(gs_alloc_array((void **)&e->ground, 2 * (size_t)W, 8, "ground patterns"));
    memset(e->ground, 0, 2 * (size_t)W * 8);
    int ng = 0, only = 0;
    for (int i = 0; i < e->pats.npatterns && i + 1 < L; i++) {
        if (!e->pats.bottom[i])
            continue;
        int l = i + 1;
        e->ground[l >> 6] |= (uint64_t)1 << (l & 63);
        ng++;
        if (e->pats.bottom[i] == e->pats.count[i]) {
            e->ground[W + (l >> 6)] |= (uint64_t)1 << (l & 63);
            only++;
        }
    }
    GS_CHECK(ng > 0, GS_ERR_ARG, "model.ground: %s has no pattern on its bottom row",
             e->cfg->sample);
    gs_log(GS_LOG_INFO, "ground: %d patterns of the sample's bottom row for the output's bottom "
           "row, %d of them found only there (banned above)", ng, only);
    e->params.ground = e->ground;
    e->params.ground_only = e->ground + W;
    return GS_OK;
}

/* model.fix_z_faces = auto (from the config and the example alone, so a
 * resumed run decides the same): an example lattice whose bottom layer holds
 * more than one label (a terrain of stone and dirt, a village's grass and
 * roads) gets its z faces synthesized, each limited to the labels of the
 * example's own face layer: fixing the bottom to the start model's one label
 * holds everything built on it to the start column (terrain3: flat, 2 of 4
 * labels; the village: no roads). A top layer of several labels alone (the
 * mountain reaches its example's ceiling) keeps the faces fixed: synthesizing
 * it there raised completeness 0.69 -> 0.93 but lowered the 3x3x3 share
 * 0.49 -> 0.45 and let peaks climb to z = 9 (example 6). */
static gs_err decide_z_faces(model_engine *e)
{
    const model_config *c = e->cfg;
    const gs_model_lattice *ex = &e->example;
    const int fours = ex->frames > 1, exfz = gs_model_frame_nz(ex);
    if (fours)
        e->params.fix_z_faces = 0; /* fixed faces would be the lattice's, not each frame's */
    const int o3 = c->overlap3d > 0; /* (fix_z_faces = true is refused with it) */
    if (strcmp(c->fix_z_faces, "auto") || c->tileset[0] || c->sample[0] ||
        strchr(c->periodic, 'z') || c->size[2] < 3 || exfz < 2)
        return GS_OK;
    const int L = gs_model_rules_nlabels(e->rules);
    const size_t W = ((size_t)L + 63) / 64, layer = (size_t)ex->nx * (size_t)ex->ny;
    GS_CALL(gs_alloc_array((void **)&e->zface, 2 * W, 8, "z face labels"));
    memset(e->zface, 0, 2 * W * 8);
    int distinct[2] = {0, 0};
    for (int f = 0; f < 2; f++)
        for (int t = 0; t < (fours ? ex->frames : 1); t++) {
            /* 4D: the bottom / top layer of every frame */
            const uint16_t *lab = ex->labels + (size_t)(t * exfz + (f ? exfz - 1 : 0)) * layer;
            uint64_t *m = e->zface + (size_t)f * W;
            for (size_t i = 0; i < layer; i++) {
                uint64_t bit = (uint64_t)1 << (lab[i] & 63);
                if (!(m[lab[i] >> 6] & bit))
                    distinct[f]++;
                m[lab[i] >> 6] |= bit;
            }
        }
    /* overlap3d: ex is the lattice of the example's windows, so the bottom
     * takes the windows at the example's z = 0 and the top those whose top
     * slice is the example's top layer (the output decodes the top patterns'
     * upper slices too: gs_model_patterns3d_decode) */
    /* 4D frames cannot keep fixed faces (only the lattice's lowest and
     * highest layers would stay): each frame's faces take the example's */
    /* overlap3d: one bottom pattern is a mask all the same (kept faces would
     * be the start column's, which need not be it) */
    if (distinct[0] == 1 && !fours && !o3) {
        gs_free(e->zface);
        e->zface = NULL;
        return GS_OK;
    }
    e->params.fix_z_faces = 0;
    e->params.zface[0] = e->zface;
    e->params.zface[1] = e->zface + W;
    gs_log(GS_LOG_INFO,
           "z faces synthesized (model.fix_z_faces = auto): the example's bottom layer holds %d "
           "labels, its top layer %d; each output face takes only those",
           distinct[0], distinct[1]);
    return GS_OK;
}

/* model.fix_xy_faces: the labels on each x/y face of the example (overlap3d:
 * of its window lattice, so the windows lying at that face), one mask per
 * face (x = 0, x = nx - 1, y = 0, y = ny - 1); the solver limits the output's
 * face cells to them. Merrell's start model is ground and empty up to the
 * output's sides; with free sides the choice never sees that a wall run must
 * turn before it reaches them, so walls cross the sides and no ring closes
 * (the fortress of scripts/gen-lattice.py: configs/model/DEFAULTS.md). */
static gs_err decide_xy_faces(model_engine *e)
{
    const model_config *c = e->cfg;
    if (!c->fix_xy_faces || c->overlap3d > 0)
        return GS_OK; /* overlap3d: outside_xy_faces, once the lattice exists */
    const gs_model_lattice *ex = &e->example;
    const int L = gs_model_rules_nlabels(e->rules);
    const size_t W = ((size_t)L + 63) / 64;
    GS_CALL(gs_alloc_array((void **)&e->xyface, 4 * W, 8, "x/y face labels"));
    memset(e->xyface, 0, 4 * W * 8);
    int distinct[4] = {0, 0, 0, 0};
    for (int z = 0; z < ex->nz * (ex->frames > 1 ? ex->frames : 1); z++)
        for (int y = 0; y < ex->ny; y++)
            for (int x = 0; x < ex->nx; x++) {
                const int on[4] = {x == 0, x == ex->nx - 1, y == 0, y == ex->ny - 1};
                const uint16_t l = ex->labels[(size_t)x + (size_t)ex->nx * ((size_t)y +
                                              (size_t)ex->ny * (size_t)z)];
                for (int f = 0; f < 4; f++) {
                    uint64_t *m = e->xyface + (size_t)f * W, bit = (uint64_t)1 << (l & 63);
                    if (on[f] && (size_t)(l >> 6) < W && !(m[l >> 6] & bit)) {
                        m[l >> 6] |= bit;
                        distinct[f]++;
                    }
                }
            }
    for (int f = 0; f < 4; f++)
        e->params.xyface[f] = e->xyface + (size_t)f * W;
    gs_log(GS_LOG_INFO,
           "x/y faces limited to the example's own (model.fix_xy_faces): %d / %d / %d / %d %s "
           "on its x = 0 / x = max / y = 0 / y = max faces",
           distinct[0], distinct[1], distinct[2], distinct[3],
           c->overlap3d > 0 ? "windows" : "labels");
    return GS_OK;
}

/* model.fix_xy_faces with the 3D overlapping model: the output lies inside
 * Merrell's trivial start model, the start column (the same on every rank and
 * after a restart: built again here) taken to continue past its x/y faces, so
 * a face cell's window must overlap the start column's (ground and empty
 * within N - 1 cells of the sides) and a wall ring closes inside. The
 * example's own face windows (label mode's masks) held the fortress's walls
 * where they lie within N - 1 cells of its sides (fortress seed 1: every x = 0
 * window), forcing a wall along the whole output side, and the start
 * column's ground window lay on none of the faces: every region touching a
 * side failed at its setup (fortress-yards.ini, 32x32 regions at 96x96: 72 of
 * 122 failed). */
static gs_err outside_xy_faces(model_engine *e)
{
    if (!e->cfg->fix_xy_faces || e->cfg->overlap3d <= 0)
        return GS_OK;
    gs_model_lattice col = {0};
    GS_CALL(gs_model_lattice_create(&col, 2, 2, e->lat.nz));
    col.frames = e->lat.frames;
    gs_err err = overlap3d_start(e, &col);
    if (!err)
        err = gs_alloc_array((void **)&e->outside_col, (size_t)e->lat.nz, sizeof *e->outside_col,
                             "outside column");
    for (int z = 0; !err && z < e->lat.nz; z++)
        e->outside_col[z] = col.labels[gs_model_lattice_index(&col, 0, 0, z)];
    gs_model_lattice_destroy(&col);
    GS_CALL(err);
    e->params.outside_column = e->outside_col;
    gs_log(GS_LOG_INFO, "x/y faces (model.fix_xy_faces): the start column continues past the "
           "output's sides; face windows must overlap it");
    return GS_OK;
}

/* The start model must already keep to the face labels decide_z_faces allows. */
static gs_err check_z_faces(const model_engine *e)
{
    if (!e->zface)
        return GS_OK;
    const gs_model_lattice *l = &e->lat;
    const size_t W = ((size_t)gs_model_rules_nlabels(e->rules) + 63) / 64;
    const size_t layer = (size_t)l->nx * (size_t)l->ny;
    for (int f = 0; f < 2; f++) {
        const int z = f ? l->nz - 1 : 0;
        const uint64_t *m = e->zface + (size_t)f * W;
        for (size_t i = 0; i < layer; i++) {
            uint16_t a = l->labels[(size_t)z * layer + i];
            GS_CHECK((m[a >> 6] >> (a & 63)) & 1, GS_ERR_ARG,
                     "model.fix_z_faces = auto: the start model's %s layer (z = %d) holds label %u, "
                     "which the example's %s layer lacks; give model.start_column or set "
                     "model.fix_z_faces = true or false",
                     f ? "top" : "bottom", z, a, f ? "top" : "bottom");
        }
    }
    return GS_OK;
}

gs_err model_setup(gs_run *run, model_engine *e, int resume)
{
    const model_config *c = e->cfg;
    GS_CALL(engine_params(c, &e->params));
    GS_CALL(load_inputs(run, e));
    const int frames = (int)c->frames, exframes = e->example.frames > 1 ? e->example.frames : 1;
    GS_CHECK(frames > 1 ? exframes > 1 : exframes == 1, GS_ERR_ARG,
             frames > 1 ? "model.frames = %d: the example %s has no frames (a 4D example is a "
                          "Merrell .txt whose extents line reads 'X Y Z T', or an .h5 dataset "
                          "[T, Z, Y, X])"
                        : "model.frames = %d: the example %s has %d frames: set model.frames > 1 "
                          "for a 4D output",
             frames, c->example, exframes);
    if (!e->rules)
        GS_CALL(gs_model_rules_learn(&e->example, &e->rules));
    GS_CALL(decide_z_faces(e));
    GS_CALL(decide_xy_faces(e));
    const int zsynth = !e->params.fix_z_faces && frames == 1 && c->overlap3d == 0 &&
                       !c->tileset[0] && !c->sample[0] && !strchr(c->periodic, 'z') &&
                       c->resemblance > 0;
    /* model.passes = auto, model.sweep_keep = auto: with synthesized z faces a
     * second sweep on the grid shifted by a quarter region, each rebuilt region
     * kept only if no further from the example (configs/model/DEFAULTS.md,
     * `passes = -1`): it takes the first sweep's last-decided lines (the
     * terrains' ridges) inside a region */
    const char *keep_auto = zsynth ? KEEP_AUTO_NAMES : c->open_blocks > 0 ? "mix" : "none";
    GS_CALL(model_parse_sweep_keep(!strcmp(c->sweep_keep, "auto") ? keep_auto : c->sweep_keep,
                                   c->open_blocks > 0, &e->keep_tests));
    /* auto with broad raised land in the example (a terrain's domes; not a
     * village's houses or a fortress's walls): land too (configs/model/DEFAULTS.md,
     * `sweep_keep = auto`'s land test) */
    double land_interior = 0;
    if (zsynth && !strcmp(c->sweep_keep, "auto")) {
        const gs_model_lattice *ex = &e->example;
        const int dims[3] = {ex->nx, ex->ny, ex->nz};
        GS_CALL(gs_measure_land_interior(ex->labels, dims, &land_interior));
        if (land_interior >= KEEP_LAND_INTERIOR)
            e->keep_tests |= KEEP_LAND;
    }
    if (c->passes < 0 && zsynth) {
        e->params.min_changes = 2;
        e->params.max_passes = 2;
    }
    if (zsynth && (c->passes < 0 || !strcmp(c->sweep_keep, "auto")))
        gs_log(GS_LOG_INFO, "z faces synthesized: %d sweeps (model.passes = %s), later sweeps keep "
               "a rebuilt region only if no further from the example by: %s (model.sweep_keep = %s)",
               e->params.min_changes, c->passes < 0 ? "auto" : "set",
               !strcmp(c->sweep_keep, "auto")
                   ? (e->keep_tests & KEEP_LAND ? KEEP_AUTO_NAMES ",land" : KEEP_AUTO_NAMES)
                   : c->sweep_keep,
               c->sweep_keep);
    if (e->keep_tests & KEEP_LAND && !strcmp(c->sweep_keep, "auto"))
        gs_log(GS_LOG_INFO, "the example's raised land is broad (interior %.2f >= %.2f): "
               "model.sweep_keep = auto adds land", land_interior, KEEP_LAND_INTERIOR);
    if (!strcmp(c->order, "auto") && zsynth) {
        /* synthesized z faces: grow each region in from its decided shell, ring
         * by ring, each ring's columns from the ground up (configs/model/DEFAULTS.md,
         * `order = auto`) */
        e->params.order = GS_MODEL_ORDER_ENTROPY_COLUMNS;
        gs_log(GS_LOG_INFO, "cell order: entropy_columns (model.order = auto, z faces synthesized)");
    }
    /* model.resemblance_outside = auto: half a match with synthesized z faces
     * (examples whose relief reaches their x/y faces: configs/model/DEFAULTS.md,
     * `resemblance_outside = auto`), else a mismatch (every Merrell lattice) */
    e->outside = !strcmp(c->resemblance_outside, "mismatch") ? 0
                 : !strcmp(c->resemblance_outside, "half")   ? 1
                 : !strcmp(c->resemblance_outside, "match")  ? 2
                 : !strcmp(c->resemblance_outside, "background") ? 3
                 : !strcmp(c->resemblance_outside, "wrap")   ? 0 /* the example as a tile: past
                                                                  its z faces a mismatch */
                 : zsynth ? 1 : 0;
    /* model.frequency_weight = -1 (auto): 2 with synthesized z faces (the
     * layers' label shares keep the relief: configs/model/DEFAULTS.md), else 0 */
    e->freq_beta = c->frequency_weight >= 0 ? c->frequency_weight : zsynth ? 2.0 : 0.0;
    /* model.start_column_from = auto: the example's commonest column with
     * synthesized z faces (a corner hill would leave a plateau that the
     * regions only wear down: configs/model/DEFAULTS.md), else its corner */
    e->start_commonest = !strcmp(c->start_column_from, "commonest") ? 1
                         : !strcmp(c->start_column_from, "faces") ||
                                 (!strcmp(c->start_column_from, "auto") && zsynth)
                             ? 2
                             : 0;
    if (c->resemblance > 0 && !c->tileset[0] && !c->sample[0] &&
        (!strcmp(c->resemblance_outside, "auto") || c->frequency_weight < 0))
        gs_log(GS_LOG_INFO, "%s: resemblance outside the example's faces %s%s, "
               "frequency weight %g%s",
               zsynth ? "3D output, z faces synthesized" : "z faces fixed or not a 3D output",
               e->outside == 0 ? "mismatch" : e->outside == 1 ? "half" : e->outside == 2 ? "match" : "background",
               strcmp(c->resemblance_outside, "auto") ? "" : " (model.resemblance_outside = auto)",
               e->freq_beta, c->frequency_weight < 0 ? " (model.frequency_weight = auto)" : "");
    int L = gs_model_rules_nlabels(e->rules), present = 0;
    for (int l = 0; l < L; l++)
        present += gs_model_rules_count(e->rules, l) > 0;
    size_t cells = (size_t)c->size[0] * (size_t)c->size[1] * (size_t)c->size[2] * (size_t)frames;
    size_t rcells = 1;
    for (int a = 0; a < 3; a++) {
        int64_t ext = c->size[a];
        int64_t edge = c->region[a] <= 0 || c->region[a] >= ext ? ext : c->region[a];
        if (a < 2 && edge < ext) /* model.region_jitter: edges up to edge + J */
            edge = edge + c->region_jitter < ext ? edge + c->region_jitter : ext;
        rcells *= (size_t)edge;
    }
    size_t W = ((size_t)L + 63) / 64;
    rcells *= (size_t)frames; /* 4D: a region spans every frame */
    double mem = (double)cells * 4 + (double)rcells * (double)(W * 8 + 48 + 2) +
                 8.0 * L * (double)W * 8 + (e->params.ac == GS_MODEL_AC4 ? 16.0 * L * rcells : 0);
    if (c->tileset[0] && e->ts.dim == 3)
        gs_log(GS_LOG_INFO,
               "tile set %s: %d tiles in %d orientations under %d symmetries, %zu allowed pairs, "
               "tiles %dx%dx%d voxels%s%s",
               c->tileset, e->ts.nbase, e->ts.ntiles, e->ts.group, e->ts.npairs, e->ts.vx,
               e->ts.vy, e->ts.vz, e->ts.ground ? ", ground" : "",
               e->ts.border || e->ts.nfixed ? ", border/fixed-tile constraints" : "");
    else if (c->tileset[0])
        gs_log(GS_LOG_INFO, "tile set %s%s%s: %d oriented tiles, %zu allowed pairs, tiles %dx%d px",
               c->tileset, c->subset[0] ? " subset " : "", c->subset, e->ts.ntiles, e->ts.npairs,
               e->ts.tile_w, e->ts.tile_h);
    if (c->sample[0])
        gs_log(GS_LOG_INFO, "sample %s: %d colours, %d patterns of %dx%d (symmetry %lld), %zu allowed pairs",
               c->sample, e->pats.ncolors, e->pats.npatterns, e->pats.n, e->pats.n,
               (long long)c->symmetry, e->pats.npairs);
    const gs_model_lattice *exl = c->overlap3d > 0 ? &e->src : &e->example;
    gs_log(GS_LOG_INFO, "example %s: %dx%dx%d, %d %s present (largest %d)%s", c->example,
           exl->nx, exl->ny, exl->nz, present, c->overlap3d > 0 ? "patterns" : "labels", L - 1,
           e->pal.from_file ? ", palette from the file" : "");
    gs_log(GS_LOG_INFO,
           "output %lldx%lldx%lld (%zu cells), region %lldx%lldx%lld (0 = whole axis), overlap "
           "%lld, passes %lld (max %lld), attempts %lld, backtracks %lld, order %s, weights "
           "%s, %s",
           (long long)c->size[0], (long long)c->size[1], (long long)c->size[2], cells,
           (long long)c->region[0], (long long)c->region[1], (long long)c->region[2],
           (long long)c->overlap, (long long)e->params.min_changes, (long long)e->params.max_passes,
           (long long)c->attempts, (long long)c->backtracks, c->order, c->weights, c->ac);
    gs_log(GS_LOG_INFO, "memory estimate per rank: %.1f MiB (lattice + coverage, solver, rules)",
           mem / 1048576.0);
    GS_CALL(gs_run_check_memory(run, mem, "model.size or model.region"));
    int dims[3] = {(int)c->size[0], (int)c->size[1], (int)c->size[2]};
    for (int a = 0; a < 3; a++) {
        e->full[a] = dims[a];
        if (a < 2 && strchr(c->mirror, "xy"[a])) {
            e->params.mirror[a] = 1;
            e->params.mirror_odd[a] = dims[a] & 1;
            dims[a] = (dims[a] + 1) / 2;
        }
    }
    dims[2] *= frames; /* 4D: the frames stacked along z */
    e->full[2] = dims[2];
    if (c->overlap3d > 0 && !e->params.periodic[2])
        dims[2] -= (int)c->overlap3d - 1; /* the top N - 1 layers: the last patterns' upper
                                             slices (gs_model_patterns3d_decode) */
    if (!strcmp(c->rotate, "90")) { /* the lower-left quarter */
        dims[0] /= 2;
        dims[1] /= 2;
        GS_CALL(rotation_setup(e));
    }
    if (e->params.mirror[0] || e->params.mirror[1])
        GS_CALL(mirror_setup(e));
    if (c->ground)
        GS_CALL(ground_setup(e));
    if (c->resemblance > 0 && !c->tileset[0] && !c->sample[0]) {
        GS_CALL(gs_model_resem_build_wrap(&e->example, (int)c->resemblance,
                                          (int)c->resemblance_slack, c->resemblance_layers,
                                          !strcmp(c->resemblance_outside, "wrap"), &e->resem));
        gs_model_resem_set_outside(e->resem, e->outside);
        GS_CALL(gs_model_resem_set_frequency(e->resem, &e->example, e->freq_beta));
        e->params.resem = e->resem;
        gs_log(GS_LOG_INFO, "resemblance: %d distinct %dx%dx%d example neighbourhoods, slack %lld%s",
               gs_model_resem_patterns(e->resem), 2 * (int)c->resemblance + 1,
               2 * (int)c->resemblance + 1, 2 * (int)c->resemblance + 1,
               (long long)c->resemblance_slack,
               strcmp(c->resemblance_outside, "wrap") ? ""
                                                      : ", the example taken as a tile along x and y "
                                                        "(model.resemblance_outside = wrap)");
    }
    if (!c->overlap3d && !c->tileset[0] && !c->sample[0] && frames == 1 && !e->params.periodic[2])
        GS_CALL(repair_setup(e));
    GS_CALL(gs_model_lattice_create(&e->lat, dims[0], dims[1], dims[2]));
    e->lat.frames = frames;
    if (frames > 1)
        gs_log(GS_LOG_INFO, "4D: %d frames of %lldx%lldx%lld from the example's %d frames of "
               "%dx%dx%d (transitions along time learned from consecutive frames)",
               frames, (long long)c->size[0], (long long)c->size[1], (long long)c->size[2],
               exframes, e->example.nx, e->example.ny, gs_model_frame_nz(&e->example));
    if (c->shape[0]) {
        gs_image img = {0};
        float *grey = NULL;
        GS_CALL(gs_image_read(c->shape, &img));
        gs_err err = gs_image_to_gray(&img, &grey);
        int iw = img.width, ih = img.height;
        gs_image_destroy(&img);
        GS_CALL(err);
        err = gs_alloc_array((void **)&e->shape, (size_t)dims[0] * (size_t)dims[1],
                             sizeof *e->shape, "target shape");
        if (err) {
            gs_free(grey);
            return err;
        }
        for (int y = 0; y < dims[1]; y++)
            for (int x = 0; x < dims[0]; x++) {
                int ix = (int)(((int64_t)x * iw) / dims[0]);
                int iy = ih - 1 - (int)(((int64_t)y * ih) / dims[1]);
                e->shape[(size_t)x + (size_t)dims[0] * (size_t)y] = grey[(size_t)iy * iw + ix];
            }
        gs_free(grey);
        e->params.shape = e->shape;
        e->params.shape_weight = c->shape_weight;
        e->params.shape_mh = c->shape_mh;
        e->params.shape_slack = (int)c->shape_slack;
        const int nl = gs_model_rules_nlabels(e->rules);
        GS_CALL(gs_alloc_array((void **)&e->structure, (size_t)nl, 1, "structure labels"));
        GS_CALL(gs_model_structure_labels(&e->example, nl, e->structure, &e->nstructure_labels));
        GS_CHECK(e->nstructure_labels > 0, GS_ERR_ARG,
                 "model.shape: the example %s has no structure label (a label other than "
                 "empty, its top layer's commonest, and ground, the labels below the first "
                 "layer holding empty, stacked on or under another such label)",
                 c->example);
        e->params.structure = e->structure;
        gs_log(GS_LOG_INFO, "shape: %d structure labels of %d (stacked, neither empty nor "
               "ground); choice weight %g, Metropolis b %g", e->nstructure_labels, nl,
               c->shape_weight, c->shape_mh);
    }
    if (c->pins[0] || c->border[0]) {
        GS_CALL(gs_alloc_array((void **)&e->pins, cells, sizeof *e->pins, "pins"));
        for (size_t i = 0; i < cells; i++)
            e->pins[i] = GS_MODEL_FREE;
        int fix = e->params.fix_z_faces && dims[2] >= 3;
        uint16_t border[4096];
        char bwhy[160];
        GS_CHECK(!c->border[0] || (dims[2] <= 4096 &&
                                   model_parse_column(c->border, border, dims[2], bwhy, sizeof bwhy) ==
                                       dims[2]),
                 GS_ERR_ARG, "model.border: expected %d labels (at most 4096 layers)", dims[2]);
        for (int z = fix; c->border[0] && z < dims[2] - fix; z++)
            for (int y = 0; y < dims[1]; y++)
                for (int x = 0; x < dims[0]; x++)
                    if (x == 0 || y == 0 || x == dims[0] - 1 || y == dims[1] - 1)
                        e->pins[gs_model_lattice_index(&e->lat, x, y, z)] = border[z];
        char why[200];
        GS_CHECK(model_parse_pins(c->pins, c->size, e->pins, why, sizeof why) >= 0, GS_ERR_ARG,
                 "model.pins: %s", why);
        for (size_t i = 0; i < cells; i++)
            GS_CHECK(e->pins[i] == GS_MODEL_FREE || gs_model_rules_count(e->rules, e->pins[i]) > 0,
                     GS_ERR_ARG, "model.pins/model.border: label %u does not occur in the example %s",
                     e->pins[i], c->example);
        e->params.pins = e->pins;
    }
    if (c->border_tile[0]) {
        char want[80];
        snprintf(want, sizeof want, "%s%s", c->border_tile, strchr(c->border_tile, ' ') ? "" : " 0");
        int l = 0;
        for (int t = 0; t < e->ts.ntiles && !l; t++)
            if (!strcmp(e->ts.names[t], want))
                l = t + 1;
        GS_CHECK(l > 0 && e->ts.dim == 3, GS_ERR_ARG, "model.border_tile = %s: %s", c->border_tile,
                 e->ts.dim != 3 ? "only voxel (3D) tile sets take a border tile"
                                : "no such tile in the tile set");
        e->ts.border = l;
        e->ts.border_sides = 63u;
    }
    if (e->ts.border || e->ts.nfixed || (e->ts.ground && !e->params.fix_z_faces)) {
        if (!e->pins) {
            GS_CALL(gs_alloc_array((void **)&e->pins, cells, sizeof *e->pins, "pins"));
            for (size_t i = 0; i < cells; i++)
                e->pins[i] = GS_MODEL_FREE;
        }
        GS_CALL(gs_model_tileset_pins(&e->ts, c->tileset, dims, e->params.fix_z_faces, e->pins));
        e->params.pins = e->pins;
    }
    GS_CALL(gs_alloc_array((void **)&e->coverage, cells, sizeof *e->coverage, "coverage"));
    memset(e->coverage, 0, cells * sizeof *e->coverage);
    GS_CALL(gs_model_solver_create(e->rules, e->params.ac, &e->solver));
    if (!resume) { /* a resumed run's lattice comes from the checkpoint (model_restore) */
        GS_CALL(build_start(e));
        GS_CALL(check_z_faces(e));
    }
    GS_CALL(outside_xy_faces(e));
    return GS_OK;
}
