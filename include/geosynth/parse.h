/* Bounded, checked number parsing for user text (configs, CLI, text files).
 * Never atoi/atof/sscanf on user input.
 *
 * Each parser accepts the whole string (leading/trailing blanks allowed) or
 * fails. On failure it writes a short reason into why[why_len] such as
 * "expected an integer in [1, 256], got '12x'" and returns 0; *out is left
 * unchanged. why may be NULL.
 */
#ifndef GEOSYNTH_PARSE_H
#define GEOSYNTH_PARSE_H

#include <stddef.h>
#include <stdint.h>

int gs_parse_i64(const char *s, int64_t lo, int64_t hi, int64_t *out, char *why,
                 size_t why_len);
int gs_parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out, char *why,
                 size_t why_len);
/* Finite doubles only (NaN and infinities are rejected). */
int gs_parse_f64(const char *s, double lo, double hi, double *out, char *why,
                 size_t why_len);
/* true/false, yes/no, on/off, 1/0 (case-insensitive). */
int gs_parse_bool(const char *s, int *out, char *why, size_t why_len);

/* Parses an integer prefix at *p (no leading blanks) and advances *p past it.
 * For tokenizing text formats. Returns 0 when no digits or out of range. */
int gs_scan_i64(const char **p, int64_t lo, int64_t hi, int64_t *out);

#endif
