/* points driver, the parallel hooks the core calls: the agreement that
 * remembers a collective failure, the distributed search of Psi_k (one
 * all-gather per patch), the map hook over the ranks (gs_pmap), and the
 * test-only fault injection (GS_FAIL_POINTS_AT) that proves no failure
 * leaves a rank hung. See engine.c for the error model. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>

#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "points/engine_impl.h"

static const char *const fault_sites[] = {"",           "map-alloc", "map-fn", "search-scan",
                                          "search-merge", "step",      "generate"};

/* Reads GS_FAIL_RANK / GS_FAIL_POINTS_AT for this rank. */
gs_err points_fault_init(fault_inject *f, int rank)
{
    memset(f, 0, sizeof *f);
    const char *at = getenv("GS_FAIL_POINTS_AT"), *r = getenv("GS_FAIL_RANK");
    if (!at || !at[0])
        return GS_OK;
    char why[128];
    int64_t fr = 0;
    GS_CHECK(!r || !r[0] || gs_parse_i64(r, 0, INT_MAX, &fr, why, sizeof why), GS_ERR_USAGE,
             "GS_FAIL_RANK = '%s': expected a rank (%s)", r, why);
    const char *k = strchr(at, '@');
    size_t len = k ? (size_t)(k - at) : strlen(at);
    int site = FAULT_NONE;
    for (int i = 1; i < (int)(sizeof fault_sites / sizeof *fault_sites); i++)
        if (strlen(fault_sites[i]) == len && !strncmp(at, fault_sites[i], len))
            site = i;
    GS_CHECK(site != FAULT_NONE, GS_ERR_USAGE, "GS_FAIL_POINTS_AT = '%s': expected SITE[@PATCH], "
             "SITE one of map-alloc map-fn search-scan search-merge step generate", at);
    int64_t patch = 1;
    GS_CHECK(!k || gs_parse_i64(k + 1, 0, INT64_MAX, &patch, why, sizeof why), GS_ERR_USAGE,
             "GS_FAIL_POINTS_AT = '%s': expected a patch index after '@' (%s)", at, why);
    if (fr == rank) {
        f->site = site;
        f->patch = (uint64_t)patch;
    }
    return GS_OK;
}

/* 1 when the injected failure fires here (and then never again). */
int points_fault_fires(fault_inject *f, int site)
{
    if (!f || !f->armed || f->site != site)
        return 0;
    f->armed = 0;
    f->site = FAULT_NONE;
    return 1;
}

gs_err points_fault_raise(const fault_inject *f, int site, gs_err code)
{
    if (site == FAULT_GENERATE)
        return gs_error_raise(code, __FILE__, __LINE__, __func__,
                              "points: injected failure at generate (GS_FAIL_POINTS_AT)");
    return gs_error_raise(code, __FILE__, __LINE__, __func__,
                          "points: injected failure at %s of patch %llu (GS_FAIL_POINTS_AT)",
                          fault_sites[site], (unsigned long long)f->patch);
}

/* gs_par_agree that remembers a collective failure in *together (every rank
 * returned it from the same collective: the run may end without MPI_Abort). */
gs_err points_agree(int *together, MPI_Comm comm, gs_err local)
{
    gs_err err = gs_par_agree(comm, local);
    if (err != GS_OK)
        *together = 1;
    return err;
}

gs_err points_search_ctx_alloc(search_ctx *c)
{
    GS_CALL(gs_alloc_array((void **)&c->all, (size_t)c->size, SEARCH_REC * sizeof *c->all,
                           "search exchange"));
    GS_CALL(gs_alloc_array((void **)&c->parts, (size_t)c->size, sizeof *c->parts,
                           "search parts"));
    GS_CALL(gs_alloc_array((void **)&c->counts, (size_t)c->size, 2 * sizeof *c->counts,
                           "search parts"));
    return GS_OK;
}

void points_search_ctx_free(search_ctx *c)
{
    gs_points_cands_free(&c->local);
    GS_FREE(c->all);
    GS_FREE(c->parts);
    GS_FREE(c->counts);
}

static double local_bound(void *user)
{
    search_ctx *c = user;
    return c->scale * c->local.best;
}

static void local_offer(void *user, double d, uint64_t index)
{
    search_ctx *c = user;
    gs_points_cands *o = &c->local;
    c->offers++;
    if (c->oom)
        return;
    if (o->n == o->cap) {
        size_t cap = o->cap ? 2 * o->cap : 64;
        gs_points_cand *v = gs_realloc(o->v, cap * sizeof *v);
        if (!v) {
            c->oom = 1;
            return;
        }
        o->v = v;
        o->cap = cap;
    }
    o->v[o->n].dist = d;
    o->v[o->n++].index = index;
    if (d < o->best)
        o->best = d;
}

/* gs_points_search_fn: Psi_k over all ranks (collective). Each rank scans
 * its share with its own running bound (every patch within (1 + eps) x its
 * best: a superset of its part of Psi_k, since its best is >= the global
 * one), then one MPI_Allgather of {status, count, SEARCH_SLOTS candidates}
 * per rank, and gs_points_search_merge keeps exactly the serial Psi_k. One
 * exchange per patch instead of psearch's four plus bound messages: on a
 * shared machine every exchange waits for the slowest rank, and the scan is
 * a small part of a step, so a shared bound saves less than it costs. */
gs_err points_distributed_search(void *user, const gs_points_synth *s, const float *query,
                                 int mode, double eps, gs_points_cands *out)
{
    search_ctx *c = user;
    const gs_points_bank *bank = gs_points_synth_bank(s);
    c->scale = 1.0 + eps;
    c->local.n = 0;
    c->local.best = INFINITY;
    c->oom = 0;
    gs_err status = GS_OK;
    if (c->hi > c->lo)
        status = gs_points_search_scan(bank, query, mode, (uint64_t)c->lo, (uint64_t)c->hi,
                                       local_bound, local_offer, c);
    if (status == GS_OK && c->oom)
        status = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                "points: out of memory (search candidates)");
    if (status == GS_OK && points_fault_fires(c->fault, FAULT_SEARCH_SCAN))
        status = points_fault_raise(c->fault, FAULT_SEARCH_SCAN, GS_ERR_INTERNAL);
    /* Only what can survive the merge is sent. */
    size_t kept = 0;
    if (status == GS_OK)
        for (size_t i = 0; i < c->local.n; i++)
            if (c->local.v[i].dist <= c->scale * c->local.best)
                c->local.v[kept++] = c->local.v[i];
    c->local.n = kept;
    enum { REC = SEARCH_REC };
    int64_t mine[REC];
    memset(mine, 0, sizeof mine);
    mine[0] = (int64_t)status;
    mine[1] = (int64_t)kept;
    for (size_t i = 0; i < kept && i < SEARCH_SLOTS; i++) {
        memcpy(&mine[2 + 2 * i], &c->local.v[i].dist, sizeof(double));
        mine[3 + 2 * i] = (int64_t)c->local.v[i].index;
    }
    int64_t *all = c->all;
    gs_points_cands *parts = c->parts; /* views into more */
    gs_points_cand *more = NULL;
    int *counts = c->counts;
    gs_err err = GS_OK;
    GS_TRY(err, gs_par_allgather_bytes(c->comm, mine, sizeof mine, all), done);
    int failed = 0, overflow = 0;
    int64_t total = 0;
    for (int r = 0; r < c->size; r++) {
        failed |= all[(size_t)r * REC] != GS_OK;
        overflow |= all[(size_t)r * REC + 1] > SEARCH_SLOTS;
        total += all[(size_t)r * REC + 1];
    }
    if (failed) {
        err = points_agree(c->together, c->comm, status);
        goto done;
    }
    if (total > INT_MAX / (int64_t)sizeof *more) { /* every rank sees the same total */
        *c->together = 1;
        err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                             "points: %lld search candidates within (1 + %g) x best are too many "
                             "for one exchange: lower points.eps", (long long)total, eps);
        goto done;
    }
    GS_TRY(err, gs_alloc_array((void **)&more, total ? (size_t)total : 1, sizeof *more,
                               "search candidates"), done);
    int *displs = counts + c->size, off = 0;
    for (int r = 0; r < c->size; r++) {
        int64_t nr = all[(size_t)r * REC + 1];
        parts[r].v = more + off;
        parts[r].n = (size_t)nr;
        counts[r] = (int)nr * (int)sizeof *more;
        displs[r] = off * (int)sizeof *more;
        for (int64_t i = 0; i < nr && !overflow; i++) {
            memcpy(&more[off + i].dist, &all[(size_t)r * REC + 2 + 2 * i], sizeof(double));
            more[off + i].index = (uint64_t)all[(size_t)r * REC + 3 + 2 * i];
        }
        off += (int)nr;
    }
    if (overflow) { /* every rank saw it: all gather every candidate */
        c->regathers++;
        GS_TRY(err, gs_par_allgatherv_bytes(c->comm, c->local.v, more, counts, displs), done);
    }
    /* After the exchange a failure (the allocations of more and of the
     * merge) is local: the driver aborts every rank (gs_run.failed_alone). */
    if (points_fault_fires(c->fault, FAULT_SEARCH_MERGE)) {
        err = points_fault_raise(c->fault, FAULT_SEARCH_MERGE, GS_ERR_MEM);
        goto done;
    }
    GS_TRY(err, gs_points_search_merge(parts, c->size, eps, out), done);
done:
    gs_free(more);
    return err;
}


/* gs_points_gen_params.agree over the ranks (user: map_state). The
 * "generate" fault is a local failure of this rank at the generator's first
 * agreement. */
gs_err points_map_agree(void *user, gs_err local)
{
    map_state *m = user;
    if (local == GS_OK && points_fault_fires(m->fault, FAULT_GENERATE))
        local = points_fault_raise(m->fault, FAULT_GENERATE, GS_ERR_INTERNAL);
    return points_agree(m->together, m->pm.comm, local);
}

static gs_err map_hook_computed(void *user, gs_err local)
{
    map_state *m = user;
    if (local == GS_OK && points_fault_fires(m->fault, FAULT_MAP_FN))
        local = points_fault_raise(m->fault, FAULT_MAP_FN, GS_ERR_INTERNAL);
    return local;
}

static gs_err map_hook_exchanging(void *user)
{
    map_state *m = user;
    if (points_fault_fires(m->fault, FAULT_MAP_ALLOC))
        return points_fault_raise(m->fault, FAULT_MAP_ALLOC, GS_ERR_MEM);
    return GS_OK;
}

static gs_err map_hook_agree(void *user, MPI_Comm comm, gs_err local)
{
    map_state *m = user;
    return points_agree(m->together, comm, local);
}

gs_err points_map_state_init(map_state *m, MPI_Comm comm, fault_inject *fault, int *together)
{
    gs_pmap_hooks hooks = {m, map_hook_computed, map_hook_exchanging, map_hook_agree};
    m->fault = fault;
    m->together = together;
    return gs_pmap_init(&m->pm, comm, &hooks);
}

/* gs_points_map_fn over the ranks (user: map_state). Collective. */
gs_err points_mpi_map(void *user, size_t n, size_t bytes, gs_points_range_fn fn, void *ctx,
                      void *out)
{
    map_state *m = user;
    return gs_pmap_run(&m->pm, n, bytes, fn, ctx, out);
}
