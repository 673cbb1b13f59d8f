/* Distributed checkpoint I/O: a 3D float field whose values depend only on
 * the global index is written collectively (balanced slabs, contiguous and
 * deflate-compressed with chunks straddling rank boundaries), read back with
 * a different, uneven decomposition, and checked element by element. The
 * digest of the whole arrays is the same for every rank count.
 * Collective error paths (bad tiling, wrong shape, wrong engine) must fail
 * on every rank without hanging.
 * np: 1 2 3 4 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/h5.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"

enum { NZ = 96, NY = 80, NX = 72 };

static float value_at(uint64_t i)
{
    uint64_t z = i + 0x9e3779b97f4a7c15ULL; /* splitmix64 */
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    return (float)(z >> 40) / 16777216.0f - 0.5f; /* exact in float */
}

static int failures = 0;

#define EXPECT(cond, ...)                                                                          \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            fprintf(stderr, "[rank %d] FAILED %s:%d: ", gs_par_rank(), __FILE__, __LINE__);        \
            fprintf(stderr, __VA_ARGS__);                                                          \
            fprintf(stderr, "\n");                                                                 \
            failures++;                                                                            \
        }                                                                                          \
    } while (0)

#define RUN(call)                                                                                  \
    do {                                                                                           \
        gs_err e_ = (call);                                                                        \
        if (e_ != GS_OK)                                                                           \
            gs_fatal(e_, 0);                                                                       \
    } while (0)

int main(int argc, char **argv)
{
    RUN(gs_par_init(&argc, &argv));
    MPI_Comm comm = MPI_COMM_WORLD;
    int rank = gs_par_rank(), size = gs_par_size();
    char *dir = NULL;
    if (rank == 0) {
        char tmpl[256];
        snprintf(tmpl, sizeof tmpl, "%s/gs-mpi-h5-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        if (!mkdtemp(tmpl)) {
            perror("mkdtemp");
            MPI_Abort(comm, 3);
        }
        dir = gs_malloc(strlen(tmpl) + 1);
        strcpy(dir, tmpl);
    }
    RUN(gs_par_bcast_string(comm, &dir, 0));
    char path[512];
    snprintf(path, sizeof path, "%s/checkpoint.h5", dir);

    const uint64_t plane = (uint64_t)NY * NX;
    gs_h5_shape shape = {GS_H5_F32, 3, {NZ, NY, NX}};
    gs_h5_shape lab_shape = {GS_H5_U16, 3, {NZ / 4, NY / 4, NX / 4}};

    /* ---- write: balanced slabs ---- */
    uint64_t s0, c0;
    gs_h5_split_rows(NZ, size, rank, &s0, &c0);
    float *mine = gs_calloc(c0 * plane + 1, sizeof *mine);
    for (uint64_t i = 0; i < c0 * plane; i++)
        mine[i] = value_at(s0 * plane + i);
    uint16_t *labels = gs_calloc((NZ / 4) * (NY / 4) * (NX / 4), sizeof *labels);
    for (uint64_t i = 0; i < (uint64_t)(NZ / 4) * (NY / 4) * (NX / 4); i++)
        labels[i] = (uint16_t)(value_at(i) * 1000.0f + 500.0f);

    gs_ckpt_meta meta = {"field", 20240501, "[field]\nblock = 8\n"};
    gs_ckpt_t h = NULL;
    RUN(gs_ckpt_create(comm, path, &meta, &h));
    RUN(gs_ckpt_write_slab(h, "/field/target", &shape, s0, c0, mine, NULL));
    gs_h5_write_opts packed = {4, 5}; /* 5-row chunks straddle rank boundaries */
    RUN(gs_ckpt_write_slab(h, "/field/target_packed", &shape, s0, c0, mine, &packed));
    RUN(gs_ckpt_write_whole(h, "/field/labels", &lab_shape, labels, NULL));
    RUN(gs_ckpt_set_i64(h, "/field", "iteration", 17));
    RUN(gs_ckpt_set_u64(h, "/field", "rng_counter", 1ULL << 63));

    /* Bad tiling fails on every rank, collectively, and leaves no dataset. */
    uint64_t bad_start = size == 1 ? 1 : 0, bad_count = size == 1 ? NZ - 1 : c0;
    gs_err e = gs_ckpt_write_slab(h, "/field/bad", &shape, bad_start, bad_count, mine, NULL);
    EXPECT(e == GS_ERR_ARG, "bad tiling gave %d: %s", e, gs_error_message());
    gs_error_clear();
    int ex = 1;
    RUN(gs_ckpt_exists(h, "/field/bad", &ex));
    EXPECT(ex == 0, "/field/bad exists after a refused write");
    RUN(gs_ckpt_commit(&h));

    /* ---- read: a different, uneven decomposition ---- */
    RUN(gs_ckpt_open(comm, path, "field", &h));
    uint64_t b0 = (uint64_t)NZ * (uint64_t)rank * (uint64_t)rank / ((uint64_t)size * size);
    uint64_t b1 = (uint64_t)NZ * (uint64_t)(rank + 1) * (uint64_t)(rank + 1) / ((uint64_t)size * size);
    float *slab = gs_calloc((b1 - b0) * plane + 1, sizeof *slab);
    const char *names[2] = {"/field/target", "/field/target_packed"};
    for (int n = 0; n < 2; n++) {
        memset(slab, 0, (b1 - b0) * plane * sizeof *slab);
        RUN(gs_ckpt_read_slab(h, names[n], &shape, b0, b1 - b0, slab));
        uint64_t bad = 0;
        for (uint64_t i = 0; i < (b1 - b0) * plane; i++)
            bad += slab[i] != value_at(b0 * plane + i);
        EXPECT(bad == 0, "%s: %llu wrong values in rows [%llu, %llu)", names[n],
               (unsigned long long)bad, (unsigned long long)b0, (unsigned long long)b1);
    }
    int64_t it = 0;
    uint64_t rc = 0;
    RUN(gs_ckpt_get_i64(h, "/field", "iteration", &it));
    RUN(gs_ckpt_get_u64(h, "/field", "rng_counter", &rc));
    EXPECT(it == 17 && rc == 1ULL << 63, "state attributes %lld %llu", (long long)it,
           (unsigned long long)rc);

    /* Wrong expectations fail on every rank without a hang. */
    gs_h5_shape wrong = shape;
    wrong.dims[2] = NX + 1;
    e = gs_ckpt_read_slab(h, "/field/target", &wrong, b0, b1 - b0, slab);
    EXPECT(e == GS_ERR_FORMAT && strstr(gs_error_message(), path), "wrong dims gave %d: %s", e,
           gs_error_message());
    gs_error_clear();
    /* One rank asks for rows out of range: everyone fails. */
    e = gs_ckpt_read_slab(h, "/field/target", &shape, rank == size - 1 ? NZ : 0, 1, slab);
    EXPECT(e == GS_ERR_ARG, "out-of-range rows on one rank gave %d", e);
    gs_error_clear();

    /* Digest of the whole arrays (every rank reads them; rank 0 prints). */
    float *whole = gs_calloc((uint64_t)NZ * plane, sizeof *whole);
    gs_digest d;
    gs_digest_init(&d);
    for (int n = 0; n < 2; n++) {
        RUN(gs_ckpt_read_whole(h, names[n], &shape, whole));
        gs_digest_update(&d, whole, (size_t)NZ * plane * sizeof *whole);
    }
    RUN(gs_ckpt_read_whole(h, "/field/labels", &lab_shape, labels));
    gs_digest_update(&d, labels, (size_t)(NZ / 4) * (NY / 4) * (NX / 4) * sizeof *labels);
    uint64_t dig = gs_digest_final(&d);
    RUN(gs_ckpt_close(&h));

    e = gs_ckpt_open(comm, path, "model", &h);
    EXPECT(e == GS_ERR_FORMAT && strstr(gs_error_message(), "is a 'field' checkpoint"),
           "wrong engine gave %d: %s", e, gs_error_message());
    gs_error_clear();

    int all_failures = 0;
    MPI_Allreduce(&failures, &all_failures, 1, MPI_INT, MPI_SUM, comm);
    if (rank == 0) {
        char hex[17];
        gs_digest_hex(dig, hex);
        printf("digest: ckpt %s\n", hex);
        printf("%s: np=%d, %d failures\n", all_failures ? "FAILED" : "ok", size, all_failures);
        if (!all_failures) {
            char cmd[600];
            snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
            if (system(cmd) != 0)
                fprintf(stderr, "could not remove %s\n", dir);
        }
    }
    gs_free(whole);
    gs_free(slab);
    gs_free(labels);
    gs_free(mine);
    gs_free(dir);
    gs_par_finalize();
    return all_failures ? 1 : 0;
}
