/* SPDX-License-Identifier: MIT */
/* `blur`: a plain, exact Gaussian blur with wrap-around edges (the reference the fast blur of a
 * later release is measured against). Weights and sums are double, rounded once to float.
 * Separable; the kernel exp(-d²/2σ²) is sampled at integer offsets out to ceil(6σ) (the dropped
 * tail weighs < 2e-9 of the total), folded modulo the image side so kernels wider than the image
 * wrap correctly, and normalised to sum 1, so a constant image stays exactly constant. When σ ≥ the
 * side, the periodic Gaussian differs from the mean by < 3e-9 relative and the mean is used. σ = 0
 * copies. All channels are blurred, alpha included. Cost: O(σ) per pixel per axis. */
#include "wetgraph/node.h"

#include <math.h>
#include <string.h>

typedef struct {
    float sigma;
} BlurParams;

static const WgParamSpec blur_params[] = {
    WG_PARAM_FLOAT_UI(BlurParams, sigma, "Standard deviation in pixels", 1.0, 0.0, 16384.0, 0, 64),
    WG_PARAM_END,
};
static const WgPortSpec blur_in[] = {WG_PORT("source", WG_ANY), WG_PORT_END};
static const WgPortSpec blur_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

typedef struct {
    int taps; /* kernel covers offsets -radius .. taps-1-radius */
    int radius;
    double *weight; /* taps entries; NULL means "use the mean" */
} Kernel;

static int kernel_build(Kernel *k, double sigma, int n)
{
    k->weight = NULL;
    if (sigma >= n) {
        k->taps = 0;
        return WG_OK;
    }
    int r = (int)ceil(6 * sigma);
    /* fold offsets modulo n: at most n distinct taps, centred */
    int taps = 2 * r + 1 < n ? 2 * r + 1 : n;
    int radius = taps == n ? n / 2 : r;
    double *acc = wg_calloc((size_t)taps, sizeof(double));
    k->weight = wg_malloc(sizeof(double) * (size_t)taps);
    if (!acc || !k->weight) {
        wg_free(acc);
        wg_free(k->weight);
        k->weight = NULL;
        return WG_ERR_NOMEM;
    }
    double sum = 0;
    for (int d = -r; d <= r; d++) {
        double w = exp(-0.5 * d * d / (sigma * sigma));
        int slot = ((d + radius) % n + n) % n; /* offset d lands on tap (d + radius) mod n */
        acc[slot % taps] += w;
        sum += w;
    }
    for (int t = 0; t < taps; t++) k->weight[t] = acc[t] / sum;
    wg_free(acc);
    k->taps = taps;
    k->radius = radius;
    return WG_OK;
}

typedef struct {
    const WgImage *in;
    WgImage *tmp, *out;
    Kernel kx, ky;
} Job;

static void horizontal(void *user, int y0, int y1)
{
    const Job *j = user;
    int w = j->in->width, c = j->in->channels;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d = wg_image_row(j->tmp, y);
        if (!j->kx.weight) {
            double mean[4] = {0};
            for (int x = 0; x < w; x++)
                for (int k = 0; k < c; k++) mean[k] += s[x * c + k];
            for (int x = 0; x < w; x++)
                for (int k = 0; k < c; k++) d[x * c + k] = (float)(mean[k] / w);
            continue;
        }
        for (int x = 0; x < w; x++) {
            double acc[4] = {0, 0, 0, 0};
            int sx = x - j->kx.radius;
            sx = ((sx % w) + w) % w;
            for (int t = 0; t < j->kx.taps; t++) {
                const float *p = s + (size_t)sx * (size_t)c;
                double wt = j->kx.weight[t];
                for (int k = 0; k < c; k++) acc[k] += wt * p[k];
                if (++sx == w) sx = 0;
            }
            for (int k = 0; k < c; k++) d[x * c + k] = (float)acc[k];
        }
    }
}

static void vertical(void *user, int y0, int y1)
{
    const Job *j = user;
    int h = j->in->height, n = j->in->width * j->in->channels;
    for (int y = y0; y < y1; y++) {
        float *d = wg_image_row(j->out, y);
        if (!j->ky.weight) {
            for (int i = 0; i < n; i++) {
                double m = 0;
                for (int yy = 0; yy < h; yy++) m += wg_image_row(j->tmp, yy)[i];
                d[i] = (float)(m / h);
            }
            continue;
        }
        /* accumulate in double, a block of columns at a time */
        for (int i0 = 0; i0 < n; i0 += 256) {
            int len = n - i0 < 256 ? n - i0 : 256;
            double acc[256] = {0};
            int sy = ((y - j->ky.radius) % h + h) % h;
            for (int t = 0; t < j->ky.taps; t++) {
                const float *s = wg_image_row(j->tmp, sy) + i0;
                double wt = j->ky.weight[t];
                for (int i = 0; i < len; i++) acc[i] += wt * s[i];
                if (++sy == h) sy = 0;
            }
            for (int i = 0; i < len; i++) d[i0 + i] = (float)acc[i];
        }
    }
}

static int blur_eval(WgNodeContext *ctx, WgError *err)
{
    const BlurParams *p = ctx->params;
    const WgImage *in = ctx->inputs[0];
    WgImage *out = ctx->outputs[0];
    if (p->sigma == 0) {
        for (int y = 0; y < in->height; y++)
            memcpy(wg_image_row(out, y), wg_image_row(in, y),
                   sizeof(float) * (size_t)in->width * (size_t)in->channels);
        return WG_OK;
    }
    Job j = {in, NULL, out, {0}, {0}};
    int rc = kernel_build(&j.kx, p->sigma, in->width);
    if (!rc) rc = kernel_build(&j.ky, p->sigma, in->height);
    if (!rc && !(j.tmp = wg_image_new(in->width, in->height, in->channels))) rc = WG_ERR_NOMEM;
    if (rc) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!rc) rc = wg_parallel_rows(ctx, in->height, horizontal, &j);
    if (!rc) rc = wg_parallel_rows(ctx, in->height, vertical, &j);
    wg_image_unref(j.tmp);
    wg_free(j.kx.weight);
    wg_free(j.ky.weight);
    return rc;
}

/* The horizontal pass's image, and the two kernels. */
static size_t blur_scratch(const WgNodeContext *ctx)
{
    const BlurParams *p = ctx->params;
    if (p->sigma == 0) return 0;
    int c = ctx->input_channels[0] == 4 ? 4 : 1;
    return wg_image_bytes_for(ctx->width, ctx->height, c) +
           sizeof(double) * 2 * ((size_t)ctx->width + (size_t)ctx->height);
}

const WgNodeType wg_node_blur = {
    .name = "blur",
    .summary = "Exact Gaussian blur with wrap-around edges",
    .category = "filter",
    .doc = "`sigma` is the standard deviation in pixels of the node's output. Separable, "
           "kernel sampled to ±ceil(6σ) (dropped tail < 2e-9), folded modulo the image side "
           "and normalised, so it tiles and keeps constants exact. σ ≥ the image side gives "
           "the mean (error < 3e-9). σ = 0 copies. Cost grows with σ: O(σ) per pixel.",
    .params = blur_params,
    .params_size = sizeof(BlurParams),
    .inputs = blur_in,
    .outputs = blur_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = blur_eval,
    .scratch_bytes = blur_scratch,
};
