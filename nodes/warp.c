/* SPDX-License-Identifier: MIT */
/* `warp`, `directional_warp` and `transform`: resampling a source at moved positions, with
 * wrap-around (periodic) addressing everywhere, so every output tiles wherever the mapping does.
 * Each output pixel p (pixel centres at integer coordinates) reads the source at a position
 * q(p) in double precision; q is reduced modulo the image size exactly (floor, or fmod beyond
 * 2^31), so huge displacements wrap instead of overflowing, and the sample is one shared
 * bilinear or bicubic (Keys' cubic convolution with a = −0.5, i.e. Catmull-Rom) filter over
 * the wrapped neighbours, weights and sums in double, rounded once to float. Both filters keep
 * a constant source exactly constant and give exactly the source pixel at integer positions.
 * Bicubic overshoots the source's range near sharp edges (weights down to −0.074 per axis)
 * and is clamped to ±FLT_MAX, so finite inputs never give Inf or NaN; non-finite displacements
 * count as none, non-finite source values spread to the pixels that sample them.
 * - `warp`: q = p − amount·∇I(p), ∇I by central differences with wrap, measured per length
 *   unit (a pixel of a 256-wide image, docs/format.md), the displacement amount·∇I in length
 *   units: in pixels, amount · (W/256)² · (I[x+1] − I[x−1]) / 2 along x and the same with rows
 *   along y (W the width in both directions). A picture of W pixels therefore moves by the
 *   same fraction of the tile at any resolution. Where ∇I varies slowly the picture moves by
 *   +amount·∇I, towards higher intensity for a positive amount. The displacement is split into
 *   whole pixels and a fraction before it is added to p, so rolling both inputs rolls the
 *   output bit for bit.
 * - `directional_warp`: q = p − amount·I(p)·(cos θ, sin θ) in length units, θ counter-clockwise
 *   from +x with y towards the top of the image; without `intensity`, I = 1 (a plain shift).
 * - `transform`: a 2×2 matrix A maps output texture coordinates, centred on the middle of the
 *   image (y up), to source ones: q = c + A·(p − c − offset) in texture units (0..1 of width
 *   and height). A = diag(scale) · R(−rotation), or m00..m11 when `matrix` is set: the picture
 *   is turned counter-clockwise by `rotation` and repeated `scale` times. The output tiles
 *   seamlessly when A is an integer matrix (integer scales, 90° rotations); other rotations
 *   show the seams of the source tile. Angles are reduced to the nearest multiple of 90° plus a
 *   rest, so 90° turns use exact zeros and ones; an offset within float precision of a whole
 *   pixel is snapped to it. No prefilter: scales above 1 alias like any point sampler.
 * Work is split over rows with wg_parallel_rows; each pixel depends only on its own position,
 * so any thread count gives the same bits.
 * Speed at 2048², 2 threads (bench/bench_warp, release, median of 9, the quietest of three runs
 * on a shared 2-core machine; busier runs were up to 2× slower), bilinear unless said: `warp`
 * 20 ms gray, 44 ms colour, 76 ms colour bicubic; `directional_warp` 18 ms gray, 42 ms colour;
 * `transform` (30°, scale 1.5) 29 ms gray, 71 ms colour, 111 ms colour bicubic. One memcpy of
 * the 64 MB colour image takes 6 ms warm and 33 ms into fresh pages (which a new output also
 * pays), of the 16 MB gray one 1.2 / 5 ms: the warps cost about 1.3× a first-touch copy of their
 * output in colour, 4× in gray. RGBA pixels are filtered two channels at a time with SSE2
 * (the same operations as the scalar code, so the same bits); `transform` walks tiles of 64
 * columns by a chunk's rows so that a rotated tile reads a compact patch of the source.
 */
#include "wetgraph/node.h"

#include <float.h>
#include <math.h>
#include <stdbool.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { FILTER_BILINEAR, FILTER_BICUBIC };
static const char *const filter_values[] = {"bilinear", "bicubic", NULL};
#define FILTER_LABEL "Sampling: bilinear, or bicubic (Catmull-Rom, sharper, may overshoot)"

typedef struct {
    float amount;
    int filter;
} WarpParams;

typedef struct {
    float amount;
    float angle;
    int filter;
} DirectionalWarpParams;

typedef struct {
    float offset_x, offset_y;
    float rotation;
    float scale_x, scale_y;
    bool matrix;
    float m00, m01, m10, m11;
    int filter;
} TransformParams;

static const WgParamSpec warp_params[] = {
    WG_PARAM_FLOAT_UI(WarpParams, amount,
                      "Length units (pixels of a 256-wide image) moved per unit of intensity "
                      "gradient (intensity per length unit)",
                      64.0, -1e6, 1e6, -1024, 1024),
    WG_PARAM_ENUM(WarpParams, filter, FILTER_LABEL, FILTER_BILINEAR, filter_values),
    WG_PARAM_END,
};
static const WgParamSpec directional_warp_params[] = {
    WG_PARAM_FLOAT_UI(DirectionalWarpParams, amount,
                      "Distance in length units (pixels of a 256-wide image) at intensity 1", 16.0,
                      -1e6, 1e6, -256, 256),
    WG_PARAM_FLOAT_UI(DirectionalWarpParams, angle,
                      "Direction in degrees, counter-clockwise from +x (90 = up)", 0.0, -1e6, 1e6,
                      -180, 180),
    WG_PARAM_ENUM(DirectionalWarpParams, filter, FILTER_LABEL, FILTER_BILINEAR, filter_values),
    WG_PARAM_END,
};
static const WgParamSpec transform_params[] = {
    WG_PARAM_FLOAT_UI(TransformParams, offset_x, "Move right by this fraction of the width", 0.0,
                      -1024, 1024, -1, 1),
    WG_PARAM_FLOAT_UI(TransformParams, offset_y, "Move up by this fraction of the height", 0.0,
                      -1024, 1024, -1, 1),
    WG_PARAM_FLOAT_UI(TransformParams, rotation, "Turn counter-clockwise, degrees", 0.0, -1e6, 1e6,
                      -180, 180),
    WG_PARAM_FLOAT_UI(TransformParams, scale_x, "Repetitions across the width (2: half size)", 1.0,
                      -4096, 4096, -8, 8),
    WG_PARAM_FLOAT_UI(TransformParams, scale_y, "Repetitions across the height (2: half size)", 1.0,
                      -4096, 4096, -8, 8),
    WG_PARAM_BOOL(TransformParams, matrix, "Use m00..m11 instead of rotation and scale", false),
    WG_PARAM_FLOAT_UI(TransformParams, m00, "Matrix row 0, column 0 (output to source, y up)", 1.0,
                      -4096, 4096, -8, 8),
    WG_PARAM_FLOAT_UI(TransformParams, m01, "Matrix row 0, column 1", 0.0, -4096, 4096, -8, 8),
    WG_PARAM_FLOAT_UI(TransformParams, m10, "Matrix row 1, column 0", 0.0, -4096, 4096, -8, 8),
    WG_PARAM_FLOAT_UI(TransformParams, m11, "Matrix row 1, column 1", 1.0, -4096, 4096, -8, 8),
    WG_PARAM_ENUM(TransformParams, filter, FILTER_LABEL, FILTER_BILINEAR, filter_values),
    WG_PARAM_END,
};

static const WgPortSpec warp_in[] = {WG_PORT("source", WG_ANY), WG_PORT("intensity", WG_GRAY),
                                     WG_PORT_END};
static const WgPortSpec directional_warp_in[] = {WG_PORT("source", WG_ANY),
                                                 WG_PORT_OPT("intensity", WG_GRAY), WG_PORT_END};
static const WgPortSpec transform_in[] = {WG_PORT("source", WG_ANY), WG_PORT_END};
static const WgPortSpec any_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

/* ---- shared sampling ------------------------------------------------------------------------ */

/* A sample position: the wrapped pixel at or left of / above it, and the fraction beyond. */
typedef struct {
    int x, y;
    double fx, fy;
} Tap;

/* Pixels per block: a block's taps live on the stack. */
enum { BLOCK = 256 };

/* floor(v) modulo n into *i (in [0, n)) and v − floor(v) into *f (in [0, 1), exact). Huge or
 * non-finite v cannot overflow: beyond 2^31 the reduction is fmod (exact), non-finite is 0.
 * floor by truncation and a fix-up (libm's floor is a call without SSE4.1), and no division
 * for positions within one tile of the image. */
static inline void split(double v, int n, int *i, double *f)
{
    if (v > -2147483648.0 && v < 2147483647.0) {
        long k = (long)v;
        if ((double)k > v) k--;
        *f = v - (double)k;
        if (k >= n) {
            k -= n;
            if (k >= n) k %= n;
        } else if (k < 0) {
            k += n;
            if (k < 0) {
                k %= n;
                if (k < 0) k += n;
            }
        }
        *i = (int)k;
    } else if (isfinite(v)) {
        double fl = floor(v), r = fmod(fl, (double)n); /* fl is an integer: r is exact */
        *i = (int)(r < 0 ? r + n : r);
        *f = v - fl; /* 0 beyond 2^52, where v is an integer */
    } else {
        *i = 0, *f = 0;
    }
}

static inline int wrap_index(int i, int n)
{
    if (i < 0) i += n;
    while (i >= n) i -= n; /* at most 3 times, for n = 1 */
    return i;
}

static inline float clamp_float(double v)
{
    return (float)(v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v);
}

#ifdef __SSE2__
/* An RGBA pixel as two pairs of doubles, and back to floats (each lane rounded once). */
static inline void load4(const float *p, __m128d *lo, __m128d *hi)
{
    __m128 v = _mm_loadu_ps(p);
    *lo = _mm_cvtps_pd(v);
    *hi = _mm_cvtps_pd(_mm_movehl_ps(v, v));
}
static inline void store4(float *p, __m128d lo, __m128d hi)
{
    _mm_storeu_ps(p, _mm_movelh_ps(_mm_cvtpd_ps(lo), _mm_cvtpd_ps(hi)));
}
static inline __m128d lerp2(__m128d a, __m128d b, __m128d f)
{
    return _mm_add_pd(a, _mm_mul_pd(f, _mm_sub_pd(b, a)));
}
#endif

/* Bilinear: lerps in double, a + f·(b − a), so f = 0 gives a exactly and a constant stays. The
 * SSE2 path for RGBA does the same operations two channels at a time (the same bits). */
static inline void bilinear(const WgImage *src, int c, const Tap *t, int n, float *out)
{
    int w = src->width, h = src->height;
    for (int i = 0; i < n; i++) {
        int x0 = t[i].x, x1 = x0 + 1 == w ? 0 : x0 + 1;
        int y0 = t[i].y, y1 = y0 + 1 == h ? 0 : y0 + 1;
        const float *r0 = wg_image_row(src, y0), *r1 = wg_image_row(src, y1);
        double fx = t[i].fx, fy = t[i].fy;
#ifdef __SSE2__
        if (c == 4) {
            __m128d a0, a1, b0, b1, d0, d1, e0, e1, vx = _mm_set1_pd(fx), vy = _mm_set1_pd(fy);
            load4(r0 + x0 * 4, &a0, &a1);
            load4(r0 + x1 * 4, &b0, &b1);
            load4(r1 + x0 * 4, &d0, &d1);
            load4(r1 + x1 * 4, &e0, &e1);
            __m128d t0 = lerp2(a0, b0, vx), t1 = lerp2(a1, b1, vx);
            __m128d u0 = lerp2(d0, e0, vx), u1 = lerp2(d1, e1, vx);
            store4(out + i * 4, lerp2(t0, u0, vy), lerp2(t1, u1, vy));
            continue;
        }
#endif
        for (int k = 0; k < c; k++) {
            double a = r0[x0 * c + k], b = r0[x1 * c + k];
            double d = r1[x0 * c + k], e = r1[x1 * c + k];
            double top = a + fx * (b - a), bottom = d + fx * (e - d);
            out[i * c + k] = (float)(top + fy * (bottom - top));
        }
    }
}

/* Keys' cubic convolution weights, a = −0.5 (Catmull-Rom), for taps −1, 0, 1, 2 at fraction t:
 * they sum to 1 and are (0, 1, 0, 0) at t = 0. */
static inline void keys_weights(double t, double w[4])
{
    w[0] = t * (-0.5 + t * (1.0 - 0.5 * t));
    w[1] = 1.0 + t * t * (-2.5 + 1.5 * t);
    w[2] = t * (0.5 + t * (2.0 - 1.5 * t));
    w[3] = t * t * (-0.5 + 0.5 * t);
}

/* Bicubic: each row's taps summed left to right, then the rows weighted and summed top to
 * bottom, in double; the SSE2 path for RGBA does the same operations two channels at a time. */
static inline void bicubic(const WgImage *src, int c, const Tap *t, int n, float *out)
{
    int w = src->width, h = src->height;
    for (int i = 0; i < n; i++) {
        double wx[4], wy[4], acc[4] = {0, 0, 0, 0};
        int xi[4];
        const float *rows[4];
        keys_weights(t[i].fx, wx);
        keys_weights(t[i].fy, wy);
        for (int m = 0; m < 4; m++) {
            xi[m] = wrap_index(t[i].x - 1 + m, w) * c;
            rows[m] = wg_image_row(src, wrap_index(t[i].y - 1 + m, h));
        }
#ifdef __SSE2__
        if (c == 4) {
            __m128d lo = _mm_setzero_pd(), hi = _mm_setzero_pd();
            for (int j = 0; j < 4; j++) {
                __m128d rl = _mm_setzero_pd(), rh = _mm_setzero_pd();
                for (int m = 0; m < 4; m++) {
                    __m128d pl, ph, wm = _mm_set1_pd(wx[m]);
                    load4(rows[j] + xi[m], &pl, &ph);
                    if (m == 0) {
                        rl = _mm_mul_pd(wm, pl), rh = _mm_mul_pd(wm, ph);
                    } else {
                        rl = _mm_add_pd(rl, _mm_mul_pd(wm, pl));
                        rh = _mm_add_pd(rh, _mm_mul_pd(wm, ph));
                    }
                }
                __m128d wj = _mm_set1_pd(wy[j]);
                lo = _mm_add_pd(lo, _mm_mul_pd(wj, rl));
                hi = _mm_add_pd(hi, _mm_mul_pd(wj, rh));
            }
            __m128d big = _mm_set1_pd(FLT_MAX), small = _mm_set1_pd(-FLT_MAX);
            /* min/max return their second operand on NaN: NaN passes, as in clamp_float */
            store4(out + i * 4, _mm_max_pd(small, _mm_min_pd(big, lo)),
                   _mm_max_pd(small, _mm_min_pd(big, hi)));
            continue;
        }
#endif
        for (int j = 0; j < 4; j++) {
            for (int k = 0; k < c; k++) {
                const float *r = rows[j] + k;
                double row =
                    wx[0] * r[xi[0]] + wx[1] * r[xi[1]] + wx[2] * r[xi[2]] + wx[3] * r[xi[3]];
                acc[k] += wy[j] * row;
            }
        }
        for (int k = 0; k < c; k++) out[i * c + k] = clamp_float(acc[k]);
    }
}

/* Sample src at n taps into out (n pixels of src->channels). The channel count is passed as a
 * constant to each inlined filter so the inner loops are specialised. */
static void sample(const WgImage *src, int filter, const Tap *t, int n, float *out)
{
    if (filter == FILTER_BICUBIC) {
        if (src->channels == 1)
            bicubic(src, 1, t, n, out);
        else
            bicubic(src, 4, t, n, out);
    } else {
        if (src->channels == 1)
            bilinear(src, 1, t, n, out);
        else
            bilinear(src, 4, t, n, out);
    }
}

/* ---- warp and directional_warp -------------------------------------------------------------- */

typedef struct {
    const WgImage *src, *intensity;
    WgImage *out;
    int filter;
    double scale;  /* warp: pixels moved per unit of intensity difference across two pixels */
    double ux, uy; /* directional_warp: minus the displacement in pixels at intensity 1 */
} WarpJob;

/* Tap for output pixel (x, y) reading at (x, y) + (vx, vy) pixels. Splitting the offset v
 * before adding x keeps the fraction independent of x, so rolled inputs give rolled outputs. */
static inline void offset_tap(int x, int y, double vx, double vy, int w, int h, Tap *t)
{
    int ix, iy;
    if (!isfinite(vx) || !isfinite(vy)) vx = 0, vy = 0;
    split(vx, w, &ix, &t->fx);
    split(vy, h, &iy, &t->fy);
    ix += x;
    iy += y;
    t->x = ix >= w ? ix - w : ix;
    t->y = iy >= h ? iy - h : iy;
}

static void warp_rows(void *user, int y0, int y1)
{
    const WarpJob *j = user;
    int w = j->out->width, h = j->out->height, c = j->out->channels;
    Tap taps[BLOCK];
    for (int y = y0; y < y1; y++) {
        const float *up = wg_image_row(j->intensity, y == 0 ? h - 1 : y - 1);
        const float *mid = wg_image_row(j->intensity, y);
        const float *down = wg_image_row(j->intensity, y == h - 1 ? 0 : y + 1);
        float *o = wg_image_row(j->out, y);
        for (int x0 = 0; x0 < w; x0 += BLOCK) {
            int n = w - x0 < BLOCK ? w - x0 : BLOCK;
            for (int i = 0; i < n; i++) {
                int x = x0 + i;
                double gx =
                    (double)mid[x + 1 == w ? 0 : x + 1] - (double)mid[x == 0 ? w - 1 : x - 1];
                double gy = (double)down[x] - (double)up[x];
                offset_tap(x, y, -j->scale * gx, -j->scale * gy, w, h, &taps[i]);
            }
            sample(j->src, j->filter, taps, n, o + (size_t)x0 * (size_t)c);
        }
    }
}

static void directional_rows(void *user, int y0, int y1)
{
    const WarpJob *j = user;
    int w = j->out->width, h = j->out->height, c = j->out->channels;
    Tap taps[BLOCK];
    for (int y = y0; y < y1; y++) {
        const float *in = j->intensity ? wg_image_row(j->intensity, y) : NULL;
        float *o = wg_image_row(j->out, y);
        for (int x0 = 0; x0 < w; x0 += BLOCK) {
            int n = w - x0 < BLOCK ? w - x0 : BLOCK;
            for (int i = 0; i < n; i++) {
                double v = in ? in[x0 + i] : 1.0;
                offset_tap(x0 + i, y, v * j->ux, v * j->uy, w, h, &taps[i]);
            }
            sample(j->src, j->filter, taps, n, o + (size_t)x0 * (size_t)c);
        }
    }
}

static int warp_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const WarpParams *p = ctx->params;
    double unit = ctx->width / 256.0; /* pixels per length unit */
    WarpJob j = {ctx->inputs[0],
                 ctx->inputs[1],
                 ctx->outputs[0],
                 p->filter,
                 (double)p->amount * unit * unit / 2,
                 0,
                 0};
    return wg_parallel_rows(ctx, ctx->height, warp_rows, &j);
}

/* sin and cos of an angle in degrees, exact at multiples of 90°: the angle is reduced to a
 * quadrant and a rest in [−45°, 45°], whose sine and cosine libm gives within an ulp. */
static void sincos_degrees(double deg, double *s, double *c)
{
    double r = fmod(deg, 360.0);
    if (r < 0) r += 360.0;
    int q = (int)floor(r / 90.0 + 0.5);
    double a = (r - 90.0 * q) * (M_PI / 180.0);
    double s0 = sin(a), c0 = cos(a);
    switch (q & 3) {
    case 0:
        *s = s0, *c = c0;
        break;
    case 1:
        *s = c0, *c = -s0;
        break;
    case 2:
        *s = -s0, *c = -c0;
        break;
    default:
        *s = -c0, *c = s0;
        break;
    }
}

static int directional_warp_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const DirectionalWarpParams *p = ctx->params;
    double s, c, len = (double)p->amount * (ctx->width / 256.0);
    sincos_degrees(p->angle, &s, &c);
    /* read at p − d, d = len·(cos, sin) with y up, i.e. (cos, −sin) in rows */
    WarpJob j = {ctx->inputs[0], ctx->inputs[1], ctx->outputs[0], p->filter, 0, -len * c, len * s};
    return wg_parallel_rows(ctx, ctx->height, directional_rows, &j);
}

/* ---- transform ------------------------------------------------------------------------------ */

typedef struct {
    const WgImage *src;
    WgImage *out;
    int filter;
    double bx, by;   /* source pixel position of the centre: size/2 − 0.5 */
    double ox, oy;   /* offset in pixels, x right, y up */
    double c00, c01; /* source x = bx + c00·X + c01·Y, X, Y output pixels from the centre */
    double c10, c11; /* source y (rows) = by + c10·X + c11·Y; Y up */
} TransformJob;

/* Tiles of TILE columns by the chunk's rows: a rotated or scaled tile reads a compact patch
 * of the source, where whole rows would stride across many source rows and pages. */
enum { TILE = 64 };

static void transform_rows(void *user, int y0, int y1)
{
    const TransformJob *j = user;
    int w = j->out->width, h = j->out->height, c = j->out->channels;
    Tap taps[TILE];
    for (int x0 = 0; x0 < w; x0 += TILE) {
        int n = w - x0 < TILE ? w - x0 : TILE;
        for (int y = y0; y < y1; y++) {
            double Y = -((y + 0.5) - h / 2.0) - j->oy;
            double rx = j->bx + j->c01 * Y, ry = j->by + j->c11 * Y;
            for (int i = 0; i < n; i++) {
                double X = ((x0 + i + 0.5) - w / 2.0) - j->ox;
                split(rx + j->c00 * X, w, &taps[i].x, &taps[i].fx);
                split(ry + j->c10 * X, h, &taps[i].y, &taps[i].fy);
            }
            sample(j->src, j->filter, taps, n, wg_image_row(j->out, y) + (size_t)x0 * (size_t)c);
        }
    }
}

/* An offset in texture units as pixels, snapped to a whole pixel when within the float
 * parameter's own precision of one (so k/side moves by exactly k pixels). Not reduced modulo
 * the side: A times a whole tile is a whole number of tiles only for integer matrices. */
static double offset_pixels(float offset, int side)
{
    double ulp = nextafterf(fabsf(offset), INFINITY) - fabsf(offset);
    double px = (double)offset * side;
    double whole = nearbyint(px);
    return fabs(px - whole) <= ulp * side ? whole : px;
}

static int transform_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const TransformParams *p = ctx->params;
    int w = ctx->width, h = ctx->height;
    double a00, a01, a10, a11;
    if (p->matrix) {
        a00 = p->m00, a01 = p->m01, a10 = p->m10, a11 = p->m11;
    } else {
        double s, c;
        sincos_degrees(p->rotation, &s, &c);
        a00 = p->scale_x * c, a01 = p->scale_x * s;
        a10 = -p->scale_y * s, a11 = p->scale_y * c;
    }
    /* A acts on texture coordinates (u right, v up); in pixels that is diag(w, −h)·A·
     * diag(1/w, 1/h) applied to (X, Y up), the minus turning v up into rows down. */
    double r = (double)w / h;
    TransformJob j = {ctx->inputs[0],
                      ctx->outputs[0],
                      p->filter,
                      w / 2.0 - 0.5,
                      h / 2.0 - 0.5,
                      offset_pixels(p->offset_x, w),
                      offset_pixels(p->offset_y, h),
                      a00,
                      a01 * r,
                      -a10 / r,
                      -a11};
    return wg_parallel_rows(ctx, h, transform_rows, &j);
}

/* ---- descriptors ---------------------------------------------------------------------------- */

const WgNodeType wg_node_warp = {
    .name = "warp",
    .summary = "Move a source along the gradient of an intensity map",
    .category = "filter",
    .doc = "Each output pixel p reads the source at p − amount·∇I(p). The gradient ∇I of the gray "
           "`intensity` is taken by central differences with wrap-around and measured per length "
           "unit (a pixel of a 256-wide image, docs/format.md), and the displacement "
           "amount·∇I is in length units: in pixels, amount·(W/256)²·(I[x+1] − I[x−1])/2 along "
           "x and likewise down the rows along y, W the width. The same inputs thus give the "
           "same picture at any resolution (up to filtering). Where the gradient varies slowly "
           "the picture moves by amount·∇I: towards higher intensity for a positive amount. "
           "Output has the source's kind. Reads wrap around, so the output tiles; rolling both "
           "inputs rolls the output exactly. `bilinear` or `bicubic` (Catmull-Rom, clamped to "
           "the float range) sampling in double; amount 0 copies the source exactly. Any "
           "amount gives finite output for finite input.",
    .params = warp_params,
    .params_size = sizeof(WarpParams),
    .inputs = warp_in,
    .outputs = any_out,
    .flags = WG_NODE_GLOBAL,
    .eval = warp_eval,
};

const WgNodeType wg_node_directional_warp = {
    .name = "directional_warp",
    .summary = "Move a source along a fixed direction by an intensity map",
    .category = "filter",
    .doc = "Each output pixel p reads the source at p − amount·I(p)·(cos angle, sin angle): the "
           "picture moves by amount·I length units (pixels of a 256-wide image, so the same "
           "at any resolution) towards `angle`, counted counter-clockwise from +x with y towards "
           "the top of the image (90 moves it up). Without `intensity`, I = 1: a plain shift "
           "(exact when amount·W/256 is a whole number of pixels). Output has the source's kind; "
           "reads wrap around, so the output tiles. `bilinear` or `bicubic` (Catmull-Rom) "
           "sampling in double; finite output for finite input.",
    .params = directional_warp_params,
    .params_size = sizeof(DirectionalWarpParams),
    .inputs = directional_warp_in,
    .outputs = any_out,
    .flags = WG_NODE_GLOBAL,
    .eval = directional_warp_eval,
};

const WgNodeType wg_node_transform = {
    .name = "transform",
    .summary = "Offset, rotate and scale a source as a tile",
    .category = "filter",
    .doc = "Output texture point o (coordinates 0..1 of width and height, y up, c the centre) "
           "reads the source at c + A·(o − c − offset), wrapping modulo 1. A = "
           "diag(scale_x, scale_y)·R(−rotation): the picture turns counter-clockwise by "
           "`rotation` degrees and repeats `scale` times across the tile (negative mirrors); "
           "with `matrix`, A = [m00 m01; m10 m11] as given (output to source, y up). The offset "
           "moves the picture right and up by fractions of the tile, so it is resolution "
           "independent; an offset within float precision of a whole pixel moves exactly that "
           "many pixels. The output tiles seamlessly when A has integer entries (integer scales, "
           "90° rotations, which are exact pixel permutations on square images); other "
           "rotations and fractional scales cut across the source's tiles and show seams. On "
           "non-square images A acts on texture coordinates, so a rotation is stretched to the "
           "aspect ratio. `bilinear`, or `bicubic` (Keys' cubic convolution with a = −0.5, "
           "i.e. Catmull-Rom, clamped to the float range) in double; no prefilter, so large "
           "scales alias (blur first).",
    .params = transform_params,
    .params_size = sizeof(TransformParams),
    .inputs = transform_in,
    .outputs = any_out,
    .flags = WG_NODE_GLOBAL,
    .eval = transform_eval,
};
