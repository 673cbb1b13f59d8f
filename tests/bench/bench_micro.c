/* Benchmark of the micro engine: reconstruction time vs triangle count.
 * Spheres of 10k, 100k, 1M, 2M triangles with the same texture density (the
 * distribution unit is scaled so a triangle covers ~1/3 unit^2, the paper's
 * resolution), distribution from a Boolean-model image. JSON on stdout.
 * Usage: bench_micro [max_triangles] [seed] [paper]   (default 2100000, 1, 1;
 * paper 0 skips the uncapacitated variant on the small meshes).
 * Measured on the shared 2-core machine (capacity on, one rank, CPU s):
 * 10k 0.05, 100k 0.32, 1M 4.0 (5.9 under heavy load from other jobs), 2M 7.9. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "geosynth/mem.h"
#include "geosynth/micro.h"

/* Process CPU time: the benchmark machine is shared, wall time is noisy. */
static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double wall(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int run(uint32_t segments, const gs_micro_dist *dist, uint64_t seed, int capacity, int first)
{
    gs_micro_mesh m = {0};
    gs_micro_dual d = {0};
    gs_micro_hist h = {0};
    double t0 = now();
    if (gs_micro_mesh_sphere_segments(&m, 1.0, segments) != GS_OK)
        return 1;
    double t1 = now();
    /* Triangle area ~ 1/3 unit^2: sphere area 4 pi R^2 in units = ntris / 3. */
    double upm = sqrt(m.ntris / 3.0 / (4 * 3.14159265358979));
    if (gs_micro_dual_build(&m, upm, &d) != GS_OK || gs_micro_hist_from_dist(&h, dist, m.ntris) != GS_OK)
        return 1;
    double t2 = now();
    gs_micro_recon_opts o;
    gs_micro_recon_defaults(&o);
    o.capacity = capacity;
    gs_micro_recon_t r;
    int done;
    double w2 = wall();
    if (gs_micro_recon_create(&d, &h, &o, seed, &r) != GS_OK || gs_micro_recon_run(r, 0, &done) != GS_OK)
        return 1;
    double t3 = now(), w3 = wall();
    const gs_micro_state *st = gs_micro_recon_state(r);
    gs_micro_recon_counters c = gs_micro_recon_counters_get(r);
    gs_micro_report rep;
    gs_rng rng;
    gs_rng_init(&rng, seed, 99);
    if (gs_micro_verify(&m, upm, &h, st->value, st->label, 200, &rng, &rep) != GS_OK)
        return 1;
    double t4 = now();
    /* Correction pass (the engine's default, micro.correct = yes) on the
     * meshes up to 100k triangles: CPU seconds, and as a ratio to the
     * reconstruction's (the figure to watch: the pass used to take 9 of
     * planet.ini's 10 s). Region of a triangle as engine_output.c reads it. */
    double corr_s = -1;
    gs_micro_correct_stats cst = {0};
    if (capacity && m.ntris <= 200000) {
        uint8_t *side = malloc(m.ntris);
        double *cd = malloc(m.ntris * sizeof *cd);
        if (!side || !cd)
            return 1;
        for (uint32_t t = 0; t < m.ntris; t++)
            side[t] = st->label[t] < 2 * h.nbins ? st->label[t] >= h.nbins : st->value[t] > 0;
        gs_micro_correct_opts co;
        gs_micro_correct_defaults(&co);
        co.init_value = st->value;
        double c0 = now();
        if (gs_micro_correct(&m, upm, &h, &co, side, cd, &cst) != GS_OK)
            return 1;
        corr_s = now() - c0;
        free(side);
        free(cd);
    }
    printf("%s    {\"ntris\": %u, \"capacity\": %d, \"mesh_s\": %.3f, \"dual_s\": %.3f, \"recon_cpu_s\": %.3f, \"recon_wall_s\": %.3f, "
           "\"verify_s\": %.3f, \"unassigned_share\": %.5f, \"violations\": %llu, \"pairs_checked\": %llu, "
           "\"abs_bin_error\": %lld, \"forced\": %llu, \"random_accepted\": %llu, \"random_rejected\": %llu, "
           "\"filled\": %llu, \"dijkstra_nodes\": %llu, \"digest\": \"%016llx\"",
           first ? "" : ",\n", m.ntris, capacity, t1 - t0, t2 - t1, t3 - t2, w3 - w2, t4 - t3, rep.unassigned_share,
           (unsigned long long)rep.violations, (unsigned long long)rep.pairs_checked,
           (long long)rep.abs_error_sum, (unsigned long long)c.forced, (unsigned long long)c.random_accepted,
           (unsigned long long)c.random_rejected, (unsigned long long)c.filled,
           (unsigned long long)c.dijkstra_nodes, (unsigned long long)gs_micro_state_digest(st));
    if (corr_s >= 0)
        printf(", \"correct_cpu_s\": %.3f, \"correct_over_recon\": %.2f, \"correct_rounds\": %u, "
               "\"correct_s_per_round\": %.4f, \"realized_l1_before\": %.4f, \"realized_l1_after\": %.4f",
               corr_s, t3 - t2 > 0 ? corr_s / (t3 - t2) : 0, cst.rounds, cst.rounds ? corr_s / cst.rounds : 0,
               cst.l1_before, cst.l1_after);
    printf("}");
    fflush(stdout);
    gs_micro_report_free(&rep);
    gs_micro_recon_destroy(&r);
    gs_micro_hist_free(&h);
    gs_micro_dual_free(&d);
    gs_micro_mesh_free(&m);
    return 0;
}

int main(int argc, char **argv)
{
    double maxt = argc > 1 ? strtod(argv[1], NULL) : 2100000;
    uint64_t seed = argc > 2 ? strtoull(argv[2], NULL, 10) : 1;
    int paper = argc > 3 ? atoi(argv[3]) : 1;
    gs_rng rng;
    gs_rng_init(&rng, 7, 1);
    uint8_t *img = malloc(512 * 512);
    gs_micro_dist dist;
    if (gs_micro_image_boolean(512, 512, 3, 9, 0.45, &rng, img) != GS_OK ||
        gs_micro_dist_from_image(&dist, 512, 512, img, 128, 1.0, 64) != GS_OK) {
        gs_error_report(NULL);
        return 1;
    }
    free(img);
    printf("{\"benchmark\": \"micro_reconstruction\", \"bins_per_side\": %u,\n  \"runs\": [\n", dist.nbins);
    /* 8 s^2 triangles: 10k, 100k, 1M, 2M */
    uint32_t seg[] = {35, 112, 354, 500};
    int first = 1;
    for (int i = 0; i < 4; i++) {
        if (8.0 * seg[i] * seg[i] > maxt)
            break;
        for (int cap = 1; cap >= 0; cap--) {
            if (!cap && (!paper || seg[i] > 112))
                continue; /* the paper variant only on the small meshes */
            if (run(seg[i], &dist, seed, cap, first)) {
                gs_error_report(NULL);
                return 1;
            }
            first = 0;
        }
    }
    printf("\n  ]\n}\n");
    gs_micro_dist_free(&dist);
    return 0;
}
