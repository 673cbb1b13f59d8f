/* geosynth command line: global options, subcommands, engine dispatch.
 *
 * Every rank parses the same argv (mpirun passes it to all), so the
 * decisions below are identical on all ranks without communication; only
 * file contents (configs, checkpoints) are read on rank 0 and broadcast.
 * Exit codes are the gs_err values (include/geosynth/error.h, README).
 */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/config.h"
#include "geosynth/config_load.h"
#include "geosynth/data.h"
#include "geosynth/digest.h"
#include "geosynth/engines.h"
#include "geosynth/error.h"
#include "geosynth/field_examples.h"
#include "geosynth/file.h"
#include "geosynth/h5.h"
#include "geosynth/killpoint.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/model_io.h"
#include "geosynth/par.h"
#include "geosynth/parse.h"
#include "geosynth/plugin.h"
#include "geosynth/preview.h"
#include "geosynth/run.h"
#include "geosynth/vdb.h"
#include "geosynth/version.h"

#define MAX_OVERRIDES 256

typedef struct cli_args {
    const char *command;
    const char *config_path;
    const char *run_dir;
    const char *positional;
    const char *positional2;
    const char *overrides[MAX_OVERRIDES];
    int noverrides;
    int help;
    int check; /* --check: validate the config, print it resolved, run nothing */
    const char *example_out;  /* example --out FILE */
    const char *example_size; /* example --size N */
    const char *example_seed; /* example --seed S */
    const char *files[GS_PREVIEW_MAX_PANELS]; /* preview MESH... */
    int nfiles;
} cli_args;

static int log_level_from_cli = 0;

static gs_log_level log_level_from_name(const char *name)
{
    static const char *names[] = {"error", "warn", "info", "debug"};
    for (int i = 0; i < 4; i++)
        if (name && !strcmp(name, names[i]))
            return (gs_log_level)i;
    return GS_LOG_INFO;
}

static void print_usage(FILE *out)
{
    int n;
    const gs_engine *const *engines = gs_engines(&n);
    fprintf(out,
            "geosynth %s: synthesize large geometry from a small example (MPI batch program)\n"
            "\n"
            "usage: [mpirun -np N] geosynth [-v|-q] COMMAND [options]\n"
            "\n"
            "commands:\n",
            GS_VERSION_STRING);
    for (int i = 0; i < n; i++)
        fprintf(out, "  %-9s -c CONFIG.ini [-o RUN_DIR] [--set section.key=value ...]\n"
                     "            %s\n",
                engines[i]->name, engines[i]->summary);
    fprintf(out,
            "  resume    RUN_DIR [--set run.key=value ...]\n"
            "            continue an interrupted run from RUN_DIR/checkpoint.h5 (any rank count)\n"
            "  example   grid|chainmail|balls|fibers|spheres --out FILE.obj|.ply [--size N] [--seed S]\n"
            "            write a built-in field example as a closed mesh (default size 64, seed 1)\n"
            "  preview   --out FILE.png [--size N] MESH...\n"
            "            render meshes (.ply/.obj/.off/...) side by side into one PNG, N pixels\n"
            "            per panel (default 512), e.g. the example and a run's output\n"
            "  model-check EXAMPLE OUTPUT\n"
            "            list adjacent label pairs of OUTPUT that never occur in EXAMPLE (.txt,\n"
            "            .vox, .h5) or that the WFC tile set EXAMPLE.xml[#SUBSET] does not allow;\n"
            "            exit 0 when there are none, 2 otherwise\n"
            "  inspect   FILE.h5\n"
            "            summarize a geosynth HDF5 file (checkpoint or output)\n"
            "  version   print program, format and library versions\n"
            "  help      [COMMAND]  this text, or a command's options and config keys\n"
            "\n"
            "global options:\n"
            "  -v, --verbose   more log output (debug)      -q, --quiet   only warnings and errors\n"
            "  -h, --help      this text                    --version     same as 'version'\n"
            "\n"
            "engine options:\n"
            "  -c, --config FILE      INI config (see configs/ and 'geosynth help ENGINE')\n"
            "  -o, --output DIR       run directory (overrides run.output)\n"
            "  --set section.key=VAL  override one config key (repeatable)\n"
            "  --check                validate the config (the real parser, every key and path)\n"
            "                         and print it resolved; runs nothing, exit 0 or 2/3\n"
            "\n"
            "outputs: RUN_DIR/summary.json (digest, timings, metrics), RUN_DIR/metrics.jsonl,\n"
            "RUN_DIR/checkpoint.h5 and the engine's outputs.\n"
            "\n"
            "exit codes: 0 ok, 1 usage, 2 bad input or config, 3 I/O, 4 file format,\n"
            "5 out of memory, 6 MPI, 7 external library, 8 internal error, 9 interrupted\n");
    if (n == 0)
        fprintf(out, "\n(this build has no synthesis engines yet)\n");
}

static void print_engine_help(const gs_engine *e, FILE *out)
{
    fprintf(out, "geosynth %s: %s\n\nusage: [mpirun -np N] geosynth %s -c CONFIG.ini "
                 "[-o RUN_DIR] [--set section.key=value ...]\n\nconfig keys:\n",
            e->name, e->summary, e->name);
    gs_config_print_help(e->config, out);
}

static gs_err usage_error(const char *fmt, const char *arg)
{
    return gs_error_raise(GS_ERR_USAGE, __FILE__, __LINE__, __func__, fmt, arg);
}

/* Levenshtein distance, for "did you mean". */
static size_t edit_distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 64 || lb > 64)
        return 99;
    size_t d[65][65];
    for (size_t i = 0; i <= la; i++)
        d[i][0] = i;
    for (size_t j = 0; j <= lb; j++)
        d[0][j] = j;
    for (size_t i = 1; i <= la; i++)
        for (size_t j = 1; j <= lb; j++) {
            size_t sub = d[i - 1][j - 1] + (a[i - 1] != b[j - 1]);
            size_t del = d[i - 1][j] + 1, ins = d[i][j - 1] + 1;
            d[i][j] = sub < del ? (sub < ins ? sub : ins) : (del < ins ? del : ins);
        }
    return d[la][lb];
}

static const char *closest_command(const char *name)
{
    static const char *builtins[] = {"resume", "inspect", "version", "help", "example",
                                     "model-check", "preview"};
    const char *best = NULL;
    size_t best_d = 3;
    int n;
    const gs_engine *const *engines = gs_engines(&n);
    for (int i = 0; i < n + (int)(sizeof builtins / sizeof builtins[0]); i++) {
        const char *cand = i < n ? engines[i]->name : builtins[i - n];
        size_t dist = edit_distance(name, cand);
        if (dist < best_d) {
            best_d = dist;
            best = cand;
        }
    }
    return best;
}

static gs_err parse_args(int argc, char **argv, cli_args *a)
{
    memset(a, 0, sizeof *a);
    for (int i = 1; i < argc; i++) {
        const char *s = argv[i];
        int has_next = i + 1 < argc;
        if (!strcmp(s, "-v") || !strcmp(s, "--verbose")) {
            gs_log_set_level(GS_LOG_DEBUG);
            log_level_from_cli = 1;
        } else if (!strcmp(s, "-q") || !strcmp(s, "--quiet")) {
            gs_log_set_level(GS_LOG_WARN);
            log_level_from_cli = 1;
        } else if (!strcmp(s, "-h") || !strcmp(s, "--help")) {
            a->help = 1;
        } else if (!strcmp(s, "--check")) {
            a->check = 1;
        } else if (!strcmp(s, "--version")) {
            a->command = "version";
        } else if (!strcmp(s, "-c") || !strcmp(s, "--config")) {
            if (!has_next)
                return usage_error("%s needs a file name", s);
            a->config_path = argv[++i];
        } else if (!strcmp(s, "-o") || !strcmp(s, "--output")) {
            if (!has_next)
                return usage_error("%s needs a directory", s);
            a->run_dir = argv[++i];
        } else if (!strcmp(s, "--set") || !strncmp(s, "--set=", 6)) {
            const char *v = s[5] == '=' ? s + 6 : (has_next ? argv[++i] : NULL);
            if (!v)
                return usage_error("%s needs section.key=value", s);
            if (!strchr(v, '='))
                return usage_error("--set %s: expected section.key=value", v);
            if (a->noverrides >= MAX_OVERRIDES)
                return usage_error("too many --set options (the limit is %s)", "256");
            a->overrides[a->noverrides++] = v;
        } else if (!strcmp(s, "--out") || !strcmp(s, "--size") || !strcmp(s, "--seed")) {
            if (!has_next)
                return usage_error("%s needs a value", s);
            const char **slot = s[2] == 'o' ? &a->example_out : s[3] == 'i' ? &a->example_size
                                                                             : &a->example_seed;
            *slot = argv[++i];
        } else if (s[0] == '-' && s[1] != '\0') {
            return usage_error("unknown option '%s' (see geosynth --help)", s);
        } else if (!a->command) {
            a->command = s;
        } else if (!a->positional) {
            a->positional = s;
        } else if (!a->positional2 && a->command && !strcmp(a->command, "model-check")) {
            a->positional2 = s;
        } else if (a->command && !strcmp(a->command, "preview")) {
            if (a->nfiles == 0)
                a->files[a->nfiles++] = a->positional;
            if (a->nfiles >= GS_PREVIEW_MAX_PANELS)
                return usage_error("preview: at most %s meshes side by side", "8");
            a->files[a->nfiles++] = s;
        } else {
            return usage_error("unexpected argument '%s' (see geosynth --help)", s);
        }
    }
    return GS_OK;
}

/* `geosynth example KIND --out FILE [--size N] [--seed S]` (rank 0 writes). */
static gs_err cmd_example(const cli_args *a)
{
    if (!a->positional || !a->example_out)
        return usage_error("example needs a kind and --out FILE: geosynth example %s --out x.obj",
                           GS_EXAMPLE_KINDS);
    int64_t size = 64, seed = 1;
    char why[160];
    GS_CHECK(!a->example_size || gs_parse_i64(a->example_size, 8, 1024, &size, why, sizeof why),
             GS_ERR_USAGE, "example --size %s: %s", a->example_size, why);
    GS_CHECK(!a->example_seed || gs_parse_i64(a->example_seed, 0, INT64_MAX, &seed, why, sizeof why),
             GS_ERR_USAGE, "example --seed %s: %s", a->example_seed, why);
    gs_mesh m;
    GS_CALL(gs_field_example_mesh(a->positional, size, (uint64_t)seed, &m));
    gs_err err = gs_mesh_write(a->example_out, &m, NULL);
    if (!err)
        gs_log(GS_LOG_INFO, "example %s: %zu vertices, %zu triangles -> %s", a->positional,
               m.nverts, m.ntris, a->example_out);
    gs_mesh_destroy(&m);
    GS_CALL(err);
    return GS_OK;
}

/* `geosynth preview --out FILE.png [--size N] MESH...` (rank 0 renders):
 * the meshes side by side, each fitted to its panel, example first by
 * convention (include/geosynth/preview.h). */
static gs_err cmd_preview(const cli_args *a)
{
    const char *files[GS_PREVIEW_MAX_PANELS];
    int n = a->nfiles;
    memcpy(files, a->files, sizeof files);
    if (n == 0 && a->positional)
        files[n++] = a->positional;
    if (n == 0 || !a->example_out)
        return usage_error("preview needs --out FILE.png and one or more meshes: geosynth preview "
                           "--out p.png example.obj output.ply%s", "");
    int64_t side = 512;
    char why[160];
    GS_CHECK(!a->example_size || gs_parse_i64(a->example_size, 16, 2048, &side, why, sizeof why),
             GS_ERR_USAGE, "preview --size %s: %s", a->example_size, why);
    gs_mesh meshes[GS_PREVIEW_MAX_PANELS];
    gs_preview_panel panels[GS_PREVIEW_MAX_PANELS];
    int loaded = 0;
    gs_err err = GS_OK;
    for (; loaded < n && !err; loaded++) {
        err = gs_mesh_read(files[loaded], &meshes[loaded]);
        panels[loaded] = (gs_preview_panel){&meshes[loaded], NULL, NULL};
    }
    if (err)
        loaded--; /* the failed read left nothing to free */
    if (!err)
        err = gs_preview_write(a->example_out, panels, n, (int)side);
    if (!err)
        gs_log(GS_LOG_INFO, "preview of %d mesh%s -> %s", n, n > 1 ? "es" : "", a->example_out);
    for (int i = 0; i < loaded; i++)
        gs_mesh_destroy(&meshes[i]);
    GS_CALL(err);
    return GS_OK;
}

static int cmd_version(void)
{
    if (gs_par_rank() == 0) {
        int major, minor;
        char lib[256];
        gs_par_mpi_version(&major, &minor, lib, sizeof lib);
        printf("geosynth %s (file format %d)\n", GS_VERSION_STRING, GS_FORMAT_VERSION);
        printf("MPI %d.%d: %s\n", major, minor, lib);
        printf("%s\n", gs_h5_library_version());
        const char *vdb; /* loads the plugin, or says why it cannot */
        if (gs_vdb_library_version(&vdb) == GS_OK) {
            printf("OpenVDB %s (plugin %s)\n", vdb, gs_plugin_path("vdb"));
        } else {
            printf("OpenVDB: not available: %s\n", gs_error_message());
            gs_error_clear();
        }
        int n;
        const gs_engine *const *engines = gs_engines(&n);
        printf("engines:");
        for (int i = 0; i < n; i++)
            printf(" %s", engines[i]->name);
        printf("%s\n", n ? "" : " (none)");
    }
    return 0;
}

/* Every input file a config names (PATH keys other than run.output) must be
 * readable, checked before a run starts (and by --check), so a missing file
 * is one clear message naming the config, the key and the file, plus the
 * data root and the command that fetches it for a ${data} file. Rank 0
 * looks (it is the rank that reads inputs) and prints; the answer is agreed
 * on. Collective. */
static gs_err check_inputs(const gs_engine *e, const void *cfg, const char *origin)
{
    const gs_cfg_table *t = e->config;
    int missing = 0;
    for (size_t i = 0; i < t->nkeys && gs_par_rank() == 0; i++) {
        const gs_cfg_key *k = &t->keys[i];
        if (k->type != GS_CFG_PATH || !strcmp(k->name, "run.output"))
            continue;
        const char *path = *(char *const *)((const char *)cfg + k->offset);
        if (!path || !*path || access(path, R_OK) == 0)
            continue;
        char hint[3 * PATH_MAX], line[3 * PATH_MAX];
        snprintf(line, sizeof line, "error: %s: %s = %s: %s", origin, k->name, path,
                 strerror(errno));
        gs_text_sanitize(line);
        fprintf(stderr, "%s\n", line);
        if (gs_data_missing_hint(path, hint, sizeof hint)) {
            gs_text_sanitize(hint);
            fprintf(stderr, "       %s\n", hint);
        }
        missing++;
    }
    gs_err err = GS_OK;
    if (missing)
        err = gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, __func__,
                             "%d input file%s named in %s cannot be read", missing,
                             missing > 1 ? "s" : "", origin);
    return gs_par_agree(MPI_COMM_WORLD, err);
}

/* The inputs' digests (#25 item 2): one GS_INPUT_TAG line per input file
 * the config names (every PATH key but run.output; see gs_input_line)
 * appended to the resolved config on a fresh run, so that start.ini and
 * every checkpoint record them; `resume` checks each against the file as it
 * is now and refuses a changed one (the result would no longer be the
 * run's). The files those name in turn are noted by their readers and
 * recorded by the run (gs_input_note). Rank 0; *lines is gs_malloc'ed (""
 * when the config names none). */
static gs_err input_digests(const gs_engine *e, const void *cfg, char **lines)
{
    char *s = gs_malloc(1);
    GS_CHECK(s, GS_ERR_MEM, "out of memory for the inputs' digests");
    s[0] = '\0';
    size_t len = 0;
    const gs_cfg_table *t = e->config;
    gs_err err = GS_OK;
    for (size_t i = 0; i < t->nkeys && !err; i++) {
        const gs_cfg_key *k = &t->keys[i];
        if (k->type != GS_CFG_PATH || !strcmp(k->name, "run.output"))
            continue;
        const char *path = *(char *const *)((const char *)cfg + k->offset);
        if (!path || !*path)
            continue;
        char *line = NULL;
        err = gs_input_line(k->name, path, &line);
        if (err)
            break;
        size_t n = strlen(line);
        char *grown = gs_realloc(s, len + n + 1);
        if (!grown) {
            gs_free(line);
            err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                 "out of memory for the inputs' digests");
            break;
        }
        s = grown;
        memcpy(s + len, line, n + 1);
        len += n;
        gs_free(line);
    }
    if (err) {
        gs_free(s);
        return err;
    }
    *lines = s;
    return GS_OK;
}

/* Rank 0 of a resume: every "; input" line of the stored config text
 * against the file now; *lines gets those lines (to be recorded again). */
static gs_err input_verify(const char *stored, const char *dir, const char *origin, char **lines)
{
    size_t cap = strlen(stored) + 1, len = 0;
    char *s = gs_malloc(cap);
    GS_CHECK(s, GS_ERR_MEM, "out of memory for the inputs' digests");
    s[0] = '\0';
    int changed = 0;
    char first[3 * PATH_MAX] = "";
    for (const char *p = stored; p && *p;) {
        const char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p) : strlen(p);
        if (n > strlen(GS_INPUT_TAG) && !strncmp(p, GS_INPUT_TAG, strlen(GS_INPUT_TAG)) &&
            n < 2 * PATH_MAX) {
            char line[2 * PATH_MAX], key[128], hex[17];
            unsigned long long bytes = 0;
            int at = 0;
            memcpy(line, p, n);
            line[n] = '\0';
            memcpy(s + len, line, n);
            len += n;
            s[len++] = '\n';
            s[len] = '\0';
            if (sscanf(line + strlen(GS_INPUT_TAG), "%127s xxh3 %16s %llu %n", key, hex, &bytes,
                       &at) < 3 || !at) {
                gs_free(s);
                GS_RAISE(GS_ERR_FORMAT, "%s: damaged input record '%.200s'", origin, line);
            }
            const char *path = line + strlen(GS_INPUT_TAG) + at;
            uint64_t h = 0, now = 0;
            char hex_now[17] = "(unreadable)";
            gs_err err = gs_digest_file(path, &h, &now);
            if (!err)
                gs_digest_hex(h, hex_now);
            else
                gs_error_clear();
            if (err || strcmp(hex, hex_now) || now != bytes) {
                char why[PATH_MAX + 256];
                if (err)
                    snprintf(why, sizeof why, "%s = %s cannot be read any more", key, path);
                else
                    snprintf(why, sizeof why,
                             "%s = %s has changed since the run started (then XXH3 %s, %llu "
                             "bytes; now %s, %llu bytes)",
                             key, path, hex, bytes, hex_now, (unsigned long long)now);
                if (!changed++)
                    snprintf(first, sizeof first, "%s", why);
                else
                    gs_log(GS_LOG_ERROR, "%s: also %s", dir, why);
            }
        }
        p = nl ? nl + 1 : NULL;
    }
    if (changed) {
        gs_free(s);
        GS_RAISE(GS_ERR_ARG,
                 "cannot resume %s: %s%s; resuming would not give the run's output: put the "
                 "original input back, or start a new run",
                 dir, first, changed > 1 ? " (and the inputs listed above)" : "");
    }
    *lines = s;
    return GS_OK;
}

/* Runs an engine fresh (resume = 0) or from RUN_DIR (resume = 1).
 * Collective. Config problems are collective failures. */
static gs_err run_engine(const gs_engine *e, const cli_args *a, const char *resume_config,
                         int restart, int *collective)
{
    int resume = resume_config != NULL && !restart;
    *collective = 1;
    char *resolved = NULL;
    void *cfg = gs_calloc(1, e->config_size);
    GS_CHECK(cfg != NULL, GS_ERR_MEM, "cannot allocate config");
    const char *overrides[MAX_OVERRIDES + 1];
    int nov = 0;
    for (int i = 0; i < a->noverrides; i++)
        overrides[nov++] = a->overrides[i];
    char out_override[PATH_MAX + 16];
    if (a->run_dir) {
        snprintf(out_override, sizeof out_override, "run.output=%s", a->run_dir);
        overrides[nov++] = out_override;
    }
    gs_err err;
    if (resume_config) {
        err = gs_config_text_collective(MPI_COMM_WORLD, e->config, resume_config,
                                        restart ? "(config stored in " GS_RUN_START_FILE ")"
                                                : "(config stored in the checkpoint)",
                                        overrides,
                                        (size_t)nov, cfg, &resolved);
    } else {
        err = gs_config_load_collective(MPI_COMM_WORLD, e->config, a->config_path, overrides,
                                        (size_t)nov, cfg, &resolved);
    }
    if (err) {
        gs_free(cfg);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    char origin[PATH_MAX + 32];
    snprintf(origin, sizeof origin, "%s", a->config_path ? a->config_path : "");
    if (resume_config)
        snprintf(origin, sizeof origin, "%s/%s (its stored config)", a->positional,
                 restart ? GS_RUN_START_FILE : "checkpoint.h5");
    err = check_inputs(e, cfg, origin);
    if (err && !a->check) {
        gs_config_free(e->config, cfg);
        gs_free(cfg);
        gs_free(resolved);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    if (a->check) { /* --check: the config is valid; show what a run would use */
        if (!err && gs_par_rank() == 0)
            fputs(resolved, stdout);
        gs_config_free(e->config, cfg);
        gs_free(cfg);
        gs_free(resolved);
        if (err)
            gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    char *inputs = NULL;
    if (gs_par_rank() == 0)
        err = resume_config ? input_verify(resume_config, a->positional, origin, &inputs)
                            : input_digests(e, cfg, &inputs);
    err = gs_par_agree(MPI_COMM_WORLD, err);
    if (!err && gs_par_rank() == 0 && inputs[0]) {
        size_t n = strlen(resolved) + strlen(inputs) + 1;
        char *both = gs_malloc(n);
        if (both) {
            snprintf(both, n, "%s%s", resolved, inputs);
            gs_free(resolved);
            resolved = both;
        } else {
            err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                 "out of memory for the config");
        }
    }
    gs_free(inputs);
    err = gs_par_agree(MPI_COMM_WORLD, err);
    if (!err && gs_par_rank() != 0) {
        gs_free(resolved);
        resolved = NULL;
    }
    if (!err)
        err = gs_par_bcast_string(MPI_COMM_WORLD, &resolved, 0) ? gs_error_code() : GS_OK;
    if (err) {
        gs_config_free(e->config, cfg);
        gs_free(cfg);
        gs_free(resolved);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    const gs_run_config *rc = (const gs_run_config *)((const char *)cfg + e->run_offset);
    if (!log_level_from_cli)
        gs_log_set_level(log_level_from_name(rc->log_level));
    gs_kill_point_setup(gs_par_rank(), resume_config != NULL); /* test hook GS_KILL_AT */
    gs_run run;
    err = gs_run_open(&run, MPI_COMM_WORLD, e->name, resume_config ? a->positional : rc->output,
                      resolved, (uint64_t)rc->seed, resume);
    if (!err) {
        gs_log_section("INPUT SUMMARY");
        gs_log(GS_LOG_INFO, "geosynth %s%s, %d rank%s, seed %llu, run directory %s", e->name,
               resume ? " (resumed)" : "", run.size, run.size > 1 ? "s" : "",
               (unsigned long long)rc->seed, run.dir);
        gs_run_set_checkpointing(&run, rc->checkpoint_seconds, rc->checkpoint_every);
        err = gs_run_expect_digest(&run, rc->expect_digest);
    }
    if (!err) {
        *collective = 0; /* engine failures may be local to one rank */
        err = gs_engine_drive(e, &run, cfg, resume);
        if (err)
            gs_error_push_frame(__FILE__, __LINE__, __func__);
        if (err && run.failed_together)
            *collective = 1;
    }
    gs_run_close(&run);
    gs_config_free(e->config, cfg);
    gs_free(cfg);
    gs_free(resolved);
    return err;
}

static gs_err cmd_resume(const cli_args *a, int *collective)
{
    *collective = 1;
    if (!a->positional)
        return usage_error("resume needs a run directory%s", "");
    GS_CHECK(a->run_dir == NULL, GS_ERR_USAGE,
             "resume continues in RUN_DIR itself; -o is not allowed");
    /* Only keys that do not touch the result: run.seed and run.output used
     * to be accepted, ignored by the output and recorded in summary.json. */
    static const char *const resumable[] = {"run.checkpoint_seconds=", "run.checkpoint_every=",
                                            "run.log_level=", "run.expect_digest="};
    for (int i = 0; i < a->noverrides; i++) {
        int fine = 0;
        for (size_t k = 0; k < sizeof resumable / sizeof *resumable; k++)
            fine |= !strncmp(a->overrides[i], resumable[k], strlen(resumable[k]));
        GS_CHECK(fine, GS_ERR_USAGE,
                 "resume --set %.200s: only run.checkpoint_seconds, run.checkpoint_every, "
                 "run.log_level and run.expect_digest may change when resuming (the others "
                 "would change the result or where it goes; start a new run for that)",
                 a->overrides[i]);
    }
    char engine[64] = "";
    char *config_text = NULL;
    gs_err err = GS_OK;
    int restart = 0;
    if (gs_par_rank() == 0) {
        char path[PATH_MAX], start[PATH_MAX];
        snprintf(path, sizeof path, "%s/checkpoint.h5", a->positional);
        snprintf(start, sizeof start, "%s/%s", a->positional, GS_RUN_START_FILE);
        err = gs_run_resume_prepare(a->positional);
        if (!err && access(path, F_OK) != 0 && access(start, F_OK) == 0) {
            /* Killed before its first checkpoint: start again from start.ini. */
            size_t len = 0;
            err = gs_file_read_all(start, (size_t)256 << 20, &config_text, &len);
            char *nl = err ? NULL : strchr(config_text, '\n');
            if (!err && (strncmp(config_text, "; geosynth ", 11) || !nl ||
                         (size_t)(nl - config_text) - 11 >= sizeof engine))
                err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                                     "%s: first line is not '; geosynth ENGINE'", start);
            if (!err) {
                memcpy(engine, config_text + 11, (size_t)(nl - config_text) - 11);
                restart = 1;
                gs_log(GS_LOG_WARN,
                       "%s has no checkpoint (the run stopped before its first one): starting it "
                       "again from %s",
                       a->positional, start);
            }
        } else if (!err && access(path, F_OK) != 0 && errno == ENOENT &&
                   access(start, F_OK) != 0 && errno == ENOENT) {
            /* A kill before start.ini was in place (or not a run directory). */
            err = gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, __func__,
                                 "cannot resume %s: there is neither %s nor %s (a run killed "
                                 "before it recorded its config, or not a run directory): "
                                 "start the run again with 'geosynth ENGINE -c CONFIG -o %s'",
                                 a->positional, path, start, a->positional);
        } else if (!err) {
            err = gs_ckpt_peek(path, engine, sizeof engine, &config_text);
        }
    }
    err = gs_par_agree(MPI_COMM_WORLD, err);
    if (!err)
        err = GS_PAR_BCAST_VALUE(MPI_COMM_WORLD, &restart, 0);
    if (!err)
        err = gs_par_bcast_string(MPI_COMM_WORLD, &config_text, 0) ? gs_error_code() : GS_OK;
    if (!err)
        err = GS_PAR_BCAST_VALUE(MPI_COMM_WORLD, &engine, 0);
    const gs_engine *e = err ? NULL : gs_engine_find(engine);
    if (!err && !e)
        err = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                             "%s/checkpoint.h5 belongs to engine '%s', which this build of "
                             "geosynth does not have",
                             a->positional, engine);
    /* -o is not allowed, so run.output comes from the stored config; the run
     * directory itself is a->positional (it may have been moved). */
    if (!err)
        err = run_engine(e, a, config_text, restart, collective);
    gs_free(config_text);
    return err;
}

int main(int argc, char **argv)
{
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    int rank = gs_par_rank();
    cli_args a;
    err = parse_args(argc, argv, &a);
    if (err) {
        if (rank == 0)
            fprintf(stderr, "geosynth: %s\n", gs_error_message());
        gs_par_finalize();
        return GS_ERR_USAGE;
    }
    int collective = 1;
    if (!a.command || !strcmp(a.command, "help")) {
        const gs_engine *e = a.positional ? gs_engine_find(a.positional) : NULL;
        if (rank == 0) {
            if (e)
                print_engine_help(e, stdout);
            else
                print_usage(a.command || a.help ? stdout : stderr);
        }
        gs_par_finalize();
        return a.command || a.help ? 0 : GS_ERR_USAGE;
    }
    if (!strcmp(a.command, "version")) {
        cmd_version();
        gs_par_finalize();
        return 0;
    }
    const gs_engine *engine = gs_engine_find(a.command);
    if (a.help) {
        if (rank == 0) {
            if (engine)
                print_engine_help(engine, stdout);
            else
                print_usage(stdout);
        }
        gs_par_finalize();
        return 0;
    }
    if ((a.example_out || a.example_size || a.example_seed) && strcmp(a.command, "example") &&
        (strcmp(a.command, "preview") || a.example_seed)) {
        err = usage_error("--out, --size and --seed belong to 'geosynth example' (not %s)",
                          a.command);
        err = gs_par_agree(MPI_COMM_WORLD, err);
    } else if (!strcmp(a.command, "example")) {
        err = rank == 0 ? cmd_example(&a) : GS_OK;
        err = gs_par_agree(MPI_COMM_WORLD, err);
    } else if (!strcmp(a.command, "preview")) {
        err = rank == 0 ? cmd_preview(&a) : GS_OK;
        err = gs_par_agree(MPI_COMM_WORLD, err);
    } else if (!strcmp(a.command, "inspect")) {
        if (!a.positional) {
            err = usage_error("inspect needs a file name%s", "");
        } else if (rank == 0) {
            err = gs_inspect_file(a.positional, stdout);
        }
        err = gs_par_agree(MPI_COMM_WORLD, err);
    } else if (!strcmp(a.command, "model-check")) {
        if (!a.positional2) {
            err = usage_error("model-check needs two files: EXAMPLE OUTPUT%s", "");
        } else if (rank == 0) {
            size_t nv = 0;
            err = gs_model_check_files(a.positional, a.positional2, stdout, 50, &nv);
            if (!err && nv)
                err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                     "%s: %zu adjacent pairs never occur in the example %s",
                                     a.positional2, nv, a.positional);
        }
        err = gs_par_agree(MPI_COMM_WORLD, err);
    } else if (a.check && !engine) {
        err = usage_error("--check belongs to an engine: geosynth ENGINE -c CONFIG --check "
                          "(not %s)", a.command);
    } else if (!strcmp(a.command, "resume")) {
        err = cmd_resume(&a, &collective);
    } else if (engine) {
        if (!a.config_path) {
            err = usage_error("%s needs a config: geosynth ENGINE -c CONFIG.ini (see configs/)",
                              a.command);
        } else if (a.positional) {
            err = usage_error("unexpected argument '%s'", a.positional);
        } else {
            err = run_engine(engine, &a, NULL, 0, &collective);
        }
    } else {
        const char *near = closest_command(a.command);
        char msg[256];
        snprintf(msg, sizeof msg, "unknown command '%s'%s%s%s (see geosynth --help)", a.command,
                 near ? "; did you mean '" : "", near ? near : "", near ? "'?" : "");
        err = usage_error("%s", msg);
    }
    /* Every rank agreed to stop on a signal, so that exit is collective too. */
    if (err == GS_ERR_INTERRUPTED)
        collective = 1;
    if (err)
        gs_fatal(err, collective);
    gs_par_finalize();
    return 0;
}
