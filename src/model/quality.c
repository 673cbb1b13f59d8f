/* Resemblance: share of output windows that occur in the example, through
 * the shared window measure (src/measure/lattice.c). See
 * include/geosynth/model_io.h. */
#include "geosynth/measure.h"
#include "geosynth/mem.h"
#include "geosynth/model_io.h"

gs_err gs_model_resemblance(const gs_model_lattice *example, const gs_model_lattice *output,
                            int w, double *share)
{
    GS_CHECK(w >= 1 && w <= 8, GS_ERR_ARG, "resemblance window %d: expected 1..8", w);
    const int ed[3] = {example->nx, example->ny, example->nz};
    const int od[3] = {output->nx, output->ny, output->nz};
    gs_measure_windows m;
    GS_CALL(gs_measure_lattice_windows(example->labels, ed, output->labels, od, w, &m));
    *share = m.found_share_all;
    return GS_OK;
}

gs_err gs_model_quality(const gs_model_lattice *example, const gs_model_lattice *output,
                        gs_model_quality_figures *q)
{
    const int ed[3] = {example->nx, example->ny, example->nz};
    const int od[3] = {output->nx, output->ny, output->nz};
    GS_CALL(gs_measure_lattice_windows(example->labels, ed, output->labels, od, 3, &q->w3));
    GS_CALL(gs_measure_lattice_windows(example->labels, ed, output->labels, od, 2, &q->w2));
    const size_t ne = (size_t)ed[0] * ed[1] * ed[2], no = (size_t)od[0] * od[1] * od[2];
    double *he = NULL, *ho = NULL;
    gs_err err = gs_alloc_array((void **)&he, 65536, sizeof *he, "label histogram");
    if (err == GS_OK)
        err = gs_alloc_array((void **)&ho, 65536, sizeof *ho, "label histogram");
    if (err) {
        gs_free(he);
        return err;
    }
    gs_measure_label_hist(example->labels, ne, he, 65536);
    gs_measure_label_hist(output->labels, no, ho, 65536);
    q->label_l1 = gs_measure_l1(he, ho, 65536);
    q->empty_share = no ? ho[0] / (double)no : 0;
    q->empty_share_example = ne ? he[0] / (double)ne : 0;
    q->labels_used = q->labels_example = 0;
    for (int l = 1; l < 65536; l++) {
        q->labels_used += ho[l] > 0;
        q->labels_example += he[l] > 0;
    }
    gs_free(he);
    gs_free(ho);
    GS_CALL(gs_measure_height_profile(example->labels, ed, output->labels, od, &q->profile));
    uint64_t u, n;
    err = gs_measure_unsupported(output->labels, od, &u, &n);
    if (err == GS_OK) {
        q->unsupported_share = n ? (double)u / (double)n : 0;
        err = gs_measure_unsupported(example->labels, ed, &u, &n);
        q->unsupported_share_example = n ? (double)u / (double)n : 0;
    }
    q->enclosure.layer = q->enclosure_example.layer = -1;
    const int zg = gs_measure_ground_layer(example->labels, ed);
    if (err == GS_OK && zg >= 0 && zg < od[2]) {
        err = gs_measure_enclosure_layer(example->labels, ed, zg, 1, &q->enclosure_example);
        const uint64_t large = q->enclosure_example.yard_max > 1
                                   ? (q->enclosure_example.yard_max + 1) / 2 : 1;
        if (err == GS_OK)
            err = gs_measure_enclosure_layer(example->labels, ed, zg, large,
                                             &q->enclosure_example);
        if (err == GS_OK)
            err = gs_measure_enclosure_layer(output->labels, od, zg, large, &q->enclosure);
    }
    q->layout.ground = q->layout_example.ground = -1;
    if (err == GS_OK && zg >= 0 && zg < od[2] && od[2] > 1) {
        err = gs_measure_layout_lattice(example->labels, ed, zg, 0, &q->layout_example);
        const uint64_t big = 2 * q->layout_example.largest;
        if (err == GS_OK)
            err = gs_measure_layout_lattice(example->labels, ed, zg, big, &q->layout_example);
        if (err == GS_OK)
            err = gs_measure_layout_lattice(output->labels, od, zg, big, &q->layout);
    }
    if (err)
        gs_measure_profile_free(&q->profile);
    return err;
}

gs_err gs_model_structure_labels(const gs_model_lattice *example, int nlabels, uint8_t *out,
                                 int *count)
{
    const int nx = example->nx, ny = example->ny, nz = example->nz;
    const size_t layer = (size_t)nx * (size_t)ny;
    for (int l = 0; l < nlabels; l++)
        out[l] = 0;
    *count = 0;
    if (!layer || nz < 1 || nlabels < 1)
        return GS_OK;
    /* empty: the commonest label of the top layer (ties: the smallest) */
    uint32_t *hist = NULL;
    GS_CALL(gs_alloc_array((void **)&hist, 65536, sizeof *hist, "top layer histogram"));
    const uint16_t *top = example->labels + layer * (size_t)(nz - 1);
    for (size_t i = 0; i < layer; i++)
        hist[top[i]]++;
    int empty = 0;
    for (int l = 1; l < 65536; l++)
        if (hist[l] > hist[empty])
            empty = l;
    gs_free(hist);
    /* ground: the labels of the layers below the first one holding empty;
     * out[] doubles as the mark 2 = ground or empty until the last loop */
    int zg = 0;
    for (; zg < nz; zg++) {
        const uint16_t *lz = example->labels + layer * (size_t)zg;
        int has = 0;
        for (size_t i = 0; i < layer && !has; i++)
            has = lz[i] == empty;
        if (has)
            break;
    }
    if (empty < nlabels)
        out[empty] = 2;
    for (size_t i = 0; i < layer * (size_t)zg; i++)
        if (example->labels[i] < nlabels)
            out[example->labels[i]] = 2;
    /* structure: stacked on or under a label that is neither */
    for (int z = 0; z + 1 < nz; z++)
        for (size_t i = 0; i < layer; i++) {
            int a = example->labels[layer * (size_t)z + i],
                b = example->labels[layer * (size_t)(z + 1) + i];
            if (a < nlabels && b < nlabels && out[a] != 2 && out[b] != 2)
                out[a] = out[b] = 1;
        }
    for (int l = 0; l < nlabels; l++) {
        out[l] = out[l] == 1;
        *count += out[l];
    }
    return GS_OK;
}

void gs_model_structure_shares(const gs_model_lattice *lat, const uint8_t *structure,
                               int nlabels, const float *shape, double *inside,
                               double *outside)
{
    uint64_t n[2] = {0, 0}, s[2] = {0, 0};
    for (int z = 0; z < lat->nz; z++)
        for (int y = 0; y < lat->ny; y++)
            for (int x = 0; x < lat->nx; x++) {
                int in = shape[(size_t)x + (size_t)lat->nx * (size_t)y] >= 0.5f;
                int l = lat->labels[gs_model_lattice_index(lat, x, y, z)];
                n[in]++;
                s[in] += l < nlabels && structure[l];
            }
    *inside = n[1] ? (double)s[1] / (double)n[1] : 0;
    *outside = n[0] ? (double)s[0] / (double)n[0] : 0;
}
