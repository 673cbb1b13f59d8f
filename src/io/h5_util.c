/* HDF5 helpers: error silencing, raw-byte pre-validation, serial opens,
 * type mapping, string reads. See src/io/h5_internal.h. */
#include "io/h5_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "geosynth/mem.h"
#include "geosynth/partition.h"

static const unsigned char hdf5_signature[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};

void gs_h5_quiet(void)
{
    static int quiet = 0;
    if (!quiet) {
        /* HDF5 prints its whole error stack to stderr by default; geosynth
         * reports its own message and uses HDF5's only as detail. */
        H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
        quiet = 1;
    }
}

typedef struct detail_walk {
    char *buf;
    size_t len;
    int found;
} detail_walk;

static herr_t detail_cb(unsigned n, const H5E_error2_t *e, void *data)
{
    detail_walk *w = data;
    (void)n;
    /* Walking upward, the first entry is where the error was detected: the
     * most specific description ("truncated file: eof = ..."). */
    if (!w->found && e->desc && e->desc[0]) {
        snprintf(w->buf, w->len, "%s", e->desc);
        w->found = 1;
    }
    return 0;
}

void gs_h5_detail(char *buf, size_t len)
{
    if (!len)
        return;
    buf[0] = '\0';
    detail_walk w = {buf, len, 0};
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, detail_cb, &w);
    H5Eclear2(H5E_DEFAULT);
    if (!w.found)
        snprintf(buf, len, "no detail");
}

/* ---- raw-byte pre-validation ---------------------------------------------- */

static uint64_t le_u64(const unsigned char *p, int n)
{
    uint64_t v = 0;
    for (int i = n - 1; i >= 0; i--)
        v = (v << 8) | p[i];
    return v;
}

static int valid_size(unsigned s) { return s == 2 || s == 4 || s == 8; }

/* The global heap (#25): variable-length strings (our string attributes)
 * live in global heap collections ("GCOL"), the one part of an HDF5 file
 * whose structure carries no checksum even in checksummed files, and which
 * libhdf5 1.10 trusts: an object's size is only asserted to fit its
 * collection, and H5HG_read copies that many bytes into a conversion buffer
 * sized from the (checksummed) attribute's own string length, rounded up to
 * a multiple of 4096 bytes (H5T_VLEN_MIN_CONF_BUF_SIZE), at least 4096. One
 * flipped size byte (8 -> 524288, found by fuzz_h5example) was a heap
 * overflow inside H5Aread. So every collection is walked here first, as
 * libhdf5 walks it, and refused unless:
 *   - it is at least 4096 bytes (H5HG_MINSIZE) and lies inside the file;
 *   - its objects tile it exactly (header + size rounded up to 8 each, the
 *     free-space object 0 last, or fewer than a header's bytes left over);
 *   - object ids are 1..n, each once (a missing id is a NULL object);
 *   - an object of more than 4096 bytes is alone in its collection with no
 *     free space (libhdf5 writes such a collection to fit exactly), so its
 *     size cannot have grown past its string's length rounded up to 8, and
 *     smaller ones always fit the conversion buffer.
 * A candidate needs "GCOL" and version 1 (libhdf5 refuses other versions
 * itself); scanning every byte finds collections wherever they are. */
#define GCOL_MIN ((uint64_t)4096)
#define GCOL_OBJ_INLINE ((uint64_t)4096)
#define GCOL_SCAN_CHUNK ((size_t)1 << 20)

static gs_err check_collection(const char *name, uint64_t at, uint64_t size,
                               gs_h5_read_at_fn read_at, void *ctx, unsigned sl)
{
    unsigned char hdr[8 + 8];
    uint64_t hsize = 8 + (uint64_t)sl, ohdr = 8 + (uint64_t)sl;
    if (read_at(ctx, at, hdr, (size_t)hsize) != hsize)
        return GS_OK; /* cut off: libhdf5 cannot load it either */
    if (hdr[4] != 1)
        return GS_OK; /* not a collection libhdf5 would accept */
    uint64_t csize = le_u64(hdr + 8, (int)sl);
    GS_CHECK(csize >= GCOL_MIN && csize <= size && at <= size - csize, GS_ERR_FORMAT,
             "%s: corrupt HDF5 file: the global heap collection at byte %llu declares %llu bytes "
             "(at least 4096, inside the file's %llu): its variable-length strings cannot be "
             "read safely",
             name, (unsigned long long)at, (unsigned long long)csize, (unsigned long long)size);
    uint64_t p = hsize, biggest = 0;
    unsigned nobj = 0, maxid = 0, has_free = 0;
    unsigned char seen[65536 / 8];
    memset(seen, 0, sizeof seen);
    while (p < csize) {
        if (p + ohdr > csize) { /* a tail too small for a header: free space */
            has_free = 1;
            break;
        }
        unsigned char oh[16];
        GS_CHECK(read_at(ctx, at + p, oh, (size_t)ohdr) == ohdr, GS_ERR_FORMAT,
                 "%s: truncated HDF5 file inside the global heap collection at byte %llu", name,
                 (unsigned long long)at);
        unsigned id = (unsigned)oh[0] | (unsigned)oh[1] << 8;
        uint64_t osize = le_u64(oh + 8, (int)sl);
        if (id == 0) { /* free space: its size includes its header, and it is last */
            GS_CHECK(osize == csize - p, GS_ERR_FORMAT,
                     "%s: corrupt HDF5 file: the free space of the global heap collection at "
                     "byte %llu declares %llu bytes where %llu are left",
                     name, (unsigned long long)at, (unsigned long long)osize,
                     (unsigned long long)(csize - p));
            has_free = 1;
            break;
        }
        uint64_t room = csize - p - ohdr;
        GS_CHECK(osize <= room && ((osize + 7) & ~(uint64_t)7) <= room, GS_ERR_FORMAT,
                 "%s: corrupt HDF5 file: object %u of the global heap collection at byte %llu "
                 "declares %llu bytes where %llu are left (a damaged variable-length string)",
                 name, id, (unsigned long long)at, (unsigned long long)osize,
                 (unsigned long long)room);
        GS_CHECK(!(seen[id / 8] & (1u << (id % 8))), GS_ERR_FORMAT,
                 "%s: corrupt HDF5 file: object %u appears twice in the global heap collection "
                 "at byte %llu",
                 name, id, (unsigned long long)at);
        seen[id / 8] |= (unsigned char)(1u << (id % 8));
        nobj++;
        maxid = id > maxid ? id : maxid;
        biggest = osize > biggest ? osize : biggest;
        p += ohdr + ((osize + 7) & ~(uint64_t)7);
    }
    GS_CHECK(maxid == nobj, GS_ERR_FORMAT,
             "%s: corrupt HDF5 file: the global heap collection at byte %llu holds %u objects "
             "but numbers them up to %u (a missing object cannot be read)",
             name, (unsigned long long)at, nobj, maxid);
    GS_CHECK(biggest <= GCOL_OBJ_INLINE || (nobj == 1 && !has_free), GS_ERR_FORMAT,
             "%s: corrupt HDF5 file: an object of %llu bytes shares the global heap collection "
             "at byte %llu with %s (HDF5 writes so large a string alone): its size cannot be "
             "trusted",
             name, (unsigned long long)biggest, (unsigned long long)at,
             nobj > 1 ? "other objects" : "free space");
    return GS_OK;
}

static gs_err check_global_heaps(const char *name, uint64_t size, gs_h5_read_at_fn read_at,
                                 void *ctx, unsigned sl)
{
    static const unsigned char sig[4] = {'G', 'C', 'O', 'L'};
    unsigned char *buf = gs_malloc(GCOL_SCAN_CHUNK + 3);
    GS_CHECK(buf, GS_ERR_MEM, "%s: out of memory to check the file", name);
    gs_err err = GS_OK;
    for (uint64_t off = 0; off < size && !err;) {
        /* chunks overlap by 3 bytes, so a signature across a border is seen */
        size_t want = size - off < GCOL_SCAN_CHUNK + 3 ? (size_t)(size - off) : GCOL_SCAN_CHUNK + 3;
        size_t got = read_at(ctx, off, buf, want);
        if (got < 4)
            break;
        for (const unsigned char *q = buf, *end = buf + got; !err && end - q >= 4; q++) {
            q = memchr(q, sig[0], (size_t)(end - q - 3));
            if (!q)
                break;
            if (!memcmp(q, sig, sizeof sig))
                err = check_collection(name, off + (uint64_t)(q - buf), size, read_at, ctx, sl);
        }
        if (got < want)
            break;
        off += got - 3;
    }
    gs_free(buf);
    return err;
}

gs_err gs_h5_precheck(const char *name, uint64_t size, gs_h5_read_at_fn read_at, void *ctx,
                      int checksummed)
{
    unsigned char sb[96];
    uint64_t off = 0;
    int found = 0;
    /* The superblock is at 0 or after a user block of 512, 1024, 2048, ...
     * bytes (HDF5 looks at the same offsets). */
    for (off = 0; off + 8 <= size; off = off ? off * 2 : 512) {
        if (read_at(ctx, off, sb, 8) == 8 && memcmp(sb, hdf5_signature, 8) == 0) {
            found = 1;
            break;
        }
        if (off > (UINT64_MAX >> 2))
            break;
    }
    if (!found) {
        if (size == 0)
            GS_RAISE(GS_ERR_FORMAT, "%s: not an HDF5 file (it is empty)", name);
        GS_RAISE(GS_ERR_FORMAT,
                 "%s: not an HDF5 file (no HDF5 signature at byte 0 or any user-block "
                 "offset; %llu bytes; a text or other file named .h5?)",
                 name, (unsigned long long)size);
    }
    memset(sb, 0, sizeof sb);
    size_t got = read_at(ctx, off, sb, sizeof sb);
    GS_CHECK(got >= 12, GS_ERR_FORMAT,
             "%s: truncated HDF5 file: the superblock at byte %llu is cut off (%llu bytes)",
             name, (unsigned long long)off, (unsigned long long)size);
    unsigned version = sb[8];
    unsigned so, sl, start;
    uint64_t root_at;
    if (version == 0 || version == 1) {
        so = sb[13];
        sl = sb[14];
        start = version == 0 ? 24 : 28;
        root_at = start + 5u * so; /* base, free, eof, driver, link name, header */
    } else if (version == 2 || version == 3) {
        so = sb[9];
        sl = sb[10];
        start = 12;
        root_at = start + 3u * so; /* base, extension, eof, root header */
    } else {
        GS_RAISE(GS_ERR_FORMAT,
                 "%s: unsupported HDF5 superblock version %u at byte %llu (expected 0..3)",
                 name, version, (unsigned long long)off);
    }
    GS_CHECK(!checksummed || version >= GS_H5_SB_CHECKSUMMED, GS_ERR_FORMAT,
             "%s: not a geosynth file (HDF5 superblock version %u: geosynth files use version "
             "%d or later, whose metadata is checksummed)",
             name, version, GS_H5_SB_CHECKSUMMED);
    GS_CHECK(valid_size(so) && valid_size(sl), GS_ERR_FORMAT,
             "%s: corrupt HDF5 superblock: offset size %u, length size %u (expected 2, 4 or 8)",
             name, so, sl);
    GS_CHECK(root_at + so <= got, GS_ERR_FORMAT,
             "%s: truncated HDF5 file: the superblock at byte %llu is cut off (%llu bytes)",
             name, (unsigned long long)off, (unsigned long long)size);
    uint64_t undef = so == 8 ? UINT64_MAX : ((uint64_t)1 << (8 * so)) - 1;
    uint64_t base = le_u64(sb + start, (int)so);
    uint64_t eof = le_u64(sb + start + 2 * so, (int)so);
    uint64_t root = le_u64(sb + root_at, (int)so);
    GS_CHECK(base != undef && eof != undef && base <= size, GS_ERR_FORMAT,
             "%s: corrupt HDF5 superblock: base address %llu, end of file %llu",
             name, (unsigned long long)base, (unsigned long long)eof);
    GS_CHECK(eof <= UINT64_MAX - base && base + eof <= size, GS_ERR_FORMAT,
             "%s: truncated HDF5 file: its superblock declares %llu bytes but the file has "
             "%llu (an interrupted write or copy?)",
             name, (unsigned long long)(eof > UINT64_MAX - base ? UINT64_MAX : base + eof),
             (unsigned long long)size);
    GS_CHECK(root != undef && root < eof, GS_ERR_FORMAT,
             "%s: corrupt HDF5 superblock: root group at address %llu, end of file %llu",
             name, (unsigned long long)root, (unsigned long long)eof);
    GS_CALL(check_global_heaps(name, size, read_at, ctx, sl));
    return GS_OK;
}

static size_t read_at_fd(void *ctx, uint64_t off, void *buf, size_t n)
{
    int fd = *(int *)ctx;
    size_t done = 0;
    while (done < n) {
        ssize_t r = pread(fd, (char *)buf + done, n - done, (off_t)(off + done));
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            break;
        done += (size_t)r;
    }
    return done;
}

typedef struct image_ctx {
    const unsigned char *buf;
    size_t len;
} image_ctx;

static size_t read_at_image(void *ctx, uint64_t off, void *buf, size_t n)
{
    const image_ctx *im = ctx;
    if (off >= im->len)
        return 0;
    size_t avail = im->len - (size_t)off;
    size_t k = n < avail ? n : avail;
    memcpy(buf, im->buf + off, k);
    return k;
}

gs_err gs_h5_precheck_path(const char *path, int checksummed)
{
    int fd = open(path, O_RDONLY);
    GS_CHECK(fd >= 0, GS_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0) {
        int e = errno;
        close(fd);
        GS_RAISE(GS_ERR_IO, "%s: cannot stat: %s", path, strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        GS_RAISE(GS_ERR_IO, "%s: not a regular file", path);
    }
    gs_err err = gs_h5_precheck(path, (uint64_t)st.st_size, read_at_fd, &fd, checksummed);
    close(fd);
    if (err)
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    return err;
}

gs_err gs_h5_precheck_image(const char *name, const void *buf, size_t len, int checksummed)
{
    image_ctx im = {buf, len};
    GS_CALL(gs_h5_precheck(name, len, read_at_image, &im, checksummed));
    return GS_OK;
}

gs_err gs_h5_open_serial(const char *path, int checksummed, hid_t *out)
{
    gs_h5_quiet();
    GS_CALL(gs_h5_precheck_path(path, checksummed));
    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    GS_CHECK(fapl >= 0, GS_ERR_LIB, "%s: H5Pcreate failed", path);
    H5Pset_fapl_sec2(fapl);
    hid_t f = H5Fopen(path, H5F_ACC_RDONLY, fapl);
    H5Pclose(fapl);
    if (f < 0) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        GS_RAISE(GS_ERR_FORMAT, "%s: not a readable HDF5 file (HDF5: %s)", path, d);
    }
    *out = f;
    return GS_OK;
}

gs_err gs_h5_open_image(const char *name, const void *buf, size_t len, int checksummed,
                        hid_t *out)
{
    gs_h5_quiet();
    GS_CALL(gs_h5_precheck_image(name, buf, len, checksummed));
    hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
    GS_CHECK(fapl >= 0, GS_ERR_LIB, "%s: H5Pcreate failed", name);
    if (H5Pset_fapl_core(fapl, 1 << 16, 0) < 0 ||
        H5Pset_file_image(fapl, (void *)buf, len) < 0) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        H5Pclose(fapl);
        GS_RAISE(GS_ERR_LIB, "%s: cannot set up the in-memory file (HDF5: %s)", name, d);
    }
    hid_t f = H5Fopen(name, H5F_ACC_RDONLY, fapl);
    H5Pclose(fapl);
    if (f < 0) {
        char d[256];
        gs_h5_detail(d, sizeof d);
        GS_RAISE(GS_ERR_FORMAT, "%s: not a readable HDF5 file (HDF5: %s)", name, d);
    }
    *out = f;
    return GS_OK;
}

int gs_h5_exists(hid_t loc, const char *path)
{
    if (!path || !path[0])
        return 0;
    if (strcmp(path, "/") == 0)
        return 1;
    size_t n = strlen(path);
    char *p = gs_malloc(n + 1);
    if (!p)
        return 0;
    memcpy(p, path, n + 1);
    int ok = 1;
    /* H5Lexists fails (rather than returning 0) when a parent is missing,
     * so check each prefix in turn. */
    for (size_t i = 1; i <= n && ok; i++) {
        if (p[i] == '/' || p[i] == '\0') {
            char c = p[i];
            p[i] = '\0';
            if (i > 0 && p[i - 1] != '/')
                ok = H5Lexists(loc, p, H5P_DEFAULT) > 0;
            p[i] = c;
        }
    }
    if (ok)
        ok = H5Oexists_by_name(loc, path, H5P_DEFAULT) > 0; /* dangling links */
    H5Eclear2(H5E_DEFAULT);
    gs_free(p);
    return ok;
}

gs_h5_type gs_h5_type_of(hid_t dtype, char *why, size_t why_len)
{
    H5T_class_t cls = H5Tget_class(dtype);
    size_t size = H5Tget_size(dtype);
    if (cls == H5T_FLOAT) {
        if (size == 4)
            return GS_H5_F32;
        if (size == 8)
            return GS_H5_F64;
        snprintf(why, why_len, "float%zu", size * 8);
        return 0;
    }
    if (cls == H5T_INTEGER) {
        int is_signed = H5Tget_sign(dtype) == H5T_SGN_2;
        if (!is_signed && size == 1)
            return GS_H5_U8;
        if (!is_signed && size == 2)
            return GS_H5_U16;
        if (is_signed && size == 4)
            return GS_H5_I32;
        if (is_signed && size == 8)
            return GS_H5_I64;
        if (!is_signed && size == 8)
            return GS_H5_U64;
        snprintf(why, why_len, "%sint%zu", is_signed ? "" : "u", size * 8);
        return 0;
    }
    const char *name = "unknown type";
    switch (cls) {
    case H5T_STRING: name = "string"; break;
    case H5T_COMPOUND: name = "compound"; break;
    case H5T_ENUM: name = "enum"; break;
    case H5T_ARRAY: name = "array type"; break;
    case H5T_VLEN: name = "variable-length sequence"; break;
    case H5T_OPAQUE: name = "opaque"; break;
    case H5T_REFERENCE: name = "reference"; break;
    case H5T_BITFIELD: name = "bitfield"; break;
    case H5T_TIME: name = "time"; break;
    default: break;
    }
    snprintf(why, why_len, "%s", name);
    return 0;
}

hid_t gs_h5_mem_type(gs_h5_type type)
{
    switch (type) {
    case GS_H5_F32: return H5T_NATIVE_FLOAT;
    case GS_H5_F64: return H5T_NATIVE_DOUBLE;
    case GS_H5_U8: return H5T_NATIVE_UINT8;
    case GS_H5_U16: return H5T_NATIVE_UINT16;
    case GS_H5_I32: return H5T_NATIVE_INT32;
    case GS_H5_I64: return H5T_NATIVE_INT64;
    case GS_H5_U64: return H5T_NATIVE_UINT64;
    }
    return -1;
}

hid_t gs_h5_file_type(gs_h5_type type)
{
    switch (type) {
    case GS_H5_F32: return H5T_IEEE_F32LE;
    case GS_H5_F64: return H5T_IEEE_F64LE;
    case GS_H5_U8: return H5T_STD_U8LE;
    case GS_H5_U16: return H5T_STD_U16LE;
    case GS_H5_I32: return H5T_STD_I32LE;
    case GS_H5_I64: return H5T_STD_I64LE;
    case GS_H5_U64: return H5T_STD_U64LE;
    }
    return -1;
}

const char *gs_h5_type_name(gs_h5_type type)
{
    switch (type) {
    case GS_H5_F32: return "float32";
    case GS_H5_F64: return "float64";
    case GS_H5_U8: return "uint8";
    case GS_H5_U16: return "uint16";
    case GS_H5_I32: return "int32";
    case GS_H5_I64: return "int64";
    case GS_H5_U64: return "uint64";
    }
    return "invalid";
}

size_t gs_h5_type_size(gs_h5_type type)
{
    switch (type) {
    case GS_H5_F32: return 4;
    case GS_H5_F64: return 8;
    case GS_H5_U8: return 1;
    case GS_H5_U16: return 2;
    case GS_H5_I32: return 4;
    case GS_H5_I64: return 8;
    case GS_H5_U64: return 8;
    }
    return 0;
}

void gs_h5_shape_format(const gs_h5_shape *shape, char *buf, size_t len)
{
    if (!len)
        return;
    size_t used = (size_t)snprintf(buf, len, "%s [", gs_h5_type_name(shape->type));
    int rank = shape->rank;
    if (rank < 0 || rank > GS_H5_MAX_RANK)
        rank = 0;
    for (int i = 0; i < rank && used < len; i++)
        used += (size_t)snprintf(buf + used, len - used, "%s%llu", i ? " x " : "",
                                 (unsigned long long)shape->dims[i]);
    if (used < len)
        snprintf(buf + used, len - used, "]");
}

void gs_h5_split_rows(uint64_t n, int nranks, int rank, uint64_t *start, uint64_t *count)
{
    if (nranks < 1)
        nranks = 1;
    int64_t lo = 0, hi = 0;
    if (gs_partition((int64_t)n, nranks, rank, &lo, &hi) != GS_OK) /* rank outside [0, nranks) */
        gs_error_clear();
    *start = (uint64_t)lo;
    *count = (uint64_t)(hi - lo);
}

/* ---- strings ---------------------------------------------------------------- */

static int one_element(hid_t space, char *why, size_t why_len)
{
    hssize_t n = H5Sget_simple_extent_npoints(space);
    if (n != 1) {
        snprintf(why, why_len, "holds %lld values, expected 1", (long long)n);
        return 0;
    }
    return 1;
}

static int read_fixed_str(hid_t obj, int is_attr, hid_t ftype, size_t max_len, char **out,
                          char *why, size_t why_len)
{
    size_t size = H5Tget_size(ftype);
    if (size == 0 || size > max_len) {
        snprintf(why, why_len, "string of %zu bytes (at most %zu accepted)", size, max_len);
        return -1;
    }
    char *buf = gs_calloc(size + 1, 1);
    if (!buf) {
        snprintf(why, why_len, "out of memory for %zu bytes", size);
        return -1;
    }
    hid_t mtype = H5Tcopy(ftype); /* same size and padding: no conversion */
    herr_t rc = mtype < 0 ? -1
                : is_attr ? H5Aread(obj, mtype, buf)
                          : H5Dread(obj, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
    if (mtype >= 0)
        H5Tclose(mtype);
    if (rc < 0) {
        char d[200];
        gs_h5_detail(d, sizeof d);
        snprintf(why, why_len, "unreadable string (HDF5: %s)", d);
        gs_free(buf);
        return -1;
    }
    buf[size] = '\0';
    *out = buf;
    return 0;
}

int gs_h5_read_str_attr(hid_t obj, const char *name, size_t max_len, char **out, char *why,
                        size_t why_len)
{
    int rc = -1;
    hid_t attr = -1, ftype = -1, space = -1, mtype = -1;
    if (H5Aexists(obj, name) <= 0) {
        snprintf(why, why_len, "missing");
        goto done;
    }
    attr = H5Aopen(obj, name, H5P_DEFAULT);
    ftype = attr >= 0 ? H5Aget_type(attr) : -1;
    space = attr >= 0 ? H5Aget_space(attr) : -1;
    if (attr < 0 || ftype < 0 || space < 0) {
        char d[200];
        gs_h5_detail(d, sizeof d);
        snprintf(why, why_len, "unreadable (HDF5: %s)", d);
        goto done;
    }
    if (H5Tget_class(ftype) != H5T_STRING) {
        snprintf(why, why_len, "not a string");
        goto done;
    }
    if (!one_element(space, why, why_len))
        goto done;
    if (H5Tis_variable_str(ftype) > 0) {
        char *vs = NULL;
        mtype = H5Tcopy(H5T_C_S1);
        if (mtype < 0 || H5Tset_size(mtype, H5T_VARIABLE) < 0 ||
            H5Tset_cset(mtype, H5Tget_cset(ftype)) < 0 || H5Aread(attr, mtype, &vs) < 0) {
            char d[200];
            gs_h5_detail(d, sizeof d);
            snprintf(why, why_len, "unreadable string (HDF5: %s)", d);
            goto done;
        }
        const char *s = vs ? vs : "";
        size_t n = strnlen(s, max_len + 1);
        if (n > max_len) {
            snprintf(why, why_len, "string longer than %zu bytes", max_len);
        } else if ((*out = gs_malloc(n + 1)) != NULL) {
            memcpy(*out, s, n);
            (*out)[n] = '\0';
            rc = 0;
        } else {
            snprintf(why, why_len, "out of memory");
        }
        if (vs)
            H5free_memory(vs);
        goto done;
    }
    rc = read_fixed_str(attr, 1, ftype, max_len, out, why, why_len);
done:
    if (mtype >= 0)
        H5Tclose(mtype);
    if (space >= 0)
        H5Sclose(space);
    if (ftype >= 0)
        H5Tclose(ftype);
    if (attr >= 0)
        H5Aclose(attr);
    H5Eclear2(H5E_DEFAULT);
    return rc;
}

int gs_h5_read_str_dataset(hid_t loc, const char *path, size_t max_len, char **out, char *why,
                           size_t why_len)
{
    int rc = -1;
    hid_t dset = -1, ftype = -1, space = -1;
    if (!gs_h5_exists(loc, path)) {
        snprintf(why, why_len, "missing");
        goto done;
    }
    dset = H5Dopen2(loc, path, H5P_DEFAULT);
    ftype = dset >= 0 ? H5Dget_type(dset) : -1;
    space = dset >= 0 ? H5Dget_space(dset) : -1;
    if (dset < 0 || ftype < 0 || space < 0) {
        char d[200];
        gs_h5_detail(d, sizeof d);
        snprintf(why, why_len, "not a readable dataset (HDF5: %s)", d);
        goto done;
    }
    if (H5Tget_class(ftype) != H5T_STRING || H5Tis_variable_str(ftype) != 0) {
        snprintf(why, why_len, "not a fixed-length string");
        goto done;
    }
    if (!one_element(space, why, why_len))
        goto done;
    rc = read_fixed_str(dset, 0, ftype, max_len, out, why, why_len);
done:
    if (space >= 0)
        H5Sclose(space);
    if (ftype >= 0)
        H5Tclose(ftype);
    if (dset >= 0)
        H5Dclose(dset);
    H5Eclear2(H5E_DEFAULT);
    return rc;
}

const char *gs_h5_library_version(void)
{
    static char text[64];
    unsigned major = 0, minor = 0, release = 0;
    H5get_libversion(&major, &minor, &release);
    snprintf(text, sizeof text, "HDF5 %u.%u.%u (%s)", major, minor, release,
#ifdef H5_HAVE_PARALLEL
             "parallel"
#else
             "serial"
#endif
    );
    return text;
}
