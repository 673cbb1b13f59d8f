/* model driver, the schedule figures: how fast the sweep's regions could
 * run on 2 ranks and how fast this run's schedule ran them, from each
 * region's CPU seconds (its record, region_hdr.cpu_s) and the conflicts
 * (a region waits for the interacting regions of lower colours), with no
 * waiting for a core: on a machine shared with other jobs the wall clock
 * says more about the other jobs than about the schedule.
 *
 * Per window of colours (a window ends when every rank is done, so the
 * figures add up over windows):
 *  - crit: the longest chain of dependent regions (its CPU seconds);
 *  - bound2 = max(crit, cpu / 2): no 2-rank schedule is shorter;
 *  - policy2: src/par/regions_flow.c's rule simulated on 2 ranks (serial
 *    index k = position in the window; a free rank takes, of the ready
 *    regions of its own share, k mod 2, and while the other rank is busy of
 *    the other rank's share, the one with the most dependents (regions that
 *    wait for it directly or through others, gs_regions_dependents), then
 *    the lowest k; nothing ready: wait for the next region to end), message
 *    latency 0;
 *  - replay: each rank runs the regions this run gave it, in the order it
 *    ran them (region_hdr.rank, seq), each as soon as its rank is free and
 *    its conflicts are done (at one rank: cpu).
 * cpu / each of them is a speed-up over one rank's region CPU. */
#include <stdio.h>
#include <stdlib.h>

#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/regions.h"
#include "model/engine_impl.h"

typedef struct sched_ctx {
    size_t first, n;
    const int64_t *off, *ids;
    const region_hdr *rec; /* rec[first + i] */
    int64_t *succ_off, *succ; /* the conflicts the other way: later regions waiting for i */
} sched_ctx;

static double dur(const sched_ctx *c, size_t i) { return c->rec[c->first + i].cpu_s; }

/* Pred i's j-th conflict as a window position. */
static size_t pred_at(const sched_ctx *c, int64_t j) { return (size_t)c->ids[j] - c->first; }

/* 2 ranks, the dataflow's pick rule; fin[] scratch of n. Returns the
 * makespan, or -1 when out of memory. */
static double simulate_policy2(const sched_ctx *c, double *fin)
{
    const size_t n = c->n;
    size_t *npend = gs_calloc(n ? n : 1, sizeof *npend);
    double *ready = gs_calloc(n ? n : 1, sizeof *ready);
    char *done = gs_calloc(n ? n : 1, 1);
    int64_t *dep = gs_calloc(n ? n : 1, sizeof *dep);
    if (!npend || !ready || !done || !dep ||
        gs_regions_dependents((int64_t)n, c->succ_off, c->succ, dep) != GS_OK) {
        gs_free(npend);
        gs_free(ready);
        gs_free(done);
        gs_free(dep);
        return -1;
    }
    /* the scans below are O(n) per region: windows hold at most
     * MODEL_WINDOW_REGIONS regions */
    for (size_t i = 0; i < n; i++)
        npend[i] = (size_t)(c->off[i + 1] - c->off[i]);
    double free_at[2] = {0, 0}, makespan = 0;
    size_t left = n;
    while (left > 0) {
        int r = free_at[1] < free_at[0] ? 1 : 0;
        double t = free_at[r];
        if (free_at[0] == free_at[1]) { /* both free: rank 0 first, unless only rank 1's
                                          * regions are ready (then rank 1 takes one) */
            int ready0 = 0, ready1 = 0;
            for (size_t i = 0; i < n && !ready0; i++)
                if (!done[i] && npend[i] == 0 && ready[i] <= t)
                    *(i % 2 ? &ready1 : &ready0) = 1;
            r = !ready0 && ready1;
        }
        size_t k = SIZE_MAX; /* own share; the other's while the other rank is busy */
        for (size_t i = 0; i < n; i++)
            if (!done[i] && npend[i] == 0 && ready[i] <= t &&
                ((int)(i % 2) == r || free_at[1 - r] > t) && (k == SIZE_MAX || dep[i] > dep[k]))
                k = i;
        if (k == SIZE_MAX) {
            /* nothing for r now: until the next region ends or the other
             * rank frees (then its share may be taken) */
            double next = -1;
            for (size_t i = 0; i < n; i++)
                if (done[i] && fin[i] > t && (next < 0 || fin[i] < next))
                    next = fin[i];
            for (size_t i = 0; i < n; i++) /* a ready time past t */
                if (!done[i] && npend[i] == 0 && ready[i] > t && (next < 0 || ready[i] < next))
                    next = ready[i];
            if (free_at[1 - r] > t && (next < 0 || free_at[1 - r] < next))
                next = free_at[1 - r];
            if (next < 0) /* cannot happen: the conflicts point back only */
                break;
            free_at[r] = next;
            continue;
        }
        done[k] = 1;
        fin[k] = t + dur(c, k);
        free_at[r] = fin[k];
        makespan = fin[k] > makespan ? fin[k] : makespan;
        left--;
        for (int64_t q = c->succ_off[k]; q < c->succ_off[k + 1]; q++) {
            size_t i = (size_t)c->succ[q];
            npend[i]--;
            ready[i] = fin[k] > ready[i] ? fin[k] : ready[i];
        }
    }
    gs_free(npend);
    gs_free(ready);
    gs_free(done);
    gs_free(dep);
    return left == 0 ? makespan : -1;
}

typedef struct rank_seq {
    int32_t rank, seq;
    size_t i;
} rank_seq;

static int cmp_rank_seq(const void *a, const void *b)
{
    const rank_seq *x = a, *y = b;
    if (x->rank != y->rank)
        return x->rank < y->rank ? -1 : 1;
    if (x->seq != y->seq)
        return x->seq < y->seq ? -1 : 1;
    return (x->i > y->i) - (x->i < y->i);
}

/* This run's assignment and order, each rank a core; fin[] scratch of n.
 * Returns the makespan, -1 when out of memory or the order is not one the
 * conflicts allow (it always is: a rank ran a region only after its
 * conflicts were applied there). */
static double replay(const sched_ctx *c, double *fin)
{
    const size_t n = c->n;
    rank_seq *rs = gs_calloc(n ? n : 1, sizeof *rs);
    char *done = gs_calloc(n ? n : 1, 1);
    if (!rs || !done) {
        gs_free(rs);
        gs_free(done);
        return -1;
    }
    for (size_t i = 0; i < n; i++)
        rs[i] = (rank_seq){c->rec[c->first + i].rank, c->rec[c->first + i].seq, i};
    qsort(rs, n, sizeof *rs, cmp_rank_seq);
    /* per rank a cursor into rs; sweep until no rank advances */
    double makespan = 0;
    size_t left = n;
    int moved = 1;
    size_t *cur = NULL, *end = NULL;
    double *free_at = NULL;
    size_t nranks = 0;
    for (size_t a = 0; a < n; a++)
        if (a == 0 || rs[a].rank != rs[a - 1].rank)
            nranks++;
    cur = gs_calloc(nranks ? nranks : 1, sizeof *cur);
    end = gs_calloc(nranks ? nranks : 1, sizeof *end);
    free_at = gs_calloc(nranks ? nranks : 1, sizeof *free_at);
    if (!cur || !end || !free_at) {
        left = SIZE_MAX;
        moved = 0;
    } else
        for (size_t a = 0, q = 0; a < n; a++) {
            if (a > 0 && rs[a].rank != rs[a - 1].rank)
                q++;
            if (a == 0 || rs[a].rank != rs[a - 1].rank)
                cur[q] = a;
            end[q] = a + 1;
        }
    while (left > 0 && moved) {
        moved = 0;
        for (size_t q = 0; q < nranks; q++)
            while (cur[q] < end[q]) {
                size_t k = rs[cur[q]].i;
                double start = free_at[q];
                int ok = 1;
                for (int64_t j = c->off[k]; j < c->off[k + 1] && ok; j++) {
                    size_t p = pred_at(c, j);
                    ok = done[p];
                    if (ok && fin[p] > start)
                        start = fin[p];
                }
                if (!ok)
                    break;
                done[k] = 1;
                fin[k] = start + dur(c, k);
                free_at[q] = fin[k];
                makespan = fin[k] > makespan ? fin[k] : makespan;
                cur[q]++;
                left--;
                moved = 1;
            }
    }
    gs_free(rs);
    gs_free(done);
    gs_free(cur);
    gs_free(end);
    gs_free(free_at);
    return left == 0 ? makespan : -1;
}

void model_sched_window(model_engine *e, size_t first, size_t n, const int64_t *off,
                        const int64_t *ids)
{
    if (n == 0 || !e->rec)
        return;
    const size_t m = (size_t)off[n];
    sched_ctx c = {first, n, off, ids, e->rec, gs_calloc(n + 1, sizeof(int64_t)),
                   gs_calloc(m ? m : 1, sizeof(int64_t))};
    double *fin = gs_calloc(n, sizeof *fin);
    if (!fin || !c.succ_off || !c.succ) {
        gs_free(fin);
        gs_free(c.succ_off);
        gs_free(c.succ);
        return; /* figures are bookkeeping: missing, not wrong */
    }
    for (int64_t j = 0; j < off[n]; j++)
        c.succ_off[pred_at(&c, j) + 1]++;
    for (size_t i = 0; i < n; i++)
        c.succ_off[i + 1] += c.succ_off[i];
    for (size_t i = 0; i < n; i++) /* fill, then shift the starts back */
        for (int64_t j = off[i]; j < off[i + 1]; j++)
            c.succ[c.succ_off[pred_at(&c, j)]++] = (int64_t)i;
    for (size_t i = n; i > 0; i--)
        c.succ_off[i] = c.succ_off[i - 1];
    c.succ_off[0] = 0;
    double cpu = 0, crit = 0;
    for (size_t i = 0; i < n; i++) {
        double start = 0;
        for (int64_t j = off[i]; j < off[i + 1]; j++) {
            size_t p = pred_at(&c, j);
            start = fin[p] > start ? fin[p] : start;
        }
        fin[i] = start + dur(&c, i);
        crit = fin[i] > crit ? fin[i] : crit;
        cpu += dur(&c, i);
    }
    double pol = simulate_policy2(&c, fin);
    double rep = replay(&c, fin);
    gs_free(fin);
    gs_free(c.succ_off);
    gs_free(c.succ);
    if (pol < 0 || rep < 0)
        return;
    model_sched *s = &e->sched;
    s->cpu += cpu;
    s->crit += crit;
    s->bound2 += crit > cpu / 2 ? crit : cpu / 2;
    s->policy2 += pol;
    s->replay += rep;
    s->windows++;
}

gs_err model_sched_log(gs_run *run, const model_engine *e, uint64_t window, size_t first,
                       size_t n, const int64_t *off, const int64_t *ids)
{
    char path[4096];
    gs_run_path(run, "schedule.jsonl", path, sizeof path);
    FILE *f = fopen(path, window == 0 ? "w" : "a");
    GS_CHECK(f != NULL, GS_ERR_IO, "%s: cannot open for writing (model.schedule_log)", path);
    for (size_t i = 0; i < n; i++) {
        const region_hdr *h = &e->rec[first + i];
        const gs_model_box *b = &e->plan[first + i].box;
        fprintf(f, "{\"window\":%llu,\"pass\":%d,\"id\":%zu,\"color\":%u,\"rank\":%d,"
                   "\"seq\":%d,\"cpu_s\":%.9f,\"attempts\":%d,\"backtracks\":%llu,\"ok\":%d,"
                   "\"box\":[%d,%d,%d,%d,%d,%d],\"waits_for\":[",
                (unsigned long long)window, e->pass, first + i, e->plan[first + i].color,
                (int)h->rank, (int)h->seq, h->cpu_s, (int)h->attempts,
                (unsigned long long)h->backtracks, (int)h->ok, b->x0, b->y0, b->z0, b->x1, b->y1, b->z1);
        for (int64_t j = off[i]; j < off[i + 1]; j++)
            fprintf(f, "%s%lld", j > off[i] ? "," : "", (long long)ids[j]);
        fprintf(f, "]}\n");
    }
    int bad = ferror(f);
    bad |= fclose(f) != 0;
    GS_CHECK(!bad, GS_ERR_IO, "%s: write failed (model.schedule_log)", path);
    return GS_OK;
}
