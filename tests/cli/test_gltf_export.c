/* SPDX-License-Identifier: MIT */
/* glTF assets a graph declares (<gltf>), written by `render`: beside the outputs and with them
 * (the maps, the .gltf with its .bin and textures, the .glb), passing Khronos' glTF-Validator;
 * `--output NAME` of an asset renders the outputs it needs and it alone; a frame sequence names
 * each frame's asset; `watch`'s and a batch's writes carry them too; a failed render writes no
 * asset; and `info` lists them. */
#include "wgtest.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SH(d, want, ...)                                                                           \
    do {                                                                                           \
        int st_ = wgt_shell(d, __VA_ARGS__);                                                       \
        if (st_ != (want)) {                                                                       \
            char dump_[1200];                                                                      \
            snprintf(dump_, sizeof dump_, "cat '%s/out' '%s/err' >&2", d, d);                      \
            if (system(dump_)) {                                                                   \
            }                                                                                      \
            fail_msg("exit %d, expected %d: %s", st_, want, #__VA_ARGS__);                         \
        }                                                                                          \
    } while (0)

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

static const char *fresh(const char *name)
{
    static char buf[4][1024];
    static int next;
    char *p = buf[next++ & 3];
    snprintf(p, sizeof buf[0], "%s/%s", wgt_tmpdir(), name);
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", p, p);
    assert_int_equal(system(cmd), 0);
    wgt_write_file(wgt_join(p, "g.wetgraph"), graph);
    return p;
}

/* Khronos' validator on files in d: no error, no warning. */
static void validate(const char *d, const char *files)
{
    const char *src = getenv("WETGRAPH_SOURCE");
    assert_non_null(src);
    char check[1200];
    snprintf(check, sizeof check,
             "%s/tools/gltf-validator/node_modules/gltf-validator/package.json", src);
    if (!wgt_exists(check))
        fail_msg("Khronos' glTF-Validator is not installed: run scripts/install-deps.sh");
    SH(d, 0, "node '%s/tools/gltf-validator/validate.js' %s", src, files);
}

static void test_render_writes_the_assets(void **state)
{
    (void)state;
    const char *d = fresh("all");
    SH(d, 0, "$WG render g.wetgraph -o maps");
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
    validate(d, "maps/g_tile.gltf maps/g_flat.glb");
    /* the asset follows a parameter like the maps do */
    SH(d, 0,
       "cp maps/g_tile_basecolor.png before.png && $WG render g.wetgraph -o maps --set "
       "lvl=1.5 -q && ! cmp -s before.png maps/g_tile_basecolor.png");
    /* info lists the assets */
    SH(d, 0, "$WG info g.wetgraph");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "glTF assets:"), 1);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "tile                 .gltf, grid 16"), 1);
}

static void test_output_selects_an_asset(void **state)
{
    (void)state;
    const char *d = fresh("select");
    SH(d, 0, "$WG render g.wetgraph -o sel --output flat");
    assert_true(wgt_exists(wgt_join(d, "sel/g_flat.glb")));
    assert_true(wgt_exists(wgt_join(d, "sel/g_base.png"))); /* the map it packs */
    assert_false(wgt_exists(wgt_join(d, "sel/g_tile.gltf")));
    assert_false(wgt_exists(wgt_join(d, "sel/g_nrm.png")));
    /* an output alone: no asset */
    SH(d, 0, "$WG render g.wetgraph -o one --output nrm");
    assert_false(wgt_exists(wgt_join(d, "one/g_flat.glb")));
    assert_false(wgt_exists(wgt_join(d, "one/g_tile.gltf")));
    SH(d, 2, "$WG render g.wetgraph -o x --output flta");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "did you mean 'flat'?"), 1);
}

static void test_frames_batches_and_failures(void **state)
{
    (void)state;
    const char *d = fresh("frames");
    SH(d, 0, "$WG render g.wetgraph -o seq --frames 0:1 --output flat -q");
    assert_true(wgt_exists(wgt_join(d, "seq/g_flat_0000.glb")));
    assert_true(wgt_exists(wgt_join(d, "seq/g_flat_0001.glb")));
    validate(d, "seq/g_flat_0001.glb");
    wgt_write_file(wgt_join(d, "list.csv"), "set:lvl,out\n0.2,r0\n0.9,r1\n");
    SH(d, 0, "$WG render g.wetgraph --batch list.csv -q");
    assert_true(wgt_exists(wgt_join(d, "r1/g_tile.gltf")));
    assert_true(wgt_exists(wgt_join(d, "r1/g_flat.glb")));
    /* a failing render (a parameter out of range fails before anything; an output folder that
     * cannot be made fails while writing) leaves no asset */
    SH(d, 2, "$WG render g.wetgraph -o bad --set lvl=5");
    assert_false(wgt_exists(wgt_join(d, "bad")));
    SH(d, 0, "touch blocker");
    SH(d, 1, "$WG render g.wetgraph -o blocker/sub -q");
    assert_false(wgt_exists(wgt_join(d, "blocker/sub")));
}

/* The shipped wet_gltf graph on a real material: the wet maps and the asset, which passes. */
static void test_wet_gltf(void **state)
{
    (void)state;
    const char *d = fresh("wet"), *shared = getenv("WETGRAPH_SHARED");
    assert_non_null(shared);
    const char *m = "materials/bricks102_stonewall_1k/Bricks102_1K-JPG";
    SH(d, 0,
       "$WG render wet_gltf -o w -q --size 96 --set water_level=0.7 --set liquid=tea "
       "--input basecolor='%s/%s_Color.jpg' --input height='%s/%s_Displacement.jpg' "
       "--input normal='%s/%s_NormalGL.jpg' --input roughness='%s/%s_Roughness.jpg'",
       shared, m, shared, m, shared, m, shared, m);
    assert_true(wgt_exists(wgt_join(d, "w/wet_gltf_basecolor.png")));
    assert_true(wgt_exists(wgt_join(d, "w/wet_gltf_wet_clearcoat.png")));
    validate(d, "w/wet_gltf_wet.gltf");
    SH(d, 0, "grep -c KHR_materials_clearcoat w/wet_gltf_wet.gltf");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_writes_the_assets),
        cmocka_unit_test(test_output_selects_an_asset),
        cmocka_unit_test(test_frames_batches_and_failures),
        cmocka_unit_test(test_wet_gltf),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
