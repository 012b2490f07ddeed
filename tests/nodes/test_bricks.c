/* SPDX-License-Identifier: MIT */
/* `bricks`: the mask, height and id against an analytic reference on small images, known
 * pixels, per-brick random values, the brick that straddles the wrap, tiling, resolution
 * independence, threads, seeds and hard cases (no mortar, all mortar, huge counts). */
#include "gentest.h"

/* e: distance to the brick outline over half the short side (no random row offset) */
static double ref_e(int cols, int rows, double offset, int w, int h, int x, int y, int *id)
{
    double tv = (y + 0.5) * rows / h;
    int row = (int)floor(tv);
    double fy = tv - row;
    double tu = (x + 0.5) * cols / w - offset * (row & 1);
    int col = (int)floor(tu);
    double fx = tu - col;
    col = ((col % cols) + cols) % cols;
    double bw = (double)w / cols, bh = (double)h / rows;
    double d = fmin(fmin(fx, 1 - fx) * bw, fmin(fy, 1 - fy) * bh);
    *id = row * cols + col;
    return d / (0.5 * fmin(bw, bh));
}

static void check_reference(int cols, int rows, double offset, double mortar, double bevel, int w,
                            int h)
{
    char a[256];
    snprintf(a, sizeof a, "columns=\"%d\" rows=\"%d\" row_offset=\"%g\" mortar=\"%g\" bevel=\"%g\"",
             cols, rows, offset, mortar, bevel);
    WgImage *ht = gen("bricks", a, w, h, 0, 2), *mask = gen("bricks", a, w, h, 1, 2);
    WgImage *id = gen("bricks", a, w, h, 3, 2);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int n;
            double e = ref_e(cols, rows, offset, w, h, x, y, &n);
            if (fabs(e - mortar) < 1e-4) continue; /* on the joint's edge: either side is right */
            double m = mortar == 0 || e > mortar ? 1 : 0;
            double t = bevel > 0 ? fmin(1, fmax(0, (e - mortar) / bevel)) : 1;
            double hh = m * t * t * (3 - 2 * t);
            double want_id = (n + 0.5) / (rows * cols);
            if (gt_px(mask, x, y) != m || !(fabs(gt_px(ht, x, y) - hh) <= 1e-5) ||
                !(fabs(gt_px(id, x, y) - want_id) <= 1e-6))
                fail_msg("%s %dx%d at (%d,%d): mask %g height %g id %g, want %g %g %g", a, w, h, x,
                         y, gt_px(mask, x, y), gt_px(ht, x, y), gt_px(id, x, y), m, hh, want_id);
        }
    wg_image_unref(ht);
    wg_image_unref(mask);
    wg_image_unref(id);
}

static void test_exact(void **state)
{
    (void)state;
    /* 2×2 bricks of 8×4 px, joints 1 px on each side of an edge; row 1 shifted by 4 px */
    WgImage *m = gen("bricks", "columns=\"2\" rows=\"2\" mortar=\"0.5\" bevel=\"0\"", 16, 8, 1, 1);
    static const char *const want[] = {
        "0000000000000000", "0111111001111110", "0111111001111110", "0000000000000000",
        "0000000000000000", "1110011111100111", "1110011111100111", "0000000000000000",
    };
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 16; x++) {
            double v = want[y][x] - '0';
            if (gt_px(m, x, y) != v)
                fail_msg("mask at (%d,%d) = %g, want %g", x, y, gt_px(m, x, y), v);
        }
    wg_image_unref(m);
    check_reference(2, 2, 0.5, 0.5, 0, 16, 8);
    check_reference(4, 8, 0.5, 0.1, 0.3, 128, 96);
    check_reference(3, 5, 0.25, 0.2, 0.6, 90, 70);
    check_reference(5, 3, 0.0, 0.05, 0.0, 100, 40);
}

static void test_per_brick_values(void **state)
{
    (void)state;
    const char *a = "columns=\"4\" rows=\"6\" height_variation=\"0.8\" luminance_variation=\"0.5\" "
                    "bevel=\"0\" seed=\"3\"";
    WgImage *id = gen("bricks", a, 64, 48, 3, 2), *rnd = gen("bricks", a, 64, 48, 2, 2);
    WgImage *ht = gen("bricks", a, 64, 48, 0, 2), *mask = gen("bricks", a, 64, 48, 1, 2);
    double by_id_r[24], by_id_h[24];
    for (int i = 0; i < 24; i++) by_id_r[i] = by_id_h[i] = -1;
    for (int y = 0; y < 48; y++)
        for (int x = 0; x < 64; x++) {
            int n = (int)floor(gt_px(id, x, y) * 24);
            assert_true(n >= 0 && n < 24);
            double r = gt_px(rnd, x, y);
            assert_true(r >= 0.5 && r <= 1);
            if (by_id_r[n] < 0) by_id_r[n] = r;
            assert_float_equal(r, by_id_r[n], 0); /* one random value per brick */
            if (gt_px(mask, x, y) == 1) {
                double hv = gt_px(ht, x, y);
                assert_true(hv >= 0.2 - 1e-6 && hv <= 1);
                if (by_id_h[n] < 0) by_id_h[n] = hv;
                assert_float_equal(hv, by_id_h[n], 0); /* flat tops without bevel */
            } else {
                assert_float_equal(gt_px(ht, x, y), 0, 0);
            }
        }
    int distinct = 0;
    for (int i = 0; i < 24; i++) distinct += by_id_r[i] != by_id_r[0];
    assert_true(distinct >= 20);
    /* odd rows are shifted half a brick: the brick across the left/right edge is one brick */
    for (int y = 0; y < 48; y++) {
        int row = y / 8;
        if (row & 1)
            assert_float_equal(gt_px(id, 0, y), gt_px(id, 63, y), 0);
        else
            assert_true(gt_px(id, 0, y) != gt_px(id, 63, y));
    }
    wg_image_unref(id);
    wg_image_unref(rnd);
    wg_image_unref(ht);
    wg_image_unref(mask);
}

static void test_tiling_resolution_threads(void **state)
{
    (void)state;
    /* mortar widths chosen so that no pixel centre of the sizes below lies exactly on a joint's
     * edge (there the mask may fall either way with float rounding) */
    const char *cases[] = {
        "columns=\"4\" rows=\"8\" bevel=\"0.5\" mortar=\"0.1\"",
        "columns=\"3\" rows=\"6\" bevel=\"0.8\" mortar=\"0.21\" random_offset=\"0.5\" "
        "height_variation=\"0.5\"",
        "columns=\"5\" rows=\"5\" bevel=\"0.6\" mortar=\"0.17\" row_offset=\"0.3\"",
    };
    for (int i = 0; i < 3; i++)
        for (int seed = 1; seed <= 3; seed++) {
            char a[256];
            snprintf(a, sizeof a, "%s seed=\"%d\"", cases[i], seed);
            assert_tiles("bricks", a, 120, 120, 0, false);
            assert_tiles("bricks", a, 150, 90, 0, false);
        }
    for (int i = 0; i < 3; i++)
        for (int p = 0; p < 4; p++) {
            assert_subsample("bricks", cases[i], 40, 30, p, 1e-5);
            assert_thread_invariant("bricks", cases[i], p);
        }
    assert_seeded("bricks", "columns=\"16\" rows=\"16\"", 2);
    /* height with a wide bevel is smooth but the joints are hard: small mean error */
    assert_downsample("bricks", cases[0], 64, 4, 0, 0.03, 0.5);
}

static void test_hard_cases(void **state)
{
    (void)state;
    assert_alloc_failures("bricks", "bevel=\"0.3\"", 3);
    WgImage *img = gen("bricks", "mortar=\"0\" bevel=\"0\"", 33, 17, 1, 1);
    wgt_assert_range(img, 1, 1); /* zero-width mortar: no joints at all */
    wg_image_unref(img);
    img = gen("bricks", "mortar=\"0\" bevel=\"0\"", 33, 17, 0, 1);
    wgt_assert_range(img, 1, 1);
    wg_image_unref(img);
    img = gen("bricks", "mortar=\"1\"", 33, 17, 1, 1);
    wgt_assert_range(img, 0, 0); /* all joint */
    wg_image_unref(img);
    img = gen("bricks", "columns=\"1\" rows=\"1\" row_offset=\"1\"", 9, 9, 3, 1);
    wgt_assert_range(img, 0.5, 0.5);
    wg_image_unref(img);
    for (int p = 0; p < 4; p++) {
        img = gen("bricks", "columns=\"4096\" rows=\"4096\" bevel=\"1\"", 64, 64, p, 2);
        wgt_assert_range(img, 0, 1);
        wg_image_unref(img);
    }
    assert_error_range("bricks", "columns=\"0\"", "columns");
    assert_error_range("bricks", "mortar=\"-0.1\"", "mortar");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact),
        cmocka_unit_test(test_per_brick_values),
        cmocka_unit_test(test_tiling_resolution_threads),
        cmocka_unit_test(test_hard_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
