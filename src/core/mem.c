/* Accounted allocation; see include/geosynth/mem.h.
 * Each block carries a 16-byte header with its size so gs_free can account
 * without a lookup table. */
#define _POSIX_C_SOURCE 200809L
#include "geosynth/mem.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define HEADER 16

static atomic_size_t mem_current;
static atomic_size_t mem_peak;

static void account(size_t add, size_t sub)
{
    size_t now = atomic_fetch_add(&mem_current, add) + add;
    if (sub)
        now = atomic_fetch_sub(&mem_current, sub) - sub;
    size_t peak = atomic_load(&mem_peak);
    while (now > peak && !atomic_compare_exchange_weak(&mem_peak, &peak, now)) {
    }
}

int gs_mul_size(size_t a, size_t b, size_t *out)
{
    if (a != 0 && b > SIZE_MAX / a)
        return 0;
    *out = a * b;
    return 1;
}

void *gs_malloc(size_t n)
{
    if (n > SIZE_MAX - HEADER)
        return NULL;
    unsigned char *p = malloc(n + HEADER);
    if (!p)
        return NULL;
    memcpy(p, &n, sizeof n);
    account(n, 0);
    return p + HEADER;
}

void *gs_calloc(size_t count, size_t size)
{
    size_t n;
    if (!gs_mul_size(count, size, &n) || n > SIZE_MAX - HEADER)
        return NULL;
    unsigned char *p = calloc(1, n + HEADER);
    if (!p)
        return NULL;
    memcpy(p, &n, sizeof n);
    account(n, 0);
    return p + HEADER;
}

void *gs_realloc(void *ptr, size_t n)
{
    if (!ptr)
        return gs_malloc(n);
    if (n > SIZE_MAX - HEADER)
        return NULL;
    unsigned char *base = (unsigned char *)ptr - HEADER;
    size_t old;
    memcpy(&old, base, sizeof old);
    unsigned char *p = realloc(base, n + HEADER);
    if (!p)
        return NULL;
    memcpy(p, &n, sizeof n);
    account(n, old);
    return p + HEADER;
}

void gs_free(void *ptr)
{
    if (!ptr)
        return;
    unsigned char *base = (unsigned char *)ptr - HEADER;
    size_t n;
    memcpy(&n, base, sizeof n);
    atomic_fetch_sub(&mem_current, n);
    free(base);
}

static char fail_what[128]; /* gs_mem_fail_alloc; set once, before any thread */

void gs_mem_fail_alloc(const char *what)
{
    snprintf(fail_what, sizeof fail_what, "%s", what ? what : "");
}

gs_err gs_alloc_array(void **out, size_t count, size_t size, const char *what)
{
    size_t n;
    GS_CHECK(!fail_what[0] || strcmp(fail_what, what), GS_ERR_MEM,
             "%s: cannot allocate (injected failure: GS_FAIL_ALLOC)", what);
    GS_CHECK(gs_mul_size(count, size, &n), GS_ERR_MEM,
             "%s: %zu x %zu bytes overflows the address space", what, count, size);
    void *p = gs_calloc(count, size);
    GS_CHECK(p != NULL || n == 0, GS_ERR_MEM, "%s: cannot allocate %zu bytes (%.1f MiB)",
             what, n, (double)n / (1024.0 * 1024.0));
    if (!p)
        p = gs_malloc(1);
    GS_CHECK(p != NULL, GS_ERR_MEM, "%s: cannot allocate", what);
    *out = p;
    return GS_OK;
}

size_t gs_mem_current(void) { return atomic_load(&mem_current); }
size_t gs_mem_peak(void) { return atomic_load(&mem_peak); }

size_t gs_mem_rss_peak(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        return 0;
    char line[256];
    size_t kb = 0;
    while (fgets(line, sizeof line, f)) {
        if (!strncmp(line, "VmHWM:", 6)) {
            char *end;
            kb = (size_t)strtoull(line + 6, &end, 10);
            break;
        }
    }
    fclose(f);
    return kb * 1024;
}

static size_t read_number(const char *path, const char *key, size_t scale)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    char line[256];
    size_t v = 0;
    while (fgets(line, sizeof line, f)) {
        if (!key[0] || !strncmp(line, key, strlen(key))) {
            char *end;
            unsigned long long n = strtoull(line + strlen(key), &end, 10);
            v = end != line + strlen(key) ? (size_t)n * scale : 0; /* "max": no limit */
            break;
        }
    }
    fclose(f);
    return v;
}

size_t gs_mem_available(void)
{
    size_t avail = read_number("/proc/meminfo", "MemAvailable:", 1024);
    size_t max = read_number("/sys/fs/cgroup/memory.max", "", 1);
    size_t cur = read_number("/sys/fs/cgroup/memory.current", "", 1);
    if (max && max > cur && (avail == 0 || max - cur < avail))
        avail = max - cur;
    return avail;
}
