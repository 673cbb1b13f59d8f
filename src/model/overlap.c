/* Overlapping model input (mxgmn's OverlappingModel): N x N patterns of a
 * sample image become labels, two patterns may be neighbours when they agree
 * on their overlap. See include/geosynth/model_tiles.h. */
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/mem.h"
#include "geosynth/model_tiles.h"

#define MAX_COLORS 255
#define MAX_PATTERNS 65534

void gs_model_patterns_destroy(gs_model_patterns *p)
{
    if (!p)
        return;
    gs_free(p->colors);
    gs_free(p->pat);
    gs_free(p->count);
    gs_free(p->bottom);
    gs_free(p->pairs);
    memset(p, 0, sizeof *p);
}

/* Does b placed at offset (dx, dy) from a agree with a on the overlap? */
static int agrees(const uint8_t *a, const uint8_t *b, int n, int dx, int dy)
{
    int xmin = dx < 0 ? 0 : dx, xmax = dx < 0 ? dx + n : n;
    int ymin = dy < 0 ? 0 : dy, ymax = dy < 0 ? dy + n : n;
    for (int y = ymin; y < ymax; y++)
        for (int x = xmin; x < xmax; x++)
            if (a[x + n * y] != b[x - dx + n * (y - dy)])
                return 0;
    return 1;
}

gs_err gs_model_patterns_learn(const char *png, int n, int symmetry, int periodic_input,
                               gs_model_patterns *out)
{
    GS_CHECK(n >= 2 && n <= 8, GS_ERR_ARG, "%s: pattern size N = %d: expected 2..8", png, n);
    GS_CHECK(symmetry >= 1 && symmetry <= 8, GS_ERR_ARG, "%s: symmetry %d: expected 1..8", png,
             symmetry);
    gs_image img;
    GS_CALL(gs_image_read(png, &img));
    gs_model_patterns P;
    memset(&P, 0, sizeof P);
    P.n = n;
    gs_err err = GS_OK;
    uint8_t *sample = NULL, *ps = NULL;
    uint64_t *table = NULL; /* open addressing: pattern index + 1, 0 = free */
    const int W = img.width, H = img.height, NN = n * n;
    GS_TRY_CHECK(err, W >= n && H >= n, GS_ERR_ARG, fail, "%s: %dx%d pixels: smaller than N = %d",
                 png, W, H, n);
    GS_TRY(err, gs_alloc_array((void **)&P.colors, MAX_COLORS, sizeof *P.colors, "colours"), fail);
    GS_TRY(err, gs_alloc_array((void **)&sample, (size_t)W * (size_t)H, 1, "sample"), fail);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            uint8_t px[4] = {0, 0, 0, 255};
            for (int c = 0; c < img.channels; c++) {
                size_t i = ((size_t)y * (size_t)W + (size_t)x) * (size_t)img.channels + (size_t)c;
                uint8_t v = img.bits == 8 ? img.data8[i] : (uint8_t)(img.data16[i] >> 8);
                px[img.channels <= 2 ? (c == 0 ? 0 : 3) : c] = v;
            }
            if (img.channels <= 2)
                px[1] = px[2] = px[0];
            uint32_t rgba = (uint32_t)px[0] | (uint32_t)px[1] << 8 | (uint32_t)px[2] << 16 |
                            (uint32_t)px[3] << 24;
            int k = 0;
            while (k < P.ncolors && P.colors[k] != rgba)
                k++;
            if (k == P.ncolors) {
                GS_TRY_CHECK(err, P.ncolors < MAX_COLORS, GS_ERR_ARG, fail,
                             "%s: more than %d distinct colours: the overlapping model wants a "
                             "small palette",
                             png, MAX_COLORS);
                P.colors[P.ncolors++] = rgba;
            }
            sample[(size_t)y * (size_t)W + (size_t)x] = (uint8_t)k;
        }
    gs_image_destroy(&img);
    const int xs = periodic_input ? W : W - n + 1, ys = periodic_input ? H : H - n + 1;
    size_t maxp = (size_t)xs * (size_t)ys * (size_t)symmetry;
    if (maxp > MAX_PATTERNS)
        maxp = MAX_PATTERNS;
    size_t tsize = 1;
    while (tsize < 2 * maxp + 2)
        tsize <<= 1;
    GS_TRY(err, gs_alloc_array((void **)&P.pat, maxp, (size_t)NN, "patterns"), fail);
    GS_TRY(err, gs_alloc_array((void **)&P.count, maxp, sizeof *P.count, "pattern counts"), fail);
    GS_TRY(err, gs_alloc_array((void **)&P.bottom, maxp, sizeof *P.bottom, "pattern counts"), fail);
    GS_TRY(err, gs_alloc_array((void **)&table, tsize, sizeof *table, "pattern table"), fail);
    memset(table, 0, tsize * sizeof *table);
    GS_TRY(err, gs_alloc_array((void **)&ps, 8, (size_t)NN, "pattern variants"), fail);
    for (int y = 0; y < ys; y++)
        for (int x = 0; x < xs; x++) {
            uint8_t *v = ps;
            for (int dy = 0; dy < n; dy++)
                for (int dx = 0; dx < n; dx++)
                    v[dx + n * dy] = sample[(size_t)((y + dy) % H) * (size_t)W + (size_t)((x + dx) % W)];
            /* mxgmn: 1 = reflect(0), 2 = rotate(0), 3 = reflect(2), 4 = rotate(2),
             * 5 = reflect(4), 6 = rotate(4), 7 = reflect(6); rotate(p)[x + n*y] =
             * p[n-1-y + n*x], reflect(p)[x + n*y] = p[n-1-x + n*y]. */
            for (int k = 1; k < 8; k++) {
                const uint8_t *src = ps + (size_t)(k % 2 ? k - 1 : k - 2) * (size_t)NN;
                uint8_t *dst = ps + (size_t)k * (size_t)NN;
                for (int py = 0; py < n; py++)
                    for (int px = 0; px < n; px++)
                        dst[px + n * py] = k % 2 ? src[n - 1 - px + n * py] : src[n - 1 - py + n * px];
            }
            /* a window whose bottom row is the sample's bottom row (as is or
             * mirrored in x: down stays down) is a ground pattern */
            const int at_bottom = y == H - n;
            for (int k = 0; k < symmetry; k++) {
                const uint8_t *q = ps + (size_t)k * (size_t)NN;
                uint64_t h = gs_digest_bytes(q, (size_t)NN);
                size_t slot = (size_t)h & (tsize - 1);
                for (;;) {
                    if (!table[slot]) {
                        GS_TRY_CHECK(err, (size_t)P.npatterns < maxp, GS_ERR_ARG, fail,
                                     "%s: more than %d distinct %dx%d patterns", png, MAX_PATTERNS,
                                     n, n);
                        memcpy(P.pat + (size_t)P.npatterns * (size_t)NN, q, (size_t)NN);
                        P.count[P.npatterns] = 1;
                        P.bottom[P.npatterns] = at_bottom && k < 2;
                        table[slot] = (uint64_t)++P.npatterns;
                        break;
                    }
                    size_t idx = (size_t)table[slot] - 1;
                    if (!memcmp(P.pat + idx * (size_t)NN, q, (size_t)NN)) {
                        P.count[idx]++;
                        P.bottom[idx] += at_bottom && k < 2;
                        break;
                    }
                    slot = (slot + 1) & (tsize - 1);
                }
            }
        }
    /* adjacency by overlap agreement */
    size_t cap = 1024, np = 0;
    GS_TRY(err, gs_alloc_array((void **)&P.pairs, cap, sizeof *P.pairs, "pattern pairs"), fail);
    for (int a = 0; a < P.npatterns; a++)
        for (int b = 0; b < P.npatterns; b++)
            for (int dir = 0; dir <= 2; dir += 2) {
                if (!agrees(P.pat + (size_t)a * (size_t)NN, P.pat + (size_t)b * (size_t)NN, n,
                            dir == 0, dir == 2))
                    continue;
                if (np == cap) {
                    cap *= 2;
                    void *nb = gs_realloc(P.pairs, cap * sizeof *P.pairs);
                    GS_TRY_CHECK(err, nb, GS_ERR_MEM, fail, "%s: out of memory for pairs", png);
                    P.pairs = nb;
                }
                P.pairs[np++] = (gs_model_pair){(uint8_t)dir, (uint16_t)(a + 1), (uint16_t)(b + 1)};
            }
    P.npairs = np;
    gs_free(sample);
    gs_free(ps);
    gs_free(table);
    *out = P;
    return GS_OK;
fail:
    gs_image_destroy(&img);
    gs_free(sample);
    gs_free(ps);
    gs_free(table);
    gs_model_patterns_destroy(&P);
    return err;
}

gs_err gs_model_patterns_rules(const gs_model_patterns *p, gs_model_rules_t *out)
{
    uint64_t *counts = NULL;
    GS_CALL(gs_alloc_array((void **)&counts, (size_t)p->npatterns + 1, sizeof *counts, "counts"));
    counts[0] = 0;
    for (int i = 0; i < p->npatterns; i++)
        counts[i + 1] = p->count[i];
    gs_err err = gs_model_rules_from_pairs(p->npatterns + 1, p->pairs, p->npairs, counts, out);
    gs_free(counts);
    return err;
}

gs_err gs_model_patterns_write_png(const char *path, const gs_model_patterns *p,
                                   const gs_model_lattice *lat)
{
    const int n = p->n, W = lat->nx + n - 1, H = lat->ny + n - 1;
    gs_image img;
    GS_CALL(gs_image_alloc(&img, W, H, 4, 8));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int cx = x < lat->nx ? x : lat->nx - 1, cy = y < lat->ny ? y : lat->ny - 1;
            int l = lat->labels[gs_model_lattice_index(lat, cx, cy, 0)];
            uint32_t rgba = 0;
            if (l >= 1 && l <= p->npatterns)
                rgba = p->colors[p->pat[(size_t)(l - 1) * (size_t)(n * n) + (size_t)(x - cx) +
                                        (size_t)n * (size_t)(y - cy)]];
            uint8_t *px = img.data8 + ((size_t)y * (size_t)W + (size_t)x) * 4;
            for (int c = 0; c < 4; c++)
                px[c] = (uint8_t)(rgba >> (8 * c));
        }
    gs_err err = gs_image_write_png(path, &img);
    gs_image_destroy(&img);
    return err;
}

gs_err gs_model_patterns_check(const gs_model_patterns *p, const gs_model_lattice *lat,
                               size_t *count)
{
    const int n = p->n, NN = n * n;
    size_t bad = 0;
    for (int z = 0; z < lat->nz; z++)
        for (int y = 0; y < lat->ny; y++)
            for (int x = 0; x < lat->nx; x++) {
                int a = lat->labels[gs_model_lattice_index(lat, x, y, z)];
                if (a < 1 || a > p->npatterns) {
                    bad++;
                    continue;
                }
                const uint8_t *pa = p->pat + (size_t)(a - 1) * (size_t)NN;
                for (int axis = 0; axis < 2; axis++) {
                    int qx = x + (axis == 0), qy = y + (axis == 1);
                    if (qx >= lat->nx || qy >= lat->ny)
                        continue;
                    int b = lat->labels[gs_model_lattice_index(lat, qx, qy, z)];
                    if (b < 1 || b > p->npatterns)
                        continue; /* counted at its own cell */
                    const uint8_t *pb = p->pat + (size_t)(b - 1) * (size_t)NN;
                    /* pixel (i, j) of b is pixel (i + dx, j + dy) of a */
                    int ok = 1;
                    for (int j = 0; j < n && ok; j++)
                        for (int i = 0; i < n && ok; i++) {
                            int ax = i + (axis == 0), ay = j + (axis == 1);
                            if (ax < n && ay < n && pa[ax + n * ay] != pb[i + n * j])
                                ok = 0;
                        }
                    bad += !ok;
                }
            }
    *count = bad;
    return GS_OK;
}
