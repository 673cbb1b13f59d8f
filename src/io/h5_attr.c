/* Attributes: identity and engine state (gs_ckpt_set_* / gs_ckpt_get_*),
 * groups. See include/geosynth/h5.h. */
#include "io/h5_internal.h"

#include <stdio.h>
#include <string.h>

#include "geosynth/mem.h"

gs_err gs_h5_write_attr_raw(hid_t obj, const char *name, hid_t ftype, hid_t mtype,
                            const void *value, const char *path)
{
    char d[256];
    if (H5Aexists(obj, name) > 0 && H5Adelete(obj, name) < 0) {
        gs_h5_detail(d, sizeof d);
        GS_RAISE(GS_ERR_IO, "%s: cannot replace attribute %s (HDF5: %s)", path, name, d);
    }
    hid_t space = H5Screate(H5S_SCALAR);
    hid_t attr = space >= 0 ? H5Acreate2(obj, name, ftype, space, H5P_DEFAULT, H5P_DEFAULT) : -1;
    herr_t rc = attr >= 0 ? H5Awrite(attr, mtype, value) : -1;
    if (attr >= 0)
        H5Aclose(attr);
    if (space >= 0)
        H5Sclose(space);
    if (rc < 0) {
        gs_h5_detail(d, sizeof d);
        GS_RAISE(GS_ERR_IO, "%s: cannot write attribute %s (HDF5: %s)", path, name, d);
    }
    return GS_OK;
}

gs_err gs_h5_write_str_attr(hid_t obj, const char *name, const char *value, const char *path)
{
    size_t len = strlen(value);
    GS_CHECK(len <= GS_H5_ATTR_STR_MAX, GS_ERR_ARG,
             "%s: string attribute %s has %zu bytes: at most %zu fit in an HDF5 attribute", path,
             name, len, GS_H5_ATTR_STR_MAX);
    /* variable-length UTF-8: h5py and netCDF read it back as text (str), not bytes */
    hid_t type = H5Tcopy(H5T_C_S1);
    GS_CHECK(type >= 0, GS_ERR_LIB, "%s: H5Tcopy failed", path);
    H5Tset_size(type, H5T_VARIABLE);
    H5Tset_cset(type, H5T_CSET_UTF8);
    const char *v = value;
    gs_err err = gs_h5_write_attr_raw(obj, name, type, type, &v, path);
    H5Tclose(type);
    if (err)
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    return err;
}

int gs_h5_read_num_attr(hid_t obj, const char *name, char kind, void *out, char *why,
                        size_t why_len)
{
    int rc = -1;
    hid_t attr = -1, type = -1, space = -1;
    if (H5Aexists(obj, name) <= 0) {
        snprintf(why, why_len, "missing");
        goto done;
    }
    attr = H5Aopen(obj, name, H5P_DEFAULT);
    type = attr >= 0 ? H5Aget_type(attr) : -1;
    space = attr >= 0 ? H5Aget_space(attr) : -1;
    if (attr < 0 || type < 0 || space < 0) {
        char d[200];
        gs_h5_detail(d, sizeof d);
        snprintf(why, why_len, "unreadable (HDF5: %s)", d);
        goto done;
    }
    hssize_t n = H5Sget_simple_extent_npoints(space);
    if (n != 1) { /* also guards the one-value buffers below */
        snprintf(why, why_len, "holds %lld values, expected 1", (long long)n);
        goto done;
    }
    H5T_class_t cls = H5Tget_class(type);
    size_t size = H5Tget_size(type);
    int is_signed = cls == H5T_INTEGER && H5Tget_sign(type) == H5T_SGN_2;
    if (kind == 'f') {
        if (cls != H5T_FLOAT) {
            snprintf(why, why_len, "not a floating-point value");
            goto done;
        }
        double v;
        if (H5Aread(attr, H5T_NATIVE_DOUBLE, &v) < 0)
            goto unreadable;
        *(double *)out = v;
        rc = 0;
        goto done;
    }
    if (cls != H5T_INTEGER || size > 8) {
        snprintf(why, why_len, "not an integer of at most 64 bits");
        goto done;
    }
    if (is_signed) {
        int64_t v;
        if (H5Aread(attr, H5T_NATIVE_INT64, &v) < 0)
            goto unreadable;
        if (kind == 'u' && v < 0) {
            snprintf(why, why_len, "value %lld is negative, expected an unsigned value",
                     (long long)v);
            goto done;
        }
        if (kind == 'u')
            *(uint64_t *)out = (uint64_t)v;
        else
            *(int64_t *)out = v;
    } else {
        uint64_t v;
        if (H5Aread(attr, H5T_NATIVE_UINT64, &v) < 0)
            goto unreadable;
        if (kind == 'i' && v > (uint64_t)INT64_MAX) {
            snprintf(why, why_len, "value %llu does not fit in int64", (unsigned long long)v);
            goto done;
        }
        if (kind == 'u')
            *(uint64_t *)out = v;
        else
            *(int64_t *)out = (int64_t)v;
    }
    rc = 0;
    goto done;
unreadable : {
    char d[200];
    gs_h5_detail(d, sizeof d);
    snprintf(why, why_len, "unreadable (HDF5: %s)", d);
}
done:
    if (space >= 0)
        H5Sclose(space);
    if (type >= 0)
        H5Tclose(type);
    if (attr >= 0)
        H5Aclose(attr);
    H5Eclear2(H5E_DEFAULT);
    return rc;
}

/* Creates path and missing parents as groups. Collective on a parallel file. */
static gs_err make_group(struct gs_ckpt *h, const char *path)
{
    if (gs_h5_exists(h->file, path))
        return GS_OK;
    hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
    H5Pset_create_intermediate_group(lcpl, 1);
    hid_t g = H5Gcreate2(h->file, path, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    H5Pclose(lcpl);
    if (g < 0) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        GS_RAISE(GS_ERR_IO, "%s: cannot create group %s (HDF5: %s)", h->tmp_path, path, d);
    }
    H5Gclose(g);
    return GS_OK;
}

gs_err gs_ckpt_group(gs_ckpt_t h, const char *path)
{
    GS_CHECK(h && h->writing, GS_ERR_ARG, "%s: not open for writing (creating group %s)",
             h ? h->path : "(null)", path);
    GS_CHECK(path && path[0], GS_ERR_ARG, "%s: empty group path", h->path);
    GS_CALL(make_group(h, path));
    return GS_OK;
}

gs_err gs_ckpt_exists(gs_ckpt_t h, const char *path, int *exists)
{
    GS_CHECK(h && path && exists, GS_ERR_ARG, "gs_ckpt_exists: arguments required");
    *exists = gs_h5_exists(h->file, path);
    return GS_OK;
}

static gs_err open_for_set(gs_ckpt_t h, const char *object, const char *name, hid_t *out)
{
    GS_CHECK(h && object && name && name[0], GS_ERR_ARG, "gs_ckpt_set_*: arguments required");
    GS_CHECK(h->writing, GS_ERR_ARG, "%s: not open for writing (setting %s@%s)", h->path, object,
             name);
    GS_CALL(make_group(h, object));
    hid_t obj = H5Oopen(h->file, object, H5P_DEFAULT);
    if (obj < 0) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        GS_RAISE(GS_ERR_IO, "%s: cannot open %s (HDF5: %s)", h->tmp_path, object, d);
    }
    *out = obj;
    return GS_OK;
}

static gs_err set_raw(gs_ckpt_t h, const char *object, const char *name, hid_t ftype,
                      hid_t mtype, const void *value)
{
    hid_t obj;
    GS_CALL(open_for_set(h, object, name, &obj));
    gs_err err = gs_h5_write_attr_raw(obj, name, ftype, mtype, value, h->tmp_path);
    H5Oclose(obj);
    GS_CALL(err);
    return GS_OK;
}

gs_err gs_ckpt_set_i64(gs_ckpt_t h, const char *object, const char *name, int64_t value)
{
    GS_CALL(set_raw(h, object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &value));
    return GS_OK;
}

gs_err gs_ckpt_set_u64(gs_ckpt_t h, const char *object, const char *name, uint64_t value)
{
    GS_CALL(set_raw(h, object, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &value));
    return GS_OK;
}

gs_err gs_ckpt_set_f64(gs_ckpt_t h, const char *object, const char *name, double value)
{
    GS_CALL(set_raw(h, object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value));
    return GS_OK;
}

gs_err gs_ckpt_set_str(gs_ckpt_t h, const char *object, const char *name, const char *value)
{
    GS_CHECK(value, GS_ERR_ARG, "gs_ckpt_set_str: value required");
    hid_t obj;
    GS_CALL(open_for_set(h, object, name, &obj));
    gs_err err = gs_h5_write_str_attr(obj, name, value, h->tmp_path);
    H5Oclose(obj);
    GS_CALL(err);
    return GS_OK;
}

static gs_err open_for_get(gs_ckpt_t h, const char *object, const char *name, hid_t *out)
{
    GS_CHECK(h && object && name, GS_ERR_ARG, "gs_ckpt_get_*: arguments required");
    const char *path = h->writing ? h->tmp_path : h->path;
    GS_CHECK(gs_h5_exists(h->file, object), GS_ERR_FORMAT,
             "%s: %s is missing (reading attribute %s)", path, object, name);
    hid_t obj = H5Oopen(h->file, object, H5P_DEFAULT);
    if (obj < 0) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        GS_RAISE(GS_ERR_FORMAT, "%s: cannot open %s (HDF5: %s)", path, object, d);
    }
    *out = obj;
    return GS_OK;
}

static gs_err get_num(gs_ckpt_t h, const char *object, const char *name, char kind, void *out)
{
    hid_t obj;
    GS_CALL(open_for_get(h, object, name, &obj));
    char why[300];
    int rc = gs_h5_read_num_attr(obj, name, kind, out, why, sizeof why);
    H5Oclose(obj);
    GS_CHECK(rc == 0, GS_ERR_FORMAT, "%s: attribute %s@%s: %s (expected %s)",
             h->writing ? h->tmp_path : h->path, object, name, why,
             kind == 'i' ? "int64" : kind == 'u' ? "uint64" : "float64");
    return GS_OK;
}

gs_err gs_ckpt_get_i64(gs_ckpt_t h, const char *object, const char *name, int64_t *value)
{
    GS_CALL(get_num(h, object, name, 'i', value));
    return GS_OK;
}

gs_err gs_ckpt_get_u64(gs_ckpt_t h, const char *object, const char *name, uint64_t *value)
{
    GS_CALL(get_num(h, object, name, 'u', value));
    return GS_OK;
}

gs_err gs_ckpt_get_f64(gs_ckpt_t h, const char *object, const char *name, double *value)
{
    GS_CALL(get_num(h, object, name, 'f', value));
    return GS_OK;
}

gs_err gs_ckpt_get_str(gs_ckpt_t h, const char *object, const char *name, char **value)
{
    GS_CHECK(value, GS_ERR_ARG, "gs_ckpt_get_str: value required");
    hid_t obj;
    GS_CALL(open_for_get(h, object, name, &obj));
    char why[300];
    char *s = NULL;
    int rc = gs_h5_read_str_attr(obj, name, GS_H5_ATTR_STR_MAX, &s, why, sizeof why);
    H5Oclose(obj);
    GS_CHECK(rc == 0, GS_ERR_FORMAT, "%s: attribute %s@%s: %s (expected a string)",
             h->writing ? h->tmp_path : h->path, object, name, why);
    *value = s;
    return GS_OK;
}
