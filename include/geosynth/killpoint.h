/* Kill points: the test hook behind tests/e2e/resume_anywhere.sh (#25 item 2).
 *
 * The places where a kill leaves a run directory in a different state (a
 * phase beginning or ending, every safe point where a checkpoint may be
 * decided, every step of writing a checkpoint or an HDF5 output, every step
 * of an atomic output file) call gs_kill_point. With the environment
 *   GS_KILL_AT=K      (K >= 1) rank GS_KILL_RANK (default 0) sends itself
 *                     SIGKILL at its K-th kill point (mpirun then ends the
 *                     job, as when a node dies);
 *   GS_KILL_TRACE=F   that rank appends "K<TAB>PHASE<TAB>WHAT" for each kill
 *                     point it passes to file F (before it dies at K), so a
 *                     test can list every point of a run and pick some.
 * Unset (every normal run), a kill point costs one test of a static flag.
 * The sequence of kill points is a function of the inputs and the rank count
 * alone when checkpoints are decided by units (run.checkpoint_every), not by
 * the clock. Only a fresh run counts: `resume` ignores both variables.
 */
#ifndef GEOSYNTH_KILLPOINT_H
#define GEOSYNTH_KILLPOINT_H

/* Which rank this process is (gs_par_init) and whether it resumes (the CLI):
 * a resumed run passes no kill point. */
void gs_kill_point_setup(int rank, int resumed);

/* The phase the following kill points belong to (gs_run_phase_begin). */
void gs_kill_point_phase(const char *phase);

/* A kill point; what is printf-like (the file or dataset, the step). */
void gs_kill_point(const char *what, ...) __attribute__((format(printf, 1, 2)));

/* The last component of a path (what kill point labels name). */
const char *gs_kill_base(const char *path);

#endif
