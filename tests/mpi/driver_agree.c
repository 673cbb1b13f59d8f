/* The run driver's agreement (src/run/driver.c): an operation that fails on
 * the last rank only ends the run on every rank with that error, marked as
 * agreed (so gs_fatal reports it once, from the failing rank, without
 * MPI_Abort), the state destroyed everywhere and no output written; an
 * operation that succeeds everywhere gives every rank the same digest.
 * np: 1 2 3
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/engine.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/run.h"

#define CHECK(cond, ...)                                                               \
    do {                                                                               \
        if (!(cond)) {                                                                 \
            fprintf(stderr, "[rank %d] driver_agree: check failed: %s: ", gs_par_rank(), #cond); \
            fprintf(stderr, __VA_ARGS__);                                              \
            fprintf(stderr, "\n");                                                     \
            MPI_Abort(MPI_COMM_WORLD, 1);                                              \
        }                                                                              \
    } while (0)

static int fail_rank = -1; /* the rank whose advance fails at unit 2 (-1: none) */
static int destroyed, outputs;

typedef struct st {
    int64_t done;
} st;

static gs_err t_setup(gs_run *run, const void *c, int resume, void **state, gs_json *phase)
{
    *state = gs_calloc(1, sizeof(st));
    GS_CHECK(*state != NULL, GS_ERR_MEM, "state");
    return GS_OK;
}

static void t_units(const void *state, int64_t *done, int64_t *total)
{
    *done = ((const st *)state)->done;
    *total = 4;
}

static gs_err t_advance(void *state, gs_run *run, int *finished)
{
    st *s = state;
    GS_CHECK(!(run->rank == fail_rank && s->done == 2), GS_ERR_LIB,
             "driver_agree: rank %d fails on purpose", run->rank);
    s->done++;
    *finished = s->done >= 4;
    return GS_OK;
}

static gs_err t_save(void *state, gs_run *run) { return GS_OK; }

static gs_err t_output(void *state, gs_run *run, gs_json *phase, uint64_t *digest)
{
    outputs++;
    *digest = 0xabcULL + (uint64_t)((st *)state)->done;
    return GS_OK;
}

static void t_destroy(void *state)
{
    destroyed++;
    gs_free(state);
}

static const gs_engine_ops ops = {.setup = t_setup, .units = t_units, .advance = t_advance,
                                  .save = t_save, .output = t_output, .destroy = t_destroy};
static const gs_engine eng = {"toy", "toy", NULL, 0, 0, &ops};

static gs_err drive(const char *dir)
{
    gs_run run;
    GS_CALL(gs_run_open(&run, MPI_COMM_WORLD, "toy", dir, "[run]\nseed = 1\n", 1, 0));
    gs_err err = gs_engine_drive(&eng, &run, NULL, 0);
    int together = run.failed_together;
    gs_run_close(&run);
    CHECK(err == GS_OK || together, "an agreed failure sets failed_together");
    return err;
}

int main(int argc, char **argv)
{
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    int size = gs_par_size(), rank = gs_par_rank();
    char dir[64] = "/tmp/gs-driver-agree-XXXXXX";
    if (rank == 0)
        CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    CHECK(gs_par_bcast_bytes(MPI_COMM_WORLD, dir, sizeof dir, 0) == GS_OK, "bcast");
    char d1[128], d2[128];
    snprintf(d1, sizeof d1, "%s/ok", dir);
    snprintf(d2, sizeof d2, "%s/fail", dir);

    /* every rank succeeds */
    CHECK(drive(d1) == GS_OK, "%s", gs_error_message());
    CHECK(outputs == 1 && destroyed == 1, "outputs %d destroyed %d", outputs, destroyed);

    /* the last rank fails: every rank returns its code, agreed, from that rank */
    fail_rank = size - 1;
    err = drive(d2);
    CHECK(err == GS_ERR_LIB, "rank %d got %d, expected GS_ERR_LIB", rank, (int)err);
    CHECK(gs_error_agreed_origin() == size - 1, "agreed origin %d, expected %d",
          gs_error_agreed_origin(), size - 1);
    CHECK(strstr(gs_error_message(), "fails on purpose") != NULL, "message: %s",
          gs_error_message());
    CHECK(outputs == 1 && destroyed == 2, "after the failure: outputs %d destroyed %d", outputs,
          destroyed);
    gs_error_clear();
    CHECK(gs_par_barrier(MPI_COMM_WORLD) == GS_OK, "barrier");
    if (rank == 0) {
        char cmd[128];
        snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
        CHECK(system(cmd) == 0, "cleanup");
        printf("digest: driver_agree %s\n", "ok");
    }
    gs_par_finalize();
    return 0;
}
