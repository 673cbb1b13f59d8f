/* Dense and quantized fields, quantization, subsampling, block helpers;
 * see include/geosynth/field.h. */
#include <math.h>
#include <string.h>

#include "geosynth/field.h"
#include "geosynth/mem.h"

#define GS_FIELD_MAX_SIZE 4096

static gs_err check_sizes(int64_t nx, int64_t ny, int64_t nz)
{
    GS_CHECK(nx >= 1 && ny >= 1 && nz >= 1 && nx <= GS_FIELD_MAX_SIZE && ny <= GS_FIELD_MAX_SIZE &&
                 nz <= GS_FIELD_MAX_SIZE,
             GS_ERR_ARG, "field size %lldx%lldx%lld: expected sizes in [1, %d]", (long long)nx,
             (long long)ny, (long long)nz, GS_FIELD_MAX_SIZE);
    return GS_OK;
}

gs_err gs_field_create(int64_t nx, int64_t ny, int64_t nz, gs_field **out)
{
    GS_CALL(check_sizes(nx, ny, nz));
    gs_field *f = gs_calloc(1, sizeof *f);
    GS_CHECK(f, GS_ERR_MEM, "out of memory for a field header");
    gs_err err = GS_OK;
    void *v = NULL;
    GS_TRY(err, gs_alloc_array(&v, (size_t)(nx * ny * nz), sizeof(float), "field samples"), fail);
    f->nx = nx, f->ny = ny, f->nz = nz;
    f->spacing = 1.0;
    f->v = v;
    *out = f;
    return GS_OK;
fail:
    gs_free(f);
    return err;
}

void gs_field_destroy(gs_field **f)
{
    if (!f || !*f)
        return;
    gs_free((*f)->v);
    GS_FREE(*f);
}

gs_err gs_qfield_create(int64_t nx, int64_t ny, int64_t nz, double lo, double hi, gs_qfield **out)
{
    GS_CALL(check_sizes(nx, ny, nz));
    GS_CHECK(isfinite(lo) && isfinite(hi) && lo < hi, GS_ERR_ARG,
             "quantization range [%g, %g]: expected finite lo < hi", lo, hi);
    gs_qfield *q = gs_calloc(1, sizeof *q);
    GS_CHECK(q, GS_ERR_MEM, "out of memory for a field header");
    gs_err err = GS_OK;
    void *v = NULL;
    GS_TRY(err, gs_alloc_array(&v, (size_t)(nx * ny * nz), 1, "quantized field"), fail);
    q->nx = nx, q->ny = ny, q->nz = nz;
    q->lo = lo, q->hi = hi;
    q->spacing = 1.0;
    q->q = v;
    *out = q;
    return GS_OK;
fail:
    gs_free(q);
    return err;
}

void gs_qfield_destroy(gs_qfield **q)
{
    if (!q || !*q)
        return;
    gs_free((*q)->q);
    GS_FREE(*q);
}

gs_err gs_field_quantize(const gs_field *f, double lo, double hi, gs_qfield **out)
{
    gs_qfield *q = NULL;
    GS_CALL(gs_qfield_create(f->nx, f->ny, f->nz, lo, hi, &q));
    int64_t n = f->nx * f->ny * f->nz;
    double scale = 255.0 / (hi - lo);
    for (int64_t i = 0; i < n; i++) {
        double v = f->v[i];
        if (isnan(v)) {
            gs_qfield_destroy(&q);
            GS_RAISE(GS_ERR_ARG, "field sample %lld (x=%lld y=%lld z=%lld) is NaN: expected a distance",
                     (long long)i, (long long)(i % f->nx), (long long)(i / f->nx % f->ny),
                     (long long)(i / (f->nx * f->ny)));
        }
        double t = floor((v - lo) * scale + 0.5);
        q->q[i] = (uint8_t)(t < 0 ? 0 : t > 255 ? 255 : t);
    }
    memcpy(q->origin, f->origin, sizeof q->origin);
    q->spacing = f->spacing;
    *out = q;
    return GS_OK;
}

double gs_qfield_value(const gs_qfield *q, uint8_t level)
{
    return q->lo + level * (q->hi - q->lo) / 255.0;
}

gs_err gs_qfield_dequantize(const gs_qfield *q, gs_field **out)
{
    gs_field *f = NULL;
    GS_CALL(gs_field_create(q->nx, q->ny, q->nz, &f));
    float table[256];
    for (int i = 0; i < 256; i++)
        table[i] = (float)gs_qfield_value(q, (uint8_t)i);
    int64_t n = q->nx * q->ny * q->nz;
    for (int64_t i = 0; i < n; i++)
        f->v[i] = table[q->q[i]];
    memcpy(f->origin, q->origin, sizeof f->origin);
    f->spacing = q->spacing;
    *out = f;
    return GS_OK;
}

gs_err gs_qfield_downsample(const gs_qfield *q, int factor, gs_qfield **out)
{
    GS_CHECK(factor >= 1 && (factor & (factor - 1)) == 0 && q->nx % factor == 0 &&
                 q->ny % factor == 0 && q->nz % factor == 0,
             GS_ERR_ARG,
             "downsampling %lldx%lldx%lld by %d: expected a power of two dividing every size",
             (long long)q->nx, (long long)q->ny, (long long)q->nz, factor);
    gs_qfield *d = NULL;
    GS_CALL(gs_qfield_create(q->nx / factor, q->ny / factor, q->nz / factor, q->lo, q->hi, &d));
    uint32_t c = (uint32_t)factor * factor * factor;
    for (int64_t z = 0; z < d->nz; z++)
        for (int64_t y = 0; y < d->ny; y++)
            for (int64_t x = 0; x < d->nx; x++) {
                uint32_t s = 0;
                for (int k = 0; k < factor; k++)
                    for (int j = 0; j < factor; j++) {
                        const uint8_t *row =
                            q->q + x * factor + q->nx * (y * factor + j + q->ny * (z * factor + k));
                        for (int i = 0; i < factor; i++)
                            s += row[i];
                    }
                d->q[x + d->nx * (y + d->ny * z)] = (uint8_t)((s + c / 2) / c);
            }
    memcpy(d->origin, q->origin, sizeof d->origin);
    d->spacing = q->spacing * factor;
    *out = d;
    return GS_OK;
}

int64_t gs_field_block_count(const gs_qfield *src, int block)
{
    if (block < 1 || block > src->nx || block > src->ny || block > src->nz)
        return 0;
    return (src->nx - block + 1) * (src->ny - block + 1) * (src->nz - block + 1);
}

void gs_field_block_position(const gs_qfield *src, int block, int64_t index, int64_t pos[3])
{
    int64_t bx = src->nx - block + 1, by = src->ny - block + 1;
    pos[0] = index % bx;
    pos[1] = index / bx % by;
    pos[2] = index / (bx * by);
}

gs_err gs_field_crop(const gs_field *f, int64_t mult, gs_field **out)
{
    int64_t n[3] = {f->nx / mult * mult, f->ny / mult * mult, f->nz / mult * mult};
    GS_CHECK(n[0] > 0 && n[1] > 0 && n[2] > 0, GS_ERR_ARG,
             "example of %lldx%lldx%lld samples is smaller than %lld (2^(iterations-1)) along an axis",
             (long long)f->nx, (long long)f->ny, (long long)f->nz, (long long)mult);
    gs_field *c = NULL;
    GS_CALL(gs_field_create(n[0], n[1], n[2], &c));
    for (int64_t z = 0; z < n[2]; z++)
        for (int64_t y = 0; y < n[1]; y++)
            memcpy(c->v + n[0] * (y + n[1] * z), f->v + f->nx * (y + f->ny * z),
                   (size_t)n[0] * sizeof(float));
    memcpy(c->origin, f->origin, sizeof c->origin);
    c->spacing = f->spacing;
    *out = c;
    return GS_OK;
}

void gs_field_block_copy(const gs_qfield *src, int block, int64_t index, uint8_t *out)
{
    int64_t p[3];
    gs_field_block_position(src, block, index, p);
    gs_qfield_block_at(src, block, p, out);
}

void gs_qfield_block_at(const gs_qfield *f, int block, const int64_t pos[3], uint8_t *out)
{
    for (int k = 0; k < block; k++)
        for (int j = 0; j < block; j++)
            memcpy(out + block * (j + block * k),
                   f->q + pos[0] + f->nx * (pos[1] + j + f->ny * (pos[2] + k)), (size_t)block);
}

void gs_field_query_weights(const gs_field_query *q, uint64_t *wk, uint64_t *wu)
{
    *wk = 1, *wu = 1;
    if (!q->known || q->seed_weight >= 256)
        return;
    if (q->seed_weight <= 0)
        *wu = 0;
    else
        *wk = 256, *wu = (uint64_t)q->seed_weight;
}

int64_t gs_field_query_known(const gs_field_query *q)
{
    int64_t n = (int64_t)q->block * q->block * q->block, known = 0;
    if (!q->known)
        return n;
    for (int64_t i = 0; i < n; i++)
        known += q->known[i] != 0;
    return known;
}

uint64_t gs_field_block_distance(const gs_qfield *src, int64_t index, const gs_field_query *q)
{
    int B = q->block;
    uint64_t wk, wu;
    gs_field_query_weights(q, &wk, &wu);
    int64_t p[3];
    gs_field_block_position(src, B, index, p);
    uint64_t d = 0;
    for (int k = 0; k < B; k++)
        for (int j = 0; j < B; j++) {
            const uint8_t *row = src->q + p[0] + src->nx * (p[1] + j + src->ny * (p[2] + k));
            const uint8_t *qv = q->values + B * (j + B * k);
            const uint8_t *kn = q->known ? q->known + B * (j + B * k) : NULL;
            for (int i = 0; i < B; i++) {
                int e = (int)qv[i] - (int)row[i];
                d += (uint64_t)(e * e) * (kn && !kn[i] ? wu : wk);
            }
        }
    return d;
}
