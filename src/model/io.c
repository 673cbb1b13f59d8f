/* model engine I/O: example loading (txt, csv, vox, h5), colours, .vox and PNG
 * output, and the file-level checker. See include/geosynth/model_io.h. */
#include <string.h>

#include "geosynth/h5.h"
#include "geosynth/image.h"
#include "geosynth/mem.h"
#include "geosynth/model_io.h"
#include "geosynth/model_tiles.h"
#include "geosynth/vox.h"

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    if (m > n)
        return 0;
    for (size_t i = 0; i < m; i++) {
        char c = s[n - m + i];
        if (c >= 'A' && c <= 'Z')
            c = (char)(c - 'A' + 'a');
        if (c != suffix[i])
            return 0;
    }
    return 1;
}

const char *gs_model_format_of(const char *path)
{
    if (ends_with(path, ".txt"))
        return "txt";
    if (ends_with(path, ".csv"))
        return "csv";
    if (ends_with(path, ".vox"))
        return "vox";
    if (ends_with(path, ".h5") || ends_with(path, ".hdf5") || ends_with(path, ".hdf"))
        return "h5";
    return NULL;
}

void gs_model_label_rgb(const gs_model_palette *pal, uint16_t label, uint8_t rgb[3])
{
    if (label == 0) {
        rgb[0] = rgb[1] = rgb[2] = 0;
        return;
    }
    if (pal && pal->from_file && label < 256) {
        memcpy(rgb, pal->rgba[label], 3);
        return;
    }
    /* Fixed colour per label: golden-ratio hue steps, full-ish saturation. */
    double h = (double)label * 0.618033988749895;
    h -= (double)(long)h;
    double s = 0.55 + 0.35 * (double)((label * 7u) % 3u) / 2.0, v = 0.95 - 0.25 * (double)(label % 2u);
    int i = (int)(h * 6.0);
    double f = h * 6.0 - i, p = v * (1 - s), q = v * (1 - f * s), t = v * (1 - (1 - f) * s);
    double r, g, b;
    switch (i % 6) {
    case 0: r = v, g = t, b = p; break;
    case 1: r = q, g = v, b = p; break;
    case 2: r = p, g = v, b = t; break;
    case 3: r = p, g = q, b = v; break;
    case 4: r = t, g = p, b = v; break;
    default: r = v, g = p, b = q; break;
    }
    rgb[0] = (uint8_t)(r * 255.0 + 0.5);
    rgb[1] = (uint8_t)(g * 255.0 + 0.5);
    rgb[2] = (uint8_t)(b * 255.0 + 0.5);
}

static gs_err load_vox(const char *path, gs_model_lattice *out, gs_model_palette *pal)
{
    gs_vox v;
    GS_CALL(gs_vox_read(path, &v));
    int nx = 0, ny = 0, nz = 0;
    uint8_t *labels = NULL;
    gs_model_lattice lat = {0};
    gs_err err = GS_OK;
    GS_TRY_CHECK(err, v.nmodels >= 1, GS_ERR_FORMAT, done, "%s: no voxel model in the file", path);
    GS_TRY(err, gs_vox_flatten(&v, &nx, &ny, &nz, &labels, NULL), done);
    GS_TRY(err, gs_model_lattice_create(&lat, nx, ny, nz), done);
    size_t n = (size_t)nx * (size_t)ny * (size_t)nz;
    for (size_t i = 0; i < n; i++)
        lat.labels[i] = labels[i];
    if (pal) {
        memcpy(pal->rgba, v.palette, sizeof pal->rgba);
        pal->from_file = 1;
    }
    *out = lat;
    lat.labels = NULL;
done:
    gs_free(labels);
    gs_model_lattice_destroy(&lat);
    gs_vox_destroy(&v);
    return err;
}

static gs_err load_h5(const char *path, const char *dataset, gs_model_lattice *out)
{
    if (!dataset || !dataset[0])
        dataset = "/model/labels";
    gs_ckpt_t h = NULL;
    GS_CALL(gs_ckpt_open(MPI_COMM_NULL, path, NULL, &h));
    gs_model_lattice lat = {0};
    gs_h5_shape sh;
    gs_err err = GS_OK;
    GS_TRY(err, gs_ckpt_shape(h, dataset, &sh), done);
    char got[128];
    gs_h5_shape_format(&sh, got, sizeof got);
    GS_TRY_CHECK(err, sh.type == GS_H5_U16 && sh.rank >= 2 && sh.rank <= 4, GS_ERR_FORMAT, done,
                 "%s: dataset %s is %s: expected a uint16 label lattice [nz x ny x nx] (or "
                 "[ny x nx], or 4D frames [nt x nz x ny x nx])",
                 path, dataset, got);
    int ok = 1;
    for (int i = 0; i < sh.rank; i++)
        ok &= sh.dims[i] <= (1u << 20);
    GS_TRY_CHECK(err, ok && (sh.rank < 4 || sh.dims[0] * sh.dims[1] <= (1u << 20)), GS_ERR_FORMAT,
                 done, "%s: dataset %s is %s: extents above 2^20", path, dataset, got);
    /* 4D: the frames stacked along z, as the engine holds them */
    int frames = sh.rank == 4 ? (int)sh.dims[0] : 1;
    int nz = sh.rank == 4 ? (int)(sh.dims[0] * sh.dims[1]) : sh.rank == 3 ? (int)sh.dims[0] : 1;
    int ny = (int)sh.dims[sh.rank - 2], nx = (int)sh.dims[sh.rank - 1];
    GS_TRY(err, gs_ckpt_check_stored(h, dataset, &sh), done);
    GS_TRY(err, gs_model_lattice_create(&lat, nx, ny, nz), done);
    lat.frames = frames;
    GS_TRY(err, gs_ckpt_read_whole(h, dataset, &sh, lat.labels), done);
    *out = lat;
    lat.labels = NULL;
done:
    gs_model_lattice_destroy(&lat);
    gs_ckpt_close(&h);
    return err;
}

gs_err gs_model_load(const char *path, const char *format, const char *dataset,
                     gs_model_lattice *out, gs_model_palette *pal)
{
    const char *fmt = format && strcmp(format, "auto") ? format : gs_model_format_of(path);
    GS_CHECK(fmt != NULL, GS_ERR_ARG,
             "%s: cannot tell the format from the name: expected .txt (Merrell), .csv "
             "(DeBroglie), .vox (MagicaVoxel or Slab6) or .h5 (geosynth HDF5), or set "
             "model.format",
             path);
    if (pal)
        memset(pal, 0, sizeof *pal);
    if (!strcmp(fmt, "txt"))
        return gs_model_read_merrell_txt(path, out);
    if (!strcmp(fmt, "csv"))
        return gs_model_read_debroglie_csv(path, out);
    if (!strcmp(fmt, "vox"))
        return load_vox(path, out, pal);
    if (!strcmp(fmt, "h5"))
        return load_h5(path, dataset, out);
    GS_RAISE(GS_ERR_ARG, "%s: unknown format '%s': expected auto, txt, csv, vox or h5", path, fmt);
}

gs_err gs_model_write_vox(const char *path, const gs_model_lattice *lat,
                          const gs_model_palette *pal, int *renumbered)
{
    size_t n = (size_t)lat->nx * (size_t)lat->ny * (size_t)lat->nz;
    uint8_t *labels = NULL, *map_used = NULL;
    uint16_t *map = NULL;
    uint8_t palette[256][4];
    gs_err err = GS_OK;
    GS_TRY(err, gs_alloc_array((void **)&labels, n, 1, "vox labels"), done);
    GS_TRY(err, gs_alloc_array((void **)&map, 65536, sizeof *map, "label map"), done);
    GS_TRY(err, gs_alloc_array((void **)&map_used, 65536, 1, "label map"), done);
    memset(map_used, 0, 65536);
    int maxl = 0;
    for (size_t i = 0; i < n; i++) {
        map_used[lat->labels[i]] = 1;
        if (lat->labels[i] > maxl)
            maxl = lat->labels[i];
    }
    int renum = maxl > 255, k = 0;
    for (int l = 0; l < 65536; l++) {
        map[l] = (uint16_t)l;
        if (renum && l > 0 && map_used[l])
            map[l] = (uint16_t)++k;
    }
    GS_TRY_CHECK(err, k <= 255, GS_ERR_ARG, done,
                 "%s: the lattice has %d distinct non-empty labels; .vox holds at most 255", path,
                 k);
    memset(palette, 0, sizeof palette);
    for (int l = 1; l < 65536; l++) {
        if (!map_used[l] && renum)
            continue;
        if (map[l] > 255)
            continue;
        uint8_t rgb[3];
        gs_model_label_rgb(pal, (uint16_t)l, rgb);
        memcpy(palette[map[l]], rgb, 3);
        palette[map[l]][3] = 255;
    }
    for (size_t i = 0; i < n; i++)
        labels[i] = (uint8_t)map[lat->labels[i]];
    GS_TRY(err, gs_vox_write_lattice(path, lat->nx, lat->ny, lat->nz, labels,
                                     (const uint8_t(*)[4])palette),
           done);
    if (renumbered)
        *renumbered = renum;
done:
    gs_free(labels);
    gs_free(map);
    gs_free(map_used);
    return err;
}

gs_err gs_model_write_png(const char *path, const gs_model_lattice *lat,
                          const gs_model_palette *pal)
{
    gs_image img;
    GS_CALL(gs_image_alloc(&img, lat->nx, lat->ny, 3, 8));
    for (int y = 0; y < lat->ny; y++)
        for (int x = 0; x < lat->nx; x++) {
            uint16_t l = lat->labels[gs_model_lattice_index(lat, x, y, 0)];
            uint8_t *px = img.data8 + ((size_t)(lat->ny - 1 - y) * (size_t)lat->nx + (size_t)x) * 3;
            if (l == 0)
                px[0] = px[1] = px[2] = 255;
            else
                gs_model_label_rgb(pal, l, px);
        }
    gs_err err = gs_image_write_png(path, &img);
    gs_image_destroy(&img);
    return err;
}

static const char *dir_name(int dir)
{
    return dir == 0 ? "+x" : dir == 2 ? "+y" : dir == 4 ? "+z" : "label";
}

gs_err gs_model_check_files(const char *example, const char *output, FILE *out, size_t cap,
                            size_t *count)
{
    gs_model_lattice ex = {0}, lat = {0};
    gs_model_violation *v = NULL;
    gs_model_tileset ts;
    memset(&ts, 0, sizeof ts);
    gs_err err = GS_OK;
    /* A WFC tile set "TILES.xml" or "TILES.xml#SUBSET" checks against its
     * neighbour list instead of an example lattice. */
    char tpath[4096] = "";
    const char *hash = strstr(example, ".xml#");
    if (hash || ends_with(example, ".xml")) {
        size_t pl = hash ? (size_t)(hash - example) + 4 : strlen(example);
        GS_TRY_CHECK(err, pl < sizeof tpath, GS_ERR_ARG, done, "%s: path too long", example);
        memcpy(tpath, example, pl);
        tpath[pl] = '\0';
        GS_TRY(err, gs_model_tileset_load(tpath, hash ? hash + 5 : NULL, 0, &ts), done);
        GS_TRY(err, gs_model_lattice_create(&ex, 1, 1, 1), done);
    } else {
        GS_TRY(err, gs_model_load(example, "auto", NULL, &ex, NULL), done);
    }
    GS_TRY(err, gs_model_load(output, "auto", NULL, &lat, NULL), done);
    if (cap)
        GS_TRY(err, gs_alloc_array((void **)&v, cap, sizeof *v, "violation list"), done);
    size_t nv = 0;
    if (tpath[0])
        GS_TRY(err, gs_model_tileset_check(&ts, &lat, v, cap, &nv), done);
    else
        GS_TRY(err, gs_model_check(&ex, &lat, v, cap, &nv), done);
    fprintf(out, "example %s: %dx%dx%d\noutput  %s: %dx%dx%d\n", example, ex.nx, ex.ny, ex.nz,
            output, lat.nx, lat.ny, lat.nz);
    for (size_t i = 0; i < nv && i < cap; i++) {
        const gs_model_violation *w = &v[i];
        if (w->dir < 0)
            fprintf(out, "  cell (%d, %d, %d): label %u never occurs in the example\n", w->x, w->y,
                    w->z, (unsigned)w->a);
        else
            fprintf(out,
                    "  cell (%d, %d, %d) label %u, next cell along %s label %u: pair never "
                    "adjacent in the example\n",
                    w->x, w->y, w->z, (unsigned)w->a, dir_name(w->dir), (unsigned)w->b);
    }
    if (nv > cap)
        fprintf(out, "  ... and %zu more\n", nv - cap);
    fprintf(out, "violations: %zu\n", nv);
    *count = nv;
done:
    gs_free(v);
    gs_model_tileset_destroy(&ts);
    gs_model_lattice_destroy(&ex);
    gs_model_lattice_destroy(&lat);
    return err;
}
