/* HDF5 checkpoints and outputs: atomic files, distributed arrays, engine
 * state attributes, XDMF sidecars, and the `inspect` summary.
 *
 * FILE LAYOUT (format version GS_FORMAT_VERSION, include/geosynth/version.h)
 * Files use the HDF5 1.10 file format (superblock 3): every metadata block
 * is checksummed, so damaged files are rejected before libhdf5 parses them.
 * Checkpoint readers refuse older superblocks as "not a geosynth file";
 * readable by any HDF5 >= 1.10 tool (h5dump, h5py, ParaView).
 *   /geosynth                 group; attributes:
 *       magic            string  "geosynth"
 *       format_version   int32
 *       engine           string  "field" | "points" | "micro" | "model" | ...
 *       program_version  string  GS_VERSION_STRING of the writer
 *       seed             uint64
 *       created          string  ISO 8601 UTC, "2024-05-01T12:00:00Z"
 *   /geosynth/config          scalar fixed-length string dataset: the full
 *                             resolved config text (a dataset, not an
 *                             attribute: attributes are limited to 64 KiB)
 *   /<engine>/...             engine groups, datasets and state attributes
 *                             written by the engine through this API.
 *
 * INDEX ORDER. Arrays are C order with dims given SLOWEST FIRST, exactly as
 * HDF5 (and h5py/numpy) store them. A 3D field of nx*ny*nz samples with x
 * fastest is the shape {nz, ny, nx}; element (x, y, z) is at
 * data[(z*ny + y)*nx + x]. Distributed arrays are cut along dims[0] (the
 * slowest axis, z for a 3D field): each rank owns the contiguous rows
 * [start, start+count) of dims[0], and the slabs of all ranks tile
 * [0, dims[0]) without overlap (checked). gs_h5_split_rows() gives the
 * standard balanced split.
 *
 * TYPES. Datasets are stored little-endian in the file and read back only as
 * exactly the type they were written with (no silent conversion): a reader
 * states the shape and type it expects and gets GS_ERR_FORMAT naming the
 * path, the dataset, what it found and what it expected otherwise.
 *
 * ATOMIC WRITES. gs_ckpt_create(comm, "run/checkpoint.h5") writes
 * "run/checkpoint.h5.tmp" (a stale .tmp from a killed run is removed first);
 * gs_ckpt_commit() flushes, closes, fsyncs the file, renames it over
 * "run/checkpoint.h5" and fsyncs the directory (rank 0 does the file system
 * steps). Until the rename, the previous checkpoint.h5 is untouched, so a
 * crash or SIGKILL at any moment leaves either the old or the new complete
 * file (tests/e2e/ckpt_sigkill.sh). With gs_ckpt_keep_previous() the replaced
 * file stays at that path (run/checkpoint.prev.h5), the fallback when the
 * newest one turns out damaged.
 *
 * CHECKSUMS. Every non-empty dataset is chunked with HDF5's Fletcher32
 * filter (verified by libhdf5 on each read), metadata is checksummed by the
 * 1.10 format, and /geosynth@config_digest (XXH3 of the config text) is
 * checked by every open. gs_ckpt_verify() checks a whole file.
 *
 * FULL DISKS. Before libhdf5 writes a dataset, rank 0 reserves room for the
 * whole file so far with posix_fallocate (src/io/h5_file.c gs_h5_reserve):
 * a full disk is GS_ERR_IO "no room to write ..." on every rank instead of a
 * write failing inside parallel libhdf5 on one rank (which left the others
 * waiting in its collectives). gs_ckpt_discard empties the .tmp before
 * closing it, so what libhdf5 still writes at close finds room. The
 * reserved slack is cut at commit (to the superblock's end of file).
 *
 * COLLECTIVITY. A handle opened with a communicator uses parallel HDF5
 * (MPI-IO). Functions marked "Collective" must be called by every rank of
 * that communicator in the same order with the same arguments (except the
 * slab start/count/data). Passing MPI_COMM_NULL opens a serial handle that
 * makes no MPI call at all (tools, the fuzzer); gs_ckpt_open_image(),
 * gs_ckpt_peek() and gs_inspect_file() are always serial.
 *
 * ERRORS. Every failure names the file path. Missing, unreadable or
 * unwritable files: GS_ERR_IO. Files that exist but are not what was
 * expected (not HDF5, truncated, not a geosynth file, newer format, other
 * engine, wrong shape or type): GS_ERR_FORMAT. HDF5's own error stack is
 * never printed; its innermost message is appended as "(HDF5: ...)" detail.
 * Collective functions return the same code on every rank.
 *
 * COST. Metadata operations are small; a slab write/read is one collective
 * MPI-IO operation (keep each rank's slab under 2 GiB: HDF5 1.10's MPI-IO
 * path is limited to 2^31 bytes per rank per call). Compression (deflate)
 * requires chunking; chunked writes stay collective, as parallel HDF5
 * requires for filtered datasets.
 */
#ifndef GEOSYNTH_H5_H
#define GEOSYNTH_H5_H

#include <mpi.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "geosynth/error.h"

#define GS_H5_MAX_RANK 8
#define GS_H5_ENGINE_MAX 32 /* bytes including NUL */

/* Element types. Values are stable (never renumber). */
typedef enum gs_h5_type {
    GS_H5_F32 = 1,
    GS_H5_F64 = 2,
    GS_H5_U8 = 3,
    GS_H5_U16 = 4,
    GS_H5_I32 = 5,
    GS_H5_I64 = 6,
    GS_H5_U64 = 7
} gs_h5_type;

/* "float32", "uint16", ... ("invalid" for anything else). */
const char *gs_h5_type_name(gs_h5_type type);
/* Bytes per element, 0 for an invalid type. */
size_t gs_h5_type_size(gs_h5_type type);

/* Shape of an array: type, rank in [1, GS_H5_MAX_RANK], dims slowest first. */
typedef struct gs_h5_shape {
    gs_h5_type type;
    int rank;
    uint64_t dims[GS_H5_MAX_RANK];
} gs_h5_shape;

/* Formats "float32 [64 x 64 x 32]" into buf (always NUL-terminated). */
void gs_h5_shape_format(const gs_h5_shape *shape, char *buf, size_t len);

/* Balanced split of n rows over nranks: rank r gets [*start, *start+*count),
 * the first n % nranks ranks one row more (gs_partition, partition.h, on
 * unsigned rows). Pure function. */
void gs_h5_split_rows(uint64_t n, int nranks, int rank, uint64_t *start,
                      uint64_t *count);

/* Storage options for a dataset (NULL = contiguous, uncompressed). */
typedef struct gs_h5_write_opts {
    int deflate;         /* 0 = none, 1..9 zlib level (implies chunking) */
    uint64_t chunk_rows; /* rows of dims[0] per chunk; 0 = contiguous when
                            deflate == 0, about 1 MiB chunks otherwise */
} gs_h5_write_opts;

/* Identity written into /geosynth by gs_ckpt_create. */
typedef struct gs_ckpt_meta {
    const char *engine;      /* [a-z0-9_]{1,31}, e.g. "field" */
    uint64_t seed;
    const char *config_text; /* full resolved config; NULL = "" */
} gs_ckpt_meta;

typedef struct gs_ckpt *gs_ckpt_t;

/* ---- writing ---------------------------------------------------------- */

/* Collective on comm. Starts the file path + ".tmp" (removing a stale one)
 * and writes the /geosynth group from meta. The previous file at path is
 * untouched until gs_ckpt_commit(). On success *out is a writable handle;
 * finish it with gs_ckpt_commit() or throw it away with gs_ckpt_discard().
 * On error *out is unchanged and nothing is left behind. Unwritable
 * directory: GS_ERR_IO naming the .tmp path and the system's reason. */
gs_err gs_ckpt_create(MPI_Comm comm, const char *path, const gs_ckpt_meta *meta,
                      gs_ckpt_t *out);

/* Local (call on every rank alike): gs_ckpt_commit of this handle keeps the
 * file it replaces at prev_path (a hard link renamed into place, so the
 * final path never goes missing). */
gs_err gs_ckpt_keep_previous(gs_ckpt_t h, const char *prev_path);

/* Collective. Flushes and closes the .tmp file, fsyncs it, renames it over
 * the final path and fsyncs the directory. Always frees the handle and sets
 * *h = NULL, also on error (then the .tmp is removed and the previous file
 * is still in place). */
gs_err gs_ckpt_commit(gs_ckpt_t *h);

/* Collective. Closes a handle without committing: for a writable handle the
 * .tmp file is removed; for a read handle this equals gs_ckpt_close().
 * Safe on *h == NULL. Sets *h = NULL. Use on error paths. */
void gs_ckpt_discard(gs_ckpt_t *h);

/* ---- reading ---------------------------------------------------------- */

/* Collective on comm (MPI_COMM_NULL = serial). Opens path read-only and
 * validates it: exists (GS_ERR_IO), is a complete HDF5 file (checked on the
 * raw bytes first: signature, declared end of file vs real size), has
 * /geosynth with magic "geosynth", a format_version <= GS_FORMAT_VERSION,
 * and, when engine != NULL, that engine (all GS_ERR_FORMAT). Loads the
 * identity (see accessors). On error *out is unchanged. */
gs_err gs_ckpt_open(MPI_Comm comm, const char *path, const char *engine,
                    gs_ckpt_t *out);

/* Serial. Like gs_ckpt_open but on an in-memory file image of len bytes
 * (copied; buf may be freed afterwards). name is used in messages. */
gs_err gs_ckpt_open_image(const void *buf, size_t len, const char *name,
                          const char *engine, gs_ckpt_t *out);

/* Collective for a handle opened with a communicator. Closes a read handle
 * (a writable handle is discarded). Safe on *h == NULL. Sets *h = NULL. */
gs_err gs_ckpt_close(gs_ckpt_t *h);

/* Serial, cheap: reads only what `geosynth resume RUN_DIR` needs to pick the
 * engine: validates the file like gs_ckpt_open (any engine), copies the
 * engine name into engine[engine_len] and, when config_text != NULL, sets
 * *config_text to a gs_malloc'ed copy of /geosynth/config (free with
 * gs_free). On error the outputs are unchanged. */
gs_err gs_ckpt_peek(const char *path, char *engine, size_t engine_len,
                    char **config_text);

/* Serial. Opens path like gs_ckpt_open (engine may be NULL) and reads every
 * attribute and every byte of every dataset, so that each checksum the file
 * holds is checked: the metadata checksums of the 1.10 format, the
 * Fletcher32 checksum of every data chunk and /geosynth@config_digest.
 * GS_ERR_FORMAT "PATH is damaged: OBJECT: ..." on the first failure. Costs
 * one read of the file. */
gs_err gs_ckpt_verify(const char *path, const char *engine);

/* Serial. The digest of what an HDF5 output holds (#25: the run digest
 * covers every output file): every object's name, every attribute and every
 * dataset's shape and bytes, in name order, read back from the file. Left
 * out, as the bytes of the file are: the identity group /geosynth (config
 * text with the run directory, creation time, program version) and the
 * string attributes that name an input file by path ("example",
 * "mesh_source"); the inputs' contents are recorded in start.ini instead.
 * Equal for equal contents whatever rank count wrote the file.
 * GS_ERR_IO / GS_ERR_FORMAT naming the file when it cannot be read. */
gs_err gs_h5_content_digest(const char *path, uint64_t *hash);

/* Identity of an open file (valid until close; never NULL). For a handle
 * being written these return what gs_ckpt_create wrote. */
const char *gs_ckpt_path(gs_ckpt_t h);
const char *gs_ckpt_engine(gs_ckpt_t h);
const char *gs_ckpt_program_version(gs_ckpt_t h);
const char *gs_ckpt_config(gs_ckpt_t h);
const char *gs_ckpt_created(gs_ckpt_t h);
int gs_ckpt_format_version(gs_ckpt_t h);
uint64_t gs_ckpt_seed(gs_ckpt_t h);

/* ---- engine state attributes -------------------------------------------
 * object is the path of a group or dataset ("/field", "/model/lattice");
 * setters create missing groups along the path and replace an existing
 * attribute of that name. Setters are collective (same value on every
 * rank). Getters read any integer/float/string attribute that converts
 * exactly (an int64 getter rejects a uint64 above INT64_MAX, for instance),
 * may be called by any rank of a read handle, and return GS_ERR_FORMAT when
 * the attribute is missing or of another kind. String values are limited
 * to 60000 bytes (HDF5 compact attribute storage). gs_ckpt_get_str sets
 * *value to a gs_malloc'ed string (free with gs_free). On error outputs
 * are unchanged. */
gs_err gs_ckpt_set_i64(gs_ckpt_t h, const char *object, const char *name, int64_t value);
gs_err gs_ckpt_set_u64(gs_ckpt_t h, const char *object, const char *name, uint64_t value);
gs_err gs_ckpt_set_f64(gs_ckpt_t h, const char *object, const char *name, double value);
gs_err gs_ckpt_set_str(gs_ckpt_t h, const char *object, const char *name, const char *value);
gs_err gs_ckpt_get_i64(gs_ckpt_t h, const char *object, const char *name, int64_t *value);
gs_err gs_ckpt_get_u64(gs_ckpt_t h, const char *object, const char *name, uint64_t *value);
gs_err gs_ckpt_get_f64(gs_ckpt_t h, const char *object, const char *name, double *value);
gs_err gs_ckpt_get_str(gs_ckpt_t h, const char *object, const char *name, char **value);

/* Sets *exists to 1 when a group or dataset exists at path, else 0.
 * Intermediate groups may be missing. Local. */
gs_err gs_ckpt_exists(gs_ckpt_t h, const char *path, int *exists);

/* Collective. Creates a group (and missing parents); no-op if it exists. */
gs_err gs_ckpt_group(gs_ckpt_t h, const char *path);

/* ---- arrays ------------------------------------------------------------ */

/* Collective. Creates dataset path (parents created) with the global shape
 * and writes this rank's rows [start, start+count) of dims[0] from data
 * (count * prod(dims[1..]) elements, C order). count may be 0. The slabs of
 * all ranks must tile [0, dims[0]) exactly (checked: GS_ERR_ARG). An
 * existing dataset of that name is an error (GS_ERR_ARG). */
gs_err gs_ckpt_write_slab(gs_ckpt_t h, const char *path, const gs_h5_shape *shape,
                          uint64_t start, uint64_t count, const void *data,
                          const gs_h5_write_opts *opts);

/* Collective. For small arrays every rank holds in full: rank 0's copy is
 * written (data of other ranks is ignored and may be NULL). */
gs_err gs_ckpt_write_whole(gs_ckpt_t h, const char *path, const gs_h5_shape *shape,
                           const void *data, const gs_h5_write_opts *opts);

/* Local. Shape and type of dataset path; GS_ERR_FORMAT when it is missing,
 * not a dataset, of rank 0 or > GS_H5_MAX_RANK, or of an unsupported type
 * (named in the message). On error *out is unchanged. */
gs_err gs_ckpt_shape(gs_ckpt_t h, const char *path, gs_h5_shape *out);

/* Local. GS_ERR_FORMAT when dataset path (of shape s, from gs_ckpt_shape)
 * has less storage in the file than its data needs, allowing deflate's
 * largest ratio (1032:1): a dataset declared but never written (an 11 KB
 * file declaring float32 [1024 x 1024 x 1024] made a field run allocate
 * 14 GB) is refused before its memory is allocated. For example inputs. */
gs_err gs_ckpt_check_stored(gs_ckpt_t h, const char *path, const gs_h5_shape *s);

/* Collective. Validates that dataset path has exactly the shape and type in
 * expect (GS_ERR_FORMAT otherwise, message shows both), then reads rows
 * [start, start+count) of dims[0] into data. Any decomposition works
 * (slabs may differ from the writer's and may overlap). */
gs_err gs_ckpt_read_slab(gs_ckpt_t h, const char *path, const gs_h5_shape *expect,
                         uint64_t start, uint64_t count, void *data);

/* Collective. Every rank reads the whole dataset (validated as above). */
gs_err gs_ckpt_read_whole(gs_ckpt_t h, const char *path, const gs_h5_shape *expect,
                          void *data);

/* ---- XDMF sidecars ------------------------------------------------------
 * gs_xdmf_write("run/out.h5", ...) writes "run/out.xmf" (atomically) that
 * points ParaView at datasets of out.h5 (referenced by basename, so the pair
 * can be moved together). One uniform 3D grid (3DCoRectMesh) per sidecar.
 *
 * Centering: a FIELD (distance field, density) holds samples AT grid
 * points: GS_XDMF_NODE, topology dims = data dims. A LABEL LATTICE holds one
 * value PER VOXEL: GS_XDMF_CELL, topology dims = data dims + 1 per axis, and
 * origin is the corner of voxel (0,0,0). XDMF lists dims, origin and spacing
 * slowest first (z y x); this API takes origin and spacing as x, y, z and
 * reorders. Local: call on one rank (rank 0) after the .h5 is committed. */
typedef enum gs_xdmf_center { GS_XDMF_NODE = 0, GS_XDMF_CELL = 1 } gs_xdmf_center;

typedef struct gs_xdmf_grid {
    const char *name;      /* grid name shown in ParaView */
    gs_xdmf_center center;
    uint64_t dims[3];      /* data dims slowest first {nz, ny, nx} */
    double origin[3];      /* x, y, z */
    double spacing[3];     /* dx, dy, dz (> 0) */
    uint64_t frames;       /* 0 or 1: one grid; T > 1: a time series (ParaView plays it),
                              every dataset [T][dims...] and frame t its hyperslab t */
} gs_xdmf_grid;

typedef struct gs_xdmf_attr {
    const char *name;      /* attribute name in ParaView */
    const char *dataset;   /* HDF5 path inside the .h5, dims == grid.dims (+ [components]) */
    gs_h5_type type;
    int components;        /* 0 or 1: a scalar; 3: a vector (e.g. an RGB colour per cell) */
} gs_xdmf_attr;

gs_err gs_xdmf_write(const char *h5_path, const gs_xdmf_grid *grid,
                     const gs_xdmf_attr *attrs, int nattrs);

/* The sidecar path for h5_path: ".h5" replaced by ".xmf" (appended when
 * the name has no .h5 suffix). GS_ERR_ARG when it does not fit in len. */
gs_err gs_xdmf_path(const char *h5_path, char *out, size_t len);

/* ---- inspect ------------------------------------------------------------ */

typedef struct gs_inspect_opts {
    int config_lines;        /* config lines shown (0 = all); default 40 */
    uint64_t sample_values;  /* max values read per dataset for min/max/mean;
                                larger datasets are sampled on a regular
                                grid (said in the output); default 1<<22 */
} gs_inspect_opts;

/* Serial. Prints a human-readable summary of any geosynth HDF5 file to out:
 * the /geosynth identity, the config (first 40 lines, with a note of how
 * many are left out), every group and dataset with shape, type, storage
 * and, for numeric datasets, min/max/mean, and all attributes (engine
 * state). A valid HDF5 file without /geosynth still gets its structure
 * listed, then GS_ERR_FORMAT "not a geosynth file". Not HDF5 / truncated /
 * missing: an error naming the path, nothing listed. Bounded cost: at most
 * sample_values values read per dataset. */
gs_err gs_inspect_file(const char *path, FILE *out);
gs_err gs_inspect_file_opts(const char *path, FILE *out, const gs_inspect_opts *opts);
/* The same for an in-memory file image (serial; used by the fuzzer). */
gs_err gs_inspect_image(const void *buf, size_t len, const char *name, FILE *out,
                        const gs_inspect_opts *opts);

/* "HDF5 x.y.z (parallel)" of the library linked in; static storage. */
const char *gs_h5_library_version(void);

#endif
