/* SPDX-License-Identifier: MIT */
/* `curve`: exact values, a float64 Fritsch–Carlson reference, monotonicity and no overshoot,
 * one point, unordered points, malformed points, extremes, colour, threads. */
#include "colortest.h"

/* ---- float64 reference (written from the Fritsch–Carlson recipe, independently of the node) */

typedef struct {
    int n;
    double x[64], y[64], m[64];
} RefCurve;

static void ref_build(RefCurve *c, int n, const double *x, const double *y)
{
    c->n = n;
    /* selection sort by x */
    int idx[64];
    for (int i = 0; i < n; i++) idx[i] = i;
    for (int i = 0; i < n; i++)
        for (int j = i + 1; j < n; j++)
            if (x[idx[j]] < x[idx[i]]) {
                int t = idx[i];
                idx[i] = idx[j];
                idx[j] = t;
            }
    for (int i = 0; i < n; i++) c->x[i] = x[idx[i]], c->y[i] = y[idx[i]];
    if (n == 1) return;
    double d[64];
    for (int i = 0; i + 1 < n; i++) d[i] = (c->y[i + 1] - c->y[i]) / (c->x[i + 1] - c->x[i]);
    for (int i = 0; i < n; i++) {
        if (i == 0)
            c->m[i] = d[0];
        else if (i == n - 1)
            c->m[i] = d[n - 2];
        else if (d[i - 1] * d[i] <= 0)
            c->m[i] = 0;
        else
            c->m[i] = (d[i - 1] + d[i]) / 2;
    }
    for (int i = 0; i + 1 < n; i++) {
        if (d[i] == 0) {
            c->m[i] = c->m[i + 1] = 0;
            continue;
        }
        double a = c->m[i] / d[i], b = c->m[i + 1] / d[i];
        if (a * a + b * b > 9) {
            double tau = 3 / sqrt(a * a + b * b);
            c->m[i] = tau * a * d[i];
            c->m[i + 1] = tau * b * d[i];
        }
    }
}

static double ref_eval(const RefCurve *c, double x)
{
    if (x <= c->x[0]) return c->y[0];
    if (x >= c->x[c->n - 1]) return c->y[c->n - 1];
    int k = 0;
    while (c->x[k + 1] <= x) k++;
    double h = c->x[k + 1] - c->x[k], t = (x - c->x[k]) / h;
    /* Bernstein form of the same cubic */
    double p0 = c->y[k], p1 = c->y[k] + h * c->m[k] / 3, p2 = c->y[k + 1] - h * c->m[k + 1] / 3,
           p3 = c->y[k + 1], u = 1 - t;
    return u * u * u * p0 + 3 * u * u * t * p1 + 3 * u * t * t * p2 + t * t * t * p3;
}

static void points_text(char *buf, size_t size, int n, const double *x, const double *y)
{
    size_t l = 0;
    buf[0] = '\0';
    for (int i = 0; i < n; i++)
        l += (size_t)snprintf(buf + l, size - l, "%s%.17g:%.17g", i ? " " : "", x[i], y[i]);
}

static WgImage *run_curve(const char *points, const WgImage *in)
{
    char attrs[8192];
    snprintf(attrs, sizeof attrs, "points=\"%s\"", points);
    return ct_source("curve", attrs, in);
}

/* ---- tests -------------------------------------------------------------------------------- */

static void test_default_is_identity(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(64, 16, 1, 0, 1, 1);
    WgImage *out = ct_source("curve", "", in);
    wgt_assert_identical(in, out);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_exact_values(void **state)
{
    (void)state;
    /* at the control points, outside them, and one hand-computed interior value:
     * points 0:0 1:1 2:0 give tangents 1, 0, -1, so at x = 0.5:
     * h10·1 + h01·1 = 0.125 + 0.5 = 0.625 */
    float v[] = {-1e6f, -0.5f, 0, 0.5f, 1, 1.5f, 2, 3, 1e6f};
    WgImage *in = ct_row(1, 9, v);
    WgImage *out = run_curve("0:0 1:1 2:0", in);
    float want[] = {0, 0, 0, 0.625f, 1, 0.625f, 0, 0, 0};
    for (int i = 0; i < 9; i++) assert_float_equal(wgt_px(out, i, 0, 0), want[i], 0);
    wg_image_unref(out);

    out = run_curve("0.25:0.1 0.75:0.9", in);
    float want2[] = {0.1f, 0.1f, 0.1f, 0.5f, 0.9f, 0.9f, 0.9f, 0.9f, 0.9f};
    for (int i = 0; i < 9; i++) assert_float_equal(wgt_px(out, i, 0, 0), want2[i], 1e-7);
    assert_true(wgt_px(out, 0, 0, 0) == 0.1f && wgt_px(out, 8, 0, 0) == 0.9f);
    wg_image_unref(out);
    wg_image_unref(in);

    /* knots hit exactly: 0.25 -> 0.125 */
    float k[] = {0, 0.25f, 1};
    in = ct_row(1, 3, k);
    out = run_curve("0:0 0.25:0.125 1:1", in);
    assert_true(wgt_px(out, 0, 0, 0) == 0.0f);
    assert_true(wgt_px(out, 1, 0, 0) == 0.125f);
    assert_true(wgt_px(out, 2, 0, 0) == 1.0f);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void compare_with_reference(int n, const double *x, const double *y, double lo, double hi)
{
    char points[4096];
    points_text(points, sizeof points, n, x, y);
    RefCurve rc;
    ref_build(&rc, n, x, y);
    int w = 1024;
    WgImage *in = wg_image_new(w, 4, 1);
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < w; i++)
            wg_image_row(in, j)[i] = (float)(lo + (hi - lo) * (i + j / 4.0) / w);
    WgImage *out = run_curve(points, in);
    double worst = 0;
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < w; i++) {
            double ref = ref_eval(&rc, wg_image_row(in, j)[i]);
            double got = wg_image_row(out, j)[i];
            double err = fabs(got - ref) / fmax(1.0, fabs(ref));
            if (!(err <= worst)) worst = err;
        }
    /* one rounding to float (6e-8) plus double noise */
    if (!(worst <= 1.2e-7))
        fail_msg("curve '%s': max relative error %.3g vs float64", points, worst);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_float64_reference(void **state)
{
    (void)state;
    /* a tangent-limiting case: the steep second segment forces the Fritsch–Carlson rescale */
    double x1[] = {0, 1, 2}, y1[] = {0, 0.01, 1};
    compare_with_reference(3, x1, y1, -0.5, 2.5);
    double x2[] = {0, 0.3, 1}, y2[] = {0, 0.1, 1};
    compare_with_reference(3, x2, y2, -0.1, 1.1);
    /* flat segments and a local extremum */
    double x3[] = {0, 0.2, 0.4, 0.6, 0.8, 1}, y3[] = {0, 0.5, 0.5, 1, 0.2, 0.3};
    compare_with_reference(6, x3, y3, -0.1, 1.1);
    /* random point sets, monotone or not, HDR values */
    uint64_t s = 42;
    for (int trial = 0; trial < 40; trial++) {
        int n = 2 + (int)(ct_rand(&s) * 12);
        double x[64], y[64];
        for (int i = 0; i < n; i++) {
            x[i] = ct_rand(&s) * 4 - 1;
            y[i] = trial % 2 ? ct_rand(&s) : ct_rand(&s) * 200 - 100;
        }
        compare_with_reference(n, x, y, -1.5, 3.5);
    }
}

static void test_monotone_no_overshoot(void **state)
{
    (void)state;
    uint64_t s = 7;
    int w = 4096;
    WgImage *in = wg_image_new(w, 1, 1);
    for (int i = 0; i < w; i++) wg_image_row(in, 0)[i] = (float)(-0.2 + 1.4 * i / (w - 1));
    for (int trial = 0; trial < 30; trial++) {
        /* increasing control points with wildly uneven steps */
        int n = 2 + trial % 9;
        double x[64], y[64], xa = 0, ya = 0;
        for (int i = 0; i < n; i++) {
            xa += 0.001 + ct_rand(&s) * (i % 3 ? 0.01 : 1);
            ya += (trial % 3 == 0 && i % 2) ? 0 : ct_rand(&s) * ct_rand(&s) * 3;
            x[i] = xa, y[i] = ya;
        }
        for (int i = 0; i < n; i++) x[i] /= xa; /* span [~0, 1] */
        char points[4096];
        points_text(points, sizeof points, n, x, y);
        WgImage *out = run_curve(points, in);
        const float *o = wg_image_row(out, 0);
        for (int i = 1; i < w; i++)
            if (o[i] < o[i - 1])
                fail_msg("'%s' decreases at %d: %g -> %g", points, i, o[i - 1], o[i]);
        for (int i = 0; i < w; i++)
            if (o[i] < (float)y[0] || o[i] > (float)y[n - 1])
                fail_msg("'%s' overshoots: %g outside [%g, %g]", points, o[i], y[0], y[n - 1]);
        wg_image_unref(out);
    }
    /* non-monotone points: each segment stays between its two end values */
    double x[] = {0, 0.25, 0.5, 0.75, 1}, y[] = {0, 1, 0.1, 0.9, 0.5};
    char points[512];
    points_text(points, sizeof points, 5, x, y);
    WgImage *out = run_curve(points, in);
    for (int i = 0; i < w; i++) {
        double xi = wg_image_row(in, 0)[i];
        float v = wg_image_row(out, 0)[i];
        int k = xi <= 0 ? 0 : xi >= 1 ? 3 : (int)(xi * 4);
        if (k > 3) k = 3;
        double a = xi <= 0 ? y[0] : xi >= 1 ? y[4] : fmin(y[k], y[k + 1]);
        double b = xi <= 0 ? y[0] : xi >= 1 ? y[4] : fmax(y[k], y[k + 1]);
        if (v < (float)a || v > (float)b) fail_msg("x=%g: %g outside [%g, %g]", xi, v, a, b);
    }
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_one_point_is_constant(void **state)
{
    (void)state;
    float v[] = {-1e6f, -1, 0, 0.3f, 0.5f, 1, 1e6f, 3e38f};
    WgImage *in = ct_row(1, 8, v);
    WgImage *out = run_curve("0.3:0.7", in);
    for (int i = 0; i < 8; i++) assert_true(wgt_px(out, i, 0, 0) == 0.7f);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_points_in_any_order(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(128, 4, 1, -0.2, 1.2, 3);
    WgImage *a = run_curve("0:0 0.3:0.1 0.6:0.8 1:1", in);
    WgImage *b = run_curve("  0.6:0.8\t1:1 0:0\n0.3:0.1 ", in);
    wgt_assert_identical(a, b);
    wg_image_unref(a);
    wg_image_unref(b);
    wg_image_unref(in);
}

static void test_malformed_points(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(4, 4, 1, 0, 1, 1);
    ct_fails("curve", "points=\"0:0 0.5 1:1\"", in, WG_ERR_PARSE, "point 2 '0.5' is not 'x:y'");
    ct_fails("curve", "points=\"0:0 a:1\"", in, WG_ERR_PARSE, "point 2 'a:1'");
    ct_fails("curve", "points=\"0:0 1:\"", in, WG_ERR_PARSE, "point 2 '1:'");
    ct_fails("curve", "points=\"0:0 1:1:1\"", in, WG_ERR_PARSE, "point 2 '1:1:1'");
    ct_fails("curve", "points=\"0:0,1:1\"", in, WG_ERR_PARSE, "'0:0,1:1'");
    ct_fails("curve", "points=\"0: 1\"", in, WG_ERR_PARSE, "point 1 '0:'");
    ct_fails("curve", "points=\"\"", in, WG_ERR_PARSE, "at least one point");
    ct_fails("curve", "points=\"   \"", in, WG_ERR_PARSE, "at least one point");
    ct_fails("curve", "points=\"0:0 0.5:1 0.5:0.2\"", in, WG_ERR_RANGE, "two points at x = 0.5");
    /* numbers follow the file's rules: decimal, finite, no hex */
    ct_fails("curve", "points=\"0:nan\"", in, WG_ERR_PARSE, "point 1 '0:nan' is not 'x:y'");
    ct_fails("curve", "points=\"inf:0\"", in, WG_ERR_PARSE, "point 1 'inf:0'");
    ct_fails("curve", "points=\"0x1:0\"", in, WG_ERR_PARSE, "point 1 '0x1:0'");
    ct_fails("curve", "points=\"0:1e999\"", in, WG_ERR_PARSE, "point 1 '0:1e999'");
    ct_fails("curve", "points=\"0:0 1:1e39\"", in, WG_ERR_RANGE,
             "point 2 '1:1e39' is not a finite float");
    char many[8192];
    size_t l = 0;
    for (int i = 0; i < 300; i++) l += (size_t)snprintf(many + l, sizeof many - l, "%d:0 ", i);
    char attrs[8300];
    snprintf(attrs, sizeof attrs, "points=\"%s\"", many);
    ct_fails("curve", attrs, in, WG_ERR_RANGE, "more than 256 points");
    wg_image_unref(in);
}

static void test_colour_keeps_alpha(void **state)
{
    (void)state;
    float v[] = {0, 0.5f, 1, 0.25f, 2, -1, 0.5f, 7};
    WgImage *in = ct_row(4, 8, v);
    WgImage *out = run_curve("0:1 1:0", in); /* a straight line: 1 - x on [0, 1] */
    float want[] = {1, 0.5f, 0, 0.25f, 0, 1, 0.5f, 7};
    for (int i = 0; i < 8; i++) assert_float_equal(wgt_px(out, i / 4, 0, i % 4), want[i], 1e-7);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_extremes_never_nan(void **state)
{
    (void)state;
    float v[] = {-3e38f, -1e6f, -1e-30f, 0, 1e-30f, 0.5f, 1, 1e6f, 3e38f, INFINITY, -INFINITY, NAN};
    WgImage *in = ct_row(1, 12, v);
    WgImage *out = run_curve("0:0 0.2:0.9 1:1", in);
    ct_assert_finite(out);
    assert_true(wgt_px(out, 11, 0, 0) == 0.0f); /* NaN -> first y */
    assert_true(wgt_px(out, 9, 0, 0) == 1.0f);
    assert_true(wgt_px(out, 10, 0, 0) == 0.0f);
    wg_image_unref(out);
    /* huge control values and spans */
    out = run_curve("-3e38:-3e38 0:0 1e-30:1e-30 3e38:3e38", in);
    ct_assert_finite(out);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_threads(void **state)
{
    (void)state;
    ct_assert_thread_invariant("curve", "points=\"0:0 0.3:0.1 0.7:0.95 1:1\"", "source", 1, -0.2,
                               1.2);
    ct_assert_thread_invariant("curve", "points=\"0:0 0.3:0.1 0.7:0.95 1:1\"", "source", 4, -0.2,
                               1.2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_is_identity),   cmocka_unit_test(test_exact_values),
        cmocka_unit_test(test_float64_reference),     cmocka_unit_test(test_monotone_no_overshoot),
        cmocka_unit_test(test_one_point_is_constant), cmocka_unit_test(test_points_in_any_order),
        cmocka_unit_test(test_malformed_points),      cmocka_unit_test(test_colour_keeps_alpha),
        cmocka_unit_test(test_extremes_never_nan),    cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
