/* The pictures and voxel files a model run writes after its synthesis,
 * checked against their formats' limits before it (#25: a 4096^2 tile set
 * ran the whole synthesis, then failed on tiles.png; a 70000x1 2D output
 * failed on lattice.png with "image of 70000x1 pixels" naming no file; an
 * output past 2^28 cells was written as a lattice.vox geosynth cannot read
 * back). See include/geosynth/model_tiles.h. */
#include "geosynth/image.h"
#include "geosynth/model_tiles.h"
#include "geosynth/vox.h"

gs_err gs_model_check_output_sizes(const int64_t size[3], const gs_model_tileset *ts,
                                   const gs_model_patterns *p, const char *input, int tile_image,
                                   int vox)
{
    const long long nx = size[0], ny = size[1], nz = size[2];
    const double ncells = (double)nx * (double)ny * (double)nz;
    GS_CHECK(!vox || ncells <= (double)GS_VOX_MAX_CELLS, GS_ERR_ARG,
             "model.vox: model.size = %lldx%lldx%lld makes a lattice.vox (with model.frames, each "
             "frame_NNN.vox) of %.0f voxels, more than the %zu a .vox file may hold (what "
             "geosynth reads back); set model.vox = false or a smaller model.size",
             nx, ny, nz, ncells, GS_VOX_MAX_CELLS);
    GS_CHECK(nz != 1 || (nx <= GS_IMAGE_MAX_SIDE && ny <= GS_IMAGE_MAX_SIDE), GS_ERR_ARG,
             "model.size = %lldx%lldx%lld: a 2D output is also written as lattice.png of "
             "%lldx%lld pixels, more than %d per side (the PNG writer's limit); reduce model.size",
             nx, ny, nz, nx, ny, GS_IMAGE_MAX_SIDE);
    if (!tile_image)
        return GS_OK;
    if (ts && ts->dim == 2 && ts->pixels) {
        const long long w = nx * ts->tile_w, h = ny * ts->tile_h;
        GS_CHECK(w <= GS_IMAGE_MAX_SIDE && h <= GS_IMAGE_MAX_SIDE, GS_ERR_ARG,
                 "model.tile_image: model.size = %lldx%lld tiles of %s (%dx%d pixels each) make a "
                 "tiles.png of %lldx%lld pixels, more than %d per side; set model.tile_image = "
                 "false or a smaller model.size",
                 nx, ny, input, ts->tile_w, ts->tile_h, w, h, GS_IMAGE_MAX_SIDE);
    }
    if (ts && ts->dim == 3) {
        const double cells = (double)nx * ts->vx * (double)ny * ts->vy * (double)nz * ts->vz;
        GS_CHECK(cells <= (double)GS_VOX_MAX_CELLS, GS_ERR_ARG,
                 "model.tile_image: model.size = %lldx%lldx%lld tiles of %s (%dx%dx%d voxels "
                 "each) make a tiles.vox of %lldx%lldx%lld = %.0f voxels, more than the %zu a .vox "
                 "file may hold (what geosynth reads back); set model.tile_image = false or a "
                 "smaller model.size",
                 nx, ny, nz, input, ts->vx, ts->vy, ts->vz, nx * ts->vx, ny * ts->vy, nz * ts->vz,
                 cells, GS_VOX_MAX_CELLS);
    }
    if (p && p->n > 0) {
        const long long w = nx + p->n - 1, h = ny + p->n - 1;
        GS_CHECK(w <= GS_IMAGE_MAX_SIDE && h <= GS_IMAGE_MAX_SIDE, GS_ERR_ARG,
                 "model.tile_image: model.size = %lldx%lld cells of the %dx%d patterns of %s make "
                 "an image.png of %lldx%lld pixels, more than %d per side; set model.tile_image = "
                 "false or a smaller model.size",
                 nx, ny, p->n, p->n, input, w, h, GS_IMAGE_MAX_SIDE);
    }
    return GS_OK;
}

gs_err gs_model_check_vox_labels(const gs_model_lattice *example, const char *input, int vox)
{
    if (!vox)
        return GS_OK;
    uint64_t seen[65536 / 64] = {0};
    int distinct = 0;
    const size_t n = (size_t)example->nx * (size_t)example->ny * (size_t)example->nz;
    for (size_t i = 0; i < n; i++) {
        const unsigned l = example->labels[i];
        if (l && !(seen[l / 64] >> (l % 64) & 1)) {
            seen[l / 64] |= (uint64_t)1 << (l % 64);
            distinct++;
        }
    }
    GS_CHECK(distinct <= 255, GS_ERR_ARG,
             "model.vox: %s holds %d distinct non-empty labels; the output draws from them and "
             "lattice.vox holds at most 255; set model.vox = false (lattice.h5 keeps every label)",
             input, distinct);
    return GS_OK;
}
