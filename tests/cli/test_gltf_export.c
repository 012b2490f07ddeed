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

/* The z extent (min, max) of the grid's POSITION accessor in a written .gltf. */
static void grid_depth(const char *d, const char *gltf, double *lo, double *hi)
{
    WGT_SH(d, 0,
           "python3 -c 'import json,sys; a=json.load(open(sys.argv[1])); "
           "p=a[\"accessors\"][a[\"meshes\"][0][\"primitives\"][0][\"attributes\"][\"POSITION\"]]; "
           "print(p[\"min\"][1], p[\"max\"][1])' %s > depth.txt",
           gltf);
    FILE *f = fopen(wgt_join(d, "depth.txt"), "r");
    assert_non_null(f);
    assert_int_equal(fscanf(f, "%lf %lf", lo, hi), 2);
    fclose(f);
}

/* height_scale="=expression" follows the graph's parameters, render by render; a value out of
 * range is an error naming the asset and the expression; a bad name is refused at load. */
static void test_height_scale_follows_the_parameters(void **state)
{
    (void)state;
    const char *d = wgt_fresh_dir("depth");
    wgt_write_file(wgt_join(d, "h.wetgraph"),
                   "<wetgraph version=\"1\" size=\"32\">\n"
                   "  <param name=\"depth\" type=\"float\" default=\"8\" min=\"-100\" "
                   "max=\"100\"/>\n"
                   "  <node id=\"n\" type=\"noise\" scale=\"2\"/>\n"
                   "  <node id=\"c\" type=\"uniform\" kind=\"color\" color=\"0.5 0.4 0.3 1\"/>\n"
                   "  <output name=\"base\" from=\"c\"/>\n"
                   "  <output name=\"h\" from=\"n\"/>\n"
                   "  <gltf name=\"relief\" base_color=\"base\" height=\"h\" grid=\"8\"\n"
                   "        height_scale=\"=depth / 256\"/>\n"
                   "</wetgraph>\n");
    double lo1, hi1, lo2, hi2;
    WGT_SH(d, 0, "$WG render h.wetgraph -o a -q");
    grid_depth(d, "a/h_relief.gltf", &lo1, &hi1);
    WGT_SH(d, 0, "$WG render h.wetgraph -o b -q --set depth=32");
    grid_depth(d, "b/h_relief.gltf", &lo2, &hi2);
    /* the relief lies below the plane, height_scale · (h − 1): four times deeper */
    assert_true(lo1 < -0.001);
    assert_float_equal(lo2, 4 * lo1, 1e-6);
    wgt_gltf_validate(d, "b/h_relief.gltf");
    WGT_SH(d, 0, "$WG info h.wetgraph");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "height scale =depth / 256"), 1);
    WGT_SH(d, 0, "$WG info h.wetgraph --json > info.json && python3 -c 'import json; "
           "print(json.load(open(\"info.json\"))[\"gltf\"][0][\"height_scale\"])'");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "=depth / 256"), 1);
    /* a negative depth: refused before anything is written */
    WGT_SH(d, 2, "$WG render h.wetgraph -o c -q --set depth=-10");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "gltf 'relief': height_scale =depth / 256 "
                                                      "gives -0.0390625, outside 0 .. 1e6"),
                     1);
    assert_false(wgt_exists(wgt_join(d, "c")));
    /* a name the graph does not have */
    wgt_write_file(wgt_join(d, "bad.wetgraph"),
                   "<wetgraph version=\"1\" size=\"32\">\n"
                   "  <param name=\"depth\" type=\"float\" default=\"8\"/>\n"
                   "  <node id=\"c\" type=\"uniform\" kind=\"color\" color=\"0.5 0.4 0.3 1\"/>\n"
                   "  <output name=\"base\" from=\"c\"/>\n"
                   "  <gltf name=\"relief\" base_color=\"base\" height_scale=\"=dept / 256\"/>\n"
                   "</wetgraph>\n");
    WGT_SH(d, 2, "$WG check bad.wetgraph");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "bad.wetgraph:5"), 1);
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "did you mean 'depth'?"), 1);
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
        cmocka_unit_test(test_height_scale_follows_the_parameters),
        cmocka_unit_test(test_frames_batches_and_failures),
        cmocka_unit_test(test_wet_gltf),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
