/* Registry of the engines built into geosynth. An engine is added here
 * when it lands; there are no placeholder engines. */
#include <string.h>

#include "geosynth/engines.h"

extern const gs_engine gs_engine_field;
extern const gs_engine gs_engine_model;
extern const gs_engine gs_engine_points;
extern const gs_engine gs_engine_micro;

static const gs_engine *const engine_list[] = {
    &gs_engine_field,
    &gs_engine_model,
    &gs_engine_points,
    &gs_engine_micro,
    NULL /* terminator */
};

const gs_engine *const *gs_engines(int *count)
{
    int n = 0;
    while (engine_list[n])
        n++;
    *count = n;
    return engine_list;
}

const gs_engine *gs_engine_find(const char *name)
{
    for (int i = 0; engine_list[i]; i++)
        if (!strcmp(engine_list[i]->name, name))
            return engine_list[i];
    return NULL;
}
