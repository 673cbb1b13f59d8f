/* The PLY header and item reader shared by the point-set reader
 * (src/io/pointply.c) and the mesh reader (src/io/meshread.c).
 *
 * Bounded by construction: header lines of at most 511 bytes, at most
 * GS_PLY_MAX_ELEMS elements of GS_PLY_MAX_PROPS properties, element counts up
 * to 2^31, list lengths up to GS_PLY_MAX_LIST; every read checks the bytes
 * left first, so a mutated file gives an error naming the line or byte and
 * never reads past the end. Elements without properties cost nothing to skip
 * (gs_ply_skip_elem), whatever their count. Formats: ascii,
 * binary_little_endian, binary_big_endian (all 1.0).
 */
#ifndef GEOSYNTH_PLY_INTERNAL_H
#define GEOSYNTH_PLY_INTERNAL_H

#include <stddef.h>

#include "geosynth/error.h"

#define GS_PLY_MAX_ELEMS 32
#define GS_PLY_MAX_PROPS 64
#define GS_PLY_MAX_LIST 1000000
#define GS_PLY_MAX_COUNT ((size_t)1 << 31)

enum { GS_PLY_I8, GS_PLY_U8, GS_PLY_I16, GS_PLY_U16, GS_PLY_I32, GS_PLY_U32, GS_PLY_F32,
       GS_PLY_F64, GS_PLY_NTYPES };

/* Roles a caller gives properties after gs_ply_header: >= 0 stores a scalar
 * into vals[role]; GS_PLY_ROLE_LIST stores a list's values into the list
 * buffer; GS_PLY_ROLE_SKIP (the default) skips it. */
#define GS_PLY_ROLE_SKIP (-1)
#define GS_PLY_ROLE_LIST (-2)

typedef struct gs_ply_prop {
    char name[64];
    int type;       /* value type */
    int list;       /* 1: list property */
    int count_type; /* list count type */
    int role;
} gs_ply_prop;

typedef struct gs_ply_elem {
    char name[64];
    size_t count;
    gs_ply_prop props[GS_PLY_MAX_PROPS];
    int nprops;
    int line;
} gs_ply_elem;

typedef struct gs_ply {
    const char *name; /* for messages */
    const char *data;
    size_t len, pos;
    int line;       /* ASCII: current line (1-based) */
    int ascii;      /* format ascii */
    int big_endian; /* binary_big_endian */
    gs_ply_elem *elems; /* GS_PLY_MAX_ELEMS (gs_ply_begin allocates) */
    int nelems;
} gs_ply;

/* Parses the header of data[len] (allocates r->elems; gs_ply_end frees
 * them); on success r->pos is the first data byte. */
gs_err gs_ply_begin(gs_ply *r, const char *data, size_t len, const char *name);
void gs_ply_end(gs_ply *r);

/* Index of the element called name, or -1. */
int gs_ply_find_elem(const gs_ply *r, const char *name);
/* Index of the first property of e named one of names[0..n-1], or -1. */
int gs_ply_find_prop(const gs_ply_elem *e, const char *const *names, int n);

/* Checks that e's count of items can fit in the bytes left (binary: each
 * item's fixed bytes; ascii: at least one character and a blank per value),
 * so callers may allocate count items afterwards. */
gs_err gs_ply_check_fits(const gs_ply *r, const gs_ply_elem *e);

/* Reads (or skips) item `item` of element e: scalar roles into vals (sized by
 * the caller for its highest role), the GS_PLY_ROLE_LIST property's values
 * into list[0..*list_n-1] (at most list_cap of them; a longer list is an
 * error naming the item). list may be NULL when no property has that role. */
gs_err gs_ply_item(gs_ply *r, const gs_ply_elem *e, size_t item, double *vals, double *list,
                   size_t list_cap, size_t *list_n);

/* ASCII: skips blanks and line ends before an item (counting lines), so
 * r->line and r->pos say where the item starts. */
void gs_ply_skip_blanks(gs_ply *r);

/* Skips every item of e (O(1) for elements without properties). */
gs_err gs_ply_skip_elem(gs_ply *r, const gs_ply_elem *e);

#endif
