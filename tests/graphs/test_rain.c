/* SPDX-License-Identifier: MIT */
/* graphs/rain_ripples.wetgraph and graphs/wet_rain.wetgraph: rain drop rings only where water
 * stands (the normal is the input's, bit for bit, where the water mask is 0, and at rain 0
 * everywhere); a looping setting gives the frame at loop_seconds equal to frame 0, also through
 * `render --frames`; more rain makes more rings (the drops of a lighter rain are among those of
 * a heavier one); a sheltered part gets no drops; the rings are seamless across the tile edges
 * at every frame and the same for any thread count; wet_rain at rain 0 is wet_material, bit for
 * bit, and in the rain it is wet_material in the same rain but for the two normals, rippled only
 * where the water stands; streaks run along up on steep parts only; beads stand on non-porous
 * surfaces only. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { W = 192, H = 128 };

static WgGraph *ripples;

static const char *env(const char *name)
{
    const char *s = getenv(name);
    if (!s) fail_msg("%s is not set (run through meson test)", name);
    return s;
}

static WgGraph *load_builtin(const char *name)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/graphs/%s.wetgraph", env("WETGRAPH_SOURCE"), name);
    WgError err = {0};
    WgGraph *g = NULL;
    if (wg_graph_load(path, &g, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("%s", buf);
    }
    return g;
}

static int setup(void **state)
{
    (void)state;
    ripples = load_builtin("rain_ripples");
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    wg_graph_free(ripples);
    return 0;
}

/* A bumpy normal map (linear, unit vectors). */
static double normal_fn(int x, int y, int k)
{
    double n[3] = {0.3 * sin(0.2 * x), 0.3 * cos(0.13 * y), 1};
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + 1);
    return k == 3 ? 1.0 : n[k] / l * 0.5 + 0.5;
}
/* Water in a soft-edged disc of radius 40 at (96, 64), none outside radius 48. */
static double water_fn(int x, int y, int k)
{
    (void)k;
    double r = hypot(x + 0.5 - 96, y + 0.5 - 64);
    return r < 40 ? 1 : r < 48 ? (48 - r) / 8 : 0;
}
static double left_fn(int x, int y, int k)
{
    (void)y;
    (void)k;
    return x < W / 2 ? 1 : 0;
}

/* Render rain_ripples at time t with the given inputs (NULL: not connected) and settings
 * "name=value ..." on `threads` workers. */
static WgResult *render(const WgImage *normal, const WgImage *water, const WgImage *shelter,
                        double t, const char *sets, int threads)
{
    WgError err = {0};
    WgRequest *r = wg_request_new(ripples);
    assert_non_null(r);
    if (normal && wg_request_set_input_image(r, "normal", normal, &err)) fail_msg("%s", err.message);
    if (water && wg_request_set_input_image(r, "water", water, &err)) fail_msg("%s", err.message);
    if (shelter && wg_request_set_input_image(r, "shelter", shelter, &err))
        fail_msg("%s", err.message);
    if (!normal) wg_request_set_size(r, W, H);
    char buf[512];
    snprintf(buf, sizeof buf, "%s", sets ? sets : "");
    char *save = NULL;
    for (char *p = strtok_r(buf, " ", &save); p; p = strtok_r(NULL, " ", &save)) {
        char *eq = strchr(p, '=');
        assert_non_null(eq);
        *eq = 0;
        if (wg_request_set(r, p, eq + 1, &err)) fail_msg("%s=%s: %s", p, eq + 1, err.message);
    }
    wg_request_set_time(r, t);
    WgEngine *e = wgt_engine(threads, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    wg_engine_free(e);
    wg_request_free(r);
    return res;
}

/* Sum of |ripple height| over the pixels where keep(x) holds (all when NULL). */
static double energy(const WgImage *h, bool (*keep)(int x))
{
    double s = 0;
    for (int y = 0; y < h->height; y++)
        for (int x = 0; x < h->width; x++)
            if (!keep || keep(x)) s += fabs(wgt_px(h, x, y, 0));
    return s;
}
static bool left_half(int x)
{
    return x < W / 2;
}
static bool right_half(int x)
{
    return x >= W / 2;
}

/* Outside the water the normal is the input's, bit for bit; inside the rings change it; at
 * rain 0 nothing changes anywhere. */
static void test_only_where_water(void **state)
{
    (void)state;
    WgImage *n = wgt_image_fn(W, H, 4, normal_fn), *w = wgt_image_fn(W, H, 1, water_fn);
    const double times[] = {0, 0.37, 1.9};
    for (int i = 0; i < 3; i++) {
        WgResult *res = render(n, w, NULL, times[i], "rain=1", 2);
        const WgImage *out = wgt_output(res, "normal");
        int changed = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                bool same = !memcmp(wg_image_row(out, y) + 4 * x, wg_image_row(n, y) + 4 * x,
                                    4 * sizeof(float));
                if (water_fn(x, y, 0) == 0 && !same)
                    fail_msg("t=%g: normal changed at (%d, %d) where no water stands", times[i], x,
                             y);
                changed += !same && water_fn(x, y, 0) == 1;
            }
        printf("t=%g: %d of the water's pixels rippled\n", times[i], changed);
        assert_true(changed > 100);
        wgt_assert_range(out, 0, 1);
        wg_result_free(res);
    }
    WgResult *res = render(n, NULL, NULL, 0.37, "rain=0", 2);
    wgt_assert_identical(wgt_output(res, "normal"), n);
    wgt_assert_range(wgt_output(res, "ripples"), 0, 0);
    wg_result_free(res);
    wg_image_unref(n);
    wg_image_unref(w);
}

/* loop_seconds 2 with rings of 0.7 s (snapped to 2/3 s): the frame at t = 2 and at t = 4 is the
 * frame at t = 0, and the one at t = 1 is not; the same through `render --frames` (frame 24 at
 * 12 fps is frame 0). Without a loop the rings keep changing. */
static void test_loop_closes(void **state)
{
    (void)state;
    const char *sets = "rain=0.8 loop_seconds=2 ripple_seconds=0.7";
    WgResult *a = render(NULL, NULL, NULL, 0, sets, 2), *b = render(NULL, NULL, NULL, 2, sets, 2),
             *c = render(NULL, NULL, NULL, 4, sets, 2), *d = render(NULL, NULL, NULL, 1, sets, 2);
    for (int k = 0; k < wg_result_output_count(a); k++) {
        wgt_assert_identical(wg_result_output_image(b, k), wg_result_output_image(a, k));
        wgt_assert_identical(wg_result_output_image(c, k), wg_result_output_image(a, k));
    }
    assert_true(wgt_max_abs_diff(wgt_output(d, "ripples"), wgt_output(a, "ripples")) > 0.05);
    assert_true(energy(wgt_output(a, "ripples"), NULL) > 1);
    wg_result_free(a);
    wg_result_free(b);
    wg_result_free(c);
    wg_result_free(d);

    const char *dir = wgt_fresh_dir("loop");
    WGT_SH(dir, 0,
           "\"$WG\" render \"%s/graphs/rain_ripples.wetgraph\" --size 64x48 --set rain=0.8 "
           "--set loop_seconds=2 --set ripple_seconds=0.7 --output ripples --output normal "
           "--frames 0:24 --fps 12 -o seq -q",
           env("WETGRAPH_SOURCE"));
    char f0[1024], f24[1024], f12[1024];
    snprintf(f0, sizeof f0, "%s/seq/rain_ripples_normal_0000.png", dir);
    snprintf(f24, sizeof f24, "%s/seq/rain_ripples_normal_0024.png", dir);
    snprintf(f12, sizeof f12, "%s/seq/rain_ripples_normal_0012.png", dir);
    wgt_assert_identical_files(f24, f0);
    assert_false(wgt_same_file(f12, f0));
    snprintf(f0, sizeof f0, "%s/seq/rain_ripples_ripples_0000.exr", dir);
    snprintf(f24, sizeof f24, "%s/seq/rain_ripples_ripples_0024.exr", dir);
    wgt_assert_identical_files(f24, f0);
}

/* More rain, more rings: the ring energy over a few frames grows with rain (0 at rain 0). */
static void test_density_grows_with_rain(void **state)
{
    (void)state;
    const double rains[] = {0, 0.1, 0.3, 0.6, 1};
    const double times[] = {0.1, 0.45, 0.8, 1.6};
    double prev = -1;
    for (int i = 0; i < 5; i++) {
        double e = 0;
        for (int k = 0; k < 4; k++) {
            char sets[64];
            snprintf(sets, sizeof sets, "rain=%g", rains[i]);
            WgResult *res = render(NULL, NULL, NULL, times[k], sets, 2);
            e += energy(wgt_output(res, "ripples"), NULL);
            wg_result_free(res);
        }
        printf("rain %g: ring energy %.1f\n", rains[i], e);
        if (i == 0)
            assert_true(e == 0);
        else if (!(e > 1.3 * prev + 1))
            fail_msg("rain %g: energy %g, not above %g at the lighter rain", rains[i], e, prev);
        prev = e;
    }
}

/* Sheltered parts get no drops: shelter 1 everywhere leaves the normal as it is; on the left
 * half it keeps nearly all rings off it (a ring from a drop just outside may reach in). */
static void test_shelter(void **state)
{
    (void)state;
    WgImage *n = wgt_image_fn(W, H, 4, normal_fn), *s = wgt_image_fn(W, H, 1, left_fn);
    float one = 1;
    WgImage *all = wgt_image(1, 1, 1, &one);
    WgResult *res = render(n, NULL, all, 0.4, "rain=1", 2);
    wgt_assert_identical(wgt_output(res, "normal"), n);
    wg_result_free(res);
    double el = 0, er = 0;
    for (int k = 0; k < 3; k++) {
        res = render(n, NULL, s, 0.3 + 0.4 * k, "rain=1", 2);
        el += energy(wgt_output(res, "ripples"), left_half);
        er += energy(wgt_output(res, "ripples"), right_half);
        wg_result_free(res);
    }
    printf("sheltered left half: ring energy %.1f, open right half %.1f\n", el, er);
    assert_true(er > 10 && el < 0.1 * er);
    wg_image_unref(all);
    wg_image_unref(s);
    wg_image_unref(n);
}

/* Seamless at every frame (a seam would show as a step across the last column or row far above
 * the steps inside, on a non-square tile with small drops that often cross the edges), and the
 * same bits for 1, 2 and 3 threads. */
static void test_tiles_and_threads(void **state)
{
    (void)state;
    const double times[] = {0.2, 0.65, 3.3};
    for (int i = 0; i < 3; i++) {
        WgResult *res = render(NULL, NULL, NULL, times[i], "rain=1 drop_size=3", 2);
        const WgImage *f = wgt_output(res, "ripples");
        WgtSeams st = wgt_seams(f);
        double inner_c = st.inner_c, inner_r = st.inner_r, seam_c = st.seam_c, seam_r = st.seam_r;
        printf("t=%g: seam steps %.4f / %.4f, inside %.4f / %.4f\n", times[i], seam_c, seam_r,
               inner_c, inner_r);
        if (!(seam_c <= 3 * inner_c && seam_r <= 3 * inner_r))
            fail_msg("t=%g: seam steps %g / %g against %g / %g inside", times[i], seam_c, seam_r,
                     inner_c, inner_r);
        assert_true(inner_c > 0.001);
        for (int threads = 1; threads <= 3; threads += 2) {
            WgResult *o = render(NULL, NULL, NULL, times[i], "rain=1 drop_size=3", threads);
            for (int k = 0; k < wg_result_output_count(res); k++)
                wgt_assert_identical(wg_result_output_image(o, k), wg_result_output_image(res, k));
            wg_result_free(o);
        }
        wg_result_free(res);
    }
}

/* wet_rain: at rain 0 every output is wet_material's (streaks or not); in the rain without
 * streaks every output but the two normals is wet_material's at that rain (which wets the
 * surface), and the normals change only where the water stands. */
static double color_fn(int x, int y, int k)
{
    if (k == 3) return 1.0;
    double a = 0.5 + 0.45 * sin(0.11 * x + 2.1 * k) * cos(0.07 * y + k);
    return a * a;
}
static double height_fn(int x, int y, int k)
{
    (void)k;
    return 0.5 + 0.25 * sin(2 * M_PI * x / W) * cos(2 * M_PI * y / H) + 0.05 * sin(0.9 * x);
}

static WgResult *render_wet(const WgGraph *g, const WgImage *base, const WgImage *height,
                            const WgImage *normal, const char *rain, const char *streaks)
{
    WgError err = {0};
    WgRequest *r = wg_request_new(g);
    if (wg_request_set_input_image(r, "basecolor", base, &err) ||
        wg_request_set_input_image(r, "height", height, &err) ||
        wg_request_set_input_image(r, "normal", normal, &err) ||
        wg_request_set(r, "water_level", "0.55", &err) ||
        (rain && wg_request_set(r, "rain", rain, &err)))
        fail_msg("%s", err.message);
    if (streaks && wg_request_set(r, "streaks", streaks, &err)) fail_msg("%s", err.message);
    wg_request_set_time(r, 0.35);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    wg_engine_free(e);
    wg_request_free(r);
    return res;
}

static void test_wet_rain(void **state)
{
    (void)state;
    WgGraph *gr = load_builtin("wet_rain"), *gm = load_builtin("wet_material");
    WgImage *base = wgt_image_fn(W, H, 4, color_fn), *height = wgt_image_fn(W, H, 1, height_fn),
            *normal = wgt_image_fn(W, H, 4, normal_fn);
    WgResult *m = render_wet(gm, base, height, normal, NULL, NULL);
    WgResult *m1 = render_wet(gm, base, height, normal, "1", NULL);
    WgResult *r0 = render_wet(gr, base, height, normal, "0", NULL);
    WgResult *r1 = render_wet(gr, base, height, normal, "1", "0");
    assert_int_equal(wg_result_output_count(r0), wg_result_output_count(m) + 1); /* + streaks */
    const WgImage *wm = wgt_output(m1, "watermask");
    /* the rain wets wet_material's surface: more film, a darker base colour */
    double film0 = 0, film1 = 0, g0 = 0, g1 = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            film0 += wgt_px(wgt_output(m, "wet"), x, y, 0);
            film1 += wgt_px(wgt_output(m1, "wet"), x, y, 0);
            g0 += wgt_px(wgt_output(m, "basecolor"), x, y, 1);
            g1 += wgt_px(wgt_output(m1, "basecolor"), x, y, 1);
        }
    printf("wet_material: film %.0f dry, %.0f in the rain; mean green %.4f, %.4f\n", film0, film1,
           g0 / (W * H), g1 / (W * H));
    assert_true(film1 > film0 + 0.3 * W * H && g1 < 0.9 * g0);
    for (int k = 0; k < wg_result_output_count(m); k++) {
        const char *name = wg_result_output_name(m, k);
        wgt_assert_identical(wgt_output(r0, name), wg_result_output_image(m, k));
        const WgImage *a = wgt_output(r1, name), *b = wg_result_output_image(m1, k);
        bool rippled = !strcmp(name, "normal") || !strcmp(name, "waternormal");
        if (!rippled) {
            wgt_assert_identical(a, b);
            continue;
        }
        int changed = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                bool same = !memcmp(wg_image_row(a, y) + 4 * x, wg_image_row(b, y) + 4 * x,
                                    4 * sizeof(float));
                if (!same && wgt_px(wm, x, y, 0) == 0)
                    fail_msg("%s changed at (%d, %d), where no water stands", name, x, y);
                changed += !same;
            }
        printf("%s: %d pixels rippled\n", name, changed);
        assert_true(changed > 100);
    }
    /* every parameter of wet_material is wet_rain's too: other settings, the same maps */
    static const char *const others[] = {"liquid", "tea", "wet_distance", "14", "sat_wet", "0.5",
                                         "dark_moist", "0.8", "puddle_size", "6", NULL};
    WgResult *mo = NULL, *ro = NULL;
    for (int gi = 0; gi < 2; gi++) {
        WgError err = {0};
        WgRequest *r = wg_request_new(gi ? gr : gm);
        if (wg_request_set_input_image(r, "basecolor", base, &err) ||
            wg_request_set_input_image(r, "height", height, &err) ||
            wg_request_set(r, "water_level", "0.55", &err) ||
            (gi && wg_request_set(r, "rain", "0", &err)))
            fail_msg("%s", err.message);
        for (int k = 0; others[k]; k += 2)
            if (wg_request_set(r, others[k], others[k + 1], &err)) fail_msg("%s", err.message);
        WgEngine *e = wgt_engine(2, 0, NULL);
        *(gi ? &ro : &mo) = wgt_render_request(e, r);
        wg_engine_free(e);
        wg_request_free(r);
    }
    for (int k = 0; k < wg_result_output_count(mo); k++)
        wgt_assert_identical(wgt_output(ro, wg_result_output_name(mo, k)),
                             wg_result_output_image(mo, k));
    wg_result_free(mo);
    wg_result_free(ro);
    wg_result_free(m);
    wg_result_free(m1);
    wg_result_free(r0);
    wg_result_free(r1);
    wg_image_unref(base);
    wg_image_unref(height);
    wg_image_unref(normal);
    wg_graph_free(gr);
    wg_graph_free(gm);
}

/* Streaks: water running down steep parts, only there, drawn out along `up`: their
 * autocorrelation is longer along up than across it, for up along y and along x; none at rain
 * 0 or with streaks 0. On an egg-crate relief deep enough to be steep nearly everywhere. */
static double crate_fn(int x, int y, int k)
{
    (void)k;
    double u = (x + 0.5) / W, v = (y + 0.5) / H;
    return 0.5 + 0.25 * (sin(2 * M_PI * 2 * u) + sin(2 * M_PI * 2 * v));
}
/* Correlation of an image with itself shifted by (dx, dy) pixels (wrapping). */
static double autocorr(const WgImage *f, int dx, int dy)
{
    double n = (double)f->width * f->height, s = 0, ss = 0, sxy = 0;
    for (int y = 0; y < f->height; y++)
        for (int x = 0; x < f->width; x++) {
            double a = wgt_px(f, x, y, 0);
            s += a;
            ss += a * a;
        }
    double mean = s / n, var = ss / n - mean * mean;
    for (int y = 0; y < f->height; y++)
        for (int x = 0; x < f->width; x++)
            sxy += (wgt_px(f, x, y, 0) - mean) *
                   (wgt_px(f, (x + dx) % f->width, (y + dy) % f->height, 0) - mean);
    return var > 0 ? sxy / n / var : 0;
}

static void test_streaks(void **state)
{
    (void)state;
    WgGraph *gr = load_builtin("wet_rain"), *gm = load_builtin("create_masks");
    WgImage *base = wgt_image_fn(W, H, 4, color_fn), *height = wgt_image_fn(W, H, 1, crate_fn);
    /* the slope the masks measure */
    WgError err = {0};
    WgRequest *q = wg_request_new(gm);
    if (wg_request_set_input_image(q, "height", height, &err) ||
        wg_request_set(q, "height_scale", "120", &err) || wg_request_add_output(q, "slope", &err))
        fail_msg("%s", err.message);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *qs = wgt_render_request(e, q);
    const WgImage *slope = wgt_output(qs, "slope");
    static const char *const ups[] = {"90", "0"};
    for (int k = 0; k < 2; k++) {
        WgResult *res[3];
        const char *rains[] = {"1", "0", "1"}, *strengths[] = {"1", "1", "0"};
        for (int i = 0; i < 3; i++) {
            WgRequest *r = wg_request_new(gr);
            if (wg_request_set_input_image(r, "basecolor", base, &err) ||
                wg_request_set_input_image(r, "height", height, &err) ||
                wg_request_set(r, "height_scale", "120", &err) ||
                wg_request_set(r, "water_level", "0.3", &err) ||
                wg_request_set(r, "rain", rains[i], &err) ||
                wg_request_set(r, "streaks", strengths[i], &err) ||
                wg_request_set(r, "up_angle", ups[k], &err) ||
                wg_request_add_output(r, "streaks", &err) || wg_request_add_output(r, "wet", &err))
                fail_msg("%s", err.message);
            res[i] = wgt_render_request(e, r);
            wg_request_free(r);
        }
        const WgImage *st = wgt_output(res[0], "streaks");
        double total = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double v = wgt_px(st, x, y, 0), sl = wgt_px(slope, x, y, 0);
                if (v > 0 && !(sl > 0.425))
                    fail_msg("up %s: streak %g at (%d, %d) where the slope is %g", ups[k], v, x, y,
                             sl);
                if (!(wgt_px(wgt_output(res[0], "wet"), x, y, 0) >= v - 1e-6))
                    fail_msg("up %s: the film at (%d, %d) is below its streak", ups[k], x, y);
                total += v;
            }
        double along = k == 0 ? autocorr(st, 0, 6) : autocorr(st, 6, 0),
               across = k == 0 ? autocorr(st, 6, 0) : autocorr(st, 0, 6);
        printf("up %s: streaks %.0f, autocorrelation at 6 px %.2f along up, %.2f across\n", ups[k],
               total, along, across);
        assert_true(total > 200);
        assert_true(along > across + 0.2);
        wgt_assert_range(wgt_output(res[1], "streaks"), 0, 0);
        wgt_assert_range(wgt_output(res[2], "streaks"), 0, 0);
        for (int i = 0; i < 3; i++) wg_result_free(res[i]);
    }
    wg_result_free(qs);
    wg_request_free(q);
    wg_engine_free(e);
    wg_image_unref(base);
    wg_image_unref(height);
    wg_graph_free(gr);
    wg_graph_free(gm);
}

/* Beads: on a non-porous surface in the rain, drops stand as domes: they are standing water
 * (the water mask, the liquid's roughness) with normals of their own, out of the immersed
 * part; more rain, more beads; none on a porous surface (bit for bit as without beads), under
 * a full shelter, or at rain 0. */
static WgResult *render_beads(const WgGraph *g, const WgImage *base, const WgImage *height,
                              const WgImage *shelter, const char *porosity, const char *rain,
                              const char *beads)
{
    WgError err = {0};
    WgRequest *r = wg_request_new(g);
    if (wg_request_set_input_image(r, "basecolor", base, &err) ||
        wg_request_set_input_image(r, "height", height, &err) ||
        (shelter && wg_request_set_input_image(r, "shelter", shelter, &err)) ||
        wg_request_set(r, "water_level", "0.4", &err) || wg_request_set(r, "rain", rain, &err) ||
        wg_request_set(r, "porosity", porosity, &err) || wg_request_set(r, "beads", beads, &err) ||
        wg_request_set(r, "bead_size", "6", &err) || wg_request_set(r, "streaks", "0", &err) ||
        wg_request_set(r, "ripple_strength", "0", &err))
        fail_msg("%s", err.message);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    wg_engine_free(e);
    wg_request_free(r);
    return res;
}

static void test_beads(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("wet_rain");
    WgImage *base = wgt_image_fn(W, H, 4, color_fn), *height = wgt_image_fn(W, H, 1, height_fn);
    float one = 1;
    WgImage *all = wgt_image(1, 1, 1, &one);
    WgResult *with = render_beads(g, base, height, NULL, "0", "1", "1");
    WgResult *without = render_beads(g, base, height, NULL, "0", "1", "0");
    WgResult *light = render_beads(g, base, height, NULL, "0", "0.2", "1");
    const WgImage *pw = wgt_output(with, "puddles"), *po = wgt_output(without, "puddles"),
                  *pl = wgt_output(light, "puddles");
    const WgImage *wm = wgt_output(with, "watermask"), *rough = wgt_output(with, "roughness"),
                  *imm = wgt_output(with, "immersed");
    int beads = 0, light_beads = 0, tops = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double b = wgt_px(pw, x, y, 0) - wgt_px(po, x, y, 0);
            if (b > 1 - wgt_px(imm, x, y, 0) + 1e-6)
                fail_msg("a bead %g at (%d, %d) under water (immersed %g)", b, x, y,
                         wgt_px(imm, x, y, 0));
            if (b > 0.99) {
                beads++;
                /* the liquid's roughness (0.02), up to the film's (0.3) by what the mask lacks */
                if (!(wgt_px(wm, x, y, 0) >= 0.99 &&
                      wgt_px(rough, x, y, 0) <= 0.02 + 0.3 * (1 - wgt_px(wm, x, y, 0)) + 1e-5))
                    fail_msg("bead (%d, %d): water mask %g, roughness %g", x, y,
                             wgt_px(wm, x, y, 0), wgt_px(rough, x, y, 0));
                const float *a = wg_image_row(wgt_output(with, "normal"), y) + 4 * x,
                            *c = wg_image_row(wgt_output(without, "normal"), y) + 4 * x;
                tops += fabs(a[0] - c[0]) + fabs(a[1] - c[1]) > 0.05;
            }
            light_beads += wgt_px(pl, x, y, 0) - wgt_px(po, x, y, 0) > 0.99;
        }
    printf("beads: %d pixels in heavy rain (%d with their own slope), %d in light rain\n", beads,
           tops, light_beads);
    assert_true(beads > 300 && tops > beads / 3 && light_beads < beads);
    /* none on a porous surface, under a full shelter, or at rain 0 */
    WgResult *porous = render_beads(g, base, height, NULL, "1", "1", "1");
    WgResult *porous0 = render_beads(g, base, height, NULL, "1", "1", "0");
    WgResult *covered = render_beads(g, base, height, all, "0", "1", "1");
    WgResult *covered0 = render_beads(g, base, height, all, "0", "1", "0");
    WgResult *dry = render_beads(g, base, height, NULL, "0", "0", "1");
    WgResult *dry0 = render_beads(g, base, height, NULL, "0", "0", "0");
    for (int k = 0; k < wg_result_output_count(porous); k++) {
        wgt_assert_identical(wg_result_output_image(porous, k), wg_result_output_image(porous0, k));
        wgt_assert_identical(wg_result_output_image(covered, k),
                             wg_result_output_image(covered0, k));
        wgt_assert_identical(wg_result_output_image(dry, k), wg_result_output_image(dry0, k));
    }
    WgResult *rs[] = {with, without, light, porous, porous0, covered, covered0, dry, dry0};
    for (size_t i = 0; i < sizeof rs / sizeof *rs; i++) wg_result_free(rs[i]);
    wg_image_unref(all);
    wg_image_unref(base);
    wg_image_unref(height);
    wg_graph_free(g);
}

/* wet_rain with streaks and beads in play: the same bits for 1, 2 and 3 threads, and its
 * streaks and puddles (the beads) seamless across the tile edges. */
static void test_wet_rain_threads_and_seams(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("wet_rain");
    WgImage *base = wgt_image_fn(W, H, 4, color_fn), *height = wgt_image_fn(W, H, 1, crate_fn);
    WgResult *res[3];
    for (int t = 0; t < 3; t++) {
        WgError err = {0};
        WgRequest *r = wg_request_new(g);
        if (wg_request_set_input_image(r, "basecolor", base, &err) ||
            wg_request_set_input_image(r, "height", height, &err) ||
            wg_request_set(r, "height_scale", "120", &err) ||
            wg_request_set(r, "water_level", "0.3", &err) || wg_request_set(r, "rain", "1", &err) ||
            wg_request_set(r, "porosity", "0.2", &err) || wg_request_set(r, "bead_size", "4", &err))
            fail_msg("%s", err.message);
        wg_request_set_time(r, 0.6);
        WgEngine *e = wgt_engine(t + 1, 0, NULL);
        res[t] = wgt_render_request(e, r);
        wg_engine_free(e);
        wg_request_free(r);
    }
    for (int t = 1; t < 3; t++)
        for (int k = 0; k < wg_result_output_count(res[0]); k++)
            wgt_assert_identical(wg_result_output_image(res[t], k), wg_result_output_image(res[0], k));
    static const char *const seamed[] = {"streaks", "puddles", "wet"};
    for (int i = 0; i < 3; i++) {
        const WgImage *f = wgt_output(res[1], seamed[i]);
        WgtSeams st = wgt_seams(f);
        double inner_c = st.inner_c, inner_r = st.inner_r, seam_c = st.seam_c, seam_r = st.seam_r;
        printf("wet_rain %s: seam steps %.4f / %.4f, inside %.4f / %.4f\n", seamed[i], seam_c,
               seam_r, inner_c, inner_r);
        assert_true(inner_c > 0.001);
        if (!(seam_c <= 3 * inner_c && seam_r <= 3 * inner_r))
            fail_msg("%s: seam steps %g / %g against %g / %g inside", seamed[i], seam_c, seam_r,
                     inner_c, inner_r);
    }
    for (int t = 0; t < 3; t++) wg_result_free(res[t]);
    wg_image_unref(base);
    wg_image_unref(height);
    wg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_only_where_water),  cmocka_unit_test(test_loop_closes),
        cmocka_unit_test(test_density_grows_with_rain), cmocka_unit_test(test_shelter),
        cmocka_unit_test(test_tiles_and_threads), cmocka_unit_test(test_wet_rain),
        cmocka_unit_test(test_streaks),
        cmocka_unit_test(test_beads),
        cmocka_unit_test(test_wet_rain_threads_and_seams),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
