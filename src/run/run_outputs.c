/* summary.json "outputs": one vocabulary of kinds across engines and the
 * dimensions of every output, read back from the written file's header so
 * they describe the file users open (docs/FORMATS.md, "Outputs"). */
#include "geosynth/run.h"

#include <limits.h>
#include <stdio.h>
#include <string.h>

#include "geosynth/digest.h"
#include "geosynth/log.h"
#include "geosynth/mem.h"

struct gs_run_out {
    char kind[16];
    char role[32];
    char *path;
    int have_grid;
    int64_t grid[3];
    int digested;   /* gs_run_outputs_digest covered it: hash is its digest */
    uint64_t hash;
};

void gs_run_output(gs_run *run, const char *kind, const char *role, const char *path,
                   const int64_t grid[3])
{
    if (run->nouts == run->cap_outs) {
        int cap = run->cap_outs ? 2 * run->cap_outs : 16;
        struct gs_run_out *o = gs_realloc(run->outs, (size_t)cap * sizeof *o);
        if (!o) {
            gs_log(GS_LOG_WARN, "out of memory: %s is missing from summary.json outputs", path);
            return;
        }
        run->outs = o;
        run->cap_outs = cap;
    }
    struct gs_run_out *o = &run->outs[run->nouts];
    memset(o, 0, sizeof *o);
    snprintf(o->kind, sizeof o->kind, "%s", kind);
    snprintf(o->role, sizeof o->role, "%s", role);
    size_t n = strlen(path) + 1;
    o->path = gs_malloc(n);
    if (!o->path) {
        gs_log(GS_LOG_WARN, "out of memory: %s is missing from summary.json outputs", path);
        return;
    }
    memcpy(o->path, path, n);
    if (grid) {
        o->have_grid = 1;
        memcpy(o->grid, grid, sizeof o->grid);
    }
    run->nouts++;
}

void gs_run_outputs_free(gs_run *run)
{
    for (int i = 0; i < run->nouts; i++)
        gs_free(run->outs[i].path);
    gs_free(run->outs);
    run->outs = NULL;
    run->nouts = run->cap_outs = 0;
}

static int known_kind(const char *kind)
{
    char list[] = GS_RUN_OUTPUT_KINDS;
    for (char *save = NULL, *w = strtok_r(list, " ", &save); w; w = strtok_r(NULL, " ", &save))
        if (!strcmp(w, kind))
            return 1;
    return 0;
}

static uint32_t be32(const unsigned char *b)
{
    return (uint32_t)b[0] << 24 | (uint32_t)b[1] << 16 | (uint32_t)b[2] << 8 | b[3];
}

/* PNG: width and height from IHDR. */
static int png_size(FILE *f, int64_t wh[2])
{
    unsigned char b[24];
    if (fread(b, 1, sizeof b, f) != sizeof b || memcmp(b, "\x89PNG\r\n\x1a\n", 8) ||
        memcmp(b + 12, "IHDR", 4))
        return 0;
    wh[0] = be32(b + 16);
    wh[1] = be32(b + 20);
    return 1;
}

static uint32_t le32(const unsigned char *b)
{
    return (uint32_t)b[3] << 24 | (uint32_t)b[2] << 16 | (uint32_t)b[1] << 8 | b[0];
}

/* MagicaVoxel .vox: the first SIZE chunk (x, y, z). */
static int vox_size(FILE *f, int64_t xyz[3])
{
    unsigned char b[24];
    if (fread(b, 1, 8, f) != 8 || memcmp(b, "VOX ", 4))
        return 0;
    while (fread(b, 1, 12, f) == 12) {
        uint32_t content = le32(b + 4);
        if (!memcmp(b, "MAIN", 4))
            continue; /* its children follow */
        if (!memcmp(b, "SIZE", 4) && content >= 12 && fread(b + 12, 1, 12, f) == 12) {
            for (int a = 0; a < 3; a++)
                xyz[a] = le32(b + 12 + 4 * a);
            return 1;
        }
        if (fseek(f, (long)content + (long)le32(b + 8), SEEK_CUR))
            return 0;
    }
    return 0;
}

/* PLY: the counts of element vertex and element face from the header. */
static int ply_counts(FILE *f, int64_t *verts, int64_t *faces)
{
    char line[256];
    if (!fgets(line, sizeof line, f) || strncmp(line, "ply", 3))
        return 0;
    *verts = *faces = 0;
    while (fgets(line, sizeof line, f) && strncmp(line, "end_header", 10)) {
        long long n;
        if (sscanf(line, "element vertex %lld", &n) == 1)
            *verts = n;
        else if (sscanf(line, "element face %lld", &n) == 1)
            *faces = n;
    }
    return 1;
}

/* OBJ: counts of v and f lines. */
static int obj_counts(FILE *f, int64_t *verts, int64_t *faces)
{
    char line[512];
    int bol = 1;
    *verts = *faces = 0;
    while (fgets(line, sizeof line, f)) {
        if (bol && line[0] == 'v' && line[1] == ' ')
            (*verts)++;
        else if (bol && line[0] == 'f' && line[1] == ' ')
            (*faces)++;
        bol = strchr(line, '\n') != NULL;
    }
    return 1;
}

/* glTF binary: the counts geosynth's writer puts in asset.extras
 * (include/geosynth/glb.h), from the JSON chunk. */
static int glb_counts(FILE *f, int64_t *verts, int64_t *faces)
{
    unsigned char b[20];
    if (fread(b, 1, sizeof b, f) != sizeof b || memcmp(b, "glTF", 4) || memcmp(b + 16, "JSON", 4))
        return 0;
    const uint32_t n = le32(b + 12);
    if (n > (1u << 24))
        return 0;
    char *json = gs_malloc((size_t)n + 1);
    if (!json)
        return 0;
    int ok = fread(json, 1, n, f) == n;
    json[ok ? n : 0] = '\0';
    const char *x = ok ? strstr(json, "\"extras\":{") : NULL;
    const char *v = x ? strstr(x, "\"vertices\":") : NULL, *t = x ? strstr(x, "\"triangles\":") : NULL;
    long long nv = -1, nt = -1;
    ok = v && t && sscanf(v, "\"vertices\":%lld", &nv) == 1 && sscanf(t, "\"triangles\":%lld", &nt) == 1;
    gs_free(json);
    *verts = nv;
    *faces = nt;
    return ok;
}

/* The outputs left out of the run digest, by kind, and why
 * (docs/FORMATS.md "Digest"). NULL: covered. */
static const char *digest_excluded(const char *kind)
{
    if (!strcmp(kind, "json") || !strcmp(kind, "html"))
        return "a report: it holds seconds measured by the run, and measures of outputs the "
               "digest covers";
    if (!strcmp(kind, "config"))
        return "a config to re-run from: it holds the run directory's path; what it produces "
               "is covered";
    return NULL;
}

/* OpenVDB writes a random UUID (36 characters after the 21-byte header:
 * magic, file and library versions, grid-offsets flag) into every file;
 * the digest reads it as zeros. */
#define VDB_UUID_OFFSET 21
#define VDB_UUID_LEN 36

static gs_err vdb_digest(const char *path, uint64_t *hash)
{
    FILE *f = fopen(path, "rb");
    GS_CHECK(f != NULL, GS_ERR_IO, "output %s cannot be read back for the digest", path);
    gs_digest dg;
    if (!gs_digest_init(&dg)) {
        fclose(f);
        GS_RAISE(GS_ERR_MEM, "out of memory for the digest of %s", path);
    }
    unsigned char buf[65536];
    size_t n, off = 0;
    while ((n = fread(buf, 1, sizeof buf, f)) > 0) {
        for (size_t i = 0; i < n; i++)
            if (off + i >= VDB_UUID_OFFSET && off + i < VDB_UUID_OFFSET + VDB_UUID_LEN)
                buf[i] = 0;
        gs_digest_update(&dg, buf, n);
        off += n;
    }
    int bad = ferror(f);
    fclose(f);
    uint64_t h = gs_digest_final(&dg);
    GS_CHECK(!bad, GS_ERR_IO, "output %s cannot be read back for the digest", path);
    *hash = h;
    return GS_OK;
}

gs_err gs_run_outputs_digest(gs_run *run, uint64_t engine_digest, uint64_t *digest)
{
    gs_digest dg;
    GS_CHECK(gs_digest_init(&dg), GS_ERR_MEM, "out of memory for the run digest");
    gs_digest_update(&dg, &engine_digest, sizeof engine_digest);
    gs_err err = GS_OK;
    for (int i = 0; i < run->nouts && !err; i++) {
        struct gs_run_out *o = &run->outs[i];
        o->digested = 0;
        if (digest_excluded(o->kind))
            continue;
        char full[PATH_MAX];
        if (o->path[0] == '/')
            snprintf(full, sizeof full, "%s", o->path);
        else
            gs_run_path(run, o->path, full, sizeof full);
        uint64_t bytes;
        if (!strcmp(o->kind, "h5"))
            err = gs_h5_content_digest(full, &o->hash);
        else if (!strcmp(o->kind, "vdb"))
            err = vdb_digest(full, &o->hash);
        else
            err = gs_digest_file(full, &o->hash, &bytes);
        if (err)
            break;
        o->digested = 1;
        gs_digest_update(&dg, o->path, strlen(o->path) + 1);
        gs_digest_update(&dg, &o->hash, sizeof o->hash);
    }
    uint64_t h = gs_digest_final(&dg);
    if (!err)
        *digest = h;
    return err;
}

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcmp(s + n - m, suffix);
}

gs_err gs_run_outputs_json(const gs_run *run, gs_json *j, const char *key)
{
    gs_json_begin_array(j, key);
    for (int i = 0; i < run->nouts; i++) {
        const struct gs_run_out *o = &run->outs[i];
        GS_CHECK(known_kind(o->kind), GS_ERR_INTERNAL,
                 "output %s: kind '%s' is not one of: " GS_RUN_OUTPUT_KINDS, o->path, o->kind);
        gs_json_begin_object(j, NULL);
        gs_json_str(j, "kind", o->kind);
        gs_json_str(j, "role", o->role);
        gs_json_str(j, "path", o->path);
        if (o->digested) {
            char hex[17];
            gs_digest_hex(o->hash, hex);
            gs_json_str(j, "digest", hex);
        } else {
            const char *why = digest_excluded(o->kind);
            gs_json_str(j, "digest_excluded", why ? why : "not read (the run failed first)");
        }
        char full[PATH_MAX];
        if (o->path[0] == '/')
            snprintf(full, sizeof full, "%s", o->path);
        else
            gs_run_path(run, o->path, full, sizeof full);
        FILE *f = fopen(full, "rb");
        GS_CHECK(f != NULL, GS_ERR_IO, "output %s listed in summary.json was not written", full);
        int64_t grid[3];
        int have_grid = o->have_grid;
        memcpy(grid, o->grid, sizeof grid);
        if (!have_grid && !strcmp(o->kind, "vox"))
            have_grid = vox_size(f, grid);
        if (have_grid) {
            gs_json_begin_array(j, "dimensions");
            for (int a = 0; a < 3; a++)
                gs_json_i64(j, NULL, grid[a]);
            gs_json_end_array(j);
        }
        rewind(f);
        int64_t a = 0, b = 0;
        int mesh = !strcmp(o->kind, "mesh"), points = !strcmp(o->kind, "points");
        int64_t wh[2];
        if ((!strcmp(o->kind, "image") || !strcmp(o->kind, "preview")) && png_size(f, wh)) {
            gs_json_begin_array(j, "pixels");
            gs_json_i64(j, NULL, wh[0]);
            gs_json_i64(j, NULL, wh[1]);
            gs_json_end_array(j);
        } else if ((mesh || points) &&
                   (ends_with(o->path, ".ply") ? ply_counts(f, &a, &b)
                    : ends_with(o->path, ".obj") ? obj_counts(f, &a, &b)
                    : ends_with(o->path, ".glb") ? glb_counts(f, &a, &b)
                                                 : 0)) {
            gs_json_i64(j, points ? "points" : "vertices", a);
            if (mesh)
                gs_json_i64(j, "faces", b);
        }
        fclose(f);
        gs_json_end_object(j);
    }
    gs_json_end_array(j);
    return GS_OK;
}
