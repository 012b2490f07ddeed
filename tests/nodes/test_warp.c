/* SPDX-License-Identifier: MIT */
/* `warp` and `directional_warp`: zero amount copies exactly, whole-pixel directional shifts are
 * exact cyclic shifts in each direction, both nodes match a float64 reference sampler of the
 * documented mapping on random inputs (bilinear and bicubic, gray and colour, within 2^-23,
 * the float rounding of values below 2), a constant source stays exactly constant, rolling the
 * inputs rolls the output bit for bit, the same smooth inputs at 64² and 256² give the same
 * picture, extreme amounts and values stay finite, any thread count gives the same bits, thin
 * images (1×N, N×1, 1×1), defaults and parameter errors. */
#include "warptest.h"

static WgImage *warp(const WgImage *src, const WgImage *in, double amount, const char *filter,
                     int threads)
{
    char attrs[128];
    snprintf(attrs, sizeof attrs, "amount=\"%.9g\" filter=\"%s\"", amount, filter);
    return wt_run("warp", attrs, src, in, threads);
}

static WgImage *dwarp(const WgImage *src, const WgImage *in, double amount, double angle,
                      const char *filter, int threads)
{
    char attrs[160];
    snprintf(attrs, sizeof attrs, "amount=\"%.9g\" angle=\"%.9g\" filter=\"%s\"", amount, angle,
             filter);
    return wt_run("directional_warp", attrs, src, in, threads);
}

static const char *const filters[] = {"bilinear", "bicubic"};

/* Values below 2 round to float within 2^-24 · 2; the double maths adds far less. */
#define TOL 1.2e-7

static void test_zero_amount_copies(void **state)
{
    (void)state;
    for (int c = 1; c <= 4; c += 3) {
        WgImage *src = wt_random(23, 14, c, 3);
        WgImage *in = wt_random(23, 14, 1, 4);
        for (int f = 0; f < 2; f++) {
            WgImage *a = warp(src, in, 0, filters[f], 2);
            WgImage *b = dwarp(src, in, 0, 37, filters[f], 2);
            WgImage *d = dwarp(src, NULL, 0, 0, filters[f], 2);
            assert_int_equal(a->channels, c);
            wgt_assert_identical(a, src);
            wgt_assert_identical(b, src);
            wgt_assert_identical(d, src);
            wg_image_unref(d);
            wg_image_unref(b);
            wg_image_unref(a);
        }
        wg_image_unref(in);
        wg_image_unref(src);
    }
}

/* At 64 pixels a length unit is 1/4 pixel: amount 12 is 3 pixels. */
static void test_directional_whole_pixel_shifts(void **state)
{
    (void)state;
    static const struct {
        double angle;
        int dx, dy; /* expected move in pixels, rows down */
    } cases[] = {{0, 3, 0},   {90, 0, -3},  {180, -3, 0}, {270, 0, 3},
                 {-90, 0, 3}, {450, 0, -3}, {-720, 3, 0}, {360090, 0, -3}};
    for (int c = 1; c <= 4; c += 3) {
        WgImage *src = wt_random(64, 40, c, 9);
        for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
            for (int f = 0; f < 2; f++) {
                WgImage *out = dwarp(src, NULL, 12, cases[i].angle, filters[f], 2);
                WgImage *want = wt_shift(src, cases[i].dx, cases[i].dy);
                wgt_assert_identical(out, want);
                wg_image_unref(want);
                wg_image_unref(out);
            }
        /* an intensity of 2 doubles the move; −1 reverses it */
        WgImage *two = ht_const(64, 40, 2), *minus = ht_const(64, 40, -1);
        WgImage *a = dwarp(src, two, 12, 0, "bicubic", 2), *wa = wt_shift(src, 6, 0);
        WgImage *b = dwarp(src, minus, 12, 90, "bilinear", 2), *wb = wt_shift(src, 0, 3);
        wgt_assert_identical(a, wa);
        wgt_assert_identical(b, wb);
        wg_image_unref(wb);
        wg_image_unref(b);
        wg_image_unref(wa);
        wg_image_unref(a);
        wg_image_unref(minus);
        wg_image_unref(two);
        wg_image_unref(src);
    }
}

static void check_reference(const WgImage *out, const WgImage *src, int bicubic,
                            void (*pos)(int x, int y, double *px, double *py), const char *what)
{
    assert_int_equal(out->channels, src->channels);
    assert_int_equal(out->width, src->width);
    assert_int_equal(out->height, src->height);
    for (int y = 0; y < src->height; y++)
        for (int x = 0; x < src->width; x++) {
            double px, py;
            pos(x, y, &px, &py);
            for (int k = 0; k < src->channels; k++) {
                double want = wt_sample(src, px, py, bicubic, k), got = wgt_px(out, x, y, k);
                if (!(fabs(got - want) <= TOL))
                    fail_msg("%s %dx%d %s (%d,%d,%d): %.10g, expected %.10g", what, src->width,
                             src->height, bicubic ? "bicubic" : "bilinear", x, y, k, got, want);
            }
        }
}

/* The documented mappings, written out in float64. */
static const WgImage *ref_in;
static double ref_amount, ref_angle;
static void warp_pos(int x, int y, double *px, double *py)
{
    double unit = ref_in->width / 256.0;
    double gx = (wt_px(ref_in, x + 1, y, 0) - wt_px(ref_in, x - 1, y, 0)) / 2 * unit;
    double gy = (wt_px(ref_in, x, y + 1, 0) - wt_px(ref_in, x, y - 1, 0)) / 2 * unit;
    *px = x - ref_amount * gx * unit;
    *py = y - ref_amount * gy * unit;
}
static void dwarp_pos(int x, int y, double *px, double *py)
{
    double unit = ref_in->width / 256.0, a = ref_angle * M_PI / 180;
    double v = ref_amount * unit * wt_px(ref_in, x, y, 0);
    *px = x - v * cos(a);
    *py = y + v * sin(a); /* y up: a positive sine moves the picture towards row 0 */
}

static const int shapes[][2] = {{24, 10}, {13, 17}, {16, 16}, {1, 9}, {9, 1}, {1, 1}, {2, 3}};

static void test_warp_against_float64_reference(void **state)
{
    (void)state;
    static const double amounts[] = {0.5, 64, 3000, -700, 2e5};
    for (int s = 0; s < 7; s++)
        for (int c = 1; c <= 4; c += 3) {
            WgImage *src = wt_random(shapes[s][0], shapes[s][1], c, 11 + s);
            WgImage *in = wt_random(shapes[s][0], shapes[s][1], 1, 40 + s);
            ref_in = in;
            for (int a = 0; a < 5; a++)
                for (int f = 0; f < 2; f++) {
                    WgImage *out = warp(src, in, amounts[a], filters[f], 2);
                    ref_amount = amounts[a];
                    check_reference(out, src, f, warp_pos, "warp");
                    wg_image_unref(out);
                }
            wg_image_unref(in);
            wg_image_unref(src);
        }
}

static void test_directional_against_float64_reference(void **state)
{
    (void)state;
    static const double amounts[] = {3, -40, 500};
    static const double angles[] = {0, 30, 90, 135, -100, 1000.5};
    for (int s = 0; s < 7; s++)
        for (int c = 1; c <= 4; c += 3) {
            WgImage *src = wt_random(shapes[s][0], shapes[s][1], c, 21 + s);
            WgImage *in = wt_random(shapes[s][0], shapes[s][1], 1, 60 + s);
            WgImage *one = ht_const(shapes[s][0], shapes[s][1], 1);
            for (int a = 0; a < 3; a++)
                for (int g = 0; g < 6; g++)
                    for (int f = 0; f < 2; f++) {
                        ref_amount = amounts[a], ref_angle = angles[g];
                        WgImage *out = dwarp(src, in, amounts[a], angles[g], filters[f], 2);
                        ref_in = in;
                        check_reference(out, src, f, dwarp_pos, "directional_warp");
                        wg_image_unref(out);
                        out = dwarp(src, NULL, amounts[a], angles[g], filters[f], 2);
                        ref_in = one;
                        check_reference(out, src, f, dwarp_pos, "directional_warp, no intensity");
                        wg_image_unref(out);
                    }
            wg_image_unref(one);
            wg_image_unref(in);
            wg_image_unref(src);
        }
}

/* The gradient points the way the picture goes: an intensity rising to the right moves the
 * picture right (reads from the left). */
static void test_warp_direction(void **state)
{
    (void)state;
    WgImage *src = wt_random(64, 8, 1, 5);
    WgImage *ramp = wgt_image(64, 8, 1, NULL);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 64; x++) wg_image_row(ramp, y)[x] = (float)x / 32; /* 1/32 a pixel */
    /* 1/32 per pixel is (1/32)·unit per length unit (unit = 64/256 pixels); the move in pixels
     * is amount · that · unit, so amount 512 moves one pixel */
    double unit = 64 / 256.0, amount = 1 / ((1.0 / 32) * unit * unit);
    assert_true(amount == 512);
    WgImage *out = warp(src, ramp, amount, "bilinear", 2);
    WgImage *want = wt_shift(src, 1, 0);
    /* away from the ramp's seam (x = 0 and x = 63 see the jump) */
    for (int y = 0; y < 8; y++)
        for (int x = 1; x < 63; x++)
            if (wgt_px(out, x, y, 0) != wgt_px(want, x, y, 0)) fail_msg("(%d,%d)", x, y);
    wg_image_unref(want);
    wg_image_unref(out);
    wg_image_unref(ramp);
    wg_image_unref(src);
}

static void test_constant_source_stays(void **state)
{
    (void)state;
    static const float values[] = {0.3f, 1.0f, -2.5f, 1e6f, 3e38f};
    WgImage *in = wt_random(19, 12, 1, 77);
    for (int v = 0; v < 5; v++)
        for (int f = 0; f < 2; f++) {
            WgImage *src = ht_const(19, 12, values[v]);
            WgImage *a = warp(src, in, 5000, filters[f], 2);
            WgImage *b = dwarp(src, in, 300, 21, filters[f], 2);
            wgt_assert_identical(a, src);
            wgt_assert_identical(b, src);
            wg_image_unref(b);
            wg_image_unref(a);
            wg_image_unref(src);
        }
    wg_image_unref(in);
}

static void test_tiling_rolls_commute(void **state)
{
    (void)state;
    static const int rolls[][2] = {{5, 0}, {0, 7}, {36, 21}, {11, 13}};
    WgImage *src = wt_random(37, 22, 4, 13);
    WgImage *in = wt_random(37, 22, 1, 14);
    for (int f = 0; f < 2; f++) {
        WgImage *ref_w = warp(src, in, 4000, filters[f], 2);
        WgImage *ref_d = dwarp(src, in, 77.7, 33, filters[f], 2);
        for (int r = 0; r < 4; r++) {
            WgImage *rs = ht_roll(src, rolls[r][0], rolls[r][1]);
            WgImage *ri = ht_roll(in, rolls[r][0], rolls[r][1]);
            WgImage *ow = warp(rs, ri, 4000, filters[f], 2);
            WgImage *od = dwarp(rs, ri, 77.7, 33, filters[f], 2);
            WgImage *ww = ht_roll(ref_w, rolls[r][0], rolls[r][1]);
            WgImage *wd = ht_roll(ref_d, rolls[r][0], rolls[r][1]);
            wgt_assert_identical(ow, ww);
            wgt_assert_identical(od, wd);
            wg_image_unref(wd);
            wg_image_unref(ww);
            wg_image_unref(od);
            wg_image_unref(ow);
            wg_image_unref(ri);
            wg_image_unref(rs);
        }
        wg_image_unref(ref_d);
        wg_image_unref(ref_w);
    }
    wg_image_unref(in);
    wg_image_unref(src);
}

/* The same smooth source and intensity sampled at 64² and 256²: pixel (x, y) of the small
 * render and (4x, 4y) of the large one are one texture point, so the outputs agree up to the
 * coarse render's filtering (central differences and bilinear interpolation at 64²). A
 * displacement in pixels instead of length units would move the large picture 4× (directional)
 * or 16× (warp) less, far outside the tolerance. */
static void test_resolution_independence(void **state)
{
    (void)state;
    WgImage *s64 = wt_smooth(64, 64, 4), *s256 = wt_smooth(256, 256, 4);
    WgImage *i64 = ht_wave(64, 64, 0.25, 1, 2), *i256 = ht_wave(256, 256, 0.25, 1, 2);
    for (int kind = 0; kind < 2; kind++) {
        WgImage *a =
            kind ? dwarp(s64, i64, 40, 30, "bilinear", 2) : warp(s64, i64, 1000, "bilinear", 2);
        WgImage *b =
            kind ? dwarp(s256, i256, 40, 30, "bilinear", 2) : warp(s256, i256, 1000, "bilinear", 2);
        double worst = 0, moved = 0;
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 64; x++)
                for (int k = 0; k < 4; k++) {
                    worst = fmax(worst, fabs(wgt_px(a, x, y, k) - wgt_px(b, 4 * x, 4 * y, k)));
                    moved = fmax(moved, fabs(wgt_px(a, x, y, k) - wgt_px(s64, x, y, k)));
                }
        if (!(worst <= 4e-3))
            fail_msg("%s: 64² and 256² differ by %g", kind ? "dwarp" : "warp", worst);
        if (!(moved >= 0.1))
            fail_msg("%s: the picture hardly moves (%g)", kind ? "dwarp" : "warp", moved);
        wg_image_unref(b);
        wg_image_unref(a);
    }
    wg_image_unref(i256);
    wg_image_unref(i64);
    wg_image_unref(s256);
    wg_image_unref(s64);
}

static void test_extreme_amounts_finite(void **state)
{
    (void)state;
    WgImage *src = wgt_image(512, 4, 4, NULL);
    WgImage *in = wgt_image(512, 4, 1, NULL);
    for (int y = 0; y < 4; y++) {
        for (int x = 0; x < 512 * 4; x++)
            wg_image_row(src, y)[x] = (x / 16 + y / 4) % 2 ? 3.4e38f : -3.4e38f;
        for (int x = 0; x < 512; x++)
            wg_image_row(in, y)[x] = (float)((wt_random_fn(x, y, 0) - 0.5) * 6.8e38);
    }
    static const double amounts[] = {1e6, -1e6, 123456.7};
    for (int a = 0; a < 3; a++)
        for (int f = 0; f < 2; f++) {
            WgImage *o1 = warp(src, in, amounts[a], filters[f], 2);
            WgImage *o2 = dwarp(src, in, amounts[a], 12.3, filters[f], 2);
            /* a fractional shift of ±3.4e38 stripes: bicubic overshoots the float range */
            WgImage *o3 = dwarp(src, NULL, 0.3 * (a + 1), 10 * a, filters[f], 2);
            wt_assert_finite(o1);
            wt_assert_finite(o2);
            wt_assert_finite(o3);
            wg_image_unref(o3);
            wg_image_unref(o2);
            wg_image_unref(o1);
        }
    /* non-finite intensities (only arithmetic makes them): where either component of the
     * displacement is not finite, the pixel does not move at all; elsewhere the reference */
    WgImage *small = wt_random(8, 6, 1, 3);
    WgImage *bad = wt_random(8, 6, 1, 4);
    wg_image_row(bad, 2)[3] = INFINITY;
    wg_image_row(bad, 4)[5] = NAN;
    ref_in = bad;
    for (int kind = 0; kind < 2; kind++) {
        ref_amount = kind ? 10 : 3e4, ref_angle = 30;
        WgImage *o =
            kind ? dwarp(small, bad, 10, 30, "bicubic", 2) : warp(small, bad, 3e4, "bilinear", 2);
        int still = 0;
        for (int y = 0; y < 6; y++)
            for (int x = 0; x < 8; x++) {
                double px, py;
                (kind ? dwarp_pos : warp_pos)(x, y, &px, &py);
                double want = isfinite(px) && isfinite(py) ? wt_sample(small, px, py, kind, 0)
                                                           : wgt_px(small, x, y, 0);
                still += !(isfinite(px) && isfinite(py));
                if (!(fabs(wgt_px(o, x, y, 0) - want) <= TOL))
                    fail_msg("%s, non-finite intensity: (%d,%d) %.9g, expected %.9g",
                             kind ? "directional_warp" : "warp", x, y, wgt_px(o, x, y, 0), want);
            }
        /* directional: the two pixels; warp: the 4 neighbours of each, whose differences read them
         */
        assert_int_equal(still, kind ? 2 : 8);
        wg_image_unref(o);
    }
    wg_image_unref(bad);
    wg_image_unref(small);
    wg_image_unref(in);
    wg_image_unref(src);
}

static void test_thread_invariance(void **state)
{
    (void)state;
    WgImage *src = wt_random(300, 150, 4, 1);
    WgImage *in = wt_random(300, 150, 1, 2);
    static const int threads[] = {2, 3, 8};
    for (int f = 0; f < 2; f++) {
        WgImage *a = warp(src, in, 3000, filters[f], 1);
        WgImage *b = dwarp(src, in, 50, 70, filters[f], 1);
        for (int t = 0; t < 3; t++) {
            WgImage *c = warp(src, in, 3000, filters[f], threads[t]);
            WgImage *d = dwarp(src, in, 50, 70, filters[f], threads[t]);
            wgt_assert_identical(a, c);
            wgt_assert_identical(b, d);
            wg_image_unref(d);
            wg_image_unref(c);
        }
        wg_image_unref(b);
        wg_image_unref(a);
    }
    wg_image_unref(in);
    wg_image_unref(src);
}

/* Along a side of 1 or 2 pixels the central difference reads one pixel twice, so nothing moves
 * along it; the other axis follows the reference. */
static void test_thin_images(void **state)
{
    (void)state;
    static const int sizes[][2] = {{1, 7}, {7, 1}, {2, 5}, {5, 2}, {1, 1}};
    for (int s = 0; s < 5; s++) {
        WgImage *src = wt_random(sizes[s][0], sizes[s][1], 4, 8 + s);
        WgImage *in = wt_random(sizes[s][0], sizes[s][1], 1, 9 + s);
        ref_in = in, ref_amount = 3e5;
        for (int f = 0; f < 2; f++) {
            WgImage *out = warp(src, in, 3e5, filters[f], 2);
            check_reference(out, src, f, warp_pos, "thin warp");
            for (int y = 0; y < src->height; y++)
                for (int x = 0; x < src->width; x++) {
                    double px, py;
                    warp_pos(x, y, &px, &py);
                    if (sizes[s][0] <= 2) assert_true(px == x);
                    if (sizes[s][1] <= 2) assert_true(py == y);
                }
            wg_image_unref(out);
        }
        wg_image_unref(in);
        wg_image_unref(src);
    }
}

static void test_defaults(void **state)
{
    (void)state;
    WgImage *src = wt_random(12, 9, 4, 2), *in = wt_random(12, 9, 1, 3);
    WgImage *a = wt_run("warp", "", src, in, 1), *b = warp(src, in, 64, "bilinear", 1);
    WgImage *c = wt_run("directional_warp", "", src, in, 1),
            *d = dwarp(src, in, 16, 0, "bilinear", 1);
    wgt_assert_identical(a, b);
    wgt_assert_identical(c, d);
    wg_image_unref(d);
    wg_image_unref(c);
    wg_image_unref(b);
    wg_image_unref(a);
    wg_image_unref(in);
    wg_image_unref(src);
}

static void test_errors(void **state)
{
    (void)state;
    WgImage *g = wgt_image(4, 4, 1, NULL);
    WgImage *c = wgt_image(4, 4, 4, NULL);
    const char *names[] = {"source", "intensity"};
    const WgImage *ok[] = {c, g}, *colour_in[] = {g, c};
    WgError err;
    assert_int_equal(wgt_node_error("warp", "amount=\"2e6\"", 4, 4, 2, names, ok, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "amount"));
    assert_int_not_equal(wgt_node_error("warp", "filter=\"lanczos\"", 4, 4, 2, names, ok, &err),
                         WG_OK);
    assert_non_null(strstr(err.message, "filter"));
    assert_int_not_equal(wgt_node_error("warp", "", 4, 4, 1, names, ok, &err), WG_OK);
    assert_int_not_equal(wgt_node_error("warp", "", 4, 4, 2, names, colour_in, &err), WG_OK);
    assert_int_not_equal(wgt_node_error("directional_warp", "", 4, 4, 2, names, colour_in, &err),
                         WG_OK);
    wg_image_unref(c);
    wg_image_unref(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_zero_amount_copies),
        cmocka_unit_test(test_directional_whole_pixel_shifts),
        cmocka_unit_test(test_warp_against_float64_reference),
        cmocka_unit_test(test_directional_against_float64_reference),
        cmocka_unit_test(test_warp_direction),
        cmocka_unit_test(test_constant_source_stays),
        cmocka_unit_test(test_tiling_rolls_commute),
        cmocka_unit_test(test_resolution_independence),
        cmocka_unit_test(test_extreme_amounts_finite),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_thin_images),
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
