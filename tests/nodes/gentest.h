/* SPDX-License-Identifier: MIT */
/* Checks shared by the generator tests (noise, cells, gradient, checker, sine, shape, bricks).
 *
 * Tiling. A generator samples a periodic function f(u, v) at pixel centres; it tiles when f is
 * continuous across u = 1 → 0 (and v). With the pixel step h small against the pattern's
 * features, the wrap pairs (column W−1 → 0, row H−1 → 0) are just more neighbour pairs of the
 * same function, so their differences obey the same bounds as the interior ones:
 *  - wrap_jump_ratio: max |f(0) − f(W−1)| over rows (and the vertical analogue) divided by the
 *    largest interior neighbour difference. A seam (a jump) gives a ratio ≫ 1; a continuous
 *    wrap gives ≤ 1 (up to the sampling of the maximum), so tests assert ≤ 1.05.
 *  - wrap_kink_ratio: the same with second differences f(x−1) − 2f(x) + f(x+1) over triples
 *    that straddle the wrap, against the interior maximum. It catches slope discontinuities
 *    (a Perlin lattice that wraps to the wrong gradients is continuous in value — gradient
 *    noise is 0 at lattice points — but kinked): a kink gives O(h) against O(h²) inside.
 *  Both are validated on negative controls (a non-periodic ramp, a kinked radial distance).
 *
 * Resolution independence, exactly: a W×H render samples (x+0.5)/W; a 3W×3H render samples
 * (3x+1+0.5)/(3W) = (x+0.5)/W at pixel 3x+1, so it must reproduce the small render there.
 * And loosely: a 4N render box-downsampled to N is close to the N render (stated tolerances). */
#ifndef GENTEST_H
#define GENTEST_H

#include "wgtest.h"

#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Render a generator (no inputs) at w×h, output `port`, with `threads` workers. */
static inline WgImage *gen(const char *type, const char *attrs, int w, int h, int port, int threads)
{
    return wgt_node(type, attrs, w, h, 0, NULL, NULL, port, threads);
}

static inline double gt_px(const WgImage *img, int x, int y)
{
    return wg_image_row(img, y)[x];
}

/* Largest interior first difference and largest wrap difference, both axes together. */
static inline double wrap_jump_ratio(const WgImage *img)
{
    int w = img->width, h = img->height;
    double inner = 0, wrap = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double f = gt_px(img, x, y);
            double dx = fabs(gt_px(img, (x + 1) % w, y) - f);
            double dy = fabs(gt_px(img, x, (y + 1) % h) - f);
            if (x + 1 < w)
                inner = dx > inner ? dx : inner;
            else if (w > 1)
                wrap = dx > wrap ? dx : wrap;
            if (y + 1 < h)
                inner = dy > inner ? dy : inner;
            else if (h > 1)
                wrap = dy > wrap ? dy : wrap;
        }
    if (wrap <= 1e-6) return 0;
    return inner > 0 ? wrap / inner : INFINITY;
}

static inline double wrap_kink_ratio(const WgImage *img)
{
    int w = img->width, h = img->height;
    double inner = 0, wrap = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double f = gt_px(img, x, y);
            double sx = fabs(gt_px(img, (x + w - 1) % w, y) - 2 * f + gt_px(img, (x + 1) % w, y));
            double sy = fabs(gt_px(img, x, (y + h - 1) % h) - 2 * f + gt_px(img, x, (y + 1) % h));
            if (x > 0 && x + 1 < w)
                inner = sx > inner ? sx : inner;
            else
                wrap = sx > wrap ? sx : wrap;
            if (y > 0 && y + 1 < h)
                inner = sy > inner ? sy : inner;
            else
                wrap = sy > wrap ? sy : wrap;
        }
    if (wrap <= 1e-5) return 0;
    return inner > 0 ? wrap / inner : INFINITY;
}

/* Wrap differences of the w×h render against the 3w×3h render (the same picture sampled three
 * times finer, see above): at a continuous wrap the largest wrap jump shrinks about 3×, at a
 * seam it stays; at a smooth (C¹) wrap the second differences shrink 9×, at a kink 3×. */
static inline void wrap_diffs(const WgImage *img, double *jump, double *kink)
{
    int w = img->width, h = img->height;
    *jump = *kink = 0;
    for (int y = 0; y < h; y++) {
        double a = gt_px(img, w - 2 > 0 ? w - 2 : 0, y), b = gt_px(img, w - 1, y);
        double c = gt_px(img, 0, y), d = gt_px(img, 1 % w, y);
        *jump = fmax(*jump, fabs(c - b));
        *kink = fmax(*kink, fmax(fabs(a - 2 * b + c), fabs(b - 2 * c + d)));
    }
    for (int x = 0; x < w; x++) {
        double a = gt_px(img, x, h - 2 > 0 ? h - 2 : 0), b = gt_px(img, x, h - 1);
        double c = gt_px(img, x, 0), d = gt_px(img, x, 1 % h);
        *jump = fmax(*jump, fabs(c - b));
        *kink = fmax(*kink, fmax(fabs(a - 2 * b + c), fabs(b - 2 * c + d)));
    }
}

/* smooth: the pattern is C¹ (checks kinks too). */
static inline void assert_tiles(const char *type, const char *attrs, int w, int h, int port,
                                bool smooth)
{
    WgImage *img = gen(type, attrs, w, h, port, 2);
    WgImage *fine = gen(type, attrs, 3 * w, 3 * h, port, 2);
    double j = wrap_jump_ratio(img), k = smooth ? wrap_kink_ratio(img) : 0;
    double j1, k1, j3, k3;
    wrap_diffs(img, &j1, &k1);
    wrap_diffs(fine, &j3, &k3);
    wg_image_unref(img);
    wg_image_unref(fine);
    if (!(j <= (smooth ? 1.05 : 1.5)))
        fail_msg("%s %s (%dx%d port %d): wrap jump %.3g x the interior maximum", type, attrs, w, h,
                 port, j);
    if (!(k <= 1.5))
        fail_msg("%s %s (%dx%d port %d): wrap kink %.3g x the interior maximum", type, attrs, w, h,
                 port, k);
    if (!(j3 <= 0.6 * j1 + 1e-4))
        fail_msg("%s %s (%dx%d port %d): wrap jump %.3g does not shrink 3x finer (%.3g)", type,
                 attrs, w, h, port, j1, j3);
    if (smooth && !(k3 <= 0.25 * k1 + 1e-5))
        fail_msg("%s %s (%dx%d port %d): wrap kink %.3g does not shrink 3x finer (%.3g)", type,
                 attrs, w, h, port, k1, k3);
}

/* The 3w×3h render at pixels (3x+1, 3y+1) reproduces the w×h render within tol. */
static inline void assert_subsample(const char *type, const char *attrs, int w, int h, int port,
                                    double tol)
{
    WgImage *a = gen(type, attrs, w, h, port, 2), *b = gen(type, attrs, 3 * w, 3 * h, port, 2);
    double worst = 0;
    int wx = 0, wy = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double d = fabs(gt_px(a, x, y) - gt_px(b, 3 * x + 1, 3 * y + 1));
            if (!(d <= worst)) {
                worst = d;
                wx = x;
                wy = y;
            }
        }
    wg_image_unref(a);
    wg_image_unref(b);
    if (!(worst <= tol))
        fail_msg("%s %s: %dx%d vs 3x render differ by %.3g at (%d, %d) (tolerance %.3g)", type,
                 attrs, w, h, worst, wx, wy, tol);
}

/* The (f·n)² render box-downsampled by f is close to the n² render: mean and max |diff|. */
static inline void assert_downsample(const char *type, const char *attrs, int n, int f, int port,
                                     double tol_mean, double tol_max)
{
    WgImage *a = gen(type, attrs, n, n, port, 2), *b = gen(type, attrs, f * n, f * n, port, 2);
    double sum = 0, worst = 0;
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            double m = 0;
            for (int j = 0; j < f; j++)
                for (int i = 0; i < f; i++) m += gt_px(b, f * x + i, f * y + j);
            double d = fabs(m / (f * f) - gt_px(a, x, y));
            sum += d;
            worst = d > worst ? d : worst;
        }
    wg_image_unref(a);
    wg_image_unref(b);
    double mean = sum / ((double)n * n);
    if (!(mean <= tol_mean) || !(worst <= tol_max))
        fail_msg("%s %s: %d vs %d box-downsampled: mean %.3g (tol %.3g), max %.3g (tol %.3g)", type,
                 attrs, n, f * n, mean, tol_mean, worst, tol_max);
}

/* Bit-identical for 1 and 4 threads (tall enough for many row chunks). */
static inline void assert_thread_invariant(const char *type, const char *attrs, int port)
{
    WgImage *a = gen(type, attrs, 97, 131, port, 1), *b = gen(type, attrs, 97, 131, port, 4);
    wgt_assert_identical(a, b);
    wg_image_unref(a);
    wg_image_unref(b);
}

/* Same seed: identical; another seed: a different picture (most pixels change). */
static inline void assert_seeded(const char *type, const char *attrs, int port)
{
    char a1[512], a2[512];
    snprintf(a1, sizeof a1, "%s seed=\"11\"", attrs);
    snprintf(a2, sizeof a2, "%s seed=\"12\"", attrs);
    WgImage *x = gen(type, a1, 64, 48, port, 2), *y = gen(type, a1, 64, 48, port, 1);
    WgImage *z = gen(type, a2, 64, 48, port, 2);
    wgt_assert_identical(x, y);
    int same = 0;
    for (int r = 0; r < 48; r++)
        for (int c = 0; c < 64; c++) same += gt_px(x, c, r) == gt_px(z, c, r);
    wg_image_unref(x);
    wg_image_unref(y);
    wg_image_unref(z);
    if (same > 64 * 48 / 4)
        fail_msg("%s %s: seeds 11 and 12 agree on %d of %d pixels", type, attrs, same, 64 * 48);
}

static inline void image_stats(const WgImage *img, double *mean, double *sd)
{
    double s = 0, s2 = 0;
    long n = 0;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            double v = gt_px(img, x, y);
            s += v;
            s2 += v * v;
            n++;
        }
    *mean = s / n;
    *sd = sqrt(fmax(0, s2 / n - *mean * *mean));
}

static inline void assert_error_range(const char *type, const char *attrs, const char *needle)
{
    WgError err = {0};
    assert_int_equal(wgt_node_error(type, attrs, 32, 32, 0, NULL, NULL, &err), WG_ERR_RANGE);
    wgt_assert_error(&err, WG_ERR_RANGE, 0, needle);
}

/* Allocation failures during the render: the k-th and every later engine allocation fails,
 * for every k up to a normal render's count. The render must fail with WG_ERR_NOMEM or give
 * the normal picture, and every block the hook handed out must be freed. */
static atomic_long gt_allocs, gt_live, gt_fail_at = -1;

static inline void *gt_alloc(size_t size, void *user)
{
    (void)user;
    long i = atomic_fetch_add(&gt_allocs, 1);
    long f = atomic_load(&gt_fail_at);
    if (f >= 0 && i >= f) return NULL;
    void *p = aligned_alloc(64, (size + 63) & ~(size_t)63);
    if (p) atomic_fetch_add(&gt_live, 1);
    return p;
}

static inline void gt_free(void *ptr, void *user)
{
    (void)user;
    atomic_fetch_sub(&gt_live, 1);
    free(ptr);
}

/* Render with the failing hook installed from request creation to result release; a
 * successful render's pixels are copied to a plain malloc'd array (*copy, *n floats). */
static inline int gt_render_failing(const WgGraph *g, long fail_at, float **copy, size_t *n)
{
    atomic_store(&gt_allocs, 0);
    atomic_store(&gt_live, 0);
    atomic_store(&gt_fail_at, fail_at);
    wg_set_allocator(gt_alloc, gt_free, NULL);
    WgEngineOptions opt = {2, 0, NULL};
    WgEngine *e = NULL;
    WgResult *res = NULL;
    WgError err = {0};
    WgRequest *r = wg_request_new(g);
    int rc = r ? wg_engine_new(&opt, &e, &err) : WG_ERR_NOMEM;
    if (!rc) rc = wg_render(e, r, &res, &err);
    if (!rc) {
        const WgImage *img = wg_result_output_image(res, 0);
        size_t row = (size_t)img->width * (size_t)img->channels;
        *n = row * (size_t)img->height;
        *copy = malloc(sizeof(float) * *n);
        assert_non_null(*copy);
        for (int y = 0; y < img->height; y++)
            memcpy(*copy + row * (size_t)y, wg_image_row(img, y), sizeof(float) * row);
    }
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    long live = atomic_load(&gt_live);
    wg_set_allocator(NULL, NULL, NULL);
    if (rc && rc != WG_ERR_NOMEM)
        fail_msg("failure at allocation %ld gave status %d: %s", fail_at, rc, err.message);
    if (live != 0) fail_msg("failure at allocation %ld leaks %ld blocks", fail_at, live);
    return rc;
}

static inline void assert_alloc_failures(const char *type, const char *attrs, int port)
{
    const WgNodeType *t = wg_node_type_find(type);
    assert_non_null(t);
    char xml[1024];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"37x29\" seed=\"5\">\n"
             "  <node id=\"n\" type=\"%s\" %s/>\n"
             "  <output name=\"out\" from=\"n%s%s\"/>\n</wetgraph>\n",
             type, attrs, port ? "." : "", port ? t->outputs[port].name : "");
    WgGraph *g = wgt_load(xml);
    float *ref = NULL, *img = NULL;
    size_t n_ref = 0, n = 0;
    assert_int_equal(gt_render_failing(g, -1, &ref, &n_ref), WG_OK);
    long total = atomic_load(&gt_allocs);
    assert_true(total > 0);
    int failed = 0;
    for (long k = 0; k <= total; k++) {
        if (gt_render_failing(g, k, &img, &n) == WG_OK) {
            if (n != n_ref || memcmp(ref, img, sizeof(float) * n))
                fail_msg("%s %s: render with allocation %ld failing differs", type, attrs, k);
            free(img);
        } else {
            failed++;
        }
    }
    assert_true(failed > 0);
    free(ref);
    wg_graph_free(g);
}

#endif
