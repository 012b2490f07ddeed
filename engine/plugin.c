/* SPDX-License-Identifier: MIT */
/* Node plugins (wetgraph/plugin.h): loading a plugin's shared library, checking what it declares,
 * and adding its types to the table graphs are read with (types.c), with a record per type of
 * where it came from and the identity that enters its cache keys. Nothing here is ever
 * unloaded: a graph keeps pointers to its types for as long as it lives. */
#include "internal.h"
#include "wgio.h"

#include <dirent.h>
#include <errno.h>
#include <dlfcn.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>
#include <wetgraph/plugin.h>
#include <xxhash.h>

typedef struct {
    const WgNodeType *type;
    const char *origin; /* the plugin's file (real path) or the name given to wg_plugin_add */
    uint64_t key[2];    /* the plugin's identity: its file's hash and its version */
} Origin;

static Origin *origins;
static int n_origins;
static char **loaded; /* real paths of the files loaded, so a second load does nothing */
static int n_loaded;
static const WgNodeType **table; /* the table handed to wg_set_node_types (owned) */

const char *wg_node_type_origin(const WgNodeType *t)
{
    for (int i = 0; i < n_origins; i++)
        if (origins[i].type == t) return origins[i].origin;
    return NULL;
}

const uint64_t *wg__node_type_plugin_key(const WgNodeType *t)
{
    for (int i = 0; i < n_origins; i++)
        if (origins[i].type == t) return origins[i].key;
    return NULL;
}

static int plugin_error(WgError *err, const char *file, const char *fmt, const char *detail)
{
    return wg_error_set_at(err, WG_ERR_USAGE, file, 0, 0, fmt, detail);
}

/* Check the plugin against the library and the types already known, then add its types. */
static int add(const WgPlugin *p, const char *origin, const uint64_t file_hash[2], WgError *err)
{
    if (!p) return plugin_error(err, origin, "%s", "the plugin's entry point returned NULL");
    if (p->abi != WG_PLUGIN_ABI)
        return wg_error_set_at(err, WG_ERR_USAGE, origin, 0, 0,
                               "built for plugin ABI %d, this wetgraph has ABI %d: rebuild the "
                               "plugin against this version's headers",
                               p->abi, WG_PLUGIN_ABI);
    if (p->node_type_size != sizeof(WgNodeType) || p->param_spec_size != sizeof(WgParamSpec) ||
        p->context_size != sizeof(WgNodeContext))
        return wg_error_set_at(err, WG_ERR_USAGE, origin, 0, 0,
                               "built with other descriptor sizes (node type %zu, parameter %zu, "
                               "context %zu bytes; this wetgraph: %zu, %zu, %zu): rebuild the "
                               "plugin against this version's headers",
                               p->node_type_size, p->param_spec_size, p->context_size,
                               sizeof(WgNodeType), sizeof(WgParamSpec), sizeof(WgNodeContext));
    if (!p->name || !p->name[0] || !p->version || !p->version[0])
        return plugin_error(err, origin, "%s", "the plugin has no name or no version");
    int n = 0;
    while (p->types && p->types[n]) n++;
    if (n == 0) return plugin_error(err, origin, "%s", "the plugin declares no node types");
    const WgNodeType *const *active = wg_node_types_active();
    int n_active = 0;
    while (active[n_active]) n_active++;
    for (int i = 0; i < n; i++) {
        const WgNodeType *t = p->types[i];
        WgError why = {0};
        if (wg_node_type_validate(t, &why)) return plugin_error(err, origin, "%s", why.message);
        for (int k = 0; k < i; k++)
            if (!strcmp(p->types[k]->name, t->name))
                return wg_error_set_at(err, WG_ERR_USAGE, origin, 0, 0,
                                       "node type '%s' is declared twice", t->name);
        for (int k = 0; k < n_active; k++) {
            if (strcmp(active[k]->name, t->name)) continue;
            const char *other = wg_node_type_origin(active[k]);
            if (!other)
                return wg_error_set_at(err, WG_ERR_USAGE, origin, 0, 0,
                                       "node type '%s' is a built-in type's name: a plugin "
                                       "cannot replace a built-in node",
                                       t->name);
            return wg_error_set_at(err, WG_ERR_USAGE, origin, 0, 0,
                                   "node type '%s' is already defined by the plugin %s",
                                   t->name, other);
        }
    }
    /* everything checked: nothing below can leave the tables half changed */
    const WgNodeType **grown = malloc(sizeof *grown * (size_t)(n_active + n + 1));
    Origin *more = realloc(origins, sizeof *origins * (size_t)(n_origins + n));
    char *name = strdup(origin);
    if (more) origins = more;
    if (!grown || !more || !name) {
        free(grown);
        free(name);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    XXH3_state_t *st = XXH3_createState();
    if (!st) {
        free(grown);
        free(name);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    XXH3_128bits_reset(st);
    int abi = WG_PLUGIN_ABI;
    XXH3_128bits_update(st, &abi, sizeof abi);
    XXH3_128bits_update(st, p->version, strlen(p->version) + 1);
    if (file_hash)
        XXH3_128bits_update(st, file_hash, 2 * sizeof *file_hash);
    else
        XXH3_128bits_update(st, origin, strlen(origin) + 1);
    XXH128_hash_t h = XXH3_128bits_digest(st);
    XXH3_freeState(st);
    for (int i = 0; i < n; i++)
        origins[n_origins++] = (Origin){p->types[i], name, {h.low64, h.high64}};
    memcpy(grown, active, sizeof *grown * (size_t)n_active);
    memcpy(grown + n_active, p->types, sizeof *grown * (size_t)n);
    grown[n_active + n] = NULL;
    wg_set_node_types(grown);
    free(table);
    table = grown;
    return WG_OK;
}

int wg_plugin_add(const WgPlugin *plugin, const char *origin, WgError *err)
{
    if (!origin || !origin[0])
        return wg_error_set(err, WG_ERR_USAGE, NULL, "wg_plugin_add: no origin given");
    return add(plugin, origin, NULL, err);
}

int wg_plugin_load(const char *path, WgError *err)
{
    char real[PATH_MAX];
    if (!realpath(path, real))
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0, "cannot open the plugin: %s",
                               strerror(errno));
    for (int i = 0; i < n_loaded; i++)
        if (!strcmp(loaded[i], real)) return WG_OK;
    uint64_t file_hash[2];
    if (!wg__hash_file(real, file_hash))
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0, "cannot read the plugin");
    char **more = realloc(loaded, sizeof *loaded * (size_t)(n_loaded + 1));
    if (!more) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    loaded = more;
    dlerror();
    void *h = dlopen(real, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char *why = dlerror();
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0, "cannot load the plugin: %s",
                               why ? why : "unknown reason");
    }
    WgPluginEntry entry;
    *(void **)&entry = dlsym(h, WG_PLUGIN_ENTRY);
    if (!entry) {
        dlclose(h);
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0,
                               "not a wetgraph plugin: it exports no '%s' function "
                               "(const WgPlugin *" WG_PLUGIN_ENTRY "(void), see docs/plugins.md)",
                               WG_PLUGIN_ENTRY);
    }
    int rc = add(entry(), path, file_hash, err);
    if (rc) {
        dlclose(h);
        return rc;
    }
    if (!(loaded[n_loaded] = strdup(real))) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    n_loaded++;
    return WG_OK;
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The *.so files of one folder, in name order. */
static int load_dir(const char *dir, WgError *err)
{
    DIR *d = opendir(dir);
    if (!d) return WG_OK; /* a folder that is not there holds no plugins */
    char **names = NULL;
    int n = 0, cap = 0, rc = WG_OK;
    for (struct dirent *e; (e = readdir(d));) {
        size_t len = strlen(e->d_name);
        if (len < 4 || strcmp(e->d_name + len - 3, ".so")) continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 16;
            char **more = realloc(names, sizeof *names * (size_t)cap);
            if (!more) {
                rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
                break;
            }
            names = more;
        }
        if (!(names[n] = strdup(e->d_name))) {
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
            break;
        }
        n++;
    }
    closedir(d);
    if (!rc && n) qsort(names, (size_t)n, sizeof *names, by_name);
    for (int i = 0; i < n; i++) {
        if (!rc) {
            char path[PATH_MAX];
            snprintf(path, sizeof path, "%s/%s", dir, names[i]);
            rc = wg_plugin_load(path, err);
        }
        free(names[i]);
    }
    free(names);
    return rc;
}

int wg_plugin_load_dirs(const char *dirs, WgError *err)
{
    if (!dirs) return WG_OK;
    const char *p = dirs;
    while (*p) {
        const char *end = strchr(p, ':');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len > 0 && len < PATH_MAX) {
            char dir[PATH_MAX];
            memcpy(dir, p, len);
            dir[len] = '\0';
            int rc = load_dir(dir, err);
            if (rc) return rc;
        }
        if (!end) break;
        p = end + 1;
    }
    return WG_OK;
}
