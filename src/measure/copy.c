/* Copied regions of a synthesized grid against its example (see
 * include/geosynth/measure.h, gs_measure_copy3).
 *
 * Windows are hashed exactly: each x row of k <= 8 bytes is packed into a
 * uint64, the k^2 rows are combined with fixed random odd multipliers and a
 * final mix, and every hit is verified byte by byte, so the measure never
 * mistakes a collision for a copy. Regions are joined with a union-find over
 * the output positions (parent array, path halving). */
#include <string.h>

#include "geosynth/measure.h"
#include "geosynth/mem.h"

typedef struct win_entry {
    uint64_t h;
    uint32_t pos;  /* first source position with this content */
    uint32_t count;
} win_entry;

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
    for (int c = 0; c < k; c++)
        for (int r = 0; r < k; r++)
            if (memcmp(a + ab + an[0] * (r + an[1] * c), b + bb + bn[0] * (r + bn[1] * c),
                       (size_t)k))
                return 0;
    return 1;
}

static uint32_t uf_find(uint32_t *p, uint32_t x)
{
    while (p[x] != x) {
        p[x] = p[p[x]];
        x = p[x];
    }
    return x;
}

static void uf_union(uint32_t *p, uint32_t a, uint32_t b)
{
    a = uf_find(p, a), b = uf_find(p, b);
    if (a < b)
        p[b] = a;
    else if (b < a)
        p[a] = b;
}

gs_err gs_measure_copy3(const uint8_t *out, const int64_t on[3], const uint8_t *src,
                        const int64_t sn[3], int k, int64_t large, int cell, gs_measure_copy *m)
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
    uint32_t *parent = NULL, *sizes = NULL;
    int64_t *opos = NULL; /* matched source position of the two planes in flight */
    uint8_t *used = NULL, *uniq = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&tab, cap, sizeof *tab, "copy measure: window table"), done);
    memset(tab, 0, cap * sizeof *tab);
    for (int64_t z = 0; z < sp[2]; z++)
        for (int64_t y = 0; y < sp[1]; y++)
            for (int64_t x = 0; x < sp[0]; x++) {
                int64_t base = x + sn[0] * (y + sn[1] * z);
                int flat;
                uint64_t h = win_hash(src, sn, base, k, mul, &flat);
                size_t i = (size_t)h & (cap - 1);
                for (;; i = (i + 1) & (cap - 1)) {
                    win_entry *e = &tab[i];
                    if (!e->count) {
                        e->h = h, e->pos = (uint32_t)base, e->count = 1 + flat;
                        break;
                    }
                    if (e->h == h && win_equal(src, sn, e->pos, src, sn, base, k)) {
                        e->count++;
                        break;
                    }
                }
            }
    /* source windows: unique ones, and which of them the output uses */
    GS_TRY(err, gs_alloc_array((void **)&used, (size_t)ns, 1, "copy measure: used windows"), done);
    GS_TRY(err, gs_alloc_array((void **)&uniq, (size_t)ns, 1, "copy measure: unique windows"), done);
    memset(used, 0, (size_t)ns);
    memset(uniq, 0, (size_t)ns);
    int64_t nuniq = 0;
    for (size_t i = 0; i < cap; i++)
        if (tab[i].count == 1) {
            int64_t b = tab[i].pos, x = b % sn[0], y = b / sn[0] % sn[1], z = b / (sn[0] * sn[1]);
            uniq[x + sp[0] * (y + sp[1] * z)] = 1;
            nuniq++;
        }
    m->source_unique_share = (double)nuniq / (double)ns;
    GS_TRY(err, gs_alloc_array((void **)&parent, (size_t)no, sizeof *parent, "copy measure: regions"), done);
    size_t plane = (size_t)(op[0] * op[1]);
    GS_TRY(err, gs_alloc_array((void **)&opos, 2 * plane, sizeof *opos, "copy measure: planes"), done);
    int64_t matched = 0;
    for (int64_t z = 0; z < op[2]; z++) {
        int64_t *cur = opos + (z & 1) * plane, *prev = opos + ((z + 1) & 1) * plane;
        for (int64_t y = 0; y < op[1]; y++)
            for (int64_t x = 0; x < op[0]; x++) {
                int64_t base = x + on[0] * (y + on[1] * z), pi = x + op[0] * y;
                uint32_t id = (uint32_t)(pi + (int64_t)plane * z);
                parent[id] = id;
                cur[pi] = -1;
                int flat;
                uint64_t h = win_hash(out, on, base, k, mul, &flat);
                for (size_t i = (size_t)h & (cap - 1); tab[i].count; i = (i + 1) & (cap - 1)) {
                    if (flat)
                        break;
                    const win_entry *e = &tab[i];
                    if (e->h == h && win_equal(src, sn, e->pos, out, on, base, k)) {
                        if (e->count == 1) {
                            int64_t b = e->pos, sx = b % sn[0], sy = b / sn[0] % sn[1],
                                    sz = b / (sn[0] * sn[1]);
                            cur[pi] = sx + sp[0] * (sy + sp[1] * sz);
                            used[cur[pi]] = 1;
                        }
                        break;
                    }
                }
                int64_t s = cur[pi];
                if (s < 0)
                    continue;
                matched++;
                /* same offset as a lower neighbour: the same piece */
                if (x > 0 && cur[pi - 1] == s - 1)
                    uf_union(parent, id, id - 1);
                if (y > 0 && cur[pi - op[0]] == s - sp[0])
                    uf_union(parent, id, id - (uint32_t)op[0]);
                if (z > 0 && prev[pi] == s - sp[0] * sp[1])
                    uf_union(parent, id, id - (uint32_t)plane);
            }
        /* unmatched positions never join: mark them so they are not counted */
        for (int64_t i = 0; i < (int64_t)plane; i++)
            if (cur[i] < 0)
                parent[i + (int64_t)plane * z] = UINT32_MAX;
    }
    m->matched_share = no ? (double)matched / (double)no : 0;
    /* region sizes at their roots (reuse the table as no longer needed) */
    gs_free(tab);
    tab = NULL;
    GS_TRY(err, gs_alloc_array((void **)&sizes, (size_t)no, sizeof *sizes, "copy measure: sizes"), done);
    memset(sizes, 0, (size_t)no * sizeof *sizes);
    for (int64_t i = 0; i < no; i++)
        if (parent[i] != UINT32_MAX)
            sizes[uf_find(parent, (uint32_t)i)]++;
    int64_t in_large = 0;
    for (int64_t i = 0; i < no; i++)
        if (sizes[i]) {
            m->regions++;
            if ((int64_t)sizes[i] > m->largest_region)
                m->largest_region = sizes[i];
            if ((int64_t)sizes[i] > large)
                in_large += sizes[i];
        }
    m->large_share = no ? (double)in_large / (double)no : 0;
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
    gs_free(sizes);
    gs_free(opos);
    gs_free(used);
    gs_free(uniq);
    return err;
}
