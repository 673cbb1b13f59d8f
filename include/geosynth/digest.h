/* 64-bit digests of arrays (XXH3-64) used to prove determinism.
 *
 * Every engine records the digest of its final output in summary.json as a
 * 16-digit hex string; determinism and restart tests compare these. Data are
 * hashed as raw bytes in the host's (little-endian) layout.
 */
#ifndef GEOSYNTH_DIGEST_H
#define GEOSYNTH_DIGEST_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

typedef struct gs_digest {
    void *state; /* XXH3_state_t, opaque */
} gs_digest;

uint64_t gs_digest_bytes(const void *data, size_t n);

/* Streaming digest: init, update any number of times, final (frees state).
 * Returns 0 from init only when the state cannot be allocated. */
int gs_digest_init(gs_digest *d);
void gs_digest_update(gs_digest *d, const void *data, size_t n);
uint64_t gs_digest_final(gs_digest *d);

/* splitmix64 finalizer: a fast bijective 64-bit mixer for hash tables and
 * stream ids (not a digest of data). */
static inline uint64_t gs_hash_mix64(uint64_t x)
{
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

/* Writes 16 lowercase hex digits and a NUL into out[17]. */
void gs_digest_hex(uint64_t h, char out[17]);

/* XXH3-64 of a whole file's bytes (read in 64 KiB pieces) and its size.
 * GS_ERR_IO naming the file when it cannot be opened or read. */
gs_err gs_digest_file(const char *path, uint64_t *hash, uint64_t *bytes);

/* Inputs' digests (#25 items 2 and 4): a run records, in start.ini, every
 * checkpoint and summary.json, one line per input file,
 *   "; input KEY xxh3 HEX BYTES PATH"
 * and `resume` refuses to go on when one no longer matches its file.
 * gs_input_line formats that line (with its newline) for a file as it is
 * now; *line is gs_malloc'ed.
 *
 * The files a config names are covered by the driver; the files that input
 * files name in turn (a tile set's tile images and .vox tiles, a mesh list's
 * meshes) only their readers know, so a reader notes each one it reads:
 * gs_input_note(VIA, PATH), VIA being the config key of the file that named
 * it ("model.tileset"). The line is kept (once per distinct line) until
 * gs_input_notes_take hands over every noted line since the last call
 * ("" when none; gs_free it); the run layer records them. Readers of
 * named files run on rank 0, whose notes are the ones taken. */
#define GS_INPUT_TAG "; input "
gs_err gs_input_line(const char *key, const char *path, char **line);
gs_err gs_input_note(const char *via, const char *path);
char *gs_input_notes_take(void);

#endif
