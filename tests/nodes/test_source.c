/* SPDX-License-Identifier: MIT */
/* Source nodes: `uniform` (gray values, linear colours, sRGB hex colours) and `image` (reading a
 * file, sRGB decoding, kind auto/gray/color, resampling to the node size against a float64
 * wrapping tent-filter reference, and errors). */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static WgImage *source(const char *type, const char *attrs, int w, int h)
{
    return wgt_node(type, attrs, w, h, 0, NULL, NULL, 0, 2);
}

static void assert_all(const WgImage *img, const float *px)
{
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            for (int k = 0; k < img->channels; k++)
                if (wgt_px(img, x, y, k) != px[k])
                    fail_msg("(%d,%d,%d) = %.9g, expected %.9g", x, y, k, wgt_px(img, x, y, k),
                             px[k]);
}

/* ---- uniform ----------------------------------------------------------------------------- */

static void test_uniform_gray(void **state)
{
    (void)state;
    WgImage *img = source("uniform", "value=\"0.3\"", 5, 3);
    assert_int_equal(img->width, 5);
    assert_int_equal(img->height, 3);
    assert_int_equal(img->channels, 1);
    assert_all(img, (float[]){0.3f});
    wg_image_unref(img);
    /* default: black; HDR values are fine */
    img = source("uniform", "", 2, 2);
    assert_int_equal(img->channels, 1);
    assert_all(img, (float[]){0.0f});
    wg_image_unref(img);
    img = source("uniform", "value=\"-2.5\"", 1, 1);
    assert_all(img, (float[]){-2.5f});
    wg_image_unref(img);
    img = source("uniform", "value=\"1e6\"", 3, 7);
    assert_all(img, (float[]){1e6f});
    wg_image_unref(img);
    /* kind gray ignores the colour */
    img = source("uniform", "kind=\"gray\" value=\"0.75\" color=\"1 0 0 1\"", 2, 2);
    assert_int_equal(img->channels, 1);
    assert_all(img, (float[]){0.75f});
    wg_image_unref(img);
}

static void test_uniform_linear_colour(void **state)
{
    (void)state;
    WgImage *img = source("uniform", "kind=\"color\" color=\"0.5 0.2 0.1 0.25\" value=\"9\"", 4, 6);
    assert_int_equal(img->channels, 4);
    assert_all(img, (float[]){0.5f, 0.2f, 0.1f, 0.25f});
    wg_image_unref(img);
    img = source("uniform", "kind=\"color\" color=\"0.1 0.2 0.3\"", 1, 1);
    assert_all(img, (float[]){0.1f, 0.2f, 0.3f, 1.0f});
    wg_image_unref(img);
    img = source("uniform", "kind=\"color\" color=\"0.25\"", 1, 1); /* one gray value */
    assert_all(img, (float[]){0.25f, 0.25f, 0.25f, 1.0f});
    wg_image_unref(img);
    img = source("uniform", "kind=\"color\" color=\"2.5, -1, 0, 1\"", 1, 1); /* HDR, commas */
    assert_all(img, (float[]){2.5f, -1.0f, 0.0f, 1.0f});
    wg_image_unref(img);
    img = source("uniform", "kind=\"color\"", 2, 1); /* default: opaque black */
    assert_all(img, (float[]){0, 0, 0, 1});
    wg_image_unref(img);
}

static double srgb_decode(double s)
{
    return s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4);
}

static void test_uniform_hex_colours_are_srgb(void **state)
{
    (void)state;
    struct {
        const char *text;
        int rgba[4];
    } cases[] = {
        {"#ff8000", {255, 128, 0, 255}}, {"#FF8000", {255, 128, 0, 255}},
        {"#f80", {255, 136, 0, 255}},    {"#ff800080", {255, 128, 0, 128}},
        {"#0000", {0, 0, 0, 0}},         {"#7f7f7f", {127, 127, 127, 255}},
        {"#0a0b0c", {10, 11, 12, 255}},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char attrs[128];
        snprintf(attrs, sizeof attrs, "kind=\"color\" color=\"%s\"", cases[i].text);
        WgImage *img = source("uniform", attrs, 2, 2);
        for (int k = 0; k < 4; k++) {
            double s = cases[i].rgba[k] / 255.0;
            double want = k < 3 ? srgb_decode(s) : s; /* alpha is not sRGB */
            float got = wgt_px(img, 1, 1, k);
            if (fabs(got - want) > 1e-7 * (1 + want))
                fail_msg("%s channel %d: %.9g, expected %.9g", cases[i].text, k, got, want);
        }
        wg_image_unref(img);
    }
    /* the known mid value: sRGB 0.5 (#808080 is 128/255) is about 0.2158605 linear */
    WgImage *img = source("uniform", "kind=\"color\" color=\"#808080\"", 1, 1);
    assert_float_equal(wgt_px(img, 0, 0, 0), 0.2158605, 1e-6);
    wg_image_unref(img);
}

static void test_uniform_errors(void **state)
{
    (void)state;
    WgError err;
    assert_int_equal(wgt_node_error("uniform", "value=\"2e6\"", 2, 2, 0, NULL, NULL, &err),
                     WG_ERR_RANGE);
    assert_int_not_equal(
        wgt_node_error("uniform", "kind=\"color\" color=\"#ff80z0\"", 2, 2, 0, NULL, NULL, &err),
        WG_OK);
    assert_non_null(strstr(err.message, "#ff80z0"));
    assert_int_not_equal(wgt_node_error("uniform", "kind=\"colour\"", 2, 2, 0, NULL, NULL, &err),
                         WG_OK);
    assert_non_null(strstr(err.message, "colour"));
    assert_int_not_equal(
        wgt_node_error("uniform", "kind=\"color\" color=\"1 2\"", 2, 2, 0, NULL, NULL, &err),
        WG_OK);
    assert_int_not_equal(
        wgt_node_error("uniform", "kind=\"color\" color=\"1 2 3 4 5\"", 2, 2, 0, NULL, NULL, &err),
        WG_OK);
}

/* ---- image ------------------------------------------------------------------------------- */

static double pic_fn(int x, int y, int k)
{
    if (k == 3) return ((x * 3 + y * 5) % 4 + 1) * 51 / 255.0; /* varied alpha */
    return ((x * 29 + y * 71 + k * 97) % 256) / 255.0;
}

static double gray_fn(int x, int y, int k)
{
    (void)k;
    return ((x * 4099 + y * 7919) % 65536) / 65535.0;
}

static void write_file(const char *name, int w, int h, int channels, double (*fn)(int, int, int),
                       WgFormat f)
{
    WgImage *img = wgt_image_fn(w, h, channels, fn);
    WgError err = {0};
    if (wg_image_write(wgt_path(name), img, f, WG_LINEAR, &err)) fail_msg("%s", err.message);
    wg_image_unref(img);
}

static void test_image_reads_colour_file(void **state)
{
    (void)state;
    write_file("pic.png", 6, 4, 4, pic_fn, WG_FORMAT_PNG);
    WgImage *img = source("image", "path=\"pic.png\"", 6, 4);
    assert_int_equal(img->channels, 4);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 6; x++)
            for (int k = 0; k < 4; k++)
                assert_float_equal(wgt_px(img, x, y, k), pic_fn(x, y, k), 1e-7);
    wg_image_unref(img);

    /* sRGB: colour channels decoded, alpha kept */
    img = source("image", "path=\"pic.png\" colorspace=\"srgb\"", 6, 4);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 6; x++)
            for (int k = 0; k < 4; k++) {
                double want = k < 3 ? srgb_decode(pic_fn(x, y, k)) : pic_fn(x, y, k);
                if (fabs(wgt_px(img, x, y, k) - want) > 3e-7)
                    fail_msg("(%d,%d,%d): %.9g vs %.9g", x, y, k, wgt_px(img, x, y, k), want);
            }
    wg_image_unref(img);

    /* kind=gray: Rec.709 luminance of the (decoded) colour */
    img = source("image", "path=\"pic.png\" colorspace=\"srgb\" kind=\"gray\"", 6, 4);
    assert_int_equal(img->channels, 1);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 6; x++) {
            double want = 0.2126 * srgb_decode(pic_fn(x, y, 0)) +
                          0.7152 * srgb_decode(pic_fn(x, y, 1)) +
                          0.0722 * srgb_decode(pic_fn(x, y, 2));
            assert_float_equal(wgt_px(img, x, y, 0), want, 1e-6);
        }
    wg_image_unref(img);
}

static double equal_rgb_fn(int x, int y, int k)
{
    return k == 3 ? 1.0 : ((x + 2 * y) * 23 % 256) / 255.0;
}

static void test_image_gray_of_equal_channels_is_exact(void **state)
{
    (void)state;
    write_file("greyish.png", 5, 5, 4, equal_rgb_fn, WG_FORMAT_PNG);
    WgImage *c = source("image", "path=\"greyish.png\"", 5, 5);
    WgImage *g = source("image", "path=\"greyish.png\" kind=\"gray\"", 5, 5);
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 5; x++) assert_true(wgt_px(g, x, y, 0) == wgt_px(c, x, y, 0));
    wg_image_unref(g);
    wg_image_unref(c);
}

static void test_image_reads_gray_file(void **state)
{
    (void)state;
    write_file("height.png", 7, 3, 1, gray_fn, WG_FORMAT_PNG16);
    WgImage *g = source("image", "path=\"height.png\"", 7, 3);
    assert_int_equal(g->channels, 1);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 7; x++)
            assert_float_equal(wgt_px(g, x, y, 0) * 65535.0, gray_fn(x, y, 0) * 65535.0, 0.01);
    /* kind=color: R = G = B, alpha 1 */
    WgImage *c = source("image", "path=\"height.png\" kind=\"color\"", 7, 3);
    assert_int_equal(c->channels, 4);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 7; x++) {
            for (int k = 0; k < 3; k++) assert_true(wgt_px(c, x, y, k) == wgt_px(g, x, y, 0));
            assert_true(wgt_px(c, x, y, 3) == 1.0f);
        }
    /* an absolute path works too; linear is the default */
    char attrs[1200];
    snprintf(attrs, sizeof attrs, "path=\"%s\" colorspace=\"linear\"", wgt_path("height.png"));
    WgImage *a = source("image", attrs, 7, 3);
    wgt_assert_identical(a, g);
    wg_image_unref(a);
    wg_image_unref(c);
    wg_image_unref(g);
}

/* Wrapping tent filter, float64: support max(1, src/dst) source pixels either side. */
static double tent_sample(const WgImage *src, int channel, int ox, int oy, int dw, int dh)
{
    double sx = (double)src->width / dw, sy = (double)src->height / dh;
    double hx = sx > 1 ? sx : 1, hy = sy > 1 ? sy : 1;
    double cx = (ox + 0.5) * sx - 0.5, cy = (oy + 0.5) * sy - 0.5;
    double sum = 0, wsum = 0;
    for (int j = (int)floor(cy - hy) - 1; j <= (int)ceil(cy + hy) + 1; j++) {
        double wy = 1 - fabs(j - cy) / hy;
        if (wy <= 0) continue;
        for (int i = (int)floor(cx - hx) - 1; i <= (int)ceil(cx + hx) + 1; i++) {
            double wx = 1 - fabs(i - cx) / hx;
            if (wx <= 0) continue;
            int xi = ((i % src->width) + src->width) % src->width;
            int yj = ((j % src->height) + src->height) % src->height;
            sum += wx * wy * wgt_px(src, xi, yj, channel);
            wsum += wx * wy;
        }
    }
    return sum / wsum;
}

static void test_image_is_resampled_to_the_node_size(void **state)
{
    (void)state;
    write_file("small.exr", 8, 6, 1, gray_fn, WG_FORMAT_EXR32);
    WgImage *orig = wgt_image_fn(8, 6, 1, gray_fn);
    static const int sizes[][2] = {{16, 12}, {4, 3}, {13, 5}, {8, 6}, {3, 17}};
    for (int s = 0; s < 5; s++) {
        int w = sizes[s][0], h = sizes[s][1];
        WgImage *img = source("image", "path=\"small.exr\"", w, h);
        assert_int_equal(img->width, w);
        assert_int_equal(img->height, h);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                double want = tent_sample(orig, 0, x, y, w, h);
                if (fabs(wgt_px(img, x, y, 0) - want) > 2e-6)
                    fail_msg("%dx%d (%d,%d): %.9g vs %.9g", w, h, x, y, wgt_px(img, x, y, 0), want);
            }
        wg_image_unref(img);
    }
    /* enlarging by 2 is bilinear between wrapped neighbours: the first column is a quarter of
     * the last source column and three quarters of the first */
    WgImage *big = source("image", "path=\"small.exr\"", 16, 6);
    double want = 0.25 * gray_fn(7, 2, 0) + 0.75 * gray_fn(0, 2, 0);
    assert_float_equal(wgt_px(big, 0, 2, 0), want, 1e-6);
    wg_image_unref(big);
    wg_image_unref(orig);
}

static void test_image_errors(void **state)
{
    (void)state;
    WgError err;
    assert_int_equal(wgt_node_error("image", "path=\"nowhere.png\"", 4, 4, 0, NULL, NULL, &err),
                     WG_ERR_IO);
    assert_non_null(strstr(err.message, "nowhere.png"));
    assert_int_equal(err.line, 2);
    assert_int_not_equal(wgt_node_error("image", "", 4, 4, 0, NULL, NULL, &err), WG_OK);
    assert_non_null(strstr(err.message, "path"));
    wgt_write_file(wgt_path("text.png"), "hello\n");
    assert_int_equal(wgt_node_error("image", "path=\"text.png\"", 4, 4, 0, NULL, NULL, &err),
                     WG_ERR_IO);
    wgt_assert_error(&err, WG_ERR_IO, 2, "node 'n'");
    assert_int_not_equal(
        wgt_node_error("image", "path=\"text.png\" kind=\"rgb\"", 4, 4, 0, NULL, NULL, &err),
        WG_OK);
    /* a file with NaN is rejected */
    WgImage *nan = wgt_image(2, 2, 1, (float[]){0, NAN, 0, 0});
    assert_int_equal(wg_image_write(wgt_path("nan.exr"), nan, WG_FORMAT_EXR32, WG_LINEAR, &err),
                     WG_OK);
    wg_image_unref(nan);
    assert_int_equal(wgt_node_error("image", "path=\"nan.exr\"", 2, 2, 0, NULL, NULL, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "pixel (1, 0)"));
}

static void test_sources_are_thread_invariant(void **state)
{
    (void)state;
    write_file("tv.png", 9, 70, 4, pic_fn, WG_FORMAT_PNG);
    WgImage *a =
        wgt_node("image", "path=\"tv.png\" colorspace=\"srgb\"", 30, 80, 0, NULL, NULL, 0, 1);
    WgImage *b =
        wgt_node("image", "path=\"tv.png\" colorspace=\"srgb\"", 30, 80, 0, NULL, NULL, 0, 8);
    wgt_assert_identical(a, b);
    wg_image_unref(b);
    wg_image_unref(a);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_uniform_gray),
        cmocka_unit_test(test_uniform_linear_colour),
        cmocka_unit_test(test_uniform_hex_colours_are_srgb),
        cmocka_unit_test(test_uniform_errors),
        cmocka_unit_test(test_image_reads_colour_file),
        cmocka_unit_test(test_image_gray_of_equal_channels_is_exact),
        cmocka_unit_test(test_image_reads_gray_file),
        cmocka_unit_test(test_image_is_resampled_to_the_node_size),
        cmocka_unit_test(test_image_errors),
        cmocka_unit_test(test_sources_are_thread_invariant),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
