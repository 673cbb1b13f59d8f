/* Automatic pairing for the warp (paper section 5.2, equations 1-3) and the
 * adaptive clustering that picks the target set Q. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "points/points_impl.h"

/* Targets up to this many get their coherence weights tabulated (8 MB). */
#define THETA_MAX_Q 1024

typedef struct pair_cand {
    size_t s;
    double c;
} pair_cand;

/* The S points within max_pair_dist of a target, fast: S in xy buckets of
 * that size (a counting sort, so a bucket lists its points in S order). */
typedef struct s_buckets {
    double lo[2], cell;
    long nx, ny;
    size_t *start, *idx; /* start: nx * ny + 1 */
} s_buckets;

static gs_err s_buckets_build(s_buckets *b, const gs_opoint *S, size_t ns, double md)
{
    memset(b, 0, sizeof *b);
    if (ns == 0)
        return GS_OK;
    double lo[2] = {S[0].p[0], S[0].p[1]}, hi[2] = {lo[0], lo[1]};
    for (size_t i = 1; i < ns; i++)
        for (int a = 0; a < 2; a++) {
            lo[a] = fmin(lo[a], S[i].p[a]);
            hi[a] = fmax(hi[a], S[i].p[a]);
        }
    /* Buckets of md unless that makes more of them than points (then
     * coarser: the answers are the same, found with more tests). */
    double cell = md > 0 ? md : INFINITY;
    for (;;) {
        double nx = floor((hi[0] - lo[0]) / cell) + 1, ny = floor((hi[1] - lo[1]) / cell) + 1;
        if (nx * ny <= 4.0 * (double)ns + 16) {
            b->nx = (long)nx;
            b->ny = (long)ny;
            break;
        }
        cell *= 2;
    }
    b->lo[0] = lo[0];
    b->lo[1] = lo[1];
    b->cell = cell;
    size_t nb = (size_t)b->nx * (size_t)b->ny;
    GS_CALL(gs_alloc_array((void **)&b->start, nb + 1, sizeof *b->start, "pairing buckets"));
    gs_err err = gs_alloc_array((void **)&b->idx, ns, sizeof *b->idx, "pairing buckets");
    if (err != GS_OK) {
        gs_free(b->start);
        b->start = NULL;
        return err;
    }
    memset(b->start, 0, (nb + 1) * sizeof *b->start);
    for (size_t i = 0; i < ns; i++) {
        long x = isfinite(cell) ? (long)((S[i].p[0] - lo[0]) / cell) : 0;
        long y = isfinite(cell) ? (long)((S[i].p[1] - lo[1]) / cell) : 0;
        x = x >= b->nx ? b->nx - 1 : x;
        y = y >= b->ny ? b->ny - 1 : y;
        b->start[(size_t)y * (size_t)b->nx + (size_t)x + 1]++;
    }
    for (size_t c = 0; c < nb; c++)
        b->start[c + 1] += b->start[c];
    for (size_t i = 0; i < ns; i++) {
        long x = isfinite(cell) ? (long)((S[i].p[0] - lo[0]) / cell) : 0;
        long y = isfinite(cell) ? (long)((S[i].p[1] - lo[1]) / cell) : 0;
        x = x >= b->nx ? b->nx - 1 : x;
        y = y >= b->ny ? b->ny - 1 : y;
        /* start[c] runs through bucket c's slots (restored below) */
        b->idx[b->start[(size_t)y * (size_t)b->nx + (size_t)x]++] = i;
    }
    for (size_t c = nb; c > 0; c--)
        b->start[c] = b->start[c - 1];
    b->start[0] = 0;
    return GS_OK;
}

static void s_buckets_free(s_buckets *b)
{
    gs_free(b->start);
    gs_free(b->idx);
}

/* Indices of the S points in the buckets that meet the xy box of q +- md,
 * bucket by bucket (a superset of those within md). */
static size_t s_buckets_near(const s_buckets *b, const double q[2], double md, size_t *out)
{
    if (!b->start)
        return 0;
    long x0 = 0, x1 = b->nx - 1, y0 = 0, y1 = b->ny - 1;
    if (isfinite(b->cell)) {
        double fx0 = floor((q[0] - md - b->lo[0]) / b->cell), fx1 = floor((q[0] + md - b->lo[0]) / b->cell);
        double fy0 = floor((q[1] - md - b->lo[1]) / b->cell), fy1 = floor((q[1] + md - b->lo[1]) / b->cell);
        if (!(fx1 >= 0 && fy1 >= 0 && fx0 < (double)b->nx && fy0 < (double)b->ny))
            return 0;
        x0 = fx0 < 0 ? 0 : (long)fx0;
        y0 = fy0 < 0 ? 0 : (long)fy0;
        x1 = fx1 >= (double)b->nx ? b->nx - 1 : (long)fx1;
        y1 = fy1 >= (double)b->ny ? b->ny - 1 : (long)fy1;
    }
    size_t n = 0;
    for (long y = y0; y <= y1; y++)
        for (long x = x0; x <= x1; x++) {
            size_t c = (size_t)y * (size_t)b->nx + (size_t)x;
            for (size_t k = b->start[c]; k < b->start[c + 1]; k++)
                out[n++] = b->idx[k];
        }
    return n;
}

gs_err gs_points_pairing(const gs_points_pairing_in *in, long *pair)
{
    const gs_points_params *p = in->p;
    size_t nq = in->nq, ns = in->ns;
    double inv_sp = 1.0 / in->spacing;
    double maxd2 = p->max_pair_dist * p->max_pair_dist;
    size_t *start = NULL;
    pair_cand *cand = NULL;
    unsigned char *used = NULL;
    double *fl = NULL, *fd = NULL;
    long *prev = NULL;
    size_t ncand = 0, cap = 0, *near = NULL;
    double *theta = NULL, *pe = NULL;
    s_buckets sb = {0};
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&start, nq + 1, sizeof *start, "pairing index"), done);
    GS_TRY(err, gs_alloc_array((void **)&used, ns ? ns : 1, 1, "pairing marks"), done);
    GS_TRY(err, gs_alloc_array((void **)&fl, nq ? nq : 1, sizeof *fl, "pairing lengths"), done);
    GS_TRY(err, gs_alloc_array((void **)&fd, 3 * (nq ? nq : 1), sizeof *fd, "pairing dirs"), done);
    GS_TRY(err, gs_alloc_array((void **)&prev, nq ? nq : 1, sizeof *prev, "pairing state"), done);
    GS_TRY(err, gs_alloc_array((void **)&near, ns ? ns : 1, sizeof *near, "pairing candidates"), done);
    GS_TRY(err, s_buckets_build(&sb, in->S, ns, p->max_pair_dist), done);
    /* Candidate lists with c(s, q) (eq. 2); a term over its threshold = inf.
     * Only S points near q in xy are tested. A list is not in S order, so
     * equal costs go to the lowest S index, as in S order. */
    for (size_t qi = 0; qi < nq; qi++) {
        start[qi] = ncand;
        const gs_opoint *q = &in->Q[qi];
        size_t nn = s_buckets_near(&sb, q->p, p->max_pair_dist, near);
        for (size_t ni = 0; ni < nn; ni++) {
            size_t si = near[ni];
            const gs_opoint *s = &in->S[si];
            double d2 = v3_dist2(s->p, q->p);
            if (d2 > maxd2)
                continue;
            double nt = 0.5 * (1.0 - v3_dot(s->n, q->n));
            if (nt > p->max_normal)
                continue;
            double dv = in->Sv[si] - in->Qv[qi];
            if (fabs(dv) > p->max_variation)
                continue;
            if (ncand == cap) {
                cap = cap ? 2 * cap : 1024;
                pair_cand *nc = gs_realloc(cand, cap * sizeof *nc);
                GS_TRY_CHECK(err, nc != NULL, GS_ERR_MEM, done, "pairing: out of memory");
                cand = nc;
            }
            cand[ncand].s = si;
            cand[ncand].c = p->w_p * sqrt(d2) * inv_sp + p->w_n * nt + p->w_v * dv * dv;
            ncand++;
        }
    }
    start[nq] = ncand;
    /* Steps 1-2: greedy on c alone, in the order of Q. */
    for (size_t qi = 0; qi < nq; qi++) {
        long best = -1;
        double bc = INFINITY;
        for (size_t k = start[qi]; k < start[qi + 1]; k++)
            if (!used[cand[k].s] &&
                (cand[k].c < bc || (cand[k].c == bc && (long)cand[k].s < best))) {
                bc = cand[k].c;
                best = (long)cand[k].s;
            }
        pair[qi] = best;
        if (best >= 0)
            used[best] = 1;
    }
    /* Steps 3-6: re-pair with the coherence term g against the last pairing. */
    double two_sig2 = 2.0 * p->coherence_sigma * p->coherence_sigma;
    /* The weights theta(q, r) and, per iteration, every pair's vector and
     * length are formed once (the same values the sums below would form). */
    if (p->greedy_iterations > 0 && nq <= THETA_MAX_Q) {
        GS_TRY(err, gs_alloc_array((void **)&theta, nq * nq, sizeof *theta, "pairing weights"),
               done);
        for (size_t qi = 0; qi < nq; qi++)
            for (size_t r = 0; r < nq; r++)
                theta[qi * nq + r] = exp(-v3_dist2(in->Q[qi].p, in->Q[r].p) / two_sig2);
    }
    if (p->greedy_iterations > 0)
        GS_TRY(err, gs_alloc_array((void **)&pe, nq ? nq : 1, 4 * sizeof *pe, "pairing vectors"),
               done);
    for (int it = 0; it < p->greedy_iterations; it++) {
        memcpy(prev, pair, nq * sizeof *prev);
        for (size_t r = 0; r < nq; r++) {
            if (prev[r] < 0)
                continue;
            const double *pt = in->S[prev[r]].p, *pr = in->Q[r].p;
            double *e = pe + 4 * r;
            for (int c = 0; c < 3; c++)
                e[c] = pt[c] - pr[c];
            e[3] = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        }
        for (size_t qi = 0; qi < nq; qi++) {
            double sw = 0, sl = 0, sd[3] = {0, 0, 0};
            for (size_t r = 0; r < nq; r++) {
                if (r == qi || prev[r] < 0)
                    continue;
                double th = theta ? theta[qi * nq + r]
                                  : exp(-v3_dist2(in->Q[qi].p, in->Q[r].p) / two_sig2);
                const double *e = pe + 4 * r;
                sw += th;
                sl += th * e[3];
                for (int c = 0; c < 3; c++)
                    sd[c] += th * e[c];
            }
            fl[qi] = sw > 0 ? sl / sw : -1; /* -1: no neighbouring pairs, g = 0 */
            v3_normalize(sd);
            memcpy(fd + 3 * qi, sd, sizeof sd);
        }
        memset(used, 0, ns);
        for (size_t qi = 0; qi < nq; qi++) {
            if (prev[qi] < 0) {
                pair[qi] = -1;
                continue;
            }
            long best = -1;
            double bc = INFINITY;
            for (size_t k = start[qi]; k < start[qi + 1]; k++) {
                if (used[cand[k].s])
                    continue;
                double cost = cand[k].c;
                if (fl[qi] >= 0) {
                    const double *ps = in->S[cand[k].s].p, *pq = in->Q[qi].p;
                    double e[3] = {ps[0] - pq[0], ps[1] - pq[1], ps[2] - pq[2]};
                    double len = sqrt(v3_dot(e, e));
                    cost += p->w_l * fabs(len - fl[qi]) * inv_sp;
                    if (len > 0)
                        cost += 0.5 * p->w_d * (1.0 - v3_dot(fd + 3 * qi, e) / len);
                }
                if (cost < bc || (cost == bc && (long)cand[k].s < best)) {
                    bc = cost;
                    best = (long)cand[k].s;
                }
            }
            pair[qi] = best;
            if (best >= 0)
                used[best] = 1;
        }
    }
done:
    s_buckets_free(&sb);
    gs_free(near);
    gs_free(theta);
    gs_free(pe);
    gs_free(start);
    gs_free(cand);
    gs_free(used);
    gs_free(fl);
    gs_free(fd);
    gs_free(prev);
    return err;
}
