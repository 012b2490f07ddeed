/* SPDX-License-Identifier: MIT */
/* Cancelling a render with a cancel token (wg_request_set_cancel, wg_cancel_request): before it
 * starts, from its progress callback, and from another thread while a long node runs. A
 * cancelled render returns WG_ERR_CANCELLED without a result; the node that was running stops
 * at its next chunk of rows and leaves nothing in the memory or disk cache; the nodes that had
 * finished stay cached; the next render is bit-identical to one on a fresh engine. The long
 * node is a test node ("gate") whose row chunks wait until the test releases them, so nothing
 * depends on timing; alarm() is the harness limit against hangs. */
#include "wgtest.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* ---- the gate node: out = source * 0.5 + a pattern of (x, y); each chunk of rows waits for
 * `released` ---------------------------------------------------------------------------------- */

static atomic_int released = 1;
static atomic_int chunks_started;

typedef struct {
    const WgImage *src;
    WgImage *dst;
} GateJob;

static void gate_rows(void *user, int y0, int y1)
{
    GateJob *j = user;
    atomic_fetch_add(&chunks_started, 1);
    while (!atomic_load(&released)) wgt_sleep_ms(1);
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->src, y);
        float *d = wg_image_row(j->dst, y);
        for (int x = 0; x < j->dst->width; x++)
            d[x] = s[x] * 0.5f + (float)((x * 7 + y * 3) % 11) / 22;
    }
}

static int gate_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    GateJob j = {ctx->inputs[0], ctx->outputs[0]};
    return wg_parallel_rows(ctx, ctx->height, gate_rows, &j);
}

static const WgPortSpec gate_in[] = {WG_PORT("source", WG_GRAY), WG_PORT_END};
static const WgPortSpec gate_out[] = {WG_PORT("out", WG_GRAY), WG_PORT_END};
static const WgParamSpec gate_params[] = {WG_PARAM_END};
static const WgNodeType gate_type = {
    .name = "gate",
    .summary = "test node whose row chunks wait for the test",
    .category = "test",
    .params = gate_params,
    .inputs = gate_in,
    .outputs = gate_out,
    .eval = gate_eval,
};

static const WgNodeType *types[512];

static int use_gate(void **state)
{
    (void)state;
    int n = 0;
    while (wg_node_types[n]) {
        types[n] = wg_node_types[n];
        n++;
    }
    types[n++] = &gate_type;
    types[n] = NULL;
    wg_set_node_types(types);
    atomic_store(&released, 1);
    return 0;
}

static int restore_builtin(void **state)
{
    (void)state;
    wg_set_node_types(wg_node_types);
    atomic_store(&released, 1);
    return 0;
}

/* noise -> blur -> gate -> levels -> out; "pre" is the blur's own output too. */
static const char *const graph_xml =
    "<wetgraph version=\"1\" size=\"256\" seed=\"3\">\n"
    "  <node id=\"n\" type=\"noise\"/>\n"
    "  <node id=\"pre\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"g\" type=\"gate\"><in name=\"source\" from=\"pre\"/></node>\n"
    "  <node id=\"post\" type=\"blur\" sigma=\"1\"><in name=\"source\" from=\"g\"/></node>\n"
    "  <output name=\"out\" from=\"post\"/>\n"
    "  <output name=\"pre\" from=\"pre\"/>\n"
    "</wetgraph>\n";

static void expect_same_outputs(const WgResult *a, const WgResult *b)
{
    assert_int_equal(wg_result_output_count(a), wg_result_output_count(b));
    for (int i = 0; i < wg_result_output_count(a); i++)
        wgt_assert_identical(wg_result_output_image(a, i), wg_result_output_image(b, i));
}

/* The outputs of a render of g on a fresh engine without any cache. */
static WgResult *reference(const WgGraph *g)
{
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgRequest *r = wg_request_new(g);
    WgResult *res = wgt_render_request(e, r);
    wg_request_free(r);
    wg_engine_free(e);
    return res;
}

static void expect_outcome(const WgResult *res, const char *id, WgCacheOutcome want)
{
    const WgNodeStat *s = wgt_stat(res, id);
    if (!s) fail_msg("no stat for node '%s'", id);
    if (s->cache != want) fail_msg("node '%s': cache outcome %d, expected %d", id, s->cache, want);
}

static void expect_cancelled(WgEngine *e, const WgRequest *r)
{
    WgResult *res = NULL;
    WgError err = {0};
    int rc = wg_render(e, r, &res, &err);
    if (rc != WG_ERR_CANCELLED)
        fail_msg("render returned %d (%s), expected WG_ERR_CANCELLED", rc, err.message);
    assert_null(res);
    wgt_assert_error(&err, WG_ERR_CANCELLED, 0, "cancelled");
}

/* A graph, its reference outputs, an engine, and a request of the graph with a cancel token. */
typedef struct {
    WgGraph *g;
    WgResult *ref;
    WgEngine *e;
    WgRequest *r;
    WgCancel *c;
} Fixture;

static Fixture fixture(const char *xml, int threads, const char *cache_dir)
{
    Fixture f;
    f.g = wgt_load(xml);
    f.ref = reference(f.g);
    f.e = wgt_engine(threads, 0, cache_dir);
    f.r = wg_request_new(f.g);
    f.c = wg_cancel_new();
    assert_non_null(f.c);
    wg_request_set_cancel(f.r, f.c);
    return f;
}

static void fixture_free(Fixture *f)
{
    wg_cancel_free(f->c);
    wg_request_free(f->r);
    wg_engine_free(f->e);
    wg_result_free(f->ref);
    wg_graph_free(f->g);
}

/* ---- tests ------------------------------------------------------------------------------- */

static void test_cancel_before_start(void **state)
{
    (void)state;
    Fixture f = fixture(graph_xml, 2, NULL);
    assert_false(wg_cancel_requested(f.c));
    wg_cancel_request(f.c);
    assert_true(wg_cancel_requested(f.c));
    atomic_store(&chunks_started, 0);
    expect_cancelled(f.e, f.r);
    assert_int_equal(atomic_load(&chunks_started), 0); /* nothing ran */
    /* a second render of a requested token is cancelled too, until reset */
    expect_cancelled(f.e, f.r);
    wg_cancel_reset(f.c);
    WgResult *res = wgt_render_request(f.e, f.r);
    assert_int_equal(wg_result_evaluated_count(res), 4); /* nothing was cached */
    expect_same_outputs(res, f.ref);
    wg_result_free(res);
    /* a request without a token is not affected by a requested one */
    wg_cancel_request(f.c);
    WgRequest *other = wg_request_new(f.g);
    wg_engine_clear_cache(f.e);
    res = wgt_render_request(f.e, other);
    expect_same_outputs(res, f.ref);
    wg_result_free(res);
    wg_request_free(other);
    fixture_free(&f);
}

typedef struct {
    WgCancel *c;
    int calls, cancel_at, last_done, total;
} Progress;

static void cancel_in_progress(void *user, int done, int total, const char *node)
{
    (void)node;
    Progress *p = user;
    p->calls++;
    p->last_done = done;
    p->total = total;
    if (done >= p->cancel_at) wg_cancel_request(p->c);
}

static void test_cancel_from_progress_callback(void **state)
{
    (void)state;
    Fixture f = fixture(graph_xml, 1, NULL); /* one worker: the nodes run in plan order */
    Progress p = {f.c, 0, 2, 0, 0};
    wg_request_set_progress(f.r, cancel_in_progress, &p);
    expect_cancelled(f.e, f.r);
    assert_int_equal(p.total, 4);
    assert_true(p.last_done >= 2);
    assert_true(p.last_done < 4); /* never told the render completed */
    /* n and pre finished before the cancel and are cached; the rest runs now */
    wg_cancel_reset(f.c);
    p.cancel_at = 1000;
    WgResult *res = wgt_render_request(f.e, f.r);
    expect_outcome(res, "pre", WG_HIT_MEMORY); /* (n is then not needed) */
    expect_outcome(res, "g", WG_COMPUTED);
    expect_outcome(res, "post", WG_COMPUTED);
    assert_int_equal(p.last_done, 2);
    expect_same_outputs(res, f.ref);
    wg_result_free(res);
    fixture_free(&f);
}

typedef struct {
    WgEngine *e;
    const WgRequest *r;
    WgResult *res;
    WgError err;
    int rc;
} RenderThread;

static void *render_thread(void *arg)
{
    RenderThread *t = arg;
    t->rc = wg_render(t->e, t->r, &t->res, &t->err);
    return NULL;
}

/* Start a render of r on another thread, wait until the gate node runs (its chunks hold), then
 * cancel it and let the chunks go. Returns how many of the gate's chunks started. */
static int cancel_during_gate(WgEngine *e, const WgRequest *r, WgCancel *c)
{
    atomic_store(&released, 0);
    atomic_store(&chunks_started, 0);
    RenderThread t = {e, r, NULL, {0}, 0};
    pthread_t tid;
    assert_int_equal(pthread_create(&tid, NULL, render_thread, &t), 0);
    while (atomic_load(&chunks_started) == 0) wgt_sleep_ms(1); /* alarm() is the limit */
    wg_cancel_request(c);
    atomic_store(&released, 1);
    pthread_join(tid, NULL);
    if (t.rc != WG_ERR_CANCELLED)
        fail_msg("render returned %d (%s), expected WG_ERR_CANCELLED", t.rc, t.err.message);
    assert_null(t.res);
    wgt_assert_error(&t.err, WG_ERR_CANCELLED, 0, "cancelled");
    return atomic_load(&chunks_started);
}

static void test_cancel_from_another_thread(void **state)
{
    (void)state;
    const int threads = 2;
    Fixture f = fixture(graph_xml, threads, NULL);
    int started = cancel_during_gate(f.e, f.r, f.c);
    /* the chunks that were waiting finish; no other chunk of the gate's 64 starts */
    assert_true(started >= 1);
    assert_true(started <= threads);
    /* the gate's partial output is not cached: it is computed again, and post after it */
    wg_cancel_reset(f.c);
    atomic_store(&chunks_started, 0);
    WgResult *res = wgt_render_request(f.e, f.r);
    expect_outcome(res, "pre", WG_HIT_MEMORY); /* (n is then not needed) */
    expect_outcome(res, "g", WG_COMPUTED);
    expect_outcome(res, "post", WG_COMPUTED);
    assert_int_equal(atomic_load(&chunks_started), 64);
    expect_same_outputs(res, f.ref);
    wg_result_free(res);
    /* and now everything is cached */
    res = wgt_render_request(f.e, f.r);
    assert_int_equal(wg_result_evaluated_count(res), 0);
    expect_same_outputs(res, f.ref);
    wg_result_free(res);
    fixture_free(&f);
}

/* The node that is cancelled is the last one: every node is then counted as completed, but the
 * render is still cancelled, not a result with a missing image. */
static void test_cancel_the_last_node(void **state)
{
    (void)state;
    Fixture f = fixture("<wetgraph version=\"1\" size=\"256\" seed=\"3\">\n"
                        "  <node id=\"n\" type=\"noise\"/>\n"
                        "  <node id=\"g\" type=\"gate\"><in name=\"source\" from=\"n\"/></node>\n"
                        "  <output name=\"out\" from=\"g\"/>\n"
                        "</wetgraph>\n",
                        2, NULL);
    Progress p = {NULL, 0, 1000, 0, 0}; /* only watches */
    wg_request_set_progress(f.r, cancel_in_progress, &p);
    cancel_during_gate(f.e, f.r, f.c);
    assert_true(p.calls == 0 || p.last_done < p.total); /* never told it completed */
    wg_request_set_progress(f.r, NULL, NULL);
    wg_cancel_reset(f.c);
    WgResult *res = wgt_render_request(f.e, f.r);
    expect_outcome(res, "g", WG_COMPUTED);
    expect_same_outputs(res, f.ref);
    wg_result_free(res);
    fixture_free(&f);
}

static void test_cancel_with_disk_cache(void **state)
{
    (void)state;
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", wgt_path("cancel_cache"));
    Fixture f = fixture(graph_xml, 2, dir);
    cancel_during_gate(f.e, f.r, f.c);
    wg_engine_free(f.e);
    /* n (if it is not a cheap node) and pre are on disk; the gate and post are not; no
     * temporary is left */
    int hidden = 0, entries = wgt_count_files(dir, &hidden);
    assert_int_equal(hidden, 0);
    assert_true(entries >= 1 && entries <= 2);
    int before = entries;

    /* a fresh engine on the same folder: the finished nodes come from the disk, the rest is
     * computed, and the pixels are those of an uncancelled render */
    f.e = wgt_engine(2, 0, dir);
    wg_cancel_reset(f.c);
    WgResult *res = wgt_render_request(f.e, f.r);
    expect_outcome(res, "pre", WG_HIT_DISK);
    expect_outcome(res, "g", WG_COMPUTED);
    expect_outcome(res, "post", WG_COMPUTED);
    expect_same_outputs(res, f.ref);
    wg_result_free(res);
    wg_engine_free(f.e);
    f.e = NULL;
    hidden = 0;
    entries = wgt_count_files(dir, &hidden);
    assert_int_equal(hidden, 0);
    assert_int_equal(entries, before + 2);

    fixture_free(&f);
}

/* Two requests of one graph on one engine at once, each with its own token: cancelling one
 * leaves the other to finish with the right pixels. */
static void test_cancel_leaves_other_requests(void **state)
{
    (void)state;
    Fixture f = fixture(graph_xml, 2, NULL); /* f.r with f.c, and another with its own token */
    WgRequest *r2 = wg_request_new(f.g);
    WgCancel *c2 = wg_cancel_new();
    wg_request_set_cancel(r2, c2);
    atomic_store(&released, 0);
    atomic_store(&chunks_started, 0);
    RenderThread t1 = {f.e, f.r, NULL, {0}, 0}, t2 = {f.e, r2, NULL, {0}, 0};
    pthread_t tid1, tid2;
    assert_int_equal(pthread_create(&tid1, NULL, render_thread, &t1), 0);
    while (atomic_load(&chunks_started) == 0) wgt_sleep_ms(1);
    assert_int_equal(pthread_create(&tid2, NULL, render_thread, &t2), 0);
    wg_cancel_request(f.c);
    atomic_store(&released, 1);
    pthread_join(tid1, NULL);
    pthread_join(tid2, NULL);
    assert_int_equal(t1.rc, WG_ERR_CANCELLED);
    assert_null(t1.res);
    if (t2.rc) fail_msg("the other render failed: %s", t2.err.message);
    expect_same_outputs(t2.res, f.ref);
    wg_result_free(t2.res);
    wg_cancel_free(c2);
    wg_request_free(r2);
    fixture_free(&f);
}

int main(void)
{
    alarm(120); /* harness limit: a render that never notices its cancel hangs the test */
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_cancel_before_start, use_gate, restore_builtin),
        cmocka_unit_test_setup_teardown(test_cancel_from_progress_callback, use_gate,
                                        restore_builtin),
        cmocka_unit_test_setup_teardown(test_cancel_from_another_thread, use_gate, restore_builtin),
        cmocka_unit_test_setup_teardown(test_cancel_the_last_node, use_gate, restore_builtin),
        cmocka_unit_test_setup_teardown(test_cancel_with_disk_cache, use_gate, restore_builtin),
        cmocka_unit_test_setup_teardown(test_cancel_leaves_other_requests, use_gate,
                                        restore_builtin),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
