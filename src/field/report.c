/* Geometry measures of an output against its source (see
 * include/geosynth/field.h, gs_field_geometry_measure): computed from the
 * two quantized fields alone, never from the synthesis' bookkeeping. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "field_impl.h"
#include "geosynth/log.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/sort.h"

double gs_field_step_violations(const float *v, const int64_t n[3], double spacing, double limit)
{
    int64_t nx = n[0], nxy = n[0] * n[1], pairs = 0, bad = 0;
    double lim = limit * spacing;
    for (int64_t z = 0; z < n[2]; z++)
        for (int64_t y = 0; y < n[1]; y++)
            for (int64_t x = 0; x < nx; x++) {
                int64_t i = x + nx * y + nxy * z;
                if (x + 1 < nx)
                    pairs++, bad += fabs((double)v[i + 1] - v[i]) > lim;
                if (y + 1 < n[1])
                    pairs++, bad += fabs((double)v[i + nx] - v[i]) > lim;
                if (z + 1 < n[2])
                    pairs++, bad += fabs((double)v[i + nxy] - v[i]) > lim;
            }
    return pairs ? (double)bad / (double)pairs : 0;
}

/* The same on quantized levels (a level is (hi-lo)/255 of distance). */
static double level_step_violations(const gs_qfield *q, double limit)
{
    double per = (q->hi - q->lo) / 255.0 / q->spacing; /* samples per level */
    int lim = (int)floor(limit / per); /* |dl| > lim  <=>  |dl| * per > limit */
    int64_t nx = q->nx, nxy = q->nx * q->ny, pairs = 0, bad = 0;
    const uint8_t *v = q->q;
    for (int64_t z = 0; z < q->nz; z++)
        for (int64_t y = 0; y < q->ny; y++)
            for (int64_t x = 0; x < nx; x++) {
                int64_t i = x + nx * y + nxy * z;
                if (x + 1 < nx)
                    pairs++, bad += abs(v[i + 1] - v[i]) > lim;
                if (y + 1 < q->ny)
                    pairs++, bad += abs(v[i + nx] - v[i]) > lim;
                if (z + 1 < q->nz)
                    pairs++, bad += abs(v[i + nxy] - v[i]) > lim;
            }
    return pairs ? (double)bad / (double)pairs : 0;
}

/* Topology of the inside components (gs_field_geometry_report's genus_*,
 * ring_share, open_per_msample, handles_*). */
typedef struct inside_topology {
    int64_t genus[5], handles, handles_all;
    uint64_t samples, samples_all;
} inside_topology;

/* The inside samples of q and their core (deeper than one sample: the
 * objects of the layout, gs_field_layout_mask's), labelled once
 * (gs_measure_components_nested3): *k's outer components are the inside
 * components, its inner ones the cores. */
static gs_err label_inside(const gs_qfield *q, gs_measure_nested *k)
{
    uint8_t cls[256];
    for (int i = 0; i < 256; i++) {
        double v = gs_qfield_value(q, (uint8_t)i);
        cls[i] = v / q->spacing < -1.0 ? 2 : v < 0;
        GS_CHECK(cls[i] != 2 || v < 0, GS_ERR_ARG, "layout: a core level %d not inside", i);
    }
    const int64_t n[3] = {q->nx, q->ny, q->nz};
    return gs_measure_components_nested3(q->q, n, cls, 1, k);
}

/* Inside components (k: label_inside's) that touch none of the grid's faces
 * (one that does may be cut by the box: the output's at its faces are, and
 * the source's would be): count and sizes (sorted ascending, *sizes owned by
 * the caller, *n entries), and their topology *t. */
static gs_err inside_components(const gs_measure_nested *k, uint64_t **sizes, int64_t *n,
                                inside_topology *t)
{
    memset(t, 0, sizeof *t);
    uint64_t *sz = NULL;
    GS_CALL(gs_alloc_array((void **)&sz, (size_t)k->nouter + 1, sizeof *sz, "component sizes"));
    uint32_t keep = 0;
    for (uint32_t c = 1; c <= k->nouter; c++) {
        const gs_measure_component *o = &k->outer[c];
        t->handles_all += 1 - o->euler, t->samples_all += o->size;
        if (o->faces) /* touches a face: dropped */
            continue;
        int64_t h = 1 - o->euler; /* a cavity (never in rings) counts as -1 */
        t->genus[h < 0 ? 0 : h > 4 ? 4 : h]++;
        t->handles += h, t->samples += o->size;
        sz[keep++] = o->size;
    }
    gs_sort_u64(sz, keep);
    *sizes = sz;
    *n = keep;
    return GS_OK;
}

/* The topology figures of the report from t (n interior components, cells
 * samples in the grid). */
static void topology_figures(const inside_topology *t, int64_t n, int64_t cells, int64_t *genus,
                             double *ring_share, double *open_per_msample,
                             double *handles_per_kinside, double *handles_all_per_kinside)
{
    memcpy(genus, t->genus, sizeof t->genus);
    *ring_share = n ? (double)(n - t->genus[0]) / (double)n : 0;
    *open_per_msample = 1e6 * (double)t->genus[0] / (double)cells;
    *handles_per_kinside = t->samples ? 1e3 * (double)t->handles / (double)t->samples : 0;
    *handles_all_per_kinside =
        t->samples_all ? 1e3 * (double)t->handles_all / (double)t->samples_all : 0;
}

static double median_u64(const uint64_t *s, int64_t n)
{
    if (n == 0)
        return 0;
    return n % 2 ? (double)s[n / 2] : 0.5 * ((double)s[n / 2 - 1] + (double)s[n / 2]);
}

static double share_below(const uint64_t *s, int64_t n, double t)
{
    int64_t c = 0;
    while (c < n && (double)s[c] < t)
        c++;
    return n ? (double)c / (double)n : 0;
}

/* Squared Euclidean distance transform along one line of n values
 * (Felzenszwalb and Huttenlocher 2012): f in, d out, stride st; v, z
 * scratch of n and n + 1. */
static void edt_line(uint16_t *g, int64_t n, int64_t st, double *f, double *d, int64_t *v,
                     double *z)
{
    const double INF = 1e20;
    for (int64_t i = 0; i < n; i++)
        f[i] = g[i * st] == UINT16_MAX ? INF : (double)g[i * st];
    int64_t k = 0;
    v[0] = 0, z[0] = -INF, z[1] = INF;
    for (int64_t q = 1; q < n; q++) {
        double sq;
        for (;;) {
            int64_t p = v[k];
            sq = ((f[q] + (double)(q * q)) - (f[p] + (double)(p * p))) / (double)(2 * q - 2 * p);
            if (sq <= z[k] && k > 0)
                k--;
            else
                break;
        }
        if (sq <= z[k]) { /* k == 0: q replaces the first parabola */
            v[0] = q, z[0] = -INF, z[1] = INF;
            continue;
        }
        k++;
        v[k] = q, z[k] = sq, z[k + 1] = INF;
    }
    k = 0;
    for (int64_t q = 0; q < n; q++) {
        while (z[k + 1] < (double)q)
            k++;
        double dq = (double)(q - v[k]);
        d[q] = dq * dq + f[v[k]];
    }
    for (int64_t i = 0; i < n; i++)
        g[i * st] = d[i] >= (double)(UINT16_MAX - 1) ? UINT16_MAX - 1 : (uint16_t)d[i];
}

/* Radii (samples, sorted ascending) of the largest inscribed spheres: the
 * inside samples at least one sample from every face whose distance to the
 * nearest outside sample (an exact Euclidean distance transform of the
 * inside, so not limited by the quantization band as the field's own depth
 * is) is a maximum over their 26 neighbours: a ball's centre, a fiber's
 * axis. Outside the grid counts as neither. *r owned by the caller. Memory:
 * 2 bytes per sample. */
static gs_err inscribed_radii(const gs_qfield *q, double **r, int64_t *n)
{
    int64_t nx = q->nx, ny = q->ny, nz = q->nz, nxy = nx * ny, cells = nxy * nz;
    int64_t big = nx > ny ? nx : ny;
    big = big > nz ? big : nz;
    uint16_t *g = NULL;
    double *f = NULL, *d = NULL, *z = NULL, *v = NULL;
    int64_t *vi = NULL, cnt = 0, cap = 1024;
    gs_err err = GS_OK;
    uint8_t inside[256];
    for (int i = 0; i < 256; i++)
        inside[i] = gs_qfield_value(q, (uint8_t)i) < 0;
    GS_TRY(err, gs_alloc_array((void **)&g, (size_t)cells, sizeof *g, "inscribed distances"), done);
    GS_TRY(err, gs_alloc_array((void **)&f, (size_t)big, sizeof *f, "distance line"), done);
    GS_TRY(err, gs_alloc_array((void **)&d, (size_t)big, sizeof *d, "distance line"), done);
    GS_TRY(err, gs_alloc_array((void **)&z, (size_t)big + 1, sizeof *z, "distance line"), done);
    GS_TRY(err, gs_alloc_array((void **)&vi, (size_t)big, sizeof *vi, "distance line"), done);
    GS_TRY(err, gs_alloc_array((void **)&v, (size_t)cap, sizeof *v, "inscribed radii"), done);
    for (int64_t i = 0; i < cells; i++)
        g[i] = inside[q->q[i]] ? UINT16_MAX : 0;
    for (int64_t zz = 0; zz < nz; zz++)
        for (int64_t y = 0; y < ny; y++)
            edt_line(g + nxy * zz + nx * y, nx, 1, f, d, vi, z);
    for (int64_t zz = 0; zz < nz; zz++)
        for (int64_t x = 0; x < nx; x++)
            edt_line(g + nxy * zz + x, ny, nx, f, d, vi, z);
    for (int64_t y = 0; y < ny; y++)
        for (int64_t x = 0; x < nx; x++)
            edt_line(g + nx * y + x, nz, nxy, f, d, vi, z);
    for (int64_t zz = 1; zz + 1 < nz; zz++)
        for (int64_t y = 1; y + 1 < ny; y++)
            for (int64_t x = 1; x + 1 < nx; x++) {
                int64_t i = x + nx * y + nxy * zz;
                uint16_t e = g[i];
                if (!e)
                    continue;
                int top = 1;
                for (int dz = -1; dz <= 1 && top; dz++)
                    for (int dy = -1; dy <= 1 && top; dy++)
                        for (int dx = -1; dx <= 1 && top; dx++)
                            top = g[i + dx + nx * dy + nxy * dz] <= e;
                if (!top)
                    continue;
                if (cnt == cap) {
                    double *w = gs_realloc(v, (size_t)cap * 2 * sizeof *v);
                    GS_TRY_CHECK(err, w, GS_ERR_MEM, done, "out of memory for %lld inscribed radii",
                                 (long long)cap * 2);
                    v = w, cap *= 2;
                }
                v[cnt++] = sqrt((double)e);
            }
    gs_sort_f64(v, (size_t)cnt);
    *r = v, *n = cnt;
    v = NULL;
done:
    gs_free(g);
    gs_free(f);
    gs_free(d);
    gs_free(z);
    gs_free(vi);
    gs_free(v);
    return err;
}

static double quantile(const double *s, int64_t n, double p)
{
    if (n == 0)
        return 0;
    int64_t k = (int64_t)(p * (double)(n - 1) + 0.5);
    return s[k];
}

/* Share of the inside samples of whole slabs (L samples along axis a) in
 * components of their slab that reach both of its faces along a. The slabs
 * start L/2 in from the grid's low face: an example made in a box (balls.ini:
 * balls dropped into it, none at its walls) has no inside at its faces, so
 * slabs ending there measured 0 for a source whose bulk is one mass of
 * touching balls (64^3: 0 at the walls, 0.93/0.86/0.72 along x/y/z in the
 * slab [16, 48)). */
static gs_err crossing_share(const gs_qfield *q, int a, int64_t L, double *share)
{
    int64_t n[3] = {q->nx, q->ny, q->nz}, m[3] = {q->nx, q->ny, q->nz};
    *share = 0;
    if (L < 2 || n[a] < L)
        return GS_OK;
    m[a] = L;
    size_t cells = (size_t)(m[0] * m[1] * m[2]);
    uint8_t inside[256], *mask = NULL, cls[256] = {0, 1};
    for (int i = 0; i < 256; i++)
        inside[i] = gs_qfield_value(q, (uint8_t)i) < 0;
    gs_measure_nested k;
    memset(&k, 0, sizeof k);
    uint64_t in = 0, cross = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&mask, cells, 1, "slab mask"), done);
    for (int64_t s0 = L / 2; s0 + L <= n[a]; s0 += L) {
        for (int64_t z = 0; z < m[2]; z++)
            for (int64_t y = 0; y < m[1]; y++)
                for (int64_t x = 0; x < m[0]; x++) {
                    int64_t c[3] = {x, y, z};
                    c[a] += s0;
                    uint8_t b = inside[q->q[c[0] + n[0] * (c[1] + n[1] * c[2])]];
                    mask[x + m[0] * (y + m[1] * z)] = b;
                    in += b;
                }
        gs_measure_nested_free(&k);
        GS_TRY(err, gs_measure_components_nested3(mask, m, cls, 0, &k), done);
        /* components on both faces of the slab along a */
        for (uint32_t c = 1; c <= k.nouter; c++)
            if ((k.outer[c].faces >> (2 * a) & 3) == 3)
                cross += k.outer[c].size;
    }
    *share = in ? (double)cross / (double)in : 0;
done:
    gs_free(mask);
    gs_measure_nested_free(&k);
    return err;
}

int gs_field_seam_axes(const gs_qfield *q, int period)
{
    return (q->nx > 2 * period) | (q->ny > 2 * period) << 1 | (q->nz > 2 * period) << 2;
}

void gs_field_seam_ratios(const gs_qfield *q, int period, int axes, double *ratio)
{
    double on[GS_FIELD_SEAM_PERIOD_MAX] = {0}, non[GS_FIELD_SEAM_PERIOD_MAX] = {0}, all = 0,
           nall = 0;
    const int64_t n[3] = {q->nx, q->ny, q->nz}, st[3] = {1, q->nx, q->nx * q->ny};
    for (int p = 0; p < period; p++)
        ratio[p] = 0;
    if (period < 1 || period > GS_FIELD_SEAM_PERIOD_MAX)
        return;
    for (int a = 0; a < 3; a++)
        for (int64_t z = 0; z < n[2] - (a == 2) && (axes >> a & 1); z++)
            for (int64_t y = 0; y < n[1] - (a == 1); y++) {
                const uint8_t *v = q->q + st[1] * y + st[2] * z;
                uint64_t sum = 0;
                if (a == 0) { /* along the row: step i is between x = i and i + 1 */
                    uint64_t ph[GS_FIELD_SEAM_PERIOD_MAX] = {0};
                    for (int64_t x = 0; x + 1 < n[0]; x++)
                        ph[x % period] += (uint64_t)abs(v[x + 1] - v[x]);
                    for (int p = 0; p < period; p++) {
                        on[p] += (double)ph[p];
                        non[p] += (double)((n[0] - 1 - p + period - 1) / period);
                        sum += ph[p];
                    }
                    all += (double)sum, nall += (double)(n[0] - 1);
                    continue;
                }
                for (int64_t x = 0; x < n[0]; x++)
                    sum += (uint64_t)abs(v[x + st[a]] - v[x]);
                int p = (int)((a == 1 ? y : z) % period);
                on[p] += (double)sum, non[p] += (double)n[0];
                all += (double)sum, nall += (double)n[0];
            }
    for (int p = 0; p < period; p++) {
        double off = nall - non[p] > 0 ? (all - on[p]) / (nall - non[p]) : 0;
        ratio[p] = non[p] > 0 && off > 0 ? on[p] / non[p] / off : 0;
    }
}

/* Whether q is a height field: every sample of its bottom plane inside. */
int gs_field_height_field(const gs_qfield *q)
{
    for (int64_t i = 0; i < q->nx * q->ny; i++)
        if (!(gs_qfield_value(q, q->q[i]) < 0))
            return 0;
    return 1;
}

/* The objects' mask of q (gs_field_geometry_report's layout; field.object_spacing): with height,
 * the columns lower than the mid-range of q's heights (*m gets nx*ny
 * samples, n = {nx, ny, 1}), else the core (deeper than one sample). The
 * arithmetic is analysis/field_layout.py's: levels in samples, heights
 * summed from z = 0 up. */
gs_err gs_field_layout_mask(const gs_qfield *q, int height, uint8_t **m, int64_t n[3])
{
    int64_t nxy = q->nx * q->ny, cells = nxy * q->nz;
    double d[256];
    for (int i = 0; i < 256; i++)
        d[i] = gs_qfield_value(q, (uint8_t)i) / q->spacing;
    n[0] = q->nx, n[1] = q->ny, n[2] = height ? 1 : q->nz;
    GS_CALL(gs_alloc_array((void **)m, (size_t)(height ? nxy : cells), 1, "object mask"));
    if (!height) {
        for (int64_t i = 0; i < cells; i++)
            (*m)[i] = d[q->q[i]] < -1.0;
        return GS_OK;
    }
    double *h = NULL;
    gs_err err = gs_alloc_array((void **)&h, (size_t)nxy, sizeof *h, "column heights");
    if (err != GS_OK) {
        gs_free(*m);
        *m = NULL;
        return err;
    }
    memset(h, 0, (size_t)nxy * sizeof *h);
    for (int64_t z = 0; z < q->nz; z++)
        for (int64_t i = 0; i < nxy; i++) {
            double v = 0.5 - d[q->q[i + nxy * z]];
            h[i] += v < 0 ? 0 : v > 1 ? 1 : v;
        }
    double lo = h[0], hi = h[0];
    for (int64_t i = 1; i < nxy; i++)
        lo = h[i] < lo ? h[i] : lo, hi = h[i] > hi ? h[i] : hi;
    for (int64_t i = 0; i < nxy; i++)
        (*m)[i] = h[i] < (lo + hi) / 2;
    gs_free(h);
    return GS_OK;
}

/* ko, ks: label_inside's of out and src (their cores are the objects
 * unless the example is a height field). */
static gs_err object_layout(const gs_qfield *out, const gs_qfield *src, const gs_measure_nested *ko,
                            const gs_measure_nested *ks, gs_field_geometry_report *r)
{
    r->layout_height_field = gs_field_height_field(src);
    const int64_t on[3] = {out->nx, out->ny, out->nz}, sn[3] = {src->nx, src->ny, src->nz};
    if (!r->layout_height_field)
        return gs_measure_object_layout_components(ko->inner, ko->ninner, on, ks->inner,
                                                   ks->ninner, sn, 1.5, &r->layout);
    uint8_t *mo = NULL, *ms = NULL;
    int64_t mon[3], msn[3];
    gs_err err = GS_OK;
    GS_TRY(err, gs_field_layout_mask(out, 1, &mo, mon), done);
    GS_TRY(err, gs_field_layout_mask(src, 1, &ms, msn), done);
    err = gs_measure_object_layout(mo, mon, ms, msn, 1.5, &r->layout);
done:
    gs_free(mo);
    gs_free(ms);
    return err;
}

gs_err gs_field_geometry_measure(const gs_qfield *out, const gs_qfield *src, int B,
                                 gs_field_geometry_report *r)
{
    memset(r, 0, sizeof *r);
    double t0 = gs_time_now();
    const int64_t on[3] = {out->nx, out->ny, out->nz}, sn[3] = {src->nx, src->ny, src->nz};
    GS_CALL(gs_measure_copy3(out->q, on, src->q, sn, GS_FIELD_COPY_WINDOW, (int64_t)B * B * B, B,
                             &r->copy));
    uint64_t *so = NULL, *ss = NULL;
    double *xo = NULL, *xs = NULL;
    int64_t no = 0, ns = 0;
    gs_err err = GS_OK;
    inside_topology to, ts;
    gs_measure_nested ko, ks; /* the inside and its core, labelled once */
    memset(&ko, 0, sizeof ko);
    memset(&ks, 0, sizeof ks);
    GS_TRY(err, label_inside(out, &ko), done);
    GS_TRY(err, label_inside(src, &ks), done);
    GS_TRY(err, inside_components(&ko, &so, &no, &to), done);
    GS_TRY(err, inside_components(&ks, &ss, &ns, &ts), done);
    topology_figures(&to, no, on[0] * on[1] * on[2], r->genus_out, &r->ring_share_out,
                     &r->open_per_msample_out, &r->handles_per_kinside_out,
                     &r->handles_all_per_kinside_out);
    topology_figures(&ts, ns, sn[0] * sn[1] * sn[2], r->genus_src, &r->ring_share_src,
                     &r->open_per_msample_src, &r->handles_per_kinside_src,
                     &r->handles_all_per_kinside_src);
    r->components_out = no, r->components_src = ns;
    r->components_per_msample_out = 1e6 * (double)no / (double)(on[0] * on[1] * on[2]);
    r->components_per_msample_src = 1e6 * (double)ns / (double)(sn[0] * sn[1] * sn[2]);
    r->component_median_out = median_u64(so, no);
    r->component_median_src = median_u64(ss, ns);
    r->fragment_share_out = share_below(so, no, r->component_median_src / 4);
    r->fragment_share_src = share_below(ss, ns, r->component_median_src / 4);
    GS_TRY(err, gs_alloc_array((void **)&xo, (size_t)(no ? no : 1), sizeof *xo, "sizes"), done);
    GS_TRY(err, gs_alloc_array((void **)&xs, (size_t)(ns ? ns : 1), sizeof *xs, "sizes"), done);
    for (int64_t i = 0; i < no; i++)
        xo[i] = (double)so[i];
    for (int64_t i = 0; i < ns; i++)
        xs[i] = (double)ss[i];
    GS_TRY(err, gs_measure_ks(xo, (size_t)no, xs, (size_t)ns, &r->component_size_ks), done);
    r->step_violations_out = level_step_violations(out, 1.5);
    r->step_violations_src = level_step_violations(src, 1.5);
    double *ro = NULL, *rs = NULL;
    GS_TRY(err, inscribed_radii(out, &ro, &r->inscribed_out), radii);
    GS_TRY(err, inscribed_radii(src, &rs, &r->inscribed_src), radii);
    r->inscribed_p10_out = quantile(ro, r->inscribed_out, 0.1);
    r->inscribed_p50_out = quantile(ro, r->inscribed_out, 0.5);
    r->inscribed_p90_out = quantile(ro, r->inscribed_out, 0.9);
    r->inscribed_p10_src = quantile(rs, r->inscribed_src, 0.1);
    r->inscribed_p50_src = quantile(rs, r->inscribed_src, 0.5);
    r->inscribed_p90_src = quantile(rs, r->inscribed_src, 0.9);
    GS_TRY(err, gs_measure_ks(ro, (size_t)r->inscribed_out, rs, (size_t)r->inscribed_src,
                              &r->inscribed_ks), radii);
    r->crossing_slab = sn[0] < sn[1] ? sn[0] : sn[1];
    r->crossing_slab = (sn[2] < r->crossing_slab ? sn[2] : r->crossing_slab) / 2;
    r->crossing_share_src = -1;
    for (int a = 0; a < 3; a++) {
        double cs;
        GS_TRY(err, crossing_share(src, a, r->crossing_slab, &cs), radii);
        if (cs > r->crossing_share_src)
            r->crossing_share_src = cs, r->crossing_axis = a;
    }
    GS_TRY(err, crossing_share(out, r->crossing_axis, r->crossing_slab, &r->crossing_share_out),
           radii);
    r->seam_period = B / 2 < 1 ? 1 : B / 2 > GS_FIELD_SEAM_PERIOD_MAX ? GS_FIELD_SEAM_PERIOD_MAX : B / 2;
    {
        double ph[GS_FIELD_SEAM_PERIOD_MAX];
        r->seam_axes = gs_field_seam_axes(out, r->seam_period);
        gs_field_seam_ratios(out, r->seam_period, r->seam_axes, ph);
        r->seam_ratio_out = ph[r->seam_period - 1];
        gs_field_seam_ratios(src, r->seam_period, r->seam_axes, ph);
        r->seam_ratio_src_max = 0;
        for (int p = 0; p < r->seam_period; p++)
            r->seam_ratio_src_max = ph[p] > r->seam_ratio_src_max ? ph[p] : r->seam_ratio_src_max;
    }
    GS_TRY(err, object_layout(out, src, &ko, &ks, r), radii);
radii:
    gs_free(ro);
    gs_free(rs);
    if (err != GS_OK)
        goto done;
    r->seconds = gs_time_now() - t0;
done:
    gs_measure_nested_free(&ko);
    gs_measure_nested_free(&ks);
    gs_free(so);
    gs_free(ss);
    gs_free(xo);
    gs_free(xs);
    return err;
}
