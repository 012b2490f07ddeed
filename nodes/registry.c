/* SPDX-License-Identifier: MIT */
/* The node registry: every built-in node type, in a fixed order (the order of `wetgraph nodes`
 * and docs/nodes.md). Add a node by declaring its descriptor here and listing it below. */
#include "wetgraph/node.h"
#include "wetgraph/plugin.h"

#include <string.h>

extern const WgNodeType wg_node_uniform, wg_node_image;
extern const WgNodeType wg_node_blend;
extern const WgNodeType wg_node_levels, wg_node_invert, wg_node_grayscale;
extern const WgNodeType wg_node_blur;
/* distance and morphology */
extern const WgNodeType wg_node_distance, wg_node_dilate, wg_node_erode;
/* generators */
extern const WgNodeType wg_node_noise, wg_node_cells, wg_node_gradient, wg_node_checker,
    wg_node_sine, wg_node_shape, wg_node_bricks;
/* colour and value */
extern const WgNodeType wg_node_curve, wg_node_clamp, wg_node_threshold, wg_node_auto_levels;
extern const WgNodeType wg_node_statistics;
extern const WgNodeType wg_node_gradient_map, wg_node_hsl, wg_node_colorspace, wg_node_split,
    wg_node_merge, wg_node_shuffle;
/* pixel */
extern const WgNodeType wg_node_pixel;
/* height-field filters */
extern const WgNodeType wg_node_normal, wg_node_slope;
/* relief maps from a height field */
extern const WgNodeType wg_node_curvature, wg_node_ambient_occlusion;
/* resampling */
extern const WgNodeType wg_node_warp, wg_node_directional_warp, wg_node_transform;
/* neighbourhood filters and normal-map tools */
extern const WgNodeType wg_node_sharpen, wg_node_emboss, wg_node_edge_detect,
    wg_node_directional_blur, wg_node_normal_blend, wg_node_normal_normalize;
/* material preview */
extern const WgNodeType wg_node_env_prefilter, wg_node_preview;

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
    /* generators */
    &wg_node_noise,
    &wg_node_cells,
    &wg_node_gradient,
    &wg_node_checker,
    &wg_node_sine,
    &wg_node_shape,
    &wg_node_bricks,
    /* colour and value */
    &wg_node_curve,
    &wg_node_clamp,
    &wg_node_threshold,
    &wg_node_auto_levels,
    &wg_node_statistics,
    &wg_node_gradient_map,
    &wg_node_hsl,
    &wg_node_colorspace,
    &wg_node_split,
    &wg_node_merge,
    &wg_node_shuffle,
    /* per-pixel expressions */
    &wg_node_pixel,
    /* height-field filters */
    &wg_node_normal,
    &wg_node_slope,
    /* relief maps from a height field */
    &wg_node_curvature,
    &wg_node_ambient_occlusion,
    /* distance and morphology */
    &wg_node_distance,
    &wg_node_dilate,
    &wg_node_erode,
    /* resampling */
    &wg_node_warp,
    &wg_node_directional_warp,
    &wg_node_transform,
    /* neighbourhood filters and normal-map tools */
    &wg_node_sharpen,
    &wg_node_emboss,
    &wg_node_edge_detect,
    &wg_node_directional_blur,
    &wg_node_normal_blend,
    &wg_node_normal_normalize,
    /* material preview */
    &wg_node_env_prefilter,
    &wg_node_preview,
    NULL,
};

/* The engine reads graphs with the table it is handed: give it the built-in one when the
 * library, or a program linking it statically, loads (before main, so before any graph is
 * read). A static link keeps this file through the symbol wg_node_types (see the root
 * meson.build). */
__attribute__((constructor)) static void register_builtin_types(void)
{
    wg_set_node_types(wg_node_types);
}

const WgNodeType *wg_node_type_find(const char *name)
{
    const WgNodeType *const *types = wg_node_types_active();
    for (int i = 0; types[i]; i++)
        if (!strcmp(types[i]->name, name)) return types[i];
    return NULL;
}
