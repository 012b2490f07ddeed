/* SPDX-License-Identifier: MIT */
/* `distance`, `dilate` and `erode` against a float64 brute force (every pixel against every mask
 * pixel, on the torus or in the plane, ties to the smallest (y, x)) on random masks of several
 * sizes, square, non-square, odd, 1xN and Nx1: pixels, falloff and signed modes, the Voronoi
 * fill (with its tie rule), dilate and erode for several radii including 0. Also hand-computed
 * small cases (distances across the tile edges), empty and full masks, a single pixel, tiling
 * (a cyclic shift of the mask shifts the output exactly), thread-count invariance, resolution
 * independence of the falloff, and errors. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static WgImage *run(const char *type, const char *attrs, const WgImage *mask, const WgImage *src,
                    int threads)
{
    const char *names[] = {"mask", "source"};
    const WgImage *imgs[] = {mask, src};
    return wgt_node(type, attrs, mask->width, mask->height, src ? 2 : 1, names, imgs, 0, threads);
}

static WgImage *dist(const WgImage *mask, const char *mode, bool wrap, double range, int threads)
{
    char attrs[128];
    snprintf(attrs, sizeof attrs, "mode=\"%s\" wrap=\"%s\" distance=\"%.9g\"", mode,
             wrap ? "true" : "false", range);
    return run("distance", attrs, mask, NULL, threads);
}

/* Brute force: squared distance to the nearest site (mask >= 0.5, or < 0.5 with invert) and that
 * site, the smallest (y, x) among ties; d2 = -1 without any site. Returns the number of pixels
 * with tied nearest sites. */
typedef struct {
    long long d2;
    int x, y;
} Near;

static int brute(const WgImage *mask, bool wrap, bool invert, Near *out)
{
    int w = mask->width, h = mask->height, ties = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            Near best = {-1, 0, 0};
            int count = 0;
            for (int sy = 0; sy < h; sy++)
                for (int sx = 0; sx < w; sx++) {
                    if ((wgt_px(mask, sx, sy, 0) >= 0.5f) == invert) continue;
                    long long dx = llabs((long long)x - sx), dy = llabs((long long)y - sy);
                    if (wrap && w - dx < dx) dx = w - dx;
                    if (wrap && h - dy < dy) dy = h - dy;
                    long long d2 = dx * dx + dy * dy;
                    if (best.d2 < 0 || d2 < best.d2) { /* scanning order is (y, x) ascending */
                        best = (Near){d2, sx, sy};
                        count = 1;
                    } else if (d2 == best.d2)
                        count++;
                }
            ties += count > 1;
            out[(size_t)y * w + x] = best;
        }
    return ties;
}

static uint32_t seed_of(int w, int h, int variant)
{
    return (uint32_t)(w * 7919 + h * 104729 + variant * 1299709);
}

/* Random masks: variant 0 sparse pixels, 1 about half, 2 blobs (discs), 3 dense with thin holes;
 * values spread over [0, 1] with exact 0.5 and just-below values, so the threshold is tested. */
static WgImage *random_mask(int w, int h, int variant)
{
    WgImage *m = wgt_image(w, h, 1, NULL);
    uint32_t seed = seed_of(w, h, variant);
    int cx[4], cy[4];
    double cr[4];
    for (int i = 0; i < 4; i++) {
        cx[i] = (int)(wg_hash3(seed, 11, (uint32_t)i) % (uint32_t)w);
        cy[i] = (int)(wg_hash3(seed, 13, (uint32_t)i) % (uint32_t)h);
        cr[i] = 1 + (wg_hash3(seed, 17, (uint32_t)i) % 1000) / 1000.0 * (w + h) / 8.0;
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint32_t r = wg_hash3(seed, (uint32_t)x, (uint32_t)y);
            double u = (r & 0xffff) / 65535.0;
            bool on;
            switch (variant) {
            case 0:
                on = u < 0.04;
                break;
            case 1:
                on = u < 0.5;
                break;
            case 2:
                on = false;
                for (int i = 0; i < 4; i++) {
                    double dx = x - cx[i], dy = y - cy[i];
                    if (dx * dx + dy * dy <= cr[i] * cr[i]) on = true;
                }
                break;
            default:
                on = u < 0.9;
                break;
            }
            float v = on ? 0.5f + 0.5f * (float)((r >> 16) & 0xff) / 255.0f
                         : 0.4999999f * (float)((r >> 24) & 0xff) / 255.0f;
            if (((r >> 8) & 0x1f) == 0) v = on ? 0.5f : nextafterf(0.5f, 0.0f);
            wg_image_row(m, y)[x] = v;
        }
    return m;
}

/* 600 wide: more than one band of columns in the column pass */
static const int sizes[][2] = {{17, 13}, {32, 32}, {1, 23}, {23, 1},  {40, 9}, {8, 41},
                               {31, 31}, {1, 1},   {2, 3},  {50, 50}, {600, 4}};
enum { N_SIZES = sizeof sizes / sizeof sizes[0] };

static double none_distance(int w, int h, bool wrap)
{
    return wrap ? sqrt(0.25 * w * w + 0.25 * h * h) : sqrt((double)w * w + (double)h * h);
}

static double near_d(const Near *n, int w, int h, bool wrap)
{
    return n->d2 < 0 ? none_distance(w, h, wrap) : sqrt((double)n->d2);
}

static void check_value(const WgImage *got, int x, int y, double want, double tol, const char *what)
{
    double v = wgt_px(got, x, y, 0);
    if (!(fabs(v - want) <= tol))
        fail_msg("%s %dx%d at (%d,%d): %.9g, expected %.9g", what, got->width, got->height, x, y, v,
                 want);
}

static void test_pixels_falloff_signed_vs_brute_force(void **state)
{
    (void)state;
    for (int s = 0; s < N_SIZES; s++)
        for (int variant = 0; variant < 4; variant++)
            for (int wrap = 0; wrap < 2; wrap++) {
                int w = sizes[s][0], h = sizes[s][1];
                WgImage *mask = random_mask(w, h, variant);
                Near *out = malloc(sizeof(Near) * (size_t)w * h);
                Near *in = malloc(sizeof(Near) * (size_t)w * h);
                brute(mask, wrap, false, out);
                brute(mask, wrap, true, in);
                double range = 37.5; /* R = 37.5 w / 256 pixels */
                double rpx = range * w / 256;
                WgImage *px = dist(mask, "pixels", wrap, range, 2);
                WgImage *fo = dist(mask, "falloff", wrap, range, 2);
                WgImage *sg = dist(mask, "signed", wrap, range, 2);
                wgt_assert_range(px, 0, 1e9);
                wgt_assert_range(fo, 0, 1);
                wgt_assert_range(sg, -1e9, 1e9);
                bool empty = out[0].d2 < 0;
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++) {
                        const Near *o = &out[(size_t)y * w + x], *i = &in[(size_t)y * w + x];
                        double d = near_d(o, w, h, wrap);
                        check_value(px, x, y, d, 1e-3, wrap ? "pixels wrap" : "pixels");
                        double f = empty ? 0 : fmin(1, fmax(0, 1 - d / rpx));
                        check_value(fo, x, y, f, 1e-5, "falloff");
                        double sd = o->d2 > 0 ? d : -near_d(i, w, h, wrap);
                        if (empty) sd = none_distance(w, h, wrap);
                        check_value(sg, x, y, sd, 1e-3, "signed");
                    }
                wg_image_unref(sg);
                wg_image_unref(fo);
                wg_image_unref(px);
                free(in);
                free(out);
                wg_image_unref(mask);
            }
}

/* A colour source whose every pixel is different: the fill says which site was taken. */
static double id_fn(int x, int y, int k)
{
    return k == 0 ? x : k == 1 ? y : k == 2 ? (x * 31 + y) * 0.5 : 1;
}

static void check_fill(const WgImage *mask, bool wrap, int threads, int *ties)
{
    int w = mask->width, h = mask->height;
    Near *out = malloc(sizeof(Near) * (size_t)w * h);
    *ties += brute(mask, wrap, false, out);
    WgImage *src = wgt_image_fn(w, h, 4, id_fn);
    WgImage *gray = wgt_image_fn(w, h, 1, id_fn); /* channel 0: x */
    WgImage *f = run("distance", wrap ? "" : "wrap=\"false\"", mask, src, threads);
    WgImage *g = run("distance", wrap ? "" : "wrap=\"false\"", mask, gray, threads);
    assert_int_equal(f->channels, 4);
    assert_int_equal(g->channels, 1);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const Near *o = &out[(size_t)y * w + x];
            for (int k = 0; k < 4; k++) {
                double want = o->d2 < 0 ? 0 : id_fn(o->x, o->y, k);
                if (wgt_px(f, x, y, k) != (float)want)
                    fail_msg("fill %dx%d wrap %d at (%d,%d) channel %d: %g, expected %g (site "
                             "(%d,%d))",
                             w, h, wrap, x, y, k, wgt_px(f, x, y, k), want, o->x, o->y);
            }
            assert_true(wgt_px(g, x, y, 0) == wgt_px(f, x, y, 0));
        }
    wg_image_unref(g);
    wg_image_unref(f);
    wg_image_unref(gray);
    wg_image_unref(src);
    free(out);
}

static void test_voronoi_fill_vs_brute_force(void **state)
{
    (void)state;
    int ties = 0;
    for (int s = 0; s < N_SIZES; s++)
        for (int variant = 0; variant < 4; variant++)
            for (int wrap = 0; wrap < 2; wrap++) {
                WgImage *mask = random_mask(sizes[s][0], sizes[s][1], variant);
                check_fill(mask, wrap, 2, &ties);
                wg_image_unref(mask);
            }
    assert_true(ties > 1000); /* the tie rule was exercised */
}

static void test_fill_tie_rule(void **state)
{
    (void)state;
    /* 9x9, no wrap: sites (0,4) and (8,4) tie at (4,4): same row, the smaller column wins */
    WgImage *mask = wgt_image(9, 9, 1, NULL);
    wg_image_row(mask, 4)[0] = 1;
    wg_image_row(mask, 4)[8] = 1;
    WgImage *src = wgt_image_fn(9, 9, 4, id_fn);
    WgImage *f = run("distance", "wrap=\"false\"", mask, src, 1);
    assert_true(wgt_px(f, 4, 4, 0) == 0 && wgt_px(f, 4, 4, 1) == 4);
    wg_image_unref(f);
    /* sites above and below: the smaller row wins */
    wg_image_row(mask, 4)[0] = 0;
    wg_image_row(mask, 4)[8] = 0;
    wg_image_row(mask, 1)[4] = 1;
    wg_image_row(mask, 7)[4] = 1;
    f = run("distance", "wrap=\"false\"", mask, src, 1);
    assert_true(wgt_px(f, 4, 4, 0) == 4 && wgt_px(f, 4, 4, 1) == 1);
    wg_image_unref(f);
    /* a Pythagorean tie: (4,5), (3,4) and (5,8) are all 5 from (0,8); the smallest row wins */
    memset(wg_image_row(mask, 1), 0, sizeof(float) * 9);
    memset(wg_image_row(mask, 7), 0, sizeof(float) * 9);
    wg_image_row(mask, 5)[4] = 1;
    wg_image_row(mask, 4)[3] = 1;
    wg_image_row(mask, 8)[5] = 1;
    f = run("distance", "wrap=\"false\"", mask, src, 1);
    assert_true(wgt_px(f, 0, 8, 0) == 3 && wgt_px(f, 0, 8, 1) == 4);
    WgImage *px = dist(mask, "pixels", false, 10, 1);
    assert_true(wgt_px(px, 0, 8, 0) == 5);
    wg_image_unref(px);
    wg_image_unref(f);
    wg_image_unref(src);
    wg_image_unref(mask);
    /* a tie at a breakpoint whose quotient, 98 / 98, a double product 98 x (1 / 98) puts just
     * below 1: on row 48, (0,0) and (49,47) are both sqrt(2305) from (1,48); the smaller row
     * wins there, the other from x = 2 on */
    mask = wgt_image(60, 60, 1, NULL);
    src = wgt_image_fn(60, 60, 4, id_fn);
    wg_image_row(mask, 0)[0] = 1;
    wg_image_row(mask, 47)[49] = 1;
    f = run("distance", "wrap=\"false\"", mask, src, 1);
    assert_true(wgt_px(f, 1, 48, 0) == 0 && wgt_px(f, 1, 48, 1) == 0);
    assert_true(wgt_px(f, 2, 48, 0) == 49 && wgt_px(f, 2, 48, 1) == 47);
    int ties = 0;
    check_fill(mask, false, 2, &ties);
    assert_true(ties > 0);
    wg_image_unref(f);
    wg_image_unref(src);
    wg_image_unref(mask);
}

static void test_exact_small_cases(void **state)
{
    (void)state;
    /* one pixel at (0,0) of 5x4 */
    WgImage *mask = wgt_image(5, 4, 1, NULL);
    wg_image_row(mask, 0)[0] = 1;
    WgImage *a = dist(mask, "pixels", true, 10, 1);
    WgImage *b = dist(mask, "pixels", false, 10, 1);
    assert_true(wgt_px(a, 0, 0, 0) == 0);
    assert_float_equal(wgt_px(a, 4, 3, 0), sqrt(2), 1e-6); /* across the corner */
    assert_float_equal(wgt_px(a, 4, 0, 0), 1, 0);
    assert_float_equal(wgt_px(a, 0, 3, 0), 1, 0);
    assert_float_equal(wgt_px(a, 2, 0, 0), 2, 0);
    assert_float_equal(wgt_px(a, 3, 0, 0), 2, 0);
    assert_float_equal(wgt_px(a, 2, 2, 0), sqrt(8), 1e-6);
    assert_float_equal(wgt_px(a, 3, 1, 0), sqrt(5), 1e-6);
    assert_float_equal(wgt_px(b, 4, 3, 0), 5, 0);
    assert_float_equal(wgt_px(b, 2, 2, 0), sqrt(8), 1e-6);
    assert_float_equal(wgt_px(b, 3, 1, 0), sqrt(10), 1e-6);
    wg_image_unref(b);
    wg_image_unref(a);
    wg_image_unref(mask);
    /* falloff at 256 wide: R = distance pixels */
    WgImage *m256 = wgt_image(256, 4, 1, NULL);
    wg_image_row(m256, 0)[10] = 1;
    WgImage *f = dist(m256, "falloff", true, 8, 1);
    assert_float_equal(wgt_px(f, 10, 0, 0), 1, 0);
    assert_float_equal(wgt_px(f, 14, 0, 0), 0.5, 1e-7);
    assert_float_equal(wgt_px(f, 12, 0, 0), 0.75, 1e-7);
    assert_float_equal(wgt_px(f, 18, 0, 0), 0, 0);
    assert_float_equal(wgt_px(f, 30, 2, 0), 0, 0);
    assert_float_equal(wgt_px(f, 10, 3, 0), 0.875, 1e-7); /* wraps vertically: 1 away */
    wg_image_unref(f);
    /* at 512 wide the same distance covers 16 pixels */
    WgImage *m512 = wgt_image(512, 4, 1, NULL);
    wg_image_row(m512, 0)[10] = 1;
    f = dist(m512, "falloff", true, 8, 1);
    assert_float_equal(wgt_px(f, 14, 0, 0), 0.75, 1e-7);
    wg_image_unref(f);
    /* distance 0: the mask itself */
    f = dist(m512, "falloff", true, 0, 1);
    assert_float_equal(wgt_px(f, 10, 0, 0), 1, 0);
    assert_float_equal(wgt_px(f, 11, 0, 0), 0, 0);
    wg_image_unref(f);
    wg_image_unref(m512);
    wg_image_unref(m256);
    /* signed: a 3x3 block in 7x7 */
    WgImage *blk = wgt_image(7, 7, 1, NULL);
    for (int y = 2; y <= 4; y++)
        for (int x = 2; x <= 4; x++) wg_image_row(blk, y)[x] = 1;
    WgImage *sg = dist(blk, "signed", false, 10, 1);
    assert_float_equal(wgt_px(sg, 3, 3, 0), -2, 0);
    assert_float_equal(wgt_px(sg, 2, 2, 0), -1, 0);
    assert_float_equal(wgt_px(sg, 1, 3, 0), 1, 0);
    assert_float_equal(wgt_px(sg, 0, 0, 0), sqrt(8), 1e-6);
    wg_image_unref(sg);
    sg = dist(blk, "signed", true, 10, 1); /* 7x7 wrap: (6,6) is 2 from (4,4) diagonally too */
    assert_float_equal(wgt_px(sg, 6, 6, 0), sqrt(8), 1e-6);
    assert_float_equal(wgt_px(sg, 0, 3, 0), 2, 0);
    wg_image_unref(sg);
    wg_image_unref(blk);
    /* default mode is falloff with distance 10 and wrap */
    WgImage *one = wgt_image(64, 64, 1, NULL);
    wg_image_row(one, 63)[63] = 0.5f;
    WgImage *d = run("distance", "", one, NULL, 1);
    assert_float_equal(wgt_px(d, 0, 0, 0), 1 - sqrt(2) / 2.5, 1e-6);
    wg_image_unref(d);
    wg_image_unref(one);
}

static WgImage *constant(int w, int h, float v)
{
    WgImage *m = wgt_image(w, h, 1, NULL);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) wg_image_row(m, y)[x] = v;
    return m;
}

static void assert_all(const WgImage *img, double v, const char *what)
{
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            for (int k = 0; k < img->channels; k++)
                if (wgt_px(img, x, y, k) != (float)v)
                    fail_msg("%s %dx%d (%d,%d,%d): %.9g, expected %.9g", what, img->width,
                             img->height, x, y, k, wgt_px(img, x, y, k), v);
}

static void test_empty_and_full_masks(void **state)
{
    (void)state;
    static const int dims[][2] = {{1, 1}, {1, 7}, {7, 1}, {6, 4}, {33, 20}};
    for (int i = 0; i < 5; i++)
        for (int wrap = 0; wrap < 2; wrap++) {
            int w = dims[i][0], h = dims[i][1];
            double none = none_distance(w, h, wrap);
            WgImage *e = constant(w, h, 0.25f), *full = constant(w, h, 0.5f);
            WgImage *o;
            o = dist(e, "falloff", wrap, 300, 2), assert_all(o, 0, "empty falloff");
            wg_image_unref(o);
            o = dist(e, "pixels", wrap, 10, 2), assert_all(o, none, "empty pixels");
            wg_image_unref(o);
            o = dist(e, "signed", wrap, 10, 2), assert_all(o, none, "empty signed");
            wg_image_unref(o);
            o = dist(full, "falloff", wrap, 10, 2), assert_all(o, 1, "full falloff");
            wg_image_unref(o);
            o = dist(full, "pixels", wrap, 10, 2), assert_all(o, 0, "full pixels");
            wg_image_unref(o);
            o = dist(full, "signed", wrap, 10, 2), assert_all(o, -none, "full signed");
            wg_image_unref(o);
            WgImage *src = wgt_image_fn(w, h, 4, id_fn);
            o = run("distance", wrap ? "" : "wrap=\"false\"", e, src, 2);
            assert_all(o, 0, "empty fill");
            wg_image_unref(o);
            o = run("distance", wrap ? "" : "wrap=\"false\"", full, src, 2);
            wgt_assert_identical(o, src); /* every pixel is its own nearest mask pixel */
            wg_image_unref(o);
            const char *attrs = wrap ? "radius=\"100\"" : "radius=\"100\" wrap=\"false\"";
            o = run("dilate", attrs, e, NULL, 2), assert_all(o, 0, "empty dilate");
            wg_image_unref(o);
            o = run("erode", attrs, e, NULL, 2), assert_all(o, 0, "empty erode");
            wg_image_unref(o);
            o = run("dilate", attrs, full, NULL, 2), assert_all(o, 1, "full dilate");
            wg_image_unref(o);
            o = run("erode", attrs, full, NULL, 2), assert_all(o, 1, "full erode");
            wg_image_unref(o);
            wg_image_unref(src);
            wg_image_unref(full);
            wg_image_unref(e);
        }
    /* NaN and infinite mask values: NaN is not in the mask, +inf is */
    WgImage *m = constant(5, 5, NAN);
    wg_image_row(m, 2)[2] = INFINITY;
    wg_image_row(m, 0)[0] = -INFINITY;
    WgImage *o = dist(m, "signed", true, 10, 1);
    wgt_assert_range(o, -10, 10);
    assert_float_equal(wgt_px(o, 2, 2, 0), -1, 0);
    assert_float_equal(wgt_px(o, 0, 0, 0), sqrt(8), 1e-6);
    wg_image_unref(o);
    wg_image_unref(m);
}

/* Roll an image by (dx, dy) with wrap-around. */
static WgImage *roll(const WgImage *src, int dx, int dy)
{
    int w = src->width, h = src->height, c = src->channels;
    WgImage *out = wgt_image(w, h, c, NULL);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < c; k++)
                wg_image_row(out, (y + dy) % h)[((x + dx) % w) * c + k] = wgt_px(src, x, y, k);
    return out;
}

static void test_tiling_shift_commutes(void **state)
{
    (void)state;
    static const int rolls[][2] = {{1, 0}, {0, 1}, {20, 0}, {0, 30}, {36, 40}, {13, 7}};
    static const char *modes[] = {"pixels", "falloff", "signed"};
    for (int variant = 0; variant < 4; variant++) {
        WgImage *mask = random_mask(37, 41, variant);
        for (int m = 0; m < 3; m++) {
            WgImage *ref = dist(mask, modes[m], true, 40, 2);
            for (int r = 0; r < 6; r++) {
                WgImage *rolled = roll(mask, rolls[r][0], rolls[r][1]);
                WgImage *o = dist(rolled, modes[m], true, 40, 2);
                WgImage *back = roll(o, 37 - rolls[r][0], 41 - rolls[r][1]);
                wgt_assert_identical(back, ref);
                wg_image_unref(back);
                wg_image_unref(o);
                wg_image_unref(rolled);
            }
            wg_image_unref(ref);
        }
        for (int r = 0; r < 6; r++) {
            WgImage *rolled = roll(mask, rolls[r][0], rolls[r][1]);
            WgImage *a = run("dilate", "radius=\"30\"", mask, NULL, 1);
            WgImage *b = run("dilate", "radius=\"30\"", rolled, NULL, 1);
            WgImage *back = roll(b, 37 - rolls[r][0], 41 - rolls[r][1]);
            wgt_assert_identical(back, a);
            wg_image_unref(back);
            wg_image_unref(b);
            wg_image_unref(a);
            wg_image_unref(rolled);
        }
        wg_image_unref(mask);
    }
}

static void test_thread_invariance(void **state)
{
    (void)state;
    static const int threads[] = {1, 2, 3, 8};
    WgImage *mask = random_mask(1100, 97, 2); /* three bands of columns */
    WgImage *sparse = random_mask(97, 150, 0);
    WgImage *src = wgt_image_fn(1100, 97, 4, id_fn);
    WgImage *ref[5] = {0};
    for (int t = 0; t < 4; t++) {
        WgImage *o[5] = {
            dist(mask, "signed", true, 10, threads[t]),
            dist(sparse, "falloff", false, 30, threads[t]),
            run("distance", "", mask, src, threads[t]),
            run("dilate", "radius=\"7\" wrap=\"false\"", sparse, NULL, threads[t]),
            run("erode", "radius=\"5\"", mask, NULL, threads[t]),
        };
        for (int i = 0; i < 5; i++) {
            if (t == 0)
                ref[i] = o[i];
            else {
                wgt_assert_identical(o[i], ref[i]);
                wg_image_unref(o[i]);
            }
        }
    }
    for (int i = 0; i < 5; i++) wg_image_unref(ref[i]);
    wg_image_unref(src);
    wg_image_unref(sparse);
    wg_image_unref(mask);
}

static void test_resolution_independence(void **state)
{
    (void)state;
    WgImage *m = random_mask(256, 256, 2);
    WgImage *seeds = random_mask(256, 256, 0);
    WgImage *masks[] = {m, seeds};
    for (int i = 0; i < 2; i++) {
        WgImage *big = wgt_image(512, 512, 1, NULL);
        for (int y = 0; y < 512; y++)
            for (int x = 0; x < 512; x++)
                wg_image_row(big, y)[x] = wgt_px(masks[i], x / 2, y / 2, 0);
        for (int wrap = 0; wrap < 2; wrap++) {
            double range = 24;
            WgImage *a = dist(masks[i], "falloff", wrap, range, 2);
            WgImage *b = dist(big, "falloff", wrap, range, 2);
            /* R is 24 pixels at 256 and 48 at 512; the distances agree within ~1 pixel of the
             * 512 image (the pixel centres of the two grids are half a 512-pixel apart) */
            double tol = 1.5 / (range * 2), worst = 0;
            for (int y = 0; y < 256; y++)
                for (int x = 0; x < 256; x++) {
                    double e = fabs(wgt_px(a, x, y, 0) - wgt_px(b, 2 * x, 2 * y, 0));
                    if (e > worst) worst = e;
                }
            if (worst > tol) fail_msg("mask %d wrap %d: falloff differs by %g", i, wrap, worst);
            wg_image_unref(b);
            wg_image_unref(a);
        }
        wg_image_unref(big);
    }
    wg_image_unref(seeds);
    wg_image_unref(m);
}

static void test_dilate_erode_vs_brute_force(void **state)
{
    (void)state;
    static const double radii_px[] = {0, 0.5, 1, 1.5, 2, 2.3, 3, 4.2, 7};
    for (int s = 0; s < N_SIZES; s++)
        for (int variant = 0; variant < 4; variant++)
            for (int wrap = 0; wrap < 2; wrap++) {
                int w = sizes[s][0], h = sizes[s][1];
                WgImage *mask = random_mask(w, h, variant);
                Near *out = malloc(sizeof(Near) * (size_t)w * h);
                Near *in = malloc(sizeof(Near) * (size_t)w * h);
                brute(mask, wrap, false, out);
                brute(mask, wrap, true, in);
                for (int r = 0; r < 9; r++) {
                    float radius = (float)(radii_px[r] * 256 / w); /* the length given */
                    double rp = (double)radius * w / 256;
                    char attrs[96];
                    snprintf(attrs, sizeof attrs, "radius=\"%.9g\" wrap=\"%s\"", radius,
                             wrap ? "true" : "false");
                    WgImage *di = run("dilate", attrs, mask, NULL, 2);
                    WgImage *er = run("erode", attrs, mask, NULL, 2);
                    for (int y = 0; y < h; y++)
                        for (int x = 0; x < w; x++) {
                            const Near *o = &out[(size_t)y * w + x], *i = &in[(size_t)y * w + x];
                            float want_d = o->d2 >= 0 && (double)o->d2 <= rp * rp ? 1.0f : 0.0f;
                            float want_e = i->d2 < 0 || (double)i->d2 > rp * rp ? 1.0f : 0.0f;
                            if (wgt_px(di, x, y, 0) != want_d || wgt_px(er, x, y, 0) != want_e)
                                fail_msg("%dx%d v%d wrap %d r %g at (%d,%d): dilate %g (%g), "
                                         "erode %g (%g)",
                                         w, h, variant, wrap, rp, x, y, wgt_px(di, x, y, 0), want_d,
                                         wgt_px(er, x, y, 0), want_e);
                        }
                    if (r == 0) { /* radius 0 thresholds the mask */
                        for (int y = 0; y < h; y++)
                            for (int x = 0; x < w; x++) {
                                float t = wgt_px(mask, x, y, 0) >= 0.5f ? 1.0f : 0.0f;
                                assert_true(wgt_px(di, x, y, 0) == t && wgt_px(er, x, y, 0) == t);
                            }
                    }
                    wg_image_unref(er);
                    wg_image_unref(di);
                }
                free(in);
                free(out);
                wg_image_unref(mask);
            }
}

static void test_errors(void **state)
{
    (void)state;
    WgImage *g = wgt_image(4, 4, 1, NULL);
    WgImage *c = wgt_image(4, 4, 4, NULL);
    const char *names[] = {"mask", "source"};
    const WgImage *gray[] = {g, c};
    const WgImage *color[] = {c};
    WgError err;
    assert_int_not_equal(wgt_node_error("distance", "", 4, 4, 1, names, color, &err), WG_OK);
    assert_int_equal(wgt_node_error("distance", "distance=\"-1\"", 4, 4, 1, names, gray, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "distance"));
    assert_int_not_equal(wgt_node_error("distance", "mode=\"euclid\"", 4, 4, 1, names, gray, &err),
                         WG_OK);
    assert_int_not_equal(wgt_node_error("distance", "", 4, 4, 0, names, gray, &err), WG_OK);
    assert_int_equal(wgt_node_error("dilate", "radius=\"-0.5\"", 4, 4, 1, names, gray, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "radius"));
    assert_int_not_equal(wgt_node_error("erode", "", 4, 4, 1, names, color, &err), WG_OK);
    wg_image_unref(c);
    wg_image_unref(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_small_cases),
        cmocka_unit_test(test_pixels_falloff_signed_vs_brute_force),
        cmocka_unit_test(test_voronoi_fill_vs_brute_force),
        cmocka_unit_test(test_fill_tie_rule),
        cmocka_unit_test(test_empty_and_full_masks),
        cmocka_unit_test(test_tiling_shift_commutes),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_resolution_independence),
        cmocka_unit_test(test_dilate_erode_vs_brute_force),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
