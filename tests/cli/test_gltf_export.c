/* SPDX-License-Identifier: MIT */
/* glTF assets a graph declares (<gltf>), written by `render`: beside the outputs and with them
 * (the maps, the .gltf with its .bin and textures, the .glb), passing Khronos' glTF-Validator;
 * the assets' files follow --name as the outputs do; `--output NAME` of an asset renders the outputs it needs and it alone; a frame sequence names
 * each frame's asset; `watch`'s and a batch's writes carry them too; a failed render writes no
 * asset; and `info` lists them. */
#include "wgtest.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const graph =
    "<wetgraph version=\"1\" size=\"64\">\n"
    "  <param name=\"lvl\" type=\"float\" default=\"0.5\" min=\"0\" max=\"2\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
    "  <node id=\"c\" type=\"pixel\" kind=\"color\" expr=\"rgb(a * lvl, 0.5, 0.2)\" lvl=\"=lvl\">"
    "<in name=\"a\" from=\"n\"/></node>\n"
    "  <node id=\"nm\" type=\"normal\"><in name=\"height\" from=\"n\"/></node>\n"
    "  <output name=\"base\" from=\"c\" colorspace=\"srgb\"/>\n"
    "  <output name=\"h\" from=\"n\"/>\n"
    "  <output name=\"nrm\" from=\"nm\"/>\n"
    "  <gltf name=\"tile\" base_color=\"base\" normal=\"nrm\" roughness=\"h\" clearcoat=\"h\" "
    "height=\"h\" grid=\"16\" height_scale=\"0.05\"/>\n"
    "  <gltf name=\"flat\" binary=\"true\" base_color=\"base\"/>\n"
    "</wetgraph>\n";

/* An empty folder holding g.wetgraph. */
static const char *fresh(const char *name)
{
    const char *d = wgt_fresh_dir(name);
    wgt_write_file(wgt_join(d, "g.wetgraph"), graph);
    return d;
}

static void test_render_writes_the_assets(void **state)
{
    (void)state;
    const char *d = fresh("all");
    WGT_SH(d, 0, "$WG render g.wetgraph -o maps");
    static const char *const files[] = {
        "g_base.png",     "g_h.png",           "g_nrm.png",
        "g_tile.gltf",    "g_tile.bin",        "g_tile_basecolor.png",
        "g_tile_orm.png", "g_tile_normal.png", "g_tile_clearcoat.png",
        "g_flat.glb"};
    for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
        char p[64];
        snprintf(p, sizeof p, "maps/%s", files[i]);
        if (!wgt_exists(wgt_join(d, p))) fail_msg("%s not written", p);
    }
    /* listed with the outputs */
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "maps/g_tile.gltf"), 1);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "maps/g_flat.glb"), 1);
    wgt_gltf_validate(d, "maps/g_tile.gltf maps/g_flat.glb");
    /* the asset follows a parameter like the maps do */
    WGT_SH(d, 0,
           "cp maps/g_tile_basecolor.png before.png && $WG render g.wetgraph -o maps --set "
           "lvl=1.5 -q && ! cmp -s before.png maps/g_tile_basecolor.png");
    /* info lists the assets */
    WGT_SH(d, 0, "$WG info g.wetgraph");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "glTF assets:"), 1);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "tile                 .gltf, grid 16"), 1);
}

static void test_output_selects_an_asset(void **state)
{
    (void)state;
    const char *d = fresh("select");
    WGT_SH(d, 0, "$WG render g.wetgraph -o sel --output flat");
    assert_true(wgt_exists(wgt_join(d, "sel/g_flat.glb")));
    assert_true(wgt_exists(wgt_join(d, "sel/g_base.png"))); /* the map it packs */
    assert_false(wgt_exists(wgt_join(d, "sel/g_tile.gltf")));
    assert_false(wgt_exists(wgt_join(d, "sel/g_nrm.png")));
    /* an output alone: no asset */
    WGT_SH(d, 0, "$WG render g.wetgraph -o one --output nrm");
    assert_false(wgt_exists(wgt_join(d, "one/g_flat.glb")));
    assert_false(wgt_exists(wgt_join(d, "one/g_tile.gltf")));
    WGT_SH(d, 2, "$WG render g.wetgraph -o x --output flta");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "did you mean 'flat'?"), 1);
}

/* --name names the assets as it names the outputs: {output} is the asset's name, {group} "gltf",
 * a '/' makes a folder; an asset and an output that would be one file are refused. */
static void test_assets_follow_the_name_pattern(void **state)
{
    (void)state;
    const char *d = fresh("named");
    WGT_SH(d, 0, "$WG render g.wetgraph -o o --name '{group}/{graph}-{output}'");
    static const char *const files[] = {"other/g-base.png", "other/g-h.png", "gltf/g-tile.gltf",
                                        "gltf/g-tile.bin",  "gltf/g-tile_basecolor.png",
                                        "gltf/g-flat.glb"};
    for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
        char p[64];
        snprintf(p, sizeof p, "o/%s", files[i]);
        if (!wgt_exists(wgt_join(d, p))) fail_msg("%s not written", p);
    }
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "o/gltf/g-tile.gltf"), 1);
    assert_false(wgt_exists(wgt_join(d, "o/g_tile.gltf")));
    wgt_gltf_validate(d, "o/gltf/g-tile.gltf o/gltf/g-flat.glb");
    /* in a sequence, {frame} names each frame's asset */
    WGT_SH(d, 0, "$WG render g.wetgraph -o f --frames 0:1 --name '{output}.{frame}' -q");
    assert_true(wgt_exists(wgt_join(d, "f/tile.0001.gltf")));
    assert_true(wgt_exists(wgt_join(d, "f/flat.0000.glb")));
    /* two assets written to one file: refused before rendering, nothing written */
    wgt_write_file(wgt_join(d, "two.wetgraph"),
                   "<wetgraph version=\"1\" size=\"16\">\n"
                   "  <node id=\"c\" type=\"uniform\" kind=\"color\" color=\"0.5 0.4 0.3 1\"/>\n"
                   "  <output name=\"base\" from=\"c\"/>\n"
                   "  <gltf name=\"a\" base_color=\"base\"/>\n"
                   "  <gltf name=\"b\" base_color=\"base\"/>\n"
                   "</wetgraph>\n");
    WGT_SH(d, 2, "$WG render two.wetgraph -o x --name '{graph}'");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "'a' and 'b' would both be written to "
                                                      "x/two.gltf (--name '{graph}')"),
                     1);
    assert_false(wgt_exists(wgt_join(d, "x")));
}

static void test_frames_batches_and_failures(void **state)
{
    (void)state;
    const char *d = fresh("frames");
    WGT_SH(d, 0, "$WG render g.wetgraph -o seq --frames 0:1 --output flat -q");
    assert_true(wgt_exists(wgt_join(d, "seq/g_flat_0000.glb")));
    assert_true(wgt_exists(wgt_join(d, "seq/g_flat_0001.glb")));
    wgt_gltf_validate(d, "seq/g_flat_0001.glb");
    wgt_write_file(wgt_join(d, "list.csv"), "set:lvl,out\n0.2,r0\n0.9,r1\n");
    WGT_SH(d, 0, "$WG render g.wetgraph --batch list.csv -q");
    assert_true(wgt_exists(wgt_join(d, "r1/g_tile.gltf")));
    assert_true(wgt_exists(wgt_join(d, "r1/g_flat.glb")));
    /* a failing render (a parameter out of range fails before anything; an output folder that
     * cannot be made fails while writing) leaves no asset */
    WGT_SH(d, 2, "$WG render g.wetgraph -o bad --set lvl=5");
    assert_false(wgt_exists(wgt_join(d, "bad")));
    WGT_SH(d, 0, "touch blocker");
    WGT_SH(d, 1, "$WG render g.wetgraph -o blocker/sub -q");
    assert_false(wgt_exists(wgt_join(d, "blocker/sub")));
}

/* The shipped wet_gltf graph on a real material: the wet maps and the asset, which passes. */
static void test_wet_gltf(void **state)
{
    (void)state;
    const char *d = fresh("wet"), *shared = getenv("WETGRAPH_SHARED");
    assert_non_null(shared);
    const char *m = "materials/bricks102_stonewall_1k/Bricks102_1K-JPG";
    WGT_SH(d, 0,
           "$WG render wet_gltf -o w -q --size 96 --set water_level=0.7 --set liquid=tea "
           "--input basecolor='%s/%s_Color.jpg' --input height='%s/%s_Displacement.jpg' "
           "--input normal='%s/%s_NormalGL.jpg' --input roughness='%s/%s_Roughness.jpg'",
           shared, m, shared, m, shared, m, shared, m);
    assert_true(wgt_exists(wgt_join(d, "w/wet_gltf_basecolor.png")));
    assert_true(wgt_exists(wgt_join(d, "w/wet_gltf_wet_clearcoat.png")));
    wgt_gltf_validate(d, "w/wet_gltf_wet.gltf");
    WGT_SH(d, 0, "grep -c KHR_materials_clearcoat w/wet_gltf_wet.gltf");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_writes_the_assets),
        cmocka_unit_test(test_output_selects_an_asset),
        cmocka_unit_test(test_assets_follow_the_name_pattern),
        cmocka_unit_test(test_frames_batches_and_failures),
        cmocka_unit_test(test_wet_gltf),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
