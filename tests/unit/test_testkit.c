/* SPDX-License-Identifier: MIT */
/* The node test kit holds itself to account: each check passes on a correct node and fails, with
 * a report that says where, on a node broken in the way it looks for (one that does not tile, one
 * whose result depends on the thread count, one that depends on the band it is evaluated in, one
 * off by 1e-3, one that crashes on NaN, one that overflows on huge values), so no check can pass
 * vacuously. The nodes are a program's own types, added with wg_plugin_add. */
#include "wgtest.h"

#include <math.h>
#include <signal.h>
#include <unistd.h>
#include <string.h>
#include <wetgraph/testkit.h>

typedef struct {
    float gain;
} KitParams;

static const WgParamSpec kit_params[] = {
    WG_PARAM_FLOAT(KitParams, gain, "Multiplies the input", 1, -100, 100), WG_PARAM_END};
static const WgPortSpec gray_in[] = {WG_PORT("source", WG_GRAY), WG_PORT_END};
static const WgPortSpec gray_out[] = {WG_PORT("output", WG_GRAY), WG_PORT_END};

/* 3-tap horizontal box blur times gain; `wrap` or clamped at the edges. */
static void box(WgNodeContext *ctx, bool wrap)
{
    const KitParams *p = ctx->params;
    const WgImage *in = ctx->inputs[0];
    int w = ctx->width;
    for (int y = 0; y < ctx->height; y++) {
        const float *s = wg_image_row(in, y);
        float *d = wg_image_row(ctx->outputs[0], y);
        for (int x = 0; x < w; x++) {
            int l = wrap ? (x + w - 1) % w : (x > 0 ? x - 1 : 0);
            int r = wrap ? (x + 1) % w : (x + 1 < w ? x + 1 : w - 1);
            d[x] = p->gain * (s[l] + s[x] + s[r]) / 3;
        }
    }
}

static int wrap_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    box(ctx, true);
    return WG_OK;
}

static int clamp_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    box(ctx, false);
    return WG_OK;
}

/* gain * input, plus 1e-3 */
static int off_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const KitParams *p = ctx->params;
    for (int y = 0; y < ctx->height; y++) {
        const float *s = wg_image_row(ctx->inputs[0], y);
        float *d = wg_image_row(ctx->outputs[0], y);
        for (int x = 0; x < ctx->width; x++) d[x] = p->gain * s[x] + 1e-3f;
    }
    return WG_OK;
}

/* Adds how many chunks this worker thread has done before: the same work, another answer on
 * another number of threads. Each chunk takes a millisecond, so that every worker gets some. */
static _Thread_local int chunks_done;

typedef struct {
    WgNodeContext *ctx;
} Rows;

static void threads_rows(void *user, int y0, int y1)
{
    WgNodeContext *ctx = ((Rows *)user)->ctx;
    float add = (float)chunks_done++;
    usleep(1000);
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(ctx->inputs[0], y);
        float *d = wg_image_row(ctx->outputs[0], y);
        for (int x = 0; x < ctx->width; x++) d[x] = s[x] + add;
    }
}

static int threads_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    Rows rows = {ctx};
    return wg_parallel_rows(ctx, ctx->height, threads_rows, &rows);
}

/* A "point operation" that writes its row index: in bands it sees the band's rows. */
static int rows_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    for (int y = 0; y < ctx->height; y++) {
        const float *s = wg_image_row(ctx->inputs[0], y);
        float *d = wg_image_row(ctx->outputs[0], y);
        for (int x = 0; x < ctx->width; x++) d[x] = s[x] + (float)y;
    }
    return WG_OK;
}

/* Crashes on NaN, as a NaN used as an index would (less reliably). */
static int nan_crash_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    for (int y = 0; y < ctx->height; y++) {
        const float *s = wg_image_row(ctx->inputs[0], y);
        float *d = wg_image_row(ctx->outputs[0], y);
        for (int x = 0; x < ctx->width; x++) {
            if (isnan(s[x])) raise(SIGSEGV);
            d[x] = s[x];
        }
    }
    return WG_OK;
}

/* exp of the input: +Inf from 89 on */
static int exp_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    for (int y = 0; y < ctx->height; y++) {
        const float *s = wg_image_row(ctx->inputs[0], y);
        float *d = wg_image_row(ctx->outputs[0], y);
        for (int x = 0; x < ctx->width; x++) d[x] = expf(s[x]);
    }
    return WG_OK;
}

#define KIT_TYPE(sym, nm, fl, fn)                                                                  \
    static const WgNodeType sym = {.name = nm,                                                     \
                                   .summary = "A node for the test kit's own tests",               \
                                   .category = "test",                                             \
                                   .params = kit_params,                                           \
                                   .params_size = sizeof(KitParams),                               \
                                   .inputs = gray_in,                                              \
                                   .outputs = gray_out,                                            \
                                   .flags = fl,                                                    \
                                   .eval = fn}
KIT_TYPE(kit_wrap, "kit_wrap_blur", WG_NODE_NEIGHBOURHOOD | WG_NODE_SERIAL, wrap_eval);
KIT_TYPE(kit_clamp, "kit_clamp_blur", WG_NODE_NEIGHBOURHOOD | WG_NODE_SERIAL, clamp_eval);
KIT_TYPE(kit_off, "kit_off", WG_NODE_POINT | WG_NODE_SERIAL, off_eval);
KIT_TYPE(kit_threads, "kit_threads", WG_NODE_NEIGHBOURHOOD, threads_eval);
KIT_TYPE(kit_rows, "kit_rows", WG_NODE_POINT | WG_NODE_SERIAL, rows_eval);
KIT_TYPE(kit_nan_crash, "kit_nan_crash", WG_NODE_POINT | WG_NODE_SERIAL, nan_crash_eval);
KIT_TYPE(kit_exp, "kit_exp", WG_NODE_POINT | WG_NODE_SERIAL, exp_eval);

static const WgNodeType *const kit_types[] = {&kit_wrap, &kit_clamp, &kit_off,  &kit_threads,
                                              &kit_rows, &kit_nan_crash, &kit_exp, NULL};
static const WgPlugin kit_plugin = WG_PLUGIN_INIT("kit", "1", kit_types);

static int add_kit_types(void **state)
{
    (void)state;
    WgError err = {0};
    if (wg_plugin_add(&kit_plugin, "test_testkit", &err)) fail_msg("%s", err.message);
    return 0;
}

static const char *const source_port[] = {"source", NULL};

/* A node of the kit's types on a 40x36 noise. */
static WgTestkitNode kit_node(const char *type, const WgImage **in, const char *const *params)
{
    *in = wg_testkit_image_noise(40, 36, 1, 7);
    return (WgTestkitNode){.type = type, .params = params, .input_names = source_port,
                           .inputs = in};
}

static double times_two(void *user, int x, int y, int c)
{
    const WgImage *in = user;
    return 2.0 * wg_image_row(in, y)[x * in->channels + c];
}

static void test_reference_comparison(void **state)
{
    (void)state;
    static const char *const gain2[] = {"gain=2", NULL};
    const WgImage *in;
    WgTestkitNode n = kit_node("kit_off", &in, gain2);
    WgImage *out = NULL;
    WgError err = {0};
    if (wg_testkit_run(&n, 2, &out, &err)) fail_msg("%s", err.message);
    WgTestkitReport rep;
    /* off by 1e-3: fails at 1e-4, naming a pixel and both values; passes at 2e-3 */
    assert_false(wg_testkit_compare_fn(out, times_two, (void *)in, 1e-4, &rep));
    assert_non_null(strstr(rep.message, "tolerance 0.0001"));
    assert_float_equal(rep.worst, 1e-3, 2e-6);
    assert_float_equal(rep.got - rep.want, 1e-3, 2e-6);
    assert_true(wg_testkit_compare_fn(out, times_two, (void *)in, 2e-3, &rep));
    /* a NaN where the reference has none is a failure whatever the tolerance */
    wg_image_row(out, 5)[7] = NAN;
    assert_false(wg_testkit_compare_fn(out, times_two, (void *)in, 1, &rep));
    assert_int_equal(rep.x, 7);
    assert_int_equal(rep.y, 5);
    /* parameters are checked as in a graph file */
    static const char *const bad[] = {"gain=500", NULL};
    n.params = bad;
    WgImage *none = NULL;
    assert_int_not_equal(wg_testkit_run(&n, 1, &none, &err), 0);
    assert_non_null(strstr(err.message, "gain"));
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_tiling(void **state)
{
    (void)state;
    const WgImage *in;
    WgTestkitNode n = kit_node("kit_wrap_blur", &in, NULL);
    WgTestkitReport rep;
    assert_true(wg_testkit_check_tiling(&n, 5, -3, 1e-6, &rep));
    n.type = "kit_clamp_blur";
    assert_false(wg_testkit_check_tiling(&n, 5, -3, 1e-6, &rep));
    assert_non_null(strstr(rep.message, "does not tile"));
    /* the wrong pixels are at the clamped edges, where they are and where they were rolled to */
    assert_true(rep.x == 0 || rep.x == 4 || rep.x == 5 || rep.x == 39);
    wg_image_unref(in);
}

static double ramp_fn(void *user, int x, int y, int c)
{
    (void)user, (void)y, (void)c;
    return x / 32.0;
}

/* a noise (every change as large as any) is seamless; a ramp jumps back at its edge */
static void test_seamless(void **state)
{
    (void)state;
    WgTestkitReport rep;
    WgImage *noise = wg_testkit_image_noise(32, 32, 1, 3);
    assert_true(wg_testkit_check_seamless(noise, 1.0, &rep));
    wg_image_unref(noise);
    WgImage *ramp = wg_testkit_image_fn(32, 8, 1, ramp_fn, NULL);
    assert_false(wg_testkit_check_seamless(ramp, 2.0, &rep));
    assert_int_equal(rep.x, 31);
    wg_image_unref(ramp);
}

static void test_invariance(void **state)
{
    (void)state;
    const WgImage *in;
    WgTestkitNode n = kit_node("kit_wrap_blur", &in, NULL);
    WgTestkitReport rep;
    assert_true(wg_testkit_check_invariance(&n, &rep));
    n.type = "kit_off";
    assert_true(wg_testkit_check_invariance(&n, &rep));
    /* depends on the threads */
    n.type = "kit_threads";
    assert_false(wg_testkit_check_invariance(&n, &rep));
    assert_non_null(strstr(rep.message, "threads differs from 1 thread"));
    /* depends on the rows of its band */
    n.type = "kit_rows";
    assert_false(wg_testkit_check_invariance(&n, &rep));
    assert_non_null(strstr(rep.message, "bands of 1 row differs"));
    wg_image_unref(in);
}

static void test_hard_inputs(void **state)
{
    (void)state;
    const WgImage *in;
    WgTestkitNode n = kit_node("kit_wrap_blur", &in, NULL);
    WgTestkitHardReport rep;
    if (!wg_testkit_check_hard_inputs(&n, &rep)) fail_msg("%s", rep.summary);
    assert_int_equal(rep.n_cases, 9);
    n.type = "kit_nan_crash";
    assert_false(wg_testkit_check_hard_inputs(&n, &rep));
    assert_int_equal(rep.n_failed, 1);
    if (!strstr(rep.summary, "nan: crashed: signal")) fail_msg("%s", rep.summary);
    n.type = "kit_exp";
    assert_false(wg_testkit_check_hard_inputs(&n, &rep));
    assert_int_equal(rep.n_failed, 1);
    assert_non_null(strstr(rep.summary, "huge: 1440 non-finite output values of 1440"));
    wg_image_unref(in);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reference_comparison),
        cmocka_unit_test(test_tiling),
        cmocka_unit_test(test_seamless),
        cmocka_unit_test(test_invariance),
        cmocka_unit_test(test_hard_inputs),
    };
    return cmocka_run_group_tests(tests, add_kit_types, NULL);
}
