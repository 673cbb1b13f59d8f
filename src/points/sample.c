/* Turning user geometry into an input texture: uniform Poisson-disk
 * sampling of a triangle mesh, sampling-spacing estimate of a point set,
 * axis permutation to the z-up reference plane; see include/geosynth/points.h. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/sort.h"
#include "points/points_impl.h"

#define RNG_DOMAIN_SAMPLE 0x50545341u /* "PTSA" */

gs_err gs_points_sample_mesh(const float *pos, size_t nverts, const uint32_t *tris, size_t ntris,
                             double spacing, uint64_t seed, const char *what, gs_points *out)
{
    GS_CHECK(spacing > 0 && isfinite(spacing), GS_ERR_ARG,
             "%s: sampling spacing %g must be > 0", what, spacing);
    GS_CHECK(ntris > 0 && nverts >= 3, GS_ERR_ARG, "%s: no triangles to sample", what);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < nverts; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], pos[3 * i + a]);
            hi[a] = fmax(hi[a], pos[3 * i + a]);
        }
    double *vn = NULL, *cdf = NULL;
    gs_points_grid_t grid = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&vn, nverts, 3 * sizeof *vn, "mesh vertex normals"), done);
    GS_TRY(err, gs_alloc_array((void **)&cdf, ntris, sizeof *cdf, "mesh area table"), done);
    /* Area-weighted vertex normals (smooth across triangles) and the area CDF. */
    double area = 0;
    for (size_t t = 0; t < ntris; t++) {
        const uint32_t *ix = tris + 3 * t;
        GS_TRY_CHECK(err, ix[0] < nverts && ix[1] < nverts && ix[2] < nverts, GS_ERR_ARG, done,
                     "%s: triangle %zu uses a vertex beyond the %zu vertices", what, t, nverts);
        double a[3], b[3], c[3];
        for (int d = 0; d < 3; d++) {
            a[d] = pos[3 * ix[1] + d] - pos[3 * ix[0] + d];
            b[d] = pos[3 * ix[2] + d] - pos[3 * ix[0] + d];
        }
        v3_cross(a, b, c);
        for (int k = 0; k < 3; k++)
            for (int d = 0; d < 3; d++)
                vn[3 * ix[k] + d] += c[d];
        area += 0.5 * sqrt(v3_dot(c, c));
        cdf[t] = area;
    }
    GS_TRY_CHECK(err, area > 0, GS_ERR_ARG, done, "%s: the mesh has zero area", what);
    double want = area / (spacing * spacing);
    GS_TRY_CHECK(err, want < 2e8, GS_ERR_ARG, done,
                 "%s: area %g at spacing %g gives about %.3g points, expected < 2e8: use a larger "
                 "spacing", what, area, spacing, want);
    for (int a = 0; a < 3; a++) {
        lo[a] -= spacing;
        hi[a] += spacing;
    }
    GS_TRY(err, gs_points_grid_create(lo, hi, spacing, &grid), done);
    gs_rng rng;
    gs_rng_init(&rng, seed, gs_rng_stream_id(RNG_DOMAIN_SAMPLE, 1, 0, 0));
    /* Dart throwing: tries ~ 9 per point of a maximal Poisson-disk set. */
    uint64_t tries = (uint64_t)(9.0 * want) + 64;
    for (uint64_t k = 0; k < tries; k++) {
        double u = gs_rng_uniform(&rng) * area;
        size_t l = 0, h = ntris - 1;
        while (l < h) {
            size_t m = l + (h - l) / 2;
            if (cdf[m] > u)
                h = m;
            else
                l = m + 1;
        }
        const uint32_t *ix = tris + 3 * l;
        double r1 = sqrt(gs_rng_uniform(&rng)), r2 = gs_rng_uniform(&rng);
        double w[3] = {1 - r1, r1 * (1 - r2), r1 * r2};
        gs_opoint q;
        for (int d = 0; d < 3; d++) {
            q.p[d] = 0;
            q.n[d] = 0;
            for (int c = 0; c < 3; c++) {
                q.p[d] += w[c] * pos[3 * ix[c] + d];
                q.n[d] += w[c] * vn[3 * ix[c] + d];
            }
        }
        if (v3_normalize(q.n) <= 0) { /* opposing vertex normals: use the face's */
            double a[3], b[3];
            for (int d = 0; d < 3; d++) {
                a[d] = pos[3 * ix[1] + d] - pos[3 * ix[0] + d];
                b[d] = pos[3 * ix[2] + d] - pos[3 * ix[0] + d];
            }
            v3_cross(a, b, q.n);
            if (v3_normalize(q.n) <= 0)
                continue;
        }
        if (gs_points_grid_any_within(grid, q.p, spacing))
            continue;
        GS_TRY(err, gs_points_grid_add(grid, &q), done);
    }
    GS_TRY(err, gs_points_grid_collect(grid, out), done);
done:
    gs_free(vn);
    gs_free(cdf);
    gs_points_grid_destroy(&grid);
    return err;
}

gs_err gs_points_estimate_spacing(const gs_points *pts, double *spacing)
{
    GS_CHECK(pts->n >= 16, GS_ERR_ARG,
             "point set of %zu points: too few to estimate the sampling spacing (>= 16)", pts->n);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < pts->n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], pts->v[i].p[a]);
            hi[a] = fmax(hi[a], pts->v[i].p[a]);
        }
    /* Cell from the largest face of the bounding box as if it were a sheet. */
    double ext[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    double face = fmax(ext[0] * ext[1], fmax(ext[0] * ext[2], ext[1] * ext[2]));
    double cell = sqrt(face / (double)pts->n);
    double maxe = fmax(ext[0], fmax(ext[1], ext[2]));
    GS_CHECK(maxe > 0, GS_ERR_ARG, "point set: all %zu points coincide", pts->n);
    if (!(cell > maxe * 1e-5))
        cell = maxe * 1e-5;
    for (int a = 0; a < 3; a++) {
        lo[a] -= cell;
        hi[a] += cell;
    }
    gs_points_grid_t g = NULL;
    gs_points scratch = {0};
    double *nn = NULL;
    gs_err err = GS_OK;
    size_t stride = pts->n > 20000 ? pts->n / 20000 : 1, ns = 0;
    GS_TRY(err, gs_points_grid_create(lo, hi, cell, &g), done);
    for (size_t i = 0; i < pts->n; i++)
        GS_TRY(err, gs_points_grid_add(g, &pts->v[i]), done);
    GS_TRY(err, gs_alloc_array((void **)&nn, pts->n / stride + 1, sizeof *nn, "spacing estimate"),
           done);
    for (size_t i = 0; i < pts->n; i += stride) {
        const double *p = pts->v[i].p;
        double best = INFINITY;
        for (double r = cell; r <= 4 * maxe; r *= 2) {
            scratch.n = 0;
            GS_TRY(err, gs_points_grid_query(g, p, r, &scratch), done);
            for (size_t j = 0; j < scratch.n; j++) {
                double d = v3_dist2(scratch.v[j].p, p);
                if (d > 0 && d < best)
                    best = d;
            }
            if (best <= r * r)
                break;
        }
        if (isfinite(best))
            nn[ns++] = sqrt(best);
    }
    GS_TRY_CHECK(err, ns >= 8, GS_ERR_ARG, done,
                 "point set: cannot estimate the spacing (points coincide)");
    gs_sort_f64(nn, ns);
    /* For a (near-)maximal Poisson-disk set of radius s the nearest-neighbour
     * distances lie in [s, 2s) and crowd near s: their median is 1.07-1.09 s
     * on the generators and the mesh sampler (tests/unit/test_points_input.c). */
    *spacing = nn[ns / 2] / 1.08;
done:
    gs_points_grid_destroy(&g);
    gs_points_free(&scratch);
    gs_free(nn);
    return err;
}

void gs_points_permute_to_z(gs_points *pts, int up)
{
    if (up == 2)
        return;
    /* Cyclic permutations keep the handedness, so normals stay outward:
     * up = x: (x, y, z) -> (y, z, x); up = y: (x, y, z) -> (z, x, y). */
    for (size_t i = 0; i < pts->n; i++) {
        double *v[2] = {pts->v[i].p, pts->v[i].n};
        for (int k = 0; k < 2; k++) {
            double a = v[k][0], b = v[k][1], c = v[k][2];
            if (up == 0) {
                v[k][0] = b;
                v[k][1] = c;
                v[k][2] = a;
            } else {
                v[k][0] = c;
                v[k][1] = a;
                v[k][2] = b;
            }
        }
    }
}

void gs_points_permute_from_z(gs_points *pts, int up)
{
    if (up == 2)
        return;
    for (size_t i = 0; i < pts->n; i++) {
        double *v[2] = {pts->v[i].p, pts->v[i].n};
        for (int k = 0; k < 2; k++) {
            double a = v[k][0], b = v[k][1], c = v[k][2];
            if (up == 0) { /* inverse of (y, z, x) */
                v[k][0] = c;
                v[k][1] = a;
                v[k][2] = b;
            } else { /* inverse of (z, x, y) */
                v[k][0] = b;
                v[k][1] = c;
                v[k][2] = a;
            }
        }
    }
}

void gs_points_permute_vec_to_z(double v[3], int up)
{
    gs_opoint o = {{v[0], v[1], v[2]}, {0, 0, 1}};
    gs_points one = {&o, 1, 1};
    gs_points_permute_to_z(&one, up);
    memcpy(v, o.p, sizeof o.p);
}
