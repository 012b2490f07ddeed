/* SPDX-License-Identifier: MIT */
/* Large graphs: long chains (10,000 and 100,000 nodes), wide graphs, many uses of one subgraph
 * and many outputs load, check, plan, render, and print as dot and info without running out
 * of stack, and with results that prove every node ran. Growth in time is measured by
 * bench/bench_scaling.sh, not asserted here. */
#include "wgtest.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

/* A growing text buffer for generated graphs. */
typedef struct Text {
    char *s;
    size_t len, cap;
} Text;

static void put(Text *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char buf[512];
    int n = vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    assert_true(n > 0 && (size_t)n < sizeof buf);
    if (t->len + (size_t)n + 1 > t->cap) {
        t->cap = 2 * (t->len + (size_t)n + 1);
        t->s = realloc(t->s, t->cap);
        assert_non_null(t->s);
    }
    memcpy(t->s + t->len, buf, (size_t)n + 1);
    t->len += (size_t)n;
}

/* uniform 0.25, then n-1 inverts, each reading the previous node */
static char *chain_xml(int n)
{
    Text t = {0};
    put(&t, "<wetgraph version=\"1\" size=\"2\">\n<node id=\"n0\" type=\"uniform\" "
            "value=\"0.25\"/>\n");
    for (int i = 1; i < n; i++)
        put(&t, "<node id=\"n%d\" type=\"invert\"><in name=\"source\" from=\"n%d\"/></node>\n", i,
            i - 1);
    put(&t, "<output name=\"out\" from=\"n%d\" format=\"exr32\"/>\n</wetgraph>\n", n - 1);
    return t.s;
}

static void check_chain(int n)
{
    char *xml = chain_xml(n);
    WgGraph *g = wgt_load(xml);
    free(xml);
    assert_int_equal(wg_graph_node_count(g), n);
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    assert_int_equal(wg_request_check(r, &err), WG_OK);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(res), n);
    /* n-1 inverts of 0.25: 0.75 when n-1 is odd */
    float want = (n - 1) % 2 ? 0.75f : 0.25f;
    assert_float_equal(wgt_px(wgt_output(res, "out"), 1, 1, 0), want, 0);
    wg_result_free(res);

    /* dot and info walk the whole graph too */
    FILE *f = fopen(wgt_path("chain.dot"), "w");
    assert_non_null(f);
    assert_int_equal(wg_graph_write_dot(g, f), WG_OK);
    fclose(f);
    size_t size;
    char *dot = wgt_read_file(wgt_path("chain.dot"), &size);
    char last_edge[128];
    snprintf(last_edge, sizeof last_edge, "\"n:n%d\" -> \"n:n%d\"", n - 2, n - 1);
    assert_non_null(strstr(dot, last_edge));
    free(dot);
    const WgGraphNodeInfo *ni = wg_graph_node_info(g, n - 1);
    assert_int_equal(ni->n_inputs, 1);
    char from[32];
    snprintf(from, sizeof from, "n%d", n - 2);
    assert_string_equal(ni->input_from[0], from);

    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

static void chain_10k(void **state)
{
    (void)state;
    check_chain(10000);
}

static void chain_100k(void **state)
{
    (void)state;
    check_chain(100000);
}

/* 2^15 distinct uniforms summed by a balanced tree of blends: 32,768 nodes ready at once */
static void wide_tree(void **state)
{
    (void)state;
    const int leaves = 1 << 15;
    Text t = {0};
    put(&t, "<wetgraph version=\"1\" size=\"1\">\n");
    for (int i = 0; i < leaves; i++)
        put(&t, "<node id=\"t0_%d\" type=\"uniform\" value=\"%d\"/>\n", i, i % 7);
    int level = 0;
    for (int count = leaves; count > 1; count /= 2, level++)
        for (int i = 0; i < count / 2; i++)
            put(&t,
                "<node id=\"t%d_%d\" type=\"blend\" mode=\"add\" clamp=\"false\">"
                "<in name=\"foreground\" from=\"t%d_%d\"/>"
                "<in name=\"background\" from=\"t%d_%d\"/></node>\n",
                level + 1, i, level, 2 * i, level, 2 * i + 1);
    put(&t, "<output name=\"sum\" from=\"t%d_0\" format=\"exr32\"/>\n</wetgraph>\n", level);
    WgGraph *g = wgt_load(t.s);
    free(t.s);
    WgResult *res = wgt_render(g, 2);
    double want = 0;
    for (int i = 0; i < leaves; i++) want += i % 7;
    assert_float_equal(wgt_px(wgt_output(res, "sum"), 0, 0, 0), want, 0);
    /* identical uniforms are merged: 7 distinct leaves, then the blends */
    assert_true(wg_result_evaluated_count(res) < leaves);
    wg_result_free(res);
    wg_graph_free(g);
}

/* 20,000 nodes of one subgraph type, each fed a different value, and 2,000 outputs */
static void many_subgraph_uses(void **state)
{
    (void)state;
    wgt_write_file(wgt_path("plus_half.wetgraph"),
                   "<wetgraph version=\"1\" size=\"1\">\n"
                   "<input name=\"x\" type=\"gray\"/>\n"
                   "<node id=\"half\" type=\"uniform\" value=\"0.5\"/>\n"
                   "<node id=\"sum\" type=\"blend\" mode=\"add\" clamp=\"false\">"
                   "<in name=\"foreground\" from=\"half\"/><in name=\"background\" from=\"$x\"/>"
                   "</node>\n"
                   "<output name=\"y\" from=\"sum\"/>\n</wetgraph>\n");
    const int n = 20000, outs = 2000;
    Text t = {0};
    put(&t, "<wetgraph version=\"1\" size=\"1\">\n");
    for (int i = 0; i < n; i++) {
        put(&t, "<node id=\"v%d\" type=\"uniform\" value=\"%d\"/>\n", i, i);
        put(&t, "<node id=\"p%d\" type=\"plus_half\"><in name=\"x\" from=\"v%d\"/></node>\n", i, i);
    }
    for (int k = 0; k < outs; k++)
        put(&t, "<output name=\"o%d\" from=\"p%d\" format=\"exr32\"/>\n", k, k * (n / outs));
    put(&t, "</wetgraph>\n");
    WgGraph *g = wgt_load_at(t.s, wgt_path("many.wetgraph"));
    free(t.s);
    assert_int_equal(wg_graph_output_count(g), outs);
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    assert_int_equal(wg_request_add_output(r, "o1999", &err), WG_OK);
    assert_int_equal(wg_request_add_output(r, "o7", &err), WG_OK);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    assert_float_equal(wgt_px(wgt_output(res, "o1999"), 0, 0, 0), 1999 * 10 + 0.5, 0);
    assert_float_equal(wgt_px(wgt_output(res, "o7"), 0, 0, 0), 70.5, 0);
    /* demand-driven: only the two requested branches ran (value, half merged, sum) */
    assert_true(wg_result_evaluated_count(res) <= 5);
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

/* The command line on a 100,000-node chain: check, dot and info --json finish and succeed
 * (a recursive walk would overflow the stack here). */
static void cli_chain_100k(void **state)
{
    (void)state;
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) fail_msg("WETGRAPH_BIN is not set");
    char *xml = chain_xml(100000);
    const char *path = wgt_path("chain100k.wetgraph");
    wgt_write_file(path, xml);
    free(xml);
    static const char *const commands[] = {"check", "dot", "info --json"};
    for (size_t i = 0; i < sizeof commands / sizeof *commands; i++) {
        char cmd[4096];
        snprintf(cmd, sizeof cmd, "'%s' %s '%s' > '%s' 2>&1", bin, commands[i], path,
                 wgt_path("cli.txt"));
        int st = system(cmd);
        if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) {
            char *out = wgt_read_file(wgt_path("cli.txt"), NULL);
            fail_msg("'wetgraph %s' on a 100,000-node chain: status %d: %.500s", commands[i], st,
                     out);
        }
    }
    size_t size;
    char *info = wgt_read_file(wgt_path("cli.txt"), &size);
    assert_non_null(strstr(info, "\"n99999\""));
    free(info);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(chain_10k),      cmocka_unit_test(chain_100k),
        cmocka_unit_test(wide_tree),      cmocka_unit_test(many_subgraph_uses),
        cmocka_unit_test(cli_chain_100k),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
