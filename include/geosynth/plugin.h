/* Optional heavy libraries behind plugins loaded on first use.
 *
 * OpenVDB (with TBB, Boost, Imath, Blosc) and OSMesa (with LLVM) cost every
 * process ~65 ms of start-up when linked into the program, on every rank of
 * every run, although most runs use neither. Their code lives in two shared
 * objects instead, built next to the program and opened with dlopen the
 * first time a function needs them:
 *
 *   geosynth-vdb.so     src/plugins/vdb.cpp        (gs_vdb_*, include/geosynth/vdb.h)
 *   geosynth-render.so  src/plugins/render_gl.c    (gs_render_mesh, render.h)
 *
 * A plugin is looked up in, in order: $GEOSYNTH_PLUGIN_DIR; the program's
 * directory/../lib/geosynth (make install puts them there); the program's
 * directory/../build/plugins (a source tree's bin/ and build/, wherever the
 * tree is: a cluster node may mount it at another path than the one it was
 * built at); the build tree the program was built in. A plugin calls back into the program's gs_*
 * functions, which the programs export (-rdynamic). Plugins stay loaded
 * until exit. Thread-safe.
 */
#ifndef GEOSYNTH_PLUGIN_H
#define GEOSYNTH_PLUGIN_H

#include "geosynth/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* *out = the address of symbol `sym` in plugin `name` ("vdb", "render"),
 * loading the plugin on first use. GS_ERR_LIB naming the paths tried, or
 * dlerror(), when it cannot be loaded or lacks the symbol. */
gs_err gs_plugin_sym(const char *name, const char *sym, void **out);

/* The plugin file gs_plugin_sym loaded for `name`, or NULL if none yet. */
const char *gs_plugin_path(const char *name);

#ifdef __cplusplus
}
#endif

#endif
