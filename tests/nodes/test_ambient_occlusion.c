/* SPDX-License-Identifier: MIT */
/* `ambient_occlusion` against a float64 reference of the same bounded march (written
 * independently: texture positions, periodic bilinear interpolation), and against a dense
 * horizon search (256 azimuths, 1/4-pixel steps to the full radius) on a rough 64² field, which
 * measures the error of the sparse march and of the directions' azimuth sampling (the numbers
 * are printed and bounded here, and quoted in nodes/relief.c). Also: flat input, intensity 0 and
 * radius 0 exactly 1; a single spike darkens its surroundings and leaves pixels beyond the
 * radius exactly 1; a pit is darker than a slope; tiling; thread-count invariance; resolution
 * independence (64² and 256² of one wave); extreme and non-finite inputs; 1×N, N×1, 1×1. */
#include "heighttest.h"

static WgImage *ao(const WgImage *src, double intensity, double radius, int directions, int threads)
{
    char attrs[128];
    snprintf(attrs, sizeof attrs, "intensity=\"%.9g\" radius=\"%.9g\" directions=\"%d\"", intensity,
             radius, directions);
    return ht_run("ambient_occlusion", attrs, src, threads);
}

static int wrap(int v, int n)
{
    while (v < 0) v += n;
    while (v >= n) v -= n;
    return v;
}

/* Periodic bilinear height at texture position (px, py), in pixels. */
static double bilinear(const WgImage *img, double px, double py)
{
    double fx = floor(px), fy = floor(py), ax = px - fx, ay = py - fy;
    int w = img->width, h = img->height;
    int x0 = wrap((int)fx, w), x1 = wrap((int)fx + 1, w);
    const float *r0 = wg_image_row(img, wrap((int)fy, h)),
                *r1 = wg_image_row(img, wrap((int)fy + 1, h));
    double top = r0[x0] * (1 - ax) + r0[x1] * ax;
    double bot = r1[x0] * (1 - ax) + r1[x1] * ax;
    return top * (1 - ay) + bot * ay;
}

/* 1 − mean over `dirs` azimuths (starting at `phase` of a turn step) of sin(horizon), the
 * horizon the highest elevation over samples at distances t[0..n) pixels. */
static double horizon_ao(const WgImage *img, double intensity, int x, int y, int dirs, double phase,
                         const double *t, int n)
{
    double s = img->width / 256.0, sum = 0;
    for (int d = 0; d < dirs; d++) {
        double a = 2 * M_PI * (d + phase) / dirs, ca = cos(a), sa = sin(a), best = 0;
        double h0 = ht_h(img, x, y);
        for (int k = 0; k < n; k++) {
            double v = bilinear(img, x + t[k] * ca, y + t[k] * sa);
            best = fmax(best, intensity * (v - h0) / (t[k] / s));
        }
        sum += sin(atan(best));
    }
    return 1 - sum / dirs;
}

/* The node's march, as documented: n = min(32, ⌈R⌉) steps; even when R ≤ 32, else
 * max(k, R^(k/32)). */
static int node_distances(double r_px, double *t)
{
    if (r_px <= 0) return 0;
    if (r_px <= 32) {
        int n = (int)ceil(r_px);
        for (int k = 1; k <= n; k++) t[k - 1] = r_px * k / n;
        return n;
    }
    for (int k = 1; k <= 32; k++) t[k - 1] = fmax(k, pow(r_px, k / 32.0));
    t[31] = r_px;
    return 32;
}

/* A rough field: two waves plus hashed per-pixel noise (steps of up to 0.15). */
static double rough_fn(int x, int y, int k)
{
    (void)k;
    return 0.5 + 0.2 * sin(2 * M_PI * (x / 64.0 + 2 * y / 64.0)) +
           0.15 * sin(2 * M_PI * 3 * (x / 64.0 - y / 64.0) + 1) +
           0.15 * (wg_hash3((uint32_t)x, (uint32_t)y, 7) & 0xffff) / 65535.0;
}

static void test_against_float64_reference(void **state)
{
    (void)state;
    static const int shapes[][2] = {{24, 10}, {13, 17}, {1, 9}, {9, 1}, {1, 1}};
    static const double radii[] = {0.5, 40, 300, 1024}; /* px at 24 wide: 0.05 .. 96 */
    for (int s = 0; s < 5; s++) {
        WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], 1, ht_pattern_fn);
        for (int r = 0; r < 4; r++)
            for (int dirs = 1; dirs <= 9; dirs += 4) {
                double intensity = 3, t[32];
                int n = node_distances(radii[r] * src->width / 256.0, t);
                WgImage *out = ao(src, intensity, radii[r], dirs, 2);
                for (int y = 0; y < src->height; y++)
                    for (int x = 0; x < src->width; x++) {
                        double want = horizon_ao(src, intensity, x, y, dirs, 0, t, n);
                        if (!(fabs(wgt_px(out, x, y, 0) - want) <= 1e-6))
                            fail_msg("%dx%d radius %g dirs %d (%d,%d): %.9g, expected %.9g",
                                     src->width, src->height, radii[r], dirs, x, y,
                                     wgt_px(out, x, y, 0), want);
                    }
                wg_image_unref(out);
            }
        wg_image_unref(src);
    }
}

/* The error of the bounded march against a dense horizon search at 64². */
static void dense_error(const WgImage *src, double intensity, double radius, int dirs,
                        double *max_err, double *mean_err)
{
    double r_px = radius * src->width / 256.0, dense[1024];
    int nd = 0;
    for (double t = 0.25; t < r_px; t += 0.25) dense[nd++] = t;
    dense[nd++] = r_px;
    WgImage *out = ao(src, intensity, radius, dirs, 2);
    double worst = 0, sum = 0;
    for (int y = 0; y < src->height; y++)
        for (int x = 0; x < src->width; x++) {
            double e =
                fabs(wgt_px(out, x, y, 0) - horizon_ao(src, intensity, x, y, 256, 0.5, dense, nd));
            worst = fmax(worst, e);
            sum += e;
        }
    *max_err = worst;
    *mean_err = sum / (src->width * src->height);
    wg_image_unref(out);
}

static void test_error_against_dense_search(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(64, 64, 1, rough_fn);
    static const struct {
        double radius;
        int dirs;
        double max, mean; /* bounds: the measured values rounded up */
    } cases[] = {
        {16, 8, 0.1, 0.03},   {16, 32, 0.06, 0.01},  {64, 8, 0.1, 0.03},
        {64, 32, 0.06, 0.01}, {256, 32, 0.08, 0.03},
    };
    for (int c = 0; c < 5; c++) {
        double mx, mean;
        dense_error(src, 4, cases[c].radius, cases[c].dirs, &mx, &mean);
        printf("dense search, radius %g (%g px), %d directions: max %.4f mean %.4f\n",
               cases[c].radius, cases[c].radius / 4, cases[c].dirs, mx, mean);
        if (!(mx <= cases[c].max && mean <= cases[c].mean))
            fail_msg("radius %g dirs %d: max %g mean %g", cases[c].radius, cases[c].dirs, mx, mean);
    }
    wg_image_unref(src);
}

static void test_flat_and_neutral_are_exactly_one(void **state)
{
    (void)state;
    static const float values[] = {0.0f, 0.3f, -7.25f, 1e6f, 3.4e38f};
    for (int v = 0; v < 5; v++) {
        WgImage *src = ht_const(7, 5, values[v]);
        WgImage *out = ao(src, 1e6, 300, 7, 2);
        for (int y = 0; y < 5; y++)
            for (int x = 0; x < 7; x++)
                if (wgt_px(out, x, y, 0) != 1.0f)
                    fail_msg("flat %g: %g", values[v], wgt_px(out, x, y, 0));
        wg_image_unref(out);
        wg_image_unref(src);
    }
    WgImage *src = wgt_image_fn(20, 20, 1, ht_pattern_fn);
    WgImage *a = ao(src, 0, 64, 8, 2);
    WgImage *b = ao(src, 8, 0, 8, 2);
    for (int y = 0; y < 20; y++)
        for (int x = 0; x < 20; x++)
            assert_true(wgt_px(a, x, y, 0) == 1.0f && wgt_px(b, x, y, 0) == 1.0f);
    wg_image_unref(b);
    wg_image_unref(a);
    wg_image_unref(src);
}

/* One raised pixel at 64², radius 16 units = 4 px: the spike's top and every pixel farther than
 * 4 + √2 px are exactly 1; pixels 1..4 px away along the searched axes are darker. */
static void test_spike(void **state)
{
    (void)state;
    WgImage *src = wgt_image(64, 64, 1, NULL);
    wg_image_row(src, 32)[32] = 1;
    WgImage *out = ao(src, 4, 16, 8, 2);
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            double d = hypot(x - 32, y - 32);
            float v = wgt_px(out, x, y, 0);
            if (d > 4 + M_SQRT2 && v != 1.0f) fail_msg("(%d,%d) at %g px: %g", x, y, d, v);
            assert_true(v <= 1.0f && v >= 0.0f);
        }
    assert_true(wgt_px(out, 32, 32, 0) == 1.0f);
    for (int d = 1; d <= 4; d++) {
        assert_true(wgt_px(out, 32 + d, 32, 0) < 1.0f);
        assert_true(wgt_px(out, 32 - d, 32, 0) < 1.0f);
        assert_true(wgt_px(out, 32, 32 + d, 0) < 1.0f);
        assert_true(wgt_px(out, 32 + d, 32 + d, 0) < 1.0f || d > 2); /* diagonal: 1.41 d px */
    }
    /* closer to the spike, higher horizon */
    assert_true(wgt_px(out, 33, 32, 0) < wgt_px(out, 34, 32, 0));
    assert_true(wgt_px(out, 34, 32, 0) < wgt_px(out, 36, 32, 0));
    wg_image_unref(out);
    wg_image_unref(src);
}

/* A bowl: its bottom is enclosed on every side, its rim sees open sky on the outside. */
static double bowl_fn(int x, int y, int k)
{
    (void)k;
    double r = hypot(x - 32, y - 32);
    return r < 10 ? r * r / 100 : 1;
}

static void test_pit_darker_than_rim(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(64, 64, 1, bowl_fn);
    WgImage *out = ao(src, 64, 64, 16, 2);
    assert_true(wgt_px(out, 32, 32, 0) < 0.5f);
    assert_true(wgt_px(out, 32, 32, 0) < wgt_px(out, 32, 37, 0));
    assert_true(wgt_px(out, 32, 50, 0) == 1.0f); /* the plateau outside */
    wg_image_unref(out);
    wg_image_unref(src);
}

static void test_tiling_rolls_commute(void **state)
{
    (void)state;
    ht_assert_tiles("ambient_occlusion", "intensity=\"5\" radius=\"30\" directions=\"7\"");
    ht_assert_tiles("ambient_occlusion", "intensity=\"5\" radius=\"400\" directions=\"7\"");
}

static void test_thread_invariance(void **state)
{
    (void)state;
    ht_assert_thread_invariant("ambient_occlusion",
                               "intensity=\"3\" radius=\"20\" directions=\"8\"");
}

/* One wave at 64² and 256², radius 32 units (8 and 32 px): the same texture point gets nearly
 * the same occlusion (the coarse render's bilinear surface and sparser steps differ a little).
 * A radius in pixels would search a 4× smaller area of the texture in the large render, and a
 * height per pixel would make its slopes 4× steeper. */
static void test_resolution_independence(void **state)
{
    (void)state;
    WgImage *small = ht_wave(64, 64, 0.25, 1, 1);
    WgImage *large = ht_wave(256, 256, 0.25, 1, 1);
    WgImage *a = ao(small, 100, 32, 16, 2);
    WgImage *b = ao(large, 100, 32, 16, 2);
    double worst = 0, darkest = 1;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            worst = fmax(worst, fabs(wgt_px(a, x, y, 0) - wgt_px(b, 4 * x, 4 * y, 0)));
            darkest = fmin(darkest, wgt_px(a, x, y, 0));
        }
    printf("resolution independence: max difference %.5f, darkest %.3f\n", worst, darkest);
    assert_true(worst <= 0.02); /* measured 0.0136 */
    assert_true(darkest < 0.9);
    wg_image_unref(b);
    wg_image_unref(a);
    wg_image_unref(large);
    wg_image_unref(small);
}

static void test_extreme_inputs(void **state)
{
    (void)state;
    WgImage *checker = wgt_image(6, 6, 1, NULL);
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 6; x++) wg_image_row(checker, y)[x] = (x + y) % 2 ? 3.4e38f : -3.4e38f;
    WgImage *out = ao(checker, 1e6, 1024, 64, 2);
    wgt_assert_range(out, 0, 1);
    wg_image_unref(out);
    wg_image_unref(checker);
    WgImage *bad = wgt_image_fn(8, 6, 1, ht_pattern_fn);
    wg_image_row(bad, 2)[3] = INFINITY;
    wg_image_row(bad, 4)[5] = NAN;
    out = ao(bad, 5, 64, 8, 2);
    wgt_assert_range(out, 0, 1);
    assert_true(wgt_px(out, 2, 2, 0) < 0.95f); /* beside an infinite wall */
    WgImage *ref = ao(bad, 5, 64, 8, 1);
    wgt_assert_identical(out, ref);
    wg_image_unref(ref);
    wg_image_unref(out);
    wg_image_unref(bad);
}

static void test_thin_images(void **state)
{
    (void)state;
    static const float col[] = {0, 1, 4, 2, 2};
    WgImage *tall = wgt_image(1, 5, 1, col);
    WgImage *wide = wgt_image(5, 1, 1, col);
    WgImage *one = ht_const(1, 1, 0.7f);
    WgImage *t = ao(tall, 1, 1024, 8, 2);
    WgImage *w = ao(wide, 1, 1024, 8, 2);
    WgImage *o = ao(one, 1e6, 1024, 8, 2);
    wgt_assert_range(t, 0, 1);
    wgt_assert_range(w, 0, 1);
    assert_true(wgt_px(t, 0, 2, 0) == 1.0f && wgt_px(w, 2, 0, 0) == 1.0f); /* the top */
    assert_true(wgt_px(t, 0, 0, 0) < 1.0f && wgt_px(w, 0, 0, 0) < 1.0f);   /* the bottom */
    assert_true(wgt_px(o, 0, 0, 0) == 1.0f);
    wg_image_unref(o);
    wg_image_unref(w);
    wg_image_unref(t);
    wg_image_unref(one);
    wg_image_unref(wide);
    wg_image_unref(tall);
}

static void test_defaults_and_errors(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(12, 9, 1, ht_pattern_fn);
    WgImage *a = ht_run("ambient_occlusion", "", src, 1);
    WgImage *b = ao(src, 4, 8, 8, 1);
    wgt_assert_identical(a, b);
    wg_image_unref(b);
    wg_image_unref(a);
    const char *names[] = {"height"};
    const WgImage *gray[] = {src};
    WgError err;
    assert_int_equal(
        wgt_node_error("ambient_occlusion", "directions=\"0\"", 4, 4, 1, names, gray, &err),
        WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "directions"));
    assert_int_equal(
        wgt_node_error("ambient_occlusion", "radius=\"-1\"", 4, 4, 1, names, gray, &err),
        WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "radius"));
    wg_image_unref(src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_float64_reference),
        cmocka_unit_test(test_error_against_dense_search),
        cmocka_unit_test(test_flat_and_neutral_are_exactly_one),
        cmocka_unit_test(test_spike),
        cmocka_unit_test(test_pit_darker_than_rim),
        cmocka_unit_test(test_tiling_rolls_commute),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_resolution_independence),
        cmocka_unit_test(test_extreme_inputs),
        cmocka_unit_test(test_thin_images),
        cmocka_unit_test(test_defaults_and_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
