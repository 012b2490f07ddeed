/* SPDX-License-Identifier: MIT */
/* `wetgraph render --frames`: file names, each frame equal to a single render at its $time,
 * nodes that do not depend on $time computed once for the sequence (from --stats=json) and
 * outputs that do not either encoded once (later frames' files are copies), what
 * the engine holds between frames not growing with their number, the
 * contact sheet's layout and pixels, layered EXR names, and usage errors. Runs WETGRAPH_BIN. */
#include "wgtest.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

static const char graph[] =
    "<wetgraph version=\"1\" size=\"64x32\">\n"
    "  <param name=\"speed\" type=\"float\" default=\"0.5\"/>\n"
    "  <node id=\"land\" type=\"shape\" kind=\"disk\" radius=\"0.4\"/>\n"
    "  <node id=\"dist\" type=\"distance\" distance=\"40\"><in name=\"mask\" "
    "from=\"land\"/></node>\n"
    "  <node id=\"wave\" type=\"sine\" frequency=\"3\" phase=\"=speed * $time\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"multiply\">\n"
    "    <in name=\"foreground\" from=\"wave\"/><in name=\"background\" from=\"dist\"/>\n"
    "  </node>\n"
    "  <output name=\"foam\" from=\"mix\" format=\"exr32\"/>\n"
    "  <output name=\"dist\" from=\"dist\" format=\"exr32\"/>\n"
    "</wetgraph>\n";

static char dir[1024];

static const char *path(const char *name)
{
    return wgt_join(dir, name);
}

/* Run `wetgraph ARGS` in dir; returns the exit status, stdout and stderr in files out / err. */
static int run(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int run(const char *fmt, ...)
{
    char args[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(args, sizeof args, fmt, ap);
    va_end(ap);
    return wgt_shell(dir, "\"$WG\" %s", args);
}

static WgImage *load(const char *p, int channels)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(p, channels, WG_LINEAR, &img, &err)) fail_msg("%s: %s", p, err.message);
    return img;
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s/frames", wgt_tmpdir());
    mkdir(dir, 0777);
    FILE *f = fopen(path("anim.wetgraph"), "w");
    assert_non_null(f);
    fputs(graph, f);
    fclose(f);
    return 0;
}

/* Frames 0..3 at 2 fps: the names, and frame k equals a render with --time k/2. */
static void test_frames_match_single_renders(void **state)
{
    (void)state;
    assert_int_equal(run("render anim.wetgraph --frames 0:3 --fps 2 -o seq -q"), 0);
    for (int k = 0; k <= 3; k++) {
        char name[64];
        snprintf(name, sizeof name, "seq/anim_foam_%04d.exr", k);
        assert_true(wgt_exists(path(name)));
        snprintf(name, sizeof name, "seq/anim_dist_%04d.exr", k);
        assert_true(wgt_exists(path(name)));
        char one[64];
        snprintf(one, sizeof one, "one%d", k);
        assert_int_equal(run("render anim.wetgraph --time %g -o %s -q", k / 2.0, one), 0);
        char a[80], b[80];
        snprintf(a, sizeof a, "seq/anim_foam_%04d.exr", k);
        snprintf(b, sizeof b, "%s/anim_foam.exr", one);
        WgImage *x = load(path(a), 1), *y = load(path(b), 1);
        wgt_assert_identical(x, y);
        wg_image_unref(x);
        wg_image_unref(y);
    }
    assert_false(wgt_exists(path("seq/anim_foam_0004.exr")));
    assert_false(wgt_exists(path("seq/anim_foam.exr")));
    /* the animation moves: frame 1 differs from frame 0 */
    WgImage *f0 = load(path("seq/anim_foam_0000.exr"), 1),
            *f1 = load(path("seq/anim_foam_0001.exr"), 1);
    double diff = 0;
    for (int y = 0; y < f0->height; y++)
        for (int x = 0; x < f0->width; x++) diff += fabs(wgt_px(f0, x, y, 0) - wgt_px(f1, x, y, 0));
    assert_true(diff > 1);
    wg_image_unref(f0);
    wg_image_unref(f1);
}

/* --time is the start: frame 3 at 4 fps from --time 1 is $time 1.75; numbers keep 4 digits
 * and grow past them. */
static void test_time_offset_and_numbering(void **state)
{
    (void)state;
    assert_int_equal(run("render anim.wetgraph --frames 3:3 --fps 4 --time 1 -o off -q"), 0);
    assert_int_equal(run("render anim.wetgraph --time 1.75 -o offone -q"), 0);
    WgImage *x = load(path("off/anim_foam_0003.exr"), 1),
            *y = load(path("offone/anim_foam.exr"), 1);
    wgt_assert_identical(x, y);
    wg_image_unref(x);
    wg_image_unref(y);
    assert_int_equal(run("render anim.wetgraph --frames 12345:12345 --output dist -o big -q"), 0);
    assert_true(wgt_exists(path("big/anim_dist_12345.exr")));
}

/* The distance transform of the shore does not depend on $time: computed once, then reused. */
static void test_untimed_nodes_run_once(void **state)
{
    (void)state;
    assert_int_equal(run("render anim.wetgraph --frames 0:4 -o st -q --stats=json"), 0);
    char *json = wgt_read_file(path("out"), NULL);
    assert_non_null(json);
    assert_non_null(strstr(json, "\"frames\": 5"));
    const char *d = strstr(json, "\"id\": \"dist\"");
    const char *w = strstr(json, "\"id\": \"wave\"");
    if (!d || !w) fail_msg("no dist or wave in:\n%s", json);
    if (strncmp(strstr(d, "\"computed\""), "\"computed\": 1, \"reused\": 4", 26))
        fail_msg("dist should be computed once:\n%s", json);
    if (strncmp(strstr(w, "\"computed\""), "\"computed\": 5, \"reused\": 0", 26))
        fail_msg("wave should be computed every frame:\n%s", json);
    free(json);
}

/* An output that does not change with $time is encoded once: each later frame's file is a copy
 * of the frame before's, byte for byte, and counted as copied; the timed output is encoded
 * every frame. A second run over the same files keeps every one of them. */
static void test_unchanged_outputs_copied(void **state)
{
    (void)state;
    static const char *const runs[] = {"\"files\": {\"written\": 5, \"copied\": 3, \"kept\": 0}",
                                       "\"files\": {\"written\": 0, \"copied\": 0, \"kept\": 8}"};
    for (int r = 0; r < 2; r++) {
        assert_int_equal(run("render anim.wetgraph --frames 0:3 -o cp -q --stats=json"), 0);
        char *json = wgt_read_file(path("out"), NULL);
        assert_non_null(json);
        if (!strstr(json, runs[r])) fail_msg("run %d: no %s in:\n%s", r + 1, runs[r], json);
        free(json);
    }
    for (int k = 1; k <= 3; k++) {
        char name[64];
        snprintf(name, sizeof name, "cp/anim_dist_%04d.exr", k);
        assert_true(wgt_same_file(path("cp/anim_dist_0000.exr"), path(name)));
    }
}

/* "held_bytes" of a --stats=json report */
static long long held_bytes(const char *json)
{
    const char *h = strstr(json, "\"held_bytes\": ");
    if (!h) fail_msg("no held_bytes in:\n%s", json);
    return atoll(h + 14);
}

/* What the engine holds between frames (its memory cache and its idle buffers, by its own
 * accounting) does not grow with the number of frames: 20 frames hold what 5 do, for several
 * sizes and with one and two workers. */
static void test_memory_does_not_grow_with_frames(void **state)
{
    (void)state;
    static const char *const sizes[] = {"64x32", "96x80"};
    for (int v = 0; v < 2; v++)
        for (int t = 1; t <= 2; t++) {
            long long held[2];
            static const char *const ranges[] = {"0:4", "0:19"};
            for (int k = 0; k < 2; k++) {
                assert_int_equal(run("render anim.wetgraph --frames %s --size %s --threads %d "
                                     "-o mem -q --stats=json",
                                     ranges[k], sizes[v], t),
                                 0);
                char *json = wgt_read_file(path("out"), NULL);
                held[k] = held_bytes(json);
                free(json);
            }
            if (held[0] <= 0 || held[1] > held[0])
                fail_msg("%s, %d threads: %lld bytes held after 5 frames, %lld after 20", sizes[v],
                         t, held[0], held[1]);
        }
}

/* 5 frames of 64×32 on a grid of 3 columns and 2 rows, cells 64×32 with 4-pixel gaps; each
 * cell is its frame (box average of 1 pixel: the frame itself). */
static void test_contact_sheet(void **state)
{
    (void)state;
    assert_int_equal(run("render anim.wetgraph --frames 0:4 --output foam -o cs "
                         "--contact-sheet cs/sheet.png -q"),
                     0);
    WgImage *sheet = load(path("cs/sheet.png"), 1);
    assert_int_equal(sheet->width, 4 + 3 * (64 + 4));
    assert_int_equal(sheet->height, 4 + 2 * (32 + 4));
    for (int k = 0; k < 5; k++) {
        char name[64];
        snprintf(name, sizeof name, "cs/anim_foam_%04d.exr", k);
        WgImage *f = load(path(name), 1);
        int x0 = 4 + (k % 3) * 68, y0 = 4 + (k / 3) * 36;
        for (int y = 0; y < 32; y++)
            for (int x = 0; x < 64; x++) /* the sheet is an 8-bit PNG of the linear values */
                if (fabs(wgt_px(sheet, x0 + x, y0 + y, 0) - wgt_px(f, x, y, 0)) > 0.5 / 255 + 1e-6)
                    fail_msg("frame %d at (%d,%d): sheet %g, frame %g", k, x, y,
                             wgt_px(sheet, x0 + x, y0 + y, 0), wgt_px(f, x, y, 0));
        wg_image_unref(f);
    }
    /* the unused sixth cell is background */
    assert_float_equal(wgt_px(sheet, 4 + 2 * 68 + 10, 4 + 36 + 10, 0), 0.05, 0.5 / 255 + 1e-6);
    wg_image_unref(sheet);
}

static void test_layered_frames(void **state)
{
    (void)state;
    assert_int_equal(run("render anim.wetgraph --frames 0:1 --layered lay/all.exr -q"), 0);
    assert_true(wgt_exists(path("lay/all_0000.exr")));
    assert_true(wgt_exists(path("lay/all_0001.exr")));
    assert_false(wgt_exists(path("lay/all.exr")));
}

static void test_usage_errors(void **state)
{
    (void)state;
    static const struct {
        const char *args, *message;
    } cases[] = {
        {"--frames 5:2", "bad --frames '5:2'"},
        {"--frames 1", "bad --frames '1'"},
        {"--frames a:b", "bad --frames 'a:b'"},
        {"--frames -1:2", "bad --frames '-1:2'"},
        {"--frames 0:200000", "at most 100000 frames"},
        {"--frames 0:2 --fps 0", "bad --fps '0'"},
        {"--frames 0:2 --fps nan", "bad --fps 'nan'"},
        {"--frames 0:2 --contact-sheet x.jpg", "must end in .png"},
        {"--contact-sheet x.png", "--contact-sheet needs --frames"},
        {"--fps 3", "--fps needs --frames"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        int st = run("render anim.wetgraph %s -o bad", cases[i].args);
        char *err = wgt_read_file(path("err"), NULL);
        if (st != 2 || !err || !strstr(err, cases[i].message))
            fail_msg("'%s': exit %d, stderr:\n%s", cases[i].args, st, err ? err : "");
        free(err);
    }
    assert_false(wgt_exists(path("bad")));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_frames_match_single_renders),
        cmocka_unit_test(test_time_offset_and_numbering),
        cmocka_unit_test(test_untimed_nodes_run_once),
        cmocka_unit_test(test_unchanged_outputs_copied),
        cmocka_unit_test(test_memory_does_not_grow_with_frames),
        cmocka_unit_test(test_contact_sheet),
        cmocka_unit_test(test_layered_frames),
        cmocka_unit_test(test_usage_errors),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
