/* Single- and multi-resolution synthesis (paper 5.1, 5.2) and quality
 * metrics; see include/geosynth/field.h.
 *
 * Iteration i of I works at 1/2^(I-1-i) of the final resolution: the
 * source is subsampled by averaging (gs_qfield_downsample), the target has
 * target/2^(I-1-i) samples. Iteration 0 seeds the target with random source
 * samples (one gs_rng stream keyed by the seed); later iterations seed it
 * with the previous result upsampled by 2 (nearest). Blocks are visited in a
 * raster (x fastest) at a stride of B/2, the last position of each axis
 * clamped to the target edge, so after the first row each new block has one
 * unsynthesized octant (paper: "1/8th of the block"). The best match of the
 * whole block (paper; its random seeds of iteration 0 at the weight
 * GS_FIELD_PAPER_SEED_WEIGHT, field_impl.h says why) -- or, with
 * mask_unsynthesized, of its synthesized samples plus seed_weight/256 times
 * its unsynthesized ones (seeds, coarse result; 0 = ignored) -- is copied
 * into the unsynthesized samples. With
 * seed_blocks, iteration 0 starts from tiles of random source blocks.
 *
 * Measured (seed 1 and 2, quality against the source; see configs/field):
 * seed_weight 0 keeps the statistics but the output is built of source
 * blocks (demo: every output block exists in the source, coherence 0);
 * 0.25 with seed_blocks improves GRID 64^3 -> 128^3 (coherence 30.8 vs
 * 38.0, verbatim blocks 0.25 vs 0.38, volume fraction 0.1617 vs source
 * 0.1611) but on the small quick.ini source (16^3 at iteration 0) any
 * weight >= 1/16 pulls towards empty blocks (volume fraction 0.08-0.14 vs
 * 0.16), and on chainmail (periodic) weights below 0.75 change nothing.
 * So the default stays 0 and configs opt in.
 *
 * The paper reuses one tree for all iterations by dropping leaves; with
 * every overlapping block position in the tree, the subsampled source has
 * different block positions, so each iteration builds its (small) tree. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "field_impl.h"
#include "geosynth/digest.h"
#include "geosynth/field_examples.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/sort.h"

#define SYNTH_SEED_DOMAIN 0x53594eu /* "SYN" */
#define FIRST_BLOCK_DOMAIN 0x465242u /* "FRB" */
#define TIE_DOMAIN 0x464954u         /* "FIT": the matcher's tie order per block */
/* copy_exclusions: 7 lower neighbours' continuations and 7 repeat boxes, each
 * split in up to 2 along every wrapped axis (cfg.wrap) */
#define MAX_EXCLUSIONS (14 * 8)

struct gs_field_synth {
    const gs_qfield *src;
    gs_field_synth_config cfg;
    gs_field_synth_state st;
    gs_qfield *level_src;         /* source at the current iteration's resolution (with
                                     cfg.wrap: continued past its high faces, wrap_level) */
    int64_t wn[3];                /* level source's own size (before wrap_level) */
    /* keep_volume: per block position of the level source, the tie class
     * while the target is short of inside samples (the most inside first) and
     * while it has too many (the fewest first); the level source's own inside
     * samples (of src_n) and the synthesized ones (of vol_n) so far */
    uint8_t *tie_more, *tie_less;
    uint8_t inside[256];
    int64_t src_in, src_n, vol_in, vol_n;
    /* keep_volume with target regions (region_volume): vol_in/vol_n hold
     * region kv_region's counts (-1: none yet); kv_out_* the samples outside
     * every box of colour kv_color of iteration kv_it; kv_mark marks those
     * boxes (kv_cap samples) */
    int64_t kv_region, kv_out_in, kv_out_n;
    int kv_color, kv_it;
    uint8_t *kv_mark;
    size_t kv_cap;
    gs_field_tree_t tree;
    gs_field_searcher_t searcher;
    int64_t pos[3][4096];         /* visit positions per axis */
    int64_t npos[3];
    uint8_t *qval, *qknown;
    /* target regions of the current iteration (region_blocks > 0), sorted
     * by (color, id); order[cursor] = block index (x fastest over npos) */
    int64_t *order;               /* NULL: the raster order */
    int64_t *match_at;            /* per block position of the iteration: matched index + 1
                                     (0: not yet), for the upper bound's candidate and the
                                     copy limit */
    int32_t (*rbox)[6];           /* per matched block position: bounding box (samples, lo
                                     x y z, hi x y z) of the copy it belongs to (copy_limit) */
    int objects_done;             /* gs_field_synth_complete_objects ran */
    int heights_done;             /* gs_field_synth_height_match ran */
    int64_t (*ex)[6];             /* exclusion boxes of the block being matched (copy_exclusions) */
    int nex_cap;
    uint8_t *exmark;              /* repeat_span: source blocks its boxes cover (level source) */
    int64_t *exlist;              /* the marked ones, to clear */
    int64_t nexlist;
    uint8_t *feature;             /* repeat_span: per level source block, 1 = its relief (steps
                                     along x and y) at or above the median: a feature */
    int64_t nreg;
    int64_t nr[3];                /* regions per axis */
    gs_field_region *reg;
    uint8_t *scratch;             /* 2 x the largest region box: target, mask */
    size_t scratch_len;
    /* object_spacing (object_setup, object_exclusions): the source's objects
     * (components of gs_field_layout_mask: columns of a height field, ob_dims
     * 2, or cores, 3), ob_label per mask cell (ob_ln), centres ob_c (3 an
     * object) and boxes ob_box (samples, inclusive); ob_dmin the excluded
     * spacing, ob_same the same object's; ob_forbid the source blocks the
     * block being matched may not take (ob_list: the marked ones), ob_e the
     * target's objects around it (3 an object, ob_ecap) */
    int ob_ready, ob_dims;
    int64_t ob_n, ob_ln[3];
    uint32_t *ob_label;
    double *ob_c, ob_dmin, ob_same, *ob_e;
    int64_t (*ob_box)[6];
    uint8_t *ob_forbid;
    int64_t *ob_list, ob_nlist, ob_ecap;
    uint32_t *ob_el;             /* the source object of each ob_e */
    int64_t *ob_cnt, *ob_stamp;  /* object_continue: per source block, the open objects it
                                    continues, and the last one counted */
    gs_field_cut_scratch cut;     /* seam_cut: the max-flow graph of one block */
    uint8_t *cut_term, *cut_new;  /* per block sample: tie, and the cut's choice */
    uint32_t *cut_cost;           /* per block sample: old/new disagreement */
};

/* What the region path needs to replay one block (apply). */
typedef struct block_result {
    int64_t index;                /* matched source block */
    double nd;                    /* normalized match distance */
    uint64_t pops;
    uint64_t pushes;              /* queue pushes (the upper bound lowers them) */
} block_result;

/* A box of samples the blocks read and write: the whole target, or a
 * region's private copy. */
typedef struct synth_view {
    uint8_t *target, *mask;
    int64_t o[3], n[3];           /* origin in the target, size */
} synth_view;

void gs_field_synth_config_default(gs_field_synth_config *c, const gs_qfield *src)
{
    memset(c, 0, sizeof *c);
    c->iterations = 3;
    c->block[0] = 8, c->block[1] = 8, c->block[2] = 16;
    for (int i = 3; i < GS_FIELD_MAX_ITER; i++)
        c->block[i] = 16;
    c->target[0] = 2 * src->nx, c->target[1] = 2 * src->ny, c->target[2] = 2 * src->nz;
    c->seed = 1;
    c->coarse_weight = 256;
}

static gs_err validate(const gs_qfield *src, const gs_field_synth_config *c)
{
    GS_CHECK(c->iterations >= 1 && c->iterations <= GS_FIELD_MAX_ITER, GS_ERR_ARG,
             "field.iterations = %d: expected 1..%d", c->iterations, GS_FIELD_MAX_ITER);
    int64_t f = (int64_t)1 << (c->iterations - 1);
    const int64_t sn[3] = {src->nx, src->ny, src->nz};
    for (int a = 0; a < 3; a++) {
        GS_CHECK(c->target[a] % f == 0 && c->target[a] >= f && c->target[a] <= 4096, GS_ERR_ARG,
                 "field.target[%d] = %lld: expected a multiple of %lld (2^(iterations-1)) in [%lld, 4096]",
                 a, (long long)c->target[a], (long long)f, (long long)f);
        GS_CHECK(sn[a] % f == 0, GS_ERR_ARG,
                 "source size %lld along axis %d: expected a multiple of %lld for %d iterations",
                 (long long)sn[a], a, (long long)f, c->iterations);
    }
    GS_CHECK(c->tree_shards <= 1 || (c->tree_shard >= 0 && c->tree_shard < c->tree_shards &&
                                     c->match),
             GS_ERR_ARG, "tree shard %d of %d: expected 0..%d and a match hook that combines the "
             "shards", c->tree_shard, c->tree_shards, c->tree_shards - 1);
    GS_CHECK(c->repeat_reach >= 0 && (c->repeat_reach == 0 ||
                                       2 * c->repeat_reach < c->block[c->iterations - 1]),
             GS_ERR_ARG, "field.repeat_reach = %d: expected 0 (off) or less than block/2 = %d "
             "(a neighbour's continuation must stay allowed)", c->repeat_reach,
             c->block[c->iterations - 1] / 2);
    GS_CHECK(c->repeat_span >= 0 && c->repeat_span <= 16, GS_ERR_ARG,
             "field.repeat_span = %d: expected 0 (off) to 16 block positions", c->repeat_span);
    GS_CHECK(c->repeat_pairs >= 0 && c->repeat_pairs <= 15, GS_ERR_ARG,
             "field.repeat_pairs = %d: expected 0 (off) to 15 block positions", c->repeat_pairs);
    GS_CHECK(c->repeat_free == 0 || (c->repeat_free >= 0.05 && c->repeat_free <= 1), GS_ERR_ARG,
             "field.repeat_free = %g: expected a share of the source from 0.05 to 1", c->repeat_free);
    GS_CHECK(c->region_blocks >= 0 && c->region_blocks <= 4096, GS_ERR_ARG,
             "field.region_blocks = %d: expected 0 (one region) or 1..4096 block positions per "
             "region", c->region_blocks);
    GS_CHECK(c->object_spacing >= 0 && c->object_spacing <= 2 &&
                 (c->object_spacing == 0 || (c->region_blocks == 0 && c->prov)),
             GS_ERR_ARG, "field.object_spacing = %g: expected 0 (off) or at most 2 with "
             "region_blocks 0 and a provenance map", c->object_spacing);
    GS_CHECK(c->object_same >= 0 && c->object_same < 1, GS_ERR_ARG,
             "field.object_same = %g: expected a share of the spacing in (0, 1)", c->object_same);
    for (int i = 0; i < c->iterations; i++) {
        int B = c->block[i];
        int64_t fi = (int64_t)1 << (c->iterations - 1 - i);
        int ok = B >= 2 && B <= 32 && (B & (B - 1)) == 0;
        for (int a = 0; a < 3 && ok; a++)
            ok = B <= sn[a] / fi && B <= c->target[a] / fi;
        GS_CHECK(ok, GS_ERR_ARG,
                 "field.block[%d] = %d: expected a power of two in [2, 32] not larger than the "
                 "source (%lld) or target (%lld) at that iteration",
                 i, B, (long long)(sn[0] / fi), (long long)(c->target[0] / fi));
    }
    return GS_OK;
}

static int cmp_region(const void *a_, const void *b_)
{
    const gs_field_region *a = a_, *b = b_;
    if (a->color != b->color)
        return a->color < b->color ? -1 : 1;
    return a->id < b->id ? -1 : a->id > b->id;
}

/* Regions of the current iteration and the visit order (region_blocks > 0).
 * Along each axis region r starts at block position r*R (a last region of
 * fewer than 3 positions joins the one before, so the clamped last position
 * and the two before it share a region); its blocks cover the samples
 * [pos[first], pos[last] + B), its core (what it synthesizes) starts B/2
 * higher, where the block before it ends, so the cores tile the target and a
 * region reads the top B/2 of its lower neighbours' cores. Color = rx + ry +
 * rz (a wavefront): every region it reads is of a lower color.
 *
 * Why this is the raster order's result (tests/unit/test_field.c checks it):
 * two blocks P, Q interact only where they overlap, i.e. when their
 * positions differ by at most one along every axis (stride B/2; near the
 * clamped end by two, inside one region). The block M = min(P, Q)
 * (componentwise) covers that overlap. If M is neither P nor Q, M comes
 * before both in the raster order and in the region order (M's region is
 * componentwise <= theirs, so of a lower color or the same region), so the
 * overlap is synthesized before either reads it and their order does not
 * matter; if M = P, P comes first in both orders. So every pair that
 * interacts is visited in the same relative order. */
/* Block positions [*f, *l) of region `id` along axis a (nr regions per axis). */
static void region_span(const struct gs_field_synth *s, const int64_t nr[3], int64_t id, int a,
                        int64_t *f, int64_t *l)
{
    int64_t idx = a == 0 ? id % nr[0] : a == 1 ? id / nr[0] % nr[1] : id / (nr[0] * nr[1]);
    *f = idx * s->cfg.region_blocks;
    *l = idx == nr[a] - 1 ? s->npos[a] : *f + s->cfg.region_blocks;
}

static gs_err build_regions(struct gs_field_synth *s, int B)
{
    gs_free(s->order);
    gs_free(s->reg);
    s->order = NULL, s->reg = NULL, s->nreg = 0;
    if (s->cfg.region_blocks <= 0)
        return GS_OK;
    int64_t R = s->cfg.region_blocks, nr[3];
    for (int a = 0; a < 3; a++) {
        nr[a] = (s->npos[a] + R - 1) / R;
        if (nr[a] > 1 && s->npos[a] - (nr[a] - 1) * R < 3)
            nr[a]--;
    }
    int64_t n = nr[0] * nr[1] * nr[2];
    memcpy(s->nr, nr, sizeof s->nr);
    GS_CALL(gs_alloc_array((void **)&s->reg, (size_t)n, sizeof *s->reg, "target regions"));
    GS_CALL(gs_alloc_array((void **)&s->order, (size_t)s->st.blocks_in_iteration, sizeof *s->order,
                           "block visit order"));
    for (int64_t r = 0; r < n; r++) {
        gs_field_region *g = &s->reg[r];
        g->id = r;
        g->color = 0;
        for (int a = 0; a < 3; a++) {
            int64_t f, l;
            region_span(s, nr, r, a, &f, &l);
            g->color += (int)(f / R);
            g->lo[a] = s->pos[a][f];
            g->hi[a] = s->pos[a][l - 1] + B;
        }
    }
    qsort(s->reg, (size_t)n, sizeof *s->reg, cmp_region);
    int64_t c = 0;
    size_t big = 0;
    for (int64_t r = 0; r < n; r++) {
        gs_field_region *g = &s->reg[r];
        int64_t f[3], l[3];
        for (int a = 0; a < 3; a++)
            region_span(s, nr, g->id, a, &f[a], &l[a]);
        g->first = c;
        for (int64_t z = f[2]; z < l[2]; z++)
            for (int64_t y = f[1]; y < l[1]; y++)
                for (int64_t x = f[0]; x < l[0]; x++)
                    s->order[c++] = x + s->npos[0] * (y + s->npos[1] * z);
        g->count = c - g->first;
        size_t v = (size_t)((g->hi[0] - g->lo[0]) * (g->hi[1] - g->lo[1]) * (g->hi[2] - g->lo[2]));
        if (v > big)
            big = v;
    }
    s->nreg = n;
    if (2 * big > s->scratch_len) {
        gs_free(s->scratch);
        s->scratch_len = 0;
        GS_CALL(gs_alloc_array((void **)&s->scratch, 2, big, "region scratch box"));
        s->scratch_len = 2 * big;
    }
    return GS_OK;
}

/* repeat_span: the level's source blocks that are features, whose relief
 * (summed |level step| along x and y inside the block) is at or above the
 * median over its blocks. A plain (a flat stretch of a height field, no step
 * along x or y) may repeat, a summit may not: excluding every block, the
 * plains along the example's border could not repeat and terrain.ini's
 * volume fraction rose to 0.44-0.50 over seeds 1-6 (the example's 0.416). */
static gs_err block_features(struct gs_field_synth *s, int B)
{
    const gs_qfield *ls = s->level_src;
    int64_t bn[3] = {ls->nx - B + 1, ls->ny - B + 1, ls->nz - B + 1}, n = bn[0] * bn[1] * bn[2];
    uint64_t *r = NULL, *t = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&r, (size_t)n, sizeof *r, "block relief"), done);
    GS_TRY(err, gs_alloc_array((void **)&t, (size_t)n, sizeof *t, "block relief"), done);
    GS_TRY(err, gs_alloc_array((void **)&s->feature, (size_t)n, 1, "block features"), done);
    for (int64_t k = 0; k < n; k++) {
        int64_t x0 = k % bn[0], y0 = k / bn[0] % bn[1], z0 = k / (bn[0] * bn[1]);
        uint64_t sum = 0;
        for (int64_t z = z0; z < z0 + B; z++)
            for (int64_t y = y0; y < y0 + B; y++)
                for (int64_t x = x0; x < x0 + B; x++) {
                    const uint8_t *v = ls->q + x + ls->nx * (y + ls->ny * z);
                    if (x + 1 < x0 + B)
                        sum += (uint64_t)abs(v[1] - v[0]);
                    if (y + 1 < y0 + B)
                        sum += (uint64_t)abs(v[ls->nx] - v[0]);
                }
        r[k] = t[k] = sum;
    }
    gs_sort_u64(t, (size_t)n);
    for (int64_t k = 0; k < n; k++)
        s->feature[k] = r[k] >= t[n / 2];
done:
    gs_free(r);
    gs_free(t);
    return err;
}

/* cfg.wrap: the example is a tile. A block lies inside the source, so a
 * source sample within B - 1 of a face lies in fewer blocks than one in the
 * middle (a corner sample in 1 of 49^2 positions of 16^2 blocks in 64^2):
 * the synthesis copies an example's middle more often than its border.
 * texture.ini's discs sit in the middle of a white border: disc cover 0.288
 * in the example, 0.43 in the blocks weighted by how many cover each sample,
 * 0.30-0.44 in the outputs of seeds 1-12 and their surface per volume 1-20%
 * over the source's (the perimeter per disc area as the source's). Continued
 * by B - 1 samples of itself past each wrapped high face, the source holds
 * one block position per sample along that axis, each sample in B of them. */
static gs_err wrap_level(struct gs_field_synth *s, int B)
{
    gs_qfield *l = s->level_src;
    const int64_t n[3] = {l->nx, l->ny, l->nz};
    memcpy(s->wn, n, sizeof s->wn);
    if (!s->cfg.wrap)
        return GS_OK;
    int64_t m[3];
    for (int a = 0; a < 3; a++)
        m[a] = s->cfg.wrap >> a & 1 ? n[a] + B - 1 : n[a];
    gs_qfield *w = NULL;
    GS_CALL(gs_qfield_create(m[0], m[1], m[2], l->lo, l->hi, &w));
    for (int64_t z = 0; z < m[2]; z++)
        for (int64_t y = 0; y < m[1]; y++)
            for (int64_t x = 0; x < m[0]; x++)
                w->q[x + m[0] * (y + m[1] * z)] =
                    l->q[x % n[0] + n[0] * (y % n[1] + n[1] * (z % n[2]))];
    memcpy(w->origin, l->origin, sizeof w->origin);
    w->spacing = l->spacing;
    gs_qfield_destroy(&s->level_src);
    s->level_src = w;
    return GS_OK;
}

/* Index in the level source's own samples (s->wn) of sample `i` of the
 * wrapped level source. */
static int64_t unwrap_index(const struct gs_field_synth *s, int64_t i)
{
    const gs_qfield *l = s->level_src;
    if (!s->cfg.wrap)
        return i;
    int64_t x = i % l->nx, y = i / l->nx % l->ny, z = i / (l->nx * l->ny);
    return x % s->wn[0] + s->wn[0] * (y % s->wn[1] + s->wn[1] * (z % s->wn[2]));
}

/* cfg.keep_volume: the exact best match of a block is often not one block
 * but many (blocks equal where the query is known: flat background, a
 * periodic source); which of them is taken decides what the unknown samples
 * get. With keep_volume the tie goes to the blocks with the most inside
 * samples while the synthesized samples so far hold fewer inside than the
 * level source's share, else the fewest (then the seeded order). Counts of
 * the level source and of the target's synthesized samples, and per block
 * position its class for either case (inside count in 255ths of B^3). */
static gs_err volume_classes(struct gs_field_synth *s, int B)
{
    gs_free(s->tie_more);
    gs_free(s->tie_less);
    s->tie_more = s->tie_less = NULL;
    if (!s->cfg.keep_volume)
        return GS_OK;
    const gs_qfield *l = s->level_src;
    for (int i = 0; i < 256; i++)
        s->inside[i] = gs_qfield_value(l, (uint8_t)i) < 0;
    s->src_in = 0, s->src_n = s->wn[0] * s->wn[1] * s->wn[2];
    for (int64_t z = 0; z < s->wn[2]; z++)
        for (int64_t y = 0; y < s->wn[1]; y++)
            for (int64_t x = 0; x < s->wn[0]; x++)
                s->src_in += s->inside[l->q[x + l->nx * (y + l->ny * z)]];
    s->vol_in = s->vol_n = 0;
    s->kv_region = -1, s->kv_color = -1;
    int64_t n = s->st.tn[0] * s->st.tn[1] * s->st.tn[2];
    for (int64_t i = 0; i < n; i++)
        if (s->st.mask[i])
            s->vol_n++, s->vol_in += s->inside[s->st.target[i]];
    /* inside counts of every block: prefix sums over the level source */
    int64_t px = l->nx + 1, py = l->ny + 1, pz = l->nz + 1;
    int64_t *ps = NULL;
    GS_CALL(gs_alloc_array((void **)&ps, (size_t)(px * py * pz), sizeof *ps, "inside sums"));
    for (int64_t z = 1; z < pz; z++)
        for (int64_t y = 1; y < py; y++)
            for (int64_t x = 1; x < px; x++)
                ps[x + px * (y + py * z)] =
                    s->inside[l->q[x - 1 + l->nx * (y - 1 + l->ny * (z - 1))]] +
                    ps[x - 1 + px * (y + py * z)] + ps[x + px * (y - 1 + py * z)] +
                    ps[x + px * (y + py * (z - 1))] - ps[x - 1 + px * (y - 1 + py * z)] -
                    ps[x - 1 + px * (y + py * (z - 1))] - ps[x + px * (y - 1 + py * (z - 1))] +
                    ps[x - 1 + px * (y - 1 + py * (z - 1))];
    int64_t M = gs_field_block_count(l, B);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&s->tie_more, (size_t)M, 1, "tie classes"), done);
    GS_TRY(err, gs_alloc_array((void **)&s->tie_less, (size_t)M, 1, "tie classes"), done);
    for (int64_t g = 0; g < M; g++) {
        int64_t p[3];
        gs_field_block_position(l, B, g, p);
        int64_t c = 0;
        for (int k = 0; k < 8; k++) { /* inclusion-exclusion: + at the far corner */
            int64_t x = p[0] + (k & 1 ? B : 0), y = p[1] + (k & 2 ? B : 0),
                    z = p[2] + (k & 4 ? B : 0);
            int far = (k & 1) + (k >> 1 & 1) + (k >> 2 & 1);
            c += (far % 2 ? 1 : -1) * ps[x + px * (y + py * z)];
        }
        uint8_t v = (uint8_t)((c * 255 + (int64_t)B * B * B / 2) / ((int64_t)B * B * B));
        s->tie_less[g] = v;
        s->tie_more[g] = (uint8_t)(255 - v);
    }
done:
    gs_free(ps);
    return err;
}

static gs_err object_setup(struct gs_field_synth *s);

/* Builds the level source, tree, searcher and visit order of st.iteration. */
static gs_err enter_iteration(struct gs_field_synth *s)
{
    gs_field_searcher_destroy(&s->searcher);
    gs_field_tree_destroy(&s->tree);
    gs_qfield_destroy(&s->level_src);
    int it = s->st.iteration;
    if (it >= s->cfg.iterations)
        return GS_OK;
    int64_t f = (int64_t)1 << (s->cfg.iterations - 1 - it);
    int B = s->cfg.block[it];
    GS_CALL(gs_qfield_downsample(s->src, (int)f, &s->level_src));
    GS_CALL(wrap_level(s, B));
    GS_CALL(volume_classes(s, B));
    /* the whole tree, or this shard's z-slab of it (NULL when empty) */
    GS_CALL(gs_field_tree_build_shard(s->level_src, B, s->cfg.tree_shards, s->cfg.tree_shard,
                                      &s->tree));
    if (s->tree)
        GS_CALL(gs_field_searcher_create(s->tree, &s->searcher));
    for (int a = 0; a < 3; a++) {
        int64_t T = s->cfg.target[a] / f, n = 0;
        for (int64_t p = 0; p + B < T; p += B / 2)
            s->pos[a][n++] = p;
        s->pos[a][n++] = T - B;
        s->npos[a] = n;
    }
    s->st.blocks_in_iteration = s->npos[0] * s->npos[1] * s->npos[2];
    gs_free(s->match_at);
    s->match_at = NULL;
    GS_CALL(gs_alloc_array((void **)&s->match_at, (size_t)s->st.blocks_in_iteration,
                           sizeof *s->match_at, "block matches"));
    memset(s->match_at, 0, (size_t)s->st.blocks_in_iteration * sizeof *s->match_at);
    gs_free(s->rbox);
    s->rbox = NULL;
    GS_CALL(gs_alloc_array((void **)&s->rbox, (size_t)s->st.blocks_in_iteration, sizeof *s->rbox,
                           "copy boxes"));
    {
        /* repeat_span: a box per block within K positions (every direction);
         * repeat_pairs: up to one per matched block and lower neighbour */
        int64_t K = s->cfg.repeat_span, nb = (2 * K + 1) * (2 * K + 1) * (2 * K + 1);
        int64_t np_ = s->cfg.repeat_pairs > 0 ? 7 * s->st.blocks_in_iteration : 0;
        int64_t nsb = gs_field_block_count(s->level_src, B);
        gs_free(s->ex);
        gs_free(s->exmark);
        gs_free(s->exlist);
        gs_free(s->feature);
        s->ex = NULL, s->exmark = NULL, s->exlist = NULL, s->feature = NULL, s->nexlist = 0;
        s->nex_cap = (int)((s->cfg.wrap ? MAX_EXCLUSIONS : 14) + (K > 0 ? nb : 0) + np_);
        GS_CALL(gs_alloc_array((void **)&s->ex, (size_t)s->nex_cap, sizeof *s->ex, "exclusion boxes"));
        if (K > 0 || np_ > 0) {
            GS_CALL(gs_alloc_array((void **)&s->exmark, (size_t)nsb, 1, "repeat marks"));
            memset(s->exmark, 0, (size_t)nsb);
            GS_CALL(gs_alloc_array((void **)&s->exlist, (size_t)nsb, sizeof *s->exlist, "repeat marks"));
            GS_CALL(block_features(s, B));
        }
    }
    GS_CALL(build_regions(s, B));
    if (s->cfg.object_spacing > 0 && it == s->cfg.iterations - 1) {
        int64_t nsb = gs_field_block_count(s->level_src, B);
        GS_CALL(object_setup(s));
        gs_free(s->ob_forbid);
        gs_free(s->ob_list);
        s->ob_forbid = NULL, s->ob_list = NULL, s->ob_nlist = 0;
        GS_CALL(gs_alloc_array((void **)&s->ob_forbid, (size_t)nsb, 1, "object spacing marks"));
        memset(s->ob_forbid, 0, (size_t)nsb);
        GS_CALL(gs_alloc_array((void **)&s->ob_list, (size_t)nsb, sizeof *s->ob_list,
                               "object spacing marks"));
    }
    if (s->cfg.seam_cut) {
        size_t nb = (size_t)B * B * B;
        GS_CALL(gs_field_cut_scratch_init(&s->cut, B));
        gs_free(s->cut_term);
        gs_free(s->cut_new);
        gs_free(s->cut_cost);
        s->cut_term = s->cut_new = NULL, s->cut_cost = NULL;
        GS_CALL(gs_alloc_array((void **)&s->cut_term, nb, 1, "seam cut ties"));
        GS_CALL(gs_alloc_array((void **)&s->cut_new, nb, 1, "seam cut labels"));
        GS_CALL(gs_alloc_array((void **)&s->cut_cost, nb, sizeof *s->cut_cost, "seam cut costs"));
    }
    gs_free(s->qval);
    gs_free(s->qknown);
    s->qval = gs_malloc((size_t)B * B * B);
    s->qknown = gs_malloc((size_t)B * B * B);
    GS_CHECK(s->qval && s->qknown, GS_ERR_MEM, "out of memory for a query block of %d^3", B);
    return GS_OK;
}

static gs_err alloc_state(struct gs_field_synth *s, const int64_t tn[3])
{
    size_t n = (size_t)(tn[0] * tn[1] * tn[2]);
    gs_free(s->st.target);
    gs_free(s->st.mask);
    s->st.target = s->st.mask = NULL;
    GS_CALL(gs_alloc_array((void **)&s->st.target, n, 1, "synthesis target"));
    GS_CALL(gs_alloc_array((void **)&s->st.mask, n, 1, "synthesis mask"));
    memcpy(s->st.tn, tn, sizeof s->st.tn);
    return GS_OK;
}

static void note_match(struct gs_field_synth *s, int64_t b);

static gs_err synth_new(const gs_qfield *src, const gs_field_synth_config *c, struct gs_field_synth **out)
{
    GS_CALL(validate(src, c));
    struct gs_field_synth *s = gs_calloc(1, sizeof *s);
    GS_CHECK(s, GS_ERR_MEM, "out of memory for a synthesis");
    s->src = src;
    s->cfg = *c;
    *out = s;
    return GS_OK;
}

gs_err gs_field_synth_create(const gs_qfield *src, const gs_field_synth_config *c,
                             gs_field_synth_t *out)
{
    struct gs_field_synth *s = NULL;
    GS_CALL(synth_new(src, c, &s));
    gs_err err = GS_OK;
    int64_t f = (int64_t)1 << (c->iterations - 1);
    int64_t tn[3] = {c->target[0] / f, c->target[1] / f, c->target[2] / f};
    GS_TRY(err, alloc_state(s, tn), fail);
    for (int i = 0; i < GS_FIELD_MAX_ITER; i++)
        s->st.stat_min[i] = 1e300;
    GS_TRY(err, enter_iteration(s), fail);
    /* paper 5.1: every target sample starts as a random source sample */
    gs_rng r;
    gs_rng_init(&r, c->seed, gs_rng_stream_id(SYNTH_SEED_DOMAIN, 0, 0, 0));
    const gs_qfield *ls = s->level_src;
    uint64_t ns = (uint64_t)(s->wn[0] * s->wn[1] * s->wn[2]);
    int64_t n = tn[0] * tn[1] * tn[2];
    if (!c->seed_blocks) {
        for (int64_t i = 0; i < n; i++) { /* a sample of the level source's own */
            int64_t k = (int64_t)gs_rng_below(&r, ns);
            s->st.target[i] = ls->q[k % s->wn[0] + ls->nx * (k / s->wn[0] % s->wn[1] +
                                                            ls->ny * (k / (s->wn[0] * s->wn[1])))];
        }
    } else {
        /* tiles of B0^3 copied from random source blocks (clipped at the far faces) */
        int B = getenv("GS_TILE") ? atoi(getenv("GS_TILE")) : c->block[0];
        uint64_t M = (uint64_t)gs_field_block_count(ls, B);
        for (int64_t tz = 0; tz < tn[2]; tz += B)
            for (int64_t ty = 0; ty < tn[1]; ty += B)
                for (int64_t tx = 0; tx < tn[0]; tx += B) {
                    int64_t bp[3];
                    gs_field_block_position(ls, B, (int64_t)gs_rng_below(&r, M), bp);
                    for (int64_t k = 0; k < B && tz + k < tn[2]; k++)
                        for (int64_t j = 0; j < B && ty + j < tn[1]; j++)
                            for (int64_t i = 0; i < B && tx + i < tn[0]; i++)
                                s->st.target[tx + i + tn[0] * (ty + j + tn[1] * (tz + k))] =
                                    ls->q[bp[0] + i + ls->nx * (bp[1] + j + ls->ny * (bp[2] + k))];
                }
    }
    *out = s;
    return GS_OK;
fail:
    gs_field_synth_destroy(&s);
    return err;
}

gs_err gs_field_synth_resume(const gs_qfield *src, const gs_field_synth_config *c,
                             const gs_field_synth_state *st, gs_field_synth_t *out)
{
    struct gs_field_synth *s = NULL;
    GS_CALL(synth_new(src, c, &s));
    gs_err err = GS_OK;
    GS_TRY_CHECK(err, st->iteration >= 0 && st->iteration <= c->iterations, GS_ERR_ARG, fail,
                 "checkpoint iteration %d: expected 0..%d", st->iteration, c->iterations);
    int it = st->iteration < c->iterations ? st->iteration : c->iterations - 1;
    int64_t f = (int64_t)1 << (c->iterations - 1 - it);
    for (int a = 0; a < 3; a++)
        GS_TRY_CHECK(err, st->tn[a] == c->target[a] / f, GS_ERR_ARG, fail,
                     "checkpoint target size %lld along axis %d: expected %lld for iteration %d",
                     (long long)st->tn[a], a, (long long)(c->target[a] / f), st->iteration);
    gs_field_synth_state keep = *st;
    keep.target = keep.mask = NULL;
    keep.matches = NULL;
    s->st = keep;
    GS_TRY(err, alloc_state(s, st->tn), fail);
    size_t n = (size_t)(st->tn[0] * st->tn[1] * st->tn[2]);
    memcpy(s->st.target, st->target, n);
    memcpy(s->st.mask, st->mask, n);
    GS_TRY(err, enter_iteration(s), fail);
    GS_TRY_CHECK(err, s->st.iteration >= c->iterations || (st->cursor >= 0 && st->cursor <= s->st.blocks_in_iteration),
                 GS_ERR_ARG, fail, "checkpoint cursor %lld: expected 0..%lld", (long long)st->cursor,
                 (long long)s->st.blocks_in_iteration);
    if (s->st.iteration < c->iterations) {
        /* the matches of the blocks done, in visit order (lower neighbours first) */
        int64_t M = gs_field_block_count(s->level_src, c->block[s->st.iteration]);
        for (int64_t i = 0; i < st->cursor; i++) {
            int64_t b = s->order ? s->order[i] : i;
            int64_t m = st->matches ? st->matches[b] : 0;
            GS_TRY_CHECK(err, m >= 1 && m <= M, GS_ERR_ARG, fail,
                         "checkpoint /field/matches: block %lld holds %lld, expected 1..%lld",
                         (long long)b, (long long)m, (long long)M);
            s->match_at[b] = m;
            note_match(s, b);
        }
    }
    *out = s;
    return GS_OK;
fail:
    gs_field_synth_destroy(&s);
    return err;
}

void gs_field_synth_destroy(gs_field_synth_t *sp)
{
    if (!sp || !*sp)
        return;
    struct gs_field_synth *s = *sp;
    gs_field_searcher_destroy(&s->searcher);
    gs_field_tree_destroy(&s->tree);
    gs_qfield_destroy(&s->level_src);
    gs_free(s->tie_more);
    gs_free(s->tie_less);
    gs_free(s->kv_mark);
    gs_free(s->st.target);
    gs_free(s->st.mask);
    gs_free(s->qval);
    gs_free(s->qknown);
    gs_free(s->order);
    gs_free(s->match_at);
    gs_free(s->rbox);
    gs_free(s->ex);
    gs_free(s->exmark);
    gs_free(s->exlist);
    gs_free(s->feature);
    gs_free(s->reg);
    gs_free(s->scratch);
    gs_free(s->ob_label);
    gs_free(s->ob_c);
    gs_free(s->ob_box);
    gs_free(s->ob_e);
    gs_free(s->ob_el);
    gs_free(s->ob_cnt);
    gs_free(s->ob_stamp);
    gs_free(s->ob_forbid);
    gs_free(s->ob_list);
    gs_field_cut_scratch_free(&s->cut);
    gs_free(s->cut_term);
    gs_free(s->cut_new);
    gs_free(s->cut_cost);
    GS_FREE(*sp);
}

/* Trilinear upsampling by 2 of a field of n samples (cell-centred: fine
 * sample 2i sits a quarter cell below coarse sample i, 2i+1 a quarter
 * above), so the coarse result seeds the next iteration as a smooth field,
 * not as 2^3 staircases: weights 3/4 and 1/4 per axis (edges clamped), exact
 * integer sums over 64 rounded to nearest. */
static void upsample2(const uint8_t *c, const int64_t n[3], uint8_t *f)
{
    int64_t fn[3] = {2 * n[0], 2 * n[1], 2 * n[2]};
    for (int64_t z = 0; z < fn[2]; z++) {
        int64_t z0 = z / 2, z1 = z & 1 ? (z0 + 1 < n[2] ? z0 + 1 : z0) : (z0 > 0 ? z0 - 1 : 0);
        for (int64_t y = 0; y < fn[1]; y++) {
            int64_t y0 = y / 2, y1 = y & 1 ? (y0 + 1 < n[1] ? y0 + 1 : y0) : (y0 > 0 ? y0 - 1 : 0);
            const uint8_t *r00 = c + n[0] * (y0 + n[1] * z0), *r01 = c + n[0] * (y1 + n[1] * z0);
            const uint8_t *r10 = c + n[0] * (y0 + n[1] * z1), *r11 = c + n[0] * (y1 + n[1] * z1);
            uint8_t *out = f + fn[0] * (y + fn[1] * z);
            for (int64_t x = 0; x < fn[0]; x++) {
                int64_t x0 = x / 2, x1 = x & 1 ? (x0 + 1 < n[0] ? x0 + 1 : x0) : (x0 > 0 ? x0 - 1 : 0);
                unsigned a = 3u * r00[x0] + r00[x1], b = 3u * r01[x0] + r01[x1];
                unsigned d = 3u * r10[x0] + r10[x1], e = 3u * r11[x0] + r11[x1];
                unsigned v = 3u * (3u * a + b) + (3u * d + e);
                out[x] = (uint8_t)((v + 32) / 64);
            }
        }
    }
}

/* Seam blending after the last iteration (cfg.blend = w > 0, cfg.prov
 * given). Every sample was copied from one source offset (prov); where two
 * pieces of different offsets meet, the field steps (terrain.ini: height
 * steps across the lines of the 8-sample grid were 2.4 times those elsewhere,
 * the source's 0.8-1.3: a rectangular patchwork). Texture synthesis blends
 * the overlap of neighbouring patches [Liang et al. 2001]; here each sample
 * within w of a seam becomes the mean, over the (2w+1)^3 samples around it,
 * of the source continued at it by each one's offset, held at the source's
 * face where the continuation leaves the source. Skipping such offsets (as
 * it did) left the ramp one-sided wherever a piece ended at the source's face:
 * terrain.ini, 17% of the seams across x on the seam phase, their step after
 * the blend 19 levels against 7.5 for the others (2.2 times the mean step
 * off seams); with the face held, the seam ratio (analysis/field_seams.py,
 * x and y) 1.140 -> 1.054, the example's phases 0.950-1.050. Inside a piece
 * every offset is the same and nothing changes; across
 * a seam the pieces fade into each other over 2w+1 samples. It reads only
 * prov and the source, so it is the same on every rank; levels are linear in
 * distance, so it averages distances. */
static gs_err blend_seams(struct gs_field_synth *s)
{
    int w = s->cfg.blend;
    const int32_t *prov = s->cfg.prov;
    if (w <= 0 || !prov)
        return GS_OK;
    const gs_qfield *src = s->src;
    const int64_t sn[3] = {src->nx, src->ny, src->nz};
    const int64_t *tn = s->st.tn;
    int64_t tx = tn[0], txy = tn[0] * tn[1], P = 2 * w + 1;
    /* offsets of 2w+1 planes (z mod P), packed 21 bits an axis; NONE: no provenance */
    const int64_t NONE = INT64_MIN, H = (int64_t)1 << 20;
    int64_t *po = NULL;
    uint8_t *ux = NULL; /* per plane sample: the 2w+1 around it along x share its offset */
    GS_CALL(gs_alloc_array((void **)&po, (size_t)(P * txy), sizeof *po, "seam offsets"));
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&ux, (size_t)(P * txy), 1, "seam flags"), done);
    for (int64_t z = -w; z < tn[2]; z++) {
        int64_t zn = z + w; /* plane entering the window */
        if (zn < tn[2]) {
            int64_t *pl = po + (zn % P) * txy;
            for (int64_t i = 0; i < txy; i++) {
                int64_t g = i + txy * zn, p = prov[g];
                if (p < 0) {
                    pl[i] = NONE;
                    continue;
                }
                int64_t d[3] = {p % sn[0] - i % tx, p / sn[0] % sn[1] - i / tx,
                                p / (sn[0] * sn[1]) - zn};
                for (int a = 0; a < 3; a++) /* wrapped: offsets n apart are one piece */
                    if (s->cfg.wrap >> a & 1)
                        d[a] = (d[a] % sn[a] + sn[a]) % sn[a];
                pl[i] = ((d[0] + H) << 42) | ((d[1] + H) << 21) | (d[2] + H);
            }
            uint8_t *u = ux + (zn % P) * txy;
            for (int64_t r = 0; r < tn[1]; r++) {
                const int64_t *row = pl + tx * r;
                int64_t run = 0; /* equal predecessors */
                for (int64_t x = 0; x < tx; x++) {
                    run = x > 0 && row[x] == row[x - 1] ? run + 1 : 0;
                    u[tx * r + x] = run >= (x < w ? x : w);
                }
                run = 0;
                for (int64_t x = tx - 1; x >= 0; x--) {
                    run = x + 1 < tx && row[x] == row[x + 1] ? run + 1 : 0;
                    u[tx * r + x] &= run >= (tx - 1 - x < w ? tx - 1 - x : w);
                }
            }
        }
        if (z < 0)
            continue;
        int64_t k0 = z - w > 0 ? z - w : 0, k1 = z + w < tn[2] - 1 ? z + w : tn[2] - 1;
        for (int64_t y = 0; y < tn[1]; y++) {
            int64_t j0 = y - w > 0 ? y - w : 0, j1 = y + w < tn[1] - 1 ? y + w : tn[1] - 1;
            for (int64_t x = 0; x < tx; x++) {
                int64_t h0 = x - w > 0 ? x - w : 0, h1 = x + w < tx - 1 ? x + w : tx - 1;
                /* one piece around (every row of the window uniform with this
                 * offset): unchanged, the usual case, 25 tests instead of 125 */
                int64_t me = po[(z % P) * txy + x + tx * y];
                int one = 1;
                for (int64_t k = k0; k <= k1 && one; k++)
                    for (int64_t j = j0; j <= j1 && one; j++) {
                        int64_t i = (k % P) * txy + x + tx * j;
                        one = ux[i] && po[i] == me;
                    }
                if (one)
                    continue;
                /* distinct offsets of the window and how often each occurs */
                enum { MAXD = 27 };
                int64_t d[MAXD], cnt[MAXD];
                int nd = 0;
                for (int64_t k = k0; k <= k1; k++) {
                    const int64_t *pl = po + (k % P) * txy;
                    for (int64_t j = j0; j <= j1; j++)
                        for (int64_t h = h0; h <= h1; h++) {
                            int64_t o = pl[h + tx * j];
                            if (o == NONE)
                                continue;
                            int f = 0;
                            while (f < nd && d[f] != o)
                                f++;
                            if (f == nd) {
                                if (nd == MAXD)
                                    continue; /* more pieces than that: the first 27 */
                                d[nd] = o, cnt[nd++] = 0;
                            }
                            cnt[f]++;
                        }
                }
                if (nd < 2)
                    continue; /* inside one piece: unchanged */
                uint64_t acc = 0, n = 0;
                for (int f = 0; f < nd; f++) {
                    int64_t c[3] = {x + (d[f] >> 42) - H, y + ((d[f] >> 21) & (2 * H - 1)) - H,
                                    z + (d[f] & (2 * H - 1)) - H};
                    for (int a = 0; a < 3; a++) /* held at the source's face past it, or wrapped */
                        c[a] = s->cfg.wrap >> a & 1 ? c[a] % sn[a]
                               : c[a] < 0           ? 0
                               : c[a] >= sn[a]      ? sn[a] - 1
                                                    : c[a];
                    acc += (uint64_t)cnt[f] * src->q[c[0] + sn[0] * (c[1] + sn[1] * c[2])];
                    n += (uint64_t)cnt[f];
                }
                if (n)
                    s->st.target[x + tx * y + txy * z] = (uint8_t)((acc + n / 2) / n);
            }
        }
    }
done:
    gs_free(po);
    gs_free(ux);
    return err;
}

/* Gradient-domain seam correction after the blend (cfg.seam_gradient, cfg.prov
 * given). The blend fades pieces into each other over 2 blend + 1 samples,
 * but where the two pieces disagree by more than that ramp can hide, the step
 * stays (terrain.ini seed 1: across the seams the pieces disagreed by 10-14
 * levels against a natural step of about 4; seam ratio after the blend 1.073,
 * the example's phases up to 1.050). So, as in Poisson image stitching [Perez
 * et al. 2003; Agarwala et al. 2004], the field gets the correction c that
 * minimizes, over every pair of neighbouring samples (i, j = i + e_a),
 * (c_j - c_i - r_ij)^2 + sum_i c_i^2 / B^2 (B the last block size): r_ij = 0
 * inside a piece (its steps are kept) and, across a seam (neighbours copied
 * from different source offsets), the mean of the two pieces' own steps there
 * (each piece's source continued one sample across) minus the field's step.
 * The screening term keeps the correction local (it decays over about B
 * samples), so a mismatch is spread over the pieces on both sides instead of
 * standing on the seam. Solved by conjugate gradients in double precision
 * (relative residual 1e-8, at most 1000 iterations), in one fixed order:
 * the same on every rank, as it reads only the target, prov and the source. */
static void grad_apply(const int64_t tn[3], double lambda, const double *p, double *ap)
{
    const int64_t st[3] = {1, tn[0], tn[0] * tn[1]};
    for (int64_t z = 0; z < tn[2]; z++)
        for (int64_t y = 0; y < tn[1]; y++)
            for (int64_t x = 0; x < tn[0]; x++) {
                int64_t i = x + tn[0] * (y + tn[1] * z), t[3] = {x, y, z};
                double v = lambda * p[i];
                for (int a = 0; a < 3; a++) {
                    if (t[a] > 0)
                        v += p[i] - p[i - st[a]];
                    if (t[a] + 1 < tn[a])
                        v += p[i] - p[i + st[a]];
                }
                ap[i] = v;
            }
}

static gs_err seam_gradient(struct gs_field_synth *s)
{
    const int32_t *prov = s->cfg.prov;
    if (!s->cfg.seam_gradient || !prov)
        return GS_OK;
    const gs_qfield *src = s->src;
    const int64_t sn[3] = {src->nx, src->ny, src->nz}, ss[3] = {1, sn[0], sn[0] * sn[1]};
    const int64_t *tn = s->st.tn, st[3] = {1, tn[0], tn[0] * tn[1]};
    const uint8_t *f = s->st.target;
    size_t n = (size_t)(tn[0] * tn[1] * tn[2]);
    double *c = NULL, *r = NULL, *p = NULL, *ap = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&c, n, sizeof *c, "seam correction"), done);
    GS_TRY(err, gs_alloc_array((void **)&r, n, sizeof *r, "seam correction"), done);
    GS_TRY(err, gs_alloc_array((void **)&p, n, sizeof *p, "seam correction"), done);
    GS_TRY(err, gs_alloc_array((void **)&ap, n, sizeof *ap, "seam correction"), done);
    memset(r, 0, n * sizeof *r); /* the right-hand side: sum of r_ij into j, minus into i */
    for (int64_t z = 0; z < tn[2]; z++)
        for (int64_t y = 0; y < tn[1]; y++)
            for (int64_t x = 0; x < tn[0]; x++) {
                int64_t i = x + tn[0] * (y + tn[1] * z), t[3] = {x, y, z};
                for (int a = 0; a < 3; a++) {
                    if (t[a] + 1 >= tn[a])
                        continue;
                    int64_t j = i + st[a], pi = prov[i], pj = prov[j];
                    if (pi < 0 || pj < 0)
                        continue;
                    int64_t ci = a == 0 ? pi % sn[0] : a == 1 ? pi / sn[0] % sn[1] : pi / ss[2];
                    int64_t cj = a == 0 ? pj % sn[0] : a == 1 ? pj / sn[0] % sn[1] : pj / ss[2];
                    int wa = s->cfg.wrap >> a & 1;
                    /* i's sample continued one on (wrapped: across the face), j's one back */
                    int64_t pin = ci + 1 < sn[a] ? pi + ss[a] : wa ? pi - (sn[a] - 1) * ss[a] : -1;
                    int64_t pjb = cj > 0 ? pj - ss[a] : wa ? pj + (sn[a] - 1) * ss[a] : -1;
                    if (pj == pin)
                        continue; /* inside one piece: its own step is kept */
                    double g = 0;
                    int ng = 0;
                    if (pin >= 0) /* i's piece continued to j */
                        g += (double)src->q[pin] - src->q[pi], ng++;
                    if (pjb >= 0) /* j's piece continued back to i */
                        g += (double)src->q[pj] - src->q[pjb], ng++;
                    if (!ng)
                        continue;
                    double res = g / ng - ((double)f[j] - f[i]);
                    r[j] += res, r[i] -= res;
                }
            }
    int B = s->cfg.block[s->cfg.iterations - 1];
    double lambda = 1.0 / ((double)B * B), rr = 0;
    memset(c, 0, n * sizeof *c);
    memcpy(p, r, n * sizeof *p);
    for (size_t i = 0; i < n; i++)
        rr += r[i] * r[i];
    double stop = 1e-8 * rr;
    for (int it = 0; it < 1000 && rr > stop && rr > 0; it++) {
        grad_apply(tn, lambda, p, ap);
        double pap = 0, rn = 0;
        for (size_t i = 0; i < n; i++)
            pap += p[i] * ap[i];
        double al = rr / pap;
        for (size_t i = 0; i < n; i++) {
            c[i] += al * p[i];
            r[i] -= al * ap[i];
            rn += r[i] * r[i];
        }
        double be = rn / rr;
        rr = rn;
        for (size_t i = 0; i < n; i++)
            p[i] = r[i] + be * p[i];
    }
    for (size_t i = 0; i < n; i++) {
        double v = f[i] + c[i];
        s->st.target[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : floor(v + 0.5));
    }
done:
    gs_free(c), gs_free(r), gs_free(p), gs_free(ap);
    return err;
}

/* Whole objects once the synthesis is finished (cfg.complete_objects,
 * cfg.prov given; gs_field_synth_complete_objects, called by the output
 * phase, which also measures the field before it): the geometry reconstruction the paper leaves open (5.3: "a
 * specialized geometry reconstruction operator, guided by the input geometry
 * and the synthesized distance field"), for examples made of separate
 * objects. Blocks copied from different source offsets meet inside objects:
 * a ball is glued from the pieces of two to eight source balls, and the
 * seam blend averages their distance fields (balls.ini 128^3: 8,263 inscribed
 * sphere maxima in 2.1M samples, the source 340 in 262k; radii p10/p50
 * 1.00/2.24, the source's 2.83/3.16). An object is a component of the
 * core, the samples deeper than one sample (objects that touch, as the
 * source's balls do, are apart there: balls.ini 64^3 has 10 inside
 * components but 205 cores); the source's whole objects are its cores that
 * touch none of its faces. When they hold most of the source's core (an
 * example of objects, not of a structure that runs through: fibers are
 * rebuilt as tracks of source fibers, complete_parts; a grid or a terrain is left as it
 * is), the output is rebuilt from them: each
 * core component of the synthesized field names the (source object, source
 * offset) most of its samples were copied from (provenance), and that whole
 * source object is pasted at that offset, the component with the most such
 * samples first. The source's balls touch and never overlap (no sample is
 * inside two of them), while the offsets the votes name are those of the
 * pieces, not of the balls: pasted there, 9% of touching pairs overlapped
 * (centres closer than 0.85 of their radii's sum; balls 128^3 seed 1) and 13%
 * of the balls touched none (source 2%). So an object goes to the first of
 * its offset's shifts by up to 2 samples (object_shift, nearest first) where
 * it overlaps no object pasted before and touches one, else the first where
 * it overlaps none; with none it is left out. An object's inside is the source's inside samples
 * that reach its core before any other's (breadth first), so a touching
 * neighbour's shell is not pasted with it (its slivers: balls 64^3, 41
 * inscribed-sphere maxima under 1.5 samples, without them 17). A paste is the object's inside
 * and the outside within 3 samples of its core, as a union (the lower level
 * wins: levels grow with distance); every other sample is as far outside as
 * the levels go, and the output's redistancing makes the whole a distance
 * field again. So the synthesis decides where objects lie, the source what
 * they are. Measured on balls.ini 64^3 -> 64^3 (analysis/field_objects.py,
 * summary.json): inscribed radii p10/p50/p90 1.00/2.24/3.32 -> 2.83/3.16/4.12
 * (source 2.83/3.16/4.12), their KS 0.58 -> 0.08, volume fraction 0.190 ->
 * 0.196 (0.200); with the shifts (analysis/field_contacts.py), 64^3 and
 * 128^3 seeds 1-3: no overlapping pair (before 0.069, 0.093), balls
 * touching another 0.94-0.97 (before 0.87; source 0.98), volume fraction
 * 0.186-0.214 (before 0.196, 0.224; source 0.200, its bulk at least 5
 * samples from the box's walls 0.260). It reads the target, prov and the
 * source, the same on every rank. */
typedef struct objects_scratch {
    uint8_t *mask, *touch;        /* core samples; per component: the faces it touches (bit
                                     2a: the low face of axis a, 2a + 1: the high one) */
    uint32_t *label, n;
    uint64_t *sizes;
} objects_scratch;

static void objects_free(objects_scratch *o)
{
    gs_free(o->mask);
    gs_free(o->label);
    gs_free(o->sizes);
    gs_free(o->touch);
    memset(o, 0, sizeof *o);
}

/* Components of the samples of levels q (n samples per axis, levels of
 * ref) below `below` (distance), and the components that touch a face. */
static gs_err objects_label(const gs_qfield *ref, const uint8_t *q, const int64_t n[3],
                            double below, objects_scratch *o)
{
    size_t cells = (size_t)(n[0] * n[1] * n[2]);
    uint8_t in[256];
    for (int i = 0; i < 256; i++)
        in[i] = gs_qfield_value(ref, (uint8_t)i) < below;
    if (!o->mask)
        GS_CALL(gs_alloc_array((void **)&o->mask, cells, 1, "object mask"));
    if (!o->label)
        GS_CALL(gs_alloc_array((void **)&o->label, cells, sizeof *o->label, "object labels"));
    for (size_t i = 0; i < cells; i++)
        o->mask[i] = in[q[i]];
    gs_free(o->sizes);
    gs_free(o->touch);
    o->sizes = NULL, o->touch = NULL;
    GS_CALL(gs_measure_components3(o->mask, (int)n[0], (int)n[1], (int)n[2], NULL, o->label,
                                   &o->n, &o->sizes));
    GS_CALL(gs_alloc_array((void **)&o->touch, (size_t)o->n + 1, 1, "object faces"));
    memset(o->touch, 0, (size_t)o->n + 1);
    for (int64_t z = 0; z < n[2]; z++)
        for (int64_t y = 0; y < n[1]; y++) {
            int face = z == 0 || z == n[2] - 1 || y == 0 || y == n[1] - 1;
            for (int64_t x = 0; x < n[0]; x += face || x == n[0] - 1 ? 1 : n[0] - 1)
                o->touch[o->label[x + n[0] * (y + n[1] * z)]] |=
                    (uint8_t)((x == 0) | (x == n[0] - 1) << 1 | (y == 0) << 2 |
                              (y == n[1] - 1) << 3 | (z == 0) << 4 | (z == n[2] - 1) << 5);
        }
    return GS_OK;
}

/* One vote: a core sample of target component comp copied from source
 * object obj at offset off (packed 21 bits an axis). */
typedef struct object_vote {
    uint32_t comp, obj;
    int64_t off;
} object_vote;

static int cmp_vote(const void *a_, const void *b_)
{
    const object_vote *a = a_, *b = b_;
    if (a->comp != b->comp)
        return a->comp < b->comp ? -1 : 1;
    if (a->obj != b->obj)
        return a->obj < b->obj ? -1 : 1;
    return a->off < b->off ? -1 : a->off > b->off;
}

/* A paste: target component comp's most voted source object and offset. */
typedef struct object_paste {
    int64_t votes;
    uint32_t comp, obj;
    int64_t off;
} object_paste;

/* Most votes first, then the target component. */
static int cmp_paste(const void *a_, const void *b_)
{
    const object_paste *a = a_, *b = b_;
    if (a->votes != b->votes)
        return a->votes > b->votes ? -1 : 1;
    return a->comp < b->comp ? -1 : a->comp > b->comp;
}

/* Same object and offset together, most votes first, then the component. */
static int cmp_place(const void *a_, const void *b_)
{
    const object_paste *a = a_, *b = b_;
    if (a->obj != b->obj)
        return a->obj < b->obj ? -1 : 1;
    if (a->off != b->off)
        return a->off < b->off ? -1 : 1;
    return cmp_paste(a_, b_);
}

int64_t gs_field_near3(const int64_t sn[3], const int64_t *seeds, int64_t ns, int axis,
                       int64_t lo, int64_t hi, uint32_t *stamp, uint32_t mark,
                       int (*keep)(int64_t r, const void *u), const void *u, int64_t *out,
                       int64_t m)
{
    for (int64_t i = 0; i < ns; i++) {
        int64_t v[3];
        gs_field_coords(seeds[i], sn, v);
        for (int64_t dz = -3; dz <= 3; dz++)
            for (int64_t dy = -3; dy <= 3; dy++)
                for (int64_t dx = -3; dx <= 3; dx++) {
                    if (dx * dx + dy * dy + dz * dz > 9)
                        continue;
                    int64_t w[3] = {v[0] + dx, v[1] + dy, v[2] + dz};
                    if (w[0] < 0 || w[0] >= sn[0] || w[1] < 0 || w[1] >= sn[1] || w[2] < 0 ||
                        w[2] >= sn[2] || (axis >= 0 && (w[axis] < lo || w[axis] >= hi)))
                        continue;
                    int64_t r = w[0] + sn[0] * (w[1] + sn[1] * w[2]);
                    if (stamp[r] == mark || !keep(r, u))
                        continue;
                    stamp[r] = mark;
                    out[m++] = r;
                }
    }
    return m;
}

typedef struct footprint_keep {
    const gs_qfield *src;
    const uint32_t *owner;
    uint32_t obj;
} footprint_keep;

/* Not another object's inside (a touching one's shell). */
static int footprint_keeps(int64_t r, const void *u_)
{
    const footprint_keep *u = u_;
    return u->owner[r] == u->obj || gs_qfield_value(u->src, u->src->q[r]) >= 0;
}

/* The footprint of source object obj: the samples within 3 of its core
 * (cores[first[obj] .. first[obj + 1])) that are outside or inside it
 * (owner), not a touching object's inside, each once (stamp marks them with
 * mark) into fp; returns their count. */
static int64_t object_footprint(const gs_qfield *src, const uint32_t *owner, uint32_t obj,
                                const int64_t *cores, const int64_t *first, uint32_t *stamp,
                                uint32_t mark, int64_t *fp)
{
    const int64_t sn[3] = {src->nx, src->ny, src->nz};
    const footprint_keep u = {src, owner, obj};
    return gs_field_near3(sn, cores + first[obj], first[obj + 1] - first[obj], -1, 0, 0, stamp,
                          mark, footprint_keeps, &u, fp, 0);
}

/* Object footprint fp (n samples) at offset o against the objects already
 * in out: *overlap = some inside sample of it lands on an inside sample of
 * out, *touch = some inside sample of it has a 6-neighbour inside out. */
static void object_probe(const gs_qfield *src, const int64_t *tn, const int64_t *fp, int64_t n,
                         const int64_t o[3], const uint8_t *out, const uint8_t *inside,
                         int *overlap, int *touch)
{
    const int64_t sn[3] = {src->nx, src->ny, src->nz}, st[3] = {1, tn[0], tn[0] * tn[1]};
    *overlap = *touch = 0;
    for (int64_t i = 0; i < n; i++) {
        int64_t t[3], ti;
        if (!inside[src->q[fp[i]]] || (ti = gs_field_offset_target(sn, tn, fp[i], o, t)) < 0)
            continue;
        if (inside[out[ti]]) {
            *overlap = 1;
            return;
        }
        for (int d = 0; d < 6 && !*touch; d++) {
            int64_t k = t[d / 2] + (d % 2 ? 1 : -1);
            if (k >= 0 && k < tn[d / 2])
                *touch = inside[out[ti + (d % 2 ? 1 : -1) * st[d / 2]]];
        }
    }
}

/* Pastes footprint fp (n samples of the source) at offset o into levels
 * out (prov updated), as a union (the lower level wins). */
static void paste_footprint(struct gs_field_synth *s, const int64_t *fp, int64_t n,
                            const int64_t o[3], uint8_t *out)
{
    const gs_qfield *src = s->src;
    const int64_t sn[3] = {src->nx, src->ny, src->nz}, *tn = s->st.tn;
    for (int64_t i = 0; i < n; i++) {
        int64_t t[3], ti = gs_field_offset_target(sn, tn, fp[i], o, t);
        if (ti >= 0 && src->q[fp[i]] < out[ti]) {
            out[ti] = src->q[fp[i]];
            s->cfg.prov[ti] = (int32_t)fp[i];
        }
    }
}

/* Where an object is pasted: its voted offset moved by the first of these
 * shifts (nearest first) at which it overlaps no object pasted before (no
 * sample inside both: the source's objects touch, they never overlap) and
 * touches one (an inside sample next to one of theirs), else the first at
 * which it overlaps none; else it is left out. */
#define OBJECT_SHIFTS 33
static const int8_t object_shift[OBJECT_SHIFTS][3] = {
    {0, 0, 0},    {-1, 0, 0},  {1, 0, 0},   {0, -1, 0},  {0, 1, 0},   {0, 0, -1}, {0, 0, 1},
    {-1, -1, 0},  {1, -1, 0},  {-1, 1, 0},  {1, 1, 0},   {-1, 0, -1}, {1, 0, -1}, {-1, 0, 1},
    {1, 0, 1},    {0, -1, -1}, {0, 1, -1},  {0, -1, 1},  {0, 1, 1},   {-1, -1, -1},
    {1, -1, -1},  {-1, 1, -1}, {1, 1, -1},  {-1, -1, 1}, {1, -1, 1},  {-1, 1, 1}, {1, 1, 1},
    {-2, 0, 0},   {2, 0, 0},   {0, -2, 0},  {0, 2, 0},   {0, 0, -2},  {0, 0, 2}};

/* Pastes source object obj near offset o (object_shift) into out; returns
 * whether it pasted. */
static int paste_object(struct gs_field_synth *s, const int64_t *fp, int64_t n,
                        const int64_t o[3], const uint8_t *inside, uint8_t *out)
{
    int chosen = -1;
    for (int k = 0; k < OBJECT_SHIFTS; k++) {
        int64_t p[3] = {o[0] + object_shift[k][0], o[1] + object_shift[k][1],
                        o[2] + object_shift[k][2]};
        int overlap, touch;
        object_probe(s->src, s->st.tn, fp, n, p, out, inside, &overlap, &touch);
        if (overlap)
            continue;
        if (chosen < 0)
            chosen = k;
        if (touch) {
            chosen = k;
            break;
        }
    }
    if (chosen < 0)
        return 0;
    int64_t p[3] = {o[0] + object_shift[chosen][0], o[1] + object_shift[chosen][1],
                    o[2] + object_shift[chosen][2]};
    paste_footprint(s, fp, n, p, out);
    return 1;
}

/* Long objects (fibers): rebuilt whole from the source's fibers, chained
 * slab by slab along the axis (src/field/fibers.c). The slabs are half the
 * last block thick. */
static gs_err complete_parts(struct gs_field_synth *s, int axis, int *rebuilt)
{
    GS_CALL(gs_field_fibers_rebuild(s->src, s->st.tn, s->st.target, s->cfg.prov, axis,
                                    s->cfg.block[s->cfg.iterations - 1] / 2,
                                    &s->st.objects_completed, &s->st.objects_removed));
    *rebuilt = 1;
    return GS_OK;
}

static gs_err complete_objects(struct gs_field_synth *s, int *rebuilt)
{
    *rebuilt = 0;
    if (!s->cfg.complete_objects || !s->cfg.prov)
        return GS_OK;
    const gs_qfield *src = s->src;
    const int64_t sn[3] = {src->nx, src->ny, src->nz}, *tn = s->st.tn;
    const int64_t nt = tn[0] * tn[1] * tn[2], ns = sn[0] * sn[1] * sn[2];
    const double core = src->spacing;
    const int32_t *prov = s->cfg.prov;
    objects_scratch so = {0}, to = {0};
    int64_t *first = NULL, *cores = NULL, *queue = NULL;
    uint32_t *owner = NULL;
    object_vote *votes = NULL;
    object_paste *paste = NULL;
    uint8_t *out = NULL;
    gs_err err = GS_OK;
    /* long objects first: most of the source's inside in components reaching
     * both faces of one axis (fibers 0.87-0.92 along x; balls 0, chain mail
     * 0.12): a thin fiber's core (below) breaks up into pieces that would
     * pass for separate objects */
    GS_TRY(err, objects_label(src, src->q, sn, 0, &so), done);
    uint64_t run[3] = {0, 0, 0}, whole = 0, all = 0;
    for (uint32_t c = 1; c <= so.n; c++) {
        all += so.sizes[c - 1];
        for (int a = 0; a < 3; a++)
            run[a] += (so.touch[c] >> (2 * a) & 3) == 3 ? so.sizes[c - 1] : 0;
    }
    int axis = run[1] > run[0] ? 1 : 0;
    axis = run[2] > run[axis] ? 2 : axis;
    if (2 * run[axis] > all) {
        GS_TRY(err, complete_parts(s, axis, rebuilt), done);
        goto done;
    }
    GS_TRY(err, objects_label(src, src->q, sn, -core, &so), done);
    all = 0;
    for (uint32_t c = 1; c <= so.n; c++) {
        all += so.sizes[c - 1];
        whole += so.touch[c] ? 0 : so.sizes[c - 1];
    }
    if (2 * whole <= all)
        goto done; /* neither separate nor long objects (a grid, a terrain) */
    /* the source objects' core samples, grouped: cores[first[c] .. first[c + 1]) */
    GS_TRY(err, gs_alloc_array((void **)&first, (size_t)so.n + 2, sizeof *first, "objects"), done);
    memset(first, 0, ((size_t)so.n + 2) * sizeof *first);
    for (int64_t i = 0; i < ns; i++)
        first[so.label[i] + 1] += so.label[i] != 0;
    for (uint32_t c = 1; c <= so.n + 1; c++)
        first[c] += first[c - 1];
    GS_TRY(err, gs_alloc_array((void **)&cores, (size_t)(first[so.n + 1] ? first[so.n + 1] : 1),
                               sizeof *cores, "object samples"), done);
    for (int64_t i = 0; i < ns; i++)
        if (so.label[i])
            cores[first[so.label[i]]++] = i;
    for (uint32_t c = so.n; c >= 1; c--) /* the cursors ran one object ahead */
        first[c] = first[c - 1];
    first[0] = first[1] = 0;
    /* each inside sample of the source belongs to the object whose core it
     * reaches first (breadth first through the inside, cores in index order) */
    GS_TRY(err, gs_alloc_array((void **)&owner, (size_t)ns, sizeof *owner, "object owners"), done);
    GS_TRY(err, gs_alloc_array((void **)&queue, (size_t)ns, sizeof *queue, "object queue"), done);
    int64_t head = 0, tail = 0;
    for (int64_t i = 0; i < ns; i++) {
        owner[i] = so.label[i];
        if (so.label[i])
            queue[tail++] = i;
    }
    while (head < tail) {
        int64_t v[3], i = queue[head++];
        gs_field_coords(i, sn, v);
        for (int d = 0; d < 6; d++) {
            int64_t w[3] = {v[0], v[1], v[2]};
            w[d / 2] += d % 2 ? 1 : -1;
            if (w[d / 2] < 0 || w[d / 2] >= sn[d / 2])
                continue;
            int64_t r = w[0] + sn[0] * (w[1] + sn[1] * w[2]);
            if (!owner[r] && gs_qfield_value(src, src->q[r]) < 0)
                owner[r] = owner[i], queue[tail++] = r;
        }
    }
    /* the votes of the synthesized cores */
    GS_TRY(err, objects_label(src, s->st.target, tn, -core, &to), done);
    int64_t nv = 0;
    for (int64_t i = 0; i < nt; i++)
        nv += to.label[i] && prov[i] >= 0 && so.label[prov[i]] && !so.touch[so.label[prov[i]]];
    GS_TRY(err, gs_alloc_array((void **)&votes, (size_t)(nv ? nv : 1), sizeof *votes, "votes"),
           done);
    nv = 0;
    for (int64_t i = 0; i < nt; i++) {
        if (!to.label[i] || prov[i] < 0 || !so.label[prov[i]] || so.touch[so.label[prov[i]]])
            continue;
        int64_t t[3], p[3], o[3];
        gs_field_coords(i, tn, t), gs_field_coords(prov[i], sn, p);
        for (int d = 0; d < 3; d++)
            o[d] = p[d] - t[d];
        votes[nv++] = (object_vote){to.label[i], so.label[prov[i]], gs_field_pack_offset(o)};
    }
    qsort(votes, (size_t)nv, sizeof *votes, cmp_vote);
    /* per target component its most voted (object, offset), the first in
     * cmp_vote's order among equals */
    GS_TRY(err, gs_alloc_array((void **)&paste, (size_t)to.n + 1, sizeof *paste, "pastes"), done);
    int64_t np = 0;
    for (int64_t i = 0; i < nv;) {
        int64_t j = i;
        object_paste best = {0, votes[i].comp, 0, 0};
        while (j < nv && votes[j].comp == votes[i].comp) {
            int64_t k = j;
            while (k < nv && votes[k].comp == votes[j].comp && votes[k].obj == votes[j].obj &&
                   votes[k].off == votes[j].off)
                k++;
            if (k - j > best.votes)
                best.votes = k - j, best.obj = votes[j].obj, best.off = votes[j].off;
            j = k;
        }
        paste[np++] = best;
        i = j;
    }
    /* the same object at the same place named by several components: once,
     * with the most votes */
    qsort(paste, (size_t)np, sizeof *paste, cmp_place);
    int64_t nu = 0;
    for (int64_t i = 0; i < np; i++)
        if (!nu || paste[nu - 1].obj != paste[i].obj || paste[nu - 1].off != paste[i].off)
            paste[nu++] = paste[i];
    qsort(paste, (size_t)nu, sizeof *paste, cmp_paste);
    GS_TRY(err, gs_alloc_array((void **)&out, (size_t)nt, 1, "rebuilt objects"), done);
    memset(out, 255, (size_t)nt);
    /* the footprint lists and their marks reuse the BFS queue and the source labels */
    int64_t *fp = queue;
    uint32_t *stamp = so.label;
    memset(stamp, 0, (size_t)ns * sizeof *stamp);
    uint8_t inside[256];
    for (int l = 0; l < 256; l++)
        inside[l] = gs_qfield_value(src, (uint8_t)l) < 0;
    for (int64_t i = 0; i < nu; i++) {
        int64_t o[3];
        gs_field_unpack_offset(paste[i].off, o);
        int64_t n = object_footprint(src, owner, paste[i].obj, cores, first, stamp,
                                     (uint32_t)i + 1, fp);
        if (paste_object(s, fp, n, o, inside, out))
            s->st.objects_completed++;
        else
            s->st.objects_removed++;
    }
    s->st.objects_removed += (int64_t)to.n - nu; /* components with no whole object to name */
    memcpy(s->st.target, out, (size_t)nt);
    *rebuilt = 1;
done:
    objects_free(&so);
    objects_free(&to);
    gs_free(first);
    gs_free(cores);
    gs_free(votes);
    gs_free(paste);
    gs_free(owner);
    gs_free(queue);
    gs_free(out);
    return err;
}

gs_err gs_field_synth_complete_objects(gs_field_synth_t s, gs_qfield **before)
{
    *before = NULL;
    GS_CHECK(s->st.iteration >= s->cfg.iterations, GS_ERR_ARG,
             "whole objects: the synthesis is not finished (iteration %d of %d)",
             s->st.iteration, s->cfg.iterations);
    GS_CHECK(s->st.target, GS_ERR_ARG, "whole objects: the result was already taken");
    if (s->objects_done || !s->cfg.complete_objects || !s->cfg.prov)
        return GS_OK;
    gs_qfield *b = NULL;
    GS_CALL(gs_field_synth_result(s, &b));
    int rebuilt = 0;
    gs_err err = complete_objects(s, &rebuilt);
    s->objects_done = 1;
    if (err != GS_OK || !rebuilt)
        gs_qfield_destroy(&b);
    GS_CALL(err);
    *before = b;
    return GS_OK;
}

typedef struct {
    double h;
    int64_t i;
} ranked_height;

static int cmp_ranked(const void *a_, const void *b_)
{
    const ranked_height *a = a_, *b = b_;
    if (a->h != b->h)
        return (a->h > b->h) - (a->h < b->h);
    return (a->i > b->i) - (a->i < b->i);
}

/* cfg.height_match (height-field examples): a result gets the level
 * source's height distribution, the coarse one (bit 1) before it is
 * upsampled to guide the next iteration, the last one (bit 2) after the
 * blend and the seam correction, once the synthesis is finished
 * (gs_field_synth_height_match, run by the output phase: the field before
 * it is what the copy measures read, field39). The column of rank r (heights ascending,
 * ties by position) among the N of the target takes the level source's
 * height at quantile (r + 1/2) / N (linear between its sorted column
 * heights), and the whole column moves along z by the difference (levels
 * linear in z between samples, continued linearly past the ends, clamped to
 * 0..255), so the surface keeps its shape and lies at the new height: a
 * monotone map of the heights (histogram matching), the layout of hills and
 * valleys unchanged. #19: the exclusions that keep the output from repeating
 * (repeat_span) forbid the example's one summit within 64 samples of its
 * last copy, and few blocks cover the example's border (its flat sea floor):
 * terrain.ini's outputs held the example's highest ground (at or above its
 * 95th percentile) 0.56 times as often as the example and its floor (at or
 * below its 10th) 0.19 times, KS 0.141 (seeds 1-12). Matching the coarse
 * result alone moved that little (0.032, 0.021, KS 0.132: the finer blocks
 * cannot follow guidance the exclusions leave no pieces for); the last
 * result's: 0.050, 0.096, KS 0.023. A function of the target and the source
 * alone: the same on every rank and across resume. */
static gs_err height_match(struct gs_field_synth *s, uint8_t *t, const int64_t tn[3], int last)
{
    if (!(s->cfg.height_match & (last ? 2 : 1)))
        return GS_OK;
    /* the level source's own columns (not the wrap's); once the synthesis
     * is finished (the last step) the source itself */
    const gs_qfield *ls = last ? s->src : s->level_src;
    const int64_t wn[2] = {last ? ls->nx : s->wn[0], last ? ls->ny : s->wn[1]};
    int64_t M = wn[0] * wn[1], N = tn[0] * tn[1], nz = tn[2], L = ls->nx * ls->ny;
    GS_CHECK(ls->nz == nz, GS_ERR_ARG, "field.height_match: the level source's depth %lld "
             "differs from the target's %lld (expected a height-field example and target as deep)",
             (long long)ls->nz, (long long)nz);
    gs_qfield tv = *ls; /* the target's levels, on the source's scale */
    tv.nx = tn[0], tv.ny = tn[1], tv.nz = nz, tv.q = t;
    gs_field *fs = NULL, *ft = NULL;
    double *hl = NULL, *hs = NULL, *ht = NULL, *col = NULL;
    ranked_height *r = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_qfield_dequantize(ls, &fs), done);
    GS_TRY(err, gs_qfield_dequantize(&tv, &ft), done);
    GS_TRY(err, gs_alloc_array((void **)&hl, (size_t)L, sizeof *hl, "height match"), done);
    GS_TRY(err, gs_alloc_array((void **)&hs, (size_t)M, sizeof *hs, "height match"), done);
    GS_TRY(err, gs_alloc_array((void **)&ht, (size_t)N, sizeof *ht, "height match"), done);
    GS_TRY(err, gs_alloc_array((void **)&r, (size_t)N, sizeof *r, "height match"), done);
    GS_TRY(err, gs_alloc_array((void **)&col, (size_t)nz, sizeof *col, "height match"), done);
    gs_field_surface_heights(fs, hl); /* the level source's own columns (not the wrap's) */
    for (int64_t y = 0; y < wn[1]; y++)
        for (int64_t x = 0; x < wn[0]; x++)
            hs[x + wn[0] * y] = hl[x + ls->nx * y];
    gs_sort_f64(hs, (size_t)M);
    gs_field_surface_heights(ft, ht);
    for (int64_t i = 0; i < N; i++)
        r[i].h = ht[i], r[i].i = i;
    qsort(r, (size_t)N, sizeof *r, cmp_ranked);
    for (int64_t k = 0; k < N; k++) {
        double pos = ((double)k + 0.5) / (double)N * (double)M - 0.5;
        pos = pos < 0 ? 0 : pos > (double)(M - 1) ? (double)(M - 1) : pos;
        int64_t lo = (int64_t)floor(pos);
        double want = lo + 1 < M ? hs[lo] + (pos - (double)lo) * (hs[lo + 1] - hs[lo]) : hs[M - 1];
        double dh = want - r[k].h;
        uint8_t *c = t + r[k].i;
        for (int64_t z = 0; z < nz; z++)
            col[z] = c[N * z];
        for (int64_t z = 0; z < nz; z++) {
            double zz = (double)z - dh, v;
            int64_t a = (int64_t)floor(zz);
            a = a < 0 ? 0 : a > nz - 2 ? nz - 2 : a;
            v = col[a] + (zz - (double)a) * (col[a + 1] - col[a]);
            v = v < 0 ? 0 : v > 255 ? 255 : v;
            c[N * z] = (uint8_t)floor(v + 0.5);
        }
    }
done:
    gs_field_destroy(&fs);
    gs_field_destroy(&ft);
    gs_free(hl);
    gs_free(hs);
    gs_free(ht);
    gs_free(r);
    gs_free(col);
    return err;
}

gs_err gs_field_synth_height_match(gs_field_synth_t s, gs_qfield **before)
{
    *before = NULL;
    GS_CHECK(s->st.iteration >= s->cfg.iterations, GS_ERR_ARG,
             "height match: the synthesis is not finished (iteration %d of %d)", s->st.iteration,
             s->cfg.iterations);
    GS_CHECK(s->st.target, GS_ERR_ARG, "height match: the result was already taken");
    if (s->heights_done || !(s->cfg.height_match & 2))
        return GS_OK;
    gs_qfield *b = NULL;
    GS_CALL(gs_field_synth_result(s, &b));
    gs_err err = height_match(s, s->st.target, s->st.tn, 1);
    s->heights_done = 1;
    if (err != GS_OK)
        gs_qfield_destroy(&b);
    GS_CALL(err);
    *before = b;
    return GS_OK;
}

/* Next iteration: upsample the result by 2 as the new seed. */
static gs_err advance_iteration(struct gs_field_synth *s)
{
    int next = s->st.iteration + 1;
    if (next >= s->cfg.iterations) {
        GS_CALL(blend_seams(s));
        GS_CALL(seam_gradient(s));
        /* the last result's height match: gs_field_synth_height_match */
        s->st.iteration = next;
        s->st.cursor = 0;
        return enter_iteration(s);
    }
    int64_t old[3];
    memcpy(old, s->st.tn, sizeof old);
    uint8_t *prev = s->st.target;
    GS_CALL(height_match(s, prev, old, 0));
    s->st.target = NULL;
    int64_t tn[3] = {old[0] * 2, old[1] * 2, old[2] * 2};
    gs_err err = alloc_state(s, tn);
    if (err != GS_OK) {
        gs_free(prev);
        GS_CALL(err);
    }
    upsample2(prev, old, s->st.target);
    gs_free(prev);
    s->st.iteration = next;
    s->st.cursor = 0;
    GS_CALL(enter_iteration(s));
    return GS_OK;
}

static void block_pos(const struct gs_field_synth *s, int64_t cursor, int64_t p[3])
{
    int64_t b = s->order ? s->order[cursor] : cursor;
    p[0] = s->pos[0][b % s->npos[0]];
    p[1] = s->pos[1][b / s->npos[0] % s->npos[1]];
    p[2] = s->pos[2][b / (s->npos[0] * s->npos[1])];
}

/* Matches the block at target position p on view v (the hook: serial path
 * only). */
/* Upper bound for the queue pruning (iterations >= 1, whole tree): the exact
 * distance of the continuation of the x-neighbour's match (its source block
 * moved by the same step), 0 when there is none. The overlap the query
 * shares with that neighbour was mostly copied from it, so the continuation
 * is usually close to the best match. */
/* ------------------------------------------------------------ copy limit
 *
 * The exact best match of a block whose overlap was copied from one source
 * offset is almost always that offset continued (the overlap then costs 0),
 * so a synthesis left alone copies large pieces of the source verbatim: the
 * copy measure (src/measure/copy.c) found terrain.ini's largest copied
 * region at 0.27 of the source and texture.ini's at 0.55 (discs cut into
 * crescents where such pieces meet). The paper does nothing against it
 * beyond its random seeds. With copy_limit, every copy (block positions
 * joined through lower neighbours that took the same offset) keeps the
 * bounding box of its samples; a block whose taking the offset of a lower
 * neighbour would grow that box (plus B/2 along every axis, see below) past
 * copy_limit times the source's samples
 * may not take it, nor the offsets within block/4 positions of it (else the
 * copy goes on shifted by a sample; copy_limit_reach sets another reach):
 * those source blocks are excluded from
 * the search (gs_field_search_opts.exclude), which stays exact for that
 * cost. Lower neighbours (b - d, d in {0,1}^3) are matched before b in the
 * raster order and in every region order (see build_regions), so the
 * result is the same for every rank count; the matches are checkpointed.
 * The reach: block/4 keeps a shifted continuation from carrying a copy on
 * (fibers.ini 32^3 -> 64^3 with a reach of 1: a region whose neighbouring
 * samples' offsets differ by at most 2 covers 0.80 of the source, 0.13 with
 * block/4; the fibers go on along x shifted by 2 samples). On a height field
 * it also excludes the good matches next to the continuation, so the next
 * piece is taken where it disagrees with the old one (terrain.ini seed 1,
 * before the random first block made seeds differ: seam ratio over x and y
 * 1.054 with block/4, 1.003 with a reach of 1; the region of offsets within
 * 2 covers 0.36 and 0.38 of the source. Over seeds 1-6 since: mean 1.039
 * with block/4, 1.030 with 1, see configs/field/terrain.ini). */

static void block_coords(const struct gs_field_synth *s, int64_t b, int64_t c[3])
{
    c[0] = b % s->npos[0];
    c[1] = b / s->npos[0] % s->npos[1];
    c[2] = b / (s->npos[0] * s->npos[1]);
}

/* Source offset (source block position - target position) of matched block b. */
static void block_offset(const struct gs_field_synth *s, int64_t b, int B, int64_t o[3])
{
    int64_t c[3], sp[3];
    block_coords(s, b, c);
    gs_field_block_position(s->level_src, B, s->match_at[b] - 1, sp);
    for (int a = 0; a < 3; a++) {
        o[a] = sp[a] - s->pos[a][c[a]];
        if (s->cfg.wrap >> a & 1) /* offsets a period apart copy the same */
            o[a] = (o[a] % s->wn[a] + s->wn[a]) % s->wn[a];
    }
}

/* Appends to ex the source block positions within r of centre (each axis);
 * along a wrapped axis the positions are taken modulo the source's size
 * (up to 2 boxes an axis), else clipped to the source. */
static void exclusion_box(const struct gs_field_synth *s, int B, const int64_t centre[3],
                          int64_t r, int64_t ex[][6], int *ne)
{
    const gs_qfield *ls = s->level_src;
    const int64_t sn[3] = {ls->nx, ls->ny, ls->nz};
    int64_t lo[3][2], hi[3][2];
    int np[3];
    for (int a = 0; a < 3; a++) {
        int64_t top = sn[a] - B; /* the last block position */
        if (!(s->cfg.wrap >> a & 1) || 2 * r + 1 >= s->wn[a]) {
            int64_t c = centre[a];
            if (s->cfg.wrap >> a & 1) /* the box covers every position */
                lo[a][0] = 0, hi[a][0] = top;
            else
                lo[a][0] = c - r > 0 ? c - r : 0, hi[a][0] = c + r < top ? c + r : top;
            np[a] = 1;
            continue;
        }
        int64_t n = s->wn[a], c = (centre[a] % n + n) % n; /* top = n - 1 */
        lo[a][0] = c - r, hi[a][0] = c + r, np[a] = 1;
        if (lo[a][0] < 0)
            lo[a][1] = lo[a][0] + n, hi[a][1] = n - 1, lo[a][0] = 0, np[a] = 2;
        else if (hi[a][0] > top)
            lo[a][1] = 0, hi[a][1] = hi[a][0] - n, hi[a][0] = top, np[a] = 2;
    }
    for (int k = 0; k < np[2]; k++)
        for (int j = 0; j < np[1]; j++)
            for (int i = 0; i < np[0]; i++) {
                const int w[3] = {i, j, k};
                for (int a = 0; a < 3; a++)
                    ex[*ne][a] = lo[a][w[a]], ex[*ne][a + 3] = hi[a][w[a]];
                (*ne)++;
            }
}

/* Matched lower neighbours of b (b - d, d in {0,1}^3 \ 0). */
static int lower_neighbours(const struct gs_field_synth *s, int64_t b, int64_t nb[7])
{
    int64_t c[3], n = 0;
    block_coords(s, b, c);
    for (int d = 1; d < 8; d++) {
        int64_t x = c[0] - (d & 1), y = c[1] - (d >> 1 & 1), z = c[2] - (d >> 2);
        if (x < 0 || y < 0 || z < 0)
            continue;
        int64_t i = x + s->npos[0] * (y + s->npos[1] * z);
        if (s->match_at[i])
            nb[n++] = i;
    }
    return (int)n;
}

/* Bounding box (samples) of the copy block b joins when it takes offset o:
 * its own box and those of its lower neighbours copied with offset o. */
static void copy_box(const struct gs_field_synth *s, int64_t b, int B, const int64_t o[3],
                     int64_t box[6])
{
    int64_t c[3], nb[7];
    block_coords(s, b, c);
    for (int a = 0; a < 3; a++)
        box[a] = s->pos[a][c[a]], box[a + 3] = s->pos[a][c[a]] + B;
    int n = lower_neighbours(s, b, nb);
    for (int i = 0; i < n; i++) {
        int64_t on[3];
        block_offset(s, nb[i], B, on);
        if (on[0] != o[0] || on[1] != o[1] || on[2] != o[2])
            continue;
        for (int a = 0; a < 3; a++) {
            if (s->rbox[nb[i]][a] < box[a])
                box[a] = s->rbox[nb[i]][a];
            if (s->rbox[nb[i]][a + 3] > box[a + 3])
                box[a + 3] = s->rbox[nb[i]][a + 3];
        }
    }
}

/* Records the copy box of block b, just matched (match_at[b] set). */
static void note_match(struct gs_field_synth *s, int64_t b)
{
    int B = s->cfg.block[s->st.iteration];
    int64_t o[3], box[6];
    block_offset(s, b, B, o);
    copy_box(s, b, B, o, box);
    for (int i = 0; i < 6; i++)
        s->rbox[b][i] = (int32_t)box[i];
}

/* Source block boxes block b may not take (at most 14): the continuations
 * (+- B/4 positions) of lower neighbours' offsets whose copy would outgrow
 * copy_limit, and (repeat_reach, last iteration) the source blocks within
 * repeat_reach positions of a lower neighbour's own. The latter: a block of
 * little relief along an axis matches its own copy shifted by a block stride,
 * which is not a continuation (a new offset each time, so copy_limit does not
 * see it): terrain.ini seed 5 copied the example's flat summit, source block
 * (22, 31-32), into each of 4 blocks down a column, a straight flat strip 60
 * samples long with straight cliffs along its sides (planes across x at 2.2
 * times their axis' mean, the example's steepest 1.88). The reach stays below
 * B/2, so a neighbour's continuation (its block moved by the stride) is never
 * excluded by it. Excluded in the coarse iterations too, the flat plains
 * along the example's border could not repeat either and the volume fraction
 * rose (reach 2: 0.441-0.480 over seeds 1-6, the example's 0.416). */
static int repeat_span_exclusions(struct gs_field_synth *s, int64_t b, int B, int64_t (*ex)[6], int ne);
static int covers_all(const struct gs_field_synth *s, const int64_t (*ex)[6], int ne, int B);

static int copy_exclusions(struct gs_field_synth *s, int64_t b, int B, int64_t (*ex)[6])
{
    if (s->cfg.copy_limit <= 0 && s->cfg.repeat_reach <= 0 && s->cfg.repeat_pairs <= 0)
        return 0;
    const gs_qfield *ls = s->level_src;
    double limit = s->cfg.copy_limit * (double)(s->wn[0] * s->wn[1] * s->wn[2]);
    int64_t c[3], nb[7], seen[7][3];
    block_coords(s, b, c);
    int n = lower_neighbours(s, b, nb), ne = 0, ns = 0;
    int64_t r = s->cfg.copy_limit_reach > 0 ? s->cfg.copy_limit_reach : B / 4 > 0 ? B / 4 : 1;
    for (int i = 0; i < n; i++) {
        int64_t o[3];
        block_offset(s, nb[i], B, o);
        int dup = 0;
        for (int j = 0; j < ns && !dup; j++)
            dup = seen[j][0] == o[0] && seen[j][1] == o[1] && seen[j][2] == o[2];
        if (dup)
            continue;
        memcpy(seen[ns++], o, sizeof o);
        int64_t box[6];
        copy_box(s, b, B, o, box);
        /* a block's anti-diagonal neighbours (one position up along an axis,
         * down along another) may take the same offset unseen: neither is a
         * lower neighbour of the other (in the region order one of them may
         * not be matched yet), so each grows the copy by up to B/2 along an
         * axis without the other knowing (balls.ini 32^3: copies of 0.37 of
         * the source under a limit of 0.25). Counting B/2 more along every
         * axis keeps the copies within the limit. */
        for (int a = 0; a < 3; a++)
            box[a + 3] = box[a + 3] + B / 2 < s->st.tn[a] ? box[a + 3] + B / 2 : s->st.tn[a];
        double vol = (double)(box[3] - box[0]) * (double)(box[4] - box[1]) * (double)(box[5] - box[2]);
        if (s->cfg.copy_limit <= 0 || vol <= limit)
            continue;
        int64_t cont[3];
        for (int a = 0; a < 3; a++)
            cont[a] = s->pos[a][c[a]] + o[a];
        exclusion_box(s, B, cont, r, ex, &ne);
    }
    /* repeat_reach (last iteration): nor the source blocks within repeat_reach
     * positions of one a lower neighbour took */
    int64_t rr = s->cfg.repeat_reach;
    if (rr > 0 && s->st.iteration == s->cfg.iterations - 1)
        for (int i = 0; i < n; i++) {
            int64_t sp[3];
            gs_field_block_position(ls, B, s->match_at[nb[i]] - 1, sp);
            exclusion_box(s, B, sp, rr, ex, &ne);
        }
    /* a source so small that the boxes cover every block: no exclusion */
    if (covers_all(s, ex, ne, B))
        return 0;
    return repeat_span_exclusions(s, b, B, ex, ne);
}

/* Block i is matched before block b whatever the rank count: in the raster
 * order (region_blocks = 0) i < b; with target regions, i lies in a region of
 * a lower color (every region of a color is applied on every rank before the
 * next color starts, see gs_field_synth_color) or in b's own region before b
 * (a region visits its blocks in the raster order). A region of b's color
 * may run at the same time as b's, on another rank or before it on this one:
 * its blocks never count. */
static int matched_before(const struct gs_field_synth *s, int64_t i, int64_t b)
{
    if (!s->reg)
        return i < b;
    int64_t ci[3], cb[3], R = s->cfg.region_blocks, col_i = 0, col_b = 0;
    int same = 1;
    block_coords(s, i, ci);
    block_coords(s, b, cb);
    for (int a = 0; a < 3; a++) {
        int64_t ri = ci[a] / R < s->nr[a] ? ci[a] / R : s->nr[a] - 1;
        int64_t rb = cb[a] / R < s->nr[a] ? cb[a] / R : s->nr[a] - 1;
        col_i += ri, col_b += rb, same &= ri == rb;
    }
    return col_i < col_b || (same && i < b);
}

/* Marks the source blocks of box (bn blocks per axis) and appends it to ex,
 * unless fewer than repeat_free (0: a half) of the nsb source blocks would
 * then stay unmarked (the box is left out, nothing stays marked) or it adds
 * none. terrain.ini, repeat_free 0.5 -> 0.3 (field28): repeat_ncc_out seeds
 * 1-6 mean 0.899 -> 0.873; with half free the cap stopped the span before
 * its farther rings (span 12 or 16 instead of 8: 0.909, 0.905). */
static void try_box(struct gs_field_synth *s, const int64_t bn[3], int64_t nsb, const int64_t box[6],
                    int64_t (*ex)[6], int *ne)
{
    if (*ne >= s->nex_cap)
        return;
    int64_t before = s->nexlist;
    for (int64_t z = box[2]; z <= box[5]; z++)
        for (int64_t y = box[1]; y <= box[4]; y++)
            for (int64_t x = box[0]; x <= box[3]; x++) {
                int64_t k = x + bn[0] * (y + bn[1] * z);
                if (!s->exmark[k])
                    s->exmark[k] = 1, s->exlist[s->nexlist++] = k;
            }
    double keep = s->cfg.repeat_free > 0 ? s->cfg.repeat_free : 0.5;
    if ((double)(nsb - s->nexlist) < keep * (double)nsb) { /* too much: leave this one out */
        while (s->nexlist > before)
            s->exmark[s->exlist[--s->nexlist]] = 0;
        return;
    }
    if (s->nexlist > before)
        memcpy(ex[(*ne)++], box, sizeof *ex);
}

/* The source blocks within r positions of centre (each axis), clipped to
 * the level source; 0 when nothing is left. */
static int clip_box(const int64_t sn[3], int B, const int64_t centre[3], int64_t r, int64_t box[6])
{
    for (int a = 0; a < 3; a++) {
        int64_t hi = sn[a] - B;
        box[a] = centre[a] - r > 0 ? centre[a] - r : 0;
        box[a + 3] = centre[a] + r < hi ? centre[a] + r : hi;
        if (box[a] > box[a + 3])
            return 0;
    }
    return 1;
}

/* The level's reach: r at the last iteration, halved per coarser level, at
 * least 1. */
static int64_t level_reach(const struct gs_field_synth *s, int64_t r)
{
    int64_t l = r >> (s->cfg.iterations - 1 - s->st.iteration);
    return l < 1 ? 1 : l;
}

/* repeat_span (every iteration): the source blocks within the level's reach
 * of repeat_reach of the feature blocks (block_features: not plains) taken
 * by the blocks b - d, d in [-repeat_span, repeat_span]^3, that are matched
 * before b in every order (matched_before) and do not overlap b (some
 * |d_a| >= 2), nearest first (by max_a |d_a|, then d_z, d_y, d_x), while they
 * leave at least half the source blocks free (terrain.ini: a box of reach 6
 * is 13^2 of the 49^2 source blocks, so the nearest 7 or more). The result
 * is the same for any rank count. The coarse iteration lays out the summits:
 * in the last iteration alone the span removed the cycles below but left
 * seed 5's stacked summits and seed 2's row of round hills as they were. A
 * chain of blocks each matched on its left neighbour alone (the first rows)
 * falls into a cycle of source blocks: terrain.ini seeds 5, 8, 9, 12
 * repeated 10-25% of the height map 64 samples on along x (8 block
 * positions; with the span 6-10%). Up to field22 only the blocks below b
 * (d_a >= 0) counted: the rows before b to its right (matched earlier, in a
 * region of a lower color) were free to repeat what b took (#19, field24).
 *
 * repeat_pairs (every iteration, reach P halved per coarser level): for each
 * lower neighbour n = b - e of b and each block j matched before b (not
 * overlapping b) whose own neighbour j - e took a source block within P of
 * n's, the source block j took moved by n's minus j - e's (the pair j - e, j
 * shifted as a whole), and those within P of it. So no two neighbouring
 * source blocks recur side by side in the same direction, a two-piece
 * composite in two places (nor shifted a little in the source). Found: the
 * most alike two places of terrain.ini's height maps (repeat_ncc_out
 * 0.92-0.99) were such composites: seed 18's two windows 0.993 alike took
 * 93% of their samples from the same source places (within 3 samples) in the
 * same arrangement of pieces, seed 2's 82%; the coarse iteration alone
 * already repeated at 0.98-0.99 on its own scale (its example 0.82) and the
 * last one followed it. Under the same half-the-source cap. */
static int repeat_span_exclusions(struct gs_field_synth *s, int64_t b, int B, int64_t (*ex)[6], int ne)
{
    int64_t K = s->cfg.repeat_span, rr = s->cfg.repeat_reach, P = s->cfg.repeat_pairs;
    if (K <= 0 || rr <= 0)
        K = 0;
    if (K <= 0 && P <= 0)
        return ne;
    const gs_qfield *ls = s->level_src;
    const int64_t sn[3] = {ls->nx, ls->ny, ls->nz};
    int64_t bn[3] = {sn[0] - B + 1, sn[1] - B + 1, sn[2] - B + 1}, nsb = bn[0] * bn[1] * bn[2];
    int64_t c[3];
    block_coords(s, b, c);
    /* the boxes already there */
    for (int i = 0; i < ne; i++)
        for (int64_t z = ex[i][2]; z <= ex[i][5]; z++)
            for (int64_t y = ex[i][1]; y <= ex[i][4]; y++)
                for (int64_t x = ex[i][0]; x <= ex[i][3]; x++) {
                    int64_t k = x + bn[0] * (y + bn[1] * z);
                    if (!s->exmark[k])
                        s->exmark[k] = 1, s->exlist[s->nexlist++] = k;
                }
    /* repeat_span, nearest first: Chebyshev rings r = 2..K of positions b - d */
    int64_t rl = level_reach(s, rr);
    for (int64_t r = 2; r <= K; r++)
        for (int64_t dz = -r; dz <= r; dz++)
            for (int64_t dy = -r; dy <= r; dy++)
                for (int64_t dx = -r; dx <= r; dx++) {
                    int64_t q[3] = {c[0] - dx, c[1] - dy, c[2] - dz}, box[6], sp[3];
                    if ((llabs(dx) != r && llabs(dy) != r && llabs(dz) != r) || q[0] < 0 ||
                        q[1] < 0 || q[2] < 0 || q[0] >= s->npos[0] || q[1] >= s->npos[1] ||
                        q[2] >= s->npos[2])
                        continue;
                    int64_t i = q[0] + s->npos[0] * (q[1] + s->npos[1] * q[2]);
                    if (!s->match_at[i] || !matched_before(s, i, b) || !s->feature[s->match_at[i] - 1])
                        continue;
                    gs_field_block_position(ls, B, s->match_at[i] - 1, sp);
                    if (clip_box(sn, B, sp, rl, box))
                        try_box(s, bn, nsb, box, ex, &ne);
                }
    /* repeat_pairs */
    if (P > 0) {
        int64_t pl = level_reach(s, P), nb[7];
        int nn = lower_neighbours(s, b, nb);
        for (int q = 0; q < nn; q++) {
            int64_t cn[3], e[3], sp_n[3];
            block_coords(s, nb[q], cn);
            for (int a = 0; a < 3; a++)
                e[a] = c[a] - cn[a];
            gs_field_block_position(ls, B, s->match_at[nb[q]] - 1, sp_n);
            for (int64_t j = 0; j < s->st.blocks_in_iteration; j++) {
                int64_t cj[3];
                if (j == b || !s->match_at[j] || !matched_before(s, j, b))
                    continue;
                block_coords(s, j, cj);
                int overlaps = 1, inside = 1;
                for (int a = 0; a < 3; a++)
                    overlaps &= llabs(cj[a] - c[a]) <= 1, inside &= cj[a] >= e[a];
                if (overlaps || !inside)
                    continue;
                /* j - e is componentwise below j: matched before it */
                int64_t jn = cj[0] - e[0] + s->npos[0] * (cj[1] - e[1] + s->npos[1] * (cj[2] - e[2]));
                if (!s->match_at[jn])
                    continue;
                int64_t sp_jn[3], sp_j[3], centre[3], box[6];
                int far = 0;
                gs_field_block_position(ls, B, s->match_at[jn] - 1, sp_jn);
                for (int a = 0; a < 3; a++)
                    far |= llabs(sp_jn[a] - sp_n[a]) > pl;
                if (far)
                    continue;
                gs_field_block_position(ls, B, s->match_at[j] - 1, sp_j);
                for (int a = 0; a < 3; a++)
                    centre[a] = sp_j[a] + sp_n[a] - sp_jn[a];
                if (clip_box(sn, B, centre, pl, box))
                    try_box(s, bn, nsb, box, ex, &ne);
            }
        }
    }
    while (s->nexlist > 0)
        s->exmark[s->exlist[--s->nexlist]] = 0;
    return ne;
}

/* The boxes cover every source block of the level. */
static int covers_all(const struct gs_field_synth *s, const int64_t (*ex)[6], int ne, int B)
{
    const gs_qfield *ls = s->level_src;
    int64_t covered = 0;
    for (int i = 0; i < ne; i++)
        for (int64_t z = ex[i][2]; z <= ex[i][5]; z++)
            for (int64_t y = ex[i][1]; y <= ex[i][4]; y++)
                for (int64_t x = ex[i][0]; x <= ex[i][3]; x++) {
                    int before = 0;
                    for (int j = 0; j < i && !before; j++)
                        before = x >= ex[j][0] && x <= ex[j][3] && y >= ex[j][1] && y <= ex[j][4] &&
                                 z >= ex[j][2] && z <= ex[j][5];
                    covered += !before;
                }
    return covered >= gs_field_block_count(ls, B);
}

static uint64_t candidate_bound(const struct gs_field_synth *s, int64_t b, const gs_field_query *q,
                                const int64_t ex[][6], int nex)
{
    int64_t ix = b % s->npos[0];
    if (ix == 0 || !s->match_at[b - 1])
        return 0;
    const gs_qfield *ls = s->level_src;
    int B = q->block;
    int64_t bp[3];
    gs_field_block_position(ls, B, s->match_at[b - 1] - 1, bp);
    int64_t x = bp[0] + s->pos[0][ix] - s->pos[0][ix - 1];
    if (x + B > ls->nx)
        return 0;
    for (int i = 0; i < nex; i++) /* the bound must be a block the search may take */
        if (x >= ex[i][0] && x <= ex[i][3] && bp[1] >= ex[i][1] && bp[1] <= ex[i][4] &&
            bp[2] >= ex[i][2] && bp[2] <= ex[i][5])
            return 0;
    int64_t bx = ls->nx - B + 1, by = ls->ny - B + 1, idx = x + bx * (bp[1] + by * bp[2]);
    if (s->ob_nlist && s->ob_forbid[idx])
        return 0;
    uint64_t d = gs_field_block_distance(ls, idx, q);
    return d ? d : 1;
}

/* A uniformly random source block outside the exclusions for block b that
 * holds the surface (samples inside and outside; at most 64 draws); 0 when
 * every draw was refused. A block all inside or all outside gives the blocks
 * that continue it nothing to follow: quick.ini seed 3 took an empty one and
 * its volume fraction fell to 0.068 (source 0.163; with this 0.143). */
static int random_block(const struct gs_field_synth *s, int64_t b, int B, const int64_t ex[][6],
                        int nex, gs_field_match *m)
{
    const gs_qfield *ls = s->level_src;
    gs_rng r;
    gs_rng_init(&r, s->cfg.seed, gs_rng_stream_id(FIRST_BLOCK_DOMAIN, (uint64_t)b, 0, 0));
    const uint64_t M = (uint64_t)gs_field_block_count(ls, B);
    const int q0 = (int)floor(-ls->lo / (ls->hi - ls->lo) * 255.0 + 0.5); /* the zero level */
    for (int t = 0; t < 64; t++) {
        int64_t idx = (int64_t)gs_rng_below(&r, M), bp[3];
        gs_field_block_position(ls, B, idx, bp);
        int hit = 0;
        for (int i = 0; i < nex && !hit; i++)
            hit = bp[0] >= ex[i][0] && bp[0] <= ex[i][3] && bp[1] >= ex[i][1] &&
                  bp[1] <= ex[i][4] && bp[2] >= ex[i][2] && bp[2] <= ex[i][5];
        hit |= s->ob_nlist && s->ob_forbid[idx];
        if (!hit) { /* the block holds the surface: inside and outside samples */
            int in = 0, out = 0;
            for (int k = 0; k < B; k++)
                for (int j = 0; j < B; j++)
                    for (int i = 0; i < B; i++) {
                        int v = ls->q[bp[0] + i + ls->nx * (bp[1] + j + ls->ny * (bp[2] + k))];
                        in += v < q0, out += v > q0;
                    }
            hit = !(in && out);
        }
        if (!hit) {
            memset(m, 0, sizeof *m);
            m->index = idx;
            return 1;
        }
    }
    return 0;
}

/* ------------------------------------------------------- object spacing
 *
 * texture.ini's discs lie 12.3-13.0 samples apart in the example (centre to
 * nearest centre, all 10 of them), but 6-41% of the outputs' discs had one
 * nearer than any two in the example (seeds 1-12, layout_close_share): the
 * exact match of a block is the best over its synthesized overlap, and with
 * 10 discs to choose from it is seldom exact (mean 200-350 squared levels a
 * sample), so a disc of the new samples lands where the overlap's own disc
 * leaves no room for it. The overlap term cannot see that (the new disc
 * lies in the unsynthesized samples). With field.object_spacing (last
 * iteration) the source's objects are known up front (the components of
 * gs_field_layout_mask, what the layout measure counts: a height field's
 * low columns, else cores), and the objects already in the target are read
 * through prov: a synthesized sample copied from source object l at source
 * position r lies at target position t, so l's centre lies at t + (c_l - r)
 * there, whole or cut, wherever its other samples went. A source block at sp
 * puts object l (an image of it along wrapped axes) at c_l - (sp - p) if
 * l's box reaches the block's unsynthesized box at sp; that block is
 * excluded (gs_field_search_opts.exclude_mask) if this centre lies nearer
 * than ob_dmin (object_spacing times the source's smallest centre spacing)
 * to a target object's and farther than ob_same (a quarter of ob_dmin: the
 * same object continued, as a good match of its overlap does). The
 * exclusions are a function of the target, prov and the source alone, so
 * the search stays exact over the blocks left (the brute-force reference
 * takes the same mask) and a resumed run finds the same; while an eighth of
 * the source stays free (else no exclusion; with half, as repeat_span, 83%
 * of texture.ini's blocks went without: most blocks have 50-70% of the
 * source's positions excluded, because the source's discs lie everywhere
 * about 12.5 apart and its positions put one of them in most places, seed
 * 3). Raster order only: a region's private copy keeps no provenance.
 * texture.ini (object_spacing 1), seeds 1-6: close share 0.19-0.38 ->
 * 0.13-0.23 (the rest mostly beside discs cut by the output's faces, whose
 * centres the box moves), guarded close share (layout_guarded_*) 0.10-0.42
 * -> 0-0.10; fresh seeds 13-24 pooled 0.183 -> 0.024; 1.1 spaced the discs
 * wider than the example's (nn KS 0.35 -> 0.70, s/v -9.6%); a same-object
 * reach of 0.12 instead of 0.25 left more close pairs (0.21 vs 0.18), 0.4
 * about as many (0.16). */

/* The source's objects, their centres, boxes and smallest spacing (periodic
 * along wrapped axes), once. */
static gs_err object_setup(struct gs_field_synth *s)
{
    if (s->ob_ready)
        return GS_OK;
    const gs_qfield *src = s->src;
    const int64_t sn[3] = {src->nx, src->ny, src->nz};
    int height = gs_field_height_field(src);
    uint8_t *m = NULL;
    uint64_t *sz = NULL;
    uint32_t nc = 0;
    GS_CALL(gs_field_layout_mask(src, height, &m, s->ob_ln));
    size_t cells = (size_t)(s->ob_ln[0] * s->ob_ln[1] * s->ob_ln[2]);
    gs_err err = gs_alloc_array((void **)&s->ob_label, cells, sizeof *s->ob_label, "source objects");
    if (err == GS_OK)
        err = gs_measure_components3(m, (int)s->ob_ln[0], (int)s->ob_ln[1], (int)s->ob_ln[2], NULL,
                                     s->ob_label, &nc, &sz);
    gs_free(m);
    gs_free(sz);
    GS_CALL(err);
    s->ob_dims = height ? 2 : 3;
    s->ob_n = nc;
    size_t n1 = (size_t)nc + 1;
    GS_CALL(gs_alloc_array((void **)&s->ob_c, n1, 3 * sizeof *s->ob_c, "object centres"));
    GS_CALL(gs_alloc_array((void **)&s->ob_box, n1, sizeof *s->ob_box, "object boxes"));
    memset(s->ob_c, 0, n1 * 3 * sizeof *s->ob_c);
    double *cnt = NULL;
    GS_CALL(gs_alloc_array((void **)&cnt, n1, sizeof *cnt, "object sizes"));
    memset(cnt, 0, n1 * sizeof *cnt);
    for (uint32_t l = 0; l < nc; l++)
        for (int a = 0; a < 3; a++)
            s->ob_box[l][a] = INT64_MAX, s->ob_box[l][a + 3] = INT64_MIN;
    for (size_t i = 0; i < cells; i++) {
        uint32_t l = s->ob_label[i];
        if (!l)
            continue;
        int64_t v[3];
        gs_field_coords((int64_t)i, s->ob_ln, v);
        cnt[l - 1]++;
        for (int a = 0; a < 3; a++) {
            s->ob_c[3 * (l - 1) + a] += (double)v[a];
            if (v[a] < s->ob_box[l - 1][a])
                s->ob_box[l - 1][a] = v[a];
            if (v[a] > s->ob_box[l - 1][a + 3])
                s->ob_box[l - 1][a + 3] = v[a];
        }
    }
    for (uint32_t l = 0; l < nc; l++) {
        for (int a = 0; a < 3; a++)
            s->ob_c[3 * l + a] /= cnt[l];
        if (height) /* a column reaches every z */
            s->ob_c[3 * l + 2] = 0, s->ob_box[l][2] = 0, s->ob_box[l][5] = sn[2] - 1;
    }
    gs_free(cnt);
    double best = INFINITY;
    for (int64_t i = 0; i < s->ob_n; i++)
        for (int64_t j = i + 1; j < s->ob_n; j++) {
            double q = 0;
            for (int a = 0; a < s->ob_dims; a++) {
                double d = fabs(s->ob_c[3 * i + a] - s->ob_c[3 * j + a]);
                if (s->cfg.wrap >> a & 1 && sn[a] - d < d)
                    d = (double)sn[a] - d;
                q += d * d;
            }
            best = q < best ? q : best;
        }
    s->ob_dmin = isfinite(best) ? s->cfg.object_spacing * sqrt(best) : 0;
    s->ob_same = (s->cfg.object_same > 0 ? s->cfg.object_same : 0.25) * s->ob_dmin;
    s->ob_ready = 1;
    return GS_OK;
}

/* The shift sh of image img of the source's objects (bit a of img: one
 * source period along axis a); 0 when img shifts along an axis that does
 * not wrap (no such image). */
static int object_image(const struct gs_field_synth *s, int img, int64_t sh[3])
{
    for (int a = 0; a < 3; a++) {
        sh[a] = (img >> a & 1) ? s->wn[a] : 0;
        if ((img >> a & 1) && !(s->cfg.wrap >> a & 1))
            return 0;
    }
    return 1;
}

/* The squared distance (first D axes) between target centre e and a source
 * object's centre c put by source block sp at target block p. */
static double object_offset2(const double c[3], const int64_t sp[3], const int64_t p[3],
                             const double *e, int D)
{
    double q = 0;
    for (int a = 0; a < D; a++) {
        double d = c[a] - (double)(sp[a] - p[a]) - e[a];
        q += d * d;
    }
    return q;
}

/* field.object_continue (#19 whole objects): the target's objects
 * (ob_e[0 .. ne), of source objects ob_el) whose source box, moved to their
 * centre, reaches the block's unsynthesized box [p + u0, p + u1) are open;
 * a source block may then only be taken if it puts one of the source's
 * objects (any image along wrapped axes) within ob_same of every open one's
 * centre: the same object continued, not another beside it. texture.ini
 * before: with ob_same a quarter of the spacing (3.1 samples) a block put a
 * disc 1-3 samples off the one its overlap held and the seam joined the two
 * into an elongated or bulging disc (seeds 1-12: 56 of 460 merged,
 * layout_merged_share), or a block with no disc there cut the overlap's
 * (10 fragments). When no block outside the copy exclusions (ex) and the
 * spacing marks continues them all, nothing more is marked (the exact best
 * as before). A function of the target, prov and the source alone, so the
 * search stays exact over the blocks left and a resumed run finds the same.
 * Cost per block: the open objects times the source's objects and their
 * images, plus two passes over the source blocks. */
static gs_err object_continue(struct gs_field_synth *s, const int64_t p[3], const int64_t u0[3],
                              const int64_t u1[3], int64_t ne, const int64_t (*ex)[6], int nex)
{
    const int B = s->cfg.block[s->st.iteration], D = s->ob_dims;
    const gs_qfield *ls = s->level_src;
    const int64_t bn[3] = {ls->nx - B + 1, ls->ny - B + 1, ls->nz - B + 1};
    const int64_t M = bn[0] * bn[1] * bn[2];
    const double s2 = s->ob_same * s->ob_same;
    if (!s->ob_cnt) {
        GS_CALL(gs_alloc_array((void **)&s->ob_cnt, (size_t)M, sizeof *s->ob_cnt, "object continuations"));
        GS_CALL(gs_alloc_array((void **)&s->ob_stamp, (size_t)M, sizeof *s->ob_stamp, "object continuations"));
    }
    memset(s->ob_cnt, 0, (size_t)M * sizeof *s->ob_cnt);
    for (int64_t i = 0; i < M; i++)
        s->ob_stamp[i] = -1;
    int64_t nopen = 0;
    for (int64_t i = 0; i < ne; i++) {
        const double *e = s->ob_e + 3 * i;
        uint32_t l = s->ob_el[i];
        int open = 1;
        for (int a = 0; a < D && open; a++) {
            double lo = (double)s->ob_box[l][a] + e[a] - s->ob_c[3 * l + a];
            double hi = (double)s->ob_box[l][a + 3] + e[a] - s->ob_c[3 * l + a];
            open = hi >= (double)(p[a] + u0[a]) - 0.5 && lo <= (double)(p[a] + u1[a] - 1) + 0.5;
        }
        if (!open)
            continue;
        for (int64_t k = 0; k < s->ob_n; k++)
            for (int img = 0; img < 8; img++) {
                int64_t sh[3], b0[3], b1[3];
                if (!object_image(s, img, sh))
                    continue;
                /* the source blocks within ob_same of putting object k's
                 * image at e: a box of (b1 - b0 + 1) positions an axis */
                double c[3];
                int64_t w[3], cells = 1;
                for (int a = 0; a < 3; a++) {
                    c[a] = s->ob_c[3 * k + a] + (double)sh[a];
                    double m = c[a] + (double)p[a] - e[a];
                    int64_t lo = a < D ? (int64_t)ceil(m - s->ob_same) : 0;
                    int64_t hi = a < D ? (int64_t)floor(m + s->ob_same) : bn[a] - 1;
                    b0[a] = lo < 0 ? 0 : lo, b1[a] = hi > bn[a] - 1 ? bn[a] - 1 : hi;
                    w[a] = b1[a] >= b0[a] ? b1[a] - b0[a] + 1 : 0;
                    cells *= w[a];
                }
                for (int64_t t = 0; t < cells; t++) {
                    int64_t sp[3] = {b0[0] + t % w[0], b0[1] + t / w[0] % w[1], b0[2] + t / (w[0] * w[1])};
                    int64_t idx = sp[0] + bn[0] * (sp[1] + bn[1] * sp[2]);
                    if (object_offset2(c, sp, p, e, D) <= s2 && s->ob_stamp[idx] != i)
                        s->ob_stamp[idx] = i, s->ob_cnt[idx]++;
                }
            }
        nopen++;
    }
    if (!nopen)
        return GS_OK;
    int64_t free_ = 0;
    for (int64_t idx = 0; idx < M && !free_; idx++) {
        if (s->ob_cnt[idx] != nopen || s->ob_forbid[idx])
            continue;
        int64_t sp[3] = {idx % bn[0], idx / bn[0] % bn[1], idx / (bn[0] * bn[1])};
        int in = 0;
        for (int j = 0; j < nex && !in; j++)
            in = sp[0] >= ex[j][0] && sp[0] <= ex[j][3] && sp[1] >= ex[j][1] && sp[1] <= ex[j][4] &&
                 sp[2] >= ex[j][2] && sp[2] <= ex[j][5];
        free_ = !in;
    }
    if (!free_)
        return GS_OK;
    for (int64_t idx = 0; idx < M; idx++)
        if (s->ob_cnt[idx] != nopen && !s->ob_forbid[idx])
            s->ob_forbid[idx] = 1, s->ob_list[s->ob_nlist++] = idx;
    return GS_OK;
}

/* Marks in s->ob_forbid the source blocks block p of view v (the whole
 * target) may not take (see above); returns whether any is marked. nbox:
 * the positions the exclusion boxes already cover at most. */
static gs_err object_exclusions(struct gs_field_synth *s, const synth_view *v, const int64_t p[3],
                                int64_t nbox, const int64_t (*ex)[6], int nex, int *active)
{
    *active = 0;
    for (int64_t i = 0; i < s->ob_nlist; i++)
        s->ob_forbid[s->ob_list[i]] = 0;
    s->ob_nlist = 0;
    if (!(s->ob_dmin > 0) || s->st.iteration != s->cfg.iterations - 1 || !s->cfg.prov ||
        v->target != s->st.target)
        return GS_OK;
    const int B = s->cfg.block[s->st.iteration], D = s->ob_dims;
    const int64_t *tn = s->st.tn, sn[3] = {s->src->nx, s->src->ny, s->src->nz};
    const gs_qfield *ls = s->level_src;
    /* the block's unsynthesized box */
    int64_t u0[3] = {B, B, B}, u1[3] = {0, 0, 0};
    for (int64_t k = 0; k < B; k++)
        for (int64_t j = 0; j < B; j++)
            for (int64_t i = 0; i < B; i++) {
                int64_t l[3] = {i, j, k};
                if (v->mask[p[0] + i + tn[0] * (p[1] + j + tn[1] * (p[2] + k))])
                    continue;
                for (int a = 0; a < 3; a++)
                    u0[a] = l[a] < u0[a] ? l[a] : u0[a], u1[a] = l[a] + 1 > u1[a] ? l[a] + 1 : u1[a];
            }
    if (u1[0] == 0)
        return GS_OK;
    /* the target's objects within ob_dmin of the block */
    int64_t R = (int64_t)ceil(s->ob_dmin), lo[3], hi[3], ne = 0;
    for (int a = 0; a < 3; a++) {
        lo[a] = p[a] - R > 0 ? p[a] - R : 0;
        hi[a] = p[a] + B + R < tn[a] ? p[a] + B + R : tn[a];
    }
    for (int64_t z = lo[2]; z < hi[2]; z++)
        for (int64_t y = lo[1]; y < hi[1]; y++)
            for (int64_t x = lo[0]; x < hi[0]; x++) {
                int64_t g = x + tn[0] * (y + tn[1] * z), r[3];
                int32_t pr = s->cfg.prov[g];
                if (!v->mask[g] || pr < 0)
                    continue;
                gs_field_coords(pr, sn, r);
                uint32_t l = s->ob_label[D == 2 ? r[0] + sn[0] * r[1] : pr];
                if (!l)
                    continue;
                double e[3] = {(double)x + s->ob_c[3 * (l - 1)] - (double)r[0],
                               (double)y + s->ob_c[3 * (l - 1) + 1] - (double)r[1],
                               D == 2 ? 0 : (double)z + s->ob_c[3 * (l - 1) + 2] - (double)r[2]};
                int seen = 0;
                for (int64_t i = ne - 1; i >= 0 && !seen; i--)
                    seen = s->ob_e[3 * i] == e[0] && s->ob_e[3 * i + 1] == e[1] &&
                           s->ob_e[3 * i + 2] == e[2];
                if (seen)
                    continue;
                if (ne == s->ob_ecap) {
                    int64_t cap = s->ob_ecap ? 2 * s->ob_ecap : 64;
                    double *ne_ = gs_realloc(s->ob_e, (size_t)cap * 3 * sizeof *ne_);
                    GS_CHECK(ne_, GS_ERR_MEM, "out of memory for %lld object centres",
                             (long long)cap);
                    s->ob_e = ne_;
                    uint32_t *nl = gs_realloc(s->ob_el, (size_t)cap * sizeof *nl);
                    GS_CHECK(nl, GS_ERR_MEM, "out of memory for %lld object centres",
                             (long long)cap);
                    s->ob_el = nl, s->ob_ecap = cap;
                }
                s->ob_el[ne] = l - 1;
                memcpy(s->ob_e + 3 * ne++, e, sizeof e);
            }
    if (!ne)
        return GS_OK;
    /* the source blocks that put an object near one of them */
    const int64_t bn[3] = {ls->nx - B + 1, ls->ny - B + 1, ls->nz - B + 1};
    const int64_t M = bn[0] * bn[1] * bn[2];
    const double d2 = s->ob_dmin * s->ob_dmin, s2 = s->ob_same * s->ob_same;
    for (int64_t l = 0; l < s->ob_n; l++)
        for (int img = 0; img < 8; img++) {
            int64_t sh[3];
            if (!object_image(s, img, sh))
                continue;
            double c[3];
            int64_t b0[3], b1[3];
            for (int a = 0; a < 3; a++)
                c[a] = s->ob_c[3 * l + a] + (double)sh[a];
            for (int64_t i = 0; i < ne; i++) {
                const double *e = s->ob_e + 3 * i;
                int none = 0;
                for (int a = 0; a < 3 && !none; a++) {
                    /* reaching the unsynthesized box: box lo <= sp + u1 - 1, box hi >= sp + u0 */
                    int64_t r0 = s->ob_box[l][a] + sh[a] - u1[a] + 1, r1 = s->ob_box[l][a + 3] + sh[a] - u0[a];
                    if (a < D) { /* and the centre within ob_dmin */
                        double m = c[a] + (double)p[a] - e[a];
                        int64_t c0 = (int64_t)ceil(m - s->ob_dmin), c1 = (int64_t)floor(m + s->ob_dmin);
                        r0 = c0 > r0 ? c0 : r0, r1 = c1 < r1 ? c1 : r1;
                    }
                    b0[a] = r0 > 0 ? r0 : 0, b1[a] = r1 < bn[a] - 1 ? r1 : bn[a] - 1;
                    none = b0[a] > b1[a];
                }
                if (none)
                    continue;
                for (int64_t z = b0[2]; z <= b1[2]; z++)
                    for (int64_t y = b0[1]; y <= b1[1]; y++)
                        for (int64_t x = b0[0]; x <= b1[0]; x++) {
                            int64_t sp[3] = {x, y, z};
                            double q = object_offset2(c, sp, p, e, D);
                            int64_t idx = x + bn[0] * (y + bn[1] * z);
                            if (q < d2 && q > s2 && !s->ob_forbid[idx])
                                s->ob_forbid[idx] = 1, s->ob_list[s->ob_nlist++] = idx;
                        }
            }
        }
    if (8 * (s->ob_nlist + nbox) > 7 * M) { /* an eighth of the source stays free, or none */
        for (int64_t i = 0; i < s->ob_nlist; i++)
            s->ob_forbid[s->ob_list[i]] = 0;
        s->ob_nlist = 0;
    }
    if (s->cfg.object_continue)
        GS_CALL(object_continue(s, p, u0, u1, ne, ex, nex));
    *active = s->ob_nlist > 0;
    return GS_OK;
}

/* keep_volume with target regions: the volume so far as block b of region
 * g (colour c) sees it, the same whichever rank runs g and whatever other
 * regions of c ran before it: the samples outside every box of a region of
 * colour c (no region of c writes there, so they are as they were when c
 * began) plus those of g's own box (no other region of c writes into it:
 * see cut_block). Raster order (no regions): the whole target so far, as
 * before. Both are functions of the target and its mask alone, so a run
 * resumed anywhere recounts them. Kept in vol_in/vol_n, recounted when b
 * starts another region (copy_block updates them in between); the outside
 * counts once per colour. texture.ini at region_blocks 4: the box of a
 * region is 40 x 40 x 16 samples, the outside ~85% of the target. */
static gs_err region_volume(struct gs_field_synth *s, const synth_view *v, int64_t b)
{
    if (!s->tie_more || !s->reg)
        return GS_OK;
    int B = s->cfg.block[s->st.iteration];
    int64_t c[3], lo[3], hi[3], R = s->cfg.region_blocks, r[3];
    int color = 0;
    block_coords(s, b, c);
    for (int a = 0; a < 3; a++) {
        r[a] = c[a] / R < s->nr[a] ? c[a] / R : s->nr[a] - 1;
        int64_t f = r[a] * R, l = r[a] == s->nr[a] - 1 ? s->npos[a] : f + R;
        lo[a] = s->pos[a][f], hi[a] = s->pos[a][l - 1] + B;
        color += (int)r[a];
    }
    int64_t id = r[0] + s->nr[0] * (r[1] + s->nr[1] * r[2]);
    if (id == s->kv_region)
        return GS_OK;
    const int64_t *tn = s->st.tn;
    if (color != s->kv_color || s->st.iteration != s->kv_it) {
        size_t n = (size_t)(tn[0] * tn[1] * tn[2]);
        if (n > s->kv_cap) {
            gs_free(s->kv_mark);
            s->kv_mark = NULL, s->kv_cap = 0;
            GS_CALL(gs_alloc_array((void **)&s->kv_mark, n, 1, "region box marks"));
            s->kv_cap = n;
        }
        memset(s->kv_mark, 0, n);
        for (int64_t k = 0; k < s->nreg; k++) {
            const gs_field_region *g = &s->reg[k];
            if (g->color != color)
                continue;
            for (int64_t z = g->lo[2]; z < g->hi[2]; z++)
                for (int64_t y = g->lo[1]; y < g->hi[1]; y++)
                    memset(s->kv_mark + g->lo[0] + tn[0] * (y + tn[1] * z), 1,
                           (size_t)(g->hi[0] - g->lo[0]));
        }
        s->kv_out_in = s->kv_out_n = 0;
        for (size_t i = 0; i < n; i++)
            if (!s->kv_mark[i] && s->st.mask[i])
                s->kv_out_n++, s->kv_out_in += s->inside[s->st.target[i]];
        s->kv_color = color, s->kv_it = s->st.iteration;
    }
    int64_t in = 0, cnt = 0, vx = v->n[0], vxy = v->n[0] * v->n[1];
    for (int64_t z = lo[2]; z < hi[2]; z++)
        for (int64_t y = lo[1]; y < hi[1]; y++) {
            int64_t o = lo[0] - v->o[0] + vx * (y - v->o[1]) + vxy * (z - v->o[2]);
            for (int64_t x = 0; x < hi[0] - lo[0]; x++)
                if (v->mask[o + x])
                    cnt++, in += s->inside[v->target[o + x]];
        }
    s->vol_in = s->kv_out_in + in, s->vol_n = s->kv_out_n + cnt;
    s->kv_region = id;
    return GS_OK;
}

static gs_err match_block(struct gs_field_synth *s, const synth_view *v, const int64_t p[3],
                          int64_t b, int use_hook, block_result *r)
{
    int it = s->st.iteration, B = s->cfg.block[it];
    int64_t vx = v->n[0], vxy = v->n[0] * v->n[1];
    int64_t any_known = 0;
    for (int k = 0; k < B; k++)
        for (int j = 0; j < B; j++) {
            int64_t o = p[0] - v->o[0] + vx * (p[1] - v->o[1] + j) + vxy * (p[2] - v->o[2] + k);
            memcpy(s->qval + B * (j + B * k), v->target + o, (size_t)B);
            memcpy(s->qknown + B * (j + B * k), v->mask + o, (size_t)B);
            for (int i = 0; i < B; i++)
                any_known += v->mask[o + i];
        }
    /* with masking, the first block (nothing known yet) is matched on its
     * seeds; after iteration 0 the unsynthesized samples hold the upsampled
     * coarse result, weighted by coarse_weight (256: the whole block) */
    int w, masked;
    if (s->cfg.mask_unsynthesized) {
        w = it > 0 ? s->cfg.coarse_weight : s->cfg.seed_weight;
        masked = any_known > 0 && w < 256;
    } else {
        /* the paper: whole blocks, the coarse result at full weight; its
         * random seeds "match approximately equally well with any block" only
         * if they weigh next to nothing (see GS_FIELD_PAPER_SEED_WEIGHT) */
        w = GS_FIELD_PAPER_SEED_WEIGHT;
        masked = it == 0 && any_known > 0;
    }
    gs_field_query q = {B, s->qval, masked ? s->qknown : NULL, w};
    gs_field_search_opts opts = {0};
    int64_t (*ex)[6] = s->ex;
    opts.nexclude = copy_exclusions(s, b, B, ex);
    opts.exclude = (const int64_t(*)[6])ex;
    if (s->ob_forbid) { /* object_spacing (last iteration) */
        int64_t nbox = 0;
        for (int i = 0; i < opts.nexclude; i++)
            nbox += (ex[i][3] - ex[i][0] + 1) * (ex[i][4] - ex[i][1] + 1) * (ex[i][5] - ex[i][2] + 1);
        int on = 0;
        GS_CALL(object_exclusions(s, v, p, nbox, (const int64_t(*)[6])ex, opts.nexclude, &on));
        if (on)
            opts.exclude_mask = s->ob_forbid;
    }
    opts.use_upper_bound = s->cfg.use_upper_bound && it > 0; /* no random seeds after iteration 0 */
    GS_CALL(region_volume(s, v, b));
    if (s->cfg.keep_volume && s->vol_n > 0) /* short of inside: vol_in/vol_n < src_in/src_n */
        opts.tie_class = s->vol_in * s->src_n < s->src_in * s->vol_n ? s->tie_more : s->tie_less;
    /* Exact ties (equal distance: a periodic source, flat or empty regions,
     * blocks that differ only where the query is unknown) go to a block
     * drawn by a hash of (seed, iteration, target block), not to the lowest
     * index: that biased every tie to the start of the source (patchwork,
     * chain mail tiled from its first rings). Stateless: the same at any
     * rank count and across resume. */
    uint64_t tie = gs_hash_mix64(s->cfg.seed ^ gs_rng_stream_id(TIE_DOMAIN, (uint64_t)b, (uint64_t)it, 0));
    opts.tie_key = tie ? tie : 1;
    if (opts.use_upper_bound && s->cfg.tree_shards <= 1)
        opts.start_bound = candidate_bound(s, b, &q, (const int64_t(*)[6])ex, opts.nexclude);
    gs_field_match m;
    /* A block with nothing synthesized around it in iteration 0, seeded with
     * random samples: the paper (5.1) says such seeds "match approximately
     * equally well with any block", so it takes a source block uniformly at
     * random (its own stream, keyed by the seed and the block). Matching the
     * noise exactly picked the one block closest to noise whatever the seed
     * (terrain.ini: seeds 2-5 gave the same output). */
    if (s->cfg.mask_unsynthesized && it == 0 && any_known == 0 && !s->cfg.seed_blocks &&
        random_block(s, b, B, (const int64_t(*)[6])ex, opts.nexclude, &m)) {
        r->index = m.index;
        s->match_at[b] = m.index + 1;
        note_match(s, b);
        r->nd = 0;
        r->pops = r->pushes = 0;
        return GS_OK;
    }
    if (use_hook && s->cfg.match)
        GS_CALL(s->cfg.match(s->cfg.match_ctx, s->tree, s->searcher, it, &q, &opts, &m));
    else
        GS_CALL(gs_field_tree_best_match(s->searcher, &q, &opts, &m));
    /* normalized: per known sample, in squared levels (the weighted part included) */
    uint64_t wk, wu;
    gs_field_query_weights(&q, &wk, &wu);
    r->index = m.index;
    s->match_at[b] = m.index + 1;
    note_match(s, b);
    r->nd = m.known ? (double)m.dist / (double)wk / (double)m.known : 0;
    r->pops = m.pops;
    r->pushes = m.pushes;
    return GS_OK;
}

/* Seam cut (cfg.seam_cut) of block b at p on view v against source block
 * bp: s->cut_new[i] = 1 for the block samples the new block takes. Without
 * it the new block takes the unsynthesized samples only, so pieces meet on
 * the planes of the block grid whatever they hold there (terrain.ini:
 * straight cliffs; balls and discs cut in two). With it the seam may move
 * into the synthesized overlap, along the samples where old and new agree
 * best (Efros and Freeman's minimum error boundary cut, in 3D as a graph cut
 * [Kwatra et al. 2003]; paper 5.3 names both as texture synthesis' answer).
 * Ties: an unsynthesized sample takes the new block; a synthesized one on a
 * face of the block (not of the target) keeps the old content, so the seam
 * closes inside the block; with target regions, so does every sample in the
 * box of another region of b's colour (the diagonal neighbours of b's
 * region, whose boxes meet b's in corners of lower regions' cores): a region
 * then rewrites only samples that no other region of its colour reads, so
 * running the regions of a colour on private copies gives what running them
 * one after the other gives (the result depends on region_blocks, never on
 * the rank count). A region may rewrite the strips of its lower neighbours'
 * cores that its box covers: confined to its own core, the seams between
 * regions stayed on straight planes of the block grid, 32 samples long at
 * region_blocks 4 (terrain.ini: steps 2.7 times the mean across x = 104,
 * seam ratio 1.133 -> 1.116). The rest is free. A sample's disagreement: |old - new| in
 * levels, plus one sample's worth of levels where they differ in sign (a
 * surface there would move); 0 where nothing is synthesized yet. Reads
 * only the block's box, the same on a region's private copy as on the
 * whole target. With seam_columns the cut keeps every column whole
 * (gs_field_seam_cut's columns): a height field's objects are its columns. */
static void cut_block(struct gs_field_synth *s, const synth_view *v, const int64_t p[3],
                      int64_t b, const int64_t bp[3])
{
    int B = s->cfg.block[s->st.iteration];
    const gs_qfield *ls = s->level_src;
    const int64_t *tn = s->st.tn;
    int64_t vx = v->n[0], vxy = v->n[0] * v->n[1];
    uint8_t inside[256];
    for (int l = 0; l < 256; l++)
        inside[l] = gs_qfield_value(ls, (uint8_t)l) < 0;
    uint32_t flip = (uint32_t)(255.0 * ls->spacing / (ls->hi - ls->lo) + 0.5);
    /* with target regions: the boxes (within this block) of the regions of
     * b's colour next to b's region, whose samples b must not rewrite */
    int64_t keep[26][6];
    int nkeep = 0;
    if (s->reg) {
        int64_t c[3], r[3], R = s->cfg.region_blocks;
        block_coords(s, b, c);
        for (int a = 0; a < 3; a++)
            r[a] = c[a] / R < s->nr[a] ? c[a] / R : s->nr[a] - 1;
        for (int dz = -1; dz <= 1; dz++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int64_t q[3] = {r[0] + dx, r[1] + dy, r[2] + dz}, box[6];
                    int in = dx + dy + dz == 0 && (dx || dy || dz);
                    for (int a = 0; a < 3 && in; a++) {
                        in = q[a] >= 0 && q[a] < s->nr[a];
                        if (!in)
                            break;
                        int64_t f = q[a] * R, l = q[a] == s->nr[a] - 1 ? s->npos[a] : f + R;
                        box[a] = s->pos[a][f] > p[a] ? s->pos[a][f] : p[a];
                        box[a + 3] = s->pos[a][l - 1] + B < p[a] + B ? s->pos[a][l - 1] + B : p[a] + B;
                        in = box[a] < box[a + 3];
                    }
                    if (in)
                        memcpy(keep[nkeep++], box, sizeof box);
                }
    }
    for (int k = 0; k < B; k++)
        for (int j = 0; j < B; j++) {
            int64_t o = p[0] - v->o[0] + vx * (p[1] - v->o[1] + j) + vxy * (p[2] - v->o[2] + k);
            const uint8_t *from = ls->q + bp[0] + ls->nx * (bp[1] + j + ls->ny * (bp[2] + k));
            for (int i = 0; i < B; i++) {
                int32_t n = i + B * (j + B * k);
                int64_t t = o + i;
                if (!v->mask[t]) {
                    s->cut_term[n] = GS_CUT_NEW, s->cut_cost[n] = 0;
                    continue;
                }
                uint8_t x = v->target[t], y = from[i];
                s->cut_cost[n] = (uint32_t)(x > y ? x - y : y - x) +
                                 (inside[x] != inside[y] ? flip : 0);
                int loc[3] = {i, j, k}, old = 0;
                for (int a = 0; a < 3 && !old; a++) {
                    int64_t g = p[a] + loc[a];
                    old = (loc[a] == 0 && g > 0) || (loc[a] == B - 1 && g + 1 < tn[a]);
                }
                for (int e = 0; e < nkeep && !old; e++) {
                    int64_t g[3] = {p[0] + i, p[1] + j, p[2] + k};
                    old = g[0] >= keep[e][0] && g[0] < keep[e][3] && g[1] >= keep[e][1] &&
                          g[1] < keep[e][4] && g[2] >= keep[e][2] && g[2] < keep[e][5];
                }
                s->cut_term[n] = old ? GS_CUT_OLD : GS_CUT_FREE;
            }
        }
    gs_field_seam_cut(&s->cut, s->cut_term, s->cut_cost, s->cfg.seam_columns, s->cut_new);
}

/* Copies source block `index` into the unsynthesized samples of the block
 * at p on view v (with seam_cut: into the samples the cut gives it);
 * records provenance (last iteration, whole target only). */
static void copy_block(struct gs_field_synth *s, const synth_view *v, const int64_t p[3],
                       int64_t b, int64_t index, int record)
{
    int it = s->st.iteration, B = s->cfg.block[it];
    int64_t bp[3];
    gs_field_block_position(s->level_src, B, index, bp);
    const gs_qfield *ls = s->level_src;
    int32_t *prov = record && it == s->cfg.iterations - 1 ? s->cfg.prov : NULL;
    uint64_t csq = 0, cn = 0;
    int64_t vx = v->n[0], vxy = v->n[0] * v->n[1];
    if (s->cfg.seam_cut)
        cut_block(s, v, p, b, bp);
    for (int k = 0; k < B; k++)
        for (int j = 0; j < B; j++) {
            int64_t o = p[0] - v->o[0] + vx * (p[1] - v->o[1] + j) + vxy * (p[2] - v->o[2] + k);
            int64_t so = bp[0] + ls->nx * (bp[1] + j + ls->ny * (bp[2] + k));
            const uint8_t *from = ls->q + so;
            if (s->cfg.seam_cut)
                for (int i = 0; i < B; i++)
                    if (v->mask[o + i] && s->cut_new[i + B * (j + B * k)]) {
                        if (s->tie_more)
                            s->vol_in += s->inside[from[i]] - s->inside[v->target[o + i]];
                        v->target[o + i] = from[i];
                        if (prov)
                            prov[o + i] = (int32_t)unwrap_index(s, so + i);
                    }
            for (int i = 0; i < B; i++)
                if (!v->mask[o + i]) {
                    csq += (gs_qfield_value(ls, from[i]) < 0) !=
                           (gs_qfield_value(ls, v->target[o + i]) < 0);
                    cn++;
                    if (s->tie_more)
                        s->vol_n++, s->vol_in += s->inside[from[i]];
                    v->target[o + i] = from[i];
                    v->mask[o + i] = 1;
                    if (prov)
                        prov[o + i] = (int32_t)unwrap_index(s, so + i);
                }
        }
    if (record && it > 0) {
        s->st.stat_coarse_flips[it] += csq;
        s->st.stat_coarse_n[it] += cn;
    }
}

/* Statistics of one block, and the cursor past it. */
static void account(struct gs_field_synth *s, const block_result *r)
{
    int it = s->st.iteration;
    s->st.stat_count[it]++;
    s->st.stat_sum[it] += r->nd;
    if (r->nd < s->st.stat_min[it])
        s->st.stat_min[it] = r->nd;
    if (r->nd > s->st.stat_max[it])
        s->st.stat_max[it] = r->nd;
    s->st.stat_pops[it] += r->pops;
    s->st.stat_pushes[it] += r->pushes;
    s->st.cursor++;
}

static synth_view whole_view(struct gs_field_synth *s)
{
    synth_view v = {s->st.target, s->st.mask, {0, 0, 0}, {s->st.tn[0], s->st.tn[1], s->st.tn[2]}};
    return v;
}

static gs_err synth_block(struct gs_field_synth *s)
{
    int64_t p[3];
    block_pos(s, s->st.cursor, p);
    synth_view v = whole_view(s);
    block_result r;
    int64_t b = s->order ? s->order[s->st.cursor] : s->st.cursor;
    GS_CALL(match_block(s, &v, p, b, 1, &r));
    copy_block(s, &v, p, b, r.index, 1);
    account(s, &r);
    return GS_OK;
}

gs_err gs_field_synth_color(gs_field_synth_t s, int64_t *begin, int64_t *end,
                            const gs_field_region **regions, int64_t *first_region,
                            int64_t *nregions, int *finished)
{
    if (s->st.iteration < s->cfg.iterations && s->st.cursor >= s->st.blocks_in_iteration)
        GS_CALL(advance_iteration(s));
    *finished = s->st.iteration >= s->cfg.iterations;
    if (*finished)
        return GS_OK;
    *regions = s->reg;
    if (!s->reg) {
        *begin = 0, *end = s->st.blocks_in_iteration;
        *first_region = 0, *nregions = 0;
        return GS_OK;
    }
    int64_t r = 0;
    while (r + 1 < s->nreg && s->reg[r].first + s->reg[r].count <= s->st.cursor)
        r++;
    int color = s->reg[r].color;
    int64_t a = r, b = r;
    while (a > 0 && s->reg[a - 1].color == color)
        a--;
    while (b + 1 < s->nreg && s->reg[b + 1].color == color)
        b++;
    *begin = s->reg[a].first;
    *end = s->reg[b].first + s->reg[b].count;
    *first_region = a;
    *nregions = b - a + 1;
    return GS_OK;
}

size_t gs_field_synth_region_bytes(gs_field_synth_t s, int64_t region)
{
    if (!s->reg || region < 0 || region >= s->nreg)
        return 0;
    return (size_t)s->reg[region].count * sizeof(block_result);
}

gs_field_tree_t gs_field_synth_tree(gs_field_synth_t s)
{
    return s->tree;
}

gs_err gs_field_synth_region_run(gs_field_synth_t s, int64_t region, void *out)
{
    GS_CHECK(s->reg && region >= 0 && region < s->nreg && s->st.iteration < s->cfg.iterations,
             GS_ERR_ARG, "field region %lld: expected 0..%lld of the current iteration",
             (long long)region, (long long)s->nreg - 1);
    GS_CHECK(s->cfg.tree_shards <= 1, GS_ERR_ARG,
             "field region %lld: a region is synthesized with the whole tree, this synthesis "
             "holds shard %d of %d", (long long)region, s->cfg.tree_shard, s->cfg.tree_shards);
    const gs_field_region *g = &s->reg[region];
    synth_view v = {NULL, NULL, {g->lo[0], g->lo[1], g->lo[2]},
                    {g->hi[0] - g->lo[0], g->hi[1] - g->lo[1], g->hi[2] - g->lo[2]}};
    size_t n = (size_t)(v.n[0] * v.n[1] * v.n[2]);
    v.target = s->scratch, v.mask = s->scratch + n;
    int64_t tx = s->st.tn[0], txy = s->st.tn[0] * s->st.tn[1];
    for (int64_t z = 0; z < v.n[2]; z++)
        for (int64_t y = 0; y < v.n[1]; y++) {
            int64_t o = v.o[0] + tx * (v.o[1] + y) + txy * (v.o[2] + z), d = v.n[0] * (y + v.n[1] * z);
            memcpy(v.target + d, s->st.target + o, (size_t)v.n[0]);
            memcpy(v.mask + d, s->st.mask + o, (size_t)v.n[0]);
        }
    block_result *res = out;
    s->kv_region = -1; /* region_volume recounts from this region's copy */
    for (int64_t i = 0; i < g->count; i++) {
        int64_t p[3];
        block_pos(s, g->first + i, p);
        block_result r;
        GS_CALL(match_block(s, &v, p, s->order[g->first + i], 0, &r));
        copy_block(s, &v, p, s->order[g->first + i], r.index, 0);
        memcpy(&res[i], &r, sizeof r);
    }
    return GS_OK;
}

gs_err gs_field_synth_region_apply(gs_field_synth_t s, int64_t region, const void *buf, size_t len)
{
    GS_CHECK(s->reg && region >= 0 && region < s->nreg && s->st.iteration < s->cfg.iterations,
             GS_ERR_ARG, "field region %lld: expected 0..%lld of the current iteration",
             (long long)region, (long long)s->nreg - 1);
    const gs_field_region *g = &s->reg[region];
    GS_CHECK(s->st.cursor == g->first, GS_ERR_INTERNAL,
             "field region %lld applied at block %lld: it starts at block %lld", (long long)region,
             (long long)s->st.cursor, (long long)g->first);
    GS_CHECK(len == gs_field_synth_region_bytes(s, region), GS_ERR_INTERNAL,
             "field region %lld: result of %zu bytes, expected %zu", (long long)region, len,
             gs_field_synth_region_bytes(s, region));
    int64_t M = gs_field_block_count(s->level_src, s->cfg.block[s->st.iteration]);
    synth_view v = whole_view(s);
    const unsigned char *b = buf;
    s->kv_region = -1; /* the counts copy_block keeps here are not a region's */
    for (int64_t i = 0; i < g->count; i++) {
        block_result r;
        memcpy(&r, b + (size_t)i * sizeof r, sizeof r);
        GS_CHECK(r.index >= 0 && r.index < M, GS_ERR_INTERNAL,
                 "field region %lld: block %lld matched source block %lld of %lld",
                 (long long)region, (long long)i, (long long)r.index, (long long)M);
        int64_t p[3];
        block_pos(s, s->st.cursor, p);
        s->match_at[s->order[s->st.cursor]] = r.index + 1;
        note_match(s, s->order[s->st.cursor]);
        copy_block(s, &v, p, s->order[s->st.cursor], r.index, 1);
        account(s, &r);
    }
    return GS_OK;
}

gs_err gs_field_synth_run(gs_field_synth_t s, int64_t max_blocks, int *finished)
{
    int64_t done = 0;
    while (s->st.iteration < s->cfg.iterations && (max_blocks < 0 || done < max_blocks)) {
        if (s->st.cursor >= s->st.blocks_in_iteration) {
            GS_CALL(advance_iteration(s));
            continue;
        }
        GS_CALL(synth_block(s));
        done++;
    }
    if (s->st.iteration < s->cfg.iterations && s->st.cursor >= s->st.blocks_in_iteration &&
        s->st.iteration == s->cfg.iterations - 1)
        GS_CALL(advance_iteration(s));
    *finished = s->st.iteration >= s->cfg.iterations;
    return GS_OK;
}

const gs_field_synth_state *gs_field_synth_get_state(gs_field_synth_t s)
{
    s->st.matches = s->match_at;
    return &s->st;
}

gs_err gs_field_synth_result(gs_field_synth_t s, gs_qfield **out)
{
    GS_CHECK(s->st.target, GS_ERR_ARG, "synthesis result: already taken (gs_field_synth_take_result)");
    gs_qfield *r = NULL;
    GS_CALL(gs_qfield_create(s->st.tn[0], s->st.tn[1], s->st.tn[2], s->src->lo, s->src->hi, &r));
    memcpy(r->q, s->st.target, (size_t)(s->st.tn[0] * s->st.tn[1] * s->st.tn[2]));
    int64_t f = s->cfg.target[0] / s->st.tn[0];
    r->spacing = s->src->spacing * (double)f;
    *out = r;
    return GS_OK;
}

gs_err gs_field_synth_take_result(gs_field_synth_t s, gs_qfield **out)
{
    GS_CHECK(s->st.target, GS_ERR_ARG, "synthesis result: already taken (gs_field_synth_take_result)");
    GS_CHECK(s->st.iteration >= s->cfg.iterations, GS_ERR_ARG,
             "synthesis result: the synthesis is not finished (iteration %d of %d)",
             s->st.iteration, s->cfg.iterations);
    gs_qfield *r = gs_calloc(1, sizeof *r);
    GS_CHECK(r, GS_ERR_MEM, "out of memory for a field header");
    r->nx = s->st.tn[0], r->ny = s->st.tn[1], r->nz = s->st.tn[2];
    r->lo = s->src->lo, r->hi = s->src->hi;
    r->spacing = s->src->spacing * (double)(s->cfg.target[0] / s->st.tn[0]);
    r->q = s->st.target; /* handed over, not copied */
    s->st.target = NULL;
    gs_free(s->st.mask);
    s->st.mask = NULL;
    *out = r;
    return GS_OK;
}

/* ------------------------------------------------------------- quality */

static void sign_stats(const gs_qfield *q, double *vf, double *spv)
{
    uint8_t inside[256];
    for (int i = 0; i < 256; i++)
        inside[i] = gs_qfield_value(q, (uint8_t)i) < 0;
    int64_t nx = q->nx, nxy = q->nx * q->ny, n = nxy * q->nz, in = 0, changes = 0;
    for (int64_t z = 0; z < q->nz; z++)
        for (int64_t y = 0; y < q->ny; y++)
            for (int64_t x = 0; x < nx; x++) {
                int64_t i = x + nx * y + nxy * z;
                uint8_t a = inside[q->q[i]];
                in += a;
                if (x + 1 < nx)
                    changes += a != inside[q->q[i + 1]];
                if (y + 1 < q->ny)
                    changes += a != inside[q->q[i + nx]];
                if (z + 1 < q->nz)
                    changes += a != inside[q->q[i + nxy]];
            }
    *vf = (double)in / (double)n;
    /* each sign change stands for about one cell face of surface: area spacing^2
     * per volume n*spacing^3 */
    *spv = (double)changes / ((double)n * q->spacing);
}

static gs_err tree_match(void *searcher, const gs_field_query *q, gs_field_match *out)
{
    return gs_field_tree_best_match(searcher, q, NULL, out);
}

gs_err gs_field_quality_measure(const gs_qfield *out, const gs_qfield *src, gs_field_tree_t tree,
                                gs_field_quality *qm)
{
    gs_field_searcher_t s = NULL;
    GS_CALL(gs_field_searcher_create(tree, &s));
    gs_err err = gs_field_quality_measure_with(out, src, gs_field_tree_block(tree), tree_match, s, qm);
    gs_field_searcher_destroy(&s);
    return err;
}

/* Exact lookup of whole blocks in the source (the verbatim blocks of the
 * quality measure): a polynomial hash of every source block (rolled along
 * x, y, z: O(source) work), an open-addressing table of the distinct
 * contents, each with its lowest block index, and every hit verified byte
 * by byte. */
typedef struct block_table {
    uint64_t *h;   /* hash per slot (valid when idx >= 0) */
    int64_t *idx;  /* lowest block index of that content; -1 empty */
    size_t cap;
    const gs_qfield *src;
    int B;
} block_table;

static const uint64_t BH_BASE[3] = {0x9e3779b97f4a7c15ULL, 0xc2b2ae3d27d4eb4fULL,
                                    0x165667b19e3779f9ULL};

/* Whether source block `index` holds the B^3 values at v (rows sy apart,
 * planes sz apart). */
static int block_same(const gs_qfield *src, int B, int64_t index, const uint8_t *v, int64_t sy,
                      int64_t sz)
{
    int64_t p[3];
    gs_field_block_position(src, B, index, p);
    for (int k = 0; k < B; k++)
        for (int j = 0; j < B; j++)
            if (memcmp(src->q + p[0] + src->nx * (p[1] + j + src->ny * (p[2] + k)),
                       v + sy * j + sz * k, (size_t)B))
                return 0;
    return 1;
}

/* Slot of the content at v (hash h; strides as block_same's) or of the
 * empty slot where it would go. */
static size_t block_slot(const block_table *t, uint64_t h, const uint8_t *v, int64_t sy, int64_t sz)
{
    size_t i = (size_t)gs_hash_mix64(h) & (t->cap - 1);
    while (t->idx[i] >= 0 && !(t->h[i] == h && block_same(t->src, t->B, t->idx[i], v, sy, sz)))
        i = (i + 1) & (t->cap - 1);
    return i;
}

/* The hash of a B^3 block of values (x fastest): Horner along x, y, z. */
static uint64_t block_hash(const uint8_t *val, int B)
{
    uint64_t hz = 0;
    for (int k = 0; k < B; k++) {
        uint64_t hy = 0;
        for (int j = 0; j < B; j++) {
            uint64_t hx = 0;
            const uint8_t *r = val + (size_t)B * (j + (size_t)B * k);
            for (int i = 0; i < B; i++)
                hx = hx * BH_BASE[0] + r[i];
            hy = hy * BH_BASE[1] + hx;
        }
        hz = hz * BH_BASE[2] + hy;
    }
    return hz;
}

/* Along axis a of h (dims n, stride st[a]), each entry becomes the Horner
 * sum of the B entries from it on with base b (where B fit). */
static void roll_axis(uint64_t *h, const int64_t n[3], int a, int B, uint64_t b, uint64_t *line)
{
    const int64_t st[3] = {1, n[0], n[0] * n[1]};
    int u = a == 0 ? 1 : 0, w = a == 2 ? 1 : 2;
    uint64_t bB = 1;
    for (int i = 0; i < B; i++)
        bB *= b;
    for (int64_t j = 0; j < n[w]; j++)
        for (int64_t i = 0; i < n[u]; i++) {
            uint64_t *p = h + i * st[u] + j * st[w];
            for (int64_t x = 0; x < n[a]; x++)
                line[x] = p[x * st[a]];
            uint64_t s = 0;
            for (int64_t x = 0; x < B && x < n[a]; x++)
                s = s * b + line[x];
            for (int64_t x = 0; x + B <= n[a]; x++) {
                p[x * st[a]] = s;
                if (x + B < n[a])
                    s = s * b - line[x] * bB + line[x + B];
            }
        }
}

static gs_err block_table_build(const gs_qfield *src, int B, block_table *t)
{
    memset(t, 0, sizeof *t);
    t->src = src, t->B = B;
    const int64_t n[3] = {src->nx, src->ny, src->nz}, cells = n[0] * n[1] * n[2];
    int64_t M = gs_field_block_count(src, B);
    int64_t big = n[0] > n[1] ? n[0] : n[1];
    big = big > n[2] ? big : n[2];
    uint64_t *h = NULL, *line = NULL;
    gs_err err = GS_OK;
    t->cap = 16;
    while (t->cap < 2 * (size_t)M)
        t->cap <<= 1;
    GS_TRY(err, gs_alloc_array((void **)&h, (size_t)cells, sizeof *h, "source block hashes"), done);
    GS_TRY(err, gs_alloc_array((void **)&line, (size_t)big, sizeof *line, "hash line"), done);
    GS_TRY(err, gs_alloc_array((void **)&t->h, t->cap, sizeof *t->h, "block table"), done);
    GS_TRY(err, gs_alloc_array((void **)&t->idx, t->cap, sizeof *t->idx, "block table"), done);
    for (size_t i = 0; i < t->cap; i++)
        t->idx[i] = -1;
    for (int64_t i = 0; i < cells; i++)
        h[i] = src->q[i];
    for (int a = 0; a < 3; a++)
        roll_axis(h, n, a, B, BH_BASE[a], line);
    for (int64_t index = 0; index < M; index++) { /* ascending: the lowest index stays */
        int64_t p[3];
        gs_field_block_position(src, B, index, p);
        int64_t at = p[0] + n[0] * (p[1] + n[1] * p[2]);
        size_t s = block_slot(t, h[at], src->q + at, n[0], n[0] * n[1]);
        if (t->idx[s] < 0)
            t->h[s] = h[at], t->idx[s] = index;
    }
done:
    gs_free(h);
    gs_free(line);
    return err;
}

static void block_table_free(block_table *t)
{
    gs_free(t->h);
    gs_free(t->idx);
    memset(t, 0, sizeof *t);
}

/* The lowest source block index holding exactly val, or -1. */
static int64_t block_table_find(const block_table *t, const uint8_t *val)
{
    return t->idx[block_slot(t, block_hash(val, t->B), val, t->B, (int64_t)t->B * t->B)];
}

gs_err gs_field_quality_measure_with(const gs_qfield *out, const gs_qfield *src, int B,
                                     gs_err (*match)(void *ctx, const gs_field_query *q,
                                                     gs_field_match *m),
                                     void *ctx, gs_field_quality *qm)
{
    memset(qm, 0, sizeof *qm);
    sign_stats(out, &qm->volume_fraction_out, &qm->surface_per_volume_out);
    sign_stats(src, &qm->volume_fraction_src, &qm->surface_per_volume_src);
    GS_CHECK(out->nx >= B && out->ny >= B && out->nz >= B, GS_ERR_ARG,
             "coherence with blocks of %d needs an output of at least %d^3", B, B);
    const int64_t nb[3] = {out->nx / B, out->ny / B, out->nz / B}, rows = nb[1] * nb[2];
    uint8_t *val = NULL, *sampled = NULL;
    uint64_t *order = NULL;
    block_table bt;
    memset(&bt, 0, sizeof bt);
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&val, (size_t)B * B * B, 1, "a quality block"), done);
    GS_TRY(err, gs_alloc_array((void **)&sampled, (size_t)rows, 1, "coherence rows"), done);
    GS_TRY(err, gs_alloc_array((void **)&order, (size_t)rows, sizeof *order, "coherence rows"), done);
    /* the rows of blocks along x searched for coherence: all of them up to
     * GS_FIELD_COHERENCE_BLOCKS blocks, else the first rows in the order of
     * a fixed hash of their number (a sample the same at any rank count) */
    int64_t keep = (GS_FIELD_COHERENCE_BLOCKS + nb[0] - 1) / nb[0];
    keep = keep > rows ? rows : keep;
    for (int64_t j = 0; j < rows; j++)
        order[j] = gs_hash_mix64((uint64_t)j + 1);
    gs_sort_u64(order, (size_t)rows);
    for (int64_t j = 0; j < rows; j++)
        sampled[j] = gs_hash_mix64((uint64_t)j + 1) <= order[keep - 1];
    GS_TRY(err, block_table_build(src, B, &bt), done);
    double sum = 0, sum2 = 0;
    int64_t cnt = 0, verb = 0, run = 0, prev[3] = {0, 0, 0};
    for (int64_t z = 0; z + B <= out->nz; z += B)
        for (int64_t y = 0; y + B <= out->ny; y += B)
            for (int64_t x = 0; x + B <= out->nx; x += B) {
                gs_qfield_block_at(out, B, (const int64_t[3]){x, y, z}, val);
                /* verbatim: exactly in the source (every block; the index
                 * is the lowest among equals, as the search's) */
                int64_t vi = block_table_find(&bt, val);
                if (sampled[y / B + nb[1] * (z / B)]) {
                    double d = 0; /* a verbatim block: distance 0, no search */
                    if (vi < 0) {
                        gs_field_query q = {B, val, NULL, 0};
                        gs_field_match m;
                        GS_TRY(err, match(ctx, &q, &m), done);
                        d = (double)m.dist / (double)m.known;
                    }
                    sum += d, sum2 += d * d;
                    cnt++;
                }
                if (vi >= 0) {
                    int64_t bp[3];
                    gs_field_block_position(src, B, vi, bp);
                    verb++;
                    /* the run continues when the source continues, too */
                    run = run > 0 && bp[0] == prev[0] + B && bp[1] == prev[1] && bp[2] == prev[2]
                              ? run + 1 : 1;
                    if (run > qm->longest_run)
                        qm->longest_run = run;
                    memcpy(prev, bp, sizeof prev);
                } else {
                    run = 0;
                }
                if (x + 2 * B > out->nx)
                    run = 0;
            }
    int64_t all = nb[0] * nb[1] * nb[2];
    qm->coherence = cnt ? sum / (double)cnt : 0;
    qm->verbatim = all ? (double)verb / (double)all : 0;
    qm->coherence_blocks = cnt;
    qm->coherence_grid_blocks = all;
    if (cnt > 1 && cnt < all) {
        double var = (sum2 - sum * sum / (double)cnt) / (double)(cnt - 1);
        qm->coherence_stderr =
            sqrt((var > 0 ? var : 0) / (double)cnt * (1 - (double)cnt / (double)all));
    }
done:
    block_table_free(&bt);
    gs_free(val);
    gs_free(sampled);
    gs_free(order);
    return err;
}
