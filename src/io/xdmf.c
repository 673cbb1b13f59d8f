/* XDMF 2 sidecars so ParaView opens uniform 3D grids stored in geosynth
 * HDF5 files. See include/geosynth/h5.h (gs_xdmf_write). */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/file.h"
#include "geosynth/killpoint.h"
#include "geosynth/h5.h"

gs_err gs_xdmf_path(const char *h5_path, char *out, size_t len)
{
    GS_CHECK(h5_path && out, GS_ERR_ARG, "gs_xdmf_path: arguments required");
    size_t n = strlen(h5_path);
    size_t stem = n >= 3 && strcmp(h5_path + n - 3, ".h5") == 0 ? n - 3 : n;
    GS_CHECK(stem + 5 <= len, GS_ERR_ARG, "%s: sidecar path too long", h5_path);
    memcpy(out, h5_path, stem);
    memcpy(out + stem, ".xmf", 5);
    return GS_OK;
}

/* XDMF 2 NumberType + Precision for a geosynth element type. */
static void number_type(gs_h5_type t, const char **nt, int *prec)
{
    switch (t) {
    case GS_H5_F32: *nt = "Float"; *prec = 4; return;
    case GS_H5_F64: *nt = "Float"; *prec = 8; return;
    case GS_H5_U8: *nt = "UChar"; *prec = 1; return;
    case GS_H5_U16: *nt = "UInt"; *prec = 2; return;
    case GS_H5_I32: *nt = "Int"; *prec = 4; return;
    case GS_H5_I64: *nt = "Int"; *prec = 8; return;
    case GS_H5_U64: *nt = "UInt"; *prec = 8; return;
    }
    *nt = "Float";
    *prec = 4;
}

static gs_err check_grid(const char *h5_path, const gs_xdmf_grid *g, const gs_xdmf_attr *attrs,
                         int nattrs)
{
    GS_CHECK(g && g->name && (attrs || nattrs == 0), GS_ERR_ARG,
             "%s: XDMF grid description incomplete", h5_path);
    GS_CHECK(nattrs >= 1, GS_ERR_ARG, "%s: XDMF grid '%s' needs at least one attribute",
             h5_path, g->name);
    GS_CHECK(g->center == GS_XDMF_NODE || g->center == GS_XDMF_CELL, GS_ERR_ARG,
             "%s: XDMF grid '%s': invalid centering %d", h5_path, g->name, (int)g->center);
    for (int i = 0; i < 3; i++) {
        GS_CHECK(g->dims[i] >= 1, GS_ERR_ARG, "%s: XDMF grid '%s': dimension %d is 0", h5_path,
                 g->name, i);
        GS_CHECK(isfinite(g->origin[i]) && isfinite(g->spacing[i]) && g->spacing[i] > 0,
                 GS_ERR_ARG, "%s: XDMF grid '%s': origin and spacing must be finite, spacing > 0",
                 h5_path, g->name);
    }
    for (int a = 0; a < nattrs; a++)
        GS_CHECK(attrs[a].name && attrs[a].dataset && attrs[a].dataset[0] == '/' &&
                     gs_h5_type_size(attrs[a].type) > 0 && attrs[a].components >= 0 &&
                     attrs[a].components <= 9,
                 GS_ERR_ARG,
                 "%s: XDMF attribute %d needs a name, an absolute dataset path and a valid type",
                 h5_path, a);
    return GS_OK;
}

static void write_xml(FILE *f, const char *h5_name, const gs_xdmf_grid *g,
                      const gs_xdmf_attr *attrs, int nattrs)
{
    int cell = g->center == GS_XDMF_CELL;
    /* A cell-centred lattice of n voxels has n + 1 grid points per axis. */
    unsigned long long tz = g->dims[0] + (unsigned)cell, ty = g->dims[1] + (unsigned)cell,
                       tx = g->dims[2] + (unsigned)cell;
    const unsigned long long T = g->frames > 1 ? g->frames : 1;
    fputs("<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
          "<Xdmf Version=\"2.0\">\n  <Domain>\n",
          f);
    if (T > 1) {
        fputs("    <Grid Name=\"", f);
        gs_fput_markup(f, g->name, 0);
        fputs("\" GridType=\"Collection\" CollectionType=\"Temporal\">\n", f);
    }
    for (unsigned long long t = 0; t < T; t++) {
    fputs("    <Grid Name=\"", f);
    gs_fput_markup(f, g->name, 0);
    if (T > 1)
        fprintf(f, " t=%llu", t);
    fputs("\" GridType=\"Uniform\">\n", f);
    if (T > 1)
        fprintf(f, "      <Time Value=\"%llu\"/>\n", t);
    fprintf(f, "      <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"%llu %llu %llu\"/>\n",
            tz, ty, tx);
    /* ORIGIN_DXDYDZ lists z, y, x (slowest first), like Dimensions. */
    fprintf(f,
            "      <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
            "        <DataItem Name=\"Origin\" Dimensions=\"3\" NumberType=\"Float\" "
            "Precision=\"8\" Format=\"XML\">%.17g %.17g %.17g</DataItem>\n"
            "        <DataItem Name=\"Spacing\" Dimensions=\"3\" NumberType=\"Float\" "
            "Precision=\"8\" Format=\"XML\">%.17g %.17g %.17g</DataItem>\n"
            "      </Geometry>\n",
            g->origin[2], g->origin[1], g->origin[0], g->spacing[2], g->spacing[1],
            g->spacing[0]);
    for (int a = 0; a < nattrs; a++) {
        const char *nt;
        int prec;
        number_type(attrs[a].type, &nt, &prec);
        const int vec = attrs[a].components > 1;
        fputs("      <Attribute Name=\"", f);
        gs_fput_markup(f, attrs[a].name, 0);
        fprintf(f, "\" AttributeType=\"%s\" Center=\"%s\">\n", vec ? "Vector" : "Scalar",
                cell ? "Cell" : "Node");
        const unsigned long long d0 = g->dims[0], d1 = g->dims[1], d2 = g->dims[2];
        if (T > 1) { /* frame t: hyperslab start t 0 0 0 (0), stride 1, count 1 dims */
            const int rank = 4 + vec;
            fprintf(f, "        <DataItem ItemType=\"HyperSlab\" Dimensions=\"%llu %llu %llu", d0,
                    d1, d2);
            if (vec)
                fprintf(f, " %d", attrs[a].components);
            fprintf(f, "\" Type=\"HyperSlab\">\n          <DataItem Dimensions=\"3 %d\" "
                       "Format=\"XML\">%llu 0 0 0%s 1 1 1 1%s 1 %llu %llu %llu",
                    rank, t, vec ? " 0" : "", vec ? " 1" : "", d0, d1, d2);
            if (vec)
                fprintf(f, " %d", attrs[a].components);
            fprintf(f, "</DataItem>\n          <DataItem Dimensions=\"%llu %llu %llu %llu", T, d0, d1,
                    d2);
        } else {
            fprintf(f, "        <DataItem Dimensions=\"%llu %llu %llu", d0, d1, d2);
        }
        if (vec)
            fprintf(f, " %d", attrs[a].components);
        fprintf(f, "\" NumberType=\"%s\" Precision=\"%d\" Format=\"HDF\">", nt, prec);
        gs_fput_markup(f, h5_name, 0);
        fputc(':', f);
        gs_fput_markup(f, attrs[a].dataset, 0);
        fputs(T > 1 ? "</DataItem>\n        </DataItem>\n      </Attribute>\n"
                    : "</DataItem>\n      </Attribute>\n", f);
    }
    fputs("    </Grid>\n", f);
    }
    if (T > 1)
        fputs("    </Grid>\n", f);
    fputs("  </Domain>\n</Xdmf>\n", f);
}

gs_err gs_xdmf_write(const char *h5_path, const gs_xdmf_grid *grid, const gs_xdmf_attr *attrs,
                     int nattrs)
{
    GS_CHECK(h5_path && h5_path[0], GS_ERR_ARG, "gs_xdmf_write: HDF5 path required");
    GS_CALL(check_grid(h5_path, grid, attrs, nattrs));
    char xmf[4096], tmp[4100];
    GS_CALL(gs_xdmf_path(h5_path, xmf, sizeof xmf));
    snprintf(tmp, sizeof tmp, "%s.tmp", xmf);
    const char *slash = strrchr(h5_path, '/');
    const char *h5_name = slash ? slash + 1 : h5_path; /* relative: the pair moves together */

    FILE *f = gs_fopen_new(tmp);
    GS_CHECK(f, GS_ERR_IO, "%s: cannot create: %s", tmp, strerror(errno));
    write_xml(f, h5_name, grid, attrs, nattrs);
    int bad = fflush(f) != 0 || ferror(f) || fsync(fileno(f)) != 0;
    int e = errno;
    bad |= fclose(f) != 0;
    if (bad) {
        unlink(tmp);
        GS_RAISE(GS_ERR_IO, "%s: write failed: %s", tmp, strerror(e));
    }
    gs_kill_point("%s synced, not renamed", gs_kill_base(tmp));
    if (rename(tmp, xmf) != 0) {
        e = errno;
        unlink(tmp);
        GS_RAISE(GS_ERR_IO, "%s: cannot rename %s over it: %s", xmf, tmp, strerror(e));
    }
    return GS_OK;
}
