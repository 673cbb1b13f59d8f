/* Adamson-Alexa point-set surface: frames, projection, distance fields and
 * surface variation; see include/geosynth/points.h. */
#include <float.h>
#include <string.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "points/points_impl.h"

double gs_points_mls_frame(const gs_points *nb, double R, const double y[3], double a[3],
                           double n[3])
{
    /* Branch-free: a point beyond R gets weight +0, which leaves every sum
     * exactly as skipping it would (the sums start at +0 and x + 0 = x), so
     * the result is the same while the loop has no unpredictable branch. */
    const double inv_r2 = 1.0 / (R * R), y0 = y[0], y1 = y[1], y2 = y[2];
    double sw = 0, sa0 = 0, sa1 = 0, sa2 = 0, sn0 = 0, sn1 = 0, sn2 = 0;
    const gs_opoint *q = nb->v, *end = nb->v + nb->n;
#ifdef __SSE2__
    /* The same operations as the scalar loop below, each rounded alike (a
     * lane of mulpd/addpd/subpd is the IEEE mulsd/addsd/subsd, and maxsd of
     * (t, 0) is t > 0 ? t : 0, NaN giving 0), two sums per instruction and
     * no branch on the weight (the compiler made t > 0 one). */
    const __m128d vy01 = _mm_set_pd(y1, y0), vy2 = _mm_set_sd(y2), one = _mm_set_sd(1.0);
    const __m128d vinv = _mm_set_sd(inv_r2), zero = _mm_setzero_pd();
    __m128d vsw = zero, vp01 = zero, vp2n0 = zero, vn12 = zero;
    for (; q < end; q++) {
        __m128d p01 = _mm_loadu_pd(q->p), p2n0 = _mm_loadu_pd(q->p + 2);
        __m128d n12 = _mm_loadu_pd(q->n + 1);
        __m128d d01 = _mm_sub_pd(p01, vy01), dz = _mm_sub_sd(p2n0, vy2);
        __m128d sq = _mm_mul_pd(d01, d01);
        __m128d d2 = _mm_add_sd(sq, _mm_unpackhi_pd(sq, sq));
        d2 = _mm_add_sd(d2, _mm_mul_sd(dz, dz));
        __m128d t = _mm_max_sd(_mm_sub_sd(one, _mm_mul_sd(d2, vinv)), zero);
        t = _mm_mul_sd(t, t);
        t = _mm_mul_sd(t, t);
        __m128d w = _mm_unpacklo_pd(t, t);
        vsw = _mm_add_sd(vsw, w);
        vp01 = _mm_add_pd(vp01, _mm_mul_pd(w, p01));
        vp2n0 = _mm_add_pd(vp2n0, _mm_mul_pd(w, p2n0));
        vn12 = _mm_add_pd(vn12, _mm_mul_pd(w, n12));
    }
    sw = _mm_cvtsd_f64(vsw);
    sa0 = _mm_cvtsd_f64(vp01);
    sa1 = _mm_cvtsd_f64(_mm_unpackhi_pd(vp01, vp01));
    sa2 = _mm_cvtsd_f64(vp2n0);
    sn0 = _mm_cvtsd_f64(_mm_unpackhi_pd(vp2n0, vp2n0));
    sn1 = _mm_cvtsd_f64(vn12);
    sn2 = _mm_cvtsd_f64(_mm_unpackhi_pd(vn12, vn12));
#else
    for (; q < end; q++) {
        double dx = q->p[0] - y0, dy = q->p[1] - y1, dz = q->p[2] - y2;
        double t = 1.0 - (dx * dx + dy * dy + dz * dz) * inv_r2;
        t = t > 0 ? t : 0;
        t *= t;
        double w = t * t;
        sw += w;
        sa0 += w * q->p[0];
        sa1 += w * q->p[1];
        sa2 += w * q->p[2];
        sn0 += w * q->n[0];
        sn1 += w * q->n[1];
        sn2 += w * q->n[2];
    }
#endif
    if (sw <= 0)
        return 0;
    a[0] = sa0 / sw;
    a[1] = sa1 / sw;
    a[2] = sa2 / sw;
    n[0] = sn0;
    n[1] = sn1;
    n[2] = sn2;
    if (v3_normalize(n) <= 0)
        return 0; /* opposing normals cancel: no defined surface here */
    return sw;
}

gs_err gs_points_mls_project(const gs_points_grid *g, double R, double max_reach,
                             const double x[3], gs_points *scratch, gs_points_mls_result *res)
{
    memset(res, 0, sizeof *res);
    double c[3], y[3], a[3], n[3];
    memcpy(c, x, sizeof c);
    scratch->n = 0;
    GS_CALL(gs_points_grid_query(g, c, 1.25 * R, scratch));
    int near = 0;
    for (size_t i = 0; i < scratch->n && !near; i++)
        near = v3_dist2(scratch->v[i].p, x) < R * R;
    if (!near) {
        gs_opoint nearest;
        int found;
        GS_CALL(gs_points_grid_nearest_known(g, x, max_reach, 1.25 * R, scratch, &nearest,
                                             &found));
        if (!found)
            return GS_OK;
        memcpy(c, nearest.p, sizeof c);
        scratch->n = 0;
        GS_CALL(gs_points_grid_query(g, c, 1.25 * R, scratch));
        /* Fallback answer if the projection below finds no surface. */
        double d[3] = {x[0] - c[0], x[1] - c[1], x[2] - c[2]};
        double len = sqrt(v3_dot(d, d));
        memcpy(res->y, c, sizeof res->y);
        memcpy(res->n, nearest.n, sizeof res->n);
        res->dist = v3_dot(d, nearest.n) >= 0 ? len : -len;
    }
    memcpy(y, c, sizeof y);
    double tol2 = 1e-8 * R * R;
    for (int it = 0; it < 12; it++) {
        if (v3_dist2(y, c) > 0.0625 * R * R) {
            memcpy(c, y, sizeof c);
            scratch->n = 0;
            GS_CALL(gs_points_grid_query(g, c, 1.25 * R, scratch));
        }
        if (gs_points_mls_frame(scratch, R, y, a, n) <= 0)
            return GS_OK; /* keep the nearest-sample fallback (or ok = 0) */
        double d = (x[0] - a[0]) * n[0] + (x[1] - a[1]) * n[1] + (x[2] - a[2]) * n[2];
        double ny[3] = {x[0] - d * n[0], x[1] - d * n[1], x[2] - d * n[2]};
        double moved = v3_dist2(ny, y);
        memcpy(y, ny, sizeof y);
        memcpy(res->y, y, sizeof res->y);
        memcpy(res->n, n, sizeof res->n);
        res->dist = d;
        res->iterations = it + 1;
        res->ok = 1;
        if (moved < tol2)
            break;
    }
    return GS_OK;
}

gs_err gs_points_field_node(const gs_points_grid *g, double R, double trunc, double max_reach,
                            const double x[3], gs_points *scratch, float o[4])
{
    gs_points_mls_result r;
    GS_CALL(gs_points_mls_project(g, R, max_reach, x, scratch, &r));
    if (r.ok || r.dist != 0 || r.n[0] != 0 || r.n[1] != 0 || r.n[2] != 0) {
        double d = r.dist / trunc;
        o[0] = (float)(d > 1 ? 1 : d < -1 ? -1 : d);
        o[1] = (float)r.n[0];
        o[2] = (float)r.n[1];
        o[3] = (float)r.n[2];
    } else {
        o[0] = 1;
        o[1] = o[2] = o[3] = 0;
    }
    return GS_OK;
}

gs_err gs_points_field_range(const gs_points_grid *g, double R, double trunc, double max_reach,
                             const double lo[3], const double step[3], int nx, int ny,
                             size_t first, size_t count, gs_points *scratch, float *out)
{
    size_t nxy = (size_t)nx * ny;
    for (size_t node = first; node < first + count; node++) {
        int i = (int)(node % (size_t)nx), j = (int)(node / (size_t)nx % (size_t)ny);
        int k = (int)(node / nxy);
        double x[3] = {lo[0] + i * step[0], lo[1] + j * step[1], lo[2] + k * step[2]};
        GS_CALL(gs_points_field_node(g, R, trunc, max_reach, x, scratch, out + 4 * (node - first)));
    }
    return GS_OK;
}

gs_err gs_points_field(const gs_points_grid *g, double R, double trunc, double max_reach,
                       const double lo[3], const double step[3], int nx, int ny, int nz,
                       float *out)
{
    GS_CHECK(trunc > 0 && R > 0, GS_ERR_ARG, "distance field: trunc %g and radius %g must be > 0",
             trunc, R);
    gs_points scratch = {0};
    gs_err err = gs_points_field_range(g, R, trunc, max_reach, lo, step, nx, ny, 0,
                                       (size_t)nx * ny * nz, &scratch, out);
    gs_points_free(&scratch);
    return err;
}

/* Smallest eigenvalue of a symmetric 3x3 matrix (trigonometric method). */
static double sym3_min_eigen(const double m[6]) /* xx yy zz xy xz yz */
{
    double p1 = m[3] * m[3] + m[4] * m[4] + m[5] * m[5];
    double q = (m[0] + m[1] + m[2]) / 3.0;
    if (p1 <= 1e-300) {
        double e = m[0] < m[1] ? m[0] : m[1];
        return e < m[2] ? e : m[2];
    }
    double p2 = (m[0] - q) * (m[0] - q) + (m[1] - q) * (m[1] - q) + (m[2] - q) * (m[2] - q) +
                2 * p1;
    double p = sqrt(p2 / 6.0);
    double b[6] = {(m[0] - q) / p, (m[1] - q) / p, (m[2] - q) / p, m[3] / p, m[4] / p, m[5] / p};
    double detb = b[0] * (b[1] * b[2] - b[5] * b[5]) - b[3] * (b[3] * b[2] - b[5] * b[4]) +
                  b[4] * (b[3] * b[5] - b[1] * b[4]);
    double r = detb / 2.0;
    double phi = r <= -1 ? GS_PI / 3.0 : r >= 1 ? 0 : acos(r) / 3.0;
    return q + 2 * p * cos(phi + 2.0 * GS_PI / 3.0);
}

double gs_points_surface_variation(const gs_points *nbrs, const double c[3], double r)
{
    double r2 = r * r, mean[3] = {0, 0, 0};
    size_t cnt = 0;
    for (size_t i = 0; i < nbrs->n; i++)
        if (v3_dist2(nbrs->v[i].p, c) <= r2) {
            for (int a = 0; a < 3; a++)
                mean[a] += nbrs->v[i].p[a];
            cnt++;
        }
    if (cnt < 3)
        return 0;
    for (int a = 0; a < 3; a++)
        mean[a] /= (double)cnt;
    double m[6] = {0, 0, 0, 0, 0, 0};
    for (size_t i = 0; i < nbrs->n; i++)
        if (v3_dist2(nbrs->v[i].p, c) <= r2) {
            double d[3] = {nbrs->v[i].p[0] - mean[0], nbrs->v[i].p[1] - mean[1],
                           nbrs->v[i].p[2] - mean[2]};
            m[0] += d[0] * d[0];
            m[1] += d[1] * d[1];
            m[2] += d[2] * d[2];
            m[3] += d[0] * d[1];
            m[4] += d[0] * d[2];
            m[5] += d[1] * d[2];
        }
    double tr = m[0] + m[1] + m[2];
    if (tr <= 0)
        return 0;
    double v = sym3_min_eigen(m) / tr;
    return v < 0 ? 0 : v > 1.0 / 3.0 ? 1.0 / 3.0 : v;
}

/* Solves the symmetric positive definite system m (k x k, row-major) c = b
 * by Cholesky; 0 when m is not positive definite enough (a pivot below
 * eps times the largest diagonal entry). */
static int spd_solve(double *m, double *b, int k, double eps)
{
    double dmax = 0;
    for (int i = 0; i < k; i++)
        dmax = fmax(dmax, m[i * k + i]);
    if (!(dmax > 0))
        return 0;
    for (int j = 0; j < k; j++) {
        double d = m[j * k + j];
        for (int p = 0; p < j; p++)
            d -= m[j * k + p] * m[j * k + p];
        if (!(d > eps * dmax))
            return 0;
        d = sqrt(d);
        m[j * k + j] = d;
        for (int i = j + 1; i < k; i++) {
            double s = m[i * k + j];
            for (int p = 0; p < j; p++)
                s -= m[i * k + p] * m[j * k + p];
            m[i * k + j] = s / d;
        }
    }
    for (int i = 0; i < k; i++) { /* L z = b */
        double s = b[i];
        for (int p = 0; p < i; p++)
            s -= m[i * k + p] * b[p];
        b[i] = s / m[i * k + i];
    }
    for (int i = k - 1; i >= 0; i--) { /* L^T c = z */
        double s = b[i];
        for (int p = i + 1; p < k; p++)
            s -= m[p * k + i] * b[p];
        b[i] = s / m[i * k + i];
    }
    return 1;
}

double gs_points_mls_quadric(const gs_points *nb, double R, const double y[3], const double x[3],
                             double out[3], double nout[3])
{
    double a[3], n[3];
    double w = gs_points_mls_frame(nb, R, y, a, n);
    if (w <= 0)
        return 0;
    double u[3], v[3], ax[3] = {1, 0, 0};
    if (fabs(n[0]) > 0.9)
        ax[0] = 0, ax[1] = 1;
    v3_cross(n, ax, u);
    v3_normalize(u);
    v3_cross(n, u, v);
    /* Weighted normal equations of h = c0 + c1 s + c2 t + c3 s^2 + c4 s t
     * + c5 t^2 in the frame (s, t along u, v, h along n, origin a), the
     * coordinates scaled by R (a well-scaled system). */
    const double inv_r2 = 1.0 / (R * R), ir = 1.0 / R;
    double m[36] = {0}, b[6] = {0};
    for (size_t i = 0; i < nb->n; i++) {
        const gs_opoint *q = &nb->v[i];
        double t = 1.0 - v3_dist2(q->p, y) * inv_r2;
        if (!(t > 0))
            continue;
        t *= t;
        double wq = t * t;
        double d[3] = {q->p[0] - a[0], q->p[1] - a[1], q->p[2] - a[2]};
        double s = v3_dot(d, u) * ir, r = v3_dot(d, v) * ir, h = v3_dot(d, n) * ir;
        double f[6] = {1, s, r, s * s, s * r, r * r};
        for (int j = 0; j < 6; j++) {
            b[j] += wq * f[j] * h;
            for (int k = 0; k <= j; k++)
                m[j * 6 + k] += wq * f[j] * f[k];
        }
    }
    for (int j = 0; j < 6; j++)
        for (int k = j + 1; k < 6; k++)
            m[j * 6 + k] = m[k * 6 + j];
    double c[6];
    memcpy(c, b, sizeof c);
    if (!spd_solve(m, c, 6, 1e-9)) { /* too few points around: the plane */
        memset(c, 0, sizeof c);
    }
    double dx[3] = {x[0] - a[0], x[1] - a[1], x[2] - a[2]};
    double s = v3_dot(dx, u) * ir, r = v3_dot(dx, v) * ir;
    double h = c[0] + c[1] * s + c[2] * r + c[3] * s * s + c[4] * s * r + c[5] * r * r;
    double hs = c[1] + 2 * c[3] * s + c[4] * r, hr = c[2] + c[4] * s + 2 * c[5] * r;
    for (int k = 0; k < 3; k++) {
        out[k] = a[k] + R * (s * u[k] + r * v[k] + h * n[k]);
        nout[k] = n[k] - hs * u[k] - hr * v[k];
    }
    if (v3_normalize(nout) <= 0)
        return 0;
    return w;
}
