/* glTF 2.0 binary writer; see include/geosynth/glb.h. */
#include "geosynth/glb.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/file.h"
#include "geosynth/json.h"

#define GLB_MAGIC 0x46546C67u      /* "glTF" */
#define GLB_CHUNK_JSON 0x4E4F534Au /* "JSON" */
#define GLB_CHUNK_BIN 0x004E4942u  /* "BIN\0" */
#define GL_FLOAT 5126
#define GL_UNSIGNED_INT 5125
#define GL_ARRAY_BUFFER 34962
#define GL_ELEMENT_ARRAY_BUFFER 34963

double gs_srgb_to_linear(uint8_t c)
{
    const double s = c / 255.0;
    return s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4);
}

static void put32(uint8_t *p, uint32_t u)
{
    p[0] = (uint8_t)u;
    p[1] = (uint8_t)(u >> 8);
    p[2] = (uint8_t)(u >> 16);
    p[3] = (uint8_t)(u >> 24);
}

/* z-up (x, y, z) -> glTF y-up (x, z, -y) */
static void to_y_up(const float *in, float out[3])
{
    out[0] = in[0];
    out[1] = in[2];
    out[2] = in[1] == 0.0f ? 0.0f : -in[1]; /* no -0 */
}

static int write_f32x3(FILE *f, const float v[3])
{
    uint8_t b[12];
    for (int k = 0; k < 3; k++) {
        uint32_t u;
        memcpy(&u, &v[k], sizeof u);
        put32(b + 4 * k, u);
    }
    return fwrite(b, 1, sizeof b, f) == sizeof b;
}

static void buffer_view(gs_json *j, size_t offset, size_t length, int target)
{
    gs_json_begin_object(j, NULL);
    gs_json_i64(j, "buffer", 0);
    gs_json_i64(j, "byteOffset", (int64_t)offset);
    gs_json_i64(j, "byteLength", (int64_t)length);
    gs_json_i64(j, "target", target);
    gs_json_end_object(j);
}

static void accessor(gs_json *j, int view, int component, size_t count, const char *type,
                     const float *lo, const float *hi)
{
    gs_json_begin_object(j, NULL);
    gs_json_i64(j, "bufferView", view);
    gs_json_i64(j, "componentType", component);
    gs_json_i64(j, "count", (int64_t)count);
    gs_json_str(j, "type", type);
    if (lo) {
        gs_json_begin_array(j, "min");
        for (int k = 0; k < 3; k++)
            gs_json_f64(j, NULL, lo[k]);
        gs_json_end_array(j);
        gs_json_begin_array(j, "max");
        for (int k = 0; k < 3; k++)
            gs_json_f64(j, NULL, hi[k]);
        gs_json_end_array(j);
    }
    gs_json_end_object(j);
}

static void material(gs_json *j, const char *name, const uint8_t *rgb)
{
    gs_json_begin_object(j, NULL);
    gs_json_str(j, "name", name);
    gs_json_begin_object(j, "pbrMetallicRoughness");
    gs_json_begin_array(j, "baseColorFactor");
    for (int k = 0; k < 3; k++)
        gs_json_f64(j, NULL, round(gs_srgb_to_linear(rgb[k]) * 1e6) / 1e6);
    gs_json_f64(j, NULL, 1.0);
    gs_json_end_array(j);
    gs_json_f64(j, "metallicFactor", 0.0); /* the default 1 renders as dark metal */
    gs_json_f64(j, "roughnessFactor", 1.0);
    gs_json_end_object(j);
    gs_json_end_object(j);
}

gs_err gs_glb_write(const char *path, const gs_glb_desc *d)
{
    const size_t nv = d->nverts;
    GS_CHECK(nv > 0 && nv <= ((size_t)1 << 30), GS_ERR_ARG, "%s: a glTF mesh needs 1 to 2^30 vertices, not %zu",
             path, nv);
    float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (size_t i = 0; i < nv; i++) {
        float p[3];
        GS_CHECK(isfinite(d->pos[3 * i]) && isfinite(d->pos[3 * i + 1]) && isfinite(d->pos[3 * i + 2]),
                 GS_ERR_ARG, "%s: vertex %zu has a non-finite coordinate", path, i);
        to_y_up(d->pos + 3 * i, p);
        for (int k = 0; k < 3; k++) {
            lo[k] = i == 0 || p[k] < lo[k] ? p[k] : lo[k];
            hi[k] = i == 0 || p[k] > hi[k] ? p[k] : hi[k];
        }
    }
    size_t total_tris = 0, nprim = 0;
    for (size_t p = 0; p < d->nparts; p++) {
        for (size_t t = 0; t < 3 * d->parts[p].ntris; t++)
            GS_CHECK(d->parts[p].tris[t] < nv, GS_ERR_ARG, "%s: part %zu uses vertex %u of %zu", path, p,
                     d->parts[p].tris[t], nv);
        total_tris += d->parts[p].ntris;
        nprim += d->parts[p].ntris > 0;
    }
    GS_CHECK(d->nparts == 0 || nprim > 0, GS_ERR_ARG, "%s: a glTF mesh without triangles", path);
    const size_t attr_bytes = 12 * nv;
    const int nattr = 1 + (d->normals != NULL) + (d->vertex_rgb != NULL);
    const size_t bin = (size_t)nattr * attr_bytes + 12 * total_tris;
    GS_CHECK(bin < ((size_t)1 << 31), GS_ERR_ARG, "%s: %zu bytes of mesh data: more than a .glb holds", path,
             bin);

    /* the JSON chunk */
    gs_json j;
    gs_json_init(&j);
    gs_json_begin_object(&j, NULL);
    gs_json_begin_object(&j, "asset");
    gs_json_str(&j, "version", "2.0");
    gs_json_str(&j, "generator", "geosynth");
    gs_json_begin_object(&j, "extras");
    gs_json_str(&j, "up_axis", "z");
    gs_json_str(&j, "stored_as", "y-up (x, z, -y), as glTF asks");
    gs_json_str(&j, "units", d->units ? d->units : "");
    if (d->about)
        gs_json_str(&j, "about", d->about);
    gs_json_i64(&j, "vertices", (int64_t)nv);
    gs_json_i64(&j, "triangles", (int64_t)total_tris);
    gs_json_end_object(&j);
    gs_json_end_object(&j);
    gs_json_i64(&j, "scene", 0);
    gs_json_begin_array(&j, "scenes");
    gs_json_begin_object(&j, NULL);
    gs_json_begin_array(&j, "nodes");
    gs_json_i64(&j, NULL, 0);
    gs_json_end_array(&j);
    gs_json_end_object(&j);
    gs_json_end_array(&j);
    const char *name = d->name ? d->name : "geosynth";
    gs_json_begin_array(&j, "nodes");
    gs_json_begin_object(&j, NULL);
    gs_json_str(&j, "name", name);
    gs_json_i64(&j, "mesh", 0);
    gs_json_end_object(&j);
    gs_json_end_array(&j);
    /* accessors: 0 POSITION, then NORMAL, COLOR_0, then one index list per primitive */
    const int acc_normal = d->normals ? 1 : -1, acc_colour = d->vertex_rgb ? nattr - 1 : -1;
    gs_json_begin_array(&j, "meshes");
    gs_json_begin_object(&j, NULL);
    gs_json_str(&j, "name", name);
    gs_json_begin_array(&j, "primitives");
    for (size_t p = 0, k = 0; p < (d->nparts ? d->nparts : 1); p++) {
        if (d->nparts && d->parts[p].ntris == 0)
            continue;
        gs_json_begin_object(&j, NULL);
        gs_json_begin_object(&j, "attributes");
        gs_json_i64(&j, "POSITION", 0);
        if (acc_normal >= 0)
            gs_json_i64(&j, "NORMAL", acc_normal);
        if (acc_colour >= 0)
            gs_json_i64(&j, "COLOR_0", acc_colour);
        gs_json_end_object(&j);
        if (d->nparts)
            gs_json_i64(&j, "indices", nattr + (int64_t)k);
        gs_json_i64(&j, "material", (int64_t)k);
        gs_json_i64(&j, "mode", d->nparts ? 4 : 0); /* TRIANGLES, POINTS */
        gs_json_end_object(&j);
        k++;
    }
    gs_json_end_array(&j);
    gs_json_end_object(&j);
    gs_json_end_array(&j);
    static const uint8_t grey[3] = {200, 200, 200}, white[3] = {255, 255, 255};
    const uint8_t *plain = d->vertex_rgb ? white : grey;
    gs_json_begin_array(&j, "materials");
    if (!d->nparts)
        material(&j, "points", plain);
    for (size_t p = 0; p < d->nparts; p++)
        if (d->parts[p].ntris)
            material(&j, d->parts[p].name ? d->parts[p].name : "surface",
                     d->parts[p].rgb ? d->parts[p].rgb : plain);
    gs_json_end_array(&j);
    gs_json_begin_array(&j, "accessors");
    accessor(&j, 0, GL_FLOAT, nv, "VEC3", lo, hi);
    for (int a = 1; a < nattr; a++)
        accessor(&j, a, GL_FLOAT, nv, "VEC3", NULL, NULL);
    for (size_t p = 0, k = 0; p < d->nparts; p++)
        if (d->parts[p].ntris)
            accessor(&j, nattr + (int)k++, GL_UNSIGNED_INT, 3 * d->parts[p].ntris, "SCALAR", NULL, NULL);
    gs_json_end_array(&j);
    gs_json_begin_array(&j, "bufferViews");
    size_t off = 0;
    for (int a = 0; a < nattr; a++, off += attr_bytes)
        buffer_view(&j, off, attr_bytes, GL_ARRAY_BUFFER);
    for (size_t p = 0; p < d->nparts; p++)
        if (d->parts[p].ntris) {
            buffer_view(&j, off, 12 * d->parts[p].ntris, GL_ELEMENT_ARRAY_BUFFER);
            off += 12 * d->parts[p].ntris;
        }
    gs_json_end_array(&j);
    gs_json_begin_array(&j, "buffers");
    gs_json_begin_object(&j, NULL);
    gs_json_i64(&j, "byteLength", (int64_t)bin);
    gs_json_end_object(&j);
    gs_json_end_array(&j);
    gs_json_end_object(&j);
    if (j.failed) {
        gs_json_free(&j);
        GS_RAISE(GS_ERR_MEM, "%s: out of memory for the glTF JSON", path);
    }
    const size_t json_len = (j.len + 3) & ~(size_t)3, bin_len = (bin + 3) & ~(size_t)3;

    gs_atomic_file af;
    gs_err err = gs_atomic_begin(path, &af);
    if (err) {
        gs_json_free(&j);
        return err;
    }
    FILE *f = af.f;
    uint8_t h[12];
    put32(h, GLB_MAGIC);
    put32(h + 4, 2);
    put32(h + 8, (uint32_t)(12 + 8 + json_len + 8 + bin_len));
    int ok = fwrite(h, 1, 12, f) == 12;
    put32(h, (uint32_t)json_len);
    put32(h + 4, GLB_CHUNK_JSON);
    ok = ok && fwrite(h, 1, 8, f) == 8 && fwrite(j.buf, 1, j.len, f) == j.len;
    for (size_t i = j.len; ok && i < json_len; i++)
        ok = fputc(' ', f) != EOF;
    gs_json_free(&j);
    put32(h, (uint32_t)bin_len);
    put32(h + 4, GLB_CHUNK_BIN);
    ok = ok && fwrite(h, 1, 8, f) == 8;
    for (size_t i = 0; ok && i < nv; i++) {
        float p[3];
        to_y_up(d->pos + 3 * i, p);
        ok = write_f32x3(f, p);
    }
    for (size_t i = 0; ok && d->normals && i < nv; i++) {
        float n[3];
        to_y_up(d->normals + 3 * i, n);
        ok = write_f32x3(f, n);
    }
    for (size_t i = 0; ok && d->vertex_rgb && i < nv; i++) {
        float c[3];
        for (int k = 0; k < 3; k++)
            c[k] = (float)gs_srgb_to_linear(d->vertex_rgb[3 * i + (size_t)k]);
        ok = write_f32x3(f, c);
    }
    for (size_t p = 0; ok && p < d->nparts; p++)
        for (size_t t = 0; ok && t < 3 * d->parts[p].ntris; t++) {
            uint8_t b[4];
            put32(b, d->parts[p].tris[t]);
            ok = fwrite(b, 1, 4, f) == 4;
        }
    for (size_t i = bin; ok && i < bin_len; i++)
        ok = fputc(0, f) != EOF;
    (void)ok; /* a failed write sets the stream's error flag: the commit names the cause */
    return gs_atomic_commit(&af);
}
