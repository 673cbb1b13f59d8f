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
    if (err)
        gs_measure_profile_free(&q->profile);
    return err;
}
