/* Label lattices: allocation, digest, Merrell's text format, run lengths.
 * See include/geosynth/model.h. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/file.h"

#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "model/model_impl.h"

/* qsort context of gs_model_sort_rows: rows of g_row labels */
static size_t g_row;
static int cmp_row(const void *pa, const void *pb)
{
    const uint16_t *a = pa, *b = pb;
    for (size_t i = 0; i < g_row; i++)
        if (a[i] != b[i])
            return a[i] < b[i] ? -1 : 1;
    return 0;
}

void gs_model_sort_rows(uint16_t *rows, size_t n, size_t row)
{
    g_row = row;
    qsort(rows, n, row * sizeof *rows, cmp_row);
}

#define GS_MODEL_MAX_DIM (1 << 20)
#define GS_MODEL_MAX_CELLS ((size_t)1 << 31)

gs_err gs_model_lattice_create(gs_model_lattice *lat, int nx, int ny, int nz)
{
    GS_CHECK(nx >= 1 && ny >= 1 && nz >= 1 && nx <= GS_MODEL_MAX_DIM && ny <= GS_MODEL_MAX_DIM &&
                 nz <= GS_MODEL_MAX_DIM,
             GS_ERR_ARG, "lattice size %dx%dx%d: expected each extent in [1, %d]", nx, ny, nz,
             GS_MODEL_MAX_DIM);
    size_t n = (size_t)nx * (size_t)ny;
    GS_CHECK(n <= GS_MODEL_MAX_CELLS && n * (size_t)nz <= GS_MODEL_MAX_CELLS, GS_ERR_ARG,
             "lattice size %dx%dx%d: more than 2^31 cells", nx, ny, nz);
    n *= (size_t)nz;
    void *p = NULL;
    GS_CALL(gs_alloc_array(&p, n, sizeof(uint16_t), "label lattice"));
    lat->nx = nx;
    lat->ny = ny;
    lat->nz = nz;
    lat->labels = p;
    lat->frames = 1;
    return GS_OK;
}

void gs_model_lattice_destroy(gs_model_lattice *lat)
{
    if (!lat)
        return;
    GS_FREE(lat->labels);
    lat->nx = lat->ny = lat->nz = lat->frames = 0;
}

uint64_t gs_model_lattice_digest(const gs_model_lattice *lat)
{
    gs_digest d;
    if (!gs_digest_init(&d))
        return 0;
    int32_t dims[4] = {lat->nx, lat->ny, lat->nz, lat->frames};
    /* frames only for 4D lattices: 3D digests stay what they were */
    gs_digest_update(&d, dims, lat->frames > 1 ? sizeof dims : 3 * sizeof dims[0]);
    gs_digest_update(&d, lat->labels,
                     (size_t)lat->nx * (size_t)lat->ny * (size_t)lat->nz * sizeof(uint16_t));
    return gs_digest_final(&d);
}

gs_err gs_model_lattice_frame(const gs_model_lattice *l, int t, gs_model_lattice *out)
{
    const int T = l->frames > 1 ? l->frames : 1, fz = gs_model_frame_nz(l);
    GS_CHECK(t >= 0 && t < T, GS_ERR_ARG, "frame %d of a lattice of %d frames", t, T);
    gs_model_lattice f = {0};
    GS_CALL(gs_model_lattice_create(&f, l->nx, l->ny, fz));
    const size_t n = (size_t)l->nx * (size_t)l->ny * (size_t)fz;
    memcpy(f.labels, l->labels + (size_t)t * n, n * sizeof *f.labels);
    *out = f;
    return GS_OK;
}

gs_err gs_model_lattice_filmstrip(const gs_model_lattice *l, int gap, int max_frames,
                                  gs_model_lattice *out)
{
    int T = l->frames > 1 ? l->frames : 1;
    if (max_frames > 0 && T > max_frames)
        T = max_frames;
    const int fz = gs_model_frame_nz(l), step = l->nx + (gap > 0 ? gap : 0);
    gs_model_lattice f = {0};
    GS_CALL(gs_model_lattice_create(&f, step * (T - 1) + l->nx, l->ny, fz));
    for (int t = 0; t < T; t++)
        for (int z = 0; z < fz; z++)
            for (int y = 0; y < l->ny; y++)
                memcpy(f.labels + gs_model_lattice_index(&f, t * step, y, z),
                       l->labels + gs_model_lattice_index(l, 0, y, t * fz + z),
                       (size_t)l->nx * sizeof *f.labels);
    *out = f;
    return GS_OK;
}

/* ---- Merrell's .txt -------------------------------------------------------- */

typedef struct txt_cursor {
    const char *p, *end;
    int line;
    const char *name;
} txt_cursor;

/* Skips blanks and newlines (counting lines). Returns 0 at end of text. */
static int skip_space(txt_cursor *c)
{
    while (c->p < c->end) {
        char ch = *c->p;
        if (ch == '\n') {
            c->line++;
        } else if (ch != ' ' && ch != '\t' && ch != '\r' && ch != '\f' && ch != '\v') {
            return 1;
        }
        c->p++;
    }
    return 0;
}

static void token_text(const txt_cursor *c, char *buf, size_t n)
{
    size_t k = 0;
    const char *q = c->p;
    while (q < c->end && k + 1 < n && *q != ' ' && *q != '\t' && *q != '\n' && *q != '\r')
        buf[k++] = *q++;
    buf[k] = 0;
}

/* Reads one integer token in [lo, hi]; what names it in errors. */
static gs_err read_int(txt_cursor *c, int64_t lo, int64_t hi, const char *what, int64_t *out)
{
    GS_CHECK(skip_space(c), GS_ERR_FORMAT, "%s:%d: unexpected end of file: expected %s",
             c->name, c->line, what);
    /* gs_scan_i64 reads a NUL-free prefix; copy the token so it cannot run
     * past the buffer end. */
    char tok[32];
    token_text(c, tok, sizeof tok);
    const char *q = tok;
    int64_t v;
    int ok = gs_scan_i64(&q, lo, hi, &v);
    GS_CHECK(ok && *q == 0, GS_ERR_FORMAT, "%s:%d: expected %s in [%lld, %lld], got '%s'", c->name,
             c->line, what, (long long)lo, (long long)hi, tok);
    c->p += q - tok;
    *out = v;
    return GS_OK;
}

gs_err gs_model_parse_merrell_txt(const char *text, size_t len, const char *name,
                                  gs_model_lattice *out)
{
    txt_cursor c = {text, text + len, 1, name ? name : "<memory>"};
    for (int i = 0; i < 3; i++) { /* three free header lines */
        const char *nl = memchr(c.p, '\n', (size_t)(c.end - c.p));
        GS_CHECK(nl != NULL, GS_ERR_FORMAT,
                 "%s:%d: expected 3 header lines and then the 'X Y Z' extents", c.name, c.line);
        c.p = nl + 1;
        c.line++;
    }
    int64_t ext[3];
    static const char *ext_name[3] = {"the x extent", "the y extent", "the z extent"};
    for (int i = 0; i < 3; i++)
        GS_CALL(read_int(&c, 1, 4096, ext_name[i], &ext[i]));
    /* a fourth extent on the same line: frames of a 4D lattice */
    int64_t frames = 1;
    while (c.p < c.end && (*c.p == ' ' || *c.p == '\t' || *c.p == '\r'))
        c.p++;
    if (c.p < c.end && *c.p != '\n')
        GS_CALL(read_int(&c, 1, 4096, "the t extent (frames)", &frames));
    GS_CHECK(ext[2] * frames <= 4096, GS_ERR_FORMAT, "%s:%d: %lld frames of %lld layers: at most "
             "4096 layers in all", c.name, c.line, (long long)frames, (long long)ext[2]);
    ext[2] *= frames;
    size_t n = (size_t)(ext[0] * ext[1] * ext[2]);
    /* Each label takes a digit and a separator: refuse extents the rest of
     * the file cannot hold before allocating them (4096^3 from a 30-byte file
     * reserved 2^31 cells; fuzz_lattice). */
    size_t room = ((size_t)(c.end - c.p) + 1) / 2;
    GS_CHECK(n <= room, GS_ERR_FORMAT,
             "%s:%d: extents %lld x %lld x %lld need %zu labels, but the rest of the file "
             "(%zu bytes) holds at most %zu: truncated file or wrong extents",
             c.name, c.line, (long long)ext[0], (long long)ext[1], (long long)ext[2], n,
             (size_t)(c.end - c.p), room);
    gs_model_lattice lat = {0};
    GS_CALL(gs_model_lattice_create(&lat, (int)ext[0], (int)ext[1], (int)ext[2]));
    lat.frames = (int)frames;
    gs_err err = GS_OK;
    /* File order (frame after frame, each like a 3D lattice, is the same
     * as z stacked over the frames): z outermost, then x, then y innermost. */
    size_t k = 0;
    for (int z = 0; z < lat.nz; z++)
        for (int x = 0; x < lat.nx; x++)
            for (int y = 0; y < lat.ny; y++, k++) {
                if (skip_space(&c) && *c.p == '<') {
                    err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                         "%s:%d: section starts after %zu labels: extents %lldx%lldx%lld "
                                         "need %zu",
                                         c.name, c.line, k, (long long)ext[0], (long long)ext[1],
                                         (long long)ext[2], n);
                    goto done;
                }
                int64_t v;
                GS_TRY(err, read_int(&c, 0, 65535, "a label", &v), done);
                lat.labels[gs_model_lattice_index(&lat, x, y, z)] = (uint16_t)v;
            }
    /* After the labels only an <Objects> section (or nothing) may follow. */
    if (skip_space(&c)) {
        char tok[32];
        token_text(&c, tok, sizeof tok);
        GS_TRY_CHECK(err, *c.p == '<', GS_ERR_FORMAT, done,
                     "%s:%d: more labels than the extents %lldx%lldx%lld allow (got '%s' where the "
                     "<Objects> section or the end was expected)",
                     c.name, c.line, (long long)ext[0], (long long)ext[1], (long long)ext[2], tok);
    }
    *out = lat;
    return GS_OK;
done:
    gs_model_lattice_destroy(&lat);
    return err;
}

gs_err gs_model_read_merrell_txt(const char *path, gs_model_lattice *out)
{
    FILE *f = fopen(path, "rb");
    GS_CHECK(f != NULL, GS_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    gs_err err = GS_OK;
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len + 65536 > cap) {
            GS_TRY_CHECK(err, cap < ((size_t)1 << 31), GS_ERR_FORMAT, done,
                         "%s: larger than 2 GiB: not a model sample", path);
            size_t ncap = cap ? 2 * cap : 131072;
            char *nb = gs_realloc(buf, ncap);
            GS_TRY_CHECK(err, nb != NULL, GS_ERR_MEM, done, "%s: cannot allocate %zu bytes",
                         path, ncap);
            buf = nb;
            cap = ncap;
        }
        size_t got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0)
            break;
    }
    GS_TRY_CHECK(err, !ferror(f), GS_ERR_IO, done, "%s: read error", path);
    GS_TRY(err, gs_model_parse_merrell_txt(buf, len, path, out), done);
done:
    fclose(f);
    gs_free(buf);
    return err;
}

gs_err gs_model_write_merrell_txt(const char *path, const gs_model_lattice *lat)
{
    FILE *f = gs_fopen_new(path); /* never through a planted symlink */
    GS_CHECK(f != NULL, GS_ERR_IO, "%s: cannot create: %s", path, strerror(errno));
    if (lat->frames > 1)
        fprintf(f, "Model synthesized by geosynth.\n\nx, y, z extents and frames\n%d %d %d %d\n",
                lat->nx, lat->ny, gs_model_frame_nz(lat), lat->frames);
    else
        fprintf(f, "Model synthesized by geosynth.\n\nx, y, and z extents\n%d %d %d\n", lat->nx,
                lat->ny, lat->nz);
    for (int z = 0; z < lat->nz; z++) {
        fputc('\n', f);
        for (int x = 0; x < lat->nx; x++) {
            for (int y = 0; y < lat->ny; y++)
                fprintf(f, y ? " %u" : "%u",
                        (unsigned)lat->labels[gs_model_lattice_index(lat, x, y, z)]);
            fputc('\n', f);
        }
    }
    int bad = ferror(f);
    bad |= fclose(f) != 0;
    GS_CHECK(!bad, GS_ERR_IO, "%s: write failed", path);
    return GS_OK;
}

/* ---- statistics --------------------------------------------------------------- */

void gs_model_run_lengths(const gs_model_lattice *lat, double mean[3])
{
    const int n[3] = {lat->nx, lat->ny, lat->nz};
    for (int axis = 0; axis < 3; axis++) {
        uint64_t runs = 0, cells = 0;
        const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
        for (int i = 0; i < n[a1]; i++)
            for (int j = 0; j < n[a2]; j++) {
                int prev = -1;
                for (int t = 0; t < n[axis]; t++) {
                    int p[3];
                    p[axis] = t;
                    p[a1] = i;
                    p[a2] = j;
                    int lab = lat->labels[gs_model_lattice_index(lat, p[0], p[1], p[2])];
                    if (lab != 0) {
                        cells++;
                        if (lab != prev)
                            runs++;
                    }
                    prev = lab;
                }
            }
        mean[axis] = runs ? (double)cells / (double)runs : 0.0;
    }
}
