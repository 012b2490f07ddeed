/* SPDX-License-Identifier: MIT */
/* `threshold`: hard and soft steps, contrast 0 and 1, the ends of the position range, a float64
 * reference built from Substance's Histogram Scan graph, extremes, alpha, threads. */
#include "colortest.h"

static WgImage *run(float position, float contrast, const WgImage *in)
{
    char attrs[128];
    snprintf(attrs, sizeof attrs, "position=\"%.9g\" contrast=\"%.9g\"", position, contrast);
    return ct_source("threshold", attrs, in);
}

/* Substance's Histogram Scan (Levels with computed input points), Position = 1 - p. */
static double substance_scan(double x, double p, double c)
{
    double q = p; /* 1 - Position */
    double start_low = (fmax(q, 0.5) - 0.5) * 2, end_low = fmin(q * 2, 1);
    double w = fmin(fmax(c * 0.5, 0), 1);
    double in_low = start_low + (end_low - start_low) * w;
    double in_high = end_low + (start_low - end_low) * w;
    if (in_high <= in_low) return x >= in_low ? 1 : 0;
    return fmin(fmax((x - in_low) / (in_high - in_low), 0), 1);
}

static void test_hard_step(void **state)
{
    (void)state;
    float v[] = {-1e6f, 0, 0.49999997f, 0.5f, 0.50000006f, 1, 1e6f};
    WgImage *in = ct_row(1, 7, v);
    WgImage *out = ct_source("threshold", "", in); /* defaults: 0.5, contrast 1 */
    float want[] = {0, 0, 0, 1, 1, 1, 1};
    for (int i = 0; i < 7; i++) assert_true(wgt_px(out, i, 0, 0) == want[i]);
    wg_image_unref(out);
    wg_image_unref(in);

    float u[] = {0.2f, 0.29999998f, 0.3f, 0.8f};
    in = ct_row(1, 4, u);
    out = run(0.3f, 1, in);
    float want3[] = {0, 0, 1, 1};
    for (int i = 0; i < 4; i++) assert_true(wgt_px(out, i, 0, 0) == want3[i]);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_contrast_zero(void **state)
{
    (void)state;
    /* at position 0.5 contrast 0 is the identity on [0, 1], clamped outside */
    WgImage *in = ct_random_image(64, 4, 1, -0.5, 1.5, 9);
    WgImage *out = run(0.5f, 0, in);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 64; x++) {
            float v = wgt_px(in, x, y, 0);
            float want = v < 0 ? 0 : v > 1 ? 1 : v;
            assert_true(wgt_px(out, x, y, 0) == want);
        }
    wg_image_unref(out);
    /* at position 0.25 contrast 0 the ramp is [0, 0.5] */
    float v[] = {0, 0.125f, 0.25f, 0.5f, 0.75f};
    WgImage *in2 = ct_row(1, 5, v);
    out = run(0.25f, 0, in2);
    float want[] = {0, 0.25f, 0.5f, 1, 1};
    for (int i = 0; i < 5; i++) assert_float_equal(wgt_px(out, i, 0, 0), want[i], 1e-7);
    wg_image_unref(out);
    wg_image_unref(in2);
    wg_image_unref(in);
}

static void test_soft_step_exact(void **state)
{
    (void)state;
    /* p = 0.25, c = 0.5: half-width 0.5 * 0.25 = 0.125, ramp [0.125, 0.375] */
    float v[] = {0, 0.125f, 0.1875f, 0.25f, 0.3125f, 0.375f, 1};
    WgImage *in = ct_row(1, 7, v);
    WgImage *out = run(0.25f, 0.5f, in);
    float want[] = {0, 0, 0.25f, 0.5f, 0.75f, 1, 1};
    for (int i = 0; i < 7; i++) assert_true(wgt_px(out, i, 0, 0) == want[i]);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_position_ends(void **state)
{
    (void)state;
    float v[] = {-1, -1e-30f, 0, 0.5f, 0.99999994f, 1, 2};
    WgImage *in = ct_row(1, 7, v);
    for (int c = 0; c <= 2; c++) {
        WgImage *out = run(0, c * 0.5f, in);
        float want0[] = {0, 0, 1, 1, 1, 1, 1};
        for (int i = 0; i < 7; i++) assert_true(wgt_px(out, i, 0, 0) == want0[i]);
        wg_image_unref(out);
        out = run(1, c * 0.5f, in);
        float want1[] = {0, 0, 0, 0, 0, 1, 1};
        for (int i = 0; i < 7; i++) assert_true(wgt_px(out, i, 0, 0) == want1[i]);
        wg_image_unref(out);
    }
    wg_image_unref(in);
}

static void test_matches_substance(void **state)
{
    (void)state;
    int w = 512;
    WgImage *in = wg_image_new(w, 1, 1);
    for (int i = 0; i < w; i++) wg_image_row(in, 0)[i] = (float)(-0.1 + 1.2 * i / (w - 1));
    float ps[] = {0, 0.1f, 0.25f, 0.4f, 0.5f, 0.6f, 0.77f, 0.9f, 1};
    float cs[] = {0, 0.2f, 0.5f, 0.8f, 0.99f, 1};
    for (size_t a = 0; a < sizeof ps / sizeof ps[0]; a++)
        for (size_t b = 0; b < sizeof cs / sizeof cs[0]; b++) {
            WgImage *out = run(ps[a], cs[b], in);
            for (int i = 0; i < w; i++) {
                double x = wg_image_row(in, 0)[i];
                double ref = substance_scan(x, ps[a], cs[b]);
                double got = wgt_px(out, i, 0, 0);
                /* the two formulas round differently; near a hard step the reference's in_low
                 * may land one double ulp from p, so compare away from the step itself */
                if (fabs(got - ref) > 1e-6 && fabs(x - ps[a]) > 1e-6)
                    fail_msg("p=%g c=%g x=%.9g: %.9g, Substance %.9g", ps[a], cs[b], x, got, ref);
            }
            wg_image_unref(out);
        }
    wg_image_unref(in);
}

static void test_extremes_and_alpha(void **state)
{
    (void)state;
    float v[] = {-3e38f, 0.4f, 3e38f, 0.25f, NAN, INFINITY, -INFINITY, 1e6f};
    WgImage *in = ct_row(4, 8, v);
    WgImage *out = run(0.5f, 0.5f, in);
    float want[] = {0, 0.3f, 1, 0.25f, 0, 1, 0, 1e6f};
    for (int i = 0; i < 8; i++) assert_float_equal(wgt_px(out, i / 4, 0, i % 4), want[i], 1e-7);
    assert_true(wgt_px(out, 0, 0, 3) == 0.25f && wgt_px(out, 1, 0, 3) == 1e6f);
    ct_assert_finite(out);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_out_of_range_params(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(4, 4, 1, 0, 1, 1);
    WgError err;
    const char *names[] = {"source"};
    const WgImage *images[] = {in};
    assert_int_equal(wgt_node_error("threshold", "contrast=\"1.5\"", 4, 4, 1, names, images, &err),
                     WG_ERR_RANGE);
    assert_int_equal(wgt_node_error("threshold", "position=\"-0.1\"", 4, 4, 1, names, images, &err),
                     WG_ERR_RANGE);
    wg_image_unref(in);
}

static void test_threads(void **state)
{
    (void)state;
    ct_assert_thread_invariant("threshold", "position=\"0.4\" contrast=\"0.3\"", "source", 1, -0.5,
                               1.5);
    ct_assert_thread_invariant("threshold", "position=\"0.4\" contrast=\"0.3\"", "source", 4, -0.5,
                               1.5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hard_step),           cmocka_unit_test(test_contrast_zero),
        cmocka_unit_test(test_soft_step_exact),     cmocka_unit_test(test_position_ends),
        cmocka_unit_test(test_matches_substance),   cmocka_unit_test(test_extremes_and_alpha),
        cmocka_unit_test(test_out_of_range_params), cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
