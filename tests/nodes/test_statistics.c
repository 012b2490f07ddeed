/* SPDX-License-Identifier: MIT */
/* `statistics`: exact minimum and maximum, the mean against a float64 reference, constant
 * outputs at the node's size, non-finite values ignored, images without a finite value, extreme
 * values, and bit-identical results for any thread count. */
#include "colortest.h"

/* Output `port` (0 min, 1 max, 2 mean) of a statistics node on `in`. */
static WgImage *stat(const WgImage *in, int port, int threads)
{
    const char *names[] = {"source"};
    const WgImage *images[] = {in};
    return wgt_node("statistics", "", in->width, in->height, 1, names, images, port, threads);
}

/* Every pixel of `img` is exactly `v`. */
static void assert_constant(const WgImage *img, float v)
{
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            if (wgt_px(img, x, y, 0) != v)
                fail_msg("pixel (%d, %d) is %.9g, expected %.9g", x, y, wgt_px(img, x, y, 0), v);
}

static void test_exact_small(void **state)
{
    (void)state;
    float v[] = {0.2f, -0.45f, 0.7f, 0.3f, 0.2f, 0.6f};
    WgImage *in = wgt_image(3, 2, 1, v);
    WgImage *lo = stat(in, 0, 1), *hi = stat(in, 1, 1), *mean = stat(in, 2, 1);
    assert_int_equal(lo->width, 3);
    assert_int_equal(lo->height, 2);
    assert_constant(lo, -0.45f);
    assert_constant(hi, 0.7f);
    double want = ((double)0.2f - 0.45f + 0.7f + 0.3f + 0.2f + 0.6f) / 6;
    assert_constant(mean, (float)want);
    wg_image_unref(lo);
    wg_image_unref(hi);
    wg_image_unref(mean);
    wg_image_unref(in);
}

/* A large random image: min and max exact, the mean within one float rounding of the float64
 * mean of the same values. */
static void test_float64_reference(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(301, 257, 1, -3, 5, 42);
    double lo = INFINITY, hi = -INFINITY, sum = 0;
    for (int y = 0; y < in->height; y++)
        for (int x = 0; x < in->width; x++) {
            double v = wgt_px(in, x, y, 0);
            lo = fmin(lo, v);
            hi = fmax(hi, v);
            sum += v;
        }
    double mean = sum / (in->width * in->height);
    WgImage *a = stat(in, 0, 2), *b = stat(in, 1, 2), *m = stat(in, 2, 2);
    assert_constant(a, (float)lo);
    assert_constant(b, (float)hi);
    assert_true(fabs(wgt_px(m, 0, 0, 0) - mean) <= 1e-7 * (1 + fabs(mean)));
    assert_constant(m, wgt_px(m, 0, 0, 0));
    wg_image_unref(a);
    wg_image_unref(b);
    wg_image_unref(m);
    wg_image_unref(in);
}

static void test_non_finite_ignored(void **state)
{
    (void)state;
    float v[] = {NAN, INFINITY, 0.25f, -INFINITY, 0.75f, NAN};
    WgImage *in = wgt_image(2, 3, 1, v);
    WgImage *lo = stat(in, 0, 1), *hi = stat(in, 1, 1), *mean = stat(in, 2, 1);
    assert_constant(lo, 0.25f);
    assert_constant(hi, 0.75f);
    assert_constant(mean, 0.5f);
    wg_image_unref(lo);
    wg_image_unref(hi);
    wg_image_unref(mean);
    wg_image_unref(in);
    /* nothing finite: every output is 0 */
    float w[] = {NAN, INFINITY, -INFINITY};
    in = wgt_image(3, 1, 1, w);
    for (int port = 0; port < 3; port++) {
        WgImage *o = stat(in, port, 1);
        assert_constant(o, 0.0f);
        wg_image_unref(o);
    }
    wg_image_unref(in);
}

/* Values near the float limits: the sum is in double, so the mean does not overflow, and it is
 * kept within [min, max]. */
static void test_extremes(void **state)
{
    (void)state;
    float v[] = {3e38f, 3e38f, 3e38f, 3e38f};
    WgImage *in = wgt_image(2, 2, 1, v);
    WgImage *m = stat(in, 2, 1);
    assert_constant(m, 3e38f);
    wg_image_unref(m);
    wg_image_unref(in);
    float one = -7.5f;
    in = wgt_image(1, 1, 1, &one);
    for (int port = 0; port < 3; port++) {
        WgImage *o = stat(in, port, 1);
        assert_constant(o, -7.5f);
        wg_image_unref(o);
    }
    wg_image_unref(in);
}

static void test_threads(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(97, 389, 1, 0, 1, 7);
    for (int port = 0; port < 3; port++) {
        WgImage *a = stat(in, port, 1), *b = stat(in, port, 4);
        wgt_assert_identical(a, b);
        wg_image_unref(a);
        wg_image_unref(b);
    }
    wg_image_unref(in);
}

/* A colour input is a graph error, as for every gray port. */
static void test_colour_rejected(void **state)
{
    (void)state;
    WgImage *in = wgt_image(2, 2, 4, NULL);
    ct_fails("statistics", "", in, WG_ERR_TYPE, "grayscale");
    wg_image_unref(in);
}

/* A uniform image (one row shared by every row, as an unconnected graph input or a `uniform`
 * node gives) is measured once, with the same bits as the same value written in full. */
static void test_uniform_source(void **state)
{
    (void)state;
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"301x257\">\n"
                          "  <node id=\"u\" type=\"uniform\" value=\"0.1\"/>\n"
                          "  <node id=\"st\" type=\"statistics\"><in name=\"source\" from=\"u\"/></node>\n"
                          "  <output name=\"lo\" from=\"st.min\"/>\n"
                          "  <output name=\"hi\" from=\"st.max\"/>\n"
                          "  <output name=\"mean\" from=\"st.mean\"/>\n"
                          "</wetgraph>\n");
    for (int threads = 1; threads <= 3; threads += 2) {
        WgResult *r = wgt_render(g, threads);
        float v = 0.1f;
        WgImage *one = wgt_image(1, 1, 1, &v), *full = wg_image_convert(one, 301, 257, 1);
        assert_non_null(full);
        const char *outs[] = {"lo", "hi", "mean"};
        for (int k = 0; k < 3; k++) {
            WgImage *want = stat(full, k, threads);
            assert_float_equal(wgt_px(wgt_output(r, outs[k]), 0, 0, 0), wgt_px(want, 0, 0, 0), 0);
            assert_constant(wgt_output(r, outs[k]), wgt_px(want, 0, 0, 0));
            wg_image_unref(want);
        }
        wg_image_unref(full);
        wg_image_unref(one);
        wg_result_free(r);
    }
    wg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_small),
        cmocka_unit_test(test_float64_reference),
        cmocka_unit_test(test_non_finite_ignored),
        cmocka_unit_test(test_extremes),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_colour_rejected),
        cmocka_unit_test(test_uniform_source),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
