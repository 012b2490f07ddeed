/* SPDX-License-Identifier: MIT */
/* `pixel`: a per-pixel expression (the equivalent of Substance's Pixel Processor). The
 * expression is compiled once per evaluation (once per group when fused: the prepare hook) by
 * nodes/pixel_compile.c into a
 * row program: constant subexpressions folded in double, row-uniform ones (y, v) computed once per
 * row, the rest run over spans of up to 256 pixels of a row, one straight loop per operation over
 * float arrays so the compiler vectorises them. Varying arithmetic is float32 (each operation
 * correctly rounded, libm's float functions within 1 ulp), so the result differs from the double
 * reference (wg_expr_eval) by float rounding: ~1e-7 relative per operation, amplified only by
 * ill-conditioned maths (cancellation, discontinuities of floor/step/comparisons, large
 * arguments of sin). sample() is bilinear, wrapping, with coordinates in double; noise() is 2D
 * gradient noise (Perlin 2002 quintic fade, 16 gradient directions from wg_hash3 of the
 * lattice point, the node's seed and the period) with an integer period, so it tiles. Division
 * by zero and other non-finite intermediates follow IEEE; the output is sanitised (NaN -> 0,
 * ±Inf -> ±FLT_MAX) unless allow_nonfinite="true". Rows are independent, so the output is
 * bit-identical for any thread count. */
#include "pixel_program.h"
#include "hot.h"

#include <float.h>
#include <ctype.h>
#include <math.h>
#include <stdatomic.h>
#include <string.h>

enum { KIND_GRAY, KIND_COLOR };
static const char *const kind_values[] = {"gray", "color", NULL};

typedef struct {
    int kind;
    const char *expr;
    bool allow_nonfinite;
} PixelParams;

static const WgParamSpec pixel_params[] = {
    WG_PARAM_ENUM(PixelParams, kind, "Output kind: gray (a number) or color (RGBA)", KIND_GRAY,
                  kind_values),
    WG_PARAM_STRING(PixelParams, expr, "Per-pixel expression", "0"),
    WG_PARAM_BOOL(PixelParams, allow_nonfinite,
                  "Write NaN and ±Inf as computed (default: NaN -> 0, ±Inf -> ±FLT_MAX)", false),
    WG_PARAM_END,
};
static const WgPortSpec pixel_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

/* ---- noise and sampling ------------------------------------------------------------------ */

uint32_t wg__px_seed(uint64_t seed)
{
    return wg_hash_u32((uint32_t)seed ^ wg_hash_u32((uint32_t)(seed >> 32) + 0x9e3779b9u));
}

/* 16 unit gradients, k * 22.5 degrees. */
static const double grad16[16][2] = {
    {1, 0},
    {0.92387953251128674, 0.38268343236508977},
    {0.70710678118654752, 0.70710678118654752},
    {0.38268343236508977, 0.92387953251128674},
    {0, 1},
    {-0.38268343236508977, 0.92387953251128674},
    {-0.70710678118654752, 0.70710678118654752},
    {-0.92387953251128674, 0.38268343236508977},
    {-1, 0},
    {-0.92387953251128674, -0.38268343236508977},
    {-0.70710678118654752, -0.70710678118654752},
    {-0.38268343236508977, -0.92387953251128674},
    {0, -1},
    {0.38268343236508977, -0.92387953251128674},
    {0.70710678118654752, -0.70710678118654752},
    {0.92387953251128674, -0.38268343236508977},
};

/* Wrap a finite coordinate into [0, period): integer cell and fraction. */
static inline void wrap_cell(double x, int period, int *cell, double *frac)
{
    if (!(x >= 0 && x < period)) {
        x = fmod(x, period); /* exact */
        if (x < 0) x += period;
    }
    double f = floor(x);
    int c = (int)f;
    *frac = x - f;
    *cell = c >= period ? c - period : c;
}

float wg__px_noise(uint32_t seed, float u, float v, float scale)
{
    if (!isfinite(u) || !isfinite(v)) return 0.5f;
    int period = scale >= 4096 ? 4096 : scale >= 1.5f ? (int)floor((double)scale + 0.5) : 1;
    int ix, iy;
    double fx, fy;
    wrap_cell((double)u * period, period, &ix, &fx);
    wrap_cell((double)v * period, period, &iy, &fy);
    int jx = ix + 1 == period ? 0 : ix + 1, jy = iy + 1 == period ? 0 : iy + 1;
    uint32_t salt = seed ^ ((uint32_t)period * 0x85ebca6bu);
    const double *g00 = grad16[wg_hash3((uint32_t)ix, (uint32_t)iy, salt) & 15];
    const double *g10 = grad16[wg_hash3((uint32_t)jx, (uint32_t)iy, salt) & 15];
    const double *g01 = grad16[wg_hash3((uint32_t)ix, (uint32_t)jy, salt) & 15];
    const double *g11 = grad16[wg_hash3((uint32_t)jx, (uint32_t)jy, salt) & 15];
    double n00 = g00[0] * fx + g00[1] * fy, n10 = g10[0] * (fx - 1) + g10[1] * fy;
    double n01 = g01[0] * fx + g01[1] * (fy - 1), n11 = g11[0] * (fx - 1) + g11[1] * (fy - 1);
    double sx = fx * fx * fx * (fx * (fx * 6 - 15) + 10);
    double sy = fy * fy * fy * (fy * (fy * 6 - 15) + 10);
    double a = n00 + (n10 - n00) * sx, b = n01 + (n11 - n01) * sx;
    /* |a + (b - a) sy| <= sqrt(2)/2 for unit gradients, so this maps onto [0, 1] */
    double r = 0.5 + (a + (b - a) * sy) * 0.70710678118654752;
    return (float)(r < 0 ? 0 : r > 1 ? 1 : r);
}

/* Bilinear, wrapping, pixel centres at (i + 0.5) / size; non-finite coordinates give 0. */
static inline float sample_one(const WgImage *img, int ch, float u, float v)
{
    if (!isfinite(u) || !isfinite(v)) return 0;
    int x0, y0;
    double tx, ty;
    wrap_cell((double)u * img->width - 0.5, img->width, &x0, &tx);
    wrap_cell((double)v * img->height - 0.5, img->height, &y0, &ty);
    int x1 = x0 + 1 == img->width ? 0 : x0 + 1, y1 = y0 + 1 == img->height ? 0 : y0 + 1;
    int c = img->channels;
    const float *r0 = wg_image_row(img, y0), *r1 = wg_image_row(img, y1);
    double a = r0[x0 * c + ch], b = r0[x1 * c + ch], d = r1[x0 * c + ch], e = r1[x1 * c + ch];
    double top = a + (b - a) * tx, bottom = d + (e - d) * tx;
    return (float)(top + (bottom - top) * ty);
}

/* ---- kernels: one straight loop per operation -------------------------------------------- */

/* Branch-free helpers. GCC with trapping maths (the C default; meson.build turns it off, as
 * errno-setting maths, which lets sqrt vectorise) will not if-convert a `?:` whose arm holds
 * float arithmetic or a conversion, and then does not vectorise the loop; blending bit patterns
 * keeps every kernel below a straight vectorisable loop whatever the flags. */
static inline uint32_t bits(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static inline float from_bits(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

/* c ? a : b, both already computed */
static inline float pick(bool c, float a, float b)
{
    uint32_t m = -(uint32_t)c;
    return from_bits((bits(a) & m) | (bits(b) & ~m));
}

/* floorf without SSE4.1's roundps: truncate through int32 where 0 < |x| < 2^23 (larger floats
 * are integers already; NaN, ±Inf and ±0 are returned as they are). Bit-identical to floorf. */
static inline float floor_f(float x)
{
    bool small = (fabsf(x) < 0x1p23f) & (x != 0);
    float xs = pick(small, x, 0.0f);
    int32_t k = (int32_t)xs;
    k -= (float)k > xs;
    return pick(small, (float)k, x);
}

/* powf without the call for the exponents 1 and 2, common where an exponent varies from a
 * neutral 1 (as a saturation does over dry pixels): powf(x, 1) is x and powf(x, 2) the correctly
 * rounded x * x, for every x, NaN included. */
static inline float pow_f(float x, float y)
{
    return y == 1 ? x : y == 2 ? x * x : powf(x, y);
}

/* floor(x + 0.5) exactly as the double evaluator gets it (in float, x + 0.5f could round up). */
static inline float round_f(float x)
{
    bool small = fabsf(x) < 0x1p23f;
    float xs = pick(small, x, 0.0f);
    int32_t k = (int32_t)xs;
    k -= (float)k > xs;
    k += xs >= (float)k + 0.5f;
    return pick(small, (float)k, x); /* ±0 give +0, as floor(±0 + 0.5) */
}

/* Kernels take operands as arrays; an operand that is constant over the span (a constant or a
 * row-uniform value) is passed as a pointer to one float, and the variant of the kernel that
 * reads it as a scalar is chosen by a mask (bit i: operand i is a scalar), so no broadcast row
 * is loaded. */
#define K1(name, expr)                                                                             \
    HOT static void name(float *restrict d, const float *restrict a, int n)                        \
    {                                                                                              \
        for (int i = 0; i < n; i++) {                                                              \
            const float x = a[i];                                                                  \
            d[i] = (expr);                                                                         \
        }                                                                                          \
    }
typedef void (*Kernel2)(float *restrict, const float *restrict, const float *restrict, int);
typedef void (*Kernel3)(float *restrict, const float *restrict, const float *restrict,
                        const float *restrict, int);
#define K2V(name, X, Y, expr)                                                                      \
    HOT static void name(float *restrict d, const float *restrict a, const float *restrict b,      \
                         int n)                                                                    \
    {                                                                                              \
        for (int i = 0; i < n; i++) {                                                              \
            const float x = X, y = Y;                                                              \
            d[i] = (expr);                                                                         \
        }                                                                                          \
    }
#define K2(name, expr)                                                                             \
    K2V(name##_vv, a[i], b[i], expr)                                                               \
    K2V(name##_sv, a[0], b[i], expr)                                                               \
    K2V(name##_vs, a[i], b[0], expr)                                                               \
    static const Kernel2 name[4] = {name##_vv, name##_sv, name##_vs, name##_vv};
#define K3V(name, X, Y, Z, expr)                                                                   \
    HOT static void name(float *restrict d, const float *restrict a, const float *restrict b,      \
                         const float *restrict c, int n)                                           \
    {                                                                                              \
        for (int i = 0; i < n; i++) {                                                              \
            const float x = X, y = Y, z = Z;                                                       \
            d[i] = (expr);                                                                         \
        }                                                                                          \
    }
#define K3(name, expr)                                                                             \
    K3V(name##_vvv, a[i], b[i], c[i], expr)                                                        \
    K3V(name##_svv, a[0], b[i], c[i], expr)                                                        \
    K3V(name##_vsv, a[i], b[0], c[i], expr)                                                        \
    K3V(name##_ssv, a[0], b[0], c[i], expr)                                                        \
    K3V(name##_vvs, a[i], b[i], c[0], expr)                                                        \
    K3V(name##_svs, a[0], b[i], c[0], expr)                                                        \
    K3V(name##_vss, a[i], b[0], c[0], expr)                                                        \
    static const Kernel3 name[8] = {name##_vvv, name##_svv, name##_vsv, name##_ssv,                \
                                    name##_vvs, name##_svs, name##_vss, name##_vvv};

static inline float smooth(float e0, float e1, float x)
{
    float t = (x - e0) / (e1 - e0);
    t = pick(t < 0, 0.0f, pick(t > 1, 1.0f, t));
    float s = t * t * (3 - 2 * t);
    return pick(e0 == e1, pick(x < e0, 0.0f, 1.0f), s); /* degenerate edges: a step */
}

/* clang-format off */
K1(k_neg, -x)
K1(k_not, x == 0 ? 1.0f : 0.0f)
K1(k_abs, fabsf(x))
K1(k_floor, floor_f(x))
K1(k_ceil, -floor_f(-x))
K1(k_fract, x - floor_f(x))
K1(k_sqrt, sqrtf(x))
K1(k_exp, expf(x))
K1(k_log, logf(x))
K1(k_sin, sinf(x))
K1(k_cos, cosf(x))
K1(k_tan, tanf(x))
K1(k_round, round_f(x))
K1(k_sign, x > 0 ? 1.0f : x < 0 ? -1.0f : 0.0f)
K1(k_asin, asinf(x))
K1(k_acos, acosf(x))
K1(k_atan, atanf(x))
K2(k_add, x + y)
K2(k_sub, x - y)
K2(k_mul, x * y)
K2(k_div, x / y)
K2(k_mod, x - y * floor_f(x / y))
K2(k_pow, pow_f(x, y))
K2(k_lt, x < y ? 1.0f : 0.0f)
K2(k_le, x <= y ? 1.0f : 0.0f)
K2(k_gt, x > y ? 1.0f : 0.0f)
K2(k_ge, x >= y ? 1.0f : 0.0f)
K2(k_eq, x == y ? 1.0f : 0.0f)
K2(k_ne, x != y ? 1.0f : 0.0f)
K2(k_and, (x != 0) & (y != 0) ? 1.0f : 0.0f)
K2(k_or, (x != 0) | (y != 0) ? 1.0f : 0.0f)
K2(k_min, y < x ? y : x) /* the order matters for NaN: as wg_expr_call */
K2(k_max, y > x ? y : x)
K2(k_step, y < x ? 0.0f : 1.0f)
K2(k_atan2, atan2f(x, y))
K3(k_clamp, x < y ? y : x > z ? z : x)
K3(k_lerp, x + (y - x) * z)
K3(k_smoothstep, smooth(x, y, z))
K3(k_select, x != 0 ? y : z)
/* clang-format on */

/* One channel of n colour pixels, s[0], s[4], ... */
HOT static void read_channel(float *restrict d, const float *restrict s, int n)
{
    for (int i = 0; i < n; i++) d[i] = s[4 * i];
}

/* ---- execution --------------------------------------------------------------------------- */

typedef struct {
    const WgPxProgram *p;
    const WgImage *const *inputs;
    WgImage *out;
    bool raw;
    atomic_int failed;
} Job;

static void run_op(const Job *j, const WgPxVal *v, float *restrict d, const float *a,
                   const float *b, const float *c, int x0, int y, int n)
{
    const WgPxProgram *p = j->p;
    switch (v->op) {
    case WG_PX_X:
        for (int i = 0; i < n; i++) d[i] = (float)(x0 + i);
        break;
    case WG_PX_U:
        for (int i = 0; i < n; i++) d[i] = (float)((x0 + i + 0.5) / p->width);
        break;
    case WG_PX_Y:
        d[0] = (float)y;
        break;
    case WG_PX_V:
        d[0] = (float)((y + 0.5) / p->height);
        break;
    case WG_PX_INPUT:
        read_channel(d, wg_image_row(j->inputs[v->input], y) + 4 * x0 + v->channel, n);
        break;
    /* clang-format off */
    case WG_PX_NEG: k_neg(d, a, n); break;
    case WG_PX_NOT: k_not(d, a, n); break;
    case WG_PX_ABS: k_abs(d, a, n); break;
    case WG_PX_FLOOR: k_floor(d, a, n); break;
    case WG_PX_CEIL: k_ceil(d, a, n); break;
    case WG_PX_FRACT: k_fract(d, a, n); break;
    case WG_PX_SQRT: k_sqrt(d, a, n); break;
    case WG_PX_EXP: k_exp(d, a, n); break;
    case WG_PX_LOG: k_log(d, a, n); break;
    case WG_PX_SIN: k_sin(d, a, n); break;
    case WG_PX_COS: k_cos(d, a, n); break;
    case WG_PX_TAN: k_tan(d, a, n); break;
    case WG_PX_ROUND: k_round(d, a, n); break;
    case WG_PX_SIGN: k_sign(d, a, n); break;
    case WG_PX_ASIN: k_asin(d, a, n); break;
    case WG_PX_ACOS: k_acos(d, a, n); break;
    case WG_PX_ATAN: k_atan(d, a, n); break;
    case WG_PX_ADD: k_add[v->scalars](d, a, b, n); break;
    case WG_PX_SUB: k_sub[v->scalars](d, a, b, n); break;
    case WG_PX_MUL: k_mul[v->scalars](d, a, b, n); break;
    case WG_PX_DIV: k_div[v->scalars](d, a, b, n); break;
    case WG_PX_MOD: k_mod[v->scalars](d, a, b, n); break;
    case WG_PX_POW: k_pow[v->scalars](d, a, b, n); break;
    case WG_PX_LT: k_lt[v->scalars](d, a, b, n); break;
    case WG_PX_LE: k_le[v->scalars](d, a, b, n); break;
    case WG_PX_GT: k_gt[v->scalars](d, a, b, n); break;
    case WG_PX_GE: k_ge[v->scalars](d, a, b, n); break;
    case WG_PX_EQ: k_eq[v->scalars](d, a, b, n); break;
    case WG_PX_NE: k_ne[v->scalars](d, a, b, n); break;
    case WG_PX_AND: k_and[v->scalars](d, a, b, n); break;
    case WG_PX_OR: k_or[v->scalars](d, a, b, n); break;
    case WG_PX_MIN: k_min[v->scalars](d, a, b, n); break;
    case WG_PX_MAX: k_max[v->scalars](d, a, b, n); break;
    case WG_PX_STEP: k_step[v->scalars](d, a, b, n); break;
    case WG_PX_ATAN2: k_atan2[v->scalars](d, a, b, n); break;
    case WG_PX_CLAMP: k_clamp[v->scalars](d, a, b, c, n); break;
    case WG_PX_LERP: k_lerp[v->scalars](d, a, b, c, n); break;
    case WG_PX_SMOOTHSTEP: k_smoothstep[v->scalars](d, a, b, c, n); break;
    case WG_PX_SELECT: k_select[v->scalars](d, a, b, c, n); break;
    /* clang-format on */
    case WG_PX_SAMPLE: {
        const WgImage *img = j->inputs[v->input];
        for (int i = 0; i < n; i++) d[i] = sample_one(img, v->channel, a[i], b[i]);
        break;
    }
    case WG_PX_NOISE:
        for (int i = 0; i < n; i++) d[i] = wg__px_noise(p->seed, a[i], b[i], c[i]);
        break;
    case WG_PX_CONST:
    case WG_PX_COUNT_:
        break;
    }
}

static inline float clean(float v)
{
    return v != v ? 0.0f : v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v;
}

HOT static void write_gray(float *restrict d, const float *restrict s, int n, bool raw)
{
    if (raw)
        memcpy(d, s, sizeof(float) * (size_t)n);
    else
        for (int i = 0; i < n; i++) d[i] = clean(s[i]);
}

HOT static void write_color(float *restrict d, const float *restrict r, const float *restrict g,
                            const float *restrict b, const float *restrict a, int n, bool raw)
{
    if (raw) {
        for (int i = 0; i < n; i++) {
            d[4 * i] = r[i];
            d[4 * i + 1] = g[i];
            d[4 * i + 2] = b[i];
            d[4 * i + 3] = a[i];
        }
        return;
    }
    for (int i = 0; i < n; i++) {
        d[4 * i] = clean(r[i]);
        d[4 * i + 1] = clean(g[i]);
        d[4 * i + 2] = clean(b[i]);
        d[4 * i + 3] = clean(a[i]);
    }
}

static void fill(float *d, float v, int n)
{
    for (int i = 0; i < n; i++) d[i] = v;
}

static void pixel_rows(void *user, int y0, int y1)
{
    Job *j = user;
    const WgPxProgram *p = j->p;
    enum { L = WG_PX_LANES };
    size_t floats = (size_t)L * (size_t)(p->n_regs + p->n_bcast) + (size_t)p->n_vals + 1;
    float *mem = wg_malloc(sizeof(float) * floats);
    const float **ptr = wg_calloc((size_t)p->n_vals + 1, sizeof(float *));
    if (!mem || !ptr) {
        atomic_store(&j->failed, 1);
        wg_free(mem);
        wg_free(ptr);
        return;
    }
    float *regs = mem, *bc = regs + (size_t)L * p->n_regs, *sc = bc + (size_t)L * p->n_bcast;
    for (int s = 0; s < p->n_consts; s++) {
        const WgPxVal *v = &p->vals[p->consts[s]];
        sc[p->consts[s]] = (float)v->value;
        if (v->bcast >= 0) fill(bc + (size_t)L * v->bcast, (float)v->value, L);
    }
    for (int i = 0; i < p->n_vals; i++)
        if (p->vals[i].bcast >= 0) ptr[i] = bc + (size_t)L * p->vals[i].bcast;
    WgImage *out = j->out;
    int nc = out->channels;
    for (int y = y0; y < y1; y++) {
        for (int s = 0; s < p->n_uniform; s++) {
            int id = p->uniform[s];
            const WgPxVal *v = &p->vals[id];
            run_op(j, v, &sc[id], &sc[v->args[0]], &sc[v->args[1]], &sc[v->args[2]], 0, y, 1);
            if (v->bcast >= 0) fill(bc + (size_t)L * v->bcast, sc[id], L);
        }
        float *o = wg_image_row(out, y);
        for (int x0 = 0; x0 < p->width; x0 += L) {
            int n = p->width - x0 < L ? p->width - x0 : L;
            for (int s = 0; s < p->n_varying; s++) {
                int id = p->varying[s];
                const WgPxVal *v = &p->vals[id];
                if (v->reg < 0) { /* gray input: read in place */
                    ptr[id] = wg_image_row(j->inputs[v->input], y) + x0;
                    continue;
                }
                float *d = regs + (size_t)L * v->reg;
                const float *a[3];
                for (int q = 0; q < 3; q++)
                    a[q] = v->scalars >> q & 1 ? &sc[v->args[q]] : ptr[v->args[q]];
                run_op(j, v, d, a[0], a[1], a[2], x0, y, n);
                ptr[id] = d;
            }
            if (nc == 1)
                write_gray(o + x0, ptr[p->out[0]], n, j->raw);
            else
                write_color(o + (size_t)x0 * 4, ptr[p->out[0]], ptr[p->out[1]], ptr[p->out[2]],
                            ptr[p->out[3]], n, j->raw);
        }
    }
    wg_free(mem);
    wg_free(ptr);
}

/* ---- the node ---------------------------------------------------------------------------- */

static int pixel_channels(const WgNodeContext *ctx, int port)
{
    (void)port;
    const PixelParams *pp = ctx->params;
    return pp->kind == KIND_COLOR ? 4 : 1;
}

static int pixel_check(const WgNodeContext *ctx, WgError *err)
{
    const PixelParams *pp = ctx->params;
    WgPxProgram *p = NULL;
    int rc = wg__px_compile(ctx, pp->expr, pixel_channels(ctx, 0), NULL, &p, err);
    wg__px_free(p);
    return rc;
}

/* A program compiled once for every band of a fused evaluation, with the input channels it
 * was compiled for. */
typedef struct {
    WgPxProgram *p;
    int n_inputs;
    int channels[];
} Prepared;

/* Channels of each input as eval sees them: an unconnected one reads as gray. */
static void input_channels(const WgNodeContext *ctx, int *channels)
{
    for (int i = 0; i < ctx->n_inputs; i++)
        channels[i] = ctx->inputs                  ? (ctx->inputs[i] ? ctx->inputs[i]->channels : 1)
                      : ctx->input_channels[i] > 0 ? ctx->input_channels[i]
                                                   : 1;
}

static int pixel_prepare(const WgNodeContext *ctx, void **state, WgError *err)
{
    const PixelParams *pp = ctx->params;
    Prepared *s = wg_calloc(1, sizeof *s + sizeof(int) * ((size_t)ctx->n_inputs + 1));
    if (!s) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    s->n_inputs = ctx->n_inputs;
    input_channels(ctx, s->channels);
    int rc = wg__px_compile(ctx, pp->expr, pixel_channels(ctx, 0), s->channels, &s->p, err);
    if (rc) {
        wg_free(s);
        return rc;
    }
    *state = s;
    return WG_OK;
}

static void pixel_finish(void *state)
{
    Prepared *s = state;
    if (!s) return;
    wg__px_free(s->p);
    wg_free(s);
}

static int pixel_eval(WgNodeContext *ctx, WgError *err)
{
    const PixelParams *pp = ctx->params;
    int *channels = wg_calloc((size_t)ctx->n_inputs + 1, sizeof(int));
    if (!channels) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    input_channels(ctx, channels);
    /* a band of a fused group: the program prepare compiled, if the inputs are as it assumed */
    const Prepared *pre = ctx->prepared;
    WgPxProgram *p = NULL;
    int rc = WG_OK;
    if (pre && pre->n_inputs == ctx->n_inputs &&
        pre->p->out_channels == ctx->outputs[0]->channels &&
        !memcmp(pre->channels, channels, sizeof(int) * (size_t)ctx->n_inputs))
        p = pre->p;
    else
        rc = wg__px_compile(ctx, pp->expr, ctx->outputs[0]->channels, channels, &p, err);
    wg_free(channels);
    if (rc) return rc;
    Job j = {.p = p, .inputs = ctx->inputs, .out = ctx->outputs[0], .raw = pp->allow_nonfinite};
    atomic_init(&j.failed, 0);
    rc = wg_parallel_rows(ctx, j.out->height, pixel_rows, &j);
    if (!rc && atomic_load(&j.failed)) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!pre || p != pre->p) wg__px_free(p);
    return rc;
}

/* Does `expr` contain `name` as a whole token? Names are letters, digits and _ (with a leading
 * $ for $time and its kin), so this finds every use; a name that also appears as a channel
 * (c.r) or hidden by an input only costs a recomputation. $time enters the node through here,
 * so a pixel node whose expression does not read $time is computed once per frame sequence. */
static bool pixel_uses_scope_name(const void *params, const char *name)
{
    const char *e = ((const PixelParams *)params)->expr;
    size_t n = strlen(name);
    if (!e || !n) return false;
    for (const char *p = strstr(e, name); p; p = strstr(p + 1, name)) {
        char before = p > e ? p[-1] : ' ', after = p[n];
        bool word_before = isalnum((unsigned char)before) || before == '_' || before == '$';
        bool word_after = isalnum((unsigned char)after) || after == '_';
        if (!word_before && !word_after) return true;
    }
    return false;
}

/* A pixel expression is a point operation unless it reads the row (y, v, $height: the band
 * has its own height) or other pixels (sample): only then does it need the whole image. noise()
 * hashes coordinates the expression computes, so it is fine without v. Everything else the
 * program compiles from (inputs, extras, scope, seed, the width) is the same for a band. A
 * name that only hides one of these (an input called v) just forgoes fusion. */
static bool pixel_banded(const void *params)
{
    static const char *const row_names[] = {"y", "v", "$height", "sample"};
    for (size_t i = 0; i < sizeof row_names / sizeof *row_names; i++)
        if (pixel_uses_scope_name(params, row_names[i])) return false;
    return true;
}

const WgNodeType wg_node_pixel = {
    .name = "pixel",
    .summary = "Per-pixel expression over any number of named inputs (Pixel Processor)",
    .category = "pixel",
    .doc = "`expr` is computed at every pixel with the language of `=...` attributes "
           "(docs/format.md) plus pixel functions.\n\n"
           "**Names** are looked up in this order, the first match wins: (1) the inputs, by their "
           "`<in name>`: a gray input is its value at this pixel, a colour input is a colour and "
           "`name.r`, `name.g`, `name.b`, `name.a` are its channels; (2) the node's extra numeric "
           "attributes (any attribute that is not `kind`, `expr`, `allow_nonfinite` or a reserved "
           "one, e.g. `freq=\"3\"` or `freq=\"=2*scale\"`); (3) the graph's numeric parameters "
           "(float, int, bool as 0/1, enum as its index) and `$time`, `$seed`, `$width`, "
           "`$height` (this node's size); (4) `u`, `v` (the pixel centre, (x + 0.5)/width and "
           "(y + 0.5)/height, in [0,1)) and `x`, `y` (the integer pixel indices). So an input "
           "named `v` hides the coordinate v, an extra attribute hides a graph parameter of the "
           "same name, and a graph parameter named `u` hides u.\n\n"
           "**Statements**: `expr` may start with definitions, `name = expression;`, each "
           "usable by the ones after it and by the result, which comes last: `d = max(wh - h, "
           "0); k = exp(-d * absorb); base * k + tint * (1 - k)`. A name may be a number or a "
           "colour; it must not already name an input, an extra attribute, a graph parameter, "
           "a coordinate or an earlier definition. Writing a subexpression once this way gives "
           "the same pixels as writing it out wherever it is used. Error columns count in the "
           "whole `expr`.\n\n"
           "**Functions**: those of parameter expressions (abs min max clamp lerp/mix smoothstep "
           "step floor ceil fract mod sqrt pow exp log sin cos tan asin acos atan atan2 round "
           "sign) and: `sample(input, u, v)`, the input bilinearly interpolated at (u, v) with "
           "wrapping (pixel centres at (i + 0.5)/size; non-finite coordinates give 0); the first "
           "argument must be an input name (a colour input gives a colour) or one channel of a "
           "colour input (`sample(c.g, u, v)`, a number). `noise(u, v, scale)`: 2D gradient "
           "noise (Perlin's, quintic fade, 16 gradient directions hashed from the lattice point, "
           "the node's seed and the period) in [0,1], 0.5 on lattice points, with round(scale) "
           "cells per unit (1 to 4096; NaN counts as 1), periodic with period 1 in u and v so "
           "`noise(u, v, 8)` tiles; deterministic, it changes with the node's seed; non-finite "
           "u or v give 0.5. `rgb(r, g, b)` (alpha 1) and `rgba(r, g, b, a)` build colours.\n\n"
           "**Types**: every subexpression is a number or a colour. Arithmetic, unary minus and "
           "the maths functions work per channel on colours, a number being used for all four "
           "channels (`c * 0.5` halves alpha too; `rgb(...)` keeps alpha 1). Comparisons, `!`, "
           "`&&`, `||`, the condition of `?:`, the arguments of rgb(), rgba(), noise() and the "
           "coordinates of sample() need numbers; both branches of `?:` must have the same type. "
           "With kind=\"gray\" the expression must give a number; with kind=\"color\" a colour, "
           "or a number, written as gray (n, n, n, 1). Unknown names, wrong argument counts and "
           "type errors are reported when the graph is checked (`wetgraph check`), with the "
           "column in `expr`.\n\n"
           "**Precision**: constant subexpressions (numbers, extras, graph parameters, $time) are "
           "folded in double exactly as parameter expressions are, then rounded to float once; "
           "everything that varies per pixel is float32 (IEEE operations, single-precision libm "
           "functions), so results match the double evaluation up to float rounding: random "
           "expressions agree within 2e-6·(1 + S), S the largest intermediate magnitude (seen: "
           "2e-7·(1 + S)), except across cancellations and at the jumps of floor, step, mod, "
           "comparisons. Large values lose absolute precision as floats do: sin(1000 + x) is "
           "off by up to ~6e-5, mod(x, y) and fract(x) degrade beyond |x/y| ~ 2^20, "
           "intermediates overflow to ±inf beyond 3.4e38. sample() and noise() compute their "
           "coordinates in double.\n\n"
           "**Non-finite values**: division by zero and other invalid operations follow IEEE "
           "inside the expression (1/0 = inf, 0/0 = NaN, comparisons with NaN are false, NaN "
           "counts as true in `?:`, `&&` and `||`, clamp(NaN, a, b) = NaN); the written result is "
           "sanitised, NaN -> 0 and ±Inf -> ±FLT_MAX, unless `allow_nonfinite=\"true\"`.\n\n"
           "Compiled once per evaluation into a row program: constant folding, row-uniform parts "
           "(y, v) computed once per row, shared subexpressions, then one straight vectorisable "
           "loop per operation over spans of 256 pixels.\n\n"
           "**Fusion**: an expression that does not read `y`, `v` or `$height` and does not use "
           "sample() computes each pixel from the same pixel of its inputs: it is a point "
           "operation and is fused with the point operations around it, evaluated a band of rows "
           "at a time (docs/engine.md; compiled once for all the bands), bit-identical to the node "
           "run "
           "alone. Otherwise (sample() reads anywhere in its input) it runs alone.",
    .params = pixel_params,
    .params_size = sizeof(PixelParams),
    .outputs = pixel_out,
    .flags = WG_NODE_GLOBAL | WG_NODE_DYNAMIC_INPUTS | WG_NODE_EXTRA_PARAMS | WG_NODE_SCOPED |
             WG_NODE_SEEDED,
    .output_channels = pixel_channels,
    .check = pixel_check,
    .eval = pixel_eval,
    .uses_scope_name = pixel_uses_scope_name,
    .banded = pixel_banded,
    .prepare = pixel_prepare,
    .finish = pixel_finish,
};
