/* Minimal JSON writer for machine-readable results (metrics.jsonl,
 * summary.json, benchmark output). Builds text in a growing buffer; strings
 * are escaped, non-finite numbers become null. Nesting is tracked so commas
 * are placed automatically:
 *
 *     gs_json j; gs_json_init(&j);
 *     gs_json_begin_object(&j, NULL);
 *     gs_json_str(&j, "engine", "field");
 *     gs_json_f64(&j, "seconds", 1.5);
 *     gs_json_end_object(&j);
 *     ... j.buf holds the text ...; gs_json_free(&j);
 *
 * Allocation failure is sticky: j.failed is set and later calls do nothing.
 */
#ifndef GEOSYNTH_JSON_H
#define GEOSYNTH_JSON_H

#include <stddef.h>
#include <stdint.h>

#define GS_JSON_MAX_DEPTH 32

typedef struct gs_json {
    char *buf;
    size_t len, cap;
    int depth;
    int count[GS_JSON_MAX_DEPTH]; /* members written at each depth */
    int failed;
} gs_json;

void gs_json_init(gs_json *j);
void gs_json_free(gs_json *j);

/* key is NULL inside arrays and at top level. */
void gs_json_begin_object(gs_json *j, const char *key);
void gs_json_end_object(gs_json *j);
void gs_json_begin_array(gs_json *j, const char *key);
void gs_json_end_array(gs_json *j);
void gs_json_str(gs_json *j, const char *key, const char *value);
void gs_json_f64(gs_json *j, const char *key, double value);
void gs_json_i64(gs_json *j, const char *key, int64_t value);
void gs_json_u64(gs_json *j, const char *key, uint64_t value);
/* A 64-bit seed both ways: "key": the number (read exactly by every JSON
 * reader only below 2^53) and "key_string": its decimal text (exact in jq,
 * JavaScript and everywhere else). docs/FORMATS.md, "Seeds in JSON". */
void gs_json_seed(gs_json *j, const char *key, uint64_t value);
void gs_json_bool(gs_json *j, const char *key, int value);
/* Inserts already-formatted JSON text as a value. */
void gs_json_raw(gs_json *j, const char *key, const char *json_text);
/* Inside an object: adds the members of another object's text ("{...}"). */
void gs_json_merge(gs_json *j, const char *object_json);

#endif
