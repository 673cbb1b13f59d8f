/* Large-scale repetition of a synthesized height map against its example
 * (see include/geosynth/measure.h, gs_measure_repeats2).
 *
 * Windows of w x w samples are reduced to their residual after the least
 * squares plane (a ramp matches any ramp of the same direction: two slopes
 * are not the same mountain) and normalized, so the normalized cross
 * correlation of two windows is the dot product of their vectors.
 * analysis/field_repeats.py computes the same figures from field.h5. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/sort.h"

/* Window size: the first lag at which the example's autocorrelation (the
 * mean of the x and y ones, mean removed) falls below 1/e, in
 * [3, min(nx, ny) / 2] (two windows that do not overlap fit the example). */
static int feature_size(const double *h, int64_t nx, int64_t ny)
{
    int64_t n = nx * ny, lim = (nx < ny ? nx : ny) / 2;
    double mean = 0, var = 0;
    for (int64_t i = 0; i < n; i++)
        mean += h[i];
    mean /= (double)n;
    for (int64_t i = 0; i < n; i++)
        var += (h[i] - mean) * (h[i] - mean);
    var /= (double)n;
    if (lim < 3)
        return (int)lim;
    if (var <= 0)
        return 3;
    int64_t L = 1;
    for (; L < lim; L++) {
        double cx = 0, cy = 0;
        for (int64_t y = 0; y < ny; y++)
            for (int64_t x = 0; x + L < nx; x++)
                cx += (h[x + nx * y] - mean) * (h[x + L + nx * y] - mean);
        for (int64_t y = 0; y + L < ny; y++)
            for (int64_t x = 0; x < nx; x++)
                cy += (h[x + nx * y] - mean) * (h[x + nx * (y + L)] - mean);
        double c = 0.5 * (cx / (double)((nx - L) * ny) + cy / (double)(nx * (ny - L))) / var;
        if (c < exp(-1.0))
            break;
    }
    return (int)(L < 3 ? 3 : L);
}

/* The windows at stride st of an nx x ny map: origins (x, y), residual RMS,
 * and normalized residual vectors (w*w each). */
typedef struct windows {
    int64_t n;
    int64_t *x, *y;
    double *rms;
    float *v;
} windows;

static void windows_free(windows *W)
{
    gs_free(W->x);
    gs_free(W->y);
    gs_free(W->rms);
    gs_free(W->v);
    memset(W, 0, sizeof *W);
}

static gs_err windows_make(const double *h, int64_t nx, int64_t ny, int w, windows *W)
{
    memset(W, 0, sizeof *W);
    const int64_t st = 1;
    int64_t px = (nx - w) / st + 1, py = (ny - w) / st + 1, n = px * py, ww = (int64_t)w * w;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&W->x, (size_t)n, sizeof *W->x, "repeat windows"), fail);
    GS_TRY(err, gs_alloc_array((void **)&W->y, (size_t)n, sizeof *W->y, "repeat windows"), fail);
    GS_TRY(err, gs_alloc_array((void **)&W->rms, (size_t)n, sizeof *W->rms, "repeat windows"), fail);
    GS_TRY(err, gs_alloc_array((void **)&W->v, (size_t)(n * ww), sizeof *W->v, "repeat windows"), fail);
    double c = 0.5 * (w - 1), sxx = 0;
    for (int i = 0; i < w; i++)
        sxx += (i - c) * (i - c);
    sxx *= w; /* sum over the window of (x - c)^2, the same for y */
    for (int64_t k = 0; k < n; k++) {
        int64_t x0 = k % px * st, y0 = k / px * st;
        float *v = W->v + k * ww;
        double mean = 0, bx = 0, by = 0, ss = 0;
        for (int j = 0; j < w; j++)
            for (int i = 0; i < w; i++) {
                double a = h[x0 + i + nx * (y0 + j)];
                mean += a, bx += (i - c) * a, by += (j - c) * a;
            }
        mean /= (double)ww, bx /= sxx, by /= sxx;
        for (int j = 0; j < w; j++)
            for (int i = 0; i < w; i++) {
                double e = h[x0 + i + nx * (y0 + j)] - mean - bx * (i - c) - by * (j - c);
                ss += e * e;
            }
        double norm = sqrt(ss);
        for (int j = 0; j < w; j++)
            for (int i = 0; i < w; i++) {
                double e = h[x0 + i + nx * (y0 + j)] - mean - bx * (i - c) - by * (j - c);
                v[i + w * j] = (float)(norm > 0 ? e / norm : 0);
            }
        W->x[k] = x0, W->y[k] = y0, W->rms[k] = sqrt(ss / (double)ww);
    }
    W->n = n;
    return GS_OK;
fail:
    windows_free(W);
    return err;
}

static double dot(const float *a, const float *b, int64_t n)
{
    double s[4] = {0, 0, 0, 0};
    int64_t i = 0;
    for (; i + 4 <= n; i += 4)
        for (int k = 0; k < 4; k++)
            s[k] += (double)a[i + k] * b[i + k];
    for (; i < n; i++)
        s[0] += (double)a[i] * b[i];
    return (s[0] + s[1]) + (s[2] + s[3]);
}

/* window k lies inside the crop box (x0, y0, width, height) and on its grid
 * of stride st (origin a multiple of st from the crop's along x and y) */
static int in_box(const windows *W, int64_t k, int w, const int64_t box[4])
{
    return W->x[k] >= box[0] && W->y[k] >= box[1] && W->x[k] + w <= box[0] + box[2] &&
           W->y[k] + w <= box[1] + box[3];
}

static int on_grid(const windows *W, int64_t k, int st, const int64_t box[4])
{
    return (W->x[k] - box[0]) % st == 0 && (W->y[k] - box[1]) % st == 0;
}

static int overlap(const windows *A, int64_t i, const windows *B, int64_t j, int w)
{
    return llabs(A->x[i] - B->x[j]) < w && llabs(A->y[i] - B->y[j]) < w;
}

/* Highest NCC between a window of W inside box on its grid of stride st and
 * any other window of W inside box, both with relief >= floor, that do not
 * overlap and whose origins are at most reach apart along each axis (one
 * side on every position: a repeat at any offset is seen whole); -1 when
 * there is no such pair. */
static double best_pair(const windows *W, int w, int st, double floor, int64_t reach,
                        const int64_t box[4])
{
    double best = -1;
    int64_t ww = (int64_t)w * w;
    for (int64_t i = 0; i < W->n; i++) {
        if (W->rms[i] < floor || !in_box(W, i, w, box) || !on_grid(W, i, st, box))
            continue;
        for (int64_t j = 0; j < W->n; j++) {
            if (W->rms[j] < floor || !in_box(W, j, w, box) || overlap(W, i, W, j, w) ||
                llabs(W->x[i] - W->x[j]) > reach || llabs(W->y[i] - W->y[j]) > reach)
                continue;
            double c = dot(W->v + i * ww, W->v + j * ww, ww);
            if (c > best)
                best = c;
        }
    }
    return best;
}

/* Crop origins along an axis of n samples for crops of c (the example's
 * side, at most n): every c/2 samples from 0, and n - c last, so the crops
 * cover the axis; returns their count (at most n + 1). */
static int64_t crop_origins(int64_t n, int64_t c, int64_t *o)
{
    if (c >= n) {
        o[0] = 0;
        return 1;
    }
    int64_t step = c / 2 > 0 ? c / 2 : 1, k = 0;
    for (int64_t p = 0; p + c <= n; p += step)
        o[k++] = p;
    if (o[k - 1] != n - c)
        o[k++] = n - c;
    return k;
}

/* ncc_out_area: the median over the output's example-sized crops of the
 * most alike two places inside each crop (crops without a pair left out;
 * -1 when no crop has one). */
static gs_err area_figure(const windows *O, int64_t onx, int64_t ony, int64_t snx, int64_t sny,
                          gs_measure_repeats *m)
{
    int64_t cx = snx < onx ? snx : onx, cy = sny < ony ? sny : ony, *ox = NULL, *oy = NULL;
    double *f = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&ox, (size_t)onx + 1, sizeof *ox, "repeat crops"), done);
    GS_TRY(err, gs_alloc_array((void **)&oy, (size_t)ony + 1, sizeof *oy, "repeat crops"), done);
    int64_t nx = crop_origins(onx, cx, ox), ny = crop_origins(ony, cy, oy), nf = 0;
    GS_TRY(err, gs_alloc_array((void **)&f, (size_t)(nx * ny), sizeof *f, "repeat crops"), done);
    for (int64_t j = 0; j < ny; j++)
        for (int64_t i = 0; i < nx; i++) {
            const int64_t box[4] = {ox[i], oy[j], cx, cy};
            double c = best_pair(O, m->window, m->stride, m->relief, m->reach, box);
            if (c > -1)
                f[nf++] = c;
        }
    m->crops = (int)(nx * ny);
    if (nf == 0) {
        m->ncc_out_area = -1;
        goto done;
    }
    gs_sort_f64(f, (size_t)nf);
    m->ncc_out_area = nf % 2 ? f[nf / 2] : 0.5 * (f[nf / 2 - 1] + f[nf / 2]);
    m->ncc_out_area_max = f[nf - 1];
done:
    gs_free(ox);
    gs_free(oy);
    gs_free(f);
    return err;
}

typedef struct hit {
    double c;
    int64_t j;
} hit;

static int cmp_hit(const void *a_, const void *b_)
{
    const hit *a = a_, *b = b_;
    if (a->c != b->c)
        return a->c > b->c ? -1 : 1;
    return (a->j > b->j) - (a->j < b->j);
}

gs_err gs_measure_repeats2(const double *out, int64_t onx, int64_t ony, const double *src,
                           int64_t snx, int64_t sny, gs_measure_repeats *m)
{
    memset(m, 0, sizeof *m);
    int w = feature_size(src, snx, sny);
    GS_CHECK(w >= 3 && w <= onx && w <= ony, GS_ERR_ARG,
             "repeat measure: example %lldx%lld, output %lldx%lld: expected both at least 6 "
             "samples along x and y", (long long)snx, (long long)sny, (long long)onx,
             (long long)ony);
    m->window = w;
    m->stride = w / 4 > 1 ? w / 4 : 1;
    m->reach = snx > sny ? snx : sny;
    windows S = {0}, O = {0};
    double *r = NULL;
    hit *hits = NULL;
    gs_err err = GS_OK;
    int64_t ww = (int64_t)w * w;
    GS_TRY(err, windows_make(src, snx, sny, w, &S), done);
    GS_TRY(err, windows_make(out, onx, ony, w, &O), done);
    /* relief floor: the median residual RMS of the example's windows */
    GS_TRY(err, gs_alloc_array((void **)&r, (size_t)S.n, sizeof *r, "window relief"), done);
    memcpy(r, S.rms, (size_t)S.n * sizeof *r);
    gs_sort_f64(r, (size_t)S.n);
    m->relief = S.n % 2 ? r[S.n / 2] : 0.5 * (r[S.n / 2 - 1] + r[S.n / 2]);
    for (int64_t i = 0; i < S.n; i++)
        m->windows_src += S.rms[i] >= m->relief;
    for (int64_t i = 0; i < O.n; i++)
        m->windows_out += O.rms[i] >= m->relief;
    const int64_t sbox[4] = {0, 0, snx, sny}, obox[4] = {0, 0, onx, ony};
    m->ncc_src = best_pair(&S, w, m->stride, m->relief, m->reach, sbox);
    m->ncc_out = best_pair(&O, w, m->stride, m->relief, m->reach, obox);
    GS_TRY(err, area_figure(&O, onx, ony, snx, sny, m), done);
    /* recurrence: distinct output windows matching one example window
     * better than any other example window that does not overlap it does */
    GS_TRY(err, gs_alloc_array((void **)&hits, (size_t)(O.n ? O.n : 1), sizeof *hits, "repeat hits"), done);
    for (int64_t i = 0; i < S.n; i++) {
        if (S.rms[i] < m->relief || !on_grid(&S, i, m->stride, sbox))
            continue;
        int64_t nh = 0;
        for (int64_t j = 0; j < O.n; j++) {
            if (O.rms[j] < m->relief)
                continue;
            double c = dot(S.v + i * ww, O.v + j * ww, ww);
            if (c >= m->ncc_src)
                hits[nh].c = c, hits[nh++].j = j;
        }
        if (nh <= m->recur_out)
            continue;
        qsort(hits, (size_t)nh, sizeof *hits, cmp_hit);
        int64_t took = 0;
        for (int64_t k = 0; k < nh; k++) {
            int free_ = 1;
            for (int64_t t = 0; t < took && free_; t++)
                free_ = !overlap(&O, hits[k].j, &O, hits[t].j, w);
            if (free_)
                hits[took++] = hits[k];
        }
        if (took > m->recur_out)
            m->recur_out = (int)took;
    }
done:
    windows_free(&S);
    windows_free(&O);
    gs_free(r);
    gs_free(hits);
    return err;
}
