/* SPDX-License-Identifier: MIT */
/* `wetgraph watch --serve`: started in the background on a graph in a temporary folder with a
 * free port, it serves its page; /api/state lists the graph's parameters, its nodes, whether it
 * reads $time and which outputs are gray; /api/set (GET and POST) changes one, /events
 * announces the new render and the output's PNG then differs and decodes to the image
 * `wetgraph render --set` writes; an unknown parameter is refused (400); /api/set?$time=T sets
 * $time (a malformed time is refused) and /api/state?after=V answers with that render; /graph.svg
 * is what `dot -Tsvg` wrote (a stand-in script first in PATH records its arguments and input) and
 * dot runs once, not on every render; without dot in PATH /graph.svg is 404; path traversal (plain
 * and %-encoded) and unknown paths are 404; an edit of the graph file still renders again; SIGINT
 * ends it with exit 0. It listens on [::1] and on [::] (IPv4 too) when the machine has IPv6
 * loopback (skipped otherwise), and a malformed address is a usage error naming it. A value set
 * while a long render runs cancels that render ("superseded") and the next one applies it. The HTTP
 * client is plain sockets with HTTP/1.0 (the server closes each connection after its answer); every
 * wait has a harness limit (socket time-outs, LIMIT_MS), no timing assertions. Runs WETGRAPH_BIN.
 */
#include "wgtest.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

enum { LIMIT_MS = 30000, LIMIT_S = 30 };

static const char graph[] =
    "<wetgraph version=\"1\" size=\"64\">\n"
    "  <param name=\"level\" type=\"float\" default=\"0.25\" min=\"0\" max=\"1\"/>\n"
    "  <param name=\"mode\" type=\"enum\" values=\"a b\" default=\"a\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"%s\"/>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=level\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"multiply\">\n"
    "    <in name=\"foreground\" from=\"n\"/><in name=\"background\" from=\"u\"/>\n"
    "  </node>\n"
    "  <output name=\"c\" from=\"mix\" format=\"png\"/>\n"
    "</wetgraph>\n";

static char dir[1024];
static pid_t watcher;
static int port, family = AF_INET; /* where request() connects: 127.0.0.1 or ::1 */

static const char *path(const char *name)
{
    return wgt_join(dir, name);
}

static void save(const char *name, const char *scale)
{
    char tmp[64], text[2048];
    snprintf(tmp, sizeof tmp, ".%s.swp", name);
    snprintf(text, sizeof text, graph, scale);
    wgt_write_file(path(tmp), text);
    assert_int_equal(rename(path(tmp), path(name)), 0);
}

static int count_in(const char *file, const char *needle)
{
    return wgt_count_in(path(file), needle);
}

static void wait_for(const char *needle, int count)
{
    wgt_wait_for(watcher, path("werr"), needle, count, LIMIT_MS);
}

/* Connect and send "METHOD target HTTP/1.0"; the socket has a receive time-out. */
static int request(const char *method, const char *target)
{
    int fd = socket(family, SOCK_STREAM, 0);
    assert_true(fd >= 0);
    struct timeval tv = {LIMIT_S, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    struct sockaddr_in6 sa6 = {.sin6_family = AF_INET6, .sin6_port = htons((uint16_t)port)};
    sa6.sin6_addr = in6addr_loopback;
    if (family == AF_INET6 ? connect(fd, (struct sockaddr *)&sa6, sizeof sa6)
                           : connect(fd, (struct sockaddr *)&sa, sizeof sa))
        fail_msg("cannot connect to port %d (%s)", port, family == AF_INET6 ? "::1" : "127.0.0.1");
    char req[2048];
    int n = snprintf(req, sizeof req, "%s %s HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n", method, target);
    assert_int_equal(write(fd, req, (size_t)n), n);
    return fd;
}

typedef struct {
    int status;
    char *head, *body; /* body points into head's buffer; free head */
    size_t size;
} Reply;

/* Read the answer to a request() made earlier. */
static Reply answer(int fd, const char *method, const char *target)
{
    size_t cap = 1 << 16, len = 0;
    char *buf = malloc(cap + 1);
    assert_non_null(buf);
    for (;;) {
        if (len == cap) {
            buf = realloc(buf, 2 * cap + 1);
            assert_non_null(buf);
            cap *= 2;
        }
        ssize_t n = read(fd, buf + len, cap - len);
        if (n < 0) fail_msg("%s %s: no complete answer", method, target);
        if (n == 0) break;
        len += (size_t)n;
    }
    close(fd);
    buf[len] = '\0';
    Reply r = {0, buf, NULL, 0};
    if (sscanf(buf, "HTTP/1.%*d %d", &r.status) != 1) fail_msg("%s %s: not HTTP", method, target);
    char *end = strstr(buf, "\r\n\r\n");
    assert_non_null(end);
    r.body = end + 4;
    r.size = len - (size_t)(r.body - buf);
    return r;
}

static Reply http(const char *method, const char *target)
{
    return answer(request(method, target), method, target);
}

static int status_of(const char *method, const char *target)
{
    Reply r = http(method, target);
    free(r.head);
    return r.status;
}

/* GET /out/c.png into file name; returns the decoded image (owned by the caller). */
static WgImage *fetch_png(const char *name)
{
    Reply r = http("GET", "/out/c.png?v=1");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.head, "image/png"));
    FILE *f = fopen(path(name), "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(r.body, 1, r.size, f), r.size);
    fclose(f);
    free(r.head);
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path(name), 1, WG_LINEAR, &img, &err)) fail_msg("%s: %s", name, err.message);
    return img;
}

/* Start `watch GRAPH -o o ... --serve HOST:PORT` on a free port (PORT alone when host is NULL)
 * with the options `more` (NULL-terminated, may be empty) and PATH set to path_dir (a folder of
 * the test's folder, with or without a stand-in dot, or NULL to keep PATH), logging to wout and
 * werr; wait for its first render. request() then connects over IPv4. */
static void start_watch(const char *graph_file, const char *host, const char *path_dir,
                        const char *const more[])
{
    unlink(path("werr")); /* the last session's log */
    port = wgt_free_port();
    family = AF_INET;
    char spec[64];
    if (host)
        snprintf(spec, sizeof spec, "%s:%d", host, port);
    else
        snprintf(spec, sizeof spec, "%d", port);
    const char *args[32] = {"watch", graph_file, "-o", "o", "--serve", spec};
    for (int i = 0; more[i]; i++) args[6 + i] = more[i];
    watcher = wgt_spawn(dir, "wout", "werr", path_dir ? path(path_dir) : NULL, args);
    wait_for("watch: waiting", 1);
}

/* Start watch on g.wetgraph (see start_watch). */
static void start(const char *host, const char *path_dir)
{
    static const char *const none[] = {NULL};
    start_watch("g.wetgraph", host, path_dir, none);
}

/* Ctrl-C ends the session cleanly. */
static void stop(void)
{
    int st = wgt_stop(watcher, SIGINT, LIMIT_MS);
    watcher = 0;
    assert_true(WIFEXITED(st));
    assert_int_equal(WEXITSTATUS(st), 0);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s/serve", wgt_tmpdir());
    mkdir(dir, 0777);
    /* a stand-in for graphviz's dot: records each run's arguments and input */
    mkdir(path("bin"), 0777);
    mkdir(path("nobin"), 0777);
    wgt_write_file(path("bin/dot"), "#!/bin/sh\nPATH=/usr/bin:/bin\n"
                                    "echo \"$*\" >>dot.args\n"
                                    "cat >dot.in\n"
                                    "echo '<svg xmlns=\"http://www.w3.org/2000/svg\"><text>stand-in"
                                    "</text></svg>'\n");
    chmod(path("bin/dot"), 0755);
    return 0;
}

static void test_serve_session(void **state)
{
    (void)state;
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) fail_msg("WETGRAPH_BIN is not set");
    save("g.wetgraph", "4");
    start("127.0.0.1", "bin");

    /* the page */
    Reply r = http("GET", "/");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.head, "text/html"));
    assert_non_null(strstr(r.body, "/api/state"));
    assert_non_null(strstr(r.body, "EventSource('/events')"));
    free(r.head);

    /* the state lists the parameters from their declarations */
    r = http("GET", "/api/state");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "{\"name\":\"level\",\"type\":\"float\""));
    assert_non_null(strstr(r.body, "\"value\":\"0.25\",\"min\":0,\"max\":1}"));
    assert_non_null(strstr(r.body, "\"values\":[\"a\",\"b\"]"));
    assert_non_null(strstr(r.body, "\"outputs\":[{\"name\":\"c\",\"version\":1,\"channels\":1}]"));
    assert_non_null(strstr(r.body, "\"id\":\"mix\""));
    assert_non_null(strstr(r.body, "\"nodes\":[{\"id\":\"n\",\"type\":\"noise\"},"));
    assert_non_null(strstr(r.body, "\"time\":0,\"reads_time\":false"));
    assert_non_null(strstr(r.body, "\"svg\":1"));
    assert_non_null(strstr(r.body, "\"error\":null"));
    free(r.head);

    /* the graph's picture: dot -Tsvg with the graph on its input, its output served as is */
    r = http("GET", "/graph.svg");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.head, "image/svg+xml"));
    assert_non_null(strstr(r.body, "<text>stand-in</text></svg>"));
    free(r.head);
    assert_int_equal(count_in("dot.args", "-Tsvg\n"), 1);
    assert_int_equal(count_in("dot.in", "digraph"), 1);
    assert_true(count_in("dot.in", "mix") > 0);
    WgImage *first = fetch_png("first.png");

    /* a change: /events announces the render, the preview is the image render --set writes */
    int events = request("GET", "/events");
    r = http("GET", "/api/set?level=0.75");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "\"ok\":true"));
    free(r.head);
    char ev[4096] = "";
    size_t got = 0;
    while (!strstr(ev, "event: render")) {
        ssize_t n = read(events, ev + got, sizeof ev - 1 - got);
        if (n <= 0) fail_msg("no render event");
        got += (size_t)n;
        ev[got] = '\0';
    }
    close(events);
    wait_for("watch: waiting", 2);
    WgImage *second = fetch_png("second.png");
    assert_true(wgt_max_abs_diff(first, second) > 0.1);
    assert_int_equal(wgt_shell(dir, "'%s' render g.wetgraph --set level=0.75 -o cli -q", bin), 0);
    WgImage *cli = NULL;
    WgError err = {0};
    if (wg_image_read(path("cli/g_c.png"), 1, WG_LINEAR, &cli, &err)) fail_msg("%s", err.message);
    wgt_assert_identical(second, cli);
    r = http("GET", "/api/state");
    assert_non_null(strstr(r.body, "\"value\":\"0.75\""));
    assert_non_null(strstr(r.body, "\"sets\":[\"level=0.75\"]"));
    free(r.head);

    /* POST works too; an unknown parameter is refused and renders nothing */
    assert_int_equal(status_of("POST", "/api/set?level=0.5"), 200);
    wait_for("watch: waiting", 3);
    assert_int_equal(status_of("GET", "/api/set?nope=1"), 400);

    /* $time: a number is queued and the state shows the render's time (/api/state?after=V
     * answers once that render is there); anything else is refused */
    r = http("GET", "/api/state");
    unsigned long long v = 0;
    assert_int_equal(sscanf(r.body, "{\"version\":%llu,", &v), 1);
    free(r.head);
    char target[64], version[64];
    snprintf(target, sizeof target, "/api/state?after=%llu", v);
    int waiting = request("GET", target);
    assert_int_equal(status_of("POST", "/api/set?%24time=2.5"), 200);
    r = answer(waiting, "GET", target);
    snprintf(version, sizeof version, "{\"version\":%llu,", v + 1);
    assert_non_null(strstr(r.body, version));
    assert_non_null(strstr(r.body, "\"time\":2.5,"));
    free(r.head);
    wait_for("watch: waiting", 4);
    assert_int_equal(status_of("GET", "/api/state?after=x"), 400);
    r = http("GET", "/api/state?after=0"); /* already there */
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "\"sets\":[\"level=0.5\"]"));
    free(r.head);
    assert_int_equal(status_of("POST", "/api/set?%24time=soon"), 400);
    assert_int_equal(status_of("POST", "/api/set?%24time=1e999"), 400);
    /* four renders with other values, one picture: dot runs when the graph changes */
    assert_int_equal(count_in("dot.args", "-Tsvg\n"), 1);

    /* only the page and the current outputs */
    const char *bad[] = {"/out/../../etc/passwd",
                         "/out/../../etc/passwd.png",
                         "/out/%2e%2e/%2e%2e/etc/passwd.png",
                         "/out/..%2f..%2fetc%2fpasswd.png",
                         "/%2e%2e/%2e%2e/etc/passwd",
                         "/etc/passwd",
                         "/out/nope.png",
                         "/out/c",
                         "/out/.png",
                         "/api/statex",
                         "/g.wetgraph",
                         "/o/g_c.png",
                         "/graph.svgx",
                         "/graph.svg/../../etc/passwd",
                         "/out/../graph.svg",
                         "/graph",
                         "/dot.in"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        int st = status_of("GET", bad[i]);
        if (st != 404) fail_msg("GET %s: status %d, expected 404", bad[i], st);
    }

    /* an edit of the file renders again, with the web view's value still applied */
    save("g.wetgraph", "9");
    wait_for("watch: waiting", 5);
    WgImage *third = fetch_png("third.png");
    assert_true(wgt_max_abs_diff(second, third) > 0.01);
    assert_int_equal(wgt_shell(dir, "'%s' render g.wetgraph --set level=0.5 -o cli -q", bin), 0);
    wg_image_unref(cli);
    cli = NULL;
    if (wg_image_read(path("cli/g_c.png"), 1, WG_LINEAR, &cli, &err)) fail_msg("%s", err.message);
    wgt_assert_identical(third, cli);
    wg_image_unref(first);
    wg_image_unref(second);
    wg_image_unref(third);
    wg_image_unref(cli);

    /* Ctrl-C ends the session cleanly */
    stop();
}

/* The version (the render that made its image) /api/state gives output `name`. */
static long output_version(const char *state, const char *name)
{
    char key[256];
    snprintf(key, sizeof key, "{\"name\":\"%s\",\"version\":", name);
    const char *p = strstr(state, key);
    if (!p) fail_msg("no output %s in %s", name, state);
    return atol(p + strlen(key));
}

/* Previews: an image wider than 1024 pixels is served reduced by the smallest whole factor that
 * brings it to 1024 or less (1500 by 2: 750); after
 * a change that leaves an output's image as it was, that output keeps its version (the page
 * does not reload it) and its preview, while the changed one gets the new render's. */
static void test_serve_previews(void **state)
{
    (void)state;
    wgt_write_file(path("g.wetgraph"),
                   "<wetgraph version=\"1\" size=\"64\">\n"
                   "  <param name=\"level\" type=\"float\" default=\"0.25\" min=\"0\" max=\"1\"/>\n"
                   "  <node id=\"wide\" type=\"pixel\" size=\"1500x300\" expr=\"u * level\"/>\n"
                   "  <node id=\"still\" type=\"noise\" scale=\"4\"/>\n"
                   "  <output name=\"wide\" from=\"wide\" format=\"png\"/>\n"
                   "  <output name=\"still\" from=\"still\" format=\"png\"/>\n"
                   "</wetgraph>\n");
    start(NULL, "nobin");
    Reply r = http("GET", "/out/wide.png");
    assert_int_equal(r.status, 200);
    assert_true(r.size > 24 && !memcmp(r.body + 12, "IHDR", 4));
    const unsigned char *ihdr = (const unsigned char *)r.body + 16;
    long w = (long)ihdr[0] << 24 | (long)ihdr[1] << 16 | ihdr[2] << 8 | ihdr[3];
    long h = (long)ihdr[4] << 24 | (long)ihdr[5] << 16 | ihdr[6] << 8 | ihdr[7];
    assert_int_equal(w, 750); /* reduced by 2, the smallest whole factor that fits 1024 */
    assert_int_equal(h, 150);
    free(r.head);
    Reply before = http("GET", "/out/still.png");
    r = http("GET", "/api/state");
    long wide0 = output_version(r.body, "wide"), still0 = output_version(r.body, "still");
    free(r.head);
    assert_int_equal(status_of("POST", "/api/set?level=0.5"), 200);
    wait_for("watch: waiting", 2);
    r = http("GET", "/api/state?after=1");
    long wide1 = output_version(r.body, "wide"), still1 = output_version(r.body, "still");
    free(r.head);
    assert_true(wide1 > wide0);
    assert_int_equal(still1, still0);
    Reply after = http("GET", "/out/still.png");
    assert_true(after.size == before.size && !memcmp(after.body, before.body, after.size));
    free(before.head);
    free(after.head);
    stop();
}

/* Without dot in PATH there is no picture (the page lists the nodes instead). */
static void test_serve_without_dot(void **state)
{
    (void)state;
    save("g.wetgraph", "4");
    start(NULL, "nobin");
    Reply r = http("GET", "/api/state");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "\"svg\":null"));
    assert_non_null(strstr(r.body, "\"nodes\":[{\"id\":\"n\",\"type\":\"noise\"},"));
    free(r.head);
    assert_int_equal(status_of("GET", "/graph.svg"), 404);
    stop();
}

/* Can this machine listen on ::1? */
static bool have_ipv6_loopback(void)
{
    int fd = socket(AF_INET6, SOCK_STREAM, 0);
    if (fd < 0) return false;
    struct sockaddr_in6 sa = {.sin6_family = AF_INET6};
    sa.sin6_addr = in6addr_loopback;
    bool ok = bind(fd, (struct sockaddr *)&sa, sizeof sa) == 0;
    close(fd);
    return ok;
}

/* [::1]:PORT listens on IPv6 loopback; [::]:PORT takes IPv6 and IPv4 connections. */
static void test_serve_ipv6(void **state)
{
    (void)state;
    if (!have_ipv6_loopback()) skip();
    save("g.wetgraph", "4");
    start("[::1]", "nobin");
    assert_int_equal(count_in("werr", "serving on http://[::1]:"), 1);
    family = AF_INET6;
    assert_int_equal(status_of("GET", "/api/state"), 200);
    assert_int_equal(status_of("GET", "/out/../../etc/passwd.png"), 404);
    stop();

    start("[::]", "nobin");
    family = AF_INET6;
    assert_int_equal(status_of("GET", "/api/state"), 200);
    family = AF_INET;
    assert_int_equal(status_of("GET", "/api/state"), 200);
    stop();
}

static int stop_watcher(void **state)
{
    (void)state;
    wgt_kill(watcher);
    watcher = 0;
    return 0;
}

/* A chain of ambient occlusions whose radius is a parameter: short at first, then /api/set
 * makes it long (far more work than the harness limit allows); a second /api/set arrives while
 * that render runs, after its first new node is in the disk cache, and makes the chain short
 * again: the long render is superseded, and the outputs are those of `wetgraph render` with the
 * last values. */
static void test_serve_set_supersedes_a_running_render(void **state)
{
    (void)state;
    const char *bin = getenv("WETGRAPH_BIN");
    char *text = wgt_slow_graph(
        "  <param name=\"level\" type=\"float\" default=\"0.25\" min=\"0\" max=\"1\"/>\n"
        "  <param name=\"radius\" type=\"float\" default=\"16\" min=\"0\" max=\"64\"/>\n"
        "  <param name=\"dirs\" type=\"int\" default=\"64\" min=\"1\" max=\"64\"/>\n",
        "=radius", "=dirs");
    wgt_write_file(path("slow.wetgraph"), text);
    free(text);
    static const char *const more[] = {"--threads",   "2",     "--cache", "scache", "--set",
                                       "radius=0.25", "--set", "dirs=1",  NULL};
    start_watch("slow.wetgraph", "127.0.0.1", NULL, more);
    int entries = wgt_count_files(path("scache"), NULL);
    assert_int_equal(status_of("GET", "/api/set?radius=16&dirs=64"), 200);
    wgt_wait_for_files(watcher, path("scache"), entries, LIMIT_MS);
    assert_int_equal(status_of("GET", "/api/set?radius=0.5&dirs=1&level=0.75"), 200);
    wait_for("watch: waiting", 2);
    assert_int_equal(count_in("werr", "watch: render superseded after "), 1);
    assert_int_equal(count_in("werr", "watch: rendered"), 2); /* the first and the last */
    assert_int_equal(count_in("werr", "error"), 0);
    Reply r = http("GET", "/api/state");
    assert_non_null(strstr(r.body, "\"error\":null"));
    free(r.head);

    assert_int_equal(
        wgt_shell(dir,
                  "'%s' render slow.wetgraph -o sref --set radius=0.5 --set dirs=1 --set "
                  "level=0.75 --threads 1",
                  bin),
        0);
    wgt_assert_identical_files(path("o/slow_a.exr"), path("sref/slow_a.exr"));
    wgt_assert_identical_files(path("o/slow_c.exr"), path("sref/slow_c.exr"));
    stop();
}

/* A malformed --serve is a usage error naming it. */
static void test_serve_usage(void **state)
{
    (void)state;
    const char *bin = getenv("WETGRAPH_BIN");
    save("g.wetgraph", "4");
    assert_int_equal(wgt_shell(dir, "'%s' watch g.wetgraph --serve 70000 2>err2", bin), 2);
    assert_int_equal(count_in("err2", "--serve 70000: the port must be a number"), 1);
    assert_int_equal(wgt_shell(dir, "'%s' watch g.wetgraph --serve local:80 2>err2", bin), 2);
    assert_int_equal(count_in("err2", "is not an IPv4 address"), 1);
    assert_int_equal(wgt_shell(dir, "'%s' watch g.wetgraph --serve ::1:8080 2>err2", bin), 2);
    assert_int_equal(count_in("err2", "--serve ::1:8080: an IPv6 address goes in brackets"), 1);
    assert_int_equal(wgt_shell(dir, "'%s' watch g.wetgraph --serve '[::1]8080' 2>err2", bin), 2);
    assert_int_equal(count_in("err2", "--serve [::1]8080: expected [IPV6]:PORT"), 1);
    assert_int_equal(wgt_shell(dir, "'%s' watch g.wetgraph --serve '[::1' 2>err2", bin), 2);
    assert_int_equal(count_in("err2", "expected [IPV6]:PORT"), 1);
    assert_int_equal(wgt_shell(dir, "'%s' watch g.wetgraph --serve '[1.2.3.4]:80' 2>err2", bin), 2);
    assert_int_equal(count_in("err2", "'1.2.3.4' is not an IPv6 address"), 1);
    assert_int_equal(wgt_shell(dir, "'%s' watch g.wetgraph --serve '[::1]:0' 2>err2", bin), 2);
    assert_int_equal(count_in("err2", "the port must be a number from 1 to 65535"), 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_serve_session, stop_watcher),
        cmocka_unit_test_teardown(test_serve_without_dot, stop_watcher),
        cmocka_unit_test_teardown(test_serve_previews, stop_watcher),
        cmocka_unit_test_teardown(test_serve_ipv6, stop_watcher),
        cmocka_unit_test(test_serve_usage),
        cmocka_unit_test_teardown(test_serve_set_supersedes_a_running_render, stop_watcher),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
