/* Unit tests for the field engine's examples and geometry
 * (src/field/examples.c, src/field/geometry.c). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "../util/testutil.h"
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/field_examples.h"
#include "geosynth/mem.h"

#define OK(expr) assert_int_equal((expr), GS_OK)

/* Every generator: deterministic, has inside and outside, and its mesh is closed. */
static void test_generators(void **state)
{
    (void)state;
    const char *kinds[] = {"grid", "chainmail", "balls", "fibers", "spheres", "chainmail_jittered"};
    for (int k = 0; k < 6; k++) {
        gs_field *a = NULL, *b = NULL;
        OK(gs_field_example_make(kinds[k], 32, 7, &a));
        OK(gs_field_example_make(kinds[k], 32, 7, &b));
        size_t n = 32 * 32 * 32;
        assert_true(gs_digest_bytes(a->v, n * 4) == gs_digest_bytes(b->v, n * 4));
        int64_t in = 0;
        for (size_t i = 0; i < n; i++) {
            in += a->v[i] < 0;
            assert_true(a->v[i] <= GS_EXAMPLE_BAND && isfinite(a->v[i]));
        }
        double vf = (double)in / (double)n;
        fprintf(stderr, "%s: volume fraction %.3f\n", kinds[k], vf);
        assert_true(vf > 0.02 && vf < 0.7);
        gs_field_destroy(&a);
        gs_field_destroy(&b);
        gs_mesh m;
        OK(gs_field_example_mesh(kinds[k], 24, 3, &m));
        gs_mesh_topology topo;
        OK(gs_mesh_topology_check(&m, &topo));
        assert_true(m.ntris > 100);
        assert_true(topo.closed);
        assert_true(gs_mesh_volume(&m) > 0);
        gs_mesh_destroy(&m);
    }
    gs_field *f = NULL;
    assert_int_equal(gs_field_example_make("knot", 32, 1, &f), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), GS_EXAMPLE_KINDS));
    assert_int_equal(gs_field_example_make("grid", 4, 1, &f), GS_ERR_ARG);
    gs_error_clear();
}

/* chainmail repeats every 24 samples along x (rings alternate their axis
 * every 12); chainmail_jittered, its rings each their own, does not: the
 * largest difference between samples 24 apart is a sizeable share of a
 * ring's thickness (1.15..1.45 minor radius, centres moved up to 0.6). */
static void test_chainmail_jittered_not_periodic(void **state)
{
    (void)state;
    const int64_t n = 64;
    for (int k = 0; k < 2; k++) {
        gs_field *f = NULL;
        OK(gs_field_example_make(k ? "chainmail_jittered" : "chainmail", n, 1, &f));
        double worst = 0;
        for (int64_t z = 0; z < n; z++)
            for (int64_t y = 0; y < n; y++)
                for (int64_t x = 0; x + 24 < n; x++) {
                    double d = fabs((double)f->v[x + 24 + n * (y + n * z)] - f->v[x + n * (y + n * z)]);
                    worst = d > worst ? d : worst;
                }
        fprintf(stderr, "%s: largest change over 24 samples along x %.4f\n",
                k ? "chainmail_jittered" : "chainmail", worst);
        if (k)
            assert_true(worst > 0.5);
        else
            assert_true(worst < 1e-3);
        gs_field_destroy(&f);
    }
}

/* Dropped balls never overlap: the union's field equals the nearest ball's
 * distance: no sample is inside by more than the largest radius (5), and the
 * share of inside samples stays below random close packing (0.64). */
static void test_balls_no_overlap(void **state)
{
    (void)state;
    gs_field *f = NULL;
    OK(gs_field_example_make("balls", 48, 5, &f));
    int64_t n = 48 * 48 * 48, in = 0;
    float mn = 0;
    for (int64_t i = 0; i < n; i++) {
        in += f->v[i] < 0;
        mn = f->v[i] < mn ? f->v[i] : mn;
    }
    assert_true(mn >= -5.01f);
    assert_true((double)in / (double)n < 0.64);
    fprintf(stderr, "dropped balls: volume fraction %.3f\n", (double)in / (double)n);
    assert_true((double)in / (double)n > 0.1); /* the box gets filled (loose: no rolling) */
    gs_field_destroy(&f);
}

/* Copied geometry: copying the whole source in place puts the contour's
 * vertices on the source's own surface (no seams, nothing moves); a shifted
 * source copied back by its provenance lands on the source's surface too;
 * nothing copied leaves the base as it is. */
/* The copy tests' source: the spheres example at 24^3, its contour, and a
 * provenance map for a 24^3 target. */
typedef struct copy_case {
    gs_field *f;
    gs_mesh src;
    int32_t *prov;
} copy_case;

static void spheres_source(copy_case *c)
{
    c->f = NULL;
    OK(gs_field_example_make("spheres", 24, 2, &c->f));
    OK(gs_field_contour(c->f, 0.0, 0.0, &c->src));
    c->prov = gs_malloc(24 * 24 * 24 * sizeof *c->prov);
    assert_non_null(c->prov);
}

static void test_copy_geometry(void **state)
{
    (void)state;
    copy_case cc;
    spheres_source(&cc);
    gs_field *f = cc.f;
    gs_mesh src = cc.src;
    int32_t *prov = cc.prov;
    int64_t sn[3] = {24, 24, 24};
    for (int i = 0; i < 24 * 24 * 24; i++)
        prov[i] = i;
    gs_mesh out;
    gs_field_copy_stats st;
    OK(gs_field_copy_geometry(&src, sn, prov, f, &src, 1.0, 10, &out, &st));
    assert_int_equal(out.ntris, src.ntris);
    assert_memory_equal(out.tris, src.tris, 3 * src.ntris * sizeof *src.tris);
    assert_int_equal(st.seam_vertices, 0);
    assert_true(st.mean_shift < 1e-4);
    /* all but those within a sample of the box faces (they stay) */
    assert_true((double)st.copied_vertices > 0.5 * (double)src.nverts);
    gs_mesh_destroy(&out);
    /* target = source shifted by (3, 2, 1): its contour copied back */
    gs_field *g = NULL;
    OK(gs_field_create(24, 24, 24, &g));
    for (int z = 0; z < 24; z++)
        for (int y = 0; y < 24; y++)
            for (int x = 0; x < 24; x++) {
                int sx = (x + 21) % 24, sy = (y + 22) % 24, sz = (z + 23) % 24;
                int s = sx + 24 * (sy + 24 * sz);
                prov[x + 24 * (y + 24 * z)] = s;
                g->v[x + 24 * (y + 24 * z)] = f->v[s];
            }
    gs_mesh base;
    OK(gs_field_contour(g, 0.0, 0.0, &base));
    OK(gs_field_copy_geometry(&src, sn, prov, g, &base, 1.0, 0, &out, &st));
    assert_int_equal(out.ntris, base.ntris);
    assert_true(st.copied_vertices > 0);
    gs_mesh_destroy(&out);
    /* nothing copied: the base unchanged */
    for (int i = 0; i < 24 * 24 * 24; i++)
        prov[i] = -1;
    OK(gs_field_copy_geometry(&src, sn, prov, g, &base, 1.0, 0, &out, &st));
    assert_int_equal(st.copied_vertices, 0);
    assert_memory_equal(out.pos, base.pos, 3 * base.nverts * sizeof *base.pos);
    gs_mesh_destroy(&out);
    gs_mesh_destroy(&base);
    gs_field_destroy(&g);
    gs_free(prov);
    gs_mesh_destroy(&src);
    gs_field_destroy(&f);
}

/* The copy's room per vertex skips the walk's steps the field's slope bound
 * rules out: the same answer as every step, on a smooth field (sheets of
 * sines, many steps skipped), on two sheets 1.4 samples apart (the room
 * binds) and on noise (a large slope: few skipped), at points on and off
 * the zero level. */
static void test_copy_room_skips_exactly(void **state)
{
    (void)state;
    gs_field *f = NULL;
    OK(gs_field_create(20, 18, 16, &f));
    uint64_t r = 12345;
    for (int kind = 0; kind < 3; kind++) {
        for (int z = 0; z < 16; z++)
            for (int y = 0; y < 18; y++)
                for (int x = 0; x < 20; x++) {
                    double v;
                    r = r * 6364136223846793005ULL + 1442695040888963407ULL;
                    if (kind == 0)
                        v = 2.5 * sin(0.37 * x + 0.2 * y) * cos(0.23 * z) + 0.3;
                    else if (kind == 1)
                        v = fabs(z - 7.9) - 0.7; /* two sheets, 1.4 apart */
                    else
                        v = (double)(r >> 11) / 9007199254740992.0 * 2 - 1;
                    f->v[x + 20 * (y + 18 * z)] = (float)v;
                }
        int differ = 0, bound = 0;
        for (int i = 0; i < 400; i++) {
            double p[3];
            for (int a = 0; a < 3; a++) {
                r = r * 6364136223846793005ULL + 1442695040888963407ULL;
                p[a] = 1 + (double)(r >> 11) / 9007199254740992.0 * 13;
            }
            double fast = gs_field_copy_room(f, p, 0), ref = gs_field_copy_room(f, p, 1);
            differ += fast != ref;
            bound += ref < 2;
        }
        assert_int_equal(differ, 0);
        assert_true(bound > 20); /* the room binds often enough to matter */
    }
    gs_field_destroy(&f);
}

/* gs_field_copy_geometry_consume (the output's copy: base's triangles
 * taken, not duplicated, the provenance packed and consumed) gives the very mesh and figures of
 * gs_field_copy_geometry, on a target with seams (two halves copied at
 * different offsets) and relaxation on, and leaves base destroyed. */
static void test_copy_geometry_consume(void **state)
{
    (void)state;
    copy_case cc;
    spheres_source(&cc);
    const int64_t sn[3] = {24, 24, 24};
    gs_field *f = cc.f, *g = NULL;
    int32_t *prov = cc.prov;
    OK(gs_field_create(24, 24, 24, &g));
    for (int z = 0; z < 24; z++)
        for (int y = 0; y < 24; y++)
            for (int x = 0; x < 24; x++) {
                int k = x < 12 ? 5 : 0; /* the halves' offsets differ: seams at x = 12 */
                int sx = (x + k) % 24, sy = (y + 2 * k) % 24, sz = z;
                int s = sx + 24 * (sy + 24 * sz);
                prov[x + 24 * (y + 24 * z)] = s;
                g->v[x + 24 * (y + 24 * z)] = f->v[s];
            }
    gs_mesh base, out1, out2;
    gs_field_copy_stats st1, st2;
    OK(gs_field_contour(g, 0.0, 0.0, &base));
    OK(gs_field_copy_geometry(&cc.src, sn, prov, g, &base, 1.0, 10, &out1, &st1));
    assert_true(st1.seam_vertices > 0);
    size_t nv = base.nverts;
    gs_field_prov packed;
    OK(gs_field_prov_pack(prov, (int64_t[3]){24, 24, 24}, &packed));
    OK(gs_field_copy_geometry_consume(&cc.src, sn, &packed, g, &base, 1.0, 10, &out2, &st2));
    assert_null(packed.row); /* consumed */
    assert_null(packed.run);
    assert_int_equal(base.nverts, 0);
    assert_null(base.pos);
    assert_null(base.tris);
    assert_int_equal(out2.nverts, nv);
    assert_int_equal(out2.ntris, out1.ntris);
    assert_memory_equal(out2.tris, out1.tris, 3 * out1.ntris * sizeof *out1.tris);
    assert_memory_equal(out2.pos, out1.pos, 3 * out1.nverts * sizeof *out1.pos);
    assert_int_equal(st2.seam_vertices, st1.seam_vertices);
    assert_int_equal(st2.copied_vertices, st1.copied_vertices);
    assert_int_equal(st2.pulled_back, st1.pulled_back);
    assert_true(st2.mean_shift == st1.mean_shift);
    gs_mesh_destroy(&out1);
    gs_mesh_destroy(&out2);
    gs_field_destroy(&g);
    gs_free(prov);
    gs_mesh_destroy(&cc.src);
    gs_field_destroy(&f);
}

/* The packed provenance (the output copy's) is lossless: on a target made
 * of pieces copied along x at random offsets and lengths, some rows
 * crossing a source row's end (the run goes on: its values are consecutive),
 * stretches of -1 and of another negative value, single samples, rows of
 * one sample and a whole-row run, every sample reads back its value; the
 * runs are the pieces (counted here independently), so it is small. */
static void test_prov_pack(void **state)
{
    (void)state;
    const int64_t dims[3][3] = {{37, 5, 4}, {1, 7, 3}, {64, 3, 2}};
    uint64_t r = 99;
#define RND(m) (r = r * 6364136223846793005ULL + 1442695040888963407ULL, (int64_t)((r >> 33) % (uint64_t)(m)))
    for (int k = 0; k < 3; k++) {
        const int64_t *n = dims[k], total = n[0] * n[1] * n[2];
        int32_t *prov = gs_malloc((size_t)total * sizeof *prov);
        assert_non_null(prov);
        int64_t pieces = 0;
        for (int64_t row = 0; row < n[1] * n[2]; row++)
            for (int64_t x = 0; x < n[0]; pieces++) {
                int64_t len = 1 + RND(k == 2 && row == 0 ? 1000 : 12), kind = RND(6);
                int32_t v = kind == 0 ? -1 : kind == 1 ? -7 : (int32_t)RND(100000);
                for (int64_t i = 0; i < len && x < n[0]; i++, x++)
                    prov[x + n[0] * row] = v < 0 ? v : v + (int32_t)i;
            }
        gs_field_prov p;
        OK(gs_field_prov_pack(prov, n, &p));
        int64_t differ = 0;
        for (int64_t t = 0; t < total; t++)
            differ += gs_field_prov_at(&p, t) != prov[t];
        printf("packed provenance %lldx%lldx%lld: %lld runs (%lld pieces written), %zu bytes, "
               "%lld samples differ\n", (long long)n[0], (long long)n[1], (long long)n[2],
               (long long)p.runs, (long long)pieces, gs_field_prov_bytes(&p), (long long)differ);
        assert_int_equal(differ, 0);
        /* adjacent pieces may join (a piece going on where the last ended,
         * -1 after -1): never more runs than pieces */
        assert_true(p.runs <= pieces && p.runs >= n[1] * n[2]);
        gs_field_prov_destroy(&p);
        assert_null(p.row);
        gs_free(prov);
    }
#undef RND
    /* a whole row copied in order: one run a row */
    int32_t line[50];
    for (int i = 0; i < 50; i++)
        line[i] = 1000 + i;
    gs_field_prov p;
    OK(gs_field_prov_pack(line, (int64_t[3]){50, 1, 1}, &p));
    assert_int_equal(p.runs, 1);
    assert_int_equal(gs_field_prov_at(&p, 49), 1049);
    gs_field_prov_destroy(&p);
}

/* Height map: inside below the surface, zero crossing at h. */
static void test_heightmap(void **state)
{
    (void)state;
    gs_field *f = NULL;
    char path[4096];
    OK(gs_field_from_heightmap(gs_test_data("heightmaps/raylib-heightmap.png", path, sizeof path),
                               32, 16, 8, &f));
    assert_int_equal(f->nx, 32);
    assert_int_equal(f->ny, 32);
    assert_int_equal(f->nz, 16);
    for (int64_t y = 0; y < 32; y++)
        for (int64_t x = 0; x < 32; x++) {
            /* one sign change per column: bottom inside, top outside; |d| <= the
             * vertical distance to the surface (it is a true minimum) */
            assert_true(f->v[x + 32 * y] < 0);
            assert_true(f->v[x + 32 * (y + 32 * 15)] > 0);
            int changes = 0;
            for (int64_t z = 1; z < 16; z++)
                changes += (f->v[x + 32 * (y + 32 * z)] < 0) != (f->v[x + 32 * (y + 32 * (z - 1))] < 0);
            assert_int_equal(changes, 1);
        }
    gs_field_destroy(&f);
    assert_int_equal(gs_field_from_heightmap("/nonexistent.png", 32, 16, 8, &f), GS_ERR_IO);
    gs_error_clear();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_generators),
        cmocka_unit_test(test_chainmail_jittered_not_periodic),
        cmocka_unit_test(test_balls_no_overlap),
        cmocka_unit_test(test_copy_geometry),
        cmocka_unit_test(test_copy_room_skips_exactly),
        cmocka_unit_test(test_copy_geometry_consume),
        cmocka_unit_test(test_prov_pack),
        cmocka_unit_test(test_heightmap),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
