/* Internals shared by src/io/h5_*.c, xdmf.c and inspect.c (not installed). */
#ifndef GEOSYNTH_IO_H5_INTERNAL_H
#define GEOSYNTH_IO_H5_INTERNAL_H

#include <hdf5.h>

#include "geosynth/h5.h"

struct gs_ckpt {
    hid_t file;
    MPI_Comm comm;     /* MPI_COMM_NULL: serial handle, no MPI calls */
    int rank, size;
    int writing;       /* 1 while a .tmp is being written */
    char *path;        /* final path (or image name) */
    char *tmp_path;    /* path + ".tmp" when writing */
    char *prev_path;   /* where commit keeps the replaced file (NULL: nowhere) */
    int reserve_fd;    /* rank 0 of a file being written: tmp_path for fallocate (-1: none) */
    int reserve_off;   /* 1 when the file system has no fallocate */
    uint64_t reserve_total; /* bytes reserved so far (gs_h5_reserve) */
    char engine[GS_H5_ENGINE_MAX];
    char *program_version;
    char *config;
    char created[40];
    int format_version;
    uint64_t seed;
};

/* Collective on a file being written: rank 0 reserves bytes (plus a margin
 * for metadata) at the file's end of allocation with posix_fallocate, so a
 * full disk is reported here, before libhdf5 writes anything. Parallel
 * libhdf5 cannot fail a write on one rank: the other ranks wait in its
 * internal collectives forever (#25: disk full during a checkpoint hung
 * np 2 and 3). File systems without fallocate are left unreserved. */
gs_err gs_h5_reserve(struct gs_ckpt *h, uint64_t bytes, const char *what);

/* Silences HDF5's automatic error printing (idempotent, cheap). */
void gs_h5_quiet(void);

/* Innermost message of HDF5's current error stack ("unable to open file:
 * truncated file ..."), then clears the stack. buf gets "" when empty. */
void gs_h5_detail(char *buf, size_t len);

/* Raw-byte validation of an HDF5 file before libhdf5 sees it: finds the
 * superblock signature (offset 0, 512, 1024, ...), checks the superblock
 * version, offset/length sizes and that the declared end-of-file address
 * fits in size. read_at(ctx, off, buf, n) returns bytes read (may be short).
 * name is used in messages. GS_ERR_FORMAT on failure.
 *
 * checksummed != 0 also requires superblock version >= 3: such files (what
 * gs_ckpt_create writes, libver v110) checksum every metadata block, chunk
 * indexes included, so libhdf5 rejects damaged metadata by checksum before
 * parsing it. Older formats are parsed unchecked, and libhdf5 1.10 crashes
 * on hostile ones (found by tests/fuzz/fuzz_ckpt.c: SEGV in H5A__close
 * under H5Aiterate2 on a corrupt attribute message in a version-0 file; a
 * 4 GiB malloc in H5Dread from a damaged v1 B-tree chunk size in a
 * version-2 file). Checkpoint readers use 1; inspect uses 0 because it must
 * list any HDF5 file. */
#define GS_H5_SB_CHECKSUMMED 3
typedef size_t (*gs_h5_read_at_fn)(void *ctx, uint64_t off, void *buf, size_t n);
gs_err gs_h5_precheck(const char *name, uint64_t size, gs_h5_read_at_fn read_at, void *ctx,
                      int checksummed);
/* The same on a file path (GS_ERR_IO when missing/unreadable). */
gs_err gs_h5_precheck_path(const char *path, int checksummed);
gs_err gs_h5_precheck_image(const char *name, const void *buf, size_t len, int checksummed);

/* Opens path (serial sec2 driver) or an image (core driver) read-only after
 * the precheck. On error *out is unchanged. */
gs_err gs_h5_open_serial(const char *path, int checksummed, hid_t *out);
gs_err gs_h5_open_image(const char *name, const void *buf, size_t len, int checksummed,
                        hid_t *out);

/* Walks path component by component: 1 when the object exists. */
int gs_h5_exists(hid_t loc, const char *path);

/* Maps a stored datatype to gs_h5_type; 0 and a description in why
 * ("int16", "compound") when unsupported. */
gs_h5_type gs_h5_type_of(hid_t dtype, char *why, size_t why_len);
hid_t gs_h5_mem_type(gs_h5_type type);  /* native type, not to be closed */
hid_t gs_h5_file_type(gs_h5_type type); /* little-endian type, not to be closed */

/* Reads a string attribute or scalar string dataset (fixed or variable
 * length) into a gs_malloc'ed string. max_len bounds the size accepted.
 * Return 0 on success, -1 with why filled on failure (no gs_err raised). */
int gs_h5_read_str_attr(hid_t obj, const char *name, size_t max_len, char **out,
                        char *why, size_t why_len);
int gs_h5_read_str_dataset(hid_t loc, const char *path, size_t max_len, char **out,
                           char *why, size_t why_len);

/* Reads a numeric attribute holding exactly one value: kind 'i' (int64),
 * 'u' (uint64) from any integer type when the value fits, 'f' (double) from
 * a float type. 0 on success, -1 with why filled (no gs_err raised). */
int gs_h5_read_num_attr(hid_t obj, const char *name, char kind, void *out, char *why,
                        size_t why_len);

/* Create-or-replace a scalar attribute on obj (collective on a parallel
 * file: same value on every rank). path is used in messages. */
gs_err gs_h5_write_attr_raw(hid_t obj, const char *name, hid_t ftype, hid_t mtype,
                            const void *value, const char *path);
gs_err gs_h5_write_str_attr(hid_t obj, const char *name, const char *value, const char *path);

/* Reads /geosynth into h (magic, format version, engine, ...), checking
 * engine when non-NULL. Messages name h->path. Local. */
gs_err gs_h5_load_identity(struct gs_ckpt *h, const char *engine);

#define GS_H5_CONFIG_MAX ((size_t)256 << 20)
#define GS_H5_ATTR_STR_MAX ((size_t)60000)

#endif
