/* Memory with accounting: current and peak bytes held through gs_malloc.
 *
 * Every allocation of engine data goes through these so the run can report
 * peak memory per rank (summary.json) and print estimates before allocating.
 * Sizes are checked for overflow (gs_alloc_array). Counters are atomic.
 */
#ifndef GEOSYNTH_MEM_H
#define GEOSYNTH_MEM_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Allocate n bytes (zeroed when zero != 0). Returns NULL on failure or n == 0
 * is treated as 1 byte. Free with gs_free(). */
void *gs_malloc(size_t n);
void *gs_calloc(size_t count, size_t size);
void *gs_realloc(void *p, size_t n);
void gs_free(void *p);

/* Checked allocation for user-sized arrays: *out = count*size bytes, zeroed.
 * what names the array in the error message. On error *out is unchanged and
 * GS_ERR_MEM is raised (overflow or allocation failure). */
gs_err gs_alloc_array(void **out, size_t count, size_t size, const char *what);

/* Test-only failure injection: from now on every gs_alloc_array of this
 * process whose what is exactly the given name (NULL: none) fails with
 * GS_ERR_MEM, as out of memory would. gs_par_init sets it on rank R from
 * GS_FAIL_RANK=R GS_FAIL_ALLOC=NAME (tests/e2e/mpi_errors_alloc.sh,
 * tests/mpi/bcast_alloc.c: a rank that cannot allocate must not leave the
 * others waiting in a collective). */
void gs_mem_fail_alloc(const char *what);

/* Frees *p (allocated by gs_*) and sets it to NULL. */
#define GS_FREE(p) do { gs_free(p); (p) = NULL; } while (0)

/* Multiplies with overflow check; returns 0 on overflow. */
int gs_mul_size(size_t a, size_t b, size_t *out);

size_t gs_mem_current(void);
size_t gs_mem_peak(void);
/* Peak resident set size of the process in bytes (from /proc), 0 if unknown. */
size_t gs_mem_rss_peak(void);
/* Memory this process may still take, in bytes: MemAvailable of
 * /proc/meminfo, lowered to what the cgroup (v2 memory.max - memory.current)
 * leaves; 0 if unknown. */
size_t gs_mem_available(void);

#ifdef __cplusplus
}
#endif

#endif
