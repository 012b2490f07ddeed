/* SPDX-License-Identifier: MIT */
/* The memory budget is kept: a render that is accepted stays within the budget plus the fixed
 * overhead docs/engine.md states, measured as the peak resident memory of a forked child that
 * decodes an image file, renders with two threads and encodes the result; the engine's
 * own count of image memory never exceeds the budget for any thread count; and a render whose
 * nodes' working memory (not only their outputs) cannot fit is refused before any node runs,
 * naming the largest need. The resident-memory assertion is skipped under AddressSanitizer,
 * whose shadow memory and quarantine inflate the resident size. */
#include "wgtest.h"

#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#if defined(__SANITIZE_ADDRESS__)
#define UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define UNDER_ASAN 1
#endif
#endif
#ifndef UNDER_ASAN
#define UNDER_ASAN 0
#endif

#define MIB ((size_t)1 << 20)
/* The part of the stated overhead a render adds on top of a process that has already loaded
 * the libraries: strips of rows, decoders' row buffers, thread stacks, allocator metadata. */
#define RENDER_SLACK (16 * MIB)

static double pattern(int x, int y, int k)
{
    return 0.5 + 0.45 * sin(x * 0.031 * (k + 1) + y * 0.017) * cos(y * 0.023 - x * 0.011 * k);
}

/* An image file, a levels and an exact blur of it, and a parallel branch, blended: at 2048²
 * colour every image is 64 MiB. The outputs alone peak at 192 MiB in plan order; the blur's
 * own image and the decoding come on top. */
static const char *graph_xml(void)
{
    static char xml[2048];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"2048\">\n"
             "  <node id=\"src\" type=\"image\" path=\"%s\"/>\n"
             "  <node id=\"a\" type=\"levels\" in_low=\"0.1\" in_high=\"0.9\">"
             "<in name=\"source\" from=\"src\"/></node>\n"
             "  <node id=\"b\" type=\"blur\" sigma=\"0.125\" quality=\"exact\">"
             "<in name=\"source\" from=\"a\"/></node>\n"
             "  <node id=\"c\" type=\"invert\"><in name=\"source\" from=\"src\"/></node>\n"
             "  <node id=\"d\" type=\"blend\" mode=\"overlay\"><in name=\"foreground\" from=\"b\"/>"
             "<in name=\"background\" from=\"c\"/></node>\n"
             "  <output name=\"out\" from=\"d\"/>\n"
             "</wetgraph>\n",
             wgt_path("big.png"));
    return xml;
}

static size_t status_kib(const char *key)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f) return 0;
    char line[256];
    size_t v = 0, n = strlen(key);
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, key, n) && line[n] == ':') v = strtoull(line + n + 1, NULL, 10);
    fclose(f);
    return v;
}

typedef struct {
    int rc;
    size_t base_kib, peak_kib;
    char message[512];
} ChildReport;

/* Render in a child with a fresh high-water mark; the child writes the output PNG too. */
static ChildReport render_in_child(const WgGraph *g, int threads, size_t budget)
{
    int fd[2];
    assert_int_equal(pipe(fd), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        close(fd[0]);
        ChildReport rep = {0};
        alarm(120); /* a hang fails the test instead of blocking it */
        int cr = open("/proc/self/clear_refs", O_WRONLY);
        bool reset = cr >= 0 && write(cr, "5", 1) == 1;
        if (cr >= 0) close(cr);
        WgEngine *e = wgt_engine(threads, budget, NULL);
        rep.base_kib = reset ? status_kib("VmRSS") : 0;
        WgRequest *r = wg_request_new(g);
        WgResult *res = NULL;
        WgError err = {0};
        rep.rc = wg_render(e, r, &res, &err);
        if (!rep.rc)
            rep.rc = wg_image_write(wgt_path("budget_out.png"), wg_result_output_image(res, 0),
                                    WG_FORMAT_PNG, WG_SRGB, &err);
        snprintf(rep.message, sizeof rep.message, "%s", err.message);
        rep.peak_kib = status_kib("VmHWM");
        if (write(fd[1], &rep, sizeof rep) != (ssize_t)sizeof rep) _exit(3);
        _exit(0); /* the parent owns the test state; no cleanup in the child */
    }
    close(fd[1]);
    ChildReport rep = {0};
    ssize_t got = read(fd[0], &rep, sizeof rep);
    close(fd[0]);
    int status = 0;
    assert_int_equal(waitpid(pid, &status, 0), pid);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || got != (ssize_t)sizeof rep)
        fail_msg("the rendering child did not finish (status 0x%x)", status);
    return rep;
}

static void test_resident_memory_stays_within_the_budget(void **state)
{
    (void)state;
    if (UNDER_ASAN) skip(); /* shadow memory and quarantine inflate the resident size */
    WgImage *src = wgt_image_fn(2048, 2048, 4, pattern);
    WgError err = {0};
    assert_int_equal(wg_image_write(wgt_path("big.png"), src, WG_FORMAT_PNG, WG_SRGB, &err), 0);
    wg_image_unref(src);
    WgGraph *g = wgt_load(graph_xml());
    /* 224 MiB holds the outputs of any step but not the blur's working memory beside them;
     * 320 MiB holds everything */
    const size_t budgets[] = {224 * MIB, 320 * MIB};
    int accepted = 0;
    for (int threads = 2; threads <= 2; threads++) { /* 2: branches run side by side */
        for (size_t k = 0; k < sizeof budgets / sizeof budgets[0]; k++) {
            ChildReport rep = render_in_child(g, threads, budgets[k]);
            if (rep.rc == WG_ERR_BUDGET) continue;
            if (rep.rc) fail_msg("%d threads, %zu MiB: %s", threads, budgets[k] / MIB, rep.message);
            accepted++;
            if (!rep.base_kib) skip(); /* no way to reset the high-water mark here */
            size_t used = (rep.peak_kib - rep.base_kib) * 1024;
            if (used > budgets[k] + RENDER_SLACK)
                fail_msg("%d threads, budget %zu MiB: the render took %.1f MiB more resident "
                         "memory (allowed: the budget + %zu MiB)",
                         threads, budgets[k] / MIB, used / (double)MIB, RENDER_SLACK / MIB);
        }
    }
    assert_int_equal(accepted, 1); /* the larger budget is enough */
    wg_graph_free(g);
}

/* Twelve independent branches meeting in a chain of blends: threads run branches out of plan
 * order, which must never take the count past the budget, even with the least budget the plan
 * accepts. */
static void test_counted_peak_stays_within_the_budget(void **state)
{
    (void)state;
    char xml[8192];
    size_t n = 0;
    n += (size_t)snprintf(xml + n, sizeof xml - n, "<wetgraph version=\"1\" size=\"128\">\n");
    for (int i = 0; i < 12; i++)
        n += (size_t)snprintf(xml + n, sizeof xml - n,
                              "  <node id=\"n%d\" type=\"noise\" scale=\"%d\" octaves=\"3\"/>\n"
                              "  <node id=\"b%d\" type=\"blur\" sigma=\"%d\"%s>"
                              "<in name=\"source\" from=\"n%d\"/></node>\n",
                              i, 2 + i, i, 1 + i % 3, i % 2 ? " size=\"256\"" : "", i);
    n += (size_t)snprintf(xml + n, sizeof xml - n,
                          "  <node id=\"m1\" type=\"blend\" mode=\"add\"><in name=\"foreground\" "
                          "from=\"b0\"/><in name=\"background\" from=\"b1\"/></node>\n");
    for (int i = 2; i < 12; i++)
        n += (size_t)snprintf(xml + n, sizeof xml - n,
                              "  <node id=\"m%d\" type=\"blend\" mode=\"screen\">"
                              "<in name=\"foreground\" from=\"b%d\"/><in name=\"background\" "
                              "from=\"m%d\"/></node>\n",
                              i, i, i - 1);
    snprintf(xml + n, sizeof xml - n, "  <output name=\"out\" from=\"m11\"/>\n</wetgraph>\n");
    WgGraph *g = wgt_load(xml);
    WgRequest *r = wg_request_new(g);
    /* the least budget the plan accepts (a refusal costs only the planning) */
    size_t lo = 1, hi = 256 * MIB;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        WgEngine *e = wgt_engine(1, mid, NULL);
        WgResult *res = NULL;
        WgError err = {0};
        int rc = wg_render(e, r, &res, &err);
        if (rc == WG_OK) {
            hi = mid;
            wg_result_free(res);
        } else {
            assert_int_equal(rc, WG_ERR_BUDGET);
            lo = mid + 1;
        }
        wg_engine_free(e);
    }
    WgResult *first = NULL;
    for (int threads = 1; threads <= 8; threads *= 2) {
        WgEngine *e = wgt_engine(threads, lo, NULL);
        WgResult *res = wgt_render_request(e, r);
        if (wg_result_peak_bytes(res) > lo)
            fail_msg("%d threads: counted peak %zu > budget %zu", threads,
                     wg_result_peak_bytes(res), lo);
        if (first)
            wgt_assert_identical(wg_result_output_image(first, 0), wg_result_output_image(res, 0));
        else
            first = res;
        if (res != first) wg_result_free(res);
        wg_engine_free(e);
    }
    wg_result_free(first);
    wg_request_free(r);
    wg_graph_free(g);
}

static void count_progress(void *user, int done, int total, const char *node)
{
    (void)done;
    (void)total;
    (void)node;
    ++*(int *)user;
}

/* The outputs fit (16 MiB each, 32 MiB at once), the blur's own image does not: refused before
 * any node runs, with the node that needs the most named. */
static void test_working_memory_that_cannot_fit_is_refused_up_front(void **state)
{
    (void)state;
    WgGraph *g = wgt_load("<wetgraph version=\"1\" size=\"1024\">\n"
                          "  <node id=\"u\" type=\"pixel\" kind=\"color\" expr=\"rgb(0.2, 0.4, 0.6)\"/>\n"
                          "  <node id=\"soft\" type=\"blur\" sigma=\"3\" quality=\"exact\">"
                          "<in name=\"source\" from=\"u\"/></node>\n"
                          "  <output name=\"out\" from=\"soft\"/>\n"
                          "</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    int calls = 0;
    wg_request_set_progress(r, count_progress, &calls);
    for (int threads = 1; threads <= 4; threads *= 4) {
        WgEngine *e = wgt_engine(threads, 40 * MIB, NULL);
        WgResult *res = NULL;
        WgError err = {0};
        assert_int_equal(wg_render(e, r, &res, &err), WG_ERR_BUDGET);
        assert_null(res);
        assert_int_equal(calls, 0);
        wgt_assert_error(&err, WG_ERR_BUDGET, 0,
                         "needs at least 48.0 MiB|budget is 40.0 MiB|--memory-budget|"
                         "the largest need of one node is 'soft' (blur): 48.0 MiB");
        wg_engine_free(e);
    }
    WgEngine *e = wgt_engine(2, 49 * MIB, NULL);
    WgResult *res = wgt_render_request(e, r);
    assert_true(wg_result_peak_bytes(res) <= 49 * MIB);
    assert_true(wg_result_peak_bytes(res) >= 48 * MIB);
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_working_memory_that_cannot_fit_is_refused_up_front),
        cmocka_unit_test(test_counted_peak_stays_within_the_budget),
        cmocka_unit_test(test_resident_memory_stays_within_the_budget),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
