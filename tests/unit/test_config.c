/* Unit tests for src/core/config.c: every key type, every problem class,
 * overrides, path resolution, the resolved text round trip, help. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "geosynth/config.h"
#include "geosynth/error.h"
#include "geosynth/mem.h"
#include "../util/testutil.h"

typedef struct test_cfg {
    int unrelated_before;
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
    int unrelated_after;
} test_cfg;

static void validate(const void *p, gs_cfg_ctx *ctx)
{
    const test_cfg *c = p;
    double sum = 0;
    for (int64_t i = 0; i < c->hist.n; i++)
        sum += c->hist.v[i];
    if (sum > 1.0 + 1e-12)
        gs_cfg_report(ctx, "micro.hist", "fractions add up to %g, more than 1", sum);
}

static const gs_cfg_key keys[] = {
    GS_CFG_KEY_INT(test_cfg, block, "field.block", 2, 64, GS_CFG_POW2, "16",
                   "block edge in voxels"),
    GS_CFG_KEY_REAL(test_cfg, weight, "field.weight", 0, 10, GS_CFG_OPEN_LO, "1.5",
                    "weight of the coherence term"),
    GS_CFG_KEY_BOOL(test_cfg, smooth, "field.smooth", "false", "smooth the seams"),
    GS_CFG_KEY_STRING(test_cfg, name, "field.name", "demo", "name of the run"),
    GS_CFG_KEY_PATH(test_cfg, source, "field.source", NULL, "example to synthesize from"),
    GS_CFG_KEY_PATH(test_cfg, mask, "field.mask", "", "optional mask field"),
    GS_CFG_KEY_ENUM(test_cfg, method, "field.method", "exhaustive|tree|pca", "tree",
                    "nearest-block search"),
    GS_CFG_KEY_INT3(test_cfg, size, "field.size", 1, 4096, 0, "64", "output size in voxels"),
    GS_CFG_KEY_INT(test_cfg, levels, "field.pyramid.levels", 1, 8, 0, "3", "pyramid levels"),
    GS_CFG_KEY_REAL_LIST(test_cfg, hist, "micro.hist", 0, 1, 0, "0.25, 0.75",
                         "target histogram fractions"),
    GS_CFG_KEY_REAL_LIST(test_cfg, extra, "micro.extra", -1e6, 1e6, 0, "", "extra values"),
    GS_CFG_RUN_KEYS(test_cfg, run, "test"),
};
static const gs_cfg_table table = GS_CFG_TABLE("test", test_cfg, keys, validate);

static char tmpdir[256];
static char cwd[4096];

static int setup(void **state)
{
    (void)state;
    snprintf(tmpdir, sizeof tmpdir, "/tmp/gs-test-config-XXXXXX");
    if (!mkdtemp(tmpdir))
        return -1;
    if (!getcwd(cwd, sizeof cwd))
        return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[512];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    return system(cmd) == 0 ? 0 : -1;
}

/* Writes text to tmpdir/name and returns the path (static buffer). */
static const char *write_file(const char *name, const char *text, size_t len)
{
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    char *slash = strrchr(path, '/');
    *slash = '\0';
    mkdir(path, 0700);
    *slash = '/';
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, len, f), len);
    fclose(f);
    return path;
}

static const char *write_text(const char *name, const char *text)
{
    return write_file(name, text, strlen(text));
}

/* Index of the first problem containing every one of the NULL-terminated
 * needles, or -1. */
static int find_problem(const gs_cfg_problems *p, ...)
{
    for (size_t i = 0; i < p->nkept; i++) {
        va_list ap;
        va_start(ap, p);
        int all = 1;
        for (const char *s = va_arg(ap, const char *); s; s = va_arg(ap, const char *))
            all &= strstr(p->msg[i], s) != NULL;
        va_end(ap);
        if (all)
            return (int)i;
    }
    return -1;
}

static void dump(const gs_cfg_problems *p) { gs_cfg_problems_print(p, stderr); }

static void test_table_check(void **state)
{
    (void)state;
    assert_int_equal(gs_config_table_check(&table), GS_OK);
    static const gs_cfg_key bad_default[] = {
        GS_CFG_KEY_INT(test_cfg, block, "field.block", 2, 64, GS_CFG_POW2, "12", "x"),
    };
    static const gs_cfg_table t1 = GS_CFG_TABLE("bad", test_cfg, bad_default, NULL);
    assert_int_equal(gs_config_table_check(&t1), GS_ERR_INTERNAL);
    assert_non_null(strstr(gs_error_message(), "field.block"));
    assert_non_null(strstr(gs_error_message(), "power of two"));
    static const gs_cfg_key dup[] = {
        GS_CFG_KEY_INT(test_cfg, block, "field.block", 2, 64, 0, "4", "x"),
        GS_CFG_KEY_INT(test_cfg, levels, "field.block", 2, 64, 0, "4", "x"),
    };
    static const gs_cfg_table t2 = GS_CFG_TABLE("dup", test_cfg, dup, NULL);
    assert_int_equal(gs_config_table_check(&t2), GS_ERR_INTERNAL);
    assert_non_null(strstr(gs_error_message(), "twice"));
    static const gs_cfg_key bad_name[] = {
        GS_CFG_KEY_INT(test_cfg, block, "Block", 2, 64, 0, "4", "x"),
    };
    static const gs_cfg_table t3 = GS_CFG_TABLE("name", test_cfg, bad_name, NULL);
    assert_int_equal(gs_config_table_check(&t3), GS_ERR_INTERNAL);
    static const gs_cfg_key bad_enum[] = {
        GS_CFG_KEY_ENUM(test_cfg, method, "field.method", "a||b", "a", "x"),
    };
    static const gs_cfg_table t4 = GS_CFG_TABLE("enum", test_cfg, bad_enum, NULL);
    assert_int_equal(gs_config_table_check(&t4), GS_ERR_INTERNAL);
    gs_error_clear();
}

static void test_every_type(void **state)
{
    (void)state;
    const char *path = write_text("sub/all.ini",
                                  "; comment\n"
                                  "# another\n"
                                  "[field]\n"
                                  "block = 32\n"
                                  "weight: 2.5e-1   ; inline comment\n"
                                  "smooth = Yes # inline hash comment\n"
                                  "  name = hello world   \n"
                                  "source = ../data/./ex.h5\n"
                                  "mask = /abs//mask.h5\n"
                                  "method = PCA\n"
                                  "size = 64 x 32x16\n"
                                  "[field.pyramid]\n"
                                  "levels = 5\n"
                                  "[micro]\n"
                                  "hist = 0.1, 0.2 0.3,0.4\n"
                                  "extra = -1e3\n"
                                  "[ run ]\n"
                                  "seed = 18446744073709551615\n"
                                  "seed_x = 1\n");
    /* The seed above is out of range for int64 and seed_x unknown: fix
     * them and check the good file. */
    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    test_cfg c;
    memset(&c, 0, sizeof c);
    assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_ERR_ARG);
    assert_int_equal(p.n, 2);
    assert_true(find_problem(&p, "all.ini:18:", "[run] seed = 18446744073709551615",
                             "expected an integer >= 0 (out of range)", NULL) >= 0);
    assert_true(find_problem(&p, "all.ini:19:", "[run] seed_x = 1", "unknown key",
                             "did you mean 'seed'?", NULL) >= 0);
    gs_cfg_problems_free(&p);

    path = write_text("sub/all.ini", "[field]\n"
                                     "block = 32\n"
                                     "weight: 2.5e-1   ; inline comment\n"
                                     "smooth = Yes # inline hash comment\n"
                                     "  name = hello world   \n"
                                     "source = ../data/./ex.h5\n"
                                     "mask = /abs//mask.h5\n"
                                     "method = PCA\n"
                                     "size = 64 x 32x16\n"
                                     "[field.pyramid]\n"
                                     "levels = 5\n"
                                     "[micro]\n"
                                     "hist = 0.1, 0.2 0.3,0.4\n"
                                     "extra = -1e3\n"
                                     "[ run ]\n"
                                     "seed = 9223372036854775807\n"
                                     "log_level = DEBUG\n"
                                     "checkpoint_seconds = 0\n");
    c.unrelated_before = 11;
    c.unrelated_after = 22;
    assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_OK);
    assert_int_equal(p.n, 0);
    assert_int_equal(c.unrelated_before, 11);
    assert_int_equal(c.unrelated_after, 22);
    assert_int_equal(c.block, 32);
    assert_true(c.weight == 0.25);
    assert_int_equal(c.smooth, 1);
    assert_string_equal(c.name, "hello world");
    char expect[4200];
    snprintf(expect, sizeof expect, "%s/data/ex.h5", tmpdir); /* relative to the file */
    assert_string_equal(c.source, expect);
    assert_string_equal(c.mask, "/abs/mask.h5");
    assert_string_equal(c.method, "pca");
    assert_int_equal(c.size[0], 64);
    assert_int_equal(c.size[1], 32);
    assert_int_equal(c.size[2], 16);
    assert_int_equal(c.levels, 5);
    assert_int_equal(c.hist.n, 4);
    assert_true(c.hist.v[0] == 0.1 && c.hist.v[3] == 0.4);
    assert_int_equal(c.extra.n, 1);
    assert_true(c.extra.v[0] == -1000.0);
    assert_true(c.run.seed == INT64_MAX);
    assert_string_equal(c.run.log_level, "debug");
    assert_true(c.run.checkpoint_seconds == 0.0);
    assert_int_equal(c.run.checkpoint_every, 0);
    /* default run.output resolves against the current directory */
    snprintf(expect, sizeof expect, "%s/runs/test", cwd);
    assert_string_equal(c.run.output, expect);
    gs_config_free(&table, &c);
    assert_null(c.name);
    assert_null(c.hist.v);
    assert_int_equal(c.hist.n, 0);
    gs_config_free(&table, &c); /* twice is harmless */
}

static void test_defaults_and_empty_file(void **state)
{
    (void)state;
    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    test_cfg c;
    memset(&c, 0, sizeof c);
    /* Empty file: every default, but the required key is reported. */
    const char *path = write_text("empty.ini", "");
    assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_ERR_ARG);
    assert_int_equal(p.n, 1);
    assert_true(find_problem(&p, "empty.ini: [field] source: required key missing",
                             "--set field.source=", NULL) >= 0);
    assert_non_null(strstr(gs_error_message(), "1 problem in"));
    assert_null(c.name); /* unchanged on failure */
    gs_cfg_problems_free(&p);
    const char *set[] = {"field.source = x.h5"};
    assert_int_equal(gs_config_load(&table, path, set, 1, &c, &p), GS_OK);
    assert_int_equal(c.block, 16);
    assert_true(c.weight == 1.5);
    assert_int_equal(c.smooth, 0);
    assert_string_equal(c.name, "demo");
    assert_string_equal(c.mask, "");
    assert_string_equal(c.method, "tree");
    assert_int_equal(c.size[0], 64);
    assert_int_equal(c.size[2], 64);
    assert_int_equal(c.levels, 3);
    assert_int_equal(c.hist.n, 2);
    assert_int_equal(c.extra.n, 0);
    assert_null(c.extra.v);
    assert_true(c.run.seed == 1);
    assert_true(c.run.checkpoint_seconds == 300.0);
    assert_string_equal(c.run.log_level, "info");
    char expect[4200];
    snprintf(expect, sizeof expect, "%s/x.h5", cwd); /* override: relative to cwd */
    assert_string_equal(c.source, expect);
    gs_config_free(&table, &c);
    /* No file at all: the same. */
    assert_int_equal(gs_config_load(&table, NULL, set, 1, &c, &p), GS_OK);
    assert_int_equal(c.block, 16);
    gs_config_free(&table, &c);
    /* Only comments and blank lines, CRLF and a BOM. */
    path = write_text("comments.ini", "\xEF\xBB\xBF; only comments\r\n\r\n   # x\r\n[field]\r\n"
                                      "source = a.h5\r\n");
    assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_OK);
    snprintf(expect, sizeof expect, "%s/a.h5", tmpdir);
    assert_string_equal(c.source, expect);
    gs_config_free(&table, &c);
    assert_int_equal(p.n, 0);
}

static void test_all_problems_at_once(void **state)
{
    (void)state;
    const char *path = write_text("bad.ini",
                                  "[field]\n"                       /* 1 */
                                  "blok = 16\n"                     /* 2 */
                                  "block = 12x\n"                   /* 3 */
                                  "block = 8\n"                     /* 4 duplicate */
                                  "weight = nan\n"                  /* 5 */
                                  "smooth = maybe\n"                /* 6 */
                                  "method = kdtree\n"               /* 7 */
                                  "size = 64x0x16\n"                /* 8 */
                                  "this line has no equals\n"       /* 9 */
                                  "[feild]\n"                       /* 10 */
                                  "source = x\n"                    /* 11 ignored */
                                  "[micro]\n"                       /* 12 */
                                  "hist = 0.5, 2\n"                 /* 13 */
                                  "extra = 1,,2\n"                  /* 14 */
                                  "seed = 4\n"                      /* 15 wrong section */
                                  "[run\n"                          /* 16 */
                                  "[run]\n"                         /* 17 */
                                  "checkpoint_seconds = inf\n"      /* 18 */
                                  "checkpoint_every = -1\n"         /* 19 */
                                  "[field]\n"                       /* 20 */
                                  "weight = 0\n"                    /* 21 duplicate across headers */
                                  "[field.pyramid]\n"               /* 22 */
                                  "levels = 99999999999999999999\n" /* 23 */
                                  "[field]\n"                       /* 24 */
                                  "mask =\n"                        /* 25 fine: optional */
                                  "name =\n");                      /* 26 empty not ok */
    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    test_cfg c;
    memset(&c, 0, sizeof c);
    assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_ERR_ARG);
    dump(&p);
    struct {
        const char *a, *b, *c;
    } want[] = {
        {"bad.ini:2: [field] blok = 16", "unknown key", "did you mean 'block'?"},
        {"bad.ini:3: [field] block = 12x", "expected an integer power of two in [2, 64]", ""},
        {"bad.ini:4: [field] block = 8", "duplicate key (first set on line 3)", ""},
        {"bad.ini:5: [field] weight = nan", "expected a number in (0, 10]", "(not finite)"},
        {"bad.ini:6: [field] smooth = maybe", "expected true or false", ""},
        {"bad.ini:7: [field] method = kdtree", "expected one of exhaustive|tree|pca", ""},
        {"bad.ini:8: [field] size = 64x0x16", "element 2 is '0'", "(out of range)"},
        {"bad.ini:9:", "expected 'name = value', '[section]' or a comment", ""},
        {"bad.ini:10: [feild]", "unknown section", "did you mean [field]?"},
        {"bad.ini:13: [micro] hist = 0.5, 2", "element 2 is '2'", "in [0, 1]"},
        {"bad.ini:14: [micro] extra = 1,,2", "empty element", ""},
        {"bad.ini:15: [micro] seed = 4", "unknown key", "did you mean 'seed' in section [run]?"},
        {"bad.ini:16:", "without closing ']'", ""},
        {"bad.ini:18: [run] checkpoint_seconds = inf", "(not finite)", ""},
        {"bad.ini:19: [run] checkpoint_every = -1", "expected an integer >= 0", "(out of range)"},
        {"bad.ini:21: [field] weight = 0", "duplicate key (first set on line 5)", ""},
        {"bad.ini:23: [field.pyramid] levels = 99999999999999999999", "in [1, 8]",
         "(out of range)"},
        {"bad.ini:26: [field] name = ", "expected text, got an empty value", ""},
        {"bad.ini: [field] source: required key missing", "", ""},
    };
    size_t nwant = sizeof want / sizeof want[0];
    for (size_t i = 0; i < nwant; i++) {
        if (find_problem(&p, want[i].a, want[i].b, want[i].c, NULL) < 0)
            fail_msg("no problem matches '%s' '%s' '%s'", want[i].a, want[i].b, want[i].c);
    }
    assert_int_equal(p.n, nwant);
    /* The problems come in file order. */
    assert_non_null(strstr(p.msg[0], ":2:"));
    assert_non_null(strstr(p.msg[1], ":3:"));
    char summary[64];
    snprintf(summary, sizeof summary, "%zu problems in %s", nwant, path);
    assert_string_equal(gs_error_message(), summary);
    assert_null(c.name);
    gs_cfg_problems_free(&p);
    gs_error_clear();
}

static void test_suggestions(void **state)
{
    (void)state;
    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    test_cfg c;
    memset(&c, 0, sizeof c);
    const char *text = "source = a\n"       /* outside any section */
                       "[fild]\n"
                       "[zzzzzz]\n"
                       "[field]\n"
                       "Block = 4\n"        /* case */
                       "field.source = b\n" /* dotted name inside a section */
                       "qqqqqqqqqq = 1\n";
    assert_int_equal(gs_config_parse_text(&table, text, strlen(text), "s.ini", NULL, NULL, 0, &c,
                                          &p),
                     GS_ERR_ARG);
    dump(&p);
    assert_true(find_problem(&p, "s.ini:1: source = a: key outside any [section]",
                             "did you mean 'source' in section [field]?", NULL) >= 0);
    assert_true(find_problem(&p, "s.ini:2: [fild]: unknown section; did you mean [field]?",
                             NULL) >= 0);
    assert_true(find_problem(&p, "s.ini:3: [zzzzzz]: unknown section (sections: [field] "
                                 "[field.pyramid] [micro] [run])",
                             NULL) >= 0);
    assert_true(find_problem(&p, "s.ini:5: [field] Block = 4: unknown key; did you mean 'block'?",
                             NULL) >= 0);
    assert_true(find_problem(&p, "s.ini:6: [field] field.source = b: unknown key; did you mean "
                                 "'source'?",
                             NULL) >= 0);
    int i = find_problem(&p, "s.ini:7: [field] qqqqqqqqqq = 1: unknown key", NULL);
    assert_true(i >= 0);
    assert_null(strstr(p.msg[i], "did you mean"));
    assert_non_null(strstr(p.msg[i], "(see geosynth test --help)"));
    gs_cfg_problems_free(&p);
    gs_error_clear();
}

static void test_overrides(void **state)
{
    (void)state;
    const char *path = write_text("ov.ini", "[field]\nsource = s.h5\nblock = 8\n[run]\nseed = 5\n");
    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    test_cfg c;
    memset(&c, 0, sizeof c);
    const char *good[] = {"field.block=32", "run.seed = 7", "run.seed=9", "field.mask=m/../k.h5",
                          "micro.hist=0.5 0.5", "field.size=8,4,2", "run.output=~/out"};
    assert_int_equal(gs_config_load(&table, path, good, 7, &c, &p), GS_OK);
    assert_int_equal(c.block, 32);   /* override beats the file */
    assert_true(c.run.seed == 9);    /* last --set wins */
    char expect[4200];
    snprintf(expect, sizeof expect, "%s/k.h5", cwd);
    assert_string_equal(c.mask, expect);
    snprintf(expect, sizeof expect, "%s/s.h5", tmpdir);
    assert_string_equal(c.source, expect);
    assert_int_equal(c.hist.n, 2);
    assert_int_equal(c.size[0], 8);
    assert_int_equal(c.size[2], 2);
    const char *home = getenv("HOME");
    if (home && home[0] == '/') {
        assert_true(strncmp(c.run.output, home, strlen(home) - (strlen(home) > 1)) == 0);
        assert_non_null(strstr(c.run.output, "/out"));
    }
    gs_config_free(&table, &c);

    const char *bad[] = {"field.block=3", "field.blok=4", "noequals", "field.name=a ;b",
                         "feild.block=4", "field.weight=0", "field.name=;b"};
    assert_int_equal(gs_config_load(&table, path, bad, 7, &c, &p), GS_ERR_ARG);
    dump(&p);
    assert_int_equal(p.n, 7);
    assert_true(find_problem(&p, "--set field.weight=0: expected a number in (0, 10] (out of range)",
                             NULL) >= 0);
    assert_true(find_problem(&p, "--set field.block=3: expected an integer power of two in [2, 64]",
                             "(not a power of two)", NULL) >= 0);
    assert_true(find_problem(&p, "--set field.blok=4: unknown key; did you mean 'field.block'?",
                             NULL) >= 0);
    assert_true(find_problem(&p, "--set noequals: expected section.key=value", NULL) >= 0);
    assert_true(find_problem(&p, "--set field.name=a ;b:", "would start a comment", NULL) >= 0);
    /* written back as "name = ;b" it would read as empty (found by fuzz_config) */
    assert_true(find_problem(&p, "--set field.name=;b:", "at the start would start a comment",
                             NULL) >= 0);
    assert_true(find_problem(&p, "--set feild.block=4: unknown key; did you mean 'field.block'?",
                             NULL) >= 0);
    gs_cfg_problems_free(&p);

    /* Cross-key validation runs once the keys are fine, and names the origin. */
    const char *sum[] = {"micro.hist=0.9,0.9"};
    assert_int_equal(gs_config_load(&table, path, sum, 1, &c, &p), GS_ERR_ARG);
    assert_true(find_problem(&p, "--set micro.hist=0.9,0.9: fractions add up to 1.8", NULL) >= 0);
    gs_cfg_problems_free(&p);
    path = write_text("sum.ini", "[field]\nsource = s\n[micro]\nhist = 0.6 0.6\n");
    assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_ERR_ARG);
    assert_true(find_problem(&p, "sum.ini:4: [micro] hist = 0.6 0.6: fractions add up to 1.2",
                             NULL) >= 0);
    gs_cfg_problems_free(&p);
    gs_error_clear();
}

static void test_file_problems(void **state)
{
    (void)state;
    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    test_cfg c;
    memset(&c, 0, sizeof c);
    char missing[600];
    snprintf(missing, sizeof missing, "%s/nope.ini", tmpdir);
    assert_int_equal(gs_config_load(&table, missing, NULL, 0, &c, &p), GS_ERR_IO);
    assert_non_null(strstr(gs_error_message(), missing));
    assert_non_null(strstr(gs_error_message(), "No such file"));
    assert_int_equal(gs_config_load(&table, tmpdir, NULL, 0, &c, &p), GS_ERR_IO);
    assert_non_null(strstr(gs_error_message(), "is a directory"));
    if (geteuid() != 0) { /* root reads anything */
        const char *path = write_text("locked.ini", "[field]\n");
        chmod(path, 0);
        assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_ERR_IO);
        assert_non_null(strstr(gs_error_message(), "Permission denied"));
    }
    assert_int_equal(p.n, 0);

    static const char binary[] = "[field]\nsource = a\n\0\x01\x02\xff";
    const char *path = write_file("bin.ini", binary, sizeof binary);
    assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_ERR_ARG);
    assert_int_equal(p.n, 1);
    assert_true(find_problem(&p, "bin.ini: not a text file (NUL byte at offset 19)", NULL) >= 0);
    gs_cfg_problems_free(&p);

    /* An over-long line and a control character; the lines after still count. */
    size_t n = GS_CFG_MAX_LINE + 100;
    char *text = malloc(n + 64);
    assert_non_null(text);
    strcpy(text, "[field]\nname = ");
    size_t at = strlen(text);
    memset(text + at, 'a', n - at);
    strcpy(text + n, "\nsource\x07 = x\nblock = 3\n");
    path = write_text("long.ini", text);
    free(text);
    assert_int_equal(gs_config_load(&table, path, NULL, 0, &c, &p), GS_ERR_ARG);
    dump(&p);
    assert_true(find_problem(&p, "long.ini:2: line is", "at most 65535 allowed", NULL) >= 0);
    assert_true(find_problem(&p, "long.ini:3: control character 0x07 at column 7", NULL) >= 0);
    assert_true(find_problem(&p, "long.ini:4: [field] block = 3", NULL) >= 0);
    gs_cfg_problems_free(&p);
    gs_error_clear();
}

static void test_many_problems_capped(void **state)
{
    (void)state;
    size_t len = 0;
    char *text = malloc(300 * 16);
    assert_non_null(text);
    len += (size_t)sprintf(text, "[field]\n");
    for (int i = 0; i < 300; i++)
        len += (size_t)sprintf(text + len, "bogus%d = 1\n", i);
    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    test_cfg c;
    memset(&c, 0, sizeof c);
    assert_int_equal(gs_config_parse_text(&table, text, len, "many.ini", NULL, NULL, 0, &c, &p),
                     GS_ERR_ARG);
    free(text);
    assert_int_equal(p.n, 301); /* 300 unknown keys + missing source */
    assert_int_equal(p.nkept, GS_CFG_MAX_PROBLEMS);
    char *buf = gs_test_problems_text(&p);
    assert_non_null(strstr(buf, "error: ... and 201 more problems"));
    free(buf);
    gs_cfg_problems_free(&p);
    gs_error_clear();
}

static void test_round_trip(void **state)
{
    (void)state;
    const char *path = write_text("rt.ini", "[field]\nsource = d/e.h5\nweight = 0.1\nsize=7\n"
                                            "smooth = on\nname = a;b #c\n"
                                            "[micro]\nhist = 1e-300 0.3333333333333333 -0\n"
                                            "extra = 1e6, -1e6, 123456.789\n");
    gs_cfg_problems p = GS_CFG_PROBLEMS_INIT;
    test_cfg a, b, c2;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    memset(&c2, 0, sizeof c2);
    const char *set[] = {"run.seed=123456789012345"};
    assert_int_equal(gs_config_load(&table, path, set, 1, &a, &p), GS_OK);
    assert_string_equal(a.name, "a;b");
    char *t1 = NULL, *t2 = NULL, *t3 = NULL;
    assert_int_equal(gs_config_resolved_text(&table, &a, &t1), GS_OK);
    fprintf(stderr, "%s", t1);
    assert_non_null(strstr(t1, "\n[field]\n# block edge in voxels (an integer power of two in "
                               "[2, 64]; default 16)\nblock = 16\n"));
    assert_non_null(strstr(t1, "\nweight = 0.1\n"));
    assert_non_null(strstr(t1, "\nsize = 7x7x7\n"));
    assert_non_null(strstr(t1, "\nsmooth = true\n"));
    assert_non_null(strstr(t1, "\nhist = 1e-300, 0.3333333333333333, 0\n"));
    assert_non_null(strstr(t1, "\nmask =\n"));
    assert_non_null(strstr(t1, "\n[field.pyramid]\n"));
    assert_non_null(strstr(t1, "\nseed = 123456789012345\n"));
    /* Parsed again from another directory base: the identical struct and text. */
    assert_int_equal(gs_config_parse_text(&table, t1, strlen(t1), "resolved", "/", NULL, 0, &b,
                                          &p),
                     GS_OK);
    assert_int_equal(gs_config_resolved_text(&table, &b, &t2), GS_OK);
    assert_string_equal(t1, t2);
    assert_int_equal(a.block, b.block);
    assert_true(a.weight == b.weight);
    assert_string_equal(a.source, b.source);
    assert_string_equal(a.mask, b.mask);
    assert_int_equal(a.hist.n, b.hist.n);
    for (int64_t i = 0; i < a.hist.n; i++)
        assert_true(a.hist.v[i] == b.hist.v[i]);
    assert_true(!signbit(b.hist.v[2]));
    for (int64_t i = 0; i < a.extra.n; i++)
        assert_true(a.extra.v[i] == b.extra.v[i]);
    assert_true(a.run.seed == b.run.seed);
    /* Same input, same bytes. */
    assert_int_equal(gs_config_load(&table, path, set, 1, &c2, &p), GS_OK);
    assert_int_equal(gs_config_resolved_text(&table, &c2, &t3), GS_OK);
    assert_string_equal(t1, t3);
    /* A value no file can hold is refused, not written wrongly. */
    char *saved = b.name;
    b.name = "x ;y";
    char *t4 = NULL;
    assert_int_equal(gs_config_resolved_text(&table, &b, &t4), GS_ERR_ARG);
    assert_non_null(strstr(gs_error_message(), "field.name"));
    b.name = saved;
    /* A path that normalizes into a value no file can hold ("x /." is the
     * directory "x "): refused at parse time, naming the key and the reason. */
    gs_cfg_problems q = GS_CFG_PROBLEMS_INIT;
    test_cfg e;
    memset(&e, 0, sizeof e);
    const char *blank = "[field]\nsource = x /.\n";
    assert_int_equal(gs_config_parse_text(&table, blank, strlen(blank), "blank.ini", "/b", NULL, 0,
                                          &e, &q),
                     GS_ERR_ARG);
    assert_int_equal(q.n, 1);
    char *msg = gs_test_problems_text(&q);
    fprintf(stderr, "%s", msg);
    assert_non_null(strstr(msg, "blank.ini:2: [field] source"));
    assert_non_null(strstr(msg, "/b/x '"));
    assert_non_null(strstr(msg, "blanks"));
    free(msg);
    gs_cfg_problems_free(&q);
    gs_free(t1);
    gs_free(t2);
    gs_free(t3);
    gs_config_free(&table, &a);
    gs_config_free(&table, &b);
    gs_config_free(&table, &c2);
    assert_int_equal(p.n, 0);
    gs_error_clear();
}

static void test_help(void **state)
{
    (void)state;
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    gs_config_print_help(&table, f);
    fclose(f);
    fprintf(stderr, "%s", buf);
    assert_non_null(strstr(buf, "geosynth test"));
    assert_non_null(strstr(buf, "\n[field]\n"));
    assert_non_null(strstr(buf, "\n[run]\n"));
    assert_non_null(strstr(buf, "block edge in voxels"));
    assert_non_null(strstr(buf, "an integer power of two in [2, 64]; default 16"));
    assert_non_null(strstr(buf, "a path; required"));
    assert_non_null(strstr(buf, "one of exhaustive|tree|pca; default tree"));
    assert_non_null(strstr(buf, "a number in (0, 10]; default 1.5"));
    assert_non_null(strstr(buf, "one of error|warn|info|debug; default info"));
    assert_non_null(strstr(buf, "default: none"));
    free(buf);
}

typedef struct events {
    char log[2048];
} events;

static void record(void *user, int line, const char *section, const char *name,
                   const char *value, const char *error)
{
    events *e = user;
    size_t n = strlen(e->log);
    if (error)
        snprintf(e->log + n, sizeof e->log - n, "%d!%s|", line, error);
    else if (!name)
        snprintf(e->log + n, sizeof e->log - n, "%d[%s]|", line, section);
    else
        snprintf(e->log + n, sizeof e->log - n, "%d:%s.%s=%s|", line, section, name, value);
}

static void test_ini_scan(void **state)
{
    (void)state;
    events e = {""};
    const char *text = "a=1\n[ s ] ; c\n  k : v;x ; comment\nk2 = ;gone\nk3 =;kept\n"
                       "[t]x\n= 5\n  # c\nlast = a # b";
    int lines = gs_ini_scan(text, strlen(text), record, &e);
    assert_int_equal(lines, 9);
    assert_string_equal(e.log, "1:.a=1|2[s]|3:s.k=v;x|4:s.k2=|5:s.k3=;kept|"
                               "6!text after the section header's ']'|"
                               "7!missing key name before '='|9:s.last=a|");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_table_check),
        cmocka_unit_test(test_every_type),
        cmocka_unit_test(test_defaults_and_empty_file),
        cmocka_unit_test(test_all_problems_at_once),
        cmocka_unit_test(test_suggestions),
        cmocka_unit_test(test_overrides),
        cmocka_unit_test(test_file_problems),
        cmocka_unit_test(test_many_problems_capped),
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_help),
        cmocka_unit_test(test_ini_scan),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
