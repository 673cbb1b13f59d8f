/* The data root: where example inputs named `${data}/...` live.
 *
 * A config value (or a line of a list file such as micro.mesh_list) that
 * begins with "${data}/" names a file under the data root, whose layout is
 * the same everywhere (e.g. ${data}/meshes/spot.obj,
 * ${data}/model-synthesis/merrell42-model-synthesis/samples/castle.txt):
 *   1. $GS_DATA when set and not empty (absolute, or relative to the current
 *      directory);
 *   2. else PREFIX/share/geosynth/data when the running program is
 *      PREFIX/bin/geosynth and that directory exists (`make install`);
 *   3. else the data/ directory of the source tree the program was built
 *      from (compiled in as GS_DATA_BUILD_DIR by the Makefile).
 * The repository's data/ holds the redistributable examples (data/SOURCES.md);
 * third-party files that may not be redistributed are fetched into the same
 * root by `make data` (scripts/fetch-data.sh, manifest scripts/data-manifest.tsv).
 *
 * Paths are joined and normalized lexically ("." and ".." removed, symlinks
 * not followed); the result is absolute. No state is kept between calls:
 * GS_DATA is read every time. Not collective.
 */
#ifndef GEOSYNTH_DATA_H
#define GEOSYNTH_DATA_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* "${data}" */
#define GS_DATA_VAR "${data}"

/* If value begins with "${data}/" (or is exactly "${data}"), returns the
 * part after "${data}/" ("" for the root itself); else NULL. */
const char *gs_data_relative(const char *value);

/* The data root, absolute and normalized, into buf (cap bytes); *how (may be
 * NULL) describes where it came from ("GS_DATA", "the installed
 * share/geosynth/data", "the source tree's data/"). Returns 0 with a reason
 * in why when the root cannot be determined (no current directory for a
 * relative GS_DATA, or the path does not fit). */
int gs_data_root(char *buf, size_t cap, const char **how, char *why, size_t wl);

/* If path (absolute, normalized) lies under the data root, writes into buf a
 * hint for a missing file there and returns 1:
 *   "this is ${data}/REL; the data root is ROOT (HOW). Third-party data the
 *    repository may not include is fetched with `make data` in the geosynth
 *    source tree ([GS_DATA=ROOT ]scripts/fetch-data.sh REL fetches only this
 *    file)"   (GS_DATA=ROOT unless ROOT is the source tree's data/)
 * Returns 0 (buf = "") when path is elsewhere. */
int gs_data_missing_hint(const char *path, char *buf, size_t cap);

#ifdef __cplusplus
}
#endif

#endif
