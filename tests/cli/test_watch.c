/* SPDX-License-Identifier: MIT */
/* `wetgraph watch`: started in the background on a graph in a temporary folder, it renders;
 * a valid edit of the graph (saved as editors do, a new file renamed over the old one) gives
 * new outputs with the new value, and writes only the files whose image changed (or that are
 * missing); an edit of a subgraph file too; a broken edit prints the
 * error with file and line and leaves the outputs as they were; the fix renders again; the
 * session survives 100 edits in a row with broken ones among them and its resident memory does
 * not grow; SIGINT ends it with exit 0. An edit saved while a long render runs cancels that
 * render ("superseded") and the edit's render follows, with the outputs a plain render gives;
 * SIGINT during a long render stops it and ends the session. Saves made in steps (truncate,
 * pause, write) of a subgraph and of the graph, timed across the renders' reading of the files,
 * always end with the last save rendered.
 * Each wait has a harness limit (no timing assertions). Runs WETGRAPH_BIN. */
#include "wgtest.h"

#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

enum { LIMIT_MS = 30000 };

static const char sub[] = "<wetgraph version=\"1\" size=\"16\">\n"
                          "  <node id=\"u\" type=\"uniform\" value=\"%s\"/>\n"
                          "  <output name=\"out\" from=\"u\"/>\n"
                          "</wetgraph>\n";

/* A 256x256 graph: a blur keeps images of a size that a leak per edit would show in VmRSS. */
static const char graph[] =
    "<wetgraph version=\"1\" size=\"256\">\n"
    "  <param name=\"level\" type=\"float\" default=\"%s\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
    "  <node id=\"soft\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=level\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"add\">\n"
    "    <in name=\"foreground\" from=\"soft\"/><in name=\"background\" from=\"u\"/>\n"
    "  </node>\n"
    "  <node id=\"s\" type=\"sub\"/>\n"
    "  <output name=\"a\" from=\"u\" format=\"exr32\"/>\n"
    "  <output name=\"b\" from=\"s.out\" format=\"exr32\"/>\n"
    "  <output name=\"c\" from=\"mix\" format=\"exr32\"/>\n"
    "</wetgraph>\n";

static char dir[1024];
static pid_t watcher;

static const char *path(const char *name)
{
    return wgt_join(dir, name);
}

/* Save as an editor does: write a new file, rename it over the old one. */
static void save(const char *name, const char *fmt, const char *value)
{
    char tmp[64], text[8192];
    snprintf(tmp, sizeof tmp, ".%s.swp", name);
    snprintf(text, sizeof text, fmt, value);
    wgt_write_file(path(tmp), text);
    assert_int_equal(rename(path(tmp), path(name)), 0);
}

static int count_in(const char *file, const char *needle)
{
    return wgt_count_in(path(file), needle);
}

static void wait_for(const char *needle, int count)
{
    wgt_wait_for(watcher, path("err"), needle, count, LIMIT_MS);
}

/* Start watch on w.wetgraph in the test's folder (with a disk cache in folder `cache` unless it
 * is NULL), logging to out and err there. */
/* Start watch on w.wetgraph. A file saved within a tick of the clock before watch reads it may
 * still be being written, so watch reads it again (one more render, the first one superseded):
 * the files the tests have just saved are left that long first, so that every render counted
 * is one the test asked for. */
static pid_t spawn_watch(const char *cache)
{
    wgt_sleep_ms(50);
    const char *args[] = {
        "watch", "w.wetgraph", "-o", "o", "--threads", "2", cache ? "--cache" : NULL, cache, NULL};
    return wgt_spawn(dir, "out", "err", NULL, args);
}

static float value_of(const char *name)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path(name), 1, WG_LINEAR, &img, &err)) fail_msg("%s: %s", name, err.message);
    float v = wgt_px(img, 3, 5, 0);
    wg_image_unref(img);
    return v;
}

static long rss_kb(void)
{
    char p[64], line[256];
    snprintf(p, sizeof p, "/proc/%d/status", (int)watcher);
    FILE *f = fopen(p, "r");
    assert_non_null(f);
    long kb = -1;
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, "VmRSS:", 6)) kb = atol(line + 6);
    fclose(f);
    return kb;
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s/watch", wgt_tmpdir());
    mkdir(dir, 0777);
    return 0;
}

static void test_watch_session(void **state)
{
    (void)state;
    save("sub.wetgraph", sub, "0.125");
    save("w.wetgraph", graph, "0.25");
    /* under AddressSanitizer, freed memory is held in a quarantine that would look like growth;
     * without it the resident memory means what it does in a normal build (the watcher's
     * setting only: this process's is restored) */
    const char *asan = getenv("ASAN_OPTIONS");
    char *asan_before = asan ? strdup(asan) : NULL;
    if (asan) {
        char opts[1024];
        snprintf(opts, sizeof opts, "%s:quarantine_size_mb=0:thread_local_quarantine_size_kb=0",
                 asan);
        setenv("ASAN_OPTIONS", opts, 1);
    }
    watcher = spawn_watch(NULL);
    if (asan_before) setenv("ASAN_OPTIONS", asan_before, 1);
    free(asan_before);
    wait_for("watch: waiting", 1);
    assert_int_equal(count_in("err", "watch: rendered"), 1);
    assert_true(value_of("o/w_a.exr") == 0.25f);
    assert_true(value_of("o/w_b.exr") == 0.125f);

    /* a valid edit: only what depends on it runs again, and only the files whose image changed
       are written again (b's file is the same file: same inode; a's was replaced) */
    struct stat a0, b0, a1, b1;
    assert_int_equal(stat(path("o/w_a.exr"), &a0), 0);
    assert_int_equal(stat(path("o/w_b.exr"), &b0), 0);
    save("w.wetgraph", graph, "0.5");
    wait_for("watch: waiting", 2);
    assert_int_equal(count_in("err", "watch: rendered"), 2);
    assert_true(value_of("o/w_a.exr") == 0.5f);
    assert_int_equal(count_in("err", "blur"), 1);
    assert_int_equal(stat(path("o/w_a.exr"), &a1), 0);
    assert_int_equal(stat(path("o/w_b.exr"), &b1), 0);
    assert_true(a1.st_ino != a0.st_ino);
    assert_true(b1.st_ino == b0.st_ino);
    assert_int_equal(count_in("out", "o/w_b.exr"), 1); /* listed when it was written */
    assert_int_equal(count_in("out", "o/w_a.exr"), 2);

    /* a subgraph's edit; c's file, removed meanwhile, is written again although its image
       did not change */
    assert_int_equal(unlink(path("o/w_c.exr")), 0);
    save("sub.wetgraph", sub, "0.375");
    wait_for("watch: waiting", 3);
    assert_true(value_of("o/w_b.exr") == 0.375f);
    assert_true(wgt_exists(path("o/w_c.exr")));

    /* a broken edit: the error with file and line, the outputs kept */
    size_t before_size;
    char *before = wgt_read_file(path("o/w_a.exr"), &before_size);
    save("w.wetgraph", "<wetgraph version=\"1\" size=\"256\">\n  <param name=\"level\" %s\n",
         "type=\"float\" default=\"0.6\"/>\n  <node id=\"u\" type=\"uniform\" value=\"=lvl\"/>\n");
    wait_for("watch: waiting", 4);
    assert_int_equal(count_in("err", "watch: rendered"), 3);
    assert_int_equal(count_in("err", "wetgraph: error: w.wetgraph:"), 1);
    assert_int_equal(count_in("err", "the last good outputs are kept"), 1);
    size_t after_size;
    char *after = wgt_read_file(path("o/w_a.exr"), &after_size);
    assert_true(before_size == after_size && !memcmp(before, after, after_size));
    free(before);
    free(after);

    /* the fix resumes */
    save("w.wetgraph", graph, "0.75");
    wait_for("watch: waiting", 5);
    assert_int_equal(count_in("err", "watch: rendered"), 4);
    assert_true(value_of("o/w_a.exr") == 0.75f);

    /* 100 edits in a row, each a new value, every seventh one broken: the resident memory
     * stays where it was after the first few (the memory cache keeps what the last render
     * used, not every version), and the session survives */
    long first = 0;
    int broken = 0;
    for (int i = 0; i < 100; i++) {
        if (i % 7 == 3) {
            save("w.wetgraph", "<wetgraph version=\"1\" size=\"256\">\n  <param name=%s\n", "");
            broken++;
        } else {
            char value[32];
            snprintf(value, sizeof value, "%.3f", 0.3 + i / 1000.0);
            save("w.wetgraph", graph, value);
        }
        wait_for("watch: waiting", 6 + i);
        if (i == 4) first = rss_kb();
    }
    long last = rss_kb();
    print_message("VmRSS after 5 edits %ld kB, after 100 edits %ld kB\n", first, last);
    assert_true(last - first < 2048);
    assert_int_equal(count_in("err", "wetgraph: error: w.wetgraph:"), 1 + broken);
    assert_true(value_of("o/w_a.exr") == 0.399f);

    /* Ctrl-C ends the session cleanly */
    int st = wgt_stop(watcher, SIGINT, LIMIT_MS);
    assert_true(WIFEXITED(st));
    assert_int_equal(WEXITSTATUS(st), 0);
    assert_int_equal(count_in("err", "watch: stopped"), 1);
}

/* A failed assertion leaves the watcher running: stop it. */
static int stop_watcher(void **state)
{
    (void)state;
    wgt_kill(watcher);
    watcher = 0;
    return 0;
}

/* Options render refuses, and the ones watch does not take. */
static void test_watch_usage(void **state)
{
    (void)state;
    char cmd[2048];
    const char *bin = getenv("WETGRAPH_BIN");
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' watch w.wetgraph --frames 0:3 2>err2 >/dev/null",
             dir, bin);
    int st = system(cmd);
    assert_int_equal(WEXITSTATUS(st), 2);
    snprintf(cmd, sizeof cmd, "cd '%s' && '%s' watch --threads 0 w.wetgraph 2>err2 >/dev/null", dir,
             bin);
    st = system(cmd);
    assert_int_equal(WEXITSTATUS(st), 2);
    assert_true(count_in("err2", "wetgraph watch: bad --threads") == 1);
}

/* The graph with a chain of ambient occlusions on `c`: about 20 s of work on two threads (far
 * more than the harness limit allows), after a noise node that finishes at once. */
static void save_slow(const char *value)
{
    char params[256];
    snprintf(params, sizeof params, "  <param name=\"level\" type=\"float\" default=\"%s\"/>\n",
             value);
    char *text = wgt_slow_graph(params, "16", "64");
    save("w.wetgraph", "%s", text);
    free(text);
}

/* The images in two files of the test's folder are bit-identical. */
static void assert_same_image(const char *a, const char *b)
{
    wgt_assert_identical_files(path(a), path(b));
}

static void test_watch_supersedes_a_running_render(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s/watch_cancel", wgt_tmpdir());
    mkdir(dir, 0777);
    save("sub.wetgraph", sub, "0.125");
    save("w.wetgraph", graph, "0.25");
    watcher = spawn_watch("cache");
    wait_for("watch: waiting", 1);
    int entries = wgt_count_files(path("cache"), NULL);

    /* the long render has begun once its first nodes are in the disk cache; the next edit
     * arrives while the occlusions run */
    save_slow("0.5");
    wgt_wait_for_files(watcher, path("cache"), entries, LIMIT_MS);
    save("w.wetgraph", graph, "0.75");
    wait_for("watch: waiting", 2);
    assert_int_equal(count_in("err", "watch: render superseded after "), 1);
    assert_int_equal(count_in("err", "watch: rendered"), 2); /* the first and the last */
    assert_int_equal(count_in("err", "error"), 0);
    assert_true(value_of("o/w_a.exr") == 0.75f);

    /* the outputs are those of a plain render of the last state */
    /* (run in ref/, where its out and err files go: err here is the watch's log) */
    mkdir(path("ref"), 0777);
    assert_int_equal(
        wgt_shell(path("ref"), "cd .. && \"$WG\" render w.wetgraph -o ref --threads 1"), 0);
    assert_same_image("o/w_a.exr", "ref/w_a.exr");
    assert_same_image("o/w_b.exr", "ref/w_b.exr");
    assert_same_image("o/w_c.exr", "ref/w_c.exr");

    /* Ctrl-C during a long render stops it too, and the session ends cleanly */
    entries = wgt_count_files(path("cache"), NULL);
    save_slow("0.625");
    wgt_wait_for_files(watcher, path("cache"), entries, LIMIT_MS);
    int st = wgt_stop(watcher, SIGINT, LIMIT_MS);
    assert_true(WIFEXITED(st));
    assert_int_equal(WEXITSTATUS(st), 0);
    assert_int_equal(count_in("err", "watch: render stopped after "), 1);
    assert_int_equal(count_in("err", "watch: render superseded after "), 1);
    assert_true(value_of("o/w_a.exr") == 0.75f); /* the outputs of the last complete render */
}

/* Save in place without care, as some editors and scripts do: truncate the file (and close
 * it), wait, then write the new text. A read in between sees an empty file. */
static void save_in_steps(const char *name, const char *text, int pause_ms)
{
    FILE *f = fopen(path(name), "w");
    assert_non_null(f);
    fclose(f);
    if (pause_ms) wgt_sleep_ms(pause_ms);
    f = fopen(path(name), "w");
    assert_non_null(f);
    assert_int_equal(fputs(text, f) >= 0, 1);
    fclose(f);
}

/* Wait until the first pixel of file name is value (the render of the last save). */
static void wait_for_value(const char *name, float value)
{
    float now = -1;
    for (int waited = 0; waited < 8000; waited += 20) {
        if (wgt_exists(path(name)) && (now = value_of(name)) == value) return;
        wgt_sleep_ms(20);
    }
    fail_msg("%s holds %g, not %g, the value of the last save: it was not rendered", name, now,
             value);
}

/* Saves made in steps while watch reads: the graph uses a large subgraph (slow to load) and,
 * after it, a small one; the small one is saved in steps (truncate, pause, write) and saved
 * again at a time that sweeps across the next render's reading of the files, with pauses of
 * several lengths. Whatever a render read (an empty file, an error, an older text), the last
 * save is always rendered. The main graph is saved in steps the same way. */
static void test_watch_saves_in_steps(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s/watch_steps", wgt_tmpdir());
    mkdir(dir, 0777);
    char *big = malloc(1 << 21);
    assert_non_null(big);
    size_t len = (size_t)snprintf(big, 1 << 21, "<wetgraph version=\"1\" size=\"16\">\n");
    for (int i = 0; i < 12000; i++)
        len += (size_t)snprintf(big + len, (1 << 21) - len,
                                "  <node id=\"u%d\" type=\"uniform\" value=\"%g\"/>\n", i,
                                i / 12000.0);
    snprintf(big + len, (1 << 21) - len, "  <output name=\"out\" from=\"u6000\"/>\n</wetgraph>\n");
    wgt_write_file(path("big.wetgraph"), big);
    free(big);
    save("small.wetgraph", sub, "0.5");
    static const char main_graph[] = "<wetgraph version=\"1\" size=\"16\">\n"
                                     "  <node id=\"a\" type=\"big\"/>\n"
                                     "  <node id=\"b\" type=\"small\"/>\n"
                                     "  <node id=\"u\" type=\"uniform\" value=\"%s\"/>\n"
                                     "  <output name=\"a\" from=\"a.out\" format=\"exr32\"/>\n"
                                     "  <output name=\"b\" from=\"b.out\" format=\"exr32\"/>\n"
                                     "  <output name=\"u\" from=\"u\" format=\"exr32\"/>\n"
                                     "</wetgraph>\n";
    save("w.wetgraph", main_graph, "0.25");
    watcher = spawn_watch(NULL);
    wait_for("watch: waiting", 1);
    wait_for_value("o/w_b.exr", 0.5f);

    static const int first_pause[] = {0, 40, 90, 140};
    static const int small_pause[] = {0, 5, 15};
    char text[1024];
    int k = 0;
    for (int gap = 40; gap <= 200; gap += 10, k++) {
        float v1 = (float)(k * 2 + 1) / 64, v2 = (float)(k * 2 + 2) / 64;
        char value[32];
        snprintf(value, sizeof value, "%.9g", v1);
        snprintf(text, sizeof text, sub, value);
        save_in_steps("small.wetgraph", text, first_pause[k % 4]);
        wgt_sleep_ms(gap); /* the next save lands across the render the first one started */
        snprintf(value, sizeof value, "%.9g", v2);
        snprintf(text, sizeof text, sub, value);
        save_in_steps("small.wetgraph", text, small_pause[k % 3]);
        wait_for_value("o/w_b.exr", v2);
    }
    for (int gap = 0; gap <= 120; gap += 20, k++) {
        float v = (float)k / 64;
        char value[32];
        snprintf(value, sizeof value, "%.9g", v);
        snprintf(text, sizeof text, main_graph, value);
        save_in_steps("w.wetgraph", text, gap);
        wait_for_value("o/w_u.exr", v);
    }
    print_message("%d renders, %d with an error, %d superseded\n",
                  count_in("err", "watch: rendered"), count_in("err", "wetgraph: error:"),
                  count_in("err", "superseded"));
    int st = wgt_stop(watcher, SIGINT, LIMIT_MS);
    assert_true(WIFEXITED(st));
    assert_int_equal(WEXITSTATUS(st), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_watch_session, stop_watcher),
        cmocka_unit_test(test_watch_usage),
        cmocka_unit_test_teardown(test_watch_supersedes_a_running_render, stop_watcher),
        cmocka_unit_test_teardown(test_watch_saves_in_steps, stop_watcher),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
