/* SPDX-License-Identifier: MIT */
/* libFuzzer target for graph files. Each input is loaded from memory as a .wetgraph file
 * anchored in a temporary folder that holds one subgraph (type="fuzz_sub") and one picture
 * (fuzz.png), as the seeds in corpus/graph expect; other subgraph types resolve only to the
 * built-in graph library. If it loads, placeholder images feed the inputs without a default, it is
 * checked at 8x8, and if the plan holds at most MAX_PIXELS pixels in all it is rendered with one
 * thread under a 64 MiB budget (a valid size="16384" would take gigabytes, not find bugs). Every
 * failure must be clean: a negative status equal to err.code, with a message. Anything else,
 * and any sanitizer report, is a crash for libFuzzer. Run it through scripts/fuzz.sh. */
#include "internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define MAX_PIXELS (64 * 1024)

static WgEngine *engine;
static WgImage *gray, *color;
static char dir[400], graph_path[512], sub_path[512], png_path[512];

/* the subgraph of corpus/graph/subgraph.wetgraph and limits.wetgraph */
static const char *const sub_xml =
    "<wetgraph version=\"1\" size=\"16\">\n"
    "  <param name=\"mode\" type=\"enum\" values=\"multiply|screen|add\" default=\"screen\"/>\n"
    "  <param name=\"amount\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <input name=\"base\" type=\"color\" default=\"#808080\"/>\n"
    "  <input name=\"mask\" type=\"gray\"/>\n"
    "  <node id=\"fg\" type=\"uniform\" value=\"=amount\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"=mode\" opacity=\"=amount\">\n"
    "    <in name=\"foreground\" from=\"fg\"/>\n"
    "    <in name=\"background\" from=\"$base\"/>\n"
    "    <in name=\"mask\" from=\"$mask\"/>\n"
    "  </node>\n"
    "  <output name=\"out\" from=\"mix\"/>\n"
    "  <output name=\"mask\" from=\"$mask\"/>\n"
    "</wetgraph>\n";

static void cleanup(void)
{
    unlink(sub_path);
    unlink(png_path);
    rmdir(dir);
}

/* A failing call must say so consistently; a bad failure aborts, which libFuzzer reports. */
static int expect_clean(const char *what, int rc, const WgError *err)
{
    if (rc == WG_OK) return rc;
    if (rc > 0 || err->code != rc || !err->message[0]) {
        fprintf(stderr, "fuzz_graph: %s returned %d with err.code %d and message '%s'\n", what, rc,
                err->code, err->message);
        abort();
    }
    return rc;
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    setenv("WETGRAPH_PATH", "", 1);
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/wgfuzz-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
    if (!mkdtemp(dir)) {
        perror("fuzz_graph: mkdtemp");
        exit(1);
    }
    atexit(cleanup);
    snprintf(graph_path, sizeof graph_path, "%s/fuzz.wetgraph", dir);
    snprintf(sub_path, sizeof sub_path, "%s/fuzz_sub.wetgraph", dir);
    snprintf(png_path, sizeof png_path, "%s/fuzz.png", dir);
    FILE *f = fopen(sub_path, "w");
    if (!f || fputs(sub_xml, f) < 0 || fclose(f)) {
        perror("fuzz_graph: cannot write the subgraph");
        exit(1);
    }
    WgEngineOptions opt = {1, (size_t)64 << 20, NULL};
    WgError err = {0};
    gray = wg_image_new_zero(4, 4, 1);
    color = wg_image_new_zero(4, 4, 4);
    if (wg_engine_new(&opt, &engine, &err) || !gray || !color ||
        wg_image_write(png_path, color, WG_FORMAT_PNG, WG_SRGB, &err)) {
        fprintf(stderr, "fuzz_graph: setup failed: %s\n", err.message);
        exit(1);
    }
    return 0;
}

static long plan_pixels(const WgRequest *r)
{
    WgPlan plan;
    WgError err = {0};
    if (wg__plan_build(r, &plan, &err)) return -1;
    long px = 0;
    for (int i = 0; i < plan.n_insts; i++) px += (long)plan.insts[i].width * plan.insts[i].height;
    wg__plan_free(&plan);
    return px;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgResult *res = NULL;
    WgError err = {0};
    if (expect_clean("load", wg_graph_load_memory((const char *)data, size, graph_path, &g, &err),
                     &err))
        return 0;
    if (!(r = wg_request_new(g))) abort();
    wg_request_set_size(r, 8, 8);
    int rc = WG_OK;
    for (int i = 0; i < wg_graph_input_count(g) && !rc; i++) {
        const WgGraphInputInfo *in = wg_graph_input_info(g, i);
        if (in->has_default) continue;
        memset(&err, 0, sizeof err);
        rc = expect_clean(
            "set_input_image",
            wg_request_set_input_image(r, in->name, in->kind == WG_COLOR ? color : gray, &err),
            &err);
    }
    if (!rc) {
        memset(&err, 0, sizeof err);
        rc = expect_clean("check", wg_request_check(r, &err), &err);
    }
    if (!rc) {
        long px = plan_pixels(r);
        if (px < 0) {
            fprintf(stderr, "fuzz_graph: the plan fails to build after a passing check\n");
            abort();
        }
        if (px <= MAX_PIXELS) {
            memset(&err, 0, sizeof err);
            expect_clean("render", wg_render(engine, r, &res, &err), &err);
        }
    }
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
    return 0;
}
