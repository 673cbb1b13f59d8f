/* Internal: the small XML reader of the tile-set loaders (tileset.c: mxgmn's
 * 2D sets, tileset3d.c: MarkovJunior's 3D sets). Elements with attributes,
 * comments, <?...?> and <!...> declarations, the five predefined entities and
 * numeric character references; text content is ignored. Errors name file
 * and line. */
#ifndef GEOSYNTH_MODEL_TILESET_IMPL_H
#define GEOSYNTH_MODEL_TILESET_IMPL_H

#include <stddef.h>

#include "geosynth/error.h"
#include "geosynth/model_tiles.h"

#define XML_MAX_ATTRS 16

typedef struct xml_elem {
    char *name;
    int nattr;
    char *key[XML_MAX_ATTRS];
    char *val[XML_MAX_ATTRS];
    int parent; /* index, -1 for the root */
    int line;
} xml_elem;

typedef struct xml_doc {
    char *buf; /* the file, names and values are cut out of it in place */
    xml_elem *e;
    int n, cap;
    const char *file;
} xml_doc;

/* Parses path into d (names and values cut out of one buffer); on error d is
 * zeroed. Free with gs_tsxml_free. */
gs_err gs_tsxml_parse(const char *path, xml_doc *d);
void gs_tsxml_free(xml_doc *d);
/* Value of attribute key of e, or NULL. */
const char *gs_tsxml_attr(const xml_elem *e, const char *key);

/* ---- lenient JSON (DeBroglie configs: line and block comments, trailing commas) */

enum { TSJ_NULL, TSJ_BOOL, TSJ_NUM, TSJ_STR, TSJ_ARR, TSJ_OBJ };

typedef struct tsjson_node {
    int type;
    char *key;   /* member name inside an object, else NULL */
    char *str;   /* TSJ_STR: decoded text */
    double num;  /* TSJ_NUM, TSJ_BOOL (0 / 1) */
    int first;   /* first child (arrays, objects), -1 none */
    int next;    /* next sibling, -1 none */
    int line;
} tsjson_node;

typedef struct tsjson_doc {
    char *buf;
    tsjson_node *n; /* n[0] is the root */
    int count, cap;
    const char *file;
} tsjson_doc;

/* Parses path; errors name file and line. On error d is zeroed. */
gs_err gs_tsjson_parse(const char *path, tsjson_doc *d);
void gs_tsjson_free(tsjson_doc *d);
/* Member key of object node obj, or -1. */
int gs_tsjson_get(const tsjson_doc *d, int obj, const char *key);

/* ---- shared by the loaders ------------------------------------------------ */

/* Sorts pairs by (dir, a, b) and drops duplicates; returns the new count. */
size_t gs_tileset_pairs_unique(gs_model_pair *pairs, size_t n);
/* The 3D loaders (tileset3d.c); *out zeroed. d is the parsed MarkovJunior XML. */
gs_err gs_tileset3d_load_mj(const char *path, const xml_doc *d, const char *folder,
                            gs_model_tileset *out);
gs_err gs_tileset3d_load_debroglie(const char *path, gs_model_tileset *out);

#endif
