/* Plugin loading: see include/geosynth/plugin.h. */
#include <dlfcn.h>
#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "geosynth/plugin.h"

#ifndef GS_PLUGIN_BUILD_DIR
#define GS_PLUGIN_BUILD_DIR ""
#endif

enum { MAX_PLUGINS = 4 };

typedef struct plugin {
    char name[16];
    void *handle;
    char path[PATH_MAX];
} plugin;

static plugin plugins[MAX_PLUGINS];
static int nplugins;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;

/* dir/geosynth-name.so into buf; 0 when it does not fit. */
static int plugin_file(char *buf, size_t cap, const char *dir, const char *name)
{
    int n = snprintf(buf, cap, "%s/geosynth-%s.so", dir, name);
    return n > 0 && (size_t)n < cap;
}

/* The directories to try, in order (see plugin.h); *n of them. */
static void plugin_dirs(char dirs[4][PATH_MAX], int *n)
{
    *n = 0;
    const char *env = getenv("GEOSYNTH_PLUGIN_DIR");
    if (env && *env && strlen(env) < PATH_MAX)
        strcpy(dirs[(*n)++], env);
    char exe[PATH_MAX];
    ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (len > 0) {
        exe[len] = 0;
        char *slash = strrchr(exe, '/');
        if (slash) {
            *slash = 0;
            static const char *const rel[2] = {"../lib/geosynth", "../build/plugins"};
            for (int r = 0; r < 2; r++) {
                int k = snprintf(dirs[*n], PATH_MAX, "%s/%s", exe, rel[r]);
                if (k > 0 && k < PATH_MAX)
                    (*n)++;
            }
        }
    }
    if (GS_PLUGIN_BUILD_DIR[0] && strlen(GS_PLUGIN_BUILD_DIR) < PATH_MAX)
        strcpy(dirs[(*n)++], GS_PLUGIN_BUILD_DIR);
}

/* The loaded plugin `name`, loading it now if needed (lock held). */
static gs_err plugin_get(const char *name, plugin **out)
{
    for (int i = 0; i < nplugins; i++)
        if (strcmp(plugins[i].name, name) == 0) {
            *out = &plugins[i];
            return GS_OK;
        }
    GS_CHECK(nplugins < MAX_PLUGINS && strlen(name) < sizeof plugins[0].name, GS_ERR_INTERNAL,
             "plugin '%s': no room in the plugin table", name);
    char dirs[4][PATH_MAX], file[PATH_MAX], tried[4 * PATH_MAX + 64] = "";
    int ndirs;
    plugin_dirs(dirs, &ndirs);
    char why[512] = "";
    for (int d = 0; d < ndirs; d++) {
        if (!plugin_file(file, sizeof file, dirs[d], name))
            continue;
        size_t at = strlen(tried);
        snprintf(tried + at, sizeof tried - at, "%s%s", at ? ", " : "", file);
        if (access(file, F_OK) != 0)
            continue;
        void *h = dlopen(file, RTLD_NOW | RTLD_LOCAL);
        if (!h) { /* present but broken: say why, do not try older copies */
            const char *e = dlerror();
            snprintf(why, sizeof why, ": %s", e ? e : "dlopen failed");
            break;
        }
        plugin *p = &plugins[nplugins++];
        strcpy(p->name, name);
        p->handle = h;
        snprintf(p->path, sizeof p->path, "%s", file);
        *out = p;
        return GS_OK;
    }
    return gs_error_raise(GS_ERR_LIB, __FILE__, __LINE__, __func__,
                          "cannot load the %s plugin geosynth-%s.so (tried %s)%s; build it with "
                          "make, or set GEOSYNTH_PLUGIN_DIR to its directory",
                          name, name, tried[0] ? tried : "no directory", why);
}

gs_err gs_plugin_sym(const char *name, const char *sym, void **out)
{
    *out = NULL;
    pthread_mutex_lock(&lock);
    plugin *p = NULL;
    gs_err err = plugin_get(name, &p);
    if (err == GS_OK) {
        dlerror();
        *out = dlsym(p->handle, sym);
        if (!*out) {
            const char *e = dlerror();
            err = gs_error_raise(GS_ERR_LIB, __FILE__, __LINE__, __func__,
                                 "plugin %s has no symbol %s (%s): rebuild it with make", p->path,
                                 sym, e ? e : "null");
        }
    } else {
        gs_error_push_frame(__FILE__, __LINE__, __func__);
    }
    pthread_mutex_unlock(&lock);
    return err;
}

const char *gs_plugin_path(const char *name)
{
    const char *path = NULL;
    pthread_mutex_lock(&lock);
    for (int i = 0; i < nplugins; i++)
        if (strcmp(plugins[i].name, name) == 0)
            path = plugins[i].path;
    pthread_mutex_unlock(&lock);
    return path;
}
