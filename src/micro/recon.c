/* Stochastic reconstruction (paper 4.4): label every triangle with a signed
 * distance value so that the labels follow the histogram and every pair obeys
 * |x_i - x_j| <= d(i, j) (d: geodesic distance over the ring graph, geo.c;
 * the paper's dual graph grows hexagons).
 *
 * Bins are processed from the highest magnitude down to 0, positive before
 * negative at each magnitude. Each unassigned triangle keeps a range
 * [lo, hi] of values that violate no constraint. For bin (side, m):
 *  1. forced: triangles whose range lies at or beyond the bin (lo >= m for
 *     the positive side) cannot take any value of a later bin, so they take
 *     the value nearest zero they may have (lo, e.g. "range [2.3, 5.7] ->
 *     2.3"), most extreme first, while the bin has counts left;
 *  2. random: the bin's remaining counts go to random triangles (gs_rng) whose
 *     range contains the bin's inner edge m, which is the value they get;
 *     each placement is propagated outward by a Dijkstra that stops where it
 *     no longer changes any range.
 * Triangles left without a value get the neighbour average, clamped to the
 * range the constraints allow (exactly computed, so never a violation).
 *
 * Which bounds are tracked, and why that is exact. Mirror the negative side
 * (b1 = -hi) so both sides look like the positive one (b0 = lo). A value
 * placed on side s only ever tightens b_s usefully: the bound it puts on the
 * other side, b_{1-s} >= -(x + d), is never above -m and every later decision
 * only reads b_{1-s} >= -m (inner edges of later bins have magnitude <= m).
 * Likewise b_s only matters down to -m, so a placement at value a explores
 * radius a + m. A forced value (x = lo) tightens nothing of its own side (its
 * bound is implied by the triangle inequality), so it needs no propagation.
 * The search stops at a triangle whose range it does not tighten: everything
 * behind it is then at least as tight already (triangle inequality again).
 *
 * Change against the paper (opts.capacity, default on): the paper leaves 5-10%
 * of the triangles unlabelled, mostly because random seeds force more
 * triangles into lower bins (the cones x = a - d around them) than those bins
 * hold. Here every triangle whose lo >= 0 is "committed" to the bin of its lo
 * (it can end nowhere else), demand[bin] = labelled + committed, and a random
 * placement is accepted only if the commitments it creates keep demand <=
 * count in every bin. Forced assignments then never overflow and the leftover
 * comes only from bins that found no admissible seed. Once the next lower bin
 * is full, seeds are drawn next to existing structures, including the ones
 * this bin has placed (see run_bin), so a bin fills by growing plateaus.
 *
 * Band accounting (with capacity): a triangle whose side-s bound is above -1
 * can only take a value of side s or of bin 0 of the other side, so their
 * number, band[s], must stay within those bins' counts; a placement that
 * would push it over is rejected like a bin overflow. Without it the
 * scattered seeds of a large positive region (stone: 69% of the area) left
 * too few triangles at distance >= 1 from it for the negative bins (1.9%
 * unassigned, bin 0 of both sides full). band[] counts the stored bounds
 * (every write of lo/hi updates it), so a resumed run recomputes the same
 * numbers. Probes reach radius 2a >= a + 1 for a >= 1, so every crossing of
 * -1 a placement causes is seen. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "micro/micro_impl.h"

#define MICRO_RNG_DOMAIN 0x6d696372u /* "micr" */

typedef struct forced_item {
    double b;
    uint32_t t;
} forced_item;

struct gs_micro_recon {
    const gs_micro_dual *d;
    const gs_micro_hist *h;
    gs_micro_recon_opts o;
    gs_micro_state st;
    int64_t *demand;         /* [2K] */
    int64_t band[2];         /* triangles whose side-s bound is > -1 */
    int64_t band_cap[2];     /* counts of side s + bin 0 of the other side */
    struct gs_micro_geo *geo;
    uint32_t *cand;          /* random candidates, fill queue */
    forced_item *forced;     /* forced assignments of a bin */
    uint32_t *near;          /* random candidates next to higher structures */
    size_t cap_near;
    uint8_t *innear;         /* [n] 1 while a triangle waits in near (bin-local) */
    uint32_t *live;          /* triangles unlabelled at the last bin start */
    size_t nlive;
    uint32_t *rec_t;         /* propagation record */
    double *rec_b;
    size_t cap_rec;
    int64_t *delta;          /* [2K] demand change of a probe */
    uint32_t *delta_bins;
    gs_micro_recon_counters c;
};

void gs_micro_recon_defaults(gs_micro_recon_opts *o)
{
    o->capacity = 1;
    o->max_rejects_per_bin = 0;
}

/* Lower bound in side-s mirrored coordinates. */
static inline double bound(const gs_micro_state *st, int s, uint32_t j)
{
    return s ? -st->hi[j] : st->lo[j];
}

/* Bin a triangle's range commits it to (it can be labelled from no other bin
 * with counts left), or UINT32_MAX. */
static inline uint32_t commit_bin(const gs_micro_state *st, uint32_t j)
{
    uint32_t K = st->nbins;
    double lo = st->lo[j], hi = st->hi[j];
    if (lo >= 0) {
        uint32_t k = lo >= (double)(K - 1) ? K - 1 : (uint32_t)lo;
        return gs_micro_bin_index(K, 0, k);
    }
    if (hi <= 0) {
        uint32_t k = -hi >= (double)(K - 1) ? K - 1 : (uint32_t)-hi;
        return gs_micro_bin_index(K, 1, k);
    }
    return UINT32_MAX;
}

static void state_zero(gs_micro_state *st)
{
    memset(st, 0, sizeof *st);
}

void gs_micro_state_free(gs_micro_state *st)
{
    if (!st)
        return;
    gs_free(st->placed);
    gs_free(st->value);
    gs_free(st->label);
    gs_free(st->lo);
    gs_free(st->hi);
    state_zero(st);
}

static gs_err state_alloc(gs_micro_state *st, uint32_t n, uint32_t K)
{
    state_zero(st);
    st->ntris = n;
    st->nbins = K;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&st->placed, 2 * (size_t)K, sizeof *st->placed, "bin counters"), fail);
    GS_TRY(err, gs_alloc_array((void **)&st->value, n, sizeof *st->value, "triangle values"), fail);
    GS_TRY(err, gs_alloc_array((void **)&st->label, n, sizeof *st->label, "triangle labels"), fail);
    GS_TRY(err, gs_alloc_array((void **)&st->lo, n, sizeof *st->lo, "triangle ranges"), fail);
    GS_TRY(err, gs_alloc_array((void **)&st->hi, n, sizeof *st->hi, "triangle ranges"), fail);
    return GS_OK;
fail:
    gs_micro_state_free(st);
    return err;
}

gs_err gs_micro_state_copy(gs_micro_state *dst, const gs_micro_state *src)
{
    gs_micro_state t;
    GS_CALL(state_alloc(&t, src->ntris, src->nbins));
    size_t n = src->ntris;
    t.seed = src->seed;
    t.step = src->step;
    t.rng = src->rng;
    memcpy(t.placed, src->placed, 2 * (size_t)src->nbins * sizeof *t.placed);
    memcpy(t.value, src->value, n * sizeof *t.value);
    memcpy(t.label, src->label, n * sizeof *t.label);
    memcpy(t.lo, src->lo, n * sizeof *t.lo);
    memcpy(t.hi, src->hi, n * sizeof *t.hi);
    *dst = t;
    return GS_OK;
}

uint64_t gs_micro_state_digest(const gs_micro_state *st)
{
    gs_digest dg;
    if (!gs_digest_init(&dg))
        return 0;
    gs_digest_update(&dg, st->label, (size_t)st->ntris * sizeof *st->label);
    gs_digest_update(&dg, st->value, (size_t)st->ntris * sizeof *st->value);
    return gs_digest_final(&dg);
}

static gs_err check_inputs(const gs_micro_dual *d, const gs_micro_hist *h)
{
    GS_CHECK(h->nbins >= 1 && 2 * (uint64_t)h->nbins < GS_MICRO_FILLED, GS_ERR_ARG,
             "histogram with %u bins per side: expected [1, %u]", h->nbins, (GS_MICRO_FILLED - 1) / 2);
    int64_t sum = 0;
    for (uint32_t i = 0; i < 2 * h->nbins; i++) {
        GS_CHECK(h->count[i] >= 0, GS_ERR_ARG, "histogram bin %u has count %lld: expected >= 0", i,
                 (long long)h->count[i]);
        sum += h->count[i];
    }
    GS_CHECK(sum == (int64_t)d->ntris, GS_ERR_ARG,
             "histogram counts sum to %lld but the mesh has %u triangles", (long long)sum, d->ntris);
    return GS_OK;
}

static gs_err recon_alloc(const gs_micro_dual *d, const gs_micro_hist *h, const gs_micro_recon_opts *opts,
                          gs_micro_recon_t *out)
{
    struct gs_micro_recon *r = gs_calloc(1, sizeof *r);
    GS_CHECK(r, GS_ERR_MEM, "reconstruction");
    r->d = d;
    r->h = h;
    if (opts)
        r->o = *opts;
    else
        gs_micro_recon_defaults(&r->o);
    uint32_t n = d->ntris, K = h->nbins;
    gs_err err = GS_OK;
    GS_TRY(err, state_alloc(&r->st, n, K), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->demand, 2 * (size_t)K, sizeof *r->demand, "bin demand"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->delta, 2 * (size_t)K, sizeof *r->delta, "bin demand"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->delta_bins, 2 * (size_t)K, sizeof *r->delta_bins, "bin demand"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->cand, n, sizeof *r->cand, "candidates"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->forced, n, sizeof *r->forced, "candidates"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->live, n, sizeof *r->live, "candidates"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->near, n, sizeof *r->near, "candidates"), fail);
    r->cap_near = n;
    GS_TRY(err, gs_alloc_array((void **)&r->innear, n, sizeof *r->innear, "candidates"), fail);
    for (uint32_t j = 0; j < n; j++)
        r->live[j] = j;
    r->nlive = n;
    GS_TRY(err, gs_micro_geo_create(d, &r->geo), fail);
    *out = r;
    return GS_OK;
fail:
    gs_micro_recon_destroy(&r);
    return err;
}

static void recompute_demand(struct gs_micro_recon *r)
{
    const gs_micro_state *st = &r->st;
    uint32_t K = st->nbins;
    for (uint32_t i = 0; i < 2 * st->nbins; i++)
        r->demand[i] = st->placed[i];
    for (int s = 0; s < 2; s++) {
        r->band[s] = 0;
        r->band_cap[s] = r->h->count[gs_micro_bin_index(K, 1 - s, 0)];
        for (uint32_t k = 0; k < K; k++)
            r->band_cap[s] += r->h->count[gs_micro_bin_index(K, s, k)];
    }
    for (uint32_t j = 0; j < st->ntris; j++) {
        r->band[0] += bound(st, 0, j) > -1;
        r->band[1] += bound(st, 1, j) > -1;
        if (st->label[j] != GS_MICRO_UNASSIGNED)
            continue;
        uint32_t b = commit_bin(st, j);
        if (b != UINT32_MAX)
            r->demand[b]++;
    }
}

static void step_rng(gs_micro_state *st)
{
    gs_rng g;
    gs_rng_init(&g, st->seed, gs_rng_stream_id(MICRO_RNG_DOMAIN, st->step, 0, 0));
    st->rng = gs_rng_save(&g);
}

gs_err gs_micro_recon_create(const gs_micro_dual *d, const gs_micro_hist *h, const gs_micro_recon_opts *opts,
                             uint64_t seed, gs_micro_recon_t *out)
{
    GS_CALL(check_inputs(d, h));
    struct gs_micro_recon *r;
    GS_CALL(recon_alloc(d, h, opts, &r));
    gs_micro_state *st = &r->st;
    st->seed = seed;
    st->step = 0;
    double K = (double)h->nbins;
    for (uint32_t j = 0; j < d->ntris; j++) {
        st->label[j] = GS_MICRO_UNASSIGNED;
        st->lo[j] = -K;
        st->hi[j] = K;
    }
    step_rng(st);
    recompute_demand(r);
    *out = r;
    return GS_OK;
}

gs_err gs_micro_recon_resume(const gs_micro_dual *d, const gs_micro_hist *h, const gs_micro_recon_opts *opts,
                             const gs_micro_state *src, gs_micro_recon_t *out)
{
    GS_CALL(check_inputs(d, h));
    GS_CHECK(src->ntris == d->ntris && src->nbins == h->nbins, GS_ERR_ARG,
             "saved reconstruction has %u triangles and %u bins, the input %u and %u", src->ntris,
             src->nbins, d->ntris, h->nbins);
    GS_CHECK(src->step <= 2 * src->nbins + 1, GS_ERR_ARG, "saved reconstruction step %u: expected <= %u",
             src->step, 2 * src->nbins + 1);
    for (uint32_t j = 0; j < src->ntris; j++) {
        uint16_t l = src->label[j];
        GS_CHECK(l == GS_MICRO_UNASSIGNED || l == GS_MICRO_FILLED || l < 2 * src->nbins, GS_ERR_ARG,
                 "saved reconstruction: triangle %u has label %u", j, l);
    }
    struct gs_micro_recon *r;
    GS_CALL(recon_alloc(d, h, opts, &r));
    gs_micro_state_free(&r->st);
    gs_err err = gs_micro_state_copy(&r->st, src);
    if (err != GS_OK) {
        gs_micro_recon_destroy(&r);
        GS_CALL(err);
    }
    recompute_demand(r);
    *out = r;
    return GS_OK;
}

void gs_micro_recon_destroy(gs_micro_recon_t *rp)
{
    struct gs_micro_recon *r = *rp;
    if (!r)
        return;
    gs_micro_state_free(&r->st);
    gs_free(r->demand);
    gs_free(r->delta);
    gs_free(r->delta_bins);
    gs_free(r->cand);
    gs_free(r->forced);
    gs_free(r->live);
    gs_free(r->near);
    gs_free(r->innear);
    gs_free(r->rec_t);
    gs_free(r->rec_b);
    gs_micro_geo_destroy(&r->geo);
    gs_free(r);
    *rp = NULL;
}

const gs_micro_state *gs_micro_recon_state(gs_micro_recon_t r)
{
    return &r->st;
}

gs_micro_recon_counters gs_micro_recon_counters_get(gs_micro_recon_t r)
{
    return r->c;
}

/* Labels j from bin idx with value x and moves it out of its commitment. */
static void assign(struct gs_micro_recon *r, uint32_t j, uint32_t idx, double x)
{
    gs_micro_state *st = &r->st;
    uint32_t old = commit_bin(st, j);
    if (old != UINT32_MAX)
        r->demand[old]--;
    r->demand[idx]++;
    st->placed[idx]++;
    st->label[j] = (uint16_t)idx;
    st->value[j] = x;
    r->band[0] -= bound(st, 0, j) > -1;
    r->band[1] -= bound(st, 1, j) > -1;
    st->lo[j] = st->hi[j] = x;
    r->band[0] += bound(st, 0, j) > -1;
    r->band[1] += bound(st, 1, j) > -1;
}

static gs_err record_push(struct gs_micro_recon *r, size_t n, uint32_t j, double b)
{
    if (n == r->cap_rec) {
        size_t cap = r->cap_rec ? 2 * r->cap_rec : 4096;
        uint32_t *t = gs_realloc(r->rec_t, cap * sizeof *t);
        GS_CHECK(t, GS_ERR_MEM, "propagation record of %zu entries", cap);
        r->rec_t = t;
        double *x = gs_realloc(r->rec_b, cap * sizeof *x);
        GS_CHECK(x, GS_ERR_MEM, "propagation record of %zu entries", cap);
        r->rec_b = x;
        r->cap_rec = cap;
    }
    r->rec_t[n] = j;
    r->rec_b[n] = b;
    return GS_OK;
}

/* Pruned Dijkstra from c for a side-s value a (mirrored): records every
 * unassigned triangle whose side-s bound a - d tightens, out to radius
 * a + floor_b (bounds below -floor_b are never read). With check, it also
 * sums the demand change per bin (triangles whose lo moves into a higher bin
 * leave their old bin, c leaves its commitment for bin idx) and gives up as
 * soon as a bin would exceed its count: the search runs in increasing
 * distance, i.e. decreasing new bound, and a triangle leaves bin k only for a
 * bound above k + 1, so every departure from bin k comes before the first
 * arrival in it and the first overflow is final. *ok = 0 then. */
static gs_err probe(struct gs_micro_recon *r, uint32_t c, int s, double a, double floor_b, uint32_t idx,
                    int check, size_t *nrec, int *ok)
{
    struct gs_micro_geo *g = r->geo;
    const gs_micro_state *st = &r->st;
    const int64_t *count = r->h->count;
    uint32_t K = st->nbins, ntb = 0;
    micro_geo_reset(g);
    size_t n = 0;
    int64_t dband = 0;
    *ok = 1;
#define DELTA(bin, v)                                                                              \
    do {                                                                                           \
        if (r->delta[bin] == 0)                                                                    \
            r->delta_bins[ntb++] = (bin);                                                          \
        r->delta[bin] += (v);                                                                      \
        if (r->demand[bin] + r->delta[bin] > count[bin])                                           \
            *ok = 0;                                                                               \
    } while (0)
#define BAND(old, nb)                                                                              \
    do {                                                                                           \
        if ((old) <= -1 && (nb) > -1 && r->band[s] + ++dband > r->band_cap[s])                   \
            *ok = 0;                                                                               \
    } while (0)
    if (check) {
        uint32_t oc = commit_bin(st, c);
        if (oc != idx) {
            if (oc != UINT32_MAX)
                DELTA(oc, -1);
            DELTA(idx, 1);
        }
        BAND(bound(st, s, c), a);
    }
    GS_CALL(micro_geo_seed(g, c));
    double du;
    uint32_t u;
    double radius = a + floor_b;
    while (*ok && micro_heap_pop(&g->heap, &du, &u)) {
        if (du > g->dist[u])
            continue;
        r->c.dijkstra_nodes++;
        if (u != c) {
            if (st->label[u] != GS_MICRO_UNASSIGNED)
                continue; /* assigned: bound already exact, nothing behind changes */
            double nb = a - du;
            if (nb <= bound(st, s, u))
                continue; /* not tightened: prune */
            GS_CALL(record_push(r, n++, u, nb));
            if (check)
                BAND(bound(st, s, u), nb);
            if (check && nb >= 0) {
                uint32_t k = nb >= (double)(K - 1) ? K - 1 : (uint32_t)nb;
                uint32_t nbin = gs_micro_bin_index(K, s, k), obin = commit_bin(st, u);
                if (nbin != obin) {
                    if (obin != UINT32_MAX)
                        DELTA(obin, -1);
                    DELTA(nbin, 1);
                }
            }
        }
        GS_CALL(micro_geo_relax(g, u, du, radius));
    }
#undef DELTA
#undef BAND
    for (uint32_t i = 0; i < ntb; i++)
        r->delta[r->delta_bins[i]] = 0;
    *nrec = n;
    return GS_OK;
}

/* Cheap exact pre-test for a side-s placement at a = m >= 1 while bin
 * (s, m-1) is full: an unassigned neighbour j at distance w < 1 would get the
 * bound m - w, in bin m-1, and if b(c) + w < m - 1 then b(j) <= b(c) + w (the
 * bounds are 1-Lipschitz) says j is not yet committed there, so the probe
 * would overflow bin m-1 and reject. Saves the search for most rejections. */
static int sure_overflow(const struct gs_micro_recon *r, uint32_t c, int s, double a)
{
    const gs_micro_dual *d = r->d;
    const gs_micro_state *st = &r->st;
    double bc = bound(st, s, c);
    for (uint32_t k = d->roff[c]; k < d->roff[c + 1]; k++) {
        double w = d->rw[k];
        if (w < 1 && bc + w < a - 1 - 1e-9 && st->label[d->radj[k]] == GS_MICRO_UNASSIGNED)
            return 1;
    }
    return 0;
}

/* Appends j to the near pool (which can outgrow n: a rejected seed may come
 * back, see run_bin). */
static gs_err near_push(struct gs_micro_recon *r, size_t *nn, uint32_t j)
{
    if (*nn == r->cap_near) {
        size_t cap = 2 * r->cap_near + 16;
        uint32_t *p = gs_realloc(r->near, cap * sizeof *p);
        GS_CHECK(p, GS_ERR_MEM, "near pool of %zu entries", cap);
        r->near = p;
        r->cap_near = cap;
    }
    r->near[(*nn)++] = j;
    r->innear[j] = 1;
    return GS_OK;
}

static int cmp_forced(const void *x, const void *y)
{
    const forced_item *a = x, *b = y;
    if (a->b != b->b)
        return a->b > b->b ? -1 : 1;
    return a->t < b->t ? -1 : a->t > b->t;
}

static gs_err run_bin(struct gs_micro_recon *r)
{
    gs_micro_state *st = &r->st;
    uint32_t K = st->nbins;
    uint32_t m = K - 1 - st->step / 2;
    int s = (int)(st->step % 2);
    uint32_t idx = gs_micro_bin_index(K, s, m);
    int64_t count = r->h->count[idx];
    double a = (double)m;

    /* One pass over the still unlabelled triangles (the list shrinks as the
     * run proceeds) collects the forced ones and the random candidates.
     * Forced assignments change no other range (see the file comment), so
     * the candidate set stays valid after them; candidates are re-checked
     * when drawn anyway. */
    forced_item *f = r->forced;
    size_t nf = 0, nc = 0, nn = 0, keep = 0;
    for (size_t i = 0; i < r->nlive; i++) {
        uint32_t j = r->live[i];
        if (st->label[j] != GS_MICRO_UNASSIGNED)
            continue;
        r->live[keep++] = j;
        double b = bound(st, s, j);
        if (b >= a && b < a + 1 && commit_bin(st, j) == idx)
            f[nf++] = (forced_item){b, j};
        if (b <= a && bound(st, 1 - s, j) <= -a) {
            r->cand[nc++] = j;
            if (b >= a - 2)
                GS_CALL(near_push(r, &nn, j));
        }
    }
    r->nlive = keep;

    /* 1. Forced: range at or beyond the bin on this side, most extreme first. */
    qsort(f, nf, sizeof *f, cmp_forced);
    for (size_t i = 0; i < nf && st->placed[idx] < count; i++) {
        double x = s ? -f[i].b : f[i].b;
        assign(r, f[i].t, idx, x == 0 ? 0.0 : x);
        r->c.forced++;
    }
    if (st->placed[idx] >= count) {
        for (size_t i = 0; i < nn; i++)
            r->innear[r->near[i]] = 0;
        return GS_OK;
    }

    /* 2. Random placements at the bin's inner edge. Candidates are drawn
     * without replacement (incremental Fisher-Yates) and re-checked on draw,
     * since earlier placements shrink ranges. While the next lower bin is
     * full, a seed whose range starts below m - 2 would push its first ring
     * (distance < 1, bound in bin m-1) into that full bin (the bounds are
     * 1-Lipschitz), so draws then come from the "near" pool (range reaching
     * m - 2, i.e. next to higher structures) only, and the bin ends when that
     * pool is used up. This keeps the cost per bin proportional to the seeds
     * placed instead of to the mesh. The pool also takes in every triangle an
     * accepted placement of this bin lifts to a bound >= m - 2, so once the
     * lower bin is full the bin's own plateaus grow (a seed beside one needs
     * next to no new room in the lower bin) instead of the bin stopping short
     * (top bins of a random distribution lost most of their counts so).
     * When the whole candidate pool has been drawn, draws go on from the near
     * pool; a seed rejected for capacity may rejoin it when a later accepted
     * placement tightens its range (its neighbourhood then has more room
     * committed), so the pool only grows with accepted placements and the
     * bin ends. */
    gs_rng rng;
    gs_rng_restore(&rng, st->rng);
    double value = s && a != 0 ? -a : a;
    uint64_t rejects = 0;
    uint32_t lower = m > 0 ? gs_micro_bin_index(K, s, m - 1) : idx;
    size_t ic = 0, in = 0;
    while (st->placed[idx] < count) {
        int lower_full = r->o.capacity && m > 0 && r->demand[lower] >= r->h->count[lower];
        int use_near = lower_full || (r->o.capacity && ic >= nc);
        uint32_t *pool = use_near ? r->near : r->cand;
        size_t *pi = use_near ? &in : &ic, pn = use_near ? nn : nc;
        if (*pi >= pn)
            break;
        size_t i = (*pi)++;
        size_t pick = i + (size_t)gs_rng_below(&rng, pn - i);
        uint32_t c = pool[pick];
        pool[pick] = pool[i];
        pool[i] = c;
        if (st->label[c] != GS_MICRO_UNASSIGNED || bound(st, s, c) > a || bound(st, 1 - s, c) > -a)
            continue;
        if (r->o.capacity && lower_full && sure_overflow(r, c, s, a)) {
            r->innear[c] = 0;
            r->c.random_rejected++;
            if (++rejects >= r->o.max_rejects_per_bin && r->o.max_rejects_per_bin)
                break;
            continue;
        }
        size_t nrec;
        int ok;
        GS_CALL(probe(r, c, s, a, a, idx, r->o.capacity, &nrec, &ok));
        if (!ok) {
            r->innear[c] = 0;
            r->c.random_rejected++;
            if (++rejects >= r->o.max_rejects_per_bin && r->o.max_rejects_per_bin)
                break;
            continue;
        }
        for (size_t k = 0; k < nrec; k++) {
            uint32_t j = r->rec_t[k];
            uint32_t ob = commit_bin(st, j);
            r->band[s] += bound(st, s, j) <= -1 && r->rec_b[k] > -1;
            if (s)
                st->hi[j] = -r->rec_b[k];
            else
                st->lo[j] = r->rec_b[k];
            uint32_t nb = commit_bin(st, j);
            if (ob != nb) {
                if (ob != UINT32_MAX)
                    r->demand[ob]--;
                if (nb != UINT32_MAX)
                    r->demand[nb]++;
            }
            /* The near pool grows with this bin's own structures: a seed
             * next to a plateau already placed at a costs the full lower
             * bin little or nothing (its ring is mostly committed), where an
             * isolated one is rejected. Record order is deterministic. */
            if (r->o.capacity && r->rec_b[k] >= a - 2 && !r->innear[j])
                GS_CALL(near_push(r, &nn, j));
        }
        assign(r, c, idx, value);
        r->c.random_accepted++;
    }
    for (size_t i = 0; i < nn; i++)
        r->innear[r->near[i]] = 0;
    return GS_OK;
}

/* Neighbour fill: every triangle still unlabelled gets the mean of its
 * labelled neighbours, clamped to the exact admissible range (all labelled
 * triangles within 2K, the farthest any constraint can bind). Breadth-first
 * from the labelled region, so each one has a labelled neighbour. */
static gs_err run_fill(struct gs_micro_recon *r)
{
    gs_micro_state *st = &r->st;
    const gs_micro_dual *d = r->d;
    uint32_t n = st->ntris;
    double K = (double)st->nbins;
    uint32_t *queue = r->cand;
    uint8_t *seen = NULL;
    GS_CALL(gs_alloc_array((void **)&seen, n, 1, "fill queue"));
    size_t head = 0, tail = 0;
    for (uint32_t j = 0; j < n; j++) {
        if (st->label[j] != GS_MICRO_UNASSIGNED)
            continue;
        for (uint32_t k = d->off[j]; k < d->off[j + 1]; k++)
            if (st->label[d->adj[k]] != GS_MICRO_UNASSIGNED) {
                queue[tail++] = j;
                seen[j] = 1;
                break;
            }
    }
    gs_err err = GS_OK;
    for (uint32_t next = 0;;) {
        if (head == tail) {
            /* A component without any labelled triangle starts at its lowest index. */
            while (next < n && (st->label[next] != GS_MICRO_UNASSIGNED || seen[next]))
                next++;
            if (next == n)
                break;
            seen[next] = 1;
            queue[tail++] = next;
        }
        uint32_t j = queue[head++];
        double sum = 0;
        int cnt = 0;
        for (uint32_t k = d->off[j]; k < d->off[j + 1]; k++) {
            uint32_t u = d->adj[k];
            if (st->label[u] != GS_MICRO_UNASSIGNED)
                sum += st->value[u], cnt++;
            else if (!seen[u])
                seen[u] = 1, queue[tail++] = u;
        }
        double v = cnt ? sum / cnt : 0;
        const uint32_t *bt;
        const double *bd;
        size_t nb;
        GS_TRY(err, gs_micro_geo_ball(r->geo, j, 2 * K, &bt, &bd, &nb), done);
        double lo = -INFINITY, hi = INFINITY;
        for (size_t i = 0; i < nb; i++) {
            uint32_t u = bt[i];
            if (st->label[u] == GS_MICRO_UNASSIGNED)
                continue;
            lo = fmax(lo, st->value[u] - bd[i]);
            hi = fmin(hi, st->value[u] + bd[i]);
        }
        v = lo > hi ? 0.5 * (lo + hi) : fmin(fmax(v, lo), hi);
        st->value[j] = v == 0 ? 0.0 : v;
        st->label[j] = GS_MICRO_FILLED;
        st->lo[j] = st->hi[j] = st->value[j];
        r->c.filled++;
    }
done:
    gs_free(seen);
    return err;
}

gs_err gs_micro_recon_run(gs_micro_recon_t r, uint32_t max_steps, int *done)
{
    gs_micro_state *st = &r->st;
    uint32_t last = 2 * st->nbins + 1;
    for (uint32_t k = 0; st->step < last && (max_steps == 0 || k < max_steps); k++) {
        if (st->step < 2 * st->nbins)
            GS_CALL(run_bin(r));
        else
            GS_CALL(run_fill(r));
        st->step++;
        step_rng(st);
    }
    *done = st->step >= last;
    return GS_OK;
}

gs_err gs_micro_reconstruct(const gs_micro_dual *d, const gs_micro_hist *h, const gs_micro_recon_opts *opts,
                            uint64_t seed, double *value, uint16_t *label)
{
    gs_micro_recon_t r;
    GS_CALL(gs_micro_recon_create(d, h, opts, seed, &r));
    int done = 0;
    gs_err err = gs_micro_recon_run(r, 0, &done);
    if (err == GS_OK) {
        memcpy(value, r->st.value, (size_t)d->ntris * sizeof *value);
        memcpy(label, r->st.label, (size_t)d->ntris * sizeof *label);
    }
    gs_micro_recon_destroy(&r);
    GS_CALL(err);
    return GS_OK;
}
