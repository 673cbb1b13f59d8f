/* model driver, the sweep: each pass's plan of regions, a region run and
 * applied through gs_regions (one dataflow over the colours of a window),
 * coverage, the advance by a window of colours, and the per-rank time
 * report. See engine.c for why the result is identical at any rank count. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/log.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "model/engine_impl.h"
#include "model/model_impl.h"

gs_err model_parse_sweep_keep(const char *s, int open_blocks, int *tests)
{
    static const char *const name[5] = {"mix", "fill", "support", "windows", "land"};
    static const int bit[5] = {KEEP_MIX, KEEP_FILL, KEEP_SUPPORT, KEEP_WINDOWS, KEEP_LAND};
    *tests = open_blocks ? KEEP_OPEN : 0;
    if (!strcmp(s, "none"))
        return GS_OK;
    const char *p = s;
    while (*p) {
        size_t n = strcspn(p, ",");
        int found = 0;
        for (int i = 0; i < 5 && !found; i++)
            if (n == strlen(name[i]) && !strncmp(p, name[i], n)) {
                *tests |= bit[i];
                found = 1;
            }
        GS_CHECK(found && n > 0, GS_ERR_ARG,
                 "model.sweep_keep = \"%s\": expected auto, none or a comma-separated list of mix, "
                 "fill, support, windows, land",
                 s);
        p += n + (p[n] == ',');
    }
    return GS_OK;
}

/* model.sweep_keep's windows test: the example's non-empty 3x3x3 window keys */
static gs_err keep_keys_make(model_engine *e)
{
    const gs_model_lattice *ex = &e->example;
    const int ed[3] = {ex->nx, ex->ny, ex->nz}, od[3] = {e->lat.nx, e->lat.ny, e->lat.nz};
    for (int a = 0; a < 3; a++)
        e->keep_w[a] = 3 < ed[a] ? (3 < od[a] ? 3 : od[a]) : (ed[a] < od[a] ? ed[a] : od[a]);
    const size_t n = gs_measure_window_count(ed, e->keep_w);
    uint8_t *nz = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&e->keep_keys, n ? n : 1, sizeof *e->keep_keys,
                               "keep test windows"), done);
    GS_TRY(err, gs_alloc_array((void **)&nz, n ? n : 1, 1, "keep test windows"), done);
    GS_TRY(err, gs_measure_window_keys(ex->labels, ed, e->keep_w, e->keep_keys, nz), done);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (nz[i])
            e->keep_keys[m++] = e->keep_keys[i];
    e->nkeep_keys = gs_measure_keys_sort_unique(e->keep_keys, m);
done:
    gs_free(nz);
    return err;
}

gs_err model_make_plan(model_engine *e)
{
    if (e->pass > 0 && (e->keep_tests & KEEP_WINDOWS) && !e->keep_keys)
        GS_CALL(keep_keys_make(e));
    GS_FREE(e->plan);
    GS_FREE(e->region_status);
    GS_FREE(e->region_attempts);
    GS_FREE(e->rec);
    GS_CALL(gs_model_plan(&e->params, e->lat.nx, e->lat.ny, e->lat.nz, e->pass, &e->plan,
                          &e->nplan, &e->ncolors));
    if (e->pass > 0 && e->cfg->open_blocks > 0) { /* made from e->lat: see synth.c */
        const gs_model_lattice *ex = &e->example;
        const int dims[3] = {ex->nx, ex->ny, ex->nz};
        const int ground = gs_measure_ground_layer(ex->labels, dims);
        const int claim = e->cfg->open_blocks_largest > 0;
        if (claim && !e->open_owner)
            GS_CALL(gs_alloc_array((void **)&e->open_owner, (size_t)e->lat.nx * (size_t)e->lat.ny,
                                   sizeof *e->open_owner, "open blocks owners"));
        GS_CALL(gs_model_plan_open_blocks(&e->params, &e->lat, ground, (int)e->cfg->open_blocks,
                                          claim, e->plan, &e->nplan, &e->ncolors,
                                          e->open_owner));
        e->open_ground = ground;
        e->open_largest = 0;
        if (claim && ground >= 0) {
            gs_measure_layout le;
            GS_CALL(gs_measure_layout_lattice(ex->labels, dims, ground, 0, &le));
            e->open_largest = (uint64_t)floor(e->cfg->open_blocks_largest * (double)le.largest);
        }
    }
    for (size_t i = 0; i < e->nplan; i++)
        GS_CHECK(e->plan[i].id == i, GS_ERR_INTERNAL, "plan id %u at %zu", e->plan[i].id, i);
    GS_CALL(gs_alloc_array((void **)&e->region_status, e->nplan, sizeof(int32_t), "region status"));
    GS_CALL(gs_alloc_array((void **)&e->region_attempts, e->nplan, sizeof(int32_t),
                           "region attempts"));
    e->rec = gs_calloc(e->nplan ? e->nplan : 1, sizeof *e->rec);
    GS_CHECK(e->rec != NULL, GS_ERR_MEM, "out of memory for %zu region records", e->nplan);
    for (size_t i = 0; i < e->nplan; i++) {
        e->region_status[i] = -1;
        e->region_attempts[i] = 0;
    }
    /* the plan's largest box (model.region_jitter: edges vary per pass) */
    if (e->nplan && gs_model_plan_max_cells(e->plan, e->nplan) > e->buf_cells) {
        GS_FREE(e->buf);
        e->buf_cells = gs_model_plan_max_cells(e->plan, e->nplan);
        GS_CALL(gs_alloc_array((void **)&e->buf, e->buf_cells, sizeof *e->buf, "region labels"));
    }
    return GS_OK;
}

static size_t box_cells(const gs_model_box *b)
{
    return (size_t)(b->x1 - b->x0) * (size_t)(b->y1 - b->y0) * (size_t)(b->z1 - b->z0);
}

/* A later sweep's keep test (model.sweep_keep; model.open_blocks: mix): is
 * the rebuilt content of box (e->buf) further from the example than the
 * content it replaces (e->lat's)? The box's old content is settled when the
 * region runs (every region interacting with it ran before: the same at any
 * rank count). */
static uint16_t box_label(const model_engine *e, const gs_model_box *b, int old, size_t k, int x,
                          int y, int z)
{
    return old ? e->lat.labels[gs_model_lattice_index(&e->lat, x, y, z)] : e->buf[k];
}

/* mix: the L1 distance of the box's label counts per layer to the example
 * layer's shares (resemblance's layer shares), summed over its layers; fill:
 * the same of its non-empty count per layer (the height profile's measure,
 * src/measure/lattice.c). Without resemblance's layer shares, 0. */
static gs_err box_layer_dist(const model_engine *e, const gs_model_box *b, int old, int fill,
                             double *dist)
{
    const struct gs_model_resem *R = e->params.resem;
    *dist = 0;
    if (!R || !R->zshare)
        return GS_OK;
    const size_t L = (size_t)R->L;
    uint32_t *cnt = NULL;
    GS_CALL(gs_alloc_array((void **)&cnt, L, sizeof *cnt, "keep test counts"));
    double d = 0;
    size_t k = 0;
    for (int z = b->z0; z < b->z1; z++) {
        memset(cnt, 0, L * sizeof *cnt);
        size_t m = 0;
        for (int y = b->y0; y < b->y1; y++)
            for (int x = b->x0; x < b->x1; x++, k++, m++) {
                const uint16_t a = box_label(e, b, old, k, x, y, z);
                cnt[a < L ? a : 0] += a < L;
            }
        const float *t = R->zshare + (size_t)(z < R->nz ? z : R->nz - 1) * L;
        if (fill) {
            double tf = 0;
            for (size_t a = 1; a < L; a++)
                tf += (double)t[a];
            d += fabs((double)m - (double)cnt[0] - tf * (double)m);
        } else
            for (size_t a = 0; a < L; a++)
                d += fabs((double)cnt[a] - (double)t[a] * (double)m);
    }
    gs_free(cnt);
    *dist = d;
    return GS_OK;
}

/* support: the box's non-empty cells with no 6-connected path of non-empty
 * box cells to the ground layer (z = 0) or to a non-empty cell next to the
 * box (the solver's box_supported, counted). Without the repair's empty
 * labels (an example with floating structure), 0. */
static int lattice_solid(const void *ctx, int x, int y, int z)
{
    const model_engine *e = ctx;
    return !e->repair_empty[e->lat.labels[gs_model_lattice_index(&e->lat, x, y, z)]];
}

static gs_err box_floating(const model_engine *e, const gs_model_box *b, int old, size_t *nf)
{
    const uint8_t *empty = e->repair_empty;
    *nf = 0;
    if (!empty)
        return GS_OK;
    const int rx = b->x1 - b->x0, ry = b->y1 - b->y0, rz = b->z1 - b->z0;
    const size_t n = (size_t)rx * (size_t)ry * (size_t)rz;
    uint8_t *st = NULL;
    GS_CALL(gs_alloc_array((void **)&st, n ? n : 1, 1, "keep test support"));
    size_t solid = 0, k = 0;
    for (int z = 0; z < rz; z++)
        for (int y = 0; y < ry; y++)
            for (int x = 0; x < rx; x++, k++) {
                st[k] = !empty[box_label(e, b, old, k, b->x0 + x, b->y0 + y, b->z0 + z)];
                solid += st[k];
            }
    size_t reached = gs_model_box_support(st, b, &e->lat, e->params.periodic, lattice_solid, e);
    gs_free(st);
    GS_CHECK(reached != SIZE_MAX, GS_ERR_MEM, "keep test support: %zu cells", n);
    *nf = solid - reached;
    return GS_OK;
}

/* windows: the share of the non-empty 3x3x3 windows meeting the box found in
 * the example, in the box grown by 2 cells (1 with resemblance's w < 2: no
 * further than the regions it interacts with reach), clipped to the lattice */
static gs_err box_window_share(const model_engine *e, const gs_model_box *b, int old,
                               double *share)
{
    const gs_model_lattice *l = &e->lat;
    const int g = e->params.resem && e->params.resem->w >= 2 ? 2 : 1;
    int lo[3] = {b->x0 - g, b->y0 - g, b->z0 - g}, hi[3] = {b->x1 + g, b->y1 + g, b->z1 + g};
    const int ld[3] = {l->nx, l->ny, l->nz};
    int d[3];
    *share = 1;
    for (int a = 0; a < 3; a++) {
        lo[a] = lo[a] < 0 ? 0 : lo[a];
        hi[a] = hi[a] > ld[a] ? ld[a] : hi[a];
        d[a] = hi[a] - lo[a];
        if (d[a] < e->keep_w[a])
            return GS_OK;
    }
    const size_t n = (size_t)d[0] * (size_t)d[1] * (size_t)d[2];
    const size_t nw = gs_measure_window_count(d, e->keep_w);
    uint16_t *sub = NULL;
    uint64_t *keys = NULL;
    uint8_t *nz = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&sub, n, sizeof *sub, "keep test windows"), done);
    GS_TRY(err, gs_alloc_array((void **)&keys, nw ? nw : 1, sizeof *keys, "keep test windows"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&nz, nw ? nw : 1, 1, "keep test windows"), done);
    const int rx = b->x1 - b->x0, ry = b->y1 - b->y0;
    size_t i = 0;
    for (int z = lo[2]; z < hi[2]; z++)
        for (int y = lo[1]; y < hi[1]; y++)
            for (int x = lo[0]; x < hi[0]; x++, i++) {
                const int in = x >= b->x0 && x < b->x1 && y >= b->y0 && y < b->y1 &&
                               z >= b->z0 && z < b->z1;
                sub[i] = in && !old ? e->buf[(size_t)(x - b->x0) +
                                             (size_t)rx * ((size_t)(y - b->y0) +
                                                           (size_t)ry * (size_t)(z - b->z0))]
                                    : l->labels[gs_model_lattice_index(l, x, y, z)];
            }
    GS_TRY(err, gs_measure_window_keys(sub, d, e->keep_w, keys, nz), done);
    size_t ne = 0, found = 0;
    for (size_t k = 0; k < nw; k++)
        if (nz[k]) {
            ne++;
            found += (size_t)gs_measure_keys_has(e->keep_keys, e->nkeep_keys, keys[k]);
        }
    *share = ne ? (double)found / (double)ne : 1;
done:
    gs_free(sub);
    gs_free(keys);
    gs_free(nz);
    return err;
}

static gs_err sweep_keep_worse(const model_engine *e, const gs_model_box *b, int *worse)
{
    const int t = e->keep_tests;
    *worse = 0;
    for (int fill = 0; fill < 2 && !*worse; fill++)
        if (t & (fill ? KEEP_FILL : KEEP_MIX)) {
            double d_old = 0, d_new = 0;
            GS_CALL(box_layer_dist(e, b, 1, fill, &d_old));
            GS_CALL(box_layer_dist(e, b, 0, fill, &d_new));
            *worse = d_new > d_old;
        }
    if ((t & KEEP_SUPPORT) && !*worse) {
        size_t f_old = 0, f_new = 0;
        GS_CALL(box_floating(e, b, 1, &f_old));
        GS_CALL(box_floating(e, b, 0, &f_new));
        *worse = f_new > f_old;
    }
    if ((t & KEEP_WINDOWS) && !*worse) {
        double s_old = 0, s_new = 0;
        GS_CALL(box_window_share(e, b, 1, &s_old));
        GS_CALL(box_window_share(e, b, 0, &s_new));
        *worse = s_new < s_old;
        /* land: flat water's windows are always found in a terrain's example, so
         * windows alone keeps the rebuilds with less land (terrain 144, 152: too
         * little land); a rebuild closer to the example's fill passes */
        if (*worse && (t & KEEP_LAND)) {
            double d_old = 0, d_new = 0;
            GS_CALL(box_layer_dist(e, b, 1, 1, &d_old));
            GS_CALL(box_layer_dist(e, b, 0, 1, &d_new));
            *worse = d_new >= d_old;
        }
    }
    return GS_OK;
}

/* model.open_blocks_largest: does the rebuilt content of box (e->buf) make
 * or join a structure (6-connected non-empty cells from the example's ground
 * layer up, holding a cell above it: summary.json structure_max) of more
 * than e->open_largest cells? Outside the box the flood reads only the
 * columns of the structures this region meets (e->open_owner == id: no other
 * region of the pass meets them, so none writes them and the answer does
 * not depend on the order regions finish in). A region never meets another
 * kept region's box, so the flood sees every structure the pass leaves
 * through it, except ones joined through flat cover in the ground layer
 * alone (a bush beside the box: no structure column, read as empty). */
static gs_err open_block_too_large(model_engine *e, int64_t id, const gs_model_box *b,
                                   int *large)
{
    *large = 0;
    if (!e->open_largest)
        return GS_OK;
    const gs_model_lattice *l = &e->lat;
    const int nx = l->nx, ny = l->ny, nz = l->nz, g0 = e->open_ground;
    const size_t n = (size_t)nx * (size_t)ny * (size_t)nz;
    /* made once and left all 0 (the cells reached are cleared at the end):
     * a whole-lattice calloc per try was ~0.8 MB zeroed on castle-10x */
    if (!e->open_seen)
        GS_CALL(gs_alloc_array((void **)&e->open_seen, n, 1, "open blocks flood"));
    if (!e->open_queue)
        GS_CALL(gs_alloc_array((void **)&e->open_queue, n, sizeof *e->open_queue,
                               "open blocks flood"));
    uint8_t *seen = e->open_seen;
    int32_t *queue = e->open_queue;
    size_t tail = 0; /* every cell reached by this call: queue[0, tail) */
#define CELL_FULL(x, y, z)                                                                       \
    ((x) >= b->x0 && (x) < b->x1 && (y) >= b->y0 && (y) < b->y1 && (z) >= b->z0 && (z) < b->z1  \
         ? e->buf[(size_t)((x) - b->x0) +                                                        \
                  (size_t)(b->x1 - b->x0) *                                                      \
                      ((size_t)((y) - b->y0) + (size_t)(b->y1 - b->y0) * (size_t)((z) - b->z0))] \
               != 0                                                                              \
         : e->open_owner[(size_t)(y) * (size_t)nx + (size_t)(x)] == (int32_t)id &&               \
               l->labels[gs_model_lattice_index(l, (x), (y), (z))] != 0)
    for (int z0 = b->z0 > g0 ? b->z0 : g0; z0 < b->z1 && !*large; z0++)
        for (int y0 = b->y0; y0 < b->y1 && !*large; y0++)
            for (int x0 = b->x0; x0 < b->x1 && !*large; x0++) {
                const size_t c0 = gs_model_lattice_index(l, x0, y0, z0);
                if (seen[c0] || !CELL_FULL(x0, y0, z0))
                    continue;
                /* the structure of c0: breadth first (the cells reached do
                 * not depend on the order) */
                size_t head = tail;
                const size_t first = tail;
                int tall = 0;
                seen[c0] = 1;
                queue[tail++] = (int32_t)c0;
                while (head < tail) {
                    const size_t c = (size_t)queue[head++];
                    const int x = (int)(c % (size_t)nx), y = (int)(c / (size_t)nx % (size_t)ny),
                              z = (int)(c / ((size_t)nx * (size_t)ny));
                    tall |= z > g0;
                    static const int d[6][3] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                                {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
                    for (int k = 0; k < 6; k++) {
                        const int u = x + d[k][0], v = y + d[k][1], w = z + d[k][2];
                        if (u < 0 || v < 0 || w < g0 || u >= nx || v >= ny || w >= nz)
                            continue;
                        const size_t q = gs_model_lattice_index(l, u, v, w);
                        if (!seen[q] && CELL_FULL(u, v, w)) {
                            seen[q] = 1;
                            queue[tail++] = (int32_t)q;
                        }
                    }
                }
                *large = tall && tail - first > e->open_largest;
            }
#undef CELL_FULL
    for (size_t i = 0; i < tail; i++)
        seen[queue[i]] = 0;
    return GS_OK;
}

#define OPEN_BLOCK_TRIES 4

static gs_err region_run(void *ctx, int64_t id, int color, int pass, gs_rng *rng,
                         gs_region_out *out)
{
    (void)color;
    (void)rng; /* the core keys its own streams by (seed, region id, pass, attempt) */
    model_engine *e = ctx;
    GS_CHECK(id >= 0 && (size_t)id < e->nplan, GS_ERR_INTERNAL, "region id %lld", (long long)id);
    const gs_model_region *r = &e->plan[id];
    size_t cells = box_cells(&r->box);
    GS_CHECK(cells <= e->buf_cells, GS_ERR_INTERNAL, "region %lld larger than the plan's largest",
             (long long)id);
    gs_model_region_result res;
    double cpu0 = gs_cpu_now();
    /* model.open_blocks' and model.sweep_keep's later sweeps: a rebuild is optional (the old content
     * is consistent), so a region gives up after OPEN_BLOCK_TRIES tries (model.open_blocks_tries) and
     * is not split, and then keeps its content (counted as rejected); with
     * model.open_blocks_largest a rebuild the keep tests reject counts as a
     * failed try (the next round draws other streams) */
    const int open = pass > 0 && e->keep_tests;
    gs_model_params q = e->params;
    if (open) {
        q.split_depth = 0;
        if (e->cfg->open_blocks_backtracks >= 0)
            q.backtracks = (int)e->cfg->open_blocks_backtracks;
    }
    const int cap = e->cfg->open_blocks > 0 ? (int)e->cfg->open_blocks_tries : OPEN_BLOCK_TRIES;
    const int tries = open && q.attempts > cap ? cap : q.attempts;
    int used = 0;
    uint64_t choices = 0, backtracks = 0;
    for (uint64_t round = 0;; round++) {
        q.attempts = tries - used;
        GS_CALL(gs_model_region_run(e->solver, &e->lat, &r->box, &q, r->id,
                                    (uint64_t)pass + (round << 32), e->buf, &res));
        used += res.attempts;
        choices += res.choices;
        backtracks += res.backtracks;
        if (!open)
            break;
        if (!res.ok) { /* kept as it was, counted as not accepted (ok = 3) */
            res.partial = 0;
            res.mh_rejected = 1;
            break;
        }
        int worse = 0;
        GS_CALL(sweep_keep_worse(e, &r->box, &worse));
        if (!worse)
            GS_CALL(open_block_too_large(e, id, &r->box, &worse));
        if (!worse)
            break;
        res.ok = 0;
        res.mh_rejected = 1;
        if (!e->open_largest || used >= tries)
            break;
    }
    res.attempts = used;
    res.choices = choices;
    res.backtracks = backtracks;
    double cpu_s = gs_cpu_now() - cpu0;
    /* ok: 1 accepted, 2 partly resampled (apply, count as failed), 0 kept,
     * 3 consistent but not accepted by the Metropolis step or a keep test (kept) */
    region_hdr h = {res.ok ? 1 : res.partial ? 2 : res.mh_rejected ? 3 : 0, res.attempts,
                    res.choices, res.backtracks, e->rank, e->window_seq++, cpu_s};
    GS_CALL(gs_region_out_append(out, &h, sizeof h));
    if (h.ok == 1 || h.ok == 2)
        GS_CALL(gs_region_out_append(out, e->buf, cells * sizeof *e->buf));
    return GS_OK;
}

static gs_err region_apply(void *ctx, int64_t id, const void *buf, size_t len)
{
    model_engine *e = ctx;
    const gs_model_region *r = &e->plan[id];
    const gs_model_box *b = &r->box;
    size_t cells = box_cells(b);
    region_hdr h;
    GS_CHECK(len >= sizeof h, GS_ERR_INTERNAL, "region %lld: %zu result bytes", (long long)id, len);
    memcpy(&h, buf, sizeof h);
    if (e->rec)
        e->rec[id] = h;
    GS_CHECK(len == sizeof h + (h.ok == 1 || h.ok == 2 ? cells * sizeof(uint16_t) : 0),
             GS_ERR_INTERNAL,
             "region %lld: %zu result bytes for ok=%d", (long long)id, len, (int)h.ok);
    e->stats.regions++;
    e->stats.attempts += (uint64_t)h.attempts;
    e->stats.choices += h.choices;
    e->stats.backtracks += h.backtracks;
    e->region_cells += cells;
    if (e->region_status[id] < 0 && e->pass_prog_open)
        gs_progress_update(&e->pass_prog, ++e->pass_done);
    e->region_status[id] = h.ok == 1 ? 1 : h.ok == 3 ? 2 : 0;
    e->region_attempts[id] = h.attempts;
    if (h.ok == 3) {
        e->stats.mh_rejected++;
        return GS_OK;
    }
    if (h.ok != 1) {
        e->stats.failed++;
        if (h.ok == 2)
            gs_model_region_apply(&e->lat, b, (const uint16_t *)((const char *)buf + sizeof h));
        return GS_OK;
    }
    e->stats.accepted++;
    gs_model_region_apply(&e->lat, b, (const uint16_t *)((const char *)buf + sizeof h));
    /* every rank applies every region: rows, not cells */
    const size_t row = (size_t)(b->x1 - b->x0);
    for (int z = b->z0; z < b->z1; z++)
        for (int y = b->y0; y < b->y1; y++) {
            uint16_t *cv = e->coverage + gs_model_lattice_index(&e->lat, b->x0, y, z);
            for (size_t x = 0; x < row; x++)
                cv[x] = (uint16_t)(cv[x] + (cv[x] < UINT16_MAX));
        }
    return GS_OK;
}

/* Fewest accepted regions over the active cells (the core driver's rule). */
static uint64_t min_coverage(const model_engine *e)
{
    const gs_model_lattice *l = &e->lat;
    int fix = e->params.fix_z_faces && l->nz >= 3;
    const int z0 = fix, z1 = fix ? l->nz - 1 : l->nz;
    if (z1 <= z0 || l->nx <= 0 || l->ny <= 0)
        return 0;
    /* layers z0..z1-1 are contiguous */
    const uint16_t *cv = e->coverage + gs_model_lattice_index(l, 0, 0, z0);
    const size_t n = (size_t)l->nx * (size_t)l->ny * (size_t)(z1 - z0);
    uint16_t m = UINT16_MAX;
    for (size_t i = 0; i < n; i++)
        m = cv[i] < m ? cv[i] : m;
    return m;
}

/* Colours run together at most this many regions at a time (one colour
 * alone may have more): bounds the results kept, the conflict lists
 * (gs_model_plan_conflicts, linear in the window) and how late a
 * time-based checkpoint or a signal is seen. */
#define MODEL_WINDOW_REGIONS 2048

/* Collective: runs colours e->color.. of pass e->pass on all ranks, as many
 * as fit a window (see MODEL_WINDOW_REGIONS) and end no later than a
 * unit-based checkpoint or stop would after one colour, as one dataflow
 * (gs_regions_set_conflicts): a region starts when the regions of earlier
 * colours it touches are done, not when the whole colour is. */
static gs_err run_window(gs_run *run, model_engine *e)
{
    double t0 = gs_time_now();
    int64_t budget = 0;
    GS_CALL(gs_run_units_until_due(run, e->units, &budget));
    size_t first = 0;
    while (first < e->nplan && (int)e->plan[first].color < e->color)
        first++;
    size_t last = first;
    int next = e->color;
    do {
        size_t end = last;
        while (end < e->nplan && (int)e->plan[end].color == next)
            end++;
        if (end > last && last > first && end - first > MODEL_WINDOW_REGIONS)
            break;
        last = end;
        next++;
    } while (next < e->ncolors && (int64_t)(last - first) < budget);
    size_t n = last - first;
    if (n == 0) {
        e->color = next;
        return GS_OK;
    }
    gs_region *list = NULL;
    int64_t *off = NULL, *ids = NULL;
    gs_regions_t s = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&list, n, sizeof *list, "colour regions"), done);
    for (size_t i = first; i < last; i++) {
        list[i - first].id = (int64_t)e->plan[i].id;
        list[i - first].color = (int)e->plan[i].color;
    }
    /* conflicts: interacting regions of lower colours (the plan is sorted
     * by colour) */
    GS_TRY(err, gs_model_plan_conflicts(&e->params, e->lat.nx, e->lat.ny, e->lat.nz,
                                        e->plan + first, n, &off, &ids),
           done);
    GS_TRY(err, gs_regions_create(run->comm, list, (int64_t)n, e->params.seed, MODEL_RNG_DOMAIN, &s),
           done);
    GS_TRY(err, gs_regions_set_conflicts(s, off, ids), done);
    e->rank = run->rank;
    e->window_seq = 0;
    GS_TRY(err, gs_regions_run_pass(s, e->pass, region_run, region_apply, e), done);
    model_sched_window(e, first, n, off, ids);
    if (e->cfg->schedule_log && run->rank == 0)
        GS_TRY(err, model_sched_log(run, e, e->windows_run, first, n, off, ids), done);
    e->windows_run++;
    gs_regions_stats qs = gs_regions_get_stats(s);
    e->queue.computed += qs.computed;
    e->queue.bytes += qs.bytes;
    e->queue.t_compute += qs.t_compute;
    e->queue.t_wait += qs.t_wait;
    e->queue.t_exchange += qs.t_exchange;
    e->queue.t_apply += qs.t_apply;
    e->queue.t_pass += qs.t_pass;
    e->queue.t_tail += qs.t_tail;
    e->queue.duplicates += qs.duplicates;
    e->units += (int64_t)n;
    e->color = next;
done:
    gs_regions_destroy(&s);
    gs_free(list);
    gs_free(off);
    gs_free(ids);
    e->t_windows += gs_time_now() - t0;
    return err;
}

/* Floating cells of the lattice of patterns (gs_model_support_floating:
 * origins, and the decoded layers above the top one); their x / y bounding
 * box into bb (x0, y0, x1, y1). Returns how many, SIZE_MAX when out of
 * memory. */
static size_t floating_cells(const model_engine *e, const gs_model_params *p, int bb[4])
{
    const gs_model_lattice *l = &e->lat;
    const int above = p->support_above ? p->support_layers_above : 0;
    const size_t layer = (size_t)l->nx * (size_t)l->ny, n = layer * (size_t)(l->nz + above);
    uint8_t *st = gs_malloc(n ? n : 1);
    if (!st)
        return SIZE_MAX;
    size_t nf = gs_model_support_floating(l->labels, l->nx, l->ny, l->nz, p, st);
    bb[0] = l->nx, bb[1] = l->ny, bb[2] = -1, bb[3] = -1;
    for (size_t i = 0; i < n && nf != SIZE_MAX; i++)
        if (st[i] == 1) {
            int x = (int)(i % (size_t)l->nx), y = (int)(i / (size_t)l->nx % (size_t)l->ny);
            bb[0] = x < bb[0] ? x : bb[0];
            bb[1] = y < bb[1] ? y : bb[1];
            bb[2] = x > bb[2] ? x : bb[2];
            bb[3] = y > bb[3] ? y : bb[3];
        }
    gs_free(st);
    return nf;
}

/* Every rank, after the last pass (model.overlap3d on an example without
 * floating structure): a region's try checks support through the region to
 * the non-empty cells next to it (box_supported), which need not reach the
 * ground themselves once other regions changed, so regions (blocks) can
 * leave floating structure where the whole grid cannot. The floating cells
 * are resynthesized in the box of their x / y extent (all pieces together:
 * the check wants none left anywhere) grown by a margin, over every layer,
 * with the exact whole-lattice check (params.support_global); a failing box
 * grows (margin doubled) up to the whole grid. Serial and
 * keyed by (seed, region id past the plans', pass): the same on every rank.
 * Counted as regions (accepted / failed). A successful box leaves no
 * floating cell (its check is the whole lattice's), and the margin doubles to
 * the whole grid within ~32 failures, so MODEL_REPAIR_MAX_TRIES only bounds
 * the loop should that ever stop holding: it then ends as a failed region. */
#define MODEL_REPAIR_ID 0x7f000000u
#define MODEL_REPAIR_MAX_TRIES 64
#define MODEL_REPAIR_PIECE_ROUNDS 3

/* The repair box over x / y extent bb (x0, y0, x1, y1 inclusive) grown by margin, clipped to
 * the lattice, over every layer. */
static gs_model_box repair_box(const gs_model_lattice *l, const int bb[4], int margin)
{
    gs_model_box b = {bb[0] - margin, bb[1] - margin, 0, bb[2] + 1 + margin, bb[3] + 1 + margin,
                      l->nz};
    b.x0 = b.x0 < 0 ? 0 : b.x0;
    b.y0 = b.y0 < 0 ? 0 : b.y0;
    b.x1 = b.x1 > l->nx ? l->nx : b.x1;
    b.y1 = b.y1 > l->ny ? l->ny : b.y1;
    return b;
}

/* Default mode (e->repair_empty): first each floating piece (6-connected
 * floating cells) alone, in the box of its x / y extent grown by 2 << round,
 * over every layer, with the regions' own check (non-empty cells reach z = 0
 * through the box or a non-empty cell next to it); a piece next to another
 * may stay floating, so up to MODEL_REPAIR_PIECE_ROUNDS rounds, then the
 * boxes over all pieces below. Small boxes keep the rest of the output as the
 * passes left it. Keys after the boxes' (the same on every rank). *clean = 1
 * when it found no floating cell (then the boxes below would find none:
 * their check, params.support_global, floods the same lattice the same way;
 * skipping it saves ~1 of the ~2 ms castle-10x spent here, replicated on
 * every rank, of a ~60 ms synthesis). */
static gs_err repair_pieces(model_engine *e, const gs_model_params *p, uint16_t *buf, int *clean)
{
    const gs_model_lattice *l = &e->lat;
    const size_t layer = (size_t)l->nx * (size_t)l->ny, n = layer * (size_t)l->nz;
    uint8_t *st = gs_malloc(n ? n : 1);
    int32_t *queue = gs_malloc((n ? n : 1) * sizeof *queue);
    gs_err err = GS_OK;
    uint64_t id = MODEL_REPAIR_ID + MODEL_REPAIR_MAX_TRIES; /* after the boxes' keys below */
    GS_TRY_CHECK(err, st && queue, GS_ERR_MEM, done, "support repair: cannot allocate");
    static const int d6[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int round = 0; round < MODEL_REPAIR_PIECE_ROUNDS; round++) {
        size_t nf = gs_model_support_floating(l->labels, l->nx, l->ny, l->nz, p, st);
        GS_TRY_CHECK(err, nf != SIZE_MAX, GS_ERR_MEM, done, "support repair: cannot allocate");
        if (nf == 0) {
            *clean = 1;
            break;
        }
        const int margin = 2 << round;
        for (size_t i0 = 0; i0 < n; i0++) {
            if (st[i0] != 1)
                continue;
            /* the piece of i0 (marked 3), its x / y extent */
            int bb[4] = {l->nx, l->ny, -1, -1};
            size_t head = 0, tail = 0, cells = 0;
            st[i0] = 3;
            queue[tail++] = (int32_t)i0;
            while (head < tail) {
                int32_t u = queue[head++];
                int x = (int)((size_t)u % (size_t)l->nx), y = (int)((size_t)u / (size_t)l->nx % (size_t)l->ny);
                int z = (int)((size_t)u / layer);
                cells++;
                bb[0] = x < bb[0] ? x : bb[0];
                bb[1] = y < bb[1] ? y : bb[1];
                bb[2] = x > bb[2] ? x : bb[2];
                bb[3] = y > bb[3] ? y : bb[3];
                for (int d = 0; d < 6; d++) {
                    int px = x + d6[d][0], py = y + d6[d][1], pz = z + d6[d][2];
                    if (p->periodic[0])
                        px = (px % l->nx + l->nx) % l->nx;
                    if (p->periodic[1])
                        py = (py % l->ny + l->ny) % l->ny;
                    if (px < 0 || py < 0 || pz < 0 || px >= l->nx || py >= l->ny || pz >= l->nz)
                        continue;
                    size_t v = (size_t)px + (size_t)l->nx * ((size_t)py + (size_t)l->ny * (size_t)pz);
                    if (st[v] == 1) {
                        st[v] = 3;
                        queue[tail++] = (int32_t)v;
                    }
                }
            }
            gs_model_box b = repair_box(l, bb, margin);
            gs_model_region_result res;
            GS_TRY(err,
                   gs_model_region_run(e->solver, &e->lat, &b, p, id++,
                                       (uint64_t)e->pass, buf, &res),
                   done);
            gs_log(GS_LOG_DEBUG, "support repair: a piece of %zu floating cells, box x %d..%d "
                   "y %d..%d: %s", cells, b.x0, b.x1 - 1, b.y0, b.y1 - 1,
                   res.ok ? "resynthesized" : "kept");
            e->stats.regions++;
            e->stats.attempts += (uint64_t)res.attempts;
            e->stats.choices += res.choices;
            e->stats.backtracks += res.backtracks;
            if (res.ok) {
                e->stats.accepted++;
                gs_model_region_apply(&e->lat, &b, buf);
            }
        }
    }
done:
    gs_free(st);
    gs_free(queue);
    return err;
}

/* Default mode (e->repair_empty), the last resort when no repair box keeps the
 * output supported: the floating cells become empty (label 0) when that breaks
 * no rule. A floating piece is a 6-connected component of non-empty cells with
 * no path to z = 0, so every neighbour outside it is empty: emptied, each of its
 * cells sits among empty cells only, which the rules allow wherever the example
 * has empty next to empty along every axis (checked on the whole lattice; no
 * carving with pins or label-limited x/y faces, and none on the top layer
 * unless its face set holds empty). Village 267 at synthesis seed 2: one leaves
 * cell alone on the output's y = 0 face, which every resynthesized box up to the
 * whole grid left floating somewhere (#18 untuned, configs/model/DEFAULTS.md).
 * Returns the cells emptied (0: none could be, the lattice unchanged). */
static size_t carve_floating(model_engine *e, const gs_model_params *p)
{
    gs_model_lattice *l = &e->lat;
    if (p->pins || p->xyface[0] || p->xyface[1] || p->xyface[2] || p->xyface[3] ||
        p->support_layers_above > 0)
        return 0;
    const size_t layer = (size_t)l->nx * (size_t)l->ny, n = layer * (size_t)l->nz;
    uint8_t *st = gs_malloc(n ? n : 1);
    uint16_t *old = gs_malloc((n ? n : 1) * sizeof *old);
    size_t nf = st && old ? gs_model_support_floating(l->labels, l->nx, l->ny, l->nz, p, st)
                          : SIZE_MAX;
    size_t carved = 0;
    if (nf != SIZE_MAX && nf > 0) {
        memcpy(old, l->labels, n * sizeof *old);
        int ok = 1;
        for (size_t i = 0; i < n; i++)
            if (st[i] == 1) {
                if (i / layer == (size_t)l->nz - 1 && p->zface[1] && !(p->zface[1][0] & 1u))
                    ok = 0;
                l->labels[i] = 0;
                carved++;
            }
        if (!ok || gs_model_rules_violations(e->rules, l) != 0) {
            memcpy(l->labels, old, n * sizeof *old);
            carved = 0;
        }
    }
    gs_free(st);
    gs_free(old);
    return carved;
}

/* The repair's end with nf cells still floating after tries boxes (whole: the
 * last box was the whole grid): emptied if no rule breaks (carve_floating),
 * else a failed region. */
static void support_last_resort(model_engine *e, const gs_model_params *p, size_t nf, int tries,
                                int whole)
{
    size_t carved = carve_floating(e, p);
    if (carved) {
        if (whole)
            gs_log(GS_LOG_INFO, "support repair: %zu floating cells emptied (among empty cells "
                   "only, no rule broken) after the whole grid", carved);
        else
            gs_log(GS_LOG_INFO, "support repair: %zu floating cells emptied (among empty cells "
                   "only, no rule broken) after %d boxes", carved, tries);
        return;
    }
    e->stats.failed++;
    if (whole)
        gs_log(GS_LOG_WARN, "support repair: %zu floating cells remain", nf);
    else
        gs_log(GS_LOG_WARN, "support repair: %zu floating cells remain after %d boxes", nf, tries);
}

static gs_err support_repair(model_engine *e)
{
    const uint8_t *empty = e->params.support_empty ? e->params.support_empty : e->repair_empty;
    if (!empty)
        return GS_OK;
    const gs_model_lattice *l = &e->lat;
    gs_model_params p = e->params;
    p.support_empty = empty;
    uint16_t *buf = NULL;
    GS_CALL(gs_alloc_array((void **)&buf, lattice_cells(l), sizeof *buf, "repair labels"));
    gs_err err = GS_OK;
    int margin = (int)(e->cfg->overlap3d > 0 ? e->cfg->overlap3d : 2), tries = 0;
    int clean = 0;
    if (!e->params.support_empty)
        GS_TRY(err, repair_pieces(e, &p, buf, &clean), done);
    p.support_global = 1;
    while (!clean) {
        int bb[4];
        size_t nf = floating_cells(e, &p, bb);
        GS_TRY_CHECK(err, nf != SIZE_MAX, GS_ERR_MEM, done, "support repair: cannot allocate");
        if (nf == 0)
            break;
        if (tries == MODEL_REPAIR_MAX_TRIES) {
            support_last_resort(e, &p, nf, tries, 0);
            break;
        }
        gs_model_box b = repair_box(l, bb, margin);
        const int whole = b.x0 == 0 && b.y0 == 0 && b.x1 == l->nx && b.y1 == l->ny;
        gs_model_region_result res;
        GS_TRY(err,
               gs_model_region_run(e->solver, &e->lat, &b, &p, MODEL_REPAIR_ID + (uint64_t)tries,
                                   (uint64_t)e->pass, buf, &res),
               done);
        gs_log(GS_LOG_INFO,
               "support repair %d: %zu floating cells, box x %d..%d y %d..%d: %s", tries + 1, nf,
               b.x0, b.x1 - 1, b.y0, b.y1 - 1, res.ok ? "resynthesized" : "failed");
        e->stats.regions++;
        e->stats.attempts += (uint64_t)res.attempts;
        e->stats.choices += res.choices;
        e->stats.backtracks += res.backtracks;
        tries++;
        if (res.ok) {
            e->stats.accepted++;
            gs_model_region_apply(&e->lat, &b, buf);
            continue;
        }
        if (whole) { /* nothing left to grow */
            support_last_resort(e, &p, nf, tries, 1);
            break;
        }
        margin *= 2;
    }
done:
    gs_free(buf);
    return err;
}

/* Collective: the next batch of the synthesis (a new pass's plan, then one
 * window of colours, run_window); *finished once the passes are done. */
gs_err model_advance_window(gs_run *run, model_engine *e, int *finished)
{
    *finished = e->done;
    if (e->done) {
        e->stats.passes = e->pass;
        return GS_OK;
    }
    if (!e->plan)
        GS_CALL(model_make_plan(e));
    if (e->color == 0)
        gs_log(GS_LOG_INFO, "pass %d: %zu regions in %d colours", e->pass + 1, e->nplan,
               e->ncolors);
    if (!e->pass_prog_open) { /* a new pass, or the one a checkpoint stopped in */
        char label[64];
        snprintf(label, sizeof label, "pass %d regions", e->pass + 1);
        gs_progress_begin(&e->pass_prog, label, (uint64_t)e->nplan);
        e->pass_done = 0;
        for (size_t i = 0; i < e->nplan; i++)
            e->pass_done += e->region_status[i] >= 0;
        gs_progress_update(&e->pass_prog, e->pass_done);
        e->pass_prog_open = 1;
    }
    GS_CALL(run_window(run, e));
    if (e->color >= e->ncolors) {
        gs_progress_end(&e->pass_prog);
        e->pass_prog_open = 0;
        uint64_t acc = 0, fail = 0, kept = 0;
        for (size_t i = 0; i < e->nplan; i++) {
            acc += e->region_status[i] == 1;
            fail += e->region_status[i] == 0;
            kept += e->region_status[i] == 2;
        }
        e->stats.min_coverage = min_coverage(e);
        gs_log(GS_LOG_INFO,
               "pass %d done: %llu accepted, %llu failed, %llu kept as they were (rejected); "
               "every cell in >= %llu accepted regions (goal %d)",
               e->pass + 1, (unsigned long long)acc, (unsigned long long)fail,
               (unsigned long long)kept,
               (unsigned long long)e->stats.min_coverage, e->params.min_changes);
        e->pass++;
        e->color = 0;
        if (e->stats.min_coverage >= (uint64_t)e->params.min_changes ||
            e->pass >= e->params.max_passes) {
            e->done = 1;
            GS_CALL(support_repair(e));
        } else
            GS_CALL(model_make_plan(e));
    }
    *finished = e->done;
    if (e->done)
        e->stats.passes = e->pass;
    return GS_OK;
}

static const char *const q_key[Q_N] = {
    "regions", "region_s", "wait_s", "tail_s", "exchange_s", "apply_s", "flow_s",
    "window_setup_s", "outside_windows_s", "cpu_s", "duplicates"};

/* Collective. The ideal speed-up over one rank is the sum over the max of
 * the region seconds: robust to a shared machine's noise, unlike wall
 * time. Per rank: wait_s = nothing ready to run here (tail_s of it: every
 * region was claimed, the end of a pass), flow_s = in the dataflow passes,
 * window_setup_s = building the window's conflict lists and scheduler
 * (every rank does it, serial), outside_windows_s = the rest of the
 * synthesis phase (plans, coverage, checkpoints). */
gs_err model_queue_report(gs_run *run, const model_engine *e, double cpu, queue_report_t *q,
                          gs_json *j)
{
    double mine[Q_N] = {(double)e->queue.computed, e->queue.t_compute, e->queue.t_wait,
                        e->queue.t_tail, e->queue.t_exchange, e->queue.t_apply, e->queue.t_pass,
                        e->t_windows - e->queue.t_pass, e->synth_seconds - e->t_windows, cpu,
                        (double)e->queue.duplicates};
    double *all = run->rank == 0 ? gs_calloc((size_t)run->size * Q_N, sizeof *all) : NULL;
    gs_err local = run->rank == 0 && !all
                       ? gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                        "cannot gather the per-rank times")
                       : GS_OK;
    GS_CALL(gs_par_agree(run->comm, local));
    GS_CALL(gs_par_gather_bytes(run->comm, mine, sizeof mine, all, 0));
    memset(q, 0, sizeof *q);
    if (run->rank != 0)
        return GS_OK;
    /* "per_rank": {key: [rank 0, rank 1, ...], ...} into the open object j */
    gs_json_begin_object(j, "per_rank");
    for (int k = 0; k < Q_N; k++) {
        gs_json_begin_array(j, q_key[k]);
        for (int r = 0; r < run->size; r++) {
            double v = all[(size_t)r * Q_N + k];
            q->sum[k] += v;
            q->max[k] = r == 0 || v > q->max[k] ? v : q->max[k];
            if (k == Q_REGIONS || k == Q_DUPLICATES)
                gs_json_i64(j, NULL, (int64_t)v);
            else
                gs_json_f64(j, NULL, round(v * 1e4) / 1e4);
        }
        gs_json_end_array(j);
    }
    gs_json_end_object(j);
    gs_free(all);
    return GS_OK;
}
