/* SPDX-License-Identifier: MIT */
/* The page of `wetgraph watch --serve` in a real browser: Debian's chromium, headless, loads
 * it with ?set=level=0.6&events=0 (no open /events connection, which would keep its virtual
 * clock waiting) and dumps the DOM the script built. The DOM must hold a slider for the
 * float parameter `level` with its declared range, a menu for the enum, the output's image
 * loaded (the page marks a figure with data-loaded once its image has loaded) and shown in
 * gray, and, with no dot in the watch session's PATH, the list of the graph's nodes; the watch
 * session must have rendered with level=0.6 (the page applied the address's setting). On a
 * graph that reads $time and has an image input, with a stand-in dot in PATH, the page
 * (?cmap=turbo&play=3&big=height) shows the picture, shows the output enlarged, draws the gray
 * output through the turbo colour map (the canvas pixel the page reads back is not gray),
 * plays three frames and pauses, and the command line it offers has --time; the last frame's
 * output file is the one `wetgraph render --time T` writes for the time the page shows. With
 * /events open (as a person's browser has it), ?play=3 renders three frames too. A page from
 * elsewhere (a file) that aims an image, fetches and a form at /api/set changes nothing, and the
 * real page's change is then the only one. Fails with a
 * clear message when chromium is not installed (scripts/install-deps.sh installs it). chromium
 * runs under `timeout` with a virtual time budget (a harness limit, not a timing assertion).
 * Runs WETGRAPH_BIN. */
#include "wgtest.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

enum { LIMIT_MS = 30000 };

static const char graph[] =
    "<wetgraph version=\"1\" size=\"64\">\n"
    "  <param name=\"level\" type=\"float\" default=\"0.25\" min=\"0\" max=\"2\"/>\n"
    "  <param name=\"mode\" type=\"enum\" values=\"a b\" default=\"a\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=level\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"multiply\">\n"
    "    <in name=\"foreground\" from=\"n\"/><in name=\"background\" from=\"u\"/>\n"
    "  </node>\n"
    "  <output name=\"c\" from=\"mix\" format=\"png\"/>\n"
    "</wetgraph>\n";

/* gray, changing with $time, with an image input that has no default (as foam's shore) */
static const char animated[] =
    "<wetgraph version=\"1\" size=\"64\">\n"
    "  <input name=\"shape\" type=\"gray\"/>\n"
    "  <param name=\"speed\" type=\"float\" default=\"1\" min=\"0\" max=\"4\"/>\n"
    "  <node id=\"wave\" type=\"pixel\" expr=\"fract(x + y + $time)\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"multiply\">\n"
    "    <in name=\"foreground\" from=\"$shape\"/><in name=\"background\" from=\"wave\"/>\n"
    "  </node>\n"
    "  <output name=\"height\" from=\"mix\" format=\"png\"/>\n"
    "</wetgraph>\n";

static char dir[1024];
static pid_t watcher, chromium; /* chromium: the `timeout` running it in the background */

/* Stop the background chromium (timeout passes SIGTERM on) and wait for it to be gone. */
static void stop_chromium(void)
{
    if (chromium <= 0) return;
    kill(chromium, SIGTERM);
    for (int waited = 0; kill(chromium, 0) == 0 && waited < LIMIT_MS; waited += 5) wgt_sleep_ms(5);
    chromium = 0;
}

static const char *path(const char *name)
{
    return wgt_join(dir, name);
}

static int count_in(const char *file, const char *needle)
{
    return wgt_count_in(path(file), needle);
}

static void wait_for(const char *needle, int count)
{
    wgt_wait_for(watcher, path("werr"), needle, count, LIMIT_MS);
}

/* SIGTERM ends the session cleanly. */
static void stop(void)
{
    int st = wgt_stop(watcher, SIGTERM, LIMIT_MS);
    watcher = 0;
    assert_true(WIFEXITED(st) && WEXITSTATUS(st) == 0);
}

/* WETGRAPH_BIN; fails the test when it is not set or chromium is not installed. */
static const char *need_chromium(void)
{
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) fail_msg("WETGRAPH_BIN is not set");
    if (wgt_shell(dir, "command -v chromium"))
        fail_msg("chromium is not installed: the page test needs Debian's chromium "
                 "(scripts/install-deps.sh installs it)");
    return bin;
}

/* Load the page at http://127.0.0.1:port/query in headless chromium, its DOM into dom.html (a
 * virtual time budget, and `timeout` as the harness limit). */
static void dump_dom(int port, const char *query)
{
    int st = wgt_shell(dir,
                       "timeout 60 chromium --headless=new --no-sandbox --disable-gpu "
                       "--user-data-dir=profile --virtual-time-budget=5000 --window-size=1200,800 "
                       "--dump-dom 'http://127.0.0.1:%d/%s' >dom.html 2>chromium.log",
                       port, query);
    if (st) fail_msg("chromium failed (status %d): see %s", st, path("chromium.log"));
}

/* Start watch on g.wetgraph with PATH set to path_dir (a folder of the test's folder: "bin"
 * holds a stand-in dot, "nobin" nothing) and input (an --input value, or NULL); returns the
 * port it serves. */
static int start(const char *path_dir, const char *input)
{
    mkdir(path("bin"), 0777);
    mkdir(path("nobin"), 0777);
    wgt_write_file(path("bin/dot"),
                   "#!/bin/sh\n"
                   "PATH=/usr/bin:/bin\n"
                   "cat >/dev/null\n"
                   "echo '<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"120\" "
                   "height=\"40\"><text x=\"4\" y=\"24\">stand-in</text></svg>'\n");
    chmod(path("bin/dot"), 0755);
    unlink(path("werr"));
    int port = wgt_free_port();
    char spec[64];
    snprintf(spec, sizeof spec, "127.0.0.1:%d", port);
    const char *args[] = {
        "watch", "g.wetgraph", "-o", "o", "--serve", spec, input ? "--input" : NULL, input, NULL};
    watcher = wgt_spawn(dir, "wout", "werr", path(path_dir), args);
    return port;
}

static void test_serve_page(void **state)
{
    (void)state;
    const char *bin = need_chromium();
    wgt_write_file(path("g.wetgraph"), graph);
    int port = start("nobin", NULL);
    wait_for("watch: waiting", 1);
    dump_dom(port, "?set=level=0.6&events=0");
    if (!count_in("dom.html", "<input type=\"range\" min=\"0\" max=\"2\""))
        fail_msg("the page built no slider for 'level' (%s)", path("dom.html"));
    assert_int_equal(count_in("dom.html", "id=\"param-level\""), 1);
    assert_int_equal(count_in("dom.html", "<select id=\"param-mode\""), 1);
    if (!count_in("dom.html", "<figure id=\"out-c\" data-channels=\"1\" data-map=\"gray\" "
                              "data-loaded="))
        fail_msg("the page did not load the image of output 'c' (%s)", path("dom.html"));
    /* no dot: the graph is a list of its nodes */
    assert_int_equal(count_in("dom.html", "<ul id=\"nodes\"><li>n (noise)"), 1);
    assert_int_equal(count_in("dom.html", "<li>mix (blend)"), 1);
    assert_int_equal(count_in("dom.html", "<div id=\"timebox\" hidden=\"\">"), 1);
    wait_for("watch: waiting", 2); /* the render of ?set=level=0.6 */
    assert_int_equal(wgt_shell(dir, "'%s' render g.wetgraph --set level=0.6 -o cli -q", bin), 0);
    assert_true(wgt_same_file(path("o/g_c.png"), path("cli/g_c.png")));
    stop();
}

/* The value of attribute name="..." in the first element holding needle, or "". */
static const char *attr(const char *needle, const char *name)
{
    static char value[256];
    size_t size;
    char *dom = wgt_read_file(path("dom.html"), &size), key[64];
    value[0] = '\0';
    char *el = strstr(dom, needle), *end = el ? strchr(el, '>') : NULL;
    snprintf(key, sizeof key, " %s=\"", name);
    char *at = el ? strstr(el, key) : NULL;
    if (at && at < end) {
        at += strlen(key);
        snprintf(value, sizeof value, "%.*s", (int)strcspn(at, "\""), at);
    }
    free(dom);
    return value;
}

static void test_serve_page_false_colour_and_play(void **state)
{
    (void)state;
    const char *bin = need_chromium();
    wgt_write_file(path("shape.wetgraph"), "<wetgraph version=\"1\" size=\"64\">"
                                           "<node id=\"n\" type=\"noise\" scale=\"4\"/>"
                                           "<output name=\"s\" from=\"n\" format=\"png\"/>"
                                           "</wetgraph>\n");
    assert_int_equal(wgt_shell(dir, "'%s' render shape.wetgraph -o . -q", bin), 0);
    wgt_write_file(path("g.wetgraph"), animated);
    int port = start("bin", "shape=shape_s.png");
    wait_for("watch: waiting", 1);
    dump_dom(port, "?cmap=turbo&play=3&big=height&events=0");
    /* the picture dot drew */
    assert_int_equal(
        count_in("dom.html", "<img id=\"graph\" alt=\"the graph\" src=\"/graph.svg?v="), 1);
    /* the gray output through turbo: the pixel read back from the canvas is coloured */
    if (strcmp(attr("<figure id=\"out-height\"", "data-map"), "turbo"))
        fail_msg("the output is not shown through turbo (%s)", path("dom.html"));
    int r = -1, g = -1, b = -1;
    if (sscanf(attr("<figure id=\"out-height\"", "data-sample"), "%d,%d,%d", &r, &g, &b) != 3)
        fail_msg("no pixel read back from the canvas (%s)", path("dom.html"));
    if (r == g && g == b) fail_msg("the canvas pixel %d,%d,%d is gray", r, g, b);
    assert_string_equal(attr("<figure id=\"out-height\"", "class"), "big"); /* ?big=height */
    /* three frames played, then paused, at a time after 0 */
    assert_string_equal(attr("<button id=\"play\"", "data-frames"), "3");
    assert_string_equal(attr("<button id=\"play\"", "data-playing"), "false");
    char t[64];
    snprintf(t, sizeof t, "%s", attr("<span id=\"tval\"", "data-t"));
    if (!(atof(t) > 0)) fail_msg("$time did not advance: '%s' (%s)", t, path("dom.html"));
    assert_int_equal(count_in("dom.html", "<div id=\"timebox\">"), 1);
    char cmd[128]; /* Save as --set: the time too */
    snprintf(cmd, sizeof cmd, "wetgraph render g.wetgraph --time %s</textarea>", t);
    if (count_in("dom.html", cmd) != 1) fail_msg("no '%s' in %s", cmd, path("dom.html"));
    wait_for("watch: waiting", 4); /* the first render and three frames */
    assert_int_equal(
        wgt_shell(dir, "'%s' render g.wetgraph --input shape=shape_s.png --time %s -o cli -q", bin,
                  t),
        0);
    if (!wgt_same_file(path("o/g_height.png"), path("cli/g_height.png")))
        fail_msg("the last frame is not the render at $time = %s", t);
    stop();
}

/* Playing with /events open (as in a browser a person uses): the page hears of each frame
 * through the event stream. chromium's virtual clock never runs out with the stream open, so it
 * runs in the background until the three frames have rendered, and is then stopped. */
static void test_serve_page_plays_with_events(void **state)
{
    (void)state;
    const char *bin = need_chromium();
    assert_int_equal(wgt_shell(dir, "'%s' render shape.wetgraph -o . -q", bin), 0);
    wgt_write_file(path("g.wetgraph"), animated);
    int port = start("nobin", "shape=shape_s.png");
    wait_for("watch: waiting", 1);
    unlink(path("chromium.pid"));
    assert_int_equal(wgt_shell(dir,
                               "timeout 60 chromium --headless=new --no-sandbox --disable-gpu "
                               "--user-data-dir=profile2 --virtual-time-budget=5000 "
                               "--window-size=1200,800 --dump-dom "
                               "'http://127.0.0.1:%d/?play=3' >dom2.html 2>chromium2.log & "
                               "echo $! >chromium.pid",
                               port),
                     0);
    size_t size;
    char *text = wgt_read_file(path("chromium.pid"), &size);
    chromium = atoi(text);
    free(text);
    assert_true(chromium > 0);
    wait_for("watch: waiting", 4); /* the first render and three frames */
    stop_chromium();
    stop();
}

/* Another site's page cannot drive the session: a page from elsewhere (a file, so its origin is
 * not the server's) that loads /api/set as an image, POSTs to it with fetch (with and without a
 * made-up token) and submits a form to it, and tries to read /api/state, changes nothing and
 * reads nothing; the real page then still applies its ?set=, and the next render's --set list
 * (the command line the page offers) holds only that change. */
static void test_serve_page_other_site_cannot_drive(void **state)
{
    (void)state;
    need_chromium();
    wgt_write_file(path("g.wetgraph"), graph);
    int port = start("nobin", NULL);
    wait_for("watch: waiting", 1);
    char page[4096];
    snprintf(page, sizeof page,
             "<!DOCTYPE html><html><body>\n"
             "<img src=\"http://127.0.0.1:%d/api/set?mode=b&amp;level=2\">\n"
             "<iframe name=\"sink\"></iframe>\n"
             "<form id=\"f\" method=\"POST\" target=\"sink\" "
             "action=\"http://127.0.0.1:%d/api/set?level=1.5\">"
             "<input name=\"mode\" value=\"b\"></form>\n"
             "<script>\n"
             "const u='http://127.0.0.1:%d';\n"
             "fetch(u+'/api/set?mode=b&level=2',{method:'POST',mode:'no-cors',"
             "body:new URLSearchParams([['mode','b']])}).catch(()=>{});\n"
             "fetch(u+'/api/set?mode=b',{method:'POST',headers:{'X-Wetgraph-Token':'0'}})"
             ".catch(()=>{});\n"
             "fetch(u+'/api/state').then(r=>r.text()).then(t=>{document.body.dataset.read=t})"
             ".catch(()=>{document.body.dataset.read='refused'});\n"
             "document.getElementById('f').submit();\n"
             "</script></body></html>\n",
             port, port, port);
    wgt_write_file(path("elsewhere.html"), page);
    int st = wgt_shell(dir,
                       "timeout 60 chromium --headless=new --no-sandbox --disable-gpu "
                       "--user-data-dir=profile3 --virtual-time-budget=3000 "
                       "--dump-dom 'file://%s' >dom3.html 2>chromium3.log",
                       path("elsewhere.html"));
    if (st) fail_msg("chromium failed (status %d): see %s", st, path("chromium3.log"));
    if (count_in("dom3.html", "\"params\"")) fail_msg("the other page read the state");
    /* the real page's change, and the page loaded again shows what the render used */
    dump_dom(port, "?set=level=0.6&events=0");
    wait_for("watch: waiting", 2);
    dump_dom(port, "?events=0");
    if (count_in("dom.html", "wetgraph render g.wetgraph --set level=0.6</textarea>") != 1)
        fail_msg("the render used more than the page's change (%s)", path("dom.html"));
    assert_int_equal(count_in("werr", "watch: rendered"), 2);
    stop();
}

static int stop_watcher(void **state)
{
    (void)state;
    stop_chromium();
    wgt_kill(watcher);
    watcher = 0;
    return 0;
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s/serve_page", wgt_tmpdir());
    mkdir(dir, 0777);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_serve_page, stop_watcher),
        cmocka_unit_test_teardown(test_serve_page_false_colour_and_play, stop_watcher),
        cmocka_unit_test_teardown(test_serve_page_plays_with_events, stop_watcher),
        cmocka_unit_test_teardown(test_serve_page_other_site_cannot_drive, stop_watcher),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
