/* Rank-aware logging and progress; see include/geosynth/log.h. */
#define _POSIX_C_SOURCE 200809L
#include "geosynth/log.h"

#include "geosynth/error.h"

#include <stdarg.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>
#include <unistd.h>

static int log_rank = 0;
static int log_level_set = 0;
static gs_log_level log_level = GS_LOG_INFO;

static gs_log_level level_from_env(void)
{
    const char *v = getenv("GS_LOG");
    if (!v)
        return GS_LOG_INFO;
    if (!strcasecmp(v, "error"))
        return GS_LOG_ERROR;
    if (!strcasecmp(v, "warn"))
        return GS_LOG_WARN;
    if (!strcasecmp(v, "debug"))
        return GS_LOG_DEBUG;
    return GS_LOG_INFO;
}

void gs_log_set_rank(int rank) { log_rank = rank; }
int gs_log_rank(void) { return log_rank; }

void gs_log_set_level(gs_log_level level)
{
    log_level = level;
    log_level_set = 1;
}

gs_log_level gs_log_get_level(void)
{
    return log_level_set ? log_level : level_from_env();
}

static const char *level_tag(gs_log_level level)
{
    switch (level) {
    case GS_LOG_ERROR: return "error: ";
    case GS_LOG_WARN: return "warning: ";
    case GS_LOG_DEBUG: return "debug: ";
    default: return "";
    }
}

static void vlog(int all_ranks, gs_log_level level, const char *fmt, va_list ap)
{
    if (level > gs_log_get_level())
        return;
    if (!all_ranks && log_rank != 0 && level > GS_LOG_WARN)
        return;
    char buf[4096];
    vsnprintf(buf, sizeof buf, fmt, ap);
    gs_text_sanitize(buf); /* log lines quote paths and names from input files */
    if (log_rank != 0 || all_ranks)
        fprintf(stderr, "[rank %d] %s%s\n", log_rank, level_tag(level), buf);
    else
        fprintf(stderr, "%s%s\n", level_tag(level), buf);
    fflush(stderr);
}

void gs_log(gs_log_level level, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vlog(0, level, fmt, ap);
    va_end(ap);
}

void gs_log_all(gs_log_level level, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vlog(1, level, fmt, ap);
    va_end(ap);
}

void gs_log_section(const char *name)
{
    gs_log(GS_LOG_INFO, "== %s ==", name);
}

double gs_time_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double gs_cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void gs_progress_begin(gs_progress *p, const char *label, uint64_t total)
{
    memset(p, 0, sizeof *p);
    snprintf(p->label, sizeof p->label, "%s", label);
    p->total = total;
    p->start_time = gs_time_now();
    p->last_print = p->start_time;
    p->last_decile = -1;
    p->active = log_rank == 0 && gs_log_get_level() >= GS_LOG_INFO;
    p->is_tty = isatty(fileno(stderr));
}

/* " ETA 12.3s" from the rate since the first update (a resumed run starts
 * its count there), "" before any progress. */
static void format_eta(const gs_progress *p, double now, char *out, size_t len)
{
    out[0] = '\0';
    if (p->done <= p->first_done || p->done >= p->total || now <= p->first_time)
        return;
    double rate = (double)(p->done - p->first_done) / (now - p->first_time);
    double eta = (double)(p->total - p->done) / rate;
    if (eta < 3600)
        snprintf(out, len, ", ETA %.1fs", eta);
    else
        snprintf(out, len, ", ETA %.0fh%02.0fm", floor(eta / 3600), floor(fmod(eta, 3600) / 60));
}

void gs_progress_update(gs_progress *p, uint64_t done)
{
    if (!p->started) { /* the first count: a resumed run's rate starts here */
        p->started = 1;
        p->first_done = done;
        p->first_time = gs_time_now();
    }
    p->done = done;
    if (!p->active || p->total == 0)
        return;
    double now = gs_time_now();
    double frac = (double)done / (double)p->total;
    if (frac > 1.0)
        frac = 1.0;
    char eta[48];
    if (p->is_tty) {
        if (now - p->last_print < 0.1 && done < p->total)
            return;
        format_eta(p, now, eta, sizeof eta);
        int width = 30, fill = (int)(frac * width);
        char bar[31];
        for (int i = 0; i < width; i++)
            bar[i] = i < fill ? '#' : '.';
        bar[width] = '\0';
        fprintf(stderr, "\r%-20s [%s] %5.1f%% %8.1fs%-18s", p->label, bar, 100.0 * frac,
                now - p->start_time, eta);
        fflush(stderr);
        p->last_print = now;
        return;
    }
    int decile = (int)(frac * 10.0);
    if (decile != p->last_decile || now - p->last_print > 10.0) {
        /* formatted only for a line printed: the model engine updates per
         * region on rank 0, inside the synthesis */
        format_eta(p, now, eta, sizeof eta);
        fprintf(stderr, "%s: %llu/%llu (%.0f%%) after %.1fs%s\n", p->label,
                (unsigned long long)done, (unsigned long long)p->total, 100.0 * frac,
                now - p->start_time, eta);
        fflush(stderr);
        p->last_decile = decile;
        p->last_print = now;
    }
}

void gs_progress_end(gs_progress *p)
{
    if (!p->active)
        return;
    if (p->is_tty) {
        gs_progress_update(p, p->total);
        fputc('\n', stderr);
    } else if (p->last_decile < 10) {
        fprintf(stderr, "%s: done in %.1fs\n", p->label, gs_time_now() - p->start_time);
    }
    fflush(stderr);
    p->active = 0;
}
