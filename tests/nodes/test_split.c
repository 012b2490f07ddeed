/* SPDX-License-Identifier: MIT */
/* `split`: exact channel copies (extremes included), gray promotion, split -> merge round trip,
 * threads. */
#include "colortest.h"

static WgImage *split_port(const WgImage *in, int port, int threads)
{
    const char *names[] = {"source"};
    const WgImage *images[] = {in};
    return wgt_node("split", "", in->width, in->height, 1, names, images, port, threads);
}

static void test_exact_copies(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(19, 7, 4, -1e6, 1e6, 3);
    wg_image_row(in, 0)[0] = 3e38f;
    wg_image_row(in, 0)[3] = -0.0f;
    for (int port = 0; port < 4; port++) {
        WgImage *out = split_port(in, port, 1);
        assert_int_equal(out->channels, 1);
        for (int y = 0; y < 7; y++)
            for (int x = 0; x < 19; x++)
                assert_memory_equal(&wg_image_row(out, y)[x], &wg_image_row(in, y)[4 * x + port],
                                    sizeof(float));
        WgImage *t4 = split_port(in, port, 4);
        wgt_assert_identical(out, t4);
        wg_image_unref(t4);
        wg_image_unref(out);
    }
    wg_image_unref(in);
}

static void test_gray_promoted(void **state)
{
    (void)state;
    float v[] = {0.25f, -2, 7};
    WgImage *in = ct_row(1, 3, v);
    for (int port = 0; port < 4; port++) {
        WgImage *out = split_port(in, port, 1);
        for (int i = 0; i < 3; i++) assert_true(wgt_px(out, i, 0, 0) == (port == 3 ? 1.0f : v[i]));
        wg_image_unref(out);
    }
    wg_image_unref(in);
}

static void test_split_merge_round_trip(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(33, 17, 4, -3, 3, 9);
    WgGraph *g =
        wgt_load("<wetgraph version=\"1\" size=\"33x17\">\n"
                 "  <input name=\"c\" type=\"color\"/>\n"
                 "  <node id=\"s\" type=\"split\"><in name=\"source\" from=\"$c\"/></node>\n"
                 "  <node id=\"m\" type=\"merge\">\n"
                 "    <in name=\"r\" from=\"s.r\"/><in name=\"g\" from=\"s.g\"/>\n"
                 "    <in name=\"b\" from=\"s.b\"/><in name=\"a\" from=\"s.a\"/>\n"
                 "  </node>\n"
                 "  <output name=\"out\" from=\"m\"/>\n"
                 "</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "c", in, &err), WG_OK);
    WgEngineOptions opt = {2, 0, NULL};
    WgEngine *e = NULL;
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) fail_msg("render: %s", err.message);
    wgt_assert_identical(in, wgt_output(res, "out"));
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
    wg_image_unref(in);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_copies),
        cmocka_unit_test(test_gray_promoted),
        cmocka_unit_test(test_split_merge_round_trip),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
