/* Typed configuration tables: INI parsing, validation, overrides, help and
 * the resolved text; see include/geosynth/config.h. No MPI here (the
 * collective loader is src/run/config_load.c) so the fuzzer can drive it. */
#include "geosynth/config.h"

#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "geosynth/data.h"
#include "geosynth/file.h"
#include "geosynth/mem.h"
#include "geosynth/parse.h"

/* Files larger than this are not configs (a mistaken -c data.h5). */
#define CFG_MAX_FILE (64u << 20)
/* Longest value quoted back in a message. */
#define CFG_QUOTE_MAX 80

/* ------------------------------------------------------------------ text */

typedef struct sbuf {
    char *s;
    size_t n, cap;
    int oom;
} sbuf;

static void sb_vadd(sbuf *b, const char *fmt, va_list ap)
{
    if (b->oom)
        return;
    va_list aq;
    va_copy(aq, ap);
    int need = vsnprintf(NULL, 0, fmt, aq);
    va_end(aq);
    if (need < 0) {
        b->oom = 1;
        return;
    }
    if (b->n + (size_t)need + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 256;
        while (cap < b->n + (size_t)need + 1)
            cap *= 2;
        char *s = gs_realloc(b->s, cap);
        if (!s) {
            b->oom = 1;
            return;
        }
        b->s = s;
        b->cap = cap;
    }
    vsnprintf(b->s + b->n, b->cap - b->n, fmt, ap);
    b->n += (size_t)need;
}

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static void sb_add(sbuf *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    sb_vadd(b, fmt, ap);
    va_end(ap);
}

static char *str_dup(const char *s)
{
    size_t n = strlen(s);
    char *d = gs_malloc(n + 1);
    if (d)
        memcpy(d, s, n + 1);
    return d;
}

static char *str_ndup(const char *s, size_t n)
{
    char *d = gs_malloc(n + 1);
    if (d) {
        memcpy(d, s, n);
        d[n] = '\0';
    }
    return d;
}

static char *lskip(const char *s)
{
    while (*s && isspace((unsigned char)*s))
        s++;
    return (char *)s;
}

static char *rstrip(char *s)
{
    char *p = s + strlen(s);
    while (p > s && isspace((unsigned char)p[-1]))
        *--p = '\0';
    return s;
}

/* A value as quoted in messages: cut to CFG_QUOTE_MAX bytes. */
static void quote(char *out, size_t outlen, const char *v)
{
    size_t n = strlen(v);
    if (n <= CFG_QUOTE_MAX)
        snprintf(out, outlen, "%s", v);
    else
        snprintf(out, outlen, "%.*s...", CFG_QUOTE_MAX, v);
}

/* -------------------------------------------------------------- problems */

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static void problem_add(gs_cfg_problems *p, const char *fmt, ...)
{
    p->n++;
    if (p->nkept >= GS_CFG_MAX_PROBLEMS)
        return;
    sbuf b = {0};
    va_list ap;
    va_start(ap, fmt);
    sb_vadd(&b, fmt, ap);
    va_end(ap);
    if (b.oom || !b.s) {
        gs_free(b.s);
        return; /* counted in n; the summary still says how many */
    }
    gs_text_sanitize(b.s); /* problems quote config lines and --set values */
    char **msg = gs_realloc(p->msg, (p->nkept + 1) * sizeof *msg);
    if (!msg) {
        gs_free(b.s);
        return;
    }
    p->msg = msg;
    p->msg[p->nkept++] = b.s;
}

void gs_cfg_problems_print(const gs_cfg_problems *p, FILE *f)
{
    for (size_t i = 0; i < p->nkept; i++)
        fprintf(f, "error: %s\n", p->msg[i]);
    if (p->n > p->nkept)
        fprintf(f, "error: ... and %zu more problems\n", p->n - p->nkept);
}

void gs_cfg_problems_free(gs_cfg_problems *p)
{
    for (size_t i = 0; i < p->nkept; i++)
        gs_free(p->msg[i]);
    gs_free(p->msg);
    p->msg = NULL;
    p->nkept = 0;
    p->n = 0;
}

/* ------------------------------------------------------------- tokenizer */

/* inih's find_chars_or_comment: first char of chars, or an inline comment
 * (';' or '#' preceded by a blank), or the end. */
static char *find_chars_or_comment(const char *s, const char *chars)
{
    int was_space = 0;
    while (*s && (!chars || !strchr(chars, *s)) && !(was_space && (*s == ';' || *s == '#'))) {
        was_space = isspace((unsigned char)*s);
        s++;
    }
    return (char *)s;
}

int gs_ini_scan(const char *text, size_t len, gs_ini_fn fn, void *user)
{
    size_t pos = 0;
    int lineno = 0;
    if (len >= 3 && (unsigned char)text[0] == 0xEF && (unsigned char)text[1] == 0xBB &&
        (unsigned char)text[2] == 0xBF)
        pos = 3;
    size_t bufcap = (len < GS_CFG_MAX_LINE ? len : GS_CFG_MAX_LINE) + 1;
    char *buf = gs_malloc(bufcap);
    char *section = gs_malloc(bufcap);
    if (!buf || !section) {
        gs_free(buf);
        gs_free(section);
        if (fn)
            fn(user, 1, "", NULL, NULL, "out of memory while reading the text");
        return 0;
    }
    section[0] = '\0';
    char why[96];
    while (pos < len) {
        lineno++;
        const char *line = text + pos;
        const char *eol = memchr(line, '\n', len - pos);
        size_t n = eol ? (size_t)(eol - line) : len - pos;
        pos += n + (eol ? 1 : 0);
        if (n + 1 > GS_CFG_MAX_LINE) {
            snprintf(why, sizeof why, "line is %zu bytes long (at most %d allowed)", n,
                     GS_CFG_MAX_LINE - 1);
            fn(user, lineno, section, NULL, NULL, why);
            continue;
        }
        if (n && line[n - 1] == '\r')
            n--; /* CRLF files */
        size_t bad = n;
        for (size_t i = 0; i < n; i++) {
            unsigned char c = (unsigned char)line[i];
            if ((c < 0x20 && c != '\t') || c == 0x7f) {
                bad = i;
                break;
            }
        }
        if (bad < n) {
            snprintf(why, sizeof why, "control character 0x%02x at column %zu",
                     (unsigned char)line[bad], bad + 1);
            fn(user, lineno, section, NULL, NULL, why);
            continue;
        }
        memcpy(buf, line, n);
        buf[n] = '\0';
        char *start = lskip(rstrip(buf));
        if (*start == '\0' || *start == ';' || *start == '#')
            continue;
        if (*start == '[') {
            char *end = find_chars_or_comment(start + 1, "]");
            if (*end != ']') {
                fn(user, lineno, section, NULL, NULL, "section header without closing ']'");
                continue;
            }
            *end = '\0';
            char *rest = lskip(end + 1);
            if (*rest && *rest != ';' && *rest != '#') {
                fn(user, lineno, section, NULL, NULL, "text after the section header's ']'");
                continue;
            }
            char *name = rstrip(lskip(start + 1));
            if (*name == '\0') {
                fn(user, lineno, section, NULL, NULL, "empty section name");
                continue;
            }
            memmove(section, name, strlen(name) + 1);
            fn(user, lineno, section, NULL, NULL, NULL);
            continue;
        }
        char *end = find_chars_or_comment(start, "=:");
        if (*end != '=' && *end != ':') {
            fn(user, lineno, section, NULL, NULL,
               "expected 'name = value', '[section]' or a comment");
            continue;
        }
        *end = '\0';
        char *name = rstrip(start);
        char *value = end + 1;
        char *cut = find_chars_or_comment(value, NULL);
        *cut = '\0';
        value = rstrip(lskip(value));
        if (*name == '\0') {
            fn(user, lineno, section, NULL, NULL, "missing key name before '='");
            continue;
        }
        fn(user, lineno, section, name, value, NULL);
    }
    gs_free(buf);
    gs_free(section);
    return lineno;
}

/* ------------------------------------------------------------ key names */

/* Length of the section part of "sec.sub.key" (up to the last dot). */
static size_t section_len(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot ? (size_t)(dot - name) : 0;
}

static const char *key_part(const char *name)
{
    const char *dot = strrchr(name, '.');
    return dot ? dot + 1 : name;
}

static int same_section(const char *name, const char *section)
{
    size_t n = section_len(name);
    return strlen(section) == n && !strncmp(name, section, n);
}

const gs_cfg_key *gs_config_find(const gs_cfg_table *t, const char *name)
{
    for (size_t i = 0; i < t->nkeys; i++)
        if (!strcmp(t->keys[i].name, name))
            return &t->keys[i];
    return NULL;
}

static ptrdiff_t find_in_section(const gs_cfg_table *t, const char *section, const char *key)
{
    for (size_t i = 0; i < t->nkeys; i++)
        if (same_section(t->keys[i].name, section) && !strcmp(key_part(t->keys[i].name), key))
            return (ptrdiff_t)i;
    return -1;
}

static int section_known(const gs_cfg_table *t, const char *section)
{
    for (size_t i = 0; i < t->nkeys; i++)
        if (same_section(t->keys[i].name, section))
            return 1;
    return 0;
}

/* Case-insensitive edit distance (Levenshtein plus adjacent transpositions,
 * so "feild" is one edit from "field") of a[0..na) and b[0..nb); names
 * longer than 64 bytes get no suggestion. */
static size_t edit_distance(const char *a, size_t na, const char *b, size_t nb)
{
    if (na > 64 || nb > 64)
        return SIZE_MAX;
    size_t rows[3][65];
    size_t *prev2 = rows[0], *prev = rows[1], *cur = rows[2];
    for (size_t j = 0; j <= nb; j++)
        prev[j] = j;
    for (size_t i = 1; i <= na; i++) {
        cur[0] = i;
        int ai = tolower((unsigned char)a[i - 1]);
        for (size_t j = 1; j <= nb; j++) {
            int bj = tolower((unsigned char)b[j - 1]);
            size_t best = prev[j - 1] + (ai != bj);
            if (prev[j] + 1 < best)
                best = prev[j] + 1;
            if (cur[j - 1] + 1 < best)
                best = cur[j - 1] + 1;
            if (i > 1 && j > 1 && ai == tolower((unsigned char)b[j - 2]) &&
                tolower((unsigned char)a[i - 2]) == bj && prev2[j - 2] + 1 < best)
                best = prev2[j - 2] + 1;
            cur[j] = best;
        }
        size_t *t = prev2;
        prev2 = prev;
        prev = cur;
        cur = t;
    }
    return prev[nb];
}

/* Largest distance still worth suggesting for a name of n bytes. */
static size_t close_enough(size_t n)
{
    size_t d = n / 3;
    return d < 1 ? 1 : d > 3 ? 3 : d;
}

/* Suggestion for an unknown key in a known section (or in no section):
 * the nearest key name, preferring the same section on ties; writes "" when
 * nothing is close. */
static void suggest_key(const gs_cfg_table *t, const char *section, const char *key, char *out,
                        size_t outlen)
{
    size_t best = SIZE_MAX, besti = 0;
    size_t nk = strlen(key);
    for (size_t i = 0; i < t->nkeys; i++) {
        const char *kn = key_part(t->keys[i].name);
        size_t d = edit_distance(key, nk, kn, strlen(kn));
        /* "field.block" written inside a section or before any section */
        size_t dfull = edit_distance(key, nk, t->keys[i].name, strlen(t->keys[i].name));
        if (dfull < d)
            d = dfull;
        if (d == SIZE_MAX || d > close_enough(nk))
            continue;
        size_t score = 2 * d + !same_section(t->keys[i].name, section);
        if (score < best) {
            best = score;
            besti = i;
        }
    }
    if (best == SIZE_MAX) {
        snprintf(out, outlen, " (see geosynth %s --help)", t->engine);
        return;
    }
    const char *name = t->keys[besti].name;
    if (same_section(name, section))
        snprintf(out, outlen, "; did you mean '%s'?", key_part(name));
    else
        snprintf(out, outlen, "; did you mean '%s' in section [%.*s]?", key_part(name),
                 (int)section_len(name), name);
}

static void suggest_section(const gs_cfg_table *t, const char *section, char *out,
                            size_t outlen)
{
    size_t best = SIZE_MAX, besti = 0, ns = strlen(section);
    for (size_t i = 0; i < t->nkeys; i++) {
        size_t d = edit_distance(section, ns, t->keys[i].name, section_len(t->keys[i].name));
        if (d <= close_enough(ns) && d < best) {
            best = d;
            besti = i;
        }
    }
    if (best != SIZE_MAX) {
        snprintf(out, outlen, "; did you mean [%.*s]?", (int)section_len(t->keys[besti].name),
                 t->keys[besti].name);
        return;
    }
    /* Nothing close: list the sections (in table order, each once). */
    sbuf b = {0};
    for (size_t i = 0; i < t->nkeys; i++) {
        const char *n = t->keys[i].name;
        size_t sl = section_len(n);
        int seen = 0;
        for (size_t j = 0; j < i && !seen; j++)
            seen = section_len(t->keys[j].name) == sl && !strncmp(t->keys[j].name, n, sl);
        if (!seen)
            sb_add(&b, "%s[%.*s]", b.n ? " " : "", (int)sl, n);
    }
    snprintf(out, outlen, " (sections: %s)", b.s && !b.oom ? b.s : "?");
    gs_free(b.s);
}

static void suggest_full(const gs_cfg_table *t, const char *full, char *out, size_t outlen)
{
    size_t best = SIZE_MAX, besti = 0, nf = strlen(full);
    for (size_t i = 0; i < t->nkeys; i++) {
        size_t d = edit_distance(full, nf, t->keys[i].name, strlen(t->keys[i].name));
        if (d <= close_enough(nf) && d < best) {
            best = d;
            besti = i;
        }
    }
    if (best != SIZE_MAX)
        snprintf(out, outlen, "; did you mean '%s'?", t->keys[besti].name);
    else
        snprintf(out, outlen, " (see geosynth %s --help)", t->engine);
}

/* --------------------------------------------------------------- values */

static int64_t bound_i64(double v)
{
    if (v <= -9223372036854775808.0)
        return INT64_MIN;
    if (v >= 9223372036854775807.0)
        return INT64_MAX;
    return (int64_t)v;
}

static int is_pow2(int64_t v) { return v > 0 && (v & (v - 1)) == 0; }

/* What a key accepts, with an article: "an integer in [2, 64]". */
static void format_real(double v, char *out, size_t outlen);

static void describe(const gs_cfg_key *k, char *out, size_t outlen)
{
    long long lo = (long long)bound_i64(k->lo), hi = (long long)bound_i64(k->hi);
    const char *p2 = (k->flags & GS_CFG_POW2) ? " power of two" : "";
    char range[96];
    if (k->type == GS_CFG_INT || k->type == GS_CFG_INT3) {
        if (hi == INT64_MAX && lo == INT64_MIN)
            snprintf(range, sizeof range, "%s", "");
        else if (hi == INT64_MAX)
            snprintf(range, sizeof range, " >= %lld", lo);
        else
            snprintf(range, sizeof range, " in [%lld, %lld]", lo, hi);
    } else {
        char a[40], b[40];
        format_real(k->lo, a, sizeof a);
        format_real(k->hi, b, sizeof b);
        snprintf(range, sizeof range, " in %c%s, %s]", (k->flags & GS_CFG_OPEN_LO) ? '(' : '[',
                 a, b);
    }
    switch (k->type) {
    case GS_CFG_INT: snprintf(out, outlen, "an integer%s%s", p2, range); break;
    case GS_CFG_REAL: snprintf(out, outlen, "a number%s", range); break;
    case GS_CFG_BOOL: snprintf(out, outlen, "true or false"); break;
    case GS_CFG_STRING: snprintf(out, outlen, "text"); break;
    case GS_CFG_PATH: snprintf(out, outlen, "a path"); break;
    case GS_CFG_ENUM: snprintf(out, outlen, "one of %s", k->choices ? k->choices : "?"); break;
    case GS_CFG_INT3:
        snprintf(out, outlen, "one or three integers%s%s, like 64 or 64x32x16",
                 *p2 ? " (powers of two)" : "", range);
        break;
    case GS_CFG_REAL_LIST:
        snprintf(out, outlen, "a list of numbers%s, separated by commas or blanks", range);
        break;
    default: snprintf(out, outlen, "?"); break;
    }
}

static int empty_ok(const gs_cfg_key *k) { return k->def && k->def[0] == '\0'; }

/* One integer element of an INT or INT3 key. */
static int parse_int_elem(const gs_cfg_key *k, const char *s, int64_t *out, char *why,
                          size_t wl, const char *what)
{
    char exp[200], pwhy[160];
    describe(k, exp, sizeof exp);
    int64_t v;
    if (!gs_parse_i64(s, INT64_MIN, INT64_MAX, &v, pwhy, sizeof pwhy)) {
        snprintf(why, wl, "expected %s%s%s", exp, what,
                 strstr(pwhy, "out of range") ? " (out of range)" : "");
        return 0;
    }
    if (v < bound_i64(k->lo) || v > bound_i64(k->hi)) {
        snprintf(why, wl, "expected %s%s (out of range)", exp, what);
        return 0;
    }
    if ((k->flags & GS_CFG_POW2) && !is_pow2(v)) {
        snprintf(why, wl, "expected %s%s (not a power of two)", exp, what);
        return 0;
    }
    *out = v;
    return 1;
}

static int parse_real_elem(const gs_cfg_key *k, const char *s, double *out, char *why,
                           size_t wl, const char *what)
{
    char exp[200], pwhy[160];
    describe(k, exp, sizeof exp);
    double v;
    if (!gs_parse_f64(s, -DBL_MAX, DBL_MAX, &v, pwhy, sizeof pwhy)) {
        const char *tail = strstr(pwhy, "not finite")  ? " (not finite)"
                           : strstr(pwhy, "overflow") ? " (overflow)"
                           : strstr(pwhy, "range")    ? " (out of range)"
                                                      : "";
        snprintf(why, wl, "expected %s%s%s", exp, what, tail);
        return 0;
    }
    if (v < k->lo || v > k->hi || ((k->flags & GS_CFG_OPEN_LO) && v <= k->lo)) {
        snprintf(why, wl, "expected %s%s (out of range)", exp, what);
        return 0;
    }
    *out = v == 0 ? 0.0 : v; /* no -0: it would print as "-0" and differ from "0" */
    return 1;
}

/* Splits s at separators (any of seps, blanks around them ignored, runs of
 * blanks count as one separator). Writes token starts/ends; returns the
 * count, or -1 on an empty token ("1,,2") or too many tokens. */
static int split_tokens(const char *s, const char *seps, const char **tb, const char **te,
                        int max)
{
    int n = 0;
    const char *p = lskip(s);
    if (!*p)
        return 0;
    for (;;) {
        const char *b = p;
        while (*p && !isspace((unsigned char)*p) && !strchr(seps, *p))
            p++;
        if (p == b || n == max)
            return -1;
        tb[n] = b;
        te[n] = p;
        n++;
        p = lskip(p);
        if (!*p)
            return n;
        if (strchr(seps, *p))
            p = lskip(p + 1);
        if (!*p)
            return -1; /* trailing separator */
    }
}

/* Text that can be written back into an INI file and read as the same
 * string: no control characters, no blanks at either end, no inline
 * comment start (also none at the start: "key = ;x" reads as empty). */
static int text_round_trips(const char *s, char *why, size_t wl)
{
    size_t n = strlen(s);
    if (n && (isspace((unsigned char)s[0]) || isspace((unsigned char)s[n - 1]))) {
        snprintf(why, wl, "leading or trailing blanks cannot be kept");
        return 0;
    }
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c < 0x20 || c == 0x7f) {
            snprintf(why, wl, "control character 0x%02x in the value", c);
            return 0;
        }
        /* written back as "key = value", a first ';' or '#' follows a blank too */
        if ((c == ';' || c == '#') && (i == 0 || isspace((unsigned char)s[i - 1]))) {
            snprintf(why, wl, "'%c' %s would start a comment", c,
                     i ? "after a blank" : "at the start");
            return 0;
        }
    }
    return 1;
}

/* Absolute, lexically normalized path of value relative to base (absolute
 * directory); "~/" is $HOME, "${data}/" the data root (geosynth/data.h).
 * gs_malloc'ed, or NULL with why. */
static char *resolve_path(const char *value, const char *base, char *why, size_t wl)
{
    sbuf joined = {0};
    const char *data_rel = gs_data_relative(value);
    if (data_rel) {
        char root[PATH_MAX];
        if (!gs_data_root(root, sizeof root, NULL, why, wl))
            return NULL;
        sb_add(&joined, "%s/%s", root, data_rel);
    } else if (value[0] == '/') {
        sb_add(&joined, "%s", value);
    } else if (value[0] == '~' && (value[1] == '/' || value[1] == '\0')) {
        const char *home = getenv("HOME");
        if (!home || home[0] != '/') {
            snprintf(why, wl, "'~' needs $HOME to be set to an absolute path");
            return NULL;
        }
        sb_add(&joined, "%s/%s", home, value + 1);
    } else {
        sb_add(&joined, "%s/%s", base, value);
    }
    char *out = joined.oom ? NULL : gs_realloc(joined.s, joined.n + 2); /* gs_path_normalize */
    if (!out) {
        gs_free(joined.s);
        snprintf(why, wl, "out of memory");
        return NULL;
    }
    gs_path_normalize(out);
    /* The resolved path is what every rank, the resolved config and a resume
     * read back: "x /." normalizes to ".../x ", whose blank no config keeps. */
    char rt[96];
    if (!text_round_trips(out, rt, sizeof rt)) {
        snprintf(why, wl, "resolves to '%.*s%s', which a config cannot hold (%s)", 60, out,
                 strlen(out) > 60 ? "..." : "", rt);
        gs_free(out);
        return NULL;
    }
    return out;
}

static char *current_dir(void)
{
    size_t cap = 256;
    for (;;) {
        char *b = gs_malloc(cap);
        if (!b)
            return NULL;
        if (getcwd(b, cap))
            return b;
        gs_free(b);
        if (errno != ERANGE || cap > (1u << 20))
            return NULL;
        cap *= 2;
    }
}

static size_t member_size(gs_cfg_type type)
{
    switch (type) {
    case GS_CFG_INT: return sizeof(int64_t);
    case GS_CFG_REAL: return sizeof(double);
    case GS_CFG_BOOL: return sizeof(int);
    case GS_CFG_STRING:
    case GS_CFG_PATH:
    case GS_CFG_ENUM: return sizeof(char *);
    case GS_CFG_INT3: return 3 * sizeof(int64_t);
    case GS_CFG_REAL_LIST: return sizeof(gs_cfg_real_list);
    }
    return 0;
}

static void free_member(const gs_cfg_key *k, unsigned char *cfg)
{
    void *m = cfg + k->offset;
    if (k->type == GS_CFG_STRING || k->type == GS_CFG_PATH || k->type == GS_CFG_ENUM) {
        char **s = m;
        GS_FREE(*s);
    } else if (k->type == GS_CFG_REAL_LIST) {
        gs_cfg_real_list *l = m;
        GS_FREE(l->v);
        l->n = 0;
    }
}

/* Parses value for key k into the struct at cfg (freeing what the member
 * held). base: absolute directory for relative paths. Returns 1, or 0 with
 * why (the member unchanged). */
static int parse_value(const gs_cfg_key *k, const char *value, const char *base,
                       unsigned char *cfg, char *why, size_t wl)
{
    void *m = cfg + k->offset;
    char exp[200];
    describe(k, exp, sizeof exp);
    const char *v = lskip(value);
    size_t vn = strlen(v);
    while (vn && isspace((unsigned char)v[vn - 1]))
        vn--;
    char *trimmed = str_ndup(v, vn);
    if (!trimmed) {
        snprintf(why, wl, "out of memory");
        return 0;
    }
    int ok = 0;
    if (vn == 0 && !(empty_ok(k) && (k->type == GS_CFG_STRING || k->type == GS_CFG_PATH ||
                                     k->type == GS_CFG_REAL_LIST))) {
        snprintf(why, wl, "expected %s, got an empty value", exp);
        goto done;
    }
    switch (k->type) {
    case GS_CFG_INT: {
        int64_t x;
        if ((ok = parse_int_elem(k, trimmed, &x, why, wl, "")))
            *(int64_t *)m = x;
        break;
    }
    case GS_CFG_REAL: {
        double x;
        if ((ok = parse_real_elem(k, trimmed, &x, why, wl, "")))
            *(double *)m = x;
        break;
    }
    case GS_CFG_BOOL: {
        int b;
        if ((ok = gs_parse_bool(trimmed, &b, NULL, 0)))
            *(int *)m = b;
        else
            snprintf(why, wl, "expected true or false (yes/no, on/off, 1/0)");
        break;
    }
    case GS_CFG_STRING:
    case GS_CFG_PATH: {
        if (!text_round_trips(trimmed, why, wl))
            break;
        char *s;
        if (k->type == GS_CFG_PATH && vn > 0)
            s = resolve_path(trimmed, base, why, wl);
        else if (!(s = str_dup(trimmed)))
            snprintf(why, wl, "out of memory");
        if (!s)
            break;
        free_member(k, cfg);
        *(char **)m = s;
        ok = 1;
        break;
    }
    case GS_CFG_ENUM: {
        const char *c = k->choices ? k->choices : "";
        while (*c) {
            const char *bar = strchr(c, '|');
            size_t cn = bar ? (size_t)(bar - c) : strlen(c);
            if (cn == vn && !strncasecmp(c, trimmed, cn)) {
                char *s = str_ndup(c, cn);
                if (!s) {
                    snprintf(why, wl, "out of memory");
                    goto done;
                }
                free_member(k, cfg);
                *(char **)m = s;
                ok = 1;
                goto done;
            }
            c += cn + (bar ? 1 : 0);
        }
        snprintf(why, wl, "expected %s", exp);
        break;
    }
    case GS_CFG_INT3: {
        const char *tb[4], *te[4];
        int n = split_tokens(trimmed, ",xX", tb, te, 4);
        if (n != 1 && n != 3) {
            snprintf(why, wl, "expected %s", exp);
            break;
        }
        int64_t x[3];
        ok = 1;
        for (int i = 0; i < n && ok; i++) {
            char tok[64], what[96];
            snprintf(tok, sizeof tok, "%.*s", (int)(te[i] - tb[i]), tb[i]);
            if (n == 3)
                snprintf(what, sizeof what, "; element %d is '%s'", i + 1, tok);
            else
                what[0] = '\0';
            if (te[i] - tb[i] >= 60) {
                snprintf(why, wl, "expected %s (element %d is too long)", exp, i + 1);
                ok = 0;
            } else {
                ok = parse_int_elem(k, tok, &x[i], why, wl, what);
            }
        }
        if (ok) {
            if (n == 1)
                x[1] = x[2] = x[0];
            memcpy(m, x, sizeof x);
        }
        break;
    }
    case GS_CFG_REAL_LIST: {
        const char **tb = gs_malloc((GS_CFG_MAX_LIST + 1) * sizeof *tb);
        const char **te = gs_malloc((GS_CFG_MAX_LIST + 1) * sizeof *te);
        double *x = gs_malloc(GS_CFG_MAX_LIST * sizeof *x);
        int n = (tb && te && x) ? split_tokens(trimmed, ",", tb, te, GS_CFG_MAX_LIST + 1) : -2;
        if (n == -2)
            snprintf(why, wl, "out of memory");
        else if (n < 0)
            snprintf(why, wl, "expected %s; found an empty element", exp);
        else if (n > GS_CFG_MAX_LIST)
            snprintf(why, wl, "expected %s; at most %d of them", exp, GS_CFG_MAX_LIST);
        else {
            ok = 1;
            for (int i = 0; i < n && ok; i++) {
                char tok[64], what[96];
                snprintf(tok, sizeof tok, "%.*s", (int)(te[i] - tb[i] < 60 ? te[i] - tb[i] : 60),
                         tb[i]);
                snprintf(what, sizeof what, "; element %d is '%s'", i + 1, tok);
                if (te[i] - tb[i] >= 60) {
                    ok = 0;
                    snprintf(why, wl, "expected %s%s... (too long)", exp, what);
                } else {
                    ok = parse_real_elem(k, tok, &x[i], why, wl, what);
                }
            }
            if (ok) {
                double *v2 = NULL;
                if (n > 0 && !(v2 = gs_malloc((size_t)n * sizeof *v2))) {
                    snprintf(why, wl, "out of memory");
                    ok = 0;
                } else {
                    if (n > 0)
                        memcpy(v2, x, (size_t)n * sizeof *v2);
                    free_member(k, cfg);
                    ((gs_cfg_real_list *)m)->v = v2;
                    ((gs_cfg_real_list *)m)->n = n;
                }
            }
        }
        gs_free(tb);
        gs_free(te);
        gs_free(x);
        break;
    }
    }
done:
    gs_free(trimmed);
    return ok;
}

/* Shortest decimal text that reads back as exactly v, without an exponent
 * for magnitudes in [1e-4, 1e17) ("300", not "3e+02"). */
static void format_real(double v, char *out, size_t outlen)
{
    int prec = 1;
    for (; prec < 17; prec++) {
        snprintf(out, outlen, "%.*g", prec, v);
        if (strtod(out, NULL) == v)
            break;
    }
    int exp10 = v != 0 ? (int)floor(log10(fabs(v))) : 0;
    if (exp10 >= 0 && exp10 < 17 && prec < exp10 + 1)
        prec = exp10 + 1;
    snprintf(out, outlen, "%.*g", prec, v);
}

/* The member's value as INI text (gs_malloc'ed), or NULL. */
static char *format_value(const gs_cfg_key *k, const unsigned char *cfg)
{
    const void *m = cfg + k->offset;
    sbuf b = {0};
    char num[40];
    switch (k->type) {
    case GS_CFG_INT: sb_add(&b, "%lld", (long long)*(const int64_t *)m); break;
    case GS_CFG_REAL:
        format_real(*(const double *)m, num, sizeof num);
        sb_add(&b, "%s", num);
        break;
    case GS_CFG_BOOL: sb_add(&b, "%s", *(const int *)m ? "true" : "false"); break;
    case GS_CFG_STRING:
    case GS_CFG_PATH:
    case GS_CFG_ENUM: {
        const char *s = *(char *const *)m;
        sb_add(&b, "%s", s ? s : "");
        break;
    }
    case GS_CFG_INT3: {
        const int64_t *x = m;
        sb_add(&b, "%lldx%lldx%lld", (long long)x[0], (long long)x[1], (long long)x[2]);
        break;
    }
    case GS_CFG_REAL_LIST: {
        const gs_cfg_real_list *l = m;
        sb_add(&b, "%s", "");
        for (int64_t i = 0; i < l->n; i++) {
            format_real(l->v[i], num, sizeof num);
            sb_add(&b, "%s%s", i ? ", " : "", num);
        }
        break;
    }
    }
    if (b.oom) {
        gs_free(b.s);
        return NULL;
    }
    return b.s;
}

/* ---------------------------------------------------------------- tables */

static int name_ok(const char *n)
{
    int words = 0, len = 0;
    for (const char *p = n;; p++) {
        if (*p == '.' || *p == '\0') {
            if (len == 0)
                return 0;
            words++;
            len = 0;
            if (*p == '\0')
                break;
        } else if ((*p >= 'a' && *p <= 'z') || (*p >= '0' && *p <= '9') || *p == '_') {
            len++;
        } else {
            return 0;
        }
    }
    return words >= 2;
}

gs_err gs_config_table_check(const gs_cfg_table *t)
{
    GS_CHECK(t && t->keys && t->nkeys > 0 && t->size > 0 && t->engine && t->engine[0],
             GS_ERR_INTERNAL, "config table %s is empty or incomplete",
             t && t->engine ? t->engine : "(unnamed)");
    unsigned char *scratch = gs_calloc(1, t->size);
    GS_CHECK(scratch, GS_ERR_MEM, "cannot allocate %zu bytes for config '%s'", t->size,
             t->engine);
    gs_err err = GS_OK;
    for (size_t i = 0; i < t->nkeys; i++) {
        const gs_cfg_key *k = &t->keys[i];
        const char *n = k->name ? k->name : "(null)";
        GS_TRY_CHECK(err, k->name && name_ok(k->name), GS_ERR_INTERNAL, done,
                     "config table '%s': key name '%s' is not section.key in [a-z0-9_]",
                     t->engine, n);
        for (size_t j = 0; j < i; j++)
            GS_TRY_CHECK(err, strcmp(t->keys[j].name, k->name) != 0, GS_ERR_INTERNAL, done,
                         "config table '%s': key '%s' appears twice", t->engine, n);
        GS_TRY_CHECK(err, (unsigned)k->type <= GS_CFG_REAL_LIST, GS_ERR_INTERNAL, done,
                     "config table '%s': key '%s' has unknown type %d", t->engine, n,
                     (int)k->type);
        GS_TRY_CHECK(err, k->offset + member_size(k->type) <= t->size, GS_ERR_INTERNAL, done,
                     "config table '%s': key '%s' lies outside the struct", t->engine, n);
        GS_TRY_CHECK(err, k->help && !strchr(k->help, '\n'), GS_ERR_INTERNAL, done,
                     "config table '%s': key '%s' needs a one-line help", t->engine, n);
        if (k->type == GS_CFG_INT || k->type == GS_CFG_REAL || k->type == GS_CFG_INT3 ||
            k->type == GS_CFG_REAL_LIST)
            GS_TRY_CHECK(err, k->lo <= k->hi, GS_ERR_INTERNAL, done,
                         "config table '%s': key '%s' has bounds [%g, %g]", t->engine, n,
                         k->lo, k->hi);
        if (k->type == GS_CFG_ENUM) {
            const char *c = k->choices;
            int good = c && *c && c[strlen(c) - 1] != '|' && !strstr(c, "||") && *c != '|' &&
                       !strpbrk(c, " \t;#");
            GS_TRY_CHECK(err, good, GS_ERR_INTERNAL, done,
                         "config table '%s': key '%s' needs choices \"a|b|c\"", t->engine, n);
        }
        if (k->def) {
            char why[400];
            GS_TRY_CHECK(err, parse_value(k, k->def, "/", scratch, why, sizeof why),
                         GS_ERR_INTERNAL, done,
                         "config table '%s': default '%s' of key '%s' is invalid: %s",
                         t->engine, k->def, n, why);
        }
    }
done:
    for (size_t i = 0; i < t->nkeys; i++)
        if ((unsigned)t->keys[i].type <= GS_CFG_REAL_LIST &&
            t->keys[i].offset + member_size(t->keys[i].type) <= t->size)
            free_member(&t->keys[i], scratch);
    gs_free(scratch);
    return err;
}

void gs_config_free(const gs_cfg_table *t, void *cfg)
{
    if (!t || !cfg)
        return;
    for (size_t i = 0; i < t->nkeys; i++)
        free_member(&t->keys[i], cfg);
}

/* ----------------------------------------------------------------- parse */

enum { SRC_NONE, SRC_FILE, SRC_OVERRIDE, SRC_DEFAULT };

typedef struct key_src {
    int kind;
    int line;            /* SRC_FILE */
    const char *setarg;  /* SRC_OVERRIDE: the --set argument as given */
    char *value;         /* text the value came from (gs_malloc'ed) */
} key_src;

struct gs_cfg_ctx {
    const gs_cfg_table *t;
    const char *origin;
    const char *base; /* absolute directory for relative paths in the text */
    const char *cwd;  /* absolute current directory */
    gs_cfg_problems *problems;
    unsigned char *scratch;
    key_src *src;
    int in_unknown_section;
};

static void on_ini(void *user, int line, const char *section, const char *name,
                   const char *value, const char *error)
{
    gs_cfg_ctx *c = user;
    char hint[512], q[CFG_QUOTE_MAX + 8];
    if (error) {
        problem_add(c->problems, "%s:%d: %s", c->origin, line, error);
        return;
    }
    if (!name) {
        c->in_unknown_section = !section_known(c->t, section);
        if (c->in_unknown_section) {
            suggest_section(c->t, section, hint, sizeof hint);
            quote(q, sizeof q, section);
            problem_add(c->problems, "%s:%d: [%s]: unknown section%s", c->origin, line, q, hint);
        }
        return;
    }
    if (c->in_unknown_section)
        return; /* reported once at its header */
    quote(q, sizeof q, value);
    char qn[CFG_QUOTE_MAX + 8];
    quote(qn, sizeof qn, name);
    if (section[0] == '\0') {
        suggest_key(c->t, "", name, hint, sizeof hint);
        problem_add(c->problems, "%s:%d: %s = %s: key outside any [section]%s", c->origin, line,
                    qn, q, hint);
        return;
    }
    char qs[CFG_QUOTE_MAX + 8];
    quote(qs, sizeof qs, section);
    ptrdiff_t i = find_in_section(c->t, section, name);
    if (i < 0) {
        suggest_key(c->t, section, name, hint, sizeof hint);
        problem_add(c->problems, "%s:%d: [%s] %s = %s: unknown key%s", c->origin, line, qs, qn,
                    q, hint);
        return;
    }
    key_src *s = &c->src[i];
    if (s->kind == SRC_FILE) {
        problem_add(c->problems, "%s:%d: [%s] %s = %s: duplicate key (first set on line %d)",
                    c->origin, line, qs, qn, q, s->line);
        return;
    }
    s->kind = SRC_FILE;
    s->line = line;
    gs_free(s->value);
    s->value = str_dup(value);
    char why[400];
    if (!parse_value(&c->t->keys[i], value, c->base, c->scratch, why, sizeof why))
        problem_add(c->problems, "%s:%d: [%s] %s = %s: %s", c->origin, line, qs, qn, q, why);
}

static void apply_override(gs_cfg_ctx *c, const char *arg)
{
    char q[CFG_QUOTE_MAX + 8], hint[512], why[400];
    quote(q, sizeof q, arg ? arg : "");
    const char *eq = arg ? strchr(arg, '=') : NULL;
    if (!eq) {
        problem_add(c->problems, "--set %s: expected section.key=value", q);
        return;
    }
    const char *nb = lskip(arg);
    size_t nn = (size_t)(eq - nb);
    while (nn && isspace((unsigned char)nb[nn - 1]))
        nn--;
    char *name = str_ndup(nb, nn);
    if (!name) {
        problem_add(c->problems, "--set %s: out of memory", q);
        return;
    }
    const gs_cfg_key *k = gs_config_find(c->t, name);
    if (!k) {
        suggest_full(c->t, name, hint, sizeof hint);
        problem_add(c->problems, "--set %s: unknown key%s", q, hint);
        gs_free(name);
        return;
    }
    gs_free(name);
    size_t i = (size_t)(k - c->t->keys);
    key_src *s = &c->src[i];
    s->kind = SRC_OVERRIDE;
    s->setarg = arg;
    gs_free(s->value);
    s->value = str_dup(eq + 1);
    if (!parse_value(k, eq + 1, c->cwd, c->scratch, why, sizeof why))
        problem_add(c->problems, "--set %s: %s", q, why);
}

void gs_cfg_report(gs_cfg_ctx *c, const char *key, const char *fmt, ...)
{
    sbuf b = {0};
    va_list ap;
    va_start(ap, fmt);
    sb_vadd(&b, fmt, ap);
    va_end(ap);
    const char *msg = b.s && !b.oom ? b.s : fmt;
    const gs_cfg_key *k = gs_config_find(c->t, key);
    if (!k) {
        problem_add(c->problems, "%s: %s: %s", c->origin, key, msg);
    } else {
        const key_src *s = &c->src[k - c->t->keys];
        char q[CFG_QUOTE_MAX + 8];
        quote(q, sizeof q, s->value ? s->value : "");
        int sl = (int)section_len(k->name);
        if (s->kind == SRC_FILE)
            problem_add(c->problems, "%s:%d: [%.*s] %s = %s: %s", c->origin, s->line, sl,
                        k->name, key_part(k->name), q, msg);
        else if (s->kind == SRC_OVERRIDE) {
            char qa[CFG_QUOTE_MAX + 8];
            quote(qa, sizeof qa, s->setarg);
            problem_add(c->problems, "--set %s: %s", qa, msg);
        } else
            problem_add(c->problems, "%s: [%.*s] %s = %s (default): %s", c->origin, sl, k->name,
                        key_part(k->name), q, msg);
    }
    gs_free(b.s);
}

static gs_err copy_out(const gs_cfg_table *t, const unsigned char *scratch, void *out)
{
    for (size_t i = 0; i < t->nkeys; i++)
        memcpy((unsigned char *)out + t->keys[i].offset, scratch + t->keys[i].offset,
               member_size(t->keys[i].type));
    return GS_OK;
}

gs_err gs_config_parse_text(const gs_cfg_table *t, const char *text, size_t len,
                            const char *origin, const char *base_dir,
                            const char *const *overrides, size_t noverrides, void *out,
                            gs_cfg_problems *problems)
{
    GS_CHECK(problems && out && (text || len == 0), GS_ERR_INTERNAL,
             "gs_config_parse_text needs text, out and problems");
    GS_CALL(gs_config_table_check(t));
    if (!origin)
        origin = "(config text)";
    gs_err err = GS_OK;
    size_t before = problems->n;
    gs_cfg_ctx c = {.t = t, .origin = origin, .problems = problems};
    char *cwd = current_dir();
    char *base = NULL;
    c.scratch = gs_calloc(1, t->size);
    c.src = gs_calloc(t->nkeys, sizeof *c.src);
    GS_TRY_CHECK(err, cwd, GS_ERR_IO, done, "cannot determine the current directory: %s",
                 strerror(errno));
    GS_TRY_CHECK(err, c.scratch && c.src, GS_ERR_MEM, done,
                 "cannot allocate the config of '%s'", t->engine);
    c.cwd = cwd;
    if (base_dir) {
        char why[128];
        base = resolve_path(base_dir, cwd, why, sizeof why);
        GS_TRY_CHECK(err, base, GS_ERR_MEM, done, "config base directory: %s", why);
        c.base = base;
    } else {
        c.base = cwd;
    }

    const char *nul = len ? memchr(text, '\0', len) : NULL;
    if (nul) {
        problem_add(problems, "%s: not a text file (NUL byte at offset %zu)", origin,
                    (size_t)(nul - text));
    } else {
        gs_ini_scan(text, len, on_ini, &c);
        for (size_t i = 0; i < noverrides; i++)
            apply_override(&c, overrides[i]);
        char why[400];
        for (size_t i = 0; i < t->nkeys; i++) {
            const gs_cfg_key *k = &t->keys[i];
            if (c.src[i].kind != SRC_NONE)
                continue;
            int sl = (int)section_len(k->name);
            if (!k->def) {
                problem_add(problems,
                            "%s: [%.*s] %s: required key missing (%s); set it in the file "
                            "or with --set %s=...",
                            origin, sl, k->name, key_part(k->name), k->help, k->name);
                continue;
            }
            c.src[i].kind = SRC_DEFAULT;
            c.src[i].value = str_dup(k->def);
            if (!parse_value(k, k->def, cwd, c.scratch, why, sizeof why))
                problem_add(problems, "%s: [%.*s] %s = %s (default): %s", origin, sl, k->name,
                            key_part(k->name), k->def, why);
        }
        if (problems->n == before && t->validate)
            t->validate(c.scratch, &c);
    }
    if (problems->n != before) {
        size_t n = problems->n - before;
        err = gs_error_raise(GS_ERR_ARG, __FILE__, __LINE__, __func__, "%zu problem%s in %s", n,
                             n == 1 ? "" : "s", origin);
        goto done;
    }
    copy_out(t, c.scratch, out);
    gs_free(c.scratch); /* its strings now belong to *out */
    c.scratch = NULL;
done:
    if (c.scratch) {
        gs_config_free(t, c.scratch);
        gs_free(c.scratch);
    }
    if (c.src)
        for (size_t i = 0; i < t->nkeys; i++)
            gs_free(c.src[i].value);
    gs_free(c.src);
    gs_free(base);
    gs_free(cwd);
    return err;
}

gs_err gs_config_load(const gs_cfg_table *t, const char *path, const char *const *overrides,
                      size_t noverrides, void *out, gs_cfg_problems *problems)
{
    if (!path)
        return gs_config_parse_text(t, "", 0, "(no config file)", NULL, overrides, noverrides,
                                    out, problems);
    FILE *f = fopen(path, "rb");
    GS_CHECK(f, GS_ERR_IO, "cannot open config file '%s': %s", path, strerror(errno));
    gs_err err = GS_OK;
    char *text = NULL, *dir = NULL;
    struct stat st;
    GS_TRY_CHECK(err, fstat(fileno(f), &st) == 0, GS_ERR_IO, done,
                 "cannot read config file '%s': %s", path, strerror(errno));
    GS_TRY_CHECK(err, !S_ISDIR(st.st_mode), GS_ERR_IO, done,
                 "config file '%s' is a directory", path);
    size_t cap = 4096, n = 0;
    text = gs_malloc(cap);
    GS_TRY_CHECK(err, text, GS_ERR_MEM, done, "cannot allocate memory to read '%s'", path);
    for (;;) {
        if (n == cap) {
            GS_TRY_CHECK(err, cap < CFG_MAX_FILE, GS_ERR_FORMAT, done,
                         "config file '%s' is larger than %u MiB: not a config file", path,
                         CFG_MAX_FILE >> 20);
            char *bigger = gs_realloc(text, cap * 2);
            GS_TRY_CHECK(err, bigger, GS_ERR_MEM, done, "cannot allocate memory to read '%s'",
                         path);
            text = bigger;
            cap *= 2;
        }
        size_t got = fread(text + n, 1, cap - n, f);
        n += got;
        if (got == 0) {
            GS_TRY_CHECK(err, !ferror(f), GS_ERR_IO, done, "cannot read config file '%s': %s",
                         path, strerror(errno));
            break;
        }
    }
    const char *slash = strrchr(path, '/');
    dir = slash ? str_ndup(path, slash == path ? 1 : (size_t)(slash - path)) : str_dup(".");
    GS_TRY_CHECK(err, dir, GS_ERR_MEM, done, "out of memory");
    GS_TRY(err, gs_config_parse_text(t, text, n, path, dir, overrides, noverrides, out, problems),
           done);
done:
    fclose(f);
    gs_free(text);
    gs_free(dir);
    return err;
}

/* ------------------------------------------------------- resolved / help */

static void describe_default(const gs_cfg_key *k, char *out, size_t outlen)
{
    if (!k->def)
        snprintf(out, outlen, "required");
    else if (!k->def[0])
        snprintf(out, outlen, "default: none");
    else
        snprintf(out, outlen, "default %s", k->def);
}

/* Calls visit for each key, grouped by section in order of first appearance. */
static void for_each_by_section(const gs_cfg_table *t, void (*visit)(void *, const gs_cfg_key *, int),
                                void *user)
{
    for (size_t i = 0; i < t->nkeys; i++) {
        const char *n = t->keys[i].name;
        size_t sl = section_len(n);
        int seen = 0;
        for (size_t j = 0; j < i && !seen; j++)
            seen = section_len(t->keys[j].name) == sl && !strncmp(t->keys[j].name, n, sl);
        if (seen)
            continue;
        int first = 1;
        for (size_t j = i; j < t->nkeys; j++)
            if (section_len(t->keys[j].name) == sl && !strncmp(t->keys[j].name, n, sl)) {
                visit(user, &t->keys[j], first);
                first = 0;
            }
    }
}

typedef struct resolved_state {
    sbuf b;
    const unsigned char *cfg;
    int bad;
    char why[200];
    const char *badkey;
} resolved_state;

static void visit_resolved(void *user, const gs_cfg_key *k, int first)
{
    resolved_state *r = user;
    if (first)
        sb_add(&r->b, "\n[%.*s]\n", (int)section_len(k->name), k->name);
    char exp[200], def[200];
    describe(k, exp, sizeof exp);
    describe_default(k, def, sizeof def);
    char *v = format_value(k, r->cfg);
    if (!v) {
        r->b.oom = 1;
        return;
    }
    if (!r->bad && !text_round_trips(v, r->why, sizeof r->why)) {
        r->bad = 1;
        r->badkey = k->name;
    }
    sb_add(&r->b, "# %s (%s; %s)\n%s =%s%s\n", k->help, exp, def, key_part(k->name),
           v[0] ? " " : "", v);
    gs_free(v);
}

gs_err gs_config_resolved_text(const gs_cfg_table *t, const void *cfg, char **text)
{
    GS_CALL(gs_config_table_check(t));
    resolved_state r = {.cfg = cfg};
    sb_add(&r.b, "# geosynth %s configuration, resolved: every key with its effective value.\n",
           t->engine);
    sb_add(&r.b, "# Paths are absolute. Use it as is with -c to repeat the run.\n");
    for_each_by_section(t, visit_resolved, &r);
    if (r.b.oom) {
        gs_free(r.b.s);
        GS_RAISE(GS_ERR_MEM, "cannot allocate the resolved config of '%s'", t->engine);
    }
    if (r.bad) {
        gs_free(r.b.s);
        GS_RAISE(GS_ERR_ARG, "config key %s cannot be written back: %s", r.badkey, r.why);
    }
    *text = r.b.s;
    return GS_OK;
}

typedef struct help_state {
    FILE *f;
    int width;
} help_state;

static void visit_help(void *user, const gs_cfg_key *k, int first)
{
    help_state *h = user;
    if (first)
        fprintf(h->f, "\n[%.*s]\n", (int)section_len(k->name), k->name);
    char exp[200], def[200];
    describe(k, exp, sizeof exp);
    describe_default(k, def, sizeof def);
    fprintf(h->f, "  %-*s  %s\n  %-*s  %s; %s\n", h->width, key_part(k->name), k->help, h->width,
            "", exp, def);
}

void gs_config_print_help(const gs_cfg_table *t, FILE *f)
{
    help_state h = {f, 8};
    for (size_t i = 0; i < t->nkeys; i++) {
        int w = (int)strlen(key_part(t->keys[i].name));
        if (w > h.width && w <= 28)
            h.width = w;
    }
    fprintf(f, "Configuration of geosynth %s: an INI file (-c FILE) with these sections and "
               "keys;\noverride any key with --set section.key=value (paths in a file are "
               "relative to the file).\n",
            t->engine);
    for_each_by_section(t, visit_help, &h);
}
