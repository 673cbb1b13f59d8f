/* Shared helpers for the unit tests; see testutil.h. */
#include "testutil.h"

#include <stdio.h>
#include <stdlib.h>

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
