/* SPDX-License-Identifier: MIT */
/* `env_prefilter` and `preview` at small sizes: the white furnace (a white dielectric of any
 * roughness in a uniform white environment returns white within 2e-3), a perfect mirror
 * (metallic 1, roughness 0, base colour 1) returns the environment in the reflected direction,
 * Fresnel reflectance rising to nearly 1 at grazing view, energy never above the uniform
 * environment for random maps with and without water, water_mask 0 giving the dry render bit
 * for bit, refraction making a submerged stripe look less deep than an unrefracted view does,
 * bit-identical results for 1, 2 and 3 threads, the 2 x 2 repeat showing four equal quarters,
 * NaN-free output on non-finite and huge inputs, and the atlas size check. The multiple-scattering
 * compensation: a white metal of any roughness in a white environment returns white; a rough
 * white metal under a sky over black ground reflects the sky (the dominant direction). A smooth
 * dielectric reflects as the exact Fresnel equations say, within 3 %, and so does the water's
 * surface for its own index. The
 * specular level: F0 = 0.08 x specular at normal incidence, 0.5 where the port is not connected,
 * and it acts under the water too. Under clear water (the default tint): a gold disc sunk in a
 * pit keeps its hue, is not brighter than dry and still reflects as a metal; a white material in
 * a uniform grey environment stays grey. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* The atlas has 8 blocks of 32 x 16, 2 across and 4 down. The engine resamples a node's inputs to
 * its size, so the previews here are rendered at the atlas's own size, where it arrives untouched.
 */
enum { AW = 64, AH = 64 };

static double env_sky(int x, int y, int k)
{
    double u = (x + 0.5) / AW, v = (y + 0.5) / AH; /* the environment spans the image */
    if (k == 3) return 1;
    if (k == 0) return 0.2 + 0.8 * v;
    if (k == 1) return 0.5 + 0.3 * cos(2 * M_PI * u);
    return 0.5;
}

static WgImage *prefilter(const WgImage *env, int threads)
{
    const char *names[] = {"environment"};
    const WgImage *images[] = {env};
    return wgt_node("env_prefilter", "", AW, AH, 1, names, images, 0, threads);
}

static WgImage *const_image(int w, int h, int ch, float v)
{
    WgImage *img = wgt_image(w, h, ch, NULL);
    for (int y = 0; y < h; y++) {
        float *r = wg_image_row(img, y);
        for (int x = 0; x < w * ch; x++) r[x] = (ch == 4 && x % 4 == 3) ? 1 : v;
    }
    return img;
}

typedef struct {
    const char *names[16];
    const WgImage *images[16];
    int n;
} Inputs;

static void in_add(Inputs *in, const char *name, const WgImage *img)
{
    in->names[in->n] = name, in->images[in->n] = img, in->n++;
}

static WgImage *preview(const char *attrs, int w, int h, const Inputs *in, int threads)
{
    return wgt_node("preview", attrs, w, h, in->n, (const char **)in->names,
                    (const WgImage **)in->images, 0, threads);
}

#define LINEAR "tonemap=\"none\" encoding=\"linear\" "

static void test_furnace(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    WgImage *base = const_image(8, 8, 4, 1);
    static const float rough[] = {0, 0.1f, 0.3f, 0.5f, 0.8f, 1};
    for (int r = 0; r < 6; r++) {
        WgImage *rm = const_image(8, 8, 1, rough[r]);
        Inputs in = {0};
        in_add(&in, "environment", atlas);
        in_add(&in, "basecolor", base);
        in_add(&in, "roughness", rm);
        for (int el = 10; el <= 90; el += 40) {
            char attrs[256];
            snprintf(attrs, sizeof attrs, LINEAR "elevation=\"%d\"", el);
            WgImage *out = preview(attrs, AW, AH, &in, 2);
            for (int y = 0; y < AH; y++)
                for (int x = 0; x < AW; x++)
                    for (int k = 0; k < 3; k++)
                        if (fabs(wgt_px(out, x, y, k) - 1) > 2e-3)
                            fail_msg("roughness %g elevation %d (%d,%d): %g, expected 1", rough[r],
                                     el, x, y, wgt_px(out, x, y, k));
            wg_image_unref(out);
        }
        wg_image_unref(rm);
    }
    wg_image_unref(base);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

static void test_mirror(void **state)
{
    (void)state;
    WgImage *env = wgt_image_fn(AW, AH, 4, env_sky), *atlas = prefilter(env, 2);
    WgImage *base = const_image(8, 8, 4, 1), *zero = const_image(8, 8, 1, 0);
    WgImage *one = const_image(8, 8, 1, 1);
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", base);
    in_add(&in, "roughness", zero);
    in_add(&in, "metallic", one);
    for (int el = 20; el <= 80; el += 20) {
        char attrs[256];
        snprintf(attrs, sizeof attrs, LINEAR "elevation=\"%d\" azimuth=\"0\" fov=\"1\"", el);
        WgImage *out = preview(attrs, AW, AH, &in, 2);
        /* the centre ray looks down at elevation el: its reflection goes up at el, v = θ/π,
         * and azimuth +y (u = 0.25) */
        double v = (90.0 - el) / 180, want_r = 0.2 + 0.8 * v, want_g = 0.5;
        double got_r = wgt_px(out, AW / 2, AH / 2, 0), got_g = wgt_px(out, AW / 2, AH / 2, 1);
        if (fabs(got_r - want_r) > 0.02 || fabs(got_g - want_g) > 0.02)
            fail_msg("elevation %d: (%g, %g), expected (%g, %g)", el, got_r, got_g, want_r, want_g);
        wg_image_unref(out);
    }
    wg_image_unref(one);
    wg_image_unref(zero);
    wg_image_unref(base);
    wg_image_unref(atlas);
    wg_image_unref(env);
}

static void test_fresnel_grazing(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    WgImage *black = const_image(8, 8, 4, 0), *zero = const_image(8, 8, 1, 0);
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", black);
    in_add(&in, "roughness", zero);
    static const int els[] = {90, 60, 30, 10, 3, 1};
    double prev = 0;
    for (int i = 0; i < 6; i++) {
        char attrs[256];
        snprintf(attrs, sizeof attrs, LINEAR "elevation=\"%d\" fov=\"1\" zoom=\"20\"", els[i]);
        WgImage *out = preview(attrs, AW, AH, &in, 1);
        double f = wgt_px(out, AW / 2, AH / 2, 0);
        if (i == 0 && fabs(f - 0.04) > 0.005) fail_msg("normal incidence: %g, expected 0.04", f);
        if (i > 0 && !(f > prev)) fail_msg("elevation %d: %g, not above %g", els[i], f, prev);
        if (i == 5 && !(f > 0.8)) fail_msg("grazing: %g, expected > 0.8", f);
        prev = f;
        wg_image_unref(out);
    }
    wg_image_unref(zero);
    wg_image_unref(black);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

static double noise_fn(int x, int y, int k)
{
    return (wg_hash3((uint32_t)x, (uint32_t)y, (uint32_t)k) & 0xffff) / 65535.0;
}

/* Random material and water maps, with the water where `mask` (0 or the random mask). */
static void random_inputs(Inputs *in, WgImage **keep, const WgImage *atlas, bool water,
                          bool mask_zero)
{
    int n = 0;
    in_add(in, "environment", atlas);
    in_add(in, "basecolor", keep[n++] = wgt_image_fn(16, 16, 4, noise_fn));
    in_add(in, "normal", keep[n++] = wgt_image_fn(16, 16, 4, noise_fn));
    in_add(in, "roughness", keep[n++] = wgt_image_fn(16, 16, 1, noise_fn));
    in_add(in, "height", keep[n++] = wgt_image_fn(16, 16, 1, noise_fn));
    in_add(in, "ao", keep[n++] = wgt_image_fn(16, 16, 1, noise_fn));
    in_add(in, "metallic", keep[n++] = wgt_image_fn(16, 16, 1, noise_fn));
    if (water) {
        in_add(in, "water_height", keep[n++] = const_image(16, 16, 1, 0.7f));
        in_add(in, "water_normal", keep[n++] = wgt_image_fn(16, 16, 4, noise_fn));
        in_add(in, "water_roughness", keep[n++] = wgt_image_fn(16, 16, 1, noise_fn));
        in_add(in, "water_specular", keep[n++] = const_image(16, 16, 1, 0.02f));
        in_add(in, "water_mask",
               keep[n++] =
                   mask_zero ? const_image(16, 16, 1, 0) : wgt_image_fn(16, 16, 1, noise_fn));
    }
    keep[n] = NULL;
}

static void unref_all(WgImage **keep)
{
    for (int i = 0; keep[i]; i++) wg_image_unref(keep[i]);
}

static void test_energy(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    for (int water = 0; water < 2; water++) {
        WgImage *keep[16];
        Inputs in = {0};
        random_inputs(&in, keep, atlas, water, false);
        WgImage *out = preview(LINEAR "elevation=\"35\" height_scale=\"0.1\"", AW, AH, &in, 2);
        for (int y = 0; y < AH; y++)
            for (int x = 0; x < AW; x++)
                for (int k = 0; k < 3; k++)
                    if (!(wgt_px(out, x, y, k) <= 1 + 1e-4 && wgt_px(out, x, y, k) >= 0))
                        fail_msg("water %d (%d,%d): %g exceeds the environment's 1", water, x, y,
                                 wgt_px(out, x, y, k));
        wg_image_unref(out);
        unref_all(keep);
    }
    wg_image_unref(atlas);
    wg_image_unref(white);
}

static void test_mask_zero_is_dry(void **state)
{
    (void)state;
    WgImage *env = wgt_image_fn(AW, AH, 4, env_sky), *atlas = prefilter(env, 2);
    const char *attrs = "elevation=\"40\" height_scale=\"0.08\" sun=\"true\" repeat=\"true\"";
    WgImage *k1[16], *k2[16];
    Inputs dry = {0}, wet = {0};
    random_inputs(&dry, k1, atlas, false, false);
    random_inputs(&wet, k2, atlas, true, true);
    WgImage *a = preview(attrs, AW, AH, &dry, 2), *b = preview(attrs, AW, AH, &wet, 2);
    wgt_assert_identical(a, b);
    /* and the water does change the picture where its mask is not 0 */
    WgImage *k3[16];
    Inputs wet2 = {0};
    random_inputs(&wet2, k3, atlas, true, false);
    WgImage *c = preview(attrs, AW, AH, &wet2, 2);
    assert_true(wgt_max_abs_diff(a, c) > 0.01);
    wg_image_unref(a);
    wg_image_unref(b);
    wg_image_unref(c);
    unref_all(k1);
    unref_all(k2);
    unref_all(k3);
    wg_image_unref(atlas);
    wg_image_unref(env);
}

/* A bright stripe across the floor of a deep, clear pool: the row where it appears. */
static double stripe_row(const WgImage *atlas, double ior)
{
    enum { T = 64 };
    WgImage *base = wgt_image(T, T, 4, NULL);
    for (int y = 0; y < T; y++)
        for (int x = 0; x < T; x++) {
            float *p = wg_image_row(base, y) + 4 * x;
            float v = (y >= 16 && y < 24) ? 1.0f : 0.05f;
            p[0] = p[1] = p[2] = v, p[3] = 1;
        }
    WgImage *floor0 = const_image(T, T, 1, 0), *surface = const_image(T, T, 1, 1);
    WgImage *mask = const_image(T, T, 1, 1), *white = const_image(AW, AH, 4, 1);
    WgImage *a = prefilter(white, 1);
    (void)atlas;
    Inputs in = {0};
    in_add(&in, "environment", a);
    in_add(&in, "basecolor", base);
    in_add(&in, "height", floor0);
    in_add(&in, "water_height", surface);
    in_add(&in, "water_mask", mask);
    char attrs[256];
    snprintf(attrs, sizeof attrs,
             LINEAR "elevation=\"40\" azimuth=\"0\" fov=\"1\" zoom=\"2\" height_scale=\"0.3\" "
                    "water_ior=\"%g\" water_tint=\"1 1 1\"",
             ior);
    int H = AH;
    WgImage *out = preview(attrs, AW, AH, &in, 2);
    double sw = 0, sy = 0;
    for (int y = 0; y < H; y++) {
        double v = wgt_px(out, AW / 2, y, 0);
        if (v > 0.3) sw += v, sy += v * y;
    }
    wg_image_unref(out);
    wg_image_unref(a);
    wg_image_unref(white);
    wg_image_unref(mask);
    wg_image_unref(surface);
    wg_image_unref(floor0);
    wg_image_unref(base);
    assert_true(sw > 0);
    return sy / sw;
}

static void test_refraction_raises_floor(void **state)
{
    (void)state;
    /* The camera looks along +y from below the tile. Unrefracted, the stripe on the floor
     * 0.3 tile widths deep is seen through the surface 0.3/tan(40°) before it; refracted, the
     * ray bends towards the vertical and meets the floor sooner, so the stripe is seen through
     * a surface point closer to it (a higher row of the picture): it looks shallower, raised
     * towards the viewer, by about the depth ratio tan θt / tan θi. */
    double plain = stripe_row(NULL, 1.0), water = stripe_row(NULL, 1.33);
    /* Where the stripe should be seen: through the surface hs / tan(el) before it unrefracted,
     * hs · tan θt with sin θt = cos(el) / 1.33 refracted; a length along the tile shows as
     * sin(el) of it on the image plane, whose half height is 0.5 / zoom = 0.25 (AH / 2 rows). */
    double el = 40 * M_PI / 180, hs = 0.3, st = cos(el) / 1.33;
    double off_plain = hs / tan(el), off_water = hs * st / sqrt(1 - st * st);
    double rows = (off_plain - off_water) * sin(el) * (AH / 2) / 0.25;
    print_message("stripe row: %g unrefracted, %g refracted, expected %g rows apart\n", plain,
                  water, rows);
    if (!(water < plain - 3) || fabs((plain - water) - rows) > 2)
        fail_msg("stripe at row %g refracted, %g unrefracted: expected %g rows higher", water,
                 plain, rows);
}

static void test_threads(void **state)
{
    (void)state;
    WgImage *env = wgt_image_fn(AW, AH, 4, env_sky);
    WgImage *a1 = prefilter(env, 1), *a2 = prefilter(env, 2), *a3 = prefilter(env, 3);
    wgt_assert_identical(a1, a2);
    wgt_assert_identical(a1, a3);
    WgImage *keep[16];
    Inputs in = {0};
    random_inputs(&in, keep, a1, true, false);
    const char *attrs = "elevation=\"30\" height_scale=\"0.1\" sun=\"true\"";
    WgImage *o1 = preview(attrs, AW, AH, &in, 1), *o2 = preview(attrs, AW, AH, &in, 2);
    WgImage *o3 = preview(attrs, AW, AH, &in, 3);
    wgt_assert_identical(o1, o2);
    wgt_assert_identical(o1, o3);
    wg_image_unref(o1);
    wg_image_unref(o2);
    wg_image_unref(o3);
    unref_all(keep);
    wg_image_unref(a1);
    wg_image_unref(a2);
    wg_image_unref(a3);
    wg_image_unref(env);
}

/* Seen from straight above with a narrow field of view in a uniform environment, `repeat` shows
 * the tile 2 x 2: each quarter of the picture is the same (the maps wrap), up to the view
 * direction's small change across the picture. */
static void test_repeat_tiles(void **state)
{
    (void)state;
    WgImage *env = const_image(AW, AH, 4, 0.5f), *atlas = prefilter(env, 2);
    WgImage *base = wgt_image_fn(16, 16, 4, noise_fn);
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", base);
    WgImage *out =
        preview(LINEAR "elevation=\"90\" azimuth=\"0\" fov=\"1\" repeat=\"true\"", AW, AH, &in, 2);
    double worst = 0;
    for (int y = 0; y < AH / 2; y++)
        for (int x = 0; x < AW / 2; x++)
            for (int k = 0; k < 3; k++) {
                double a = wgt_px(out, x, y, k), b = wgt_px(out, x + AW / 2, y, k);
                double c = wgt_px(out, x, y + AH / 2, k);
                worst = fmax(worst, fmax(fabs(a - b), fabs(a - c)));
            }
    if (worst > 1e-4) fail_msg("quarters differ by %g", worst);
    /* and the picture is not flat: the quarters agree because the tile repeats */
    assert_true(wgt_max_abs_diff(out, atlas) > 0);
    wg_image_unref(out);
    wg_image_unref(base);
    wg_image_unref(atlas);
    wg_image_unref(env);
}

static double extreme_fn(int x, int y, int k)
{
    static const double v[] = {NAN, INFINITY, -INFINITY, 1e30, -1e30, 0, 1, 3e38, -5, 0.5};
    return v[(x * 3 + y * 7 + k) % 10];
}

static void test_extreme_inputs(void **state)
{
    (void)state;
    WgImage *env = wgt_image_fn(AW, AH, 4, extreme_fn), *atlas = prefilter(env, 2);
    for (int y = 0; y < AH; y++)
        for (int x = 0; x < AW; x++)
            for (int k = 0; k < 4; k++)
                if (!isfinite(wgt_px(atlas, x, y, k))) fail_msg("atlas (%d,%d) not finite", x, y);
    static const char *names[] = {"environment",     "basecolor",      "normal",
                                  "roughness",       "height",         "ao",
                                  "metallic",        "water_height",   "water_normal",
                                  "water_roughness", "water_specular", "water_mask",
                                  "specular"};
    WgImage *maps[13];
    Inputs in = {0};
    for (int i = 0; i < 13; i++) {
        bool color = i == 1 || i == 2 || i == 8;
        maps[i] = i == 0 ? NULL : wgt_image_fn(9, 9, color ? 4 : 1, extreme_fn);
        in_add(&in, names[i], i == 0 ? atlas : maps[i]);
    }
    static const char *attrs[] = {
        "sun=\"true\" sun_intensity=\"1000000\" exposure=\"20\" height_scale=\"1\"",
        "sun=\"true\" elevation=\"1\" height_scale=\"0\" encoding=\"srgb\"",
        LINEAR "repeat=\"true\" pom_steps=\"1\" exposure=\"-20\"",
    };
    for (int a = 0; a < 3; a++) {
        WgImage *out = preview(attrs[a], AW, AH, &in, 2);
        for (int y = 0; y < AH; y++)
            for (int x = 0; x < AW; x++)
                for (int k = 0; k < 4; k++)
                    if (!isfinite(wgt_px(out, x, y, k)))
                        fail_msg("%s: (%d,%d) is %g", attrs[a], x, y, wgt_px(out, x, y, k));
        wg_image_unref(out);
    }
    for (int i = 1; i < 13; i++) wg_image_unref(maps[i]);
    wg_image_unref(atlas);
    wg_image_unref(env);
}

/* A white metal (F0 = 1) loses no energy at any roughness: what single scattering misses (the
 * split-sum A + B < 1 of a rough lobe) is returned by the multiple-scattering term. */
static void test_furnace_metal(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    WgImage *base = const_image(8, 8, 4, 1), *one = const_image(8, 8, 1, 1);
    static const float rough[] = {0.2f, 0.5f, 0.7f, 1};
    for (int r = 0; r < 4; r++) {
        WgImage *rm = const_image(8, 8, 1, rough[r]);
        Inputs in = {0};
        in_add(&in, "environment", atlas);
        in_add(&in, "basecolor", base);
        in_add(&in, "roughness", rm);
        in_add(&in, "metallic", one);
        for (int el = 15; el <= 90; el += 25) {
            char attrs[256];
            snprintf(attrs, sizeof attrs, LINEAR "elevation=\"%d\"", el);
            WgImage *out = preview(attrs, AW, AH, &in, 2);
            for (int y = 0; y < AH; y++)
                for (int x = 0; x < AW; x++)
                    if (fabs(wgt_px(out, x, y, 1) - 1) > 2e-3)
                        fail_msg("metal, roughness %g elevation %d (%d,%d): %g, expected 1",
                                 rough[r], el, x, y, wgt_px(out, x, y, 1));
            wg_image_unref(out);
        }
        wg_image_unref(rm);
    }
    wg_image_unref(one);
    wg_image_unref(base);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

static double env_upper(int x, int y, int k)
{
    (void)x;
    return k == 3 ? 1 : (y + 0.5) / AH < 0.5 ? 1 : 0;
}

/* Under a sky of 1 above the horizon and black ground, a flat rough white metal reflects only
 * the sky (its lobe times n·l is zero below its horizon): 1. The split sum prefiltered around
 * the mirror direction would gather the black ground into a rough lobe seen at a low angle;
 * read along the dominant direction it stays within 8 % (it fell to 0.8 at 20 degrees). */
static void test_rough_lobe_horizon(void **state)
{
    (void)state;
    WgImage *env = wgt_image_fn(AW, AH, 4, env_upper), *atlas = prefilter(env, 2);
    WgImage *base = const_image(8, 8, 4, 1), *one = const_image(8, 8, 1, 1);
    static const float rough[] = {0.7f, 0.85f, 1};
    for (int r = 0; r < 3; r++) {
        WgImage *rm = const_image(8, 8, 1, rough[r]);
        Inputs in = {0};
        in_add(&in, "environment", atlas);
        in_add(&in, "basecolor", base);
        in_add(&in, "roughness", rm);
        in_add(&in, "metallic", one);
        for (int el = 20; el <= 60; el += 40) {
            char attrs[256];
            snprintf(attrs, sizeof attrs, LINEAR "elevation=\"%d\" fov=\"1\" zoom=\"20\"", el);
            WgImage *out = preview(attrs, AW, AH, &in, 2);
            double c = wgt_px(out, AW / 2, AH / 2, 1);
            print_message("roughness %g elevation %d: %g\n", rough[r], el, c);
            if (fabs(c - 1) > 0.08)
                fail_msg("roughness %g elevation %d: %g, expected 1", rough[r], el, c);
            wg_image_unref(out);
        }
        wg_image_unref(rm);
    }
    wg_image_unref(one);
    wg_image_unref(base);
    wg_image_unref(atlas);
    wg_image_unref(env);
}

/* The Fresnel term follows the exact reflectance of a dielectric of index 1.5 (F0 0.04), which
 * Schlick's (1 − c)⁵ undershoots by 11-21 % between 40° and 60° from the normal: a smooth black
 * dielectric in a white environment reflects within 3 % of it. */
static void test_fresnel_exact(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    WgImage *black = const_image(8, 8, 4, 0), *zero = const_image(8, 8, 1, 0);
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", black);
    in_add(&in, "roughness", zero);
    static const int els[] = {50, 40, 30, 20};
    for (int i = 0; i < 4; i++) {
        char attrs[256];
        snprintf(attrs, sizeof attrs, LINEAR "elevation=\"%d\" fov=\"1\" zoom=\"20\"", els[i]);
        WgImage *out = preview(attrs, AW, AH, &in, 1);
        double f = wgt_px(out, AW / 2, AH / 2, 0);
        double c = sin(els[i] * M_PI / 180), g = sqrt(1.25 + c * c);
        double a = (g - c) / (g + c), b = (c * (g + c) - 1) / (c * (g - c) + 1);
        double exact = 0.5 * a * a * (1 + b * b);
        print_message("incidence %d: %g, exact %g\n", 90 - els[i], f, exact);
        if (fabs(f / exact - 1) > 0.03)
            fail_msg("incidence %d degrees: reflectance %g, exact %g", 90 - els[i], f, exact);
        wg_image_unref(out);
    }
    wg_image_unref(zero);
    wg_image_unref(black);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

/* The water's surface reflects as the exact Fresnel equations of its index say: smooth water of
 * index 1.33 (water_specular = its F0) whose tint absorbs all the light that enters, so what is
 * seen is the reflection alone, in a uniform white environment, returns F(θ) within 3 % from 40°
 * to 75° of incidence (the rescaled index-1.5 curve was 19 % high at 60° and 15 % at 70°). */
static void test_water_fresnel_exact(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    WgImage *grey = const_image(8, 8, 4, 0.5f), *floor0 = const_image(8, 8, 1, 0);
    WgImage *surface = const_image(8, 8, 1, 1), *one = const_image(8, 8, 1, 1);
    WgImage *zero = const_image(8, 8, 1, 0);
    double n = 1.33, r0 = (n - 1) / (n + 1);
    WgImage *f0 = const_image(8, 8, 1, (float)(r0 * r0));
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", grey);
    in_add(&in, "height", floor0);
    in_add(&in, "water_height", surface);
    in_add(&in, "water_mask", one);
    in_add(&in, "water_roughness", zero);
    in_add(&in, "water_specular", f0);
    static const int els[] = {50, 40, 30, 20, 15};
    for (int i = 0; i < 5; i++) {
        char attrs[256];
        snprintf(attrs, sizeof attrs,
                 LINEAR "elevation=\"%d\" fov=\"1\" zoom=\"20\" height_scale=\"0.3\" "
                        "water_tint=\"0 0 0\" absorption_depth=\"0.01\"",
                 els[i]);
        WgImage *out = preview(attrs, AW, AH, &in, 1);
        double f = wgt_px(out, AW / 2, AH / 2, 0);
        double c = sin(els[i] * M_PI / 180), g = sqrt(n * n - 1 + c * c);
        double a = (g - c) / (g + c), b = (c * (g + c) - 1) / (c * (g - c) + 1);
        double exact = 0.5 * a * a * (1 + b * b);
        print_message("water, incidence %d: %g, exact %g\n", 90 - els[i], f, exact);
        if (fabs(f / exact - 1) > 0.03)
            fail_msg("water, incidence %d degrees: reflectance %g, exact %g", 90 - els[i], f,
                     exact);
        wg_image_unref(out);
    }
    wg_image_unref(f0);
    wg_image_unref(zero);
    wg_image_unref(one);
    wg_image_unref(surface);
    wg_image_unref(floor0);
    wg_image_unref(grey);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

/* A T x T map: height 1 on the rows above `wall_row` (the tile's far side, seen from azimuth 0),
 * 0 below; or a constant. */
static WgImage *wall_map(int t, int wall_row, float below, float above)
{
    WgImage *img = wgt_image(t, t, 1, NULL);
    for (int y = 0; y < t; y++)
        for (int x = 0; x < t; x++) wg_image_row(img, y)[x] = y < wall_row ? above : below;
    return img;
}

/* The water's mirror sees the relief that stands out of it. A pool (the floor 0.3 tile widths
 * down, the water halfway) against a black wall on the tile's far side, seen from 20° in a white
 * environment, the water's tint absorbing what enters (so the reflection alone is seen): where
 * the mirror ray meets the wall, the water reflects the dark wall (under half of what the same
 * pool without the wall reflects); far from the wall it reflects the sky exactly as without it.
 * Water pixels are those where the picture changes when the water's mask is 0. */
static void test_water_mirrors_relief(void **state)
{
    (void)state;
    enum { T = 64, WALL = 24 };
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    WgImage *black = const_image(T, T, 4, 0), *rough = const_image(T, T, 1, 0.5f);
    WgImage *wall = wall_map(T, WALL, 0, 1), *flat = wall_map(T, WALL, 0, 0);
    WgImage *surface = const_image(T, T, 1, 0.5f), *wzero = const_image(T, T, 1, 0);
    WgImage *mask = wall_map(T, WALL + 1, 1, 0), *nomask = const_image(T, T, 1, 0);
    const char *attrs = LINEAR "elevation=\"20\" azimuth=\"0\" fov=\"40\" height_scale=\"0.3\" "
                               "water_tint=\"0 0 0\" absorption_depth=\"0.01\"";
    WgImage *out[3];
    const WgImage *heights[3] = {wall, flat, wall}, *masks[3] = {mask, mask, nomask};
    for (int k = 0; k < 3; k++) {
        Inputs in = {0};
        in_add(&in, "environment", atlas);
        in_add(&in, "basecolor", black);
        in_add(&in, "roughness", rough);
        in_add(&in, "height", heights[k]);
        in_add(&in, "water_height", surface);
        in_add(&in, "water_roughness", wzero);
        in_add(&in, "water_mask", masks[k]);
        out[k] = preview(attrs, AW, AH, &in, 2);
    }
    int water = 0, dark = 0, open = 0;
    for (int y = 0; y < AH; y++)
        for (int x = AW / 4; x < 3 * AW / 4; x++) {
            double a = wgt_px(out[0], x, y, 0), b = wgt_px(out[1], x, y, 0);
            double dry = wgt_px(out[2], x, y, 0);
            if (a == dry) continue; /* not water */
            water++;
            if (a < 0.5 * b) dark++;
            if (fabs(a - b) <= 1e-6 * b) open++;
        }
    print_message("water pixels %d, reflecting the wall %d, the sky as without it %d\n", water,
                  dark, open);
    assert_true(water > 200);
    assert_true(dark > water / 10);
    assert_true(open > water / 4);
    for (int k = 0; k < 3; k++) wg_image_unref(out[k]);
    wg_image_unref(nomask);
    wg_image_unref(mask);
    wg_image_unref(wzero);
    wg_image_unref(surface);
    wg_image_unref(flat);
    wg_image_unref(wall);
    wg_image_unref(rough);
    wg_image_unref(black);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

/* F0 of a dielectric = 0.08 x specular: seen straight down, a smooth black material in a
 * white environment reflects F0 (plus the lobe's tiny bias); an unconnected port is 0.5. */
static double spec_center(const WgImage *atlas, const WgImage *spec, const WgImage *black,
                          const WgImage *rough)
{
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", black);
    in_add(&in, "roughness", rough);
    if (spec) in_add(&in, "specular", spec);
    WgImage *out = preview(LINEAR "elevation=\"90\" fov=\"1\" zoom=\"20\"", AW, AH, &in, 1);
    double f = wgt_px(out, AW / 2, AH / 2, 0);
    wg_image_unref(out);
    return f;
}

static void test_specular_level(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    WgImage *black = const_image(8, 8, 4, 0), *rough = const_image(8, 8, 1, 0.05f);
    static const float levels[] = {0, 0.25f, 0.5f, 1};
    for (int i = 0; i < 4; i++) {
        WgImage *sp = const_image(8, 8, 1, levels[i]);
        double f = spec_center(atlas, sp, black, rough);
        if (fabs(f - 0.08 * levels[i]) > 0.004)
            fail_msg("specular %g: reflectance %g, expected %g", levels[i], f, 0.08 * levels[i]);
        wg_image_unref(sp);
    }
    WgImage *half = const_image(8, 8, 1, 0.5f);
    assert_float_equal(spec_center(atlas, NULL, black, rough),
                       spec_center(atlas, half, black, rough), 0);
    wg_image_unref(half);
    wg_image_unref(rough);
    wg_image_unref(black);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

/* A PT x PT tile that is `inner` within radius r of the centre and `outer` around it. */
enum { PT = 48 };
static WgImage *pit_map(int ch, float inner, float outer, float r)
{
    WgImage *img = wgt_image(PT, PT, ch, NULL);
    for (int y = 0; y < PT; y++)
        for (int x = 0; x < PT; x++) {
            double dx = (x + 0.5) / PT - 0.5, dy = (y + 0.5) / PT - 0.5;
            float v = dx * dx + dy * dy < r * r ? inner : outer;
            float *p = wg_image_row(img, y) + ch * x;
            for (int k = 0; k < ch; k++) p[k] = (ch == 4 && k == 3) ? 1 : v;
        }
    return img;
}

/* The scene the under-water cases look into: a round pit (floor at height 0.3 within radius 0.3
 * of the centre, 1 around it), filled with water to height 0.85. */
typedef struct {
    WgImage *height, *water_height, *water_mask;
} Pit;

static Pit pit_open(void)
{
    return (Pit){pit_map(1, 0.3f, 1, 0.3f), pit_map(1, 0.85f, 1, 0.3f), pit_map(1, 1, 0, 0.3f)};
}

/* Connects the pit's height and, with water, its water. */
static void pit_add(Inputs *in, const Pit *pit, bool water)
{
    in_add(in, "height", pit->height);
    if (!water) return;
    in_add(in, "water_height", pit->water_height);
    in_add(in, "water_mask", pit->water_mask);
}

static void pit_close(Pit *pit)
{
    wg_image_unref(pit->water_mask);
    wg_image_unref(pit->water_height);
    wg_image_unref(pit->height);
}

static WgImage *gold_map(void)
{
    static const float gold[3] = {1.0f, 0.766f, 0.336f}, stone[3] = {0.3f, 0.3f, 0.3f};
    WgImage *img = wgt_image(PT, PT, 4, NULL);
    for (int y = 0; y < PT; y++)
        for (int x = 0; x < PT; x++) {
            double dx = (x + 0.5) / PT - 0.5, dy = (y + 0.5) / PT - 0.5;
            const float *c = dx * dx + dy * dy < 0.2 * 0.2 ? gold : stone;
            float *p = wg_image_row(img, y) + 4 * x;
            p[0] = c[0], p[1] = c[1], p[2] = c[2], p[3] = 1;
        }
    return img;
}

/* Mean linear colour of the centre 9 x 9 pixels. */
static void centre_mean(const WgImage *img, double c[3])
{
    c[0] = c[1] = c[2] = 0;
    for (int y = AH / 2 - 4; y <= AH / 2 + 4; y++)
        for (int x = AW / 2 - 4; x <= AW / 2 + 4; x++)
            for (int k = 0; k < 3; k++) c[k] += wgt_px(img, x, y, k) / 81;
}

static WgImage *render_pit(const WgImage *atlas, const WgImage *base, const WgImage *metal,
                           bool water, const char *camera)
{
    Pit pit = pit_open();
    WgImage *rough = const_image(PT, PT, 1, 0.3f), *wr = const_image(PT, PT, 1, 0.02f);
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", base);
    in_add(&in, "roughness", rough);
    in_add(&in, "metallic", metal);
    pit_add(&in, &pit, water);
    if (water) in_add(&in, "water_roughness", wr);
    char attrs[256];
    snprintf(attrs, sizeof attrs, LINEAR "azimuth=\"0\" fov=\"30\" height_scale=\"0.1\" %s",
             camera);
    WgImage *out = preview(attrs, AW, AH, &in, 2);
    wg_image_unref(wr);
    wg_image_unref(rough);
    pit_close(&pit);
    return out;
}

/* A gold disc sunk in a pit under clear water stays a gold metal. In a uniform white
 * environment (where what the disc reflects does not depend on where the refracted ray sends
 * it): its luminance not above the dry one, no channel brighter by more than the water's own
 * reflection (0.03), its chromaticity within 0.02 of the dry one, more than half as bright. In a
 * graded sky: still shaded as a metal, reflecting the sky, so unlike the same disc painted
 * (metallic 0) under the same water. */
static void test_gold_under_water(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    WgImage *env = wgt_image_fn(AW, AH, 4, env_sky), *sky = prefilter(env, 2);
    WgImage *gold = gold_map(), *metal = pit_map(1, 1, 0, 0.2f), *paint = const_image(PT, PT, 1, 0);
    const char *cam = "elevation=\"65\" zoom=\"2\"";
    WgImage *dry = render_pit(atlas, gold, metal, false, cam);
    WgImage *wet = render_pit(atlas, gold, metal, true, cam);
    WgImage *sky_metal = render_pit(sky, gold, metal, true, cam);
    WgImage *painted = render_pit(sky, gold, paint, true, cam);
    double d[3], w[3], m[3], p[3];
    centre_mean(dry, d), centre_mean(wet, w), centre_mean(sky_metal, m), centre_mean(painted, p);
    print_message("gold dry (%.3f %.3f %.3f), under clear water (%.3f %.3f %.3f)\n", d[0], d[1],
                  d[2], w[0], w[1], w[2]);
    double sd = d[0] + d[1] + d[2], sw = w[0] + w[1] + w[2], sp = p[0] + p[1] + p[2];
    double lum_d = 0.2126 * d[0] + 0.7152 * d[1] + 0.0722 * d[2];
    double lum_w = 0.2126 * w[0] + 0.7152 * w[1] + 0.0722 * w[2];
    if (lum_w > lum_d) fail_msg("luminance %g under water, brighter than dry %g", lum_w, lum_d);
    for (int k = 0; k < 3; k++) {
        /* a channel may gain the water's own (white) reflection, a few percent */
        if (w[k] > d[k] + 0.03)
            fail_msg("channel %d: %g under water, brighter than dry %g", k, w[k], d[k]);
        if (fabs(w[k] / sw - d[k] / sd) > 0.02)
            fail_msg("channel %d: chromaticity %g under water, %g dry", k, w[k] / sw, d[k] / sd);
    }
    if (!(sw > 0.5 * sd)) fail_msg("under water %g, less than half of dry %g", sw, sd);
    double sm = m[0] + m[1] + m[2];
    print_message("under water in the sky: metal (%.3f %.3f %.3f), painted (%.3f %.3f %.3f)\n",
                  m[0], m[1], m[2], p[0], p[1], p[2]);
    if (!(fabs(sp - sm) > 0.05 * sm))
        fail_msg("metal %g and paint %g under water look alike: metallic is not used", sm, sp);
    wg_image_unref(painted);
    wg_image_unref(sky_metal);
    wg_image_unref(sky);
    wg_image_unref(env);
    wg_image_unref(wet);
    wg_image_unref(dry);
    wg_image_unref(paint);
    wg_image_unref(metal);
    wg_image_unref(gold);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

/* Clear water adds no colour: a white material in a pit under the default water, in a uniform
 * grey environment, is grey everywhere (r, g, b within 3 % of each other). And the specular
 * level of the material under the water is used there. */
static void test_clear_water_neutral(void **state)
{
    (void)state;
    WgImage *grey = const_image(AW, AH, 4, 0.5f), *atlas = prefilter(grey, 2);
    WgImage *white = const_image(PT, PT, 4, 1), *zero = const_image(PT, PT, 1, 0);
    static const int els[] = {20, 50, 80};
    for (int i = 0; i < 3; i++) {
        char extra[64];
        snprintf(extra, sizeof extra, "elevation=\"%d\"", els[i]);
        WgImage *out = render_pit(atlas, white, zero, true, extra);
        for (int y = 0; y < AH; y++)
            for (int x = 0; x < AW; x++) {
                double r = wgt_px(out, x, y, 0), g = wgt_px(out, x, y, 1), b = wgt_px(out, x, y, 2);
                double lo = fmin(r, fmin(g, b)), hi = fmax(r, fmax(g, b));
                if (!(hi <= lo * 1.03))
                    fail_msg("elevation %d (%d,%d): (%g %g %g) is not grey", els[i], x, y, r, g, b);
            }
        wg_image_unref(out);
    }
    wg_image_unref(zero);
    wg_image_unref(white);
    wg_image_unref(atlas);
    wg_image_unref(grey);
}

/* The white furnace under water: a flat floor whose base colour is what the maps give a white
 * material under water (Lekner and Dorf's albedo 1 − r_e, r_e = 0.067 for water), under smooth
 * clear water in a white environment, returns 1 within 2 % seen from 90° to 20°: every bit of
 * light comes back out, through the surface or reflected by it. Counting the surface twice (the
 * base colour already holds the way in and out) returned 0.87. */
static void test_under_water_furnace(void **state)
{
    (void)state;
    WgImage *white = const_image(AW, AH, 4, 1), *atlas = prefilter(white, 2);
    double n = 1.333, ri = -1.440 / (n * n) + 0.710 / n + 0.668 + 0.0636 * n;
    double re = 1 - n * n * (1 - ri), r0 = (n - 1) / (n + 1);
    WgImage *base = const_image(8, 8, 4, (float)(1 - re)), *floor0 = const_image(8, 8, 1, 0);
    WgImage *surface = const_image(8, 8, 1, 1), *one = const_image(8, 8, 1, 1);
    WgImage *zero = const_image(8, 8, 1, 0), *rough = const_image(8, 8, 1, 0.5f);
    WgImage *f0 = const_image(8, 8, 1, (float)(r0 * r0));
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", base);
    in_add(&in, "roughness", rough);
    in_add(&in, "height", floor0);
    in_add(&in, "water_height", surface);
    in_add(&in, "water_mask", one);
    in_add(&in, "water_roughness", zero);
    in_add(&in, "water_specular", f0);
    static const int els[] = {90, 60, 40, 20};
    for (int i = 0; i < 4; i++) {
        char attrs[256];
        snprintf(attrs, sizeof attrs,
                 LINEAR "elevation=\"%d\" fov=\"1\" zoom=\"20\" height_scale=\"0.05\"", els[i]);
        WgImage *out = preview(attrs, AW, AH, &in, 1);
        double v = wgt_px(out, AW / 2, AH / 2, 0);
        print_message("under water, elevation %d: %g\n", els[i], v);
        if (fabs(v - 1) > 0.02) fail_msg("elevation %d: %g, expected 1 within 2 %%", els[i], v);
        wg_image_unref(out);
    }
    wg_image_unref(f0);
    wg_image_unref(rough);
    wg_image_unref(zero);
    wg_image_unref(one);
    wg_image_unref(surface);
    wg_image_unref(floor0);
    wg_image_unref(base);
    wg_image_unref(atlas);
    wg_image_unref(white);
}

/* The specular level of the material under the water changes what is seen through it. */
static void test_specular_under_water(void **state)
{
    (void)state;
    WgImage *env = wgt_image_fn(AW, AH, 4, env_sky), *atlas = prefilter(env, 2);
    WgImage *black = const_image(PT, PT, 4, 0.02f), *zero = const_image(PT, PT, 1, 0);
    Pit pit = pit_open();
    double c[2][3];
    for (int i = 0; i < 2; i++) {
        WgImage *sp = const_image(PT, PT, 1, i ? 1.0f : 0.0f);
        Inputs in = {0};
        in_add(&in, "environment", atlas);
        in_add(&in, "basecolor", black);
        in_add(&in, "roughness", zero);
        in_add(&in, "specular", sp);
        pit_add(&in, &pit, true);
        WgImage *out = preview(LINEAR "elevation=\"70\" azimuth=\"0\" fov=\"30\" zoom=\"2\" "
                                      "height_scale=\"0.1\"",
                               AW, AH, &in, 2);
        centre_mean(out, c[i]);
        wg_image_unref(out);
        wg_image_unref(sp);
    }
    print_message("under water, specular 0: %g, specular 1: %g\n", c[0][1], c[1][1]);
    if (!(c[1][1] > c[0][1] * 1.5))
        fail_msg("specular 1 under water %g is not well above specular 0 %g", c[1][1], c[0][1]);
    pit_close(&pit);
    wg_image_unref(zero);
    wg_image_unref(black);
    wg_image_unref(atlas);
    wg_image_unref(env);
}

/* The water_tint input, where connected, is the tint: a uniform tint image gives the same
 * pixels (to float rounding) as the same colour in the parameter (which it overrides), and tea's
 * tint darkens the blue of a white floor under the water far more than its red. */
static WgImage *render_tinted(const WgImage *atlas, const char *tint_attr, const WgImage *tint)
{
    WgImage *white = const_image(PT, PT, 4, 1);
    Pit pit = pit_open();
    Inputs in = {0};
    in_add(&in, "environment", atlas);
    in_add(&in, "basecolor", white);
    pit_add(&in, &pit, true);
    if (tint) in_add(&in, "water_tint", tint);
    char attrs[256];
    snprintf(attrs, sizeof attrs,
             LINEAR "azimuth=\"0\" fov=\"30\" height_scale=\"0.1\" elevation=\"65\" "
                    "zoom=\"2\" absorption_depth=\"1\" %s",
             tint_attr);
    WgImage *out = preview(attrs, AW, AH, &in, 2);
    pit_close(&pit);
    wg_image_unref(white);
    return out;
}

static void test_tint_input(void **state)
{
    (void)state;
    WgImage *grey = const_image(AW, AH, 4, 0.5f), *atlas = prefilter(grey, 2);
    WgImage *tea = wgt_image(PT, PT, 4, NULL);
    for (int y = 0; y < PT; y++) {
        float *r = wg_image_row(tea, y);
        for (int x = 0; x < PT; x++)
            r[4 * x] = 0.8f, r[4 * x + 1] = 0.4f, r[4 * x + 2] = 0.1f, r[4 * x + 3] = 1;
    }
    WgImage *by_param = render_tinted(atlas, "water_tint=\"0.8 0.4 0.1\"", NULL);
    /* the input wins over a different parameter */
    WgImage *by_input = render_tinted(atlas, "water_tint=\"1 1 1\"", tea);
    WgImage *clear = render_tinted(atlas, "", NULL);
    wgt_assert_near(by_param, by_input, 1e-6); /* bilinear weights of a uniform image */
    double t[3], c[3];
    centre_mean(by_input, t), centre_mean(clear, c);
    print_message("white floor under clear water (%.3f %.3f %.3f), under tea (%.3f %.3f %.3f)\n",
                  c[0], c[1], c[2], t[0], t[1], t[2]);
    if (!(t[2] < 0.5 * c[2] && t[0] > t[2] * 2))
        fail_msg("tea's tint is not applied: blue %g (clear %g), red %g", t[2], c[2], t[0]);
    wg_image_unref(clear);
    wg_image_unref(by_input);
    wg_image_unref(by_param);
    wg_image_unref(tea);
    wg_image_unref(atlas);
    wg_image_unref(grey);
}

static void test_atlas_size_error(void **state)
{
    (void)state;
    WgImage *env = const_image(8, 8, 4, 1);
    const char *names[] = {"environment"};
    const WgImage *images[] = {env};
    WgError err;
    int rc = wgt_node_error("env_prefilter", "", 30, 30, 1, names, images, &err);
    assert_int_equal(rc, WG_ERR_RANGE);
    wgt_assert_error(&err, WG_ERR_RANGE, 0, "env_prefilter|square|30x30");
    wg_image_unref(env);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_furnace),
        cmocka_unit_test(test_mirror),
        cmocka_unit_test(test_fresnel_grazing),
        cmocka_unit_test(test_energy),
        cmocka_unit_test(test_mask_zero_is_dry),
        cmocka_unit_test(test_refraction_raises_floor),
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_repeat_tiles),
        cmocka_unit_test(test_extreme_inputs),
        cmocka_unit_test(test_atlas_size_error),
        cmocka_unit_test(test_furnace_metal),
        cmocka_unit_test(test_specular_level),
        cmocka_unit_test(test_gold_under_water),
        cmocka_unit_test(test_clear_water_neutral),
        cmocka_unit_test(test_specular_under_water),
        cmocka_unit_test(test_rough_lobe_horizon),
        cmocka_unit_test(test_fresnel_exact),
        cmocka_unit_test(test_water_mirrors_relief),
        cmocka_unit_test(test_water_fresnel_exact),
        cmocka_unit_test(test_under_water_furnace),
        cmocka_unit_test(test_tint_input),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
