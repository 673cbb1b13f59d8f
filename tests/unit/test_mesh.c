/* Unit tests for src/io/mesh.c: reading the real meshes, closedness,
 * welding, normals, OBJ/PLY writers, error messages. */
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
#include "geosynth/rng.h"


static const char *tmp_path(const char *name, char *buf, size_t n)
{
    snprintf(buf, n, "%s/%s", gs_test_tmpdir, name);
    return buf;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

typedef struct expect {
    const char *file;
    size_t nverts, ntris, boundary;
    int closed;
} expect;

/* Counts checked by Euler: closed genus-0 meshes satisfy V - E + F = 2. */
static void check_real_meshes(const expect *cases, size_t ncases)
{
    for (size_t i = 0; i < ncases; i++) {
        char path[4096];
        gs_mesh m;
        assert_int_equal(gs_mesh_read(gs_test_data(cases[i].file, path, sizeof path), &m), GS_OK);
        gs_mesh_topology t;
        assert_int_equal(gs_mesh_topology_check(&m, &t), GS_OK);
        printf("%s: %zu vertices, %zu triangles, %zu edges, %zu boundary, %zu non-manifold, "
               "closed %d\n",
               cases[i].file, m.nverts, m.ntris, t.edges, t.boundary_edges, t.nonmanifold_edges,
               t.closed);
        assert_int_equal(m.nverts, cases[i].nverts);
        assert_int_equal(m.ntris, cases[i].ntris);
        assert_int_equal(t.boundary_edges, cases[i].boundary);
        assert_int_equal(t.closed, cases[i].closed);
        assert_int_equal(t.nonmanifold_edges, 0);
        if (t.closed) {
            assert_int_equal((long)m.nverts - (long)t.edges + (long)m.ntris, 2);
            assert_true(gs_mesh_volume(&m) > 0); /* outward orientation */
            assert_int_equal(gs_mesh_require_closed(&m, path, NULL), GS_OK);
        } else {
            assert_int_equal(gs_mesh_require_closed(&m, path, "signed distance field"),
                             GS_ERR_ARG);
            assert_non_null(strstr(gs_error_message(), "223 boundary edges"));
            gs_error_clear();
        }
        gs_mesh_destroy(&m);
        assert_null(m.pos);
    }
}

/* spot.obj is in the repository's data/. */
static void test_real_mesh_spot(void **state)
{
    (void)state;
    static const expect spot = {"meshes/spot.obj", 2930, 5856, 0, 1};
    check_real_meshes(&spot, 1);
}

/* The Stanford meshes come from `make data`. */
static void test_real_meshes_fetched(void **state)
{
    (void)state;
    static const expect cases[] = {
        {"meshes/stanford-bunny.obj", 34834, 69451, 223, 0},
        {"meshes/bunny-closed.off", 3485, 6966, 0, 1},
        {"meshes/armadillo.obj", 43243, 86482, 0, 1},
    };
    GS_TEST_NEED_DATA(cases[0].file, cases[1].file, cases[2].file);
    check_real_meshes(cases, sizeof cases / sizeof cases[0]);
}

static void test_read_errors(void **state)
{
    (void)state;
    gs_mesh m;
    char path[256];
    assert_int_equal(gs_mesh_read("/nonexistent/mesh.obj", &m), GS_ERR_IO);
    assert_non_null(strstr(gs_error_message(), "/nonexistent/mesh.obj"));
    assert_null(m.pos);

    tmp_path("notamesh.obj", path, sizeof path);
    write_text(path, "\x01\x02 this is not a mesh at all\n");
    gs_err e = gs_mesh_read(path, &m);
    assert_int_equal(e, GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "notamesh.obj"));

    tmp_path("lines.obj", path, sizeof path);
    write_text(path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n");
    assert_int_equal(gs_mesh_read(path, &m), GS_ERR_FORMAT);
    printf("lines only: %s\n", gs_error_message());
    assert_non_null(strstr(gs_error_message(), "lines.obj"));

    tmp_path("nan.obj", path, sizeof path);
    write_text(path, "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    e = gs_mesh_read(path, &m);
    printf("nan: %s\n", gs_error_message());
    assert_int_equal(e, GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "nan.obj"));

    tmp_path("degenerate.off", path, sizeof path);
    write_text(path, "OFF\n3 1 0\n0 0 0\n0 0 0\n1 1 1\n3 0 1 2\n");
    e = gs_mesh_read(path, &m);
    printf("degenerate: %s\n", gs_error_message());
    assert_int_equal(e, GS_ERR_FORMAT);
    gs_error_clear();
}

/* A quad split in two with duplicated vertices (as assimp produces when
 * normals differ), plus welding with a tolerance. */
static void test_weld_and_normals(void **state)
{
    (void)state;
    gs_mesh m;
    assert_int_equal(gs_mesh_alloc(&m, 6, 2, 0), GS_OK);
    const float p[6][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1.0004f, 0}};
    const uint32_t t[2][3] = {{0, 1, 2}, {3, 4, 5}};
    memcpy(m.pos, p, sizeof p);
    memcpy(m.tris, t, sizeof t);
    assert_int_equal(gs_mesh_weld(&m, 0.0f), GS_OK);
    assert_int_equal(m.nverts, 4);
    assert_int_equal(m.ntris, 2);
    gs_mesh_topology topo;
    assert_int_equal(gs_mesh_topology_check(&m, &topo), GS_OK);
    assert_int_equal(topo.edges, 5);
    assert_int_equal(topo.boundary_edges, 4);
    assert_false(topo.closed);
    assert_int_equal(gs_mesh_compute_normals(&m), GS_OK);
    for (size_t i = 0; i < m.nverts; i++)
        assert_true(fabsf(m.normals[3 * i + 2] - 1.0f) < 1e-6f);
    assert_true(fabs(gs_mesh_area(&m) - 1.0) < 1e-3);
    /* tolerance weld collapses the second triangle onto a segment */
    float lo[3], hi[3];
    gs_mesh_bbox(&m, lo, hi);
    assert_true(lo[0] == 0 && hi[0] == 1 && hi[1] > 1.0f);
    assert_int_equal(gs_mesh_weld(&m, 1.5f), GS_OK);
    assert_int_equal(m.ntris, 0);
    assert_int_equal(gs_mesh_weld(&m, -1.0f), GS_ERR_ARG);
    gs_error_clear();
    gs_mesh_destroy(&m);
}

/* Tolerance weld against its definition, checked by brute force: in
 * vertex order, a vertex joins the lowest kept vertex within tol, else it
 * is kept. Clusters of points closer than tol, chains that straddle cell
 * faces and cell middles, negative coordinates, a point set (kept vertices
 * stay, in order). */
static void test_weld_matches_brute_force(void **state)
{
    (void)state;
    const float tols[3] = {0.35f, 1.0f, 0.01f};
    for (int ti = 0; ti < 3; ti++) {
        float tol = tols[ti];
        enum { N = 3000 };
        gs_mesh m;
        assert_int_equal(gs_mesh_alloc(&m, N, 0, 0), GS_OK);
        gs_rng r;
        gs_rng_init(&r, 7 + (uint64_t)ti, 0);
        for (int i = 0; i < N; i++) {
            float *p = m.pos + 3 * i;
            if (i % 3 == 0 || i < 3) {
                for (int k = 0; k < 3; k++) /* on a lattice of cell faces and middles */
                    p[k] = (float)((double)tol * ((double)gs_rng_below(&r, 40) / 2.0 - 10.0));
            } else { /* near an earlier point: within, at, or just beyond tol */
                const float *o = m.pos + 3 * (size_t)gs_rng_below(&r, (uint64_t)i);
                double d[3], n = 0;
                for (int k = 0; k < 3; k++) {
                    d[k] = gs_rng_uniform(&r) - 0.5;
                    n += d[k] * d[k];
                }
                double len = tol * (0.5 + gs_rng_uniform(&r) * 0.7) / (sqrt(n) + 1e-12);
                for (int k = 0; k < 3; k++)
                    p[k] = (float)(o[k] + d[k] * len);
            }
        }
        float *orig = malloc(sizeof(float) * 3 * N);
        memcpy(orig, m.pos, sizeof(float) * 3 * N);
        /* brute force */
        int *kept = malloc(sizeof(int) * N), nk = 0;
        for (int i = 0; i < N; i++) {
            int join = -1;
            for (int j = 0; j < nk && join < 0; j++) {
                const float *a = orig + 3 * i, *b = orig + 3 * kept[j];
                double d2 = 0;
                for (int k = 0; k < 3; k++)
                    d2 += ((double)a[k] - b[k]) * ((double)a[k] - b[k]);
                if (d2 <= (double)tol * tol)
                    join = kept[j];
            }
            if (join < 0)
                kept[nk++] = i;
        }
        assert_int_equal(gs_mesh_weld(&m, tol), GS_OK);
        assert_int_equal((int)m.nverts, nk);
        assert_true(nk < N * 9 / 10 && nk > N / 10); /* both outcomes are common */
        for (int j = 0; j < nk; j++)
            assert_memory_equal(m.pos + 3 * j, orig + 3 * kept[j], 3 * sizeof(float));
        free(kept);
        free(orig);
        gs_mesh_destroy(&m);
    }
}

static void test_misoriented_and_nonmanifold(void **state)
{
    (void)state;
    gs_mesh m;
    /* tetrahedron with one face flipped */
    assert_int_equal(gs_mesh_alloc(&m, 4, 4, 0), GS_OK);
    const float p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const uint32_t t[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 2, 3}};
    memcpy(m.pos, p, sizeof p);
    memcpy(m.tris, t, sizeof t);
    gs_mesh_topology topo;
    assert_int_equal(gs_mesh_topology_check(&m, &topo), GS_OK);
    assert_int_equal(topo.boundary_edges, 0);
    assert_int_equal(topo.misoriented_edges, 3);
    assert_false(topo.closed);
    m.tris[9] = 0, m.tris[10] = 3, m.tris[11] = 2; /* fix it */
    assert_int_equal(gs_mesh_topology_check(&m, &topo), GS_OK);
    assert_true(topo.closed);
    assert_true(gs_mesh_volume(&m) > 0);
    gs_mesh_destroy(&m);
    /* three triangles on one edge */
    assert_int_equal(gs_mesh_alloc(&m, 5, 3, 0), GS_OK);
    const uint32_t f[3][3] = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
    memcpy(m.tris, f, sizeof f);
    assert_int_equal(gs_mesh_topology_check(&m, &topo), GS_OK);
    assert_int_equal(topo.nonmanifold_edges, 1);
    gs_mesh_destroy(&m);
}

static void test_write_read_roundtrip(void **state)
{
    (void)state;
    char src[4096], path[256];
    gs_mesh m, r;
    assert_int_equal(gs_mesh_read(gs_test_data("meshes/spot.obj", src, sizeof src), &m),
                     GS_OK);
    assert_int_equal(gs_mesh_compute_normals(&m), GS_OK);
    assert_int_equal(gs_alloc_array((void **)&m.scalar, m.nverts, sizeof(float), "s"), GS_OK);
    for (size_t i = 0; i < m.nverts; i++)
        m.scalar[i] = m.pos[3 * i + 2] * 2;
    const char *names[] = {"spot.obj", "spot.ply"};
    for (int k = 0; k < 2; k++) {
        tmp_path(names[k], path, sizeof path);
        assert_int_equal(gs_mesh_write(path, &m, "height"), GS_OK);
        char tmp[300];
        snprintf(tmp, sizeof tmp, "%s.tmp", path);
        assert_int_equal(access(tmp, F_OK), -1);
        assert_int_equal(gs_mesh_read(path, &r), GS_OK);
        assert_int_equal(r.nverts, m.nverts);
        assert_int_equal(r.ntris, m.ntris);
        /* same vertex order and exact float positions (OBJ writes %.9g) */
        assert_memory_equal(r.pos, m.pos, 3 * m.nverts * sizeof(float));
        assert_memory_equal(r.tris, m.tris, 3 * m.ntris * sizeof(uint32_t));
        gs_mesh_destroy(&r);
    }
    /* the PLY header declares what we wrote */
    tmp_path("spot.ply", path, sizeof path);
    FILE *f = fopen(path, "rb");
    char head[512] = {0};
    assert_true(fread(head, 1, sizeof head - 1, f) > 0);
    fclose(f);
    assert_non_null(strstr(head, "format binary_little_endian 1.0"));
    assert_non_null(strstr(head, "property float nx"));
    assert_non_null(strstr(head, "property float height"));
    /* uchar label property */
    GS_FREE(m.scalar);
    assert_int_equal(gs_alloc_array((void **)&m.label, m.nverts, 1, "l"), GS_OK);
    tmp_path("labels.ply", path, sizeof path);
    assert_int_equal(gs_mesh_write_ply(path, &m, "label"), GS_OK);
    assert_int_equal(gs_mesh_read(path, &r), GS_OK);
    assert_int_equal(r.ntris, m.ntris);
    gs_mesh_destroy(&r);
    assert_int_equal(gs_mesh_write_ply(path, &m, "bad name"), GS_ERR_ARG);
    assert_int_equal(gs_mesh_write("/nonexistent/dir/x.obj", &m, NULL), GS_ERR_IO);
    assert_int_equal(gs_mesh_write(tmp_path("x.stl", path, sizeof path), &m, NULL), GS_ERR_ARG);
    m.tris[5] = (uint32_t)m.nverts; /* out of range index is refused */
    assert_int_equal(gs_mesh_write_obj(tmp_path("y.obj", path, sizeof path), &m), GS_ERR_FORMAT);
    gs_error_clear();
    gs_mesh_destroy(&m);
}


/* The bounded readers (src/io/meshread.c): a cube in every format reads to
 * 8 vertices and 12 triangles; counts beyond the file, indices out of range
 * and unknown extensions are refused with the file and line or byte named. */
static void expect_mesh_error(const char *text, const char *name, const char *needle)
{
    gs_mesh m;
    gs_err e = gs_mesh_parse(text, strlen(text), name, &m);
    if (e != GS_ERR_FORMAT || !strstr(gs_error_message(), needle) ||
        !strstr(gs_error_message(), name))
        fail_msg("%s: expected an error with '%s', got %d: %s", name, needle, e,
                 gs_error_message());
    gs_error_clear();
}

/* gs_mesh_compute_normals in ranges of vertices (the memory bound of large
 * contours): the same bits as all vertices at once, for ranges that split
 * triangles' corners between passes (random triangles over scattered
 * vertices, each vertex in several triangles). */
static void test_normals_ranged(void **state)
{
    (void)state;
    enum { NV = 997, NT = 4000 };
    gs_mesh m, r;
    assert_int_equal(gs_mesh_alloc(&m, NV, NT, 0), GS_OK);
    gs_rng g;
    gs_rng_init(&g, 19, 34);
    for (size_t i = 0; i < 3 * (size_t)NV; i++)
        m.pos[i] = (float)(gs_rng_u32(&g) % 100000) / 1000.0f;
    for (size_t t = 0; t < NT; t++)
        for (int c = 0; c < 3; c++)
            m.tris[3 * t + c] = (uint32_t)(c ? gs_rng_u32(&g) % NV : t % NV);
    assert_int_equal(gs_mesh_compute_normals(&m), GS_OK);
    const size_t ranges[] = {1, 2, 7, 100, NV - 1, NV, 5000};
    for (size_t k = 0; k < sizeof ranges / sizeof *ranges; k++) {
        r = m;
        r.normals = NULL;
        assert_int_equal(gs_mesh_compute_normals_ranged(&r, ranges[k]), GS_OK);
        assert_memory_equal(r.normals, m.normals, 3 * (size_t)NV * sizeof(float));
        gs_free(r.normals);
    }
    /* not every normal is zero or axis-aligned: the comparison means something */
    size_t tilted = 0;
    for (size_t i = 0; i < NV; i++)
        tilted += fabsf(m.normals[3 * i]) > 0.1f && fabsf(m.normals[3 * i + 1]) > 0.1f;
    assert_true(tilted > NV / 4);
    r = m;
    r.normals = NULL;
    assert_int_equal(gs_mesh_compute_normals_ranged(&r, 0), GS_ERR_ARG);
    gs_error_clear();
    gs_mesh_destroy(&m);
}

static void test_bounded_readers(void **state)
{
    (void)state;
    static const char *v8 = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n";
    static const char *q6 = "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";
    char buf[2048];
    gs_mesh m;
    snprintf(buf, sizeof buf, "OFF\n8 6 0\n%s%s", v8, q6);
    assert_int_equal(gs_mesh_parse(buf, strlen(buf), "cube.off", &m), GS_OK);
    assert_true(m.nverts == 8 && m.ntris == 12);
    gs_mesh_topology t;
    assert_int_equal(gs_mesh_topology_check(&m, &t), GS_OK);
    assert_true(t.closed);
    gs_mesh_destroy(&m);
    snprintf(buf, sizeof buf,
             "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
             "property float z\nelement face 6\nproperty list uchar int vertex_indices\n"
             "end_header\n%s%s", v8, q6);
    assert_int_equal(gs_mesh_parse(buf, strlen(buf), "cube.ply", &m), GS_OK);
    assert_true(m.nverts == 8 && m.ntris == 12);
    gs_mesh_destroy(&m);
    /* big-endian binary PLY: one triangle */
    static const unsigned char be[] = "ply\nformat binary_big_endian 1.0\nelement vertex 3\n"
                                      "property float x\nproperty float y\nproperty float z\n"
                                      "element face 1\nproperty list uchar int vertex_indices\n"
                                      "end_header\n";
    unsigned char bb[400];
    size_t n = sizeof be - 1;
    memcpy(bb, be, n);
    const unsigned char one[4] = {0x3f, 0x80, 0, 0}, zero[4] = {0, 0, 0, 0};
    for (int i = 0; i < 9; i++) /* (0,0,0) (1,0,0) (0,1,0) */
        memcpy(bb + n + 4 * i, (i == 3 || i == 7) ? one : zero, 4);
    n += 36;
    bb[n++] = 3;
    for (int k = 0; k < 3; k++) {
        bb[n++] = 0, bb[n++] = 0, bb[n++] = 0, bb[n++] = (unsigned char)k;
    }
    assert_int_equal(gs_mesh_parse((const char *)bb, n, "be.ply", &m), GS_OK);
    assert_true(m.nverts == 3 && m.ntris == 1 && m.pos[3] == 1.0f && m.pos[7] == 1.0f);
    gs_mesh_destroy(&m);
    expect_mesh_error("ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\n"
                      "property float x\nproperty float y\nproperty float z\nelement face 1\n"
                      "property list uchar int vertex_indices\nend_header\n",
                      "huge.ply", "need more data than the 0 bytes left");
    expect_mesh_error("OFF\n2000000000 1 0\n0 0 0\n", "huge.off", "vertex count");
    snprintf(buf, sizeof buf, "OFF\n8 1 0\n%s3 0 1 9\n", v8);
    expect_mesh_error(buf, "index.off", "line 11: a face's vertex index");
    expect_mesh_error("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "index.obj",
                      "line 4: face uses vertex 4 but the file has 3 vertices");
    expect_mesh_error("v 0 0 0\nf -2 1 1\n", "back.obj", "refers back past");
    expect_mesh_error("solid x\n facet normal 0 0 0\n  outer loop\n   vertex 0 0 0\n",
                      "cut.stl", "file ends inside a facet");
    expect_mesh_error("v 0 0 0\n", "x.xyz", "unknown mesh extension '.xyz'");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_real_mesh_spot),
        cmocka_unit_test(test_real_meshes_fetched),
        cmocka_unit_test(test_read_errors),
        cmocka_unit_test(test_weld_and_normals),
        cmocka_unit_test(test_weld_matches_brute_force),
        cmocka_unit_test(test_misoriented_and_nonmanifold),
        cmocka_unit_test(test_write_read_roundtrip),
        cmocka_unit_test(test_bounded_readers),
        cmocka_unit_test(test_normals_ranged),
    };
    return cmocka_run_group_tests(tests, gs_test_tmpdir_setup, gs_test_tmpdir_teardown);
}
