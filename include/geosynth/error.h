/* geosynth error handling: one error type, one propagation macro.
 *
 * Every fallible function returns gs_err (GS_OK == 0). The first failure is
 * raised with GS_CHECK / GS_RAISE, which records a message plus
 * file:line:function; every caller that propagates it with GS_CALL appends its
 * own frame, so the final report is a traceback, not a guess:
 *
 *     GS_CALL(gs_mesh_read(path, &mesh));
 *     GS_CHECK(n > 0, GS_ERR_ARG, "lattice size %d must be > 0", n);
 *
 * GS_CHECK stays on in every build (use it for anything a user can get wrong);
 * GS_ASSERT is for internal invariants in hot loops and compiles away with
 * NDEBUG.
 *
 * The error record is per thread (a process normally has one thread that
 * raises). gs_error_report() prints it; gs_fatal() (src/par/runtime.c) is the one
 * place that reports and aborts all MPI ranks. No code under src/ calls
 * assert(), exit() or abort() directly.
 *
 * Exit codes of the geosynth binary equal the gs_err value of the failure
 * (documented in README.md): 0 ok, 1 usage, 2 bad input / config, 3 I/O,
 * 4 file format, 5 out of memory, 6 MPI, 7 external library, 8 internal bug,
 * 9 interrupted.
 */
#ifndef GEOSYNTH_ERROR_H
#define GEOSYNTH_ERROR_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum gs_err {
    GS_OK = 0,
    GS_ERR_USAGE = 1,       /* wrong command line */
    GS_ERR_ARG = 2,         /* bad config value or bad input content */
    GS_ERR_IO = 3,          /* file missing, unreadable, unwritable */
    GS_ERR_FORMAT = 4,      /* file exists but is not what was expected */
    GS_ERR_MEM = 5,         /* allocation failed or size would overflow */
    GS_ERR_MPI = 6,         /* MPI call failed or ranks disagree */
    GS_ERR_LIB = 7,         /* an external library (HDF5, OpenVDB, ...) failed */
    GS_ERR_INTERNAL = 8,    /* a geosynth bug */
    GS_ERR_INTERRUPTED = 9  /* stopped on request (signal) */
} gs_err;

/* Short name of an error code ("bad input", "I/O", ...). Never NULL. */
const char *gs_err_name(gs_err code);

/* Records a new error (discarding any earlier record) and returns code.
 * fmt is printf-style. Use through GS_CHECK / GS_RAISE. */
gs_err gs_error_raise(gs_err code, const char *file, int line, const char *func,
                      const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 5, 6)))
#endif
    ;

/* Marks the current error as agreed by every rank of the job (gs_par_agree
 * over all of them), first reported by origin_rank: the job then reports it
 * once, from that rank, and exits without MPI_Abort (gs_fatal). A new error
 * (gs_error_raise) or gs_error_clear drops the mark. */
void gs_error_mark_agreed(int origin_rank);
/* That rank, or -1 when the current error is not marked. */
int gs_error_agreed_origin(void);

/* Appends a traceback frame to the current error. Use through GS_CALL. */
void gs_error_push_frame(const char *file, int line, const char *func);

/* Replaces, in place, every control byte but newline and tab (and DEL) with
 * '?': text quoted from an input file (a terminal escape sequence in a PNG
 * chunk name, a CR of a CRLF table, a NUL) must not drive the user's
 * terminal (#25). Every error message, log line, config problem and
 * `inspect` listing goes through it. */
void gs_text_sanitize(char *s);

/* Adds context to the current error's message ("while reading X"). */
void gs_error_add_context(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* The current error's code and message (empty string when none). */
gs_err gs_error_code(void);
const char *gs_error_message(void);

/* Writes "error: <message>" and the traceback to stderr, each line prefixed
 * with prefix (e.g. "[rank 3] ") when non-NULL. */
void gs_error_report(const char *prefix);

/* Forgets the current error (after it has been handled). */
void gs_error_clear(void);

#define GS_RAISE(code, ...) \
    return gs_error_raise((code), __FILE__, __LINE__, __func__, __VA_ARGS__)

#define GS_CHECK(cond, code, ...)                                             \
    do {                                                                      \
        if (!(cond))                                                          \
            return gs_error_raise((code), __FILE__, __LINE__, __func__,       \
                                  __VA_ARGS__);                               \
    } while (0)

#define GS_CALL(expr)                                                         \
    do {                                                                      \
        gs_err gs_call_err_ = (expr);                                         \
        if (gs_call_err_ != GS_OK) {                                          \
            gs_error_push_frame(__FILE__, __LINE__, __func__);                \
            return gs_call_err_;                                              \
        }                                                                     \
    } while (0)

/* Variants for functions that must release resources on failure:
 *     gs_err err = GS_OK;
 *     GS_TRY(err, gs_thing(&x), done);
 *     GS_TRY_CHECK(err, n > 0, GS_ERR_ARG, done, "n = %d", n);
 *   done:
 *     free(x);
 *     return err;
 */
#define GS_TRY(err, expr, label)                                              \
    do {                                                                      \
        (err) = (expr);                                                       \
        if ((err) != GS_OK) {                                                 \
            gs_error_push_frame(__FILE__, __LINE__, __func__);                \
            goto label;                                                       \
        }                                                                     \
    } while (0)

#define GS_TRY_CHECK(err, cond, code, label, ...)                             \
    do {                                                                      \
        if (!(cond)) {                                                        \
            (err) = gs_error_raise((code), __FILE__, __LINE__, __func__,      \
                                   __VA_ARGS__);                              \
            goto label;                                                       \
        }                                                                     \
    } while (0)

#ifdef NDEBUG
#define GS_ASSERT(cond) ((void)0)
#else
void gs_assert_fail(const char *expr, const char *file, int line, const char *func);
#define GS_ASSERT(cond) \
    ((cond) ? (void)0 : gs_assert_fail(#cond, __FILE__, __LINE__, __func__))
#endif

#ifdef __cplusplus
}
#endif

#endif
