/* Unit tests for the model engine's WFC inputs (model_tiles.h): tile set
 * parsing and mxgmn's symmetry expansion, XML errors with file and line,
 * rules from pairs, the tile-set checker, overlapping patterns. Runs from
 * tests/. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "../util/testutil.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/error.h"
#include "geosynth/image.h"
#include "geosynth/mem.h"
#include "geosynth/model.h"
#include "geosynth/model_tiles.h"

/* mxgmn's WaveFunctionCollapse tile sets and samples (fetched by `make
 * data`; the tests that read them skip without them). */
#define WFC "wfc/mxgmn-WaveFunctionCollapse/"
static const char *wfc(const char *rel)
{
    static char path[4096], full[512];
    snprintf(full, sizeof full, WFC "%s", rel);
    return gs_test_data(full, path, sizeof path);
}

static int has_pair(const gs_model_tileset *ts, int dir, const char *a, const char *b)
{
    int la = 0, lb = 0;
    for (int t = 0; t < ts->ntiles; t++) {
        if (!strcmp(ts->names[t], a))
            la = t + 1;
        if (!strcmp(ts->names[t], b))
            lb = t + 1;
    }
    assert_true(la > 0 && lb > 0);
    for (size_t i = 0; i < ts->npairs; i++)
        if (ts->pairs[i].dir == dir && ts->pairs[i].a == la && ts->pairs[i].b == lb)
            return 1;
    return 0;
}

static void test_knots_expansion(void **state)
{
    (void)state;
    GS_TEST_NEED_DATA(WFC "tilesets/Knots.xml");
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    assert_int_equal(gs_model_tileset_load(wfc("tilesets/Knots.xml"), "Standard", 1, &ts), GS_OK);
    /* corner L 4 + cross I 2 + empty X 1 + line I 2 = 9 (t is not in Standard) */
    assert_int_equal(ts.ntiles, 9);
    assert_string_equal(ts.names[0], "corner 0");
    assert_string_equal(ts.names[6], "empty 0");
    assert_int_equal(ts.tile_w, 10);
    /* "corner 1" left of "empty" (XML line 10) */
    assert_true(has_pair(&ts, 0, "corner 1", "empty 0"));
    /* pairs are expanded by symmetry: rotating "corner 1 | empty" by 90
     * degrees puts empty below/above the turned corner */
    assert_true(has_pair(&ts, 2, "empty 0", "corner 2") || has_pair(&ts, 2, "corner 2", "empty 0"));
    /* not listed in any orientation: empty next to a line end-on */
    assert_false(has_pair(&ts, 0, "empty 0", "line 0") && has_pair(&ts, 0, "empty 0", "line 1"));
    /* rules: every pair allowed in both orders */
    gs_model_rules_t r = NULL;
    assert_int_equal(gs_model_tileset_rules(&ts, &r), GS_OK);
    for (size_t i = 0; i < ts.npairs; i++) {
        assert_true(gs_model_rules_allows(r, ts.pairs[i].dir, ts.pairs[i].a, ts.pairs[i].b));
        assert_true(gs_model_rules_allows(r, ts.pairs[i].dir ^ 1, ts.pairs[i].b, ts.pairs[i].a));
    }
    /* the checker on a uniform empty layer (empty next to empty is allowed) and
     * after putting a corner that ends in the void */
    gs_model_lattice lat = {0};
    assert_int_equal(gs_model_lattice_create(&lat, 4, 4, 1), GS_OK);
    for (int i = 0; i < 16; i++)
        lat.labels[i] = 7;
    size_t n = 99;
    gs_model_violation v[4];
    assert_int_equal(gs_model_tileset_check(&ts, &lat, v, 4, &n), GS_OK);
    assert_int_equal(n, 0);
    lat.labels[5] = 1; /* corner 0: lines to the top and right */
    assert_int_equal(gs_model_tileset_check(&ts, &lat, v, 4, &n), GS_OK);
    assert_true(n >= 2);
    assert_int_equal(gs_model_rules_violations(r, &lat) > 0, 1);
    lat.labels[0] = 200;
    assert_int_equal(gs_model_tileset_check(&ts, &lat, v, 4, &n), GS_OK);
    assert_int_equal(v[0].dir, -1);
    gs_model_lattice_destroy(&lat);
    gs_model_rules_destroy(&r);
    gs_model_tileset_destroy(&ts);
}

static void test_counts_of_every_tileset(void **state)
{
    (void)state;
    GS_TEST_NEED_DATA(WFC "tilesets/Knots.xml", WFC "tilesets/Rooms.xml", WFC "tilesets/Circuit.xml",
                      WFC "tilesets/Summer.xml", WFC "tilesets/Castle.xml");
    static const struct {
        const char *file, *subset;
        int tiles;
    } cases[] = {
        {"tilesets/Knots.xml", "", 13},       /* + t (T, 4) */
        {"tilesets/Rooms.xml", "", 28},
        {"tilesets/Circuit.xml", "Turnless", 36},
        {"tilesets/Summer.xml", "", 40},
        {"tilesets/Castle.xml", "", 29},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        gs_model_tileset ts;
        memset(&ts, 0, sizeof ts);
        assert_int_equal(gs_model_tileset_load(wfc(cases[i].file), cases[i].subset, 0, &ts), GS_OK);
        assert_int_equal(ts.ntiles, cases[i].tiles);
        assert_true(ts.npairs > 0);
        assert_null(ts.pixels);
        gs_model_tileset_destroy(&ts);
    }
}

static void expect_xml_error(const char *text, const char *want)
{
    char path[128];
    snprintf(path, sizeof path, "/tmp/gs_tiles_%ld.xml", (long)getpid());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    gs_err e = gs_model_tileset_load(path, NULL, 0, &ts);
    assert_int_not_equal(e, GS_OK);
    const char *msg = gs_error_message();
    if (!strstr(msg, want))
        fail_msg("error '%s' lacks '%s'", msg, want);
    assert_non_null(strstr(msg, path));
    assert_int_equal(ts.ntiles, 0);
    gs_error_clear();
    remove(path);
}

static void test_xml_errors(void **state)
{
    (void)state;
    expect_xml_error("<set>\n<tiles>\n<tile name=\"a\"/>\n</tiles>\n<neighbors>\n"
                     "<neighbor left=\"a\" right=\"b\"/>\n</neighbors>\n</set>\n",
                     ":6: right=\"b\": no tile named 'b'");
    expect_xml_error("<set>\n<tiles>\n<tile name=\"a\" symmetry=\"Z\"/>\n</tiles>\n</set>\n",
                     ":3: tile a: symmetry=\"Z\"");
    expect_xml_error("<set>\n<tiles>\n<tile name=\"a\">\n</tiles>\n</set>\n",
                     ":4: closing tag </tiles> does not match the open <tile> (line 3)");
    expect_xml_error("<set>\n<tiles>\n<tile name=\"a\" weight=\"x\"/>\n</tiles>\n</set>\n",
                     ":3: tile a: weight=\"x\"");
    expect_xml_error("<set>\n<tiles>\n<tile name=\"a b\"/>\n</tiles>\n</set>\n", ":3: <tile> needs name");
    expect_xml_error("<set>\n<!-- open\n", ":2: comment '<!--' is never closed");
    expect_xml_error("<set>\n<tiles>\n<tile name=\"a\"/>\n</tiles>\n", "end of file inside <set>");
    expect_xml_error("<set>\n<tiles>\n<tile name=\"a\"/>\n</tiles>\n<neighbors>\n"
                     "<neighbor left=\"a 9\" right=\"a\"/>\n</neighbors>\n</set>\n",
                     ":6: left=\"a 9\": orientation");
    expect_xml_error("<set>\n<tiles>\n<tile name=\"a\"/>\n</tiles>\n</set>\n",
                     "no <neighbor> pair between kept tiles");
}

static void test_overlapping_knot(void **state)
{
    (void)state;
    GS_TEST_NEED_DATA(WFC "samples/Knot.png");
    gs_model_patterns p;
    memset(&p, 0, sizeof p);
    assert_int_equal(gs_model_patterns_learn(wfc("samples/Knot.png"), 3, 8, 1, &p), GS_OK);
    assert_true(p.npatterns > 1 && p.ncolors >= 2);
    /* every listed pair agrees on its overlap per the independent checker */
    gs_model_lattice lat = {0};
    assert_int_equal(gs_model_lattice_create(&lat, 2, 1, 1), GS_OK);
    for (size_t i = 0; i < p.npairs; i++) {
        if (p.pairs[i].dir != 0)
            continue;
        lat.labels[0] = p.pairs[i].a;
        lat.labels[1] = p.pairs[i].b;
        size_t n = 9;
        assert_int_equal(gs_model_patterns_check(&p, &lat, &n), GS_OK);
        assert_int_equal(n, 0);
    }
    /* symmetry 1 gives no more patterns than symmetry 8 */
    gs_model_patterns q;
    memset(&q, 0, sizeof q);
    assert_int_equal(gs_model_patterns_learn(wfc("samples/Knot.png"), 3, 1, 1, &q), GS_OK);
    assert_true(q.npatterns <= p.npatterns);
    uint64_t total = 0;
    for (int i = 0; i < q.npatterns; i++)
        total += q.count[i];
    gs_image img;
    assert_int_equal(gs_image_read(wfc("samples/Knot.png"), &img), GS_OK);
    /* periodic input: one window per pixel, each counted once */
    assert_int_equal(total, (uint64_t)img.width * (uint64_t)img.height);
    gs_image_destroy(&img);
    gs_model_patterns_destroy(&q);
    gs_model_lattice_destroy(&lat);
    gs_model_patterns_destroy(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_knots_expansion),
        cmocka_unit_test(test_counts_of_every_tileset),
        cmocka_unit_test(test_xml_errors),
        cmocka_unit_test(test_overlapping_knot),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
