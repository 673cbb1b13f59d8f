/* Colored regions with a rank-0 work queue; see regions.h.
 *
 * Queue protocol inside one color (tags on a private dup of the
 * communicator):
 *   worker -> 0  TAG_REQUEST  int64 status (GS_OK, or the worker's failure)
 *   0 -> worker  TAG_ASSIGN   int64 position in the region list, or -1 = done
 * Each worker starts a color with `prefetch` implicit requests: rank 0
 * answers them before computing anything itself, so nobody waits for rank
 * 0's first region. On receiving an assignment a worker sends one new
 * request, then computes; so it holds up to `prefetch` regions and rarely
 * waits while rank 0 is busy with its own region. Rank 0 therefore knows
 * how many requests each worker will still send (prefetch + assignments),
 * answers every one (with "done" once the queue is empty), and a color ends
 * with no message left pending. Waiting ranks yield the processor instead
 * of spinning (ranks are often oversubscribed). All sends are MPI_Isend so
 * neither side stalls while the other computes.
 *
 * Results are packed on each rank as records
 *   int64 id | int64 len | len bytes | zero padding to a multiple of 8
 * and exchanged with one MPI_Allgatherv after the color.
 */
#include "geosynth/regions.h"

#include <limits.h>
#include <sched.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "par/regions_impl.h"

enum { TAG_REQUEST = 201, TAG_ASSIGN = 202 };

/* ---- result buffers ---- */

gs_err gs_region_out_reserve(gs_region_out *out, size_t n, void **dst)
{
    if (n > out->cap - out->len) {
        size_t need;
        GS_CHECK(out->len <= SIZE_MAX - n && (need = out->len + n) <= (size_t)INT_MAX, GS_ERR_MEM,
                 "regions: result of %zu + %zu bytes is too large (at most 2 GiB per color)",
                 out->len, n);
        size_t cap = out->cap ? out->cap : 4096;
        while (cap < need)
            cap = cap > SIZE_MAX / 2 ? need : 2 * cap;
        unsigned char *p = gs_realloc(out->data, cap);
        GS_CHECK(p != NULL, GS_ERR_MEM, "regions: cannot grow a result buffer to %zu bytes", cap);
        out->data = p;
        out->cap = cap;
    }
    *dst = out->data + out->len;
    out->len += n;
    return GS_OK;
}

gs_err gs_region_out_append(gs_region_out *out, const void *data, size_t n)
{
    void *dst;
    GS_CALL(gs_region_out_reserve(out, n, &dst));
    if (n)
        memcpy(dst, data, n);
    return GS_OK;
}

/* ---- create / destroy ---- */

static int cmp_i64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

typedef struct color_key {
    int color;
    int64_t pos;
} color_key;

static int cmp_color_key(const void *a, const void *b)
{
    const color_key *x = a, *y = b;
    if (x->color != y->color)
        return x->color < y->color ? -1 : 1;
    return (x->pos > y->pos) - (x->pos < y->pos); /* input order inside a color */
}

static void free_sched(gs_regions_t s)
{
    gs_free(s->regions);
    gs_free(s->order);
    gs_free(s->colors);
    gs_free(s->pack.data);
    gs_free(s->gathered);
    gs_free(s->rcounts);
    gs_free(s->displs);
    gs_regions_free_conflicts(s);
    gs_free(s);
}

/* Local part of create: validation and indexing, no MPI. */
static gs_err build(gs_regions_t s, const gs_region *regions, int64_t count)
{
    GS_CHECK(count >= 0, GS_ERR_ARG, "regions: count %lld must be >= 0", (long long)count);
    GS_CALL(gs_alloc_array((void **)&s->regions, count ? (size_t)count : 1, sizeof *s->regions,
                           "region list"));
    GS_CALL(gs_alloc_array((void **)&s->order, count ? (size_t)count : 1, sizeof *s->order,
                           "region order"));
    GS_CALL(gs_alloc_array((void **)&s->gathered, (size_t)s->size * 2, sizeof *s->gathered,
                           "region gather buffer"));
    GS_CALL(gs_alloc_array((void **)&s->rcounts, (size_t)s->size, sizeof *s->rcounts, "counts"));
    GS_CALL(gs_alloc_array((void **)&s->displs, (size_t)s->size, sizeof *s->displs, "displs"));
    for (int64_t i = 0; i < count; i++) {
        GS_CHECK(regions[i].id >= 0 && regions[i].color >= 0, GS_ERR_ARG,
                 "regions: entry %lld has id %lld and color %d: expected both >= 0",
                 (long long)i, (long long)regions[i].id, regions[i].color);
        s->regions[i] = regions[i];
        s->order[i] = regions[i].id;
    }
    s->count = count;
    /* Unique ids (sort a copy, held in order for now). */
    qsort(s->order, (size_t)count, sizeof *s->order, cmp_i64);
    for (int64_t i = 1; i < count; i++)
        GS_CHECK(s->order[i] != s->order[i - 1], GS_ERR_ARG,
                 "regions: id %lld appears more than once", (long long)s->order[i]);
    color_key *keys = NULL;
    GS_CALL(gs_alloc_array((void **)&keys, count ? (size_t)count : 1, sizeof *keys, "color keys"));
    for (int64_t i = 0; i < count; i++)
        keys[i] = (color_key){s->regions[i].color, i};
    qsort(keys, (size_t)count, sizeof *keys, cmp_color_key);
    for (int64_t i = 0; i < count; i++)
        s->order[i] = keys[i].pos;
    gs_free(keys);
    int ncolors = 0;
    for (int64_t i = 0; i < count; i++)
        if (i == 0 || s->regions[s->order[i]].color != s->regions[s->order[i - 1]].color)
            ncolors++;
    GS_CALL(gs_alloc_array((void **)&s->colors, ncolors ? (size_t)ncolors : 1, sizeof *s->colors,
                           "color list"));
    int c = -1;
    for (int64_t i = 0; i < count; i++) {
        if (i == 0 || s->regions[s->order[i]].color != s->regions[s->order[i - 1]].color) {
            c++;
            s->colors[c] = (color_span){s->regions[s->order[i]].color, i, i};
        }
        s->colors[c].end = i + 1;
    }
    s->ncolors = ncolors;
    return GS_OK;
}

gs_err gs_regions_create(MPI_Comm comm, const gs_region *regions, int64_t count, uint64_t seed,
                         uint32_t rng_domain, gs_regions_t *out)
{
    gs_regions_t s = gs_calloc(1, sizeof *s);
    gs_err local = s ? GS_OK
                     : gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                      "regions: cannot allocate the scheduler");
    if (s) {
        GS_MPI(MPI_Comm_rank(comm, &s->rank));
        GS_MPI(MPI_Comm_size(comm, &s->size));
        s->seed = seed;
        s->domain = rng_domain;
        s->prefetch = 2;
        local = build(s, regions, count);
    }
    gs_err err = gs_par_agree(comm, local);
    if (err == GS_OK) {
        /* Field by field (the struct's padding bytes are not initialized),
         * chained so no allocation can fail here. */
        uint64_t h = 0;
        for (int64_t i = 0; i < count; i++) {
            int64_t f[3] = {(int64_t)h, regions[i].id, regions[i].color};
            h = gs_digest_bytes(f, sizeof f);
        }
        err = gs_par_check_same_i64(comm, count, "region count");
        if (err == GS_OK)
            err = gs_par_check_same_i64(comm, (int64_t)h, "region list digest");
    }
    if (err == GS_OK) {
        int rc = MPI_Comm_dup(comm, &s->comm);
        if (rc != MPI_SUCCESS)
            err = gs_mpi_error(rc, "MPI_Comm_dup", __FILE__, __LINE__, __func__);
        else
            MPI_Comm_set_errhandler(s->comm, MPI_ERRORS_RETURN);
    }
    if (err != GS_OK) {
        if (s)
            free_sched(s);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    *out = s;
    return GS_OK;
}

void gs_regions_destroy(gs_regions_t *ps)
{
    gs_regions_t s = ps ? *ps : NULL;
    if (!s)
        return;
    MPI_Comm_free(&s->comm);
    free_sched(s);
    *ps = NULL;
}

gs_regions_stats gs_regions_get_stats(const gs_regions_t s) { return s->stats; }

void gs_regions_set_prefetch(gs_regions_t s, int depth)
{
    s->prefetch = depth < 1 ? 1 : depth > GS_REGIONS_PREFETCH_MAX ? GS_REGIONS_PREFETCH_MAX : depth;
}

/* ---- one color ---- */

/* Runs region at position pos of the list and appends its record to the
 * pack. On failure the pack is left as before. */
gs_err gs_regions_compute_one(gs_regions_t s, int64_t pos, int pass, gs_region_run_fn run,
                              void *ctx)
{
    const gs_region *r = &s->regions[pos];
    size_t start = s->pack.len;
    int64_t header[2] = {r->id, 0};
    GS_CALL(gs_region_out_append(&s->pack, header, sizeof header));
    gs_rng rng;
    gs_rng_init(&rng, s->seed, gs_rng_stream_id(s->domain, (uint64_t)r->id, (uint64_t)pass, 0));
    double t0 = gs_time_now();
    gs_err err = run(ctx, r->id, r->color, pass, &rng, &s->pack);
    s->stats.t_compute += gs_time_now() - t0;
    if (err == GS_OK) {
        size_t len = s->pack.len - start - sizeof header;
        size_t pad = (8 - len % 8) % 8;
        static const unsigned char zeros[8] = {0};
        err = gs_region_out_append(&s->pack, zeros, pad);
        header[1] = (int64_t)len;
        if (err == GS_OK)
            memcpy(s->pack.data + start, header, sizeof header);
    }
    if (err != GS_OK) {
        s->pack.len = start;
        gs_error_add_context("region %lld, color %d, pass %d", (long long)r->id, r->color, pass);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    s->stats.computed++;
    return GS_OK;
}

int gs_regions_iprobe(MPI_Comm comm, int tag, int *flag, MPI_Status *st)
{
    int rc = MPI_Iprobe(MPI_ANY_SOURCE, tag, comm, flag, st);
    if (rc == MPI_SUCCESS && !*flag)
        rc = MPI_Iprobe(MPI_ANY_SOURCE, tag, comm, flag, st);
    return rc;
}

/* Waits for req without spinning a core away from a rank that computes
 * (ranks are often oversubscribed): MPI_Test, then yield the processor. */
static gs_err polite_wait(MPI_Request *req, double *waited)
{
    double t0 = gs_time_now();
    for (;;) {
        int flag = 0;
        GS_MPI(MPI_Test(req, &flag, MPI_STATUS_IGNORE));
        if (flag)
            break;
        sched_yield();
    }
    *waited += gs_time_now() - t0;
    return GS_OK;
}

/* Rank 0's view of the queue inside one color. */
typedef struct queue_state {
    int64_t next, end;   /* positions s->order[next..end) not handed out */
    int stop;            /* a failure anywhere: hand out "done" only */
    int64_t pending;     /* requests sent or still to be sent, not answered */
    MPI_Request *reply_req; /* [size * d] */
    int64_t *reply;         /* [size * d] */
    int64_t *assigned;   /* [size] regions handed to each worker */
    int64_t *started;    /* [size] explicit requests received = regions started */
    int64_t *owed;       /* [size] requests received (or implicit) not answered */
    int64_t *answered;   /* [size] */
} queue_state;

/* Answers the oldest owed request of worker w: a region, or -1 = done. */
static gs_err answer(gs_regions_t s, queue_state *q, int w, int give)
{
    int d = s->prefetch;
    size_t slot = (size_t)w * (size_t)d + (size_t)(q->answered[w] % d);
    GS_MPI(MPI_Wait(&q->reply_req[slot], MPI_STATUS_IGNORE));
    if (give) {
        q->reply[slot] = s->order[q->next++];
        q->assigned[w]++;
        q->pending++; /* the request this assignment will trigger */
    } else {
        q->reply[slot] = -1;
    }
    q->answered[w]++;
    q->owed[w]--;
    q->pending--;
    GS_MPI(MPI_Isend(&q->reply[slot], 1, MPI_INT64_T, w, TAG_ASSIGN, s->comm, &q->reply_req[slot]));
    return GS_OK;
}

/* Answers what can be answered now. Near the end of the queue (fewer
 * regions left than ranks) a worker that still holds an unstarted region
 * gets nothing more for now: the region stays in the queue for whoever is
 * free first (often rank 0), so prefetching does not unbalance the end of
 * a color. The worker's next request (sent when it starts its held region)
 * brings it back. */
static gs_err serve(gs_regions_t s, queue_state *q)
{
    for (int w = 1; w < s->size; w++)
        while (q->owed[w] > 0) {
            int empty = q->stop || q->next >= q->end;
            int holds = q->assigned[w] - q->started[w] > 0;
            if (!empty && holds && q->end - q->next < s->size)
                break;
            GS_CALL(answer(s, q, w, !empty));
        }
    return GS_OK;
}

/* Rank 0: serves the queue and computes regions between requests.
 * Every worker sends `prefetch` implicit requests plus one per assignment
 * it receives, so rank 0 knows exactly how many requests are still to come:
 * the color ends when the queue is empty and every one was answered. */
static gs_err coordinate(gs_regions_t s, const color_span *c, int pass, gs_region_run_fn run,
                         void *ctx, gs_err *status)
{
    int d = s->prefetch;
    size_t nslots = (size_t)s->size * (size_t)d;
    queue_state q = {.next = c->begin, .end = c->end};
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&q.reply_req, nslots, sizeof *q.reply_req, "requests"), done);
    GS_TRY(err, gs_alloc_array((void **)&q.reply, nslots, sizeof *q.reply, "replies"), done);
    int64_t **counters[] = {&q.assigned, &q.started, &q.owed, &q.answered};
    for (size_t i = 0; i < sizeof counters / sizeof counters[0]; i++)
        GS_TRY(err, gs_alloc_array((void **)counters[i], (size_t)s->size, sizeof(int64_t),
                                   "queue counters"), done);
    for (size_t i = 0; i < nslots; i++)
        q.reply_req[i] = MPI_REQUEST_NULL;
    for (int w = 1; w < s->size; w++)
        q.owed[w] = d; /* the implicit requests: everyone gets work first */
    q.pending = (int64_t)(s->size - 1) * d;
    GS_TRY(err, serve(s, &q), done);
    while (q.pending > 0 || (!q.stop && q.next < q.end)) {
        int have = 0;
        MPI_Status st;
        int rc = gs_regions_iprobe(s->comm, TAG_REQUEST, &have, &st);
        GS_TRY_CHECK(err, rc == MPI_SUCCESS, GS_ERR_MPI, done, "regions: MPI_Iprobe failed");
        if (!have) {
            if (!q.stop && q.next < q.end) {
                gs_err e = gs_regions_compute_one(s, s->order[q.next++], pass, run, ctx);
                if (e != GS_OK) {
                    *status = e;
                    q.stop = 1;
                }
                GS_TRY(err, serve(s, &q), done);
            } else {
                double t0 = gs_time_now();
                sched_yield();
                s->stats.t_wait += gs_time_now() - t0;
            }
            continue;
        }
        int64_t worker_status = GS_OK;
        int w = st.MPI_SOURCE;
        rc = MPI_Recv(&worker_status, 1, MPI_INT64_T, w, TAG_REQUEST, s->comm, MPI_STATUS_IGNORE);
        GS_TRY_CHECK(err, rc == MPI_SUCCESS, GS_ERR_MPI, done, "regions: MPI_Recv of a request failed");
        if (worker_status != GS_OK)
            q.stop = 1;
        q.started[w]++;
        q.owed[w]++;
        GS_TRY(err, serve(s, &q), done);
    }
    int rc = MPI_Waitall((int)nslots, q.reply_req, MPI_STATUSES_IGNORE);
    GS_TRY_CHECK(err, rc == MPI_SUCCESS, GS_ERR_MPI, done, "regions: MPI_Waitall failed");
done:
    gs_free(q.reply_req);
    gs_free(q.reply);
    gs_free(q.assigned);
    gs_free(q.started);
    gs_free(q.owed);
    gs_free(q.answered);
    return err;
}

/* Worker: depth requests outstanding; each assignment received triggers one
 * new request before the region is computed (prefetch). Replies come in
 * request order, so once "done" arrives every later reply is "done" too. */
static gs_err work(gs_regions_t s, int pass, gs_region_run_fn run, void *ctx, gs_err *status)
{
    int d = s->prefetch;
    MPI_Request req[GS_REGIONS_PREFETCH_MAX];
    int64_t request[GS_REGIONS_PREFETCH_MAX];
    for (int k = 0; k < d; k++)
        req[k] = MPI_REQUEST_NULL; /* the first d requests are implicit */
    int64_t outstanding = d, sent = 0;
    while (outstanding > 0) {
        int64_t assigned = -1;
        MPI_Request rreq;
        GS_MPI(MPI_Irecv(&assigned, 1, MPI_INT64_T, 0, TAG_ASSIGN, s->comm, &rreq));
        GS_CALL(polite_wait(&rreq, &s->stats.t_wait));
        outstanding--;
        if (assigned < 0)
            continue;
        int k = (int)(sent++ % d);
        GS_MPI(MPI_Wait(&req[k], MPI_STATUS_IGNORE));
        request[k] = (int64_t)*status;
        GS_MPI(MPI_Isend(&request[k], 1, MPI_INT64_T, 0, TAG_REQUEST, s->comm, &req[k]));
        outstanding++;
        if (*status == GS_OK)
            *status = gs_regions_compute_one(s, assigned, pass, run, ctx);
    }
    GS_MPI(MPI_Waitall(d, req, MPI_STATUSES_IGNORE));
    return GS_OK;
}

typedef struct result_ref {
    int64_t id;
    const unsigned char *buf;
    size_t len;
} result_ref;

static int cmp_ref(const void *a, const void *b)
{
    const result_ref *x = a, *y = b;
    return (x->id > y->id) - (x->id < y->id);
}

/* Exchange and apply, after the queue of one color is done. */
static gs_err exchange_apply(gs_regions_t s, const color_span *c, gs_region_apply_fn apply,
                             void *ctx, gs_err status)
{
    double t0 = gs_time_now();
    int64_t mine[2] = {(int64_t)s->pack.len, (int64_t)status};
    GS_MPI(MPI_Allgather(mine, 2, MPI_INT64_T, s->gathered, 2, MPI_INT64_T, s->comm));
    int64_t total = 0;
    int any_failed = 0;
    for (int r = 0; r < s->size; r++) {
        total += s->gathered[2 * r];
        any_failed |= s->gathered[2 * r + 1] != GS_OK;
    }
    if (any_failed)
        return gs_par_agree(s->comm, status);
    GS_CHECK(total <= INT_MAX, GS_ERR_ARG,
             "regions: results of color %d total %lld bytes: at most %d can be exchanged at "
             "once; use smaller regions", c->color, (long long)total, INT_MAX);
    int off = 0;
    for (int r = 0; r < s->size; r++) {
        s->rcounts[r] = (int)s->gathered[2 * r];
        s->displs[r] = off;
        off += s->rcounts[r];
    }
    int64_t nreg = c->end - c->begin;
    unsigned char *all = NULL;
    result_ref *refs = NULL;
    gs_err local = gs_alloc_array((void **)&all, total ? (size_t)total : 1, 1, "color results");
    if (local == GS_OK)
        local = gs_alloc_array((void **)&refs, nreg ? (size_t)nreg : 1, sizeof *refs, "result index");
    gs_err err = GS_OK;
    GS_TRY(err, gs_par_agree(s->comm, local), done);
    int rc = MPI_Allgatherv(s->pack.data, (int)s->pack.len, MPI_BYTE, all, s->rcounts, s->displs,
                            MPI_BYTE, s->comm);
    GS_TRY_CHECK(err, rc == MPI_SUCCESS, GS_ERR_MPI, done, "regions: MPI_Allgatherv of results failed");
    s->stats.bytes += total;
    double t1 = gs_time_now();
    s->stats.t_exchange += t1 - t0;
    /* Index the records; every region of the color exactly once. */
    int64_t n = 0;
    size_t at = 0;
    local = GS_OK;
    while (at < (size_t)total && local == GS_OK) {
        int64_t header[2];
        memcpy(header, all + at, sizeof header);
        size_t len = (size_t)header[1];
        if (n >= nreg || header[1] < 0 || len > (size_t)total - at - sizeof header) {
            local = gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                                   "regions: malformed result record at byte %zu of color %d",
                                   at, c->color);
            break;
        }
        refs[n++] = (result_ref){header[0], all + at + sizeof header, len};
        at += sizeof header + len + (8 - len % 8) % 8;
    }
    if (local == GS_OK) {
        qsort(refs, (size_t)n, sizeof *refs, cmp_ref);
        if (n != nreg)
            local = gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                                   "regions: color %d has %lld regions but %lld results came back",
                                   c->color, (long long)nreg, (long long)n);
    }
    for (int64_t i = 0; i < n && local == GS_OK; i++) {
        if (i > 0 && refs[i].id == refs[i - 1].id)
            local = gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                                   "regions: region %lld computed twice", (long long)refs[i].id);
        else
            local = apply(ctx, refs[i].id, refs[i].buf, refs[i].len);
        if (local != GS_OK)
            gs_error_add_context("applying region %lld of color %d", (long long)refs[i].id,
                                 c->color);
    }
    s->stats.t_apply += gs_time_now() - t1;
    GS_TRY(err, gs_par_agree(s->comm, local), done);
done:
    gs_free(all);
    gs_free(refs);
    return err;
}

gs_err gs_regions_run_pass(gs_regions_t s, int pass, gs_region_run_fn run,
                           gs_region_apply_fn apply, void *ctx)
{
    if (s->pred_off)
        return gs_regions_flow_pass(s, pass, run, apply, ctx);
    for (int ci = 0; ci < s->ncolors; ci++) {
        const color_span *c = &s->colors[ci];
        gs_err status = GS_OK;
        s->pack.len = 0;
        if (s->size == 1) {
            for (int64_t i = c->begin; i < c->end && status == GS_OK; i++)
                status = gs_regions_compute_one(s, s->order[i], pass, run, ctx);
        } else if (s->rank == 0) {
            GS_CALL(coordinate(s, c, pass, run, ctx, &status));
        } else {
            GS_CALL(work(s, pass, run, ctx, &status));
        }
        GS_CALL(exchange_apply(s, c, apply, ctx, status));
    }
    return GS_OK;
}

/* ---- region grids ---- */

gs_err gs_regions_grid(const int64_t dims[3], const int64_t size[3], int64_t overlap,
                       int64_t halo, gs_region_box **boxes, int64_t *count)
{
    static const char axis_name[3] = {'x', 'y', 'z'};
    int64_t nr[3];
    GS_CHECK(overlap >= 0 && halo >= 0, GS_ERR_ARG,
             "regions: overlap %lld and halo %lld must be >= 0", (long long)overlap, (long long)halo);
    for (int a = 0; a < 3; a++) {
        GS_CHECK(dims[a] >= 1 && size[a] >= 1, GS_ERR_ARG,
                 "regions: along %c the box has %lld cells and regions %lld: expected both >= 1",
                 axis_name[a], (long long)dims[a], (long long)size[a]);
        nr[a] = (dims[a] + size[a] - 1) / size[a];
        GS_CHECK(nr[a] < 3 || size[a] >= 2 * overlap + halo, GS_ERR_ARG,
                 "regions: along %c regions of %lld cells are too small for overlap %lld and halo "
                 "%lld: same-colored regions two apart would interact; expected size >= "
                 "2 * overlap + halo = %lld", axis_name[a], (long long)size[a],
                 (long long)overlap, (long long)halo, (long long)(2 * overlap + halo));
    }
    size_t n;
    GS_CHECK(gs_mul_size((size_t)nr[0], (size_t)nr[1], &n) && gs_mul_size(n, (size_t)nr[2], &n),
             GS_ERR_MEM, "regions: region count overflows");
    gs_region_box *b = NULL;
    GS_CALL(gs_alloc_array((void **)&b, n, sizeof *b, "region boxes"));
    for (int64_t iz = 0; iz < nr[2]; iz++)
        for (int64_t iy = 0; iy < nr[1]; iy++)
            for (int64_t ix = 0; ix < nr[0]; ix++) {
                int64_t id = ix + nr[0] * (iy + nr[1] * iz);
                int64_t idx[3] = {ix, iy, iz};
                gs_region_box *r = &b[id];
                r->id = id;
                r->color = (int)((ix & 1) | (iy & 1) << 1 | (iz & 1) << 2);
                for (int a = 0; a < 3; a++) {
                    r->lo[a] = idx[a] * size[a];
                    r->hi[a] = r->lo[a] + size[a] < dims[a] ? r->lo[a] + size[a] : dims[a];
                    r->wlo[a] = r->lo[a] - overlap > 0 ? r->lo[a] - overlap : 0;
                    r->whi[a] = r->hi[a] + overlap < dims[a] ? r->hi[a] + overlap : dims[a];
                    r->rlo[a] = r->wlo[a] - halo > 0 ? r->wlo[a] - halo : 0;
                    r->rhi[a] = r->whi[a] + halo < dims[a] ? r->whi[a] + halo : dims[a];
                }
            }
    *boxes = b;
    *count = (int64_t)n;
    return GS_OK;
}

static int boxes_meet(const int64_t alo[3], const int64_t ahi[3], const int64_t blo[3],
                      const int64_t bhi[3])
{
    for (int a = 0; a < 3; a++)
        if (ahi[a] <= blo[a] || bhi[a] <= alo[a])
            return 0;
    return 1;
}

gs_err gs_regions_check_separated(const gs_region_box *boxes, int64_t count)
{
    for (int64_t i = 0; i < count; i++)
        for (int64_t j = i + 1; j < count; j++) {
            const gs_region_box *a = &boxes[i], *b = &boxes[j];
            if (a->color != b->color)
                continue;
            GS_CHECK(!boxes_meet(a->wlo, a->whi, b->rlo, b->rhi) &&
                         !boxes_meet(b->wlo, b->whi, a->rlo, a->rhi),
                     GS_ERR_ARG,
                     "regions: regions %lld and %lld share color %d but one writes what the "
                     "other reads", (long long)a->id, (long long)b->id, a->color);
        }
    return GS_OK;
}
