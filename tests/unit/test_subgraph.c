/* SPDX-License-Identifier: MIT */
/* Subgraphs: where a subgraph type is looked up (the including file's folder, then WETGRAPH_PATH,
 * then the built-in graphs folder), explicit relative paths, parameters and inputs passed by the
 * parent, input defaults, several outputs, independent instances, recursion, and errors located
 * in the subgraph's own file. All files are written under wgt_tmpdir(). */
#include "wgtest.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* ---- helpers ----------------------------------------------------------------------------- */

/* wgt_tmpdir()/a/b..., created; in a static rotating buffer like wgt_path. */
static const char *dir(const char *name)
{
    const char *p = wgt_path(name);
    char tmp[1024];
    snprintf(tmp, sizeof tmp, "%s", p);
    for (char *s = tmp + strlen(wgt_tmpdir()) + 1; *s; s++) {
        if (*s != '/') continue;
        *s = '\0';
        mkdir(tmp, 0777);
        *s = '/';
    }
    mkdir(tmp, 0777);
    return p;
}

static const char *file_in(const char *folder, const char *name)
{
    static char buf[8][1024];
    static int next;
    char *p = buf[next++ & 7];
    snprintf(p, 1024, "%s/%s", folder, name);
    return p;
}

static void write_in(const char *folder, const char *name, const char *text)
{
    wgt_write_file(file_in(folder, name), text);
}

/* A subgraph that outputs a constant gray value. */
static void write_constant(const char *folder, const char *name, double value)
{
    char xml[512];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <node id=\"u\" type=\"uniform\" value=\"%.17g\"/>\n"
             "  <output name=\"out\" from=\"u\"/>\n"
             "</wetgraph>\n",
             value);
    write_in(folder, name, xml);
}

static WgGraph *load_file(const char *path)
{
    WgGraph *g = NULL;
    WgError err = {0};
    if (wg_graph_load(path, &g, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("load %s: %s", path, buf);
    }
    return g;
}

static int load_file_error(const char *path, WgError *err)
{
    WgGraph *g = NULL;
    memset(err, 0, sizeof *err);
    int rc = wg_graph_load(path, &g, err);
    if (rc == WG_OK) {
        wg_graph_free(g);
        fail_msg("expected %s to be rejected", path);
    }
    assert_null(g);
    return rc;
}

static bool ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

/* Render with an optional parameter override; fails the test on error. */
static WgResult *render_with(const WgGraph *g, const char *name, const char *value)
{
    WgError err = {0};
    WgEngineOptions opt = {1, 0, NULL};
    WgEngine *e = NULL;
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    WgRequest *r = wg_request_new(g);
    if (name && wg_request_set(r, name, value, &err)) fail_msg("set %s: %s", name, err.message);
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("render: %s", buf);
    }
    wg_request_free(r);
    wg_engine_free(e);
    return res;
}

static int render_error(const WgGraph *g, const char *name, const char *value, WgError *err)
{
    WgEngineOptions opt = {1, 0, NULL};
    WgEngine *e = NULL;
    memset(err, 0, sizeof *err);
    assert_int_equal(wg_engine_new(&opt, &e, err), WG_OK);
    WgRequest *r = wg_request_new(g);
    if (name) assert_int_equal(wg_request_set(r, name, value, err), WG_OK);
    WgResult *res = NULL;
    int rc = wg_render(e, r, &res, err);
    if (rc == WG_OK) fail_msg("expected the render to fail");
    assert_null(res);
    wg_request_free(r);
    wg_engine_free(e);
    return rc;
}

/* Every pixel of every channel of `img` equals `v` (as float). */
static void assert_constant(const WgImage *img, int channels, double v)
{
    assert_non_null(img);
    assert_int_equal(img->channels, channels);
    for (int y = 0; y < img->height; y++)
        for (int i = 0; i < img->width * img->channels; i++)
            if (wg_image_row(img, y)[i] != (float)v)
                fail_msg("pixel %d,%d channel %d is %.9g, expected %.9g", i / channels, y,
                         i % channels, wg_image_row(img, y)[i], (float)v);
}

static int teardown_env(void **state)
{
    (void)state;
    setenv("WETGRAPH_PATH", "", 1);
    unsetenv("WETGRAPH_GRAPHS_DIR");
    return 0;
}

/* ---- resolution order -------------------------------------------------------------------- */

static const char *const uses_layer = "<wetgraph version=\"1\" size=\"8\">\n"
                                      "  <node id=\"s\" type=\"layer\"/>\n"
                                      "  <output name=\"o\" from=\"s\"/>\n"
                                      "</wetgraph>\n";

static void test_resolution_order(void **state)
{
    (void)state;
    const char *main_dir = dir("order/main");
    const char *p1 = dir("order/path1");
    const char *p2 = dir("order/path2");
    const char *builtin = dir("order/builtin");
    char env[4096];
    snprintf(env, sizeof env, "%s:%s", p1, p2);
    setenv("WETGRAPH_PATH", env, 1);
    setenv("WETGRAPH_GRAPHS_DIR", builtin, 1);
    assert_string_equal(wg_builtin_graphs_dir(), builtin);

    write_constant(main_dir, "layer.wetgraph", 0.125);
    write_constant(p1, "layer.wetgraph", 0.25);
    write_constant(p2, "layer.wetgraph", 0.375);
    write_constant(builtin, "layer.wetgraph", 0.5);
    const char *main_path = file_in(main_dir, "main.wetgraph");
    wgt_write_file(main_path, uses_layer);

    /* each time the winner is removed, the next location takes over */
    struct {
        const char *folder;
        double value;
    } steps[] = {{main_dir, 0.125}, {p1, 0.25}, {p2, 0.375}, {builtin, 0.5}};
    for (int i = 0; i < 4; i++) {
        WgGraph *g = load_file(main_path);
        const WgGraphNodeInfo *ni = wg_graph_node_info(g, 0);
        assert_true(ni->is_subgraph);
        assert_string_equal(ni->type, "layer");
        char expect[2048];
        snprintf(expect, sizeof expect, "%s/layer.wetgraph", steps[i].folder);
        assert_string_equal(ni->subgraph_path, expect);
        WgResult *r = render_with(g, NULL, NULL);
        const WgImage *img = wgt_output(r, "o");
        assert_int_equal(img->width, 8); /* the parent's size, not the subgraph's own */
        assert_constant(img, 1, steps[i].value);
        wg_result_free(r);
        wg_graph_free(g);
        assert_int_equal(unlink(file_in(steps[i].folder, "layer.wetgraph")), 0);
    }
    WgError err;
    load_file_error(main_path, &err);
    wgt_assert_error(&err, WG_ERR_TYPE, 2,
                     "unknown node type 'layer' (not a built-in node, and no "
                     "layer.wetgraph next to this file, in WETGRAPH_PATH or in");
    assert_non_null(strstr(err.message, builtin));

    /* empty entries in WETGRAPH_PATH are skipped */
    snprintf(env, sizeof env, "::%s:", p2);
    setenv("WETGRAPH_PATH", env, 1);
    write_constant(p2, "layer.wetgraph", 0.375);
    WgGraph *g = load_file(main_path);
    WgResult *r = render_with(g, NULL, NULL);
    assert_constant(wgt_output(r, "o"), 1, 0.375);
    wg_result_free(r);
    wg_graph_free(g);
    teardown_env(NULL);
}

static void test_builtin_node_types_win(void **state)
{
    (void)state;
    const char *d = dir("builtin_wins");
    /* a file named after a built-in node is not a subgraph */
    write_constant(d, "invert.wetgraph", 0.5);
    const char *path = file_in(d, "main.wetgraph");
    wgt_write_file(path,
                   "<wetgraph version=\"1\" size=\"2\">\n"
                   "  <node id=\"u\" type=\"uniform\" value=\"0.25\"/>\n"
                   "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"u\"/></node>\n"
                   "  <output name=\"o\" from=\"i\"/>\n"
                   "</wetgraph>\n");
    WgGraph *g = load_file(path);
    assert_false(wg_graph_node_info(g, 1)->is_subgraph);
    WgResult *r = render_with(g, NULL, NULL);
    assert_constant(wgt_output(r, "o"), 1, 0.75);
    wg_result_free(r);
    wg_graph_free(g);
}

/* ---- explicit paths ---------------------------------------------------------------------- */

static void test_explicit_relative_paths(void **state)
{
    (void)state;
    const char *top = dir("explicit");
    const char *lib = dir("explicit/lib");
    const char *deep = dir("explicit/lib/deep");
    /* lib/shapes.wetgraph uses `inner`: found next to shapes, not next to main */
    write_constant(top, "inner.wetgraph", 0.75);
    write_constant(lib, "inner.wetgraph", 0.25);
    write_constant(deep, "leaf.wetgraph", 0.5);
    write_in(lib, "shapes.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"a\" type=\"inner\"/>\n"
             "  <node id=\"b\" type=\"deep/leaf.wetgraph\"/>\n"
             "  <node id=\"c\" type=\"../inner.wetgraph\"/>\n"
             "  <output name=\"a\" from=\"a\"/>\n"
             "  <output name=\"b\" from=\"b\"/>\n"
             "  <output name=\"c\" from=\"c\"/>\n"
             "</wetgraph>\n");
    const char *path = file_in(top, "main.wetgraph");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"2\">\n"
                         "  <node id=\"s\" type=\"lib/shapes.wetgraph\"/>\n"
                         "  <output name=\"a\" from=\"s.a\"/>\n"
                         "  <output name=\"b\" from=\"s.b\"/>\n"
                         "  <output name=\"c\" from=\"s.c\"/>\n"
                         "</wetgraph>\n");
    WgGraph *g = load_file(path);
    const WgGraphNodeInfo *ni = wg_graph_node_info(g, 0);
    assert_true(ni->is_subgraph);
    assert_string_equal(ni->type, "lib/shapes.wetgraph");
    assert_string_equal(ni->subgraph_path, file_in(top, "lib/shapes.wetgraph"));
    WgResult *r = render_with(g, NULL, NULL);
    assert_constant(wgt_output(r, "a"), 1, 0.25);
    assert_constant(wgt_output(r, "b"), 1, 0.5);
    assert_constant(wgt_output(r, "c"), 1, 0.75);
    wg_result_free(r);
    wg_graph_free(g);

    /* an explicit path that does not exist */
    WgError err;
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"2\">\n"
                         "\n"
                         "  <node id=\"s\" type=\"lib/nope.wetgraph\"/>\n"
                         "  <output name=\"o\" from=\"s\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_IO, 3,
                     "subgraph file 'lib/nope.wetgraph' not found (relative to ");
    assert_true(ends_with(err.file, "/explicit/main.wetgraph"));
    /* explicit paths are not searched for elsewhere */
    write_constant(lib, "only_in_lib.wetgraph", 0.5);
    setenv("WETGRAPH_PATH", lib, 1);
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"2\">\n"
                         "  <node id=\"s\" type=\"only_in_lib.wetgraph\"/>\n"
                         "  <output name=\"o\" from=\"s\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_IO, 2, "subgraph file 'only_in_lib.wetgraph' not found");
    teardown_env(NULL);
}

/* ---- parameters -------------------------------------------------------------------------- */

static void test_params_passed_as_attributes(void **state)
{
    (void)state;
    const char *d = dir("params");
    write_in(d, "scaled.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <param name=\"v\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
             "  <node id=\"u\" type=\"uniform\" value=\"=v * 2\"/>\n"
             "  <output name=\"out\" from=\"u\"/>\n"
             "</wetgraph>\n");
    const char *path = file_in(d, "main.wetgraph");
    wgt_write_file(
        path, "<wetgraph version=\"1\" size=\"16\">\n"
              "  <param name=\"amount\" type=\"float\" default=\"0.1\"/>\n"
              "  <node id=\"a\" type=\"scaled\"/>\n"
              "  <node id=\"b\" type=\"scaled\" v=\"0.25\"/>\n"
              "  <node id=\"c\" type=\"scaled\" v=\"=amount * 3\"/>\n"
              "  <node id=\"d\" type=\"scaled\" size=\"32x8\" v=\"=$width / 64 + $height / 64\"/>\n"
              "  <output name=\"a\" from=\"a\"/>\n"
              "  <output name=\"b\" from=\"b\"/>\n"
              "  <output name=\"c\" from=\"c.out\"/>\n"
              "  <output name=\"d\" from=\"d\"/>\n"
              "</wetgraph>\n");
    WgGraph *g = load_file(path);
    WgResult *r = render_with(g, NULL, NULL);
    assert_constant(wgt_output(r, "a"), 1, 0.5 * 2);
    assert_constant(wgt_output(r, "b"), 1, 0.25 * 2);
    assert_constant(wgt_output(r, "c"), 1, 0.1 * 3 * 2);
    const WgImage *dimg = wgt_output(r, "d");
    assert_int_equal(dimg->width, 32);
    assert_int_equal(dimg->height, 8);
    assert_constant(dimg, 1, (32.0 / 64 + 8.0 / 64) * 2);
    /* four different parameter values: four different nodes evaluated */
    assert_int_equal(wg_result_evaluated_count(r), 4);
    wg_result_free(r);

    /* the parent's expression sees the overridden parameter */
    r = render_with(g, "amount", "0.15");
    assert_constant(wgt_output(r, "c"), 1, 0.15 * 3 * 2);
    assert_constant(wgt_output(r, "a"), 1, 1.0);
    wg_result_free(r);

    /* ... and its range is the subgraph parameter's */
    WgError err;
    render_error(g, "amount", "0.5", &err);
    wgt_assert_error(&err, WG_ERR_RANGE, 5,
                     "node \'c\'|expression 'amount * 3' gives: 'v' = 1.5 is "
                     "outside [0, 1]");
    assert_true(ends_with(err.file, "/params/main.wetgraph"));
    wg_graph_free(g);

    /* literals are checked at load time against the subgraph's declaration */
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"16\">\n"
                         "  <node id=\"a\" type=\"scaled\" v=\"3\"/>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_RANGE, 2, "node \'a\'|'v' = 3 is outside [0, 1]");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"16\">\n"
                         "  <node id=\"a\" type=\"scaled\" v=\"much\"/>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_TYPE, 2, "node \'a\'|'v' expects a number, got 'much'");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"16\">\n"
                         "  <node id=\"a\" type=\"scaled\" vv=\"0.5\"/>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 2,
                     "node \'a\'|subgraph 'scaled' has no parameter 'vv'; did "
                     "you mean 'v'?");
    /* an expression in the parent may only use the parent's names */
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"16\">\n"
                         "  <node id=\"a\" type=\"scaled\" v=\"=v / 2\"/>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 2, "unknown name 'v'");
}

static void test_non_numeric_params_and_seed(void **state)
{
    (void)state;
    const char *d = dir("colors");
    write_in(d, "tinted.wetgraph",
             "<wetgraph version=\"1\" seed=\"99\">\n"
             "  <param name=\"tint\" type=\"color\" default=\"0 0 0 1\"/>\n"
             "  <param name=\"kind\" type=\"enum\" values=\"gray|color\" default=\"color\"/>\n"
             "  <node id=\"u\" type=\"uniform\" kind=\"=kind\" color=\"=tint\" value=\"0.5\"/>\n"
             "  <node id=\"s\" type=\"uniform\" value=\"=$seed + $time\"/>\n"
             "  <output name=\"out\" from=\"u\"/>\n"
             "  <output name=\"seed\" from=\"s\"/>\n"
             "</wetgraph>\n");
    const char *path = file_in(d, "main.wetgraph");
    wgt_write_file(path,
                   "<wetgraph version=\"1\" size=\"2\" seed=\"3\">\n"
                   "  <param name=\"c\" type=\"color\" default=\"0.25 0.5 0.75 1\"/>\n"
                   "  <node id=\"a\" type=\"tinted\" tint=\"=c\"/>\n"
                   "  <node id=\"b\" type=\"tinted\" tint=\"1 0 0.5\" kind=\"gray\" seed=\"11\"/>\n"
                   "  <output name=\"a\" from=\"a\"/>\n"
                   "  <output name=\"b\" from=\"b.out\"/>\n"
                   "  <output name=\"a_seed\" from=\"a.seed\"/>\n"
                   "  <output name=\"b_seed\" from=\"b.seed\"/>\n"
                   "</wetgraph>\n");
    WgGraph *g = load_file(path);
    WgResult *r = render_with(g, NULL, NULL);
    const WgImage *a = wgt_output(r, "a");
    assert_int_equal(a->channels, 4);
    assert_float_equal(wgt_px(a, 1, 1, 0), 0.25f, 0);
    assert_float_equal(wgt_px(a, 1, 1, 1), 0.5f, 0);
    assert_float_equal(wgt_px(a, 1, 1, 2), 0.75f, 0);
    assert_float_equal(wgt_px(a, 1, 1, 3), 1.0f, 0);
    assert_constant(wgt_output(r, "b"), 1, 0.5);
    /* a subgraph runs with its node's seed, else the parent's; never its own root seed */
    assert_constant(wgt_output(r, "a_seed"), 1, 3);
    assert_constant(wgt_output(r, "b_seed"), 1, 11);
    wg_result_free(r);
    wg_graph_free(g);

    wgt_write_file(path, "<wetgraph version=\"1\" size=\"2\">\n"
                         "  <param name=\"f\" type=\"float\"/>\n"
                         "  <node id=\"a\" type=\"tinted\" tint=\"=f\"/>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "</wetgraph>\n");
    WgError err;
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_TYPE, 3, "'tint' is a color parameter");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"2\">\n"
                         "  <node id=\"a\" type=\"tinted\" kind=\"rgb\"/>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_TYPE, 2, "'kind' has no value 'rgb'");
}

/* ---- inputs and outputs ------------------------------------------------------------------ */

static void test_inputs_defaults_and_outputs(void **state)
{
    (void)state;
    const char *d = dir("inputs");
    write_in(d, "inv.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <input name=\"src\" type=\"gray\" default=\"0.25\"/>\n"
             "  <input name=\"tint\" type=\"color\" default=\"0.5 0.25 0.125\"/>\n"
             "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"$src\"/></node>\n"
             "  <output name=\"out\" from=\"i\"/>\n"
             "  <output name=\"through\" from=\"$src\"/>\n"
             "  <output name=\"tint\" from=\"$tint\"/>\n"
             "</wetgraph>\n");
    const char *path = file_in(d, "main.wetgraph");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"u\" type=\"uniform\" value=\"0.125\"/>\n"
                         "  <node id=\"a\" type=\"inv\">\n"
                         "    <in name=\"src\" from=\"u\"/>\n"
                         "  </node>\n"
                         "  <node id=\"b\" type=\"inv\"/>\n"
                         "  <node id=\"c\" type=\"inv\">\n"
                         "    <in name=\"src\" from=\"a.out\"/>\n"
                         "  </node>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "  <output name=\"b\" from=\"b.out\"/>\n"
                         "  <output name=\"a_through\" from=\"a.through\"/>\n"
                         "  <output name=\"b_through\" from=\"b.through\"/>\n"
                         "  <output name=\"b_tint\" from=\"b.tint\"/>\n"
                         "  <output name=\"c\" from=\"c\"/>\n"
                         "</wetgraph>\n");
    WgGraph *g = load_file(path);
    WgResult *r = render_with(g, NULL, NULL);
    assert_constant(wgt_output(r, "a"), 1, 1 - 0.125);
    assert_constant(wgt_output(r, "b"), 1, 1 - 0.25);
    assert_constant(wgt_output(r, "a_through"), 1, 0.125);
    assert_constant(wgt_output(r, "b_through"), 1, 0.25);
    assert_constant(wgt_output(r, "c"), 1, 0.125); /* inverted twice */
    const WgImage *t = wgt_output(r, "b_tint");
    assert_int_equal(t->channels, 4);
    assert_float_equal(wgt_px(t, 3, 3, 0), 0.5f, 0);
    assert_float_equal(wgt_px(t, 3, 3, 1), 0.25f, 0);
    assert_float_equal(wgt_px(t, 3, 3, 2), 0.125f, 0);
    assert_float_equal(wgt_px(t, 3, 3, 3), 1.0f, 0);
    wg_result_free(r);
    wg_graph_free(g);

    WgError err;
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"u\" type=\"uniform\"/>\n"
                         "  <node id=\"a\" type=\"inv\">\n"
                         "    <in name=\"srcc\" from=\"u\"/>\n"
                         "  </node>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 4, "node \'a\'|has no input 'srcc'; did you mean 'src'?");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"a\" type=\"inv\"/>\n"
                         "  <output name=\"a\" from=\"a.result\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 3,
                     "node 'a' has no output 'result' (outputs: out, through, tint)");

    /* an input without a default must be connected */
    write_in(d, "needs.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <input name=\"src\" type=\"gray\"/>\n"
             "  <output name=\"out\" from=\"$src\"/>\n"
             "</wetgraph>\n");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"a\" type=\"needs\"/>\n"
                         "  <output name=\"a\" from=\"a\"/>\n"
                         "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 2, "node \'a\'|required input 'src' is not connected");
}

/* ---- instances --------------------------------------------------------------------------- */

static void test_instances_are_independent_and_merged_when_equal(void **state)
{
    (void)state;
    const char *d = dir("instances");
    write_in(d, "level.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <param name=\"v\" type=\"float\" default=\"0.5\"/>\n"
             "  <node id=\"u\" type=\"uniform\" value=\"=v\"/>\n"
             "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"u\"/></node>\n"
             "  <output name=\"out\" from=\"i\"/>\n"
             "</wetgraph>\n");
    const char *path = file_in(d, "main.wetgraph");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"x\" type=\"level\" v=\"0.25\"/>\n"
                         "  <node id=\"y\" type=\"level\" v=\"0.75\"/>\n"
                         "  <node id=\"z\" type=\"level\" v=\"=0.5 - 0.25\"/>\n"
                         "  <output name=\"x\" from=\"x\"/>\n"
                         "  <output name=\"y\" from=\"y\"/>\n"
                         "  <output name=\"z\" from=\"z\"/>\n"
                         "</wetgraph>\n");
    WgGraph *g = load_file(path);
    WgResult *r = render_with(g, NULL, NULL);
    assert_constant(wgt_output(r, "x"), 1, 0.75);
    assert_constant(wgt_output(r, "y"), 1, 0.25);
    assert_constant(wgt_output(r, "z"), 1, 0.75);
    /* x and z compute the same thing: 2 nodes for them, 2 for y */
    assert_int_equal(wg_result_evaluated_count(r), 4);
    assert_int_equal(wg_result_stat_count(r), 4);
    bool seen_x = false, seen_y = false;
    for (int i = 0; i < wg_result_stat_count(r); i++) {
        const char *id = wg_result_stat(r, i)->id;
        seen_x |= !strcmp(id, "x/u");
        seen_y |= !strcmp(id, "y/i");
        assert_null(strstr(id, "z/")); /* merged into x's */
    }
    assert_true(seen_x && seen_y);
    wg_result_free(r);
    wg_graph_free(g);
}

static void test_shared_subgraph_is_not_a_cycle(void **state)
{
    (void)state;
    /* a diamond: main uses b and c, both use d */
    const char *d = dir("diamond");
    write_constant(d, "d.wetgraph", 0.25);
    const char *uses_d =
        "<wetgraph version=\"1\">\n"
        "  <node id=\"n\" type=\"d\"/>\n"
        "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"n\"/></node>\n"
        "  <output name=\"out\" from=\"i\"/>\n"
        "</wetgraph>\n";
    write_in(d, "b.wetgraph", uses_d);
    write_in(d, "c.wetgraph", uses_d);
    const char *path = file_in(d, "main.wetgraph");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"2\">\n"
                         "  <node id=\"b\" type=\"b\"/>\n"
                         "  <node id=\"c\" type=\"c\"/>\n"
                         "  <node id=\"d\" type=\"d\"/>\n"
                         "  <output name=\"b\" from=\"b\"/>\n"
                         "  <output name=\"c\" from=\"c\"/>\n"
                         "  <output name=\"d\" from=\"d\"/>\n"
                         "</wetgraph>\n");
    WgGraph *g = load_file(path);
    WgResult *r = render_with(g, NULL, NULL);
    assert_constant(wgt_output(r, "b"), 1, 0.75);
    assert_constant(wgt_output(r, "c"), 1, 0.75);
    assert_constant(wgt_output(r, "d"), 1, 0.25);
    assert_int_equal(wg_result_evaluated_count(r), 2); /* one uniform, one invert */
    wg_result_free(r);
    wg_graph_free(g);
}

/* ---- expansion limit --------------------------------------------------------------------- */

/* Files <stem>0 .. <stem>{n-1}.wetgraph in d: each uses the next `fan` times and holds `extra`
 * uniforms of its own (`first_extra` for the first file); the last holds `leaf` uniforms, or
 * when `leaf` is 0 no node at all, only an input it passes on. counts[i] gets the instances
 * file i expands to (each node and input one, each use of a subgraph one more than what it
 * holds), saturating at 1e18. */
static void write_fan_chain(const char *d, const char *stem, int n, int fan, int extra, int leaf,
                            int first_extra, double *counts)
{
    for (int i = n - 1; i >= 0; i--) {
        char *xml = NULL;
        size_t size = 0;
        FILE *f = open_memstream(&xml, &size);
        assert_non_null(f);
        fprintf(f, "<wetgraph version=\"1\" size=\"2\">\n");
        int own = i == n - 1 ? leaf : i == 0 ? first_extra : extra;
        bool pass_on = i == n - 1 && leaf == 0;
        if (pass_on) fprintf(f, "  <input name=\"in\" type=\"gray\" default=\"0.1\"/>\n");
        for (int k = 0; k < own; k++)
            fprintf(f, "  <node id=\"u%d\" type=\"uniform\" value=\"0.%d\"/>\n", k, k + 1);
        if (i < n - 1)
            for (int k = 0; k < fan; k++)
                fprintf(f, "  <node id=\"s%d\" type=\"%s%d\"/>\n", k, stem, i + 1);
        fprintf(f, "  <output name=\"out\" from=\"%s\"/>\n",
                i < n - 1 ? "s0"
                : pass_on ? "$in"
                          : "u0");
        fprintf(f, "</wetgraph>\n");
        fclose(f);
        char name[64];
        snprintf(name, sizeof name, "%s%d.wetgraph", stem, i);
        write_in(d, name, xml);
        free(xml);
        counts[i] = own + pass_on + (i < n - 1 ? fan * (1 + counts[i + 1]) : 0);
        if (counts[i] > 1e18) counts[i] = 1e18;
    }
}

static void test_fan_out_is_refused_with_the_chain(void **state)
{
    (void)state;
    /* each file using the next several times: 2^40 instances from 40 tiny files */
    static const struct {
        int n, fan, extra, leaf;
    } cases[] = {{40, 2, 0, 1}, {25, 2, 1, 2}, {16, 3, 0, 1}, {12, 5, 2, 3}, {62, 2, 0, 1},
                 {9, 7, 1, 1},  {30, 4, 3, 2}, {45, 2, 0, 0}, {21, 3, 0, 0}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char folder[64], stem[16];
        snprintf(folder, sizeof folder, "fan_out/%zu", c);
        snprintf(stem, sizeof stem, "f%zu_", c);
        const char *d = dir(folder);
        double counts[64];
        int n = cases[c].n;
        write_fan_chain(d, stem, n, cases[c].fan, cases[c].extra, cases[c].leaf, cases[c].extra,
                        counts);
        assert_true(counts[0] > WG_MAX_INSTANCES);
        /* the chain ends at the last file still over the limit by itself */
        int last = 0;
        while (last + 1 < n && counts[last + 1] > WG_MAX_INSTANCES) last++;
        char top[64];
        snprintf(top, sizeof top, "%s0.wetgraph", stem);
        clock_t t0 = clock();
        WgError err;
        assert_int_equal(load_file_error(file_in(d, top), &err), WG_ERR_RANGE);
        double ms = 1000.0 * (double)(clock() - t0) / CLOCKS_PER_SEC;
        print_message("fan-out %d files x%d: refused in %.1f ms of CPU\n", n, cases[c].fan, ms);
        assert_true(ends_with(err.file, top));
        assert_non_null(strstr(err.message, "more than 1000000 node instances"));
        char expect[1024] = "";
        for (int i = 0; i <= last; i++) {
            size_t l = strlen(expect);
            snprintf(expect + l, sizeof expect - l, "%s%s%d.wetgraph", i ? " -> " : "", stem, i);
        }
        const char *chain = strstr(err.message, ": ");
        assert_non_null(chain);
        chain += 2;
        if (strlen(expect) < 400 || !strcmp(chain, expect)) {
            assert_string_equal(chain, expect);
        } else {
            /* too long for one message: the first and the last file, with ... between */
            char first[64], end[64];
            snprintf(first, sizeof first, "%s0.wetgraph -> %s1.wetgraph -> ", stem, stem);
            snprintf(end, sizeof end, " -> ... -> %s%d.wetgraph", stem, last);
            assert_memory_equal(chain, first, strlen(first));
            if (!ends_with(chain, end)) fail_msg("'%s' does not end in '%s'", chain, end);
        }
        /* the file where the chain ends loads when the limit is not crossed below it */
        if (last + 1 < n) {
            char below[64];
            snprintf(below, sizeof below, "%s%d.wetgraph", stem, last + 1);
            WgGraph *g = load_file(file_in(d, below));
            wg_graph_free(g);
        }
    }
}

static void test_fan_out_under_the_limit_works(void **state)
{
    (void)state;
    /* exactly at the limit loads; one more node is refused, naming only the top file (ten
     * uniforms and ten uses of e1, which holds 99,998 instances) */
    const char *d = dir("fan_out/edge");
    double counts[8];
    write_fan_chain(d, "e", 6, 10, 8, 8, 10, counts);
    assert_true(counts[0] == WG_MAX_INSTANCES);
    WgGraph *g = load_file(file_in(d, "e0.wetgraph"));
    wg_graph_free(g);
    write_fan_chain(d, "e", 6, 10, 8, 8, 11, counts);
    WgError err;
    assert_int_equal(load_file_error(file_in(d, "e0.wetgraph"), &err), WG_ERR_RANGE);
    assert_true(ends_with(err.message, "copies all its nodes): e0.wetgraph"));

    /* small chains of several fan-outs render, with every instance merged into one */
    for (int fan = 2; fan <= 4; fan++) {
        char folder[64];
        snprintf(folder, sizeof folder, "fan_out/small%d", fan);
        const char *s = dir(folder);
        double c[8];
        write_fan_chain(s, "m", 6, fan, 1, fan == 3 ? 0 : 1, 0, c);
        g = load_file(file_in(s, "m0.wetgraph"));
        WgResult *r = render_with(g, NULL, NULL);
        assert_constant(wgt_output(r, "out"), 1, 0.1);
        wg_result_free(r);
        wg_graph_free(g);
    }
}

/* ---- recursion --------------------------------------------------------------------------- */

static void test_direct_recursion(void **state)
{
    (void)state;
    const char *d = dir("recursion_direct");
    const char *self = "<wetgraph version=\"1\">\n"
                       "  <node id=\"u\" type=\"uniform\"/>\n"
                       "  <node id=\"again\" type=\"self\"/>\n"
                       "  <output name=\"o\" from=\"u\"/>\n"
                       "</wetgraph>\n";
    write_in(d, "self.wetgraph", self);
    WgError err;
    assert_int_equal(load_file_error(file_in(d, "self.wetgraph"), &err), WG_ERR_CYCLE);
    wgt_assert_error(&err, WG_ERR_CYCLE, 0, "subgraph recursion: self.wetgraph -> self.wetgraph");
    assert_non_null(strstr(err.message, "used by node 'again' at "));
    assert_non_null(strstr(err.message, "self.wetgraph:3"));

    /* the same text loaded from memory under that file's name */
    WgGraph *g = NULL;
    memset(&err, 0, sizeof err);
    assert_int_equal(
        wg_graph_load_memory(self, strlen(self), file_in(d, "self.wetgraph"), &g, &err),
        WG_ERR_CYCLE);
    assert_null(g);
    assert_non_null(strstr(err.message, "self.wetgraph -> self.wetgraph"));

    /* through an explicit path spelled differently */
    write_in(d, "spelled.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"again\" type=\"./../recursion_direct/spelled.wetgraph\"/>\n"
             "  <output name=\"o\" from=\"again\"/>\n"
             "</wetgraph>\n");
    assert_int_equal(load_file_error(file_in(d, "spelled.wetgraph"), &err), WG_ERR_CYCLE);
    wgt_assert_error(&err, WG_ERR_CYCLE, 0, "spelled.wetgraph -> spelled.wetgraph");
}

static void test_indirect_recursion(void **state)
{
    (void)state;
    const char *d = dir("recursion_indirect");
    write_in(d, "a.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"to_b\" type=\"b\"/>\n"
             "  <output name=\"o\" from=\"to_b\"/>\n"
             "</wetgraph>\n");
    write_in(d, "b.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"u\" type=\"uniform\"/>\n"
             "  <node id=\"to_c\" type=\"c\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n");
    write_in(d, "c.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"to_a\" type=\"a\"/>\n"
             "  <output name=\"o\" from=\"to_a\"/>\n"
             "</wetgraph>\n");
    WgError err;
    assert_int_equal(load_file_error(file_in(d, "a.wetgraph"), &err), WG_ERR_CYCLE);
    wgt_assert_error(&err, WG_ERR_CYCLE, 0,
                     "subgraph recursion: a.wetgraph -> b.wetgraph -> "
                     "c.wetgraph -> a.wetgraph");
    /* where each link is used */
    assert_non_null(strstr(err.message, "used by node 'to_a' at "));
    assert_non_null(strstr(err.message, "c.wetgraph:2"));
    assert_non_null(strstr(err.message, "used by node 'to_c' at "));
    assert_non_null(strstr(err.message, "b.wetgraph:3"));
    assert_non_null(strstr(err.message, "used by node 'to_b' at "));

    /* entering the loop elsewhere names it from there */
    assert_int_equal(load_file_error(file_in(d, "b.wetgraph"), &err), WG_ERR_CYCLE);
    wgt_assert_error(&err, WG_ERR_CYCLE, 0, "b.wetgraph -> c.wetgraph -> a.wetgraph -> b.wetgraph");

    /* a graph that only uses the loop from outside is rejected too */
    write_in(d, "outer.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"x\" type=\"c\"/>\n"
             "  <output name=\"o\" from=\"x\"/>\n"
             "</wetgraph>\n");
    assert_int_equal(load_file_error(file_in(d, "outer.wetgraph"), &err), WG_ERR_CYCLE);
    wgt_assert_error(&err, WG_ERR_CYCLE, 0, "c.wetgraph -> a.wetgraph -> b.wetgraph -> c.wetgraph");
}

/* ---- errors inside subgraphs ------------------------------------------------------------- */

static void test_errors_located_in_the_subgraph_file(void **state)
{
    (void)state;
    const char *d = dir("sub_errors");
    write_in(d, "broken.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"u\" type=\"uniform\"/>\n"
             "  <node id=\"b\" type=\"blur\" sigma=\"wide\">\n"
             "    <in name=\"source\" from=\"u\"/>\n"
             "  </node>\n"
             "  <output name=\"o\" from=\"b\"/>\n"
             "</wetgraph>\n");
    write_in(d, "middle.wetgraph",
             "<wetgraph version=\"1\">\n"
             "\n"
             "  <node id=\"inner\" type=\"broken\"/>\n"
             "  <output name=\"o\" from=\"inner\"/>\n"
             "</wetgraph>\n");
    const char *path = file_in(d, "main.wetgraph");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"outer\" type=\"middle\"/>\n"
                         "  <output name=\"o\" from=\"outer\"/>\n"
                         "</wetgraph>\n");
    WgError err;
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_TYPE, 3, "node \'b\'|'sigma' expects a number, got 'wide'");
    assert_true(ends_with(err.file, "/sub_errors/broken.wetgraph"));
    char where[2048];
    snprintf(where, sizeof where, "(used by node 'inner' at %s:3)", file_in(d, "middle.wetgraph"));
    assert_non_null(strstr(err.message, where));
    snprintf(where, sizeof where, "(used by node 'outer' at %s:2)", path);
    assert_non_null(strstr(err.message, where));

    /* malformed XML in a subgraph */
    write_in(d, "broken.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"u\" type=\"uniform\"\n"
             "</wetgraph>\n");
    load_file_error(path, &err);
    assert_int_equal(err.code, WG_ERR_PARSE);
    assert_true(ends_with(err.file, "/sub_errors/broken.wetgraph"));
    assert_true(err.line >= 2 && err.line <= 3);
    assert_non_null(strstr(err.message, "XML: "));
    assert_non_null(strstr(err.message, "(used by node 'outer' at "));

    /* an unknown type inside the subgraph */
    write_in(d, "broken.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <node id=\"u\" type=\"unifrom\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n");
    load_file_error(path, &err);
    wgt_assert_error(&err, WG_ERR_TYPE, 2, "unknown node type 'unifrom'; did you mean 'uniform'?");
    assert_true(ends_with(err.file, "/sub_errors/broken.wetgraph"));

    /* errors found while instantiating are located in the subgraph too, with the node's path */
    write_in(d, "broken.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <param name=\"k\" type=\"float\" default=\"0\"/>\n"
             "  <node id=\"u\" type=\"uniform\"/>\n"
             "  <node id=\"b\" type=\"blend\" opacity=\"=k\">\n"
             "    <in name=\"foreground\" from=\"u\"/>\n"
             "    <in name=\"background\" from=\"u\"/>\n"
             "  </node>\n"
             "  <output name=\"o\" from=\"b\"/>\n"
             "</wetgraph>\n");
    write_in(d, "middle.wetgraph",
             "<wetgraph version=\"1\">\n"
             "  <param name=\"k\" type=\"float\" default=\"0\"/>\n"
             "  <node id=\"inner\" type=\"broken\" k=\"=k * 4\"/>\n"
             "  <output name=\"o\" from=\"inner\"/>\n"
             "</wetgraph>\n");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <param name=\"k\" type=\"float\" default=\"0.125\"/>\n"
                         "  <node id=\"outer\" type=\"middle\" k=\"=k\"/>\n"
                         "  <output name=\"o\" from=\"outer\"/>\n"
                         "</wetgraph>\n");
    WgGraph *g = load_file(path);
    WgResult *r = render_with(g, NULL, NULL);
    assert_constant(wgt_output(r, "o"), 1, 0);
    wg_result_free(r);
    render_error(g, "k", "0.5", &err);
    wgt_assert_error(&err, WG_ERR_RANGE, 4, "'opacity' = 2 is outside [0, 1]");
    assert_true(ends_with(err.file, "/sub_errors/broken.wetgraph"));
    assert_string_equal(err.node, "outer/inner/b");
    wg_graph_free(g);
}

/* ---- warnings ---------------------------------------------------------------------------- */

/* The warnings of g with "name=value" settings (NULL: none) and outputs (NULL: all), through
 * wg_request_warnings and, the same, through a render's result; returns the count. */
static int warnings_of(const WgGraph *g, const char *const *sets, const char *only_output,
                       WgWarning **out)
{
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgError err = {0};
    for (int i = 0; sets && sets[i]; i++) {
        char name[64];
        const char *eq = strchr(sets[i], '=');
        snprintf(name, sizeof name, "%.*s", (int)(eq - sets[i]), sets[i]);
        if (wg_request_set(r, name, eq + 1, &err)) fail_msg("%s", err.message);
    }
    if (only_output && wg_request_add_output(r, only_output, &err)) fail_msg("%s", err.message);
    int n = -1;
    if (wg_request_warnings(r, out, &n, &err)) fail_msg("%s", err.message);
    WgEngine *e = wgt_engine(1, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    assert_int_equal(wg_result_warning_count(res), n);
    for (int i = 0; i < n; i++) {
        const WgWarning *a = wg_result_warning(res, i), *b = &(*out)[i];
        assert_string_equal(a->file, b->file);
        assert_int_equal(a->line, b->line);
        assert_string_equal(a->message, b->message);
        assert_true(a->node && b->node ? !strcmp(a->node, b->node) : a->node == b->node);
    }
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    return n;
}

static void expect_warning(const WgWarning *w, const char *file_end, int line, const char *node,
                           const char *message)
{
    size_t a = strlen(w->file), b = strlen(file_end);
    if (a < b || strcmp(w->file + a - b, file_end)) fail_msg("warning in %s", w->file);
    assert_int_equal(w->line, line);
    if (node)
        assert_string_equal(w->node, node);
    else
        assert_null(w->node);
    assert_string_equal(w->message, message);
}

static void test_warnings_per_instance(void **state)
{
    (void)state;
    const char *d = dir("warnings");
    write_in(d, "level.wetgraph",
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <param name=\"level\" type=\"float\" default=\"0.5\" min=\"0\" max=\"10\"/>\n"
             "  <node id=\"u\" type=\"uniform\" value=\"=level / 10\"/>\n"
             "  <output name=\"out\" from=\"u\"/>\n"
             "  <warning when=\"=level > 1\"\n"
             "           message=\"level {level} is above 1 at {=$width}x{=$height}\"/>\n"
             "</wetgraph>\n");
    write_in(d, "wrap.wetgraph",
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <param name=\"x\" type=\"float\" default=\"0\" min=\"0\" max=\"10\"/>\n"
             "  <node id=\"inner\" type=\"level\" level=\"=x * 2\"/>\n"
             "  <output name=\"out\" from=\"inner\"/>\n"
             "</wetgraph>\n");
    write_in(d, "top.wetgraph",
             "<wetgraph version=\"1\" size=\"8\">\n"
             "  <param name=\"a\" type=\"float\" default=\"0.5\" min=\"0\" max=\"10\"/>\n"
             "  <warning when=\"=a > 4\" message=\"a = {a} is large\"/>\n"
             "  <node id=\"low\" type=\"level\" level=\"=a\"/>\n"
             "  <node id=\"high\" type=\"level\" level=\"=a + 2\" size=\"16x12\"/>\n"
             "  <node id=\"w\" type=\"wrap\" x=\"=a\"/>\n"
             "  <output name=\"o1\" from=\"low\"/>\n"
             "  <output name=\"o2\" from=\"high\"/>\n"
             "  <output name=\"o3\" from=\"w\"/>\n"
             "</wetgraph>\n");
    WgGraph *g = load_file(file_in(d, "top.wetgraph"));
    WgWarning *w = NULL;
    /* defaults: only the instance whose level is above 1, with its own size */
    assert_int_equal(warnings_of(g, NULL, NULL, &w), 1);
    expect_warning(&w[0], "warnings/level.wetgraph", 5, "high", "level 2.5 is above 1 at 16x12");
    wg_warnings_free(w, 1);
    /* a = 0.6: the nested instance too (its level is 2 x = 1.2), named by its path */
    const char *const mid[] = {"a=0.6", NULL};
    assert_int_equal(warnings_of(g, mid, NULL, &w), 2);
    expect_warning(&w[0], "warnings/level.wetgraph", 5, "high", "level 2.6 is above 1 at 16x12");
    expect_warning(&w[1], "warnings/level.wetgraph", 5, "w/inner", "level 1.2 is above 1 at 8x8");
    wg_warnings_free(w, 2);
    /* a = 4.5: the graph's own warning first, then every instance */
    const char *const big[] = {"a=4.5", NULL};
    assert_int_equal(warnings_of(g, big, NULL, &w), 4);
    expect_warning(&w[0], "warnings/top.wetgraph", 3, NULL, "a = 4.5 is large");
    expect_warning(&w[1], "warnings/level.wetgraph", 5, "low", "level 4.5 is above 1 at 8x8");
    expect_warning(&w[2], "warnings/level.wetgraph", 5, "high", "level 6.5 is above 1 at 16x12");
    expect_warning(&w[3], "warnings/level.wetgraph", 5, "w/inner", "level 9 is above 1 at 8x8");
    wg_warnings_free(w, 4);
    /* only what the requested outputs use is instantiated, and warns */
    assert_int_equal(warnings_of(g, big, "o1", &w), 2);
    expect_warning(&w[1], "warnings/level.wetgraph", 5, "low", "level 4.5 is above 1 at 8x8");
    wg_warnings_free(w, 2);
    /* a = 0: none */
    const char *const none[] = {"a=0", NULL};
    assert_int_equal(warnings_of(g, none, NULL, &w), 1);
    wg_warnings_free(w, 1);
    const char *const small[] = {"a=0", "a=0.4", NULL};
    assert_int_equal(warnings_of(g, small, "o3", &w), 0);
    assert_null(w);
    wg_graph_free(g);

    /* a condition that is not a finite number is an error where the warning is written, naming
     * the instance */
    write_in(d, "inf.wetgraph",
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <param name=\"k\" type=\"float\" default=\"0\" min=\"0\" max=\"10\"/>\n"
             "  <node id=\"u\" type=\"uniform\"/>\n"
             "  <output name=\"out\" from=\"u\"/>\n"
             "  <warning when=\"=1 / k\" message=\"k {k}\"/>\n"
             "</wetgraph>\n");
    write_in(d, "use_inf.wetgraph",
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <node id=\"i\" type=\"inf\" k=\"1\"/>\n"
             "  <node id=\"j\" type=\"inf\"/>\n"
             "  <output name=\"a\" from=\"i\"/>\n"
             "  <output name=\"b\" from=\"j\"/>\n"
             "</wetgraph>\n");
    g = load_file(file_in(d, "use_inf.wetgraph"));
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    int n = -1;
    assert_int_equal(wg_request_warnings(r, &w, &n, &err), WG_ERR_RANGE);
    assert_null(w);
    assert_int_equal(n, 0);
    wgt_assert_error(&err, WG_ERR_RANGE, 5,
                     "inf.wetgraph:5:|node 'j'|'when' expression '1 / k' gives inf, not a finite");
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_missing_subgraph(void **state)
{
    (void)state;
    const char *d = dir("missing");
    const char *path = file_in(d, "main.wetgraph");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"s\" type=\"water_ripples\"/>\n"
                         "  <output name=\"o\" from=\"s\"/>\n"
                         "</wetgraph>\n");
    WgError err;
    assert_int_equal(load_file_error(path, &err), WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 2,
                     "unknown node type 'water_ripples' (not a built-in node, "
                     "and no water_ripples.wetgraph next to this file");
    assert_string_equal(err.file, path);

    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"s\" type=\"ripples.wetgraph\"/>\n"
                         "  <output name=\"o\" from=\"s\"/>\n"
                         "</wetgraph>\n");
    assert_int_equal(load_file_error(path, &err), WG_ERR_IO);
    wgt_assert_error(&err, WG_ERR_IO, 2, "subgraph file 'ripples.wetgraph' not found");

    /* a folder with the right name is not a file */
    dir("missing/folder.wetgraph");
    wgt_write_file(path, "<wetgraph version=\"1\" size=\"4\">\n"
                         "  <node id=\"s\" type=\"folder\"/>\n"
                         "  <output name=\"o\" from=\"s\"/>\n"
                         "</wetgraph>\n");
    assert_int_equal(load_file_error(path, &err), WG_ERR_TYPE);
}

/* Subgraph inputs keep their declared kind: gray into a colour input is promoted (R = G = B,
 * alpha 1), colour into a gray input is an error at the <in> line. */
static void test_input_kinds_are_enforced(void **state)
{
    (void)state;
    const char *folder = dir("kinds");
    write_in(folder, "inner.wetgraph",
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <input name=\"c\" type=\"color\" default=\"0 0 0 1\"/>\n"
             "  <input name=\"g\" type=\"gray\" default=\"0\"/>\n"
             "  <output name=\"c\" from=\"$c\"/>\n"
             "  <output name=\"g\" from=\"$g\"/>\n"
             "</wetgraph>\n");
    write_in(folder, "promote.wetgraph",
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <node id=\"u\" type=\"uniform\" value=\"0.25\"/>\n"
             "  <node id=\"i\" type=\"inner\"><in name=\"c\" from=\"u\"/></node>\n"
             "  <output name=\"c\" from=\"i.c\"/>\n"
             "</wetgraph>\n");
    WgGraph *g = load_file(file_in(folder, "promote.wetgraph"));
    WgResult *res = render_with(g, NULL, NULL);
    const WgImage *c = wgt_output(res, "c");
    assert_int_equal(c->channels, 4);
    for (int x = 0; x < 4; x++) {
        assert_true(wgt_px(c, x, 1, 0) == 0.25f && wgt_px(c, x, 1, 1) == 0.25f);
        assert_true(wgt_px(c, x, 1, 2) == 0.25f && wgt_px(c, x, 1, 3) == 1.0f);
    }
    wg_result_free(res);
    wg_graph_free(g);

    write_in(folder, "refuse.wetgraph",
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <node id=\"u\" type=\"uniform\" kind=\"color\" color=\"1 0 0 1\"/>\n"
             "  <node id=\"i\" type=\"inner\">\n"
             "    <in name=\"g\" from=\"u\"/>\n"
             "  </node>\n"
             "  <output name=\"g\" from=\"i.g\"/>\n"
             "</wetgraph>\n");
    g = load_file(file_in(folder, "refuse.wetgraph"));
    WgError err;
    assert_int_equal(render_error(g, NULL, NULL, &err), WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 4,
                     "node 'i' (inner)|input 'g' of subgraph 'inner' takes a gray image|grayscale");
    wg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_resolution_order, teardown_env),
        cmocka_unit_test(test_builtin_node_types_win),
        cmocka_unit_test_teardown(test_explicit_relative_paths, teardown_env),
        cmocka_unit_test(test_params_passed_as_attributes),
        cmocka_unit_test(test_non_numeric_params_and_seed),
        cmocka_unit_test(test_inputs_defaults_and_outputs),
        cmocka_unit_test(test_instances_are_independent_and_merged_when_equal),
        cmocka_unit_test(test_shared_subgraph_is_not_a_cycle),
        cmocka_unit_test(test_fan_out_is_refused_with_the_chain),
        cmocka_unit_test(test_fan_out_under_the_limit_works),
        cmocka_unit_test(test_direct_recursion),
        cmocka_unit_test(test_indirect_recursion),
        cmocka_unit_test(test_errors_located_in_the_subgraph_file),
        cmocka_unit_test(test_missing_subgraph),
        cmocka_unit_test(test_input_kinds_are_enforced),
        cmocka_unit_test(test_warnings_per_instance),
    };
    setenv("WETGRAPH_PATH", "", 1);
    unsetenv("WETGRAPH_GRAPHS_DIR");
    return cmocka_run_group_tests(tests, NULL, NULL);
}
