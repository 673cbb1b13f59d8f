/* 3D overlapping model (model.overlap3d = N): every N x N x N window of an
 * example lattice is a label (a pattern); two patterns may be neighbours
 * along +x/+y/+z when they agree on their (N-1)-thick overlap. The output
 * lattice holds each cell's pattern's origin cell, so every output window
 * of edge k <= N lies inside one pattern: it is an example window by
 * construction. See include/geosynth/model_tiles.h. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/model_tiles.h"

void gs_model_patterns3d_destroy(gs_model_patterns3d *p)
{
    if (!p)
        return;
    gs_free(p->pat);
    gs_free(p->count);
    gs_free(p->pairs);
    gs_free(p->support_empty);
    gs_free(p->support_above);
    gs_model_lattice_destroy(&p->windows);
    memset(p, 0, sizeof *p);
}

/* Copies the part of pattern q lying at coordinate >= lo and <= hi
 * along axis (0 x, 1 y, 2 z); every other coordinate whole. */
static void slice_copy(const uint16_t *q, int n, int axis, int lo, int hi, uint16_t *dst)
{
    size_t k = 0;
    for (int z = 0; z < n; z++)
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++) {
                int c = axis == 0 ? x : axis == 1 ? y : z;
                if (c >= lo && c <= hi)
                    dst[k++] = q[x + n * (y + n * z)];
            }
}

typedef struct key_idx {
    uint64_t key;
    int32_t idx;
} key_idx;

static int key_cmp(const void *a, const void *b)
{
    const key_idx *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->idx < y->idx ? -1 : x->idx > y->idx;
}

gs_err gs_model_patterns3d_learn(const gs_model_lattice *ex, int n, int max_patterns,
                                 const char *name, gs_model_patterns3d *out)
{
    GS_CHECK(n >= 2 && n <= 4, GS_ERR_ARG, "model.overlap3d = %d: expected 2..4 (or 0 = off)", n);
    GS_CHECK(ex->frames <= 1, GS_ERR_ARG, "%s: model.overlap3d needs a 3D example, not 4D", name);
    GS_CHECK(ex->nx >= n && ex->ny >= n && ex->nz >= n, GS_ERR_ARG,
             "%s: %dx%dx%d cells: smaller than model.overlap3d = %d along some axis", name, ex->nx,
             ex->ny, ex->nz, n);
    gs_model_patterns3d P;
    memset(&P, 0, sizeof P);
    P.n = n;
    const int NNN = n * n * n, wx = ex->nx - n + 1, wy = ex->ny - n + 1, wz = ex->nz - n + 1;
    const size_t nwin = (size_t)wx * (size_t)wy * (size_t)wz;
    size_t tsize = 1;
    while (tsize < 2 * nwin + 2)
        tsize <<= 1;
    gs_err err = GS_OK;
    int32_t *table = NULL; /* open addressing: pattern index, -1 = free */
    uint16_t *w = NULL, *sa = NULL;
    key_idx *lo = NULL;
    GS_TRY(err, gs_alloc_array((void **)&P.pat, nwin, (size_t)NNN * sizeof *P.pat, "patterns"), fail);
    GS_TRY(err, gs_alloc_array((void **)&P.count, nwin, sizeof *P.count, "pattern counts"), fail);
    GS_TRY(err, gs_alloc_array((void **)&table, tsize, sizeof *table, "pattern table"), fail);
    GS_TRY(err, gs_alloc_array((void **)&w, (size_t)NNN, sizeof *w, "window"), fail);
    GS_TRY(err, gs_model_lattice_create(&P.windows, wx, wy, wz), fail);
    for (size_t i = 0; i < tsize; i++)
        table[i] = -1;
    for (int z = 0; z < wz; z++)
        for (int y = 0; y < wy; y++)
            for (int x = 0; x < wx; x++) {
                for (int dz = 0; dz < n; dz++)
                    for (int dy = 0; dy < n; dy++)
                        for (int dx = 0; dx < n; dx++)
                            w[dx + n * (dy + n * dz)] =
                                ex->labels[gs_model_lattice_index(ex, x + dx, y + dy, z + dz)];
                size_t slot = (size_t)gs_digest_bytes(w, (size_t)NNN * sizeof *w) & (tsize - 1);
                int idx;
                for (;;) {
                    idx = table[slot];
                    if (idx < 0) {
                        GS_TRY_CHECK(err, P.npatterns < max_patterns, GS_ERR_ARG, fail,
                                     "%s: more than %d distinct %dx%dx%d windows (model.overlap3d "
                                     "= %d): the rules would need %.0f MiB and the solver slows "
                                     "with the label count; use a smaller N or example",
                                     name, max_patterns, n, n, n, n,
                                     8.0 * max_patterns * ((max_patterns + 63) / 64) * 8 / 1048576.0);
                        idx = P.npatterns++;
                        memcpy(P.pat + (size_t)idx * (size_t)NNN, w, (size_t)NNN * sizeof *w);
                        P.count[idx] = 0;
                        table[slot] = idx;
                        break;
                    }
                    if (!memcmp(P.pat + (size_t)idx * (size_t)NNN, w, (size_t)NNN * sizeof *w))
                        break;
                    slot = (slot + 1) & (tsize - 1);
                }
                P.count[idx]++;
                P.windows.labels[gs_model_lattice_index(&P.windows, x, y, z)] = (uint16_t)(idx + 1);
            }
    /* Overlap agreement along +axis: b at v + e_axis of a when a's cells at
     * coordinate 1..n-1 along the axis equal b's at 0..n-2. Patterns sorted
     * by the digest of their low slab; each a looks its high slab up. */
    const int NS = NNN / n * (n - 1); /* cells of one (n-1)-thick slab */
    const int np = P.npatterns;
    size_t cap = 1024, npairs = 0;
    GS_TRY(err, gs_alloc_array((void **)&P.pairs, cap, sizeof *P.pairs, "pattern pairs"), fail);
    GS_TRY(err, gs_alloc_array((void **)&sa, 2 * (size_t)NS, sizeof *sa, "slabs"), fail);
    GS_TRY(err, gs_alloc_array((void **)&lo, (size_t)np, sizeof *lo, "slab keys"), fail);
    for (int axis = 0; axis < 3; axis++) {
        for (int b = 0; b < np; b++) {
            slice_copy(P.pat + (size_t)b * (size_t)NNN, n, axis, 0, n - 2, sa);
            lo[b] = (key_idx){gs_digest_bytes(sa, (size_t)NS * sizeof *sa), b};
        }
        qsort(lo, (size_t)np, sizeof *lo, key_cmp);
        for (int a = 0; a < np; a++) {
            slice_copy(P.pat + (size_t)a * (size_t)NNN, n, axis, 1, n - 1, sa);
            uint64_t key = gs_digest_bytes(sa, (size_t)NS * sizeof *sa);
            size_t l = 0, h = (size_t)np; /* first entry with key >= key */
            while (l < h) {
                size_t m = (l + h) / 2;
                if (lo[m].key < key)
                    l = m + 1;
                else
                    h = m;
            }
            for (size_t i = l; i < (size_t)np && lo[i].key == key; i++) {
                int b = lo[i].idx;
                slice_copy(P.pat + (size_t)b * (size_t)NNN, n, axis, 0, n - 2, sa + NS);
                if (memcmp(sa, sa + NS, (size_t)NS * sizeof *sa))
                    continue; /* digest collision */
                if (npairs == cap) {
                    cap *= 2;
                    void *nb = gs_realloc(P.pairs, cap * sizeof *P.pairs);
                    GS_TRY_CHECK(err, nb, GS_ERR_MEM, fail, "%s: out of memory for pattern pairs",
                                 name);
                    P.pairs = nb;
                }
                P.pairs[npairs++] =
                    (gs_model_pair){(uint8_t)(2 * axis), (uint16_t)(a + 1), (uint16_t)(b + 1)};
            }
        }
    }
    P.npairs = npairs;
    {
        /* an example without floating structure: which patterns are empty at their origin */
        const int dims[3] = {ex->nx, ex->ny, ex->nz};
        uint64_t unsup = 0, nonempty = 0;
        GS_TRY(err, gs_measure_unsupported(ex->labels, dims, &unsup, &nonempty), fail);
        if (unsup == 0) {
            GS_TRY(err, gs_alloc_array((void **)&P.support_empty, (size_t)P.npatterns + 1, 1,
                                       "pattern origins"),
                   fail);
            GS_TRY(err, gs_alloc_array((void **)&P.support_above, (size_t)P.npatterns + 1, 1,
                                       "pattern columns"),
                   fail);
            P.support_empty[0] = 1;
            P.support_above[0] = 0;
            for (int a = 0; a < P.npatterns; a++) {
                const uint16_t *q = P.pat + (size_t)a * (size_t)NNN;
                P.support_empty[a + 1] = q[0] == 0;
                P.support_above[a + 1] = 0;
                for (int k = 1; k < n; k++)
                    P.support_above[a + 1] |= (uint8_t)((q[(size_t)k * (size_t)(n * n)] != 0) << (k - 1));
            }
        }
    }
    gs_free(table);
    gs_free(w);
    gs_free(sa);
    gs_free(lo);
    *out = P;
    return GS_OK;
fail:
    gs_free(table);
    gs_free(w);
    gs_free(sa);
    gs_free(lo);
    gs_model_patterns3d_destroy(&P);
    return err;
}

gs_err gs_model_patterns3d_rules(const gs_model_patterns3d *p, gs_model_rules_t *out)
{
    /* the 2D model's conversion: label i + 1 weighs count[i], label 0 absent */
    gs_model_patterns view;
    memset(&view, 0, sizeof view);
    view.npatterns = p->npatterns;
    view.count = p->count;
    view.pairs = p->pairs;
    view.npairs = p->npairs;
    return gs_model_patterns_rules(&view, out);
}

gs_err gs_model_patterns3d_decode(const gs_model_patterns3d *p, const gs_model_lattice *plat,
                                  int top, gs_model_lattice *out)
{
    const int n = p->n, extra = top ? n - 1 : 0;
    GS_CALL(gs_model_lattice_create(out, plat->nx, plat->ny, plat->nz + extra));
    const size_t NNN = (size_t)n * (size_t)n * (size_t)n;
    for (int z = 0; z < out->nz; z++) {
        /* above the last pattern layer: that layer's patterns' upper slices */
        const int pz = z < plat->nz ? z : plat->nz - 1, k = z - pz;
        for (int y = 0; y < plat->ny; y++)
            for (int x = 0; x < plat->nx; x++) {
                size_t i = gs_model_lattice_index(plat, x, y, pz);
                int l = plat->labels[i];
                GS_CHECK(l >= 1 && l <= p->npatterns, GS_ERR_INTERNAL,
                         "cell %zu holds no pattern (%d)", i, l);
                out->labels[gs_model_lattice_index(out, x, y, z)] =
                    p->pat[(size_t)(l - 1) * NNN + (size_t)k * (size_t)n * (size_t)n];
            }
    }
    return GS_OK;
}

size_t gs_model_patterns3d_check(const gs_model_patterns3d *p, const gs_model_lattice *plat,
                                 const int periodic[3])
{
    const int n = p->n, NNN = n * n * n;
    size_t bad = 0;
    for (int z = 0; z < plat->nz; z++)
        for (int y = 0; y < plat->ny; y++)
            for (int x = 0; x < plat->nx; x++) {
                int a = plat->labels[gs_model_lattice_index(plat, x, y, z)];
                if (a < 1 || a > p->npatterns) {
                    bad++;
                    continue;
                }
                const uint16_t *pa = p->pat + (size_t)(a - 1) * (size_t)NNN;
                for (int axis = 0; axis < 3; axis++) {
                    int q[3] = {x, y, z}, ext[3] = {plat->nx, plat->ny, plat->nz};
                    q[axis]++;
                    if (q[axis] >= ext[axis]) {
                        if (!periodic || !periodic[axis])
                            continue;
                        q[axis] = 0;
                    }
                    int b = plat->labels[gs_model_lattice_index(plat, q[0], q[1], q[2])];
                    if (b < 1 || b > p->npatterns)
                        continue; /* counted at its own cell */
                    const uint16_t *pb = p->pat + (size_t)(b - 1) * (size_t)NNN;
                    /* cell (i, j, k) of b is cell (i, j, k) + e_axis of a */
                    int ok = 1;
                    for (int k = 0; k < n && ok; k++)
                        for (int j = 0; j < n && ok; j++)
                            for (int i = 0; i < n && ok; i++) {
                                int c[3] = {i, j, k};
                                c[axis]++;
                                if (c[axis] < n &&
                                    pa[c[0] + n * (c[1] + n * c[2])] != pb[i + n * (j + n * k)])
                                    ok = 0;
                            }
                    bad += !ok;
                }
            }
    return bad;
}
