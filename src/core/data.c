/* The data root: see include/geosynth/data.h. */
#include "geosynth/data.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "geosynth/file.h"

#ifndef GS_DATA_BUILD_DIR
#define GS_DATA_BUILD_DIR ""
#endif

const char *gs_data_relative(const char *value)
{
    size_t n = strlen(GS_DATA_VAR);
    if (!value || strncmp(value, GS_DATA_VAR, n) != 0)
        return NULL;
    if (value[n] == '\0')
        return value + n;
    if (value[n] != '/')
        return NULL; /* "${database}" is not the variable */
    return value + n + 1;
}

static int is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

/* a, "/", b into buf, normalized; 0 when it does not fit. */
static int join(char *buf, size_t cap, const char *a, const char *b)
{
    int k = snprintf(buf, cap, "%s/%s", a, b);
    if (k < 0 || (size_t)k + 2 > cap)
        return 0;
    gs_path_normalize(buf);
    return 1;
}

int gs_data_root(char *buf, size_t cap, const char **how, char *why, size_t wl)
{
    const char *env = getenv("GS_DATA");
    const char *dummy;
    if (!how)
        how = &dummy;
    if (env && *env) {
        *how = "GS_DATA";
        char cwd[PATH_MAX];
        if (env[0] != '/' && !getcwd(cwd, sizeof cwd)) {
            snprintf(why, wl, "GS_DATA = %s is relative, and the current directory is unknown",
                     env);
            return 0;
        }
        if (!join(buf, cap, env[0] == '/' ? "" : cwd, env)) {
            snprintf(why, wl, "GS_DATA = %s: path too long", env);
            return 0;
        }
        return 1;
    }
    /* An installed program, PREFIX/bin/geosynth, uses PREFIX/share/geosynth/data. */
    char exe[PATH_MAX];
    ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (len > 0) {
        exe[len] = '\0';
        char *slash = strrchr(exe, '/');
        if (slash) {
            *slash = '\0';
            if (join(buf, cap, exe, "../share/geosynth/data") && is_dir(buf)) {
                *how = "installed with the program; GS_DATA overrides it";
                return 1;
            }
        }
    }
    if (GS_DATA_BUILD_DIR[0] && join(buf, cap, GS_DATA_BUILD_DIR, ".")) {
        *how = "the data/ folder of the source tree; GS_DATA overrides it";
        return 1;
    }
    snprintf(why, wl, "no data root: set GS_DATA to the folder that holds the example data");
    return 0;
}

int gs_data_missing_hint(const char *path, char *buf, size_t cap)
{
    char root[PATH_MAX], why[160];
    const char *how;
    buf[0] = '\0';
    if (!path || !gs_data_root(root, sizeof root, &how, why, sizeof why))
        return 0;
    size_t n = strlen(root);
    if (strcmp(root, "/") == 0 || strncmp(path, root, n) != 0 || path[n] != '/')
        return 0;
    const char *rel = path + n + 1;
    const char *q = strpbrk(rel, " \t'\"$\\*?;&|<>()") ? "'" : ""; /* shell-quoted */
    /* The fetch script fills the source tree's data/ unless told another root. */
    char build_root[PATH_MAX], env[PATH_MAX + 16] = "";
    int is_default = GS_DATA_BUILD_DIR[0] && join(build_root, sizeof build_root,
                                                  GS_DATA_BUILD_DIR, ".") &&
                     !strcmp(build_root, root);
    if (!is_default)
        snprintf(env, sizeof env, "GS_DATA=%s ", root);
    snprintf(buf, cap,
             "this is " GS_DATA_VAR "/%s; the data root is %s (%s)%s. Third-party data "
             "the repository may not include is fetched with `make data` in the geosynth "
             "source tree (%sscripts/fetch-data.sh %s%s%s fetches only this file)",
             rel, root, how, is_dir(root) ? "" : ", which does not exist", env, q, rel, q);
    return 1;
}
