/* SPDX-License-Identifier: MIT */
/* `gradient_map`: keys at, between and beyond their positions, linear and smooth against a
 * float64 reference, hex (sRGB) and numeric (linear) colours, alpha, one key, unordered keys,
 * hard edges, malformed keys, extremes, threads. */
#include "colortest.h"

static WgImage *run(const char *keys, const char *interp, const WgImage *in)
{
    char attrs[4096];
    snprintf(attrs, sizeof attrs, "keys=\"%s\" interpolation=\"%s\"", keys, interp);
    return ct_source("gradient_map", attrs, in);
}

/* IEC 61966-2-1 decode of an 8-bit value, as the engine decodes #hex colours. */
static double hex_lin(int v)
{
    double x = (float)v / 255.0f;
    return x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4);
}

static void test_default_black_to_white(void **state)
{
    (void)state;
    float v[] = {-1, 0, 0.25f, 0.5f, 1, 2};
    WgImage *in = ct_row(1, 6, v);
    WgImage *out = ct_source("gradient_map", "", in);
    assert_int_equal(out->channels, 4);
    float want[] = {0, 0, 0.25f, 0.5f, 1, 1};
    for (int i = 0; i < 6; i++) {
        for (int k = 0; k < 3; k++) assert_true(wgt_px(out, i, 0, k) == want[i]);
        assert_true(wgt_px(out, i, 0, 3) == 1.0f);
    }
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_keys_linear_and_smooth(void **state)
{
    (void)state;
    const char *keys = "0:#1a1a1a 0.5:#804020 1:#ffffff";
    /* key colours as the node holds them (float), interpolated in float64 */
    double c[3][3] = {{(float)hex_lin(0x1a), (float)hex_lin(0x1a), (float)hex_lin(0x1a)},
                      {(float)hex_lin(0x80), (float)hex_lin(0x40), (float)hex_lin(0x20)},
                      {1, 1, 1}};
    int w = 257;
    WgImage *in = wg_image_new(w, 1, 1);
    for (int i = 0; i < w; i++) wg_image_row(in, 0)[i] = (float)(-0.25 + 1.5 * i / (w - 1));
    for (int smooth = 0; smooth < 2; smooth++) {
        WgImage *out = run(keys, smooth ? "smooth" : "linear", in);
        for (int i = 0; i < w; i++) {
            double x = wg_image_row(in, 0)[i];
            int a = x < 0.5 ? 0 : 1;
            double t = (x - (a ? 0.5 : 0)) / 0.5;
            t = t < 0 ? 0 : t > 1 ? 1 : t;
            if (smooth) t = t * t * (3 - 2 * t);
            for (int k = 0; k < 3; k++) {
                double ref = c[a][k] + (c[a + 1][k] - c[a][k]) * t;
                double got = wgt_px(out, i, 0, k);
                if (fabs(got - ref) > 0x1p-24 * ref + 1e-12) /* one rounding */
                    fail_msg("%s x=%g channel %d: %.9g vs float64 %.9g",
                             smooth ? "smooth" : "linear", x, k, got, ref);
            }
            assert_true(wgt_px(out, i, 0, 3) == 1.0f);
        }
        /* exactly the key colours at the keys */
        float at[] = {0, 0.5f, 1};
        WgImage *kin = ct_row(1, 3, at);
        WgImage *kout = run(keys, smooth ? "smooth" : "linear", kin);
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++) assert_true(wgt_px(kout, j, 0, k) == (float)c[j][k]);
        wg_image_unref(kout);
        wg_image_unref(kin);
        wg_image_unref(out);
    }
    wg_image_unref(in);
}

static void test_smooth_hand_values(void **state)
{
    (void)state;
    /* smoothstep(0.25) = 0.15625, smoothstep(0.5) = 0.5, numeric colours are linear */
    float v[] = {0.25f, 0.5f, 0.75f};
    WgImage *in = ct_row(1, 3, v);
    WgImage *out = run("0:0 1:1,0.5,0", "smooth", in);
    assert_true(wgt_px(out, 0, 0, 0) == 0.15625f);
    assert_true(wgt_px(out, 0, 0, 1) == 0.078125f);
    assert_true(wgt_px(out, 1, 0, 0) == 0.5f);
    assert_true(wgt_px(out, 2, 0, 0) == 0.84375f);
    assert_true(wgt_px(out, 2, 0, 2) == 0.0f);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_alpha_and_colour_syntax(void **state)
{
    (void)state;
    float v[] = {0, 0.5f, 1};
    WgImage *in = ct_row(1, 3, v);
    WgImage *out = run("0:#ff000000 1:0.2,0.4,0.6,1", "linear", in);
    assert_true(wgt_px(out, 0, 0, 0) == 1.0f && wgt_px(out, 0, 0, 3) == 0.0f);
    assert_float_equal(wgt_px(out, 1, 0, 0), 0.6, 1e-7);
    assert_float_equal(wgt_px(out, 1, 0, 1), 0.2, 1e-7);
    assert_float_equal(wgt_px(out, 1, 0, 3), 0.5, 1e-7);
    assert_true(wgt_px(out, 2, 0, 1) == 0.4f && wgt_px(out, 2, 0, 3) == 1.0f);
    wg_image_unref(out);
    /* #rgb and one gray number */
    out = run("0:#f00 1:0.5", "linear", in);
    assert_true(wgt_px(out, 0, 0, 0) == 1.0f && wgt_px(out, 0, 0, 1) == 0.0f);
    assert_true(wgt_px(out, 2, 0, 0) == 0.5f && wgt_px(out, 2, 0, 2) == 0.5f);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_one_key_unordered_and_hard_edge(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(64, 4, 1, -0.5, 1.5, 11);
    WgImage *out = run("0.4:#336699", "smooth", in);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 64; x++) {
            assert_true(wgt_px(out, x, y, 0) == (float)hex_lin(0x33));
            assert_true(wgt_px(out, x, y, 2) == (float)hex_lin(0x99));
        }
    wg_image_unref(out);

    WgImage *a = run("0:#000 0.3:#f80 1:#fff", "linear", in);
    WgImage *b = run("1:#fff 0:#000 0.3:#f80", "linear", in);
    wgt_assert_identical(a, b);
    wg_image_unref(a);
    wg_image_unref(b);

    float v[] = {0.25f, 0.49999997f, 0.5f, 0.75f};
    WgImage *e = ct_row(1, 4, v);
    out = run("0:#000 0.5:#000 0.5:#fff 1:#fff", "linear", e);
    float want[] = {0, 0, 1, 1};
    for (int i = 0; i < 4; i++) assert_true(wgt_px(out, i, 0, 0) == want[i]);
    wg_image_unref(out);
    wg_image_unref(e);
    wg_image_unref(in);
}

static void test_malformed_keys(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(4, 4, 1, 0, 1, 1);
    ct_fails("gradient_map", "keys=\"0:#000 0.5 1:#fff\"", in, WG_ERR_PARSE,
             "key 2 '0.5' is not 'position:colour'");
    ct_fails("gradient_map", "keys=\"x:#fff\"", in, WG_ERR_PARSE, "key 1 'x:#fff'");
    ct_fails("gradient_map", "keys=\"0:#12345\"", in, WG_ERR_PARSE, "bad colour '#12345'");
    ct_fails("gradient_map", "keys=\"0:#ggg\"", in, WG_ERR_PARSE, "bad colour '#ggg'");
    ct_fails("gradient_map", "keys=\"0:red\"", in, WG_ERR_PARSE, "bad colour 'red'");
    ct_fails("gradient_map", "keys=\"0:0.1,0.2\"", in, WG_ERR_PARSE, "bad colour");
    ct_fails("gradient_map", "keys=\"0:1,2,3,4,5\"", in, WG_ERR_PARSE, "bad colour");
    ct_fails("gradient_map", "keys=\"0:\"", in, WG_ERR_PARSE, "bad colour ''");
    ct_fails("gradient_map", "keys=\"0:nan\"", in, WG_ERR_PARSE, "bad colour 'nan'");
    ct_fails("gradient_map", "keys=\"inf:#fff\"", in, WG_ERR_PARSE, "key 1");
    ct_fails("gradient_map", "keys=\"0:1e39\"", in, WG_ERR_PARSE, "bad colour '1e39'");
    ct_fails("gradient_map", "keys=\"0x0:#fff\"", in, WG_ERR_PARSE, "key 1");
    ct_fails("gradient_map", "keys=\"0:0x1\"", in, WG_ERR_PARSE, "bad colour '0x1'");
    ct_fails("gradient_map", "keys=\"\"", in, WG_ERR_PARSE, "at least one key");
    wg_image_unref(in);
    /* a colour image on the gray input is a graph error */
    WgImage *c = ct_random_image(4, 4, 4, 0, 1, 1);
    WgError err;
    const char *names[] = {"source"};
    const WgImage *images[] = {c};
    assert_int_equal(wgt_node_error("gradient_map", "", 4, 4, 1, names, images, &err), WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 0, "grayscale");
    wg_image_unref(c);
}

static void test_extremes(void **state)
{
    (void)state;
    float v[] = {-3e38f, -1e6f, 1e6f, 3e38f, NAN, INFINITY, -INFINITY};
    WgImage *in = ct_row(1, 7, v);
    WgImage *out = run("0:#000 1:#fff", "smooth", in);
    ct_assert_finite(out);
    float want[] = {0, 0, 1, 1, 0, 1, 0};
    for (int i = 0; i < 7; i++) assert_true(wgt_px(out, i, 0, 0) == want[i]);
    wg_image_unref(out);
    out = run("-3e38:-3e38 3e38:3e38", "smooth", in);
    ct_assert_finite(out);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_threads(void **state)
{
    (void)state;
    ct_assert_thread_invariant("gradient_map",
                               "keys=\"0:#1a1a1a 0.5:#804020 1:#ffffff\" interpolation=\"smooth\"",
                               "source", 1, -0.2, 1.2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_black_to_white),
        cmocka_unit_test(test_keys_linear_and_smooth),
        cmocka_unit_test(test_smooth_hand_values),
        cmocka_unit_test(test_alpha_and_colour_syntax),
        cmocka_unit_test(test_one_key_unordered_and_hard_edge),
        cmocka_unit_test(test_malformed_keys),
        cmocka_unit_test(test_extremes),
        cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
