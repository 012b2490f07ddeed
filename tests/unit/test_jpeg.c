/* SPDX-License-Identifier: MIT */
/* JPEG pixels decoded natively with libjpeg-turbo (io/jpeg_read.c), held against OpenImageIO's
 * own read (linked directly, tests/support/wgt_oiio.cpp): gray and colour, 4:2:0 and 4:4:4,
 * baseline and progressive, odd sizes, to the same floats bit for bit, without loading
 * wetgraph's OpenImageIO module; CMYK files still read through the module; damaged files
 * (cut, flipped bytes, broken tables, stray bytes) refused with one line naming the file and
 * nothing printed by libjpeg; the decode at a DCT scale, resampled to a smaller size, against
 * the full decode resampled to it; and the memory a decode is counted to need. The JPEGs are
 * written here with libjpeg. */
#include "wgtest.h"

#include "internal.h"
#include "wgio.h"
#include "wgt_oiio.h"

#include <fcntl.h>
#include <jpeglib.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Pixel (x, y) channel k of a test picture: waves of a few frequencies, plus `grain` of
 * per-pixel noise (0..1), as 8-bit codes. */
static unsigned char picture(int x, int y, int k, int w, int h, double grain)
{
    /* periodic over the picture, as a tiling texture is */
    double u = 2 * M_PI * x / w, v0 = 2 * M_PI * y / h;
    double v = 0.5 + 0.3 * sin(u + 2.0 * k) * cos(2 * v0 - k) + 0.15 * sin(7 * u + 5 * v0 + k) +
               0.05 * cos(40 * u - 23 * v0);
    v += grain * ((wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k) & 0xff) / 255.0 - 0.5);
    v = v < 0 ? 0 : v > 1 ? 1 : v;
    return (unsigned char)lrint(v * 255);
}

typedef struct {
    int w, h, c;      /* c: 1 gray, 3 RGB, 4 CMYK */
    bool progressive; /* else baseline */
    bool subsample;   /* colour at 4:2:0, else 4:4:4 */
    int quality;
    double grain;
} JpegSpec;

static void write_jpeg(const char *path, const JpegSpec *s)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    struct jpeg_compress_struct cinfo;
    struct jpeg_error_mgr jerr;
    cinfo.err = jpeg_std_error(&jerr);
    jpeg_create_compress(&cinfo);
    jpeg_stdio_dest(&cinfo, f);
    cinfo.image_width = (JDIMENSION)s->w;
    cinfo.image_height = (JDIMENSION)s->h;
    cinfo.input_components = s->c;
    cinfo.in_color_space = s->c == 1 ? JCS_GRAYSCALE : s->c == 3 ? JCS_RGB : JCS_CMYK;
    jpeg_set_defaults(&cinfo);
    jpeg_set_quality(&cinfo, s->quality, TRUE);
    if (s->c == 3) {
        cinfo.comp_info[0].h_samp_factor = cinfo.comp_info[0].v_samp_factor = s->subsample ? 2 : 1;
        cinfo.comp_info[1].h_samp_factor = cinfo.comp_info[1].v_samp_factor = 1;
        cinfo.comp_info[2].h_samp_factor = cinfo.comp_info[2].v_samp_factor = 1;
    }
    if (s->progressive) jpeg_simple_progression(&cinfo);
    jpeg_start_compress(&cinfo, TRUE);
    unsigned char *row = malloc((size_t)s->w * (size_t)s->c);
    assert_non_null(row);
    while (cinfo.next_scanline < cinfo.image_height) {
        int y = (int)cinfo.next_scanline;
        for (int x = 0; x < s->w; x++)
            for (int k = 0; k < s->c; k++)
                row[x * s->c + k] = picture(x, y, k, s->w, s->h, s->grain);
        JSAMPROW r = row;
        jpeg_write_scanlines(&cinfo, &r, 1);
    }
    jpeg_finish_compress(&cinfo);
    jpeg_destroy_compress(&cinfo);
    free(row);
    fclose(f);
}

static WgImage *read_ok(const char *path, int channels, WgColorspace cs)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path, channels, cs, &img, &err)) {
        char msg[2048];
        wg_error_format(&err, msg, sizeof msg);
        fail_msg("%s", msg);
    }
    return img;
}

/* wetgraph's read (linear, the file's channels) against OpenImageIO's, value for value. */
static void expect_same_as_oiio(const char *path, int c)
{
    char msg[512];
    WgtOiioSpec spec;
    float *ref = wgt_oiio_read(path, &spec, msg, sizeof msg);
    if (!ref) fail_msg("%s: %s", path, msg);
    assert_int_equal(spec.c, c == 4 ? 4 : c);
    WgImage *img = read_ok(path, 0, WG_LINEAR);
    assert_int_equal(img->width, spec.w);
    assert_int_equal(img->height, spec.h);
    int colour = c == 1 ? 1 : 3;
    for (int y = 0; y < spec.h; y++)
        for (int x = 0; x < spec.w; x++)
            for (int k = 0; k < colour; k++) {
                float want = ref[((size_t)y * (size_t)spec.w + (size_t)x) * (size_t)spec.c + k];
                float got = wgt_px(img, x, y, k);
                if (memcmp(&want, &got, sizeof got))
                    fail_msg("%s (%d, %d) channel %d: %.9g, OpenImageIO %.9g", path, x, y, k, got,
                             want);
            }
    wg_image_unref(img);
    free(ref);
}

/* The same codes as OpenImageIO (which drives the same libjpeg with the same accurate IDCT and
 * upsampling): a tolerance of zero. */
static void test_native_decode_equals_openimageio(void **state)
{
    (void)state;
    static const int sizes[][2] = {{1, 1}, {17, 9}, {37, 23}, {64, 64}, {100, 75}, {8, 200}};
    char name[64];
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        for (int variant = 0; variant < 5; variant++) {
            /* gray; RGB 4:2:0 and 4:4:4; each baseline and progressive (gray once each) */
            JpegSpec s = {sizes[i][0],
                          sizes[i][1],
                          variant < 2 ? 1 : 3,
                          variant % 2 == 1,
                          variant == 2 || variant == 3,
                          60 + 9 * variant,
                          0.2 * variant};
            if (variant == 4) s.progressive = true;
            snprintf(name, sizeof name, "n%zu_%d.jpg", i, variant);
            const char *path = wgt_path(name);
            write_jpeg(path, &s);
            int w, h, c;
            if (wg__jpeg_probe(path, &w, &h, &c)) fail_msg("%s is not decoded natively", path);
            expect_same_as_oiio(path, s.c);
        }
    }
    /* no file so far needed wetgraph's OpenImageIO module */
    assert_false(wg__oiio_loaded());
    /* a CMYK JPEG is left to it, and reads as it did */
    JpegSpec cmyk = {29, 31, 4, false, false, 90, 0.1};
    const char *path = wgt_path("cmyk.jpg");
    write_jpeg(path, &cmyk);
    int w, h, c;
    assert_int_equal(wg__jpeg_probe(path, &w, &h, &c), 1);
    WgImage *img = read_ok(path, 4, WG_LINEAR);
    assert_int_equal(img->width, 29);
    wg_image_unref(img);
    assert_true(wg__oiio_loaded());
}

/* Reading `path` fails with one line of I/O error naming it that has every '|'-separated
 * part, and nothing is written to stderr meanwhile. */
static void expect_refused(const char *path, const char *parts)
{
    char capture[512];
    snprintf(capture, sizeof capture, "%s.stderr", path);
    fflush(stderr);
    int saved = dup(2), fd = open(capture, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(saved >= 0 && fd >= 0);
    dup2(fd, 2);
    close(fd);
    WgImage *img = NULL;
    WgError err = {0};
    int rc = wg_image_read(path, 0, WG_SRGB, &img, &err);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    size_t n = 0;
    char *printed = wgt_read_file(capture, &n);
    if (n) fail_msg("%s: printed to stderr: %s", path, printed);
    free(printed);
    char msg[2048];
    wg_error_format(&err, msg, sizeof msg);
    if (rc != WG_ERR_IO) fail_msg("%s: status %d, expected an I/O error (%s)", path, rc, msg);
    assert_null(img);
    assert_non_null(strstr(msg, path));
    assert_null(strchr(msg, '\n'));
    char buf[256];
    snprintf(buf, sizeof buf, "%s", parts);
    for (char *p = strtok(buf, "|"); p; p = strtok(NULL, "|"))
        if (!strstr(err.message, p)) fail_msg("%s: '%s' is not in '%s'", path, p, err.message);
}

/* Offset of the first byte after the SOS segment's header (the entropy-coded data). */
static size_t scan_start(const unsigned char *d, size_t n)
{
    for (size_t i = 2; i + 4 < n;) {
        assert_int_equal(d[i], 0xff);
        size_t len = (size_t)d[i + 2] << 8 | d[i + 3];
        if (d[i + 1] == 0xda) return i + 2 + len;
        i += 2 + len;
    }
    fail_msg("no scan");
    return 0;
}

static size_t find_marker(const unsigned char *d, size_t n, unsigned char m)
{
    for (size_t i = 0; i + 1 < n; i++)
        if (d[i] == 0xff && d[i + 1] == m) return i;
    fail_msg("no marker %02x", m);
    return 0;
}

static void write_bytes(const char *path, const unsigned char *d, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(d, 1, n, f), n);
    fclose(f);
}

/* Damaged files, each refused with one line naming the file: cut within the scan at several
 * points (baseline and progressive), cut just before EOI, bytes of the scan overwritten with
 * garbage, a Huffman table with impossible counts, and stray bytes before the EOI marker. */
/* A destination of other channels than the file's: gray spread to colour with alpha 1, colour
 * reduced to its luminance, as for any other 8-bit file; the decoder takes the file's own
 * channels, not the destination's. */
static void test_channels_other_than_the_files(void **state)
{
    (void)state;
    JpegSpec gray = {67, 45, 1, false, false, 90, 0.3}, colour = {67, 45, 3, true, true, 90, 0.3};
    write_jpeg(wgt_path("chan_gray.jpg"), &gray);
    write_jpeg(wgt_path("chan_rgb.jpg"), &colour);
    for (int srgb = 0; srgb < 2; srgb++) {
        WgColorspace cs = srgb ? WG_SRGB : WG_LINEAR;
        WgImage *g1 = read_ok(wgt_path("chan_gray.jpg"), 1, cs);
        WgImage *g4 = read_ok(wgt_path("chan_gray.jpg"), 4, cs);
        WgImage *c4 = read_ok(wgt_path("chan_rgb.jpg"), 4, cs);
        WgImage *c1 = read_ok(wgt_path("chan_rgb.jpg"), 1, cs);
        assert_int_equal(g4->channels, 4);
        assert_int_equal(c1->channels, 1);
        for (int y = 0; y < 45; y++)
            for (int x = 0; x < 67; x++) {
                float v = wgt_px(g1, x, y, 0);
                for (int k = 0; k < 3; k++) assert_true(wgt_px(g4, x, y, k) == v);
                assert_true(wgt_px(g4, x, y, 3) == 1.0f);
                float px[4] = {wgt_px(c4, x, y, 0), wgt_px(c4, x, y, 1), wgt_px(c4, x, y, 2), 1};
                assert_true(wgt_px(c1, x, y, 0) == wg__luminance(px));
            }
        wg_image_unref(g1);
        wg_image_unref(g4);
        wg_image_unref(c4);
        wg_image_unref(c1);
    }
}

static void test_damaged_jpeg_refused_in_one_line(void **state)
{
    (void)state;
    for (int prog = 0; prog < 2; prog++) {
        JpegSpec s = {97, 61, 3, prog, true, 85, 0.5};
        const char *path = wgt_path(prog ? "whole_p.jpg" : "whole_b.jpg");
        write_jpeg(path, &s);
        size_t n;
        unsigned char *d = (unsigned char *)wgt_read_file(path, &n);
        size_t scan = scan_start(d, n);
        char name[64];
        for (int cut = 1; cut <= 4; cut++) {
            snprintf(name, sizeof name, "cut%d_%d.jpg", prog, cut);
            write_bytes(wgt_path(name), d, scan + (n - scan) * (size_t)cut / 5);
            expect_refused(wgt_path(name), "cannot read the image|damaged or incomplete");
        }
        snprintf(name, sizeof name, "noeoi%d.jpg", prog);
        write_bytes(wgt_path(name), d, n - 2);
        expect_refused(wgt_path(name), "damaged or incomplete|Premature end of JPEG file");

        /* a stretch of the first scan overwritten: 0xff 0xd3 is a restart marker the file has no
         * restart interval for, which libjpeg reports (and then resynchronises) */
        unsigned char *g = malloc(n);
        memcpy(g, d, n);
        for (size_t i = scan + 10; i < scan + 40 && i + 1 < n; i += 2) {
            g[i] = 0xff;
            g[i + 1] = 0xd3;
        }
        snprintf(name, sizeof name, "garbage%d.jpg", prog);
        write_bytes(wgt_path(name), g, n);
        expect_refused(wgt_path(name), "cannot read the image");

        /* stray bytes before EOI */
        memcpy(g, d, n);
        unsigned char *x = malloc(n + 8);
        size_t eoi = n - 2;
        memcpy(x, d, eoi);
        memcpy(x + eoi, "\x12\x34\x56\x78\x9a\xbc", 6);
        memcpy(x + eoi + 6, d + eoi, 2);
        snprintf(name, sizeof name, "stray%d.jpg", prog);
        write_bytes(wgt_path(name), x, n + 6);
        expect_refused(wgt_path(name), "damaged or incomplete");

        /* a Huffman table whose code counts add up to more codes than its length allows */
        memcpy(g, d, n);
        size_t dht = find_marker(g, n, 0xc4);
        for (int k = 0; k < 16; k++) g[dht + 5 + k] = 0xff;
        snprintf(name, sizeof name, "dht%d.jpg", prog);
        write_bytes(wgt_path(name), g, n);
        expect_refused(wgt_path(name), "cannot read the image");
        free(x);
        free(g);
        free(d);
    }
}

/* wg_image_decode_size picks the smallest DCT scale whose sides are at least the ones asked for
 * (the file's size for any other file, or when nothing smaller fits), and the picture decoded
 * there and resampled matches the whole decode resampled within a bound: both are low-pass
 * filters of the same picture, libjpeg's scaled IDCT a sharper one than the tent, and on these
 * tiling pictures with fine detail (waves up to a period of 6 pixels and per-pixel grain of
 * +-0.05) they differ by at most 0.07, 0.007 on average (measured: up to 0.059, mean 0.0055,
 * the worst at 7/8, where the tent is nearly bilinear and barely filters). */
static void test_scaled_decode_matches_full_decode(void **state)
{
    (void)state;
    static const struct {
        int w, h, tw, th, dw, dh;
    } cases[] = {
        {1000, 600, 500, 300, 500, 300}, /* 4/8 exactly: no resampling at all */
        {1000, 600, 300, 200, 375, 225}, /* 3/8 */
        {1000, 600, 64, 64, 125, 75},    /* 1/8 */
        {1000, 600, 126, 64, 250, 150},  /* 2/8: 1/8 is one pixel short in x */
        {257, 129, 200, 100, 225, 113},  /* 7/8, rounded up */
        {257, 129, 257, 129, 257, 129},  /* the file's size */
        {257, 129, 300, 64, 257, 129},   /* larger on one side: the whole file */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        for (int c = 1; c <= 3; c += 2) {
            JpegSpec s = {cases[i].w, cases[i].h, c, i % 2 == 1, true, 90, 0.1};
            char name[64];
            snprintf(name, sizeof name, "scaled%zu_%d.jpg", i, c);
            const char *path = wgt_path(name);
            write_jpeg(path, &s);
            int dw, dh, tw = cases[i].tw, th = cases[i].th, oc = c == 1 ? 1 : 4;
            WgError err = {0};
            assert_int_equal(wg_image_decode_size(path, tw, th, &dw, &dh, &err), WG_OK);
            if (dw != cases[i].dw || dh != cases[i].dh)
                fail_msg("%dx%d for %dx%d decodes at %dx%d, expected %dx%d", cases[i].w, cases[i].h,
                         tw, th, dw, dh, cases[i].dw, cases[i].dh);
            WgImage *full = read_ok(path, oc, WG_SRGB);
            WgImage *want = wg_image_convert(full, tw, th, oc);
            WgImage *dec = wg_image_new(dw, dh, oc);
            assert_int_equal(wg_image_read_into(path, WG_SRGB, dec, &err), WG_OK);
            WgImage *got = wg_image_new(tw, th, oc);
            assert_int_equal(wg_image_resample_into(NULL, dec, got), WG_OK);
            double max = 0, sum = 0;
            for (int y = 0; y < th; y++)
                for (int x = 0; x < tw; x++)
                    for (int k = 0; k < oc; k++) {
                        double e = fabs(wgt_px(got, x, y, k) - wgt_px(want, x, y, k));
                        sum += e;
                        if (e > max) max = e;
                    }
            double mean = sum / ((double)tw * th * oc);
            printf("%dx%d -> %dx%d via %dx%d, %d channels: max %.4f, mean %.5f\n", cases[i].w,
                   cases[i].h, tw, th, dw, dh, c, max, mean);
            if (dw == cases[i].w && dh == cases[i].h) assert_true(max == 0);
            if (max > 0.07 || mean > 0.007)
                fail_msg("%s: scaled decode differs by max %.4f, mean %.5f", path, max, mean);
            wg_image_unref(got);
            wg_image_unref(dec);
            wg_image_unref(want);
            wg_image_unref(full);
        }
    }
    /* a PNG is read at its own size whatever is asked */
    WgImage *img = wg_image_new(40, 30, 1);
    memset(img->data, 0, wg_image_bytes(img));
    WgError err = {0};
    assert_int_equal(wg_image_write(wgt_path("p.png"), img, WG_FORMAT_PNG, WG_LINEAR, &err), 0);
    int dw, dh;
    assert_int_equal(wg_image_decode_size(wgt_path("p.png"), 5, 5, &dw, &dh, &err), WG_OK);
    assert_int_equal(dw, 40);
    assert_int_equal(dh, 30);
    wg_image_unref(img);
}

/* The memory budget's view of a JPEG decode: a progressive file holds its coefficients for the
 * whole image (2 bytes a sample), a baseline one a few rows of blocks. */
static void test_jpeg_scratch_counts_progressive_coefficients(void **state)
{
    (void)state;
    static const int sizes[][2] = {{300, 200}, {37, 23}, {1000, 17}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        for (int c = 1; c <= 3; c += 2) {
            int w = sizes[i][0], h = sizes[i][1];
            JpegSpec p = {w, h, c, true, false, 80, 0.1}, b = {w, h, c, false, false, 80, 0.1};
            const char *pp = wgt_path("scratch_p.jpg"), *bp = wgt_path("scratch_b.jpg");
            write_jpeg(pp, &p);
            write_jpeg(bp, &b);
            size_t whole = 2 * (size_t)w * (size_t)h * (size_t)c;
            size_t sp = wg_image_read_scratch(pp), sb = wg_image_read_scratch(bp);
            if (sp < whole) fail_msg("progressive %dx%dx%d: scratch %zu < %zu", w, h, c, sp, whole);
            if (sb == 0 || sb >= sp) fail_msg("baseline %dx%dx%d: scratch %zu", w, h, c, sb);
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_native_decode_equals_openimageio),
        cmocka_unit_test(test_damaged_jpeg_refused_in_one_line),
        cmocka_unit_test(test_channels_other_than_the_files),
        cmocka_unit_test(test_scaled_decode_matches_full_decode),
        cmocka_unit_test(test_jpeg_scratch_counts_progressive_coefficients),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
