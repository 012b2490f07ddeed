/* SPDX-License-Identifier: MIT */
/* `noise`: tileable lattice noise and its fractal sums. Kinds: value noise (a random value per
 * lattice point, quintic-smoothed bilinear), Perlin gradient noise (Perlin 2002, "Improving
 * noise": quintic fade, here with 16 unit gradient directions in 2D), simplex-style noise
 * (Perlin 2001 / Gustavson 2005: radial kernels (r²-d²)⁴ around the corners of equilateral
 * triangles, here on a triangular lattice with an even number of rows so that it tiles) and white
 * noise (one random value per cell, no interpolation). Octave o has scale·lacunarity^o cells
 * across the width and weight persistence^o. Everything tiles because every octave has a whole
 * number of cells per tile in both directions and lattice indices wrap modulo that count; pixel
 * centres are mapped to lattice coordinates in exact integer arithmetic, so the same point of
 * the tile gets the same value at any resolution and the wrap is exact. Randomness is a hash of
 * (lattice index, octave, seed); nothing depends on the thread count. Each octave is normalised
 * by its exact bound (value: 1, Perlin: √2/2, simplex: 1/16), so the output needs no clamping
 * (a final clamp to [0,1] only absorbs float rounding). Speed: when an octave has at most one
 * lattice column per pixel, a row is evaluated per lattice cell (gradients cached per cell row,
 * each cell reduced to a linear function of the column's fraction), else per pixel. */
#include "wetgraph/node.h"
#include "hot.h"

#include <math.h>
#include <string.h>

enum { K_VALUE, K_PERLIN, K_SIMPLEX, K_WHITE };
enum { M_NORMAL, M_TURBULENCE, M_RIDGED };
static const char *const kind_values[] = {"value", "perlin", "simplex", "white", NULL};
static const char *const mode_values[] = {"normal", "turbulence", "ridged", NULL};

#define MAX_OCTAVES 16

typedef struct {
    int kind;
    int scale;
    int octaves;
    float persistence;
    int lacunarity;
    int mode;
} NoiseParams;

static const WgParamSpec noise_params[] = {
    WG_PARAM_ENUM(NoiseParams, kind, "Noise kind", 1, kind_values),
    WG_PARAM_INT(NoiseParams, scale, "Cells across the width at the first octave", 8, 1, 16384),
    WG_PARAM_INT(NoiseParams, octaves, "Number of octaves (0: flat 0.5)", 6, 0, MAX_OCTAVES),
    WG_PARAM_FLOAT(NoiseParams, persistence, "Weight ratio between octaves", 0.5, 0.0, 1.0),
    WG_PARAM_INT(NoiseParams, lacunarity, "Cell count ratio between octaves", 2, 1, 4),
    WG_PARAM_ENUM(NoiseParams, mode, "How octaves are summed", 0, mode_values),
    WG_PARAM_END,
};
static const WgPortSpec noise_out[] = {WG_PORT("output", WG_GRAY), WG_PORT_END};

/* 16 unit gradient directions k·22.5°, pre-scaled by the inverse of each kind's bound. */
#define C8 0.92387953251128674f
#define S8 0.38268343236508977f
#define R2 0.70710678118654752f
/* clang-format off */
#define DIRS(s)                                                                                    \
    {(s) * 1, (s) * C8, (s) * R2, (s) * S8, 0, -(s) * S8, -(s) * R2, -(s) * C8,                    \
     -(s) * 1, -(s) * C8, -(s) * R2, -(s) * S8, 0, (s) * S8, (s) * R2, (s) * C8}
#define DIRS_Y(s)                                                                                  \
    {0, (s) * S8, (s) * R2, (s) * C8, (s) * 1, (s) * C8, (s) * R2, (s) * S8,                       \
     0, -(s) * S8, -(s) * R2, -(s) * C8, -(s) * 1, -(s) * C8, -(s) * R2, -(s) * S8}
/* clang-format on */
/* Perlin 2D with unit gradients peaks at √2/2 (cell centre, all gradients pointing in). */
static const float perlin_gx[16] = DIRS(1.41421356237309505f);
static const float perlin_gy[16] = DIRS_Y(1.41421356237309505f);
/* The triangular-lattice kernel sum peaks at 1/16 (edge midpoint, both gradients along the
 * edge); found by exhaustive search over the triangle, attained by the k·22.5° set. */
static const float simplex_gx[16] = DIRS(16.0f);
static const float simplex_gy[16] = DIRS_Y(16.0f);

#define H3 0.86602540378443865f /* row height of the triangular lattice */

/* ---- lattice helpers --------------------------------------------------------------------- */

/* Pixel p of n samples the axis at (p + 0.5)/n of the tile, i.e. at lattice coordinate
 * (2p+1)·period/(2n) = cell + frac, computed exactly (period < 2^58, n <= 16384). */
static inline void axis_coord(uint64_t period, int n, int p, uint64_t *cell, float *frac)
{
    uint64_t two_n = 2 * (uint64_t)n, k = 2 * (uint64_t)p + 1;
    uint64_t q = period / two_n, r = period % two_n, kr = k * r;
    *cell = k * q + kr / two_n;
    *frac = (float)((double)(kr % two_n) / (double)two_n);
}

/* Key of a lattice index: j ^ K0 below 2^32 (coarse octaves use that form directly); larger
 * indices fold their high half in through a hash. */
#define K0 0x5a6bc3e1u
static inline uint32_t lattice_key(uint64_t i)
{
    return (uint32_t)i ^ (i >> 32 ? wg_hash_u32((uint32_t)(i >> 32) ^ 0x5bd1e995u) : K0);
}

static inline uint64_t wrap_next(uint64_t i, uint64_t period)
{
    return i + 1 == period ? 0 : i + 1;
}

static inline float fade(float t)
{
    return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
}

/* A value in [-1, 1) from a hash. */
static inline float hash_signed(uint32_t h)
{
    return (float)(h >> 8) * 0x1p-23f - 1.0f;
}

/* ---- job --------------------------------------------------------------------------------- */

typedef struct {
    uint64_t px, py; /* lattice cells across and down (simplex: triangle columns, rows) */
    uint32_t seed;
    float amp;
    bool coarse; /* px <= width: per-row tables over lattice columns */
    bool wide;   /* coarse with cells >= 8 pixels wide: loop over cells, then pixels */
    /* column tables (width entries) */
    uint64_t *ix;
    int32_t *cell; /* coarse: ix as int */
    float *fx, *sx;
    uint32_t *k0, *k1; /* fine: keys of the lattice columns left and right of each pixel */
    int *run;          /* wide: run[j] = first pixel of lattice column j, j = 0..px */
    size_t cache_at;   /* coarse: offset of this octave's band cache in a scratch */
} Octave;

typedef struct {
    float *row, *a, *b, *a2, *b2, *cache;
    int64_t band[MAX_OCTAVES]; /* lattice row the band cache holds, -1: none */
} Scratch;

typedef struct {
    const NoiseParams *p;
    WgImage *out;
    int n_oct;
    Octave oct[MAX_OCTAVES];
    double amp_sum;
    int n_bands;
    Scratch *scratch;
} Job;

/* ---- one octave of one row --------------------------------------------------------------- */

typedef struct {
    uint64_t iy;
    float fy;
    uint32_t ry0, ry1; /* keys of the lattice rows above and below */
} RowCoord;

static RowCoord row_coord(const Octave *o, int h, int y)
{
    RowCoord r;
    axis_coord(o->py, h, y, &r.iy, &r.fy);
    r.ry0 = wg_hash_u32(lattice_key(r.iy) ^ o->seed);
    r.ry1 = wg_hash_u32(lattice_key(wrap_next(r.iy, o->py)) ^ o->seed);
    return r;
}

/* Band caches hold, per lattice column, data of the two lattice rows around the current row
 * (structure of arrays, `stride` floats apart), refilled when the row enters a new cell. */
static inline size_t cache_stride(const Octave *o)
{
    return (size_t)o->px + 4;
}

/* Coarse rows: along a row, lattice cell j is n(fx) = l + s(fx)·(r − l) with l = a_j + b_j·fx
 * and r = a2_j + b2_j·fx, so a pixel costs a few flops. Wide cells loop over their pixels
 * (contiguous, vectorised); narrow ones gather per pixel. */
static inline void lerp_cells(const Octave *o, const Scratch *s, int w, float *out)
{
    const float *a = s->a, *b = s->b, *a2 = s->a2, *b2 = s->b2, *fx = o->fx, *sx = o->sx;
    if (o->wide) {
        for (uint64_t j = 0; j < o->px; j++) {
            float al = a[j], bl = b[j], ar = a2[j], br = b2[j];
            for (int x = o->run[j]; x < o->run[j + 1]; x++) {
                float l = al + bl * fx[x], r = ar + br * fx[x];
                out[x] = l + sx[x] * (r - l);
            }
        }
        return;
    }
    const int32_t *cell = o->cell;
    for (int x = 0; x < w; x++) {
        int32_t i = cell[x];
        float l = a[i] + b[i] * fx[x], r = a2[i] + b2[i] * fx[x];
        out[x] = l + sx[x] * (r - l);
    }
}

HOT static void perlin_row(const Octave *o, Scratch *s, int oi, const RowCoord *rc, int w,
                           float *out)
{
    float fy = rc->fy, sy = fade(fy);
    if (o->coarse) {
        size_t st = cache_stride(o);
        float *g0x = s->cache + o->cache_at, *g0y = g0x + st, *g1x = g0y + st, *g1y = g1x + st;
        uint64_t n = o->px;
        if (s->band[oi] != (int64_t)rc->iy) {
            for (uint64_t j = 0; j < n; j++) {
                uint32_t h0 = wg_hash_u32(((uint32_t)j ^ K0) ^ rc->ry0) >> 28;
                uint32_t h1 = wg_hash_u32(((uint32_t)j ^ K0) ^ rc->ry1) >> 28;
                g0x[j] = perlin_gx[h0];
                g0y[j] = perlin_gy[h0];
                g1x[j] = perlin_gx[h1];
                g1y[j] = perlin_gy[h1];
            }
            g0x[n] = g0x[0];
            g0y[n] = g0y[0];
            g1x[n] = g1x[0];
            g1y[n] = g1y[0];
            s->band[oi] = (int64_t)rc->iy;
        }
        /* corner column j contributes (1-sy)·g0·(fx, fy) + sy·g1·(fx, fy-1) = a_j + b_j·fx */
        float *a = s->a, *b = s->b, *a2 = s->a2, *b2 = s->b2;
        for (uint64_t j = 0; j <= n; j++) {
            a[j] = (1 - sy) * g0y[j] * fy + sy * g1y[j] * (fy - 1);
            b[j] = (1 - sy) * g0x[j] + sy * g1x[j];
        }
        for (uint64_t j = 0; j < n; j++) {
            b2[j] = b[j + 1];
            a2[j] = a[j + 1] - b[j + 1];
        }
        lerp_cells(o, s, w, out);
        return;
    }
    for (int x = 0; x < w; x++) {
        float fx = o->fx[x];
        uint32_t h00 = wg_hash_u32(o->k0[x] ^ rc->ry0) >> 28;
        uint32_t h10 = wg_hash_u32(o->k1[x] ^ rc->ry0) >> 28;
        uint32_t h01 = wg_hash_u32(o->k0[x] ^ rc->ry1) >> 28;
        uint32_t h11 = wg_hash_u32(o->k1[x] ^ rc->ry1) >> 28;
        float l = (1 - sy) * (perlin_gx[h00] * fx + perlin_gy[h00] * fy) +
                  sy * (perlin_gx[h01] * fx + perlin_gy[h01] * (fy - 1));
        float r = (1 - sy) * (perlin_gx[h10] * (fx - 1) + perlin_gy[h10] * fy) +
                  sy * (perlin_gx[h11] * (fx - 1) + perlin_gy[h11] * (fy - 1));
        out[x] = l + o->sx[x] * (r - l);
    }
}

HOT static void value_row(const Octave *o, Scratch *s, int oi, const RowCoord *rc, int w,
                          float *out)
{
    float sy = fade(rc->fy);
    if (o->coarse) {
        size_t st = cache_stride(o);
        float *v0 = s->cache + o->cache_at, *v1 = v0 + st;
        uint64_t n = o->px;
        if (s->band[oi] != (int64_t)rc->iy) {
            for (uint64_t j = 0; j < n; j++) {
                v0[j] = hash_signed(wg_hash_u32(((uint32_t)j ^ K0) ^ rc->ry0));
                v1[j] = hash_signed(wg_hash_u32(((uint32_t)j ^ K0) ^ rc->ry1));
            }
            v0[n] = v0[0];
            v1[n] = v1[0];
            s->band[oi] = (int64_t)rc->iy;
        }
        float *a = s->a, *b = s->b, *a2 = s->a2, *b2 = s->b2;
        for (uint64_t j = 0; j <= n; j++) a[j] = v0[j] + sy * (v1[j] - v0[j]);
        for (uint64_t j = 0; j < n; j++) {
            a2[j] = a[j + 1];
            b[j] = b2[j] = 0;
        }
        lerp_cells(o, s, w, out);
        return;
    }
    for (int x = 0; x < w; x++) {
        float v00 = hash_signed(wg_hash_u32(o->k0[x] ^ rc->ry0));
        float v10 = hash_signed(wg_hash_u32(o->k1[x] ^ rc->ry0));
        float v01 = hash_signed(wg_hash_u32(o->k0[x] ^ rc->ry1));
        float v11 = hash_signed(wg_hash_u32(o->k1[x] ^ rc->ry1));
        float l = v00 + sy * (v01 - v00), r = v10 + sy * (v11 - v10);
        out[x] = l + o->sx[x] * (r - l);
    }
}

HOT static void white_row(const Octave *o, Scratch *s, int oi, const RowCoord *rc, int w,
                          float *out)
{
    if (o->coarse) {
        float *v = s->cache + o->cache_at;
        if (s->band[oi] != (int64_t)rc->iy) {
            for (uint64_t j = 0; j < o->px; j++)
                v[j] = hash_signed(wg_hash_u32(((uint32_t)j ^ K0) ^ rc->ry0));
            s->band[oi] = (int64_t)rc->iy;
        }
        for (int x = 0; x < w; x++) out[x] = v[o->cell[x]];
        return;
    }
    for (int x = 0; x < w; x++) out[x] = hash_signed(wg_hash_u32(o->k0[x] ^ rc->ry0));
}

/* Simplex-style noise on a triangular lattice: row j of vertices lies at height j·√3/2 and is
 * shifted right by half a cell when j is odd (py is even, so the pattern wraps). In the band
 * between rows j and j+1, with s = ±1/2 the shift of the upper row relative to the lower one,
 * the point (xb, ty) has skewed coordinates α = xb − s·ty, β = ty; the four corners of the
 * parallelogram cell floor(α) hold the containing triangle, and corners further than √3/2 (the
 * inradius of a vertex's hexagon, the kernel radius) contribute exactly zero. floor(α) is the
 * pixel's column index plus k ∈ {−1, 0}. */
static inline float corner(float gx, float gy, float dx, float dy)
{
    float t = 0.75f - dx * dx - dy * dy;
    t = 0.5f * (t + fabsf(t)); /* max(t, 0) without a branch, so the loops vectorise */
    t *= t;
    return t * t * (gx * dx + gy * dy);
}

/* Pixels [x0, x1) of one parallelogram cell (cache index i): constant gradients. */
static inline void simplex_span(float *out, const float *fxs, int x0, int x1, float base, float k,
                                float shty, float sh, float dy0, float dy1, const float *g0x,
                                const float *g0y, const float *g1x, const float *g1y, int32_t i)
{
    float ax = g0x[i], ay = g0y[i], bx = g0x[i + 1], by = g0y[i + 1];
    float cx = g1x[i], cy = g1y[i], dx_ = g1x[i + 1], dy_ = g1y[i + 1];
    for (int x = x0; x < x1; x++) {
        float t = fxs[x] + base;
        float dx = t - k + shty;
        out[x] = corner(ax, ay, dx, dy0) + corner(bx, by, dx - 1, dy0) +
                 corner(cx, cy, dx - sh, dy1) + corner(dx_, dy_, dx - 1 - sh, dy1);
    }
}

HOT static void simplex_row(const Octave *o, Scratch *s, int oi, const RowCoord *rc, int w,
                            float *out)
{
    float ty = rc->fy;
    float ob = (rc->iy & 1) ? 0.5f : 0.0f;
    float sh = (rc->iy & 1) ? -0.5f : 0.5f; /* upper row shift relative to the lower one */
    float dy0 = ty * H3, dy1 = dy0 - H3;
    float base = -ob - sh * ty, shty = sh * ty;
    if (o->coarse) {
        /* columns -1 .. px+1 live at index c+1 */
        size_t st = cache_stride(o);
        float *g0x = s->cache + o->cache_at, *g0y = g0x + st, *g1x = g0y + st, *g1y = g1x + st;
        uint64_t n = o->px;
        if (s->band[oi] != (int64_t)rc->iy) {
            for (uint64_t j = 0; j < n; j++) {
                uint32_t h0 = wg_hash_u32(((uint32_t)j ^ K0) ^ rc->ry0) >> 28;
                uint32_t h1 = wg_hash_u32(((uint32_t)j ^ K0) ^ rc->ry1) >> 28;
                g0x[j + 1] = simplex_gx[h0];
                g0y[j + 1] = simplex_gy[h0];
                g1x[j + 1] = simplex_gx[h1];
                g1y[j + 1] = simplex_gy[h1];
            }
            float *arr[4] = {g0x, g0y, g1x, g1y};
            for (int k = 0; k < 4; k++) {
                arr[k][0] = arr[k][n];                 /* column -1 = px-1 */
                arr[k][n + 1] = arr[k][1];             /* column px = 0 */
                arr[k][n + 2] = arr[k][n > 1 ? 2 : 1]; /* column px+1 = 1 mod px */
            }
            s->band[oi] = (int64_t)rc->iy;
        }
        const int32_t *cell = o->cell;
        const float *fxs = o->fx;
        if (o->wide) {
            /* within lattice column j, the pixels with k = -1 (t < 0) come first */
            for (uint64_t j = 0; j < n; j++) {
                int e = o->run[j + 1], m = o->run[j];
                while (m < e && (fxs[m] + base) + 1.0f < 1.0f) m++;
                simplex_span(out, fxs, o->run[j], m, base, -1.0f, shty, sh, dy0, dy1, g0x, g0y, g1x,
                             g1y, (int32_t)j);
                simplex_span(out, fxs, m, e, base, 0.0f, shty, sh, dy0, dy1, g0x, g0y, g1x, g1y,
                             (int32_t)j + 1);
            }
            return;
        }
        for (int x = 0; x < w; x++) {
            float t = fxs[x] + base;
            int32_t k = (int32_t)(t + 1.0f) - 1; /* floor(t), t in (-1, 1) */
            float dx = t - (float)k + shty;
            int32_t i = cell[x] + k + 1;
            out[x] = corner(g0x[i], g0y[i], dx, dy0) + corner(g0x[i + 1], g0y[i + 1], dx - 1, dy0) +
                     corner(g1x[i], g1y[i], dx - sh, dy1) +
                     corner(g1x[i + 1], g1y[i + 1], dx - 1 - sh, dy1);
        }
        return;
    }
    for (int x = 0; x < w; x++) {
        float t = o->fx[x] + base;
        int32_t k = (int32_t)(t + 1.0f) - 1;
        float dx = t - (float)k + shty;
        uint64_t i = o->ix[x];
        if (k) i = i == 0 ? o->px - 1 : i - 1;
        uint32_t ka = lattice_key(i), kb = lattice_key(wrap_next(i, o->px));
        uint32_t h00 = wg_hash_u32(ka ^ rc->ry0) >> 28, h10 = wg_hash_u32(kb ^ rc->ry0) >> 28;
        uint32_t h01 = wg_hash_u32(ka ^ rc->ry1) >> 28, h11 = wg_hash_u32(kb ^ rc->ry1) >> 28;
        out[x] = corner(simplex_gx[h00], simplex_gy[h00], dx, dy0) +
                 corner(simplex_gx[h10], simplex_gy[h10], dx - 1, dy0) +
                 corner(simplex_gx[h01], simplex_gy[h01], dx - sh, dy1) +
                 corner(simplex_gx[h11], simplex_gy[h11], dx - 1 - sh, dy1);
    }
}

/* ---- rows -------------------------------------------------------------------------------- */

HOT static void accumulate(int mode, bool first, float amp, const float *n, int w, float *out)
{
    if (first) {
        switch (mode) {
        case M_NORMAL:
            for (int x = 0; x < w; x++) out[x] = amp * n[x];
            break;
        case M_TURBULENCE:
            for (int x = 0; x < w; x++) out[x] = amp * fabsf(n[x]);
            break;
        default:
            for (int x = 0; x < w; x++) {
                float r = 1 - fabsf(n[x]);
                out[x] = amp * r * r;
            }
            break;
        }
        return;
    }
    switch (mode) {
    case M_NORMAL:
        for (int x = 0; x < w; x++) out[x] += amp * n[x];
        break;
    case M_TURBULENCE:
        for (int x = 0; x < w; x++) out[x] += amp * fabsf(n[x]);
        break;
    default:
        for (int x = 0; x < w; x++) {
            float r = 1 - fabsf(n[x]);
            out[x] += amp * r * r;
        }
        break;
    }
}

HOT static void finish(float offset, float k, int w, float *out)
{
    for (int x = 0; x < w; x++) {
        float v = offset + out[x] * k;
        out[x] = v < 0 ? 0 : v > 1 ? 1 : v;
    }
}

static void noise_bands(void *user, int b0, int b1)
{
    const Job *j = user;
    const NoiseParams *p = j->p;
    int w = j->out->width, h = j->out->height;
    for (int b = b0; b < b1; b++) {
        Scratch *s = &j->scratch[b];
        int y0 = (int)((long long)b * h / j->n_bands);
        int y1 = (int)((long long)(b + 1) * h / j->n_bands);
        for (int y = y0; y < y1; y++) {
            float *out = wg_image_row(j->out, y);
            if (j->n_oct == 0) {
                for (int x = 0; x < w; x++) out[x] = 0.5f;
                continue;
            }
            for (int oi = 0; oi < j->n_oct; oi++) {
                const Octave *o = &j->oct[oi];
                RowCoord rc = row_coord(o, h, y);
                switch (p->kind) {
                case K_VALUE:
                    value_row(o, s, oi, &rc, w, s->row);
                    break;
                case K_PERLIN:
                    perlin_row(o, s, oi, &rc, w, s->row);
                    break;
                case K_SIMPLEX:
                    simplex_row(o, s, oi, &rc, w, s->row);
                    break;
                default:
                    white_row(o, s, oi, &rc, w, s->row);
                    break;
                }
                accumulate(p->mode, oi == 0, o->amp, s->row, w, out);
            }
            float k = (float)(1.0 / j->amp_sum);
            if (p->mode == M_NORMAL)
                finish(0.5f, 0.5f * k, w, out);
            else
                finish(0.0f, k, w, out);
        }
    }
}

/* ---- setup ------------------------------------------------------------------------------- */

static void job_free(Job *j)
{
    for (int i = 0; i < MAX_OCTAVES; i++) {
        Octave *o = &j->oct[i];
        wg_free(o->ix);
        wg_free(o->cell);
        wg_free(o->fx);
        wg_free(o->sx);
        wg_free(o->k0);
        wg_free(o->k1);
        wg_free(o->run);
    }
    if (j->scratch)
        for (int b = 0; b < j->n_bands; b++) {
            wg_free(j->scratch[b].row);
            wg_free(j->scratch[b].a);
            wg_free(j->scratch[b].b);
            wg_free(j->scratch[b].a2);
            wg_free(j->scratch[b].b2);
            wg_free(j->scratch[b].cache);
        }
    wg_free(j->scratch);
}

static int octave_setup(Octave *o, int kind, int w, size_t *cache_floats, size_t *ab_floats)
{
    size_t n = (size_t)w;
    o->ix = wg_malloc(n * sizeof(uint64_t));
    o->fx = wg_malloc(n * sizeof(float));
    o->sx = wg_malloc(n * sizeof(float));
    if (!o->ix || !o->fx || !o->sx) return WG_ERR_NOMEM;
    for (int x = 0; x < w; x++) {
        axis_coord(o->px, w, x, &o->ix[x], &o->fx[x]);
        o->sx[x] = fade(o->fx[x]);
    }
    o->coarse = o->px <= (uint64_t)w;
    if (o->coarse) {
        o->wide = o->px * 4 <= (uint64_t)w;
        o->cell = wg_malloc(n * sizeof(int32_t));
        o->run = wg_malloc((size_t)(o->px + 1) * sizeof(int));
        if (!o->cell || !o->run) return WG_ERR_NOMEM;
        uint64_t j = 0;
        for (int x = 0; x < w; x++) {
            o->cell[x] = (int32_t)o->ix[x];
            while (j <= o->ix[x]) o->run[j++] = x;
        }
        while (j <= o->px) o->run[j++] = w;
        o->cache_at = *cache_floats;
        *cache_floats += 4 * (size_t)(o->px + 4);
        if ((size_t)o->px + 4 > *ab_floats) *ab_floats = (size_t)o->px + 4;
    } else if (kind != K_SIMPLEX) {
        o->k0 = wg_malloc(n * sizeof(uint32_t));
        o->k1 = wg_malloc(n * sizeof(uint32_t));
        if (!o->k0 || !o->k1) return WG_ERR_NOMEM;
        for (int x = 0; x < w; x++) {
            o->k0[x] = lattice_key(o->ix[x]);
            o->k1[x] = lattice_key(wrap_next(o->ix[x], o->px));
        }
    }
    return WG_OK;
}

static uint64_t rows_for(int scale, int w, int h)
{
    double r = floor((double)scale * h / w + 0.5);
    return r < 1 ? 1 : (uint64_t)r;
}

static int noise_eval(WgNodeContext *ctx, WgError *err)
{
    const NoiseParams *p = ctx->params;
    int w = ctx->width, h = ctx->height;
    Job j;
    memset(&j, 0, sizeof j);
    j.p = p;
    j.out = ctx->outputs[0];
    /* lattice rows: square cells (simplex: an even number of triangle rows, √3/2 high) */
    uint64_t px = (uint64_t)p->scale, py;
    if (p->kind == K_SIMPLEX) {
        double r = floor((double)p->scale * h / (w * 1.7320508075688772) + 0.5);
        py = 2 * (r < 1 ? 1 : (uint64_t)r);
    } else {
        py = rows_for(p->scale, w, h);
    }
    uint32_t seed = wg_hash3((uint32_t)ctx->seed, (uint32_t)(ctx->seed >> 32), 0x6e6f6973u);
    double amp = 1;
    size_t cache_floats = 0, ab_floats = 1;
    int rc = WG_OK;
    for (int o = 0; o < p->octaves && amp > 0; o++) {
        Octave *oc = &j.oct[j.n_oct++];
        oc->px = px;
        oc->py = py;
        oc->seed = wg_hash_u32(seed ^ wg_hash_u32((uint32_t)o + 0x9e3779b9u));
        oc->amp = (float)amp;
        j.amp_sum += (float)amp;
        if ((rc = octave_setup(oc, p->kind, w, &cache_floats, &ab_floats))) break;
        amp *= p->persistence;
        px *= (uint64_t)p->lacunarity;
        py *= (uint64_t)p->lacunarity;
    }
    if (!rc) {
        j.n_bands = wg_parallel_chunks(h);
        j.scratch = wg_calloc((size_t)j.n_bands, sizeof(Scratch));
        if (!j.scratch) rc = WG_ERR_NOMEM;
        for (int b = 0; !rc && b < j.n_bands; b++) {
            Scratch *s = &j.scratch[b];
            s->row = wg_malloc((size_t)w * sizeof(float));
            s->a = wg_malloc(ab_floats * sizeof(float));
            s->b = wg_malloc(ab_floats * sizeof(float));
            s->a2 = wg_malloc(ab_floats * sizeof(float));
            s->b2 = wg_malloc(ab_floats * sizeof(float));
            s->cache = wg_malloc((cache_floats ? cache_floats : 1) * sizeof(float));
            if (!s->row || !s->a || !s->b || !s->a2 || !s->b2 || !s->cache) rc = WG_ERR_NOMEM;
            for (int o = 0; o < MAX_OCTAVES; o++) s->band[o] = -1;
        }
    }
    if (rc) {
        job_free(&j);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    /* one call per band of rows, so each band owns its scratch (bands depend on h only) */
    rc = wg_parallel_rows(ctx, j.n_bands, noise_bands, &j);
    job_free(&j);
    return rc;
}

/* What noise_eval and octave_setup allocate: per octave the column tables, per band of rows a
 * row, the four interpolation rows and the lattice cache of the coarse octaves. */
static size_t noise_scratch(const WgNodeContext *ctx)
{
    const NoiseParams *p = ctx->params;
    size_t w = (size_t)ctx->width, cache = 0, ab = 1, octaves = 0;
    uint64_t px = (uint64_t)p->scale;
    double amp = 1;
    for (int o = 0; o < p->octaves && amp > 0; o++) {
        octaves++;
        if (px <= (uint64_t)w) {
            cache += 4 * (size_t)(px + 4);
            if ((size_t)px + 4 > ab) ab = (size_t)px + 4;
        }
        amp *= p->persistence;
        px *= (uint64_t)p->lacunarity;
    }
    size_t per_octave = w * (8 + 4 + 4) + w * 8 + 4 * (w + 2);
    size_t per_band = 4 * (w + 4 * ab + cache + 1);
    return octaves * per_octave + (size_t)wg_parallel_chunks(ctx->height) * per_band;
}

const WgNodeType wg_node_noise = {
    .name = "noise",
    .summary = "Tileable value, Perlin, simplex or white noise with fractal octaves",
    .category = "generator",
    .doc = "Lattice noise summed over `octaves`: octave o has scale·lacunarity^o cells across the "
           "width and weight persistence^o. Cells are square: the first octave has "
           "max(1, round(scale·H/W)) cells down (the rule of every lattice generator), so the "
           "lattice tiles on any image size; pixel centres (x+0.5)/W, (y+0.5)/H are mapped to "
           "lattice coordinates exactly, so renders at different sizes sample the same "
           "picture. Kinds: `value` (a random value per lattice point, quintic-smoothed "
           "bilinear); `perlin` (Perlin 2002 gradient noise, 16 gradient directions); "
           "`simplex` (simplex-style radial kernels (3/4 − d²)⁴ on a triangular lattice with an "
           "even number 2·max(1, round(scale·H/(W·√3))) of rows, so it tiles; its triangles are "
           "stretched vertically by round(t)/t, t = scale·H/(W·√3), at most 0.5/t off: 8% on a "
           "square tile at scale 8, 3% at scale 32); `white` (an independent uniform value per "
           "cell, no interpolation: set "
           "`scale` to the image width for per-pixel noise). Each octave n is normalised to "
           "[−1, 1] by its exact bound, and the weighted mean over octaves is mapped to [0, 1]: "
           "`normal` 0.5 + 0.5·Σwn/Σw; `turbulence` Σw|n|/Σw; `ridged` Σw(1−|n|)²/Σw. The "
           "range is guaranteed without clipping, so contrast is modest: Perlin fbm with the "
           "defaults has mean 0.5 and standard deviation about 0.1 (follow with levels or "
           "auto_levels for full range). `octaves=\"0\"` gives a flat 0.5. Cells finer than a "
           "pixel are point-sampled (they alias like white noise); Perlin noise is 0 at lattice "
           "points, so when scale·lacunarity^o / W is an even whole number that octave samples "
           "only zeros. Lacunarity is a whole number "
           "so every octave tiles. Same seed and parameters give the same pixels at any thread "
           "count.",
    .params = noise_params,
    .params_size = sizeof(NoiseParams),
    .outputs = noise_out,
    .flags = WG_NODE_SOURCE | WG_NODE_SEEDED,
    .eval = noise_eval,
    .scratch_bytes = noise_scratch,
};
