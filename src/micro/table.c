/* Distribution tables from CSV files and the sanity check of table sums.
 * See include/geosynth/micro.h (gs_micro_dist_read_csv). */
#include <math.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "micro/micro_impl.h"

#define TABLE_MAX_ROWS 16384
#define TABLE_MAX_BYTES ((size_t)64 << 20)

/* Splits line (modified in place) at commas into at most max fields,
 * trimming blanks; returns the field count (max + 1 when there are more). */
static int split_fields(char *line, char **f, int max)
{
    int n = 0;
    char *p = line;
    for (;;) {
        char *c = strchr(p, ',');
        if (c)
            *c = '\0';
        while (*p == ' ' || *p == '\t')
            p++;
        char *e = p + strlen(p);
        while (e > p && (e[-1] == ' ' || e[-1] == '\t' || e[-1] == '\r'))
            *--e = '\0';
        if (n < max)
            f[n] = p;
        n++;
        if (!c)
            break;
        p = c + 1;
    }
    return n > max ? max + 1 : n;
}

gs_err gs_micro_dist_read_csv(const char *path, gs_micro_dist *d)
{
    char *text = NULL;
    size_t len = 0;
    GS_CALL(gs_file_read_all(path, TABLE_MAX_BYTES, &text, &len));
    gs_err err = GS_OK;
    double *pos = NULL, *neg = NULL;
    GS_TRY(err, gs_alloc_array((void **)&pos, TABLE_MAX_ROWS, sizeof *pos, "table"), done);
    GS_TRY(err, gs_alloc_array((void **)&neg, TABLE_MAX_ROWS, sizeof *neg, "table"), done);
    GS_TRY_CHECK(err, memchr(text, '\0', len) == NULL, GS_ERR_ARG, done,
                 "%s: not a text file (contains a NUL byte)", path);
    uint32_t rows = 0;
    int line_no = 0, seen_data_or_header = 0;
    for (char *line = text; line && *line != '\0';) {
        char *nl = strchr(line, '\n');
        if (nl)
            *nl = '\0';
        line_no++;
        char *p = line;
        while (*p == ' ' || *p == '\t' || *p == '\r')
            p++;
        if (*p != '\0' && *p != '#') {
            char *f[3];
            int nf = split_fields(p, f, 3);
            int64_t bin;
            char why[160];
            if (!seen_data_or_header && !gs_parse_i64(f[0], 0, INT64_MAX, &bin, NULL, 0) &&
                !gs_parse_f64(f[0], -INFINITY, INFINITY, &(double){0}, NULL, 0)) {
                seen_data_or_header = 1; /* header row */
            } else {
                seen_data_or_header = 1;
                GS_TRY_CHECK(err, nf == 3, GS_ERR_ARG, done,
                             "%s:%d: expected 3 comma-separated fields 'bin, positive, negative', "
                             "got %s%d",
                             path, line_no, nf > 3 ? "more than " : "", nf > 3 ? 3 : nf);
                GS_TRY_CHECK(err, rows < TABLE_MAX_ROWS, GS_ERR_ARG, done,
                             "%s:%d: more than %d bins", path, line_no, TABLE_MAX_ROWS);
                GS_TRY_CHECK(err, gs_parse_i64(f[0], 0, TABLE_MAX_ROWS, &bin, why, sizeof why),
                             GS_ERR_ARG, done, "%s:%d: bin '%s': %s", path, line_no, f[0], why);
                GS_TRY_CHECK(err, bin == (int64_t)rows, GS_ERR_ARG, done,
                             "%s:%d: bin %lld: expected bin %u (rows list bins 0, 1, 2, ... in order)",
                             path, line_no, (long long)bin, rows);
                for (int c = 1; c <= 2; c++) {
                    double *dst = c == 1 ? &pos[rows] : &neg[rows];
                    GS_TRY_CHECK(err, gs_parse_f64(f[c], 0, 1, dst, why, sizeof why), GS_ERR_ARG,
                                 done, "%s:%d: %s probability '%s': %s", path, line_no,
                                 c == 1 ? "positive" : "negative", f[c], why);
                }
                rows++;
            }
        }
        line = nl ? nl + 1 : NULL;
    }
    GS_TRY_CHECK(err, rows > 0, GS_ERR_ARG, done,
                 "%s: no table rows: expected lines 'bin, positive, negative' for bins 0, 1, ...",
                 path);
    err = gs_micro_dist_create(d, rows, pos, neg);
    if (err != GS_OK) {
        gs_error_add_context("in %s", path);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    }
done:
    gs_free(text);
    gs_free(pos);
    gs_free(neg);
    return err;
}

gs_err gs_micro_dist_check_sum(const double *pos, size_t npos, const double *neg, size_t nneg,
                               double tol, const char *what)
{
    double sp = 0, sn = 0;
    for (size_t k = 0; k < npos; k++) {
        GS_CHECK(pos[k] >= 0 && isfinite(pos[k]), GS_ERR_ARG,
                 "%s: positive bin %zu has probability %g: expected >= 0", what, k, pos[k]);
        sp += pos[k];
    }
    for (size_t k = 0; k < nneg; k++) {
        GS_CHECK(neg[k] >= 0 && isfinite(neg[k]), GS_ERR_ARG,
                 "%s: negative bin %zu has probability %g: expected >= 0", what, k, neg[k]);
        sn += neg[k];
    }
    tol += 1e-12; /* 0.27 + 0.72 is 0.99 only up to rounding */
    int joint = fabs(sp + sn - 1) <= tol, each = fabs(sp - 1) <= tol && fabs(sn - 1) <= tol;
    GS_CHECK(joint || each, GS_ERR_ARG,
             "%s: probabilities sum to %g (positive %g + negative %g): expected 1 together "
             "(the regions' area shares) or 1 per side (equal areas), within %g",
             what, sp + sn, sp, sn, tol);
    return GS_OK;
}
