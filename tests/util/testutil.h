/* Shared helpers for the unit tests (linked into every test program). */
#ifndef GEOSYNTH_TESTUTIL_H
#define GEOSYNTH_TESTUTIL_H

/* A private temporary directory for one test program: use
 * gs_test_tmpdir_setup / gs_test_tmpdir_teardown as the cmocka group
 * setup/teardown; the directory's path is in gs_test_tmpdir. */
extern char gs_test_tmpdir[64];
int gs_test_tmpdir_setup(void **state);
int gs_test_tmpdir_teardown(void **state);

#endif
