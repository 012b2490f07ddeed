/* SPDX-License-Identifier: MIT */
/* Instantiation (plan.c, request.c): node sizes, parameter overrides, expressions over the graph
 * scope, range and finiteness checks of their results, demand-driven resolution, gray/colour
 * port checks, graph inputs, and how many nodes a render evaluates (only the needed ones, and
 * identical ones once). */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ---- helpers ----------------------------------------------------------------------------- */

static WgGraph *load(const char *xml)
{
    return wgt_load(xml);
}

static WgRequest *request(const WgGraph *g)
{
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    return r;
}

static WgResult *render(const WgRequest *r)
{
    WgError err = {0};
    WgEngineOptions opt = {1, 0, NULL};
    WgEngine *e = NULL;
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("render: %s", buf);
    }
    wg_engine_free(e);
    return res;
}

/* Expect both wg_request_check and wg_render to fail with the same error. */
static void render_fails(const WgRequest *r, int code, int line, const char *needle)
{
    WgError err = {0};
    assert_int_equal(wg_request_check(r, &err), code);
    wgt_assert_error(&err, code, line, needle);
    WgEngineOptions opt = {1, 0, NULL};
    WgEngine *e = NULL;
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    WgResult *res = NULL;
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_render(e, r, &res, &err), code);
    assert_null(res);
    wgt_assert_error(&err, code, line, needle);
    wg_engine_free(e);
}

static void set_ok(WgRequest *r, const char *name, const char *value)
{
    WgError err = {0};
    if (wg_request_set(r, name, value, &err)) fail_msg("set %s=%s: %s", name, value, err.message);
}

static void set_fails(WgRequest *r, const char *name, const char *value, int code,
                      const char *needle)
{
    WgError err = {0};
    int rc = wg_request_set(r, name, value, &err);
    if (rc != code)
        fail_msg("set %s=%s: status %d, expected %d (%s)", name, value, rc, code, err.message);
    wgt_assert_error(&err, code, 0, needle);
}

static void assert_size(const WgImage *img, int w, int h)
{
    assert_non_null(img);
    if (img->width != w || img->height != h)
        fail_msg("size %dx%d, expected %dx%d", img->width, img->height, w, h);
}

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

static float value_of(const WgResult *res, const char *name)
{
    return wg_image_row(wgt_output(res, name), 0)[0];
}

/* ---- sizes ------------------------------------------------------------------------------- */

static void test_graph_size_and_override(void **state)
{
    (void)state;
    WgGraph *g = load("<wetgraph version=\"1\" size=\"32x16\">\n"
                      "  <node id=\"u\" type=\"uniform\" value=\"0.5\"/>\n"
                      "  <output name=\"o\" from=\"u\"/>\n"
                      "</wetgraph>\n");
    WgRequest *r = request(g);
    WgResult *res = render(r);
    assert_size(wgt_output(res, "o"), 32, 16);
    assert_constant(wgt_output(res, "o"), 1, 0.5);
    assert_int_equal(wg_result_output_format(res, 0), WG_FORMAT_PNG16); /* gray default */
    wg_result_free(res);

    wg_request_set_size(r, 8, 4);
    res = render(r);
    assert_size(wgt_output(res, "o"), 8, 4);
    wg_result_free(res);

    wg_request_set_size(r, 16384, 1);
    res = render(r);
    assert_size(wgt_output(res, "o"), 16384, 1);
    wg_result_free(res);

    wg_request_set_size(r, 0, 4);
    render_fails(r, WG_ERR_RANGE, 0, "size 0x4 is outside 1..16384 per side");
    wg_request_set_size(r, 16385, 4);
    render_fails(r, WG_ERR_RANGE, 0, "size 16385x4 is outside 1..16384 per side");
    wg_request_set_size(r, 4, -2);
    render_fails(r, WG_ERR_RANGE, 0, "size 4x-2 is outside");
    wg_request_free(r);
    wg_graph_free(g);

    g = load("<wetgraph version=\"1\" size=\"24\">\n"
             "  <node id=\"u\" type=\"uniform\" kind=\"color\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n");
    res = wgt_render(g, 1);
    assert_size(wgt_output(res, "o"), 24, 24);
    assert_int_equal(wg_result_output_format(res, 0), WG_FORMAT_PNG); /* colour default */
    wg_result_free(res);
    wg_graph_free(g);
}

static const char *const sizes_xml =
    "<wetgraph version=\"1\" size=\"16\">\n"
    "  <node id=\"fixed\" type=\"uniform\" size=\"8x4\"/>\n"
    "  <node id=\"double\" type=\"uniform\" size=\"x2\"/>\n"
    "  <node id=\"quarter\" type=\"uniform\" size=\"/4\"/>\n"
    "  <node id=\"half\" type=\"uniform\" size=\"x0.5\"/>\n"
    "  <node id=\"third\" type=\"uniform\" size=\"/3\"/>\n"
    "  <node id=\"graph\" type=\"uniform\" size=\"graph\"/>\n"
    "  <node id=\"plain\" type=\"uniform\"/>\n"
    "  <node id=\"follow\" type=\"blur\" size=\"input\"><in name=\"source\" "
    "from=\"fixed\"/></node>\n"
    "  <node id=\"resized\" type=\"blur\"><in name=\"source\" from=\"fixed\"/></node>\n"
    "  <output name=\"fixed\" from=\"fixed\"/>\n"
    "  <output name=\"double\" from=\"double\"/>\n"
    "  <output name=\"quarter\" from=\"quarter\"/>\n"
    "  <output name=\"half\" from=\"half\"/>\n"
    "  <output name=\"third\" from=\"third\"/>\n"
    "  <output name=\"graph\" from=\"graph\"/>\n"
    "  <output name=\"plain\" from=\"plain\"/>\n"
    "  <output name=\"follow\" from=\"follow\"/>\n"
    "  <output name=\"resized\" from=\"resized\"/>\n"
    "</wetgraph>\n";

static void test_node_sizes(void **state)
{
    (void)state;
    WgGraph *g = load(sizes_xml);
    WgRequest *r = request(g);
    WgResult *res = render(r);
    assert_size(wgt_output(res, "fixed"), 8, 4);
    assert_size(wgt_output(res, "double"), 32, 32);
    assert_size(wgt_output(res, "quarter"), 4, 4);
    assert_size(wgt_output(res, "half"), 8, 8);
    assert_size(wgt_output(res, "third"), 5, 5); /* 16/3 rounds to nearest */
    assert_size(wgt_output(res, "graph"), 16, 16);
    assert_size(wgt_output(res, "plain"), 16, 16);
    assert_size(wgt_output(res, "follow"), 8, 4);
    assert_size(wgt_output(res, "resized"), 16, 16); /* inputs are resampled to the node's size */
    wg_result_free(res);

    /* relative sizes follow an overridden graph size; fixed ones do not */
    wg_request_set_size(r, 10, 6);
    res = render(r);
    assert_size(wgt_output(res, "fixed"), 8, 4);
    assert_size(wgt_output(res, "double"), 20, 12);
    assert_size(wgt_output(res, "quarter"), 3, 2); /* 2.5 and 1.5 round away from zero */
    assert_size(wgt_output(res, "half"), 5, 3);
    assert_size(wgt_output(res, "third"), 3, 2);
    assert_size(wgt_output(res, "plain"), 10, 6);
    assert_size(wgt_output(res, "follow"), 8, 4);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_size_errors(void **state)
{
    (void)state;
    /* /K giving less than one pixel */
    WgGraph *g = load("<wetgraph version=\"1\" size=\"4\">\n"
                      "  <node id=\"ok\" type=\"uniform\" size=\"/8\"/>\n"
                      "  <node id=\"tiny\" type=\"uniform\" size=\"/9\"/>\n"
                      "  <output name=\"ok\" from=\"ok\"/>\n"
                      "  <output name=\"tiny\" from=\"tiny\"/>\n"
                      "</wetgraph>\n");
    WgRequest *r = request(g);
    WgError err = {0};
    assert_int_equal(wg_request_add_output(r, "ok", &err), WG_OK);
    WgResult *res = render(r);
    assert_size(wgt_output(res, "ok"), 1, 1); /* 0.5 rounds up */
    wg_result_free(res);
    wg_request_free(r);
    r = request(g);
    render_fails(r, WG_ERR_RANGE, 3, "node \'tiny\'|size '/9' of 4x4 gives 0x0, outside 1..16384");
    wg_request_free(r);
    wg_graph_free(g);

    /* only one side too small */
    g = load("<wetgraph version=\"1\" size=\"64x4\">\n"
             "  <node id=\"u\" type=\"uniform\" size=\"/16\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n");
    r = request(g);
    render_fails(r, WG_ERR_RANGE, 2, "node \'u\'|size '/16' of 64x4 gives 4x0");
    wg_request_set_size(r, 64, 64);
    assert_int_equal(wg_request_check(r, &err), WG_OK);
    wg_request_free(r);
    wg_graph_free(g);

    /* the 16384 cap (checked without rendering) */
    g = load("<wetgraph version=\"1\" size=\"16384x8\">\n"
             "  <node id=\"u\" type=\"uniform\" size=\"x2\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n");
    r = request(g);
    render_fails(r, WG_ERR_RANGE, 2,
                 "node \'u\'|size 'x2' of 16384x8 gives 32768x16, outside 1..16384");
    wg_request_set_size(r, 8192, 8);
    assert_int_equal(wg_request_check(r, &err), WG_OK);
    wg_request_set_size(r, 8193, 8);
    render_fails(r, WG_ERR_RANGE, 2, "gives 16386x16");
    wg_request_free(r);
    wg_graph_free(g);

    /* size="input" on a node without inputs */
    g = load("<wetgraph version=\"1\" size=\"4\">\n"
             "  <node id=\"u\" type=\"uniform\" size=\"input\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n");
    r = request(g);
    render_fails(r, WG_ERR_PARSE, 2, "node \'u\'|size=\"input\" but no input is connected");
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_size_from_an_input(void **state)
{
    (void)state;
    WgGraph *g =
        load("<wetgraph version=\"1\" size=\"$photo\">\n"
             "  <input name=\"photo\" type=\"gray\"/>\n"
             "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"$photo\"/></node>\n"
             "  <node id=\"u\" type=\"uniform\" value=\"=$width + $height / 100\"/>\n"
             "  <output name=\"inv\" from=\"i\"/>\n"
             "  <output name=\"u\" from=\"u\"/>\n"
             "</wetgraph>\n");
    WgRequest *r = request(g);
    render_fails(r, WG_ERR_USAGE, 1,
                 "the graph size is '$photo' but no image was given for input "
                 "'photo' (--input photo=FILE or --size WxH)");

    /* from an image given through the API */
    float px[12 * 6];
    for (int i = 0; i < 12 * 6; i++) px[i] = 0.25f;
    WgImage *img = wgt_image(12, 6, 1, px);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "photo", img, &err), WG_OK);
    WgResult *res = render(r);
    assert_size(wgt_output(res, "inv"), 12, 6);
    assert_constant(wgt_output(res, "inv"), 1, 0.75);
    assert_constant(wgt_output(res, "u"), 1, 12 + 6 / 100.0);
    wg_result_free(res);

    /* --size wins over the input's size (the input is resampled) */
    wg_request_set_size(r, 5, 3);
    res = render(r);
    assert_size(wgt_output(res, "inv"), 5, 3);
    assert_constant(wgt_output(res, "inv"), 1, 0.75);
    wg_result_free(res);
    wg_request_free(r);

    /* from a file, probed without decoding it first */
    const char *path = wgt_path("photo.exr");
    assert_int_equal(wg_image_write(path, img, WG_FORMAT_EXR32, WG_LINEAR, &err), WG_OK);
    r = request(g);
    assert_int_equal(wg_request_set_input_file(r, "photo", path, &err), WG_OK);
    res = render(r);
    assert_size(wgt_output(res, "inv"), 12, 6);
    assert_constant(wgt_output(res, "inv"), 1, 0.75);
    wg_result_free(res);

    /* without the image but with an explicit size, outputs not using it still render */
    wg_request_free(r);
    r = request(g);
    wg_request_set_size(r, 7, 2);
    assert_int_equal(wg_request_add_output(r, "u", &err), WG_OK);
    res = render(r);
    assert_size(wgt_output(res, "u"), 7, 2);
    wg_result_free(res);
    wg_request_free(r);
    wg_image_unref(img);
    wg_graph_free(g);
}

/* ---- parameters -------------------------------------------------------------------------- */

static const char *const params_xml =
    "<wetgraph version=\"1\" size=\"2\">\n"
    "  <param name=\"water\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <param name=\"count\" type=\"int\" default=\"2\" min=\"1\" max=\"8\"/>\n"
    "  <param name=\"flag\" type=\"bool\"/>\n"
    "  <param name=\"mode\" type=\"enum\" values=\"copy|multiply\"/>\n"
    "  <param name=\"tint\" type=\"color\" default=\"0 0 0 1\"/>\n"
    "  <param name=\"note\" type=\"string\"/>\n"
    "  <node id=\"w\" type=\"uniform\" value=\"=water\"/>\n"
    "  <node id=\"n\" type=\"uniform\" value=\"=count / 4\"/>\n"
    "  <node id=\"f\" type=\"uniform\" value=\"=flag ? 1 : 0.5\"/>\n"
    "  <node id=\"t\" type=\"uniform\" kind=\"color\" color=\"=tint\"/>\n"
    "  <node id=\"half\" type=\"uniform\" value=\"0.5\"/>\n"
    "  <node id=\"m\" type=\"blend\" mode=\"=mode\">\n"
    "    <in name=\"foreground\" from=\"half\"/>\n"
    "    <in name=\"background\" from=\"half\"/>\n"
    "  </node>\n"
    "  <output name=\"w\" from=\"w\"/>\n"
    "  <output name=\"n\" from=\"n\"/>\n"
    "  <output name=\"f\" from=\"f\"/>\n"
    "  <output name=\"t\" from=\"t\"/>\n"
    "  <output name=\"m\" from=\"m\"/>\n"
    "</wetgraph>\n";

static void test_parameter_overrides(void **state)
{
    (void)state;
    WgGraph *g = load(params_xml);
    WgRequest *r = request(g);
    WgResult *res = render(r);
    assert_float_equal(value_of(res, "w"), 0.5f, 0);
    assert_float_equal(value_of(res, "n"), 0.5f, 0);
    assert_float_equal(value_of(res, "f"), 0.5f, 0);
    assert_float_equal(value_of(res, "m"), 0.5f, 0); /* copy */
    wg_result_free(res);

    set_ok(r, "water", "0.25");
    set_ok(r, "count", "3");
    set_ok(r, "flag", "true");
    set_ok(r, "mode", "multiply");
    set_ok(r, "tint", "0.5 0.25 0.125 1");
    set_ok(r, "note", "anything");
    res = render(r);
    assert_constant(wgt_output(res, "w"), 1, 0.25);
    assert_constant(wgt_output(res, "n"), 1, 0.75);
    assert_constant(wgt_output(res, "f"), 1, 1);
    assert_constant(wgt_output(res, "m"), 1, 0.25); /* multiply */
    const WgImage *t = wgt_output(res, "t");
    assert_float_equal(wgt_px(t, 0, 0, 0), 0.5f, 0);
    assert_float_equal(wgt_px(t, 0, 0, 1), 0.25f, 0);
    assert_float_equal(wgt_px(t, 0, 0, 2), 0.125f, 0);
    assert_float_equal(wgt_px(t, 0, 0, 3), 1.0f, 0);
    wg_result_free(res);

    /* bad values are rejected when set and leave the previous value in place */
    set_fails(r, "water", "abc", WG_ERR_TYPE, "'water' expects a number, got 'abc'");
    set_fails(r, "water", "2", WG_ERR_RANGE, "'water' = 2 is outside [0, 1]");
    set_fails(r, "water", "-0.5", WG_ERR_RANGE, "'water' = -0.5 is outside [0, 1]");
    set_fails(r, "water", "nan", WG_ERR_RANGE, "'water' is NaN, not a finite number");
    set_fails(r, "count", "2.5", WG_ERR_TYPE, "'count' expects a whole number, got '2.5'");
    set_fails(r, "count", "9", WG_ERR_RANGE, "'count' = 9 is outside [1, 8]");
    set_fails(r, "flag", "maybe", WG_ERR_TYPE, "'flag' expects true or false, got 'maybe'");
    set_fails(r, "mode", "multipy", WG_ERR_TYPE,
              "'mode' has no value 'multipy'; did you mean 'multiply'?");
    set_fails(r, "tint", "orange", WG_ERR_TYPE, "'tint' expects a colour");
    res = render(r);
    assert_constant(wgt_output(res, "w"), 1, 0.25);
    assert_constant(wgt_output(res, "n"), 1, 0.75);
    assert_constant(wgt_output(res, "m"), 1, 0.25);
    wg_result_free(res);

    /* '=' values are constant expressions, checked like literals */
    set_ok(r, "water", "=1 / 8");
    set_ok(r, "count", "=2 * 2");
    set_fails(r, "water", "=1 / 0", WG_ERR_RANGE, "'water' is infinite, not a finite number");
    set_fails(r, "water", "=0 / 0", WG_ERR_RANGE, "'water' is NaN");
    set_fails(r, "water", "=3 - 1", WG_ERR_RANGE, "'water' = 2 is outside [0, 1]");
    set_fails(r, "water", "=count", WG_ERR_PARSE, "unknown name 'count'");
    set_fails(r, "water", "=1 +", WG_ERR_PARSE, "unexpected end");
    set_fails(r, "tint", "=1", WG_ERR_TYPE, "'tint' is a color parameter, not a number");
    res = render(r);
    assert_constant(wgt_output(res, "w"), 1, 0.125);
    assert_constant(wgt_output(res, "n"), 1, 1.0);
    wg_result_free(res);

    /* unknown names, with a suggestion and the list */
    set_fails(r, "wter", "0.5", WG_ERR_USAGE,
              "graph 'test' has no parameter 'wter'; did you mean "
              "'water'? (parameters: water, count, flag, mode, tint, note)");
    set_fails(r, "level", "0.5", WG_ERR_USAGE,
              "graph 'test' has no parameter 'level' (parameters: ");
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_expressions_see_the_scope(void **state)
{
    (void)state;
    WgGraph *g =
        load("<wetgraph version=\"1\" size=\"32x16\" seed=\"7\">\n"
             "  <param name=\"k\" type=\"float\" default=\"0.5\"/>\n"
             "  <node id=\"w\" type=\"uniform\" value=\"=$width / 64\"/>\n"
             "  <node id=\"h\" type=\"uniform\" value=\"=$height / 64\"/>\n"
             "  <node id=\"own\" type=\"uniform\" size=\"8x4\" value=\"=$width * 10 + $height\"/>\n"
             "  <node id=\"s\" type=\"uniform\" value=\"=$seed\"/>\n"
             "  <node id=\"s2\" type=\"uniform\" seed=\"12\" value=\"=$seed\"/>\n"
             "  <node id=\"t\" type=\"uniform\" value=\"=$time * 2\"/>\n"
             "  <node id=\"k\" type=\"uniform\" value=\"=k * k + 1\"/>\n"
             "  <output name=\"w\" from=\"w\"/>\n"
             "  <output name=\"h\" from=\"h\"/>\n"
             "  <output name=\"own\" from=\"own\"/>\n"
             "  <output name=\"s\" from=\"s\"/>\n"
             "  <output name=\"s2\" from=\"s2\"/>\n"
             "  <output name=\"t\" from=\"t\"/>\n"
             "  <output name=\"k\" from=\"k\"/>\n"
             "</wetgraph>\n");
    WgRequest *r = request(g);
    WgResult *res = render(r);
    assert_constant(wgt_output(res, "w"), 1, 0.5);
    assert_constant(wgt_output(res, "h"), 1, 0.25);
    assert_constant(wgt_output(res, "own"), 1, 84); /* the node's own size */
    assert_constant(wgt_output(res, "s"), 1, 7);
    assert_constant(wgt_output(res, "s2"), 1, 12);
    assert_constant(wgt_output(res, "t"), 1, 0);
    assert_constant(wgt_output(res, "k"), 1, 1.25);
    wg_result_free(res);

    set_ok(r, "k", "0.3");
    wg_request_set_seed(r, 123);
    wg_request_set_time(r, 0.375);
    wg_request_set_size(r, 64, 8);
    res = render(r);
    assert_constant(wgt_output(res, "w"), 1, 1.0);
    assert_constant(wgt_output(res, "h"), 1, 0.125);
    assert_constant(wgt_output(res, "own"), 1, 84);
    assert_constant(wgt_output(res, "s"), 1, 123);
    assert_constant(wgt_output(res, "s2"), 1, 12); /* a node's own seed is kept */
    assert_constant(wgt_output(res, "t"), 1, 0.75);
    assert_constant(wgt_output(res, "k"), 1, 0.3 * 0.3 + 1);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
}

static const char *const range_xml = "<wetgraph version=\"1\" size=\"4\">\n"
                                     "  <param name=\"k\" type=\"float\" default=\"0.25\"/>\n"
                                     "  <node id=\"u\" type=\"uniform\"/>\n"
                                     "  <node id=\"b\" type=\"blend\" opacity=\"=k * 2\">\n"
                                     "    <in name=\"foreground\" from=\"u\"/>\n"
                                     "    <in name=\"background\" from=\"u\"/>\n"
                                     "  </node>\n"
                                     "  <node id=\"soft\" type=\"blur\" sigma=\"=k - 0.5\">\n"
                                     "    <in name=\"source\" from=\"u\"/>\n"
                                     "  </node>\n"
                                     "  <output name=\"b\" from=\"b\"/>\n"
                                     "  <output name=\"soft\" from=\"soft\"/>\n"
                                     "</wetgraph>\n";

static void test_expression_results_out_of_range(void **state)
{
    (void)state;
    WgGraph *g = load(range_xml);
    WgRequest *r = request(g);
    /* the default k gives a negative sigma */
    render_fails(r, WG_ERR_RANGE, 8,
                 "node \'soft\'|expression 'k - 0.5' gives: 'sigma' = -0.25 is "
                 "outside [0, 16384]");
    set_ok(r, "k", "0.75");
    render_fails(r, WG_ERR_RANGE, 4,
                 "node \'b\'|expression 'k * 2' gives: 'opacity' = 1.5 is outside [0, 1]");
    WgError err = {0};
    wg_request_check(r, &err);
    assert_string_equal(err.node, "b");
    assert_true(strstr(err.file, "/test.wetgraph") != NULL);
    set_ok(r, "k", "0.5");
    WgResult *res = render(r);
    assert_constant(wgt_output(res, "b"), 1, 0);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_non_finite_expressions(void **state)
{
    (void)state;
    static const struct {
        const char *attrs;
        const char *needle;
    } cases[] = {
        {"value=\"=1/0\"",
         "node \'u\'|expression '1/0' gives: 'value' is infinite, not a finite number"},
        {"value=\"=-1/0\"", "'value' is infinite"},
        {"value=\"=0/0\"", "'value' is NaN, not a finite number"},
        {"value=\"=log(k)\"", "'value' is infinite"},
        {"value=\"=sqrt(k - 1)\"", "'value' is NaN"},
        {"value=\"=10^400\"", "'value' is infinite"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        char xml[1024];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"4\">\n"
                 "  <param name=\"k\" type=\"float\" default=\"0\"/>\n"
                 "  <node id=\"u\" type=\"uniform\" %s/>\n"
                 "  <output name=\"o\" from=\"u\"/>\n"
                 "</wetgraph>\n",
                 cases[i].attrs);
        WgGraph *g = load(xml);
        WgRequest *r = request(g);
        render_fails(r, WG_ERR_RANGE, 3, cases[i].needle);
        wg_request_free(r);
        wg_graph_free(g);
    }
}

/* ---- demand-driven instantiation --------------------------------------------------------- */

static const char *const demand_xml =
    "<wetgraph version=\"1\" size=\"4\">\n"
    "  <node id=\"good\" type=\"uniform\" value=\"0.25\"/>\n"
    "  <node id=\"also\" type=\"invert\"><in name=\"source\" from=\"good\"/></node>\n"
    "  <node id=\"inf\" type=\"uniform\" value=\"=1/0\"/>\n"
    "  <node id=\"pic\" type=\"image\" path=\"missing.png\"/>\n"
    "  <node id=\"orphan\" type=\"blur\" sigma=\"=-1\"><in name=\"source\" from=\"inf\"/></node>\n"
    "  <node id=\"mix\" type=\"blend\">\n"
    "    <in name=\"foreground\" from=\"pic\"/>\n"
    "    <in name=\"background\" from=\"inf\"/>\n"
    "  </node>\n"
    "  <output name=\"good\" from=\"good\"/>\n"
    "  <output name=\"bad\" from=\"mix\"/>\n"
    "  <output name=\"also\" from=\"also\"/>\n"
    "</wetgraph>\n";

static void test_demand_driven(void **state)
{
    (void)state;
    WgGraph *g = load(demand_xml);
    WgRequest *r = request(g);
    /* all outputs: the first broken node reached is reported */
    render_fails(r, WG_ERR_IO, 5, "node \'pic\'|file '");
    WgError err = {0};
    wg_request_check(r, &err);
    assert_non_null(strstr(err.message, "missing.png' not found"));

    /* only "good": nothing broken is reached; the orphan never is */
    assert_int_equal(wg_request_add_output(r, "good", &err), WG_OK);
    assert_int_equal(wg_request_add_output(r, "good", &err), WG_OK); /* once is enough */
    WgResult *res = render(r);
    assert_int_equal(wg_result_output_count(res), 1);
    assert_string_equal(wg_result_output_name(res, 0), "good");
    assert_constant(wg_result_output_image(res, 0), 1, 0.25);
    assert_int_equal(wg_result_evaluated_count(res), 1);
    wg_result_free(res);

    /* outputs come in the order they were asked for */
    wg_request_free(r);
    r = request(g);
    assert_int_equal(wg_request_add_output(r, "also", &err), WG_OK);
    assert_int_equal(wg_request_add_output(r, "good", &err), WG_OK);
    res = render(r);
    assert_int_equal(wg_result_output_count(res), 2);
    assert_string_equal(wg_result_output_name(res, 0), "also");
    assert_string_equal(wg_result_output_name(res, 1), "good");
    assert_constant(wg_result_output_image(res, 0), 1, 0.75);
    assert_int_equal(wg_result_evaluated_count(res), 2);
    wg_result_free(res);

    assert_int_equal(wg_request_add_output(r, "nope", &err), WG_ERR_USAGE);
    wgt_assert_error(&err, WG_ERR_USAGE, 0,
                     "graph 'test' has no output 'nope' (outputs: good, bad, also)");
    wg_request_free(r);

    /* asking for the broken output alone fails the same way */
    r = request(g);
    assert_int_equal(wg_request_add_output(r, "bad", &err), WG_OK);
    render_fails(r, WG_ERR_IO, 5, "missing.png");
    wg_request_free(r);
    wg_graph_free(g);

    /* a graph whose broken nodes feed no output renders */
    g = load("<wetgraph version=\"1\" size=\"4\">\n"
             "  <node id=\"inf\" type=\"uniform\" value=\"=1/0\"/>\n"
             "  <node id=\"pic\" type=\"image\" path=\"missing.png\"/>\n"
             "  <node id=\"u\" type=\"uniform\" value=\"0.5\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n");
    res = wgt_render(g, 1);
    assert_constant(wgt_output(res, "o"), 1, 0.5);
    assert_int_equal(wg_result_evaluated_count(res), 1);
    wg_result_free(res);
    wg_graph_free(g);
}

/* ---- gray and colour ports --------------------------------------------------------------- */

static void test_colour_into_gray_port(void **state)
{
    (void)state;
    WgGraph *g = load("<wetgraph version=\"1\" size=\"4\">\n"
                      "  <node id=\"c\" type=\"uniform\" kind=\"color\" color=\"1 0 0\"/>\n"
                      "  <node id=\"g\" type=\"uniform\" value=\"0.5\"/>\n"
                      "  <node id=\"b\" type=\"blend\">\n"
                      "    <in name=\"foreground\" from=\"g\"/>\n"
                      "    <in name=\"background\" from=\"g\"/>\n"
                      "    <in name=\"mask\" from=\"c\"/>\n"
                      "  </node>\n"
                      "  <output name=\"o\" from=\"b\"/>\n"
                      "</wetgraph>\n");
    WgRequest *r = request(g);
    render_fails(r, WG_ERR_TYPE, 7,
                 "node \'b\'|input 'mask' takes a gray image but gets a "
                 "colour one; convert it with a 'grayscale' node");
    wg_request_free(r);
    wg_graph_free(g);

    /* a colour graph input is colour too */
    g = load("<wetgraph version=\"1\" size=\"4\">\n"
             "  <input name=\"paint\" type=\"color\" default=\"0.5\"/>\n"
             "  <node id=\"g\" type=\"uniform\" value=\"0.5\"/>\n"
             "  <node id=\"b\" type=\"blend\">\n"
             "    <in name=\"foreground\" from=\"g\"/>\n"
             "    <in name=\"background\" from=\"g\"/>\n"
             "\n"
             "    <in name=\"mask\" from=\"$paint\"/>\n"
             "  </node>\n"
             "  <output name=\"o\" from=\"b\"/>\n"
             "</wetgraph>\n");
    r = request(g);
    render_fails(r, WG_ERR_TYPE, 8, "input 'mask' takes a gray image but gets a colour one");
    wg_request_free(r);
    wg_graph_free(g);

    /* the suggested fix works, and a colour image given for a gray graph input is converted */
    g = load("<wetgraph version=\"1\" size=\"4\">\n"
             "  <input name=\"m\" type=\"gray\"/>\n"
             "  <node id=\"c\" type=\"uniform\" kind=\"color\" color=\"0.25 0.25 0.25 1\"/>\n"
             "  <node id=\"gs\" type=\"grayscale\"><in name=\"source\" from=\"c\"/></node>\n"
             "  <node id=\"one\" type=\"uniform\" value=\"1\"/>\n"
             "  <node id=\"zero\" type=\"uniform\" value=\"0\"/>\n"
             "  <node id=\"a\" type=\"blend\">\n"
             "    <in name=\"foreground\" from=\"one\"/>\n"
             "    <in name=\"background\" from=\"zero\"/>\n"
             "    <in name=\"mask\" from=\"gs\"/>\n"
             "  </node>\n"
             "  <node id=\"b\" type=\"blend\">\n"
             "    <in name=\"foreground\" from=\"one\"/>\n"
             "    <in name=\"background\" from=\"zero\"/>\n"
             "    <in name=\"mask\" from=\"$m\"/>\n"
             "  </node>\n"
             "  <output name=\"a\" from=\"a\"/>\n"
             "  <output name=\"b\" from=\"b\"/>\n"
             "</wetgraph>\n");
    r = request(g);
    float px[4] = {0.2f, 0.4f, 0.6f, 1.0f};
    WgImage *img = wgt_image(1, 1, 4, px);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "m", img, &err), WG_OK);
    WgResult *res = render(r);
    const WgImage *a = wgt_output(res, "a");
    assert_int_equal(a->channels, 1);
    assert_float_equal(wgt_px(a, 2, 2, 0), 0.25, 1e-6); /* Rec.709 weights sum to 1 */
    const WgImage *b = wgt_output(res, "b");
    assert_int_equal(b->channels, 1);
    assert_float_equal(wgt_px(b, 2, 2, 0), 0.2126 * 0.2 + 0.7152 * 0.4 + 0.0722 * 0.6, 1e-6);
    wg_result_free(res);
    wg_image_unref(img);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_gray_promoted_into_colour_port(void **state)
{
    (void)state;
    WgGraph *g = load("<wetgraph version=\"1\" size=\"4\">\n"
                      "  <node id=\"g\" type=\"uniform\" value=\"0.375\"/>\n"
                      "  <node id=\"r\" type=\"grayscale\" weights=\"1 0 0 0\"><in name=\"source\" "
                      "from=\"g\"/></node>\n"
                      "  <node id=\"gr\" type=\"grayscale\" weights=\"0 1 0 0\"><in "
                      "name=\"source\" from=\"g\"/></node>\n"
                      "  <node id=\"b\" type=\"grayscale\" weights=\"0 0 1 0\"><in name=\"source\" "
                      "from=\"g\"/></node>\n"
                      "  <node id=\"sum\" type=\"grayscale\" weights=\"1 1 1 0\"><in "
                      "name=\"source\" from=\"g\"/></node>\n"
                      "  <output name=\"r\" from=\"r\"/>\n"
                      "  <output name=\"g\" from=\"gr\"/>\n"
                      "  <output name=\"b\" from=\"b\"/>\n"
                      "  <output name=\"sum\" from=\"sum\"/>\n"
                      "</wetgraph>\n");
    WgResult *res = wgt_render(g, 1);
    assert_constant(wgt_output(res, "r"), 1, 0.375);
    assert_constant(wgt_output(res, "g"), 1, 0.375);
    assert_constant(wgt_output(res, "b"), 1, 0.375);
    assert_constant(wgt_output(res, "sum"), 1, 3 * 0.375);
    wg_result_free(res);
    wg_graph_free(g);
}

/* ---- graph inputs ------------------------------------------------------------------------ */

static void test_graph_inputs(void **state)
{
    (void)state;
    WgGraph *g =
        load("<wetgraph version=\"1\" size=\"4\">\n"
             "  <input name=\"height\" type=\"gray\"/>\n"
             "  <input name=\"base\" type=\"color\" default=\"0.5 0.25 0.125\"/>\n"
             "  <input name=\"level\" type=\"gray\" default=\"0.75\"/>\n"
             "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"$height\"/></node>\n"
             "  <output name=\"o\" from=\"i\"/>\n"
             "  <output name=\"base\" from=\"$base\"/>\n"
             "  <output name=\"level\" from=\"$level\"/>\n"
             "</wetgraph>\n");
    WgRequest *r = request(g);
    render_fails(r, WG_ERR_USAGE, 2,
                 "graph input 'height' has no default and no image was given "
                 "(--input height=FILE)");

    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "hieght", NULL, &err), WG_ERR_USAGE);
    wgt_assert_error(&err, WG_ERR_USAGE, 0,
                     "graph 'test' has no input 'hieght'; did you mean 'height'? (inputs: height, base, level)");
    assert_int_equal(wg_request_set_input_file(r, "height", wgt_path("nothing_here.png"), &err),
                     WG_ERR_IO);

    /* inputs with defaults need nothing */
    assert_int_equal(wg_request_add_output(r, "base", &err), WG_OK);
    assert_int_equal(wg_request_add_output(r, "level", &err), WG_OK);
    WgResult *res = render(r);
    const WgImage *base = wgt_output(res, "base");
    assert_size(base, 4, 4);
    assert_int_equal(base->channels, 4);
    assert_float_equal(wgt_px(base, 3, 1, 0), 0.5f, 0);
    assert_float_equal(wgt_px(base, 3, 1, 1), 0.25f, 0);
    assert_float_equal(wgt_px(base, 3, 1, 2), 0.125f, 0);
    assert_float_equal(wgt_px(base, 3, 1, 3), 1.0f, 0);
    assert_constant(wgt_output(res, "level"), 1, 0.75);
    wg_result_free(res);
    wg_request_free(r);

    /* given images are resampled to the graph size; the request keeps its own reference */
    r = request(g);
    float px[4] = {0.25f, 0.25f, 0.25f, 0.25f};
    WgImage *img = wgt_image(2, 2, 1, px);
    assert_int_equal(wg_request_set_input_image(r, "height", img, &err), WG_OK);
    assert_int_equal(img->refcount_, 2);
    float lv[1] = {0.5f};
    WgImage *level = wgt_image(1, 1, 1, lv);
    assert_int_equal(wg_request_set_input_image(r, "level", level, &err), WG_OK);
    wg_image_unref(level);
    res = render(r);
    assert_size(wgt_output(res, "o"), 4, 4);
    assert_constant(wgt_output(res, "o"), 1, 0.75);
    assert_constant(wgt_output(res, "level"), 1, 0.5);
    wg_result_free(res);
    wg_request_free(r);
    assert_int_equal(img->refcount_, 1);
    wg_image_unref(img);
    wg_graph_free(g);
}

/* ---- what gets evaluated ----------------------------------------------------------------- */

static void test_evaluated_count(void **state)
{
    (void)state;
    WgGraph *g =
        load("<wetgraph version=\"1\" size=\"8\">\n"
             "  <node id=\"a\" type=\"uniform\" value=\"0.25\"/>\n"
             "  <node id=\"b\" type=\"invert\"><in name=\"source\" from=\"a\"/></node>\n"
             "  <node id=\"c\" type=\"uniform\" value=\"0.5\"/>\n"
             "  <node id=\"d\" type=\"blur\" sigma=\"1\"><in name=\"source\" from=\"c\"/></node>\n"
             "  <node id=\"e\" type=\"levels\"><in name=\"source\" from=\"d\"/></node>\n"
             "  <output name=\"small\" from=\"b\"/>\n"
             "  <output name=\"big\" from=\"e\"/>\n"
             "</wetgraph>\n");
    WgRequest *r = request(g);
    WgError err = {0};
    assert_int_equal(wg_request_add_output(r, "small", &err), WG_OK);
    WgResult *res = render(r);
    assert_int_equal(wg_result_evaluated_count(res), 2);
    assert_int_equal(wg_result_stat_count(res), 2);
    bool seen_a = false, seen_b = false;
    for (int i = 0; i < wg_result_stat_count(res); i++) {
        const WgNodeStat *s = wg_result_stat(res, i);
        assert_int_equal(s->cache, WG_COMPUTED);
        assert_int_equal(s->width, 8);
        seen_a |= !strcmp(s->id, "a") && !strcmp(s->type, "uniform");
        seen_b |= !strcmp(s->id, "b") && !strcmp(s->type, "invert");
    }
    assert_true(seen_a && seen_b);
    assert_constant(wgt_output(res, "small"), 1, 0.75);
    wg_result_free(res);
    wg_request_free(r);

    r = request(g);
    res = render(r);
    assert_int_equal(wg_result_evaluated_count(res), 5);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_identical_nodes_are_merged(void **state)
{
    (void)state;
    WgGraph *g = load(
        "<wetgraph version=\"1\" size=\"8\">\n"
        "  <node id=\"u1\" type=\"uniform\" value=\"0.25\"/>\n"
        "  <node id=\"u2\" type=\"uniform\" value=\"=0.125 * 2\" label=\"same\" pos=\"1 2\"/>\n"
        "  <node id=\"b1\" type=\"levels\" in_mid=\"0.5\"><in name=\"source\" "
        "from=\"u1\"/></node>\n"
        "  <node id=\"b2\" type=\"levels\"><in name=\"source\" from=\"u2\"/></node>\n"
        "  <node id=\"m\" type=\"blend\" mode=\"add\">\n"
        "    <in name=\"foreground\" from=\"b1\"/>\n"
        "    <in name=\"background\" from=\"b2\"/>\n"
        "  </node>\n"
        "  <node id=\"other\" type=\"uniform\" value=\"0.25\" size=\"4\"/>\n"
        "  <node id=\"o2\" type=\"levels\" out_high=\"0.5\"><in name=\"source\" "
        "from=\"u1\"/></node>\n"
        "  <output name=\"m\" from=\"m\"/>\n"
        "  <output name=\"b2\" from=\"b2\"/>\n"
        "  <output name=\"other\" from=\"other\"/>\n"
        "  <output name=\"o2\" from=\"o2\"/>\n"
        "</wetgraph>\n");
    WgRequest *r = request(g);
    WgError err = {0};
    assert_int_equal(wg_request_add_output(r, "m", &err), WG_OK);
    WgResult *res = render(r);
    assert_constant(wgt_output(res, "m"), 1, 0.5);
    assert_int_equal(wg_result_evaluated_count(res),
                     3); /* u, b (a default written out is the same), m */
    wg_result_free(res);
    wg_request_free(r);

    /* a different size or parameter is a different node */
    r = request(g);
    res = render(r);
    assert_int_equal(wg_result_evaluated_count(res), 5); /* u, b, m, other, o2 */
    assert_size(wgt_output(res, "other"), 4, 4);
    assert_constant(wgt_output(res, "b2"), 1, 0.25);
    assert_constant(wgt_output(res, "o2"), 1, 0.125);
    /* the merged node appears once in the stats */
    int levels = 0;
    for (int i = 0; i < wg_result_stat_count(res); i++)
        levels += !strcmp(wg_result_stat(res, i)->type, "levels");
    assert_int_equal(levels, 2);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
}

/* wg_request_reads_time: true when an output depends on $time through an expression attribute or
 * a per-pixel expression; false when only an unused node reads it. */
static bool reads_time(const char *body)
{
    char xml[2048];
    snprintf(xml, sizeof xml, "<wetgraph version=\"1\" size=\"8\">%s</wetgraph>", body);
    WgGraph *g = load(xml);
    WgRequest *r = request(g);
    WgError err = {0};
    bool out = true;
    assert_int_equal(wg_request_reads_time(r, &out, &err), WG_OK);
    wg_request_free(r);
    wg_graph_free(g);
    return out;
}

static void test_reads_time(void **state)
{
    (void)state;
    assert_false(reads_time("<node id=\"n\" type=\"noise\" scale=\"4\"/>"
                            "<output name=\"o\" from=\"n\"/>"));
    assert_true(reads_time("<node id=\"n\" type=\"noise\" scale=\"=4 + $time\"/>"
                           "<output name=\"o\" from=\"n\"/>"));
    assert_false(reads_time("<node id=\"n\" type=\"noise\" scale=\"4\"/>"
                            "<node id=\"unused\" type=\"noise\" scale=\"=4 + $time\"/>"
                            "<output name=\"o\" from=\"n\"/>"));
    assert_true(reads_time("<node id=\"p\" type=\"pixel\" expr=\"fract($time)\"/>"
                           "<output name=\"o\" from=\"p\"/>"));
    assert_false(reads_time("<node id=\"p\" type=\"pixel\" expr=\"x\"/>"
                            "<output name=\"o\" from=\"p\"/>"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_graph_size_and_override),
        cmocka_unit_test(test_node_sizes),
        cmocka_unit_test(test_size_errors),
        cmocka_unit_test(test_size_from_an_input),
        cmocka_unit_test(test_parameter_overrides),
        cmocka_unit_test(test_expressions_see_the_scope),
        cmocka_unit_test(test_expression_results_out_of_range),
        cmocka_unit_test(test_non_finite_expressions),
        cmocka_unit_test(test_demand_driven),
        cmocka_unit_test(test_colour_into_gray_port),
        cmocka_unit_test(test_gray_promoted_into_colour_port),
        cmocka_unit_test(test_graph_inputs),
        cmocka_unit_test(test_evaluated_count),
        cmocka_unit_test(test_identical_nodes_are_merged),
        cmocka_unit_test(test_reads_time),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
