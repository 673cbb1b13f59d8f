/* Resemblance during synthesis (Merrell 2007, section 3.3, Eqs. 2-6): the
 * index of the example's neighbourhoods. See include/geosynth/model.h
 * (gs_model_resem_build) and the chooser in src/model/solver.c.
 *
 * Every example location v' gives a pattern: its label E[v'] (the centre)
 * and the labels of its (2w+1)^3 - 1 neighbours (OUTSIDE past the example's
 * faces: undefined; per offset q a bitset marks the patterns with OUTSIDE
 * there, which the chooser scores as gs_model_resem_set_outside says: a
 * mismatch by default, half a match, a match, or a match only against the
 * example's face background of that layer (bg), a mismatch against anything else;
 * gs_model_resem_build_wrap takes the example as a tile instead: past its x/y
 * faces lies the example's cell a period on, so only past its z faces is a cell
 * undefined). Equal patterns are merged with a multiplicity.
 * Patterns are sorted by centre label, so the patterns whose centre is a
 * candidate of a cell form a few runs of bit positions. For every (offset
 * q, label a) that occurs, a bitset over the patterns marks those with label
 * a at q: the match count of every pattern against a cell's decided
 * neighbours is the sum of the neighbours' bitsets, accumulated in
 * bit-sliced counters (src/model/solver.c, choose_label_resem).
 */
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "model/model_impl.h"

#define OUTSIDE 0xffffu

/* Numbers the (label, offset) pairs marked 0 in slot ([L + 1][Q], label-major; -1 =
 * none) in that order: the bitsets of one label at neighbouring offsets lie side by
 * side, so a cell whose decided neighbours mostly hold a few labels (air, ground)
 * reads a few runs of the slot table and of the bitsets instead of one cache line per
 * neighbour (the counts are the same: only where each bitset is stored changes).
 * Returns how many were numbered. */
static size_t number_slots(int32_t *slot, size_t n)
{
    size_t ns = 0;
    for (size_t k = 0; k < n; k++)
        if (slot[k] == 0)
            slot[k] = (int32_t)ns++;
    return ns;
}

/* The layer views (struct gs_model_resem_view): layer z's patterns (zbits) in the
 * index's order, their multiplicities there (zmult), and bitsets over them of the
 * (offset, label) pairs and the past-the-faces cells that occur among them. Left out
 * (lv = NULL: every choice counts over all patterns, with the same result) when the
 * slot tables would take more than 64 MiB. */
static gs_err build_layer_views(struct gs_model_resem *r, const uint16_t *rows, size_t row)
{
    const size_t P = (size_t)r->P, Q = (size_t)r->Q, L = (size_t)r->L, nz = (size_t)r->nz;
    const size_t LS = L + 1; /* slot rows: column L (no label) holds none */
    if (Q * LS * nz * sizeof(int32_t) > ((size_t)64 << 20))
        return GS_OK;
    r->lv = gs_calloc(nz, sizeof *r->lv);
    GS_CHECK(r->lv != NULL, GS_ERR_MEM, "resemblance layer index: cannot allocate");
    uint32_t *idx = gs_malloc((P ? P : 1) * sizeof *idx);
    int32_t *slot = gs_malloc(Q * LS * sizeof *slot);
    int32_t *oslot = gs_malloc(Q * sizeof *oslot);
    gs_err err = GS_OK;
    GS_TRY_CHECK(err, idx && slot && oslot, GS_ERR_MEM, done,
                 "resemblance layer index: cannot allocate");
    for (size_t z = 0; z < nz; z++) {
        const uint64_t *zb = r->zbits + z * (size_t)r->PW;
        size_t Pz = 0;
        for (size_t i = 0; i < P; i++)
            if ((zb[i >> 6] >> (i & 63)) & 1)
                idx[Pz++] = (uint32_t)i;
        const size_t PWz = (Pz + 63) / 64;
        for (size_t k = 0; k < Q * LS; k++)
            slot[k] = -1;
        for (size_t j = 0; j < Pz; j++)
            for (size_t q = 0; q < Q; q++) {
                uint16_t a = rows[idx[j] * row + 1 + q];
                if (a != OUTSIDE)
                    slot[a * Q + q] = 0;
            }
        size_t ns = number_slots(slot, Q * LS);
        for (size_t q = 0; q < Q; q++) {
            oslot[q] = -1;
            for (size_t j = 0; j < Pz && oslot[q] < 0; j++)
                if (rows[idx[j] * row + 1 + q] == OUTSIDE)
                    oslot[q] = (int32_t)ns++;
        }
        /* one block: bits, slot, oslot, range, mult, center */
        const size_t nb = (ns ? ns : 1) * PWz, bytes = nb * 8 + (Q * LS + Q + L + 1) * 4 +
                                                       (Pz ? Pz : 1) * 4 + (Pz ? Pz : 1) * 2;
        void *raw = gs_calloc(1, bytes + 64);
        GS_TRY_CHECK(err, raw != NULL, GS_ERR_MEM, done,
                     "resemblance layer index: cannot allocate %zu bytes", bytes);
        uint64_t *mem = gs_model_line_align(raw); /* the bitsets' rows on line boundaries */
        int32_t *vslot = (int32_t *)(mem + nb), *voslot = vslot + Q * LS, *vrange = voslot + Q;
        uint32_t *vmult = (uint32_t *)(vrange + L + 1);
        uint16_t *vcenter = (uint16_t *)(vmult + (Pz ? Pz : 1));
        memcpy(vslot, slot, Q * LS * sizeof *slot);
        memcpy(voslot, oslot, Q * sizeof *oslot);
        for (size_t j = 0; j < Pz; j++) {
            const size_t i = idx[j];
            vmult[j] = r->zmult[z * P + i];
            vcenter[j] = r->center[i];
            vrange[vcenter[j] + 1]++;
            for (size_t q = 0; q < Q; q++) {
                uint16_t a = rows[i * row + 1 + q];
                int32_t sl = a == OUTSIDE ? oslot[q] : slot[a * Q + q];
                mem[(size_t)sl * PWz + (j >> 6)] |= (uint64_t)1 << (j & 63);
            }
        }
        for (size_t l = 0; l < L; l++)
            vrange[l + 1] += vrange[l];
        r->lv[z] = (struct gs_model_resem_view){(int)Pz, (int)PWz, vmult, vcenter, vrange,
                                                vslot, mem, voslot, raw};
    }
done:
    gs_free(idx);
    gs_free(slot);
    gs_free(oslot);
    return err;
}

gs_err gs_model_resem_build(const gs_model_lattice *ex, int w, int slack, int layers,
                            gs_model_resem_t *out)
{
    return gs_model_resem_build_wrap(ex, w, slack, layers, 0, out);
}

gs_err gs_model_resem_build_wrap(const gs_model_lattice *ex, int w, int slack, int layers,
                                 int wrap_xy, gs_model_resem_t *out)
{
    GS_CHECK(w >= 1 && w <= 2, GS_ERR_ARG, "model.resemblance window radius %d: expected 1 or 2", w);
    GS_CHECK(slack >= 0 && slack <= 64, GS_ERR_ARG, "model.resemblance_slack = %d: expected 0..64",
             slack);
    const int side = 2 * w + 1;
    const int Q = side * side * side - 1;
    const size_t key = (size_t)Q + 1, row = key + 1; /* centre, neighbours, then z */
    const size_t ne = (size_t)ex->nx * ex->ny * ex->nz;
    struct gs_model_resem *r = gs_calloc(1, sizeof *r);
    GS_CHECK(r != NULL, GS_ERR_MEM, "resemblance index: cannot allocate");
    uint16_t *rows = NULL, *zs = NULL; /* zs: layer of every location, in merged order */
    uint32_t *first = NULL;            /* first location of every pattern */
    gs_err err = GS_OK;
    r->w = w;
    r->Q = Q;
    r->slack = slack;
    GS_TRY(err, gs_alloc_array((void **)&r->off, (size_t)Q * 3, sizeof *r->off, "offsets"), fail);
    int q = 0;
    for (int dz = -w; dz <= w; dz++)
        for (int dy = -w; dy <= w; dy++)
            for (int dx = -w; dx <= w; dx++) {
                if (!dx && !dy && !dz)
                    continue;
                r->off[3 * q] = dx;
                r->off[3 * q + 1] = dy;
                r->off[3 * q + 2] = dz;
                q++;
            }
    GS_TRY(err, gs_alloc_array((void **)&rows, ne, row * sizeof *rows, "example neighbourhoods"),
           fail);
    int L = 1;
    size_t i = 0;
    for (int z = 0; z < ex->nz; z++)
        for (int y = 0; y < ex->ny; y++)
            for (int x = 0; x < ex->nx; x++, i++) {
                uint16_t *rw = rows + i * row;
                rw[0] = ex->labels[gs_model_lattice_index(ex, x, y, z)];
                rw[key] = (uint16_t)z;
                if (rw[0] + 1 > L)
                    L = rw[0] + 1;
                for (q = 0; q < Q; q++) {
                    int px = x + r->off[3 * q], py = y + r->off[3 * q + 1], pz = z + r->off[3 * q + 2];
                    if (wrap_xy) { /* the example as a tile: the cell a period on */
                        px = (px % ex->nx + ex->nx) % ex->nx;
                        py = (py % ex->ny + ex->ny) % ex->ny;
                    }
                    rw[1 + q] = px < 0 || py < 0 || pz < 0 || px >= ex->nx || py >= ex->ny ||
                                        pz >= ex->nz
                                    ? OUTSIDE
                                    : ex->labels[gs_model_lattice_index(ex, px, py, pz)];
                }
            }
    gs_model_sort_rows(rows, ne, row); /* patterns: rows of `row` labels, centre first */
    /* merge equal rows */
    size_t P = 0;
    GS_TRY(err, gs_alloc_array((void **)&r->mult, ne, sizeof *r->mult, "pattern counts"), fail);
    GS_TRY(err, gs_alloc_array((void **)&zs, ne, sizeof *zs, "pattern layers"), fail);
    GS_TRY(err, gs_alloc_array((void **)&first, ne + 1, sizeof *first, "pattern layers"), fail);
    for (i = 0; i < ne; i++) {
        zs[i] = rows[i * row + key];
        if (P && !memcmp(rows + (P - 1) * row, rows + i * row, key * sizeof *rows)) {
            r->mult[P - 1]++;
            continue;
        }
        first[P] = (uint32_t)i;
        if (P != i)
            memcpy(rows + P * row, rows + i * row, row * sizeof *rows);
        r->mult[P++] = 1;
    }
    first[P] = (uint32_t)ne;
    r->P = (int)P;
    r->PW = (int)((P + 63) / 64);
    r->L = L;
    GS_TRY(err, gs_alloc_array((void **)&r->center, P, sizeof *r->center, "pattern centres"), fail);
    GS_TRY(err, gs_alloc_array((void **)&r->range, (size_t)L + 1, sizeof *r->range, "centre runs"),
           fail);
    for (int l = 0; l <= L; l++)
        r->range[l] = 0;
    for (i = 0; i < P; i++) {
        r->center[i] = rows[i * row];
        r->range[r->center[i] + 1]++;
    }
    for (int l = 0; l < L; l++)
        r->range[l + 1] += r->range[l];
    /* bitsets of the (offset, label) pairs that occur */
    GS_TRY(err, gs_alloc_array((void **)&r->slot, (size_t)Q * (size_t)(L + 1), sizeof *r->slot, "slots"),
           fail);
    for (size_t k = 0; k < (size_t)Q * (size_t)(L + 1); k++)
        r->slot[k] = -1;
    for (i = 0; i < P; i++)
        for (q = 0; q < Q; q++) {
            uint16_t a = rows[i * row + 1 + (size_t)q];
            if (a != OUTSIDE)
                r->slot[(size_t)a * (size_t)Q + (size_t)q] = 0;
        }
    size_t nslots = number_slots(r->slot, (size_t)Q * (size_t)(L + 1));
    GS_TRY(err, gs_alloc_array((void **)&r->bits, nslots ? nslots : 1, (size_t)r->PW * 8, "pattern bitsets"),
           fail);
    memset(r->bits, 0, (nslots ? nslots : 1) * (size_t)r->PW * 8);
    for (i = 0; i < P; i++)
        for (q = 0; q < Q; q++) {
            uint16_t a = rows[i * row + 1 + (size_t)q];
            if (a == OUTSIDE)
                continue;
            uint64_t *b = r->bits + (size_t)r->slot[(size_t)a * (size_t)Q + (size_t)q] * (size_t)r->PW;
            b[i >> 6] |= (uint64_t)1 << (i & 63);
        }
    /* the patterns with OUTSIDE at q: one more bitset per such offset */
    GS_TRY(err, gs_alloc_array((void **)&r->oslot, (size_t)Q, sizeof *r->oslot, "outside slots"),
           fail);
    size_t extra = 0;
    for (q = 0; q < Q; q++) {
        r->oslot[q] = -1;
        for (i = 0; i < P && r->oslot[q] < 0; i++)
            if (rows[i * row + 1 + (size_t)q] == OUTSIDE)
                r->oslot[q] = (int32_t)(nslots + extra++);
    }
    if (extra) {
        void *nb = gs_realloc(r->bits, (nslots + extra) * (size_t)r->PW * 8);
        GS_TRY_CHECK(err, nb != NULL, GS_ERR_MEM, fail, "resemblance index: out of memory");
        r->bits = nb;
        memset(r->bits + nslots * (size_t)r->PW, 0, extra * (size_t)r->PW * 8);
        for (q = 0; q < Q; q++)
            for (i = 0; r->oslot[q] >= 0 && i < P; i++)
                if (rows[i * row + 1 + (size_t)q] == OUTSIDE)
                    r->bits[(size_t)r->oslot[q] * (size_t)r->PW + (i >> 6)] |= (uint64_t)1 << (i & 63);
    }
    nslots += extra;
    r->nslots = nslots;
    r->nz = ex->nz;
    /* the background of every layer: the commonest label on the example's x/y faces there
     * (what an example continued past its faces most likely holds) */
    GS_TRY(err, gs_alloc_array((void **)&r->bg, (size_t)ex->nz, sizeof *r->bg, "backgrounds"),
           fail);
    {
        uint32_t *hist = gs_calloc((size_t)L, sizeof *hist);
        GS_TRY_CHECK(err, hist != NULL, GS_ERR_MEM, fail, "resemblance index: out of memory");
        for (int z = 0; z < ex->nz; z++) {
            memset(hist, 0, (size_t)L * sizeof *hist);
            for (int y = 0; y < ex->ny; y++)
                for (int x = 0; x < ex->nx; x++)
                    if (x == 0 || y == 0 || x == ex->nx - 1 || y == ex->ny - 1)
                        hist[ex->labels[gs_model_lattice_index(ex, x, y, z)]]++;
            int best = 0;
            for (int l = 1; l < L; l++)
                if (hist[l] > hist[best])
                    best = l;
            r->bg[z] = (uint16_t)best;
        }
        gs_free(hist);
    }
    r->layers = layers;
    if (layers) {
        GS_TRY(err, gs_alloc_array((void **)&r->zmult, (size_t)ex->nz * P, sizeof *r->zmult,
                                   "pattern layer counts"),
               fail);
        GS_TRY(err, gs_alloc_array((void **)&r->zbits, (size_t)ex->nz * (size_t)r->PW, 8,
                                   "pattern layer bitsets"),
               fail);
        memset(r->zmult, 0, (size_t)ex->nz * P * sizeof *r->zmult);
        memset(r->zbits, 0, (size_t)ex->nz * (size_t)r->PW * 8);
        for (i = 0; i < P; i++)
            for (uint32_t k = first[i]; k < first[i + 1]; k++) {
                r->zmult[(size_t)zs[k] * P + i]++;
                r->zbits[(size_t)zs[k] * (size_t)r->PW + (i >> 6)] |= (uint64_t)1 << (i & 63);
            }
    }
    gs_free(zs);
    gs_free(first);
    zs = NULL;
    first = NULL;
    r->all = (struct gs_model_resem_view){(int)P, r->PW, r->mult, r->center, r->range,
                                          r->slot, r->bits, r->oslot, NULL};
    if (layers)
        GS_TRY(err, build_layer_views(r, rows, row), fail);
    int B = 1; /* counts in half matches: at most 2Q */
    while ((1 << B) <= 2 * Q)
        B++;
    GS_TRY_CHECK(err, B <= GS_MODEL_RESEM_MAX_B, GS_ERR_INTERNAL, fail,
                 "resemblance: %d neighbours need %d counter bits", Q, B);
    r->B = B;
    gs_free(rows);
    *out = r;
    return GS_OK;
fail:
    gs_free(rows);
    gs_free(zs);
    gs_free(first);
    gs_model_resem_destroy(&r);
    return err;
}

void gs_model_resem_destroy(gs_model_resem_t *pr)
{
    if (!pr || !*pr)
        return;
    struct gs_model_resem *r = *pr;
    gs_free(r->off);
    gs_free(r->mult);
    gs_free(r->center);
    gs_free(r->range);
    gs_free(r->slot);
    gs_free(r->bits);
    gs_free(r->zmult);
    gs_free(r->zbits);
    gs_free(r->oslot);
    gs_free(r->bg);
    gs_free(r->zshare);
    for (int z = 0; r->lv && z < r->nz; z++)
        gs_free(r->lv[z].mem);
    gs_free(r->lv);
    gs_free(r);
    *pr = NULL;
}

int gs_model_resem_patterns(const gs_model_resem_t r) { return r ? r->P : 0; }

void gs_model_resem_set_outside(gs_model_resem_t r, int weight)
{
    if (r) {
        r->outside_bg = weight == 3;
        r->outside = weight == 3 ? 0 : weight < 0 ? 0 : weight > 2 ? 2 : weight;
    }
}

gs_err gs_model_resem_set_frequency(gs_model_resem_t r, const gs_model_lattice *ex, double beta)
{
    GS_CHECK(beta >= 0 && beta <= 64, GS_ERR_ARG, "model.frequency_weight = %g: expected 0..64",
             beta);
    if (!r)
        return GS_OK;
    r->freq_beta = beta;
    gs_free(r->zshare);
    r->zshare = NULL;
    if (beta <= 0)
        return GS_OK;
    const size_t L = (size_t)r->L, nz = (size_t)r->nz > 0 ? (size_t)r->nz : 1;
    GS_CALL(gs_alloc_array((void **)&r->zshare, nz * L, sizeof *r->zshare, "label shares"));
    const size_t layer = (size_t)ex->nx * (size_t)ex->ny;
    for (int z = 0; z < ex->nz; z++)
        for (size_t i = 0; i < layer; i++) {
            unsigned a = ex->labels[(size_t)z * layer + i];
            if (a >= L)
                continue;
            if (r->layers && (size_t)z < nz)
                r->zshare[(size_t)z * L + a] += 1.0f / (float)layer;
            else
                for (size_t k = 0; k < nz; k++)
                    r->zshare[k * L + a] += 1.0f / (float)(layer * (size_t)ex->nz);
        }
    return GS_OK;
}
