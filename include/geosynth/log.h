/* Rank-aware logging and progress reporting.
 *
 * Levels: ERROR < WARN < INFO < DEBUG. By default rank 0 prints INFO and
 * above; other ranks print WARN and above, prefixed with "[rank N]". The
 * level comes from gs_log_set_level() (CLI -v / -q) or the GS_LOG environment
 * variable (error|warn|info|debug). Messages go to stderr so stdout stays
 * free for machine-readable output (inspect, --help).
 *
 * Progress: on a terminal rank 0 draws a bar that rewrites one line; when
 * stderr is not a terminal (batch jobs, CI) it prints a plain line at most
 * every few seconds and at every 10% step.
 */
#ifndef GEOSYNTH_LOG_H
#define GEOSYNTH_LOG_H

#include <stdint.h>

typedef enum gs_log_level {
    GS_LOG_ERROR = 0,
    GS_LOG_WARN = 1,
    GS_LOG_INFO = 2,
    GS_LOG_DEBUG = 3
} gs_log_level;

/* Tells the logger which rank this process is (call after MPI_Init). */
void gs_log_set_rank(int rank);
int gs_log_rank(void);
void gs_log_set_level(gs_log_level level);
gs_log_level gs_log_get_level(void);

void gs_log(gs_log_level level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Like gs_log but printed by every rank that calls it (still level-filtered). */
void gs_log_all(gs_log_level level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

#define GS_INFO(...) gs_log(GS_LOG_INFO, __VA_ARGS__)
#define GS_WARN(...) gs_log(GS_LOG_WARN, __VA_ARGS__)
#define GS_DEBUG(...) gs_log(GS_LOG_DEBUG, __VA_ARGS__)

/* Prints a section banner on rank 0 ("== SETUP =="). */
void gs_log_section(const char *name);

typedef struct gs_progress {
    char label[64];
    uint64_t total;
    uint64_t done;
    double start_time;
    double last_print;
    int last_decile;
    int is_tty;
    int active; /* only rank 0 prints */
    int started;         /* first update seen */
    uint64_t first_done; /* its count and time: the ETA's rate is measured from there */
    double first_time;
} gs_progress;

void gs_progress_begin(gs_progress *p, const char *label, uint64_t total);
void gs_progress_update(gs_progress *p, uint64_t done);
void gs_progress_end(gs_progress *p);

/* Monotonic wall-clock seconds. */
double gs_time_now(void);
/* CPU seconds of this process (all threads): on a shared machine it
 * swings much less than wall time. */
double gs_cpu_now(void);

#endif
