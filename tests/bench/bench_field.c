/* Benchmark of the field engine core: per-query matching time of the search
 * tree against brute force on the same quantized data (paper table 1), by
 * query kind, plus the whole default synthesis on one core. JSON on stdout,
 * progress on stderr.
 *
 * usage: bench_field [--sizes 64/8,128/16,256/32] [--queries N] [--brute N] [--fft N]
 *                    [--brute-max-blocks N] [--synth 0|1] [--shape balls] [--mesh FILE]
 *                    [--shards 2,4|none] [--shard-queries N] [--synth-queries N]
 * The matcher cases use the signed distance field of a closed mesh (--mesh,
 * default ${data}/meshes/armadillo.obj, fetched by `make data`, as the paper's table 1) sampled at
 * N along its longest axis and cropped to a multiple of 4 per axis (as the
 * engine crops for 3 iterations); --mesh none uses the procedural --shape
 * instead. The whole synthesis always runs on the procedural shape.
 *
 * Two families of queries per case: made-up kinds ("queries": a source
 * block, and source blocks with a perturbed, seeded, coarse, masked or
 * weighted octant), and the queries real syntheses ask
 * ("synthesis_queries", --synth-queries N per matching setting, see
 * run_synth_queries): recorded from a 3-iteration synthesis of the same
 * source in the paper's whole-block setting, grid.ini's weighted one and the
 * engine's masked default, with mean, median and worst tree times.
 * Brute force over more than --brute-max-blocks candidates is timed on the
 * first --brute-max-blocks blocks and extrapolated linearly (its cost is
 * exactly proportional to the block count); the JSON says so per case.
 *
 * FFT baseline (--fft N queries per kind): the exact weighted SSD of every
 * block at once, sum W q^2 - 2 corr(W q, s) + corr(W, s^2) (W the per-sample
 * weight of the distance: 0/1 for masked queries), with the two
 * source spectra precomputed and, by linearity, one inverse transform per
 * query (two forward ones). FFTW is GPL: it is linked into this benchmark
 * only, never into the library. */
#include <complex.h>
#include <fftw3.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/field.h"
#include "geosynth/field_examples.h"
#include "geosynth/file.h"
#include "geosynth/mesh.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"
#include "geosynth/rng.h"

enum { K_SOURCE, K_PERTURBED, K_SEEDED, K_SEEDED_COARSE, K_MASKED, K_WEIGHTED, K_COUNT };
static const char *kind_name[K_COUNT] = {"source", "perturbed", "seeded_octant", "coarse_seeded_octant",
                                         "masked_octant", "weighted_seeded_octant"};
/* K_WEIGHTED: random seeds in the unknown octant at field.seed_weight 0.25 */
#define BENCH_SEED_WEIGHT 64

/* Synthesis-like queries: 7 octants of a source block; the 8th octant holds
 * random source samples (iteration 0 of the paper), or a coarse (2x
 * subsampled) copy of another source region (later iterations), or is
 * unknown (masked). */
static void make_query(gs_rng *r, const gs_qfield *src, int B, int kind, uint8_t *val, uint8_t *known)
{
    int64_t M = gs_field_block_count(src, B), n = (int64_t)B * B * B;
    gs_field_block_copy(src, B, (int64_t)gs_rng_below(r, (uint64_t)M), val);
    memset(known, 1, (size_t)n);
    int h = B / 2;
    int64_t srcn = src->nx * src->ny * src->nz;
    uint8_t *other = malloc((size_t)n);
    gs_field_block_copy(src, B, (int64_t)gs_rng_below(r, (uint64_t)M), other);
    for (int z = 0; z < h; z++)
        for (int y = 0; y < h; y++)
            for (int x = 0; x < h; x++) {
                int64_t i = h + x + B * (h + y + B * (h + z));
                if (kind == K_PERTURBED) {
                    continue;
                } else if (kind == K_SEEDED) {
                    val[i] = src->q[gs_rng_below(r, (uint64_t)srcn)];
                } else if (kind == K_SEEDED_COARSE) {
                    val[i] = other[(x & ~1) + B * ((y & ~1) + B * (z & ~1))];
                } else if (kind == K_MASKED) {
                    known[i] = 0;
                } else if (kind == K_WEIGHTED) {
                    val[i] = src->q[gs_rng_below(r, (uint64_t)srcn)];
                    known[i] = 0;
                }
            }
    if (kind == K_PERTURBED)
        for (int64_t i = 0; i < n; i++)
            if (gs_rng_below(r, 4) == 0) {
                int v = val[i] + (int)gs_rng_below(r, 9) - 4;
                val[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
    free(other);
}


/* Exact matcher by FFT (benchmark baseline). */
typedef struct fft_matcher {
    int64_t n, nc;             /* real samples, complex bins */
    double *in;
    fftw_complex *fs, *fs2, *fa, *fb;
    fftw_plan fwd_a, fwd_b, inv;
} fft_matcher;

static int fft_create(const gs_qfield *src, fft_matcher *m)
{
    int n0 = (int)src->nz, n1 = (int)src->ny, n2 = (int)src->nx;
    m->n = (int64_t)n0 * n1 * n2;
    m->nc = (int64_t)n0 * n1 * (n2 / 2 + 1);
    m->in = fftw_alloc_real((size_t)m->n);
    m->fs = fftw_alloc_complex((size_t)m->nc);
    m->fs2 = fftw_alloc_complex((size_t)m->nc);
    m->fa = fftw_alloc_complex((size_t)m->nc);
    m->fb = fftw_alloc_complex((size_t)m->nc);
    if (!m->in || !m->fs || !m->fs2 || !m->fa || !m->fb)
        return 0;
    fftw_plan p = fftw_plan_dft_r2c_3d(n0, n1, n2, m->in, m->fs, FFTW_ESTIMATE);
    for (int64_t i = 0; i < m->n; i++)
        m->in[i] = src->q[i];
    fftw_execute_dft_r2c(p, m->in, m->fs);
    for (int64_t i = 0; i < m->n; i++)
        m->in[i] = (double)src->q[i] * src->q[i];
    fftw_execute_dft_r2c(p, m->in, m->fs2);
    fftw_destroy_plan(p);
    m->fwd_a = fftw_plan_dft_r2c_3d(n0, n1, n2, m->in, m->fa, FFTW_ESTIMATE);
    m->fwd_b = fftw_plan_dft_r2c_3d(n0, n1, n2, m->in, m->fb, FFTW_ESTIMATE);
    m->inv = fftw_plan_dft_c2r_3d(n0, n1, n2, m->fa, m->in, FFTW_ESTIMATE);
    return 1;
}

static void fft_destroy(fft_matcher *m)
{
    fftw_destroy_plan(m->fwd_a);
    fftw_destroy_plan(m->fwd_b);
    fftw_destroy_plan(m->inv);
    fftw_free(m->in);
    fftw_free(m->fs);
    fftw_free(m->fs2);
    fftw_free(m->fa);
    fftw_free(m->fb);
}

/* Best block (lowest index among equal rounded distances). */
static void fft_match(fft_matcher *m, const gs_qfield *src, const gs_field_query *q, int64_t *best,
                      uint64_t *best_dist)
{
    int B = q->block;
    int64_t nx = src->nx, nxy = src->nx * src->ny;
    uint64_t wk, wu; /* per-sample weights of the distance (field.h): known, unknown */
    gs_field_query_weights(q, &wk, &wu);
    double qq = 0;
    memset(m->in, 0, (size_t)m->n * sizeof *m->in);
    for (int k = 0; k < B; k++)
        for (int j = 0; j < B; j++)
            for (int i = 0; i < B; i++) {
                int64_t o = i + B * (j + (int64_t)B * k);
                double w = (double)(q->known && !q->known[o] ? wu : wk), v = q->values[o];
                m->in[i + nx * j + nxy * k] = w * v;
                qq += w * v * v;
            }
    fftw_execute_dft_r2c(m->fwd_a, m->in, m->fa);
    memset(m->in, 0, (size_t)m->n * sizeof *m->in);
    for (int k = 0; k < B; k++)
        for (int j = 0; j < B; j++)
            for (int i = 0; i < B; i++) {
                int64_t o = i + B * (j + (int64_t)B * k);
                m->in[i + nx * j + nxy * k] = (double)(q->known && !q->known[o] ? wu : wk);
            }
    fftw_execute_dft_r2c(m->fwd_b, m->in, m->fb);
    /* corr(a, s)(p) = sum_x a(x) s(p + x)  <->  conj(A) S */
    for (int64_t i = 0; i < m->nc; i++)
        m->fa[i] = -2.0 * conj(m->fa[i]) * m->fs[i] + conj(m->fb[i]) * m->fs2[i];
    fftw_execute_dft_c2r(m->inv, m->fa, m->in);
    double scale = 1.0 / (double)m->n;
    int64_t bx = src->nx - B + 1, by = src->ny - B + 1, bz = src->nz - B + 1;
    *best = -1;
    for (int64_t z = 0; z < bz; z++)
        for (int64_t y = 0; y < by; y++)
            for (int64_t x = 0; x < bx; x++) {
                double d = qq + m->in[x + nx * y + nxy * z] * scale;
                uint64_t di = d < 0 ? 0 : (uint64_t)llround(d);
                if (*best < 0 || di < *best_dist) {
                    *best = x + bx * (y + by * z);
                    *best_dist = di;
                }
            }
}

static int parse_int_arg(const char *s, int64_t lo, int64_t hi, int64_t *out, const char *what)
{
    char why[128];
    if (!gs_parse_i64(s, lo, hi, out, why, sizeof why)) {
        fprintf(stderr, "bench_field: %s = '%s': %s\n", what, s, why);
        return 0;
    }
    return 1;
}

/* Quantized source of n samples along the longest axis: the mesh's signed
 * distance (range +-3 samples, the engine's default) or the procedural shape. */
static gs_qfield *make_source(int64_t n, gs_field_shape shape, const gs_mesh *mesh, const char *mesh_path)
{
    gs_field *f = NULL;
    gs_qfield *src = NULL;
    gs_err err = mesh ? gs_field_from_mesh(mesh, mesh_path, n, 2, 1, 0, &f)
                      : gs_field_make_shape(shape, n, 1, &f);
    /* cropped to a multiple of 4 per axis, as the engine crops for 3
     * iterations, so the synthesis queries below come from this very source */
    gs_field *c = NULL;
    if (err == GS_OK)
        err = gs_field_crop(f, 4, &c);
    if (err == GS_OK) {
        double r = 3 * c->spacing;
        err = gs_field_quantize(c, -r, r, &src);
    }
    gs_field_destroy(&c);
    gs_field_destroy(&f);
    if (err != GS_OK) {
        gs_error_report("bench_field: ");
        return NULL;
    }
    return src;
}

/* field.tree = sharded: the tree split into P z-slabs, one per rank
 * (gs_field_tree_build_slab). Memory: the largest slab's tree + pyramid
 * against the whole. Work: every query (the kinds below; the seeded kinds
 * are left out, a 256^3/32 one takes ~18 s whole) searched on each slab,
 * without a bound (no sharing: the slowest a rank can be) and with the
 * whole tree's best as bound (perfect sharing: the fastest); a distributed
 * query takes about the slowest slab's time, between the two (an unshared
 * search stops at SHARD_UNSHARED_POPS pops, so that figure is a lower
 * bound where "unshared_capped" > 0). Slabs are
 * built one at a time, so the process holds one slab besides the whole. */
#define SHARD_UNSHARED_POPS 1000000 /* unshared slab searches stop here (counted as capped) */
static const int shard_kinds[] = {K_SOURCE, K_PERTURBED, K_MASKED, K_WEIGHTED};
#define SHARD_KINDS ((int)(sizeof shard_kinds / sizeof *shard_kinds))

static int run_shards(const gs_qfield *src, int B, gs_field_searcher_t whole,
                      const gs_field_tree_info *wi, const int *ranks, int nranks, int queries)
{
    int64_t nb = (int64_t)B * B * B, bz = src->nz - B + 1;
    uint8_t *val = gs_malloc((size_t)nb), *known = gs_malloc((size_t)nb);
    int nq = SHARD_KINDS * queries;
    double *wt = gs_calloc((size_t)nq, sizeof *wt), *un = gs_calloc((size_t)nq, sizeof *un),
           *sh = gs_calloc((size_t)nq, sizeof *sh);
    uint64_t *wd = gs_calloc((size_t)nq, sizeof *wd);
    int64_t *wix = gs_calloc((size_t)nq, sizeof *wix);
    if (!val || !known || !wt || !un || !sh || !wd || !wix)
        return 0;
    int ok = 1;
    /* the whole tree's answers and times */
    for (int kk = 0; kk < SHARD_KINDS; kk++) {
        gs_rng r;
        gs_rng_init(&r, 7, gs_rng_stream_id(6, (uint64_t)shard_kinds[kk], (uint64_t)src->nx, (uint64_t)B));
        for (int t = 0; t < queries; t++) {
            int kind = shard_kinds[kk];
            make_query(&r, src, B, kind, val, known);
            gs_field_query q = {B, val, kind >= K_MASKED ? known : NULL,
                                kind == K_WEIGHTED ? BENCH_SEED_WEIGHT : 0};
            gs_field_match m;
            double t0 = gs_time_now();
            if (gs_field_tree_best_match(whole, &q, NULL, &m) != GS_OK)
                return 0;
            wt[kk * queries + t] = gs_time_now() - t0;
            wd[kk * queries + t] = m.dist, wix[kk * queries + t] = m.index;
        }
    }
    printf(",\n     \"shards\": [");
    for (int ri = 0; ri < nranks; ri++) {
        int P = ranks[ri];
        if (P > bz)
            continue;
        size_t bytes_max = 0;
        double build_max = 0;
        memset(un, 0, (size_t)nq * sizeof *un);
        memset(sh, 0, (size_t)nq * sizeof *sh);
        int agree = 0, capped = 0;
        for (int k = 0; k < P; k++) {
            int64_t z0 = bz * k / P, z1 = bz * (k + 1) / P;
            gs_field_tree_t t = NULL;
            gs_field_searcher_t ss = NULL;
            if (gs_field_tree_build_slab(src, B, z0, z1, &t) != GS_OK ||
                gs_field_searcher_create(t, &ss) != GS_OK) {
                gs_error_report("bench_field: ");
                return 0;
            }
            gs_field_tree_info ti;
            gs_field_tree_get_info(t, &ti);
            if (ti.tree_bytes + ti.pyramid_bytes > bytes_max)
                bytes_max = ti.tree_bytes + ti.pyramid_bytes;
            if (ti.build_seconds > build_max)
                build_max = ti.build_seconds;
            for (int kk = 0; kk < SHARD_KINDS; kk++) {
                gs_rng r;
                gs_rng_init(&r, 7, gs_rng_stream_id(6, (uint64_t)shard_kinds[kk], (uint64_t)src->nx,
                                                    (uint64_t)B));
                for (int qi = 0; qi < queries; qi++) {
                    int kind = shard_kinds[kk], j = kk * queries + qi;
                    make_query(&r, src, B, kind, val, known);
                    gs_field_query q = {B, val, kind >= K_MASKED ? known : NULL,
                                        kind == K_WEIGHTED ? BENCH_SEED_WEIGHT : 0};
                    gs_field_match m;
                    uint64_t bound = UINT64_MAX;
                    gs_field_search_opts cap = {0};
                    cap.max_pops = SHARD_UNSHARED_POPS;
                    double t0 = gs_time_now();
                    gs_field_tree_search(ss, 0, gs_field_tree_top_count(t), &q, &cap, &bound, &m);
                    double tu = gs_time_now() - t0;
                    if (tu > un[j])
                        un[j] = tu;
                    capped += m.truncated;
                    bound = wd[j];
                    t0 = gs_time_now();
                    gs_field_tree_search(ss, 0, gs_field_tree_top_count(t), &q, NULL, &bound, &m);
                    /* with the whole answer as bound, the slab holding it finds it exactly */
                    if (m.found && m.dist == wd[j] && m.index == wix[j])
                        agree++;
                    double ts = gs_time_now() - t0;
                    if (ts > sh[j])
                        sh[j] = ts;
                }
            }
            gs_field_searcher_destroy(&ss);
            gs_field_tree_destroy(&t);
        }
        size_t whole_bytes = wi->tree_bytes + wi->pyramid_bytes;
        printf("%s\n       {\"ranks\": %d, \"rank_bytes_max\": %zu, \"rank_bytes_vs_whole\": %.3f, "
               "\"rank_build_s_max\": %.3f, \"agree\": %d, \"n\": %d, \"unshared_capped\": %d, "
               "\"kinds\": {",
               ri ? "," : "", P, bytes_max, (double)bytes_max / (double)whole_bytes, build_max, agree,
               nq, capped);
        for (int kk = 0; kk < SHARD_KINDS; kk++) {
            double w = 0, u = 0, h = 0;
            for (int qi = 0; qi < queries; qi++) {
                int j = kk * queries + qi;
                w += wt[j], u += un[j], h += sh[j];
            }
            printf("%s\"%s\": {\"whole_s\": %.6f, \"slowest_rank_s_unshared\": %.6f, "
                   "\"slowest_rank_s_shared\": %.6f, \"rank_vs_whole_unshared\": %.3f, "
                   "\"rank_vs_whole_shared\": %.3f}",
                   kk ? ", " : "", kind_name[shard_kinds[kk]], w / queries, u / queries, h / queries,
                   w > 0 ? u / w : 0, w > 0 ? h / w : 0);
        }
        printf("}}");
        fflush(stdout);
        fprintf(stderr, "bench_field: %lld/%d sharded over %d: largest rank %.1f MB of %.1f MB\n",
                (long long)src->nx, B, P, bytes_max / 1e6, whole_bytes / 1e6);
        if (agree != nq)
            ok = 0;
    }
    printf("]");
    gs_free(val);
    gs_free(known);
    gs_free(wt);
    gs_free(un);
    gs_free(sh);
    gs_free(wd);
    gs_free(wix);
    return ok;
}

/* Real synthesis queries. The made-up kinds above stand for parts of a
 * synthesis; these are the queries a synthesis asks: every query of the
 * last iteration of a 3-iteration synthesis of this very source (target N/2
 * per axis, blocks B/2, B/2, B like the paper's 8, 8, 16; run.seed 1) is
 * recorded through the engine's match hook with the tree's time on it (so
 * the tree's mean, median, 90th percentile and worst are over every query
 * of the iteration, 343 here: a few far-off queries dominate the mean), and
 * `n` of them, evenly spread over the iteration, are answered again with the
 * FFT baseline and brute force (whose times hardly depend on the query) to
 * time those and check the answers. Three matching settings (see
 * configs/field): */
typedef struct synth_setting {
    const char *name;
    int mask, weight, seed_blocks;
} synth_setting;
static const synth_setting synth_settings[] = {
    {"synthesis_paper", 0, 0, 0},     /* mask_unsynthesized = no: whole blocks, seeds included */
    {"synthesis_weighted", 1, 64, 1}, /* grid.ini (make demo): seed_weight 0.25, seed_blocks */
    {"synthesis_masked", 1, 0, 0},    /* the engine default: unsynthesized samples ignored */
};
#define SYNTH_SETTINGS ((int)(sizeof synth_settings / sizeof *synth_settings))

/* One recorded query: values and known flags (B^3 each) after the header. */
typedef struct capture_rec {
    int has_mask, weight;
} capture_rec;

typedef struct capture {
    int last;            /* the iteration recorded */
    int64_t nb, n, cap;  /* B^3, queries recorded, room */
    size_t rec_bytes;    /* header + 2 B^3 */
    unsigned char *recs;
    double *seconds;     /* the tree's time on each, in the synthesis */
    uint64_t pops;
} capture;

static capture_rec *capture_at(const capture *c, int64_t i)
{
    return (capture_rec *)(c->recs + (size_t)i * c->rec_bytes);
}

/* Query i as recorded (values and flags point into the record). */
static gs_field_query capture_query(const capture *c, int B, int64_t i)
{
    capture_rec *r = capture_at(c, i);
    const uint8_t *v = (const uint8_t *)(r + 1);
    return (gs_field_query){B, v, r->has_mask ? v + c->nb : NULL, r->weight};
}

static gs_err capture_hook(void *ctx, gs_field_tree_t tree, gs_field_searcher_t s, int iteration,
                           const gs_field_query *q, const gs_field_search_opts *opts,
                           gs_field_match *out)
{
    capture *c = ctx;
    if (iteration != c->last)
        return gs_field_tree_best_match(s, q, opts, out);
    if (c->n == c->cap) {
        int64_t cap = c->cap ? 2 * c->cap : 64;
        unsigned char *r = gs_realloc(c->recs, (size_t)cap * c->rec_bytes);
        if (r)
            c->recs = r;
        double *t = r ? gs_realloc(c->seconds, (size_t)cap * sizeof *t) : NULL;
        if (t)
            c->seconds = t;
        GS_CHECK(t, GS_ERR_MEM, "out of memory for %lld recorded queries", (long long)cap);
        c->cap = cap;
    }
    capture_rec *r = capture_at(c, c->n);
    r->has_mask = q->known != NULL;
    r->weight = q->seed_weight;
    memcpy(r + 1, q->values, (size_t)c->nb);
    if (q->known)
        memcpy((uint8_t *)(r + 1) + c->nb, q->known, (size_t)c->nb);
    double t0 = gs_time_now();
    GS_CALL(gs_field_tree_best_match(s, q, opts, out));
    c->seconds[c->n++] = gs_time_now() - t0;
    c->pops += out->pops;
    return GS_OK;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static int run_synth_queries(int64_t size, const gs_qfield *src, int B, gs_field_searcher_t s,
                             const gs_field_tree_info *info, fft_matcher *fm, int nq,
                             int brute_queries, int64_t brute_max)
{
    int ok = 1;
    int64_t nb = (int64_t)B * B * B, T = src->nx > src->ny ? src->nx : src->ny;
    T = (T > src->nz ? T : src->nz) / 2 & ~(int64_t)3;
    if (T < 2 * B)
        T = 2 * B;
    printf(",\n     \"synthesis_queries\": {\"target\": %lld, \"blocks\": [%d, %d, %d]",
           (long long)T, B / 2, B / 2, B);
    for (int si = 0; si < SYNTH_SETTINGS && ok; si++) {
        const synth_setting *st = &synth_settings[si];
        gs_field_synth_config cfg;
        gs_field_synth_config_default(&cfg, src);
        cfg.block[0] = cfg.block[1] = B / 2 < 2 ? 2 : B / 2;
        cfg.block[2] = B;
        cfg.target[0] = cfg.target[1] = cfg.target[2] = T;
        cfg.mask_unsynthesized = st->mask;
        cfg.seed_weight = st->weight;
        cfg.seed_blocks = st->seed_blocks;
        capture cap = {cfg.iterations - 1, nb, 0, 0, sizeof(capture_rec) + 2 * (size_t)nb, NULL,
                       NULL, 0};
        cfg.match = capture_hook;
        cfg.match_ctx = &cap;
        gs_field_synth_t syn = NULL;
        int finished = 0;
        double t0 = gs_time_now();
        if (gs_field_synth_create(src, &cfg, &syn) != GS_OK ||
            gs_field_synth_run(syn, -1, &finished) != GS_OK) {
            gs_error_report("bench_field: ");
            ok = 0;
        }
        double synth_s = gs_time_now() - t0;
        gs_field_synth_destroy(&syn);
        int n = cap.n < nq ? (int)cap.n : nq;
        if (!ok || n == 0) {
            fprintf(stderr, "bench_field: %s recorded no query\n", st->name);
            ok = 0;
        }
        double fft_sum = 0, brute_sum = 0, dist_sum = 0;
        int agree = 0, fft_agree = 0, brute_done = 0, extrapolated = 0;
        for (int j = 0; j < n && ok; j++) {
            int64_t i = (2 * j + 1) * cap.n / (2 * n); /* evenly spread over the iteration */
            gs_field_query q = capture_query(&cap, B, i);
            gs_field_match mt, mb;
            if (gs_field_tree_best_match(s, &q, NULL, &mt) != GS_OK) {
                gs_error_report("bench_field: ");
                ok = 0;
                break;
            }
            uint64_t wk, wu;
            gs_field_query_weights(&q, &wk, &wu);
            dist_sum += (double)mt.dist / (double)wk / (double)nb;
            int64_t fi;
            uint64_t fd = 0;
            t0 = gs_time_now();
            fft_match(fm, src, &q, &fi, &fd);
            fft_sum += gs_time_now() - t0;
            fft_agree += fi == mt.index && fd == mt.dist;
            if (j < brute_queries) {
                int64_t end = info->blocks < brute_max ? info->blocks : brute_max;
                uint64_t bound = UINT64_MAX;
                t0 = gs_time_now();
                gs_field_brute_search(src, &q, 0, end, &bound, &mb);
                double bt = gs_time_now() - t0;
                if (end < info->blocks) {
                    extrapolated = 1;
                    bt *= (double)info->blocks / (double)end;
                } else {
                    agree += mb.index == mt.index && mb.dist == mt.dist;
                }
                brute_sum += bt;
                brute_done++;
            }
        }
        if (ok) {
            /* the tree over every recorded query (its mean is what a
             * synthesis pays; tails weigh), FFT and brute force on n */
            int64_t m = cap.n;
            double tree_sum = 0;
            for (int64_t i = 0; i < m; i++)
                tree_sum += cap.seconds[i];
            qsort(cap.seconds, (size_t)m, sizeof *cap.seconds, cmp_double);
            double tq = tree_sum / (double)m, fq = fft_sum / n;
            double bq = brute_done ? brute_sum / brute_done : 0;
            double med = m % 2 ? cap.seconds[m / 2] : (cap.seconds[m / 2 - 1] + cap.seconds[m / 2]) / 2;
            printf(",\n       \"%s\": {\"mask_unsynthesized\": %d, \"seed_weight\": %d, "
                   "\"seed_blocks\": %d, \"synthesis_s\": %.2f, \"recorded\": %lld, "
                   "\"tree_s\": %.6f, \"tree_median_s\": %.6f, \"tree_p90_s\": %.6f, "
                   "\"tree_max_s\": %.6f, \"pops\": %.0f, \"n\": %d, \"fft_s\": %.6f, "
                   "\"brute_s\": %.6f, \"brute_n\": %d, \"brute_extrapolated\": %s, "
                   "\"tree_vs_fft\": %.1f, \"tree_vs_fft_median\": %.1f, "
                   "\"tree_vs_brute\": %.1f, \"tree_vs_brute_median\": %.1f, \"agree\": %d, "
                   "\"fft_agree\": %d, \"mean_match_per_sample\": %.1f}",
                   st->name, st->mask, st->weight, st->seed_blocks, synth_s, (long long)m, tq, med,
                   cap.seconds[m * 9 / 10], cap.seconds[m - 1], (double)cap.pops / (double)m, n,
                   fq, bq, brute_done, extrapolated ? "true" : "false", fq / tq, fq / med, bq / tq,
                   bq / med, agree, fft_agree, dist_sum / n);
            fflush(stdout);
            fprintf(stderr, "bench_field: %lld/%d %s: tree mean %.4f s median %.4f s over %lld, "
                    "fft %.4f s, brute %.4f s\n", (long long)size, B, st->name, tq, med,
                    (long long)m, fq, bq);
            if ((!extrapolated && agree != brute_done) || fft_agree != n)
                ok = 0;
        }
        gs_free(cap.recs);
        gs_free(cap.seconds);
    }
    printf("}");
    return ok;
}

static int run_case(int64_t n, int B, int queries, int brute_queries, int64_t brute_max,
                    int fft_queries, gs_field_shape shape, const gs_mesh *mesh, const char *mesh_path,
                    const int *shards, int nshards, int shard_queries, int synth_queries, int first)
{
    gs_qfield *src = make_source(n, shape, mesh, mesh_path);
    if (!src)
        return 0;
    size_t mem0 = gs_mem_current();
    gs_field_tree_t tree = NULL;
    fprintf(stderr, "bench_field: building tree %lld^3 / %d\n", (long long)n, B);
    if (gs_field_tree_build(src, B, &tree) != GS_OK) {
        gs_error_report("bench_field: ");
        return 0;
    }
    size_t tree_mem = gs_mem_current() - mem0;
    gs_field_tree_info info;
    gs_field_tree_get_info(tree, &info);
    gs_field_searcher_t s = NULL;
    if (gs_field_searcher_create(tree, &s) != GS_OK)
        return 0;
    printf("%s    {\"source\": %lld, \"dims\": [%lld, %lld, %lld], \"block\": %d, \"shape\": \"%s\", "
           "\"blocks\": %lld, \"distinct\": %lld, \"nodes\": %lld, \"top\": %lld,\n",
           first ? "" : ",\n", (long long)n, (long long)src->nx, (long long)src->ny, (long long)src->nz,
           B, mesh ? mesh_path : gs_field_shape_name(shape), (long long)info.blocks,
           (long long)info.distinct, (long long)info.nodes, (long long)info.top);
    printf("     \"nodes_full_per_level\": [");
    for (int k = 0; k < info.levels; k++)
        printf("%s%lld", k ? ", " : "", (long long)info.level_full[k]);
    printf("], \"nodes_partial_per_level\": [");
    for (int k = 0; k < info.levels; k++)
        printf("%s%lld", k ? ", " : "", (long long)info.level_partial[k]);
    printf("],\n     \"tree_bytes\": %zu, \"pyramid_bytes\": %zu, \"build_bytes_held\": %zu, "
           "\"peak_bytes\": %zu, \"build_s\": %.3f, \"pyramid_s\": %.3f, \"dedup_s\": %.3f, "
           "\"sort_s\": %.3f,\n     \"queries\": {",
           info.tree_bytes, info.pyramid_bytes, tree_mem, gs_mem_peak(), info.build_seconds,
           info.pyramid_seconds, info.dedup_seconds, info.sort_seconds);
    int64_t nb = (int64_t)B * B * B;
    uint8_t *val = gs_malloc((size_t)nb), *known = gs_malloc((size_t)nb);
    int ok = 1;
    fft_matcher fm = {0};
    double fft_setup = gs_time_now();
    if (fft_queries > 0 && !fft_create(src, &fm)) {
        fprintf(stderr, "bench_field: out of memory for the FFT baseline\n");
        return 0;
    }
    fft_setup = gs_time_now() - fft_setup;
    for (int kind = 0; kind < K_COUNT; kind++) {
        gs_rng r;
        gs_rng_init(&r, 99, gs_rng_stream_id(5, (uint64_t)kind, (uint64_t)n, (uint64_t)B));
        double tree_time = 0, brute_time = 0, fft_time = 0;
        int fft_done = 0, fft_agree = 0;
        uint64_t pops = 0, refinements = 0;
        size_t qpeak = 0;
        int brute_done = 0, agree = 0, extrapolated = 0;
        for (int t = 0; t < queries; t++) {
            make_query(&r, src, B, kind, val, known);
            gs_field_query q = {B, val, kind >= K_MASKED ? known : NULL,
                                kind == K_WEIGHTED ? BENCH_SEED_WEIGHT : 0};
            gs_field_match mt, mb;
            double t0 = gs_time_now();
            if (gs_field_tree_best_match(s, &q, NULL, &mt) != GS_OK) {
                gs_error_report("bench_field: ");
                return 0;
            }
            tree_time += gs_time_now() - t0;
            pops += mt.pops;
            refinements += mt.refinements;
            if (mt.queue_peak > qpeak)
                qpeak = mt.queue_peak;
            if (t < fft_queries) {
                int64_t fi;
                uint64_t fd = 0;
                t0 = gs_time_now();
                fft_match(&fm, src, &q, &fi, &fd);
                fft_time += gs_time_now() - t0;
                fft_done++;
                fft_agree += fi == mt.index && fd == mt.dist;
            }
            if (t < brute_queries) {
                int64_t end = info.blocks < brute_max ? info.blocks : brute_max;
                uint64_t bound = UINT64_MAX;
                t0 = gs_time_now();
                gs_field_brute_search(src, &q, 0, end, &bound, &mb);
                double bt = gs_time_now() - t0;
                if (end < info.blocks) {
                    extrapolated = 1;
                    bt *= (double)info.blocks / (double)end;
                } else {
                    agree += mb.index == mt.index && mb.dist == mt.dist;
                }
                brute_time += bt;
                brute_done++;
            }
        }
        double tq = tree_time / queries, bq = brute_done ? brute_time / brute_done : 0;
        double fq = fft_done ? fft_time / fft_done : 0;
        printf("%s\n       \"%s\": {\"n\": %d, \"tree_s\": %.6f, \"brute_s\": %.6f, \"speedup\": %.1f, "
               "\"brute_n\": %d, \"brute_extrapolated\": %s, \"agree\": %d, \"fft_s\": %.6f, "
               "\"fft_n\": %d, \"fft_agree\": %d, \"tree_vs_fft\": %.1f, \"pops\": %.0f, "
               "\"refinements\": %.0f, \"queue_peak\": %zu}",
               kind ? "," : "", kind_name[kind], queries, tq, bq, tq > 0 ? bq / tq : 0, brute_done,
               extrapolated ? "true" : "false", agree, fq, fft_done, fft_agree, tq > 0 ? fq / tq : 0,
               (double)pops / queries, (double)refinements / queries, qpeak);
        fflush(stdout);
        if ((!extrapolated && agree != brute_done) || fft_agree != fft_done)
            ok = 0;
        fprintf(stderr, "bench_field: %lld/%d %s tree %.4f s brute %.4f s fft %.4f s\n", (long long)n,
                B, kind_name[kind], tq, bq, fq);
    }
    printf("},\n     \"fft_setup_s\": %.3f", fft_setup);
    if (synth_queries > 0) {
        if (fft_queries <= 0 && !fft_create(src, &fm)) {
            fprintf(stderr, "bench_field: out of memory for the FFT baseline\n");
            return 0;
        }
        ok &= run_synth_queries(n, src, B, s, &info, &fm, synth_queries, brute_queries, brute_max);
    }
    if (fft_queries > 0 || synth_queries > 0)
        fft_destroy(&fm);
    if (nshards > 0 && shard_queries > 0)
        ok &= run_shards(src, B, s, &info, shards, nshards, shard_queries);
    printf("}");
    gs_free(val);
    gs_free(known);
    gs_field_searcher_destroy(&s);
    gs_field_tree_destroy(&tree);
    gs_qfield_destroy(&src);
    return ok;
}

/* One whole synthesis with cfg (one core); the result's digest in *digest. */
static gs_field_synth_t synthesize(const gs_qfield *src, const gs_field_synth_config *cfg,
                                   double *seconds, uint64_t *digest)
{
    gs_field_synth_t syn = NULL;
    double t0 = gs_time_now();
    if (gs_field_synth_create(src, cfg, &syn) != GS_OK) {
        gs_error_report("bench_field: ");
        return NULL;
    }
    int finished = 0;
    while (!finished) {
        if (gs_field_synth_run(syn, 64, &finished) != GS_OK) {
            gs_error_report("bench_field: ");
            gs_field_synth_destroy(&syn);
            return NULL;
        }
        const gs_field_synth_state *st = gs_field_synth_get_state(syn);
        fprintf(stderr, "\rbench_field: synthesis%s iteration %d block %lld/%lld   ",
                cfg->use_upper_bound ? "" : " (no upper bound)", st->iteration,
                (long long)st->cursor, (long long)st->blocks_in_iteration);
    }
    fprintf(stderr, "\n");
    *seconds = gs_time_now() - t0;
    const gs_field_synth_state *st = gs_field_synth_get_state(syn);
    *digest = gs_digest_bytes(st->target, (size_t)(st->tn[0] * st->tn[1] * st->tn[2]));
    return syn;
}

static void print_iterations(const gs_field_synth_config *cfg, const gs_field_synth_state *st)
{
    for (int i = 0; i < cfg->iterations; i++)
        printf("%s{\"matches\": %lld, \"mean_dist\": %.2f, \"max_dist\": %.2f, \"mean_pops\": %.0f, "
               "\"pops\": %llu, \"pushes\": %llu}",
               i ? ", " : "", (long long)st->stat_count[i],
               st->stat_count[i] ? st->stat_sum[i] / st->stat_count[i] : 0, st->stat_max[i],
               st->stat_count[i] ? (double)st->stat_pops[i] / st->stat_count[i] : 0,
               (unsigned long long)st->stat_pops[i], (unsigned long long)st->stat_pushes[i]);
}

/* The engine's default synthesis of the 64^3 shape (3 iterations, 128^3),
 * with the queue pruning (field.upper_bound, the default) and without it:
 * the same result (digest), the pops and queue pushes of each iteration. */
static int run_synthesis(gs_field_shape shape)
{
    gs_field *f = NULL;
    gs_qfield *src = NULL;
    if (gs_field_make_shape(shape, 64, 1, &f) != GS_OK || gs_field_quantize(f, -3, 3, &src) != GS_OK)
        return 0;
    gs_field_destroy(&f);
    gs_field_synth_config cfg;
    gs_field_synth_config_default(&cfg, src);
    cfg.use_upper_bound = 0;
    double plain_s = 0, synth_s = 0;
    uint64_t plain_digest = 0, digest = 0;
    gs_field_synth_t plain = synthesize(src, &cfg, &plain_s, &plain_digest);
    cfg.use_upper_bound = 1;
    gs_field_synth_t syn = plain ? synthesize(src, &cfg, &synth_s, &digest) : NULL;
    if (!syn) {
        gs_field_synth_destroy(&plain);
        gs_qfield_destroy(&src);
        return 0;
    }
    const gs_field_synth_state *st = gs_field_synth_get_state(syn);
    gs_qfield *res = NULL;
    gs_field_synth_result(syn, &res);
    gs_field_tree_t tree = NULL;
    gs_field_tree_build(src, cfg.block[cfg.iterations - 1], &tree);
    gs_field_quality qm;
    double t0 = gs_time_now();
    gs_field_quality_measure(res, src, tree, &qm);
    double quality_s = gs_time_now() - t0;
    printf(",\n  \"synthesis\": {\"source\": 64, \"target\": %lld, \"iterations\": %d, \"blocks\": [",
           (long long)cfg.target[0], cfg.iterations);
    for (int i = 0; i < cfg.iterations; i++)
        printf("%s%d", i ? ", " : "", cfg.block[i]);
    printf("], \"seconds_one_core\": %.2f, \"per_iteration\": [", synth_s);
    print_iterations(&cfg, st);
    printf("],\n    \"no_upper_bound\": {\"seconds_one_core\": %.2f, \"same_digest\": %s, "
           "\"per_iteration\": [", plain_s, plain_digest == digest ? "true" : "false");
    print_iterations(&cfg, gs_field_synth_get_state(plain));
    printf("]},\n    \"volume_fraction_out\": %.4f, \"volume_fraction_src\": %.4f, "
           "\"surface_per_volume_out\": %.4f, \"surface_per_volume_src\": %.4f, "
           "\"coherence\": %.2f, \"coherence_blocks\": %lld, \"quality_s\": %.2f}",
           qm.volume_fraction_out, qm.volume_fraction_src, qm.surface_per_volume_out,
           qm.surface_per_volume_src, qm.coherence, (long long)qm.coherence_blocks, quality_s);
    gs_field_tree_destroy(&tree);
    gs_qfield_destroy(&res);
    gs_field_synth_destroy(&syn);
    gs_field_synth_destroy(&plain);
    gs_qfield_destroy(&src);
    return plain_digest == digest;
}

int main(int argc, char **argv)
{
    const char *sizes = "64/8,128/16,256/32";
    /* Defaults keep `make bench` near 15 minutes here: a seeded 256^3/32 tree query
     * takes ~18 s, a masked brute-force one over 2M blocks ~5 min. */
    int64_t queries = 12, brute = 2, brute_max = 500000, synth = 1, fft = 2;
    int64_t shard_queries = 2, synth_queries = 12;
    int shards[8], nshards = 0;
    const char *shard_list = "2,4";
    gs_field_shape shape = GS_FIELD_BALLS;
    const char *mesh_path = "${data}/meshes/armadillo.obj";
    char *mesh_abs = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!v) {
            fprintf(stderr, "bench_field: %s needs a value\n", a);
            return 1;
        }
        i++;
        if (!strcmp(a, "--sizes"))
            sizes = v;
        else if (!strcmp(a, "--queries")) {
            if (!parse_int_arg(v, 1, 1000000, &queries, a))
                return 1;
        } else if (!strcmp(a, "--brute")) {
            if (!parse_int_arg(v, 0, 1000000, &brute, a))
                return 1;
        } else if (!strcmp(a, "--fft")) {
            if (!parse_int_arg(v, 0, 1000000, &fft, a))
                return 1;
        } else if (!strcmp(a, "--brute-max-blocks")) {
            if (!parse_int_arg(v, 1, INT64_MAX, &brute_max, a))
                return 1;
        } else if (!strcmp(a, "--synth")) {
            if (!parse_int_arg(v, 0, 1, &synth, a))
                return 1;
        } else if (!strcmp(a, "--shape")) {
            int found = 0;
            for (int k = 0; k < 4; k++)
                if (!strcmp(v, gs_field_shape_name((gs_field_shape)k)))
                    shape = (gs_field_shape)k, found = 1;
            if (!found) {
                fprintf(stderr, "bench_field: --shape %s: expected spheres, grid, chainmail or balls\n", v);
                return 1;
            }
        } else if (!strcmp(a, "--shards")) {
            shard_list = v;
        } else if (!strcmp(a, "--synth-queries")) {
            if (!parse_int_arg(v, 0, 1000000, &synth_queries, a))
                return 1;
        } else if (!strcmp(a, "--shard-queries")) {
            if (!parse_int_arg(v, 0, 1000000, &shard_queries, a))
                return 1;
        } else if (!strcmp(a, "--mesh")) {
            mesh_path = strcmp(v, "none") ? v : NULL;
        } else {
            fprintf(stderr, "bench_field: unknown option %s\n", a);
            return 1;
        }
    }
    for (const char *sp = shard_list; *sp && strcmp(shard_list, "none");) {
        int64_t r;
        if (nshards == 8 || !gs_scan_i64(&sp, 2, 64, &r) || (*sp && *sp != ',')) {
            fprintf(stderr, "bench_field: --shards '%s': expected up to 8 rank counts in [2, 64] "
                            "(R[,R...]) or none\n", shard_list);
            return 1;
        }
        shards[nshards++] = (int)r;
        if (*sp == ',')
            sp++;
    }
    gs_mesh mesh, *meshp = NULL;
    if (mesh_path) {
        if (gs_path_absolute(mesh_path, NULL, &mesh_abs) != GS_OK) {
            gs_error_report("bench_field: ");
            return 1;
        }
        mesh_path = mesh_abs;
        if (gs_mesh_read(mesh_path, &mesh) != GS_OK) {
            gs_error_report("bench_field: ");
            return 1;
        }
        meshp = &mesh;
    }
    printf("{\"bench\": \"field\", \"cases\": [\n");
    int ok = 1, first = 1;
    const char *p = sizes;
    while (*p) {
        int64_t n, b;
        if (!gs_scan_i64(&p, 2, 4096, &n) || *p != '/') {
            fprintf(stderr, "bench_field: --sizes '%s': expected N/B[,N/B...]\n", sizes);
            return 1;
        }
        p++;
        if (!gs_scan_i64(&p, 2, 32, &b) || (*p && *p != ',')) {
            fprintf(stderr, "bench_field: --sizes '%s': expected N/B[,N/B...]\n", sizes);
            return 1;
        }
        if (*p == ',')
            p++;
        ok &= run_case(n, (int)b, (int)queries, (int)brute, brute_max, (int)fft, shape, meshp, mesh_path,
                       shards, nshards, (int)shard_queries, (int)synth_queries, first);
        first = 0;
    }
    printf("\n  ]");
    if (synth)
        ok &= run_synthesis(shape);
    printf(",\n  \"ok\": %s}\n", ok ? "true" : "false");
    if (meshp)
        gs_mesh_destroy(meshp);
    gs_free(mesh_abs);
    return ok ? 0 : 1;
}
