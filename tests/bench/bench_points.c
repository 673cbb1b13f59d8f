/* Benchmark of the points engine core on the paper's table 1 cases:
 * height field, chain mail, weave, flowers (68k-197k output points) and the
 * large chain mail (about 2.9M output points). Single process; prints one
 * JSON object with per-case phase times (wall clock; synthesis_cpu is the
 * process CPU time, the better figure on a shared machine) (search, warp, blend, other as in
 * the paper, plus relaxation, example generation and precomputation).
 * Usage: bench_points [small|large|all|CASE] (default all). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "geosynth/digest.h"
#include "geosynth/error.h"
#include "geosynth/json.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/points.h"

typedef struct bench_case {
    const char *name;
    int kind;            /* 0 height field, 1 chain mail, 2 weave, 3 flowers */
    double spacing;      /* sets the example's point count */
    double out_points;   /* wanted output points (sets the output size) */
    double w_n, w_v, w_l, w_d; /* table 1 weights */
} bench_case;

static const bench_case cases[] = {
    {"heightfield", 0, 0.0275, 87101, 3, 30, 9, 7},
    {"chainmail", 1, 0.033, 197282, 1, 10, 8, 6},
    {"weave", 2, 0.03, 126139, 2, 15, 6, 5},
    {"flowers", 3, 0.019, 68290, 2, 2, 6, 6},
    {"chainmail_large", 1, 0.033, 2947085, 1, 10, 8, 6},
};

static double cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static gs_err run_case(const bench_case *bc, gs_json *j)
{
    const double L = 4;
    gs_points_params p;
    gs_points_params_default(L, L, bc->spacing, &p);
    p.w_n = bc->w_n;
    p.w_v = bc->w_v;
    p.w_l = bc->w_l;
    p.w_d = bc->w_d;
    gs_points_gen_params gp = {{L, L}, 1.2 * gs_points_params_padding(&p), bc->spacing, 2007,
                               0, NULL, NULL, NULL};
    gs_points_texture tex;
    double t0 = gs_time_now();
    if (bc->kind == 0) {
        enum { W = 96 };
        static float img[W * W];
        for (int y = 0; y < W; y++)
            for (int x = 0; x < W; x++) {
                double u = x * 0.09, v = y * 0.09;
                img[y * W + x] = (float)(0.5 + 0.25 * sin(3 * u + sin(2 * v)) * cos(2.5 * v) +
                                         0.1 * sin(1.2 * u * v));
            }
        GS_CALL(gs_points_gen_heightfield(&gp, W, W, NULL, img, 0.6, &tex));
    } else if (bc->kind == 1) {
        GS_CALL(gs_points_gen_chainmail(&gp, 4, &tex));
    } else if (bc->kind == 2) {
        GS_CALL(gs_points_gen_weave(&gp, 4, &tex));
    } else {
        GS_CALL(gs_points_gen_flowers(&gp, 4, &tex));
    }
    double t1 = gs_time_now();
    size_t inside = 0;
    for (size_t i = 0; i < tex.pts.n; i++) {
        const double *q = tex.pts.v[i].p;
        inside += q[0] >= 0 && q[0] < L && q[1] >= 0 && q[1] < L;
    }
    double side = L * sqrt(bc->out_points / (double)inside);
    p.out_size[0] = p.out_size[1] = side;
    gs_points_synth_t s = NULL;
    gs_points out = {0};
    gs_err err = GS_OK;
    GS_TRY(err, gs_points_synth_create(&tex, &p, &s), done);
    double t2 = gs_time_now(), c2 = cpu_now();
    GS_TRY(err, gs_points_synth_run(s), done);
    GS_TRY(err, gs_points_synth_finish(s, &out), done);
    double t3 = gs_time_now(), c3 = cpu_now();
    gs_points_times tm = gs_points_synth_times(s);
    size_t nm;
    const gs_points_patch_metrics *m = gs_points_synth_metrics(s, &nm);
    double sd = 0, cand = 0, pairs = 0, gap = 0, res = 0;
    for (size_t i = 0; i < nm; i++) {
        sd += m[i].best_dist;
        cand += m[i].candidates;
        pairs += m[i].pairs;
        gap += m[i].pair_gap;
        res += m[i].warp_residual;
    }
    char hex[17];
    gs_digest_hex(gs_points_digest(&out), hex);
    gs_json_begin_object(j, NULL);
    gs_json_str(j, "case", bc->name);
    gs_json_u64(j, "points_in", tex.pts.n);
    gs_json_u64(j, "points_in_box", inside);
    gs_json_u64(j, "points_out", out.n);
    gs_json_f64(j, "out_size", side);
    gs_json_u64(j, "patches_placed", nm);
    gs_json_u64(j, "input_patches", gs_points_synth_input_patches(s));
    gs_json_begin_object(j, "seconds");
    gs_json_f64(j, "generate", t1 - t0);
    gs_json_f64(j, "precompute", t2 - t1);
    gs_json_f64(j, "search", tm.search);
    gs_json_f64(j, "warp", tm.warp);
    gs_json_f64(j, "blend", tm.blend);
    gs_json_f64(j, "other", tm.other);
    gs_json_f64(j, "relax", tm.relax);
    gs_json_f64(j, "synthesis_total", t3 - t2);
    gs_json_f64(j, "synthesis_cpu", c3 - c2);
    gs_json_end_object(j);
    gs_json_begin_object(j, "quality");
    gs_json_f64(j, "density_in", gs_points_synth_input_density(s));
    gs_json_f64(j, "density_out", out.n / (side * side));
    gs_json_f64(j, "mean_search_distance", nm ? sd / nm : 0);
    gs_json_f64(j, "mean_candidates", nm ? cand / nm : 0);
    gs_json_f64(j, "mean_pairs", nm ? pairs / nm : 0);
    gs_json_f64(j, "mean_pair_gap", nm ? gap / nm : 0);
    gs_json_f64(j, "mean_warp_residual", nm ? res / nm : 0);
    gs_json_end_object(j);
    gs_json_u64(j, "peak_bytes", gs_mem_peak());
    gs_json_str(j, "digest", hex);
    gs_json_end_object(j);
    fprintf(stderr, "%-16s in %7zu out %8zu  search %6.2f warp %6.2f blend %6.2f other %5.2f relax %5.2f total %6.2f s (cpu %.2f)\n",
            bc->name, tex.pts.n, out.n, tm.search, tm.warp, tm.blend, tm.other, tm.relax, t3 - t2, c3 - c2);
done:
    gs_points_free(&out);
    gs_points_synth_destroy(&s);
    gs_points_texture_free(&tex);
    return err;
}

int main(int argc, char **argv)
{
    const char *which = argc > 1 ? argv[1] : "all";
    int ncases = (int)(sizeof cases / sizeof cases[0]), named = 0;
    for (int i = 0; i < ncases; i++)
        named |= !strcmp(which, cases[i].name);
    if (!named && strcmp(which, "small") && strcmp(which, "large") && strcmp(which, "all")) {
        fprintf(stderr, "usage: bench_points [small|large|all|CASE]\n");
        return 2;
    }
    gs_json j;
    gs_json_init(&j);
    gs_json_begin_object(&j, NULL);
    gs_json_str(&j, "benchmark", "points");
    gs_json_str(&j, "note", "single process; the paper's table 1 times were on a 2.2 GHz Athlon 64");
    gs_json_begin_array(&j, "cases");
    for (int i = 0; i < ncases; i++) {
        int large = strstr(cases[i].name, "large") != NULL;
        if ((large && !strcmp(which, "small")) || (!large && !strcmp(which, "large")) ||
            (named && strcmp(which, cases[i].name)))
            continue;
        if (run_case(&cases[i], &j) != GS_OK) {
            gs_error_report(NULL);
            gs_json_free(&j);
            return 1;
        }
    }
    gs_json_end_array(&j);
    gs_json_end_object(&j);
    printf("%s\n", j.buf);
    gs_json_free(&j);
    return 0;
}
