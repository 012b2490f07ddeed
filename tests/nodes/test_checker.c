/* SPDX-License-Identifier: MIT */
/* `checker`: exact squares on square and non-square images, the board continuing across the
 * wrap, resolution independence, hard cases. */
#include "gentest.h"

static void expect_board(int scale, int w, int h)
{
    char a[64];
    snprintf(a, sizeof a, "scale=\"%d\"", scale);
    WgImage *img = gen("checker", a, w, h, 0, 2);
    int nx = 2 * scale, ny = 2 * (int)fmax(1, floor((double)scale * h / w + 0.5));
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int cx = (int)floor((x + 0.5) * nx / w), cy = (int)floor((y + 0.5) * ny / h);
            double want = ((cx + cy) & 1) ? 0.0 : 1.0;
            assert_float_equal(gt_px(img, x, y), want, 0);
        }
    /* an even number of squares both ways: the board alternates across the wrap too */
    for (int y = 0; y < h && nx <= w; y++) assert_true(gt_px(img, 0, y) != gt_px(img, w - 1, y));
    for (int x = 0; x < w && ny <= h; x++) assert_true(gt_px(img, x, 0) != gt_px(img, x, h - 1));
    wg_image_unref(img);
}

static void test_exact(void **state)
{
    (void)state;
    WgImage *img = gen("checker", "scale=\"2\"", 8, 8, 0, 1);
    static const char *const rows[] = {"11001100", "11001100", "00110011", "00110011"};
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 8; x++) assert_float_equal(gt_px(img, x, y), rows[y % 4][x] - '0', 0);
    wg_image_unref(img);
    expect_board(2, 8, 8);
    expect_board(3, 12, 6);  /* rows = round(1.5) = 2: squares 2 px wide, 1.5 px high */
    expect_board(5, 30, 70); /* rows = round(11.67) = 12 */
    expect_board(1, 7, 3);
}

static void test_tiling_resolution_threads(void **state)
{
    (void)state;
    assert_subsample("checker", "scale=\"3\"", 36, 20, 0, 0);
    assert_thread_invariant("checker", "scale=\"7\"", 0);
    /* 4x4 boxes of the 256 render straddle square edges only where 64 px squares do not
     * divide evenly: scale 4 on 64 gives 8 px squares, so the box means are exactly 0 or 1 */
    assert_downsample("checker", "scale=\"4\"", 64, 4, 0, 0, 0);
}

static void test_hard_cases(void **state)
{
    (void)state;
    assert_alloc_failures("checker", "scale=\"3\"", 0);
    assert_error_range("checker", "scale=\"0\"", "'scale' = 0 is outside");
    WgImage *img = gen("checker", "scale=\"8192\"", 64, 64, 0, 1);
    wgt_assert_range(img, 0, 1);
    wg_image_unref(img);
    img = gen("checker", "scale=\"3\"", 1, 1, 0, 1);
    wgt_assert_range(img, 1, 1);
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
