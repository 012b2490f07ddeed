/* SPDX-License-Identifier: MIT */
/* The node registry: every built-in node type, in a fixed order (the order of `wetgraph nodes`
 * and docs/nodes.md). Add a node by declaring its descriptor here and listing it below. */
#include "wetgraph/node.h"

#include <string.h>

extern const WgNodeType wg_node_uniform, wg_node_image;
extern const WgNodeType wg_node_blend;
extern const WgNodeType wg_node_levels, wg_node_invert, wg_node_grayscale;
extern const WgNodeType wg_node_blur;
/* issue 3: generators */
/* issue 3: colour and value */
/* issue 3: pixel */

const WgNodeType *const wg_node_types[] = {
    /* sources */
    &wg_node_uniform,
    &wg_node_image,
    /* blending */
    &wg_node_blend,
    /* colour and value */
    &wg_node_levels,
    &wg_node_invert,
    &wg_node_grayscale,
    /* filters */
    &wg_node_blur,
    /* generators (issue 3) */
    /* colour and value (issue 3) */
    /* per-pixel expressions (issue 3) */
    NULL,
};

const WgNodeType *wg_node_type_find(const char *name)
{
    for (int i = 0; wg_node_types[i]; i++)
        if (!strcmp(wg_node_types[i]->name, name)) return wg_node_types[i];
    return NULL;
}
