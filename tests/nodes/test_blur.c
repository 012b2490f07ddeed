/* SPDX-License-Identifier: MIT */
/* `blur` against a straightforward float64 periodic Gaussian (a direct 2-D sum over every
 * source pixel with wrap-around, the kernel summed over all periodic images), for several
 * sigmas including 0, sub-pixel ones, kernels wider than the image and sigma beyond the image
 * (the mean); non-square and colour images; tiling (rolling commutes with the blur); flat
 * inputs, impulses and extreme values; errors; thread invariance. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static WgImage *blur(const WgImage *src, double sigma, int threads)
{
    char attrs[64];
    snprintf(attrs, sizeof attrs, "sigma=\"%.17g\"", sigma);
    const char *names[] = {"source"};
    const WgImage *imgs[] = {src};
    return wgt_node("blur", attrs, src->width, src->height, 1, names, imgs, 0, threads);
}

/* Periodic Gaussian weight of offset d on a ring of n pixels (unnormalised). */
static double ring_weight(int d, int n, double sigma)
{
    double w = 0;
    int reach = (int)ceil(12 * sigma) + n;
    for (int m = -(reach / n + 1); m <= reach / n + 1; m++) {
        double e = d + (double)m * n;
        w += exp(-e * e / (2 * sigma * sigma));
    }
    return w;
}

/* Direct 2-D sum: out(x,y) = sum over all (i,j) of G(i,j) in(x+i, y+j), G the normalised
 * periodic 2-D Gaussian exp(-(i^2 + j^2) / 2 sigma^2). */
static double *reference(const WgImage *src, double sigma)
{
    int w = src->width, h = src->height, c = src->channels;
    double *g = malloc(sizeof(double) * (size_t)w * (size_t)h);
    double total = 0;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            /* the 2-D periodic sum of exp(-(a^2+b^2)/2s^2) factors over a and b */
            g[j * w + i] = ring_weight(i, w, sigma) * ring_weight(j, h, sigma);
            total += g[j * w + i];
        }
    double *out = calloc((size_t)w * (size_t)h * (size_t)c, sizeof(double));
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int j = 0; j < h; j++)
                for (int i = 0; i < w; i++) {
                    double wt = g[j * w + i] / total;
                    const float *p = wg_image_row(src, (y + j) % h) + (size_t)((x + i) % w) * c;
                    for (int k = 0; k < c; k++) out[((size_t)y * w + x) * c + k] += wt * p[k];
                }
    free(g);
    return out;
}

static void compare(const WgImage *got, const double *want, double tol, const char *what)
{
    int c = got->channels;
    for (int y = 0; y < got->height; y++)
        for (int x = 0; x < got->width; x++)
            for (int k = 0; k < c; k++) {
                double r = want[((size_t)y * got->width + x) * c + k];
                double v = wgt_px(got, x, y, k);
                if (!(fabs(v - r) <= tol * (1 + fabs(r))))
                    fail_msg("%s (%d,%d,%d): %.9g, expected %.9g", what, x, y, k, v, r);
            }
}

static double pattern_fn(int x, int y, int k)
{
    return (wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k) & 0xffff) / 65535.0 +
           (x % 7 == 0 ? 0.5 : 0) - (y % 5 == 1 ? 0.25 : 0);
}

static void test_against_periodic_gaussian(void **state)
{
    (void)state;
    static const double sigmas[] = {0.3, 0.5, 1, 2.5, 4, 7, 11.5, 40};
    static const int shapes[][3] = {{24, 10, 1}, {13, 17, 4}, {16, 16, 1}, {1, 9, 1}, {30, 2, 4}};
    for (int s = 0; s < 5; s++) {
        WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], shapes[s][2], pattern_fn);
        for (int i = 0; i < 8; i++) {
            WgImage *out = blur(src, sigmas[i], 2);
            wgt_assert_same_shape(out, src);
            double *ref = reference(src, sigmas[i]);
            char what[64];
            snprintf(what, sizeof what, "%dx%dx%d sigma %g", src->width, src->height, src->channels,
                     sigmas[i]);
            compare(out, ref, 2e-6, what);
            free(ref);
            wg_image_unref(out);
        }
        wg_image_unref(src);
    }
}

static void test_sigma_zero_copies(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(11, 6, 4, pattern_fn);
    WgImage *out = blur(src, 0, 1);
    wgt_assert_identical(out, src);
    wg_image_unref(out);
    wg_image_unref(src);
}

static double image_mean(const WgImage *img, int k)
{
    double m = 0;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) m += wgt_px(img, x, y, k);
    return m / ((double)img->width * img->height);
}

static void test_sigma_beyond_the_image_is_the_mean(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(20, 12, 4, pattern_fn);
    static const double sigmas[] = {20, 25, 1000, 16384};
    for (int i = 0; i < 4; i++) {
        WgImage *out = blur(src, sigmas[i], 3);
        for (int k = 0; k < 4; k++) {
            double m = image_mean(src, k);
            for (int y = 0; y < 12; y++)
                for (int x = 0; x < 20; x++)
                    if (fabs(wgt_px(out, x, y, k) - m) > 1e-6)
                        fail_msg("sigma %g (%d,%d,%d): %.9g vs mean %.9g", sigmas[i], x, y, k,
                                 wgt_px(out, x, y, k), m);
        }
        wg_image_unref(out);
    }
    /* only one axis beyond its side: the mean along it, a Gaussian along the other */
    WgImage *out = blur(src, 15, 1);
    double *ref = reference(src, 15);
    compare(out, ref, 2e-6, "sigma 15 on 20x12");
    for (int x = 0; x < 20; x++) /* every column is constant */
        for (int y = 1; y < 12; y++)
            assert_float_equal(wgt_px(out, x, y, 0), wgt_px(out, x, 0, 0), 1e-6);
    free(ref);
    wg_image_unref(out);
    wg_image_unref(src);
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

static void test_tiling_rolls_commute(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(37, 22, 4, pattern_fn);
    static const double sigmas[] = {0.7, 3, 9, 30};
    static const int rolls[][2] = {{5, 0}, {0, 7}, {36, 21}, {11, 13}};
    for (int i = 0; i < 4; i++) {
        WgImage *ref = blur(src, sigmas[i], 2);
        for (int r = 0; r < 4; r++) {
            WgImage *rolled = roll(src, rolls[r][0], rolls[r][1]);
            WgImage *b = blur(rolled, sigmas[i], 2);
            WgImage *back = roll(b, 37 - rolls[r][0], 22 - rolls[r][1]);
            /* same taps in the same order: bit-identical (the mean of a whole row or column
             * sums in another order when sigma reaches the side) */
            if (sigmas[i] < 22)
                wgt_assert_identical(back, ref);
            else
                wgt_assert_near(back, ref, 1e-6);
            wg_image_unref(back);
            wg_image_unref(b);
            wg_image_unref(rolled);
        }
        wg_image_unref(ref);
    }
    wg_image_unref(src);
}

static void test_edges_wrap(void **state)
{
    (void)state;
    /* an impulse in the corner spreads to the other three corners */
    WgImage *src = wgt_image(16, 16, 1, NULL);
    wg_image_row(src, 0)[0] = 1;
    WgImage *out = blur(src, 1.5, 1);
    float v = wgt_px(out, 0, 0, 0);
    assert_true(v > 0);
    assert_float_equal(wgt_px(out, 15, 0, 0), wgt_px(out, 1, 0, 0), 1e-7);
    assert_float_equal(wgt_px(out, 0, 15, 0), wgt_px(out, 0, 1, 0), 1e-7);
    assert_float_equal(wgt_px(out, 15, 15, 0), wgt_px(out, 1, 1, 0), 1e-7);
    assert_float_equal(image_mean(out, 0) * 256, 1.0, 1e-6); /* mass is kept */
    double w1 = exp(-1 / (2 * 1.5 * 1.5));
    assert_float_equal(wgt_px(out, 1, 0, 0) / v, w1, 1e-6);
    wg_image_unref(out);
    wg_image_unref(src);
}

static void test_flat_and_extreme_inputs(void **state)
{
    (void)state;
    static const float values[] = {0.3f, 1.0f, -7.25f, 1e6f, 0.0f};
    static const double sigmas[] = {0.4, 2, 6.5, 13};
    for (int v = 0; v < 5; v++) {
        WgImage *flat = wgt_image(29, 13, 1, NULL);
        for (int y = 0; y < 13; y++)
            for (int x = 0; x < 29; x++) wg_image_row(flat, y)[x] = values[v];
        for (int s = 0; s < 4; s++) {
            WgImage *out = blur(flat, sigmas[s], 2);
            for (int y = 0; y < 13; y++)
                for (int x = 0; x < 29; x++)
                    if (wgt_px(out, x, y, 0) != values[v]) /* exact: double sums */
                        fail_msg("flat %g sigma %g: %.9g at (%d,%d)", values[v], sigmas[s],
                                 wgt_px(out, x, y, 0), x, y);
            wg_image_unref(out);
        }
        wg_image_unref(flat);
    }
    /* a 1e6 spike on a small background: the reference holds in relative terms */
    WgImage *spike = wgt_image_fn(15, 11, 1, pattern_fn);
    wg_image_row(spike, 4)[6] = 1e6f;
    WgImage *out = blur(spike, 1.8, 2);
    double *ref = reference(spike, 1.8);
    for (int y = 0; y < 11; y++)
        for (int x = 0; x < 15; x++) {
            double r = ref[y * 15 + x];
            if (fabs(wgt_px(out, x, y, 0) - r) > 1e-6 * 1e6 * 1e-3 + 2e-6 * fabs(r))
                fail_msg("spike (%d,%d): %.9g vs %.9g", x, y, wgt_px(out, x, y, 0), r);
        }
    free(ref);
    wg_image_unref(out);
    wg_image_unref(spike);
}

static void test_errors(void **state)
{
    (void)state;
    WgImage *g = wgt_image(4, 4, 1, NULL);
    const char *names[] = {"source"};
    const WgImage *imgs[] = {g};
    WgError err;
    assert_int_equal(wgt_node_error("blur", "sigma=\"-1\"", 4, 4, 1, names, imgs, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "sigma"));
    assert_int_equal(err.line, 3);
    assert_int_equal(wgt_node_error("blur", "sigma=\"20000\"", 4, 4, 1, names, imgs, &err),
                     WG_ERR_RANGE);
    assert_int_not_equal(wgt_node_error("blur", "sigma=\"wide\"", 4, 4, 1, names, imgs, &err),
                         WG_OK);
    assert_int_not_equal(wgt_node_error("blur", "", 4, 4, 0, names, imgs, &err), WG_OK);
    wg_image_unref(g);
}

static void test_default_sigma_is_one(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(12, 9, 1, pattern_fn);
    const char *names[] = {"source"};
    const WgImage *imgs[] = {src};
    WgImage *a = wgt_node("blur", "", 12, 9, 1, names, imgs, 0, 1);
    WgImage *b = blur(src, 1, 1);
    wgt_assert_identical(a, b);
    wg_image_unref(b);
    wg_image_unref(a);
    wg_image_unref(src);
}

static void test_thread_invariance(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(45, 150, 4, pattern_fn);
    static const double sigmas[] = {0.6, 5, 80, 200};
    for (int s = 0; s < 4; s++) {
        WgImage *a = blur(src, sigmas[s], 1);
        WgImage *b = blur(src, sigmas[s], 2);
        WgImage *c = blur(src, sigmas[s], 8);
        wgt_assert_identical(a, b);
        wgt_assert_identical(a, c);
        wg_image_unref(c);
        wg_image_unref(b);
        wg_image_unref(a);
    }
    wg_image_unref(src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_periodic_gaussian),
        cmocka_unit_test(test_sigma_zero_copies),
        cmocka_unit_test(test_sigma_beyond_the_image_is_the_mean),
        cmocka_unit_test(test_tiling_rolls_commute),
        cmocka_unit_test(test_edges_wrap),
        cmocka_unit_test(test_flat_and_extreme_inputs),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_default_sigma_is_one),
        cmocka_unit_test(test_thread_invariance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
