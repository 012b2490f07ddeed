/* SPDX-License-Identifier: MIT */
/* `wetgraph watch --serve`: started in the background on a graph in a temporary folder with a
 * free port, it serves its page; /api/state lists the graph's parameters, its nodes, whether it
 * reads $time and which outputs are gray; POST /api/set with the page's token (in the query
 * string or a form body) changes one, /events
 * announces the new render and the output's PNG then differs and decodes to the image
 * `wetgraph render --set` writes; an unknown parameter is refused (400); /api/set?$time=T sets
 * $time (a malformed time is refused) and /api/state?after=V answers with that render; /graph.svg
 * is what `dot -Tsvg` wrote (a stand-in script first in PATH records its arguments and input) and
 * dot runs once, not on every render; without dot in PATH /graph.svg is 404; path traversal (plain
 * and %-encoded) and unknown paths are 404; an edit of the graph file still renders again; SIGINT
 * ends it with exit 0. It listens on [::1] and on [::] (IPv4 too) when the machine has IPv6
 * loopback (skipped otherwise), and a malformed address is a usage error naming it. A value set
 * while a long render runs cancels that render ("superseded") and the next one applies it.
 * Another site cannot read or drive it (foreign Host, Origin, Sec-Fetch-Site, GET, missing or
 * wrong token: all refused, nothing queued); malformed bodies, render numbers and %00 in an
 * address are refused; 120 half-sent requests leave the page answering and are closed after
 * the server's short time-out. The HTTP
 * client is plain sockets with HTTP/1.0 (the server closes each connection after its answer); every
 * wait has a harness limit (socket time-outs, LIMIT_MS), no timing assertions. Runs WETGRAPH_BIN.
 */
#include "wgtest.h"

#include <arpa/inet.h>
#include <errno.h>
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

/* The Host header of this session's requests: the address request() connects to, and the port. */
static const char *host(void)
{
    static char text[64];
    snprintf(text, sizeof text, family == AF_INET6 ? "[::1]:%d" : "127.0.0.1:%d", port);
    return text;
}

/* Connect and send text; the socket has a receive time-out of limit_s seconds. */
static int send_text(const char *text, int limit_s)
{
    int fd = socket(family, SOCK_STREAM, 0);
    assert_true(fd >= 0);
    struct timeval tv = {limit_s, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    struct sockaddr_in6 sa6 = {.sin6_family = AF_INET6, .sin6_port = htons((uint16_t)port)};
    sa6.sin6_addr = in6addr_loopback;
    if (family == AF_INET6 ? connect(fd, (struct sockaddr *)&sa6, sizeof sa6)
                           : connect(fd, (struct sockaddr *)&sa, sizeof sa))
        fail_msg("cannot connect to port %d (%s)", port, family == AF_INET6 ? "::1" : "127.0.0.1");
    size_t n = strlen(text);
    assert_int_equal(write(fd, text, n), (ssize_t)n);
    return fd;
}

/* Send "METHOD target HTTP/1.0" with the Host header host_header (none when NULL), the header
 * lines headers ("Name: value\r\n" each, or "") and body (or NULL, none). */
static int request_full(const char *method, const char *target, const char *host_header,
                        const char *headers, const char *body)
{
    char length[64] = "";
    if (body) snprintf(length, sizeof length, "Content-Length: %zu\r\n", strlen(body));
    char host_line[128] = "";
    if (host_header) snprintf(host_line, sizeof host_line, "Host: %s\r\n", host_header);
    size_t size = 4096 + (body ? strlen(body) : 0);
    char *req = malloc(size);
    assert_non_null(req);
    int n = snprintf(req, size, "%s %s HTTP/1.0\r\n%s%s%s\r\n%s", method, target, host_line,
                     headers, length, body ? body : "");
    assert_true(n > 0 && (size_t)n < size);
    int fd = send_text(req, LIMIT_S);
    free(req);
    return fd;
}

/* Connect and send "METHOD target HTTP/1.0" with this session's Host. */
static int request(const char *method, const char *target)
{
    return request_full(method, target, host(), "", NULL);
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

/* The run's token, from the page (its meta element). */
static char token[128];

static void read_token(void)
{
    Reply r = http("GET", "/");
    assert_int_equal(r.status, 200);
    const char *key = "<meta name=\"wetgraph-token\" content=\"";
    const char *at = strstr(r.body, key);
    if (!at) fail_msg("the page has no token");
    at += strlen(key);
    snprintf(token, sizeof token, "%.*s", (int)strcspn(at, "\""), at);
    free(r.head);
    assert_true(strlen(token) >= 32);
}

/* POST /api/set?query as the page does (with the token); the answer. */
static Reply set_reply(const char *query)
{
    char target[1024], headers[256];
    snprintf(target, sizeof target, "/api/set?%s", query);
    snprintf(headers, sizeof headers, "X-Wetgraph-Token: %s\r\n", token);
    return answer(request_full("POST", target, host(), headers, NULL), "POST", target);
}

static int set_status(const char *query)
{
    Reply r = set_reply(query);
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
    family = host && !strcmp(host, "[::1]") ? AF_INET6 : AF_INET;
    char spec[64];
    if (host)
        snprintf(spec, sizeof spec, "%s:%d", host, port);
    else
        snprintf(spec, sizeof spec, "%d", port);
    const char *args[32] = {"watch", graph_file, "-o", "o", "--serve", spec};
    for (int i = 0; more[i]; i++) args[6 + i] = more[i];
    watcher = wgt_spawn(dir, "wout", "werr", path_dir ? path(path_dir) : NULL, args);
    wait_for("watch: waiting", 1);
    read_token();
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
    assert_non_null(strstr(r.body, "<script src=\"/page.js\">"));
    free(r.head);
    /* its script and style, and the shader the 3D view loads: the files of the source tree */
    r = http("GET", "/page.js");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.head, "text/javascript"));
    assert_non_null(strstr(r.body, "/api/state"));
    assert_non_null(strstr(r.body, "EventSource('/events')"));
    free(r.head);
    r = http("GET", "/page.css");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.head, "text/css"));
    free(r.head);
    r = http("GET", "/shaders/wet_layered.frag");
    assert_int_equal(r.status, 200);
    {
        char shader[4096];
        snprintf(shader, sizeof shader, "%s/docs/shaders/wet_layered.frag",
                 getenv("WETGRAPH_SOURCE"));
        size_t size;
        char *text = wgt_read_file(shader, &size);
        assert_int_equal(r.size, size);
        assert_memory_equal(r.body, text, size);
        free(r.head);
        free(text);
    }
    /* the 3D view's data: an output's pixels as half floats, its size in a header; the
     * environment's atlas (the built-in sky: no environment was given) */
    r = http("GET", "/map/c");
    assert_int_equal(r.status, 200);
    {
        const char *dims = strstr(r.head, "X-Wetgraph-Size: ");
        int w = 0, h = 0, c = 0;
        if (!dims || sscanf(dims + 17, "%d %d %d", &w, &h, &c) != 3) fail_msg("no X-Wetgraph-Size");
        assert_true(w > 0 && h > 0 && c == 1);
        assert_int_equal(r.size, (size_t)w * h * c * 2);
    }
    free(r.head);
    r = http("GET", "/env/0");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.head, "X-Wetgraph-Size: 512 512 4"));
    assert_int_equal(r.size, 512 * 512 * 4 * 2);
    free(r.head);
    const char *missing[] = {"/map/nothing", "/map/", "/env/1", "/env/x", "/env/"};
    for (size_t i = 0; i < sizeof missing / sizeof *missing; i++) {
        r = http("GET", missing[i]);
        if (r.status != 404) fail_msg("GET %s: status %d, expected 404", missing[i], r.status);
        free(r.head);
    }

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
    r = set_reply("level=0.75");
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

    /* a form body works too; an unknown parameter is refused and renders nothing */
    char headers[256];
    snprintf(headers, sizeof headers,
             "X-Wetgraph-Token: %s\r\nContent-Type: application/x-www-form-urlencoded\r\n", token);
    r = answer(request_full("POST", "/api/set", host(), headers, "level=0.5"), "POST", "body");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "\"queued\":1"));
    free(r.head);
    wait_for("watch: waiting", 3);
    assert_int_equal(set_status("nope=1"), 400);

    /* $time: a number is queued and the state shows the render's time (/api/state?after=V
     * answers once that render is there); anything else is refused */
    r = http("GET", "/api/state");
    unsigned long long v = 0;
    assert_int_equal(sscanf(r.body, "{\"version\":%llu,", &v), 1);
    free(r.head);
    char target[64], version[64];
    snprintf(target, sizeof target, "/api/state?after=%llu", v);
    int waiting = request("GET", target);
    assert_int_equal(set_status("%24time=2.5"), 200);
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
    assert_int_equal(set_status("%24time=soon"), 400);
    assert_int_equal(set_status("%24time=1e999"), 400);
    assert_int_equal(set_status("%24view=nope"), 400); /* $view names a node of the graph */
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
    assert_int_equal(set_status("level=0.5"), 200);
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
/* The 3D view's environments: each --env file and --input environment=FILE, in that order,
 * prefiltered before the first render; a file that cannot be read is reported on stderr and in
 * the state, and has no atlas (404), while the others are served. */
static void test_serve_environments(void **state)
{
    (void)state;
    const char *shared = getenv("WETGRAPH_SHARED");
    if (!shared || !shared[0]) fail_msg("WETGRAPH_SHARED is not set");
    char env[4096];
    snprintf(env, sizeof env, "%s/env/potsdamer_platz_1k.hdr", shared);
    save("g.wetgraph", "4");
    const char *const more[] = {"--env", "missing.hdr", "--env", env, NULL};
    start_watch("g.wetgraph", NULL, "nobin", more);
    assert_int_equal(count_in("werr", "warning: the 3D view's environment missing.hdr: "), 1);
    Reply r = http("GET", "/api/state");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "\"environments\":[{\"name\":\"missing.hdr\",\"ready\":false,"
                                   "\"error\":\""));
    assert_non_null(strstr(r.body, "{\"name\":\"potsdamer_platz_1k.hdr\",\"ready\":true,"
                                   "\"error\":null}]"));
    free(r.head);
    assert_int_equal(status_of("GET", "/env/0"), 404);
    r = http("GET", "/env/1");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.head, "X-Wetgraph-Size: 512 512 4"));
    free(r.head);
    stop();
}

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

/* [::1]:PORT listens on IPv6 loopback; [::]:PORT takes IPv6 and IPv4 connections and warns
 * that the page has no authentication. */
static void test_serve_ipv6(void **state)
{
    (void)state;
    if (!have_ipv6_loopback()) skip();
    save("g.wetgraph", "4");
    start("[::1]", "nobin");
    assert_int_equal(count_in("werr", "serving on http://[::1]:"), 1);
    assert_int_equal(count_in("werr", "no authentication"), 0);
    family = AF_INET6;
    assert_int_equal(status_of("GET", "/api/state"), 200);
    assert_int_equal(status_of("GET", "/out/../../etc/passwd.png"), 404);
    stop();

    start("[::]", "nobin");
    /* every address: anyone who reaches one gets the page and its token */
    assert_int_equal(count_in("werr", "the page has no authentication"), 1);
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
    assert_int_equal(set_status("radius=16&dirs=64"), 200);
    wgt_wait_for_files(watcher, path("scache"), entries, LIMIT_MS);
    assert_int_equal(set_status("radius=0.5&dirs=1&level=0.75"), 200);
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

/* How many times needle occurs in the answer's text (head and body). */
static int count_text(const Reply *r, const char *needle)
{
    int n = 0;
    for (const char *p = r->head; (p = strstr(p, needle)); p++) n++;
    return n;
}

/* Another site's page cannot read or drive the session: a Host that is not this server (as
 * DNS rebinding sends) is answered 421 on every path, without the state; a change needs POST
 * (GET is 405), the run's token (missing, wrong or another run's is 403) and, when the browser
 * says where it comes from, this server's own origin (Origin, Sec-Fetch-Site). None of the
 * refused requests queues anything: the one accepted change afterwards is the only one in the
 * render's --set list and the only render. */
static void test_serve_refuses_other_sites(void **state)
{
    (void)state;
    save("g.wetgraph", "4");
    start("127.0.0.1", "nobin");
    assert_int_equal(count_in("werr", "no authentication"), 0); /* loopback: no warning */
    char old_token[sizeof token];
    snprintf(old_token, sizeof old_token, "%s", token);
    stop(); /* a second run: its token is another */
    start("127.0.0.1", "nobin");
    assert_string_not_equal(token, old_token);

    /* hosts that are not this server */
    char foreign[8][96];
    snprintf(foreign[0], sizeof foreign[0], "attacker.example:%d", port);
    snprintf(foreign[1], sizeof foreign[1], "attacker.example");
    snprintf(foreign[2], sizeof foreign[2], "localhost.attacker.example:%d", port);
    snprintf(foreign[3], sizeof foreign[3], "127.0.0.1:%d", port == 65535 ? 1 : port + 1);
    snprintf(foreign[4], sizeof foreign[4], "127.0.0.1");
    snprintf(foreign[5], sizeof foreign[5], "127.0.0.1.nip.io:%d", port);
    snprintf(foreign[6], sizeof foreign[6], "10.1.2.3:%d", port);
    snprintf(foreign[7], sizeof foreign[7], "[::1]:%d0", port);
    const char *paths[] = {"/",        "/api/state", "/out/c.png", "/graph.svg", "/events",
                           "/api/set", "/map/c",     "/env/0",     "/page.js"};
    for (size_t h = 0; h < 9; h++)
        for (size_t k = 0; k < sizeof paths / sizeof *paths; k++) {
            const char *name = h < 8 ? foreign[h] : NULL; /* 8: no Host at all */
            Reply r = answer(request_full("GET", paths[k], name, "", NULL), "GET", paths[k]);
            if (r.status != 421 || strstr(r.body, "level") || strstr(r.body, "token"))
                fail_msg("GET %s with Host %s: status %d, expected 421", paths[k],
                         name ? name : "(none)", r.status);
            free(r.head);
        }
    /* names of this server */
    char own[4][96];
    snprintf(own[0], sizeof own[0], "localhost:%d", port);
    snprintf(own[1], sizeof own[1], "LocalHost:%d", port);
    snprintf(own[2], sizeof own[2], "127.0.0.1:%d", port);
    snprintf(own[3], sizeof own[3], "[::1]:%d", port);
    for (int h = 0; h < 4; h++) {
        Reply r = answer(request_full("GET", "/api/state", own[h], "", NULL), "GET", own[h]);
        if (r.status != 200) fail_msg("Host %s: status %d, expected 200", own[h], r.status);
        free(r.head);
    }

    /* changes that are refused */
    char wrong[sizeof token], with_token[256];
    snprintf(wrong, sizeof wrong, "%s", token);
    wrong[strlen(wrong) - 1] = wrong[strlen(wrong) - 1] == '0' ? '1' : '0';
    snprintf(with_token, sizeof with_token, "X-Wetgraph-Token: %s\r\n", token);
    char h_wrong[256], h_old[256], h_short[256], h_origin[8][256], other_origin[128];
    snprintf(h_wrong, sizeof h_wrong, "X-Wetgraph-Token: %s\r\n", wrong);
    snprintf(h_old, sizeof h_old, "X-Wetgraph-Token: %s\r\n", old_token);
    snprintf(h_short, sizeof h_short, "X-Wetgraph-Token: %.16s\r\n", token);
    snprintf(other_origin, sizeof other_origin, "http://127.0.0.1:%d",
             port == 65535 ? 1 : port + 1);
    const char *origins[] = {"Origin: http://attacker.example\r\n",
                             "Origin: null\r\n",
                             other_origin,
                             "Origin: https://127.0.0.1\r\n",
                             "Sec-Fetch-Site: cross-site\r\nSec-Fetch-Mode: cors\r\n",
                             "Sec-Fetch-Site: same-site\r\nSec-Fetch-Mode: cors\r\n",
                             "Sec-Fetch-Site: cross-site\r\nSec-Fetch-Mode: navigate\r\n"};
    for (size_t i = 0; i < sizeof origins / sizeof *origins; i++) {
        if (origins[i] == other_origin)
            snprintf(h_origin[i], sizeof h_origin[i], "%sOrigin: %s\r\n", with_token, other_origin);
        else
            snprintf(h_origin[i], sizeof h_origin[i], "%s%s", with_token, origins[i]);
    }
    struct {
        const char *method, *target, *headers, *body;
        int status;
    } refused[] = {
        {"GET", "/api/set?mode=b", with_token, NULL, 405},
        {"HEAD", "/api/set?mode=b", with_token, NULL, 405},
        {"PUT", "/api/set?mode=b", with_token, NULL, 405},
        {"POST", "/api/set?mode=b", "", NULL, 403},
        {"POST", "/api/set", "Content-Type: application/x-www-form-urlencoded\r\n", "mode=b", 403},
        {"POST", "/api/set?mode=b", h_wrong, NULL, 403},
        {"POST", "/api/set?mode=b", h_old, NULL, 403},
        {"POST", "/api/set?mode=b", h_short, NULL, 403},
        {"POST", "/api/set?mode=b", "X-Wetgraph-Token: \r\n", NULL, 403},
    };
    for (size_t i = 0; i < sizeof refused / sizeof *refused; i++) {
        Reply r = answer(request_full(refused[i].method, refused[i].target, host(),
                                      refused[i].headers, refused[i].body),
                         refused[i].method, refused[i].target);
        if (r.status != refused[i].status)
            fail_msg("%s %s (%zu): status %d, expected %d", refused[i].method, refused[i].target, i,
                     r.status, refused[i].status);
        if (r.status == 405) assert_int_equal(count_text(&r, "Allow: POST"), 1);
        free(r.head);
    }
    for (size_t i = 0; i < sizeof origins / sizeof *origins; i++) {
        Reply r = answer(request_full("POST", "/api/set?mode=b", host(), h_origin[i], NULL), "POST",
                         h_origin[i]);
        if (r.status != 403)
            fail_msg("POST with %s: status %d, expected 403", h_origin[i], r.status);
        free(r.head);
    }
    /* reading from another site's page (not a navigation) is refused too: the state, the 3D
     * view's maps and environments, and the page's files */
    Reply r;
    const char *reads[] = {"/api/state", "/map/c", "/env/0", "/page.js",
                           "/shaders/wet_layered.frag"};
    for (size_t i = 0; i < sizeof reads / sizeof *reads; i++) {
        r = answer(request_full("GET", reads[i], host(),
                                "Sec-Fetch-Site: cross-site\r\nSec-Fetch-Mode: cors\r\n", NULL),
                   "GET", reads[i]);
        if (r.status != 403) fail_msg("GET %s from another site: status %d", reads[i], r.status);
        free(r.head);
    }
    /* a link from another site opens the page, which then leaves its address's ?set= alone */
    r = answer(request_full("GET", "/?set=mode=b", host(),
                            "Sec-Fetch-Site: cross-site\r\nSec-Fetch-Mode: navigate\r\n", NULL),
               "GET", "navigation");
    assert_int_equal(r.status, 200);
    assert_int_equal(count_text(&r, "name=\"wetgraph-address-settings\" content=\"0\""), 1);
    free(r.head);
    r = http("GET", "/?set=level=0.5");
    assert_int_equal(count_text(&r, "name=\"wetgraph-address-settings\" content=\"1\""), 1);
    free(r.head);

    /* the page's own request, as a browser sends it */
    char page_headers[512];
    snprintf(page_headers, sizeof page_headers,
             "%sOrigin: http://%s\r\nSec-Fetch-Site: same-origin\r\nSec-Fetch-Mode: cors\r\n"
             "Content-Type: application/x-www-form-urlencoded;charset=UTF-8\r\n",
             with_token, host());
    r = answer(request_full("POST", "/api/set", host(), page_headers, "level=0.5"), "POST", "page");
    assert_int_equal(r.status, 200);
    free(r.head);
    wait_for("watch: waiting", 2);
    r = http("GET", "/api/state");
    assert_non_null(strstr(r.body, "\"sets\":[\"level=0.5\"]"));
    assert_non_null(strstr(r.body, "{\"version\":2,"));
    free(r.head);
    assert_int_equal(count_in("werr", "watch: rendered"), 1 + 1);
    stop();
}

/* /api/set reads name=value pairs from the query string and from an
 * application/x-www-form-urlencoded body: another body type is 415, a malformed body or a
 * request that sets nothing 400, a body over the limit 413, and a request with one bad change
 * queues none of its changes; /api/state?after= takes digits only (no sign, no overflow); an
 * address with %00 is refused (it would decode to a shorter name). */
static void test_serve_set_bodies_and_addresses(void **state)
{
    (void)state;
    save("g.wetgraph", "4");
    start("127.0.0.1", "nobin");
    char form[256], json[256], plain[256];
    snprintf(form, sizeof form,
             "X-Wetgraph-Token: %s\r\nContent-Type: application/x-www-form-urlencoded\r\n", token);
    snprintf(json, sizeof json, "X-Wetgraph-Token: %s\r\nContent-Type: application/json\r\n",
             token);
    snprintf(plain, sizeof plain, "X-Wetgraph-Token: %s\r\nContent-Type: text/plain\r\n", token);
    char none[256];
    snprintf(none, sizeof none, "X-Wetgraph-Token: %s\r\n", token);
    char *big = malloc(20001);
    assert_non_null(big);
    memset(big, 'x', 20000);
    memcpy(big, "level=", 6);
    big[20000] = '\0';
    struct {
        const char *target, *headers, *body;
        int status;
        const char *says;
    } cases[] = {
        {"/api/set", json, "{\"level\":0.6}", 415, "application/x-www-form-urlencoded"},
        {"/api/set", json, "{\"mode\":\"b\",\"level\":\"0.7\"}", 415, "x-www-form-urlencoded"},
        {"/api/set", plain, "level=0.6", 415, "x-www-form-urlencoded"},
        {"/api/set", none, "level=0.6", 415, "x-www-form-urlencoded"},
        {"/api/set", none, NULL, 400, "nothing to set"},
        {"/api/set", form, "", 400, "nothing to set"},
        {"/api/set", form, "&&", 400, "nothing to set"},
        {"/api/set", form, "level", 400, "name=value"},
        {"/api/set", form, "level=0.6&nope=1", 400, "no parameter 'nope'"},
        {"/api/set?level=0.6", form, "mode=c%zz", 400, "%-escape"},
        {"/api/set", form, "level=0.6%00", 400, "NUL"},
        {"/api/set", form, "mode=b&%24time=never", 400, "$time"},
        {"/api/set", form, "=b", 400, "name of 1 to"},
        {"/api/set?mode=b&level=0.6%00x", none, NULL, 400, "NUL"},
        {"/api/set?mode=b&nope=2", none, NULL, 400, "no parameter 'nope'"},
        {"/api/set", form, big, 413, "larger than"},
        {"/api/state?after=-1", "", NULL, 400, "render number"},
        {"/api/state?after=%2B1", "", NULL, 400, "render number"},
        {"/api/state?after=%201", "", NULL, 400, "render number"},
        {"/api/state?after=", "", NULL, 400, "render number"},
        {"/api/state?after=1x", "", NULL, 400, "render number"},
        {"/api/state?after=99999999999999999999", "", NULL, 400, "render number"},
        {"/api/state?after=18446744073709551616", "", NULL, 400, "render number"},
        {"/out/c.png%00.txt", "", NULL, 400, "NUL"},
        {"/out/c%00.png", "", NULL, 400, "NUL"},
        {"/out/c.png%00", "", NULL, 400, "NUL"},
        {"/api/state%00x", "", NULL, 400, "NUL"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        const char *method = strncmp(cases[i].target, "/api/set", 8) ? "GET" : "POST";
        Reply r =
            answer(request_full(method, cases[i].target, host(), cases[i].headers, cases[i].body),
                   method, cases[i].target);
        if (r.status != cases[i].status || !strstr(r.body, cases[i].says))
            fail_msg("%s %s with body '%.40s': status %d (expected %d), '%s'", method,
                     cases[i].target, cases[i].body ? cases[i].body : "", r.status, cases[i].status,
                     r.body);
        free(r.head);
    }
    free(big);
    /* the names as they are still work */
    assert_int_equal(status_of("GET", "/out/c.png"), 200);
    assert_int_equal(status_of("GET", "/api/state?after=0"), 200);
    /* a form body and the query string together; + is a space, %-escapes decoded */
    Reply r = answer(request_full("POST", "/api/set?level=0.625", host(), form, "mode=%62"), "POST",
                     "form");
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "\"queued\":2"));
    free(r.head);
    wait_for("watch: waiting", 2);
    r = http("GET", "/api/state");
    assert_non_null(strstr(r.body, "\"sets\":[\"level=0.625\",\"mode=b\"]"));
    assert_non_null(strstr(r.body, "{\"version\":2,"));
    free(r.head);
    assert_int_equal(count_in("werr", "watch: rendered"), 2);
    stop();
}

/* Open connections that send half a request (or nothing): n of them at once, then a normal
 * request must be answered at once, and the server closes the idle ones after its short
 * time-out (well before the harness limit). */
static void idle_round(int n, bool wait_closed)
{
    int *fds = calloc((size_t)n, sizeof *fds);
    assert_non_null(fds);
    for (int i = 0; i < n; i++) {
        char half[256];
        if (i % 3 == 0)
            snprintf(half, sizeof half, "GET /api/state HTTP/1.1\r\nHost: %s\r\n", host());
        else if (i % 3 == 1)
            snprintf(half, sizeof half, "GET /out/c.png HTT");
        else
            snprintf(half, sizeof half, "P");
        fds[i] = send_text(half, LIMIT_S);
    }
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    char req[256];
    snprintf(req, sizeof req, "GET /api/state HTTP/1.0\r\nHost: %s\r\n\r\n", host());
    Reply r = answer(send_text(req, 5), "GET", "/api/state beside idle connections");
    clock_gettime(CLOCK_MONOTONIC, &t1);
    assert_int_equal(r.status, 200);
    assert_non_null(strstr(r.body, "\"version\":"));
    free(r.head);
    print_message("%d idle connections: answered in %.0f ms\n", n,
                  (t1.tv_sec - t0.tv_sec) * 1e3 + (t1.tv_nsec - t0.tv_nsec) / 1e6);
    for (int i = 0; i < n; i++) {
        if (wait_closed) { /* EOF or a reset, not the receive time-out */
            char c;
            errno = 0;
            ssize_t got = read(fds[i], &c, 1);
            if (got != 0 && !(got < 0 && errno == ECONNRESET))
                fail_msg("idle connection %d: not closed by the server (%s)", i,
                         got < 0 ? strerror(errno) : "data");
        }
        close(fds[i]);
    }
    if (wait_closed) {
        clock_gettime(CLOCK_MONOTONIC, &t1);
        print_message("the idle connections were closed after %.1f s\n",
                      (t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) / 1e9);
    }
    free(fds);
}

static void test_serve_idle_connections(void **state)
{
    (void)state;
    save("g.wetgraph", "4");
    start("127.0.0.1", "nobin");
    idle_round(64, false);
    idle_round(120, true);
    assert_int_equal(status_of("GET", "/api/state"), 200);
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
        cmocka_unit_test_teardown(test_serve_environments, stop_watcher),
        cmocka_unit_test_teardown(test_serve_without_dot, stop_watcher),
        cmocka_unit_test_teardown(test_serve_previews, stop_watcher),
        cmocka_unit_test_teardown(test_serve_ipv6, stop_watcher),
        cmocka_unit_test(test_serve_usage),
        cmocka_unit_test_teardown(test_serve_refuses_other_sites, stop_watcher),
        cmocka_unit_test_teardown(test_serve_set_bodies_and_addresses, stop_watcher),
        cmocka_unit_test_teardown(test_serve_idle_connections, stop_watcher),
        cmocka_unit_test_teardown(test_serve_set_supersedes_a_running_render, stop_watcher),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
