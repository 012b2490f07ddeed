/* SPDX-License-Identifier: MIT */
/* `merge`: all inputs, some inputs with the default or given constants, no inputs, gray-only
 * ports, threads. */
#include "colortest.h"

static void test_all_connected(void **state)
{
    (void)state;
    WgImage *c[4];
    for (int k = 0; k < 4; k++) c[k] = ct_random_image(23, 9, 1, -1e6, 1e6, 10 + (uint64_t)k);
    const char *names[] = {"r", "g", "b", "a"};
    const WgImage *images[] = {c[0], c[1], c[2], c[3]};
    WgImage *out = wgt_node("merge", "", 23, 9, 4, names, images, 0, 1);
    assert_int_equal(out->channels, 4);
    for (int y = 0; y < 9; y++)
        for (int x = 0; x < 23; x++)
            for (int k = 0; k < 4; k++) assert_true(wgt_px(out, x, y, k) == wgt_px(c[k], x, y, 0));
    WgImage *t4 = wgt_node("merge", "", 23, 9, 4, names, images, 0, 4);
    wgt_assert_identical(out, t4);
    wg_image_unref(t4);
    wg_image_unref(out);
    /* inputs given in another order connect by name */
    const char *names2[] = {"a", "b", "g", "r"};
    const WgImage *images2[] = {c[3], c[2], c[1], c[0]};
    WgImage *out2 = wgt_node("merge", "", 23, 9, 4, names2, images2, 0, 1);
    for (int y = 0; y < 9; y++)
        for (int x = 0; x < 23; x++)
            for (int k = 0; k < 4; k++) assert_true(wgt_px(out2, x, y, k) == wgt_px(c[k], x, y, 0));
    wg_image_unref(out2);
    for (int k = 0; k < 4; k++) wg_image_unref(c[k]);
}

static void test_unconnected_defaults(void **state)
{
    (void)state;
    WgImage *g = ct_random_image(5, 3, 1, 0, 1, 4);
    const char *names[] = {"g"};
    const WgImage *images[] = {g};
    WgImage *out = wgt_node("merge", "", 5, 3, 1, names, images, 0, 1);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 5; x++) {
            assert_true(wgt_px(out, x, y, 0) == 0.0f);
            assert_true(wgt_px(out, x, y, 1) == wgt_px(g, x, y, 0));
            assert_true(wgt_px(out, x, y, 2) == 0.0f);
            assert_true(wgt_px(out, x, y, 3) == 1.0f);
        }
    wg_image_unref(out);
    /* constants from the parameters; a connected input wins over its parameter */
    out = wgt_node("merge", "r=\"0.25\" g=\"9\" b=\"-1\" a=\"0.5\"", 5, 3, 1, names, images, 0, 1);
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 5; x++) {
            assert_true(wgt_px(out, x, y, 0) == 0.25f);
            assert_true(wgt_px(out, x, y, 1) == wgt_px(g, x, y, 0));
            assert_true(wgt_px(out, x, y, 2) == -1.0f);
            assert_true(wgt_px(out, x, y, 3) == 0.5f);
        }
    wg_image_unref(out);
    wg_image_unref(g);
}

static void test_nothing_connected(void **state)
{
    (void)state;
    WgImage *out = wgt_node("merge", "r=\"0.1\" b=\"0.3\"", 7, 2, 0, NULL, NULL, 0, 1);
    assert_int_equal(out->width, 7);
    assert_int_equal(out->height, 2);
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 7; x++) {
            assert_true(wgt_px(out, x, y, 0) == 0.1f);
            assert_true(wgt_px(out, x, y, 1) == 0.0f);
            assert_true(wgt_px(out, x, y, 2) == 0.3f);
            assert_true(wgt_px(out, x, y, 3) == 1.0f);
        }
    wg_image_unref(out);
}

static void test_colour_on_gray_port_is_an_error(void **state)
{
    (void)state;
    WgImage *c = ct_random_image(4, 4, 4, 0, 1, 1);
    const char *names[] = {"r"};
    const WgImage *images[] = {c};
    WgError err;
    assert_int_equal(wgt_node_error("merge", "", 4, 4, 1, names, images, &err), WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 0, "input 'r' takes a gray image");
    wg_image_unref(c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_all_connected),
        cmocka_unit_test(test_unconnected_defaults),
        cmocka_unit_test(test_nothing_connected),
        cmocka_unit_test(test_colour_on_gray_port_is_an_error),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
