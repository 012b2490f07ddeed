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
 * real page's change is then the only one. The 3D view (WebGL2 on SwiftShader): on a wet
 * material made from a shared material, its picture read back for a fixed camera matches the
 * `preview` node's within a measured bound (MEAN_BOUND), is not the clear colour, changes with
 * the camera and between the dry and the wet material, and after a parameter change given with
 * ?set= the page says the render is done and the view shows that render's maps and picture.
 * The view's other shapes: the sphere is a disc of the size its radius and distance give from
 * every side (the background in the corners, lit material inside), its picture changes with the
 * camera and the environment's rotation, and under a sky bright above and dark below its top is
 * bright and its bottom dark (the environment read in world space); the displaced grid at a
 * grazing angle is another picture than the plane, its near edge notched by the relief (the
 * plane's straight), under the plane and levelled where the liquid covers it; on a checker of
 * raised and sunken squares its picture is the plane's (the relief drawn once, by the mesh) and its
 * far edge is notched by the sunken squares. Moving the view draws at a lower resolution when
 * pictures cost more than the frame budget, and at full resolution once it stops.
 * On the foam graph, foam.frag drawn in the page matches the graph's foam mask at a fixed time.
 * A click on a node of the graph shows that node's pixels.
 * The controls built from the parameters' UI hints are driven as a person drives them
 * (tests/cli/page_driver.js, over the DevTools protocol): slider, number box, reset, colour
 * picker and folding groups set exact values.
 * Fails with a clear message when chromium is not installed (scripts/install-deps.sh installs
 * it) or gives the page no WebGL2 context. chromium
 * runs under `timeout` with a virtual time budget (a harness limit, not a timing assertion).
 * Runs WETGRAPH_BIN. */
#include "wgtest.h"

#include <arpa/inet.h>
#include <math.h>
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

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { LIMIT_MS = 30000 };

/* WebGL2 in headless chromium without a GPU: ANGLE on SwiftShader, the software renderer
 * Debian's chromium ships */
#define CHROMIUM_GL "--use-angle=swiftshader --enable-unsafe-swiftshader"

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

static void need_node(void)
{
    if (wgt_shell(dir, "command -v node"))
        fail_msg("node is not installed: the page driver needs Node.js (scripts/install-deps.sh)");
}

/* Drive the page at http://127.0.0.1:port/?query with tests/cli/page_driver.js running the
 * steps in the test folder's file `steps`, in the chromium profile profile_NAME; its output goes
 * to NAME.out and NAME.err there. Returns the output (the caller frees it), the driver's exit
 * status in *status. */
static char *drive_page(int port, const char *query, const char *steps, const char *name,
                        int *status)
{
    *status = wgt_shell(dir,
                        "node '%s/tests/cli/page_driver.js' 'http://127.0.0.1:%d/?%s' %s "
                        "profile_%s >%s.out 2>%s.err",
                        getenv("WETGRAPH_SOURCE"), port, query, steps, name, name, name);
    char file[64];
    snprintf(file, sizeof file, "%s.out", name);
    size_t size;
    return wgt_read_file(path(file), &size);
}

/* Load the page at http://127.0.0.1:port/query in headless chromium, its DOM into dom.html (a
 * virtual time budget, and `timeout` as the harness limit). */
static int budget_ms = 5000;
static void dump_dom(int port, const char *query)
{
    int st = wgt_shell(dir,
                       "timeout 120 chromium --headless=new --no-sandbox " CHROMIUM_GL
                       " --user-data-dir=profile --virtual-time-budget=%d --window-size=1200,800 "
                       "--dump-dom 'http://127.0.0.1:%d/%s' >dom.html 2>chromium.log",
                       budget_ms, port, query);
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
    assert_int_equal(count_in("dom.html", "<ul id=\"nodes\"><li data-node=\"n\" class=\"pick\">n "
                                          "(noise)"),
                     1);
    assert_int_equal(count_in("dom.html", "<li data-node=\"mix\" class=\"pick\">mix (blend)"), 1);
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
    /* the picture dot drew, in the page, and a link to it */
    assert_int_equal(count_in("dom.html", "id=\"graph\""), 1);
    assert_int_equal(count_in("dom.html", ">stand-in</text></svg><a href=\"/graph.svg?v="), 1);
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

/* ---- the 3D view ---------------------------------------------------------------------------- */

/* A wet material from a shared material (PavingStones130, in the shared folder the tests get as
 * WETGRAPH_SHARED) made by wet_material at N x N, the maps the 3D view reads as outputs, and
 * the `preview` node's picture of them at the same size: 512, the size of the environment's
 * atlas, which the node would resample to its own size (and the size the server reads the
 * environment at for the 3D view) through the 3D view's default camera at zoom 2
 * (tone mapped, sRGB-encoded, 8-bit), the material bound as graphs/wet_preview.wetgraph binds it
 * and the liquid tea (tint, absorption depth and index from its presets there), so that the
 * liquid's colour is compared too. */
enum { N = 512 };
static const char lookdev[] =
    "<wetgraph version=\"1\" size=\"512\">\n"
    "  <input name=\"environment\" type=\"color\"/>\n"
    "  <input name=\"basecolor\" type=\"color\" colorspace=\"srgb\"/>\n"
    "  <input name=\"height\" type=\"gray\"/>\n"
    "  <input name=\"normal\" type=\"color\" default=\"0.5 0.5 1 1\"/>\n"
    "  <input name=\"roughness\" type=\"gray\" default=\"0.5\"/>\n"
    "  <input name=\"ao\" type=\"gray\" default=\"1\"/>\n"
    "  <param name=\"water_level\" type=\"float\" default=\"0.6\" min=\"0\" max=\"1\"/>\n"
    "  <param name=\"height_scale\" type=\"float\" default=\"16\" min=\"0.001\" max=\"4096\"/>\n"
    "  <param name=\"liquid\" type=\"enum\" values=\"water|muddy_water|tea|milk|blood|oil\" "
    "default=\"tea\"/>\n"
    "  <node id=\"wet\" type=\"wet_material\" water_level=\"=water_level\" liquid=\"=liquid\" "
    "height_scale=\"=height_scale\">\n"
    "    <in name=\"basecolor\" from=\"$basecolor\"/><in name=\"height\" from=\"$height\"/>\n"
    "    <in name=\"normal\" from=\"$normal\"/><in name=\"roughness\" from=\"$roughness\"/>\n"
    "    <in name=\"ao\" from=\"$ao\"/>\n"
    "  </node>\n"
    "  <node id=\"range\" type=\"statistics\"><in name=\"source\" from=\"wet.height\"/></node>\n"
    "  <node id=\"under_height\" type=\"pixel\" expr=\"(h - lo) / max(hi - lo, 1e-30)\">\n"
    "    <in name=\"h\" from=\"wet.underheight\"/><in name=\"lo\" from=\"range.min\"/>"
    "<in name=\"hi\" from=\"range.max\"/>\n"
    "  </node>\n"
    "  <node id=\"water_height\" type=\"pixel\" expr=\"(h - lo) / max(hi - lo, 1e-30)\">\n"
    "    <in name=\"h\" from=\"wet.waterheight\"/><in name=\"lo\" from=\"range.min\"/>"
    "<in name=\"hi\" from=\"range.max\"/>\n"
    "  </node>\n"
    "  <node id=\"under_normal\" type=\"blend\" mode=\"copy\">\n"
    "    <in name=\"foreground\" from=\"wet.undernormal\"/><in name=\"background\" "
    "from=\"wet.normal\"/><in name=\"mask\" from=\"wet.watermask\"/>\n"
    "  </node>\n"
    "  <node id=\"env\" type=\"env_prefilter\" size=\"512\"><in name=\"environment\" "
    "from=\"$environment\"/></node>\n"
    "  <node id=\"view\" type=\"preview\" elevation=\"50\" azimuth=\"20\" zoom=\"2\" "
    "height_scale=\"=height_scale / 256\" absorption_depth=\"=2.4 / height_scale\" "
    "water_ior=\"1.334\" water_tint=\"0.8 0.4 0.1\" tonemap=\"aces\" encoding=\"linear\">\n"
    "    <in name=\"environment\" from=\"env\"/>\n"
    "    <in name=\"basecolor\" from=\"wet.underbasecolor\"/><in name=\"normal\" "
    "from=\"under_normal\"/>\n"
    "    <in name=\"roughness\" from=\"wet.underroughness\"/><in name=\"height\" "
    "from=\"under_height\"/>\n"
    "    <in name=\"ao\" from=\"wet.ao\"/><in name=\"metallic\" from=\"wet.undermetallic\"/>\n"
    "    <in name=\"specular\" from=\"wet.underspecular\"/>\n"
    "    <in name=\"water_height\" from=\"water_height\"/><in name=\"water_normal\" "
    "from=\"wet.waternormal\"/>\n"
    "    <in name=\"water_roughness\" from=\"wet.waterroughness\"/><in name=\"water_specular\" "
    "from=\"wet.waterspecular\"/>\n"
    "    <in name=\"water_mask\" from=\"wet.watermask\"/>\n"
    "  </node>\n"
    "  <output name=\"view\" from=\"view\" format=\"png\" colorspace=\"srgb\"/>\n"
    "  <output name=\"basecolor\" from=\"wet.basecolor\"/><output name=\"normal\" "
    "from=\"wet.normal\"/>\n"
    "  <output name=\"height\" from=\"wet.height\"/><output name=\"ao\" from=\"wet.ao\"/>\n"
    "  <output name=\"roughness\" from=\"wet.roughness\"/>\n"
    "  <output name=\"metallic\" from=\"wet.metallic\"/><output name=\"specular\" "
    "from=\"wet.specular\"/>\n"
    "  <output name=\"underbasecolor\" from=\"wet.underbasecolor\"/>\n"
    "  <output name=\"undernormal\" from=\"wet.undernormal\"/>\n"
    "  <output name=\"underroughness\" from=\"wet.underroughness\"/>\n"
    "  <output name=\"underheight\" from=\"wet.underheight\"/>\n"
    "  <output name=\"undermetallic\" from=\"wet.undermetallic\"/>\n"
    "  <output name=\"underspecular\" from=\"wet.underspecular\"/>\n"
    "  <output name=\"waterheight\" from=\"wet.waterheight\"/>\n"
    "  <output name=\"waternormal\" from=\"wet.waternormal\"/>\n"
    "  <output name=\"waterroughness\" from=\"wet.waterroughness\"/>\n"
    "  <output name=\"waterspecular\" from=\"wet.waterspecular\"/>\n"
    "  <output name=\"watermask\" from=\"wet.watermask\"/>\n"
    "</wetgraph>\n";

/* Start watch on lookdev.wetgraph with the shared material and environment (the environment
 * input is the 3D view's environment too: env, a file of the test's folder, or with NULL the
 * shared venice_sunset_1k.hdr); returns the port. */
static int start_lookdev_env(const char *env)
{
    const char *shared = getenv("WETGRAPH_SHARED");
    if (!shared || !shared[0]) fail_msg("WETGRAPH_SHARED is not set");
    static char in[6][4096];
    const char *m = "materials/pavingstones130_1k/PavingStones130_1K_";
    if (env)
        snprintf(in[0], sizeof in[0], "environment=%s", path(env));
    else
        snprintf(in[0], sizeof in[0], "environment=%s/env/venice_sunset_1k.hdr", shared);
    snprintf(in[1], sizeof in[1], "basecolor=%s/%sColor.jpg", shared, m);
    snprintf(in[2], sizeof in[2], "height=%s/%sDisplacement.jpg", shared, m);
    snprintf(in[3], sizeof in[3], "normal=%s/%sNormalGL.jpg", shared, m);
    snprintf(in[4], sizeof in[4], "roughness=%s/%sRoughness.jpg", shared, m);
    snprintf(in[5], sizeof in[5], "ao=%s/%sAmbientOcclusion.jpg", shared, m);
    for (int i = 0; i < 6; i++)
        if (access(strchr(in[i], '=') + 1, R_OK))
            fail_msg("the shared material file %s is missing", strchr(in[i], '=') + 1);
    wgt_write_file(path("lookdev.wetgraph"), lookdev);
    mkdir(path("nobin"), 0777);
    unlink(path("werr"));
    int port = wgt_free_port();
    char spec[64];
    snprintf(spec, sizeof spec, "127.0.0.1:%d", port);
    const char *args[] = {"watch",   "lookdev.wetgraph",
                          "-o",      "o",
                          "--serve", spec,
                          "--input", in[0],
                          "--input", in[1],
                          "--input", in[2],
                          "--input", in[3],
                          "--input", in[4],
                          "--input", in[5],
                          NULL};
    watcher = wgt_spawn(dir, "wout", "werr", path("nobin"), args);
    return port;
}

static int start_lookdev(void)
{
    return start_lookdev_env(NULL);
}

/* The 3D view's state after dump_dom: fails with its message unless it is ready. */
static void view_ready(void)
{
    char st[64];
    snprintf(st, sizeof st, "%s", attr("<figure id=\"view3d\"", "data-state"));
    if (!strcmp(st, "no-webgl2"))
        fail_msg("chromium gives the page no WebGL2 context (SwiftShader, with " CHROMIUM_GL
                 "): the 3D view cannot be tested (%s)",
                 path("dom.html"));
    if (strcmp(st, "ready"))
        fail_msg("the 3D view is '%s': %s (%s)", st, attr("<figure id=\"view3d\"", "data-error"),
                 path("dom.html"));
}

/* The n x n picture the page read back (data-probe, hex RGB from the top row) into px, and,
 * when cover is not NULL, which of its pixels are the surface rather than the background
 * (data-cover, one '0' or '1' a pixel, in the same order) into cover. */
static void probe_n(unsigned char *px, unsigned char *cover, int n)
{
    size_t size;
    char *dom = wgt_read_file(path("dom.html"), &size);
    char *at = strstr(dom, "<figure id=\"view3d\"");
    char *p = at ? strstr(at, " data-probe=\"") : NULL;
    if (!p || p > strchr(at, '>'))
        fail_msg("the 3D view read no picture back (%s)", path("dom.html"));
    p += strlen(" data-probe=\"");
    for (int i = 0; i < n * n * 3; i++) {
        unsigned v;
        if (sscanf(p + 2 * i, "%2x", &v) != 1)
            fail_msg("data-probe is shorter than %d values", n * n * 3);
        px[i] = (unsigned char)v;
    }
    if (cover) {
        char *c = strstr(at, " data-cover=\"");
        if (!c || c > strchr(at, '>')) fail_msg("the 3D view gave no data-cover");
        c += strlen(" data-cover=\"");
        if ((int)strspn(c, "01") != n * n) fail_msg("data-cover is not %d values", n * n);
        for (int i = 0; i < n * n; i++) cover[i] = c[i] == '1';
    }
    free(dom);
}

static void probe(unsigned char *px)
{
    probe_n(px, NULL, N);
}

/* px as a binary PPM in the test's folder, to look at when a comparison fails. */
static void save_ppm(const char *name, const unsigned char *px)
{
    FILE *f = fopen(path(name), "wb");
    if (!f) fail_msg("cannot write %s", path(name));
    fprintf(f, "P6 %d %d 255\n", N, N);
    fwrite(px, 1, N * N * 3, f);
    fclose(f);
}

/* Mean |a - b| over the pixels and channels, 8-bit levels; *far: the share of values more than
 * 16 levels apart. */
static double mean_diff(const unsigned char *a, const unsigned char *b, double *far)
{
    double sum = 0;
    int n = 0;
    for (int i = 0; i < N * N * 3; i++) {
        int d = abs(a[i] - b[i]);
        sum += d;
        n += d > 16;
    }
    if (far) *far = (double)n / (N * N * 3);
    return sum / (N * N * 3);
}

/* The preview node's picture the watch session wrote, as 8-bit values. */
static void cpu_view(unsigned char *px)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path("o/lookdev_view.png"), 4, WG_LINEAR, &img, &err))
        fail_msg("%s", err.message);
    assert_int_equal(img->width, N);
    assert_int_equal(img->height, N);
    for (int y = 0; y < N; y++)
        for (int x = 0; x < N; x++)
            for (int c = 0; c < 3; c++)
                px[3 * (y * N + x) + c] =
                    (unsigned char)lrintf(wg_image_row(img, y)[4 * x + c] * 255);
    wg_image_unref(img);
}

/* The bound: the mean |GPU - CPU| over the picture within 2.5 of 255 levels (8-bit, sRGB-encoded
 * after the tone curve), and at most 3% of the values more than 16 levels apart. Measured with
 * chromium's SwiftShader: 1.73 levels and 1.5% at water_level 0.6, 0.68 and 0.6% at 0.25; the
 * error gathers in the far rows, where the relief is seen at a grazing angle and one pixel
 * covers several texels. What differs: the GPU reads the rough levels of the prefiltered
 * environment from a mip chain (web/view3d.js: loadEnv) where the node reads the blocks, maps
 * at half-float precision, the normal under the liquid blended by the page rather than by the
 * graph's blend node, 8-bit rounding on both sides, and the relief's edges where one side's
 * parallax search meets a texel the other misses. For scale: the dry material against the wet
 * one differs by about 9 levels, a change of water level by about 12, another camera by tens. */
#define MEAN_BOUND 2.5
#define FAR_BOUND 0.03

static void test_view3d_matches_preview(void **state)
{
    (void)state;
    need_chromium();
    int port = start_lookdev();
    wait_for("watch: waiting", 1);
    budget_ms = 30000;
    unsigned char gpu[N * N * 3], cpu[N * N * 3], moved[N * N * 3], dry[N * N * 3];
    char q[256];
    snprintf(q, sizeof q, "?events=0&probe=%d&split=0&view=50,20,2,0", N);
    dump_dom(port, q);
    view_ready();
    probe(gpu);
    cpu_view(cpu);
    /* not the clear colour: the material and the environment are drawn */
    int clear = 0;
    for (int i = 0; i < N * N; i++)
        clear += abs(gpu[3 * i] - 18) <= 1 && abs(gpu[3 * i + 1] - 18) <= 1 &&
                 abs(gpu[3 * i + 2] - 20) <= 1;
    if (clear > N * N / 100)
        fail_msg("%d of %d pixels of the 3D view are the clear colour", clear, N * N);
    save_ppm("view_gpu.ppm", gpu);
    save_ppm("view_cpu.ppm", cpu);
    double far, mean = mean_diff(gpu, cpu, &far);
    /* the same view, all dry: the liquid's own effect */
    snprintf(q, sizeof q, "?events=0&probe=%d&split=1&view=50,20,2,0", N);
    dump_dom(port, q);
    view_ready();
    probe(dry);
    double wet_effect = mean_diff(gpu, dry, NULL);
    print_message("3D view against the preview node (%d x %d, wet): mean |GPU - CPU| %.2f of 255 "
                  "levels, %.2f%% of the values more than 16 apart; the liquid's own effect %.2f\n",
                  N, N, mean, 100 * far, wet_effect);
    if (mean > MEAN_BOUND || far > FAR_BOUND)
        fail_msg("the 3D view differs from the preview node by %.2f levels on average (bound "
                 "%.1f), %.2f%% of the values by more than 16 (bound %.0f%%)",
                 mean, MEAN_BOUND, 100 * far, 100 * FAR_BOUND);
    assert_true(wet_effect > 2 * MEAN_BOUND);
    /* another camera: another picture */
    snprintf(q, sizeof q, "?events=0&probe=%d&split=0&view=70,110,1.4,90", N);
    dump_dom(port, q);
    view_ready();
    probe(moved);
    double camera_change = mean_diff(gpu, moved, NULL);
    print_message("3D view: another camera changes the picture by %.2f levels on average\n",
                  camera_change);
    assert_true(camera_change > 4 * MEAN_BOUND);
    stop();
}

/* A parameter change reaches the 3D view once its render is done: the page opened with
 * ?set=water_level=0.25 says the render is done (<body data-render="done">), shows the maps of
 * that render (data-version), and its picture is the preview node's of that render, within the
 * bound, and not the picture before the change. */
static void test_view3d_follows_a_render(void **state)
{
    (void)state;
    need_chromium();
    int port = start_lookdev();
    wait_for("watch: waiting", 1);
    budget_ms = 30000;
    unsigned char before[N * N * 3], after[N * N * 3], cpu[N * N * 3];
    char q[256];
    snprintf(q, sizeof q, "?events=0&probe=%d&split=0&view=50,20,2,0", N);
    dump_dom(port, q);
    view_ready();
    probe(before);
    int v0 = atoi(attr("<figure id=\"view3d\"", "data-version"));
    snprintf(q, sizeof q, "?events=0&probe=%d&split=0&view=50,20,2,0&set=water_level=0.25", N);
    dump_dom(port, q);
    view_ready();
    assert_string_equal(attr("<body", "data-render"), "done");
    int v1 = atoi(attr("<figure id=\"view3d\"", "data-version"));
    if (v1 <= v0) fail_msg("the 3D view shows render %d after the change, %d before", v1, v0);
    probe(after);
    wait_for("watch: waiting", 2);
    cpu_view(cpu);
    double far, mean = mean_diff(after, cpu, &far), change = mean_diff(before, after, NULL);
    print_message("3D view after water_level=0.25: mean |GPU - CPU| %.2f levels (%.2f%% more than "
                  "16 apart); the change moved the picture by %.2f\n",
                  mean, 100 * far, change);
    if (mean > MEAN_BOUND || far > FAR_BOUND)
        fail_msg("after the change the 3D view differs from the preview node by %.2f levels", mean);
    assert_true(change > 2 * MEAN_BOUND);
    stop();
}

/* ---- the 3D view's shapes ------------------------------------------------------------------- */

enum { P = 128 }; /* the shapes' pictures read back: P x P */

/* The 3D view opened with ?events=0&probe=P& + q: fails unless it is ready and shows `shape`;
 * its picture into px and which pixels are the surface into cover. */
static void shape_view(int port, const char *q, const char *shape, unsigned char *px,
                       unsigned char *cover)
{
    char url[256];
    snprintf(url, sizeof url, "?events=0&probe=%d&%s", P, q);
    dump_dom(port, url);
    view_ready();
    if (strcmp(attr("<figure id=\"view3d\"", "data-shape"), shape))
        fail_msg("the 3D view shows '%s', not the %s (%s)",
                 attr("<figure id=\"view3d\"", "data-shape"), shape, path("dom.html"));
    probe_n(px, cover, P);
}

/* Mean |a - b| over the pixels where mask is set (all with NULL), 8-bit levels. */
static double mean_diff_in(const unsigned char *a, const unsigned char *b,
                           const unsigned char *mask)
{
    double sum = 0;
    int n = 0;
    for (int i = 0; i < P * P; i++)
        if (!mask || mask[i])
            for (int c = 0; c < 3; c++, n++) sum += abs(a[3 * i + c] - b[3 * i + c]);
    return n ? sum / n : 0;
}

/* The sphere of the 3D view (radius 0.4 about the origin, which the camera looks at from
 * 0.5 / zoom / tan(17.5 degrees)): its silhouette is a disc about the picture's centre of
 * radius tan(asin(0.4 / distance)) / tan(17.5 degrees) half-pictures. disc[i]: 1 inside by
 * more than 1.5 pixels, 0 outside by more than 1.5, 2 on the edge. Returns the radius. */
static double sphere_disc(unsigned char *disc)
{
    double th = tan(17.5 * M_PI / 180), dist = 0.5 / th;
    double r = tan(asin(0.4 / dist)) / th * P / 2;
    for (int y = 0; y < P; y++)
        for (int x = 0; x < P; x++) {
            double d = hypot(x + 0.5 - P / 2.0, y + 0.5 - P / 2.0);
            disc[y * P + x] = d < r - 1.5 ? 1 : d > r + 1.5 ? 0 : 2;
        }
    return r;
}

/* Pixels whose cover is not the disc's (off its edge). */
static int off_disc(const unsigned char *cover, const unsigned char *disc)
{
    int wrong = 0;
    for (int i = 0; i < P * P; i++) wrong += disc[i] != 2 && cover[i] != disc[i];
    return wrong;
}

/* Steps for page_driver.js: the 3D view's shape menu, used as a person uses it, redraws the view
 * on the chosen shape. */
static const char shape_steps[] =
    "const f = () => document.getElementById('view3d');\n"
    "await until(() => f() && f().dataset.state === 'ready' && f().dataset.draws, 'the 3D view');\n"
    "const s = document.getElementById('view-shape');\n"
    "const before = [f().dataset.shape, [...s.options].map(o => o.value).join(',')];\n"
    "s.value = 'sphere'; s.dispatchEvent(new Event('change'));\n"
    "await until(() => f().dataset.shape === 'sphere', 'the sphere');\n"
    "s.value = 'grid'; s.dispatchEvent(new Event('change'));\n"
    "await until(() => f().dataset.shape === 'grid', 'the grid');\n"
    "return before.concat([f().dataset.state]);\n";

/* The sphere: round from every side (the surface is the disc the sphere's size and distance
 * give, the corners the background), lit material inside (bright enough, and not the plane's
 * silhouette), and its picture changes when the camera orbits and when the environment turns;
 * the page's shape menu, driven in the page, switches the view to the sphere and the grid. */
static void test_view3d_sphere(void **state)
{
    (void)state;
    need_chromium();
    int port = start_lookdev();
    wait_for("watch: waiting", 1);
    budget_ms = 30000;
    static unsigned char a[P * P * 3], b[P * P * 3], c[P * P * 3], plane[P * P * 3];
    static unsigned char ca[P * P], cb[P * P], cc[P * P], cplane[P * P], disc[P * P];
    double r = sphere_disc(disc);
    shape_view(port, "shape=sphere&split=0&view=30,20,1,0", "sphere", a, ca);
    int wrong = off_disc(ca, disc);
    double lum = 0;
    int in = 0;
    for (int i = 0; i < P * P; i++)
        if (disc[i] == 1) in++, lum += (a[3 * i] + a[3 * i + 1] + a[3 * i + 2]) / 3.0;
    lum /= in;
    print_message("sphere: %d of %d pixels off the disc of radius %.1f; mean level inside %.1f\n",
                  wrong, P * P, r, lum);
    if (wrong)
        fail_msg("the sphere's silhouette is not the disc of radius %.1f: %d pixels off", r, wrong);
    assert_true(!ca[0] && !ca[P - 1] && !ca[P * (P - 1)] && !ca[P * P - 1]);
    if (lum < 30) fail_msg("the sphere is dark inside: mean level %.1f", lum);
    /* orbiting: the same disc, another picture in it */
    shape_view(port, "shape=sphere&split=0&view=70,140,1,0", "sphere", b, cb);
    wrong = off_disc(cb, disc);
    double orbit = mean_diff_in(a, b, disc);
    /* the environment turned: another picture on the same disc */
    shape_view(port, "shape=sphere&split=0&view=30,20,1,120", "sphere", c, cc);
    double turned = mean_diff_in(a, c, disc);
    print_message("sphere: orbiting changes the disc's picture by %.2f levels (%d pixels off the "
                  "disc), turning the environment by %.2f\n",
                  orbit, wrong, turned);
    if (wrong)
        fail_msg("seen from elevation 70, azimuth 140 the sphere is not round: %d pixels", wrong);
    assert_true(orbit > 8);
    assert_true(turned > 4);
    /* the plane through the same camera: not a disc (the shape control took effect) */
    shape_view(port, "shape=plane&split=0&view=30,20,1,0", "plane", plane, cplane);
    if (off_disc(cplane, disc) < P * P / 10)
        fail_msg("the plane's silhouette is the sphere's disc too");
    /* the menu */
    need_node();
    wgt_write_file(path("shape_steps.js"), shape_steps);
    int st;
    char *out = drive_page(port, "events=0", "shape_steps.js", "shape", &st);
    if (st) fail_msg("the page driver failed (status %d):\n%.2000s", st, out);
    if (strcmp(out, "[\"plane\",\"plane,sphere,grid\",\"ready\"]\n"))
        fail_msg("the shape menu: %s", out);
    free(out);
    stop();
}

/* The environment on the sphere is read in world space: lit by a sky that is bright above the
 * horizon and dark below (an equirectangular picture made by a pixel node), the sphere seen from
 * the side is bright on its upper half and dark on its lower half, as the background is. In its
 * own tangent frame (z along each point's normal) every point would see the bright side (measured
 * so: 167 levels above, 167 below; in world space 153 and 80). */
static void test_view3d_sphere_world_environment(void **state)
{
    (void)state;
    const char *bin = need_chromium();
    wgt_write_file(path("sky.wetgraph"),
                   "<wetgraph version=\"1\" size=\"256\"><node id=\"s\" type=\"pixel\" "
                   "expr=\"(v &lt; 0.5) * 0.98 + 0.02\"/><output name=\"sky\" from=\"s\" "
                   "format=\"png\"/></wetgraph>\n");
    assert_int_equal(wgt_shell(dir, "'%s' render sky.wetgraph -o . -q", bin), 0);
    int port = start_lookdev_env("sky_sky.png");
    wait_for("watch: waiting", 1);
    budget_ms = 30000;
    static unsigned char a[P * P * 3], ca[P * P], disc[P * P];
    double r = sphere_disc(disc);
    shape_view(port, "shape=sphere&split=1&view=5,20,1,0", "sphere", a, ca);
    double top = 0, bottom = 0, bg_top = 0, bg_bottom = 0;
    int nt = 0, nb = 0, mt = 0, mb = 0;
    for (int y = 0; y < P; y++)
        for (int x = 0; x < P; x++) {
            int i = y * P + x;
            double l = (a[3 * i] + a[3 * i + 1] + a[3 * i + 2]) / 3.0, dy = y + 0.5 - P / 2.0;
            if (disc[i] == 1 && dy < -r / 3) top += l, nt++;
            if (disc[i] == 1 && dy > r / 3) bottom += l, nb++;
            if (!ca[i] && y < P / 8) bg_top += l, mt++;
            if (!ca[i] && y >= P - P / 8) bg_bottom += l, mb++;
        }
    top /= nt, bottom /= nb, bg_top /= mt, bg_bottom /= mb;
    print_message("sphere under a sky bright above, dark below: upper part %.1f, lower part %.1f "
                  "levels; the background %.1f above, %.1f below\n",
                  top, bottom, bg_top, bg_bottom);
    if (!(bg_top > bg_bottom + 100))
        fail_msg("the sky is not bright above and dark below: %.1f, %.1f", bg_top, bg_bottom);
    if (!(top > 1.5 * bottom && top > bottom + 40))
        fail_msg("the sphere is not lit from above: upper part %.1f, lower part %.1f levels", top,
                 bottom);
    stop();
}

/* The last row from the top where cover is set in column x, or -1. */
static int bottom_row(const unsigned char *cover, int x)
{
    for (int y = P - 1; y >= 0; y--)
        if (cover[y * P + x]) return y;
    return -1;
}

/* The displaced grid against the plane at a grazing camera: another picture, and where the
 * plane's near edge is a straight line (its second differences along the edge are below a
 * pixel) the grid's near edge is its profile through the relief, notched by the joints between
 * the stones: its drop under the plane's edge varies from column to column by more than a pixel
 * (standard deviation), all dry; the wet grid's edge, where the liquid's flat surface covers
 * the joints, varies less. The grid lies at or under the plane (the tile's plane is the top of
 * the relief, height 1, and this water stays under it), lower in many columns. (The far edge,
 * at this angle, is hidden behind the stones in front of it, which fill its notches.) */
static void test_view3d_grid(void **state)
{
    (void)state;
    need_chromium();
    int port = start_lookdev();
    wait_for("watch: waiting", 1);
    budget_ms = 30000;
    static unsigned char plane[P * P * 3], grid[P * P * 3], wet[P * P * 3];
    static unsigned char cp[P * P], cg[P * P], cw[P * P];
    shape_view(port, "shape=plane&split=1&view=8,20,1,0", "plane", plane, cp);
    shape_view(port, "shape=grid&split=1&view=8,20,1,0", "grid", grid, cg);
    shape_view(port, "shape=grid&split=0&view=8,20,1,0", "grid", wet, cw);
    double change = mean_diff_in(plane, grid, NULL);
    double bend = 0, drop = 0, drop2 = 0, wdrop = 0, wdrop2 = 0;
    int cols = 0, lower = 0, above = 0;
    for (int x = 1; x < P - 1; x++) {
        int p0 = bottom_row(cp, x - 1), p1 = bottom_row(cp, x), p2 = bottom_row(cp, x + 1);
        int g1 = bottom_row(cg, x), w1 = bottom_row(cw, x);
        if (p0 < 0 || p0 == P - 1 || p1 < 0 || p1 == P - 1 || p2 < 0 || p2 == P - 1 || g1 < 0 ||
            w1 < 0)
            continue;
        cols++;
        bend += abs(p0 - 2 * p1 + p2);
        drop += g1 - p1, drop2 += (double)(g1 - p1) * (g1 - p1);
        wdrop += w1 - p1, wdrop2 += (double)(w1 - p1) * (w1 - p1);
        lower += g1 > p1 + 1;
        above += g1 < p1 - 1;
    }
    if (cols < P / 4) fail_msg("the plane's near edge is in %d columns only", cols);
    bend /= cols, drop /= cols, wdrop /= cols;
    double spread = sqrt(fmax(drop2 / cols - drop * drop, 0));
    double wspread = sqrt(fmax(wdrop2 / cols - wdrop * wdrop, 0));
    print_message("grid against plane at elevation 8, dry: the picture changes by %.2f levels; "
                  "the grid's near edge is %.2f pixels under the plane's on average, varying by "
                  "%.2f (the plane's edge bends by %.2f a column), lower in %d of %d columns, "
                  "higher in %d; wet, %.2f under, varying by %.2f\n",
                  change, drop, spread, bend, lower, cols, above, wdrop, wspread);
    assert_true(change > 1.5);
    if (!(bend < 0.5 && spread > 1))
        fail_msg("the grid's near edge shows no relief: it varies by %.2f pixels (the plane's "
                 "bends by %.2f)",
                 spread, bend);
    assert_true(lower > cols / 4);
    assert_int_equal(above, 0);
    if (!(wspread < spread))
        fail_msg("the liquid does not level the grid's edge: it varies by %.2f pixels wet, %.2f "
                 "dry",
                 wspread, spread);
    stop();
}

/* A material made to show where the relief is drawn: a checker of raised and sunken squares
 * (height 1 and 0, 1/8 of the tile wide), coloured by a sine of period 1/8 in u (red) and in v
 * (green), so that a texture coordinate seen at the wrong place changes the colour. */
static const char relief_probe[] =
    "<wetgraph version=\"1\" size=\"256\">\n"
    "  <param name=\"height_scale\" type=\"float\" default=\"16\" min=\"0\" max=\"256\"/>\n"
    "  <node id=\"h\" type=\"pixel\" expr=\"(fract(u * 4) &lt; 0.5) != (fract(v * 4) &lt; "
    "0.5)\"/>\n"
    "  <node id=\"c\" type=\"pixel\" kind=\"color\" expr=\"rgb(0.5 + 0.5 * sin(6.2831853 * 8 * "
    "u), 0.5 + 0.5 * sin(6.2831853 * 8 * v), 0.2)\"/>\n"
    "  <output name=\"basecolor\" from=\"c\" format=\"png\"/>\n"
    "  <output name=\"height\" from=\"h\" format=\"png\"/>\n"
    "</wetgraph>\n";

/* Pixels set in m whose neighbours within 2 pixels are all set too. */
static void erode2(const unsigned char *m, unsigned char *out)
{
    for (int y = 0; y < P; y++)
        for (int x = 0; x < P; x++) {
            int all = 1;
            for (int dy = -2; dy <= 2 && all; dy++)
                for (int dx = -2; dx <= 2 && all; dx++) {
                    int yy = y + dy, xx = x + dx;
                    all = yy >= 0 && yy < P && xx >= 0 && xx < P && m[yy * P + xx];
                }
            out[y * P + x] = (unsigned char)all;
        }
}

/* The first row from the top where cover is set in column x, or -1. */
static int top_row(const unsigned char *cover, int x)
{
    for (int y = 0; y < P; y++)
        if (cover[y * P + x]) return y;
    return -1;
}

/* The displaced grid draws the relief once: on the checker of raised and sunken squares, seen
 * from two cameras, the grid's picture inside the surface equals the plane's, whose relief only
 * the shader's parallax search draws, within 2 levels on average (measured 1.0 and 1.2 on
 * SwiftShader: the squares' walls, which the grid draws as one-cell slopes, and sampling). A grid
 * whose shader also searched down from the mesh, as if the mesh were the tile's flat top (the
 * relief counted twice), shows the sunken squares' colours shifted along the view: 3.3 and 4.0
 * levels. The far edge, seen from above the sunken squares' depth, is notched by them (dips of
 * a few pixels where a sunken square meets it) where the plane's is straight, and never above
 * the plane's. */
static void test_view3d_grid_relief_once(void **state)
{
    (void)state;
    need_chromium();
    wgt_write_file(path("g.wetgraph"), relief_probe);
    int port = start("nobin", NULL);
    wait_for("watch: waiting", 1);
    budget_ms = 30000;
    static unsigned char plane[P * P * 3], grid[P * P * 3];
    static unsigned char cp[P * P], cg[P * P], both[P * P], inside[P * P];
    static const char *const views[] = {"35,20,1,0", "25,60,1,0"};
    for (int v = 0; v < 2; v++) {
        char q[128];
        snprintf(q, sizeof q, "shape=plane&split=1&view=%s", views[v]);
        shape_view(port, q, "plane", plane, cp);
        snprintf(q, sizeof q, "shape=grid&split=1&view=%s", views[v]);
        shape_view(port, q, "grid", grid, cg);
        int n = 0;
        for (int i = 0; i < P * P; i++) both[i] = cp[i] && cg[i];
        erode2(both, inside);
        for (int i = 0; i < P * P; i++) n += inside[i];
        double diff = mean_diff_in(plane, grid, inside);
        print_message("relief checker, camera %s: grid against plane %.2f levels on average over "
                      "%d pixels inside both\n",
                      views[v], diff, n);
        if (n < P * P / 4) fail_msg("the plane and the grid share only %d pixels", n);
        if (diff > 2)
            fail_msg("seen from %s, the grid's picture differs from the plane's by %.2f levels "
                     "inside the surface (bound 2): the relief is not drawn once",
                     views[v], diff);
        if (v) continue;
        /* the far edge, from the first camera */
        double bend = 0, dip = 0, dip2 = 0;
        int cols = 0, above = 0, notched = 0;
        for (int x = 1; x < P - 1; x++) {
            int p0 = top_row(cp, x - 1), p1 = top_row(cp, x), p2 = top_row(cp, x + 1);
            int g1 = top_row(cg, x);
            if (p0 <= 0 || p1 <= 0 || p2 <= 0 || g1 <= 0) continue;
            cols++;
            bend += abs(p0 - 2 * p1 + p2);
            dip += g1 - p1, dip2 += (double)(g1 - p1) * (g1 - p1);
            above += g1 < p1 - 1;
            notched += g1 > p1 + 1;
        }
        if (cols < P / 4) fail_msg("the plane's far edge is in %d columns only", cols);
        bend /= cols, dip /= cols;
        double spread = sqrt(fmax(dip2 / cols - dip * dip, 0));
        print_message("far edge: the grid's %.2f pixels under the plane's on average, varying by "
                      "%.2f, notched in %d of %d columns, higher in %d (the plane's bends by "
                      "%.2f a column)\n",
                      dip, spread, notched, cols, above, bend);
        if (!(bend < 0.5 && spread > 1 && notched > cols / 8))
            fail_msg("the grid's far edge shows no relief: it varies by %.2f pixels, notched in "
                     "%d of %d columns (the plane's bends by %.2f)",
                     spread, notched, cols, bend);
        assert_int_equal(above, 0);
    }
    stop();
}

/* Steps for page_driver.js: a drag on the 3D view, the mouse moving every 16 ms (as a person's
 * does) until a picture drawn while moving has the smallest scale (at most 15 s), then let go;
 * returns the scales seen while moving, the number of pictures drawn then, and the scale once
 * the view has settled (the next picture after the drag). */
static const char move_steps[] =
    "const f = () => document.getElementById('view3d');\n"
    "await until(() => f() && f().dataset.state === 'ready' && f().dataset.draws, 'the 3D view');\n"
    "const c = f().querySelector('canvas'), r = c.getBoundingClientRect();\n"
    "const ev = (t, x) => c.dispatchEvent(new PointerEvent(t, {clientX: r.left + x, clientY: "
    "r.top + 50, button: 0, buttons: 1, pointerId: 1, bubbles: true}));\n"
    "ev('pointerdown', 100);\n"
    "const d0 = +f().dataset.draws, seen = new Set();\n"
    "let x = 100;\n"
    "const id = setInterval(() => { ev('pointermove', ++x); seen.add(f().dataset.scale); }, 16);\n"
    "try { await until(() => f().dataset.scale === '0.25', 'a picture at scale 0.25', 15000); }\n"
    "finally { clearInterval(id); }\n"
    "ev('pointerup', x);\n"
    "const d1 = +f().dataset.draws;\n"
    "await until(() => +f().dataset.draws > d1 && f().dataset.scale === '1', 'the settled view');\n"
    "return [[...seen].filter(v => v !== '1').length > 0, d1 - d0 > 1, f().dataset.scale,\n"
    "        f().dataset.camera !== '50,20,1,0'];\n";

/* Moving the view draws at a lower resolution when pictures cost more than the page's frame
 * budget, and at full resolution again once it stops: with a budget of 1 ms a frame (?frame_ms=1,
 * which any renderer exceeds), a drag brings the pictures down to the smallest scale, 1/4 of the
 * canvas's resolution, and the view then settles at scale 1; with ?frame_ms=0 (always full
 * resolution) a drag never lowers it. How many pictures a second this gives is measured by
 * bench/run_view3d.sh. */
static void test_view3d_moves_at_lower_resolution(void **state)
{
    (void)state;
    need_chromium();
    need_node();
    int port = start_lookdev();
    wait_for("watch: waiting", 1);
    wgt_write_file(path("move_steps.js"), move_steps);
    int st;
    char *out = drive_page(port, "events=0&frame_ms=1", "move_steps.js", "move", &st);
    if (st) fail_msg("the page driver failed (status %d):\n%.2000s", st, out);
    if (strcmp(out, "[true,true,\"1\",true]\n"))
        fail_msg("moving the view at a budget of 1 ms a frame: %s", out);
    free(out);
    /* always full resolution: the driver never sees scale 0.25 (it gives up after 15 s) */
    out = drive_page(port, "events=0&frame_ms=0", "move_steps.js", "move0", &st);
    if (!st || !strstr(out, "a picture at scale 0.25"))
        fail_msg("with ?frame_ms=0 the view moved at a lower resolution: %s", out);
    free(out);
    stop();
}

/* ---- controls an artist can use ---------------------------------------------------------------
 */

static const char hinted[] =
    "<wetgraph version=\"1\" size=\"16\">\n"
    "  <param name=\"depth\" type=\"float\" default=\"16\" min=\"0.001\" max=\"4096\" "
    "soft_min=\"1\" soft_max=\"64\" step=\"0.5\" group=\"Zones\" label=\"Relief depth\" "
    "description=\"The length the range stands for\"/>\n"
    "  <param name=\"count\" type=\"int\" default=\"3\" min=\"0\" max=\"10\" step=\"2\" "
    "group=\"Puddles\"/>\n"
    "  <param name=\"tint_r\" type=\"float\" default=\"-1\" min=\"-1\" max=\"1\" "
    "group=\"Liquid\"/>\n"
    "  <param name=\"tint_g\" type=\"float\" default=\"-1\" min=\"-1\" max=\"1\" "
    "group=\"Liquid\"/>\n"
    "  <param name=\"tint_b\" type=\"float\" default=\"-1\" min=\"-1\" max=\"1\" "
    "group=\"Liquid\"/>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=depth / 4096\"/>\n"
    "  <output name=\"c\" from=\"u\" format=\"png\"/>\n"
    "</wetgraph>\n";

/* The steps page_driver.js runs in the page: each moves a control as a person does (the events
 * a drag, a typed number, a click fire) and waits until the session's last render used the
 * value (the state's --set list), then reads the controls back. */
static const char hinted_steps[] =
    "await until(() => document.getElementById('param-depth'), 'the controls');\n"
    "const i = document.getElementById('param-depth'), b = document.getElementById('num-depth');\n"
    "const row = document.getElementById('row-depth');\n"
    "return [i.min, i.max, i.step, b.min, b.max, row.title, row.closest('details').dataset.group,\n"
    "        [...document.querySelectorAll('details.group > summary')].map(x => "
    "x.textContent).join(','),\n"
    "        document.getElementById('param-count').step];\n"
    "----\n"
    "const used = async v => until(async () => (await (await fetch('/api/state')).json()).sets\n"
    "    .includes(v), v);\n"
    "window.used = used;\n"
    "const i = document.getElementById('param-depth');\n"
    "i.value = '37.5'; i.dispatchEvent(new Event('input'));\n"
    "await used('depth=37.5');\n"
    "return document.getElementById('num-depth').value;\n"
    "----\n"
    "const b = document.getElementById('num-depth');\n"
    "b.value = '1000.125'; b.dispatchEvent(new Event('change'));\n"
    "await window.used('depth=1000.125');\n"
    "return document.getElementById('param-depth').value;\n"
    "----\n"
    "document.getElementById('reset-depth').click();\n"
    "await window.used('depth=16');\n"
    "return [document.getElementById('num-depth').value, "
    "document.getElementById('param-depth').value];\n"
    "----\n"
    "const c = document.getElementById('color-tint');\n"
    "c.value = '#ff8000'; c.dispatchEvent(new Event('input'));\n"
    "await window.used('tint_r=1.0000'); await window.used('tint_g=0.2159');\n"
    "await window.used('tint_b=0.0000');\n"
    "return document.getElementById('num-tint_g').value;\n"
    "----\n"
    "document.querySelector('#rgb-tint button').click();\n"
    "await window.used('tint_r=-1'); await window.used('tint_g=-1'); await "
    "window.used('tint_b=-1');\n"
    "const g = document.querySelector('details.group');\n"
    "g.querySelector('summary').click();\n"
    "return g.open;\n";

/* The controls from the parameters' UI hints, driven in chromium: the slider spans the soft
 * range with the declared step and sets exact values, the number box takes exact values beyond
 * the soft range (the slider stays at its end), reset goes back to the default, the three
 * tint_* floats get one colour picker (linear values from its sRGB) and a button back to the
 * preset, and the groups fold. Needs Node.js (scripts/install-deps.sh installs it). */
static void test_param_controls(void **state)
{
    (void)state;
    need_chromium();
    need_node();
    wgt_write_file(path("g.wetgraph"), hinted);
    wgt_write_file(path("steps.js"), hinted_steps);
    int port = start("nobin", NULL);
    wait_for("watch: waiting", 1);
    int st;
    char *out = drive_page(port, "events=0", "steps.js", "driver", &st);
    if (st) fail_msg("the page driver failed (status %d):\n%s", st, out);
    static const char *const want[] = {
        "[\"1\",\"64\",\"0.5\",\"0.001\",\"4096\",\"The length the range stands for\",\"Zones\","
        "\"Zones,Puddles,Liquid\",\"2\"]",
        "\"37.5\"",        /* the slider's value, exact, in the number box */
        "\"64\"",          /* 1000.125 typed: the slider at its end */
        "[\"16\",\"16\"]", /* reset */
        "\"0.2159\"",      /* the picker's green, linear */
        "false",           /* the group folded */
    };
    char *line = out;
    for (size_t i = 0; i < sizeof want / sizeof *want; i++) {
        char *end = strchr(line, '\n');
        if (!end) fail_msg("the page driver stopped after %zu steps:\n%s", i, out);
        *end = '\0';
        if (strcmp(line, want[i])) fail_msg("step %zu: '%s', expected '%s'", i + 1, line, want[i]);
        line = end + 1;
    }
    free(out);
    stop();
}

/* ---- any node's image -------------------------------------------------------------------------
 */

/* Steps for page_driver.js: click the node `node` (selector: the list item or the picture's box)
 * and return the caption, the channels and the gray values of the image the page then shows,
 * and whether anything of the picture's own scripts ran. */
static const char node_steps[] =
    "await until(() => document.querySelector(SELECTOR), 'the graph');\n"
    "document.querySelector(SELECTOR).dispatchEvent(new MouseEvent('click', {bubbles: true}));\n"
    "await until(() => { const f = document.getElementById('out-$view');\n"
    "  return f && f.dataset.node === NODE && f.dataset.loaded; }, 'the node view');\n"
    "const f = document.getElementById('out-$view'), im = f.querySelector('img');\n"
    "const c = document.createElement('canvas'); c.width = im.naturalWidth; c.height = "
    "im.naturalHeight;\n"
    "const x = c.getContext('2d'); x.drawImage(im, 0, 0);\n"
    "const d = x.getImageData(0, 0, c.width, c.height).data, g = [];\n"
    "for (let k = 0; k < d.length; k += 4) g.push(d[k]);\n"
    "return [f.querySelector('figcaption span').textContent, f.dataset.channels, c.width,\n"
    "        document.title, !!document.querySelector('#graph [onclick], #graph script'), g];\n";

/* Run node_steps on the page for node `node` found by selector; check the caption and that the
 * gray values shown are those of the 8-bit PNG `want` (a file of the test's folder). */
static void check_node_view(int port, const char *selector, const char *node, const char *want)
{
    char steps[4096], *at;
    snprintf(steps, sizeof steps, "%s", node_steps);
    while ((at = strstr(steps, "SELECTOR")) || (at = strstr(steps, "NODE"))) {
        bool sel = !strncmp(at, "SELECTOR", 8);
        char rest[4096], q[128];
        snprintf(rest, sizeof rest, "%s", at + (sel ? 8 : 4));
        snprintf(q, sizeof q, "'%s'", sel ? selector : node);
        snprintf(at, sizeof steps - (size_t)(at - steps), "%s%s", q, rest);
    }
    wgt_write_file(path("node_steps.js"), steps);
    int st;
    char *out = drive_page(port, "events=0", "node_steps.js", "node", &st);
    if (st) fail_msg("the page driver failed (status %d):\n%.2000s", st, out);
    char head[256];
    snprintf(head, sizeof head, "[\"node %s\",\"1\",64,\"wetgraph watch\",false,[", node);
    if (strncmp(out, head, strlen(head)))
        fail_msg("the node view: %.300s, expected %s...", out, head);
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path(want), 1, WG_LINEAR, &img, &err)) fail_msg("%s", err.message);
    char *p = out + strlen(head);
    int worst = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            char *end;
            long v = strtol(p, &end, 10);
            if (end == p) fail_msg("the node view has fewer than 64 x 64 values");
            p = end + 1;
            int d = abs((int)v - (int)lrintf(wg_image_row(img, y)[x] * 255));
            worst = d > worst ? d : worst;
        }
    wg_image_unref(img);
    free(out);
    /* the preview's 8 bits against the file's: the same rounding of the same image */
    if (worst > 1) fail_msg("the node view differs from %s by up to %d levels", want, worst);
}

/* A click on a node in the graph shows that node's image: on the list of nodes (no dot), the
 * noise node `n`, which no output shows, equal to the file `wetgraph render` writes for an
 * output from `n`; on dot's picture (a stand-in dot that draws the SVG dot draws, plus a script
 * and an event attribute, which must not run), the node `mix`, equal to output c's file. */
static void test_node_view(void **state)
{
    (void)state;
    const char *bin = need_chromium();
    need_node();
    char g_n[2048];
    snprintf(g_n, sizeof g_n, "%s", graph);
    char *end = strstr(g_n, "</wetgraph>");
    snprintf(end, sizeof g_n - (size_t)(end - g_n),
             "  <output name=\"n\" from=\"n\" format=\"png\"/>\n</wetgraph>\n");
    wgt_write_file(path("gn.wetgraph"), g_n);
    assert_int_equal(wgt_shell(dir, "'%s' render gn.wetgraph -o cli -q", bin), 0);
    wgt_write_file(path("g.wetgraph"), graph);
    int port = start("nobin", NULL);
    wait_for("watch: waiting", 1);
    check_node_view(port, "#nodes li[data-node=n]", "n", "cli/gn_n.png");
    stop();
    /* dot's picture, as dot draws it: a group of class node titled n:ID per node */
    mkdir(path("svgbin"), 0777);
    wgt_write_file(path("svgbin/dot"),
                   "#!/bin/sh\n"
                   "PATH=/usr/bin:/bin\n"
                   "cat >/dev/null\n"
                   "echo '<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"200pt\" "
                   "height=\"60pt\" viewBox=\"0 0 200 60\"><g id=\"graph0\" class=\"graph\">"
                   "<g id=\"node1\" class=\"node\"><title>n:mix</title><polygon fill=\"none\" "
                   "stroke=\"black\" points=\"0,0 100,0 100,40 0,40\"/><text x=\"10\" "
                   "y=\"24\">mix</text></g><script>document.title=\"ran\"</script>"
                   "<g id=\"node2\" class=\"node\" onclick=\"document.title=1\"><title>n:u</title>"
                   "<ellipse cx=\"150\" cy=\"20\" rx=\"40\" ry=\"18\"/></g></g></svg>'\n");
    chmod(path("svgbin/dot"), 0755);
    port = start("svgbin", NULL);
    wait_for("watch: waiting", 1);
    check_node_view(port, "#graph g.node[data-node=mix]", "mix", "o/g_c.png");
    stop();
}

/* ---- foam.frag in real time -------------------------------------------------------------------
 */

/* The foam graph's page: foam.frag drawn in the page from the render's `maps`, still at $time T
 * (?foamtime=T) and read back at the graph's size, against the graph's own `foam` rendered at
 * --time T: the same mask (foam > 1/2) but at a few edge pixels (measured on SwiftShader: 7 of
 * 16384 at t = 3.3; tests/graphs/test_glsl.c says why edges may differ: fwidth against half the
 * Sobel gradient), few values far apart, and another time gives another picture. */
static void test_foam_view(void **state)
{
    (void)state;
    const char *bin = need_chromium();
    wgt_write_file(path("shore.wetgraph"),
                   "<wetgraph version=\"1\" size=\"128\"><node id=\"s\" type=\"pixel\" "
                   "expr=\"cos(6.283185307179586 * u) + 0.6 * sin(12.566370614359172 * v) &gt; "
                   "0.3\"/><output name=\"shore\" from=\"s\" format=\"png\"/></wetgraph>\n");
    assert_int_equal(wgt_shell(dir, "'%s' render shore.wetgraph -o . -q", bin), 0);
    char graph_path[4096];
    snprintf(graph_path, sizeof graph_path, "%s/graphs/foam.wetgraph", getenv("WETGRAPH_SOURCE"));
    mkdir(path("nobin"), 0777);
    unlink(path("werr"));
    int port = wgt_free_port();
    char spec[64];
    snprintf(spec, sizeof spec, "127.0.0.1:%d", port);
    const char *args[] = {"watch",   graph_path, "-o",  "fo",      "--size",
                          "128",     "--time",   "3.3", "--input", "shore=shore_shore.png",
                          "--serve", spec,       NULL};
    watcher = wgt_spawn(dir, "wout", "werr", path("nobin"), args);
    wait_for("watch: waiting", 1);
    budget_ms = 20000;
    static unsigned char gpu[128 * 128], later[128 * 128];
    for (int k = 0; k < 2; k++) {
        dump_dom(port, k ? "?events=0&foamtime=5.1&probe=128" : "?events=0&foamtime=3.3&probe=128");
        char st[64];
        snprintf(st, sizeof st, "%s", attr("<figure id=\"foamview\"", "data-state"));
        if (strcmp(st, "ready"))
            fail_msg("the foam view is '%s': %s (%s)", st,
                     attr("<figure id=\"foamview\"", "data-error"), path("dom.html"));
        size_t size;
        char *dom = wgt_read_file(path("dom.html"), &size);
        char *at = strstr(dom, "<figure id=\"foamview\""),
             *p = at ? strstr(at, " data-probe=\"") : NULL;
        if (!p || p > strchr(at, '>')) fail_msg("the foam view read no picture back");
        p += strlen(" data-probe=\"");
        for (int i = 0; i < 128 * 128; i++) {
            unsigned v;
            if (sscanf(p + 2 * i, "%2x", &v) != 1) fail_msg("data-probe is too short");
            (k ? later : gpu)[i] = (unsigned char)v;
        }
        free(dom);
    }
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path("fo/foam_foam.png"), 1, WG_LINEAR, &img, &err))
        fail_msg("%s", err.message);
    assert_int_equal(img->width, 128);
    int differ = 0, far = 0, foam = 0, clear = 0, moved = 0;
    for (int y = 0; y < 128; y++)
        for (int x = 0; x < 128; x++) {
            float c = wg_image_row(img, y)[x], g = gpu[y * 128 + x] / 255.0f;
            differ += (c > 0.5f) != (g > 0.5f);
            far += fabsf(c - g) > 0.5f;
            foam += c > 0.5f, clear += c <= 0.5f;
            moved += (gpu[y * 128 + x] > 127) != (later[y * 128 + x] > 127);
        }
    wg_image_unref(img);
    print_message("foam.frag in the page at t = 3.3: the mask differs from the graph's at %d of "
                  "16384 pixels (%d foam), %d values more than 0.5 apart; t = 5.1 changes %d\n",
                  differ, foam, far, moved);
    assert_true(foam > 300 && clear > 300);
    if (differ > 82)
        fail_msg("foam.frag's mask differs from the graph's at %d pixels (bound 82, 0.5%%)",
                 differ);
    if (far > 164) fail_msg("%d values differ by more than 0.5 (bound 164, 1%%)", far);
    assert_true(moved > 300);
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
        cmocka_unit_test_teardown(test_param_controls, stop_watcher),
        cmocka_unit_test_teardown(test_node_view, stop_watcher),
        cmocka_unit_test_teardown(test_foam_view, stop_watcher),
        cmocka_unit_test_teardown(test_view3d_matches_preview, stop_watcher),
        cmocka_unit_test_teardown(test_view3d_follows_a_render, stop_watcher),
        cmocka_unit_test_teardown(test_view3d_sphere, stop_watcher),
        cmocka_unit_test_teardown(test_view3d_sphere_world_environment, stop_watcher),
        cmocka_unit_test_teardown(test_view3d_grid, stop_watcher),
        cmocka_unit_test_teardown(test_view3d_grid_relief_once, stop_watcher),
        cmocka_unit_test_teardown(test_view3d_moves_at_lower_resolution, stop_watcher),
    };
    /* WGT_ONLY=PATTERN runs the tests whose names match it (cmocka's * and ? wildcards) */
    if (getenv("WGT_ONLY")) cmocka_set_test_filter(getenv("WGT_ONLY"));
    return cmocka_run_group_tests(tests, setup, NULL);
}
