/* Collective configuration loading; see include/geosynth/config_load.h. */
#include "geosynth/config_load.h"

#include <stdio.h>
#include <string.h>

#include "geosynth/mem.h"
#include "geosynth/par.h"

/* Shared by the file and text entry points: rank 0 parses either path
 * (text == NULL) or text (named origin in messages). */
static gs_err load_collective(MPI_Comm comm, const gs_cfg_table *t, const char *path,
                              const char *text_in, const char *origin,
                              const char *const *overrides, size_t noverrides, void *out,
                              char **resolved_text)
{
    int rank;
    GS_CALL(gs_par_comm_rank(comm, &rank, NULL));
    /* Scratch struct: *out stays unchanged unless every rank succeeds. */
    unsigned char *cfg = gs_calloc(1, t && t->size ? t->size : 1);
    char *text = NULL;
    gs_err local = GS_OK;
    if (!cfg)
        local = gs_error_raise(GS_ERR_MEM, __FILE__, __LINE__, __func__,
                               "cannot allocate the config");
    else if (rank == 0) {
        gs_cfg_problems problems = GS_CFG_PROBLEMS_INIT;
        if (text_in)
            local = gs_config_parse_text(t, text_in, strlen(text_in), origin, NULL, overrides,
                                         noverrides, cfg, &problems);
        else
            local = gs_config_load(t, path, overrides, noverrides, cfg, &problems);
        gs_cfg_problems_print(&problems, stderr);
        fflush(stderr);
        gs_cfg_problems_free(&problems);
        if (local == GS_OK) {
            local = gs_config_resolved_text(t, cfg, &text);
            if (local != GS_OK)
                gs_config_free(t, cfg);
        }
    }
    gs_err err = gs_par_agree(comm, local);
    if (err != GS_OK) {
        if (local == GS_OK)
            gs_config_free(t, cfg); /* rank 0 succeeded, another rank did not */
        goto fail;
    }

    err = gs_par_bcast_string(comm, &text, 0);
    if (err != GS_OK)
        goto fail; /* an MPI failure: collective on every rank already */
    local = GS_OK;
    if (rank != 0) {
        gs_cfg_problems problems = GS_CFG_PROBLEMS_INIT;
        local = gs_config_parse_text(t, text, strlen(text), "(resolved config from rank 0)",
                                     NULL, NULL, 0, cfg, &problems);
        if (local != GS_OK) {
            char first[512];
            snprintf(first, sizeof first, "%s", problems.nkept ? problems.msg[0] : "");
            local = gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                                   "cannot reproduce rank 0's config from its resolved text: %s",
                                   first);
        } else {
            /* The text must be a fixed point; a difference is a config.c bug. */
            char *again = NULL;
            local = gs_config_resolved_text(t, cfg, &again);
            if (local == GS_OK && strcmp(again, text) != 0)
                local = gs_error_raise(GS_ERR_INTERNAL, __FILE__, __LINE__, __func__,
                                       "the resolved config text does not round-trip");
            gs_free(again);
            if (local != GS_OK)
                gs_config_free(t, cfg);
        }
        gs_cfg_problems_free(&problems);
    }
    err = gs_par_agree(comm, local);
    if (err != GS_OK) {
        if (local == GS_OK)
            gs_config_free(t, cfg);
        goto fail;
    }
    /* Copy the table's members only; other members of *out are the caller's. */
    for (size_t i = 0; i < t->nkeys; i++) {
        const gs_cfg_key *k = &t->keys[i];
        size_t size = k->type == GS_CFG_INT || k->type == GS_CFG_REAL ? 8
                      : k->type == GS_CFG_BOOL                        ? sizeof(int)
                      : k->type == GS_CFG_INT3                        ? 3 * sizeof(int64_t)
                      : k->type == GS_CFG_REAL_LIST ? sizeof(gs_cfg_real_list)
                                                    : sizeof(char *);
        memcpy((unsigned char *)out + k->offset, cfg + k->offset, size);
    }
    gs_free(cfg);
    if (resolved_text)
        *resolved_text = text;
    else
        gs_free(text);
    return GS_OK;
fail:
    gs_free(cfg);
    gs_free(text);
    return err;
}

gs_err gs_config_load_collective(MPI_Comm comm, const gs_cfg_table *t, const char *path,
                                 const char *const *overrides, size_t noverrides, void *out,
                                 char **resolved_text)
{
    return load_collective(comm, t, path, NULL, NULL, overrides, noverrides, out, resolved_text);
}

gs_err gs_config_text_collective(MPI_Comm comm, const gs_cfg_table *t, const char *text,
                                 const char *origin, const char *const *overrides,
                                 size_t noverrides, void *out, char **resolved_text)
{
    return load_collective(comm, t, NULL, text ? text : "", origin, overrides, noverrides, out,
                           resolved_text);
}
