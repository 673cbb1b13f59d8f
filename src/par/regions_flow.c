/* Dataflow across colors for gs_regions (gs_regions_set_conflicts, see
 * regions.h).
 *
 * Serial index k = position in s->order (colors ascending, list order
 * inside a color): the order of the serial loop the result must equal.
 * pred[k] are the interacting regions of lower colors, so every pred of k
 * has a smaller serial index. On every rank:
 *  - run k only when every pred of k is applied here; apply a record only
 *    when its preds are applied here. What else is applied at that moment
 *    does not touch k's read box: a region that does is a pred (applied) or
 *    a successor of k, which no rank can run before k's record exists.
 * So a region's result is the same whichever rank runs it and whenever, and
 * equals the serial loop's.
 *
 * No coordinator: every rank sees every record, so every rank knows which
 * regions are ready, and picks one nobody claimed from its own share
 * (k mod size = rank) and the share of a rank that is busy (its regions
 * that this rank is the thief() of): the one with the most dependents
 * (regions that wait for it directly or through others,
 * gs_regions_dependents), then the lowest k; with none, the best one that
 * some rank has left unclaimed for FLOW_STEAL_AFTER (its process is not
 * running: another job on its core). Before running it sends a claim to
 * everyone. Two ranks can still
 * pick the same region when they choose within a message latency of each
 * other; both then run it, the bytes are the same, receivers keep the first. (A rank-0 work queue
 * that answers only between rank 0's own regions left workers waiting about
 * half a region per region: simulated on castle-10x's region costs, 1.73x
 * on 2 ranks against 1.93x without a coordinator.) The rule before, the
 * lowest k of the own share first and a busy rank's only when none was
 * ready, left the regions of one share to one rank: on castle-10x (seed 1)
 * its two longest regions (4 and 6 tries, 10-19 ms of the ~60-90 ms) were
 * both rank 1's and ran one after the other, 1.76x on 2 ranks in the
 * regions' own CPU seconds (src/model/engine_sched.c) against a 2.00x bound;
 * this rule gives 1.99x there.
 *
 * Messages on the scheduler's private communicator, to every other rank:
 *   TAG_FLOW_HEADER  int64 {k, FLOW_CLAIM, 0}: k is being run
 *                    int64 {k, status, len}: the record of k; status GS_OK
 *                    (then TAG_FLOW_DATA: len bytes in chunks of at most
 *                    FLOW_CHUNK) or the gs_err of the failed run
 *                    int64 {-1, status, 0}: this rank failed (apply, memory)
 *   TAG_FLOW_FIN     int64: headers sent to that rank in this pass
 * Chunks stay under Open MPI's shared-memory eager limit (4 KiB) so a
 * record reaches the others while its sender computes the next region; a
 * rendezvous transfer would wait for the sender's next MPI call. A failure
 * stops the pass on every rank that hears of it. A rank leaves once every
 * region has a record there (or it stopped), it sent its FIN counts and it
 * received every header the others sent it, so no message is left for the
 * next pass; local failures are then made collective with gs_par_agree.
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

enum { TAG_FLOW_HEADER = 212, TAG_FLOW_DATA = 213, TAG_FLOW_FIN = 214 };
#define FLOW_CHUNK 3840
#define FLOW_CLAIM (-2)
#define FLOW_MAX_SENDS 4096
/* A ready region of an idle rank's share that rank has not claimed after
 * this many seconds is taken by another idle rank: its owner is most
 * likely descheduled (a shared machine; an idle rank polls, so it claims
 * within microseconds when it runs). */
#define FLOW_STEAL_AFTER 0.001

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
    unsigned char **data;   /* [n] result bytes, NULL until known */
    char *have, *applied;   /* [n] record here; applied here */
    char *claimed;          /* [n] some rank runs or ran it (as far as this rank knows) */
    int64_t *npend;         /* [n] preds not applied on this rank */
    int64_t *stack;         /* [2n + 1] apply worklist */
    int64_t *heap[2];       /* [n] each: candidates (preds applied): this rank's share
                               (heap, best first: before()), the others' share (list) */
    int64_t *dep;           /* [n] regions waiting for k, directly or not: the priority */
    double *ready_at;       /* [n] when a region of the others' share became a candidate */
    char *busy;             /* [size] last header from that rank was a claim */
    int64_t nheap[2];
    int64_t nhave;          /* records here (distinct regions) */
    int64_t nclaimed;       /* regions with claimed[] set */
    int stop;               /* a failure somewhere: run nothing more */
    gs_err local;           /* first failure on this rank (run or apply) */
    int64_t notice[3];      /* {-1, status, 0}: this rank stopped (send buffer) */
    int64_t *claim_msg;     /* [n][3] send buffers of claims */
    int64_t *sent, *got;    /* [size] header messages sent to / received from each rank */
    int64_t *fin;           /* [2 size]: headers each rank says it sent here (-1 = no FIN
                               yet), then the FIN send buffers */
    int fin_sent;
    int pick_random;        /* test hook GS_FLOW_PICK=random:SEED: any ready region */
    uint64_t pick_state;    /* its splitmix64 state */
    MPI_Request sends[FLOW_MAX_SENDS];
    int nsends;
} flow;

static void mark_claimed(flow *f, int64_t k)
{
    f->nclaimed += !f->claimed[k];
    f->claimed[k] = 1;
}

static void fail_local(flow *f, gs_err e)
{
    if (f->local == GS_OK)
        f->local = e;
    f->stop = 1;
}

/* Region a goes before b: more dependents, then the lower serial index. */
static int before(const flow *f, int64_t a, int64_t b)
{
    return f->dep[a] != f->dep[b] ? f->dep[a] > f->dep[b] : a < b;
}

static void heap_push(const flow *f, int64_t *h, int64_t *n, int64_t k)
{
    int64_t i = (*n)++;
    while (i > 0 && before(f, k, h[(i - 1) / 2])) {
        h[i] = h[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    h[i] = k;
}

static int64_t heap_pop(const flow *f, int64_t *h, int64_t *n)
{
    int64_t top = h[0], last = h[--*n], i = 0;
    for (;;) {
        int64_t c = 2 * i + 1;
        if (c >= *n)
            break;
        if (c + 1 < *n && before(f, h[c + 1], h[c]))
            c++;
        if (!before(f, h[c], last))
            break;
        h[i] = h[c];
        i = c;
    }
    if (*n > 0)
        h[i] = last;
    return top;
}

gs_err gs_regions_dependents(int64_t n, const int64_t *succ_off, const int64_t *succ, int64_t *dep)
{
    /* a depth-first walk per region; stamp[j] = the last walk that reached
     * j. The walks stay near their region (a conflict is a neighbour of a
     * lower colour), and a window with conflicts holds at most a few
     * thousand regions. */
    size_t nn = n > 0 ? (size_t)n : 1;
    int64_t *stamp = NULL, *stack = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&stamp, nn, sizeof *stamp, "dependents"), done);
    GS_TRY(err, gs_alloc_array((void **)&stack, nn, sizeof *stack, "dependents"), done);
    for (int64_t k = 0; k < n; k++)
        stamp[k] = -1;
    for (int64_t k = 0; k < n; k++) {
        int64_t top = 0, count = 0;
        stack[top++] = k;
        while (top > 0) {
            int64_t j = stack[--top];
            for (int64_t q = succ_off[j]; q < succ_off[j + 1]; q++)
                if (stamp[succ[q]] != k) {
                    stamp[succ[q]] = k;
                    stack[top++] = succ[q];
                    count++;
                }
        }
        dep[k] = count;
    }
done:
    gs_free(stamp);
    gs_free(stack);
    return err;
}

/* k's preds are applied here: a candidate to run. Class 0 = this rank's
 * share (k mod size = rank); class 1 = the others' share, taken while its
 * owner is busy (or does not run), so two idle ranks rarely pick the same
 * region. */
static void add_candidate(flow *f, int64_t k)
{
    if (k % f->s->size == f->s->rank)
        heap_push(f, f->heap[0], &f->nheap[0], k);
    else {
        f->heap[1][f->nheap[1]++] = k; /* scanned by pick() */
        f->ready_at[k] = gs_time_now();
    }
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
            if (--f->npend[m] == 0) {
                add_candidate(f, m);
                if (f->have[m])
                    f->stack[top++] = m;
            }
        }
    }
    s->stats.t_apply += gs_time_now() - t0;
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
    if (tag == TAG_FLOW_HEADER)
        f->sent[to]++;
    return GS_OK;
}

/* A header (claim, record or stop notice), and for a record its bytes, to
 * every other rank. */
static gs_err send_all(flow *f, const int64_t hdr[3], const unsigned char *data)
{
    gs_regions_t s = f->s;
    double t0 = gs_time_now();
    for (int r = 0; r < s->size; r++) {
        if (r == s->rank)
            continue;
        GS_CALL(post_send(f, hdr, 3 * sizeof *hdr, r, TAG_FLOW_HEADER));
        for (int64_t at = 0; hdr[1] == GS_OK && at < hdr[2]; at += FLOW_CHUNK) {
            int64_t len = hdr[2] - at < FLOW_CHUNK ? hdr[2] - at : FLOW_CHUNK;
            GS_CALL(post_send(f, data + at, len, r, TAG_FLOW_DATA));
        }
    }
    s->stats.t_exchange += gs_time_now() - t0;
    return GS_OK;
}

/* Tells the others this rank stopped (a local failure they cannot see). */
static gs_err announce_stop(flow *f)
{
    if (f->notice[0] == -1)
        return GS_OK;
    f->notice[0] = -1;
    f->notice[1] = f->local != GS_OK ? f->local : GS_ERR_INTERNAL;
    f->notice[2] = 0;
    return send_all(f, f->notice, NULL);
}

/* A record arrived or was made here. */
static void take_record(flow *f, int64_t k)
{
    f->have[k] = 1;
    mark_claimed(f, k);
    f->nhave++;
    if (f->hdr[k][1] != GS_OK)
        f->stop = 1;
    else
        try_apply(f, k);
}

/* Claims k, runs it and sends the record. */
static gs_err run_region(flow *f, int64_t k)
{
    gs_regions_t s = f->s;
    mark_claimed(f, k);
    int64_t *claim = f->claim_msg + 3 * k;
    claim[0] = k;
    claim[1] = FLOW_CLAIM;
    claim[2] = 0;
    GS_CALL(send_all(f, claim, NULL));
    int64_t status = GS_OK, len = 0;
    s->pack.len = 0;
    gs_err e = gs_regions_compute_one(s, s->order[k], f->pass, f->run, f->ctx);
    if (e == GS_OK) {
        int64_t h[2];
        memcpy(h, s->pack.data, sizeof h);
        len = h[1];
        f->data[k] = gs_malloc(len ? (size_t)len : 1);
        if (f->data[k])
            memcpy(f->data[k], s->pack.data + sizeof h, (size_t)len);
        else
            e = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                               "regions: cannot keep a result of %lld bytes", (long long)len);
    }
    if (e != GS_OK) {
        fail_local(f, e);
        status = e;
        len = 0;
    }
    f->hdr[k][0] = k;
    f->hdr[k][1] = status;
    f->hdr[k][2] = len;
    GS_CALL(send_all(f, f->hdr[k], f->data[k]));
    take_record(f, k);
    return GS_OK;
}

/* Receives one header (and a record's bytes) waiting from `from`. */
static gs_err recv_header(flow *f, int from)
{
    gs_regions_t s = f->s;
    double t0 = gs_time_now();
    int64_t h[3];
    GS_MPI(MPI_Recv(h, (int)sizeof h, MPI_BYTE, from, TAG_FLOW_HEADER, s->comm, MPI_STATUS_IGNORE));
    f->got[from]++;
    GS_CHECK(h[0] >= -1 && h[0] < f->n && h[2] >= 0 && h[2] <= INT_MAX, GS_ERR_INTERNAL,
             "regions: malformed header {%lld, %lld, %lld} from rank %d", (long long)h[0],
             (long long)h[1], (long long)h[2], from);
    if (h[0] < 0) { /* stop notice */
        f->stop = 1;
        return GS_OK;
    }
    int64_t k = h[0];
    f->busy[from] = h[1] == FLOW_CLAIM;
    if (h[1] == FLOW_CLAIM) {
        mark_claimed(f, k);
        return GS_OK;
    }
    /* A second record of k (two ranks picked it at once) has the same bytes
     * (results depend only on the state, which both had): drop it. */
    int keep = !f->have[k];
    unsigned char scratch[FLOW_CHUNK];
    unsigned char *dst = NULL;
    if (keep && h[1] == GS_OK) {
        dst = gs_malloc(h[2] ? (size_t)h[2] : 1);
        if (!dst)
            fail_local(f, gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                         "regions: cannot receive a result of %lld bytes",
                                         (long long)h[2]));
    }
    for (int64_t at = 0; h[1] == GS_OK && at < h[2]; at += FLOW_CHUNK) {
        int64_t len = h[2] - at < FLOW_CHUNK ? h[2] - at : FLOW_CHUNK;
        GS_MPI(MPI_Recv(dst ? dst + at : scratch, (int)len, MPI_BYTE, from, TAG_FLOW_DATA,
                        s->comm, MPI_STATUS_IGNORE));
    }
    s->stats.bytes += h[1] == GS_OK ? h[2] : 0;
    s->stats.t_exchange += gs_time_now() - t0;
    if (!keep) {
        s->stats.duplicates += h[1] == GS_OK;
        return GS_OK;
    }
    memcpy(f->hdr[k], h, sizeof h);
    f->data[k] = dst;
    if (h[1] == GS_OK && !dst)
        f->hdr[k][1] = GS_ERR_MEM; /* not kept: cannot be applied here */
    take_record(f, k);
    return GS_OK;
}

/* Handles every message waiting; *got = 1 if there was one. */
static gs_err progress(flow *f, int *got)
{
    gs_regions_t s = f->s;
    for (;;) {
        int flag = 0;
        MPI_Status st;
        GS_MPI(gs_regions_iprobe(s->comm, MPI_ANY_TAG, &flag, &st));
        if (!flag)
            return GS_OK;
        *got = 1;
        if (st.MPI_TAG == TAG_FLOW_HEADER) {
            GS_CALL(recv_header(f, st.MPI_SOURCE));
        } else {
            GS_CHECK(st.MPI_TAG == TAG_FLOW_FIN, GS_ERR_INTERNAL,
                     "regions: unexpected message tag %d from rank %d", st.MPI_TAG, st.MPI_SOURCE);
            GS_MPI(MPI_Recv(&f->fin[st.MPI_SOURCE], (int)sizeof(int64_t), MPI_BYTE, st.MPI_SOURCE,
                            TAG_FLOW_FIN, s->comm, MPI_STATUS_IGNORE));
        }
    }
}

/* The rank that takes region k of a busy owner's share at once (the others
 * wait FLOW_STEAL_AFTER): one of the other ranks by k, so two idle ranks
 * do not both take the busy rank's best region. At 2 ranks: the other
 * rank. (castle-10x at 3 ranks on 2 loaded cores, duplicate records of its
 * 63 regions: 15-33 with the rule before; 96-255 with any idle rank taking
 * a busy rank's region and long-unclaimed ones in the same choice; 12-27
 * with thief() and those last.) */
static int thief(const gs_regions_t s, int64_t k)
{
    int owner = (int)(k % s->size);
    return s->size < 2 ? owner
                       : (owner + 1 + (int)(k / s->size % (s->size - 1))) % s->size;
}

/* Of the candidates nobody claimed, of this rank's share and of the share
 * of a rank that is busy (its last header was a claim) when this rank is
 * the region's thief(), the first by before(); if there is none, the first
 * one any other rank left unclaimed for FLOW_STEAL_AFTER (its owner or
 * thief does not run: an idle owner takes its region itself, so two idle
 * ranks do not both grab the one region that just became ready). -1 if
 * none.
 * Test hook GS_FLOW_PICK=random:SEED: a random candidate of the own share
 * instead (every order the conflicts allow is one a loaded machine could
 * produce; results must not change, even at one rank). */
static int64_t pick(flow *f)
{
    double now = -1;
    if (f->pick_random) { /* test hook: a random ready region of the own share */
        int64_t n = 0;
        for (int64_t i = 0; i < f->nheap[0]; i++)
            if (!f->claimed[f->heap[0][i]])
                f->heap[0][n++] = f->heap[0][i];
        f->nheap[0] = n;
        if (n > 0) {
            uint64_t z = (f->pick_state += 0x9e3779b97f4a7c15ull); /* splitmix64 */
            z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
            z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
            z ^= z >> 31;
            int64_t at = (int64_t)(z % (uint64_t)n), k = f->heap[0][at];
            f->heap[0][at] = f->heap[0][--f->nheap[0]];
            return k;
        }
    }
    while (!f->pick_random && f->nheap[0] > 0 && f->claimed[f->heap[0][0]])
        heap_pop(f, f->heap[0], &f->nheap[0]);
    int64_t own = !f->pick_random && f->nheap[0] > 0 ? f->heap[0][0] : -1;
    int64_t best = own, stale = -1, n = 0;
    for (int64_t i = 0; i < f->nheap[1]; i++) {
        int64_t k = f->heap[1][i];
        if (f->claimed[k])
            continue;
        f->heap[1][n++] = k;
        if (f->busy[k % f->s->size] && thief(f->s, k) == f->s->rank) {
            if (best < 0 || before(f, k, best))
                best = k;
        } else if (stale < 0 || before(f, k, stale)) {
            if (now < 0)
                now = gs_time_now();
            if (now - f->ready_at[k] >= FLOW_STEAL_AFTER)
                stale = k;
        }
    }
    f->nheap[1] = n;
    if (best >= 0 && best == own)
        heap_pop(f, f->heap[0], &f->nheap[0]);
    return best >= 0 ? best : stale;
}

/* Every rank runs regions until every region has a record here (or a
 * failure stops the pass), then says how many headers it sent to each rank
 * and leaves once it received as many from each. */
static gs_err run_flow(flow *f)
{
    gs_regions_t s = f->s;
    for (int64_t k = 0; k < f->n; k++)
        if (f->npend[k] == 0)
            add_candidate(f, k);
    for (;;) {
        int got = 0;
        GS_CALL(progress(f, &got));
        if (f->stop && f->local != GS_OK)
            GS_CALL(announce_stop(f));
        if (!f->stop && f->nhave < f->n) {
            int64_t k = pick(f);
            if (k >= 0) {
                GS_CALL(run_region(f, k));
                continue;
            }
        } else if (!f->fin_sent) {
            f->fin_sent = 1;
            for (int r = 0; r < s->size; r++)
                if (r != s->rank) {
                    f->fin[s->size + r] = f->sent[r];
                    GS_CALL(post_send(f, &f->fin[s->size + r], sizeof(int64_t), r, TAG_FLOW_FIN));
                }
        }
        if (f->fin_sent) {
            int all = 1;
            for (int r = 0; r < s->size; r++)
                all &= r == s->rank || (f->fin[r] >= 0 && f->got[r] == f->fin[r]);
            if (all)
                return GS_OK;
        }
        if (!got) {
            double t0 = gs_time_now();
            sched_yield();
            double dt = gs_time_now() - t0;
            s->stats.t_wait += dt;
            if (f->nclaimed == f->n || f->stop)
                s->stats.t_tail += dt;
        }
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
    gs_free(f->claimed);
    gs_free(f->npend);
    gs_free(f->stack);
    gs_free(f->heap[0]);
    gs_free(f->heap[1]);
    gs_free(f->dep);
    gs_free(f->ready_at);
    gs_free(f->claim_msg);
    gs_free(f->sent);
    gs_free(f->got);
    gs_free(f->fin);
    gs_free(f->busy);
}

gs_err gs_regions_flow_pass(gs_regions_t s, int pass, gs_region_run_fn run,
                            gs_region_apply_fn apply, void *ctx)
{
    double t_start = gs_time_now();
    flow *f = gs_calloc(1, sizeof *f);
    gs_err local = f ? GS_OK
                     : gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                      "regions: cannot allocate the dataflow state");
    size_t nn = s->count ? (size_t)s->count : 1, np = (size_t)s->size;
    if (f) {
        const char *hook = getenv("GS_FLOW_PICK");
        *f = (flow){.s = s, .pass = pass, .run = run, .apply = apply, .ctx = ctx, .n = s->count};
        if (hook && strncmp(hook, "random:", 7) == 0) {
            f->pick_random = 1;
            f->pick_state = strtoull(hook + 7, NULL, 10) + ((uint64_t)s->rank << 32) +
                            ((uint64_t)pass << 48);
        }
        f->data = gs_calloc(nn, sizeof *f->data);
        f->hdr = gs_calloc(nn, sizeof *f->hdr);
        f->have = gs_calloc(nn, 1);
        f->applied = gs_calloc(nn, 1);
        f->claimed = gs_calloc(nn, 1);
        f->npend = gs_calloc(nn, sizeof *f->npend);
        f->stack = gs_calloc(2 * nn + 1, sizeof *f->stack);
        f->heap[0] = gs_calloc(nn, sizeof *f->heap[0]);
        f->heap[1] = gs_calloc(nn, sizeof *f->heap[1]);
        f->dep = gs_calloc(nn, sizeof *f->dep);
        f->ready_at = gs_calloc(nn, sizeof *f->ready_at);
        f->claim_msg = gs_calloc(3 * nn, sizeof *f->claim_msg);
        f->sent = gs_calloc(np, sizeof *f->sent);
        f->got = gs_calloc(np, sizeof *f->got);
        f->fin = gs_calloc(2 * np, sizeof *f->fin); /* [0, size): received; [size, 2 size): sent */
        f->busy = gs_calloc(np, 1);
        if (!f->data || !f->hdr || !f->have || !f->applied || !f->claimed || !f->npend ||
            !f->stack || !f->heap[0] || !f->heap[1] || !f->dep || !f->ready_at || !f->claim_msg || !f->sent || !f->got ||
            !f->fin || !f->busy)
            local = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                   "regions: cannot allocate the dataflow state of %lld regions",
                                   (long long)s->count);
        else {
            for (size_t r = 0; r < np; r++)
                f->fin[r] = -1;
            local = gs_regions_dependents(s->count, s->succ_off, s->succ, f->dep);
        }
    }
    gs_err err = gs_par_agree(s->comm, local);
    if (err == GS_OK) {
        for (int64_t k = 0; k < f->n; k++)
            f->npend[k] = s->pred_off[k + 1] - s->pred_off[k];
        err = run_flow(f);
        /* An MPI failure is local (see regions.h): return it without the
         * collective agreement the other ranks may never reach. */
        if (err == GS_OK)
            err = flush_sends(f);
        if (err == GS_OK) {
            int64_t applied = 0;
            for (int64_t k = 0; k < f->n; k++)
                applied += f->applied[k];
            if (f->local == GS_OK && !f->stop && applied != f->n)
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
    s->stats.t_pass += gs_time_now() - t_start;
    if (err != GS_OK)
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    return err;
}
