/* SPDX-License-Identifier: MIT */
/* The glTF assets a graph declares (<gltf>, docs/format.md), written by `render` beside its
 * outputs and in the same write set, so that the maps, the textures and the asset are replaced
 * together or not at all: which assets a render covers, the outputs they need, and their files
 * (named as the outputs are, by --name with {output} the asset's name, by default
 * DIR/<graph>_<name>.gltf with its .bin and PNGs, or .glb; _<frame> before the extension in a
 * sequence). */
#include "render.h"

#include <string.h>

bool gltf_selected(const Options *o, const WgGraph *g, int i)
{
    if (!o->n_outputs) return true;
    const char *name = wg_graph_gltf_info(g, i)->name;
    for (int k = 0; k < o->n_outputs; k++)
        if (!strcmp(o->outputs[k], name)) return true;
    return false;
}

int gltf_request_outputs(const Options *o, const WgGraph *g, WgRequest *r, WgError *err)
{
    for (int i = 0; i < wg_graph_gltf_count(g); i++) {
        if (!o->n_outputs || !gltf_selected(o, g, i)) continue; /* all outputs come anyway */
        const WgGraphGltfInfo *a = wg_graph_gltf_info(g, i);
        for (int k = 0; k < WG_GLTF_SLOT_COUNT; k++)
            if (a->maps[k] && wg_request_add_output(r, a->maps[k], err)) return err->code;
    }
    return WG_OK;
}

bool gltf_needs_output(const Options *o, const WgGraph *g, const char *output)
{
    for (int i = 0; i < wg_graph_gltf_count(g); i++) {
        if (!gltf_selected(o, g, i)) continue;
        const WgGraphGltfInfo *a = wg_graph_gltf_info(g, i);
        for (int k = 0; k < WG_GLTF_SLOT_COUNT; k++)
            if (a->maps[k] && !strcmp(a->maps[k], output)) return true;
    }
    return false;
}

int gltf_stage(const Options *o, const WgGraph *g, GltfImageOf image_of, void *user, int frame,
               WgWriteSet *set, char (*paths)[4096], int *n_paths, WgError *err)
{
    *n_paths = 0;
    for (int i = 0; i < wg_graph_gltf_count(g); i++) {
        if (!gltf_selected(o, g, i)) continue;
        const WgGraphGltfInfo *info = wg_graph_gltf_info(g, i);
        WgGltfAsset a = {.name = info->name,
                         .binary = info->binary,
                         .grid = info->grid,
                         .height_scale = info->height_scale,
                         .repeat = info->repeat};
        for (int k = 0; k < WG_GLTF_SLOT_COUNT; k++) {
            if (!info->maps[k]) continue;
            if (!(a.maps[k] = image_of(user, info->maps[k])))
                return wg_error_set(err, WG_ERR_EVAL, NULL,
                                    "gltf '%s': the output '%s' was not rendered", info->name,
                                    info->maps[k]);
        }
        char *path = paths[(*n_paths)++];
        if (!gltf_file(o, g, i, frame, path, 4096))
            return wg_error_set(err, WG_ERR_USAGE, NULL,
                                "--name '%s' names what this render does not have", o->name);
        int rc = name_folder(path, err);
        if (!rc) rc = wg_gltf_write(set, path, &a, err);
        if (rc) return rc;
    }
    return WG_OK;
}

const WgImage *gltf_image_of_result(void *user, const char *output)
{
    const WgResult *res = user;
    for (int j = 0; j < wg_result_output_count(res); j++)
        if (!strcmp(wg_result_output_name(res, j), output)) return wg_result_output_image(res, j);
    return NULL;
}
