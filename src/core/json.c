/* Minimal JSON writer; see include/geosynth/json.h. */
#include "geosynth/json.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/mem.h"

void gs_json_init(gs_json *j) { memset(j, 0, sizeof *j); }

void gs_json_free(gs_json *j)
{
    gs_free(j->buf);
    memset(j, 0, sizeof *j);
}

static void put(gs_json *j, const char *s, size_t n)
{
    if (j->failed)
        return;
    if (j->len + n + 1 > j->cap) {
        size_t cap = j->cap ? j->cap : 256;
        while (cap < j->len + n + 1)
            cap *= 2;
        char *b = gs_realloc(j->buf, cap);
        if (!b) {
            j->failed = 1;
            return;
        }
        j->buf = b;
        j->cap = cap;
    }
    memcpy(j->buf + j->len, s, n);
    j->len += n;
    j->buf[j->len] = '\0';
}

static void puts_(gs_json *j, const char *s) { put(j, s, strlen(s)); }

static void put_string(gs_json *j, const char *s)
{
    put(j, "\"", 1);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        char esc[8];
        switch (*p) {
        case '"': puts_(j, "\\\""); break;
        case '\\': puts_(j, "\\\\"); break;
        case '\n': puts_(j, "\\n"); break;
        case '\r': puts_(j, "\\r"); break;
        case '\t': puts_(j, "\\t"); break;
        default:
            if (*p < 0x20) {
                snprintf(esc, sizeof esc, "\\u%04x", *p);
                puts_(j, esc);
            } else {
                put(j, (const char *)p, 1);
            }
        }
    }
    put(j, "\"", 1);
}

static void member(gs_json *j, const char *key)
{
    if (j->depth > 0 && j->count[j->depth - 1]++ > 0)
        put(j, ",", 1);
    if (key) {
        put_string(j, key);
        put(j, ":", 1);
    }
}

static void open_(gs_json *j, const char *key, const char *bracket)
{
    member(j, key);
    puts_(j, bracket);
    if (j->depth < GS_JSON_MAX_DEPTH)
        j->count[j->depth] = 0;
    j->depth++;
}

static void close_(gs_json *j, const char *bracket)
{
    if (j->depth > 0)
        j->depth--;
    puts_(j, bracket);
}

void gs_json_begin_object(gs_json *j, const char *key) { open_(j, key, "{"); }
void gs_json_end_object(gs_json *j) { close_(j, "}"); }
void gs_json_begin_array(gs_json *j, const char *key) { open_(j, key, "["); }
void gs_json_end_array(gs_json *j) { close_(j, "]"); }

void gs_json_str(gs_json *j, const char *key, const char *value)
{
    member(j, key);
    if (value)
        put_string(j, value);
    else
        puts_(j, "null");
}

void gs_json_f64(gs_json *j, const char *key, double value)
{
    member(j, key);
    if (!isfinite(value)) {
        puts_(j, "null");
        return;
    }
    char b[40];
    snprintf(b, sizeof b, "%.17g", value);
    /* Shorter form when it round-trips exactly. */
    char s[40];
    snprintf(s, sizeof s, "%.6g", value);
    double back;
    if (sscanf(s, "%lf", &back) == 1 && back == value)
        puts_(j, s);
    else
        puts_(j, b);
}

void gs_json_i64(gs_json *j, const char *key, int64_t value)
{
    member(j, key);
    char b[32];
    snprintf(b, sizeof b, "%" PRId64, value);
    puts_(j, b);
}

void gs_json_u64(gs_json *j, const char *key, uint64_t value)
{
    member(j, key);
    char b[32];
    snprintf(b, sizeof b, "%" PRIu64, value);
    puts_(j, b);
}

void gs_json_seed(gs_json *j, const char *key, uint64_t value)
{
    char k[64], b[32];
    snprintf(k, sizeof k, "%s_string", key);
    snprintf(b, sizeof b, "%" PRIu64, value);
    gs_json_u64(j, key, value);
    gs_json_str(j, k, b);
}

void gs_json_bool(gs_json *j, const char *key, int value)
{
    member(j, key);
    puts_(j, value ? "true" : "false");
}

void gs_json_raw(gs_json *j, const char *key, const char *json_text)
{
    member(j, key);
    puts_(j, json_text);
}

void gs_json_merge(gs_json *j, const char *object_json)
{
    const char *b = strchr(object_json, '{');
    const char *e = strrchr(object_json, '}');
    if (!b || !e || e <= b)
        return;
    b++;
    while (b < e && (*b == ' ' || *b == '\n' || *b == '\t'))
        b++;
    while (e > b && (e[-1] == ' ' || e[-1] == '\n' || e[-1] == '\t'))
        e--;
    if (b == e)
        return;
    member(j, NULL);
    put(j, b, (size_t)(e - b));
}
