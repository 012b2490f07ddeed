/* SPDX-License-Identifier: MIT */
/* Helpers shared by the `warp`, `directional_warp` and `transform` tests: running the nodes, a
 * float64 periodic sampler written independently of the node (positions reduced with fmod, the
 * bilinear tent and Keys' piecewise cubic kernel, a = −0.5, evaluated from their textbook
 * formulas), random and smooth test images, and exact cyclic shifts. Positions are in pixels
 * with pixel centres at integers. */
#ifndef WARPTEST_H
#define WARPTEST_H

#include "heighttest.h"

#include <float.h>

/* Run `type` at the source's size with `source` and, when not NULL, `intensity` connected. */
static inline WgImage *wt_run(const char *type, const char *attrs, const WgImage *src,
                              const WgImage *intensity, int threads)
{
    const char *names[] = {"source", "intensity"};
    const WgImage *imgs[] = {src, intensity};
    return wgt_node(type, attrs, src->width, src->height, intensity ? 2 : 1, names, imgs, 0,
                    threads);
}

static inline double wt_px(const WgImage *img, long x, long y, int k)
{
    long w = img->width, h = img->height;
    return wg_image_row(img, (int)(((y % h) + h) % h))[(((x % w) + w) % w) * img->channels + k];
}

static inline double wt_keys(double x)
{
    const double a = -0.5;
    x = fabs(x);
    if (x <= 1) return (a + 2) * x * x * x - (a + 3) * x * x + 1;
    if (x < 2) return a * x * x * x - 5 * a * x * x + 8 * a * x - 4 * a;
    return 0;
}

/* The periodic image sampled at pixel position (px, py), channel k, in float64. */
static inline double wt_sample(const WgImage *img, double px, double py, int bicubic, int k)
{
    px = fmod(px, img->width);
    if (px < 0) px += img->width;
    py = fmod(py, img->height);
    if (py < 0) py += img->height;
    double x0 = floor(px), y0 = floor(py);
    if (!bicubic) {
        double fx = px - x0, fy = py - y0;
        return (1 - fx) * (1 - fy) * wt_px(img, (long)x0, (long)y0, k) +
               fx * (1 - fy) * wt_px(img, (long)x0 + 1, (long)y0, k) +
               (1 - fx) * fy * wt_px(img, (long)x0, (long)y0 + 1, k) +
               fx * fy * wt_px(img, (long)x0 + 1, (long)y0 + 1, k);
    }
    double s = 0;
    for (int j = -1; j <= 2; j++)
        for (int i = -1; i <= 2; i++)
            s += wt_keys(px - (x0 + i)) * wt_keys(py - (y0 + j)) *
                 wt_px(img, (long)x0 + i, (long)y0 + j, k);
    return s;
}

/* Uniform random values in [0, 1), a different stream per channel and per `salt`. */
static uint32_t wt_salt = 1;
static inline double wt_random_fn(int x, int y, int k)
{
    return (wg_hash3((uint32_t)x * 7919u + wt_salt, (uint32_t)y, (uint32_t)k) & 0xffffff) /
           16777216.0;
}
static inline WgImage *wt_random(int w, int h, int channels, uint32_t salt)
{
    wt_salt = salt;
    return wgt_image_fn(w, h, channels, wt_random_fn);
}

/* A smooth periodic picture sampled at texture coordinates x/W, y/H (so pixel (x, y) of a W²
 * render and (4x, 4y) of a (4W)² one are the same point), different per channel. */
static int wt_sw = 64, wt_sh = 64;
static inline double wt_smooth_fn(int x, int y, int k)
{
    double u = 2 * M_PI * x / wt_sw, v = 2 * M_PI * y / wt_sh;
    return 0.5 + 0.3 * sin(u + 0.7 * k) * cos(v - 0.2) + 0.15 * sin(2 * v + u + k);
}
static inline WgImage *wt_smooth(int w, int h, int channels)
{
    wt_sw = w, wt_sh = h;
    return wgt_image_fn(w, h, channels, wt_smooth_fn);
}

/* out(x, y) = src(x − dx, y − dy), wrapped. */
static inline WgImage *wt_shift(const WgImage *src, int dx, int dy)
{
    int w = src->width, h = src->height;
    return ht_roll(src, ((dx % w) + w) % w, ((dy % h) + h) % h);
}

static inline void wt_assert_finite(const WgImage *img)
{
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width * img->channels; x++)
            if (!isfinite(wg_image_row(img, y)[x]))
                fail_msg("value %d of row %d is %g", x, y, wg_image_row(img, y)[x]);
}

#endif
