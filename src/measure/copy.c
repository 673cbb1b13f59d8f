/* Copied regions of a synthesized grid against its example (see
 * include/geosynth/measure.h, gs_measure_copy3).
 *
 * Windows are hashed exactly: each x row of k <= 8 bytes is packed into a
 * uint64, the k^2 rows are combined with fixed random odd multipliers and a
 * final mix, and every hit is verified byte by byte, so the measure never
 * mistakes a collision for a copy. Regions are joined with a union-find over
 * two planes of output positions (path halving), each region's size counted
 * when it ends (the reference keeps every plane: the same figures). A window the source
 * repeats continues a lower neighbour's offset when the source agrees there
 * (checked byte by byte), so a copy of a repetitive source is seen whole.
 * Speed (#19: the table is larger than the caches, its lookups were most of
 * the cost): an output window equal to the source's one step on from where
 * a lower neighbour's window was found takes that source position's entry
 * (recorded when the table was built), and a filter of one bit per hash
 * class (in cache) skips the lookup of most windows absent from the source;
 * the figures are those of looking every window up
 * (gs_measure_copy3_reference). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "unionfind.h"

typedef struct win_entry {
    uint64_t h;
    uint32_t pos;  /* first source position with this content */
    uint32_t count;
    uint32_t pos2; /* the second one (count >= 2): a period candidate */
} win_entry;

/* Exact periods of the source (translations v with src[x + v] == src[x]
 * wherever both are inside), and positions reduced modulo them. */
#define MAX_PERIODS 12
typedef struct periods {
    int n;
    int64_t v[MAX_PERIODS][3];
    int64_t sp[3];                 /* window positions per axis */
} periods;

/* Does translation v map src onto itself wherever both are inside (with at
 * least half of the source overlapping)? */
static int is_period(const uint8_t *src, const int64_t sn[3], const int64_t v[3])
{
    int64_t lo[3], hi[3], over = 1;
    for (int a = 0; a < 3; a++) {
        lo[a] = v[a] < 0 ? -v[a] : 0, hi[a] = v[a] > 0 ? sn[a] - v[a] : sn[a];
        if (hi[a] <= lo[a])
            return 0;
        over *= hi[a] - lo[a];
    }
    if (2 * over < sn[0] * sn[1] * sn[2] / 4)
        return 0;
    int64_t d = v[0] + sn[0] * (v[1] + sn[1] * v[2]);
    for (int64_t z = lo[2]; z < hi[2]; z++)
        for (int64_t y = lo[1]; y < hi[1]; y++) {
            int64_t i = lo[0] + sn[0] * (y + sn[1] * z);
            if (memcmp(src + i, src + i + d, (size_t)(hi[0] - lo[0])))
                return 0;
        }
    return 1;
}

/* How far c lies outside the window positions (0: inside). */
static inline int64_t outside(const periods *P, const int64_t c[3])
{
    int64_t d = 0;
    for (int a = 0; a < 3; a++)
        d += c[a] < 0 ? -c[a] : c[a] >= P->sp[a] ? c[a] - P->sp[a] + 1 : 0;
    return d;
}

/* Position c reduced modulo the periods: moved by +-v while that brings it
 * inside or to a lower linear index (deterministic; the lowest translate for
 * the lattices met here). Returns the linear index, or -2 when no translate
 * is inside (never the -1 of an unmatched position). */
static int64_t reduce(const periods *P, const int64_t c0[3])
{
    int64_t c[3] = {c0[0], c0[1], c0[2]};
    for (int moved = 1; moved;) {
        moved = 0;
        for (int i = 0; i < P->n; i++)
            for (int sg = -1; sg <= 1; sg += 2) {
                int64_t t[3] = {c[0] + sg * P->v[i][0], c[1] + sg * P->v[i][1], c[2] + sg * P->v[i][2]};
                int64_t ot = outside(P, t), oc = outside(P, c);
                int64_t lt = t[0] + P->sp[0] * (t[1] + P->sp[1] * t[2]);
                int64_t lc = c[0] + P->sp[0] * (c[1] + P->sp[1] * c[2]);
                if (ot < oc || (ot == 0 && oc == 0 && lt < lc)) {
                    memcpy(c, t, sizeof c);
                    moved = 1;
                }
            }
    }
    if (outside(P, c))
        return -2;
    return c[0] + P->sp[0] * (c[1] + P->sp[1] * c[2]);
}

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

static inline uint64_t row_at(const uint8_t *p, int k)
{
    uint64_t r = 0;
    memcpy(&r, p, (size_t)k);
    return r;
}

/* Hash of the window at base; *flat = 1 when all its samples are equal (such
 * windows are skipped: constant space says nothing about provenance). */
static inline uint64_t win_hash(const uint8_t *g, const int64_t n[3], int64_t base, int k,
                                const uint64_t *mul, int *flat)
{
    uint64_t h = 0;
    if (k == 4) { /* the engine's window: one 32-bit load per row */
        uint32_t r0;
        memcpy(&r0, g + base, 4);
        uint32_t diff = r0 ^ (uint32_t)(r0 & 0xffu) * 0x01010101u;
        for (int c = 0; c < 4; c++)
            for (int b = 0; b < 4; b++) {
                uint32_t r;
                memcpy(&r, g + base + n[0] * (b + n[1] * c), 4);
                diff |= r ^ r0;
                h += (uint64_t)r * mul[b + 8 * c];
            }
        *flat = diff == 0;
        return mix64(h);
    }
    *flat = 0;
    for (int c = 0; c < k; c++)
        for (int b = 0; b < k; b++)
            h += row_at(g + base + n[0] * (b + n[1] * c), k) * mul[b + 8 * c];
    return mix64(h);
}

static int win_equal(const uint8_t *a, const int64_t an[3], int64_t ab, const uint8_t *b,
                     const int64_t bn[3], int64_t bb, int k)
{
    if (k == 4) { /* the engine's window: 32-bit rows, no library call */
        uint32_t diff = 0;
        for (int c = 0; c < 4; c++)
            for (int r = 0; r < 4; r++) {
                uint32_t ra, rb;
                memcpy(&ra, a + ab + an[0] * (r + an[1] * c), 4);
                memcpy(&rb, b + bb + bn[0] * (r + bn[1] * c), 4);
                diff |= ra ^ rb;
            }
        return diff == 0;
    }
    for (int c = 0; c < k; c++)
        for (int r = 0; r < k; r++)
            if (memcmp(a + ab + an[0] * (r + an[1] * c), b + bb + bn[0] * (r + bn[1] * c),
                       (size_t)k))
                return 0;
    return 1;
}

/* The window position (x fastest over sp) of the window at sample index b. */
static inline int64_t win_index(int64_t b, const int64_t sn[3], const int64_t sp[3])
{
    return b % sn[0] + sp[0] * (b / sn[0] % sn[1] + sp[1] * (b / (sn[0] * sn[1])));
}

/* Values of the lower x, y, z neighbours of plane position pi (cur: this
 * plane, prev: the one below; -1 outside), and the coordinates of window
 * position i. */
static inline void lower_neighbours(const int64_t *cur, const int64_t *prev, int64_t pi, int64_t x,
                                    int64_t y, int64_t z, int64_t row, int64_t nb[3])
{
    nb[0] = x > 0 ? cur[pi - 1] : -1;
    nb[1] = y > 0 ? cur[pi - row] : -1;
    nb[2] = z > 0 ? prev[pi] : -1;
}

static inline void win_coords(int64_t i, const int64_t sp[3], int64_t t[3])
{
    t[0] = i % sp[0], t[1] = i / sp[0] % sp[1], t[2] = i / (sp[0] * sp[1]);
}

/* The table's entry holding the window of g at base, or NULL. */
static const win_entry *lookup(const win_entry *tab, size_t cap, uint64_t h, const uint8_t *src,
                               const int64_t sn[3], const uint8_t *g, const int64_t gn[3],
                               int64_t base, int k)
{
    for (size_t i = (size_t)h & (cap - 1); tab[i].count; i = (i + 1) & (cap - 1))
        if (tab[i].h == h && win_equal(src, sn, tab[i].pos, g, gn, base, k))
            return &tab[i];
    return NULL;
}

static int cmp_i64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return x < y ? -1 : x > y;
}

static gs_err find_periods(const win_entry *tab, size_t cap, const uint8_t *src, const int64_t sn[3],
                           periods *P)
{
    size_t nd = 0;
    for (size_t i = 0; i < cap; i++)
        nd += tab[i].count >= 2;
    if (!nd)
        return GS_OK;
    int64_t *d = NULL;
    GS_CALL(gs_alloc_array((void **)&d, nd, sizeof *d, "copy measure: period candidates"));
    nd = 0;
    for (size_t i = 0; i < cap; i++)
        if (tab[i].count >= 2)
            d[nd++] = (int64_t)tab[i].pos2 - (int64_t)tab[i].pos; /* > 0: in scan order */
    qsort(d, nd, sizeof *d, cmp_i64);
    /* the most frequent differences, tried in order of frequency (ties: the
     * smaller difference) */
    for (int tries = 0; tries < 4 * MAX_PERIODS && P->n < MAX_PERIODS; tries++) {
        size_t best = 0, bn = 0;
        for (size_t i = 0; i < nd;) {
            size_t j = i;
            while (j < nd && d[j] == d[i])
                j++;
            if (d[i] != 0 && j - i > bn)
                best = i, bn = j - i;
            i = j;
        }
        if (bn < 2)
            break;
        int64_t L = d[best];
        for (size_t i = 0; i < nd; i++)
            if (d[i] == L)
                d[i] = 0; /* tried */
        /* linear difference -> vector (x may be negative: a row below) */
        int64_t sxy = sn[0] * sn[1], vz = L / sxy, r = L - vz * sxy;
        int64_t vy = r / sn[0], vx = r - vy * sn[0];
        if (vx > sn[0] / 2)
            vx -= sn[0], vy++;
        if (vy > sn[1] / 2)
            vy -= sn[1], vz++;
        int64_t v[3] = {vx, vy, vz};
        int known = 0;
        for (int i = 0; i < P->n; i++)
            known |= (P->v[i][0] == v[0] && P->v[i][1] == v[1] && P->v[i][2] == v[2]) ||
                     (P->v[i][0] == -v[0] && P->v[i][1] == -v[1] && P->v[i][2] == -v[2]);
        if (!known && is_period(src, sn, v)) {
            memcpy(P->v[P->n], v, sizeof v);
            P->n++;
        }
    }
    gs_free(d);
    return GS_OK;
}

/* Copied regions counted as they end (positions join only lower neighbours,
 * so a region with no position in the plane just done has ended): the
 * union-find holds two planes of positions, each root the region's size. */
typedef struct region_sizes {
    int64_t regions, largest, in_large, large;
} region_sizes;

static void region_union(uint32_t *p, uint64_t *size, uint32_t a, uint32_t b)
{
    a = uf_find(p, a), b = uf_find(p, b);
    if (a == b)
        return;
    if (b < a) {
        uint32_t t = a;
        a = b, b = t;
    }
    p[b] = a;
    size[a] += size[b];
}

static void region_end(region_sizes *rs, uint64_t size)
{
    rs->regions++;
    if ((int64_t)size > rs->largest)
        rs->largest = (int64_t)size;
    if ((int64_t)size > rs->large)
        rs->in_large += (int64_t)size;
}

/* A plane done: its positions (slots [cb, cb + n); UINT32_MAX: none) take
 * roots among themselves (a region's root below moves up to its first
 * position here) and point at them directly, so the plane below (slots
 * [pb, pb + n); UINT32_MAX: none) can be overwritten; the regions still
 * rooted there have ended. */
static void planes_done(uint32_t *p, uint64_t *size, uint32_t cb, uint32_t pb, uint32_t n,
                        region_sizes *rs)
{
    for (uint32_t i = cb; cb != UINT32_MAX && i < cb + n; i++) {
        if (p[i] == UINT32_MAX)
            continue;
        uint32_t r = uf_find(p, i);
        if (pb != UINT32_MAX && r >= pb && r < pb + n) {
            p[r] = i, p[i] = i;
            size[i] = size[r];
        }
    }
    for (uint32_t i = cb; cb != UINT32_MAX && i < cb + n; i++)
        if (p[i] != UINT32_MAX)
            p[i] = uf_find(p, i);
    for (uint32_t i = pb; pb != UINT32_MAX && i < pb + n; i++)
        if (p[i] == i)
            region_end(rs, size[i]);
}

/* fast: an output window found one step on from a lower neighbour's source
 * position takes that position's entry, and a filter skips most absent
 * windows; 0: every output window is looked up in the table (the reference) */
static gs_err copy3(const uint8_t *out, const int64_t on[3], const uint8_t *src,
                    const int64_t sn[3], int k, int64_t large, int cell, int fast,
                    gs_measure_copy *m)
{
    memset(m, 0, sizeof *m);
    m->window = k;
    GS_CHECK(k >= 2 && k <= 8 && cell >= 1, GS_ERR_ARG,
             "copy measure: window %d (expected 2..8), cell %d (expected >= 1)", k, cell);
    int64_t sp[3], op[3];
    for (int a = 0; a < 3; a++) {
        sp[a] = sn[a] - k + 1, op[a] = on[a] - k + 1;
        GS_CHECK(sp[a] >= 1 && op[a] >= 1, GS_ERR_ARG,
                 "copy measure: window %d larger than the source (%lld) or output (%lld) on axis %d",
                 k, (long long)sn[a], (long long)on[a], a);
    }
    int64_t ns = sp[0] * sp[1] * sp[2], no = op[0] * op[1] * op[2];
    GS_CHECK(no < (int64_t)UINT32_MAX, GS_ERR_ARG, "copy measure: %lld output positions is too many",
             (long long)no);
    GS_CHECK(sn[0] * sn[1] * sn[2] < (int64_t)UINT32_MAX, GS_ERR_ARG,
             "copy measure: a source of %lld samples is too large", (long long)(sn[0] * sn[1] * sn[2]));
    m->positions = no;
    uint64_t mul[64];
    for (int i = 0; i < 64; i++)
        mul[i] = mix64(0x9e3779b97f4a7c15ULL * (uint64_t)(i + 1)) | 1;
    size_t cap = 1;
    while (cap < 2 * (size_t)ns)
        cap <<= 1;
    win_entry *tab = NULL;
    uint32_t *parent = NULL; /* union-find over the two planes of positions in flight */
    uint64_t *rsize = NULL;  /* positions of the region at each root */
    int64_t *opos = NULL; /* matched source position of the two planes in flight */
    int64_t *fpos = NULL; /* and a source position holding the same window (a prediction) */
    uint32_t *first = NULL; /* per source position: its window's entry (first occurrence), or none */
    uint8_t *used = NULL, *uniq = NULL;
    uint64_t *seen = NULL; /* one bit per hash value class: a window absent from the source
                              is mostly known absent without a probe of the (large) table */
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&tab, cap, sizeof *tab, "copy measure: window table"), done);
    memset(tab, 0, cap * sizeof *tab);
    GS_TRY(err, gs_alloc_array((void **)&first, (size_t)ns, sizeof *first, "copy measure: entries"), done);
    periods P;
    memset(&P, 0, sizeof P);
    memcpy(P.sp, sp, sizeof P.sp);
    for (int pass = 0;; pass++) {
        /* pass 0: every position; later passes (a periodic source): the
         * positions reduced modulo the periods found so far */
        for (int64_t z = 0; z < sp[2]; z++)
            for (int64_t y = 0; y < sp[1]; y++)
                for (int64_t x = 0; x < sp[0]; x++) {
                    if (pass && reduce(&P, (int64_t[3]){x, y, z}) != x + sp[0] * (y + sp[1] * z))
                        continue;
                    int64_t base = x + sn[0] * (y + sn[1] * z);
                    int flat;
                    uint64_t h = win_hash(src, sn, base, k, mul, &flat);
                    size_t i = (size_t)h & (cap - 1);
                    int64_t fp = x + sp[0] * (y + sp[1] * z);
                    for (;; i = (i + 1) & (cap - 1)) {
                        win_entry *e = &tab[i];
                        if (!e->count) {
                            e->h = h, e->pos = e->pos2 = (uint32_t)base, e->count = 1 + flat;
                            break;
                        }
                        if (e->h == h && win_equal(src, sn, e->pos, src, sn, base, k)) {
                            if (e->count++ == 1)
                                e->pos2 = (uint32_t)base;
                            fp = win_index(e->pos, sn, sp);
                            break;
                        }
                    }
                    /* each source window's entry (pass 0 holds them all),
                     * so an output window found at a source position (a
                     * neighbour's continued) needs no lookup */
                    if (!pass)
                        first[x + sp[0] * (y + sp[1] * z)] = flat ? UINT32_MAX : (uint32_t)fp;
                }
        /* periods: the translations between the first two occurrences of
         * repeated windows, most frequent first, that map the whole source
         * onto itself. The first two occurrences mostly differ by one
         * period (chainmail.ini: 24 along x), the next ones show among the
         * positions reduced modulo it (its face-centred periods (-12, 12, 0)
         * ...), so this repeats until no new one shows */
        int had = P.n;
        if (pass < 4)
            GS_TRY(err, find_periods(tab, cap, src, sn, &P), done);
        if (P.n == had)
            break;
        memset(tab, 0, cap * sizeof *tab);
    }
    m->periods = P.n;
    /* the filter: 8 bits per table slot (>= 16 per source window), indexed
     * by hash bits above the table's; exact (a set bit only means: probe) */
    size_t seen_words = cap / 8;
    GS_TRY(err, gs_alloc_array((void **)&seen, seen_words, sizeof *seen, "copy measure: window filter"), done);
    memset(seen, 0, seen_words * sizeof *seen);
    for (size_t i = 0; i < cap; i++)
        if (tab[i].count) {
            size_t b = (size_t)(tab[i].h >> 32) & (64 * seen_words - 1);
            seen[b >> 6] |= 1ULL << (b & 63);
        }
    for (int i = 0; i < P.n; i++) {
        int64_t l2 = P.v[i][0] * P.v[i][0] + P.v[i][1] * P.v[i][1] + P.v[i][2] * P.v[i][2];
        if (!m->shortest_period || (double)l2 < m->shortest_period * m->shortest_period)
            m->shortest_period = sqrt((double)l2);
    }
    /* source windows: unique ones, and which of them the output uses */
    GS_TRY(err, gs_alloc_array((void **)&used, (size_t)ns, 1, "copy measure: used windows"), done);
    GS_TRY(err, gs_alloc_array((void **)&uniq, (size_t)ns, 1, "copy measure: unique windows"), done);
    memset(used, 0, (size_t)ns);
    memset(uniq, 0, (size_t)ns);
    int64_t nuniq = 0;
    for (size_t i = 0; i < cap; i++)
        if (tab[i].count == 1) {
            uniq[win_index(tab[i].pos, sn, sp)] = 1;
            nuniq++;
        }
    /* a periodic source: the final table holds the reduced positions, so
     * each position's entry is looked up */
    for (int64_t z = 0; P.n && z < sp[2]; z++)
        for (int64_t y = 0; y < sp[1]; y++)
            for (int64_t x = 0; x < sp[0]; x++) {
                int64_t base = x + sn[0] * (y + sn[1] * z);
                int flat;
                uint64_t h = win_hash(src, sn, base, k, mul, &flat);
                const win_entry *e = flat ? NULL : lookup(tab, cap, h, src, sn, src, sn, base, k);
                first[x + sp[0] * (y + sp[1] * z)] = e ? (uint32_t)win_index(e->pos, sn, sp) : UINT32_MAX;
            }
    int64_t nred = ns;
    if (P.n) {
        nred = 0;
        for (int64_t z = 0; z < sp[2]; z++)
            for (int64_t y = 0; y < sp[1]; y++)
                for (int64_t x = 0; x < sp[0]; x++)
                    nred += reduce(&P, (int64_t[3]){x, y, z}) == x + sp[0] * (y + sp[1] * z);
    }
    m->source_unique_share = (double)nuniq / (double)nred;
    size_t plane = (size_t)(op[0] * op[1]);
    /* the reference keeps every plane's positions (a region's size counted
     * at the end), the fast one two planes in flight */
    size_t slots = fast ? 2 * plane : (size_t)no;
    GS_TRY(err, gs_alloc_array((void **)&parent, slots, sizeof *parent, "copy measure: regions"), done);
    GS_TRY(err, gs_alloc_array((void **)&rsize, slots, sizeof *rsize, "copy measure: region sizes"), done);
    region_sizes rs = {0, 0, 0, large};
    GS_TRY(err, gs_alloc_array((void **)&opos, 2 * plane, sizeof *opos, "copy measure: planes"), done);
    GS_TRY(err, gs_alloc_array((void **)&fpos, 2 * plane, sizeof *fpos, "copy measure: planes"), done);
    int64_t matched = 0;
    for (int64_t z = 0; z < op[2]; z++) {
        int64_t *cur = opos + (z & 1) * plane, *prev = opos + ((z + 1) & 1) * plane;
        int64_t *fcur = fpos + (z & 1) * plane, *fprev = fpos + ((z + 1) & 1) * plane;
        /* this plane's positions are slots [cb, cb + plane), the plane
         * below's [pb, pb + plane) */
        const uint32_t cb = (uint32_t)((fast ? z & 1 : z) * (int64_t)plane),
                       pb = (uint32_t)((fast ? (z + 1) & 1 : z - 1) * (int64_t)plane);
        for (int64_t y = 0; y < op[1]; y++)
            for (int64_t x = 0; x < op[0]; x++) {
                int64_t base = x + on[0] * (y + on[1] * z), pi = x + op[0] * y;
                uint32_t id = cb + (uint32_t)pi;
                parent[id] = UINT32_MAX; /* unmatched positions never join */
                cur[pi] = -1;
                int flat, via = 0;
                uint64_t h = win_hash(out, on, base, k, mul, &flat);
                /* the window's entry, as its first occurrence (fi; once: its
                 * only one): where a lower neighbour's window was found one
                 * step on in the source (a copy continued: no lookup), else
                 * looked up (the filter first: most absent windows) */
                int64_t fi = -1;
                fcur[pi] = -1;
                if (!flat && fast) {
                    int64_t nf[3], t[3];
                    lower_neighbours(fcur, fprev, pi, x, y, z, op[0], nf);
                    for (int a = 0; a < 3 && fcur[pi] < 0; a++) {
                        if (nf[a] < 0)
                            continue;
                        win_coords(nf[a], sp, t);
                        if (++t[a] >= sp[a])
                            continue;
                        if (win_equal(src, sn, t[0] + sn[0] * (t[1] + sn[1] * t[2]), out, on, base, k)) {
                            int64_t tp = t[0] + sp[0] * (t[1] + sp[1] * t[2]);
                            fcur[pi] = tp;
                            fi = first[tp] == UINT32_MAX ? -1 : (int64_t)first[tp];
                        }
                    }
                }
                if (!flat && fcur[pi] < 0) {
                    size_t sb = (size_t)(h >> 32) & (64 * seen_words - 1);
                    const win_entry *e = !fast || (seen[sb >> 6] >> (sb & 63)) & 1
                                             ? lookup(tab, cap, h, src, sn, out, on, base, k)
                                             : NULL; /* else not in the source */
                    if (e)
                        fcur[pi] = fi = win_index(e->pos, sn, sp);
                }
                if (fi >= 0 && uniq[fi]) {
                    cur[pi] = fi;
                    used[cur[pi]] = 1;
                    matched++;
                } else if (fi >= 0) {
                    /* a window that occurs more than once in the source (most
                     * of a repetitive one's, grid.ini's): it continues the
                     * offset of a lower neighbour whose source position one
                     * step on holds it too (verified), else it starts at its
                     * first occurrence. So a verbatim copy of a repetitive
                     * source stays one region wherever its windows are
                     * ambiguous, and an offset chain is still exact */
                    int64_t nbs[3], t[3];
                    lower_neighbours(cur, prev, pi, x, y, z, op[0], nbs);
                    for (int a = 0; a < 3 && cur[pi] < 0; a++) {
                        if (nbs[a] < 0)
                            continue;
                        win_coords(nbs[a], sp, t);
                        t[a]++;
                        int64_t ti = P.n ? reduce(&P, t)
                                         : outside(&P, t) ? -2 : t[0] + sp[0] * (t[1] + sp[1] * t[2]);
                        if (ti < 0)
                            continue;
                        int64_t tb = ti % sp[0] + sn[0] * (ti / sp[0] % sp[1] + sn[1] * (ti / (sp[0] * sp[1])));
                        if (win_equal(src, sn, tb, out, on, base, k))
                            cur[pi] = ti, via = 1 << a;
                    }
                    if (cur[pi] < 0)
                        cur[pi] = fi;
                }
                int64_t s = cur[pi];
                if (s < 0)
                    continue;
                parent[id] = id, rsize[id] = 1;
                const uint32_t below = pb + (uint32_t)pi;
                if (via & 1)
                    region_union(parent, rsize, id, id - 1);
                if (via & 2)
                    region_union(parent, rsize, id, id - (uint32_t)op[0]);
                if (via & 4)
                    region_union(parent, rsize, id, below);
                /* same offset as a lower neighbour (modulo the periods): the
                 * same piece */
                if (!P.n) {
                    /* (not across a source row or plane: s - 1 at x = 0 is
                     * the previous row's end, another offset) */
                    if (x > 0 && s % sp[0] > 0 && cur[pi - 1] == s - 1)
                        region_union(parent, rsize, id, id - 1);
                    if (y > 0 && s / sp[0] % sp[1] > 0 && cur[pi - op[0]] == s - sp[0])
                        region_union(parent, rsize, id, id - (uint32_t)op[0]);
                    if (z > 0 && prev[pi] >= 0 && prev[pi] == s - sp[0] * sp[1])
                        region_union(parent, rsize, id, below);
                } else {
                    int64_t c[3] = {s % sp[0], s / sp[0] % sp[1], s / (sp[0] * sp[1])};
                    int64_t cx[3] = {c[0] - 1, c[1], c[2]}, cy[3] = {c[0], c[1] - 1, c[2]},
                            cz[3] = {c[0], c[1], c[2] - 1};
                    if (x > 0 && cur[pi - 1] >= 0 && cur[pi - 1] == reduce(&P, cx))
                        region_union(parent, rsize, id, id - 1);
                    if (y > 0 && cur[pi - op[0]] >= 0 && cur[pi - op[0]] == reduce(&P, cy))
                        region_union(parent, rsize, id, id - (uint32_t)op[0]);
                    if (z > 0 && prev[pi] >= 0 && prev[pi] == reduce(&P, cz))
                        region_union(parent, rsize, id, below);
                }
            }
        if (fast)
            planes_done(parent, rsize, cb, z > 0 ? pb : UINT32_MAX, (uint32_t)plane, &rs);
    }
    /* the last plane's regions end there (the reference: every region) */
    planes_done(parent, rsize, UINT32_MAX,
                fast ? (uint32_t)(((op[2] - 1) & 1) * plane) : 0, fast ? (uint32_t)plane : (uint32_t)no,
                &rs);
    m->matched_share = no ? (double)matched / (double)no : 0;
    m->regions = rs.regions;
    m->largest_region = rs.largest;
    m->large_share = no ? (double)rs.in_large / (double)no : 0;
    m->largest_region_of_source = (double)m->largest_region / (double)ns;
    /* completeness over source cells holding a unique window */
    int64_t cells = 0, hit = 0;
    for (int64_t cz = 0; cz < sp[2]; cz += cell)
        for (int64_t cy = 0; cy < sp[1]; cy += cell)
            for (int64_t cx = 0; cx < sp[0]; cx += cell) {
                int any = 0, got = 0;
                for (int64_t z = cz; z < cz + cell && z < sp[2]; z++)
                    for (int64_t y = cy; y < cy + cell && y < sp[1]; y++)
                        for (int64_t x = cx; x < cx + cell && x < sp[0]; x++) {
                            int64_t i = x + sp[0] * (y + sp[1] * z);
                            any |= uniq[i];
                            got |= used[i];
                        }
                cells += any;
                hit += any && got;
            }
    m->completeness = cells ? (double)hit / (double)cells : 0;
done:
    gs_free(tab);
    gs_free(parent);
    gs_free(rsize);
    gs_free(opos);
    gs_free(used);
    gs_free(uniq);
    gs_free(seen);
    gs_free(first);
    gs_free(fpos);
    return err;
}

gs_err gs_measure_copy3(const uint8_t *out, const int64_t on[3], const uint8_t *src,
                        const int64_t sn[3], int k, int64_t large, int cell, gs_measure_copy *m)
{
    return copy3(out, on, src, sn, k, large, cell, 1, m);
}

gs_err gs_measure_copy3_reference(const uint8_t *out, const int64_t on[3], const uint8_t *src,
                                  const int64_t sn[3], int k, int64_t large, int cell,
                                  gs_measure_copy *m)
{
    return copy3(out, on, src, sn, k, large, cell, 0, m);
}
