/* libFuzzer target for the config parser (src/core/config.c).
 *
 * Input: optional leading lines "--set section.key=value" (overrides), then
 * INI text. Properties checked on every input:
 *  - parsing never crashes, leaks or reads out of bounds (ASan/UBSan);
 *  - a failure returns GS_ERR_ARG with at least one problem, and leaves the
 *    output struct untouched;
 *  - on success the resolved text parses again to the identical text (the
 *    round trip every rank and every resume relies on);
 *  - on inputs inside the subset where inih and gs_ini_scan must agree
 *    (short lines, no indentation, no '#' after a blank, no control bytes),
 *    gs_ini_scan reports the same (section, name, value) sequence as inih's
 *    ini_parse_string and inih reports no error.
 */
#include <ctype.h>
#include <ini.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/config.h"
#include "geosynth/error.h"
#include "geosynth/mem.h"

typedef struct fz_cfg {
    int64_t block;
    double weight;
    int smooth;
    char *name;
    char *source;
    char *mask;
    char *method;
    int64_t size[3];
    int64_t levels;
    gs_cfg_real_list hist;
    gs_cfg_real_list extra;
    gs_run_config run;
} fz_cfg;

static void validate(const void *p, gs_cfg_ctx *ctx)
{
    const fz_cfg *c = p;
    if (c->size[0] * c->size[1] > 1000000)
        gs_cfg_report(ctx, "field.size", "too many voxels per slice");
}

static const gs_cfg_key keys[] = {
    GS_CFG_KEY_INT(fz_cfg, block, "field.block", 2, 64, GS_CFG_POW2, "16", "block edge"),
    GS_CFG_KEY_REAL(fz_cfg, weight, "field.weight", 0, 10, GS_CFG_OPEN_LO, "1.5", "weight"),
    GS_CFG_KEY_BOOL(fz_cfg, smooth, "field.smooth", "false", "smooth seams"),
    GS_CFG_KEY_STRING(fz_cfg, name, "field.name", "demo", "run name"),
    GS_CFG_KEY_PATH(fz_cfg, source, "field.source", "in.h5", "example"),
    GS_CFG_KEY_PATH(fz_cfg, mask, "field.mask", "", "mask"),
    GS_CFG_KEY_ENUM(fz_cfg, method, "field.method", "exhaustive|tree|pca", "tree", "search"),
    GS_CFG_KEY_INT3(fz_cfg, size, "field.size", 1, 4096, 0, "64", "output size"),
    GS_CFG_KEY_INT(fz_cfg, levels, "field.pyramid.levels", 1, 8, 0, "3", "levels"),
    GS_CFG_KEY_REAL_LIST(fz_cfg, hist, "micro.hist", 0, 1, 0, "0.25, 0.75", "histogram"),
    GS_CFG_KEY_REAL_LIST(fz_cfg, extra, "micro.extra", -1e6, 1e6, 0, "", "extra"),
    GS_CFG_RUN_KEYS(fz_cfg, run, "fuzz"),
};
static const gs_cfg_table table = GS_CFG_TABLE("fuzz", fz_cfg, keys, validate);

/* Event logs for the differential check; '\x1f' separates fields. */
typedef struct evlog {
    char *s;
    size_t n, cap;
    int errors;
} evlog;

static void ev_add(evlog *e, const char *a, size_t na)
{
    if (e->n + na + 2 > e->cap) {
        e->cap = (e->n + na + 2) * 2;
        e->s = realloc(e->s, e->cap);
        if (!e->s)
            abort();
    }
    memcpy(e->s + e->n, a, na);
    e->n += na;
    e->s[e->n++] = '\x1f';
    e->s[e->n] = '\0';
}

static void on_scan(void *user, int line, const char *section, const char *name,
                    const char *value, const char *error)
{
    evlog *e = user;
    (void)line;
    if (error) {
        e->errors++;
        return;
    }
    if (!name)
        return;
    ev_add(e, section, strlen(section));
    ev_add(e, name, strlen(name));
    ev_add(e, value, strlen(value));
}

static int on_inih(void *user, const char *section, const char *name, const char *value)
{
    evlog *e = user;
    /* inih keeps blanks inside the brackets; gs_ini_scan trims them. */
    while (*section && isspace((unsigned char)*section))
        section++;
    size_t ns = strlen(section);
    while (ns && isspace((unsigned char)section[ns - 1]))
        ns--;
    ev_add(e, section, ns);
    ev_add(e, name, strlen(name));
    ev_add(e, value, strlen(value));
    return 1;
}

/* Inputs where inih (Debian build: 200-byte lines, multi-line values on,
 * only ';' inline comments) and gs_ini_scan must produce the same events. */
static int in_common_subset(const char *s, size_t n)
{
    size_t col = 0;
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c == '\n') {
            col = 0;
            continue;
        }
        if (c < 0x20 || c == 0x7f)
            return 0;
        if (col == 0 && (c == ' ' || c == '\t'))
            return 0;
        if (c == '#' && i > 0 && isspace((unsigned char)s[i - 1]))
            return 0;
        if (++col > 45)
            return 0;
    }
    return 1;
}

static void differential(const char *text, size_t n)
{
    if (!in_common_subset(text, n))
        return;
    evlog mine = {0}, theirs = {0};
    gs_ini_scan(text, n, on_scan, &mine);
    if (mine.errors == 0) {
        char *z = malloc(n + 1);
        if (!z)
            abort();
        memcpy(z, text, n);
        z[n] = '\0';
        int rc = ini_parse_string(z, on_inih, &theirs);
        if (rc != 0) {
            fprintf(stderr, "inih reports an error at line %d that gs_ini_scan accepted\n", rc);
            abort();
        }
        if ((mine.s || theirs.s) &&
            (!mine.s || !theirs.s || mine.n != theirs.n || memcmp(mine.s, theirs.s, mine.n))) {
            fprintf(stderr, "gs_ini_scan and inih disagree:\n  ours:  %s\n  inih:  %s\n",
                    mine.s ? mine.s : "", theirs.s ? theirs.s : "");
            abort();
        }
        free(z);
    }
    free(mine.s);
    free(theirs.s);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *text = (const char *)data;
    size_t len = size;
    /* Leading "--set " lines are overrides. */
    char *ovbuf[8];
    const char *ov[8];
    size_t nov = 0;
    while (nov < 8 && len > 6 && !memcmp(text, "--set ", 6)) {
        const char *eol = memchr(text, '\n', len);
        size_t l = eol ? (size_t)(eol - text) : len;
        if (memchr(text, '\0', l))
            break;
        ovbuf[nov] = malloc(l - 6 + 1);
        if (!ovbuf[nov])
            abort();
        memcpy(ovbuf[nov], text + 6, l - 6);
        ovbuf[nov][l - 6] = '\0';
        ov[nov] = ovbuf[nov];
        nov++;
        text += l + (eol ? 1 : 0);
        len -= l + (eol ? 1 : 0);
    }

    differential(text, len);

    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    fz_cfg c;
    memset(&c, 0xA5, sizeof c);
    fz_cfg before = c;
    gs_err err = gs_config_parse_text(&table, text, len, "fuzz.ini", "/base/dir", ov, nov, &c, &p);
    if (err != GS_OK) {
        if (err != GS_ERR_ARG || p.n == 0 || memcmp(&c, &before, sizeof c) != 0)
            abort();
    } else {
        if (p.n != 0)
            abort();
        char *t1 = NULL, *t2 = NULL;
        if (gs_config_resolved_text(&table, &c, &t1) != GS_OK)
            abort();
        fz_cfg d;
        memset(&d, 0, sizeof d);
        if (gs_config_parse_text(&table, t1, strlen(t1), "resolved", "/", NULL, 0, &d, &p) !=
            GS_OK) {
            gs_cfg_problems_print(&p, stderr);
            fprintf(stderr, "resolved text does not parse:\n%s", t1);
            abort();
        }
        if (gs_config_resolved_text(&table, &d, &t2) != GS_OK || strcmp(t1, t2) != 0) {
            fprintf(stderr, "resolved text is not a fixed point:\n%s\n---\n%s", t1, t2 ? t2 : "");
            abort();
        }
        gs_free(t1);
        gs_free(t2);
        gs_config_free(&table, &d);
        gs_config_free(&table, &c);
    }
    gs_cfg_problems_free(&p);
    gs_error_clear();
    for (size_t i = 0; i < nov; i++)
        free(ovbuf[i]);
    return 0;
}
