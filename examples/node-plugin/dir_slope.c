/* SPDX-License-Identifier: MIT */
/* `dir_slope`: the slope of a height field along one direction, as a wetgraph plugin.
 *
 * The height is differentiated along the direction `angle` (degrees anticlockwise from +x, y up
 * the image) by a central difference over a step of `length` length units (a length unit is a
 * pixel of a 256-wide image, so the step covers length x width / 256 pixels and the node gives
 * the same picture at any resolution):
 *
 *     slope(p) = intensity * (h(p + s d) - h(p - s d)) / (2 length)
 *
 * with s the step in pixels, d the unit direction and h sampled bilinearly with wrap-around, so
 * the output tiles. `intensity` is how many length units a height of 1 stands for (as in the
 * built-in `normal` and `slope` nodes): the output is then a true slope (rise over run), e.g.
 * 1 for a 45-degree face rising along `angle`. A longer step measures a smoother slope. */
#include <math.h>

#define PI 3.14159265358979323846
#include <wetgraph/plugin.h>

typedef struct {
    float angle;
    float length;
    float intensity;
} DirSlopeParams;

static const WgParamSpec dir_slope_params[] = {
    WG_PARAM_FLOAT_UI(DirSlopeParams, angle, "Direction, degrees anticlockwise from +x", 0, -3600,
                      3600, -180, 180),
    WG_PARAM_FLOAT_UI(DirSlopeParams, length,
                      "Half the difference step, a length (pixels of a 256-wide image)", 1,
                      0.001, 4096, 0.25, 32),
    WG_PARAM_FLOAT_UI(DirSlopeParams, intensity,
                      "Length units (pixels of a 256-wide image) that a height of 1 stands for",
                      1, 0, 1e6, 0, 64),
    WG_PARAM_END};
static const WgPortSpec dir_slope_in[] = {WG_PORT("height", WG_GRAY), WG_PORT_END};
static const WgPortSpec dir_slope_out[] = {WG_PORT("slope", WG_GRAY), WG_PORT_END};

typedef struct {
    const WgNodeContext *ctx;
    double sx, sy;  /* the step s d in pixels, y down the image */
    double scale;   /* intensity / (2 length) */
} Job;

/* h at (x, y) in pixels (centres at integers), bilinear, wrapping */
static double sample(const WgImage *h, double x, double y)
{
    double fx = floor(x), fy = floor(y);
    double tx = x - fx, ty = y - fy;
    long w = h->width, hh = h->height;
    long x0 = ((long)fx % w + w) % w, y0 = ((long)fy % hh + hh) % hh;
    long x1 = (x0 + 1) % w, y1 = (y0 + 1) % hh;
    const float *r0 = wg_image_row(h, (int)y0), *r1 = wg_image_row(h, (int)y1);
    double top = r0[x0] + (r0[x1] - (double)r0[x0]) * tx;
    double bottom = r1[x0] + (r1[x1] - (double)r1[x0]) * tx;
    return top + (bottom - top) * ty;
}

static void rows(void *user, int y0, int y1)
{
    const Job *j = user;
    const WgImage *h = j->ctx->inputs[0];
    for (int y = y0; y < y1; y++) {
        float *out = wg_image_row(j->ctx->outputs[0], y);
        for (int x = 0; x < j->ctx->width; x++) {
            double ahead = sample(h, x + j->sx, y + j->sy);
            double behind = sample(h, x - j->sx, y - j->sy);
            double v = j->scale * (ahead - behind);
            /* non-finite heights give 0 (flat), as the built-in slope counts NaN */
            out[x] = isfinite(v) ? (float)v : 0.0f;
        }
    }
}

static int dir_slope_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const DirSlopeParams *p = ctx->params;
    double step = p->length * ctx->width / 256.0, a = p->angle * PI / 180.0;
    Job j = {ctx, step * cos(a), -step * sin(a), p->intensity / (2.0 * p->length)};
    return wg_parallel_rows(ctx, ctx->height, rows, &j);
}

static const WgNodeType dir_slope = {
    .name = "dir_slope",
    .summary = "Slope of a height field along one direction, over a step of a given length",
    .category = "filter",
    .doc = "The central difference of `height` along `angle` over ±`length` (a length: pixels of "
           "a 256-wide image), times `intensity` / (2 `length`): rise over run, resolution "
           "independent, sampled bilinearly with wrap-around, so the output tiles.",
    .params = dir_slope_params,
    .params_size = sizeof(DirSlopeParams),
    .inputs = dir_slope_in,
    .outputs = dir_slope_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = dir_slope_eval,
};

static const WgNodeType *const types[] = {&dir_slope, NULL};

WG_PLUGIN_EXPORT const WgPlugin *wetgraph_plugin(void)
{
    static const WgPlugin plugin = WG_PLUGIN_INIT("dir_slope", "1.0.0", types);
    return &plugin;
}
