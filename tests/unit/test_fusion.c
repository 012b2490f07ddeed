/* SPDX-License-Identifier: MIT */
/* Fused point operations (engine/fuse.c): renders with fusion are bit-identical to renders
 * without (WgEngineOptions.no_fuse) for 1, 2 and 3 threads, on graphs mixing point and
 * non-point nodes, shared and requested intermediates, promotions and resampling between point
 * nodes, multi-output nodes, point sources and subgraphs; results requested or read outside
 * their group are materialised and cached inside the group, intermediates shared within a group
 * stay in bands; no group contains a path that leaves it and comes back; the counted peak
 * memory of a long chain is lower fused; --stats and the result list the groups; dot --fused
 * draws them. */
#include "wgtest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

/* 203 rows: several bands, the last one partial. */
#define W 96
#define H 203

/* Every kind of edge around point nodes:
 * - n -> lev: a non-point source feeds a group; lev is shared by crv and thr, both in the group,
 *   so it stays in bands;
 * - crv is requested and feeds gm: materialised inside the group (lev, crv, thr, gm, hs);
 * - a blur between point nodes ends one group (hs) and starts another (inv -> cs);
 * - a, b and ml meet in a masked blend: a tree-shaped group of four;
 * - pr (gray) into hsl's colour port is promoted: not fused across;
 * - half is resampled from hl: not fused across;
 * - split's four outputs meet in merge, then shuffle;
 * - a colour uniform is the foreground of a blend (a point source fused in);
 * - the subgraph `tone` (levels -> invert) sits between point nodes of the parent. */
static const char *const mixed_xml =
    "<wetgraph version=\"1\" size=\"96x203\" seed=\"5\">\n"
    "  <input name=\"src\" type=\"color\"/>\n"
    "  <input name=\"h\" type=\"gray\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\" octaves=\"3\"/>\n"
    "  <node id=\"lev\" type=\"levels\" in_low=\"0.2\" in_high=\"0.8\" in_mid=\"0.4\">"
    "<in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"crv\" type=\"curve\" points=\"0:0 0.3:0.6 1:1\">"
    "<in name=\"source\" from=\"lev\"/></node>\n"
    "  <node id=\"thr\" type=\"threshold\" position=\"0.4\" contrast=\"0.2\">"
    "<in name=\"source\" from=\"lev\"/></node>\n"
    "  <node id=\"gm\" type=\"gradient_map\" keys=\"0:#102030 0.5:#806040 1:#f0e0d0\">"
    "<in name=\"source\" from=\"crv\"/></node>\n"
    "  <node id=\"hs\" type=\"hsl\" hue=\"0.1\" saturation=\"0.3\" lightness=\"-0.1\">"
    "<in name=\"source\" from=\"gm\"/></node>\n"
    "  <node id=\"sblur\" type=\"blur\" sigma=\"1.5\"><in name=\"source\" from=\"hs\"/></node>\n"
    "  <node id=\"inv\" type=\"invert\"><in name=\"source\" from=\"sblur\"/></node>\n"
    "  <node id=\"cs\" type=\"colorspace\" direction=\"to_srgb\">"
    "<in name=\"source\" from=\"inv\"/></node>\n"
    "  <node id=\"a\" type=\"invert\"><in name=\"source\" from=\"$h\"/></node>\n"
    "  <node id=\"b\" type=\"clamp\" min=\"0.1\" max=\"0.7\"><in name=\"source\" "
    "from=\"$h\"/></node>\n"
    "  <node id=\"ml\" type=\"levels\" out_low=\"0.2\"><in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"overlay\" opacity=\"0.8\">"
    "<in name=\"foreground\" from=\"a\"/><in name=\"background\" from=\"b\"/>"
    "<in name=\"mask\" from=\"ml\"/></node>\n"
    "  <node id=\"pr\" type=\"clamp\" min=\"0.2\" max=\"0.9\"><in name=\"source\" "
    "from=\"$h\"/></node>\n"
    "  <node id=\"hp\" type=\"hsl\" hue=\"0.3\"><in name=\"source\" from=\"pr\"/></node>\n"
    "  <node id=\"hl\" type=\"levels\" in_low=\"0.1\"><in name=\"source\" from=\"$h\"/></node>\n"
    "  <node id=\"half\" type=\"invert\" size=\"48x101\"><in name=\"source\" from=\"hl\"/></node>\n"
    "  <node id=\"s\" type=\"split\"><in name=\"source\" from=\"$src\"/></node>\n"
    "  <node id=\"m\" type=\"merge\"><in name=\"r\" from=\"s.b\"/><in name=\"g\" from=\"s.g\"/>"
    "<in name=\"b\" from=\"s.r\"/><in name=\"a\" from=\"s.a\"/></node>\n"
    "  <node id=\"sh\" type=\"shuffle\" a=\"one\"><in name=\"source\" from=\"m\"/></node>\n"
    "  <node id=\"tint\" type=\"uniform\" kind=\"color\" color=\"0.9 0.4 0.2 1\"/>\n"
    "  <node id=\"tinted\" type=\"blend\" mode=\"multiply\" opacity=\"0.6\">"
    "<in name=\"foreground\" from=\"tint\"/><in name=\"background\" from=\"sh\"/></node>\n"
    "  <node id=\"pre\" type=\"clamp\" min=\"0.05\" max=\"0.95\">"
    "<in name=\"source\" from=\"$h\"/></node>\n"
    "  <node id=\"t\" type=\"tone\" gain=\"0.7\"><in name=\"source\" from=\"pre\"/></node>\n"
    "  <node id=\"post\" type=\"curve\" points=\"0:0.1 1:0.9\"><in name=\"source\" "
    "from=\"t\"/></node>\n"
    "  <output name=\"crv\" from=\"crv\"/>\n"
    "  <output name=\"thr\" from=\"thr\"/>\n"
    "  <output name=\"cs\" from=\"cs\"/>\n"
    "  <output name=\"mix\" from=\"mix\"/>\n"
    "  <output name=\"hp\" from=\"hp\"/>\n"
    "  <output name=\"half\" from=\"half\"/>\n"
    "  <output name=\"tinted\" from=\"tinted\"/>\n"
    "  <output name=\"post\" from=\"post\"/>\n"
    "</wetgraph>\n";

static const char *const tone_xml =
    "<wetgraph version=\"1\">\n"
    "  <param name=\"gain\" type=\"float\" default=\"1\" min=\"0\" max=\"1\"/>\n"
    "  <input name=\"source\" type=\"gray\"/>\n"
    "  <node id=\"l\" type=\"levels\" out_high=\"=gain\"><in name=\"source\" "
    "from=\"$source\"/></node>\n"
    "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"l\"/></node>\n"
    "  <output name=\"out\" from=\"i\"/>\n"
    "</wetgraph>\n";

static double src_fn(int x, int y, int k)
{
    if (k == 3) return 0.5 + 0.5 * sin(x * 0.3 + y * 0.11);
    return 0.5 + 0.6 * sin(x * 0.37 + y * 0.23 * (k + 1) + k) * cos(y * 0.19 - x * 0.05 * k);
}

static double h_fn(int x, int y, int k)
{
    (void)k;
    return fmod(x * 0.137 + y * y * 0.0173, 1.0) * 1.5 - 0.2;
}

static WgGraph *mixed_graph(void)
{
    wgt_write_file(wgt_path("tone.wetgraph"), tone_xml);
    return wgt_load_at(mixed_xml, wgt_path("mixed.wetgraph"));
}

static WgRequest *mixed_request(const WgGraph *g)
{
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgImage *src = wgt_image_fn(W, H, 4, src_fn);
    WgImage *h = wgt_image_fn(W, H, 1, h_fn);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "src", src, &err), WG_OK);
    assert_int_equal(wg_request_set_input_image(r, "h", h, &err), WG_OK);
    wg_image_unref(src);
    wg_image_unref(h);
    return r;
}

static WgEngine *engine(int threads, bool fuse)
{
    WgEngineOptions opt = {.threads = threads, .no_fuse = !fuse};
    WgEngine *e = NULL;
    WgError err = {0};
    if (wg_engine_new(&opt, &e, &err)) fail_msg("engine: %s", err.message);
    return e;
}

static WgResult *render(int threads, bool fuse, const WgRequest *r)
{
    WgEngine *e = engine(threads, fuse);
    WgResult *res = wgt_render_request(e, r);
    wg_engine_free(e);
    return res;
}

static void expect_same_outputs(const WgResult *a, const WgResult *b)
{
    assert_int_equal(wg_result_output_count(a), wg_result_output_count(b));
    for (int i = 0; i < wg_result_output_count(a); i++) {
        assert_string_equal(wg_result_output_name(a, i), wg_result_output_name(b, i));
        wgt_assert_identical(wg_result_output_image(a, i), wg_result_output_image(b, i));
    }
}

static int fused_of(const WgResult *res, const char *id)
{
    const WgNodeStat *s = wgt_stat(res, id);
    if (!s) fail_msg("no stat for '%s'", id);
    return s->fused;
}

/* ---- identical results ------------------------------------------------------------------- */

static void test_fused_renders_are_identical_to_unfused(void **state)
{
    (void)state;
    WgGraph *g = mixed_graph();
    WgRequest *r = mixed_request(g);
    WgResult *ref = render(1, false, r);
    for (int i = 0; i < wg_result_stat_count(ref); i++)
        assert_int_equal(wg_result_stat(ref, i)->fused, 0);
    for (int threads = 1; threads <= 3; threads++) {
        WgResult *unfused = render(threads, false, r);
        WgResult *fused = render(threads, true, r);
        expect_same_outputs(ref, unfused);
        expect_same_outputs(ref, fused);
        assert_int_equal(wg_result_evaluated_count(fused), wg_result_evaluated_count(unfused));
        /* the groups, in plan order of their sinks: lev, crv, thr, gm -> hs; inv -> cs; a, b,
         * ml -> mix; split -> merge -> shuffle -> blend with the uniform; pre -> tone -> post */
        int g_hs = fused_of(fused, "hs"), g_cs = fused_of(fused, "cs");
        int g_mix = fused_of(fused, "mix"), g_tinted = fused_of(fused, "tinted");
        int g_post = fused_of(fused, "post");
        assert_true(g_hs > 0 && g_cs > 0 && g_mix > 0 && g_tinted > 0 && g_post > 0);
        static const char *const with_hs[] = {"lev", "crv", "thr", "gm"};
        for (size_t k = 0; k < 4; k++) assert_int_equal(fused_of(fused, with_hs[k]), g_hs);
        /* shared inside the group: bands only; requested: materialised in the group */
        assert_int_equal(wgt_stat(fused, "lev")->bytes, 0);
        assert_int_equal(wgt_stat(fused, "gm")->bytes, 0);
        assert_int_equal(wgt_stat(fused, "crv")->bytes, wg_image_bytes_for(W, H, 1));
        assert_int_equal(wgt_stat(fused, "thr")->bytes, wg_image_bytes_for(W, H, 1));
        assert_int_equal(fused_of(fused, "inv"), g_cs);
        assert_int_equal(fused_of(fused, "a"), g_mix);
        assert_int_equal(fused_of(fused, "b"), g_mix);
        assert_int_equal(fused_of(fused, "ml"), g_mix);
        assert_int_equal(fused_of(fused, "s"), g_tinted);
        assert_int_equal(fused_of(fused, "m"), g_tinted);
        assert_int_equal(fused_of(fused, "sh"), g_tinted);
        assert_int_equal(fused_of(fused, "tint"), g_tinted);
        assert_int_equal(fused_of(fused, "pre"), g_post);
        assert_int_equal(fused_of(fused, "t/l"), g_post);
        assert_int_equal(fused_of(fused, "t/i"), g_post);
        /* not point operations, or read only promoted or resampled: alone */
        static const char *const alone[] = {"n", "sblur", "pr", "hp", "hl", "half"};
        for (size_t k = 0; k < sizeof alone / sizeof *alone; k++)
            if (fused_of(fused, alone[k])) fail_msg("'%s' was fused", alone[k]);
        int groups[] = {g_hs, g_cs, g_mix, g_tinted, g_post};
        for (int x = 0; x < 5; x++)
            for (int y = x + 1; y < 5; y++) assert_int_not_equal(groups[x], groups[y]);
        wg_result_free(unfused);
        wg_result_free(fused);
    }
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

/* Requesting an intermediate materialises it, inside its group: the group goes on. */
static void test_requested_intermediates_are_materialised(void **state)
{
    (void)state;
    WgGraph *g = mixed_graph();
    WgRequest *r = mixed_request(g);
    WgError err = {0};
    assert_int_equal(wg_request_add_output(r, "mix", &err), WG_OK);
    WgResult *all = render(2, true, r);
    assert_true(fused_of(all, "ml") > 0);
    assert_int_equal(wgt_stat(all, "ml")->bytes, 0);
    assert_true(wgt_stat(all, "mix")->bytes > 0);
    wg_request_free(r);

    /* the same graph with ml as an output too */
    char *xml = malloc(strlen(mixed_xml) + 64);
    strcpy(xml, mixed_xml);
    char *end = strstr(xml, "</wetgraph>");
    strcpy(end, "  <output name=\"ml\" from=\"ml\"/>\n</wetgraph>\n");
    WgGraph *g2 = wgt_load_at(xml, wgt_path("mixed2.wetgraph"));
    free(xml);
    r = mixed_request(g2);
    for (int threads = 1; threads <= 3; threads++) {
        WgResult *fused = render(threads, true, r), *unfused = render(threads, false, r);
        expect_same_outputs(fused, unfused);
        assert_true(fused_of(fused, "mix") > 0); /* still with a, b and ml */
        assert_int_equal(fused_of(fused, "ml"), fused_of(fused, "mix"));
        assert_int_equal(wgt_stat(fused, "ml")->bytes, wg_image_bytes_for(W, H, 1));
        assert_int_equal(wgt_stat(fused, "a")->bytes, 0);
        assert_int_equal(fused_of(fused, "a"), fused_of(fused, "mix"));
        wgt_assert_identical(wgt_output(fused, "mix"), wgt_output(all, "mix"));
        wg_result_free(fused);
        wg_result_free(unfused);
    }
    wg_result_free(all);
    wg_request_free(r);
    wg_graph_free(g2);
    wg_graph_free(g);
}

/* ---- the cache ---------------------------------------------------------------------------- */

static const char *const chain_xml =
    "<wetgraph version=\"1\" size=\"64x150\">\n"
    "  <param name=\"gain\" type=\"float\" default=\"0.8\" min=\"0\" max=\"1\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\" octaves=\"2\"/>\n"
    "  <node id=\"p1\" type=\"levels\" in_low=\"0.1\"><in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"p2\" type=\"invert\"><in name=\"source\" from=\"p1\"/></node>\n"
    "  <node id=\"p3\" type=\"levels\" out_high=\"=gain\"><in name=\"source\" "
    "from=\"p2\"/></node>\n"
    "  <node id=\"p4\" type=\"clamp\" min=\"0.1\"><in name=\"source\" from=\"p3\"/></node>\n"
    "  <node id=\"bl\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"p2\"/></node>\n"
    "  <output name=\"out\" from=\"p4\"/>\n"
    "  <output name=\"soft\" from=\"bl\"/>\n"
    "</wetgraph>\n";

/* What is materialised is cached as before: p2 (read by the blur, outside the group) and p4
 * (requested), both members of one group; p1 and p3 are not, and an edit downstream of p2
 * recomputes p3 and p4 only. */
static void test_the_cache_keeps_what_is_materialised(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(chain_xml);
    WgRequest *r = wg_request_new(g);
    WgEngine *e = engine(2, true);
    WgResult *first = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(first), 6);
    assert_true(fused_of(first, "p1") > 0);
    assert_int_equal(fused_of(first, "p1"), fused_of(first, "p2"));
    assert_int_equal(fused_of(first, "p1"), fused_of(first, "p3"));
    assert_int_equal(fused_of(first, "p1"), fused_of(first, "p4"));
    assert_int_equal(wgt_stat(first, "p2")->bytes, wg_image_bytes_for(64, 150, 1));
    assert_int_equal(wgt_stat(first, "p3")->bytes, 0);

    WgResult *again = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(again), 0);
    assert_int_equal(wgt_stat(again, "p4")->cache, WG_HIT_MEMORY);

    WgError err = {0};
    assert_int_equal(wg_request_set(r, "gain", "0.6", &err), WG_OK);
    WgResult *edited = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(edited), 2);
    assert_int_equal(wgt_stat(edited, "p2")->cache, WG_HIT_MEMORY);
    assert_int_equal(wgt_stat(edited, "p3")->cache, WG_COMPUTED);
    assert_int_equal(wgt_stat(edited, "p4")->cache, WG_COMPUTED);
    assert_true(fused_of(edited, "p3") > 0);
    WgResult *cold = render(3, false, r);
    expect_same_outputs(edited, cold);

    /* back: both outputs from memory, nothing upstream looked at */
    assert_int_equal(wg_request_set(r, "gain", "0.8", &err), WG_OK);
    WgResult *back = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(back), 0);
    expect_same_outputs(back, first);
    assert_null(wgt_stat(back, "p1"));

    wg_result_free(first);
    wg_result_free(again);
    wg_result_free(edited);
    wg_result_free(cold);
    wg_result_free(back);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

/* ---- memory ------------------------------------------------------------------------------ */

/* A gray height coloured, adjusted in colour and reduced to gray again: unfused, two colour
 * images are alive at every colour step; fused, only the gray source and the gray result. */
static const char *const long_chain_xml =
    "<wetgraph version=\"1\" size=\"256\">\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\" octaves=\"2\"/>\n"
    "  <node id=\"c1\" type=\"gradient_map\" keys=\"0:#203040 1:#e0c0a0\">"
    "<in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"c2\" type=\"hsl\" hue=\"0.2\"><in name=\"source\" from=\"c1\"/></node>\n"
    "  <node id=\"c3\" type=\"levels\" in_low=\"0.1\"><in name=\"source\" from=\"c2\"/></node>\n"
    "  <node id=\"c4\" type=\"invert\"><in name=\"source\" from=\"c3\"/></node>\n"
    "  <node id=\"c5\" type=\"colorspace\"><in name=\"source\" from=\"c4\"/></node>\n"
    "  <node id=\"c6\" type=\"clamp\" max=\"0.8\"><in name=\"source\" from=\"c5\"/></node>\n"
    "  <node id=\"c7\" type=\"shuffle\" r=\"g\" g=\"b\" b=\"r\"><in name=\"source\" "
    "from=\"c6\"/></node>\n"
    "  <node id=\"c8\" type=\"curve\" points=\"0:0 0.5:0.7 1:1\"><in name=\"source\" "
    "from=\"c7\"/></node>\n"
    "  <node id=\"c9\" type=\"threshold\" contrast=\"0.1\"><in name=\"source\" "
    "from=\"c8\"/></node>\n"
    "  <node id=\"c10\" type=\"grayscale\"><in name=\"source\" from=\"c9\"/></node>\n"
    "  <output name=\"out\" from=\"c10\"/>\n"
    "</wetgraph>\n";

static void test_a_long_chain_peaks_lower_fused(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(long_chain_xml);
    WgRequest *r = wg_request_new(g);
    size_t gray = wg_image_bytes_for(256, 256, 1), color = wg_image_bytes_for(256, 256, 4);
    for (int threads = 1; threads <= 3; threads++) {
        WgResult *fused = render(threads, true, r), *unfused = render(threads, false, r);
        expect_same_outputs(fused, unfused);
        for (int i = 1; i <= 10; i++) {
            char id[8];
            snprintf(id, sizeof id, "c%d", i);
            assert_int_equal(fused_of(fused, id), 1);
        }
        assert_int_equal(fused_of(fused, "n"), 0);
        assert_int_equal(wg_result_peak_bytes(unfused), 2 * color);
        assert_int_equal(wg_result_peak_bytes(fused), 2 * gray);
        wg_result_free(fused);
        wg_result_free(unfused);
    }
    /* the lower need is what the budget checks: a budget between the two now suffices */
    WgEngineOptions opt = {.threads = 2, .memory_budget = 2 * gray + 1024};
    WgEngine *e = NULL;
    WgError err = {0};
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    WgResult *res = wgt_render_request(e, r);
    assert_true(wg_result_peak_bytes(res) <= opt.memory_budget);
    wg_result_free(res);
    wg_engine_free(e);
    opt.no_fuse = true;
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    res = NULL;
    assert_int_equal(wg_render(e, r, &res, &err), WG_ERR_BUDGET);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

/* Colour, reduced to gray, coloured again: one group of the three would keep the colour input
 * until its colour output exists (two colour images), where unfused never holds more than one
 * colour and one gray image. Groups that raise the estimated peak are cut: gr runs alone, iv
 * and gm are fused, and the peak is the unfused one; a budget of one colour and one gray image
 * renders fused; below it, the error states that need. */
static void test_groups_do_not_raise_the_peak(void **state)
{
    (void)state;
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"512\">\n"
                          "  <input name=\"src\" type=\"color\"/>\n"
                          "  <node id=\"gr\" type=\"grayscale\"><in name=\"source\" "
                          "from=\"$src\"/></node>\n"
                          "  <node id=\"iv\" type=\"invert\"><in name=\"source\" "
                          "from=\"gr\"/></node>\n"
                          "  <node id=\"gm\" type=\"gradient_map\" keys=\"0:#000 1:#8af\">"
                          "<in name=\"source\" from=\"iv\"/></node>\n"
                          "  <output name=\"out\" from=\"gm\"/>\n"
                          "</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    WgImage *src = wgt_image_fn(512, 512, 4, src_fn);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "src", src, &err), WG_OK);
    size_t gray = wg_image_bytes_for(512, 512, 1), color = wg_image_bytes_for(512, 512, 4);
    WgResult *fused = render(1, true, r), *unfused = render(1, false, r);
    assert_int_equal(fused_of(fused, "gr"), 0);
    assert_int_equal(fused_of(fused, "iv"), 1);
    assert_int_equal(fused_of(fused, "gm"), 1);
    assert_int_equal(wg_result_peak_bytes(fused), color + gray);
    assert_int_equal(wg_result_peak_bytes(unfused), color + gray);
    WgEngineOptions opt = {.threads = 2, .memory_budget = color + gray + 1024};
    WgEngine *e = NULL;
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    WgResult *res = wgt_render_request(e, r);
    assert_int_equal(fused_of(res, "iv"), 1);
    assert_true(wg_result_peak_bytes(res) <= opt.memory_budget);
    expect_same_outputs(res, fused);
    wg_result_free(res);
    wg_engine_free(e);
    /* neither fits: the error states the smaller need */
    opt.memory_budget = color + gray - 1024;
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    res = NULL;
    assert_int_equal(wg_render(e, r, &res, &err), WG_ERR_BUDGET);
    char need[64];
    snprintf(need, sizeof need, "needs at least %.1f MiB", (color + gray) / 1048576.0);
    assert_string_equal(need, "needs at least 5.0 MiB");
    wgt_assert_error(&err, WG_ERR_BUDGET, 0, need);
    wg_engine_free(e);
    wg_result_free(fused);
    wg_result_free(unfused);
    wg_image_unref(src);
    wg_request_free(r);
    wg_graph_free(g);
}

/* A right-deep comb of blends over uniforms: in plan order every uniform comes before the
 * blends, so all are alive at once. With 8 the group fits its band buffers; with 80 bands of
 * one 16384-wide row (64 KiB) it would need 5 MiB per thread, and its nodes run alone. */
static void test_wide_groups_are_not_fused(void **state)
{
    (void)state;
    for (int leaves = 8; leaves <= 80; leaves += 72) {
        char xml[32768];
        size_t n = (size_t)snprintf(xml, sizeof xml, "<wetgraph version=\"1\" size=\"16384x3\">\n");
        for (int i = 0; i < leaves; i++)
            n += (size_t)snprintf(xml + n, sizeof xml - n,
                                  "  <node id=\"u%d\" type=\"uniform\" value=\"%g\"/>\n", i,
                                  i / (double)leaves);
        for (int i = 0; i + 1 < leaves; i++)
            n += (size_t)snprintf(xml + n, sizeof xml - n,
                                  "  <node id=\"b%d\" type=\"blend\" mode=\"add\" "
                                  "clamp=\"false\"><in name=\"foreground\" from=\"u%d\"/>"
                                  "<in name=\"background\" from=\"%c%d\"/></node>\n",
                                  i, i, i + 2 < leaves ? 'b' : 'u', i + 1);
        snprintf(xml + n, sizeof xml - n, "  <output name=\"out\" from=\"b0\"/>\n</wetgraph>\n");
        WgGraph *g = wgt_load(xml);
        WgRequest *r = wg_request_new(g);
        for (int threads = 1; threads <= 2; threads++) {
            WgResult *fused = render(threads, true, r), *unfused = render(threads, false, r);
            expect_same_outputs(fused, unfused);
            assert_int_equal(fused_of(fused, "u0"), leaves == 8 ? 1 : 0);
            assert_int_equal(fused_of(fused, "b0"), leaves == 8 ? 1 : 0);
            wg_result_free(fused);
            wg_result_free(unfused);
        }
        wg_request_free(r);
        wg_graph_free(g);
    }
}

/* Pixel expressions shaped like the wet material's masks and maps: named gray and colour inputs,
 * extra attributes, a graph parameter, a uniform (stride 0) input, statistics of the height as
 * inputs, noise() of u with the seed, colour and gray mixed. Those that read no row and no other
 * pixel fuse (px1 -> px2 -> px3 -> col -> px4, and the subgraph's two); one reading y, one
 * reading v, one using sample() and one reading $height need the whole image and run alone, as
 * does a shared one. Fused and unfused are bit-identical for 1, 2 and 3 threads, at sizes
 * whose last band is partial. */
static const char *const pixel_xml_fmt =
    "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"%d\">\n"
    "  <param name=\"level\" type=\"float\" default=\"0.45\" min=\"0\" max=\"1\"/>\n"
    "  <input name=\"src\" type=\"color\"/>\n"
    "  <input name=\"h\" type=\"gray\"/>\n"
    "  <input name=\"pm\" type=\"gray\" default=\"0.7\"/>\n"
    "  <node id=\"st\" type=\"statistics\"><in name=\"source\" from=\"$h\"/></node>\n"
    "  <node id=\"px1\" type=\"pixel\" k=\"=128 * level\" expr=\"clamp((level - h) * k, 0, 1)\">"
    "<in name=\"h\" from=\"$h\"/></node>\n"
    "  <node id=\"px2\" type=\"pixel\" expr=\"d = m * pm; d + (1 - d) * (h - lo) / (hi - lo + "
    "1e-6) * noise(u * 3 + h, 0.25, 4)\"><in name=\"m\" from=\"px1\"/>"
    "<in name=\"pm\" from=\"$pm\"/><in name=\"h\" from=\"$h\"/>"
    "<in name=\"lo\" from=\"st.min\"/><in name=\"hi\" from=\"st.max\"/></node>\n"
    "  <node id=\"px3\" type=\"pixel\" kind=\"color\" expr=\"A * (1 - 0.6 * w) + rgb(w, w * "
    "w, sqrt(w)) * 0.3\"><in name=\"A\" from=\"$src\"/><in name=\"w\" from=\"px2\"/></node>\n"
    "  <node id=\"col\" type=\"hsl\" saturation=\"0.2\"><in name=\"source\" from=\"px3\"/>"
    "</node>\n"
    "  <node id=\"px4\" type=\"pixel\" kind=\"color\" expr=\"C.r > 0.5 ? C * C : pow(C, 0.8) + "
    "x * 1e-4\"><in name=\"C\" from=\"col\"/></node>\n"
    "  <node id=\"py\" type=\"pixel\" expr=\"a * 0.5 + y * 1e-3\"><in name=\"a\" from=\"$h\"/>"
    "</node>\n"
    "  <node id=\"qy\" type=\"invert\"><in name=\"source\" from=\"py\"/></node>\n"
    "  <node id=\"pv\" type=\"pixel\" expr=\"a * v\"><in name=\"a\" from=\"$h\"/></node>\n"
    "  <node id=\"qv\" type=\"invert\"><in name=\"source\" from=\"pv\"/></node>\n"
    "  <node id=\"ps\" type=\"pixel\" expr=\"sample(a, u + 0.01, 0.5) - a\">"
    "<in name=\"a\" from=\"$h\"/></node>\n"
    "  <node id=\"qs\" type=\"invert\"><in name=\"source\" from=\"ps\"/></node>\n"
    "  <node id=\"ph\" type=\"pixel\" expr=\"a * $height\"><in name=\"a\" from=\"$h\"/></node>\n"
    "  <node id=\"qh\" type=\"invert\"><in name=\"source\" from=\"ph\"/></node>\n"
    "  <node id=\"sh\" type=\"pixel\" expr=\"1 - a\"><in name=\"a\" from=\"$h\"/></node>\n"
    "  <node id=\"sa\" type=\"pixel\" expr=\"a * a\"><in name=\"a\" from=\"sh\"/></node>\n"
    "  <node id=\"sb\" type=\"pixel\" expr=\"a + 1\"><in name=\"a\" from=\"sh\"/></node>\n"
    "  <node id=\"t\" type=\"ptone\"><in name=\"source\" from=\"sa\"/></node>\n"
    "  <output name=\"px4\" from=\"px4\"/>\n"
    "  <output name=\"qy\" from=\"qy\"/>\n"
    "  <output name=\"qv\" from=\"qv\"/>\n"
    "  <output name=\"qs\" from=\"qs\"/>\n"
    "  <output name=\"qh\" from=\"qh\"/>\n"
    "  <output name=\"t\" from=\"t\"/>\n"
    "  <output name=\"sb\" from=\"sb\"/>\n"
    "</wetgraph>\n";

static const char *const ptone_xml =
    "<wetgraph version=\"1\">\n"
    "  <input name=\"source\" type=\"gray\"/>\n"
    "  <node id=\"a\" type=\"pixel\" g=\"0.7\" expr=\"s * g + 0.1\"><in name=\"s\" "
    "from=\"$source\"/></node>\n"
    "  <node id=\"b\" type=\"pixel\" expr=\"1 - s * s\"><in name=\"s\" from=\"a\"/></node>\n"
    "  <output name=\"out\" from=\"b\"/>\n"
    "</wetgraph>\n";

static void test_point_pixel_expressions_fuse(void **state)
{
    (void)state;
    static const int sizes[][3] = {{96, 203, 5}, {131, 67, 11}, {512, 301, 2}};
    wgt_write_file(wgt_path("ptone.wetgraph"), ptone_xml);
    for (size_t z = 0; z < sizeof sizes / sizeof *sizes; z++) {
        int w = sizes[z][0], h = sizes[z][1];
        char xml[8192];
        snprintf(xml, sizeof xml, pixel_xml_fmt, w, h, sizes[z][2]);
        WgGraph *g = wgt_load_at(xml, wgt_path("pixels.wetgraph"));
        WgRequest *r = wg_request_new(g);
        assert_non_null(r);
        WgImage *src = wgt_image_fn(w, h, 4, src_fn), *hm = wgt_image_fn(w, h, 1, h_fn);
        WgError err = {0};
        assert_int_equal(wg_request_set_input_image(r, "src", src, &err), WG_OK);
        assert_int_equal(wg_request_set_input_image(r, "h", hm, &err), WG_OK);
        wg_image_unref(src);
        wg_image_unref(hm);
        WgResult *ref = render(1, false, r);
        for (int threads = 1; threads <= 3; threads++) {
            WgResult *fused = render(threads, true, r), *unfused = render(threads, false, r);
            expect_same_outputs(ref, unfused);
            expect_same_outputs(ref, fused);
            int chain = fused_of(fused, "px4"), sub = fused_of(fused, "t/b");
            assert_true(chain > 0 && sub > 0 && chain != sub);
            static const char *const in_chain[] = {"px1", "px2", "px3", "col"};
            for (size_t k = 0; k < 4; k++) assert_int_equal(fused_of(fused, in_chain[k]), chain);
            assert_int_equal(fused_of(fused, "sa"), sub);
            assert_int_equal(fused_of(fused, "t/a"), sub);
            /* sh, shared by sa and sb in the same group, stays in bands */
            assert_int_equal(fused_of(fused, "sh"), sub);
            assert_int_equal(fused_of(fused, "sb"), sub);
            assert_int_equal(wgt_stat(fused, "sh")->bytes, 0);
            /* rows, other pixels, the height; shared; reading an input in place */
            static const char *const alone[] = {"py", "pv", "ps", "ph", "st"};
            for (size_t k = 0; k < sizeof alone / sizeof *alone; k++)
                if (fused_of(fused, alone[k])) fail_msg("'%s' was fused", alone[k]);
            wg_result_free(fused);
            wg_result_free(unfused);
        }
        wg_result_free(ref);
        wg_request_free(r);
        wg_graph_free(g);
    }
}

/* A pixel node in a fused group is compiled once for the render (its check when the plan is
 * built, then once for all the bands), not once per band: 16 bands of a 64x2048 image here. */
long wg__px_compiled(void);

static void test_pixel_nodes_compile_once_per_group(void **state)
{
    (void)state;
    static const char *const xml =
        "<wetgraph version=\"1\" size=\"64x2048\">\n"
        "  <node id=\"n\" type=\"noise\" scale=\"4\" octaves=\"2\"/>\n"
        "  <node id=\"a\" type=\"pixel\" expr=\"s * 0.5 + 0.1\"><in name=\"s\" "
        "from=\"n\"/></node>\n"
        "  <node id=\"b\" type=\"pixel\" expr=\"1 - s * s\"><in name=\"s\" from=\"a\"/></node>\n"
        "  <node id=\"c\" type=\"pixel\" kind=\"color\" expr=\"rgb(s, s * s, 1 - s)\">"
        "<in name=\"s\" from=\"b\"/></node>\n"
        "  <output name=\"out\" from=\"c\"/>\n"
        "</wetgraph>\n";
    WgGraph *g = wgt_load(xml);
    WgRequest *r = wg_request_new(g);
    WgResult *ref = render(1, false, r);
    for (int threads = 1; threads <= 2; threads++) {
        long before = wg__px_compiled();
        WgResult *fused = render(threads, true, r);
        long compiles = wg__px_compiled() - before;
        assert_true(fused_of(fused, "a") > 0);
        assert_int_equal(fused_of(fused, "c"), fused_of(fused, "a"));
        expect_same_outputs(ref, fused);
        if (compiles > 6) fail_msg("%ld programs compiled for 3 pixel nodes", compiles);
        wg_result_free(fused);
    }
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

/* No group holds a path that leaves it and comes back: a feeds a blur that c reads, so a and c
 * are in different groups even though c reads a as it is; d and e, which read a directly and
 * nothing from outside that depends on it, join a's group; f reads e and c, and joins c's group
 * (a's would take c's path through the blur in). The plan order is a, d, e, b, c, f (f reads e
 * first): the blur, reading a, comes after a's group. Reading f's inputs the other way round
 * puts the blur before e: a node outside a group that reads a member must come after the
 * group's last member, so a then runs alone (and d, e and c, f fused would hold a, b and e while
 * f is made, more than unfused: they are not). No group raises the peak. A plan of more than
 * 4096 nodes (a chain of 5000 inverts and levels) still fuses its chain. */
static void test_groups_hold_no_path_that_leaves_them(void **state)
{
    (void)state;
    static const char *const xml_fmt =
        "<wetgraph version=\"1\" size=\"80x97\">\n"
        "  <input name=\"h\" type=\"gray\"/>\n"
        "  <node id=\"a\" type=\"pixel\" expr=\"s * 0.8 + 0.1\"><in name=\"s\" "
        "from=\"$h\"/></node>\n"
        "  <node id=\"b\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"a\"/></node>\n"
        "  <node id=\"c\" type=\"pixel\" expr=\"s - t\"><in name=\"s\" from=\"a\"/>"
        "<in name=\"t\" from=\"b\"/></node>\n"
        "  <node id=\"d\" type=\"invert\"><in name=\"source\" from=\"a\"/></node>\n"
        "  <node id=\"e\" type=\"pixel\" expr=\"s * s\"><in name=\"s\" from=\"d\"/></node>\n"
        "  <node id=\"f\" type=\"pixel\" expr=\"s + t\">%s</node>\n"
        "  <output name=\"f\" from=\"f\"/>\n"
        "</wetgraph>\n";
    static const char *const orders[] = {"<in name=\"t\" from=\"e\"/><in name=\"s\" from=\"c\"/>",
                                         "<in name=\"s\" from=\"c\"/><in name=\"t\" from=\"e\"/>"};
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgResult *ref = NULL;
    for (int v = 0; v < 2; v++) {
        char xml[4096];
        snprintf(xml, sizeof xml, xml_fmt, orders[v]);
        g = wgt_load(xml);
        r = wg_request_new(g);
        WgImage *h = wgt_image_fn(80, 97, 1, h_fn);
        WgError err = {0};
        assert_int_equal(wg_request_set_input_image(r, "h", h, &err), WG_OK);
        wg_image_unref(h);
        ref = render(1, false, r);
        for (int threads = 1; threads <= 3; threads++) {
            WgResult *fused = render(threads, true, r);
            expect_same_outputs(ref, fused);
            int ga = fused_of(fused, "a"), gc = fused_of(fused, "c"), gd = fused_of(fused, "d");
            assert_int_equal(fused_of(fused, "b"), 0);
            assert_true(wg_result_peak_bytes(fused) <= wg_result_peak_bytes(ref));
            if (v == 0) { /* a, d, e: a materialised for the blur, d in bands; c, f */
                assert_true(gc > 0 && gd > 0 && gc != gd);
                assert_int_equal(ga, gd);
                assert_int_equal(fused_of(fused, "e"), gd);
                assert_int_equal(fused_of(fused, "f"), gc);
                assert_int_equal(wgt_stat(fused, "a")->bytes, wg_image_bytes_for(80, 97, 1));
                assert_int_equal(wgt_stat(fused, "d")->bytes, 0);
                assert_int_equal(wgt_stat(fused, "e")->bytes, wg_image_bytes_for(80, 97, 1));
            } else { /* the blur comes before e in plan order: a alone */
                assert_int_equal(ga, 0);
            }
            wg_result_free(fused);
        }
        wg_result_free(ref);
        wg_request_free(r);
        wg_graph_free(g);
    }

    enum { N = 5000 };
    size_t cap = (size_t)N * 120 + 256, at = 0;
    char *big = malloc(cap);
    at += (size_t)snprintf(big + at, cap - at,
                           "<wetgraph version=\"1\" size=\"16x16\">\n"
                           "  <node id=\"n0\" type=\"noise\" scale=\"2\"/>\n");
    for (int i = 1; i < N; i++)
        at += (size_t)snprintf(big + at, cap - at,
                               "  <node id=\"n%d\" type=\"%s\"><in name=\"source\" "
                               "from=\"n%d\"/></node>\n",
                               i, i % 2 ? "invert" : "levels", i - 1);
    snprintf(big + at, cap - at, "  <output name=\"out\" from=\"n%d\"/>\n</wetgraph>\n", N - 1);
    g = wgt_load(big);
    free(big);
    r = wg_request_new(g);
    ref = render(1, false, r);
    WgResult *fused = render(2, true, r);
    expect_same_outputs(ref, fused);
    assert_int_equal(fused_of(fused, "n1"), 1);
    assert_int_equal(fused_of(fused, "n4999"), 1);
    wg_result_free(fused);
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

/* ---- listing the groups ----------------------------------------------------------------- */

static void test_stats_list_the_groups(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(chain_xml);
    WgRequest *r = wg_request_new(g);
    WgResult *res = render(2, true, r);
    /* one group: p2 is materialised for the blur, p4 for the output */
    assert_int_equal(fused_of(res, "p1"), 1);
    assert_int_equal(fused_of(res, "p2"), 1);
    assert_int_equal(fused_of(res, "p3"), 1);
    assert_int_equal(fused_of(res, "p4"), 1);
    assert_int_equal(fused_of(res, "n"), 0);
    assert_int_equal(fused_of(res, "bl"), 0);
    assert_int_equal(wgt_stat(res, "p1")->bytes, 0);
    assert_int_equal(wgt_stat(res, "p3")->bytes, 0);
    assert_int_equal(wgt_stat(res, "p2")->bytes, wg_image_bytes_for(64, 150, 1));
    for (int i = 0; i < wg_result_stat_count(res); i++)
        assert_true(wg_result_stat(res, i)->ms >= 0);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
}

/* Run `cmd` with sh in the test folder; its stdout and stderr into `out` (NUL-terminated). */
static int run(const char *cmd, char *out, size_t size)
{
    char full[4096];
    snprintf(full, sizeof full, "cd '%s' && %s 2>&1", wgt_tmpdir(), cmd);
    FILE *p = popen(full, "r");
    assert_non_null(p);
    size_t n = fread(out, 1, size - 1, p);
    out[n] = '\0';
    int status = pclose(p);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

static void test_the_command_line_lists_and_draws_the_groups(void **state)
{
    (void)state;
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) skip();
    wgt_write_file(wgt_path("chain.wetgraph"), chain_xml);
    static char out[1 << 16];
    char cmd[2048];

    snprintf(cmd, sizeof cmd, "'%s' render chain.wetgraph -o fz --stats -q", bin);
    assert_int_equal(run(cmd, out, sizeof out), 0);
    if (!strstr(out, "fused group #1: 4 point operations from 'p1' to 'p4'") ||
        !strstr(out, "2 are materialised (the other 2 exist only in bands)") ||
        strstr(out, "fused group #2"))
        fail_msg("--stats output:\n%s", out);

    snprintf(cmd, sizeof cmd, "'%s' render chain.wetgraph -o fz --stats=json -q", bin);
    assert_int_equal(run(cmd, out, sizeof out), 0);
    if (!strstr(out, "\"id\": \"p1\", \"type\": \"levels\"") ||
        !strstr(out, "\"bytes\": 0, \"fused\": 1}") ||
        !strstr(out, "{\"group\": 1, \"nodes\": 4, ") ||
        !strstr(out, "\"sink\": \"p4\", \"materialised\": 2}"))
        fail_msg("--stats=json output:\n%s", out);

    snprintf(cmd, sizeof cmd, "'%s' render chain.wetgraph -o fz --stats --no-fuse -q", bin);
    assert_int_equal(run(cmd, out, sizeof out), 0);
    if (strstr(out, "fused group") || strstr(out, "#1")) fail_msg("--no-fuse output:\n%s", out);

    snprintf(cmd, sizeof cmd, "'%s' dot --fused chain.wetgraph", bin);
    assert_int_equal(run(cmd, out, sizeof out), 0);
    const char *c1 = strstr(out, "subgraph cluster_fused_1 {");
    if (!c1 || !strstr(c1, "\"n:p1\";\n    \"n:p2\";\n    \"n:p3\";\n    \"n:p4\";\n  }") ||
        strstr(out, "cluster_fused_2"))
        fail_msg("dot --fused output:\n%s", out);
    snprintf(cmd, sizeof cmd, "'%s' dot chain.wetgraph", bin);
    assert_int_equal(run(cmd, out, sizeof out), 0);
    if (strstr(out, "cluster")) fail_msg("dot output:\n%s", out);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fused_renders_are_identical_to_unfused),
        cmocka_unit_test(test_requested_intermediates_are_materialised),
        cmocka_unit_test(test_the_cache_keeps_what_is_materialised),
        cmocka_unit_test(test_a_long_chain_peaks_lower_fused),
        cmocka_unit_test(test_groups_do_not_raise_the_peak),
        cmocka_unit_test(test_wide_groups_are_not_fused),
        cmocka_unit_test(test_point_pixel_expressions_fuse),
        cmocka_unit_test(test_pixel_nodes_compile_once_per_group),
        cmocka_unit_test(test_groups_hold_no_path_that_leaves_them),
        cmocka_unit_test(test_stats_list_the_groups),
        cmocka_unit_test(test_the_command_line_lists_and_draws_the_groups),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
