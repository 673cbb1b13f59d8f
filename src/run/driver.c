/* The one run driver (include/geosynth/engine.h): phases, checkpoint
 * cadence, stop on a signal, agreement after every operation, summary. */
#include <string.h>

#include "geosynth/engine.h"
#include "geosynth/log.h"
#include "geosynth/par.h"

/* Every rank's status of a collective operation, agreed: an error on any
 * rank is the error of all (gs_par_agree marks it agreed, so it is reported
 * once, by the rank it came from). */
static gs_err agree(gs_run *run, gs_err local)
{
    if (local != GS_OK && local != GS_ERR_INTERRUPTED && run->failed_alone && run->size > 1)
        gs_fatal(local, 0); /* the others may be waiting inside the operation */
    gs_err err = gs_par_agree(run->comm, local);
    if (err != GS_OK && err != GS_ERR_INTERRUPTED)
        run->failed_together = 1;
    return err;
}

/* Ends the running phase with the members the engine put into j. */
static gs_err end_phase(gs_run *run, gs_json *j)
{
    gs_json_end_object(j);
    gs_err err = gs_run_phase_end(run, j->failed ? NULL : j->buf);
    gs_json_free(j);
    return err;
}

static gs_err synthesis(const gs_engine_ops *ops, void *st, gs_run *run)
{
    int64_t done = 0, total = 0;
    ops->units(st, &done, &total);
    gs_progress prog;
    if (total > 0) {
        gs_progress_begin(&prog, "synthesis", (uint64_t)total);
        gs_progress_update(&prog, (uint64_t)done);
    }
    gs_err err = GS_OK;
    for (int finished = 0; !finished;) {
        GS_TRY(err, agree(run, ops->advance(st, run, &finished)), end);
        ops->units(st, &done, &total);
        if (total > 0)
            gs_progress_update(&prog, (uint64_t)done);
        if (finished) /* the output follows at once: no checkpoint, no stop */
            break;
        int stop = 0;
        if (gs_run_checkpoint_due(run, done, &stop))
            GS_TRY(err, agree(run, ops->save(st, run)), end);
        if (stop) {
            err = gs_run_interrupted(run);
            goto end;
        }
    }
end:
    if (total > 0)
        gs_progress_end(&prog);
    return err;
}

gs_err gs_engine_drive(const gs_engine *e, gs_run *run, void *config, int resume)
{
    const gs_engine_ops *ops = e->ops;
    gs_err err = GS_OK;
    if (ops->whole) {
        int handled = 0;
        GS_CALL(agree(run, ops->whole(run, config, resume, &handled)));
        if (handled)
            return GS_OK;
    }
    void *st = NULL;
    gs_json pj;
    gs_json_init(&pj);

    gs_run_phase_begin(run, "setup");
    gs_json_begin_object(&pj, NULL);
    GS_TRY(err, agree(run, ops->setup(run, config, resume, &st, &pj)), done);
    if (resume)
        GS_TRY(err, agree(run, ops->restore(st, run)), done);
    {
        int64_t units = 0, total = 0;
        ops->units(st, &units, &total);
        gs_json_bool(&pj, "resumed", resume);
        gs_json_i64(&pj, "resumed_at_units", resume ? units : 0);
    }
    GS_TRY(err, end_phase(run, &pj), done);

    gs_run_phase_begin(run, "synthesis");
    GS_TRY(err, synthesis(ops, st, run), done);
    gs_json_init(&pj);
    gs_json_begin_object(&pj, NULL);
    if (ops->synthesis_report)
        GS_TRY(err, agree(run, ops->synthesis_report(st, run, &pj)), done);
    GS_TRY(err, end_phase(run, &pj), done);

    if (ops->finish) {
        gs_run_phase_begin(run, "finish");
        gs_json_init(&pj);
        gs_json_begin_object(&pj, NULL);
        GS_TRY(err, agree(run, ops->finish(st, run, &pj)), done);
        GS_TRY(err, end_phase(run, &pj), done);
    }

    gs_run_phase_begin(run, "output");
    uint64_t digest = 0;
    gs_json_init(&pj);
    gs_json_begin_object(&pj, NULL);
    GS_TRY(err, agree(run, ops->output(st, run, &pj, &digest)), done);
    GS_TRY(err, end_phase(run, &pj), done);
    GS_TRY(err, gs_run_finish(run, digest), done);
done:
    gs_json_free(&pj);
    if (ops->destroy)
        ops->destroy(st);
    return err;
}
