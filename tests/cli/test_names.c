/* SPDX-License-Identifier: MIT */
/* Output names and formats a pipeline sets: --name patterns ({graph}, {output}, {frame}, {row}
 * and a batch row's columns, with '/' making sub-folders), --format NAME=FMT for one output
 * beside the global --format, and files that two outputs would share refused before anything
 * is rendered. The built-in graphs' layer maps and masks carry no word of a PBR map's name,
 * checked by the words rule of name-matching tools and by Blender's Node Wrangler itself. */
#include "wgtest.h"

#include <ctype.h>
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const graph = "<wetgraph version=\"1\" size=\"16\">\n"
                                 "  <param name=\"lvl\" type=\"float\" default=\"0.5\" min=\"0\" "
                                 "max=\"2\"/>\n"
                                 "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
                                 "  <node id=\"c\" type=\"levels\" out_high=\"=lvl\"><in "
                                 "name=\"source\" from=\"n\"/></node>\n"
                                 "  <output name=\"base\" from=\"c\" group=\"maps\"/>\n"
                                 "  <output name=\"h\" from=\"n\" format=\"exr\"/>\n"
                                 "</wetgraph>\n";

/* An empty folder holding g.wetgraph. */
static const char *fresh(const char *name)
{
    const char *d = wgt_fresh_dir(name);
    wgt_write_file(wgt_join(d, "g.wetgraph"), graph);
    return d;
}

static void expect(const char *d, const char *file, bool there)
{
    if (wgt_exists(wgt_join(d, file)) != there)
        fail_msg("%s %s", file, there ? "not written" : "written");
}

static void test_patterns(void **state)
{
    (void)state;
    const char *d = fresh("patterns");
    WGT_SH(d, 0, "$WG render g.wetgraph -o o --name 'maps/{output}/{graph}' -q");
    expect(d, "o/maps/base/g.png", true);
    expect(d, "o/maps/h/g.exr", true);
    /* each output's group a folder, "other" without one */
    WGT_SH(d, 0, "$WG render g.wetgraph -o k --name '{group}/{output}' -q");
    expect(d, "k/maps/base.png", true);
    expect(d, "k/other/h.exr", true);
    WGT_SH(d, 0, "$WG render g.wetgraph -o f --frames 2:3 --name '{output}_{frame}' -q");
    expect(d, "f/base_0002.png", true);
    expect(d, "f/h_0003.exr", true);
    wgt_write_file(wgt_join(d, "l.csv"), "#mat,set:lvl,out\nstone,0.3,r0\nwood,0.7,r1\n");
    WGT_SH(d, 0, "$WG render g.wetgraph --batch l.csv --name '{#mat}_{output}_{row}_{set:lvl}' -q");
    expect(d, "r0/stone_base_0_0.3.png", true);
    expect(d, "r1/wood_h_1_0.7.exr", true);
}

static void test_formats(void **state)
{
    (void)state;
    const char *d = fresh("formats");
    /* one output's own format over the global one, over the graph's */
    WGT_SH(d, 0, "$WG render g.wetgraph -o a --format h=exr32 --format png16 -q");
    expect(d, "a/g_base.png", true);
    expect(d, "a/g_h.exr", true);
    /* the PNG 16-bit (IHDR's bit depth), the EXR float (larger than the graph's half) */
    FILE *f = fopen(wgt_join(d, "a/g_base.png"), "rb");
    assert_non_null(f);
    unsigned char head[26];
    assert_int_equal(fread(head, 1, 26, f), 26);
    fclose(f);
    assert_int_equal(head[24], 16);
    WGT_SH(d, 0, "$WG render g.wetgraph -o half -q");
    WGT_SH(d, 0, "test $(stat -c %%s a/g_h.exr) -gt $(stat -c %%s half/g_h.exr)");
    WGT_SH(d, 0, "$WG render g.wetgraph -o b --format base=exr -q");
    expect(d, "b/g_base.exr", true);
    WGT_SH(d, 2, "$WG render g.wetgraph -o c --format bsae=exr");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "graph 'g' has no output 'bsae'"), 1);
    WGT_SH(d, 2, "$WG render g.wetgraph -o c --format base=jpeg2000");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "unknown --format 'base=jpeg2000'"), 1);
}

/* JPEG (its quality set on the command line) and Targa outputs, through OpenImageIO: a Targa is
 * the 8-bit PNG's pixels exactly; a JPEG is close to them, smaller at a lower quality, and a
 * new quality writes the file again. */
static void test_jpeg_and_tga(void **state)
{
    (void)state;
    const char *d = fresh("jpeg");
    WGT_SH(d, 0, "$WG render g.wetgraph -o p --format png --size 64 -q");
    WGT_SH(d, 0, "$WG render g.wetgraph -o t --format tga --size 64 -q");
    WGT_SH(d, 0, "$WG render g.wetgraph -o lo --format jpeg --jpeg-quality 30 --size 64 -q");
    WGT_SH(d, 0, "$WG render g.wetgraph -o hi --format base=jpg --jpeg-quality 95 --size 64 -q");
    expect(d, "hi/g_h.exr", true);
    WgImage *png = NULL, *tga = NULL, *lo = NULL, *hi = NULL;
    WgError err = {0};
    assert_int_equal(wg_image_read(wgt_join(d, "p/g_base.png"), 1, WG_LINEAR, &png, &err), 0);
    assert_int_equal(wg_image_read(wgt_join(d, "t/g_base.tga"), 1, WG_LINEAR, &tga, &err), 0);
    assert_int_equal(wg_image_read(wgt_join(d, "lo/g_base.jpg"), 1, WG_LINEAR, &lo, &err), 0);
    assert_int_equal(wg_image_read(wgt_join(d, "hi/g_base.jpg"), 1, WG_LINEAR, &hi, &err), 0);
    wgt_assert_identical(tga, png);
    double e_lo = 0, e_hi = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            float v = wg_image_row(png, y)[x];
            e_lo += fabs(wg_image_row(lo, y)[x] - v);
            e_hi += fabs(wg_image_row(hi, y)[x] - v);
        }
    e_lo /= 64 * 64, e_hi /= 64 * 64;
    if (!(e_hi < e_lo && e_hi < 0.01))
        fail_msg("JPEG errors: quality 30 %g, quality 95 %g", e_lo, e_hi);
    WGT_SH(d, 0, "test $(stat -c %%s lo/g_base.jpg) -lt $(stat -c %%s hi/g_base.jpg)");
    /* another quality is another file: written again, not kept */
    WGT_SH(d, 0, "$WG render g.wetgraph -o lo --format jpeg --jpeg-quality 95 --size 64");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "lo/g_base.jpg"), 1);
    WGT_SH(d, 2, "$WG render g.wetgraph -o x --jpeg-quality 101");
    wg_image_unref(png);
    wg_image_unref(tga);
    wg_image_unref(lo);
    wg_image_unref(hi);
}

static void test_collisions_and_bad_patterns(void **state)
{
    (void)state;
    const char *d = fresh("collide");
    /* the two outputs would be one file: refused before rendering, nothing written */
    WGT_SH(d, 2, "$WG render g.wetgraph -o x --name '{graph}' --format png");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "'base' and 'h' would both be written to "
                                                      "x/g.png (--name '{graph}')"),
                     1);
    expect(d, "x", false);
    /* different extensions keep them apart */
    WGT_SH(d, 0, "$WG render g.wetgraph -o y --name '{graph}' -q");
    expect(d, "y/g.png", true);
    expect(d, "y/g.exr", true);
    static const struct {
        const char *args, *msg;
    } bad[] = {
        {"--name '{outptu}'", "unknown placeholder {outptu}"},
        {"--name '{frame}'", "{frame} needs --frames"},
        {"--name '{row}_{output}'", "{row} takes a batch row: it needs --batch"},
        {"--name '{output'", "'{' without '}'"},
        {"--name 'maps/'", "the pattern ends without a file name"},
        {"--frames 0:1 --name '{output}'", "a frame sequence needs {frame} in the name"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        WGT_SH(d, 2, "$WG render g.wetgraph -o z %s", bad[i].args);
        if (!wgt_count_in(wgt_join(d, "err"), bad[i].msg))
            fail_msg("%s: expected '%s'", bad[i].args, bad[i].msg);
    }
    expect(d, "z", false);
}

/* The words a file name is made of, as Blender's Node Wrangler splits it to match maps to
 * inputs: extension and digits dropped, a lower-to-upper case change, '_', '.', '-' and '#'
 * separate words; lower case. Words are written into `words`, space-separated with a leading
 * and trailing space, so " normal " finds the word. */
static void name_words(const char *name, char *words, size_t cap)
{
    size_t n = 0;
    words[n++] = ' ';
    for (const char *c = name; *c && n + 2 < cap; c++) {
        if (isdigit((unsigned char)*c)) continue;
        if (strchr("_.-#", *c)) {
            if (words[n - 1] != ' ') words[n++] = ' ';
            continue;
        }
        if (isupper((unsigned char)*c) && c > name && islower((unsigned char)c[-1]) &&
            words[n - 1] != ' ')
            words[n++] = ' ';
        words[n++] = (char)tolower((unsigned char)*c);
    }
    if (words[n - 1] != ' ') words[n++] = ' ';
    words[n] = '\0';
}

/* Node Wrangler's default words for the Principled BSDF's inputs (Blender 3.4). */
static const char *const pbr_words[] = {
    "diffuse",  "diff",         "albedo",      "base",      "col",      "color",
    "sss",      "subsurface",   "metallic",    "metalness", "metal",    "mtl",
    "specularity", "specular",  "spec",        "spc",       "normal",   "nor",
    "nrm",      "nrml",         "norm",        "bump",      "bmp",      "roughness",
    "rough",    "rgh",          "gloss",       "glossy",    "glossiness", "displacement",
    "displace", "disp",         "dsp",         "height",    "heightmap", "transmission",
    "transparency", "emission", "emissive",    "emit",      "alpha",    "opacity",
    "ao",       "ambient",      "occlusion"};

/* The first PBR word among a name's words, or NULL. */
static const char *pbr_word_in(const char *name)
{
    char words[256], key[64];
    name_words(name, words, sizeof words);
    for (size_t i = 0; i < sizeof pbr_words / sizeof *pbr_words; i++) {
        snprintf(key, sizeof key, " %s ", pbr_words[i]);
        if (strstr(words, key)) return pbr_words[i];
    }
    return NULL;
}

static void test_name_words(void **state)
{
    (void)state;
    assert_string_equal(pbr_word_in("WallTexture_diff_2k.002.jpg"), "diff");
    assert_string_equal(pbr_word_in("wet_material_water_normal.png"), "normal");
    assert_string_equal(pbr_word_in("rockBaseColor.png"), "base");
    assert_string_equal(pbr_word_in("g#AO"), "ao");
    assert_null(pbr_word_in("wet_material_waternormal.png"));
    assert_null(pbr_word_in("wet_material_basecolor.png"));
    assert_null(pbr_word_in("wet_material_underroughness.png"));
}

/* In every built-in graph, a layer map or mask written under its default name
 * (<graph>_<output>) has no word of a PBR map's name: a tool matching one folder's files to a
 * material's inputs never takes it for the material's own map. */
static void test_layer_names_free_of_pbr_words(void **state)
{
    (void)state;
    const char *src = getenv("WETGRAPH_SOURCE");
    assert_non_null(src);
    char dir[4096], path[4096 + 256], file[512];
    snprintf(dir, sizeof dir, "%s/graphs", src);
    DIR *d = opendir(dir);
    assert_non_null(d);
    int checked = 0;
    for (struct dirent *e; (e = readdir(d));) {
        size_t len = strlen(e->d_name);
        if (len < 9 || strcmp(e->d_name + len - 9, ".wetgraph")) continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        WgGraph *g = NULL;
        WgError err = {0};
        if (wg_graph_load(path, &g, &err)) fail_msg("%s", err.message);
        for (int i = 0; i < wg_graph_output_count(g); i++) {
            const WgGraphOutputInfo *o = wg_graph_output_info(g, i);
            if (!o->group || (strcmp(o->group, "layers") && strcmp(o->group, "masks"))) continue;
            snprintf(file, sizeof file, "%.*s_%s.png", (int)(len - 9), e->d_name, o->name);
            const char *w = pbr_word_in(file);
            if (w) fail_msg("%s: output '%s' (group %s) is written as %s: '%s' is a PBR map's word",
                            e->d_name, o->name, o->group, file, w);
            checked++;
        }
        wg_graph_free(g);
    }
    closedir(d);
    assert_true(checked >= 20); /* wet_material's and wet_gltf's layers and masks were seen */
}

/* Blender's Node Wrangler, given every file of a wet_material render (in name order and in
 * reverse), wires the one-surface maps and nothing else; with `basecolor` added to its base
 * colour words, the base colour too. Where Blender is not installed the test is skipped. */
static void test_node_wrangler_wires_the_maps(void **state)
{
    (void)state;
    if (wgt_shell(".", "command -v blender") != 0) {
        print_message("blender not found: Node Wrangler's wiring not checked "
                      "(scripts/install-deps.sh installs it)\n");
        skip();
    }
    const char *src = getenv("WETGRAPH_SOURCE"), *shared = getenv("WETGRAPH_SHARED");
    assert_non_null(src);
    assert_non_null(shared);
    const char *d = wgt_fresh_dir("wrangler");
    WGT_SH(d, 0,
           "m='%s/materials/bricks102_stonewall_1k/Bricks102_1K-JPG' && $WG render wet_material "
           "-o all --size 64x32 --set water_level=0.6 -q --input basecolor=\"${m}_Color.jpg\" "
           "--input height=\"${m}_Displacement.jpg\" --input normal=\"${m}_NormalGL.jpg\" "
           "--input roughness=\"${m}_Roughness.jpg\" --input ao=\"${m}_AmbientOcclusion.jpg\"",
           shared);
    static const char *const ao = "Ambient Occlusion\twet_material_ao.png\n";
    static const char *const wired =
        "Displacement\twet_material_height.png\n"
        "Metallic\twet_material_metallic.png\n"
        "Normal\twet_material_normal.png\n"
        "Roughness\twet_material_roughness.png\n"
        "Specular\twet_material_specular.png\n";
    static const char *const runs[] = {"", "reverse", "reverse basecolor"};
    for (int r = 0; r < 3; r++) {
        WGT_SH(d, 0,
               "blender -b --factory-startup -P '%s/bench/blender_node_wrangler.py' -- all %s "
               "2>/dev/null | grep -P '\\t' | sort > wired.txt",
               src, runs[r]);
        char want[1024];
        snprintf(want, sizeof want, "%s%s%s", ao,
                 r == 2 ? "Base Color\twet_material_basecolor.png\n" : "", wired);
        FILE *f = fopen(wgt_join(d, "wired.txt"), "r");
        assert_non_null(f);
        char got[1024] = {0};
        size_t n = fread(got, 1, sizeof got - 1, f);
        fclose(f);
        got[n] = '\0';
        if (strcmp(got, want)) fail_msg("Node Wrangler (%s) wired:\n%swanted:\n%s", runs[r], got, want);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_patterns),
        cmocka_unit_test(test_formats),
        cmocka_unit_test(test_jpeg_and_tga),
        cmocka_unit_test(test_collisions_and_bad_patterns),
        cmocka_unit_test(test_name_words),
        cmocka_unit_test(test_layer_names_free_of_pbr_words),
        cmocka_unit_test(test_node_wrangler_wires_the_maps),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
