/* SPDX-License-Identifier: MIT */
/* graphs/foam.wetgraph and graphs/foam_pattern.wetgraph on a synthetic periodic shore that
 * crosses the tile edges: the foam is seamless at every frame (v exactly: a rolled shore gives
 * the rolled v); a looping setting gives frame N equal to frame 0, a one-second loop still moves
 * and every speed snaps to the nearest non-zero whole number of cycles per loop with its sign (0
 * stays 0); a higher threshold never adds
 * foam; no foam beyond the band's sea-side edge nor inland beyond the inland reach; the nodes
 * that do not depend on $time are computed once for a sequence; T tiles and merges its two
 * layers with max; everything is finite and in range; the graph warns for exactly the values
 * snapping changes by more than 2x; a painted distance texture (pattern_mode profile) is used
 * as T as it is and the foam follows its profile; a noise input replaces N1; sine_warp moves
 * the waves (seamless, looping); a third stroke layer only adds foam; speed_noise varies the
 * waves' speed and loops. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { N = 128 };

static WgGraph *foam_graph;

static double shore_fn(int x, int y, int k)
{
    (void)k;
    double u = (x + 0.5) / N, v = (y + 0.5) / N;
    return cos(2 * M_PI * u) + 0.6 * sin(4 * M_PI * v) > 0.3 ? 1.0 : 0.0;
}

static int setup(void **state)
{
    (void)state;
    const char *src = getenv("WETGRAPH_SOURCE");
    if (!src) return -1;
    char path[2048];
    snprintf(path, sizeof path, "%s/graphs/foam.wetgraph", src);
    WgError err = {0};
    if (wg_graph_load(path, &foam_graph, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return -1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    wg_graph_free(foam_graph);
    return 0;
}

/* Render the foam graph on shore at time t with "name=value" settings (NULL-terminated). */
static WgResult *render(WgEngine *e, const WgImage *shore, double t, const char *const *sets)
{
    WgRequest *r = wg_request_new(foam_graph);
    WgError err = {0};
    assert_non_null(r);
    if (wg_request_set_input_image(r, "shore", shore, &err)) fail_msg("%s", err.message);
    for (int i = 0; sets && sets[i]; i++) {
        char name[64];
        const char *eq = strchr(sets[i], '=');
        snprintf(name, sizeof name, "%.*s", (int)(eq - sets[i]), sets[i]);
        if (wg_request_set(r, name, eq + 1, &err)) fail_msg("%s: %s", sets[i], err.message);
    }
    wg_request_set_time(r, t);
    WgResult *res = wgt_render_request(e, r);
    wg_request_free(r);
    return res;
}

static WgImage *roll(const WgImage *a, int dx, int dy)
{
    WgImage *b = wg_image_new(a->width, a->height, a->channels);
    assert_non_null(b);
    for (int y = 0; y < a->height; y++)
        for (int x = 0; x < a->width; x++)
            for (int k = 0; k < a->channels; k++)
                wg_image_row(b, (y + dy) % a->height)[((x + dx) % a->width) * a->channels + k] =
                    wgt_px(a, x, y, k);
    return b;
}

/* A seam would show as a step across the last column (row) far above the steps inside. */
static void test_seamless_at_every_frame(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const double times[] = {0, 1.3, 7.9};
    for (int i = 0; i < 3; i++) {
        WgResult *res = render(e, shore, times[i], NULL);
        const WgImage *f = wgt_output(res, "foam");
        wgt_assert_range(f, 0, 1);
        WgtSeams st = wgt_seams(f);
        double inner_c = st.inner_c, inner_r = st.inner_r, seam_c = st.seam_c, seam_r = st.seam_r;
        if (!(seam_c <= 3 * inner_c + 0.02 && seam_r <= 3 * inner_r + 0.02))
            fail_msg("t=%g: seam steps %g / %g against %g / %g inside", times[i], seam_c, seam_r,
                     inner_c, inner_r);
        assert_true(inner_c > 0.001); /* there is foam with edges at all */
        wgt_assert_range(wgt_output(res, "preview"), 0, 1);
        wgt_assert_range(wgt_output(res, "maps"), 0, 1);
        wg_result_free(res);
    }
    /* v is exact: a rolled shore gives the rolled v */
    WgResult *a = render(e, shore, 0, NULL);
    WgImage *rolled = roll(shore, 37, 90);
    WgResult *b = render(e, rolled, 0, NULL);
    WgImage *want = roll(wgt_output(a, "v"), 37, 90);
    wgt_assert_near(wgt_output(b, "v"), want, 1e-5);
    wg_image_unref(want);
    wg_image_unref(rolled);
    wg_result_free(a);
    wg_result_free(b);
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* loop_seconds 2: every speed snaps, so the frame at t = 2 (frame 48 at 24 fps) is frame 0. */
static void test_loop(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const char *const sets[] = {
        "loop_seconds=2",    "speed=0.3",   "tex_speed_x=0.04",   "warp_speed=0.1",
        "layer2_speed=-0.2", "come_go=0.3", "come_go_period=0.7", NULL};
    WgResult *a = render(e, shore, 0, sets), *b = render(e, shore, 2, sets),
             *c = render(e, shore, 0.5, sets);
    double same = wgt_max_abs_diff(wgt_output(a, "foam"), wgt_output(b, "foam"));
    double moved = wgt_max_abs_diff(wgt_output(a, "foam"), wgt_output(c, "foam"));
    if (!(same <= 1e-4)) fail_msg("frame at loop_seconds differs from frame 0 by %g", same);
    assert_true(moved > 0.5); /* and the animation does move in between */
    wg_result_free(a);
    wg_result_free(b);
    wg_result_free(c);
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* A one-second loop at 24 fps with the default speeds, all well below one wave or tile per
 * second: each snaps to one whole cycle per loop rather than to none, so frame 12 (t = 0.5)
 * differs from frame 0 and frame 24 (t = 1) equals it. */
static void test_short_loop_moves(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const char *const sets[] = {"loop_seconds=1", NULL};
    WgResult *f0 = render(e, shore, 0, sets), *f12 = render(e, shore, 12 / 24.0, sets),
             *f24 = render(e, shore, 24 / 24.0, sets);
    double moved = wgt_max_abs_diff(wgt_output(f0, "foam"), wgt_output(f12, "foam"));
    double same = wgt_max_abs_diff(wgt_output(f0, "foam"), wgt_output(f24, "foam"));
    if (!(moved > 0.5)) fail_msg("frame 12 of a 1 s loop differs from frame 0 by only %g", moved);
    if (!(same <= 1e-4)) fail_msg("frame 24 of a 1 s loop differs from frame 0 by %g", same);
    wg_result_free(f0);
    wg_result_free(f12);
    wg_result_free(f24);
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* The snapping rule, speed by speed: with a 1 s loop, -0.2 becomes -1 (sign kept), 0.3 becomes
 * 1, 1.4 stays 1, 2.5 becomes 3 (halves round up, as foam.frag's floor(x + 0.5)), 0 stays 0 and
 * a 0.45 s come-and-go period becomes 2 cycles per loop: the loop renders exactly what the
 * unlooped graph renders with those speeds set by hand, at several times. */
static void test_snapping_rule(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const char *const looped[] = {"loop_seconds=1",  "speed=-0.2",          "tex_speed_x=0.3",
                                  "tex_speed_y=2.5", "warp_speed=1.4",      "layer2_speed=0",
                                  "come_go=0.3",     "come_go_period=0.45", NULL};
    const char *const snapped[] = {
        "speed=-1",       "tex_speed_x=1", "tex_speed_y=3",      "warp_speed=1",
        "layer2_speed=0", "come_go=0.3",   "come_go_period=0.5", NULL};
    const double times[] = {0.3, 0.55, 7.2};
    for (int i = 0; i < 3; i++) {
        WgResult *a = render(e, shore, times[i], looped), *b = render(e, shore, times[i], snapped);
        double d = wgt_max_abs_diff(wgt_output(a, "foam"), wgt_output(b, "foam"));
        if (!(d <= 1e-4)) fail_msg("t=%g: snapped speeds differ from the rule by %g", times[i], d);
        wg_result_free(a);
        wg_result_free(b);
    }
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* The warnings of the foam graph with "name=value" settings (NULL-terminated): which of the
 * six snapped values warn (bit i for names[i], from the message's first word). */
static const char *const snapped_names[] = {"speed",       "warp_speed",   "tex_speed_x",
                                            "tex_speed_y", "layer2_speed", "come_go_period"};

static unsigned warned(const WgImage *shore, const char *const *sets, WgWarning **list, int *n)
{
    WgRequest *r = wg_request_new(foam_graph);
    WgError err = {0};
    assert_non_null(r);
    if (wg_request_set_input_image(r, "shore", shore, &err)) fail_msg("%s", err.message);
    for (int i = 0; sets[i]; i++) {
        char name[64];
        const char *eq = strchr(sets[i], '=');
        snprintf(name, sizeof name, "%.*s", (int)(eq - sets[i]), sets[i]);
        if (wg_request_set(r, name, eq + 1, &err)) fail_msg("%s: %s", sets[i], err.message);
    }
    if (wg_request_warnings(r, list, n, &err)) fail_msg("%s", err.message);
    wg_request_free(r);
    unsigned bits = 0;
    for (int i = 0; i < *n; i++) {
        const WgWarning *w = &(*list)[i];
        assert_null(w->node);
        assert_non_null(strstr(w->file, "foam.wetgraph"));
        int k = -1;
        for (int j = 0; j < 6; j++) {
            size_t l = strlen(snapped_names[j]);
            if (!strncmp(w->message, snapped_names[j], l) && w->message[l] == ' ') k = j;
        }
        if (k < 0) fail_msg("unexpected warning: %s", w->message);
        if (bits & (1u << k)) fail_msg("two warnings for %s", snapped_names[k]);
        bits |= 1u << k;
    }
    return bits;
}

/* Which values snapping changes by more than a factor of 2, from the rule itself: a speed s
 * becomes sign(s)·max(1, round(|s|·L))/L, the period p becomes L / max(1, round(L/p)). */
static unsigned changed_more_than_2x(const double v[6], double L)
{
    unsigned bits = 0;
    for (int k = 0; k < 6 && L > 0; k++) {
        double ratio;
        if (k < 5) {
            if (v[k] == 0) continue;
            ratio = fmax(1, floor(fabs(v[k]) * L + 0.5)) / L / fabs(v[k]);
        } else {
            ratio = v[k] / (L / fmax(1, floor(L / v[k] + 0.5)));
        }
        if (ratio > 2 || ratio < 0.5) bits |= 1u << k;
    }
    return bits;
}

/* The graph warns for exactly the values snapping changes by more than 2x (docs/foam.md), each
 * once, naming it and what it becomes; with the defaults and a 1-second loop all six, with a
 * loop of 100 s or none, nothing. */
static void test_snapping_warnings(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(16, 16, 1, shore_fn);
    WgWarning *w = NULL;
    int n = 0;
    const double defaults[6] = {0.25, 0.02, 0.01, -0.005, -0.015, 6};
    const char *const l1[] = {"loop_seconds=1", NULL};
    assert_int_equal(warned(shore, l1, &w, &n), 0x3f);
    assert_int_equal(n, 6);
    assert_string_equal(w[2].message,
                        "tex_speed_x 0.01 tiles/s snaps to 1 (one tile per 1 s loop), 100x faster: "
                        "raise loop_seconds to at least 50 to keep it within 2x");
    assert_string_equal(w[3].message, "tex_speed_y -0.005 tiles/s snaps to -1 (one tile per 1 s "
                                      "loop), 200x faster: raise loop_seconds to at least 100 to "
                                      "keep it within 2x");
    assert_string_equal(w[5].message, "come_go_period 6 s snaps to 1 s (one come-and-go per loop), "
                                      "6x faster: raise loop_seconds to at least 3 to keep it "
                                      "within 2x");
    wg_warnings_free(w, n);
    const char *const l100[] = {"loop_seconds=100", NULL};
    assert_int_equal(warned(shore, l100, &w, &n), 0);
    assert_int_equal(n, 0);
    const char *const l0[] = {"loop_seconds=0", "tex_speed_x=1e-6", NULL};
    assert_int_equal(warned(shore, l0, &w, &n), 0);
    /* the defaults over loop lengths around the table's bounds */
    const double loops[] = {0.5,  1,     1.99, 2,    2.9, 3,    24.9, 25,
                            33.3, 33.34, 40,   49.9, 50,  99.9, 100};
    for (size_t i = 0; i < sizeof loops / sizeof *loops; i++) {
        char l[64];
        snprintf(l, sizeof l, "loop_seconds=%.17g", loops[i]);
        const char *const sets[] = {l, NULL};
        unsigned got = warned(shore, sets, &w, &n);
        wg_warnings_free(w, n);
        if (got != changed_more_than_2x(defaults, loops[i]))
            fail_msg("loop %g: warned %#x, expected %#x", loops[i], got,
                     changed_more_than_2x(defaults, loops[i]));
    }
    /* other values: zero speeds never warn, signs do not matter, the period either way */
    const struct {
        double v[6], L;
    } cases[] = {
        {{0, 0, 0, 0, 0, 0.5}, 0.2},   {{0.3, -0.3, 0.7, -2, 0.05, 0.5}, 1},
        {{-1, 2, -0.1, 0.1, 0, 9}, 4}, {{0.125, -0.124, 0.126, 3, -3, 1e5}, 4},
        {{5, 5, 5, 5, 5, 0.3}, 0.11},  {{0.01, 0.02, 0.03, 0.04, 0.05, 40}, 19.99},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        char text[7][64];
        const char *sets[8];
        for (int k = 0; k < 6; k++) {
            snprintf(text[k], sizeof text[k], "%s=%.17g", snapped_names[k], cases[i].v[k]);
            sets[k] = text[k];
        }
        snprintf(text[6], sizeof text[6], "loop_seconds=%.17g", cases[i].L);
        sets[6] = text[6];
        sets[7] = NULL;
        unsigned got = warned(shore, sets, &w, &n);
        wg_warnings_free(w, n);
        unsigned want = changed_more_than_2x(cases[i].v, cases[i].L);
        if (got != want) fail_msg("case %zu: warned %#x, expected %#x", i, got, want);
    }
    wg_image_unref(shore);
}

static void test_threshold_and_band(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const char *const lo[] = {"threshold=0.1", NULL}, *const hi[] = {"threshold=0.3", NULL},
                      *const dry[] = {"inland_reach=0", "threshold=-2", NULL};
    WgResult *a = render(e, shore, 1.5, lo), *b = render(e, shore, 1.5, hi),
             *c = render(e, shore, 1.5, dry);
    const WgImage *fa = wgt_output(a, "foam"), *fb = wgt_output(b, "foam"),
                  *fc = wgt_output(c, "foam"), *v = wgt_output(c, "v");
    double sum_a = 0, sum_b = 0;
    int sea = 0, land = 0;
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++) {
            double pa = wgt_px(fa, x, y, 0), pb = wgt_px(fb, x, y, 0);
            if (pb > pa + 1e-6)
                fail_msg("a higher threshold adds foam at (%d,%d): %g > %g", x, y, pb, pa);
            sum_a += pa;
            sum_b += pb;
            double vv = wgt_px(v, x, y, 0), pc = wgt_px(fc, x, y, 0);
            /* threshold -2 puts foam everywhere in the band: none outside it */
            if (vv <= 0 && pc != 0) fail_msg("foam %g beyond the band at sea (v = %g)", pc, vv);
            if (vv >= 1.02 && pc != 0) fail_msg("foam %g inland (v = %g)", pc, vv);
            sea += vv <= 0;
            land += vv >= 1.02;
            if (vv > 0.05 && vv < 0.95 && !(pc > 0.99))
                fail_msg("no foam in the band at v = %g", vv);
        }
    assert_true(sum_b < sum_a);           /* it does remove some */
    assert_true(sea > 100 && land > 100); /* the shore has both far sea and inland */
    wg_result_free(a);
    wg_result_free(b);
    wg_result_free(c);
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* Three frames through one engine: the shore's distance transform, v, the noises and T are
 * computed for the first frame only (a pixel node's key holds $time only when its expression
 * reads it); the per-frame nodes every time. */
static void test_untimed_nodes_once(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    static const char *const once[] = {"sd", "v", "n1", "n2", "n3", "pattern/d1", "pattern/t"};
    static const char *const every[] = {"tex", "mix", "grad", "foam"};
    for (int f = 0; f < 3; f++) {
        WgResult *res = render(e, shore, f / 24.0, NULL);
        for (size_t i = 0; i < sizeof once / sizeof once[0]; i++) {
            /* after the first frame a node is either a cache hit or not needed at all (its
             * consumer was a hit) */
            const WgNodeStat *s = wgt_stat(res, once[i]);
            bool computed = s && s->cache == WG_COMPUTED;
            if (computed != (f == 0))
                fail_msg("frame %d: %s %s", f, once[i], f ? "recomputed" : "not computed");
        }
        for (size_t i = 0; i < sizeof every / sizeof every[0]; i++)
            assert_int_equal(wgt_stat(res, every[i])->cache, WG_COMPUTED);
        wg_result_free(res);
    }
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* foam_pattern: 1 on the strokes, 0 beyond `width`, max of the two layers, and wrapping: a
 * stroke on the left edge reaches the right edge. */
static void test_pattern(void **state)
{
    (void)state;
    const char *src = getenv("WETGRAPH_SOURCE");
    char xml[2048];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"64\">\n"
             "  <input name=\"a\" type=\"gray\"/><input name=\"b\" type=\"gray\"/>\n"
             "  <node id=\"p\" type=\"%s/graphs/foam_pattern.wetgraph\" width=\"32\" width2=\"16\" "
             "contrast=\"1\">\n"
             "    <in name=\"strokes\" from=\"$a\"/><in name=\"strokes2\" from=\"$b\"/>\n"
             "  </node>\n"
             "  <output name=\"t\" from=\"p.T\"/>\n"
             "</wetgraph>\n",
             src);
    WgGraph *g = wgt_load(xml);
    float a[64 * 64] = {0}, b[64 * 64] = {0};
    for (int y = 0; y < 64; y++) a[y * 64 + 0] = 1; /* a line on column 0 */
    b[32 * 64 + 32] = 1;                            /* a dot in the middle */
    WgImage *ia = wgt_image(64, 64, 1, a), *ib = wgt_image(64, 64, 1, b);
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "a", ia, &err), 0);
    assert_int_equal(wg_request_set_input_image(r, "b", ib, &err), 0);
    WgEngine *e = wgt_engine(1, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    const WgImage *t = wgt_output(res, "t");
    /* width 32 length units at 64 px = 8 px: falloff 1 - d/8 from column 0, wrapping */
    for (int x = 0; x < 64; x++) {
        int d = x < 32 ? x : 64 - x;
        double want = fmax(0, 1 - d / 8.0);
        int dd = abs(x - 32); /* the dot's layer on row 32: 1 - d/4 */
        double want32 = fmax(want, fmax(0, 1 - dd / 4.0));
        assert_float_equal(wgt_px(t, x, 0, 0), want, 1e-6);
        assert_float_equal(wgt_px(t, x, 32, 0), want32, 1e-6);
    }
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_image_unref(ia);
    wg_image_unref(ib);
    wg_graph_free(g);
}

/* docs/shaders/foam.frag's formula, written as pixel nodes over the graph's packed `maps` (v/2,
 * T, N1, N2), with the graph's default parameters, reproduces the graph's foam at three times;
 * only the anti-aliasing differs in the shader (fwidth), so it is the graph's one here. */
static void test_shader_formula_on_packed_maps(void **state)
{
    (void)state;
    const char *src = getenv("WETGRAPH_SOURCE");
    static const char body[] =
        "  <node id=\"mixs\" type=\"pixel\" sp=\"=fract(0.25 * $time)\"\n"
        "        cg=\"=sin(6.283185307179586 * fract($time / 6))\" wd=\"=fract(0.02 * $time)\"\n"
        "        tx=\"=fract(0.01 * $time)\" ty=\"=fract(-0.005 * $time)\"\n"
        "        l2=\"=fract(-0.015 * $time)\" wk=\"=2 * 6 / 256\"\n"
        "        expr=\"0.55 * (sin(6.283185307179586 * ((4 + 1 * (2 * m.b - 1)) * (m.r * 2) - sp "
        "- "
        "0.15 * cg)) + 0.9 * (m.r * 2) - 0.75 + 0.25 * (2 * sample(m.b, u + 0.25, v + 0.25) - 1))"
        " + 0.8 * (max(sample(m.g, u + wk * (sample(m.a, u + wd, v + wd) - 0.5) + tx,"
        " v + wk * (sample(m.a, u + wd + 0.5, v + wd + 0.5) - 0.5) + ty),"
        " 0.8 * sample(m.g, (u + wk * (sample(m.a, u + wd, v + wd) - 0.5)) * 2 + l2,"
        " (v + wk * (sample(m.a, u + wd + 0.5, v + wd + 0.5) - 0.5)) * 2))"
        " + 0.9 * (m.r * 2) - 0.75 + 0.25 * (2 * sample(m.b, u + 0.25, v + 0.25) - 1))"
        " - 0.45 - 0.1 * (2 * sample(m.b, u + 0.75, v + 0.75) - 1)\">\n"
        "    <in name=\"m\" from=\"f.maps\"/>\n"
        "  </node>\n"
        "  <node id=\"grad\" type=\"edge_detect\" mode=\"magnitude\">\n"
        "    <in name=\"source\" from=\"mixs\"/>\n"
        "  </node>\n"
        "  <node id=\"fs\" type=\"pixel\" expr=\"clamp(x1 / max(0.5 * g, 1e-4) + 0.5, 0, 1) * "
        "smoothstep(0, 0.04, m.r * 2) * (1 - smoothstep(1.08, 1.12, m.r * 2))\">\n"
        "    <in name=\"x1\" from=\"mixs\"/><in name=\"g\" from=\"grad\"/>"
        "<in name=\"m\" from=\"f.maps\"/>\n"
        "  </node>\n"
        "  <output name=\"graph\" from=\"f.foam\"/>\n"
        "  <output name=\"shader\" from=\"fs\"/>\n"
        "</wetgraph>\n";
    char xml[8192];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"%d\">\n"
             "  <input name=\"shore\" type=\"gray\"/>\n"
             "  <node id=\"f\" type=\"%s/graphs/foam.wetgraph\"><in name=\"shore\" "
             "from=\"$shore\"/></node>\n%s",
             N, src, body);
    WgGraph *g = wgt_load(xml);
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const double times[] = {0.4, 3.3, 11.7};
    for (int i = 0; i < 3; i++) {
        WgRequest *r = wg_request_new(g);
        WgError err = {0};
        if (wg_request_set_input_image(r, "shore", shore, &err)) fail_msg("%s", err.message);
        wg_request_set_time(r, times[i]);
        WgResult *res = wgt_render_request(e, r);
        const WgImage *a = wgt_output(res, "graph"), *b = wgt_output(res, "shader");
        int differ = 0, edge = 0;
        for (int y = 0; y < N; y++)
            for (int x = 0; x < N; x++) {
                float p = wgt_px(a, x, y, 0);
                edge += p > 0.02f && p < 0.98f;
                differ += fabsf(p - wgt_px(b, x, y, 0)) > 0.02f;
            }
        /* differences only where the foam has an edge (about one pixel wide) */
        if (differ > edge / 4 + 2)
            fail_msg("t=%g: %d pixels differ (%d edge pixels)", times[i], differ, edge);
        assert_true(edge > 50);
        wg_result_free(res);
        wg_request_free(r);
    }
    wg_engine_free(e);
    wg_image_unref(shore);
    wg_graph_free(g);
}

/* Render the foam graph on shore with more inputs (names[i] <- images[i]) at time t. */
static WgResult *render_with(WgEngine *e, const WgImage *shore, const char *const *names,
                             const WgImage *const *images, int n, double t, const char *const *sets)
{
    WgRequest *r = wg_request_new(foam_graph);
    WgError err = {0};
    assert_non_null(r);
    if (wg_request_set_input_image(r, "shore", shore, &err)) fail_msg("%s", err.message);
    for (int i = 0; i < n; i++)
        if (wg_request_set_input_image(r, names[i], images[i], &err))
            fail_msg("%s: %s", names[i], err.message);
    for (int i = 0; sets && sets[i]; i++) {
        char name[64];
        const char *eq = strchr(sets[i], '=');
        snprintf(name, sizeof name, "%.*s", (int)(eq - sets[i]), sets[i]);
        if (wg_request_set(r, name, eq + 1, &err)) fail_msg("%s: %s", sets[i], err.message);
    }
    wg_request_set_time(r, t);
    WgResult *res = wgt_render_request(e, r);
    wg_request_free(r);
    return res;
}

/* A painted distance texture: a smooth tileable profile in [0.05, 0.95]. */
static double profile_fn(int x, int y, int k)
{
    (void)k;
    double u = (x + 0.5) / N, v = (y + 0.5) / N;
    return 0.5 + 0.45 * sin(2 * M_PI * 2 * u) * cos(2 * M_PI * 3 * v);
}

/* pattern_mode profile uses a painted distance texture as T as it is (the maps' T is the
 * profile), so the foam of the texture term alone follows the profile's level sets at every
 * threshold; the strokes mode rebuilds T from the strokes at 0.5 and loses the profile. */
static void test_painted_profile(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn), *prof = wgt_image_fn(N, N, 1, profile_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const char *names[] = {"pattern"};
    const WgImage *in[] = {prof};
    static const char *const thresholds[] = {"threshold=0.3", "threshold=0.6"};
    for (int k = 0; k < 2; k++) {
        const char *const sets[] = {"pattern_mode=profile", "ratio_sine=0", "ratio_tex=1",
                                    "warp_amp=0", "tex_speed_x=0", "tex_speed_y=0", "layer2=0",
                                    "a=0", "b=0", "reach_noise=0", "threshold_noise=0",
                                    thresholds[k], NULL};
        double thr = k ? 0.6 : 0.3;
        WgResult *res = render_with(e, shore, names, in, 1, 0.7, sets);
        const WgImage *maps = wgt_output(res, "maps"), *foam = wgt_output(res, "foam"),
                      *v = wgt_output(res, "v");
        int checked = 0;
        for (int y = 0; y < N; y++)
            for (int x = 0; x < N; x++) {
                double p = profile_fn(x, y, 0);
                assert_float_equal(wgt_px(maps, x, y, 1), (float)p, 0);
                double vv = wgt_px(v, x, y, 0);
                if (vv < 0.1 || vv > 0.95 || fabs(p - thr) < 0.1) continue;
                if ((wgt_px(foam, x, y, 0) > 0.5) != (p > thr))
                    fail_msg("threshold %g at (%d, %d): foam %g where the profile is %g", thr, x,
                             y, wgt_px(foam, x, y, 0), p);
                checked++;
            }
        printf("threshold %g: %d pixels follow the profile\n", thr, checked);
        assert_true(checked > 2000);
        wg_result_free(res);
    }
    const char *const strokes[] = {"pattern_mode=strokes", NULL};
    WgResult *res = render_with(e, shore, names, in, 1, 0.7, strokes);
    WgImage *g = wgt_image(N, N, 1, NULL);
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++) wg_image_row(g, y)[x] = wgt_px(wgt_output(res, "maps"), x, y, 1);
    assert_true(wgt_max_abs_diff(g, prof) > 0.2);
    wg_image_unref(g);
    wg_result_free(res);
    wg_engine_free(e);
    wg_image_unref(prof);
    wg_image_unref(shore);
}

/* A `noise` input replaces N1: given the built-in N1 (the maps' b) the foam is the same, bit
 * for bit; another noise changes it. */
static void test_noise_input(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *a = render(e, shore, 1.1, NULL);
    WgImage *n1 = wgt_image(N, N, 1, NULL), *other = wgt_image_fn(N, N, 1, profile_fn);
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++) wg_image_row(n1, y)[x] = wgt_px(wgt_output(a, "maps"), x, y, 2);
    const char *names[] = {"noise"};
    const WgImage *same[] = {n1}, *diff[] = {other};
    WgResult *b = render_with(e, shore, names, same, 1, 1.1, NULL);
    WgResult *c = render_with(e, shore, names, diff, 1, 1.1, NULL);
    for (int k = 0; k < wg_result_output_count(a); k++)
        wgt_assert_identical(wg_result_output_image(b, k), wg_result_output_image(a, k));
    assert_true(wgt_max_abs_diff(wgt_output(c, "foam"), wgt_output(a, "foam")) > 0.5);
    wg_result_free(a);
    wg_result_free(b);
    wg_result_free(c);
    wg_image_unref(n1);
    wg_image_unref(other);
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* With `sets` (which give loop_seconds 2) the foam at t = 2 is the foam at t = 0: the loop
 * closes. */
static void assert_loop_closes(WgEngine *e, const WgImage *shore, const char *const *sets)
{
    WgResult *c0 = render(e, shore, 0, sets), *c2 = render(e, shore, 2, sets);
    wgt_assert_identical(wgt_output(c2, "foam"), wgt_output(c0, "foam"));
    wg_result_free(c0);
    wg_result_free(c2);
}

/* sine_warp moves the sine waves by the texture's warp: the foam changes, stays seamless, and
 * a loop still closes. */
static void test_sine_warp(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const char *const warped[] = {"sine_warp=1.5", NULL};
    const char *const looped[] = {"sine_warp=1.5", "loop_seconds=2", NULL};
    WgResult *a = render(e, shore, 0.7, NULL), *b = render(e, shore, 0.7, warped);
    assert_true(wgt_max_abs_diff(wgt_output(a, "foam"), wgt_output(b, "foam")) > 0.5);
    const WgImage *f = wgt_output(b, "foam");
    WgtSeams st = wgt_seams(f);
    assert_true(st.seam_c <= 3 * st.inner_c + 0.02 && st.seam_r <= 3 * st.inner_r + 0.02);
    assert_loop_closes(e, shore, looped);
    wg_result_free(a);
    wg_result_free(b);
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* A third stroke layer only adds foam (the mask with it holds the mask without: T is merged
 * with max), changes the foam, and a loop still closes with its drift snapped. */
static void test_layer3(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const char *const three[] = {"layer3=0.9", "layer3_scale=3", NULL};
    const char *const looped[] = {"layer3=0.9", "layer3_speed=0.3", "loop_seconds=2", NULL};
    WgResult *a = render(e, shore, 0.8, NULL), *b = render(e, shore, 0.8, three);
    const WgImage *fa = wgt_output(a, "foam"), *fb = wgt_output(b, "foam"),
                  *v = wgt_output(a, "v");
    int more = 0;
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++) {
            double vv = wgt_px(v, x, y, 0);
            if (vv < 0.05 || vv > 1.05) continue; /* inside the band, off its soft edges */
            bool ia = wgt_px(fa, x, y, 0) > 0.5, ib = wgt_px(fb, x, y, 0) > 0.5;
            if (ia && !ib) fail_msg("(%d, %d): a third layer removes foam", x, y);
            more += ib && !ia;
        }
    printf("a third layer: %d more foam pixels\n", more);
    assert_true(more > 50);
    assert_loop_closes(e, shore, looped);
    /* and the foam moves meanwhile */
    WgResult *c0 = render(e, shore, 0, looped), *c1 = render(e, shore, 1, looped);
    assert_true(wgt_max_abs_diff(wgt_output(c1, "foam"), wgt_output(c0, "foam")) > 0.5);
    wg_result_free(a);
    wg_result_free(b);
    wg_result_free(c0);
    wg_result_free(c1);
    wg_engine_free(e);
    wg_image_unref(shore);
}

/* speed_noise: the waves run faster in places, then slower (the come-and-go's amplitude varies
 * with a noise): the foam changes, and a loop still closes. */
static void test_speed_noise(void **state)
{
    (void)state;
    WgImage *shore = wgt_image_fn(N, N, 1, shore_fn);
    WgEngine *e = wgt_engine(2, 0, NULL);
    const char *const noisy[] = {"speed_noise=0.5", "come_go_period=2", NULL};
    const char *const looped[] = {"speed_noise=0.5", "loop_seconds=2", NULL};
    WgResult *a = render(e, shore, 0.5, NULL), *b = render(e, shore, 0.5, noisy);
    WgResult *a0 = render(e, shore, 0, NULL), *b0 = render(e, shore, 0, noisy);
    assert_true(wgt_max_abs_diff(wgt_output(a, "foam"), wgt_output(b, "foam")) > 0.5);
    /* at t = 0 the come-and-go is at rest: no difference */
    wgt_assert_identical(wgt_output(b0, "foam"), wgt_output(a0, "foam"));
    assert_loop_closes(e, shore, looped);
    WgResult *rs[] = {a, b, a0, b0};
    for (size_t i = 0; i < sizeof rs / sizeof *rs; i++) wg_result_free(rs[i]);
    wg_engine_free(e);
    wg_image_unref(shore);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_seamless_at_every_frame),
        cmocka_unit_test(test_loop),
        cmocka_unit_test(test_short_loop_moves),
        cmocka_unit_test(test_snapping_rule),
        cmocka_unit_test(test_snapping_warnings),
        cmocka_unit_test(test_threshold_and_band),
        cmocka_unit_test(test_untimed_nodes_once),
        cmocka_unit_test(test_pattern),
        cmocka_unit_test(test_shader_formula_on_packed_maps),
        cmocka_unit_test(test_painted_profile),
        cmocka_unit_test(test_noise_input),
        cmocka_unit_test(test_sine_warp),
        cmocka_unit_test(test_layer3),
        cmocka_unit_test(test_speed_noise),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
