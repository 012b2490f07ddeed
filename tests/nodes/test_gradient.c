/* SPDX-License-Identifier: MIT */
/* `gradient`: exact values for each kind and repeat mode, tiling where documented (linear
 * repeat/mirror, radial) and the documented non-tiling cases as negative controls for the
 * tiling checks, resolution independence and threads. */
#include "gentest.h"

static double mirror2(double s)
{
    double m = s - 2 * floor(s / 2);
    return 1 - fabs(1 - m);
}

static void expect(const char *attrs, int w, int h, double (*f)(double u, double v, double a))
{
    WgImage *img = gen("gradient", attrs, w, h, 0, 2);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double want = f((x + 0.5) / w, (y + 0.5) / h, (double)h / w);
            if (!(fabs(gt_px(img, x, y) - want) <= 1e-5))
                fail_msg("%s %dx%d at (%d,%d): %.7g, want %.7g", attrs, w, h, x, y,
                         gt_px(img, x, y), want);
        }
    wg_image_unref(img);
}

static double lin0(double u, double v, double a)
{
    (void)v;
    (void)a;
    return u;
}
static double lin90(double u, double v, double a)
{
    (void)u;
    (void)a;
    return v;
}
static double lin180(double u, double v, double a)
{
    (void)v;
    (void)a;
    return 1 - u;
}
static double lin45(double u, double v, double a)
{
    return (u + v * a) / (1 + a);
}
static double lin_count2(double u, double v, double a)
{
    (void)v;
    (void)a;
    return fmin(1, 2 * u);
}
static double rep3(double u, double v, double a)
{
    (void)v;
    (void)a;
    return 3 * u - floor(3 * u);
}
static double mir1(double u, double v, double a)
{
    (void)v;
    (void)a;
    return mirror2(2 * u);
}
/* angle 45, count 2 on a square: wave vector (1.41, 1.41) rounds to (1, 1) */
static double rep_diag(double u, double v, double a)
{
    (void)a;
    return u + v - floor(u + v);
}
static double radial(double u, double v, double a)
{
    double dx = u - 0.25, dy = v - 0.5;
    dx -= floor(dx + 0.5);
    dy = (dy - floor(dy + 0.5)) * a;
    return fmin(1, sqrt(dx * dx + dy * dy) / 0.4);
}
static double radial_mirror(double u, double v, double a)
{
    double dx = u - 0.5, dy = (v - 0.5) * a;
    return mirror2(sqrt(dx * dx + dy * dy) / 0.1);
}
static double angular(double u, double v, double a)
{
    double t = atan2((v - 0.5) * a, u - 0.5) / (2 * M_PI) - 90.0 / 360;
    return t - floor(t);
}

static void test_exact_values(void **state)
{
    (void)state;
    expect("angle=\"0\"", 8, 3, lin0);
    expect("angle=\"90\"", 3, 8, lin90);
    expect("angle=\"180\"", 8, 2, lin180);
    expect("angle=\"45\"", 10, 6, lin45);
    expect("angle=\"0\" count=\"2\"", 8, 2, lin_count2);
    expect("angle=\"0\" count=\"3\" repeat=\"repeat\"", 12, 3, rep3);
    expect("angle=\"0\" count=\"1\" repeat=\"mirror\"", 12, 3, mir1);
    expect("angle=\"45\" count=\"2\" repeat=\"repeat\"", 16, 16, rep_diag);
    expect("kind=\"radial\" center_x=\"0.25\" radius=\"0.4\"", 20, 12, radial);
    expect("kind=\"radial\" repeat=\"mirror\" radius=\"0.1\"", 16, 16, radial_mirror);
    expect("kind=\"angular\" angle=\"90\" repeat=\"repeat\"", 9, 9, angular);
    /* centre pixel of odd sizes: radial 0 */
    WgImage *img = gen("gradient", "kind=\"radial\"", 9, 9, 0, 1);
    assert_float_equal(gt_px(img, 4, 4), 0, 0);
    wg_image_unref(img);
}

static void test_tiling(void **state)
{
    (void)state;
    const char *tiling[] = {
        "angle=\"0\" count=\"2\" repeat=\"mirror\"",
        "angle=\"30\" count=\"3\" repeat=\"mirror\"",
        "angle=\"135\" count=\"2\" repeat=\"mirror\"",
        "kind=\"radial\" radius=\"0.2\" repeat=\"mirror\" center_x=\"0.3\" center_y=\"0.6\"",
        "kind=\"radial\" radius=\"0.3\" center_x=\"0.1\"",
    };
    for (int i = 0; i < 5; i++) {
        assert_tiles("gradient", tiling[i], 96, 96, 0, false);
        assert_tiles("gradient", tiling[i], 120, 72, 0, false);
    }
    /* repeat: a sawtooth, so jumps inside too; check exact periodicity of the phase instead:
     * the value at the wrap continues the interior ramp step */
    WgImage *img = gen("gradient", "angle=\"0\" count=\"2\" repeat=\"repeat\"", 64, 8, 0, 1);
    for (int y = 0; y < 8; y++) {
        double step = gt_px(img, 1, y) - gt_px(img, 0, y);
        double wrap = gt_px(img, 0, y) - gt_px(img, 63, y) + 1; /* wraps through a sawtooth drop */
        assert_float_equal(wrap, step, 1e-6);
    }
    wg_image_unref(img);
    /* documented as not tiling: they fail the checks (negative controls for gentest.h) */
    WgImage *a = gen("gradient", "angle=\"20\"", 64, 64, 0, 1);
    assert_true(wrap_jump_ratio(a) > 10);
    wg_image_unref(a);
    /* angular jumps where the nearest copy of the centre changes: the wrap jump does not
     * shrink when sampled 3x finer (interior jumps near the centre hide it from the ratio) */
    a = gen("gradient", "kind=\"angular\" repeat=\"mirror\"", 64, 64, 0, 1);
    WgImage *b = gen("gradient", "kind=\"angular\" repeat=\"mirror\"", 192, 192, 0, 1);
    double j1, k1, j3, k3;
    wrap_diffs(a, &j1, &k1);
    wrap_diffs(b, &j3, &k3);
    assert_true(j1 > 0.5 && j3 > 0.6 * j1);
    wg_image_unref(a);
    wg_image_unref(b);
}

static void test_resolution_and_threads(void **state)
{
    (void)state;
    const char *cases[] = {
        "angle=\"30\" count=\"3\" repeat=\"mirror\"",
        "kind=\"radial\" radius=\"0.2\" repeat=\"repeat\"",
        "kind=\"angular\" angle=\"10\" count=\"2\"",
        "angle=\"-60\"",
    };
    for (int i = 0; i < 4; i++) {
        assert_subsample("gradient", cases[i], 30, 20, 0, 1e-5);
        assert_thread_invariant("gradient", cases[i], 0);
    }
    /* the triangle wave's peaks are kinks: a 4x4 box there loses up to ~0.03 */
    assert_downsample("gradient", cases[0], 64, 4, 0, 0.002, 0.03);
}

static void test_hard_cases(void **state)
{
    (void)state;
    assert_alloc_failures("gradient", "kind=\"radial\"", 0);
    assert_error_range("gradient", "radius=\"0\"", "radius");
    assert_error_range("gradient", "center_x=\"2\"", "center_x");
    /* a count too small to round to a whole period: flat 0 */
    WgImage *img = gen("gradient", "angle=\"0\" count=\"0.3\" repeat=\"repeat\"", 8, 8, 0, 1);
    wgt_assert_range(img, 0, 0);
    wg_image_unref(img);
    img = gen("gradient", "angle=\"33\" count=\"16384\" repeat=\"mirror\"", 64, 1, 0, 1);
    wgt_assert_range(img, 0, 1);
    wg_image_unref(img);
    img = gen("gradient", "kind=\"radial\" radius=\"1e-6\"", 1, 1, 0, 1);
    wgt_assert_range(img, 0, 1);
    wg_image_unref(img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_values),
        cmocka_unit_test(test_tiling),
        cmocka_unit_test(test_resolution_and_threads),
        cmocka_unit_test(test_hard_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
