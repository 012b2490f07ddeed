/* SPDX-License-Identifier: MIT */
/* `auto_levels`: exact stretch, flat images, a single bright pixel, linked and per-channel
 * colour, non-finite values (in every lane of the gray scan too), extremes, and independence from
 * threads and row chunking. */
#include "colortest.h"

static WgImage *run(const char *attrs, const WgImage *in, int threads)
{
    return ct_run("auto_levels", attrs, "source", in, threads);
}

/* The documented formula over the whole image, computed directly. */
static float expect(float x, double lo, double hi)
{
    if (!(hi > lo)) return 0.5f;
    double t = ((double)x - lo) * (1.0 / (hi - lo));
    return t > 0 ? (t < 1 ? (float)t : 1.0f) : 0.0f;
}

static void test_stretch_exact(void **state)
{
    (void)state;
    float v[] = {0.2f, 0.45f, 0.7f, 0.3f, 0.2f, 0.6f};
    WgImage *in = wgt_image(3, 2, 1, v);
    WgImage *out = run("", in, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.0f);
    assert_true(wgt_px(out, 2, 0, 0) == 1.0f);
    assert_true(wgt_px(out, 1, 1, 0) == 0.0f);
    assert_float_equal(wgt_px(out, 1, 0, 0), 0.5, 1e-7);
    assert_float_equal(wgt_px(out, 0, 1, 0), 0.2, 1e-7);
    assert_float_equal(wgt_px(out, 2, 1, 0), 0.8, 1e-7);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_flat_image(void **state)
{
    (void)state;
    float vals[] = {0, 0.37f, 1, -5, 1e6f};
    for (size_t i = 0; i < sizeof vals / sizeof vals[0]; i++) {
        float v[12];
        for (int k = 0; k < 12; k++) v[k] = vals[i];
        WgImage *in = wgt_image(4, 3, 1, v);
        WgImage *out = run("", in, 1);
        for (int y = 0; y < 3; y++)
            for (int x = 0; x < 4; x++) assert_true(wgt_px(out, x, y, 0) == 0.5f);
        wg_image_unref(out);
        wg_image_unref(in);
    }
    /* a single pixel is flat too */
    float one = 0.9f;
    WgImage *in = wgt_image(1, 1, 1, &one);
    WgImage *out = run("", in, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.5f);
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_single_bright_pixel(void **state)
{
    (void)state;
    for (int bright = 0; bright < 2; bright++) {
        WgImage *in = wg_image_new_zero(33, 70, 1);
        for (int y = 0; y < 70; y++)
            for (int x = 0; x < 33; x++) wg_image_row(in, y)[x] = bright ? 0.3f : 0.0f;
        wg_image_row(in, 41)[17] = bright ? 0.9f : 1e6f;
        WgImage *out = run("", in, 4);
        for (int y = 0; y < 70; y++)
            for (int x = 0; x < 33; x++)
                assert_true(wgt_px(out, x, y, 0) == (x == 17 && y == 41 ? 1.0f : 0.0f));
        wg_image_unref(out);
        wg_image_unref(in);
    }
}

static void test_colour_linked_and_per_channel(void **state)
{
    (void)state;
    /* R in [0.2, 0.4], G in [0.1, 0.5], B flat 0.3, alpha ignored and kept */
    float v[] = {0.2f, 0.1f, 0.3f, 7, 0.4f, 0.5f, 0.3f, -2, 0.3f, 0.3f, 0.3f, 0.5f};
    WgImage *in = wgt_image(3, 1, 4, v);
    WgImage *out = run("", in, 1); /* linked: one range [0.1, 0.5] */
    for (int i = 0; i < 12; i++) {
        float want = i % 4 == 3 ? v[i] : expect(v[i], 0.1f, 0.5f);
        assert_true(wgt_px(out, i / 4, 0, i % 4) == want);
    }
    /* a neutral gray stays neutral */
    assert_true(wgt_px(out, 2, 0, 0) == wgt_px(out, 2, 0, 1) &&
                wgt_px(out, 2, 0, 1) == wgt_px(out, 2, 0, 2));
    wg_image_unref(out);

    out = run("mode=\"per_channel\"", in, 1);
    double lo[3] = {0.2f, 0.1f, 0.3f}, hi[3] = {0.4f, 0.5f, 0.3f};
    for (int i = 0; i < 12; i++) {
        int k = i % 4;
        float want = k == 3 ? v[i] : expect(v[i], lo[k], hi[k]);
        assert_true(wgt_px(out, i / 4, 0, k) == want);
    }
    assert_true(wgt_px(out, 0, 0, 0) == 0.0f && wgt_px(out, 1, 0, 0) == 1.0f);
    assert_true(wgt_px(out, 0, 0, 2) == 0.5f); /* flat blue channel */
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_non_finite_and_extremes(void **state)
{
    (void)state;
    float v[] = {NAN, INFINITY, -INFINITY, -3e38f, 3e38f, 0};
    WgImage *in = wgt_image(6, 1, 1, v);
    WgImage *out = run("", in, 1);
    ct_assert_finite(out);
    float want[] = {0, 1, 0, 0, 1, 0.5f};
    for (int i = 0; i < 6; i++) assert_float_equal(wgt_px(out, i, 0, 0), want[i], 1e-7);
    wg_image_unref(out);
    wg_image_unref(in);
    /* only non-finite values: nothing to measure, flat */
    float w[] = {NAN, INFINITY};
    in = wgt_image(2, 1, 1, w);
    out = run("", in, 1);
    assert_true(wgt_px(out, 0, 0, 0) == 0.5f && wgt_px(out, 1, 0, 0) == 0.5f);
    wg_image_unref(out);
    wg_image_unref(in);
}

/* Non-finite values and the extremes in every lane of the eight-wide scan and in its tail: the
 * range is that of the finite values, each output the formula's. */
static void test_non_finite_in_every_lane(void **state)
{
    (void)state;
    enum { W = 23 };
    for (int p = 0; p < W; p++) {
        float v[W];
        for (int i = 0; i < W; i++) v[i] = 0.2f + 0.6f * (float)((i * 7 + p) % W) / W;
        v[p] = NAN;
        v[(p + 5) % W] = INFINITY;
        v[(p + 11) % W] = -INFINITY;
        v[(p + 3) % W] = -2.0f;
        v[(p + 17) % W] = 3.0f;
        WgImage *in = wgt_image(W, 1, 1, v);
        WgImage *out = run("", in, 1);
        for (int i = 0; i < W; i++)
            if (wgt_px(out, i, 0, 0) != expect(v[i], -2.0, 3.0))
                fail_msg("p=%d: x=%d %.9g, expected %.9g", p, i, wgt_px(out, i, 0, 0),
                         expect(v[i], -2.0, 3.0));
        wg_image_unref(out);
        wg_image_unref(in);
    }
    /* a row of non-finite values only, longer than a vector: flat */
    float w[19];
    for (int i = 0; i < 19; i++) w[i] = i % 3 == 0 ? NAN : i % 3 == 1 ? INFINITY : -INFINITY;
    WgImage *in = wgt_image(19, 1, 1, w);
    WgImage *out = run("", in, 1);
    for (int i = 0; i < 19; i++) assert_true(wgt_px(out, i, 0, 0) == 0.5f);
    wg_image_unref(out);
    wg_image_unref(in);
}

/* Bit-identical to the formula over the whole image for many heights (so many different row
 * chunkings: fewer rows than chunks, exactly 64, uneven splits) and thread counts. */
static void test_independent_of_chunks_and_threads(void **state)
{
    (void)state;
    int heights[] = {1, 2, 63, 64, 65, 127, 300};
    for (size_t hi = 0; hi < sizeof heights / sizeof heights[0]; hi++) {
        int h = heights[hi];
        for (int channels = 1; channels <= 4; channels += 3) {
            WgImage *in = ct_random_image(37, h, channels, -3, 5, 100 + (uint64_t)h);
            /* the extremes in a row near the end, so a per-chunk slip would show */
            wg_image_row(in, h - 1)[channels * 3] = -7.25f;
            wg_image_row(in, h / 2)[channels * 5] = 9.5f;
            double lo = -7.25, hi2 = 9.5;
            WgImage *a = run("", in, 1);
            for (int y = 0; y < h; y++)
                for (int i = 0; i < 37 * channels; i++) {
                    float x = wg_image_row(in, y)[i];
                    float want = channels == 4 && i % 4 == 3 ? x : expect(x, lo, hi2);
                    if (wg_image_row(a, y)[i] != want)
                        fail_msg("h=%d c=%d: (%d, %d) %.9g, expected %.9g", h, channels, i, y,
                                 wg_image_row(a, y)[i], want);
                }
            for (int threads = 2; threads <= 8; threads *= 2) {
                WgImage *b = run("", in, threads);
                wgt_assert_identical(a, b);
                wg_image_unref(b);
            }
            WgImage *c = run("mode=\"per_channel\"", in, 1);
            WgImage *d = run("mode=\"per_channel\"", in, 4);
            wgt_assert_identical(c, d);
            wg_image_unref(c);
            wg_image_unref(d);
            wg_image_unref(a);
            wg_image_unref(in);
        }
    }
}

static void test_output_range(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(64, 64, 4, -1e6, 1e6, 77);
    WgImage *out = run("", in, 4);
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++)
            for (int k = 0; k < 3; k++) {
                float v = wgt_px(out, x, y, k);
                assert_true(v >= 0 && v <= 1);
            }
    wg_image_unref(out);
    wg_image_unref(in);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stretch_exact),
        cmocka_unit_test(test_flat_image),
        cmocka_unit_test(test_single_bright_pixel),
        cmocka_unit_test(test_colour_linked_and_per_channel),
        cmocka_unit_test(test_non_finite_and_extremes),
        cmocka_unit_test(test_non_finite_in_every_lane),
        cmocka_unit_test(test_independent_of_chunks_and_threads),
        cmocka_unit_test(test_output_range),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
