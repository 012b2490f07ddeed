/* SPDX-License-Identifier: MIT */
/* `transform`: the identity copies exactly, whole-pixel offsets are exact cyclic shifts (also
 * on a side that 1/side is not exact in binary for), 90°/180°/270° turns of square images (odd
 * and even sides) and mirrors are exact pixel permutations, scale 2 of a tileable picture is
 * two exact copies matching the closed form of a resampled sine, the matrix form equals
 * rotation and scale bit for bit, the node matches a float64 reference of the documented
 * mapping on random inputs (bilinear and bicubic, within 2^-23), constants stay constant,
 * extreme parameters stay finite, any thread count gives the same bits, thin images, defaults
 * and parameter errors. */
#include "warptest.h"

typedef struct {
    double ox, oy, rot, sx, sy;
    int matrix;
    double m[4];
} Tf;

static WgImage *transform(const WgImage *src, const Tf *t, const char *filter, int threads)
{
    char attrs[512];
    snprintf(attrs, sizeof attrs,
             "offset_x=\"%.9g\" offset_y=\"%.9g\" rotation=\"%.9g\" scale_x=\"%.9g\" "
             "scale_y=\"%.9g\" matrix=\"%s\" m00=\"%.9g\" m01=\"%.9g\" m10=\"%.9g\" m11=\"%.9g\" "
             "filter=\"%s\"",
             t->ox, t->oy, t->rot, t->sx, t->sy, t->matrix ? "true" : "false", t->m[0], t->m[1],
             t->m[2], t->m[3], filter);
    return wt_run("transform", attrs, src, NULL, threads);
}

static const char *const filters[] = {"bilinear", "bicubic"};
#define TOL 1.2e-7 /* values below 2 round to float within 2^-24 · 2 */
#define ID                                                                                         \
    {                                                                                              \
        0, 0, 0, 1, 1, 0,                                                                          \
        {                                                                                          \
            1, 0, 0, 1                                                                             \
        }                                                                                          \
    }

/* out(x, y) = src(map(x, y)) for every pixel and channel, bit for bit. */
static void assert_permutation(const WgImage *out, const WgImage *src,
                               void (*map)(int w, int h, int x, int y, int *sx, int *sy),
                               const char *what)
{
    wgt_assert_same_shape(out, src);
    for (int y = 0; y < src->height; y++)
        for (int x = 0; x < src->width; x++) {
            int sx, sy;
            map(src->width, src->height, x, y, &sx, &sy);
            for (int k = 0; k < src->channels; k++)
                if (wgt_px(out, x, y, k) != wgt_px(src, sx, sy, k))
                    fail_msg("%s %dx%d (%d,%d,%d): %.9g, expected source (%d,%d): %.9g", what,
                             src->width, src->height, x, y, k, wgt_px(out, x, y, k), sx, sy,
                             wgt_px(src, sx, sy, k));
        }
}

static void turn90(int w, int h, int x, int y, int *sx, int *sy)
{
    (void)h;
    *sx = w - 1 - y, *sy = x; /* the right edge shows what was at the bottom: counter-clockwise */
}
static void turn180(int w, int h, int x, int y, int *sx, int *sy)
{
    *sx = w - 1 - x, *sy = h - 1 - y;
}
static void turn270(int w, int h, int x, int y, int *sx, int *sy)
{
    (void)h;
    *sx = y, *sy = w - 1 - x;
}
static void mirror_x(int w, int h, int x, int y, int *sx, int *sy)
{
    (void)h;
    *sx = w - 1 - x, *sy = y;
}

static void test_identity_copies(void **state)
{
    (void)state;
    static const Tf ids[] = {ID,
                             {0, 0, 360, 1, 1, 0, {0}},
                             {0, 0, -720, 1, 1, 0, {0}},
                             {1, -2, 0, 1, 1, 0, {0}},
                             {0, 0, 0, 1, 1, 1, {1, 0, 0, 1}}};
    for (int c = 1; c <= 4; c += 3) {
        WgImage *src = wt_random(23, 14, c, 3);
        for (int i = 0; i < 5; i++)
            for (int f = 0; f < 2; f++) {
                WgImage *out = transform(src, &ids[i], filters[f], 2);
                assert_int_equal(out->channels, c);
                wgt_assert_identical(out, src);
                wg_image_unref(out);
            }
        WgImage *d = wt_run("transform", "", src, NULL, 1);
        wgt_assert_identical(d, src);
        wg_image_unref(d);
        wg_image_unref(src);
    }
}

static void test_whole_pixel_offsets(void **state)
{
    (void)state;
    static const struct {
        int w, h;
        double ox, oy;
        int dx, dy; /* expected move, rows down */
    } cases[] = {
        {64, 40, 3.0 / 64, 0, 3, 0},          {64, 40, 0, 5.0 / 40, 0, -5},
        {64, 40, -0.5, -0.25, -32, 10},       {64, 40, 1 + 3.0 / 64, -7.0 / 40, 3, 7},
        {37, 11, 5.0 / 37, 2.0 / 11, 5, -2},  {37, 11, -12.0 / 37, 100 + 3.0 / 11, -12, -3},
        {3, 1000, 1.0 / 3, 1.0 / 1000, 1, -1}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        for (int c = 1; c <= 4; c += 3) {
            WgImage *src = wt_random(cases[i].w, cases[i].h, c, 5);
            WgImage *want = wt_shift(src, cases[i].dx, cases[i].dy);
            Tf t = ID;
            t.ox = cases[i].ox, t.oy = cases[i].oy;
            for (int f = 0; f < 2; f++) {
                WgImage *out = transform(src, &t, filters[f], 2);
                wgt_assert_identical(out, want);
                wg_image_unref(out);
            }
            wg_image_unref(want);
            wg_image_unref(src);
        }
}

static void test_right_angles_are_permutations(void **state)
{
    (void)state;
    static const int sides[] = {16, 15, 1, 2};
    for (int s = 0; s < 4; s++)
        for (int c = 1; c <= 4; c += 3) {
            int n = sides[s];
            WgImage *src = wt_random(n, n, c, 7 + s);
            for (int f = 0; f < 2; f++) {
                Tf t = ID;
                t.rot = 90;
                WgImage *a = transform(src, &t, filters[f], 2);
                t.rot = 180;
                WgImage *b = transform(src, &t, filters[f], 2);
                t.rot = -90;
                WgImage *d = transform(src, &t, filters[f], 2);
                t.rot = 810; /* 2·360 + 90 */
                WgImage *e = transform(src, &t, filters[f], 2);
                Tf m = {0, 0, 0, -1, 1, 0, {0}};
                WgImage *g = transform(src, &m, filters[f], 2);
                Tf mat = {0, 0, 0, 1, 1, 1, {0, 1, -1, 0}}; /* = rotation 90 */
                WgImage *h = transform(src, &mat, filters[f], 2);
                assert_permutation(a, src, turn90, "90°");
                assert_permutation(b, src, turn180, "180°");
                assert_permutation(d, src, turn270, "-90°");
                assert_permutation(e, src, turn90, "810°");
                assert_permutation(g, src, mirror_x, "scale_x -1");
                assert_permutation(h, src, turn90, "matrix (0 1; -1 0)");
                wg_image_unref(h);
                wg_image_unref(g);
                wg_image_unref(e);
                wg_image_unref(d);
                wg_image_unref(b);
                wg_image_unref(a);
            }
            wg_image_unref(src);
        }
}

/* A sine of k periods across the width, sampled at pixel centres: S(j) = sin(2πk(j+½)/W + φ).
 * Scale 2 reads half-way between pixels 2x − W/2 and 2x − W/2 + 1, whose mean is exactly
 * cos(πk/W) · sin(2π·2k(x+½)/W − πk + φ): twice the frequency, slightly damped. */
static int sine_w = 64, sine_k = 3;
static double sine_fn(int x, int y, int k)
{
    return sin(2 * M_PI * sine_k * (x + 0.5) / sine_w + 0.4 + k) * (1 + 0.001 * y);
}

static void test_scale_two_tiles(void **state)
{
    (void)state;
    int w = 64, h = 48;
    sine_w = w, sine_k = 3;
    WgImage *src = wgt_image_fn(w, h, 4, sine_fn);
    Tf t = ID;
    t.sx = 2, t.sy = 1;
    WgImage *out = transform(src, &t, "bilinear", 2);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < 4; k++) {
                double want = cos(M_PI * sine_k / w) *
                              sin(2 * M_PI * 2 * sine_k * (x + 0.5) / w - M_PI * sine_k + 0.4 + k) *
                              (1 + 0.001 * y);
                if (!(fabs(wgt_px(out, x, y, k) - want) <= 3e-7))
                    fail_msg("(%d,%d,%d): %.9g, expected %.9g", x, y, k, wgt_px(out, x, y, k),
                             want);
            }
    wg_image_unref(out);
    wg_image_unref(src);
    /* any picture: scale (2, 3) is exactly 2 × 3 copies, and the matrix form gives the same */
    for (int f = 0; f < 2; f++) {
        WgImage *r = wt_random(w, h, 4, 99);
        Tf s = ID, m = {0, 0, 0, 1, 1, 1, {2, 0, 0, 3}};
        s.sx = 2, s.sy = 3;
        WgImage *a = transform(r, &s, filters[f], 2);
        WgImage *b = transform(r, &m, filters[f], 2);
        wgt_assert_identical(a, b);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                for (int k = 0; k < 4; k++) {
                    float v = wgt_px(a, x, y, k);
                    if (v != wgt_px(a, (x + w / 2) % w, y, k) ||
                        v != wgt_px(a, x, (y + h / 3) % h, k))
                        fail_msg("%s: not two by three copies at (%d,%d)", filters[f], x, y);
                }
        wg_image_unref(b);
        wg_image_unref(a);
        wg_image_unref(r);
    }
}

/* An offset in pixels, snapped to a whole pixel within the float parameter's precision (the
 * documented rule). */
static double snapped(double offset, int side)
{
    float f = (float)offset;
    double px = (double)f * side, ulp = nextafterf(fabsf(f), INFINITY) - fabsf(f);
    return fabs(px - round(px)) <= ulp * side ? round(px) : px;
}

/* The documented mapping in texture units, written out in float64. */
static void reference_position(const Tf *t, int w, int h, int x, int y, double *px, double *py)
{
    double a[4];
    if (t->matrix) {
        for (int i = 0; i < 4; i++) a[i] = (float)t->m[i];
    } else {
        double th = (float)t->rot * M_PI / 180, sx = (float)t->sx, sy = (float)t->sy;
        a[0] = sx * cos(th), a[1] = sx * sin(th), a[2] = -sy * sin(th), a[3] = sy * cos(th);
    }
    double u = (x + 0.5) / w - 0.5 - snapped(t->ox, w) / w;
    double v = -((y + 0.5) / h - 0.5) - snapped(t->oy, h) / h; /* y up */
    double su = 0.5 + a[0] * u + a[1] * v, sv = 0.5 - (a[2] * u + a[3] * v);
    *px = su * w - 0.5;
    *py = sv * h - 0.5;
}

static void test_against_float64_reference(void **state)
{
    (void)state;
    static const int shapes[][2] = {{24, 10}, {13, 17}, {16, 16}, {1, 9}, {9, 1}, {1, 1}, {2, 3}};
    static const Tf cases[] = {
        {0.13, -0.27, 30, 1, 1, 0, {0}},
        {0, 0, -123.4, 1.7, -0.6, 0, {0}},
        {0.5, 2.25, 0, 1, 1, 1, {0.3, -1.2, 2.5, 0.8}},
        {0.01, 0.02, 45, 3, 3, 0, {0}},
        {-3.3, 0.7, 100000.3, 0.01, 0.2, 0, {0}},
        {0.2, 0.1, 10, 250, -90, 0, {0}},
    };
    for (int s = 0; s < 7; s++)
        for (int c = 1; c <= 4; c += 3) {
            int w = shapes[s][0], h = shapes[s][1];
            WgImage *src = wt_random(w, h, c, 31 + s);
            for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
                for (int f = 0; f < 2; f++) {
                    WgImage *out = transform(src, &cases[i], filters[f], 2);
                    wgt_assert_same_shape(out, src);
                    for (int y = 0; y < h; y++)
                        for (int x = 0; x < w; x++) {
                            double px, py;
                            reference_position(&cases[i], w, h, x, y, &px, &py);
                            for (int k = 0; k < c; k++) {
                                double want = wt_sample(src, px, py, f, k);
                                double got = wgt_px(out, x, y, k);
                                /* position rounding: ~1e-16 · |position| pixels, at most a
                                 * unit step per pixel of random input */
                                double tol = TOL + 1e-15 * (fabs(px) + fabs(py));
                                if (!(fabs(got - want) <= tol))
                                    fail_msg("case %zu %dx%d %s (%d,%d,%d): %.10g, expected %.10g",
                                             i, w, h, filters[f], x, y, k, got, want);
                            }
                        }
                    wg_image_unref(out);
                }
            wg_image_unref(src);
        }
}

static void test_constant_source_stays(void **state)
{
    (void)state;
    static const float values[] = {0.3f, -2.5f, 3e38f};
    Tf t = {0.123, 0.456, 33, 2.7, -0.4, 0, {0}};
    for (int v = 0; v < 3; v++)
        for (int f = 0; f < 2; f++) {
            WgImage *src = ht_const(21, 13, values[v]);
            WgImage *out = transform(src, &t, filters[f], 2);
            wgt_assert_identical(out, src);
            wg_image_unref(out);
            wg_image_unref(src);
        }
}

static void test_extremes_finite(void **state)
{
    (void)state;
    WgImage *src = wgt_image(64, 32, 4, NULL);
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 64 * 4; x++)
            wg_image_row(src, y)[x] = (x / 16 + y / 4) % 2 ? 3.4e38f : -3.4e38f;
    static const Tf cases[] = {{1000.1, -999.9, 33, 4096, -4096, 0, {0}},
                               {0.3, 0.3, 1e6, 0, 0, 0, {0}},
                               {0, 0, 0, 1, 1, 1, {4096, -4096, 4096, 4096}},
                               {0.1, 0.2, 7, 0.37, 1.3, 0, {0}}};
    for (int i = 0; i < 4; i++)
        for (int f = 0; f < 2; f++) {
            WgImage *out = transform(src, &cases[i], filters[f], 2);
            wt_assert_finite(out);
            wg_image_unref(out);
        }
    wg_image_unref(src);
}

static void test_thread_invariance(void **state)
{
    (void)state;
    WgImage *src = wt_random(300, 150, 4, 1);
    Tf t = {0.1, 0.3, 21, 1.3, 0.8, 0, {0}};
    static const int threads[] = {2, 3, 8};
    for (int f = 0; f < 2; f++) {
        WgImage *a = transform(src, &t, filters[f], 1);
        for (int i = 0; i < 3; i++) {
            WgImage *b = transform(src, &t, filters[f], threads[i]);
            wgt_assert_identical(a, b);
            wg_image_unref(b);
        }
        wg_image_unref(a);
    }
    wg_image_unref(src);
}

static void test_errors(void **state)
{
    (void)state;
    WgImage *c = wgt_image(4, 4, 4, NULL);
    const char *names[] = {"source"};
    const WgImage *in[] = {c};
    WgError err;
    assert_int_equal(wgt_node_error("transform", "scale_x=\"5000\"", 4, 4, 1, names, in, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "scale_x"));
    assert_int_not_equal(
        wgt_node_error("transform", "filter=\"nearest\"", 4, 4, 1, names, in, &err), WG_OK);
    assert_non_null(strstr(err.message, "filter"));
    assert_int_not_equal(wgt_node_error("transform", "matrix=\"maybe\"", 4, 4, 1, names, in, &err),
                         WG_OK);
    assert_int_not_equal(wgt_node_error("transform", "", 4, 4, 0, names, in, &err), WG_OK);
    wg_image_unref(c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_identity_copies),
        cmocka_unit_test(test_whole_pixel_offsets),
        cmocka_unit_test(test_right_angles_are_permutations),
        cmocka_unit_test(test_scale_two_tiles),
        cmocka_unit_test(test_against_float64_reference),
        cmocka_unit_test(test_constant_source_stays),
        cmocka_unit_test(test_extremes_finite),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
