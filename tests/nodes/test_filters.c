/* SPDX-License-Identifier: MIT */
/* `sharpen`, `emboss`, `edge_detect` and `directional_blur` against float64 references written
 * independently of the nodes (a direct 2D periodic Gaussian with every periodic image summed, the
 * 3×3 Sobel kernels spelled out, bilinear samples along the streak), on several shapes including
 * 1×N, N×1 and 1×1; exact small cases (a unit step, an impulse); constants (sharpen returns them
 * exactly, edge_detect gives 0, emboss 0.5); tiling (a cyclic shift of the input shifts the
 * output, bit for bit); thread-count invariance; extreme and non-finite inputs (finite output);
 * resolution independence of sharpen's radius and directional_blur's length (one smooth wave at
 * 64² and 256², checked against each other and against the continuous filter's response); and
 * parameter errors. */
#include "heighttest.h"

#include <float.h>

static WgImage *run(const char *type, const char *port, const char *attrs, const WgImage *src,
                    int threads)
{
    const char *names[] = {port};
    const WgImage *imgs[] = {src};
    return wgt_node(type, attrs, src->width, src->height, 1, names, imgs, 0, threads);
}

static WgImage *sharpen_q(const WgImage *src, double amount, double radius, const char *quality,
                          int threads)
{
    char a[160];
    snprintf(a, sizeof a, "amount=\"%.9g\" radius=\"%.9g\" quality=\"%s\"", amount, radius,
             quality);
    return run("sharpen", "source", a, src, threads);
}
static WgImage *sharpen(const WgImage *src, double amount, double radius, int threads)
{
    return sharpen_q(src, amount, radius, "exact", threads);
}
static WgImage *sharpen_fast(const WgImage *src, double amount, double radius, int threads)
{
    return sharpen_q(src, amount, radius, "fast", threads);
}
static WgImage *emboss(const WgImage *src, double angle, double intensity, int threads)
{
    char a[128];
    snprintf(a, sizeof a, "angle=\"%.9g\" intensity=\"%.9g\"", angle, intensity);
    return run("emboss", "height", a, src, threads);
}
static WgImage *edges(const WgImage *src, double intensity, const char *mode, int threads)
{
    char a[128];
    snprintf(a, sizeof a, "intensity=\"%.9g\" mode=\"%s\"", intensity, mode);
    return run("edge_detect", "source", a, src, threads);
}
static WgImage *dirblur(const WgImage *src, double angle, double length, const char *kernel,
                        int threads)
{
    char a[160];
    snprintf(a, sizeof a, "angle=\"%.9g\" length=\"%.9g\" kernel=\"%s\"", angle, length, kernel);
    return run("directional_blur", "source", a, src, threads);
}

static double px(const WgImage *img, int x, int y, int k)
{
    int w = img->width, h = img->height;
    return wg_image_row(img, ((y % h) + h) % h)[(((x % w) + w) % w) * img->channels + k];
}

static double pattern4_fn(int x, int y, int k)
{
    return ht_pattern_fn(x, y, k) - 0.3 * k;
}

/* ---- float64 references ---- */

/* The periodic Gaussian over a side n at offset d: the sum over every periodic image. */
static double periodic_gauss(double sigma, int n, int d)
{
    double s = 0, total = 0;
    int m = (int)ceil(8 * sigma / n) + 2;
    for (int e = -m * n; e <= m * n; e++) {
        double g = exp(-0.5 * e * e / (sigma * sigma));
        total += g;
        if (((e % n) + n) % n == d) s += g;
    }
    return s / total;
}

static double sharpen_ref(const WgImage *src, double amount, double radius, int x, int y, int k)
{
    int w = src->width, h = src->height;
    double sigma = radius * w / 256.0;
    if (sigma == 0 || amount == 0 || (k == 3 && src->channels == 4)) return px(src, x, y, k);
    double b = 0;
    for (int dy = 0; dy < h; dy++) {
        double wy = periodic_gauss(sigma, h, dy);
        for (int dx = 0; dx < w; dx++)
            b += wy * periodic_gauss(sigma, w, dx) * px(src, x + dx, y + dy, k);
    }
    double s = px(src, x, y, k);
    return s + amount * (s - b);
}

static const double KX[3][3] = {{-1, 0, 1}, {-2, 0, 2}, {-1, 0, 1}}; /* rows top to bottom */
static const double KY[3][3] = {{1, 2, 1}, {0, 0, 0}, {-1, -2, -1}}; /* rising upwards */

static void sobel_ref(const WgImage *src, int x, int y, double *gx, double *gy)
{
    *gx = *gy = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double v = px(src, x + j - 1, y + i - 1, 0);
            *gx += KX[i][j] * v;
            *gy += KY[i][j] * v;
        }
}

static double emboss_ref(const WgImage *src, double angle, double intensity, int x, int y)
{
    double gx, gy, a = angle * M_PI / 180;
    sobel_ref(src, x, y, &gx, &gy);
    double v = 0.5 - intensity * src->width / 256.0 * (gx * cos(a) + gy * sin(a)) / 16;
    return v < 0 ? 0 : v > 1 ? 1 : v;
}

static double edge_ref(const WgImage *src, double intensity, int mode, int x, int y)
{
    double gx, gy;
    sobel_ref(src, x, y, &gx, &gy);
    double g = mode == 1 ? gx : mode == 2 ? gy : sqrt(gx * gx + gy * gy);
    return intensity * g / 4;
}

static double bilinear(const WgImage *src, double fx, double fy, int k)
{
    double x0 = floor(fx), y0 = floor(fy), ax = fx - x0, ay = fy - y0;
    int ix = (int)x0, iy = (int)y0;
    return (1 - ax) * (1 - ay) * px(src, ix, iy, k) + ax * (1 - ay) * px(src, ix + 1, iy, k) +
           (1 - ax) * ay * px(src, ix, iy + 1, k) + ax * ay * px(src, ix + 1, iy + 1, k);
}

static double dirblur_ref(const WgImage *src, double angle, double length, int gaussian, int x,
                          int y, int k)
{
    double len = length * src->width / 256.0;
    int n = (int)ceil(len);
    if (n <= 1) return px(src, x, y, k);
    double a = angle * M_PI / 180, sum = 0, acc = 0, sigma = len / 6;
    for (int i = 0; i < n; i++) {
        double t = (i + 0.5) * len / n - len / 2;
        double wt = gaussian ? exp(-t * t / (2 * sigma * sigma)) : 1;
        acc += wt * bilinear(src, x + t * cos(a), y - t * sin(a), k);
        sum += wt;
    }
    return acc / sum;
}

static void check_near(double got, double want, double tol, const char *what, int x, int y, int k)
{
    if (!(fabs(got - want) <= tol))
        fail_msg("%s (%d,%d,%d): %.10g, expected %.10g (tolerance %.3g)", what, x, y, k, got, want,
                 tol);
}

static const int shapes[][2] = {{24, 10}, {13, 17}, {1, 9}, {9, 1}, {1, 1}, {2, 3}};
enum { N_SHAPES = 6 };

static void test_sharpen_reference(void **state)
{
    (void)state;
    static const double params[][2] = {{1, 1}, {0.5, 8}, {3, 40}, {2, 300}, {0, 5}, {1, 0}};
    for (int s = 0; s < N_SHAPES; s++)
        for (int c = 1; c <= 4; c += 3) {
            WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], c, pattern4_fn);
            for (int p = 0; p < 6; p++) {
                /* exact: float64 sums rounded once; fast: the fast blur's few 1e-7 of the
                 * largest |value| (1 here), amplified by 1 + amount */
                for (int fast = 0; fast < 2; fast++) {
                    WgImage *out = fast ? sharpen_fast(src, params[p][0], params[p][1], 2)
                                        : sharpen(src, params[p][0], params[p][1], 2);
                    assert_int_equal(out->channels, c);
                    double slack = fast ? 1e-6 : 2e-8;
                    for (int y = 0; y < src->height; y++)
                        for (int x = 0; x < src->width; x++)
                            for (int k = 0; k < c; k++) {
                                double want = sharpen_ref(src, params[p][0], params[p][1], x, y, k);
                                check_near(wgt_px(out, x, y, k), want,
                                           6e-8 * fabs(want) + slack * (1 + params[p][0]),
                                           fast ? "sharpen fast" : "sharpen", x, y, k);
                            }
                    wg_image_unref(out);
                }
            }
            wg_image_unref(src);
        }
}

static void test_emboss_edge_reference(void **state)
{
    (void)state;
    static const double angles[] = {0, 30, 135, 270, -45};
    for (int s = 0; s < N_SHAPES; s++) {
        WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], 1, ht_pattern_fn);
        for (int a = 0; a < 5; a++) {
            WgImage *out = emboss(src, angles[a], a * 3 + 0.5, 2);
            for (int y = 0; y < src->height; y++)
                for (int x = 0; x < src->width; x++)
                    check_near(wgt_px(out, x, y, 0), emboss_ref(src, angles[a], a * 3 + 0.5, x, y),
                               6e-8, "emboss", x, y, 0);
            wg_image_unref(out);
        }
        static const char *const modes[] = {"magnitude", "x", "y"};
        for (int m = 0; m < 3; m++) {
            WgImage *out = edges(src, 1.5, modes[m], 2);
            for (int y = 0; y < src->height; y++)
                for (int x = 0; x < src->width; x++) {
                    double want = edge_ref(src, 1.5, m, x, y);
                    check_near(wgt_px(out, x, y, 0), want, 6e-8 * fabs(want) + 1e-15, modes[m], x,
                               y, 0);
                }
            wg_image_unref(out);
        }
        wg_image_unref(src);
    }
}

static void test_dirblur_reference(void **state)
{
    (void)state;
    static const double params[][2] = {{0, 40}, {30, 64}, {90, 100}, {217, 300}, {45, 10}};
    for (int s = 0; s < N_SHAPES; s++)
        for (int c = 1; c <= 4; c += 3) {
            WgImage *src = wgt_image_fn(shapes[s][0], shapes[s][1], c, pattern4_fn);
            for (int p = 0; p < 5; p++)
                for (int g = 0; g < 2; g++) {
                    WgImage *out =
                        dirblur(src, params[p][0], params[p][1], g ? "gaussian" : "box", 2);
                    for (int y = 0; y < src->height; y++)
                        for (int x = 0; x < src->width; x++)
                            for (int k = 0; k < c; k++) {
                                double want =
                                    dirblur_ref(src, params[p][0], params[p][1], g, x, y, k);
                                check_near(wgt_px(out, x, y, k), want, 6e-8 * fabs(want) + 1e-12,
                                           "directional_blur", x, y, k);
                            }
                    wg_image_unref(out);
                }
            wg_image_unref(src);
        }
}

/* A unit step up between columns 3 and 4 of an 8-wide image (and down across the wrap). */
static double step_fn(int x, int y, int k)
{
    (void)y, (void)k;
    return x >= 4 ? 1 : 0;
}

static void test_exact_small_cases(void **state)
{
    (void)state;
    WgImage *step = wgt_image_fn(8, 5, 1, step_fn);
    WgImage *mag = edges(step, 1, "magnitude", 1);
    WgImage *gx = edges(step, 1, "x", 1);
    WgImage *gy = edges(step, 1, "y", 1);
    /* intensity 32 at width 8: a scale of 1 per unit height, light from +x */
    WgImage *em = emboss(step, 0, 32, 1);
    for (int y = 0; y < 5; y++)
        for (int x = 0; x < 8; x++) {
            int up = x == 3 || x == 4, down = x == 7 || x == 0;
            assert_true(wgt_px(mag, x, y, 0) == (up || down ? 1.0f : 0.0f));
            assert_true(wgt_px(gx, x, y, 0) == (up ? 1.0f : down ? -1.0f : 0.0f));
            assert_true(wgt_px(gy, x, y, 0) == 0.0f);
            /* rising towards the light faces away from it: darker */
            assert_true(wgt_px(em, x, y, 0) == (up ? 0.25f : down ? 0.75f : 0.5f));
        }
    wg_image_unref(em);
    wg_image_unref(gy);
    wg_image_unref(gx);
    wg_image_unref(mag);
    wg_image_unref(step);

    /* an impulse, blurred along x over 4 pixels (length 128 at width 8): samples at ±0.5 and
     * ±1.5 pixels, each shared by two pixels, give weights 1/8 1/4 1/4 1/4 1/8 */
    WgImage *imp = wgt_image(8, 3, 1, NULL);
    wg_image_row(imp, 1)[2] = 1;
    WgImage *db = dirblur(imp, 0, 128, "box", 1);
    static const float want[8] = {0.125f, 0.25f, 0.25f, 0.25f, 0.125f, 0, 0, 0};
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 8; x++) assert_true(wgt_px(db, x, y, 0) == (y == 1 ? want[x] : 0));
    wg_image_unref(db);
    /* 90°: the same along the column, upwards */
    WgImage *tall = wgt_image(8, 8, 1, NULL);
    wg_image_row(tall, 2)[1] = 1;
    db = dirblur(tall, 90, 128, "box", 1);
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 8; x++) assert_true(wgt_px(db, x, y, 0) == (x == 1 ? want[y] : 0));
    wg_image_unref(db);
    wg_image_unref(tall);
    wg_image_unref(imp);
}

static void test_constants(void **state)
{
    (void)state;
    static const float values[] = {0.0f, 0.3f, 1.0f, -7.25f, 1e6f, 3e38f, -3e38f};
    for (int v = 0; v < 7; v++)
        for (int s = 0; s < N_SHAPES; s++) {
            int w = shapes[s][0], h = shapes[s][1];
            WgImage *src = ht_const(w, h, values[v]);
            WgImage *outs[] = {
                sharpen(src, 5, 3, 2),           sharpen(src, 1000, 4096, 2),
                dirblur(src, 33, 200, "box", 2), dirblur(src, 33, 200, "gaussian", 2),
                edges(src, 1e6, "magnitude", 2), emboss(src, 20, 1e6, 2)};
            const float want[] = {values[v], values[v], values[v], values[v], 0, 0.5f};
            for (int o = 0; o < 6; o++) {
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++)
                        if (wgt_px(outs[o], x, y, 0) != want[o])
                            fail_msg("constant %g, output %d at (%d,%d): %.10g", values[v], o, x, y,
                                     wgt_px(outs[o], x, y, 0));
                wg_image_unref(outs[o]);
            }
            /* fast sharpen: the FFT keeps a constant within 1e-6 relative, times 1 + amount
             * (its float sums overflow near the float limit: that range is the exact one's) */
            if (fabsf(values[v]) > 1e30f) {
                wg_image_unref(src);
                continue;
            }
            WgImage *fast[] = {sharpen_fast(src, 5, 3, 2), sharpen_fast(src, 1000, 4096, 2)};
            const double amount[] = {5, 1000};
            for (int o = 0; o < 2; o++) {
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++) {
                        double got = wgt_px(fast[o], x, y, 0), want = values[v];
                        if (!(fabs(got - want) <= 1e-6 * fabs(want) * (1 + amount[o])))
                            fail_msg("constant %g, fast sharpen %d at (%d,%d): %.10g", want, o, x,
                                     y, got);
                    }
                wg_image_unref(fast[o]);
            }
            wg_image_unref(src);
        }
}

typedef WgImage *(*Filter)(const WgImage *src, int threads);
static WgImage *f_sharpen(const WgImage *s, int t)
{
    return sharpen(s, 1.5, 20, t);
}
static WgImage *f_sharpen_wide(const WgImage *s, int t)
{
    return sharpen(s, 1.5, 400, t);
}
static WgImage *f_emboss(const WgImage *s, int t)
{
    return emboss(s, 135, 30, t);
}
static WgImage *f_edges(const WgImage *s, int t)
{
    return edges(s, 2, "magnitude", t);
}
static WgImage *f_edges_y(const WgImage *s, int t)
{
    return edges(s, 2, "y", t);
}
static WgImage *f_dirblur(const WgImage *s, int t)
{
    return dirblur(s, 30, 60, "box", t);
}
static WgImage *f_dirblur_g(const WgImage *s, int t)
{
    return dirblur(s, 200, 90, "gaussian", t);
}
static WgImage *f_sharpen_fast(const WgImage *s, int t)
{
    return sharpen_fast(s, 1.5, 20, t); /* the FFT path: σ 2.9 px at 37 wide is below 3 px */
}
static WgImage *f_sharpen_fast_wide(const WgImage *s, int t)
{
    return sharpen_fast(s, 1.5, 400, t);
}
static const Filter filters[] = {f_sharpen,   f_sharpen_wide, f_emboss,
                                 f_edges,     f_edges_y,      f_dirblur,
                                 f_dirblur_g, f_sharpen_fast, f_sharpen_fast_wide};
static const int filter_color[] = {1, 1, 0, 0, 0, 1, 1, 1, 1};
/* A rolled input gives the rolled output bit for bit, except through an FFT, whose rounding
 * depends on where the pixels sit: there within 1e-6 · (1 + amount). */
static const double roll_tolerance[] = {0, 0, 0, 0, 0, 0, 0, 0, 2.5e-6};
enum { N_FILTERS = 9 };

static void test_tiling_rolls_commute(void **state)
{
    (void)state;
    static const int rolls[][2] = {{5, 0}, {0, 7}, {36, 21}, {11, 13}};
    for (int f = 0; f < N_FILTERS; f++)
        for (int c = 1; c <= (filter_color[f] ? 4 : 1); c += 3) {
            WgImage *src = wgt_image_fn(37, 22, c, pattern4_fn);
            WgImage *ref = filters[f](src, 2);
            for (int r = 0; r < 4; r++) {
                WgImage *rolled = ht_roll(src, rolls[r][0], rolls[r][1]);
                WgImage *out = filters[f](rolled, 2);
                WgImage *want = ht_roll(ref, rolls[r][0], rolls[r][1]);
                if (roll_tolerance[f] == 0)
                    wgt_assert_identical(out, want);
                else
                    wgt_assert_near(out, want, roll_tolerance[f]);
                wg_image_unref(want);
                wg_image_unref(out);
                wg_image_unref(rolled);
            }
            wg_image_unref(ref);
            wg_image_unref(src);
        }
}

static void test_thread_invariance(void **state)
{
    (void)state;
    static const int threads[] = {2, 3, 8};
    for (int f = 0; f < N_FILTERS; f++)
        for (int c = 1; c <= (filter_color[f] ? 4 : 1); c += 3) {
            WgImage *src = wgt_image_fn(300, 150, c, pattern4_fn);
            WgImage *a = filters[f](src, 1);
            for (int t = 0; t < 3; t++) {
                WgImage *b = filters[f](src, threads[t]);
                wgt_assert_identical(a, b);
                wg_image_unref(b);
            }
            wg_image_unref(a);
            wg_image_unref(src);
        }
}

static void test_extreme_inputs(void **state)
{
    (void)state;
    WgImage *big = wgt_image(6, 6, 1, NULL);
    for (int y = 0; y < 6; y++)
        for (int x = 0; x < 6; x++) wg_image_row(big, y)[x] = (x + y) % 2 ? 3.4e38f : -3.4e38f;
    WgImage *bad = wgt_image_fn(8, 6, 1, ht_pattern_fn);
    wg_image_row(bad, 2)[3] = INFINITY;
    wg_image_row(bad, 4)[5] = NAN;
    wg_image_row(bad, 1)[6] = -INFINITY;
    const WgImage *inputs[] = {big, bad};
    for (int i = 0; i < 2; i++) {
        WgImage *outs[] = {sharpen(inputs[i], 1000, 3, 2), edges(inputs[i], 1e6, "magnitude", 2),
                           edges(inputs[i], 1e6, "x", 2), emboss(inputs[i], 10, 1e6, 2),
                           dirblur(inputs[i], 30, 100, "box", 2)};
        for (int o = 0; o < 5; o++) {
            wgt_assert_range(outs[o], -FLT_MAX, FLT_MAX);
            wg_image_unref(outs[o]);
        }
    }
    /* averages of finite values stay finite and within the input's range */
    WgImage *db = dirblur(big, 30, 100, "gaussian", 2);
    wgt_assert_range(db, -3.4e38, 3.4e38);
    wg_image_unref(db);
    WgImage *em = emboss(big, 10, 1e6, 2);
    wgt_assert_range(em, 0, 1);
    wg_image_unref(em);
    wg_image_unref(bad);
    wg_image_unref(big);
}

/* One wave at 64² and 256²: pixel (x, y) of the small render is pixel (4x, 4y) of the large
 * one. The continuous filters' responses are known: a Gaussian of σ (in texture units) scales
 * the wave's deviation from 0.5 by exp(−|k|²σ²/2), a box of length ℓ along u by sinc(k·u ℓ/2). */
static void test_resolution_independence(void **state)
{
    (void)state;
    WgImage *small = ht_wave(64, 64, 0.25, 1, 2);
    WgImage *large = ht_wave(256, 256, 0.25, 1, 2);
    double k2 = 4 * M_PI * M_PI * 5 / (256.0 * 256.0); /* |k|² per length unit squared */
    for (int f = 0; f < 3; f++) {
        WgImage *a, *b;
        double gain;
        if (f == 0) {
            double amount = 2, radius = 8; /* σ = 2 pixels at 64² */
            a = sharpen(small, amount, radius, 2);
            b = sharpen(large, amount, radius, 2);
            gain = 1 + amount * (1 - exp(-k2 * radius * radius / 2));
        } else {
            double angle = f == 1 ? 0 : 60, len = 80, r = angle * M_PI / 180;
            a = dirblur(small, angle, len, "box", 2);
            b = dirblur(large, angle, len, "box", 2);
            /* k·u per length unit: the wave's phase 2π(x + 2y)/256 with y downwards */
            double ku = 2 * M_PI / 256 * (cos(r) - 2 * sin(r));
            double z = ku * len / 2;
            gain = sin(z) / z;
        }
        double worst = 0, worst_exact = 0, change = 0;
        for (int y = 0; y < 64; y++)
            for (int x = 0; x < 64; x++) {
                double va = wgt_px(a, x, y, 0), vb = wgt_px(b, 4 * x, 4 * y, 0);
                double s = wgt_px(small, x, y, 0);
                double exact = 0.5 + gain * (s - 0.5);
                worst = fmax(worst, fabs(va - vb));
                worst_exact = fmax(worst_exact, fmax(fabs(va - exact), fabs(vb - exact)));
                change = fmax(change, fabs(va - s));
            }
        if (!(worst <= (f ? 2e-3 : 1e-6) && worst_exact <= (f ? 2e-3 : 1e-6)))
            fail_msg("filter %d: 64² against 256² %.3g, against the continuous filter %.3g", f,
                     worst, worst_exact);
        if (!(change > 0.02)) fail_msg("filter %d changes the wave by only %.3g", f, change);
        wg_image_unref(b);
        wg_image_unref(a);
    }
    wg_image_unref(large);
    wg_image_unref(small);
}

static void test_defaults_and_errors(void **state)
{
    (void)state;
    WgImage *src = wgt_image_fn(12, 9, 1, ht_pattern_fn);
    WgImage *a = run("sharpen", "source", "", src, 1), *b = sharpen(src, 1, 1, 1);
    wgt_assert_identical(a, b);
    wg_image_unref(a), wg_image_unref(b);
    a = run("emboss", "height", "", src, 1), b = emboss(src, 135, 1, 1);
    wgt_assert_identical(a, b);
    wg_image_unref(a), wg_image_unref(b);
    a = run("edge_detect", "source", "", src, 1), b = edges(src, 1, "magnitude", 1);
    wgt_assert_identical(a, b);
    wg_image_unref(a), wg_image_unref(b);
    a = run("directional_blur", "source", "", src, 1), b = dirblur(src, 0, 4, "box", 1);
    wgt_assert_identical(a, b);
    wg_image_unref(a), wg_image_unref(b);

    WgImage *c = wgt_image(4, 4, 4, NULL);
    const char *src_names[] = {"source"}, *height_names[] = {"height"};
    const WgImage *gray[] = {src}, *color[] = {c};
    WgError err;
    assert_int_equal(wgt_node_error("sharpen", "radius=\"-1\"", 4, 4, 1, src_names, gray, &err),
                     WG_ERR_RANGE);
    assert_non_null(strstr(err.message, "radius"));
    assert_int_equal(
        wgt_node_error("directional_blur", "length=\"-2\"", 4, 4, 1, src_names, gray, &err),
        WG_ERR_RANGE);
    assert_int_not_equal(
        wgt_node_error("directional_blur", "kernel=\"tent\"", 4, 4, 1, src_names, gray, &err),
        WG_OK);
    assert_int_not_equal(
        wgt_node_error("edge_detect", "mode=\"z\"", 4, 4, 1, src_names, gray, &err), WG_OK);
    assert_int_not_equal(wgt_node_error("edge_detect", "", 4, 4, 1, src_names, color, &err), WG_OK);
    assert_int_not_equal(wgt_node_error("emboss", "", 4, 4, 1, height_names, color, &err), WG_OK);
    assert_int_equal(
        wgt_node_error("emboss", "intensity=\"-1\"", 4, 4, 1, height_names, gray, &err),
        WG_ERR_RANGE);
    wg_image_unref(c);
    wg_image_unref(src);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sharpen_reference),
        cmocka_unit_test(test_emboss_edge_reference),
        cmocka_unit_test(test_dirblur_reference),
        cmocka_unit_test(test_exact_small_cases),
        cmocka_unit_test(test_constants),
        cmocka_unit_test(test_tiling_rolls_commute),
        cmocka_unit_test(test_thread_invariance),
        cmocka_unit_test(test_extreme_inputs),
        cmocka_unit_test(test_resolution_independence),
        cmocka_unit_test(test_defaults_and_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
