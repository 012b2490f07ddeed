/* SPDX-License-Identifier: MIT */
/* Image files in the layouts the engine does not write, and what it writes, held against
 * OpenImageIO read directly (tests/support/wgt_oiio.cpp, not wetgraph's module): tiled and
 * MIP-mapped EXR and TIFF files of sizes that are and are not multiples of the tile size; every
 * EXR the engine writes (single-layer half and float, layered) over a sweep of sizes and
 * contents, read back bit for bit by both readers; EXR files whose data window is not the
 * display window, natively and through OpenImageIO; hostile EXR headers that declare more than
 * the file holds, read within a bound on the peak memory of a child process; damaged PNG files
 * refused with one line on stderr and nothing from libpng; unknown critical PNG chunks; the
 * channel mapping of gray, gray+alpha, RGB and RGBA files; and errors that name the file. */
#include "wgtest.h"

#include "internal.h"
#include "wgio.h"
#include "wgt_oiio.h"

#include <fcntl.h>
#include <math.h>
#include <openexr.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

/* ---- helpers ----------------------------------------------------------------------------- */

static uint32_t rng = 0x2545f491u;

static uint32_t next_u32(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 17;
    rng ^= rng << 5;
    return rng;
}

static float unit(void)
{
    return (float)(next_u32() >> 8) / 16777216.0f;
}

static WgImage *read_ok(const char *path, int channels)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path, channels, WG_LINEAR, &img, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("read %s: %s", path, buf);
    }
    return img;
}

static void write_file(const char *path, const WgtOiioSpec *s, const float *data)
{
    char msg[512];
    if (wgt_oiio_write(path, s, data, msg, sizeof msg)) fail_msg("write %s: %s", path, msg);
}

static float *oiio_read(const char *path, WgtOiioSpec *s)
{
    char msg[512];
    float *px = wgt_oiio_read(path, s, msg, sizeof msg);
    if (!px) fail_msg("OpenImageIO read %s: %s", path, msg);
    return px;
}

static bool same_bits(float a, float b)
{
    return !memcmp(&a, &b, sizeof a);
}

/* The image read from `path` equals OpenImageIO's read_image of it, bit for bit: its channels
 * in place (gray as gray; RGB with alpha 1), and its size that of the data window. */
static void expect_equal_to_openimageio(const char *path, int expect_tiled)
{
    WgtOiioSpec s;
    float *ref = oiio_read(path, &s);
    if (expect_tiled) assert_true(s.tile_w > 0);
    WgImage *img = read_ok(path, 0);
    assert_int_equal(img->width, s.w);
    assert_int_equal(img->height, s.h);
    assert_int_equal(img->channels, s.c <= 2 ? 1 : 4);
    for (int y = 0; y < s.h; y++)
        for (int x = 0; x < s.w; x++)
            for (int k = 0; k < img->channels; k++) {
                float want = k < s.c ? ref[((size_t)y * s.w + x) * s.c + k] : 1.0f;
                float got = wgt_px(img, x, y, k);
                if (!same_bits(want, got))
                    fail_msg("%s: pixel (%d, %d) channel %d is %.9g, OpenImageIO reads %.9g", path,
                             x, y, k, got, want);
            }
    wg_image_unref(img);
    free(ref);
}

static float *random_pixels(int w, int h, int c)
{
    float *px = malloc((size_t)w * h * c * sizeof(float));
    assert_non_null(px);
    for (size_t i = 0; i < (size_t)w * h * c; i++) px[i] = unit();
    return px;
}

/* ---- tiled and MIP-mapped files ---------------------------------------------------------- */

static void test_tiled_files_read_as_openimageio(void **state)
{
    (void)state;
    static const struct {
        int w, h, tw, th;
    } sizes[] = {{8, 8, 4, 4},     {37, 23, 16, 16}, {5, 3, 16, 16},   {33, 17, 16, 32},
                 {64, 64, 16, 16}, {1, 1, 16, 16},   {50, 70, 32, 16}, {17, 40, 16, 16}};
    static const struct {
        const char *ext, *type;
        bool tiff;
    } kinds[] = {{"exr", "float", false},
                 {"exr", "half", false},
                 {"tif", "float", true},
                 {"tif", "uint16", true},
                 {"tif", "uint8", true}};
    static const int channels[] = {1, 3, 4, 2};
    int n = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
            int c = channels[(i + k) % 4];
            /* TIFF tiles are multiples of 16 */
            if (kinds[k].tiff && (sizes[i].tw % 16 || sizes[i].th % 16)) continue;
            WgtOiioSpec s = {.w = sizes[i].w,
                             .h = sizes[i].h,
                             .c = c,
                             .tile_w = sizes[i].tw,
                             .tile_h = sizes[i].th,
                             .type = kinds[k].type};
            float *px = random_pixels(s.w, s.h, c);
            char name[64];
            snprintf(name, sizeof name, "tiled%zu_%zu.%s", i, k, kinds[k].ext);
            const char *path = wgt_path(name);
            write_file(path, &s, px);
            expect_equal_to_openimageio(path, 1);
            free(px);
            n++;
        }
    assert_true(n >= 30);
}

static void test_mipmapped_files_read_their_first_level(void **state)
{
    (void)state;
    static const struct {
        int w, h, tw, th;
        const char *ext, *type;
    } files[] = {{53, 41, 16, 8, "exr", "half"},
                 {8, 8, 4, 4, "exr", "float"},
                 {64, 32, 32, 32, "exr", "float"},
                 {37, 19, 16, 16, "exr", "float"},
                 {100, 3, 64, 16, "exr", "half"}};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        int c = i % 2 ? 3 : 4;
        WgtOiioSpec s = {.w = files[i].w,
                         .h = files[i].h,
                         .c = c,
                         .tile_w = files[i].tw,
                         .tile_h = files[i].th,
                         .mipmap = true,
                         .type = files[i].type};
        float *px = random_pixels(s.w, s.h, c);
        char name[64];
        snprintf(name, sizeof name, "mip%zu.%s", i, files[i].ext);
        const char *path = wgt_path(name);
        write_file(path, &s, px);
        WgtOiioSpec got;
        free(oiio_read(path, &got));
        assert_true(got.mipmap);
        expect_equal_to_openimageio(path, 1);
        free(px);
    }
}

/* Multi-part files (read: the first part) pass the header walk whatever their parts' layout:
 * tiles larger than the image, scanlines in big chunks, several of each. */
static void test_multipart_files_read_their_first_part(void **state)
{
    (void)state;
    static const struct {
        int w, h, tile, parts;
        const char *type;
        bool constant;
    } files[] = {{64, 64, 64, 2, "half", false},   {13, 7, 32, 3, "float", false},
                 {40, 33, 0, 2, "float", false},   {5, 90, 0, 4, "half", false},
                 {37, 29, 8, 2, "float", false},   {2, 2048, 2048, 2, "half", true},
                 {3, 1000, 1024, 3, "float", true}};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        int c = i % 2 ? 4 : 3;
        WgtOiioSpec s = {.w = files[i].w,
                         .h = files[i].h,
                         .c = c,
                         .tile_w = files[i].tile,
                         .tile_h = files[i].tile,
                         .type = files[i].type,
                         .parts = files[i].parts};
        float *px = random_pixels(s.w, s.h, c);
        /* a constant tall part in one tile compresses to a few bytes: fewer than the offsets
         * its rows would need as scanline chunks */
        for (size_t k = 0; files[i].constant && k < (size_t)s.w * s.h * c; k++) px[k] = 0.5f;
        char name[64];
        snprintf(name, sizeof name, "parts%zu.exr", i);
        const char *path = wgt_path(name);
        write_file(path, &s, px);
        expect_equal_to_openimageio(path, files[i].tile > 0);
        free(px);
    }
}

/* ---- every EXR the engine writes reads back exactly -------------------------------------- */

/* Rounded to half as OpenEXR rounds (to nearest, ties to even). */
static float to_half(float v)
{
    return (float)(_Float16)v;
}

/* A finite float with random bits; for half, one a half holds exactly. */
static float random_finite(bool half)
{
    for (;;) {
        if (half) {
            _Float16 h;
            uint16_t bits = (uint16_t)next_u32();
            memcpy(&h, &bits, sizeof h);
            if (isfinite((float)h)) return (float)h;
        } else {
            uint32_t bits = next_u32();
            float f;
            memcpy(&f, &bits, sizeof f);
            if (isfinite(f)) return f;
        }
    }
}

enum { NOISE, NORMALS, CONSTANT, RANDOM_BITS, GRADIENT, CONTENTS };

/* An image of the kind `content` with c channels (1 or 4; alpha below 1 in places when
 * `alpha`). NORMALS renders the engine's own noise -> normal graph. */
static WgImage *content_image(int content, int w, int h, int c, bool alpha, bool half)
{
    if (content == NORMALS) {
        char attrs[64];
        snprintf(attrs, sizeof attrs, "seed=\"%d\"", (int)(next_u32() % 1000));
        WgImage *height = wgt_node("noise", attrs, w, h, 0, NULL, NULL, 0, 1);
        const char *names[] = {"height"};
        const WgImage *in[] = {height};
        WgImage *n = wgt_node("normal", "", w, h, 1, names, in, 0, 1);
        wg_image_unref(height);
        if (c == 1) {
            WgImage *g = wgt_image(w, h, 1, NULL);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++) wg_image_row(g, y)[x] = wgt_px(n, x, y, 0);
            wg_image_unref(n);
            return g;
        }
        if (alpha)
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++) wg_image_row(n, y)[4 * x + 3] = wgt_px(n, x, y, 2);
        return n;
    }
    WgImage *img = wgt_image(w, h, c, NULL);
    float constant = unit();
    for (int y = 0; y < h; y++) {
        float *row = wg_image_row(img, y);
        for (int x = 0; x < w; x++)
            for (int k = 0; k < c; k++) {
                float v = content == NOISE      ? unit()
                          : content == CONSTANT ? constant
                          : content == GRADIENT ? (float)(x + y * w + k) / (float)(w * h + 3)
                                                : random_finite(half);
                if (c == 4 && k == 3 && !alpha) v = 1.0f;
                row[x * c + k] = v;
            }
    }
    return img;
}

/* The file at path holds `img` (as half when `half`): read back by the engine and by
 * OpenImageIO, bit for bit, channel `k` of the file being channel k of the image (gray: Y). */
static void expect_exr_holds(const char *path, const WgImage *img, bool half, const char *what)
{
    WgImage *back = read_ok(path, img->channels);
    WgtOiioSpec s;
    float *ref = oiio_read(path, &s);
    assert_int_equal(s.w, img->width);
    assert_int_equal(s.h, img->height);
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            for (int k = 0; k < img->channels; k++) {
                float want = wgt_px(img, x, y, k);
                if (half) want = to_half(want);
                float ours = wgt_px(back, x, y, k);
                float theirs = k < s.c ? ref[((size_t)y * s.w + x) * s.c + k] : 1.0f;
                if (!same_bits(want, ours) || !same_bits(want, theirs))
                    fail_msg("%s (%dx%d, %s): pixel (%d, %d) channel %d: written %.9g, read back "
                             "%.9g by wetgraph and %.9g by OpenImageIO",
                             what, img->width, img->height, half ? "half" : "float", x, y, k, want,
                             ours, theirs);
            }
    free(ref);
    wg_image_unref(back);
}

static void write_and_check(int content, int w, int h, int c, bool alpha, bool half, int *files)
{
    static const char *const names[CONTENTS] = {"noise", "normals", "constant", "random bits",
                                                "gradient"};
    WgImage *img = content_image(content, w, h, c, alpha, half);
    WgError err = {0};
    const char *path = wgt_path("sweep.exr");
    /* Every tenth file through wg_image_write, the others through its encoder straight to the
     * file (the same channels: RGB when every alpha is 1): the write set's fsyncs of a
     * thousand files would make the test wait on the disk. */
    int rc;
    if (*files % 10 == 0) {
        rc = wg_image_write(path, img, half ? WG_FORMAT_EXR : WG_FORMAT_EXR32, WG_LINEAR, &err);
    } else {
        int fc = c == 4 ? 3 : 1;
        for (int y = 0; y < h && c == 4; y++)
            for (int x = 0; x < w; x++)
                if (wgt_px(img, x, y, 3) != 1.0f) fc = 4;
        rc = wg__exr_write_image(path, path, img, fc, half, NULL, &err);
    }
    if (rc) fail_msg("write %dx%d: %s", w, h, err.message);
    expect_exr_holds(path, img, half, names[content]);
    (*files)++;
    wg_image_unref(img);
}

static void test_exr_outputs_read_back_exactly(void **state)
{
    (void)state;
    int files = 0;
    for (int h = 1; h <= 12; h++)
        for (int w = 1; w <= 12; w++) {
            /* the normal maps of the engine at every size, in both types; the other contents
             * in turn */
            for (int half = 0; half < 2; half++) {
                write_and_check(NORMALS, w, h, 4, false, half, &files);
                write_and_check((w + h + half) % CONTENTS, w, h, (w + h) % 2 ? 4 : 1,
                                (w * h) % 3 == 0, half, &files);
                write_and_check(RANDOM_BITS, w, h, 4, true, half, &files);
            }
        }
    static const int larger[][2] = {{37, 29}, {64, 64}, {100, 3}, {257, 5}, {3, 100}, {129, 33}};
    for (size_t i = 0; i < sizeof larger / sizeof larger[0]; i++)
        for (int content = 0; content < CONTENTS; content++)
            for (int half = 0; half < 2; half++)
                write_and_check(content, larger[i][0], larger[i][1], content % 2 ? 1 : 4,
                                content == RANDOM_BITS, half, &files);
    assert_true(files > 900);
}

static void test_layered_exr_reads_back_exactly(void **state)
{
    (void)state;
    for (int w = 1; w <= 12; w++)
        for (int h = 1; h <= 12; h++) {
            bool half = (w + h) % 2;
            WgImage *a = content_image((w + h) % CONTENTS, w, h, 4, w % 2, half);
            WgImage *b = content_image((w * h) % CONTENTS, w, h, 1, false, half);
            WgImage *c = content_image((w + 2 * h + 1) % CONTENTS, w, h, 4, h % 2, half);
            const char *names[] = {"a", "b", "c"};
            const WgImage *images[] = {a, b, c};
            WgError err = {0};
            const char *path = wgt_path("layers.exr");
            if (wg_exr_write_layers(path, 3, names, images, half, &err))
                fail_msg("write layers: %s", err.message);
            WgtOiioSpec s;
            float *ref = oiio_read(path, &s);
            /* OpenImageIO gives each layer's channels in R G B A order: a.R a.G a.B a.A b.Y
             * c.R c.G c.B c.A */
            static const int layer_of[] = {0, 0, 0, 0, 1, 2, 2, 2, 2};
            static const int comp_of[] = {0, 1, 2, 3, 0, 0, 1, 2, 3};
            assert_int_equal(s.c, 9);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++)
                    for (int k = 0; k < 9; k++) {
                        float want = wgt_px(images[layer_of[k]], x, y, comp_of[k]);
                        if (half) want = to_half(want);
                        float got = ref[((size_t)y * w + x) * 9 + k];
                        if (!same_bits(want, got))
                            fail_msg("layered %dx%d %s: pixel (%d, %d) channel %d: %.9g read as "
                                     "%.9g",
                                     w, h, half ? "half" : "float", x, y, k, want, got);
                    }
            free(ref);
            wg_image_unref(a);
            wg_image_unref(b);
            wg_image_unref(c);
        }
}

/* OpenImageIO's EXR writer (OpenEXR's C++ library, which stores a chunk raw when it does not
 * shrink) gives files both readers read exactly too. */
static void test_openimageio_exr_writes_read_back_exactly(void **state)
{
    (void)state;
    for (int h = 1; h <= 12; h += 1)
        for (int w = 1; w <= 12; w += 3) {
            for (int half = 0; half < 2; half++) {
                WgImage *img = content_image(RANDOM_BITS, w, h, 4, true, half);
                float *packed = malloc((size_t)w * h * 4 * sizeof(float));
                for (int y = 0; y < h; y++)
                    memcpy(packed + (size_t)y * w * 4, wg_image_row(img, y),
                           (size_t)w * 4 * sizeof(float));
                char msg[256];
                const char *path = wgt_path("oiio_sweep.exr");
                if (wg__oiio_write(path, "exr", packed, w, h, 4, half ? -16 : 32, msg, sizeof msg))
                    fail_msg("%s", msg);
                expect_exr_holds(path, img, half, "written by OpenImageIO");
                free(packed);
                wg_image_unref(img);
            }
        }
}

/* ---- data windows ------------------------------------------------------------------------ */

/* A file whose data window (dw x dh at dx, dy) holds `px` and whose display window is
 * fw x fh at fx, fy reads as the display window with the data at its place and 0 elsewhere. */
static void check_window(int dx, int dy, int dw, int dh, int fx, int fy, int fw, int fh, int c,
                         int tile, const char *type, int index)
{
    WgtOiioSpec s = {.w = dw,
                     .h = dh,
                     .c = c,
                     .x = dx,
                     .y = dy,
                     .full_x = fx,
                     .full_y = fy,
                     .full_w = fw,
                     .full_h = fh,
                     .tile_w = tile,
                     .tile_h = tile,
                     .type = type};
    float *px = random_pixels(dw, dh, c);
    char name[64];
    snprintf(name, sizeof name, "window%d.exr", index);
    const char *path = wgt_path(name);
    write_file(path, &s, px);
    WgtOiioSpec got;
    free(oiio_read(path, &got));
    assert_int_equal(got.x, dx);
    assert_int_equal(got.full_w, fw);
    int w, h, pc;
    WgError err = {0};
    assert_int_equal(wg_image_probe(path, &w, &h, &pc, &err), WG_OK);
    assert_int_equal(w, fw);
    assert_int_equal(h, fh);
    WgImage *img = read_ok(path, 4);
    assert_int_equal(img->width, fw);
    assert_int_equal(img->height, fh);
    for (int y = 0; y < fh; y++)
        for (int x = 0; x < fw; x++) {
            int sx = x + fx - dx, sy = y + fy - dy;
            bool inside = sx >= 0 && sx < dw && sy >= 0 && sy < dh;
            for (int k = 0; k < 4; k++) {
                float want;
                int fk = c == 1 ? 0 : k; /* gray goes to R, G and B */
                if (k == 3 && c < 4)
                    want = 1.0f; /* no alpha in the file: opaque, as any file without one */
                else
                    want = inside ? px[((size_t)sy * dw + sx) * c + fk] : 0.0f;
                if (type && !strcmp(type, "half")) want = to_half(want);
                float v = wgt_px(img, x, y, k);
                if (!same_bits(v, want))
                    fail_msg("data window (%d,%d) %dx%d in display (%d,%d) %dx%d, %d channels, "
                             "tiles %d: pixel (%d, %d) channel %d is %.9g, not %.9g",
                             dx, dy, dw, dh, fx, fy, fw, fh, c, tile, x, y, k, v, want);
            }
        }
    wg_image_unref(img);
    free(px);
}

static void test_data_window_is_placed_in_the_display_window(void **state)
{
    (void)state;
    static const struct {
        int dx, dy, dw, dh, fx, fy, fw, fh;
    } windows[] = {
        {3, -2, 8, 8, 0, 0, 8, 8},    /* shifted right and up */
        {-5, -5, 8, 8, 0, 0, 8, 8},   /* negative origin */
        {5, 6, 6, 4, 0, 0, 8, 8},     /* partly outside right and below */
        {20, 20, 4, 4, 0, 0, 8, 8},   /* entirely outside */
        {-30, 2, 4, 4, 0, 0, 9, 7},   /* entirely outside on the left */
        {-2, -2, 12, 12, 0, 0, 8, 8}, /* larger than the display window */
        {12, 19, 4, 8, 10, 20, 7, 5}, /* display window not at 0,0 */
        {1, 1, 3, 37, 0, 0, 5, 40},   /* inside, taller than a chunk */
        {0, 0, 5, 5, 0, 0, 7, 3},     /* same origin, different size */
        {-7, 3, 23, 41, -10, 0, 19, 45},
    };
    static const int channels[] = {3, 4, 1};
    int index = 0;
    for (size_t i = 0; i < sizeof windows / sizeof windows[0]; i++)
        for (int layout = 0; layout < 3; layout++)
            for (int half = 0; half < 2; half++) {
                /* scanline files of 1, 3 or 4 channels are read natively; tiled ones, and five
                 * channels (the first four are RGBA), through OpenImageIO's tiles or scanlines */
                int c = layout == 2 ? 5 : channels[(i + half) % 3];
                check_window(windows[i].dx, windows[i].dy, windows[i].dw, windows[i].dh,
                             windows[i].fx, windows[i].fy, windows[i].fw, windows[i].fh, c,
                             layout == 1 ? 4 : 0, half ? "half" : "float", index++);
            }
}

/* Scanlines per chunk of an EXR file (OpenEXR's own answer). */
static int exr_lines(const char *path)
{
    exr_context_t ctx;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int32_t lines = 0;
    assert_int_equal(exr_start_read(&ctx, path, &init), EXR_ERR_SUCCESS);
    assert_int_equal(exr_get_scanlines_per_chunk(ctx, 0, &lines), EXR_ERR_SUCCESS);
    exr_finish(&ctx);
    return lines;
}

/* A data window whose rows start at an offset from the image's that is not a multiple of the
 * chunk height: strips of the image then share chunks, and each chunk is decoded once, the
 * pixels the same as OpenImageIO's. */
static void test_windowed_exr_decodes_each_chunk_once(void **state)
{
    (void)state;
    static const struct {
        int dy, dh, fh, c;
    } cases[] = {{5, 70, 80, 3}, {-3, 40, 33, 4}, {9, 17, 40, 1}, {1, 100, 101, 4}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        int c = cases[i].c, dw = 19, fw = 21;
        WgtOiioSpec s = {.w = dw,
                         .h = cases[i].dh,
                         .c = c,
                         .x = 1,
                         .y = cases[i].dy,
                         .full_w = fw,
                         .full_h = cases[i].fh};
        float *px = random_pixels(dw, cases[i].dh, c);
        char name[64];
        snprintf(name, sizeof name, "offset%zu.exr", i);
        const char *path = wgt_path(name);
        write_file(path, &s, px);
        int lines = exr_lines(path);
        WgExrIn *in;
        int w, h, fc, strip;
        char msg[512];
        if (wg__exr_open(path, &in, &w, &h, &fc, &strip, msg, sizeof msg))
            fail_msg("%s is not read natively", path);
        float *buf = malloc((size_t)w * (size_t)strip * (size_t)c * sizeof(float));
        assert_non_null(buf);
        for (int y0 = 0; y0 < h; y0 += strip) {
            int y1 = h - y0 < strip ? h : y0 + strip;
            if (wg__exr_read_rows(in, y0, y1, 0, c, buf, c * (ptrdiff_t)sizeof(float),
                                  (ptrdiff_t)((size_t)w * (size_t)c * sizeof(float)), msg,
                                  sizeof msg))
                fail_msg("%s: %s", path, msg);
        }
        /* the chunks holding the data rows inside the image */
        int first = cases[i].dy < 0 ? -cases[i].dy : 0;
        int last =
            cases[i].fh - cases[i].dy < cases[i].dh ? cases[i].fh - cases[i].dy : cases[i].dh;
        long chunks = (last - 1) / lines - first / lines + 1;
        if (wg__exr_decodes(in) != chunks)
            fail_msg("%s: %ld chunks decoded, %ld hold the rows (%d rows a chunk, strips of %d)",
                     path, wg__exr_decodes(in), chunks, lines, strip);
        free(buf);
        wg__exr_close(in);
        free(px);
        check_window(1, cases[i].dy, dw, cases[i].dh, 0, 0, fw, cases[i].fh, c, 0, "float",
                     900 + (int)i);
    }
}

/* Reading an EXR whose data window is far wider than the image: the decoder's chunk buffers are
 * as wide as the data window, and wg_image_read_scratch says so. */
static void test_exr_scratch_counts_the_data_window(void **state)
{
    (void)state;
    int dw = 4000, dh = 20, fw = 16, fh = 16, c = 3;
    WgtOiioSpec s = {.w = dw, .h = dh, .c = c, .x = -2000, .y = -2, .full_w = fw, .full_h = fh};
    float *px = random_pixels(dw, dh, c);
    const char *path = wgt_path("wide_window.exr");
    write_file(path, &s, px);
    free(px);
    int lines = exr_lines(path), strip = lines < 16 ? 16 : lines;
    size_t need = 2 * (size_t)dw * (size_t)strip * (size_t)c * sizeof(float) +
                  (size_t)dw * (size_t)lines * (size_t)c * sizeof(float);
    size_t got = wg_image_read_scratch(path);
    if (got < need)
        fail_msg("scratch %zu bytes for a %d-wide data window, needs %zu", got, dw, need);
    WgImage *img = read_ok(path, 4);
    assert_int_equal(img->width, fw);
    wg_image_unref(img);
}

/* ---- hostile EXR headers ----------------------------------------------------------------- */

static size_t put_attr(unsigned char *p, const char *name, const char *type, int32_t size,
                       const void *value, size_t value_len)
{
    size_t n = 0;
    memcpy(p + n, name, strlen(name) + 1);
    n += strlen(name) + 1;
    memcpy(p + n, type, strlen(type) + 1);
    n += strlen(type) + 1;
    memcpy(p + n, &size, 4); /* little-endian on the machines this runs on */
    n += 4;
    memcpy(p + n, value, value_len);
    return n + value_len;
}

static size_t put_box(unsigned char *p, const char *name, int32_t x0, int32_t y0, int32_t x1,
                      int32_t y1)
{
    int32_t b[4] = {x0, y0, x1, y1};
    return put_attr(p, name, "box2i", 16, b, 16);
}

/* A small EXR file (a few hundred bytes) with channels B G R Z (a layout only OpenImageIO
 * reads) whose header lies: an attribute of `attr_type` declaring `lie` bytes, or (attr_type
 * NULL) tiles of 1x1 over a data window of `side` squared. */
static void hostile_exr(const char *path, const char *attr_type, int32_t lie, int side)
{
    unsigned char buf[1024];
    size_t n = 0;
    static const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    memcpy(buf, magic, 4);
    uint32_t version = attr_type ? 2 : 2 | 0x200;
    memcpy(buf + 4, &version, 4);
    n = 8;
    unsigned char ch[4 * 18 + 1];
    size_t cn = 0;
    for (const char *name = "BGRZ"; *name; name++) {
        ch[cn++] = (unsigned char)*name;
        ch[cn++] = 0;
        int32_t fields[4] = {1, 0, 1, 1}; /* half, pLinear + reserved, x and y sampling */
        memcpy(ch + cn, fields, 16);
        cn += 16;
    }
    ch[cn++] = 0;
    n += put_attr(buf + n, "channels", "chlist", (int32_t)cn, ch, cn);
    n += put_attr(buf + n, "compression", "compression", 1, "\0", 1);
    n += put_box(buf + n, "dataWindow", 0, 0, side - 1, side - 1);
    n += put_box(buf + n, "displayWindow", 0, 0, side - 1, side - 1);
    n += put_attr(buf + n, "lineOrder", "lineOrder", 1, "\0", 1);
    float one = 1, zero[2] = {0, 0};
    n += put_attr(buf + n, "pixelAspectRatio", "float", 4, &one, 4);
    n += put_attr(buf + n, "screenWindowCenter", "v2f", 8, zero, 8);
    n += put_attr(buf + n, "screenWindowWidth", "float", 4, &one, 4);
    if (attr_type) {
        n += put_attr(buf + n, "zcomment", attr_type, lie, "abcdefgh", 8);
    } else {
        unsigned char tiles[9] = {1, 0, 0, 0, 1, 0, 0, 0, 0};
        n += put_attr(buf + n, "tiles", "tiledesc", 9, tiles, 9);
    }
    buf[n++] = 0;
    memset(buf + n, 0, 64);
    n += 64;
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
}

/* The peak resident memory (KiB) of `wetgraph render` reading `path` for a colour input under
 * --memory-budget 16 (errors expected), measured with getrusage(RUSAGE_CHILDREN) in a child
 * that only starts it and waits, so no other child of this test counts. The command is a new
 * process: forking this one, which holds OpenImageIO and its threads, would not be safe. */
static long peak_kib_reading(const char *path)
{
    char dir[1024], graph[1100];
    snprintf(dir, sizeof dir, "%s", wgt_path("peak"));
    mkdir(dir, 0777);
    snprintf(graph, sizeof graph, "%s/g.wetgraph", dir);
    wgt_write_file(graph, "<wetgraph version=\"1\" size=\"$img\">\n"
                          "  <input name=\"img\" type=\"color\"/>\n"
                          "  <output name=\"out\" from=\"$img\" format=\"exr32\"/>\n"
                          "</wetgraph>\n");
    char input[4096], out[4096];
    snprintf(input, sizeof input, "img=%s", path);
    snprintf(out, sizeof out, "%s/out", dir);
    const char *bin = getenv("WETGRAPH_BIN");
    assert_non_null(bin);
    int fds[2];
    assert_int_equal(pipe(fds), 0);
    pid_t outer = fork();
    assert_true(outer >= 0);
    if (outer == 0) {
        close(fds[0]);
        pid_t inner = fork();
        if (inner == 0) {
            int null = open("/dev/null", O_WRONLY);
            dup2(null, 1);
            dup2(null, 2);
            execl(bin, bin, "render", graph, "--input", input, "-o", out, "--memory-budget", "16",
                  (char *)NULL);
            _exit(127);
        }
        int st;
        long kib = -1;
        if (inner > 0 && waitpid(inner, &st, 0) == inner && WIFEXITED(st) &&
            WEXITSTATUS(st) != 127) {
            struct rusage ru;
            getrusage(RUSAGE_CHILDREN, &ru);
            kib = ru.ru_maxrss;
        }
        if (write(fds[1], &kib, sizeof kib) != sizeof kib) _exit(1);
        _exit(0);
    }
    close(fds[1]);
    long kib = -1;
    assert_int_equal(read(fds[0], &kib, sizeof kib), sizeof kib);
    close(fds[0]);
    int st;
    waitpid(outer, &st, 0);
    return kib;
}

static void test_hostile_exr_headers_keep_memory_bounded(void **state)
{
    (void)state;
    /* what reading a valid file through OpenImageIO takes (five channels: not read
     * natively): the libraries themselves */
    WgtOiioSpec s = {.w = 8, .h = 8, .c = 5};
    float *px = random_pixels(8, 8, 5);
    const char *valid = wgt_path("valid5.exr");
    write_file(valid, &s, px);
    free(px);
    long base = peak_kib_reading(valid);
    assert_true(base > 0);
    static const int32_t lies[] = {1600000000, 300000000, 700000000, 2147483647, 900000000};
    static const char *const types[] = {"string", "string", "stringvector", "string",
                                        "unknowntype"};
    for (size_t i = 0; i < sizeof lies / sizeof lies[0]; i++) {
        const char *path = wgt_path("hostile.exr");
        hostile_exr(path, types[i], lies[i], 8);
        long kib = peak_kib_reading(path);
        /* well under the smallest lie (300 MB) on top of the libraries */
        if (kib < 0 || kib > base + 64 * 1024)
            fail_msg("an attribute of %s declaring %d bytes: peak %ld KiB (a valid file: %ld)",
                     types[i], lies[i], kib, base);
        WgError err = {0};
        int w, h, c;
        assert_int_not_equal(wg_image_probe(path, &w, &h, &c, &err), WG_OK);
        wgt_assert_error(&err, WG_ERR_IO, 0, "hostile.exr|zcomment|declares");
    }
    /* a 16384-square data window in 1x1 tiles: 2 GiB of chunk offsets in a 400-byte file */
    for (int side = 4096; side <= 16384; side *= 2) {
        const char *path = wgt_path("hostile_tiles.exr");
        hostile_exr(path, NULL, 0, side);
        long kib = peak_kib_reading(path);
        if (kib < 0 || kib > base + 64 * 1024)
            fail_msg("1x1 tiles over %d squared: peak %ld KiB (a valid file: %ld)", side, kib,
                     base);
        WgError err = {0};
        int w, h, c;
        assert_int_not_equal(wg_image_probe(path, &w, &h, &c, &err), WG_OK);
        wgt_assert_error(&err, WG_ERR_IO, 0, "hostile_tiles.exr|chunks");
    }
}

/* A TIFF header (no pixels) of w x h with spp float samples per pixel in one strip. */
static void tiff_header(const char *path, uint32_t w, uint32_t h, uint16_t spp)
{
    static const uint16_t tags[] = {256, 257, 258, 259, 262, 273, 277, 278, 279, 284, 339};
    const uint32_t values[] = {w, h, 32, 1, spp < 3 ? 1 : 2, 8, spp, h, 16, 2, 3};
    unsigned char buf[256] = {'I', 'I', 42, 0, 24, 0, 0, 0};
    size_t n = 24;
    uint16_t count = sizeof tags / sizeof tags[0];
    memcpy(buf + n, &count, 2);
    n += 2;
    for (int i = 0; i < count; i++) {
        bool is_long =
            tags[i] == 256 || tags[i] == 257 || tags[i] == 273 || tags[i] == 278 || tags[i] == 279;
        uint16_t type = is_long ? 4 : 3;
        uint32_t one = 1;
        memcpy(buf + n, &tags[i], 2);
        memcpy(buf + n + 2, &type, 2);
        memcpy(buf + n + 4, &one, 4);
        memset(buf + n + 8, 0, 4);
        if (is_long)
            memcpy(buf + n + 8, &values[i], 4);
        else
            memcpy(buf + n + 8, &(uint16_t){(uint16_t)values[i]}, 2);
        n += 12;
    }
    memset(buf + n, 0, 4);
    n += 4;
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
}

/* OpenImageIO itself refuses a header claiming more pixel data than the largest image the
 * engine takes (16384 squared, four float channels: 4 GiB). */
static void test_openimageio_refuses_oversized_headers(void **state)
{
    (void)state;
    static const struct {
        uint32_t w, h;
        uint16_t spp;
        bool refused;
    } files[] = {{16384, 16384, 8, true},
                 {16384, 16384, 5, true},
                 {12000, 16384, 16, true},
                 {64, 48, 8, false},
                 {16384, 16384, 4, false}};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        const char *path = wgt_path("claims.tif");
        tiff_header(path, files[i].w, files[i].h, files[i].spp);
        int w, h, c;
        WgError err = {0};
        int rc = wg_image_probe(path, &w, &h, &c, &err);
        if (files[i].refused) {
            if (rc == WG_OK)
                fail_msg("a TIFF claiming %ux%u x %u floats was accepted", files[i].w, files[i].h,
                         files[i].spp);
            wgt_assert_error(&err, WG_ERR_IO, 0, "claims.tif|exceeds");
        } else {
            if (rc)
                fail_msg("%ux%u x %u floats: %s", files[i].w, files[i].h, files[i].spp,
                         err.message);
            assert_int_equal(w, (int)files[i].w);
            assert_int_equal(c, files[i].spp);
        }
    }
}

/* ---- PNG files libpng complains about ---------------------------------------------------- */

static size_t png_chunk(unsigned char *p, const char *type, const void *data, uint32_t len)
{
    unsigned char be[4] = {(unsigned char)(len >> 24), (unsigned char)(len >> 16),
                           (unsigned char)(len >> 8), (unsigned char)len};
    memcpy(p, be, 4);
    memcpy(p + 4, type, 4);
    if (len) memcpy(p + 8, data, len);
    uLong crc = crc32(0, (const Bytef *)type, 4);
    if (len) crc = crc32(crc, (const Bytef *)data, len); /* crc32(crc, NULL, 0) is 0, not crc */
    unsigned char c[4] = {(unsigned char)(crc >> 24), (unsigned char)(crc >> 16),
                          (unsigned char)(crc >> 8), (unsigned char)crc};
    memcpy(p + 8 + len, c, 4);
    return 12 + len;
}

enum {
    PNG_NO_PLTE,
    PNG_PLTE_AFTER_IDAT,
    PNG_TWO_PLTE,
    PNG_BAD_PLTE,
    PNG_CRITICAL,
    PNG_TWO_IHDR,
    PNG_HUGE_TEXT,
    PNG_INTERLACED_FILTER,
    PNG_SPLIT_IDAT,
    PNG_KINDS
};

/* A w x h PNG (palette or gray, 8 bits) with the flaw `kind`; `extra` adds an ancillary
 * unknown chunk, which is fine. */
static void flawed_png(const char *path, int kind, int w, int h, bool extra)
{
    static unsigned char buf[1 << 16];
    int type = kind == PNG_CRITICAL || kind == PNG_TWO_IHDR ? 0 : 3;
    size_t n = 0;
    memcpy(buf, "\x89PNG\r\n\x1a\n", 8);
    n = 8;
    bool interlaced = kind == PNG_INTERLACED_FILTER;
    unsigned char ihdr[13] = {0,
                              0,
                              0,
                              (unsigned char)w,
                              0,
                              0,
                              0,
                              (unsigned char)h,
                              8,
                              (unsigned char)type,
                              0,
                              0,
                              (unsigned char)interlaced};
    n += png_chunk(buf + n, "IHDR", ihdr, 13);
    if (kind == PNG_TWO_IHDR) n += png_chunk(buf + n, "IHDR", ihdr, 13);
    if (extra) n += png_chunk(buf + n, "teXt", "hello", 5);
    unsigned char plte[3 * 4] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 9, 9, 9};
    if (kind == PNG_TWO_PLTE) n += png_chunk(buf + n, "PLTE", plte, 12);
    if (kind == PNG_BAD_PLTE) n += png_chunk(buf + n, "PLTE", plte, 10);
    if (kind != PNG_NO_PLTE && kind != PNG_PLTE_AFTER_IDAT && kind != PNG_BAD_PLTE && type == 3)
        n += png_chunk(buf + n, "PLTE", plte, 12);
    if (kind == PNG_CRITICAL) n += png_chunk(buf + n, "ABCD", "xyz", 3);
    if (kind == PNG_HUGE_TEXT) {
        /* a text chunk declaring 9,000,000 bytes (libpng refuses chunks over 8,000,000) */
        unsigned char head[8] = {0x00, 0x89, 0x54, 0x40, 't', 'E', 'X', 't'};
        memcpy(buf + n, head, 8);
        memset(buf + n + 8, 'a', 4000);
        n += 8 + 4000;
    }
    unsigned char raw[64 * 65 * 2], packed[8192];
    size_t rn = 0;
    if (!interlaced) {
        for (int y = 0; y < h; y++) {
            raw[rn++] = 0;
            for (int x = 0; x < w; x++) raw[rn++] = (unsigned char)((x + y) % 4);
        }
    } else {
        /* Adam7's passes, one row (the middle one) with filter type 7 */
        static const int x0[7] = {0, 4, 0, 2, 0, 1, 0}, y0[7] = {0, 0, 4, 0, 2, 0, 1};
        static const int dx[7] = {8, 8, 4, 4, 2, 2, 1}, dy[7] = {8, 8, 8, 4, 4, 2, 2};
        int rows = 0;
        for (int p = 0; p < 7; p++)
            if (w > x0[p] && h > y0[p]) rows += (h - y0[p] + dy[p] - 1) / dy[p];
        for (int p = 0, r = 0; p < 7; p++) {
            if (w <= x0[p] || h <= y0[p]) continue;
            int pw = (w - x0[p] + dx[p] - 1) / dx[p], ph = (h - y0[p] + dy[p] - 1) / dy[p];
            for (int y = 0; y < ph; y++, r++) {
                raw[rn++] = r == rows / 2 ? 7 : 0;
                memset(raw + rn, 1, (size_t)pw);
                rn += (size_t)pw;
            }
        }
    }
    uLongf plen = sizeof packed;
    assert_int_equal(compress(packed, &plen, raw, (uLong)rn), Z_OK);
    if (kind == PNG_SPLIT_IDAT) {
        /* the data in two IDAT chunks with a text chunk between them */
        uint32_t half = (uint32_t)plen / 2;
        n += png_chunk(buf + n, "IDAT", packed, half);
        n += png_chunk(buf + n, "tEXt", "a\0b", 3);
        n += png_chunk(buf + n, "IDAT", packed + half, (uint32_t)plen - half);
    } else {
        n += png_chunk(buf + n, "IDAT", packed, (uint32_t)plen);
    }
    if (kind == PNG_PLTE_AFTER_IDAT) n += png_chunk(buf + n, "PLTE", plte, 12);
    n += png_chunk(buf + n, "IEND", NULL, 0);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
}

static int count_lines(const char *path)
{
    size_t size;
    char *text = wgt_read_file(path, &size);
    int lines = 0;
    for (size_t i = 0; i < size; i++) lines += text[i] == '\n';
    if (size && text[size - 1] != '\n') lines++;
    free(text);
    return lines;
}

static void test_flawed_png_is_one_line_without_libpng(void **state)
{
    (void)state;
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", wgt_path("pngcli"));
    mkdir(dir, 0777);
    wgt_write_file(wgt_join(dir, "g.wetgraph"),
                   "<wetgraph version=\"1\" size=\"$img\">\n"
                   "  <input name=\"img\" type=\"color\"/>\n"
                   "  <output name=\"out\" from=\"$img\" format=\"exr32\"/>\n"
                   "</wetgraph>\n");
    static const char *const needles[PNG_KINDS] = {
        "PLTE", "PLTE", "PLTE", "PLTE", "ABCD", "IHDR", "tEXt", "filter type 7", "consecutive"};
    for (int kind = 0; kind < PNG_KINDS; kind++)
        for (int v = 0; v < 3; v++) {
            int w = 1 + 13 * v + kind, h = 1 + 7 * v;
            char name[64];
            snprintf(name, sizeof name, "flaw%d_%d.png", kind, v);
            flawed_png(wgt_join(dir, name), kind, w, h, v == 1);
            int rc = wgt_shell(dir, "\"$WG\" render g.wetgraph --input img=%s -o out", name);
            const char *err = wgt_join(dir, "err");
            if (rc == 0 || count_lines(err) != 1 || wgt_count_in(err, "libpng") ||
                !wgt_count_in(err, name) || !wgt_count_in(err, needles[kind])) {
                char *text = wgt_read_file(err, NULL);
                fail_msg("%s (%dx%d): exit %d, stderr:\n%s", name, w, h, rc, text);
            }
        }
    /* the same files through the library: refused by the probe and by the read */
    for (int kind = 0; kind < PNG_KINDS; kind++) {
        char name[64];
        snprintf(name, sizeof name, "flaw%d_0.png", kind);
        const char *path = wgt_join(dir, name);
        WgError err = {0};
        int w, h, c;
        /* the probe stops at the image data, whose rows only the read inflates */
        int probe = wg_image_probe(path, &w, &h, &c, &err);
        if (kind != PNG_INTERLACED_FILTER && kind != PNG_SPLIT_IDAT) {
            assert_int_not_equal(probe, WG_OK);
            wgt_assert_error(&err, WG_ERR_IO, 0, name);
        }
        /* the read, on an image of the size the file declares */
        WgImage *dst = wg_image_new(1 + kind, 1, 4);
        memset(&err, 0, sizeof err);
        assert_int_not_equal(wg_image_read_into(path, WG_LINEAR, dst, &err), WG_OK);
        wgt_assert_error(&err, WG_ERR_IO, 0, name);
        wg_image_unref(dst);
    }
}

static void test_unknown_critical_png_chunk_is_refused(void **state)
{
    (void)state;
    /* a gray 8-bit PNG the engine decodes itself, with a chunk placed before or after the
     * image data: unknown critical ones are refused, unknown ancillary ones skipped */
    static const struct {
        const char *type;
        bool critical;
    } chunks[] = {{"ABCD", true}, {"XyZw", true}, {"aBCD", false}, {"zzZz", false}};
    for (size_t i = 0; i < sizeof chunks / sizeof chunks[0]; i++)
        for (int after = 0; after < 2; after++) {
            static unsigned char buf[4096];
            int w = 3 + (int)i, h = 2 + after;
            size_t n = 8;
            memcpy(buf, "\x89PNG\r\n\x1a\n", 8);
            unsigned char ihdr[13] = {0, 0, 0, (unsigned char)w, 0, 0, 0, (unsigned char)h, 8, 0,
                                      0, 0, 0};
            n += png_chunk(buf + n, "IHDR", ihdr, 13);
            if (!after) n += png_chunk(buf + n, chunks[i].type, "data", 4);
            unsigned char raw[64], packed[256];
            memset(raw, 0, sizeof raw);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++) raw[y * (w + 1) + 1 + x] = (unsigned char)(40 * x);
            uLongf plen = sizeof packed;
            assert_int_equal(compress(packed, &plen, raw, (uLong)(h * (w + 1))), Z_OK);
            n += png_chunk(buf + n, "IDAT", packed, (uint32_t)plen);
            if (after) n += png_chunk(buf + n, chunks[i].type, "data", 4);
            n += png_chunk(buf + n, "IEND", NULL, 0);
            const char *path = wgt_path("chunk.png");
            FILE *f = fopen(path, "wb");
            fwrite(buf, 1, n, f);
            fclose(f);
            WgImage *img = NULL;
            WgError err = {0};
            int rc = wg_image_read(path, 1, WG_LINEAR, &img, &err);
            if (chunks[i].critical) {
                if (rc == WG_OK)
                    fail_msg("chunk %s (after the data: %d) accepted", chunks[i].type, after);
                wgt_assert_error(&err, WG_ERR_IO, 0, "chunk.png|critical");
                assert_non_null(strstr(err.message, chunks[i].type));
            } else {
                if (rc) fail_msg("chunk %s refused: %s", chunks[i].type, err.message);
                for (int x = 0; x < w; x++)
                    assert_true(wgt_px(img, x, h - 1, 0) == (float)(40 * x) * (1.0f / 255.0f));
                wg_image_unref(img);
            }
        }
}

/* ---- channel mapping --------------------------------------------------------------------- */

/* A file of `c` channels (1 gray, 2 gray+alpha, 3 RGB, 4 RGBA) read into colour and gray:
 * colour gets gray in R, G and B and the file's alpha or 1; gray gets gray, or the luminance
 * of colour; alpha is never mixed into gray. */
static void check_mapping(const char *path, const float *px, int w, int h, int c, float step)
{
    WgImage *col = read_ok(path, 4), *gray = read_ok(path, 1);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *p = px + ((size_t)y * w + x) * c;
            float want[4];
            if (c <= 2) {
                want[0] = want[1] = want[2] = p[0];
                want[3] = c == 2 ? p[1] : 1.0f;
            } else {
                for (int k = 0; k < 3; k++) want[k] = p[k];
                want[3] = c == 4 ? p[3] : 1.0f;
            }
            for (int k = 0; k < 4; k++)
                if (fabsf(wgt_px(col, x, y, k) - want[k]) > step)
                    fail_msg("%s (%d channels) into colour: pixel (%d, %d) channel %d is %.9g, "
                             "not %.9g",
                             path, c, x, y, k, wgt_px(col, x, y, k), want[k]);
            float g = c <= 2 ? p[0] : wg__luminance(want);
            if (fabsf(wgt_px(gray, x, y, 0) - g) > step)
                fail_msg("%s (%d channels) into gray: pixel (%d, %d) is %.9g, not %.9g", path, c, x,
                         y, wgt_px(gray, x, y, 0), g);
        }
    wg_image_unref(col);
    wg_image_unref(gray);
}

static void test_channel_mapping_rules(void **state)
{
    (void)state;
    static const struct {
        const char *ext, *type;
        int tile;
    } kinds[] = {{"png", "uint8", 0},  {"png", "uint16", 0}, {"tif", "uint16", 0},
                 {"tif", "float", 16}, {"exr", "half", 0},   {"exr", "float", 0},
                 {"exr", "float", 4}};
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++)
        for (int c = 1; c <= 4; c++) {
            int w = 3 + c + (int)k, h = 2 + c;
            float *px = random_pixels(w, h, c);
            /* values the format holds exactly, so only the mapping is compared */
            float step = !strcmp(kinds[k].type, "uint8")    ? 1.0f / 255.0f
                         : !strcmp(kinds[k].type, "uint16") ? 1.0f / 65535.0f
                         : !strcmp(kinds[k].type, "half")   ? 1.0f / 1024.0f
                                                            : 0.0f;
            WgtOiioSpec s = {.w = w,
                             .h = h,
                             .c = c,
                             .tile_w = kinds[k].tile,
                             .tile_h = kinds[k].tile,
                             .type = kinds[k].type};
            char name[64];
            snprintf(name, sizeof name, "map%zu_%d.%s", k, c, kinds[k].ext);
            const char *path = wgt_path(name);
            write_file(path, &s, px);
            check_mapping(path, px, w, h, c, step);
            free(px);
        }
}

/* ---- errors name the file ---------------------------------------------------------------- */

static void test_exr_errors_name_the_file(void **state)
{
    (void)state;
    static const struct {
        const char *bytes;
        size_t len;
    } files[] = {
        {"v/1\x01", 4},                          /* the magic number alone */
        {"v/1\x01\x02\x00\x00\x00", 8},          /* and the version */
        {"v/1\x01garbage!", 11},                 /* an unknown version */
        {"v/1\x01\x02\x00\x00\x00chan", 12},     /* cut inside a name */
        {"v/1\x01\x02\x00\x00\x00\x00\x00", 10}, /* no attributes */
    };
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        char name[64];
        snprintf(name, sizeof name, "broken%zu.exr", i);
        const char *path = wgt_path(name);
        FILE *f = fopen(path, "wb");
        fwrite(files[i].bytes, 1, files[i].len, f);
        fclose(f);
        for (int read = 0; read < 2; read++) {
            WgError err = {0};
            WgImage *img = NULL;
            int w, h, c;
            int rc = read ? wg_image_read(path, 4, WG_LINEAR, &img, &err)
                          : wg_image_probe(path, &w, &h, &c, &err);
            assert_int_not_equal(rc, WG_OK);
            char text[1024];
            wg_error_format(&err, text, sizeof text);
            /* the file named once, no empty quotes or name-less phrases, one line */
            if (!strstr(text, name) || strstr(text, "  ") || strstr(text, "\"\"") ||
                strstr(text, "file .") || strchr(text, '\n') || strstr(text, ":  "))
                fail_msg("%s: %s", name, text);
        }
    }
}

/* ---- the PNG writer, checked against libpng's reading (through OpenImageIO) ------------ */

/* Content that makes every PNG filter win somewhere: smooth ramps, noise, flat runs, values
 * outside [0, 1] and NaN; alpha strictly inside (0, 1) so that it is kept. */
static float png_sample(int content, int x, int y, int k, int c)
{
    if (c == 2 ? k == 1 : c == 4 && k == 3) return 0.05f + 0.9f * unit();
    switch (content) {
    case 0:
        return (float)(x * 3 + y * 7 + k * 11) / 300.0f;
    case 1:
        return unit() * 1.2f - 0.1f;
    case 2:
        return (x / 4 + y / 3) % 2 ? 0.25f : 0.75f;
    default:
        return (x + y) % 97 == 0 ? NAN : sinf((float)x * 0.05f + (float)k) * 0.6f + 0.5f;
    }
}

static void test_png_writer_codes_read_back_through_libpng(void **state)
{
    (void)state;
    static const int sizes[][2] = {{1, 1}, {3, 5}, {257, 129}, {64, 33}, {2, 300}};
    int files = 0;
    for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++)
        for (int c = 1; c <= 4; c += c == 1 ? 2 : 1) /* gray, RGB, RGBA files */
            for (int bits = 8; bits <= 16; bits += 8)
                for (int srgb = 0; srgb < 2; srgb++) {
                    int w = sizes[si][0], h = sizes[si][1], content = (int)(si + c + bits) % 4;
                    WgImage *img = wg_image_new(w, h, c == 3 ? 4 : c);
                    assert_non_null(img);
                    for (int y = 0; y < h; y++) {
                        float *r = wg_image_row(img, y);
                        for (int x = 0; x < w; x++)
                            for (int k = 0; k < img->channels; k++)
                                r[x * img->channels + k] =
                                    c == 3 && k == 3 ? 1.0f : png_sample(content, x, y, k, c);
                    }
                    char path[1200];
                    snprintf(path, sizeof path, "%s/pngw_%d_%d_%d_%d_%d.png", wgt_tmpdir(), w, h, c,
                             bits, srgb);
                    WgColorspace cs = srgb ? WG_SRGB : WG_LINEAR;
                    WgError err = {0};
                    assert_int_equal(wg_image_write(path, img,
                                                    bits == 8 ? WG_FORMAT_PNG : WG_FORMAT_PNG16, cs,
                                                    &err),
                                     WG_OK);
                    WgtOiioSpec spec = {0};
                    float *px = oiio_read(path, &spec);
                    assert_int_equal(spec.w, w);
                    assert_int_equal(spec.h, h);
                    assert_int_equal(spec.c, c);
                    double max = bits == 8 ? 255.0 : 65535.0;
                    for (int y = 0; y < h; y++) {
                        const float *r = wg_image_row(img, y);
                        for (int x = 0; x < w; x++)
                            for (int k = 0; k < c; k++) {
                                double v = r[x * img->channels + k];
                                bool colour = c <= 2 ? k == 0 : k < 3;
                                if (isnan(v)) v = 0;
                                if (srgb && colour) v = wg_linear_to_srgb((float)v);
                                v = v < 0 ? 0 : v > 1 ? 1 : v;
                                double want = floor(v * max + 0.5);
                                double got = (double)px[((size_t)y * w + x) * c + k] * max;
                                if (fabs(got - want) > 0.01)
                                    fail_msg("%s: (%d, %d, %d) holds %.0f, not %.0f", path, x, y, k,
                                             got, want);
                            }
                    }
                    free(px);
                    wg_image_unref(img);
                    files++;
                }
    assert_int_equal(files, 60);
}

/* A batch of images written by several threads: when one of them fails (its temporary cannot
 * be created: the target's folder is missing), every target of the set stays as it was and no
 * temporary is left behind; once the folder is there, the batch replaces them all. */
static void test_parallel_write_failure_leaves_the_old_set(void **state)
{
    (void)state;
    char dir[1100], sub[1200], paths[6][1300];
    snprintf(dir, sizeof dir, "%s/pset", wgt_tmpdir());
    snprintf(sub, sizeof sub, "%s/later", dir);
    mkdir(dir, 0777);
    WgImage *old = wg_image_new(40, 30, 1), *img[6];
    assert_non_null(old);
    for (int y = 0; y < 30; y++)
        for (int x = 0; x < 40; x++) wg_image_row(old, y)[x] = 0.5f;
    const char *ptrs[6];
    WgFormat formats[6];
    WgColorspace cs[6];
    struct stat before[6];
    for (int i = 0; i < 6; i++) {
        snprintf(paths[i], sizeof paths[i], "%s/out%d.png", i == 3 ? sub : dir, i);
        WgError err = {0};
        if (i != 3) {
            assert_int_equal(wg_image_write(paths[i], old, WG_FORMAT_PNG16, WG_LINEAR, &err),
                             WG_OK);
            assert_int_equal(stat(paths[i], &before[i]), 0);
        }
        img[i] = wg_image_new(40 + i, 30, i % 2 ? 4 : 1);
        assert_non_null(img[i]);
        for (int y = 0; y < 30; y++)
            for (int x = 0; x < (40 + i) * img[i]->channels; x++)
                wg_image_row(img[i], y)[x] = unit();
        ptrs[i] = paths[i];
        formats[i] = i % 2 ? WG_FORMAT_PNG : WG_FORMAT_PNG16;
        cs[i] = i % 2 ? WG_SRGB : WG_LINEAR;
    }
    size_t n_old;
    char *old_bytes = wgt_read_file(paths[0], &n_old);

    for (int threads = 1; threads <= 4; threads++) {
        WgWriteSet *s = wg_write_set_new();
        WgError err = {0};
        assert_int_not_equal(wg_write_set_images(s, 6, ptrs, (const WgImage *const *)img, formats,
                                                 cs, NULL, threads, &err),
                             WG_OK);
        assert_string_equal(err.file, paths[3]);
        assert_int_equal(wg_write_set_commit(s, &err), WG_OK); /* nothing left to commit */
        wg_write_set_free(s);
        for (int i = 0; i < 6; i++) {
            if (i == 3) continue;
            struct stat st;
            assert_int_equal(stat(paths[i], &st), 0);
            assert_true(st.st_ino == before[i].st_ino && st.st_size == before[i].st_size);
        }
        size_t n;
        char *b = wgt_read_file(paths[0], &n);
        assert_true(n == n_old && !memcmp(b, old_bytes, n));
        free(b);
        int hidden = 0;
        wgt_count_files(dir, &hidden);
        assert_int_equal(hidden, 0);
    }

    mkdir(sub, 0777);
    WgWriteSet *s = wg_write_set_new();
    WgError err = {0};
    assert_int_equal(
        wg_write_set_images(s, 6, ptrs, (const WgImage *const *)img, formats, cs, NULL, 3, &err),
        WG_OK);
    assert_int_equal(wg_write_set_commit(s, &err), WG_OK);
    wg_write_set_free(s);
    for (int i = 0; i < 6; i++) {
        WgImage *back = read_ok(paths[i], 0);
        assert_int_equal(back->width, 40 + i);
        wg_image_unref(back);
        wg_image_unref(img[i]);
    }
    free(old_bytes);
    wg_image_unref(old);
}

/* The ZIP chunks of the EXRs we write, compressed by our own ZIP (libdeflate), read back by
 * OpenImageIO (OpenEXR's C++ library and its own inflate) and by our reader as the images they
 * were written from: float bit for bit, half as OpenEXR rounds; chunks that compress (smooth
 * ramps) and chunks that do not (random bits, stored raw); gray and colour; odd sizes; one
 * layer and several. */
static void test_exr_zip_chunks_read_back_everywhere(void **state)
{
    (void)state;
    static const int sizes[][2] = {{37, 19}, {1, 70}, {129, 33}};
    unsigned seed = 12345;
    for (int v = 0; v < 3; v++)
        for (int kind = 0; kind < 2; kind++) /* 0: smooth, 1: random bits */
            for (int ch = 1; ch <= 4; ch += 3)
                for (int half = 0; half < 2; half++) {
                    int w = sizes[v][0], h = sizes[v][1];
                    WgImage *img = wg_image_new(w, h, ch);
                    assert_non_null(img);
                    for (int y = 0; y < h; y++)
                        for (int x = 0; x < w * ch; x++) {
                            float f;
                            if (kind == 0) {
                                f = (float)(x + 3 * y) / 97.0f;
                            } else { /* finite random floats of any magnitude */
                                seed = seed * 1103515245u + 12345u;
                                uint32_t bits = seed ^ (seed >> 13) << 7;
                                bits &= 0xbf7fffffu; /* exponent below 255: finite */
                                memcpy(&f, &bits, sizeof f);
                                if (half) f = (float)((x % 7) * 0.37 - y * 0.011); /* in range */
                            }
                            wg_image_row(img, y)[x] = f;
                        }
                    if (ch == 4) /* alpha not all 1: written as RGBA */
                        wg_image_row(img, 0)[3] = 0.5f;
                    const char *path = wgt_path("zip.exr");
                    WgError err = {0};
                    WgFormat f = half ? WG_FORMAT_EXR : WG_FORMAT_EXR32;
                    assert_int_equal(wg_image_write(path, img, f, WG_LINEAR, &err), WG_OK);
                    WgImage *ours = NULL;
                    assert_int_equal(wg_image_read(path, 0, WG_LINEAR, &ours, &err), WG_OK);
                    char msg[512];
                    WgtOiioSpec spec = {0};
                    float *ref = wgt_oiio_read(path, &spec, msg, sizeof msg);
                    if (!ref) fail_msg("OpenImageIO cannot read our EXR: %s", msg);
                    assert_int_equal(spec.w, w);
                    assert_int_equal(spec.h, h);
                    assert_int_equal(spec.c, ch);
                    for (int y = 0; y < h; y++)
                        for (int x = 0; x < w * ch; x++) {
                            float src = wg_image_row(img, y)[x];
                            float want = half ? to_half(src) : src;
                            float a = wg_image_row(ours, y)[x], b = ref[(size_t)y * w * ch + x];
                            if (memcmp(&a, &want, 4) || memcmp(&b, &want, 4))
                                fail_msg("%dx%dx%d %s %s at %d,%d: ours %a, OpenImageIO %a, "
                                         "written %a",
                                         w, h, ch, half ? "half" : "float",
                                         kind ? "random" : "smooth", x, y, a, b, src);
                        }
                    free(ref);
                    wg_image_unref(ours);
                    /* and as a layer of a layered EXR, beside a second one */
                    const char *names[] = {"a", "b"};
                    const WgImage *imgs[] = {img, img};
                    const char *lpath = wgt_path("zipl.exr");
                    assert_int_equal(wg_exr_write_layers(lpath, 2, names, imgs, half, &err), WG_OK);
                    WgtOiioSpec lspec = {0};
                    float *lref = wgt_oiio_read(lpath, &lspec, msg, sizeof msg);
                    if (!lref) fail_msg("OpenImageIO cannot read our layered EXR: %s", msg);
                    assert_int_equal(lspec.c, 2 * ch);
                    free(lref);
                    wg_image_unref(img);
                }
}

/* The chunks of an EXR encoded on other threads, in any order, a window of them at a time: the
 * same file as on the calling thread (more chunks than a window, a short last window, half and
 * float, gray and colour, compressible and not); a runner that stops fails the write, naming the
 * file. */
static void test_exr_chunks_on_threads_make_the_same_file(void **state)
{
    (void)state;
    static const int sizes[][2] = {{7, 64 * 16 + 37}, {33, 16 * 64}, {5, 3}};
    WgWorkers threads = {.run = wgt_run_backwards};
    WgWorkers stops = {.run = wgt_run_backwards, .ctx = &wgt_parts_run};
    unsigned seed = 99;
    for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++)
        for (int ch = 1; ch <= 4; ch += 3)
            for (int half = 0; half < 2; half++) {
                int w = sizes[si][0], h = sizes[si][1];
                WgImage *img = wg_image_new(w, h, ch);
                assert_non_null(img);
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w * ch; x++) {
                        seed = seed * 1103515245u + 12345u;
                        wg_image_row(img, y)[x] =
                            y % 50 < 25 ? (float)(x + y) / 64.0f : (float)(seed >> 8) / 65536.0f;
                    }
                const char *one = wgt_path("one.exr"), *many = wgt_path("many.exr");
                WgError err = {0};
                wgt_parts_run = 0;
                assert_int_equal(wg__exr_write_image(one, one, img, ch, half, NULL, &err), WG_OK);
                assert_int_equal(wg__exr_write_image(many, many, img, ch, half, &threads, &err),
                                 WG_OK);
                assert_true(wgt_parts_run >= (h + 15) / 16); /* every chunk a part */
                assert_true(wgt_same_file(one, many));
                WgImage *back = NULL;
                assert_int_equal(wg_image_read(many, 0, WG_LINEAR, &back, &err), WG_OK);
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w * ch; x++) {
                        float want = wg_image_row(img, y)[x];
                        if (half) want = to_half(want);
                        assert_true(same_bits(want, wg_image_row(back, y)[x]));
                    }
                wg_image_unref(back);
                const char *cut = wgt_path("cut.exr");
                assert_int_not_equal(wg__exr_write_image(cut, cut, img, ch, half, &stops, &err),
                                     WG_OK);
                assert_non_null(strstr(err.message, "cancelled"));
                /* and one that leaves a chunk out fails, never writing a file without it */
                WgWorkers skips = {.run = wgt_run_skipping_one};
                if (h > 16) {
                    assert_int_not_equal(wg__exr_write_image(cut, cut, img, ch, half, &skips, &err),
                                         WG_OK);
                    assert_non_null(strstr(err.message, "not encoded"));
                }
                wg_image_unref(img);
            }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_windowed_exr_decodes_each_chunk_once),
        cmocka_unit_test(test_exr_scratch_counts_the_data_window),
        cmocka_unit_test(test_tiled_files_read_as_openimageio),
        cmocka_unit_test(test_mipmapped_files_read_their_first_level),
        cmocka_unit_test(test_multipart_files_read_their_first_part),
        cmocka_unit_test(test_exr_outputs_read_back_exactly),
        cmocka_unit_test(test_layered_exr_reads_back_exactly),
        cmocka_unit_test(test_openimageio_exr_writes_read_back_exactly),
        cmocka_unit_test(test_data_window_is_placed_in_the_display_window),
        cmocka_unit_test(test_hostile_exr_headers_keep_memory_bounded),
        cmocka_unit_test(test_openimageio_refuses_oversized_headers),
        cmocka_unit_test(test_flawed_png_is_one_line_without_libpng),
        cmocka_unit_test(test_unknown_critical_png_chunk_is_refused),
        cmocka_unit_test(test_channel_mapping_rules),
        cmocka_unit_test(test_exr_errors_name_the_file),
        cmocka_unit_test(test_png_writer_codes_read_back_through_libpng),
        cmocka_unit_test(test_parallel_write_failure_leaves_the_old_set),
        cmocka_unit_test(test_exr_zip_chunks_read_back_everywhere),
        cmocka_unit_test(test_exr_chunks_on_threads_make_the_same_file),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
