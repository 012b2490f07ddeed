/* SPDX-License-Identifier: MIT */
/* `noise`: a float64 reference of Perlin and value fbm (coarse and per-pixel paths), tiling for
 * every kind and mode over several seeds and sizes, exact and box-filtered resolution
 * independence, thread-count invariance, seeding, statistics, and hard cases (scale 0 is a
 * range error, huge scales, 0 and 16 octaves, non-square and degenerate sizes). */
#include "gentest.h"

#include <stdlib.h>

static const char *const kinds[] = {"value", "perlin", "simplex", "white"};
static const char *const modes[] = {"normal", "turbulence", "ridged"};

/* ---- float64 reference (same lattice, hashes and gradient set as nodes/noise.c) ---------- */

static uint32_t ref_key(uint64_t i)
{
    return (uint32_t)i ^ (i >> 32 ? wg_hash_u32((uint32_t)(i >> 32) ^ 0x5bd1e995u) : 0x5a6bc3e1u);
}

static double ref_fade(double t)
{
    return t * t * t * (t * (t * 6 - 15) + 10);
}

/* One octave at lattice point (tx, ty) in [0, px) × [0, py). */
static double ref_octave(int kind, double tx, double ty, uint64_t px, uint64_t py, uint32_t seed)
{
    uint64_t ix = (uint64_t)floor(tx), iy = (uint64_t)floor(ty);
    double fx = tx - (double)ix, fy = ty - (double)iy;
    double v[2][2];
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            uint64_t cx = (ix + (uint64_t)i) % px, cy = (iy + (uint64_t)j) % py;
            uint32_t h = wg_hash_u32(ref_key(cx) ^ wg_hash_u32(ref_key(cy) ^ seed));
            if (kind == 0) {
                v[j][i] = (double)(h >> 8) / 8388608.0 - 1;
            } else {
                double a = (double)(h >> 28) * M_PI / 8;
                v[j][i] = sqrt(2.0) * (cos(a) * (fx - i) + sin(a) * (fy - j));
            }
        }
    double sx = ref_fade(fx), sy = ref_fade(fy);
    double l = v[0][0] + sy * (v[1][0] - v[0][0]), r = v[0][1] + sy * (v[1][1] - v[0][1]);
    return l + sx * (r - l);
}

/* Normal-mode fbm, kind 0 value / 1 perlin, at pixel (x, y) of w×h. */
static double ref_fbm(int kind, int scale, int octaves, double persistence, int lacunarity,
                      uint64_t seed, int w, int h, int x, int y)
{
    uint32_t s = wg_hash3((uint32_t)seed, (uint32_t)(seed >> 32), 0x6e6f6973u);
    uint64_t px = (uint64_t)scale, py = (uint64_t)fmax(1, floor((double)scale * h / w + 0.5));
    double sum = 0, norm = 0, amp = 1;
    for (int o = 0; o < octaves; o++) {
        uint32_t os = wg_hash_u32(s ^ wg_hash_u32((uint32_t)o + 0x9e3779b9u));
        double tx = (x + 0.5) * (double)px / w, ty = (y + 0.5) * (double)py / h;
        sum += amp * ref_octave(kind, tx, ty, px, py, os);
        norm += (float)amp;
        amp *= persistence;
        px *= (uint64_t)lacunarity;
        py *= (uint64_t)lacunarity;
    }
    return 0.5 + 0.5 * sum / norm;
}

static void check_reference(const char *kind_name, int kind, int scale, int octaves, int w, int h)
{
    char attrs[256];
    snprintf(attrs, sizeof attrs,
             "kind=\"%s\" scale=\"%d\" octaves=\"%d\" persistence=\"0.5\" lacunarity=\"2\" "
             "seed=\"77\"",
             kind_name, scale, octaves);
    WgImage *img = gen("noise", attrs, w, h, 0, 2);
    double worst = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double d =
                fabs(gt_px(img, x, y) - ref_fbm(kind, scale, octaves, 0.5, 2, 77, w, h, x, y));
            worst = d > worst ? d : worst;
        }
    wg_image_unref(img);
    if (!(worst <= 2e-6))
        fail_msg("%s scale %d octaves %d at %dx%d: %.3g from the float64 reference", kind_name,
                 scale, octaves, w, h, worst);
}

static void test_matches_float64_reference(void **state)
{
    (void)state;
    /* cells of 16 px down to 1 px (per-cell paths), then finer than pixels (per-pixel path) */
    check_reference("perlin", 1, 4, 7, 64, 64);
    check_reference("value", 0, 4, 7, 64, 64);
    check_reference("perlin", 1, 5, 3, 70, 30); /* non-square: 2 rows */
    check_reference("perlin", 1, 100, 2, 48, 40);
    check_reference("value", 0, 100, 2, 48, 40);
}

/* ---- tiling ------------------------------------------------------------------------------ */

static void test_tiles_every_kind_mode_and_seed(void **state)
{
    (void)state;
    const char *sizes[][2] = {{"256", "256"}, {"240", "160"}, {"96", "224"}};
    for (int k = 0; k < 3; k++) /* smooth kinds */
        for (int seed = 1; seed <= 3; seed++)
            for (int s = 0; s < 3; s++) {
                char a[256];
                int w = atoi(sizes[s][0]), h = atoi(sizes[s][1]);
                snprintf(a, sizeof a, "kind=\"%s\" scale=\"3\" octaves=\"1\" seed=\"%d\"", kinds[k],
                         seed);
                assert_tiles("noise", a, w, h, 0, true);
                snprintf(a, sizeof a, "kind=\"%s\" scale=\"2\" octaves=\"4\" seed=\"%d\"", kinds[k],
                         seed);
                assert_tiles("noise", a, w, h, 0, true);
                for (int m = 1; m < 3; m++) {
                    snprintf(a, sizeof a,
                             "kind=\"%s\" scale=\"3\" octaves=\"3\" mode=\"%s\" seed=\"%d\"",
                             kinds[k], modes[m], seed);
                    assert_tiles("noise", a, w, h, 0, false);
                }
            }
}

/* White noise is piecewise constant: each lattice cell is one value, cells are exactly
 * W/scale × H/rows pixels when those divide, and the lattice wraps (cell scale-1 then 0). */
static void test_white_noise_is_constant_per_cell(void **state)
{
    (void)state;
    WgImage *img = gen("noise", "kind=\"white\" scale=\"8\" octaves=\"1\"", 64, 32, 0, 2);
    int distinct = 0;
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 64; x++) {
            assert_float_equal(gt_px(img, x, y), gt_px(img, x / 8 * 8, y / 8 * 8), 0);
            if (x % 8 == 0 && y % 8 == 0 && gt_px(img, x, y) != gt_px(img, 0, 0)) distinct++;
        }
    assert_true(distinct >= 28); /* 32 cells, values are 24-bit uniform */
    wg_image_unref(img);
    /* per-pixel white noise: scale = width */
    img = gen("noise", "kind=\"white\" scale=\"64\" octaves=\"1\"", 64, 64, 0, 2);
    double mean, sd;
    image_stats(img, &mean, &sd);
    assert_true(fabs(mean - 0.5) < 0.03);
    assert_true(fabs(sd - sqrt(1.0 / 12)) < 0.02); /* uniform on [0, 1] */
    wg_image_unref(img);
}

/* ---- resolution independence ------------------------------------------------------------- */

static void test_resolution_independent(void **state)
{
    (void)state;
    for (int k = 0; k < 4; k++) {
        char a[256];
        snprintf(a, sizeof a, "kind=\"%s\" scale=\"3\" octaves=\"4\" seed=\"5\"", kinds[k]);
        assert_subsample("noise", a, 40, 24, 0, 2e-6);
        snprintf(a, sizeof a, "kind=\"%s\" scale=\"3\" octaves=\"4\" mode=\"ridged\"", kinds[k]);
        assert_subsample("noise", a, 24, 40, 0, 2e-6);
    }
    /* 64 vs 256 box-downsampled, cells >= 8 px at 64: mean |diff| <= 0.004, max <= 0.02 */
    assert_downsample("noise", "kind=\"perlin\" scale=\"4\" octaves=\"2\"", 64, 4, 0, 0.004, 0.02);
    assert_downsample("noise", "kind=\"simplex\" scale=\"4\" octaves=\"2\"", 64, 4, 0, 0.004, 0.02);
    assert_downsample("noise", "kind=\"value\" scale=\"4\" octaves=\"2\"", 64, 4, 0, 0.004, 0.02);
}

/* ---- determinism ------------------------------------------------------------------------- */

static void test_threads_and_seeds(void **state)
{
    (void)state;
    for (int k = 0; k < 4; k++) {
        char a[256];
        snprintf(a, sizeof a, "kind=\"%s\" scale=\"5\" octaves=\"6\"", kinds[k]);
        assert_thread_invariant("noise", a, 0);
        assert_seeded("noise", a, 0);
        snprintf(a, sizeof a, "kind=\"%s\" scale=\"200\" octaves=\"2\"", kinds[k]); /* per pixel */
        assert_thread_invariant("noise", a, 0);
    }
}

/* ---- statistics -------------------------------------------------------------------------- */

static void check_stats(const char *attrs, double mlo, double mhi, double slo, double shi)
{
    for (int seed = 1; seed <= 4; seed++) {
        char a[256];
        snprintf(a, sizeof a, "%s seed=\"%d\"", attrs, seed);
        WgImage *img = gen("noise", a, 256, 256, 0, 2);
        wgt_assert_range(img, 0, 1);
        double mean, sd;
        image_stats(img, &mean, &sd);
        wg_image_unref(img);
        if (!(mean >= mlo && mean <= mhi && sd >= slo && sd <= shi))
            fail_msg("%s: mean %.4f (want %.2f..%.2f), sd %.4f (want %.2f..%.2f)", a, mean, mlo,
                     mhi, sd, slo, shi);
    }
}

static void test_statistics(void **state)
{
    (void)state;
    /* Gradient noise has mean exactly 0.5 over whole periods (odd in the gradients); the
     * standard deviations are those of the bound-normalised sums (measured over 4 seeds, ±30%). */
    check_stats("kind=\"perlin\" scale=\"8\" octaves=\"1\"", 0.49, 0.51, 0.12, 0.22);
    check_stats("kind=\"perlin\" scale=\"8\" octaves=\"6\"", 0.49, 0.51, 0.07, 0.14);
    check_stats("kind=\"simplex\" scale=\"8\" octaves=\"1\"", 0.49, 0.51, 0.19, 0.34);
    check_stats("kind=\"value\" scale=\"8\" octaves=\"1\"", 0.40, 0.60, 0.14, 0.30);
    check_stats("kind=\"value\" scale=\"8\" octaves=\"6\"", 0.42, 0.58, 0.09, 0.22);
    check_stats("kind=\"white\" scale=\"256\" octaves=\"1\"", 0.48, 0.52, 0.27, 0.31);
    check_stats("kind=\"perlin\" scale=\"8\" octaves=\"6\" mode=\"turbulence\"", 0.10, 0.30, 0.04,
                0.16);
    check_stats("kind=\"perlin\" scale=\"8\" octaves=\"6\" mode=\"ridged\"", 0.55, 0.85, 0.04,
                0.16);
}

/* ---- hard cases -------------------------------------------------------------------------- */

static void test_octaves_zero_is_flat_half(void **state)
{
    (void)state;
    for (int k = 0; k < 4; k++)
        for (int m = 0; m < 3; m++) {
            char a[256];
            snprintf(a, sizeof a, "kind=\"%s\" octaves=\"0\" mode=\"%s\"", kinds[k], modes[m]);
            WgImage *img = gen("noise", a, 17, 9, 0, 2);
            wgt_assert_range(img, 0.5, 0.5);
            wg_image_unref(img);
        }
    /* persistence 0: only the first octave counts, whatever the octave count */
    WgImage *a = gen("noise", "octaves=\"1\"", 32, 32, 0, 2);
    WgImage *b = gen("noise", "octaves=\"9\" persistence=\"0\"", 32, 32, 0, 2);
    wgt_assert_identical(a, b);
    wg_image_unref(a);
    wg_image_unref(b);
}

static void test_hard_cases(void **state)
{
    (void)state;
    assert_alloc_failures("noise", "kind=\"perlin\" scale=\"3\" octaves=\"8\"", 0);
    assert_alloc_failures("noise", "kind=\"simplex\" scale=\"60\" octaves=\"2\"", 0);
    assert_error_range("noise", "scale=\"0\"", "'scale' = 0 is outside");
    assert_error_range("noise", "octaves=\"17\"", "octaves");
    assert_error_range("noise", "lacunarity=\"0\"", "lacunarity");
    WgError err = {0};
    assert_int_equal(wgt_node_error("noise", "lacunarity=\"2.5\"", 8, 8, 0, NULL, NULL, &err),
                     WG_ERR_TYPE);
    for (int k = 0; k < 4; k++) {
        char a[256];
        double mean, sd;
        /* 4096 cells on 256 px: no crash, in range. (Every pixel centre is then a lattice
         * point, where Perlin noise is 0: flat 0.5 is the right answer for perlin.) */
        snprintf(a, sizeof a, "kind=\"%s\" scale=\"4096\" octaves=\"2\"", kinds[k]);
        WgImage *img = gen("noise", a, 256, 256, 0, 2);
        wgt_assert_range(img, 0, 1);
        wg_image_unref(img);
        snprintf(a, sizeof a, "kind=\"%s\" scale=\"4093\" octaves=\"2\"", kinds[k]);
        img = gen("noise", a, 256, 256, 0, 2);
        wgt_assert_range(img, 0, 1);
        image_stats(img, &mean, &sd);
        assert_true(sd > 0.03);
        wg_image_unref(img);
        /* 16 octaves at the largest lacunarity and scale: lattice periods up to 2^44 */
        snprintf(a, sizeof a,
                 "kind=\"%s\" scale=\"16384\" octaves=\"16\" lacunarity=\"4\" persistence=\"1\"",
                 kinds[k]);
        img = gen("noise", a, 40, 40, 0, 2);
        wgt_assert_range(img, 0, 1);
        wg_image_unref(img);
        snprintf(a, sizeof a, "kind=\"%s\" scale=\"3\" octaves=\"16\"", kinds[k]);
        img = gen("noise", a, 64, 64, 0, 2);
        wgt_assert_range(img, 0, 1);
        wg_image_unref(img);
        /* degenerate and very non-square sizes (rows = max(1, round(scale·H/W))) */
        const int sz[][2] = {{1, 1}, {1, 64}, {64, 1}, {300, 7}, {7, 300}};
        for (int s = 0; s < 5; s++) {
            snprintf(a, sizeof a, "kind=\"%s\" scale=\"5\" octaves=\"5\"", kinds[k]);
            img = gen("noise", a, sz[s][0], sz[s][1], 0, 2);
            wgt_assert_range(img, 0, 1);
            wg_image_unref(img);
        }
    }
    /* lacunarity 1: every octave has the same lattice but its own seed */
    WgImage *img = gen("noise", "scale=\"4\" octaves=\"4\" lacunarity=\"1\"", 64, 64, 0, 2);
    double mean, sd;
    image_stats(img, &mean, &sd);
    assert_true(sd > 0.03);
    wg_image_unref(img);
    assert_tiles("noise", "scale=\"4\" octaves=\"4\" lacunarity=\"1\"", 128, 128, 0, true);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_float64_reference),
        cmocka_unit_test(test_tiles_every_kind_mode_and_seed),
        cmocka_unit_test(test_white_noise_is_constant_per_cell),
        cmocka_unit_test(test_resolution_independent),
        cmocka_unit_test(test_threads_and_seeds),
        cmocka_unit_test(test_statistics),
        cmocka_unit_test(test_octaves_zero_is_flat_half),
        cmocka_unit_test(test_hard_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
