/* Automatic pairing for the warp (paper section 5.2, equations 1-3) and the
 * adaptive clustering that picks the target set Q. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "points/points_impl.h"

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
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&start, nq + 1, sizeof *start, "pairing index"), done);
    GS_TRY(err, gs_alloc_array((void **)&used, ns ? ns : 1, 1, "pairing marks"), done);
    GS_TRY(err, gs_alloc_array((void **)&fl, nq ? nq : 1, sizeof *fl, "pairing lengths"), done);
    GS_TRY(err, gs_alloc_array((void **)&fd, 3 * (nq ? nq : 1), sizeof *fd, "pairing dirs"), done);
    GS_TRY(err, gs_alloc_array((void **)&prev, nq ? nq : 1, sizeof *prev, "pairing state"), done);
    /* Candidate lists with c(s, q) (eq. 2); a term over its threshold = inf. */
    for (size_t qi = 0; qi < nq; qi++) {
        start[qi] = ncand;
        const gs_opoint *q = &in->Q[qi];
        for (size_t si = 0; si < ns; si++) {
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
            if (!used[cand[k].s] && cand[k].c < bc) {
                bc = cand[k].c;
                best = (long)cand[k].s;
            }
        pair[qi] = best;
        if (best >= 0)
            used[best] = 1;
    }
    /* Steps 3-6: re-pair with the coherence term g against the last pairing. */
    double two_sig2 = 2.0 * p->coherence_sigma * p->coherence_sigma;
    for (int it = 0; it < p->greedy_iterations; it++) {
        memcpy(prev, pair, nq * sizeof *prev);
        for (size_t qi = 0; qi < nq; qi++) {
            double sw = 0, sl = 0, sd[3] = {0, 0, 0};
            for (size_t r = 0; r < nq; r++) {
                if (r == qi || prev[r] < 0)
                    continue;
                double th = exp(-v3_dist2(in->Q[qi].p, in->Q[r].p) / two_sig2);
                const double *pt = in->S[prev[r]].p, *pr = in->Q[r].p;
                double e[3] = {pt[0] - pr[0], pt[1] - pr[1], pt[2] - pr[2]};
                sw += th;
                sl += th * sqrt(v3_dot(e, e));
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
                if (cost < bc) {
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
    gs_free(start);
    gs_free(cand);
    gs_free(used);
    gs_free(fl);
    gs_free(fd);
    gs_free(prev);
    return err;
}
