/* SPDX-License-Identifier: MIT */
/* `hsl`: zero shift is an exact copy, primaries and grays, a float64 reference written with the
 * alternative HSL-to-RGB formula, hue round trips, clipping of extremes, alpha, threads. */
#include "colortest.h"

static WgImage *run(double h, double s, double l, const WgImage *in)
{
    char attrs[256];
    snprintf(attrs, sizeof attrs, "hue=\"%.17g\" saturation=\"%.17g\" lightness=\"%.17g\"", h, s,
             l);
    return ct_source("hsl", attrs, in);
}

static double enc(double v)
{
    if (v <= 0) return 0;
    double e = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
    return e > 1 ? 1 : e;
}

static double dec(double e)
{
    return e <= 0.04045 ? e / 12.92 : pow((e + 0.055) / 1.055, 2.4);
}

/* float64 reference of the documented model; HSL -> RGB by f(n) = L - a·max(-1, min(k-3, 9-k, 1))
 */
static void ref_hsl(const float in[3], double dh, double ds, double dl, double out[3])
{
    double r = enc(in[0]), g = enc(in[1]), b = enc(in[2]);
    double mx = fmax(r, fmax(g, b)), mn = fmin(r, fmin(g, b)), c = mx - mn;
    double L = (mx + mn) / 2, S = 0, H = 0;
    if (c > 0) {
        S = c / (1 - fabs(2 * L - 1));
        double hp = mx == r   ? fmod((g - b) / c + 6, 6)
                    : mx == g ? (b - r) / c + 2
                              : (r - g) / c + 4;
        H = hp / 6;
    }
    H = fmod(fmod(H + dh, 1) + 1, 1);
    S = ds <= 0 ? S * (1 + ds) : ds >= 1 ? (S > 0) : fmin(1, S / (1 - ds));
    L = dl <= 0 ? L * (1 + dl) : L + (1 - L) * dl;
    double a = S * fmin(L, 1 - L);
    int n[3] = {0, 8, 4};
    for (int i = 0; i < 3; i++) {
        double k = fmod(n[i] + H * 12, 12);
        double e = L - a * fmax(-1, fmin(fmin(k - 3, 9 - k), 1));
        out[i] = dec(fmin(fmax(e, 0), 1));
    }
}

static void test_zero_shift_is_identity(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(61, 13, 4, -2, 3, 21);
    wg_image_row(in, 0)[0] = 1e6f;
    wg_image_row(in, 0)[1] = -3e38f;
    wg_image_row(in, 0)[2] = NAN;
    WgImage *out = ct_source("hsl", "", in);
    /* bit-identical, NaN included: compare the bytes */
    for (int y = 0; y < 13; y++)
        assert_memory_equal(wg_image_row(in, y), wg_image_row(out, y), sizeof(float) * 61 * 4);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_primaries(void **state)
{
    (void)state;
    float v[] = {1, 0, 0, 0.25f, 0, 1, 0, 1, 0, 0, 1, 0.5f};
    WgImage *in = ct_row(4, 12, v);
    /* half a turn: red -> cyan, green -> magenta, blue -> yellow */
    WgImage *out = run(0.5, 0, 0, in);
    float want[] = {0, 1, 1, 0.25f, 1, 0, 1, 1, 1, 1, 0, 0.5f};
    for (int i = 0; i < 12; i++) assert_float_equal(wgt_px(out, i / 4, 0, i % 4), want[i], 1e-6);
    wg_image_unref(out);
    /* a third of a turn: red -> green -> blue -> red */
    out = run(1.0 / 3, 0, 0, in);
    float want3[] = {0, 1, 0, 0.25f, 0, 0, 1, 1, 1, 0, 0, 0.5f};
    for (int i = 0; i < 12; i++) assert_float_equal(wgt_px(out, i / 4, 0, i % 4), want3[i], 1e-6);
    wg_image_unref(out);
    /* negative shifts wrap the other way */
    out = run(-1.0 / 3, 0, 0, in);
    float want4[] = {0, 0, 1, 0.25f, 1, 0, 0, 1, 0, 1, 0, 0.5f};
    for (int i = 0; i < 12; i++) assert_float_equal(wgt_px(out, i / 4, 0, i % 4), want4[i], 1e-6);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_saturation_and_lightness(void **state)
{
    (void)state;
    float v[] = {0.8f, 0.2f, 0.1f, 1, 0.3f, 0.3f, 0.3f, 1};
    WgImage *in = ct_row(4, 8, v);
    /* -1 saturation: gray with the same HSL lightness */
    WgImage *out = run(0, -1, 0, in);
    for (int p = 0; p < 2; p++) {
        assert_true(wgt_px(out, p, 0, 0) == wgt_px(out, p, 0, 1));
        assert_true(wgt_px(out, p, 0, 1) == wgt_px(out, p, 0, 2));
    }
    double l = (enc(0.8f) + enc(0.1f)) / 2;
    assert_float_equal(wgt_px(out, 0, 0, 0), dec(l), 1e-6);
    wg_image_unref(out);
    /* +1 saturation: a colour becomes fully saturated, a gray stays gray */
    out = run(0, 1, 0, in);
    double mx = enc(wgt_px(out, 0, 0, 0)), mn = enc(wgt_px(out, 0, 0, 2));
    assert_float_equal((mx - mn), (1 - fabs(mx + mn - 1)), 1e-6); /* S = 1 */
    assert_true(wgt_px(out, 1, 0, 0) == wgt_px(out, 1, 0, 1) &&
                wgt_px(out, 1, 0, 1) == wgt_px(out, 1, 0, 2));
    assert_float_equal(wgt_px(out, 1, 0, 0), 0.3, 1e-6);
    wg_image_unref(out);
    /* lightness +1 white, -1 black */
    out = run(0, 0, 1, in);
    for (int i = 0; i < 8; i++) assert_float_equal(wgt_px(out, i / 4, 0, i % 4), 1, 1e-6);
    wg_image_unref(out);
    out = run(0.3, 0.2, -1, in);
    for (int i = 0; i < 8; i++)
        assert_float_equal(wgt_px(out, i / 4, 0, i % 4), ((i % 4) == 3 ? 1 : 0), 0);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_float64_reference(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(64, 32, 4, 0, 1, 5);
    /* some grays, near-grays, black and white */
    for (int x = 0; x < 8; x++) {
        float *p = wg_image_row(in, 0) + 4 * x;
        p[1] = p[2] = p[0];
        if (x > 4) p[2] += 1e-4f;
    }
    wg_image_row(in, 1)[0] = wg_image_row(in, 1)[1] = wg_image_row(in, 1)[2] = 0;
    wg_image_row(in, 1)[4] = wg_image_row(in, 1)[5] = wg_image_row(in, 1)[6] = 1;
    double shifts[][3] = {{0.1, 0, 0},     {-0.7, 0.3, -0.2}, {0.25, -0.5, 0.4},
                          {0.999, 0.5, 0}, {0, 0, -0.5},      {0.5, 1, 0},
                          {0, -1, 0.3},    {-1, 0, 0},        {0.123, 0.8, 0.9}};
    double worst = 0;
    for (size_t s = 0; s < sizeof shifts / sizeof shifts[0]; s++) {
        double dh = (float)shifts[s][0], ds = (float)shifts[s][1], dl = (float)shifts[s][2];
        WgImage *out = run(dh, ds, dl, in);
        for (int y = 0; y < 32; y++)
            for (int x = 0; x < 64; x++) {
                const float *p = wg_image_row(in, y) + 4 * x;
                double ref[3];
                ref_hsl(p, dh, ds, dl, ref);
                for (int k = 0; k < 3; k++) {
                    double e = fabs(wgt_px(out, x, y, k) - ref[k]);
                    if (e > worst) worst = e;
                    if (e > 1e-7) /* one rounding to float */
                        fail_msg(
                            "shift %g %g %g, (%.9g %.9g %.9g) channel %d: %.9g vs float64 %.9g", dh,
                            ds, dl, p[0], p[1], p[2], k, wgt_px(out, x, y, k), ref[k]);
                }
                assert_true(wgt_px(out, x, y, 3) == p[3]);
            }
        wg_image_unref(out);
    }
    print_message("hsl: max |error| vs float64 %.3g\n", worst);
    wg_image_unref(in);
}

static void test_hue_round_trips(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(50, 20, 4, 0, 1, 8);
    double turns[][2] = {{1, 0}, {-1, 0}, {0.5, 0.5}, {0.3, -0.3}, {-0.75, 0.75}};
    double worst = 0;
    for (size_t t = 0; t < sizeof turns / sizeof turns[0]; t++) {
        WgImage *a = run(turns[t][0], 0, 0, in);
        WgImage *b = turns[t][1] != 0 ? run(turns[t][1], 0, 0, a) : wg_image_ref(a);
        double d = wgt_max_abs_diff(in, b);
        if (d > worst) worst = d;
        if (d > 2e-7) fail_msg("hue %g then %g: off by %.3g", turns[t][0], turns[t][1], d);
        wg_image_unref(a);
        wg_image_unref(b);
    }
    print_message("hsl: hue round trip max |error| %.3g\n", worst);
    wg_image_unref(in);
}

static void test_extremes_clipped(void **state)
{
    (void)state;
    float v[] = {-1e6f, 1e6f, 0.5f, -7, 3e38f, -3e38f, 2, 1e6f, NAN, INFINITY, -INFINITY, 0};
    WgImage *in = ct_row(4, 12, v);
    WgImage *out = run(0.2, 0.3, 0.1, in);
    ct_assert_finite(out);
    for (int p = 0; p < 3; p++)
        for (int k = 0; k < 3; k++) {
            float c = wgt_px(out, p, 0, k);
            assert_true(c >= 0 && c <= 1);
        }
    assert_true(wgt_px(out, 0, 0, 3) == -7 && wgt_px(out, 1, 0, 3) == 1e6f);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_gray_input_promoted(void **state)
{
    (void)state;
    float v[] = {0, 0.5f, 1};
    WgImage *in = ct_row(1, 3, v);
    WgImage *out = run(0.4, 0, 0, in);
    assert_int_equal(out->channels, 4);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 4; k++)
            assert_float_equal(wgt_px(out, i, 0, k), (k == 3 ? 1 : v[i]), 1e-6);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_threads(void **state)
{
    (void)state;
    ct_assert_thread_invariant("hsl", "hue=\"0.3\" saturation=\"0.2\" lightness=\"-0.1\"", "source",
                               4, 0, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zero_shift_is_identity),   cmocka_unit_test(test_primaries),
        cmocka_unit_test(test_saturation_and_lightness), cmocka_unit_test(test_float64_reference),
        cmocka_unit_test(test_hue_round_trips),          cmocka_unit_test(test_extremes_clipped),
        cmocka_unit_test(test_gray_input_promoted),      cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
