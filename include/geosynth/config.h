/* Configuration: one typed table of keys per engine drives INI parsing,
 * validation, defaults, `--set section.key=value` overrides, `--help` text
 * and the echo of the resolved configuration.
 *
 * An engine declares a plain struct and a table of keys that point into it:
 *
 *     typedef struct field_config {
 *         int64_t block; double weight; char *source; gs_run_config run;
 *     } field_config;
 *     static const gs_cfg_key field_keys[] = {
 *         GS_CFG_KEY_INT(field_config, block, "field.block", 2, 64, GS_CFG_POW2,
 *                        "16", "block edge in voxels"),
 *         GS_CFG_KEY_PATH(field_config, source, "field.source", NULL,
 *                         "example to synthesize from (mesh, VDB, HDF5)"),
 *         GS_CFG_RUN_KEYS(field_config, run, "field"),
 *     };
 *     const gs_cfg_table field_table = GS_CFG_TABLE("field", field_config, field_keys, NULL);
 *
 * The GS_CFG_KEY_* macros check at compile time that the member has the C
 * type the key type needs (a mismatch is a _Generic selection error).
 *
 * Key types and the C member they fill:
 *   INT        int64_t           decimal integer in [lo, hi] (GS_CFG_POW2: also a power of two)
 *   REAL       double            finite number in [lo, hi] (GS_CFG_OPEN_LO: > lo)
 *   BOOL       int               true/false, yes/no, on/off, 1/0 -> 1 or 0
 *   STRING     char *            any text without control characters
 *   PATH       char *            file or directory; stored absolute (see below)
 *   ENUM       char *            one of choices "a|b|c" (case-insensitive, stored as spelled in choices)
 *   INT3       int64_t[3]        "64" (all three), "64x32x16", "64,32,16" or "64 32 16"; x first
 *   REAL_LIST  gs_cfg_real_list  numbers separated by commas and/or blanks, each in [lo, hi],
 *                                1..GS_CFG_MAX_LIST of them
 * Integer bounds are given as doubles; bounds at or beyond +-2^63 mean the
 * int64_t limits. def is the default as user text (parsed exactly like a
 * value in a file); def == NULL makes the key required. An empty value is
 * accepted for STRING, PATH and REAL_LIST exactly when the default is ""
 * ("none"); otherwise empty is an error.
 *
 * Paths: a PATH value from a file resolves relative to that file's
 * directory, from a --set override or a default relative to the current
 * directory; "~/" means $HOME. The stored value is absolute and lexically
 * normalized ("." and ".." removed, no symlinks followed, the file need not
 * exist), so the resolved config works from any directory (`geosynth resume`).
 *
 * File syntax (inih semantics, parsed here line by line, see below):
 * `[section]` headers, `name = value` or `name : value`, blanks around
 * names and values trimmed, whole-line comments starting with ';' or '#',
 * inline comments ';' or '#' when preceded by a blank, a UTF-8 BOM skipped.
 * Differences from inih's defaults, all deliberate: no multi-line
 * continuation (an indented line is an ordinary line, not a silent append to
 * the previous value), '#' also starts inline comments, section names are
 * trimmed, text after a section's ']' is an error, every malformed line is
 * reported (inih stops at the first), lines may be up to GS_CFG_MAX_LINE
 * bytes (inih's build has a fixed 200-byte buffer and silently splits longer
 * lines, which breaks long absolute paths and line numbers). Debian's inih
 * does not pass line numbers to the handler (INI_HANDLER_LINENO = 0), which
 * is the other reason the tokenizer is ours; tests/fuzz/fuzz_config.c checks
 * it against inih's ini_parse_string() on inputs both accept.
 * A key name "sec.sub.key" lives in section [sec.sub] as key "key".
 *
 * Problems: every problem of a file and of the overrides is collected (a
 * config with three mistakes gets three messages), each naming where, the
 * key and what was expected:
 *   configs/field/grid.ini:12: [field] blok = 16: unknown key; did you mean 'block'?
 *   configs/field/grid.ini:3: [feild]: unknown section; did you mean [field]?
 *   configs/field/grid.ini:14: [field] block = 12x: expected an integer power of two in [2, 64]
 *   --set field.block=99: expected an integer power of two in [2, 64] (out of range)
 *   configs/field/grid.ini: [field] source: required key missing (example to ...)
 * An empty file (or only comments) is valid: every key takes its default and
 * only required keys are reported missing. A file containing a NUL byte is
 * "not a text file" (one problem). Overrides beat the file; when the same key
 * is overridden twice the last --set wins. A bad value in the file is still
 * reported when a --set replaces it (the file itself is wrong).
 *
 * Memory: STRING/PATH/ENUM members and REAL_LIST arrays are gs_malloc'ed and
 * owned by the struct: release with gs_config_free(). Cost: linear in the
 * text, plus a small edit distance per unknown key against all keys.
 * Thread safety: no global state; each call is independent.
 */
#ifndef GEOSYNTH_CONFIG_H
#define GEOSYNTH_CONFIG_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "geosynth/error.h"

#define GS_CFG_MAX_LINE 65536 /* bytes per line including the newline */
#define GS_CFG_MAX_LIST 2048  /* elements of a REAL_LIST */

typedef enum gs_cfg_type {
    GS_CFG_INT,
    GS_CFG_REAL,
    GS_CFG_BOOL,
    GS_CFG_STRING,
    GS_CFG_PATH,
    GS_CFG_ENUM,
    GS_CFG_INT3,
    GS_CFG_REAL_LIST
} gs_cfg_type;

/* Key flags. */
enum {
    GS_CFG_POW2 = 1u,    /* INT, INT3: value must be a power of two */
    GS_CFG_OPEN_LO = 2u  /* REAL, REAL_LIST: value must be > lo (lo itself excluded) */
};

typedef struct gs_cfg_real_list {
    double *v; /* gs_malloc'ed, n elements (NULL when n == 0) */
    int64_t n;
} gs_cfg_real_list;

typedef struct gs_cfg_key {
    const char *name;    /* "section.key": [a-z0-9_] words joined by '.' */
    gs_cfg_type type;
    double lo, hi;       /* bounds of INT, INT3, REAL and REAL_LIST elements */
    const char *def;     /* default as text; NULL = required */
    size_t offset;       /* of the member in the engine's struct */
    const char *help;    /* one line, no trailing period needed */
    const char *choices; /* ENUM: "a|b|c" */
    unsigned flags;      /* GS_CFG_POW2, GS_CFG_OPEN_LO */
} gs_cfg_key;

/* Cross-key validation: called after every key parsed without problems;
 * reports with gs_cfg_report(), which adds the key's origin and value. */
typedef struct gs_cfg_ctx gs_cfg_ctx;
typedef void (*gs_cfg_validate_fn)(const void *cfg, gs_cfg_ctx *ctx);

typedef struct gs_cfg_table {
    const char *engine;          /* "field", used in messages and the resolved text */
    const gs_cfg_key *keys;
    size_t nkeys;
    size_t size;                 /* sizeof the engine's struct */
    gs_cfg_validate_fn validate; /* may be NULL */
} gs_cfg_table;

/* Collected problems ("file:line: [section] key = value: what was expected").
 * At most GS_CFG_MAX_PROBLEMS messages are kept; n counts all of them.
 * Start from GS_CFG_PROBLEMS_INIT (or zeroed memory); free with
 * gs_cfg_problems_free(). */
#define GS_CFG_MAX_PROBLEMS 100
typedef struct gs_cfg_problems {
    char **msg;  /* gs_malloc'ed strings, nkept of them */
    size_t nkept;
    size_t n;    /* total, including those not kept */
} gs_cfg_problems;
#define GS_CFG_PROBLEMS_INIT {NULL, 0, 0}

/* Writes each kept problem as "error: MSG\n", then "... and N more" if some
 * were dropped. */
void gs_cfg_problems_print(const gs_cfg_problems *p, FILE *f);
void gs_cfg_problems_free(gs_cfg_problems *p);

/* Reports a cross-key problem from a validate callback, e.g.
 * gs_cfg_report(ctx, "micro.hi", "must be greater than micro.lo = %g", lo). */
void gs_cfg_report(gs_cfg_ctx *ctx, const char *key, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Checks a table: names well formed and unique, bounds ordered, ENUM
 * choices present, every default valid for its key. Raises GS_ERR_INTERNAL
 * naming the key (a broken table is a geosynth bug). The loaders call it. */
gs_err gs_config_table_check(const gs_cfg_table *t);

/* Reads the INI file at path (NULL: no file, defaults only), applies the
 * overrides ("section.key=value", as given to --set), fills defaults and
 * validates. On success the table's members of *out are set (other members
 * of the struct are untouched; any strings they held before are NOT freed).
 * On failure *out is unchanged and:
 *  - GS_ERR_IO if the file cannot be opened or read (message names the path
 *    and the system's reason; no problems added);
 *  - GS_ERR_ARG "N problems in PATH" with every problem appended to
 *    *problems (which may already hold some; it must not be NULL).
 * Not collective. */
gs_err gs_config_load(const gs_cfg_table *t, const char *path, const char *const *overrides,
                      size_t noverrides, void *out, gs_cfg_problems *problems);

/* The same over text in memory (len bytes, need not be NUL-terminated).
 * origin names the text in messages (a path, or e.g. "<resolved config>");
 * base_dir is the directory relative PATH values in the text resolve
 * against (NULL: the current directory). */
gs_err gs_config_parse_text(const gs_cfg_table *t, const char *text, size_t len,
                            const char *origin, const char *base_dir,
                            const char *const *overrides, size_t noverrides, void *out,
                            gs_cfg_problems *problems);

/* Canonical INI text of every key with its effective value, grouped by
 * section in table order, one "# help (type, range, default)" comment per
 * key. Parsing it again yields the identical struct and the identical text;
 * it has no timestamps, so the same config always gives the same bytes.
 * *text is gs_malloc'ed (free with gs_free). Fails (GS_ERR_ARG) only for a
 * struct that no file could produce: a string with a control character or
 * an inline-comment sequence (" ;", " #"), or leading/trailing blanks. */
gs_err gs_config_resolved_text(const gs_cfg_table *t, const void *cfg, char **text);

/* `geosynth ENGINE --help` text: every section, key, type, range or
 * choices, default (or "required") and help. */
void gs_config_print_help(const gs_cfg_table *t, FILE *f);

/* Frees the strings and lists of *cfg and sets those members to NULL / 0.
 * Safe on a zeroed struct and twice in a row. */
void gs_config_free(const gs_cfg_table *t, void *cfg);

/* The key named "section.key", or NULL. */
const gs_cfg_key *gs_config_find(const gs_cfg_table *t, const char *name);

/* Low-level tokenizer (exposed for tests and the fuzzer). Calls fn once per
 * event in file order: a section header (name == NULL), a "name = value"
 * line, or a malformed line (error != NULL, a reason such as "line has
 * neither '=' nor ':'"). section/name/value are NUL-terminated and valid
 * only during the call. Lines are numbered from 1. Returns the number of
 * lines. */
typedef void (*gs_ini_fn)(void *user, int line, const char *section, const char *name,
                          const char *value, const char *error);
int gs_ini_scan(const char *text, size_t len, gs_ini_fn fn, void *user);

/* The keys every engine shares, section [run]. Embed a gs_run_config in the
 * engine struct and splice GS_CFG_RUN_KEYS(struct_type, member, "engine")
 * into its key table. run.output defaults to "runs/ENGINE" under the
 * directory geosynth is started from; the CLI's -o DIR is the same as
 * --set run.output=DIR. */
typedef struct gs_run_config {
    int64_t seed;              /* run.seed, >= 0, default 1 */
    char *output;              /* run.output, absolute run directory */
    double checkpoint_seconds; /* run.checkpoint_seconds, 0 = off, default 300 */
    int64_t checkpoint_every;  /* run.checkpoint_every, units of work, 0 = off (default) */
    char *log_level;           /* run.log_level: error|warn|info|debug, default info */
    char *expect_digest;       /* run.expect_digest: 16 hex digits or "" (default, no check) */
} gs_run_config;

/* ---- key constructors (compile-time checked member types) ---- */

/* The type of an INT3 member. */
typedef int64_t gs_cfg_int3[3];

/* offsetof(st, m), or a compile error when m is not of type T. */
#define GS_CFG_OFFSET_(st, m, T) _Generic(&((st *)0)->m, T *: offsetof(st, m))

#define GS_CFG_KEY_INT(st, m, name, lo, hi, flags, def, help) \
    {(name), GS_CFG_INT, (lo), (hi), (def), GS_CFG_OFFSET_(st, m, int64_t), (help), NULL, (flags)}
#define GS_CFG_KEY_REAL(st, m, name, lo, hi, flags, def, help) \
    {(name), GS_CFG_REAL, (lo), (hi), (def), GS_CFG_OFFSET_(st, m, double), (help), NULL, (flags)}
#define GS_CFG_KEY_BOOL(st, m, name, def, help) \
    {(name), GS_CFG_BOOL, 0, 1, (def), GS_CFG_OFFSET_(st, m, int), (help), NULL, 0}
#define GS_CFG_KEY_STRING(st, m, name, def, help) \
    {(name), GS_CFG_STRING, 0, 0, (def), GS_CFG_OFFSET_(st, m, char *), (help), NULL, 0}
#define GS_CFG_KEY_PATH(st, m, name, def, help) \
    {(name), GS_CFG_PATH, 0, 0, (def), GS_CFG_OFFSET_(st, m, char *), (help), NULL, 0}
#define GS_CFG_KEY_ENUM(st, m, name, choices, def, help) \
    {(name), GS_CFG_ENUM, 0, 0, (def), GS_CFG_OFFSET_(st, m, char *), (help), (choices), 0}
#define GS_CFG_KEY_INT3(st, m, name, lo, hi, flags, def, help) \
    {(name), GS_CFG_INT3, (lo), (hi), (def), GS_CFG_OFFSET_(st, m, gs_cfg_int3), (help), NULL, (flags)}
#define GS_CFG_KEY_REAL_LIST(st, m, name, lo, hi, flags, def, help)                          \
    {(name), GS_CFG_REAL_LIST, (lo), (hi), (def), GS_CFG_OFFSET_(st, m, gs_cfg_real_list), \
     (help), NULL, (flags)}

/* Upper bound for INT keys that take any non-negative int64_t. */
#define GS_CFG_INT_MAX 9223372036854775807.0

#define GS_CFG_RUN_KEYS(st, member, engine)                                                  \
    GS_CFG_KEY_INT(st, member.seed, "run.seed", 0, GS_CFG_INT_MAX, 0, "1",                   \
                   "seed of every random stream; same seed + config = same output"),         \
    GS_CFG_KEY_PATH(st, member.output, "run.output", "runs/" engine,                         \
                    "run directory for outputs, checkpoint.h5, metrics.jsonl, summary.json"), \
    GS_CFG_KEY_REAL(st, member.checkpoint_seconds, "run.checkpoint_seconds", 0, 1e9, 0,      \
                    "300", "write a checkpoint every this many wall-clock seconds (0 = off)"), \
    GS_CFG_KEY_INT(st, member.checkpoint_every, "run.checkpoint_every", 0, GS_CFG_INT_MAX, 0, \
                   "0", "also checkpoint every this many units of work (0 = off)"),          \
    GS_CFG_KEY_ENUM(st, member.log_level, "run.log_level", "error|warn|info|debug", "info",  \
                    "messages printed: error < warn < info < debug"),                       \
    GS_CFG_KEY_STRING(st, member.expect_digest, "run.expect_digest", "",                     \
                      "16 hex digits: the run fails (exit 2) unless its output digest is this " \
                      "one; a match prints 'digest: HEX (verified)' (empty = no check)")

#define GS_CFG_TABLE(engine, st, keys, validate) \
    {(engine), (keys), sizeof(keys) / sizeof((keys)[0]), sizeof(st), (validate)}

#endif
