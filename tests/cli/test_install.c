/* SPDX-License-Identifier: MIT */
/* wetgraph as an installed tool: graphs named on the command line (a file, or a graph's name
 * found in WETGRAPH_PATH, then the built-in folder, with a suggestion and exit 2 when there is
 * none), `wetgraph graphs`, the manual page (generated from --help-all), the bash completion
 * (commands, options, graph names, node types, a graph's parameters and outputs), and a
 * `meson install` into a scratch folder whose files render a graph by name from another
 * folder. */
#include "wgtest.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

static void expect_file_has(const char *dir, const char *file, const char *needle)
{
    if (wgt_count_in(wgt_join(dir, file), needle) == 0) {
        char cmd[1200];
        snprintf(cmd, sizeof cmd, "cat '%s/out' '%s/err' >&2", dir, dir);
        if (system(cmd)) {
        }
        fail_msg("expected '%s' in %s/%s", needle, dir, file);
    }
}

static const char *const tiny_graph = "<wetgraph version=\"1\" size=\"8\" label=\"Tiny\">\n"
                                      "  <param name=\"v\" type=\"float\" default=\"0.25\"/>\n"
                                      "  <node id=\"c\" type=\"uniform\" value=\"=v\"/>\n"
                                      "  <output name=\"flat\" from=\"c\"/>\n"
                                      "</wetgraph>\n";

static void test_names(void **state)
{
    (void)state;
    const char *d = wgt_fresh_dir("names");
    /* from a folder holding no graph, by name, with and without the extension */
    WGT_SH(d, 0, "$WG info wet_material");
    expect_file_has(d, "out", "graph wet_material");
    WGT_SH(d, 0, "$WG check foam.wetgraph texturing");
    expect_file_has(d, "out", "texturing: ok");
    /* a misspelt name: exit 2, where it looked, and the closest name */
    WGT_SH(d, 2, "$WG render wet_materal -o x");
    expect_file_has(d, "err", "did you mean 'wet_material'?");
    expect_file_has(d, "err", "WETGRAPH_PATH");
    WGT_SH(d, 2, "$WG check nothing_like_it");
    expect_file_has(d, "err", "'wetgraph graphs' lists them");
    /* a path is never looked up by name; a missing file and a folder are bad input (exit 2)
     * for every command */
    static const char *const cmds[] = {"render", "check", "info", "dot", "watch"};
    for (int i = 0; i < 5; i++) {
        WGT_SH(d, 2, "$WG %s ./wet_material", cmds[i]);
        expect_file_has(d, "err", "./wet_material: cannot open the graph file: no such file");
        WGT_SH(d, 2, "mkdir -p sub && $WG %s sub", cmds[i]);
        expect_file_has(d, "err", "sub: cannot open the graph file: it is a folder");
    }
    /* a file in the current folder comes before a graph of the same name */
    wgt_write_file(wgt_join(d, "wet_material"), tiny_graph);
    WGT_SH(d, 0, "$WG info wet_material");
    expect_file_has(d, "out", "Tiny");
}

static void test_path(void **state)
{
    (void)state;
    const char *lib = wgt_fresh_dir("library"), *d = wgt_fresh_dir("elsewhere");
    wgt_write_file(wgt_join(lib, "tiny.wetgraph"), tiny_graph);
    wgt_write_file(wgt_join(lib, "foam.wetgraph"), tiny_graph); /* shadows the built-in one */
    WGT_SH(d, 2, "$WG render tiny -o maps");
    WGT_SH(d, 0, "WETGRAPH_PATH='/nonexistent:%s' $WG render tiny -o maps --set v=0.5", lib);
    assert_true(wgt_exists(wgt_join(d, "maps/tiny_flat.png")));
    WGT_SH(d, 0, "WETGRAPH_PATH='%s' $WG graphs --paths", lib);
    char line[1200];
    snprintf(line, sizeof line, "%s/foam.wetgraph", lib);
    expect_file_has(d, "out", line);
    snprintf(line, sizeof line, "%s/tiny.wetgraph", lib);
    expect_file_has(d, "out", line);
    expect_file_has(d, "out", "wet_material");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "foam "), 1); /* listed once */
    WGT_SH(d, 0, "WETGRAPH_PATH='%s' $WG graphs", lib);
    expect_file_has(d, "out", "Tiny");
    expect_file_has(d, "out", "Wet material");
    WGT_SH(d, 2, "$WG graphs --bogus");
}

static void test_manual(void **state)
{
    (void)state;
    const char *man = getenv("WETGRAPH_MAN");
    if (!man || !man[0])
        fail_msg("the manual page was not built: install help2man (scripts/install-deps.sh)");
    const char *d = wgt_fresh_dir("manual");
    /* every command's usage, from the same text as its --help */
    WGT_SH(d, 0, "$WG --help-all");
    static const char *const cmds[] = {"render", "check", "info",  "nodes",
                                       "dot",    "watch", "graphs"};
    for (int i = 0; i < 7; i++) {
        char usage[64];
        snprintf(usage, sizeof usage, "usage: wetgraph %s", cmds[i]);
        expect_file_has(d, "out", usage);
        if (wgt_count_in(man, usage) == 0) fail_msg("%s: no '%s'", man, usage);
    }
    assert_true(wgt_count_in(man, ".TH WETGRAPH \"1\"") == 1);
    assert_true(wgt_count_in(man, "WETGRAPH_PATH") > 0);
}

/* The completions bash offers for the words after `wetgraph` (the last one being completed),
 * one per line in d/out. */
static void complete(const char *d, const char *words)
{
    const char *src = getenv("WETGRAPH_SOURCE");
    assert_non_null(src);
    char script[2048];
    snprintf(
        script, sizeof script,
        "source '%s/cli/wetgraph.bash'; COMP_WORDS=('%s' %s); "
        "COMP_CWORD=$((${#COMP_WORDS[@]} - 1)); _wetgraph; printf '%%s\\n' \"${COMPREPLY[@]}\"",
        src, getenv("WETGRAPH_BIN"), words);
    char cmd[4096];
    FILE *f = fopen(wgt_join(d, "complete.sh"), "w");
    assert_non_null(f);
    fputs(script, f);
    fclose(f);
    snprintf(cmd, sizeof cmd, "bash complete.sh");
    WGT_SH(d, 0, "%s", cmd);
}

static void test_completion(void **state)
{
    (void)state;
    const char *d = wgt_fresh_dir("completion");
    static const struct {
        const char *words, *want, *not_want;
    } cases[] = {
        {"re", "render", "check"},
        {"gr", "graphs", NULL},
        {"render --thr", "--threads", "--set"},
        {"watch --se", "--serve", NULL},
        {"render wet_m", "wet_material", NULL},
        {"render wet_material --set water_l", "water_level=", "water_level\n"},
        {"render -o out --threads 2 wet_material --set water_level = 0.5 --output wat",
         "watermask", "basecolor"},
        {"render wet_material --input he", "height=", "water_level"},
        {"render wet_material --plug", "--plugin", NULL},
        {"nodes --plugin ", NULL, "blur"},
        {"nodes bl", "blur", "noise"},
        {"info texturing --json", NULL, NULL},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        complete(d, cases[i].words);
        if (cases[i].want && wgt_count_in(wgt_join(d, "out"), cases[i].want) == 0)
            fail_msg("'wetgraph %s': '%s' not offered", cases[i].words, cases[i].want);
        if (cases[i].not_want && wgt_count_in(wgt_join(d, "out"), cases[i].not_want) > 0)
            fail_msg("'wetgraph %s': '%s' offered", cases[i].words, cases[i].not_want);
    }
}

static void test_installed(void **state)
{
    (void)state;
    const char *build = getenv("WETGRAPH_BUILD_ROOT"), *shared = getenv("WETGRAPH_SHARED");
    assert_non_null(build);
    assert_non_null(shared);
    const char *dest = wgt_fresh_dir("dest"), *d = wgt_fresh_dir("user");
    WGT_SH(d, 0, "meson install -C '%s' --no-rebuild --quiet --destdir '%s'", build, dest);
    /* where things went: the prefix is the build's, under dest */
    WGT_SH(d, 0,
           "cd '%s' && find . -path '*/bin/wetgraph' -o -name "
           "'libwetgraph.so*' -o -name 'wetgraph-oiio.so' -o -name "
           "wet_material.wetgraph -o -name wetgraph.1 -o -path "
           "'*/completions/wetgraph' -o -name graph.h -o -name wetgraph.pc",
           dest);
    static const char *const want[] = {"bin/wetgraph",           "libwetgraph.so",
                                       "wetgraph-oiio.so",       "wetgraph/graphs/wet_material",
                                       "man1/wetgraph.1",        "completions/wetgraph",
                                       "include/wetgraph/graph", "pkgconfig/wetgraph.pc"};
    for (int i = 0; i < 8; i++)
        if (wgt_count_in(wgt_join(d, "out"), want[i]) == 0)
            fail_msg("meson install did not install %s", want[i]);
    /* the installed program, library, module and graphs render a graph by name from another
     * folder (the prefix lives under dest, so the loader and the library are told where) */
    const char *mat = "bricks102_stonewall_1k/Bricks102_1K-JPG";
    WGT_SH(d, 0,
           "bin=$(find '%s' -path '*/bin/wetgraph'); lib=$(dirname \"$(find '%s' -name "
           "'libwetgraph.so*' | head -1)\"); graphs=$(dirname \"$(find '%s' -name "
           "wet_material.wetgraph)\"); LD_LIBRARY_PATH=$lib WETGRAPH_MODULE_DIR=$lib/wetgraph "
           "WETGRAPH_GRAPHS_DIR=$graphs \"$bin\" render wet_material -o maps --size 32 -q "
           "--input basecolor='%s/materials/%s_Color.jpg' "
           "--input height='%s/materials/%s_Displacement.jpg' --output basecolor && "
           "LD_LIBRARY_PATH=$lib WETGRAPH_GRAPHS_DIR=$graphs \"$bin\" graphs --paths",
           dest, dest, dest, shared, mat, shared, mat);
    assert_true(wgt_exists(wgt_join(d, "maps/wet_material_basecolor.png")));
    expect_file_has(d, "out", dest); /* the graphs listed are the installed ones */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names),     cmocka_unit_test(test_path),
        cmocka_unit_test(test_manual),    cmocka_unit_test(test_completion),
        cmocka_unit_test(test_installed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
