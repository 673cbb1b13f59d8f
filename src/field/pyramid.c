/* Global sum pyramid and the block-relative step layout; see
 * include/geosynth/field.h ("Global pyramid"). */
#include <math.h>
#include <string.h>

#include "field_impl.h"
#include "geosynth/mem.h"

gs_err gs_field_pyramid_create(const gs_qfield *src, int levels, gs_field_pyramid_t *out)
{
    GS_CHECK(levels >= 1 && levels <= GS_FIELD_MAX_LEVEL + 1, GS_ERR_ARG,
             "pyramid levels = %d: expected 1..%d", levels, GS_FIELD_MAX_LEVEL + 1);
    int64_t side = (int64_t)1 << (levels - 1);
    GS_CHECK(src->nx >= side && src->ny >= side && src->nz >= side, GS_ERR_ARG,
             "pyramid of %d levels needs a field of at least %lld^3 samples, got %lldx%lldx%lld",
             levels, (long long)side, (long long)src->nx, (long long)src->ny, (long long)src->nz);
    struct gs_field_pyramid *p = gs_calloc(1, sizeof *p);
    GS_CHECK(p, GS_ERR_MEM, "out of memory for a pyramid header");
    p->src = src;
    p->levels = levels;
    p->nx = src->nx, p->ny = src->ny, p->nz = src->nz;
    int64_t n = p->nx * p->ny * p->nz;
    p->bytes = (size_t)n;
    gs_err err = GS_OK;
    /* sums of squares of the level below and of this level, kept only while
     * building: the cells hold the spreads derived from them */
    uint32_t *qlow = NULL, *qcur = NULL;
    if (levels > 1) {
        GS_TRY(err, gs_alloc_array((void **)&qlow, (size_t)n, sizeof(uint32_t), "pyramid squares"),
               fail);
        GS_TRY(err, gs_alloc_array((void **)&qcur, (size_t)n, sizeof(uint32_t), "pyramid squares"),
               fail);
    }
    for (int m = 1; m < levels; m++) {
        void *a = NULL;
        GS_TRY(err, gs_alloc_array(&a, (size_t)n, sizeof(gs_pyr_cell), "pyramid level"), fail);
        p->cell[m] = a;
        p->bytes += (size_t)n * sizeof(gs_pyr_cell);
        /* S_m[x] = sum of the 8 S_{m-1} at x + {0,h}^3, over positions whose
         * cube fits; Q_m likewise */
        int64_t h = (int64_t)1 << (m - 1), s = 2 * h, c = (int64_t)1 << (3 * m);
        int64_t sx = p->nx, sxy = p->nx * p->ny;
        for (int64_t z = 0; z + s <= p->nz; z++)
            for (int64_t y = 0; y + s <= p->ny; y++) {
                int64_t row = sx * y + sxy * z;
                gs_pyr_cell *dst = p->cell[m] + row;
                uint32_t *qd = qcur + row;
                int64_t hy = h * sx, hz = h * sxy;
                const int64_t o[8] = {0, h, hy, hy + h, hz, hz + h, hz + hy, hz + hy + h};
                for (int64_t x = 0; x + s <= p->nx; x++) {
                    uint32_t s1 = 0, s2 = 0;
                    if (m == 1) {
                        const uint8_t *q = src->q + row;
                        for (int k = 0; k < 8; k++) {
                            uint32_t v = q[x + o[k]];
                            s1 += v;
                            s2 += v * v;
                        }
                    } else {
                        const gs_pyr_cell *q = p->cell[m - 1] + row;
                        const uint32_t *ql = qlow + row;
                        for (int k = 0; k < 8; k++) {
                            s1 += q[x + o[k]].sum;
                            s2 += ql[x + o[k]];
                        }
                    }
                    qd[x] = s2;
                    /* exact integer below 2^53, correctly rounded root */
                    double v = (double)(c * (int64_t)s2 - (int64_t)s1 * s1);
                    dst[x] = (gs_pyr_cell){s1, (float)sqrt(v)};
                }
            }
        uint32_t *t = qlow;
        qlow = qcur;
        qcur = t;
    }
    gs_free(qlow);
    gs_free(qcur);
    *out = p;
    return GS_OK;
fail:
    gs_free(qlow);
    gs_free(qcur);
    gs_field_pyramid_destroy(&p);
    return err;
}

void gs_field_pyramid_destroy(gs_field_pyramid_t *pp)
{
    if (!pp || !*pp)
        return;
    for (int m = 1; m <= GS_FIELD_MAX_LEVEL; m++) {
        gs_free((*pp)->cell[m]);
    }
    GS_FREE(*pp);
}

uint32_t gs_field_pyramid_sum(gs_field_pyramid_t p, int m, int64_t x, int64_t y, int64_t z)
{
    return gs_pyr_at(p, m, x + p->nx * (y + p->ny * z));
}

size_t gs_field_pyramid_bytes(gs_field_pyramid_t p)
{
    return p->bytes;
}

/* ------------------------------------------------------------ layout */

static void morton_decode(int64_t j, int k, int64_t c[3])
{
    c[0] = c[1] = c[2] = 0;
    for (int b = 0; b < k; b++) {
        c[0] |= ((j >> (3 * b)) & 1) << b;
        c[1] |= ((j >> (3 * b + 1)) & 1) << b;
        c[2] |= ((j >> (3 * b + 2)) & 1) << b;
    }
}

gs_err gs_step_layout_init(gs_step_layout *lay, int B, int64_t nx, int64_t ny)
{
    memset(lay, 0, sizeof *lay);
    int L = 0;
    while ((1 << L) < B)
        L++;
    GS_CHECK(B >= 2 && B <= (1 << GS_FIELD_MAX_LEVEL) && (1 << L) == B, GS_ERR_ARG,
             "block size %d: expected a power of two in [2, %d]", B, 1 << GS_FIELD_MAX_LEVEL);
    lay->B = B;
    lay->L = L;
    int64_t first = 0;
    for (int k = 0; k <= L; k++) {
        int64_t cells = (int64_t)1 << (3 * k);
        /* refinements of level k-1 cells reveal level k: first index of those */
        if (k >= 1) {
            lay->level_first[k] = first;
            first += cells / 8;
        }
        lay->cell_off[k] = gs_calloc((size_t)cells, sizeof(int64_t));
        lay->qcell_off[k] = gs_calloc((size_t)cells, sizeof(int64_t));
        if (!lay->cell_off[k] || !lay->qcell_off[k]) {
            gs_step_layout_free(lay);
            GS_RAISE(GS_ERR_MEM, "out of memory for the step layout of block %d", B);
        }
        int64_t s = (int64_t)B >> k;
        for (int64_t j = 0; j < cells; j++) {
            int64_t c[3];
            morton_decode(j, k, c);
            lay->cell_off[k][j] = s * (c[0] + nx * (c[1] + ny * c[2]));
            lay->qcell_off[k][j] = s * (c[0] + B * (c[1] + (int64_t)B * c[2]));
        }
    }
    lay->level_first[L + 1] = first;
    lay->steps = GS_FIELD_QSTEPS + first;
    return GS_OK;
}

void gs_step_layout_free(gs_step_layout *lay)
{
    for (int k = 0; k <= GS_FIELD_MAX_LEVEL; k++) {
        gs_free(lay->cell_off[k]);
        gs_free(lay->qcell_off[k]);
        lay->cell_off[k] = lay->qcell_off[k] = NULL;
    }
}

gs_err gs_field_level_bound(gs_field_pyramid_t p, int64_t index, const gs_field_query *q, int level,
                            uint64_t *out)
{
    gs_step_layout lay;
    GS_CALL(gs_step_layout_init(&lay, q->block, p->nx, p->ny));
    int L = lay.L, B = q->block;
    uint64_t wk, wu;
    gs_field_query_weights(q, &wk, &wu);
    gs_err err = GS_OK;
    GS_TRY_CHECK(err, level >= 0 && level <= L && p->levels > L, GS_ERR_ARG, done,
                 "level %d of block %d: expected 0..%d with a pyramid of > %d levels", level, B, L,
                 L);
    int64_t pos[3];
    gs_field_block_position(p->src, B, index, pos);
    int64_t base = pos[0] + p->nx * (pos[1] + p->ny * pos[2]);
    int64_t s = (int64_t)B >> level;
    uint64_t total = 0;
    for (int64_t j = 0; j < ((int64_t)1 << (3 * level)); j++) {
        int64_t qo = lay.qcell_off[level][j];
        uint64_t qs = 0;
        int full = 1;
        for (int64_t k = 0; k < s; k++)
            for (int64_t jj = 0; jj < s; jj++)
                for (int64_t i = 0; i < s; i++) {
                    int64_t o = qo + i + B * (jj + (int64_t)B * k);
                    qs += q->values[o];
                    if (q->known && !q->known[o])
                        full = 0;
                }
        int64_t d = (int64_t)qs - (int64_t)gs_pyr_at(p, L - level, base + lay.cell_off[level][j]);
        total += ((uint64_t)(d * d) << (3 * level)) * (full ? wk : wu);
    }
    *out = total;
done:
    gs_step_layout_free(&lay);
    return err;
}
