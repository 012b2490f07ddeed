/* SPDX-License-Identifier: MIT */
/* Graph files: loading and validating a .wetgraph file (and every subgraph it uses), and
 * reading what it declares: parameters, image inputs, outputs and nodes. A loaded WgGraph is
 * immutable; rendering it with different parameters or inputs is done with a WgRequest
 * (eval.h). */
#ifndef WETGRAPH_GRAPH_H
#define WETGRAPH_GRAPH_H

#include "error.h"
#include "io.h"
#include "node.h"
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct WgGraph WgGraph;

typedef struct WgGraphParamInfo {
    const char *name;
    WgParamType type;
    const char *default_text; /* as written in the file (or the type's natural default) */
    bool has_min, has_max;
    double min, max;
    const char *label;         /* may be NULL */
    const char *const *values; /* enum values, NULL-terminated; NULL for other types */
    int line;
    /* UI hints (float and int; they change nothing the graph computes): the range a slider
     * spans (within the hard range, which still validates every value), its step, the group the
     * control is shown in, and a description longer than the label (a tooltip) */
    bool has_soft_min, has_soft_max, has_step;
    double soft_min, soft_max, step;
    const char *group;       /* may be NULL (every type) */
    const char *description; /* may be NULL (every type) */
} WgGraphParamInfo;

typedef struct WgGraphInputInfo {
    const char *name;
    int kind; /* WG_GRAY or WG_COLOR */
    WgColorspace colorspace;
    bool has_default;
    const char *default_text;
    int line;
} WgGraphInputInfo;

typedef struct WgGraphOutputInfo {
    const char *name;
    const char *from; /* "node", "node.port" or "$input" */
    WgFormat format;  /* WG_FORMAT_DEFAULT when not given */
    WgColorspace colorspace;
    WgPngCompression compression; /* `compression`: how a PNG is compressed (default: DEFAULT) */
    int line;
    const char *group; /* the kind of map it is (`group`, e.g. maps, layers, masks), or NULL */
} WgGraphOutputInfo;

typedef struct WgGraphNodeInfo {
    const char *id;
    const char *type; /* as written */
    bool is_subgraph;
    const char *subgraph_path; /* resolved file for subgraphs, else NULL */
    int n_inputs;
    const char *const *input_ports; /* <in name> */
    const char *const *input_from;  /* <in from> */
    int line;
} WgGraphNodeInfo;

/* Most instances a graph may expand to: each node and graph input counts one, each use of a
 * subgraph one plus all that the subgraph holds (nested). Far above real graphs, far below what
 * subgraphs each using the next several times can reach (2^40 for 40 small files). */
#define WG_MAX_INSTANCES 1000000

/* Load and validate a graph file and its subgraphs. The caller owns *out. Subgraph types are
 * looked up as <type>.wetgraph in the including file's folder, then each folder of the
 * WETGRAPH_PATH environment variable (':'-separated), then the built-in graphs folder. A graph
 * that would expand to more than WG_MAX_INSTANCES node instances is refused (WG_ERR_RANGE),
 * naming the chain of files from this one to the subgraph that crosses the limit. */
int wg_graph_load(const char *path, WgGraph **out, WgError *err);
/* Load the graph file at `path` only to find its errors: each one of its elements that fails is
 * set aside and the rest loaded again, so that the independent errors of the file are found in
 * one go (up to `max`, in errors[0..*count)); an error that follows from an element set aside
 * (a reference to it) is not counted. WG_OK (and *count 0) when the file is valid. */
int wg_graph_check_all(const char *path, WgError *errors, int max, int *count);
/* Same from memory; `path` names the source in messages and anchors relative paths. */
int wg_graph_load_memory(const char *xml, size_t len, const char *path, WgGraph **out,
                         WgError *err);
void wg_graph_free(WgGraph *g);

const char *wg_graph_name(const WgGraph *g); /* file name without folder and extension */
const char *wg_graph_path(const WgGraph *g);
const char *wg_graph_label(const WgGraph *g); /* the root's `label`, or NULL */
const char *wg_graph_size_text(const WgGraph *g); /* root `size` attribute */
uint64_t wg_graph_seed(const WgGraph *g);

int wg_graph_param_count(const WgGraph *g);
const WgGraphParamInfo *wg_graph_param_info(const WgGraph *g, int i);
int wg_graph_input_count(const WgGraph *g);
const WgGraphInputInfo *wg_graph_input_info(const WgGraph *g, int i);
int wg_graph_output_count(const WgGraph *g);
const WgGraphOutputInfo *wg_graph_output_info(const WgGraph *g, int i);
/* A glTF asset the graph declares (<gltf>): each map a graph output, by name (NULL where the
 * asset has none); the rest as WgGltfAsset says. */
typedef struct WgGraphGltfInfo {
    const char *name;
    const char *maps[WG_GLTF_SLOT_COUNT];
    bool binary;
    int grid;
    double height_scale, repeat;
    /* height_scale written as "=expression" over the graph's parameters: its text (after '=');
     * height_scale is then 0 and a render's value is wg_result_gltf_height_scale */
    const char *height_scale_expr;
    int line;
} WgGraphGltfInfo;
int wg_graph_gltf_count(const WgGraph *g);
const WgGraphGltfInfo *wg_graph_gltf_info(const WgGraph *g, int i);
/* The <gltf> named `name`, or -1. */
int wg_graph_find_gltf(const WgGraph *g, const char *name);
int wg_graph_node_count(const WgGraph *g);
const WgGraphNodeInfo *wg_graph_node_info(const WgGraph *g, int i);

/* Graphviz description of the graph (its own nodes; subgraphs as single boxes). */
int wg_graph_write_dot(const WgGraph *g, FILE *f);

/* Parse "N" or "WxH" (sides 1..WG_MAX_SIDE); false when malformed or out of range. */
bool wg_parse_size(const char *text, int *width, int *height);

/* Folder of the built-in graph library used as the last search location. */
const char *wg_builtin_graphs_dir(void);

/* The graph file a command line names: `name` itself when it exists (a folder is an error);
 * else, when it holds no '/', <name>.wetgraph (or `name`, when it ends so) in each folder of
 * WETGRAPH_PATH, then in the built-in folder, as a subgraph type is looked up. The caller
 * frees *path with wg_free. Not found: WG_ERR_IO, with the closest graph name as a
 * suggestion. */
int wg_graph_find(const char *name, char **path, WgError *err);

/* One graph of the library: its name (file name without .wetgraph) and file. */
typedef struct WgGraphEntry {
    char *name;
    char *path;
} WgGraphEntry;

/* Every graph a name finds (wg_graph_find): the .wetgraph files of the WETGRAPH_PATH folders
 * and of the built-in folder, each name once (the first folder holding it wins), sorted by
 * name. Free with wg_graph_list_free. */
int wg_graph_list(WgGraphEntry **out, int *count, WgError *err);
void wg_graph_list_free(WgGraphEntry *list, int count);

/* "did you mean" helper: the candidate closest to `word` (edit distance <= 2 or a prefix
 * match), or NULL. */
const char *wg_suggest(const char *word, const char *const *candidates, int count);

#ifdef __cplusplus
}
#endif
#endif
