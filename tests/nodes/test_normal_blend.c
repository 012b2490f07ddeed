/* SPDX-License-Identifier: MIT */
/* `normal_blend` and `normal_normalize`. RNM is checked against an independent float64 form of
 * what it means: the detail rotated by the rotation that takes +z onto the base (Rodrigues'
 * formula about the axis z × b); whiteout against (b.xy + d.xy, b.z·d.z) normalised; opacity
 * against the detail mixed towards flat. Flat detail or zero opacity give the base (within
 * 1e-6), flat base with RNM gives the detail; normalize gives unit vectors, (0,0,1) for a zero
 * vector, keeps alpha and already-unit inputs. Also tiling, thread-count invariance, 1×N, N×1,
 * 1×1 images, extreme and non-finite inputs (finite, unit output) and parameter errors. */
#include "heighttest.h"

static WgImage *blend(const WgImage *base, const WgImage *detail, const char *method,
                      double opacity, int threads)
{
    char a[96];
    snprintf(a, sizeof a, "method=\"%s\" opacity=\"%.9g\"", method, opacity);
    const char *names[] = {"base", "detail"};
    const WgImage *imgs[] = {base, detail};
    return wgt_node("normal_blend", a, base->width, base->height, 2, names, imgs, 0, threads);
}

static WgImage *normalize(const WgImage *src, int threads)
{
    const char *names[] = {"normal"};
    const WgImage *imgs[] = {src};
    return wgt_node("normal_normalize", "", src->width, src->height, 1, names, imgs, 0, threads);
}

static void unit3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int k = 0; k < 3; k++) v[k] /= l;
}

/* Random unit normals in the upper hemisphere (z ≥ 0.15), encoded, alpha 0.25..1. `salt`
 * picks the set. */
static uint32_t salt;
static double normals_fn(int x, int y, int k)
{
    double v[3];
    for (int i = 0; i < 3; i++)
        v[i] = (wg_hash3((uint32_t)x, (uint32_t)y, salt * 8 + (uint32_t)i) & 0xffff) / 32767.5 - 1;
    v[2] = 0.15 + fabs(v[2]);
    unit3(v);
    if (k == 3) return 0.25 + (wg_hash3((uint32_t)x, (uint32_t)y, salt * 8 + 5) & 0xff) / 340.0;
    return v[k] * 0.5 + 0.5;
}
static WgImage *normals(int w, int h, uint32_t s)
{
    salt = s;
    return wgt_image_fn(w, h, 4, normals_fn);
}

static void decode_px(const WgImage *img, int x, int y, double v[3])
{
    for (int k = 0; k < 3; k++) v[k] = 2.0 * wgt_px(img, x, y, k) - 1;
}

/* Rotate d by the rotation taking (0,0,1) to unit b (Rodrigues). */
static void rotate_to(const double b[3], const double d[3], double r[3])
{
    double s = sqrt(b[0] * b[0] + b[1] * b[1]), c = b[2];
    if (s == 0) {
        for (int i = 0; i < 3; i++) r[i] = d[i];
        return;
    }
    double k[3] = {-b[1] / s, b[0] / s, 0}; /* z × b, normalised */
    double kxd[3] = {k[1] * d[2] - k[2] * d[1], k[2] * d[0] - k[0] * d[2],
                     k[0] * d[1] - k[1] * d[0]};
    double kd = k[0] * d[0] + k[1] * d[1] + k[2] * d[2];
    for (int i = 0; i < 3; i++) r[i] = d[i] * c + kxd[i] * s + k[i] * kd * (1 - c);
}

static void reference(const double b0[3], const double d0[3], int whiteout, double opacity,
                      double r[3])
{
    double b[3] = {b0[0], b0[1], b0[2]}, d[3] = {d0[0], d0[1], d0[2]};
    unit3(b);
    unit3(d);
    double m[3] = {opacity * d[0], opacity * d[1], 1 - opacity + opacity * d[2]};
    unit3(m);
    if (whiteout) {
        r[0] = b[0] + m[0], r[1] = b[1] + m[1], r[2] = b[2] * m[2];
    } else {
        rotate_to(b, m, r);
    }
    unit3(r);
}

static void check_blend(const WgImage *base, const WgImage *detail, int whiteout, double opacity,
                        double tol)
{
    WgImage *out = blend(base, detail, whiteout ? "whiteout" : "rnm", opacity, 2);
    for (int y = 0; y < base->height; y++)
        for (int x = 0; x < base->width; x++) {
            double b[3], d[3], r[3];
            decode_px(base, x, y, b);
            decode_px(detail, x, y, d);
            reference(b, d, whiteout, opacity, r);
            for (int k = 0; k < 3; k++) {
                double got = wgt_px(out, x, y, k), want = r[k] * 0.5 + 0.5;
                if (!(fabs(got - want) <= tol))
                    fail_msg("%s opacity %g (%d,%d,%d): %.10g, expected %.10g",
                             whiteout ? "whiteout" : "rnm", opacity, x, y, k, got, want);
            }
            assert_true(wgt_px(out, x, y, 3) == wgt_px(base, x, y, 3));
        }
    wg_image_unref(out);
}

static void test_against_float64_reference(void **state)
{
    (void)state;
    static const int shapes[][2] = {{24, 10}, {13, 17}, {1, 9}, {9, 1}, {1, 1}};
    static const double opacities[] = {1, 0.5, 0.1, 0};
    for (int s = 0; s < 5; s++) {
        WgImage *b = normals(shapes[s][0], shapes[s][1], 1);
        WgImage *d = normals(shapes[s][0], shapes[s][1], 2);
        for (int o = 0; o < 4; o++)
            for (int m = 0; m < 2; m++) check_blend(b, d, m, opacities[o], 1e-7);
        wg_image_unref(d);
        wg_image_unref(b);
    }
}

static double flat_fn(int x, int y, int k)
{
    (void)x, (void)y;
    return k == 2 || k == 3 ? 1 : 0.5;
}

static void test_flat_detail_and_zero_opacity_keep_base(void **state)
{
    (void)state;
    WgImage *b = normals(31, 19, 3), *d = normals(31, 19, 4);
    WgImage *flat = wgt_image_fn(31, 19, 4, flat_fn);
    for (int m = 0; m < 2; m++) {
        const char *method = m ? "whiteout" : "rnm";
        WgImage *outs[] = {blend(b, flat, method, 1, 2), blend(b, d, method, 0, 2),
                           blend(b, flat, method, 0.4, 2)};
        for (int o = 0; o < 3; o++) {
            wgt_assert_near(outs[o], b, 1e-6);
            wg_image_unref(outs[o]);
        }
    }
    /* a flat base takes the detail as it is (the rotation is the identity) */
    WgImage *outs[] = {blend(flat, d, "rnm", 1, 2), blend(flat, d, "whiteout", 1, 2)};
    for (int o = 0; o < 2; o++) {
        for (int y = 0; y < 19; y++)
            for (int x = 0; x < 31; x++)
                for (int k = 0; k < 3; k++)
                    assert_float_equal(wgt_px(outs[o], x, y, k), wgt_px(d, x, y, k), 1e-6);
        wg_image_unref(outs[o]);
    }
    /* flat on flat is exactly flat */
    WgImage *ff = blend(flat, flat, "rnm", 0.7, 1);
    wgt_assert_identical(ff, flat);
    wg_image_unref(ff);
    wg_image_unref(flat);
    wg_image_unref(d);
    wg_image_unref(b);
}

/* A worked case: base tilted 45° towards +x, detail tilted 45° towards +x. RNM turns the detail
 * with the base: 90°, (1, 0, 0). Whiteout: (√½ + √½, 0, ½) normalised = (2√2, 0, 1)/3. */
static void test_exact_small_case(void **state)
{
    (void)state;
    double h = sqrt(0.5);
    float v[4] = {(float)(h * 0.5 + 0.5), 0.5f, (float)(h * 0.5 + 0.5), 1};
    WgImage *b = wgt_image(1, 1, 4, v);
    WgImage *rnm = blend(b, b, "rnm", 1, 1), *wo = blend(b, b, "whiteout", 1, 1);
    assert_float_equal(wgt_px(rnm, 0, 0, 0), 1.0, 1e-6);
    assert_float_equal(wgt_px(rnm, 0, 0, 1), 0.5, 1e-6);
    assert_float_equal(wgt_px(rnm, 0, 0, 2), 0.5, 1e-6);
    assert_float_equal(wgt_px(wo, 0, 0, 0), 2 * sqrt(2) / 3 * 0.5 + 0.5, 1e-6);
    assert_float_equal(wgt_px(wo, 0, 0, 1), 0.5, 1e-6);
    assert_float_equal(wgt_px(wo, 0, 0, 2), 1.0 / 3 * 0.5 + 0.5, 1e-6);
    wg_image_unref(wo);
    wg_image_unref(rnm);
    wg_image_unref(b);
}

static double scaled_fn(int x, int y, int k)
{
    if (k == 3) return 0.5;
    double v = normals_fn(x, y, k) * 2 - 1;
    double scale = 0.05 + (x * 7 + y * 3) % 11 / 10.0; /* shorter and longer than 1 */
    return v * scale * 0.5 + 0.5;
}

static void test_normalize(void **state)
{
    (void)state;
    salt = 6;
    WgImage *src = wgt_image_fn(23, 14, 4, scaled_fn);
    WgImage *out = normalize(src, 2);
    for (int y = 0; y < 14; y++)
        for (int x = 0; x < 23; x++) {
            double v[3], n[3];
            decode_px(src, x, y, v);
            for (int k = 0; k < 3; k++) n[k] = v[k];
            unit3(n);
            for (int k = 0; k < 3; k++)
                assert_float_equal(wgt_px(out, x, y, k), n[k] * 0.5 + 0.5, 3e-8);
            assert_true(wgt_px(out, x, y, 3) == 0.5f);
        }
    wg_image_unref(out);
    /* zero vectors (and NaN) become (0,0,1); flat and axis vectors stay exactly */
    static const float cases[][4] = {{0.5f, 0.5f, 0.5f, 1},
                                     {NAN, 0.5f, 0.5f, 1},
                                     {0.5f, 0.5f, 1, 0.3f},
                                     {1, 0.5f, 0.5f, 1},
                                     {0.5f, 0, 0.5f, 1},
                                     {0.5f, 0.5f, 0.75f, 1},
                                     {INFINITY, 0.5f, -INFINITY, 1},
                                     {3e38f, 3e38f, 0.5f, 1}};
    static const float want[][3] = {{0.5f, 0.5f, 1}, {0.5f, 0.5f, 1}, {0.5f, 0.5f, 1},
                                    {1, 0.5f, 0.5f}, {0.5f, 0, 0.5f}, {0.5f, 0.5f, 1},
                                    {0, 0, 0},       {0, 0, 0.5f}};
    WgImage *c = wgt_image(8, 1, 4, &cases[0][0]);
    out = normalize(c, 1);
    for (int i = 0; i < 8; i++) {
        if (i == 6) { /* (+inf, 0, −inf): (√½, 0, −√½) */
            assert_float_equal(wgt_px(out, i, 0, 0), sqrt(0.5) * 0.5 + 0.5, 1e-7);
            assert_true(wgt_px(out, i, 0, 1) == 0.5f);
            assert_float_equal(wgt_px(out, i, 0, 2), 0.5 - sqrt(0.5) * 0.5, 1e-7);
        } else if (i == 7) {
            assert_float_equal(wgt_px(out, i, 0, 0), sqrt(0.5) * 0.5 + 0.5, 1e-7);
            assert_float_equal(wgt_px(out, i, 0, 1), sqrt(0.5) * 0.5 + 0.5, 1e-7);
            assert_float_equal(wgt_px(out, i, 0, 2), 0.5, 1e-7);
        } else {
            for (int k = 0; k < 3; k++)
                if (wgt_px(out, i, 0, k) != want[i][k])
                    fail_msg("case %d channel %d: %.9g", i, k, wgt_px(out, i, 0, k));
        }
        assert_true(wgt_px(out, i, 0, 3) == cases[i][3]);
    }
    wg_image_unref(out);
    wg_image_unref(c);
    wg_image_unref(src);
}

static void assert_unit(const WgImage *out)
{
    for (int y = 0; y < out->height; y++)
        for (int x = 0; x < out->width; x++) {
            double n[3];
            decode_px(out, x, y, n);
            double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (!(fabs(len - 1) <= 1.1e-7)) fail_msg("|n| at (%d,%d) is %.12g", x, y, len);
        }
}

static void test_extreme_inputs(void **state)
{
    (void)state;
    static const float vals[] = {0, 1, 0.5f, 3e38f, -3e38f, NAN, INFINITY, -INFINITY, 1e-30f};
    WgImage *a = wgt_image(9, 9, 4, NULL), *b = wgt_image(9, 9, 4, NULL);
    for (int y = 0; y < 9; y++)
        for (int x = 0; x < 9; x++)
            for (int k = 0; k < 4; k++) {
                wg_image_row(a, y)[x * 4 + k] = vals[(x + k * 2 + y) % 9];
                wg_image_row(b, y)[x * 4 + k] = vals[(y * 3 + k + x * 5) % 9];
            }
    for (int k = 0; k < 9; k++) wg_image_row(a, k)[k * 4 + 3] = 1; /* finite alpha */
    WgImage *outs[] = {blend(a, b, "rnm", 1, 2), blend(a, b, "whiteout", 0.5, 2),
                       blend(b, a, "rnm", 0.3, 2), normalize(a, 2)};
    for (int o = 0; o < 4; o++) {
        for (int y = 0; y < 9; y++)
            for (int x = 0; x < 9; x++)
                for (int k = 0; k < 3; k++) {
                    float v = wgt_px(outs[o], x, y, k);
                    if (!(v >= 0 && v <= 1)) fail_msg("output %d (%d,%d,%d): %g", o, x, y, k, v);
                }
        assert_unit(outs[o]);
        wg_image_unref(outs[o]);
    }
    /* a base pointing straight down is outside the hemisphere RNM works in: kept */
    float down[4] = {0.5f, 0.5f, 0, 1};
    WgImage *dn = wgt_image(1, 1, 4, down), *d = normals(1, 1, 9);
    WgImage *o = blend(dn, d, "rnm", 1, 1);
    wgt_assert_identical(o, dn);
    wg_image_unref(o);
    wg_image_unref(d);
    wg_image_unref(dn);
    wg_image_unref(b);
    wg_image_unref(a);
}

static void test_tiling_and_threads(void **state)
{
    (void)state;
    WgImage *b = normals(300, 150, 10), *d = normals(300, 150, 11);
    for (int m = 0; m < 3; m++) {
        WgImage *ref = m == 2 ? normalize(d, 1) : blend(b, d, m ? "whiteout" : "rnm", 0.8, 1);
        static const int threads[] = {2, 3, 8};
        for (int t = 0; t < 3; t++) {
            WgImage *o = m == 2 ? normalize(d, threads[t])
                                : blend(b, d, m ? "whiteout" : "rnm", 0.8, threads[t]);
            wgt_assert_identical(o, ref);
            wg_image_unref(o);
        }
        WgImage *rb = ht_roll(b, 17, 33), *rd = ht_roll(d, 17, 33);
        WgImage *o = m == 2 ? normalize(rd, 2) : blend(rb, rd, m ? "whiteout" : "rnm", 0.8, 2);
        WgImage *want = ht_roll(ref, 17, 33);
        wgt_assert_identical(o, want);
        wg_image_unref(want);
        wg_image_unref(o);
        wg_image_unref(rd);
        wg_image_unref(rb);
        wg_image_unref(ref);
    }
    wg_image_unref(d);
    wg_image_unref(b);
}

static void test_defaults_and_errors(void **state)
{
    (void)state;
    WgImage *b = normals(6, 5, 12), *d = normals(6, 5, 13);
    const char *names[] = {"base", "detail"};
    const WgImage *imgs[] = {b, d};
    WgImage *def = wgt_node("normal_blend", "", 6, 5, 2, names, imgs, 0, 1);
    WgImage *rnm = blend(b, d, "rnm", 1, 1);
    wgt_assert_identical(def, rnm);
    WgError err;
    assert_int_equal(wgt_node_error("normal_blend", "opacity=\"1.5\"", 6, 5, 2, names, imgs, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "opacity"));
    assert_int_not_equal(
        wgt_node_error("normal_blend", "method=\"udn\"", 6, 5, 2, names, imgs, &err), WG_OK);
    assert_int_not_equal(wgt_node_error("normal_blend", "", 6, 5, 1, names, imgs, &err), WG_OK);
    wg_image_unref(rnm);
    wg_image_unref(def);
    wg_image_unref(d);
    wg_image_unref(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_float64_reference),
        cmocka_unit_test(test_flat_detail_and_zero_opacity_keep_base),
        cmocka_unit_test(test_exact_small_case),
        cmocka_unit_test(test_normalize),
        cmocka_unit_test(test_extreme_inputs),
        cmocka_unit_test(test_tiling_and_threads),
        cmocka_unit_test(test_defaults_and_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
