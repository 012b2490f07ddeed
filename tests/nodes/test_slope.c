/* SPDX-License-Identifier: MIT */
/* `slope` (atan|g| / (π/2)) against a float64 reference of the same periodic finite
 * differences (within 2^-25, the rounding to float), against exact analytic gradients (a
 * periodic sine wave and a paraboloid away from the seams), flat input exactly 0, a 45° ramp
 * 0.5, monotonic in the intensity, Sobel close to central on smooth input, extreme inputs
 * (finite, within [0, 1], vertical steps at 1), agreement with `normal` (the angle of its
 * decoded n.z), tiling, thread-count invariance, resolution independence (64² and 256² of one
 * wave), 1×N, N×1 and 1×1 images, and parameter errors. */
#include "heighttest.h"

static WgImage *slope(const WgImage *src, double intensity, const char *method, int threads)
{
    char attrs[128];
    snprintf(attrs, sizeof attrs, "intensity=\"%.9g\" method=\"%s\"", intensity, method);
    return ht_run("slope", attrs, src, threads);
}

static double slope_of(double gx, double gy)
{
    return atan(sqrt(gx * gx + gy * gy)) / (M_PI / 2);
}

#define ROUNDING 2.9802322387695312e-08 /* 2^-25 */

static void test_against_float64_reference(void **state)
{
    (void)state;
    static const int shapes[][2] = {{24, 10}, {13, 17}, {1, 9}, {9, 1}, {1, 1}, {2, 3}};
    static const double intensities[] = {0, 0.5, 1, 7.5, 300, 1e6};
    for (int s = 0; s < 6; s++) {
        WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], 1, ht_pattern_fn);
        for (int i = 0; i < 6; i++)
            for (int sobel = 0; sobel < 2; sobel++) {
                WgImage *out = slope(src, intensities[i], sobel ? "sobel" : "central", 2);
                assert_int_equal(out->channels, 1);
                for (int y = 0; y < src->height; y++)
                    for (int x = 0; x < src->width; x++) {
                        double gx, gy;
                        ht_gradient(src, intensities[i], sobel, x, y, &gx, &gy);
                        double want = slope_of(gx, gy), got = wgt_px(out, x, y, 0);
                        if (!(fabs(got - want) <= ROUNDING * (1 + 1e-6)) || got > 1 || got < 0)
                            fail_msg("%dx%d intensity %g (%d,%d): %.10g, expected %.10g",
                                     src->width, src->height, intensities[i], x, y, got, want);
                    }
                wg_image_unref(out);
            }
        wg_image_unref(src);
    }
}

static void test_flat_is_zero(void **state)
{
    (void)state;
    static const float values[] = {0.0f, 0.3f, -7.25f, 1e6f, 3e38f};
    for (int v = 0; v < 5; v++)
        for (int sobel = 0; sobel < 2; sobel++) {
            WgImage *src = ht_const(9, 6, values[v]);
            WgImage *out = slope(src, 1e6, sobel ? "sobel" : "central", 2);
            for (int y = 0; y < 6; y++)
                for (int x = 0; x < 9; x++)
                    if (wgt_px(out, x, y, 0) != 0.0f) fail_msg("flat %g: not 0", values[v]);
            wg_image_unref(out);
            wg_image_unref(src);
        }
}

/* The wave's central differences are the derivative times sin(kΔ)/(kΔ) per axis (Sobel also
 * (1 + cos k'Δ)/2 of the other axis): closed forms up to the float storage of the heights. */
static void test_wave_analytic(void **state)
{
    (void)state;
    int w = 128;
    double intensity = 80;
    WgImage *src = ht_wave(w, w, 0.25, 1, 2);
    for (int sobel = 0; sobel < 2; sobel++) {
        WgImage *out = slope(src, intensity, sobel ? "sobel" : "central", 2);
        double kx = 2 * M_PI / w, ky = 2 * M_PI * 2 / w;
        double fx = sin(kx) / kx, fy = sin(ky) / ky;
        if (sobel) fx *= (1 + cos(ky)) / 2, fy *= (1 + cos(kx)) / 2;
        double worst_raw = 0;
        for (int y = 0; y < w; y++)
            for (int x = 0; x < w; x++) {
                double gx, gy;
                ht_wave_gradient(w, intensity, x, y, &gx, &gy);
                double want = slope_of(gx * fx, gy * fy), got = wgt_px(out, x, y, 0);
                if (!(fabs(got - want) <= 2e-6))
                    fail_msg("wave (%d,%d): %.9g, expected %.9g", x, y, got, want);
                worst_raw = fmax(worst_raw, fabs(got - slope_of(gx, gy)));
            }
        /* against the true derivative: (kΔ)²/6 relative on |g| (Sobel: + (kΔ)²/4), and
         * d slope / d|g| = (2/π)/(1 + |g|²) ≤ 0.64 */
        assert_true(worst_raw <= (sobel ? 4e-3 : 1.5e-3));
        assert_true(worst_raw > 1e-5);
        wg_image_unref(out);
    }
    wg_image_unref(src);
}

static double para_fn(int x, int y, int k)
{
    (void)k;
    return ((x - 20.5) * (x - 20.5) + (y - 27.0) * (y - 27.0)) / 2048;
}

static void test_paraboloid_analytic(void **state)
{
    (void)state;
    int w = 48, h = 64;
    WgImage *src = wgt_image_fn(w, h, 1, para_fn);
    double intensity = 30, s = intensity * w / 256.0;
    for (int sobel = 0; sobel < 2; sobel++) {
        WgImage *out = slope(src, intensity, sobel ? "sobel" : "central", 3);
        for (int y = 2; y < h - 2; y++)
            for (int x = 2; x < w - 2; x++) {
                double want = slope_of(s * 2 * (x - 20.5) / 2048, s * 2 * (y - 27.0) / 2048);
                if (!(fabs(wgt_px(out, x, y, 0) - want) <= 1e-6))
                    fail_msg("paraboloid (%d,%d): %.9g, expected %.9g", x, y, wgt_px(out, x, y, 0),
                             want);
            }
        wg_image_unref(out);
    }
    wg_image_unref(src);
}

/* A ramp of one height unit per length unit is 45°: slope 0.5 (away from the wrap seam). */
static double ramp_fn(int x, int y, int k)
{
    (void)y, (void)k;
    return 4.0 * x; /* 64 wide: a length unit is 1/4 pixel, so 4 per pixel is 1 per unit */
}

static void test_ramp_is_45_degrees(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(64, 8, 1, ramp_fn);
    WgImage *out = slope(src, 1, "central", 2);
    for (int y = 0; y < 8; y++)
        for (int x = 1; x < 63; x++) assert_float_equal(wgt_px(out, x, y, 0), 0.5, 3e-8);
    assert_true(wgt_px(out, 0, 0, 0) > 0.9f); /* the seam is a cliff */
    wg_image_unref(out);
    wg_image_unref(src);
}

/* Non-decreasing in the gradient magnitude: a larger intensity never lowers the slope, and the
 * order of pixels by |g| is the order of their slopes. */
static void test_monotonic(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(23, 17, 1, ht_pattern_fn);
    WgImage *prev = NULL;
    double last = 0;
    for (double intensity = 0.01; intensity < 2e5; intensity *= 3) {
        last = intensity;
        WgImage *out = slope(src, intensity, "sobel", 2);
        if (prev)
            for (int y = 0; y < 17; y++)
                for (int x = 0; x < 23; x++)
                    if (wgt_px(out, x, y, 0) < wgt_px(prev, x, y, 0))
                        fail_msg("intensity %g lowers the slope at (%d,%d)", intensity, x, y);
        wg_image_unref(prev);
        prev = out;
    }
    for (int y = 0; y < 17; y++)
        for (int x = 0; x < 23; x++)
            for (int v = 0; v < 17; v++)
                for (int u = 0; u < 23; u++) {
                    double a, b, c, d;
                    ht_gradient(src, (float)last, 1, x, y, &a, &b);
                    ht_gradient(src, (float)last, 1, u, v, &c, &d);
                    if (a * a + b * b < c * c + d * d &&
                        wgt_px(prev, x, y, 0) > wgt_px(prev, u, v, 0))
                        fail_msg("(%d,%d) is less steep than (%d,%d) but has a higher slope", x, y,
                                 u, v);
                }
    wg_image_unref(prev);
    wg_image_unref(src);
}

static void test_extreme_inputs(void **state)
{
    (void)state;
    WgImage *step = wgt_image(16, 12, 1, NULL);
    for (int y = 0; y < 12; y++)
        for (int x = 8; x < 16; x++) wg_image_row(step, y)[x] = 1e6f;
    WgImage *out = slope(step, 1e6, "central", 2);
    wgt_assert_range(out, 0, 1);
    assert_true(wgt_px(out, 7, 3, 0) == 1.0f && wgt_px(out, 0, 3, 0) == 1.0f);
    assert_true(wgt_px(out, 3, 3, 0) == 0.0f);
    wg_image_unref(out);
    wg_image_unref(step);
    WgImage *checker = wgt_image(6, 6, 1, NULL);
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 6; x++) wg_image_row(checker, y)[x] = (x + y) % 2 ? 3.4e38f : -3.4e38f;
    wg_image_row(checker, 1)[4] = 0;
    for (int sobel = 0; sobel < 2; sobel++) {
        out = slope(checker, 1e6, sobel ? "sobel" : "central", 1);
        wgt_assert_range(out, 0, 1);
        wg_image_unref(out);
    }
    wg_image_unref(checker);
    /* non-finite heights: an infinite difference is vertical, a NaN one flat */
    WgImage *bad = wgt_image_fn(8, 6, 1, ht_pattern_fn);
    wg_image_row(bad, 2)[3] = INFINITY;
    wg_image_row(bad, 4)[5] = NAN;
    out = slope(bad, 5, "sobel", 2);
    wgt_assert_range(out, 0, 1);
    assert_true(wgt_px(out, 2, 2, 0) == 1.0f && wgt_px(out, 3, 3, 0) == 1.0f);
    wg_image_unref(out);
    out = slope(bad, 5, "central", 2);
    double gx, gy;
    ht_gradient(bad, 5, 0, 4, 4, &gx, &gy); /* gx is NaN: counted as 0 */
    assert_float_equal(wgt_px(out, 4, 4, 0), slope_of(0, gy), 3e-8);
    wg_image_unref(out);
    wg_image_unref(bad);
}

/* The slope is the angle of the normal from straight up: acos(n.z) / (π/2), n.z decoded from
 * `normal` (loose: acos is ill-conditioned near n.z = 1, so compared where the angle is
 * over 10°, with the 2^-24 error of the encoded n.z magnified by 1/sin). */
static void test_agrees_with_normal(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(40, 30, 1, ht_pattern_fn);
    WgImage *s = slope(src, 40, "central", 2);
    WgImage *n = ht_run("normal", "intensity=\"40\"", src, 2);
    int compared = 0;
    for (int y = 0; y < 30; y++)
        for (int x = 0; x < 40; x++) {
            double nz = 2.0 * wgt_px(n, x, y, 2) - 1;
            double angle = acos(nz) / (M_PI / 2);
            if (angle < 1.0 / 9) continue;
            compared++;
            assert_float_equal(wgt_px(s, x, y, 0), angle, 1e-6);
        }
    assert_true(compared > 100);
    wg_image_unref(n);
    wg_image_unref(s);
    wg_image_unref(src);
}

static void test_sobel_close_to_central(void **state)
{
    (void)state;
    WgImage *src = ht_wave(128, 128, 0.25, 1, 2);
    WgImage *c = slope(src, 80, "central", 2);
    WgImage *s = slope(src, 80, "sobel", 2);
    double d = wgt_max_abs_diff(c, s);
    assert_true(d < 2e-3 && d > 1e-6);
    wg_image_unref(s);
    wg_image_unref(c);
    wg_image_unref(src);
}

static void test_tiling_rolls_commute(void **state)
{
    (void)state;
    ht_assert_tiles("slope", "intensity=\"9\"");
    ht_assert_tiles("slope", "intensity=\"9\" method=\"sobel\"");
}

static void test_thread_invariance(void **state)
{
    (void)state;
    ht_assert_thread_invariant("slope", "intensity=\"3\"");
    ht_assert_thread_invariant("slope", "intensity=\"3\" method=\"sobel\"");
}

/* 64² and 256² renders of one wave agree at corresponding points (x, y) and (4x, 4y) up to the
 * coarse render's discretisation error; a per-pixel gradient would differ by 4×. */
static void test_resolution_independence(void **state)
{
    (void)state;
    WgImage *small = ht_wave(64, 64, 0.25, 1, 1);
    WgImage *large = ht_wave(256, 256, 0.25, 1, 1);
    for (int sobel = 0; sobel < 2; sobel++) {
        const char *m = sobel ? "sobel" : "central";
        WgImage *a = slope(small, 110, m, 2);
        WgImage *b = slope(large, 110, m, 2);
        double worst = 0, steepest = 0;
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 64; x++) {
                worst = fmax(worst, fabs(wgt_px(a, x, y, 0) - wgt_px(b, 4 * x, 4 * y, 0)));
                steepest = fmax(steepest, wgt_px(a, x, y, 0));
            }
        assert_true(worst <= (sobel ? 4e-3 : 2e-3));
        assert_true(steepest > 0.3);
        wg_image_unref(b);
        wg_image_unref(a);
    }
    wg_image_unref(large);
    wg_image_unref(small);
}

static void test_thin_images(void **state)
{
    (void)state;
    static const float col[] = {0, 1, 4, 2, 2};
    WgImage *tall = wgt_image(1, 5, 1, col);
    WgImage *wide = wgt_image(5, 1, 1, col);
    WgImage *one = ht_const(1, 1, 0.7f);
    WgImage *t = slope(tall, 256, "central", 2);
    WgImage *w = slope(wide, 256, "sobel", 2);
    WgImage *o = slope(one, 1e6, "central", 2);
    for (int i = 0; i < 5; i++) {
        double d = (col[(i + 1) % 5] - col[(i + 4) % 5]) / 2.0;
        assert_float_equal(wgt_px(t, 0, i, 0), slope_of(0, d), 3e-8);
        /* one row: Sobel's 1-2-1 weights all land on the row itself */
        assert_float_equal(wgt_px(w, i, 0, 0), slope_of(5 * d, 0), 3e-8);
    }
    assert_true(wgt_px(o, 0, 0, 0) == 0.0f);
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
    WgImage *a = ht_run("slope", "", src, 1);
    WgImage *b = slope(src, 1, "central", 1);
    wgt_assert_identical(a, b);
    wg_image_unref(b);
    wg_image_unref(a);
    const char *names[] = {"height"};
    const WgImage *gray[] = {src};
    WgError err;
    assert_int_equal(wgt_node_error("slope", "intensity=\"-0.5\"", 4, 4, 1, names, gray, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "intensity"));
    assert_int_not_equal(wgt_node_error("slope", "method=\"x\"", 4, 4, 1, names, gray, &err),
                         WG_OK);
    assert_int_not_equal(wgt_node_error("slope", "format=\"opengl\"", 4, 4, 1, names, gray, &err),
                         WG_OK);
    wg_image_unref(src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_float64_reference),
        cmocka_unit_test(test_flat_is_zero),
        cmocka_unit_test(test_wave_analytic),
        cmocka_unit_test(test_paraboloid_analytic),
        cmocka_unit_test(test_ramp_is_45_degrees),
        cmocka_unit_test(test_monotonic),
        cmocka_unit_test(test_extreme_inputs),
        cmocka_unit_test(test_agrees_with_normal),
        cmocka_unit_test(test_sobel_close_to_central),
        cmocka_unit_test(test_tiling_rolls_commute),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_resolution_independence),
        cmocka_unit_test(test_thin_images),
        cmocka_unit_test(test_defaults_and_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
