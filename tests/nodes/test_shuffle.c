/* SPDX-License-Identifier: MIT */
/* `shuffle`: identity by default, swaps, copies, constants, gray promotion, bad source names,
 * threads. */
#include "colortest.h"

static void check(const char *attrs, const int src[4])
{
    WgImage *in = ct_random_image(21, 11, 4, -1e6, 1e6, 17);
    WgImage *out = ct_source("shuffle", attrs, in);
    for (int y = 0; y < 11; y++)
        for (int x = 0; x < 21; x++)
            for (int k = 0; k < 4; k++) {
                float want = src[k] == 4 ? 0.0f : src[k] == 5 ? 1.0f : wgt_px(in, x, y, src[k]);
                if (wgt_px(out, x, y, k) != want)
                    fail_msg("%s: (%d, %d) channel %d = %g, expected %g", attrs, x, y, k,
                             wgt_px(out, x, y, k), want);
            }
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_mappings(void **state)
{
    (void)state;
    check("", (int[]){0, 1, 2, 3});
    check("r=\"b\" b=\"r\"", (int[]){2, 1, 0, 3});
    check("a=\"one\"", (int[]){0, 1, 2, 5});
    check("r=\"a\" g=\"a\" b=\"a\" a=\"one\"", (int[]){3, 3, 3, 5});
    check("r=\"zero\" g=\"r\" b=\"g\" a=\"b\"", (int[]){4, 0, 1, 2});
}

static void test_gray_promoted(void **state)
{
    (void)state;
    float v[] = {0.25f, -2};
    WgImage *in = ct_row(1, 2, v);
    WgImage *out = ct_source("shuffle", "r=\"a\" a=\"g\"", in);
    for (int i = 0; i < 2; i++) {
        assert_true(wgt_px(out, i, 0, 0) == 1.0f);
        assert_true(wgt_px(out, i, 0, 1) == v[i]);
        assert_true(wgt_px(out, i, 0, 3) == v[i]);
    }
    wg_image_unref(out);
    wg_image_unref(in);
}

static void test_bad_source(void **state)
{
    (void)state;
    WgImage *in = ct_random_image(4, 4, 4, 0, 1, 1);
    const char *names[] = {"source"};
    const WgImage *images[] = {in};
    WgError err;
    assert_int_equal(wgt_node_error("shuffle", "g=\"one1\"", 4, 4, 1, names, images, &err),
                     WG_ERR_TYPE);
    wgt_assert_error(&err, WG_ERR_TYPE, 0, "zero, one");
    wg_image_unref(in);
}

static void test_threads(void **state)
{
    (void)state;
    ct_assert_thread_invariant("shuffle", "r=\"g\" g=\"b\" b=\"r\" a=\"zero\"", "source", 4, -1, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mappings),
        cmocka_unit_test(test_gray_promoted),
        cmocka_unit_test(test_bad_source),
        cmocka_unit_test(test_threads),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
