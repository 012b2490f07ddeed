/* SPDX-License-Identifier: MIT */
/* The node registry: every descriptor is well formed by wg_node_type_validate (unique lowercase
 * names, a summary and a category, at least one output, unique port and parameter names, defaults within their ranges,
 * valid enum defaults, colour defaults that parse, parameter fields inside the params struct,
 * flags consistent with the ports), and docs/nodes.md is what `wetgraph nodes --markdown`
 * prints. */
#include "wgtest.h"

#include "internal.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void test_descriptors_are_well_formed(void **state)
{
    (void)state;
    int count = 0;
    for (; wg_node_types[count]; count++) {
        const WgNodeType *t = wg_node_types[count];
        WgError err = {0};
        if (wg_node_type_validate(t, &err)) fail_msg("%s", err.message);
        for (int k = 0; k < count; k++)
            if (!strcmp(wg_node_types[k]->name, t->name))
                fail_msg("node '%s' registered twice", t->name);
        if (wg_node_type_find(t->name) != t)
            fail_msg("wg_node_type_find('%s') finds another", t->name);
        if (wg_node_type_origin(t)) fail_msg("%s: a built-in type with a plugin origin", t->name);
    }
    assert_true(count >= 7);
    assert_null(wg_node_type_find("no_such_node"));
    assert_null(wg_node_type_find(""));
}

static void test_foundation_nodes_are_registered(void **state)
{
    (void)state;
    static const char *const names[] = {"uniform", "image",     "blend", "levels",
                                        "invert",  "grayscale", "blur"};
    for (int i = 0; i < 7; i++)
        if (!wg_node_type_find(names[i])) fail_msg("'%s' is not registered", names[i]);
}

/* ---- docs/nodes.md ----------------------------------------------------------------------- */

static char *slurp_stream(FILE *f)
{
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    assert_non_null(buf);
    size_t k;
    while ((k = fread(buf + n, 1, cap - n - 1, f)) > 0) {
        n += k;
        if (cap - n - 1 == 0) {
            cap *= 2;
            buf = realloc(buf, cap);
            assert_non_null(buf);
        }
    }
    buf[n] = '\0';
    return buf;
}

static void test_docs_nodes_md_is_up_to_date(void **state)
{
    (void)state;
    const char *bin = getenv("WETGRAPH_BIN"), *src = getenv("WETGRAPH_SOURCE");
    if (!bin || !src)
        fail_msg("WETGRAPH_BIN and WETGRAPH_SOURCE must be set (run through meson test)");
    char cmd[4096];
    snprintf(cmd, sizeof cmd, "'%s' nodes --markdown", bin);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    char *generated = slurp_stream(p);
    assert_int_equal(pclose(p), 0);
    char path[4096];
    snprintf(path, sizeof path, "%s/docs/nodes.md", src);
    FILE *f = fopen(path, "rb");
    if (!f) {
        free(generated);
        fail_msg("%s is missing: run `build/cli/wetgraph nodes --markdown > docs/nodes.md`", path);
    }
    char *committed = slurp_stream(f);
    fclose(f);
    /* the line of the first difference, 0 when equal */
    size_t line = 0;
    if (strcmp(generated, committed)) {
        size_t i = 0;
        line = 1;
        while (generated[i] && generated[i] == committed[i]) {
            if (generated[i] == '\n') line++;
            i++;
        }
    }
    free(committed);
    free(generated);
    if (line)
        fail_msg("docs/nodes.md is out of date (first difference on line %zu): run "
                 "`build/cli/wetgraph nodes --markdown > docs/nodes.md`",
                 line);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_descriptors_are_well_formed),
        cmocka_unit_test(test_foundation_nodes_are_registered),
        cmocka_unit_test(test_docs_nodes_md_is_up_to_date),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
