/* field driver, the synthesis' parallel parts: the exact best match of a
 * block spread over the ranks (gs_psearch over the tree's top-level subtrees
 * or slabs, the bound shared), the quality measure's matcher, and a colour's
 * target regions on the gs_regions work queue. See engine.c for why the
 * output is identical at any rank count. */
#include <math.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/regions.h"
#include "field/engine_impl.h"

static void poll_bound(void *ctx_, uint64_t *bound)
{
    match_ctx *ctx = ctx_;
    double b = gs_psearch_bound(ctx->cur);
    if (isfinite(b) && b >= 0 && b < (double)*bound)
        *bound = (uint64_t)b;
}

static gs_err search_share(void *user, gs_psearch_t ps, int64_t lo, int64_t hi)
{
    match_ctx *ctx = user;
    ctx->cur = ps;
    int64_t t0 = lo, t1 = hi;
    if (ctx->sharded) {
        /* the unit is this rank's slab: its whole tree (none when the slab is empty) */
        if (!ctx->tree)
            return GS_OK;
        t0 = 0, t1 = gs_field_tree_top_count(ctx->tree);
    }
    double b = gs_psearch_bound(ps);
    uint64_t bound = isfinite(b) ? (uint64_t)b : UINT64_MAX;
    gs_field_search_opts o = ctx->opts;
    o.poll = poll_bound;
    o.poll_ctx = ctx;
    o.poll_every = 16;
    GS_CALL(gs_field_tree_search(ctx->searcher, t0, t1, ctx->q, &o, &bound, &ctx->local));
    if (ctx->local.found) {
        gs_psearch_offer(ps, (double)ctx->local.dist, lo);
        (void)gs_psearch_bound(ps); /* poll interval 1: sends the improvement now */
    }
    return GS_OK;
}

/* The synthesis' match hook: exact best match, spread over the ranks. */
gs_err field_match_block(void *ctx_, gs_field_tree_t tree, gs_field_searcher_t searcher,
                         int iteration, const gs_field_query *q,
                         const gs_field_search_opts *opts, gs_field_match *out)
{
    match_ctx *ctx = ctx_;
    gs_run *run = ctx->run;
    ctx->queries++;
    int done = 0;
    if (ctx->sharded) {
        /* every rank holds one slab of the tree: always spread */
    } else if (run->size == 1) {
        GS_CALL(gs_field_tree_best_match(searcher, q, opts, out));
        done = 1;
    } else {
        /* Most masked queries finish in a few hundred pops: every rank runs
         * them whole (same answer everywhere, no messages), and only the
         * queries that exceed the budget -- the same ones on every rank --
         * are spread over the ranks. */
        gs_field_search_opts lo = opts ? *opts : (gs_field_search_opts){0};
        lo.max_pops = FIELD_LOCAL_POPS;
        uint64_t bound = UINT64_MAX;
        GS_CALL(gs_field_tree_search(searcher, 0, gs_field_tree_top_count(tree), q, &lo, &bound, out));
        done = out->found && !out->truncated;
        if (done)
            ctx->local_queries++;
    }
    if (!done) {
        if (ctx->ps_iteration != iteration) {
            /* candidates: the top-level subtrees weighted by their blocks, or
             * sharded one per rank (its slab) */
            gs_psearch_destroy(&ctx->ps);
            int64_t top = ctx->sharded ? run->size : gs_field_tree_top_count(tree);
            double *w = NULL;
            if (!ctx->sharded) {
                GS_CALL(gs_alloc_array((void **)&w, (size_t)top, sizeof *w, "subtree weights"));
                for (int64_t i = 0; i < top; i++)
                    w[i] = (double)gs_field_tree_top_blocks(tree, i);
            }
            gs_err err = gs_psearch_create(run->comm, top, w, &ctx->ps);
            gs_free(w);
            GS_CALL(err);
            gs_psearch_set_poll_interval(ctx->ps, 1);
            ctx->ps_iteration = iteration;
        }
        ctx->searcher = searcher;
        ctx->tree = tree;
        ctx->q = q;
        ctx->opts = opts ? *opts : (gs_field_search_opts){0};
        memset(&ctx->local, 0, sizeof ctx->local);
        gs_psearch_hit hit;
        GS_CALL(gs_psearch_best(ctx->ps, search_share, ctx, &hit));
        GS_CHECK(hit.index >= 0, GS_ERR_INTERNAL, "distributed block search found no block");
        /* psearch orders ties by subtree; the serial answer is the lowest
         * tie rank (the lowest index without a tie key, see
         * gs_field_tie_rank) among the ranks' bests at the best distance */
        int64_t key = ctx->local.found && (double)ctx->local.dist == hit.dist
                      ? (int64_t)gs_field_tie_rank_of(&ctx->opts, ctx->local.index)
                      : INT64_MAX, best;
        GS_CALL(gs_par_min_i64(run->comm, key, &best));
        GS_CHECK(best != INT64_MAX, GS_ERR_INTERNAL, "distributed block search lost its best block");
        *out = ctx->local;
        out->found = 1;
        out->index = gs_field_tie_index((uint64_t)best);
        out->dist = (uint64_t)hit.dist;
        out->pops = ctx->local.pops; /* this rank's work */
        /* the same on every rank, also on one whose slab found nothing */
        out->known = gs_field_query_known(q);
    }
    ctx->pops += out->pops;
    return GS_OK;
}

/* Quality measure: every rank matches every output block with its whole
 * full-resolution tree or its slab of it, through field_match_block (its own key
 * for the psearch handle). */
#define QUALITY_ITERATION GS_FIELD_MAX_ITER
gs_err field_quality_match(void *ctx_, const gs_field_query *q, gs_field_match *out)
{
    match_ctx *ctx = ctx_;
    return field_match_block(ctx, ctx->qtree, ctx->qsearcher, QUALITY_ITERATION, q, NULL, out);
}

/* ------------------------------------------------------ target regions */

/* Regions of one color on the gs_regions work queue: each rank synthesizes
 * its regions on private copies with the whole local tree, the results (one
 * source block per target block) are exchanged and applied in id order on
 * every rank. Same state as the serial order (gs_field_synth_run). */
/* ctx is the synthesis; gs_regions ids are its region indices. */
static gs_err field_region_run(void *synth, int64_t id, int color, int pass, gs_rng *rng,
                               gs_region_out *out)
{
    (void)color, (void)pass, (void)rng; /* the synthesis has no randomness after seeding */
    void *dst = NULL;
    GS_CALL(gs_region_out_reserve(out, gs_field_synth_region_bytes(synth, id), &dst));
    return gs_field_synth_region_run(synth, id, dst);
}

static gs_err field_region_apply(void *synth, int64_t id, const void *buf, size_t len)
{
    return gs_field_synth_region_apply(synth, id, buf, len);
}


#define FIELD_REGIONS_DOMAIN 0x46524547u /* "FREG" */


gs_err field_run_color_regions(gs_run *run, gs_field_synth_t synth, int64_t first, int64_t n,
                               region_times *rt)
{
    gs_region *list = NULL;
    GS_CALL(gs_alloc_array((void **)&list, (size_t)n, sizeof *list, "colour regions"));
    for (int64_t i = 0; i < n; i++)
        list[i].id = first + i, list[i].color = 0;
    gs_regions_t rs = NULL;
    gs_err err = gs_regions_create(run->comm, list, n, (uint64_t)run->seed, FIELD_REGIONS_DOMAIN, &rs);
    gs_free(list);
    GS_CALL(err);
    err = gs_regions_run_pass(rs, 0, field_region_run, field_region_apply, synth);
    gs_regions_stats st = gs_regions_get_stats(rs);
    rt->compute += st.t_compute, rt->wait += st.t_wait;
    rt->exchange += st.t_exchange, rt->apply += st.t_apply;
    rt->regions += st.computed;
    gs_regions_destroy(&rs);
    return err;
}
