/* Collective config loading: rank 0 reads a config (relative paths, an
 * override), every rank ends up with the identical struct; a bad config
 * fails on every rank with the same code. Prints the digest of the
 * resolved text, which must not depend on the rank count.
 * np: 1 2 3 4 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/config_load.h"
#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"

typedef struct demo_cfg {
    int64_t block;
    double weight;
    char *source;
    char *method;
    int64_t size[3];
    gs_cfg_real_list hist;
    gs_run_config run;
} demo_cfg;

static const gs_cfg_key keys[] = {
    GS_CFG_KEY_INT(demo_cfg, block, "field.block", 2, 64, GS_CFG_POW2, "16", "block edge"),
    GS_CFG_KEY_REAL(demo_cfg, weight, "field.weight", 0, 10, 0, "1", "coherence weight"),
    GS_CFG_KEY_PATH(demo_cfg, source, "field.source", NULL, "example"),
    GS_CFG_KEY_ENUM(demo_cfg, method, "field.method", "tree|exhaustive", "tree", "search"),
    GS_CFG_KEY_INT3(demo_cfg, size, "field.size", 1, 1024, 0, "32", "output size"),
    GS_CFG_KEY_REAL_LIST(demo_cfg, hist, "micro.hist", 0, 1, 0, "0.5 0.5", "histogram"),
    GS_CFG_RUN_KEYS(demo_cfg, run, "demo"),
};
static const gs_cfg_table table = GS_CFG_TABLE("demo", demo_cfg, keys, NULL);

#define FAIL(...)                                                                       \
    do {                                                                                \
        fprintf(stderr, "[rank %d] FAILED: ", rank);                                   \
        fprintf(stderr, __VA_ARGS__);                                                   \
        fprintf(stderr, "\n");                                                          \
        MPI_Abort(MPI_COMM_WORLD, 1);                                                   \
    } while (0)

int main(int argc, char **argv)
{
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    int rank = gs_par_rank();
    /* Rank 0 writes the file into a directory only it knows about; the
     * others never see the path. Relative paths are fixed in the text. */
    char dir[] = "/tmp/gs-mpi-config-XXXXXX", path[128] = "";
    if (rank == 0) {
        if (!mkdtemp(dir))
            FAIL("mkdtemp");
        snprintf(path, sizeof path, "%s/good.ini", dir);
        FILE *f = fopen(path, "w");
        if (!f)
            FAIL("cannot write %s", path);
        fputs("[field]\nblock = 8\nweight = 0.125\nsource = data/example.h5\nsize = 64x32x16\n"
              "[micro]\nhist = 0.1, 0.2, 0.7\n[run]\nseed = 42\noutput = /tmp/gs-out\n",
              f);
        fclose(f);
    }
    const char *set[] = {"field.method=Exhaustive"};
    demo_cfg cfg;
    memset(&cfg, 0, sizeof cfg);
    char *text = NULL;
    err = gs_config_load_collective(MPI_COMM_WORLD, &table, rank == 0 ? path : NULL,
                                    rank == 0 ? set : NULL, rank == 0 ? 1 : 0, &cfg, &text);
    if (err)
        gs_fatal(err, 1);
    /* Every rank holds the same values, with rank 0's directory in the path. */
    if (cfg.block != 8 || cfg.weight != 0.125 || cfg.size[1] != 32 || cfg.hist.n != 3 ||
        cfg.hist.v[2] != 0.7 || cfg.run.seed != 42 || strcmp(cfg.method, "exhaustive") ||
        strcmp(cfg.run.output, "/tmp/gs-out") || !strstr(cfg.source, "/data/example.h5") ||
        strncmp(cfg.source, "/tmp/gs-mpi-config-", 19))
        FAIL("unexpected values (block %lld, source %s)", (long long)cfg.block, cfg.source);
    if (gs_par_check_same_i64(MPI_COMM_WORLD, (int64_t)gs_digest_bytes(text, strlen(text)),
                              "resolved config digest") != GS_OK)
        FAIL("ranks hold different resolved texts");
    /* The digest must not depend on the temporary directory name: digest
     * the text with rank 0's directory replaced by a fixed one. */
    char *stable = gs_malloc(strlen(text) + 1);
    {
        const char *src = text;
        char *o = stable;
        size_t dl = strlen("/tmp/gs-mpi-config-XXXXXX");
        while (*src) {
            if (!strncmp(src, "/tmp/gs-mpi-config-", 19)) {
                memcpy(o, "/tmp/gs-mpi-config-FIXED!", dl);
                o += dl;
                src += dl;
            } else {
                *o++ = *src++;
            }
        }
        *o = '\0';
    }
    char hex[17];
    gs_digest_hex(gs_digest_bytes(stable, strlen(stable)), hex);
    if (rank == 0)
        printf("digest: config %s\n", hex);
    gs_free(stable);
    gs_free(text);
    gs_config_free(&table, &cfg);

    /* A bad config: every rank gets GS_ERR_ARG, nothing is changed. */
    if (rank == 0) {
        snprintf(path, sizeof path, "%s/bad.ini", dir);
        FILE *f = fopen(path, "w");
        if (!f)
            FAIL("cannot write %s", path);
        fputs("[field]\nblok = 8\nsource = x\nweight = -1\n", f);
        fclose(f);
        fprintf(stderr, "(the two problems below are expected)\n");
    }
    demo_cfg bad;
    memset(&bad, 0, sizeof bad);
    text = NULL;
    err = gs_config_load_collective(MPI_COMM_WORLD, &table, rank == 0 ? path : NULL, NULL, 0,
                                    &bad, &text);
    if (err != GS_ERR_ARG || text != NULL || bad.source != NULL)
        FAIL("bad config gave code %d", (int)err);
    if (!strstr(gs_error_message(), "2 problems in"))
        FAIL("message '%s'", gs_error_message());
    gs_error_clear();
    /* A missing file: GS_ERR_IO everywhere. */
    if (rank == 0)
        snprintf(path, sizeof path, "%s/missing.ini", dir);
    err = gs_config_load_collective(MPI_COMM_WORLD, &table, rank == 0 ? path : NULL, NULL, 0,
                                    &bad, NULL);
    if (err != GS_ERR_IO)
        FAIL("missing file gave code %d", (int)err);
    gs_error_clear();
    if (rank == 0) {
        char cmd[128];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
        if (system(cmd) != 0)
            FAIL("cleanup");
        printf("config_load ok\n");
    }
    gs_par_finalize();
    return 0;
}
