/* gs_ckpt_verify: reads every byte a checkpoint holds, so that libhdf5
 * checks every checksum (metadata of the 1.10 format, Fletcher32 of every
 * data chunk, the config digest) before a resume trusts the file. See
 * include/geosynth/h5.h. */
#include "io/h5_internal.h"

#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/mem.h"

typedef struct verify_ctx {
    const char *path;
    gs_err err;
    char what[1024]; /* object and reason of the first failure */
    gs_digest *dg;   /* gs_h5_content_digest: what is read goes in here (NULL: verify only) */
} verify_ctx;

/* Content digest: one record per object, attribute and block read, each led
 * by its name and shape so that moving bytes between them changes it. */
static void dg_add(verify_ctx *c, const void *data, size_t n)
{
    if (c->dg)
        gs_digest_update(c->dg, data, n);
}

static void dg_name(verify_ctx *c, const char *tag, const char *name)
{
    dg_add(c, tag, strlen(tag) + 1);
    dg_add(c, name, strlen(name) + 1);
}

/* What gs_h5_content_digest leaves out (include/geosynth/h5.h): the identity
 * group and the attributes that name input files by path. */
static int dg_skip_object(const char *name)
{
    return !strcmp(name, "geosynth") || !strncmp(name, "geosynth/", 9);
}

static int dg_skip_attr(const char *name)
{
    return !strcmp(name, "example") || !strcmp(name, "mesh_source");
}

static void fail(verify_ctx *c, const char *obj, const char *what)
{
    char d[256];
    gs_h5_detail(d, sizeof d);
    snprintf(c->what, sizeof c->what, "%s%.300s: %.320s%s%s%s", obj[0] == '/' ? "" : "/", obj, what, d[0] ? " (HDF5: " : "", d,
             d[0] ? ")" : "");
    c->err = GS_ERR_FORMAT;
}

/* Fixed-size types only: geosynth writes no variable-length datasets (its
 * string attributes are variable-length UTF-8; attributes are metadata,
 * checked by the 1.10 format's checksums). */
static int fixed_type(hid_t type)
{
    H5T_class_t k = H5Tget_class(type);
    return k != H5T_VLEN && k != H5T_REFERENCE && !(k == H5T_STRING && H5Tis_variable_str(type));
}

static herr_t read_attr(hid_t obj, const char *name, const H5A_info_t *info, void *op)
{
    verify_ctx *c = op;
    (void)info;
    if (c->dg && dg_skip_attr(name))
        return 0;
    hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    hid_t t = a >= 0 ? H5Aget_type(a) : -1;
    hid_t s = a >= 0 ? H5Aget_space(a) : -1;
    int ok = a >= 0 && t >= 0 && s >= 0;
    if (ok && fixed_type(t)) {
        hssize_t n = H5Sget_simple_extent_npoints(s);
        size_t bytes = H5Tget_size(t) * (size_t)(n > 0 ? n : 0);
        void *buf = bytes ? gs_malloc(bytes) : NULL;
        ok = bytes == 0 || (buf && H5Aread(a, t, buf) >= 0);
        if (ok) {
            dg_name(c, "attr", name);
            dg_add(c, &bytes, sizeof bytes);
            dg_add(c, buf, bytes);
        }
        gs_free(buf);
    } else if (ok && c->dg) {
        /* variable-length strings (geosynth's string attributes) */
        char *v = NULL, why[160];
        ok = gs_h5_read_str_attr(obj, name, GS_H5_ATTR_STR_MAX, &v, why, sizeof why) == 0;
        if (ok) {
            dg_name(c, "attr-str", name);
            dg_add(c, v, strlen(v) + 1);
        }
        gs_free(v);
    }
    if (!ok) {
        char obj_name[256] = "";
        H5Iget_name(obj, obj_name, sizeof obj_name);
        char what[320];
        snprintf(what, sizeof what, "attribute %.200s cannot be read", name);
        fail(c, obj_name[0] ? obj_name : "?", what);
    }
    if (s >= 0)
        H5Sclose(s);
    if (t >= 0)
        H5Tclose(t);
    if (a >= 0)
        H5Aclose(a);
    return ok ? 0 : 1;
}

/* Reads a dataset in blocks of whole chunk rows (or ~1 MiB of rows). */
static int read_dataset(verify_ctx *c, hid_t d, const char *name)
{
    int ok = 0;
    hid_t t = H5Dget_type(d), fs = H5Dget_space(d), dcpl = H5Dget_create_plist(d), ms = -1;
    void *buf = NULL;
    if (t < 0 || fs < 0 || dcpl < 0)
        goto done;
    if (!fixed_type(t)) {
        ok = c->dg == NULL; /* a digest must not leave a dataset out silently */
        if (!ok)
            fail(c, name, "variable-length dataset: its contents cannot be digested");
        goto done;
    }
    int rank = H5Sget_simple_extent_ndims(fs);
    size_t esize = H5Tget_size(t);
    dg_name(c, "dataset", name);
    dg_add(c, &esize, sizeof esize);
    if (rank == 0) { /* scalar */
        buf = gs_malloc(esize ? esize : 1);
        ok = buf && H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) >= 0;
        if (ok)
            dg_add(c, buf, esize);
        goto done;
    }
    if (rank < 0 || rank > H5S_MAX_RANK)
        goto done;
    hsize_t dims[H5S_MAX_RANK], chunk[H5S_MAX_RANK];
    H5Sget_simple_extent_dims(fs, dims, NULL);
    dg_add(c, &rank, sizeof rank);
    dg_add(c, dims, (size_t)rank * sizeof dims[0]);
    size_t row = esize;
    for (int i = 1; i < rank; i++)
        if (!gs_mul_size(row, (size_t)dims[i], &row))
            goto done;
    hsize_t rows = 0;
    if (H5Pget_layout(dcpl) == H5D_CHUNKED && H5Pget_chunk(dcpl, rank, chunk) == rank)
        rows = chunk[0];
    if (rows == 0)
        rows = row >= ((size_t)1 << 20) ? 1 : ((size_t)1 << 20) / (row ? row : 1);
    if (dims[0] == 0 || row == 0) {
        ok = 1;
        goto done;
    }
    if (rows > dims[0])
        rows = dims[0];
    size_t bytes;
    if (!gs_mul_size(row, (size_t)rows, &bytes) || !(buf = gs_malloc(bytes)))
        goto done;
    hsize_t off[H5S_MAX_RANK] = {0}, cnt[H5S_MAX_RANK];
    for (int i = 1; i < rank; i++)
        cnt[i] = dims[i];
    ok = 1;
    for (hsize_t r = 0; ok && r < dims[0]; r += rows) {
        off[0] = r;
        cnt[0] = dims[0] - r < rows ? dims[0] - r : rows;
        if (ms >= 0)
            H5Sclose(ms);
        ms = H5Screate_simple(rank, cnt, NULL);
        ok = ms >= 0 && H5Sselect_hyperslab(fs, H5S_SELECT_SET, off, NULL, cnt, NULL) >= 0 &&
             H5Dread(d, t, ms, fs, H5P_DEFAULT, buf) >= 0;
        if (ok)
            dg_add(c, buf, row * (size_t)cnt[0]);
        if (!ok) {
            char what[160];
            snprintf(what, sizeof what, "rows [%llu, %llu) cannot be read",
                     (unsigned long long)r, (unsigned long long)(r + cnt[0]));
            fail(c, name, what);
        }
    }
done:
    if (!ok && c->err == GS_OK)
        fail(c, name, "cannot be read");
    gs_free(buf);
    if (ms >= 0)
        H5Sclose(ms);
    if (dcpl >= 0)
        H5Pclose(dcpl);
    if (fs >= 0)
        H5Sclose(fs);
    if (t >= 0)
        H5Tclose(t);
    return ok;
}

static herr_t visit(hid_t root, const char *name, const H5O_info_t *info, void *op)
{
    verify_ctx *c = op;
    if (c->dg && dg_skip_object(name))
        return 0;
    if (c->dg)
        dg_name(c, info->type == H5O_TYPE_DATASET ? "object-dataset" : "object", name);
    hid_t o = H5Oopen(root, name, H5P_DEFAULT);
    if (o < 0) {
        fail(c, name, "cannot be opened");
        return 1;
    }
    int ok = H5Aiterate2(o, H5_INDEX_NAME, c->dg ? H5_ITER_INC : H5_ITER_NATIVE, NULL, read_attr,
                         c) >= 0 &&
             c->err == GS_OK;
    if (ok && info->type == H5O_TYPE_DATASET)
        ok = read_dataset(c, o, name);
    else if (!ok && c->err == GS_OK)
        fail(c, name, "its attributes cannot be read");
    H5Oclose(o);
    return ok ? 0 : 1;
}

gs_err gs_ckpt_verify(const char *path, const char *engine)
{
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_open(MPI_COMM_NULL, path, engine, &h));
    verify_ctx c = {path, GS_OK, "", NULL};
    herr_t rc = H5Ovisit2(h->file, H5_INDEX_NAME, H5_ITER_NATIVE, visit, &c, H5O_INFO_BASIC);
    if (rc < 0 && c.err == GS_OK)
        fail(&c, "/", "its objects cannot be listed");
    H5Eclear2(H5E_DEFAULT);
    gs_ckpt_close(&h);
    GS_CHECK(c.err == GS_OK, GS_ERR_FORMAT, "%s is damaged: %s", path, c.what);
    return GS_OK;
}

gs_err gs_h5_content_digest(const char *path, uint64_t *hash)
{
    hid_t f = -1;
    GS_CALL(gs_h5_open_serial(path, 0, &f));
    gs_digest dg;
    if (!gs_digest_init(&dg)) {
        H5Fclose(f);
        GS_RAISE(GS_ERR_MEM, "%s: out of memory for its digest", path);
    }
    verify_ctx c = {path, GS_OK, "", &dg};
    herr_t rc = H5Ovisit2(f, H5_INDEX_NAME, H5_ITER_INC, visit, &c, H5O_INFO_BASIC);
    if (rc < 0 && c.err == GS_OK)
        fail(&c, "/", "its objects cannot be listed");
    H5Eclear2(H5E_DEFAULT);
    H5Fclose(f);
    uint64_t h = gs_digest_final(&dg);
    GS_CHECK(c.err == GS_OK, GS_ERR_FORMAT, "%s cannot be read back for its digest: %s", path,
             c.what);
    *hash = h;
    return GS_OK;
}
