/* SPDX-License-Identifier: MIT */
/* The scheduler: bit-identical results for any thread count, only the nodes the requested
 * outputs need are evaluated, a failing node stops the render with its id and location (for any
 * thread count, without crashing or leaking), the memory budget is checked before anything runs,
 * and the reported peak memory is plausible. Row-parallel nodes run one at a time (each on every
 * worker) while serial ones (WG_NODE_SERIAL) run beside them. */
#include "wgtest.h"

#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Several independent branches (two blurs, levels, invert, grayscale) meeting in a masked
 * blend, a resampled blur, a node nothing uses, and a branch that only feeds one output. */
static const char *const branches_xml =
    "<wetgraph version=\"1\" size=\"48x40\">\n" /* 1 */
    "  <input name=\"src\" type=\"color\"/>\n"  /* 2 */
    "  <input name=\"h\" type=\"gray\"/>\n"     /* 3 */
    "  <node id=\"blur_a\" type=\"blur\" sigma=\"1.5\"><in name=\"source\" from=\"$src\"/></node>\n"
    "  <node id=\"lev_a\" type=\"levels\" in_low=\"0.1\" in_high=\"0.8\" in_mid=\"0.3\">"
    "<in name=\"source\" from=\"blur_a\"/></node>\n"
    "  <node id=\"blur_b\" type=\"blur\" sigma=\"3\"><in name=\"source\" from=\"$h\"/></node>\n"
    "  <node id=\"inv_b\" type=\"invert\"><in name=\"source\" from=\"blur_b\"/></node>\n"
    "  <node id=\"gray_c\" type=\"grayscale\"><in name=\"source\" from=\"$src\"/></node>\n"
    "  <node id=\"lev_c\" type=\"levels\" in_low=\"0.9\" in_high=\"0.2\">"
    "<in name=\"source\" from=\"gray_c\"/></node>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"overlay\" opacity=\"0.7\">"
    "<in name=\"foreground\" from=\"lev_a\"/><in name=\"background\" from=\"inv_b\"/>"
    "<in name=\"mask\" from=\"lev_c\"/></node>\n"
    "  <node id=\"small\" type=\"blur\" sigma=\"0.7\" size=\"24x20\">"
    "<in name=\"source\" from=\"mix\"/></node>\n"
    "  <node id=\"tint\" type=\"uniform\" kind=\"color\" color=\"#80a0ff\"/>\n"
    "  <node id=\"tinted\" type=\"blend\" mode=\"multiply\" clamp=\"false\">"
    "<in name=\"foreground\" from=\"tint\"/><in name=\"background\" from=\"blur_a\"/></node>\n"
    "  <node id=\"dead\" type=\"blur\" sigma=\"5\"><in name=\"source\" from=\"$src\"/></node>\n"
    "  <output name=\"mix\" from=\"mix\"/>\n"
    "  <output name=\"a\" from=\"lev_a\"/>\n"
    "  <output name=\"b\" from=\"inv_b\"/>\n"
    "  <output name=\"small\" from=\"small\"/>\n"
    "  <output name=\"tinted\" from=\"tinted\"/>\n"
    "</wetgraph>\n";

static double src_fn(int x, int y, int k)
{
    if (k == 3) return 0.5 + 0.5 * sin(x * 0.3 + y * 0.11);
    return 0.5 + 0.45 * sin(x * 0.37 + y * 0.23 * (k + 1) + k) * cos(y * 0.19 - x * 0.05 * k);
}

static double h_fn(int x, int y, int k)
{
    (void)k;
    return fmod(x * 0.137 + y * y * 0.0173, 1.0) * 1.5 - 0.2;
}

static WgRequest *branches_request(const WgGraph *g)
{
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgImage *src = wgt_image_fn(48, 40, 4, src_fn);
    WgImage *h = wgt_image_fn(48, 40, 1, h_fn);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "src", src, &err), WG_OK);
    assert_int_equal(wg_request_set_input_image(r, "h", h, &err), WG_OK);
    wg_image_unref(src);
    wg_image_unref(h);
    return r;
}

static void test_output_is_identical_for_any_thread_count(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(branches_xml);
    WgRequest *r = branches_request(g);
    static const int threads[] = {1, 2, 3, 8};
    WgResult *ref = NULL;
    for (int t = 0; t < 4; t++) {
        for (int repeat = 0; repeat < 3; repeat++) {
            WgEngine *e = wgt_engine(threads[t], 0, NULL);
            WgResult *res = wgt_render_request(e, r);
            assert_int_equal(wg_result_output_count(res), 5);
            assert_int_equal(wg_result_evaluated_count(res), 12);
            if (!ref) {
                ref = res;
            } else {
                for (int i = 0; i < 5; i++) {
                    assert_string_equal(wg_result_output_name(res, i),
                                        wg_result_output_name(ref, i));
                    wgt_assert_identical(wg_result_output_image(res, i),
                                         wg_result_output_image(ref, i));
                }
                wg_result_free(res);
            }
            wg_engine_free(e);
        }
    }
    /* the outputs are not trivial: the branches really computed something */
    const WgImage *mix = wgt_output(ref, "mix");
    assert_int_equal(mix->channels, 4);
    assert_true(wgt_max_abs_diff(mix, wgt_output(ref, "a")) > 0.05);
    const WgImage *small = wgt_output(ref, "small");
    assert_int_equal(small->width, 24);
    assert_int_equal(small->height, 20);
    const WgImage *b = wgt_output(ref, "b");
    assert_int_equal(b->channels, 1);
    wgt_assert_range(b, -1, 1.3);
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_only_needed_nodes_run(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(branches_xml);
    WgRequest *r = branches_request(g);
    WgError err = {0};
    assert_int_equal(wg_request_add_output(r, "b", &err), WG_OK);
    WgEngine *e = wgt_engine(4, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    assert_int_equal(wg_result_output_count(res), 1);
    assert_string_equal(wg_result_output_name(res, 0), "b");
    /* the input image, its blur and the invert: nothing of the colour branches */
    assert_int_equal(wg_result_evaluated_count(res), 3);
    assert_int_equal(wg_result_stat_count(res), 3);
    static const char *const ids[] = {"$h", "blur_b", "inv_b"};
    for (int i = 0; i < 3; i++) {
        const WgNodeStat *s = wgt_stat(res, ids[i]);
        if (!s) fail_msg("no stat for %s", ids[i]);
        assert_int_equal(s->cache, WG_COMPUTED);
        assert_int_equal(s->width, 48);
        assert_int_equal(s->height, 40);
        assert_int_equal(s->channels, 1);
        assert_true(s->bytes >= 48 * 40 * sizeof(float));
    }
    assert_string_equal(wgt_stat(res, "blur_b")->type, "blur");
    assert_null(wgt_stat(res, "dead"));
    assert_null(wgt_stat(res, "blur_a"));
    wg_result_free(res);
    wg_request_free(r);

    /* every output: all but the unused node */
    r = branches_request(g);
    wg_engine_clear_cache(e);
    res = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(res), 12);
    assert_int_equal(wg_result_stat_count(res), 12);
    assert_null(wgt_stat(res, "dead"));
    assert_non_null(wgt_stat(res, "tint"));
    assert_string_equal(wgt_stat(res, "tint")->type, "uniform");
    assert_int_equal(wgt_stat(res, "small")->width, 24);
    assert_int_equal(wgt_stat(res, "mix")->channels, 4);
    wg_result_free(res);
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
}

static void test_broken_unused_node_is_never_resolved(void **state)
{
    (void)state;
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"8\">\n"
                          "  <node id=\"ok\" type=\"uniform\" value=\"0.25\"/>\n"
                          "  <node id=\"broken\" type=\"image\" path=\"no_such_file.png\"/>\n"
                          "  <output name=\"out\" from=\"ok\"/>\n"
                          "  <output name=\"bad\" from=\"broken\"/>\n"
                          "</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    assert_int_equal(wg_request_add_output(r, "out", &err), WG_OK);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(res), 1);
    assert_true(wgt_px(wg_result_output_image(res, 0), 7, 7, 0) == 0.25f);
    wg_result_free(res);
    wg_request_free(r);
    /* asking for it fails with its location */
    r = wg_request_new(g);
    assert_int_equal(wg_render(e, r, &res, &err), WG_ERR_IO);
    assert_null(res);
    wgt_assert_error(&err, WG_ERR_IO, 3, "no_such_file.png");
    wgt_assert_error(&err, WG_ERR_IO, 3, "node 'broken'");
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
}

static double noise_fn(int x, int y, int k)
{
    (void)k;
    uint32_t h = wg_hash3((uint32_t)x, (uint32_t)y, 17);
    return (h & 0xffff) / 65535.0;
}

/* A graph whose `img` node (line 2) reads `file`, beside heavier independent branches. */
static char *failing_xml(const char *file)
{
    static char xml[4096];
    snprintf(
        xml, sizeof xml,
        "<wetgraph version=\"1\" size=\"64\">\n"
        "  <node id=\"img\" type=\"image\" path=\"%s\"/>\n"
        "  <node id=\"u\" type=\"uniform\" value=\"0.5\" size=\"256\"/>\n"
        "  <node id=\"b1\" type=\"blur\" sigma=\"4\" size=\"256\"><in name=\"source\" "
        "from=\"u\"/></node>\n"
        "  <node id=\"b2\" type=\"blur\" sigma=\"6\" size=\"256\"><in name=\"source\" "
        "from=\"b1\"/></node>\n"
        "  <node id=\"b3\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"img\"/></node>\n"
        "  <node id=\"mix\" type=\"blend\" mode=\"add\"><in name=\"foreground\" from=\"b3\"/>"
        "<in name=\"background\" from=\"b2\"/></node>\n"
        "  <output name=\"mix\" from=\"mix\"/>\n"
        "  <output name=\"side\" from=\"b2\"/>\n"
        "</wetgraph>\n",
        file);
    return xml;
}

static void truncate_file(const char *path, long keep)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    char buf[1 << 16];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    assert_true((long)n > keep);
    f = fopen(path, "wb");
    fwrite(buf, 1, (size_t)keep, f);
    fclose(f);
}

static void test_failing_node_stops_the_render(void **state)
{
    (void)state;
    static const int threads[] = {1, 2, 3, 8};
    for (int variant = 0; variant < 2; variant++) {
        for (int t = 0; t < 4; t++) {
            const char *png = wgt_path("fragile.png");
            WgImage *pic = wgt_image_fn(64, 64, 1, noise_fn);
            WgError err = {0};
            assert_int_equal(wg_image_write(png, pic, WG_FORMAT_PNG16, WG_LINEAR, &err), WG_OK);
            wg_image_unref(pic);
            const char *graph_path = wgt_path("failing.wetgraph");
            WgGraph *g = wgt_load_at(failing_xml("fragile.png"), graph_path);
            WgRequest *r = wg_request_new(g);
            assert_int_equal(wg_request_check(r, &err), WG_OK);
            /* now damage the file: cut in the middle of the pixels (the header still reads),
             * or replace it with text */
            if (variant == 0)
                truncate_file(png, 2000);
            else
                wgt_write_file(png, "not an image at all\n");
            WgEngine *e = wgt_engine(threads[t], 0, NULL);
            WgResult *res = (WgResult *)(uintptr_t)1;
            memset(&err, 0, sizeof err);
            int rc = wg_render(e, r, &res, &err);
            if (rc != WG_ERR_IO) {
                char buf[2048];
                wg_error_format(&err, buf, sizeof buf);
                fail_msg("variant %d, %d threads: status %d (%s)", variant, threads[t], rc, buf);
            }
            assert_null(res);
            wgt_assert_error(&err, WG_ERR_IO, 2, "node 'img'");
            assert_string_equal(err.file, graph_path);
            assert_int_equal(err.line, 2);
            assert_non_null(strstr(err.message, "cannot read the image"));
            char buf[2048];
            wg_error_format(&err, buf, sizeof buf);
            char where[1200];
            snprintf(where, sizeof where, "%s:2: ", graph_path);
            if (strncmp(buf, where, strlen(where))) fail_msg("message starts: %s", buf);
            /* the engine is still usable: the other output renders */
            wg_request_free(r);
            r = wg_request_new(g);
            assert_int_equal(wg_request_add_output(r, "side", &err), WG_OK);
            res = wgt_render_request(e, r);
            assert_float_equal(wgt_px(wg_result_output_image(res, 0), 10, 10, 0), 0.5, 1e-6);
            wg_result_free(res);
            wg_request_free(r);
            wg_engine_free(e);
            wg_graph_free(g);
        }
    }
}

static void test_missing_input_image_file_fails_cleanly(void **state)
{
    (void)state;
    WgGraph *g =
        wgt_load("<wetgraph version=\"1\" size=\"16\">\n"
                 "  <input name=\"src\" type=\"gray\"/>\n"
                 "  <node id=\"b\" type=\"blur\"><in name=\"source\" from=\"$src\"/></node>\n"
                 "  <output name=\"out\" from=\"b\"/>\n"
                 "</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    const char *missing = wgt_path("gone.png");
    assert_int_equal(wg_request_set_input_file(r, "src", missing, &err), WG_ERR_IO);
    assert_string_equal(err.file, missing);
    /* without any image the render says which input is missing */
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = NULL;
    memset(&err, 0, sizeof err);
    assert_int_equal(wg_render(e, r, &res, &err), WG_ERR_USAGE);
    wgt_assert_error(&err, WG_ERR_USAGE, 2, "--input src=FILE");
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

/* ---- memory budget ----------------------------------------------------------------------- */

static const char *const budget_xml =
    "<wetgraph version=\"1\" size=\"64\">\n"
    "  <node id=\"small\" type=\"uniform\" value=\"0.5\"/>\n"
    "  <node id=\"big\" type=\"pixel\" kind=\"color\" expr=\"rgb(0.1, 0.2, 0.3)\" size=\"512\"/>\n"
    "  <node id=\"medium\" type=\"blur\" sigma=\"1\" size=\"256\"><in name=\"source\" "
    "from=\"big\"/></node>\n"
    "  <node id=\"down\" type=\"levels\" out_high=\"2\"><in name=\"source\" "
    "from=\"medium\"/></node>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"multiply\"><in name=\"foreground\" from=\"small\"/>"
    "<in name=\"background\" from=\"down\"/></node>\n"
    "  <output name=\"out\" from=\"mix\"/>\n"
    "</wetgraph>\n";

static void count_progress(void *user, int done, int total, const char *node)
{
    (void)done;
    (void)total;
    (void)node;
    ++*(int *)user;
}

static void test_memory_budget_fails_early(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(budget_xml);
    WgRequest *r = wg_request_new(g);
    int calls = 0;
    wg_request_set_progress(r, count_progress, &calls);
    size_t big = wg_image_bytes_for(512, 512, 4);
    assert_int_equal(big, 4u << 20);
    for (int threads = 1; threads <= 8; threads *= 8) {
        WgEngine *e = wgt_engine(threads, 1u << 20, NULL);
        assert_int_equal(wg_engine_memory_budget(e), 1u << 20);
        WgResult *res = NULL;
        WgError err = {0};
        assert_int_equal(wg_render(e, r, &res, &err), WG_ERR_BUDGET);
        assert_null(res);
        assert_non_null(strstr(err.message, "node 'big'"));
        assert_non_null(strstr(err.message, "--memory-budget"));
        assert_non_null(strstr(err.message, "budget is 1.0 MiB"));
        assert_int_equal(calls, 0); /* nothing was evaluated */
        wg_engine_free(e);
    }
    /* a budget that fits */
    WgEngine *e = wgt_engine(4, 64u << 20, NULL);
    WgResult *res = wgt_render_request(e, r);
    assert_true(calls > 0);
    assert_int_equal(wg_result_evaluated_count(res), 5);
    const WgImage *out = wg_result_output_image(res, 0);
    assert_int_equal(out->channels, 4);
    /* levels maps 0.1 to 0.2; multiplied by 0.5 */
    assert_float_equal(wgt_px(out, 3, 3, 0), 0.1, 1e-6);
    size_t peak = wg_result_peak_bytes(res), sum = 0, largest = 0;
    for (int i = 0; i < wg_result_stat_count(res); i++) {
        size_t b = wg_result_stat(res, i)->bytes;
        sum += b;
        if (b > largest) largest = b;
    }
    assert_int_equal(largest, big);
    assert_true(peak >= largest);
    /* the peak counts working memory too: medium resamples big (its horizontal pass, 256x512,
     * and the result) and blurs through an image of its own */
    size_t work = wg_image_bytes_for(256, 512, 4) + 2 * wg_image_bytes_for(256, 256, 4);
    assert_true(peak <= sum + work + (64u << 10));
    /* big and medium are both alive while medium runs */
    assert_true(peak >= big + wg_image_bytes_for(256, 256, 4));
    wg_result_free(res);
    wg_engine_free(e);

    /* just enough for the sequential working set: big, medium and its working memory */
    e = wgt_engine(1, big + wg_image_bytes_for(256, 256, 4) + work + (64u << 10), NULL);
    res = wgt_render_request(e, r);
    assert_true(wg_result_peak_bytes(res) <= wg_engine_memory_budget(e));
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_peak_bytes_is_plausible(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(branches_xml);
    WgRequest *r = branches_request(g);
    for (int threads = 1; threads <= 8; threads *= 2) {
        WgEngine *e = wgt_engine(threads, 0, NULL);
        WgResult *res = wgt_render_request(e, r);
        size_t peak = wg_result_peak_bytes(res), sum = 0, largest = 0, outputs = 0;
        for (int i = 0; i < wg_result_stat_count(res); i++) {
            size_t b = wg_result_stat(res, i)->bytes;
            /* a fused intermediate is never materialised (docs/engine.md) */
            if (!wg_result_stat(res, i)->fused || b)
                assert_int_equal(b, wg_image_bytes_for(wg_result_stat(res, i)->width,
                                                       wg_result_stat(res, i)->height,
                                                       wg_result_stat(res, i)->channels));
            sum += b;
            if (b > largest) largest = b;
        }
        for (int i = 0; i < wg_result_output_count(res); i++)
            outputs += wg_image_bytes(wg_result_output_image(res, i));
        if (peak < largest || peak > sum)
            fail_msg("%d threads: peak %zu outside [%zu, %zu]", threads, peak, largest, sum);
        /* the requested outputs are all alive at the end */
        assert_true(peak >= outputs);
        wg_result_free(res);
        wg_engine_free(e);
    }
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_engine_options(void **state)
{
    (void)state;
    WgEngineOptions opt = {300, 0, NULL};
    WgEngine *e = (WgEngine *)(uintptr_t)1;
    WgError err = {0};
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_ERR_RANGE);
    assert_null(e);
    assert_non_null(strstr(err.message, "300 threads"));
    assert_int_equal(wg_engine_new(NULL, &e, &err), WG_OK);
    assert_true(wg_engine_memory_budget(e) > 0);
    assert_true(wg_engine_memory_budget(e) <= (size_t)16 << 30);
    wg_engine_free(e);
}

/* ---- progress ---------------------------------------------------------------------------- */

typedef struct {
    int calls, last_done, last_total;
} Progress;

static void slow_progress(void *user, int done, int total, const char *node)
{
    (void)node;
    Progress *p = user;
    p->calls++;
    p->last_done = done;
    p->last_total = total;
    /* give the workers time to finish more nodes while the callback runs */
    usleep(20000);
}

static void test_progress_reaches_the_total(void **state)
{
    (void)state;
    /* one source, then four independent blurs that finish while the callback sleeps */
    WgGraph *g = wgt_load(
        "<wetgraph version=\"1\" size=\"256\">\n"
        "  <node id=\"u\" type=\"uniform\" value=\"0.1\"/>\n"
        "  <node id=\"a\" type=\"blur\" sigma=\"4\"><in name=\"source\" from=\"u\"/></node>\n"
        "  <node id=\"b\" type=\"blur\" sigma=\"5\"><in name=\"source\" from=\"u\"/></node>\n"
        "  <node id=\"c\" type=\"blur\" sigma=\"6\"><in name=\"source\" from=\"u\"/></node>\n"
        "  <node id=\"d\" type=\"blur\" sigma=\"7\"><in name=\"source\" from=\"u\"/></node>\n"
        "  <output name=\"a\" from=\"a\"/>\n"
        "  <output name=\"b\" from=\"b\"/>\n"
        "  <output name=\"c\" from=\"c\"/>\n"
        "  <output name=\"d\" from=\"d\"/>\n"
        "</wetgraph>\n");
    for (int threads = 1; threads <= 4; threads *= 4) {
        WgRequest *r = wg_request_new(g);
        Progress p = {0};
        wg_request_set_progress(r, slow_progress, &p);
        WgEngine *e = wgt_engine(threads, 0, NULL);
        WgResult *res = wgt_render_request(e, r);
        assert_true(p.calls >= 1);
        assert_int_equal(p.last_total, 5);
        assert_int_equal(p.last_done, 5);
        wg_result_free(res);
        wg_engine_free(e);
        wg_request_free(r);
    }
    wg_graph_free(g);
}

/* Probes: a row-parallel node type and a serial one (WG_NODE_SERIAL), sources writing their
 * value (distinct, else equal nodes would be merged into one), that count how many of their kind
 * run at once. A serial probe waits (at most 2 s) for a second one to run beside it; a parallel one
 * lingers 5 ms so that another would show. */
static atomic_int parallel_now, parallel_most, serial_now, serial_most;

static void note(atomic_int *now, atomic_int *most)
{
    int v = atomic_fetch_add(now, 1) + 1, m = atomic_load(most);
    while (v > m && !atomic_compare_exchange_weak(most, &m, v)) {
    }
}

typedef struct {
    float value;
} ProbeParams;
static const WgParamSpec probe_params[] = {
    WG_PARAM_FLOAT(ProbeParams, value, "Value written (distinct values keep probes apart)", 0, -10,
                   10),
    WG_PARAM_END,
};

static void probe_fill(WgNodeContext *ctx)
{
    float v = ((const ProbeParams *)ctx->params)->value;
    WgImage *o = ctx->outputs[0];
    for (int y = 0; y < o->height; y++)
        for (int x = 0; x < o->width; x++) wg_image_row(o, y)[x] = v;
}

static int parallel_probe_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    note(&parallel_now, &parallel_most);
    wgt_sleep_ms(5);
    probe_fill(ctx);
    atomic_fetch_sub(&parallel_now, 1);
    return WG_OK;
}

static int serial_probe_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    note(&serial_now, &serial_most);
    for (int i = 0; i < 2000 && atomic_load(&serial_now) < 2; i++) wgt_sleep_ms(1);
    probe_fill(ctx);
    atomic_fetch_sub(&serial_now, 1);
    return WG_OK;
}

static const WgPortSpec probe_out[] = {WG_PORT("out", WG_GRAY), WG_PORT_END};
static const WgNodeType parallel_probe = {
    .name = "parallel_probe",
    .summary = "test node",
    .category = "test",
    .params = probe_params,
    .params_size = sizeof(ProbeParams),
    .outputs = probe_out,
    .flags = WG_NODE_SOURCE,
    .eval = parallel_probe_eval,
};
static const WgNodeType serial_probe = {
    .name = "serial_probe",
    .summary = "test node",
    .category = "test",
    .params = probe_params,
    .params_size = sizeof(ProbeParams),
    .outputs = probe_out,
    .flags = WG_NODE_SOURCE | WG_NODE_SERIAL,
    .eval = serial_probe_eval,
};

static void test_parallel_nodes_run_one_at_a_time(void **state)
{
    (void)state;
    static const WgNodeType *types[512];
    int n = 0;
    while (wg_node_types[n]) {
        types[n] = wg_node_types[n];
        n++;
    }
    types[n++] = &parallel_probe;
    types[n++] = &serial_probe;
    types[n] = NULL;
    wg_set_node_types(types);
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"16\">\n"
                          "  <node id=\"s1\" type=\"serial_probe\" value=\"1\"/>\n"
                          "  <node id=\"s2\" type=\"serial_probe\" value=\"2\"/>\n"
                          "  <node id=\"p1\" type=\"parallel_probe\" value=\"3\"/>\n"
                          "  <node id=\"p2\" type=\"parallel_probe\" value=\"4\"/>\n"
                          "  <node id=\"p3\" type=\"parallel_probe\" value=\"5\"/>\n"
                          "  <node id=\"p4\" type=\"parallel_probe\" value=\"6\"/>\n"
                          "  <node id=\"sum\" type=\"pixel\" expr=\"a + b + c + d + e + f\">"
                          "<in name=\"a\" from=\"s1\"/><in name=\"b\" from=\"s2\"/>"
                          "<in name=\"c\" from=\"p1\"/><in name=\"d\" from=\"p2\"/>"
                          "<in name=\"e\" from=\"p3\"/><in name=\"f\" from=\"p4\"/></node>\n"
                          "  <output name=\"out\" from=\"sum\"/>\n"
                          "</wetgraph>\n");
    for (int threads = 2; threads <= 4; threads += 2) {
        atomic_store(&parallel_most, 0);
        atomic_store(&serial_most, 0);
        WgResult *res = wgt_render(g, threads);
        assert_true(wgt_px(wgt_output(res, "out"), 3, 5, 0) == 21.0f);
        assert_int_equal(atomic_load(&parallel_most), 1);
        assert_int_equal(atomic_load(&serial_most), 2); /* both serial probes at once */
        wg_result_free(res);
    }
    wg_graph_free(g);
    wg_set_node_types(wg_node_types);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_output_is_identical_for_any_thread_count),
        cmocka_unit_test(test_only_needed_nodes_run),
        cmocka_unit_test(test_broken_unused_node_is_never_resolved),
        cmocka_unit_test(test_failing_node_stops_the_render),
        cmocka_unit_test(test_missing_input_image_file_fails_cleanly),
        cmocka_unit_test(test_memory_budget_fails_early),
        cmocka_unit_test(test_peak_bytes_is_plausible),
        cmocka_unit_test(test_engine_options),
        cmocka_unit_test(test_progress_reaches_the_total),
        cmocka_unit_test(test_parallel_nodes_run_one_at_a_time),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
