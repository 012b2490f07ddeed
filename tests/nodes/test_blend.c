/* SPDX-License-Identifier: MIT */
/* `blend`: all 12 modes against a float64 reference over a grid of (A, B) values, with opacity
 * and a mask, clamped and HDR; gray and colour mixing and alpha; empty and full masks; extreme
 * values; errors; thread-count invariance. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static const char *const modes[] = {"copy",    "add",     "subtract", "multiply",
                                    "add_sub", "max",     "min",      "switch",
                                    "divide",  "overlay", "screen",   "soft_light"};
enum { N_MODES = 12 };

/* f(A, B) per the node's documentation, in double. */
static double ref_mode(int mode, double a, double b)
{
    switch (mode) {
    case 0:
        return a;
    case 1:
        return b + a;
    case 2:
        return b - a;
    case 3:
        return a * b;
    case 4:
        return b + 2 * a - 1;
    case 5:
        return a > b ? a : b;
    case 6:
        return a < b ? a : b;
    case 8:
        return b / (a > 0x1p-16 ? a : 0x1p-16);
    case 9:
        return b < 0.5 ? 2 * a * b : 1 - 2 * (1 - a) * (1 - b);
    case 10:
        return 1 - (1 - a) * (1 - b);
    case 11: {
        /* W3C compositing spec, soft-light */
        if (a <= 0.5) return b - (1 - 2 * a) * b * (1 - b);
        double d = b <= 0.25 ? ((16 * b - 12) * b + 4) * b : sqrt(b);
        return b + (2 * a - 1) * (d - b);
    }
    }
    return NAN;
}

/* One channel of the blend; t is opacity * mask as the node computes it (float). */
static double ref_blend(int mode, double a, double b, float t, bool clamp, bool alpha)
{
    double v;
    if (mode == 7)
        v = t >= 0.5f ? a : b;
    else if (alpha)
        v = b + (a - b) * t;
    else
        v = b + (ref_mode(mode, a, b) - b) * t;
    if (clamp) v = v < 0 ? 0 : v > 1 ? 1 : v;
    return v;
}

static const float grid[] = {-0.5f, 0.0f, 0.1f, 0.25f, 0.4f, 0.5f, 0.6f, 0.75f, 0.9f, 1.0f, 1.5f};
enum { N_GRID = 11 };

static double fg_fn(int x, int y, int k)
{
    (void)y;
    (void)k;
    return grid[x];
}

static double bg_fn(int x, int y, int k)
{
    (void)x;
    (void)k;
    return grid[y];
}

static double mask_fn(int x, int y, int k)
{
    (void)k;
    return ((x * 3 + y * 5) % 11) / 10.0;
}

static WgImage *blend(const char *attrs, const WgImage *fg, const WgImage *bg, const WgImage *mask,
                      int threads)
{
    const char *names[] = {"foreground", "background", "mask"};
    const WgImage *imgs[] = {fg, bg, mask};
    return wgt_node("blend", attrs, fg->width, fg->height, mask ? 3 : 2, names, imgs, 0, threads);
}

static double tol(double ref)
{
    return 3e-6 * (1 + fabs(ref));
}

static void check_grid(int mode, float opacity, bool clamp, bool with_mask)
{
    WgImage *fg = wgt_image_fn(N_GRID, N_GRID, 1, fg_fn);
    WgImage *bg = wgt_image_fn(N_GRID, N_GRID, 1, bg_fn);
    WgImage *mask = with_mask ? wgt_image_fn(N_GRID, N_GRID, 1, mask_fn) : NULL;
    char attrs[128];
    snprintf(attrs, sizeof attrs, "mode=\"%s\" opacity=\"%g\" clamp=\"%s\"", modes[mode], opacity,
             clamp ? "true" : "false");
    WgImage *out = blend(attrs, fg, bg, mask, 2);
    assert_int_equal(out->channels, 1);
    for (int y = 0; y < N_GRID; y++)
        for (int x = 0; x < N_GRID; x++) {
            float t = opacity * (mask ? wgt_px(mask, x, y, 0) : 1.0f);
            double want = ref_blend(mode, grid[x], grid[y], t, clamp, false);
            double got = wgt_px(out, x, y, 0);
            if (!(fabs(got - want) <= tol(want)))
                fail_msg("%s: A=%g B=%g t=%g: %.9g, expected %.9g", attrs, grid[x], grid[y], t, got,
                         want);
        }
    wg_image_unref(out);
    wg_image_unref(mask);
    wg_image_unref(bg);
    wg_image_unref(fg);
}

static void test_modes_against_reference(void **state)
{
    (void)state;
    static const float opacities[] = {1.0f, 0.6f, 0.5f, 0.0f};
    for (int m = 0; m < N_MODES; m++)
        for (int o = 0; o < 4; o++)
            for (int clamp = 0; clamp < 2; clamp++)
                for (int mask = 0; mask < 2; mask++) check_grid(m, opacities[o], clamp, mask);
}

static void test_exact_small_cases(void **state)
{
    (void)state;
    /* hand-computed values, opacity 1, no mask */
    struct {
        const char *mode;
        float a, b, want;
    } cases[] = {
        {"copy", 0.3f, 0.8f, 0.3f},        {"add", 0.25f, 0.5f, 0.75f},
        {"add", 0.75f, 0.5f, 1.0f},        {"subtract", 0.25f, 0.5f, 0.25f},
        {"subtract", 0.75f, 0.5f, 0.0f},   {"multiply", 0.5f, 0.5f, 0.25f},
        {"add_sub", 0.75f, 0.5f, 1.0f},    {"add_sub", 0.25f, 0.5f, 0.0f},
        {"add_sub", 0.5f, 0.25f, 0.25f},   {"max", 0.25f, 0.5f, 0.5f},
        {"min", 0.25f, 0.5f, 0.25f},       {"switch", 0.25f, 0.5f, 0.25f},
        {"divide", 0.5f, 0.25f, 0.5f},     {"divide", 0.0f, 0.0f, 0.0f},
        {"divide", 0.0f, 0.5f, 1.0f},      {"overlay", 0.5f, 0.25f, 0.25f},
        {"overlay", 0.25f, 0.75f, 0.625f}, {"screen", 0.5f, 0.5f, 0.75f},
        {"soft_light", 0.5f, 0.3f, 0.3f},  {"soft_light", 1.0f, 0.25f, 0.5f},
        {"soft_light", 0.0f, 0.5f, 0.25f},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        WgImage *fg = wgt_image(1, 1, 1, &cases[i].a), *bg = wgt_image(1, 1, 1, &cases[i].b);
        char attrs[64];
        snprintf(attrs, sizeof attrs, "mode=\"%s\"", cases[i].mode);
        WgImage *out = blend(attrs, fg, bg, NULL, 1);
        if (wgt_px(out, 0, 0, 0) != cases[i].want)
            fail_msg("%s(%g, %g) = %.9g, expected %.9g", cases[i].mode, cases[i].a, cases[i].b,
                     wgt_px(out, 0, 0, 0), cases[i].want);
        wg_image_unref(out);
        wg_image_unref(bg);
        wg_image_unref(fg);
    }
}

static void test_default_is_copy_at_full_opacity(void **state)
{
    (void)state;
    WgImage *fg = wgt_image_fn(N_GRID, N_GRID, 1, fg_fn),
            *bg = wgt_image_fn(N_GRID, N_GRID, 1, bg_fn);
    WgImage *out = blend("", fg, bg, NULL, 1);
    /* copy, clamped */
    for (int x = 0; x < N_GRID; x++) {
        float want = grid[x] < 0 ? 0 : grid[x] > 1 ? 1 : grid[x];
        assert_true(wgt_px(out, x, 3, 0) == want);
    }
    wg_image_unref(out);
    wg_image_unref(bg);
    wg_image_unref(fg);
}

static double col_fn(int x, int y, int k)
{
    return fmod(0.13 * x + 0.29 * y + 0.37 * k + 0.05, 1.0);
}

static void test_gray_and_colour_mixing(void **state)
{
    (void)state;
    WgImage *fg = wgt_image_fn(6, 5, 4, col_fn); /* alpha varies too */
    WgImage *bg = wgt_image_fn(6, 5, 1, mask_fn);
    WgImage *mask = wgt_image_fn(6, 5, 1, bg_fn); /* grid values by row, incl. <0 and >1 */
    for (int m = 0; m < N_MODES; m++) {
        for (int swap = 0; swap < 2; swap++) {
            const WgImage *a = swap ? bg : fg, *b = swap ? fg : bg;
            char attrs[128];
            snprintf(attrs, sizeof attrs, "mode=\"%s\" opacity=\"0.8\"", modes[m]);
            WgImage *out = blend(attrs, a, b, mask, 2);
            assert_int_equal(out->channels, 4);
            for (int y = 0; y < 5; y++)
                for (int x = 0; x < 6; x++) {
                    float t = 0.8f * wgt_px(mask, x, y, 0);
                    for (int k = 0; k < 4; k++) {
                        /* a gray image counts as R = G = B with alpha 1 */
                        double av = a->channels == 1 ? (k == 3 ? 1 : wgt_px(a, x, y, 0))
                                                     : wgt_px(a, x, y, k);
                        double bv = b->channels == 1 ? (k == 3 ? 1 : wgt_px(b, x, y, 0))
                                                     : wgt_px(b, x, y, k);
                        double want = ref_blend(m, av, bv, t, true, k == 3);
                        double got = wgt_px(out, x, y, k);
                        if (!(fabs(got - want) <= tol(want)))
                            fail_msg("%s swap %d (%d,%d,%d): %.9g, expected %.9g", modes[m], swap,
                                     x, y, k, got, want);
                    }
                }
            wg_image_unref(out);
        }
    }
    /* colour over colour: alpha mixes like copy in every mode (here multiply) */
    WgImage *fg2 = wgt_image(1, 1, 4, (float[]){0.5f, 0.5f, 0.5f, 0.2f});
    WgImage *bg2 = wgt_image(1, 1, 4, (float[]){0.5f, 0.25f, 1.0f, 0.6f});
    WgImage *out = blend("mode=\"multiply\" opacity=\"0.5\"", fg2, bg2, NULL, 1);
    assert_float_equal(wgt_px(out, 0, 0, 0), 0.375, 1e-7);
    assert_float_equal(wgt_px(out, 0, 0, 1), 0.1875, 1e-7);
    assert_float_equal(wgt_px(out, 0, 0, 2), 0.75, 1e-7);
    assert_float_equal(wgt_px(out, 0, 0, 3), 0.4, 1e-7);
    wg_image_unref(out);
    wg_image_unref(bg2);
    wg_image_unref(fg2);
    wg_image_unref(mask);
    wg_image_unref(bg);
    wg_image_unref(fg);
}

static void test_empty_and_full_masks(void **state)
{
    (void)state;
    WgImage *fg = wgt_image_fn(7, 9, 4, col_fn), *bg = wgt_image_fn(7, 9, 4, mask_fn);
    WgImage *empty = wgt_image(7, 9, 1, NULL);
    WgImage *full = wgt_image(7, 9, 1, NULL);
    for (int y = 0; y < 9; y++)
        for (int x = 0; x < 7; x++) wg_image_row(full, y)[x] = 1;
    for (int m = 0; m < N_MODES; m++) {
        char attrs[64];
        snprintf(attrs, sizeof attrs, "mode=\"%s\"", modes[m]);
        /* an empty mask leaves the background untouched (it is within [0,1]) */
        WgImage *out = blend(attrs, fg, bg, empty, 1);
        wgt_assert_identical(out, bg);
        wg_image_unref(out);
        /* a full mask equals no mask */
        out = blend(attrs, fg, bg, full, 1);
        WgImage *nomask = blend(attrs, fg, bg, NULL, 1);
        wgt_assert_identical(out, nomask);
        wg_image_unref(nomask);
        wg_image_unref(out);
        /* opacity 0 too */
        snprintf(attrs, sizeof attrs, "mode=\"%s\" opacity=\"0\"", modes[m]);
        out = blend(attrs, fg, bg, NULL, 1);
        wgt_assert_identical(out, bg);
        wg_image_unref(out);
    }
    wg_image_unref(full);
    wg_image_unref(empty);
    wg_image_unref(bg);
    wg_image_unref(fg);
}

static void test_hdr_extremes(void **state)
{
    (void)state;
    float a[] = {1e6f, -1e6f, 1e6f, 0.0f};
    float b[] = {1e6f, 3.0f, -2.0f, 1e6f};
    WgImage *fa = wgt_image(4, 1, 1, a), *fb = wgt_image(4, 1, 1, b);
    struct {
        const char *mode;
        float want[4];
    } cases[] = {
        {"add", {2e6f, -999997.0f, 999998.0f, 1e6f}},
        {"subtract", {0.0f, 1000003.0f, -1000002.0f, 1e6f}},
        {"multiply", {1e12f, -3e6f, -2e6f, 0.0f}},
        {"max", {1e6f, 3.0f, 1e6f, 1e6f}},
        {"divide", {1.0f, 3.0f * 65536.0f, -2e-6f, 1e6f * 65536.0f}},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char attrs[64];
        snprintf(attrs, sizeof attrs, "mode=\"%s\" clamp=\"false\"", cases[i].mode);
        WgImage *out = blend(attrs, fa, fb, NULL, 1);
        int mode = 0;
        while (strcmp(modes[mode], cases[i].mode)) mode++;
        for (int x = 0; x < 4; x++) {
            float got = wgt_px(out, x, 0, 0);
            /* B + (f - B) in float: rounding of the two terms, relative to their size */
            double f = ref_mode(mode, a[x], b[x]);
            double tol = 1e-6 * fabs(cases[i].want[x]) + 2.5e-7 * (fabs(f) + fabs(b[x]));
            if (!(fabs(got - cases[i].want[x]) <= tol))
                fail_msg("%s x=%d: %.9g, expected %.9g", cases[i].mode, x, got, cases[i].want[x]);
        }
        wgt_assert_range(out, -1e13, 1e13);
        wg_image_unref(out);
        /* clamped: everything in [0,1], never NaN */
        snprintf(attrs, sizeof attrs, "mode=\"%s\"", cases[i].mode);
        out = blend(attrs, fa, fb, NULL, 1);
        wgt_assert_range(out, 0, 1);
        wg_image_unref(out);
    }
    /* at full opacity the result is f(A, B) itself, even when B dwarfs A (HDR heights) */
    float small[] = {0.001f, -3.25f, 1e-6f, 0.1f};
    float huge[] = {1e6f, 1e7f, -5e5f, 1e6f};
    WgImage *sa = wgt_image(4, 1, 1, small), *hb = wgt_image(4, 1, 1, huge);
    WgImage *copied = blend("mode=\"copy\" clamp=\"false\"", sa, hb, NULL, 1);
    for (int x = 0; x < 4; x++)
        if (wgt_px(copied, x, 0, 0) != small[x])
            fail_msg("copy of %.9g over %.9g gave %.9g", small[x], huge[x],
                     wgt_px(copied, x, 0, 0));
    wg_image_unref(copied);
    /* and the background itself where the mask is 0 */
    WgImage *zero = wgt_image(4, 1, 1, NULL);
    copied = blend("mode=\"add\" clamp=\"false\"", hb, sa, zero, 1);
    for (int x = 0; x < 4; x++) assert_true(wgt_px(copied, x, 0, 0) == small[x]);
    wg_image_unref(copied);
    wg_image_unref(zero);
    wg_image_unref(hb);
    wg_image_unref(sa);

    /* divide never produces NaN or infinity, even 0/0 and x/-0 */
    float za[] = {0.0f, -0.0f, -1.0f, 1e-30f};
    float zb[] = {0.0f, 1.0f, 1.0f, -1.0f};
    WgImage *ia = wgt_image(4, 1, 1, za), *ib = wgt_image(4, 1, 1, zb);
    WgImage *out = blend("mode=\"divide\" clamp=\"false\"", ia, ib, NULL, 1);
    wgt_assert_range(out, -1e6, 1e6);
    assert_true(wgt_px(out, 0, 0, 0) == 0.0f);
    assert_true(wgt_px(out, 1, 0, 0) == 65536.0f);
    wg_image_unref(out);
    wg_image_unref(ib);
    wg_image_unref(ia);
    wg_image_unref(fb);
    wg_image_unref(fa);
}

static void test_inputs_are_resampled(void **state)
{
    (void)state;
    /* a 1x1 foreground over a 4x4 background: constant colour */
    WgImage *fg = wgt_image(1, 1, 1, (float[]){0.25f});
    WgImage *bg = wgt_image_fn(4, 4, 1, mask_fn);
    const char *names[] = {"foreground", "background"};
    const WgImage *imgs[] = {fg, bg};
    WgImage *out = wgt_node("blend", "mode=\"add\"", 4, 4, 2, names, imgs, 0, 1);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++) {
            double want = fmin(1.0, 0.25 + (double)wgt_px(bg, x, y, 0));
            assert_float_equal(wgt_px(out, x, y, 0), want, 1e-7);
        }
    wg_image_unref(out);
    wg_image_unref(bg);
    wg_image_unref(fg);
}

static void test_errors(void **state)
{
    (void)state;
    WgImage *g = wgt_image(2, 2, 1, NULL), *c = wgt_image(2, 2, 4, NULL);
    WgError err;
    const char *names[] = {"foreground", "background", "mask"};
    const WgImage *colour_mask[] = {g, g, c};
    assert_int_equal(wgt_node_error("blend", "", 2, 2, 3, names, colour_mask, &err), WG_ERR_TYPE);
    assert_non_null(strstr(err.message, "'mask' takes a gray image"));
    const WgImage *two[] = {g, g};
    assert_int_equal(wgt_node_error("blend", "opacity=\"1.5\"", 2, 2, 2, names, two, &err),
                     WG_ERR_RANGE);
    assert_int_not_equal(wgt_node_error("blend", "mode=\"burn\"", 2, 2, 2, names, two, &err),
                         WG_OK);
    assert_non_null(strstr(err.message, "burn"));
    /* both images are required */
    assert_int_not_equal(wgt_node_error("blend", "", 2, 2, 1, names, two, &err), WG_OK);
    assert_non_null(strstr(err.message, "background"));
    wg_image_unref(c);
    wg_image_unref(g);
}

static double rnd_fn(int x, int y, int k)
{
    return (wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k) & 0xffffff) / (double)0xffffff * 1.4 -
           0.2;
}

static void test_thread_invariance(void **state)
{
    (void)state;
    WgImage *fg = wgt_image_fn(67, 130, 4, rnd_fn), *bg = wgt_image_fn(67, 130, 1, mask_fn);
    WgImage *mask = wgt_image_fn(67, 130, 1, rnd_fn);
    for (int m = 0; m < N_MODES; m += 5) {
        char attrs[64];
        snprintf(attrs, sizeof attrs, "mode=\"%s\" opacity=\"0.7\" clamp=\"false\"", modes[m]);
        WgImage *a = blend(attrs, fg, bg, mask, 1);
        WgImage *b = blend(attrs, fg, bg, mask, 3);
        WgImage *c = blend(attrs, fg, bg, mask, 8);
        wgt_assert_identical(a, b);
        wgt_assert_identical(a, c);
        wg_image_unref(c);
        wg_image_unref(b);
        wg_image_unref(a);
    }
    wg_image_unref(mask);
    wg_image_unref(bg);
    wg_image_unref(fg);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_modes_against_reference),
        cmocka_unit_test(test_exact_small_cases),
        cmocka_unit_test(test_default_is_copy_at_full_opacity),
        cmocka_unit_test(test_gray_and_colour_mixing),
        cmocka_unit_test(test_empty_and_full_masks),
        cmocka_unit_test(test_hdr_extremes),
        cmocka_unit_test(test_inputs_are_resampled),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_thread_invariance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
