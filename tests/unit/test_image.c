/* SPDX-License-Identifier: MIT */
/* WgImage: size limits, layout, reference counting, wg_image_convert (resampling against float64
 * references: a wrapping tent of half-width max(1, source/target), i.e. bilinear when enlarging;
 * constants kept exactly; gray/colour conversion), wg_image_resample_into on the engine's threads
 * (the same values for every thread count, an infinite sample reaching only the outputs its
 * taps cover), images over the caller's memory (wg_image_wrap) and the allocation hook, including a
 * render under injected allocation failures. */
#include "wgtest.h"

#include "internal.h"

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

/* ---- a counting, failing allocator ------------------------------------------------------- */

static atomic_long n_allocs, n_frees;
static atomic_long fail_at = -1; /* index of the first allocation to fail; -1 never */
static atomic_bool fail_all;

static void *hook_alloc(size_t size, void *user)
{
    (void)user;
    long i = atomic_fetch_add(&n_allocs, 1);
    if (atomic_load(&fail_all)) return NULL;
    long f = atomic_load(&fail_at);
    if (f >= 0 && i >= f) return NULL;
    size_t rounded = (size + 63) & ~(size_t)63;
    return aligned_alloc(64, rounded);
}

static void hook_free(void *ptr, void *user)
{
    (void)user;
    atomic_fetch_add(&n_frees, 1);
    free(ptr);
}

static void install(long fail_from, bool all)
{
    atomic_store(&n_allocs, 0);
    atomic_store(&n_frees, 0);
    atomic_store(&fail_at, fail_from);
    atomic_store(&fail_all, all);
    wg_set_allocator(hook_alloc, hook_free, NULL);
}

static int restore_allocator(void **state)
{
    (void)state;
    wg_set_allocator(NULL, NULL, NULL);
    return 0;
}

/* ---- helpers ----------------------------------------------------------------------------- */

/* A deterministic, irregular test pattern in [0, 1). */
static double pattern(int x, int y, int k)
{
    uint32_t h = wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k + 17u);
    return (h >> 8) / 16777216.0;
}

static double src_at(const WgImage *img, int x, int y, int k)
{
    x = ((x % img->width) + img->width) % img->width;
    y = ((y % img->height) + img->height) % img->height;
    return wgt_px(img, x, y, k);
}

/* float64 reference weights for one axis, from the documented definition: a tent of half-width
 * max(1, src/dst) source pixels centred on the output pixel's centre, wrapping around the edges,
 * normalised per output pixel (bilinear when enlarging). Returns the number of taps written. */
static int ref_weights(int src, int dst, int o, int *index, double *weight)
{
    double scale = (double)src / dst, support = scale > 1 ? scale : 1;
    double c = (o + 0.5) * scale - 0.5, sum = 0;
    int n = 0;
    for (int i = (int)floor(c - support); i <= (int)ceil(c + support); i++) {
        double w = 1 - fabs(i - c) / support;
        if (w <= 0) continue;
        index[n] = ((i % src) + src) % src;
        weight[n++] = w;
        sum += w;
    }
    for (int k = 0; k < n; k++) weight[k] /= sum;
    return n;
}

static double reference(const WgImage *s, int w, int h, int x, int y, int k)
{
    int ix[64], iy[64];
    double wx[64], wy[64];
    int nx = ref_weights(s->width, w, x, ix, wx);
    int ny = ref_weights(s->height, h, y, iy, wy);
    double sum = 0;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) sum += wy[j] * wx[i] * src_at(s, ix[i], iy[j], k);
    return sum;
}

/* Convert and compare every value with the float64 reference. */
static void check_resample(const WgImage *s, int w, int h, double tol)
{
    WgImage *d = wg_image_convert(s, w, h, s->channels);
    assert_non_null(d);
    assert_int_equal(d->width, w);
    assert_int_equal(d->height, h);
    assert_int_equal(d->channels, s->channels);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < s->channels; k++) {
                double want = reference(s, w, h, x, y, k), got = wgt_px(d, x, y, k);
                if (!(fabs(got - want) <= tol))
                    fail_msg("%dx%d -> %dx%d: pixel %d,%d channel %d is %.9g, expected %.9g",
                             s->width, s->height, w, h, x, y, k, got, want);
            }
    wg_image_unref(d);
}

/* ---- creation ---------------------------------------------------------------------------- */

static void test_new_limits(void **state)
{
    (void)state;
    static const int bad[][3] = {{0, 5, 1},     {5, 0, 1},     {-1, 5, 1}, {5, -3, 4},
                                 {16385, 1, 1}, {1, 16385, 4}, {4, 4, 0},  {4, 4, 2},
                                 {4, 4, 3},     {4, 4, 5},     {4, 4, -1}, {-16384, -16384, 1}};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        if (wg_image_new(bad[i][0], bad[i][1], bad[i][2]))
            fail_msg("wg_image_new(%d, %d, %d) should fail", bad[i][0], bad[i][1], bad[i][2]);
        assert_null(wg_image_new_zero(bad[i][0], bad[i][1], bad[i][2]));
    }
    static const int good[][3] = {{1, 1, 1},  {1, 1, 4},     {3, 2, 4},
                                  {17, 5, 1}, {16384, 1, 1}, {1, 16384, 4}};
    for (size_t i = 0; i < sizeof good / sizeof *good; i++) {
        int w = good[i][0], h = good[i][1], c = good[i][2];
        WgImage *img = wg_image_new(w, h, c);
        assert_non_null(img);
        assert_int_equal(img->width, w);
        assert_int_equal(img->height, h);
        assert_int_equal(img->channels, c);
        assert_int_equal(img->refcount_, 1);
        /* rows start on 64-byte boundaries */
        assert_true(img->stride >= (size_t)w * c);
        assert_int_equal(img->stride % 16, 0);
        assert_int_equal((uintptr_t)img->data % 64, 0);
        assert_int_equal(wg_image_bytes(img), img->stride * (size_t)h * sizeof(float));
        assert_int_equal(wg_image_bytes_for(w, h, c), wg_image_bytes(img));
        wg_image_unref(img);
    }
    assert_int_equal(wg_image_bytes_for(3, 2, 4), 16 * 2 * sizeof(float));
    assert_int_equal(wg_image_bytes_for(17, 5, 1), 32 * 5 * sizeof(float));
    assert_int_equal(wg_image_bytes(NULL), 0);

    WgImage *z = wg_image_new_zero(5, 3, 4);
    assert_non_null(z);
    for (int y = 0; y < 3; y++)
        for (int i = 0; i < 20; i++) assert_true(wg_image_row(z, y)[i] == 0.0f);
    wg_image_unref(z);
}

static void test_refcount(void **state)
{
    (void)state;
    install(-1, false);
    WgImage *img = wg_image_new(4, 4, 1);
    assert_non_null(img);
    assert_int_equal(atomic_load(&n_allocs), 2); /* the struct and the pixels */
    assert_int_equal(img->refcount_, 1);
    assert_ptr_equal(wg_image_ref(img), img);
    assert_ptr_equal(wg_image_ref(img), img);
    assert_int_equal(img->refcount_, 3);
    wg_image_unref(img);
    wg_image_unref(img);
    assert_int_equal(img->refcount_, 1);
    assert_int_equal(atomic_load(&n_frees), 0);
    wg_image_unref(img); /* the last reference frees both blocks */
    assert_int_equal(atomic_load(&n_frees), 2);
    /* NULL-safe */
    assert_null(wg_image_ref(NULL));
    wg_image_unref(NULL);
    assert_int_equal(atomic_load(&n_frees), 2);
    restore_allocator(NULL);
}

/* ---- images over the caller's memory ----------------------------------------------------- */

static int released;

static void count_release(void *user)
{
    released += *(int *)user;
}

static void test_wrap(void **state)
{
    (void)state;
    enum { W = 7, H = 5, C = 4, STRIDE = W * C + 3 }; /* rows 124 bytes apart: not aligned */
    float *buf = malloc(sizeof(float) * STRIDE * H);
    assert_non_null(buf);
    for (int y = 0; y < H; y++)
        for (int i = 0; i < STRIDE; i++)
            buf[y * STRIDE + i] = i < W * C ? (float)(y * W * C + i) / 256.0f : NAN;
    int one = 1;
    released = 0;
    /* bad sizes and strides: NULL, and the release is not called */
    assert_null(wg_image_wrap(0, H, C, STRIDE, buf, count_release, &one));
    assert_null(wg_image_wrap(W, H, 3, STRIDE, buf, count_release, &one));
    assert_null(wg_image_wrap(W, H, C, W * C - 1, buf, count_release, &one));
    assert_null(wg_image_wrap(W, H, C, STRIDE, NULL, count_release, &one));
    assert_int_equal(released, 0);

    WgImage *img = wg_image_wrap(W, H, C, STRIDE, buf, count_release, &one);
    assert_non_null(img);
    assert_ptr_equal(img->data, buf); /* no copy */
    assert_true(wgt_px(img, 3, 2, 1) == (float)(2 * W * C + 3 * C + 1) / 256.0f);
    /* a request holds its own reference: the pixels stay lent until it lets go */
    WgGraph *g =
        wgt_load("<wetgraph version=\"1\" size=\"$src\">"
                 "<input name=\"src\" type=\"color\"/>"
                 "<node id=\"copy\" type=\"levels\"><in name=\"source\" from=\"$src\"/></node>"
                 "<output name=\"out\" from=\"copy\"/></wetgraph>");
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "src", img, &err), WG_OK);
    wg_image_unref(img);
    assert_int_equal(released, 0);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    const WgImage *out = wgt_output(res, "out");
    assert_ptr_not_equal(out->data, buf);
    for (int y = 0; y < H; y++)
        for (int i = 0; i < W * C; i++)
            if (wg_image_row(out, y)[i] != buf[y * STRIDE + i])
                fail_msg("sample %d of row %d: %g, the buffer holds %g", i, y,
                         wg_image_row(out, y)[i], buf[y * STRIDE + i]);
    wg_result_free(res);
    wg_engine_free(e);
    assert_int_equal(released, 0);
    wg_request_free(r); /* the last reference */
    assert_int_equal(released, 1);
    wg_graph_free(g);

    /* without a release the caller keeps the pixels; the struct alone is freed */
    img = wg_image_wrap(W, H, C, STRIDE, buf, NULL, NULL);
    assert_non_null(img);
    wg_image_unref(img);
    free(buf);
}

/* ---- resampling -------------------------------------------------------------------------- */

static void test_constant_stays_constant(void **state)
{
    (void)state;
    static const float values[] = {0.3f, 0.7f, 1.0f / 3.0f, 123.456f, -2.5e-3f, 0.1f};
    static const int sizes[][2] = {{13, 11}, {3, 2},   {1, 1}, {14, 10}, {7, 5}, {16, 3},
                                   {2, 9},   {100, 1}, {6, 4}, {21, 15}, {5, 7}};
    for (int c = 1; c <= 4; c += 3) {
        for (size_t v = 0; v < sizeof values / sizeof *values; v++) {
            WgImage *src = wg_image_new(7, 5, c);
            assert_non_null(src);
            for (int y = 0; y < 5; y++)
                for (int i = 0; i < 7 * c; i++) wg_image_row(src, y)[i] = values[v];
            for (size_t s = 0; s < sizeof sizes / sizeof *sizes; s++) {
                WgImage *d = wg_image_convert(src, sizes[s][0], sizes[s][1], c);
                assert_non_null(d);
                for (int y = 0; y < d->height; y++)
                    for (int i = 0; i < d->width * c; i++)
                        if (wg_image_row(d, y)[i] != values[v])
                            fail_msg("7x5x%d of %.9g -> %dx%d: %.9g at %d,%d", c, values[v],
                                     sizes[s][0], sizes[s][1], wg_image_row(d, y)[i], i / c, y);
                wg_image_unref(d);
            }
            wg_image_unref(src);
        }
    }
}

static void test_downsample(void **state)
{
    (void)state;
    /* exact 2x: per axis, the tent of half-width 2 centred between two source pixels weighs the
     * four nearest ones 1/8, 3/8, 3/8, 1/8 (wrapping at the edges) */
    WgImage *s = wgt_image_fn(8, 6, 1, pattern);
    WgImage *d = wg_image_convert(s, 4, 3, 1);
    assert_non_null(d);
    static const double w[4] = {1.0 / 8, 3.0 / 8, 3.0 / 8, 1.0 / 8};
    double sum_src = 0, sum_dst = 0;
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 4; x++) {
            double want = 0;
            for (int j = 0; j < 4; j++)
                for (int i = 0; i < 4; i++)
                    want += w[j] * w[i] * src_at(s, 2 * x - 1 + i, 2 * y - 1 + j, 0);
            assert_float_equal(wgt_px(d, x, y, 0), want, 1e-7);
            sum_dst += wgt_px(d, x, y, 0);
        }
    /* every source pixel weighs the same in total: the mean is kept */
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 8; x++) sum_src += wgt_px(s, x, y, 0);
    assert_float_equal(sum_dst / 12, sum_src / 48, 1e-7);
    wg_image_unref(d);
    wg_image_unref(s);

    /* other factors, integer and not, gray and colour, one axis or both */
    s = wgt_image_fn(12, 10, 4, pattern);
    check_resample(s, 4, 5, 1e-6);  /* 3x, 2x */
    check_resample(s, 6, 10, 1e-6); /* 2x, 1x */
    check_resample(s, 5, 4, 1e-6);  /* 2.4x, 2.5x */
    check_resample(s, 1, 1, 1e-6);  /* the mean */
    check_resample(s, 7, 3, 1e-6);
    wg_image_unref(s);

    /* shrinking to one pixel gives the mean */
    s = wgt_image_fn(6, 4, 1, pattern);
    d = wg_image_convert(s, 1, 1, 1);
    double mean = 0;
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 6; x++) mean += wgt_px(s, x, y, 0) / 24;
    assert_float_equal(wgt_px(d, 0, 0, 0), mean, 1e-7);
    wg_image_unref(d);
    wg_image_unref(s);
}

static void test_upsample_is_bilinear_with_wrap(void **state)
{
    (void)state;
    WgImage *s = wgt_image_fn(4, 3, 1, pattern);
    WgImage *d = wg_image_convert(s, 8, 6, 1);
    assert_non_null(d);
    /* known positions: output pixel centres fall a quarter pixel off the source centres */
    /* (0,0): x = -0.25 -> wraps to source column 3 with weight 0.25 */
    double p = 0.25 * 0.25 * src_at(s, 3, 2, 0) + 0.25 * 0.75 * src_at(s, 0, 2, 0) +
               0.75 * 0.25 * src_at(s, 3, 0, 0) + 0.75 * 0.75 * src_at(s, 0, 0, 0);
    assert_float_equal(wgt_px(d, 0, 0, 0), p, 1e-6);
    /* (7,5): x = 3.25, y = 2.25 -> wraps to column 0 and row 0 with weight 0.25 */
    p = 0.75 * 0.75 * src_at(s, 3, 2, 0) + 0.75 * 0.25 * src_at(s, 0, 2, 0) +
        0.25 * 0.75 * src_at(s, 3, 0, 0) + 0.25 * 0.25 * src_at(s, 0, 0, 0);
    assert_float_equal(wgt_px(d, 7, 5, 0), p, 1e-6);
    /* (3,2): x = 1.25, y = 0.75 */
    p = 0.25 * 0.75 * src_at(s, 1, 0, 0) + 0.25 * 0.25 * src_at(s, 2, 0, 0) +
        0.75 * 0.75 * src_at(s, 1, 1, 0) + 0.75 * 0.25 * src_at(s, 2, 1, 0);
    assert_float_equal(wgt_px(d, 3, 2, 0), p, 1e-6);
    wg_image_unref(d);
    /* every pixel, several factors */
    check_resample(s, 8, 6, 1e-6);
    check_resample(s, 10, 7, 1e-6);
    check_resample(s, 13, 3, 1e-6); /* one axis only */
    check_resample(s, 37, 29, 1e-6);
    wg_image_unref(s);

    s = wgt_image_fn(5, 4, 4, pattern);
    check_resample(s, 9, 11, 1e-6);
    check_resample(s, 11, 2, 1e-6); /* enlarge one axis, shrink the other */
    check_resample(s, 2, 11, 1e-6);
    wg_image_unref(s);

    /* a single pixel stays that value everywhere */
    float one[4] = {0.1f, 0.2f, 0.3f, 0.4f};
    s = wgt_image(1, 1, 4, one);
    d = wg_image_convert(s, 3, 5, 4);
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 3; x++)
            for (int k = 0; k < 4; k++) assert_true(wgt_px(d, x, y, k) == one[k]);
    wg_image_unref(d);
    wg_image_unref(s);
}

/* Enlarging a row by 2 or 4 gives, bit for bit, each output's two-tap sum in float as the
 * tap table defines it (the tent's weights in double, normalised, rounded to float; the sum
 * (a·f) + (b·g), kept only where the taps differ, and saturated), for gray and colour, at the
 * wrapping edges and inside; rows kept 1:1 are copied. Values include runs of equal samples and
 * magnitudes near FLT_MAX. */
static void test_enlarge_row_bits(void **state)
{
    (void)state;
    static const int widths[] = {8, 9, 13, 64, 101};
    for (size_t wi = 0; wi < sizeof widths / sizeof widths[0]; wi++)
        for (int factor = 2; factor <= 4; factor += 2)
            for (int c = 1; c <= 4; c += 3) {
                int w = widths[wi], dw = factor * w, h = 3;
                WgImage *src = wg_image_new(w, h, c);
                assert_non_null(src);
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++)
                        for (int k = 0; k < c; k++) {
                            float v = (float)pattern(x, y, k);
                            if (x % 5 == 2) v = (float)pattern(x - 1, y, k); /* a run */
                            if (y == 2 && x % 3 == 0) v = (x % 2 ? -1 : 1) * FLT_MAX * 0.9f;
                            wg_image_row(src, y)[x * c + k] = v;
                        }
                WgImage *dst = wg_image_convert(src, dw, h, c);
                assert_non_null(dst);
                double scale = (double)w / dw;
                for (int o = 0; o < dw; o++) {
                    double centre = (o + 0.5) * scale - 0.5;
                    int first = (int)floor(centre - 1) + 1;
                    double wt[4], sum = 0;
                    for (int t = 0; t < 4; t++) {
                        double dd = fabs(first + t - centre);
                        wt[t] = dd < 1 ? 1 - dd : 0;
                        sum += wt[t];
                    }
                    int idx[2], n = 0;
                    float fw[2];
                    for (int t = 0; t < 4 && n < 2; t++)
                        if (wt[t] != 0) {
                            idx[n] = ((first + t) % w + w) % w;
                            fw[n++] = (float)(wt[t] / sum);
                        }
                    assert_int_equal(n, 2);
                    for (int y = 0; y < h; y++)
                        for (int k = 0; k < c; k++) {
                            float f = wg_image_row(src, y)[idx[0] * c + k];
                            float g = wg_image_row(src, y)[idx[1] * c + k];
                            float v = fw[0] * f + fw[1] * g;
                            v = v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v;
                            float want = f != g ? v : f, got = wgt_px(dst, o, y, k);
                            if (memcmp(&want, &got, sizeof got))
                                fail_msg("%d -> %d, %d channels: output %d row %d channel %d is "
                                         "%.9g, expected %.9g",
                                         w, dw, c, o, y, k, got, want);
                        }
                }
                wg_image_unref(dst);
                wg_image_unref(src);
            }
}

/* wg_image_resample_into: the float64 reference within 1e-6 over sizes that enlarge, shrink
 * and mix, gray and colour, and the same bits as wg_image_convert with no threads and with 2,
 * 3 and 4 workers (each output value sums its taps in one order, whichever thread computes
 * it). */
static void test_resample_into_threads(void **state)
{
    (void)state;
    static const int sizes[][4] = {{37, 23, 64, 64},  {64, 64, 37, 23}, {300, 17, 41, 70},
                                   {5, 200, 128, 9},  {1, 1, 19, 7},    {257, 129, 256, 128},
                                   {1024, 3, 100, 3}, {33, 65, 66, 130}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        for (int c = 1; c <= 4; c += 3) {
            WgImage *src = wg_image_new(sizes[i][0], sizes[i][1], c);
            assert_non_null(src);
            for (int y = 0; y < src->height; y++)
                for (int x = 0; x < src->width; x++)
                    for (int k = 0; k < c; k++)
                        wg_image_row(src, y)[x * c + k] = (float)pattern(x, y, k);
            int w = sizes[i][2], h = sizes[i][3];
            check_resample(src, w, h, 1e-6);
            WgImage *want = wg_image_convert(src, w, h, c);
            assert_non_null(want);
            for (int threads = 0; threads <= 4; threads++) {
                if (threads == 1) continue;
                WgNodeContext ctx = {0};
                ctx.pool_ = threads ? wg__pool_new(threads) : NULL;
                WgImage *got = wg_image_new(w, h, c);
                assert_non_null(got);
                assert_int_equal(wg_image_resample_into(threads ? &ctx : NULL, src, got), WG_OK);
                wgt_assert_identical(got, want);
                wg_image_unref(got);
                if (ctx.pool_) wg__pool_free(ctx.pool_);
            }
            wg_image_unref(want);
            wg_image_unref(src);
        }
    }
    WgImage *a = wg_image_new(4, 4, 1), *b = wg_image_new(2, 2, 4);
    assert_int_equal(wg_image_resample_into(NULL, a, b), WG_ERR_TYPE);
    wg_image_unref(a);
    wg_image_unref(b);
}

/* An infinite sample reaches only the outputs whose tent covers it (saturated to FLT_MAX there):
 * enlarging 8 -> 16 is bilinear, so it touches the four outputs around it, and every other
 * output is the finite
 * interpolation of its two neighbours (a tap of zero weight must not turn it into NaN). */
static void test_infinity_stays_local(void **state)
{
    (void)state;
    WgImage *src = wg_image_new(8, 1, 1);
    for (int x = 0; x < 8; x++) wg_image_row(src, 0)[x] = (float)x;
    wg_image_row(src, 0)[4] = INFINITY;
    WgImage *d = wg_image_convert(src, 16, 1, 1);
    assert_non_null(d);
    for (int x = 0; x < 16; x++) {
        float v = wgt_px(d, x, 0, 0);
        bool covered = x >= 7 && x <= 10; /* centres 3.25 .. 4.75 */
        if (covered ? v != FLT_MAX : !isfinite(v))
            fail_msg("output %d is %g (%s)", x, v,
                     covered ? "expected FLT_MAX" : "expected finite");
    }
    /* 16 -> 8 with the infinity at 6 (taps of half-width 2): outputs 2 and 3 cover it */
    WgImage *s2 = wg_image_new(16, 1, 1);
    for (int x = 0; x < 16; x++) wg_image_row(s2, 0)[x] = 1;
    wg_image_row(s2, 0)[6] = INFINITY;
    WgImage *d2 = wg_image_convert(s2, 8, 1, 1);
    for (int x = 0; x < 8; x++) {
        float v = wgt_px(d2, x, 0, 0);
        if (x == 2 || x == 3 ? v != FLT_MAX : v != 1.0f) fail_msg("output %d is %g", x, v);
    }
    wg_image_unref(d2);
    wg_image_unref(s2);
    wg_image_unref(d);
    wg_image_unref(src);
}

static void test_same_size_is_a_copy(void **state)
{
    (void)state;
    WgImage *s = wgt_image_fn(6, 3, 4, pattern);
    WgImage *d = wg_image_convert(s, 6, 3, 4);
    assert_non_null(d);
    assert_ptr_not_equal(d, s);
    assert_ptr_not_equal(d->data, s->data);
    assert_int_equal(d->refcount_, 1);
    assert_int_equal(s->refcount_, 1);
    wgt_assert_identical(d, s);
    float before = wgt_px(s, 2, 1, 3);
    wg_image_row(d, 1)[2 * 4 + 3] = 42.0f;
    assert_true(wgt_px(s, 2, 1, 3) == before);
    wg_image_unref(d);
    wg_image_unref(s);
}

static void test_channel_conversion(void **state)
{
    (void)state;
    /* gray -> colour: R = G = B = value, alpha 1 */
    WgImage *g = wgt_image_fn(5, 2, 1, pattern);
    WgImage *c = wg_image_convert(g, 5, 2, 4);
    assert_non_null(c);
    assert_int_equal(c->channels, 4);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 5; x++) {
            for (int k = 0; k < 3; k++) assert_true(wgt_px(c, x, y, k) == wgt_px(g, x, y, 0));
            assert_true(wgt_px(c, x, y, 3) == 1.0f);
        }
    /* ... and back: exact, since R = G = B */
    WgImage *back = wg_image_convert(c, 5, 2, 1);
    wgt_assert_identical(back, g);
    wg_image_unref(back);
    wg_image_unref(c);
    wg_image_unref(g);

    /* colour -> gray: Rec.709 luminance, alpha ignored */
    float px[] = {0.2f, 0.5f, 0.9f, 0.3f, 1.0f, 0.0f, 0.0f, 1.0f, 0.0f, 1.0f, 0.0f, 0.0f,
                  0.0f, 0.0f, 1.0f, 0.5f, 0.1f, 0.1f, 0.1f, 0.0f, 0.7f, 0.7f, 0.7f, 0.25f};
    c = wgt_image(3, 2, 4, px);
    g = wg_image_convert(c, 3, 2, 1);
    assert_non_null(g);
    assert_int_equal(g->channels, 1);
    for (int i = 0; i < 6; i++) {
        const float *p = px + 4 * i;
        double want = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        assert_float_equal(wgt_px(g, i % 3, i / 3, 0), want, 1e-7);
    }
    assert_true(wgt_px(g, 1, 1, 0) == 0.1f); /* exactly R when R = G = B */
    assert_true(wgt_px(g, 2, 1, 0) == 0.7f);
    wg_image_unref(g);

    /* resampling and conversion together */
    g = wg_image_convert(c, 6, 4, 1);
    assert_non_null(g);
    assert_int_equal(g->width, 6);
    WgImage *sized = wg_image_convert(c, 6, 4, 4);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 6; x++) {
            const float *p = wg_image_row(sized, y) + 4 * x;
            assert_float_equal(wgt_px(g, x, y, 0), 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2],
                               1e-6);
        }
    wg_image_unref(sized);
    wg_image_unref(g);
    wg_image_unref(c);
}

static void test_convert_rejects_bad_targets(void **state)
{
    (void)state;
    WgImage *s = wgt_image_fn(4, 4, 1, pattern);
    assert_null(wg_image_convert(NULL, 4, 4, 1));
    assert_null(wg_image_convert(s, 0, 4, 1));
    assert_null(wg_image_convert(s, 4, 0, 1));
    assert_null(wg_image_convert(s, -4, 4, 1));
    assert_null(wg_image_convert(s, 4, 16385, 1));
    assert_null(wg_image_convert(s, 4, 4, 3));
    assert_null(wg_image_convert(s, 4, 4, 2));
    assert_null(wg_image_convert(s, 8, 8, 0));
    assert_int_equal(s->refcount_, 1);
    wg_image_unref(s);
}

/* ---- the allocation hook ----------------------------------------------------------------- */

static void test_failing_allocator(void **state)
{
    (void)state;
    install(-1, true);
    assert_null(wg_image_new(4, 4, 1));
    assert_null(wg_image_new_zero(4, 4, 4));
    assert_null(wg_malloc(16));
    assert_null(wg_calloc(4, 4));
    assert_null(wg_strdup("x"));
    assert_true(atomic_load(&n_allocs) >= 5);
    assert_int_equal(atomic_load(&n_frees), 0);
    restore_allocator(NULL);

    /* the struct is allocated but the pixels are not: nothing leaks */
    install(1, false);
    assert_null(wg_image_new(4, 4, 1));
    assert_int_equal(atomic_load(&n_allocs), 2);
    assert_int_equal(atomic_load(&n_frees), 1);
    restore_allocator(NULL);

    /* conversion under failure */
    WgImage *s = wgt_image_fn(4, 4, 4, pattern);
    bool converted = false;
    for (long k = 0; k < 64 && !converted; k++) {
        install(k, false);
        WgImage *d = wg_image_convert(s, 7, 3, 1);
        long allocs = atomic_load(&n_allocs), frees = atomic_load(&n_frees);
        restore_allocator(NULL);
        if (d) {
            assert_true(allocs <= k);
            wg_image_unref(d);
            converted = true;
        } else {
            /* everything that was allocated before the failure was released */
            assert_int_equal(frees, k);
        }
    }
    assert_true(converted);
    wg_image_unref(s);

    /* the default allocator is back */
    WgImage *img = wg_image_new(4, 4, 1);
    assert_non_null(img);
    wg_image_unref(img);
}

static const char *const render_xml =
    "<wetgraph version=\"1\" size=\"16\">\n"
    "  <param name=\"k\" type=\"float\" default=\"0.25\"/>\n"
    "  <input name=\"src\" type=\"gray\" default=\"0.5\"/>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=k\"/>\n"
    "  <node id=\"c\" type=\"uniform\" kind=\"color\" color=\"0.5 0.25 0.125 1\" size=\"x2\"/>\n"
    "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"u\"/></node>\n"
    "  <node id=\"b\" type=\"blend\" mode=\"multiply\">\n"
    "    <in name=\"foreground\" from=\"c\"/>\n"
    "    <in name=\"background\" from=\"$src\"/>\n"
    "    <in name=\"mask\" from=\"i\"/>\n"
    "  </node>\n"
    "  <node id=\"s\" type=\"blur\" sigma=\"1.5\"><in name=\"source\" from=\"b\"/></node>\n"
    "  <output name=\"o\" from=\"s\"/>\n"
    "  <output name=\"i\" from=\"i\"/>\n"
    "</wetgraph>\n";

static void test_render_fails_cleanly_without_memory(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(render_xml);
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgError err = {0};
    WgEngineOptions opt = {2, 0, NULL};
    WgEngine *e = NULL;
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);

    /* the reference result */
    WgResult *ref = NULL;
    assert_int_equal(wg_render(e, r, &ref, &err), WG_OK);
    wg_engine_clear_cache(e);

    /* nothing can be allocated */
    install(-1, true);
    WgResult *res = NULL;
    memset(&err, 0, sizeof err);
    int rc = wg_render(e, r, &res, &err);
    restore_allocator(NULL);
    assert_int_equal(rc, WG_ERR_NOMEM);
    assert_null(res);
    assert_int_equal(err.code, WG_ERR_NOMEM);

    /* the k-th and all later allocations fail, for every k until the render needs no more:
     * each render fails with WG_ERR_NOMEM or (when only best-effort allocations such as cache
     * entries failed) succeeds with the right pixels */
    bool all_allocated = false;
    int failures = 0;
    for (long k = 0; k < 100000 && !all_allocated; k++) {
        wg_engine_clear_cache(e);
        install(k, false);
        res = NULL;
        memset(&err, 0, sizeof err);
        rc = wg_render(e, r, &res, &err);
        long allocs = atomic_load(&n_allocs);
        restore_allocator(NULL);
        all_allocated = allocs <= k;
        if (rc == WG_OK) {
            assert_non_null(res);
            wgt_assert_identical(wgt_output(res, "o"), wgt_output(ref, "o"));
            wgt_assert_identical(wgt_output(res, "i"), wgt_output(ref, "i"));
            wg_result_free(res);
            continue;
        }
        failures++;
        assert_false(all_allocated);
        if (rc != WG_ERR_NOMEM || err.code != WG_ERR_NOMEM) {
            char buf[2048];
            wg_error_format(&err, buf, sizeof buf);
            fail_msg("allocation %ld failing: status %d, error code %d (%s)", k, rc, err.code, buf);
        }
        assert_null(res);
    }
    assert_true(all_allocated);
    assert_true(failures > 20);

    /* and the engine still works with the default allocator */
    wg_engine_clear_cache(e);
    assert_int_equal(wg_render(e, r, &res, &err), WG_OK);
    wgt_assert_identical(wgt_output(res, "o"), wgt_output(ref, "o"));
    wg_result_free(res);
    wg_result_free(ref);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_new_limits),
        cmocka_unit_test_teardown(test_refcount, restore_allocator),
        cmocka_unit_test(test_wrap),
        cmocka_unit_test(test_constant_stays_constant),
        cmocka_unit_test(test_downsample),
        cmocka_unit_test(test_upsample_is_bilinear_with_wrap),
        cmocka_unit_test(test_resample_into_threads),
        cmocka_unit_test(test_enlarge_row_bits),
        cmocka_unit_test(test_infinity_stays_local),
        cmocka_unit_test(test_same_size_is_a_copy),
        cmocka_unit_test(test_channel_conversion),
        cmocka_unit_test(test_convert_rejects_bad_targets),
        cmocka_unit_test_teardown(test_failing_allocator, restore_allocator),
        cmocka_unit_test_teardown(test_render_fails_cleanly_without_memory, restore_allocator),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
