/* gs_par_bcast_alloc (include/geosynth/par.h; #25 "never hang"): rank 0
 * holds an array, every other rank allocates room for it, the ranks agree on
 * those allocations, then rank 0 broadcasts.
 *  1. No failure: every rank holds rank 0's 100000 values (their digest).
 *  2. The last rank cannot allocate (gs_mem_fail_alloc, what GS_FAIL_ALLOC
 *     sets from the environment; at np 1 rank 0 allocates nothing, so
 *     nothing fails): every rank returns GS_ERR_MEM from the same call, the
 *     others with "rank R failed: ..." naming the array, the failing rank's
 *     pointer stays NULL, and every rank then goes on to the same next
 *     collective (a broadcast of a marker) and gets rank 0's value. Without
 *     the agreement rank 0 sat in the broadcast while the failing rank went
 *     on to the next collective: an alarm of 30 s ends a hang here with exit
 *     code 142, so tests/run.sh reports it.
 * np: 1 2 3
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"

#define CHECK(cond, ...)                                                                     \
    do {                                                                                     \
        if (!(cond)) {                                                                       \
            fprintf(stderr, "[rank %d] bcast_alloc: check failed: %s: ", gs_par_rank(), #cond); \
            fprintf(stderr, __VA_ARGS__);                                                    \
            fprintf(stderr, "\n");                                                           \
            MPI_Abort(MPI_COMM_WORLD, 1);                                                    \
        }                                                                                    \
    } while (0)

#define N 100000

int main(int argc, char **argv)
{
    alarm(30); /* a hang fails the test instead of waiting for tests/run.sh's 300 s */
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    const int rank = gs_par_rank(), size = gs_par_size();
    const MPI_Comm comm = MPI_COMM_WORLD;

    /* 1. every rank receives rank 0's values */
    uint32_t *v = NULL;
    if (rank == 0) {
        CHECK(gs_alloc_array((void **)&v, N, sizeof *v, "values") == GS_OK, "alloc");
        for (uint32_t i = 0; i < N; i++)
            v[i] = i * 2654435761u;
    }
    CHECK(gs_par_bcast_alloc(comm, (void **)&v, N, sizeof *v, 0, "values") == GS_OK, "%s",
          gs_error_message());
    CHECK(v != NULL, "no array");
    for (uint32_t i = 0; i < N; i++)
        CHECK(v[i] == i * 2654435761u, "value %u differs", i);
    if (rank == size - 1) /* one line at every np (tests/run.sh compares them) */
        printf("digest: %016llx\n", (unsigned long long)gs_digest_bytes(v, N * sizeof *v));

    /* 2. the last rank cannot allocate "doomed" */
    const int fails = size - 1;
    if (rank == fails && size > 1)
        gs_mem_fail_alloc("doomed");
    uint32_t *w = rank == 0 ? v : NULL;
    err = gs_par_bcast_alloc(comm, (void **)&w, N, sizeof *w, 0, "doomed");
    if (size == 1) {
        CHECK(err == GS_OK && w == v, "np 1: nothing to allocate, expected success");
    } else {
        CHECK(err == GS_ERR_MEM, "expected GS_ERR_MEM on every rank, got %d", (int)err);
        const char *msg = gs_error_message();
        CHECK(strstr(msg, "doomed") != NULL, "the message names no array: %s", msg);
        if (rank != fails) {
            char want[32];
            snprintf(want, sizeof want, "rank %d failed", fails);
            CHECK(strstr(msg, want) != NULL, "the message names no failed rank: %s", msg);
        } else {
            CHECK(w == NULL, "the failing rank got a pointer");
        }
        gs_error_clear();
    }
    gs_mem_fail_alloc(NULL);
    /* every rank is at the same next collective */
    int marker = rank == 0 ? 4242 : 0;
    CHECK(GS_PAR_BCAST_VALUE(comm, &marker, 0) == GS_OK && marker == 4242,
          "the next collective got %d", marker);
    if (rank == 0)
        fprintf(stderr, "bcast_alloc: np %d: broadcast ok; rank %d's failed allocation "
                "returned GS_ERR_MEM on every rank, no hang\n", size, fails);
    gs_free(v);
    gs_par_finalize();
    return 0;
}
