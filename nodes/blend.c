/* SPDX-License-Identifier: MIT */
/* `blend`: Substance-style blending of a foreground over a background, with opacity and an
 * optional gray mask. Per channel, with A = foreground, B = background:
 *   copy A | add B+A | subtract B-A | multiply A*B | add_sub B+2A-1 | max | min
 *   switch: A where opacity*mask >= 0.5, else B (a hard switch, no mixing)
 *   divide B/max(A, 2^-16) (never NaN or infinite) | overlay | screen | soft_light (W3C)
 * then result = B + (f(A,B) - B) * opacity * mask (switch excepted), clamped to [0,1] unless
 * clamp="false" (HDR mode). Colour alpha is mixed like `copy`. A gray input mixed with a colour
 * one counts as R = G = B with alpha 1. Computed in double, where no product of floats
 * overflows, and rounded once: finite inputs give finite outputs (saturating at ±FLT_MAX), never
 * an infinity or a NaN made of one. */
#include "wetgraph/node.h"

#include <float.h>
#include <math.h>

enum {
    M_COPY,
    M_ADD,
    M_SUBTRACT,
    M_MULTIPLY,
    M_ADD_SUB,
    M_MAX,
    M_MIN,
    M_SWITCH,
    M_DIVIDE,
    M_OVERLAY,
    M_SCREEN,
    M_SOFT_LIGHT
};
static const char *const mode_values[] = {"copy",   "add",        "subtract", "multiply", "add_sub",
                                          "max",    "min",        "switch",   "divide",   "overlay",
                                          "screen", "soft_light", NULL};

typedef struct {
    int mode;
    float opacity;
    bool clamp;
} BlendParams;

static const WgParamSpec blend_params[] = {
    WG_PARAM_ENUM(BlendParams, mode, "Blend mode", 0, mode_values),
    WG_PARAM_FLOAT(BlendParams, opacity, "Opacity", 1.0, 0.0, 1.0),
    WG_PARAM_BOOL(BlendParams, clamp, "Clamp the result to [0,1] (false: HDR mode)", true),
    WG_PARAM_END,
};
static const WgPortSpec blend_in[] = {
    WG_PORT("foreground", WG_ANY),
    WG_PORT("background", WG_ANY),
    WG_PORT_OPT("mask", WG_GRAY),
    WG_PORT_END,
};
static const WgPortSpec blend_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

static int blend_channels(const WgNodeContext *ctx, int port)
{
    (void)port;
    return ctx->input_channels[0] == 4 || ctx->input_channels[1] == 4 ? 4 : 1;
}

static inline double soft_light(double a, double b)
{
    if (a <= 0.5) return b - (1 - 2 * a) * b * (1 - b);
    double d = b <= 0.25 ? ((16 * b - 12) * b + 4) * b : sqrt(b);
    return b + (2 * a - 1) * (d - b);
}

static inline double blend_one(int mode, double a, double b)
{
    switch (mode) {
    case M_COPY:
        return a;
    case M_ADD:
        return b + a;
    case M_SUBTRACT:
        return b - a;
    case M_MULTIPLY:
        return a * b;
    case M_ADD_SUB:
        return b + 2 * a - 1;
    case M_MAX:
        return a > b ? a : b;
    case M_MIN:
        return a < b ? a : b;
    case M_DIVIDE:
        return b / (a > 0x1p-16 ? a : 0x1p-16);
    case M_OVERLAY:
        return b < 0.5 ? 2 * a * b : 1 - 2 * (1 - a) * (1 - b);
    case M_SCREEN:
        return 1 - (1 - a) * (1 - b);
    case M_SOFT_LIGHT:
        return soft_light(a, b);
    default:
        return a;
    }
}

typedef struct {
    const BlendParams *p;
    const WgImage *fg, *bg, *mask;
    WgImage *out;
} Job;

static inline float channel(const WgImage *img, const float *row, int x, int k)
{
    if (img->channels == 1) return k == 3 ? 1.0f : row[x];
    return row[4 * x + k];
}

static void blend_rows(void *user, int y0, int y1)
{
    const Job *j = user;
    const BlendParams *p = j->p;
    int c = j->out->channels;
    for (int y = y0; y < y1; y++) {
        const float *fr = wg_image_row(j->fg, y), *br = wg_image_row(j->bg, y);
        const float *mr = j->mask ? wg_image_row(j->mask, y) : NULL;
        float *o = wg_image_row(j->out, y);
        for (int x = 0; x < j->out->width; x++) {
            double t = (double)p->opacity * (mr ? mr[x] : 1.0f);
            for (int k = 0; k < c; k++) {
                double a = channel(j->fg, fr, x, k), b = channel(j->bg, br, x, k);
                double v;
                /* (1-t)B + tF rather than B + (F-B)t: exact at t = 0 and t = 1 even when B is
                 * much larger than F (HDR heights) */
                if (p->mode == M_SWITCH)
                    v = t >= 0.5 ? a : b;
                else if (k == 3)
                    v = (1 - t) * b + t * a;
                else
                    v = (1 - t) * b + t * blend_one(p->mode, a, b);
                if (p->clamp) v = v < 0 ? 0 : v > 1 ? 1 : v;
                o[x * c + k] = (float)(v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v);
            }
        }
    }
}

static int blend_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    Job j = {ctx->params, ctx->inputs[0], ctx->inputs[1], ctx->inputs[2], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, blend_rows, &j);
}

const WgNodeType wg_node_blend = {
    .name = "blend",
    .summary = "Blend a foreground over a background (12 modes, opacity, mask)",
    .category = "blend",
    .doc = "Per channel with A = foreground and B = background: copy A; add B+A; subtract B-A; "
           "multiply A·B; add_sub B+2A-1 (A above 0.5 adds, below subtracts); max; min; switch "
           "(A where opacity·mask ≥ 0.5, else B, no mixing); divide B/max(A, 2^-16) (never NaN "
           "or infinite); overlay; screen; soft_light (W3C formula). The result is "
           "B + (f(A,B) − B)·opacity·mask, clamped to [0,1] unless `clamp=\"false\"` (HDR mode, "
           "for heights and other unbounded data). Colour alpha mixes like copy. A gray input "
           "blended with a colour one counts as R = G = B, alpha 1; the output is colour if "
           "either input is.",
    .params = blend_params,
    .params_size = sizeof(BlendParams),
    .inputs = blend_in,
    .outputs = blend_out,
    .flags = WG_NODE_POINT,
    .output_channels = blend_channels,
    .eval = blend_eval,
};
