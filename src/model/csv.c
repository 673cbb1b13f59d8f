/* DeBroglie's CSV lattices (the format of its samples/merrell/NAME.csv): see
 * gs_model_parse_debroglie_csv in include/geosynth/model.h. */
#include <stdio.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "model/model_impl.h"

#define CSV_MAX_BYTES ((size_t)256 << 20)

/* One line of the text: [b, e) without the newline (and a '\r' before it). */
typedef struct csv_line {
    const char *b, *e;
    int no; /* 1-based */
} csv_line;

static int blank(const csv_line *l)
{
    for (const char *p = l->b; p < l->e; p++)
        if (*p != ' ' && *p != '\t')
            return 0;
    return 1;
}

static size_t count_fields(const csv_line *l)
{
    size_t n = 1;
    for (const char *p = l->b; p < l->e; p++)
        n += *p == ',';
    return n;
}

/* Splits the text into lines (at most *n); returns the count. */
static size_t split_lines(const char *text, size_t len, csv_line *lines, size_t cap)
{
    size_t n = 0;
    const char *p = text, *end = text + len;
    int no = 1;
    while (p < end && n < cap) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        const char *e = nl ? nl : end;
        const char *le = e > p && e[-1] == '\r' ? e - 1 : e;
        lines[n++] = (csv_line){p, le, no++};
        p = nl ? nl + 1 : end;
    }
    return n;
}

gs_err gs_model_parse_debroglie_csv(const char *text, size_t len, const char *name,
                                    gs_model_lattice *out)
{
    name = name ? name : "<memory>";
    GS_CHECK(memchr(text, '\0', len) == NULL, GS_ERR_FORMAT, "%s: not a text file (NUL byte)",
             name);
    size_t cap = 1;
    for (size_t i = 0; i < len; i++)
        cap += text[i] == '\n';
    csv_line *lines = NULL;
    GS_CALL(gs_alloc_array((void **)&lines, cap, sizeof *lines, "CSV lines"));
    size_t nlines = split_lines(text, len, lines, cap);
    gs_model_lattice lat = {0};
    gs_err err = GS_OK;
    /* Shape: layers are runs of non-blank lines separated by blank ones; every
     * row of every layer has the first row's field count, every layer the
     * first layer's row count. */
    size_t nx = 0, ny = 0, nz = 0, rows = 0;
    int first_row_line = 0, first_layer_line = 0;
    for (size_t i = 0; i <= nlines; i++) {
        int is_blank = i == nlines || blank(&lines[i]);
        if (is_blank) {
            if (rows > 0) { /* a layer ended */
                if (nz == 0) {
                    ny = rows;
                } else {
                    GS_TRY_CHECK(err, rows == ny, GS_ERR_FORMAT, done,
                                 "%s:%d: layer %zu has %zu rows, but the first layer (line %d) "
                                 "has %zu",
                                 name, lines[i - 1].no, nz + 1, rows, first_layer_line, ny);
                }
                nz++;
                rows = 0;
            }
            continue;
        }
        size_t nf = count_fields(&lines[i]);
        if (nx == 0) {
            nx = nf;
            first_row_line = lines[i].no;
        }
        if (rows == 0 && nz == 0)
            first_layer_line = lines[i].no;
        GS_TRY_CHECK(err, nf == nx, GS_ERR_FORMAT, done,
                     "%s:%d: row has %zu comma-separated labels, but the first row (line %d) has "
                     "%zu",
                     name, lines[i].no, nf, first_row_line, nx);
        rows++;
    }
    GS_TRY_CHECK(err, nz > 0, GS_ERR_FORMAT, done,
                 "%s: no labels (expected rows of comma-separated labels, layers separated by "
                 "blank lines)",
                 name);
    GS_TRY_CHECK(err, nx <= 4096 && ny <= 4096 && nz <= 4096, GS_ERR_FORMAT, done,
                 "%s: %zux%zux%zu labels: expected each extent in [1, 4096]", name, nx, ny, nz);
    GS_TRY(err, gs_model_lattice_create(&lat, (int)nx, (int)ny, (int)nz), done);
    /* Fill: column = x, row = y, layer = z (DeBroglie's CsvImporter reads
     * data[z][y][x] the same way). */
    size_t z = 0, y = 0;
    for (size_t i = 0; i < nlines; i++) {
        if (blank(&lines[i])) {
            if (y > 0) {
                z++;
                y = 0;
            }
            continue;
        }
        const char *p = lines[i].b;
        for (size_t x = 0; x < nx; x++) {
            const char *comma = memchr(p, ',', (size_t)(lines[i].e - p));
            const char *fe = comma ? comma : lines[i].e;
            char field[64], why[128];
            size_t fl = (size_t)(fe - p);
            int64_t v = 0;
            snprintf(field, sizeof field, "%.*s", (int)(fl < 60 ? fl : 60), p);
            int ok = fl < 60 && gs_parse_i64(field, 0, 65535, &v, why, sizeof why);
            if (!ok) {
                char shown[64];
                size_t a = 0, b = strlen(field);
                while (a < b && (field[a] == ' ' || field[a] == '\t'))
                    a++;
                while (b > a && (field[b - 1] == ' ' || field[b - 1] == '\t'))
                    b--;
                snprintf(shown, sizeof shown, "%.*s%s", (int)(b - a), field + a,
                         fl >= 60 ? "..." : "");
                err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                     "%s:%d: field %zu: expected a label in [0, 65535], got '%s'",
                                     name, lines[i].no, x + 1, shown);
                goto done;
            }
            lat.labels[gs_model_lattice_index(&lat, (int)x, (int)y, (int)z)] = (uint16_t)v;
            p = comma ? comma + 1 : fe;
        }
        y++;
    }
    *out = lat;
    lat.labels = NULL;
done:
    gs_model_lattice_destroy(&lat);
    gs_free(lines);
    return err;
}

gs_err gs_model_read_debroglie_csv(const char *path, gs_model_lattice *out)
{
    char *text = NULL;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, CSV_MAX_BYTES, &text, &len));
    gs_err err = gs_model_parse_debroglie_csv(text, len, path, out);
    gs_free(text);
    if (err)
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    return err;
}
