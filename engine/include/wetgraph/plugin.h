/* SPDX-License-Identifier: MIT */
/* Node plugins: node types written outside the tree, in a shared library, and added to the
 * types graphs are read with.
 *
 * A plugin is a shared library that exports one function, `wetgraph_plugin`, returning a
 * description of itself built with WG_PLUGIN_INIT:
 *
 *     static const WgNodeType *const types[] = {&my_node, NULL};
 *     WG_PLUGIN_EXPORT const WgPlugin *wetgraph_plugin(void)
 *     {
 *         static const WgPlugin plugin = WG_PLUGIN_INIT("my_nodes", "1.0.0", types);
 *         return &plugin;
 *     }
 *
 * The loader checks the ABI version and the descriptors' sizes the plugin was compiled with
 * against the library's, then every descriptor (wg_node_type_validate), and refuses a type whose
 * name is a built-in's or another plugin's. A plugin's types take part in cache keys through the
 * plugin's identity (a hash of its file and its version string), so a replaced plugin never gets
 * results its predecessor cached. Plugins are never unloaded.
 *
 * `wetgraph` loads the plugins of the WETGRAPH_PLUGIN_PATH folders (every *.so, in name order)
 * and those given with `--plugin FILE` (docs/plugins.md). */
#ifndef WETGRAPH_PLUGIN_H
#define WETGRAPH_PLUGIN_H

#include "error.h"
#include "node.h"
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Raised whenever WgNodeType, WgParamSpec, WgPortSpec, WgNodeContext or the meaning of what a
 * node sees changes incompatibly. */
#define WG_PLUGIN_ABI 1

typedef struct WgPlugin {
    int abi;                        /* WG_PLUGIN_ABI the plugin was compiled with */
    size_t node_type_size;          /* sizeof(WgNodeType) there */
    size_t param_spec_size;         /* sizeof(WgParamSpec) there */
    size_t context_size;            /* sizeof(WgNodeContext) there */
    const char *name;               /* a short name, for messages */
    const char *version;            /* the plugin's own version: part of its types' cache keys */
    const WgNodeType *const *types; /* NULL-terminated */
} WgPlugin;

#define WG_PLUGIN_INIT(name, version, types)                                                       \
    {                                                                                              \
        WG_PLUGIN_ABI, sizeof(WgNodeType), sizeof(WgParamSpec), sizeof(WgNodeContext), name,       \
            version, types                                                                         \
    }

/* The entry point's name and type. */
#define WG_PLUGIN_ENTRY "wetgraph_plugin"
typedef const WgPlugin *(*WgPluginEntry)(void);
#define WG_PLUGIN_EXPORT __attribute__((visibility("default")))

/* Load the plugin at path and add its types. Loading a file already loaded does nothing.
 * Errors (WG_ERR_PLUGIN... as WG_ERR_USAGE, naming the file): it cannot be opened, no entry
 * point, an ABI or descriptor-size mismatch, an invalid descriptor, a name taken by a built-in
 * type or another plugin's (naming both files). On error no type of the plugin is added. Not
 * thread-safe: load plugins before graphs are read or rendered. */
int wg_plugin_load(const char *path, WgError *err);
/* Every *.so of each folder of a colon-separated list, in name order; empty entries and
 * missing folders are skipped. Stops at the first error. */
int wg_plugin_load_dirs(const char *dirs, WgError *err);
/* Add a plugin already in the process (linked in, or a program's own node types): `origin`
 * stands for its file in messages and, with its version, in cache keys. The WgPlugin and its
 * types must outlive the process's use of them. */
int wg_plugin_add(const WgPlugin *plugin, const char *origin, WgError *err);

/* Is the descriptor well formed? Checks what the engine relies on: a lowercase identifier as
 * name, a one-line summary and a category, an eval function, at least one output, ports with
 * unique lowercase names and a valid kind, parameters with unique lowercase names (not a
 * reserved attribute), a label, a known type, a default within its range and a UI range
 * within it, valid enum values and default, colour defaults that parse, fields inside the
 * params struct, and known flags. WG_ERR_TYPE naming the type and what is wrong otherwise. */
int wg_node_type_validate(const WgNodeType *t, WgError *err);

/* The node types graphs are read with now (built-in, then plugins'), NULL-terminated. */
const WgNodeType *const *wg_node_types_active(void);
/* The file of the plugin a type came from (its origin), or NULL for a built-in type. */
const char *wg_node_type_origin(const WgNodeType *t);

#ifdef __cplusplus
}
#endif
#endif
