/* Point-set measures (see include/geosynth/measure.h): connected components
 * of a point cloud under a linking radius. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/sort.h"

static uint32_t uf_find(uint32_t *par, uint32_t i)
{
    while (par[i] != i) {
        par[i] = par[par[i]];
        i = par[i];
    }
    return i;
}

typedef struct cell_key {
    uint64_t cell;
    uint32_t idx;
} cell_key;

static int cell_key_cmp(const void *a, const void *b)
{
    const cell_key *x = a, *y = b;
    if (x->cell != y->cell)
        return x->cell < y->cell ? -1 : 1;
    return x->idx < y->idx ? -1 : x->idx > y->idx;
}

/* The cell code of integer cell coordinates (21 bits each, offset). */
static uint64_t cell_code(long cx, long cy, long cz)
{
    const long off = 1L << 20;
    return ((uint64_t)(cx + off) << 42) | ((uint64_t)(cy + off) << 21) | (uint64_t)(cz + off);
}

/* The first of the sorted keys k[0 .. n) in cell code (n if none). */
static size_t cell_first(const cell_key *k, size_t n, uint64_t code)
{
    size_t a = 0, b = n;
    while (a < b) {
        size_t m = a + (b - a) / 2;
        if (k[m].cell < code)
            a = m + 1;
        else
            b = m;
    }
    return a;
}

/* The points within sqrt(r2) of point i (itself left out) into *nb (grown
 * as needed, capacity *cap), *m of them: the 27 cells around its cell; with
 * flat != 0 the distance in x y alone over the 9 cells of keys whose cells
 * have z 0. */
static gs_err cell_neighbours(const cell_key *k, const long (*cc)[3], const double *xyz,
                              size_t stride, size_t n, size_t i, double r2, int flat,
                              uint32_t **nb, size_t *cap, size_t *m)
{
    const double *p = xyz + i * stride;
    *m = 0;
    for (int dz = flat ? 0 : -1; dz <= (flat ? 0 : 1); dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                uint64_t code = cell_code(cc[i][0] + dx, cc[i][1] + dy, cc[i][2] + dz);
                for (size_t j = cell_first(k, n, code); j < n && k[j].cell == code; j++) {
                    uint32_t q = k[j].idx;
                    const double *o = xyz + (size_t)q * stride;
                    double d0 = p[0] - o[0], d1 = p[1] - o[1], d2 = flat ? 0 : p[2] - o[2];
                    if (q == i || d0 * d0 + d1 * d1 + d2 * d2 > r2)
                        continue;
                    if (*m == *cap) {
                        size_t c = *cap ? 2 * *cap : 64;
                        uint32_t *t = gs_realloc(*nb, c * sizeof *t);
                        GS_CHECK(t != NULL, GS_ERR_MEM,
                                 "point neighbours: out of memory (%zu neighbours)", c);
                        *nb = t;
                        *cap = c;
                    }
                    (*nb)[(*m)++] = q;
                }
            }
    return GS_OK;
}

/* The cells (side radius) of n points: each point's integer cell *cc and
 * the keys *k sorted by cell (both gs_malloc'ed); what names the caller in
 * errors. */
static gs_err point_cells(const double *xyz, size_t stride, size_t n, double radius,
                          const char *what, cell_key **k, long (**cc)[3])
{
    *k = NULL;
    *cc = NULL;
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            lo[a] = fmin(lo[a], xyz[i * stride + a]);
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            GS_CHECK(isfinite(xyz[i * stride + a]) &&
                         (xyz[i * stride + a] - lo[a]) / radius < (double)(1L << 19),
                     GS_ERR_ARG, "%s: point %zu is not finite or too far out", what, i);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)k, n ? n : 1, sizeof **k, "point cells"), fail);
    GS_TRY(err, gs_alloc_array((void **)cc, n ? n : 1, sizeof **cc, "point cells"), fail);
    for (size_t i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++)
            (*cc)[i][a] = (long)floor((xyz[i * stride + a] - lo[a]) / radius);
        (*k)[i].cell = cell_code((*cc)[i][0], (*cc)[i][1], (*cc)[i][2]);
        (*k)[i].idx = (uint32_t)i;
    }
    qsort(*k, n, sizeof **k, cell_key_cmp);
    return GS_OK;
fail:
    gs_free(*k);
    gs_free(*cc);
    *k = NULL;
    *cc = NULL;
    return err;
}

gs_err gs_measure_point_components(const double *xyz, size_t stride, size_t n, double radius,
                                   uint32_t *label, uint32_t *ncomp, uint64_t **sizes)
{
    GS_CHECK(radius > 0 && isfinite(radius), GS_ERR_ARG,
             "point components: radius %g, expected > 0", radius);
    GS_CHECK(n < UINT32_MAX && stride >= 3, GS_ERR_ARG,
             "point components: %zu points with stride %zu, expected < 2^32 and stride >= 3", n,
             stride);
    *ncomp = 0;
    if (sizes)
        *sizes = NULL;
    cell_key *k = NULL;
    uint32_t *par = NULL, *first = NULL, *nb = NULL;
    size_t nbcap = 0;
    uint64_t *sz = NULL;
    long (*cc)[3] = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, point_cells(xyz, stride, n, radius, "point components", &k, &cc), done);
    GS_TRY(err, gs_alloc_array((void **)&par, n ? n : 1, sizeof *par, "point components"), done);
    for (size_t i = 0; i < n; i++)
        par[i] = (uint32_t)i;
    double r2 = radius * radius;
    /* Each point against the points of the 27 cells around it (binary
     * search for each cell's run in the sorted keys). */
    for (size_t i = 0; i < n; i++) {
        size_t m;
        GS_TRY(err, cell_neighbours(k, (const long (*)[3])cc, xyz, stride, n, i, r2, 0, &nb,
                                    &nbcap, &m), done);
        for (size_t j = 0; j < m; j++) {
            uint32_t q = nb[j];
            if (q <= i)
                continue;
            uint32_t ra = uf_find(par, (uint32_t)i), rb = uf_find(par, q);
            if (ra != rb)
                par[ra > rb ? ra : rb] = ra < rb ? ra : rb;
        }
    }
    /* Number components in order of their lowest point index. */
    GS_TRY(err, gs_alloc_array((void **)&first, n ? n : 1, sizeof *first, "point components"),
           done);
    uint32_t nc = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t r = uf_find(par, (uint32_t)i);
        if (r == i)
            first[i] = ++nc;
        label[i] = first[r];
    }
    if (sizes) {
        GS_TRY(err, gs_alloc_array((void **)&sz, (size_t)nc + 1, sizeof *sz, "component sizes"),
               done);
        memset(sz, 0, ((size_t)nc + 1) * sizeof *sz);
        for (size_t i = 0; i < n; i++)
            sz[label[i]]++;
        *sizes = sz;
        sz = NULL;
    }
    *ncomp = nc;
done:
    gs_free(cc);
    gs_free(k);
    gs_free(par);
    gs_free(first);
    gs_free(nb);
    gs_free(sz);
    return err;
}

gs_err gs_measure_point_nearest(const double *xyz, size_t stride, size_t n, double radius,
                                double *dist)
{
    GS_CHECK(radius > 0 && isfinite(radius), GS_ERR_ARG,
             "point nearest: radius %g, expected > 0", radius);
    GS_CHECK(n < UINT32_MAX && stride >= 3, GS_ERR_ARG,
             "point nearest: %zu points with stride %zu, expected < 2^32 and stride >= 3", n,
             stride);
    cell_key *k = NULL;
    uint32_t *nb = NULL;
    size_t nbcap = 0;
    long (*cc)[3] = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, point_cells(xyz, stride, n, radius, "point nearest", &k, &cc), done);
    for (size_t i = 0; i < n; i++) {
        size_t m;
        GS_TRY(err, cell_neighbours(k, (const long (*)[3])cc, xyz, stride, n, i, radius * radius,
                                    0, &nb, &nbcap, &m), done);
        double best = INFINITY;
        const double *p = xyz + i * stride;
        for (size_t j = 0; j < m; j++) {
            const double *o = xyz + (size_t)nb[j] * stride;
            double d0 = p[0] - o[0], d1 = p[1] - o[1], d2 = p[2] - o[2];
            best = fmin(best, d0 * d0 + d1 * d1 + d2 * d2);
        }
        dist[i] = sqrt(best);
    }
done:
    gs_free(cc);
    gs_free(k);
    gs_free(nb);
    return err;
}

gs_err gs_measure_point_pieces(const double *xyz, size_t stride, size_t n, double radius,
                               const double lo[2], const double hi[2], uint64_t small,
                               gs_measure_pieces *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(lo[0] < hi[0] && lo[1] < hi[1], GS_ERR_ARG,
             "point pieces: box (%g, %g) - (%g, %g) is empty", lo[0], lo[1], hi[0], hi[1]);
    double *in = NULL;
    uint32_t *label = NULL, nc = 0;
    uint64_t *sizes = NULL;
    uint8_t *cut = NULL;
    double *box = NULL;
    size_t m = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&in, n ? n : 1, 3 * sizeof *in, "point pieces"), done);
    for (size_t i = 0; i < n; i++) {
        const double *p = xyz + i * stride;
        if (p[0] >= lo[0] && p[0] < hi[0] && p[1] >= lo[1] && p[1] < hi[1]) {
            memcpy(in + 3 * m, p, 3 * sizeof *in);
            m++;
        }
    }
    GS_TRY(err, gs_alloc_array((void **)&label, m ? m : 1, sizeof *label, "point pieces"), done);
    GS_TRY(err, gs_measure_point_components(in, 3, m, radius, label, &nc, &sizes), done);
    GS_TRY(err, gs_alloc_array((void **)&cut, (size_t)nc + 1, 1, "point pieces"), done);
    GS_TRY(err, gs_alloc_array((void **)&box, (size_t)nc + 1, 4 * sizeof *box, "point pieces"),
           done);
    memset(cut, 0, (size_t)nc + 1);
    for (uint32_t c = 0; c <= nc; c++) {
        box[4 * c] = box[4 * c + 1] = INFINITY;
        box[4 * c + 2] = box[4 * c + 3] = -INFINITY;
    }
    for (size_t i = 0; i < m; i++) {
        const double *p = in + 3 * i;
        double *b = box + 4 * label[i];
        for (int a = 0; a < 2; a++) {
            b[a] = fmin(b[a], p[a]);
            b[2 + a] = fmax(b[2 + a], p[a]);
        }
        if (p[0] - lo[0] <= radius || hi[0] - p[0] <= radius || p[1] - lo[1] <= radius ||
            hi[1] - p[1] <= radius)
            cut[label[i]] = 1;
    }
    for (uint32_t c = 1; c <= nc; c++) {
        if (cut[c]) {
            out->border++;
            continue;
        }
        out->pieces++;
        const double *b = box + 4 * c;
        double ax = hi[0] - lo[0] - (b[2] - b[0]) - 2 * radius;
        double ay = hi[1] - lo[1] - (b[3] - b[1]) - 2 * radius;
        double w = ax > 0 && ay > 0 ? 1.0 / (ax * ay) : 0; /* ax, ay > 0 for an inner piece */
        out->density += w;
        if (sizes[c] < small) {
            out->small++;
            out->small_points += sizes[c];
            out->small_density += w;
        }
    }
done:
    gs_free(in);
    gs_free(label);
    gs_free(sizes);
    gs_free(cut);
    gs_free(box);
    return err;
}

/* ------------------------------------------------ seams from patch ids -- */

/* The MLS frame (weights (1 - d^2/R^2)^4, as the points engine's) at p of
 * the points idx[0 .. m) that pass keep: weighted centroid a, unit mean
 * normal n; returns the weight sum (0: nothing). */
typedef struct seam_fit {
    double w, a[3], n[3];
} seam_fit;

static void seam_fit_add(seam_fit *f, const double *q, const double *p, double inv_r2)
{
    double d0 = q[0] - p[0], d1 = q[1] - p[1], d2 = q[2] - p[2];
    double t = 1 - (d0 * d0 + d1 * d1 + d2 * d2) * inv_r2;
    if (!(t > 0))
        return;
    t *= t;
    t *= t;
    f->w += t;
    for (int a = 0; a < 3; a++) {
        f->a[a] += t * q[a];
        f->n[a] += t * q[3 + a];
    }
}

/* Adds the fit's distance and angle at point p to the sums s[0..3]
 * (dist, angle, matched, unmatched) and dist to a list. */
static void seam_fit_score(const seam_fit *f, const double *p, double min_w, double *s,
                           double *dl, size_t *nd)
{
    double nn = sqrt(f->n[0] * f->n[0] + f->n[1] * f->n[1] + f->n[2] * f->n[2]);
    if (f->w < min_w || !(nn > 0)) {
        s[3] += 1;
        return;
    }
    double d = 0, c = 0;
    for (int a = 0; a < 3; a++) {
        double n = f->n[a] / nn;
        d += (p[a] - f->a[a] / f->w) * n;
        c += p[3 + a] * n;
    }
    c = c > 1 ? 1 : c < -1 ? -1 : c;
    s[0] += fabs(d);
    s[1] += acos(c) * (180.0 / 3.14159265358979323846);
    s[2] += 1;
    dl[(*nd)++] = fabs(d);
}

static double seam_p90(double *v, size_t n)
{
    if (!n)
        return 0;
    gs_sort_f64(v, n);
    return v[(size_t)floor(0.9 * (double)(n - 1))];
}

/* A fraction in [0, 1) for point i's fit toward direction d: the golden
 * ratio's sequence (evenly spread over the fits, fixed by the point's index,
 * so the same on every run). */
static double seam_spread(size_t i, int d)
{
    double x = (double)(4 * (uint64_t)i + (uint64_t)d) * 0.6180339887498949;
    return x - floor(x);
}

gs_err gs_measure_point_seams(const double *v, size_t n, const int32_t *id, double radius,
                              double band, double min_weight, gs_measure_seams *out)
{
    return gs_measure_point_seams_far(v, n, id, radius, band, min_weight, 0, out);
}

gs_err gs_measure_point_seams_far(const double *v, size_t n, const int32_t *id, double radius,
                                  double band, double min_weight, double far_dist,
                                  gs_measure_seams *out)
{
    memset(out, 0, sizeof *out);
    GS_CHECK(radius > 0 && isfinite(radius) && band > 0 && band <= radius, GS_ERR_ARG,
             "point seams: radius %g, band %g: expected 0 < band <= radius", radius, band);
    GS_CHECK(far_dist >= 0 && isfinite(far_dist), GS_ERR_ARG,
             "point seams: far distance %g, expected >= 0", far_dist);
    GS_CHECK(n < UINT32_MAX, GS_ERR_ARG, "point seams: %zu points, expected < 2^32", n);
    if (n == 0)
        return GS_OK;
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            GS_CHECK(isfinite(v[6 * i + a]), GS_ERR_ARG, "point seams: point %zu is not finite",
                     i);
            lo[a] = fmin(lo[a], v[6 * i + a]);
        }
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            GS_CHECK((v[6 * i + a] - lo[a]) / radius < (double)(1L << 19), GS_ERR_ARG,
                     "point seams: point %zu is too far out", i);
    cell_key *k = NULL, *k2 = NULL;
    long (*cc)[3] = NULL, (*cc2)[3] = NULL;
    uint32_t *nb = NULL, *nb2 = NULL;
    size_t cap2 = 0;
    double *dl[2] = {NULL, NULL};
    size_t nd[2] = {0, 0}, cap = 0;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&k, n, sizeof *k, "point seams"), done);
    GS_TRY(err, gs_alloc_array((void **)&cc, n, sizeof *cc, "point seams"), done);
    GS_TRY(err, gs_alloc_array((void **)&k2, n, sizeof *k2, "point seams"), done);
    GS_TRY(err, gs_alloc_array((void **)&cc2, n, sizeof *cc2, "point seams"), done);
    for (int w = 0; w < 2; w++)
        GS_TRY(err, gs_alloc_array((void **)&dl[w], n, 4 * sizeof *dl[w], "point seams"), done);
    for (size_t i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++)
            cc[i][a] = (long)floor((v[6 * i + a] - lo[a]) / radius);
        k[i].cell = cell_code(cc[i][0], cc[i][1], cc[i][2]);
        k[i].idx = (uint32_t)i;
    }
    qsort(k, n, sizeof *k, cell_key_cmp);
    for (size_t i = 0; i < n; i++) { /* the same cells flattened: the x y neighbours */
        cc2[i][0] = cc[i][0];
        cc2[i][1] = cc[i][1];
        cc2[i][2] = 0;
        k2[i].cell = cell_code(cc[i][0], cc[i][1], 0);
        k2[i].idx = (uint32_t)i;
    }
    qsort(k2, n, sizeof *k2, cell_key_cmp);
    double r2 = radius * radius, b2 = band * band, inv_r2 = 1.0 / r2;
    double sum[2][4] = {{0, 0, 0, 0}, {0, 0, 0, 0}};
    /* Directions of the inside half-discs: +x, -x, +y, -y. */
    static const double dir[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (size_t i = 0; i < n; i++) {
        const double *p = v + 6 * i;
        size_t m;
        GS_TRY(err, cell_neighbours(k, (const long (*)[3])cc, v, 6, n, i, r2, 0, &nb, &cap, &m),
               done);
        size_t m2;
        GS_TRY(err, cell_neighbours(k2, (const long (*)[3])cc2, v, 6, n, i, b2, 1, &nb2, &cap2,
                                    &m2), done);
        /* The other patch across: the id of the nearest point of another
         * patch within band in the plane (at any height, so a surface that
         * ends at the seam with nothing across is a seam point too); none
         * within radius in space either: an inside point. */
        double best = INFINITY;
        int32_t other = id[i];
        int any_other = 0;
        for (size_t j = 0; j < m; j++)
            any_other |= id[nb[j]] != id[i];
        for (size_t j = 0; j < m2; j++) {
            if (id[nb2[j]] == id[i])
                continue;
            const double *o = v + 6 * (size_t)nb2[j];
            double d2 = (o[0] - p[0]) * (o[0] - p[0]) + (o[1] - p[1]) * (o[1] - p[1]);
            if (d2 < best || (d2 == best && id[nb2[j]] < other)) {
                best = d2;
                other = id[nb2[j]];
            }
        }
        if (other != id[i]) {
            seam_fit f = {0, {0, 0, 0}, {0, 0, 0}};
            for (size_t j = 0; j < m; j++)
                if (id[nb[j]] == other)
                    seam_fit_add(&f, v + 6 * (size_t)nb[j], p, inv_r2);
            seam_fit_score(&f, p, min_weight, sum[0], dl[0], &nd[0]);
        } else if (!any_other) {
            /* A virtual seam: a straight line across direction d at a
             * distance u from p, u spread evenly over [0, band) (a seam
             * point lies at any distance within band of the other patch),
             * the points beyond it standing for the other patch, kept only
             * when one of them lies within band in the plane (as a seam
             * point is found): the seam's one-sided geometry at its
             * distances, so a seam where one surface runs on unchanged
             * scores as this (a half-disc at u = 0 does not: on a curved
             * surface the other side's points lie further off, weave.ini's
             * verbatim seam 9.9 deg vs 5.8 inside). */
            for (int d = 0; d < 4; d++) {
                double u = band * seam_spread(i, d);
                int near = 0;
                for (size_t j = 0; j < m2 && !near; j++) {
                    const double *o = v + 6 * (size_t)nb2[j];
                    near = (o[0] - p[0]) * dir[d][0] + (o[1] - p[1]) * dir[d][1] > u;
                }
                if (!near)
                    continue;
                seam_fit f = {0, {0, 0, 0}, {0, 0, 0}};
                for (size_t j = 0; j < m; j++) {
                    const double *o = v + 6 * (size_t)nb[j];
                    if ((o[0] - p[0]) * dir[d][0] + (o[1] - p[1]) * dir[d][1] > u)
                        seam_fit_add(&f, o, p, inv_r2);
                }
                seam_fit_score(&f, p, min_weight, sum[1], dl[1], &nd[1]);
            }
        }
    }
    for (int w = 0; w < 2; w++) {
        double *s = sum[w], tot = s[2] + s[3];
        double *dist = w ? &out->inside_dist : &out->seam_dist;
        double *ang = w ? &out->inside_angle : &out->seam_angle;
        double *open = w ? &out->inside_open : &out->seam_open;
        double *p90 = w ? &out->inside_dist_p90 : &out->seam_dist_p90;
        *dist = s[2] > 0 ? s[0] / s[2] : 0;
        *ang = s[2] > 0 ? s[1] / s[2] : 0;
        *open = tot > 0 ? s[3] / tot : 0;
        *p90 = seam_p90(dl[w], nd[w]);
    }
    /* Broken: open, or farther than far_dist (sorted lists: the tail). */
    out->far_dist = far_dist > 0 ? far_dist : out->inside_dist_p90;
    for (int w = 0; w < 2; w++) {
        double *s = sum[w], tot = s[2] + s[3];
        size_t far = 0;
        while (far < nd[w] && dl[w][nd[w] - 1 - far] > out->far_dist)
            far++;
        *(w ? &out->inside_broken : &out->seam_broken) =
            tot > 0 ? (s[3] + (double)far) / tot : 0;
    }
    out->seam_points = (uint64_t)(sum[0][2] + sum[0][3]);
    out->inside_fits = (uint64_t)(sum[1][2] + sum[1][3]);
done:
    gs_free(k);
    gs_free(cc);
    gs_free(nb);
    gs_free(k2);
    gs_free(cc2);
    gs_free(nb2);
    gs_free(dl[0]);
    gs_free(dl[1]);
    return err;
}
