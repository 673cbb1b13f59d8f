/* Dataflow across colors for gs_regions (gs_regions_set_conflicts, see
 * regions.h).
 *
 * Serial index k = position in s->order (colors ascending, list order
 * inside a color): the order of the serial loop the result must equal.
 * pred[k] are the interacting regions of lower colors, so every pred of k
 * has a smaller serial index. Two rules give the serial result on every
 * rank, whatever the rank count and timing:
 *  - hand out k only when every pred of k has been computed (rank 0 sees
 *    its result), so k's result cannot exist before the results it reads;
 *  - on every rank apply k only after its preds were applied there, and
 *    compute k only when they are. What else is applied at that moment does
 *    not touch k's read box: a region that does is a pred (applied) or a
 *    successor of k (not computed yet, it waits for k).
 *
 * Messages on the scheduler's private communicator:
 *   0 -> worker  TAG_FLOW_ASSIGN  int64: k >= 0 = compute region k;
 *                                 -1 - n = no more regions, n records in all
 *   every rank -> every other rank, for each region it ran:
 *                TAG_FLOW_HEADER  int64 {k, status, len}
 *                TAG_FLOW_DATA    len bytes in chunks of at most FLOW_CHUNK
 * Chunks stay under Open MPI's shared-memory eager limit (4 KiB) so a
 * result reaches the others while its sender computes the next region;
 * a rendezvous transfer would wait for the sender's next MPI call. status:
 * GS_OK, FLOW_SKIPPED (not run: a failure was known), or the run's gs_err.
 * A record with status != GS_OK stops the pass on every rank that sees it:
 * rank 0 hands out nothing more and sends every worker the number of
 * records to expect; held regions are skipped. Every rank leaves once it has
 * that many records, so no message is left pending; local failures are
 * then made collective with gs_par_agree.
 *
 * Rank 0 answers between its own regions, so a worker holds up to
 * `prefetch` regions (the second one hides rank 0's region); a worker that
 * already holds one gets another only while at least `size` regions are
 * ready, so the end of the pass is not left to one rank's backlog.
 */
#include <limits.h>
#include <sched.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "par/regions_impl.h"

enum { TAG_FLOW_ASSIGN = 211, TAG_FLOW_HEADER = 212, TAG_FLOW_DATA = 213 };
#define FLOW_CHUNK 3840
#define FLOW_SKIPPED (-1)
#define FLOW_MAX_SENDS 4096

/* ---- conflicts ---- */

void gs_regions_free_conflicts(gs_regions_t s)
{
    GS_FREE(s->pred_off);
    GS_FREE(s->pred);
    GS_FREE(s->succ_off);
    GS_FREE(s->succ);
}

typedef struct id_pos {
    int64_t id, pos;
} id_pos;

static int cmp_id_pos(const void *a, const void *b)
{
    const id_pos *x = a, *y = b;
    return (x->id > y->id) - (x->id < y->id);
}

/* Local part: CSR by serial index, checked. */
static gs_err build_conflicts(gs_regions_t s, const int64_t *offsets, const int64_t *ids)
{
    int64_t n = s->count;
    GS_CHECK(offsets[0] == 0, GS_ERR_ARG, "regions: conflict offsets must start at 0");
    for (int64_t i = 0; i < n; i++)
        GS_CHECK(offsets[i + 1] >= offsets[i], GS_ERR_ARG,
                 "regions: conflict offsets decrease at entry %lld", (long long)i);
    int64_t m = offsets[n];
    size_t nn = n ? (size_t)n : 1, mm = m ? (size_t)m : 1;
    id_pos *map = NULL;
    int64_t *serial = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&map, nn, sizeof *map, "region id map"), done);
    GS_TRY(err, gs_alloc_array((void **)&serial, nn, sizeof *serial, "serial index"), done);
    GS_TRY(err, gs_alloc_array((void **)&s->pred_off, nn + 1, sizeof(int64_t), "conflicts"), done);
    GS_TRY(err, gs_alloc_array((void **)&s->pred, mm, sizeof(int64_t), "conflicts"), done);
    GS_TRY(err, gs_alloc_array((void **)&s->succ_off, nn + 1, sizeof(int64_t), "conflicts"), done);
    GS_TRY(err, gs_alloc_array((void **)&s->succ, mm, sizeof(int64_t), "conflicts"), done);
    for (int64_t i = 0; i < n; i++)
        map[i] = (id_pos){s->regions[i].id, i};
    qsort(map, (size_t)n, sizeof *map, cmp_id_pos);
    for (int64_t k = 0; k < n; k++)
        serial[s->order[k]] = k;
    s->pred_off[0] = 0;
    for (int64_t k = 0; k <= n; k++)
        s->succ_off[k] = 0;
    for (int64_t k = 0; k < n; k++) {
        int64_t i = s->order[k], at = s->pred_off[k];
        for (int64_t j = offsets[i]; j < offsets[i + 1]; j++) {
            id_pos key = {ids[j], 0};
            const id_pos *hit = bsearch(&key, map, (size_t)n, sizeof *map, cmp_id_pos);
            GS_TRY_CHECK(err, hit != NULL, GS_ERR_ARG, done,
                         "regions: region %lld lists conflict %lld, which is not in the list",
                         (long long)s->regions[i].id, (long long)ids[j]);
            GS_TRY_CHECK(err, s->regions[hit->pos].color < s->regions[i].color, GS_ERR_ARG, done,
                         "regions: region %lld (color %d) lists conflict %lld of color %d: "
                         "conflicts must have a lower color",
                         (long long)s->regions[i].id, s->regions[i].color, (long long)ids[j],
                         s->regions[hit->pos].color);
            int64_t p = serial[hit->pos];
            s->pred[at++] = p;
            s->succ_off[p + 1]++;
        }
        s->pred_off[k + 1] = at;
    }
    for (int64_t k = 0; k < n; k++)
        s->succ_off[k + 1] += s->succ_off[k];
    for (int64_t k = 0; k < n; k++)
        serial[k] = s->succ_off[k]; /* fill positions */
    for (int64_t k = 0; k < n; k++)
        for (int64_t j = s->pred_off[k]; j < s->pred_off[k + 1]; j++)
            s->succ[serial[s->pred[j]]++] = k;
done:
    gs_free(map);
    gs_free(serial);
    if (err != GS_OK)
        gs_regions_free_conflicts(s);
    return err;
}

gs_err gs_regions_set_conflicts(gs_regions_t s, const int64_t *offsets, const int64_t *ids)
{
    gs_regions_free_conflicts(s);
    gs_err err = gs_par_agree(s->comm, build_conflicts(s, offsets, ids));
    if (err == GS_OK) {
        uint64_t h = gs_digest_bytes(offsets, (size_t)(s->count + 1) * sizeof *offsets);
        int64_t f[2] = {(int64_t)h, (int64_t)gs_digest_bytes(ids, (size_t)offsets[s->count] *
                                                                       sizeof *ids)};
        err = gs_par_check_same_i64(s->comm, (int64_t)gs_digest_bytes(f, sizeof f),
                                    "region conflict digest");
    }
    if (err != GS_OK) {
        gs_regions_free_conflicts(s);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    }
    return err;
}

/* ---- one pass ---- */

typedef struct flow {
    gs_regions_t s;
    int pass;
    gs_region_run_fn run;
    gs_region_apply_fn apply;
    void *ctx;
    int64_t n;
    int64_t (*hdr)[3];      /* [n] {k, status, len} of every record here */
    unsigned char **data;   /* [n] result bytes (8-aligned), NULL until known */
    char *have, *applied;   /* [n] */
    int64_t *npend;         /* [n] preds not applied on this rank */
    int64_t *stack;         /* [2n + 1] apply worklist */
    int64_t seen;           /* records on this rank (own and received) */
    int64_t total;          /* records to expect; -1 = not known yet */
    int stop;
    gs_err local;           /* first failure on this rank (run or apply) */
    MPI_Request sends[FLOW_MAX_SENDS];
    int nsends;
    /* worker: assigned, not yet run (FIFO) */
    int64_t held[GS_REGIONS_PREFETCH_MAX];
    int nheld, held_head;
    /* rank 0: scheduler */
    int64_t *undone;        /* [n] preds not computed anywhere */
    int64_t *heap;          /* [n] ready serial indices, min-heap */
    int64_t nheap;
    int64_t *owned;         /* [size] regions each worker holds (assigned, no record) */
    int64_t handed;         /* regions handed out (to anyone, rank 0 included) */
    int end_sent;
    int64_t end_msg, *assign_msg; /* [n] send buffers */
} flow;

static void fail_local(flow *f, gs_err e)
{
    if (f->local == GS_OK)
        f->local = e;
    f->stop = 1;
}

static void heap_push(flow *f, int64_t k)
{
    int64_t i = f->nheap++;
    while (i > 0 && f->heap[(i - 1) / 2] > k) {
        f->heap[i] = f->heap[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    f->heap[i] = k;
}

static int64_t heap_pop(flow *f)
{
    int64_t top = f->heap[0], last = f->heap[--f->nheap], i = 0;
    for (;;) {
        int64_t c = 2 * i + 1;
        if (c >= f->nheap)
            break;
        if (c + 1 < f->nheap && f->heap[c + 1] < f->heap[c])
            c++;
        if (f->heap[c] >= last)
            break;
        f->heap[i] = f->heap[c];
        i = c;
    }
    if (f->nheap > 0)
        f->heap[i] = last;
    return top;
}

/* Applies k and everything it unblocks, if k's preds are applied here. */
static void try_apply(flow *f, int64_t k)
{
    gs_regions_t s = f->s;
    int64_t top = 0;
    f->stack[top++] = k;
    double t0 = gs_time_now();
    while (top > 0 && f->local == GS_OK) {
        int64_t j = f->stack[--top];
        if (!f->have[j] || f->applied[j] || f->npend[j] > 0 || f->hdr[j][1] != GS_OK)
            continue;
        const gs_region *r = &s->regions[s->order[j]];
        gs_err e = f->apply(f->ctx, r->id, f->data[j], (size_t)f->hdr[j][2]);
        if (e != GS_OK) {
            gs_error_add_context("applying region %lld of color %d", (long long)r->id, r->color);
            fail_local(f, e);
            break;
        }
        f->applied[j] = 1;
        for (int64_t q = s->succ_off[j]; q < s->succ_off[j + 1]; q++) {
            int64_t m = s->succ[q];
            if (--f->npend[m] == 0 && f->have[m])
                f->stack[top++] = m;
        }
    }
    s->stats.t_apply += gs_time_now() - t0;
}

/* Rank 0: record k exists (OK): its successors may become ready. */
static void mark_done(flow *f, int64_t k)
{
    gs_regions_t s = f->s;
    for (int64_t q = s->succ_off[k]; q < s->succ_off[k + 1]; q++) {
        int64_t m = s->succ[q];
        if (--f->undone[m] == 0)
            heap_push(f, m);
    }
}

static gs_err flush_sends(flow *f)
{
    GS_MPI(MPI_Waitall(f->nsends, f->sends, MPI_STATUSES_IGNORE));
    f->nsends = 0;
    return GS_OK;
}

static gs_err post_send(flow *f, const void *buf, int64_t len, int to, int tag)
{
    if (f->nsends == FLOW_MAX_SENDS)
        GS_CALL(flush_sends(f));
    GS_MPI(MPI_Isend(buf, (int)len, MPI_BYTE, to, tag, f->s->comm, &f->sends[f->nsends++]));
    return GS_OK;
}

/* Record k of this rank to every other rank. */
static gs_err send_record(flow *f, int64_t k)
{
    gs_regions_t s = f->s;
    double t0 = gs_time_now();
    for (int r = 0; r < s->size; r++) {
        if (r == s->rank)
            continue;
        GS_CALL(post_send(f, f->hdr[k], sizeof f->hdr[k], r, TAG_FLOW_HEADER));
        for (int64_t at = 0; at < f->hdr[k][2]; at += FLOW_CHUNK) {
            int64_t len = f->hdr[k][2] - at < FLOW_CHUNK ? f->hdr[k][2] - at : FLOW_CHUNK;
            GS_CALL(post_send(f, f->data[k] + at, len, r, TAG_FLOW_DATA));
        }
    }
    s->stats.t_exchange += gs_time_now() - t0;
    return GS_OK;
}

/* A record arrived or was made here: count it, store it, apply it. */
static void take_record(flow *f, int64_t k, int from)
{
    gs_regions_t s = f->s;
    f->have[k] = 1;
    f->seen++;
    if (f->hdr[k][1] != GS_OK) {
        f->stop = 1;
        if (f->hdr[k][1] != FLOW_SKIPPED && f->local == GS_OK && from == s->rank)
            f->local = (gs_err)f->hdr[k][1];
    }
    if (s->rank == 0) {
        if (from != 0)
            f->owned[from]--;
        if (f->hdr[k][1] == GS_OK)
            mark_done(f, k);
    }
    if (f->hdr[k][1] == GS_OK)
        try_apply(f, k);
}

/* Runs region k here (or skips it after a failure) and sends the record. */
static gs_err run_region(flow *f, int64_t k)
{
    gs_regions_t s = f->s;
    int64_t status = FLOW_SKIPPED, len = 0;
    if (!f->stop) {
        s->pack.len = 0;
        gs_err e = gs_regions_compute_one(s, s->order[k], f->pass, f->run, f->ctx);
        if (e == GS_OK) {
            int64_t h[2];
            memcpy(h, s->pack.data, sizeof h);
            len = h[1];
            f->data[k] = gs_malloc(len ? (size_t)len : 1);
            if (f->data[k]) {
                memcpy(f->data[k], s->pack.data + sizeof h, (size_t)len);
                status = GS_OK;
            } else {
                e = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                   "regions: cannot keep a result of %lld bytes", (long long)len);
            }
        }
        if (e != GS_OK) {
            fail_local(f, e);
            status = e;
            len = 0;
        }
    }
    f->hdr[k][0] = k;
    f->hdr[k][1] = status;
    f->hdr[k][2] = len;
    GS_CALL(send_record(f, k));
    take_record(f, k, s->rank);
    return GS_OK;
}

/* Receives one record whose header is waiting from `from`. */
static gs_err recv_record(flow *f, int from)
{
    gs_regions_t s = f->s;
    double t0 = gs_time_now();
    int64_t h[3];
    GS_MPI(MPI_Recv(h, (int)sizeof h, MPI_BYTE, from, TAG_FLOW_HEADER, s->comm, MPI_STATUS_IGNORE));
    GS_CHECK(h[0] >= 0 && h[0] < f->n && !f->have[h[0]] && h[2] >= 0 && h[2] <= INT_MAX,
             GS_ERR_INTERNAL, "regions: malformed record header {%lld, %lld, %lld} from rank %d",
             (long long)h[0], (long long)h[1], (long long)h[2], from);
    int64_t k = h[0];
    memcpy(f->hdr[k], h, sizeof h);
    unsigned char scratch[FLOW_CHUNK];
    f->data[k] = f->local == GS_OK ? gs_malloc(h[2] ? (size_t)h[2] : 1) : NULL;
    if (!f->data[k] && f->local == GS_OK)
        fail_local(f, gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                     "regions: cannot receive a result of %lld bytes",
                                     (long long)h[2]));
    for (int64_t at = 0; at < h[2]; at += FLOW_CHUNK) {
        int64_t len = h[2] - at < FLOW_CHUNK ? h[2] - at : FLOW_CHUNK;
        GS_MPI(MPI_Recv(f->data[k] ? f->data[k] + at : scratch, (int)len, MPI_BYTE, from,
                        TAG_FLOW_DATA, s->comm, MPI_STATUS_IGNORE));
    }
    if (!f->data[k])
        f->hdr[k][1] = FLOW_SKIPPED; /* not kept: cannot be applied here */
    s->stats.bytes += h[2];
    s->stats.t_exchange += gs_time_now() - t0;
    take_record(f, k, from);
    return GS_OK;
}

/* Handles every message waiting; *got = 1 if there was one. */
static gs_err progress(flow *f, int *got)
{
    gs_regions_t s = f->s;
    for (;;) {
        int flag = 0;
        MPI_Status st;
        GS_MPI(MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, s->comm, &flag, &st));
        if (!flag)
            return GS_OK;
        *got = 1;
        if (st.MPI_TAG == TAG_FLOW_HEADER) {
            GS_CALL(recv_record(f, st.MPI_SOURCE));
        } else {
            GS_CHECK(st.MPI_TAG == TAG_FLOW_ASSIGN && st.MPI_SOURCE == 0 && s->rank != 0,
                     GS_ERR_INTERNAL, "regions: unexpected message tag %d from rank %d",
                     st.MPI_TAG, st.MPI_SOURCE);
            int64_t v;
            GS_MPI(MPI_Recv(&v, (int)sizeof v, MPI_BYTE, 0, TAG_FLOW_ASSIGN, s->comm, MPI_STATUS_IGNORE));
            if (v >= 0) {
                GS_CHECK(v < f->n && f->nheld < s->prefetch, GS_ERR_INTERNAL,
                         "regions: assignment %lld with %d held", (long long)v, f->nheld);
                f->held[(f->held_head + f->nheld++) % GS_REGIONS_PREFETCH_MAX] = v;
            } else {
                f->total = -1 - v;
            }
        }
    }
}

/* Rank 0: hands ready regions to workers. */
static gs_err serve(flow *f)
{
    gs_regions_t s = f->s;
    for (int w = 1; w < s->size && !f->stop; w++)
        while (f->nheap > 0 && f->owned[w] < s->prefetch &&
               (f->owned[w] == 0 || f->nheap >= s->size)) {
            int64_t k = heap_pop(f);
            f->assign_msg[k] = k;
            GS_CALL(post_send(f, &f->assign_msg[k], sizeof f->assign_msg[k], w, TAG_FLOW_ASSIGN));
            f->owned[w]++;
            f->handed++;
        }
    if (!f->end_sent && (f->stop || f->handed == f->n)) {
        f->end_sent = 1;
        f->total = f->handed;
        f->end_msg = -1 - f->handed;
        for (int w = 1; w < s->size; w++)
            GS_CALL(post_send(f, &f->end_msg, sizeof f->end_msg, w, TAG_FLOW_ASSIGN));
    }
    return GS_OK;
}

static void idle(flow *f)
{
    double t0 = gs_time_now();
    sched_yield();
    f->s->stats.t_wait += gs_time_now() - t0;
}

static gs_err coordinate(flow *f)
{
    for (int64_t k = 0; k < f->n; k++)
        if ((f->undone[k] = f->s->pred_off[k + 1] - f->s->pred_off[k]) == 0)
            heap_push(f, k);
    for (;;) {
        int got = 0;
        GS_CALL(progress(f, &got));
        GS_CALL(serve(f));
        if (!f->stop && f->nheap > 0) {
            f->handed++;
            GS_CALL(run_region(f, heap_pop(f)));
            continue;
        }
        if (f->end_sent && f->seen == f->total)
            return GS_OK;
        if (!got)
            idle(f);
    }
}

static gs_err work(flow *f)
{
    for (;;) {
        int got = 0;
        GS_CALL(progress(f, &got));
        if (f->nheld > 0) {
            int64_t k = f->held[f->held_head];
            if (f->stop || f->npend[k] == 0) {
                f->held_head = (f->held_head + 1) % GS_REGIONS_PREFETCH_MAX;
                f->nheld--;
                GS_CALL(run_region(f, k));
                continue;
            }
        }
        if (f->total >= 0 && f->seen == f->total && f->nheld == 0)
            return GS_OK;
        if (!got)
            idle(f);
    }
}

static void flow_free(flow *f)
{
    if (f->data)
        for (int64_t k = 0; k < f->n; k++)
            gs_free(f->data[k]);
    gs_free(f->data);
    gs_free(f->hdr);
    gs_free(f->have);
    gs_free(f->applied);
    gs_free(f->npend);
    gs_free(f->stack);
    gs_free(f->undone);
    gs_free(f->heap);
    gs_free(f->owned);
    gs_free(f->assign_msg);
}

gs_err gs_regions_flow_pass(gs_regions_t s, int pass, gs_region_run_fn run,
                            gs_region_apply_fn apply, void *ctx)
{
    flow *f = gs_calloc(1, sizeof *f);
    gs_err local = f ? GS_OK
                     : gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                      "regions: cannot allocate the dataflow state");
    size_t nn = s->count ? (size_t)s->count : 1;
    if (f) {
        *f = (flow){.s = s, .pass = pass, .run = run, .apply = apply, .ctx = ctx, .n = s->count,
                    .total = -1};
        f->data = gs_calloc(nn, sizeof *f->data);
        f->hdr = gs_calloc(nn, sizeof *f->hdr);
        f->have = gs_calloc(nn, 1);
        f->applied = gs_calloc(nn, 1);
        f->npend = gs_calloc(nn, sizeof *f->npend);
        f->stack = gs_calloc(2 * nn + 1, sizeof *f->stack);
        if (s->rank == 0) {
            f->undone = gs_calloc(nn, sizeof *f->undone);
            f->heap = gs_calloc(nn, sizeof *f->heap);
            f->owned = gs_calloc((size_t)s->size, sizeof *f->owned);
            f->assign_msg = gs_calloc(nn, sizeof *f->assign_msg);
        }
        if (!f->data || !f->hdr || !f->have || !f->applied || !f->npend || !f->stack ||
            (s->rank == 0 && (!f->undone || !f->heap || !f->owned || !f->assign_msg)))
            local = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                   "regions: cannot allocate the dataflow state of %lld regions",
                                   (long long)s->count);
    }
    gs_err err = gs_par_agree(s->comm, local);
    if (err == GS_OK) {
        for (int64_t k = 0; k < f->n; k++)
            f->npend[k] = s->pred_off[k + 1] - s->pred_off[k];
        err = s->rank == 0 ? coordinate(f) : work(f);
        /* An MPI failure is local (see regions.h): return it without the
         * collective agreement the other ranks may never reach. */
        if (err == GS_OK)
            err = flush_sends(f);
        if (err == GS_OK) {
            int64_t applied = 0;
            for (int64_t k = 0; k < f->n; k++)
                applied += f->applied[k];
            if (f->local == GS_OK && applied != f->n)
                fail_local(f, gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                                             "regions: %lld of %lld results applied",
                                             (long long)applied, (long long)f->n));
            err = gs_par_agree(s->comm, f->local);
        }
    }
    if (f) {
        flow_free(f);
        gs_free(f);
    }
    if (err != GS_OK)
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    return err;
}
