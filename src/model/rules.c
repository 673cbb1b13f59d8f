/* Transition bitsets learned from an example (paper Eq. 1) and the trivial
 * consistent start model. See include/geosynth/model.h. */
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/model_tiles.h"
#include "model/model_impl.h"

/* x and y steps; z and t steps from gs_model_step_z */
static const int step[GS_MODEL_DIRS][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1},
                                           {0, 0}, {0, 0}, {0, 0}, {0, 0}};

static inline void set_bit(uint64_t *s, int b) { s[b >> 6] |= (uint64_t)1 << (b & 63); }
static inline int get_bit(const uint64_t *s, int b) { return (int)((s[b >> 6] >> (b & 63)) & 1); }

gs_err gs_model_rules_learn(const gs_model_lattice *ex, gs_model_rules_t *out)
{
    size_t n = (size_t)ex->nx * (size_t)ex->ny * (size_t)ex->nz;
    GS_CHECK(n > 0 && ex->labels, GS_ERR_ARG, "example lattice is empty");
    int L = 0;
    for (size_t i = 0; i < n; i++)
        if (ex->labels[i] >= L)
            L = ex->labels[i] + 1;
    struct gs_model_rules *r = gs_calloc(1, sizeof *r);
    GS_CHECK(r, GS_ERR_MEM, "model rules: cannot allocate");
    gs_err err = GS_OK;
    r->nlabels = L;
    r->words = (L + 63) / 64;
    const size_t W = (size_t)r->words;
    GS_TRY(err, gs_alloc_array((void **)&r->allow, (size_t)L * GS_MODEL_DIRS * W, 8, "transition sets"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&r->present, W, 8, "label set"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->full_support, GS_MODEL_DIRS * W, 8, "support sets"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&r->count, (size_t)L, 8, "label counts"), fail);
    for (int z = 0; z < ex->nz; z++)
        for (int y = 0; y < ex->ny; y++)
            for (int x = 0; x < ex->nx; x++) {
                int a = ex->labels[gs_model_lattice_index(ex, x, y, z)];
                r->count[a]++;
                for (int d = 0; d < GS_MODEL_DIRS; d++) {
                    int qx = x + step[d][0], qy = y + step[d][1], qz = gs_model_step_z(ex, z, d);
                    /* Only pairs inside the example (and along z inside one
                     * frame) count: the outside is not a label. */
                    if (qx < 0 || qy < 0 || qz < 0 || qx >= ex->nx || qy >= ex->ny)
                        continue;
                    int b = ex->labels[gs_model_lattice_index(ex, qx, qy, qz)];
                    set_bit(r->allow + ((size_t)a * GS_MODEL_DIRS + (size_t)d) * W, b);
                }
            }
    for (int a = 0; a < L; a++) {
        if (!r->count[a])
            continue;
        set_bit(r->present, a);
        r->npresent++;
    }
    gs_model_rules_rebuild_support(r);
    *out = r;
    return GS_OK;
fail:
    gs_model_rules_destroy(&r);
    return err;
}

/* full_support[d] = every label some present label allows along d: the
 * candidate set of a cell whose neighbour along d is still open. */
void gs_model_rules_rebuild_support(struct gs_model_rules *r)
{
    const size_t W = (size_t)r->words;
    memset(r->full_support, 0, GS_MODEL_DIRS * W * 8);
    for (int a = 0; a < r->nlabels; a++)
        if (r->count[a])
            for (int d = 0; d < GS_MODEL_DIRS; d++)
                for (size_t w = 0; w < W; w++)
                    r->full_support[(size_t)d * W + w] |= gs_model_allow(r, a, d)[w];
}

void gs_model_rules_destroy(gs_model_rules_t *rules)
{
    if (!rules || !*rules)
        return;
    struct gs_model_rules *r = *rules;
    gs_free(r->allow);
    gs_free(r->present);
    gs_free(r->full_support);
    gs_free(r->count);
    gs_free(r);
    *rules = NULL;
}

int gs_model_rules_nlabels(const gs_model_rules_t rules) { return rules->nlabels; }

int gs_model_rules_allows(const gs_model_rules_t r, int dir, int a, int b)
{
    if (a < 0 || b < 0 || a >= r->nlabels || b >= r->nlabels || dir < 0 || dir >= GS_MODEL_DIRS)
        return 0;
    return get_bit(gs_model_allow(r, a, dir), b);
}

uint64_t gs_model_rules_count(const gs_model_rules_t r, int label)
{
    return label >= 0 && label < r->nlabels ? r->count[label] : 0;
}

size_t gs_model_rules_violations(const gs_model_rules_t r, const gs_model_lattice *lat)
{
    size_t bad = 0;
    for (int z = 0; z < lat->nz; z++)
        for (int y = 0; y < lat->ny; y++)
            for (int x = 0; x < lat->nx; x++) {
                int a = lat->labels[gs_model_lattice_index(lat, x, y, z)];
                if (a >= r->nlabels || !r->count[a]) {
                    bad++;
                    continue;
                }
                for (int d = 0; d < GS_MODEL_DIRS; d += 2) {
                    int qx = x + step[d][0], qy = y + step[d][1], qz = gs_model_step_z(lat, z, d);
                    if (qx >= lat->nx || qy >= lat->ny || qz < 0)
                        continue;
                    int b = lat->labels[gs_model_lattice_index(lat, qx, qy, qz)];
                    if (b >= r->nlabels || !get_bit(gs_model_allow(r, a, d), b))
                        bad++;
                }
            }
    return bad;
}

size_t gs_model_pins_unmet(const gs_model_params *p, const gs_model_lattice *lat)
{
    size_t bad = 0, n = (size_t)lat->nx * (size_t)lat->ny * (size_t)lat->nz;
    for (size_t i = 0; p->pins && i < n; i++)
        bad += p->pins[i] != GS_MODEL_FREE && p->pins[i] != lat->labels[i];
    return bad;
}

size_t gs_model_rules_violations_wrap(const gs_model_rules_t r, const gs_model_lattice *lat,
                                      const int periodic[3])
{
    size_t bad = gs_model_rules_violations(r, lat);
    const int n[3] = {lat->nx, lat->ny, lat->nz};
    for (int a = 0; a < 3; a++) {
        if (!periodic || !periodic[a])
            continue;
        /* pairs (last, first) along axis a */
        int o1 = a == 0 ? lat->ny : lat->nx, o2 = a == 2 ? lat->ny : lat->nz;
        for (int j = 0; j < o2; j++)
            for (int i = 0; i < o1; i++) {
                int p0[3], p1[3];
                if (a == 0) { p0[1] = p1[1] = i; p0[2] = p1[2] = j; }
                if (a == 1) { p0[0] = p1[0] = i; p0[2] = p1[2] = j; }
                if (a == 2) { p0[0] = p1[0] = i; p0[1] = p1[1] = j; }
                p0[a] = n[a] - 1;
                p1[a] = 0;
                int x = lat->labels[gs_model_lattice_index(lat, p0[0], p0[1], p0[2])];
                int y = lat->labels[gs_model_lattice_index(lat, p1[0], p1[1], p1[2])];
                if (x >= r->nlabels || y >= r->nlabels || !get_bit(gs_model_allow(r, x, 2 * a), y))
                    bad++;
            }
    }
    return bad;
}

/* ---- trivial start model ------------------------------------------------------ */

/* A uniform layer of l is consistent (and, in 4D, stays l from frame to frame). */
static int tiles_horizontally(const struct gs_model_rules *r, int l, int frames)
{
    return r->count[l] && get_bit(gs_model_allow(r, l, 0), l) && get_bit(gs_model_allow(r, l, 2), l) &&
           (frames <= 1 || get_bit(gs_model_allow(r, l, 6), l));
}

gs_err gs_model_initial(const gs_model_rules_t r, const gs_model_lattice *ex,
                        const uint16_t *column, gs_model_lattice *out)
{
    return gs_model_initial_faces(r, ex, column, NULL, NULL, out);
}

gs_err gs_model_initial_faces(const gs_model_rules_t r, const gs_model_lattice *ex,
                              const uint16_t *column, const uint64_t *bottom, const uint64_t *top,
                              gs_model_lattice *out)
{
    return gs_model_initial_prefer(r, ex, column, NULL, bottom, top, out);
}

gs_err gs_model_commonest_column(const gs_model_lattice *ex, int faces, uint16_t *col)
{
    const int nz = gs_model_frame_nz(ex);
    size_t ncol = 0;
    uint16_t *cols = NULL;
    GS_CALL(gs_alloc_array((void **)&cols, (size_t)ex->nx * (size_t)ex->ny * (size_t)nz,
                           sizeof *cols, "example columns"));
    for (int y = 0; y < ex->ny; y++)
        for (int x = 0; x < ex->nx; x++) {
            if (faces && x && y && x < ex->nx - 1 && y < ex->ny - 1)
                continue;
            for (int z = 0; z < nz; z++)
                cols[ncol * (size_t)nz + (size_t)z] = ex->labels[gs_model_lattice_index(ex, x, y, z)];
            ncol++;
        }
    gs_model_sort_rows(cols, ncol, (size_t)nz);
    /* the longest run of equal columns; ties: the first in sorted order */
    size_t best = 0, best_n = 0;
    for (size_t i = 0; i < ncol;) {
        size_t j = i + 1;
        while (j < ncol && !memcmp(cols + j * (size_t)nz, cols + i * (size_t)nz,
                                   (size_t)nz * sizeof *cols))
            j++;
        if (j - i > best_n) {
            best_n = j - i;
            best = i;
        }
        i = j;
    }
    memcpy(col, cols + best * (size_t)nz, (size_t)nz * sizeof *col);
    gs_free(cols);
    return GS_OK;
}

gs_err gs_model_initial_prefer(const gs_model_rules_t r, const gs_model_lattice *ex,
                               const uint16_t *column, const uint16_t *prefer,
                               const uint64_t *bottom, const uint64_t *top, gs_model_lattice *out)
{
    /* 4D: one column per frame, the same in every frame */
    const int nz = gs_model_frame_nz(out), L = r->nlabels, exnz = gs_model_frame_nz(ex);
    uint16_t *col = NULL;
    double *score = NULL;
    int32_t *from = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&col, (size_t)nz, sizeof *col, "initial column"), done);
    if (column) {
        memcpy(col, column, (size_t)nz * sizeof *col);
        for (int z = 0; z < nz; z++) {
            int l = col[z];
            GS_TRY_CHECK(err, l < L && r->count[l], GS_ERR_ARG, done,
                         "initial column: label %d at z=%d does not occur in the example", l, z);
            if (out->nx > 1 || out->ny > 1)
                GS_TRY_CHECK(err, tiles_horizontally(r, l, out->frames), GS_ERR_ARG, done,
                             "initial column: label %d at z=%d never sits next to itself along x "
                             "and y in the example, so a uniform layer of it is inconsistent",
                             l, z);
            if (z + 1 < nz)
                GS_TRY_CHECK(err, get_bit(gs_model_allow(r, l, 4), col[z + 1]), GS_ERR_ARG, done,
                             "initial column: label %d at z=%d never lies below label %d in the "
                             "example",
                             l, z, col[z + 1]);
        }
    } else {
        /* Dynamic programming over z: best-scoring path through horizontally
         * self-tileable labels with valid vertical transitions. Preference:
         * the example's corner column (or the column prefer), empty above its
         * top, then labels frequent in the corresponding example layer. */
        GS_TRY(err, gs_alloc_array((void **)&score, (size_t)nz * (size_t)L, sizeof *score, "column DP"),
               done);
        GS_TRY(err, gs_alloc_array((void **)&from, (size_t)nz * (size_t)L, sizeof *from, "column DP"),
               done);
        const double NONE = -1.0;
        size_t layer = (size_t)ex->nx * (size_t)ex->ny;
        for (int z = 0; z < nz; z++) {
            int ez = z < exnz ? z : exnz - 1;
            int preferred = z >= exnz ? 0
                            : prefer  ? prefer[z]
                                      : ex->labels[gs_model_lattice_index(ex, 0, 0, z)];
            for (int l = 0; l < L; l++) {
                double *s = &score[(size_t)z * L + l];
                *s = NONE;
                from[(size_t)z * L + l] = -1;
                if (!r->count[l] || ((out->nx > 1 || out->ny > 1) && !tiles_horizontally(r, l, out->frames)))
                    continue;
                if ((z == 0 && bottom && !get_bit(bottom, l)) || (z == nz - 1 && top && !get_bit(top, l)))
                    continue;
                uint64_t freq = 0;
                for (size_t i = 0; i < layer; i++)
                    freq += ex->labels[(size_t)ez * layer + i] == l;
                double own = (l == preferred ? 2.0 : 0.0) + (double)freq / (double)(layer + 1);
                if (z == 0) {
                    *s = own;
                    continue;
                }
                for (int p = 0; p < L; p++) {
                    double sp = score[(size_t)(z - 1) * L + p];
                    if (sp < 0 || !get_bit(gs_model_allow(r, p, 4), l))
                        continue;
                    if (sp + own > *s) {
                        *s = sp + own;
                        from[(size_t)z * L + l] = p;
                    }
                }
            }
        }
        int best = -1;
        for (int l = 0; l < L; l++)
            if (score[(size_t)(nz - 1) * L + l] >= 0 &&
                (best < 0 || score[(size_t)(nz - 1) * L + l] > score[(size_t)(nz - 1) * L + best]))
                best = l;
        GS_TRY_CHECK(err, best >= 0, GS_ERR_ARG, done,
                     "no consistent start model: no column of %d labels that each sit next to "
                     "themselves along x and y and stack validly along z exists in the example; "
                     "give an initial column explicitly",
                     nz);
        for (int z = nz - 1; z >= 0; z--) {
            col[z] = (uint16_t)best;
            best = from[(size_t)z * L + best];
        }
    }
    for (int z = 0; z < out->nz; z++)
        for (int y = 0; y < out->ny; y++)
            for (int x = 0; x < out->nx; x++)
                out->labels[gs_model_lattice_index(out, x, y, z)] = col[z % nz];
    /* Verify (cheap) rather than trust the construction. */
    size_t bad = gs_model_rules_violations(r, out);
    GS_TRY_CHECK(err, bad == 0, GS_ERR_INTERNAL, done,
                 "initial model has %zu adjacency violations", bad);
done:
    gs_free(col);
    gs_free(score);
    gs_free(from);
    return err;
}

/* ---- rules from explicit pairs (tile sets, overlapping patterns) ------------- */

gs_err gs_model_rules_from_pairs(int L, const gs_model_pair *pairs, size_t npairs,
                                 const uint64_t *counts, gs_model_rules_t *out)
{
    GS_CHECK(L > 0 && L <= 65536, GS_ERR_ARG, "rules from pairs: %d labels, expected 1..65536", L);
    struct gs_model_rules *r = gs_calloc(1, sizeof *r);
    GS_CHECK(r, GS_ERR_MEM, "model rules: cannot allocate");
    gs_err err = GS_OK;
    r->nlabels = L;
    r->words = (L + 63) / 64;
    const size_t W = (size_t)r->words;
    GS_TRY(err, gs_alloc_array((void **)&r->allow, (size_t)L * GS_MODEL_DIRS * W, 8, "transition sets"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&r->present, W, 8, "label set"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->full_support, GS_MODEL_DIRS * W, 8, "support sets"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&r->count, (size_t)L, 8, "label counts"), fail);
    memset(r->allow, 0, (size_t)L * GS_MODEL_DIRS * W * 8);
    memset(r->present, 0, W * 8);
    for (int l = 0; l < L; l++)
        r->count[l] = counts[l];
    for (size_t i = 0; i < npairs; i++) {
        const gs_model_pair *p = &pairs[i];
        GS_TRY_CHECK(err, (p->dir == 0 || p->dir == 2 || p->dir == 4) && p->a < L && p->b < L,
                     GS_ERR_ARG, fail, "rules from pairs: pair %zu (dir %d, %u, %u) out of range",
                     i, p->dir, p->a, p->b);
        set_bit(r->allow + ((size_t)p->a * GS_MODEL_DIRS + p->dir) * W, p->b);
        set_bit(r->allow + ((size_t)p->b * GS_MODEL_DIRS + (p->dir ^ 1u)) * W, p->a);
    }
    for (int a = 0; a < L; a++) {
        if (!r->count[a])
            continue;
        set_bit(r->present, a);
        r->npresent++;
    }
    gs_model_rules_rebuild_support(r);
    *out = r;
    return GS_OK;
fail:
    gs_model_rules_destroy(&r);
    return err;
}
