/* SPDX-License-Identifier: MIT */
/* Colour nodes: `gradient_map` (gray to colour through colour keys), `hsl` (hue, saturation and
 * lightness shifts), `colorspace` (sRGB transfer function, IEC 61966-2-1), and channel plumbing:
 * `split`, `merge`, `shuffle`.
 *
 * Colours written in parameters follow the engine's colour values: `#rgb`, `#rrggbb`,
 * `#rrggbbaa` are sRGB and decoded to linear (alpha stays as written), numbers are linear. All
 * interpolation happens on linear values. `hsl` works on the sRGB-encoded values, as Photoshop
 * and Substance do on 8-bit textures, so its sliders move in perceptual steps; see its doc for
 * the exact model. Everything is computed in double and rounded once to float. */
#include "wetgraph/node.h"

#include <ctype.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static inline double clamp01(double v)
{
    return v > 0 ? (v < 1 ? v : 1) : 0; /* NaN -> 0 */
}

/* ---- gradient_map ------------------------------------------------------------------------ */

#define GRADIENT_MAX_KEYS 256

enum { GM_LINEAR, GM_SMOOTH };
static const char *const gm_interpolations[] = {"linear", "smooth", NULL};

typedef struct {
    const char *keys;
    int interpolation;
} GradientMapParams;

static const WgParamSpec gradient_map_params[] = {
    WG_PARAM_STRING(GradientMapParams, keys, "Colour keys 'position:colour ...'",
                    "0:#000000 1:#ffffff"),
    WG_PARAM_ENUM(GradientMapParams, interpolation, "Between keys", GM_LINEAR, gm_interpolations),
    WG_PARAM_END,
};
static const WgPortSpec gray_source_in[] = {WG_PORT("source", WG_GRAY), WG_PORT_END};
static const WgPortSpec color_out[] = {WG_PORT("output", WG_COLOR), WG_PORT_END};

typedef struct {
    int n;
    double pos[GRADIENT_MAX_KEYS];
    double rgba[GRADIENT_MAX_KEYS][4];
} Gradient;

static bool number(const char *s, const char *end, double *out)
{
    char buf[64];
    size_t len = (size_t)(end - s);
    if (len == 0 || len >= sizeof buf) return false;
    memcpy(buf, s, len);
    buf[len] = '\0';
    return wg_parse_number(buf, out) && fabs(*out) <= FLT_MAX;
}

static int hex_digit(int c)
{
    if (c >= '0' && c <= '9') return c - '0';
    c = tolower(c);
    return c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
}

/* A colour in [s, end): #rgb, #rgba, #rrggbb, #rrggbbaa (sRGB, decoded to linear) or 1, 3 or 4
 * numbers separated by commas (linear). The same rules as the engine's colour values. */
static bool parse_color(const char *s, const char *end, double out[4])
{
    if (s < end && *s == '#') {
        s++;
        int n = (int)(end - s);
        int digits = (n == 3 || n == 4) ? 1 : (n == 6 || n == 8) ? 2 : 0;
        if (!digits) return false;
        double c[4] = {0, 0, 0, 1};
        for (int i = 0; i < n / digits; i++) {
            int v = 0;
            for (int k = 0; k < digits; k++) {
                int d = hex_digit((unsigned char)s[i * digits + k]);
                if (d < 0) return false;
                v = v * 16 + d;
            }
            if (digits == 1) v *= 17;
            c[i] = (float)v / 255.0f;
        }
        for (int i = 0; i < 3; i++) out[i] = wg_srgb_to_linear((float)c[i]);
        out[3] = (float)c[3];
        return true;
    }
    double v[4];
    int n = 0;
    const char *p = s;
    for (;;) {
        const char *comma = memchr(p, ',', (size_t)(end - p));
        const char *e = comma ? comma : end;
        if (n == 4 || !number(p, e, &v[n])) return false;
        v[n] = (float)v[n]; /* as precise as the engine's colour values */
        n++;
        if (!comma) break;
        p = comma + 1;
    }
    if (n == 2) return false;
    if (n == 1) v[1] = v[2] = v[0];
    if (n < 4) v[3] = 1;
    memcpy(out, v, sizeof v);
    return true;
}

static int gradient_parse(const char *text, Gradient *g, WgError *err)
{
    g->n = 0;
    const char *p = text ? text : "";
    for (;;) {
        while (isspace((unsigned char)*p)) p++;
        if (!*p) break;
        const char *tok = p;
        while (*p && !isspace((unsigned char)*p)) p++;
        int len = (int)(p - tok);
        if (g->n == GRADIENT_MAX_KEYS)
            return wg_error_set(err, WG_ERR_RANGE, NULL, "keys: more than %d keys",
                                GRADIENT_MAX_KEYS);
        const char *colon = memchr(tok, ':', (size_t)len);
        double pos, c[4];
        if (!colon || !number(tok, colon, &pos))
            return wg_error_set(err, WG_ERR_PARSE, NULL,
                                "keys: key %d '%.*s' is not 'position:colour' (e.g. "
                                "\"0:#1a1a1a 0.5:#804020 1:#ffffff\", keys separated by spaces)",
                                g->n + 1, len, tok);
        if (!parse_color(colon + 1, p, c))
            return wg_error_set(err, WG_ERR_PARSE, NULL,
                                "keys: key %d '%.*s' has a bad colour '%.*s' (#rgb, #rrggbb, "
                                "#rrggbbaa, or 1, 3 or 4 numbers joined by commas)",
                                g->n + 1, len, tok, (int)(p - colon - 1), colon + 1);
        /* stable insertion sort: keys at the same position keep their order (a hard edge) */
        int k = g->n;
        while (k > 0 && g->pos[k - 1] > pos) {
            g->pos[k] = g->pos[k - 1];
            memcpy(g->rgba[k], g->rgba[k - 1], sizeof g->rgba[k]);
            k--;
        }
        g->pos[k] = pos;
        memcpy(g->rgba[k], c, sizeof c);
        g->n++;
    }
    if (g->n == 0)
        return wg_error_set(err, WG_ERR_PARSE, NULL,
                            "keys: needs at least one key 'position:colour', e.g. "
                            "\"0:#000000 1:#ffffff\"");
    return WG_OK;
}

typedef struct {
    const Gradient *g;
    bool smooth;
    const WgImage *in;
    WgImage *out;
} GradientJob;

static inline void gradient_eval1(const Gradient *g, bool smooth, float xf, float *o)
{
    double x = xf;
    int n = g->n;
    const double *c;
    if (!(x >= g->pos[0]))
        c = g->rgba[0]; /* also NaN */
    else if (x >= g->pos[n - 1])
        c = g->rgba[n - 1];
    else {
        int lo = 0, hi = n - 1; /* pos[lo] <= x < pos[hi] */
        while (hi - lo > 1) {
            int mid = (lo + hi) / 2;
            if (g->pos[mid] <= x)
                lo = mid;
            else
                hi = mid;
        }
        double t = (x - g->pos[lo]) / (g->pos[hi] - g->pos[lo]);
        if (smooth) t = t * t * (3 - 2 * t);
        const double *a = g->rgba[lo], *b = g->rgba[hi];
        for (int k = 0; k < 4; k++) o[k] = (float)(a[k] + (b[k] - a[k]) * t);
        return;
    }
    for (int k = 0; k < 4; k++) o[k] = (float)c[k];
}

static void gradient_rows(void *user, int y0, int y1)
{
    const GradientJob *j = user;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d = wg_image_row(j->out, y);
        for (int x = 0; x < j->out->width; x++) gradient_eval1(j->g, j->smooth, s[x], d + 4 * x);
    }
}

static int gradient_map_check(const WgNodeContext *ctx, WgError *err)
{
    Gradient g;
    return gradient_parse(((const GradientMapParams *)ctx->params)->keys, &g, err);
}

static int gradient_map_eval(WgNodeContext *ctx, WgError *err)
{
    const GradientMapParams *p = ctx->params;
    Gradient g;
    int rc = gradient_parse(p->keys, &g, err);
    if (rc) return rc;
    GradientJob j = {&g, p->interpolation == GM_SMOOTH, ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, gradient_rows, &j);
}

const WgNodeType wg_node_gradient_map = {
    .name = "gradient_map",
    .summary = "Colour a gray image through a gradient of colour keys",
    .category = "color",
    .doc = "`keys=\"0:#1a1a1a 0.5:#804020 1:#ffffff\"`: keys `position:colour` separated by "
           "spaces, in any order (sorted by position, at most 256). A colour is `#rgb`, `#rgba`, "
           "`#rrggbb` or `#rrggbbaa` (sRGB, decoded to linear like every colour value; alpha as "
           "written) or 1, 3 or 4 linear numbers joined by commas (`0.5:0.2,0.1,0.05`). Between "
           "the keys a and b around x, with t = (x − pos_a)/(pos_b − pos_a), the output is "
           "a + (b − a)·s(t) on linear R, G, B, A, where s(t) = t for `linear` and "
           "s(t) = t²(3 − 2t) (smoothstep: zero slope at each key) for `smooth`; both stay "
           "between the two key colours (no overshoot). Below the first key and above the last "
           "the colour is constant; one key gives a constant. Two keys at the same position make "
           "a hard edge: the earlier key's colour below it, the later one from it on. NaN takes "
           "the first colour. Computed in double, rounded once to float.",
    .params = gradient_map_params,
    .params_size = sizeof(GradientMapParams),
    .inputs = gray_source_in,
    .outputs = color_out,
    .flags = WG_NODE_POINT,
    .check = gradient_map_check,
    .eval = gradient_map_eval,
};

/* ---- hsl --------------------------------------------------------------------------------- */

typedef struct {
    float hue, saturation, lightness;
} HslParams;

static const WgParamSpec hsl_params[] = {
    WG_PARAM_FLOAT_UI(HslParams, hue, "Hue shift in turns (wraps; 1/3 turns red to green)", 0.0,
                      -1.0, 1.0, -0.5, 0.5),
    WG_PARAM_FLOAT(HslParams, saturation, "Saturation shift (-1 gray, 1 fully saturated)", 0.0,
                   -1.0, 1.0),
    WG_PARAM_FLOAT(HslParams, lightness, "Lightness shift (-1 black, 1 white)", 0.0, -1.0, 1.0),
    WG_PARAM_END,
};
static const WgPortSpec color_source_in[] = {WG_PORT("source", WG_COLOR), WG_PORT_END};

/* The IEC 61966-2-1 curves of wg_linear_to_srgb / wg_srgb_to_linear, kept in double: HSL is
 * ill-conditioned near black and white (S divides by min(L, 1 - L)), so a float rounding of the
 * encoded values would be amplified there. */
static double encode_d(double v)
{
    if (!(v > 0)) return 0; /* also NaN */
    double e = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
    return e < 1 ? e : 1;
}

static double decode_d(double e)
{
    return e <= 0.04045 ? e / 12.92 : pow((e + 0.055) / 1.055, 2.4);
}

/* e: sRGB-encoded RGB in [0,1], shifted in place. */
static void hsl_shift(double e[3], double dh, double ds, double dl)
{
    double r = e[0], g = e[1], b = e[2];
    double mx = fmax(r, fmax(g, b)), mn = fmin(r, fmin(g, b));
    double c = mx - mn, l = 0.5 * (mx + mn), h = 0, s = 0;
    if (c > 0) {
        s = c / (1 - fabs(2 * l - 1));
        if (mx == r)
            h = (g - b) / c;
        else if (mx == g)
            h = (b - r) / c + 2;
        else
            h = (r - g) / c + 4;
        h /= 6;
    }
    h += dh;
    h -= floor(h);
    if (!(h < 1)) h = 0; /* -tiny - floor(-tiny) rounds up to 1 */
    if (ds <= 0)
        s *= 1 + ds;
    else if (ds >= 1)
        s = s > 0 ? 1 : 0;
    else
        s = fmin(1, s / (1 - ds));
    if (dl <= 0)
        l *= 1 + dl;
    else
        l += (1 - l) * dl;
    double cc = (1 - fabs(2 * l - 1)) * s, hp = h * 6;
    double x = cc * (1 - fabs(fmod(hp, 2) - 1)), m = l - 0.5 * cc;
    double rgb[3];
    switch ((int)hp) {
    case 0:
        rgb[0] = cc, rgb[1] = x, rgb[2] = 0;
        break;
    case 1:
        rgb[0] = x, rgb[1] = cc, rgb[2] = 0;
        break;
    case 2:
        rgb[0] = 0, rgb[1] = cc, rgb[2] = x;
        break;
    case 3:
        rgb[0] = 0, rgb[1] = x, rgb[2] = cc;
        break;
    case 4:
        rgb[0] = x, rgb[1] = 0, rgb[2] = cc;
        break;
    default:
        rgb[0] = cc, rgb[1] = 0, rgb[2] = x;
        break;
    }
    for (int k = 0; k < 3; k++) e[k] = clamp01(rgb[k] + m);
}

typedef struct {
    const HslParams *p;
    const WgImage *in;
    WgImage *out;
} HslJob;

static void hsl_rows(void *user, int y0, int y1)
{
    const HslJob *j = user;
    const HslParams *p = j->p;
    bool identity = p->hue == 0 && p->saturation == 0 && p->lightness == 0;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d = wg_image_row(j->out, y);
        if (identity) {
            memcpy(d, s, sizeof(float) * 4 * (size_t)j->out->width);
            continue;
        }
        for (int x = 0; x < j->out->width; x++) {
            double e[3];
            for (int k = 0; k < 3; k++) e[k] = encode_d(s[4 * x + k]);
            hsl_shift(e, p->hue, p->saturation, p->lightness);
            for (int k = 0; k < 3; k++) d[4 * x + k] = (float)decode_d(e[k]);
            d[4 * x + 3] = s[4 * x + 3];
        }
    }
}

static int hsl_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    HslJob j = {ctx->params, ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, hsl_rows, &j);
}

const WgNodeType wg_node_hsl = {
    .name = "hsl",
    .summary = "Shift hue, saturation and lightness",
    .category = "color",
    .doc = "Works in HSL on the sRGB-encoded values (the numbers an artist sees in a picture "
           "editor): each linear channel is encoded with the IEC 61966-2-1 curve and clipped to "
           "[0, 1], converted to HSL (hexcone hue H in turns, L = (max + min)/2, "
           "S = (max − min)/(1 − |2L − 1|); grays have H = S = 0), shifted, converted back and "
           "decoded to linear. Shifts: H' = frac(H + `hue`) (wraps); `saturation` s ≤ 0 scales "
           "S' = S·(1 + s), s > 0 gives S' = min(1, S/(1 − s)) (s = 1: any non-gray colour "
           "fully saturated); `lightness` l ≤ 0 gives L' = L·(1 + l), l > 0 gives "
           "L' = L + (1 − L)·l (l = ±1: white or black). Unlike Substance's HSL node (additive S "
           "and L), grays stay gray under any saturation shift and every shift is continuous. "
           "All zero is exactly the identity (a copy, values outside [0, 1] included); any "
           "other setting clips the input to [0, 1] and gives output in [0, 1]. Computed in "
           "double throughout (the sRGB curves too: HSL is ill-conditioned near black and white) "
           "and rounded once to float, so the result is within 10⁻⁷ of the float64 model; a hue "
           "shift of ±1, or +0.5 twice, returns the input within 2·10⁻⁷. Gray inputs are "
           "promoted to colour; alpha is unchanged. NaN channels count as 0.",
    .params = hsl_params,
    .params_size = sizeof(HslParams),
    .inputs = color_source_in,
    .outputs = color_out,
    .flags = WG_NODE_POINT,
    .eval = hsl_eval,
};

/* ---- colorspace -------------------------------------------------------------------------- */

enum { CS_TO_LINEAR, CS_TO_SRGB };
static const char *const cs_directions[] = {"to_linear", "to_srgb", NULL};

typedef struct {
    int direction;
} ColorspaceParams;

static const WgParamSpec colorspace_params[] = {
    WG_PARAM_ENUM(ColorspaceParams, direction, "sRGB-encoded to linear, or linear to sRGB",
                  CS_TO_LINEAR, cs_directions),
    WG_PARAM_END,
};
static const WgPortSpec any_source_in[] = {WG_PORT("source", WG_ANY), WG_PORT_END};
static const WgPortSpec any_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

typedef struct {
    bool to_srgb;
    const WgImage *in;
    WgImage *out;
} ColorspaceJob;

static inline float finite_or_max(float v)
{
    return isinf(v) ? copysignf(FLT_MAX, v) : v;
}

static void colorspace_rows(void *user, int y0, int y1)
{
    const ColorspaceJob *j = user;
    int c = j->in->channels;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d = wg_image_row(j->out, y);
        for (int i = 0; i < j->in->width * c; i++) {
            float x = s[i];
            if (c == 4 && (i & 3) == 3)
                d[i] = x;
            else if (x != x)
                d[i] = 0;
            else
                d[i] = finite_or_max(j->to_srgb ? wg_linear_to_srgb(x) : wg_srgb_to_linear(x));
        }
    }
}

static int colorspace_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const ColorspaceParams *p = ctx->params;
    ColorspaceJob j = {p->direction == CS_TO_SRGB, ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, colorspace_rows, &j);
}

const WgNodeType wg_node_colorspace = {
    .name = "colorspace",
    .summary = "Convert between sRGB-encoded and linear values",
    .category = "color",
    .doc = "The IEC 61966-2-1 transfer functions, evaluated in double and rounded once to "
           "float. `to_linear`: v ≤ 0.04045 ? v/12.92 : ((v + 0.055)/1.055)^2.4 (negative values "
           "follow the linear segment). `to_srgb`: v ≤ 0 ? 0 : v ≤ 0.0031308 ? 12.92·v : "
           "1.055·v^(1/2.4) − 0.055 (negative values become 0). Values above 1 follow the power "
           "segment; results beyond the float range saturate at ±FLT_MAX, NaN becomes 0. "
           "Round trip: to_linear(to_srgb(v)) is within 2·10⁻⁷·v (relative) of v for v in "
           "[0, 1]. Applied to the colour channels of colour images and to the value of gray "
           "ones; alpha is unchanged.",
    .params = colorspace_params,
    .params_size = sizeof(ColorspaceParams),
    .inputs = any_source_in,
    .outputs = any_out,
    .flags = WG_NODE_POINT,
    .eval = colorspace_eval,
};

/* ---- split ------------------------------------------------------------------------------- */

static const WgPortSpec split_out[] = {
    WG_PORT("r", WG_GRAY), WG_PORT("g", WG_GRAY), WG_PORT("b", WG_GRAY),
    WG_PORT("a", WG_GRAY), WG_PORT_END,
};

typedef struct {
    const WgImage *in;
    WgImage *const *out;
} SplitJob;

static void split_rows(void *user, int y0, int y1)
{
    const SplitJob *j = user;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d[4];
        for (int k = 0; k < 4; k++) d[k] = wg_image_row(j->out[k], y);
        for (int x = 0; x < j->in->width; x++)
            for (int k = 0; k < 4; k++) d[k][x] = s[4 * x + k];
    }
}

static int split_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    SplitJob j = {ctx->inputs[0], ctx->outputs};
    return wg_parallel_rows(ctx, ctx->outputs[0]->height, split_rows, &j);
}

const WgNodeType wg_node_split = {
    .name = "split",
    .summary = "Colour to four gray images: r, g, b, a",
    .category = "color",
    .doc = "Exact copies of the channels. A gray input is promoted first (r = g = b = value, "
           "a = 1). Refer to an output as `node.r`, `node.g`, `node.b`, `node.a`.",
    .inputs = color_source_in,
    .outputs = split_out,
    .flags = WG_NODE_POINT,
    .eval = split_eval,
};

/* ---- merge ------------------------------------------------------------------------------- */

typedef struct {
    float r, g, b, a;
} MergeParams;

static const WgParamSpec merge_params[] = {
    WG_PARAM_FLOAT_UI(MergeParams, r, "R where input r is not connected", 0.0, -1e6, 1e6, 0, 1),
    WG_PARAM_FLOAT_UI(MergeParams, g, "G where input g is not connected", 0.0, -1e6, 1e6, 0, 1),
    WG_PARAM_FLOAT_UI(MergeParams, b, "B where input b is not connected", 0.0, -1e6, 1e6, 0, 1),
    WG_PARAM_FLOAT_UI(MergeParams, a, "A where input a is not connected", 1.0, -1e6, 1e6, 0, 1),
    WG_PARAM_END,
};
static const WgPortSpec merge_in[] = {
    WG_PORT_OPT("r", WG_GRAY),
    WG_PORT_OPT("g", WG_GRAY),
    WG_PORT_OPT("b", WG_GRAY),
    WG_PORT_OPT("a", WG_GRAY),
    WG_PORT_END,
};

typedef struct {
    const WgImage *in[4];
    float value[4];
    WgImage *out;
} MergeJob;

static void merge_rows(void *user, int y0, int y1)
{
    const MergeJob *j = user;
    for (int y = y0; y < y1; y++) {
        float *d = wg_image_row(j->out, y);
        for (int k = 0; k < 4; k++) {
            if (j->in[k]) {
                const float *s = wg_image_row(j->in[k], y);
                for (int x = 0; x < j->out->width; x++) d[4 * x + k] = s[x];
            } else {
                for (int x = 0; x < j->out->width; x++) d[4 * x + k] = j->value[k];
            }
        }
    }
}

static int merge_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const MergeParams *p = ctx->params;
    MergeJob j = {{NULL}, {p->r, p->g, p->b, p->a}, ctx->outputs[0]};
    for (int k = 0; k < 4 && k < ctx->n_inputs; k++) j.in[k] = ctx->inputs[k];
    return wg_parallel_rows(ctx, j.out->height, merge_rows, &j);
}

const WgNodeType wg_node_merge = {
    .name = "merge",
    .summary = "Four gray images (r, g, b, a) to one colour image",
    .category = "color",
    .doc = "Each channel is an exact copy of its gray input; an unconnected input takes the "
           "parameter of the same name (defaults r = g = b = 0, a = 1). With nothing connected "
           "the output is the constant colour (r, g, b, a) at the node's size.",
    .params = merge_params,
    .params_size = sizeof(MergeParams),
    .inputs = merge_in,
    .outputs = color_out,
    .flags = WG_NODE_POINT,
    .eval = merge_eval,
};

/* ---- shuffle ----------------------------------------------------------------------------- */

enum { SH_R, SH_G, SH_B, SH_A, SH_ZERO, SH_ONE };
static const char *const shuffle_sources[] = {"r", "g", "b", "a", "zero", "one", NULL};

typedef struct {
    int r, g, b, a;
} ShuffleParams;

static const WgParamSpec shuffle_params[] = {
    WG_PARAM_ENUM(ShuffleParams, r, "Source of the output's R", SH_R, shuffle_sources),
    WG_PARAM_ENUM(ShuffleParams, g, "Source of the output's G", SH_G, shuffle_sources),
    WG_PARAM_ENUM(ShuffleParams, b, "Source of the output's B", SH_B, shuffle_sources),
    WG_PARAM_ENUM(ShuffleParams, a, "Source of the output's A", SH_A, shuffle_sources),
    WG_PARAM_END,
};

typedef struct {
    int src[4];
    const WgImage *in;
    WgImage *out;
} ShuffleJob;

static void shuffle_rows(void *user, int y0, int y1)
{
    const ShuffleJob *j = user;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d = wg_image_row(j->out, y);
        for (int x = 0; x < j->out->width; x++)
            for (int k = 0; k < 4; k++) {
                int src = j->src[k];
                d[4 * x + k] = src == SH_ZERO ? 0.0f : src == SH_ONE ? 1.0f : s[4 * x + src];
            }
    }
}

static int shuffle_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const ShuffleParams *p = ctx->params;
    ShuffleJob j = {{p->r, p->g, p->b, p->a}, ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, j.out->height, shuffle_rows, &j);
}

const WgNodeType wg_node_shuffle = {
    .name = "shuffle",
    .summary = "Reorder, copy or replace the channels of a colour image",
    .category = "color",
    .doc = "Each output channel `r`, `g`, `b`, `a` names its source: an input channel (`r`, "
           "`g`, `b`, `a`) or a constant (`zero`, `one`). The default is the identity; "
           "`r=\"b\" b=\"r\"` swaps red and blue, `a=\"one\"` makes the image opaque, "
           "`r=\"a\" g=\"a\" b=\"a\" a=\"one\"` shows the alpha. Values are copied exactly. A "
           "gray input is promoted first (r = g = b = value, a = 1).",
    .params = shuffle_params,
    .params_size = sizeof(ShuffleParams),
    .inputs = color_source_in,
    .outputs = color_out,
    .flags = WG_NODE_POINT,
    .eval = shuffle_eval,
};
