/* Unit tests for the JSON writer, file helpers and the run directory/summary. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/file.h"
#include "geosynth/json.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/run.h"

static void test_json_nesting_and_escapes(void **state)
{
    (void)state;
    gs_json j;
    gs_json_init(&j);
    gs_json_begin_object(&j, NULL);
    gs_json_str(&j, "s", "a\"b\\c\nd\x01");
    gs_json_f64(&j, "x", 0.1);
    gs_json_f64(&j, "nan", NAN);
    gs_json_i64(&j, "i", -42);
    gs_json_begin_array(&j, "arr");
    gs_json_u64(&j, NULL, 1);
    gs_json_bool(&j, NULL, 0);
    gs_json_begin_object(&j, NULL);
    gs_json_end_object(&j);
    gs_json_end_array(&j);
    gs_json_merge(&j, "{ \"m\": 1, \"n\": [2] }");
    gs_json_merge(&j, "{ }");
    gs_json_end_object(&j);
    assert_false(j.failed);
    assert_string_equal(j.buf, "{\"s\":\"a\\\"b\\\\c\\nd\\u0001\",\"x\":0.1,\"nan\":null,\"i\":-42,"
                               "\"arr\":[1,false,{}],\"m\": 1, \"n\": [2]}");
    gs_json_free(&j);
    /* doubles that need 17 digits keep them */
    gs_json_init(&j);
    gs_json_f64(&j, NULL, 1.0 / 3.0);
    assert_string_equal(j.buf, "0.33333333333333331");
    gs_json_free(&j);
}

static void test_file_atomic_and_read(void **state)
{
    (void)state;
    char dir[] = "/tmp/gs-test-file-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char sub[512], path[600];
    snprintf(sub, sizeof sub, "%s/a/b/c", dir);
    assert_int_equal(gs_mkdir_p(sub), GS_OK);
    assert_int_equal(gs_mkdir_p(sub), GS_OK); /* idempotent */
    snprintf(path, sizeof path, "%s/out.txt", sub);
    assert_int_equal(gs_file_write_atomic(path, "hello", 5), GS_OK);
    assert_int_equal(gs_file_write_atomic(path, "world!", 6), GS_OK);
    char *data = NULL;
    size_t len = 0;
    assert_int_equal(gs_file_read_all(path, 1 << 20, &data, &len), GS_OK);
    assert_int_equal(len, 6);
    assert_string_equal(data, "world!");
    gs_free(data);
    char tmp[620];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    assert_false(gs_file_exists(tmp));
    /* too large, missing, directory */
    data = NULL;
    assert_int_equal(gs_file_read_all(path, 3, &data, &len), GS_ERR_ARG);
    assert_null(data);
    assert_int_equal(gs_file_read_all("/nonexistent/x.ini", 100, &data, &len), GS_ERR_IO);
    assert_non_null(strstr(gs_error_message(), "/nonexistent/x.ini"));
    assert_int_equal(gs_file_read_all(sub, 100, &data, &len), GS_ERR_IO);
    /* a file where a directory is wanted */
    assert_int_equal(gs_mkdir_p(path), GS_ERR_IO);
    char *abs = NULL;
    assert_int_equal(gs_path_absolute("../x/./y.obj", "/data/configs/field", &abs), GS_OK);
    assert_string_equal(abs, "/data/configs/x/y.obj");
    gs_free(abs);
    assert_int_equal(gs_path_absolute("/a/b/../../..", NULL, &abs), GS_OK);
    assert_string_equal(abs, "/");
    gs_free(abs);
    gs_error_clear();
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

static void test_run_summary(void **state)
{
    (void)state;
    char dir[] = "/tmp/gs-test-run-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char rundir[600];
    snprintf(rundir, sizeof rundir, "%s/run1", dir);
    gs_run run;
    assert_int_equal(gs_run_open(&run, MPI_COMM_WORLD, "toy", rundir, "[run]\nseed = 5\n", 5, 0), GS_OK);
    gs_run_phase_begin(&run, "setup");
    assert_int_equal(gs_run_phase_end(&run, "{\"items\": 3}"), GS_OK);
    gs_run_phase_begin(&run, "synthesis");
    assert_int_equal(gs_run_phase_end(&run, NULL), GS_OK);
    gs_run_metric_f64(&run, "coherence", 0.25);
    gs_run_metric_i64(&run, "violations", 0);
    char obj[700];
    snprintf(obj, sizeof obj, "%s/out.obj", rundir);
    FILE *of = fopen(obj, "w");
    assert_non_null(of);
    fputs("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", of);
    fclose(of);
    gs_run_output(&run, "mesh", "surface", "out.obj", NULL);
    assert_int_equal(gs_run_finish(&run, 0x1234abcdULL), GS_OK);
    char path[700];
    char *text = NULL;
    snprintf(path, sizeof path, "%s/summary.json", rundir);
    assert_int_equal(gs_file_read_all(path, 1 << 20, &text, NULL), GS_OK);
    /* the run digest covers the engine's digest and every output file:
     * XXH3 over the engine digest, then each output's path and file digest */
    static const char objtext[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    uint64_t engine = 0x1234abcdULL, fileh = gs_digest_bytes(objtext, sizeof objtext - 1);
    gs_digest dg;
    assert_true(gs_digest_init(&dg));
    gs_digest_update(&dg, &engine, sizeof engine);
    gs_digest_update(&dg, "out.obj", 8);
    gs_digest_update(&dg, &fileh, sizeof fileh);
    char want[64], hex[17], fhex[17];
    gs_digest_hex(gs_digest_final(&dg), hex);
    gs_digest_hex(fileh, fhex);
    snprintf(want, sizeof want, "\"digest\":\"%s\"}", hex);
    assert_non_null(strstr(text, want));
    assert_non_null(strstr(text, "\"engine\":\"toy\""));
    assert_non_null(strstr(text, "\"coherence\":0.25"));
    assert_non_null(strstr(text, "\"config\":\"[run]\\nseed = 5\\n\""));
    char entry[160];
    snprintf(entry, sizeof entry, "{\"kind\":\"mesh\",\"role\":\"surface\",\"path\":\"out.obj\","
             "\"digest\":\"%s\",\"vertices\":3,\"faces\":1}", fhex);
    assert_non_null(strstr(text, entry));
    assert_non_null(strstr(text, "\"seed\":5,\"seed_string\":\"5\""));
    gs_free(text);
    snprintf(path, sizeof path, "%s/metrics.jsonl", rundir);
    assert_int_equal(gs_file_read_all(path, 1 << 20, &text, NULL), GS_OK);
    assert_non_null(strstr(text, "\"phase\":\"setup\""));
    assert_non_null(strstr(text, "\"items\": 3}\n"));
    assert_non_null(strstr(text, "\"phase\":\"synthesis\""));
    gs_free(text);
    gs_run_close(&run);
    /* unwritable output directory: clear error, not a crash */
    if (geteuid() != 0) {
        assert_int_equal(gs_run_open(&run, MPI_COMM_WORLD, "toy", "/proc/gs-no", "", 1, 0) != GS_OK, 1);
    } else {
        assert_int_not_equal(gs_run_open(&run, MPI_COMM_WORLD, "toy", "/proc/gs-no/x", "", 1, 0), GS_OK);
        assert_non_null(strstr(gs_error_message(), "/proc/gs-no"));
    }
    gs_run_close(&run);
    gs_error_clear();
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

int main(int argc, char **argv)
{
    if (gs_par_init(&argc, &argv) != GS_OK)
        return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_json_nesting_and_escapes),
        cmocka_unit_test(test_file_atomic_and_read),
        cmocka_unit_test(test_run_summary),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    gs_par_finalize();
    return rc;
}
