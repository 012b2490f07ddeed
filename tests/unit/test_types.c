/* SPDX-License-Identifier: MIT */
/* The node types the engine reads graphs with come from the table handed to
 * wg_set_node_types: the built-in registry from the start, or a program's own table, through
 * the hash index and through the linear search used for tables too large for it. Each test
 * restores the built-in table afterwards. */
#include "wgtest.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int restore_builtin(void **state)
{
    (void)state;
    wg_set_node_types(wg_node_types);
    return 0;
}

static const char *const flat_xml = "<wetgraph version=\"1\" size=\"4\">\n"
                                    "  <node id=\"a\" type=\"flat\" value=\"0.25\"/>\n"
                                    "  <output name=\"out\" from=\"a\"/>\n"
                                    "</wetgraph>\n";
static const char *const blur_xml = "<wetgraph version=\"1\" size=\"4\">\n"
                                    "  <node id=\"a\" type=\"uniform\" value=\"0.5\"/>\n"
                                    "  <node id=\"b\" type=\"blur\"><in name=\"source\" "
                                    "from=\"a\"/></node>\n"
                                    "  <output name=\"out\" from=\"b\"/>\n"
                                    "</wetgraph>\n";

/* `uniform` under another name */
static WgNodeType flat_type(void)
{
    WgNodeType t = *wg_node_type_find("uniform");
    t.name = "flat";
    return t;
}

static void assert_renders_flat(const char *xml, float value)
{
    WgGraph *g = wgt_load(xml);
    WgResult *r = wgt_render(g, 1);
    const WgImage *img = wgt_output(r, "out");
    assert_float_equal(wgt_px(img, 3, 3, 0), value, 0);
    wg_result_free(r);
    wg_graph_free(g);
}

static void test_builtin_table_at_start(void **state)
{
    (void)state;
    /* nothing set: the library handed the engine the registry when it loaded */
    WgGraph *g = wgt_load(blur_xml);
    wg_graph_free(g);
}

static void test_custom_table(void **state)
{
    (void)state;
    WgNodeType flat = flat_type();
    const WgNodeType *table[] = {&flat, wg_node_type_find("uniform"), NULL};
    wg_set_node_types(table);
    assert_renders_flat(flat_xml, 0.25f);
    WgError err;
    /* a built-in type left out of the table is unknown, and suggestions come from the table */
    assert_int_equal(wgt_load_error(blur_xml, &err), WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 3, "unknown node type 'blur'");
    char *typo = strdup(flat_xml);
    memcpy(strstr(typo, "flat"), "flta", 4);
    assert_int_equal(wgt_load_error(typo, &err), WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 2, "unknown node type 'flta'; did you mean 'flat'?");
    free(typo);
    /* graph inputs become `uniform` nodes found in the same table */
    assert_renders_flat("<wetgraph version=\"1\" size=\"4\">\n"
                        "  <input name=\"base\" type=\"gray\" default=\"0.75\"/>\n"
                        "  <output name=\"out\" from=\"$base\"/>\n"
                        "</wetgraph>\n",
                        0.75f);

    wg_set_node_types(wg_node_types);
    assert_int_equal(wgt_load_error(flat_xml, &err), WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 2, "unknown node type 'flat'");
    wg_graph_free(wgt_load(blur_xml));
}

static void test_no_table(void **state)
{
    (void)state;
    wg_set_node_types(NULL);
    WgError err;
    assert_int_equal(wgt_load_error(blur_xml, &err), WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 2, "unknown node type 'uniform'");
}

/* Over 255 types the table is searched without the index; the first of equal names wins. */
static void test_large_table(void **state)
{
    (void)state;
    enum { N = 300 };
    static WgNodeType types[N + 1];
    static char names[N][16];
    static const WgNodeType *table[N + 2];
    for (int i = 0; i < N; i++) {
        types[i] = flat_type();
        snprintf(names[i], sizeof names[i], "t%d", i);
        types[i].name = names[i];
        table[i] = &types[i];
    }
    types[N] = *wg_node_type_find("blur"); /* `value` is no blur parameter */
    types[N].name = "t7";
    table[N] = &types[N];
    table[N + 1] = NULL;
    wg_set_node_types(table);
    char xml[256];
    snprintf(xml, sizeof xml, "%s", flat_xml);
    memcpy(strstr(xml, "flat"), "t299", 4);
    assert_renders_flat(xml, 0.25f);
    memcpy(strstr(xml, "t299"), "t7\"  ", 5);
    WgGraph *g = wgt_load(xml);
    assert_string_equal(wg_graph_node_info(g, 0)->type, "t7");
    wg_graph_free(g);

    /* the same through the index: a small table with a duplicate name */
    const WgNodeType *small[] = {&types[7], &types[N], NULL};
    wg_set_node_types(small);
    g = wgt_load(xml);
    wg_graph_free(g);
    WgError err;
    const WgNodeType *reversed[] = {&types[N], &types[7], NULL};
    wg_set_node_types(reversed);
    assert_int_equal(wgt_load_error(xml, &err), WG_ERR_PARSE);
    wgt_assert_error(&err, WG_ERR_PARSE, 2, "has no parameter 'value'");
    assert_int_equal(wgt_load_error(flat_xml, &err), WG_ERR_TYPE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_builtin_table_at_start),
        cmocka_unit_test_teardown(test_custom_table, restore_builtin),
        cmocka_unit_test_teardown(test_no_table, restore_builtin),
        cmocka_unit_test_teardown(test_large_table, restore_builtin),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
