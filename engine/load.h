/* SPDX-License-Identifier: MIT */
/* What the files that load a .wetgraph document share (xml.c reads the document,
 * graph_check.c links and checks it, graph_files.c finds and reads graph files): the state of
 * one load, the document being read, and the functions they call across files. Private to the
 * loader; the rest of the engine sees the loaded graph through internal.h. */
#ifndef WETGRAPH_LOAD_H
#define WETGRAPH_LOAD_H

#include "internal.h"

#include <stdbool.h>
#include <stddef.h>

typedef struct LoadCtx {
    char *stack[64]; /* real paths of the graphs being loaded, outermost first */
    int depth;
    WgGraph **loaded; /* every graph file loaded so far, shared by all that use it */
    char **loaded_real;
    int n_loaded, cap_loaded;
    WgNameIndex loaded_index; /* real path -> position in loaded */
    /* wg_graph_check_all: the outermost file's errors, collected up to collect_max */
    WgError *collected;
    int n_collected, collect_max;
} LoadCtx;

/* The document being read: errors name its path. */
typedef struct Doc {
    const char *path;
    WgError *err;
    WgNameIndex subgraphs; /* node type -> the first node of this file using that subgraph */
} Doc;
/* Out of memory, with a message like every other error (the bare code would leave it empty). */
static inline int nomem(WgError *err)
{
    return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
}

/* ---- xml.c ------------------------------------------------------------------------------- */

/* Load the graph file at `path` (or share the copy this load already has), detecting recursion
 * between graph files. */
int wg__load_file(LoadCtx *lc, const char *path, WgGraph **out, WgError *err);

/* ---- graph_check.c ----------------------------------------------------------------------- */

/* Node ids, input, output and parameter names: a letter or '_', then letters, digits, '_', '-'. */
bool wg__valid_id(const char *s);
/* Resolve "node", "node.port" or "$input" in graph g. */
int wg__resolve_from(Doc *d, WgGraph *g, const char *from, int line, int *node, int *port,
                     int *input);
/* Resolve a node's connections and check its required inputs; `seen` starts empty and
 * collects the node's connected port names. */
int wg__link_node(Doc *d, WgGraph *g, NodeDef *n, WgNameIndex *seen);
/* WG_ERR_CYCLE naming the node ids around the first cycle between g's nodes. */
int wg__find_cycle(Doc *d, WgGraph *g);

/* ---- graph_files.c ----------------------------------------------------------------------- */

char *wg__dir_of(const char *path);
bool wg__ends_with(const char *s, const char *suffix);
/* Find and load the subgraph file of node n, whose type is no node type: the file it names,
 * or <type>.wetgraph next to the file, in WETGRAPH_PATH or in the built-in graphs folder. */
int wg__resolve_subgraph(LoadCtx *lc, Doc *d, WgGraph *g, NodeDef *n, WgError *err);
/* The whole file (the line annotation needs the text); caller frees *text. */
int wg__read_text(const char *path, char **text, size_t *len, WgError *err);

#endif
