/* 3D thin-plate spline (biharmonic kernel |r|) solved with LAPACK dgesv;
 * see include/geosynth/points.h. */
#include <lapacke.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "geosynth/mem.h"
#include "points/points_impl.h"

gs_err gs_points_tps_fit(const double *src, const double *dst, int n, double lambda,
                         gs_points_tps *out)
{
    GS_CHECK(n >= 4, GS_ERR_ARG, "thin-plate spline: %d control pairs, expected >= 4", n);
    GS_CHECK(n <= 20000, GS_ERR_ARG, "thin-plate spline: %d control pairs, expected <= 20000", n);
    int N = n + 4;
    double *A = NULL, *B = NULL, *c = NULL, *w = NULL;
    lapack_int *ipiv = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&A, (size_t)N * N, sizeof *A, "spline matrix"), fail);
    GS_TRY(err, gs_alloc_array((void **)&B, (size_t)N * 3, sizeof *B, "spline right-hand side"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&ipiv, (size_t)N, sizeof *ipiv, "spline pivots"), fail);
    GS_TRY(err, gs_alloc_array((void **)&c, (size_t)n * 3, sizeof *c, "spline centers"), fail);
    GS_TRY(err, gs_alloc_array((void **)&w, (size_t)n * 3, sizeof *w, "spline weights"), fail);
    /* Column-major [K P; P^T 0]; symmetric, so the layout does not matter. */
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++)
            A[(size_t)j * N + i] = sqrt(v3_dist2(src + 3 * i, src + 3 * j));
        A[(size_t)i * N + i] += lambda;
        double row[4] = {1, src[3 * i], src[3 * i + 1], src[3 * i + 2]};
        for (int k = 0; k < 4; k++) {
            A[(size_t)(n + k) * N + i] = row[k];
            A[(size_t)i * N + n + k] = row[k];
        }
        for (int d = 0; d < 3; d++)
            B[(size_t)d * N + i] = dst[3 * i + d];
    }
    lapack_int info = LAPACKE_dgesv(LAPACK_COL_MAJOR, N, 3, A, N, ipiv, B, N);
    GS_TRY_CHECK(err, info >= 0, GS_ERR_LIB, fail, "thin-plate spline: dgesv argument %d invalid",
                 (int)-info);
    GS_TRY_CHECK(err, info == 0, GS_ERR_ARG, fail,
                 "thin-plate spline: singular system with %d pairs (coincident or coplanar "
                 "control points)", n);
    for (int i = 0; i < 3 * n; i++)
        if (!isfinite(B[i % n + (size_t)(i / n) * N]))
            info = 1;
    GS_TRY_CHECK(err, info == 0, GS_ERR_ARG, fail, "thin-plate spline: ill-conditioned system");
    memcpy(c, src, (size_t)n * 3 * sizeof *c);
    for (int i = 0; i < n; i++)
        for (int d = 0; d < 3; d++)
            w[3 * i + d] = B[(size_t)d * N + i];
    out->n = n;
    out->c = c;
    out->w = w;
    for (int d = 0; d < 3; d++) {
        out->b[d] = B[(size_t)d * N + n];
        for (int k = 0; k < 3; k++)
            out->A[3 * d + k] = B[(size_t)d * N + n + 1 + k];
    }
    gs_free(A);
    gs_free(B);
    gs_free(ipiv);
    return GS_OK;
fail:
    gs_free(A);
    gs_free(B);
    gs_free(ipiv);
    gs_free(c);
    gs_free(w);
    return err;
}

void gs_points_tps_free(gs_points_tps *t)
{
    gs_free(t->c);
    gs_free(t->w);
    t->c = t->w = NULL;
    t->n = 0;
}

void gs_points_tps_eval(const gs_points_tps *t, const double x[3], double y[3], double J[9])
{
    /* Sums in locals: y and J may alias nothing, but the compiler cannot
     * know, and stores through them every term otherwise. The terms and
     * their order are those of the formula (the result does not change). */
    const double x0 = x[0], x1 = x[1], x2 = x[2];
    double y0 = t->b[0] + t->A[0] * x0 + t->A[1] * x1 + t->A[2] * x2;
    double y1 = t->b[1] + t->A[3] * x0 + t->A[4] * x1 + t->A[5] * x2;
    double y2 = t->b[2] + t->A[6] * x0 + t->A[7] * x1 + t->A[8] * x2;
    const double *c = t->c, *w = t->w;
    const int n = t->n;
    double j[9];
    memcpy(j, t->A, sizeof j);
#ifdef __SSE2__
    /* The loop below with two sums per instruction: each lane rounds like
     * the scalar operation and every sum keeps its terms and their order,
     * so the result is bit-identical. Lanes: (y0, y1) y2, (j0, j1) (j3, j4)
     * (j6, j7), (j2, j5) j8. */
    if (J) {
        const __m128d x01 = _mm_loadu_pd(x), vx2 = _mm_set_sd(x2);
        __m128d vy01 = _mm_set_pd(y1, y0), vy2 = _mm_set_sd(y2);
        __m128d J01 = _mm_loadu_pd(j), J34 = _mm_loadu_pd(j + 3), J67 = _mm_loadu_pd(j + 6);
        __m128d J25 = _mm_set_pd(j[5], j[2]), J8 = _mm_set_sd(j[8]);
        for (int i = 0; i < n; i++, c += 3, w += 3) {
            __m128d e01 = _mm_sub_pd(x01, _mm_loadu_pd(c));
            __m128d e2 = _mm_sub_sd(vx2, _mm_load_sd(c + 2));
            __m128d sq = _mm_mul_pd(e01, e01);
            __m128d r = _mm_add_sd(sq, _mm_unpackhi_pd(sq, sq));
            r = _mm_sqrt_sd(r, _mm_add_sd(r, _mm_mul_sd(e2, e2)));
            __m128d w01 = _mm_loadu_pd(w), w2 = _mm_load_sd(w + 2);
            __m128d rr = _mm_unpacklo_pd(r, r);
            vy01 = _mm_add_pd(vy01, _mm_mul_pd(w01, rr));
            vy2 = _mm_add_sd(vy2, _mm_mul_sd(w2, r));
            if (!(_mm_cvtsd_f64(r) > 0))
                continue;
            __m128d inv = _mm_div_sd(_mm_set_sd(1.0), r);
            inv = _mm_unpacklo_pd(inv, inv);
            __m128d w0 = _mm_unpacklo_pd(w01, w01), w1 = _mm_unpackhi_pd(w01, w01);
            J01 = _mm_add_pd(J01, _mm_mul_pd(_mm_mul_pd(w0, e01), inv));
            J34 = _mm_add_pd(J34, _mm_mul_pd(_mm_mul_pd(w1, e01), inv));
            J67 = _mm_add_pd(J67, _mm_mul_pd(_mm_mul_pd(_mm_unpacklo_pd(w2, w2), e01), inv));
            J25 = _mm_add_pd(J25, _mm_mul_pd(_mm_mul_pd(w01, _mm_unpacklo_pd(e2, e2)), inv));
            J8 = _mm_add_sd(J8, _mm_mul_sd(_mm_mul_sd(w2, e2), inv));
        }
        _mm_storeu_pd(J, J01);
        J[2] = _mm_cvtsd_f64(J25);
        _mm_storeu_pd(J + 3, J34);
        J[5] = _mm_cvtsd_f64(_mm_unpackhi_pd(J25, J25));
        _mm_storeu_pd(J + 6, J67);
        J[8] = _mm_cvtsd_f64(J8);
        y[0] = _mm_cvtsd_f64(vy01);
        y[1] = _mm_cvtsd_f64(_mm_unpackhi_pd(vy01, vy01));
        y[2] = _mm_cvtsd_f64(vy2);
        return;
    }
#endif
    for (int i = 0; i < n; i++, c += 3, w += 3) {
        double e0 = x0 - c[0], e1 = x1 - c[1], e2 = x2 - c[2];
        double r = sqrt(e0 * e0 + e1 * e1 + e2 * e2);
        y0 += w[0] * r;
        y1 += w[1] * r;
        y2 += w[2] * r;
        if (J && r > 0) {
            double inv = 1.0 / r;
            j[0] += w[0] * e0 * inv;
            j[1] += w[0] * e1 * inv;
            j[2] += w[0] * e2 * inv;
            j[3] += w[1] * e0 * inv;
            j[4] += w[1] * e1 * inv;
            j[5] += w[1] * e2 * inv;
            j[6] += w[2] * e0 * inv;
            j[7] += w[2] * e1 * inv;
            j[8] += w[2] * e2 * inv;
        }
    }
    if (J)
        memcpy(J, j, sizeof j);
    y[0] = y0;
    y[1] = y1;
    y[2] = y2;
}

void gs_points_tps_normal(const double J[9], const double n[3], double out[3])
{
    /* Tangents: u orthogonal to n (built from the smallest component), v = n x u. */
    double u[3], v[3];
    double ax = fabs(n[0]), ay = fabs(n[1]), az = fabs(n[2]);
    double e[3] = {0, 0, 0};
    e[(ax <= ay && ax <= az) ? 0 : (ay <= az ? 1 : 2)] = 1;
    v3_cross(n, e, u);
    v3_normalize(u);
    v3_cross(n, u, v);
    double ju[3], jv[3];
    for (int d = 0; d < 3; d++) {
        ju[d] = J[3 * d] * u[0] + J[3 * d + 1] * u[1] + J[3 * d + 2] * u[2];
        jv[d] = J[3 * d] * v[0] + J[3 * d + 1] * v[1] + J[3 * d + 2] * v[2];
    }
    v3_cross(ju, jv, out);
    if (v3_normalize(out) <= 0)
        memcpy(out, n, 3 * sizeof *out);
}
