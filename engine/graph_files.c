/* SPDX-License-Identifier: MIT */
/* Finding and reading graph files: the built-in graphs folder (WETGRAPH_GRAPHS_DIR, else the
 * source tree's graphs/, else the installed one), path helpers, the search for a subgraph
 * named by a node's type (a .wetgraph path relative to the using file; or <type>.wetgraph next
 * to the using file, then in each WETGRAPH_PATH folder, then in the built-in folder) with a
 * spelling suggestion when nothing is found, and reading a graph file's whole text. */
#include "load.h"

#include <errno.h>
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

const char *wg_builtin_graphs_dir(void)
{
    const char *env = getenv("WETGRAPH_GRAPHS_DIR");
    if (env && dir_exists(env)) return env;
    if (dir_exists(WG_SOURCE_GRAPHS_DIR)) return WG_SOURCE_GRAPHS_DIR;
    return WG_INSTALL_GRAPHS_DIR;
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
