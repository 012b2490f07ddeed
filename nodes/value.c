/* SPDX-License-Identifier: MIT */
/* Value remapping: `curve`, `clamp`, `threshold`, `auto_levels`. All work on the colour channels
 * of gray or colour images and leave alpha unchanged.
 *
 * `curve` is a monotone cubic Hermite spline through control points with the tangents of
 * Fritsch & Carlson ("Monotone piecewise cubic interpolation", SIAM J. Numer. Anal. 17(2), 1980):
 * secant averages, zeroed at local extrema and flat segments, then scaled into the circle
 * α² + β² ≤ 9 so that every segment is monotone and never leaves the range of its two end values.
 * It is evaluated in double and rounded once to float (≤ 0.5 ulp from the exact spline, and
 * clamped to the segment's value range so that rounding can never overshoot).
 * `threshold` is Substance's Histogram Scan with the window centred on `position`.
 * `auto_levels` measures the finite minimum and maximum per row (so the result does not depend on
 * how rows are split between threads), combines them in row order, then stretches linearly. */
#include "wetgraph/node.h"
#include "hot.h"

#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static const WgPortSpec source_in[] = {WG_PORT("source", WG_ANY), WG_PORT_END};
static const WgPortSpec output_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

/* Apply EXPR (a float expression of `x`) to every colour value of rows [y0, y1); alpha copied. */
#define POINT_LOOP(in, out, y0, y1, EXPR)                                                          \
    do {                                                                                           \
        int c_ = (in)->channels;                                                                   \
        for (int y = (y0); y < (y1); y++) {                                                        \
            const float *s_ = wg_image_row((in), y);                                               \
            float *d_ = wg_image_row((out), y);                                                    \
            for (int i_ = 0; i_ < (in)->width * c_; i_++) {                                        \
                float x = s_[i_];                                                                  \
                d_[i_] = (c_ == 4 && (i_ & 3) == 3) ? x : (EXPR);                                  \
            }                                                                                      \
        }                                                                                          \
    } while (0)

/* ---- curve ------------------------------------------------------------------------------- */

#define CURVE_MAX_POINTS 256

typedef struct {
    const char *points;
} CurveParams;

static const WgParamSpec curve_params[] = {
    WG_PARAM_STRING(CurveParams, points, "Control points 'x:y x:y ...' (any order)", "0:0 1:1"),
    WG_PARAM_END,
};

typedef struct {
    int n;
    double x[CURVE_MAX_POINTS], y[CURVE_MAX_POINTS], m[CURVE_MAX_POINTS];
} Curve;

/* Parse one finite number from [s, end); false if it is not exactly a number. */
static bool number(const char *s, const char *end, double *out)
{
    char buf[64];
    size_t len = (size_t)(end - s);
    if (len == 0 || len >= sizeof buf) return false;
    memcpy(buf, s, len);
    buf[len] = '\0';
    return wg_parse_number(buf, out);
}

/* Parse "x:y ..." into c (sorted by x), and compute the Fritsch–Carlson tangents. */
static int curve_parse(const char *text, Curve *c, WgError *err)
{
    c->n = 0;
    const char *p = text ? text : "";
    for (;;) {
        while (isspace((unsigned char)*p)) p++;
        if (!*p) break;
        const char *tok = p;
        while (*p && !isspace((unsigned char)*p)) p++;
        int len = (int)(p - tok);
        if (c->n == CURVE_MAX_POINTS)
            return wg_error_set(err, WG_ERR_RANGE, NULL, "points: more than %d points",
                                CURVE_MAX_POINTS);
        const char *colon = memchr(tok, ':', (size_t)len);
        double x, y;
        if (!colon || !number(tok, colon, &x) || !number(colon + 1, p, &y))
            return wg_error_set(err, WG_ERR_PARSE, NULL,
                                "points: point %d '%.*s' is not 'x:y' (two numbers joined by ':', "
                                "points separated by spaces, e.g. \"0:0 0.3:0.1 1:1\")",
                                c->n + 1, len, tok);
        if (!(fabs(x) <= FLT_MAX) || !(fabs(y) <= FLT_MAX))
            return wg_error_set(err, WG_ERR_RANGE, NULL,
                                "points: point %d '%.*s' is not a finite float value", c->n + 1,
                                len, tok);
        /* insertion sort: the list is short and usually sorted already */
        int k = c->n;
        while (k > 0 && c->x[k - 1] > x) {
            c->x[k] = c->x[k - 1];
            c->y[k] = c->y[k - 1];
            k--;
        }
        if (k > 0 && c->x[k - 1] == x)
            return wg_error_set(err, WG_ERR_RANGE, NULL,
                                "points: two points at x = %g (x values must differ)", x);
        c->x[k] = x;
        c->y[k] = y;
        c->n++;
    }
    if (c->n == 0)
        return wg_error_set(err, WG_ERR_PARSE, NULL,
                            "points: needs at least one point 'x:y', e.g. \"0:0 1:1\"");
    int n = c->n;
    if (n == 1) {
        c->m[0] = 0;
        return WG_OK;
    }
    double d[CURVE_MAX_POINTS] = {0};
    for (int k = 0; k < n - 1; k++) {
        d[k] = (c->y[k + 1] - c->y[k]) / (c->x[k + 1] - c->x[k]);
        /* points so close that the slope overflows: the steepest that still averages finitely */
        if (isinf(d[k])) d[k] = copysign(DBL_MAX / 2, d[k]);
    }
    c->m[0] = d[0];
    c->m[n - 1] = d[n - 2];
    for (int k = 1; k < n - 1; k++)
        c->m[k] = (d[k - 1] > 0 && d[k] > 0) || (d[k - 1] < 0 && d[k] < 0) ? 0.5 * (d[k - 1] + d[k])
                                                                           : 0.0;
    for (int k = 0; k < n - 1; k++) {
        if (d[k] == 0) {
            c->m[k] = c->m[k + 1] = 0;
            continue;
        }
        double a = c->m[k] / d[k], b = c->m[k + 1] / d[k];
        double r = hypot(a, b);
        if (r > 3) { /* tau·a·d[k] is tau·m[k]; so written it stays 0 when a overflows */
            double tau = 3 / r;
            c->m[k] *= tau;
            c->m[k + 1] *= tau;
        }
    }
    return WG_OK;
}

static inline float curve_eval1(const Curve *c, float xf)
{
    double x = xf;
    int n = c->n;
    if (!(x > c->x[0])) return (float)c->y[0]; /* also NaN */
    if (x >= c->x[n - 1]) return (float)c->y[n - 1];
    int lo = 0, hi = n - 1; /* x[lo] < x < x[hi]... until adjacent */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (c->x[mid] <= x)
            lo = mid;
        else
            hi = mid;
    }
    double h = c->x[hi] - c->x[lo], t = (x - c->x[lo]) / h;
    double t2 = t * t, t3 = t2 * t;
    double y0 = c->y[lo], y1 = c->y[hi];
    double v = (2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + t) * h * c->m[lo] +
               (3 * t2 - 2 * t3) * y1 + (t3 - t2) * h * c->m[hi];
    double vmin = y0 < y1 ? y0 : y1, vmax = y0 < y1 ? y1 : y0;
    v = v < vmin ? vmin : v > vmax ? vmax : v;
    return (float)v;
}

typedef struct {
    const Curve *curve;
    const WgImage *in;
    WgImage *out;
} CurveJob;

static void curve_rows(void *user, int y0, int y1)
{
    const CurveJob *j = user;
    POINT_LOOP(j->in, j->out, y0, y1, curve_eval1(j->curve, x));
}

static int curve_check(const WgNodeContext *ctx, WgError *err)
{
    Curve c;
    return curve_parse(((const CurveParams *)ctx->params)->points, &c, err);
}

static int curve_eval(WgNodeContext *ctx, WgError *err)
{
    Curve c;
    int rc = curve_parse(((const CurveParams *)ctx->params)->points, &c, err);
    if (rc) return rc;
    CurveJob j = {&c, ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, curve_rows, &j);
}

const WgNodeType wg_node_curve = {
    .name = "curve",
    .summary = "Remap values through a smooth monotone curve of control points",
    .category = "adjust",
    .doc = "`points=\"0:0 0.3:0.1 1:1\"`: control points `x:y` separated by spaces, in any order "
           "(they are sorted by x; two points with the same x are an error), at most 256, any "
           "finite float values. Between points the curve is a cubic Hermite spline with "
           "Fritsch–Carlson tangents: m_k = (d_{k−1} + d_k)/2 where the neighbouring secant "
           "slopes d have the same sign, else 0; m_0 = d_0 and m_{n−1} = d_{n−2}; both tangents "
           "of a flat segment are 0; then for each segment with α = m_k/d_k, β = m_{k+1}/d_k and "
           "α² + β² > 9, both are scaled by 3/√(α² + β²). So each segment is monotone and stays "
           "between its end values: increasing points give a non-decreasing curve with no "
           "overshoot, and a non-monotone list has its extremes exactly at the points. Below the "
           "first point and above the last the curve is constant; one point gives a constant. "
           "Evaluated in double, rounded once to float (≤ 0.5 ulp). Applied to each colour "
           "channel; alpha is unchanged. NaN maps to the first point's y.",
    .params = curve_params,
    .params_size = sizeof(CurveParams),
    .inputs = source_in,
    .outputs = output_out,
    .flags = WG_NODE_POINT,
    .check = curve_check,
    .eval = curve_eval,
};

/* ---- clamp ------------------------------------------------------------------------------- */

typedef struct {
    float min, max;
} ClampParams;

static const WgParamSpec clamp_params[] = {
    WG_PARAM_FLOAT_UI(ClampParams, min, "Lower bound", 0.0, -1e6, 1e6, 0, 1),
    WG_PARAM_FLOAT_UI(ClampParams, max, "Upper bound", 1.0, -1e6, 1e6, 0, 1),
    WG_PARAM_END,
};

static inline float clamp1(float x, float lo, float hi)
{
    x = x > lo ? x : lo; /* NaN -> lo */
    return x < hi ? x : hi;
}

typedef struct {
    const ClampParams *p;
    const WgImage *in;
    WgImage *out;
} ClampJob;

static void clamp_rows(void *user, int y0, int y1)
{
    const ClampJob *j = user;
    float lo = j->p->min, hi = j->p->max;
    POINT_LOOP(j->in, j->out, y0, y1, clamp1(x, lo, hi));
}

static int clamp_check(const WgNodeContext *ctx, WgError *err)
{
    const ClampParams *p = ctx->params;
    if (p->min > p->max)
        return wg_error_set(err, WG_ERR_RANGE, NULL, "min %g is above max %g", p->min, p->max);
    return WG_OK;
}

static int clamp_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    ClampJob j = {ctx->params, ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, clamp_rows, &j);
}

const WgNodeType wg_node_clamp = {
    .name = "clamp",
    .summary = "Limit values to [min, max]",
    .category = "adjust",
    .doc = "min(max(x, min), max) on each colour channel; alpha is unchanged. min > max is an "
           "error; min = max gives a constant. NaN becomes min. Exact (no rounding).",
    .params = clamp_params,
    .params_size = sizeof(ClampParams),
    .inputs = source_in,
    .outputs = output_out,
    .flags = WG_NODE_POINT,
    .check = clamp_check,
    .eval = clamp_eval,
};

/* ---- threshold --------------------------------------------------------------------------- */

typedef struct {
    float position, contrast;
} ThresholdParams;

static const WgParamSpec threshold_params[] = {
    WG_PARAM_FLOAT(ThresholdParams, position, "Centre of the step", 0.5, 0.0, 1.0),
    WG_PARAM_FLOAT(ThresholdParams, contrast, "Hardness: 0 widest ramp, 1 hard step", 1.0, 0.0,
                   1.0),
    WG_PARAM_END,
};

typedef struct {
    double lo, scale; /* scale 0: hard step at lo */
    const WgImage *in;
    WgImage *out;
} ThresholdJob;

static inline float threshold1(const ThresholdJob *j, float x)
{
    if (j->scale == 0) return x >= j->lo ? 1.0f : 0.0f;
    double t = ((double)x - j->lo) * j->scale;
    return t > 0 ? (t < 1 ? (float)t : 1.0f) : 0.0f; /* NaN -> 0 */
}

static void threshold_rows(void *user, int y0, int y1)
{
    const ThresholdJob *j = user;
    POINT_LOOP(j->in, j->out, y0, y1, threshold1(j, x));
}

static int threshold_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const ThresholdParams *p = ctx->params;
    double pos = p->position, w = (1.0 - p->contrast) * fmin(pos, 1.0 - pos);
    double lo = pos - w, hi = pos + w;
    ThresholdJob j = {lo, 0, ctx->inputs[0], ctx->outputs[0]};
    if (hi > lo && isfinite(1 / (hi - lo)))
        j.scale = 1 / (hi - lo);
    else
        j.lo = pos;
    return wg_parallel_rows(ctx, j.out->height, threshold_rows, &j);
}

const WgNodeType wg_node_threshold = {
    .name = "threshold",
    .summary = "Soft step from black to white around a position (Substance's Histogram Scan)",
    .category = "adjust",
    .doc = "With p = `position` and c = `contrast`, the half-width of the ramp is "
           "w = (1 − c)·min(p, 1 − p); output = clamp((x − (p − w)) / (2w), 0, 1), computed in "
           "double and rounded once. When w = 0 (c = 1, or p = 0 or 1) it is a hard step: 1 "
           "where x ≥ p, else 0. At p = 0.5 the ramp runs from p − (1 − c)/2 to p + (1 − c)/2 "
           "(c = 0 is the identity on [0, 1]); towards the ends the window narrows so that it "
           "never leaves [0, 1]. This is exactly Substance Designer's Histogram Scan with "
           "Position = 1 − p (or Invert Position on and Position = p), except that c = 1 is a "
           "true step instead of a 10⁻⁴ wide ramp. Output is in [0, 1] (NaN maps to 0). "
           "Applied to each colour channel; alpha is unchanged.",
    .params = threshold_params,
    .params_size = sizeof(ThresholdParams),
    .inputs = source_in,
    .outputs = output_out,
    .flags = WG_NODE_POINT,
    .eval = threshold_eval,
};

/* ---- auto_levels ------------------------------------------------------------------------- */

enum { AL_LINKED, AL_PER_CHANNEL };
static const char *const auto_levels_modes[] = {"linked", "per_channel", NULL};

typedef struct {
    int mode;
} AutoLevelsParams;

static const WgParamSpec auto_levels_params[] = {
    WG_PARAM_ENUM(AutoLevelsParams, mode,
                  "Colour: one range over R, G, B (linked) or one per channel", AL_LINKED,
                  auto_levels_modes),
    WG_PARAM_END,
};

typedef struct {
    const WgImage *in;
    WgImage *out;
    int slots;              /* ranges per row: 1 (gray or linked) or 3 (per channel) */
    float *row_lo, *row_hi; /* [height * slots]; +inf/-inf when a row has no finite value */
    double lo[3], scale[3]; /* scale 0: flat, output 0.5 */
} AutoLevelsJob;

/* Eight floats as one vector (GCC and Clang vector types: AVX in the AVX2 clone, two SSE
 * registers in the baseline, plain code elsewhere). */
typedef float V8 __attribute__((vector_size(32)));
typedef int32_t I8 __attribute__((vector_size(32)));

/* mask ? a : b, lane by lane (a macro: a function returning V8 would change the baseline ABI) */
#define SELECT8(mask, a, b) ((V8)(((I8)(a) & (mask)) | ((I8)(b) & ~(mask))))

/* The smallest and largest finite values of s[0..n) (+inf and -inf when there is none), eight
 * lanes at a time: min and max do not depend on the order, but for the sign of a zero, which
 * changes no output of the node. */
HOT static void finite_range(const float *s, int n, float *lo_out, float *hi_out)
{
    const V8 inf = {INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY};
    V8 lo = inf, hi = -inf;
    int x = 0;
    for (; x + 8 <= n; x += 8) {
        V8 v;
        memcpy(&v, s + x, sizeof v);
        I8 finite = ((I8)v & 0x7fffffff) <= 0x7f7fffff; /* the bits of a finite float's |v| */
        V8 a = SELECT8(finite, v, inf), b = SELECT8(finite, v, -inf);
        lo = SELECT8(a < lo, a, lo);
        hi = SELECT8(b > hi, b, hi);
    }
    float l = INFINITY, h = -INFINITY;
    for (int k = 0; k < 8; k++) {
        l = lo[k] < l ? lo[k] : l;
        h = hi[k] > h ? hi[k] : h;
    }
    for (; x < n; x++)
        if (isfinite(s[x])) {
            l = s[x] < l ? s[x] : l;
            h = s[x] > h ? s[x] : h;
        }
    *lo_out = l, *hi_out = h;
}

static void auto_levels_measure(void *user, int y0, int y1)
{
    AutoLevelsJob *j = user;
    int c = j->in->channels, w = j->in->width, cc = c == 4 ? 3 : 1;
    if (c == 1) {
        for (int y = y0; y < y1; y++)
            finite_range(wg_image_row(j->in, y), w, &j->row_lo[y], &j->row_hi[y]);
        return;
    }
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (int x = 0; x < w; x++)
            for (int k = 0; k < cc; k++) {
                float v = s[x * c + k];
                if (!isfinite(v)) continue;
                int slot = j->slots == 1 ? 0 : k;
                if (v < lo[slot]) lo[slot] = v;
                if (v > hi[slot]) hi[slot] = v;
            }
        for (int k = 0; k < j->slots; k++) {
            j->row_lo[(size_t)y * j->slots + k] = lo[k];
            j->row_hi[(size_t)y * j->slots + k] = hi[k];
        }
    }
}

static inline float auto_levels1(const AutoLevelsJob *j, int slot, float x)
{
    if (j->scale[slot] == 0) return 0.5f;
    double t = ((double)x - j->lo[slot]) * j->scale[slot];
    return t > 0 ? (t < 1 ? (float)t : 1.0f) : 0.0f;
}

/* auto_levels1 over a gray row with a range (scale not 0), clamped before the conversion so
 * that the loop vectorises: the same values (NaN and t <= 0 give 0, t >= 1 gives 1). */
HOT static void auto_levels_row(const float *s, float *d, int n, double lo, double scale)
{
    for (int x = 0; x < n; x++) {
        double t = ((double)s[x] - lo) * scale;
        t = t > 0 ? t : 0;
        t = t < 1 ? t : 1;
        d[x] = (float)t;
    }
}

static void auto_levels_apply(void *user, int y0, int y1)
{
    const AutoLevelsJob *j = user;
    int c = j->in->channels, w = j->in->width;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d = wg_image_row(j->out, y);
        if (c == 1) {
            if (j->scale[0] == 0)
                for (int x = 0; x < w; x++) d[x] = 0.5f;
            else
                auto_levels_row(s, d, w, j->lo[0], j->scale[0]);
            continue;
        }
        for (int x = 0; x < w; x++) {
            for (int k = 0; k < 3; k++)
                d[4 * x + k] = auto_levels1(j, j->slots == 1 ? 0 : k, s[4 * x + k]);
            d[4 * x + 3] = s[4 * x + 3];
        }
    }
}

static int auto_levels_eval(WgNodeContext *ctx, WgError *err)
{
    const AutoLevelsParams *p = ctx->params;
    AutoLevelsJob j = {ctx->inputs[0], ctx->outputs[0], 1, NULL, NULL, {0}, {0}};
    if (j.in->channels == 4 && p->mode == AL_PER_CHANNEL) j.slots = 3;
    int h = j.in->height;
    j.row_lo = wg_malloc(sizeof(float) * (size_t)h * (size_t)j.slots);
    j.row_hi = wg_malloc(sizeof(float) * (size_t)h * (size_t)j.slots);
    int rc = WG_OK;
    if (!j.row_lo || !j.row_hi) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!rc) rc = wg_parallel_rows(ctx, h, auto_levels_measure, &j);
    if (!rc) {
        /* combine the rows in row order: independent of threads and chunking */
        for (int k = 0; k < j.slots; k++) {
            float lo = INFINITY, hi = -INFINITY;
            for (int y = 0; y < h; y++) {
                float a = j.row_lo[(size_t)y * j.slots + k], b = j.row_hi[(size_t)y * j.slots + k];
                if (a < lo) lo = a;
                if (b > hi) hi = b;
            }
            j.lo[k] = lo;
            j.scale[k] = hi > lo ? 1.0 / ((double)hi - (double)lo) : 0.0;
        }
        rc = wg_parallel_rows(ctx, h, auto_levels_apply, &j);
    }
    wg_free(j.row_lo);
    wg_free(j.row_hi);
    return rc;
}

const WgNodeType wg_node_auto_levels = {
    .name = "auto_levels",
    .summary = "Stretch the image's actual value range to [0, 1]",
    .category = "adjust",
    .doc = "Measures the minimum lo and maximum hi of the finite values, then outputs "
           "(x − lo)/(hi − lo), computed in double, rounded once and clamped to [0, 1] (so the "
           "minimum maps to exactly 0 and the maximum to exactly 1). A flat image (hi = lo, or "
           "no finite value) outputs 0.5 everywhere: there is no range to stretch, and 0.5 is "
           "the neutral middle. Non-finite inputs are ignored when measuring; +inf maps to 1, "
           "−inf and NaN to 0. Colour: `mode=\"linked\"` (default) measures one range over R, "
           "G and B together and applies it to all three, so neutral grays stay neutral and "
           "hues keep their order; `per_channel` stretches R, G and B independently (like an "
           "automatic white balance; a flat channel becomes 0.5). Alpha is neither measured nor "
           "changed. The range is reduced per row and the rows combined in order, so the result "
           "is bit-identical for any thread count.",
    .params = auto_levels_params,
    .params_size = sizeof(AutoLevelsParams),
    .inputs = source_in,
    .outputs = output_out,
    .flags = WG_NODE_GLOBAL,
    .eval = auto_levels_eval,
};
