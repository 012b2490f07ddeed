/* SPDX-License-Identifier: MIT */
/* Pattern generators: `gradient` (linear, radial, angular ramps with none/repeat/mirror),
 * `checker`, `sine` (a plane wave), `shape` (disk, square, regular polygon, star, tiled on a grid,
 * with a smoothstep falloff from an exact inside distance) and `bricks` (a running-bond tile
 * generator with mortar, bevel and per-brick random values). Every pattern is evaluated at
 * pixel centres ((x+0.5)/W, (y+0.5)/H) in tile coordinates, so renders at different sizes are
 * the same picture sampled more or less finely. Repetition counts are whole numbers per tile
 * (lattices: `scale` cells across the width and max(1, round(scale·H/W)) down, so cells stay
 * square; wave vectors are rounded to whole periods per tile), and lattice coordinates are
 * computed exactly in integers, so every pattern tiles without a seam. Two documented
 * exceptions: `gradient` linear with repeat="none" and `angular` (any repeat) are not periodic.
 * Hard edges (checker, bricks mask, shapes with no falloff) are point-sampled, not
 * antialiased. The shape distance is the exact Euclidean distance to the outline for points
 * inside (polygons and stars are folded into one symmetric wedge, where the outline is a single
 * segment). Only `bricks` uses the seed. */
#include "wetgraph/node.h"
#include "hot.h"

#include <math.h>
#include <string.h>

#define PI 3.14159265358979323846

/* Row loops are HOT (hot.h): floor and friends inline in their AVX2 clone. */

/* Pixel p of n samples the axis at (p + 0.5)/n of the tile, i.e. at lattice coordinate
 * (2p+1)·period/(2n) = cell + frac, computed exactly. */
static inline void axis_coord(uint64_t period, int n, int p, uint64_t *cell, double *frac)
{
    uint64_t two_n = 2 * (uint64_t)n, k = 2 * (uint64_t)p + 1;
    uint64_t q = period / two_n, r = period % two_n, kr = k * r;
    *cell = k * q + kr / two_n;
    *frac = (double)(kr % two_n) / (double)two_n;
}

/* The lattice rule shared by all generators: cells down for `scale` cells across. */
static inline uint64_t rows_for(int scale, int w, int h)
{
    double r = floor((double)scale * h / w + 0.5);
    return r < 1 ? 1 : (uint64_t)r;
}

/* frac(k·(p + 0.5)/n) for an integer number k of periods per tile (k may be negative). */
static inline double wave_phase(int64_t k, int n, int p)
{
    int64_t two_n = 2 * (int64_t)n;
    int64_t m = (k % two_n) * (2 * (int64_t)p + 1) % two_n;
    if (m < 0) m += two_n;
    return (double)m / (double)two_n;
}

/* A whole number of periods (at most ±2^24, far beyond any image). */
static inline int64_t snap(double v)
{
    v = floor(v + 0.5);
    return v > 16777216.0 ? 16777216 : v < -16777216.0 ? -16777216 : (int64_t)v;
}

static inline float clamp01(float v)
{
    return v < 0 ? 0 : v > 1 ? 1 : v;
}

static inline float smoothstep01(float t)
{
    t = clamp01(t);
    return t * t * (3 - 2 * t);
}

/* ==== gradient ============================================================================ */

enum { G_LINEAR, G_RADIAL, G_ANGULAR };
enum { R_NONE, R_REPEAT, R_MIRROR };
static const char *const gradient_kind_values[] = {"linear", "radial", "angular", NULL};
static const char *const repeat_values[] = {"none", "repeat", "mirror", NULL};

typedef struct {
    int kind;
    int repeat;
    float angle;
    float count;
    float center_x, center_y;
    float radius;
} GradientParams;

static const WgParamSpec gradient_params[] = {
    WG_PARAM_ENUM(GradientParams, kind, "Gradient shape", 0, gradient_kind_values),
    WG_PARAM_ENUM(GradientParams, repeat, "Beyond the first ramp: clamp, repeat or mirror", 0,
                  repeat_values),
    WG_PARAM_FLOAT_UI(GradientParams, angle,
                      "Direction in degrees (0: left to right, 90: top "
                      "to bottom)",
                      0.0, -1e6, 1e6, -180, 180),
    WG_PARAM_FLOAT_UI(GradientParams, count, "Ramps across the tile (linear, angular)", 1.0, 0.0,
                      16384.0, 0, 16),
    WG_PARAM_FLOAT(GradientParams, center_x, "Centre x (radial, angular), tile units", 0.5, 0.0,
                   1.0),
    WG_PARAM_FLOAT(GradientParams, center_y, "Centre y (radial, angular), tile units", 0.5, 0.0,
                   1.0),
    WG_PARAM_FLOAT_UI(GradientParams, radius, "Radius of one ramp (radial), in image widths", 0.5,
                      1e-6, 1e6, 0.01, 1),
    WG_PARAM_END,
};
static const WgPortSpec gray_out[] = {WG_PORT("output", WG_GRAY), WG_PORT_END};

typedef struct {
    const GradientParams *p;
    WgImage *out;
    double cosa, sina, aspect; /* aspect = H/W */
    int64_t kx, ky;            /* linear repeat/mirror: periods across and down */
    double lo, span;           /* linear none: projection range over the image */
    double *dx;                /* radial, angular: per column, offset to the nearest centre */
} GradientJob;

static inline float apply_repeat(int repeat, double s)
{
    switch (repeat) {
    case R_NONE:
        return clamp01((float)s);
    case R_REPEAT:
        return (float)(s - floor(s));
    default: { /* period 2: rises over [0, 1], falls over [1, 2] */
        double m = s - 2 * floor(s / 2);
        return clamp01((float)(1 - fabs(1 - m)));
    }
    }
}

HOT static void gradient_rows(void *user, int y0, int y1)
{
    const GradientJob *j = user;
    const GradientParams *p = j->p;
    int w = j->out->width, h = j->out->height;
    for (int y = y0; y < y1; y++) {
        float *o = wg_image_row(j->out, y);
        double v = (y + 0.5) / h;
        if (p->kind == G_LINEAR && p->repeat != R_NONE) {
            double cy = wave_phase(j->ky, h, y);
            for (int x = 0; x < w; x++) {
                double f = wave_phase(j->kx, w, x) + cy;
                f -= floor(f);
                o[x] = p->repeat == R_REPEAT ? (float)f : apply_repeat(R_MIRROR, 2 * f);
            }
            continue;
        }
        if (p->kind == G_LINEAR) {
            for (int x = 0; x < w; x++) {
                double u = (x + 0.5) / w;
                double proj = (u * j->cosa + v * j->aspect * j->sina - j->lo) / j->span;
                o[x] = apply_repeat(R_NONE, p->count * proj);
            }
            continue;
        }
        /* offsets to the nearest copy of the centre, in image widths */
        double dy = v - p->center_y;
        dy = (dy - floor(dy + 0.5)) * j->aspect;
        for (int x = 0; x < w; x++) {
            double dx = j->dx[x];
            double s;
            if (p->kind == G_RADIAL) {
                s = sqrt(dx * dx + dy * dy) / p->radius;
            } else {
                /* clockwise on screen (y down) from the direction `angle` */
                double a = atan2(dy, dx) / (2 * PI) - p->angle / 360.0;
                a -= floor(a);
                s = p->count * a;
                if (p->repeat == R_MIRROR) s *= 2;
            }
            o[x] = apply_repeat(p->repeat, s);
        }
    }
}

static int gradient_eval(WgNodeContext *ctx, WgError *err)
{
    const GradientParams *p = ctx->params;
    GradientJob j = {p, ctx->outputs[0], 0, 0, 0, 0, 0, 0, 1, NULL};
    double a = p->angle * PI / 180;
    j.cosa = cos(a);
    j.sina = sin(a);
    j.aspect = (double)ctx->height / ctx->width;
    j.kx = snap(p->count * j.cosa);
    j.ky = snap(p->count * j.sina * j.aspect);
    double ex = j.cosa, ey = j.aspect * j.sina;
    j.lo = (ex < 0 ? ex : 0) + (ey < 0 ? ey : 0);
    j.span = fabs(ex) + fabs(ey);
    if (p->kind != G_LINEAR) {
        j.dx = wg_malloc(sizeof(double) * (size_t)ctx->width);
        if (!j.dx) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        for (int x = 0; x < ctx->width; x++) {
            double dx = (x + 0.5) / ctx->width - p->center_x;
            j.dx[x] = dx - floor(dx + 0.5);
        }
    }
    int rc = wg_parallel_rows(ctx, ctx->height, gradient_rows, &j);
    wg_free(j.dx);
    return rc;
}

const WgNodeType wg_node_gradient = {
    .name = "gradient",
    .summary = "Linear, radial or angular ramp, clamped, repeated or mirrored",
    .category = "generator",
    .doc = "Output in [0, 1]. Positions are measured in image widths (square pixels). "
           "`linear`: along the direction `angle` (degrees, 0 = left to right, 90 = top to "
           "bottom). With repeat=\"none\" the ramp runs from 0 at the first image corner to 1 at "
           "the opposite corner along that direction, times `count`, clamped; this does not "
           "tile. With repeat/mirror the wave vector (count·cos, count·sin·H/W) is rounded to a "
           "whole number of periods across and down the tile, so the pattern tiles; the actual "
           "angle and ramp count can differ slightly from the requested ones (most at small "
           "counts; a rounded vector of (0, 0) gives a flat 0). `radial`: distance to the "
           "nearest copy of (`center_x`, `center_y`) over `radius`; it always tiles (the "
           "distance is measured on the torus, so rings are cut flat half a tile from the "
           "centre). `angular`: the clockwise angle around the centre from the direction "
           "`angle`, as a fraction of a turn, times `count`; it does not tile (it jumps where "
           "the nearest copy of the centre changes, half a tile away, and at the start "
           "direction unless mirrored). Repeat modes: `none` clamps to [0, 1]; `repeat` takes "
           "the fractional part; `mirror` rises over one ramp and falls over the next (linear "
           "and angular: `count` full rise-and-fall cycles; radial: up to `radius`, down to 0 "
           "at 2·radius).",
    .params = gradient_params,
    .params_size = sizeof(GradientParams),
    .outputs = gray_out,
    .flags = WG_NODE_SOURCE | WG_NODE_CHEAP,
    .eval = gradient_eval,
};

/* ==== checker ============================================================================= */

typedef struct {
    int scale;
} CheckerParams;

static const WgParamSpec checker_params[] = {
    WG_PARAM_INT(CheckerParams, scale, "Checker periods (square pairs) across the width", 4, 1,
                 8192),
    WG_PARAM_END,
};

static int checker_eval(WgNodeContext *ctx, WgError *err)
{
    const CheckerParams *p = ctx->params;
    WgImage *out = ctx->outputs[0];
    int w = ctx->width, h = ctx->height;
    uint64_t nx = 2 * (uint64_t)p->scale, ny = 2 * rows_for(p->scale, w, h);
    unsigned char *par = wg_malloc((size_t)w);
    if (!par) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int x = 0; x < w; x++) {
        uint64_t c;
        double f;
        axis_coord(nx, w, x, &c, &f);
        par[x] = (unsigned char)(c & 1);
    }
    for (int y = 0; y < h; y++) {
        uint64_t c;
        double f;
        axis_coord(ny, h, y, &c, &f);
        float *o = wg_image_row(out, y);
        unsigned py = (unsigned)(c & 1);
        for (int x = 0; x < w; x++) o[x] = (par[x] ^ py) ? 0.0f : 1.0f;
    }
    wg_free(par);
    return WG_OK;
}

const WgNodeType wg_node_checker = {
    .name = "checker",
    .summary = "Checkerboard of 0 and 1 squares",
    .category = "generator",
    .doc = "2·scale squares across the width and 2·max(1, round(scale·H/W)) down (the lattice "
           "rule of every generator, counted in pairs of squares so the board always tiles); "
           "the top-left square is 1. Hard edges, point-sampled at pixel centres: when a "
           "square is a whole number of pixels wide and high, every pixel lies wholly in one "
           "square.",
    .params = checker_params,
    .params_size = sizeof(CheckerParams),
    .outputs = gray_out,
    .flags = WG_NODE_SOURCE | WG_NODE_CHEAP,
    .eval = checker_eval,
};

/* ==== sine ================================================================================ */

typedef struct {
    float angle;
    float frequency;
    float phase;
} SineParams;

static const WgParamSpec sine_params[] = {
    WG_PARAM_FLOAT_UI(SineParams, angle,
                      "Direction of travel in degrees (0: along x, 90: "
                      "along y)",
                      0.0, -1e6, 1e6, -180, 180),
    WG_PARAM_FLOAT_UI(SineParams, frequency, "Waves across the tile", 4.0, 0.0, 16384.0, 0, 64),
    WG_PARAM_FLOAT_UI(SineParams, phase, "Phase in turns", 0.0, -1e6, 1e6, 0, 1),
    WG_PARAM_END,
};

typedef struct {
    WgImage *out;
    float *cs, *sn; /* per column: cos and sin of 2π·phase_x */
    double ky, phase;
} SineJob;

HOT static void sine_rows(void *user, int y0, int y1)
{
    const SineJob *j = user;
    int w = j->out->width, h = j->out->height;
    for (int y = y0; y < y1; y++) {
        double t = 2 * PI * (wave_phase((int64_t)j->ky, h, y) + j->phase);
        float cy = (float)cos(t), sy = (float)sin(t);
        float *o = wg_image_row(j->out, y);
        /* sin(a + b) = sin a cos b + cos a sin b */
        for (int x = 0; x < w; x++) o[x] = clamp01(0.5f + 0.5f * (j->sn[x] * cy + j->cs[x] * sy));
    }
}

static int sine_eval(WgNodeContext *ctx, WgError *err)
{
    const SineParams *p = ctx->params;
    int w = ctx->width, h = ctx->height;
    double a = p->angle * PI / 180;
    int64_t kx = snap(p->frequency * cos(a));
    SineJob j = {ctx->outputs[0], wg_malloc(sizeof(float) * (size_t)w),
                 wg_malloc(sizeof(float) * (size_t)w), (double)snap(p->frequency * sin(a) * h / w),
                 p->phase - floor(p->phase)};
    int rc;
    if (!j.cs || !j.sn) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    } else {
        for (int x = 0; x < w; x++) {
            double t = 2 * PI * wave_phase(kx, w, x);
            j.cs[x] = (float)cos(t);
            j.sn[x] = (float)sin(t);
        }
        rc = wg_parallel_rows(ctx, h, sine_rows, &j);
    }
    wg_free(j.cs);
    wg_free(j.sn);
    return rc;
}

const WgNodeType wg_node_sine = {
    .name = "sine",
    .summary = "Plane sine wave in [0, 1] along a direction",
    .category = "generator",
    .doc = "0.5 + 0.5·sin(2π(kx·u + ky·v + phase)) with u, v the tile coordinates of the pixel "
           "centre and (kx, ky) = (frequency·cos(angle), frequency·sin(angle)·H/W) rounded to "
           "whole numbers, so the wave tiles: `frequency` waves across the tile along the "
           "direction (measured with square pixels), the actual angle and frequency rounded to "
           "the nearest tileable ones (a rounded vector of (0, 0) gives the constant "
           "0.5 + 0.5·sin(2π·phase)). `phase` is in turns (1 = a whole wave). Exact to float "
           "rounding (phases are reduced in integers before the sine).",
    .params = sine_params,
    .params_size = sizeof(SineParams),
    .outputs = gray_out,
    .flags = WG_NODE_SOURCE | WG_NODE_CHEAP,
    .eval = sine_eval,
};

/* ==== shape =============================================================================== */

enum { S_DISK, S_SQUARE, S_POLYGON, S_STAR };
static const char *const shape_kind_values[] = {"disk", "square", "polygon", "star", NULL};

typedef struct {
    int kind;
    int scale;
    float radius;
    float rotation;
    int sides;
    float inner_radius;
    float falloff;
} ShapeParams;

static const WgParamSpec shape_params[] = {
    WG_PARAM_ENUM(ShapeParams, kind, "Shape", 0, shape_kind_values),
    WG_PARAM_INT(ShapeParams, scale, "Shapes across the width (tiled count)", 1, 1, 4096),
    WG_PARAM_FLOAT(ShapeParams, radius, "Radius (square: half side), in half cell widths", 0.8, 0.0,
                   2.0),
    WG_PARAM_FLOAT_UI(ShapeParams, rotation, "Clockwise rotation in degrees", 0.0, -1e6, 1e6, -180,
                      180),
    WG_PARAM_INT(ShapeParams, sides, "Sides of the polygon, points of the star", 5, 3, 64),
    WG_PARAM_FLOAT(ShapeParams, inner_radius, "Star: inner radius over outer radius", 0.5, 0.05,
                   1.0),
    WG_PARAM_FLOAT(ShapeParams, falloff, "Soft edge depth, as a fraction of the radius", 0.0, 0.0,
                   1.0),
    WG_PARAM_END,
};

typedef struct {
    const ShapeParams *p;
    WgImage *out;
    uint64_t nx, ny;
    float *lx;                                  /* per column: local x in [-1, 1) */
    double rc, rs;                              /* cos, sin of the rotation */
    float outer;                                /* outer radius of the distance function */
    float an, tip_x, tip_y, vx, vy, ex, ey, ee; /* wedge: tip A, valley B, edge e = B - A */
    int n;                                      /* corners */
    float tip_sin[64], tip_cos[64]; /* direction of corner k: angle 2πk/n clockwise from up */
    float depth;                    /* falloff depth, 0: hard edge */
    float outer2;                   /* outer², nothing beyond */
    int reach;                      /* 0: own cell only, 1: also the 8 neighbours */
} ShapeJob;

/* Signed distance (negative inside) in half cell widths, point already rotated. Polygons and
 * stars fold the point into the wedge between a tip (angle 0) and the next valley (π/n) by
 * turning it back by its sector's angle and mirroring; the nearest outline point is then on
 * the segment tip–valley (a point is nearer to the segment of its own wedge than to any
 * mirrored copy), inside exactly when on the centre's side of it. */
static inline float shape_sd(const ShapeJob *j, float qx, float qy)
{
    float r2 = qx * qx + qy * qy;
    if (j->p->kind == S_DISK) return sqrtf(r2) - j->outer;
    /* sector of the angle from "up" (−y), clockwise */
    float phi = atan2f(qx, -qy);
    int k = (int)floorf((phi + j->an) / (2 * j->an));
    k = k < 0 ? k + j->n : k >= j->n ? k - j->n : k;
    float ts = j->tip_sin[k], tc = j->tip_cos[k];
    float px = qx * ts - qy * tc;        /* along the tip direction (ts, −tc) */
    float py = fabsf(qx * tc + qy * ts); /* across it, mirrored */
    float ax = px - j->tip_x, ay = py;
    float t = (ax * j->ex + ay * j->ey) / j->ee;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    float dx = ax - t * j->ex, dy = ay - t * j->ey;
    float d = sqrtf(dx * dx + dy * dy);
    float cross = j->ex * ay - j->ey * ax; /* > 0 on the centre's side of the edge */
    return cross > 0 ? -d : d;
}

static inline float shape_value(const ShapeJob *j, float sd)
{
    if (j->depth <= 0) return sd < 0 ? 1.0f : 0.0f;
    return smoothstep01(-sd / j->depth);
}

HOT static void shape_rows(void *user, int y0, int y1)
{
    const ShapeJob *j = user;
    int w = j->out->width, h = j->out->height;
    float c = (float)j->rc, s = (float)j->rs;
    for (int y = y0; y < y1; y++) {
        uint64_t cell;
        double fy;
        axis_coord(j->ny, h, y, &cell, &fy);
        float ly = (float)(2 * fy - 1);
        float *o = wg_image_row(j->out, y);
        for (int x = 0; x < w; x++) {
            float best = 0;
            for (int oy = -j->reach; oy <= j->reach; oy++)
                for (int ox = -j->reach; ox <= j->reach; ox++) {
                    float px = j->lx[x] - 2.0f * (float)ox, py = ly - 2.0f * (float)oy;
                    if (px * px + py * py >= j->outer2) continue; /* outside: 0 */
                    float v = shape_value(j, shape_sd(j, c * px + s * py, -s * px + c * py));
                    best = v > best ? v : best;
                }
            o[x] = best;
        }
    }
}

static int shape_eval(WgNodeContext *ctx, WgError *err)
{
    const ShapeParams *p = ctx->params;
    int w = ctx->width, h = ctx->height;
    ShapeJob j;
    memset(&j, 0, sizeof j);
    j.p = p;
    j.out = ctx->outputs[0];
    j.nx = (uint64_t)p->scale;
    j.ny = rows_for(p->scale, w, h);
    double rot = p->rotation * PI / 180;
    int n = p->sides;
    double inner = p->inner_radius;
    j.outer = p->radius;
    if (p->kind == S_SQUARE) {
        n = 4;
        rot += PI / 4; /* a 4-gon has a corner up; turn it to axis-aligned edges */
        j.outer = (float)(p->radius * sqrt(2.0));
    }
    if (p->kind != S_STAR) inner = cos(PI / n);
    j.rc = cos(rot);
    j.rs = sin(rot);
    j.an = (float)(PI / n);
    j.n = n;
    for (int k = 0; k < n; k++) {
        j.tip_sin[k] = (float)sin(2 * PI * k / n);
        j.tip_cos[k] = (float)cos(2 * PI * k / n);
    }
    j.tip_x = j.outer;
    j.tip_y = 0;
    j.vx = (float)(j.outer * inner * cos(PI / n));
    j.vy = (float)(j.outer * inner * sin(PI / n));
    j.ex = j.vx - j.tip_x;
    j.ey = j.vy - j.tip_y;
    j.ee = j.ex * j.ex + j.ey * j.ey;
    if (j.ee <= 0) j.ee = 1; /* radius 0: empty shape, any positive value avoids 0/0 */
    j.depth = p->falloff * p->radius;
    /* a shape reaching past its cell (outer radius > 1 half width) is also drawn from the
     * neighbouring cells; radius <= 2√2 < 3 never reaches two cells away */
    j.reach = j.outer > 1 ? 1 : 0;
    j.outer2 = j.outer * j.outer * 1.0001f + 1e-6f;
    j.lx = wg_malloc(sizeof(float) * (size_t)w);
    if (!j.lx) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int x = 0; x < w; x++) {
        uint64_t cell;
        double fx;
        axis_coord(j.nx, w, x, &cell, &fx);
        j.lx[x] = (float)(2 * fx - 1);
    }
    int rc = wg_parallel_rows(ctx, h, shape_rows, &j);
    wg_free(j.lx);
    return rc;
}

const WgNodeType wg_node_shape = {
    .name = "shape",
    .summary = "Disk, square, regular polygon or star, tiled on a grid",
    .category = "generator",
    .doc = "One shape per cell, centred, on a grid of `scale` cells across the width and "
           "max(1, round(scale·H/W)) down (the lattice rule of every generator; cells that "
           "round to non-square pixels stretch the shape with them). Sizes are in half cell "
           "widths: `radius` is the disk radius, the square's half side, the polygon's and the "
           "star's outer (corner) radius; 1 touches the cell's edges. Shapes reaching past "
           "their cell overlap into the neighbours (union by maximum), so large shapes tile "
           "too. `rotation` turns clockwise; polygons and stars have a corner pointing up at "
           "rotation 0. `sides` counts polygon sides and star points; `inner_radius` is the "
           "star's valley radius over its outer radius. Output 1 inside and 0 outside: with "
           "`falloff` 0 a hard, point-sampled edge; otherwise smoothstep(d / (falloff·radius)) "
           "with d the exact Euclidean distance to the outline inside the shape, so the value "
           "rises from 0 at the outline to 1 at depth falloff·radius.",
    .params = shape_params,
    .params_size = sizeof(ShapeParams),
    .outputs = gray_out,
    .flags = WG_NODE_SOURCE,
    .eval = shape_eval,
};

/* ==== bricks ============================================================================== */

typedef struct {
    int columns;
    int rows;
    float row_offset;
    float random_offset;
    float mortar;
    float bevel;
    float height_variation;
    float luminance_variation;
} BricksParams;

static const WgParamSpec bricks_params[] = {
    WG_PARAM_INT(BricksParams, columns, "Bricks per row", 4, 1, 4096),
    WG_PARAM_INT(BricksParams, rows, "Rows of bricks", 8, 1, 4096),
    WG_PARAM_FLOAT(BricksParams, row_offset, "Shift of every other row, in brick widths", 0.5, 0.0,
                   1.0),
    WG_PARAM_FLOAT(BricksParams, random_offset, "Random shift per row, in brick widths", 0.0, 0.0,
                   1.0),
    WG_PARAM_FLOAT(BricksParams, mortar, "Joint width, as a fraction of the brick's short side",
                   0.1, 0.0, 1.0),
    WG_PARAM_FLOAT(BricksParams, bevel, "Height ramp width, fraction of the half short side", 0.1,
                   0.0, 1.0),
    WG_PARAM_FLOAT(BricksParams, height_variation, "Random height decrease per brick", 0.0, 0.0,
                   1.0),
    WG_PARAM_FLOAT(BricksParams, luminance_variation, "Spread of the per-brick random value", 1.0,
                   0.0, 1.0),
    WG_PARAM_END,
};
static const WgPortSpec bricks_out[] = {
    {"height", WG_GRAY, false, "bevelled brick height, 0 in the mortar"},
    {"mask", WG_GRAY, false, "1 on bricks, 0 in the mortar"},
    {"random", WG_GRAY, false, "a random value per brick"},
    {"id", WG_GRAY, false, "(brick index + 0.5) / brick count, distinct per brick"},
    WG_PORT_END,
};

typedef struct {
    const BricksParams *p;
    WgImage *height, *mask, *random, *id;
    uint32_t seed;
    int64_t *ix; /* per column: brick column before the row's shift */
    float *fx;
    double bw, bh, half; /* brick size in pixels, half its short side */
} BricksJob;

static inline float unit(uint32_t h)
{
    return (float)(h >> 8) * 0x1p-24f;
}

HOT static void bricks_rows(void *user, int y0, int y1)
{
    const BricksJob *j = user;
    const BricksParams *p = j->p;
    int w = j->height->width, h = j->height->height, cols = p->columns;
    float mortar = p->mortar, bevel = p->bevel;
    float inv_half = (float)(1 / j->half), bw = (float)j->bw;
    for (int y = y0; y < y1; y++) {
        uint64_t row;
        double fy;
        axis_coord((uint64_t)p->rows, h, y, &row, &fy);
        uint32_t rkey = wg_hash_u32((uint32_t)row ^ j->seed);
        float shift = p->row_offset * (float)(row & 1) + p->random_offset * (unit(rkey) - 0.5f);
        float dy = (float)((fy < 0.5 ? fy : 1 - fy) * j->bh);
        float *oh = wg_image_row(j->height, y), *om = wg_image_row(j->mask, y);
        float *orr = wg_image_row(j->random, y), *oi = wg_image_row(j->id, y);
        int64_t last = -1;
        float top = 0, rnd = 0, id = 0;
        for (int x = 0; x < w; x++) {
            float t = j->fx[x] - shift;
            float k = floorf(t);
            float f = t - k;
            int64_t col = (j->ix[x] + (int64_t)k) % cols;
            if (col < 0) col += cols;
            float dx = (f < 0.5f ? f : 1 - f) * bw;
            float e = (dx < dy ? dx : dy) * inv_half; /* 0 on the brick outline, <= 1 inside */
            bool in = mortar == 0 || e > mortar;
            if (col != last) { /* per-brick values, once per brick along the row */
                uint32_t hb = wg_hash_u32((uint32_t)col ^ rkey);
                float r1 = unit(wg_hash_u32(hb ^ 0x2545f491u));
                float r2 = unit(wg_hash_u32(hb ^ 0x9e3779b9u));
                top = 1 - p->height_variation * r2;
                rnd = 1 - p->luminance_variation + p->luminance_variation * r1;
                id = (float)(((double)row * cols + (double)col + 0.5) / ((double)p->rows * cols));
                last = col;
            }
            float ramp = bevel > 0 ? smoothstep01((e - mortar) / bevel) : 1.0f;
            om[x] = in ? 1.0f : 0.0f;
            oh[x] = in ? top * ramp : 0.0f;
            orr[x] = rnd;
            oi[x] = id;
        }
    }
}

static int bricks_eval(WgNodeContext *ctx, WgError *err)
{
    const BricksParams *p = ctx->params;
    int w = ctx->width, h = ctx->height;
    BricksJob j;
    memset(&j, 0, sizeof j);
    j.p = p;
    j.height = ctx->outputs[0];
    j.mask = ctx->outputs[1];
    j.random = ctx->outputs[2];
    j.id = ctx->outputs[3];
    j.seed = wg_hash3((uint32_t)ctx->seed, (uint32_t)(ctx->seed >> 32), 0x62726b73u);
    j.bw = (double)w / p->columns;
    j.bh = (double)h / p->rows;
    j.half = 0.5 * (j.bw < j.bh ? j.bw : j.bh);
    j.ix = wg_malloc(sizeof(int64_t) * (size_t)w);
    j.fx = wg_malloc(sizeof(float) * (size_t)w);
    int rc;
    if (!j.ix || !j.fx) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    } else {
        for (int x = 0; x < w; x++) {
            uint64_t c;
            double f;
            axis_coord((uint64_t)p->columns, w, x, &c, &f);
            j.ix[x] = (int64_t)c;
            j.fx[x] = (float)f;
        }
        rc = wg_parallel_rows(ctx, h, bricks_rows, &j);
    }
    wg_free(j.ix);
    wg_free(j.fx);
    return rc;
}

const WgNodeType wg_node_bricks = {
    .name = "bricks",
    .summary = "Brick / tile pattern: height, mask, per-brick random value and id",
    .category = "generator",
    .doc = "`rows` rows of `columns` bricks per tile (explicit counts: bricks stretch with the "
           "image's aspect). Every other row is shifted by `row_offset` brick widths, and each "
           "row by a further random `random_offset`·(u − 1/2); the pattern tiles for any values "
           "(with an odd row count two unshifted rows meet at the top/bottom edge). Joints: a "
           "pixel is mortar when its distance to the brick outline, in pixels over half the "
           "brick's short side (e ∈ [0, 1]), is at most `mortar` (so the joint is "
           "mortar·short side wide; `mortar=\"0\"` gives no joints at all). Outputs: `mask` 1 "
           "on bricks, 0 in joints (hard, point-sampled); `height` = (1 − "
           "height_variation·u₁)·smoothstep((e − mortar)/bevel) on bricks (a step when bevel "
           "is 0), 0 in joints, in [0, 1]; `random` = 1 − luminance_variation·(1 − u₂), a "
           "per-brick value in [1 − luminance_variation, 1] (uniform in [0, 1) at the default "
           "1); `id` = (row·columns + column + 0.5)/(rows·columns), distinct per brick. u₁, u₂ "
           "are uniform hashes of the brick and the seed. `random` and `id` are also defined "
           "in the joints (the brick whose slot holds the pixel); multiply by `mask` to clear "
           "them.",
    .params = bricks_params,
    .params_size = sizeof(BricksParams),
    .outputs = bricks_out,
    .flags = WG_NODE_SOURCE | WG_NODE_SEEDED,
    .eval = bricks_eval,
};
