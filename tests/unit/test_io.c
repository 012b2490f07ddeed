/* SPDX-License-Identifier: MIT */
/* Image I/O: exact integer round trips (PNG 8/16, TIFF 16), float and half EXR, the sRGB
 * transfer, channel mapping on read, unassociated alpha, RGB-when-opaque, atomic writes,
 * layered EXR (checked with OpenEXR's own C API), rejection of non-finite files, probe errors,
 * the format names, refusal of truncated or damaged JPEG and PNG files with one-line messages,
 * and the cause of a failed write on a full device. */
#include "wgtest.h"

#include "internal.h"
#include "wgio.h"

#include <dirent.h>
#include <fcntl.h>
#include <errno.h>
#include <math.h>
#include <openexr.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/wait.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

/* ---- helpers ----------------------------------------------------------------------------- */

static WgImage *read_ok(const char *path, int channels, WgColorspace cs)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path, channels, cs, &img, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("read %s: %s", path, buf);
    }
    return img;
}

static void write_ok(const char *path, const WgImage *img, WgFormat f, WgColorspace cs)
{
    WgError err = {0};
    if (wg_image_write(path, img, f, cs, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("write %s: %s", path, buf);
    }
}

static int probe_channels(const char *path)
{
    int w, h, c;
    WgError err = {0};
    assert_int_equal(wg_image_probe(path, &w, &h, &c, &err), WG_OK);
    return c;
}

static bool exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Names in a folder other than . and .., NULL-terminated, caller frees. */
static int list_dir(const char *dir, char names[][256], int max)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        if (n < max) snprintf(names[n], 256, "%s", e->d_name);
        n++;
    }
    closedir(d);
    return n;
}

static const char *fresh_dir(const char *name)
{
    const char *p = wgt_path(name);
    mkdir(p, 0777);
    return p;
}

/* ---- integer formats --------------------------------------------------------------------- */

static void test_png16_round_trip_is_exact(void **state)
{
    (void)state;
    /* all 65536 codes, k/65535 */
    WgImage *img = wgt_image(256, 256, 1, NULL);
    for (int k = 0; k < 65536; k++) wg_image_row(img, k / 256)[k % 256] = (float)(k / 65535.0);
    const char *path = wgt_path("all16.png");
    write_ok(path, img, WG_FORMAT_PNG16, WG_LINEAR);
    assert_int_equal(probe_channels(path), 1);
    WgImage *back = read_ok(path, 0, WG_LINEAR);
    assert_int_equal(back->channels, 1);
    for (int k = 0; k < 65536; k++) {
        double v = wgt_px(back, k % 256, k / 256, 0);
        /* exact to the code; the float is k/65535 to float precision */
        if (lround(v * 65535.0) != k || fabs(v - k / 65535.0) > 6e-8)
            fail_msg("code %d read back as %.9g", k, v);
    }
    /* file -> float -> file is bit for bit */
    const char *path2 = wgt_path("all16b.png");
    write_ok(path2, back, WG_FORMAT_PNG16, WG_LINEAR);
    WgImage *again = read_ok(path2, 0, WG_LINEAR);
    wgt_assert_identical(back, again);
    wg_image_unref(again);
    wg_image_unref(back);
    wg_image_unref(img);
}

static void test_png8_rounds_to_nearest_and_clamps(void **state)
{
    (void)state;
    /* columns: (k + 0.49)/255 -> k, (k + 0.51)/255 -> k + 1, and out-of-range values */
    float vals[] = {0.49f / 255,   0.51f / 255,   100.49f / 255, 100.51f / 255,
                    254.49f / 255, 254.51f / 255, -0.5f,         2.0f,
                    NAN,           1.0f,          0.0f,          0.5f};
    int expect[] = {0, 1, 100, 101, 254, 255, 0, 255, 0, 255, 0, 128};
    int n = (int)(sizeof vals / sizeof vals[0]);
    WgImage *img = wgt_image(n, 1, 1, vals);
    const char *path = wgt_path("round8.png");
    write_ok(path, img, WG_FORMAT_PNG, WG_LINEAR);
    WgImage *back = read_ok(path, 0, WG_LINEAR);
    for (int i = 0; i < n; i++) {
        double v = wgt_px(back, i, 0, 0);
        if (fabs(v * 255.0 - expect[i]) > 1e-4)
            fail_msg("value %d (%.9g) read back as %.9g, expected code %d", i, vals[i], v,
                     expect[i]);
    }
    wg_image_unref(back);
    wg_image_unref(img);
}

static void test_png16_clamps_and_rounds(void **state)
{
    (void)state;
    float vals[] = {-1.0f, 1.5f, 1000.4f / 65535, 1000.6f / 65535, NAN};
    int expect[] = {0, 65535, 1000, 1001, 0};
    WgImage *img = wgt_image(5, 1, 1, vals);
    const char *path = wgt_path("round16.png");
    write_ok(path, img, WG_FORMAT_PNG16, WG_LINEAR);
    WgImage *back = read_ok(path, 0, WG_LINEAR);
    for (int i = 0; i < 5; i++)
        if (fabs(wgt_px(back, i, 0, 0) * 65535.0 - expect[i]) > 1e-3)
            fail_msg("value %d read back as %.9g", i, wgt_px(back, i, 0, 0));
    wg_image_unref(back);
    wg_image_unref(img);
}

static double code_fn(int x, int y, int k)
{
    /* distinct 16-bit codes per channel; alpha 1 */
    if (k == 3) return 1.0;
    return ((x * 7919 + y * 104729 + k * 15485863) % 65536) / 65535.0;
}

static void test_tif16_round_trip_is_exact(void **state)
{
    (void)state;
    WgImage *img = wgt_image_fn(37, 23, 4, code_fn);
    const char *path = wgt_path("rgb16.tif");
    write_ok(path, img, WG_FORMAT_TIF16, WG_LINEAR);
    assert_int_equal(probe_channels(path), 3); /* opaque: written as RGB */
    WgImage *back = read_ok(path, 0, WG_LINEAR);
    assert_int_equal(back->channels, 4);
    for (int y = 0; y < 23; y++)
        for (int x = 0; x < 37; x++)
            for (int k = 0; k < 4; k++) {
                double want = code_fn(x, y, k) * 65535.0;
                double got = wgt_px(back, x, y, k) * 65535.0;
                if (fabs(got - want) > 0.01)
                    fail_msg("(%d,%d,%d): %.6f vs %.6f", x, y, k, got, want);
            }
    wg_image_unref(back);
    wg_image_unref(img);
}

static void test_tif16_keeps_alpha_unassociated(void **state)
{
    (void)state;
    float px[] = {0.2f, 0.6f, 1.0f, 0.5f, 1.0f, 0.25f, 0.75f, 0.0f};
    WgImage *img = wgt_image(2, 1, 4, px);
    const char *path = wgt_path("alpha16.tif");
    write_ok(path, img, WG_FORMAT_TIF16, WG_LINEAR);
    assert_int_equal(probe_channels(path), 4);
    WgImage *back = read_ok(path, 0, WG_LINEAR);
    for (int i = 0; i < 8; i++) {
        double want = floor(px[i] * 65535.0 + 0.5);
        double got = wgt_px(back, i / 4, 0, i % 4) * 65535.0;
        if (fabs(got - want) > 0.01) fail_msg("value %d: code %.4f, expected %.0f", i, got, want);
    }
    wg_image_unref(back);
    wg_image_unref(img);
}

/* ---- EXR --------------------------------------------------------------------------------- */

static void test_exr32_is_bit_exact(void **state)
{
    (void)state;
    float vals[] = {-3.5f,       1e6f,    1e-20f, 0.1f, -0.0f, 65504.0f,
                    123456.789f, -1e-30f, 1.0f,   2.5f, 1e30f, -7.25f};
    WgImage *gray = wgt_image(4, 3, 1, vals);
    const char *path = wgt_path("f32.exr");
    write_ok(path, gray, WG_FORMAT_EXR32, WG_LINEAR);
    WgImage *back = read_ok(path, 0, WG_LINEAR);
    wgt_assert_identical(gray, back);
    wg_image_unref(back);

    /* colour with alpha, and the colorspace is ignored for EXR */
    float rgba[] = {-3.5f, 1e6f, 0.1f, 0.25f, 4.0f, -0.125f, 1e-20f, 1.5f};
    WgImage *col = wgt_image(2, 1, 4, rgba);
    const char *path2 = wgt_path("f32rgba.exr");
    write_ok(path2, col, WG_FORMAT_EXR32, WG_SRGB);
    assert_int_equal(probe_channels(path2), 4);
    back = read_ok(path2, 0, WG_LINEAR);
    wgt_assert_identical(col, back);
    wg_image_unref(back);
    wg_image_unref(col);
    wg_image_unref(gray);
}

/* Nearest half value (round to nearest even), for normal and subnormal halves. */
static double to_half(double v)
{
    if (v == 0) return v;
    double a = fabs(v);
    int e;
    frexp(a, &e); /* a = m * 2^e, m in [0.5, 1) */
    int exp2 = e - 1;
    if (exp2 < -14) exp2 = -14; /* subnormal spacing 2^-24 */
    double ulp = ldexp(1.0, exp2 - 10);
    double q = nearbyint(a / ulp) * ulp;
    return v < 0 ? -q : q;
}

static void test_exr_half_within_half_precision(void **state)
{
    (void)state;
    float vals[] = {-3.5f,     1000.3f, 1e-3f, 0.1f, 0.333333f, 65504.0f,
                    -2.71828f, 1e-6f,   1.0f,  0.5f, 7.77f,     60000.0f};
    WgImage *img = wgt_image(12, 1, 1, vals);
    const char *path = wgt_path("half.exr");
    write_ok(path, img, WG_FORMAT_EXR, WG_LINEAR);
    WgImage *back = read_ok(path, 0, WG_LINEAR);
    for (int i = 0; i < 12; i++) {
        double got = wgt_px(back, i, 0, 0), want = to_half(vals[i]);
        if (got != want) fail_msg("%.9g stored as half %.9g, expected %.9g", vals[i], got, want);
        if (fabs(got - vals[i]) > fabs(vals[i]) * 0x1p-11 + 0x1p-25)
            fail_msg("%.9g -> %.9g is outside half precision", vals[i], got);
    }
    wg_image_unref(back);
    wg_image_unref(img);
}

/* ---- sRGB -------------------------------------------------------------------------------- */

static void test_srgb_transfer_functions(void **state)
{
    (void)state;
    assert_float_equal(wg_linear_to_srgb(0.5f), 0.7353569, 1e-7);
    assert_float_equal(wg_srgb_to_linear(0.7353569f), 0.5, 2e-7);
    assert_float_equal(wg_linear_to_srgb(0.0f), 0.0, 0);
    assert_float_equal(wg_linear_to_srgb(-0.25f), 0.0, 0);
    assert_float_equal(wg_linear_to_srgb(1.0f), 1.0, 1e-7);
    assert_float_equal(wg_srgb_to_linear(1.0f), 1.0, 0);
    assert_float_equal(wg_srgb_to_linear(0.0f), 0.0, 0);
    /* the linear segment */
    assert_float_equal(wg_srgb_to_linear(0.04f), 0.04 / 12.92, 1e-9);
    assert_float_equal(wg_linear_to_srgb(0.002f), 0.002 * 12.92, 1e-9);
    /* the two pieces meet */
    assert_float_equal(wg_srgb_to_linear(0.04045f), 0.0031308, 1e-7);
    assert_float_equal(wg_linear_to_srgb(0.0031308f), 0.04045, 1e-6);
    /* monotonic and inverse of each other on a fine grid */
    float prev = -1;
    for (int i = 0; i <= 1000; i++) {
        float s = i / 1000.0f;
        float l = wg_srgb_to_linear(s);
        if (!(l > prev)) fail_msg("not increasing at %g", s);
        prev = l;
        if (fabs(wg_linear_to_srgb(l) - s) > 2e-7) fail_msg("round trip of %g", s);
    }
}

static void test_srgb_png_round_trips_every_code(void **state)
{
    (void)state;
    WgImage *img = wgt_image(256, 1, 4, NULL);
    float *row = wg_image_row(img, 0);
    for (int k = 0; k < 256; k++) {
        row[4 * k + 0] = wg_srgb_to_linear(k / 255.0f);
        row[4 * k + 1] = wg_srgb_to_linear((255 - k) / 255.0f);
        row[4 * k + 2] = wg_srgb_to_linear((k * 37 % 256) / 255.0f);
        row[4 * k + 3] = k / 255.0f; /* alpha is never encoded */
    }
    const char *path = wgt_path("srgb8.png");
    write_ok(path, img, WG_FORMAT_PNG, WG_SRGB);
    WgImage *raw = read_ok(path, 0, WG_LINEAR);
    WgImage *lin = read_ok(path, 0, WG_SRGB);
    for (int k = 0; k < 256; k++) {
        int codes[4] = {k, 255 - k, k * 37 % 256, k};
        for (int c = 0; c < 4; c++) {
            double v = wgt_px(raw, k, 0, c) * 255.0;
            if (fabs(v - codes[c]) > 1e-4)
                fail_msg("pixel %d channel %d: code %.4f, expected %d", k, c, v, codes[c]);
            double l = wgt_px(lin, k, 0, c);
            double want = c == 3 ? codes[c] / 255.0 : wg_srgb_to_linear(codes[c] / 255.0f);
            if (fabs(l - want) > 3e-7)
                fail_msg("pixel %d channel %d decoded to %.9g, expected %.9g", k, c, l, want);
        }
    }
    wg_image_unref(lin);
    wg_image_unref(raw);
    wg_image_unref(img);
}

/* Opaque colour images are written as RGB (four pixels at a time where the processor allows),
 * others as RGBA whichever pixel has the alpha that is not 1: every width from 1 to 20 and a few
 * across the packing's stretches of 256 pixels, linear and sRGB, each code read back. */
static void test_rgb_codes_at_every_width(void **state)
{
    (void)state;
    int widths[27];
    for (int k = 0; k < 20; k++) widths[k] = k + 1;
    int wide[] = {255, 256, 257, 259, 300, 513, 517};
    memcpy(widths + 20, wide, sizeof wide);
    for (int wi = 0; wi < 27; wi++) {
        int w = widths[wi];
        for (int transparent = -1; transparent < 3; transparent++) {
            /* -1: opaque; else the pixel of row 2 whose alpha is 0.5: first, middle, last */
            int tx = transparent == 0 ? 0 : transparent == 1 ? w / 2 : w - 1;
            WgImage *img = wgt_image(w, 3, 4, NULL);
            for (int y = 0; y < 3; y++)
                for (int x = 0; x < w; x++) {
                    float *p = wg_image_row(img, y) + 4 * x;
                    for (int c = 0; c < 3; c++)
                        p[c] = (float)((x * 7 + y * 31 + c * 85) % 256) / 255.0f;
                    p[3] = transparent >= 0 && y == 2 && x == tx ? 0.5f : 1.0f;
                }
            for (int srgb = 0; srgb < 2; srgb++) {
                WgColorspace cs = srgb ? WG_SRGB : WG_LINEAR;
                const char *path = wgt_path("rgb_width.png");
                write_ok(path, img, WG_FORMAT_PNG, cs);
                assert_int_equal(probe_channels(path), transparent < 0 ? 3 : 4);
                WgImage *back = read_ok(path, 4, cs);
                for (int y = 0; y < 3; y++)
                    for (int x = 0; x < w; x++)
                        for (int c = 0; c < 4; c++) {
                            bool colour = c < 3;
                            int want = wg_quantize8(wgt_px(img, x, y, c), srgb && colour);
                            int got = wg_quantize8(wgt_px(back, x, y, c), srgb && colour);
                            if (got != want)
                                fail_msg("width %d, %s, alpha at %d: pixel (%d, %d) channel %d is "
                                         "%d, expected %d",
                                         w, srgb ? "sRGB" : "linear", transparent, x, y, c, got,
                                         want);
                        }
                wg_image_unref(back);
            }
            wg_image_unref(img);
        }
    }
}

/* sRGB decoding of integer files uses a table; it must give exactly the formula's result on the
 * value read, for every 16-bit code (and so every 8-bit one), and the formula elsewhere. */
static void test_srgb_decode_table_is_exact(void **state)
{
    (void)state;
    WgImage *img = wg_image_new(256, 256, 1);
    assert_non_null(img);
    for (int i = 0; i < 65536; i++) wg_image_row(img, i / 256)[i % 256] = (float)(i / 65535.0);
    const char *path = wgt_path("codes16.png");
    WgError err = {0};
    assert_int_equal(wg_image_write(path, img, WG_FORMAT_PNG16, WG_LINEAR, &err), WG_OK);
    WgImage *back = NULL, *raw = NULL;
    assert_int_equal(wg_image_read(path, 1, WG_SRGB, &back, &err), WG_OK);
    assert_int_equal(wg_image_read(path, 1, WG_LINEAR, &raw, &err), WG_OK);
    for (int i = 0; i < 65536; i++) {
        float want = wg_srgb_to_linear(wg_image_row(raw, i / 256)[i % 256]);
        float got = wg_image_row(back, i / 256)[i % 256];
        if (got != want) fail_msg("code %d: %.9g, formula %.9g", i, got, want);
    }
    wg_image_unref(back);
    wg_image_unref(raw);
    /* a float file takes the formula for values between codes and outside [0, 1] */
    float odd[4] = {0.3f, -0.25f, 1.5f, 0.5f + 1e-6f};
    WgImage *f = wgt_image(4, 1, 1, odd);
    path = wgt_path("odd.exr");
    assert_int_equal(wg_image_write(path, f, WG_FORMAT_EXR32, WG_LINEAR, &err), WG_OK);
    assert_int_equal(wg_image_read(path, 1, WG_SRGB, &back, &err), WG_OK);
    for (int x = 0; x < 4; x++) assert_true(wgt_px(back, x, 0, 0) == wg_srgb_to_linear(odd[x]));
    wg_image_unref(back);
    wg_image_unref(f);
    wg_image_unref(img);
}

static void test_srgb_png16_gray(void **state)
{
    (void)state;
    /* a gray image written as sRGB is encoded, as reading a gray file as sRGB decodes it: the
     * two are symmetric */
    float vals[] = {0.5f, 0.0f, 1.0f, 0.002f};
    WgImage *img = wgt_image(4, 1, 1, vals);
    const char *path = wgt_path("srgb16.png");
    write_ok(path, img, WG_FORMAT_PNG16, WG_SRGB);
    WgImage *raw = read_ok(path, 0, WG_LINEAR);
    WgImage *lin = read_ok(path, 0, WG_SRGB);
    for (int i = 0; i < 4; i++) {
        double want = floor(wg_linear_to_srgb(vals[i]) * 65535.0 + 0.5);
        double got = wgt_px(raw, i, 0, 0) * 65535.0;
        if (fabs(got - want) > 0.01) fail_msg("value %d: code %.3f, expected %.0f", i, got, want);
        if (fabs(wgt_px(lin, i, 0, 0) - vals[i]) > 2e-5)
            fail_msg("value %d: %.9g read back as %.9g", i, vals[i], wgt_px(lin, i, 0, 0));
    }
    wg_image_unref(lin);
    wg_image_unref(raw);
    wg_image_unref(img);
}

/* ---- channels ---------------------------------------------------------------------------- */

static void test_gray_file_maps_to_gray_or_rgba(void **state)
{
    (void)state;
    float vals[] = {0, 0.25f, 0.5f, 1};
    WgImage *img = wgt_image(2, 2, 1, vals);
    const char *path = wgt_path("gray.tif");
    write_ok(path, img, WG_FORMAT_TIF16, WG_LINEAR);
    assert_int_equal(probe_channels(path), 1);
    WgImage *g = read_ok(path, 0, WG_LINEAR);
    assert_int_equal(g->channels, 1);
    WgImage *c = read_ok(path, 4, WG_LINEAR);
    assert_int_equal(c->channels, 4);
    for (int i = 0; i < 4; i++) {
        float v = wgt_px(g, i % 2, i / 2, 0);
        assert_float_equal(v * 65535.0, floor(vals[i] * 65535.0 + 0.5), 1e-3);
        for (int k = 0; k < 3; k++) assert_true(wgt_px(c, i % 2, i / 2, k) == v);
        assert_true(wgt_px(c, i % 2, i / 2, 3) == 1.0f);
    }
    wg_image_unref(c);
    wg_image_unref(g);
    wg_image_unref(img);
}

static void test_colour_file_maps_to_rgba_or_luminance(void **state)
{
    (void)state;
    /* opaque RGB: pure red, equal channels, mixed */
    float px[] = {1, 0, 0, 1, 0.4f, 0.4f, 0.4f, 1, 0.1f, 0.7f, 0.3f, 1};
    WgImage *img = wgt_image(3, 1, 4, px);
    const char *path = wgt_path("rgb.exr");
    write_ok(path, img, WG_FORMAT_EXR32, WG_LINEAR);
    assert_int_equal(probe_channels(path), 3);
    WgImage *c = read_ok(path, 0, WG_LINEAR);
    assert_int_equal(c->channels, 4);
    wgt_assert_identical(img, c);
    WgImage *g = read_ok(path, 1, WG_LINEAR);
    assert_int_equal(g->channels, 1);
    assert_true(wgt_px(g, 0, 0, 0) == 0.2126f);
    assert_true(wgt_px(g, 1, 0, 0) == 0.4f); /* exactly the value when R = G = B */
    assert_float_equal(wgt_px(g, 2, 0, 0), 0.2126 * 0.1 + 0.7152 * 0.7 + 0.0722 * 0.3, 1e-6);
    wg_image_unref(g);
    wg_image_unref(c);
    wg_image_unref(img);

    /* RGBA with alpha < 1: luminance ignores alpha */
    float px2[] = {0.5f, 0.5f, 0.5f, 0.25f};
    img = wgt_image(1, 1, 4, px2);
    path = wgt_path("rgba.exr");
    write_ok(path, img, WG_FORMAT_EXR32, WG_LINEAR);
    assert_int_equal(probe_channels(path), 4);
    g = read_ok(path, 1, WG_LINEAR);
    assert_true(wgt_px(g, 0, 0, 0) == 0.5f);
    wg_image_unref(g);
    wg_image_unref(img);
}

/* Into gray: the gray channel; into colour: gray in R, G and B and the file's alpha. */
static void test_gray_alpha_file_reads_as_gray_or_gray_and_alpha(void **state)
{
    (void)state;
    /* a 2-channel (gray + alpha) PNG, written through the bridge directly */
    uint8_t data[] = {10, 255, 200, 128, 0, 0, 255, 50};
    char msg[256];
    const char *path = wgt_path("ga.png");
    assert_int_equal(wg__oiio_write(path, "png", data, 4, 1, 2, 8, msg, sizeof msg), 0);
    assert_int_equal(probe_channels(path), 2);
    WgImage *g = read_ok(path, 0, WG_LINEAR);
    assert_int_equal(g->channels, 1);
    for (int x = 0; x < 4; x++) assert_float_equal(wgt_px(g, x, 0, 0) * 255.0, data[2 * x], 1e-4);
    WgImage *c = read_ok(path, 4, WG_LINEAR);
    assert_int_equal(c->channels, 4);
    for (int x = 0; x < 4; x++) {
        assert_float_equal(wgt_px(c, x, 0, 1) * 255.0, data[2 * x], 1e-4);
        assert_float_equal(wgt_px(c, x, 0, 3) * 255.0, data[2 * x + 1], 1e-4);
    }
    wg_image_unref(c);
    wg_image_unref(g);
}

static void test_alpha_stays_unassociated_in_png(void **state)
{
    (void)state;
    /* codes chosen so the floats are exact k/255 */
    int codes[] = {51, 153, 255, 128, 200, 10, 90, 0, 255, 255, 255, 1};
    float px[12];
    for (int i = 0; i < 12; i++) px[i] = codes[i] / 255.0f;
    WgImage *img = wgt_image(3, 1, 4, px);
    const char *path = wgt_path("alpha8.png");
    write_ok(path, img, WG_FORMAT_PNG, WG_LINEAR);
    assert_int_equal(probe_channels(path), 4);
    WgImage *back = read_ok(path, 0, WG_LINEAR);
    for (int i = 0; i < 12; i++) {
        double got = wgt_px(back, i / 4, 0, i % 4) * 255.0;
        if (fabs(got - codes[i]) > 1e-4)
            fail_msg("pixel %d channel %d: code %.4f, expected %d (alpha %d)", i / 4, i % 4, got,
                     codes[i], codes[(i / 4) * 4 + 3]);
    }
    /* and through sRGB: the colour channels are encoded, alpha is not, nothing premultiplied */
    const char *path2 = wgt_path("alpha8srgb.png");
    write_ok(path2, back, WG_FORMAT_PNG, WG_SRGB);
    WgImage *back2 = read_ok(path2, 0, WG_SRGB);
    for (int i = 0; i < 12; i++) {
        double got = wgt_px(back2, i / 4, 0, i % 4), want = wgt_px(back, i / 4, 0, i % 4);
        if (i % 4 == 3) {
            if (got != want) fail_msg("alpha of pixel %d: %.9g vs %.9g", i / 4, got, want);
            continue;
        }
        /* one 8-bit sRGB step at most, measured where the quantisation happens */
        double d = fabs(wg_linear_to_srgb((float)got) - wg_linear_to_srgb((float)want));
        if (d > 0.5 / 255 + 1e-6)
            fail_msg("srgb pixel %d channel %d: %.6f vs %.6f", i / 4, i % 4, got, want);
    }
    wg_image_unref(back2);
    wg_image_unref(back);
    wg_image_unref(img);
}

static void test_rgb_written_when_alpha_is_one(void **state)
{
    (void)state;
    WgImage *img = wgt_image(3, 2, 4, NULL);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 3; x++) wg_image_row(img, y)[4 * x + 3] = 1.0f;
    const char *p1 = wgt_path("opaque.png");
    write_ok(p1, img, WG_FORMAT_PNG, WG_LINEAR);
    assert_int_equal(probe_channels(p1), 3);
    /* one pixel slightly transparent: RGBA */
    wg_image_row(img, 1)[4 * 2 + 3] = 0.999f;
    const char *p2 = wgt_path("nearly.png");
    write_ok(p2, img, WG_FORMAT_PNG, WG_LINEAR);
    assert_int_equal(probe_channels(p2), 4);
    const char *p3 = wgt_path("nearly.exr");
    write_ok(p3, img, WG_FORMAT_EXR, WG_LINEAR);
    assert_int_equal(probe_channels(p3), 4);
    /* gray stays 1 channel */
    WgImage *g = wgt_image(2, 2, 1, NULL);
    const char *p4 = wgt_path("gray1.exr");
    write_ok(p4, g, WG_FORMAT_EXR32, WG_LINEAR);
    assert_int_equal(probe_channels(p4), 1);
    wg_image_unref(g);
    wg_image_unref(img);
}

static void test_default_format_is_png16_for_gray_png8_for_colour(void **state)
{
    (void)state;
    float g[] = {1000 / 65535.0f};
    WgImage *gray = wgt_image(1, 1, 1, g);
    const char *p1 = wgt_path("default_gray.png");
    write_ok(p1, gray, WG_FORMAT_DEFAULT, WG_LINEAR);
    WgImage *b1 = read_ok(p1, 0, WG_LINEAR);
    assert_float_equal(wgt_px(b1, 0, 0, 0) * 65535.0, 1000, 1e-3); /* 16 bits kept */
    float c[] = {0.3f, 0.3f, 0.3f, 1};
    WgImage *col = wgt_image(1, 1, 4, c);
    const char *p2 = wgt_path("default_colour.png");
    write_ok(p2, col, WG_FORMAT_DEFAULT, WG_LINEAR);
    WgImage *b2 = read_ok(p2, 0, WG_LINEAR);
    assert_float_equal(wgt_px(b2, 0, 0, 0) * 255.0, 77, 1e-4); /* 8 bits: 0.3*255 = 76.5 -> 77 */
    wg_image_unref(b2);
    wg_image_unref(col);
    wg_image_unref(b1);
    wg_image_unref(gray);
}

/* ---- atomic writes ----------------------------------------------------------------------- */

static void test_temp_path_semantics(void **state)
{
    (void)state;
    char *a = wg__temp_path_for("/some/dir/height.png");
    char *b = wg__temp_path_for("/some/dir/height.png");
    assert_non_null(a);
    assert_non_null(b);
    assert_string_not_equal(a, b);
    /* same folder, hidden, same extension */
    assert_int_equal(strncmp(a, "/some/dir/.height.", 18), 0);
    assert_string_equal(a + strlen(a) - 4, ".png");
    assert_null(strchr(a + strlen("/some/dir/"), '/'));
    char *c = wg__temp_path_for("plain");
    assert_int_equal(strncmp(c, ".plain.tmp", 10), 0);
    assert_null(strchr(c, '/'));
    char *d = wg__temp_path_for("dir.v2/file");
    assert_int_equal(strncmp(d, "dir.v2/.file", 12), 0);
    wg_free(a);
    wg_free(b);
    wg_free(c);
    wg_free(d);
}

static void test_write_into_missing_folder_fails_and_leaves_nothing(void **state)
{
    (void)state;
    const char *dir = fresh_dir("atomic1");
    char missing[1024], path[1100];
    snprintf(missing, sizeof missing, "%s/no/such", dir);
    snprintf(path, sizeof path, "%s/out.png", missing);
    WgImage *img = wgt_image(2, 2, 1, NULL);
    WgError err = {0};
    assert_int_equal(wg_image_write(path, img, WG_FORMAT_PNG16, WG_LINEAR, &err), WG_ERR_IO);
    char msg[2048];
    wg_error_format(&err, msg, sizeof msg);
    assert_non_null(strstr(msg, path));
    assert_false(exists(missing));
    char names[8][256];
    assert_int_equal(list_dir(dir, names, 8), 0);
    /* the layered writer too */
    const WgImage *imgs[] = {img};
    const char *names1[] = {"h"};
    snprintf(path, sizeof path, "%s/out.exr", missing);
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_exr_write_layers(path, 1, names1, imgs, false, &err), WG_ERR_IO);
    assert_false(exists(missing));
    assert_int_equal(list_dir(dir, names, 8), 0);
    wg_image_unref(img);
}

static void test_successful_write_leaves_no_temp_files(void **state)
{
    (void)state;
    const char *dir = fresh_dir("atomic2");
    WgImage *img = wgt_image_fn(16, 8, 4, code_fn);
    static const WgFormat formats[] = {WG_FORMAT_PNG, WG_FORMAT_PNG16, WG_FORMAT_TIF16,
                                       WG_FORMAT_EXR, WG_FORMAT_EXR32};
    char path[1100];
    for (int i = 0; i < 5; i++) {
        snprintf(path, sizeof path, "%s/img%d.%s", dir, i, wg_format_extension(formats[i]));
        write_ok(path, img, formats[i], WG_LINEAR);
        write_ok(path, img, formats[i], WG_LINEAR); /* replacing an existing file */
    }
    const WgImage *imgs[] = {img};
    const char *names1[] = {"c"};
    snprintf(path, sizeof path, "%s/layers.exr", dir);
    WgError err = {0};
    assert_int_equal(wg_exr_write_layers(path, 1, names1, imgs, true, &err), WG_OK);
    char names[16][256];
    int n = list_dir(dir, names, 16);
    assert_int_equal(n, 6);
    for (int i = 0; i < n; i++)
        if (names[i][0] == '.') fail_msg("left-over temporary file %s", names[i]);
    wg_image_unref(img);
}

/* The next temporary name the writer will use for `path`: the counter is per process and
 * increments by one per call. */
static void next_temp_path(const char *path, char *out, size_t size)
{
    char *t = wg__temp_path_for(path);
    char *host = strrchr(t, '-'); /* "-<host><ext>" */
    *host = '\0';
    char *dash = strrchr(t, '-');
    unsigned c = (unsigned)strtoul(dash + 1, NULL, 10);
    snprintf(out, size, "%.*s-%u-%s", (int)(dash - t), t, c + 1, host + 1);
    wg_free(t);
}

static void test_failed_write_keeps_the_old_file(void **state)
{
    (void)state;
    const char *dir = fresh_dir("atomic3");
    char path[1100], blocker[1200];
    snprintf(path, sizeof path, "%s/keep.png", dir);
    WgImage *old = wgt_image_fn(8, 8, 1, code_fn);
    write_ok(path, old, WG_FORMAT_PNG16, WG_LINEAR);
    size_t n0;
    char *before = wgt_read_file(path, &n0);
    /* make the temporary file impossible to create: a folder sits at its name */
    next_temp_path(path, blocker, sizeof blocker);
    assert_int_equal(mkdir(blocker, 0777), 0);
    WgImage *other = wgt_image(8, 8, 1, NULL);
    WgError err = {0};
    assert_int_equal(wg_image_write(path, other, WG_FORMAT_PNG16, WG_LINEAR, &err), WG_ERR_IO);
    assert_string_equal(err.file, path);
    rmdir(blocker);
    size_t n1;
    char *after = wgt_read_file(path, &n1);
    assert_int_equal(n0, n1);
    assert_memory_equal(before, after, n0);
    char names[8][256];
    assert_int_equal(list_dir(dir, names, 8), 1);
    /* same for the layered EXR */
    snprintf(path, sizeof path, "%s/keep.exr", dir);
    const WgImage *imgs[] = {old};
    const char *lnames[] = {"h"};
    assert_int_equal(wg_exr_write_layers(path, 1, lnames, imgs, false, &err), WG_OK);
    free(before);
    before = wgt_read_file(path, &n0);
    next_temp_path(path, blocker, sizeof blocker);
    assert_int_equal(mkdir(blocker, 0777), 0);
    const WgImage *imgs2[] = {other};
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_exr_write_layers(path, 1, lnames, imgs2, false, &err), WG_ERR_IO);
    rmdir(blocker);
    free(after);
    after = wgt_read_file(path, &n1);
    assert_int_equal(n0, n1);
    assert_memory_equal(before, after, n0);
    assert_int_equal(list_dir(dir, names, 8), 2);
    free(before);
    free(after);
    wg_image_unref(other);
    wg_image_unref(old);
}

static void test_temp_names_are_recognised_exactly(void **state)
{
    (void)state;
    static const char *const targets[] = {"/d/height.png", "plain",      "dir.v2/file",
                                          "a.b.exr",       "/d/.hidden", "x.tmp5-6.png"};
    for (int i = 0; i < 6; i++) {
        char *t = wg__temp_path_for(targets[i]);
        const char *slash = strrchr(t, '/');
        assert_int_equal(wg__temp_name_pid(slash ? slash + 1 : t), (long)getpid());
        wg_free(t);
    }
    static const char *const others[] = {"height.png",
                                         "height.tmp12-1.png",
                                         ".height.tmp12-1.png.part",
                                         ".height.tmp12.png",
                                         ".height.tmp-1.png",
                                         ".height.tmp12-.png",
                                         ".height.tmp012-1.png",
                                         ".height.tmp12-01.png",
                                         ".height.tmp0-1.png",
                                         ".a.b.tmp12-1",
                                         ".tmp12-1.png",
                                         ".h.tmp99999999999-1.png",
                                         ".h.tmp12-99999999999.png",
                                         "d/.h.tmp12-1.png",
                                         ".h.tmp12-1x.png"};
    for (size_t i = 0; i < sizeof others / sizeof others[0]; i++)
        if (wg__temp_name_pid(others[i])) fail_msg("'%s' taken for a temporary", others[i]);
    assert_int_equal(wg__temp_name_pid(".a.b.tmp12-1.exr"), 12);
    assert_int_equal(wg__temp_name_pid(".x.tmp5-6.tmp7-8.png"), 7);
    assert_int_equal(wg__temp_name_pid("..tmp3-1.hidden"), 3);
}

/* Temporaries carry this machine's id beside the process id; names with another id, or without
 * one (earlier versions), are temporaries too, and the host part has exactly one form. */
static void test_temp_names_carry_the_host(void **state)
{
    (void)state;
    char *t = wg__temp_path_for("/d/height.png");
    char want[64];
    snprintf(want, sizeof want, "-%08x.png", (unsigned)wg__temp_host());
    assert_string_equal(t + strlen(t) - strlen(want), want);
    long long host = 0;
    assert_int_equal(wg__temp_name_parse(strrchr(t, '/') + 1, &host), (long)getpid());
    assert_true(host == (long long)wg__temp_host());
    wg_free(t);
    assert_int_equal(wg__temp_name_parse(".h.tmp12-1-0a1b2c3d.png", &host), 12);
    assert_true(host == 0x0a1b2c3d);
    assert_int_equal(wg__temp_name_parse(".h.tmp12-1-ffffffff", &host), 12);
    assert_true(host == 0xffffffffLL);
    assert_int_equal(wg__temp_name_parse(".h.tmp12-1.png", &host), 12);
    assert_true(host == -1);
    static const char *const others[] = {".h.tmp12-1-0A1B2C3D.png",  ".h.tmp12-1-0a1b2c3.png",
                                         ".h.tmp12-1-0a1b2c3d4.png", ".h.tmp12-1-0a1b2c3g.png",
                                         ".h.tmp12-1--a1b2c3d.png",  ".h.tmp12-1-0a1b2c3d.x.png"};
    for (size_t i = 0; i < sizeof others / sizeof others[0]; i++)
        if (wg__temp_name_pid(others[i])) fail_msg("'%s' taken for a temporary", others[i]);
}

static void touch_file(const char *dir, const char *name, time_t age)
{
    char p[1400];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    wgt_write_file(p, "partial");
    struct timespec ts[2] = {{time(NULL) - age, 0}, {time(NULL) - age, 0}};
    assert_int_equal(utimensat(AT_FDCWD, p, ts, 0), 0);
}

/* This machine's temporaries go when their process is gone; another machine's (whose processes
 * cannot be asked) and those without a host id only when a day has passed since they were last
 * written. */
static void test_stale_temporaries_by_host(void **state)
{
    (void)state;
    const char *dir = fresh_dir("stale_hosts");
    pid_t child = fork(); /* a process id that is certainly gone */
    assert_true(child >= 0);
    if (child == 0) _exit(0);
    assert_int_equal(waitpid(child, NULL, 0), child);
    unsigned self = (unsigned)wg__temp_host(), other = self ^ 0x5a5a5a5au;
    long dead = (long)child, live = (long)getpid();
    const time_t day = WG_TEMP_FOREIGN_AGE, fresh = 60;
    struct {
        const char *fmt;
        long pid;
        unsigned host;
        time_t age;
        bool removed;
    } cases[] = {
        {".a%d.tmp%ld-1-%08x.png", dead, self, fresh, true},        /* this host, gone */
        {".a%d.tmp%ld-1-%08x.png", live, self, fresh, false},       /* this host, running */
        {".a%d.tmp%ld-1-%08x.png", live, self, 2 * day, false},     /* running, however old */
        {".a%d.tmp%ld-1-%08x.png", dead, other, fresh, false},      /* another host: cannot tell */
        {".a%d.tmp%ld-1-%08x.png", dead, other, day - 3600, false}, /* ... less than a day */
        {".a%d.tmp%ld-1-%08x.png", live, other, day + 3600, true},  /* ... a day untouched */
        {".a%d.tmp%ld-1.png", dead, 0, fresh, false},               /* no host id */
        {".a%d.tmp%ld-1.png", live, 0, day + 3600, true},
        {"a%d.tmp%ld-1-%08x.png", dead, self, 2 * day, false}, /* not a temporary's name */
    };
    int n = (int)(sizeof cases / sizeof cases[0]), expect = 0;
    char names[16][256];
    for (int i = 0; i < n; i++) {
        snprintf(names[i], sizeof names[i], cases[i].fmt, i, cases[i].pid, cases[i].host);
        touch_file(dir, names[i], cases[i].age);
        expect += cases[i].removed;
    }
    char sub[1200]; /* a folder named like a stale temporary stays */
    snprintf(sub, sizeof sub, "%s/.d.tmp%ld-1-%08x.png", dir, dead, self);
    assert_int_equal(mkdir(sub, 0777), 0);
    assert_int_equal(wg_remove_stale_temporaries(dir), expect);
    for (int i = 0; i < n; i++) {
        char p[1400];
        snprintf(p, sizeof p, "%s/%s", dir, names[i]);
        if (wgt_exists(p) == cases[i].removed)
            fail_msg("'%s' should have been %s", names[i], cases[i].removed ? "removed" : "kept");
    }
    assert_true(wgt_exists(sub));
}

/* Temporaries of a write set, in the order the set made them. */
static int temps_in(const char *dir, char names[][256], int max)
{
    char all[32][256];
    int n = list_dir(dir, all, 32), k = 0;
    for (int i = 0; i < n; i++)
        if (wg__temp_name_pid(all[i]) == (long)getpid() && k < max)
            snprintf(names[k++], 256, "%s", all[i]);
    return k;
}

/* A staged file copied into another set: the copy is staged beside its own target, holds the
 * same bytes once committed, and the source stays staged; a file the set does not have is an
 * error that stages nothing. */
static void test_write_set_copy(void **state)
{
    (void)state;
    const char *dir = fresh_dir("setcopy");
    char a[1100], b[1100], c[1100];
    snprintf(a, sizeof a, "%s/a.bin", dir);
    snprintf(b, sizeof b, "%s/b.bin", dir);
    snprintf(c, sizeof c, "%s/c.bin", dir);
    static unsigned char bytes[300000];
    for (size_t i = 0; i < sizeof bytes; i++) bytes[i] = (unsigned char)(i * 7 + (i >> 9));
    WgError err = {0};
    WgWriteSet *from = wg_write_set_new(), *to = wg_write_set_new();
    assert_int_equal(wg_write_set_bytes(from, a, bytes, sizeof bytes, &err), WG_OK);
    assert_int_equal(wg_write_set_copy(to, b, from, 0, &err), WG_OK);
    assert_int_equal(wg_write_set_copy(to, c, from, 1, &err), WG_ERR_USAGE);
    assert_non_null(strstr(err.message, "no staged file 1"));
    char names[4][256];
    assert_int_equal(temps_in(dir, names, 4), 2); /* a's and b's */
    assert_int_equal(wg_write_set_commit(to, &err), WG_OK);
    assert_int_equal(wg_write_set_commit(from, &err), WG_OK);
    for (int k = 0; k < 2; k++) {
        size_t n;
        char *got = wgt_read_file(k ? b : a, &n);
        assert_int_equal(n, sizeof bytes);
        assert_memory_equal(got, bytes, n);
        free(got);
    }
    assert_int_equal(access(c, F_OK), -1);
    assert_int_equal(temps_in(dir, names, 4), 0);
    wg_write_set_free(to);
    wg_write_set_free(from);
}

/* A writer told what the caller found of a colour image's alpha lays the file out by it without
 * reading the image for it: RGB when told every alpha is 1, RGBA when told one is not (both for
 * an opaque image here), and found as usual when not told (-1) or for a gray image; PNG and EXR
 * alike. */
static void test_write_set_told_alpha(void **state)
{
    (void)state;
    const char *dir = fresh_dir("setalpha");
    WgImage *colour = wgt_image(9, 5, 4, NULL), *gray = wgt_image(9, 5, 1, NULL);
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 9; x++) {
            float *p = wg_image_row(colour, y) + 4 * x;
            p[0] = x / 8.0f, p[1] = y / 4.0f, p[2] = 0.5f, p[3] = 1.0f;
            wg_image_row(gray, y)[x] = (x + y) / 12.0f;
        }
    static const WgFormat formats[] = {WG_FORMAT_PNG, WG_FORMAT_PNG16, WG_FORMAT_EXR};
    for (size_t f = 0; f < sizeof formats / sizeof *formats; f++)
        for (int told = -1; told <= 1; told++)
            for (int g = 0; g < 2; g++) {
                char path[1100];
                snprintf(path, sizeof path, "%s/told.%s", dir, wg_format_extension(formats[f]));
                WgError err = {0};
                WgWriteSet *set = wg_write_set_new();
                assert_int_equal(
                    wg_write_set_image_alpha_on(set, path, g ? gray : colour, formats[f], WG_LINEAR,
                                                WG_PNG_COMPRESSION_FAST, NULL, told, &err),
                    WG_OK);
                assert_int_equal(wg_write_set_commit(set, &err), WG_OK);
                wg_write_set_free(set);
                int want = g ? 1 : told == 0 ? 4 : 3;
                if (probe_channels(path) != want)
                    fail_msg("%s, %s, told %d: %d channels, expected %d",
                             wg_format_extension(formats[f]), g ? "gray" : "colour", told,
                             probe_channels(path), want);
                WgImage *back = read_ok(path, g ? 1 : 4, WG_LINEAR);
                double tol = formats[f] == WG_FORMAT_PNG ? 0.51 / 255 : 1e-3;
                double d = wgt_max_abs_diff(back, g ? gray : colour);
                if (d > tol)
                    fail_msg("%s, %s, told %d: read back %g off", wg_format_extension(formats[f]),
                             g ? "gray" : "colour", told, d);
                wg_image_unref(back);
            }
    wg_image_unref(colour);
    wg_image_unref(gray);
}

/* A file in place copied into a set: the same bytes once committed, the source untouched; a
 * source that does not exist is an error naming the target and the source that stages
 * nothing. */
static void test_write_set_copy_file(void **state)
{
    (void)state;
    const char *dir = fresh_dir("setcopyfile");
    char a[1100], b[1100], c[1100], gone[1100];
    snprintf(a, sizeof a, "%s/a.bin", dir);
    snprintf(b, sizeof b, "%s/b.bin", dir);
    snprintf(c, sizeof c, "%s/c.bin", dir);
    snprintf(gone, sizeof gone, "%s/gone.bin", dir);
    static unsigned char bytes[200000];
    for (size_t i = 0; i < sizeof bytes; i++) bytes[i] = (unsigned char)(i * 13 + (i >> 7));
    WgError err = {0};
    WgWriteSet *set = wg_write_set_new();
    assert_int_equal(wg_write_set_bytes(set, a, bytes, sizeof bytes, &err), WG_OK);
    assert_int_equal(wg_write_set_commit(set, &err), WG_OK);
    assert_int_equal(wg_write_set_copy_file(set, b, a, &err), WG_OK);
    assert_int_equal(wg_write_set_copy_file(set, c, gone, &err), WG_ERR_IO);
    assert_string_equal(err.file, c);
    assert_non_null(strstr(err.message, "cannot read"));
    assert_non_null(strstr(err.message, "gone.bin"));
    char names[4][256];
    assert_int_equal(temps_in(dir, names, 4), 1); /* b's */
    assert_int_equal(wg_write_set_commit(set, &err), WG_OK);
    assert_true(wgt_same_file(a, b));
    size_t n;
    char *got = wgt_read_file(a, &n);
    assert_int_equal(n, sizeof bytes);
    assert_memory_equal(got, bytes, n);
    free(got);
    assert_int_equal(access(c, F_OK), -1);
    assert_int_equal(temps_in(dir, names, 4), 0);
    wg_write_set_free(set);
}

/* Three files of `bytes` (seeded by k) staged in a new set in dir as f0.bin .. f2.bin. */
static WgWriteSet *stage_three(const char *dir, int k, char path[3][1100])
{
    WgWriteSet *s = wg_write_set_new();
    assert_non_null(s);
    for (int i = 0; i < 3; i++) {
        unsigned char bytes[4096];
        for (size_t j = 0; j < sizeof bytes; j++) bytes[j] = (unsigned char)(j * 31 + i + 7 * k);
        snprintf(path[i], 1100, "%s/f%d.bin", dir, i);
        WgError err = {0};
        assert_int_equal(wg_write_set_bytes(s, path[i], bytes, sizeof bytes, &err), WG_OK);
    }
    return s;
}

/* Does the file hold what stage_three(k) staged for it? */
static bool holds_stage(const char *path, int i, int k)
{
    size_t n = 0;
    unsigned char *got = (unsigned char *)wgt_read_file(path, &n);
    bool same = n == 4096;
    for (size_t j = 0; same && j < n; j++) same = got[j] == (unsigned char)(j * 31 + i + 7 * k);
    free(got);
    return same;
}

typedef struct {
    WgWriteSet *set;
    int rc;
    atomic_bool returned;
} CommitJob;

static void *commit_thread(void *arg)
{
    CommitJob *j = arg;
    WgError err = {0};
    j->rc = wg_write_set_commit(j->set, &err);
    atomic_store(&j->returned, true);
    return NULL;
}

/* Staged temporaries are flushed to the disk on the flusher thread, and a commit renames
 * nothing before every one of its flushes is done: while the flusher is held, the commit waits
 * and the targets keep their old bytes; released, the three are flushed there and renamed. A
 * set freed uncommitted has its flushes dropped: removed, never flushed. */
static void test_write_set_flushes_on_a_thread(void **state)
{
    (void)state;
    const char *dir = fresh_dir("flush");
    char path[3][1100];
    WgWriteSet *s = stage_three(dir, 0, path);
    WgError err = {0};
    assert_int_equal(wg_write_set_commit(s, &err), WG_OK);
    wg_write_set_free(s);

    wg__flush_pause(true);
    long before = wg__flush_count();
    CommitJob j = {stage_three(dir, 1, path), -1};
    atomic_init(&j.returned, false);
    pthread_t t;
    assert_int_equal(pthread_create(&t, NULL, commit_thread, &j), 0);
    struct timespec wait = {0, 100 * 1000 * 1000};
    nanosleep(&wait, NULL);
    bool early = atomic_load(&j.returned);
    for (int i = 0; i < 3; i++) assert_true(holds_stage(path[i], i, 0));
    wg__flush_pause(false);
    assert_int_equal(pthread_join(t, NULL), 0);
    assert_false(early);
    assert_int_equal(j.rc, WG_OK);
    assert_int_equal(wg__flush_count() - before, 3);
    for (int i = 0; i < 3; i++) assert_true(holds_stage(path[i], i, 1));
    wg_write_set_free(j.set);

    wg__flush_pause(true);
    before = wg__flush_count();
    s = stage_three(dir, 2, path);
    wg_write_set_free(s);
    wg__flush_pause(false);
    char names[4][256];
    assert_int_equal(temps_in(dir, names, 4), 0);
    s = stage_three(dir, 3, path); /* flushed after the dropped ones: they are settled by then */
    assert_int_equal(wg_write_set_commit(s, &err), WG_OK);
    wg_write_set_free(s);
    assert_int_equal(wg__flush_count() - before, 3);
    for (int i = 0; i < 3; i++) assert_true(holds_stage(path[i], i, 3));
}

/* At most WG_FLUSH_QUEUE_MAX flushes wait, each with its file open: while the flusher is held,
 * the files staged beyond are flushed by their writer, and all are in place after the commit. */
static void test_write_set_flush_queue_is_bounded(void **state)
{
    (void)state;
    const char *dir = fresh_dir("flushmax");
    enum { N = WG_FLUSH_QUEUE_MAX + 6 };
    static char paths[N][1100];
    wg__flush_pause(true);
    long before = wg__flush_count();
    WgWriteSet *s = wg_write_set_new();
    WgError err = {0};
    for (int i = 0; i < N; i++) {
        snprintf(paths[i], sizeof paths[i], "%s/f%03d.bin", dir, i);
        assert_int_equal(wg_write_set_bytes(s, paths[i], &i, sizeof i, &err), WG_OK);
    }
    wg__flush_pause(false);
    assert_int_equal(wg_write_set_commit(s, &err), WG_OK);
    wg_write_set_free(s);
    assert_int_equal(wg__flush_count() - before, WG_FLUSH_QUEUE_MAX);
    for (int i = 0; i < N; i++) {
        size_t n = 0;
        char *got = wgt_read_file(paths[i], &n);
        assert_int_equal(n, sizeof i);
        assert_memory_equal(got, &i, sizeof i);
        free(got);
    }
}

/* A child made by fork while its parent's flushes wait has no flusher thread: they come back
 * to it unflushed and its commit flushes them itself, instead of waiting forever. */
static void test_write_set_commit_after_fork(void **state)
{
    (void)state;
    const char *dir = fresh_dir("flushfork");
    char path[3][1100];
    wg__flush_pause(true);
    WgWriteSet *s = stage_three(dir, 4, path);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        alarm(20); /* a commit waiting forever fails the test */
        WgError err = {0};
        _exit(wg_write_set_commit(s, &err) == WG_OK ? 0 : 1);
    }
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    wg__flush_pause(false);
    assert_true(WIFEXITED(status));
    assert_int_equal(WEXITSTATUS(status), 0);
    for (int i = 0; i < 3; i++) assert_true(holds_stage(path[i], i, 4));
    wg_write_set_free(s); /* the parent's temporaries are the renamed files: nothing left */
    char names[4][256];
    assert_int_equal(temps_in(dir, names, 4), 0);
}

static void test_write_set_replaces_all_or_reports_which(void **state)
{
    (void)state;
    const char *dir = fresh_dir("set1");
    char path[3][1100], blocker[1200];
    WgImage *old = wgt_image(4, 4, 1, NULL);
    WgImage *img = wgt_image_fn(4, 4, 1, code_fn);
    static const char *const names[] = {"a.png", "b.png", "c.png"};
    for (int i = 0; i < 3; i++) {
        snprintf(path[i], sizeof path[i], "%s/%s", dir, names[i]);
        write_ok(path[i], old, WG_FORMAT_PNG16, WG_LINEAR);
    }
    size_t n_old;
    char *old_bytes = wgt_read_file(path[0], &n_old);
    WgError err = {0};

    /* nothing changes before commit, and freeing an uncommitted set removes its temporaries */
    WgWriteSet *s = wg_write_set_new();
    assert_non_null(s);
    for (int i = 0; i < 3; i++)
        assert_int_equal(wg_write_set_image(s, path[i], img, WG_FORMAT_PNG16, WG_LINEAR, &err),
                         WG_OK);
    char t[4][256];
    assert_int_equal(temps_in(dir, t, 4), 3);
    for (int i = 0; i < 3; i++) {
        size_t n;
        char *b = wgt_read_file(path[i], &n);
        assert_true(n == n_old && !memcmp(b, old_bytes, n));
        free(b);
    }
    wg_write_set_free(s);
    char all[8][256];
    assert_int_equal(list_dir(dir, all, 8), 3);

    /* a folder at the last target: refused before any rename */
    snprintf(blocker, sizeof blocker, "%s/d.png", dir);
    assert_int_equal(mkdir(blocker, 0777), 0);
    s = wg_write_set_new();
    for (int i = 0; i < 2; i++)
        assert_int_equal(wg_write_set_image(s, path[i], img, WG_FORMAT_PNG16, WG_LINEAR, &err),
                         WG_OK);
    assert_int_equal(wg_write_set_image(s, blocker, img, WG_FORMAT_PNG16, WG_LINEAR, &err), WG_OK);
    assert_int_equal(wg_write_set_commit(s, &err), WG_ERR_IO);
    wgt_assert_error(&err, WG_ERR_IO, 0, "d.png|Is a directory|no file was replaced");
    wg_write_set_free(s);
    rmdir(blocker);
    assert_int_equal(list_dir(dir, all, 8), 3);
    for (int i = 0; i < 3; i++) {
        size_t n;
        char *b = wgt_read_file(path[i], &n);
        assert_true(n == n_old && !memcmp(b, old_bytes, n));
        free(b);
    }

    /* a rename failing in the middle (the second temporary vanished): the first file is
     * replaced, the others are not, no temporary stays, and the error says all of it */
    s = wg_write_set_new();
    for (int i = 0; i < 3; i++)
        assert_int_equal(wg_write_set_image(s, path[i], img, WG_FORMAT_PNG16, WG_LINEAR, &err),
                         WG_OK);
    assert_int_equal(temps_in(dir, t, 4), 3);
    for (int i = 0; i < 3; i++)
        if (!strncmp(t[i], ".b.", 3)) {
            char p[1400];
            snprintf(p, sizeof p, "%s/%s", dir, t[i]);
            assert_int_equal(unlink(p), 0);
        }
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_write_set_commit(s, &err), WG_ERR_IO);
    assert_string_equal(err.file, path[1]);
    char want[4000];
    snprintf(want, sizeof want,
             "cannot replace the file: No such file or directory|replaced: %s|not replaced: %s, "
             "%s",
             path[0], path[1], path[2]);
    wgt_assert_error(&err, WG_ERR_IO, 0, want);
    wg_write_set_free(s);
    assert_int_equal(list_dir(dir, all, 8), 3);
    WgImage *a = NULL, *c = NULL;
    assert_int_equal(wg_image_read(path[0], 1, WG_LINEAR, &a, &err), WG_OK);
    assert_int_equal(wg_image_read(path[2], 1, WG_LINEAR, &c, &err), WG_OK);
    assert_float_equal(wgt_px(a, 1, 2, 0), wgt_px(img, 1, 2, 0), 1e-4);
    assert_float_equal(wgt_px(c, 1, 2, 0), 0, 0);
    wg_image_unref(a);
    wg_image_unref(c);

    /* a target named like a temporary is refused: a later clean-up would delete it */
    char tmpname[1200];
    snprintf(tmpname, sizeof tmpname, "%s/.x.tmp12-3.png", dir);
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_image_write(tmpname, img, WG_FORMAT_PNG16, WG_LINEAR, &err), WG_ERR_USAGE);
    wgt_assert_error(&err, WG_ERR_USAGE, 0, ".x.tmp12-3.png|form of a temporary file");
    assert_int_equal(list_dir(dir, all, 8), 3);
    free(old_bytes);
    wg_image_unref(img);
    wg_image_unref(old);
}

/* ---- layered EXR ------------------------------------------------------------------------- */

typedef struct {
    int n;
    char names[16][64];
    int types[16];
    float *planes[16];
    int width, height;
} ExrData;

static void quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    (void)code;
    (void)msg;
}

/* Read every channel of part 0 as float planes with OpenEXR's C API. */
static void exr_read_all(const char *path, ExrData *d)
{
    memset(d, 0, sizeof *d);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    exr_context_t ctx = NULL;
    assert_int_equal(exr_start_read(&ctx, path, &init), EXR_ERR_SUCCESS);
    int parts = 0;
    assert_int_equal(exr_get_count(ctx, &parts), EXR_ERR_SUCCESS);
    assert_int_equal(parts, 1);
    const exr_attr_chlist_t *chl = NULL;
    assert_int_equal(exr_get_channels(ctx, 0, &chl), EXR_ERR_SUCCESS);
    assert_true(chl->num_channels <= 16);
    exr_attr_box2i_t dw;
    assert_int_equal(exr_get_data_window(ctx, 0, &dw), EXR_ERR_SUCCESS);
    d->width = dw.max.x - dw.min.x + 1;
    d->height = dw.max.y - dw.min.y + 1;
    d->n = chl->num_channels;
    for (int c = 0; c < d->n; c++) {
        snprintf(d->names[c], 64, "%s", chl->entries[c].name.str);
        d->types[c] = chl->entries[c].pixel_type;
        d->planes[c] = calloc((size_t)d->width * (size_t)d->height, sizeof(float));
        assert_non_null(d->planes[c]);
    }
    int32_t lines = 1;
    assert_int_equal(exr_get_scanlines_per_chunk(ctx, 0, &lines), EXR_ERR_SUCCESS);
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    bool init_done = false;
    for (int y = dw.min.y; y <= dw.max.y; y += lines) {
        exr_chunk_info_t ci;
        assert_int_equal(exr_read_scanline_chunk_info(ctx, 0, y, &ci), EXR_ERR_SUCCESS);
        if (!init_done)
            assert_int_equal(exr_decoding_initialize(ctx, 0, &ci, &dec), EXR_ERR_SUCCESS);
        else
            assert_int_equal(exr_decoding_update(ctx, 0, &ci, &dec), EXR_ERR_SUCCESS);
        init_done = true;
        for (int c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            int idx = -1;
            for (int k = 0; k < d->n; k++)
                if (!strcmp(d->names[k], ch->channel_name)) idx = k;
            assert_true(idx >= 0);
            ch->decode_to_ptr =
                (uint8_t *)(d->planes[idx] + (size_t)(ci.start_y - dw.min.y) * (size_t)d->width);
            ch->user_pixel_stride = 4;
            ch->user_line_stride = 4 * d->width;
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
        }
        assert_int_equal(exr_decoding_choose_default_routines(ctx, 0, &dec), EXR_ERR_SUCCESS);
        assert_int_equal(exr_decoding_run(ctx, 0, &dec), EXR_ERR_SUCCESS);
    }
    if (init_done) exr_decoding_destroy(ctx, &dec);
    exr_finish(&ctx);
}

static void exr_free(ExrData *d)
{
    for (int c = 0; c < d->n; c++) free(d->planes[c]);
}

static const float *exr_plane(const ExrData *d, const char *name)
{
    for (int c = 0; c < d->n; c++)
        if (!strcmp(d->names[c], name)) return d->planes[c];
    fail_msg("no channel %s", name);
    return NULL;
}

static double layer_fn(int x, int y, int k)
{
    return (x - 3) * 0.75 + y * 1.5 - k * 2.25 + (x * y % 3) * 1e3;
}

static void test_layered_exr_channels_and_values(void **state)
{
    (void)state;
    WgImage *height = wgt_image_fn(9, 5, 1, layer_fn);
    WgImage *colour = wgt_image_fn(9, 5, 4, layer_fn);
    WgImage *mask = wgt_image_fn(9, 5, 1, code_fn);
    const WgImage *imgs[] = {height, colour, mask};
    const char *names[] = {"height", "base.color", "mask"};
    for (int half = 0; half < 2; half++) {
        const char *path = wgt_path(half ? "layers_half.exr" : "layers.exr");
        WgError err = {0};
        assert_int_equal(wg_exr_write_layers(path, 3, names, imgs, half, &err), WG_OK);
        ExrData d;
        exr_read_all(path, &d);
        assert_int_equal(d.width, 9);
        assert_int_equal(d.height, 5);
        /* channel lists are stored sorted */
        static const char *const expect[] = {"base.color.A", "base.color.B", "base.color.G",
                                             "base.color.R", "height.Y",     "mask.Y"};
        assert_int_equal(d.n, 6);
        for (int c = 0; c < 6; c++) {
            assert_string_equal(d.names[c], expect[c]);
            assert_int_equal(d.types[c], half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT);
        }
        const float *h = exr_plane(&d, "height.Y"), *m = exr_plane(&d, "mask.Y");
        const float *rgba[4] = {exr_plane(&d, "base.color.R"), exr_plane(&d, "base.color.G"),
                                exr_plane(&d, "base.color.B"), exr_plane(&d, "base.color.A")};
        for (int y = 0; y < 5; y++)
            for (int x = 0; x < 9; x++) {
                size_t i = (size_t)y * 9 + (size_t)x;
                double want_h = wgt_px(height, x, y, 0), want_m = wgt_px(mask, x, y, 0);
                if (half) {
                    want_h = to_half(want_h);
                    want_m = to_half(want_m);
                }
                if (h[i] != (float)want_h)
                    fail_msg("height (%d,%d): %.9g vs %.9g", x, y, h[i], want_h);
                if (m[i] != (float)want_m)
                    fail_msg("mask (%d,%d): %.9g vs %.9g", x, y, m[i], want_m);
                for (int k = 0; k < 4; k++) {
                    double want = wgt_px(colour, x, y, k);
                    if (half) want = to_half(want);
                    if (rgba[k][i] != (float)want)
                        fail_msg("colour (%d,%d,%d): %.9g vs %.9g", x, y, k, rgba[k][i], want);
                }
            }
        exr_free(&d);
    }
    wg_image_unref(mask);
    wg_image_unref(colour);
    wg_image_unref(height);
}

static void test_layered_exr_rejects_bad_layers(void **state)
{
    (void)state;
    WgImage *a = wgt_image(4, 4, 1, NULL), *b = wgt_image(4, 3, 1, NULL);
    const char *path = wgt_path("bad_layers.exr");
    WgError err = {0};
    const WgImage *sizes[] = {a, b};
    const char *n2[] = {"a", "b"};
    assert_int_equal(wg_exr_write_layers(path, 2, n2, sizes, false, &err), WG_ERR_USAGE);
    assert_non_null(strstr(err.message, "'b' is 4x3"));
    const WgImage *dup[] = {a, a};
    const char *same[] = {"x", "x"};
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_exr_write_layers(path, 2, same, dup, false, &err), WG_ERR_USAGE);
    assert_non_null(strstr(err.message, "'x' given twice"));
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_exr_write_layers(path, 0, same, dup, false, &err), WG_ERR_USAGE);
    assert_false(exists(path));
    wg_image_unref(a);
    wg_image_unref(b);
}

/* ---- errors on read ---------------------------------------------------------------------- */

static void test_non_finite_values_are_rejected(void **state)
{
    (void)state;
    WgImage *img = wgt_image(6, 4, 1, NULL);
    wg_image_row(img, 2)[3] = NAN;
    wg_image_row(img, 3)[0] = INFINITY;
    const char *path = wgt_path("nan.exr");
    write_ok(path, img, WG_FORMAT_EXR32, WG_LINEAR);
    WgImage *out = NULL;
    WgError err = {0};
    assert_int_equal(wg_image_read(path, 0, WG_LINEAR, &out, &err), WG_ERR_RANGE);
    assert_null(out);
    wgt_assert_error(&err, WG_ERR_RANGE, 0, "pixel (3, 2)");
    assert_non_null(strstr(err.message, "2 non-finite"));
    assert_string_equal(err.file, path);
    /* colour: the pixel, not the value index */
    WgImage *c = wgt_image(5, 3, 4, NULL);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 5; x++) wg_image_row(c, y)[4 * x + 3] = 1;
    wg_image_row(c, 1)[4 * 4 + 2] = -INFINITY;
    const char *path2 = wgt_path("inf.exr");
    write_ok(path2, c, WG_FORMAT_EXR, WG_LINEAR);
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_image_read(path2, 4, WG_LINEAR, &out, &err), WG_ERR_RANGE);
    wgt_assert_error(&err, WG_ERR_RANGE, 0, "pixel (4, 1)");
    wg_image_unref(c);
    wg_image_unref(img);
}

static void test_probe_errors_name_the_path(void **state)
{
    (void)state;
    int w, h, c;
    WgError err = {0};
    const char *missing = wgt_path("does_not_exist.png");
    assert_int_equal(wg_image_probe(missing, &w, &h, &c, &err), WG_ERR_IO);
    assert_string_equal(err.file, missing);
    char msg[2048];
    wg_error_format(&err, msg, sizeof msg);
    assert_non_null(strstr(msg, missing));

    const char *text = wgt_path("not_an_image.png");
    wgt_write_file(text, "this is not a picture\n");
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_image_probe(text, &w, &h, &c, &err), WG_ERR_IO);
    assert_string_equal(err.file, text);
    assert_non_null(strstr(err.message, "cannot read the image"));

    WgImage *img = NULL;
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_image_read(text, 0, WG_LINEAR, &img, &err), WG_ERR_IO);
    assert_null(img);
    assert_string_equal(err.file, text);

    memset(&err, 0, sizeof err);
    assert_int_equal(wg_image_probe(wgt_tmpdir(), &w, &h, &c, &err), WG_ERR_IO);
    assert_non_null(strstr(err.message, "not a regular file"));

    /* an empty file */
    const char *empty = wgt_path("empty.exr");
    wgt_write_file(empty, "");
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_image_probe(empty, &w, &h, &c, &err), WG_ERR_IO);
    assert_string_equal(err.file, empty);
}

static void test_probe_reports_shape(void **state)
{
    (void)state;
    WgImage *img = wgt_image(13, 7, 1, NULL);
    const char *path = wgt_path("shape.png");
    write_ok(path, img, WG_FORMAT_PNG16, WG_LINEAR);
    int w = 0, h = 0, c = 0;
    WgError err = {0};
    assert_int_equal(wg_image_probe(path, &w, &h, &c, &err), WG_OK);
    assert_int_equal(w, 13);
    assert_int_equal(h, 7);
    assert_int_equal(c, 1);
    wg_image_unref(img);
}

static void test_format_names(void **state)
{
    (void)state;
    static const char *const names[] = {"png", "png16", "tif16", "exr", "exr32", "jpeg", "tga"};
    static const char *const ext[] = {"png", "png", "tif", "exr", "exr", "jpg", "tga"};
    for (int i = 0; i < 7; i++) {
        assert_int_equal(wg_format_parse(names[i]), i + 1);
        assert_string_equal(wg_format_name((WgFormat)(i + 1)), names[i]);
        assert_string_equal(wg_format_extension((WgFormat)(i + 1)), ext[i]);
    }
    assert_int_equal(wg_format_parse("PNG"), -1);
    assert_int_equal(wg_format_parse("tif"), -1);
    assert_int_equal(wg_format_parse("jpg"), WG_FORMAT_JPEG); /* the extension, as an alias */
    assert_int_equal(wg_format_parse("JPEG"), -1);
    assert_int_equal(wg_format_parse(""), -1);
    assert_int_equal(wg_format_parse("default"), -1);
    assert_int_equal(wg_format_parse("png16 "), -1);
    assert_string_equal(wg_format_name(WG_FORMAT_DEFAULT), "default");
}

/* ---- damaged files ----------------------------------------------------------------------- */

static void put_file(const char *path, const char *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

/* Keep the first `keep` bytes of src in dst. */
static void cut_file(const char *src, const char *dst, size_t keep)
{
    size_t n;
    char *data = wgt_read_file(src, &n);
    assert_non_null(data);
    assert_true(n > keep);
    put_file(dst, data, keep);
    free(data);
}

/* wg_image_read fails with an I/O error on that file whose message has every '|'-separated
 * part; no image is returned. */
static void expect_refused(const char *path, const char *parts)
{
    WgImage *img = NULL;
    WgError err = {0};
    int rc = wg_image_read(path, 0, WG_LINEAR, &img, &err);
    char msg[2048];
    wg_error_format(&err, msg, sizeof msg);
    if (rc != WG_ERR_IO) fail_msg("%s: status %d, expected an I/O error (%s)", path, rc, msg);
    assert_null(img);
    assert_string_equal(err.file, path);
    assert_non_null(strstr(msg, path));
    assert_null(strchr(err.message, '\n'));
    char buf[256];
    snprintf(buf, sizeof buf, "%s", parts);
    for (char *p = strtok(buf, "|"); p; p = strtok(NULL, "|"))
        if (!strstr(err.message, p)) fail_msg("%s: '%s' is not in '%s'", path, p, err.message);
}

static double grain_fn(int x, int y, int k)
{
    if (k == 3) return 1;
    return (wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k) & 0xff) / 255.0;
}

/* libjpeg reports a file cut short only as a warning ("Premature end of JPEG file") and fills in
 * the rest: the read must fail anyway. */
static void test_truncated_jpeg_is_refused(void **state)
{
    (void)state;
    WgImage *img = wgt_image_fn(256, 256, 4, grain_fn);
    size_t count = 256 * 256 * 3;
    uint8_t *data = malloc(count);
    assert_non_null(data);
    for (size_t i = 0; i < count; i++)
        data[i] = (uint8_t)lrint(wgt_px(img, (int)(i / 3 % 256), (int)(i / 3 / 256), (int)(i % 3)) *
                                 255.0);
    char msg[256];
    const char *whole = wgt_path("grain.jpg");
    assert_int_equal(wg__oiio_write(whole, "jpg", data, 256, 256, 3, 8, msg, sizeof msg), 0);
    free(data);
    wg_image_unref(img);
    WgImage *ok = read_ok(whole, 0, WG_LINEAR);
    wg_image_unref(ok);
    const char *cut = wgt_path("grain_cut.jpg");
    cut_file(whole, cut, 20000);
    expect_refused(cut, "cannot read the image|damaged or incomplete|Premature end of JPEG file");

    /* the same with a real photograph, when the shared materials are there */
    const char *shared = getenv("WETGRAPH_SHARED");
    char real[2048];
    snprintf(real, sizeof real, "%s/materials/bricks102_stonewall_1k/Bricks102_1K-JPG_Color.jpg",
             shared ? shared : "");
    if (shared && exists(real)) {
        const char *real_cut = wgt_path("bricks_cut.jpg");
        cut_file(real, real_cut, 20000);
        expect_refused(real_cut, "cannot read the image|Premature end of JPEG file");
    }
}

/* PNG files are checked before libpng reads them: a cut, a flipped bit in the pixel data or the
 * header, and a missing IEND are refused with what is wrong and where. */
static void test_damaged_png_is_refused(void **state)
{
    (void)state;
    WgImage *img = wgt_image_fn(64, 64, 4, grain_fn);
    const char *whole = wgt_path("grain.png");
    write_ok(whole, img, WG_FORMAT_PNG16, WG_LINEAR);
    wg_image_unref(img);
    size_t n;
    char *data = wgt_read_file(whole, &n);
    assert_true(n > 4000);

    const char *cut = wgt_path("grain_cut.png");
    put_file(cut, data, 2000);
    expect_refused(cut, "cannot read the image|truncated|ends at byte 2000|IDAT");
    /* the header alone still probes (the check before a render), the pixels do not read */
    int w, h, c;
    WgError err = {0};
    assert_int_equal(wg_image_probe(cut, &w, &h, &c, &err), WG_OK);

    const char *flipped = wgt_path("grain_flip.png");
    /* a byte of the first IDAT's CRC: whatever the compressed data holds, only the CRC can
     * tell (a flipped byte of the data itself may instead break the deflate stream) */
    size_t crc_at = 0;
    for (size_t i = 8; i + 8 < n && !crc_at; i++)
        if (!memcmp(data + i, "IDAT", 4)) {
            const unsigned char *l = (const unsigned char *)data + i - 4;
            crc_at = i + 4 + ((size_t)l[0] << 24 | (size_t)l[1] << 16 | (size_t)l[2] << 8 | l[3]);
        }
    assert_true(crc_at > 0 && crc_at < n);
    data[crc_at] ^= 0x20;
    put_file(flipped, data, n);
    expect_refused(flipped, "cannot read the image|damaged|CRC|IDAT");
    data[crc_at] ^= 0x20;

    const char *header = wgt_path("grain_header.png");
    data[20] ^= 0x01; /* the IHDR's height */
    put_file(header, data, n);
    expect_refused(header, "cannot read the image|damaged|CRC|IHDR");
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_image_probe(header, &w, &h, &c, &err), WG_ERR_IO);
    assert_non_null(strstr(err.message, "IHDR"));
    data[20] ^= 0x01;

    const char *no_end = wgt_path("grain_noend.png");
    put_file(no_end, data, n - 12); /* the IEND chunk is 12 bytes */
    expect_refused(no_end, "truncated|IEND");
    free(data);
}

/* A PNG made here, chunk by chunk, with correct CRCs: IHDR (8-bit gray unless `colour_type`
 * says otherwise), one IDAT holding `raw` compressed (or taken as is when `compressed`), IEND. */
static void put_png(const char *path, int w, int h, int colour_type, const unsigned char *raw,
                    size_t raw_n, bool compressed)
{
    unsigned char *idat = malloc(compressBound(raw_n) + raw_n);
    assert_non_null(idat);
    uLongf idat_n = compressBound(raw_n);
    if (compressed) {
        memcpy(idat, raw, raw_n);
        idat_n = raw_n;
    } else {
        assert_int_equal(compress2(idat, &idat_n, raw, raw_n, 9), Z_OK);
    }
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    fwrite(sig, 1, 8, f);
    unsigned char ihdr[13] = {0, 0, 0, 0, 0, 0, 0, 0, 8, (unsigned char)colour_type, 0, 0, 0};
    for (int k = 0; k < 4; k++) {
        ihdr[k] = (unsigned char)((unsigned)w >> (24 - 8 * k));
        ihdr[4 + k] = (unsigned char)((unsigned)h >> (24 - 8 * k));
    }
    const struct {
        const char *type;
        const unsigned char *data;
        size_t n;
    } chunks[] = {{"IHDR", ihdr, 13}, {"IDAT", idat, idat_n}, {"IEND", NULL, 0}};
    for (int i = 0; i < 3; i++) {
        unsigned char be[4];
        for (int k = 0; k < 4; k++) be[k] = (unsigned char)(chunks[i].n >> (24 - 8 * k));
        fwrite(be, 1, 4, f);
        fwrite(chunks[i].type, 1, 4, f);
        if (chunks[i].n) fwrite(chunks[i].data, 1, chunks[i].n, f);
        uLong crc = crc32(0, (const Bytef *)chunks[i].type, 4);
        if (chunks[i].n) crc = crc32(crc, chunks[i].data, (uInt)chunks[i].n);
        for (int k = 0; k < 4; k++) be[k] = (unsigned char)(crc >> (24 - 8 * k));
        fwrite(be, 1, 4, f);
    }
    assert_int_equal(fclose(f), 0);
    free(idat);
}

/* Files whose chunks and CRCs are all correct but whose image data libpng would refuse (and
 * complain about on stderr by itself): refused by our check first, and stderr stays empty. */
static void test_png_with_bad_image_data_is_refused(void **state)
{
    (void)state;
    enum { W = 32, H = 16, ROW = W + 1 };
    unsigned char raw[ROW * H];
    for (int y = 0; y < H; y++) {
        raw[y * ROW] = 0; /* filter type None */
        for (int x = 0; x < W; x++)
            raw[y * ROW + 1 + x] = (unsigned char)(wg_hash3(x, y, 3) & 0xff);
    }
    const char *good = wgt_path("made_good.png");
    put_png(good, W, H, 0, raw, sizeof raw, false);
    WgImage *img = read_ok(good, 0, WG_LINEAR);
    assert_float_equal(wgt_px(img, 5, 7, 0), raw[7 * ROW + 1 + 5] / 255.0, 1e-6);
    wg_image_unref(img);

    /* the deflate stream damaged, the CRC made to match */
    unsigned char packed[2 * sizeof raw + 64];
    uLongf packed_n = sizeof packed;
    assert_int_equal(compress2(packed, &packed_n, raw, sizeof raw, 9), Z_OK);
    for (int i = 10; i < 30; i++) packed[i] ^= 0x5a;
    const char *corrupt = wgt_path("made_corrupt.png");
    put_png(corrupt, W, H, 0, packed, packed_n, true);

    unsigned char bad_filter[sizeof raw];
    memcpy(bad_filter, raw, sizeof raw);
    bad_filter[9 * ROW] = 7;
    const char *filter = wgt_path("made_filter.png");
    put_png(filter, W, H, 0, bad_filter, sizeof bad_filter, false);

    const char *short_data = wgt_path("made_short.png");
    put_png(short_data, W, H, 0, raw, sizeof raw / 2, false);

    const char *bad_header = wgt_path("made_header.png");
    put_png(bad_header, W, H, 5, raw, sizeof raw, false); /* colour type 5 does not exist */

    /* libpng would print to stderr: catch anything written there while reading */
    fflush(stderr);
    int saved = dup(2);
    const char *log = wgt_path("stderr.txt");
    int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(saved >= 0 && fd >= 0);
    dup2(fd, 2);
    close(fd);
    expect_refused(corrupt, "cannot read the image|compressed image data is corrupt");
    expect_refused(filter, "damaged|row 9|filter type 7");
    expect_refused(short_data, "damaged|image data ends early|264 of 528 bytes");
    expect_refused(bad_header, "damaged|IHDR");
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    size_t n;
    char *printed = wgt_read_file(log, &n);
    if (n) fail_msg("a library wrote to stderr: %s", printed);
    free(printed);
}

/* A full disk: the write fails and says why (OpenImageIO's PNG writer alone reports success). */
static void test_write_to_a_full_device_says_so(void **state)
{
    (void)state;
    if (!exists("/dev/full")) skip();
    size_t count = 256 * 256 * 3;
    uint16_t *data = malloc(count * sizeof *data);
    assert_non_null(data);
    for (size_t i = 0; i < count; i++) data[i] = (uint16_t)(i * 2654435761u >> 16);
    static const char *const ext[] = {"png", "tif", "exr"};
    for (int i = 0; i < 3; i++) {
        char msg[256] = "";
        int bits = i == 2 ? 32 : 16;
        void *buf = data;
        float *f = NULL;
        if (bits == 32) {
            f = malloc(count * sizeof *f);
            assert_non_null(f);
            for (size_t k = 0; k < count; k++) f[k] = data[k] / 65535.0f;
            buf = f;
        }
        assert_int_equal(
            wg__oiio_write("/dev/full", ext[i], buf, 256, 256, 3, bits, msg, sizeof msg), -1);
        if (!strstr(msg, "no space left on device")) fail_msg("%s: '%s'", ext[i], msg);
        free(f);
    }
    free(data);
}

/* ---- native readers against OpenImageIO -------------------------------------------------- */

/* The whole file through the OpenImageIO module, packed floats of all its channels. */
static float *oiio_read_all(const char *path, int *w, int *h, int *c)
{
    WgOiioIn *in;
    char msg[512];
    int bits;
    if (wg__oiio_open(path, &in, w, h, c, &bits, NULL, msg, sizeof msg))
        fail_msg("%s: %s", path, msg);
    size_t n = (size_t)*w * (size_t)*h * (size_t)*c;
    float *v = malloc(n * sizeof(float));
    assert_non_null(v);
    if (wg__oiio_read_rows(in, 0, *h, 0, *c, 0, v, *c * (ptrdiff_t)sizeof(float),
                           (ptrdiff_t)((size_t)*w * (size_t)*c * sizeof(float)), msg, sizeof msg))
        fail_msg("%s: %s", path, msg);
    wg__oiio_close(in);
    return v;
}

/* The file read by wetgraph (natively for these files) equals OpenImageIO's read bit for bit. */
static void expect_native_read_equals_oiio(const char *path)
{
    WgExrIn *ex;
    int w, h, c, strip;
    char msg[512];
    if (wg__exr_open(path, &ex, &w, &h, &c, &strip, msg, sizeof msg))
        fail_msg("%s is not read natively", path);
    wg__exr_close(ex);
    int ow, oh, oc;
    float *ref = oiio_read_all(path, &ow, &oh, &oc);
    assert_int_equal(ow, w);
    assert_int_equal(oh, h);
    assert_int_equal(oc, c);
    assert_int_equal(probe_channels(path), c);
    WgImage *img = read_ok(path, c <= 2 ? 1 : 4, WG_LINEAR);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < (c == 2 ? 1 : c); k++) {
                float want = ref[((size_t)y * (size_t)w + (size_t)x) * (size_t)c + (size_t)k];
                float got = wgt_px(img, x, y, k);
                if (memcmp(&want, &got, sizeof got))
                    fail_msg("%s (%d, %d) channel %d: %.9g, OpenImageIO %.9g", path, x, y, k, got,
                             want);
            }
    wg_image_unref(img);
    free(ref);
}

static double exr_pattern(int x, int y, int k)
{
    /* values that round differently to half: ties, tiny, negative, large, near 1 */
    static const double special[] = {1.0 + 1.0 / 2048, 1.0 + 3.0 / 2048, -0.3333333, 6.1e-5, 3e-8,
                                     65504.0,          65519.0,          0.999};
    int i = (x * 7 + y * 13 + k * 5) % 40;
    return i < 8 ? special[i] : (x * 37 + y * 11 + k * 101) % 1000 / 997.0 - 0.1;
}

/* Single-layer EXR is written and read with OpenEXR's C API; the files match OpenImageIO's. */
static void test_exr_native_matches_openimageio(void **state)
{
    (void)state;
    int w = 37, h = 45; /* not a multiple of the 16-row ZIP chunk */
    for (int layout = 0; layout < 3; layout++) {
        int channels = layout == 0 ? 1 : 4;
        WgImage *img = wgt_image_fn(w, h, channels, exr_pattern);
        if (layout == 1) /* opaque: written as RGB */
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++) wg_image_row(img, y)[4 * x + 3] = 1.0f;
        int c = layout == 0 ? 1 : layout == 1 ? 3 : 4;
        for (int half = 0; half < 2; half++) {
            char native[64], oiio[64];
            snprintf(native, sizeof native, "native%d%d.exr", layout, half);
            snprintf(oiio, sizeof oiio, "oiio%d%d.exr", layout, half);
            write_ok(wgt_path(native), img, half ? WG_FORMAT_EXR : WG_FORMAT_EXR32, WG_LINEAR);
            /* the same pixels written by OpenImageIO */
            float *packed = malloc((size_t)w * (size_t)h * (size_t)c * sizeof(float));
            assert_non_null(packed);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++)
                    for (int k = 0; k < c; k++)
                        packed[((size_t)y * (size_t)w + (size_t)x) * (size_t)c + (size_t)k] =
                            wgt_px(img, x, y, k);
            char msg[512];
            if (wg__oiio_write(wgt_path(oiio), "exr", packed, w, h, c, half ? -16 : 32, msg,
                               sizeof msg))
                fail_msg("%s", msg);
            free(packed);
            expect_native_read_equals_oiio(wgt_path(native));
            expect_native_read_equals_oiio(wgt_path(oiio));
            /* both writers convert to half alike */
            WgImage *a = read_ok(wgt_path(native), channels, WG_LINEAR);
            WgImage *b = read_ok(wgt_path(oiio), channels, WG_LINEAR);
            wgt_assert_identical(a, b);
            if (!half) wgt_assert_identical(a, img);
            wg_image_unref(a);
            wg_image_unref(b);
        }
        wg_image_unref(img);
    }
    /* Y A in OpenImageIO's order, gray with alpha */
    float ya[2 * 6] = {0.25f, 1, 0.5f, 0.75f, 0.125f, 0, 1, 0.5f, 0.375f, 1, 2, 0.25f};
    char msg[512];
    const char *path = wgt_path("ya.exr");
    if (wg__oiio_write(path, "exr", ya, 3, 2, 2, 32, msg, sizeof msg)) fail_msg("%s", msg);
    int ow, oh, oc;
    float *ref = oiio_read_all(path, &ow, &oh, &oc);
    free(ref);
    if (oc == 2) { /* OpenImageIO names 2 channels R G, which is left to it */
        WgImage *g = read_ok(path, 1, WG_LINEAR);
        for (int i = 0; i < 6; i++) assert_true(wgt_px(g, i % 3, i / 3, 0) == ya[2 * i]);
        wg_image_unref(g);
    }
    /* a layered EXR is left to OpenImageIO and still reads */
    WgImage *l1 = wgt_image_fn(4, 4, 1, exr_pattern);
    const char *names[] = {"height"};
    const WgImage *layers[] = {l1};
    WgError err = {0};
    assert_int_equal(wg_exr_write_layers(wgt_path("lay1.exr"), 1, names, layers, false, &err), 0);
    WgExrIn *ex;
    int lw, lh, lc, strip;
    assert_int_equal(
        wg__exr_open(wgt_path("lay1.exr"), &ex, &lw, &lh, &lc, &strip, msg, sizeof msg), 1);
    WgImage *back = read_ok(wgt_path("lay1.exr"), 1, WG_LINEAR);
    wgt_assert_identical(back, l1);
    wg_image_unref(back);
    wg_image_unref(l1);
}

/* A PNG built from its parts: IHDR, optional PLTE and tRNS, one IDAT of unfiltered rows. */
static void put_chunk(FILE *f, const char *type, const unsigned char *data, uint32_t len)
{
    unsigned char be[4] = {len >> 24, len >> 16 & 255, len >> 8 & 255, len & 255};
    fwrite(be, 1, 4, f);
    fwrite(type, 1, 4, f);
    if (len) fwrite(data, 1, len, f);
    uLong crc = crc32(0, (const Bytef *)type, 4);
    if (len) crc = crc32(crc, data, len); /* crc32 of a NULL buffer is 0, not the CRC */
    unsigned char cb[4] = {crc >> 24, crc >> 16 & 255, crc >> 8 & 255, crc & 255};
    fwrite(cb, 1, 4, f);
}

static void make_png(const char *path, int w, int h, int depth, int type, bool trns)
{
    static const int samples[7] = {1, 0, 3, 1, 2, 0, 4};
    size_t row = 1 + ((size_t)w * (size_t)(samples[type] * depth) + 7) / 8;
    size_t raw_size = row * (size_t)h;
    unsigned char *raw = calloc(raw_size, 1);
    assert_non_null(raw);
    /* every filter type in turn (the bytes after it are whatever they are) */
    for (size_t i = 0; i < raw_size; i++)
        raw[i] = i % row ? (unsigned char)(i * 7 + i / 5) : (unsigned char)(i / row % 5);
    if (type == 3) /* palette indices within the 4 entries */
        for (size_t i = 0; i < raw_size; i++) raw[i] = 0;
    uLongf zsize = compressBound(raw_size);
    unsigned char *z = malloc(zsize);
    assert_non_null(z);
    assert_int_equal(compress(z, &zsize, raw, raw_size), Z_OK);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fwrite("\x89PNG\r\n\x1a\n", 1, 8, f);
    unsigned char ihdr[13] = {0,
                              0,
                              0,
                              (unsigned char)w,
                              0,
                              0,
                              0,
                              (unsigned char)h,
                              (unsigned char)depth,
                              (unsigned char)type,
                              0,
                              0,
                              0};
    put_chunk(f, "IHDR", ihdr, 13);
    unsigned char plte[12] = {0, 0, 0, 255, 0, 0, 0, 255, 0, 0, 0, 255};
    if (type == 3) put_chunk(f, "PLTE", plte, 12);
    unsigned char t[6] = {0, 1, 0, 2, 0, 3};
    if (trns) put_chunk(f, "tRNS", t, type == 3 ? 2 : type == 0 ? 2 : 6);
    put_chunk(f, "IDAT", z, (uint32_t)zsize);
    put_chunk(f, "IEND", NULL, 0);
    fclose(f);
    free(raw);
    free(z);
}

/* PNG sizes and channels come from the header without OpenImageIO, and agree with it. */
static void test_png_probe_matches_openimageio(void **state)
{
    (void)state;
    static const struct {
        int depth, type;
        bool trns;
    } kinds[] = {{8, 0, false}, {8, 0, true}, {16, 0, false}, {1, 0, false}, {8, 4, false},
                 {8, 2, false}, {8, 2, true}, {16, 2, false}, {8, 6, false}, {16, 6, false},
                 {8, 3, false}, {8, 3, true}, {2, 3, true},   {16, 0, true}};
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++) {
        char name[64], msg[512];
        snprintf(name, sizeof name, "kind%zu.png", i);
        const char *path = wgt_path(name);
        make_png(path, 11, 7, kinds[i].depth, kinds[i].type, kinds[i].trns);
        int w, h, c, ow, oh, oc;
        assert_int_equal(wg__png_probe(path, &w, &h, &c, msg, sizeof msg), 0);
        if (wg__oiio_probe(path, &ow, &oh, &oc, msg, sizeof msg)) fail_msg("%s: %s", name, msg);
        if (w != ow || h != oh || c != oc)
            fail_msg("%s (depth %d, colour type %d%s): %dx%d, %d channels; OpenImageIO %dx%d, %d",
                     name, kinds[i].depth, kinds[i].type, kinds[i].trns ? ", tRNS" : "", w, h, c,
                     ow, oh, oc);
        /* and the whole file reads with that many channels, the values OpenImageIO reads */
        WgImage *img = read_ok(path, 0, WG_LINEAR);
        assert_int_equal(img->channels, c <= 2 ? 1 : 4);
        float *ref = oiio_read_all(path, &ow, &oh, &oc);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                for (int k = 0; k < img->channels; k++) {
                    const float *r = ref + ((size_t)y * (size_t)w + (size_t)x) * (size_t)c;
                    float want = k < c ? r[k] : 1.0f, got = wgt_px(img, x, y, k);
                    if (memcmp(&want, &got, sizeof got))
                        fail_msg("%s (%d, %d) channel %d: %.9g, OpenImageIO %.9g", name, x, y, k,
                                 got, want);
                }
        free(ref);
        wg_image_unref(img);
    }
    char msg[512];
    int w, h, c;
    assert_int_equal(wg__png_probe(wgt_path("ya.exr"), &w, &h, &c, msg, sizeof msg), 1);
}

/* Integer files are read as their codes and converted through tables: the result equals
 * OpenImageIO's float read of the file, sRGB-decoded with the formula, for every path (gray or
 * colour file, to gray or colour, 8 and 16 bits, PNG and JPEG). */
static void test_integer_files_read_as_openimageio_floats(void **state)
{
    (void)state;
    int w = 256, h = 4;
    unsigned short *px = malloc((size_t)w * (size_t)h * 4 * sizeof *px);
    assert_non_null(px);
    static const struct {
        const char *name, *ext;
        int c, bits;
    } files[] = {{"codes8.png", "png", 4, 8}, {"codes16.png", "png", 3, 16},
                 {"gray8.png", "png", 1, 8},  {"gray16.png", "png", 1, 16},
                 {"ga8.png", "png", 2, 8},    {"codes.jpg", "jpg", 3, 8}};
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        int c = files[f].c, bits = files[f].bits;
        size_t n = (size_t)w * (size_t)h * (size_t)c;
        unsigned char *p8 = (unsigned char *)px;
        for (size_t i = 0; i < n; i++) { /* every code of the type along the rows */
            unsigned v = (unsigned)(i * (bits == 8 ? 1u : 257u) + i / 7 * 13);
            if (bits == 8)
                p8[i] = (unsigned char)v;
            else
                px[i] = (unsigned short)(v * 97);
        }
        char msg[512];
        const char *path = wgt_path(files[f].name);
        if (wg__oiio_write(path, files[f].ext, px, w, h, c, bits, msg, sizeof msg))
            fail_msg("%s", msg);
        int ow, oh, oc;
        float *ref = oiio_read_all(path, &ow, &oh, &oc);
        assert_int_equal(oc, c);
        for (int cs = 0; cs < 2; cs++) {
            for (int channels = 1; channels <= 4; channels += 3) {
                WgImage *img = read_ok(path, channels, cs ? WG_SRGB : WG_LINEAR);
                for (int y = 0; y < h; y++) {
                    for (int x = 0; x < w; x++) {
                        const float *r = ref + ((size_t)y * (size_t)w + (size_t)x) * (size_t)c;
                        float want[4];
                        int colour = c <= 2 ? 1 : 3;
                        for (int k = 0; k < colour; k++)
                            want[k] = cs ? wg_srgb_to_linear(r[k]) : r[k];
                        if (colour == 1) want[1] = want[2] = want[0];
                        want[3] = c == 4 ? r[3] : c == 2 ? r[1] : 1.0f;
                        float lum = wg__luminance(want);
                        for (int k = 0; k < channels; k++) {
                            float e = channels == 1 ? (colour == 1 ? want[0] : lum) : want[k];
                            float got = wgt_px(img, x, y, k);
                            if (memcmp(&e, &got, sizeof got))
                                fail_msg("%s %s to %d channels, (%d, %d) channel %d: %.9g, "
                                         "expected %.9g",
                                         files[f].name, cs ? "srgb" : "linear", channels, x, y, k,
                                         got, e);
                        }
                    }
                }
                wg_image_unref(img);
            }
        }
        free(ref);
    }
    free(px);
}

/* JPEG sizes and channels come from the header without OpenImageIO and agree with it; a header
 * that is cut, or a file that is not a JPEG, is left to OpenImageIO. */
static void expect_jpeg_probe(const char *path)
{
    int w, h, c, ow, oh, oc;
    char msg[512];
    if (wg__jpeg_probe(path, &w, &h, &c)) fail_msg("%s: not probed natively", path);
    if (wg__oiio_probe(path, &ow, &oh, &oc, msg, sizeof msg)) fail_msg("%s: %s", path, msg);
    if (w != ow || h != oh || c != oc)
        fail_msg("%s: %dx%d, %d channels; OpenImageIO %dx%d, %d", path, w, h, c, ow, oh, oc);
}

static void test_jpeg_probe_matches_openimageio(void **state)
{
    (void)state;
    unsigned char px[37 * 23 * 3];
    for (size_t i = 0; i < sizeof px; i++) px[i] = (unsigned char)(i * 13);
    char msg[512];
    for (int c = 1; c <= 3; c += 2) {
        const char *path = wgt_path(c == 1 ? "probe_gray.jpg" : "probe_rgb.jpg");
        if (wg__oiio_write(path, "jpg", px, 37, 23, c, 8, msg, sizeof msg)) fail_msg("%s", msg);
        expect_jpeg_probe(path);
    }
    /* the header is all a probe needs */
    size_t n;
    char *data = wgt_read_file(wgt_path("probe_rgb.jpg"), &n);
    assert_non_null(data);
    const char *cut = wgt_path("probe_cut.jpg");
    put_file(cut, data, n - 40);
    expect_jpeg_probe(cut);
    int w, h, c;
    put_file(cut, data, 30); /* inside the header */
    assert_int_equal(wg__jpeg_probe(cut, &w, &h, &c), 1);
    free(data);
    wgt_write_file(wgt_path("probe_text.jpg"), "not a JPEG\n");
    assert_int_equal(wg__jpeg_probe(wgt_path("probe_text.jpg"), &w, &h, &c), 1);
    /* real photographs (EXIF and other segments before the frame), when they are there */
    const char *shared = getenv("WETGRAPH_SHARED");
    char dir[2048];
    snprintf(dir, sizeof dir, "%s/materials", shared ? shared : "");
    DIR *d = shared ? opendir(dir) : NULL;
    for (struct dirent *e; d && (e = readdir(d));) {
        if (e->d_name[0] == '.') continue;
        char sub[2300];
        snprintf(sub, sizeof sub, "%s/%s", dir, e->d_name);
        DIR *m = opendir(sub);
        for (struct dirent *f; m && (f = readdir(m));) {
            size_t len = strlen(f->d_name);
            if (len < 4 || strcmp(f->d_name + len - 4, ".jpg")) continue;
            char path[2600];
            snprintf(path, sizeof path, "%s/%s", sub, f->d_name);
            expect_jpeg_probe(path);
        }
        if (m) closedir(m);
    }
    if (d) closedir(d);
}

/* wg_quantize8 against the formula it replaces (sRGB encoding with pow, clamping, rounding):
 * every float within 64 ulps of each place the code changes, a sweep over [0, 2] and beyond,
 * and the special values. */
static int quantize8_reference(float v, bool srgb)
{
    if (isnan(v)) v = 0;
    if (srgb) v = wg_linear_to_srgb(v);
    double x = v < 0 ? 0 : v > 1 ? 1 : v;
    return (int)floor(x * 255.0 + 0.5);
}

static float float_of(uint32_t bits)
{
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

static void test_quantize8_matches_the_formula(void **state)
{
    (void)state;
    long checked = 0;
    for (int srgb = 0; srgb < 2; srgb++) {
        int last = 0;
        for (uint32_t b = 0; b <= 0x40400000u; b += 331) { /* 0 .. 3 */
            float v = float_of(b);
            int want = quantize8_reference(v, srgb);
            assert_int_equal(wg_quantize8(v, srgb), want);
            if (want != last) /* a change of code: every float around it */
                for (uint32_t n = b > 400 ? b - 400 : 0; n <= b + 64; n++, checked++)
                    assert_int_equal(wg_quantize8(float_of(n), srgb),
                                     quantize8_reference(float_of(n), srgb));
            last = want;
            checked++;
        }
        static const float special[] = {0.0f, -0.0f, -1.0f,  -INFINITY, INFINITY, 1.0f,
                                        2.0f, 1e30f, 1e-45f, -1e-45f,   0.5f,     0.0031308f};
        for (size_t i = 0; i < sizeof special / sizeof special[0]; i++)
            assert_int_equal(wg_quantize8(special[i], srgb), quantize8_reference(special[i], srgb));
        assert_int_equal(wg_quantize8(NAN, srgb), 0);
        assert_int_equal(wg_quantize8(-NAN, srgb), 0);
    }
    assert_int_equal(wg_quantize8(1.0f, true), 255);
    assert_true(checked > 1000000);
}

/* 8-bit files hold wg_quantize8's code of every sample (sRGB for the colour channels of an
 * sRGB file, never for alpha), whatever the value: floats around every place a code changes,
 * a sweep with values below 0 and above 1, NaN and infinities; colour with alpha, opaque colour
 * (written as RGB) and gray; odd sizes. */
static void test_png8_holds_quantize8_codes(void **state)
{
    (void)state;
    /* the values: every float near each code change (found on a sweep), then the specials */
    static float values[200000];
    int nv = 0;
    for (int srgb = 0; srgb < 2; srgb++) {
        int last = 0;
        for (uint32_t b = 0; b <= 0x3f900000u && nv < 190000; b += 4099) {
            int code = wg_quantize8(float_of(b), srgb);
            if (code != last)
                for (uint32_t n = b - 40; n <= b + 40 && nv < 190000; n += 3)
                    values[nv++] = float_of(n);
            last = code;
        }
    }
    static const float special[] = {0.0f,  -0.0f,  -1.0f,   -INFINITY, INFINITY, 1.0f, 2.0f,
                                    1e30f, 1e-45f, -1e-45f, 0.5f,      NAN,      -NAN, 0.0031308f};
    for (size_t i = 0; i < sizeof special / sizeof *special; i++) values[nv++] = special[i];
    static const int sizes[][2] = {{37, 5}, {3, 64}, {256, 9}};
    for (int v = 0; v < 3; v++)
        for (int layout = 0; layout < 3; layout++) /* RGBA, RGB (alpha 1), gray */
            for (int cs = 0; cs < 2; cs++) {
                int w = sizes[v][0], h = sizes[v][1], ch = layout == 2 ? 1 : 4;
                WgImage *img = wg_image_new(w, h, ch);
                assert_non_null(img);
                long at = v * 7919 + layout * 131 + cs;
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++)
                        for (int k = 0; k < ch; k++)
                            wg_image_row(img, y)[x * ch + k] =
                                layout == 1 && k == 3 ? 1.0f : values[at++ % nv];
                WgError err = {0};
                const char *path = wgt_path("codes8.png");
                assert_int_equal(wg_image_write(path, img, WG_FORMAT_PNG, (WgColorspace)cs, &err),
                                 WG_OK);
                WgImage *back = NULL; /* read as linear: each sample is its code / 255 */
                assert_int_equal(wg_image_read(path, ch, WG_LINEAR, &back, &err), WG_OK);
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++)
                        for (int k = 0; k < ch; k++) {
                            float src = wg_image_row(img, y)[x * ch + k];
                            int want = wg_quantize8(src, cs == WG_SRGB && k < 3);
                            int got = (int)lrintf(wg_image_row(back, y)[x * ch + k] * 255.0f);
                            if (got != want)
                                fail_msg("%dx%d, %d channels, cs %d: (%d, %d, %d) holds %d for "
                                         "%a, wg_quantize8 gives %d",
                                         w, h, ch, cs, x, y, k, got, src, want);
                        }
                wg_image_unref(back);
                wg_image_unref(img);
            }
}

/* Linear 16- and 8-bit files hold floor(clamp(v, 0, 1) * max + 0.5) of every sample, computed
 * here in double: the floats within 6 ulps of every place a code changes, (k + 1/2) / max for
 * every k, and the special values; gray and colour rows, whose packing loops are vectorised;
 * packed by each of the loops the processor runs: AVX-512, AVX2 (both with FMA), double. */
static void test_linear_codes_at_every_boundary(void **state)
{
    (void)state;
    static const char *const loop_names[] = {"double", "FMA", "AVX-512"};
    for (int way = 0; way < 6; way++) {
        int bits = way % 2 ? 16 : 8, loops = way / 2;
        if (wg__pack_loops(loops) != loops) continue; /* not on this processor */
        double max = bits == 8 ? 255.0 : 65535.0;
        int n_codes = (int)max;
        long n = (long)n_codes * 13 + 16;
        float *values = malloc((size_t)n * sizeof *values);
        assert_non_null(values);
        long nv = 0;
        for (int k = 0; k < n_codes; k++) {
            float mid = (float)((k + 0.5) / max);
            uint32_t b;
            memcpy(&b, &mid, sizeof b);
            for (int d = -6; d <= 6; d++) values[nv++] = float_of(b + (uint32_t)d);
        }
        static const float special[] = {0.0f, -0.0f,          -1.0f,     -INFINITY, INFINITY, 1.0f,
                                        2.0f, 1e30f,          1e-45f,    -1e-45f,   0.5f,     NAN,
                                        -NAN, 0x1.fffffep-1f, 0x1p-126f, 1.0000001f};
        for (size_t i = 0; i < sizeof special / sizeof *special; i++) values[nv++] = special[i];
        for (int ch = 1; ch <= 4; ch += 3) {
            int w = 1021, h = (int)((nv + (long)w * ch - 1) / ((long)w * ch));
            WgImage *img = wg_image_new(w, h, ch);
            assert_non_null(img);
            long at = 0;
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w * ch; x++) /* alpha varies too: written as RGBA */
                    wg_image_row(img, y)[x] = values[at++ % nv];
            WgError err = {0};
            const char *path = wgt_path("codes_linear.png");
            assert_int_equal(wg_image_write(path, img, bits == 8 ? WG_FORMAT_PNG : WG_FORMAT_PNG16,
                                            WG_LINEAR, &err),
                             WG_OK);
            WgImage *back = NULL; /* each sample is its code / max */
            assert_int_equal(wg_image_read(path, ch, WG_LINEAR, &back, &err), WG_OK);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w * ch; x++) {
                    float v = wg_image_row(img, y)[x];
                    double c = isnan(v) ? 0 : v < 0 ? 0 : v > 1 ? 1 : (double)v;
                    long want = (long)floor(c * max + 0.5);
                    long got = lrint(wg_image_row(back, y)[x] * max);
                    if (got != want)
                        fail_msg("%d bits (%s), %d channels: sample %d of row %d holds %ld for "
                                 "%a, not %ld",
                                 bits, loop_names[loops], ch, x, y, got, v, want);
                }
            wg_image_unref(back);
            wg_image_unref(img);
        }
        free(values);
    }
    wg__pack_loops(-1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_png16_round_trip_is_exact),
        cmocka_unit_test(test_linear_codes_at_every_boundary),
        cmocka_unit_test(test_png8_rounds_to_nearest_and_clamps),
        cmocka_unit_test(test_rgb_codes_at_every_width),
        cmocka_unit_test(test_png16_clamps_and_rounds),
        cmocka_unit_test(test_tif16_round_trip_is_exact),
        cmocka_unit_test(test_tif16_keeps_alpha_unassociated),
        cmocka_unit_test(test_exr32_is_bit_exact),
        cmocka_unit_test(test_exr_half_within_half_precision),
        cmocka_unit_test(test_srgb_transfer_functions),
        cmocka_unit_test(test_srgb_png_round_trips_every_code),
        cmocka_unit_test(test_srgb_png16_gray),
        cmocka_unit_test(test_srgb_decode_table_is_exact),
        cmocka_unit_test(test_gray_file_maps_to_gray_or_rgba),
        cmocka_unit_test(test_colour_file_maps_to_rgba_or_luminance),
        cmocka_unit_test(test_gray_alpha_file_reads_as_gray_or_gray_and_alpha),
        cmocka_unit_test(test_alpha_stays_unassociated_in_png),
        cmocka_unit_test(test_rgb_written_when_alpha_is_one),
        cmocka_unit_test(test_default_format_is_png16_for_gray_png8_for_colour),
        cmocka_unit_test(test_temp_path_semantics),
        cmocka_unit_test(test_write_into_missing_folder_fails_and_leaves_nothing),
        cmocka_unit_test(test_successful_write_leaves_no_temp_files),
        cmocka_unit_test(test_failed_write_keeps_the_old_file),
        cmocka_unit_test(test_temp_names_are_recognised_exactly),
        cmocka_unit_test(test_temp_names_carry_the_host),
        cmocka_unit_test(test_stale_temporaries_by_host),
        cmocka_unit_test(test_write_set_replaces_all_or_reports_which),
        cmocka_unit_test(test_write_set_copy),
        cmocka_unit_test(test_write_set_copy_file),
        cmocka_unit_test(test_write_set_told_alpha),
        cmocka_unit_test(test_write_set_flushes_on_a_thread),
        cmocka_unit_test(test_write_set_flush_queue_is_bounded),
        cmocka_unit_test(test_write_set_commit_after_fork),
        cmocka_unit_test(test_layered_exr_channels_and_values),
        cmocka_unit_test(test_layered_exr_rejects_bad_layers),
        cmocka_unit_test(test_non_finite_values_are_rejected),
        cmocka_unit_test(test_probe_errors_name_the_path),
        cmocka_unit_test(test_probe_reports_shape),
        cmocka_unit_test(test_format_names),
        cmocka_unit_test(test_truncated_jpeg_is_refused),
        cmocka_unit_test(test_damaged_png_is_refused),
        cmocka_unit_test(test_png_with_bad_image_data_is_refused),
        cmocka_unit_test(test_write_to_a_full_device_says_so),
        cmocka_unit_test(test_exr_native_matches_openimageio),
        cmocka_unit_test(test_png_probe_matches_openimageio),
        cmocka_unit_test(test_integer_files_read_as_openimageio_floats),
        cmocka_unit_test(test_jpeg_probe_matches_openimageio),
        cmocka_unit_test(test_quantize8_matches_the_formula),
        cmocka_unit_test(test_png8_holds_quantize8_codes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
