/* Quality measures of label lattices (see include/geosynth/measure.h): window
 * resemblance without the all-empty windows, completeness, height profile
 * and unsupported structure. Computed from an output and its example alone. */
#include <stdlib.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/measure.h"
#include "geosynth/mem.h"

enum { MAX_WINDOW_CELLS = 4096 };

size_t gs_measure_window_count(const int dims[3], const int w[3])
{
    size_t n = 1;
    for (int a = 0; a < 3; a++)
        n *= dims[a] >= w[a] ? (size_t)(dims[a] - w[a] + 1) : 0;
    return n;
}

gs_err gs_measure_window_keys(const uint16_t *labels, const int dims[3], const int w[3],
                              uint64_t *keys, uint8_t *nonempty)
{
    for (int a = 0; a < 3; a++)
        GS_CHECK(w[a] >= 1 && w[a] <= dims[a], GS_ERR_ARG,
                 "window extent %d along axis %d: expected 1..%d", w[a], a, dims[a]);
    GS_CHECK((size_t)w[0] * w[1] * w[2] <= MAX_WINDOW_CELLS, GS_ERR_ARG,
             "window of %dx%dx%d cells: at most %d", w[0], w[1], w[2], MAX_WINDOW_CELLS);
    uint16_t buf[MAX_WINDOW_CELLS];
    const size_t nx = (size_t)dims[0], nxy = nx * (size_t)dims[1];
    size_t i = 0;
    for (int z = 0; z + w[2] <= dims[2]; z++)
        for (int y = 0; y + w[1] <= dims[1]; y++)
            for (int x = 0; x + w[0] <= dims[0]; x++, i++) {
                size_t k = 0;
                uint16_t any = 0;
                for (int dz = 0; dz < w[2]; dz++)
                    for (int dy = 0; dy < w[1]; dy++) {
                        const uint16_t *row = labels + (size_t)x + nx * (size_t)(y + dy) +
                                              nxy * (size_t)(z + dz);
                        for (int dx = 0; dx < w[0]; dx++) {
                            buf[k++] = row[dx];
                            any |= row[dx];
                        }
                    }
                keys[i] = gs_digest_bytes(buf, k * sizeof *buf);
                if (nonempty)
                    nonempty[i] = any != 0;
            }
    return GS_OK;
}

gs_err gs_measure_lattice_windows(const uint16_t *example, const int edims[3],
                                  const uint16_t *output, const int odims[3], int k,
                                  gs_measure_windows *out)
{
    GS_CHECK(k >= 1 && k <= 16, GS_ERR_ARG, "window edge %d: expected 1..16", k);
    memset(out, 0, sizeof *out);
    int w[3];
    for (int a = 0; a < 3; a++) {
        GS_CHECK(edims[a] >= 1 && odims[a] >= 1, GS_ERR_ARG, "empty lattice along axis %d", a);
        w[a] = k;
        if (w[a] > edims[a])
            w[a] = edims[a];
        if (w[a] > odims[a])
            w[a] = odims[a];
        out->extent[a] = w[a];
    }
    const size_t ne = gs_measure_window_count(edims, w), no = gs_measure_window_count(odims, w);
    uint64_t *ek = NULL, *ok = NULL, *eall = NULL;
    uint8_t *enz = NULL, *onz = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&ek, ne, sizeof *ek, "example windows"), done);
    GS_TRY(err, gs_alloc_array((void **)&eall, ne, sizeof *eall, "example windows"), done);
    GS_TRY(err, gs_alloc_array((void **)&enz, ne, 1, "example windows"), done);
    GS_TRY(err, gs_alloc_array((void **)&ok, no, sizeof *ok, "output windows"), done);
    GS_TRY(err, gs_alloc_array((void **)&onz, no, 1, "output windows"), done);
    GS_TRY(err, gs_measure_window_keys(example, edims, w, ek, enz), done);
    GS_TRY(err, gs_measure_window_keys(output, odims, w, ok, onz), done);
    /* every example window (for the figure with empty windows) and the
     * non-empty ones */
    memcpy(eall, ek, ne * sizeof *ek);
    size_t nall = gs_measure_keys_sort_unique(eall, ne);
    size_t nne = 0;
    for (size_t i = 0; i < ne; i++)
        if (enz[i])
            ek[nne++] = ek[i];
    nne = gs_measure_keys_sort_unique(ek, nne);
    uint64_t found_all = 0;
    size_t nout = 0;
    for (size_t i = 0; i < no; i++) {
        if (onz[i]) {
            out->output_nonempty++;
            out->found += (uint64_t)gs_measure_keys_has(ek, nne, ok[i]);
            ok[nout++] = ok[i];
            found_all += (uint64_t)gs_measure_keys_has(ek, nne, ok[i]);
        } else {
            found_all += (uint64_t)gs_measure_keys_has(eall, nall, ok[i]);
        }
    }
    out->output_windows = no;
    out->found_share = out->output_nonempty ? (double)out->found / (double)out->output_nonempty : 0;
    out->found_share_all = no ? (double)found_all / (double)no : 0;
    /* completeness: distinct non-empty example windows met in the output */
    nout = gs_measure_keys_sort_unique(ok, nout);
    out->example_distinct = nne;
    for (size_t i = 0, j = 0; i < nne && j < nout;) {
        if (ek[i] == ok[j]) {
            out->example_covered++;
            i++;
            j++;
        } else if (ek[i] < ok[j]) {
            i++;
        } else {
            j++;
        }
    }
    out->completeness = nne ? (double)out->example_covered / (double)nne : 0;
done:
    gs_free(ek);
    gs_free(eall);
    gs_free(enz);
    gs_free(ok);
    gs_free(onz);
    return err;
}

void gs_measure_label_hist(const uint16_t *labels, size_t ncells, double *hist, size_t nlabels)
{
    memset(hist, 0, nlabels * sizeof *hist);
    if (nlabels == 0)
        return;
    for (size_t i = 0; i < ncells; i++)
        hist[labels[i] < nlabels ? labels[i] : nlabels - 1] += 1;
}

gs_err gs_measure_height_profile(const uint16_t *example, const int edims[3],
                                 const uint16_t *output, const int odims[3],
                                 gs_measure_profile *out)
{
    memset(out, 0, sizeof *out);
    const int nz = odims[2];
    const size_t elayer = (size_t)edims[0] * (size_t)edims[1];
    const size_t olayer = (size_t)odims[0] * (size_t)odims[1];
    double *ho = NULL, *he = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&out->fill_output, (size_t)nz, sizeof(double), "profile"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&out->fill_example, (size_t)nz, sizeof(double), "profile"),
           fail);
    GS_TRY(err, gs_alloc_array((void **)&ho, 65536, sizeof *ho, "layer histogram"), fail);
    GS_TRY(err, gs_alloc_array((void **)&he, 65536, sizeof *he, "layer histogram"), fail);
    out->nz = nz;
    out->top_output = out->top_example = -1;
    for (int z = 0; z < edims[2]; z++)
        for (size_t i = 0; i < elayer; i++)
            if (example[elayer * (size_t)z + i]) {
                out->top_example = z;
                break;
            }
    double fsum = 0, lsum = 0;
    for (int z = 0; z < nz; z++) {
        const uint16_t *ol = output + olayer * (size_t)z;
        gs_measure_label_hist(ol, olayer, ho, 65536);
        if (z < edims[2]) {
            gs_measure_label_hist(example + elayer * (size_t)z, elayer, he, 65536);
        } else {
            memset(he, 0, 65536 * sizeof *he);
            he[0] = 1;
        }
        double eall = 0, efill = 0;
        for (size_t l = 0; l < 65536; l++)
            eall += he[l];
        efill = eall - he[0];
        out->fill_output[z] = olayer ? (double)(olayer - (size_t)ho[0]) / (double)olayer : 0;
        out->fill_example[z] = eall > 0 ? efill / eall : 0;
        if (ho[0] < (double)olayer)
            out->top_output = z;
        fsum += out->fill_output[z] > out->fill_example[z] ? out->fill_output[z] - out->fill_example[z]
                                                           : out->fill_example[z] - out->fill_output[z];
        lsum += gs_measure_l1(ho, he, 65536);
    }
    out->fill_mean_abs = nz ? fsum / nz : 0;
    out->label_l1_mean = nz ? lsum / nz : 0;
    gs_free(ho);
    gs_free(he);
    return GS_OK;
fail:
    gs_free(ho);
    gs_free(he);
    gs_measure_profile_free(out);
    return err;
}

void gs_measure_profile_free(gs_measure_profile *p)
{
    gs_free(p->fill_output);
    gs_free(p->fill_example);
    p->fill_output = p->fill_example = NULL;
}

gs_err gs_measure_unsupported(const uint16_t *labels, const int dims[3], uint64_t *unsupported,
                              uint64_t *nonempty)
{
    const size_t n = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
    const size_t layer = (size_t)dims[0] * (size_t)dims[1];
    uint8_t *mask = NULL, *grounded = NULL;
    uint32_t *comp = NULL, ncomp = 0;
    gs_err err = GS_OK;
    *unsupported = *nonempty = 0;
    GS_TRY(err, gs_alloc_array((void **)&mask, n, 1, "support mask"), done);
    GS_TRY(err, gs_alloc_array((void **)&comp, n, sizeof *comp, "support components"), done);
    for (size_t i = 0; i < n; i++) {
        mask[i] = labels[i] != 0;
        *nonempty += mask[i];
    }
    static const int flat[3] = {0, 0, 0};
    GS_TRY(err, gs_measure_components3(mask, dims[0], dims[1], dims[2], flat, comp, &ncomp, NULL),
           done);
    GS_TRY(err, gs_alloc_array((void **)&grounded, (size_t)ncomp + 1, 1, "grounded components"),
           done);
    memset(grounded, 0, (size_t)ncomp + 1);
    for (size_t i = 0; i < layer; i++)
        grounded[comp[i]] = 1;
    if (dims[2] > 1)
        for (size_t i = 0; i < n; i++)
            *unsupported += mask[i] && !grounded[comp[i]];
done:
    gs_free(mask);
    gs_free(comp);
    gs_free(grounded);
    return err;
}

int gs_measure_ground_layer(const uint16_t *labels, const int dims[3])
{
    const size_t layer = (size_t)dims[0] * (size_t)dims[1];
    for (int z = 0; z < dims[2]; z++)
        for (size_t i = 0; i < layer; i++)
            if (labels[layer * (size_t)z + i] == 0)
                return z;
    return -1;
}

gs_err gs_measure_land_interior(const uint16_t *labels, const int dims[3], double *interior)
{
    const int nx = dims[0], ny = dims[1], nz = dims[2];
    const size_t layer = (size_t)nx * (size_t)ny;
    *interior = 0;
    if (!layer || nz < 1)
        return GS_OK;
    int *h = NULL;
    GS_CALL(gs_alloc_array((void **)&h, layer, sizeof *h, "land interior heights"));
    int hmin = nz;
    for (size_t i = 0; i < layer; i++) {
        h[i] = -1;
        for (int z = nz - 1; z >= 0 && h[i] < 0; z--)
            if (labels[layer * (size_t)z + i])
                h[i] = z;
        hmin = h[i] < hmin ? h[i] : hmin;
    }
    uint64_t high = 0, inner = 0;
    for (int z = hmin + 1; z < nz; z++)
        for (int y = 0; y < ny; y++)
            for (int x = 0; x < nx; x++) {
                const size_t i = (size_t)y * (size_t)nx + (size_t)x;
                if (h[i] < z)
                    continue;
                high++;
                inner += (x == 0 || h[i - 1] >= z) && (x == nx - 1 || h[i + 1] >= z) &&
                         (y == 0 || h[i - (size_t)nx] >= z) &&
                         (y == ny - 1 || h[i + (size_t)nx] >= z);
            }
    gs_free(h);
    *interior = high ? (double)inner / (double)high : 0;
    return GS_OK;
}

gs_err gs_measure_enclosure_layer(const uint16_t *labels, const int dims[3], int z,
                                  uint64_t min_large, gs_measure_enclosure *out)
{
    GS_CHECK(z >= 0 && z < dims[2], GS_ERR_ARG, "enclosure: layer %d of %d", z, dims[2]);
    const int nx = dims[0], ny = dims[1];
    const size_t layer = (size_t)nx * (size_t)ny;
    memset(out, 0, sizeof *out);
    out->layer = z;
    out->cells = layer;
    uint8_t *mask = NULL, *open = NULL;
    uint32_t *comp = NULL, ncomp = 0;
    uint64_t *sizes = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&mask, layer, 1, "enclosure mask"), done);
    GS_TRY(err, gs_alloc_array((void **)&comp, layer, sizeof *comp, "enclosure components"),
           done);
    const uint16_t *l = labels + layer * (size_t)z;
    for (size_t i = 0; i < layer; i++)
        mask[i] = l[i] == 0;
    static const int flat[3] = {0, 0, 0};
    GS_TRY(err, gs_measure_components3(mask, nx, ny, 1, flat, comp, &ncomp, &sizes), done);
    GS_TRY(err, gs_alloc_array((void **)&open, (size_t)ncomp + 1, 1, "open components"), done);
    memset(open, 0, (size_t)ncomp + 1);
    for (int x = 0; x < nx; x++)
        open[comp[x]] = open[comp[(size_t)nx * (size_t)(ny - 1) + (size_t)x]] = 1;
    for (int y = 0; y < ny; y++)
        open[comp[(size_t)nx * (size_t)y]] = open[comp[(size_t)nx * (size_t)y + (size_t)(nx - 1)]] = 1;
    for (uint32_t c = 1; c <= ncomp; c++) {
        if (open[c])
            continue;
        out->yards++;
        out->enclosed += sizes[c];
        if (sizes[c] > out->yard_max)
            out->yard_max = sizes[c];
        if (sizes[c] >= min_large)
            out->large += sizes[c];
    }
done:
    gs_free(mask);
    gs_free(comp);
    gs_free(open);
    gs_free(sizes);
    return err;
}

static int cmp_u64_desc(const void *a, const void *b)
{
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? 1 : x > y ? -1 : 0;
}

gs_err gs_measure_layout_lattice(const uint16_t *labels, const int dims[3], int ground,
                                 uint64_t large_min, gs_measure_layout *out)
{
    GS_CHECK(ground >= 0 && ground < dims[2], GS_ERR_ARG, "layout: ground layer %d of %d", ground,
             dims[2]);
    const int nx = dims[0], ny = dims[1], nz = dims[2] - ground;
    const size_t layer = (size_t)nx * (size_t)ny, n = layer * (size_t)nz;
    memset(out, 0, sizeof *out);
    out->ground = ground;
    out->columns = layer;
    uint8_t *mask = NULL, *open = NULL, *tall = NULL;
    uint32_t *comp = NULL, ncomp = 0;
    uint64_t *sizes = NULL, *tall_sizes = NULL;
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&mask, n, 1, "layout mask"), done);
    GS_TRY(err, gs_alloc_array((void **)&open, layer, 1, "open columns"), done);
    GS_TRY(err, gs_alloc_array((void **)&comp, n, sizeof *comp, "layout components"), done);
    memset(open, 1, layer);
    const uint16_t *above = labels + layer * (size_t)ground;
    for (size_t i = 0; i < n; i++) {
        mask[i] = above[i] != 0;
        if (mask[i])
            open[i % layer] = 0;
    }
    for (int y = 0; y < ny; y++)
        for (int x = 0; x < nx; x++) {
            if (!open[(size_t)x + (size_t)nx * (size_t)y])
                continue;
            out->open++;
            int clear = 1;
            for (int dy = -1; dy <= 1 && clear; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    const int u = x + dx, v = y + dy;
                    if (u >= 0 && u < nx && v >= 0 && v < ny &&
                        !open[(size_t)u + (size_t)nx * (size_t)v]) {
                        clear = 0;
                        break;
                    }
                }
            out->clear += (uint64_t)clear;
        }
    static const int flat[3] = {0, 0, 0};
    GS_TRY(err, gs_measure_components3(mask, nx, ny, nz, flat, comp, &ncomp, &sizes), done);
    GS_TRY(err, gs_alloc_array((void **)&tall, (size_t)ncomp + 1, 1, "structures"), done);
    memset(tall, 0, (size_t)ncomp + 1);
    for (size_t i = layer; i < n; i++)
        tall[comp[i]] = 1;
    GS_TRY(err, gs_alloc_array((void **)&tall_sizes, (size_t)ncomp + 1, sizeof *tall_sizes,
                               "structure sizes"),
           done);
    for (uint32_t c = 1; c <= ncomp; c++) {
        if (!tall[c])
            continue;
        tall_sizes[out->structures++] = sizes[c];
        out->structure_cells += sizes[c];
        if (large_min && sizes[c] > large_min)
            out->large_cells += sizes[c];
    }
    /* nested: structures none of whose columns is on the lattice's border or
     * next to a column of the outside (the columns without structure cells
     * 4-connected through such columns to the border); open[] is reused as
     * 1 = structure column, 2 = outside */
    memset(open, 0, layer);
    for (size_t i = 0; i < n; i++)
        if (comp[i] && tall[comp[i]])
            open[i % layer] = 1;
    uint32_t *queue = NULL;
    GS_TRY(err, gs_alloc_array((void **)&queue, layer, sizeof *queue, "outside columns"), done);
    size_t qt = 0;
    for (int y = 0; y < ny; y++)
        for (int x = 0; x < nx; x++) {
            const size_t c = (size_t)x + (size_t)nx * (size_t)y;
            if ((x == 0 || y == 0 || x == nx - 1 || y == ny - 1) && open[c] == 0) {
                open[c] = 2;
                queue[qt++] = (uint32_t)c;
            }
        }
    for (size_t qh = 0; qh < qt; qh++) {
        const int x = (int)(queue[qh] % (uint32_t)nx), y = (int)(queue[qh] / (uint32_t)nx);
        const int nb[4][2] = {{x + 1, y}, {x - 1, y}, {x, y + 1}, {x, y - 1}};
        for (int k = 0; k < 4; k++) {
            if (nb[k][0] < 0 || nb[k][0] >= nx || nb[k][1] < 0 || nb[k][1] >= ny)
                continue;
            const size_t c = (size_t)nb[k][0] + (size_t)nx * (size_t)nb[k][1];
            if (open[c] == 0) {
                open[c] = 2;
                queue[qt++] = (uint32_t)c;
            }
        }
    }
    gs_free(queue);
    for (size_t i = 0; i < n; i++) { /* tall[c] = 2: the structure meets the outside */
        const uint32_t c = comp[i];
        if (!c || tall[c] != 1)
            continue;
        const size_t col = i % layer;
        const int x = (int)(col % (size_t)nx), y = (int)(col / (size_t)nx);
        if (x == 0 || y == 0 || x == nx - 1 || y == ny - 1 || open[col - 1] == 2 ||
            open[col + 1] == 2 || open[col - (size_t)nx] == 2 || open[col + (size_t)nx] == 2)
            tall[c] = 2;
    }
    for (uint32_t c = 1; c <= ncomp; c++)
        if (tall[c] == 1)
            out->nested_cells += sizes[c];
    qsort(tall_sizes, out->structures, sizeof *tall_sizes, cmp_u64_desc);
    if (out->structures)
        out->largest = tall_sizes[0];
    for (uint64_t i = 0, cum = 0; i < out->structures; i++) {
        cum += tall_sizes[i];
        if (2 * cum >= out->structure_cells) {
            out->size_median = tall_sizes[i];
            break;
        }
    }
done:
    gs_free(mask);
    gs_free(open);
    gs_free(comp);
    gs_free(sizes);
    gs_free(tall);
    gs_free(tall_sizes);
    return err;
}

gs_err gs_measure_grid_crossing_lattice(const uint16_t *labels, const int dims[3], int ground,
                                        const int period[2], gs_measure_grid_crossing *out)
{
    GS_CHECK(ground >= 0 && ground < dims[2], GS_ERR_ARG, "grid crossing: ground layer %d of %d",
             ground, dims[2]);
    const int nx = dims[0], ny = dims[1];
    const size_t layer = (size_t)nx * (size_t)ny;
    memset(out, 0, sizeof *out);
    uint8_t *col = NULL;
    GS_CALL(gs_alloc_array((void **)&col, layer ? layer : 1, 1, "structure columns"));
    memset(col, 0, layer);
    for (int z = ground; z < dims[2]; z++)
        for (size_t i = 0; i < layer; i++)
            col[i] |= labels[layer * (size_t)z + i] != 0;
    const int px = period[0] > 0 && period[0] < nx ? period[0] : 0;
    const int py = period[1] > 0 && period[1] < ny ? period[1] : 0;
    for (int y = 0; y < ny; y++)
        for (int x = 0; x < nx; x++) {
            const size_t c = (size_t)x + (size_t)nx * (size_t)y;
            if (x > 0) { /* the pair (x - 1, x) across the line at x */
                const int both = col[c] && col[c - 1], on = px && x % px == 0;
                out->on_pairs += (uint64_t)on;
                out->on_both += (uint64_t)(on && both);
                out->off_pairs += (uint64_t)!on;
                out->off_both += (uint64_t)(!on && both);
            }
            if (y > 0) {
                const int both = col[c] && col[c - (size_t)nx], on = py && y % py == 0;
                out->on_pairs += (uint64_t)on;
                out->on_both += (uint64_t)(on && both);
                out->off_pairs += (uint64_t)!on;
                out->off_both += (uint64_t)(!on && both);
            }
        }
    gs_free(col);
    if (out->on_pairs && out->off_pairs && out->off_both)
        out->ratio = ((double)out->on_both / (double)out->on_pairs) /
                     ((double)out->off_both / (double)out->off_pairs);
    return GS_OK;
}
