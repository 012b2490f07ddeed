/* SPDX-License-Identifier: MIT */
/* `clamp`: exact values, min = max, min > max rejected, NaN and extremes, alpha, threads. */
#include "colortest.h"

static void test_exact_values(void **state)
{
    (void)state;
    float v[] = {-1e6f, -0.5f, 0, 0.2f, 0.5f, 0.8f, 1, 1e6f};
    WgImage *in = ct_row(1, 8, v);
    WgImage *out = ct_source("clamp", "min=\"0.2\" max=\"0.8\"", in);
    float want[] = {0.2f, 0.2f, 0.2f, 0.2f, 0.5f, 0.8f, 0.8f, 0.8f};
    for (int i = 0; i < 8; i++) assert_true(wgt_px(out, i, 0, 0) == want[i]);
    wg_image_unref(out);
    /* default [0, 1] */
    out = ct_source("clamp", "", in);
    float want01[] = {0, 0, 0, 0.2f, 0.5f, 0.8f, 1, 1};
    for (int i = 0; i < 8; i++) assert_true(wgt_px(out, i, 0, 0) == want01[i]);
    wg_image_unref(out);
    /* HDR bounds */
    out = ct_source("clamp", "min=\"-1\" max=\"1000\"", in);
    float wanth[] = {-1, -0.5f, 0, 0.2f, 0.5f, 0.8f, 1, 1000};
    for (int i = 0; i < 8; i++) assert_true(wgt_px(out, i, 0, 0) == wanth[i]);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_min_equals_max_and_min_above_max(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(16, 8, 4, -2, 2, 5);
    WgImage *out = ct_source("clamp", "min=\"0.3\" max=\"0.3\"", in);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 16; x++) {
            for (int k = 0; k < 3; k++) assert_true(wgt_px(out, x, y, k) == 0.3f);
            assert_true(wgt_px(out, x, y, 3) == wgt_px(in, x, y, 3));
        }
    wg_image_unref(out);
    ct_fails("clamp", "min=\"0.8\" max=\"0.2\"", in, WG_ERR_RANGE, "min 0.8 is above max 0.2");
    wg_image_unref(in);
}

static void test_colour_alpha_unchanged(void **state)
{
    (void)state;
    float v[] = {-1, 0.5f, 2, -3, 0.25f, 1.5f, 0.75f, 9};
    WgImage *in = ct_row(4, 8, v);
    WgImage *out = ct_source("clamp", "", in);
    float want[] = {0, 0.5f, 1, -3, 0.25f, 1, 0.75f, 9};
    for (int i = 0; i < 8; i++) assert_true(wgt_px(out, i / 4, 0, i % 4) == want[i]);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_nan_and_infinities(void **state)
{
    (void)state;
    float v[] = {NAN, INFINITY, -INFINITY, 3e38f, -3e38f};
    WgImage *in = ct_row(1, 5, v);
    WgImage *out = ct_source("clamp", "min=\"-2\" max=\"3\"", in);
    ct_assert_finite(out);
    float want[] = {-2, 3, -2, 3, -2};
    for (int i = 0; i < 5; i++) assert_true(wgt_px(out, i, 0, 0) == want[i]);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_threads(void **state)
{
    (void)state;
    ct_assert_thread_invariant("clamp", "min=\"0.1\" max=\"0.9\"", "source", 1, -1, 2);
    ct_assert_thread_invariant("clamp", "min=\"0.1\" max=\"0.9\"", "source", 4, -1, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_values),
        cmocka_unit_test(test_min_equals_max_and_min_above_max),
        cmocka_unit_test(test_colour_alpha_unchanged),
        cmocka_unit_test(test_nan_and_infinities),
        cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
