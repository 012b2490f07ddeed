/* SPDX-License-Identifier: MIT */
/* Helpers shared by the `normal` and `slope` tests: running a height-field node on an image, a
 * float64 reference gradient written independently of the node (periodic indexing, the 3×3
 * kernel spelled out), height fields with a known gradient (a periodic sine wave sampled at
 * texture coordinates x/W, so a 4× larger render has the same point at pixel 4x; a paraboloid),
 * rolling an image, and a deterministic noisy pattern.
 *
 * Length units: the nodes measure the gradient per length unit, a pixel of a 256-wide image
 * (docs/format.md), so for an image W pixels wide the gradient is
 * intensity · (W/256) · (height difference per pixel). */
#ifndef HEIGHTTEST_H
#define HEIGHTTEST_H

#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static inline WgImage *ht_run(const char *type, const char *attrs, const WgImage *src, int threads)
{
    const char *names[] = {"height"};
    const WgImage *imgs[] = {src};
    return wgt_node(type, attrs, src->width, src->height, 1, names, imgs, 0, threads);
}

static inline double ht_h(const WgImage *img, int x, int y)
{
    int w = img->width, h = img->height;
    return wg_image_row(img, ((y % h) + h) % h)[((x % w) + w) % w];
}

/* The float64 periodic finite-difference gradient at (x, y): gx to the right, gy downwards, in
 * height per length unit. Central: (h[+1] − h[−1]) / 2; sobel: 1-2-1 weighted, over 8. */
static inline void ht_gradient(const WgImage *img, double intensity, int sobel, int x, int y,
                               double *gx, double *gy)
{
    static const double wt[3] = {1, 2, 1};
    double s = intensity * img->width / 256.0;
    if (!sobel) {
        *gx = s * (ht_h(img, x + 1, y) - ht_h(img, x - 1, y)) / 2;
        *gy = s * (ht_h(img, x, y + 1) - ht_h(img, x, y - 1)) / 2;
        return;
    }
    double dx = 0, dy = 0;
    for (int i = -1; i <= 1; i++) {
        dx += wt[i + 1] * (ht_h(img, x + 1, y + i) - ht_h(img, x - 1, y + i));
        dy += wt[i + 1] * (ht_h(img, x + i, y + 1) - ht_h(img, x + i, y - 1));
    }
    *gx = s * dx / 8;
    *gy = s * dy / 8;
}

/* The unit normal (−∂z/∂x, −∂z/∂y_up, 1)/len of a surface whose gradient is gx (right) and
 * gy_down (downwards, so ∂z/∂y_up = −gy_down), OpenGL convention (y up). */
static inline void ht_normal(double gx, double gy_down, double n[3])
{
    double len = sqrt(1 + gx * gx + gy_down * gy_down);
    n[0] = -gx / len;
    n[1] = gy_down / len;
    n[2] = 1 / len;
}

/* The decoded normal of output pixel (x, y): 2·rgb − 1 (exact in double). */
static inline void ht_decode(const WgImage *out, int x, int y, double n[3])
{
    for (int k = 0; k < 3; k++) n[k] = 2.0 * wgt_px(out, x, y, k) - 1;
}

/* A periodic wave: h = 0.5 + amp · sin(2π(a·x/W + b·y/H) + phase), sampled at x/W. */
static double ht_amp = 0.25, ht_phase = 0.3;
static int ht_a = 1, ht_b = 2, ht_w = 64, ht_hh = 64;
static inline double ht_wave_fn(int x, int y, int k)
{
    (void)k;
    return 0.5 +
           ht_amp * sin(2 * M_PI * ((double)ht_a * x / ht_w + (double)ht_b * y / ht_hh) + ht_phase);
}
static inline WgImage *ht_wave(int w, int h, double amp, int a, int b)
{
    ht_amp = amp, ht_a = a, ht_b = b, ht_w = w, ht_hh = h;
    return wgt_image_fn(w, h, 1, ht_wave_fn);
}
/* The exact gradient (per length unit) of ht_wave on a square W×W image at pixel (x, y). */
static inline void ht_wave_gradient(int w, double intensity, int x, int y, double *gx, double *gy)
{
    double phi = 2 * M_PI * ((double)ht_a * x / w + (double)ht_b * y / w) + ht_phase;
    double c = intensity * ht_amp * 2 * M_PI / 256 * cos(phi);
    *gx = c * ht_a;
    *gy = c * ht_b;
}

/* A noisy pattern with steps and gentle parts. */
static inline double ht_pattern_fn(int x, int y, int k)
{
    return (wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k) & 0xffff) / 65535.0 +
           (x % 7 == 0 ? 0.5 : 0) - (y % 5 == 1 ? 0.25 : 0);
}

/* Roll an image by (dx, dy) with wrap-around. */
static inline WgImage *ht_roll(const WgImage *src, int dx, int dy)
{
    int w = src->width, h = src->height, c = src->channels;
    WgImage *out = wgt_image(w, h, c, NULL);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < c; k++)
                wg_image_row(out, (y + dy) % h)[((x + dx) % w) * c + k] = wgt_px(src, x, y, k);
    return out;
}

static inline WgImage *ht_const(int w, int h, float v)
{
    WgImage *img = wgt_image(w, h, 1, NULL);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) wg_image_row(img, y)[x] = v;
    return img;
}

/* Tiling: cyclic shifts of the height (by {5,0}, {0,7}, {W-1,H-1}, {11,13} on a 37×22 pattern)
 * shift the output of node `type` with `attrs` exactly. */
static inline void ht_assert_tiles(const char *type, const char *attrs)
{
    WgImage *src = wgt_image_fn(37, 22, 1, ht_pattern_fn);
    static const int rolls[][2] = {{5, 0}, {0, 7}, {36, 21}, {11, 13}};
    WgImage *ref = ht_run(type, attrs, src, 2);
    for (int r = 0; r < 4; r++) {
        WgImage *rolled = ht_roll(src, rolls[r][0], rolls[r][1]);
        WgImage *out = ht_run(type, attrs, rolled, 2);
        WgImage *want = ht_roll(ref, rolls[r][0], rolls[r][1]);
        wgt_assert_identical(out, want);
        wg_image_unref(want);
        wg_image_unref(out);
        wg_image_unref(rolled);
    }
    wg_image_unref(ref);
    wg_image_unref(src);
}

/* The same bits from 1, 2, 3 and 8 threads on a 300×150 pattern. */
static inline void ht_assert_thread_invariant(const char *type, const char *attrs)
{
    WgImage *src = wgt_image_fn(300, 150, 1, ht_pattern_fn);
    WgImage *a = ht_run(type, attrs, src, 1);
    static const int threads[] = {2, 3, 8};
    for (int t = 0; t < 3; t++) {
        WgImage *b = ht_run(type, attrs, src, threads[t]);
        wgt_assert_identical(a, b);
        wg_image_unref(b);
    }
    wg_image_unref(a);
    wg_image_unref(src);
}

#endif
