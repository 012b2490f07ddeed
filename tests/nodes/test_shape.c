/* SPDX-License-Identifier: MIT */
/* `shape`: exact inside/outside and falloff values for each kind against analytic
 * references, overlap into neighbouring cells, tiling, rotation symmetries, resolution
 * independence, threads, hard cases. */
#include "gentest.h"

/* local cell coordinates in [-1, 1) of pixel (x, y) for `scale` cells across */
static void local(int scale, int w, int h, int x, int y, double *lx, double *ly)
{
    int ny = (int)fmax(1, floor((double)scale * h / w + 0.5));
    double tx = (x + 0.5) * scale / w, ty = (y + 0.5) * ny / h;
    *lx = 2 * (tx - floor(tx)) - 1;
    *ly = 2 * (ty - floor(ty)) - 1;
}

static void expect(const char *shape, int scale, int w, int h, double (*f)(double, double))
{
    char attrs[256];
    snprintf(attrs, sizeof attrs, "%s scale=\"%d\"", shape, scale);
    WgImage *img = gen("shape", attrs, w, h, 0, 2);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double lx, ly;
            local(scale, w, h, x, y, &lx, &ly);
            double want = f(lx, ly);
            if (!(fabs(gt_px(img, x, y) - want) <= 2e-5))
                fail_msg("%s at (%d,%d) [%.3f %.3f]: %.7g, want %.7g", attrs, x, y, lx, ly,
                         gt_px(img, x, y), want);
        }
    wg_image_unref(img);
}

static double smooth(double t)
{
    t = fmin(1, fmax(0, t));
    return t * t * (3 - 2 * t);
}
static double disk_hard(double x, double y)
{
    return x * x + y * y < 0.25 ? 1 : 0;
}
static double disk_soft(double x, double y)
{
    return smooth((0.8 - sqrt(x * x + y * y)) / 0.4);
}
static double square_hard(double x, double y)
{
    return fmax(fabs(x), fabs(y)) < 0.6 ? 1 : 0;
}
static double square_soft(double x, double y)
{
    return smooth((0.6 - fmax(fabs(x), fabs(y))) / 0.3);
}
/* hexagon, corner up, outer radius 0.9: inside distance = apothem − max projection on the
 * edge normals (at 30° + k·60° from up) */
static double hexagon_soft(double x, double y)
{
    double m = -1e9;
    for (int k = 0; k < 6; k++) {
        double a = M_PI / 6 + k * M_PI / 3;
        m = fmax(m, x * sin(a) - y * cos(a));
    }
    return smooth((0.9 * cos(M_PI / 6) - m) / (0.5 * 0.9));
}
/* square rotated by 45°: a diamond |x| + |y| < 0.6·√2 */
static double diamond_hard(double x, double y)
{
    return fabs(x) + fabs(y) < 0.6 * sqrt(2) ? 1 : 0;
}
/* a square of half side 1.3 overlaps its neighbours (centres 2 apart): inside when within
 * 1.3 (max norm) of the own centre or of a neighbour's */
static double big_square(double x, double y)
{
    for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++)
            if (fmax(fabs(x - 2 * i), fabs(y - 2 * j)) < 1.3) return 1;
    return 0;
}

static void test_exact(void **state)
{
    (void)state;
    expect("kind=\"disk\" radius=\"0.5\"", 1, 16, 16, disk_hard);
    expect("kind=\"disk\" radius=\"0.8\" falloff=\"0.5\"", 3, 48, 32, disk_soft);
    expect("kind=\"square\" radius=\"0.6\"", 2, 20, 20, square_hard);
    expect("kind=\"square\" radius=\"0.6\" falloff=\"0.5\"", 2, 40, 40, square_soft);
    expect("kind=\"polygon\" sides=\"6\" radius=\"0.9\" falloff=\"0.5\"", 1, 33, 33, hexagon_soft);
    expect("kind=\"square\" radius=\"0.6\" rotation=\"45\"", 1, 31, 31, diamond_hard);
    expect("kind=\"square\" radius=\"1.3\"", 2, 40, 40, big_square);
    /* star: full at the centre, 0 in the valleys between the points, 1 along a point */
    WgImage *img =
        gen("shape", "kind=\"star\" sides=\"5\" radius=\"1\" inner_radius=\"0.4\"", 101, 101, 0, 1);
    assert_float_equal(gt_px(img, 50, 50), 1, 0);
    assert_float_equal(gt_px(img, 50, 10), 1, 0); /* up: a point, radius 0.8 < 1 */
    assert_float_equal(gt_px(img, 50, 90), 0, 0); /* down: a valley (inner radius 0.4) */
    assert_float_equal(gt_px(img, 50, 65), 1, 0); /* down at radius 0.30 < 0.4: inside */
    assert_float_equal(gt_px(img, 50, 75), 0, 0); /* down at radius 0.50 > 0.4: outside */
    wg_image_unref(img);
}

static void test_tiling_symmetry_resolution_threads(void **state)
{
    (void)state;
    const char *cases[] = {
        "kind=\"disk\" radius=\"0.9\" falloff=\"1\" scale=\"3\"",
        "kind=\"star\" radius=\"1.6\" falloff=\"0.6\" scale=\"2\" rotation=\"17\"",
        "kind=\"square\" radius=\"1.2\" falloff=\"0.8\" scale=\"3\" rotation=\"30\"",
        "kind=\"polygon\" sides=\"7\" radius=\"1\" falloff=\"0.7\"",
    };
    for (int i = 0; i < 4; i++) {
        assert_tiles("shape", cases[i], 120, 120, 0, false);
        assert_tiles("shape", cases[i], 150, 100, 0, false);
        assert_subsample("shape", cases[i], 30, 24, 0, 2e-5);
        assert_thread_invariant("shape", cases[i], 0);
    }
    assert_downsample("shape", cases[0], 64, 4, 0, 0.003, 0.02);
    /* symmetries: a disk ignores rotation; a square turned 90° and a pentagon turned 72° are
     * themselves (up to float rounding at the outline) */
    WgImage *a = gen("shape", "kind=\"disk\" falloff=\"0.5\"", 40, 40, 0, 1);
    WgImage *b = gen("shape", "kind=\"disk\" falloff=\"0.5\" rotation=\"33\"", 40, 40, 0, 1);
    wgt_assert_near(a, b, 1e-6);
    wg_image_unref(a);
    wg_image_unref(b);
    a = gen("shape", "kind=\"polygon\" falloff=\"0.5\"", 40, 40, 0, 1);
    b = gen("shape", "kind=\"polygon\" falloff=\"0.5\" rotation=\"72\"", 40, 40, 0, 1);
    wgt_assert_near(a, b, 1e-4);
    wg_image_unref(a);
    wg_image_unref(b);
}

static void test_hard_cases(void **state)
{
    (void)state;
    assert_alloc_failures("shape", "kind=\"star\" scale=\"2\"", 0);
    assert_error_range("shape", "scale=\"0\"", "'scale' = 0 is outside");
    assert_error_range("shape", "radius=\"3\"", "radius");
    assert_error_range("shape", "sides=\"2\"", "sides");
    WgImage *img = gen("shape", "radius=\"0\" falloff=\"1\"", 16, 16, 0, 1);
    wgt_assert_range(img, 0, 0);
    wg_image_unref(img);
    img = gen("shape", "kind=\"star\" scale=\"4096\" radius=\"2\" sides=\"64\"", 64, 32, 0, 2);
    wgt_assert_range(img, 0, 1);
    wg_image_unref(img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact),
        cmocka_unit_test(test_tiling_symmetry_resolution_threads),
        cmocka_unit_test(test_hard_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
