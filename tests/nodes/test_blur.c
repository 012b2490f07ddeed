/* SPDX-License-Identifier: MIT */
/* `blur`, both qualities, against a straightforward float64 periodic Gaussian (a direct 2-D sum
 * over every source pixel with wrap-around, the kernel summed over all periodic images), for
 * several sigmas including 0, sub-pixel ones, kernels wider than the image and sigma beyond the
 * image (the mean); `fast` against `exact` on random images from σ = 0.5 px to the image size;
 * sigma as a length (σ_px = sigma · width / 256); non-square, thin and colour images; tiling
 * (rolling commutes with the blur); flat inputs, impulses and HDR values; errors; thread
 * invariance. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const qualities[] = {"exact", "fast"};

/* Blur by sigma_px pixels: the length attribute is sigma_px · 256 / width. */
static WgImage *blur_q(const WgImage *src, double sigma_px, const char *quality, int threads)
{
    char attrs[128];
    snprintf(attrs, sizeof attrs, "sigma=\"%.17g\" quality=\"%s\"", sigma_px * 256 / src->width,
             quality);
    const char *names[] = {"source"};
    const WgImage *imgs[] = {src};
    return wgt_node("blur", attrs, src->width, src->height, 1, names, imgs, 0, threads);
}

/* Periodic Gaussian weight of offset d on a ring of n pixels (unnormalised). */
static double ring_weight(int d, int n, double sigma)
{
    double w = 0;
    int reach = (int)ceil(12 * sigma) + n;
    for (int m = -(reach / n + 1); m <= reach / n + 1; m++) {
        double e = d + (double)m * n;
        w += exp(-e * e / (2 * sigma * sigma));
    }
    return w;
}

/* Direct 2-D sum: out(x,y) = sum over all (i,j) of G(i,j) in(x+i, y+j), G the normalised
 * periodic 2-D Gaussian exp(-(i^2 + j^2) / 2 sigma^2). */
static double *reference(const WgImage *src, double sigma)
{
    int w = src->width, h = src->height, c = src->channels;
    double *g = malloc(sizeof(double) * (size_t)w * (size_t)h);
    double total = 0;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            /* the 2-D periodic sum of exp(-(a^2+b^2)/2s^2) factors over a and b */
            g[j * w + i] = ring_weight(i, w, sigma) * ring_weight(j, h, sigma);
            total += g[j * w + i];
        }
    double *out = calloc((size_t)w * (size_t)h * (size_t)c, sizeof(double));
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int j = 0; j < h; j++)
                for (int i = 0; i < w; i++) {
                    double wt = g[j * w + i] / total;
                    const float *p = wg_image_row(src, (y + j) % h) + (size_t)((x + i) % w) * c;
                    for (int k = 0; k < c; k++) out[((size_t)y * w + x) * c + k] += wt * p[k];
                }
    free(g);
    return out;
}

static void compare(const WgImage *got, const double *want, double tol, const char *what)
{
    int c = got->channels;
    for (int y = 0; y < got->height; y++)
        for (int x = 0; x < got->width; x++)
            for (int k = 0; k < c; k++) {
                double r = want[((size_t)y * got->width + x) * c + k];
                double v = wgt_px(got, x, y, k);
                if (!(fabs(v - r) <= tol * (1 + fabs(r))))
                    fail_msg("%s (%d,%d,%d): %.9g, expected %.9g", what, x, y, k, v, r);
            }
}

static double pattern_fn(int x, int y, int k)
{
    return (wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k) & 0xffff) / 65535.0 +
           (x % 7 == 0 ? 0.5 : 0) - (y % 5 == 1 ? 0.25 : 0);
}

/* Tolerance of each quality against the float64 reference, relative to 1 + |value|: exact sums
 * in double; fast sums in float (direct) or goes through float FFTs. */
static double tolerance(int q)
{
    return q == 0 ? 2e-6 : 1e-5;
}

static void test_against_periodic_gaussian(void **state)
{
    (void)state;
    static const double sigmas[] = {0.3, 0.5, 1, 2.5, 4, 7, 11.5, 40};
    static const int shapes[][3] = {{24, 10, 1}, {13, 17, 4}, {16, 16, 1}, {1, 9, 1}, {30, 2, 4}};
    for (int s = 0; s < 5; s++) {
        WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], shapes[s][2], pattern_fn);
        for (int i = 0; i < 8; i++) {
            double *ref = reference(src, sigmas[i]);
            for (int q = 0; q < 2; q++) {
                WgImage *out = blur_q(src, sigmas[i], qualities[q], 2);
                wgt_assert_same_shape(out, src);
                char what[64];
                snprintf(what, sizeof what, "%s %dx%dx%d sigma %g", qualities[q], src->width,
                         src->height, src->channels, sigmas[i]);
                compare(out, ref, tolerance(q), what);
                wg_image_unref(out);
            }
            free(ref);
        }
        wg_image_unref(src);
    }
}

/* sigma is a length: sigma · width / 256 pixels, along both axes (the width's scale). */
static void test_sigma_is_a_length(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(64, 40, 1, pattern_fn);
    const char *names[] = {"source"};
    const WgImage *imgs[] = {src};
    double *ref = reference(src, 2.0); /* 8 × 64 / 256 */
    double *ref5 = reference(src, 5.0);
    for (int q = 0; q < 2; q++) {
        char attrs[64];
        snprintf(attrs, sizeof attrs, "sigma=\"8\" quality=\"%s\"", qualities[q]);
        WgImage *out = wgt_node("blur", attrs, 64, 40, 1, names, imgs, 0, 2);
        compare(out, ref, tolerance(q), attrs);
        wg_image_unref(out);
        snprintf(attrs, sizeof attrs, "sigma=\"20\" quality=\"%s\"", qualities[q]);
        out = wgt_node("blur", attrs, 64, 40, 1, names, imgs, 0, 2);
        compare(out, ref5, tolerance(q), attrs);
        wg_image_unref(out);
    }
    free(ref5);
    free(ref);
    wg_image_unref(src);
}

static void test_sigma_zero_copies(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(11, 6, 4, pattern_fn);
    for (int q = 0; q < 2; q++) {
        WgImage *out = blur_q(src, 0, qualities[q], 1);
        wgt_assert_identical(out, src);
        wg_image_unref(out);
        /* 0.1 px: the neighbours weigh exp(-50) ≈ 2e-22 */
        out = blur_q(src, 0.1, qualities[q], 1);
        wgt_assert_near(out, src, 1e-7);
        wg_image_unref(out);
    }
    wg_image_unref(src);
}

static double image_mean(const WgImage *img, int k)
{
    double m = 0;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) m += wgt_px(img, x, y, k);
    return m / ((double)img->width * img->height);
}

static void test_sigma_beyond_the_image_is_the_mean(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(20, 12, 4, pattern_fn);
    static const double sigmas[] = {20, 25, 1000, 16384 * 20 / 256};
    for (int q = 0; q < 2; q++)
        for (int i = 0; i < 4; i++) {
            WgImage *out = blur_q(src, sigmas[i], qualities[q], 3);
            for (int k = 0; k < 4; k++) {
                double m = image_mean(src, k);
                for (int y = 0; y < 12; y++)
                    for (int x = 0; x < 20; x++)
                        if (fabs(wgt_px(out, x, y, k) - m) > 1e-6)
                            fail_msg("%s sigma %g (%d,%d,%d): %.9g vs mean %.9g", qualities[q],
                                     sigmas[i], x, y, k, wgt_px(out, x, y, k), m);
            }
            wg_image_unref(out);
        }
    /* only one axis beyond its side: the mean along it, a Gaussian along the other */
    double *ref = reference(src, 15);
    for (int q = 0; q < 2; q++) {
        WgImage *out = blur_q(src, 15, qualities[q], 1);
        compare(out, ref, tolerance(q), "sigma 15 on 20x12");
        for (int x = 0; x < 20; x++) /* every column is constant */
            for (int y = 1; y < 12; y++)
                assert_float_equal(wgt_px(out, x, y, 0), wgt_px(out, x, 0, 0), 1e-6);
        wg_image_unref(out);
    }
    free(ref);
    wg_image_unref(src);
}

/* Roll an image by (dx, dy) with wrap-around. */
static WgImage *roll(const WgImage *src, int dx, int dy)
{
    int w = src->width, h = src->height, c = src->channels;
    WgImage *out = wgt_image(w, h, c, NULL);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < c; k++)
                wg_image_row(out, (y + dy) % h)[((x + dx) % w) * c + k] = wgt_px(src, x, y, k);
    return out;
}

static void test_tiling_rolls_commute(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(37, 22, 4, pattern_fn);
    static const double sigmas[] = {0.7, 2.9, 3, 9, 30};
    static const int rolls[][2] = {{5, 0}, {0, 7}, {36, 21}, {11, 13}};
    for (int q = 0; q < 2; q++)
        for (int i = 0; i < 5; i++) {
            WgImage *ref = blur_q(src, sigmas[i], qualities[q], 2);
            for (int r = 0; r < 4; r++) {
                WgImage *rolled = roll(src, rolls[r][0], rolls[r][1]);
                WgImage *b = blur_q(rolled, sigmas[i], qualities[q], 2);
                WgImage *back = roll(b, 37 - rolls[r][0], 22 - rolls[r][1]);
                /* direct sums: same taps in the same order, bit-identical (the mean of a whole
                 * row or column sums in another order when sigma reaches the side); FFT: the
                 * rolled input rounds differently */
                if (sigmas[i] < (q == 0 ? 22 : 3))
                    wgt_assert_identical(back, ref);
                else
                    wgt_assert_near(back, ref, 1e-6);
                wg_image_unref(back);
                wg_image_unref(b);
                wg_image_unref(rolled);
            }
            wg_image_unref(ref);
        }
    wg_image_unref(src);
}

static void test_edges_wrap(void **state)
{
    (void)state;
    /* an impulse in the corner spreads to the other three corners */
    WgImage *src = wgt_image(16, 16, 1, NULL);
    wg_image_row(src, 0)[0] = 1;
    static const double sigmas[] = {1.5, 4};
    for (int q = 0; q < 2; q++)
        for (int s = 0; s < 2; s++) {
            WgImage *out = blur_q(src, sigmas[s], qualities[q], 1);
            float v = wgt_px(out, 0, 0, 0);
            assert_true(v > 0);
            assert_float_equal(wgt_px(out, 15, 0, 0), wgt_px(out, 1, 0, 0), 1e-7);
            assert_float_equal(wgt_px(out, 0, 15, 0), wgt_px(out, 0, 1, 0), 1e-7);
            assert_float_equal(wgt_px(out, 15, 15, 0), wgt_px(out, 1, 1, 0), 1e-7);
            assert_float_equal(image_mean(out, 0) * 256, 1.0, 1e-6); /* mass is kept */
            if (s == 0) {
                double w1 = exp(-1 / (2 * 1.5 * 1.5));
                assert_float_equal(wgt_px(out, 1, 0, 0) / v, w1, 1e-5);
            }
            wg_image_unref(out);
        }
    wg_image_unref(src);
}

/* An impulse keeps its sum at every sigma, on a non-power-of-two image. */
static void test_impulse_keeps_its_sum(void **state)
{
    (void)state;
    WgImage *src = wgt_image(97, 61, 1, NULL);
    wg_image_row(src, 30)[40] = 1;
    static const double sigmas[] = {0.5, 2, 3, 5, 16, 64, 97, 500};
    for (int q = 0; q < 2; q++)
        for (int s = 0; s < 8; s++) {
            WgImage *out = blur_q(src, sigmas[s], qualities[q], 2);
            double sum = image_mean(out, 0) * 97 * 61;
            if (fabs(sum - 1) > 1e-5)
                fail_msg("%s sigma %g: sum %.9g", qualities[q], sigmas[s], sum);
            wgt_assert_range(out, -1e-7, 1);
            wg_image_unref(out);
        }
    wg_image_unref(src);
}

static void test_flat_and_extreme_inputs(void **state)
{
    (void)state;
    static const float values[] = {0.3f, 1.0f, -7.25f, 1e6f, 0.0f};
    static const double sigmas[] = {0.4, 2, 6.5, 13, 29, 100};
    for (int v = 0; v < 5; v++) {
        WgImage *flat = wgt_image(29, 13, 1, NULL);
        for (int y = 0; y < 13; y++)
            for (int x = 0; x < 29; x++) wg_image_row(flat, y)[x] = values[v];
        for (int q = 0; q < 2; q++)
            for (int s = 0; s < 6; s++) {
                WgImage *out = blur_q(flat, sigmas[s], qualities[q], 2);
                /* exact: double sums, exact; fast: float sums and FFTs, within 1e-6 relative */
                double tol = q == 0 ? 0 : 1e-6 * fabs(values[v]);
                for (int y = 0; y < 13; y++)
                    for (int x = 0; x < 29; x++)
                        if (!(fabs(wgt_px(out, x, y, 0) - values[v]) <= tol))
                            fail_msg("%s flat %g sigma %g: %.9g at (%d,%d)", qualities[q],
                                     values[v], sigmas[s], wgt_px(out, x, y, 0), x, y);
                wg_image_unref(out);
            }
        wg_image_unref(flat);
    }
    /* a 1e6 spike on a small background: the reference holds in relative terms (to the peak) */
    WgImage *spike = wgt_image_fn(15, 11, 1, pattern_fn);
    wg_image_row(spike, 4)[6] = 1e6f;
    static const double spike_sigmas[] = {1.8, 4.5};
    for (int s = 0; s < 2; s++) {
        double *ref = reference(spike, spike_sigmas[s]);
        for (int q = 0; q < 2; q++) {
            WgImage *out = blur_q(spike, spike_sigmas[s], qualities[q], 2);
            for (int y = 0; y < 11; y++)
                for (int x = 0; x < 15; x++) {
                    double r = ref[y * 15 + x];
                    if (fabs(wgt_px(out, x, y, 0) - r) >
                        1e-6 * 1e6 * 1e-3 + 2e-6 * fabs(r) + (q == 1 ? 1e-6 * 1e6 : 0))
                        fail_msg("%s spike sigma %g (%d,%d): %.9g vs %.9g", qualities[q],
                                 spike_sigmas[s], x, y, wgt_px(out, x, y, 0), r);
                }
            wg_image_unref(out);
        }
        free(ref);
    }
    wg_image_unref(spike);
}

static double random_fn(int x, int y, int k)
{
    return (wg_hash3((uint32_t)x * 7919u, (uint32_t)y, (uint32_t)k + 11u) >> 8) / 16777215.0;
}
static double hdr_fn(int x, int y, int k)
{
    return 1e6 * random_fn(x, y, k);
}

/* fast against exact on random [0, 1] images, from 0.5 px to the image size; and on HDR data up
 * to 1e6, relative to the largest value; also 1×N and N×1. */
static void test_fast_matches_exact(void **state)
{
    (void)state;
    static const int shapes[][3] = {
        {97, 61, 1}, {320, 200, 1}, {40, 33, 4}, {1, 150, 1}, {150, 1, 1}};
    static const double sigmas[] = {0.5, 1, 2, 3, 5, 16, 64, 256, -1 /* the width */};
    double worst[2] = {0, 0};
    for (int s = 0; s < 5; s++)
        for (int hdr = 0; hdr < 2; hdr++) {
            WgImage *src =
                wgt_image_fn(shapes[s][0], shapes[s][1], shapes[s][2], hdr ? hdr_fn : random_fn);
            double scale = hdr ? 1e6 : 1;
            for (int i = 0; i < 9; i++) {
                double sigma = sigmas[i] < 0 ? src->width : sigmas[i];
                if (sigma * 256 / src->width > 16384) continue; /* beyond sigma's range */
                WgImage *a = blur_q(src, sigma, "exact", 2);
                WgImage *b = blur_q(src, sigma, "fast", 2);
                double d = wgt_max_abs_diff(a, b) / scale;
                if (!(d <= 1e-6))
                    fail_msg("%dx%dx%d%s sigma %g: fast differs from exact by %.3g", src->width,
                             src->height, src->channels, hdr ? " HDR" : "", sigma, d);
                worst[hdr] = fmax(worst[hdr], d);
                wg_image_unref(b);
                wg_image_unref(a);
            }
            wg_image_unref(src);
        }
    print_message("max |fast - exact|: %.3g on [0, 1], %.3g relative on [0, 1e6]\n", worst[0],
                  worst[1]);
}

static void test_errors(void **state)
{
    (void)state;
    WgImage *g = wgt_image(4, 4, 1, NULL);
    const char *names[] = {"source"};
    const WgImage *imgs[] = {g};
    WgError err;
    assert_int_equal(wgt_node_error("blur", "sigma=\"-1\"", 4, 4, 1, names, imgs, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "sigma"));
    assert_int_equal(err.line, 3);
    assert_int_equal(wgt_node_error("blur", "sigma=\"20000\"", 4, 4, 1, names, imgs, &err),
                     WG_ERR_RANGE);
    assert_int_not_equal(wgt_node_error("blur", "sigma=\"wide\"", 4, 4, 1, names, imgs, &err),
                         WG_OK);
    assert_int_not_equal(wgt_node_error("blur", "quality=\"best\"", 4, 4, 1, names, imgs, &err),
                         WG_OK);
    assert_non_null(strstr(err.message, "quality"));
    assert_int_not_equal(wgt_node_error("blur", "", 4, 4, 0, names, imgs, &err), WG_OK);
    wg_image_unref(g);
}

static void test_defaults(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(512, 9, 1, pattern_fn);
    const char *names[] = {"source"};
    const WgImage *imgs[] = {src};
    WgImage *a = wgt_node("blur", "", 512, 9, 1, names, imgs, 0, 1);
    WgImage *b = wgt_node("blur", "sigma=\"1\" quality=\"fast\"", 512, 9, 1, names, imgs, 0, 1);
    WgImage *c = blur_q(src, 2, "fast", 1); /* 1 × 512 / 256 */
    wgt_assert_identical(a, b);
    wgt_assert_identical(a, c);
    wg_image_unref(c);
    wg_image_unref(b);
    wg_image_unref(a);
    wg_image_unref(src);
}

/* The fast path's half spectrum counts against the memory budget: at 1024² gray and σ = 3 px
 * the two images take 8 MiB and the kept spectrum 3 MiB more. */
static void test_budget_counts_the_spectrum(void **state)
{
    (void)state;
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"1024\">\n"
                          "  <node id=\"u\" type=\"pixel\" expr=\"0.5\"/>\n"
                          "  <node id=\"soft\" type=\"blur\" sigma=\"0.75\">"
                          "<in name=\"source\" from=\"u\"/></node>\n"
                          "  <output name=\"out\" from=\"soft\"/>\n"
                          "</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    static const size_t mib = (size_t)1 << 20;
    WgEngine *e = wgt_engine(2, 10 * mib, NULL);
    WgResult *res = NULL;
    WgError err = {0};
    assert_int_equal(wg_render(e, r, &res, &err), WG_ERR_BUDGET);
    wgt_assert_error(&err, WG_ERR_BUDGET, 0, "'soft' (blur)");
    wg_engine_free(e);
    e = wgt_engine(2, 12 * mib, NULL);
    res = wgt_render_request(e, r);
    wgt_assert_range(wgt_output(res, "out"), 0.5 - 1e-6, 0.5 + 1e-6);
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_thread_invariance(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(45, 150, 4, pattern_fn);
    WgImage *gray = wgt_image_fn(97, 61, 1, random_fn);
    static const double sigmas[] = {0.6, 2.5, 5, 80, 200};
    for (int q = 0; q < 2; q++)
        for (int s = 0; s < 5; s++)
            for (int g = 0; g < 2; g++) {
                WgImage *a = blur_q(g ? gray : src, sigmas[s], qualities[q], 1);
                static const int threads[] = {2, 3, 8};
                for (int t = 0; t < 3; t++) {
                    WgImage *b = blur_q(g ? gray : src, sigmas[s], qualities[q], threads[t]);
                    wgt_assert_identical(a, b);
                    wg_image_unref(b);
                }
                wg_image_unref(a);
            }
    wg_image_unref(gray);
    wg_image_unref(src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_periodic_gaussian),
        cmocka_unit_test(test_sigma_is_a_length),
        cmocka_unit_test(test_sigma_zero_copies),
        cmocka_unit_test(test_sigma_beyond_the_image_is_the_mean),
        cmocka_unit_test(test_tiling_rolls_commute),
        cmocka_unit_test(test_edges_wrap),
        cmocka_unit_test(test_impulse_keeps_its_sum),
        cmocka_unit_test(test_flat_and_extreme_inputs),
        cmocka_unit_test(test_fast_matches_exact),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_budget_counts_the_spectrum),
        cmocka_unit_test(test_thread_invariance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
