/* Unit tests for the OpenVDB bridge: dense <-> grid, .vdb files, mesh ->
 * distance (checked against brute force), contouring, redistancing. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "../util/testutil.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/mem.h"
#include "geosynth/mesh.h"
#include "geosynth/vdb.h"

#define PI 3.14159265358979323846


static const char *tmp_path(const char *name, char *buf, size_t n)
{
    snprintf(buf, n, "%s/%s", gs_test_tmpdir, name);
    return buf;
}

/* ---- brute-force point-triangle distance (Ericson, Real-Time Collision Detection 5.1.5) */
static void sub(const double *a, const double *b, double *o)
{
    o[0] = a[0] - b[0];
    o[1] = a[1] - b[1];
    o[2] = a[2] - b[2];
}
static double dot(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static double point_tri_dist(const double *p, const double *a, const double *b, const double *c)
{
    double ab[3], ac[3], ap[3], q[3];
    sub(b, a, ab);
    sub(c, a, ac);
    sub(p, a, ap);
    double d1 = dot(ab, ap), d2 = dot(ac, ap);
    double v, w;
    if (d1 <= 0 && d2 <= 0) {
        memcpy(q, a, sizeof q);
        goto out;
    }
    double bp[3];
    sub(p, b, bp);
    double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) {
        memcpy(q, b, sizeof q);
        goto out;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        v = d1 / (d1 - d3);
        for (int k = 0; k < 3; k++)
            q[k] = a[k] + v * ab[k];
        goto out;
    }
    double cp[3];
    sub(p, c, cp);
    double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) {
        memcpy(q, c, sizeof q);
        goto out;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        w = d2 / (d2 - d6);
        for (int k = 0; k < 3; k++)
            q[k] = a[k] + w * ac[k];
        goto out;
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        for (int k = 0; k < 3; k++)
            q[k] = b[k] + w * (c[k] - b[k]);
        goto out;
    }
    {
        double denom = 1.0 / (va + vb + vc);
        v = vb * denom;
        w = vc * denom;
        for (int k = 0; k < 3; k++)
            q[k] = a[k] + ab[k] * v + ac[k] * w;
    }
out:;
    double d[3];
    sub(p, q, d);
    return sqrt(dot(d, d));
}

static double mesh_dist(const gs_mesh *m, const double *p)
{
    double best = HUGE_VAL;
    for (size_t t = 0; t < m->ntris; t++) {
        double v[3][3];
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++)
                v[c][k] = m->pos[3 * (size_t)m->tris[3 * t + c] + k];
        double d = point_tri_dist(p, v[0], v[1], v[2]);
        best = d < best ? d : best;
    }
    return best;
}

static void sample_pos(const gs_vdb_dense *d, size_t i, size_t j, size_t k, double p[3])
{
    p[0] = d->origin[0] + d->voxel * (double)i;
    p[1] = d->origin[1] + d->voxel * (double)j;
    p[2] = d->origin[2] + d->voxel * (double)k;
}

/* Unit cube [0,1]^3, 12 outward triangles. */
static void make_cube(gs_mesh *m)
{
    static const float v[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                  {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    static const uint32_t t[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7},
                                      {0, 1, 5}, {0, 5, 4}, {1, 2, 6}, {1, 6, 5},
                                      {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
    assert_int_equal(gs_mesh_alloc(m, 8, 12, 0), GS_OK);
    memcpy(m->pos, v, sizeof v);
    memcpy(m->tris, t, sizeof t);
}

/* Truncated and byte-flipped copies of a valid two-grid file: each gives the
 * grid or an error naming the file (gs_vdb_check, then OpenVDB in a child
 * process), never an abort, crash or hang of this process. */
static void damaged_vdb_files(const gs_vdb_grid_t *grids)
{
    char good[256], bad[256];
    tmp_path("good.vdb", good, sizeof good);
    tmp_path("damaged.vdb", bad, sizeof bad);
    assert_int_equal(gs_vdb_write(good, grids, 2), GS_OK);
    FILE *f = fopen(good, "rb");
    static unsigned char img[1 << 16];
    size_t n = fread(img, 1, sizeof img, f);
    fclose(f);
    assert_true(n > 200 && n < sizeof img);
    int refused = 0, read = 0;
    uint64_t rs = 12345;
    for (int t = 0; t < 120; t++) {
        static unsigned char mut[1 << 16];
        memcpy(mut, img, n);
        size_t len = n;
        if (t < 40) {
            len = (size_t)t * n / 40; /* truncated */
        } else {
            for (int k = 0; k < 1 + t % 4; k++) { /* 1-4 bytes flipped */
                rs = rs * 6364136223846793005ULL + 1442695040888963407ULL;
                mut[(rs >> 33) % n] ^= (unsigned char)(1u << ((rs >> 20) % 8));
            }
        }
        f = fopen(bad, "wb");
        assert_true(fwrite(mut, 1, len, f) == len || len == 0);
        fclose(f);
        gs_vdb_dense r;
        gs_err e = gs_vdb_read_dense(bad, NULL, &r);
        if (e == GS_OK) {
            read++;
            gs_vdb_dense_destroy(&r);
            continue;
        }
        refused++;
        if (!strstr(gs_error_message(), "damaged.vdb"))
            fail_msg("damaged file %d: error without the file name: %s", t, gs_error_message());
        gs_error_clear();
    }
    printf("damaged .vdb copies: %d refused with a message, %d read\n", refused, read);
    assert_true(refused >= 40);
}

static void test_dense_grid_roundtrip(void **state)
{
    (void)state;
    gs_vdb_dense d, r;
    assert_int_equal(gs_vdb_dense_alloc(&d, 7, 5, 3), GS_OK);
    d.origin[0] = 1;
    d.origin[1] = -2;
    d.origin[2] = 0.5;
    d.voxel = 0.25;
    d.background = -1;
    for (size_t z = 0; z < 3; z++)
        for (size_t y = 0; y < 5; y++)
            for (size_t x = 0; x < 7; x++)
                d.v[x + 7 * (y + 5 * z)] = (float)(x + 10 * y + 100 * z) + 0.5f;
    d.v[0] = -1; /* equal to the background: inactive, but the box must survive */
    gs_vdb_grid_t g = NULL;
    assert_int_equal(gs_vdb_grid_from_dense(&d, "density", 0.0f, &g), GS_OK);
    assert_string_equal(gs_vdb_grid_name(g), "density");
    assert_int_equal(gs_vdb_grid_active_voxels(g), 7 * 5 * 3 - 1);
    assert_int_equal(gs_vdb_grid_to_dense(g, &r), GS_OK);
    assert_true(r.nx == 7 && r.ny == 5 && r.nz == 3);
    assert_memory_equal(r.v, d.v, 7 * 5 * 3 * sizeof(float));
    assert_true(fabs(r.origin[0] - 1) < 1e-12 && fabs(r.origin[1] + 2) < 1e-12 &&
                fabs(r.origin[2] - 0.5) < 1e-12 && fabs(r.voxel - 0.25) < 1e-12);
    gs_vdb_dense_destroy(&r);

    /* .vdb file with two grids, read by name and by default */
    char path[256];
    tmp_path("two.vdb", path, sizeof path);
    gs_vdb_dense d2;
    assert_int_equal(gs_vdb_dense_alloc(&d2, 2, 2, 2), GS_OK);
    for (int i = 0; i < 8; i++)
        d2.v[i] = (float)i * 3;
    gs_vdb_grid_t g2 = NULL;
    assert_int_equal(gs_vdb_grid_from_dense(&d2, "other", 0.0f, &g2), GS_OK);
    gs_vdb_grid_t both[2] = {g, g2};
    assert_int_equal(gs_vdb_write(path, both, 2), GS_OK);
    assert_int_equal(access(path, F_OK), 0);
    char tmp[300];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    assert_int_equal(access(tmp, F_OK), -1);
    assert_int_equal(gs_vdb_read_dense(path, NULL, &r), GS_OK); /* first float grid */
    assert_true(r.nx == 7 && r.ny == 5 && r.nz == 3 && r.background == -1.0f);
    assert_memory_equal(r.v, d.v, 7 * 5 * 3 * sizeof(float));
    assert_true(fabs(r.origin[1] + 2) < 1e-12 && fabs(r.voxel - 0.25) < 1e-12);
    gs_vdb_dense_destroy(&r);
    assert_int_equal(gs_vdb_read_dense(path, "other", &r), GS_OK);
    assert_true(r.nx == 2 && r.ny == 2 && r.nz == 2);
    assert_memory_equal(r.v, d2.v, 8 * sizeof(float));
    gs_vdb_dense_destroy(&r);
    /* a missing name lists the grids */
    assert_int_equal(gs_vdb_read_dense(path, "sdf", &r), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "'density'"));
    assert_non_null(strstr(gs_error_message(), "'other'"));
    assert_null(r.v);
    /* missing and damaged files */
    assert_int_equal(gs_vdb_read_dense("/nonexistent/x.vdb", NULL, &r), GS_ERR_IO);
    tmp_path("bad.vdb", path, sizeof path);
    FILE *f = fopen(path, "wb");
    fputs("this is not a vdb file", f);
    fclose(f);
    gs_err e = gs_vdb_read_dense(path, NULL, &r);
    assert_int_equal(e, GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "bad.vdb: not a VDB file"));
    gs_error_clear();
    damaged_vdb_files(both);
    gs_vdb_grid_destroy(&g);
    gs_vdb_grid_destroy(&g2);
    assert_null(g);
    gs_vdb_dense_destroy(&d);
    gs_vdb_dense_destroy(&d2);
}

/* Every sample of the cube's distance fields against brute force. */
static void test_cube_distance_brute_force(void **state)
{
    (void)state;
    gs_mesh cube;
    make_cube(&cube);
    for (int is_signed = 0; is_signed <= 1; is_signed++) {
        gs_vdb_distance_opts o = {20, 0.3, is_signed};
        gs_vdb_dense d;
        assert_int_equal(gs_vdb_mesh_to_distance(&cube, "cube", &o, &d), GS_OK);
        assert_true(fabs(d.voxel - 1.6 / 19) < 1e-9);
        assert_true(d.nx == 20 && d.ny == 20 && d.nz == 20);
        assert_true(fabs(d.origin[0] + 0.3) < 1e-6);
        double worst = 0;
        for (size_t k = 0; k < d.nz; k++)
            for (size_t j = 0; j < d.ny; j++)
                for (size_t i = 0; i < d.nx; i++) {
                    double p[3];
                    sample_pos(&d, i, j, k, p);
                    double ref = mesh_dist(&cube, p);
                    int inside = p[0] > 0 && p[0] < 1 && p[1] > 0 && p[1] < 1 && p[2] > 0 &&
                                 p[2] < 1;
                    if (is_signed && inside)
                        ref = -ref;
                    double err = fabs(d.v[i + d.nx * (j + d.ny * k)] - ref);
                    worst = err > worst ? err : worst;
                }
        printf("cube %s distance: worst error %.3g voxels\n", is_signed ? "signed" : "unsigned",
               worst / d.voxel);
        assert_true(worst <= 0.5 * d.voxel);
        gs_vdb_dense_destroy(&d);
    }
    gs_mesh_destroy(&cube);
}

/* Analytic sphere SDF -> contour -> area, volume, closedness; contour ->
 * signed distance again -> close to the analytic one. */
static void test_sphere_roundtrip(void **state)
{
    (void)state;
    const double r = 1.0, h = 0.05;
    gs_vdb_dense d;
    assert_int_equal(gs_vdb_dense_alloc(&d, 56, 56, 56), GS_OK);
    d.voxel = h;
    for (int k = 0; k < 3; k++)
        d.origin[k] = -27.5 * h + 0.013; /* off-centre on purpose */
    d.background = 1.5f;
    for (size_t z = 0; z < 56; z++)
        for (size_t y = 0; y < 56; y++)
            for (size_t x = 0; x < 56; x++) {
                double p[3];
                sample_pos(&d, x, y, z, p);
                d.v[x + 56 * (y + 56 * z)] = (float)(sqrt(dot(p, p)) - r);
            }
    gs_mesh m;
    assert_int_equal(gs_vdb_dense_to_mesh(&d, 0.0, 0.0, &m), GS_OK);
    double area = gs_mesh_area(&m), vol = gs_mesh_volume(&m);
    double a_ref = 4 * PI * r * r, v_ref = 4.0 / 3.0 * PI * r * r * r;
    printf("sphere contour: %zu triangles, area %.4f (ref %.4f), volume %.4f (ref %.4f)\n",
           m.ntris, area, a_ref, vol, v_ref);
    assert_true(fabs(area - a_ref) < 0.03 * a_ref);
    assert_true(fabs(vol - v_ref) < 0.03 * v_ref); /* positive: outward orientation */
    gs_mesh_topology t;
    assert_int_equal(gs_mesh_topology_check(&m, &t), GS_OK);
    assert_true(t.closed);
    for (size_t i = 0; i < m.nverts; i++) {
        double p[3] = {m.pos[3 * i], m.pos[3 * i + 1], m.pos[3 * i + 2]};
        assert_true(fabs(sqrt(dot(p, p)) - r) < 0.5 * h);
    }
    /* back to a signed distance field */
    gs_vdb_distance_opts o = {40, 0.25, 1};
    gs_vdb_dense s;
    assert_int_equal(gs_vdb_mesh_to_distance(&m, "sphere contour", &o, &s), GS_OK);
    double worst = 0;
    for (size_t k = 0; k < s.nz; k++)
        for (size_t j = 0; j < s.ny; j++)
            for (size_t i = 0; i < s.nx; i++) {
                double p[3];
                sample_pos(&s, i, j, k, p);
                double err = fabs(s.v[i + s.nx * (j + s.ny * k)] - (sqrt(dot(p, p)) - r));
                worst = err > worst ? err : worst;
            }
    printf("sphere SDF from contour: worst error %.3g voxels of %.3g\n", worst / s.voxel, s.voxel);
    assert_true(worst < 0.5 * s.voxel);
    /* an empty iso-surface is not an error */
    gs_mesh e;
    assert_int_equal(gs_vdb_dense_to_mesh(&d, 100.0, 0.0, &e), GS_OK);
    assert_int_equal(e.ntris, 0);
    gs_mesh_destroy(&e);
    gs_vdb_dense_destroy(&s);
    gs_mesh_destroy(&m);
    gs_vdb_dense_destroy(&d);
}

static void test_spot_unsigned(void **state)
{
    (void)state;
    char path[4096];
    gs_mesh m;
    assert_int_equal(gs_mesh_read(gs_test_data("meshes/spot.obj", path, sizeof path), &m), GS_OK);
    gs_vdb_distance_opts o = {48, -1, 0};
    gs_vdb_dense d;
    assert_int_equal(gs_vdb_mesh_to_distance(&m, path, &o, &d), GS_OK);
    size_t n = d.nx * d.ny * d.nz, clamped = 0;
    float mn = HUGE_VALF, mx = 0;
    for (size_t i = 0; i < n; i++) {
        clamped += d.v[i] >= d.background;
        mn = d.v[i] < mn ? d.v[i] : mn;
        mx = d.v[i] > mx ? d.v[i] : mx;
    }
    printf("spot unsigned: %zux%zux%zu, voxel %.4f, range %.4f..%.4f, background %.4f\n", d.nx,
           d.ny, d.nz, d.voxel, (double)mn, (double)mx, (double)d.background);
    assert_int_equal(clamped, 0);
    assert_true(mn >= 0 && mn < d.voxel);
    /* spot checks against brute force on a sparse sub-lattice */
    double worst = 0;
    for (size_t k = 0; k < d.nz; k += 7)
        for (size_t j = 0; j < d.ny; j += 5)
            for (size_t i = 0; i < d.nx; i += 3) {
                double p[3];
                sample_pos(&d, i, j, k, p);
                double err = fabs(d.v[i + d.nx * (j + d.ny * k)] - mesh_dist(&m, p));
                worst = err > worst ? err : worst;
            }
    printf("spot unsigned: worst sampled error %.3g voxels\n", worst / d.voxel);
    assert_true(worst < 0.5 * d.voxel);
    gs_vdb_dense_destroy(&d);
    /* spot is closed: a signed field is allowed and negative somewhere */
    o.is_signed = 1;
    o.samples = 24;
    assert_int_equal(gs_vdb_mesh_to_distance(&m, path, &o, &d), GS_OK);
    mn = HUGE_VALF;
    for (size_t i = 0; i < d.nx * d.ny * d.nz; i++)
        mn = d.v[i] < mn ? d.v[i] : mn;
    assert_true(mn < 0);
    gs_vdb_dense_destroy(&d);
    gs_mesh_destroy(&m);
}

/* An open mesh asked for a signed field is refused with a message naming the
 * file and its boundary edges; its unsigned field is fine. */
static void check_open_signed_refused(gs_mesh *m, const char *path, const char *name)
{
    gs_vdb_distance_opts o = {16, -1, 1};
    gs_vdb_dense d;
    assert_int_equal(gs_vdb_mesh_to_distance(m, path, &o, &d), GS_ERR_ARG);
    assert_null(d.v);
    const char *msg = gs_error_message();
    assert_non_null(strstr(msg, name));
    assert_non_null(strstr(msg, "signed distance"));
    assert_non_null(strstr(msg, "boundary edges"));
    printf("refusal: %s\n", msg);
    gs_error_clear();
    o.is_signed = 0; /* the unsigned field is fine */
    assert_int_equal(gs_vdb_mesh_to_distance(m, path, &o, &d), GS_OK);
    gs_vdb_dense_destroy(&d);
    /* bad options */
    o.samples = 2;
    assert_int_equal(gs_vdb_mesh_to_distance(m, path, &o, &d), GS_ERR_ARG);
    gs_error_clear();
}

/* spot.obj (in the repository) with a hole: its last 40 triangles dropped. */
static void test_open_spot_signed_refused(void **state)
{
    (void)state;
    char path[4096];
    gs_mesh m;
    assert_int_equal(gs_mesh_read(gs_test_data("meshes/spot.obj", path, sizeof path), &m), GS_OK);
    m.ntris -= 40;
    check_open_signed_refused(&m, "spot-with-a-hole", "spot-with-a-hole");
    m.ntris += 40;
    gs_mesh_destroy(&m);
}

/* The open Stanford bunny (`make data`), where the sign first came out wrong. */
static void test_open_bunny_signed_refused(void **state)
{
    (void)state;
    GS_TEST_NEED_DATA("meshes/stanford-bunny.obj");
    char path[4096];
    gs_mesh m;
    assert_int_equal(gs_mesh_read(gs_test_data("meshes/stanford-bunny.obj", path, sizeof path), &m),
                     GS_OK);
    check_open_signed_refused(&m, path, "stanford-bunny.obj");
    gs_mesh_destroy(&m);
}

/* Redistancing (field.h5's distance, field.vdb): a field like a synthesized
 * one (a distance clamped to +-3 samples with jumps, not a distance field)
 * redistanced in one call and in pieces of 1, 4 and 9 planes gives the same
 * values bit for bit (the field engine splits the planes over its ranks and
 * into pieces of bounded memory); no neighbour step exceeds a sample; the
 * .vdb written from them reads back the same over the box. */
static void test_redistance_pieces(void **state)
{
    (void)state;
    const size_t nx = 23, ny = 19, nz = 41, n = nx * ny * nz;
    const double h = 0.5, range = 3;
    gs_vdb_dense d;
    assert_int_equal(gs_vdb_dense_alloc(&d, nx, ny, nz), GS_OK);
    d.voxel = h;
    d.origin[0] = 1.25, d.origin[1] = -2, d.origin[2] = 0.5;
    d.background = (float)(range * h);
    uint32_t r = 12345;
    for (size_t z = 0; z < nz; z++)
        for (size_t y = 0; y < ny; y++)
            for (size_t x = 0; x < nx; x++) {
                r = r * 1664525u + 1013904223u;
                double v = 2.5 * (sin(0.7 * x) + sin(0.5 * y + 1) + sin(0.45 * z + 2)) +
                           1.5 * ((r >> 8) / 16777216.0 - 0.5);
                v = v < -range ? -range : v > range ? range : v;
                d.v[x + nx * (y + ny * z)] = (float)(v * h);
            }
    float *whole = NULL, *parts = NULL;
    assert_int_equal(gs_alloc_array((void **)&whole, n, sizeof *whole, "t"), GS_OK);
    assert_int_equal(gs_alloc_array((void **)&parts, n, sizeof *parts, "t"), GS_OK);
    assert_int_equal(gs_vdb_redistance(&d, 4, range, 0, nz, whole), GS_OK);
    const size_t steps[3] = {1, 4, 9};
    for (int s = 0; s < 3; s++) {
        memset(parts, 0, n * sizeof *parts);
        for (size_t z = 0; z < nz; z += steps[s]) {
            size_t e = z + steps[s] < nz ? z + steps[s] : nz;
            assert_int_equal(gs_vdb_redistance(&d, 4, range, z, e, parts + nx * ny * z), GS_OK);
        }
        size_t differ = 0;
        for (size_t i = 0; i < n; i++)
            differ += memcmp(&whole[i], &parts[i], sizeof *whole) != 0;
        printf("redistanced in pieces of %zu planes: %zu of %zu samples differ\n", steps[s],
               differ, n);
        assert_int_equal(differ, 0);
    }
    /* a distance field: every axis step within a sample, the band inside */
    double worst = 0;
    size_t band = 0, changed = 0;
    for (size_t z = 0; z < nz; z++)
        for (size_t y = 0; y < ny; y++)
            for (size_t x = 0; x < nx; x++) {
                size_t i = x + nx * (y + ny * z);
                float a = whole[i];
                assert_true(fabsf(a) <= d.background);
                band += fabsf(a) < d.background;
                changed += a != d.v[i];
                if (x + 1 < nx) worst = fmax(worst, fabs(a - whole[i + 1]));
                if (y + 1 < ny) worst = fmax(worst, fabs(a - whole[i + nx]));
                if (z + 1 < nz) worst = fmax(worst, fabs(a - whole[i + nx * ny]));
            }
    printf("largest neighbour step %.4f (voxel %.2f), %zu samples in the band, %zu changed\n",
           worst, h, band, changed);
    assert_true(worst <= h * (1 + 1e-5));
    assert_true(band > n / 4 && changed > n / 4);
    /* field.vdb: the same values read back over the box */
    char path[4096];
    tmp_path("redistanced.vdb", path, sizeof path);
    gs_vdb_dense w = d, back;
    w.v = whole;
    assert_int_equal(gs_vdb_level_set_write(&w, 4, range, "surface", path), GS_OK);
    assert_int_equal(gs_vdb_read_dense(path, "surface", &back), GS_OK);
    assert_int_equal(back.nx, nx);
    assert_int_equal(back.nz, nz);
    assert_true(fabs(back.origin[0] - d.origin[0]) < 1e-9 && fabs(back.origin[2] - d.origin[2]) < 1e-9);
    assert_true(fabs(back.background - d.background) < 1e-6);
    assert_memory_equal(back.v, whole, n * sizeof *whole);
    gs_vdb_dense_destroy(&back);
    gs_free(whole);
    gs_free(parts);
    gs_vdb_dense_destroy(&d);
}

/* Redistancing gives distances, not the field it was given: a field with
 * steps of 2.5 samples (two balls' distance times 2.5, clamped to the band
 * like a synthesized one) redistanced is, at every sample, the distance to
 * its own zero surface as contoured (gs_vdb_dense_to_mesh, brute force over
 * every triangle), clamped to the band, signed as the field, within a
 * tenth of a voxel everywhere (next to a crossing too, where the
 * neighbour-step bound may lower a sample). Returning the field unchanged,
 * or a band that does not reach half_width, fails it; so did OpenVDB's
 * levelSetRebuild (0.38 voxels off, 0.62 next to a crossing). */
static void test_redistance_exact(void **state)
{
    (void)state;
    const size_t nx = 30, ny = 26, nz = 28, n = nx * ny * nz;
    const double h = 0.25, range = 3, slope = 2.5;
    gs_vdb_dense d;
    assert_int_equal(gs_vdb_dense_alloc(&d, nx, ny, nz), GS_OK);
    d.voxel = h;
    d.origin[0] = -1, d.origin[1] = 0.5, d.origin[2] = 0;
    d.background = (float)(range * h);
    const double c[2][3] = {{2.6, 3.7, 3.3}, {5.0, 4.1, 3.6}}, rad[2] = {1.6, 1.1};
    for (size_t z = 0; z < nz; z++)
        for (size_t y = 0; y < ny; y++)
            for (size_t x = 0; x < nx; x++) {
                double p[3], v = HUGE_VAL;
                sample_pos(&d, x, y, z, p);
                for (int b = 0; b < 2; b++) {
                    double e[3];
                    sub(p, c[b], e);
                    v = fmin(v, sqrt(dot(e, e)) - rad[b]);
                }
                v *= slope;
                v = v < -range * h ? -range * h : v > range * h ? range * h : v;
                d.v[x + nx * (y + ny * z)] = (float)v;
            }
    gs_mesh m;
    assert_int_equal(gs_vdb_dense_to_mesh(&d, 0.0, 0.0, &m), GS_OK);
    float *out = NULL;
    assert_int_equal(gs_alloc_array((void **)&out, n, sizeof *out, "t"), GS_OK);
    assert_int_equal(gs_vdb_redistance(&d, 4, range, 0, nz, out), GS_OK);
    double worst = 0, worst_next = 0;
    size_t band = 0;
    for (size_t z = 0; z < nz; z++)
        for (size_t y = 0; y < ny; y++)
            for (size_t x = 0; x < nx; x++) {
                size_t i = x + nx * (y + ny * z);
                double p[3];
                sample_pos(&d, x, y, z, p);
                double ref = fmin(mesh_dist(&m, p), range * h);
                ref = d.v[i] < 0 ? -ref : ref;
                band += fabs(ref) < range * h;
                /* next to a crossing: a neighbour of the other sign */
                int next = 0;
                const long off[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
                for (int k = 0; k < 6; k++) {
                    long a = (long)x + off[k][0], b = (long)y + off[k][1], e = (long)z + off[k][2];
                    if (a >= 0 && b >= 0 && e >= 0 && a < (long)nx && b < (long)ny && e < (long)nz)
                        next |= (d.v[(size_t)a + nx * ((size_t)b + ny * (size_t)e)] < 0) != (d.v[i] < 0);
                }
                double err = fabs(out[i] - ref) / h;
                if (next)
                    worst_next = fmax(worst_next, err);
                else
                    worst = fmax(worst, err);
            }
    printf("redistanced vs brute-force distance to the contour (%zu triangles, %zu samples in "
           "the band): worst %.4f voxels, %.4f next to a crossing\n", m.ntris, band, worst, worst_next);
    assert_true(band > n / 10);
    assert_true(worst <= 0.1 && worst_next <= 0.1);
    gs_free(out);
    gs_mesh_destroy(&m);
    gs_vdb_dense_destroy(&d);
}

/* The redistancing indexes a piece's padded box with 32 bits: a call whose
 * box holds more than GS_VDB_REDIST_MAX_SAMPLES samples is a clear error
 * (GS_ERR_ARG naming the planes, the box and the limit), refused before
 * any of the field is read (the field here claims 65536 x 65536 x 2
 * samples over a buffer of one: a wrap would read far past it); a call
 * within the limit on the same planes' shape is taken. */
static void test_redistance_oversize_refused(void **state)
{
    (void)state;
    float one = 1.0f;
    gs_vdb_dense d;
    memset(&d, 0, sizeof d);
    d.nx = 65536, d.ny = 65536, d.nz = 2;
    d.voxel = 1, d.background = 3;
    d.v = &one;
    assert_int_equal(gs_vdb_redistance(&d, 4, 3, 0, 1, &one), GS_ERR_ARG);
    printf("refused: %s\n", gs_error_message());
    assert_non_null(strstr(gs_error_message(), "planes [0, 1)"));
    assert_non_null(strstr(gs_error_message(), "32-bit sample indices"));
    gs_error_clear();
    /* the same shape, small enough: taken */
    gs_vdb_dense s;
    assert_int_equal(gs_vdb_dense_alloc(&s, 16, 16, 2), GS_OK);
    s.voxel = 1, s.background = 3;
    for (size_t i = 0; i < 16 * 16 * 2; i++)
        s.v[i] = (float)((double)(i % 16) - 7.5);
    float out[16 * 16];
    assert_int_equal(gs_vdb_redistance(&s, 4, 3, 0, 1, out), GS_OK);
    gs_vdb_dense_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dense_grid_roundtrip),
        cmocka_unit_test(test_cube_distance_brute_force),
        cmocka_unit_test(test_sphere_roundtrip),
        cmocka_unit_test(test_spot_unsigned),
        cmocka_unit_test(test_open_spot_signed_refused),
        cmocka_unit_test(test_open_bunny_signed_refused),
        cmocka_unit_test(test_redistance_pieces),
        cmocka_unit_test(test_redistance_exact),
        cmocka_unit_test(test_redistance_oversize_refused),
    };
    return cmocka_run_group_tests(tests, gs_test_tmpdir_setup, gs_test_tmpdir_teardown);
}
