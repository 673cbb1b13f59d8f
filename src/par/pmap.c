/* The parallel map with adaptive shares; see include/geosynth/pmap.h. */
#include "geosynth/pmap.h"

#include <limits.h>
#include <string.h>

#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/partition.h"

gs_err gs_pmap_init(gs_pmap *m, MPI_Comm comm, const gs_pmap_hooks *hooks)
{
    m->comm = comm;
    GS_CALL(gs_par_comm_rank(comm, &m->rank, &m->size));
    memset(&m->hooks, 0, sizeof m->hooks);
    if (hooks)
        m->hooks = *hooks;
    for (int r = 0; r < m->size && r < GS_PMAP_MAX_RANKS_ADAPTIVE; r++)
        m->share[r] = 1.0 / m->size;
    return GS_OK;
}

static gs_err pmap_agree(const gs_pmap *m, gs_err local)
{
    if (m->hooks.agree)
        return m->hooks.agree(m->hooks.user, m->comm, local);
    return gs_par_agree(m->comm, local);
}

/* Items [start, start + count) of rank r out of n under the shares. */
static void pmap_split(const gs_pmap *m, uint64_t n, int r, uint64_t *start, uint64_t *count)
{
    if (m->size > GS_PMAP_MAX_RANKS_ADAPTIVE) {
        int64_t lo = 0, hi = 0;
        (void)gs_partition((int64_t)n, m->size, r, &lo, &hi); /* valid arguments */
        *start = (uint64_t)lo;
        *count = (uint64_t)(hi - lo);
        return;
    }
    double cum = 0;
    for (int q = 0; q < r; q++)
        cum += m->share[q];
    uint64_t lo = r == 0 ? 0 : (uint64_t)(cum * (double)n);
    uint64_t hi = r == m->size - 1 ? n : (uint64_t)((cum + m->share[r]) * (double)n);
    if (lo > n)
        lo = n;
    if (hi > n)
        hi = n;
    if (hi < lo)
        hi = lo;
    *start = lo;
    *count = hi - lo;
}

/* New shares from every rank's (items, seconds) of one map: half the old
 * share, half the measured speed; every rank keeps at least a tenth of an
 * equal share so its speed stays measured. Maps too short to time are
 * ignored. */
static void pmap_adapt(gs_pmap *m, const double *items, const double *seconds)
{
    if (m->size > GS_PMAP_MAX_RANKS_ADAPTIVE)
        return;
    double speed[GS_PMAP_MAX_RANKS_ADAPTIVE], total = 0;
    for (int r = 0; r < m->size; r++) {
        if (items[r] < 1 || seconds[r] < 2e-4)
            return;
        speed[r] = items[r] / seconds[r];
        total += speed[r];
    }
    double floor_share = 0.1 / m->size, sum = 0;
    for (int r = 0; r < m->size; r++) {
        double sh = 0.5 * m->share[r] + 0.5 * speed[r] / total;
        m->share[r] = sh < floor_share ? floor_share : sh;
        sum += m->share[r];
    }
    for (int r = 0; r < m->size; r++)
        m->share[r] /= sum;
}

/* The one-collective exchange: every rank sends its items, its status and
 * its compute seconds, then every rank copies all items into out and adapts
 * the shares. On a failure anywhere every rank returns it (the agreement
 * names the first). */
static gs_err pmap_exchange_with_status(gs_pmap *m, size_t n, size_t bytes, gs_err local,
                                        double seconds, void *out)
{
    enum { TRAILER = 2 * sizeof(int64_t) }; /* status, seconds */
    int size = m->size, rank = m->rank;
    int *counts = NULL, *displs = NULL;
    double *items = NULL, *secs = NULL;
    char *send = NULL, *recv = NULL;
    gs_err err = GS_OK;
    /* A failure before the exchange is local: the caller aborts every rank. */
    if (m->hooks.exchanging)
        GS_TRY(err, m->hooks.exchanging(m->hooks.user), done);
    GS_TRY(err, gs_alloc_array((void **)&counts, (size_t)size, 2 * sizeof *counts, "map counts"),
           done);
    GS_TRY(err, gs_alloc_array((void **)&items, (size_t)size, 2 * sizeof *items, "map counts"),
           done);
    displs = counts + size;
    secs = items + size;
    int off = 0;
    uint64_t mine_start = 0, mine_count = 0;
    for (int r = 0; r < size; r++) {
        uint64_t st, ct;
        pmap_split(m, n, r, &st, &ct);
        if (r == rank) {
            mine_start = st;
            mine_count = ct;
        }
        counts[r] = (int)(ct * bytes + TRAILER);
        displs[r] = off;
        off += counts[r];
    }
    GS_TRY(err, gs_alloc_array((void **)&send, (size_t)counts[rank], 1, "map exchange"), done);
    GS_TRY(err, gs_alloc_array((void **)&recv, (size_t)off, 1, "map exchange"), done);
    int64_t status = (int64_t)local;
    memcpy(send, (char *)out + mine_start * bytes, mine_count * bytes);
    memcpy(send + mine_count * bytes, &status, sizeof status);
    memcpy(send + mine_count * bytes + sizeof status, &seconds, sizeof seconds);
    GS_TRY(err, gs_par_allgatherv_bytes(m->comm, send, recv, counts, displs), done);
    int failed = 0;
    for (int r = 0; r < size; r++) {
        uint64_t st, ct;
        pmap_split(m, n, r, &st, &ct);
        const char *tail = recv + displs[r] + ct * bytes;
        memcpy(&status, tail, sizeof status);
        memcpy(&secs[r], tail + sizeof status, sizeof secs[r]);
        items[r] = (double)ct;
        failed |= status != GS_OK;
        if (r != rank)
            memcpy((char *)out + st * bytes, recv + displs[r], ct * bytes);
    }
    if (failed) /* every rank saw it: all of them agree on the message */
        err = pmap_agree(m, local);
    else
        pmap_adapt(m, items, secs);
done:
    gs_free(counts);
    gs_free(items);
    gs_free(send);
    gs_free(recv);
    return err;
}

gs_err gs_pmap_run(gs_pmap *m, size_t n, size_t bytes, gs_pmap_range_fn fn, void *ctx,
                   void *out)
{
    int size = m->size;
    uint64_t start, count;
    pmap_split(m, n, m->rank, &start, &count);
    double t0 = gs_time_now();
    gs_err err = count ? fn(ctx, (size_t)start, (size_t)(start + count),
                            (char *)out + (size_t)start * bytes)
                       : GS_OK;
    if (m->hooks.computed)
        err = m->hooks.computed(m->hooks.user, err);
    double seconds = gs_time_now() - t0;
    if (size > 1 && n > 0 && n <= GS_PMAP_ONE_EXCHANGE_BYTES / bytes) {
        GS_CALL(pmap_exchange_with_status(m, n, bytes, err, seconds, out));
        return GS_OK;
    }
    GS_CALL(pmap_agree(m, err));
    if (size == 1 || n == 0)
        return GS_OK;
    GS_CHECK(n < (size_t)INT_MAX && bytes < (size_t)INT_MAX, GS_ERR_ARG,
             "parallel map: %zu items of %zu bytes are too many for one exchange", n, bytes);
    int *counts = NULL, *displs = NULL;
    GS_CALL(gs_alloc_array((void **)&counts, (size_t)size, 2 * sizeof *counts, "map counts"));
    displs = counts + size;
    for (int r = 0; r < size; r++) {
        uint64_t st, ct;
        pmap_split(m, n, r, &st, &ct);
        counts[r] = (int)ct;
        displs[r] = (int)st;
    }
    gs_err rc = gs_par_allgatherv_items(m->comm, out, bytes, counts, displs);
    gs_free(counts);
    GS_CALL(rc);
    return GS_OK;
}
