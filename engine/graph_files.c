/* SPDX-License-Identifier: MIT */
/* Finding and reading graph files: the built-in graphs folder (WETGRAPH_GRAPHS_DIR, else the
 * source tree's graphs/ for the library in the build tree and the installed one for an
 * installed library), path helpers, the search for a subgraph
 * named by a node's type (a .wetgraph path relative to the using file; or <type>.wetgraph next
 * to the using file, then in each WETGRAPH_PATH folder, then in the built-in folder) with a
 * spelling suggestion when nothing is found, the graph a command line names (a file, or a
 * graph's name looked up as a subgraph is, from WETGRAPH_PATH on), the graph library (every
 * graph those folders hold, by name), and reading a graph file's whole text. */
#include "load.h"

#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#ifndef WG_SOURCE_GRAPHS_DIR
#define WG_SOURCE_GRAPHS_DIR ""
#endif
#ifndef WG_INSTALL_GRAPHS_DIR
#define WG_INSTALL_GRAPHS_DIR ""
#endif
#ifndef WG_BUILD_DIR
#define WG_BUILD_DIR ""
#endif

static bool file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static bool dir_exists(const char *path)
{
    struct stat st;
    return path[0] && stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

/* Whether this library is the one in the build tree (not an installed copy): found through
 * the path of the object holding this function. */
static bool in_build_tree(void)
{
    Dl_info info;
    if (!dladdr((void *)in_build_tree, &info) || !info.dli_fname) return false;
    char *real = realpath(info.dli_fname, NULL);
    size_t len = strlen(WG_BUILD_DIR);
    bool in = real && len > 0 && !strncmp(real, WG_BUILD_DIR, len) && real[len] == '/';
    free(real);
    return in;
}

static const char *builtin_dir;

static void builtin_dir_find(void)
{
    /* a library built here reads the source tree's graphs, an installed one its own */
    bool build = in_build_tree();
    if (build && dir_exists(WG_SOURCE_GRAPHS_DIR))
        builtin_dir = WG_SOURCE_GRAPHS_DIR;
    else if (dir_exists(WG_INSTALL_GRAPHS_DIR) || !dir_exists(WG_SOURCE_GRAPHS_DIR))
        builtin_dir = WG_INSTALL_GRAPHS_DIR;
    else
        builtin_dir = WG_SOURCE_GRAPHS_DIR;
}

const char *wg_builtin_graphs_dir(void)
{
    const char *env = getenv("WETGRAPH_GRAPHS_DIR");
    if (env && dir_exists(env)) return env;
    static pthread_once_t once = PTHREAD_ONCE_INIT;
    pthread_once(&once, builtin_dir_find);
    return builtin_dir;
}

char *wg__dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash) return wg_strdup(".");
    if (slash == path) return wg_strdup("/");
    return wg_strndup(path, (size_t)(slash - path));
}

static char *join_path(const char *dir, const char *name)
{
    if (name[0] == '/' || !dir || !dir[0]) return wg_strdup(name);
    size_t n = strlen(dir) + strlen(name) + 2;
    char *p = wg_malloc(n);
    if (p) snprintf(p, n, "%s/%s", dir, name);
    return p;
}

bool wg__ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}
/* *found = dir/file when that file exists. A path that cannot be built is WG_ERR_NOMEM: it
 * must not pass for a missing file. */
static int try_path(const char *dir, const char *file, char **found, WgError *err)
{
    char *cand = join_path(dir, file);
    if (!cand) return nomem(err);
    if (file_exists(cand))
        *found = cand;
    else
        wg_free(cand);
    return WG_OK;
}

int wg__resolve_subgraph(LoadCtx *lc, Doc *d, WgGraph *g, NodeDef *n, WgError *err)
{
    char *found = NULL;
    int rc = WG_OK;
    if (wg__ends_with(n->type_name, ".wetgraph")) {
        found = join_path(g->dir, n->type_name);
        if (found && !file_exists(found)) {
            wg_free(found);
            return wg_error_set_at(err, WG_ERR_IO, d->path, n->line, 0,
                                   "subgraph file '%s' not found (relative to %s)", n->type_name,
                                   g->dir);
        }
    } else {
        size_t fl = strlen(n->type_name) + 10;
        char *file = wg_malloc(fl);
        if (!file) return nomem(err);
        snprintf(file, fl, "%s.wetgraph", n->type_name);
        rc = try_path(g->dir, file, &found, err);
        const char *env = getenv("WETGRAPH_PATH");
        if (!rc && !found && env) {
            char *copy = wg_strdup(env);
            if (!copy) rc = nomem(err);
            for (char *save = NULL, *tok = copy ? strtok_r(copy, ":", &save) : NULL;
                 tok && !found && !rc; tok = strtok_r(NULL, ":", &save))
                rc = try_path(tok, file, &found, err);
            wg_free(copy);
        }
        if (!rc && !found) rc = try_path(wg_builtin_graphs_dir(), file, &found, err);
        wg_free(file);
        if (rc) return rc;
        if (!found) {
            const char *names[256];
            int count = wg__node_type_names(names, 256);
            const char *s = wg_suggest(n->type_name, names, count);
            if (s)
                return wg_error_set_at(err, WG_ERR_TYPE, d->path, n->line, 0,
                                       "unknown node type '%s'; did you mean '%s'?", n->type_name,
                                       s);
            return wg_error_set_at(
                err, WG_ERR_TYPE, d->path, n->line, 0,
                "unknown node type '%s' (not a built-in node, and no %s.wetgraph "
                "next to this file, in WETGRAPH_PATH or in %s)",
                n->type_name, n->type_name, wg_builtin_graphs_dir());
        }
    }
    if (!found) return nomem(err);
    rc = wg__load_file(lc, found, &n->sub, err);
    if (rc && err && !err->file[0]) wg_error_locate(err, d->path, n->line, n->id);
    if (rc == WG_ERR_CYCLE || rc == WG_ERR_PARSE || rc == WG_ERR_TYPE || rc == WG_ERR_RANGE ||
        rc == WG_ERR_IO) {
        /* keep the inner location, say where it was used */
        if (err) {
            size_t l = strlen(err->message);
            snprintf(err->message + l, sizeof err->message - l, " (used by node '%s' at %s:%d)",
                     n->id, d->path, n->line);
        }
    }
    wg_free(found);
    return rc;
}

/* ---- graphs named on a command line, and the library ----------------------------------- */

/* The folders a graph name is looked up in, in order: each WETGRAPH_PATH folder, then the
 * built-in one. Returns the count; *buf holds the strings (wg_free it). */
static int library_dirs(const char **dirs, int max, char **buf)
{
    int n = 0;
    const char *env = getenv("WETGRAPH_PATH");
    *buf = env && env[0] ? wg_strdup(env) : NULL;
    for (char *save = NULL, *tok = *buf ? strtok_r(*buf, ":", &save) : NULL; tok && n < max - 1;
         tok = strtok_r(NULL, ":", &save))
        dirs[n++] = tok;
    dirs[n++] = wg_builtin_graphs_dir();
    return n;
}

static int cmp_entry(const void *a, const void *b)
{
    return strcmp(((const WgGraphEntry *)a)->name, ((const WgGraphEntry *)b)->name);
}

void wg_graph_list_free(WgGraphEntry *list, int count)
{
    for (int i = 0; list && i < count; i++) {
        wg_free(list[i].name);
        wg_free(list[i].path);
    }
    wg_free(list);
}

int wg_graph_list(WgGraphEntry **out, int *count, WgError *err)
{
    *out = NULL, *count = 0;
    const char *dirs[64];
    char *buf = NULL;
    int n_dirs = library_dirs(dirs, 64, &buf), n = 0, cap = 0, rc = WG_OK;
    WgGraphEntry *list = NULL;
    for (int k = 0; k < n_dirs && !rc; k++) {
        DIR *d = dir_exists(dirs[k]) ? opendir(dirs[k]) : NULL;
        if (!d) continue;
        int first = n; /* entries of earlier folders shadow this one's */
        for (struct dirent *e; !rc && (e = readdir(d));) {
            size_t len = strlen(e->d_name);
            if (e->d_name[0] == '.' || !wg__ends_with(e->d_name, ".wetgraph") || len == 9) continue;
            char *path = join_path(dirs[k], e->d_name);
            char *name = wg_strndup(e->d_name, len - 9);
            if (!path || !name) {
                wg_free(path), wg_free(name);
                rc = nomem(err);
                break;
            }
            bool shadowed = !file_exists(path);
            for (int i = 0; i < first && !shadowed; i++) shadowed = !strcmp(list[i].name, name);
            if (shadowed) {
                wg_free(path), wg_free(name);
                continue;
            }
            if (n == cap) {
                int c = cap ? 2 * cap : 32;
                WgGraphEntry *bigger = wg_realloc_array(list, (size_t)cap, (size_t)c, sizeof *list);
                if (!bigger) {
                    wg_free(path), wg_free(name);
                    rc = nomem(err);
                    break;
                }
                list = bigger, cap = c;
            }
            list[n++] = (WgGraphEntry){name, path};
        }
        closedir(d);
    }
    wg_free(buf);
    if (rc) {
        wg_graph_list_free(list, n);
        return rc;
    }
    if (n > 1) qsort(list, (size_t)n, sizeof *list, cmp_entry);
    *out = list, *count = n;
    return WG_OK;
}

int wg_graph_find(const char *name, char **path, WgError *err)
{
    *path = NULL;
    if (!name || !name[0]) return wg_error_set(err, WG_ERR_IO, NULL, "no graph file given");
    struct stat st;
    if (stat(name, &st) == 0) {
        if (S_ISDIR(st.st_mode))
            return wg_error_set_at(err, WG_ERR_IO, name, 0, 0,
                                   "cannot open the graph file: it is a folder");
        return (*path = wg_strdup(name)) ? WG_OK : nomem(err);
    }
    if (strchr(name, '/'))
        return wg_error_set_at(err, WG_ERR_IO, name, 0, 0,
                               "cannot open the graph file: no such file");
    /* a bare name: NAME.wetgraph (or NAME) in WETGRAPH_PATH, then the built-in folder */
    size_t fl = strlen(name) + 10;
    char *file = wg_malloc(fl);
    if (!file) return nomem(err);
    snprintf(file, fl, "%s%s", name, wg__ends_with(name, ".wetgraph") ? "" : ".wetgraph");
    const char *dirs[64];
    char *buf = NULL;
    int n_dirs = library_dirs(dirs, 64, &buf), rc = WG_OK;
    for (int k = 0; k < n_dirs && !*path && !rc; k++)
        if (dir_exists(dirs[k])) rc = try_path(dirs[k], file, path, err);
    wg_free(buf);
    wg_free(file);
    if (rc || *path) return rc;
    WgGraphEntry *list = NULL;
    int count = 0;
    const char *names[512], *s = NULL;
    if (!wg_graph_list(&list, &count, NULL)) {
        int m = count < 512 ? count : 512;
        for (int i = 0; i < m; i++) names[i] = list[i].name;
        s = wg_suggest(name, names, m);
    }
    wg_error_set_at(err, WG_ERR_IO, name, 0, 0,
                    "no such graph file, and no graph of that name in WETGRAPH_PATH or in %s%s%s%s",
                    wg_builtin_graphs_dir(), s ? "; did you mean '" : "", s ? s : "",
                    s ? "'?" : " ('wetgraph graphs' lists them)");
    wg_graph_list_free(list, count);
    return WG_ERR_IO;
}

/* The whole file (the line annotation needs the text); graph files are small. */
int wg__read_text(const char *path, char **text, size_t *len, WgError *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the graph file: %s",
                               strerror(errno));
    size_t cap = 1 << 16, n = 0;
    char *buf = wg_malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap) break;
        if (cap >= ((size_t)1 << 30)) {
            wg_free(buf);
            fclose(f);
            return wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0, "graph file larger than 1 GiB");
        }
        char *bigger = wg_realloc_array(buf, cap, cap * 2, 1);
        if (!bigger) wg_free(buf);
        buf = bigger;
        cap *= 2;
    }
    bool bad = buf && ferror(f);
    fclose(f);
    if (!buf) return nomem(err);
    if (bad) {
        wg_free(buf);
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the graph file: %s",
                               strerror(errno));
    }
    *text = buf;
    *len = n;
    return WG_OK;
}
