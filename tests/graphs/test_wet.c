/* SPDX-License-Identifier: MIT */
/* The wet-material graphs (graphs/texturing.wetgraph, graphs/wet_material.wetgraph) on small
 * synthetic materials: empty masks give back the dry material; the wet base colour is never
 * brighter than the dry one and not less saturated; immersed parts get the liquid's roughness
 * and, away from the meniscus, upward normals; every output is finite and in range, also for
 * non-square and 16-bit inputs; and asking for one output evaluates only the nodes it needs;
 * wet_material's painted level and drying band reach the maps. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define W 256
#define H 128

static const char *source_dir(void)
{
    const char *s = getenv("WETGRAPH_SOURCE");
    if (!s) fail_msg("WETGRAPH_SOURCE is not set (run through meson test)");
    return s;
}

static WgGraph *load_builtin(const char *name)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/graphs/%s.wetgraph", source_dir(), name);
    WgError err = {0};
    WgGraph *g = NULL;
    if (wg_graph_load(path, &g, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("%s", buf);
    }
    return g;
}

/* A material with saturated, pale and near-gray colours, a rolling height field and a bumpy
 * normal map (linear values). */
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
static double normal_fn(int x, int y, int k)
{
    double n[3] = {0.3 * sin(0.2 * x), 0.3 * cos(0.13 * y), 1};
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + 1);
    return k == 3 ? 1.0 : n[k] / l * 0.5 + 0.5;
}
static double rough_fn(int x, int y, int k)
{
    (void)k;
    return 0.2 + 0.7 * (x + y) / (double)(W + H);
}
/* Zones: immersed is a hard-edged disc of radius 40 at (128, 64); wet a ring around it fading
 * out, moist the next ring, puddles a soft blob. immersed + wet + moist <= 1. */
static double disc_r(int x, int y)
{
    return hypot(x + 0.5 - 128, y + 0.5 - 64);
}
static double immersed_fn(int x, int y, int k)
{
    (void)k;
    return disc_r(x, y) < 40 ? 1 : 0;
}
static double wet_fn(int x, int y, int k)
{
    (void)k;
    double r = disc_r(x, y);
    return r < 40 ? 0 : r < 50 ? 1 : r < 60 ? (60 - r) / 10 : 0;
}
static double moist_fn(int x, int y, int k)
{
    (void)k;
    double r = disc_r(x, y);
    return r < 40 ? 0 : r < 50 ? 0 : r < 60 ? (r - 50) / 10 : r < 70 ? (70 - r) / 10 : 0;
}
static double puddles_fn(int x, int y, int k)
{
    (void)k;
    double r = hypot(x - 30.5, y - 30.5);
    return r < 10 ? 1 : r < 14 ? (14 - r) / 4 : 0;
}
static double level_fn(int x, int y, int k)
{
    double h = height_fn(x, y, k);
    return immersed_fn(x, y, k) > 0 ? fmax(h, 0.6) : h;
}

typedef struct {
    WgImage *base, *height, *normal, *rough, *imm, *wet, *moist, *pud, *wh;
} Material;

static Material material(int w, int h)
{
    Material m = {
        wgt_image_fn(w, h, 4, color_fn),    wgt_image_fn(w, h, 1, height_fn),
        wgt_image_fn(w, h, 4, normal_fn),   wgt_image_fn(w, h, 1, rough_fn),
        wgt_image_fn(w, h, 1, immersed_fn), wgt_image_fn(w, h, 1, wet_fn),
        wgt_image_fn(w, h, 1, moist_fn),    wgt_image_fn(w, h, 1, puddles_fn),
        wgt_image_fn(w, h, 1, level_fn),
    };
    return m;
}
static void material_free(Material *m)
{
    WgImage **p[] = {&m->base, &m->height, &m->normal, &m->rough, &m->imm,
                     &m->wet,  &m->moist,  &m->pud,    &m->wh};
    for (size_t i = 0; i < sizeof p / sizeof p[0]; i++) wg_image_unref(*p[i]);
}

static void set_input(WgRequest *r, const char *name, const WgImage *img)
{
    WgError err = {0};
    if (wg_request_set_input_image(r, name, img, &err)) fail_msg("%s: %s", name, err.message);
}
static void set_param(WgRequest *r, const char *name, const char *value)
{
    WgError err = {0};
    if (wg_request_set(r, name, value, &err)) fail_msg("%s: %s", name, err.message);
}

/* Render texturing on the material; `zones` false leaves the zone inputs unconnected. */
static WgResult *render_texturing(const WgGraph *g, const Material *m, bool zones,
                                  const char **params, const char *only)
{
    WgRequest *r = wg_request_new(g);
    set_input(r, "basecolor", m->base);
    set_input(r, "height", m->height);
    set_input(r, "normal", m->normal);
    set_input(r, "roughness", m->rough);
    if (zones) {
        set_input(r, "immersed", m->imm);
        set_input(r, "wet", m->wet);
        set_input(r, "moist", m->moist);
        set_input(r, "puddles", m->pud);
        set_input(r, "water_height", m->wh);
    }
    for (int i = 0; params && params[i]; i += 2) set_param(r, params[i], params[i + 1]);
    if (only) {
        WgError err = {0};
        if (wg_request_add_output(r, only, &err)) fail_msg("%s", err.message);
    }
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    wg_engine_free(e);
    wg_request_free(r);
    return res;
}

/* HSV saturation of a linear colour. */
static double saturation(const float *p)
{
    double mx = fmax(p[0], fmax(p[1], p[2])), mn = fmin(p[0], fmin(p[1], p[2]));
    return mx > 1e-6 ? (mx - mn) / mx : 0;
}

static void test_dry_when_no_zones(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("texturing");
    Material m = material(W, H);
    WgResult *res = render_texturing(g, &m, false, NULL, NULL);
    wgt_assert_near(wgt_output(res, "basecolor"), m.base, 1e-6);
    wgt_assert_near(wgt_output(res, "normal"), m.normal, 1e-6);
    wgt_assert_near(wgt_output(res, "roughness"), m.rough, 1e-6);
    wgt_assert_near(wgt_output(res, "height"), m.height, 1e-6);
    wgt_assert_range(wgt_output(res, "ao"), 1, 1);
    wgt_assert_range(wgt_output(res, "metallic"), 0, 0);
    wgt_assert_range(wgt_output(res, "water_mask"), 0, 0);
    wg_result_free(res);
    material_free(&m);
    wg_graph_free(g);
}

static void check_darker_richer(const WgImage *dry, const WgImage *wet, double sat_tol)
{
    double darkest = 1;
    for (int y = 0; y < dry->height; y++)
        for (int x = 0; x < dry->width; x++) {
            const float *d = wg_image_row(dry, y) + 4 * x, *w = wg_image_row(wet, y) + 4 * x;
            for (int k = 0; k < 3; k++)
                if (!(w[k] <= d[k] + 1e-6))
                    fail_msg("(%d, %d) channel %d: wet %g brighter than dry %g", x, y, k, w[k],
                             d[k]);
            if (!(saturation(w) >= saturation(d) - sat_tol))
                fail_msg("(%d, %d): saturation drops from %g to %g", x, y, saturation(d),
                         saturation(w));
            if (d[1] > 0.05) darkest = fmin(darkest, w[1] / d[1]);
        }
    /* the wet zone really is darker */
    assert_true(darkest < 0.7);
}

static void test_darker_and_more_saturated(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("texturing");
    Material m = material(W, H);
    /* a colourless liquid: darkening and saturation alone must never brighten or desaturate */
    const char *clear[] = {"tint_r", "1", "tint_g", "1", "tint_b", "1", NULL};
    WgResult *res = render_texturing(g, &m, true, clear, NULL);
    check_darker_richer(m.base, wgt_output(res, "basecolor"), 1e-6);
    wg_result_free(res);
    /* the default liquid, water, is clear */
    res = render_texturing(g, &m, true, NULL, NULL);
    check_darker_richer(m.base, wgt_output(res, "basecolor"), 1e-6);
    wg_result_free(res);
    /* a tinted clear liquid only takes light away (its tint may shift the hue either way) */
    const char *tea[] = {"liquid", "tea", NULL};
    res = render_texturing(g, &m, true, tea, NULL);
    check_darker_richer(m.base, wgt_output(res, "basecolor"), 1);
    wg_result_free(res);
    material_free(&m);
    wg_graph_free(g);
}

static void test_immersed_roughness_and_normals(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("texturing");
    Material m = material(W, H);
    const char *params[] = {"water_roughness", "0.03", "meniscus_width", "8", NULL};
    WgResult *res = render_texturing(g, &m, true, params, NULL);
    const WgImage *rough = wgt_output(res, "roughness"), *n = wgt_output(res, "normal");
    const WgImage *wn = wgt_output(res, "water_normal"), *hgt = wgt_output(res, "height");
    double band = 8.0 * W / 256 + 2; /* meniscus width in pixels, plus the normal's stencil */
    int inside = 0, in_band_raised = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            if (immersed_fn(x, y, 0) < 1) continue;
            assert_true(wgt_px(rough, x, y, 0) <= 0.03 + 1e-6);
            double r = disc_r(x, y);
            if (r < 40 - band) {
                inside++;
                assert_float_equal(wgt_px(n, x, y, 0), 0.5, 1e-6);
                assert_float_equal(wgt_px(n, x, y, 1), 0.5, 1e-6);
                assert_float_equal(wgt_px(n, x, y, 2), 1.0, 1e-6);
                assert_float_equal(wgt_px(hgt, x, y, 0), level_fn(x, y, 0), 1e-6);
            } else if (r > 39 && wgt_px(hgt, x, y, 0) > 0.6 + 1e-3) {
                in_band_raised++;
            }
        }
    assert_true(inside > 1000);
    /* the meniscus raises the liquid along the edge and bends its normal there */
    assert_true(in_band_raised > 50);
    double bent = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) bent = fmax(bent, fabs(wgt_px(wn, x, y, 0) - 0.5));
    assert_true(bent > 0.01);
    wg_result_free(res);
    material_free(&m);
    wg_graph_free(g);
}

static void check_outputs_in_range(const WgResult *res, double max_height)
{
    for (int i = 0; i < wg_result_output_count(res); i++) {
        const char *name = wg_result_output_name(res, i);
        const WgImage *img = wg_result_output_image(res, i);
        if (strstr(name, "height"))
            wgt_assert_range(img, 0, max_height);
        else
            wgt_assert_range(img, 0, 1);
    }
}

static void test_outputs_finite_in_range(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("texturing");
    Material m = material(W, H);
    const char *liquids[] = {"water", "muddy_water", "tea", "milk", "blood", "oil"};
    for (int i = 0; i < 6; i++) {
        const char *params[] = {"liquid", liquids[i], "normal_format", "directx", NULL};
        WgResult *res = render_texturing(g, &m, true, params, NULL);
        check_outputs_in_range(res, 1.0);
        wg_result_free(res);
    }
    material_free(&m);
    wg_graph_free(g);
}

/* Non-square, 16-bit PNG height and an 8-bit sRGB base colour read from files. */
static void test_files_16bit_non_square(void **state)
{
    (void)state;
    Material m = material(200, 72);
    WgError err = {0};
    const char *hpath = wgt_path("height16.png"), *cpath = wgt_path("color.png");
    if (wg_image_write(hpath, m.height, WG_FORMAT_PNG16, WG_LINEAR, &err) ||
        wg_image_write(cpath, m.base, WG_FORMAT_PNG, WG_SRGB, &err))
        fail_msg("%s", err.message);
    WgGraph *g = load_builtin("texturing");
    WgRequest *r = wg_request_new(g);
    if (wg_request_set_input_file(r, "height", hpath, &err) ||
        wg_request_set_input_file(r, "basecolor", cpath, &err))
        fail_msg("%s", err.message);
    set_input(r, "immersed", m.imm);
    set_input(r, "wet", m.wet);
    set_input(r, "puddles", m.pud);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    const WgImage *b = wgt_output(res, "basecolor");
    assert_int_equal(b->width, 200);
    assert_int_equal(b->height, 72);
    check_outputs_in_range(res, 1.0);
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
    material_free(&m);
}

/* Only the base colour: the normal, meniscus and roughness nodes do not run. */
static void test_only_basecolor_evaluated(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("texturing");
    Material m = material(W, H);
    /* each of these runs in a render of every output, so a renamed node fails here */
    const char *unneeded[] = {
        "surf/normal_out", "surf/water_normal", "surf/edge", "surf/meniscus", "rough", "ao_out"};
    WgResult *res = render_texturing(g, &m, true, NULL, NULL);
    for (size_t i = 0; i < sizeof unneeded / sizeof unneeded[0]; i++)
        if (!wgt_stat(res, unneeded[i])) fail_msg("no node '%s' in the full render", unneeded[i]);
    wg_result_free(res);
    res = render_texturing(g, &m, true, NULL, "basecolor");
    assert_int_equal(wg_result_output_count(res), 1);
    assert_non_null(wgt_stat(res, "albedo"));
    for (size_t i = 0; i < sizeof unneeded / sizeof unneeded[0]; i++)
        if (wgt_stat(res, unneeded[i])) fail_msg("node '%s' ran for basecolor alone", unneeded[i]);
    wg_result_free(res);
    material_free(&m);
    wg_graph_free(g);
}

/* wet_material renders the material, the layer maps and the masks; the given params. */
static WgResult *render_wet_material(const WgGraph *g, const Material *m, const char *level,
                                     const char *only)
{
    WgRequest *r = wg_request_new(g);
    set_input(r, "basecolor", m->base);
    set_input(r, "height", m->height);
    set_input(r, "normal", m->normal);
    set_input(r, "roughness", m->rough);
    set_param(r, "water_level", level);
    if (only) {
        WgError err = {0};
        if (wg_request_add_output(r, only, &err)) fail_msg("%s", err.message);
    }
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    wg_engine_free(e);
    wg_request_free(r);
    return res;
}

/* Water level 0: empty masks, the dry material comes back unchanged. */
static void test_wet_material_dry_at_level_0(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("wet_material");
    Material m = material(W, H);
    WgResult *res = render_wet_material(g, &m, "0", NULL);
    wgt_assert_range(wgt_output(res, "immersed"), 0, 0);
    wgt_assert_range(wgt_output(res, "wet"), 0, 0);
    wgt_assert_range(wgt_output(res, "puddles"), 0, 0);
    wgt_assert_near(wgt_output(res, "basecolor"), m.base, 1e-6);
    wgt_assert_near(wgt_output(res, "normal"), m.normal, 1e-6);
    wgt_assert_near(wgt_output(res, "roughness"), m.rough, 1e-6);
    wgt_assert_near(wgt_output(res, "height"), m.height, 1e-6);
    wg_result_free(res);
    material_free(&m);
    wg_graph_free(g);
}

/* A wet material: darker and richer, everything in range; basecolor alone does not run the
 * normal nodes nor the zones view. */
static void test_wet_material_wet(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("wet_material");
    Material m = material(W, H);
    /* nodes the base colour does not need: each runs in a render of every output (so a
       renamed node fails here rather than passing the check below unseen) */
    const char *unneeded[] = {"tex/surf/normal_out", "tex/surf/water_normal", "tex/surf/edge",
                              "masks/zones"};
    WgResult *res = render_wet_material(g, &m, "0.5", NULL);
    check_darker_richer(m.base, wgt_output(res, "basecolor"), 0.01);
    check_outputs_in_range(res, 1.1);
    for (size_t i = 0; i < sizeof unneeded / sizeof unneeded[0]; i++)
        if (!wgt_stat(res, unneeded[i])) fail_msg("no node '%s' in the full render", unneeded[i]);
    wg_result_free(res);
    res = render_wet_material(g, &m, "0.5", "basecolor");
    assert_int_equal(wg_result_output_count(res), 1);
    assert_non_null(wgt_stat(res, "tex/albedo"));
    assert_non_null(wgt_stat(res, "masks/immersed"));
    for (size_t i = 0; i < sizeof unneeded / sizeof unneeded[0]; i++)
        if (wgt_stat(res, unneeded[i])) fail_msg("node '%s' ran for basecolor alone", unneeded[i]);
    wg_result_free(res);
    material_free(&m);
    wg_graph_free(g);
}

/* The custom-masks example renders with its own masks and darkens where they are. */
static void test_custom_masks_example(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("examples/custom_masks");
    Material m = material(W, H);
    WgRequest *r = wg_request_new(g);
    set_input(r, "basecolor", m.base);
    set_input(r, "height", m.height);
    set_input(r, "splash", m.wet);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    check_darker_richer(m.base, wgt_output(res, "basecolor"), 0.01);
    /* fully painted and above the water: wet; unpainted: dry */
    const WgImage *wet = wgt_output(res, "wet");
    int painted = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double s = wet_fn(x, y, 0);
            if (s == 0) assert_float_equal(wgt_px(wet, x, y, 0), 0, 1e-6);
            if (s == 1 && height_fn(x, y, 0) > 0.48) {
                assert_float_equal(wgt_px(wet, x, y, 0), 1, 1e-6);
                painted++;
            }
        }
    assert_true(painted > 100);
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    material_free(&m);
    wg_graph_free(g);
}

/* ---- the darkening against Lekner & Dorf, on real materials ------------------------------- */

static double luminance(const float *p)
{
    return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
}

/* Lekner & Dorf's wet/dry albedo ratio for albedo a under a liquid of index n: (1 - r_e)(1 -
 * r_i) / (1 - r_i a), r_i the diffuse internal reflectance (the Egan & Hilgeman fit), (1 - r_e) =
 * n^2 (1 - r_i). */
static double lekner_dorf_ratio(double a, double n)
{
    double ri = -1.440 / (n * n) + 0.710 / n + 0.668 + 0.0636 * n;
    return n * n * (1 - ri) * (1 - ri) / (1 - ri * a);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}
static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static WgImage *load_shared(const char *rel, int channels, WgColorspace cs, int w, int h)
{
    char path[2048];
    const char *shared = getenv("WETGRAPH_SHARED");
    if (!shared) fail_msg("WETGRAPH_SHARED is not set (run through meson test)");
    snprintf(path, sizeof path, "%s/materials/%s", shared, rel);
    WgError err = {0};
    WgImage *img = NULL;
    if (wg_image_read(path, channels, cs, &img, &err)) fail_msg("%s: %s", path, err.message);
    WgImage *small = wg_image_convert(img, w, h, channels);
    assert_non_null(small);
    wg_image_unref(img);
    return small;
}

/* With the defaults (water, porosity 1), the median per-pixel wet/dry ratio of the linear
 * luminance, divided by Lekner & Dorf's ratio for that pixel's dry albedo, lies in [0.8, 1.25]
 * in the wet and the immersed zones; the moist zone darkens, but less than the model. Two real
 * materials at two water levels. */
static void test_darkening_follows_lekner_dorf(void **state)
{
    (void)state;
    static const struct {
        const char *color, *height;
        int w, h;
    } mats[] = {
        {"bricks102_stonewall_1k/Bricks102_1K-JPG_Color.jpg",
         "bricks102_stonewall_1k/Bricks102_1K-JPG_Displacement.jpg", 384, 192},
        {"pavingstones130_1k/PavingStones130_1K_Color.jpg",
         "pavingstones130_1k/PavingStones130_1K_Displacement.jpg", 256, 256},
    };
    const char *levels[] = {"0.5", "0.6"};
    WgGraph *g = load_builtin("wet_material");
    for (int mi = 0; mi < 2; mi++) {
        WgImage *base = load_shared(mats[mi].color, 4, WG_SRGB, mats[mi].w, mats[mi].h);
        WgImage *hgt = load_shared(mats[mi].height, 1, WG_LINEAR, mats[mi].w, mats[mi].h);
        for (int li = 0; li < 2; li++) {
            WgRequest *r = wg_request_new(g);
            set_input(r, "basecolor", base);
            set_input(r, "height", hgt);
            set_param(r, "water_level", levels[li]);
            WgEngine *e = wgt_engine(2, 0, NULL);
            WgResult *res = wgt_render_request(e, r);
            const WgImage *wet = wgt_output(res, "basecolor"), *zi = wgt_output(res, "immersed");
            const WgImage *zw = wgt_output(res, "wet"), *zm = wgt_output(res, "moist");
            size_t n = (size_t)base->width * base->height;
            double *qi = malloc(n * sizeof *qi), *qw = malloc(n * sizeof *qw),
                   *um = malloc(n * sizeof *um);
            int ni = 0, nw = 0, nm = 0;
            for (int y = 0; y < base->height; y++)
                for (int x = 0; x < base->width; x++) {
                    double a = luminance(wg_image_row(base, y) + 4 * x);
                    if (a < 0.01) continue;
                    double t = luminance(wg_image_row(wet, y) + 4 * x) / a;
                    double ld = lekner_dorf_ratio(a, 1.333);
                    if (wgt_px(zi, x, y, 0) >= 0.99) qi[ni++] = t / ld;
                    if (wgt_px(zw, x, y, 0) >= 0.99) qw[nw++] = t / ld;
                    if (wgt_px(zm, x, y, 0) >= 0.5) um[nm++] = (1 - t) / (1 - ld);
                }
            if (ni < 200 || nw < 200 || nm < 100)
                fail_msg("%s at %s: too few pixels in a zone (%d immersed, %d wet, %d moist)",
                         mats[mi].color, levels[li], ni, nw, nm);
            double mi_ = median(qi, ni), mw = median(qw, nw), mm = median(um, nm);
            if (!(mi_ >= 0.8 && mi_ <= 1.25 && mw >= 0.8 && mw <= 1.25))
                fail_msg("%s at %s: median wet/dry over Lekner & Dorf is %.3f immersed, %.3f wet",
                         mats[mi].color, levels[li], mi_, mw);
            /* moist: darker than dry, lighter than fully wet (u: the share of the darkening) */
            if (!(mm > 0.05 && mm < 1))
                fail_msg("%s at %s: moist zone has %.3f of the model's darkening", mats[mi].color,
                         levels[li], mm);
            free(qi);
            free(qw);
            free(um);
            wg_result_free(res);
            wg_engine_free(e);
            wg_request_free(r);
        }
        wg_image_unref(base);
        wg_image_unref(hgt);
    }
    wg_graph_free(g);
}

/* ---- depths are lengths: the units of the height map do not matter ------------------------ */

static double srgb_encode(double v)
{
    v = fmin(fmax(v, 0), 1);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
}
static double max_srgb_diff(const WgImage *a, const WgImage *b)
{
    double d = 0;
    for (int y = 0; y < a->height; y++)
        for (int x = 0; x < a->width; x++)
            for (int k = 0; k < 3; k++)
                d = fmax(d,
                         fabs(srgb_encode(wgt_px(a, x, y, k)) - srgb_encode(wgt_px(b, x, y, k))));
    return d;
}
static double height_x1000(int x, int y, int k)
{
    return 1000 * height_fn(x, y, k);
}

/* A height map and the same map x1000, both float EXR files: for every liquid the same base
 * colour (within 2/255 encoded), the same meniscus (water normals) and the same surface
 * relative to the map. */
static void test_depths_free_of_height_units(void **state)
{
    (void)state;
    int w = 160, h = 96;
    Material m = material(w, h);
    WgImage *big = wgt_image_fn(w, h, 1, height_x1000);
    const char *p1 = wgt_path("height_1.exr"), *p1000 = wgt_path("height_1000.exr");
    WgError err = {0};
    if (wg_image_write(p1, m.height, WG_FORMAT_EXR32, WG_LINEAR, &err) ||
        wg_image_write(p1000, big, WG_FORMAT_EXR32, WG_LINEAR, &err))
        fail_msg("%s", err.message);
    WgGraph *g = load_builtin("wet_material");
    const char *liquids[] = {"water", "muddy_water", "tea", "milk", "blood", "oil"};
    for (int i = 0; i < 6; i++) {
        WgResult *res[2];
        for (int s = 0; s < 2; s++) {
            WgRequest *r = wg_request_new(g);
            set_input(r, "basecolor", m.base);
            set_input(r, "normal", m.normal);
            if (wg_request_set_input_file(r, "height", s ? p1000 : p1, &err))
                fail_msg("%s", err.message);
            set_param(r, "water_level", "0.6");
            set_param(r, "liquid", liquids[i]);
            set_param(r, "meniscus_width", "12");
            WgEngine *e = wgt_engine(2, 0, NULL);
            res[s] = wgt_render_request(e, r);
            wg_engine_free(e);
            wg_request_free(r);
        }
        double d = max_srgb_diff(wgt_output(res[0], "basecolor"), wgt_output(res[1], "basecolor"));
        if (d > 2.0 / 255)
            fail_msg("%s: base colour differs by %.1f/255 at x1000", liquids[i], 255 * d);
        const WgImage *wn0 = wgt_output(res[0], "waternormal"),
                      *wn1 = wgt_output(res[1], "waternormal");
        wgt_assert_near(wn0, wn1, 1e-3);
        double bent = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) bent = fmax(bent, fabs(wgt_px(wn0, x, y, 0) - 0.5));
        assert_true(bent > 0.02); /* there is a meniscus to compare */
        const WgImage *s0 = wgt_output(res[0], "waterheight"),
                      *s1 = wgt_output(res[1], "waterheight");
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                assert_float_equal(wgt_px(s1, x, y, 0) / 1000, wgt_px(s0, x, y, 0), 1e-4);
        wg_result_free(res[0]);
        wg_result_free(res[1]);
    }
    wg_image_unref(big);
    material_free(&m);
    wg_graph_free(g);
}

/* ---- water_level is a fraction of the height map's range in every graph ------------------- */

static double image_min(const WgImage *img, double *hi)
{
    double lo = INFINITY;
    *hi = -INFINITY;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            lo = fmin(lo, wgt_px(img, x, y, 0));
            *hi = fmax(*hi, wgt_px(img, x, y, 0));
        }
    return lo;
}
static double mean_of(const WgImage *img)
{
    double s = 0;
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) s += wgt_px(img, x, y, 0);
    return s / ((double)img->width * img->height);
}

/* The test height uses part of 0..1 (about 0.2 to 0.8). texturing without a water height
 * flattens the immersed part at lo + water_level (hi - lo); custom_masks immerses the same share
 * of the map as create_masks at the same water_level, for the map and the map x1000. */
static void test_water_level_same_everywhere(void **state)
{
    (void)state;
    Material m = material(W, H);
    double hi, lo = image_min(m.height, &hi);
    WgGraph *g = load_builtin("texturing");
    WgRequest *r = wg_request_new(g);
    set_input(r, "basecolor", m.base);
    set_input(r, "height", m.height);
    set_input(r, "immersed", m.imm);
    set_param(r, "water_level", "0.4");
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    const WgImage *surf = wgt_output(res, "height");
    double level = lo + 0.4 * (hi - lo);
    int below = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            if (disc_r(x, y) > 40 - 8) continue; /* away from the meniscus */
            double hh = height_fn(x, y, 0);
            assert_float_equal(wgt_px(surf, x, y, 0), fmax(hh, level), 1e-5);
            below += hh < level - 0.01;
        }
    assert_true(below > 100);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);

    WgImage *big = wgt_image_fn(W, H, 1, height_x1000);
    WgGraph *gc = load_builtin("examples/custom_masks"), *gm = load_builtin("create_masks");
    for (int s = 0; s < 2; s++) {
        const WgImage *hm = s ? big : m.height;
        for (int li = 0; li < 3; li++) {
            const char *lv = li == 0 ? "0.25" : li == 1 ? "0.4" : "0.7";
            r = wg_request_new(gc);
            set_input(r, "basecolor", m.base);
            set_input(r, "height", hm);
            set_param(r, "water_level", lv);
            res = wgt_render_request(e, r);
            double custom = mean_of(wgt_output(res, "immersed"));
            wg_result_free(res);
            wg_request_free(r);
            r = wg_request_new(gm);
            set_input(r, "height", hm);
            set_param(r, "water_level", lv);
            res = wgt_render_request(e, r);
            double masks = mean_of(wgt_output(res, "immersed"));
            wg_result_free(res);
            wg_request_free(r);
            if (!(fabs(custom - masks) < 0.03 && masks > 0.02))
                fail_msg("water_level %s (x%d): custom_masks immerses %.3f, create_masks %.3f", lv,
                         s ? 1000 : 1, custom, masks);
        }
    }
    wg_graph_free(gc);
    wg_graph_free(gm);
    wg_image_unref(big);
    wg_engine_free(e);
    material_free(&m);
}

/* ---- the liquid's colour in the film and the moist zone ----------------------------------- */

static double dark_fn(int x, int y, int k)
{
    (void)x;
    (void)y;
    return k == 3 ? 1.0 : 0.02 + 0.01 * k;
}

/* Tea and blood stain the wet film (no standing liquid there) and, weaker, the moist zone; the
 * dry part is untouched; milk lightens a dark material's film. */
static void test_liquid_stains_film(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("texturing");
    Material m = material(W, H);
    /* film and moist rings only: no immersed part, no puddles */
    WgImage *none = wgt_image(W, H, 1, NULL);
    WgImage *saved_imm = m.imm, *saved_pud = m.pud;
    m.imm = none;
    m.pud = none;
    const char *liq[] = {"water", "tea", "blood", "milk"};
    WgResult *res[4];
    for (int i = 0; i < 4; i++) {
        const char *p[] = {"liquid", liq[i], NULL};
        res[i] = render_texturing(g, &m, true, p, NULL);
    }
    const WgImage *water = wgt_output(res[0], "basecolor"), *tea = wgt_output(res[1], "basecolor");
    const WgImage *blood = wgt_output(res[2], "basecolor");
    int nwet = 0, nmoist = 0;
    double tea_wet = 0, tea_moist = 0, blood_wet = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double w = wet_fn(x, y, 0), mo = moist_fn(x, y, 0);
            const float *pw = wg_image_row(water, y) + 4 * x, *pt = wg_image_row(tea, y) + 4 * x;
            const float *pb = wg_image_row(blood, y) + 4 * x;
            if (pw[2] < 0.02 || pw[0] < 0.02) continue;
            /* blue over red, relative to water: below 1 where stained amber */
            double amber = (pt[2] / pw[2]) / (pt[0] / pw[0]);
            if (w == 1) {
                tea_wet += amber;
                blood_wet += (pb[1] / pw[1]) / (pb[0] / pw[0]);
                nwet++;
            } else if (mo >= 0.7 && w == 0) {
                tea_moist += amber;
                nmoist++;
            } else if (w == 0 && mo == 0 && disc_r(x, y) > 40) {
                for (int k = 0; k < 3; k++) assert_float_equal(pt[k], pw[k], 1e-6);
            }
        }
    if (nwet < 100 || nmoist < 100) fail_msg("%d film and %d moist pixels", nwet, nmoist);
    tea_wet /= nwet;
    tea_moist /= nmoist;
    blood_wet /= nwet;
    if (!(tea_wet < 0.8))
        fail_msg("tea does not stain the film: blue/red %.3f of water's", tea_wet);
    if (!(tea_moist < 0.97 && tea_moist > tea_wet))
        fail_msg("tea in the moist zone: blue/red %.3f of water's (film %.3f)", tea_moist, tea_wet);
    if (!(blood_wet < 0.5)) fail_msg("blood does not stain the film: green/red %.3f", blood_wet);
    for (int i = 0; i < 4; i++) wg_result_free(res[i]);

    /* milk lightens a dark material's film */
    WgImage *dark = wgt_image_fn(W, H, 4, dark_fn), *saved_base = m.base;
    m.base = dark;
    const char *milk[] = {"liquid", "milk", NULL};
    WgResult *rm = render_texturing(g, &m, true, milk, NULL);
    const WgImage *b = wgt_output(rm, "basecolor");
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            if (wet_fn(x, y, 0) == 1) assert_true(wgt_px(b, x, y, 1) > 2 * 0.03);
    wg_result_free(rm);
    m.base = saved_base;
    wg_image_unref(dark);
    m.imm = saved_imm;
    m.pud = saved_pud;
    wg_image_unref(none);
    material_free(&m);
    wg_graph_free(g);
}

/* ---- layer maps and the specular level ---------------------------------------------------- */

static double gold_fn(int x, int y, int k)
{
    (void)x;
    (void)y;
    static const double c[4] = {0.9, 0.6, 0.15, 1};
    return c[k];
}
/* metallic 1 in a coin of radius 20 inside the immersed disc, 0 elsewhere */
static double coin_fn(int x, int y, int k)
{
    (void)k;
    return disc_r(x, y) < 20 ? 1 : 0;
}
static double spec_fn(int x, int y, int k)
{
    (void)k;
    return 0.2 + 0.6 * x / (double)W + 0.0 * y;
}
static double raised_level_fn(int x, int y, int k)
{
    return immersed_fn(x, y, k) > 0 ? fmax(height_fn(x, y, k), 0.75) : height_fn(x, y, k);
}

/* The material under the liquid keeps its own metallic, normal, specular and (under standing
 * liquid) roughness, and is darkened only by the liquid in its pores: its colour does not
 * depend on the liquid's depth, and a metal coin keeps its colour. The single-layer maps take
 * the liquid's dielectric top (metallic 0, the liquid's F0) only where the liquid covers. Each
 * path counts the liquid's absorption once: basecolor = under_basecolor x the transmission of
 * the standing liquid. */
static void test_layer_maps(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("texturing");
    Material m = material(W, H);
    WgImage *gold = wgt_image_fn(W, H, 4, gold_fn), *coin = wgt_image_fn(W, H, 1, coin_fn);
    WgImage *spec = wgt_image_fn(W, H, 1, spec_fn), *deep = wgt_image_fn(W, H, 1, raised_level_fn);
    WgResult *res[2];
    for (int s = 0; s < 2; s++) {
        WgRequest *r = wg_request_new(g);
        set_input(r, "basecolor", gold);
        set_input(r, "height", m.height);
        set_input(r, "normal", m.normal);
        set_input(r, "roughness", m.rough);
        set_input(r, "metallic", coin);
        set_input(r, "specular", spec);
        set_input(r, "immersed", m.imm);
        set_input(r, "wet", m.wet);
        set_input(r, "moist", m.moist);
        set_input(r, "puddles", m.pud);
        set_input(r, "water_height", s ? deep : m.wh);
        set_param(r, "liquid", "tea");
        WgEngine *e = wgt_engine(2, 0, NULL);
        res[s] = wgt_render_request(e, r);
        wg_engine_free(e);
        wg_request_free(r);
    }
    const WgResult *rr = res[0];
    wgt_assert_near(wgt_output(rr, "under_metallic"), coin, 0);
    wgt_assert_near(wgt_output(rr, "under_specular"), spec, 0);
    wgt_assert_near(wgt_output(rr, "under_normal"), m.normal, 0);
    /* deeper standing liquid: the same material under it, a darker single-layer colour */
    wgt_assert_near(wgt_output(res[1], "under_basecolor"), wgt_output(rr, "under_basecolor"), 1e-6);
    const WgImage *mask = wgt_output(rr, "water_mask"), *met = wgt_output(rr, "metallic");
    const WgImage *sp = wgt_output(rr, "specular"), *ur = wgt_output(rr, "under_roughness");
    const WgImage *ub = wgt_output(rr, "under_basecolor"), *bc = wgt_output(rr, "basecolor");
    const WgImage *bc_deep = wgt_output(res[1], "basecolor");
    double f0 = pow((1.334 - 1) / (1.334 + 1), 2) / 0.08;
    int covered = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double wm = wgt_px(mask, x, y, 0);
            if (wm == 0) {
                assert_float_equal(wgt_px(met, x, y, 0), coin_fn(x, y, 0), 1e-6);
                assert_float_equal(wgt_px(sp, x, y, 0), spec_fn(x, y, 0), 1e-6);
                for (int k = 0; k < 3; k++)
                    assert_float_equal(wgt_px(bc, x, y, k), wgt_px(ub, x, y, k), 1e-6);
            } else if (wm == 1) {
                covered++;
                assert_float_equal(wgt_px(met, x, y, 0), 0, 1e-6);
                assert_float_equal(wgt_px(sp, x, y, 0), f0, 1e-4);
                assert_float_equal(wgt_px(ur, x, y, 0), rough_fn(x, y, 0), 1e-6);
                for (int k = 0; k < 3; k++) {
                    /* absorbed once: the single-layer colour is the layer's times a
                       transmission below 1, darker where the liquid is deeper */
                    assert_true(wgt_px(bc, x, y, k) <= wgt_px(ub, x, y, k) + 1e-6);
                    assert_true(wgt_px(bc_deep, x, y, k) <= wgt_px(bc, x, y, k) + 1e-6);
                }
                if (coin_fn(x, y, 0) == 1) /* the metal coin has no pores: its own colour */
                    for (int k = 0; k < 3; k++)
                        assert_float_equal(wgt_px(ub, x, y, k), gold_fn(x, y, k), 1e-6);
            }
        }
    assert_true(covered > 1000);
    wg_result_free(res[0]);
    wg_result_free(res[1]);
    wg_image_unref(gold);
    wg_image_unref(coin);
    wg_image_unref(spec);
    wg_image_unref(deep);
    material_free(&m);
    wg_graph_free(g);
}

/* ---- wet_preview: clear water is clear ----------------------------------------------------- */

static double white_fn(int x, int y, int k)
{
    (void)x;
    (void)y;
    return k == 3 ? 1 : 0.8;
}
static double grey_env(int x, int y, int k)
{
    (void)x;
    (void)y;
    return k == 3 ? 1 : 0.5;
}

/* A white material wet with water under a uniform grey sky stays neutral: the preview is given
 * water's (clear) absorption, r, g, b within 3 %. */
static void test_preview_clear_water_neutral(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("wet_preview");
    WgImage *white = wgt_image_fn(96, 48, 4, white_fn), *env = wgt_image_fn(64, 32, 4, grey_env);
    WgImage *hgt = wgt_image_fn(W, H, 1, height_fn);
    WgRequest *r = wg_request_new(g);
    set_input(r, "environment", env);
    set_input(r, "basecolor", white);
    set_input(r, "height", hgt);
    set_param(r, "water_level", "0.6");
    wg_request_set_size(r, 48, 48);
    WgError err = {0};
    if (wg_request_add_output(r, "preview_wet", &err)) fail_msg("%s", err.message);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    const WgImage *p = wgt_output(res, "preview_wet");
    for (int y = 0; y < p->height; y++)
        for (int x = 0; x < p->width; x++) {
            const float *c = wg_image_row(p, y) + 4 * x;
            double mx = fmax(c[0], fmax(c[1], c[2])), mn = fmin(c[0], fmin(c[1], c[2]));
            if (mx > 0.01 && mn < 0.97 * mx)
                fail_msg("(%d, %d) is not neutral: %g %g %g", x, y, c[0], c[1], c[2]);
        }
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_image_unref(white);
    wg_image_unref(env);
    wg_image_unref(hgt);
    wg_graph_free(g);
}

/* ---- wet_preview: a gold coin under water stays a gold metal -------------------------------- */

enum { COIN = 64 };
static double coin_r(int x, int y)
{
    double dx = (x + 0.5) / COIN - 0.5, dy = (y + 0.5) / COIN - 0.5;
    return sqrt(dx * dx + dy * dy);
}
/* a pit (height 0.1) of radius 0.3 in a plateau (1) */
static double pit_fn(int x, int y, int k)
{
    (void)k;
    double r = coin_r(x, y);
    return r < 0.25 ? 0.1 : r < 0.3 ? 0.1 + 0.9 * (r - 0.25) / 0.05 : 1;
}
/* a gold disc (sRGB encoded, as the basecolor input is) in grey stone */
static double coin_color_fn(int x, int y, int k)
{
    static const double gold[4] = {1.0, 0.89, 0.61, 1}, stone[4] = {0.5, 0.5, 0.5, 1};
    return coin_r(x, y) < 0.2 ? gold[k] : stone[k];
}
static double coin_metal_fn(int x, int y, int k)
{
    (void)k;
    return coin_r(x, y) < 0.2 ? 1 : 0;
}
static double zero_fn(int x, int y, int k)
{
    (void)x, (void)y, (void)k;
    return 0;
}
static double sky_fn(int x, int y, int k)
{
    double u = (x + 0.5) / 64, v = (y + 0.5) / 32;
    if (k == 3) return 1;
    return v < 0.5 ? 1.5 - 0.5 * u * (k == 0) : 0.05; /* a bright sky over a dark ground */
}
static double one_fn(int x, int y, int k)
{
    (void)x, (void)y, (void)k;
    return 1;
}

/* the mean linear colour of the 9 x 9 pixels at the centre of preview output `name` */
static void coin_view(const WgImage *env, double (*metal)(int, int, int), const char *name,
                      double c[3])
{
    WgGraph *g = load_builtin("wet_preview");
    WgImage *col = wgt_image_fn(COIN, COIN, 4, coin_color_fn);
    WgImage *hgt = wgt_image_fn(COIN, COIN, 1, pit_fn), *mt = wgt_image_fn(COIN, COIN, 1, metal);
    WgRequest *r = wg_request_new(g);
    set_input(r, "environment", env);
    set_input(r, "basecolor", col);
    set_input(r, "height", hgt);
    set_input(r, "metallic", mt);
    set_param(r, "water_level", "0.5");
    set_param(r, "elevation", "70");
    set_param(r, "zoom", "2");
    set_param(r, "exposure", "-1.5"); /* away from the tone curve's shoulder */
    wg_request_set_size(r, COIN, COIN);
    WgError err = {0};
    if (wg_request_add_output(r, name, &err)) fail_msg("%s", err.message);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    const WgImage *p = wgt_output(res, name);
    c[0] = c[1] = c[2] = 0;
    for (int y = p->height / 2 - 4; y <= p->height / 2 + 4; y++)
        for (int x = p->width / 2 - 4; x <= p->width / 2 + 4; x++)
            for (int k = 0; k < 3; k++) c[k] += wgt_px(p, x, y, k) / 81;
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_image_unref(mt);
    wg_image_unref(hgt);
    wg_image_unref(col);
    wg_graph_free(g);
}

/* The coin under clear water, in a white environment: not brighter than dry, its hue kept
 * (chromaticity within 0.02). In a sky over dark ground it still reflects as a metal: unlike
 * the same disc painted (metallic 0) under the same water. */
static void test_preview_gold_under_water(void **state)
{
    (void)state;
    WgImage *white = wgt_image_fn(64, 32, 4, one_fn), *sky = wgt_image_fn(64, 32, 4, sky_fn);
    double d[3], w[3], m[3], p[3];
    coin_view(white, coin_metal_fn, "preview_dry", d);
    coin_view(white, coin_metal_fn, "preview_wet", w);
    coin_view(sky, coin_metal_fn, "preview_wet", m);
    coin_view(sky, zero_fn, "preview_wet", p);
    print_message("gold coin dry (%.3f %.3f %.3f), under water (%.3f %.3f %.3f); in the sky: "
                  "metal (%.3f %.3f %.3f), painted (%.3f %.3f %.3f)\n",
                  d[0], d[1], d[2], w[0], w[1], w[2], m[0], m[1], m[2], p[0], p[1], p[2]);
    double sd = d[0] + d[1] + d[2], sw = w[0] + w[1] + w[2];
    if (!(d[0] > 1.5 * d[2])) fail_msg("the dry coin (%g %g %g) is not gold", d[0], d[1], d[2]);
    double lum_d = 0.2126 * d[0] + 0.7152 * d[1] + 0.0722 * d[2];
    double lum_w = 0.2126 * w[0] + 0.7152 * w[1] + 0.0722 * w[2];
    if (lum_w > lum_d) fail_msg("under water %g, brighter than dry %g", lum_w, lum_d);
    for (int k = 0; k < 3; k++)
        if (fabs(w[k] / sw - d[k] / sd) > 0.02)
            fail_msg("channel %d: chromaticity %g under water, %g dry", k, w[k] / sw, d[k] / sd);
    double sm = m[0] + m[1] + m[2], sp = p[0] + p[1] + p[2];
    if (!(fabs(sm - sp) > 0.05 * sm))
        fail_msg("metal %g and paint %g under water look alike: the metal is lost", sm, sp);
    wg_image_unref(sky);
    wg_image_unref(white);
}

/* ---- the wet material fused ------------------------------------------------------------- */

static WgRequest *wet_request(const WgGraph *g, const Material *m, const char *const *params)
{
    WgRequest *r = wg_request_new(g);
    set_input(r, "basecolor", m->base);
    set_input(r, "height", m->height);
    set_input(r, "normal", m->normal);
    set_input(r, "roughness", m->rough);
    for (int k = 0; params[k]; k += 2) set_param(r, params[k], params[k + 1]);
    return r;
}

static WgResult *render_with(const WgRequest *r, int threads, bool fuse, bool keep)
{
    WgEngineOptions opt = {.threads = threads, .no_fuse = !fuse, .no_memory_cache = !keep};
    WgEngine *e = NULL;
    WgError err = {0};
    if (wg_engine_new(&opt, &e, &err)) fail_msg("engine: %s", err.message);
    WgResult *res = wgt_render_request(e, r);
    if (keep) { /* a second render on the same engine: its buffers are reused, dirty */
        wg_engine_clear_cache(e);
        WgResult *again = wgt_render_request(e, r);
        for (int k = 0; k < wg_result_output_count(res); k++)
            wgt_assert_identical(wg_result_output_image(again, k), wg_result_output_image(res, k));
        wg_result_free(again);
    }
    wg_engine_free(e);
    return res;
}

/* The wet material's point work runs fused (its masks and maps in groups, materialised where
 * they are outputs or read by a blur or distance, the rest in bands, at sizes where that keeps
 * the peak memory within one image of the unfused run), with every output
 * bit-identical to the unfused render for 1, 2 and 3 threads, on a fresh engine and on one whose
 * buffers are reused; at two sizes whose last band is partial, for clear water and for a tinted,
 * scattering liquid with the artistic saturation (the pow and exp paths). No group holds
 * `immersed` with `wet`: the path immersed -> distance -> wet leaves the group and comes back. */
static void test_wet_material_fused_identical(void **state)
{
    (void)state;
    static const int sizes[][2] = {{256, 128}, {203, 157}};
    static const char *const clear[] = {"water_level", "0.55", NULL};
    static const char *const tea[] = {"water_level", "0.6",       "liquid", "tea", "sat_wet",
                                      "0.7",         "sat_moist", "0.3",    NULL};
    static const char *const *const sets[] = {clear, tea};
    WgGraph *g = load_builtin("wet_material");
    for (size_t z = 0; z < 2; z++)
        for (size_t p = 0; p < 2; p++) {
            Material m = material(sizes[z][0], sizes[z][1]);
            WgRequest *r = wet_request(g, &m, sets[p]);
            WgResult *ref = render_with(r, 1, false, false);
            assert_int_equal(wg_result_output_count(ref), 23);
            for (int threads = 1; threads <= 3; threads++) {
                WgResult *fused = render_with(r, threads, true, threads == 2);
                for (int k = 0; k < wg_result_output_count(ref); k++)
                    wgt_assert_identical(wg_result_output_image(fused, k),
                                         wg_result_output_image(ref, k));
                int in_group = 0;
                for (int i = 0; i < wg_result_stat_count(fused); i++)
                    in_group += wg_result_stat(fused, i)->fused > 0;
                if (in_group < 12) fail_msg("%d nodes fused", in_group);
                int group = wgt_stat(fused, "masks/wet")->fused;
                assert_true(group > 0);
                static const char *const fused_too[] = {"masks/moist", "masks/puddles", "tex/under",
                                                        "tex/albedo", "tex/rough"};
                for (size_t k = 0; k < sizeof fused_too / sizeof *fused_too; k++)
                    assert_true(wgt_stat(fused, fused_too[k])->fused > 0);
                assert_true(wgt_stat(fused, "masks/immersed")->fused != group);
                if (threads == 1) { /* run in order: at most one image above unfused */
                    size_t largest = 0;
                    for (int i = 0; i < wg_result_stat_count(ref); i++)
                        if (wg_result_stat(ref, i)->bytes > largest)
                            largest = wg_result_stat(ref, i)->bytes;
                    if (wg_result_peak_bytes(fused) > wg_result_peak_bytes(ref) + largest)
                        fail_msg("fused peak %zu, unfused %zu, largest image %zu",
                                 wg_result_peak_bytes(fused), wg_result_peak_bytes(ref), largest);
                }
                wg_result_free(fused);
            }
            wg_result_free(ref);
            wg_request_free(r);
            material_free(&m);
        }
    wg_graph_free(g);
}

/* A warm render, where the result cache holds the masks and only the texturing nodes that read
 * a changed parameter run (grouped anew, reading cached masks as inputs), equals a cold unfused
 * render of the changed request, for 1 and 2 threads. */
static void test_wet_material_fused_warm_equals_cold(void **state)
{
    (void)state;
    static const char *const before[] = {"water_level", "0.55", "sat_wet", "0.5", NULL};
    static const char *const after[] = {"water_level", "0.55", "sat_wet", "0.5",
                                        "dark_wet",    "0.7",  NULL};
    WgGraph *g = load_builtin("wet_material");
    Material m = material(203, 157);
    WgRequest *r0 = wet_request(g, &m, before), *r1 = wet_request(g, &m, after);
    WgResult *ref = render_with(r1, 1, false, false);
    for (int threads = 1; threads <= 2; threads++) {
        WgEngineOptions opt = {.threads = threads};
        WgEngine *e = NULL;
        WgError err = {0};
        if (wg_engine_new(&opt, &e, &err)) fail_msg("engine: %s", err.message);
        WgResult *cold = wgt_render_request(e, r0);
        WgResult *warm = wgt_render_request(e, r1);
        assert_true(wg_result_evaluated_count(warm) > 0);
        assert_true(wg_result_evaluated_count(warm) < wg_result_evaluated_count(cold));
        assert_int_equal(wgt_stat(warm, "masks/wet")->cache, WG_HIT_MEMORY);
        assert_int_equal(wgt_stat(warm, "tex/under")->cache, WG_COMPUTED);
        for (int k = 0; k < wg_result_output_count(ref); k++)
            wgt_assert_identical(wg_result_output_image(warm, k), wg_result_output_image(ref, k));
        wg_result_free(cold);
        wg_result_free(warm);
        wg_engine_free(e);
    }
    wg_result_free(ref);
    wg_request_free(r0);
    wg_request_free(r1);
    material_free(&m);
    wg_graph_free(g);
}

/* wet_material forwards the painted level and the drying band: a constant `level` image gives
 * every output of the same constant water_level, bit for bit; at drying 1 the band is dry (every
 * output is that of no band); at drying 0 the band (immersed at high_water, out of the water
 * now) has the base colour of the undrained material (clear water: the pores and the film
 * darken it as much as the standing water did) and the film's roughness, not the water's. */
static void test_wet_material_level_and_drying(void **state)
{
    (void)state;
    WgGraph *g = load_builtin("wet_material");
    Material m = material(W, H);
    float v = 0.625f;
    WgImage *c = wgt_image(1, 1, 1, &v);
    static const char *const by_param[] = {"water_level", "0.625", NULL};
    static const char *const by_image[] = {"water_level", "0.1", NULL};
    WgRequest *r = wet_request(g, &m, by_param), *ri = wet_request(g, &m, by_image);
    set_input(ri, "level", c);
    WgResult *a = render_with(r, 2, true, false), *b = render_with(ri, 2, true, false);
    assert_int_equal(wg_result_output_count(a), 23);
    for (int k = 0; k < wg_result_output_count(a); k++)
        wgt_assert_identical(wg_result_output_image(b, k), wg_result_output_image(a, k));
    assert_true(mean_of(wgt_output(a, "immersed")) > 0.1);
    wg_result_free(a);
    wg_result_free(b);
    wg_request_free(r);
    wg_request_free(ri);

    static const char *const low[] = {"water_level", "0.4", NULL};
    static const char *const high[] = {"water_level", "0.7", NULL};
    static const char *const dry[] = {"water_level", "0.4", "high_water", "0.7", "drying", "1", NULL};
    static const char *const d0[] = {"water_level", "0.4", "high_water", "0.7", "drying", "0", NULL};
    WgRequest *rl = wet_request(g, &m, low), *rh = wet_request(g, &m, high),
              *rd = wet_request(g, &m, dry), *r0 = wet_request(g, &m, d0);
    WgResult *nl = render_with(rl, 2, true, false), *nh = render_with(rh, 2, true, false),
             *nd = render_with(rd, 2, true, false), *n0 = render_with(r0, 2, true, false);
    for (int k = 0; k < wg_result_output_count(nl); k++)
        wgt_assert_identical(wg_result_output_image(nd, k), wg_result_output_image(nl, k));
    const WgImage *ih = wgt_output(nh, "immersed"), *il = wgt_output(nl, "immersed");
    const WgImage *bh = wgt_output(nh, "basecolor"), *b0 = wgt_output(n0, "basecolor");
    const WgImage *r0i = wgt_output(n0, "roughness");
    const WgImage *p0 = wgt_output(n0, "puddles");
    int band = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            if (!(wgt_px(ih, x, y, 0) == 1 && wgt_px(il, x, y, 0) == 0)) continue;
            band++;
            for (int k = 0; k < 3; k++)
                if (fabs(wgt_px(b0, x, y, k) - wgt_px(bh, x, y, k)) > 1e-6)
                    fail_msg("band (%d, %d) channel %d: drying 0 gives %g, undrained %g", x, y, k,
                             wgt_px(b0, x, y, k), wgt_px(bh, x, y, k));
            /* darker than dry, where the colour is not black */
            if (wgt_px(m.base, x, y, 1) > 0.05 &&
                !(wgt_px(b0, x, y, 1) < 0.9 * wgt_px(m.base, x, y, 1)))
                fail_msg("band (%d, %d) is not darker at drying 0", x, y);
            double rr = rough_fn(x, y, 0), film = fmin(rr, 0.3), pu = wgt_px(p0, x, y, 0);
            double want = film + (0.02 - film) * pu;
            if (fabs(wgt_px(r0i, x, y, 0) - want) > 1e-5)
                fail_msg("band (%d, %d): roughness %g, the film's %g", x, y, wgt_px(r0i, x, y, 0),
                         want);
        }
    printf("%d band pixels\n", band);
    assert_true(band > 1000);
    wg_result_free(nl);
    wg_result_free(nh);
    wg_result_free(nd);
    wg_result_free(n0);
    wg_request_free(rl);
    wg_request_free(rh);
    wg_request_free(rd);
    wg_request_free(r0);
    wg_image_unref(c);
    material_free(&m);
    wg_graph_free(g);
}

/* wet_gltf and wet_preview forward the level image and the drying and rain parameters to
 * wet_material: a constant level image is the same as that water_level, and a drying band or
 * rain changes what they make. */
static void test_graphs_built_on_wet_material_forward_wetness(void **state)
{
    (void)state;
    Material m = material(W, H);
    float v = 0.625f;
    WgImage *c = wgt_image(1, 1, 1, &v);
    WgImage *env = wgt_image_fn(64, 32, 4, grey_env);
    static const char *const graphs[] = {"wet_gltf", "wet_preview"};
    for (int i = 0; i < 2; i++) {
        WgGraph *g = load_builtin(graphs[i]);
        static const char *const by_param[] = {"water_level", "0.625", NULL};
        static const char *const by_image[] = {"water_level", "0.1", NULL};
        static const char *const drained[] = {"water_level", "0.4", "high_water", "0.7", NULL};
        static const char *const rained[] = {"water_level", "0.4", "rain", "0.8", NULL};
        static const char *const plain[] = {"water_level", "0.4", NULL};
        const char *const *sets[] = {by_param, by_image, drained, rained, plain};
        WgResult *res[5];
        for (int k = 0; k < 5; k++) {
            WgRequest *r = wet_request(g, &m, sets[k]);
            if (k == 1) set_input(r, "level", c);
            if (i == 1) {
                set_input(r, "environment", env);
                wg_request_set_size(r, 48, 48);
            }
            res[k] = render_with(r, 2, true, false);
            wg_request_free(r);
        }
        int n = wg_result_output_count(res[0]);
        assert_true(n > 0);
        for (int k = 0; k < n; k++)
            wgt_assert_identical(wg_result_output_image(res[1], k), wg_result_output_image(res[0], k));
        const char *shown = i == 0 ? "basecolor" : "preview_wet";
        for (int k = 2; k < 4; k++) {
            const WgImage *a = wgt_output(res[k], shown), *b = wgt_output(res[4], shown);
            double diff = 0;
            for (int y = 0; y < a->height; y++)
                for (int x = 0; x < a->width * a->channels; x++)
                    diff = fmax(diff, fabs(wg_image_row(a, y)[x] - wg_image_row(b, y)[x]));
            if (diff < 1e-3)
                fail_msg("%s: %s does not change with %s", graphs[i], shown, sets[k][2]);
        }
        for (int k = 0; k < 5; k++) wg_result_free(res[k]);
        wg_graph_free(g);
    }
    wg_image_unref(c);
    wg_image_unref(env);
    material_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_dry_when_no_zones),
        cmocka_unit_test(test_darker_and_more_saturated),
        cmocka_unit_test(test_immersed_roughness_and_normals),
        cmocka_unit_test(test_outputs_finite_in_range),
        cmocka_unit_test(test_files_16bit_non_square),
        cmocka_unit_test(test_only_basecolor_evaluated),
        cmocka_unit_test(test_wet_material_dry_at_level_0),
        cmocka_unit_test(test_wet_material_wet),
        cmocka_unit_test(test_custom_masks_example),
        cmocka_unit_test(test_darkening_follows_lekner_dorf),
        cmocka_unit_test(test_depths_free_of_height_units),
        cmocka_unit_test(test_water_level_same_everywhere),
        cmocka_unit_test(test_liquid_stains_film),
        cmocka_unit_test(test_layer_maps),
        cmocka_unit_test(test_preview_clear_water_neutral),
        cmocka_unit_test(test_preview_gold_under_water),
        cmocka_unit_test(test_wet_material_fused_identical),
        cmocka_unit_test(test_wet_material_fused_warm_equals_cold),
        cmocka_unit_test(test_wet_material_level_and_drying),
        cmocka_unit_test(test_graphs_built_on_wet_material_forward_wetness),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
