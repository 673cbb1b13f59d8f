/* Checkpoint loop for the SIGKILL test (tests/e2e/ckpt_sigkill.sh).
 *
 *   h5_ckpt_loop write DIR MB N   resume from DIR/checkpoint.h5 if present
 *                                 (k = its k + 1, else 0) and write N
 *                                 checkpoints of about MB MiB each (N = 0:
 *                                 forever); writes DIR/pid.RANK first
 *   h5_ckpt_loop verify DIR       (serial, no MPI) open DIR/checkpoint.h5,
 *                                 validate it, check
 *                                 every value against its own k; prints
 *                                 "verified k=K" (exit 1 on any mismatch)
 *   h5_ckpt_loop                  self-test (what tests/run.sh runs): three
 *                                 checkpoints, a stale .tmp, one more, verify
 *
 * Checkpoint k holds /loop/a (float32 [nz x 256 x 256], value a function of
 * k and the global index), /loop/b (uint64 [4096]), attribute /loop@k and
 * seed k.
 * np: 1 2 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/h5.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/parse.h"

enum { NY = 256, NX = 256, NB = 4096 };

static float a_value(int64_t k, uint64_t i)
{
    return (float)((i * 2654435761ULL + (uint64_t)k * 40503ULL) & 0xffffff);
}

static uint64_t b_value(int64_t k, uint64_t i) { return (uint64_t)k * 1000003ULL + i * i; }

static gs_err write_one(MPI_Comm comm, const char *path, int64_t k, uint64_t nz)
{
    int rank = gs_par_rank(), size = gs_par_size();
    const uint64_t plane = (uint64_t)NY * NX;
    uint64_t s0, c0;
    gs_h5_split_rows(nz, size, rank, &s0, &c0);
    float *a = NULL;
    uint64_t *b = NULL;
    GS_CALL(gs_alloc_array((void **)&a, c0 * plane + 1, sizeof *a, "loop slab"));
    gs_err err = gs_alloc_array((void **)&b, NB, sizeof *b, "loop b");
    if (err) {
        gs_free(a);
        GS_CALL(err);
    }
    for (uint64_t i = 0; i < c0 * plane; i++)
        a[i] = a_value(k, s0 * plane + i);
    for (uint64_t i = 0; i < NB; i++)
        b[i] = b_value(k, i);
    gs_ckpt_meta meta = {"field", (uint64_t)k, "[loop]\nkind = sigkill test\n"};
    gs_ckpt_t h = NULL;
    gs_h5_shape as = {GS_H5_F32, 3, {nz, NY, NX}}, bs = {GS_H5_U64, 1, {NB}};
    GS_TRY(err, gs_ckpt_create(comm, path, &meta, &h), done);
    GS_TRY(err, gs_ckpt_write_slab(h, "/loop/a", &as, s0, c0, a, NULL), done);
    GS_TRY(err, gs_ckpt_write_whole(h, "/loop/b", &bs, b, NULL), done);
    GS_TRY(err, gs_ckpt_set_i64(h, "/loop", "k", k), done);
    GS_TRY(err, gs_ckpt_commit(&h), done);
done:
    gs_ckpt_discard(&h);
    gs_free(a);
    gs_free(b);
    return err;
}

/* Collective: opens and checks a checkpoint against its own k. */
static gs_err verify(MPI_Comm comm, const char *path, int64_t *k_out, uint64_t *digest)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_open(comm, path, "field", &h));
    gs_err err = GS_OK;
    int64_t k = -1;
    gs_h5_shape as;
    float *a = NULL;
    uint64_t *b = NULL;
    GS_TRY(err, gs_ckpt_get_i64(h, "/loop", "k", &k), done);
    GS_TRY_CHECK(err, gs_ckpt_seed(h) == (uint64_t)k, GS_ERR_FORMAT, done,
                 "%s: seed %llu but k %lld", path, (unsigned long long)gs_ckpt_seed(h),
                 (long long)k);
    GS_TRY(err, gs_ckpt_shape(h, "/loop/a", &as), done);
    GS_TRY_CHECK(err, as.type == GS_H5_F32 && as.rank == 3 && as.dims[1] == NY && as.dims[2] == NX,
                 GS_ERR_FORMAT, done, "%s: /loop/a has an unexpected shape", path);
    uint64_t n = as.dims[0] * NY * NX;
    GS_TRY(err, gs_alloc_array((void **)&a, n + 1, sizeof *a, "verify a"), done);
    GS_TRY(err, gs_alloc_array((void **)&b, NB, sizeof *b, "verify b"), done);
    GS_TRY(err, gs_ckpt_read_whole(h, "/loop/a", &as, a), done);
    gs_h5_shape bs = {GS_H5_U64, 1, {NB}};
    GS_TRY(err, gs_ckpt_read_whole(h, "/loop/b", &bs, b), done);
    uint64_t bad = 0;
    for (uint64_t i = 0; i < n; i++)
        bad += a[i] != a_value(k, i);
    for (uint64_t i = 0; i < NB; i++)
        bad += b[i] != b_value(k, i);
    GS_TRY_CHECK(err, bad == 0, GS_ERR_FORMAT, done, "%s: %llu values do not match k = %lld",
                 path, (unsigned long long)bad, (long long)k);
    *k_out = k;
    if (digest) {
        gs_digest d;
        gs_digest_init(&d);
        gs_digest_update(&d, a, n * sizeof *a);
        gs_digest_update(&d, b, NB * sizeof *b);
        *digest = gs_digest_final(&d);
    }
done:
    gs_free(a);
    gs_free(b);
    gs_ckpt_close(&h);
    return err;
}

static gs_err run_write(MPI_Comm comm, const char *dir, const char *mb_text, const char *n_text)
{
    int64_t mb = 0, n = 0;
    char why[128];
    GS_CHECK(gs_parse_i64(mb_text, 1, 4096, &mb, why, sizeof why), GS_ERR_USAGE, "MB: %s", why);
    GS_CHECK(gs_parse_i64(n_text, 0, 1000000, &n, why, sizeof why), GS_ERR_USAGE, "N: %s", why);
    char path[1024], pidfile[1100];
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    snprintf(pidfile, sizeof pidfile, "%s/pid.%d", dir, gs_par_rank());
    FILE *f = fopen(pidfile, "w");
    GS_CHECK(f, GS_ERR_IO, "%s: cannot write", pidfile);
    fprintf(f, "%ld\n", (long)getpid());
    fclose(f);
    uint64_t nz = (uint64_t)mb * 1024 * 1024 / (NY * NX * sizeof(float));
    int64_t k = 0;
    if (access(path, F_OK) == 0) {
        GS_CALL(verify(comm, path, &k, NULL));
        k++;
    }
    for (int64_t i = 0; n == 0 || i < n; i++, k++) {
        GS_CALL(write_one(comm, path, k, nz));
        if (gs_par_rank() == 0) {
            printf("wrote k=%lld\n", (long long)k);
            fflush(stdout);
        }
    }
    return GS_OK;
}

static gs_err self_test(MPI_Comm comm)
{
    char *dir = NULL;
    if (gs_par_rank() == 0) {
        char tmpl[256];
        snprintf(tmpl, sizeof tmpl, "%s/gs-loop-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        GS_CHECK(mkdtemp(tmpl), GS_ERR_IO, "%s: mkdtemp failed", tmpl);
        dir = gs_malloc(strlen(tmpl) + 1);
        strcpy(dir, tmpl);
    }
    GS_CALL(gs_par_bcast_string(comm, &dir, 0));
    char path[1024], tmp[1100];
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    GS_CALL(run_write(comm, dir, "1", "3"));
    int64_t k = -1;
    GS_CALL(verify(comm, path, &k, NULL));
    GS_CHECK(k == 2, GS_ERR_INTERNAL, "expected k = 2 after three checkpoints, got %lld",
             (long long)k);
    if (gs_par_rank() == 0) { /* what a SIGKILL mid-write leaves behind */
        FILE *f = fopen(tmp, "w");
        fputs("\x89HDF\r\n\x1a\n garbage", f);
        fclose(f);
    }
    GS_MPI(MPI_Barrier(comm));
    GS_CALL(run_write(comm, dir, "1", "1"));
    uint64_t dig = 0;
    GS_CALL(verify(comm, path, &k, &dig));
    GS_CHECK(k == 3 && access(tmp, F_OK) != 0, GS_ERR_INTERNAL,
             "expected k = 3 and no .tmp after the stale-tmp run, got k = %lld", (long long)k);
    if (gs_par_rank() == 0) {
        char hex[17], cmd[1200];
        gs_digest_hex(dig, hex);
        printf("digest: loop %s\n", hex);
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
        if (system(cmd) != 0)
            fprintf(stderr, "could not remove %s\n", dir);
    }
    gs_free(dir);
    return GS_OK;
}

int main(int argc, char **argv)
{
    gs_err err;
    if (argc == 3 && strcmp(argv[1], "verify") == 0) {
        /* Serial handle: no MPI start-up at all (the test runs this 20+ times). */
        char path[1024];
        snprintf(path, sizeof path, "%s/checkpoint.h5", argv[2]);
        int64_t k = -1;
        err = verify(MPI_COMM_NULL, path, &k, NULL);
        if (err) {
            gs_error_report(NULL);
            return (int)err;
        }
        printf("verified k=%lld\n", (long long)k);
        return 0;
    }
    err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    MPI_Comm comm = MPI_COMM_WORLD;
    if (argc == 1) {
        err = self_test(comm);
    } else if (argc == 5 && strcmp(argv[1], "write") == 0) {
        err = run_write(comm, argv[2], argv[3], argv[4]);
    } else {
        fprintf(stderr, "usage: h5_ckpt_loop [write DIR MB N | verify DIR]\n");
        err = gs_error_raise(GS_ERR_USAGE, __FILE__, __LINE__, __func__, "bad arguments");
    }
    if (err)
        gs_fatal(err, 1);
    gs_par_finalize();
    return 0;
}
