/* Internal layout of the model engine (see include/geosynth/model.h).
 *
 * Label sets are bitsets of W = ceil(L/64) words. A region solver keeps one
 * set per region cell (its candidates C(M')), the region's face-neighbour
 * table (-1 where the neighbour is outside the region: either a fixed shell
 * cell, whose constraint is folded into the initial candidates, or outside
 * the output, which constrains nothing), and the propagation queue.
 */
#ifndef GEOSYNTH_MODEL_IMPL_H
#define GEOSYNTH_MODEL_IMPL_H

#include <stdint.h>

#include "geosynth/model.h"
#include "geosynth/rng.h"

struct gs_model_rules {
    int nlabels;            /* L = largest label + 1 */
    int words;              /* W */
    int npresent;           /* labels occurring in the example */
    uint64_t *allow;        /* [L][8][W]: labels allowed at v+e_d given label a at v (d: +-x, +-y, +-z, +-t) */
    uint64_t *present;      /* [W] */
    uint64_t *full_support; /* [8][W]: union of allow[a][d] over present a */
    uint64_t *count;        /* [L] occurrences */
};

static inline const uint64_t *gs_model_allow(const struct gs_model_rules *r, int a, int d)
{
    return r->allow + ((size_t)a * GS_MODEL_DIRS + (size_t)d) * (size_t)r->words;
}

/* Recompute full_support from allow and count, after the rules changed
 * (learned, read from pairs, symmetrized, turned). */
void gs_model_rules_rebuild_support(struct gs_model_rules *r);
/* Sorts n rows of `row` uint16 labels lexicographically (qsort; not reentrant):
 * the resemblance patterns (resemble.c) and the example's columns (rules.c). */
void gs_model_sort_rows(uint16_t *rows, size_t n, size_t row);

/* The patterns one choice counts over: the whole index, or (layers) one example layer's
 * patterns packed into their own bit positions, in the index's order (sorted by centre),
 * with that layer's multiplicities. The layer's slots hold only the (offset, label) pairs
 * that occur among its patterns, so a decided neighbour whose pair never occurs there adds
 * nothing; with 8 layers the candidates' match counts take about a quarter of the words
 * (castle.txt: 3-4 instead of 11 of 28), with the same counts, maximum and draw. */
struct gs_model_resem_view {
    int P, PW;
    const uint32_t *mult;   /* [P] */
    const uint16_t *center; /* [P] non-decreasing */
    const int32_t *range;   /* [L + 1] */
    const int32_t *slot;    /* [L + 1][Q] (row L: no label, none) */
    const uint64_t *bits;   /* [slots][PW] */
    const int32_t *oslot;   /* [Q] */
    void *mem;              /* the layer view's own allocation (NULL for all) */
};

/* Index of the example's neighbourhoods for resemblance (src/model/resemble.c). */
#define GS_MODEL_RESEM_MAX_B 8 /* counter bits (solver.c keeps 8 planes): counts are in
                                 half matches, 2Q < 2^8 */
struct gs_model_resem {
    int w, Q;          /* window radius, neighbours per window ((2w+1)^3 - 1) */
    int *off;          /* [Q][3] neighbour offsets */
    int P, PW;         /* distinct patterns, 64-bit words over them */
    uint32_t *mult;    /* [P] example locations with that pattern */
    uint16_t *center;  /* [P] centre label, non-decreasing */
    int L;             /* largest label + 1 */
    int32_t *range;    /* [L + 1] patterns with centre l: [range[l], range[l+1]) */
    int32_t *slot;     /* [L + 1][Q] bitset of (label, offset), -1 = none (row L: no label);
                          numbered label-major (resemble.c, number_slots) */
    uint64_t *bits;    /* [nslots][PW] */
    size_t nslots;
    int B;             /* bits of the match counters (<= GS_MODEL_RESEM_MAX_B) */
    int slack;         /* d0 - minimum distance */
    int nz, layers;    /* example layers; layers = 1: a cell at height z only draws
                          patterns found at example layer min(z, nz - 1) */
    uint32_t *zmult;   /* [nz][P] locations per layer (layers only) */
    uint64_t *zbits;   /* [nz][PW] patterns present in each layer */
    int32_t *oslot;    /* [Q] bitset (in bits) of the patterns with a cell past the
                          example's faces at q, -1 = none */
    int outside;       /* what such a cell scores against a decided neighbour, in half
                          matches: 0 (a mismatch), 1 (half), 2 (a match); a defined
                          equal label scores 2 */
    int outside_bg;    /* 1: such a cell scores a match against the example's background
                          label of the decided neighbour's layer (bg), else a mismatch */
    uint16_t *bg;      /* [nz] commonest label of the example's x/y faces at each layer */
    double freq_beta;  /* label-frequency constraint strength (0 = off) */
    float *zshare;     /* [nz][L] share of each label in each example layer (all layers
                          alike when layers = 0), with freq_beta */
    struct gs_model_resem_view all; /* every pattern (the arrays above) */
    struct gs_model_resem_view *lv; /* [nz] (layers only, else NULL): each layer's patterns
                                       alone, packed */
};


#define GS_MODEL_UCACHE_BITS 10 /* 1024 cached AC-3 unions (castle.txt: 90% of lookups hit) */
#define GS_MODEL_UCACHE_MAX_W 8 /* the cache up to 512 labels: 576 KiB at W = 8 */
/* Without utab, AC-3 revises a cell by the labels removed since its last
 * revision when they are fewer than 1 / GS_MODEL_AC_DELTA of its candidates
 * (fortress31 with 3x3x3 window labels: 1-4 all alike, 2.4 removed of 52) */
#define GS_MODEL_AC_DELTA 2
#define GS_MODEL_UTAB_MAX_W 2 /* AC-3 union table: 128 KiB at W = 1, 512 KiB at W = 2 */

struct gs_model_solver {
    const struct gs_model_rules *rules;
    gs_model_ac ac;
    int W, L;
    size_t cap;        /* cells allocated */
    size_t n;          /* cells of the current problem */
    uint64_t *dom;     /* [n][W] candidates */
    uint16_t *size;    /* [n] popcount of dom */
    int32_t *nbr;      /* [n][6] neighbour cell or -1 */
    int32_t *queue;    /* ring of n cells */
    uint8_t *inq;      /* [n] */
    size_t qhead, qlen;
    int ndirs;         /* directions with neighbours in the current problem (6 in 3D) */
    uint64_t *utab;    /* AC-3 unions (W <= GS_MODEL_UTAB_MAX_W, else NULL):
                          [8W byte positions][256 byte values][8][W], on cache-line
                          boundaries (a row at W = 1 is one line; utab_mem: the block) */
    uint64_t *ucache;  /* AC-3 unions of recent candidate sets (W <= GS_MODEL_UCACHE_MAX_W):
                          direct-mapped, [1 << GS_MODEL_UCACHE_BITS][8][W] unions (on line
                          boundaries) keyed by ukey [..][W], 72 KiB at W = 1; a key of zeros
                          is an empty entry (only sets of 2 or more candidates are looked up) */
    uint64_t *ukey;
    void *utab_mem, *ucache_mem;
    uint32_t *sp_off, *sp_mid; /* AC-3 unions without utab (W > GS_MODEL_UTAB_MAX_W): label a's
                          non-zero allow words are entries sp_off[a]..sp_off[a + 1] - 1
                          (sp_mid[a]: past the 3D directions' entries), each a position
                          sp_k (d W + w) in the union and a word sp_val */
    uint16_t *sp_k;
    uint64_t *sp_val;
    uint32_t *rv_off;  /* AC-3 reverse rows {a : b in allow[a][d]} by non-zero words:
                          entries rv_off[8 b + d] .. rv_off[8 b + d + 1] - 1, each a word
                          index rv_k and its word rv_val */
    uint16_t *rv_k;
    uint64_t *rv_val;
    int ac_delta;      /* GS_MODEL_AC_DELTA (tests: 0 = every revision a whole one) */
    int ucache_bits;   /* index bits in use, 1..GS_MODEL_UCACHE_BITS (tests use 1 to force
                          collisions) */
    uint64_t *pending; /* [n][W] labels removed but not yet propagated (AC-4; AC-3: since
                          the cell's last revision, non-zero only while it is queued) */
    uint16_t *support; /* AC-4: [n][6][L] support counts */
    size_t support_cap;
    /* cell order */
    uint64_t *heap;    /* min-heap of (size, tie, cell) keys (solver.c) */
    int32_t *hpos;     /* [n] ENTROPY: heap position of the cell's key, -1 = none */
    size_t heap_len, heap_cap;
    int heap_on;
    const uint16_t *pins;  /* params of the current region run */
    const float *shape;
    double shape_weight;
    const uint8_t *structure; /* params.structure */
    int shape_slack;
    int box_x0, box_y0, box_rx, box_ry, lat_nx; /* current box (shape lookup) */
    int mirror[3], mirror_odd[3];
    const int *mirror_map[3]; /* label symmetry per mirrored axis (NULL = identity) */
    const int *rotate_map; /* params.rotate_map: the quarter's rotation face */
    const uint64_t *ground, *ground_only; /* overlapping model ground rows (params) */
    const uint64_t *zface[2]; /* bottom / top layer label masks (params) */
    const uint64_t *xyface[4]; /* x0 / x1 / y0 / y1 face label masks (params) */
    const uint16_t *outside_col; /* params.outside_column (NULL = free) */
    int order_log;         /* ENTROPY_LOG buckets */
    uint32_t push_counter; /* ENTROPY_LOG fresh tie keys */
    uint32_t *tie;     /* [n] random tie-break keys */
    uint32_t *order;   /* [n] visit order (scan, random) */
    uint64_t *weights; /* [L] choice weights */
    gs_model_weights weights_kind;
    const struct gs_model_resem *resem; /* resemblance index (params), NULL = off */
    const void *ov;         /* current overlay (solver.c) and lattice for outside reads */
    const struct gs_model_lattice *lat;
    int box_z0, box_rz, periodic[3];
    uint64_t *rs_buf;       /* resemblance scratch: cand, mask, B counter slices */
    size_t rs_cap;
    uint32_t *fq_cnt;       /* label-frequency constraint: [box rz][L + 1] decided cells per
                               layer and label, then the layer's total (refreshed every
                               fq_every choices) */
    size_t fq_cap, fq_left, fq_every;
    int fq_on;              /* fq_exact is kept (with rs_on, a label-frequency weight) */
    uint32_t *fq_exact;     /* [box rz][L + 1]: fq_cnt's figures kept exact at every change
                               of a cell's count to or from 1 (rs_note), so a refresh is a
                               copy instead of a pass over the box */
    uint16_t *fq_state;     /* [n] the label fq_exact counts a box cell under, 0xffff = none */
    size_t fq_exact_cap, fq_state_cap;
    uint32_t *fq_stamp;     /* [L] choice at which freq_factors last computed a label's factor */
    uint32_t fq_gen;        /* choices with a label-frequency weight so far (fq_stamp's clock) */
    size_t fq_stamp_cap;
    int rs_on;              /* rs_lab is kept (a region try with resemblance) */
    uint16_t *rs_lab;       /* resemblance: labels of the box padded by the window radius,
                               box cells while decided (solver.c, resem_map_build) */
    int32_t *rs_pidx;       /* [n] a box cell's position in rs_lab */
    int32_t *rs_dq;         /* [Q] window offsets in rs_lab */
    int32_t *rs_bgq;        /* [rz][Q] face background a neighbour matches (outside = background) */
    size_t rs_lab_cap, rs_pidx_cap, rs_dq_cap, rs_bgq_cap;
    uint64_t revisions; /* statistics: cells processed by propagation */
    uint64_t backtracks_done; /* statistics: decisions undone */
    int32_t wipe_cell;    /* the cell the last wipe-out emptied (-1 = none; backjump) */
    /* chronological backtracking (AC-3 only): a cell's candidates are saved
     * on the trail the first time they change at a decision level */
    int trail_on;
    uint32_t level, level_counter;
    uint32_t *stamp;      /* [n] level at which the cell was last saved */
    int32_t *trail_cell;
    uint16_t *trail_size;
    uint64_t *trail_dom;  /* [trail_cap][W] */
    size_t trail_len, trail_cap;
    size_t trail_base;    /* entries dropped from the trail's front: a decision's mark
                             counts them, position mark - trail_base holds its entry */
    size_t trail_undo_left; /* undos left in the try's budget: decisions deeper than this
                               below the top are never undone, their entries are dropped
                               when the trail is full (solver.c, trail_compact) */
    struct gs_model_decision *dec;
    size_t ndec, dec_cap;
};

/* p rounded up to the next 64-byte (cache line) boundary: tables whose rows are read
 * whole are allocated 64 bytes longer and used from there. */
static inline void *gs_model_line_align(void *p)
{
    return (void *)(((uintptr_t)p + 63) & ~(uintptr_t)63);
}

struct gs_model_decision {
    int32_t cell;
    int label;
    size_t mark;     /* trail length before the decision (with trail_base) */
    uint32_t level;  /* level id of the decision */
    size_t pos;      /* position in the visit order (scan/random) */
};

/* Prepares the solver for a problem of n cells (grows buffers). */
gs_err gs_model_solver_reserve(struct gs_model_solver *s, size_t n);
/* Sets up an rx*ry*rz box problem with free outside (every neighbour outside
 * the box is -1) and all present labels as candidates. For tests and for
 * region setup, which then narrows dom/size. */
gs_err gs_model_solver_load_box(struct gs_model_solver *s, int rx, int ry, int rz);
/* Same with wrap[a] != 0: the box is periodic along axis a (the neighbour of
 * the last cell is the first one). */
gs_err gs_model_solver_load_box_wrap(struct gs_model_solver *s, int rx, int ry, int rz,
                                     const int wrap[3]);
/* Recomputes size[] from dom[]. Returns 0 if some cell is empty. */
int gs_model_solver_recount(struct gs_model_solver *s);
/* Establishes arc consistency from the current candidates with the
 * solver's algorithm. Returns 1 when consistent, 0 on a wipe-out. */
int gs_model_ac_establish(struct gs_model_solver *s);
/* Restricts cell c to label k and propagates. Returns 0 on a wipe-out. */
int gs_model_ac_assign(struct gs_model_solver *s, int32_t c, int k);
/* Test hook: the resemblance choice (paper Eqs. 4-6, params.resem) for cell c
 * of box b of lat, the cells around the box read from lat, the box cells'
 * candidates dom ([cells][W], x fastest; one candidate = decided), drawn
 * from rng: *label, -1 when no candidate label has a pattern. Without the
 * label-frequency weight (its counts live in a region try). */
gs_err gs_model_resem_choose_at(struct gs_model_solver *s, const gs_model_lattice *lat,
                                const gs_model_box *b, const gs_model_params *p,
                                const uint64_t *dom, int32_t c, gs_rng *rng, int *label);

/* Support inside a box: st holds the box's cells (x fastest), 1 non-empty, 0
 * empty. Every non-empty cell with a 6-connected path of non-empty box cells
 * to the ground layer (global z = 0) or to a cell next to the box for which
 * solid_at(ctx, x, y, z) is non-zero (lattice coordinates, x / y wrapped where
 * periodic) becomes 2. Returns how many became 2 (cells marked 1 stay 1:
 * floating), SIZE_MAX without memory. The solver's acceptance test and the
 * sweeps' keep test share it. */
size_t gs_model_box_support(uint8_t *st, const gs_model_box *b, const gs_model_lattice *lat,
                            const int periodic[3],
                            int (*solid_at)(const void *ctx, int x, int y, int z),
                            const void *ctx);

#endif
