/* SPDX-License-Identifier: MIT */
/* `normal` and `slope`: a tangent-space normal map and a steepness map from a height field.
 * Both take the gradient of the height, measured per unit of texture length: a height value of 1
 * stands for `intensity` length units, and a length unit is one pixel of a 256-pixel-wide image
 * (docs/format.md, "Lengths"), i.e. width/256 pixels of the output in both directions. With
 * pixel differences dh/dx, dh/dy the surface gradient is g = intensity · (width/256) · dh/dpixel,
 * so one height map gives the same normals at 1024² and 4096² up to the finite-difference error.
 * `central` differences: dh/dx = (h[x+1] − h[x−1]) / 2 (error O(step²) on smooth
 * input); `sobel`: the same difference of the 1-2-1 column sums, over 8 (a smoothed central
 * difference). Reads wrap around the edges, so the output tiles; a side of 1 or 2 pixels has a
 * zero gradient along it. The normal is (−gx, −gy, 1)/√(1 + |g|²) with x to the right and y
 * towards the top of the image (OpenGL, green up; DirectX flips the green channel), encoded
 * n·0.5 + 0.5 with alpha 1. The slope is atan|g| / (π/2): 0 flat, 1 vertical, the surface's
 * angle from horizontal as a fraction of 90°. Everything is computed in double from the float
 * heights and rounded once: each channel is within 2^-25 (3e-8) of the exact encoding of the
 * exact finite difference, a flat input gives exactly (0.5, 0.5, 1) and slope 0, and the
 * encoding is symmetric around 0.5 (negative components are stored as 1 − e with e the rounded
 * positive one), so DirectX green is exactly 1 − OpenGL green. Finite heights never overflow the
 * double maths (|g| < 1e49); non-finite heights, which only arithmetic can produce, give finite
 * output: an infinite difference counts as vertical, NaN as flat.
 * Speed at 2048², 2 threads (bench/bench_normal, release, AVX2 clone, median of 15, on a shared
 * 2-core machine): `normal` 20 ms central, 22 ms sobel (37 / 42 ms on 1 thread); `slope` 15 ms
 * central, 16 ms sobel. One memcpy of the 64 MB colour output takes 8-10 ms into a buffer
 * written before and 33 ms into fresh pages; of the 16 MB gray image 1.2 ms warm, 6.5 ms fresh.
 * So `normal` is 2-2.6× a warm memcpy of its output (and faster than a first-touch one, which a
 * newly allocated output also pays); `slope` is 2.3× a first-touch memcpy of its output but 13×
 * a warm one when it used libm's atan; the vectorised atan below halved its arithmetic, and what
 * remains is mostly the first touch of a fresh output. Work is split over rows with
 * wg_parallel_rows; each pixel depends only on its neighbours, so any thread count gives the
 * same bits.
 */
#include "wetgraph/node.h"
#include "hot.h"

#include <math.h>
#include <stdbool.h>

typedef struct {
    float intensity;
    int format;
    int method;
} NormalParams;

typedef struct {
    float intensity;
    int method;
} SlopeParams;

enum { FORMAT_OPENGL, FORMAT_DIRECTX };
enum { METHOD_CENTRAL, METHOD_SOBEL };

static const char *const format_values[] = {"opengl", "directx", NULL};
static const char *const method_values[] = {"central", "sobel", NULL};

#define INTENSITY_LABEL                                                                            \
    "Height scale: length units (pixels of a 256-wide image) that a height of 1 stands for"

static const WgParamSpec normal_params[] = {
    WG_PARAM_FLOAT_UI(NormalParams, intensity, INTENSITY_LABEL, 1.0, 0.0, 1e6, 0, 64),
    WG_PARAM_ENUM(NormalParams, format, "opengl (green up) or directx (green down)", 0,
                  format_values),
    WG_PARAM_ENUM(NormalParams, method, "Finite differences: central or sobel", 0, method_values),
    WG_PARAM_END,
};
static const WgParamSpec slope_params[] = {
    WG_PARAM_FLOAT_UI(SlopeParams, intensity, INTENSITY_LABEL, 1.0, 0.0, 1e6, 0, 64),
    WG_PARAM_ENUM(SlopeParams, method, "Finite differences: central or sobel", 0, method_values),
    WG_PARAM_END,
};
static const WgPortSpec height_in[] = {WG_PORT("height", WG_GRAY), WG_PORT_END};
static const WgPortSpec normal_out[] = {WG_PORT("normal", WG_COLOR), WG_PORT_END};
static const WgPortSpec slope_out[] = {WG_PORT("slope", WG_GRAY), WG_PORT_END};

/* Pixels per block: a block's gradient and its wrapped source rows live on the stack. */
enum { BLOCK = 256 };

typedef struct {
    const WgImage *height;
    WgImage *out;
    int method;
    double scale; /* intensity · (width/256) / the difference's divisor */
    double green; /* +1 OpenGL (gy points down, so the up component is +gy), −1 DirectX */
} Job;

/* Pixels [x0 − 1, x0 + n] of a row of width w, wrapped, into dst[0 .. n+1]. */
static void load_wrapped(const float *row, int w, int x0, int n, float *dst)
{
    dst[0] = row[x0 == 0 ? w - 1 : x0 - 1];
    for (int i = 0; i < n; i++) dst[i + 1] = row[x0 + i];
    dst[n + 1] = row[x0 + n == w ? 0 : x0 + n];
}

/* The surface gradient (gx to the right, gy downwards, in height per length unit) of pixels
 * [x0, x0+n) of row y, into gx[0..n) and gy[0..n). Neighbours wrap around the edges. Returns
 * whether every component is at most 1e150 in magnitude (always so for finite heights). */
HOT static bool gradient(const Job *j, int y, int x0, int n, double *gx, double *gy)
{
    const WgImage *img = j->height;
    int w = img->width, h = img->height;
    float u[BLOCK + 2], m[BLOCK + 2], d[BLOCK + 2];
    load_wrapped(wg_image_row(img, y == 0 ? h - 1 : y - 1), w, x0, n, u);
    load_wrapped(wg_image_row(img, y), w, x0, n, m);
    load_wrapped(wg_image_row(img, y == h - 1 ? 0 : y + 1), w, x0, n, d);
    double s = j->scale;
    if (j->method == METHOD_SOBEL) {
        for (int i = 0; i < n; i++) {
            double right = (double)u[i + 2] + 2.0 * m[i + 2] + d[i + 2];
            double left = (double)u[i] + 2.0 * m[i] + d[i];
            double below = (double)d[i] + 2.0 * d[i + 1] + d[i + 2];
            double above = (double)u[i] + 2.0 * u[i + 1] + u[i + 2];
            gx[i] = s * (right - left);
            gy[i] = s * (below - above);
        }
    } else {
        for (int i = 0; i < n; i++) {
            gx[i] = s * ((double)m[i + 2] - (double)m[i]);
            gy[i] = s * ((double)d[i + 1] - (double)u[i + 1]);
        }
    }
    int bad = 0;
    for (int i = 0; i < n; i++) bad |= !(fabs(gx[i]) <= 1e150) | !(fabs(gy[i]) <= 1e150);
    return !bad;
}

/* Finite stand-ins for the differences of non-finite heights: ±inf stays a huge slope of its
 * sign (1e150, whose square still fits a double), NaN becomes flat. */
static void tame(double *g, int n)
{
    for (int i = 0; i < n; i++)
        g[i] = isnan(g[i]) ? 0 : g[i] > 1e150 ? 1e150 : g[i] < -1e150 ? -1e150 : g[i];
}

/* Encode a normal component c in [−1, 1] as c·0.5 + 0.5, symmetric around 0.5: e, the rounded
 * value for |c|, is ≥ 0.5, so for negative c the sum e + (1 − 2e) = 1 − e is exact (written as
 * arithmetic rather than a branch so the loop vectorizes). */
static inline float encode(double c)
{
    float e = (float)(0.5 + 0.5 * fabs(c));
    float negative = (float)(c < 0);
    return e + negative * (1.0f - 2.0f * e);
}

/* q[i] = √q[i]: one vector instruction per few values (the project builds without errno-setting
 * maths), correctly rounded as the scalar sqrt; inlined, so that the AVX2 clones use AVX2. */
static inline __attribute__((always_inline)) void sqrt_block(double *q, int n)
{
    for (int i = 0; i < n; i++) q[i] = sqrt(q[i]);
}

HOT static void normal_block(const double *gx, const double *gy, int n, double green, float *o)
{
    double len[BLOCK];
    for (int i = 0; i < n; i++) len[i] = 1 + gx[i] * gx[i] + gy[i] * gy[i];
    sqrt_block(len, n);
    for (int i = 0; i < n; i++) {
        double inv = 1 / len[i];
        o[4 * i + 0] = encode(-gx[i] * inv);
        o[4 * i + 1] = encode(green * gy[i] * inv);
        o[4 * i + 2] = (float)(0.5 + 0.5 * inv);
        o[4 * i + 3] = 1.0f;
    }
}

static void normal_rows(void *user, int y0, int y1)
{
    const Job *j = user;
    int w = j->height->width;
    double gx[BLOCK], gy[BLOCK];
    for (int y = y0; y < y1; y++) {
        float *o = wg_image_row(j->out, y);
        for (int x0 = 0; x0 < w; x0 += BLOCK) {
            int n = w - x0 < BLOCK ? w - x0 : BLOCK;
            if (!gradient(j, y, x0, n, gx, gy)) tame(gx, n), tame(gy, n);
            normal_block(gx, gy, n, j->green, o + (size_t)x0 * 4);
        }
    }
}

/* atan of a ≥ 0 without a libm call, so the loop vectorises. Two reductions bring the argument to
 * |t| ≤ tan(π/12) ≈ 0.268: atan(a) = π/2 − atan(1/a) above 1, and atan(a) = π/6 + atan(t) with
 * t = (a√3 − 1)/(a + √3) above tan(π/12). There the Taylor series t − t³/3 + … to t¹⁷/17 leaves a
 * remainder below 0.268¹⁹/19 < 3e-13, and the reductions' rounding adds a few ulps of double:
 * the result is within 1e-12 of atan(a), four orders below the float output's resolution.
 * a = +inf gives π/2 (1/a = 0); the caller never passes NaN. */
static inline double atan_nonneg(double a)
{
    const double tan_pi12 = 0.26794919243112270, sqrt3 = 1.7320508075688772;
    double inv = 1 / a; /* both branches computed, then selected */
    int big = a > 1;
    double r = big ? inv : a;
    double shifted = (r * sqrt3 - 1) / (r + sqrt3);
    int mid = r > tan_pi12;
    double t = mid ? shifted : r;
    double z = t * t;
    double p = 1.0 / 17;
    p = p * z - 1.0 / 15;
    p = p * z + 1.0 / 13;
    p = p * z - 1.0 / 11;
    p = p * z + 1.0 / 9;
    p = p * z - 1.0 / 7;
    p = p * z + 1.0 / 5;
    p = p * z - 1.0 / 3;
    double v = t + t * z * p + (mid ? M_PI / 6 : 0);
    return big ? M_PI / 2 - v : v;
}

/* |g| = √(gx² + gy²) cannot overflow: the components are at most 1e150. The slope is within
 * 1e-12 of atan|g| / (π/2) before its rounding to float. */
HOT static void slope_block(const double *gx, const double *gy, int n, float *o)
{
    double mag[BLOCK];
    for (int i = 0; i < n; i++) mag[i] = gx[i] * gx[i] + gy[i] * gy[i];
    sqrt_block(mag, n);
    for (int i = 0; i < n; i++) {
        double s = atan_nonneg(mag[i]) * (2 / M_PI);
        o[i] = (float)(s < 1 ? s : 1);
    }
}

static void slope_rows(void *user, int y0, int y1)
{
    const Job *j = user;
    int w = j->height->width;
    double gx[BLOCK], gy[BLOCK];
    for (int y = y0; y < y1; y++) {
        float *o = wg_image_row(j->out, y);
        for (int x0 = 0; x0 < w; x0 += BLOCK) {
            int n = w - x0 < BLOCK ? w - x0 : BLOCK;
            if (!gradient(j, y, x0, n, gx, gy)) tame(gx, n), tame(gy, n);
            slope_block(gx, gy, n, o + x0);
        }
    }
}

static double gradient_scale(float intensity, int method, int width)
{
    return (double)intensity * (width / 256.0) / (method == METHOD_SOBEL ? 8.0 : 2.0);
}

static int normal_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const NormalParams *p = ctx->params;
    Job j = {ctx->inputs[0], ctx->outputs[0], p->method,
             gradient_scale(p->intensity, p->method, ctx->width),
             p->format == FORMAT_DIRECTX ? -1.0 : 1.0};
    return wg_parallel_rows(ctx, ctx->height, normal_rows, &j);
}

static int slope_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const SlopeParams *p = ctx->params;
    Job j = {ctx->inputs[0], ctx->outputs[0], p->method,
             gradient_scale(p->intensity, p->method, ctx->width), 0};
    return wg_parallel_rows(ctx, ctx->height, slope_rows, &j);
}

const WgNodeType wg_node_normal = {
    .name = "normal",
    .summary = "Tangent-space normal map from a height field",
    .category = "filter",
    .doc = "The gradient g of the height is measured per length unit (a pixel of a 256-wide "
           "image, docs/format.md): a height of 1 stands for `intensity` units, so "
           "g = intensity · (width/256) · dh/dpixel and a height map gives the same normals at "
           "any resolution (up to the finite-difference error). `central`: (h[x+1] − h[x−1])/2; "
           "`sobel`: the difference of 1-2-1 weighted neighbours, over 8 (smoother on noisy "
           "input). Reads wrap around the edges, so the output tiles. The normal "
           "(−gx, −gy, 1)/√(1 + |g|²), x to the right and y towards the top of the image, is "
           "encoded "
           "n·0.5 + 0.5 with alpha 1; `directx` flips green (exactly 1 − the OpenGL value). A "
           "flat input gives exactly (0.5, 0.5, 1). Computed in double and rounded once: each "
           "channel within 3e-8 of the exact encoding, unit length within 1.1e-7, finite for any "
           "input.",
    .params = normal_params,
    .params_size = sizeof(NormalParams),
    .inputs = height_in,
    .outputs = normal_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = normal_eval,
};

const WgNodeType wg_node_slope = {
    .name = "slope",
    .summary = "Steepness of a height field: 0 flat to 1 vertical",
    .category = "filter",
    .doc = "atan|g| / (π/2): the surface's angle from horizontal as a fraction of 90°, with the "
           "gradient g measured exactly as in `normal` (same `intensity` and `method`, wrapping "
           "reads). An angle rather than 1 − n.z because it grows evenly with steepness (45° is "
           "0.5, where 1 − n.z gives 0.29 and crowds gentle slopes near 0), so a threshold reads "
           "as an angle; it is non-decreasing in |g|, 0 exactly on flat input, 1 for vertical "
           "steps. Computed in double, rounded once to float (within 3e-8).",
    .params = slope_params,
    .params_size = sizeof(SlopeParams),
    .inputs = height_in,
    .outputs = slope_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = slope_eval,
};

/* ---- normal_blend and normal_normalize ---------------------------------------------------- */
/* Both decode n = 2·rgb − 1 in double, work on unit vectors and encode as `normal` does
 * (symmetric around 0.5, rounded once). `normal_blend` lays a detail normal map over a base one:
 * `rnm` is Reoriented Normal Mapping (Barré-Brisebois & Hill 2012, "Blending in Detail"): the
 * detail is rotated by the rotation taking +z to the base, t = b + (0,0,1), u = d·(−1,−1,1),
 * r = t·(t·u)/t.z − u; `whiteout` is (b.xy + d.xy, b.z·d.z). `opacity` first mixes the detail
 * with flat (0,0,1), so opacity 0 gives the base. Inputs are renormalised first (a zero or
 * non-finite vector counts as flat), and a base pointing straight down (t.z = 0, outside the
 * tangent hemisphere) keeps the base. Alpha is the base's. `normal_normalize` scales an encoded
 * vector to unit length; a zero (or NaN) vector becomes (0,0,1), an infinite component
 * dominates. Per pixel, so thread count and tiling cannot change anything. Speed at 2048²,
 * 2 threads (bench/bench_filters, medians over runs on a loaded 2-core machine): normal_blend
 * rnm 92-291 ms, whiteout 157-249 ms; normal_normalize 78-122 ms. */

typedef struct {
    int method;
    float opacity;
} NormalBlendParams;

enum { BLEND_RNM, BLEND_WHITEOUT };
static const char *const blend_values[] = {"rnm", "whiteout", NULL};

static const WgParamSpec normal_blend_params[] = {
    WG_PARAM_ENUM(NormalBlendParams, method, "rnm (reoriented normal mapping) or whiteout", 0,
                  blend_values),
    WG_PARAM_FLOAT(NormalBlendParams, opacity, "Detail strength: 0 keeps the base", 1.0, 0.0, 1.0),
    WG_PARAM_END,
};
static const WgPortSpec normal_blend_in[] = {WG_PORT("base", WG_COLOR), WG_PORT("detail", WG_COLOR),
                                             WG_PORT_END};
static const WgPortSpec normal_in[] = {WG_PORT("normal", WG_COLOR), WG_PORT_END};

/* v scaled to unit length; a zero or NaN vector becomes (0, 0, 1); infinite components win. */
static void unit(double v[3])
{
    double m = fmax(fabs(v[0]), fmax(fabs(v[1]), fabs(v[2])));
    if (!(m > 0) || isnan(v[0]) || isnan(v[1]) || isnan(v[2])) {
        v[0] = v[1] = 0, v[2] = 1;
        return;
    }
    if (isinf(m))
        for (int k = 0; k < 3; k++) v[k] = isinf(v[k]) ? copysign(1, v[k]) : 0;
    else
        for (int k = 0; k < 3; k++) v[k] /= m; /* no overflow or underflow in the squares */
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; k++) v[k] /= len;
}

static void decode_unit(const float *p, double v[3])
{
    for (int k = 0; k < 3; k++) v[k] = 2.0 * p[k] - 1.0;
    unit(v);
}

static void encode_unit(const double v[3], float alpha, float *o)
{
    o[0] = encode(v[0]);
    o[1] = encode(v[1]);
    o[2] = encode(v[2]);
    o[3] = alpha;
}

typedef struct {
    const WgImage *base, *detail;
    WgImage *out;
    int method;
    double opacity;
} BlendJob;

static void normal_blend_rows(void *user, int y0, int y1)
{
    const BlendJob *j = user;
    int w = j->out->width;
    for (int y = y0; y < y1; y++) {
        const float *bp = wg_image_row(j->base, y), *dp = wg_image_row(j->detail, y);
        float *o = wg_image_row(j->out, y);
        for (int x = 0; x < w; x++) {
            double b[3], d[3], r[3];
            decode_unit(bp + 4 * x, b);
            decode_unit(dp + 4 * x, d);
            if (j->opacity < 1) {
                d[0] *= j->opacity, d[1] *= j->opacity;
                d[2] = 1 + j->opacity * (d[2] - 1);
                unit(d);
            }
            if (j->method == BLEND_WHITEOUT) {
                r[0] = b[0] + d[0], r[1] = b[1] + d[1], r[2] = b[2] * d[2];
            } else {
                double t[3] = {b[0], b[1], b[2] + 1}, u[3] = {-d[0], -d[1], d[2]};
                if (t[2] > 0) {
                    double s = (t[0] * u[0] + t[1] * u[1] + t[2] * u[2]) / t[2];
                    for (int k = 0; k < 3; k++) r[k] = t[k] * s - u[k];
                } else {
                    for (int k = 0; k < 3; k++) r[k] = b[k];
                }
            }
            unit(r);
            encode_unit(r, bp[4 * x + 3], o + 4 * x);
        }
    }
}

static void normal_normalize_rows(void *user, int y0, int y1)
{
    const BlendJob *j = user;
    int w = j->out->width;
    for (int y = y0; y < y1; y++) {
        const float *p = wg_image_row(j->base, y);
        float *o = wg_image_row(j->out, y);
        for (int x = 0; x < w; x++) {
            double v[3];
            decode_unit(p + 4 * x, v);
            encode_unit(v, p[4 * x + 3], o + 4 * x);
        }
    }
}

static int normal_blend_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const NormalBlendParams *p = ctx->params;
    BlendJob j = {ctx->inputs[0], ctx->inputs[1], ctx->outputs[0], p->method, p->opacity};
    return wg_parallel_rows(ctx, ctx->height, normal_blend_rows, &j);
}

static int normal_normalize_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    BlendJob j = {ctx->inputs[0], NULL, ctx->outputs[0], 0, 1};
    return wg_parallel_rows(ctx, ctx->height, normal_normalize_rows, &j);
}

const WgNodeType wg_node_normal_blend = {
    .name = "normal_blend",
    .summary = "Combine a detail normal map with a base one (RNM or whiteout)",
    .category = "filter",
    .doc = "`rnm`: Reoriented Normal Mapping (Barré-Brisebois & Hill 2012): the detail is "
           "rotated as +z is rotated onto the base, t = b + (0,0,1), u = d·(−1,−1,1), "
           "r = t·(t·u)/t.z − u. `whiteout`: (b.xy + d.xy, b.z·d.z). The result is normalised. "
           "`opacity` mixes the detail towards flat first (0 keeps the base). Inputs are "
           "decoded n = 2·rgb − 1 and renormalised (zero counts as flat); encoded as `normal` "
           "does, alpha from the base. Computed in double, rounded once.",
    .params = normal_blend_params,
    .params_size = sizeof(NormalBlendParams),
    .inputs = normal_blend_in,
    .outputs = normal_out,
    .flags = WG_NODE_POINT,
    .eval = normal_blend_eval,
};

const WgNodeType wg_node_normal_normalize = {
    .name = "normal_normalize",
    .summary = "Rescale an encoded normal map to unit-length vectors",
    .category = "filter",
    .doc = "Decodes n = 2·rgb − 1, divides by |n| in double and encodes as `normal` does "
           "(each channel within 3e-8 of exact); a zero vector becomes (0, 0, 1), i.e. "
           "(0.5, 0.5, 1). Alpha is kept.",
    .params = NULL,
    .params_size = 0,
    .inputs = normal_in,
    .outputs = normal_out,
    .flags = WG_NODE_POINT,
    .eval = normal_normalize_eval,
};
