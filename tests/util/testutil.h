/* Shared helpers for the unit tests (linked into every test program). */
#ifndef GEOSYNTH_TESTUTIL_H
#define GEOSYNTH_TESTUTIL_H

#include <stddef.h>

#include "geosynth/config.h"
#include "geosynth/model.h"

/* A private temporary directory for one test program: use
 * gs_test_tmpdir_setup / gs_test_tmpdir_teardown as the cmocka group
 * setup/teardown; the directory's path is in gs_test_tmpdir. */
extern char gs_test_tmpdir[64];
int gs_test_tmpdir_setup(void **state);
int gs_test_tmpdir_teardown(void **state);

/* Example data: the absolute path of rel ("meshes/spot.obj") under the data
 * root (GS_DATA, else this tree's data/; include/geosynth/data.h) into buf.
 * Returns buf (cap >= 4096 is plenty). */
const char *gs_test_data(const char *rel, char *buf, size_t cap);

/* Whether every file rel... (NULL-terminated) is under the data root. A
 * missing file that `make data` fetches (listed in scripts/data-manifest.tsv)
 * makes the test skip: it prints one line "check skipped: needs ${data}/REL,
 * ... (fetched by `make data`)" (the reason tests/run.sh reports) and returns 0 for GS_TEST_NEED_DATA to call
 * cmocka's skip(). A missing file that is not in the manifest (a file the
 * repository itself should hold) is a failure, not a skip: it returns -1. */
int gs_test_have_data(const char *rel, ...);

/* In a cmocka test: skip it (with the reason printed) unless the data is
 * there; fail it when a file that should be in the repository is missing. */
#define GS_TEST_NEED_DATA(...)                                    \
    do {                                                          \
        int gs_have_ = gs_test_have_data(__VA_ARGS__, (char *)0); \
        if (gs_have_ < 0)                                         \
            fail_msg("example data missing from the repository"); \
        if (gs_have_ == 0)                                        \
            skip();                                               \
    } while (0)

/* Reads Paul Merrell's samples/NAME (a .txt fetched by `make data`) into *ex,
 * skipping the cmocka test when it is absent (GS_TEST_NEED_DATA) and failing
 * it when it cannot be read. Call first in a test, before anything is
 * allocated (a skip leaves the test at once). */
void gs_test_read_merrell_sample(const char *name, gs_model_lattice *ex);

/* What gs_cfg_problems_print writes for p, as a NUL-terminated text
 * (malloc'ed: free()); fails the cmocka test when it cannot be captured. */
char *gs_test_problems_text(const gs_cfg_problems *p);

#endif
