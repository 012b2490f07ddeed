/* SPDX-License-Identifier: MIT */
/* `sine`: exact values (wave vector rounded to whole periods per tile), smooth tiling at
 * several angles, resolution independence, threads, hard cases. */
#include "gentest.h"

static void expect(const char *attrs, int w, int h, double kx, double ky, double phase)
{
    WgImage *img = gen("sine", attrs, w, h, 0, 2);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double t = kx * (x + 0.5) / w + ky * (y + 0.5) / h + phase;
            double want = 0.5 + 0.5 * sin(2 * M_PI * t);
            if (!(fabs(gt_px(img, x, y) - want) <= 1e-6))
                fail_msg("%s at (%d,%d): %.7g, want %.7g", attrs, x, y, gt_px(img, x, y), want);
        }
    wg_image_unref(img);
}

static void test_exact(void **state)
{
    (void)state;
    expect("angle=\"0\" frequency=\"2\"", 8, 2, 2, 0, 0);
    expect("angle=\"90\" frequency=\"3\"", 9, 9, 0, 3, 0);
    /* frequency counts waves across the width: on a 2×9 image that is 3·9/2 → 14 down */
    expect("angle=\"90\" frequency=\"3\"", 2, 9, 0, 14, 0);
    expect("angle=\"0\" frequency=\"1\" phase=\"0.25\"", 8, 1, 1, 0, 0.25);
    /* 5·(cos 30°, sin 30°·16/32) = (4.33, 1.25) rounds to (4, 1) */
    expect("angle=\"30\" frequency=\"5\"", 32, 16, 4, 1, 0);
    expect("angle=\"180\" frequency=\"2\" phase=\"-1.5\"", 16, 4, -2, 0, 0.5);
    /* frequency too low to round to a period: constant 0.5 + 0.5 sin(2π·phase) */
    expect("angle=\"45\" frequency=\"0.4\" phase=\"0.1\"", 5, 5, 0, 0, 0.1);
    /* pixel values at known points: frequency 1 across 4 px */
    WgImage *img = gen("sine", "frequency=\"1\"", 4, 1, 0, 1);
    assert_float_equal(gt_px(img, 0, 0), 0.5 + 0.5 * sin(M_PI / 4), 1e-6);
    assert_float_equal(gt_px(img, 1, 0), 0.5 + 0.5 * sin(3 * M_PI / 4), 1e-6);
    wg_image_unref(img);
}

static void test_tiling_resolution_threads(void **state)
{
    (void)state;
    const char *cases[] = {"angle=\"0\" frequency=\"3\"", "angle=\"30\" frequency=\"4\"",
                           "angle=\"-100\" frequency=\"2.5\" phase=\"0.3\""};
    for (int i = 0; i < 3; i++) {
        assert_tiles("sine", cases[i], 128, 128, 0, true);
        assert_tiles("sine", cases[i], 160, 96, 0, true);
        assert_subsample("sine", cases[i], 30, 20, 0, 1e-6);
        assert_thread_invariant("sine", cases[i], 0);
    }
    /* 4x4 box of a sine of wavelength >= 16 px at 64: attenuation 1 − sinc ≈ 0.6% */
    assert_downsample("sine", cases[1], 64, 4, 0, 0.004, 0.01);
}

static void test_hard_cases(void **state)
{
    (void)state;
    assert_alloc_failures("sine", "angle=\"20\"", 0);
    assert_error_range("sine", "frequency=\"-1\"", "frequency");
    WgImage *img = gen("sine", "frequency=\"16384\" angle=\"17\" phase=\"1e5\"", 64, 3, 0, 1);
    wgt_assert_range(img, 0, 1);
    wg_image_unref(img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact),
        cmocka_unit_test(test_tiling_resolution_threads),
        cmocka_unit_test(test_hard_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
