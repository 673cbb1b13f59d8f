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
#include <sys/stat.h>
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


/* ---- symmetry expansion, checked against the tiles' own pixels / voxels ----
 *
 * Independent of the loaders' symmetry tables: the action of a rotation or
 * mirror on an oriented tile is found by transforming its image (pixels or
 * voxels, with this file's own index formulas) and looking the result up
 * among the oriented tiles of the same name. The pair list must then be
 * closed under the generators of the group: a pair (a, b, +axis) maps to
 * (g a, g b, g axis), swapped when g axis is negative. Removing any of the
 * loaders' expansions (mxgmn's four left/right and four up/down pairs, or
 * the 3D loader's closure over the group) leaves a declared pair whose image
 * is missing for an asymmetric tile. */

static int same_base(const gs_model_tileset *ts, int a, int b)
{
    const char *sa = strrchr(ts->names[a], ' '), *sb = strrchr(ts->names[b], ' ');
    return sa - ts->names[a] == sb - ts->names[b] &&
           !strncmp(ts->names[a], ts->names[b], (size_t)(sa - ts->names[a]));
}

static int pair_present(const gs_model_tileset *ts, int dir, int a, int b)
{
    for (size_t i = 0; i < ts->npairs; i++)
        if (ts->pairs[i].dir == dir && ts->pairs[i].a == a + 1 && ts->pairs[i].b == b + 1)
            return 1;
    return 0;
}

/* g: 3x3 signed permutation (new position = g * old, centred); dir map of
 * +axis k: axis j with sign g[j][k]. act[t] = oriented tile g makes of t. */
static void check_closed(const gs_model_tileset *ts, const int *act, const int g[3][3])
{
    for (size_t i = 0; i < ts->npairs; i++) {
        int k = ts->pairs[i].dir / 2, j = 0;
        while (!g[j][k])
            j++;
        int A = act[ts->pairs[i].a - 1], B = act[ts->pairs[i].b - 1];
        int ok = g[j][k] > 0 ? pair_present(ts, 2 * j, A, B) : pair_present(ts, 2 * j, B, A);
        if (!ok)
            fail_msg("pair (%s | %s, dir %d) has no image (%s | %s) under the symmetry",
                     ts->names[ts->pairs[i].a - 1], ts->names[ts->pairs[i].b - 1],
                     ts->pairs[i].dir, ts->names[A], ts->names[B]);
    }
}

/* Voxel action of g, by this test's own index arithmetic. */
static void voxel_action(const gs_model_tileset *ts, const int g[3][3], int *act)
{
    const int s[3] = {ts->vx, ts->vy, ts->vz};
    const size_t tv = (size_t)s[0] * s[1] * s[2];
    uint8_t *img = malloc(tv);
    assert_non_null(img);
    for (int t = 0; t < ts->ntiles; t++) {
        const uint8_t *src = ts->voxels + (size_t)t * tv;
        for (int z = 0; z < s[2]; z++)
            for (int y = 0; y < s[1]; y++)
                for (int x = 0; x < s[0]; x++) {
                    int o[3] = {2 * x - (s[0] - 1), 2 * y - (s[1] - 1), 2 * z - (s[2] - 1)}, n[3];
                    for (int i = 0; i < 3; i++)
                        n[i] = (g[i][0] * o[0] + g[i][1] * o[1] + g[i][2] * o[2] + s[i] - 1) / 2;
                    img[n[0] + s[0] * (n[1] + s[1] * n[2])] = src[x + s[0] * (y + s[1] * z)];
                }
        act[t] = -1;
        for (int u = 0; u < ts->ntiles && act[t] < 0; u++)
            if (same_base(ts, t, u) && !memcmp(ts->voxels + (size_t)u * tv, img, tv))
                act[t] = u;
        if (act[t] < 0)
            fail_msg("%s turned is no orientation of its tile", ts->names[t]);
    }
    free(img);
}

static const int ROTZ[3][3] = {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}};
static const int ROTY[3][3] = {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}};
static const int MIRX[3][3] = {{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}};

static int count_orientations(const gs_model_tileset *ts, const char *name)
{
    int n = 0;
    char pre[72];
    snprintf(pre, sizeof pre, "%s ", name);
    for (int t = 0; t < ts->ntiles; t++)
        n += !strncmp(ts->names[t], pre, strlen(pre));
    return n;
}

static int tile_label(const gs_model_tileset *ts, const char *name)
{
    for (int t = 0; t < ts->ntiles; t++)
        if (!strcmp(ts->names[t], name))
            return t + 1;
    fail_msg("no tile %s", name);
    return 0;
}

static void test_knots3d_cube_symmetry(void **state)
{
    (void)state;
    GS_TEST_NEED_DATA("vox/MarkovJunior-tilesets/Knots3D.xml");
    char path[4096];
    gs_test_data("vox/MarkovJunior-tilesets/Knots3D.xml", path, sizeof path);
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    assert_int_equal(gs_model_tileset_load_any(path, NULL, "Knots3D/3", 0, &ts), GS_OK);
    assert_int_equal(ts.dim, 3);
    assert_int_equal(ts.group, 48);
    assert_int_equal(ts.vx, 3);
    /* a tube straight through: 3 axes; a turn: 12 (MarkovJunior: P = 16) */
    assert_int_equal(count_orientations(&ts, "Empty"), 1);
    assert_int_equal(count_orientations(&ts, "Line"), 3);
    assert_int_equal(count_orientations(&ts, "Turn"), 12);
    /* z pairs exist: the set is 3D */
    int z = 0;
    for (size_t i = 0; i < ts.npairs; i++)
        z += ts.pairs[i].dir == 4;
    assert_true(z > 0);
    /* the straight tube continues along its own axis: Line 0 runs along z */
    assert_true(pair_present(&ts, 4, tile_label(&ts, "Line 0") - 1, tile_label(&ts, "Line 0") - 1));
    assert_false(pair_present(&ts, 4, tile_label(&ts, "Line 0") - 1, tile_label(&ts, "Empty 0") - 1));
    int *act = malloc((size_t)ts.ntiles * sizeof *act);
    assert_non_null(act);
    const int (*gen[3])[3] = {ROTZ, ROTY, MIRX};
    for (int k = 0; k < 3; k++) {
        voxel_action(&ts, gen[k], act);
        check_closed(&ts, act, gen[k]);
    }
    free(act);
    /* the checker sees z neighbours */
    gs_model_lattice lat = {0};
    assert_int_equal(gs_model_lattice_create(&lat, 2, 2, 2), GS_OK);
    for (int i = 0; i < 8; i++)
        lat.labels[i] = (uint16_t)tile_label(&ts, "Empty 0");
    size_t n = 99;
    gs_model_violation v[4];
    assert_int_equal(gs_model_tileset_check(&ts, &lat, v, 4, &n), GS_OK);
    assert_int_equal(n, 0);
    lat.labels[0] = (uint16_t)tile_label(&ts, "Line 0"); /* a tube ending in the void above */
    assert_int_equal(gs_model_tileset_check(&ts, &lat, v, 4, &n), GS_OK);
    assert_true(n >= 1);
    /* assembled voxels: the tile's voxels at its cell */
    gs_model_lattice vox = {0};
    uint8_t pal[256][4];
    assert_int_equal(gs_model_tileset_assemble(&ts, &lat, &vox, pal), GS_OK);
    assert_int_equal(vox.nx, 6);
    assert_int_equal(vox.nz, 6);
    assert_int_equal(memcmp(pal, ts.vox_palette, sizeof pal), 0);
    for (int k = 0; k < 3; k++)
        assert_int_equal(vox.labels[gs_model_lattice_index(&vox, 1, 1, k)],
                         ts.voxels[(size_t)(tile_label(&ts, "Line 0") - 1) * 27 + 1 + 3 + 9 * k]);
    assert_true(vox.labels[gs_model_lattice_index(&vox, 1, 1, 1)] != 0);
    gs_model_lattice_destroy(&vox);
    gs_model_lattice_destroy(&lat);
    gs_model_tileset_destroy(&ts);
}

static void test_escher_cube_symmetry(void **state)
{
    (void)state;
    GS_TEST_NEED_DATA("vox/MarkovJunior-tilesets/Escher.xml");
    char path[4096];
    gs_test_data("vox/MarkovJunior-tilesets/Escher.xml", path, sizeof path);
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    assert_int_equal(gs_model_tileset_load_any(path, NULL, NULL, 0, &ts), GS_OK);
    /* MarkovJunior's own count (analysis/mj_tiles_check.py re-derives it):
     * 55 orientations, 2061 pairs */
    assert_int_equal(ts.ntiles, 55);
    assert_int_equal(ts.npairs, 2061);
    assert_int_equal(count_orientations(&ts, "Stairs"), 12);
    assert_true(ts.weight[tile_label(&ts, "Stairs 0") - 1] == 100.0);
    int *act = malloc((size_t)ts.ntiles * sizeof *act);
    assert_non_null(act);
    const int (*gen[3])[3] = {ROTZ, ROTY, MIRX};
    for (int k = 0; k < 3; k++) {
        voxel_action(&ts, gen[k], act);
        check_closed(&ts, act, gen[k]);
    }
    free(act);
    gs_model_tileset_destroy(&ts);
}

static void test_castle_json(void **state)
{
    (void)state;
    GS_TEST_NEED_DATA("vox/DeBroglie-castle/castle.json");
    char path[4096];
    gs_test_data("vox/DeBroglie-castle/castle.json", path, sizeof path);
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    assert_int_equal(gs_model_tileset_load_any(path, NULL, NULL, 0, &ts), GS_OK);
    assert_int_equal(ts.group, 8);
    assert_int_equal(ts.nbase, 14);
    /* the voxels agree with the declared tileSymmetry: X 1, E / L 4, none 8 */
    assert_int_equal(count_orientations(&ts, "ground"), 1);
    assert_int_equal(count_orientations(&ts, "wall"), 4);
    assert_int_equal(count_orientations(&ts, "turret"), 4);
    assert_int_equal(count_orientations(&ts, "wall_top_with_outer_corner"), 8);
    assert_int_equal(ts.ntiles, 48);
    int ground = tile_label(&ts, "ground 0"), empty = tile_label(&ts, "empty 0");
    assert_int_equal(ts.ground, ground);
    assert_int_equal(ts.border, empty);
    assert_int_equal(ts.border_sides & 63u, 63u);         /* all sides ... */
    assert_int_equal(ts.border_sides >> 6, 1u << 4);      /* ... but zmin */
    assert_int_equal(ts.nfixed, 1);
    assert_int_equal(ts.fixed[0][0], 5);
    assert_int_equal(ts.fixed[0][1], 4);
    assert_int_equal(ts.fixed[0][2], 8);
    assert_int_equal(ts.fixed[0][3], tile_label(&ts, "turret_top 0"));
    /* ground is banned above the bottom layer: nothing lies under it */
    for (size_t i = 0; i < ts.npairs; i++)
        assert_false(ts.pairs[i].dir == 4 && ts.pairs[i].b == ground);
    /* the listed exceptions: every wall orientation on the ground, and a turret
     * on an outer corner in the same orientation (not from the faces) */
    for (int k = 0; k < 4; k++) {
        char nm[72];
        snprintf(nm, sizeof nm, "wall_outer_corner %d", k);
        assert_true(pair_present(&ts, 4, ground - 1, tile_label(&ts, nm) - 1));
    }
    assert_true(pair_present(&ts, 4, tile_label(&ts, "wall_outer_corner 0") - 1,
                             tile_label(&ts, "turret 0") - 1));
    int *act = malloc((size_t)ts.ntiles * sizeof *act);
    assert_non_null(act);
    const int (*gen[2])[3] = {ROTZ, MIRX};
    for (int k = 0; k < 2; k++) {
        voxel_action(&ts, gen[k], act);
        check_closed(&ts, act, gen[k]);
    }
    free(act);
    /* pins: border cells empty except on the bottom, the turret top fixed */
    int dims[3] = {10, 10, 10};
    uint16_t *pins = malloc(1000 * sizeof *pins);
    assert_non_null(pins);
    for (int i = 0; i < 1000; i++)
        pins[i] = GS_MODEL_FREE;
    assert_int_equal(gs_model_tileset_pins(&ts, path, dims, 1, pins), GS_OK);
    assert_int_equal(pins[0 + 10 * 5 + 100 * 5], empty);      /* x = 0 face */
    assert_int_equal(pins[5 + 10 * 5 + 100 * 5], GS_MODEL_FREE);
    assert_int_equal(pins[0 + 10 * 5 + 100 * 0], GS_MODEL_FREE); /* zmin: the ground layer */
    assert_int_equal(pins[5 + 10 * 4 + 100 * 8], tile_label(&ts, "turret_top 0"));
    int small[3] = {4, 4, 10};
    assert_int_not_equal(gs_model_tileset_pins(&ts, path, small, 1, pins), GS_OK);
    assert_non_null(strstr(gs_error_message(), "fixedTile"));
    gs_error_clear();
    free(pins);
    gs_model_tileset_destroy(&ts);
}

/* A 2D tile set written here: tiles of every symmetry class with images that
 * have exactly that symmetry (F has none), neighbours including F. */
static void write_tile_png(const char *path, const char *pattern, uint8_t r, uint8_t g)
{
    gs_image img;
    assert_int_equal(gs_image_alloc(&img, 4, 4, 4, 8), GS_OK);
    for (int i = 0; i < 16; i++) {
        int on = pattern[i] == '#';
        uint8_t px[4] = {on ? r : 0, on ? g : 0, on ? 200 : 0, 255};
        memcpy(img.data8 + 4 * i, px, 4);
    }
    assert_int_equal(gs_image_write_png(path, &img), GS_OK);
    gs_image_destroy(&img);
}

static void test_2d_expansion_against_images(void **state)
{
    (void)state;
    char dir[128], xml[160], png[200];
    snprintf(dir, sizeof dir, "/tmp/gs_tiles2d_%ld", (long)getpid());
    snprintf(xml, sizeof xml, "%s.xml", dir);
    assert_int_equal(mkdir(dir, 0700), 0);
    static const struct { const char *name, *sym, *pat; } T[] = {
        {"e", "X", "................"},
        {"bar", "I", ".##..##..##..##."},      /* vertical bar: left-right mirror */
        {"tee", "T", "####.##..##..##."},      /* top row + bar: left-right mirror */
        {"ell", "L", "####...#...#...#"},      /* top row + right column */
        {"eff", "F", "##.............."}};     /* domino in a corner: no symmetry */
    for (int i = 0; i < 5; i++) {
        snprintf(png, sizeof png, "%s/%s.png", dir, T[i].name);
        write_tile_png(png, T[i].pat, (uint8_t)(40 * i + 40), (uint8_t)(200 - 30 * i));
    }
    FILE *f = fopen(xml, "w");
    assert_non_null(f);
    fprintf(f, "<set>\n<tiles>\n");
    for (int i = 0; i < 5; i++)
        fprintf(f, "<tile name=\"%s\" symmetry=\"%s\"/>\n", T[i].name, T[i].sym);
    fprintf(f, "</tiles>\n<neighbors>\n"
               "<neighbor left=\"eff\" right=\"e\"/>\n"
               "<neighbor left=\"eff 5\" right=\"ell 1\"/>\n"
               "<neighbor left=\"tee 3\" right=\"eff 2\"/>\n"
               "<neighbor left=\"bar\" right=\"eff 7\"/>\n"
               "</neighbors>\n</set>\n");
    fclose(f);
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    assert_int_equal(gs_model_tileset_load(xml, NULL, 1, &ts), GS_OK);
    assert_int_equal(ts.ntiles, 1 + 2 + 4 + 4 + 8);
    /* pixel action of the 90-degree turn and the left-right mirror, found by
     * image content (x = column, y = row, +y down as the lattice) */
    const int S = 4;
    const size_t tb = (size_t)S * S * 4;
    uint8_t *img = malloc(tb);
    int *act = malloc((size_t)ts.ntiles * sizeof *act);
    assert_non_null(img);
    assert_non_null(act);
    /* rot: (x, y) -> (S-1-y, x): +x -> +y; mirror: (x, y) -> (S-1-x, y) */
    static const int G[2][3][3] = {{{0, -1, 0}, {1, 0, 0}, {0, 0, 1}}, {{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    for (int k = 0; k < 2; k++) {
        for (int t = 0; t < ts.ntiles; t++) {
            const uint8_t *src = ts.pixels + (size_t)t * tb;
            for (int y = 0; y < S; y++)
                for (int x = 0; x < S; x++) {
                    int nx = k == 0 ? S - 1 - y : S - 1 - x, ny = k == 0 ? x : y;
                    memcpy(img + ((size_t)ny * S + (size_t)nx) * 4, src + ((size_t)y * S + (size_t)x) * 4, 4);
                }
            act[t] = -1;
            for (int u = 0; u < ts.ntiles && act[t] < 0; u++)
                if (same_base(&ts, t, u) && !memcmp(ts.pixels + (size_t)u * tb, img, tb))
                    act[t] = u;
            if (act[t] < 0)
                fail_msg("%s turned is no orientation of its tile", ts.names[t]);
        }
        check_closed(&ts, act, G[k]);
    }
    /* every orientation of F is a distinct picture, and each declared pair
     * is there as written */
    assert_true(pair_present(&ts, 0, tile_label(&ts, "eff 0") - 1, tile_label(&ts, "e 0") - 1));
    free(act);
    free(img);
    gs_model_tileset_destroy(&ts);
    for (int i = 0; i < 5; i++) {
        snprintf(png, sizeof png, "%s/%s.png", dir, T[i].name);
        remove(png);
    }
    rmdir(dir);
    remove(xml);
}

static void test_3d_errors(void **state)
{
    (void)state;
    char path[128];
    snprintf(path, sizeof path, "/tmp/gs_tiles3d_%ld.json", (long)getpid());
    static const struct { const char *text, *want; } C[] = {
        {"{\"srcType\": \"bitmapSet\", \"tiles\": []}", "expected \"voxSet\""},
        {"{\"srcType\": \"voxSet\",\n \"tiles\": [\n {\"src\": \"none.vox\", \"value\": \"a\"}]}",
         "none.vox"},
        {"{\"srcType\": \"voxSet\", \"symmetry\": 3, \"tiles\": []}", "expected 1, 2, 4 or 8"},
        {"{\"srcType\": \"voxSet\",\n \"tiles\": [\n", ":3: end of file inside an array"},
        {"// c\n{\"srcType\": \"voxSet\", /* x */ \"tiles\": [], }", "\"tiles\" is empty"},
    };
    for (size_t i = 0; i < sizeof C / sizeof C[0]; i++) {
        FILE *f = fopen(path, "w");
        assert_non_null(f);
        fputs(C[i].text, f);
        fclose(f);
        gs_model_tileset ts;
        memset(&ts, 0, sizeof ts);
        assert_int_not_equal(gs_model_tileset_load_any(path, NULL, NULL, 0, &ts), GS_OK);
        const char *msg = gs_error_message();
        if (!strstr(msg, C[i].want))
            fail_msg("case %zu: error '%s' lacks '%s'", i, msg, C[i].want);
        assert_int_equal(ts.ntiles, 0);
        gs_error_clear();
    }
    remove(path);
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
        cmocka_unit_test(test_knots3d_cube_symmetry),
        cmocka_unit_test(test_escher_cube_symmetry),
        cmocka_unit_test(test_castle_json),
        cmocka_unit_test(test_2d_expansion_against_images),
        cmocka_unit_test(test_3d_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
