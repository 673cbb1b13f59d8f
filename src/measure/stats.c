/* Shared quality-measure statistics (see include/geosynth/measure.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"

double gs_measure_l1(const double *a, const double *b, size_t n)
{
    double sa = 0, sb = 0;
    for (size_t i = 0; i < n; i++)
        sa += a[i], sb += b[i];
    if (sa <= 0 && sb <= 0)
        return 0;
    if (sa <= 0 || sb <= 0)
        return 2;
    double d = 0;
    for (size_t i = 0; i < n; i++)
        d += fabs(a[i] / sa - b[i] / sb);
    return d;
}

static int cmp_double(const void *pa, const void *pb)
{
    double a = *(const double *)pa, b = *(const double *)pb;
    return (a > b) - (a < b);
}

/* Sorted copy of the non-NaN values of x. */
static gs_err sorted_copy(const double *x, size_t n, double **out, size_t *m)
{
    *out = NULL;
    *m = 0;
    if (n == 0)
        return GS_OK;
    GS_CALL(gs_alloc_array((void **)out, n, sizeof **out, "KS sample copy"));
    for (size_t i = 0; i < n; i++)
        if (!isnan(x[i]))
            (*out)[(*m)++] = x[i];
    qsort(*out, *m, sizeof **out, cmp_double);
    return GS_OK;
}

gs_err gs_measure_ks(const double *x, size_t nx, const double *y, size_t ny, double *out)
{
    double *a = NULL, *b = NULL;
    size_t na, nb;
    gs_err err = GS_OK;
    GS_TRY(err, sorted_copy(x, nx, &a, &na), done);
    GS_TRY(err, sorted_copy(y, ny, &b, &nb), done);
    if (na == 0 || nb == 0) {
        *out = (na == 0 && nb == 0) ? 0 : 1;
        goto done;
    }
    double d = 0;
    size_t i = 0, j = 0;
    while (i < na && j < nb) {
        double t = a[i] < b[j] ? a[i] : b[j];
        while (i < na && a[i] <= t)
            i++;
        while (j < nb && b[j] <= t)
            j++;
        double g = fabs((double)i / na - (double)j / nb);
        if (g > d)
            d = g;
    }
    *out = d;
done:
    gs_free(a);
    gs_free(b);
    return err;
}

gs_err gs_measure_components3(const uint8_t *mask, int nx, int ny, int nz, const int periodic[3],
                              uint32_t *label, uint32_t *ncomp, uint64_t **sizes)
{
    GS_CHECK(nx > 0 && ny > 0 && nz > 0, GS_ERR_ARG, "components: grid %dx%dx%d", nx, ny, nz);
    uint64_t cells = (uint64_t)nx * ny * nz;
    GS_CHECK(cells < UINT32_MAX, GS_ERR_ARG, "components: grid of %llu cells is too large",
             (unsigned long long)cells);
    if (sizes)
        *sizes = NULL;
    *ncomp = 0;
    uint32_t *queue = NULL;
    uint64_t *sz = NULL;
    size_t szcap = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&queue, cells, sizeof *queue, "component queue"), done);
    memset(label, 0, cells * sizeof *label);
    const int n[3] = {nx, ny, nz};
    const int wrap[3] = {periodic && periodic[0], periodic && periodic[1], periodic && periodic[2]};
    for (uint64_t s = 0; s < cells; s++) {
        if (!mask[s] || label[s])
            continue;
        uint32_t id = ++*ncomp;
        if (sizes && id >= szcap) {
            size_t cap = szcap ? 2 * szcap : 64;
            uint64_t *g = gs_realloc(sz, cap * sizeof *g);
            GS_TRY_CHECK(err, g, GS_ERR_MEM, done, "cannot grow the component sizes");
            memset(g + szcap, 0, (cap - szcap) * sizeof *g);
            sz = g;
            szcap = cap;
        }
        size_t head = 0, tail = 0;
        queue[tail++] = (uint32_t)s;
        label[s] = id;
        while (head < tail) {
            uint32_t c = queue[head++];
            int p[3] = {(int)(c % nx), (int)((c / nx) % ny), (int)(c / ((uint64_t)nx * ny))};
            for (int k = 0; k < 3; k++)
                for (int d = -1; d <= 1; d += 2) {
                    int q[3] = {p[0], p[1], p[2]};
                    q[k] += d;
                    if (q[k] < 0 || q[k] >= n[k]) {
                        if (!wrap[k] || n[k] == 1)
                            continue;
                        q[k] = (q[k] + n[k]) % n[k];
                    }
                    uint64_t t = (uint64_t)q[0] + (uint64_t)nx * (q[1] + (uint64_t)ny * q[2]);
                    if (mask[t] && !label[t]) {
                        label[t] = id;
                        queue[tail++] = (uint32_t)t;
                    }
                }
        }
        if (sizes)
            sz[id] = tail;
    }
    if (sizes) {
        if (!sz) {
            GS_TRY(err, gs_alloc_array((void **)&sz, 1, sizeof *sz, "component sizes"), done);
            sz[0] = 0;
        }
        *sizes = sz;
        sz = NULL;
    }
done:
    gs_free(queue);
    gs_free(sz);
    return err;
}

void gs_measure_component_euler3(const uint32_t *label, int nx, int ny, int nz, uint32_t ncomp,
                                 int64_t *euler)
{
    const int64_t sy = nx, sz = (int64_t)nx * ny;
    memset(euler, 0, ((size_t)ncomp + 1) * sizeof *euler);
    for (int64_t z = 0; z < nz; z++)
        for (int64_t y = 0; y < ny; y++)
            for (int64_t x = 0; x < nx; x++) {
                int64_t i = x + sy * y + sz * z;
                uint32_t c = label[i];
                if (!c)
                    continue;
                /* 6-adjacent set cells are one component: a test of "set" suffices */
                int bx = x + 1 < nx && label[i + 1], by = y + 1 < ny && label[i + sy],
                    bz = z + 1 < nz && label[i + sz];
                int sxy = bx && by && label[i + 1 + sy], sxz = bx && bz && label[i + 1 + sz],
                    syz = by && bz && label[i + sy + sz];
                int cube = sxy && sxz && syz && label[i + 1 + sy + sz];
                euler[c] += 1 - (bx + by + bz) + (sxy + sxz + syz) - cube;
            }
}

/* Along axis a of v (dims d), each sample becomes the sum of the w samples
 * from it on, wrapped: (w / d) whole periods plus a wrapped partial run. */
static void window_sums_axis(double *v, const int64_t d[3], int a, int64_t w, double *line)
{
    const int64_t st[3] = {1, d[0], d[0] * d[1]};
    int64_t n = d[a], k = w / n, r = w % n;
    int b1 = a == 0 ? 1 : 0, b2 = a == 2 ? 1 : 2;
    for (int64_t j = 0; j < d[b2]; j++)
        for (int64_t i = 0; i < d[b1]; i++) {
            double *p = v + i * st[b1] + j * st[b2], tot = 0;
            for (int64_t x = 0; x < n; x++)
                line[x] = p[x * st[a]], tot += line[x];
            double run = 0; /* partial run of r from x, wrapped */
            for (int64_t x = 0; x < r; x++)
                run += line[x];
            for (int64_t x = 0; x < n; x++) {
                p[x * st[a]] = (double)k * tot + run;
                run += line[(x + r) % n] - line[x];
            }
        }
}

gs_err gs_measure_window_share_range(const uint8_t *mask, const int64_t n[3], const int64_t w[3],
                                     double *lo, double *hi)
{
    int64_t cells = n[0] * n[1] * n[2], big = n[0] > n[1] ? n[0] : n[1];
    big = big > n[2] ? big : n[2];
    double *v = NULL, *line = NULL;
    GS_CALL(gs_alloc_array((void **)&v, (size_t)cells, sizeof *v, "window sums"));
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&line, (size_t)big, sizeof *line, "window sums"), done);
    for (int64_t i = 0; i < cells; i++)
        v[i] = mask[i] != 0;
    for (int a = 0; a < 3; a++)
        window_sums_axis(v, n, a, w[a], line);
    double vol = (double)w[0] * (double)w[1] * (double)w[2];
    *lo = 1, *hi = 0;
    for (int64_t i = 0; i < cells; i++) {
        double f = v[i] / vol;
        *lo = f < *lo ? f : *lo;
        *hi = f > *hi ? f : *hi;
    }
done:
    gs_free(v);
    gs_free(line);
    return err;
}
