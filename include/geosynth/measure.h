/* Quality measures shared by every engine (src/measure/): computed from an
 * output and its example alone, never from an engine's own bookkeeping, so a
 * reviewer holding the two files gets the same figures. Engine-specific
 * measures (lattice windows, copied regions, seams, realized contact
 * distributions) live in src/measure/ too, one file per kind of data, and
 * build on these.
 *
 * Conventions: distributions are non-negative counts or weights; an L1
 * distance compares them after normalizing each to sum 1, so it lies in
 * [0, 2] (0 = the same mix, 2 = disjoint). A KS distance is the largest
 * difference of two empirical cumulative distributions, in [0, 1].
 * Nothing here uses MPI or allocates on success paths beyond what is stated.
 */
#ifndef GEOSYNTH_MEASURE_H
#define GEOSYNTH_MEASURE_H

#include <stddef.h>
#include <stdint.h>

#include "geosynth/error.h"

/* L1 distance of two distributions over n bins after normalizing each to sum
 * 1: sum |a_i/A - b_i/B|. Both empty: 0; one empty: 2. */
double gs_measure_l1(const double *a, const double *b, size_t n);

/* Two-sample Kolmogorov-Smirnov distance sup_t |F_x(t) - F_y(t)| of samples
 * x (nx values) and y (ny values); NaNs are ignored. Both empty: 0; one
 * empty: 1. Sorts copies (O((nx + ny) log)); GS_ERR_MEM when they cannot be
 * allocated. */
gs_err gs_measure_ks(const double *x, size_t nx, const double *y, size_t ny, double *out);

/* Connected components of the set cells (mask != 0) of an nx*ny*nz grid, x
 * fastest (cell (x, y, z) at x + nx*(y + ny*z)), 6-connected (face
 * neighbours); periodic[k] != 0 wraps axis k. label[i] receives the
 * component of cell i numbered 1 .. *ncomp in order of each component's
 * lowest cell index, 0 for unset cells. *sizes (gs_malloc'ed, *ncomp + 1
 * entries, [0] unused) receives the cell count of each; pass NULL to skip.
 * Memory: label plus one queue of up to nx*ny*nz uint32. Cost: O(cells).
 * Grids of 2^32 - 1 cells or more are GS_ERR_ARG. */
gs_err gs_measure_components3(const uint8_t *mask, int nx, int ny, int nz, const int periodic[3],
                              uint32_t *label, uint32_t *ncomp, uint64_t **sizes);

#endif
