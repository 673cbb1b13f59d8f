/* Model synthesis benchmark: runs Paul Merrell's 3D samples at the sizes of
 * his samples.xml (and larger) over several seeds and prints one JSON object
 * per (case, setting) on stdout: cells/s, accepted/failed regions, retries,
 * adjacency violations (independent checker), run-length ratio vs example.
 *
 *   build/tests/bench/bench_model [--data DIR] [--seeds N] [--only NAME] [--nx NX]
 *       [--order config|scan|random|entropy|entropy_log|all] [--ac 3|4|both] [--weights uniform|frequency]
 *       [--scale 1|10|all] [--attempts K] [--tile T] [--resemblance 0|1|2] [--layers 0|1]
 *       [--outside mismatch|half|match|background]
 *
 * --resemblance W (default 2) and --layers (default 1) as the engine's
 * model.resemblance / model.resemblance_layers defaults (0 = the adjacency-only
 * method), --outside as model.resemblance_outside (default mismatch: what auto
 * gives these lattices, whose z faces are fixed; castle.ini
 * sets background); each line also gives the quality figures of gs_model_quality
 * averaged over the seeds (non-empty 3x3x3 resemblance, the same with empty
 * windows, label L1).
 *
 * --order config (the default) uses each case's shipped config's order.
 * --tile T starts from gs_model_initial_tiled() with a periodic TxT tile.
 *
 * DIR defaults to ${data}/model-synthesis/merrell42-model-synthesis/samples, Paul
 * Merrell's lattices under the data root (GS_DATA, else the tree's data/),
 * fetched by `make data`.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "geosynth/data.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/model.h"
#include "geosynth/model_io.h"
#include "geosynth/parse.h"

typedef struct bench_case {
    const char *file;
    int nx, ny, nz, bx, by; /* bx = by = 0: whole grid */
    int scale;              /* 1: author's size, 10: ten times the cells */
    double author_cells_per_s; /* the author's implementation on this machine, single process
                                  (issue 4); 0 = not measured or it failed */
    int order;              /* cell order of the shipped config (configs/model/NAME.ini);
                               --order overrides */
} bench_case;

static const bench_case cases[] = {
    {"castle.txt", 40, 40, 10, 0, 0, 1, 31000, GS_MODEL_ORDER_ENTROPY},
    {"castle.txt", 100, 100, 10, 20, 20, 1, 4600, GS_MODEL_ORDER_ENTROPY},
    {"city.txt", 40, 40, 10, 0, 0, 1, 10000, GS_MODEL_ORDER_ENTROPY},
    {"city lights.txt", 40, 40, 10, 0, 0, 1, 0, GS_MODEL_ORDER_ENTROPY},
    {"canyon.txt", 40, 40, 10, 0, 0, 1, 0, GS_MODEL_ORDER_ENTROPY},
    {"mountain.txt", 40, 40, 10, 0, 0, 1, 0, GS_MODEL_ORDER_ENTROPY_LOG},
    {"escheresque.txt", 30, 30, 10, 10, 10, 1, 900, GS_MODEL_ORDER_ENTROPY},
    {"parliament.txt", 30, 30, 10, 10, 10, 1, 4700, GS_MODEL_ORDER_ENTROPY},
    {"gadgets.txt", 40, 40, 6, 0, 0, 1, 0, GS_MODEL_ORDER_ENTROPY},
    {"gadgets.txt", 40, 40, 6, 20, 20, 1, 0, GS_MODEL_ORDER_ENTROPY},
    {"gadgets2.txt", 40, 40, 6, 0, 0, 1, 0, GS_MODEL_ORDER_ENTROPY},
    {"castle.txt", 126, 126, 10, 20, 20, 10, 0, GS_MODEL_ORDER_ENTROPY},
    {"castle.txt", 316, 316, 10, 20, 20, 10, 0, GS_MODEL_ORDER_ENTROPY},
    {"city.txt", 126, 126, 10, 20, 20, 10, 0, GS_MODEL_ORDER_ENTROPY},
    {"canyon.txt", 126, 126, 10, 20, 20, 10, 0, GS_MODEL_ORDER_ENTROPY},
    {"mountain.txt", 126, 126, 10, 20, 20, 10, 0, GS_MODEL_ORDER_ENTROPY_LOG},
    {"escheresque.txt", 95, 95, 10, 10, 10, 10, 0, GS_MODEL_ORDER_ENTROPY},
    {"parliament.txt", 95, 95, 10, 10, 10, 10, 0, GS_MODEL_ORDER_ENTROPY},
    {"gadgets.txt", 126, 126, 6, 20, 20, 10, 0, GS_MODEL_ORDER_ENTROPY},
};

static int g_tile = 0, g_tiled_seeds = 0, g_resem = 2, g_layers = 1, g_outside = 0;

/* Process CPU seconds: on a shared machine wall time swings 2-3x with the
 * load, CPU time of this single-threaded process much less. */
static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static const char *order_name[] = {"scan", "random", "entropy", "entropy_log"};

static int parse_int(const char *s, int lo, int hi, int *out)
{
    int64_t v;
    char why[128];
    if (!gs_parse_i64(s, lo, hi, &v, why, sizeof why)) {
        fprintf(stderr, "bench_model: %s\n", why);
        return 0;
    }
    *out = (int)v;
    return 1;
}

static gs_err run_case(const char *dir, const bench_case *bc, gs_model_order order, gs_model_ac ac,
                       gs_model_weights weights, int attempts, int backtracks, int seeds)
{
    char path[4352];
    snprintf(path, sizeof path, "%s/%s", dir, bc->file);
    gs_model_lattice ex = {0}, out = {0};
    gs_model_rules_t rules = NULL;
    gs_model_resem_t resem = NULL;
    gs_err err = GS_OK;
    double r3 = 0, r3e = 0, l1 = 0;
    GS_TRY(err, gs_model_read_merrell_txt(path, &ex), done);
    GS_TRY(err, gs_model_rules_learn(&ex, &rules), done);
    if (g_resem > 0)
        GS_TRY(err, gs_model_resem_build(&ex, g_resem, 0, g_layers, &resem), done);
    gs_model_resem_set_outside(resem, g_outside);
    GS_TRY(err, gs_model_lattice_create(&out, bc->nx, bc->ny, bc->nz), done);
    double exrun[3];
    gs_model_run_lengths(&ex, exrun);
    double secs = 0, cpu = 0, run_ratio[3] = {0, 0, 0};
    uint64_t nsplit = 0, nkept = 0, nback = 0, regions = 0, accepted = 0, failed = 0, tries = 0, violations = 0;
    int seeds_clean = 0;
    for (int seed = 1; seed <= seeds; seed++) {
        gs_model_params p;
        gs_model_params_default(&p);
        p.seed = (uint64_t)seed;
        p.region[0] = bc->bx;
        p.region[1] = bc->by;
        p.order = order;
        p.ac = ac;
        p.weights = weights;
        p.attempts = attempts;
        p.backtracks = backtracks;
        p.resem = resem;
        if (g_tile > 0) {
            int tiled = 0;
            GS_TRY(err, gs_model_initial_tiled(rules, &ex, &p, g_tile, &out, &tiled), done);
            g_tiled_seeds += tiled;
        } else {
            GS_TRY(err, gs_model_initial(rules, &ex, NULL, &out), done);
        }
        gs_model_stats st;
        double c0 = cpu_now();
        GS_TRY(err, gs_model_synthesize(rules, &p, &out, &st), done);
        cpu += cpu_now() - c0;
        size_t nviol = 0;
        GS_TRY(err, gs_model_check(&ex, &out, NULL, 0, &nviol), done);
        secs += st.seconds;
        regions += st.regions;
        accepted += st.accepted;
        failed += st.failed;
        nsplit += st.split;
        nkept += st.kept_cells;
        tries += st.attempts;
        nback += st.backtracks;
        violations += nviol;
        gs_model_quality_figures q;
        GS_TRY(err, gs_model_quality(&ex, &out, &q), done);
        gs_measure_profile_free(&q.profile);
        r3 += q.w3.found_share / seeds;
        r3e += q.w3.found_share_all / seeds;
        l1 += q.label_l1 / seeds;
        seeds_clean += st.failed == 0 && nviol == 0;
        double run[3];
        gs_model_run_lengths(&out, run);
        for (int a = 0; a < 3; a++)
            run_ratio[a] += exrun[a] > 0 ? run[a] / exrun[a] / seeds : 0;
    }
    double cells = (double)bc->nx * bc->ny * bc->nz * seeds;
    printf("{\"sample\": \"%s\", \"size\": [%d, %d, %d], \"region\": [%d, %d], \"scale\": %d, "
           "\"order\": \"%s\", \"ac\": %d, \"backtrack_budget\": %d, \"weights\": \"%s\", \"attempts\": %d, \"seeds\": %d, "
           "\"seconds_per_run\": %.4f, \"cpu_seconds_per_run\": %.4f, \"cells_per_s\": %.0f, "
           "\"cells_per_cpu_s\": %.0f, \"regions\": %llu, "
           "\"accepted\": %llu, \"failed\": %llu, \"retries\": %llu, \"violations\": %llu, "
           "\"backtracks\": %llu, \"split\": %llu, \"kept_cells\": %llu, \"clean_seeds\": %d, \"run_length_ratio\": [%.2f, %.2f, %.2f], "
           "\"author_cells_per_s\": %.0f, \"x_author_cpu\": %.1f, \"resemblance\": %d, \"layers\": %d, "
           "\"resemblance_3x3x3\": %.3f, \"resemblance_3x3x3_with_empty\": %.3f, \"label_l1\": %.3f}\n",
           bc->file, bc->nx, bc->ny, bc->nz, bc->bx, bc->by, bc->scale, order_name[order], (int)ac, backtracks,
           weights == GS_MODEL_WEIGHTS_UNIFORM ? "uniform" : "frequency", attempts, seeds,
           secs / seeds, cpu / seeds, cells / secs, cells / cpu, (unsigned long long)regions, (unsigned long long)accepted,
           (unsigned long long)failed, (unsigned long long)(tries - regions),
           (unsigned long long)violations, (unsigned long long)nback, (unsigned long long)nsplit, (unsigned long long)nkept, seeds_clean, run_ratio[0], run_ratio[1], run_ratio[2],
           bc->author_cells_per_s, bc->author_cells_per_s > 0 ? cells / cpu / bc->author_cells_per_s : 0,
           g_resem, g_layers, r3, r3e, l1);
    fflush(stdout);
done:
    gs_model_lattice_destroy(&ex);
    gs_model_lattice_destroy(&out);
    gs_model_rules_destroy(&rules);
    gs_model_resem_destroy(&resem);
    return err;
}

int main(int argc, char **argv)
{
    char dir[4096], why[200];
    if (!gs_data_root(dir, sizeof dir - 64, NULL, why, sizeof why)) {
        fprintf(stderr, "bench_model: %s\n", why);
        return 1;
    }
    strcat(dir, "/model-synthesis/merrell42-model-synthesis/samples");
    int seeds = 5, attempts = 20, backtracks = 1000, scale = 1, order_sel = -2, ac_sel = 3;
    gs_model_weights weights = GS_MODEL_WEIGHTS_UNIFORM;
    const char *only = NULL;
    int only_nx = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) {
            fprintf(stderr, "bench_model: %s needs a value\n", a);
            return 1;
        }
        i++;
        if (!strcmp(a, "--data")) {
            snprintf(dir, sizeof dir, "%s", v);
        } else if (!strcmp(a, "--seeds")) {
            if (!parse_int(v, 1, 1000, &seeds))
                return 1;
        } else if (!strcmp(a, "--attempts")) {
            if (!parse_int(v, 1, 100000, &attempts))
                return 1;
        } else if (!strcmp(a, "--backtracks")) {
            if (!parse_int(v, 0, 100000000, &backtracks))
                return 1;
        } else if (!strcmp(a, "--tile")) {
            if (!parse_int(v, 0, 100000, &g_tile))
                return 1;
        } else if (!strcmp(a, "--only")) {
            only = v;
        } else if (!strcmp(a, "--nx")) {
            if (!parse_int(v, 1, 100000, &only_nx))
                return 1;
        } else if (!strcmp(a, "--scale")) {
            scale = !strcmp(v, "all") ? 0 : (!strcmp(v, "10") ? 10 : 1);
        } else if (!strcmp(a, "--order")) {
            order_sel = !strcmp(v, "scan")     ? 0
                        : !strcmp(v, "random") ? 1
                        : !strcmp(v, "all")    ? -1
                        : !strcmp(v, "entropy_log") ? 3
                        : !strcmp(v, "config")      ? -2
                                               : 2;
        } else if (!strcmp(a, "--ac")) {
            ac_sel = !strcmp(v, "4") ? 4 : !strcmp(v, "both") ? 0 : 3;
        } else if (!strcmp(a, "--resemblance")) {
            if (!parse_int(v, 0, 2, &g_resem))
                return 1;
        } else if (!strcmp(a, "--outside")) {
            g_outside = !strcmp(v, "half")         ? 1
                        : !strcmp(v, "match")      ? 2
                        : !strcmp(v, "background") ? 3
                                                   : 0;
        } else if (!strcmp(a, "--layers")) {
            if (!parse_int(v, 0, 1, &g_layers))
                return 1;
        } else if (!strcmp(a, "--weights")) {
            weights = !strcmp(v, "frequency") ? GS_MODEL_WEIGHTS_FREQUENCY : GS_MODEL_WEIGHTS_UNIFORM;
        } else {
            fprintf(stderr, "bench_model: unknown option %s\n", a);
            return 1;
        }
    }
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        if (scale && cases[c].scale != scale)
            continue;
        if (only && !strstr(cases[c].file, only))
            continue;
        if (only_nx && cases[c].nx != only_nx)
            continue;
        for (int o = 0; o < 4; o++) {
            if (order_sel >= 0 ? o != order_sel : order_sel == -2 && o != cases[c].order)
                continue;
            for (int ac = 3; ac <= 4; ac++) {
                if (ac_sel && ac != ac_sel)
                    continue;
                if (run_case(dir, &cases[c], (gs_model_order)o, (gs_model_ac)ac, weights, attempts,
                             backtracks, seeds) != GS_OK) {
                    gs_error_report("bench_model: ");
                    return 1;
                }
            }
        }
    }
    return 0;
}
