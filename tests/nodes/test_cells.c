/* SPDX-License-Identifier: MIT */
/* `cells`: the analytic regular grid (jitter 0) for every metric, a brute-force float64
 * reference over all feature points of the tile (validates the pruned search), an exact
 * tiling check (f1 and f2 are 1-Lipschitz, so no neighbour pair may differ by more than one
 * pixel step in cell units, wrap pairs included), resolution independence, threads, seeds and
 * hard cases. */
#include "gentest.h"

static const char *const metrics[] = {"euclidean", "manhattan", "chebyshev"};

static double dist(int metric, double dx, double dy)
{
    dx = fabs(dx);
    dy = fabs(dy);
    return metric == 0 ? sqrt(dx * dx + dy * dy) : metric == 1 ? dx + dy : fmax(dx, dy);
}

static uint32_t ref_key(uint64_t i)
{
    return (uint32_t)i ^ (i >> 32 ? wg_hash_u32((uint32_t)(i >> 32) ^ 0x5bd1e995u) : 0x5a6bc3e1u);
}

/* Brute force: every feature point of the tile and of its 8 neighbouring copies. */
static void ref_cells(int metric, int scale, double jit, uint64_t seed, int w, int h, int x, int y,
                      double *f1, double *f2, double *id)
{
    int px = scale, py = (int)fmax(1, floor((double)scale * h / w + 0.5));
    uint32_t s = wg_hash3((uint32_t)seed, (uint32_t)(seed >> 32), 0x63656c6cu);
    double tx = (x + 0.5) * px / w, ty = (y + 0.5) * py / h;
    *f1 = *f2 = INFINITY;
    for (int j = 0; j < py; j++)
        for (int i = 0; i < px; i++) {
            uint32_t hh = wg_hash_u32(ref_key((uint64_t)i) ^ wg_hash_u32(ref_key((uint64_t)j) ^ s));
            double ox = i + 0.5 + jit * (((hh & 0xffff) + 0.5) / 65536 - 0.5);
            double oy = j + 0.5 + jit * (((hh >> 16) + 0.5) / 65536 - 0.5);
            for (int cy = -1; cy <= 1; cy++)
                for (int cx = -1; cx <= 1; cx++) {
                    double d = dist(metric, ox + cx * px - tx, oy + cy * py - ty);
                    if (d < *f1) {
                        *f2 = *f1;
                        *f1 = d;
                        *id = (double)(wg_hash_u32(hh ^ 0x68e31da4u) >> 8) / 16777216.0;
                    } else if (d < *f2) {
                        *f2 = d;
                    }
                }
        }
}

static void check_reference(int metric, int scale, double jit, int w, int h)
{
    char a[256];
    snprintf(a, sizeof a, "metric=\"%s\" scale=\"%d\" jitter=\"%g\" seed=\"9\"", metrics[metric],
             scale, jit);
    WgImage *o[4];
    for (int p = 0; p < 4; p++) o[p] = gen("cells", a, w, h, p, 2);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double f1, f2, id;
            ref_cells(metric, scale, jit, 9, w, h, x, y, &f1, &f2, &id);
            double want[4] = {fmin(f1, 1), fmin(f2, 1), fmin(f2 - f1, 1), id};
            for (int p = 0; p < 4; p++) {
                double got = gt_px(o[p], x, y);
                /* id may legitimately differ where two points tie for nearest */
                if (p == 3 && f2 - f1 < 1e-5) continue;
                if (!(fabs(got - want[p]) <= 2e-5))
                    fail_msg(
                        "%s scale %d jitter %g %dx%d: port %d at (%d,%d) = %.7g, reference %.7g",
                        metrics[metric], scale, jit, w, h, p, x, y, got, want[p]);
            }
        }
    for (int p = 0; p < 4; p++) wg_image_unref(o[p]);
}

static void test_matches_brute_force_reference(void **state)
{
    (void)state;
    for (int m = 0; m < 3; m++) {
        check_reference(m, 5, 1.0, 60, 60);
        check_reference(m, 4, 0.7, 50, 30); /* non-square: 2 rows */
        check_reference(m, 1, 1.0, 24, 24); /* one cell: all neighbours are its own copies */
        check_reference(m, 2, 1.0, 20, 44);
        check_reference(m, 80, 1.0, 40, 40); /* cells smaller than pixels */
    }
}

/* jitter 0: points at cell centres; with cells of an odd number of pixels the centre pixel
 * sits exactly on the point. */
static void test_regular_grid(void **state)
{
    (void)state;
    for (int m = 0; m < 3; m++) {
        char a[128];
        snprintf(a, sizeof a, "jitter=\"0\" scale=\"4\" metric=\"%s\"", metrics[m]);
        WgImage *f1 = gen("cells", a, 36, 36, 0, 2), *f2 = gen("cells", a, 36, 36, 1, 2);
        WgImage *id = gen("cells", a, 36, 36, 3, 2);
        for (int y = 0; y < 36; y++)
            for (int x = 0; x < 36; x++) {
                double fx = (x % 9 + 0.5) / 9 - 0.5, fy = (y % 9 + 0.5) / 9 - 0.5;
                assert_float_equal(gt_px(f1, x, y), dist(m, fx, fy), 1e-6);
                double second = INFINITY;
                for (int j = -1; j <= 1; j++)
                    for (int i = -1; i <= 1; i++)
                        if (i || j) second = fmin(second, dist(m, fx - i, fy - j));
                assert_float_equal(gt_px(f2, x, y), fmin(second, 1), 1e-6);
                assert_float_equal(gt_px(id, x, y), gt_px(id, x / 9 * 9, y / 9 * 9), 0);
                if (x % 9 == 4 && y % 9 == 4) assert_float_equal(gt_px(f1, x, y), 0, 0);
            }
        wg_image_unref(f1);
        wg_image_unref(f2);
        wg_image_unref(id);
    }
}

/* f1 and f2 are 1-Lipschitz in cell units under each metric, for axis steps: neighbours, wrap
 * pairs included, differ by at most one pixel step (scale/W across, rows/H down). A wrong wrap
 * misses points across the edge and breaks the bound there. */
static void assert_lipschitz(const char *attrs, int scale, int w, int h)
{
    double sx = (double)scale / w, sy = fmax(1, floor((double)scale * h / w + 0.5)) / h;
    for (int p = 0; p < 2; p++) {
        WgImage *img = gen("cells", attrs, w, h, p, 2);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                double f = gt_px(img, x, y);
                double dx = fabs(gt_px(img, (x + 1) % w, y) - f),
                       dy = fabs(gt_px(img, x, (y + 1) % h) - f);
                if (!(dx <= sx * (1 + 1e-4) + 1e-6) || !(dy <= sy * (1 + 1e-4) + 1e-6))
                    fail_msg("%s port %d %dx%d: step at (%d,%d) is %.4g, %.4g (bounds %.4g, %.4g)",
                             attrs, p, w, h, x, y, dx, dy, sx, sy);
            }
        wg_image_unref(img);
    }
}

static void test_tiles(void **state)
{
    (void)state;
    for (int m = 0; m < 3; m++)
        for (int seed = 1; seed <= 4; seed++) {
            char a[160];
            snprintf(a, sizeof a, "metric=\"%s\" scale=\"6\" seed=\"%d\"", metrics[m], seed);
            assert_lipschitz(a, 6, 96, 96);
            assert_lipschitz(a, 6, 120, 64);
            assert_tiles("cells", a, 120, 64, 0, false);
            assert_tiles("cells", a, 120, 64, 2, false);
            snprintf(a, sizeof a, "metric=\"%s\" scale=\"1\" seed=\"%d\"", metrics[m], seed);
            assert_lipschitz(a, 1, 64, 64);
        }
}

static void test_resolution_and_determinism(void **state)
{
    (void)state;
    for (int m = 0; m < 3; m++) {
        char a[128];
        snprintf(a, sizeof a, "metric=\"%s\" scale=\"5\"", metrics[m]);
        for (int p = 0; p < 4; p++) {
            assert_subsample("cells", a, 40, 30, p, 2e-6);
            assert_thread_invariant("cells", a, p);
        }
        assert_seeded("cells", a, 0);
        assert_seeded("cells", a, 3);
        /* f1 is 1-Lipschitz: a 4x4 box mean differs from the centre sample by at most
         * 1.5 steps of the 256 render and much less on average */
        assert_downsample("cells", a, 64, 4, 0, 0.01, 0.06);
    }
}

static void test_hard_cases(void **state)
{
    (void)state;
    assert_alloc_failures("cells", "scale=\"5\"", 2);
    assert_alloc_failures("cells", "scale=\"60\" metric=\"manhattan\"", 0);
    assert_error_range("cells", "scale=\"0\"", "'scale' = 0 is outside");
    assert_error_range("cells", "jitter=\"1.5\"", "jitter");
    for (int m = 0; m < 3; m++) {
        char a[128];
        snprintf(a, sizeof a, "metric=\"%s\" scale=\"4096\"", metrics[m]);
        for (int p = 0; p < 4; p++) {
            WgImage *img = gen("cells", a, 256, 256, p, 2);
            wgt_assert_range(img, 0, 1);
            wg_image_unref(img);
        }
        snprintf(a, sizeof a, "metric=\"%s\" scale=\"7\"", metrics[m]);
        const int sz[][2] = {{1, 1}, {1, 50}, {50, 1}, {300, 9}};
        for (int s = 0; s < 4; s++) {
            WgImage *img = gen("cells", a, sz[s][0], sz[s][1], 0, 2);
            wgt_assert_range(img, 0, 1);
            wg_image_unref(img);
        }
    }
    /* ids: uniform-ish over many cells, distinct cells differ */
    WgImage *id = gen("cells", "scale=\"64\" jitter=\"0\"", 64, 64, 3, 2);
    double mean, sd;
    image_stats(id, &mean, &sd);
    assert_true(fabs(mean - 0.5) < 0.05 && fabs(sd - sqrt(1.0 / 12)) < 0.03);
    wg_image_unref(id);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_brute_force_reference),
        cmocka_unit_test(test_regular_grid),
        cmocka_unit_test(test_tiles),
        cmocka_unit_test(test_resolution_and_determinism),
        cmocka_unit_test(test_hard_cases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
