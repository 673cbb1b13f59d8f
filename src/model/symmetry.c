/* Label symmetry of the paper's Sec. 4.1 (T' = S.T): which label is the
 * mirror image of which, learned from the example's transition function or
 * given as label pairs, and the transition function restricted to pairs
 * whose image is allowed too. See include/geosynth/model.h. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "model/model_impl.h"

static inline int get_bit(const uint64_t *s, int b) { return (int)((s[b >> 6] >> (b & 63)) & 1); }
static inline void set_bit(uint64_t *s, int b) { s[b >> 6] |= (uint64_t)1 << (b & 63); }
static inline void clr_bit(uint64_t *s, int b) { s[b >> 6] &= ~((uint64_t)1 << (b & 63)); }

/* The direction d seen in the mirror along axis ax: flipped along ax; ax 3
 * is the diagonal x = y (x and y swap). */
static inline int mirror_dir(int d, int ax)
{
    if (ax == 3)
        return d < 4 ? d ^ 2 : d;
    return d >> 1 == ax ? d ^ 1 : d;
}

/* The direction d turned by 90 degrees about z (x -> y -> -x). */
static inline int rotate_dir(int d)
{
    static const int rot[GS_MODEL_DIRS] = {2, 3, 1, 0, 4, 5, 6, 7};
    return rot[d];
}

static int popcount_set(const uint64_t *s, size_t W)
{
    int n = 0;
    for (size_t w = 0; w < W; w++)
        n += __builtin_popcountll(s[w]);
    return n;
}

/* S(a) = b, S(b) = a is consistent with every label already mapped: each
 * pair (u, d, v) among {a, b} x mapped has its image (S u, d', S v). */
static int pair_consistent(const struct gs_model_rules *r, int ax, const int *S, int a)
{
    const int L = r->nlabels;
    for (int c = 0; c < L; c++) {
        if (S[c] < 0)
            continue;
        for (int d = 0; d < GS_MODEL_DIRS; d++) {
            int dm = mirror_dir(d, ax);
            if (get_bit(gs_model_allow(r, a, d), c) && !get_bit(gs_model_allow(r, S[a], dm), S[c]))
                return 0;
            if (get_bit(gs_model_allow(r, c, d), a) && !get_bit(gs_model_allow(r, S[c], dm), S[a]))
                return 0;
        }
    }
    return 1;
}

typedef struct {
    const struct gs_model_rules *r;
    int ax;
    const uint64_t *cand;
    const int *order;
    int n;
    int *S;
    long budget;
} search;

/* Exact involution S over the labels of order[i..]: each label a not yet
 * mapped takes a candidate b (a itself first), with S(b) = a as well. */
static int search_from(search *q, int i)
{
    while (i < q->n && q->S[q->order[i]] >= 0)
        i++;
    if (i == q->n)
        return 1;
    if (--q->budget < 0)
        return 0;
    const int a = q->order[i];
    const size_t W = (size_t)q->r->words;
    const uint64_t *ca = q->cand + (size_t)a * W;
    for (int pass = 0; pass < 2; pass++)
        for (int b = 0; b < q->r->nlabels; b++) {
            if ((pass == 0) != (b == a) || !get_bit(ca, b) || q->S[b] >= 0)
                continue;
            q->S[a] = b;
            q->S[b] = a;
            if (pair_consistent(q->r, q->ax, q->S, a) && pair_consistent(q->r, q->ax, q->S, b) &&
                search_from(q, i + 1))
                return 1;
            q->S[a] = q->S[b] = -1;
            if (q->budget < 0)
                return 0;
        }
    return 0;
}

gs_err gs_model_rules_learn_mirror(const gs_model_rules_t r, int ax, int *S, int *exact)
{
    GS_CHECK(ax >= 0 && ax < 4, GS_ERR_ARG, "mirror axis %d: expected 0..3", ax);
    const int L = r->nlabels;
    const size_t W = (size_t)r->words;
    uint64_t *cand = NULL;
    int *order = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&cand, (size_t)L * W, 8, "label symmetry candidates"), done);
    GS_TRY(err, gs_alloc_array((void **)&order, (size_t)L, sizeof *order, "label order"), done);
    memset(cand, 0, (size_t)L * W * 8);
    /* b may be the image of a when its neighbour counts are a's mirrored */
    for (int a = 0; a < L; a++)
        for (int b = 0; b < L; b++) {
            if (!r->count[a] || !r->count[b])
                continue;
            int same = 1;
            for (int d = 0; d < GS_MODEL_DIRS && same; d++)
                same = popcount_set(gs_model_allow(r, a, d), W) ==
                       popcount_set(gs_model_allow(r, b, mirror_dir(d, ax)), W);
            if (same)
                set_bit(cand + (size_t)a * W, b);
        }
    /* refine: b stays a candidate of a while every neighbour c of a along d
     * has a candidate among b's neighbours along d' (and a of b: involution) */
    for (int changed = 1; changed;) {
        changed = 0;
        for (int a = 0; a < L; a++)
            for (int b = 0; b < L; b++) {
                uint64_t *ca = cand + (size_t)a * W;
                if (!get_bit(ca, b))
                    continue;
                int keep = get_bit(cand + (size_t)b * W, a);
                for (int d = 0; d < GS_MODEL_DIRS && keep; d++) {
                    const uint64_t *na = gs_model_allow(r, a, d);
                    const uint64_t *nb = gs_model_allow(r, b, mirror_dir(d, ax));
                    for (int c = 0; c < L && keep; c++) {
                        if (!get_bit(na, c))
                            continue;
                        const uint64_t *cc = cand + (size_t)c * W;
                        int any = 0;
                        for (size_t w = 0; w < W && !any; w++)
                            any = (cc[w] & nb[w]) != 0;
                        keep = any;
                    }
                }
                if (!keep) {
                    clr_bit(ca, b);
                    changed = 1;
                }
            }
    }
    /* fewest candidates first */
    int n = 0;
    for (int k = 1; k <= L; k++)
        for (int a = 0; a < L; a++)
            if (r->count[a] && popcount_set(cand + (size_t)a * W, W) == k)
                order[n++] = a;
    for (int a = 0; a < L; a++)
        S[a] = -1;
    search q = {r, ax, cand, order, n, S, 200000};
    *exact = n == r->npresent && search_from(&q, 0);
    if (!*exact) {
        /* greedy: each label takes its first consistent candidate (itself
         * first), or no image (it leaves the symmetric model) */
        for (int a = 0; a < L; a++)
            S[a] = -1;
        for (int i = 0; i < n; i++) {
            int a = order[i];
            if (S[a] >= 0)
                continue;
            const uint64_t *ca = cand + (size_t)a * W;
            for (int pass = 0; pass < 2 && S[a] < 0; pass++)
                for (int b = 0; b < L && S[a] < 0; b++) {
                    if ((pass == 0) != (b == a) || !get_bit(ca, b) || S[b] >= 0)
                        continue;
                    S[a] = b;
                    S[b] = a;
                    if (!pair_consistent(r, ax, S, a) || !pair_consistent(r, ax, S, b))
                        S[a] = S[b] = -1;
                }
        }
    }
done:
    gs_free(cand);
    gs_free(order);
    return err;
}

gs_err gs_model_rules_mirror_pairs(const gs_model_rules_t r, const char *key, const char *text,
                                   int *S)
{
    const int L = r->nlabels;
    for (int a = 0; a < L; a++)
        S[a] = r->count[a] ? a : -1;
    const char *p = text;
    int pair = 0;
    while (*p) {
        while (*p == ' ' || *p == ',' || *p == '\t')
            p++;
        if (!*p)
            break;
        char *end;
        long a = strtol(p, &end, 10);
        GS_CHECK(end != p, GS_ERR_ARG, "%s = \"%s\": pair %d: expected two labels \"A B\"", key,
                 text, pair + 1);
        p = end;
        long b = strtol(p, &end, 10);
        GS_CHECK(end != p, GS_ERR_ARG, "%s = \"%s\": pair %d: expected a second label after %ld",
                 key, text, pair + 1, a);
        p = end;
        GS_CHECK(a >= 0 && b >= 0 && a < L && b < L && r->count[a] && r->count[b], GS_ERR_ARG,
                 "%s: pair %ld %ld: expected labels that occur in the example", key, a, b);
        GS_CHECK(S[a] == a && S[b] == b, GS_ERR_ARG, "%s: pair %ld %ld: a label is paired twice",
                 key, a, b);
        S[a] = (int)b;
        S[b] = (int)a;
        pair++;
        GS_CHECK(*p == 0 || *p == ',' || *p == ' ' || *p == '\t', GS_ERR_ARG,
                 "%s = \"%s\": pair %d: expected \"A B, C D\"", key, text, pair);
    }
    return GS_OK;
}

/* Allowed (a, d, b) entries over every direction (each pair counts along
 * +d and -d). */
static size_t count_allowed(const struct gs_model_rules *r)
{
    const size_t n = (size_t)r->nlabels * GS_MODEL_DIRS * (size_t)r->words;
    size_t bits = 0;
    for (size_t i = 0; i < n; i++)
        bits += (size_t)__builtin_popcountll(r->allow[i]);
    return bits;
}

gs_err gs_model_rules_symmetrize(gs_model_rules_t r, const int axes[3], const int *const maps[3],
                                 size_t *dropped)
{
    const size_t W = (size_t)r->words;
    const int L = r->nlabels;
    uint64_t *old = NULL;
    GS_CALL(gs_alloc_array((void **)&old, (size_t)L * GS_MODEL_DIRS * W, 8, "transition sets"));
    const size_t before = count_allowed(r);
    /* keep (a, d, b) only when (S a, d', S b) is allowed, for every mirrored
     * axis, until nothing changes (two mirrors: T = T ∩ Sx T ∩ Sy T ...) */
    for (int changed = 1; changed;) {
        changed = 0;
        for (int ax = 0; ax < 3; ax++) {
            if (!axes[ax])
                continue;
            const int *S = maps ? maps[ax] : NULL;
            memcpy(old, r->allow, (size_t)L * GS_MODEL_DIRS * W * 8);
            for (int a = 0; a < L; a++)
                for (int d = 0; d < GS_MODEL_DIRS; d++) {
                    uint64_t *al = r->allow + ((size_t)a * GS_MODEL_DIRS + (size_t)d) * W;
                    const int dm = mirror_dir(d, ax);
                    for (int b = 0; b < L; b++) {
                        if (!get_bit(al, b))
                            continue;
                        int sa = S ? S[a] : a, sb = S ? S[b] : b;
                        int keep = sa >= 0 && sb >= 0 &&
                                   get_bit(old + ((size_t)sa * GS_MODEL_DIRS + (size_t)dm) * W, sb);
                        if (!keep) {
                            clr_bit(al, b);
                            changed = 1;
                        }
                    }
                }
        }
    }
    gs_free(old);
    const size_t after = count_allowed(r);
    if (dropped)
        *dropped = (before - after) / 2; /* each pair is stored along +d and -d */
    gs_model_rules_rebuild_support(r);
    return GS_OK;
}

gs_err gs_model_rules_rotation(gs_model_rules_t r, const int *R, size_t *dropped)
{
    const size_t W = (size_t)r->words;
    const int L = r->nlabels;
    uint64_t *old = NULL;
    GS_CALL(gs_alloc_array((void **)&old, (size_t)L * GS_MODEL_DIRS * W, 8, "transition sets"));
    const size_t before = count_allowed(r);
    /* keep (a, d, b) only when (R a, R d, R b) is allowed, until nothing
     * changes: the rules are then the same turned by 90 degrees */
    for (int changed = 1; changed;) {
        changed = 0;
        memcpy(old, r->allow, (size_t)L * GS_MODEL_DIRS * W * 8);
        for (int a = 0; a < L; a++)
            for (int d = 0; d < 6; d++) {
                uint64_t *al = r->allow + ((size_t)a * GS_MODEL_DIRS + (size_t)d) * W;
                const int dr = rotate_dir(d);
                for (int b = 0; b < L; b++) {
                    if (!get_bit(al, b))
                        continue;
                    int keep = R[a] >= 0 && R[b] >= 0 &&
                               get_bit(old + ((size_t)R[a] * GS_MODEL_DIRS + (size_t)dr) * W, R[b]);
                    if (!keep) {
                        clr_bit(al, b);
                        changed = 1;
                    }
                }
            }
    }
    gs_free(old);
    const size_t after = count_allowed(r);
    if (dropped)
        *dropped = (before - after) / 2;
    /* the quarter's rotation face (+t / -t of a 3D lattice): b at the
     * partner cell stands for R b beyond the +x face */
    for (int a = 0; a < L; a++) {
        uint64_t *f = r->allow + ((size_t)a * GS_MODEL_DIRS + 6) * W;
        memset(f, 0, W * 8);
        memset(f + W, 0, W * 8); /* direction 7 */
    }
    for (int a = 0; a < L; a++)
        for (int b = 0; b < L; b++)
            if (R[b] >= 0 && get_bit(gs_model_allow(r, a, 0), R[b])) {
                set_bit(r->allow + ((size_t)a * GS_MODEL_DIRS + 6) * W, b);
                set_bit(r->allow + ((size_t)b * GS_MODEL_DIRS + 7) * W, a);
            }
    gs_model_rules_rebuild_support(r);
    return GS_OK;
}

/* Transition pairs (a, d, b) whose image (S a, d mirrored, S b) is allowed. */
static size_t preserved_pairs(const struct gs_model_rules *r, int ax, const int *S)
{
    const int L = r->nlabels;
    size_t n = 0;
    for (int a = 0; a < L; a++) {
        if (!r->count[a] || S[a] < 0)
            continue;
        for (int d = 0; d < 6; d++) {
            const uint64_t *al = gs_model_allow(r, a, d), *im = gs_model_allow(r, S[a], mirror_dir(d, ax));
            for (int b = 0; b < L; b++)
                n += get_bit(al, b) && S[b] >= 0 && get_bit(im, S[b]);
        }
    }
    return n;
}

static uint64_t layer_set(const gs_model_lattice *ex, int l)
{
    uint64_t m = 0;
    const size_t layer = (size_t)ex->nx * (size_t)ex->ny;
    for (int z = 0; z < ex->nz && z < 64; z++)
        for (size_t i = 0; i < layer; i++)
            if (ex->labels[(size_t)z * layer + i] == l) {
                m |= (uint64_t)1 << z;
                break;
            }
    return m;
}

gs_err gs_model_rules_learn_mirror_near(const gs_model_rules_t r, const gs_model_lattice *ex, int ax,
                                        int *S, size_t *kept, size_t *total)
{
    GS_CHECK(ax >= 0 && ax < 4, GS_ERR_ARG, "mirror axis %d: expected 0..3", ax);
    const int L = r->nlabels;
    uint64_t *zs = NULL;
    GS_CALL(gs_alloc_array((void **)&zs, (size_t)L, sizeof *zs, "label layers"));
    for (int l = 0; l < L; l++) {
        S[l] = r->count[l] ? l : -1;
        zs[l] = r->count[l] ? layer_set(ex, l) : 0;
    }
    /* coordinate ascent from the identity: swap a with b (same layers) when
     * more pairs keep an allowed image; fixed order, so deterministic */
    size_t best = preserved_pairs(r, ax, S);
    for (int round = 0, better = 1; better && round < 20; round++) {
        better = 0;
        for (int a = 0; a < L; a++) {
            if (!r->count[a])
                continue;
            for (int b = 0; b < L; b++) {
                if (b == S[a] || !r->count[b] || zs[b] != zs[a])
                    continue;
                int old[4] = {a, S[a], b, S[b]}, was[4];
                for (int i = 0; i < 4; i++)
                    was[i] = S[old[i]];
                /* undo a's and b's pairs, then pair a with b */
                S[S[a]] = S[a];
                S[S[b]] = S[b];
                S[a] = b;
                S[b] = a;
                size_t n = preserved_pairs(r, ax, S);
                if (n > best) {
                    best = n;
                    better = 1;
                } else {
                    for (int i = 0; i < 4; i++)
                        S[old[i]] = was[i];
                }
            }
        }
    }
    size_t all = 0;
    for (int a = 0; a < L; a++)
        for (int d = 0; d < 6; d++)
            all += (size_t)popcount_set(gs_model_allow(r, a, d), (size_t)r->words);
    gs_free(zs);
    if (kept)
        *kept = best;
    if (total)
        *total = all;
    return GS_OK;
}
