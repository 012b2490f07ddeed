/* SPDX-License-Identifier: MIT */
/* Which commands load OpenImageIO: the wetgraph command (WETGRAPH_BIN) runs with LD_DEBUG=files,
 * which makes the dynamic linker name on stderr every library it loads, at start-up or later by
 * dlopen. `nodes`, `--help`, `check` of graphs reading PNG, EXR and JPEG files, `info` and
 * `dot` of a graph with PNG inputs and outputs, a render whose files are all EXR, a render reading
 * a PNG or a JPEG (decoded natively) into an EXR and one writing PNGs (encoded natively) must not
 * load libOpenImageIO; a render writing or reading a TIFF must (through the module
 * wetgraph-oiio.so), and when the module cannot be found
 * such a render fails with a message naming the image file and the module path tried. */
#include "wgtest.h"

#include "internal.h"
#include "wgio.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

typedef struct {
    int status;
    char *err;
} Run;

/* Run WETGRAPH_BIN with args in wgt_tmpdir(), LD_DEBUG=files and, when module_dir is given,
 * WETGRAPH_MODULE_DIR; stdout is dropped, stderr kept. Killed after 60 s. */
static Run run(const char *module_dir, const char *const *args)
{
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) fail_msg("WETGRAPH_BIN is not set");
    char err_path[1200];
    snprintf(err_path, sizeof err_path, "%s/stderr.txt", wgt_tmpdir());
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        if (chdir(wgt_tmpdir()) || !freopen("/dev/null", "w", stdout) ||
            !freopen(err_path, "w", stderr))
            _exit(98);
        setenv("LD_DEBUG", "files", 1);
        if (module_dir) setenv("WETGRAPH_MODULE_DIR", module_dir, 1);
        char *argv[16] = {(char *)bin};
        for (int i = 0; args[i] && i < 14; i++) argv[i + 1] = (char *)args[i];
        execv(bin, argv);
        _exit(99);
    }
    int st = 0;
    for (int waited = 0;; waited++) {
        pid_t r = waitpid(pid, &st, WNOHANG);
        if (r == pid) break;
        if (waited > 6000) {
            kill(pid, SIGKILL);
            waitpid(pid, &st, 0);
            fail_msg("'%s %s' did not finish in 60 s", bin, args[0]);
        }
        nanosleep(&(struct timespec){0, 10000000}, NULL);
    }
    Run r = {WIFEXITED(st) ? WEXITSTATUS(st) : -1, wgt_read_file(err_path, NULL)};
    if (!r.err) r.err = calloc(1, 1);
    return r;
}

/* The loader's trace is there (so an absence means something), and says whether OpenImageIO
 * was loaded. */
static void expect_oiio(const Run *r, const char *what, bool loaded)
{
    if (!strstr(r->err, "file=libc.so"))
        fail_msg("%s: no LD_DEBUG trace on stderr:\n%.2000s", what, r->err);
    if (!!strstr(r->err, "file=libOpenImageIO") != loaded)
        fail_msg("%s: OpenImageIO was %sloaded", what, loaded ? "not " : "");
}

static const char *const png_graph =
    "<wetgraph version=\"1\" size=\"8\">\n"
    "  <node id=\"img\" type=\"image\" path=\"in.png\"/>\n"
    "  <node id=\"inv\" type=\"invert\"><in name=\"source\" from=\"img\"/></node>\n"
    "  <output name=\"out\" from=\"inv\" format=\"png16\"/>\n"
    "</wetgraph>\n";
static const char *const png_exr_graph =
    "<wetgraph version=\"1\" size=\"8\">\n"
    "  <node id=\"img\" type=\"image\" path=\"in.png\" colorspace=\"srgb\"/>\n"
    "  <output name=\"out\" from=\"img\" format=\"exr32\"/>\n"
    "</wetgraph>\n";
static const char *const jpg_graph = "<wetgraph version=\"1\" size=\"8\">\n"
                                     "  <node id=\"img\" type=\"image\" path=\"in.jpg\"/>\n"
                                     "  <output name=\"out\" from=\"img\" format=\"exr\"/>\n"
                                     "</wetgraph>\n";
static const char *const tif_graph = "<wetgraph version=\"1\" size=\"8\">\n"
                                     "  <node id=\"img\" type=\"image\" path=\"in.tif\"/>\n"
                                     "  <output name=\"out\" from=\"img\" format=\"exr\"/>\n"
                                     "</wetgraph>\n";
static const char *const exr_graph =
    "<wetgraph version=\"1\" size=\"8\">\n"
    "  <node id=\"img\" type=\"image\" path=\"in.exr\"/>\n"
    "  <node id=\"inv\" type=\"invert\"><in name=\"source\" from=\"img\"/></node>\n"
    "  <output name=\"out\" from=\"inv\" format=\"exr\"/>\n"
    "</wetgraph>\n";

static void test_oiio_loaded_only_when_needed(void **state)
{
    (void)state;
    float v[64 * 4];
    for (int i = 0; i < 64 * 4; i++) v[i] = (float)(i % 7) / 7.0f;
    WgImage *img = wgt_image(8, 8, 4, v);
    WgError err = {0};
    assert_int_equal(wg_image_write(wgt_path("in.png"), img, WG_FORMAT_PNG, WG_LINEAR, &err), 0);
    assert_int_equal(wg_image_write(wgt_path("in.exr"), img, WG_FORMAT_EXR, WG_LINEAR, &err), 0);
    unsigned char rgb[64 * 3];
    for (int i = 0; i < 64 * 3; i++) rgb[i] = (unsigned char)(i * 5);
    char msg[512];
    if (wg__oiio_write(wgt_path("in.jpg"), "jpg", rgb, 8, 8, 3, 8, msg, sizeof msg))
        fail_msg("%s", msg);
    if (wg__oiio_write(wgt_path("in.tif"), "tif", rgb, 8, 8, 3, 8, msg, sizeof msg))
        fail_msg("%s", msg);
    wg_image_unref(img);
    wgt_write_file(wgt_path("tif.wetgraph"), tif_graph);
    wgt_write_file(wgt_path("png.wetgraph"), png_graph);
    wgt_write_file(wgt_path("png_exr.wetgraph"), png_exr_graph);
    wgt_write_file(wgt_path("jpg.wetgraph"), jpg_graph);
    wgt_write_file(wgt_path("exr.wetgraph"), exr_graph);

    static const struct {
        const char *args[8];
        bool loaded;
    } cases[] = {
        {{"nodes"}, false},
        {{"--help"}, false},
        {{"check", "png.wetgraph", "exr.wetgraph", "jpg.wetgraph"}, false},
        {{"info", "png.wetgraph"}, false},
        {{"dot", "png.wetgraph"}, false},
        {{"render", "exr.wetgraph", "-q", "-o", "exr_out"}, false},
        {{"render", "png_exr.wetgraph", "-q", "-o", "png_exr_out"}, false},
        {{"render", "png.wetgraph", "-q", "-o", "png_out"}, false},
        {{"render", "png.wetgraph", "-q", "-o", "tif_out", "--format", "tif16"}, true},
        {{"render", "jpg.wetgraph", "-q", "-o", "jpg_out"}, false},
        {{"render", "tif.wetgraph", "-q", "-o", "tif_in_out"}, true},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        Run r = run(NULL, cases[i].args);
        if (r.status != 0)
            fail_msg("'wetgraph %s %s' exited %d:\n%.3000s", cases[i].args[0],
                     cases[i].args[1] ? cases[i].args[1] : "", r.status, r.err);
        expect_oiio(&r, cases[i].args[0], cases[i].loaded);
        free(r.err);
    }
    /* the renders wrote their outputs */
    int w, h, c;
    assert_int_equal(wg_image_probe(wgt_path("exr_out/exr_out.exr"), &w, &h, &c, &err), 0);
    assert_int_equal(wg_image_probe(wgt_path("png_exr_out/png_exr_out.exr"), &w, &h, &c, &err), 0);
    assert_int_equal(wg_image_probe(wgt_path("png_out/png_out.png"), &w, &h, &c, &err), 0);
    assert_int_equal(wg_image_probe(wgt_path("jpg_out/jpg_out.exr"), &w, &h, &c, &err), 0);
}

static void test_missing_module_is_a_clear_error(void **state)
{
    (void)state;
    char dir[1200];
    snprintf(dir, sizeof dir, "%s/no-module-here", wgt_tmpdir());
    char want[1300];
    snprintf(want, sizeof want, "%s/wetgraph-oiio.so", dir);
    static const struct {
        const char *graph, *file;
    } need[] = {{"tif.wetgraph", "in.tif"}, {"png.wetgraph", "png_out.tif"}};
    for (int i = 0; i < 2; i++) {
        const char *args[] = {"render",      need[i].graph, "-q",    "-o",
                              "missing_out", "--format",    "tif16", NULL};
        if (i == 0) args[5] = NULL;
        Run r = run(dir, args);
        if (r.status != 1) fail_msg("'render %s' exited %d", need[i].graph, r.status);
        if (!strstr(r.err, i == 0 ? "in.tif" : "missing_out/png_out.tif") || !strstr(r.err, want) ||
            !strstr(r.err, "OpenImageIO module"))
            fail_msg("expected the image, the module path and the reason in:\n%.3000s", r.err);
        free(r.err);
    }
    /* PNG in, EXR out; EXR only; PNG in and out; JPEG in: no module needed */
    const char *const ok[4] = {"png_exr.wetgraph", "exr.wetgraph", "png.wetgraph", "jpg.wetgraph"};
    for (int i = 0; i < 4; i++) {
        const char *args[] = {"render", ok[i], "-q", "-o", "missing_out", NULL};
        Run r = run(dir, args);
        if (r.status != 0) fail_msg("'render %s' exited %d:\n%.3000s", ok[i], r.status, r.err);
        expect_oiio(&r, ok[i], false);
        free(r.err);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_oiio_loaded_only_when_needed),
        cmocka_unit_test(test_missing_module_is_a_clear_error),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
