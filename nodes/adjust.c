/* SPDX-License-Identifier: MIT */
/* Value adjustments: `levels`, `invert`, `grayscale`. Point operations on the colour channels;
 * alpha passes through unchanged. */
#include "wetgraph/node.h"

#include <float.h>
#include <math.h>

typedef struct {
    const void *params;
    const WgImage *in;
    WgImage *out;
} Job;

/* Run `fn` on every value of every colour channel (alpha copied). */
#define POINT_LOOP(job, y0, y1, EXPR)                                                              \
    do {                                                                                           \
        int c_ = (job)->in->channels;                                                              \
        for (int y = (y0); y < (y1); y++) {                                                        \
            const float *s_ = wg_image_row((job)->in, y);                                          \
            float *d_ = wg_image_row((job)->out, y);                                               \
            for (int i_ = 0; i_ < (job)->in->width * c_; i_++) {                                   \
                float x = s_[i_];                                                                  \
                d_[i_] = (c_ == 4 && (i_ & 3) == 3) ? x : (EXPR);                                  \
            }                                                                                      \
        }                                                                                          \
    } while (0)

static const WgPortSpec source_in[] = {WG_PORT("source", WG_ANY), WG_PORT_END};
static const WgPortSpec output_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

/* ---- levels ------------------------------------------------------------------------------ */

typedef struct {
    float in_low, in_mid, in_high, out_low, out_high;
} LevelsParams;

static const WgParamSpec levels_params[] = {
    WG_PARAM_FLOAT_UI(LevelsParams, in_low, "Input black point", 0.0, -1e6, 1e6, 0, 1),
    WG_PARAM_FLOAT(LevelsParams, in_mid, "Input mid-tone (0.5 = linear)", 0.5, 0.001, 0.999),
    WG_PARAM_FLOAT_UI(LevelsParams, in_high, "Input white point", 1.0, -1e6, 1e6, 0, 1),
    WG_PARAM_FLOAT_UI(LevelsParams, out_low, "Output black", 0.0, -1e6, 1e6, 0, 1),
    WG_PARAM_FLOAT_UI(LevelsParams, out_high, "Output white", 1.0, -1e6, 1e6, 0, 1),
    WG_PARAM_END,
};

static float levels_one(const LevelsParams *p, float gamma, float x)
{
    float t;
    if (p->in_high == p->in_low)
        t = x >= p->in_low ? 1.0f : 0.0f;
    else
        t = (x - p->in_low) / (p->in_high - p->in_low);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    if (gamma != 1.0f) t = powf(t, gamma);
    return p->out_low + t * (p->out_high - p->out_low);
}

typedef struct {
    Job job;
    float gamma;
} LevelsJob;

/* levels_one without the power: the same operations, in a loop the compiler vectorises */
static inline float levels_linear(float x, float lo, float scale_div, float out_low, float range)
{
    float t = (x - lo) / scale_div;
    float u = t > 1 ? 1.0f : t; /* two selects (NaN stays NaN): no branch */
    t = t < 0 ? 0.0f : u;
    return out_low + t * range;
}

static void levels_rows(void *user, int y0, int y1)
{
    const LevelsJob *lj = user;
    const LevelsParams *p = lj->job.params;
    float g = lj->gamma;
    if (g == 1.0f && p->in_high != p->in_low) {
        float lo = p->in_low, div = p->in_high - p->in_low, ol = p->out_low,
              range = p->out_high - p->out_low;
        const WgImage *in = lj->job.in;
        int c = in->channels, n = in->width * c;
        for (int y = y0; y < y1; y++) {
            const float *src = wg_image_row(in, y);
            float *dst = wg_image_row(lj->job.out, y);
            /* every value computed, alpha put back: a loop without branches vectorises */
            for (int i = 0; i < n; i++) dst[i] = levels_linear(src[i], lo, div, ol, range);
            if (c == 4)
                for (int i = 3; i < n; i += 4) dst[i] = src[i];
        }
    } else {
        POINT_LOOP(&lj->job, y0, y1, levels_one(p, g, x));
    }
}

static int levels_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const LevelsParams *p = ctx->params;
    /* the mid-tone maps to 0.5: t^g with mid^g = 0.5 */
    float gamma = p->in_mid == 0.5f ? 1.0f : (float)(log(0.5) / log((double)p->in_mid));
    LevelsJob j = {{ctx->params, ctx->inputs[0], ctx->outputs[0]}, gamma};
    return wg_parallel_rows(ctx, j.job.out->height, levels_rows, &j);
}

const WgNodeType wg_node_levels = {
    .name = "levels",
    .summary = "Remap values: input black/mid/white points to output black/white",
    .category = "adjust",
    .doc = "t = clamp((x − in_low)/(in_high − in_low), 0, 1), then t^γ with γ chosen so that "
           "`in_mid` (a position between the input points, 0.5 = no change) maps to 0.5, then "
           "out_low + t·(out_high − out_low). in_low > in_high inverts; in_low = in_high is a "
           "hard step at that value. Alpha is unchanged.",
    .params = levels_params,
    .params_size = sizeof(LevelsParams),
    .inputs = source_in,
    .outputs = output_out,
    .flags = WG_NODE_POINT,
    .eval = levels_eval,
};

/* ---- invert ------------------------------------------------------------------------------ */

static void invert_rows(void *user, int y0, int y1)
{
    const Job *j = user;
    POINT_LOOP(j, y0, y1, 1.0f - x);
}

static int invert_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    Job j = {NULL, ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, invert_rows, &j);
}

const WgNodeType wg_node_invert = {
    .name = "invert",
    .summary = "1 − x on every colour channel",
    .category = "adjust",
    .doc = "Alpha is unchanged.",
    .inputs = source_in,
    .outputs = output_out,
    .flags = WG_NODE_POINT,
    .eval = invert_eval,
};

/* ---- grayscale --------------------------------------------------------------------------- */

typedef struct {
    float weights[4];
} GrayscaleParams;

static const WgParamSpec grayscale_params[] = {
    WG_PARAM_COLOR(GrayscaleParams, weights, "Channel weights R G B (A ignored)",
                   "0.2126 0.7152 0.0722 0"),
    WG_PARAM_END,
};
static const WgPortSpec grayscale_in[] = {WG_PORT("source", WG_COLOR), WG_PORT_END};
static const WgPortSpec grayscale_out[] = {WG_PORT("output", WG_GRAY), WG_PORT_END};

static void grayscale_rows(void *user, int y0, int y1)
{
    const Job *j = user;
    const float *w = ((const GrayscaleParams *)j->params)->weights;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d = wg_image_row(j->out, y);
        for (int x = 0; x < j->out->width; x++) {
            /* in double, where products of floats cannot overflow; saturated to the float range */
            double v =
                (double)w[0] * s[4 * x] + (double)w[1] * s[4 * x + 1] + (double)w[2] * s[4 * x + 2];
            d[x] = (float)(v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v);
        }
    }
}

static int grayscale_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    Job j = {ctx->params, ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, grayscale_rows, &j);
}

const WgNodeType wg_node_grayscale = {
    .name = "grayscale",
    .summary = "Colour to gray as a weighted sum of R, G, B",
    .category = "adjust",
    .doc = "Default weights are Rec.709 luminance for linear RGB (0.2126, 0.7152, 0.0722). "
           "Alpha is ignored. Weights are not normalised, so `weights=\"1 0 0\"` extracts red.",
    .params = grayscale_params,
    .params_size = sizeof(GrayscaleParams),
    .inputs = grayscale_in,
    .outputs = grayscale_out,
    .flags = WG_NODE_POINT,
    .eval = grayscale_eval,
};
