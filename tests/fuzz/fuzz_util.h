/* Helpers shared by the libFuzzer targets tests/fuzz/fuzz_*.c (a header:
 * the Makefile builds only the .c files as targets).
 *
 * fuzz_file: the readers that take a path (images, tile sets, micro tables,
 * HDF5 examples) get the input written to a private scratch directory made
 * once per process (mkdtemp under $TMPDIR or /tmp, removed at exit).
 * fuzz_check_error: every refused input must leave a message, and the
 * message must be printable text (escaped: no terminal escape sequences or
 * other control bytes from the file reach the user's terminal, #25 item 4). */
#ifndef GEOSYNTH_FUZZ_UTIL_H
#define GEOSYNTH_FUZZ_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/error.h"
#include "geosynth/mem.h"

static char fuzz_dir_path[512];

static void fuzz_dir_remove(void)
{
    if (fuzz_dir_path[0]) {
        char cmd[600];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", fuzz_dir_path);
        if (system(cmd) != 0)
            fprintf(stderr, "fuzz: could not remove %s\n", fuzz_dir_path);
    }
}

/* The scratch directory (made on first use). */
static const char *fuzz_dir(void)
{
    if (!fuzz_dir_path[0]) {
        const char *t = getenv("TMPDIR");
        snprintf(fuzz_dir_path, sizeof fuzz_dir_path, "%s/gs-fuzz-XXXXXX", t && t[0] ? t : "/tmp");
        if (!mkdtemp(fuzz_dir_path)) {
            perror("fuzz: mkdtemp");
            abort();
        }
        atexit(fuzz_dir_remove);
    }
    return fuzz_dir_path;
}

/* Writes data to SCRATCH/name and returns that path (static storage). */
static const char *fuzz_file(const char *name, const uint8_t *data, size_t size)
{
    static char path[1024];
    snprintf(path, sizeof path, "%s/%s", fuzz_dir(), name);
    /* A new file each time, not the last one truncated: ext4 (auto_da_alloc)
     * writes a truncated-and-rewritten file back to disk when it is closed,
     * which held fuzz_h5example to a few runs a second on a busy disk. */
    unlink(path);
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror(path);
        abort();
    }
    return path;
}

/* An exact-size gs_malloc copy of data (so ASan sees any read past its
 * end; 1 byte for an empty input), NULL when out of memory; gs_free it. */
static char *fuzz_copy(const uint8_t *data, size_t size)
{
    char *buf = gs_malloc(size ? size : 1);
    if (buf && size)
        memcpy(buf, data, size);
    return buf;
}

/* The layout of most targets' inputs: one byte of options, then the file.
 * *opt gets the first byte, *len the file's size, and the file comes back as
 * a fuzz_copy (gs_free it); NULL for an empty input or out of memory. */
static char *fuzz_split(const uint8_t *data, size_t size, uint8_t *opt, size_t *len)
{
    if (size < 1)
        return NULL;
    *opt = data[0];
    *len = size - 1;
    return fuzz_copy(data + 1, size - 1);
}

/* After a refused input: a message, printable, then cleared. */
static void fuzz_check_error(void)
{
    const char *m = gs_error_message();
    if (m[0] == '\0')
        __builtin_trap(); /* an error must say what is wrong */
    for (const unsigned char *p = (const unsigned char *)m; *p; p++)
        if ((*p < 32 && *p != '\n' && *p != '\t') || *p == 127) {
            fprintf(stderr, "fuzz: control byte 0x%02x in the error message: %s\n", *p, m);
            __builtin_trap(); /* the file's bytes must be escaped */
        }
    gs_error_clear();
}

#endif
