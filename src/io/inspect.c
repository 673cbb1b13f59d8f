/* `geosynth inspect FILE.h5`: a human-readable summary of any geosynth HDF5
 * file. See include/geosynth/h5.h (gs_inspect_file). */
#include "io/h5_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geosynth/mem.h"

typedef struct inspect_ctx {
    FILE *out;
    const gs_inspect_opts *opts;
    int is_geosynth;
    int objects;
} inspect_ctx;

static void print_bytes(FILE *out, double b)
{
    const char *unit[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    int u = 0;
    while (b >= 1024 && u < 4) {
        b /= 1024;
        u++;
    }
    if (u == 0)
        fprintf(out, "%.0f %s", b, unit[u]);
    else
        fprintf(out, "%.1f %s", b, unit[u]);
}

static void print_config(FILE *out, const char *cfg, int max_lines, const char *name)
{
    int lines = 0;
    for (const char *p = cfg; *p; p++)
        if (*p == '\n' || p[1] == '\0')
            lines++;
    int shown = max_lines > 0 && lines > max_lines ? max_lines : lines;
    fprintf(out, "  config:          %d line%s%s\n", lines, lines == 1 ? "" : "s",
            shown < lines ? " (first lines shown)" : "");
    const char *p = cfg;
    for (int i = 0; i < shown && *p; i++) {
        const char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p) : strlen(p);
        fprintf(out, "    | %.*s\n", (int)n, p);
        p += n + (nl ? 1 : 0);
    }
    if (shown < lines)
        fprintf(out, "    ... %d more lines not shown (full text: h5dump -d /geosynth/config %s)\n",
                lines - shown, name);
}

/* One attribute value, compactly. */
static herr_t attr_cb(hid_t obj, const char *name, const H5A_info_t *info, void *data)
{
    inspect_ctx *c = data;
    (void)info;
    char why[200];
    fprintf(c->out, "      @%s = ", name);
    hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
    hid_t t = a >= 0 ? H5Aget_type(a) : -1;
    hid_t s = a >= 0 ? H5Aget_space(a) : -1;
    hssize_t n = s >= 0 ? H5Sget_simple_extent_npoints(s) : -1;
    H5T_class_t cls = t >= 0 ? H5Tget_class(t) : H5T_NO_CLASS;
    int is_signed = cls == H5T_INTEGER && H5Tget_sign(t) == H5T_SGN_2;
    size_t size = t >= 0 ? H5Tget_size(t) : 0;
    if (s >= 0)
        H5Sclose(s);
    if (t >= 0)
        H5Tclose(t);
    if (a >= 0)
        H5Aclose(a);
    if (n == 1 && cls == H5T_INTEGER) {
        int64_t i;
        uint64_t u;
        if (is_signed && gs_h5_read_num_attr(obj, name, 'i', &i, why, sizeof why) == 0)
            fprintf(c->out, "%lld (int%zu)\n", (long long)i, size * 8);
        else if (!is_signed && gs_h5_read_num_attr(obj, name, 'u', &u, why, sizeof why) == 0)
            fprintf(c->out, "%llu (uint%zu)\n", (unsigned long long)u, size * 8);
        else
            fprintf(c->out, "(unreadable: %s)\n", why);
    } else if (n == 1 && cls == H5T_FLOAT) {
        double v;
        if (gs_h5_read_num_attr(obj, name, 'f', &v, why, sizeof why) == 0)
            fprintf(c->out, "%.17g (float%zu)\n", v, size * 8);
        else
            fprintf(c->out, "(unreadable: %s)\n", why);
    } else if (n == 1 && cls == H5T_STRING) {
        char *v = NULL;
        if (gs_h5_read_str_attr(obj, name, GS_H5_ATTR_STR_MAX, &v, why, sizeof why) == 0) {
            size_t len = strlen(v);
            fputc('"', c->out);
            for (size_t i = 0; i < len && i < 200; i++)
                fputc(v[i] == '\n' ? ' ' : ((unsigned char)v[i] < 0x20 ? '?' : v[i]), c->out);
            fprintf(c->out, "%s\"\n", len > 200 ? "..." : "");
            gs_free(v);
        } else {
            fprintf(c->out, "(unreadable string: %s)\n", why);
        }
    } else {
        char tn[64] = "";
        if (cls == H5T_INTEGER || cls == H5T_FLOAT)
            snprintf(tn, sizeof tn, "%s%zu", cls == H5T_FLOAT ? "float" : is_signed ? "int" : "uint",
                     size * 8);
        else
            snprintf(tn, sizeof tn, "class %d", (int)cls);
        fprintf(c->out, "(%lld values of %s)\n", (long long)n, tn);
    }
    H5Eclear2(H5E_DEFAULT);
    return 0;
}

static void print_attrs(inspect_ctx *c, hid_t obj)
{
    hsize_t idx = 0;
    H5Aiterate2(obj, H5_INDEX_NAME, H5_ITER_INC, &idx, attr_cb, c);
    H5Eclear2(H5E_DEFAULT);
}

/* Regular sampling grid with at most budget points: strides per axis. */
static uint64_t sample_grid(int rank, const hsize_t *dims, uint64_t budget, hsize_t *stride,
                            hsize_t *count)
{
    double total = 1;
    int big = 0;
    for (int i = 0; i < rank; i++) {
        total *= (double)dims[i];
        big += dims[i] > 1;
        stride[i] = 1;
        count[i] = dims[i];
    }
    if (total > (double)budget && big > 0) {
        double g = pow(total / (double)budget, 1.0 / big);
        for (int i = 0; i < rank; i++) {
            if (dims[i] > 1 && g >= 2) {
                stride[i] = (hsize_t)g;
                count[i] = (dims[i] + stride[i] - 1) / stride[i];
            }
        }
    }
    /* Rounding left too many: thin the slowest axes further. */
    for (int i = 0; i < rank; i++) {
        double sel = 1;
        for (int k = 0; k < rank; k++)
            sel *= (double)count[k];
        if (sel <= (double)budget)
            break;
        double others = sel / (double)count[i];
        hsize_t want = others >= (double)budget ? 1 : (hsize_t)((double)budget / others);
        if (want < 1)
            want = 1;
        if (want < count[i]) {
            stride[i] = (dims[i] + want - 1) / want;
            count[i] = (dims[i] + stride[i] - 1) / stride[i];
        }
    }
    uint64_t sel = 1;
    for (int i = 0; i < rank; i++)
        sel *= count[i];
    return sel;
}

static void print_stats(inspect_ctx *c, hid_t d, hid_t space, int rank, const hsize_t *dims,
                        uint64_t total)
{
    if (total == 0) {
        fprintf(c->out, "      (empty)\n");
        return;
    }
    hsize_t stride[H5S_MAX_RANK], count[H5S_MAX_RANK], start[H5S_MAX_RANK] = {0};
    uint64_t budget = c->opts->sample_values ? c->opts->sample_values : 1;
    uint64_t n = sample_grid(rank, dims, budget, stride, count);
    double *v = NULL;
    if (gs_alloc_array((void **)&v, (size_t)n, sizeof *v, "inspect sample") != GS_OK) {
        gs_error_clear();
        fprintf(c->out, "      (statistics skipped: out of memory)\n");
        return;
    }
    hsize_t hn = n;
    hid_t fs = H5Scopy(space);
    hid_t ms = H5Screate_simple(1, &hn, NULL);
    if (fs < 0 || ms < 0 ||
        H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, stride, count, NULL) < 0 ||
        H5Dread(d, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, v) < 0) {
        char detail[200];
        gs_h5_detail(detail, sizeof detail);
        fprintf(c->out, "      (statistics unavailable: %s)\n", detail);
    } else {
        double lo = INFINITY, hi = -INFINITY, sum = 0;
        uint64_t finite = 0, nonfinite = 0;
        for (uint64_t i = 0; i < n; i++) {
            if (!isfinite(v[i])) {
                nonfinite++;
                continue;
            }
            lo = v[i] < lo ? v[i] : lo;
            hi = v[i] > hi ? v[i] : hi;
            sum += v[i];
            finite++;
        }
        if (finite)
            fprintf(c->out, "      min %.9g  max %.9g  mean %.9g", lo, hi, sum / (double)finite);
        else
            fprintf(c->out, "      no finite values");
        if (nonfinite)
            fprintf(c->out, "  (%llu NaN/inf)", (unsigned long long)nonfinite);
        if (n < total)
            fprintf(c->out, "  [sampled %llu of %llu values]", (unsigned long long)n,
                    (unsigned long long)total);
        fputc('\n', c->out);
    }
    if (fs >= 0)
        H5Sclose(fs);
    if (ms >= 0)
        H5Sclose(ms);
    gs_free(v);
    H5Eclear2(H5E_DEFAULT);
}

static void print_dataset(inspect_ctx *c, hid_t d, const char *name)
{
    hid_t t = H5Dget_type(d), s = H5Dget_space(d), dcpl = H5Dget_create_plist(d);
    int rank = s >= 0 ? H5Sget_simple_extent_ndims(s) : -1;
    hsize_t dims[H5S_MAX_RANK];
    if (rank < 0 || rank > H5S_MAX_RANK || H5Sget_simple_extent_dims(s, dims, NULL) < 0) {
        fprintf(c->out, "dataset (unreadable dataspace)\n");
        goto done;
    }
    char tn[64] = "";
    H5T_class_t cls = t >= 0 ? H5Tget_class(t) : H5T_NO_CLASS;
    gs_h5_type gt = t >= 0 ? gs_h5_type_of(t, tn, sizeof tn) : 0;
    if (gt)
        snprintf(tn, sizeof tn, "%s", gs_h5_type_name(gt));
    if (cls == H5T_STRING)
        snprintf(tn, sizeof tn, "%s string (%zu bytes)",
                 H5Tis_variable_str(t) > 0 ? "variable-length" : "fixed-length", H5Tget_size(t));
    fprintf(c->out, "dataset %s ", tn);
    uint64_t total = 1;
    if (rank == 0) {
        fprintf(c->out, "scalar");
    } else {
        fputc('[', c->out);
        for (int i = 0; i < rank; i++) {
            fprintf(c->out, "%s%llu", i ? " x " : "", (unsigned long long)dims[i]);
            total *= dims[i];
        }
        fputc(']', c->out);
    }
    if (dcpl >= 0 && H5Pget_layout(dcpl) == H5D_CHUNKED) {
        hsize_t ch[H5S_MAX_RANK];
        int cr = H5Pget_chunk(dcpl, H5S_MAX_RANK, ch);
        fprintf(c->out, ", chunks ");
        for (int i = 0; i < cr; i++)
            fprintf(c->out, "%s%llu", i ? "x" : "", (unsigned long long)ch[i]);
        int nf = H5Pget_nfilters(dcpl);
        for (int i = 0; i < nf && i < 8; i++) {
            unsigned flags, cd[8];
            size_t ncd = 8;
            char fname[64] = "";
            unsigned fc;
            if (H5Pget_filter2(dcpl, (unsigned)i, &flags, &ncd, cd, sizeof fname, fname, &fc) >= 0)
                fprintf(c->out, ", %s", fname[0] ? fname : "filter");
        }
    }
    fprintf(c->out, ", ");
    print_bytes(c->out, (double)H5Dget_storage_size(d));
    fprintf(c->out, " stored\n");
    if (strcmp(name, "/geosynth/config") == 0)
        ; /* shown in the identity section */
    else if ((cls == H5T_INTEGER || cls == H5T_FLOAT) && rank > 0)
        print_stats(c, d, s, rank, dims, total);
done:
    H5Eclear2(H5E_DEFAULT);
    if (dcpl >= 0)
        H5Pclose(dcpl);
    if (s >= 0)
        H5Sclose(s);
    if (t >= 0)
        H5Tclose(t);
}

static herr_t visit_cb(hid_t root, const char *name, const H5L_info_t *info, void *data)
{
    inspect_ctx *c = data;
    c->objects++;
    fprintf(c->out, "  /%-38s ", name);
    if (info->type != H5L_TYPE_HARD) {
        /* Never followed: an external link could open any file. */
        fprintf(c->out, "%s link (not followed)\n",
                info->type == H5L_TYPE_SOFT ? "soft" : "external");
        return 0;
    }
    hid_t obj = H5Oopen(root, name, H5P_DEFAULT);
    if (obj < 0) {
        char d[200];
        gs_h5_detail(d, sizeof d);
        fprintf(c->out, "(unreadable: %s)\n", d);
        return 0;
    }
    H5I_type_t it = H5Iget_type(obj);
    if (it == H5I_GROUP)
        fprintf(c->out, "group\n");
    else if (it == H5I_DATASET)
        print_dataset(c, obj, name);
    else if (it == H5I_DATATYPE)
        fprintf(c->out, "named datatype\n");
    else
        fprintf(c->out, "object of unknown kind\n");
    if (!(c->is_geosynth && strcmp(name, "geosynth") == 0)) /* identity printed above */
        print_attrs(c, obj);
    H5Oclose(obj);
    H5Eclear2(H5E_DEFAULT);
    return 0;
}

static gs_err inspect_listing(hid_t f, const char *name, FILE *out, const gs_inspect_opts *opts);

/* The listing quotes names, strings and the config text from the file: it
 * is built in memory and written sanitized (gs_text_sanitize, #25). */
static gs_err inspect_open_file(hid_t f, const char *name, FILE *out, const gs_inspect_opts *opts)
{
    char *buf = NULL;
    size_t len = 0;
    FILE *mem = open_memstream(&buf, &len);
    GS_CHECK(mem != NULL, GS_ERR_MEM, "%s: no memory for the listing", name);
    gs_err err = inspect_listing(f, name, mem, opts);
    fclose(mem);
    if (buf) {
        gs_text_sanitize(buf);
        fwrite(buf, 1, strlen(buf), out);
    }
    free(buf);
    return err;
}

static gs_err inspect_listing(hid_t f, const char *name, FILE *out, const gs_inspect_opts *opts)
{
    gs_inspect_opts def = {40, (uint64_t)1 << 22};
    if (!opts)
        opts = &def;
    inspect_ctx c = {out, opts, 0, 0};
    gs_err ident = GS_OK;
    fprintf(out, "file: %s\n", name);
    c.is_geosynth = gs_h5_exists(f, "/geosynth");
    if (c.is_geosynth) {
        struct gs_ckpt h;
        memset(&h, 0, sizeof h);
        h.file = f;
        h.comm = MPI_COMM_NULL;
        h.path = (char *)name;
        ident = gs_h5_load_identity(&h, NULL);
        if (ident == GS_OK) {
            fprintf(out, "geosynth file, format version %d\n", h.format_version);
            fprintf(out, "  engine:          %s\n", h.engine);
            fprintf(out, "  program_version: %s\n", h.program_version);
            fprintf(out, "  seed:            %llu\n", (unsigned long long)h.seed);
            fprintf(out, "  created:         %s\n", h.created);
            print_config(out, h.config, opts->config_lines, name);
        } else {
            fprintf(out, "INVALID geosynth identity: %s\n", gs_error_message());
        }
        gs_free(h.program_version);
        gs_free(h.config);
    } else {
        fprintf(out, "not a geosynth file (no /geosynth group); its structure:\n");
    }
    fprintf(out, "objects:\n  /%-38s group\n", "");
    print_attrs(&c, f);
    H5Lvisit(f, H5_INDEX_NAME, H5_ITER_INC, visit_cb, &c);
    H5Eclear2(H5E_DEFAULT);
    fflush(out);
    GS_CHECK(c.is_geosynth, GS_ERR_FORMAT, "%s: not a geosynth file (no /geosynth group)", name);
    GS_CALL(ident);
    return GS_OK;
}

gs_err gs_inspect_file_opts(const char *path, FILE *out, const gs_inspect_opts *opts)
{
    GS_CHECK(path && out, GS_ERR_ARG, "gs_inspect_file: path and output required");
    hid_t f;
    GS_CALL(gs_h5_open_serial(path, 0, &f));
    gs_err err = inspect_open_file(f, path, out, opts);
    H5Fclose(f);
    H5Eclear2(H5E_DEFAULT);
    GS_CALL(err);
    return GS_OK;
}

gs_err gs_inspect_file(const char *path, FILE *out)
{
    GS_CALL(gs_inspect_file_opts(path, out, NULL));
    return GS_OK;
}

gs_err gs_inspect_image(const void *buf, size_t len, const char *name, FILE *out,
                        const gs_inspect_opts *opts)
{
    GS_CHECK(name && out && (buf || len == 0), GS_ERR_ARG, "gs_inspect_image: arguments required");
    hid_t f;
    GS_CALL(gs_h5_open_image(name, buf, len, 0, &f));
    gs_err err = inspect_open_file(f, name, out, opts);
    H5Fclose(f);
    H5Eclear2(H5E_DEFAULT);
    GS_CALL(err);
    return GS_OK;
}
