/* SPDX-License-Identifier: MIT */
/* `env_prefilter` and `preview`: a physically based picture of a material tile, lit by an
 * equirectangular environment, with an optional water layer over it.
 * `env_prefilter` turns an equirectangular environment (z up; u = 0.5 − φ/2π with φ the azimuth
 * from +x towards +y, v = θ/π from the zenith) into a square atlas read by `preview`: 8 blocks,
 * 2 across and 4 down (block b at column b % 2, row b / 2), each an equirectangular map of half
 * the atlas's width and a quarter of its height, read in normalised coordinates (a square atlas
 * reaching a square preview of another size is resampled uniformly and stays usable; a preview
 * smaller than the atlas blurs the lighting): blocks 0-5 hold the GGX specular prefiltered
 * radiance for roughness 0, 0.2, ..., 1 (α = roughness², the split-sum approximation of Karis
 * 2013 with N = V = R; roughness 0 is the environment box-filtered to the block; the others
 * integrate 64 Hammersley GGX samples per texel, each read from a box mip chain at the level
 * whose texel matches the sample's solid angle, "filtered importance sampling" after Křivánek &
 * Colbert 2008, weighted by N·L); block 6 the diffuse irradiance over π (a brute-force cosine
 * integral over a 32 × 16 reduction of the environment, normalised by the integral of the
 * weights so a uniform environment gives exactly its value); block 7 the split-sum BRDF table
 * in its left half (u = n·v, v = roughness; R = A, G = B, with F0·A + B the directional albedo
 * of the GGX lobe with height-correlated Smith visibility and the Fresnel term
 * F0 + (1 − F0)·w(v·h) of fresnel_w, 128 samples per texel, A + B ≤ 1).
 * A size of 512 (blocks of 256 × 128) is a good default; any square side, a multiple of 4 and
 * at least 16, works.
 * Negative and non-finite radiances read as 0, larger than 1e6 as 1e6.
 * `preview` renders the tile (twice over, 2 × 2, with `repeat`) seen by a perspective camera
 * at `elevation`/`azimuth` degrees, the relief carved by parallax occlusion mapping below the
 * tile's plane (a height of 1 is the plane, 0 lies `height_scale` tile widths below it: a
 * linear search of `pom_steps` steps, then one secant step). Shading is metallic/roughness PBR:
 * F0 = mix(0.08 · specular, basecolor, metallic) (`specular` 0.5 where not connected: F0 0.04),
 * diffuse colour basecolor · (1 − metallic), GGX with height-correlated Smith visibility and
 * the Fresnel term F0 + (1 − F0)·w(c) (fresnel_w: the exact curve of a dielectric of index 1.5,
 * rescaled) for the sun, Lambert diffuse. Ambient light is image-based, the split sum
 * with multiple scattering restored (Fdez-Agüera 2019): specular = prefiltered(reflection,
 * roughness) · Fss (Fss = F0·A + B) + irradiance · Ems·Fms (Ems = 1 − A − B, what a white lobe
 * loses to single scattering, Fms = Fss·F_avg / (1 − Ems·F_avg)), diffuse = diffuse colour ·
 * irradiance · (1 − Fss − Ems·Fms) (what the lobe reflects is not available to the diffuse
 * layer, so a white dielectric, and a white metal, in a white environment return exactly
 * white), all times AO. The optional sun is a directional light of irradiance `sun_intensity`
 * (single scattering only).
 * Water: with a `water_mask` input, the camera ray is also marched against `water_height`; at
 * its hit, the surface (normal `water_normal`, roughness `water_roughness`, F0 `water_specular`
 * or ((n−1)/(n+1))² from `water_ior`) reflects the environment, or the relief standing out
 * of the water where its mirror ray meets it (relief_above), with the same compensated
 * weights, E = Fss + Ems·Fms in all, scaled from the index-1.5 curve to the exact Fresnel
 * curve of the water's own index (water_fresnel; for a smooth surface E is that F(n·v); using
 * the lobe's own albedo keeps reflection plus transmission ≤ 1 when rough), which every
 * crossing of the surface uses. The ray is refracted
 * (Snell, `water_ior`) and marched again, from the water surface, against `height`, where the
 * material is shaded as seen from below the water, with its own metallic and specular level (a
 * metal stays a metal; its diffuse colour × under_water_gain, as its base colour is the wet
 * albedo seen from outside): the view direction is the refracted ray; ambient light arrives only
 * through the surface, each direction above it refracted and scaled by 1 − F (under_irradiance);
 * the reflection leaves through the surface scaled by 1 − F or, beyond the critical angle, sees
 * the submerged floor; the sun arrives along its refracted direction scaled by 1 − F(l·n); the
 * light leaves scaled by 1 − E. Rough lobes read the prefiltered environment along Frostbite's
 * dominant direction (dominant_dir), dry and under water.
 * Beer–Lambert absorption: the light crosses the view path in the water plus the vertical depth
 * (both in height units), and is multiplied by tint^(path / absorption_depth), tint the
 * `water_tint` input where connected (read where the ray enters the water, so a graph can give
 * a liquid's tint from its preset or paint it) and else the parameter (default 1 1 1: clear
 * water; the maps of the material under the water carry no absorption). The result
 * is mix(dry, wet, water_mask); where the mask is 0 (or not connected) the dry render is
 * returned untouched, bit for bit. Rays that miss the tile see the environment.
 * Output: radiance · 2^exposure, through the filmic curve of Narkowicz 2015 ("ACES filmic tone
 * mapping curve", f(x) = x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14), clamped to [0, 1]) or
 * none; values stay linear for an output written with colorspace="srgb" (`encoding` linear) or
 * are sRGB-encoded here (`encoding` srgb, for an output written as it is). Every pixel is
 * computed on its own from the inputs, so any thread count gives the same bits; non-finite or
 * out-of-range map values are clamped (heights to ±16), and a non-finite result is written 0.
 */
#include "wetgraph/node.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { LEVELS = 6, BLOCKS = LEVELS + 2, IRR_BLOCK = LEVELS, LUT_BLOCK = LEVELS + 1 };
/* blocks are laid out 2 across, 4 down: block b at column b % 2, row b / 2 */
enum { COLS = 2, ROWS = 4 };
enum { SPEC_SAMPLES = 64, LUT_SAMPLES = 128, IRR_W = 32, IRR_H = 16, UW_SAMPLES = 16 };

typedef struct {
    float x, y, z;
} V3;

static inline V3 v3(float x, float y, float z)
{
    return (V3){x, y, z};
}
static inline V3 add(V3 a, V3 b)
{
    return v3(a.x + b.x, a.y + b.y, a.z + b.z);
}
static inline V3 sub(V3 a, V3 b)
{
    return v3(a.x - b.x, a.y - b.y, a.z - b.z);
}
static inline V3 scale(V3 a, float s)
{
    return v3(a.x * s, a.y * s, a.z * s);
}
static inline V3 mul(V3 a, V3 b)
{
    return v3(a.x * b.x, a.y * b.y, a.z * b.z);
}
static inline float dot(V3 a, V3 b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
static inline V3 cross(V3 a, V3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline V3 normalize(V3 a)
{
    float l = sqrtf(dot(a, a));
    return l > 1e-20f ? scale(a, 1.0f / l) : v3(0, 0, 1);
}
static inline V3 reflect(V3 d, V3 n)
{
    return sub(d, scale(n, 2 * dot(d, n)));
}
/* Refraction of direction d (towards the surface) through normal n (against d), eta = n1/n2.
 * Returns false on total internal reflection. */
static inline bool refract(V3 d, V3 n, float eta, V3 *t)
{
    float c = -dot(d, n);
    float k = 1 - eta * eta * (1 - c * c);
    if (k < 0) return false;
    *t = normalize(add(scale(d, eta), scale(n, eta * c - sqrtf(k))));
    return true;
}
static inline float clampf(float x, float lo, float hi)
{
    return x > lo ? (x < hi ? x : hi) : lo; /* NaN → lo */
}

static double radical_inverse(unsigned i)
{
    i = (i << 16) | (i >> 16);
    i = ((i & 0x55555555u) << 1) | ((i & 0xAAAAAAAAu) >> 1);
    i = ((i & 0x33333333u) << 2) | ((i & 0xCCCCCCCCu) >> 2);
    i = ((i & 0x0F0F0F0Fu) << 4) | ((i & 0xF0F0F0F0u) >> 4);
    i = ((i & 0x00FF00FFu) << 8) | ((i & 0xFF00FF00u) >> 8);
    return i * 2.3283064365386963e-10;
}

/* GGX half vector around +z for the sample (u1, u2), α = roughness². */
static void ggx_half(double u1, double u2, double a, double h[3])
{
    double phi = 2 * M_PI * u1;
    double ct = sqrt((1 - u2) / (1 + (a * a - 1) * u2)), st = sqrt(1 - ct * ct);
    h[0] = st * cos(phi), h[1] = st * sin(phi), h[2] = ct;
}

static double vis_smith(double nv, double nl, double a)
{
    double a2 = a * a;
    double gv = nl * sqrt(nv * nv * (1 - a2) + a2), gl = nv * sqrt(nl * nl * (1 - a2) + a2);
    return 0.5 / (gv + gl);
}

/* The shape of the Fresnel reflectance, from 0 at normal incidence (c = cos θ = 1) to 1 at
 * grazing: the exact Fresnel reflectance F(c) of a dielectric of index 1.5 (F0 = 0.04, the
 * usual specular level), rescaled, w = (F − 0.04)/0.96. Reflectance is f0 + (1 − f0) w(c),
 * linear in f0 as Schlick's (1 − c)⁵ is, so the split-sum table still splits F0 out, but
 * following the real curve, which rises earlier: Schlick's is 11 % low at 40° and 21 % at 50°
 * to 60° for F0 0.04. For other dielectrics (water: F0 0.02) it is still much closer than
 * Schlick's; for metals it is an approximation as Schlick's is. */
static double fresnel_w(double c)
{
    c = c > 0 ? (c < 1 ? c : 1) : 0;
    double g = sqrt(1.25 + c * c); /* n² − 1 + c², n = 1.5 */
    double a = (g - c) / (g + c), b = (c * (g + c) - 1) / (c * (g - c) + 1);
    return (0.5 * a * a * (1 + b * b) - 0.04) / 0.96;
}
/* The cosine-weighted hemispherical average of fresnel_w, 2 ∫ w(c) c dc: the diffuse
 * reflectance of a surface of F0 f0 is f0 + (1 − f0) W_AVG. */
#define W_AVG 0.0539354f

static V3 dir_of(double u, double v)
{
    double phi = (0.5 - u) * 2 * M_PI, th = v * M_PI;
    return v3((float)(sin(th) * cos(phi)), (float)(sin(th) * sin(phi)), (float)cos(th));
}

static void uv_of(V3 d, float rot, float *u, float *v)
{
    float phi = atan2f(d.y, d.x) + rot;
    float uu = 0.5f - phi * (float)(0.5 / M_PI);
    uu -= floorf(uu);
    *u = uu;
    *v = acosf(clampf(d.z, -1, 1)) * (float)(1 / M_PI);
}

/* ---- env_prefilter ------------------------------------------------------------------------ */

typedef struct {
    int unused;
} PrefilterParams;

static const WgParamSpec prefilter_params[] = {WG_PARAM_END};
static const WgPortSpec prefilter_in[] = {WG_PORT("environment", WG_COLOR), WG_PORT_END};
static const WgPortSpec prefilter_out[] = {WG_PORT("atlas", WG_COLOR), WG_PORT_END};

/* A mip chain of RGB float maps, level 0 W × W/2, each level half the previous. */
typedef struct {
    int levels;
    int w[16], h[16];
    float *data[16];
} Mips;

static V3 mip_texel(const Mips *m, int l, int x, int y)
{
    int w = m->w[l], h = m->h[l];
    x %= w;
    if (x < 0) x += w;
    y = y < 0 ? 0 : y >= h ? h - 1 : y;
    const float *p = m->data[l] + 3 * ((size_t)y * w + x);
    return v3(p[0], p[1], p[2]);
}

static V3 mip_bilinear(const Mips *m, int l, float u, float v)
{
    float fx = u * m->w[l] - 0.5f, fy = v * m->h[l] - 0.5f;
    int x = (int)floorf(fx), y = (int)floorf(fy);
    float ax = fx - x, ay = fy - y;
    V3 a = mip_texel(m, l, x, y), b = mip_texel(m, l, x + 1, y);
    V3 c = mip_texel(m, l, x, y + 1), d = mip_texel(m, l, x + 1, y + 1);
    V3 top = add(scale(a, 1 - ax), scale(b, ax)), bot = add(scale(c, 1 - ax), scale(d, ax));
    return add(scale(top, 1 - ay), scale(bot, ay));
}

static V3 mip_sample(const Mips *m, V3 d, float level)
{
    float u, v;
    uv_of(d, 0, &u, &v);
    level = clampf(level, 0, (float)(m->levels - 1));
    int l0 = (int)level;
    float f = level - l0;
    V3 a = mip_bilinear(m, l0, u, v);
    if (f <= 0 || l0 + 1 >= m->levels) return a;
    return add(scale(a, 1 - f), scale(mip_bilinear(m, l0 + 1, u, v), f));
}

typedef struct {
    const WgImage *env;
    WgImage *out;
    Mips mips;
    int bw, bh, irr_level;
    float *irr_table; /* per source texel: direction, solid-angle weight, colour */
    int irr_n;
    float spec_table[4 * SPEC_SAMPLES * (LEVELS - 1)]; /* half vector, mip level */
} PrefilterJob;

static float *out_px(WgImage *img, int block, int bw, int bh, int x, int y)
{
    return wg_image_row(img, block / COLS * bh + y) + 4 * ((size_t)(block % COLS) * bw + x);
}

static void put(float *p, V3 c)
{
    p[0] = c.x, p[1] = c.y, p[2] = c.z, p[3] = 1;
}

static void prefilter_rows(void *user, int y0, int y1)
{
    PrefilterJob *j = user;
    const Mips *m = &j->mips;
    int bw = j->bw, bh = j->bh;
    for (int yy = y0; yy < y1; yy++) {
        int brow = yy / bh, row = yy % bh;
        double v = (row + 0.5) / bh;
        for (int xx = 0; xx < COLS * bw; xx++) {
            int block = brow * COLS + xx / bw, x = xx % bw;
            float *o = out_px(j->out, block, bw, bh, x, row);
            double u = (x + 0.5) / bw;
            V3 n = dir_of(u, v);
            if (block == 0) {
                put(o, mip_texel(m, 0, x, row));
            } else if (block < LEVELS) {
                /* tangent frame around n */
                V3 up = fabsf(n.z) < 0.999f ? v3(0, 0, 1) : v3(1, 0, 0);
                V3 tx = normalize(cross(up, n)), ty = cross(n, tx);
                double acc[3] = {0, 0, 0}, wsum = 0;
                const float *tab = j->spec_table + 4 * SPEC_SAMPLES * (size_t)(block - 1);
                for (int s = 0; s < SPEC_SAMPLES; s++) {
                    const float *h = tab + 4 * s;
                    V3 hv = add(add(scale(tx, h[0]), scale(ty, h[1])), scale(n, h[2]));
                    V3 l = sub(scale(hv, 2 * dot(n, hv)), n);
                    double nl = dot(n, l);
                    if (nl <= 0) continue;
                    V3 c = mip_sample(m, l, h[3]);
                    acc[0] += c.x * nl, acc[1] += c.y * nl, acc[2] += c.z * nl;
                    wsum += nl;
                }
                if (wsum <= 0) wsum = 1;
                put(o, v3((float)(acc[0] / wsum), (float)(acc[1] / wsum), (float)(acc[2] / wsum)));
            } else if (block == IRR_BLOCK) {
                double acc[3] = {0, 0, 0}, wsum = 0;
                for (int k = 0; k < j->irr_n; k++) {
                    const float *s = j->irr_table + 7 * (size_t)k;
                    double c = n.x * s[0] + n.y * s[1] + n.z * s[2];
                    if (c <= 0) continue;
                    double w = c * s[3];
                    acc[0] += s[4] * w, acc[1] += s[5] * w, acc[2] += s[6] * w;
                    wsum += w;
                }
                if (wsum <= 0) wsum = 1;
                put(o, v3((float)(acc[0] / wsum), (float)(acc[1] / wsum), (float)(acc[2] / wsum)));
            } else {
                /* the BRDF table in the block's left half, a square (bh = bw/2) */
                int side = bh;
                if (x >= side || row >= side) {
                    put(o, v3(0, 0, 0));
                    continue;
                }
                double nv = (x + 0.5) / side, r = (row + 0.5) / side, a = r * r;
                double vx = sqrt(1 - nv * nv), vz = nv;
                double A = 0, B = 0;
                for (int s = 0; s < LUT_SAMPLES; s++) {
                    double h[3];
                    ggx_half((s + 0.5) / LUT_SAMPLES, radical_inverse((unsigned)s), a, h);
                    double vh = vx * h[0] + vz * h[2];
                    double lz = 2 * vh * h[2] - vz;
                    if (lz <= 0 || vh <= 0) continue;
                    double g = vis_smith(nv, lz, a) * 4 * lz * vh / h[2];
                    double fc = fresnel_w(vh);
                    A += (1 - fc) * g, B += fc * g;
                }
                A /= LUT_SAMPLES, B /= LUT_SAMPLES;
                if (A + B > 1) {
                    double k = 1 / (A + B);
                    A *= k, B *= k;
                }
                put(o, v3((float)A, (float)B, 0));
            }
        }
    }
}

static float clean(float x)
{
    return x > 0 ? (x < 1e6f ? x : 1e6f) : 0; /* NaN, negative → 0 */
}

static int prefilter_check(const WgNodeContext *ctx, WgError *err)
{
    int w = ctx->width, h = ctx->height;
    if (w < 16 || w % 4 || h != w)
        return wg_error_set(err, WG_ERR_RANGE, NULL,
                            "env_prefilter needs a square size, a multiple of 4 and at least 16 "
                            "(e.g. size=\"512\"), not %dx%d",
                            w, h);
    return WG_OK;
}

static size_t mips_floats(int bw, int bh)
{
    size_t n = 0;
    for (int w = bw, h = bh; w >= 1 && h >= 1; w /= 2, h /= 2) n += 3 * (size_t)w * h;
    return n;
}

static size_t prefilter_scratch(const WgNodeContext *ctx)
{
    return sizeof(float) * mips_floats(ctx->width / COLS, ctx->height / ROWS);
}

static int prefilter_eval(WgNodeContext *ctx, WgError *err)
{
    int st = prefilter_check(ctx, err);
    if (st) return st;
    const WgImage *env = ctx->inputs[0];
    PrefilterJob j = {
        .env = env, .out = ctx->outputs[0], .bw = ctx->width / COLS, .bh = ctx->height / ROWS};
    size_t bytes = prefilter_scratch(ctx);
    float *buf = wg_scratch_alloc(ctx, bytes);
    if (!buf) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory for the mip chain");
    /* level 0: the environment (at the node's size, twice a block's width and four times its
     * height) averaged      * over each block-sized texel */
    Mips *m = &j.mips;
    m->levels = 0;
    float *p = buf;
    for (int w = j.bw, h = j.bh; w >= 1 && h >= 1 && m->levels < 16; w /= 2, h /= 2) {
        m->w[m->levels] = w, m->h[m->levels] = h, m->data[m->levels] = p;
        p += 3 * (size_t)w * h;
        m->levels++;
    }
    for (int y = 0; y < j.bh; y++)
        for (int x = 0; x < j.bw; x++) {
            double s[3] = {0, 0, 0};
            for (int k = 0; k < ROWS; k++)
                for (int i = 0; i < COLS; i++) {
                    const float *e = wg_image_row(env, y * ROWS + k) + 4 * ((size_t)x * COLS + i);
                    s[0] += clean(e[0]), s[1] += clean(e[1]), s[2] += clean(e[2]);
                }
            float *o = m->data[0] + 3 * ((size_t)y * j.bw + x);
            for (int c = 0; c < 3; c++) o[c] = (float)(s[c] / (ROWS * COLS));
        }
    for (int l = 1; l < m->levels; l++) {
        int w = m->w[l], h = m->h[l], pw = m->w[l - 1];
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                for (int c = 0; c < 3; c++) {
                    const float *q = m->data[l - 1];
                    double s = q[3 * ((size_t)(2 * y) * pw + 2 * x) + c] +
                               q[3 * ((size_t)(2 * y) * pw + 2 * x + 1) + c] +
                               q[3 * ((size_t)(2 * y + 1) * pw + 2 * x) + c] +
                               q[3 * ((size_t)(2 * y + 1) * pw + 2 * x + 1) + c];
                    m->data[l][3 * ((size_t)y * w + x) + c] = (float)(s / 4);
                }
    }
    j.irr_level = 0;
    while (j.irr_level + 1 < m->levels && m->w[j.irr_level] > IRR_W) j.irr_level++;
    int iw = m->w[j.irr_level], ih = m->h[j.irr_level];
    float table[7 * 64 * 32];
    j.irr_table = table, j.irr_n = iw * ih;
    for (int y = 0; y < ih; y++)
        for (int x = 0; x < iw; x++) {
            float *t = table + 7 * ((size_t)y * iw + x);
            double v = (y + 0.5) / ih;
            V3 l = dir_of((x + 0.5) / iw, v);
            const float *c = m->data[j.irr_level] + 3 * ((size_t)y * iw + x);
            t[0] = l.x, t[1] = l.y, t[2] = l.z, t[3] = (float)sin(v * M_PI);
            t[4] = c[0], t[5] = c[1], t[6] = c[2];
        }
    /* the GGX samples of each level and the mip level matching each one's solid angle */
    double texel_sa = 4 * M_PI / ((double)m->w[0] * m->h[0]);
    for (int b = 1; b < LEVELS; b++) {
        double r = (double)b / (LEVELS - 1), a = r * r, a2 = a * a;
        for (int s = 0; s < SPEC_SAMPLES; s++) {
            double h[3];
            ggx_half((s + 0.5) / SPEC_SAMPLES, radical_inverse((unsigned)s), a, h);
            double dd = h[2] * h[2] * (a2 - 1) + 1, D = a2 / (M_PI * dd * dd);
            double sa = 1 / (SPEC_SAMPLES * D / 4 + 1e-9);
            float *t = j.spec_table + 4 * (SPEC_SAMPLES * (size_t)(b - 1) + s);
            t[0] = (float)h[0], t[1] = (float)h[1], t[2] = (float)h[2];
            t[3] = (float)(0.5 * log2(sa / texel_sa) + 1);
        }
    }
    st = wg_parallel_rows(ctx, ctx->height, prefilter_rows, &j);
    wg_scratch_free(ctx, buf, bytes);
    return st;
}

const WgNodeType wg_node_env_prefilter = {
    .name = "env_prefilter",
    .summary = "Prefiltered lighting atlas (specular levels, irradiance, BRDF table) for preview",
    .category = "render",
    .doc = "Input: an equirectangular environment (z up, the zenith at the top row), linear HDR. "
           "Output: 8 blocks, 2 across and 4 down, each an equirectangular map of half the width "
           "and a quarter of the height: GGX-prefiltered radiance for roughness 0, 0.2, ..., 1, "
           "the diffuse irradiance over pi, and the split-sum BRDF table (R = scale A, G = bias "
           "B of F0) in a square at the left of the last block. Size: a "
           "square size, a multiple of 4 and at least 16, e.g. size=\"512\".",
    .params = prefilter_params,
    .params_size = sizeof(PrefilterParams),
    .inputs = prefilter_in,
    .outputs = prefilter_out,
    .flags = WG_NODE_GLOBAL,
    .check = prefilter_check,
    .eval = prefilter_eval,
    .scratch_bytes = prefilter_scratch,
};

/* ---- preview ------------------------------------------------------------------------------ */

typedef struct {
    float elevation, azimuth, fov, zoom;
    bool repeat;
    float height_scale;
    int pom_steps;
    float env_rotation, exposure;
    bool sun;
    float sun_elevation, sun_azimuth, sun_intensity;
    float sun_color[4];
    float water_ior;
    float water_tint[4];
    float absorption_depth;
    int tonemap, encoding;
} PreviewParams;

enum { TONEMAP_ACES, TONEMAP_NONE };
enum { ENCODING_LINEAR, ENCODING_SRGB };
static const char *const tonemap_values[] = {"aces", "none", NULL};
static const char *const encoding_values[] = {"linear", "srgb", NULL};

static const WgParamSpec preview_params[] = {
    WG_PARAM_FLOAT(PreviewParams, elevation, "Camera elevation above the tile, degrees", 50, 1, 90),
    WG_PARAM_FLOAT(PreviewParams, azimuth, "Camera azimuth, degrees (0: from the bottom edge)", 20,
                   -360, 360),
    WG_PARAM_FLOAT(PreviewParams, fov, "Vertical field of view, degrees", 35, 1, 120),
    WG_PARAM_FLOAT(PreviewParams, zoom, "Zoom: 1 shows the whole tile from straight above", 1, 0.05,
                   20),
    WG_PARAM_BOOL(PreviewParams, repeat, "Show the tile 2 x 2", false),
    WG_PARAM_FLOAT_UI(PreviewParams, height_scale,
                      "Relief depth: tile widths between height 1 and height 0", 0.04, 0, 1, 0,
                      0.2),
    WG_PARAM_INT(PreviewParams, pom_steps, "Parallax occlusion mapping: steps of the search", 48, 1,
                 1024),
    WG_PARAM_FLOAT(PreviewParams, env_rotation, "Environment rotation about the vertical, degrees",
                   0, -360, 360),
    WG_PARAM_FLOAT(PreviewParams, exposure, "Exposure, stops (radiance x 2^exposure)", 0, -20, 20),
    WG_PARAM_BOOL(PreviewParams, sun, "Add a directional sun light", false),
    WG_PARAM_FLOAT(PreviewParams, sun_elevation, "Sun elevation, degrees", 35, 0, 90),
    WG_PARAM_FLOAT(PreviewParams, sun_azimuth, "Sun azimuth, degrees", 120, -360, 360),
    WG_PARAM_FLOAT_UI(PreviewParams, sun_intensity,
                      "Sun irradiance on a surface facing it (environment units)", 3, 0, 1e6, 0,
                      20),
    WG_PARAM_COLOR(PreviewParams, sun_color, "Sun colour (linear)", "1 0.95 0.9"),
    WG_PARAM_FLOAT(PreviewParams, water_ior, "Index of refraction of the water", 1.33, 1, 3),
    WG_PARAM_COLOR(PreviewParams, water_tint, "Water transmittance over absorption_depth (linear)",
                   "1 1 1"),
    WG_PARAM_FLOAT_UI(PreviewParams, absorption_depth,
                      "Path length in the water, height units, over which water_tint applies", 1,
                      1e-4, 1e6, 0.05, 10),
    WG_PARAM_ENUM(PreviewParams, tonemap, "Tone mapping: aces (Narkowicz's fit) or none", 0,
                  tonemap_values),
    WG_PARAM_ENUM(PreviewParams, encoding,
                  "linear: display values for an output with colorspace=\"srgb\"; srgb: encoded "
                  "here",
                  0, encoding_values),
    WG_PARAM_END,
};

enum {
    IN_ENV,
    IN_BASE,
    IN_NORMAL,
    IN_ROUGH,
    IN_HEIGHT,
    IN_AO,
    IN_METAL,
    IN_SPEC,
    IN_WH,
    IN_WN,
    IN_WR,
    IN_WS,
    IN_WM,
    IN_WT,
    N_IN
};
static const WgPortSpec preview_in[] = {
    WG_PORT("environment", WG_COLOR),
    WG_PORT("basecolor", WG_COLOR),
    WG_PORT_OPT("normal", WG_COLOR),
    WG_PORT_OPT("roughness", WG_GRAY),
    WG_PORT_OPT("height", WG_GRAY),
    WG_PORT_OPT("ao", WG_GRAY),
    WG_PORT_OPT("metallic", WG_GRAY),
    WG_PORT_OPT("specular", WG_GRAY),
    WG_PORT_OPT("water_height", WG_GRAY),
    WG_PORT_OPT("water_normal", WG_COLOR),
    WG_PORT_OPT("water_roughness", WG_GRAY),
    WG_PORT_OPT("water_specular", WG_GRAY),
    WG_PORT_OPT("water_mask", WG_GRAY),
    WG_PORT_OPT("water_tint", WG_COLOR),
    WG_PORT_END,
};
static const WgPortSpec preview_out[] = {WG_PORT("image", WG_COLOR), WG_PORT_END};

typedef struct {
    const PreviewParams *p;
    const WgImage *in[N_IN];
    WgImage *out;
    int w, h;
    V3 cam, fwd, right, up;
    float tan_half, span, rot, expo;
    float hmin, hmax, wmin, wmax;
    V3 sun_dir, sun_rad;
    float water_f0;
    float uw_dirs[UW_SAMPLES][3]; /* cosine-weighted directions around +z */
} PreviewJob;

/* bilinear, wrapping, tile coordinates: x right, y up, [0, 1) is the tile */
static float tex_gray(const WgImage *img, float x, float y, float def)
{
    if (!img || !isfinite(x) || !isfinite(y)) return def;
    int w = img->width, h = img->height;
    float fx = x * w - 0.5f, fy = (1 - y) * h - 0.5f;
    fx -= floorf(fx / w) * w, fy -= floorf(fy / h) * h;
    if (!(fx >= 0 && fx < w)) fx = 0;
    if (!(fy >= 0 && fy < h)) fy = 0;
    int x0 = (int)fx, y0 = (int)fy;
    float ax = fx - x0, ay = fy - y0;
    if (x0 >= w) x0 = 0;
    if (y0 >= h) y0 = 0;
    int x1 = x0 + 1 == w ? 0 : x0 + 1, y1 = y0 + 1 == h ? 0 : y0 + 1;
    const float *r0 = wg_image_row(img, y0), *r1 = wg_image_row(img, y1);
    float v = (r0[x0] * (1 - ax) + r0[x1] * ax) * (1 - ay) + (r1[x0] * (1 - ax) + r1[x1] * ax) * ay;
    return isfinite(v) ? v : def;
}

static V3 tex_color(const WgImage *img, float x, float y, V3 def)
{
    if (!img || !isfinite(x) || !isfinite(y)) return def;
    int w = img->width, h = img->height;
    float fx = x * w - 0.5f, fy = (1 - y) * h - 0.5f;
    fx -= floorf(fx / w) * w, fy -= floorf(fy / h) * h;
    if (!(fx >= 0 && fx < w)) fx = 0; /* a coordinate too large to wrap in float */
    if (!(fy >= 0 && fy < h)) fy = 0;
    int x0 = (int)fx, y0 = (int)fy;
    float ax = fx - x0, ay = fy - y0;
    if (x0 >= w) x0 = 0;
    if (y0 >= h) y0 = 0;
    int x1 = x0 + 1 == w ? 0 : x0 + 1, y1 = y0 + 1 == h ? 0 : y0 + 1;
    const float *a = wg_image_row(img, y0) + 4 * x0, *b = wg_image_row(img, y0) + 4 * x1;
    const float *c = wg_image_row(img, y1) + 4 * x0, *d = wg_image_row(img, y1) + 4 * x1;
    float o[3];
    for (int k = 0; k < 3; k++) {
        o[k] = (a[k] * (1 - ax) + b[k] * ax) * (1 - ay) + (c[k] * (1 - ax) + d[k] * ax) * ay;
        if (!isfinite(o[k])) o[k] = k == 0 ? def.x : k == 1 ? def.y : def.z;
    }
    return v3(o[0], o[1], o[2]);
}

/* The atlas in normalised coordinates: block b, u wrapping, v clamped inside the block. The
 * atlas may arrive resampled to any size: blocks are then a fractional number of pixels, read
 * from the block's first whole pixel. */
static V3 atlas(const WgImage *a, int block, float u, float v)
{
    int w = a->width, h = a->height;
    float bw = (float)w / COLS, bh = (float)h / ROWS;
    int nbw = bw >= 1 ? (int)bw : 1, nbh = bh >= 1 ? (int)bh : 1;
    int ox = (int)lroundf(block % COLS * bw), oy = (int)lroundf(block / COLS * bh);
    if (ox + nbw > w) ox = w - nbw;
    if (oy + nbh > h) oy = h - nbh;
    float fx = u * nbw - 0.5f;
    fx -= floorf(fx / nbw) * nbw;
    float fy = clampf(v * nbh - 0.5f, 0, (float)(nbh - 1));
    /* a direction made of non-finite inputs reads the block's first pixel */
    if (!(fx >= 0 && fx < (float)nbw)) fx = 0;
    if (!(fy >= 0 && fy <= (float)(nbh - 1))) fy = 0;
    int x0 = (int)fx, y0 = (int)fy;
    if (x0 >= nbw) x0 = 0;
    float ax = fx - x0, ay = fy - y0;
    int x1 = x0 + 1 == nbw ? 0 : x0 + 1, y1 = y0 + 1 < nbh ? y0 + 1 : y0;
    const float *r0 = wg_image_row(a, oy + y0), *r1 = wg_image_row(a, oy + y1);
    x0 += ox, x1 += ox;
    float o[3];
    for (int k = 0; k < 3; k++)
        o[k] = (r0[4 * x0 + k] * (1 - ax) + r0[4 * x1 + k] * ax) * (1 - ay) +
               (r1[4 * x0 + k] * (1 - ax) + r1[4 * x1 + k] * ax) * ay;
    return v3(o[0], o[1], o[2]);
}

static V3 env_spec(const PreviewJob *j, V3 d, float rough)
{
    float u, v;
    uv_of(d, j->rot, &u, &v);
    float f = clampf(rough, 0, 1) * (LEVELS - 1);
    int l0 = (int)f;
    if (l0 >= LEVELS - 1) l0 = LEVELS - 2;
    float t = f - l0;
    V3 a = atlas(j->in[IN_ENV], l0, u, v);
    if (t <= 0) return a;
    return add(scale(a, 1 - t), scale(atlas(j->in[IN_ENV], l0 + 1, u, v), t));
}

static V3 env_irr(const PreviewJob *j, V3 n)
{
    float u, v;
    uv_of(n, j->rot, &u, &v);
    return atlas(j->in[IN_ENV], IRR_BLOCK, u, v);
}

static void brdf_lut(const PreviewJob *j, float nv, float rough, float *A, float *B)
{
    /* the table fills the left half of its block: u = n·v / 2, v = roughness, in normalised
     * coordinates (the atlas may reach the preview resampled) */
    const WgImage *a = j->in[IN_ENV];
    float su = 0.5f / ((float)a->width / COLS / 2), sv = 0.5f / ((float)a->height / ROWS);
    float u = clampf(nv, su, 1 - su) * 0.5f;
    float v = clampf(rough, sv, 1 - sv);
    V3 c = atlas(a, LUT_BLOCK, u, v);
    *A = clampf(c.x, 0, 1), *B = clampf(c.y, 0, 1 - *A);
}

static float fresnel(float f0, float c)
{
    return f0 + (1 - f0) * (float)fresnel_w(c);
}

/* Fresnel reflectance of the water's surface for light crossing it at cos c on the air side
 * (the same both ways): the exact curve of a dielectric of index n = (1 + √f0)/(1 − √f0), the
 * index whose normal reflectance is f0. The rescaled index-1.5 curve of fresnel() is 15 % high
 * for water at 70° (0.154 against 0.133), which seen low made the water's mirror too bright. */
static float water_fresnel(float f0, float c)
{
    float s = sqrtf(clampf(f0, 0, 0.98f)), n = (1 + s) / (1 - s);
    c = clampf(c, 1e-6f, 1);
    float g = sqrtf(n * n - 1 + c * c);
    float a = (g - c) / (g + c), b = (c * (g + c) - 1) / (c * (g - c) + 1);
    return 0.5f * a * a * (1 + b * b);
}

/* The ambient weights of a lobe of reflectance f0 at n·v with split-sum terms A, B, with the
 * energy that single scattering loses restored (Fdez-Agüera 2019): fss = f0·A + B is what the
 * lobe reflects once, ems = 1 − (A + B) what a white lobe loses to masking, returned as
 * ms = fss·F_avg / (1 − ems·F_avg) · ems (F_avg = f0 + (1 − f0)·W_AVG), light scattered between
 * the microfacets and leaving about as diffusely as the irradiance. fss + ms ≤ 1, equal to 1
 * for f0 = 1. */
static float ms_weights(float f0, float A, float B, float *ms)
{
    float ems = 1 - (A + B), fss = f0 * A + B, favg = f0 + (1 - f0) * W_AVG;
    *ms = fss * favg / (1 - ems * favg) * ems;
    return fss;
}

/* Radiance leaving a material point towards v (before exposure). irr: the ambient irradiance
 * over π reaching the point, rad: the prefiltered radiance arriving along the reflection;
 * sun_rad: the sun's irradiance arriving along sun_l. spec is the specular level: F0 = 0.08 ·
 * spec for the dielectric part; kd scales the diffuse colour (1, or under_water_gain). */
static V3 shade(const PreviewJob *j, V3 v, V3 n, V3 base, float rough, float metal, float spec,
                float ao, V3 irr, V3 rad, V3 sun_l, V3 sun_rad, float kd)
{
    float nv = clampf(dot(n, v), 1e-4f, 1);
    float fd = 0.08f * spec;
    V3 f0 = add(scale(v3(fd, fd, fd), 1 - metal), scale(base, metal));
    V3 dc = scale(base, (1 - metal) * kd);
    float A, B;
    brdf_lut(j, nv, rough, &A, &B);
    V3 fss, ms;
    fss.x = ms_weights(f0.x, A, B, &ms.x);
    fss.y = ms_weights(f0.y, A, B, &ms.y);
    fss.z = ms_weights(f0.z, A, B, &ms.z);
    V3 e = add(fss, ms); /* what the lobe reflects is not available to the diffuse layer */
    V3 sp = mul(rad, fss);
    V3 diff = mul(irr, add(ms, mul(dc, v3(1 - e.x, 1 - e.y, 1 - e.z))));
    V3 out = scale(add(sp, diff), ao);
    if (j->p->sun) {
        float nl = dot(n, sun_l);
        if (nl > 0) {
            V3 hv = normalize(add(v, sun_l));
            float nh = clampf(dot(n, hv), 0, 1), vh = clampf(dot(v, hv), 0, 1);
            float a = rough * rough;
            if (a < 2e-3f) a = 2e-3f; /* a point light on a mirror: keep the highlight finite */
            float a2 = a * a, dd = nh * nh * (a2 - 1) + 1;
            float D = a2 / ((float)M_PI * dd * dd);
            float vis = (float)vis_smith(nv, nl, a);
            V3 f = v3(fresnel(f0.x, vh), fresnel(f0.y, vh), fresnel(f0.z, vh));
            V3 s = scale(f, D * vis);
            V3 d = scale(mul(dc, v3(1 - f.x, 1 - f.y, 1 - f.z)), (float)(1 / M_PI));
            out = add(out, scale(mul(add(s, d), sun_rad), nl));
        }
    }
    return out;
}

/* Parallax occlusion mapping: the first point where the ray o + t d (d.z < 0) meets the surface
 * z = hs (h(x, y) − 1), searched between the planes z_top and z_bot. */
static V3 march(const PreviewJob *j, const WgImage *hmap, V3 o, V3 d, float z_top, float z_bot,
                float hdef)
{
    float hs = j->p->height_scale;
    float t0 = 0, t1 = (z_bot - o.z) / d.z;
    if (o.z > z_top) t0 = (z_top - o.z) / d.z;
    if (!(t1 > t0) || hs <= 0) {
        float t = hs <= 0 ? -o.z / d.z : t0;
        if (hs <= 0) t = t > 0 ? t : 0;
        return add(o, scale(d, t));
    }
    int n = j->p->pom_steps;
    float dt = (t1 - t0) / n;
    float prev_t = t0, prev_gap = 0;
    for (int i = 0; i <= n; i++) {
        float t = t0 + dt * i;
        V3 p = add(o, scale(d, t));
        float hv = clampf(tex_gray(hmap, p.x, p.y, hdef), -16, 16);
        float gap = p.z - hs * (hv - 1); /* > 0: above the surface */
        if (gap <= 0) {
            if (i == 0) return p;
            float tt = prev_t + dt * prev_gap / (prev_gap - gap);
            return add(o, scale(d, tt));
        }
        prev_t = t, prev_gap = gap;
    }
    return add(o, scale(d, t1));
}

static V3 decode_normal(V3 c)
{
    return normalize(v3(2 * c.x - 1, 2 * c.y - 1, 2 * c.z - 1));
}

static bool inside(const PreviewJob *j, V3 p)
{
    return p.x >= 0 && p.y >= 0 && p.x <= j->span && p.y <= j->span;
}

/* Material parameters at a point of the tile. */
static void material_at(const PreviewJob *j, V3 p, V3 *base, V3 *n, float *rough, float *metal,
                        float *spec, float *ao)
{
    V3 b = tex_color(j->in[IN_BASE], p.x, p.y, v3(0.5f, 0.5f, 0.5f));
    *base = v3(clampf(b.x, 0, 1), clampf(b.y, 0, 1), clampf(b.z, 0, 1));
    *n = decode_normal(tex_color(j->in[IN_NORMAL], p.x, p.y, v3(0.5f, 0.5f, 1)));
    if (n->z < 1e-3f) *n = normalize(v3(n->x, n->y, 1e-3f));
    *rough = clampf(tex_gray(j->in[IN_ROUGH], p.x, p.y, 0.5f), 0, 1);
    *metal = clampf(tex_gray(j->in[IN_METAL], p.x, p.y, 0), 0, 1);
    *spec = clampf(tex_gray(j->in[IN_SPEC], p.x, p.y, 0.5f), 0, 1);
    *ao = clampf(tex_gray(j->in[IN_AO], p.x, p.y, 1), 0, 1);
}

static V3 background(const PreviewJob *j, V3 d)
{
    return env_spec(j, d, 0);
}

/* The direction to read the prefiltered environment in for the lobe of roughness rough around
 * the mirror direction r of normal n: the split sum prefilters around r as if the lobe were
 * centred there (N = V = R), so a rough lobe would gather the light below the surface's horizon;
 * its energy in fact leans towards the normal as it widens. Frostbite's dominant direction
 * (Lagarde & de Rousiers 2014, 4.9.3): lerp(n, r, (1 − α)(√(1 − α) + α)), α = rough². */
static V3 dominant_dir(V3 n, V3 r, float rough)
{
    float a = rough * rough, f = (1 - a) * (sqrtf(1 - a) + a);
    return normalize(add(scale(n, 1 - f), scale(r, f)));
}

/* Radiance leaving the relief's point p (out of the water) along the ray direction d. */
static V3 shade_relief(const PreviewJob *j, V3 p, V3 d)
{
    V3 base, n;
    float rough, metal, spec, ao;
    material_at(j, p, &base, &n, &rough, &metal, &spec, &ao);
    V3 v = scale(d, -1);
    return shade(j, v, n, base, rough, metal, spec, ao, env_irr(j, n),
                 env_spec(j, dominant_dir(n, reflect(d, n), rough), rough), j->sun_dir, j->sun_rad,
                 1);
}

/* The gain of the diffuse colour of the material under the water, 1/(1 − r_e)². Its base
 * colour is the wet albedo seen from outside (wet_material's under_basecolor: Lekner and Dorf's
 * A_w = (1 − r_e)(1 − r_i) A / (1 − r_i A), which already holds the light's way in and out
 * through the surface and the light the surface traps), while this path sends the light
 * through the surface on its way in (under_irradiance: 1 − r_e on average) and out (1 − E):
 * without the gain the surface would be counted twice, 13 % too dark for water. r_e is the
 * diffuse external reflectance the maps' model uses for the index whose F0 is f0:
 * r_i = −1.440/n² + 0.710/n + 0.668 + 0.0636 n, 1 − r_e = n² (1 − r_i) (0.067 for 1.333). */
static float under_water_gain(float f0)
{
    float s = sqrtf(clampf(f0, 0, 0.98f)), n = (1 + s) / (1 - s);
    float ri = -1.440f / (n * n) + 0.710f / n + 0.668f + 0.0636f * n;
    float re = clampf(1 - n * n * (1 - ri), 0, 0.9f);
    return 1 / ((1 - re) * (1 - re));
}

static V3 render_dry(const PreviewJob *j, V3 d)
{
    float hs = j->p->height_scale;
    V3 p = march(j, j->in[IN_HEIGHT], j->cam, d, hs * (j->hmax - 1), hs * (j->hmin - 1), 1);
    if (!inside(j, p)) return background(j, d);
    return shade_relief(j, p, d);
}

/* The first point where the rising ray o + t d (d.z > 0) from the water's surface meets the
 * relief standing out of the water, searched in pom_steps steps (and one secant step) up to the
 * relief's top plane inside the tile; false where it reaches the sky. */
static bool relief_above(const PreviewJob *j, V3 o, V3 d, V3 *hit)
{
    float hs = j->p->height_scale, z_top = hs * (j->hmax - 1);
    if (!(d.z > 1e-4f) || !(hs > 0) || !(o.z < z_top)) return false;
    int n = j->p->pom_steps;
    float dt = (z_top - o.z) / d.z / n;
    float prev_gap = o.z - hs * (clampf(tex_gray(j->in[IN_HEIGHT], o.x, o.y, 1), -16, 16) - 1);
    for (int i = 1; i <= n; i++) {
        V3 p = add(o, scale(d, dt * i));
        if (!inside(j, p)) return false;
        float gap = p.z - hs * (clampf(tex_gray(j->in[IN_HEIGHT], p.x, p.y, 1), -16, 16) - 1);
        if (gap <= 0) {
            float g0 = fmaxf(prev_gap, 0), f = g0 - gap > 0 ? g0 / (g0 - gap) : 0;
            *hit = add(o, scale(d, dt * (i - 1 + f)));
            return isfinite(hit->x) && isfinite(hit->y) && isfinite(hit->z);
        }
        prev_gap = gap;
    }
    return false;
}

/* Ambient irradiance over π at a point of normal n under a water surface of normal nw and F0
 * f0: the environment enters only through the surface, each direction l_a of the hemisphere
 * above it refracted to l_w and scaled by 1 − F(l_a·nw), so it reaches the point from the cone
 * of the refracted directions (a low sun arrives steeper and weakened, a face turned away from
 * the cone gets little). E/π = (1/π) ∫ (1 − F) L(l_a) cos θ_a · max(0, n·l_w) / cos θ_w dω_a
 * (the radiance gained by entering the denser water, n², cancels the solid angle it is
 * squeezed into), estimated with UW_SAMPLES cosine-weighted directions fixed in the surface's
 * frame, L read from the prefiltered level of roughness 0.8 (a blur matching the samples'
 * spacing). A uniform environment L under a flat surface gives L · (1 − F̄) at n = nw, F̄ the
 * cosine-weighted average of water_fresnel (0.066 for index 1.33). */
static V3 under_irradiance(const PreviewJob *j, V3 n, V3 nw, float f0)
{
    V3 up = fabsf(nw.z) < 0.999f ? v3(0, 0, 1) : v3(1, 0, 0);
    V3 tx = normalize(cross(up, nw)), ty = cross(nw, tx);
    float eta = 1 / j->p->water_ior;
    V3 acc = v3(0, 0, 0);
    for (int k = 0; k < UW_SAMPLES; k++) {
        const float *s = j->uw_dirs[k];
        V3 la = add(add(scale(tx, s[0]), scale(ty, s[1])), scale(nw, s[2]));
        V3 t;
        if (!refract(scale(la, -1), nw, eta, &t)) continue; /* cannot happen entering water */
        float cw = -dot(t, nw), nl = -dot(t, n);
        if (!(nl > 0) || !(cw > 1e-4f)) continue;
        float w = (1 - water_fresnel(f0, s[2])) * nl / cw;
        acc = add(acc, scale(env_spec(j, la, 0.8f), w));
    }
    return scale(acc, 1.0f / UW_SAMPLES);
}

/* The water layer where its mask is above 0; returns false where the dry render stands. */
static bool render_wet(const PreviewJob *j, V3 d, V3 dry, V3 *out)
{
    const PreviewParams *p = j->p;
    float hs = p->height_scale;
    V3 pw = march(j, j->in[IN_WH], j->cam, d, hs * (j->wmax - 1), hs * (j->wmin - 1), 1);
    if (!inside(j, pw)) return false;
    float m = clampf(tex_gray(j->in[IN_WM], pw.x, pw.y, 0), 0, 1);
    if (!(m > 0)) return false;
    V3 nw = decode_normal(tex_color(j->in[IN_WN], pw.x, pw.y, v3(0.5f, 0.5f, 1)));
    if (nw.z < 1e-3f) nw = normalize(v3(nw.x, nw.y, 1e-3f));
    float rw = clampf(tex_gray(j->in[IN_WR], pw.x, pw.y, 0.02f), 0, 1);
    float f0 = clampf(tex_gray(j->in[IN_WS], pw.x, pw.y, j->water_f0), 0, 1);
    V3 v = scale(d, -1);
    float nv = clampf(dot(nw, v), 1e-4f, 1);
    float A, B;
    brdf_lut(j, nv, rw, &A, &B);
    float ms, fss = ms_weights(f0, A, B, &ms);
    /* the split-sum table follows the index-1.5 curve; scaled to the water's own at n·v (exact
     * for a smooth surface, which water nearly always is) */
    float fc = fresnel(f0, nv), kf = fc > 1e-6f ? water_fresnel(f0, nv) / fc : 1;
    fss *= kf, ms *= kf;
    float e = fminf(fss + ms, 1); /* what the surface reflects; 1 − e crosses it */
    V3 rr = reflect(d, nw), q;
    V3 mirror = relief_above(j, pw, rr, &q) ? shade_relief(j, q, rr)
                                            : env_spec(j, dominant_dir(nw, rr, rw), rw);
    V3 top = add(scale(mirror, fss), scale(env_irr(j, nw), ms));
    V3 sun_under = v3(0, 0, 0), sun_l = j->sun_dir;
    if (p->sun) {
        /* the water's own highlight: a dielectric of F0 f0 without diffuse part */
        float nl = dot(nw, j->sun_dir);
        if (nl > 0) {
            V3 hv = normalize(add(v, j->sun_dir));
            float nh = clampf(dot(nw, hv), 0, 1), vh = clampf(dot(v, hv), 0, 1);
            float a = rw * rw;
            if (a < 2e-3f) a = 2e-3f;
            float a2 = a * a, dd = nh * nh * (a2 - 1) + 1;
            float D = a2 / ((float)M_PI * dd * dd);
            float s = D * (float)vis_smith(nv, nl, a) * water_fresnel(f0, vh) * nl;
            top = add(top, scale(j->sun_rad, s));
            V3 t;
            if (refract(scale(j->sun_dir, -1), nw, 1 / p->water_ior, &t)) {
                sun_l = scale(t, -1);
                sun_under = scale(j->sun_rad, 1 - water_fresnel(f0, nl));
            }
        }
    }
    V3 t;
    if (!refract(d, nw, 1 / p->water_ior, &t) || t.z >= 0) t = d;
    V3 pu = march(j, j->in[IN_HEIGHT], pw, t, pw.z, hs * (j->hmin - 1), 1);
    V3 base, n;
    float rough, metal, spec, ao;
    material_at(j, pu, &base, &n, &rough, &metal, &spec, &ao);
    /* under the surface: the ambient light that crosses it, and the reflection, which leaves
     * through the surface (scaled by 1 − F) or, beyond the critical angle, is reflected back
     * down and sees the submerged floor, taken as this point's own diffuse radiance */
    V3 irr = under_irradiance(j, n, nw, f0), rad;
    V3 rw_dir = dominant_dir(n, reflect(t, n), rough), ra;
    float kd = under_water_gain(f0);
    if (dot(rw_dir, nw) > 0 && refract(rw_dir, scale(nw, -1), p->water_ior, &ra))
        rad = scale(env_spec(j, ra, rough), 1 - water_fresnel(f0, dot(ra, nw)));
    else
        rad = mul(irr, scale(base, (1 - metal) * kd));
    V3 under =
        shade(j, scale(t, -1), n, base, rough, metal, spec, ao, irr, rad, sun_l, sun_under, kd);
    float path = 0;
    if (hs > 0) {
        V3 dp = sub(pw, pu);
        path = (sqrtf(dot(dp, dp)) + fmaxf(pw.z - pu.z, 0)) / hs;
    }
    float k = path / p->absorption_depth;
    V3 tint = j->in[IN_WT] ? tex_color(j->in[IN_WT], pw.x, pw.y, v3(1, 1, 1))
                           : v3(p->water_tint[0], p->water_tint[1], p->water_tint[2]);
    V3 tr = v3(powf(clampf(tint.x, 0, 1), k), powf(clampf(tint.y, 0, 1), k),
               powf(clampf(tint.z, 0, 1), k));
    V3 wet = add(top, scale(mul(under, tr), 1 - e));
    *out = m >= 1 ? wet : add(scale(dry, 1 - m), scale(wet, m));
    return true;
}

static float aces(float x)
{
    return clampf(x * (2.51f * x + 0.03f) / (x * (2.43f * x + 0.59f) + 0.14f), 0, 1);
}

static float srgb_encode(float x)
{
    return x <= 0.0031308f ? 12.92f * x : 1.055f * powf(x, 1 / 2.4f) - 0.055f;
}

static float finish(const PreviewJob *j, float x)
{
    x *= j->expo;
    if (!isfinite(x) || x < 0) x = x > 0 ? 1e30f : 0;
    if (j->p->tonemap == TONEMAP_ACES) x = aces(x);
    if (j->p->encoding == ENCODING_SRGB) x = srgb_encode(clampf(x, 0, 1));
    return isfinite(x) ? x : 0;
}

static void preview_rows(void *user, int y0, int y1)
{
    const PreviewJob *j = user;
    float aspect = (float)j->w / j->h;
    for (int y = y0; y < y1; y++) {
        float *o = wg_image_row(j->out, y);
        for (int x = 0; x < j->w; x++) {
            float u = (2 * (x + 0.5f) / j->w - 1) * aspect, v = 1 - 2 * (y + 0.5f) / j->h;
            V3 d = normalize(
                add(j->fwd, scale(add(scale(j->right, u), scale(j->up, v)), j->tan_half)));
            V3 c;
            if (d.z >= 0) {
                c = background(j, d);
            } else {
                c = render_dry(j, d);
                if (j->in[IN_WM]) {
                    V3 wet;
                    if (render_wet(j, d, c, &wet)) c = wet;
                }
            }
            o[4 * x + 0] = finish(j, c.x);
            o[4 * x + 1] = finish(j, c.y);
            o[4 * x + 2] = finish(j, c.z);
            o[4 * x + 3] = 1;
        }
    }
}

static void height_range(const WgImage *img, float *lo, float *hi)
{
    *lo = 1, *hi = 1;
    if (!img) return;
    float a = 1e30f, b = -1e30f;
    for (int y = 0; y < img->height; y++) {
        const float *r = wg_image_row(img, y);
        for (int x = 0; x < img->width; x++) {
            float v = clampf(isfinite(r[x]) ? r[x] : 1, -16, 16);
            a = v < a ? v : a, b = v > b ? v : b;
        }
    }
    *lo = a < 1 ? a : 1, *hi = b > 1 ? b : 1;
    /* heights interpolate between texels: the bilinear surface stays within [lo, hi] */
}

static int preview_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const PreviewParams *p = ctx->params;
    PreviewJob j = {.p = p, .out = ctx->outputs[0], .w = ctx->width, .h = ctx->height};
    for (int i = 0; i < N_IN; i++) j.in[i] = ctx->inputs[i];
    const float deg = (float)(M_PI / 180);
    float el = p->elevation * deg, az = p->azimuth * deg;
    V3 back = v3(sinf(az) * cosf(el), -cosf(az) * cosf(el), sinf(el)); /* towards the camera */
    j.right = v3(cosf(az), sinf(az), 0);
    j.up = normalize(cross(back, j.right));
    j.fwd = scale(back, -1);
    j.span = p->repeat ? 2 : 1;
    j.tan_half = tanf(p->fov * deg / 2);
    float dist = 0.5f * j.span / p->zoom / j.tan_half;
    j.cam = add(v3(0.5f * j.span, 0.5f * j.span, 0), scale(back, dist));
    j.rot = p->env_rotation * deg;
    j.expo = exp2f(p->exposure);
    height_range(j.in[IN_HEIGHT], &j.hmin, &j.hmax);
    height_range(j.in[IN_WH], &j.wmin, &j.wmax);
    if (!j.in[IN_WH]) j.wmin = j.hmin, j.wmax = j.hmax, j.in[IN_WH] = j.in[IN_HEIGHT];
    float se = p->sun_elevation * deg, sa = p->sun_azimuth * deg;
    j.sun_dir = v3(cosf(se) * cosf(sa), cosf(se) * sinf(sa), sinf(se));
    j.sun_rad = scale(v3(p->sun_color[0], p->sun_color[1], p->sun_color[2]), p->sun_intensity);
    float r = (p->water_ior - 1) / (p->water_ior + 1);
    j.water_f0 = r * r;
    for (int k = 0; k < UW_SAMPLES; k++) {
        /* Hammersley points, cosine-weighted: r = √u1, φ = 2π u2 */
        double u1 = (k + 0.5) / UW_SAMPLES, u2 = radical_inverse((unsigned)k);
        double rr = sqrt(u1), ph = 2 * M_PI * u2;
        j.uw_dirs[k][0] = (float)(rr * cos(ph)), j.uw_dirs[k][1] = (float)(rr * sin(ph));
        j.uw_dirs[k][2] = (float)sqrt(1 - u1);
    }
    return wg_parallel_rows(ctx, ctx->height, preview_rows, &j);
}

const WgNodeType wg_node_preview = {
    .name = "preview",
    .summary = "Physically based picture of a material tile, optionally under water",
    .category = "render",
    .doc = "Renders the tile (2 x 2 with repeat) from a perspective camera, the relief by "
           "parallax occlusion mapping of height (1 is the tile's plane, 0 lies height_scale "
           "tile widths below), GGX/Smith/Fresnel specular and Lambert diffuse lit by an "
           "env_prefilter atlas (environment input, split sum with multiple scattering restored) "
           "and an optional sun; F0 = 0.08 x specular (0.5 unconnected) for dielectrics. With "
           "water_mask, a "
           "water layer (water_height, water_normal, water_roughness, water_specular as F0) "
           "reflects, refracts the view ray into the material below and absorbs along the path "
           "(water_tint over absorption_depth: the water_tint input where connected, else the "
           "parameter, clear by default); where the mask is 0 the result "
           "is the dry render "
           "exactly. Filmic curve: Narkowicz's ACES fit. docs/preview.md describes the model.",
    .params = preview_params,
    .params_size = sizeof(PreviewParams),
    .inputs = preview_in,
    .outputs = preview_out,
    .flags = WG_NODE_GLOBAL,
    .eval = preview_eval,
};
