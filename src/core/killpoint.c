/* Kill points (test hook); see include/geosynth/killpoint.h. */
#include "geosynth/killpoint.h"

#include <fcntl.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/parse.h"

static int kp_on = -1;        /* -1: not set up; 0: off; 1: counting on this rank */
static long long kp_at;       /* GS_KILL_AT (0: never) */
static long long kp_count;    /* kill points passed */
static int kp_trace = -1;     /* GS_KILL_TRACE descriptor */
static char kp_phase[48] = "start";

void gs_kill_point_setup(int rank, int resumed)
{
    const char *at = getenv("GS_KILL_AT");
    const char *trace = getenv("GS_KILL_TRACE");
    const char *who = getenv("GS_KILL_RANK");
    int64_t k = 0, r = 0;
    char why[128];
    kp_on = 0;
    if (resumed || ((!at || !*at) && (!trace || !*trace)))
        return;
    if (at && *at && !gs_parse_i64(at, 1, INT64_MAX, &k, why, sizeof why))
        return;
    if (who && *who && !gs_parse_i64(who, 0, 1 << 20, &r, why, sizeof why))
        return;
    if (r != rank)
        return;
    kp_at = (long long)k;
    if (trace && *trace)
        kp_trace = open(trace, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    kp_on = 1;
}

void gs_kill_point_phase(const char *phase)
{
    snprintf(kp_phase, sizeof kp_phase, "%s", phase);
}

void gs_kill_point(const char *what, ...)
{
    if (kp_on <= 0)
        return;
    kp_count++;
    if (kp_trace >= 0) {
        char line[512];
        int n = snprintf(line, sizeof line, "%lld\t%s\t", kp_count, kp_phase);
        va_list ap;
        va_start(ap, what);
        if (n > 0 && n < (int)sizeof line)
            n += vsnprintf(line + n, sizeof line - (size_t)n, what, ap);
        va_end(ap);
        if (n >= (int)sizeof line - 1)
            n = (int)sizeof line - 2;
        line[n++] = '\n';
        if (write(kp_trace, line, (size_t)n) != n) {
            /* a trace is only for the test reading it */
        }
    }
    if (kp_count == kp_at)
        raise(SIGKILL);
}

const char *gs_kill_base(const char *path)
{
    const char *slash = path ? strrchr(path, '/') : NULL;
    return slash ? slash + 1 : path ? path : "";
}
