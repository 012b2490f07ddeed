/* SPDX-License-Identifier: MIT */
/* Outputs handed over while the render runs (wg_request_set_output_fn): every requested output
 * reaches the output function exactly once, with the image, name, format and colour space a
 * render without it gives, at any thread count and also when the output comes from the memory
 * cache; the result then holds no output images, and the engine lets go of each output once it
 * has been handed over, so a chain of outputs needs the memory of a few images, not of all;
 * pictures read from files wait until a job needs them, also on several workers; an
 * output function that fails makes the render fail with its error, and with one worker no later
 * node runs and no later output is handed over; work an output function splits in parts
 * (WgOutputInfo.workers) runs each part once, and idle workers take parts too, also when the
 * render is cancelled meanwhile (it then ends cancelled, not failed). */
#include "wgtest.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define CHAIN 8

/* a pattern, then a chain of blurs; every node is an output, in several formats and spaces */
static char *chain_graph(int w, int h)
{
    char *xml = malloc(8192);
    assert_non_null(xml);
    int n = snprintf(xml, 8192,
                     "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"9\">\n"
                     "  <node id=\"n0\" type=\"pixel\" expr=\"fract(u * 3 + y * 0.01) * v\"/>\n",
                     w, h);
    for (int i = 1; i < CHAIN; i++)
        n += snprintf(xml + n, 8192 - (size_t)n,
                      "  <node id=\"n%d\" type=\"blur\" sigma=\"%d\"><in name=\"source\" "
                      "from=\"n%d\"/></node>\n",
                      i, i, i - 1);
    static const char *const fmt[] = {"png16", "png", "exr", "exr32"};
    for (int i = 0; i < CHAIN; i++)
        n += snprintf(xml + n, 8192 - (size_t)n,
                      "  <output name=\"o%d\" from=\"n%d\" format=\"%s\"%s/>\n", i, i, fmt[i % 4],
                      i % 3 == 1 ? " colorspace=\"srgb\"" : "");
    snprintf(xml + n, 8192 - (size_t)n, "</wetgraph>\n");
    return xml;
}

typedef struct {
    atomic_int calls[CHAIN];
    WgImage *images[CHAIN];
    WgOutputInfo info[CHAIN];
    int fail_at; /* output index whose call fails; -1: none */
} Seen;

static WgImage *copy_image(const WgImage *src)
{
    WgImage *c = wg_image_new(src->width, src->height, src->channels);
    assert_non_null(c);
    for (int y = 0; y < src->height; y++)
        memcpy(wg_image_row(c, y), wg_image_row(src, y),
               (size_t)src->width * (size_t)src->channels * sizeof(float));
    return c;
}

static int take_output(void *user, const WgOutputInfo *out, WgError *err)
{
    Seen *s = user;
    int i = out->index;
    if (atomic_fetch_add(&s->calls[i], 1) == 0) {
        s->info[i] = *out;
        s->images[i] = copy_image(out->image); /* the image is borrowed for the call only */
    }
    if (i == s->fail_at)
        return wg_error_set_at(err, WG_ERR_IO, "o.png", 0, 0, "the disk refused output %d", i);
    return WG_OK;
}

static void seen_init(Seen *s, int fail_at)
{
    memset(s, 0, sizeof *s);
    for (int i = 0; i < CHAIN; i++) atomic_init(&s->calls[i], 0);
    s->fail_at = fail_at;
}

static void seen_free(Seen *s)
{
    for (int i = 0; i < CHAIN; i++) wg_image_unref(s->images[i]);
}

/* Each output once, the same as the result of a render without an output function. */
static void expect_handed_over(const Seen *s, const WgResult *plain, const WgResult *streamed)
{
    assert_int_equal(wg_result_output_count(streamed), CHAIN);
    for (int i = 0; i < CHAIN; i++) {
        assert_int_equal(atomic_load(&s->calls[i]), 1);
        assert_int_equal(s->info[i].index, i);
        assert_string_equal(wg_result_output_name(streamed, i), wg_result_output_name(plain, i));
        assert_int_equal(s->info[i].format, wg_result_output_format(plain, i));
        assert_int_equal(s->info[i].colorspace, wg_result_output_colorspace(plain, i));
        wgt_assert_identical(s->images[i], wg_result_output_image(plain, i));
        assert_null(wg_result_output_image(streamed, i));
    }
}

static void test_every_output_is_handed_over_once(void **state)
{
    (void)state;
    static const int sizes[][2] = {{37, 23}, {64, 64}, {5, 131}};
    for (int v = 0; v < 3; v++) {
        char *xml = chain_graph(sizes[v][0], sizes[v][1]);
        WgGraph *g = wgt_load(xml);
        WgResult *plain = wgt_render(g, 2);
        static const int threads[] = {1, 2, 4};
        for (int t = 0; t < 3; t++) {
            WgEngine *e = wgt_engine(threads[t], 0, NULL);
            WgRequest *r = wg_request_new(g);
            assert_non_null(r);
            Seen s;
            seen_init(&s, -1);
            wg_request_set_output_fn(r, take_output, &s);
            WgResult *res = wgt_render_request(e, r);
            expect_handed_over(&s, plain, res);
            wg_result_free(res);
            seen_free(&s);
            /* again on the same engine: every output now comes from the memory cache */
            seen_init(&s, -1);
            res = wgt_render_request(e, r);
            assert_int_equal(wg_result_evaluated_count(res), 0);
            expect_handed_over(&s, plain, res);
            wg_result_free(res);
            seen_free(&s);
            wg_request_free(r);
            wg_engine_free(e);
        }
        wg_result_free(plain);
        wg_graph_free(g);
        free(xml);
    }
}

static void test_outputs_are_let_go_once_handed_over(void **state)
{
    (void)state;
    char *xml = chain_graph(160, 120);
    WgGraph *g = wgt_load(xml);
    size_t image = wg_image_bytes_for(160, 120, 1);
    WgEngineOptions opt = {1, 0, NULL, true, false}; /* one worker, no memory cache */
    WgEngine *e = NULL;
    WgError err = {0};
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgResult *plain = wgt_render_request(e, r);
    Seen s;
    seen_init(&s, -1);
    wg_request_set_output_fn(r, take_output, &s);
    WgResult *res = wgt_render_request(e, r);
    expect_handed_over(&s, plain, res);
    /* kept for the result: all eight outputs at the end; handed over: the blur's input and
     * output, its scratch, and at most one output being handed over */
    size_t kept = wg_result_peak_bytes(plain), streamed = wg_result_peak_bytes(res);
    if (kept < CHAIN * image || streamed > 4 * image)
        fail_msg("peak %zu bytes kept, %zu streamed; an image is %zu", kept, streamed, image);
    wg_result_free(plain);
    wg_result_free(res);
    seen_free(&s);
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
    free(xml);
}

static void test_failing_output_fails_the_render(void **state)
{
    (void)state;
    char *xml = chain_graph(40, 30);
    WgGraph *g = wgt_load(xml);
    static const int threads[] = {1, 3};
    for (int t = 0; t < 2; t++) {
        WgEngine *e = wgt_engine(threads[t], 0, NULL);
        WgRequest *r = wg_request_new(g);
        assert_non_null(r);
        Seen s;
        seen_init(&s, 3);
        wg_request_set_output_fn(r, take_output, &s);
        WgResult *res = NULL;
        WgError err = {0};
        assert_int_equal(wg_render(e, r, &res, &err), WG_ERR_IO);
        assert_null(res);
        wgt_assert_error(&err, WG_ERR_IO, 0, "o.png|the disk refused output 3");
        for (int i = 0; i <= 3; i++) assert_int_equal(atomic_load(&s.calls[i]), 1);
        if (threads[t] == 1) /* the next node was queued behind the failing call: skipped */
            for (int i = 4; i < CHAIN; i++) assert_int_equal(atomic_load(&s.calls[i]), 0);
        seen_free(&s);
        /* the engine renders the request again once the output function succeeds */
        seen_init(&s, -1);
        WgResult *plain = wgt_render(g, 1);
        res = wgt_render_request(e, r);
        expect_handed_over(&s, plain, res);
        wg_result_free(res);
        wg_result_free(plain);
        seen_free(&s);
        wg_request_free(r);
        wg_engine_free(e);
    }
    wg_graph_free(g);
    free(xml);
}

/* Four pictures read from files (serial source jobs, which may start beside others), each only
 * inverted and handed over. In plan order (the graph's inputs first) all four would be read
 * before the first is inverted; the render reads each one when it is needed, and the jobs that
 * could start early do not take it past what the render in that order needs. */
static void test_sources_wait_until_they_are_needed(void **state)
{
    (void)state;
    static const int sizes[][2] = {{128, 96}, {71, 130}};
    for (int v = 0; v < 2; v++) {
        int w = sizes[v][0], h = sizes[v][1];
        WgError err = {0};
        for (int i = 0; i < 4; i++) { /* four different files: four different nodes */
            WgImage *pic = wgt_image(w, h, 1, NULL);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++)
                    wg_image_row(pic, y)[x] = (float)((x * 3 + y * 5 + i) % 17) / 16;
            char name[32];
            snprintf(name, sizeof name, "pic%d.png", i);
            assert_int_equal(wg_image_write(wgt_path(name), pic, WG_FORMAT_PNG16, WG_LINEAR, &err),
                             WG_OK);
            wg_image_unref(pic);
        }
        char xml[2048];
        int n = snprintf(xml, sizeof xml, "<wetgraph version=\"1\" size=\"%dx%d\">\n", w, h);
        for (int i = 0; i < 4; i++)
            n += snprintf(xml + n, sizeof xml - (size_t)n,
                          "  <input name=\"p%d\" type=\"gray\"/>\n", i);
        for (int i = 0; i < 4; i++)
            n += snprintf(xml + n, sizeof xml - (size_t)n,
                          "  <node id=\"i%d\" type=\"invert\"><in name=\"source\" "
                          "from=\"$p%d\"/></node>\n",
                          i, i);
        for (int i = 0; i < 4; i++)
            n += snprintf(xml + n, sizeof xml - (size_t)n,
                          "  <output name=\"o%d\" from=\"i%d\" format=\"png16\"/>\n", i, i);
        snprintf(xml + n, sizeof xml - (size_t)n, "</wetgraph>\n");
        WgGraph *g = wgt_load_at(xml, wgt_path("pics.wetgraph"));
        size_t image = wg_image_bytes_for(w, h, 1);
        for (int threads = 1; threads <= 4; threads += 3) {
            WgEngineOptions opt = {threads, 0, NULL, true, true}; /* unfused: whole images */
            WgEngine *e = NULL;
            assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
            WgRequest *r = wg_request_new(g);
            assert_non_null(r);
            for (int i = 0; i < 4; i++) {
                char name[8], file[32];
                snprintf(name, sizeof name, "p%d", i);
                snprintf(file, sizeof file, "pic%d.png", i);
                assert_int_equal(wg_request_set_input_file(r, name, wgt_path(file), &err), WG_OK);
            }
            Seen s;
            seen_init(&s, -1);
            wg_request_set_output_fn(r, take_output, &s);
            WgResult *res = wgt_render_request(e, r);
            for (int i = 0; i < 4; i++) assert_int_equal(atomic_load(&s.calls[i]), 1);
            /* a picture and its inverse, a picture's decoding scratch, one output being handed
             * over: never four pictures */
            if (wg_result_peak_bytes(res) > 3 * image + image / 2)
                fail_msg("%dx%d, %d threads: peak %zu bytes; a picture is %zu", w, h, threads,
                         wg_result_peak_bytes(res), image);
            wg_result_free(res);
            seen_free(&s);
            wg_request_free(r);
            wg_engine_free(e);
        }
        wg_graph_free(g);
    }
}

/* A colour image made early from a small source waits for a consumer whose other input, a
 * picture, comes last; meanwhile another picture's branch runs. Making it just before its
 * consumer instead holds one colour image less through that branch. */
static const char *const near_graph =
    "<wetgraph version=\"1\" size=\"%dx%d\">\n"
    "  <input name=\"b\" type=\"color\"/>\n"
    "  <input name=\"n\" type=\"color\"/>\n"
    "  <node id=\"g\" type=\"pixel\" expr=\"u * v\"/>\n"
    "  <node id=\"wc\" type=\"pixel\" kind=\"color\" expr=\"rgb(g, 1 - g, g * g)\">"
    "<in name=\"g\" from=\"g\"/></node>\n"
    "  <node id=\"uc\" type=\"pixel\" kind=\"color\" expr=\"b * 0.5\">"
    "<in name=\"b\" from=\"$b\"/></node>\n"
    "  <node id=\"a\" type=\"pixel\" expr=\"c.r + c.g\"><in name=\"c\" from=\"uc\"/></node>\n"
    "  <node id=\"f\" type=\"pixel\" expr=\"m.r * n.g\"><in name=\"m\" from=\"wc\"/>"
    "<in name=\"n\" from=\"$n\"/></node>\n"
    "  <output name=\"u\" from=\"uc\" format=\"png\"/>\n"
    "  <output name=\"a\" from=\"a\" format=\"png16\"/>\n"
    "  <output name=\"f\" from=\"f\" format=\"png16\"/>\n"
    "</wetgraph>\n";

static void test_images_are_made_when_their_consumer_is_near(void **state)
{
    (void)state;
    static const int sizes[][2] = {{64, 48}, {33, 70}};
    for (int v = 0; v < 2; v++) {
        int w = sizes[v][0], h = sizes[v][1];
        WgError err = {0};
        for (int i = 0; i < 2; i++) {
            WgImage *pic = wgt_image(w, h, 4, NULL);
            for (int y = 0; y < h; y++)
                for (int x = 0; x < 4 * w; x++)
                    wg_image_row(pic, y)[x] = (float)((x * 7 + y * 3 + i) % 13) / 12;
            char name[32];
            snprintf(name, sizeof name, "col%d.png", i);
            assert_int_equal(wg_image_write(wgt_path(name), pic, WG_FORMAT_PNG, WG_LINEAR, &err),
                             WG_OK);
            wg_image_unref(pic);
        }
        char xml[2048];
        snprintf(xml, sizeof xml, near_graph, w, h);
        WgGraph *g = wgt_load_at(xml, wgt_path("near.wetgraph"));
        size_t colour = wg_image_bytes_for(w, h, 4);
        WgEngineOptions opt = {1, 0, NULL, true, true}; /* one worker, unfused */
        WgEngine *e = NULL;
        assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
        WgRequest *r = wg_request_new(g);
        assert_non_null(r);
        assert_int_equal(wg_request_set_input_file(r, "b", wgt_path("col0.png"), &err), WG_OK);
        assert_int_equal(wg_request_set_input_file(r, "n", wgt_path("col1.png"), &err), WG_OK);
        Seen s;
        seen_init(&s, -1);
        wg_request_set_output_fn(r, take_output, &s);
        WgResult *res = wgt_render_request(e, r);
        for (int i = 0; i < 3; i++) assert_int_equal(atomic_load(&s.calls[i]), 1);
        /* two colour images and a few gray ones at once (a picture and its half, or the made
         * colour image and the last picture), never three colour images */
        if (wg_result_peak_bytes(res) > 2 * colour + colour / 2 + colour / 8)
            fail_msg("%dx%d: peak %zu bytes; a colour image is %zu", w, h,
                     wg_result_peak_bytes(res), colour);
        wg_result_free(res);
        seen_free(&s);
        wg_request_free(r);
        wg_engine_free(e);
        wg_graph_free(g);
    }
}

/* Parts of an output function's work: each marks its indices and the thread it ran on. */
#define PARTS 48
typedef struct {
    atomic_int hits[PARTS];
    pthread_t ran_on[PARTS];
} Parts;

static void mark_parts(void *user, int i0, int i1)
{
    Parts *p = user;
    for (int i = i0; i < i1; i++) {
        atomic_fetch_add(&p->hits[i], 1);
        p->ran_on[i] = pthread_self();
        nanosleep(&(struct timespec){0, 2000000}, NULL); /* 2 ms: long enough to share */
    }
}

static atomic_int split_outputs, shared_outputs;

static int split_output(void *user, const WgOutputInfo *out, WgError *err)
{
    (void)user;
    (void)err;
    Parts p;
    for (int i = 0; i < PARTS; i++) atomic_init(&p.hits[i], 0);
    assert_non_null(out->workers.run);
    assert_int_equal(out->workers.run(out->workers.ctx, PARTS, mark_parts, &p), 0);
    bool shared = false;
    for (int i = 0; i < PARTS; i++) {
        assert_int_equal(atomic_load(&p.hits[i]), 1);
        shared |= !pthread_equal(p.ran_on[i], p.ran_on[0]);
    }
    atomic_fetch_add(&split_outputs, 1);
    atomic_fetch_add(&shared_outputs, shared);
    return WG_OK;
}

static void test_output_work_runs_on_the_workers(void **state)
{
    (void)state;
    char *xml = chain_graph(32, 32);
    WgGraph *g = wgt_load(xml);
    for (int threads = 1; threads <= 2; threads++) {
        WgEngine *e = wgt_engine(threads, 0, NULL);
        WgRequest *r = wg_request_new(g);
        assert_non_null(r);
        atomic_store(&split_outputs, 0);
        atomic_store(&shared_outputs, 0);
        wg_request_set_output_fn(r, split_output, NULL);
        WgResult *res = wgt_render_request(e, r);
        assert_int_equal(atomic_load(&split_outputs), CHAIN);
        /* one worker: all on it; two: the last output's parts at least, with nothing else
         * left to run, are shared */
        if (threads == 1)
            assert_int_equal(atomic_load(&shared_outputs), 0);
        else
            assert_true(atomic_load(&shared_outputs) >= 1);
        wg_result_free(res);
        wg_request_free(r);
        wg_engine_free(e);
    }
    wg_graph_free(g);
    free(xml);
}

/* An output call whose render is cancelled while its parts run: every part still runs once and
 * run() says so; the render ends cancelled, not failed. */
typedef struct {
    WgCancel *cancel;
    atomic_int calls, stopped, missed;
} CancelSeen;

static int cancel_then_split(void *user, const WgOutputInfo *out, WgError *err)
{
    (void)err;
    CancelSeen *c = user;
    if (atomic_fetch_add(&c->calls, 1) == 0) wg_cancel_request(c->cancel);
    Parts p;
    for (int i = 0; i < PARTS; i++) atomic_init(&p.hits[i], 0);
    if (out->workers.run(out->workers.ctx, PARTS, mark_parts, &p)) atomic_fetch_add(&c->stopped, 1);
    for (int i = 0; i < PARTS; i++) atomic_fetch_add(&c->missed, atomic_load(&p.hits[i]) != 1);
    return WG_OK;
}

static void test_output_work_finishes_in_a_cancelled_render(void **state)
{
    (void)state;
    char *xml = chain_graph(32, 32);
    WgGraph *g = wgt_load(xml);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    CancelSeen c = {.cancel = wg_cancel_new()};
    assert_non_null(c.cancel);
    wg_request_set_cancel(r, c.cancel);
    wg_request_set_output_fn(r, cancel_then_split, &c);
    WgResult *res = NULL;
    WgError err = {0};
    int rc = wg_render(e, r, &res, &err);
    if (rc != WG_ERR_CANCELLED)
        fail_msg("render returned %d (%s), expected WG_ERR_CANCELLED", rc, err.message);
    assert_true(atomic_load(&c.calls) >= 1);
    assert_int_equal(atomic_load(&c.stopped), 0);
    assert_int_equal(atomic_load(&c.missed), 0);
    wg_request_free(r);
    wg_cancel_free(c.cancel);
    wg_engine_free(e);
    wg_graph_free(g);
    free(xml);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_output_is_handed_over_once),
        cmocka_unit_test(test_outputs_are_let_go_once_handed_over),
        cmocka_unit_test(test_failing_output_fails_the_render),
        cmocka_unit_test(test_sources_wait_until_they_are_needed),
        cmocka_unit_test(test_images_are_made_when_their_consumer_is_near),
        cmocka_unit_test(test_output_work_runs_on_the_workers),
        cmocka_unit_test(test_output_work_finishes_in_a_cancelled_render),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
