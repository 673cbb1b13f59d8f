/* Distributed exact search with shared bounds; see psearch.h.
 *
 * Bound exchange: a rank whose local best beats every bound it has sent or
 * received sends it to all other ranks with MPI_Isend (tag TAG_BOUND) during
 * a poll; polls also MPI_Iprobe for bounds from others. At the end of the
 * query one MPI_Allgather carries each rank's best hit, status and number of
 * bound broadcasts; each rank then receives exactly the messages still
 * addressed to it (MPI keeps messages between two ranks on one tag in order,
 * so a later query's bounds are never taken for this one's) and completes
 * its own sends, leaving nothing pending on the communicator.
 */
#include "geosynth/psearch.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/partition.h"

enum { TAG_BOUND = 101 };

/* One bound broadcast in flight: the value must live until every send of it
 * completes. */
typedef struct bound_send {
    double value;
    int nreq;
    MPI_Request req[]; /* P - 1 */
} bound_send;

struct gs_psearch {
    MPI_Comm comm;
    int rank, size;
    int64_t ncand, lo, hi;
    int poll_every, poll_countdown;
    gs_psearch_stats stats;

    /* Per-query state. */
    int within;
    double scale;        /* 1 + eps in within mode, 1 otherwise */
    gs_psearch_hit local; /* best offered here, total order */
    double remote;        /* best distance received from other ranks */
    double sent;          /* last distance this rank broadcast */
    int64_t nbcast;       /* broadcasts this query */
    int64_t *received;    /* [size] bound messages received per source */
    int64_t *gathered;    /* [4 * size] end-of-query gather buffer */
    int64_t *counts;      /* [size] within mode: hits per rank */
    int *rcounts, *displs; /* [size] within mode: Allgatherv layout in bytes */
    gs_err err;           /* first failure in offer/poll (sticky per query) */
    bound_send **sends;   /* broadcasts whose sends may still be pending */
    int64_t nsends, cap_sends;
    gs_psearch_hit *hits; /* within mode: offered hits under the threshold */
    int64_t nhits, cap_hits;
};

static int hit_less(double d1, int64_t i1, double d2, int64_t i2)
{
    return d1 < d2 || (d1 == d2 && i1 < i2);
}

static int hit_cmp(const void *a, const void *b)
{
    const gs_psearch_hit *x = a, *y = b;
    if (hit_less(x->dist, x->index, y->dist, y->index))
        return -1;
    if (hit_less(y->dist, y->index, x->dist, x->index))
        return 1;
    return 0;
}

static double threshold(const gs_psearch_t ps)
{
    double d = ps->local.dist < ps->remote ? ps->local.dist : ps->remote;
    return ps->within ? d * ps->scale : d;
}

gs_err gs_psearch_create(MPI_Comm comm, int64_t ncand, const double *weights,
                         gs_psearch_t *out)
{
    int rank, size;
    GS_MPI(MPI_Comm_rank(comm, &rank));
    GS_MPI(MPI_Comm_size(comm, &size));
    int64_t lo, hi;
    if (weights)
        GS_CALL(gs_partition_weighted(ncand, weights, size, rank, &lo, &hi));
    else
        GS_CALL(gs_partition(ncand, size, rank, &lo, &hi));
    GS_CALL(gs_par_check_same_i64(comm, ncand, "psearch candidate count"));
    gs_psearch_t ps = gs_calloc(1, sizeof *ps);
    GS_CHECK(ps != NULL, GS_ERR_MEM, "psearch: cannot allocate the search context");
    ps->received = gs_calloc((size_t)size, sizeof *ps->received);
    ps->gathered = gs_calloc((size_t)size * 4, sizeof *ps->gathered);
    ps->counts = gs_calloc((size_t)size, sizeof *ps->counts);
    ps->rcounts = gs_calloc((size_t)size, sizeof *ps->rcounts);
    ps->displs = gs_calloc((size_t)size, sizeof *ps->displs);
    gs_err local = ps->received && ps->gathered && ps->counts && ps->rcounts && ps->displs
                   ? GS_OK
                   : gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                    "psearch: cannot allocate counters for %d ranks", size);
    int rc = local == GS_OK ? MPI_Comm_dup(comm, &ps->comm) : MPI_SUCCESS;
    if (rc != MPI_SUCCESS)
        local = gs_mpi_error(rc, "MPI_Comm_dup", __FILE__, __LINE__, __func__);
    if (local != GS_OK) {
        gs_free(ps->received);
        gs_free(ps->gathered);
        gs_free(ps->counts);
        gs_free(ps->rcounts);
        gs_free(ps->displs);
        gs_free(ps);
        return local;
    }
    MPI_Comm_set_errhandler(ps->comm, MPI_ERRORS_RETURN);
    ps->rank = rank;
    ps->size = size;
    ps->ncand = ncand;
    ps->lo = lo;
    ps->hi = hi;
    ps->poll_every = 64;
    ps->scale = 1.0;
    *out = ps;
    return GS_OK;
}

void gs_psearch_destroy(gs_psearch_t *pps)
{
    gs_psearch_t ps = pps ? *pps : NULL;
    if (!ps)
        return;
    MPI_Comm_free(&ps->comm);
    gs_free(ps->received);
    gs_free(ps->gathered);
    gs_free(ps->counts);
    gs_free(ps->rcounts);
    gs_free(ps->displs);
    gs_free(ps->sends);
    gs_free(ps->hits);
    gs_free(ps);
    *pps = NULL;
}

void gs_psearch_share(const gs_psearch_t ps, int64_t *lo, int64_t *hi)
{
    *lo = ps->lo;
    *hi = ps->hi;
}

void gs_psearch_set_poll_interval(gs_psearch_t ps, int every)
{
    ps->poll_every = every < 1 ? 1 : every;
}

gs_psearch_stats gs_psearch_get_stats(const gs_psearch_t ps) { return ps->stats; }

gs_err gs_psearch_bcast(gs_psearch_t ps, void *buf, int64_t bytes)
{
    GS_CHECK(bytes >= 0 && bytes <= INT_MAX, GS_ERR_ARG,
             "psearch: query of %lld bytes: expected at most %d", (long long)bytes, INT_MAX);
    GS_MPI(MPI_Bcast(buf, (int)bytes, MPI_BYTE, 0, ps->comm));
    return GS_OK;
}

/* Frees the oldest broadcasts whose sends have completed. */
static gs_err reap_sends(gs_psearch_t ps, int wait)
{
    int64_t done = 0;
    for (; done < ps->nsends; done++) {
        bound_send *b = ps->sends[done];
        if (wait) {
            GS_MPI(MPI_Waitall(b->nreq, b->req, MPI_STATUSES_IGNORE));
        } else {
            int flag = 0;
            GS_MPI(MPI_Testall(b->nreq, b->req, &flag, MPI_STATUSES_IGNORE));
            if (!flag)
                break;
        }
        gs_free(b);
    }
    if (done > 0) {
        memmove(ps->sends, ps->sends + done, (size_t)(ps->nsends - done) * sizeof *ps->sends);
        ps->nsends -= done;
    }
    return GS_OK;
}

static gs_err send_bound(gs_psearch_t ps, double value)
{
    if (ps->nsends == ps->cap_sends) {
        int64_t cap = ps->cap_sends ? 2 * ps->cap_sends : 8;
        bound_send **s = gs_realloc(ps->sends, (size_t)cap * sizeof *s);
        GS_CHECK(s != NULL, GS_ERR_MEM, "psearch: cannot grow the send list to %lld", (long long)cap);
        ps->sends = s;
        ps->cap_sends = cap;
    }
    bound_send *b = gs_malloc(sizeof *b + (size_t)(ps->size - 1) * sizeof(MPI_Request));
    GS_CHECK(b != NULL, GS_ERR_MEM, "psearch: cannot allocate a bound message");
    b->value = value;
    b->nreq = 0;
    ps->sends[ps->nsends++] = b; /* owned by the list from here on */
    for (int r = 0; r < ps->size; r++) {
        if (r == ps->rank)
            continue;
        GS_MPI(MPI_Isend(&b->value, 1, MPI_DOUBLE, r, TAG_BOUND, ps->comm, &b->req[b->nreq]));
        b->nreq++;
    }
    ps->sent = value;
    ps->nbcast++;
    ps->stats.bcasts++;
    return GS_OK;
}

static gs_err receive_bound(gs_psearch_t ps, int source)
{
    double v;
    GS_MPI(MPI_Recv(&v, 1, MPI_DOUBLE, source, TAG_BOUND, ps->comm, MPI_STATUS_IGNORE));
    ps->received[source]++;
    ps->stats.msgs_received++;
    if (v < ps->remote)
        ps->remote = v;
    return GS_OK;
}

static gs_err poll_network(gs_psearch_t ps)
{
    ps->stats.polls++;
    double mine = ps->local.dist;
    if (mine < ps->sent && mine < ps->remote)
        GS_CALL(send_bound(ps, mine));
    for (;;) {
        int flag = 0;
        MPI_Status st;
        GS_MPI(MPI_Iprobe(MPI_ANY_SOURCE, TAG_BOUND, ps->comm, &flag, &st));
        if (!flag)
            break;
        GS_CALL(receive_bound(ps, st.MPI_SOURCE));
    }
    GS_CALL(reap_sends(ps, 0));
    return GS_OK;
}

double gs_psearch_bound(gs_psearch_t ps)
{
    if (--ps->poll_countdown <= 0) {
        ps->poll_countdown = ps->poll_every;
        if (ps->size > 1 && ps->err == GS_OK)
            ps->err = poll_network(ps);
    }
    return threshold(ps);
}

static gs_err keep_hit(gs_psearch_t ps, double dist, int64_t index)
{
    if (ps->nhits == ps->cap_hits) {
        /* Drop hits the threshold has overtaken before growing. */
        double t = threshold(ps);
        int64_t k = 0;
        for (int64_t j = 0; j < ps->nhits; j++)
            if (ps->hits[j].dist <= t)
                ps->hits[k++] = ps->hits[j];
        ps->nhits = k;
        if (k > ps->cap_hits / 2 || ps->cap_hits == 0) {
            int64_t cap = ps->cap_hits ? 2 * ps->cap_hits : 256;
            void *h = NULL;
            size_t bytes;
            GS_CHECK(gs_mul_size((size_t)cap, sizeof *ps->hits, &bytes), GS_ERR_MEM,
                     "psearch: hit list of %lld entries overflows", (long long)cap);
            h = gs_realloc(ps->hits, bytes);
            GS_CHECK(h != NULL, GS_ERR_MEM, "psearch: cannot grow the hit list to %lld", (long long)cap);
            ps->hits = h;
            ps->cap_hits = cap;
        }
    }
    ps->hits[ps->nhits++] = (gs_psearch_hit){dist, index};
    return GS_OK;
}

void gs_psearch_offer(gs_psearch_t ps, double dist, int64_t index)
{
    if (ps->err != GS_OK)
        return;
    if (!(dist >= 0.0) || index < ps->lo || index >= ps->hi) {
        ps->err = gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                                 "psearch: offered candidate %lld at distance %g: expected an "
                                 "index in this rank's share [%lld, %lld) and a distance >= 0",
                                 (long long)index, dist, (long long)ps->lo, (long long)ps->hi);
        return;
    }
    ps->stats.offers++;
    if (hit_less(dist, index, ps->local.dist, ps->local.index))
        ps->local = (gs_psearch_hit){dist, index};
    if (ps->within && dist <= threshold(ps))
        ps->err = keep_hit(ps, dist, index);
}

static void begin_query(gs_psearch_t ps, int within, double scale)
{
    ps->within = within;
    ps->scale = scale;
    ps->local = (gs_psearch_hit){INFINITY, -1};
    ps->remote = INFINITY;
    ps->sent = INFINITY;
    ps->nbcast = 0;
    ps->err = GS_OK;
    ps->nhits = 0;
    ps->poll_countdown = 1; /* poll at the first bound request */
    memset(ps->received, 0, (size_t)ps->size * sizeof *ps->received);
    ps->stats.queries++;
}

/* Runs the callback, then the one collective of the query: gathers every
 * rank's {best dist bits, best index, broadcasts sent, status}, drains the
 * bound messages, and agrees on failure. */
static gs_err run_query(gs_psearch_t ps, gs_psearch_fn fn, void *user, gs_psearch_hit *best)
{
    gs_err status = fn(user, ps, ps->lo, ps->hi);
    if (status == GS_OK)
        status = ps->err;
    int64_t mine[4];
    memcpy(&mine[0], &ps->local.dist, sizeof(double));
    mine[1] = ps->local.index;
    mine[2] = ps->nbcast;
    mine[3] = (int64_t)status;
    int64_t *all = ps->gathered;
    gs_err err = GS_OK;
    int rc = MPI_Allgather(mine, 4, MPI_INT64_T, all, 4, MPI_INT64_T, ps->comm);
    if (rc != MPI_SUCCESS) {
        err = gs_mpi_error(rc, "MPI_Allgather", __FILE__, __LINE__, __func__);
        goto done;
    }
    for (int s = 0; s < ps->size && err == GS_OK; s++)
        while (s != ps->rank && ps->received[s] < all[4 * s + 2] && err == GS_OK)
            err = receive_bound(ps, s);
    if (err == GS_OK)
        err = reap_sends(ps, 1);
    if (err != GS_OK)
        goto done;
    int any_failed = 0;
    gs_psearch_hit g = {INFINITY, -1};
    for (int s = 0; s < ps->size; s++) {
        if (all[4 * s + 3] != GS_OK)
            any_failed = 1;
        double d;
        memcpy(&d, &all[4 * s + 0], sizeof d);
        if (hit_less(d, all[4 * s + 1], g.dist, g.index))
            g = (gs_psearch_hit){d, all[4 * s + 1]};
    }
    if (any_failed) {
        err = gs_par_agree(ps->comm, status);
        goto done;
    }
    *best = g;
done:
    return err;
}

gs_err gs_psearch_best(gs_psearch_t ps, gs_psearch_fn fn, void *user, gs_psearch_hit *best)
{
    begin_query(ps, 0, 1.0);
    GS_CALL(run_query(ps, fn, user, best));
    return GS_OK;
}

gs_err gs_psearch_within(gs_psearch_t ps, double eps, gs_psearch_fn fn, void *user,
                         gs_psearch_hit **hits, int64_t *count)
{
    GS_CHECK(eps >= 0.0 && isfinite(eps), GS_ERR_ARG,
             "psearch: tolerance eps = %g: expected a finite value >= 0", eps);
    begin_query(ps, 1, 1.0 + eps);
    gs_psearch_hit best;
    GS_CALL(run_query(ps, fn, user, &best));
    /* The final threshold is computed exactly like the running one, from a
     * best distance that is <= every running bound, so no hit under it was
     * dropped while searching. */
    double t = best.dist * ps->scale;
    int64_t k = 0;
    for (int64_t j = 0; j < ps->nhits; j++)
        if (ps->hits[j].dist <= t)
            ps->hits[k++] = ps->hits[j];
    ps->nhits = k;
    int64_t *counts = ps->counts;
    int *rcounts = ps->rcounts, *displs = ps->displs;
    gs_psearch_hit *all = NULL;
    gs_err err = GS_OK;
    int rc = MPI_Allgather(&ps->nhits, 1, MPI_INT64_T, counts, 1, MPI_INT64_T, ps->comm);
    GS_TRY_CHECK(err, rc == MPI_SUCCESS, GS_ERR_MPI, done, "psearch: MPI_Allgather of hit counts failed");
    int64_t total = 0;
    for (int s = 0; s < ps->size; s++) {
        total += counts[s];
        GS_TRY_CHECK(err, total <= INT_MAX / (int64_t)sizeof(gs_psearch_hit), GS_ERR_ARG, done,
                     "psearch: %lld hits within (1 + %g) * %g exceed what one gather can carry "
                     "(%d): lower eps", (long long)total, eps, best.dist,
                     INT_MAX / (int)sizeof(gs_psearch_hit));
    }
    int off = 0;
    for (int s = 0; s < ps->size; s++) {
        rcounts[s] = (int)counts[s] * (int)sizeof(gs_psearch_hit);
        displs[s] = off;
        off += rcounts[s];
    }
    all = total ? gs_malloc((size_t)total * sizeof *all) : NULL;
    gs_err local = total == 0 || all ? GS_OK
            : gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                             "psearch: cannot allocate %lld hits", (long long)total);
    GS_TRY(err, gs_par_agree(ps->comm, local), done);
    rc = MPI_Allgatherv(ps->hits, rcounts[ps->rank], MPI_BYTE, all, rcounts, displs, MPI_BYTE,
                        ps->comm);
    GS_TRY_CHECK(err, rc == MPI_SUCCESS, GS_ERR_MPI, done, "psearch: MPI_Allgatherv of hits failed");
    if (total > 1)
        qsort(all, (size_t)total, sizeof *all, hit_cmp);
    *hits = all;
    *count = total;
    all = NULL;
done:
    gs_free(all);
    return err;
}
