/* SPDX-License-Identifier: MIT */
/* Node plugins through the CLI (tests/plugins: a good plugin in two versions and one per fault):
 * `--plugin LIB` and WETGRAPH_PLUGIN_PATH add its type to `nodes`, `info` and renders; every
 * fault the loader refuses (no such file, not a library, no entry point, another ABI, an
 * invalid descriptor, no eval, a built-in's name, another plugin's name) is a usage error
 * naming the file and what is wrong; a replaced plugin never gets its predecessor's cached
 * results; and the plugin template (examples/node-plugin) builds against the installed library
 * with pkg-config, passes its own test-kit tests and renders from the CLI through --plugin. */
#include "wgtest.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const graph =
    "<wetgraph version=\"1\" size=\"8\">\n"
    "  <node id=\"g\" type=\"uniform\" value=\"0.125\"/>\n"
    "  <node id=\"o\" type=\"plugin_offset\" amount=\"0.25\"><in name=\"source\" from=\"g\"/></node>\n"
    "  <output name=\"out\" from=\"o\" format=\"exr32\"/>\n"
    "</wetgraph>\n";

static const char *plugins(void)
{
    const char *dir = getenv("WETGRAPH_TEST_PLUGINS");
    assert_non_null(dir);
    return dir;
}

static const char *fresh(const char *name)
{
    const char *d = wgt_fresh_dir(name);
    wgt_write_file(wgt_join(d, "g.wetgraph"), graph);
    return d;
}

/* The one value of the rendered output d/<file> (every pixel is the same). */
static float value_of(const char *d, const char *file)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(wgt_join(d, file), 1, WG_LINEAR, &img, &err)) fail_msg("%s", err.message);
    float v = wg_image_row(img, 3)[5];
    wg_image_unref(img);
    return v;
}

static void expect_error(const char *d, const char *text)
{
    if (wgt_count_in(wgt_join(d, "err"), text) == 0) {
        WGT_SH(d, 0, "cat err >&2");
        fail_msg("expected '%s' in the error", text);
    }
}

static void test_plugin_types_are_everywhere(void **state)
{
    (void)state;
    const char *d = fresh("use");
    const char *lib = wgt_join(plugins(), "offset_v1.so");
    /* without the plugin the type is unknown */
    WGT_SH(d, 2, "$WG check g.wetgraph");
    expect_error(d, "plugin_offset");
    WGT_SH(d, 0, "$WG nodes --plugin '%s'", lib);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "plugin_offset"), 1);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "[plugin "), 1);
    WGT_SH(d, 0, "$WG nodes plugin_offset --plugin='%s'", lib);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "plugin: "), 1);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "amount"), 1);
    WGT_SH(d, 0, "$WG nodes --markdown --plugin '%s'", lib);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "## `plugin_offset`"), 1);
    WGT_SH(d, 0, "$WG check --plugin '%s' g.wetgraph", lib);
    WGT_SH(d, 0, "$WG info g.wetgraph --json --plugin '%s'", lib);
    WGT_SH(d, 0, "$WG render g.wetgraph -o a -q --plugin '%s'", lib);
    assert_float_equal(value_of(d, "a/g_out.exr"), 0.375f, 1e-7);
    /* the same from a folder of WETGRAPH_PLUGIN_PATH (empty and missing entries skipped) */
    WGT_SH(d, 0, "mkdir -p lib && cp '%s' lib/ && WETGRAPH_PLUGIN_PATH=::/nonexistent:lib $WG render "
           "g.wetgraph -o b -q", lib);
    assert_float_equal(value_of(d, "b/g_out.exr"), 0.375f, 1e-7);
    /* a file given twice (by the path and by --plugin) is loaded once */
    WGT_SH(d, 0, "WETGRAPH_PLUGIN_PATH=lib $WG render g.wetgraph -o c -q --plugin lib/offset_v1.so");
}

static void test_loader_errors(void **state)
{
    (void)state;
    const char *d = fresh("errors");
    const char *dir = plugins();
    static const struct {
        const char *file, *text;
    } cases[] = {
        {"missing.so", "missing.so: cannot open the plugin: No such file or directory"},
        {"../g.wetgraph", "cannot load the plugin"},
        {"no_entry.so", "no_entry.so: not a wetgraph plugin: it exports no 'wetgraph_plugin' "
                        "function"},
        {"old_abi.so", "old_abi.so: built for plugin ABI 100, this wetgraph has ABI 1: rebuild"},
        {"bad_param.so", "bad_param.so: node type 'plugin_offset': parameter 'amount': default 5 "
                         "outside 0 .. 1"},
        {"no_eval.so", "no_eval.so: node type 'plugin_offset': no eval function"},
        {"clash_builtin.so", "clash_builtin.so: node type 'blur' is a built-in type's name: a "
                             "plugin cannot replace a built-in node"},
    };
    wgt_write_file(wgt_join(d, "lib.wetgraph"), graph);
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        const char *path = strncmp(cases[i].file, "../", 3) ? wgt_join(dir, cases[i].file)
                                                              : wgt_join(d, "lib.wetgraph");
        WGT_SH(d, 2, "$WG nodes --plugin '%s'", path);
        expect_error(d, cases[i].text);
        /* from the plugin path too, for every command */
        if (i > 0)
            WGT_SH(d, 2, "mkdir -p p%zu && cp '%s' p%zu/x.so && WETGRAPH_PLUGIN_PATH=p%zu $WG check g.wetgraph",
                   i, path, i, i);
    }
    /* two plugins with one type name: the second is refused, naming the first's file */
    WGT_SH(d, 2, "$WG nodes --plugin '%s/offset_v1.so' --plugin '%s/offset_v2.so'", dir, dir);
    expect_error(d, "offset_v2.so: node type 'plugin_offset' is already defined by the plugin ");
    expect_error(d, "offset_v1.so");
    WGT_SH(d, 2, "$WG nodes --plugin");
    expect_error(d, "--plugin needs a file");
}

/* The plugin's file and version are in its nodes' cache keys: a plugin replaced by another
 * build (same file name, same type) computes again instead of reading what the old one cached.
 * Its node, a point operation, would not be stored as the render's last node (a leaf): a
 * blur reads it. */
static void test_replaced_plugin_is_not_served_from_the_cache(void **state)
{
    (void)state;
    const char *d = fresh("cache");
    wgt_write_file(
        wgt_join(d, "g.wetgraph"),
        "<wetgraph version=\"1\" size=\"8\">\n"
        "  <node id=\"g\" type=\"uniform\" value=\"0.125\"/>\n"
        "  <node id=\"o\" type=\"plugin_offset\" amount=\"0.25\">"
        "<in name=\"source\" from=\"g\"/></node>\n"
        "  <node id=\"b\" type=\"blur\" sigma=\"1\"><in name=\"source\" from=\"o\"/></node>\n"
        "  <output name=\"out\" from=\"b\" format=\"exr32\"/>\n"
        "</wetgraph>\n");
    const char *dir = plugins();
    WGT_SH(d, 0, "cp '%s/offset_v1.so' plug.so && $WG render g.wetgraph -o a -q --cache c "
           "--plugin plug.so", dir);
    assert_float_equal(value_of(d, "a/g_out.exr"), 0.375f, 1e-7);
    /* the same plugin again: its node comes from the cache */
    WGT_SH(d, 0, "$WG render g.wetgraph -o b -q --cache c --plugin plug.so --stats=json > s.json");
    assert_int_equal(wgt_count_in(wgt_join(d, "s.json"), "\"cache\": \"disk\""), 1);
    WGT_SH(d, 0, "cp '%s/offset_v2.so' plug.so && $WG render g.wetgraph -o c2 -q --cache c "
           "--plugin plug.so", dir);
    assert_float_equal(value_of(d, "c2/g_out.exr"), 0.875f, 1e-7);
}

static void test_template_builds_against_the_installed_tree(void **state)
{
    (void)state;
    const char *build = getenv("WETGRAPH_BUILD_ROOT"), *src = getenv("WETGRAPH_SOURCE"),
               *san = getenv("WETGRAPH_SANITIZE");
    assert_non_null(build);
    assert_non_null(src);
    const char *d = wgt_fresh_dir("template");
    WGT_SH(d, 0, "meson install -C '%s' --no-rebuild --quiet --destdir \"$PWD/dest\"", build);
    /* the installed .pc names the prefix: the sysroot puts it under dest */
    WGT_SH(d, 0,
           "pc=$(dirname \"$(find \"$PWD/dest\" -name wetgraph.pc)\") && "
           "PKG_CONFIG_SYSROOT_DIR=\"$PWD/dest\" PKG_CONFIG_PATH=\"$pc\" meson setup ex "
           "'%s/examples/node-plugin' -Db_sanitize=%s > setup.log && ninja -C ex > build.log",
           src, san && san[0] ? san : "none");
    WGT_SH(d, 0,
           "LD_LIBRARY_PATH=\"$(dirname \"$(find \"$PWD/dest\" -name 'libwetgraph.so' | head -1)\")\" "
           "meson test -C ex --print-errorlogs > test.log || { cat test.log; exit 1; }");
    assert_int_equal(wgt_count_in(wgt_join(d, "ex/meson-logs/testlog.txt"), "0 checks failed"), 1);
    WGT_SH(d, 0, "$WG render '%s/examples/node-plugin/slope_demo.wetgraph' --plugin ex/dir_slope.so "
           "-o rendered -q", src);
    assert_true(wgt_exists(wgt_join(d, "rendered/slope_demo_slope.png")));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plugin_types_are_everywhere),
        cmocka_unit_test(test_loader_errors),
        cmocka_unit_test(test_replaced_plugin_is_not_served_from_the_cache),
        cmocka_unit_test(test_template_builds_against_the_installed_tree),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
