/* Candidate sets C(M') by arc consistency (bitset AC-3 and support-count
 * AC-4) and the labelling of one region. See include/geosynth/model.h and
 * src/model/model_impl.h.
 *
 * AC-3 here works on cells, not arcs: a cell whose candidates shrank is
 * queued once; popping it ORs the transition sets of its remaining labels
 * into six support masks and intersects each neighbour with one of them.
 * With more than 128 labels (no union table) the transition sets are kept
 * by their non-zero words, and a cell that lost few labels since its last
 * revision is revised by those alone: only the neighbour labels they
 * supported are tested against its candidates (AC-3 with removals, as AC-4
 * without counts): the same removals, so the same queue, trail and heap.
 * AC-4 keeps, per (cell, direction, label), the number of neighbour labels
 * supporting it; a queued cell carries the bitset of labels removed since it
 * was last processed, and each removal decrements the counts it supported.
 * Both compute the same (unique) arc-consistent closure.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "model/model_impl.h"

#define GS_MODEL_RNG_DOMAIN 0x4d4f444cu /* "MODL" */
#define GS_MODEL_MH_DOMAIN 0x4d4f4d48u  /* "MOMH": the Metropolis step */

/* Without the popcnt instruction (x86-64 baseline) GCC calls libgcc's
 * __popcountdi2: 2% of a run; the same count inline. */
static inline int popcount64(uint64_t v)
{
#if defined(__x86_64__) && !defined(__POPCNT__)
    v = v - ((v >> 1) & 0x5555555555555555ull);
    v = (v & 0x3333333333333333ull) + ((v >> 2) & 0x3333333333333333ull);
    v = (v + (v >> 4)) & 0x0f0f0f0f0f0f0f0full;
    return (int)((v * 0x0101010101010101ull) >> 56);
#else
    return __builtin_popcountll(v);
#endif
}
static inline int ctz64(uint64_t v) { return __builtin_ctzll(v); }

/* The two hot loops (AC-3, the resemblance counts) also built for AVX2
 * machines, chosen at load time (GCC/Clang function multi-versioning on
 * x86-64 ELF): the popcount above becomes one instruction there and the
 * 4-word match counts one register wide. Integer code only: the same
 * results either way. */
#if defined(__x86_64__) && defined(__ELF__) && defined(__GNUC__) && !defined(__POPCNT__)
#define GS_HOT_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define GS_HOT_CLONES
#endif

/* The lowest label of a non-empty domain (the label of a decided cell). */
static inline int first_label(const uint64_t *dc)
{
    size_t w = 0;
    while (!dc[w])
        w++;
    return (int)(w * 64) + ctz64(dc[w]);
}

/* ---- buffers ----------------------------------------------------------------- */

static gs_err grow(void **p, size_t count, size_t size, const char *what)
{
    size_t bytes;
    GS_CHECK(gs_mul_size(count, size, &bytes), GS_ERR_MEM, "%s: size overflows", what);
    void *q = gs_realloc(*p, bytes ? bytes : 1);
    GS_CHECK(q != NULL, GS_ERR_MEM, "%s: cannot allocate %zu bytes", what, bytes);
    *p = q;
    return GS_OK;
}

gs_err gs_model_solver_reserve(struct gs_model_solver *s, size_t n)
{
    GS_CHECK(n < ((size_t)1 << 31), GS_ERR_ARG, "region of %zu cells: at most 2^31 supported", n);
    if (n > s->cap) {
        size_t W = (size_t)s->W;
        GS_CALL(grow((void **)&s->dom, n * W, 8, "region candidates"));
        GS_CALL(grow((void **)&s->pending, n * W, 8, "region removals"));
        GS_CALL(grow((void **)&s->size, n, sizeof *s->size, "region candidate counts"));
        GS_CALL(grow((void **)&s->nbr, n * GS_MODEL_DIRS, sizeof *s->nbr, "region neighbours"));
        GS_CALL(grow((void **)&s->queue, n, sizeof *s->queue, "propagation queue"));
        GS_CALL(grow((void **)&s->inq, n, 1, "propagation flags"));
        GS_CALL(grow((void **)&s->tie, n, sizeof *s->tie, "tie keys"));
        GS_CALL(grow((void **)&s->order, n, sizeof *s->order, "cell order"));
        GS_CALL(grow((void **)&s->stamp, n, sizeof *s->stamp, "trail stamps"));
        GS_CALL(grow((void **)&s->hpos, n, sizeof *s->hpos, "heap positions"));
        s->cap = n;
    }
    if (s->ac == GS_MODEL_AC4 && n > s->support_cap) {
        GS_CALL(grow((void **)&s->support, n * GS_MODEL_DIRS * (size_t)s->L, sizeof *s->support,
                     "AC-4 support counts"));
        s->support_cap = n;
    }
    s->n = n;
    return GS_OK;
}

/* Rows of nrows x len words as their non-zero words: row j's are entries
 * off[j] .. off[j + 1] - 1, each a position k in the row and its word val. */
static gs_err sparse_pack(const uint64_t *dense, size_t nrows, size_t len, uint32_t **off,
                          uint16_t **k, uint64_t **val)
{
    size_t nz = 0;
    for (size_t i = 0; i < nrows * len; i++)
        nz += dense[i] != 0;
    GS_CHECK(nz < UINT32_MAX && len <= 65536, GS_ERR_ARG, "AC-3 rows: too many labels");
    GS_CALL(gs_alloc_array((void **)off, nrows + 1, sizeof **off, "AC-3 sparse rows"));
    GS_CALL(gs_alloc_array((void **)k, nz ? nz : 1, sizeof **k, "AC-3 sparse rows"));
    GS_CALL(gs_alloc_array((void **)val, nz ? nz : 1, 8, "AC-3 sparse rows"));
    uint32_t e = 0;
    for (size_t j = 0; j < nrows; j++) {
        (*off)[j] = e;
        for (size_t i = 0; i < len; i++)
            if (dense[j * len + i]) {
                (*k)[e] = (uint16_t)i;
                (*val)[e++] = dense[j * len + i];
            }
    }
    (*off)[nrows] = e;
    return GS_OK;
}

/* AC-3 without the union table (more than 128 labels): the allow rows of
 * each label by their non-zero words (sp_*; sp_mid[a] is label a's first
 * entry past the six 3D directions), and the reverse rows {a : b in
 * allow[a][d]} per (b, d) (rv_*) for the revisions by removals. */
static gs_err sparse_build(struct gs_model_solver *s)
{
    const struct gs_model_rules *r = s->rules;
    const size_t W = (size_t)s->W, L = (size_t)s->L, D = GS_MODEL_DIRS;
    GS_CALL(sparse_pack(r->allow, L, D * W, &s->sp_off, &s->sp_k, &s->sp_val));
    GS_CALL(gs_alloc_array((void **)&s->sp_mid, L, sizeof *s->sp_mid, "AC-3 sparse rows"));
    for (size_t a = 0; a < L; a++) {
        uint32_t i = s->sp_off[a];
        while (i < s->sp_off[a + 1] && s->sp_k[i] < 6 * W)
            i++;
        s->sp_mid[a] = i;
    }
    uint64_t *tr = NULL;
    GS_CALL(gs_alloc_array((void **)&tr, L * D * W, 8, "AC-3 reverse rows"));
    memset(tr, 0, L * D * W * 8);
    for (size_t a = 0; a < L; a++)
        for (size_t d = 0; d < D; d++) {
            const uint64_t *al = gs_model_allow(r, (int)a, (int)d);
            for (size_t w = 0; w < W; w++)
                for (uint64_t bits = al[w]; bits; bits &= bits - 1) {
                    const size_t b = w * 64 + (size_t)ctz64(bits);
                    tr[(b * D + d) * W + a / 64] |= (uint64_t)1 << (a % 64);
                }
        }
    const gs_err err = sparse_pack(tr, L * D, W, &s->rv_off, &s->rv_k, &s->rv_val);
    gs_free(tr);
    return err;
}

gs_err gs_model_solver_create(const gs_model_rules_t rules, gs_model_ac ac, gs_model_solver_t *out)
{
    GS_CHECK(ac == GS_MODEL_AC3 || ac == GS_MODEL_AC4, GS_ERR_ARG,
             "arc consistency algorithm %d: expected 3 (AC-3) or 4 (AC-4)", (int)ac);
    GS_CHECK(rules->nlabels <= 65535, GS_ERR_ARG, "at most 65535 labels supported");
    struct gs_model_solver *s = gs_calloc(1, sizeof *s);
    GS_CHECK(s, GS_ERR_MEM, "model solver: cannot allocate");
    s->rules = rules;
    s->ac = ac;
    s->W = rules->words;
    s->L = rules->nlabels;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&s->weights, (size_t)s->L, 8, "label weights"), fail);
    s->ndirs = GS_MODEL_DIRS;
    s->ac_delta = GS_MODEL_AC_DELTA;
    if (s->W <= GS_MODEL_UTAB_MAX_W) {
        /* AC-3 support unions by bytes: row (byte position j, value v) = the
         * allow rows of every direction ORed over the labels 8j + (bits of v) */
        const size_t W = (size_t)s->W, row = GS_MODEL_DIRS * W, nchunk = 8 * W;
        GS_TRY(err, gs_alloc_array(&s->utab_mem, nchunk * 256 * row + 8, 8, "AC-3 union table"),
               fail);
        s->utab = gs_model_line_align(s->utab_mem);
        for (size_t j = 0; j < nchunk; j++) {
            uint64_t *t = s->utab + j * 256 * row;
            memset(t, 0, row * 8);
            for (unsigned v = 1; v < 256; v++) {
                const unsigned low = (unsigned)__builtin_ctz(v);
                const int a = (int)(8 * j + low);
                const uint64_t *prev = t + (size_t)(v & (v - 1)) * row;
                for (size_t k = 0; k < row; k++)
                    t[(size_t)v * row + k] =
                        prev[k] | (a < s->L ? gs_model_allow(rules, a, 0)[k] : 0);
            }
        }
    } else {
        GS_TRY(err, sparse_build(s), fail);
    }
    if (s->W <= GS_MODEL_UCACHE_MAX_W) {
        const size_t W = (size_t)s->W;
        const size_t ents = (size_t)1 << GS_MODEL_UCACHE_BITS;
        GS_TRY(err, gs_alloc_array(&s->ucache_mem, ents * (1 + GS_MODEL_DIRS) * W + 8, 8,
                                   "AC-3 union cache"),
               fail);
        s->ucache = gs_model_line_align(s->ucache_mem);
        s->ukey = s->ucache + ents * GS_MODEL_DIRS * W;
        memset(s->ukey, 0, ents * W * 8);
        s->ucache_bits = GS_MODEL_UCACHE_BITS;
    }
    *out = s;
    return GS_OK;
fail:
    gs_model_solver_destroy(&s);
    return err;
}

void gs_model_solver_destroy(gs_model_solver_t *ps)
{
    if (!ps || !*ps)
        return;
    struct gs_model_solver *s = *ps;
    gs_free(s->dom);
    gs_free(s->pending);
    gs_free(s->size);
    gs_free(s->nbr);
    gs_free(s->queue);
    gs_free(s->inq);
    gs_free(s->tie);
    gs_free(s->order);
    gs_free(s->support);
    gs_free(s->heap);
    gs_free(s->hpos);
    gs_free(s->utab_mem);
    gs_free(s->ucache_mem);
    gs_free(s->sp_off);
    gs_free(s->sp_mid);
    gs_free(s->sp_k);
    gs_free(s->sp_val);
    gs_free(s->rv_off);
    gs_free(s->rv_k);
    gs_free(s->rv_val);
    gs_free(s->weights);
    gs_free(s->stamp);
    gs_free(s->trail_cell);
    gs_free(s->trail_size);
    gs_free(s->trail_dom);
    gs_free(s->dec);
    gs_free(s->rs_buf);
    gs_free(s->fq_cnt);
    gs_free(s->fq_exact);
    gs_free(s->fq_state);
    gs_free(s->fq_stamp);
    gs_free(s->rs_lab);
    gs_free(s->rs_pidx);
    gs_free(s->rs_dq);
    gs_free(s->rs_bgq);
    gs_free(s);
    *ps = NULL;
}

gs_err gs_model_solver_load_box(struct gs_model_solver *s, int rx, int ry, int rz)
{
    static const int none[3] = {0, 0, 0};
    return gs_model_solver_load_box_wrap(s, rx, ry, rz, none);
}

/* fz > 0: the box's z holds frames of fz layers (4D), its first layer at
 * height z0 of the lattice: +z/-z stop at frame boundaries, +t/-t join the
 * cells fz layers apart. */
static gs_err load_box_frames(struct gs_model_solver *s, int rx, int ry, int rz, const int wrap[3],
                              int fz, int z0)
{
    size_t n = (size_t)rx * (size_t)ry * (size_t)rz;
    GS_CALL(gs_model_solver_reserve(s, n));
    const size_t W = (size_t)s->W;
    const uint64_t *present = s->rules->present;
    int32_t c = 0;
    for (int z = 0; z < rz; z++)
        for (int y = 0; y < ry; y++)
            for (int x = 0; x < rx; x++, c++) {
                int32_t *nb = s->nbr + (size_t)c * GS_MODEL_DIRS;
                nb[0] = x + 1 < rx ? c + 1 : (wrap[0] ? c - (rx - 1) : -1);
                nb[1] = x > 0 ? c - 1 : (wrap[0] ? c + (rx - 1) : -1);
                nb[2] = y + 1 < ry ? c + rx : (wrap[1] ? c - rx * (ry - 1) : -1);
                nb[3] = y > 0 ? c - rx : (wrap[1] ? c + rx * (ry - 1) : -1);
                nb[4] = z + 1 < rz ? c + rx * ry : (wrap[2] ? c - rx * ry * (rz - 1) : -1);
                nb[5] = z > 0 ? c - rx * ry : (wrap[2] ? c + rx * ry * (rz - 1) : -1);
                nb[6] = nb[7] = -1;
                if (fz > 0) {
                    if ((z0 + z + 1) % fz == 0)
                        nb[4] = -1; /* the next layer is the next frame's bottom */
                    if ((z0 + z) % fz == 0)
                        nb[5] = -1;
                    nb[6] = z + fz < rz ? c + rx * ry * fz : -1;
                    nb[7] = z >= fz ? c - rx * ry * fz : -1;
                }
                memcpy(s->dom + (size_t)c * W, present, W * 8);
                s->size[c] = (uint16_t)s->rules->npresent;
            }
    s->ndirs = fz > 0 ? GS_MODEL_DIRS : 6;
    s->rs_on = 0;
    s->fq_on = 0;
    memset(s->inq, 0, n);
    memset(s->pending, 0, n * W * 8);
    memset(s->stamp, 0, n * sizeof *s->stamp);
    s->trail_on = 0;
    s->level = s->level_counter = 1;
    s->trail_len = 0;
    s->trail_base = 0;
    s->ndec = 0;
    s->qhead = s->qlen = 0;
    s->heap_on = 0;
    s->heap_len = 0;
    return GS_OK;
}

gs_err gs_model_solver_load_box_wrap(struct gs_model_solver *s, int rx, int ry, int rz,
                                     const int wrap[3])
{
    return load_box_frames(s, rx, ry, rz, wrap, 0, 0);
}

int gs_model_solver_recount(struct gs_model_solver *s)
{
    const size_t W = (size_t)s->W;
    int ok = 1;
    for (size_t c = 0; c < s->n; c++) {
        int k = 0;
        for (size_t w = 0; w < W; w++)
            k += popcount64(s->dom[c * W + w]);
        s->size[c] = (uint16_t)k;
        ok &= k > 0;
    }
    return ok;
}

/* ---- min-heap of (candidate count, tie key, cell) ------------------------------------ */

/* The next cell is the undecided one with the smallest key (bucket, tie, cell).
 * ENTROPY keeps one entry per cell, re-keyed in place when its count changes
 * (hpos: its heap position, -1 = none): its key is a function of the cell's
 * count alone, so this returns the same cell as a heap of every key pushed
 * with the stale ones skipped, which castle.txt 40x40x10 popped 23 times per
 * choice (17% of a run). ENTROPY_LOG draws a fresh tie key per push, so its
 * heap keeps every push and skips stale entries when popping. Decided cells
 * stay in either heap until popped (and skipped). */

/* Heap bucket of a cell: its candidate count (ENTROPY) or the count's
 * binary order of magnitude (ENTROPY_LOG: cells with 2-3, 4-7, ...
 * candidates are equals, so ties are broken at random more often). */
static inline unsigned heap_bucket(const struct gs_model_solver *s, int32_t c)
{
    unsigned k = s->size[c];
    if (s->order_log)
        return 32u - (unsigned)__builtin_clz(k ? k : 1u);
    return k > 255 ? 255u : k;
}

static inline uint32_t mix32(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

/* The cell heap is 4-ary (children of i: 4i+1..4i+4): half the depth of a
 * binary heap for the sift-up of every revision (castle.ini: 1.02-1.31x the
 * binary heap's synthesis CPU). Keys end in the cell index, so the pops come
 * in key order whatever the heap's shape: the same outputs.
 * Moves key up from position i (indexed heap: keeps hpos). */
static inline void heap_sift_up(struct gs_model_solver *s, size_t i, uint64_t key, int indexed)
{
    while (i > 0) {
        size_t parent = (i - 1) / 4;
        if (s->heap[parent] <= key)
            break;
        s->heap[i] = s->heap[parent];
        if (indexed)
            s->hpos[(uint32_t)s->heap[i]] = (int32_t)i;
        i = parent;
    }
    s->heap[i] = key;
    if (indexed)
        s->hpos[(uint32_t)key] = (int32_t)i;
}

/* Moves key down from position i in a heap of n entries. */
static inline void heap_sift_down(struct gs_model_solver *s, size_t i, uint64_t key, int indexed)
{
    const size_t n = s->heap_len;
    for (;;) {
        size_t l = 4 * i + 1;
        if (l >= n)
            break;
        size_t m = l;
        const size_t e = l + 4 < n ? l + 4 : n;
        for (size_t k = l + 1; k < e; k++)
            if (s->heap[k] < s->heap[m])
                m = k;
        if (s->heap[m] >= key)
            break;
        s->heap[i] = s->heap[m];
        if (indexed)
            s->hpos[(uint32_t)s->heap[i]] = (int32_t)i;
        i = m;
    }
    s->heap[i] = key;
    if (indexed)
        s->hpos[(uint32_t)key] = (int32_t)i;
}

/* Records cell c's current count: ENTROPY re-keys its entry (or adds one),
 * ENTROPY_LOG pushes a new one. Returns 0 when the heap cannot grow. */
static int heap_push(struct gs_model_solver *s, int32_t c)
{
    const int indexed = !s->order_log;
    if (indexed && s->hpos[c] >= 0) {
        size_t i = (size_t)s->hpos[c];
        uint64_t old = s->heap[i];
        uint64_t key = ((uint64_t)heap_bucket(s, c) << 56) | (old & 0x00ffffffffffffffull);
        if (key < old)
            heap_sift_up(s, i, key, 1);
        else if (key > old)
            heap_sift_down(s, i, key, 1);
        return 1;
    }
    if (s->heap_len == s->heap_cap) {
        size_t ncap = s->heap_cap ? 2 * s->heap_cap : 1024;
        uint64_t *h = gs_realloc(s->heap, ncap * sizeof *h);
        if (!h)
            return 0;
        s->heap = h;
        s->heap_cap = ncap;
    }
    unsigned k = heap_bucket(s, c);
    /* ENTROPY_LOG draws a fresh tie key per push (deterministic: a hash of
     * the cell's random key and a push counter) */
    uint32_t tie = s->order_log ? mix32(s->tie[c] ^ (s->push_counter++ * 0x9e3779b9u)) : s->tie[c];
    uint64_t key = ((uint64_t)k << 56) | ((uint64_t)(tie & 0xffffffu) << 32) | (uint32_t)c;
    heap_sift_up(s, s->heap_len++, key, indexed);
    return 1;
}

static uint64_t heap_pop(struct gs_model_solver *s)
{
    const int indexed = !s->order_log;
    uint64_t top = s->heap[0];
    if (indexed)
        s->hpos[(uint32_t)top] = -1;
    uint64_t last = s->heap[--s->heap_len];
    if (s->heap_len)
        heap_sift_down(s, 0, last, indexed);
    return top;
}

/* ---- resemblance: decided labels ---------------------------------------------- */

/* rs_lab (see resem_map_build) holds a box cell's label while it is decided
 * (one candidate) and R->L (none) otherwise: every change of a box cell's
 * count to or from 1 goes through here while rs_on. */
static inline void rs_note(struct gs_model_solver *s, int32_t c)
{
    if (!s->rs_on)
        return;
    int l = s->size[c] == 1 ? first_label(s->dom + (size_t)c * (size_t)s->W) : s->resem->L;
    s->rs_lab[s->rs_pidx[c]] = (uint16_t)(l < s->resem->L ? l : s->resem->L);
    if (s->fq_on) { /* the decided cells per layer and label, exact */
        const uint16_t now = s->size[c] == 1 ? (uint16_t)l : 0xffffu, was = s->fq_state[c];
        if (now != was) {
            const size_t L1 = (size_t)s->L + 1;
            uint32_t *row = s->fq_exact + (size_t)(c / (s->box_rx * s->box_ry)) * L1;
            if (was != 0xffffu) {
                row[was]--;
                row[L1 - 1]--;
            }
            if (now != 0xffffu) {
                row[now]++;
                row[L1 - 1]++;
            }
            s->fq_state[c] = now;
        }
    }
}

/* ---- trail ------------------------------------------------------------------------- */

/* A full trail first drops the entries no undo can reach: with u undos
 * left in the budget, only the top u decisions can be undone (each undo
 * takes the top one), so the entries before the mark of decision ndec - u
 * are never read. Dropped when they are at least half the trail (castle.ini:
 * ~22 entries per decision, 1000 undos: the trail stays at ~32k entries
 * instead of growing to 128k, with the page faults and copies of the
 * growth). Returns 1 when room was made. */
static int trail_compact(struct gs_model_solver *s)
{
    const size_t left = s->trail_undo_left;
    if (s->ndec <= left)
        return 0;
    const size_t imin = s->ndec - left;
    const size_t keep = (imin < s->ndec ? s->dec[imin].mark : s->trail_base + s->trail_len) -
                        s->trail_base;
    if (keep < s->trail_len / 2)
        return 0;
    const size_t W = (size_t)s->W, rest = s->trail_len - keep;
    memmove(s->trail_cell, s->trail_cell + keep, rest * sizeof *s->trail_cell);
    memmove(s->trail_size, s->trail_size + keep, rest * sizeof *s->trail_size);
    memmove(s->trail_dom, s->trail_dom + keep * W, rest * W * 8);
    s->trail_len = rest;
    s->trail_base += keep;
    return 1;
}

/* Saves cell c's candidates before their first change at the current level.
 * Returns 0 when the trail cannot grow. */
static int trail_save(struct gs_model_solver *s, int32_t c)
{
    if (!s->trail_on || s->stamp[c] == s->level)
        return 1;
    const size_t W = (size_t)s->W;
    if (s->trail_len == s->trail_cap && !trail_compact(s)) {
        size_t ncap = s->trail_cap ? 2 * s->trail_cap : 4096;
        int32_t *tc = gs_realloc(s->trail_cell, ncap * sizeof *tc);
        if (!tc)
            return 0;
        s->trail_cell = tc;
        uint16_t *ts = gs_realloc(s->trail_size, ncap * sizeof *ts);
        if (!ts)
            return 0;
        s->trail_size = ts;
        uint64_t *td = gs_realloc(s->trail_dom, ncap * W * 8);
        if (!td)
            return 0;
        s->trail_dom = td;
        s->trail_cap = ncap;
    }
    size_t t = s->trail_len++;
    s->trail_cell[t] = c;
    s->trail_size[t] = s->size[c];
    memcpy(s->trail_dom + t * W, s->dom + (size_t)c * W, W * 8);
    s->stamp[c] = s->level;
    return 1;
}

static int heap_push(struct gs_model_solver *s, int32_t c);

/* Undoes every change recorded after mark (newest first). */
static int trail_restore(struct gs_model_solver *s, size_t mark)
{
    const size_t W = (size_t)s->W;
    if (mark < s->trail_base)
        return 0; /* dropped by trail_compact: cannot happen within the budget */
    mark -= s->trail_base;
    while (s->trail_len > mark) {
        size_t t = --s->trail_len;
        int32_t c = s->trail_cell[t];
        s->size[c] = s->trail_size[t];
        memcpy(s->dom + (size_t)c * W, s->trail_dom + t * W, W * 8);
        rs_note(s, c);
        if (s->heap_on && s->size[c] > 1 && !heap_push(s, c))
            return 0;
    }
    return 1;
}

/* ---- propagation ----------------------------------------------------------------- */

static inline void enqueue(struct gs_model_solver *s, int32_t c)
{
    if (s->inq[c])
        return;
    s->inq[c] = 1;
    size_t tail = s->qhead + s->qlen;
    if (tail >= s->n)
        tail -= s->n;
    s->queue[tail] = c;
    s->qlen++;
}

static inline int32_t dequeue(struct gs_model_solver *s)
{
    int32_t c = s->queue[s->qhead];
    if (++s->qhead == s->n)
        s->qhead = 0;
    s->qlen--;
    s->inq[c] = 0;
    return c;
}

/* Empties the queue after a wipe-out, with the queued cells' removals (a
 * stale removal would only widen a later revision by removals). */
static void queue_clear(struct gs_model_solver *s)
{
    const size_t W = (size_t)s->W;
    while (s->qlen)
        memset(s->pending + (size_t)dequeue(s) * W, 0, W * 8);
}

/* ORs into un (zeroed) the allow rows of the labels in dc, by their
 * non-zero words: the entries of label a up to end[a]. */
static inline __attribute__((always_inline)) void sparse_union(const struct gs_model_solver *s,
                                                               const uint64_t *dc, const size_t W,
                                                               const uint32_t *end, uint64_t *un)
{
    for (size_t w = 0; w < W; w++)
        for (uint64_t bits = dc[w]; bits; bits &= bits - 1) {
            const size_t a = w * 64 + (size_t)ctz64(bits);
            for (uint32_t i = s->sp_off[a], e = end[a]; i < e; i++)
                un[s->sp_k[i]] |= s->sp_val[i];
        }
}

/* ORs into un (zeroed) the allow rows of every direction of the labels in
 * dc, by bytes: a table row per (byte position, byte value), at most 8 W
 * rows instead of one per label (castle.txt: 23 candidates per revised cell). */
static inline __attribute__((always_inline)) void utab_union(const struct gs_model_solver *s,
                                                             const uint64_t *dc, const size_t W,
                                                             uint64_t *un)
{
    for (size_t w = 0; w < W; w++)
        for (uint64_t bits = dc[w]; bits;) {
            const unsigned j = (unsigned)ctz64(bits) >> 3;
            const uint64_t *row =
                s->utab + ((w * 8 + j) * 256 + ((bits >> (8 * j)) & 0xff)) * GS_MODEL_DIRS * W;
            bits &= ~((uint64_t)0xff << (8 * j));
            for (size_t k = 0; k < GS_MODEL_DIRS * W; k++)
                un[k] |= row[k];
        }
}

/* 1 when label b at the neighbour in direction d has a support among the
 * candidates dc: the reverse row {a : b in allow[a][d]} meets dc. */
static inline __attribute__((always_inline)) int has_support(const struct gs_model_solver *s,
                                                             const uint64_t *dc, size_t b, int d)
{
    const size_t j = b * GS_MODEL_DIRS + (size_t)d;
    for (uint32_t i = s->rv_off[j], e = s->rv_off[j + 1]; i < e; i++)
        if (dc[s->rv_k[i]] & s->rv_val[i])
            return 1;
    return 0;
}

/* Returns 0 on a wipe-out (queue cleared), 1 when the queue drained. */
/* Bitset AC-3 over the queue. W (64-bit words per domain) is a parameter so
 * that ac3_run() can instantiate it with constant W = 1..4 and 8: the example
 * lattices have at most a few hundred labels, and with a constant word
 * count the support accumulation unrolls (castle.txt, 1 word: 1.6x faster
 * in bench_model). sparse (constant): no union table, the unions from the
 * sparse rows and the revisions by removals (pending, then rem).
 * Why revising by removals gives the same closure: after a cell c's
 * revision every label of a neighbour u has a support among c's candidates
 * D; labels c loses later go to pending(c), so each label of u keeps a
 * support in D + pending(c) until c's next revision. A label of u outside
 * the union of pending(c)'s rows therefore has one in D, and only the labels
 * inside it need the test. The first revision after establish (pending = all
 * ones) and a restore (which returns to a drained queue) keep this true. */
static inline __attribute__((always_inline)) int ac3_run_words(struct gs_model_solver *s,
                                                               const size_t W, const int sparse)
{
    const struct gs_model_rules *r = s->rules;
    uint64_t sup[(GS_MODEL_DIRS + 1) * 8];
    uint64_t *big = NULL; /* only for more than 512 labels */
    uint64_t *acc = sup;
    if (W > 8) {
        big = gs_malloc((GS_MODEL_DIRS + 1) * W * 8);
        if (!big)
            return 0;
        acc = big;
    }
    uint64_t *rem = acc + GS_MODEL_DIRS * W; /* [W] a revised cell's removals */
    /* removals are kept (pending) only without the union table (sparse): with
     * it a whole revision takes at most 8 W table rows */
    const int track = sparse;
    int ok = 1;
    /* directions with neighbours: 6 in 3D, 8 with time or a rotation face */
    const size_t nd = (size_t)s->ndirs;
    while (s->qlen) {
        int32_t c = dequeue(s);
        s->revisions++;
        if (s->heap_on && s->size[c] > 1 && !heap_push(s, c)) {
            ok = 0;
            break;
        }
        const uint64_t *dc = s->dom + (size_t)c * W;
        int nrem = 0;
        if (track) {
            uint64_t *pc = s->pending + (size_t)c * W;
            for (size_t w = 0; w < W; w++) {
                rem[w] = pc[w];
                nrem += popcount64(pc[w]);
                pc[w] = 0;
            }
        }
        const uint64_t *use;
        int delta = 0;
        if (s->size[c] == r->npresent) {
            use = r->full_support;
        } else if (s->size[c] == 1) { /* a decided cell: its label's rows as they are */
            use = gs_model_allow(r, first_label(dc), 0);
        } else if (track && s->ac_delta > 0 && nrem * s->ac_delta < s->size[c]) {
            /* few labels removed since c's last revision: only the neighbour
             * labels they supported can have lost their support; the union
             * of the removed labels' rows names them, and each is tested
             * against c's candidates (its reverse row, by non-zero words) */
            memset(acc, 0, nd * W * 8);
            sparse_union(s, rem, W, nd == 6 ? s->sp_mid : s->sp_off + 1, acc);
            use = acc;
            delta = 1;
        } else if (s->ucache) {
            /* Unions of recent sets are cached (a pure function of the set;
             * castle.txt: 90% of the revisions find theirs) */
            uint64_t h = dc[0];
            for (size_t w = 1; w < W; w++)
                h = h * 0x100000001b3ull ^ dc[w];
            h *= 0x9e3779b97f4a7c15ull;
            const size_t e = (size_t)(h >> (64 - s->ucache_bits));
            uint64_t *ent = s->ukey + e * W, *un = s->ucache + e * GS_MODEL_DIRS * W;
            uint64_t miss = 0;
            for (size_t w = 0; w < W; w++)
                miss |= ent[w] ^ dc[w];
            if (miss) {
                memcpy(ent, dc, W * 8);
                memset(un, 0, GS_MODEL_DIRS * W * 8);
                if (!sparse)
                    utab_union(s, dc, W, un);
                else /* every direction: the entry serves 3D and 4D boxes */
                    sparse_union(s, dc, W, s->sp_off + 1, un);
            }
            use = un;
        } else { /* more labels than the cache takes */
            memset(acc, 0, nd * W * 8);
            sparse_union(s, dc, W, nd == 6 ? s->sp_mid : s->sp_off + 1, acc);
            use = acc;
        }
        const int32_t *nb = s->nbr + (size_t)c * GS_MODEL_DIRS;
        for (int d = 0; d < (int)nd; d++) {
            int32_t u = nb[d];
            if (u < 0 || s->size[u] == 0)
                continue;
            uint64_t *du = s->dom + (size_t)u * W;
            const uint64_t *sd = use + (size_t)d * W;
            uint64_t *rm = acc + (size_t)d * W; /* d's union is not read again */
            uint64_t diff = 0;
            if (delta) {
                for (size_t w = 0; w < W; w++) {
                    uint64_t out = 0;
                    for (uint64_t bits = du[w] & sd[w]; bits; bits &= bits - 1)
                        if (!has_support(s, dc, w * 64 + (size_t)ctz64(bits), d))
                            out |= bits & -bits;
                    rm[w] = out;
                    diff |= out;
                }
            } else {
                for (size_t w = 0; w < W; w++)
                    diff |= du[w] & ~sd[w];
            }
            if (!diff)
                continue;
            if (!trail_save(s, u)) {
                ok = 0;
                goto out;
            }
            int k = 0;
            uint64_t *pu = s->pending + (size_t)u * W;
            for (size_t w = 0; w < W; w++) {
                const uint64_t out = delta ? rm[w] : du[w] & ~sd[w];
                du[w] &= ~out;
                if (track)
                    pu[w] |= out;
                k += popcount64(du[w]);
            }
            s->size[u] = (uint16_t)k;
            if (k <= 1) {
                if (k == 0) {
                    if (track)
                        memset(pu, 0, W * 8);
                    s->wipe_cell = u;
                    ok = 0;
                    goto out;
                }
                rs_note(s, u);
            }
            enqueue(s, u);
        }
    }
out:
    if (!ok)
        queue_clear(s);
    gs_free(big);
    return ok;
}

GS_HOT_CLONES static int ac3_run(struct gs_model_solver *s)
{
    if (s->utab) /* W <= GS_MODEL_UTAB_MAX_W */
        return s->W == 1 ? ac3_run_words(s, 1, 0) : ac3_run_words(s, 2, 0);
    switch (s->W) {
    case 3: return ac3_run_words(s, 3, 1);
    case 4: return ac3_run_words(s, 4, 1);
    case 8: return ac3_run_words(s, 8, 1);
    default: return ac3_run_words(s, (size_t)s->W, 1);
    }
}

static int ac4_run(struct gs_model_solver *s)
{
    const struct gs_model_rules *r = s->rules;
    const size_t W = (size_t)s->W, L = (size_t)s->L;
    uint64_t rem_small[4];
    uint64_t *rem = W <= 4 ? rem_small : gs_malloc(W * 8);
    if (!rem)
        return 0;
    int ok = 1;
    while (s->qlen) {
        int32_t c = dequeue(s);
        s->revisions++;
        if (s->heap_on && s->size[c] > 1 && !heap_push(s, c)) {
            ok = 0;
            break;
        }
        uint64_t *pc = s->pending + (size_t)c * W;
        memcpy(rem, pc, W * 8);
        memset(pc, 0, W * 8);
        const int32_t *nb = s->nbr + (size_t)c * GS_MODEL_DIRS;
        for (int d = 0; d < GS_MODEL_DIRS; d++) {
            int32_t u = nb[d];
            if (u < 0)
                continue;
            uint16_t *cnt = s->support + ((size_t)u * GS_MODEL_DIRS + (size_t)(d ^ 1)) * L;
            uint64_t *du = s->dom + (size_t)u * W;
            uint64_t *pu = s->pending + (size_t)u * W;
            for (size_t w = 0; w < W; w++)
                for (uint64_t bits = rem[w]; bits; bits &= bits - 1) {
                    int a = (int)(w * 64) + ctz64(bits);
                    const uint64_t *al = gs_model_allow(r, a, d);
                    for (size_t v = 0; v < W; v++)
                        for (uint64_t m = al[v] & du[v]; m; m &= m - 1) {
                            int b = (int)(v * 64) + ctz64(m);
                            if (--cnt[b] == 0) {
                                uint64_t bit = (uint64_t)1 << (b & 63);
                                du[v] &= ~bit;
                                pu[v] |= bit;
                                if (--s->size[u] == 0) {
                                    ok = 0;
                                    goto out;
                                }
                                if (s->size[u] == 1)
                                    rs_note(s, u);
                                enqueue(s, u);
                            }
                        }
                }
        }
    }
out:
    if (!ok)
        queue_clear(s);
    if (rem != rem_small)
        gs_free(rem);
    return ok;
}

int gs_model_ac_establish(struct gs_model_solver *s)
{
    const size_t W = (size_t)s->W, L = (size_t)s->L, n = s->n;
    for (size_t c = 0; c < n; c++)
        if (s->size[c] == 0)
            return 0;
    if (s->ac == GS_MODEL_AC3) {
        /* every label "removed": each cell's first revision is a whole one */
        memset(s->pending, 0xff, n * W * 8);
        for (size_t c = 0; c < n; c++)
            enqueue(s, (int32_t)c);
        return ac3_run(s);
    }
    /* AC-4: counts against the current candidates first, then remove the
     * unsupported labels and propagate those removals. */
    const struct gs_model_rules *r = s->rules;
    for (size_t c = 0; c < n; c++) {
        const int32_t *nb = s->nbr + c * GS_MODEL_DIRS;
        const uint64_t *dc = s->dom + c * W;
        uint64_t *pc = s->pending + c * W;
        for (int d = 0; d < GS_MODEL_DIRS; d++) {
            int32_t u = nb[d];
            if (u < 0)
                continue;
            const uint64_t *du = s->dom + (size_t)u * W;
            uint16_t *cnt = s->support + (c * GS_MODEL_DIRS + (size_t)d) * L;
            for (size_t w = 0; w < W; w++)
                for (uint64_t bits = dc[w]; bits; bits &= bits - 1) {
                    int b = (int)(w * 64) + ctz64(bits);
                    const uint64_t *al = gs_model_allow(r, b, d);
                    int k = 0;
                    for (size_t v = 0; v < W; v++)
                        k += popcount64(al[v] & du[v]);
                    cnt[b] = (uint16_t)k;
                    if (k == 0)
                        pc[w] |= (uint64_t)1 << (b & 63);
                }
        }
    }
    for (size_t c = 0; c < n; c++) {
        uint64_t *dc = s->dom + c * W, *pc = s->pending + c * W;
        int any = 0, k = 0;
        for (size_t w = 0; w < W; w++) {
            any |= pc[w] != 0;
            dc[w] &= ~pc[w];
            k += popcount64(dc[w]);
        }
        if (!any)
            continue;
        s->size[c] = (uint16_t)k;
        if (k == 0) {
            queue_clear(s);
            return 0;
        }
        if (k == 1)
            rs_note(s, (int32_t)c);
        enqueue(s, (int32_t)c);
    }
    return ac4_run(s);
}

int gs_model_ac_assign(struct gs_model_solver *s, int32_t c, int k)
{
    const size_t W = (size_t)s->W;
    uint64_t *dc = s->dom + (size_t)c * W;
    if (!trail_save(s, c))
        return 0;
    if (s->ac == GS_MODEL_AC4) {
        uint64_t *pc = s->pending + (size_t)c * W;
        for (size_t w = 0; w < W; w++)
            pc[w] |= dc[w];
        pc[k >> 6] &= ~((uint64_t)1 << (k & 63));
    }
    memset(dc, 0, W * 8);
    dc[k >> 6] = (uint64_t)1 << (k & 63);
    s->size[c] = 1;
    rs_note(s, c);
    enqueue(s, c);
    return s->ac == GS_MODEL_AC4 ? ac4_run(s) : ac3_run(s);
}

/* Removes label k from cell c (a refuted decision) and propagates (AC-3). */
static int ac_refute(struct gs_model_solver *s, int32_t c, int k)
{
    const size_t W = (size_t)s->W;
    if (!trail_save(s, c))
        return 0;
    s->dom[(size_t)c * W + (size_t)(k >> 6)] &= ~((uint64_t)1 << (k & 63));
    if (--s->size[c] == 0) {
        s->wipe_cell = c;
        return 0;
    }
    s->pending[(size_t)c * W + (size_t)(k >> 6)] |= (uint64_t)1 << (k & 63);
    if (s->size[c] == 1)
        rs_note(s, c);
    enqueue(s, c);
    return ac3_run(s);
}

/* model.backjump R: which decision a wipe-out refutes. Chronological
 * backtracking refutes the latest one; when the emptied cell lies farther
 * than R cells (each axis) from it, the cause is mostly an older decision
 * next to that cell (a wall run that cannot close inside pinned faces), and
 * refuting the later, unrelated decisions one by one used up the undo budget
 * (castle-yards.ini: new tries, configs/model/DEFAULTS.md). Returns how many
 * decisions stay on the stack with the one to refute on top: the latest
 * within R of the emptied cell (the later ones are undone unrefuted and
 * decided again), or the latest when none of those the trail can still undo
 * (trail_compact keeps the undo budget's) is near. */
static size_t backjump_to(const struct gs_model_solver *s, int R)
{
    const int32_t w = s->wipe_cell, rx = s->box_rx, rxy = s->box_rx * s->box_ry;
    if (R <= 0 || w < 0)
        return s->ndec;
    const int wx = w % rx, wy = (w / rx) % s->box_ry, wz = w / rxy;
    for (size_t j = s->ndec; j > 0 && s->dec[j - 1].mark >= s->trail_base; j--) {
        const int32_t c = s->dec[j - 1].cell;
        const int cx = c % rx, cy = (c / rx) % s->box_ry, cz = c / rxy;
        if (abs(cx - wx) <= R && abs(cy - wy) <= R && abs(cz - wz) <= R)
            return j;
    }
    return s->ndec;
}

/* ---- one region ------------------------------------------------------------------- */

/* Candidates of the region's cells: present labels narrowed by the fixed
 * shell cells (labels of lat just outside the box, inside the output). */
/* Labels inside the overlay box ob come from obuf (x fastest within ob), the
 * others from lat: a sub-box of a region sees its siblings' new labels. */
typedef struct overlay {
    const gs_model_box *ob;
    const uint16_t *obuf;
} overlay;

static inline int overlay_label(const gs_model_lattice *lat, const overlay *ov, int x, int y, int z)
{
    const gs_model_box *o = ov ? ov->ob : NULL;
    if (o && x >= o->x0 && x < o->x1 && y >= o->y0 && y < o->y1 && z >= o->z0 && z < o->z1)
        return ov->obuf[(size_t)(x - o->x0) +
                        (size_t)(o->x1 - o->x0) *
                            ((size_t)(y - o->y0) + (size_t)(o->y1 - o->y0) * (size_t)(z - o->z0))];
    return lat->labels[gs_model_lattice_index(lat, x, y, z)];
}

/* ---- resemblance neighbourhoods ---------------------------------------------- */

/* rs_lab: the labels around the box, padded by the window radius w on every
 * side (x fastest): a cell outside the box holds its fixed label (the shell,
 * from lat overlaid with ov, wrapped along periodic axes; R->L = none outside
 * the output), a box cell its label while decided (rs_note). rs_pidx: a box
 * cell's position in it, rs_dq the window's offsets, rs_bgq[z][q] the face
 * background a neighbour at q of a cell at box height z matches (outside =
 * background; -1 = none, below the output: never equal to a label or to
 * R->L). A neighbourhood read is one load per offset,
 * with no bounds test or branch. */
static gs_err resem_map_build(struct gs_model_solver *s, const gs_model_lattice *lat,
                              const overlay *ov, const gs_model_box *b, const int periodic[3])
{
    const struct gs_model_resem *R = s->resem;
    const int w = R->w, rx = b->x1 - b->x0, ry = b->y1 - b->y0, rz = b->z1 - b->z0;
    const int px = rx + 2 * w, py = ry + 2 * w, pz = rz + 2 * w;
    const size_t n = (size_t)px * (size_t)py * (size_t)pz, nb = (size_t)rx * (size_t)ry * (size_t)rz;
    const size_t nq = (size_t)R->Q * (size_t)rz;
    if (n > s->rs_lab_cap) {
        GS_CALL(grow((void **)&s->rs_lab, n, sizeof *s->rs_lab, "resemblance neighbourhood labels"));
        s->rs_lab_cap = n;
    }
    if (nb > s->rs_pidx_cap) {
        GS_CALL(grow((void **)&s->rs_pidx, nb, sizeof *s->rs_pidx, "resemblance cell positions"));
        s->rs_pidx_cap = nb;
    }
    if ((size_t)R->Q > s->rs_dq_cap) {
        GS_CALL(grow((void **)&s->rs_dq, (size_t)R->Q, sizeof *s->rs_dq, "resemblance offsets"));
        s->rs_dq_cap = (size_t)R->Q;
    }
    if (nq > s->rs_bgq_cap) {
        GS_CALL(grow((void **)&s->rs_bgq, nq, sizeof *s->rs_bgq, "resemblance backgrounds"));
        s->rs_bgq_cap = nq;
    }
    for (int q = 0; q < R->Q; q++) {
        const int *o = R->off + 3 * q;
        s->rs_dq[q] = o[0] + px * (o[1] + py * o[2]);
        for (int z = 0; z < rz; z++) {
            /* the neighbour's layer, as the example's (its top one above it) */
            const int zb = b->z0 + z + o[2] < R->nz ? b->z0 + z + o[2] : R->nz - 1;
            s->rs_bgq[(size_t)z * (size_t)R->Q + (size_t)q] = zb >= 0 ? R->bg[zb] : -1;
        }
    }
    const int gn[3] = {lat->nx, lat->ny, lat->nz};
    size_t i = 0;
    for (int z = -w; z < rz + w; z++)
        for (int y = -w; y < ry + w; y++)
            for (int x = -w; x < rx + w; x++, i++) {
                if (x >= 0 && y >= 0 && z >= 0 && x < rx && y < ry && z < rz) {
                    s->rs_pidx[x + rx * (y + ry * z)] = (int32_t)i;
                    s->rs_lab[i] = (uint16_t)R->L;
                    continue;
                }
                int g[3] = {b->x0 + x, b->y0 + y, b->z0 + z};
                int out = 0;
                for (int a = 0; a < 3; a++) {
                    if (periodic[a])
                        g[a] = (g[a] % gn[a] + gn[a]) % gn[a];
                    out |= g[a] < 0 || g[a] >= gn[a];
                }
                int label = out ? R->L : overlay_label(lat, ov, g[0], g[1], g[2]);
                s->rs_lab[i] = (uint16_t)(label < R->L ? label : R->L);
            }
    return GS_OK;
}

static gs_err setup_region(struct gs_model_solver *s, const gs_model_lattice *lat,
                           const overlay *ov, const gs_model_box *b, const int periodic[3],
                           int *ok)
{
    const int rx = b->x1 - b->x0, ry = b->y1 - b->y0, rz = b->z1 - b->z0;
    /* a region spanning a whole periodic axis wraps onto itself */
    const int wrap[3] = {periodic[0] && rx == lat->nx, periodic[1] && ry == lat->ny,
                         periodic[2] && rz == lat->nz};
    const int fz = lat->frames > 1 ? gs_model_frame_nz(lat) : 0;
    GS_CALL(load_box_frames(s, rx, ry, rz, wrap, fz, b->z0));
    /* mirror faces: the +a neighbour of a cell on the lattice's upper face
     * is its own mirror image S(l) (even full extent: (l, S l) must be
     * allowed along +a) or, odd, the face is the shared centre (S l = l; its
     * neighbour S(cell below) is then implied by the S-symmetric rules) */
    const int bhi[3] = {b->x1 == lat->nx, b->y1 == lat->ny, b->z1 == lat->nz};
    const int ext[3] = {rx, ry, rz}, stride[3] = {1, rx, rx * ry};
    for (int a = 0; a < 3; a++) {
        if (!s->mirror[a] || !bhi[a] || wrap[a])
            continue;
        const int *S = s->mirror_map[a];
        for (int32_t c = 0; c < (int32_t)s->n; c++) {
            if ((c / stride[a]) % ext[a] != ext[a] - 1)
                continue;
            uint64_t *dc = s->dom + (size_t)c * (size_t)s->W;
            for (int l = 0; l < s->L; l++) {
                if (!((dc[l >> 6] >> (l & 63)) & 1))
                    continue;
                int sl = S ? S[l] : l;
                int keep = s->mirror_odd[a]
                               ? sl == l
                               : sl >= 0 && ((gs_model_allow(s->rules, l, 2 * a)[sl >> 6] >> (sl & 63)) & 1);
                if (!keep)
                    dc[l >> 6] &= ~((uint64_t)1 << (l & 63));
            }
        }
    }
    if (s->rotate_map && fz == 0 && rx == lat->nx && ry == lat->ny && rx == ry) {
        /* rotation face: beyond (h-1, y) lies the turned image of (y, h-1),
         * joined along direction 6 (the partner along 7); the corner
         * (h-1, h-1) is its own partner: it keeps labels a with R a allowed
         * at +x of a */
        s->ndirs = GS_MODEL_DIRS;
        for (int z = 0; z < rz; z++)
            for (int y = 0; y < ry; y++) {
                const int32_t c1 = (int32_t)(rx - 1 + rx * (y + ry * z));
                const int32_t c2 = (int32_t)(y + rx * (ry - 1 + ry * z));
                if (c1 != c2) {
                    s->nbr[(size_t)c1 * GS_MODEL_DIRS + 6] = c2;
                    s->nbr[(size_t)c2 * GS_MODEL_DIRS + 7] = c1;
                    continue;
                }
                uint64_t *dc = s->dom + (size_t)c1 * (size_t)s->W;
                for (int l = 0; l < s->L; l++)
                    if (((dc[l >> 6] >> (l & 63)) & 1) &&
                        !((gs_model_allow(s->rules, l, 6)[l >> 6] >> (l & 63)) & 1))
                        dc[l >> 6] &= ~((uint64_t)1 << (l & 63));
            }
    }
    if (s->ground || s->ground_only)
        for (int32_t c = 0; c < (int32_t)s->n; c++) {
            /* ground: the last row holds ground patterns, the others none of
             * the patterns found only there */
            uint64_t *dc = s->dom + (size_t)c * (size_t)s->W;
            int bottom = b->y0 + (c / rx) % ry == lat->ny - 1;
            for (int w = 0; w < s->W; w++) {
                if (bottom && s->ground)
                    dc[w] &= s->ground[w];
                else if (!bottom && s->ground_only)
                    dc[w] &= ~s->ground_only[w];
            }
        }
    for (int f = 0; f < 2; f++) {
        /* synthesized z faces: the example's own bottom / top labels only
         * (4D: the bottom and top of every frame) */
        const int fh = gs_model_frame_nz(lat);
        for (int t = 0; s->zface[f] && t < (lat->frames > 1 ? lat->frames : 1); t++) {
            const int zf = t * fh + (f ? fh - 1 : 0);
            if (zf < b->z0 || zf >= b->z1)
                continue;
            const int32_t layer = rx * ry, c0 = (int32_t)(zf - b->z0) * layer;
            for (int32_t c = c0; c < c0 + layer; c++)
                for (int w = 0; w < s->W; w++)
                    s->dom[(size_t)c * (size_t)s->W + (size_t)w] &= s->zface[f][w];
        }
    }
    if (s->xyface[0])
        /* model.fix_xy_faces: the output's x/y face cells keep to the example's own
         * face labels (each cell: every face it lies on) */
        for (int32_t c = 0; c < (int32_t)s->n; c++) {
            const int gx = b->x0 + c % rx, gy = b->y0 + (c / rx) % ry;
            const int on[4] = {gx == 0, gx == lat->nx - 1, gy == 0, gy == lat->ny - 1};
            uint64_t *dc = s->dom + (size_t)c * (size_t)s->W;
            for (int f = 0; f < 4; f++)
                for (int w = 0; on[f] && w < s->W; w++)
                    dc[w] &= s->xyface[f][w];
        }
    const uint16_t *pins = s->pins;
    s->box_x0 = b->x0;
    s->box_y0 = b->y0;
    s->box_rx = rx;
    s->box_ry = ry;
    s->lat_nx = lat->nx;
    s->box_z0 = b->z0;
    s->box_rz = rz;
    s->lat = lat;
    s->ov = ov;
    for (int a = 0; a < 3; a++)
        s->periodic[a] = periodic[a];
    if (s->resem)
        GS_CALL(resem_map_build(s, lat, ov, b, periodic));
    const struct gs_model_rules *r = s->rules;
    const size_t W = (size_t)s->W;
    static const int step[GS_MODEL_DIRS][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1},
                                               {0, 0}, {0, 0}, {0, 0}, {0, 0}};
    int32_t c = 0;
    *ok = 1;
    for (int z = 0; z < rz; z++)
        for (int y = 0; y < ry; y++)
            for (int x = 0; x < rx; x++, c++) {
                uint64_t *dc = s->dom + (size_t)c * W;
                if (pins) {
                    uint16_t pin = pins[gs_model_lattice_index(lat, b->x0 + x, b->y0 + y, b->z0 + z)];
                    if (pin != GS_MODEL_FREE) {
                        for (size_t w = 0; w < W; w++)
                            dc[w] = (pin >> 6) == (int)w ? dc[w] & ((uint64_t)1 << (pin & 63)) : 0;
                    }
                }
                if (x > 0 && x + 1 < rx && y > 0 && y + 1 < ry && z > 0 && z + 1 < rz &&
                    (fz == 0 || (z >= fz && z + fz < rz)))
                    continue; /* interior: jump handled by the loop cheaply enough */
                const int32_t *nb = s->nbr + (size_t)c * GS_MODEL_DIRS;
                for (int d = 0; d < GS_MODEL_DIRS; d++) {
                    if (nb[d] >= 0)
                        continue;
                    if (d >= 6 && fz == 0)
                        break; /* a 3D lattice has no time neighbours */
                    if (fz > 0 && (d >> 1) >= 2 && gs_model_step_z(lat, b->z0 + z, d) < 0)
                        continue; /* another frame along z, or no frame along t: free */
                    int qx = b->x0 + x + step[d][0], qy = b->y0 + y + step[d][1],
                        qz = b->z0 + z + (d == 4) - (d == 5) + (d == 6 ? fz : d == 7 ? -fz : 0);
                    if ((s->mirror[0] && qx == lat->nx) || (s->mirror[1] && qy == lat->ny) ||
                        (s->mirror[2] && qz == lat->nz))
                        continue; /* beyond a mirror face: the face mask above */
                    if (periodic[0])
                        qx = (qx + lat->nx) % lat->nx;
                    if (periodic[1])
                        qy = (qy + lat->ny) % lat->ny;
                    if (periodic[2])
                        qz = (qz + lat->nz) % lat->nz;
                    if (qz < 0 || qz >= lat->nz)
                        continue; /* below or above the output: free */
                    int m;
                    if (qx < 0 || qy < 0 || qx >= lat->nx || qy >= lat->ny) {
                        if (!s->outside_col)
                            continue; /* past the output's sides: free */
                        m = s->outside_col[qz]; /* past them: the start column */
                    } else {
                        m = overlay_label(lat, ov, qx, qy, qz);
                    }
                    if (m >= s->L) {
                        for (size_t w = 0; w < W; w++)
                            dc[w] = 0;
                        continue;
                    }
                    /* label a at p needs m at p+e_d: a in allow[m][opposite d] */
                    const uint64_t *al = gs_model_allow(r, m, d ^ 1);
                    for (size_t w = 0; w < W; w++)
                        dc[w] &= al[w];
                }
            }
    *ok = gs_model_solver_recount(s);
    if (s->resem && s->resem->zshare) { /* exact label counts, from no cell decided */
        const size_t rows = (size_t)rz * ((size_t)s->L + 1);
        if (rows > s->fq_exact_cap) {
            GS_CALL(grow((void **)&s->fq_exact, rows, sizeof *s->fq_exact, "label-frequency counts"));
            s->fq_exact_cap = rows;
        }
        if (s->n > s->fq_state_cap) {
            GS_CALL(grow((void **)&s->fq_state, s->n, sizeof *s->fq_state, "label-frequency states"));
            s->fq_state_cap = s->n;
        }
        if ((size_t)s->L > s->fq_stamp_cap) {
            GS_CALL(grow((void **)&s->fq_stamp, (size_t)s->L, sizeof *s->fq_stamp,
                         "label-frequency stamps"));
            memset(s->fq_stamp, 0, (size_t)s->L * sizeof *s->fq_stamp);
            s->fq_stamp_cap = (size_t)s->L;
            s->fq_gen = 0;
        }
        memset(s->fq_exact, 0, rows * sizeof *s->fq_exact);
        memset(s->fq_state, 0xff, s->n * sizeof *s->fq_state);
        s->fq_on = 1;
    }
    if (s->resem) { /* the cells decided from the start (pins, a one-label face) */
        s->rs_on = 1;
        for (int32_t u = 0; u < (int32_t)s->n; u++)
            if (s->size[u] == 1)
                rs_note(s, u);
    }
    return GS_OK;
}

/* Target value m of c's column and the constraint-weighted factor of a
 * structure label, exp(g*(2m-1)) (any other label: its inverse). */
static double shape_factor(const struct gs_model_solver *s, int32_t c)
{
    int x = s->box_x0 + c % s->box_rx, y = s->box_y0 + (c / s->box_rx) % s->box_ry;
    double m = s->shape[(size_t)x + (size_t)s->lat_nx * (size_t)y];
    return exp(s->shape_weight * (2 * m - 1));
}

/* Soft shape constraint without resemblance: weights scaled by the target
 * value of c's column (structure labels up, the others down). */
static int choose_label_shape(struct gs_model_solver *s, int32_t c, gs_rng *rng)
{
    const size_t W = (size_t)s->W;
    const uint64_t *dc = s->dom + (size_t)c * W;
    double f_full = shape_factor(s, c), f_empty = 1.0 / f_full;
    double total = 0;
    for (size_t w = 0; w < W; w++)
        for (uint64_t bits = dc[w]; bits; bits &= bits - 1) {
            int a = (int)(w * 64) + ctz64(bits);
            double base = s->weights_kind == GS_MODEL_WEIGHTS_UNIFORM ? 1.0 : (double)s->weights[a];
            total += base * (s->structure[a] ? f_full : f_empty);
        }
    double pick = gs_rng_uniform(rng) * total;
    int last = -1;
    for (size_t w = 0; w < W; w++)
        for (uint64_t bits = dc[w]; bits; bits &= bits - 1) {
            int a = (int)(w * 64) + ctz64(bits);
            double base = s->weights_kind == GS_MODEL_WEIGHTS_UNIFORM ? 1.0 : (double)s->weights[a];
            double wa = base * (s->structure[a] ? f_full : f_empty);
            if (pick < wa)
                return a;
            pick -= wa;
            last = a;
        }
    return last;
}

/* Label-frequency constraint (gs_model_resem_set_frequency): the decided
 * cells per layer and label of the box, counted afresh every fq_every
 * choices (cells decided by propagation included: fq_exact, kept by
 * rs_note), each choice added at once. */
static void freq_recount(struct gs_model_solver *s)
{
    const size_t L1 = (size_t)s->L + 1;
    memcpy(s->fq_cnt, s->fq_exact, (size_t)s->box_rz * L1 * sizeof *s->fq_cnt);
    s->fq_left = s->fq_every;
}

/* The label-frequency factors of a choice at cell c: ((t*D + 1) / (n + 1))^beta
 * of a candidate label a, computed by freq_factor when first asked for at
 * this choice (the counts do not change within a choice). */
typedef struct freq_ctx {
    const uint32_t *row; /* the counts of c's layer, its total last */
    const float *t;      /* the example's shares at c's layer */
    double *fac;         /* [L] */
    uint32_t gen;        /* this choice's fq_stamp value */
} freq_ctx;

static freq_ctx freq_begin(struct gs_model_solver *s, int32_t c)
{
    const struct gs_model_resem *R = s->resem;
    const size_t L1 = (size_t)s->L + 1;
    if (!s->fq_left)
        freq_recount(s);
    s->fq_left--;
    if (++s->fq_gen == 0) { /* the clock wrapped: no factor is current */
        memset(s->fq_stamp, 0, (size_t)s->L * sizeof *s->fq_stamp);
        s->fq_gen = 1;
    }
    const int zl = s->box_z0 + c / (s->box_rx * s->box_ry);
    freq_ctx f;
    f.row = s->fq_cnt + (size_t)(c / (s->box_rx * s->box_ry)) * L1;
    f.t = R->zshare + (size_t)(zl < R->nz ? zl : R->nz - 1) * (size_t)R->L;
    double *fac = (double *)(s->fq_cnt + (size_t)s->box_rz * L1 + 1);
    f.fac = (double *)(((uintptr_t)fac + 7) & ~(uintptr_t)7);
    f.gen = s->fq_gen;
    return f;
}

static inline double freq_factor(struct gs_model_solver *s, const freq_ctx *f, int a)
{
    if (s->fq_stamp[a] != f->gen) {
        const size_t L1 = (size_t)s->L + 1;
        f->fac[a] = pow(((double)f->t[a] * f->row[L1 - 1] + 1.0) / ((double)f->row[a] + 1.0),
                        s->resem->freq_beta);
        s->fq_stamp[a] = f->gen;
    }
    return f->fac[a];
}

/* Candidate patterns of view V (labels below L) for the candidate labels dc:
 * the centre runs of the labels, set in cand[*wlo, *whi) (the words they
 * span). Returns 0 when no candidate label has a pattern. */
static int resem_cand(const struct gs_model_resem_view *V, int L, const uint64_t *dc, size_t W,
                      uint64_t *cand, size_t *wlo_out, size_t *whi_out)
{
    const int32_t *range = V->range;
    size_t wlo = (size_t)V->PW, whi = 0;
    for (size_t w = 0; w < W; w++)
        for (uint64_t bits = dc[w]; bits; bits &= bits - 1) {
            int a = (int)(w * 64) + ctz64(bits);
            if (a >= L || range[a] == range[a + 1])
                continue;
            size_t lo = (size_t)range[a] >> 6, hi = ((size_t)range[a + 1] + 63) >> 6;
            if (lo < wlo)
                wlo = lo;
            if (hi > whi)
                whi = hi;
        }
    if (wlo >= whi)
        return 0;
    memset(cand + wlo, 0, (whi - wlo) * 8);
    for (size_t w = 0; w < W; w++)
        for (uint64_t bits = dc[w]; bits; bits &= bits - 1) {
            int a = (int)(w * 64) + ctz64(bits);
            if (a >= L)
                continue;
            /* bits [lo, hi) word by word */
            size_t lo = (size_t)range[a], hi = (size_t)range[a + 1];
            while (lo < hi) {
                size_t w0 = lo >> 6, end = (w0 + 1) << 6 < hi ? (w0 + 1) << 6 : hi;
                uint64_t bits_hi = end - (w0 << 6) == 64 ? ~(uint64_t)0
                                                          : (((uint64_t)1 << (end - (w0 << 6))) - 1);
                cand[w0] |= bits_hi & ~(((uint64_t)1 << (lo & 63)) - 1);
                lo = end;
            }
        }
    *wlo_out = wlo;
    *whi_out = whi;
    return 1;
}

/* Match counting of choose_label_resem on 1, 2 or 4 consecutive pattern
 * words at once (T: a word, or GCC/Clang vector extensions: 2 words are one
 * SSE2 register, 4 one AVX2 register or two SSE2 ones; the same operations
 * lane by lane): the bit-sliced planes (B of them, into cnt, PW words apart)
 * of the counts of the matches (nbl[0..nn), each a word offset into bits:
 * plus 2 half matches) and half matches (nbo[0..no): plus 1). */
typedef uint64_t rs_v2 __attribute__((vector_size(16)));
typedef uint64_t rs_v4 __attribute__((vector_size(32)));
#define RS_CSA(h, l, a, b, c)                                                                    \
    do {                                                                                         \
        const __typeof__(a) u_ = (a) ^ (b);                                                      \
        h = ((a) & (b)) | (u_ & (c));                                                            \
        l = u_ ^ (c);                                                                            \
    } while (0)
/* four more neighbours into ones and twos, their fours carried out to fo */
#define RS_QUAD(fo, a, b, c, d)                                                                  \
    do {                                                                                         \
        RS_CSA(twosA, ones, ones, a, b);                                                         \
        RS_CSA(twosB, ones, ones, c, d);                                                         \
        RS_CSA(fo, twos, twos, twosA, twosB);                                                    \
    } while (0)
#define RS_COUNT_KERNEL(NAME, T)                                                                 \
    static inline __attribute__((always_inline)) void NAME(                                     \
        const uint64_t *bits, const uint64_t *nbl, size_t nn, const uint64_t *nbo, size_t no,    \
        int B, uint64_t *cnt, size_t PW)                                                         \
    {                                                                                            \
        T zero;                                                                                  \
        memset(&zero, 0, sizeof zero);                                                           \
        T ones = zero, twos = zero, fours = zero, eights = zero, h4 = zero, h5 = zero, h6 = zero, t; \
        size_t i = 0;                                                                            \
        T v[16];                                                                                 \
        for (; i + 16 <= nn; i += 16) {                                                          \
            for (int k = 0; k < 16; k++)                                                         \
                memcpy(&v[k], bits + nbl[i + (size_t)k], sizeof(T));                             \
            T twosA, twosB, foursA, foursB, eightsA, eightsB, sixteens;                          \
            RS_QUAD(foursA, v[0], v[1], v[2], v[3]);                                             \
            RS_QUAD(foursB, v[4], v[5], v[6], v[7]);                                             \
            RS_CSA(eightsA, fours, fours, foursA, foursB);                                       \
            RS_QUAD(foursA, v[8], v[9], v[10], v[11]);                                           \
            RS_QUAD(foursB, v[12], v[13], v[14], v[15]);                                         \
            RS_CSA(eightsB, fours, fours, foursA, foursB);                                       \
            RS_CSA(sixteens, eights, eights, eightsA, eightsB);                                  \
            t = h4 & sixteens;                                                                   \
            h4 ^= sixteens;                                                                      \
            T carry = t;                                                                         \
            t = h5 & carry;                                                                      \
            h5 ^= carry;                                                                         \
            h6 ^= t;                                                                             \
        }                                                                                        \
        for (; i < nn; i++) {                                                                    \
            T carry;                                                                             \
            memcpy(&carry, bits + nbl[i], sizeof(T));                                            \
            t = ones & carry; ones ^= carry; carry = t;                                          \
            t = twos & carry; twos ^= carry; carry = t;                                          \
            t = fours & carry; fours ^= carry; carry = t;                                        \
            t = eights & carry; eights ^= carry; carry = t;                                      \
            t = h4 & carry; h4 ^= carry; carry = t;                                              \
            t = h5 & carry; h5 ^= carry; carry = t;                                              \
            h6 ^= carry;                                                                         \
        }                                                                                        \
        T p[8] = {zero, ones, twos, fours, eights, h4, h5, h6};                                  \
        for (i = 0; i < no; i++) {                                                               \
            T carry;                                                                             \
            memcpy(&carry, bits + nbo[i], sizeof(T));                                            \
            for (int b = 0; b < 8; b++) {                                                        \
                t = p[b] & carry;                                                                \
                p[b] ^= carry;                                                                   \
                carry = t;                                                                       \
            }                                                                                    \
        }                                                                                        \
        for (int b = 0; b < B; b++)                                                              \
            memcpy(cnt + (size_t)b * PW, &p[b], sizeof(T));                                      \
    }
RS_COUNT_KERNEL(rs_count_v1, uint64_t)
RS_COUNT_KERNEL(rs_count_v2, rs_v2)
RS_COUNT_KERNEL(rs_count_v4, rs_v4)
#undef RS_COUNT_KERNEL
#undef RS_QUAD
#undef RS_CSA

/* Resemblance (paper Eqs. 4-6, see gs_model_resem_build in model.h): match
 * counts of the candidate patterns in bit-sliced counters over the words of
 * the candidates' centre runs, then the patterns with the most matches
 * (minus the slack), then one of them by multiplicity; its centre is the
 * label. Returns -1 when scratch space cannot grow. */
GS_HOT_CLONES static int choose_label_resem(struct gs_model_solver *s, int32_t c, gs_rng *rng)
{
    const struct gs_model_resem *R = s->resem;
    const size_t W = (size_t)s->W, PW = (size_t)R->PW;
    const uint64_t *dc = s->dom + (size_t)c * W;
    const size_t need = PW * (size_t)(R->B + 4) + 2 * (size_t)R->Q + 64 * PW; /* + weights */
    if (need > s->rs_cap) {
        uint64_t *nb = gs_realloc(s->rs_buf, need * 8);
        if (!nb)
            return -1;
        s->rs_buf = nb;
        s->rs_cap = need;
    }
    uint64_t *cand = s->rs_buf, *mask = cand + PW, *tmp = mask + PW, *cnt = tmp + PW;
    uint32_t *act = (uint32_t *)(cnt + (size_t)R->B * PW); /* words with a candidate */
    /* [2Q] bitsets of the decided neighbours: nn scoring 2 (equal label, or
     * past the example's faces with outside = 2), then no scoring 1 (past the
     * faces, outside = 1) from the end */
    uint64_t *nbl = cnt + (size_t)(R->B + 1) * PW;
    uint64_t *nbo = nbl + R->Q;
    size_t nact = 0, nn = 0, no = 0;
    /* candidate patterns: the centre runs of the candidate labels; with layers
     * only the patterns of the cell's example layer, when any is a candidate
     * (its packed view when built, else the whole index masked) */
    const struct gs_model_resem_view *V = &R->all;
    const uint32_t *mult = R->mult;
    size_t wlo = 0, whi = 0;
    int zl = -1;
    if (R->layers) {
        zl = s->box_z0 + c / (s->box_rx * s->box_ry);
        if (zl >= R->nz)
            zl = R->nz - 1;
        if (R->lv && resem_cand(&R->lv[zl], R->L, dc, W, cand, &wlo, &whi)) {
            V = &R->lv[zl];
            mult = V->mult;
            zl = -1; /* packed: every pattern of the view is the layer's */
        }
    }
    if (V == &R->all && !resem_cand(V, R->L, dc, W, cand, &wlo, &whi))
        return -1;
    if (zl >= 0) {
        const uint64_t *zb = R->zbits + (size_t)zl * PW;
        uint64_t any = 0;
        for (size_t w = wlo; w < whi; w++)
            any |= cand[w] & zb[w];
        if (any) {
            for (size_t w = wlo; w < whi; w++)
                cand[w] &= zb[w];
            mult = R->zmult + (size_t)zl * (size_t)R->P;
        }
    }
    const size_t VPW = (size_t)V->PW;
    for (size_t w = wlo; w < whi; w++)
        if (cand[w])
            act[nact++] = (uint32_t)w;
    /* the bitset of every decided neighbour */
    const int z = c / (s->box_rx * s->box_ry);
    const uint16_t *lab = s->rs_lab + s->rs_pidx[c];
    const int32_t *dq = s->rs_dq, *vslot = V->slot, *voslot = V->oslot;
    const size_t Q = (size_t)R->Q; /* slot rows: one per label, R->L (none) has none */
    if (R->outside_bg) {
        /* past the example's faces lies its face background of the
         * neighbour's layer (a match), nothing else */
        const int32_t *bgq = s->rs_bgq + (size_t)z * (size_t)R->Q;
        for (int q = 0; q < R->Q; q++) {
            const unsigned l = lab[dq[q]];
            const int32_t sl = vslot[l * Q + (size_t)q], os = voslot[q];
            nbl[nn] = (uint64_t)sl * VPW;
            nn += sl >= 0;
            nbl[nn] = (uint64_t)os * VPW;
            nn += (os >= 0) & ((int32_t)l == bgq[q]);
        }
    } else {
        for (int q = 0; q < R->Q; q++) {
            const unsigned l = lab[dq[q]];
            const int32_t sl = vslot[l * Q + (size_t)q];
            nbl[nn] = (uint64_t)sl * VPW;
            nn += sl >= 0;
            if (R->outside && l < (unsigned)R->L && voslot[q] >= 0) {
                if (R->outside == 2)
                    nbl[nn++] = (uint64_t)voslot[q] * VPW;
                else
                    nbo[no++] = (uint64_t)voslot[q] * VPW;
            }
        }
    }
    /* match counts: the neighbours' bits added into bit-sliced counters
     * (counts in half matches <= 2Q < 2^B, B <= 8 for w <= 2: a match adds
     * from plane 1, a half match from plane 0), CW candidate words at a time
     * where the view has that many, with the counter planes in registers.
     * The matches are counted 16 neighbours at a time by a carry-save adder
     * tree (Harley-Seal: 15 full adders of 5 operations instead of 16 ripple
     * adds of 14), the sixteens rippled into planes 5-7. Bits of
     * non-candidate patterns are counted too and never read (every use below
     * masks with the candidates); a chunk ending past the view's last word
     * starts earlier (a word counted twice gets the same planes). */
    const size_t CW = VPW >= 4 ? 4 : VPW >= 2 ? 2 : 1;
    for (size_t j = 0; j < nact;) {
        size_t w0 = act[j];
        if (w0 + CW > VPW)
            w0 = VPW - CW;
        if (CW == 4)
            rs_count_v4(V->bits + w0, nbl, nn, nbo, no, R->B, cnt + w0, PW);
        else if (CW == 2)
            rs_count_v2(V->bits + w0, nbl, nn, nbo, no, R->B, cnt + w0, PW);
        else
            rs_count_v1(V->bits + w0, nbl, nn, nbo, no, R->B, cnt + w0, PW);
        while (j < nact && act[j] < w0 + CW)
            j++;
    }
    /* the highest count among the candidates: top bit down */
    memcpy(mask + wlo, cand + wlo, (whi - wlo) * 8);
    int best = 0;
    for (int b = R->B - 1; b >= 0; b--) {
        const uint64_t *cb = cnt + (size_t)b * PW;
        uint64_t any = 0;
        for (size_t j = 0; j < nact; j++)
            any |= tmp[act[j]] = mask[act[j]] & cb[act[j]];
        if (any) {
            for (size_t j = 0; j < nact; j++)
                mask[act[j]] = tmp[act[j]];
            best |= 1 << b;
        }
    }
    /* outside the target shape the constraint-weighted choice also sees the
     * next closest neighbourhoods (shape_slack more), so it can leave out
     * structure the closest ones would continue */
    const int slack = 2 * (R->slack + (s->shape && shape_factor(s, c) < 1.0 ? s->shape_slack : 0));
    if (slack > 0) { /* counts >= best - slack (half matches): bit-sliced compare */
        int t = best - slack;
        if (t <= 0) {
            memcpy(mask + wlo, cand + wlo, (whi - wlo) * 8);
        } else {
            for (size_t j = 0; j < nact; j++) {
                const size_t w = act[j];
                uint64_t ge = 0, eq = cand[w];
                for (int b = R->B - 1; b >= 0; b--) {
                    uint64_t cb = cnt[(size_t)b * PW + w];
                    if (t >> b & 1) {
                        eq &= cb;
                    } else {
                        ge |= eq & cb;
                        eq &= ~cb;
                    }
                }
                mask[w] = ge | eq;
            }
        }
    }
    if (s->shape || R->zshare) { /* Eq. 6 times the constraint weights of each centre label */
        const double f_full = s->shape ? shape_factor(s, c) : 1.0, f_empty = 1.0 / f_full;
        freq_ctx fq = {0};
        if (R->zshare)
            fq = freq_begin(s, c);
        /* each pattern's weight once, kept for the draw (patterns of one centre
         * label are one run: its factors are looked up once per run) */
        double *wts = (double *)(nbl + 2 * (size_t)R->Q); /* [64 PW] */
        double dtotal = 0, fw = 1.0;
        int la = -1;
        size_t nw = 0;
        for (size_t w = wlo; w < whi; w++)
            for (uint64_t bits = mask[w]; bits; bits &= bits - 1) {
                size_t i = w * 64 + (size_t)ctz64(bits);
                const int a = V->center[i];
                if (a != la) {
                    la = a;
                    fw = R->zshare ? freq_factor(s, &fq, a) : 1.0;
                }
                const double wi =
                    mult[i] * (s->shape ? (s->structure[a] ? f_full : f_empty) : 1.0) * fw;
                wts[nw++] = wi;
                dtotal += wi;
            }
        double dpick = gs_rng_uniform(rng) * dtotal;
        int last = -1;
        nw = 0;
        for (size_t w = wlo; w < whi; w++)
            for (uint64_t bits = mask[w]; bits; bits &= bits - 1) {
                size_t i = w * 64 + (size_t)ctz64(bits);
                double wi = wts[nw++];
                if (dpick < wi)
                    return V->center[i];
                dpick -= wi;
                last = V->center[i];
            }
        return last;
    }
    uint64_t total = 0;
    for (size_t w = wlo; w < whi; w++)
        for (uint64_t bits = mask[w]; bits; bits &= bits - 1)
            total += mult[w * 64 + (size_t)ctz64(bits)];
    uint64_t pick = gs_rng_below(rng, total);
    for (size_t w = wlo; w < whi; w++)
        for (uint64_t bits = mask[w]; bits; bits &= bits - 1) {
            size_t i = w * 64 + (size_t)ctz64(bits);
            if (pick < mult[i])
                return V->center[i];
            pick -= mult[i];
        }
    return -1;
}

static int choose_label(struct gs_model_solver *s, int32_t c, gs_rng *rng)
{
    const size_t W = (size_t)s->W;
    const uint64_t *dc = s->dom + (size_t)c * W;
    if (s->resem)
        return choose_label_resem(s, c, rng); /* with the shape weights when set */
    if (s->shape)
        return choose_label_shape(s, c, rng);
    if (s->weights_kind == GS_MODEL_WEIGHTS_UNIFORM) {
        uint64_t pick = gs_rng_below(rng, s->size[c]);
        for (size_t w = 0; w < W; w++) {
            uint64_t bits = dc[w];
            int k = popcount64(bits);
            if (pick >= (uint64_t)k) {
                pick -= (uint64_t)k;
                continue;
            }
            for (; pick; pick--)
                bits &= bits - 1;
            return (int)(w * 64) + ctz64(bits);
        }
        return -1;
    }
    uint64_t total = 0;
    for (size_t w = 0; w < W; w++)
        for (uint64_t bits = dc[w]; bits; bits &= bits - 1)
            total += s->weights[w * 64 + (size_t)ctz64(bits)];
    uint64_t pick = gs_rng_below(rng, total);
    for (size_t w = 0; w < W; w++)
        for (uint64_t bits = dc[w]; bits; bits &= bits - 1) {
            int a = (int)(w * 64) + ctz64(bits);
            if (pick < s->weights[a])
                return a;
            pick -= s->weights[a];
        }
    return -1;
}

/* x/y distance of box column (x, y) to the nearest face in shell (x-, x+,
 * y-, y+: output beyond it); 0 when no face has. */
static inline int shell_dist(int x, int y, int rx, int ry, const int shell[4])
{
    const int df[4] = {x, rx - 1 - x, y, ry - 1 - y};
    int d = -1;
    for (int f = 0; f < 4; f++)
        if (shell[f] && (d < 0 || df[f] < d))
            d = df[f];
    return d < 0 ? 0 : d;
}

/* ENTROPY_LAYERS: the tie key of every box cell (24 bits, smaller first)
 * becomes (its layer, its x/y distance to the nearest box face with output
 * beyond it, the random key's low bits): among cells with as many candidates
 * the lowest layer is decided first, and in a layer the cells next to the
 * decided shell. With synthesized z faces and the entropy order's random
 * ties, structure started at every height and place at once: roofs decided
 * before the walls under them, hill tops before their flanks (gen-lattice
 * villages: roof sheets over walls that never close; #18 untuned examples).
 * ENTROPY_COLUMNS (columns = 1) swaps the first two: (distance, layer,
 * random): the region is decided ring by ring in from its decided shell,
 * each ring's columns from the ground up, so a choice sees whole decided
 * columns on its shell side. Layer first, a region's whole ground layer was
 * decided seeing only that layer (and the shell): the size of a stone patch
 * at z = 0 sets how tall a hill can grow on it (each layer up is 1-2 cells
 * narrower), and patches chosen without the height above them came out
 * smaller and more ragged than the example's, so each layer up was narrower
 * than the example's and the layers the example reaches in a few columns
 * (hill tops, a keep's top) were never reached (#18, terrain 89 and 92). */
static void layer_ties(struct gs_model_solver *s, const gs_model_lattice *lat, const gs_model_box *b,
                       const int periodic[3], int columns)
{
    const int rx = b->x1 - b->x0, ry = b->y1 - b->y0, rz = b->z1 - b->z0;
    const int shell[4] = {b->x0 > 0 || periodic[0], b->x1 < lat->nx || periodic[0],
                          b->y0 > 0 || periodic[1], b->y1 < lat->ny || periodic[1]};
    int dmax = 0;
    for (int y = 0; y < ry; y++)
        for (int x = 0; x < rx; x++) {
            const int d = shell_dist(x, y, rx, ry, shell);
            dmax = d > dmax ? d : dmax;
        }
    int zb = 0, db = 0; /* bits of the layer and the distance */
    while ((1 << zb) < rz)
        zb++;
    while ((1 << db) < dmax + 1)
        db++;
    const int zs = zb > 12 ? zb - 12 : 0, ds = db > 8 ? db - 8 : 0; /* at most 20 bits */
    zb -= zs;
    db -= ds;
    const int rb = 24 - zb - db; /* random bits below */
    int32_t c = 0;
    for (int z = 0; z < rz; z++)
        for (int y = 0; y < ry; y++)
            for (int x = 0; x < rx; x++, c++) {
                const uint32_t zk = (uint32_t)(z >> zs),
                               dk = (uint32_t)(shell_dist(x, y, rx, ry, shell) >> ds);
                const uint32_t key = columns ? (dk << zb) | zk : (zk << db) | dk;
                s->tie[c] = (key << rb) | (s->tie[c] & ((1u << rb) - 1u));
            }
}

/* One attempt: returns 1 when every cell ended with exactly one label.
 * flip (scan order): bit 0 runs x from the box's upper face down, bit 1 y. */
static gs_err attempt_region(struct gs_model_solver *s, const gs_model_lattice *lat,
                             const overlay *ov, const gs_model_box *b, const gs_model_params *p,
                             int budget_scale, int flip, gs_rng *rng, uint64_t *choices, int *ok)
{
    GS_CALL(setup_region(s, lat, ov, b, p->periodic, ok));
    if (!*ok)
        return GS_OK;
    *ok = gs_model_ac_establish(s);
    if (!*ok)
        return GS_OK;
    const int32_t n = (int32_t)s->n;
    const int entropy = p->order == GS_MODEL_ORDER_ENTROPY || p->order == GS_MODEL_ORDER_ENTROPY_LOG ||
                        p->order == GS_MODEL_ORDER_ENTROPY_LAYERS ||
                        p->order == GS_MODEL_ORDER_ENTROPY_COLUMNS;
    s->order_log = p->order == GS_MODEL_ORDER_ENTROPY_LOG;
    s->push_counter = 0;
    if (entropy) {
        for (int32_t c = 0; c < n; c++)
            s->tie[c] = gs_rng_u32(rng);
        if (p->order == GS_MODEL_ORDER_ENTROPY_LAYERS || p->order == GS_MODEL_ORDER_ENTROPY_COLUMNS)
            layer_ties(s, lat, b, p->periodic, p->order == GS_MODEL_ORDER_ENTROPY_COLUMNS);
        s->heap_len = 0;
        for (int32_t c = 0; c < n; c++)
            s->hpos[c] = -1;
        for (int32_t c = 0; c < n; c++)
            if (s->size[c] > 1 && !heap_push(s, c))
                GS_RAISE(GS_ERR_MEM, "region heap: cannot allocate");
        s->heap_on = 1;
    } else {
        const int rx = b->x1 - b->x0, ry = b->y1 - b->y0, rz = b->z1 - b->z0;
        int32_t k = 0;
        for (int i = 0; i < rx; i++) /* the author's scan: z fastest, then y, then x */
            for (int j = 0; j < ry; j++)
                for (int z = 0; z < rz; z++) {
                    const int x = flip & 1 ? rx - 1 - i : i, y = flip & 2 ? ry - 1 - j : j;
                    s->order[k++] = (uint32_t)(x + rx * (y + ry * z));
                }
        if (p->order == GS_MODEL_ORDER_RANDOM)
            for (int32_t i = n - 1; i > 0; i--) {
                int32_t j = (int32_t)gs_rng_below(rng, (uint64_t)i + 1);
                uint32_t t = s->order[i];
                s->order[i] = s->order[j];
                s->order[j] = t;
            }
    }
    if (s->resem && s->resem->zshare) { /* label counts, then L factors (doubles) */
        const size_t need = (size_t)b->z1 - (size_t)b->z0;
        const size_t words = need * ((size_t)s->L + 1) + 2 + 2 * (size_t)s->L;
        if (words > s->fq_cap) {
            uint32_t *nb = gs_realloc(s->fq_cnt, words * sizeof *nb);
            GS_CHECK(nb != NULL, GS_ERR_MEM, "label-frequency counts: cannot allocate");
            s->fq_cnt = nb;
            s->fq_cap = words;
        }
        s->fq_every = s->n / 64 ? s->n / 64 : 1;
        s->fq_left = 0;
    }
    const int64_t budget64 = s->ac == GS_MODEL_AC3 ? (int64_t)p->backtracks * budget_scale : 0;
    const int budget = budget64 > 100000000 ? 100000000 : (int)budget64;
    s->trail_on = budget > 0;
    s->trail_undo_left = (size_t)budget;
    int backtracks = 0, rewinds = 0;
    uint64_t spent = 0; /* undone before a rewind */
    if (p->rewinds > 0) /* a rewind reaches back past the undo budget: keep the trail */
        s->trail_undo_left = SIZE_MAX;
    size_t pos = 0;
    *ok = 0;
    for (;;) {
        /* next undecided cell */
        int32_t c = -1;
        if (entropy) {
            while (s->heap_len) {
                uint64_t key = heap_pop(s);
                int32_t cand = (int32_t)(uint32_t)key;
                unsigned k = heap_bucket(s, cand);
                if (s->size[cand] > 1 && (unsigned)(key >> 56) == k) {
                    c = cand;
                    break;
                }
            }
        } else {
            while (pos < (size_t)n && s->size[s->order[pos]] <= 1)
                pos++;
            if (pos < (size_t)n)
                c = (int32_t)s->order[pos];
        }
        if (c < 0) {
            *ok = 1;
            break;
        }
        int label = choose_label(s, c, rng);
        (*choices)++;
        if (label < 0)
            break;
        if (s->fq_cnt && s->resem && s->resem->zshare) { /* counted at once; refreshed later */
            uint32_t *row = s->fq_cnt + (size_t)(c / (s->box_rx * s->box_ry)) * ((size_t)s->L + 1);
            row[label]++;
            row[s->L]++;
        }
        if (budget) {
            if (s->ndec == s->dec_cap) {
                size_t ncap = s->dec_cap ? 2 * s->dec_cap : 256;
                struct gs_model_decision *d = gs_realloc(s->dec, ncap * sizeof *d);
                GS_CHECK(d != NULL, GS_ERR_MEM, "decision stack: cannot allocate");
                s->dec = d;
                s->dec_cap = ncap;
            }
            struct gs_model_decision *d = &s->dec[s->ndec++];
            d->cell = c;
            d->label = label;
            d->mark = s->trail_base + s->trail_len;
            d->level = ++s->level_counter;
            d->pos = pos;
            s->level = d->level;
        }
        s->wipe_cell = -1;
        int good = gs_model_ac_assign(s, c, label);
        while (!good) {
            if (budget && backtracks >= budget && rewinds < p->rewinds && s->ndec > 0) {
                /* model.rewinds: the budget ran out (the cause lies further back
                 * than the undo reached); undo the latest 30% of the decisions
                 * unrefuted and go on with a fresh budget, not a new try */
                const size_t t = s->ndec - (s->ndec * 3 + 9) / 10;
                struct gs_model_decision d = s->dec[t];
                s->ndec = t;
                GS_CHECK(trail_restore(s, d.mark), GS_ERR_MEM,
                         "rewind: cannot allocate the region heap, or the trail entries are gone");
                s->level = s->ndec ? s->dec[s->ndec - 1].level : 1;
                pos = d.pos;
                spent += backtracks;
                backtracks = 0;
                rewinds++;
                s->wipe_cell = -1;
                good = 1;
                break;
            }
            if (!budget || s->ndec == 0 || backtracks >= budget)
                goto done;
            s->ndec = backjump_to(s, p->backjump);
            struct gs_model_decision d = s->dec[--s->ndec];
            s->wipe_cell = -1;
            backtracks++;
            s->trail_undo_left = p->rewinds > 0 ? SIZE_MAX : (size_t)(budget - backtracks);
            GS_CHECK(trail_restore(s, d.mark), GS_ERR_MEM,
                     "undo: cannot allocate the region heap, or the trail entries are gone");
            s->level = s->ndec ? s->dec[s->ndec - 1].level : 1;
            pos = d.pos;
            good = ac_refute(s, d.cell, d.label);
        }
    }
done:
    s->heap_on = 0;
    s->trail_on = 0;
    s->backtracks_done += (uint64_t)backtracks + spent;
    return GS_OK;
}

size_t gs_model_box_support(uint8_t *st, const gs_model_box *b, const gs_model_lattice *lat,
                            const int periodic[3],
                            int (*solid_at)(const void *ctx, int x, int y, int z),
                            const void *ctx)
{
    const int rx = b->x1 - b->x0, ry = b->y1 - b->y0, rz = b->z1 - b->z0;
    const size_t n = (size_t)rx * (size_t)ry * (size_t)rz;
    int32_t *queue = gs_malloc((n ? n : 1) * sizeof *queue);
    if (!queue)
        return SIZE_MAX;
    static const int d6[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    size_t head = 0, tail = 0, k = 0;
    for (int z = 0; z < rz; z++)
        for (int y = 0; y < ry; y++)
            for (int x = 0; x < rx; x++, k++) {
                if (!st[k])
                    continue;
                int grounded = b->z0 + z == 0;
                for (int d = 0; d < 6 && !grounded; d++) {
                    int px = x + d6[d][0], py = y + d6[d][1], pz = z + d6[d][2];
                    if (px >= 0 && py >= 0 && pz >= 0 && px < rx && py < ry && pz < rz)
                        continue;
                    int gx = b->x0 + px, gy = b->y0 + py, gz = b->z0 + pz;
                    if (periodic[0])
                        gx = (gx % lat->nx + lat->nx) % lat->nx;
                    if (periodic[1])
                        gy = (gy % lat->ny + lat->ny) % lat->ny;
                    if (gx < 0 || gy < 0 || gz < 0 || gx >= lat->nx || gy >= lat->ny ||
                        gz >= lat->nz)
                        continue;
                    grounded = solid_at(ctx, gx, gy, gz);
                }
                if (grounded) {
                    st[k] = 2;
                    queue[tail++] = (int32_t)k;
                }
            }
    while (head < tail) {
        int32_t u = queue[head++];
        int x = u % rx, y = (u / rx) % ry, z = u / (rx * ry);
        for (int d = 0; d < 6; d++) {
            int px = x + d6[d][0], py = y + d6[d][1], pz = z + d6[d][2];
            if (px < 0 || py < 0 || pz < 0 || px >= rx || py >= ry || pz >= rz)
                continue;
            int32_t v = (int32_t)(px + rx * (py + ry * pz));
            if (st[v] == 1) {
                st[v] = 2;
                queue[tail++] = v;
            }
        }
    }
    gs_free(queue);
    return tail;
}

typedef struct support_ctx {
    const gs_model_lattice *lat;
    const overlay *ov;
    const uint8_t *empty;
    int L;
} support_ctx;

static int overlay_solid(const void *ctx, int x, int y, int z)
{
    const support_ctx *c = ctx;
    int m = overlay_label(c->lat, c->ov, x, y, z);
    return m < c->L && !c->empty[m];
}

/* 1 when every non-empty cell of the solved box reaches, through 6-connected
 * non-empty box cells, the ground layer (global z = 0) or a non-empty cell
 * next to the box (outside it; taken as supported): no floating structure
 * (params.support_empty, empty[label] = 1 for empty space). -1: no memory. */
static int box_supported(struct gs_model_solver *s, const gs_model_lattice *lat,
                         const overlay *ov, const gs_model_box *b, const uint8_t *empty)
{
    const int rx = b->x1 - b->x0, ry = b->y1 - b->y0, rz = b->z1 - b->z0;
    const size_t n = (size_t)rx * (size_t)ry * (size_t)rz, W = (size_t)s->W;
    uint8_t *st = gs_malloc(n ? n : 1);
    if (!st)
        return -1;
    size_t solid = 0;
    for (size_t c = 0; c < n; c++) {
        st[c] = !empty[first_label(s->dom + c * W)];
        solid += st[c];
    }
    const support_ctx ctx = {lat, ov, empty, s->L};
    size_t reached = gs_model_box_support(st, b, lat, s->periodic, overlay_solid, &ctx);
    gs_free(st);
    return reached == SIZE_MAX ? -1 : reached == solid;
}

/* st (x fastest) 1 = non-empty, 0 = empty: every non-empty cell with a
 * 6-connected path of non-empty cells to z = 0 (x / y wrapping where
 * periodic) becomes 2. Returns how many, SIZE_MAX when out of memory. */
static size_t support_flood(uint8_t *st, int nx, int ny, int nz, const int periodic[3])
{
    const size_t n = (size_t)nx * (size_t)ny * (size_t)nz, layer = (size_t)nx * (size_t)ny;
    int32_t *queue = gs_malloc((n ? n : 1) * sizeof *queue);
    if (!queue)
        return SIZE_MAX;
    size_t head = 0, tail = 0;
    for (size_t i = 0; i < layer && i < n; i++)
        if (st[i] == 1) {
            st[i] = 2;
            queue[tail++] = (int32_t)i;
        }
    /* the reached set does not depend on the visiting order; neighbours by
     * index offsets (every rank runs this after the last pass: serial work) */
#define FLOOD_VISIT(v)                                                                           \
    do {                                                                                         \
        const size_t v_ = (v);                                                                   \
        if (st[v_] == 1) {                                                                       \
            st[v_] = 2;                                                                          \
            queue[tail++] = (int32_t)v_;                                                         \
        }                                                                                        \
    } while (0)
    const size_t sx = (size_t)nx, sy = (size_t)ny;
    while (head < tail) {
        const size_t u = (size_t)queue[head++], xy = u % layer, x = xy % sx, y = xy / sx;
        const size_t z = u / layer;
        if (x + 1 < sx)
            FLOOD_VISIT(u + 1);
        else if (periodic[0])
            FLOOD_VISIT(u + 1 - sx);
        if (x > 0)
            FLOOD_VISIT(u - 1);
        else if (periodic[0])
            FLOOD_VISIT(u + sx - 1);
        if (y + 1 < sy)
            FLOOD_VISIT(u + sx);
        else if (periodic[1])
            FLOOD_VISIT(u + sx - layer);
        if (y > 0)
            FLOOD_VISIT(u - sx);
        else if (periodic[1])
            FLOOD_VISIT(u + layer - sx);
        if (z + 1 < (size_t)nz)
            FLOOD_VISIT(u + layer);
        if (z > 0)
            FLOOD_VISIT(u - layer);
    }
#undef FLOOD_VISIT
    gs_free(queue);
    return tail;
}

size_t gs_model_support_floating(const uint16_t *labels, int nx, int ny, int nz,
                                 const gs_model_params *p, uint8_t *st)
{
    const size_t layer = (size_t)nx * (size_t)ny, n = layer * (size_t)nz;
    const int above = p->support_above ? p->support_layers_above : 0;
    size_t solid = 0;
    for (size_t i = 0; i < n; i++) {
        st[i] = !p->support_empty[labels[i]];
        solid += st[i];
    }
    for (int k = 0; k < above && nz > 0; k++) /* the decoded layers over the top one */
        for (size_t i = 0; i < layer; i++) {
            uint8_t v = (p->support_above[labels[n - layer + i]] >> k) & 1;
            st[n + (size_t)k * layer + i] = v;
            solid += v;
        }
    size_t reached = support_flood(st, nx, ny, nz + above, p->periodic);
    return reached == SIZE_MAX ? SIZE_MAX : solid - reached;
}

/* params.support_global: 1 when gs_model_support_floating finds no floating
 * cell in the whole lattice (box cells from the solved domains, the others
 * from lat overlaid with ov): exact where box_supported takes a non-empty
 * cell next to the box as supported. -1: no memory. */
static int lattice_supported(struct gs_model_solver *s, const gs_model_lattice *lat,
                             const overlay *ov, const gs_model_box *b, const gs_model_params *p)
{
    const int nx = lat->nx, ny = lat->ny, nz = lat->nz;
    const size_t n = (size_t)nx * (size_t)ny * (size_t)nz, W = (size_t)s->W;
    const size_t extra = (size_t)nx * (size_t)ny * (size_t)(p->support_above ? p->support_layers_above : 0);
    const int rx = b->x1 - b->x0, ry = b->y1 - b->y0;
    uint16_t *view = gs_malloc((n ? n : 1) * sizeof *view);
    uint8_t *st = gs_malloc(n + extra ? n + extra : 1);
    if (!view || !st) {
        gs_free(view);
        gs_free(st);
        return -1;
    }
    for (int z = 0; z < nz; z++)
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++) {
                int m;
                if (x >= b->x0 && x < b->x1 && y >= b->y0 && y < b->y1 && z >= b->z0 && z < b->z1)
                    m = first_label(s->dom + ((size_t)(x - b->x0) +
                                              (size_t)rx * ((size_t)(y - b->y0) +
                                                            (size_t)ry * (size_t)(z - b->z0))) *
                                                 W);
                else
                    m = overlay_label(lat, ov, x, y, z);
                view[gs_model_lattice_index(lat, x, y, z)] = (uint16_t)(m < s->L ? m : 0);
            }
    size_t nf = gs_model_support_floating(view, nx, ny, nz, p, st);
    gs_free(view);
    gs_free(st);
    return nf == SIZE_MAX ? -1 : nf == 0;
}

/* Runs up to p->attempts tries on box b (shell from lat overlaid with ov) and
 * on success writes b's labels into ov's buffer. The undo budget grows with
 * the attempt: x1 for the first quarter of the tries, x2, x4, then x8.
 * Scan order: try k runs the scan from corner k mod 4 of the box (x, then y
 * reversed; the author's own for try 0). A try's streams differ, but with
 * resemblance at the minimum distance (resemblance_slack 0) nearly every
 * choice has one closest neighbourhood, so the tries of one scan were
 * replays of one search: castle-10x's regions that failed once failed 13-20
 * times, each stuck where the scan meets a face whose content its first
 * slices did not see coming (budget spent undoing the last 2-3 slices), on
 * 14 of seeds 1-30 one such region held 44-87% of the synthesis CPU. From
 * another corner the face met last is met first: no region of seeds 1-30
 * needed more than 3 tries (configs/model/DEFAULTS.md, "Tries that replay"). */
static gs_err run_box(struct gs_model_solver *s, const gs_model_lattice *lat, const overlay *ov,
                      uint16_t *obuf, const gs_model_box *b, const gs_model_params *p,
                      uint64_t region_id, uint64_t pass, uint64_t path,
                      gs_model_region_result *res, int *ok)
{
    *ok = 0;
    const int q = p->attempts >= 4 ? p->attempts / 4 : 1;
    for (int attempt = 0; attempt < p->attempts && !*ok; attempt++) {
        gs_rng rng;
        gs_rng_init(&rng, p->seed,
                    gs_rng_stream_id(GS_MODEL_RNG_DOMAIN, region_id, pass,
                                     (uint64_t)attempt | (path << 32)));
        int scale = attempt / q >= 3 ? 8 : 1 << (attempt / q);
        GS_CALL(attempt_region(s, lat, ov, b, p, scale, attempt & 3, &rng, &res->choices, ok));
        res->attempts++;
        if (*ok && p->support_empty) { /* a try leaving floating structure is a failed try */
            int sup = p->support_global ? lattice_supported(s, lat, ov, b, p)
                                        : box_supported(s, lat, ov, b, p->support_empty);
            GS_CHECK(sup >= 0, GS_ERR_MEM, "support check: cannot allocate");
            *ok = sup;
        }
    }
    if (!*ok)
        return GS_OK;
    const gs_model_box *o = ov->ob;
    const size_t W = (size_t)s->W;
    size_t c = 0;
    for (int z = b->z0; z < b->z1; z++)
        for (int y = b->y0; y < b->y1; y++)
            for (int x = b->x0; x < b->x1; x++, c++) {
                obuf[(size_t)(x - o->x0) +
                     (size_t)(o->x1 - o->x0) *
                         ((size_t)(y - o->y0) + (size_t)(o->y1 - o->y0) * (size_t)(z - o->z0))] =
                    (uint16_t)first_label(s->dom + c * W);
            }
    return GS_OK;
}

/* Box b failed: split it into 2x2 sub-boxes along x and y (halves, when the
 * edge is at least 2*GS_MODEL_MIN_SPLIT) and run them in a fixed order, each
 * seeing its already resampled siblings; a failing sub-box splits again up
 * to depth levels. *kept counts the cells that keep their old labels. */
#define GS_MODEL_MIN_SPLIT 3
static gs_err split_box(struct gs_model_solver *s, const gs_model_lattice *lat, const overlay *ov,
                        uint16_t *obuf, const gs_model_box *b, const gs_model_params *p,
                        uint64_t region_id, uint64_t pass, uint64_t path, int depth,
                        gs_model_region_result *res, uint64_t *kept)
{
    const int ex = b->x1 - b->x0, ey = b->y1 - b->y0;
    const int nxs = ex >= 2 * GS_MODEL_MIN_SPLIT ? 2 : 1, nys = ey >= 2 * GS_MODEL_MIN_SPLIT ? 2 : 1;
    if (depth <= 0 || nxs * nys == 1) {
        *kept += (uint64_t)ex * (uint64_t)ey * (uint64_t)(b->z1 - b->z0);
        return GS_OK;
    }
    for (int j = 0; j < nys; j++)
        for (int i = 0; i < nxs; i++) {
            gs_model_box sb = *b;
            if (nxs == 2) {
                sb.x0 = i ? b->x0 + ex / 2 : b->x0;
                sb.x1 = i ? b->x1 : b->x0 + ex / 2;
            }
            if (nys == 2) {
                sb.y0 = j ? b->y0 + ey / 2 : b->y0;
                sb.y1 = j ? b->y1 : b->y0 + ey / 2;
            }
            uint64_t sub = path * 5 + (uint64_t)(1 + i + 2 * j);
            int ok = 0;
            GS_CALL(run_box(s, lat, ov, obuf, &sb, p, region_id, pass, sub, res, &ok));
            if (!ok)
                GS_CALL(split_box(s, lat, ov, obuf, &sb, p, region_id, pass, sub, depth - 1, res,
                                  kept));
        }
    return GS_OK;
}

/* The params a region run reads, into the solver. */
static gs_err take_params(struct gs_model_solver *s, const gs_model_params *p)
{
    if (s->ac != p->ac) {
        s->ac = p->ac;
        s->support_cap = 0; /* force (re)allocation of AC-4 counts */
    }
    s->weights_kind = p->weights;
    s->pins = p->pins;
    s->shape = p->shape;
    s->resem = p->resem;
    s->shape_weight = p->shape_weight;
    s->structure = p->structure;
    s->shape_slack = p->shape_slack;
    GS_CHECK(!p->shape || p->structure, GS_ERR_ARG, "params.shape needs params.structure");
    for (int a = 0; a < 3; a++) {
        s->mirror[a] = p->mirror[a];
        s->mirror_odd[a] = p->mirror_odd[a];
        s->mirror_map[a] = p->mirror_map[a];
    }
    s->ground = p->ground;
    s->ground_only = p->ground_only;
    s->rotate_map = p->rotate_map;
    s->zface[0] = p->zface[0];
    s->zface[1] = p->zface[1];
    for (int f = 0; f < 4; f++)
        s->xyface[f] = p->xyface[f];
    s->outside_col = p->outside_column;
    for (int a = 0; a < s->L; a++)
        s->weights[a] = s->rules->count[a];
    return GS_OK;
}

gs_err gs_model_resem_choose_at(struct gs_model_solver *s, const gs_model_lattice *lat,
                                const gs_model_box *b, const gs_model_params *p,
                                const uint64_t *dom, int32_t c, gs_rng *rng, int *label)
{
    GS_CHECK(p->resem != NULL && !p->resem->zshare, GS_ERR_ARG,
             "gs_model_resem_choose_at: params.resem is not set or has a label-frequency weight");
    GS_CALL(take_params(s, p));
    int ok = 0;
    GS_CALL(setup_region(s, lat, NULL, b, p->periodic, &ok));
    GS_CHECK(c >= 0 && (size_t)c < s->n, GS_ERR_ARG, "gs_model_resem_choose_at: cell %d", (int)c);
    memcpy(s->dom, dom, s->n * (size_t)s->W * 8);
    GS_CHECK(gs_model_solver_recount(s), GS_ERR_ARG, "gs_model_resem_choose_at: an empty cell");
    for (int32_t u = 0; u < (int32_t)s->n; u++)
        rs_note(s, u);
    *label = choose_label_resem(s, c, rng);
    return GS_OK;
}

gs_err gs_model_region_run(gs_model_solver_t s, const gs_model_lattice *lat,
                           const gs_model_box *b, const gs_model_params *p,
                           uint64_t region_id, uint64_t pass, uint16_t *out,
                           gs_model_region_result *res)
{
    GS_CHECK(b->x0 >= 0 && b->y0 >= 0 && b->z0 >= 0 && b->x1 <= lat->nx && b->y1 <= lat->ny &&
                 b->z1 <= lat->nz && b->x0 < b->x1 && b->y0 < b->y1 && b->z0 < b->z1,
             GS_ERR_ARG, "region [%d,%d)x[%d,%d)x[%d,%d) is empty or outside the %dx%dx%d lattice",
             b->x0, b->x1, b->y0, b->y1, b->z0, b->z1, lat->nx, lat->ny, lat->nz);
    GS_CHECK(p->attempts >= 1, GS_ERR_ARG, "model.attempts = %d: expected >= 1", p->attempts);
    GS_CHECK(p->split_depth >= 0 && p->split_depth <= 8, GS_ERR_ARG,
             "model.split_depth = %d: expected an integer in [0, 8]", p->split_depth);
    GS_CALL(take_params(s, p));
    memset(res, 0, sizeof *res);
    const uint64_t bt0 = s->backtracks_done;
    size_t c = 0;
    for (int z = b->z0; z < b->z1; z++)
        for (int y = b->y0; y < b->y1; y++)
            for (int x = b->x0; x < b->x1; x++, c++)
                out[c] = lat->labels[gs_model_lattice_index(lat, x, y, z)];
    overlay ov = {b, out};
    int ok = 0;
    GS_CALL(run_box(s, lat, &ov, out, b, p, region_id, pass, 0, res, &ok));
    if (ok) {
        res->ok = 1;
    } else if (p->split_depth > 0) {
        uint64_t kept = 0;
        GS_CALL(split_box(s, lat, &ov, out, b, p, region_id, pass, 0, p->split_depth, res, &kept));
        res->kept_cells = kept;
        res->ok = kept == 0;
        res->partial = !res->ok && kept < (uint64_t)c;
        res->split = 1;
    } else {
        res->kept_cells = c;
    }
    if ((res->ok || res->partial) && p->shape && p->shape_mh > 0 && pass > 0) {
        /* Metropolis step (paper Sec. 4.2): accept with min(1, f(M')/f(M)),
         * from the second pass on: the first replaces the start model, which
         * is no sample of the example (one column repeated: a region that kept
         * it would keep a carpet of the corner column's bushes) */
        double dE = 0;
        size_t k = 0;
        for (int z = b->z0; z < b->z1; z++)
            for (int y = b->y0; y < b->y1; y++)
                for (int x = b->x0; x < b->x1; x++, k++) {
                    int o = lat->labels[gs_model_lattice_index(lat, x, y, z)], n = out[k];
                    int so = o < s->L && p->structure[o], sn = n < s->L && p->structure[n];
                    if (so != sn)
                        dE += (sn - so) * (2.0 * p->shape[(size_t)x + (size_t)lat->nx * (size_t)y] - 1);
                }
        if (dE < 0) {
            gs_rng rng;
            gs_rng_init(&rng, p->seed, gs_rng_stream_id(GS_MODEL_MH_DOMAIN, region_id, pass, 0));
            if (gs_rng_uniform(&rng) >= exp(p->shape_mh * dE)) {
                res->ok = res->partial = 0;
                res->mh_rejected = 1;
            }
        }
    }
    res->backtracks = s->backtracks_done - bt0;
    return GS_OK;
}

void gs_model_region_apply(gs_model_lattice *lat, const gs_model_box *b, const uint16_t *labels)
{
    size_t c = 0;
    for (int z = b->z0; z < b->z1; z++)
        for (int y = b->y0; y < b->y1; y++) {
            size_t row = gs_model_lattice_index(lat, b->x0, y, z);
            size_t len = (size_t)(b->x1 - b->x0);
            memcpy(lat->labels + row, labels + c, len * sizeof *labels);
            c += len;
        }
}
