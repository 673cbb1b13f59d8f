/* Shared helpers for the unit tests; see testutil.h. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "testutil.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/data.h"
#include "geosynth/error.h"

char gs_test_tmpdir[64];

int gs_test_tmpdir_setup(void **state)
{
    (void)state;
    snprintf(gs_test_tmpdir, sizeof gs_test_tmpdir, "/tmp/gs-test-XXXXXX");
    return mkdtemp(gs_test_tmpdir) ? 0 : -1;
}

int gs_test_tmpdir_teardown(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", gs_test_tmpdir);
    return system(cmd) == 0 ? 0 : -1;
}

const char *gs_test_data(const char *rel, char *buf, size_t cap)
{
    char root[PATH_MAX], why[200];
    if (!gs_data_root(root, sizeof root, NULL, why, sizeof why)) {
        fprintf(stderr, "gs_test_data: %s\n", why);
        snprintf(root, sizeof root, "/nonexistent-data-root");
    }
    snprintf(buf, cap, "%s/%s", root, rel);
    return buf;
}

/* Whether rel is a destination of scripts/data-manifest.tsv (tests run from
 * tests/, or GS_ROOT names the tree). */
static int in_manifest(const char *rel)
{
    const char *root = getenv("GS_ROOT");
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s/scripts/data-manifest.tsv", root ? root : "..");
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    char line[8192];
    size_t n = strlen(rel);
    int found = 0;
    while (!found && fgets(line, sizeof line, f))
        found = line[0] != '#' && strncmp(line, rel, n) == 0 && line[n] == '\t';
    fclose(f);
    return found;
}

int gs_test_have_data(const char *rel, ...)
{
    va_list ap;
    va_start(ap, rel);
    int have = 1;
    char missing[4096] = "";
    for (const char *r = rel; r; r = va_arg(ap, const char *)) {
        char path[PATH_MAX + 256];
        if (access(gs_test_data(r, path, sizeof path), R_OK) == 0)
            continue;
        if (in_manifest(r)) {
            size_t n = strlen(missing);
            snprintf(missing + n, sizeof missing - n, "%s" GS_DATA_VAR "/%s", n ? ", " : "", r);
            if (have > 0)
                have = 0;
        } else {
            printf("example data missing: %s is not in the repository's data/ nor a file "
                   "`make data` fetches\n", path);
            have = -1;
        }
    }
    va_end(ap);
    if (missing[0])
        printf("check skipped: needs %s (fetched by `make data`)\n", missing);
    fflush(stdout);
    return have;
}

void gs_test_read_merrell_sample(const char *name, gs_model_lattice *ex)
{
    char rel[256], path[PATH_MAX + 256];
    snprintf(rel, sizeof rel, "model-synthesis/merrell42-model-synthesis/samples/%s", name);
    GS_TEST_NEED_DATA(rel);
    gs_err e = gs_model_read_merrell_txt(gs_test_data(rel, path, sizeof path), ex);
    if (e != GS_OK)
        gs_error_report("gs_test_read_merrell_sample: ");
    assert_int_equal(e, GS_OK);
}

char *gs_test_problems_text(const gs_cfg_problems *p)
{
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    assert_non_null(f);
    gs_cfg_problems_print(p, f);
    assert_int_equal(fclose(f), 0);
    assert_non_null(buf);
    return buf;
}
