/* Unit tests for src/core: errors, parsing, RNG, digests, memory. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/error.h"
#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "geosynth/rng.h"
#include "geosynth/sort.h"

static gs_err inner(int v)
{
    GS_CHECK(v > 0, GS_ERR_ARG, "value %d must be > 0", v);
    return GS_OK;
}

static gs_err outer(int v)
{
    GS_CALL(inner(v));
    return GS_OK;
}

static void test_error_traceback(void **state)
{
    (void)state;
    gs_error_clear();
    assert_int_equal(outer(1), GS_OK);
    assert_int_equal(outer(-3), GS_ERR_ARG);
    assert_int_equal(gs_error_code(), GS_ERR_ARG);
    assert_string_equal(gs_error_message(), "value -3 must be > 0");
    gs_error_add_context("while reading %s", "x.ini");
    assert_non_null(strstr(gs_error_message(), "(while reading x.ini)"));
    gs_error_clear();
    assert_int_equal(gs_error_code(), GS_OK);
}

static void test_parse_numbers(void **state)
{
    (void)state;
    int64_t i = 7;
    char why[128];
    assert_true(gs_parse_i64(" 42 ", 0, 100, &i, why, sizeof why));
    assert_int_equal(i, 42);
    assert_false(gs_parse_i64("12x", 0, 100, &i, why, sizeof why));
    assert_int_equal(i, 42); /* unchanged on failure */
    assert_non_null(strstr(why, "'12x'"));
    assert_false(gs_parse_i64("101", 0, 100, &i, why, sizeof why));
    assert_non_null(strstr(why, "out of range"));
    assert_false(gs_parse_i64("99999999999999999999999", INT64_MIN, INT64_MAX, &i, why, sizeof why));
    assert_false(gs_parse_i64("", 0, 100, &i, why, sizeof why));
    uint64_t u;
    assert_false(gs_parse_u64("-1", 0, 10, &u, why, sizeof why));
    assert_true(gs_parse_u64("18446744073709551615", 0, UINT64_MAX, &u, why, sizeof why));
    assert_true(u == UINT64_MAX);
    double d = 0;
    assert_true(gs_parse_f64("2.5e-1", 0, 1, &d, why, sizeof why));
    assert_true(d == 0.25);
    assert_false(gs_parse_f64("nan", -1e300, 1e300, &d, why, sizeof why));
    assert_false(gs_parse_f64("inf", -1e300, 1e300, &d, why, sizeof why));
    assert_false(gs_parse_f64("1e999", -1e300, 1e300, &d, why, sizeof why));
    int b = -1;
    assert_true(gs_parse_bool("Yes", &b, why, sizeof why));
    assert_int_equal(b, 1);
    assert_true(gs_parse_bool("off", &b, why, sizeof why));
    assert_int_equal(b, 0);
    assert_false(gs_parse_bool("maybe", &b, why, sizeof why));
    const char *p = "12 -5 x";
    int64_t a;
    assert_true(gs_scan_i64(&p, -100, 100, &a));
    assert_int_equal(a, 12);
    p++;
    assert_true(gs_scan_i64(&p, -100, 100, &a));
    assert_int_equal(a, -5);
    p++;
    assert_false(gs_scan_i64(&p, -100, 100, &a));
}

static void test_rng_streams(void **state)
{
    (void)state;
    gs_rng a, b, c;
    gs_rng_init(&a, 1234, 7);
    gs_rng_init(&b, 1234, 7);
    gs_rng_init(&c, 1234, 8);
    int same_c = 0;
    for (int i = 0; i < 1000; i++) {
        uint32_t x = gs_rng_u32(&a), y = gs_rng_u32(&b), z = gs_rng_u32(&c);
        assert_int_equal(x, y);
        same_c += x == z;
    }
    assert_true(same_c < 3);
    /* save/restore mid-block resumes the exact sequence */
    gs_rng_init(&a, 99, 1);
    for (int i = 0; i < 5; i++)
        gs_rng_u32(&a);
    gs_rng_state s = gs_rng_save(&a);
    uint32_t expect[9];
    for (int i = 0; i < 9; i++)
        expect[i] = gs_rng_u32(&a);
    gs_rng_restore(&b, s);
    for (int i = 0; i < 9; i++)
        assert_int_equal(gs_rng_u32(&b), expect[i]);
    /* uniform in [0,1), below() in range with a sane mean */
    double sum = 0;
    for (int i = 0; i < 100000; i++) {
        double u = gs_rng_uniform(&a);
        assert_true(u >= 0.0 && u < 1.0);
        sum += u;
        uint64_t k = gs_rng_below(&a, 7);
        assert_true(k < 7);
    }
    assert_true(sum / 100000 > 0.49 && sum / 100000 < 0.51);
    assert_true(gs_rng_stream_id(1, 2, 3, 4) != gs_rng_stream_id(1, 2, 4, 3));
}

static void test_digest(void **state)
{
    (void)state;
    float v[1000];
    for (int i = 0; i < 1000; i++)
        v[i] = (float)i * 0.5f;
    uint64_t h1 = gs_digest_bytes(v, sizeof v);
    gs_digest d;
    assert_true(gs_digest_init(&d));
    gs_digest_update(&d, v, 400 * sizeof(float));
    gs_digest_update(&d, v + 400, 600 * sizeof(float));
    assert_true(gs_digest_final(&d) == h1);
    v[999] = 1.0f;
    assert_true(gs_digest_bytes(v, sizeof v) != h1);
    char hex[17];
    gs_digest_hex(0x00ff00ff00ff00ffULL, hex);
    assert_string_equal(hex, "00ff00ff00ff00ff");
}

static void test_memory_accounting(void **state)
{
    (void)state;
    size_t before = gs_mem_current();
    void *p = gs_malloc(1 << 20);
    assert_non_null(p);
    assert_true(gs_mem_current() == before + (1 << 20));
    assert_true(gs_mem_peak() >= before + (1 << 20));
    p = gs_realloc(p, 2 << 20);
    assert_true(gs_mem_current() == before + (2 << 20));
    gs_free(p);
    assert_true(gs_mem_current() == before);
    void *q = NULL;
    assert_int_equal(gs_alloc_array(&q, SIZE_MAX / 2, 4, "huge lattice"), GS_ERR_MEM);
    assert_null(q);
    assert_non_null(strstr(gs_error_message(), "huge lattice"));
    gs_error_clear();
}

/* XML (XDMF names) and HTML (gallery config text) share one escaper. */
static void test_markup_escape(void **state)
{
    (void)state;
    const char *in = "a<b>&\"q'\n\tz\x01";
    const char *want[2] = {"a&lt;b&gt;&amp;&quot;q&apos;__z_", "a&lt;b&gt;&amp;&quot;q&apos;\n\tz_"};
    for (int keep = 0; keep < 2; keep++) {
        char buf[128] = {0};
        FILE *f = fmemopen(buf, sizeof buf - 1, "w");
        assert_non_null(f);
        gs_fput_markup(f, in, keep);
        fclose(f);
        assert_string_equal(buf, want[keep]);
    }
}

/* The shared sorts: ascending, duplicates and both zeros kept, every value
 * still there (the engines' and measures' percentiles and medians use them). */
static void test_sorts(void **state)
{
    (void)state;
    double d[9] = {3.5, -1.0, 0.0, 2.0, -0.0, 3.5, -7.25, 1e300, -1e-300};
    double dsum = 0.0, dsum2 = 0.0;
    for (int i = 0; i < 9; i++)
        dsum += d[i] == 1e300 ? 0.0 : d[i];
    gs_sort_f64(d, 9);
    for (int i = 0; i < 9; i++) {
        if (i > 0)
            assert_true(d[i - 1] <= d[i]);
        dsum2 += d[i] == 1e300 ? 0.0 : d[i];
    }
    assert_true(d[0] == -7.25 && d[8] == 1e300 && d[6] == 3.5 && d[7] == 3.5);
    assert_true(dsum == dsum2);
    uint64_t u[7] = {UINT64_MAX, 5, 0, 5, (uint64_t)1 << 63, 1, 2};
    const uint64_t uw[7] = {0, 1, 2, 5, 5, (uint64_t)1 << 63, UINT64_MAX};
    gs_sort_u64(u, 7);
    assert_memory_equal(u, uw, sizeof uw);
    gs_sort_f64(NULL, 0);
    gs_sort_u64(u, 1);
    assert_true(u[0] == 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_error_traceback),  cmocka_unit_test(test_parse_numbers),
        cmocka_unit_test(test_rng_streams),      cmocka_unit_test(test_digest),
        cmocka_unit_test(test_memory_accounting), cmocka_unit_test(test_markup_escape),
        cmocka_unit_test(test_sorts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
