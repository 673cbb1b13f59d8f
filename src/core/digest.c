/* XXH3-64 digests; see include/geosynth/digest.h. */
#include "geosynth/digest.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include <xxhash.h>

#include "geosynth/error.h"
#include "geosynth/mem.h"

uint64_t gs_digest_bytes(const void *data, size_t n)
{
    return (uint64_t)XXH3_64bits(data, n);
}

int gs_digest_init(gs_digest *d)
{
    XXH3_state_t *s = XXH3_createState();
    if (!s)
        return 0;
    XXH3_64bits_reset(s);
    d->state = s;
    return 1;
}

void gs_digest_update(gs_digest *d, const void *data, size_t n)
{
    XXH3_64bits_update((XXH3_state_t *)d->state, data, n);
}

uint64_t gs_digest_final(gs_digest *d)
{
    uint64_t h = (uint64_t)XXH3_64bits_digest((XXH3_state_t *)d->state);
    XXH3_freeState((XXH3_state_t *)d->state);
    d->state = NULL;
    return h;
}

void gs_digest_hex(uint64_t h, char out[17])
{
    snprintf(out, 17, "%016llx", (unsigned long long)h);
}

gs_err gs_digest_file(const char *path, uint64_t *hash, uint64_t *bytes)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    GS_CHECK(fd >= 0, GS_ERR_IO, "cannot open %s: %s", path, strerror(errno));
    XXH3_state_t *s = XXH3_createState();
    if (!s) {
        close(fd);
        GS_RAISE(GS_ERR_MEM, "%s: cannot allocate a digest state", path);
    }
    XXH3_64bits_reset(s);
    char buf[1 << 16];
    uint64_t total = 0;
    ssize_t n;
    while ((n = read(fd, buf, sizeof buf)) > 0 || (n < 0 && errno == EINTR))
        if (n > 0) {
            XXH3_64bits_update(s, buf, (size_t)n);
            total += (uint64_t)n;
        }
    int e = errno;
    close(fd);
    uint64_t h = (uint64_t)XXH3_64bits_digest(s);
    XXH3_freeState(s);
    GS_CHECK(n == 0, GS_ERR_IO, "cannot read %s: %s", path, strerror(e));
    *hash = h;
    *bytes = total;
    return GS_OK;
}

gs_err gs_input_line(const char *key, const char *path, char **line)
{
    uint64_t h = 0, bytes = 0;
    GS_CALL(gs_digest_file(path, &h, &bytes));
    char hex[17];
    gs_digest_hex(h, hex);
    size_t n = strlen(GS_INPUT_TAG) + strlen(key) + strlen(path) + 64;
    char *s = gs_malloc(n);
    GS_CHECK(s, GS_ERR_MEM, "out of memory for the digest of %s", path);
    snprintf(s, n, "%s%s xxh3 %s %llu %s\n", GS_INPUT_TAG, key, hex, (unsigned long long)bytes,
             path);
    *line = s;
    return GS_OK;
}

static char *input_notes; /* noted lines not yet taken */
static char *input_seen;  /* every line noted, so each is kept once */

static gs_err append_text(char **buf, const char *text)
{
    size_t have = *buf ? strlen(*buf) : 0, add = strlen(text);
    char *grown = gs_realloc(*buf, have + add + 1);
    GS_CHECK(grown, GS_ERR_MEM, "out of memory for the inputs' digests");
    memcpy(grown + have, text, add + 1);
    *buf = grown;
    return GS_OK;
}

gs_err gs_input_note(const char *via, const char *path)
{
    char *line = NULL;
    GS_CALL(gs_input_line(via, path, &line));
    gs_err err = GS_OK;
    if (!input_seen || !strstr(input_seen, line)) {
        err = append_text(&input_seen, line);
        if (!err)
            err = append_text(&input_notes, line);
    }
    gs_free(line);
    return err;
}

char *gs_input_notes_take(void)
{
    char *s = input_notes;
    input_notes = NULL;
    if (!s && (s = gs_malloc(1)) != NULL)
        s[0] = '\0';
    return s;
}
