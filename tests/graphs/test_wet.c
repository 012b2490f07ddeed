/* SPDX-License-Identifier: MIT */
/* The wet-material graphs (graphs/texturing.wetgraph, graphs/wet_material.wetgraph) on small
 * synthetic materials: empty masks give back the dry material; the wet base colour is never
 * brighter than the dry one and not less saturated; immersed parts get the liquid's roughness
 * and, away from the meniscus, upward normals; every output is finite and in range, also for
 * non-square and 16-bit inputs; and asking for one output evaluates only the nodes it needs. */
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
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
