/* SPDX-License-Identifier: MIT */
/* `colorspace`: the IEC 61966-2-1 formulas (bit-exact against a float64 evaluation rounded once),
 * the round-trip error bound, negative and huge values, gray and colour, threads. */
#include "colortest.h"

static double to_lin(double v)
{
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

static double to_srgb(double v)
{
    if (v <= 0) return 0;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
}

static WgImage *run(const char *dir, const WgImage *in)
{
    char attrs[64];
    snprintf(attrs, sizeof attrs, "direction=\"%s\"", dir);
    return ct_source("colorspace", attrs, in);
}

static void test_known_values(void **state)
{
    (void)state;
    float v[] = {0, 0.04045f, 0.5f, 1, -0.1f, 2};
    WgImage *in = ct_row(1, 6, v);
    WgImage *lin = run("to_linear", in);
    assert_true(wgt_px(lin, 0, 0, 0) == 0.0f);
    assert_float_equal(wgt_px(lin, 1, 0, 0), 0.04045 / 12.92, 1e-9);
    assert_float_equal(wgt_px(lin, 2, 0, 0), 0.21404114, 1e-7);
    assert_true(wgt_px(lin, 3, 0, 0) == 1.0f);
    assert_float_equal(wgt_px(lin, 4, 0, 0), -0.1 / 12.92, 1e-9); /* linear segment continues */
    assert_float_equal(wgt_px(lin, 5, 0, 0), pow(2.055 / 1.055, 2.4), 1e-6);
    WgImage *srgb = run("to_srgb", in);
    assert_true(wgt_px(srgb, 0, 0, 0) == 0.0f);
    assert_float_equal(wgt_px(srgb, 2, 0, 0), 0.73535698, 1e-7);
    assert_true(wgt_px(srgb, 3, 0, 0) == 1.0f);
    assert_true(wgt_px(srgb, 4, 0, 0) == 0.0f); /* negative -> 0 */
    wg_image_unref(srgb);
    wg_image_unref(lin);
    wg_image_unref(in);
}

static void test_formulas_exact(void **state)
{
    (void)state;
    /* every result is the float64 formula rounded once */
    int w = 2048, h = 8;
    WgImage *in = wg_image_new(w, h, 1);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            wg_image_row(in, y)[x] =
                (float)(y < 4 ? (x + y * w) / (4.0 * w - 1) * 1.2 - 0.1
                              : pow(10, -8 + 8.0 * (x + (y - 4) * w) / (4.0 * w)));
    WgImage *lin = run("to_linear", in), *srgb = run("to_srgb", in);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double v = wg_image_row(in, y)[x];
            if (wgt_px(lin, x, y, 0) != (float)to_lin(v))
                fail_msg("to_linear(%.9g) = %.9g, expected %.9g", v, wgt_px(lin, x, y, 0),
                         (float)to_lin(v));
            if (wgt_px(srgb, x, y, 0) != (float)to_srgb(v))
                fail_msg("to_srgb(%.9g) = %.9g, expected %.9g", v, wgt_px(srgb, x, y, 0),
                         (float)to_srgb(v));
        }
    wg_image_unref(lin);
    wg_image_unref(srgb);
    wg_image_unref(in);
}

static void test_round_trip_bound(void **state)
{
    (void)state;
    /* linear -> sRGB -> linear and back the other way, over [0, 1] evenly and log-spaced down to
     * the smallest normal float: relative error within 2e-7 (documented bound) */
    int w = 1024, h = 512;
    WgImage *in = wg_image_new(w, h, 1);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double t = (double)(y * w + x) / (w * h - 1);
            wg_image_row(in, y)[x] = (float)(y % 2 ? t : pow(2, -126 * (1 - t)));
        }
    WgImage *a = run("to_srgb", in), *b = run("to_linear", a);
    WgImage *c = run("to_linear", in), *d = run("to_srgb", c);
    double worst = 0, worst2 = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double v = wg_image_row(in, y)[x];
            if (v == 0) continue;
            double e = fabs(wgt_px(b, x, y, 0) - v) / v;
            double e2 = fabs(wgt_px(d, x, y, 0) - v) / v;
            if (e > worst) worst = e;
            if (e2 > worst2 && v >= 0x1p-100) worst2 = e2;
        }
    print_message("colorspace round trip: linear->srgb->linear %.3g, srgb->linear->srgb %.3g\n",
                  worst, worst2);
    assert_true(worst <= 2e-7);
    assert_true(worst2 <= 2e-7);
    wg_image_unref(a);
    wg_image_unref(b);
    wg_image_unref(c);
    wg_image_unref(d);
    wg_image_unref(in);
}

static void test_colour_alpha_and_extremes(void **state)
{
    (void)state;
    float v[] = {0.5f, 1e6f, 3e38f, 0.3f, -3e38f, NAN, INFINITY, -1};
    WgImage *in = ct_row(4, 8, v);
    for (int dir = 0; dir < 2; dir++) {
        WgImage *out = run(dir ? "to_srgb" : "to_linear", in);
        ct_assert_finite(out);
        assert_true(wgt_px(out, 0, 0, 3) == 0.3f && wgt_px(out, 1, 0, 3) == -1.0f);
        assert_true(wgt_px(out, 1, 0, 1) == 0.0f);                         /* NaN -> 0 */
        if (dir == 0) assert_true(wgt_px(out, 0, 0, 2) == 3.40282347e38f); /* saturates */
        wg_image_unref(out);
    }
    wg_image_unref(in);
}

static void test_threads(void **state)
{
    (void)state;
    ct_assert_thread_invariant("colorspace", "direction=\"to_srgb\"", "source", 4, -0.5, 2);
    ct_assert_thread_invariant("colorspace", "direction=\"to_linear\"", "source", 1, -0.5, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_known_values),     cmocka_unit_test(test_formulas_exact),
        cmocka_unit_test(test_round_trip_bound), cmocka_unit_test(test_colour_alpha_and_extremes),
        cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
