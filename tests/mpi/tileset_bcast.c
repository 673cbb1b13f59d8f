/* Tile sets and learned patterns parsed on rank 0 only and broadcast
 * (gs_model_tileset_bcast, gs_model_patterns_bcast; #25): rank 0 writes a
 * small mxgmn tile set (two tiles, symmetries L and T: 8 oriented tiles, tile PNGs) and a
 * sample PNG, parses them, and removes the files before the broadcast, so
 * no other rank can have read them. Every rank must then hold the same
 * names, weights, pairs, orientations, patterns, counts and colours (a
 * digest of every field, equal to rank 0's), the same rules, and no tile
 * images (pixels NULL, tile size 0) but on rank 0.
 * np: 1 2 3
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/digest.h"
#include "geosynth/image.h"
#include "geosynth/mem.h"
#include "geosynth/model_tiles.h"
#include "geosynth/par.h"

#define CHECK(cond, ...)                                                                      \
    do {                                                                                      \
        if (!(cond)) {                                                                        \
            fprintf(stderr, "[rank %d] tileset_bcast: check failed: %s: ", gs_par_rank(), #cond); \
            fprintf(stderr, __VA_ARGS__);                                                     \
            fprintf(stderr, "\n");                                                            \
            MPI_Abort(MPI_COMM_WORLD, 1);                                                     \
        }                                                                                     \
    } while (0)

static void add(gs_digest *d, const void *p, size_t n)
{
    if (p && n)
        gs_digest_update(d, p, n);
}

static uint64_t tileset_digest(const gs_model_tileset *ts)
{
    gs_digest d;
    CHECK(gs_digest_init(&d), "digest");
    int hdr[] = {ts->ntiles, ts->dim, ts->vx, ts->vy, ts->vz, ts->group, ts->nbase,
                 ts->ground, ts->border, ts->nfixed};
    add(&d, hdr, sizeof hdr);
    size_t nt = (size_t)ts->ntiles;
    add(&d, ts->names, nt * sizeof *ts->names);
    add(&d, ts->weight, nt * sizeof *ts->weight);
    for (size_t i = 0; i < ts->npairs; i++) { /* by value: the struct has padding */
        uint64_t k = (uint64_t)ts->pairs[i].dir << 32 | (uint64_t)ts->pairs[i].a << 16 |
                     ts->pairs[i].b;
        add(&d, &k, sizeof k);
    }
    add(&d, ts->base, nt * sizeof *ts->base);
    add(&d, ts->orient, nt * sizeof *ts->orient);
    return gs_digest_final(&d);
}

static uint64_t patterns_digest(const gs_model_patterns *p)
{
    gs_digest d;
    CHECK(gs_digest_init(&d), "digest");
    int hdr[] = {p->n, p->npatterns, p->ncolors};
    add(&d, hdr, sizeof hdr);
    size_t np = (size_t)p->npatterns;
    add(&d, p->colors, (size_t)p->ncolors * sizeof *p->colors);
    add(&d, p->pat, np * (size_t)(p->n * p->n));
    add(&d, p->count, np * sizeof *p->count);
    add(&d, p->bottom, np * sizeof *p->bottom);
    for (size_t i = 0; i < p->npairs; i++) {
        uint64_t k = (uint64_t)p->pairs[i].dir << 32 | (uint64_t)p->pairs[i].a << 16 |
                     p->pairs[i].b;
        add(&d, &k, sizeof k);
    }
    return gs_digest_final(&d);
}

static void write_png(const char *path, int w, int h, uint32_t seed)
{
    gs_image img;
    CHECK(gs_image_alloc(&img, w, h, 4, 8) == GS_OK, "%s", gs_error_message());
    for (int i = 0; i < w * h; i++) {
        uint32_t v = (uint32_t)i * 2654435761u ^ seed;
        uint8_t *px = img.data8 + 4 * i;
        px[0] = (v >> 3) & 1 ? 255 : 0, px[1] = (v >> 7) & 1 ? 200 : 40, px[2] = 90, px[3] = 255;
    }
    CHECK(gs_image_write_png(path, &img) == GS_OK, "%s", gs_error_message());
    gs_image_destroy(&img);
}

int main(int argc, char **argv)
{
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    const int rank = gs_par_rank();
    const MPI_Comm comm = MPI_COMM_WORLD;
    gs_model_tileset ts;
    gs_model_patterns pats;
    memset(&ts, 0, sizeof ts);
    memset(&pats, 0, sizeof pats);
    uint64_t want[2] = {0, 0};
    if (rank == 0) {
        char dir[64] = "/tmp/gs-tileset-bcast-XXXXXX", path[160], sub[128];
        CHECK(mkdtemp(dir) != NULL, "mkdtemp");
        snprintf(sub, sizeof sub, "%s/set", dir);
        char cmd[200];
        snprintf(cmd, sizeof cmd, "mkdir -p %s", sub);
        CHECK(system(cmd) == 0, "mkdir");
        snprintf(path, sizeof path, "%s/corner.png", sub);
        write_png(path, 3, 3, 1);
        snprintf(path, sizeof path, "%s/line.png", sub);
        write_png(path, 3, 3, 2);
        snprintf(path, sizeof path, "%s/set.xml", dir);
        FILE *f = fopen(path, "w");
        CHECK(f != NULL, "%s", path);
        fputs("<set>\n<tiles>\n<tile name=\"corner\" symmetry=\"L\" weight=\"0.5\"/>\n"
              "<tile name=\"line\" symmetry=\"T\"/>\n</tiles>\n<neighbors>\n"
              "<neighbor left=\"corner 1\" right=\"line\"/>\n"
              "<neighbor left=\"line 2\" right=\"corner\"/>\n"
              "<neighbor left=\"corner\" right=\"corner 3\"/>\n</neighbors>\n</set>\n",
              f);
        fclose(f);
        CHECK(gs_model_tileset_load(path, NULL, 1, &ts) == GS_OK, "%s", gs_error_message());
        CHECK(ts.pixels != NULL && ts.tile_w == 3, "rank 0 loads the tile images");
        snprintf(path, sizeof path, "%s/sample.png", dir);
        write_png(path, 12, 10, 7);
        CHECK(gs_model_patterns_learn(path, 2, 8, 1, &pats) == GS_OK, "%s", gs_error_message());
        want[0] = tileset_digest(&ts);
        want[1] = patterns_digest(&pats);
        snprintf(cmd, sizeof cmd, "rm -rf %s", dir); /* nobody else can read them now */
        CHECK(system(cmd) == 0, "cleanup");
    }
    CHECK(gs_par_barrier(comm) == GS_OK, "barrier");
    CHECK(gs_model_tileset_bcast(comm, 0, &ts) == GS_OK, "%s", gs_error_message());
    CHECK(gs_model_patterns_bcast(comm, 0, &pats) == GS_OK, "%s", gs_error_message());
    CHECK(gs_par_bcast_bytes(comm, want, sizeof want, 0) == GS_OK, "bcast");
    uint64_t got[2] = {tileset_digest(&ts), patterns_digest(&pats)};
    CHECK(got[0] == want[0], "tile set digest %016llx, rank 0's %016llx", (unsigned long long)got[0],
          (unsigned long long)want[0]);
    CHECK(got[1] == want[1], "patterns digest %016llx, rank 0's %016llx",
          (unsigned long long)got[1], (unsigned long long)want[1]);
    CHECK(ts.ntiles == 8 && ts.npairs > 0, "ntiles %d npairs %zu", ts.ntiles, ts.npairs);
    CHECK(rank == 0 || (ts.pixels == NULL && ts.tile_w == 0 && ts.tile_h == 0),
          "tile images only on rank 0");
    /* the rules every rank builds agree too */
    gs_model_rules_t r1 = NULL, r2 = NULL;
    CHECK(gs_model_tileset_rules(&ts, &r1) == GS_OK, "%s", gs_error_message());
    CHECK(gs_model_patterns_rules(&pats, &r2) == GS_OK, "%s", gs_error_message());
    int64_t sum = 0;
    for (int l = 0; l < gs_model_rules_nlabels(r1); l++)
        for (int m = 0; m < gs_model_rules_nlabels(r1); m++)
            sum = sum * 3 + gs_model_rules_allows(r1, 0, l, m) + 2 * gs_model_rules_allows(r1, 2, l, m);
    for (int l = 0; l < gs_model_rules_nlabels(r2); l++)
        sum = sum * 7 + (int64_t)gs_model_rules_count(r2, l);
    CHECK(gs_par_check_same_i64(comm, sum, "rules") == GS_OK, "%s", gs_error_message());
    gs_model_rules_destroy(&r1);
    gs_model_rules_destroy(&r2);
    gs_model_tileset_destroy(&ts);
    gs_model_patterns_destroy(&pats);
    if (rank == 0)
        printf("digest: tileset_bcast %016llx%016llx\n", (unsigned long long)want[0],
               (unsigned long long)want[1]);
    gs_par_finalize();
    return 0;
}
