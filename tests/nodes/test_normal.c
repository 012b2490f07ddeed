/* SPDX-License-Identifier: MIT */
/* `normal` against a float64 reference of the same periodic finite differences (each channel
 * within 2^-25, the one rounding to float), against exact analytic gradients (a periodic sine
 * wave, whose central and Sobel differences are known in closed form, and a paraboloid, whose
 * central differences are exact, checked away from the seams), the flat case exactly, DirectX as
 * OpenGL with green flipped exactly, Sobel close to central on smooth input, extreme inputs
 * (finite, unit length), tiling, thread-count invariance, resolution independence (64² and 256²
 * of one wave agree at corresponding points), 1×N, N×1 and 1×1 images, and parameter errors. */
#include "heighttest.h"

static WgImage *normal(const WgImage *src, double intensity, const char *format, const char *method,
                       int threads)
{
    char attrs[128];
    snprintf(attrs, sizeof attrs, "intensity=\"%.9g\" format=\"%s\" method=\"%s\"", intensity,
             format, method);
    return ht_run("normal", attrs, src, threads);
}

/* Each encoded channel is within this of the exact encoding of the exact difference. */
#define ROUNDING 2.9802322387695312e-08 /* 2^-25 */

static void assert_unit_and_opaque(const WgImage *out)
{
    for (int y = 0; y < out->height; y++)
        for (int x = 0; x < out->width; x++) {
            double n[3];
            ht_decode(out, x, y, n);
            double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (!(fabs(len - 1) <= 1.1e-7)) fail_msg("|n| at (%d,%d) is %.12g", x, y, len);
            if (wgt_px(out, x, y, 3) != 1.0f) fail_msg("alpha at (%d,%d)", x, y);
            for (int k = 0; k < 3; k++)
                if (!(wgt_px(out, x, y, k) >= 0 && wgt_px(out, x, y, k) <= 1))
                    fail_msg("channel %d at (%d,%d) is %g", k, x, y, wgt_px(out, x, y, k));
        }
}

static void assert_matches_reference(const WgImage *src, double intensity, int sobel,
                                     const char *what)
{
    WgImage *out = normal(src, intensity, "opengl", sobel ? "sobel" : "central", 2);
    assert_int_equal(out->channels, 4);
    assert_int_equal(out->width, src->width);
    assert_int_equal(out->height, src->height);
    for (int y = 0; y < src->height; y++)
        for (int x = 0; x < src->width; x++) {
            double gx, gy, n[3];
            ht_gradient(src, intensity, sobel, x, y, &gx, &gy);
            ht_normal(gx, gy, n);
            for (int k = 0; k < 3; k++) {
                double want = n[k] * 0.5 + 0.5, got = wgt_px(out, x, y, k);
                if (!(fabs(got - want) <= ROUNDING * (1 + 1e-9)))
                    fail_msg("%s %dx%d intensity %g %s (%d,%d,%d): %.10g, expected %.10g", what,
                             src->width, src->height, intensity, sobel ? "sobel" : "central", x, y,
                             k, got, want);
            }
        }
    assert_unit_and_opaque(out);
    wg_image_unref(out);
}

static void test_against_float64_reference(void **state)
{
    (void)state;
    static const int shapes[][2] = {{24, 10}, {13, 17}, {16, 16}, {1, 9}, {9, 1}, {1, 1}, {2, 3}};
    static const double intensities[] = {0, 0.5, 1, 7.5, 300, 1e6};
    for (int s = 0; s < 7; s++) {
        WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], 1, ht_pattern_fn);
        for (int i = 0; i < 6; i++)
            for (int sobel = 0; sobel < 2; sobel++)
                assert_matches_reference(src, intensities[i], sobel, "pattern");
        wg_image_unref(src);
    }
}

static void test_flat_is_exactly_up(void **state)
{
    (void)state;
    static const float values[] = {0.0f, 0.3f, 1.0f, -7.25f, 1e6f, 3e38f};
    static const double intensities[] = {0, 1, 64, 1e6};
    static const char *const formats[] = {"opengl", "directx"};
    static const char *const methods[] = {"central", "sobel"};
    for (int v = 0; v < 6; v++)
        for (int i = 0; i < 4; i++)
            for (int f = 0; f < 4; f++) {
                WgImage *src = ht_const(7 + f, 5, values[v]);
                WgImage *out = normal(src, intensities[i], formats[f % 2], methods[f / 2], 2);
                for (int y = 0; y < 5; y++)
                    for (int x = 0; x < 7 + f; x++) {
                        const float *p = wg_image_row(out, y) + x * 4;
                        if (p[0] != 0.5f || p[1] != 0.5f || p[2] != 1.0f || p[3] != 1.0f)
                            fail_msg("flat %g: (%g, %g, %g, %g)", values[v], p[0], p[1], p[2],
                                     p[3]);
                    }
                wg_image_unref(out);
                wg_image_unref(src);
            }
}

/* On the wave the central difference is the derivative times sin(kΔ)/(kΔ), kΔ = 2πa/W per
 * axis, and Sobel also multiplies by (1 + cos(k'Δ))/2 of the other axis: closed forms, so the
 * only error left is the float storage of the heights (amp·2^-24 per pixel, times the scale). */
static void test_wave_analytic(void **state)
{
    (void)state;
    int w = 128;
    double intensity = 80; /* |g| up to about 1: normals well away from vertical */
    WgImage *src = ht_wave(w, w, 0.25, 1, 2);
    for (int sobel = 0; sobel < 2; sobel++) {
        WgImage *out = normal(src, intensity, "opengl", sobel ? "sobel" : "central", 2);
        double kx = 2 * M_PI * 1 / w, ky = 2 * M_PI * 2 / w;
        double fx = sin(kx) / kx, fy = sin(ky) / ky;
        if (sobel) fx *= (1 + cos(ky)) / 2, fy *= (1 + cos(kx)) / 2;
        double worst_raw = 0;
        for (int y = 0; y < w; y++)
            for (int x = 0; x < w; x++) {
                double gx, gy, n[3], raw[3], got[3];
                ht_wave_gradient(w, intensity, x, y, &gx, &gy);
                ht_normal(gx * fx, gy * fy, n);
                ht_normal(gx, gy, raw);
                ht_decode(out, x, y, got);
                for (int k = 0; k < 3; k++) {
                    /* height storage: 0.5·2^-24 per value, through 2 values · scale/2 */
                    if (!(fabs(got[k] - n[k]) <= 2e-6))
                        fail_msg("wave %s (%d,%d,%d): %.9g, expected %.9g",
                                 sobel ? "sobel" : "central", x, y, k, got[k], n[k]);
                    worst_raw = fmax(worst_raw, fabs(got[k] - raw[k]));
                }
            }
        /* against the true derivative: the discretisation error, 1 − sin(kΔ)/kΔ ≈ (kΔ)²/6 =
         * 1.6e-3 relative for central (plus (kΔ)²/4 for Sobel's smoothing), on |g| ≤ 1.1 */
        assert_true(worst_raw <= (sobel ? 6e-3 : 2.5e-3));
        assert_true(worst_raw > 1e-5); /* the check above is not vacuous */
        wg_image_unref(out);
    }
    wg_image_unref(src);
}

/* h = c·((x − cx)² + (y − cy)²): central differences of a quadratic are exact, 2c(x − cx), and
 * Sobel's smoothing across the other axis leaves it exact too; checked away from the seams,
 * where the periodic extension jumps. The x and y signs pin the orientation: height rising to
 * the right tilts the normal left (red < 0.5); rising downwards tilts it up (OpenGL green >
 * 0.5). */
static double para_c = 1.0 / 2048;
static double para_fn(int x, int y, int k)
{
    (void)k;
    return para_c * ((x - 20.5) * (x - 20.5) + (y - 27.0) * (y - 27.0));
}

static void test_paraboloid_analytic(void **state)
{
    (void)state;
    int w = 48, h = 64;
    WgImage *src = wgt_image_fn(w, h, 1, para_fn);
    double intensity = 30, s = intensity * w / 256.0;
    for (int sobel = 0; sobel < 2; sobel++) {
        WgImage *out = normal(src, intensity, "opengl", sobel ? "sobel" : "central", 3);
        for (int y = 2; y < h - 2; y++)
            for (int x = 2; x < w - 2; x++) {
                double n[3], got[3];
                ht_normal(s * 2 * para_c * (x - 20.5), s * 2 * para_c * (y - 27.0), n);
                ht_decode(out, x, y, got);
                for (int k = 0; k < 3; k++)
                    if (!(fabs(got[k] - n[k]) <= 1e-6))
                        fail_msg("paraboloid %s (%d,%d,%d): %.9g, expected %.9g",
                                 sobel ? "sobel" : "central", x, y, k, got[k], n[k]);
            }
        assert_true(wgt_px(out, 40, 27, 0) < 0.47f); /* rising to the right: faces left */
        assert_true(wgt_px(out, 5, 27, 0) > 0.53f);  /* falling to the right: faces right */
        assert_true(wgt_px(out, 20, 60, 1) > 0.53f); /* rising downwards: faces up */
        assert_true(wgt_px(out, 20, 3, 1) < 0.47f);  /* rising upwards: faces down */
        assert_true(fabs(wgt_px(out, 20, 27, 0) - 0.5) < 0.01); /* near the bottom: level */
        wg_image_unref(out);
    }
    wg_image_unref(src);
}

static void test_directx_flips_green_exactly(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(31, 19, 1, ht_pattern_fn);
    static const double intensities[] = {0.3, 5, 1e4};
    for (int i = 0; i < 3; i++)
        for (int sobel = 0; sobel < 2; sobel++) {
            const char *m = sobel ? "sobel" : "central";
            WgImage *gl = normal(src, intensities[i], "opengl", m, 2);
            WgImage *dx = normal(src, intensities[i], "directx", m, 2);
            for (int y = 0; y < 19; y++)
                for (int x = 0; x < 31; x++) {
                    for (int k = 0; k < 4; k++)
                        if (k != 1 && wgt_px(gl, x, y, k) != wgt_px(dx, x, y, k))
                            fail_msg("channel %d differs at (%d,%d)", k, x, y);
                    /* exactly mirrored around 0.5: the decoded green is exactly negated */
                    if ((double)wgt_px(gl, x, y, 1) + (double)wgt_px(dx, x, y, 1) != 1.0)
                        fail_msg("green at (%d,%d): %.10g and %.10g", x, y, wgt_px(gl, x, y, 1),
                                 wgt_px(dx, x, y, 1));
                }
            wg_image_unref(dx);
            wg_image_unref(gl);
        }
    wg_image_unref(src);
}

/* On a smooth wave the two operators differ only by Sobel's (1 + cos kΔ)/2 smoothing of the
 * other axis: 1 − (1 + cos kΔ)/2 ≈ (kΔ)²/4 = 2.4e-3 relative at 128² with 2 periods. */
static void test_sobel_close_to_central(void **state)
{
    (void)state;
    WgImage *src = ht_wave(128, 128, 0.25, 1, 2);
    WgImage *c = normal(src, 80, "opengl", "central", 2);
    WgImage *s = normal(src, 80, "opengl", "sobel", 2);
    double d = wgt_max_abs_diff(c, s);
    assert_true(d < 2e-3); /* encoded: half the decoded difference */
    assert_true(d > 1e-6);
    wg_image_unref(s);
    wg_image_unref(c);
    wg_image_unref(src);
}

static void test_extreme_inputs(void **state)
{
    (void)state;
    /* steps of 1e6 at the largest intensity: near-vertical normals, still unit and finite */
    WgImage *step = wgt_image(16, 12, 1, NULL);
    for (int y = 0; y < 12; y++)
        for (int x = 8; x < 16; x++) wg_image_row(step, y)[x] = 1e6f;
    for (int sobel = 0; sobel < 2; sobel++) {
        const char *m = sobel ? "sobel" : "central";
        WgImage *out = normal(step, 1e6, "opengl", m, 2);
        assert_unit_and_opaque(out);
        /* the rising edge at x = 7..8 faces left, the wrap edge at x = 15..0 faces right */
        assert_true(wgt_px(out, 7, 5, 0) < 1e-6f && wgt_px(out, 8, 5, 0) < 1e-6f);
        assert_true(wgt_px(out, 15, 5, 0) > 1 - 1e-6f && wgt_px(out, 0, 5, 0) > 1 - 1e-6f);
        assert_true(wgt_px(out, 3, 5, 0) == 0.5f && wgt_px(out, 3, 5, 2) == 1.0f);
        wg_image_unref(out);
    }
    wg_image_unref(step);
    /* the largest floats, alternating sign: differences near 7e38 times 1e6 */
    WgImage *checker = wgt_image(6, 6, 1, NULL);
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 6; x++) wg_image_row(checker, y)[x] = (x + y) % 2 ? 3.4e38f : -3.4e38f;
    wg_image_row(checker, 2)[3] = 0;
    for (int sobel = 0; sobel < 2; sobel++) {
        WgImage *out = normal(checker, 1e6, "directx", sobel ? "sobel" : "central", 1);
        assert_unit_and_opaque(out);
        wg_image_unref(out);
    }
    wg_image_unref(checker);
    /* non-finite heights (only arithmetic makes them): an infinite difference is vertical, a
     * NaN one flat, and nothing else changes */
    WgImage *bad = wgt_image_fn(8, 6, 1, ht_pattern_fn);
    wg_image_row(bad, 2)[3] = INFINITY;
    wg_image_row(bad, 4)[5] = NAN;
    WgImage *out = normal(bad, 5, "opengl", "central", 2);
    assert_unit_and_opaque(out);
    assert_true(wgt_px(out, 2, 2, 0) == 0.0f && wgt_px(out, 4, 2, 0) == 1.0f); /* ±x walls */
    assert_true(wgt_px(out, 3, 1, 1) == 1.0f && wgt_px(out, 3, 3, 1) == 0.0f); /* ±y walls */
    assert_true(wgt_px(out, 4, 4, 0) == 0.5f && wgt_px(out, 6, 4, 0) == 0.5f); /* NaN: flat */
    assert_true(wgt_px(out, 5, 3, 1) == 0.5f && wgt_px(out, 5, 5, 1) == 0.5f);
    WgImage *ref = normal(bad, 5, "opengl", "central", 1);
    wgt_assert_identical(out, ref);
    wg_image_unref(ref);
    wg_image_unref(out);
    wg_image_unref(bad);
}

static void test_tiling_rolls_commute(void **state)
{
    (void)state;
    ht_assert_tiles("normal", "intensity=\"9\"");
    ht_assert_tiles("normal", "intensity=\"9\" method=\"sobel\"");
}

static void test_thread_invariance(void **state)
{
    (void)state;
    ht_assert_thread_invariant("normal", "intensity=\"3\"");
    ht_assert_thread_invariant("normal", "intensity=\"3\" method=\"sobel\"");
}

/* One wave sampled at 64² and 256²: pixel (x, y) of the small render and (4x, 4y) of the large
 * one are the same point of the texture, so their normals agree up to the discretisation error
 * of the coarse one ((kΔ)²/6 = 1.6e-3 relative for the 64² render, on |g| ≤ 1.1). A gradient
 * per pixel instead of per length unit would differ by 4×. */
static void test_resolution_independence(void **state)
{
    (void)state;
    for (int sobel = 0; sobel < 2; sobel++) {
        const char *m = sobel ? "sobel" : "central";
        WgImage *small = ht_wave(64, 64, 0.25, 1, 1);
        WgImage *large = ht_wave(256, 256, 0.25, 1, 1);
        WgImage *a = normal(small, 110, "opengl", m, 2);
        WgImage *b = normal(large, 110, "opengl", m, 2);
        double worst = 0, steepest = 0;
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 64; x++) {
                double na[3], nb[3];
                ht_decode(a, x, y, na);
                ht_decode(b, 4 * x, 4 * y, nb);
                for (int k = 0; k < 3; k++) worst = fmax(worst, fabs(na[k] - nb[k]));
                steepest = fmax(steepest, 1 - na[2]);
            }
        assert_true(worst <= (sobel ? 5e-3 : 2.5e-3));
        assert_true(steepest > 0.2); /* the normals do tilt */
        wg_image_unref(b);
        wg_image_unref(a);
        wg_image_unref(large);
        wg_image_unref(small);
    }
}

/* Thin images: along a side of 1 or 2 pixels both neighbours are the same pixel (wrapping), so
 * that component is 0; the other follows the column or row. */
static void test_thin_images(void **state)
{
    (void)state;
    static const float col[] = {0, 1, 4, 2, 2};
    WgImage *tall = wgt_image(1, 5, 1, col);
    WgImage *wide = wgt_image(5, 1, 1, col);
    WgImage *one = ht_const(1, 1, 0.7f);
    WgImage *t = normal(tall, 256, "opengl", "central", 2);
    WgImage *w = normal(wide, 256, "opengl", "central", 2);
    WgImage *o = normal(one, 1e6, "opengl", "sobel", 2);
    for (int i = 0; i < 5; i++) {
        /* width 1: the scale is intensity · 1/256 = 1 per unit height */
        double d = (col[(i + 1) % 5] - col[(i + 4) % 5]) / 2.0, n[3], g[3];
        ht_normal(0, d, n);
        ht_decode(t, 0, i, g);
        assert_true(wgt_px(t, 0, i, 0) == 0.5f);
        assert_float_equal(g[1], n[1], 1e-7);
        assert_float_equal(g[2], n[2], 1e-7);
        /* width 5: 5/256 · 256 = 5 per unit height, along x */
        ht_normal(5 * d, 0, n);
        ht_decode(w, i, 0, g);
        assert_true(wgt_px(w, i, 0, 1) == 0.5f);
        assert_float_equal(g[0], n[0], 1e-7);
        assert_float_equal(g[2], n[2], 1e-7);
    }
    assert_true(wgt_px(o, 0, 0, 0) == 0.5f && wgt_px(o, 0, 0, 1) == 0.5f &&
                wgt_px(o, 0, 0, 2) == 1.0f && wgt_px(o, 0, 0, 3) == 1.0f);
    wg_image_unref(o);
    wg_image_unref(w);
    wg_image_unref(t);
    wg_image_unref(one);
    wg_image_unref(wide);
    wg_image_unref(tall);
}

static void test_defaults(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(12, 9, 1, ht_pattern_fn);
    WgImage *a = ht_run("normal", "", src, 1);
    WgImage *b = normal(src, 1, "opengl", "central", 1);
    wgt_assert_identical(a, b);
    wg_image_unref(b);
    wg_image_unref(a);
    wg_image_unref(src);
}

static void test_errors(void **state)
{
    (void)state;
    WgImage *g = wgt_image(4, 4, 1, NULL);
    WgImage *c = wgt_image(4, 4, 4, NULL);
    const char *names[] = {"height"};
    const WgImage *gray[] = {g}, *color[] = {c};
    WgError err;
    assert_int_equal(wgt_node_error("normal", "intensity=\"-1\"", 4, 4, 1, names, gray, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "intensity"));
    assert_int_equal(wgt_node_error("normal", "intensity=\"2e6\"", 4, 4, 1, names, gray, &err),
                     WG_ERR_RANGE);
    assert_int_not_equal(wgt_node_error("normal", "format=\"vulkan\"", 4, 4, 1, names, gray, &err),
                         WG_OK);
    assert_non_null(strstr(err.message, "format"));
    assert_int_not_equal(wgt_node_error("normal", "method=\"prewitt\"", 4, 4, 1, names, gray, &err),
                         WG_OK);
    assert_int_not_equal(wgt_node_error("normal", "", 4, 4, 1, names, color, &err), WG_OK);
    assert_int_not_equal(wgt_node_error("normal", "", 4, 4, 0, names, gray, &err), WG_OK);
    wg_image_unref(c);
    wg_image_unref(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_float64_reference),
        cmocka_unit_test(test_flat_is_exactly_up),
        cmocka_unit_test(test_wave_analytic),
        cmocka_unit_test(test_paraboloid_analytic),
        cmocka_unit_test(test_directx_flips_green_exactly),
        cmocka_unit_test(test_sobel_close_to_central),
        cmocka_unit_test(test_extreme_inputs),
        cmocka_unit_test(test_tiling_rolls_commute),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_resolution_independence),
        cmocka_unit_test(test_thin_images),
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
