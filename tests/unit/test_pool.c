/* SPDX-License-Identifier: MIT */
/* The buffer pool (engine/mempool.c): freed buffers are handed out again by size class, within
 * the pool's limit, and a mapping that misses its class is cut from a larger idle one; a second
 * render on the same engine takes every buffer from the pool and gives the same bytes as a fresh
 * engine with another thread count, even when every buffer handed out is first filled with NaNs (so
 * no node may read memory it has not written); the memory budget holds with the pool's idle buffers
 * counted; a released buffer goes back to the system; images may outlive their engine; and under
 * injected allocation failures at every point, a render (first or second on one engine) fails with
 * WG_ERR_NOMEM or gives the normal result, leaking nothing. */
#include "wgtest.h"

#include "internal.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MIB ((size_t)1 << 20)

/* Most node families, with intermediates at 512² (1 MiB gray: mapped buffers; colour 4 MiB:
 * 2 MiB aligned buffers), scratch memory (exact and fast blur, distance, sharpen) and
 * inputs the engine converts (a half-size image resampled, gray promoted to colour). */
static const char *mixed_xml(int size)
{
    static char xml[4096];
    snprintf(
        xml, sizeof xml,
        "<wetgraph version=\"1\" size=\"%d\" seed=\"3\">\n"
        "  <node id=\"n\" type=\"noise\" octaves=\"3\"/>\n"
        "  <node id=\"c\" type=\"cells\" scale=\"6\"/>\n"
        "  <node id=\"l\" type=\"levels\" in_low=\"0.3\" in_high=\"0.7\">"
        "<in name=\"source\" from=\"n\"/></node>\n"
        "  <node id=\"be\" type=\"blur\" sigma=\"2\" quality=\"exact\">"
        "<in name=\"source\" from=\"l\"/></node>\n"
        "  <node id=\"bf\" type=\"blur\" sigma=\"3\"><in name=\"source\" from=\"c.f1\"/></node>\n"
        "  <node id=\"d\" type=\"distance\" mode=\"signed\"><in name=\"mask\" from=\"l\"/></node>\n"
        "  <node id=\"di\" type=\"dilate\" radius=\"2\"><in name=\"mask\" from=\"l\"/></node>\n"
        "  <node id=\"s\" type=\"sharpen\" radius=\"2\"><in name=\"source\" from=\"be\"/></node>\n"
        "  <node id=\"nm\" type=\"normal\"><in name=\"height\" from=\"bf\"/></node>\n"
        "  <node id=\"w\" type=\"warp\" amount=\"4\"><in name=\"source\" from=\"nm\"/>"
        "<in name=\"intensity\" from=\"n\"/></node>\n"
        "  <node id=\"cv\" type=\"curvature\"><in name=\"height\" from=\"d\"/></node>\n"
        "  <node id=\"ao\" type=\"ambient_occlusion\" radius=\"2\" directions=\"4\">"
        "<in name=\"height\" from=\"di\"/></node>\n"
        "  <node id=\"db\" type=\"directional_blur\" length=\"3\"><in name=\"source\" "
        "from=\"w\"/></node>\n"
        "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"s\"/></node>\n"
        "  <node id=\"h\" type=\"invert\" size=\"/2\"><in name=\"source\" from=\"l\"/></node>\n"
        "  <node id=\"bl\" type=\"blend\" mode=\"overlay\"><in name=\"foreground\" from=\"h\"/>"
        "<in name=\"background\" from=\"nm\"/></node>\n"
        "  <output name=\"e\" from=\"bl\"/>\n"
        "  <output name=\"a\" from=\"db\"/>\n"
        "  <output name=\"b\" from=\"cv\"/>\n"
        "  <output name=\"c\" from=\"ao\"/>\n"
        "  <output name=\"d\" from=\"i\"/>\n"
        "</wetgraph>\n",
        size);
    return xml;
}

static WgResult *render_on(WgEngine *e, const WgGraph *g)
{
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgResult *res = wgt_render_request(e, r);
    wg_request_free(r);
    return res;
}

static void assert_results_identical(const WgResult *a, const WgResult *b)
{
    assert_int_equal(wg_result_output_count(a), wg_result_output_count(b));
    for (int i = 0; i < wg_result_output_count(a); i++)
        wgt_assert_identical(wg_result_output_image(a, i), wg_result_output_image(b, i));
}

/* ---- the pool itself --------------------------------------------------------------------- */

static void test_classes(void **state)
{
    (void)state;
    WgMemPool *p = wg__mempool_new(4 * MIB);
    WgMemoryStats s;
    int m1, m2, m3;
    void *a = wg__mempool_get(p, MIB, &m1);
    void *b = wg__mempool_get(p, 1000, &m2);
    assert_non_null(a);
    assert_non_null(b);
    assert_true(((uintptr_t)a & 63) == 0 && ((uintptr_t)b & 63) == 0);
    assert_int_equal(m1, 1); /* 1 MiB and more: a mapping of its own */
    assert_int_equal(m2, 0);
    memset(a, 1, MIB);
    memset(b, 2, 1000);
    wg__mempool_put(p, a, MIB, m1);
    wg__mempool_put(p, b, 1000, m2);
    wg__mempool_stats(p, &s);
    assert_int_equal(s.pool_buffers, 2);
    assert_int_equal(s.pool_hits, 0);
    assert_int_equal(s.pool_misses, 2);
    /* same class: the same buffer again; another size: new memory */
    assert_ptr_equal(wg__mempool_get(p, MIB, &m3), a);
    assert_int_equal(m3, 1);
    void *c = wg__mempool_get(p, 3 * MIB, &m3);
    assert_non_null(c);
    assert_true(((uintptr_t)c & ((2 * MIB) - 1)) == 0); /* 2 MiB aligned */
    wg__mempool_stats(p, &s);
    assert_int_equal(s.pool_hits, 1);
    assert_int_equal(s.pool_misses, 3);
    /* the limit: 3 MiB idle fits beside 1 MiB, another 1 MiB does not */
    wg__mempool_put(p, c, 3 * MIB, m3);
    wg__mempool_put(p, a, MIB, 1);
    wg__mempool_stats(p, &s);
    assert_true(s.pool_bytes <= 4 * MIB);
    assert_true(s.pool_released >= MIB);
    wg__mempool_trim(p, 0);
    wg__mempool_stats(p, &s);
    assert_int_equal(s.pool_bytes, 0);
    assert_int_equal(s.pool_buffers, 0);
    wg__mempool_close(p);
}

/* A mapping request that misses its class is cut from the smallest larger idle mapping (pages
 * touched before), the rest staying idle as a buffer of its own; a rest smaller than a mapping's
 * size goes back to the system. */
static void test_split(void **state)
{
    (void)state;
    WgMemPool *p = wg__mempool_new(64 * MIB);
    WgMemoryStats s;
    int m;
    char *big = wg__mempool_get(p, 8 * MIB, &m), *mid = wg__mempool_get(p, 6 * MIB, &m);
    memset(big, 1, 8 * MIB);
    memset(mid, 2, 6 * MIB);
    wg__mempool_put(p, big, 8 * MIB, 1);
    wg__mempool_put(p, mid, 6 * MIB, 1);
    /* 2 MiB: from the smaller of the two (6 MiB), whose other 4 MiB stay idle */
    char *a = wg__mempool_get(p, 2 * MIB, &m);
    assert_ptr_equal(a, mid);
    assert_int_equal(m, 1);
    wg__mempool_stats(p, &s);
    assert_int_equal(s.pool_bytes, 12 * MIB);
    assert_int_equal(s.pool_buffers, 2);
    /* 4 MiB: the rest, exactly */
    char *b = wg__mempool_get(p, 4 * MIB, &m);
    assert_ptr_equal(b, mid + 2 * MIB);
    /* 7.5 MiB from the 8 MiB: the last half MiB is too small to keep */
    char *c = wg__mempool_get(p, 7 * MIB + MIB / 2, &m);
    assert_ptr_equal(c, big);
    wg__mempool_stats(p, &s);
    assert_int_equal(s.pool_bytes, 0);
    assert_int_equal(s.pool_buffers, 0);
    assert_int_equal(s.pool_hits, 3);
    assert_int_equal(s.pool_misses, 2);
    /* the pieces are buffers of their own: written, put back and given back one by one */
    memset(a, 3, 2 * MIB);
    memset(b, 4, 4 * MIB);
    memset(c, 5, 7 * MIB + MIB / 2);
    wg__mempool_put(p, b, 4 * MIB, 1);
    wg__mempool_put(p, a, 2 * MIB, 1);
    wg__mempool_put(p, c, 7 * MIB + MIB / 2, 1);
    wg__mempool_stats(p, &s);
    assert_int_equal(s.pool_bytes, 13 * MIB + MIB / 2);
    wg__mempool_close(p);
}

/* A buffer taken from the pool and released goes back to the system, not to the pool: an
 * idle buffer reused that way (a writer's scratch) leaves the pool smaller, the released count
 * grows, and the pool's references balance (it closes cleanly after, also with one still out). */
static void test_release(void **state)
{
    (void)state;
    WgMemPool *p = wg__mempool_new(64 * MIB);
    WgMemoryStats s;
    int m;
    char *a = wg__mempool_get(p, 6 * MIB, &m), *b = wg__mempool_get(p, 2 * MIB, &m);
    memset(a, 1, 6 * MIB);
    wg__mempool_put(p, a, 6 * MIB, m);
    char *again = wg__mempool_get(p, 6 * MIB, &m); /* the idle one, touched before */
    assert_ptr_equal(again, a);
    memset(again, 2, 6 * MIB);
    wg__mempool_release(p, again, 6 * MIB);
    wg__mempool_stats(p, &s);
    assert_int_equal(s.pool_bytes, 0);
    assert_int_equal(s.pool_buffers, 0);
    assert_int_equal(s.pool_released, 6 * MIB);
    wg__mempool_release(p, NULL, 6 * MIB); /* nothing */
    char *small = wg__mempool_get(p, 1000, &m);
    memset(small, 3, 1000);
    wg__mempool_release(p, small, 1000);
    wg__mempool_close(p);
    memset(b, 4, 2 * MIB);
    wg__mempool_release(p, b, 2 * MIB); /* after close: the last reference */
}

/* An image outlives its engine: its buffer goes back to the system when it is freed. */
static void test_outlives_engine(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(mixed_xml(64));
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = render_on(e, g);
    wg_engine_free(e);
    assert_true(wg_result_output_count(res) == 5);
    wgt_assert_range(wg_result_output_image(res, 1), 0, 1);
    wg_result_free(res);
    wg_graph_free(g);
}

/* ---- reuse and determinism --------------------------------------------------------------- */

static void reuse_run(const WgGraph *g, const WgResult *ref, bool memory_cache, int threads)
{
    wg__mempool_set_poison(true);
    WgEngineOptions opt = {threads, 0, NULL, !memory_cache};
    WgEngine *e = NULL;
    WgError err = {0};
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    WgMemoryStats s1, s2;
    WgResult *first = render_on(e, g);
    assert_results_identical(ref, first);
    wg_result_free(first);
    wg_engine_memory_stats(e, &s1);
    assert_true(s1.pool_hits > 0); /* intermediates freed during the render were reused */
    assert_true(s1.pool_bytes > 0);
    /* a second render of the same request takes its buffers from the pool. The order of frees
     * and allocations can follow the machine's load (worker threads, the budget's waits), so
     * more buffers of a class can be live at once than in the first render: at least three in
     * four come from the pool */
    wg_engine_clear_cache(e);
    WgResult *second = render_on(e, g);
    wg_engine_memory_stats(e, &s2);
    wg__mempool_set_poison(false);
    assert_results_identical(ref, second);
    uint64_t fresh = s2.pool_misses - s1.pool_misses;
    uint64_t asked = fresh + (s2.pool_hits - s1.pool_hits);
    if (fresh * 4 > asked)
        fail_msg("%d threads: the second render took %llu new buffers of %llu", threads,
                 (unsigned long long)fresh, (unsigned long long)asked);
    assert_true(s2.pool_hits > s1.pool_hits);
    wg_result_free(second);
    wg_engine_free(e);
}

static void test_reuse_identical(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(mixed_xml(512));
    WgEngine *e1 = wgt_engine(1, 0, NULL);
    WgResult *ref = render_on(e1, g);
    wg_engine_free(e1);
    for (int threads = 1; threads <= 2; threads++) {
        reuse_run(g, ref, true, threads);
        reuse_run(g, ref, false, threads);
    }
    wg_result_free(ref);
    wg_graph_free(g);
}

/* ---- the budget -------------------------------------------------------------------------- */

typedef struct {
    WgEngine *e;
    size_t budget, worst;
} Watch;

static void watch_progress(void *user, int done, int total, const char *id)
{
    (void)done;
    (void)total;
    (void)id;
    Watch *w = user;
    WgMemoryStats s;
    wg_engine_memory_stats(w->e, &s);
    if (s.pool_bytes > w->worst) w->worst = s.pool_bytes;
}

/* A chain of point nodes at 512² gray (1 MiB each) in a budget of 6 MiB: a render needs two
 * images at once, so the cache and the pool share 4 MiB. The pool never holds more than the
 * budget leaves, and after the render it holds at most what the result leaves. Without the
 * memory cache, intermediates are freed after their last consumer and their buffers reused. */
static void budget_run(bool memory_cache)
{
    char xml[4096];
    int at = snprintf(xml, sizeof xml,
                      "<wetgraph version=\"1\" size=\"512\">\n"
                      "  <node id=\"n0\" type=\"gradient\"/>\n");
    for (int i = 1; i < 12; i++)
        at += snprintf(xml + at, sizeof xml - (size_t)at,
                       "  <node id=\"n%d\" type=\"%s\"><in name=\"source\" from=\"n%d\"/></node>\n",
                       i, i % 2 ? "invert" : "levels", i - 1);
    snprintf(xml + at, sizeof xml - (size_t)at,
             "  <output name=\"out\" from=\"n11\"/>\n</wetgraph>\n");
    WgGraph *g = wgt_load(xml);
    size_t budget = 6 * MIB;
    /* unfused: the chain's intermediates are whole images whose buffers the pool passes on */
    WgEngineOptions opt = {2, budget, NULL, !memory_cache, true};
    Watch w = {NULL, budget, 0};
    WgError err = {0};
    assert_int_equal(wg_engine_new(&opt, &w.e, &err), WG_OK);
    for (int round = 0; round < 2; round++) {
        WgRequest *r = wg_request_new(g);
        wg_request_set_progress(r, watch_progress, &w);
        WgResult *res = wgt_render_request(w.e, r);
        assert_true(wg_result_peak_bytes(res) <= budget);
        WgMemoryStats s;
        wg_engine_memory_stats(w.e, &s);
        size_t kept = wg_image_bytes(wg_result_output_image(res, 0));
        if (s.pool_bytes + kept > budget)
            fail_msg("after the render the pool holds %zu bytes beside the %zu of the result, "
                     "budget %zu",
                     s.pool_bytes, kept, budget);
        /* two images are live at once; the other 4 MiB are shared by cache and pool */
        if (w.worst > budget - 2 * MIB)
            fail_msg("the pool held %zu bytes during the render, budget %zu", w.worst, budget);
        if (!memory_cache) {
            /* each node but the first two takes the buffer of the node two before it */
            if (s.pool_hits < (uint64_t)(round + 1) * 9)
                fail_msg("%llu pool hits after render %d", (unsigned long long)s.pool_hits,
                         round + 1);
        }
        wg_result_free(res);
        wg_request_free(r);
        wg_engine_clear_cache(w.e);
    }
    wg_engine_free(w.e);
    wg_graph_free(g);
}

static void test_budget_counts_pool(void **state)
{
    (void)state;
    budget_run(true);
    budget_run(false);
}

/* ---- allocation failures ----------------------------------------------------------------- */

static atomic_long n_allocs, n_live, fail_at = -1;

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

/* Two renders on one engine (the second after clearing the cache, so its buffers come from
 * the pool) with allocation k and every later one failing. Each render must fail with
 * WG_ERR_NOMEM or equal the reference. Returns the allocations made. */
static long render_twice_failing(const WgGraph *g, long k, const WgResult *ref)
{
    atomic_store(&n_allocs, 0);
    atomic_store(&n_live, 0);
    atomic_store(&fail_at, k);
    wg_set_allocator(hook_alloc, hook_free, NULL);
    WgEngineOptions opt = {2, 0, NULL};
    WgEngine *e = NULL;
    WgError err = {0};
    int rc = wg_engine_new(&opt, &e, &err);
    for (int round = 0; !rc && round < 2; round++) {
        WgRequest *r = wg_request_new(g);
        WgResult *res = NULL;
        memset(&err, 0, sizeof err);
        rc = r ? wg_render(e, r, &res, &err) : WG_ERR_NOMEM;
        if (!rc && ref) assert_results_identical(ref, res);
        wg_result_free(res);
        wg_request_free(r);
        wg_engine_clear_cache(e);
    }
    wg_engine_free(e);
    long made = atomic_load(&n_allocs), live = atomic_load(&n_live);
    wg_set_allocator(NULL, NULL, NULL);
    atomic_store(&fail_at, -1);
    if (rc && rc != WG_ERR_NOMEM)
        fail_msg("failure at allocation %ld gave status %d: %s", k, rc, err.message);
    if (live != 0) fail_msg("failure at allocation %ld leaks %ld blocks", k, live);
    return made;
}

static void test_alloc_failures(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(mixed_xml(24));
    WgResult *ref = wgt_render(g, 1);
    long total = render_twice_failing(g, -1, ref);
    assert_true(total > 10);
    /* every failure point; the count varies a little with the schedule, so go beyond it */
    for (long k = 0; k < total + 20; k++) render_twice_failing(g, k, ref);
    wg_result_free(ref);
    wg_graph_free(g);
}

/* wg_engine_trim: with room for nothing, every cached image goes (the next render computes
 * every node again, to the same pixels) and the pool gives back every idle buffer; with room
 * for everything, nothing goes. */
static void test_trim(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(mixed_xml(128));
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *first = render_on(e, g);
    int all = wg_result_evaluated_count(first);
    assert_true(all > 10);
    wg_engine_trim(e, SIZE_MAX, SIZE_MAX);
    WgResult *res = render_on(e, g);
    assert_int_equal(wg_result_evaluated_count(res), 0); /* all kept */
    wg_result_free(res);
    wg_engine_trim(e, 0, 0);
    WgMemoryStats m;
    wg_engine_memory_stats(e, &m);
    assert_int_equal(m.pool_bytes, 0);
    assert_int_equal(m.pool_buffers, 0);
    res = render_on(e, g);
    assert_int_equal(wg_result_evaluated_count(res), all);
    assert_results_identical(first, res);
    wg_result_free(res);
    wg_result_free(first);
    wg_engine_free(e);
    wg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_classes),         cmocka_unit_test(test_outlives_engine),
        cmocka_unit_test(test_reuse_identical), cmocka_unit_test(test_budget_counts_pool),
        cmocka_unit_test(test_alloc_failures),  cmocka_unit_test(test_trim),
        cmocka_unit_test(test_split),           cmocka_unit_test(test_release),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
