/* Distributed arrays: collective slab writes and reads with validation of
 * shape and type. See include/geosynth/h5.h. */
#include "io/h5_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/killpoint.h"
#include "geosynth/par.h"

static int is_parallel(const struct gs_ckpt *h) { return h->comm != MPI_COMM_NULL; }

static gs_err agree(const struct gs_ckpt *h, gs_err local)
{
    if (!is_parallel(h))
        return local;
    return gs_par_agree(h->comm, local);
}

static const char *file_name(const struct gs_ckpt *h)
{
    return h->writing ? h->tmp_path : h->path;
}

/* Checks a caller-given shape; *row_elems = prod(dims[1..]). */
static gs_err check_shape(const struct gs_ckpt *h, const char *dset, const gs_h5_shape *s,
                          uint64_t *row_elems)
{
    GS_CHECK(s && gs_h5_type_size(s->type) > 0, GS_ERR_ARG,
             "%s: dataset %s: invalid element type %d", file_name(h), dset, s ? (int)s->type : -1);
    GS_CHECK(s->rank >= 1 && s->rank <= GS_H5_MAX_RANK, GS_ERR_ARG,
             "%s: dataset %s: rank %d out of range [1, %d]", file_name(h), dset, s->rank,
             GS_H5_MAX_RANK);
    size_t total = gs_h5_type_size(s->type), row = 1;
    for (int i = 0; i < s->rank; i++) {
        GS_CHECK(s->dims[i] <= (uint64_t)SIZE_MAX && gs_mul_size(total, (size_t)s->dims[i], &total),
                 GS_ERR_ARG, "%s: dataset %s: size overflows", file_name(h), dset);
        if (i > 0)
            row *= (size_t)s->dims[i];
    }
    *row_elems = row;
    return GS_OK;
}

/* Collective: the (start, count) of all ranks tile [0, n). */
static int cmp_pair(const void *a, const void *b)
{
    const uint64_t *x = a, *y = b;
    return x[0] < y[0] ? -1 : x[0] > y[0] ? 1 : 0;
}

static gs_err check_tiling(const struct gs_ckpt *h, const char *dset, uint64_t n,
                           uint64_t start, uint64_t count)
{
    if (!is_parallel(h)) {
        GS_CHECK(start == 0 && count == n, GS_ERR_ARG,
                 "%s: dataset %s: a serial write must cover rows [0, %llu), got [%llu, %llu)",
                 file_name(h), dset, (unsigned long long)n, (unsigned long long)start,
                 (unsigned long long)(start + count));
        return GS_OK;
    }
    uint64_t mine[2] = {start, count};
    uint64_t *all = NULL;
    GS_CALL(gs_alloc_array((void **)&all, (size_t)h->size * 2, sizeof *all, "slab table"));
    gs_err gathered = gs_par_allgather_bytes(h->comm, mine, sizeof mine, all);
    if (gathered != GS_OK) {
        gs_free(all);
        GS_CALL(gathered);
    }
    qsort(all, (size_t)h->size, 2 * sizeof *all, cmp_pair);
    uint64_t next = 0;
    gs_err err = GS_OK;
    for (int r = 0; r < h->size && !err; r++) {
        uint64_t s = all[2 * r], c = all[2 * r + 1];
        if (c == 0)
            continue;
        if (s != next)
            err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                                 "%s: dataset %s: rank slabs do not tile rows [0, %llu): "
                                 "row %llu is %s",
                                 file_name(h), dset, (unsigned long long)n,
                                 (unsigned long long)(s < next ? s : next),
                                 s < next ? "written twice" : "not written");
        next = s + c;
    }
    if (!err && next != n)
        err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                             "%s: dataset %s: rank slabs cover rows [0, %llu) of %llu",
                             file_name(h), dset, (unsigned long long)next,
                             (unsigned long long)n);
    gs_free(all);
    return err;
}

/* Selects rows [start, start+count) in fspace and builds the matching memory
 * space (an empty selection when there is nothing to move). */
static hid_t select_rows(hid_t fspace, const gs_h5_shape *s, uint64_t start, uint64_t count,
                         uint64_t row_elems)
{
    if (count == 0 || row_elems == 0) {
        H5Sselect_none(fspace);
        hsize_t one = 1;
        hid_t m = H5Screate_simple(1, &one, NULL);
        if (m >= 0)
            H5Sselect_none(m);
        return m;
    }
    hsize_t off[GS_H5_MAX_RANK] = {0}, cnt[GS_H5_MAX_RANK];
    off[0] = start;
    cnt[0] = count;
    for (int i = 1; i < s->rank; i++)
        cnt[i] = s->dims[i];
    if (H5Sselect_hyperslab(fspace, H5S_SELECT_SET, off, NULL, cnt, NULL) < 0)
        return -1;
    return H5Screate_simple(s->rank, cnt, NULL);
}

static gs_err make_dcpl(const struct gs_ckpt *h, const char *dset, const gs_h5_shape *s,
                        uint64_t row_elems, const gs_h5_write_opts *opts, hid_t *out)
{
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    GS_CHECK(dcpl >= 0, GS_ERR_LIB, "%s: H5Pcreate failed", file_name(h));
    /* Every element gets written: skip the fill pass. */
    H5Pset_fill_time(dcpl, H5D_FILL_TIME_NEVER);
    int deflate = opts ? opts->deflate : 0;
    uint64_t rows = opts ? opts->chunk_rows : 0;
    GS_CHECK(deflate >= 0 && deflate <= 9, GS_ERR_ARG,
             "%s: dataset %s: deflate level %d out of range [0, 9]", file_name(h), dset, deflate);
    int empty = row_elems == 0 || s->dims[0] == 0;
    /* Every non-empty dataset is chunked and carries HDF5's Fletcher32
     * checksum per chunk (added last, so it covers the stored bytes), checked
     * by libhdf5 on every read: a flipped byte in the data of a checkpoint is
     * an error, never a silently different state (#25). Metadata (object
     * headers with the attributes, chunk indexes) is checksummed by the 1.10
     * format itself. */
    if (!empty) {
        size_t row_bytes = (size_t)row_elems * gs_h5_type_size(s->type);
        if (rows == 0)
            rows = row_bytes >= ((size_t)1 << 20) ? 1 : ((size_t)1 << 20) / row_bytes;
        if (rows > s->dims[0])
            rows = s->dims[0];
        if ((double)rows * (double)row_bytes >= 4294967295.0) {
            H5Pclose(dcpl);
            GS_RAISE(GS_ERR_ARG,
                     "%s: dataset %s: a chunk of %llu rows of %zu bytes exceeds HDF5's 4 GiB "
                     "chunk limit",
                     file_name(h), dset, (unsigned long long)rows, row_bytes);
        }
        hsize_t chunk[GS_H5_MAX_RANK];
        chunk[0] = rows;
        for (int i = 1; i < s->rank; i++)
            chunk[i] = s->dims[i];
        H5Pset_chunk(dcpl, s->rank, chunk);
        if (deflate > 0)
            H5Pset_deflate(dcpl, (unsigned)deflate);
        H5Pset_fletcher32(dcpl);
    }
    *out = dcpl;
    return GS_OK;
}

static gs_err write_rows(struct gs_ckpt *h, const char *dset, const gs_h5_shape *s,
                         uint64_t start, uint64_t count, const void *data,
                         const gs_h5_write_opts *opts, int tiled)
{
    GS_CHECK(h && dset && dset[0], GS_ERR_ARG, "gs_ckpt_write_*: handle and dataset required");
    uint64_t row_elems = 0;
    gs_err local = GS_OK, err;
    /* Validation that every rank does alike (same arguments). */
    GS_CHECK(h->writing, GS_ERR_ARG, "%s: not open for writing (dataset %s)", h->path, dset);
    GS_CALL(check_shape(h, dset, s, &row_elems));
    GS_CHECK(!gs_h5_exists(h->file, dset), GS_ERR_ARG, "%s: dataset %s already exists",
             file_name(h), dset);
    /* Validation that may differ between ranks: agreed on. */
    if (start > s->dims[0] || count > s->dims[0] - start)
        local = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                               "%s: dataset %s: rows [%llu, %llu) outside [0, %llu)",
                               file_name(h), dset, (unsigned long long)start,
                               (unsigned long long)(start + count),
                               (unsigned long long)s->dims[0]);
    else if (count > 0 && row_elems > 0 && !data)
        local = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                               "%s: dataset %s: no data given for %llu rows", file_name(h), dset,
                               (unsigned long long)count);
    GS_CALL(agree(h, local));
    if (tiled)
        GS_CALL(check_tiling(h, dset, s->dims[0], start, count));
    uint64_t bytes = 1;
    for (int i = 0; i < s->rank; i++)
        bytes *= s->dims[i];
    GS_CALL(gs_h5_reserve(h, bytes * gs_h5_type_size(s->type), dset));

    hid_t dcpl = -1, fspace = -1, mspace = -1, d = -1, dxpl = -1;
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    char detail[256];
    err = make_dcpl(h, dset, s, row_elems, opts, &dcpl);
    if (err)
        goto done;
    H5Pset_create_intermediate_group(lcpl, 1);
    hsize_t dims[GS_H5_MAX_RANK];
    for (int i = 0; i < s->rank; i++)
        dims[i] = s->dims[i];
    fspace = H5Screate_simple(s->rank, dims, NULL);
    d = fspace >= 0 ? H5Dcreate2(h->file, dset, gs_h5_file_type(s->type), fspace, lcpl, dcpl,
                                 H5P_DEFAULT)
                    : -1;
    if (d < 0) {
        gs_h5_detail(detail, sizeof detail);
        err = gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, __func__,
                             "%s: cannot create dataset %s (HDF5: %s)", file_name(h), dset,
                             detail);
        goto done;
    }
    gs_kill_point("%s %s created, not written", gs_kill_base(h->path), dset);
    mspace = select_rows(fspace, s, start, count, row_elems);
    dxpl = H5Pcreate(H5P_DATASET_XFER);
    if (is_parallel(h))
        H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE);
    if (mspace < 0 || dxpl < 0 ||
        H5Dwrite(d, gs_h5_mem_type(s->type), mspace, fspace, dxpl, data) < 0) {
        gs_h5_detail(detail, sizeof detail);
        err = gs_error_raise(GS_ERR_IO, __FILE__, __LINE__, __func__,
                             "%s: cannot write dataset %s (HDF5: %s)", file_name(h), dset,
                             detail);
    }
    if (!err)
        gs_kill_point("%s %s written", gs_kill_base(h->path), dset);
done:
    if (dxpl >= 0)
        H5Pclose(dxpl);
    if (mspace >= 0)
        H5Sclose(mspace);
    if (d >= 0)
        H5Dclose(d);
    if (fspace >= 0)
        H5Sclose(fspace);
    if (dcpl >= 0)
        H5Pclose(dcpl);
    if (lcpl >= 0)
        H5Pclose(lcpl);
    GS_CALL(agree(h, err));
    return GS_OK;
}

gs_err gs_ckpt_write_slab(gs_ckpt_t h, const char *path, const gs_h5_shape *shape,
                          uint64_t start, uint64_t count, const void *data,
                          const gs_h5_write_opts *opts)
{
    GS_CALL(write_rows(h, path, shape, start, count, data, opts, 1));
    return GS_OK;
}

gs_err gs_ckpt_write_whole(gs_ckpt_t h, const char *path, const gs_h5_shape *shape,
                           const void *data, const gs_h5_write_opts *opts)
{
    GS_CHECK(shape, GS_ERR_ARG, "gs_ckpt_write_whole: shape required");
    int root = !h || h->rank == 0;
    GS_CALL(write_rows(h, path, shape, 0, root ? shape->dims[0] : 0, data, opts, 0));
    return GS_OK;
}

/* Reads the stored shape of an open dataset. */
static gs_err stored_shape(const struct gs_ckpt *h, const char *dset, hid_t d, gs_h5_shape *out)
{
    char why[64] = "";
    hid_t type = H5Dget_type(d), space = H5Dget_space(d);
    gs_h5_shape s;
    memset(&s, 0, sizeof s);
    s.type = type >= 0 ? gs_h5_type_of(type, why, sizeof why) : 0;
    int rank = space >= 0 ? H5Sget_simple_extent_ndims(space) : -1;
    hsize_t dims[H5S_MAX_RANK];
    int ok = rank >= 1 && rank <= GS_H5_MAX_RANK &&
             H5Sget_simple_extent_dims(space, dims, NULL) == rank;
    if (type >= 0)
        H5Tclose(type);
    if (space >= 0)
        H5Sclose(space);
    H5Eclear2(H5E_DEFAULT);
    GS_CHECK(s.type != 0, GS_ERR_FORMAT,
             "%s: dataset %s has element type %s: geosynth reads float32, float64, uint8, "
             "uint16, int32, int64, uint64",
             file_name(h), dset, why[0] ? why : "unknown");
    GS_CHECK(ok, GS_ERR_FORMAT, "%s: dataset %s has rank %d: expected 1..%d", file_name(h), dset,
             rank, GS_H5_MAX_RANK);
    s.rank = rank;
    for (int i = 0; i < rank; i++)
        s.dims[i] = dims[i];
    *out = s;
    return GS_OK;
}

static gs_err open_dataset(const struct gs_ckpt *h, const char *dset, hid_t *out)
{
    GS_CHECK(h && dset, GS_ERR_ARG, "gs_ckpt_*: handle and dataset required");
    GS_CHECK(gs_h5_exists(h->file, dset), GS_ERR_FORMAT, "%s: dataset %s is missing",
             file_name(h), dset);
    H5O_type_t ot = H5O_TYPE_UNKNOWN;
    hid_t obj = H5Oopen(h->file, dset, H5P_DEFAULT);
    if (obj >= 0) {
        H5I_type_t it = H5Iget_type(obj);
        ot = it == H5I_DATASET ? H5O_TYPE_DATASET : H5O_TYPE_UNKNOWN;
    }
    if (obj < 0 || ot != H5O_TYPE_DATASET) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        if (obj >= 0)
            H5Oclose(obj);
        GS_RAISE(GS_ERR_FORMAT, "%s: %s is not a readable dataset%s%s%s", file_name(h), dset,
                 obj >= 0 ? "" : " (HDF5: ", obj >= 0 ? "" : d, obj >= 0 ? "" : ")");
    }
    *out = obj;
    return GS_OK;
}

gs_err gs_ckpt_shape(gs_ckpt_t h, const char *path, gs_h5_shape *out)
{
    hid_t d;
    GS_CALL(open_dataset(h, path, &d));
    gs_err err = stored_shape(h, path, d, out);
    H5Dclose(d);
    GS_CALL(err);
    return GS_OK;
}

gs_err gs_ckpt_check_stored(gs_ckpt_t h, const char *path, const gs_h5_shape *s)
{
    hid_t d;
    GS_CALL(open_dataset(h, path, &d));
    hsize_t stored = H5Dget_storage_size(d);
    H5Dclose(d);
    double bytes = (double)gs_h5_type_size(s->type);
    for (int i = 0; i < s->rank; i++)
        bytes *= (double)s->dims[i];
    char buf[160];
    gs_h5_shape_format(s, buf, sizeof buf);
    GS_CHECK(bytes <= 1032.0 * (double)stored + 4096.0, GS_ERR_FORMAT,
             "%s: dataset %s is %s (%.0f bytes), but the file stores only %llu bytes of it: "
             "its data was never written or the file is damaged",
             file_name(h), path, buf, bytes, (unsigned long long)stored);
    return GS_OK;
}

static gs_err check_expected(const struct gs_ckpt *h, const char *dset, const gs_h5_shape *got,
                             const gs_h5_shape *want)
{
    int same = got->type == want->type && got->rank == want->rank;
    for (int i = 0; same && i < got->rank; i++)
        same = got->dims[i] == want->dims[i];
    if (!same) {
        char a[160], b[160];
        gs_h5_shape_format(got, a, sizeof a);
        gs_h5_shape_format(want, b, sizeof b);
        GS_RAISE(GS_ERR_FORMAT, "%s: dataset %s is %s: expected %s", file_name(h), dset, a, b);
    }
    return GS_OK;
}

static gs_err read_rows(struct gs_ckpt *h, const char *dset, const gs_h5_shape *expect,
                        uint64_t start, uint64_t count, void *data)
{
    GS_CHECK(h && dset && expect, GS_ERR_ARG, "gs_ckpt_read_*: arguments required");
    uint64_t row_elems = 0;
    hid_t d = -1, fspace = -1, mspace = -1, dxpl = -1;
    gs_h5_shape got;
    gs_err local = check_shape(h, dset, expect, &row_elems);
    if (!local)
        local = open_dataset(h, dset, &d);
    if (!local)
        local = stored_shape(h, dset, d, &got);
    if (!local)
        local = check_expected(h, dset, &got, expect);
    if (!local && (start > expect->dims[0] || count > expect->dims[0] - start))
        local = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                               "%s: dataset %s: rows [%llu, %llu) outside [0, %llu)",
                               file_name(h), dset, (unsigned long long)start,
                               (unsigned long long)(start + count),
                               (unsigned long long)expect->dims[0]);
    if (!local && count > 0 && row_elems > 0 && !data)
        local = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__,
                               "%s: dataset %s: no buffer given", file_name(h), dset);
    gs_err err = agree(h, local);
    if (err)
        goto done;
    fspace = H5Dget_space(d);
    mspace = fspace >= 0 ? select_rows(fspace, expect, start, count, row_elems) : -1;
    dxpl = H5Pcreate(H5P_DATASET_XFER);
    if (is_parallel(h))
        H5Pset_dxpl_mpio(dxpl, H5FD_MPIO_COLLECTIVE);
    local = GS_OK;
    if (mspace < 0 || dxpl < 0 ||
        H5Dread(d, gs_h5_mem_type(expect->type), mspace, fspace, dxpl, data) < 0) {
        char detail[256];
        gs_h5_detail(detail, sizeof detail);
        local = gs_error_raise(GS_ERR_FORMAT, __FILE__, __LINE__, __func__,
                               "%s: cannot read dataset %s (HDF5: %s)", file_name(h), dset,
                               detail);
    }
    err = agree(h, local);
done:
    if (dxpl >= 0)
        H5Pclose(dxpl);
    if (mspace >= 0)
        H5Sclose(mspace);
    if (fspace >= 0)
        H5Sclose(fspace);
    if (d >= 0)
        H5Dclose(d);
    H5Eclear2(H5E_DEFAULT);
    if (err)
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    return err;
}

gs_err gs_ckpt_read_slab(gs_ckpt_t h, const char *path, const gs_h5_shape *expect,
                         uint64_t start, uint64_t count, void *data)
{
    GS_CALL(read_rows(h, path, expect, start, count, data));
    return GS_OK;
}

gs_err gs_ckpt_read_whole(gs_ckpt_t h, const char *path, const gs_h5_shape *expect,
                          void *data)
{
    GS_CHECK(expect, GS_ERR_ARG, "gs_ckpt_read_whole: expected shape required");
    GS_CALL(read_rows(h, path, expect, 0, expect->dims[0], data));
    return GS_OK;
}
