/* Tile sets and learned patterns parsed on rank 0 and broadcast (#25: every
 * rank used to parse the tile set itself; a 16 MB tile-set XML cost 1.1 GB
 * RSS on each rank). See include/geosynth/model_tiles.h. */
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/model_tiles.h"
#include "geosynth/par.h"

/* gs_par_bcast_alloc: allocated off root, agreed, broadcast (a rank that
 * cannot allocate is reported by every rank instead of leaving the others
 * in the broadcast). */
#define BCAST_ARRAY(field, n, what)                                                        \
    GS_TRY(err, gs_par_bcast_alloc(comm, (void **)&(field), (n), sizeof *(field), root, what), \
           fail)

gs_err gs_model_tileset_bcast(MPI_Comm comm, int root, gs_model_tileset *ts)
{
    int rank, size;
    gs_err err = GS_OK;
    GS_CALL(gs_par_comm_rank(comm, &rank, &size));
    gs_model_tileset hdr = *ts;
    GS_CALL(GS_PAR_BCAST_VALUE(comm, &hdr, root));
    if (rank != root) {
        *ts = hdr;
        /* root's pointers mean nothing here; tile images stay on root */
        ts->names = NULL;
        ts->weight = NULL;
        ts->pairs = NULL;
        ts->pixels = NULL;
        ts->voxels = NULL;
        ts->base = ts->orient = NULL;
        ts->fixed = NULL;
        ts->tile_w = ts->tile_h = 0;
    }
    const size_t nt = (size_t)(hdr.ntiles > 0 ? hdr.ntiles : 0);
    const size_t nvox = hdr.voxels ? (size_t)hdr.vx * (size_t)hdr.vy * (size_t)hdr.vz * nt : 0;
    const size_t nfixed = (size_t)(hdr.nfixed > 0 ? hdr.nfixed : 0);
    BCAST_ARRAY(ts->names, hdr.names ? nt : 0, "tile names");
    BCAST_ARRAY(ts->weight, hdr.weight ? nt : 0, "tile weights");
    BCAST_ARRAY(ts->pairs, hdr.pairs ? hdr.npairs : 0, "tile pairs");
    BCAST_ARRAY(ts->voxels, nvox, "tile voxels");
    BCAST_ARRAY(ts->base, hdr.base ? nt : 0, "tile bases");
    BCAST_ARRAY(ts->orient, hdr.orient ? nt : 0, "tile orientations");
    BCAST_ARRAY(ts->fixed, hdr.fixed ? nfixed : 0, "fixed tiles");
    return GS_OK;
fail:
    if (rank != root)
        gs_model_tileset_destroy(ts);
    return err;
}

gs_err gs_model_patterns_bcast(MPI_Comm comm, int root, gs_model_patterns *p)
{
    int rank, size;
    gs_err err = GS_OK;
    GS_CALL(gs_par_comm_rank(comm, &rank, &size));
    gs_model_patterns hdr = *p;
    GS_CALL(GS_PAR_BCAST_VALUE(comm, &hdr, root));
    if (rank != root) {
        *p = hdr;
        p->colors = NULL;
        p->pat = NULL;
        p->count = p->bottom = NULL;
        p->pairs = NULL;
    }
    const size_t np = (size_t)(hdr.npatterns > 0 ? hdr.npatterns : 0);
    const size_t cells = (size_t)hdr.n * (size_t)hdr.n;
    BCAST_ARRAY(p->colors, hdr.colors ? (size_t)hdr.ncolors : 0, "pattern colours");
    BCAST_ARRAY(p->pat, hdr.pat ? np * cells : 0, "patterns");
    BCAST_ARRAY(p->count, hdr.count ? np : 0, "pattern counts");
    BCAST_ARRAY(p->bottom, hdr.bottom ? np : 0, "pattern bottom counts");
    BCAST_ARRAY(p->pairs, hdr.pairs ? hdr.npairs : 0, "pattern pairs");
    return GS_OK;
fail:
    if (rank != root)
        gs_model_patterns_destroy(p);
    return err;
}
