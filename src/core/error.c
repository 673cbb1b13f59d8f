/* Error record and traceback; see include/geosynth/error.h. */
#include "geosynth/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define GS_ERROR_MSG_MAX 2048
#define GS_ERROR_FRAMES_MAX 32

typedef struct gs_error_frame {
    const char *file;
    int line;
    const char *func;
} gs_error_frame;

typedef struct gs_error_record {
    gs_err code;
    char message[GS_ERROR_MSG_MAX];
    gs_error_frame frames[GS_ERROR_FRAMES_MAX];
    int nframes;
    int dropped_frames;
    int agreed; /* 1 + the rank that reported it, when every rank agreed on it; 0 = not */
} gs_error_record;

static _Thread_local gs_error_record error_record;

const char *gs_err_name(gs_err code)
{
    switch (code) {
    case GS_OK: return "ok";
    case GS_ERR_USAGE: return "usage";
    case GS_ERR_ARG: return "bad input";
    case GS_ERR_IO: return "I/O";
    case GS_ERR_FORMAT: return "file format";
    case GS_ERR_MEM: return "out of memory";
    case GS_ERR_MPI: return "MPI";
    case GS_ERR_LIB: return "library";
    case GS_ERR_INTERNAL: return "internal";
    case GS_ERR_INTERRUPTED: return "interrupted";
    }
    return "unknown";
}

static void push_frame(const char *file, int line, const char *func)
{
    gs_error_record *r = &error_record;
    if (r->nframes < GS_ERROR_FRAMES_MAX)
        r->frames[r->nframes++] = (gs_error_frame){file, line, func};
    else
        r->dropped_frames++;
}

/* Messages quote input files ("got 'abc'"): control bytes other than newline
 * and tab (a terminal escape sequence in a PNG chunk name, a CR from a CRLF
 * table, NULs) become '?' so a file cannot drive the user's terminal (#25). */
void gs_text_sanitize(char *s)
{
    for (unsigned char *p = (unsigned char *)s; *p; p++)
        if ((*p < 32 && *p != '\n' && *p != '\t') || *p == 127)
            *p = '?';
}

gs_err gs_error_raise(gs_err code, const char *file, int line, const char *func,
                      const char *fmt, ...)
{
    gs_error_record *r = &error_record;
    r->code = code == GS_OK ? GS_ERR_INTERNAL : code;
    r->nframes = 0;
    r->dropped_frames = 0;
    r->agreed = 0;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(r->message, sizeof r->message, fmt, ap);
    va_end(ap);
    gs_text_sanitize(r->message);
    push_frame(file, line, func);
    return r->code;
}

void gs_error_push_frame(const char *file, int line, const char *func)
{
    push_frame(file, line, func);
}

void gs_error_add_context(const char *fmt, ...)
{
    gs_error_record *r = &error_record;
    char ctx[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(ctx, sizeof ctx, fmt, ap);
    va_end(ap);
    gs_text_sanitize(ctx);
    size_t len = strlen(r->message);
    if (len + 2 < sizeof r->message)
        snprintf(r->message + len, sizeof r->message - len, " (%s)", ctx);
}

gs_err gs_error_code(void) { return error_record.code; }

const char *gs_error_message(void) { return error_record.message; }

void gs_error_clear(void)
{
    error_record.code = GS_OK;
    error_record.message[0] = '\0';
    error_record.nframes = 0;
    error_record.dropped_frames = 0;
    error_record.agreed = 0;
}

void gs_error_mark_agreed(int origin_rank) { error_record.agreed = origin_rank + 1; }

int gs_error_agreed_origin(void) { return error_record.agreed - 1; }

void gs_error_report(const char *prefix)
{
    const gs_error_record *r = &error_record;
    const char *p = prefix ? prefix : "";
    fprintf(stderr, "%serror (%s): %s\n", p, gs_err_name(r->code),
            r->message[0] ? r->message : "(no message)");
    for (int i = 0; i < r->nframes; i++)
        fprintf(stderr, "%s  at %s:%d in %s()\n", p, r->frames[i].file,
                r->frames[i].line, r->frames[i].func);
    if (r->dropped_frames)
        fprintf(stderr, "%s  ... %d more frames\n", p, r->dropped_frames);
    fflush(stderr);
}

#ifndef NDEBUG
void gs_assert_fail(const char *expr, const char *file, int line, const char *func)
{
    fprintf(stderr, "internal error: assertion '%s' failed at %s:%d in %s()\n",
            expr, file, line, func);
    fflush(stderr);
    abort(); /* internal invariant broken: a bug, never user input */
}
#endif
