/* Checked number parsing; see include/geosynth/parse.h. */
#include "geosynth/parse.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static void say(char *why, size_t why_len, const char *fmt, const char *what, const char *s)
{
    if (why && why_len)
        snprintf(why, why_len, fmt, what, s);
}

static const char *skip_blanks(const char *s)
{
    while (*s && isspace((unsigned char)*s))
        s++;
    return s;
}

static int only_blanks(const char *s)
{
    return *skip_blanks(s) == '\0';
}

int gs_parse_i64(const char *s, int64_t lo, int64_t hi, int64_t *out, char *why,
                 size_t why_len)
{
    char range[96];
    snprintf(range, sizeof range, "an integer in [%lld, %lld]", (long long)lo, (long long)hi);
    if (!s) {
        say(why, why_len, "expected %s, got nothing%s", range, "");
        return 0;
    }
    const char *p = skip_blanks(s);
    char *end;
    errno = 0;
    long long v = strtoll(p, &end, 10);
    if (end == p || !only_blanks(end)) {
        say(why, why_len, "expected %s, got '%s'", range, s);
        return 0;
    }
    if (errno == ERANGE || v < lo || v > hi) {
        say(why, why_len, "expected %s, got '%s' (out of range)", range, s);
        return 0;
    }
    *out = (int64_t)v;
    return 1;
}

int gs_parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out, char *why,
                 size_t why_len)
{
    char range[96];
    snprintf(range, sizeof range, "an integer in [%llu, %llu]", (unsigned long long)lo,
             (unsigned long long)hi);
    if (!s) {
        say(why, why_len, "expected %s, got nothing%s", range, "");
        return 0;
    }
    const char *p = skip_blanks(s);
    if (*p == '-') {
        say(why, why_len, "expected %s, got '%s' (negative)", range, s);
        return 0;
    }
    char *end;
    errno = 0;
    unsigned long long v = strtoull(p, &end, 10);
    if (end == p || !only_blanks(end)) {
        say(why, why_len, "expected %s, got '%s'", range, s);
        return 0;
    }
    if (errno == ERANGE || v < lo || v > hi) {
        say(why, why_len, "expected %s, got '%s' (out of range)", range, s);
        return 0;
    }
    *out = (uint64_t)v;
    return 1;
}

int gs_parse_f64(const char *s, double lo, double hi, double *out, char *why,
                 size_t why_len)
{
    char range[96];
    snprintf(range, sizeof range, "a number in [%g, %g]", lo, hi);
    if (!s) {
        say(why, why_len, "expected %s, got nothing%s", range, "");
        return 0;
    }
    const char *p = skip_blanks(s);
    char *end;
    errno = 0;
    double v = strtod(p, &end);
    if (end == p || !only_blanks(end)) {
        say(why, why_len, "expected %s, got '%s'", range, s);
        return 0;
    }
    if (!isfinite(v)) {
        say(why, why_len, "expected %s, got '%s' (not finite)", range, s);
        return 0;
    }
    if (errno == ERANGE && fabs(v) > 1.0) {
        say(why, why_len, "expected %s, got '%s' (overflow)", range, s);
        return 0;
    }
    if (v < lo || v > hi) {
        say(why, why_len, "expected %s, got '%s' (out of range)", range, s);
        return 0;
    }
    *out = v;
    return 1;
}

int gs_parse_bool(const char *s, int *out, char *why, size_t why_len)
{
    static const char *yes[] = {"true", "yes", "on", "1"};
    static const char *no[] = {"false", "no", "off", "0"};
    if (s) {
        const char *p = skip_blanks(s);
        size_t n = strlen(p);
        while (n && isspace((unsigned char)p[n - 1]))
            n--;
        for (int i = 0; i < 4; i++) {
            if (strlen(yes[i]) == n && !strncasecmp(p, yes[i], n)) {
                *out = 1;
                return 1;
            }
            if (strlen(no[i]) == n && !strncasecmp(p, no[i], n)) {
                *out = 0;
                return 1;
            }
        }
    }
    say(why, why_len, "expected %s, got '%s'", "true/false (yes/no, on/off, 1/0)", s ? s : "");
    return 0;
}

int gs_scan_i64(const char **p, int64_t lo, int64_t hi, int64_t *out)
{
    const char *s = *p;
    if (!(*s == '-' || *s == '+' || isdigit((unsigned char)*s)))
        return 0;
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (end == s || errno == ERANGE || v < lo || v > hi)
        return 0;
    *out = (int64_t)v;
    *p = end;
    return 1;
}
