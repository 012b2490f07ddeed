/* SPDX-License-Identifier: MIT */
/* graphs/create_masks.wetgraph: physical invariants of the wet zone masks on real height maps
 * (bricks102, 8-bit JPEG; wood_cabinet_worn_long, 16-bit PNG; both downscaled to 256x128, so
 * non-square) and synthetic ones: water_level 0 gives exactly empty masks and 1 all immersed;
 * the immersed part grows with the level and lies below it; water_height is the height with the
 * immersed part flattened at the level, in the input's units; wet and moist are empty far from
 * the water; slopes steeper than slope_limit are never wet; the zones partition every pixel;
 * every output is finite and in range for default and extreme parameters; an affine change of
 * the height (a map using part of 0..1) changes nothing; a cyclic shift of the inputs shifts the
 * outputs; renders at two resolutions agree up to filtering; the moist zone's reach follows the
 * porosity (the parameter and the map, pixel by pixel), and a porosity of 0 has no moist zone,
 * in the masks nor in the zones view. A `level` image: constant, it is water_level; tilted, it
 * floods the low side. The drying band: none below the water level, all wet at drying 0, dry
 * at drying 1, never wetter as drying grows, the film before the moisture, porous parts last,
 * the puddles shrinking to the deepest hollows; rain on the exposed surface: never drier with
 * more rain, film on the flat parts and none on steep walls, kept off by a shelter or the
 * ambient occlusion; tiling and thread-count invariance. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static WgGraph *graph;
static WgEngine *engine;
static WgImage *bricks, *wood; /* 256x128 */

typedef struct {
    WgImage *imm, *wet, *moist, *pud, *wh;
} Masks;

static const char *env(const char *name)
{
    const char *s = getenv(name);
    if (!s) fail_msg("%s is not set (run through meson test)", name);
    return s;
}

static WgImage *load_height(const char *rel, int w, int h)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/%s", env("WETGRAPH_SHARED"), rel);
    WgError err = {0};
    WgImage *img = NULL;
    if (wg_image_read(path, 1, WG_LINEAR, &img, &err)) fail_msg("%s: %s", path, err.message);
    WgImage *small = wg_image_convert(img, w, h, 1);
    assert_non_null(small);
    wg_image_unref(img);
    return small;
}

static int setup(void **state)
{
    (void)state;
    char path[2048];
    snprintf(path, sizeof path, "%s/graphs/create_masks.wetgraph", env("WETGRAPH_SOURCE"));
    WgError err = {0};
    if (wg_graph_load(path, &graph, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fprintf(stderr, "%s\n", buf);
        return -1;
    }
    engine = wgt_engine(2, 0, NULL);
    bricks =
        load_height("materials/bricks102_stonewall_1k/Bricks102_1K-JPG_Displacement.jpg", 256, 128);
    wood = load_height("materials/wood_cabinet_worn_long_1k/wood_cabinet_worn_long_disp_1k.png",
                       256, 128);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    wg_image_unref(bricks);
    wg_image_unref(wood);
    wg_engine_free(engine);
    wg_graph_free(graph);
    return 0;
}

/* Render the masks with the given images connected (names[i] <- images[i]) on an engine of
 * `threads` workers (2: the suite's own engine), with parameters "name=value ...". */
static Masks render_with(const char *const *names, const WgImage *const *images, int n,
                         const char *sets, int threads)
{
    WgError err = {0};
    WgRequest *r = wg_request_new(graph);
    assert_non_null(r);
    for (int i = 0; i < n; i++)
        if (wg_request_set_input_image(r, names[i], images[i], &err))
            fail_msg("%s: %s", names[i], err.message);
    char buf[1024];
    snprintf(buf, sizeof buf, "%s", sets ? sets : "");
    char *save = NULL;
    for (char *p = strtok_r(buf, " ", &save); p; p = strtok_r(NULL, " ", &save)) {
        char *eq = strchr(p, '=');
        assert_non_null(eq);
        *eq = 0;
        if (wg_request_set(r, p, eq + 1, &err)) fail_msg("%s=%s: %s", p, eq + 1, err.message);
    }
    const char *outs[] = {"immersed", "wet", "moist", "puddles", "water_height"};
    for (int i = 0; i < 5; i++)
        if (wg_request_add_output(r, outs[i], &err)) fail_msg("%s", err.message);
    WgEngine *e = threads == 2 ? engine : wgt_engine(threads, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    if (e != engine) wg_engine_free(e);
    Masks m = {
        wg_image_ref(wgt_output(res, "immersed")),     wg_image_ref(wgt_output(res, "wet")),
        wg_image_ref(wgt_output(res, "moist")),        wg_image_ref(wgt_output(res, "puddles")),
        wg_image_ref(wgt_output(res, "water_height")),
    };
    wg_result_free(res);
    wg_request_free(r);
    return m;
}

/* Render the masks of `height` (and `noise`, may be NULL) with parameters "name=value ...". */
static Masks render(const WgImage *height, const WgImage *noise, const char *sets)
{
    const char *const names[] = {"height", "noise"};
    const WgImage *const images[] = {height, noise};
    return render_with(names, images, noise ? 2 : 1, sets, 2);
}

static void masks_free(Masks *m)
{
    wg_image_unref(m->imm);
    wg_image_unref(m->wet);
    wg_image_unref(m->moist);
    wg_image_unref(m->pud);
    wg_image_unref(m->wh);
}

static float px(const WgImage *img, int x, int y)
{
    return wg_image_row(img, y)[x];
}

static void assert_all(const WgImage *img, float v, const char *what)
{
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            if (px(img, x, y) != v)
                fail_msg("%s at (%d, %d) is %.9g, expected %g", what, x, y, px(img, x, y), v);
}

static void range_of(const WgImage *img, double *lo, double *hi)
{
    *lo = INFINITY;
    *hi = -INFINITY;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            *lo = fmin(*lo, px(img, x, y));
            *hi = fmax(*hi, px(img, x, y));
        }
}

/* The height as the graph sees it: blurred by 0.75 length units (caller unrefs). */
static WgImage *smoothed(const WgImage *h)
{
    const char *names[] = {"source"};
    const WgImage *in[] = {h};
    return wgt_node("blur", "sigma=\"0.75\"", h->width, h->height, 1, names, in, 0, 1);
}

/* The range the graph measures: min and max of the smoothed height. */
static void smoothed_range(const WgImage *h, double *lo, double *hi)
{
    WgImage *sm = smoothed(h);
    range_of(sm, lo, hi);
    wg_image_unref(sm);
}

/* ---- synthetic height maps ---------------------------------------------------------------- */

#define PI 3.14159265358979323846

/* Rolling tileable hills, non-square. */
static double hills(int x, int y, int k)
{
    (void)k;
    double u = (x + 0.5) / 192, v = (y + 0.5) / 128;
    return 0.5 + 0.25 * sin(2 * PI * u) * cos(4 * PI * v) + 0.1 * sin(6 * PI * (u + v));
}

/* A cone: 0 at the centre of a 160x96 tile, rising with the distance on the torus. */
static double cone(int x, int y, int k)
{
    (void)k;
    double dx = fabs(x - 80.0), dy = fabs(y - 48.0);
    return sqrt(dx * dx + dy * dy) / 100;
}

/* Flat low ground at 0.1 with a mesa at 0.9 whose walls are vertical, gentle ripples on top. */
static double mesa(int x, int y, int k)
{
    (void)k;
    bool in = x >= 40 && x < 100 && y >= 30 && y < 90;
    return (in ? 0.9 : 0.1) + 0.02 * sin(2 * PI * x / 32.0) * sin(2 * PI * y / 32.0);
}

/* A smooth tileable noise image in [0, 1] for the `noise` input. */
static double wavy(int x, int y, int k)
{
    (void)k;
    double u = (x + 0.5) / 256, v = (y + 0.5) / 128;
    return 0.5 + 0.3 * sin(2 * PI * 3 * u + 1) * sin(2 * PI * 2 * v) + 0.2 * cos(2 * PI * 5 * u);
}

/* ---- tests -------------------------------------------------------------------------------- */

/* water_level 0: no water at all, even with the widest reach and the strongest noise. */
static void test_level_zero_is_dry(void **state)
{
    (void)state;
    WgImage *maps[] = {bricks, wood, wgt_image_fn(192, 128, 1, hills),
                       wgt_image_fn(160, 96, 1, mesa)};
    const char *params[] = {
        "water_level=0",
        "water_level=0 noise_intensity=1 wet_distance=128 moist_distance=128 wet_height=1 "
        "moist_height=1 puddle_density=1 edge_softness=1 slope_limit=1",
    };
    for (int i = 0; i < 4; i++)
        for (int p = 0; p < 2; p++) {
            Masks m = render(maps[i], NULL, params[p]);
            assert_all(m.imm, 0, "immersed");
            assert_all(m.wet, 0, "wet");
            assert_all(m.moist, 0, "moist");
            assert_all(m.pud, 0, "puddles");
            wgt_assert_identical(m.wh, maps[i]); /* nothing flattened */
            masks_free(&m);
        }
    wg_image_unref(maps[2]);
    wg_image_unref(maps[3]);
}

/* water_level 1: everything immersed, nothing wet or moist, a flat water surface above the
 * highest point. */
static void test_level_one_is_immersed(void **state)
{
    (void)state;
    WgImage *maps[] = {bricks, wood, wgt_image_fn(192, 128, 1, hills)};
    for (int i = 0; i < 3; i++) {
        Masks m = render(maps[i], NULL, "water_level=1 noise_intensity=1 edge_softness=0");
        assert_all(m.imm, 1, "immersed");
        assert_all(m.wet, 0, "wet");
        assert_all(m.moist, 0, "moist");
        assert_all(m.pud, 0, "puddles");
        double lo, hi, wlo, whi;
        smoothed_range(maps[i], &lo, &hi);
        range_of(m.wh, &wlo, &whi);
        assert_true(wlo == whi && fabs(wlo - (lo + (1 + 1.0 / 128) * (hi - lo))) <= 1e-6);
        masks_free(&m);
    }
    wg_image_unref(maps[2]);
}

/* The immersed mask grows with the level at every pixel; it lies below the water surface (the
 * smoothed height the graph measures, normalised by its range, is below the level);
 * water_height is the height in the input's units, flattened at the surface there. */
static void test_immersed_grows_and_lies_below(void **state)
{
    (void)state;
    WgImage *maps[] = {bricks, wood};
    for (int i = 0; i < 2; i++) {
        double lo, hi;
        WgImage *sm = smoothed(maps[i]);
        range_of(sm, &lo, &hi);
        WgImage *prev = NULL;
        double prev_area = 0;
        for (int k = 0; k <= 10; k++) {
            double wl = k / 10.0;
            char sets[64];
            snprintf(sets, sizeof sets, "water_level=%g", wl);
            Masks m = render(maps[i], NULL, sets);
            /* the water surface: water_level of the range plus 1/128, in the input's units */
            double lw = wl * (1 + 1.0 / 128), level = lo + lw * (hi - lo), tol = 1e-6;
            double area = 0;
            int full = 0;
            for (int y = 0; y < m.imm->height; y++)
                for (int x = 0; x < m.imm->width; x++) {
                    double a = px(m.imm, x, y), h = px(maps[i], x, y), w = px(m.wh, x, y);
                    double hn = (px(sm, x, y) - lo) / (hi - lo);
                    area += a;
                    if (prev && a < px(prev, x, y))
                        fail_msg("level %g: immersed shrank at (%d, %d)", wl, x, y);
                    if (a > 0 && !(hn < lw + tol))
                        fail_msg("level %g: immersed %g at (%d, %d) above the water (%g >= %g)", wl,
                                 a, x, y, hn, lw);
                    if (a == 0 && w != (float)h)
                        fail_msg("level %g: dry water_height %g != height %g", wl, w, h);
                    if (a > 0 && !(w >= fmin(h, level) - tol && w <= fmax(h, level) + tol))
                        fail_msg("level %g: water_height %g not between %g and %g", wl, w, h,
                                 level);
                    if (a == 1) {
                        if (!(fabs(w - level) <= tol))
                            fail_msg("level %g: flattened water_height %.9g, level %.9g", wl, w,
                                     level);
                        full++;
                    }
                }
            assert_true(area >= prev_area);
            if (k == 7) assert_true(full > 0); /* the test does see water */
            prev_area = area;
            wg_image_unref(prev);
            prev = wg_image_ref(m.imm);
            masks_free(&m);
        }
        wg_image_unref(prev);
        wg_image_unref(sm);
    }
}

/* Distance in length units (pixels of a 256-wide image) from every pixel to the nearest
 * immersed (>= 0.5) pixel on the torus, from the exact distance node (tested on its own). */
static double *length_to_water(const WgImage *imm)
{
    int w = imm->width, h = imm->height;
    const char *names[] = {"mask"};
    const WgImage *in[] = {imm};
    WgImage *dist = wgt_node("distance", "mode=\"pixels\"", w, h, 1, names, in, 0, 1);
    double *d = malloc(sizeof(double) * (size_t)w * h);
    assert_non_null(d);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) d[(size_t)y * w + x] = px(dist, x, y) * 256.0 / w;
    wg_image_unref(dist);
    return d;
}

/* Beyond twice their reach from the immersed edge (the noise at full intensity can at most
 * double the reach; a margin of 10% covers rounding), wet, moist and puddles are exactly 0; and
 * the test does see wet and moist pixels closer in. */
static void test_dry_far_from_water(void **state)
{
    (void)state;
    WgImage *c = wgt_image_fn(160, 96, 1, cone);
    WgImage *n = wgt_image_fn(160, 96, 1, wavy);
    const char *sets[] = {
        "water_level=0.15 wet_distance=4 moist_distance=12 wet_height=1 moist_height=1 "
        "noise_intensity=1",
        "water_level=0.15 wet_distance=10 moist_distance=20 wet_height=1 moist_height=1 "
        "puddle_density=1 noise_intensity=1",
    };
    for (int s = 0; s < 2; s++)
        for (int with_noise = 0; with_noise < 2; with_noise++) {
            Masks m = render(c, with_noise ? n : NULL, sets[s]);
            double *d = length_to_water(m.imm);
            double wet_reach = s ? 10 : 4, moist_reach = s ? 20 : 12;
            int near_wet = 0, near_moist = 0;
            for (int y = 0; y < 96; y++)
                for (int x = 0; x < 160; x++) {
                    double dl = d[y * 160 + x];
                    if (dl >= 2.2 * wet_reach && (px(m.wet, x, y) != 0 || px(m.pud, x, y) != 0))
                        fail_msg("wet %g at (%d, %d), %g from the water", px(m.wet, x, y), x, y,
                                 dl);
                    if (dl >= 2.2 * moist_reach && px(m.moist, x, y) != 0)
                        fail_msg("moist %g at (%d, %d), %g from the water", px(m.moist, x, y), x, y,
                                 dl);
                    near_wet += dl > 0 && dl < wet_reach / 2 && px(m.wet, x, y) > 0.5f;
                    near_moist += dl > wet_reach && dl < moist_reach && px(m.moist, x, y) > 0.2f;
                }
            assert_true(near_wet > 0);
            assert_true(near_moist > 0);
            free(d);
            masks_free(&m);
        }
    wg_image_unref(c);
    wg_image_unref(n);
}

/* Puddles lie in hollows (the smoothed, normalised height below its blur over puddle_size),
 * within wet_distance of the water, and get fewer with the distance: the share of puddle pixels
 * in the nearest third of that band is larger than in the farthest third. */
static void test_puddles_in_hollows_near_water(void **state)
{
    (void)state;
    const char *names[] = {"source"};
    const WgImage *in[] = {bricks};
    WgImage *sm = wgt_node("blur", "sigma=\"0.75\"", 256, 128, 1, names, in, 0, 1);
    in[0] = sm;
    WgImage *sn = wgt_node("auto_levels", "", 256, 128, 1, names, in, 0, 1);
    in[0] = sn;
    WgImage *hb = wgt_node("blur", "sigma=\"4\"", 256, 128, 1, names, in, 0, 1);
    const char *levels[] = {"water_level=0.6 puddle_density=1 wet_distance=12",
                            "water_level=0.65 puddle_density=0.6 wet_distance=12"};
    for (int l = 0; l < 2; l++) {
        Masks m = render(bricks, NULL, levels[l]);
        double *d = length_to_water(m.imm);
        double count[3] = {0, 0, 0}, area[3] = {0, 0, 0};
        for (int y = 0; y < 128; y++)
            for (int x = 0; x < 256; x++) {
                double p = px(m.pud, x, y), dl = d[y * 256 + x];
                if (p > 0 && !(px(hb, x, y) > px(sn, x, y)))
                    fail_msg("%s: puddle %g at (%d, %d) is not in a hollow", levels[l], p, x, y);
                if (p > 0 && !(dl < 12))
                    fail_msg("%s: puddle %g at (%d, %d), %g from the water", levels[l], p, x, y,
                             dl);
                if (dl > 0 && dl < 12) {
                    int band = (int)(dl / 4);
                    count[band] += p;
                    area[band] += 1;
                }
            }
        Masks none = render(bricks, NULL,
                            l ? "water_level=0.65 puddle_density=0 wet_distance=12"
                              : "water_level=0.6 puddle_density=0 wet_distance=12");
        assert_all(none.pud, 0, "puddles at density 0");
        masks_free(&none);
        printf("%s: puddle share by distance %.4f %.4f %.4f\n", levels[l], count[0] / area[0],
               count[1] / area[1], count[2] / area[2]);
        assert_true(count[0] > 0);
        assert_true(count[0] / area[0] > count[2] / area[2]);
        free(d);
        masks_free(&m);
    }
    wg_image_unref(sm);
    wg_image_unref(sn);
    wg_image_unref(hb);
}

/* Slope of the graph's smoothed, normalised height, computed with the nodes the graph uses
 * (auto_levels normalises as the graph's pixel expression does, within float rounding). */
static WgImage *reference_slope(const WgImage *h, double intensity)
{
    const char *names[] = {"source"};
    const WgImage *in[] = {h};
    WgImage *sm = wgt_node("blur", "sigma=\"0.75\"", h->width, h->height, 1, names, in, 0, 1);
    in[0] = sm;
    WgImage *sn = wgt_node("auto_levels", "", h->width, h->height, 1, names, in, 0, 1);
    const char *hnames[] = {"height"};
    in[0] = sn;
    char attrs[128];
    snprintf(attrs, sizeof attrs, "intensity=\"%g\" method=\"sobel\"", intensity);
    WgImage *sl = wgt_node("slope", attrs, h->width, h->height, 1, hnames, in, 0, 1);
    wg_image_unref(sn);
    wg_image_unref(sm);
    return sl;
}

/* A wide cone on a 256x256 tile: 0 at the centre. */
static double wide_cone(int x, int y, int k)
{
    (void)k;
    double dx = fabs(x - 128.0), dy = fabs(y - 128.0);
    return sqrt(dx * dx + dy * dy) / 180;
}

/* Transitions are gradients, not steps: on a smooth slope, away from the waterline, wet and
 * moist change by less than half their range between neighbouring pixels and take many
 * values in between; with edge_softness 0 the wet edge is a step (so the test can tell). */
static void test_soft_transitions(void **state)
{
    (void)state;
    WgImage *c = wgt_image_fn(256, 256, 1, wide_cone);
    for (int hard = 0; hard < 2; hard++) {
        Masks m = render(c, NULL,
                         hard ? "water_level=0.3 noise_intensity=0 edge_softness=0 wet_height=1"
                              : "water_level=0.3 noise_intensity=0 wet_height=1");
        double jump[2] = {0, 0};
        int between[2] = {0, 0};
        const WgImage *img[2] = {m.wet, m.moist};
        for (int k = 0; k < 2; k++)
            for (int y = 0; y < 256; y++)
                for (int x = 0; x < 256; x++) {
                    float v = px(img[k], x, y);
                    between[k] += v > 0.05f && v < 0.95f;
                    int x1 = (x + 1) % 256;
                    if (px(m.imm, x, y) != 0 || px(m.imm, x1, y) != 0) continue;
                    jump[k] = fmax(jump[k], fabs((double)px(img[k], x1, y) - v));
                }
        printf("edge_softness %s: largest step wet %.3f, moist %.3f; pixels between 0.05 and "
               "0.95: wet %d, moist %d\n",
               hard ? "0" : "default", jump[0], jump[1], between[0], between[1]);
        if (!hard) {
            assert_true(jump[0] < 0.5 && jump[1] < 0.5);
            assert_true(between[0] > 500 && between[1] > 500);
        } else {
            assert_true(jump[0] > 0.9);
        }
        masks_free(&m);
    }
    wg_image_unref(c);
}

/* Walls steeper than slope_limit + slope_softness / 2 are never wet, although they are next to
 * the water: with the limit at 1 the same pixels are wet. */
static void test_steep_walls_stay_dry(void **state)
{
    (void)state;
    WgImage *m2 = wgt_image_fn(160, 96, 1, mesa);
    WgImage *maps[] = {bricks, m2};
    const char *levels[] = {"water_level=0.62", "water_level=0.3"};
    for (int i = 0; i < 2; i++) {
        WgImage *sl = reference_slope(maps[i], 16);
        char sets[256];
        snprintf(sets, sizeof sets, "%s wet_height=0.9 wet_distance=8", levels[i]);
        Masks m = render(maps[i], NULL, sets);
        snprintf(sets, sizeof sets,
                 "%s wet_height=0.9 wet_distance=8 slope_limit=1 "
                 "slope_softness=0",
                 levels[i]);
        Masks all = render(maps[i], NULL, sets);
        float limit = 0.5f + 0.15f * 0.5f + 1e-4f; /* margin for the normalisation's rounding */
        int steep = 0, steep_wet_without_limit = 0;
        for (int y = 0; y < sl->height; y++)
            for (int x = 0; x < sl->width; x++) {
                if (!(px(sl, x, y) >= limit)) continue;
                steep++;
                if (px(m.wet, x, y) != 0 || px(m.pud, x, y) != 0)
                    fail_msg("steep pixel (%d, %d), slope %g, is wet (%g)", x, y, px(sl, x, y),
                             px(m.wet, x, y));
                steep_wet_without_limit += px(all.wet, x, y) > 0.1f;
            }
        printf("map %d: %d steep pixels, %d of them wet without the slope limit\n", i, steep,
               steep_wet_without_limit);
        assert_true(steep_wet_without_limit > 20);
        masks_free(&m);
        masks_free(&all);
        wg_image_unref(sl);
    }
    wg_image_unref(m2);
}

static void check_masks(const Masks *m, const char *what)
{
    wgt_assert_range(m->imm, 0, 1);
    wgt_assert_range(m->wet, 0, 1);
    wgt_assert_range(m->moist, 0, 1);
    wgt_assert_range(m->pud, 0, 1);
    wgt_assert_range(m->wh, -1e30, 1e30);
    for (int y = 0; y < m->imm->height; y++)
        for (int x = 0; x < m->imm->width; x++) {
            double s = (double)px(m->imm, x, y) + px(m->wet, x, y) + px(m->moist, x, y);
            if (!(s <= 1 + 1e-6)) fail_msg("%s: zones sum to %.9g at (%d, %d)", what, s, x, y);
            if (!(px(m->pud, x, y) <= px(m->wet, x, y) + 1e-6))
                fail_msg("%s: puddle %g outside the wet zone (%g) at (%d, %d)", what,
                         px(m->pud, x, y), px(m->wet, x, y), x, y);
        }
}

/* Zones partition the surface, every output is finite and in range, for default, smallest and
 * largest parameters, with and without a noise input. */
static void test_partition_and_ranges(void **state)
{
    (void)state;
    WgImage *n = wgt_image_fn(256, 128, 1, wavy);
    WgImage *maps[] = {bricks, wood, wgt_image_fn(192, 128, 1, hills),
                       wgt_image_fn(160, 96, 1, mesa)};
    const char *params[] = {
        "",
        "wet_height=0.001 wet_distance=0.01 moist_height=0.001 moist_distance=0.01 "
        "noise_intensity=0 slope_limit=0 slope_softness=0 height_scale=0.001 puddle_density=0 "
        "puddle_size=0.1 edge_softness=0",
        "wet_height=1 wet_distance=128 moist_height=1 moist_distance=128 noise_intensity=1 "
        "slope_limit=1 slope_softness=1 height_scale=4096 puddle_density=1 puddle_size=64 "
        "edge_softness=1",
        "wet_height=0.5 moist_height=0.05 wet_distance=30 moist_distance=3",
    };
    const char *levels[] = {"0.2", "0.5", "0.8"};
    for (int i = 0; i < 4; i++)
        for (int p = 0; p < 4; p++)
            for (int l = 0; l < 3; l++) {
                char sets[512];
                snprintf(sets, sizeof sets, "water_level=%s %s", levels[l], params[p]);
                for (int with_noise = 0; with_noise < 2; with_noise++) {
                    Masks m = render(maps[i], with_noise ? n : NULL, sets);
                    check_masks(&m, sets);
                    masks_free(&m);
                }
            }
    wg_image_unref(maps[2]);
    wg_image_unref(maps[3]);
    wg_image_unref(n);
}

/* Hard cases: a flat map (no range: the height counts as the middle of the range), one pixel,
 * a 3x2 map, a single spike on flat ground; levels 0 and 1 stay exact and every output is
 * finite and partitions. */
static void test_hard_cases(void **state)
{
    (void)state;
    float flat_v[16 * 8], tiny_v[6] = {0.1f, 0.9f, 0.4f, 0.4f, 0.2f, 0.7f}, one_v = 0.3f;
    for (int i = 0; i < 16 * 8; i++) flat_v[i] = 0.25f;
    WgImage *flat = wgt_image(16, 8, 1, flat_v), *tiny = wgt_image(3, 2, 1, tiny_v);
    WgImage *one = wgt_image(1, 1, 1, &one_v);
    WgImage *spike = wgt_image(64, 32, 1, NULL);
    wg_image_row(spike, 10)[20] = 5;
    WgImage *maps[] = {flat, tiny, one, spike};
    const char *levels[] = {"0", "0.3", "0.6", "1"};
    for (int i = 0; i < 4; i++)
        for (int l = 0; l < 4; l++) {
            char sets[128];
            snprintf(sets, sizeof sets, "water_level=%s noise_intensity=1 puddle_density=1",
                     levels[l]);
            Masks m = render(maps[i], NULL, sets);
            check_masks(&m, sets);
            if (l == 0) assert_all(m.imm, 0, "immersed");
            if (l == 0) assert_all(m.wet, 0, "wet");
            if (l == 0) assert_all(m.moist, 0, "moist");
            if (l == 3) assert_all(m.imm, 1, "immersed");
            if (i == 0) /* flat: all or nothing, around the middle of the range */
                assert_all(m.imm, l >= 2 ? 1.0f : 0.0f, "immersed (flat)");
            masks_free(&m);
        }
    for (int i = 0; i < 4; i++) wg_image_unref(maps[i]);
}

/* The zones view is an opaque colour image in [0, 1]. */
static void test_zones_view(void **state)
{
    (void)state;
    WgError err = {0};
    WgRequest *r = wg_request_new(graph);
    if (wg_request_set_input_image(r, "height", bricks, &err)) fail_msg("%s", err.message);
    if (wg_request_set(r, "water_level", "0.6", &err)) fail_msg("%s", err.message);
    if (wg_request_add_output(r, "zones", &err)) fail_msg("%s", err.message);
    WgResult *res = wgt_render_request(engine, r);
    const WgImage *z = wgt_output(res, "zones");
    assert_int_equal(z->channels, 4);
    wgt_assert_range(z, 0, 1);
    for (int y = 0; y < z->height; y++)
        for (int x = 0; x < z->width; x++) assert_true(wg_image_row(z, y)[4 * x + 3] == 1.0f);
    wg_result_free(res);
    wg_request_free(r);
}

/* A map using only part of 0..1 (the 16-bit wood map squeezed into [0.3, 0.45]) gives the same
 * masks as the full map, and its water_height is the same affine map of the full one. The
 * 16-bit precision is used: levels 0.0005 apart immerse different areas. */
static void test_partial_range_and_16_bit(void **state)
{
    (void)state;
    WgImage *squeezed = wg_image_new(wood->width, wood->height, 1);
    for (int y = 0; y < wood->height; y++)
        for (int x = 0; x < wood->width; x++)
            wg_image_row(squeezed, y)[x] = 0.3f + 0.15f * px(wood, x, y);
    double lo, hi;
    range_of(wood, &lo, &hi);
    for (int l = 1; l < 10; l += 2) {
        char sets[64];
        snprintf(sets, sizeof sets, "water_level=%g", l / 10.0);
        Masks a = render(wood, NULL, sets), b = render(squeezed, NULL, sets);
        const WgImage *ma[] = {a.imm, a.wet, a.moist, a.pud},
                      *mb[] = {b.imm, b.wet, b.moist, b.pud};
        for (int k = 0; k < 4; k++) {
            double sum = 0;
            for (int y = 0; y < wood->height; y++)
                for (int x = 0; x < wood->width; x++)
                    sum += fabs((double)px(ma[k], x, y) - px(mb[k], x, y));
            double mean = sum / (wood->width * wood->height);
            if (!(mean <= 1e-4)) fail_msg("%s mask %d: mean difference %g", sets, k, mean);
        }
        for (int y = 0; y < wood->height; y++)
            for (int x = 0; x < wood->width; x++) {
                double want = 0.3 + 0.15 * px(a.wh, x, y);
                if (!(fabs(px(b.wh, x, y) - want) <= 1e-4 * 0.15 * (hi - lo)))
                    fail_msg("%s: water_height %g, expected %g", sets, px(b.wh, x, y), want);
            }
        masks_free(&a);
        masks_free(&b);
    }
    double area[2] = {0, 0};
    for (int k = 0; k < 2; k++) {
        Masks m = render(wood, NULL, k ? "water_level=0.6005" : "water_level=0.6");
        for (int y = 0; y < wood->height; y++)
            for (int x = 0; x < wood->width; x++) area[k] += px(m.imm, x, y);
        masks_free(&m);
    }
    assert_true(area[1] > area[0]);
    wg_image_unref(squeezed);
}

static WgImage *roll(const WgImage *img, int dx, int dy)
{
    WgImage *out = wg_image_new(img->width, img->height, 1);
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++)
            wg_image_row(out, (y + dy) % img->height)[(x + dx) % img->width] = px(img, x, y);
    return out;
}

/* Shifting the height and the noise cyclically shifts every output (up to the rounding of the
 * FFT blur). */
static void test_tiling(void **state)
{
    (void)state;
    WgImage *n = wgt_image_fn(256, 128, 1, wavy);
    WgImage *hs = roll(bricks, 77, 35), *ns = roll(n, 77, 35);
    const char *levels[] = {"water_level=0.55", "water_level=0.7 puddle_density=1"};
    for (int l = 0; l < 2; l++) {
        Masks a = render(bricks, n, levels[l]), b = render(hs, ns, levels[l]);
        const WgImage *ma[] = {a.imm, a.wet, a.moist, a.pud, a.wh};
        const WgImage *mb[] = {b.imm, b.wet, b.moist, b.pud, b.wh};
        for (int k = 0; k < 5; k++) {
            WgImage *r = roll(ma[k], 77, 35);
            double d = wgt_max_abs_diff(r, mb[k]);
            printf("%s output %d: max difference after the shift %.3g\n", levels[l], k, d);
            if (!(d <= 2e-3)) fail_msg("%s output %d differs by %g after a shift", levels[l], k, d);
            wg_image_unref(r);
        }
        masks_free(&a);
        masks_free(&b);
    }
    wg_image_unref(n);
    wg_image_unref(hs);
    wg_image_unref(ns);
}

/* Resolution independence: bricks102 at its own 1024x512 and upsampled to 2048x1024 give the
 * same masks up to filtering: both renders shrunk to 256x128 (which averages away the
 * one-pixel differences along the zone edges) agree. */
static void test_resolution_independence(void **state)
{
    (void)state;
    char path[2048];
    snprintf(path, sizeof path, "%s/%s", env("WETGRAPH_SHARED"),
             "materials/bricks102_stonewall_1k/Bricks102_1K-JPG_Displacement.jpg");
    WgError err = {0};
    WgImage *one = NULL;
    if (wg_image_read(path, 1, WG_LINEAR, &one, &err)) fail_msg("%s: %s", path, err.message);
    assert_int_equal(one->width, 1024);
    WgImage *two = wg_image_convert(one, 2048, 1024, 1);
    const char *levels[] = {"water_level=0.55", "water_level=0.7", "water_level=0.8"};
    for (int l = 0; l < 3; l++) {
        Masks a = render(one, NULL, levels[l]), b = render(two, NULL, levels[l]);
        const WgImage *ma[] = {a.imm, a.wet, a.moist, a.pud};
        const WgImage *mb[] = {b.imm, b.wet, b.moist, b.pud};
        for (int k = 0; k < 4; k++) {
            WgImage *sa = wg_image_convert(ma[k], 256, 128, 1);
            WgImage *sb = wg_image_convert(mb[k], 256, 128, 1);
            double sum = 0, ref = 0, worst = 0;
            for (int y = 0; y < 128; y++)
                for (int x = 0; x < 256; x++) {
                    double d = fabs((double)px(sa, x, y) - px(sb, x, y));
                    sum += d;
                    ref += px(sa, x, y);
                    worst = fmax(worst, d);
                }
            double mean = sum / (256 * 128);
            printf("%s mask %d: mean |1K - 2K| %.4f (mean value %.4f), max %.3f\n", levels[l], k,
                   mean, ref / (256 * 128), worst);
            /* puddles are small, with a sharp depth threshold: a few pixels differ more */
            if (!(mean <= 0.01 && worst <= (k == 3 ? 0.5 : 0.25)))
                fail_msg("%s mask %d: mean difference %g, max %g", levels[l], k, mean, worst);
            wg_image_unref(sa);
            wg_image_unref(sb);
        }
        masks_free(&a);
        masks_free(&b);
    }
    wg_image_unref(one);
    wg_image_unref(two);
}

/* The optional noise input: a constant 0.5 moves nothing (the same zones as noise_intensity 0),
 * and another noise image moves the wet edge. */
/* Sum of a mask's values over the pixels where keep(x) holds (all pixels when keep is NULL). */
static double mask_sum(const WgImage *m, bool (*keep)(int x))
{
    double s = 0;
    for (int y = 0; y < m->height; y++)
        for (int x = 0; x < m->width; x++)
            if (!keep || keep(x)) s += px(m, x, y);
    return s;
}
static bool left_half(int x)
{
    return x < 128;
}
static bool right_half(int x)
{
    return x >= 128;
}
/* Porosity 1 on the left half of a 256-wide map, 0 on the right. */
static double half_porous(int x, int y, int k)
{
    (void)y;
    (void)k;
    return x < 128 ? 1 : 0;
}

/* Capillary rise needs pores: porosity 0 gives no moist zone at all (and no blue in the zones
 * view) while the wet film stays; a lower porosity shortens the moist reach; a porosity map
 * moves it pixel by pixel. */
static void test_moist_follows_porosity(void **state)
{
    (void)state;
    WgImage *maps[] = {bricks, wood};
    for (int i = 0; i < 2; i++) {
        Masks full = render(maps[i], NULL, "water_level=0.55");
        Masks half = render(maps[i], NULL, "water_level=0.55 porosity=0.5");
        Masks none = render(maps[i], NULL, "water_level=0.55 porosity=0");
        double mf = mask_sum(full.moist, NULL), mh = mask_sum(half.moist, NULL);
        assert_true(mf > 200);
        assert_true(mh > 0.05 * mf && mh < 0.8 * mf);
        assert_all(none.moist, 0, "moist at porosity 0");
        /* the film does not depend on the pores */
        wgt_assert_near(none.wet, full.wet, 1e-6);
        wgt_assert_near(none.imm, full.imm, 0);

        WgError err = {0};
        WgRequest *r = wg_request_new(graph);
        WgImage *pm = wgt_image_fn(256, 128, 1, half_porous);
        if (wg_request_set_input_image(r, "height", maps[i], &err) ||
            wg_request_set_input_image(r, "porosity_map", pm, &err) ||
            wg_request_set(r, "water_level", "0.55", &err))
            fail_msg("%s", err.message);
        WgResult *res = wgt_render_request(engine, r);
        const WgImage *moist = wgt_output(res, "moist");
        /* where the map is 0 nothing is moist; where it is 1 the moist zone is as without it */
        assert_true(mask_sum(moist, right_half) == 0);
        assert_true(fabs(mask_sum(moist, left_half) - mask_sum(full.moist, left_half)) < 1e-3);
        assert_true(mask_sum(full.moist, right_half) > 50);
        wg_result_free(res);
        wg_request_free(r);

        /* the zones view of a non-porous material shows no moist (blue) zone */
        r = wg_request_new(graph);
        if (wg_request_set_input_image(r, "height", maps[i], &err) ||
            wg_request_set(r, "water_level", "0.55", &err) ||
            wg_request_set(r, "porosity", "0", &err) || wg_request_add_output(r, "zones", &err))
            fail_msg("%s", err.message);
        res = wgt_render_request(engine, r);
        const WgImage *z = wgt_output(res, "zones");
        for (int y = 0; y < z->height; y++)
            for (int x = 0; x < z->width; x++) {
                const float *p = wg_image_row(z, y) + 4 * x;
                if (p[2] > fminf(p[0], p[1]) + 1e-6)
                    fail_msg("zones view at (%d, %d) is blue (%g %g %g) at porosity 0", x, y, p[0],
                             p[1], p[2]);
            }
        wg_result_free(res);
        wg_request_free(r);
        wg_image_unref(pm);
        masks_free(&full);
        masks_free(&half);
        masks_free(&none);
    }
}

static void test_noise_input(void **state)
{
    (void)state;
    float half = 0.5f;
    WgImage *flat = wgt_image(1, 1, 1, &half);
    WgImage *n = wgt_image_fn(256, 128, 1, wavy);
    Masks a = render(bricks, flat, "water_level=0.65");
    Masks b = render(bricks, NULL, "water_level=0.65 noise_intensity=0");
    Masks c = render(bricks, n, "water_level=0.65");
    Masks d = render(bricks, NULL, "water_level=0.65");
    wgt_assert_identical(a.imm, b.imm);
    wgt_assert_identical(a.wet, b.wet);
    wgt_assert_identical(a.moist, b.moist);
    assert_true(wgt_max_abs_diff(c.wet, d.wet) > 0.1);
    masks_free(&a);
    masks_free(&b);
    masks_free(&c);
    masks_free(&d);
    wg_image_unref(flat);
    wg_image_unref(n);
}

/* ---- a painted water level ----------------------------------------------------------------- */

static void assert_masks_identical(const Masks *a, const Masks *b)
{
    wgt_assert_identical(a->imm, b->imm);
    wgt_assert_identical(a->wet, b->wet);
    wgt_assert_identical(a->moist, b->moist);
    wgt_assert_identical(a->pud, b->pud);
    wgt_assert_identical(a->wh, b->wh);
}

/* A water plane tilted along x: level 0.2 on the left edge to 0.8 on the right. */
static double tilted(int x, int y, int k)
{
    (void)y;
    (void)k;
    return 0.2 + 0.6 * (x + 0.5) / 256;
}

/* A constant `level` image is the constant water_level (bit for bit where the level is a float
 * exactly, within float rounding otherwise); a level of 0 everywhere is dry even with the
 * widest reach; a tilted level floods the low side, every immersed pixel lies below its own
 * level and water_height is flattened at it. */
static void test_level_image(void **state)
{
    (void)state;
    const char *name[] = {"height", "level"};
    float v = 0.625f, v6 = 0.6f, zero = 0;
    WgImage *c = wgt_image(1, 1, 1, &v), *c6 = wgt_image(1, 1, 1, &v6),
            *z = wgt_image(1, 1, 1, &zero);
    WgImage *maps[] = {bricks, wood};
    for (int i = 0; i < 2; i++) {
        const WgImage *in[] = {maps[i], c};
        Masks a = render_with(name, in, 2, "", 2);
        Masks b = render(maps[i], NULL, "water_level=0.625");
        assert_true(mask_sum(b.imm, NULL) > 100 && mask_sum(b.wet, NULL) > 100);
        assert_masks_identical(&a, &b);
        masks_free(&a);
        masks_free(&b);
        const WgImage *in6[] = {maps[i], c6};
        a = render_with(name, in6, 2, "water_level=0.1", 2);
        b = render(maps[i], NULL, "water_level=0.6");
        wgt_assert_near(a.imm, b.imm, 1e-4);
        wgt_assert_near(a.wet, b.wet, 1e-4);
        wgt_assert_near(a.moist, b.moist, 1e-4);
        wgt_assert_near(a.pud, b.pud, 1e-4);
        masks_free(&a);
        masks_free(&b);
        const WgImage *inz[] = {maps[i], z};
        a = render_with(name, inz, 2,
                        "water_level=0.7 noise_intensity=1 wet_distance=128 moist_distance=128 "
                        "wet_height=1 moist_height=1 puddle_density=1 edge_softness=1",
                        2);
        assert_all(a.imm, 0, "immersed at level 0");
        assert_all(a.wet, 0, "wet at level 0");
        assert_all(a.moist, 0, "moist at level 0");
        assert_all(a.pud, 0, "puddles at level 0");
        masks_free(&a);
    }

    /* the tilted plane on the bricks */
    WgImage *t = wgt_image_fn(256, 128, 1, tilted);
    const WgImage *in[] = {bricks, t};
    Masks m = render_with(name, in, 2, "", 2);
    double lo, hi;
    WgImage *sm = smoothed(bricks);
    range_of(sm, &lo, &hi);
    double left = 0, right = 0;
    for (int y = 0; y < 128; y++)
        for (int x = 0; x < 256; x++) {
            double a = px(m.imm, x, y), hn = (px(sm, x, y) - lo) / (hi - lo);
            double lw = px(t, x, y) * (1 + 1.0 / 128), level = lo + lw * (hi - lo);
            if (x < 64) left += a;
            if (x >= 192) right += a;
            if (a > 0 && !(hn < lw + 1e-6))
                fail_msg("immersed %g at (%d, %d) above its level (%g >= %g)", a, x, y, hn, lw);
            if (a == 1 && !(fabs(px(m.wh, x, y) - level) <= 1e-5))
                fail_msg("water_height %g at (%d, %d), its level %g", px(m.wh, x, y), x, y, level);
        }
    printf("tilted level: immersed %.0f px in the left quarter, %.0f in the right\n", left, right);
    assert_true(right > 0.4 * 64 * 128 && left < 0.02 * 64 * 128);
    /* the same at one and three threads */
    Masks m1 = render_with(name, in, 2, "", 1), m3 = render_with(name, in, 2, "", 3);
    assert_masks_identical(&m, &m1);
    assert_masks_identical(&m, &m3);
    masks_free(&m);
    masks_free(&m1);
    masks_free(&m3);
    wg_image_unref(sm);
    wg_image_unref(t);
    wg_image_unref(c);
    wg_image_unref(c6);
    wg_image_unref(z);
}

/* ---- drying after the water dropped -------------------------------------------------------- */

#define DRY_SETS "water_level=0.45 high_water=0.75"

/* The drying band: a high_water at or below the water level changes nothing, whatever the
 * drying; drying 1 leaves the band dry (the masks of no band at all, bit for bit); drying 0
 * keeps wet everything the high water wetted (what was immersed at high_water and is out of
 * the water is covered by the film, and the undrained masks' wet and moist area is still wet
 * or moist), with puddles in the band's hollows; as drying grows no pixel gets wetter, the
 * film goes first and the moisture lasts longest where the material is porous; the puddles
 * shrink to the deepest hollows. */
static void test_drying(void **state)
{
    (void)state;
    WgImage *maps[] = {bricks, wood};
    for (int i = 0; i < 2; i++) {
        const WgImage *hm = maps[i];
        Masks none = render(hm, NULL, "water_level=0.45");
        Masks below = render(hm, NULL, "water_level=0.45 high_water=0.3 drying=0.5");
        Masks dry = render(hm, NULL, DRY_SETS " drying=1");
        assert_masks_identical(&none, &below);
        assert_masks_identical(&none, &dry);
        masks_free(&below);
        masks_free(&dry);

        /* drying 0 against the undrained masks (the water still at high_water) */
        Masks high = render(hm, NULL, "water_level=0.75");
        Masks d0 = render(hm, NULL, DRY_SETS " drying=0");
        double band = 0, band_pud = 0;
        for (int y = 0; y < 128; y++)
            for (int x = 0; x < 256; x++) {
                double wa = px(d0.imm, x, y) + px(d0.wet, x, y), ma = wa + px(d0.moist, x, y);
                double wh = px(high.imm, x, y) + px(high.wet, x, y),
                       mh = wh + px(high.moist, x, y);
                if (!(wa >= wh - 1e-6 && ma >= mh - 1e-6))
                    fail_msg("drying 0 at (%d, %d): wet %g, moist %g below the undrained %g, %g", x,
                             y, wa, ma, wh, mh);
                if (px(high.imm, x, y) == 1 && px(none.imm, x, y) == 0) {
                    if (px(d0.wet, x, y) != 1)
                        fail_msg("drained pixel (%d, %d) has wet %g at drying 0", x, y,
                                 px(d0.wet, x, y));
                    band++;
                    band_pud += px(d0.pud, x, y);
                }
            }
        assert_true(band > 2000);
        assert_true(band_pud > 0.05 * band);
        /* the immersed part and the water surface are the current water's */
        wgt_assert_identical(d0.imm, none.imm);
        wgt_assert_identical(d0.wh, none.wh);

        /* as drying grows: no pixel gets wetter, the film goes before the moisture */
        static const double steps[] = {0, 0.2, 0.4, 0.6, 0.8, 1};
        Masks prev = d0;
        double wet_sum[6], moist_sum[6], pud_sum[6];
        for (int k = 0; k < 6; k++) {
            char sets[128];
            snprintf(sets, sizeof sets, DRY_SETS " drying=%g", steps[k]);
            Masks m = k ? render(hm, NULL, sets) : d0;
            for (int y = 0; y < 128; y++)
                for (int x = 0; x < 256; x++) {
                    double damp = px(m.wet, x, y) + px(m.moist, x, y),
                           pdamp = px(prev.wet, x, y) + px(prev.moist, x, y);
                    if (!(px(m.wet, x, y) <= px(prev.wet, x, y) + 1e-6 && damp <= pdamp + 1e-6 &&
                          px(m.pud, x, y) <= px(prev.pud, x, y) + 1e-6))
                        fail_msg("drying %g at (%d, %d): wetter than at %g", steps[k], x, y,
                                 steps[k - 1]);
                    if (!(px(m.wet, x, y) + px(m.moist, x, y) + px(m.imm, x, y) <= 1 + 1e-6 &&
                          px(m.pud, x, y) <= px(m.wet, x, y) + 1e-6 && px(m.moist, x, y) >= 0))
                        fail_msg("drying %g at (%d, %d): the zones do not partition", steps[k], x,
                                 y);
                }
            wet_sum[k] = mask_sum(m.wet, NULL) - mask_sum(none.wet, NULL);
            moist_sum[k] = mask_sum(m.moist, NULL) - mask_sum(none.moist, NULL);
            pud_sum[k] = mask_sum(m.pud, NULL) - mask_sum(none.pud, NULL);
            printf("map %d, drying %.1f: band film %.0f, moist %.0f, puddles %.0f\n", i, steps[k],
                   wet_sum[k], moist_sum[k], pud_sum[k]);
            if (k > 1) masks_free(&prev);
            prev = m;
        }
        masks_free(&prev);
        /* the film dries first: by 0.4 most of it has gone while the moisture holds */
        assert_true(wet_sum[2] < 0.3 * wet_sum[0]);
        assert_true(moist_sum[2] > 0.5 * (wet_sum[0] + moist_sum[0]));
        assert_true(pud_sum[2] > 0 && pud_sum[4] < 0.5 * pud_sum[0]);
        masks_free(&d0);
        masks_free(&high);
        masks_free(&none);
    }
}

/* Hollow depth the graph measures: the normalised smoothed height's blur over puddle_size (4)
 * minus itself (caller frees). */
static double *hollow_depth(const WgImage *h)
{
    double lo, hi;
    WgImage *sm = smoothed(h);
    range_of(sm, &lo, &hi);
    int w = h->width, hh = h->height;
    WgImage *sn = wgt_image(w, hh, 1, NULL);
    for (int y = 0; y < hh; y++)
        for (int x = 0; x < w; x++) wg_image_row(sn, y)[x] = (px(sm, x, y) - lo) / (hi - lo);
    const char *names[] = {"source"};
    const WgImage *in[] = {sn};
    WgImage *hb = wgt_node("blur", "sigma=\"4\"", w, hh, 1, names, in, 0, 1);
    double *d = malloc(sizeof(double) * (size_t)w * hh);
    assert_non_null(d);
    for (int y = 0; y < hh; y++)
        for (int x = 0; x < w; x++) d[(size_t)y * w + x] = px(hb, x, y) - px(sn, x, y);
    wg_image_unref(hb);
    wg_image_unref(sn);
    wg_image_unref(sm);
    return d;
}

/* Porous parts dry last: with less porosity the band is never damper, and clearly drier half
 * way; porosity 0 has no moist stage at all; a porosity map acts pixel by pixel. The puddles
 * left in the band shrink to the deepest hollows. Tiles and keeps the thread-count
 * invariance. */
static void test_drying_porosity_and_puddles(void **state)
{
    (void)state;
    Masks full = render(bricks, NULL, DRY_SETS " drying=0.6");
    Masks low = render(bricks, NULL, DRY_SETS " drying=0.6 porosity=0.2");
    Masks zero = render(bricks, NULL, DRY_SETS " drying=0.3 porosity=0");
    double df = 0, dl = 0;
    for (int y = 0; y < 128; y++)
        for (int x = 0; x < 256; x++) {
            double a = px(full.wet, x, y) + px(full.moist, x, y),
                   b = px(low.wet, x, y) + px(low.moist, x, y);
            if (!(b <= a + 1e-6))
                fail_msg("(%d, %d): porosity 0.2 damper (%g) than 1 (%g)", x, y, b, a);
            df += a;
            dl += b;
        }
    printf("drying 0.6: damp %.0f at porosity 1, %.0f at 0.2\n", df, dl);
    assert_true(dl < 0.6 * df);
    assert_all(zero.moist, 0, "moist at porosity 0");
    assert_true(mask_sum(zero.wet, NULL) > 100);

    const char *name[] = {"height", "porosity_map"};
    WgImage *pm = wgt_image_fn(256, 128, 1, half_porous);
    const WgImage *in[] = {bricks, pm};
    Masks mapped = render_with(name, in, 2, DRY_SETS " drying=0.6", 2);
    Masks none = render(bricks, NULL, DRY_SETS " drying=0.6 porosity=0");
    for (int y = 0; y < 128; y++)
        for (int x = 0; x < 256; x++) {
            const Masks *want = x < 128 ? &full : &none;
            if (px(mapped.moist, x, y) != px(want->moist, x, y) ||
                px(mapped.wet, x, y) != px(want->wet, x, y))
                fail_msg("porosity map at (%d, %d): moist %g, wet %g; expected %g, %g", x, y,
                         px(mapped.moist, x, y), px(mapped.wet, x, y), px(want->moist, x, y),
                         px(want->wet, x, y));
        }

    /* puddles: the band's hollows that still hold water are deeper on average as drying goes
       on (the shallow ones dry first) */
    double *depth = hollow_depth(bricks);
    Masks nob = render(bricks, NULL, "water_level=0.45");
    double prev_mean = 0;
    for (int k = 0; k < 3; k++) {
        char sets[128];
        snprintf(sets, sizeof sets, DRY_SETS " drying=%g", 0.2 + 0.3 * k);
        Masks m = render(bricks, NULL, sets);
        double sum = 0, n = 0;
        for (int y = 0; y < 128; y++)
            for (int x = 0; x < 256; x++)
                if (px(nob.pud, x, y) == 0 && px(m.pud, x, y) > 0.5) {
                    sum += depth[(size_t)y * 256 + x];
                    n++;
                }
        printf("drying %.1f: %.0f band puddle pixels, mean hollow depth %.3f\n", 0.2 + 0.3 * k, n,
               n > 0 ? sum / n : 0);
        assert_true(n > 5);
        assert_true(sum / n > prev_mean);
        prev_mean = sum / n;
        masks_free(&m);
    }
    free(depth);

    /* tiles (the noise shifted with the height: the built-in noise stays where it is), and
       the same at 1 and 3 threads */
    WgImage *n = wgt_image_fn(256, 128, 1, wavy);
    WgImage *hs = roll(bricks, 77, 35), *ps = roll(pm, 77, 35), *ns = roll(n, 77, 35);
    const char *name3[] = {"height", "porosity_map", "noise"};
    const WgImage *ins[] = {hs, ps, ns}, *inb[] = {bricks, pm, n};
    Masks shifted = render_with(name3, ins, 3, DRY_SETS " drying=0.4", 2);
    Masks base = render_with(name3, inb, 3, DRY_SETS " drying=0.4", 2);
    const WgImage *ma[] = {base.imm, base.wet, base.moist, base.pud};
    const WgImage *mb[] = {shifted.imm, shifted.wet, shifted.moist, shifted.pud};
    for (int k = 0; k < 4; k++) {
        WgImage *r = roll(ma[k], 77, 35);
        double d = wgt_max_abs_diff(r, mb[k]);
        printf("drying output %d: max difference after the shift %.3g\n", k, d);
        if (!(d <= 2e-3)) fail_msg("drying output %d differs by %g after a shift", k, d);
        wg_image_unref(r);
    }
    Masks t1 = render_with(name3, inb, 3, DRY_SETS " drying=0.4", 1);
    Masks t3 = render_with(name3, inb, 3, DRY_SETS " drying=0.4", 3);
    assert_masks_identical(&base, &t1);
    assert_masks_identical(&base, &t3);
    masks_free(&t1);
    masks_free(&t3);
    masks_free(&base);
    masks_free(&shifted);
    wg_image_unref(hs);
    wg_image_unref(ps);
    wg_image_unref(ns);
    wg_image_unref(n);
    masks_free(&nob);
    masks_free(&mapped);
    masks_free(&none);
    wg_image_unref(pm);
    masks_free(&full);
    masks_free(&low);
    masks_free(&zero);
}

/* ---- rain on the exposed surface ----------------------------------------------------------- */

/* Rain 0 changes nothing whatever the shelter; as the rain grows no pixel gets drier; at rain 1
 * the flat exposed parts are all film and the steep walls get no film (only soaked pores, so
 * they stay drier), with or without water; hollows fill; a full shelter (the input, or the
 * ambient occlusion through ao_shelter, pixel by pixel) keeps the rain off, bit for bit; a
 * non-porous material soaks none; tiles and keeps the thread-count invariance. */
static void test_rain(void **state)
{
    (void)state;
    float one = 1, zero = 0;
    WgImage *all = wgt_image(1, 1, 1, &one), *none = wgt_image(1, 1, 1, &zero);
    WgImage *left_ao = wgt_image_fn(256, 128, 1, half_porous); /* 1 left, 0 right */
    const char *nsh[] = {"height", "shelter"}, *nao[] = {"height", "ao"};
    const WgImage *ish[] = {bricks, all}, *iao[] = {bricks, left_ao}, *iao0[] = {bricks, none};

    Masks dry = render(bricks, NULL, "water_level=0.45");
    Masks r0 = render_with(nao, iao0, 2, "water_level=0.45 ao_shelter=1", 2);
    assert_masks_identical(&dry, &r0);
    Masks sheltered = render_with(nsh, ish, 2, "water_level=0.45 rain=1", 2);
    assert_masks_identical(&dry, &sheltered);
    masks_free(&r0);
    masks_free(&sheltered);

    /* the slope the graph measures: of the normalised smoothed height, 16 length units deep */
    double lo, hi;
    WgImage *sm = smoothed(bricks);
    range_of(sm, &lo, &hi);
    WgImage *sn = wgt_image(256, 128, 1, NULL);
    for (int y = 0; y < 128; y++)
        for (int x = 0; x < 256; x++) wg_image_row(sn, y)[x] = (px(sm, x, y) - lo) / (hi - lo);
    const char *names[] = {"height"};
    const WgImage *in[] = {sn};
    WgImage *slope = wgt_node("slope", "intensity=\"16\" method=\"sobel\"", 256, 128, 1, names, in, 0, 1);

    static const char *const sets[] = {"water_level=0.45", "water_level=0.45 rain=0.25",
                                       "water_level=0.45 rain=0.5", "water_level=0.45 rain=1"};
    Masks prev = render(bricks, NULL, sets[0]);
    for (int k = 1; k < 4; k++) {
        Masks m = render(bricks, NULL, sets[k]);
        for (int y = 0; y < 128; y++)
            for (int x = 0; x < 256; x++) {
                double damp = px(m.wet, x, y) + px(m.moist, x, y),
                       pdamp = px(prev.wet, x, y) + px(prev.moist, x, y);
                if (!(px(m.wet, x, y) >= px(prev.wet, x, y) - 1e-6 && damp >= pdamp - 1e-6 &&
                      px(m.pud, x, y) >= px(prev.pud, x, y) - 1e-6))
                    fail_msg("%s at (%d, %d): drier than with less rain", sets[k], x, y);
                if (!(damp + px(m.imm, x, y) <= 1 + 1e-6 && px(m.pud, x, y) <= px(m.wet, x, y) + 1e-6))
                    fail_msg("%s at (%d, %d): the zones do not partition", sets[k], x, y);
            }
        printf("%s: wet %.0f, moist %.0f, puddles %.0f\n", sets[k], mask_sum(m.wet, NULL),
               mask_sum(m.moist, NULL), mask_sum(m.pud, NULL));
        masks_free(&prev);
        prev = m;
    }
    /* rain 1: film on every flat exposed pixel, none on the steep walls (drier: pores only) */
    for (int lv = 0; lv < 2; lv++) {
        Masks m = lv ? prev : render(bricks, NULL, "water_level=0 rain=1");
        int flat = 0, steep = 0;
        double steep_damp = 0;
        for (int y = 0; y < 128; y++)
            for (int x = 0; x < 256; x++) {
                double sl = px(slope, x, y);
                if (sl < 0.5 - 0.075 - 1e-3 && px(m.imm, x, y) == 0) {
                    if (!(px(m.wet, x, y) == 1))
                        fail_msg("rain 1: flat (%d, %d) has film %g", x, y, px(m.wet, x, y));
                    flat++;
                }
                if (sl > 0.5 + 0.075 + 1e-3 && px(m.imm, x, y) == 0) {
                    if (!(px(m.wet, x, y) == 0 && px(m.pud, x, y) == 0))
                        fail_msg("rain 1: steep (%d, %d) has film %g", x, y, px(m.wet, x, y));
                    steep++;
                    steep_damp += px(m.moist, x, y);
                }
            }
        printf("rain 1, level %s: %d flat pixels all film, %d steep with mean moisture %.2f\n",
               lv ? "0.45" : "0", flat, steep, steep_damp / steep);
        assert_true(flat > 1000 && steep > 100);
        /* with no water near, the walls only soak (porosity 1, half the flat parts' rain);
           next to water they take its moisture too */
        if (!lv) assert_true(steep_damp / steep < 0.75);
        if (!lv) {
            assert_true(mask_sum(m.pud, NULL) > 200);
            assert_all(m.imm, 0, "immersed at level 0");
            masks_free(&m);
        }
    }
    /* the water's film reaches further in the rain */
    Masks wide = render(bricks, NULL, "water_level=0.45 rain=0.3 slope_limit=0 slope_softness=0");
    Masks narrow = render(bricks, NULL, "water_level=0.45 slope_limit=0 slope_softness=0");
    assert_true(mask_sum(wide.wet, NULL) == mask_sum(narrow.wet, NULL)); /* no film holds */
    assert_true(mask_sum(wide.moist, NULL) > 1.1 * mask_sum(narrow.moist, NULL));
    masks_free(&wide);
    masks_free(&narrow);

    /* sheltered by the ambient occlusion on the right half (ao 0 there), pixel by pixel */
    Masks ao = render_with(nao, iao, 2, "water_level=0.45 rain=1 ao_shelter=1", 2);
    for (int y = 0; y < 128; y++)
        for (int x = 128; x < 256; x++)
            if (px(ao.wet, x, y) != px(dry.wet, x, y) || px(ao.moist, x, y) != px(dry.moist, x, y) ||
                px(ao.pud, x, y) != px(dry.pud, x, y))
                fail_msg("sheltered (%d, %d) is wetter than without rain", x, y);
    assert_true(mask_sum(ao.wet, left_half) > 2 * mask_sum(dry.wet, left_half) + 1000);
    masks_free(&ao);

    /* a non-porous material soaks nothing up */
    Masks glazed = render(bricks, NULL, "water_level=0.45 rain=1 porosity=0");
    assert_all(glazed.moist, 0, "moist at porosity 0");
    masks_free(&glazed);

    /* tiles (with the noise shifted along), and the same at 1 and 3 threads */
    WgImage *n = wgt_image_fn(256, 128, 1, wavy);
    WgImage *hs = roll(bricks, 77, 35), *ns = roll(n, 77, 35);
    const char *name2[] = {"height", "noise"};
    const WgImage *ins[] = {hs, ns}, *inb[] = {bricks, n};
    Masks a = render_with(name2, inb, 2, "water_level=0.45 rain=0.4", 2);
    Masks b = render_with(name2, ins, 2, "water_level=0.45 rain=0.4", 2);
    const WgImage *ma[] = {a.imm, a.wet, a.moist, a.pud}, *mb[] = {b.imm, b.wet, b.moist, b.pud};
    for (int k = 0; k < 4; k++) {
        WgImage *r = roll(ma[k], 77, 35);
        double d = wgt_max_abs_diff(r, mb[k]);
        printf("rain output %d: max difference after the shift %.3g\n", k, d);
        if (!(d <= 2e-3)) fail_msg("rain output %d differs by %g after a shift", k, d);
        wg_image_unref(r);
    }
    Masks t1 = render_with(name2, inb, 2, "water_level=0.45 rain=0.4", 1);
    Masks t3 = render_with(name2, inb, 2, "water_level=0.45 rain=0.4", 3);
    assert_masks_identical(&a, &t1);
    assert_masks_identical(&a, &t3);
    masks_free(&a);
    masks_free(&b);
    masks_free(&t1);
    masks_free(&t3);
    wg_image_unref(n);
    wg_image_unref(hs);
    wg_image_unref(ns);
    masks_free(&prev);
    masks_free(&dry);
    wg_image_unref(slope);
    wg_image_unref(sn);
    wg_image_unref(sm);
    wg_image_unref(left_ao);
    wg_image_unref(all);
    wg_image_unref(none);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_level_zero_is_dry),
        cmocka_unit_test(test_level_one_is_immersed),
        cmocka_unit_test(test_immersed_grows_and_lies_below),
        cmocka_unit_test(test_dry_far_from_water),
        cmocka_unit_test(test_soft_transitions),
        cmocka_unit_test(test_steep_walls_stay_dry),
        cmocka_unit_test(test_puddles_in_hollows_near_water),
        cmocka_unit_test(test_partition_and_ranges),
        cmocka_unit_test(test_hard_cases),
        cmocka_unit_test(test_zones_view),
        cmocka_unit_test(test_partial_range_and_16_bit),
        cmocka_unit_test(test_tiling),
        cmocka_unit_test(test_resolution_independence),
        cmocka_unit_test(test_noise_input),
        cmocka_unit_test(test_moist_follows_porosity),
        cmocka_unit_test(test_level_image),
        cmocka_unit_test(test_drying),
        cmocka_unit_test(test_drying_porosity_and_puddles),
        cmocka_unit_test(test_rain),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
