/* SPDX-License-Identifier: MIT */
/* `levels`, `invert`, `grayscale`: exact small cases, a float64 reference for levels over a
 * grid of values and settings (mid-tone, inverted ranges, the in_low == in_high step, HDR
 * outputs), alpha passing through, gray inputs to colour ports, errors, thread invariance. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static WgImage *apply(const char *type, const char *attrs, const WgImage *src, int threads)
{
    const char *names[] = {"source"};
    const WgImage *imgs[] = {src};
    return wgt_node(type, attrs, src->width, src->height, 1, names, imgs, 0, threads);
}

/* x from -0.5 to 1.5 in steps of 1/32 along a row of 65 */
static double ramp_fn(int x, int y, int k)
{
    (void)y;
    (void)k;
    return -0.5 + x / 32.0;
}

/* ---- levels ------------------------------------------------------------------------------ */

typedef struct {
    double in_low, in_mid, in_high, out_low, out_high;
} Levels;

static double ref_levels(const Levels *p, double x)
{
    double t;
    if (p->in_high == p->in_low)
        t = x >= p->in_low ? 1 : 0;
    else
        t = (x - p->in_low) / (p->in_high - p->in_low);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    t = pow(t, log(0.5) / log(p->in_mid)); /* in_mid maps to 0.5 */
    return p->out_low + t * (p->out_high - p->out_low);
}

static void test_levels_default_is_identity_on_unit_range(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(65, 1, 1, ramp_fn);
    WgImage *out = apply("levels", "", src, 1);
    for (int x = 0; x < 65; x++) {
        double v = ramp_fn(x, 0, 0);
        float want = (float)(v < 0 ? 0 : v > 1 ? 1 : v);
        if (wgt_px(out, x, 0, 0) != want) fail_msg("x=%g -> %.9g", v, wgt_px(out, x, 0, 0));
    }
    wg_image_unref(out);
    wg_image_unref(src);
}

static void test_levels_against_reference(void **state)
{
    (void)state;
    static const Levels cases[] = {
        {0, 0.5, 1, 0, 1},
        {0.2, 0.5, 0.6, 0.1, 0.9},
        {0, 0.25, 1, 0, 1},
        {0, 0.8, 1, 0, 1},
        {0.1, 0.3, 0.9, 0, 1},
        {1, 0.5, 0, 0, 1}, /* inverted */
        {0.9, 0.7, 0.2, 0, 1},
        {0, 0.5, 1, 1, 0},
        {0.4, 0.5, 0.4, 0, 1}, /* step */
        {0.4, 0.2, 0.4, -2, 3},
        {-0.5, 0.5, 1.5, 0, 10},
        {0, 0.001, 1, 0, 1},
        {0, 0.999, 1, 0, 1},
        {0.25, 0.5, 0.75, -1e3, 1e3},
    };
    WgImage *src = wgt_image_fn(65, 1, 1, ramp_fn);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const Levels *p = &cases[i];
        char attrs[256];
        snprintf(attrs, sizeof attrs,
                 "in_low=\"%g\" in_mid=\"%g\" in_high=\"%g\" out_low=\"%g\" out_high=\"%g\"",
                 p->in_low, p->in_mid, p->in_high, p->out_low, p->out_high);
        WgImage *out = apply("levels", attrs, src, 2);
        /* the reference with the parameters as the node sees them (float) */
        Levels f = {(float)p->in_low, (float)p->in_mid, (float)p->in_high, (float)p->out_low,
                    (float)p->out_high};
        for (int x = 0; x < 65; x++) {
            double v = (float)ramp_fn(x, 0, 0);
            double want = ref_levels(&f, v);
            double got = wgt_px(out, x, 0, 0);
            double scale = fabs(f.out_high - f.out_low) + fabs(f.out_low);
            /* float powf near t = 0 with a large exponent: compare in absolute terms */
            if (!(fabs(got - want) <= 2e-6 * (1 + scale)))
                fail_msg("%s: x=%g -> %.9g, expected %.9g", attrs, v, got, want);
        }
        wg_image_unref(out);
    }
    wg_image_unref(src);
}

static void test_levels_exact_cases(void **state)
{
    (void)state;
    float px[] = {0.25f, 0.5f, 0.75f, 0.3999f, 0.4f, 2.0f};
    WgImage *src = wgt_image(6, 1, 1, px);
    /* mid-tone 0.25 maps to 0.5 (gamma 0.5: a square root) */
    WgImage *out = apply("levels", "in_mid=\"0.25\"", src, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.5f);
    assert_float_equal(wgt_px(out, 1, 0, 0), sqrt(0.5), 1e-7);
    assert_true(wgt_px(out, 5, 0, 0) == 1.0f);
    wg_image_unref(out);
    /* inverted range */
    out = apply("levels", "in_low=\"1\" in_high=\"0\"", src, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.75f);
    assert_true(wgt_px(out, 2, 0, 0) == 0.25f);
    assert_true(wgt_px(out, 5, 0, 0) == 0.0f);
    wg_image_unref(out);
    /* in_low == in_high: a hard step at that value, the value itself is above */
    out =
        apply("levels", "in_low=\"0.4\" in_high=\"0.4\" out_low=\"0.2\" out_high=\"0.7\"", src, 1);
    float step[] = {0.2f, 0.7f, 0.7f, 0.2f, 0.7f, 0.7f};
    for (int x = 0; x < 6; x++)
        if (fabs(wgt_px(out, x, 0, 0) - step[x]) > 1e-7)
            fail_msg("step x=%d: %.9g", x, wgt_px(out, x, 0, 0));
    wg_image_unref(out);
    /* output range remap: 0.5 -> 0.1 + 0.5 * 0.8 */
    out = apply("levels", "out_low=\"0.1\" out_high=\"0.9\"", src, 1);
    assert_float_equal(wgt_px(out, 1, 0, 0), 0.5, 1e-7);
    assert_float_equal(wgt_px(out, 0, 0, 0), 0.3, 1e-7);
    assert_float_equal(wgt_px(out, 5, 0, 0), 0.9, 1e-7);
    wg_image_unref(out);
    wg_image_unref(src);
}

static double colour_fn(int x, int y, int k)
{
    return k == 3 ? 0.3 + 0.1 * (x % 5) : fmod(0.17 * x + 0.31 * y + 0.23 * k, 1.3) - 0.1;
}

static void test_levels_on_colour_keeps_alpha(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(9, 4, 4, colour_fn);
    WgImage *out = apply("levels", "in_low=\"0.2\" in_high=\"0.8\" in_mid=\"0.4\"", src, 2);
    assert_int_equal(out->channels, 4);
    Levels p = {0.2f, 0.4f, 0.8f, 0, 1};
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 9; x++) {
            for (int k = 0; k < 3; k++)
                assert_float_equal(wgt_px(out, x, y, k), ref_levels(&p, wgt_px(src, x, y, k)),
                                   2e-6);
            assert_true(wgt_px(out, x, y, 3) == wgt_px(src, x, y, 3));
        }
    wg_image_unref(out);
    wg_image_unref(src);
}

static void test_levels_errors(void **state)
{
    (void)state;
    WgImage *g = wgt_image(2, 2, 1, NULL);
    const char *names[] = {"source"};
    const WgImage *imgs[] = {g};
    WgError err;
    assert_int_equal(wgt_node_error("levels", "in_mid=\"0\"", 2, 2, 1, names, imgs, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "in_mid"));
    assert_int_equal(wgt_node_error("levels", "in_mid=\"1\"", 2, 2, 1, names, imgs, &err),
                     WG_ERR_RANGE);
    assert_int_equal(wgt_node_error("levels", "out_high=\"=1/0\"", 2, 2, 1, names, imgs, &err),
                     WG_ERR_RANGE);
    assert_int_not_equal(wgt_node_error("levels", "gamma=\"2\"", 2, 2, 1, names, imgs, &err),
                         WG_OK);
    assert_non_null(strstr(err.message, "gamma"));
    assert_int_not_equal(wgt_node_error("levels", "", 2, 2, 0, names, imgs, &err), WG_OK);
    wg_image_unref(g);
}

/* ---- invert ------------------------------------------------------------------------------ */

static void test_invert(void **state)
{
    (void)state;
    float px[] = {0.0f, 1.0f, 0.25f, -2.0f, 5.0f, 1e6f};
    WgImage *src = wgt_image(6, 1, 1, px);
    WgImage *out = apply("invert", "", src, 1);
    assert_int_equal(out->channels, 1);
    for (int x = 0; x < 6; x++) assert_true(wgt_px(out, x, 0, 0) == 1.0f - px[x]);
    /* twice is the identity for these values */
    WgImage *back = apply("invert", "", out, 1);
    wgt_assert_identical(back, src);
    wg_image_unref(back);
    wg_image_unref(out);
    wg_image_unref(src);

    src = wgt_image_fn(9, 4, 4, colour_fn);
    out = apply("invert", "", src, 3);
    assert_int_equal(out->channels, 4);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 9; x++) {
            for (int k = 0; k < 3; k++)
                assert_true(wgt_px(out, x, y, k) == 1.0f - wgt_px(src, x, y, k));
            assert_true(wgt_px(out, x, y, 3) == wgt_px(src, x, y, 3));
        }
    wg_image_unref(out);
    wg_image_unref(src);
}

/* ---- grayscale --------------------------------------------------------------------------- */

static void test_grayscale(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(9, 4, 4, colour_fn);
    WgImage *out = apply("grayscale", "", src, 2);
    assert_int_equal(out->channels, 1);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 9; x++) {
            double want = 0.2126 * wgt_px(src, x, y, 0) + 0.7152 * wgt_px(src, x, y, 1) +
                          0.0722 * wgt_px(src, x, y, 2);
            assert_float_equal(wgt_px(out, x, y, 0), want, 1e-6);
        }
    wg_image_unref(out);

    /* weights are not normalised; alpha is ignored */
    float px[] = {0.5f, 0.25f, 0.125f, 0.0f, 1.0f, 2.0f, 4.0f, 0.5f};
    WgImage *two = wgt_image(2, 1, 4, px);
    out = apply("grayscale", "weights=\"1 0 0\"", two, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.5f);
    assert_true(wgt_px(out, 1, 0, 0) == 1.0f);
    wg_image_unref(out);
    out = apply("grayscale", "weights=\"0 0 1 1\"", two, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.125f);
    assert_true(wgt_px(out, 1, 0, 0) == 4.0f);
    wg_image_unref(out);
    out = apply("grayscale", "weights=\"1 2 4\"", two, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 1.5f);
    assert_true(wgt_px(out, 1, 0, 0) == 21.0f);
    wg_image_unref(out);
    wg_image_unref(two);

    /* a gray input is promoted (R = G = B): the weighted sum of v */
    float g[] = {0.5f, 1.0f};
    WgImage *gray = wgt_image(2, 1, 1, g);
    out = apply("grayscale", "weights=\"0.25 0.25 0.5\"", gray, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.5f);
    assert_true(wgt_px(out, 1, 0, 0) == 1.0f);
    wg_image_unref(out);
    out = apply("grayscale", "", gray, 1);
    assert_float_equal(wgt_px(out, 1, 0, 0), 1.0, 1e-6);
    wg_image_unref(out);
    wg_image_unref(gray);
    wg_image_unref(src);
}

static double rnd_fn(int x, int y, int k)
{
    return (wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k + 9) & 0xffffff) / (double)0xffffff;
}

static void test_thread_invariance(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(50, 141, 4, rnd_fn);
    static const char *const nodes[][2] = {
        {"levels", "in_low=\"0.1\" in_mid=\"0.33\" in_high=\"0.8\" out_high=\"2\""},
        {"invert", ""},
        {"grayscale", "weights=\"0.3 0.3 0.4\""},
    };
    for (int i = 0; i < 3; i++) {
        WgImage *a = apply(nodes[i][0], nodes[i][1], src, 1);
        WgImage *b = apply(nodes[i][0], nodes[i][1], src, 4);
        WgImage *c = apply(nodes[i][0], nodes[i][1], src, 7);
        wgt_assert_identical(a, b);
        wgt_assert_identical(a, c);
        wg_image_unref(c);
        wg_image_unref(b);
        wg_image_unref(a);
    }
    wg_image_unref(src);
}

static void test_flat_inputs(void **state)
{
    (void)state;
    WgImage *flat = wgt_image(5, 5, 1, NULL);
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 5; x++) wg_image_row(flat, y)[x] = 0.6f;
    WgImage *out = apply("levels", "in_low=\"0.2\" in_high=\"1\"", flat, 1);
    float v = wgt_px(out, 0, 0, 0);
    assert_float_equal(v, 0.5, 1e-7);
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 5; x++) assert_true(wgt_px(out, x, y, 0) == v);
    wg_image_unref(out);
    wg_image_unref(flat);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_levels_default_is_identity_on_unit_range),
        cmocka_unit_test(test_levels_against_reference),
        cmocka_unit_test(test_levels_exact_cases),
        cmocka_unit_test(test_levels_on_colour_keeps_alpha),
        cmocka_unit_test(test_levels_errors),
        cmocka_unit_test(test_invert),
        cmocka_unit_test(test_grayscale),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_flat_inputs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
