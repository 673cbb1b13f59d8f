/* Run directory, phases, metrics.jsonl and summary.json; see run.h. */
#include "geosynth/run.h"
#include "geosynth/killpoint.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <sys/file.h>
#include <time.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/file.h"
#include "geosynth/log.h"
#include "geosynth/parse.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/version.h"

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = gs_malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

#define GS_RUN_MAX_DIR 192

/* One run per directory: rank 0 holds an exclusive flock on DIR/.lock
 * until gs_run_close or its exit (the kernel drops it when the process
 * dies, so a killed run never leaves a stale lock). A second run into the
 * same directory stops before touching anything. */
static int held_lock_fd = -1;       /* taken by gs_run_resume_prepare for ... */
static char held_lock_dir[PATH_MAX]; /* ... the gs_run_open of this directory */

static gs_err lock_fd_of(const char *dir, int *out)
{
    char path[PATH_MAX];
    GS_CHECK(snprintf(path, sizeof path, "%s/.lock", dir) < (int)sizeof path, GS_ERR_ARG,
             "run directory path is too long (%zu characters)", strlen(dir));
    int fd = open(path, O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
    GS_CHECK(fd >= 0, GS_ERR_IO, "cannot open the lock file %s: %s", path, strerror(errno));
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        int e = errno;
        char pid[32] = "";
        ssize_t n = read(fd, pid, sizeof pid - 1);
        pid[n > 0 ? n : 0] = '\0';
        pid[strcspn(pid, "\n")] = '\0';
        close(fd);
        GS_CHECK(e != EWOULDBLOCK, GS_ERR_ARG,
                 "run directory %s is in use by another geosynth run (process %s holds %s): "
                 "wait for it to end, or give another run directory (-o DIR)",
                 dir, pid[0] ? pid : "?", path);
        GS_RAISE(GS_ERR_IO, "cannot lock %s: %s", path, strerror(e));
    }
    char pid[32];
    int n = snprintf(pid, sizeof pid, "%ld\n", (long)getpid());
    if (ftruncate(fd, 0) != 0 || write(fd, pid, (size_t)n) != n) {
        /* the pid is only for the message: the lock itself holds */
    }
    *out = fd;
    return GS_OK;
}

static gs_err lock_dir(gs_run *run)
{
    if (held_lock_fd >= 0 && !strcmp(held_lock_dir, run->dir)) {
        run->lock_fd = held_lock_fd; /* taken over from gs_run_resume_prepare */
        held_lock_fd = -1;
        return GS_OK;
    }
    GS_CALL(lock_fd_of(run->dir, &run->lock_fd));
    return GS_OK;
}

/* start.ini: the engine and the resolved config (with its inputs' digests),
 * written atomically. Rank 0. */
static gs_err write_start(const gs_run *run)
{
    char path[PATH_MAX];
    gs_run_path(run, GS_RUN_START_FILE, path, sizeof path);
    size_t n = strlen(run->config_text) + 64;
    char *text = gs_malloc(n);
    GS_CHECK(text, GS_ERR_MEM, "out of memory for %s", path);
    int len = snprintf(text, n, "; geosynth %s\n%s", run->engine, run->config_text);
    gs_err err = gs_file_write_atomic(path, text, (size_t)len);
    gs_free(text);
    GS_CALL(err);
    return GS_OK;
}

static gs_err open_dir_rank0(gs_run *run, const char *dir)
{
    GS_CALL(gs_path_absolute(dir, NULL, &run->dir));
    /* Open MPI's shared-file-pointer code under H5Fcreate overflows a fixed
     * buffer ("*** buffer overflow detected ***", exit 134) once an HDF5 path
     * reaches about 248 characters (measured: run directories of 235 characters
     * crash, 230 run), after the whole synthesis: refuse such paths up front. */
    GS_CHECK(strlen(run->dir) <= GS_RUN_MAX_DIR, GS_ERR_ARG,
             "run directory %.80s... is %zu characters long: at most %d are supported (Open "
             "MPI's parallel HDF5 I/O cannot handle longer file paths); choose a shorter one",
             run->dir, strlen(run->dir), GS_RUN_MAX_DIR);
    GS_CALL(gs_mkdir_p(run->dir));
    GS_CALL(gs_dir_check_writable(run->dir));
    GS_CALL(lock_dir(run));
    if (!run->resumed) /* what `resume` needs to start again before the first checkpoint */
        GS_CALL(write_start(run));
    return GS_OK;
}

/* The files input files name (tile images, listed meshes), noted by their
 * readers on rank 0 as they read them (gs_input_note), join the run's
 * config text: every later checkpoint and summary.json record them, and so
 * does start.ini (rewritten; a fresh run's only), so `resume` refuses a
 * changed one as it does a changed config input. Collective: called where
 * every rank is (a phase's end, a checkpoint, the summary). */
static gs_err sync_inputs(gs_run *run)
{
    char *notes = NULL;
    gs_err err = GS_OK;
    if (run->rank == 0) {
        notes = gs_input_notes_take();
        if (!notes)
            err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                                 "out of memory for the inputs' digests");
    }
    GS_CALL(gs_par_agree(run->comm, err));
    GS_CALL(gs_par_bcast_string(run->comm, &notes, 0));
    size_t have = strlen(run->config_text), add = 0;
    char *grown = gs_realloc(run->config_text, have + strlen(notes) + 1);
    if (!grown) {
        gs_free(notes);
        GS_RAISE(GS_ERR_MEM, "out of memory for the inputs' digests");
    }
    run->config_text = grown;
    for (char *p = notes; *p;) { /* lines the config does not hold yet (a resumed run's do) */
        char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p) + 1 : strlen(p);
        char c = p[n];
        p[n] = '\0';
        if (!strstr(run->config_text, p)) {
            memcpy(run->config_text + have + add, p, n + 1);
            add += n;
        }
        p[n] = c;
        p += n;
    }
    gs_free(notes);
    err = GS_OK;
    if (add && run->rank == 0 && !run->resumed)
        err = write_start(run);
    GS_CALL(gs_par_agree(run->comm, err));
    return GS_OK;
}

gs_err gs_run_open(gs_run *run, MPI_Comm comm, const char *engine, const char *dir,
                   const char *config_text, uint64_t seed, int resumed)
{
    memset(run, 0, sizeof *run);
    run->lock_fd = -1;
    run->comm = comm;
    GS_CALL(gs_par_comm_rank(comm, &run->rank, &run->size));
    snprintf(run->engine, sizeof run->engine, "%s", engine);
    run->seed = seed;
    run->resumed = resumed;
    run->open_phase = -1;
    run->start = gs_time_now();
    gs_json_init(&run->metrics);
    gs_json_begin_object(&run->metrics, NULL);
    run->config_text = dup_str(config_text ? config_text : "");
    gs_err err = run->config_text ? GS_OK : GS_ERR_MEM;
    if (!err && run->rank == 0) /* needs run->config_text */
        err = open_dir_rank0(run, dir);
    GS_CALL(gs_par_agree(comm, err));
    if (run->rank != 0)
        GS_CALL(gs_path_absolute(dir, NULL, &run->dir));
    return GS_OK;
}

void gs_run_phase_begin(gs_run *run, const char *name)
{
    if (run->nphases >= GS_RUN_MAX_PHASES)
        return;
    gs_run_phase *p = &run->phases[run->nphases];
    memset(p, 0, sizeof *p);
    snprintf(p->name, sizeof p->name, "%s", name);
    p->start = gs_time_now();
    p->cpu_start = gs_cpu_now();
    run->open_phase = run->nphases++;
    gs_log_section(name);
    gs_kill_point_phase(name);
    gs_kill_point("phase begins");
}

void gs_run_path(const gs_run *run, const char *name, char *out, size_t out_len)
{
    snprintf(out, out_len, "%s/%s", run->dir, name);
}

static gs_err append_line(const char *path, const char *line)
{
    FILE *f = gs_fopen_append(path);
    GS_CHECK(f != NULL, GS_ERR_IO, "cannot append to %s: %s", path, strerror(errno));
    int ok = fputs(line, f) >= 0 && fputc('\n', f) != EOF;
    ok = (fclose(f) == 0) && ok;
    GS_CHECK(ok, GS_ERR_IO, "cannot append to %s", path);
    return GS_OK;
}

gs_err gs_run_phase_end(gs_run *run, const char *extra_json)
{
    GS_CHECK(run->open_phase >= 0, GS_ERR_INTERNAL, "gs_run_phase_end without a running phase");
    gs_kill_point("phase ends");
    GS_CALL(sync_inputs(run));
    gs_run_phase *p = &run->phases[run->open_phase];
    run->open_phase = -1;
    p->seconds = gs_time_now() - p->start;
    p->cpu_seconds = gs_cpu_now() - p->cpu_start;
    double mine[3] = {p->seconds, -p->seconds, p->cpu_seconds}, ext[3], both[2] = {p->seconds, p->cpu_seconds}, sum[2];
    GS_CALL(gs_par_max_f64(run->comm, mine, ext, 3));
    GS_CALL(gs_par_sum_f64(run->comm, both, sum, 2));
    p->max = ext[0];
    p->min = -ext[1];
    p->avg = sum[0] / run->size;
    p->cpu_max = ext[2];
    p->cpu_sum = sum[1];
    uint64_t peak_max;
    GS_CALL(gs_par_max_u64(run->comm, (uint64_t)gs_mem_peak(), &peak_max));
    if (run->rank != 0)
        return GS_OK;
    gs_json j;
    gs_json_init(&j);
    gs_json_begin_object(&j, NULL);
    gs_json_str(&j, "phase", p->name);
    gs_json_i64(&j, "ranks", run->size);
    gs_json_begin_object(&j, "seconds");
    gs_json_f64(&j, "min", p->min);
    gs_json_f64(&j, "avg", p->avg);
    gs_json_f64(&j, "max", p->max);
    gs_json_end_object(&j);
    gs_json_f64(&j, "cpu_seconds", p->cpu_sum);
    gs_json_f64(&j, "cpu_max_seconds", p->cpu_max);
    gs_json_u64(&j, "mem_peak_bytes", peak_max);
    if (extra_json)
        gs_json_merge(&j, extra_json);
    gs_json_end_object(&j);
    char path[PATH_MAX];
    gs_run_path(run, "metrics.jsonl", path, sizeof path);
    gs_err err = j.failed ? GS_ERR_MEM : append_line(path, j.buf);
    gs_json_free(&j);
    GS_CALL(err);
    gs_log(GS_LOG_INFO, "%s: %.3f s (max over ranks), CPU %.3f s (all ranks)", p->name, p->max,
           p->cpu_sum);
    return GS_OK;
}

void gs_run_metric_f64(gs_run *run, const char *key, double value)
{
    gs_json_f64(&run->metrics, key, value);
}

void gs_run_metric_i64(gs_run *run, const char *key, int64_t value)
{
    gs_json_i64(&run->metrics, key, value);
}

void gs_run_metric_str(gs_run *run, const char *key, const char *value)
{
    gs_json_str(&run->metrics, key, value);
}

gs_err gs_run_expect_digest(gs_run *run, const char *hex)
{
    run->have_expect_digest = 0;
    if (!hex || !hex[0])
        return GS_OK;
    uint64_t v = 0;
    size_t n = strlen(hex);
    int ok = n == 16;
    for (size_t i = 0; ok && i < n; i++) {
        char c = hex[i];
        int d = c >= '0' && c <= '9' ? c - '0'
                : c >= 'a' && c <= 'f' ? c - 'a' + 10
                : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                       : -1;
        ok = d >= 0;
        v = v << 4 | (uint64_t)(d < 0 ? 0 : d);
    }
    GS_CHECK(ok, GS_ERR_ARG,
             "run.expect_digest = '%.40s': expected 16 hex digits (the \"digest\" of a "
             "summary.json), or nothing for no check",
             hex);
    run->expect_digest = v;
    run->have_expect_digest = 1;
    return GS_OK;
}

gs_err gs_run_finish(gs_run *run, uint64_t digest)
{
    gs_kill_point_phase("summary");
    gs_kill_point("summary begins");
    GS_CALL(sync_inputs(run));
    /* The digest covers every output file, read back by rank 0 (#25: a
     * damaged provenance once changed copied.ply under the same digest). */
    gs_err derr = GS_OK;
    if (run->rank == 0)
        derr = gs_run_outputs_digest(run, digest, &digest);
    GS_CALL(gs_par_agree(run->comm, derr));
    GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &digest, 0));
    int verified = !run->have_expect_digest || digest == run->expect_digest;
    uint64_t peak_max, rss_max;
    GS_CALL(gs_par_max_u64(run->comm, (uint64_t)gs_mem_peak(), &peak_max));
    GS_CALL(gs_par_max_u64(run->comm, (uint64_t)gs_mem_rss_peak(), &rss_max));
    gs_err err = GS_OK;
    if (run->rank == 0) {
        char hex[17];
        gs_digest_hex(digest, hex);
        gs_json j;
        gs_json_init(&j);
        gs_json_begin_object(&j, NULL);
        gs_json_str(&j, "engine", run->engine);
        gs_json_str(&j, "program_version", GS_VERSION_STRING);
        gs_json_i64(&j, "ranks", run->size);
        gs_json_seed(&j, "seed", run->seed);
        gs_json_bool(&j, "resumed", run->resumed);
        gs_json_f64(&j, "wall_seconds", gs_time_now() - run->start);
        gs_json_begin_array(&j, "phases");
        for (int i = 0; i < run->nphases; i++) {
            const gs_run_phase *p = &run->phases[i];
            gs_json_begin_object(&j, NULL);
            gs_json_str(&j, "name", p->name);
            gs_json_f64(&j, "min", p->min);
            gs_json_f64(&j, "avg", p->avg);
            gs_json_f64(&j, "max", p->max);
            gs_json_f64(&j, "cpu_seconds", p->cpu_sum);
            gs_json_f64(&j, "cpu_max_seconds", p->cpu_max);
            gs_json_end_object(&j);
        }
        gs_json_end_array(&j);
        gs_json_u64(&j, "mem_peak_bytes", peak_max);
        gs_json_u64(&j, "rss_peak_bytes", rss_max);
        gs_json_end_object(&run->metrics);
        gs_json_raw(&j, "metrics", run->metrics.buf ? run->metrics.buf : "{}");
        err = gs_run_outputs_json(run, &j, "outputs");
        gs_json_str(&j, "config", run->config_text);
        gs_json_str(&j, "digest", hex);
        if (run->have_expect_digest) {
            char ehex[17];
            gs_digest_hex(run->expect_digest, ehex);
            gs_json_str(&j, "expect_digest", ehex);
            gs_json_bool(&j, "digest_verified", verified);
        }
        gs_json_end_object(&j);
        char path[PATH_MAX];
        gs_run_path(run, "summary.json", path, sizeof path);
        if (err) {
            /* raised by gs_run_outputs_json */
        } else if (j.failed) {
            err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__, "summary too large");
        } else {
            size_t n = j.len;
            j.buf[n] = '\n';
            err = gs_file_write_atomic(path, j.buf, n + 1);
            j.buf[n] = '\0';
        }
        gs_json_free(&j);
        if (!err) {
            gs_log_section("RESULTS");
            gs_log(GS_LOG_INFO, "run directory: %s", run->dir);
            gs_log(GS_LOG_INFO, "wall time: %.2f s on %d rank%s, peak memory %.1f MiB",
                   gs_time_now() - run->start, run->size, run->size > 1 ? "s" : "",
                   (double)peak_max / 1048576.0);
            gs_log(GS_LOG_INFO, "digest: %s%s", hex,
                   run->have_expect_digest && verified ? " (verified)" : "");
        }
    }
    GS_CALL(gs_par_agree(run->comm, err));
    if (!verified) {
        char ehex[17], hex[17];
        gs_digest_hex(run->expect_digest, ehex);
        gs_digest_hex(digest, hex);
        run->failed_together = 1; /* every rank holds the same digest */
        return gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                              "output digest %s is not run.expect_digest = %s (summary.json "
                              "written; the output differs from the one pinned)",
                              hex, ehex);
    }
    return GS_OK;
}

void gs_run_set_checkpointing(gs_run *run, double seconds, int64_t every_units)
{
    run->ckpt_seconds = seconds;
    run->ckpt_every = every_units;
    run->ckpt_last_time = gs_time_now();
}

/* The GS_STOP_AFTER_UNITS test hook: N, or -1 when unset (or resumed). */
static int64_t stop_hook_units(const gs_run *run)
{
    const char *hook = getenv("GS_STOP_AFTER_UNITS");
    if (!hook || !hook[0] || run->resumed)
        return -1;
    int64_t n;
    char why[160];
    if (!gs_parse_i64(hook, 0, INT64_MAX, &n, why, sizeof why)) {
        static int warned;
        if (!warned++)
            gs_log(GS_LOG_WARN, "GS_STOP_AFTER_UNITS = '%s' ignored: %s", hook, why);
        return -1;
    }
    return n;
}

int gs_run_checkpoint_due(gs_run *run, int64_t units_done, int *stop)
{
    gs_kill_point("safe point after %lld units", (long long)units_done);
    int flags[2] = {0, 0}; /* {due, stop} decided from rank 0's clock and every rank's signals */
    if (run->rank == 0) {
        if (run->ckpt_seconds > 0 && gs_time_now() - run->ckpt_last_time >= run->ckpt_seconds)
            flags[0] = 1;
        if (run->ckpt_every > 0 && units_done - run->ckpt_last_units >= run->ckpt_every)
            flags[0] = 1;
        int64_t n = stop_hook_units(run);
        if (n >= 0 && units_done >= n)
            flags[1] = 1;
    }
    if (gs_par_interrupted())
        flags[1] = 1;
    int all[2] = {flags[0], flags[1]};
    if (run->size > 1 && gs_par_max_int(run->comm, flags, all, 2) != GS_OK) {
        gs_error_clear(); /* as before: a failed reduction leaves this rank's own flags */
        all[0] = flags[0], all[1] = flags[1];
    }
    if (all[1]) {
        *stop = 1;
        return 1;
    }
    return all[0];
}

gs_err gs_run_units_until_due(gs_run *run, int64_t units_done, int64_t *units)
{
    int64_t left = INT64_MAX;
    if (run->rank == 0) {
        if (run->ckpt_every > 0) {
            int64_t d = run->ckpt_every - (units_done - run->ckpt_last_units);
            left = d < left ? d : left;
        }
        int64_t n = stop_hook_units(run);
        if (n >= 0 && n - units_done < left)
            left = n - units_done;
        if (left < 1)
            left = 1;
    }
    if (run->size > 1)
        GS_CALL(GS_PAR_BCAST_VALUE(run->comm, &left, 0));
    *units = left;
    return GS_OK;
}

gs_err gs_run_check_memory(gs_run *run, double bytes, const char *hint)
{
    int local = 1;
    GS_CALL(gs_par_node_size(run->comm, &local));
    double need = bytes * local, avail = (double)gs_mem_available();
    gs_err err = GS_OK;
    if (avail > 0 && need > avail)
        err = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                             "memory estimate per rank %.0f MiB x %d rank%s on this node = %.0f "
                             "MiB, but %.0f MiB are available: the run would fail or be killed "
                             "part way; reduce %s, or spread the ranks over more nodes",
                             bytes / 1048576.0, local, local > 1 ? "s" : "", need / 1048576.0,
                             avail / 1048576.0, hint);
    GS_CALL(gs_par_agree(run->comm, err));
    return GS_OK;
}

gs_err gs_run_checkpoint_begin(gs_run *run, gs_ckpt_t *out)
{
    char path[PATH_MAX];
    gs_run_path(run, "checkpoint.h5", path, sizeof path);
    char prev[PATH_MAX];
    gs_run_path(run, "checkpoint.prev.h5", prev, sizeof prev);
    GS_CALL(sync_inputs(run));
    gs_ckpt_meta meta = {run->engine, run->seed, run->config_text};
    GS_CALL(gs_ckpt_create(run->comm, path, &meta, out));
    gs_err err = gs_ckpt_keep_previous(*out, prev);
    if (err) {
        gs_ckpt_discard(out);
        GS_CALL(err);
    }
    return GS_OK;
}

gs_err gs_run_checkpoint_commit(gs_run *run, gs_ckpt_t *h, int64_t units_done)
{
    GS_CALL(gs_ckpt_commit(h));
    run->ckpt_last_time = gs_time_now();
    run->ckpt_last_units = units_done;
    run->ckpt_count++;
    gs_log(GS_LOG_INFO, "checkpoint %lld written after %lld units",
           (long long)run->ckpt_count, (long long)units_done);
    return GS_OK;
}

gs_err gs_run_checkpoint_open(gs_run *run, gs_ckpt_t *out)
{
    char path[PATH_MAX];
    gs_run_path(run, "checkpoint.h5", path, sizeof path);
    GS_CALL(gs_ckpt_open(run->comm, path, run->engine, out));
    return GS_OK;
}

gs_err gs_run_interrupted(const gs_run *run)
{
    GS_RAISE(GS_ERR_INTERRUPTED,
             "interrupted; checkpoint written to %s/checkpoint.h5: continue with "
             "'geosynth resume %s'",
             run->dir, run->dir);
}

void gs_run_close(gs_run *run)
{
    if (run->lock_fd >= 0)
        close(run->lock_fd); /* drops the flock; the file stays (unlinking it would race) */
    gs_free(run->dir);
    gs_free(run->config_text);
    gs_json_free(&run->metrics);
    gs_run_outputs_free(run);
    memset(run, 0, sizeof *run);
}

gs_err gs_run_resume_prepare(const char *dir)
{
    char *abs = NULL;
    GS_CALL(gs_path_absolute(dir, NULL, &abs));
    gs_err err = GS_OK;
    char path[PATH_MAX], prev[PATH_MAX], damaged[PATH_MAX];
    snprintf(path, sizeof path, "%s/checkpoint.h5", abs);
    snprintf(prev, sizeof prev, "%s/checkpoint.prev.h5", abs);
    snprintf(damaged, sizeof damaged, "%s/checkpoint.h5.damaged", abs);
    if (access(path, F_OK) != 0 && access(prev, F_OK) != 0)
        goto done; /* nothing to check: the caller reports the missing checkpoint */
    if (held_lock_fd < 0) {
        GS_TRY(err, lock_fd_of(abs, &held_lock_fd), done);
        snprintf(held_lock_dir, sizeof held_lock_dir, "%s", abs);
    }
    err = gs_ckpt_verify(path, NULL);
    if (err == GS_OK || access(prev, F_OK) != 0)
        goto done;
    char why[1024];
    snprintf(why, sizeof why, "%s", gs_error_message());
    gs_error_clear();
    if (gs_ckpt_verify(prev, NULL) != GS_OK) {
        char why_prev[1024];
        snprintf(why_prev, sizeof why_prev, "%s", gs_error_message());
        gs_error_clear();
        GS_TRY_CHECK(err, 0, GS_ERR_FORMAT, done,
                     "no usable checkpoint in %s: %s; and the previous one: %s", abs, why,
                     why_prev);
    }
    gs_log(GS_LOG_WARN,
           "%s; resuming from the previous checkpoint %s instead (the damaged file is kept as "
           "%s)",
           why, prev, damaged);
    if (access(path, F_OK) == 0)
        GS_TRY_CHECK(err, rename(path, damaged) == 0, GS_ERR_IO, done, "cannot rename %s to %s: %s",
                     path, damaged, strerror(errno));
    GS_TRY_CHECK(err, rename(prev, path) == 0, GS_ERR_IO, done, "cannot rename %s to %s: %s",
                 prev, path, strerror(errno));
    err = GS_OK;
done:
    gs_free(abs);
    return err;
}
