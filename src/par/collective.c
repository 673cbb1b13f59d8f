/* The collectives engines share: chunked broadcasts, reductions, gathers;
 * see include/geosynth/par.h. */
#include "geosynth/par.h"

#include "geosynth/mem.h"

#include <limits.h>
#include <stdio.h>
#include <string.h>

/* Largest piece of one MPI call (its counts are int). */
#define PIECE ((size_t)1 << 30)

gs_err gs_par_comm_rank(MPI_Comm comm, int *rank, int *size)
{
    if (rank)
        GS_MPI(MPI_Comm_rank(comm, rank));
    if (size)
        GS_MPI(MPI_Comm_size(comm, size));
    return GS_OK;
}

gs_err gs_par_node_size(MPI_Comm comm, int *size)
{
    MPI_Comm node;
    GS_MPI(MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node));
    int rc = MPI_Comm_size(node, size);
    MPI_Comm_free(&node);
    GS_MPI(rc);
    return GS_OK;
}

gs_err gs_par_barrier(MPI_Comm comm)
{
    GS_MPI(MPI_Barrier(comm));
    return GS_OK;
}

int gs_par_barrier_quiet(MPI_Comm comm) { return MPI_Barrier(comm) == MPI_SUCCESS; }

gs_err gs_par_bcast_bytes(MPI_Comm comm, void *data, size_t bytes, int root)
{
    char *p = data;
    while (bytes > 0) {
        size_t k = bytes < PIECE ? bytes : PIECE;
        GS_MPI(MPI_Bcast(p, (int)k, MPI_BYTE, root, comm));
        p += k;
        bytes -= k;
    }
    return GS_OK;
}

gs_err gs_par_bcast_alloc(MPI_Comm comm, void **p, size_t n, size_t size, int root,
                          const char *what)
{
    int rank;
    GS_MPI(MPI_Comm_rank(comm, &rank));
    if (!n)
        return GS_OK;
    void *got = NULL;
    gs_err err = rank != root ? gs_alloc_array(&got, n, size, what) : GS_OK;
    err = gs_par_agree(comm, err);
    if (!err)
        err = gs_par_bcast_bytes(comm, rank != root ? got : *p, n * size, root);
    if (err) {
        gs_free(got);
        gs_error_push_frame(__FILE__, __LINE__, __func__);
        return err;
    }
    if (rank != root)
        *p = got;
    return GS_OK;
}

gs_err gs_par_min_i64(MPI_Comm comm, int64_t v, int64_t *out)
{
    GS_MPI(MPI_Allreduce(&v, out, 1, MPI_INT64_T, MPI_MIN, comm));
    return GS_OK;
}

gs_err gs_par_max_u64(MPI_Comm comm, uint64_t v, uint64_t *out)
{
    GS_MPI(MPI_Allreduce(&v, out, 1, MPI_UINT64_T, MPI_MAX, comm));
    return GS_OK;
}

gs_err gs_par_max_int(MPI_Comm comm, const int *in, int *out, int n)
{
    GS_MPI(MPI_Allreduce(in, out, n, MPI_INT, MPI_MAX, comm));
    return GS_OK;
}

gs_err gs_par_max_f64(MPI_Comm comm, const double *in, double *out, int n)
{
    GS_MPI(MPI_Allreduce(in, out, n, MPI_DOUBLE, MPI_MAX, comm));
    return GS_OK;
}

gs_err gs_par_sum_f64(MPI_Comm comm, const double *in, double *out, int n)
{
    GS_MPI(MPI_Allreduce(in, out, n, MPI_DOUBLE, MPI_SUM, comm));
    return GS_OK;
}

gs_err gs_par_gather_bytes(MPI_Comm comm, const void *mine, size_t bytes, void *all, int root)
{
    GS_CHECK(bytes <= (size_t)INT_MAX, GS_ERR_ARG, "gather of %zu bytes a rank is too large",
             bytes);
    GS_MPI(MPI_Gather(mine, (int)bytes, MPI_BYTE, all, (int)bytes, MPI_BYTE, root, comm));
    return GS_OK;
}

gs_err gs_par_allgather_bytes(MPI_Comm comm, const void *mine, size_t bytes, void *all)
{
    GS_CHECK(bytes <= (size_t)INT_MAX, GS_ERR_ARG, "allgather of %zu bytes a rank is too large",
             bytes);
    GS_MPI(MPI_Allgather(mine, (int)bytes, MPI_BYTE, all, (int)bytes, MPI_BYTE, comm));
    return GS_OK;
}

gs_err gs_par_allgatherv_bytes(MPI_Comm comm, const void *mine, void *all, const int *counts,
                               const int *displs)
{
    int rank;
    GS_MPI(MPI_Comm_rank(comm, &rank));
    GS_MPI(MPI_Allgatherv(mine, counts[rank], MPI_BYTE, all, counts, displs, MPI_BYTE, comm));
    return GS_OK;
}

gs_err gs_par_allgatherv_items(MPI_Comm comm, void *all, size_t item_bytes, const int *counts,
                               const int *displs)
{
    GS_CHECK(item_bytes > 0 && item_bytes < (size_t)INT_MAX, GS_ERR_ARG,
             "allgatherv: items of %zu bytes", item_bytes);
    MPI_Datatype item;
    int rc = MPI_Type_contiguous((int)item_bytes, MPI_BYTE, &item);
    if (rc == MPI_SUCCESS) {
        rc = MPI_Type_commit(&item);
        if (rc == MPI_SUCCESS)
            rc = MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, all, counts, displs, item,
                                comm);
        MPI_Type_free(&item);
    }
    GS_MPI(rc);
    return GS_OK;
}

void gs_par_mpi_version(int *major, int *minor, char *lib, size_t lib_len)
{
    *major = *minor = 0;
    MPI_Get_version(major, minor);
    char full[MPI_MAX_LIBRARY_VERSION_STRING] = "";
    int len = 0;
    MPI_Get_library_version(full, &len);
    char *nl = strchr(full, '\n');
    if (nl)
        *nl = '\0';
    if (lib_len)
        snprintf(lib, lib_len, "%s", full);
}
