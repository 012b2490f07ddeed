/* SPDX-License-Identifier: MIT */
/* Node plugins for the loader's tests, one shared library per variant (tests/plugins/meson.build
 * compiles this file with a VARIANT_* define): a good plugin in two versions whose node adds a
 * different amount (so a cache that served one's result for the other shows), and one plugin
 * per fault the loader must refuse. */
#include <wetgraph/plugin.h>

typedef struct {
    float amount;
} OffsetParams;

static const WgParamSpec offset_params[] = {
#ifdef VARIANT_BAD_PARAM
    WG_PARAM_FLOAT(OffsetParams, amount, "Added to every sample", 5, 0, 1),
#else
    WG_PARAM_FLOAT(OffsetParams, amount, "Added to every sample", 0, -1, 1),
#endif
    WG_PARAM_END};
static const WgPortSpec gray_in[] = {WG_PORT("source", WG_GRAY), WG_PORT_END};
static const WgPortSpec gray_out[] = {WG_PORT("output", WG_GRAY), WG_PORT_END};

__attribute__((unused)) static int offset_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const OffsetParams *p = ctx->params;
    const WgImage *in = ctx->inputs[0];
    WgImage *out = ctx->outputs[0];
    for (int y = 0; y < ctx->height; y++) {
        const float *s = wg_image_row(in, y);
        float *d = wg_image_row(out, y);
        for (int x = 0; x < ctx->width; x++) d[x] = s[x] + p->amount + (float)PLUGIN_BIAS;
    }
    return WG_OK;
}

#if defined(VARIANT_CLASH_BUILTIN)
#define TYPE_NAME "blur"
#else
#define TYPE_NAME "plugin_offset"
#endif

static const WgNodeType offset_type = {
    .name = TYPE_NAME,
    .summary = "Add a constant to a gray image (plus the plugin's own bias)",
    .category = "adjust",
    .params = offset_params,
    .params_size = sizeof(OffsetParams),
    .inputs = gray_in,
    .outputs = gray_out,
    .flags = WG_NODE_POINT | WG_NODE_SERIAL,
#ifndef VARIANT_NO_EVAL
    .eval = offset_eval,
#endif
};

static const WgNodeType *const types[] = {&offset_type, NULL};

#ifndef VARIANT_NO_ENTRY
WG_PLUGIN_EXPORT const WgPlugin *wetgraph_plugin(void)
{
#ifdef VARIANT_OLD_ABI
    static const WgPlugin plugin = {WG_PLUGIN_ABI - 1 + 100, sizeof(WgNodeType), sizeof(WgParamSpec),
                                    sizeof(WgNodeContext), "offset", PLUGIN_VERSION, types};
#else
    static const WgPlugin plugin = WG_PLUGIN_INIT("offset", PLUGIN_VERSION, types);
#endif
    return &plugin;
}
#else
WG_PLUGIN_EXPORT const WgPlugin *not_the_entry_point(void)
{
    static const WgPlugin plugin = WG_PLUGIN_INIT("offset", PLUGIN_VERSION, types);
    return &plugin;
}
#endif
