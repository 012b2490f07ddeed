/* SPDX-License-Identifier: MIT */
/* The graph loader: valid files load and describe themselves through the info accessors; every
 * class of error the loader reports comes with the right status code, the line of the offending
 * element (and the column inside an expression) and a message that says what to do. */
#include "wgtest.h"

#include <stdio.h>
#include <string.h>

/* Load `xml` expecting failure with `code` at `line` (0: don't check) and `needle` (as for
 * assert_error) in the formatted message. */
static void load_fails(const char *xml, int code, int line, const char *needle)
{
    WgError err;
    int rc = wgt_load_error(xml, &err);
    assert_int_equal(rc, code);
    wgt_assert_error(&err, code, line, needle);
}

static bool ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

/* ---- every independent error of a file ---------------------------------------------------- */

/* A file with four independent errors (a default out of range, an unknown output format, an
 * unknown node type, an unknown parameter) and errors that only follow from them (nodes and an
 * output reading the refused nodes): wg_graph_check_all reports the four, in the order the
 * loader meets them, each at its line; at most `max`; none for a valid file. */
static void test_check_all(void **state)
{
    (void)state;
    const char *path = wgt_path("errors.wetgraph");
    wgt_write_file(
        path, "<wetgraph version=\"1\" size=\"16\">\n"                                   /* 1 */
              "  <param name=\"a\" type=\"float\" default=\"5\" min=\"0\" max=\"1\"/>\n" /* 2 */
              "  <param name=\"b\" type=\"float\" default=\"0.5\"/>\n"                   /* 3 */
              "  <node id=\"n\" type=\"noize\" scale=\"4\"/>\n"                          /* 4 */
              "  <node id=\"m\" type=\"levels\" in_hi=\"1\"><in name=\"source\" "
              "from=\"n\"/></node>\n"                                                      /* 5 */
              "  <node id=\"k\" type=\"invert\"><in name=\"source\" from=\"m\"/></node>\n" /* 6 */
              "  <node id=\"ok\" type=\"uniform\" value=\"=b\"/>\n"                        /* 7 */
              "  <output name=\"o\" from=\"k\" format=\"gif\"/>\n"                         /* 8 */
              "  <output name=\"p\" from=\"ok\"/>\n"                                       /* 9 */
              "</wetgraph>\n");
    WgError errs[20];
    int n = 0;
    assert_int_equal(wg_graph_check_all(path, errs, 20, &n), WG_ERR_RANGE);
    static const int lines[] = {2, 8, 4, 5};
    static const char *const msgs[] = {"'a' = 5 is outside [0, 1]", "unknown format 'gif'",
                                       "unknown node type 'noize'", "no parameter 'in_hi'"};
    for (int i = 0; i < n; i++) print_message("%d: %s\n", errs[i].line, errs[i].message);
    assert_int_equal(n, 4);
    for (int i = 0; i < 4; i++) {
        assert_int_equal(errs[i].line, lines[i]);
        if (!strstr(errs[i].message, msgs[i]))
            fail_msg("error %d: '%s', expected '%s'", i, errs[i].message, msgs[i]);
    }
    assert_int_not_equal(wg_graph_check_all(path, errs, 2, &n), WG_OK);
    assert_int_equal(n, 2);
    /* a valid file, and one whose only error is the file itself */
    wgt_write_file(path,
                   "<wetgraph version=\"1\" size=\"8\">\n  <node id=\"u\" type=\"uniform\"/>\n"
                   "  <output name=\"o\" from=\"u\"/>\n</wetgraph>\n");
    assert_int_equal(wg_graph_check_all(path, errs, 20, &n), WG_OK);
    assert_int_equal(n, 0);
    wgt_write_file(path, "<wetgraph version=\"1\"><node id=\"u\"");
    assert_int_not_equal(wg_graph_check_all(path, errs, 20, &n), WG_OK);
    assert_int_equal(n, 1);
    assert_int_not_equal(wg_graph_check_all(wgt_path("none.wetgraph"), errs, 20, &n), WG_OK);
    assert_int_equal(n, 1);
}

/* ---- <gltf> ------------------------------------------------------------------------------ */

/* A graph with outputs base, rough, h and coat whose line 7 is `gltf`. */
static char *gltf_graph(const char *gltf)
{
    static char xml[2048];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"8\">\n"               /* 1 */
             "  <node id=\"u\" type=\"uniform\" value=\"0.5\"/>\n" /* 2 */
             "  <output name=\"base\" from=\"u\"/>\n"              /* 3 */
             "  <output name=\"rough\" from=\"u\"/>\n"             /* 4 */
             "  <output name=\"h\" from=\"u\"/>\n"                 /* 5 */
             "  <output name=\"coat\" from=\"u\"/>\n"              /* 6 */
             "  %s\n"                                              /* 7 */
             "</wetgraph>\n",
             gltf);
    return xml;
}

/* An output's group: an identifier, reported by the info accessors. */
static void test_output_group(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(gltf_graph("<output name=\"g2\" from=\"u\" group=\"masks\"/>"));
    assert_string_equal(wg_graph_output_info(g, 4)->group, "masks");
    assert_null(wg_graph_output_info(g, 0)->group);
    wg_graph_free(g);
    load_fails(gltf_graph("<output name=\"g2\" from=\"u\" group=\"my masks\"/>"), WG_ERR_PARSE, 7,
               "output 'g2': bad group 'my masks'");
}

static void test_gltf_element(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(gltf_graph(
        "<gltf name=\"asset\" binary=\"true\" grid=\"64\" height_scale=\"0.0625\" "
        "repeat=\"2\" base_color=\"base\" roughness=\"rough\" clearcoat=\"coat\" height=\"h\"/>"));
    assert_int_equal(wg_graph_gltf_count(g), 1);
    const WgGraphGltfInfo *a = wg_graph_gltf_info(g, 0);
    assert_string_equal(a->name, "asset");
    assert_true(a->binary);
    assert_int_equal(a->grid, 64);
    assert_true(a->height_scale == 0.0625 && a->repeat == 2);
    assert_string_equal(a->maps[WG_GLTF_BASE_COLOR], "base");
    assert_string_equal(a->maps[WG_GLTF_ROUGHNESS], "rough");
    assert_string_equal(a->maps[WG_GLTF_CLEARCOAT], "coat");
    assert_string_equal(a->maps[WG_GLTF_HEIGHT], "h");
    assert_null(a->maps[WG_GLTF_NORMAL]);
    assert_int_equal(a->line, 7);
    assert_int_equal(wg_graph_find_gltf(g, "asset"), 0);
    assert_int_equal(wg_graph_find_gltf(g, "base"), -1);
    wg_graph_free(g);
    /* the defaults: a text asset on a flat square, the texture once across */
    g = wgt_load(gltf_graph("<gltf name=\"a\" base_color=\"base\"/>"));
    a = wg_graph_gltf_info(g, 0);
    assert_false(a->binary);
    assert_int_equal(a->grid, 0);
    assert_true(a->height_scale == 0 && a->repeat == 1);
    wg_graph_free(g);

    load_fails(gltf_graph("<gltf base_color=\"base\"/>"), WG_ERR_PARSE, 7,
               "<gltf> needs a 'name' attribute");
    load_fails(gltf_graph("<gltf name=\"a\" roughness=\"rough\"/>"), WG_ERR_PARSE, 7,
               "gltf 'a' needs base_color");
    load_fails(gltf_graph("<gltf name=\"a\" base_color=\"bsae\"/>"), WG_ERR_PARSE, 7,
               "gltf 'a': base_color names no output 'bsae'; did you mean 'base'?");
    load_fails(gltf_graph("<gltf name=\"rough\" base_color=\"base\"/>"), WG_ERR_PARSE, 7,
               "the name is taken by an output or another gltf");
    load_fails(gltf_graph("<gltf name=\"a\" base_color=\"base\" grid=\"8\"/>"), WG_ERR_PARSE, 7,
               "a grid (grid=\"8\") needs height");
    load_fails(gltf_graph("<gltf name=\"a\" base_color=\"base\" grid=\"8.5\" height=\"h\"/>"),
               WG_ERR_PARSE, 7, "'grid' must be a whole number from 0 to 4096, not '8.5'");
    load_fails(gltf_graph("<gltf name=\"a\" base_color=\"base\" repeat=\"0.5\"/>"), WG_ERR_PARSE, 7,
               "'repeat' must be a number from 1 to 1e+06");
    load_fails(gltf_graph("<gltf name=\"a\" base_color=\"base\" binary=\"yes\"/>"), WG_ERR_PARSE, 7,
               "binary must be true or false, not 'yes'");
    load_fails(gltf_graph("<gltf name=\"a\" base_color=\"base\" normals=\"h\"/>"), WG_ERR_PARSE, 7,
               "'normals'");
    load_fails(gltf_graph("<gltf name=\"a\" base_color=\"base\"><x/></gltf>"), WG_ERR_PARSE, 0, "");
    /* two assets of one name */
    char two[512];
    snprintf(two, sizeof two, "%s",
             "<gltf name=\"a\" base_color=\"base\"/>\n  <gltf name=\"a\" base_color=\"base\"/>");
    load_fails(gltf_graph(two), WG_ERR_PARSE, 8, "the name is taken");
}

/* ---- <warning> --------------------------------------------------------------------------- */

/* A graph with one param `k` (float) and `mode` (enum) whose line 4 is `warning`. */
static char *warning_graph(const char *warning)
{
    static char xml[2048];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"8\">\n"                                       /* 1 */
             "  <param name=\"k\" type=\"float\" default=\"0.5\" min=\"-9\" max=\"9\"/>\n" /* 2 */
             "  <node id=\"u\" type=\"uniform\" value=\"=k\"/>\n"                          /* 3 */
             "  %s\n"                                                                      /* 4 */
             "  <output name=\"o\" from=\"u\"/>\n"                                         /* 5 */
             "  <param name=\"mode\" type=\"enum\" values=\"a|b\"/>\n"                     /* 6 */
             "</wetgraph>\n",
             warning);
    return xml;
}

static void test_warning_element(void **state)
{
    (void)state;
    /* valid: any parameter (also one declared after it), $-names, {name}, {=expr}, braces */
    const char *const ok[] = {
        "<warning when=\"=k &lt; 0.1\" message=\"k is {k}\"/>",
        "<warning when=\"=mode == 1 &amp;&amp; $width &gt; 4\" message=\"{=1 / k}x {mode} {{}}\"/>",
        "<warning message=\"m\" when=\"=$time + $seed + $height\"/>",
        "<warning when=\"=1\" message=\"spans\n    two lines\"></warning>",
    };
    for (size_t i = 0; i < sizeof ok / sizeof *ok; i++)
        wg_graph_free(wgt_load(warning_graph(ok[i])));
    load_fails(warning_graph("<warning when=\"=k\" mesage=\"x\"/>"), WG_ERR_PARSE, 4,
               "unknown attribute 'mesage' on <warning>; did you mean 'message'?");
    load_fails(warning_graph("<warning when=\"=k\" message=\"x\" level=\"2\"/>"), WG_ERR_PARSE, 4,
               "unknown attribute 'level' on <warning>");
    load_fails(warning_graph("<warning when=\"=k\"/>"), WG_ERR_PARSE, 4,
               "<warning> needs a 'message' attribute");
    load_fails(warning_graph("<warning message=\"x\"/>"), WG_ERR_PARSE, 4,
               "<warning> needs a 'when' attribute");
    load_fails(warning_graph("<warning when=\"=k\" message=\"  \"/>"), WG_ERR_PARSE, 4,
               "'message' is empty");
    load_fails(warning_graph("<warning when=\"k &lt; 1\" message=\"x\"/>"), WG_ERR_PARSE, 4,
               "'when' must be an expression starting with '='");
    /* bad expressions: the column within the attribute, and a suggestion */
    load_fails(warning_graph("<warning when=\"=k +\" message=\"x\"/>"), WG_ERR_PARSE, 4,
               "test.wetgraph:4:|warning, attribute 'when', column");
    load_fails(warning_graph("<warning when=\"=kk &lt; 1\" message=\"x\"/>"), WG_ERR_PARSE, 4,
               "test.wetgraph:4:2:|unknown name 'kk'; did you mean 'k'?");
    load_fails(warning_graph("<warning when=\"=sqrt(k, 2)\" message=\"x\"/>"), WG_ERR_PARSE, 4,
               "warning, attribute 'when'");
    /* the message's substitutions */
    load_fails(warning_graph("<warning when=\"=k\" message=\"k is {kk}\"/>"), WG_ERR_PARSE, 4,
               "no parameter 'kk'; did you mean 'k'?");
    load_fails(warning_graph("<warning when=\"=k\" message=\"k is {=k *}\"/>"), WG_ERR_PARSE, 4,
               "warning, attribute 'message' at column 7");
    load_fails(warning_graph("<warning when=\"=k\" message=\"k is {k\"/>"), WG_ERR_PARSE, 4,
               "'{' without '}'");
    load_fails(warning_graph("<warning when=\"=k\" message=\"k is }\"/>"), WG_ERR_PARSE, 4,
               "'}' without '{'");
    /* on the line of the attribute in a tag over several lines; nothing inside */
    load_fails(warning_graph("<warning message=\"x\"\n           when=\"=k +\"/>"), WG_ERR_PARSE, 5,
               "warning, attribute 'when'");
    load_fails(warning_graph("<warning when=\"=k\" message=\"x\">text</warning>"), WG_ERR_PARSE, 4,
               "unexpected text inside <warning>");
    load_fails(warning_graph("<warning when=\"=k\" message=\"x\"><in name=\"a\"/></warning>"),
               WG_ERR_PARSE, 4, "unexpected <in> inside <warning>");
}

/* ---- valid files and the info accessors --------------------------------------------------- */

static const char *const valid_xml =
    "<wetgraph version=\"1\" size=\"32x16\" seed=\"42\" label=\"Demo\">\n"                /* 1 */
    "  <param name=\"amount\" type=\"float\" default=\"0.25\" min=\"0\" max=\"1\"\n"      /* 2 */
    "         label=\"Amount\"/>\n"                                                       /* 3 */
    "  <param name=\"count\" type=\"int\" min=\"2\"/>\n"                                  /* 4 */
    "  <param name=\"flip\" type=\"bool\"/>\n"                                            /* 5 */
    "  <param name=\"tint\" type=\"color\" default=\"#ff8000\"/>\n"                       /* 6 */
    "  <param name=\"mode\" type=\"enum\" values=\"multiply|screen|add\"/>\n"             /* 7 */
    "  <param name=\"note\" type=\"string\" default=\"hello\"/>\n"                        /* 8 */
    "  <input name=\"base\" type=\"color\" colorspace=\"srgb\" default=\"#808080\"/>\n"   /* 9 */
    "  <input name=\"mask\" type=\"gray\"/>\n"                                            /* 10 */
    "  <node id=\"fg\" type=\"uniform\" kind=\"color\" color=\"=tint\" pos=\"10 20\"/>\n" /* 11 */
    "  <node id=\"mix\" type=\"blend\" mode=\"=mode\" opacity=\"=amount * 2 - 0.1\"\n"    /* 12 */
    "        clamp=\"=!flip\" label=\"Mix\">\n"                                           /* 13 */
    "    <in name=\"foreground\" from=\"fg\"/>\n"                                         /* 14 */
    "    <in name=\"background\" from=\"$base\"/>\n"                                      /* 15 */
    "    <in name=\"mask\" from=\"$mask\"/>\n"                                            /* 16 */
    "  </node>\n"                                                                         /* 17 */
    "  <!-- a comment is fine -->\n"                                                      /* 18 */
    "  <node id=\"soft\" type=\"blur\" sigma=\"=$width / 16\" size=\"/2\" seed=\"7\">\n"  /* 19 */
    "    <in name=\"source\" from=\"mix.output\"/>\n"                                     /* 20 */
    "  </node>\n"                                                                         /* 21 */
    "  <output name=\"color\" from=\"soft\" format=\"exr\" colorspace=\"linear\"/>\n"     /* 22 */
    "  <output name=\"raw\" from=\"$base\" format=\"png16\" colorspace=\"srgb\"/>\n"      /* 23 */
    "</wetgraph>\n";

/* ---- UI hints of <param> -------------------------------------------------------------------- */

static const char *hint_graph(const char *param_attrs)
{
    static char xml[1024];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"4\">\n"
             "  <param name=\"p\" %s/>\n"
             "  <node id=\"u\" type=\"uniform\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n",
             param_attrs);
    return xml;
}

/* soft_min, soft_max, step, group and description are read and reported; the hard range still
 * validates (a value beyond the soft range but within min..max is taken); bad hints are errors
 * at their attribute's line, naming the parameter. */
static void test_param_hints(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(hint_graph(
        "type=\"float\" default=\"16\" min=\"0.001\" max=\"4096\" soft_min=\"1\" soft_max=\"64\" "
        "step=\"0.5\" group=\"Zones\" label=\"Relief depth\" description=\"The length the range "
        "stands for\""));
    const WgGraphParamInfo *p = wg_graph_param_info(g, 0);
    assert_true(p->has_soft_min && p->has_soft_max && p->has_step);
    assert_true(p->soft_min == 1 && p->soft_max == 64 && p->step == 0.5);
    assert_string_equal(p->group, "Zones");
    assert_string_equal(p->label, "Relief depth");
    assert_string_equal(p->description, "The length the range stands for");
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    assert_int_equal(wg_request_set(r, "p", "1000", &err), WG_OK); /* beyond the soft range */
    assert_int_equal(wg_request_set(r, "p", "5000", &err), WG_ERR_RANGE); /* beyond the hard */
    wg_request_free(r);
    wg_graph_free(g);
    /* without hints: none reported */
    g = wgt_load(hint_graph("type=\"int\" default=\"2\" min=\"0\" max=\"8\""));
    p = wg_graph_param_info(g, 0);
    assert_false(p->has_soft_min || p->has_soft_max || p->has_step);
    assert_null(p->group);
    assert_null(p->description);
    wg_graph_free(g);
    /* a group and a description suit every type; an int step is whole */
    wg_graph_free(wgt_load(hint_graph("type=\"color\" group=\"Colour\" description=\"d\"")));
    wg_graph_free(wgt_load(hint_graph("type=\"int\" min=\"0\" max=\"8\" step=\"2\"")));
    load_fails(hint_graph("type=\"float\" min=\"0\" max=\"10\" soft_max=\"11\""), WG_ERR_RANGE, 2,
               "soft_max 11 of parameter 'p' is outside its range (max 10)");
    load_fails(hint_graph("type=\"float\" min=\"0\" max=\"10\" soft_min=\"-1\""), WG_ERR_RANGE, 2,
               "soft_min -1 of parameter 'p' is outside its range (min 0)");
    load_fails(hint_graph("type=\"float\" soft_min=\"5\" soft_max=\"5\""), WG_ERR_RANGE, 2,
               "soft_min 5 of parameter 'p' is not below its soft_max 5");
    load_fails(hint_graph("type=\"float\" step=\"0\""), WG_ERR_RANGE, 2,
               "step 0 of parameter 'p' must be a positive number");
    load_fails(hint_graph("type=\"int\" step=\"0.5\""), WG_ERR_RANGE, 2,
               "step 0.5 of parameter 'p' must be a positive whole number");
    load_fails(hint_graph("type=\"bool\" soft_min=\"0\""), WG_ERR_PARSE, 2,
               "soft_min applies only to float and int parameters");
    load_fails(hint_graph("type=\"float\" step=\"fast\""), WG_ERR_TYPE, 2,
               "'step' expects a number, got 'fast'");
    /* the attribute's own line, when the element spans several */
    load_fails("<wetgraph version=\"1\" size=\"4\">\n"
               "  <param name=\"p\" type=\"float\" min=\"0\" max=\"1\"\n"
               "         soft_max=\"2\"/>\n"
               "  <node id=\"u\" type=\"uniform\"/><output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 3, "soft_max 2");
}

static void test_valid_file_and_info(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(valid_xml);
    assert_string_equal(wg_graph_name(g), "test");
    assert_true(ends_with(wg_graph_path(g), "/test.wetgraph"));
    assert_string_equal(wg_graph_size_text(g), "32x16");
    assert_int_equal(wg_graph_seed(g), 42);

    assert_int_equal(wg_graph_param_count(g), 6);
    const WgGraphParamInfo *p = wg_graph_param_info(g, 0);
    assert_string_equal(p->name, "amount");
    assert_int_equal(p->type, WG_PARAM_FLOAT_T);
    assert_string_equal(p->default_text, "0.25");
    assert_true(p->has_min && p->has_max);
    assert_float_equal(p->min, 0, 0);
    assert_float_equal(p->max, 1, 0);
    assert_string_equal(p->label, "Amount");
    assert_null(p->values);
    /* no line check here: libxml2 numbers an element by the line where its start tag ends */

    p = wg_graph_param_info(g, 1);
    assert_string_equal(p->name, "count");
    assert_int_equal(p->type, WG_PARAM_INT_T);
    assert_true(p->has_min);
    assert_false(p->has_max);
    assert_float_equal(p->min, 2, 0);
    assert_string_equal(p->default_text, "2"); /* no default: the minimum when it is > 0 */
    assert_null(p->label);
    assert_int_equal(p->line, 4);

    p = wg_graph_param_info(g, 2);
    assert_int_equal(p->type, WG_PARAM_BOOL_T);
    assert_string_equal(p->default_text, "false");
    assert_false(p->has_min || p->has_max);

    p = wg_graph_param_info(g, 3);
    assert_int_equal(p->type, WG_PARAM_COLOR_T);
    assert_string_equal(p->default_text, "#ff8000");

    p = wg_graph_param_info(g, 4);
    assert_string_equal(p->name, "mode");
    assert_int_equal(p->type, WG_PARAM_ENUM_T);
    assert_string_equal(p->default_text, "multiply"); /* no default: the first value */
    assert_non_null(p->values);
    assert_string_equal(p->values[0], "multiply");
    assert_string_equal(p->values[1], "screen");
    assert_string_equal(p->values[2], "add");
    assert_null(p->values[3]);
    assert_int_equal(p->line, 7);

    p = wg_graph_param_info(g, 5);
    assert_int_equal(p->type, WG_PARAM_STRING_T);
    assert_string_equal(p->default_text, "hello");

    assert_int_equal(wg_graph_input_count(g), 2);
    const WgGraphInputInfo *in = wg_graph_input_info(g, 0);
    assert_string_equal(in->name, "base");
    assert_int_equal(in->kind, WG_COLOR);
    assert_int_equal(in->colorspace, WG_SRGB);
    assert_true(in->has_default);
    assert_string_equal(in->default_text, "#808080");
    assert_int_equal(in->line, 9);
    in = wg_graph_input_info(g, 1);
    assert_string_equal(in->name, "mask");
    assert_int_equal(in->kind, WG_GRAY);
    assert_int_equal(in->colorspace, WG_LINEAR);
    assert_false(in->has_default);
    assert_null(in->default_text);
    assert_int_equal(in->line, 10);

    assert_int_equal(wg_graph_output_count(g), 2);
    const WgGraphOutputInfo *o = wg_graph_output_info(g, 0);
    assert_string_equal(o->name, "color");
    assert_string_equal(o->from, "soft");
    assert_int_equal(o->format, WG_FORMAT_EXR);
    assert_int_equal(o->colorspace, WG_LINEAR);
    assert_int_equal(o->line, 22);
    o = wg_graph_output_info(g, 1);
    assert_string_equal(o->from, "$base");
    assert_int_equal(o->format, WG_FORMAT_PNG16);
    assert_int_equal(o->colorspace, WG_SRGB);

    assert_int_equal(wg_graph_node_count(g), 3);
    const WgGraphNodeInfo *n = wg_graph_node_info(g, 0);
    assert_string_equal(n->id, "fg");
    assert_string_equal(n->type, "uniform");
    assert_false(n->is_subgraph);
    assert_null(n->subgraph_path);
    assert_int_equal(n->n_inputs, 0);
    assert_int_equal(n->line, 11);
    n = wg_graph_node_info(g, 1);
    assert_string_equal(n->id, "mix");
    assert_string_equal(n->type, "blend");
    assert_int_equal(n->n_inputs, 3);
    assert_string_equal(n->input_ports[0], "foreground");
    assert_string_equal(n->input_from[0], "fg");
    assert_string_equal(n->input_ports[1], "background");
    assert_string_equal(n->input_from[1], "$base");
    assert_string_equal(n->input_ports[2], "mask");
    assert_string_equal(n->input_from[2], "$mask");
    n = wg_graph_node_info(g, 2);
    assert_string_equal(n->input_from[0], "mix.output");
    assert_int_equal(n->line, 19);
    wg_graph_free(g);
}

static void test_defaults_of_the_root(void **state)
{
    (void)state;
    /* size and seed are optional: 1024 and 0 */
    WgGraph *g = wgt_load("<wetgraph version=\"1\">\n"
                          "  <node id=\"u\" type=\"uniform\"/>\n"
                          "  <output name=\"out\" from=\"u\"/>\n"
                          "</wetgraph>\n");
    assert_string_equal(wg_graph_size_text(g), "1024");
    assert_int_equal(wg_graph_seed(g), 0);
    assert_int_equal(wg_graph_output_info(g, 0)->format, WG_FORMAT_DEFAULT);
    wg_graph_free(g);
}

static void test_load_from_a_file(void **state)
{
    (void)state;
    const char *path = wgt_path("from_disk.wetgraph");
    wgt_write_file(path, valid_xml);
    WgGraph *g = NULL;
    WgError err = {0};
    assert_int_equal(wg_graph_load(path, &g, &err), WG_OK);
    assert_string_equal(wg_graph_name(g), "from_disk");
    assert_int_equal(wg_graph_node_count(g), 3);
    wg_graph_free(g);

    g = NULL;
    assert_int_equal(wg_graph_load(wgt_path("no_such.wetgraph"), &g, &err), WG_ERR_IO);
    assert_null(g);
    assert_non_null(strstr(err.message, "cannot open"));
    assert_true(ends_with(err.file, "no_such.wetgraph"));
}

/* ---- XML and document structure ---------------------------------------------------------- */

static void test_malformed_xml(void **state)
{
    (void)state;
    WgError err;
    assert_int_equal(wgt_load_error("<wetgraph version=\"1\">\n"
                                    "  <node id=\"a\" type=\"uniform\">\n"
                                    "  <output name=\"o\" from=\"a\"/>\n"
                                    "</wetgraph>\n",
                                    &err),
                     WG_ERR_PARSE);
    /* the first error, not the cascade that follows ("Premature end of data" at the end) */
    wgt_assert_error(&err, WG_ERR_PARSE, 4,
                     "XML: Opening and ending tag mismatch: node line 2 and wetgraph");
    assert_true(ends_with(err.file, "test.wetgraph"));

    /* an unquoted attribute on line 2 */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=a type=\"uniform\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "XML: ");
    /* nothing at all */
    load_fails("", WG_ERR_PARSE, 0, "");
    /* not XML */
    load_fails("size = 1024\n", WG_ERR_PARSE, 1, "XML: ");
}

static void test_root_and_version(void **state)
{
    (void)state;
    load_fails("<?xml version=\"1.0\"?>\n<graph version=\"1\"/>\n", WG_ERR_PARSE, 2,
               "the root element must be <wetgraph>, not <graph>");
    load_fails("<wetgraph size=\"8\">\n</wetgraph>\n", WG_ERR_PARSE, 1,
               "<wetgraph> needs version=\"1\"");
    load_fails("<wetgraph version=\"2\">\n</wetgraph>\n", WG_ERR_PARSE, 1,
               "unsupported version '2' (this engine reads version 1)");
    load_fails("<wetgraph version=\"1.0\">\n</wetgraph>\n", WG_ERR_PARSE, 1,
               "unsupported version '1.0'");
}

static void test_unknown_elements(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <nodes id=\"v\" type=\"uniform\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "unknown element <nodes>; did you mean <node>?");
    load_fails("<wetgraph version=\"1\">\n"
               "\n"
               "  <texture/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3,
               "unknown element <texture> (expected param, input, node, output, warning or gltf)");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\">\n"
               "    <input name=\"x\" from=\"v\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "unexpected <input> inside <node>");
}

static void test_unknown_attributes(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\" sise=\"8\">\n</wetgraph>\n", WG_ERR_PARSE, 1,
               "unknown attribute 'sise' on <wetgraph>; did you mean 'size'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\" defualt=\"1\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "unknown attribute 'defualt' on <param>; did you mean 'default'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <input name=\"a\" type=\"gray\" colourspace=\"srgb\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2,
               "unknown attribute 'colourspace' on <input>; did you mean 'colorspace'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\" formatt=\"png\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "unknown attribute 'formatt' on <output>; did you mean 'format'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in name=\"source\" form=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "unknown attribute 'form' on <in>; did you mean 'from'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\" colour=\"red\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "unknown attribute 'colour' on <param>");
    /* on a node, an unknown attribute is an unknown parameter of its type */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\" sigam=\"2\">\n"
               "    <in name=\"source\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3,
               "node \'b\'|node type 'blur' has no parameter 'sigam'; did you mean 'sigma'?");
    /* the reserved node attributes are suggested too */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" sized=\"8\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "has no parameter 'sized'; did you mean 'size'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" brightness=\"8\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "node \'u\'|node type 'uniform' has no parameter 'brightness'");
}

static void test_missing_required_attributes(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "<node> needs a 'type' attribute");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node type=\"uniform\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "<node> needs a 'id' attribute");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "<param> needs a 'type' attribute");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "<output> needs a 'from' attribute");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in from=\"u\"/>\n"
               "  </node>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "<in> needs a 'name' attribute");
}

/* ---- node types and parameters ----------------------------------------------------------- */

static void test_unknown_node_type(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blurr\">\n"
               "    <in name=\"source\" from=\"u\"/>\n"
               "  </node>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 3, "unknown node type 'blurr'; did you mean 'blur'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"zzqxv_nothing\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2,
               "unknown node type 'zzqxv_nothing' (not a built-in node, and no "
               "zzqxv_nothing.wetgraph next to this file, in WETGRAPH_PATH");
}

static void test_graph_param_declarations(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"double\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2,
               "unknown parameter type 'double' (float, int, bool, color, enum, string)");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"color\" min=\"0\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "min/max apply only to float and int parameters");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\" values=\"x|y\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "'values' applies only to enum parameters");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"enum\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "enum parameter 'a' needs values=");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"enum\" values=\"||\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "enum parameter 'a' has no values");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\" min=\"2\" max=\"1\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 2, "min 2 is greater than max 1");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\" min=\"low\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'min' expects a number, got 'low'");
}

static void test_malformed_literals(void **state)
{
    (void)state;
    /* float, on a node */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" value=\"half\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "node \'u\'|'value' expects a number, got 'half'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" value=\"0.5.1\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'value' expects a number, got '0.5.1'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" value=\"\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'value' expects a number, got ''");
    /* numbers are decimal, without spaces: hex, padding and inf/nan words are refused */
    static const char *const not_decimal[] = {"0x10", " 0.5", "0.5 ", "1e", "+-1", "0x1p3"};
    for (size_t i = 0; i < sizeof not_decimal / sizeof *not_decimal; i++) {
        char xml[256], msg[128];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\">\n"
                 "  <param name=\"a\" type=\"float\" default=\"%s\"/>\n"
                 "</wetgraph>\n",
                 not_decimal[i]);
        snprintf(msg, sizeof msg, "'a' expects a number, got '%s' (written in decimal",
                 not_decimal[i]);
        load_fails(xml, WG_ERR_TYPE, 2, msg);
    }
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" kind=\"color\" color=\"0x1 0 0\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'color' expects a colour");
    load_fails("<wetgraph version=\"1\" size=\" 8\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 1, "bad graph size ' 8'");
    load_fails("<wetgraph version=\"1\" size=\"8\">\n"
               "  <node id=\"u\" type=\"uniform\" size=\"x 2\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "node 'u': bad size 'x 2'");
    load_fails("<wetgraph version=\"1\" seed=\"18446744073709551616\">\n"
               "  <node id=\"u\" type=\"uniform\" seed=\"18446744073709551615\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 1, "seed must be a whole number >= 0, not '18446744073709551616'");
    /* float, as a graph parameter default */
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\" default=\"1,5\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'a' expects a number, got '1,5'");
    /* int (no built-in node has one: graph parameters) */
    load_fails("<wetgraph version=\"1\">\n"
               "\n"
               "  <param name=\"n\" type=\"int\" default=\"2.5\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 3, "'n' expects a whole number, got '2.5'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"n\" type=\"int\" default=\"three\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'n' expects a number, got 'three'");
    /* bool */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blend\" clamp=\"maybe\">\n"
               "    <in name=\"foreground\" from=\"u\"/>\n"
               "    <in name=\"background\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 3, "node \'b\'|'clamp' expects true or false, got 'maybe'");
    /* enum, with a suggestion and the list of values */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blend\" mode=\"multipy\">\n"
               "    <in name=\"foreground\" from=\"u\"/>\n"
               "    <in name=\"background\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 3,
               "'mode' has no value 'multipy'; did you mean 'multiply'? (one of: copy, add,");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" kind=\"rgb\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'kind' has no value 'rgb' (one of: gray, color)");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"m\" type=\"enum\" values=\"a|b\" default=\"c\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'m' has no value 'c'");
    /* color */
    static const char *const bad_colors[] = {"#12345",    "#ggg",    "red", "0.1 0.2",
                                             "1 2 3 4 5", "0.5 x 1", "#"};
    for (size_t i = 0; i < sizeof bad_colors / sizeof *bad_colors; i++) {
        char xml[512];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\">\n"
                 "  <node id=\"u\" type=\"uniform\" kind=\"color\" color=\"%s\"/>\n"
                 "  <output name=\"o\" from=\"u\"/>\n"
                 "</wetgraph>\n",
                 bad_colors[i]);
        char needle[128];
        snprintf(needle, sizeof needle,
                 "'color' expects a colour (#rrggbb, #rrggbbaa, 'r g b', "
                 "'r g b a' or one gray value), got '%s'",
                 bad_colors[i]);
        load_fails(xml, WG_ERR_TYPE, 2, needle);
    }
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"c\" type=\"color\" default=\"#12\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'c' expects a colour");
    /* input defaults */
    load_fails("<wetgraph version=\"1\">\n"
               "  <input name=\"i\" type=\"gray\" default=\"grey\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "bad default 'grey' for input 'i'");
}

static void test_good_literals(void **state)
{
    (void)state;
    /* the accepted spellings of each type load */
    WgGraph *g =
        wgt_load("<wetgraph version=\"1\" size=\"4\">\n"
                 "  <param name=\"b1\" type=\"bool\" default=\"yes\"/>\n"
                 "  <param name=\"b2\" type=\"bool\" default=\"0\"/>\n"
                 "  <param name=\"i\" type=\"int\" default=\"-3\"/>\n"
                 "  <param name=\"f\" type=\"float\" default=\"1e-3\"/>\n"
                 "  <param name=\"c1\" type=\"color\" default=\"#abc\"/>\n"
                 "  <param name=\"c2\" type=\"color\" default=\"#aabbccdd\"/>\n"
                 "  <param name=\"c3\" type=\"color\" default=\"0.1, 0.2, 0.3\"/>\n"
                 "  <param name=\"c4\" type=\"color\" default=\"0.5\"/>\n"
                 "  <node id=\"u\" type=\"uniform\" kind=\"color\" color=\"1 0.5 0.25 0.125\"/>\n"
                 "  <output name=\"o\" from=\"u\"/>\n"
                 "</wetgraph>\n");
    WgResult *r = wgt_render(g, 1);
    const WgImage *img = wgt_output(r, "o");
    assert_int_equal(img->channels, 4);
    assert_float_equal(wgt_px(img, 3, 3, 0), 1.0f, 0);
    assert_float_equal(wgt_px(img, 3, 3, 1), 0.5f, 0);
    assert_float_equal(wgt_px(img, 3, 3, 2), 0.25f, 0);
    assert_float_equal(wgt_px(img, 3, 3, 3), 0.125f, 0);
    wg_result_free(r);
    wg_graph_free(g);
}

static void test_out_of_range_literals(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blend\" opacity=\"1.5\">\n"
               "    <in name=\"foreground\" from=\"u\"/>\n"
               "    <in name=\"background\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 3, "node \'b\'|'opacity' = 1.5 is outside [0, 1]");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\" sigma=\"-1\">\n"
               "    <in name=\"source\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 3, "'sigma' = -1 is outside [0, 16384]");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\" min=\"0\" max=\"1\" default=\"2\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 2, "'a' = 2 is outside [0, 1]");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"int\" min=\"1\" default=\"0\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 2, "'a' = 0 is below its minimum 1");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\" max=\"10\" default=\"11\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 2, "'a' = 11 is above its maximum 10");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" value=\"inf\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 2, "'value' is infinite, not a finite number");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" value=\"nan\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 2, "'value' is NaN, not a finite number");
}

/* A value just outside its range is printed with the digits that make it differ from the
 * bound (the shortest text that reads back as the same double), not rounded onto it. */
static void test_range_errors_print_enough_digits(void **state)
{
    (void)state;
    static const struct {
        const char *attrs, *needle;
    } cases[] = {
        {"min=\"0\" max=\"1\" default=\"1.0000001\"", "'a' = 1.0000001 is outside [0, 1]"},
        {"min=\"0\" max=\"1\" default=\"1.00000000000001\"",
         "'a' = 1.00000000000001 is outside [0, 1]"},
        {"min=\"0\" max=\"1\" default=\"-1e-9\"", "'a' = -1e-09 is outside [0, 1]"},
        {"min=\"0.1\" max=\"0.30000000000000004\" default=\"0.30000000000000009\"",
         "'a' = 0.3000000000000001 is outside [0.1, 0.30000000000000004]"},
        {"min=\"123456.7890123\" default=\"123456.7890122\"",
         "'a' = 123456.7890122 is below its minimum 123456.7890123"},
        {"max=\"2.5e-7\" default=\"2.5000001e-7\"",
         "'a' = 2.5000001e-07 is above its maximum 2.5e-07"},
        {"min=\"0.30000000000000004\" max=\"0.3\"",
         "min 0.30000000000000004 is greater than max 0.3"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char xml[512];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\">\n\n  <param name=\"a\" type=\"float\" %s/>\n"
                 "</wetgraph>\n",
                 cases[i].attrs);
        load_fails(xml, WG_ERR_RANGE, 3, cases[i].needle);
    }
    /* a node parameter of a built-in node */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blend\" opacity=\"1.000001\">\n"
               "    <in name=\"foreground\" from=\"u\"/>\n"
               "    <in name=\"background\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_RANGE, 3, "'opacity' = 1.000001 is outside [0, 1]");
}

/* An enum parameter listing one value twice is an error at the line of its values. */
static void test_duplicate_enum_values(void **state)
{
    (void)state;
    static const struct {
        const char *values, *twice;
    } cases[] = {
        {"a|a|b", "a"},     {"x|y|z|y", "y"},        {"b a b", "b"},
        {"p,q, r ,q", "q"}, {"one||two|one", "one"}, {"m|n|o|p|q|r|s|t|u|m", "m"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char xml[512], needle[128];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\">\n  <param name=\"e%zu\" type=\"enum\"\n"
                 "         values=\"%s\"/>\n</wetgraph>\n",
                 i, cases[i].values);
        snprintf(needle, sizeof needle, "enum parameter 'e%zu' lists the value '%s' twice", i,
                 cases[i].twice);
        load_fails(xml, WG_ERR_PARSE, 3, needle);
    }
    /* values differing only in case are different values */
    WgGraph *g = NULL;
    WgError err = {0};
    const char *ok = "<wetgraph version=\"1\">\n"
                     "  <param name=\"e\" type=\"enum\" values=\"a|A|b\" default=\"A\"/>\n"
                     "  <node id=\"u\" type=\"uniform\"/>\n"
                     "  <output name=\"o\" from=\"u\"/>\n"
                     "</wetgraph>\n";
    assert_int_equal(wg_graph_load_memory(ok, strlen(ok), "ok.wetgraph", &g, &err), WG_OK);
    wg_graph_free(g);
}

/* Elements and attributes in an XML namespace are refused, wherever they are. */
static void test_namespaces(void **state)
{
    (void)state;
    load_fails("<x:wetgraph xmlns:x=\"urn:x\" version=\"1\">\n"
               "  <x:node id=\"u\" type=\"uniform\"/>\n"
               "  <x:output name=\"o\" from=\"u\"/>\n"
               "</x:wetgraph>\n",
               WG_ERR_PARSE, 1, "element <x:wetgraph> is in the XML namespace 'urn:x'");
    load_fails("<?xml version=\"1.0\"?>\n<wetgraph xmlns=\"urn:wetgraph\" version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "element <wetgraph> is in the XML namespace 'urn:wetgraph'");
    load_fails("<wetgraph version=\"1\" xmlns:y=\"urn:y\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"v\" type=\"invert\">\n"
               "    <y:in name=\"source\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"v\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "element <y:in> is in the XML namespace 'urn:y'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\"/>\n"
               "  <node xmlns=\"urn:z\" id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "element <node> is in the XML namespace 'urn:z'");
    load_fails("<wetgraph version=\"1\" xmlns:q=\"urn:q\">\n"
               "  <node id=\"u\" type=\"uniform\"\n"
               "        q:value=\"0.5\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "attribute 'q:value' on <node> is in the XML namespace 'urn:q'");
    /* a namespace declared and not used changes nothing */
    WgGraph *g = NULL;
    WgError err = {0};
    const char *ok = "<wetgraph version=\"1\" xmlns:q=\"urn:q\">\n"
                     "  <node id=\"u\" type=\"uniform\"/>\n"
                     "  <output name=\"o\" from=\"u\"/>\n"
                     "</wetgraph>\n";
    assert_int_equal(wg_graph_load_memory(ok, strlen(ok), "ok.wetgraph", &g, &err), WG_OK);
    wg_graph_free(g);
}

/* Bytes that are not UTF-8 are one error of one line, at the line where they are. */
static void test_invalid_utf8(void **state)
{
    (void)state;
    static const char *const bad[] = {
        "caf\xe9",      /* Latin-1 */
        "\xff\xfe",     /* no UTF-8 lead byte */
        "\xc0\xaf",     /* overlong */
        "ab\xe2\x82",   /* cut short */
        "\xed\xa0\x80", /* a UTF-16 surrogate */
        "x\x80y",       /* a lone continuation byte */
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        for (int line = 2; line <= 4; line += 2) {
            char xml[512];
            snprintf(xml, sizeof xml,
                     "<wetgraph version=\"1\">\n%s  <node id=\"u\" type=\"uniform\" "
                     "label=\"%s\"/>\n  <output name=\"o\" from=\"u\"/>\n</wetgraph>\n",
                     line == 4 ? "\n\n" : "", bad[i]);
            WgError err;
            assert_int_equal(wgt_load_error(xml, &err), WG_ERR_PARSE);
            wgt_assert_error(&err, WG_ERR_PARSE, line, "XML: ");
            if (strchr(err.message, '\n')) fail_msg("two lines: %s", err.message);
            assert_true(ends_with(err.file, "test.wetgraph"));
        }
    }
}

/* ---- ids and declarations ---------------------------------------------------------------- */

static void test_duplicates(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"v\" type=\"uniform\"/>\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "duplicate node id 'u' (first defined at line 2)");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\"/>\n"
               "  <param name=\"a\" type=\"int\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "parameter 'a' is declared twice");
    load_fails("<wetgraph version=\"1\">\n"
               "  <input name=\"i\" type=\"gray\"/>\n"
               "  <input name=\"i\" type=\"color\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "input 'i' is declared twice");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "output 'o' is declared twice");
}

static void test_bad_ids(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"1st\" type=\"uniform\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "bad node id '1st'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"a.b\" type=\"uniform\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "bad node id 'a.b'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"\" type=\"uniform\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "bad node id ''");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"water-level\" type=\"float\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "parameter name 'water-level' must start with a letter");
    load_fails("<wetgraph version=\"1\">\n"
               "  <input name=\"$in\" type=\"gray\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "bad input name '$in'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"my out\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "bad output name 'my out'");
    /* ids may use '-' and '_' */
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"2\">\n"
                          "  <node id=\"_base-1\" type=\"uniform\"/>\n"
                          "  <output name=\"o\" from=\"_base-1\"/>\n"
                          "</wetgraph>\n");
    wg_graph_free(g);
}

static void test_other_declaration_errors(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <input name=\"i\" type=\"rgb\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "input type must be 'gray' or 'color', not 'rgb'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <input name=\"i\" type=\"gray\" colorspace=\"sRGB\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "colorspace must be 'linear' or 'srgb', not 'sRGB'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\" format=\"gif\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "unknown format 'gif' (png, png16, tif16, exr, exr32, jpeg, tga)");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\" colorspace=\"gamma\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "colorspace must be 'linear' or 'srgb', not 'gamma'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" size=\"8\" seed=\"-4\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "node \'u\'|seed must be a whole number >= 0, not '-4'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" seed=\"99999999999999999999\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "node \'u\'|seed must be a whole number >= 0");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" value=\"1\" value=\"2\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "XML: "); /* XML itself forbids repeated attributes */
}

/* ---- connections ------------------------------------------------------------------------- */

static void test_dangling_references(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"noise\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in name=\"source\" from=\"nosie\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "no node 'nosie'; did you mean 'noise'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in name=\"source\" from=\"height_map\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "no node 'height_map' (a graph input is written '$name')");
    load_fails("<wetgraph version=\"1\">\n"
               "  <input name=\"height\" type=\"gray\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in name=\"source\" from=\"$hieght\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "no graph input 'hieght'; did you mean '$height'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"v\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "no node 'v'");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"$u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "no graph input 'u'");
}

static void test_ports(void **state)
{
    (void)state;
    /* unknown input port, with and without a suggestion */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in name=\"sourse\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "node \'b\'|has no input 'sourse'; did you mean 'source'?");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blend\">\n"
               "    <in name=\"foreground\" from=\"u\"/>\n"
               "    <in name=\"background\" from=\"u\"/>\n"
               "    <in name=\"alpha\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 6,
               "node \'b\'|has no input 'alpha' (inputs: foreground, background, mask)");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"v\" type=\"uniform\">\n"
               "    <in name=\"source\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"v\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "(inputs: none)");
    /* unknown output port, in <in from> and in <output from> */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in name=\"source\" from=\"u.out\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "node 'u' has no output 'out' (outputs: output)");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u.image\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "node 'u' has no output 'image' (outputs: output)");
    /* an explicit, correct port is fine */
    wg_graph_free(wgt_load("<wetgraph version=\"1\" size=\"2\">\n"
                           "  <node id=\"u\" type=\"uniform\"/>\n"
                           "  <output name=\"o\" from=\"u.output\"/>\n"
                           "</wetgraph>\n"));
    /* connected twice: the second <in> is reported */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in name=\"source\" from=\"u\"/>\n"
               "    <in name=\"source\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 5, "node \'b\'|input 'source' is connected twice");
    /* required input missing: the node's line; optional ones may stay unconnected */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blend\">\n"
               "    <in name=\"foreground\" from=\"u\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3,
               "node \'b\'|required input 'background' is not connected; "
               "add <in name=\"background\" from=\"...\"/>");
}

static void test_cycles(void **state)
{
    (void)state;
    WgError err;
    assert_int_equal(wgt_load_error("<wetgraph version=\"1\">\n"
                                    "  <node id=\"u\" type=\"uniform\"/>\n"
                                    "  <node id=\"a\" type=\"blur\">\n"
                                    "    <in name=\"source\" from=\"c\"/>\n"
                                    "  </node>\n"
                                    "  <node id=\"b\" type=\"invert\">\n"
                                    "    <in name=\"source\" from=\"a\"/>\n"
                                    "  </node>\n"
                                    "  <node id=\"c\" type=\"levels\">\n"
                                    "    <in name=\"source\" from=\"b\"/>\n"
                                    "  </node>\n"
                                    "  <output name=\"o\" from=\"u\"/>\n"
                                    "</wetgraph>\n",
                                    &err),
                     WG_ERR_CYCLE);
    wgt_assert_error(&err, WG_ERR_CYCLE, 0, "cycle between nodes: ");
    /* every node of the loop is named, in the order of the edges, and nothing else */
    const char *m = strstr(err.message, "cycle between nodes: ") + strlen("cycle between nodes: ");
    const char *const loops[] = {"a -> c -> b -> a", "c -> b -> a -> c", "b -> a -> c -> b"};
    bool found = false;
    for (int i = 0; i < 3; i++) found |= !strcmp(m, loops[i]);
    if (!found) fail_msg("unexpected cycle description '%s'", m);
    assert_true(err.line == 3 || err.line == 6 || err.line == 9);
    assert_null(strstr(err.message, "u"));

    /* a node feeding itself */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"s\" type=\"blur\">\n"
               "    <in name=\"source\" from=\"s\"/>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"s\"/>\n"
               "</wetgraph>\n",
               WG_ERR_CYCLE, 2, "cycle between nodes: s -> s");
}

static void test_no_outputs(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 1, "the graph declares no <output>");
}

static void test_sizes(void **state)
{
    (void)state;
    static const char *const bad_graph_sizes[] = {"0",   "abc", "16385", "8x",       "x8",
                                                  "8x0", "-4",  "8 x 8", "100000x1", ""};
    for (size_t i = 0; i < sizeof bad_graph_sizes / sizeof *bad_graph_sizes; i++) {
        char xml[512], needle[128];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"%s\">\n"
                 "  <node id=\"u\" type=\"uniform\"/>\n"
                 "  <output name=\"o\" from=\"u\"/>\n"
                 "</wetgraph>\n",
                 bad_graph_sizes[i]);
        snprintf(needle, sizeof needle, "bad graph size '%s' (N, WxH or $input; sides 1..16384)",
                 bad_graph_sizes[i]);
        load_fails(xml, WG_ERR_PARSE, 1, needle);
    }
    load_fails("<wetgraph version=\"1\" size=\"$img\">\n"
               "  <input name=\"image\" type=\"gray\"/>\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 1, "size '$img' names no graph input");

    static const char *const bad_node_sizes[] = {"0",   "x0",     "/0",     "x",    "/abc", "x-2",
                                                 "0x5", "inputs", "x99999", "half", "16385"};
    for (size_t i = 0; i < sizeof bad_node_sizes / sizeof *bad_node_sizes; i++) {
        char xml[512], needle[160];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"8\">\n"
                 "  <node id=\"u\" type=\"uniform\" size=\"%s\"/>\n"
                 "  <output name=\"o\" from=\"u\"/>\n"
                 "</wetgraph>\n",
                 bad_node_sizes[i]);
        snprintf(needle, sizeof needle,
                 "node \'u\'|bad size '%s' (N, WxH, xK, /K, input or graph; sides 1..16384)",
                 bad_node_sizes[i]);
        load_fails(xml, WG_ERR_PARSE, 2, needle);
    }
    /* every accepted form loads */
    static const char *const good_node_sizes[] = {"16", "16x4", "x2",    "x0.5",
                                                  "/4", "/1.5", "graph", "16384"};
    for (size_t i = 0; i < sizeof good_node_sizes / sizeof *good_node_sizes; i++) {
        char xml[512];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"8\">\n"
                 "  <node id=\"u\" type=\"uniform\" size=\"%s\"/>\n"
                 "  <output name=\"o\" from=\"u\"/>\n"
                 "</wetgraph>\n",
                 good_node_sizes[i]);
        wg_graph_free(wgt_load(xml));
    }
}

/* ---- expressions ------------------------------------------------------------------------- */

static void test_expression_syntax_errors(void **state)
{
    (void)state;
    WgError err;
    /* the column counts from the start of the attribute value, '=' included */
    wgt_load_error("<wetgraph version=\"1\">\n"
                   "  <param name=\"k\" type=\"float\"/>\n"
                   "  <node id=\"u\" type=\"uniform\" value=\"=k * (2 + \"/>\n"
                   "  <output name=\"o\" from=\"u\"/>\n"
                   "</wetgraph>\n",
                   &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 3, "node 'u'|attribute 'value'|unexpected end");
    assert_int_equal(err.column, 11);

    wgt_load_error("<wetgraph version=\"1\">\n"
                   "  <node id=\"u\" type=\"uniform\" value=\"=2 3\"/>\n"
                   "  <output name=\"o\" from=\"u\"/>\n"
                   "</wetgraph>\n",
                   &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 2, "column 4: unexpected '3'");
    assert_int_equal(err.column, 4);

    wgt_load_error("<wetgraph version=\"1\">\n"
                   "  <node id=\"u\" type=\"uniform\" value=\"=\"/>\n"
                   "  <output name=\"o\" from=\"u\"/>\n"
                   "</wetgraph>\n",
                   &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 2, "empty expression");
    assert_int_equal(err.column, 2);

    wgt_load_error("<wetgraph version=\"1\">\n"
                   "  <node id=\"u\" type=\"uniform\" value=\"=clamp(1, 2)\"/>\n"
                   "  <output name=\"o\" from=\"u\"/>\n"
                   "</wetgraph>\n",
                   &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 2, "'clamp' takes 3 arguments, got 2");
    assert_int_equal(err.column, 2);

    /* the pixel functions are not available in attributes */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" value=\"=noise(1, 2)\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "only available in the pixel node");
}

static void test_expression_names(void **state)
{
    (void)state;
    WgError err;
    wgt_load_error("<wetgraph version=\"1\">\n"
                   "  <param name=\"water_level\" type=\"float\"/>\n"
                   "  <node id=\"u\" type=\"uniform\" value=\"=1 - wter_level\"/>\n"
                   "  <output name=\"o\" from=\"u\"/>\n"
                   "</wetgraph>\n",
                   &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 3, "unknown name 'wter_level'");
    assert_int_equal(err.column, 6);

    /* '$' names other than the four of the scope */
    wgt_load_error("<wetgraph version=\"1\">\n"
                   "  <node id=\"u\" type=\"uniform\" value=\"=$frame\"/>\n"
                   "  <output name=\"o\" from=\"u\"/>\n"
                   "</wetgraph>\n",
                   &err);
    wgt_assert_error(&err, WG_ERR_PARSE, 2, "unknown name '$frame'");

    /* colour and string parameters are not numbers */
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"tint\" type=\"color\"/>\n"
               "  <node id=\"u\" type=\"uniform\" value=\"=tint * 2\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "unknown name 'tint' (it is a color parameter, not a number)");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"file\" type=\"string\"/>\n"
               "  <node id=\"u\" type=\"uniform\" value=\"=file\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "unknown name 'file' (it is a string parameter, not a number)");

    /* numeric, bool and enum parameters and the four specials are in scope */
    wg_graph_free(wgt_load("<wetgraph version=\"1\" size=\"4\">\n"
                           "  <param name=\"a\" type=\"float\"/>\n"
                           "  <param name=\"n\" type=\"int\"/>\n"
                           "  <param name=\"f\" type=\"bool\"/>\n"
                           "  <param name=\"m\" type=\"enum\" values=\"x|y\"/>\n"
                           "  <node id=\"u\" type=\"uniform\"\n"
                           "        value=\"=a + n + f + m + $time + $seed + $width + $height\"/>\n"
                           "  <output name=\"o\" from=\"u\"/>\n"
                           "</wetgraph>\n"));
}

static void test_non_numeric_forwarding(void **state)
{
    (void)state;
    /* '=name' forwards a graph parameter of the same type to a colour/enum/string parameter */
    WgGraph *g =
        wgt_load("<wetgraph version=\"1\" size=\"2\">\n"
                 "  <param name=\"tint\" type=\"color\" default=\"0.5 0.25 1 1\"/>\n"
                 "  <param name=\"how\" type=\"enum\" values=\"gray|color\" default=\"color\"/>\n"
                 "  <node id=\"u\" type=\"uniform\" kind=\"= how \" color=\"=tint\"/>\n"
                 "  <output name=\"o\" from=\"u\"/>\n"
                 "</wetgraph>\n");
    WgResult *r = wgt_render(g, 1);
    const WgImage *img = wgt_output(r, "o");
    assert_int_equal(img->channels, 4);
    assert_float_equal(wgt_px(img, 1, 1, 0), 0.5f, 0);
    assert_float_equal(wgt_px(img, 1, 1, 1), 0.25f, 0);
    assert_float_equal(wgt_px(img, 1, 1, 2), 1.0f, 0);
    wg_result_free(r);
    wg_graph_free(g);

    /* of another type */
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"amount\" type=\"float\"/>\n"
               "  <node id=\"u\" type=\"uniform\" color=\"=amount\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 3,
               "node \'u\'|'color' is a color parameter: its value can only be a literal or "
               "'=name' of a graph color parameter");
    /* an expression */
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"tint\" type=\"color\"/>\n"
               "  <node id=\"u\" type=\"uniform\" color=\"=tint * 2\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 3, "'color' is a color parameter");
    /* no such parameter */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\" kind=\"=mode\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 2, "'kind' is an enum parameter");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"p\" type=\"string\"/>\n"
               "  <node id=\"u\" type=\"image\" path=\"=q\"/>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_TYPE, 3, "'path' is a string parameter");
}

/* ---- text and seeds ---------------------------------------------------------------------- */

static void test_text_inside_elements(void **state)
{
    (void)state;
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  hello\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 0, "unexpected text inside <wetgraph>");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\">value</node>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "unexpected text inside <node>");
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\">0.5</param>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "unexpected text inside <param>");
    load_fails("<wetgraph version=\"1\">\n"
               "  <input name=\"a\" type=\"gray\">x</input>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "unexpected text inside <input>");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\">png</output>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "unexpected text inside <output>");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <node id=\"b\" type=\"blur\">\n"
               "    <in name=\"source\" from=\"u\">u</in>\n"
               "  </node>\n"
               "  <output name=\"o\" from=\"b\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "unexpected text inside <in>");
    /* CDATA is text too */
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"><![CDATA[x]]></node>\n"
               "  <output name=\"o\" from=\"u\"/>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 2, "unexpected text inside <node>");
    /* elements nested where none belong */
    load_fails("<wetgraph version=\"1\">\n"
               "  <param name=\"a\" type=\"float\">\n"
               "    <default>1</default>\n"
               "  </param>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 3, "unexpected <default> inside <param>");
    load_fails("<wetgraph version=\"1\">\n"
               "  <node id=\"u\" type=\"uniform\"/>\n"
               "  <output name=\"o\" from=\"u\">\n"
               "    <format>png</format>\n"
               "  </output>\n"
               "</wetgraph>\n",
               WG_ERR_PARSE, 4, "unexpected <format> inside <output>");
    /* whitespace and comments are fine */
    wg_graph_free(wgt_load("<wetgraph version=\"1\" size=\"2\">\n"
                           "  <param name=\"a\" type=\"float\">  <!-- note --> </param>\n"
                           "  <node id=\"u\" type=\"uniform\">\n"
                           "  </node>\n"
                           "  <output name=\"o\" from=\"u\"> </output>\n"
                           "</wetgraph>\n"));
}

static void test_graph_seed(void **state)
{
    (void)state;
    static const char *const bad[] = {
        "abc", "-1", "1.5", "", " 3", "12abc", "18446744073709551616"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        char xml[512], needle[128];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" seed=\"%s\">\n"
                 "  <node id=\"u\" type=\"uniform\"/>\n"
                 "  <output name=\"o\" from=\"u\"/>\n"
                 "</wetgraph>\n",
                 bad[i]);
        snprintf(needle, sizeof needle, "seed must be a whole number >= 0, not '%s'", bad[i]);
        load_fails(xml, WG_ERR_PARSE, 1, needle);
    }
    WgGraph *g = wgt_load("<wetgraph version=\"1\" seed=\"18446744073709551615\">\n"
                          "  <node id=\"u\" type=\"uniform\"/>\n"
                          "  <output name=\"o\" from=\"u\"/>\n"
                          "</wetgraph>\n");
    assert_true(wg_graph_seed(g) == UINT64_MAX);
    wg_graph_free(g);
}

/* ---- wg_suggest -------------------------------------------------------------------------- */

static void test_suggest(void **state)
{
    (void)state;
    const char *const names[] = {"blend", "blur", "levels", NULL, "invert", "grayscale"};
    int n = 6;
    assert_string_equal(wg_suggest("blurr", names, n), "blur");
    assert_string_equal(wg_suggest("bler", names, n), "blur"); /* 1 edit from blur, 2 from blend */
    assert_string_equal(wg_suggest("BLUR", names, n), "blur"); /* case-insensitive */
    assert_string_equal(wg_suggest("lveels", names, n), "levels");  /* 2 edits */
    assert_string_equal(wg_suggest("gray", names, n), "grayscale"); /* prefix */
    assert_string_equal(wg_suggest("inv", names, n), "invert");     /* prefix, 3 letters */
    assert_null(wg_suggest("in", names, n));                        /* too short for a prefix */
    assert_null(wg_suggest("noise", names, n));
    assert_string_equal(wg_suggest("lvls", names, n), "levels"); /* 2 edits, 4 letters */
    assert_null(wg_suggest("lvl", names, n));                    /* 3 letters allow 1 edit */
    assert_null(wg_suggest("blurr", names, 0));
    /* short words allow a single edit */
    const char *const short_names[] = {"ab", "xyz"};
    assert_string_equal(wg_suggest("ac", short_names, 2), "ab");
    assert_null(wg_suggest("cd", short_names, 2));
    assert_string_equal(wg_suggest("xy", short_names, 2), "xyz");
    /* the closest wins, the first on ties */
    const char *const close[] = {"abcdef", "abcdxy", "abcdez"};
    assert_string_equal(wg_suggest("abcdez", close, 3), "abcdez");
    assert_string_equal(wg_suggest("abcdeg", close, 3), "abcdef");
}

/* Elements are reported at the line where their start tag begins and attribute errors at the
 * attribute's own line, also in tags written over several lines; comments and quoted '>' do not
 * confuse the count. Loading from a file and from memory agree. */
static void test_lines_of_multi_line_tags(void **state)
{
    (void)state;
    const char *head = "<wetgraph version=\"1\" size=\"8\">\n"        /* 1 */
                       "  <param name=\"level\" type=\"float\"/>\n"   /* 2 */
                       "  <!-- <node id=\"fake\"> in a comment -->\n" /* 3 */
                       "  <node id=\"u\"\n"                           /* 4 */
                       "        type=\"uniform\"\n"                   /* 5 */
                       "        label=\"a > b\"\n";                   /* 6 */
    char xml[2048];
    snprintf(xml, sizeof xml,
             "%s        value=\"=levl * 2\"/>\n" /* 7 */
             "  <output name=\"o\" from=\"u\"/>\n</wetgraph>\n",
             head);
    load_fails(xml, WG_ERR_PARSE, 7, "attribute 'value'|unknown name 'levl'|did you mean 'level'?");
    snprintf(xml, sizeof xml,
             "%s        valeu=\"1\"/>\n" /* 7 */
             "  <output name=\"o\" from=\"u\"/>\n</wetgraph>\n",
             head);
    load_fails(xml, WG_ERR_PARSE, 7, "has no parameter 'valeu'; did you mean 'value'?");
    snprintf(xml, sizeof xml,
             "%s        value=\"1\">\n"          /* 7 */
             "    <in name=\"x\" from=\"u\"/>\n" /* 8 */
             "  </node>\n  <output name=\"o\" from=\"u\"/>\n</wetgraph>\n",
             head);
    load_fails(xml, WG_ERR_PARSE, 8, "has no input 'x'");
    /* the node itself: the line of '<node' */
    snprintf(xml, sizeof xml,
             "%s        value=\"1\"/>\n"
             "  <node id=\"b\"\n"        /* 8 */
             "        type=\"blur\"/>\n" /* 9 */
             "  <output name=\"o\" from=\"b\"/>\n</wetgraph>\n",
             head);
    load_fails(xml, WG_ERR_PARSE, 8, "required input 'source' is not connected");
    const char *path = wgt_path("multi_line.wetgraph");
    wgt_write_file(path, xml);
    WgGraph *g = NULL;
    WgError err = {0};
    assert_int_equal(wg_graph_load(path, &g, &err), WG_ERR_PARSE);
    wgt_assert_error(&err, WG_ERR_PARSE, 8, "required input 'source'");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lines_of_multi_line_tags),
        cmocka_unit_test(test_valid_file_and_info),
        cmocka_unit_test(test_param_hints),
        cmocka_unit_test(test_defaults_of_the_root),
        cmocka_unit_test(test_load_from_a_file),
        cmocka_unit_test(test_malformed_xml),
        cmocka_unit_test(test_root_and_version),
        cmocka_unit_test(test_unknown_elements),
        cmocka_unit_test(test_unknown_attributes),
        cmocka_unit_test(test_missing_required_attributes),
        cmocka_unit_test(test_unknown_node_type),
        cmocka_unit_test(test_graph_param_declarations),
        cmocka_unit_test(test_malformed_literals),
        cmocka_unit_test(test_good_literals),
        cmocka_unit_test(test_out_of_range_literals),
        cmocka_unit_test(test_range_errors_print_enough_digits),
        cmocka_unit_test(test_duplicate_enum_values),
        cmocka_unit_test(test_namespaces),
        cmocka_unit_test(test_invalid_utf8),
        cmocka_unit_test(test_duplicates),
        cmocka_unit_test(test_bad_ids),
        cmocka_unit_test(test_other_declaration_errors),
        cmocka_unit_test(test_dangling_references),
        cmocka_unit_test(test_ports),
        cmocka_unit_test(test_cycles),
        cmocka_unit_test(test_no_outputs),
        cmocka_unit_test(test_sizes),
        cmocka_unit_test(test_expression_syntax_errors),
        cmocka_unit_test(test_expression_names),
        cmocka_unit_test(test_non_numeric_forwarding),
        cmocka_unit_test(test_text_inside_elements),
        cmocka_unit_test(test_graph_seed),
        cmocka_unit_test(test_suggest),
        cmocka_unit_test(test_warning_element),
        cmocka_unit_test(test_gltf_element),
        cmocka_unit_test(test_check_all),
        cmocka_unit_test(test_output_group),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
