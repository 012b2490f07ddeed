/* SPDX-License-Identifier: MIT */
/* `cells`: Worley / Voronoi cellular noise (Worley 1996, "A cellular texture basis function").
 * The tile holds scale × max(1, round(scale·H/W)) square-ish cells, one feature point per cell
 * at its centre displaced by jitter·(uniform − 1/2) on each axis (so jitter 0 is a regular grid
 * and jitter 1 a point anywhere in the cell); the point's position is a hash of the cell index
 * and the seed. Cell indices wrap modulo the counts, so distances are measured on the torus and
 * the result tiles exactly. f1 and f2 are the distances, in cell widths, to the nearest and
 * second-nearest feature point under the chosen metric. The search is exact: the 3×3 block
 * around the pixel's cell is always visited, then further cells only when their box could still
 * hold a point nearer than the current f2. Since f2 ≤ 1.81 cell widths (Euclidean), 1.5
 * (Chebyshev) or 2.5 (Manhattan) anywhere, the 5×5 block suffices for the first two metrics and
 * 7×7 for Manhattan. Speed: when cells are at least a pixel wide, the feature points of the
 * rows around the current cell row are cached and each cell's run of pixels is processed in
 * vectorised loops; finer cells are hashed per pixel. */
#include "wetgraph/node.h"
#include "hot.h"

#include <math.h>
#include <string.h>

enum { EUCLIDEAN, MANHATTAN, CHEBYSHEV };
static const char *const metric_values[] = {"euclidean", "manhattan", "chebyshev", NULL};

typedef struct {
    int scale;
    float jitter;
    int metric;
} CellsParams;

static const WgParamSpec cells_params[] = {
    WG_PARAM_INT(CellsParams, scale, "Cells across the width", 8, 1, 16384),
    WG_PARAM_FLOAT(CellsParams, jitter, "Feature point displacement (0: regular grid)", 1.0, 0.0,
                   1.0),
    WG_PARAM_ENUM(CellsParams, metric, "Distance metric", 0, metric_values),
    WG_PARAM_END,
};
static const WgPortSpec cells_out[] = {
    {"f1", WG_GRAY, false, "distance to the nearest feature point, in cell widths, clamped to 1"},
    {"f2", WG_GRAY, false, "distance to the second nearest, clamped to 1"},
    {"edges", WG_GRAY, false, "f2 − f1 (0 on cell borders), clamped to 1"},
    {"id", WG_GRAY, false, "a uniform random value in [0, 1) per cell"},
    WG_PORT_END,
};

#define MAX_R 3

/* Same mapping as the other lattice generators: pixel p of n samples (2p+1)·period/(2n). */
static inline void axis_coord(uint64_t period, int n, int p, uint64_t *cell, float *frac)
{
    uint64_t two_n = 2 * (uint64_t)n, k = 2 * (uint64_t)p + 1;
    uint64_t q = period / two_n, r = period % two_n, kr = k * r;
    *cell = k * q + kr / two_n;
    *frac = (float)((double)(kr % two_n) / (double)two_n);
}

static inline uint32_t lattice_key(uint64_t i)
{
    return (uint32_t)i ^ (i >> 32 ? wg_hash_u32((uint32_t)(i >> 32) ^ 0x5bd1e995u) : 0x5a6bc3e1u);
}

typedef struct {
    float *ox, *oy, *id; /* (2r+1) rows of px+2r points, row dj at (dj+r)*stride, column c at c+r */
    float *d1, *d2, *i1; /* per pixel of the row */
    int64_t band;        /* lattice row the point cache holds, -1: none */
} Scratch;

typedef struct {
    const CellsParams *p;
    WgImage *f1, *f2, *edges, *id;
    uint64_t px, py;
    int r; /* search radius in cells */
    uint32_t seed;
    int32_t *ix;
    float *fx;
    uint32_t *kc; /* key of lattice column c at kc[c + r], c = -r .. px+r-1 */
    int *run;     /* coarse: first pixel of lattice column j, j = 0..px */
    bool coarse;  /* px <= width: cache feature points per lattice row, loop per cell */
    size_t stride;
    int n_bands;
    Scratch *scratch;
} Job;

static inline float metric_dist(int metric, float dx, float dy)
{
    dx = fabsf(dx);
    dy = fabsf(dy);
    switch (metric) {
    case EUCLIDEAN:
        return dx * dx + dy * dy; /* squared until the end */
    case MANHATTAN:
        return dx + dy;
    default:
        return dx > dy ? dx : dy;
    }
}

/* Lower bound of the distance from f (in [0,1)) to a point of the cell at offset d, whose
 * point lies within [d + lo, d + hi]. */
static inline float gap(int d, float f, float lo, float hi)
{
    if (d > 0) return (float)d + lo - f;
    if (d < 0) return f - ((float)d + hi);
    return 0;
}

/* Feature point of a cell, relative to the cell's corner, and its id value. */
static inline void feature(uint32_t hh, float jit, float *ox, float *oy, float *id)
{
    *ox = 0.5f + jit * (((float)(hh & 0xffff) + 0.5f) * 0x1p-16f - 0.5f);
    *oy = 0.5f + jit * (((float)(hh >> 16) + 0.5f) * 0x1p-16f - 0.5f);
    *id = (float)(wg_hash_u32(hh ^ 0x68e31da4u) >> 8) * 0x1p-24f;
}

static void row_keys(const Job *j, uint64_t iy, uint32_t *ry)
{
    int R = j->r;
    for (int dj = -R; dj <= R; dj++) {
        int64_t m = (int64_t)(dj % (int64_t)j->py); /* (iy + dj) mod py, any py >= 1 */
        uint64_t row = (iy + (uint64_t)(m < 0 ? m + (int64_t)j->py : m)) % j->py;
        ry[dj + R] = wg_hash_u32(lattice_key(row) ^ j->seed);
    }
}

/* One candidate point (cx, cy relative to the pixel's cell corner) for pixels [x0, x1). One
 * loop per metric (and restrict pointers) so that each vectorises. */
#define CANDIDATE_LOOP(DIST)                                                                       \
    for (int x = x0; x < x1; x++) {                                                                \
        float dx = fabsf(cx - fx[x]), d = (DIST), a = d1[x];                                       \
        float far = d > a ? d : a;                                                                 \
        i1[x] = d < a ? cid : i1[x];                                                               \
        d2[x] = d2[x] < far ? d2[x] : far;                                                         \
        d1[x] = d < a ? d : a;                                                                     \
    }
static inline void candidate(int metric, float cx, float cy, float cid, const float *restrict fx,
                             float fy, float *restrict d1, float *restrict d2, float *restrict i1,
                             int x0, int x1)
{
    float dy = fabsf(cy - fy);
    switch (metric) {
    case EUCLIDEAN:
        CANDIDATE_LOOP(dx * dx + dy * dy);
        break;
    case MANHATTAN:
        CANDIDATE_LOOP(dx + dy);
        break;
    default:
        CANDIDATE_LOOP(dx > dy ? dx : dy);
        break;
    }
}
#undef CANDIDATE_LOOP

HOT static void coarse_row(const Job *j, Scratch *s, uint64_t iy, float fy)
{
    const CellsParams *p = j->p;
    int R = j->r, metric = p->metric, w = j->f1->width;
    float jit = p->jitter, lo = 0.5f - 0.5f * jit, hi = 0.5f + 0.5f * jit;
    size_t st = j->stride;
    if (s->band != (int64_t)iy) {
        uint32_t ry[2 * MAX_R + 1];
        row_keys(j, iy, ry);
        for (int dj = -R; dj <= R; dj++)
            for (int64_t c = -R; c < (int64_t)j->px + R; c++) {
                size_t k = (size_t)(dj + R) * st + (size_t)(c + R);
                feature(wg_hash_u32(j->kc[c + R] ^ ry[dj + R]), jit, &s->ox[k], &s->oy[k],
                        &s->id[k]);
            }
        s->band = (int64_t)iy;
    }
    const float *fx = j->fx;
    float *d1 = s->d1, *d2 = s->d2, *i1 = s->i1;
    for (int x = 0; x < w; x++) d1[x] = d2[x] = INFINITY;
    for (int64_t c = 0; c < (int64_t)j->px; c++) {
        int x0 = j->run[c], x1 = j->run[c + 1];
        if (x0 == x1) continue;
        for (int dj = -1; dj <= 1; dj++)
            for (int di = -1; di <= 1; di++) {
                size_t k = (size_t)(dj + R) * st + (size_t)(c + di + R);
                candidate(metric, (float)di + s->ox[k], (float)dj + s->oy[k], s->id[k], fx, fy, d1,
                          d2, i1, x0, x1);
            }
        float worst = 0;
        for (int x = x0; x < x1; x++) worst = d2[x] > worst ? d2[x] : worst;
        for (int dj = -R; dj <= R; dj++) {
            float gy = gap(dj, fy, lo, hi);
            if (metric_dist(metric, 0, gy) >= worst) continue;
            for (int di = -R; di <= R; di++) {
                if (dj >= -1 && dj <= 1 && di >= -1 && di <= 1) continue;
                /* nearest pixel of the run to that cell: the last one for di > 0, else the first */
                float gx = gap(di, di > 0 ? fx[x1 - 1] : fx[x0], lo, hi);
                if (metric_dist(metric, gx, gy) >= worst) continue;
                size_t k = (size_t)(dj + R) * st + (size_t)(c + di + R);
                candidate(metric, (float)di + s->ox[k], (float)dj + s->oy[k], s->id[k], fx, fy, d1,
                          d2, i1, x0, x1);
            }
        }
    }
}

/* Cells smaller than pixels: hash every candidate of every pixel. */
static void fine_row(const Job *j, Scratch *s, uint64_t iy, float fy)
{
    const CellsParams *p = j->p;
    int R = j->r, metric = p->metric, w = j->f1->width;
    float jit = p->jitter, lo = 0.5f - 0.5f * jit, hi = 0.5f + 0.5f * jit;
    uint32_t ry[2 * MAX_R + 1];
    row_keys(j, iy, ry);
    for (int x = 0; x < w; x++) {
        float fx = j->fx[x], ox, oy, id;
        const uint32_t *kc = j->kc + j->ix[x] + R;
        float d1 = INFINITY, d2 = INFINITY, i1 = 0;
        for (int dj = -R; dj <= R; dj++) {
            float gy = gap(dj, fy, lo, hi);
            if (dj < -1 || dj > 1)
                if (metric_dist(metric, 0, gy) >= d2) continue;
            for (int di = -R; di <= R; di++) {
                bool inner = dj >= -1 && dj <= 1 && di >= -1 && di <= 1;
                /* the 3x3 block comes first in value, not in order: the bound only skips cells
                 * that cannot beat the current f2, which stays exact in any order */
                if (!inner && metric_dist(metric, gap(di, fx, lo, hi), gy) >= d2) continue;
                feature(wg_hash_u32(kc[di] ^ ry[dj + R]), jit, &ox, &oy, &id);
                float d = metric_dist(metric, (float)di + ox - fx, (float)dj + oy - fy);
                if (d < d1) {
                    d2 = d1;
                    d1 = d;
                    i1 = id;
                } else if (d < d2) {
                    d2 = d;
                }
            }
        }
        s->d1[x] = d1;
        s->d2[x] = d2;
        s->i1[x] = i1;
    }
}

HOT static void finish_row(int metric, const Scratch *s, int w, float *o1, float *o2, float *oe,
                           float *oi)
{
    for (int x = 0; x < w; x++) {
        float d1 = s->d1[x], d2 = s->d2[x];
        if (metric == EUCLIDEAN) {
            d1 = sqrtf(d1);
            d2 = sqrtf(d2);
        }
        float e = d2 - d1;
        o1[x] = d1 < 1 ? d1 : 1;
        o2[x] = d2 < 1 ? d2 : 1;
        oe[x] = e < 1 ? e : 1;
        oi[x] = s->i1[x];
    }
}

static void cells_bands(void *user, int b0, int b1)
{
    const Job *j = user;
    int w = j->f1->width, h = j->f1->height;
    for (int b = b0; b < b1; b++) {
        Scratch *s = &j->scratch[b];
        int y0 = (int)((long long)b * h / j->n_bands);
        int y1 = (int)((long long)(b + 1) * h / j->n_bands);
        for (int y = y0; y < y1; y++) {
            uint64_t iy;
            float fy;
            axis_coord(j->py, h, y, &iy, &fy);
            if (j->coarse)
                coarse_row(j, s, iy, fy);
            else
                fine_row(j, s, iy, fy);
            finish_row(j->p->metric, s, w, wg_image_row(j->f1, y), wg_image_row(j->f2, y),
                       wg_image_row(j->edges, y), wg_image_row(j->id, y));
        }
    }
}

static void job_free(Job *j)
{
    wg_free(j->ix);
    wg_free(j->fx);
    wg_free(j->kc);
    wg_free(j->run);
    if (j->scratch)
        for (int b = 0; b < j->n_bands; b++) {
            Scratch *s = &j->scratch[b];
            wg_free(s->ox);
            wg_free(s->oy);
            wg_free(s->id);
            wg_free(s->d1);
            wg_free(s->d2);
            wg_free(s->i1);
        }
    wg_free(j->scratch);
}

static int job_init(Job *j, int w, int h)
{
    size_t n = (size_t)w;
    j->ix = wg_malloc(n * sizeof(int32_t));
    j->fx = wg_malloc(n * sizeof(float));
    j->kc = wg_malloc(((size_t)j->px + 2 * MAX_R) * sizeof(uint32_t));
    j->coarse = j->px <= (uint64_t)w;
    if (j->coarse) j->run = wg_malloc(((size_t)j->px + 1) * sizeof(int));
    if (!j->ix || !j->fx || !j->kc || (j->coarse && !j->run)) return WG_ERR_NOMEM;
    uint64_t c = 0;
    for (int x = 0; x < w; x++) {
        uint64_t cell;
        axis_coord(j->px, w, x, &cell, &j->fx[x]);
        j->ix[x] = (int32_t)cell;
        if (j->coarse)
            while (c <= cell) j->run[c++] = x;
    }
    if (j->coarse)
        while (c <= j->px) j->run[c++] = w;
    for (int64_t k = -j->r; k < (int64_t)j->px + j->r; k++) {
        int64_t m = k % (int64_t)j->px;
        j->kc[k + j->r] = lattice_key((uint64_t)(m < 0 ? m + (int64_t)j->px : m));
    }
    j->stride = (size_t)j->px + 2 * (size_t)j->r;
    size_t pts = j->coarse ? (size_t)(2 * j->r + 1) * j->stride : 1;
    j->n_bands = wg_parallel_chunks(h);
    j->scratch = wg_calloc((size_t)j->n_bands, sizeof(Scratch));
    if (!j->scratch) return WG_ERR_NOMEM;
    for (int b = 0; b < j->n_bands; b++) {
        Scratch *s = &j->scratch[b];
        s->band = -1;
        s->ox = wg_malloc(pts * sizeof(float));
        s->oy = wg_malloc(pts * sizeof(float));
        s->id = wg_malloc(pts * sizeof(float));
        s->d1 = wg_malloc(n * sizeof(float));
        s->d2 = wg_malloc(n * sizeof(float));
        s->i1 = wg_malloc(n * sizeof(float));
        if (!s->ox || !s->oy || !s->id || !s->d1 || !s->d2 || !s->i1) return WG_ERR_NOMEM;
    }
    return WG_OK;
}

static int cells_eval(WgNodeContext *ctx, WgError *err)
{
    const CellsParams *p = ctx->params;
    int w = ctx->width, h = ctx->height;
    Job j;
    memset(&j, 0, sizeof j);
    j.p = p;
    j.f1 = ctx->outputs[0];
    j.f2 = ctx->outputs[1];
    j.edges = ctx->outputs[2];
    j.id = ctx->outputs[3];
    j.px = (uint64_t)p->scale;
    double rows = floor((double)p->scale * h / w + 0.5);
    j.py = rows < 1 ? 1 : (uint64_t)rows;
    j.r = p->metric == MANHATTAN ? 3 : 2;
    j.seed = wg_hash3((uint32_t)ctx->seed, (uint32_t)(ctx->seed >> 32), 0x63656c6cu);
    int rc = job_init(&j, w, h);
    if (rc) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    /* one call per band of rows, so each band owns its scratch (bands depend on h only) */
    else
        rc = wg_parallel_rows(ctx, j.n_bands, cells_bands, &j);
    job_free(&j);
    return rc;
}

/* What job_init allocates: the column tables, and per band of rows the candidate points of
 * the coarse lattice and three distance rows. */
static size_t cells_scratch(const WgNodeContext *ctx)
{
    const CellsParams *p = ctx->params;
    size_t w = (size_t)ctx->width, px = (size_t)p->scale, r = p->metric == MANHATTAN ? 3 : 2;
    size_t pts = px <= w ? (2 * r + 1) * (px + 2 * r) : 1;
    size_t shared = w * 8 + 4 * (px + 2 * MAX_R) + 4 * (px + 1);
    size_t per_band = 4 * (3 * pts + 3 * w);
    return shared + (size_t)wg_parallel_chunks(ctx->height) * per_band;
}

const WgNodeType wg_node_cells = {
    .name = "cells",
    .summary = "Tileable Worley / Voronoi cellular noise: f1, f2, edges and cell id",
    .category = "generator",
    .doc = "One feature point per cell, at the cell centre displaced by jitter·(u − 1/2) per "
           "axis with u uniform (a hash of the cell and the seed): `jitter=\"0\"` is a regular "
           "grid (f1 = 0 at cell centres), 1 puts the point anywhere in its cell. The tile has "
           "`scale` cells across and max(1, round(scale·H/W)) down, the rule of every lattice "
           "generator, and cell indices wrap, so distances are measured on the torus and the "
           "output tiles exactly. Distances are in cell widths (in lattice units, so cells that "
           "round to slightly non-square pixels stretch with them) under the `euclidean`, "
           "`manhattan` or `chebyshev` metric. Outputs: `f1` and `f2`, the distances to the "
           "nearest and second nearest point, and `edges` = f2 − f1, all clamped to [0, 1] "
           "(f1 rarely exceeds 1: only with high jitter; f2 often does with Manhattan); `id`, a "
           "uniform value in [0, 1) per cell. The search is exact (no missed points): the 3×3 "
           "neighbourhood plus every further cell whose box could beat the current f2.",
    .params = cells_params,
    .params_size = sizeof(CellsParams),
    .outputs = cells_out,
    .flags = WG_NODE_SOURCE | WG_NODE_SEEDED,
    .eval = cells_eval,
    .scratch_bytes = cells_scratch,
};
