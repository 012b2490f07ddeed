/* SPDX-License-Identifier: MIT */
/* Uniform images: the outputs of WG_NODE_UNIFORM nodes (`uniform`, `statistics`) are one row of
 * memory for all rows (stride 0). Every way an image is read must see the same pixels as in a
 * full image of the same value: the consumers below are fed once by a `uniform` node and once by
 * a `pixel` node computing the same constant into a full image, and must agree bit for bit.
 * Also: the memory the render counts, the disk cache, writing the image to files, and
 * wg_image_convert. */
#include "wgtest.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* A graph whose source `src` is either a uniform node or a full image of the same value. */
static char *graph_with(const char *src, const char *rest)
{
    static char xml[4096];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"48x40\" seed=\"5\">\n%s\n%s</wetgraph>\n", src, rest);
    return xml;
}

static const char *const uniform_gray = "  <node id=\"src\" type=\"uniform\" value=\"0.3125\"/>";
static const char *const full_gray = "  <node id=\"src\" type=\"pixel\" expr=\"0.3125\"/>";
static const char *const uniform_color =
    "  <node id=\"src\" type=\"uniform\" kind=\"color\" color=\"0.25 0.5 0.75 1\"/>";
static const char *const full_color =
    "  <node id=\"src\" type=\"pixel\" kind=\"color\" expr=\"rgba(0.25, 0.5, 0.75, 1)\"/>";

/* Renders `rest` after each source (no fusion and with fusion) and compares output `out`. */
static void assert_same_as_full(const char *uniform, const char *full, const char *rest)
{
    for (int fuse = 0; fuse < 2; fuse++) {
        WgImage *got[2] = {NULL, NULL};
        const char *srcs[2] = {uniform, full};
        for (int k = 0; k < 2; k++) {
            WgGraph *g = wgt_load(graph_with(srcs[k], rest));
            WgEngineOptions opt = {.threads = 2, .no_fuse = !fuse};
            WgEngine *e = NULL;
            WgError err = {0};
            assert_int_equal(wg_engine_new(&opt, &e, &err), WG_OK);
            WgRequest *r = wg_request_new(g);
            WgResult *res = wgt_render_request(e, r);
            got[k] = wg_image_ref(wgt_output(res, "out"));
            wg_result_free(res);
            wg_request_free(r);
            wg_engine_free(e);
            wg_graph_free(g);
        }
        assert_int_not_equal(got[1]->stride, 0);
        wgt_assert_identical(got[0], got[1]);
        wg_image_unref(got[0]);
        wg_image_unref(got[1]);
    }
}

static void test_uniform_output_is_one_row(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(graph_with(uniform_color, "  <output name=\"out\" from=\"src\"/>\n"));
    WgResult *res = wgt_render(g, 2);
    const WgImage *img = wgt_output(res, "out");
    assert_int_equal(img->width, 48);
    assert_int_equal(img->height, 40);
    assert_int_equal(img->stride, 0);
    assert_int_equal(wg_image_bytes(img), 48 * 4 * sizeof(float));
    for (int y = 0; y < 40; y += 13)
        for (int x = 0; x < 48; x += 7) {
            assert_true(wgt_px(img, x, y, 0) == 0.25f);
            assert_true(wgt_px(img, x, y, 2) == 0.75f);
            assert_true(wgt_px(img, x, y, 3) == 1.0f);
        }
    /* the render counts one row for it */
    assert_true(wg_result_peak_bytes(res) < 48 * 40 * sizeof(float));
    wg_result_free(res);
    wg_graph_free(g);
}

static void test_point_consumers_see_the_value(void **state)
{
    (void)state;
    assert_same_as_full(uniform_gray, full_gray,
                        "  <node id=\"l\" type=\"levels\" in_low=\"0.1\" in_high=\"0.9\">"
                        "<in name=\"source\" from=\"src\"/></node>\n"
                        "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"l\"/></node>\n"
                        "  <output name=\"out\" from=\"i\"/>\n");
    assert_same_as_full(uniform_gray, full_gray,
                        "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
                        "  <node id=\"p\" type=\"pixel\" expr=\"a * b + a\"><in name=\"a\" "
                        "from=\"src\"/><in name=\"b\" from=\"n\"/></node>\n"
                        "  <output name=\"out\" from=\"p\"/>\n");
    assert_same_as_full(uniform_color, full_color,
                        "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
                        "  <node id=\"b\" type=\"blend\" mode=\"multiply\"><in name=\"foreground\" "
                        "from=\"n\"/><in name=\"background\" from=\"src\"/></node>\n"
                        "  <output name=\"out\" from=\"b\"/>\n");
}

static void test_neighbourhood_and_converting_consumers(void **state)
{
    (void)state;
    /* a filter reading windows across rows, a gray source promoted to colour, a source of
       another size resampled to the consumer's */
    assert_same_as_full(uniform_gray, full_gray,
                        "  <node id=\"b\" type=\"blur\" sigma=\"2\"><in name=\"source\" "
                        "from=\"src\"/></node>\n"
                        "  <output name=\"out\" from=\"b\"/>\n");
    assert_same_as_full(uniform_gray, full_gray,
                        "  <node id=\"c\" type=\"hsl\" saturation=\"0.5\"><in name=\"source\" "
                        "from=\"src\"/></node>\n"
                        "  <output name=\"out\" from=\"c\"/>\n");
    const char *small_u = "  <node id=\"src\" type=\"uniform\" value=\"0.7\" size=\"16\"/>";
    const char *small_f = "  <node id=\"src\" type=\"pixel\" expr=\"0.7\" size=\"16\"/>";
    assert_same_as_full(
        small_u, small_f,
        "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"src\"/></node>\n"
        "  <output name=\"out\" from=\"i\"/>\n");
    assert_same_as_full(
        uniform_gray, full_gray,
        "  <node id=\"s\" type=\"slope\"><in name=\"height\" from=\"src\"/></node>\n"
        "  <output name=\"out\" from=\"s\"/>\n");
    assert_same_as_full(uniform_color, full_color,
                        "  <node id=\"b\" type=\"blur\" sigma=\"5\"><in name=\"source\" "
                        "from=\"src\"/></node>\n"
                        "  <output name=\"out\" from=\"b\"/>\n");
}

static void test_statistics_outputs_and_the_disk_cache(void **state)
{
    (void)state;
    const char *xml =
        "<wetgraph version=\"1\" size=\"40x24\">\n"
        "  <node id=\"g\" type=\"gradient\"/>\n"
        "  <node id=\"st\" type=\"statistics\"><in name=\"source\" from=\"g\"/></node>\n"
        "  <node id=\"p\" type=\"pixel\" expr=\"(g - lo) / (hi - lo)\"><in name=\"g\" "
        "from=\"g\"/><in name=\"lo\" from=\"st.min\"/><in name=\"hi\" "
        "from=\"st.max\"/></node>\n"
        "  <output name=\"out\" from=\"p\"/>\n"
        "  <output name=\"lo\" from=\"st.min\"/>\n"
        "</wetgraph>\n";
    WgGraph *g = wgt_load(xml);
    WgRequest *r = wg_request_new(g);
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/uniform_cache", wgt_tmpdir());
    WgImage *first[2];
    for (int pass = 0; pass < 2; pass++) { /* cold, then every node from the disk */
        WgEngine *e = wgt_engine(2, 0, dir);
        WgResult *res = wgt_render_request(e, r);
        const WgImage *lo = wgt_output(res, "lo");
        assert_int_equal(lo->stride, 0);
        if (pass == 1) assert_int_equal(wgt_stat(res, "st")->cache, WG_HIT_DISK);
        const WgImage *out = wgt_output(res, "out");
        float a = wgt_px(out, 0, 0, 0), b = wgt_px(out, 39, 23, 0);
        assert_true(fminf(a, b) == 0.0f || fmaxf(a, b) == 1.0f);
        wgt_assert_range(out, 0, 1);
        if (pass == 0) {
            first[0] = wg_image_ref(out);
            first[1] = wg_image_ref(lo);
        } else {
            wgt_assert_identical(first[0], out);
            wgt_assert_identical(first[1], lo);
        }
        wg_result_free(res);
        wg_engine_free(e);
    }
    wg_image_unref(first[0]);
    wg_image_unref(first[1]);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_written_files_and_conversion(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(graph_with(uniform_color, "  <output name=\"out\" from=\"src\"/>\n"));
    WgResult *res = wgt_render(g, 1);
    const WgImage *img = wgt_output(res, "out");
    assert_int_equal(img->stride, 0);
    /* a full copy */
    WgImage *copy = wg_image_convert(img, 48, 40, 4);
    assert_non_null(copy);
    assert_int_not_equal(copy->stride, 0);
    wgt_assert_identical(copy, img);
    /* files: every row written */
    static const char *const names[] = {"u.exr", "u.png", "u.tif"};
    static const WgFormat formats[] = {WG_FORMAT_EXR32, WG_FORMAT_PNG16, WG_FORMAT_TIF16};
    for (int k = 0; k < 3; k++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", wgt_tmpdir(), names[k]);
        WgError err = {0};
        assert_int_equal(wg_image_write(path, img, formats[k], WG_LINEAR, &err), WG_OK);
        WgImage *back = NULL;
        assert_int_equal(wg_image_read(path, 4, WG_LINEAR, &back, &err), WG_OK);
        wgt_assert_near(back, copy, k == 0 ? 0 : 1.0 / 65535);
        wg_image_unref(back);
    }
    wg_image_unref(copy);
    wg_result_free(res);
    wg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_uniform_output_is_one_row),
        cmocka_unit_test(test_point_consumers_see_the_value),
        cmocka_unit_test(test_neighbourhood_and_converting_consumers),
        cmocka_unit_test(test_statistics_outputs_and_the_disk_cache),
        cmocka_unit_test(test_written_files_and_conversion),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
