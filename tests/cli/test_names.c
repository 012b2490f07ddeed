/* SPDX-License-Identifier: MIT */
/* Output names and formats a pipeline sets: --name patterns ({graph}, {output}, {frame}, {row}
 * and a batch row's columns, with '/' making sub-folders), --format NAME=FMT for one output
 * beside the global --format, and files that two outputs would share refused before anything
 * is rendered. */
#include "wgtest.h"

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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_patterns),
        cmocka_unit_test(test_formats),
        cmocka_unit_test(test_jpeg_and_tga),
        cmocka_unit_test(test_collisions_and_bad_patterns),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
