/* SPDX-License-Identifier: MIT */
/* Reference renders: every .wetgraph file in tests/graphs is rendered with the library and each
 * output compared with tests/graphs/ref/<graph>_<output>.exr (float32) within TOLERANCE. References
 * change only through scripts/update-references.sh (WETGRAPH_UPDATE_REFERENCES=1), never by a
 * test run. */
#include "wgtest.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Float32 arithmetic is reproducible here (no fast-math, no FMA contraction on x86-64); the
 * tolerance covers libm differences between machines, far below one 16-bit step (1.5e-5). */
#define TOLERANCE 2e-6

static const char *source_dir(void)
{
    const char *s = getenv("WETGRAPH_SOURCE");
    if (!s) fail_msg("WETGRAPH_SOURCE is not set (run through meson test)");
    return s;
}

static void check_graph(const char *dir, const char *file)
{
    char path[2048];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    WgError err = {0};
    WgGraph *g = NULL;
    if (wg_graph_load(path, &g, &err)) {
        char buf[2048];
        wg_error_format(&err, buf, sizeof buf);
        fail_msg("%s", buf);
    }
    WgResult *res = wgt_render(g, 2);
    bool update =
        getenv("WETGRAPH_UPDATE_REFERENCES") && !strcmp(getenv("WETGRAPH_UPDATE_REFERENCES"), "1");
    for (int i = 0; i < wg_result_output_count(res); i++) {
        const WgImage *img = wg_result_output_image(res, i);
        char ref[2048];
        snprintf(ref, sizeof ref, "%s/ref/%s_%s.exr", dir, wg_graph_name(g),
                 wg_result_output_name(res, i));
        if (update) {
            if (wg_image_write(ref, img, WG_FORMAT_EXR32, WG_LINEAR, &err))
                fail_msg("%s: %s", ref, err.message);
            printf("updated %s\n", ref);
            continue;
        }
        WgImage *want = NULL;
        if (wg_image_read(ref, img->channels, WG_LINEAR, &want, &err))
            fail_msg("%s: %s (create references with scripts/update-references.sh)", ref,
                     err.message);
        double d = wgt_max_abs_diff(img, want);
        printf("%s %s: max difference %.3g\n", file, wg_result_output_name(res, i), d);
        if (!(d <= TOLERANCE))
            fail_msg("%s output '%s' differs from %s by %.3g (tolerance %g)", file,
                     wg_result_output_name(res, i), ref, d, TOLERANCE);
        wg_image_unref(want);
    }
    wg_result_free(res);
    wg_graph_free(g);
}

static void test_reference_graphs(void **state)
{
    (void)state;
    char dir[2048];
    snprintf(dir, sizeof dir, "%s/tests/graphs", source_dir());
    DIR *d = opendir(dir);
    assert_non_null(d);
    int count = 0;
    struct dirent *e;
    char names[256][256];
    while ((e = readdir(d)) && count < 256) {
        size_t l = strlen(e->d_name);
        if (l > 9 && !strcmp(e->d_name + l - 9, ".wetgraph"))
            snprintf(names[count++], 256, "%s", e->d_name);
    }
    closedir(d);
    qsort(names, (size_t)count, sizeof names[0], (int (*)(const void *, const void *))strcmp);
    assert_true(count >= 2);
    for (int i = 0; i < count; i++) check_graph(dir, names[i]);
}

/* Every graph of the built-in library must pass `check` with its defaults. */
static void test_builtin_graphs_load(void **state)
{
    (void)state;
    char dir[2048];
    snprintf(dir, sizeof dir, "%s/graphs", source_dir());
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *e;
    int count = 0;
    while ((e = readdir(d))) {
        size_t l = strlen(e->d_name);
        if (l <= 9 || strcmp(e->d_name + l - 9, ".wetgraph")) continue;
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        WgError err = {0};
        WgGraph *g = NULL;
        if (wg_graph_load(path, &g, &err)) fail_msg("%s: %s", path, err.message);
        wg_graph_free(g);
        count++;
    }
    closedir(d);
    assert_true(count >= 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reference_graphs),
        cmocka_unit_test(test_builtin_graphs_load),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
