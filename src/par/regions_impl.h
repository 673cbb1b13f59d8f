/* Private layout of gs_regions, shared by the colour-by-colour queue
 * (regions.c) and the dataflow scheduler across colours (regions_flow.c). */
#ifndef GEOSYNTH_REGIONS_IMPL_H
#define GEOSYNTH_REGIONS_IMPL_H

#include "geosynth/regions.h"

struct gs_region_out {
    unsigned char *data;
    size_t len, cap;
};

typedef struct color_span {
    int color;
    int64_t begin, end; /* range of s->order for this color */
} color_span;

struct gs_regions {
    MPI_Comm comm;
    int rank, size;
    uint64_t seed;
    uint32_t domain;
    gs_region *regions;  /* copy of the input list */
    int64_t count;
    int64_t *order;      /* positions in regions, grouped by color, input order inside */
    color_span *colors;
    int ncolors;
    gs_regions_stats stats;
    int prefetch;        /* requests a worker keeps outstanding */
    gs_region_out pack;  /* this rank's records of the current color */
    int64_t *gathered;   /* [2 * size] pack sizes and statuses */
    int *rcounts, *displs;
    /* gs_regions_set_conflicts: per serial index k (position in order),
     * the serial indices of the earlier-coloured regions it interacts with
     * (pred) and the later ones that interact with it (succ), CSR. */
    int64_t *pred_off, *pred, *succ_off, *succ;
};

/* Runs the region at position pos of the list and appends its record
 * (int64 id | int64 len | bytes | padding to 8) to s->pack. */
gs_err gs_regions_compute_one(gs_regions_t s, int64_t pos, int pass, gs_region_run_fn run,
                              void *ctx);

/* MPI_Iprobe from any source, asked twice when the first says nothing:
 * Open MPI's Iprobe looks at the matched queue, then polls the transports
 * without looking again, so after a long region the first call misses
 * messages waiting in the shared-memory FIFO. Returns MPI's code. */
int gs_regions_iprobe(MPI_Comm comm, int tag, int *flag, MPI_Status *st);

/* gs_regions_run_pass when conflicts are set: all colours at once. */
gs_err gs_regions_flow_pass(gs_regions_t s, int pass, gs_region_run_fn run,
                            gs_region_apply_fn apply, void *ctx);

void gs_regions_free_conflicts(gs_regions_t s);

#endif
