/* MPI start-up, error agreement and the fatal-error exit; see par.h. */
#include "geosynth/par.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/log.h"
#include "geosynth/mem.h"

static int par_started_mpi = 0;
static int par_rank = 0;
static int par_size = 1;
static volatile sig_atomic_t par_signal = 0;

/* The first TERM/INT/USR1 asks for a checkpoint at the next safe point (the
 * run loop polls gs_par_interrupted). A second TERM or INT means the user
 * will not wait: the process ends at once, with a message written with
 * write(2) (async-signal-safe) and exit code 128 + signal, as a shell reports
 * it. The run directory stays resumable: every output is written atomically
 * and the last checkpoint is kept until the outputs and summary.json are. */
static void on_signal(int sig)
{
    if ((sig == SIGTERM || sig == SIGINT) && par_signal != 0) {
        /* rank 0 speaks for all (mpirun forwards the signal to every rank) */
        static const char term[] = "geosynth: second SIGTERM: stopping at once without a "
                                   "checkpoint (resume from the last one with "
                                   "'geosynth resume RUN_DIR')\n";
        static const char intr[] = "geosynth: second SIGINT: stopping at once without a "
                                   "checkpoint (resume from the last one with "
                                   "'geosynth resume RUN_DIR')\n";
        const char *m = sig == SIGTERM ? term : intr;
        size_t n = sig == SIGTERM ? sizeof term - 1 : sizeof intr - 1;
        if (par_rank == 0) {
            ssize_t w = write(2, m, n);
            (void)w;
        }
        _exit(128 + sig);
    }
    par_signal = sig;
}

gs_err gs_mpi_error(int rc, const char *call, const char *file, int line, const char *func)
{
    char msg[MPI_MAX_ERROR_STRING] = "";
    int len = 0;
    if (MPI_Error_string(rc, msg, &len) != MPI_SUCCESS)
        snprintf(msg, sizeof msg, "MPI error code %d", rc);
    return gs_error_raise(GS_ERR_MPI, file, line, func, "%s failed: %s", call, msg);
}

gs_err gs_par_init(int *argc, char ***argv)
{
    int initialized = 0;
    MPI_Initialized(&initialized);
    if (!initialized) {
        int provided;
        GS_MPI(MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided));
        par_started_mpi = 1;
    }
    GS_MPI(MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN));
    GS_MPI(MPI_Comm_rank(MPI_COMM_WORLD, &par_rank));
    GS_MPI(MPI_Comm_size(MPI_COMM_WORLD, &par_size));
    gs_log_set_rank(par_rank);
    const char *fail = getenv("GS_FAIL_ALLOC"), *fail_rank = getenv("GS_FAIL_RANK");
    if (fail && fail[0]) {
        char *end = NULL;
        long r = fail_rank ? strtol(fail_rank, &end, 10) : 0;
        GS_CHECK(!fail_rank || (end != fail_rank && !*end && r >= 0), GS_ERR_USAGE,
                 "GS_FAIL_RANK = '%s': expected a rank (with GS_FAIL_ALLOC)", fail_rank);
        if (r == par_rank)
            gs_mem_fail_alloc(fail);
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGUSR1, &sa, NULL);
    return GS_OK;
}

void gs_par_finalize(void)
{
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (par_started_mpi && !finalized)
        MPI_Finalize();
}

int gs_par_rank(void) { return par_rank; }
int gs_par_size(void) { return par_size; }

_Noreturn void gs_fatal(gs_err code, int collective)
{
    if (code == GS_OK)
        code = GS_ERR_INTERNAL;
    int finalized = 0, initialized = 0;
    MPI_Initialized(&initialized);
    MPI_Finalized(&finalized);
    int mpi_alive = initialized && !finalized;
    /* An error every rank agreed on (gs_par_agree) is reported once, by the
     * rank it came from, and every rank exits with its code: each rank used
     * to print it (the origin its own message, the others "rank 0 failed:
     * ...") and the first to get here aborted the job (#24 item 2). */
    int origin = gs_error_agreed_origin();
    if (origin >= 0 && origin < par_size)
        collective = 1;
    else
        origin = 0;
    if (collective || !mpi_alive || par_size == 1) {
        if (par_rank == origin) {
            char pre[32] = "";
            if (origin != 0 && par_size > 1)
                snprintf(pre, sizeof pre, "[rank %d] ", origin);
            gs_error_report(pre);
        }
        if (mpi_alive && par_started_mpi)
            MPI_Finalize();
        exit((int)code);
    }
    char prefix[32];
    snprintf(prefix, sizeof prefix, "[rank %d] ", par_rank);
    gs_error_report(prefix);
    MPI_Abort(MPI_COMM_WORLD, (int)code);
    exit((int)code); /* not reached */
}

gs_err gs_par_agree(MPI_Comm comm, gs_err local)
{
    int rank, size;
    GS_MPI(MPI_Comm_rank(comm, &rank));
    GS_MPI(MPI_Comm_size(comm, &size));
    /* Highest code, and lowest failing rank (as -rank maximized). An error
     * that was already agreed (an engine's own agreement, then the driver's)
     * keeps the rank it came from, so it is still reported once, from there. */
    int origin = local != GS_OK ? gs_error_agreed_origin() : -1;
    if (local != GS_OK && (origin < 0 || origin >= size))
        origin = rank;
    int mine[2] = {(int)local, local != GS_OK ? -origin : -size};
    int all[2];
    GS_MPI(MPI_Allreduce(mine, all, 2, MPI_INT, MPI_MAX, comm));
    if (all[0] == GS_OK)
        return GS_OK;
    int first = -all[1];
    char msg[1024];
    if (rank == first)
        snprintf(msg, sizeof msg, "%s", gs_error_message());
    GS_MPI(MPI_Bcast(msg, (int)sizeof msg, MPI_CHAR, first, comm));
    msg[sizeof msg - 1] = '\0';
    /* Agreed by the whole job: gs_fatal reports it once, from rank first. */
    int whole = size == par_size;
    if (local != GS_OK) {
        if (whole)
            gs_error_mark_agreed(first);
        return local;
    }
    gs_err e = gs_error_raise((gs_err)all[0], __FILE__, __LINE__, __func__, "rank %d failed: %s",
                              first, msg);
    if (whole)
        gs_error_mark_agreed(first);
    return e;
}

gs_err gs_par_check_same_i64(MPI_Comm comm, int64_t v, const char *what)
{
    int64_t mine[2] = {v, -v}, all[2];
    GS_MPI(MPI_Allreduce(mine, all, 2, MPI_INT64_T, MPI_MAX, comm));
    GS_CHECK(all[0] == v && -all[1] == v, GS_ERR_MPI,
             "ranks disagree on %s (values from %lld to %lld)", what,
             (long long)-all[1], (long long)all[0]);
    return GS_OK;
}

gs_err gs_par_bcast_string(MPI_Comm comm, char **s, int root)
{
    int rank;
    GS_MPI(MPI_Comm_rank(comm, &rank));
    long long len = rank == root ? (long long)strlen(*s) : 0;
    GS_MPI(MPI_Bcast(&len, 1, MPI_LONG_LONG, root, comm));
    GS_CHECK(len >= 0 && len < (1LL << 31), GS_ERR_ARG, "string of %lld bytes is too long to broadcast", len);
    GS_CALL(gs_par_bcast_alloc(comm, (void **)s, (size_t)len + 1, 1, root, "broadcast text"));
    return GS_OK;
}

int gs_par_interrupted(void) { return par_signal != 0; }

int gs_par_interrupted_all(MPI_Comm comm)
{
    int mine = par_signal != 0, any = mine;
    if (MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, comm) != MPI_SUCCESS)
        return mine;
    return any;
}
