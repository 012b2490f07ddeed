/* SPDX-License-Identifier: MIT */
/* Allocation failures outside rendering: loading a graph (with a subgraph read from disk),
 * building a request and parsing an expression while the k-th and every later allocation fails,
 * for every k up to the number of allocations a normal run makes. Each call must either fail
 * with WG_ERR_NOMEM (status and err.code, with a message) or succeed with a result that behaves
 * exactly like a normal run's. Nothing may leak: the hook counts live blocks, and the sanitizer
 * build adds LeakSanitizer. (Rendering under failures is tested in test_image.c.) */
#include "wgtest.h"

#include "internal.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ---- a counting, failing allocator ------------------------------------------------------- */

static atomic_long n_allocs;     /* attempts, failed ones included */
static atomic_long n_live;       /* blocks handed out and not yet freed */
static atomic_long fail_at = -1; /* index of the first allocation to fail; -1 never */

static void *hook_alloc(size_t size, void *user)
{
    (void)user;
    long i = atomic_fetch_add(&n_allocs, 1);
    long f = atomic_load(&fail_at);
    if (f >= 0 && i >= f) return NULL;
    void *p = aligned_alloc(64, (size + 63) & ~(size_t)63);
    if (p) atomic_fetch_add(&n_live, 1);
    return p;
}

static void hook_free(void *ptr, void *user)
{
    (void)user;
    atomic_fetch_sub(&n_live, 1);
    free(ptr);
}

/* Count from here on; fail the k-th allocation and all later ones (k < 0: none). */
static void install(long k)
{
    atomic_store(&n_allocs, 0);
    atomic_store(&n_live, 0);
    atomic_store(&fail_at, k);
    wg_set_allocator(hook_alloc, hook_free, NULL);
}

/* Stop failing but keep counting, so blocks allocated under failures are still tracked. */
static void stop_failing(void)
{
    atomic_store(&fail_at, -1);
}

static int restore_allocator(void **state)
{
    (void)state;
    wg_set_allocator(NULL, NULL, NULL);
    return 0;
}

/* A failed call: WG_ERR_NOMEM as status and code, with a message. */
static void assert_nomem(const char *what, long k, int rc, const WgError *err)
{
    if (rc == WG_ERR_NOMEM && err->code == WG_ERR_NOMEM && err->message[0]) return;
    char buf[2048];
    wg_error_format(err, buf, sizeof buf);
    fail_msg("%s with allocation %ld failing: status %d, error code %d, message '%s'", what, k, rc,
             err->code, buf);
}

/* ---- the graphs -------------------------------------------------------------------------- */

/* Read from disk as a subgraph, used twice (loaded once, shared). */
static const char *const sub_xml =
    "<wetgraph version=\"1\" size=\"8\">\n"
    "  <param name=\"amount\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <param name=\"shade\" type=\"color\" default=\"#804020\" label=\"Shade\"/>\n"
    "  <param name=\"how\" type=\"enum\" values=\"multiply,screen\" default=\"screen\"/>\n"
    "  <input name=\"src\" type=\"gray\" default=\"0.25\"/>\n"
    "  <node id=\"c\" type=\"uniform\" kind=\"color\" color=\"=shade\"/>\n"
    "  <node id=\"m\" type=\"blend\" mode=\"=how\" opacity=\"=amount\">\n"
    "    <in name=\"foreground\" from=\"c\"/>\n"
    "    <in name=\"background\" from=\"$src\"/>\n"
    "  </node>\n"
    "  <output name=\"out\" from=\"m\"/>\n"
    "  <output name=\"src\" from=\"$src\"/>\n"
    "</wetgraph>\n";

/* Found through WETGRAPH_PATH (its second folder). */
static const char *const lib_xml =
    "<wetgraph version=\"1\" size=\"8\">\n"
    "  <param name=\"by\" type=\"int\" default=\"1\" min=\"0\" max=\"4\"/>\n"
    "  <input name=\"src\" type=\"gray\"/>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=by * 0.25\"/>\n"
    "  <node id=\"m\" type=\"blend\" mode=\"multiply\">\n"
    "    <in name=\"foreground\" from=\"u\"/>\n"
    "    <in name=\"background\" from=\"$src\"/>\n"
    "  </node>\n"
    "  <output name=\"out\" from=\"m\"/>\n"
    "</wetgraph>\n";

/* Parameters of every type (with and without defaults, ranges, labels), inputs with defaults,
 * literal and expression attributes, '=name' forwarding of enum, colour and string parameters,
 * <in> connections from nodes, ports and graph inputs, subgraphs and several outputs. */
static const char *const main_xml =
    "<wetgraph version=\"1\" size=\"16\" seed=\"7\" label=\"Alloc\" description=\"test\">\n"
    "  <param name=\"gain\" type=\"float\" default=\"0.75\" min=\"0\" max=\"2\" label=\"Gain\"/>\n"
    "  <param name=\"lo\" type=\"float\" min=\"0.25\"/>\n"
    "  <param name=\"octs\" type=\"int\" default=\"3\" min=\"1\" max=\"8\"/>\n"
    "  <param name=\"flip\" type=\"bool\" default=\"true\"/>\n"
    "  <param name=\"tint\" type=\"color\" default=\"#ff8040\"/>\n"
    "  <param name=\"mode\" type=\"enum\" values=\"multiply|screen|overlay\" default=\"screen\"/>\n"
    "  <param name=\"how\" type=\"enum\" values=\"multiply screen\"/>\n"
    "  <param name=\"pts\" type=\"string\" default=\"0:0 0.5:0.7 1:1\"/>\n"
    "  <param name=\"note\" type=\"string\"/>\n"
    "  <input name=\"mask\" type=\"gray\" default=\"0.5\"/>\n"
    "  <input name=\"base\" type=\"color\" colorspace=\"srgb\" default=\"#808080\" label=\"B\"/>\n"
    "  <input name=\"extra\" type=\"gray\"/>\n"
    "  <node id=\"n\" type=\"noise\" kind=\"value\" scale=\"4\" octaves=\"=octs\"\n"
    "        persistence=\"=gain * 0.5 + lo / 4\" seed=\"3\" label=\"Noise\"/>\n"
    "  <node id=\"cv\" type=\"curve\" points=\"=pts\"><in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"t\" type=\"uniform\" kind=\"color\" color=\"=tint\" size=\"x2\"/>\n"
    "  <node id=\"b\" type=\"blend\" mode=\"=mode\" opacity=\"=flip ? gain / 2 : 0.1\"\n"
    "        clamp=\"=flip\">\n"
    "    <in name=\"foreground\" from=\"t.output\"/>\n"
    "    <in name=\"background\" from=\"$base\"/>\n"
    "    <in name=\"mask\" from=\"cv\"/>\n"
    "  </node>\n"
    "  <node id=\"s\" type=\"tint\" amount=\"=min(gain, 1) * 0.8\" shade=\"=tint\" how=\"=how\">\n"
    "    <in name=\"src\" from=\"cv\"/>\n"
    "  </node>\n"
    "  <node id=\"s2\" type=\"tint.wetgraph\" shade=\"0.1 0.2 0.3\" size=\"4x8\"/>\n"
    "  <node id=\"p\" type=\"pixel\" f=\"=gain * 4\" expr=\"x * f + sample(a, u, v)\">\n"
    "    <in name=\"a\" from=\"$mask\"/>\n"
    "  </node>\n"
    "  <node id=\"l\" type=\"lift\" by=\"=octs - 1\"><in name=\"src\" from=\"n\"/></node>\n"
    "  <node id=\"g\" type=\"grayscale\" weights=\"0.2 0.7 0.1\">\n"
    "    <in name=\"source\" from=\"b\"/>\n"
    "  </node>\n"
    "  <output name=\"color\" from=\"b\" format=\"exr\" colorspace=\"linear\"/>\n"
    "  <output name=\"sub\" from=\"s.out\"/>\n"
    "  <output name=\"sub2\" from=\"s2\" colorspace=\"srgb\"/>\n"
    "  <output name=\"px\" from=\"p\"/>\n"
    "  <output name=\"gray\" from=\"g\"/>\n"
    "  <output name=\"m\" from=\"$mask\"/>\n"
    "  <output name=\"lift\" from=\"l\"/>\n"
    "</wetgraph>\n";

static const char *main_path(void)
{
    static bool written;
    if (!written) {
        mkdir(wgt_path("lib"), 0777);
        wgt_write_file(wgt_path("lib/lift.wetgraph"), lib_xml);
        char search[2048];
        snprintf(search, sizeof search, "%s:%s", wgt_path("nowhere"), wgt_path("lib"));
        setenv("WETGRAPH_PATH", search, 1);
        wgt_write_file(wgt_path("tint.wetgraph"), sub_xml);
        wgt_write_file(wgt_path("main.wetgraph"), main_xml);
        written = true;
    }
    return wgt_path("main.wetgraph");
}

/* ---- comparing graphs and renders -------------------------------------------------------- */

static void assert_same_text(const char *a, const char *b)
{
    if (!a || !b)
        assert_ptr_equal(a, b);
    else
        assert_string_equal(a, b);
}

static void assert_same_list(const char *const *a, const char *const *b, int n)
{
    if (!a || !b) {
        assert_ptr_equal(a, b);
        return;
    }
    for (int i = 0; n < 0 ? a[i] || b[i] : i < n; i++) assert_same_text(a[i], b[i]);
}

/* Everything a graph declares, and the same for its subgraphs (through the internals). */
static void assert_same_graph(const WgGraph *a, const WgGraph *b)
{
    assert_same_text(wg_graph_name(a), wg_graph_name(b));
    assert_same_text(wg_graph_path(a), wg_graph_path(b));
    assert_same_text(wg_graph_size_text(a), wg_graph_size_text(b));
    assert_true(wg_graph_seed(a) == wg_graph_seed(b));
    assert_int_equal(wg_graph_param_count(a), wg_graph_param_count(b));
    for (int i = 0; i < wg_graph_param_count(a); i++) {
        const WgGraphParamInfo *p = wg_graph_param_info(a, i), *q = wg_graph_param_info(b, i);
        assert_same_text(p->name, q->name);
        assert_int_equal(p->type, q->type);
        assert_same_text(p->default_text, q->default_text);
        assert_int_equal(p->has_min, q->has_min);
        assert_int_equal(p->has_max, q->has_max);
        assert_true(p->min == q->min && p->max == q->max);
        assert_same_text(p->label, q->label);
        assert_same_list(p->values, q->values, -1);
        assert_int_equal(p->line, q->line);
    }
    assert_int_equal(wg_graph_input_count(a), wg_graph_input_count(b));
    for (int i = 0; i < wg_graph_input_count(a); i++) {
        const WgGraphInputInfo *p = wg_graph_input_info(a, i), *q = wg_graph_input_info(b, i);
        assert_same_text(p->name, q->name);
        assert_int_equal(p->kind, q->kind);
        assert_int_equal(p->colorspace, q->colorspace);
        assert_int_equal(p->has_default, q->has_default);
        assert_same_text(p->default_text, q->default_text);
        assert_int_equal(p->line, q->line);
    }
    assert_int_equal(wg_graph_output_count(a), wg_graph_output_count(b));
    for (int i = 0; i < wg_graph_output_count(a); i++) {
        const WgGraphOutputInfo *p = wg_graph_output_info(a, i), *q = wg_graph_output_info(b, i);
        assert_same_text(p->name, q->name);
        assert_same_text(p->from, q->from);
        assert_int_equal(p->format, q->format);
        assert_int_equal(p->colorspace, q->colorspace);
        assert_int_equal(p->line, q->line);
    }
    assert_int_equal(wg_graph_node_count(a), wg_graph_node_count(b));
    for (int i = 0; i < wg_graph_node_count(a); i++) {
        const WgGraphNodeInfo *p = wg_graph_node_info(a, i), *q = wg_graph_node_info(b, i);
        assert_same_text(p->id, q->id);
        assert_same_text(p->type, q->type);
        assert_int_equal(p->is_subgraph, q->is_subgraph);
        assert_same_text(p->subgraph_path, q->subgraph_path);
        assert_int_equal(p->n_inputs, q->n_inputs);
        assert_same_list(p->input_ports, q->input_ports, p->n_inputs);
        assert_same_list(p->input_from, q->input_from, p->n_inputs);
        assert_int_equal(p->line, q->line);
        const NodeDef *m = &a->nodes[i], *n = &b->nodes[i];
        assert_int_equal(m->n_attrs, n->n_attrs);
        for (int k = 0; k < m->n_attrs; k++) {
            assert_same_text(m->attrs[k].name, n->attrs[k].name);
            assert_same_text(m->attrs[k].text, n->attrs[k].text);
            assert_int_equal(m->attrs[k].param, n->attrs[k].param);
            assert_int_equal(m->attrs[k].ref_param, n->attrs[k].ref_param);
            assert_int_equal(!m->attrs[k].expr, !n->attrs[k].expr);
            char x[256], y[256];
            wg__value_format(&m->attrs[k].literal, x, sizeof x);
            wg__value_format(&n->attrs[k].literal, y, sizeof y);
            assert_string_equal(x, y);
        }
        assert_same_text(m->size_text, n->size_text);
        assert_same_text(m->seed_text, n->seed_text);
        assert_same_text(m->label, n->label);
        if (m->sub) assert_same_graph(m->sub, n->sub);
    }
}

/* Render every output of request r (with its graph's defaults when r is NULL). */
static WgResult *render(const WgGraph *g, const WgRequest *r)
{
    if (!r) return wgt_render(g, 2);
    WgError err = {0};
    WgEngineOptions opt = {2, 0, NULL};
    WgEngine *e = NULL;
    WgResult *res = NULL;
    if (wg_engine_new(&opt, &e, &err) || wg_render(e, r, &res, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("render: %s", buf);
    }
    wg_engine_free(e);
    return res;
}

static void assert_same_result(const WgResult *a, const WgResult *b)
{
    assert_int_equal(wg_result_output_count(a), wg_result_output_count(b));
    for (int i = 0; i < wg_result_output_count(a); i++) {
        assert_string_equal(wg_result_output_name(a, i), wg_result_output_name(b, i));
        assert_int_equal(wg_result_output_format(a, i), wg_result_output_format(b, i));
        assert_int_equal(wg_result_output_colorspace(a, i), wg_result_output_colorspace(b, i));
        wgt_assert_identical(wg_result_output_image(a, i), wg_result_output_image(b, i));
    }
}

/* ---- loading ----------------------------------------------------------------------------- */

static void test_load(void **state)
{
    (void)state;
    const char *path = main_path();
    WgGraph *ref = NULL;
    WgError err = {0};
    install(-1);
    int rc = wg_graph_load(path, &ref, &err);
    long needed = atomic_load(&n_allocs);
    restore_allocator(NULL);
    if (rc) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("reference load: %s", buf);
    }
    assert_true(needed > 50);
    WgResult *want = render(ref, NULL);

    int failures = 0;
    for (long k = 0; k <= needed; k++) {
        WgGraph *g = NULL;
        memset(&err, 0, sizeof err);
        install(k);
        rc = wg_graph_load(path, &g, &err);
        stop_failing();
        if (rc == WG_OK) {
            assert_non_null(g);
            assert_same_graph(g, ref);
            WgResult *got = render(g, NULL);
            assert_same_result(got, want);
            wg_result_free(got);
            wg_graph_free(g);
        } else {
            assert_nomem("wg_graph_load", k, rc, &err);
            assert_null(g);
            failures++;
        }
        long live = atomic_load(&n_live);
        restore_allocator(NULL);
        if (live) fail_msg("allocation %ld failing: %ld blocks leaked", k, live);
        if (k == needed) assert_int_equal(rc, WG_OK); /* nothing failed */
    }
    /* only best-effort allocations (sharing a subgraph) may fail without failing the load */
    assert_true(failures > needed / 2);

    /* from memory too, with the subgraph still read from disk */
    for (long k = 0; k <= needed; k++) {
        WgGraph *g = NULL;
        memset(&err, 0, sizeof err);
        install(k);
        rc = wg_graph_load_memory(main_xml, strlen(main_xml), path, &g, &err);
        stop_failing();
        if (rc == WG_OK) {
            assert_same_graph(g, ref);
            wg_graph_free(g);
        } else {
            assert_nomem("wg_graph_load_memory", k, rc, &err);
        }
        long live = atomic_load(&n_live);
        restore_allocator(NULL);
        if (live) fail_msg("allocation %ld failing: %ld blocks leaked", k, live);
    }
    wg_result_free(want);
    wg_graph_free(ref);
}

/* ---- requests ---------------------------------------------------------------------------- */

/* The calls that fill a request, in order; step i of them. */
static int request_step(WgRequest *r, int i, const WgImage *img, WgError *err)
{
    switch (i) {
    case 0:
        return wg_request_set(r, "gain", "1.25", err);
    case 1:
        return wg_request_set(r, "octs", "=2 + 3", err);
    case 2:
        return wg_request_set(r, "mode", "overlay", err);
    case 3:
        return wg_request_set(r, "pts", "0:0.2 1:0.9", err);
    case 4:
        return wg_request_set(r, "tint", "#3080c0", err);
    case 5:
        return wg_request_set(r, "flip", "false", err);
    case 6:
        return wg_request_set(r, "how", "multiply", err);
    case 7:
        return wg_request_set(r, "mode", "multiply", err); /* replaces a set value */
    case 8:
        return wg_request_set_input_image(r, "mask", img, err);
    case 9:
        return wg_request_add_output(r, "sub", err);
    case 10:
        return wg_request_add_output(r, "gray", err);
    case 11:
        return wg_request_add_output(r, "sub", err);
    case 12:
        return wg_request_add_output(r, "px", err);
    default:
        return -100;
    }
}
enum { REQUEST_STEPS = 13 };

static WgRequest *full_request(const WgGraph *g, const WgImage *img)
{
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgError err = {0};
    for (int i = 0; i < REQUEST_STEPS; i++) assert_int_equal(request_step(r, i, img, &err), WG_OK);
    return r;
}

static double ramp(int x, int y, int k)
{
    return (x * 7 + y * 3 + k) % 16 / 15.0;
}

static void test_request(void **state)
{
    (void)state;
    WgGraph *g = NULL;
    WgError err = {0};
    if (wg_graph_load(main_path(), &g, &err)) fail_msg("load: %s", err.message);
    WgImage *img = wgt_image_fn(5, 7, 1, ramp);
    WgRequest *ref = full_request(g, img);
    WgResult *want = render(g, ref);

    install(-1);
    wg_request_free(full_request(g, img));
    long needed = atomic_load(&n_allocs);
    restore_allocator(NULL);
    assert_true(needed > 5);

    for (long k = 0; k <= needed; k++) {
        install(k);
        WgRequest *r = wg_request_new(g);
        int done = 0;
        while (r && done < REQUEST_STEPS) {
            memset(&err, 0, sizeof err);
            int rc = request_step(r, done, img, &err);
            if (rc) {
                assert_nomem("wg_request_*", k, rc, &err);
                break;
            }
            done++;
        }
        stop_failing();
        /* a failed call leaves the request as it was: finish it and render */
        if (r) {
            for (; done < REQUEST_STEPS; done++) {
                memset(&err, 0, sizeof err);
                assert_int_equal(request_step(r, done, img, &err), WG_OK);
            }
            WgResult *got = render(g, r);
            assert_same_result(got, want);
            wg_result_free(got);
            wg_request_free(r);
        } else {
            assert_true(k < needed);
        }
        long live = atomic_load(&n_live);
        restore_allocator(NULL);
        if (live) fail_msg("allocation %ld failing: %ld blocks leaked", k, live);
    }
    wg_result_free(want);
    wg_request_free(ref);
    wg_image_unref(img);
    wg_graph_free(g);
}

/* ---- expressions ------------------------------------------------------------------------- */

static bool resolve_xy(void *user, const char *name, size_t len, int *slot)
{
    (void)user;
    if (len != 1 || (name[0] != 'x' && name[0] != 'y')) return false;
    *slot = name[0] == 'y';
    return true;
}

static void test_expr(void **state)
{
    (void)state;
    const char *src = "x < 2 ? clamp(-x * 3 + y ^ 2, 0, 10) : max(sin(x), y % 3, !y) / (1 + x)";
    WgExprOptions opt = {resolve_xy, NULL, false};
    const double slots[3][2] = {{1.5, 3}, {2.5, -4}, {-1, 0.25}};
    WgExpr *ref = NULL;
    WgError err = {0};
    install(-1);
    assert_int_equal(wg_expr_parse(src, &opt, &ref, &err), WG_OK);
    long needed = atomic_load(&n_allocs);
    restore_allocator(NULL);
    assert_true(needed >= 1);
    WgExpr *e;

    for (long k = 0; k <= needed; k++) {
        e = NULL;
        memset(&err, 0, sizeof err);
        install(k);
        int rc = wg_expr_parse(src, &opt, &e, &err);
        stop_failing();
        if (rc == WG_OK) {
            assert_int_equal(k, needed);
            for (int i = 0; i < 3; i++)
                assert_true(wg_expr_eval(e, slots[i]) == wg_expr_eval(ref, slots[i]));
            assert_string_equal(e->source, src);
            wg_expr_free(e);
        } else {
            assert_nomem("wg_expr_parse", k, rc, &err);
            assert_null(e);
        }
        long live = atomic_load(&n_live);
        restore_allocator(NULL);
        if (live) fail_msg("allocation %ld failing: %ld blocks leaked", k, live);
    }
    wg_expr_free(ref);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_load, restore_allocator),
        cmocka_unit_test_teardown(test_request, restore_allocator),
        cmocka_unit_test_teardown(test_expr, restore_allocator),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
