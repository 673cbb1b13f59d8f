/* Shared quality-measure statistics (see include/geosynth/measure.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/sort.h"
#include "unionfind.h"

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
    gs_sort_f64(*out, *m);
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

/* Provisional label arrays: parents in the outer and the inner set, and
 * the class of each label's samples. */
typedef struct nest_labels {
    uint32_t *po, *pi;
    uint8_t *k;
    size_t n, cap;
} nest_labels;

static gs_err nest_new(nest_labels *L, uint8_t k, uint32_t *l)
{
    if (L->n + 1 >= L->cap) {
        size_t cap = L->cap ? 2 * L->cap : 1024;
        void **arr[3] = {(void **)&L->po, (void **)&L->pi, (void **)&L->k};
        const size_t size[3] = {sizeof *L->po, sizeof *L->pi, sizeof *L->k};
        for (int a = 0; a < 3; a++) {
            void *g = gs_realloc(*arr[a], cap * size[a]);
            GS_CHECK(g, GS_ERR_MEM, "components: out of memory for %zu labels", cap);
            *arr[a] = g;
        }
        L->cap = cap;
    }
    *l = (uint32_t)++L->n;
    L->po[*l] = L->pi[*l] = *l;
    L->k[*l] = k;
    return GS_OK;
}

/* Labels -> component numbers in place (p[l] becomes the number of l's
 * component, numbered in order of their lowest label), for the labels of
 * class >= kmin; returns the count. */
static uint32_t nest_number(uint32_t *p, const uint8_t *k, size_t n, uint8_t kmin)
{
    uint32_t c = 0;
    for (size_t l = 1; l <= n; l++) {
        if (k[l] < kmin)
            continue;
        uint32_t r = p[l]; /* r < l was numbered already */
        p[l] = r == l ? ++c : p[r];
    }
    return c;
}

void gs_measure_nested_free(gs_measure_nested *r)
{
    gs_free(r->outer);
    gs_free(r->inner);
    memset(r, 0, sizeof *r);
}

gs_err gs_measure_components_nested3(const uint8_t *v, const int64_t n[3], const uint8_t cls[256],
                                     int euler, gs_measure_nested *r)
{
    memset(r, 0, sizeof *r);
    GS_CHECK(n[0] > 0 && n[1] > 0 && n[2] > 0, GS_ERR_ARG, "components: grid %lldx%lldx%lld",
             (long long)n[0], (long long)n[1], (long long)n[2]);
    const int64_t nx = n[0], ny = n[1], nz = n[2], sy = nx, sz = nx * ny, cells = sz * nz;
    GS_CHECK(cells < (int64_t)UINT32_MAX, GS_ERR_ARG,
             "components: grid of %lld samples is too large", (long long)cells);
    uint32_t *lab = NULL;
    double *ctr = NULL;
    nest_labels L;
    memset(&L, 0, sizeof L);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&lab, (size_t)cells, sizeof *lab, "component labels"), done);
    /* pass 1: a sample takes the label of a lower neighbour of its class
     * (else a new one) and joins every lower neighbour's in the outer set,
     * the inner one's in the inner set */
    for (int64_t z = 0, i = 0; z < nz; z++)
        for (int64_t y = 0; y < ny; y++)
            for (int64_t x = 0; x < nx; x++, i++) {
                uint8_t k = cls[v[i]];
                lab[i] = 0;
                if (!k)
                    continue;
                int64_t nb[3] = {x > 0 ? i - 1 : -1, y > 0 ? i - sy : -1, z > 0 ? i - sz : -1};
                uint8_t kb[3];
                uint32_t l = 0;
                for (int a = 0; a < 3; a++) {
                    kb[a] = nb[a] < 0 ? 0 : cls[v[nb[a]]];
                    if (!l && kb[a] == k)
                        l = lab[nb[a]];
                }
                if (!l)
                    GS_TRY(err, nest_new(&L, k, &l), done);
                lab[i] = l;
                for (int a = 0; a < 3; a++) {
                    if (!kb[a])
                        continue;
                    uint32_t m = lab[nb[a]];
                    if (m == l)
                        continue;
                    uf_union(L.po, l, m);
                    if (k == 2 && kb[a] == 2)
                        uf_union(L.pi, l, m);
                }
            }
    r->nouter = nest_number(L.po, L.k, L.n, 1);
    r->ninner = nest_number(L.pi, L.k, L.n, 2);
    GS_TRY(err, gs_alloc_array((void **)&r->outer, (size_t)r->nouter + 1, sizeof *r->outer,
                               "outer components"), done);
    GS_TRY(err, gs_alloc_array((void **)&r->inner, (size_t)r->ninner + 1, sizeof *r->inner,
                               "inner components"), done);
    memset(r->outer, 0, ((size_t)r->nouter + 1) * sizeof *r->outer);
    memset(r->inner, 0, ((size_t)r->ninner + 1) * sizeof *r->inner);
    /* pass 3: count (the Euler terms as gs_measure_component_euler3's, a
     * sample of the outer set being a set cell there) */
    for (int64_t z = 0, i = 0; z < nz; z++)
        for (int64_t y = 0; y < ny; y++) {
            uint8_t fyz = (uint8_t)((y == 0) << 2 | (y == ny - 1) << 3 | (z == 0) << 4 |
                                    (z == nz - 1) << 5);
            for (int64_t x = 0; x < nx; x++, i++) {
                uint32_t l = lab[i];
                if (!l)
                    continue;
                uint8_t f = fyz | (uint8_t)((x == 0) | (x == nx - 1) << 1);
                gs_measure_component *o = &r->outer[L.po[l]];
                o->size++;
                o->faces |= f;
                if (euler) {
                    int bx = x + 1 < nx && lab[i + 1], by = y + 1 < ny && lab[i + sy],
                        bz = z + 1 < nz && lab[i + sz];
                    int sxy = bx && by && lab[i + 1 + sy], sxz = bx && bz && lab[i + 1 + sz],
                        syz = by && bz && lab[i + sy + sz];
                    int cube = sxy && sxz && syz && lab[i + 1 + sy + sz];
                    o->euler += 1 - (bx + by + bz) + (sxy + sxz + syz) - cube;
                }
                if (L.k[l] == 2) {
                    gs_measure_component *c = &r->inner[L.pi[l]];
                    c->size++;
                    c->faces |= f;
                    c->sum[0] += (double)x, c->sum[1] += (double)y, c->sum[2] += (double)z;
                }
            }
        }
    /* pass 4: each core's largest distance from its centre (the sums
     * divided as the layout divides them) */
    GS_TRY(err, gs_alloc_array((void **)&ctr, (size_t)r->ninner + 1, 3 * sizeof *ctr,
                               "core centres"), done);
    for (uint32_t c = 1; c <= r->ninner; c++)
        for (int a = 0; a < 3; a++)
            ctr[3 * c + a] = r->inner[c].sum[a] / (double)r->inner[c].size;
    for (int64_t z = 0, i = 0; z < nz; z++)
        for (int64_t y = 0; y < ny; y++)
            for (int64_t x = 0; x < nx; x++, i++) {
                uint32_t l = lab[i];
                if (!l || L.k[l] != 2)
                    continue;
                uint32_t c = L.pi[l];
                const double *m = ctr + 3 * c;
                double dx = (double)x - m[0], dy = (double)y - m[1], dz = (double)z - m[2];
                double d = sqrt(dx * dx + dy * dy + dz * dz);
                if (d > r->inner[c].radius)
                    r->inner[c].radius = d;
            }
done:
    gs_free(lab);
    gs_free(ctr);
    gs_free(L.po);
    gs_free(L.pi);
    gs_free(L.k);
    if (err != GS_OK)
        gs_measure_nested_free(r);
    return err;
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
