/* MPI runtime basics: start-up, the one place errors end up, collective
 * status agreement, broadcasts of text, and the collectives engines share
 * (broadcast of arrays and header structs, reductions, gathers); engines
 * call these and never MPI directly (tests/util/check_layers.py).
 *
 * Error policy (see STYLE.md): functions return gs_err up to main(), which
 * calls gs_fatal(). Two cases:
 *  - collective failures (every rank reached the same point and knows it
 *    failed, e.g. a bad config that rank 0 validated and announced): rank 0
 *    prints the message once, every rank finalizes and exits with the code;
 *  - local failures (one rank failed on its own): that rank prints its
 *    message with a "[rank N]" prefix and calls MPI_Abort, which stops every
 *    rank; nobody is left waiting in a collective.
 * gs_par_agree() turns a local status into a collective one at points where
 * every rank is known to arrive.
 *
 * MPI calls use MPI_ERRORS_RETURN and are wrapped in GS_MPI(...) so an MPI
 * failure is an ordinary gs_err with MPI's own message.
 */
#ifndef GEOSYNTH_PAR_H
#define GEOSYNTH_PAR_H

#include <mpi.h>
#include <stdint.h>

#include "geosynth/error.h"

/* Initializes MPI (if not yet), sets MPI_ERRORS_RETURN on MPI_COMM_WORLD,
 * tells the logger the rank and installs SIGTERM/SIGINT/SIGUSR1 handlers that
 * set the interrupt flag (Slurm sends SIGTERM before killing a job). */
gs_err gs_par_init(int *argc, char ***argv);
/* Finalizes MPI if gs_par_init started it. */
void gs_par_finalize(void);

int gs_par_rank(void);
int gs_par_size(void);

/* Reports the current error and ends the program with exit code = code.
 * collective != 0: every rank calls this with the same code; only rank 0
 * prints; all exit cleanly. collective == 0: this rank prints with its rank
 * prefix and aborts every rank with MPI_Abort. Never returns. */
_Noreturn void gs_fatal(gs_err code, int collective);

/* Collective: combines each rank's status. Returns GS_OK when every rank
 * passed GS_OK. Otherwise every rank gets the highest failing code; a rank
 * whose own status was OK gets an error record naming the lowest failed rank
 * ("rank 2 failed: ..."), whose message is broadcast from that rank. */
gs_err gs_par_agree(MPI_Comm comm, gs_err local);

/* Collective debug check that v is the same on every rank (catches
 * divergent configuration before it becomes a deadlock). */
gs_err gs_par_check_same_i64(MPI_Comm comm, int64_t v, const char *what);

/* Collective: broadcasts a NUL-terminated string from root. On non-root
 * ranks *s must be NULL on entry and receives a gs_malloc'ed copy (free with
 * gs_free). */
gs_err gs_par_bcast_string(MPI_Comm comm, char **s, int root);

/* ---- collectives engines share (src/par/collective.c) ----------------------
 * Every function here is collective over comm and returns a gs_err for an MPI
 * failure (GS_MPI's message). Data moves as bytes: geosynth's ranks run one
 * architecture (its checkpoints assume it too), so a byte copy of a double or
 * a struct is the value. Counts are size_t: large arrays go in pieces of at
 * most 2^30 bytes (MPI counts are int). */

/* This rank and the rank count of comm. */
gs_err gs_par_comm_rank(MPI_Comm comm, int *rank, int *size);
/* How many ranks of comm share this rank's node (its shared memory).
 * Collective. */
gs_err gs_par_node_size(MPI_Comm comm, int *size);
gs_err gs_par_barrier(MPI_Comm comm);
/* A barrier on a clean-up path: 0 when it failed, and no error is raised
 * (the error being reported stays the current one). */
int gs_par_barrier_quiet(MPI_Comm comm);

/* Broadcasts bytes bytes at data from root (any length). */
gs_err gs_par_bcast_bytes(MPI_Comm comm, void *data, size_t bytes, int root);
/* Broadcasts n items of size bytes at *p from root, allocating them first
 * (gs_alloc_array, what names them) on every other rank; n must be the same
 * on every rank (broadcast it first). The ranks agree on those allocations
 * before the broadcast (gs_par_agree), so a rank that cannot allocate makes
 * every rank return its error (GS_ERR_MEM, "rank R failed: ...") instead of
 * leaving root waiting in the broadcast. n = 0: nothing is allocated or
 * sent. On error *p is unchanged off root. Use the same agreement after any
 * allocation a broadcast then fills (never allocate on some ranks and
 * broadcast without it). */
gs_err gs_par_bcast_alloc(MPI_Comm comm, void **p, size_t n, size_t size, int root,
                          const char *what);
/* Broadcasts one object (a named header struct, a scalar, a fixed array)
 * from root: GS_PAR_BCAST_VALUE(comm, &hdr, 0). */
#define GS_PAR_BCAST_VALUE(comm, ptr, root) gs_par_bcast_bytes((comm), (ptr), sizeof *(ptr), (root))

/* *out = the minimum (maximum) of v over the ranks. */
gs_err gs_par_min_i64(MPI_Comm comm, int64_t v, int64_t *out);
gs_err gs_par_max_u64(MPI_Comm comm, uint64_t v, uint64_t *out);
/* out[i] = the maximum (sum) of in[i] over the ranks, i < n; one collective. */
gs_err gs_par_max_int(MPI_Comm comm, const int *in, int *out, int n);
gs_err gs_par_max_f64(MPI_Comm comm, const double *in, double *out, int n);
gs_err gs_par_sum_f64(MPI_Comm comm, const double *in, double *out, int n);

/* Root receives every rank's bytes bytes, in rank order, at all (which
 * holds size * bytes on root and is ignored elsewhere). */
gs_err gs_par_gather_bytes(MPI_Comm comm, const void *mine, size_t bytes, void *all, int root);
/* Every rank receives every rank's bytes bytes, in rank order. */
gs_err gs_par_allgather_bytes(MPI_Comm comm, const void *mine, size_t bytes, void *all);
/* Every rank receives rank r's counts[r] bytes at all + displs[r]; this
 * rank sends counts[rank] bytes from mine. */
gs_err gs_par_allgatherv_bytes(MPI_Comm comm, const void *mine, void *all, const int *counts,
                               const int *displs);
/* In place: items of item_bytes each; rank r's counts[r] items already sit
 * at item displs[r] of all on rank r and reach every rank there. */
gs_err gs_par_allgatherv_items(MPI_Comm comm, void *all, size_t item_bytes, const int *counts,
                               const int *displs);

/* Local: the MPI standard version and the first line of the library's
 * version string (truncated to lib_len). */
void gs_par_mpi_version(int *major, int *minor, char *lib, size_t lib_len);

/* Interrupt flag set by SIGTERM/SIGINT/SIGUSR1 (async-signal-safe).
 * gs_par_interrupted_all() is collective: true on every rank if any rank
 * was signalled, so all ranks can checkpoint and stop together. */
int gs_par_interrupted(void);
int gs_par_interrupted_all(MPI_Comm comm);

/* Wraps one MPI call: raises GS_ERR_MPI with MPI's message on failure. */
gs_err gs_mpi_error(int rc, const char *call, const char *file, int line, const char *func);
#define GS_MPI(call)                                                          \
    do {                                                                      \
        int gs_mpi_rc_ = (call);                                              \
        if (gs_mpi_rc_ != MPI_SUCCESS)                                        \
            return gs_mpi_error(gs_mpi_rc_, #call, __FILE__, __LINE__, __func__); \
    } while (0)

#endif
