/* Unit tests for DeBroglie's CSV lattices (src/model/csv.c): the reading
 * order (column x, row y, blank-line-separated layers z), blank lines and
 * CRLF, located errors, format detection by gs_model_load, the repository's
 * parliament.csv and escheresque.csv, and (with `make data`) that they are
 * Merrell's .txt lattices with x and y swapped. Runs from tests/. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "../util/testutil.h"
#include <stdio.h>
#include <string.h>

#include "geosynth/error.h"
#include "geosynth/model.h"
#include "geosynth/model_io.h"

static uint16_t at(const gs_model_lattice *l, int x, int y, int z)
{
    return l->labels[gs_model_lattice_index(l, x, y, z)];
}

/* c is t with x and y swapped. */
static void assert_swapped(const gs_model_lattice *c, const gs_model_lattice *t)
{
    assert_true(c->nx == t->ny && c->ny == t->nx && c->nz == t->nz);
    for (int z = 0; z < c->nz; z++)
        for (int y = 0; y < c->ny; y++)
            for (int x = 0; x < c->nx; x++)
                assert_int_equal(at(c, x, y, z), at(t, y, x, z));
}

static void test_order_blank_lines_crlf(void **state)
{
    (void)state;
    /* 3 columns (x), 2 rows (y), 2 layers (z); a leading blank line, CRLF,
     * blanks around labels, two blank lines between layers, one at the end */
    const char *text = "\r\n1, 2,3\r\n4,5 ,6\r\n\r\n \t\n10,20,30\n40,50,60\n\n";
    gs_model_lattice l = {0};
    assert_int_equal(gs_model_parse_debroglie_csv(text, strlen(text), "t.csv", &l), GS_OK);
    assert_int_equal(l.nx, 3);
    assert_int_equal(l.ny, 2);
    assert_int_equal(l.nz, 2);
    assert_int_equal(at(&l, 0, 0, 0), 1);
    assert_int_equal(at(&l, 2, 0, 0), 3);
    assert_int_equal(at(&l, 0, 1, 0), 4);
    assert_int_equal(at(&l, 1, 1, 0), 5);
    assert_int_equal(at(&l, 2, 1, 1), 60);
    assert_int_equal(at(&l, 1, 0, 1), 20);
    gs_model_lattice_destroy(&l);
    /* one layer, one row */
    assert_int_equal(gs_model_parse_debroglie_csv("7", 1, "one.csv", &l), GS_OK);
    assert_true(l.nx == 1 && l.ny == 1 && l.nz == 1 && l.labels[0] == 7);
    gs_model_lattice_destroy(&l);
}

/* The same integers as a Merrell .txt (z, then x, then y innermost) are his
 * lattice with x and y swapped. */
static void test_same_integers_as_merrell_txt_swapped(void **state)
{
    (void)state;
    const char *csv = "1,2,3\n4,5,6\n\n7,8,9\n10,11,12\n";
    const char *txt = "h\nh\nh\n2 3 2\n1 2 3\n4 5 6\n7 8 9\n10 11 12\n";
    gs_model_lattice c = {0}, t = {0};
    assert_int_equal(gs_model_parse_debroglie_csv(csv, strlen(csv), "s.csv", &c), GS_OK);
    assert_int_equal(gs_model_parse_merrell_txt(txt, strlen(txt), "s.txt", &t), GS_OK);
    assert_swapped(&c, &t);
    gs_model_lattice_destroy(&c);
    gs_model_lattice_destroy(&t);
}

static void expect_error(const char *text, const char *want)
{
    gs_model_lattice l = {0};
    gs_err e = gs_model_parse_debroglie_csv(text, strlen(text), "bad.csv", &l);
    assert_int_equal(e, GS_ERR_FORMAT);
    const char *msg = gs_error_message();
    if (!strstr(msg, want))
        fail_msg("message '%s' lacks '%s'", msg, want);
    assert_null(l.labels);
    gs_error_clear();
}

static void test_errors(void **state)
{
    (void)state;
    expect_error("1,2,3\n4,5\n", "bad.csv:2: row has 2 comma-separated labels, but the first row (line 1) has 3");
    expect_error("1,2\n3,4\n\n5,6\n", "bad.csv:4: layer 2 has 1 rows, but the first layer (line 1) has 2");
    expect_error("1,2\n3,a\n", "bad.csv:2: field 2: expected a label in [0, 65535], got 'a'");
    expect_error("1,70000\n", "bad.csv:1: field 2: expected a label in [0, 65535], got '70000'");
    expect_error("1,,2\n", "bad.csv:1: field 2: expected a label in [0, 65535], got ''");
    expect_error("1,2,\n", "bad.csv:1: field 3: expected a label");
    expect_error("\n \n", "bad.csv: no labels");
    expect_error("", "bad.csv: no labels");
    gs_model_lattice l = {0};
    assert_int_equal(gs_model_parse_debroglie_csv("1\0" "2", 3, "nul.csv", &l), GS_ERR_FORMAT);
    assert_non_null(strstr(gs_error_message(), "NUL"));
    gs_error_clear();
    /* a missing file through the loader names it */
    assert_int_equal(gs_model_load("/nonexistent/x.csv", "auto", NULL, &l, NULL), GS_ERR_IO);
    assert_non_null(strstr(gs_error_message(), "/nonexistent/x.csv"));
    gs_error_clear();
}

/* The repository's copies: sizes, ground and empty labels; the loader picks
 * the format from the name (any case). */
static void test_repository_samples(void **state)
{
    (void)state;
    assert_string_equal(gs_model_format_of("a/B.CSV"), "csv");
    static const struct {
        const char *file;
        int nx, ny, nz;
    } cases[] = {
        {"model-synthesis/debroglie-samples-merrell/parliament.csv", 40, 20, 8},
        {"model-synthesis/debroglie-samples-merrell/escheresque.csv", 43, 30, 9},
    };
    for (size_t i = 0; i < 2; i++) {
        char path[4096];
        gs_model_lattice l = {0};
        assert_int_equal(gs_model_load(gs_test_data(cases[i].file, path, sizeof path), "auto",
                                       NULL, &l, NULL),
                         GS_OK);
        assert_int_equal(l.nx, cases[i].nx);
        assert_int_equal(l.ny, cases[i].ny);
        assert_int_equal(l.nz, cases[i].nz);
        size_t empty = 0, n = (size_t)l.nx * l.ny * l.nz;
        for (size_t k = 0; k < n; k++)
            empty += l.labels[k] == 0;
        printf("%s: %dx%dx%d, %zu of %zu cells empty\n", cases[i].file, l.nx, l.ny, l.nz, empty, n);
        assert_true(empty > n / 4 && empty < n); /* label 0 = air above the model */
        gs_model_lattice_destroy(&l);
    }
    /* parliament's ground: label 11 fills the bottom layer (DeBroglie's config
     * pins tile 11 on zmin) */
    char path[4096];
    gs_model_lattice l = {0};
    assert_int_equal(gs_model_read_debroglie_csv(gs_test_data(cases[0].file, path, sizeof path), &l),
                     GS_OK);
    for (int y = 0; y < l.ny; y++)
        for (int x = 0; x < l.nx; x++)
            assert_int_equal(at(&l, x, y, 0), 11);
    gs_model_lattice_destroy(&l);
}

/* With `make data`: DeBroglie's CSVs are Merrell's .txt lattices, x and y swapped. */
static void test_equal_to_merrell_txt_swapped(void **state)
{
    (void)state;
    static const char *names[] = {"parliament", "escheresque"};
    GS_TEST_NEED_DATA("model-synthesis/merrell42-model-synthesis/samples/parliament.txt",
                      "model-synthesis/merrell42-model-synthesis/samples/escheresque.txt");
    for (int i = 0; i < 2; i++) {
        char rel[256], path[4096];
        gs_model_lattice c = {0}, t = {0};
        snprintf(rel, sizeof rel, "model-synthesis/debroglie-samples-merrell/%s.csv", names[i]);
        assert_int_equal(gs_model_read_debroglie_csv(gs_test_data(rel, path, sizeof path), &c),
                         GS_OK);
        snprintf(rel, sizeof rel, "model-synthesis/merrell42-model-synthesis/samples/%s.txt",
                 names[i]);
        assert_int_equal(gs_model_read_merrell_txt(gs_test_data(rel, path, sizeof path), &t), GS_OK);
        assert_swapped(&c, &t);
        gs_model_lattice_destroy(&c);
        gs_model_lattice_destroy(&t);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_order_blank_lines_crlf),
        cmocka_unit_test(test_same_integers_as_merrell_txt_swapped),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_repository_samples),
        cmocka_unit_test(test_equal_to_merrell_txt_swapped),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
