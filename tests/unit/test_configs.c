/* Every ready config, configs/ENGINE/NAME.ini, parses and validates with its
 * engine's real config table (gs_config_load), so a shipped config never
 * fails on a typo or a range. Run from tests/ (tests/run.sh) or with
 * GS_ROOT set. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/config.h"
#include "geosynth/engines.h"
#include "geosynth/mem.h"

static void test_every_config_loads(void **state)
{
    (void)state;
    const char *root = getenv("GS_ROOT");
    int count = 0, loaded = 0, failed = 0;
    const gs_engine *const *engines = gs_engines(&count);
    for (int e = 0; e < count; e++) {
        const gs_engine *eng = engines[e];
        char dir[1024];
        snprintf(dir, sizeof dir, "%s/configs/%s", root ? root : "..", eng->name);
        DIR *d = opendir(dir);
        assert_non_null(d);
        struct dirent *ent;
        while ((ent = readdir(d)) != NULL) {
            size_t n = strlen(ent->d_name);
            if (n < 5 || strcmp(ent->d_name + n - 4, ".ini") != 0)
                continue;
            char path[2048];
            snprintf(path, sizeof path, "%s/%s", dir, ent->d_name);
            void *cfg = gs_calloc(1, eng->config_size);
            assert_non_null(cfg);
            gs_cfg_problems pr = GS_CFG_PROBLEMS_INIT;
            gs_err err = gs_config_load(eng->config, path, NULL, 0, cfg, &pr);
            if (err) {
                print_error("%s: %s\n", path, gs_error_message());
                gs_cfg_problems_print(&pr, stderr);
                failed++;
            } else {
                loaded++;
            }
            gs_cfg_problems_free(&pr);
            gs_config_free(eng->config, cfg);
            gs_free(cfg);
            gs_error_clear();
        }
        closedir(d);
    }
    print_message("%d configs loaded, %d failed\n", loaded, failed);
    assert_int_equal(failed, 0);
    assert_true(loaded >= 10);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_config_loads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
