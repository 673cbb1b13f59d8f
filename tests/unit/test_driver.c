/* Unit tests of the run driver (src/run/driver.c) with a toy engine whose
 * operations record how they were called: the order of the lifecycle, the
 * checkpoint cadence by units (never after the advance that finishes), a
 * stop by the GS_STOP_AFTER_UNITS hook (checkpoint, then exit 9's error),
 * restore only on resume, a failing operation (no output, destroy still
 * called, the error returned) and the summary's digest. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/engine.h"
#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/run.h"

enum { TOTAL = 10 };

typedef struct toy_log {
    char calls[512];      /* one letter per call: S setup, R restore, A advance, C save,
                           * Y synthesis report, F finish, O output, D destroy */
    int64_t saved_at[16]; /* units done at each save */
    int nsaved;
    int fail_advance_at;  /* advance fails when done == this (-1: never) */
    int resume_done;      /* units the restore finds */
} toy_log;

static toy_log LOG;

typedef struct toy_state {
    int64_t done;
} toy_state;

static void note(char c)
{
    size_t n = strlen(LOG.calls);
    if (n + 1 < sizeof LOG.calls)
        LOG.calls[n] = c;
}

static gs_err toy_setup(gs_run *run, const void *config, int resume, void **state, gs_json *phase)
{
    note('S');
    toy_state *t = gs_calloc(1, sizeof *t);
    GS_CHECK(t != NULL, GS_ERR_MEM, "toy state");
    *state = t;
    gs_json_i64(phase, "toy_items", TOTAL);
    return GS_OK;
}

static gs_err toy_restore(void *state, gs_run *run)
{
    note('R');
    ((toy_state *)state)->done = LOG.resume_done;
    return GS_OK;
}

static void toy_units(const void *state, int64_t *done, int64_t *total)
{
    *done = ((const toy_state *)state)->done;
    *total = TOTAL;
}

static gs_err toy_advance(void *state, gs_run *run, int *finished)
{
    note('A');
    toy_state *t = state;
    GS_CHECK(t->done != LOG.fail_advance_at, GS_ERR_LIB, "toy: advance fails at unit %lld",
             (long long)t->done);
    t->done++;
    *finished = t->done >= TOTAL;
    return GS_OK;
}

static gs_err toy_save(void *state, gs_run *run)
{
    note('C');
    toy_state *t = state;
    if (LOG.nsaved < 16)
        LOG.saved_at[LOG.nsaved++] = t->done;
    gs_ckpt_t h = NULL;
    GS_CALL(gs_run_checkpoint_begin(run, &h));
    gs_err err = gs_ckpt_set_i64(h, "/toy", "done", t->done);
    if (err == GS_OK)
        return gs_run_checkpoint_commit(run, &h, t->done);
    gs_ckpt_discard(&h);
    return err;
}

static gs_err toy_report(void *state, gs_run *run, gs_json *phase)
{
    note('Y');
    return GS_OK;
}

static gs_err toy_finish(void *state, gs_run *run, gs_json *phase)
{
    note('F');
    return GS_OK;
}

static gs_err toy_output(void *state, gs_run *run, gs_json *phase, uint64_t *digest)
{
    note('O');
    *digest = 0xfeed0000ULL + (uint64_t)((toy_state *)state)->done;
    return GS_OK;
}

static void toy_destroy(void *state)
{
    note('D');
    gs_free(state);
}

static const gs_engine_ops toy_ops = {
    .setup = toy_setup,
    .restore = toy_restore,
    .units = toy_units,
    .advance = toy_advance,
    .save = toy_save,
    .synthesis_report = toy_report,
    .finish = toy_finish,
    .output = toy_output,
    .destroy = toy_destroy,
};

static const gs_engine toy_engine = {"toy", "a toy engine", NULL, 0, 0, &toy_ops};

/* One driven run into a fresh directory; returns the driver's status and
 * leaves the directory's path in dir. */
static gs_err drive(char *dir, size_t len, int resume, int64_t every)
{
    char tmpl[] = "/tmp/gs-test-driver-XXXXXX";
    assert_non_null(mkdtemp(tmpl));
    snprintf(dir, len, "%s", tmpl);
    gs_run run;
    assert_int_equal(gs_run_open(&run, MPI_COMM_WORLD, "toy", dir, "[run]\nseed = 1\n", 1, resume),
                     GS_OK);
    gs_run_set_checkpointing(&run, 0, every);
    gs_err err = gs_engine_drive(&toy_engine, &run, NULL, resume);
    gs_run_close(&run);
    return err;
}

static void reset(void)
{
    memset(&LOG, 0, sizeof LOG);
    LOG.fail_advance_at = -1;
}

static void cleanup(const char *dir)
{
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

/* The whole lifecycle in order; a checkpoint every 2 units: after units 2,
 * 4, 6 and 8, none after the 10th (the advance that finishes); the summary
 * carries the output's digest and the setup line its members and resumed. */
static void test_lifecycle_and_cadence(void **state)
{
    (void)state;
    reset();
    char dir[256];
    assert_int_equal(drive(dir, sizeof dir, 0, 2), GS_OK);
    assert_string_equal(LOG.calls, "SAACAACAACAACAAYFOD");
    assert_int_equal(LOG.nsaved, 4);
    for (int i = 0; i < 4; i++)
        assert_int_equal(LOG.saved_at[i], 2 * (i + 1));
    char path[400], *text = NULL;
    snprintf(path, sizeof path, "%s/summary.json", dir);
    assert_int_equal(gs_file_read_all(path, 1 << 20, &text, NULL), GS_OK);
    /* no output files: the run digest is XXH3 of the engine's digest alone */
    uint64_t engine = 0xfeed000aULL;
    char want[64], hex[17];
    gs_digest_hex(gs_digest_bytes(&engine, sizeof engine), hex);
    snprintf(want, sizeof want, "\"digest\":\"%s\"", hex);
    assert_non_null(strstr(text, want));
    gs_free(text);
    snprintf(path, sizeof path, "%s/metrics.jsonl", dir);
    assert_int_equal(gs_file_read_all(path, 1 << 20, &text, NULL), GS_OK);
    assert_non_null(strstr(text, "\"toy_items\":10"));
    assert_non_null(strstr(text, "\"resumed\":false"));
    assert_non_null(strstr(text, "\"phase\":\"finish\""));
    gs_free(text);
    cleanup(dir);
}

/* Resume: restore after setup, the advances continue from its units. */
static void test_resume_restores(void **state)
{
    (void)state;
    reset();
    LOG.resume_done = 7;
    char dir[256];
    assert_int_equal(drive(dir, sizeof dir, 1, 0), GS_OK);
    assert_string_equal(LOG.calls, "SRAAAYFOD");
    cleanup(dir);
}

/* A failing advance: the error comes back, nothing is output, the state is
 * still destroyed. */
static void test_failure_destroys(void **state)
{
    (void)state;
    reset();
    LOG.fail_advance_at = 4;
    char dir[256];
    assert_int_equal(drive(dir, sizeof dir, 0, 0), GS_ERR_LIB);
    assert_non_null(strstr(gs_error_message(), "advance fails at unit 4"));
    assert_string_equal(LOG.calls, "SAAAAAD");
    gs_error_clear();
    cleanup(dir);
}

/* A stop (the GS_STOP_AFTER_UNITS hook acts like a signal): a checkpoint,
 * then GS_ERR_INTERRUPTED; no output. */
static void test_stop_checkpoints(void **state)
{
    (void)state;
    reset();
    setenv("GS_STOP_AFTER_UNITS", "5", 1);
    char dir[256];
    gs_err err = drive(dir, sizeof dir, 0, 0);
    unsetenv("GS_STOP_AFTER_UNITS");
    assert_int_equal(err, GS_ERR_INTERRUPTED);
    assert_string_equal(LOG.calls, "SAAAAACD");
    assert_int_equal(LOG.saved_at[0], 5);
    char path[400];
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    assert_int_equal(access(path, F_OK), 0);
    gs_error_clear();
    cleanup(dir);
}

int main(int argc, char **argv)
{
    if (gs_par_init(&argc, &argv) != GS_OK)
        return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lifecycle_and_cadence),
        cmocka_unit_test(test_resume_restores),
        cmocka_unit_test(test_failure_destroys),
        cmocka_unit_test(test_stop_checkpoints),
    };
    int rc = cmocka_run_group_tests(tests, NULL, NULL);
    gs_par_finalize();
    return rc;
}
