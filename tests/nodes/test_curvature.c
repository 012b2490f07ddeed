/* SPDX-License-Identifier: MIT */
/* `curvature` against a float64 reference of the periodic 5-point Laplacian (within one float
 * rounding), flat input exactly 0.5, a paraboloid's constant curvature away from the seams, a
 * sine wave's discrete Laplacian in closed form and its continuous one within the discretisation
 * error, tiling, thread-count invariance, resolution independence (64² and 256² of one wave),
 * extreme and non-finite inputs, 1×N, N×1 and 1×1 images, and parameter errors. */
#include "heighttest.h"

static WgImage *curvature(const WgImage *src, double intensity, int threads)
{
    char attrs[64];
    snprintf(attrs, sizeof attrs, "intensity=\"%.9g\"", intensity);
    return ht_run("curvature", attrs, src, threads);
}

/* 0.5 − intensity · (W/256)² · Δh, clamped, in double. */
static double reference(const WgImage *img, double intensity, int x, int y)
{
    double s = img->width / 256.0;
    double lap = ht_h(img, x + 1, y) + ht_h(img, x - 1, y) + ht_h(img, x, y + 1) +
                 ht_h(img, x, y - 1) - 4 * ht_h(img, x, y);
    double v = 0.5 - intensity * s * s * lap;
    return v < 0 ? 0 : v > 1 ? 1 : v;
}

#define ROUNDING 2.9802322387695312e-08 /* 2^-25: one rounding of a value in [0, 1] */

static void test_against_float64_reference(void **state)
{
    (void)state;
    static const int shapes[][2] = {{24, 10}, {13, 17}, {1, 9}, {9, 1}, {1, 1}, {2, 3}};
    static const double intensities[] = {0, 0.5, 16, 300, 1e6};
    for (int s = 0; s < 6; s++) {
        WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], 1, ht_pattern_fn);
        for (int i = 0; i < 5; i++) {
            WgImage *out = curvature(src, intensities[i], 2);
            for (int y = 0; y < src->height; y++)
                for (int x = 0; x < src->width; x++) {
                    double want = reference(src, intensities[i], x, y);
                    if (!(fabs(wgt_px(out, x, y, 0) - want) <= ROUNDING * (1 + 1e-9)))
                        fail_msg("%dx%d intensity %g (%d,%d): %.10g, expected %.10g", src->width,
                                 src->height, intensities[i], x, y, wgt_px(out, x, y, 0), want);
                }
            wg_image_unref(out);
        }
        wg_image_unref(src);
    }
}

static void test_flat_is_exactly_half(void **state)
{
    (void)state;
    static const float values[] = {0.0f, 0.3f, -7.25f, 1e6f, 3.4e38f, -3.4e38f};
    for (int v = 0; v < 6; v++) {
        WgImage *src = ht_const(7, 5, values[v]);
        WgImage *out = curvature(src, 1e6, 2);
        for (int y = 0; y < 5; y++)
            for (int x = 0; x < 7; x++)
                if (wgt_px(out, x, y, 0) != 0.5f)
                    fail_msg("flat %g: %g", values[v], wgt_px(out, x, y, 0));
        wg_image_unref(out);
        wg_image_unref(src);
    }
}

/* h = c·((x − cx)² + (y − cy)²): the 5-point Laplacian of a quadratic is exact, 4c per pixel²,
 * so away from the seams curvature is 0.5 − intensity·(W/256)²·4c everywhere: a bowl is
 * concave (below 0.5), a dome convex. */
static double para_c = 1.0 / 4096;
static double para_fn(int x, int y, int k)
{
    (void)k;
    return para_c * ((x - 20.5) * (x - 20.5) + (y - 27.0) * (y - 27.0));
}

static void test_paraboloid_constant(void **state)
{
    (void)state;
    int w = 48, h = 64;
    for (int sign = -1; sign <= 1; sign += 2) {
        para_c = sign / 4096.0;
        WgImage *src = wgt_image_fn(w, h, 1, para_fn);
        double intensity = 10000, s = w / 256.0;
        double want = 0.5 - intensity * s * s * 4 * para_c;
        WgImage *out = curvature(src, intensity, 3);
        for (int y = 1; y < h - 1; y++)
            for (int x = 1; x < w - 1; x++)
                if (!(fabs(wgt_px(out, x, y, 0) - want) <= 2e-6))
                    fail_msg("paraboloid (%d,%d): %.9g, expected %.9g", x, y, wgt_px(out, x, y, 0),
                             want);
        assert_true(sign > 0 ? want < 0.45 : want > 0.55);
        wg_image_unref(out);
        wg_image_unref(src);
    }
    para_c = 1.0 / 4096;
}

/* h = 0.5 + A sin(kx·x + ky·y + φ): the discrete Laplacian is exactly
 * (2cos kx − 2 + 2cos ky − 2)·(h − 0.5), the continuous one −(kx² + ky²)(h − 0.5); the only error
 * left against the first is the float storage of the heights. */
static void test_wave_analytic(void **state)
{
    (void)state;
    int w = 128;
    double intensity = 200, s = w / 256.0;
    WgImage *src = ht_wave(w, w, 0.25, 1, 2);
    WgImage *out = curvature(src, intensity, 2);
    double kx = 2 * M_PI * 1 / w, ky = 2 * M_PI * 2 / w;
    double worst_cont = 0, spread = 0;
    for (int y = 0; y < w; y++)
        for (int x = 0; x < w; x++) {
            double phi = 2 * M_PI * ((double)x / w + 2.0 * y / w) + 0.3;
            double a = 0.25 * sin(phi);
            double discrete = 0.5 - intensity * s * s * (2 * cos(kx) + 2 * cos(ky) - 4) * a;
            double cont = 0.5 + intensity * s * s * (kx * kx + ky * ky) * a;
            double got = wgt_px(out, x, y, 0);
            /* storage: 5 heights of 2^-25 relative error times intensity·s²·(≤4) */
            if (!(fabs(got - discrete) <= 1e-5))
                fail_msg("wave (%d,%d): %.9g, expected %.9g", x, y, got, discrete);
            worst_cont = fmax(worst_cont, fabs(got - cont));
            spread = fmax(spread, fabs(got - 0.5));
        }
    /* discretisation: up to (kΔ)²/12 = 8e-4 relative (kΔ = 2π·2/128) of an amplitude of 0.15 */
    assert_true(worst_cont <= 2e-4);
    assert_true(worst_cont > 1e-6); /* the discrete and continuous forms do differ */
    assert_true(spread > 0.1);      /* the curvature does vary */
    wg_image_unref(out);
    wg_image_unref(src);
}

static void test_extreme_inputs(void **state)
{
    (void)state;
    WgImage *checker = wgt_image(6, 6, 1, NULL);
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 6; x++) wg_image_row(checker, y)[x] = (x + y) % 2 ? 3.4e38f : -3.4e38f;
    WgImage *out = curvature(checker, 1e6, 2);
    wgt_assert_range(out, 0, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.0f); /* a pit among peaks: concave */
    assert_true(wgt_px(out, 1, 0, 0) == 1.0f); /* a peak among pits: convex */
    wg_image_unref(out);
    wg_image_unref(checker);
    WgImage *bad = wgt_image_fn(8, 6, 1, ht_pattern_fn);
    wg_image_row(bad, 2)[3] = INFINITY;
    wg_image_row(bad, 4)[5] = NAN;
    out = curvature(bad, 5, 2);
    wgt_assert_range(out, 0, 1);
    assert_true(wgt_px(out, 3, 2, 0) == 1.0f); /* an infinite peak: convex */
    assert_true(wgt_px(out, 2, 2, 0) == 0.0f); /* beside it: concave */
    assert_true(wgt_px(out, 5, 4, 0) == 0.5f); /* NaN: flat */
    WgImage *ref = curvature(bad, 5, 1);
    wgt_assert_identical(out, ref);
    wg_image_unref(ref);
    wg_image_unref(out);
    wg_image_unref(bad);
}

static void test_tiling_rolls_commute(void **state)
{
    (void)state;
    ht_assert_tiles("curvature", "intensity=\"9\"");
}

static void test_thread_invariance(void **state)
{
    (void)state;
    ht_assert_thread_invariant("curvature", "intensity=\"3\"");
}

/* One wave at 64² and 256²: pixel (x, y) of the small render and (4x, 4y) of the large one are
 * the same texture point, so the curvatures agree up to the coarse render's discretisation
 * ((kΔ)²/12 relative). A Laplacian per pixel² would differ by 16×. */
static void test_resolution_independence(void **state)
{
    (void)state;
    WgImage *small = ht_wave(64, 64, 0.25, 1, 1);
    WgImage *large = ht_wave(256, 256, 0.25, 1, 1);
    WgImage *a = curvature(small, 1000, 2);
    WgImage *b = curvature(large, 1000, 2);
    double worst = 0, spread = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            worst = fmax(worst, fabs(wgt_px(a, x, y, 0) - wgt_px(b, 4 * x, 4 * y, 0)));
            spread = fmax(spread, fabs(wgt_px(a, x, y, 0) - 0.5));
        }
    assert_true(worst <= 1e-3);
    assert_true(spread > 0.1);
    wg_image_unref(b);
    wg_image_unref(a);
    wg_image_unref(large);
    wg_image_unref(small);
}

/* Thin images: along a side of 1 pixel both neighbours are the pixel itself, so that axis
 * contributes 0. */
static void test_thin_images(void **state)
{
    (void)state;
    static const float col[] = {0, 1, 4, 2, 2};
    WgImage *tall = wgt_image(1, 5, 1, col);
    WgImage *wide = wgt_image(5, 1, 1, col);
    WgImage *one = ht_const(1, 1, 0.7f);
    WgImage *t = curvature(tall, 0.01 * 256 * 256, 2); /* s = 1/256: scale 0.01 */
    WgImage *w = curvature(wide, 0.01 * 256 * 256 / 25, 2);
    WgImage *o = curvature(one, 1e6, 2);
    for (int i = 0; i < 5; i++) {
        double lap = col[(i + 1) % 5] + col[(i + 4) % 5] - 2.0 * col[i];
        double want = fmin(1, fmax(0, 0.5 - 0.01 * lap));
        assert_float_equal(wgt_px(t, 0, i, 0), want, 1e-7);
        assert_float_equal(wgt_px(w, i, 0, 0), want, 1e-7);
    }
    assert_true(wgt_px(o, 0, 0, 0) == 0.5f);
    wg_image_unref(o);
    wg_image_unref(w);
    wg_image_unref(t);
    wg_image_unref(one);
    wg_image_unref(wide);
    wg_image_unref(tall);
}

static void test_defaults_and_errors(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(12, 9, 1, ht_pattern_fn);
    WgImage *a = ht_run("curvature", "", src, 1);
    WgImage *b = curvature(src, 16, 1);
    wgt_assert_identical(a, b);
    wg_image_unref(b);
    wg_image_unref(a);
    const char *names[] = {"height"};
    const WgImage *gray[] = {src};
    WgError err;
    assert_int_equal(wgt_node_error("curvature", "intensity=\"-1\"", 4, 4, 1, names, gray, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "intensity"));
    WgImage *c = wgt_image(4, 4, 4, NULL);
    const WgImage *color[] = {c};
    assert_int_not_equal(wgt_node_error("curvature", "", 4, 4, 1, names, color, &err), WG_OK);
    wg_image_unref(c);
    wg_image_unref(src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_float64_reference),
        cmocka_unit_test(test_flat_is_exactly_half),
        cmocka_unit_test(test_paraboloid_constant),
        cmocka_unit_test(test_wave_analytic),
        cmocka_unit_test(test_extreme_inputs),
        cmocka_unit_test(test_tiling_rolls_commute),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_resolution_independence),
        cmocka_unit_test(test_thin_images),
        cmocka_unit_test(test_defaults_and_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
