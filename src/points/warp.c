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
    size_t ncand = 0, cap = 0;
    double *theta = NULL, *pe = NULL;
    gs_points_columns sc = {0};
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&start, nq + 1, sizeof *start, "pairing index"), done);
    GS_TRY(err, gs_alloc_array((void **)&used, ns ? ns : 1, 1, "pairing marks"), done);
    GS_TRY(err, gs_alloc_array((void **)&fl, nq ? nq : 1, sizeof *fl, "pairing lengths"), done);
    GS_TRY(err, gs_alloc_array((void **)&fd, 3 * (nq ? nq : 1), sizeof *fd, "pairing dirs"), done);
    GS_TRY(err, gs_alloc_array((void **)&prev, nq ? nq : 1, sizeof *prev, "pairing state"), done);
    GS_TRY(err, gs_points_columns_build(&sc, in->S, ns, p->max_pair_dist), done);
    /* Candidate lists with c(s, q) (eq. 2); a term over its threshold = inf.
     * Only S points near q in xy are tested. A list is not in S order, so
     * equal costs go to the lowest S index, as in S order. */
    for (size_t qi = 0; qi < nq; qi++) {
        start[qi] = ncand;
        const gs_opoint *q = &in->Q[qi];
        double md = p->max_pair_dist, blo[2] = {q->p[0] - md, q->p[1] - md},
               bhi[2] = {q->p[0] + md, q->p[1] + md};
        int r[4];
        if (!gs_points_columns_range(&sc, blo, bhi, r))
            continue;
        for (int cy = r[2]; cy <= r[3]; cy++) {
            for (int cx = r[0]; cx <= r[1]; cx++) {
                size_t col = (size_t)cy * (size_t)sc.nx + (size_t)cx;
                for (size_t k = sc.start[col]; k < sc.start[col + 1]; k++) {
                    size_t si = sc.idx[k];
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
    gs_points_columns_free(&sc);
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
