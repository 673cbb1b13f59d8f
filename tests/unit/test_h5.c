/* Unit tests for the HDF5 layer (src/io/h5_*.c, xdmf.c, inspect.c), np 1:
 * round trips of every type and attribute kind, atomic replacement, and
 * rejection of damaged, foreign, newer, mismatched and missing files, each
 * with its gs_err code and a message naming the path. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>
#include <hdf5.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "geosynth/error.h"
#include "geosynth/h5.h"
#include "geosynth/mem.h"
#include "geosynth/par.h"
#include "geosynth/version.h"

static char tmpdir[256];

static void tpath(char *buf, size_t n, const char *name)
{
    snprintf(buf, n, "%s/%s", tmpdir, name);
}

/* Asserts the last call failed with code and a message containing each
 * non-NULL needle, then clears the error. */
static void expect_error(gs_err got, gs_err want, const char *needle1, const char *needle2)
{
    const char *msg = gs_error_message();
    if (got != want || (needle1 && !strstr(msg, needle1)) || (needle2 && !strstr(msg, needle2)))
        fail_msg("expected code %d with '%s' and '%s', got %d: %s", want, needle1 ? needle1 : "",
                 needle2 ? needle2 : "", got, msg);
    gs_error_clear();
}

static const gs_h5_type all_types[] = {GS_H5_F32, GS_H5_F64, GS_H5_U8, GS_H5_U16,
                                       GS_H5_I32, GS_H5_I64, GS_H5_U64};

/* Element i of the test pattern for type t (depends on a salt k). */
static void pattern(gs_h5_type t, void *buf, size_t n, int64_t k)
{
    for (size_t i = 0; i < n; i++) {
        int64_t v = (int64_t)i + 31 * k;
        switch (t) {
        case GS_H5_F32: ((float *)buf)[i] = (float)v * 0.5f - 3.0f; break;
        case GS_H5_F64: ((double *)buf)[i] = (double)v * 1e-3 + 1e10; break;
        case GS_H5_U8: ((uint8_t *)buf)[i] = (uint8_t)(v * 7); break;
        case GS_H5_U16: ((uint16_t *)buf)[i] = (uint16_t)(v * 131); break;
        case GS_H5_I32: ((int32_t *)buf)[i] = (int32_t)(v * -1000003); break;
        case GS_H5_I64: ((int64_t *)buf)[i] = v * -((int64_t)1 << 40); break;
        case GS_H5_U64: ((uint64_t *)buf)[i] = UINT64_MAX - (uint64_t)v; break;
        }
    }
}

static const char *sample_config =
    "[run]\nengine = field\nseed = 42\n\n[field]\nblock = 8\nlevels = 3\n";

/* Writes a small checkpoint of engine `engine` holding one 3D array per
 * type (dims 5x4x3), k as attribute /state@k. */
static void write_sample(MPI_Comm comm, const char *path, const char *engine, int64_t k)
{
    gs_ckpt_meta meta = {engine, 1234567890123ULL, sample_config};
    gs_ckpt_t h = NULL;
    assert_int_equal(gs_ckpt_create(comm, path, &meta, &h), GS_OK);
    for (size_t t = 0; t < sizeof all_types / sizeof all_types[0]; t++) {
        gs_h5_shape s = {all_types[t], 3, {5, 4, 3}};
        void *buf = gs_calloc(60, 8);
        pattern(all_types[t], buf, 60, k);
        char name[64];
        snprintf(name, sizeof name, "/%s/arr_%s", engine, gs_h5_type_name(all_types[t]));
        /* Whole for even types, slab (serial: all rows) for odd ones. */
        if (t % 2)
            assert_int_equal(gs_ckpt_write_whole(h, name, &s, buf, NULL), GS_OK);
        else
            assert_int_equal(gs_ckpt_write_slab(h, name, &s, 0, 5, buf, NULL), GS_OK);
        gs_free(buf);
    }
    assert_int_equal(gs_ckpt_set_i64(h, "/state", "k", k), GS_OK);
    assert_int_equal(gs_ckpt_commit(&h), GS_OK);
    assert_null(h);
}

static void check_sample(gs_ckpt_t h, const char *engine, int64_t k)
{
    for (size_t t = 0; t < sizeof all_types / sizeof all_types[0]; t++) {
        gs_h5_shape s = {all_types[t], 3, {5, 4, 3}}, got;
        char name[64];
        snprintf(name, sizeof name, "/%s/arr_%s", engine, gs_h5_type_name(all_types[t]));
        assert_int_equal(gs_ckpt_shape(h, name, &got), GS_OK);
        assert_int_equal(got.type, s.type);
        assert_int_equal(got.rank, 3);
        assert_true(got.dims[0] == 5 && got.dims[1] == 4 && got.dims[2] == 3);
        size_t es = gs_h5_type_size(s.type);
        void *want = gs_calloc(60, 8), *buf = gs_calloc(60, 8);
        pattern(s.type, want, 60, k);
        assert_int_equal(gs_ckpt_read_whole(h, name, &s, buf), GS_OK);
        assert_memory_equal(buf, want, 60 * es);
        memset(buf, 0, 60 * 8);
        /* Rows 2..3 only. */
        assert_int_equal(gs_ckpt_read_slab(h, name, &s, 2, 2, buf), GS_OK);
        assert_memory_equal(buf, (char *)want + 2 * 12 * es, 24 * es);
        gs_free(want);
        gs_free(buf);
    }
    int64_t kk = -1;
    assert_int_equal(gs_ckpt_get_i64(h, "/state", "k", &kk), GS_OK);
    assert_int_equal(kk, k);
}

static void test_roundtrip_all_types(void **state)
{
    (void)state;
    char path[512];
    MPI_Comm comms[2] = {MPI_COMM_WORLD, MPI_COMM_NULL};
    for (int c = 0; c < 2; c++) {
        tpath(path, sizeof path, c ? "serial.h5" : "parallel.h5");
        write_sample(comms[c], path, "field", 7 + c);
        gs_ckpt_t h = NULL;
        assert_int_equal(gs_ckpt_open(comms[c], path, "field", &h), GS_OK);
        assert_string_equal(gs_ckpt_engine(h), "field");
        assert_string_equal(gs_ckpt_program_version(h), GS_VERSION_STRING);
        assert_string_equal(gs_ckpt_config(h), sample_config);
        assert_int_equal(gs_ckpt_format_version(h), GS_FORMAT_VERSION);
        assert_true(gs_ckpt_seed(h) == 1234567890123ULL);
        assert_int_equal(strlen(gs_ckpt_created(h)), 20); /* 2024-05-01T12:00:00Z */
        assert_int_equal(gs_ckpt_created(h)[19], 'Z');
        check_sample(h, "field", 7 + c);
        assert_int_equal(gs_ckpt_close(&h), GS_OK);
        assert_null(h);
    }
}

static void test_attributes(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "attrs.h5");
    gs_ckpt_meta meta = {"model", UINT64_MAX, NULL};
    gs_ckpt_t h = NULL;
    assert_int_equal(gs_ckpt_create(MPI_COMM_WORLD, path, &meta, &h), GS_OK);
    assert_int_equal(gs_ckpt_set_i64(h, "/model/state", "iteration", -5), GS_OK);
    assert_int_equal(gs_ckpt_set_i64(h, "/model/state", "iteration", INT64_MIN), GS_OK); /* replace */
    assert_int_equal(gs_ckpt_set_u64(h, "/model/state", "rng_counter", UINT64_MAX), GS_OK);
    assert_int_equal(gs_ckpt_set_f64(h, "/model", "temperature", -0.125e-300), GS_OK);
    assert_int_equal(gs_ckpt_set_str(h, "/model", "phase", "assembly"), GS_OK);
    assert_int_equal(gs_ckpt_set_str(h, "/model", "empty", ""), GS_OK);
    /* Attributes on a dataset too. */
    uint8_t lab[4] = {1, 2, 3, 4};
    gs_h5_shape s = {GS_H5_U8, 1, {4}};
    assert_int_equal(gs_ckpt_write_whole(h, "/model/labels", &s, lab, NULL), GS_OK);
    assert_int_equal(gs_ckpt_set_i64(h, "/model/labels", "n_labels", 4), GS_OK);
    /* Too long a string attribute is refused with the limit named. */
    char *big = gs_calloc(70000, 1);
    memset(big, 'x', 69999);
    expect_error(gs_ckpt_set_str(h, "/model", "big", big), GS_ERR_ARG, "60000", path);
    gs_free(big);
    assert_int_equal(gs_ckpt_commit(&h), GS_OK);

    assert_int_equal(gs_ckpt_open(MPI_COMM_NULL, path, "model", &h), GS_OK);
    assert_string_equal(gs_ckpt_config(h), "");
    assert_true(gs_ckpt_seed(h) == UINT64_MAX);
    int64_t i = 0;
    uint64_t u = 0;
    double f = 0;
    char *str = NULL;
    assert_int_equal(gs_ckpt_get_i64(h, "/model/state", "iteration", &i), GS_OK);
    assert_true(i == INT64_MIN);
    assert_int_equal(gs_ckpt_get_u64(h, "/model/state", "rng_counter", &u), GS_OK);
    assert_true(u == UINT64_MAX);
    assert_int_equal(gs_ckpt_get_f64(h, "/model", "temperature", &f), GS_OK);
    assert_true(f == -0.125e-300);
    assert_int_equal(gs_ckpt_get_str(h, "/model", "phase", &str), GS_OK);
    assert_string_equal(str, "assembly");
    gs_free(str);
    assert_int_equal(gs_ckpt_get_str(h, "/model", "empty", &str), GS_OK);
    assert_string_equal(str, "");
    gs_free(str);
    assert_int_equal(gs_ckpt_get_i64(h, "/model/labels", "n_labels", &i), GS_OK);
    assert_int_equal(i, 4);
    /* Kind mismatches and missing things: GS_ERR_FORMAT, path named. */
    expect_error(gs_ckpt_get_i64(h, "/model/state", "rng_counter", &i), GS_ERR_FORMAT,
                 "does not fit in int64", path);
    expect_error(gs_ckpt_get_u64(h, "/model/state", "iteration", &u), GS_ERR_FORMAT, "negative",
                 path);
    expect_error(gs_ckpt_get_f64(h, "/model/state", "iteration", &f), GS_ERR_FORMAT,
                 "floating-point", path);
    expect_error(gs_ckpt_get_str(h, "/model/state", "iteration", &str), GS_ERR_FORMAT,
                 "not a string", path);
    expect_error(gs_ckpt_get_i64(h, "/model/state", "nope", &i), GS_ERR_FORMAT, "missing", path);
    expect_error(gs_ckpt_get_i64(h, "/nowhere/deep", "k", &i), GS_ERR_FORMAT, "/nowhere/deep",
                 path);
    assert_true(i == 4 && u == UINT64_MAX); /* unchanged on failure */
    int ex = -1;
    assert_int_equal(gs_ckpt_exists(h, "/model/labels", &ex), GS_OK);
    assert_int_equal(ex, 1);
    assert_int_equal(gs_ckpt_exists(h, "/model/labels/x/y", &ex), GS_OK);
    assert_int_equal(ex, 0);
    /* Setters refuse a read handle. */
    expect_error(gs_ckpt_set_i64(h, "/model", "x", 1), GS_ERR_ARG, "not open for writing", path);
    gs_ckpt_close(&h);
}

static void test_deflate_chunked(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "deflate.h5");
    gs_ckpt_meta meta = {"field", 1, "x = 1\n"};
    gs_ckpt_t h = NULL;
    enum { NZ = 20, NY = 33, NX = 17 };
    float *a = gs_calloc(NZ * NY * NX, sizeof *a), *b = gs_calloc(NZ * NY * NX, sizeof *b);
    for (int i = 0; i < NZ * NY * NX; i++)
        a[i] = (float)(i % 97) * 0.25f;
    gs_h5_shape s = {GS_H5_F32, 3, {NZ, NY, NX}};
    gs_h5_write_opts auto_chunks = {6, 0}, small_chunks = {1, 3}, chunks_only = {0, 7};
    assert_int_equal(gs_ckpt_create(MPI_COMM_WORLD, path, &meta, &h), GS_OK);
    assert_int_equal(gs_ckpt_write_slab(h, "/field/a", &s, 0, NZ, a, &auto_chunks), GS_OK);
    assert_int_equal(gs_ckpt_write_slab(h, "/field/b", &s, 0, NZ, a, &small_chunks), GS_OK);
    assert_int_equal(gs_ckpt_write_slab(h, "/field/c", &s, 0, NZ, a, &chunks_only), GS_OK);
    /* Writing a dataset twice and a bad deflate level are refused. */
    expect_error(gs_ckpt_write_slab(h, "/field/c", &s, 0, NZ, a, NULL), GS_ERR_ARG,
                 "already exists", path);
    gs_h5_write_opts bad = {12, 0};
    expect_error(gs_ckpt_write_slab(h, "/field/d", &s, 0, NZ, a, &bad), GS_ERR_ARG, "deflate",
                 path);
    /* A serial slab must cover every row. */
    expect_error(gs_ckpt_write_slab(h, "/field/e", &s, 1, NZ - 1, a, NULL), GS_ERR_ARG,
                 "rows [0, 20)", path);
    assert_int_equal(gs_ckpt_commit(&h), GS_OK);
    assert_int_equal(gs_ckpt_open(MPI_COMM_WORLD, path, "field", &h), GS_OK);
    const char *names[] = {"/field/a", "/field/b", "/field/c"};
    for (int i = 0; i < 3; i++) {
        memset(b, 0, sizeof(float) * NZ * NY * NX);
        assert_int_equal(gs_ckpt_read_whole(h, names[i], &s, b), GS_OK);
        assert_memory_equal(a, b, sizeof(float) * NZ * NY * NX);
    }
    gs_ckpt_close(&h);
    char *text = NULL;
    size_t len = 0;
    FILE *out = open_memstream(&text, &len);
    assert_int_equal(gs_inspect_file(path, out), GS_OK);
    fclose(out);
    assert_non_null(strstr(text, "deflate"));
    assert_non_null(strstr(text, "chunks 7x33x17"));
    free(text);
    gs_free(a);
    gs_free(b);
}

static int64_t read_k(const char *path)
{
    gs_ckpt_t h = NULL;
    assert_int_equal(gs_ckpt_open(MPI_COMM_WORLD, path, "field", &h), GS_OK);
    int64_t k = -1;
    assert_int_equal(gs_ckpt_get_i64(h, "/state", "k", &k), GS_OK);
    check_sample(h, "field", k);
    gs_ckpt_close(&h);
    return k;
}

static void test_atomic_replace(void **state)
{
    (void)state;
    char path[512], tmp[520];
    tpath(path, sizeof path, "atomic.h5");
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    write_sample(MPI_COMM_WORLD, path, "field", 1);
    assert_int_equal(read_k(path), 1);
    /* An abandoned write leaves the old file and no .tmp. */
    gs_ckpt_meta meta = {"field", 1, ""};
    gs_ckpt_t h = NULL;
    assert_int_equal(gs_ckpt_create(MPI_COMM_WORLD, path, &meta, &h), GS_OK);
    assert_int_equal(access(tmp, F_OK), 0);
    assert_int_equal(read_k(path), 1); /* old file readable while the new one is written */
    gs_ckpt_discard(&h);
    assert_null(h);
    assert_int_equal(access(tmp, F_OK), -1);
    assert_int_equal(read_k(path), 1);
    /* A stale, garbage .tmp from a killed run does not get in the way. */
    FILE *f = fopen(tmp, "w");
    fputs("half a checkpoint", f);
    fclose(f);
    write_sample(MPI_COMM_WORLD, path, "field", 2);
    assert_int_equal(access(tmp, F_OK), -1);
    assert_int_equal(read_k(path), 2);
}

static void test_truncated(void **state)
{
    (void)state;
    char path[512], cut[512];
    tpath(path, sizeof path, "full.h5");
    tpath(cut, sizeof cut, "cut.h5");
    write_sample(MPI_COMM_NULL, path, "field", 3);
    FILE *f = fopen(path, "rb");
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *bytes = gs_malloc((size_t)size);
    assert_int_equal(fread(bytes, 1, (size_t)size, f), (size_t)size);
    fclose(f);
    long offsets[] = {0, 4, 8, 12, 40, 95, 200, 512, 1000, 2048, size / 3, size / 2,
                      size - 100, size - 1};
    for (size_t i = 0; i < sizeof offsets / sizeof offsets[0]; i++) {
        f = fopen(cut, "wb");
        fwrite(bytes, 1, (size_t)offsets[i], f);
        fclose(f);
        gs_ckpt_t h = NULL;
        gs_err err = gs_ckpt_open(MPI_COMM_WORLD, cut, "field", &h);
        if (err != GS_ERR_FORMAT || !strstr(gs_error_message(), cut))
            fail_msg("cut at %ld of %ld: code %d: %s", offsets[i], size, err, gs_error_message());
        assert_null(h);
        gs_error_clear();
        char eng[32] = "unchanged";
        expect_error(gs_ckpt_peek(cut, eng, sizeof eng, NULL), GS_ERR_FORMAT, cut, NULL);
        assert_string_equal(eng, "unchanged");
        char *text = NULL;
        size_t len = 0;
        FILE *out = open_memstream(&text, &len);
        expect_error(gs_inspect_file(cut, out), GS_ERR_FORMAT, cut, NULL);
        fclose(out);
        free(text);
    }
    /* The superblock check names the sizes for a cut past the header. */
    f = fopen(cut, "wb");
    fwrite(bytes, 1, (size_t)size / 2, f);
    fclose(f);
    gs_ckpt_t h = NULL;
    expect_error(gs_ckpt_open(MPI_COMM_NULL, cut, NULL, &h), GS_ERR_FORMAT, "truncated", cut);
    gs_free(bytes);
}

static void test_foreign_hdf5(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "foreign.h5");
    hid_t f = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    hsize_t dims[2] = {3, 4};
    hid_t sp = H5Screate_simple(2, dims, NULL);
    hid_t g = H5Gcreate2(f, "/results", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    hid_t d = H5Dcreate2(g, "temperature", H5T_IEEE_F64LE, sp, H5P_DEFAULT, H5P_DEFAULT,
                         H5P_DEFAULT);
    double v[12];
    for (int i = 0; i < 12; i++)
        v[i] = i - 2.5;
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
    H5Dclose(d);
    H5Gclose(g);
    H5Sclose(sp);
    H5Fclose(f);
    gs_ckpt_t h = NULL;
    expect_error(gs_ckpt_open(MPI_COMM_WORLD, path, NULL, &h), GS_ERR_FORMAT,
                 "not a geosynth file (HDF5 superblock version 0", path);
    char eng[32];
    expect_error(gs_ckpt_peek(path, eng, sizeof eng, NULL), GS_ERR_FORMAT, "not a geosynth file",
                 path);
    /* inspect still lists the structure. */
    char *text = NULL;
    size_t len = 0;
    FILE *out = open_memstream(&text, &len);
    expect_error(gs_inspect_file(path, out), GS_ERR_FORMAT, "not a geosynth file", path);
    fclose(out);
    assert_non_null(strstr(text, "/results/temperature"));
    assert_non_null(strstr(text, "float64 [3 x 4]"));
    assert_non_null(strstr(text, "min -2.5  max 8.5  mean 3"));
    free(text);
    /* In the 1.10 format too: the missing group is what is reported. */
    tpath(path, sizeof path, "foreign110.h5");
    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    H5Pset_libver_bounds(fapl, H5F_LIBVER_V110, H5F_LIBVER_V110);
    f = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, fapl);
    H5Pclose(fapl);
    g = H5Gcreate2(f, "/other", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Gclose(g);
    H5Fclose(f);
    expect_error(gs_ckpt_open(MPI_COMM_NULL, path, NULL, &h), GS_ERR_FORMAT,
                 "not a geosynth file (no /geosynth group)", path);
}

static void test_wrong_engine_and_newer_format(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "model.h5");
    write_sample(MPI_COMM_WORLD, path, "model", 0);
    gs_ckpt_t h = NULL;
    expect_error(gs_ckpt_open(MPI_COMM_WORLD, path, "field", &h), GS_ERR_FORMAT,
                 "is a 'model' checkpoint, expected 'field'", path);
    assert_null(h);
    /* Bump the format version behind geosynth's back. */
    hid_t f = H5Fopen(path, H5F_ACC_RDWR, H5P_DEFAULT);
    hid_t g = H5Gopen2(f, "/geosynth", H5P_DEFAULT);
    hid_t a = H5Aopen(g, "format_version", H5P_DEFAULT);
    int32_t three = GS_FORMAT_VERSION + 2;
    H5Awrite(a, H5T_NATIVE_INT32, &three);
    H5Aclose(a);
    H5Gclose(g);
    H5Fclose(f);
    char want[600];
    snprintf(want, sizeof want,
             "%s was written by format version %d; this geosynth reads up to %d: upgrade geosynth",
             path, GS_FORMAT_VERSION + 2, GS_FORMAT_VERSION);
    expect_error(gs_ckpt_open(MPI_COMM_WORLD, path, "model", &h), GS_ERR_FORMAT, want, NULL);
    char eng[32];
    expect_error(gs_ckpt_peek(path, eng, sizeof eng, NULL), GS_ERR_FORMAT, want, NULL);
}

static void test_wrong_dims_and_type(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "dims.h5");
    write_sample(MPI_COMM_WORLD, path, "field", 4);
    gs_ckpt_t h = NULL;
    assert_int_equal(gs_ckpt_open(MPI_COMM_WORLD, path, "field", &h), GS_OK);
    float buf[200];
    gs_h5_shape dims = {GS_H5_F32, 3, {5, 4, 4}};
    expect_error(gs_ckpt_read_whole(h, "/field/arr_float32", &dims, buf), GS_ERR_FORMAT,
                 "is float32 [5 x 4 x 3]: expected float32 [5 x 4 x 4]", path);
    gs_h5_shape rank = {GS_H5_F32, 2, {20, 3}};
    expect_error(gs_ckpt_read_slab(h, "/field/arr_float32", &rank, 0, 1, buf), GS_ERR_FORMAT,
                 "expected float32 [20 x 3]", path);
    gs_h5_shape type = {GS_H5_F64, 3, {5, 4, 3}};
    expect_error(gs_ckpt_read_whole(h, "/field/arr_float32", &type, buf), GS_ERR_FORMAT,
                 "expected float64 [5 x 4 x 3]", path);
    gs_h5_shape ok = {GS_H5_F32, 3, {5, 4, 3}};
    expect_error(gs_ckpt_read_whole(h, "/field/nothing", &ok, buf), GS_ERR_FORMAT,
                 "/field/nothing is missing", path);
    expect_error(gs_ckpt_read_whole(h, "/field", &ok, buf), GS_ERR_FORMAT,
                 "not a readable dataset", path);
    expect_error(gs_ckpt_read_slab(h, "/field/arr_float32", &ok, 4, 2, buf), GS_ERR_ARG,
                 "outside [0, 5)", path);
    gs_h5_shape s;
    expect_error(gs_ckpt_shape(h, "/geosynth/config", &s), GS_ERR_FORMAT, "string", path);
    gs_ckpt_close(&h);
}

static void test_text_missing_unwritable(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "notes.h5");
    FILE *f = fopen(path, "w");
    fputs("this is a text file, renamed .h5\nsecond line\n", f);
    fclose(f);
    gs_ckpt_t h = NULL;
    expect_error(gs_ckpt_open(MPI_COMM_WORLD, path, "field", &h), GS_ERR_FORMAT,
                 "not an HDF5 file", path);
    tpath(path, sizeof path, "empty.h5");
    fclose(fopen(path, "w"));
    expect_error(gs_ckpt_open(MPI_COMM_NULL, path, "field", &h), GS_ERR_FORMAT, "empty", path);

    tpath(path, sizeof path, "does-not-exist.h5");
    expect_error(gs_ckpt_open(MPI_COMM_WORLD, path, "field", &h), GS_ERR_IO,
                 "No such file or directory", path);
    char eng[32];
    expect_error(gs_ckpt_peek(path, eng, sizeof eng, NULL), GS_ERR_IO, path, NULL);
    expect_error(gs_inspect_file(path, stderr), GS_ERR_IO, path, NULL);
    tpath(path, sizeof path, ".");
    expect_error(gs_ckpt_open(MPI_COMM_NULL, path, "field", &h), GS_ERR_IO, "not a regular file",
                 path);

    /* A directory that cannot hold files: a regular file in the way (works
     * as root too), and a read-only directory when not root. */
    gs_ckpt_meta meta = {"field", 1, ""};
    tpath(path, sizeof path, "notes.h5/ckpt.h5");
    expect_error(gs_ckpt_create(MPI_COMM_WORLD, path, &meta, &h), GS_ERR_IO, path,
                 "Not a directory");
    assert_null(h);
    if (geteuid() != 0) {
        char dir[512];
        tpath(dir, sizeof dir, "readonly");
        mkdir(dir, 0500);
        tpath(path, sizeof path, "readonly/ckpt.h5");
        expect_error(gs_ckpt_create(MPI_COMM_WORLD, path, &meta, &h), GS_ERR_IO, path,
                     "Permission denied");
        chmod(dir, 0700);
    }
    gs_ckpt_meta badmeta = {"Field!", 1, ""};
    tpath(path, sizeof path, "x.h5");
    expect_error(gs_ckpt_create(MPI_COMM_WORLD, path, &badmeta, &h), GS_ERR_ARG, "a-z", path);
}

static void test_peek(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "peek.h5");
    write_sample(MPI_COMM_WORLD, path, "points", 0);
    char eng[GS_H5_ENGINE_MAX] = "";
    char *cfg = NULL;
    assert_int_equal(gs_ckpt_peek(path, eng, sizeof eng, &cfg), GS_OK);
    assert_string_equal(eng, "points");
    assert_string_equal(cfg, sample_config);
    gs_free(cfg);
    char small[4];
    expect_error(gs_ckpt_peek(path, small, sizeof small, NULL), GS_ERR_ARG, "does not fit", path);
}

static void test_inspect(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "inspect.h5");
    gs_ckpt_meta meta = {"field", 99, NULL};
    char cfg[4000] = "";
    for (int i = 0; i < 100; i++)
        snprintf(cfg + strlen(cfg), sizeof cfg - strlen(cfg), "key%d = %d\n", i, i);
    meta.config_text = cfg;
    gs_ckpt_t h = NULL;
    assert_int_equal(gs_ckpt_create(MPI_COMM_WORLD, path, &meta, &h), GS_OK);
    enum { N = 300000 };
    double *v = gs_calloc(N, sizeof *v);
    for (int i = 0; i < N; i++)
        v[i] = i % 1000 == 0 ? -7.0 : (double)(i % 10); /* min -7 sits on a sampled point */
    gs_h5_shape s = {GS_H5_F64, 2, {N / 100, 100}};
    assert_int_equal(gs_ckpt_write_whole(h, "/field/big", &s, v, NULL), GS_OK);
    assert_int_equal(gs_ckpt_set_i64(h, "/field", "iteration", 12), GS_OK);
    assert_int_equal(gs_ckpt_set_str(h, "/field", "phase", "refine"), GS_OK);
    assert_int_equal(gs_ckpt_commit(&h), GS_OK);
    gs_free(v);
    char *text = NULL;
    size_t len = 0;
    FILE *out = open_memstream(&text, &len);
    gs_inspect_opts opts = {3, 10000};
    assert_int_equal(gs_inspect_file_opts(path, out, &opts), GS_OK);
    fclose(out);
    const char *want[] = {"geosynth file, format version 1", "engine:          field",
                          "seed:            99", "program_version: " GS_VERSION_STRING,
                          "config:          100 lines", "| key2 = 2", "97 more lines not shown",
                          "/field/big", "float64 [3000 x 100]", "min -7  max 5",
                          "[sampled", "@iteration = 12 (int64)", "@phase = \"refine\""};
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
        if (!strstr(text, want[i]))
            fail_msg("inspect output lacks '%s':\n%s", want[i], text);
    assert_null(strstr(text, "key3 = 3"));
    free(text);
    /* Full config and no sampling with the defaults. */
    out = open_memstream(&text, &len);
    gs_inspect_opts all = {0, 1 << 22};
    assert_int_equal(gs_inspect_file_opts(path, out, &all), GS_OK);
    fclose(out);
    assert_non_null(strstr(text, "| key99 = 99"));
    assert_null(strstr(text, "[sampled"));
    assert_non_null(strstr(text, "min -7  max 9  mean 4.493\n"));
    free(text);
}

/* ---- a minimal XML checker for the XDMF test ------------------------------ */

typedef struct xml_facts {
    char topo_type[64], topo_dims[64], center[16];
    char item_dims[4][64], item_text[4][256];
    int items;
} xml_facts;

/* Well-formedness: balanced tags, quoted attributes, valid entities, one
 * root. Collects the Topology and the HDF DataItems. Returns NULL when
 * well-formed, else a reason. */
static const char *xml_check(const char *s, xml_facts *x)
{
    char stack[16][32];
    int depth = 0, roots = 0;
    char cur_tag[32] = "", cur_format[16] = "";
    memset(x, 0, sizeof *x);
    while (*s) {
        if (*s != '<') {
            const char *start = s;
            while (*s && *s != '<') {
                if (*s == '&' && strncmp(s, "&amp;", 5) && strncmp(s, "&lt;", 4) &&
                    strncmp(s, "&gt;", 4) && strncmp(s, "&quot;", 6) && strncmp(s, "&apos;", 6))
                    return "bad entity";
                s++;
            }
            if (depth == 0) {
                for (const char *p = start; p < s; p++)
                    if (*p != ' ' && *p != '\n')
                        return "text outside the root";
            } else if (strcmp(cur_tag, "DataItem") == 0 && strcmp(cur_format, "HDF") == 0 &&
                       x->items < 4) {
                size_t n = (size_t)(s - start);
                snprintf(x->item_text[x->items - 1], 256, "%.*s", (int)n, start);
            }
            continue;
        }
        if (!strncmp(s, "<?", 2)) {
            s = strstr(s, "?>");
            if (!s)
                return "unterminated <?";
            s += 2;
            continue;
        }
        if (!strncmp(s, "<!", 2)) {
            s = strchr(s, '>');
            if (!s)
                return "unterminated <!";
            s++;
            continue;
        }
        int closing = s[1] == '/';
        s += closing ? 2 : 1;
        char name[32];
        size_t n = 0;
        while (*s && (('A' <= *s && *s <= 'Z') || ('a' <= *s && *s <= 'z')) && n < 31)
            name[n++] = *s++;
        name[n] = '\0';
        if (!n)
            return "empty tag name";
        if (closing) {
            if (*s != '>' || depth == 0 || strcmp(stack[depth - 1], name) != 0)
                return "mismatched closing tag";
            depth--;
            s++;
            cur_tag[0] = '\0';
            continue;
        }
        if (depth == 0 && roots++)
            return "two roots";
        snprintf(cur_tag, sizeof cur_tag, "%s", name);
        cur_format[0] = '\0';
        int is_item = !strcmp(name, "DataItem");
        char item_dims[64] = "";
        for (;;) {
            while (*s == ' ' || *s == '\n')
                s++;
            if (*s == '>' || !strncmp(s, "/>", 2))
                break;
            char an[32];
            size_t k = 0;
            while (*s && *s != '=' && *s != ' ' && k < 31)
                an[k++] = *s++;
            an[k] = '\0';
            if (*s != '=' || s[1] != '"')
                return "unquoted attribute";
            s += 2;
            const char *v = s;
            while (*s && *s != '"' && *s != '<')
                s++;
            if (*s != '"')
                return "unterminated attribute value";
            int vl = (int)(s - v);
            s++;
            if (!strcmp(name, "Topology") && !strcmp(an, "TopologyType"))
                snprintf(x->topo_type, sizeof x->topo_type, "%.*s", vl, v);
            if (!strcmp(name, "Topology") && !strcmp(an, "Dimensions"))
                snprintf(x->topo_dims, sizeof x->topo_dims, "%.*s", vl, v);
            if (!strcmp(name, "Attribute") && !strcmp(an, "Center"))
                snprintf(x->center, sizeof x->center, "%.*s", vl, v);
            if (is_item && !strcmp(an, "Dimensions"))
                snprintf(item_dims, sizeof item_dims, "%.*s", vl, v);
            if (is_item && !strcmp(an, "Format"))
                snprintf(cur_format, sizeof cur_format, "%.*s", vl, v);
        }
        if (is_item && !strcmp(cur_format, "HDF") && x->items < 4)
            snprintf(x->item_dims[x->items++], 64, "%s", item_dims);
        if (*s == '/') {
            s += 2; /* self-closing */
            continue;
        }
        s++;
        if (depth == 16)
            return "too deep";
        snprintf(stack[depth++], 32, "%s", name);
    }
    if (depth != 0)
        return "unclosed tags";
    return roots == 1 ? NULL : "no root";
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    char *buf = gs_calloc(1 << 16, 1);
    size_t n = fread(buf, 1, (1 << 16) - 1, f);
    buf[n] = '\0';
    fclose(f);
    return buf;
}

static void test_xdmf(void **state)
{
    (void)state;
    char path[512], xmf[520];
    tpath(path, sizeof path, "grid.h5");
    enum { NZ = 4, NY = 5, NX = 6 };
    float field[NZ * NY * NX];
    uint16_t labels[NZ * NY * NX];
    for (int i = 0; i < NZ * NY * NX; i++) {
        field[i] = (float)i;
        labels[i] = (uint16_t)(i % 3);
    }
    gs_ckpt_meta meta = {"model", 5, ""};
    gs_ckpt_t h = NULL;
    gs_h5_shape fs = {GS_H5_F32, 3, {NZ, NY, NX}}, ls = {GS_H5_U16, 3, {NZ, NY, NX}};
    assert_int_equal(gs_ckpt_create(MPI_COMM_WORLD, path, &meta, &h), GS_OK);
    assert_int_equal(gs_ckpt_write_whole(h, "/model/distance", &fs, field, NULL), GS_OK);
    assert_int_equal(gs_ckpt_write_whole(h, "/model/lattice", &ls, labels, NULL), GS_OK);
    assert_int_equal(gs_ckpt_commit(&h), GS_OK);

    gs_xdmf_grid node = {"distance <field> & co", GS_XDMF_NODE, {NZ, NY, NX}, {1, 2, 3},
                         {0.5, 0.25, 2}, 1};
    gs_xdmf_attr na = {"distance", "/model/distance", GS_H5_F32, 1};
    gs_xdmf_grid cell = {"lattice", GS_XDMF_CELL, {NZ, NY, NX}, {0, 0, 0}, {1, 1, 1}, 1};
    gs_xdmf_attr ca = {"label", "/model/lattice", GS_H5_U16, 1};
    struct {
        const gs_xdmf_grid *g;
        const gs_xdmf_attr *a;
        const char *topo, *center;
    } cases[2] = {{&node, &na, "4 5 6", "Node"}, {&cell, &ca, "5 6 7", "Cell"}};
    for (int c = 0; c < 2; c++) {
        assert_int_equal(gs_xdmf_write(path, cases[c].g, cases[c].a, 1), GS_OK);
        assert_int_equal(gs_xdmf_path(path, xmf, sizeof xmf), GS_OK);
        assert_non_null(strstr(xmf, "grid.xmf"));
        char *text = slurp(xmf);
        assert_non_null(text);
        xml_facts x;
        const char *why = xml_check(text, &x);
        if (why)
            fail_msg("%s is not well-formed: %s\n%s", xmf, why, text);
        assert_string_equal(x.topo_type, "3DCoRectMesh");
        assert_string_equal(x.topo_dims, cases[c].topo);
        assert_string_equal(x.center, cases[c].center);
        assert_int_equal(x.items, 1);
        assert_string_equal(x.item_dims[0], "4 5 6");
        /* The referenced dataset exists with exactly those dims. */
        char *colon = strchr(x.item_text[0], ':');
        assert_non_null(colon);
        *colon = '\0';
        assert_string_equal(x.item_text[0], "grid.h5");
        gs_h5_shape got;
        assert_int_equal(gs_ckpt_open(MPI_COMM_NULL, path, "model", &h), GS_OK);
        assert_int_equal(gs_ckpt_shape(h, colon + 1, &got), GS_OK);
        gs_ckpt_close(&h);
        char dims[64];
        snprintf(dims, sizeof dims, "%llu %llu %llu", (unsigned long long)got.dims[0],
                 (unsigned long long)got.dims[1], (unsigned long long)got.dims[2]);
        assert_string_equal(dims, x.item_dims[0]);
        if (c == 0) {
            assert_non_null(strstr(text, "distance &lt;field&gt; &amp; co"));
            assert_non_null(strstr(text, ">3 2 1</DataItem>"));      /* origin z y x */
            assert_non_null(strstr(text, ">2 0.25 0.5</DataItem>")); /* spacing z y x */
        } else {
            assert_non_null(strstr(text, "NumberType=\"UInt\" Precision=\"2\""));
        }
        gs_free(text);
        /* A real XML parser agrees, when one is installed. */
        if (access("/usr/bin/python3", X_OK) == 0) {
            char cmd[1200];
            snprintf(cmd, sizeof cmd,
                     "/usr/bin/python3 -c 'import sys, xml.etree.ElementTree as E; "
                     "E.parse(sys.argv[1])' '%s'",
                     xmf);
            assert_int_equal(system(cmd), 0);
        }
    }
    gs_xdmf_grid bad = cell;
    bad.spacing[1] = 0;
    expect_error(gs_xdmf_write(path, &bad, &ca, 1), GS_ERR_ARG, "spacing", path);
    tpath(path, sizeof path, "nodir/grid.h5");
    expect_error(gs_xdmf_write(path, &cell, &ca, 1), GS_ERR_IO, "nodir/grid.xmf.tmp", NULL);
}

static void test_split_rows(void **state)
{
    (void)state;
    for (uint64_t n = 0; n < 20; n++)
        for (int p = 1; p <= 7; p++) {
            uint64_t next = 0;
            for (int r = 0; r < p; r++) {
                uint64_t s, c;
                gs_h5_split_rows(n, p, r, &s, &c);
                assert_true(s == next);
                assert_true(c == n / (uint64_t)p || c == n / (uint64_t)p + 1);
                next = s + c;
            }
            assert_true(next == n);
        }
}

/* The global heap that holds variable-length strings carries no checksum
 * and libhdf5 1.10 trusts its object sizes (a size flipped 8 -> 524288 was
 * a heap overflow inside H5Aread, found by fuzz_h5example): such a file is
 * refused before libhdf5 reads it; a long string of our own still reads. */
static void test_global_heap(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "gheap.h5");
    gs_ckpt_meta meta = {"model", 3, NULL};
    gs_ckpt_t h = NULL;
    char *big = gs_calloc(30001, 1); /* a heap object alone in its collection */
    memset(big, 'y', 30000);
    assert_int_equal(gs_ckpt_create(MPI_COMM_NULL, path, &meta, &h), GS_OK);
    assert_int_equal(gs_ckpt_set_str(h, "/model", "names", big), GS_OK);
    assert_int_equal(gs_ckpt_set_str(h, "/model", "phase", "assembly"), GS_OK);
    assert_int_equal(gs_ckpt_commit(&h), GS_OK);
    char *str = NULL;
    assert_int_equal(gs_ckpt_open(MPI_COMM_NULL, path, "model", &h), GS_OK);
    assert_int_equal(gs_ckpt_get_str(h, "/model", "names", &str), GS_OK);
    assert_string_equal(str, big);
    gs_free(str);
    gs_ckpt_close(&h);
    FILE *f = fopen(path, "rb");
    fseek(f, 0, SEEK_END);
    size_t size = (size_t)ftell(f);
    fclose(f);
    assert_true(size < (1 << 16)); /* slurp's limit */
    char *bytes = slurp(path), *bad = gs_malloc(size);
    /* the magic "geosynth" is one heap object: its size field is 8 bytes before it */
    size_t at = 0; /* in the first collection (the name also appears elsewhere) */
    while (at + 4 <= size && memcmp(bytes + at, "GCOL", 4))
        at++;
    while (at + 8 <= size && memcmp(bytes + at, "geosynth", 8))
        at++;
    assert_true(at + 8 <= size && at >= 16);
    assert_int_equal(bytes[at - 8], 8);
    memcpy(bad, bytes, size);
    bad[at - 8] = 0, bad[at - 6] = 8; /* 8 -> 524288 */
    expect_error(gs_ckpt_open_image(bad, size, "mem.h5", "model", &h), GS_ERR_FORMAT,
                 "global heap collection", "524288 bytes");
    memcpy(bad, bytes, size);
    bad[at - 16] = 9; /* the object's id: 1..n no longer */
    expect_error(gs_ckpt_open_image(bad, size, "mem.h5", "model", &h), GS_ERR_FORMAT,
                 "global heap collection", "numbers them up to 9");
    memcpy(bad, bytes, size);
    bad[at - 8] = 12; /* past its 8 bytes: the next object is misplaced */
    expect_error(gs_ckpt_open_image(bad, size, "mem.h5", "model", &h), GS_ERR_FORMAT,
                 "global heap collection", NULL);
    memcpy(bad, bytes, size);
    assert_int_equal(gs_ckpt_open_image(bad, size, "mem.h5", "model", &h), GS_OK);
    gs_ckpt_close(&h);
    gs_free(bad);
    gs_free(bytes);
    gs_free(big);
}

static void test_precheck_image(void **state)
{
    (void)state;
    char path[512];
    tpath(path, sizeof path, "image.h5");
    write_sample(MPI_COMM_NULL, path, "micro", 9);
    char *bytes = slurp(path); /* < 64 KiB */
    FILE *f = fopen(path, "rb");
    fseek(f, 0, SEEK_END);
    size_t size = (size_t)ftell(f);
    fclose(f);
    assert_true(size < (1 << 16));
    gs_ckpt_t h = NULL;
    assert_int_equal(gs_ckpt_open_image(bytes, size, "mem.h5", "micro", &h), GS_OK);
    check_sample(h, "micro", 9);
    gs_ckpt_close(&h);
    expect_error(gs_ckpt_open_image(bytes, size - 10, "mem.h5", "micro", &h), GS_ERR_FORMAT,
                 "truncated", "mem.h5");
    /* Damaged superblock fields. */
    char *bad = gs_malloc(size);
    memcpy(bad, bytes, size);
    bad[8] = 7; /* superblock version */
    expect_error(gs_ckpt_open_image(bad, size, "mem.h5", NULL, &h), GS_ERR_FORMAT,
                 "superblock version 7", NULL);
    memcpy(bad, bytes, size);
    bad[0] = 'X';
    expect_error(gs_ckpt_open_image(bad, size, "mem.h5", NULL, &h), GS_ERR_FORMAT,
                 "not an HDF5 file", NULL);
    char *text = NULL;
    size_t len = 0;
    FILE *out = open_memstream(&text, &len);
    assert_int_equal(gs_inspect_image(bytes, size, "mem.h5", out, NULL), GS_OK);
    fclose(out);
    assert_non_null(strstr(text, "engine:          micro"));
    free(text);
    gs_free(bad);
    gs_free(bytes);
}

int main(int argc, char **argv)
{
    gs_err err = gs_par_init(&argc, &argv);
    if (err)
        gs_fatal(err, 0);
    snprintf(tmpdir, sizeof tmpdir, "%s/gs-test-h5-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roundtrip_all_types),
        cmocka_unit_test(test_attributes),
        cmocka_unit_test(test_deflate_chunked),
        cmocka_unit_test(test_atomic_replace),
        cmocka_unit_test(test_truncated),
        cmocka_unit_test(test_foreign_hdf5),
        cmocka_unit_test(test_wrong_engine_and_newer_format),
        cmocka_unit_test(test_wrong_dims_and_type),
        cmocka_unit_test(test_text_missing_unwritable),
        cmocka_unit_test(test_peek),
        cmocka_unit_test(test_inspect),
        cmocka_unit_test(test_xdmf),
        cmocka_unit_test(test_split_rows),
        cmocka_unit_test(test_precheck_image),
        cmocka_unit_test(test_global_heap),
    };
    int failed = cmocka_run_group_tests(tests, NULL, NULL);
    if (!failed) {
        char cmd[400];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
        if (system(cmd) != 0)
            fprintf(stderr, "could not remove %s\n", tmpdir);
    }
    gs_par_finalize();
    return failed ? 1 : 0;
}
