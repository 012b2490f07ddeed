/* SPDX-License-Identifier: MIT */
/* Neighbourhood filters: `sharpen`, `emboss`, `edge_detect` and `directional_blur`. Every read
 * wraps around the image edges, so each output tiles; all sums are double, rounded once to float;
 * rows are split with wg_parallel_rows and each pixel depends only on its inputs, so any thread
 * count gives the same bits. Lengths (sharpen's `radius`, directional_blur's `length`) follow
 * docs/format.md "Lengths": pixels of a 256-wide image, L · width/256 pixels of the output.
 * `sharpen` is an unsharp mask, source + amount · (source − G), with G a periodic Gaussian of
 * σ = radius · width/256 pixels. `fast` (default) takes G from the blur node's fast path
 * (nodes/gaussian.h: cost nearly independent of σ, within a few 1e-7 of the exact G); `exact` is
 * the reference: a separable kernel exp(−d²/2σ²) sampled out to ceil(6σ)
 * (dropped tail < 2e-9 of the weight), folded modulo the side and normalised; for σ ≥ the side
 * the periodic Gaussian differs from the mean by < 3e-9 relative and the mean is used. Each pass
 * sums weighted differences from the centre value (v + Σ w·(v_i − v)), so a constant stays
 * exactly constant and its sharpening exactly equal to it. Alpha is copied.
 * `emboss` and `edge_detect` use the 3×3 Sobel operator (Sobel & Feldman 1968): Gx = the 1-2-1
 * weighted column to the right minus the one to the left, Gy the row above minus the row below
 * (y towards the top of the image). `emboss` lights the height from `angle` (degrees
 * anticlockwise from +x): 0.5 − intensity · (width/256) · (G/8)·L / 2, clamped to [0, 1], where
 * G/8 is the gradient per length unit as in `normal`'s sobel method, so flat is exactly 0.5 and
 * a relief looks the same at any resolution. `edge_detect` gives intensity · |G|/4 (a sharp unit
 * step reads 1 on the pixels either side), or the signed Gx/4 or Gy/4; a constant gives exactly
 * 0. `directional_blur` averages samples along a segment of `length` centred on each pixel at
 * `angle`: ceil(length_px) samples at the midpoints of equal cells (spacing ≤ 1 pixel), each read
 * with periodic bilinear interpolation (which stays exact for constants: it also sums
 * differences from the centre); `box` weighs them equally, `gaussian` with σ = length/6 (the
 * segment is ±3σ). Non-finite inputs, which only arithmetic makes, give finite outputs (clamped
 * to the float range; NaN differences count as flat in emboss and edge_detect).
 * Speed at 2048², 2 threads (bench/bench_filters, release, medians of 5 to 9 in four runs on a
 * 2-core machine shared with other jobs, so the spread is load, not the code; 1-thread runs
 * under the same load matched the slower figures): `sharpen` exact radius 1 (σ 8 px, 97 taps a
 * pass) 139-418 ms gray, 703-1403 ms colour (its double scratch of 128 MB makes the vertical
 * pass memory-bound), radius 4 (σ 32 px) 642-1282 ms gray; `sharpen` fast 24-31 ms gray at
 * radius 1 and 4 (228 ms colour) where exact took 274 and 1241 ms in the same loaded run; `emboss`
 * 11-20 ms; `edge_detect` 14-26 ms; `directional_blur` length 4 (32 px, 75 merged bilinear taps)
 * 57-113 ms gray (box and gaussian alike), 337-654 ms colour. Inner loops run over straight runs of
 * a row with the wrap split out, so they vectorize.
 */
#include "gaussian.h"
#include "wetgraph/node.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- shared helpers ---------------------------------------------------------------------- */

static inline float to_float(double v)
{
    if (v != v) return 0.0f;
    return (float)(v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v);
}

/* A periodic 1D Gaussian over a side of n: `taps` (offset, weight) pairs, offsets already
 * reduced modulo n into [0, n), or mean = true for σ ≥ n. */
typedef struct {
    int taps;
    bool mean;
    int *offset;
    double *weight;
} Gauss;

static int gauss_build(Gauss *g, double sigma, int n)
{
    memset(g, 0, sizeof *g);
    if (sigma >= n) {
        g->mean = true;
        return WG_OK;
    }
    long r = (long)ceil(6 * sigma);
    int taps = 2 * r + 1 < n ? (int)(2 * r + 1) : n;
    g->offset = wg_malloc(sizeof(int) * (size_t)taps);
    g->weight = wg_calloc((size_t)taps, sizeof(double));
    if (!g->offset || !g->weight) return WG_ERR_NOMEM;
    double sum = 0;
    for (long d = -r; d <= r; d++) {
        double w = exp(-0.5 * (double)d * (double)d / (sigma * sigma));
        /* slot: with no folding, d + r; folded, d mod n */
        int slot = taps == n ? (int)(((d % n) + n) % n) : (int)(d + r);
        g->weight[slot] += w;
        sum += w;
    }
    for (int t = 0; t < taps; t++) {
        g->weight[t] /= sum;
        g->offset[t] = taps == n ? t : (int)((((t - r) % n) + n) % n);
    }
    g->taps = taps;
    return WG_OK;
}

static void gauss_free(Gauss *g)
{
    wg_free(g->offset);
    wg_free(g->weight);
}

/* ---- sharpen ----------------------------------------------------------------------------- */

typedef struct {
    float amount;
    float radius;
    int quality;
} SharpenParams;

enum { QUALITY_FAST, QUALITY_EXACT };
static const char *const quality_values[] = {"fast", "exact", NULL};

static const WgParamSpec sharpen_params[] = {
    WG_PARAM_FLOAT_UI(SharpenParams, amount, "Strength: source + amount · (source − blurred)", 1.0,
                      0.0, 1000.0, 0, 5),
    WG_PARAM_FLOAT_UI(SharpenParams, radius,
                      "Gaussian σ of the blur, a length (pixels of a 256-wide image)", 1.0, 0.0,
                      4096.0, 0, 16),
    WG_PARAM_ENUM(SharpenParams, quality,
                  "fast (the blur node's fast Gaussian) or exact (float64 reference)", QUALITY_FAST,
                  quality_values),
    WG_PARAM_END,
};
static const WgPortSpec any_source_in[] = {WG_PORT("source", WG_ANY), WG_PORT_END};
static const WgPortSpec any_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

typedef struct {
    const WgImage *in;
    WgImage *out;
    double *tmp;     /* the horizontal pass, w·c per row */
    double *colmean; /* σ ≥ height: the column means of tmp, the same for every row */
    Gauss gx, gy;
    double amount;
} SharpenJob;

/* Row by row into the double scratch: first Σ w·(s[x + offset] − s[x]) tap by tap over runs of
 * the row that need no wrapping (so the loops vectorize), then the centre value added. */
static void sharpen_horizontal(void *user, int y0, int y1)
{
    const SharpenJob *j = user;
    int w = j->in->width, c = j->in->channels;
    size_t n = (size_t)w * (size_t)c;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        double *d = j->tmp + (size_t)y * n;
        if (j->gx.mean) {
            for (int k = 0; k < c; k++) {
                double acc = 0, ref = s[k];
                for (int x = 0; x < w; x++) acc += (double)s[x * c + k] - ref;
                double m = ref + acc / w;
                for (int x = 0; x < w; x++) d[x * c + k] = m;
            }
            continue;
        }
        for (size_t i = 0; i < n; i++) d[i] = 0;
        for (int t = 0; t < j->gx.taps; t++) {
            size_t off = (size_t)j->gx.offset[t] * (size_t)c, split = n - off;
            double wt = j->gx.weight[t];
            for (size_t i = 0; i < split; i++) d[i] += wt * ((double)s[i + off] - s[i]);
            for (size_t i = split; i < n; i++) d[i] += wt * ((double)s[i - split] - s[i]);
        }
        for (size_t i = 0; i < n; i++) d[i] += s[i];
    }
}

enum { BLOCK = 256 };

static void sharpen_vertical(void *user, int y0, int y1)
{
    const SharpenJob *j = user;
    int w = j->in->width, h = j->in->height, c = j->in->channels;
    size_t n = (size_t)w * (size_t)c;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *o = wg_image_row(j->out, y);
        const double *mid = j->tmp + (size_t)y * n;
        for (size_t i0 = 0; i0 < n; i0 += BLOCK) {
            size_t len = n - i0 < BLOCK ? n - i0 : BLOCK;
            double acc[BLOCK] = {0};
            if (j->gy.mean) {
                for (size_t i = 0; i < len; i++) acc[i] = j->colmean[i0 + i] - mid[i0 + i];
            } else {
                for (int t = 0; t < j->gy.taps; t++) {
                    int sy = y + j->gy.offset[t];
                    if (sy >= h) sy -= h;
                    const double *r = j->tmp + (size_t)sy * n + i0;
                    double wt = j->gy.weight[t];
                    for (size_t i = 0; i < len; i++) acc[i] += wt * (r[i] - mid[i0 + i]);
                }
            }
            for (size_t i = 0; i < len; i++) {
                double v = s[i0 + i], blurred = mid[i0 + i] + acc[i];
                o[i0 + i] = to_float(v + j->amount * (v - blurred));
            }
        }
        if (c == 4)
            for (int x = 0; x < w; x++) o[x * 4 + 3] = s[x * 4 + 3];
    }
}

static double length_px(double length, int width)
{
    return length * width / 256.0;
}

static int copy_eval(WgNodeContext *ctx)
{
    const WgImage *in = ctx->inputs[0];
    for (int y = 0; y < in->height; y++)
        memcpy(wg_image_row(ctx->outputs[0], y), wg_image_row(in, y),
               sizeof(float) * (size_t)in->width * (size_t)in->channels);
    return WG_OK;
}

/* fast: the output holds the blur; each pixel becomes v + amount · (v − blurred). */
static void sharpen_combine(void *user, int y0, int y1)
{
    const SharpenJob *j = user;
    int w = j->in->width, c = j->in->channels;
    size_t n = (size_t)w * (size_t)c;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *o = wg_image_row(j->out, y);
        for (size_t i = 0; i < n; i++) {
            double v = s[i];
            o[i] = to_float(v + j->amount * (v - (double)o[i]));
        }
        if (c == 4)
            for (int x = 0; x < w; x++) o[x * 4 + 3] = s[x * 4 + 3];
    }
}

static int sharpen_eval(WgNodeContext *ctx, WgError *err)
{
    const SharpenParams *p = ctx->params;
    const WgImage *in = ctx->inputs[0];
    double sigma = length_px(p->radius, ctx->width);
    if (sigma == 0 || p->amount == 0) return copy_eval(ctx);
    if (p->quality == QUALITY_FAST) {
        SharpenJob j = {in, ctx->outputs[0], NULL, NULL, {0}, {0}, p->amount};
        int rc = wg__gaussian_fast(ctx, in, ctx->outputs[0], sigma, err);
        return rc ? rc : wg_parallel_rows(ctx, in->height, sharpen_combine, &j);
    }
    SharpenJob j = {in, ctx->outputs[0], NULL, NULL, {0}, {0}, p->amount};
    int rc = gauss_build(&j.gx, sigma, in->width);
    if (!rc) rc = gauss_build(&j.gy, sigma, in->height);
    size_t tmp_bytes =
        sizeof(double) * (size_t)in->width * (size_t)in->height * (size_t)in->channels;
    if (!rc && !(j.tmp = wg_scratch_alloc(ctx, tmp_bytes))) rc = WG_ERR_NOMEM;
    if (rc) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!rc) rc = wg_parallel_rows(ctx, in->height, sharpen_horizontal, &j);
    if (!rc && j.gy.mean) {
        /* row 0 plus the mean difference from it, so a constant column stays exact */
        size_t n = (size_t)in->width * (size_t)in->channels;
        if (!(j.colmean = wg_calloc(n, sizeof(double))))
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        for (int y = 1; !rc && y < in->height; y++)
            for (size_t i = 0; i < n; i++) j.colmean[i] += j.tmp[(size_t)y * n + i] - j.tmp[i];
        for (size_t i = 0; !rc && i < n; i++) j.colmean[i] = j.tmp[i] + j.colmean[i] / in->height;
    }
    if (!rc) rc = wg_parallel_rows(ctx, in->height, sharpen_vertical, &j);
    wg_free(j.colmean);
    wg_scratch_free(ctx, j.tmp, tmp_bytes);
    gauss_free(&j.gx);
    gauss_free(&j.gy);
    return rc;
}

/* exact: the double horizontal pass and both kernels; fast: what the fast Gaussian needs. */
static size_t sharpen_scratch(const WgNodeContext *ctx)
{
    const SharpenParams *p = ctx->params;
    double sigma = length_px(p->radius, ctx->width);
    if (sigma == 0 || p->amount == 0) return 0;
    if (p->quality == QUALITY_FAST)
        return wg__gaussian_fast_scratch(ctx->width, ctx->height, sigma);
    int c = ctx->input_channels[0] == 4 ? 4 : 1;
    return sizeof(double) * (size_t)ctx->width * (size_t)ctx->height * (size_t)c +
           (sizeof(double) + sizeof(int)) * ((size_t)ctx->width + (size_t)ctx->height);
}

const WgNodeType wg_node_sharpen = {
    .name = "sharpen",
    .summary = "Unsharp mask: source + amount · (source − Gaussian blur)",
    .category = "filter",
    .doc = "`radius` is the blur's σ as a length (pixels of a 256-wide image, docs/format.md), "
           "so σ = radius · width/256 pixels. Reads wrap, so the output tiles. `fast` (default) "
           "blurs with the `blur` node's fast periodic Gaussian (cost nearly independent of σ; "
           "the blur is within a few 1e-7 of the largest |value| of the exact one, so the result "
           "is within (1 + amount) times that, and a constant stays within amount · 1e-6 "
           "relative). `exact`: separable periodic Gaussian in double, sampled to ±ceil(6σ) "
           "(tail < 2e-9), folded modulo the side and normalised; σ ≥ the side uses the mean "
           "(< 3e-9 relative); a constant image is returned exactly; cost O(σ) per pixel. Alpha "
           "is copied; results are clamped to the float range.",
    .params = sharpen_params,
    .params_size = sizeof(SharpenParams),
    .inputs = any_source_in,
    .outputs = any_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = sharpen_eval,
    .scratch_bytes = sharpen_scratch,
};

/* ---- Sobel: emboss and edge_detect -------------------------------------------------------- */

typedef struct {
    float angle;
    float intensity;
} EmbossParams;

typedef struct {
    float intensity;
    int mode;
} EdgeParams;

enum { EDGE_MAGNITUDE, EDGE_X, EDGE_Y };
static const char *const edge_modes[] = {"magnitude", "x", "y", NULL};

static const WgParamSpec emboss_params[] = {
    WG_PARAM_FLOAT_UI(EmbossParams, angle, "Light direction, degrees anticlockwise from +x", 135.0,
                      -3600.0, 3600.0, 0, 360),
    WG_PARAM_FLOAT_UI(EmbossParams, intensity,
                      "Height scale: length units (pixels of a 256-wide image) a height of 1 "
                      "stands for",
                      1.0, 0.0, 1e6, 0, 64),
    WG_PARAM_END,
};
static const WgParamSpec edge_params[] = {
    WG_PARAM_FLOAT_UI(EdgeParams, intensity, "Gain: a sharp unit step reads `intensity`", 1.0, 0.0,
                      1e6, 0, 8),
    WG_PARAM_ENUM(EdgeParams, mode, "magnitude |G|, or the signed x or y (up) component", 0,
                  edge_modes),
    WG_PARAM_END,
};
static const WgPortSpec height_in[] = {WG_PORT("height", WG_GRAY), WG_PORT_END};
static const WgPortSpec gray_source_in[] = {WG_PORT("source", WG_GRAY), WG_PORT_END};
static const WgPortSpec relief_out[] = {WG_PORT("relief", WG_GRAY), WG_PORT_END};
static const WgPortSpec edges_out[] = {WG_PORT("edges", WG_GRAY), WG_PORT_END};

typedef struct {
    const WgImage *in;
    WgImage *out;
    int mode;
    double a, b; /* emboss: out = 0.5 − (a·Gx + b·Gy); edge: the gain on G */
    bool emboss;
} SobelJob;

static void sobel_rows(void *user, int y0, int y1)
{
    const SobelJob *j = user;
    int w = j->in->width, h = j->in->height;
    for (int y = y0; y < y1; y++) {
        const float *u = wg_image_row(j->in, y == 0 ? h - 1 : y - 1);
        const float *m = wg_image_row(j->in, y);
        const float *d = wg_image_row(j->in, y == h - 1 ? 0 : y + 1);
        float *o = wg_image_row(j->out, y);
        for (int x = 0; x < w; x++) {
            int l = x == 0 ? w - 1 : x - 1, r = x == w - 1 ? 0 : x + 1;
            double gx = ((double)u[r] + 2.0 * m[r] + d[r]) - ((double)u[l] + 2.0 * m[l] + d[l]);
            double gy = ((double)u[l] + 2.0 * u[x] + u[r]) - ((double)d[l] + 2.0 * d[x] + d[r]);
            if (gx != gx) gx = 0;
            if (gy != gy) gy = 0;
            if (j->emboss) {
                double v = 0.5 - (j->a * gx + j->b * gy);
                o[x] = v != v ? 0.5f : (float)(v < 0 ? 0 : v > 1 ? 1 : v);
            } else {
                double v = j->mode == EDGE_X   ? gx
                           : j->mode == EDGE_Y ? gy
                                               : sqrt(gx * gx + gy * gy);
                o[x] = to_float(j->a * v);
            }
        }
    }
}

/* cos and sin of an angle in degrees, exact at multiples of 90°. */
static void direction(double degrees, double *c, double *s)
{
    double a = fmod(degrees, 360.0);
    if (a < 0) a += 360;
    if (a == 0 || a == 90 || a == 180 || a == 270) {
        *c = a == 0 ? 1 : a == 180 ? -1 : 0;
        *s = a == 90 ? 1 : a == 270 ? -1 : 0;
        return;
    }
    *c = cos(a * (M_PI / 180));
    *s = sin(a * (M_PI / 180));
}

static int emboss_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const EmbossParams *p = ctx->params;
    double c, s;
    direction(p->angle, &c, &s);
    /* gradient per length unit: intensity · (width/256) · G/8, halved into gray */
    double k = (double)p->intensity * (ctx->width / 256.0) / 8 / 2;
    SobelJob j = {ctx->inputs[0], ctx->outputs[0], 0, k * c, k * s, true};
    return wg_parallel_rows(ctx, ctx->height, sobel_rows, &j);
}

static int edge_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const EdgeParams *p = ctx->params;
    SobelJob j = {ctx->inputs[0], ctx->outputs[0], p->mode, p->intensity / 4.0, 0, false};
    return wg_parallel_rows(ctx, ctx->height, sobel_rows, &j);
}

const WgNodeType wg_node_emboss = {
    .name = "emboss",
    .summary = "Directional relief of a height field: 0.5 flat, lit from `angle`",
    .category = "filter",
    .doc = "0.5 − intensity · (width/256) · (G·L)/16, clamped to [0, 1]: G is the 3×3 Sobel "
           "gradient (y towards the top), G/8 the gradient per pixel, scaled to per length unit "
           "as in `normal`, and L = (cos angle, sin angle) the light direction (degrees "
           "anticlockwise from +x). Faces turned to the light are brighter. Flat input is "
           "exactly 0.5; reads wrap, so the output tiles.",
    .params = emboss_params,
    .params_size = sizeof(EmbossParams),
    .inputs = height_in,
    .outputs = relief_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = emboss_eval,
};

const WgNodeType wg_node_edge_detect = {
    .name = "edge_detect",
    .summary = "Sobel edge strength: gradient magnitude or a signed component",
    .category = "filter",
    .doc = "`magnitude`: intensity · |G|/4 with G the 3×3 Sobel gradient, so a sharp unit step "
           "reads `intensity` on the pixels either side; `x`, `y`: the signed components "
           "intensity · Gx/4 (rising to the right) and Gy/4 (rising towards the top). Per pixel "
           "of the output: edges stay one pixel wide at any resolution. A constant gives "
           "exactly 0; reads wrap, so the output tiles; results are clamped to the float range.",
    .params = edge_params,
    .params_size = sizeof(EdgeParams),
    .inputs = gray_source_in,
    .outputs = edges_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = edge_eval,
};

/* ---- directional_blur -------------------------------------------------------------------- */

typedef struct {
    float angle;
    float length;
    int kernel;
} DirBlurParams;

enum { KERNEL_BOX, KERNEL_GAUSSIAN };
static const char *const kernel_values[] = {"box", "gaussian", NULL};

static const WgParamSpec dirblur_params[] = {
    WG_PARAM_FLOAT_UI(DirBlurParams, angle, "Direction, degrees anticlockwise from +x", 0.0,
                      -3600.0, 3600.0, 0, 360),
    WG_PARAM_FLOAT_UI(DirBlurParams, length,
                      "Extent of the streak, a length (pixels of a 256-wide image)", 4.0, 0.0,
                      1024.0, 0, 64),
    WG_PARAM_ENUM(DirBlurParams, kernel, "box (equal weights) or gaussian (σ = length/6)", 0,
                  kernel_values),
    WG_PARAM_END,
};

/* One bilinear tap: source offset (dx, dy), already reduced into [0, w) × [0, h). */
typedef struct {
    int dx, dy, order;
    double weight;
} Tap;

typedef struct {
    const WgImage *in;
    WgImage *out;
    const Tap *taps;
    int n_taps;
} DirJob;

static void dirblur_rows(void *user, int y0, int y1)
{
    const DirJob *j = user;
    int w = j->in->width, h = j->in->height, c = j->in->channels;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *o = wg_image_row(j->out, y);
        for (int x0 = 0; x0 < w; x0 += BLOCK) {
            int n = w - x0 < BLOCK ? w - x0 : BLOCK;
            double acc[BLOCK * 4] = {0};
            const float *ctr = s + (size_t)x0 * c;
            for (int t = 0; t < j->n_taps; t++) {
                const Tap *tp = &j->taps[t];
                int sy = y + tp->dy;
                if (sy >= h) sy -= h;
                const float *r = wg_image_row(j->in, sy);
                double wt = tp->weight;
                int sx = x0 + tp->dx;
                if (sx >= w) sx -= w;
                /* n ≤ w pixels from sx wrap at most once: two straight runs */
                int first = w - sx < n ? w - sx : n;
                const float *r1 = r + (size_t)sx * c;
                for (int i = 0; i < first * c; i++) acc[i] += wt * ((double)r1[i] - ctr[i]);
                for (int i = first * c; i < n * c; i++)
                    acc[i] += wt * ((double)r[i - first * c] - ctr[i]);
            }
            for (int i = 0; i < n * c; i++) o[(size_t)x0 * c + i] = to_float(ctr[i] + acc[i]);
        }
    }
}

/* Taps by row, then column, then the order they were made in (so the merge below adds equal
 * offsets in a fixed order). */
static int tap_cmp(const void *pa, const void *pb)
{
    const Tap *a = pa, *b = pb;
    if (a->dy != b->dy) return a->dy < b->dy ? -1 : 1;
    if (a->dx != b->dx) return a->dx < b->dx ? -1 : 1;
    return (a->order > b->order) - (a->order < b->order);
}

static int dirblur_eval(WgNodeContext *ctx, WgError *err)
{
    const DirBlurParams *p = ctx->params;
    int w = ctx->width, h = ctx->height;
    double len = length_px(p->length, w);
    int n = (int)ceil(len);
    if (n <= 1) return copy_eval(ctx);
    double c, s;
    direction(p->angle, &c, &s);
    Tap *taps = wg_malloc(sizeof(Tap) * 4 * (size_t)n);
    if (!taps) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    double sigma = len / 6, sum = 0;
    int count = 0;
    for (int i = 0; i < n; i++) {
        double t = -len / 2 + (i + 0.5) * len / n;
        double wt = p->kernel == KERNEL_GAUSSIAN ? exp(-0.5 * t * t / (sigma * sigma)) : 1.0;
        sum += wt;
        /* image y grows downwards; the angle's y grows upwards */
        double ox = t * c, oy = -t * s;
        double fx0 = floor(ox), fy0 = floor(oy);
        double fx = ox - fx0, fy = oy - fy0;
        long ix = (long)fx0, iy = (long)fy0;
        const double corner[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
        for (int q = 0; q < 4; q++) {
            if (corner[q] == 0) continue;
            long dx = ix + (q & 1), dy = iy + (q >> 1);
            taps[count].dx = (int)(((dx % w) + w) % w);
            taps[count].dy = (int)(((dy % h) + h) % h);
            taps[count].order = count;
            taps[count].weight = wt * corner[q];
            count++;
        }
    }
    /* neighbouring samples share bilinear corners: one tap per distinct offset */
    qsort(taps, (size_t)count, sizeof *taps, tap_cmp);
    int merged = 0;
    for (int t = 0; t < count; t++) {
        if (merged && taps[merged - 1].dx == taps[t].dx && taps[merged - 1].dy == taps[t].dy)
            taps[merged - 1].weight += taps[t].weight;
        else
            taps[merged++] = taps[t];
    }
    count = merged;
    for (int t = 0; t < count; t++) taps[t].weight /= sum;
    DirJob j = {ctx->inputs[0], ctx->outputs[0], taps, count};
    int rc = wg_parallel_rows(ctx, h, dirblur_rows, &j);
    wg_free(taps);
    return rc;
}

/* The tap table: four bilinear corners per sample. */
static size_t dirblur_scratch(const WgNodeContext *ctx)
{
    const DirBlurParams *p = ctx->params;
    double n = ceil(length_px(p->length, ctx->width));
    return n <= 1 ? 0 : sizeof(Tap) * 4 * (size_t)n;
}

const WgNodeType wg_node_directional_blur = {
    .name = "directional_blur",
    .summary = "Blur along one direction (motion streak), box or Gaussian",
    .category = "filter",
    .doc = "Averages the source along a segment of `length` (pixels of a 256-wide image, "
           "docs/format.md) centred on each pixel, at `angle` degrees anticlockwise from +x: "
           "ceil(length·width/256) samples at the midpoints of equal cells, each read with "
           "periodic bilinear interpolation, weighted equally (`box`) or by a Gaussian with "
           "σ = length/6 (`gaussian`), normalised. A streak of 1 pixel or less copies. Reads "
           "wrap, so the output tiles; constants stay exact; all channels are blurred. Cost "
           "O(length in pixels) per pixel.",
    .params = dirblur_params,
    .params_size = sizeof(DirBlurParams),
    .inputs = any_source_in,
    .outputs = any_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = dirblur_eval,
    .scratch_bytes = dirblur_scratch,
};
