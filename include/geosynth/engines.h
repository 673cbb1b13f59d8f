/* The engines built into this binary (src/cli/engines.c): the one place
 * above the engine folders that names them all, so it belongs to the cli
 * layer (docs/ARCHITECTURE.md, "Layers"); the interface each engine
 * implements is include/geosynth/engine.h. */
#ifndef GEOSYNTH_ENGINES_H
#define GEOSYNTH_ENGINES_H

#include "geosynth/engine.h"

/* The engines in --help order; *count receives how many. */
const gs_engine *const *gs_engines(int *count);
/* The engine called name, or NULL. */
const gs_engine *gs_engine_find(const char *name);

#endif
