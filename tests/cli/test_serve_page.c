/* SPDX-License-Identifier: MIT */
/* The page of `wetgraph watch --serve` in a real browser: Debian's chromium, headless, loads
 * it with ?set=level=0.6&events=0 (no open /events connection, which would keep its virtual
 * clock waiting) and dumps the DOM the script built. The DOM must hold a slider for the
 * float parameter `level` with its declared range, a menu for the enum, and the output's image
 * loaded (the page marks a figure with data-loaded once its image has loaded); the watch
 * session must have rendered with level=0.6 (the page applied the address's setting). Fails
 * with a clear message when chromium is not installed (scripts/install-deps.sh installs it).
 * chromium runs under `timeout` with a virtual time budget (a harness limit, not a timing
 * assertion). Runs WETGRAPH_BIN. */
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

static char dir[1024];
static pid_t watcher;

static const char *path(const char *name)
{
    static char buf[8][1200];
    static int next;
    char *p = buf[next++ & 7];
    snprintf(p, sizeof buf[0], "%s/%s", dir, name);
    return p;
}

static int count_in(const char *file, const char *needle)
{
    return wgt_count_in(path(file), needle);
}

static void wait_for(const char *needle, int count)
{
    wgt_wait_for(watcher, path("werr"), needle, count, LIMIT_MS);
}

static void test_serve_page(void **state)
{
    (void)state;
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) fail_msg("WETGRAPH_BIN is not set");
    snprintf(dir, sizeof dir, "%s/serve_page", wgt_tmpdir());
    mkdir(dir, 0777);
    if (wgt_shell(dir, "command -v chromium"))
        fail_msg("chromium is not installed: the page test needs Debian's chromium "
                 "(scripts/install-deps.sh installs it)");
    wgt_write_file(path("g.wetgraph"), graph);
    int port = wgt_free_port();
    char spec[64];
    snprintf(spec, sizeof spec, "127.0.0.1:%d", port);
    watcher = fork();
    assert_true(watcher >= 0);
    if (watcher == 0) {
        if (chdir(dir) || !freopen("wout", "w", stdout) || !freopen("werr", "w", stderr)) _exit(99);
        execl(bin, bin, "watch", "g.wetgraph", "-o", "o", "--serve", spec, (char *)NULL);
        _exit(98);
    }
    wait_for("watch: waiting", 1);
    int st = wgt_shell(
        dir,
        "timeout 60 chromium --headless=new --no-sandbox --disable-gpu "
        "--user-data-dir=profile --virtual-time-budget=5000 --window-size=1200,800 "
        "--dump-dom 'http://127.0.0.1:%d/?set=level=0.6&events=0' >dom.html 2>chromium.log",
        port);
    if (st) fail_msg("chromium failed (status %d): see %s", st, path("chromium.log"));
    if (!count_in("dom.html", "<input type=\"range\" min=\"0\" max=\"2\""))
        fail_msg("the page built no slider for 'level' (%s)", path("dom.html"));
    assert_int_equal(count_in("dom.html", "id=\"param-level\""), 1);
    assert_int_equal(count_in("dom.html", "<select id=\"param-mode\""), 1);
    if (!count_in("dom.html", "<figure id=\"out-c\" data-loaded="))
        fail_msg("the page did not load the image of output 'c' (%s)", path("dom.html"));
    wait_for("watch: waiting", 2); /* the render of ?set=level=0.6 */
    assert_int_equal(wgt_shell(dir, "'%s' render g.wetgraph --set level=0.6 -o cli -q", bin), 0);
    size_t a, b;
    char *served = wgt_read_file(path("o/g_c.png"), &a),
         *cli = wgt_read_file(path("cli/g_c.png"), &b);
    assert_true(a == b && !memcmp(served, cli, a));
    free(served);
    free(cli);
    assert_int_equal(kill(watcher, SIGTERM), 0);
    for (int waited = 0; waitpid(watcher, &st, WNOHANG) != watcher; waited += 5) {
        if (waited > LIMIT_MS) fail_msg("watch did not stop on SIGTERM");
        wgt_sleep_ms(5);
    }
    assert_true(WIFEXITED(st) && WEXITSTATUS(st) == 0);
}

static int stop_watcher(void **state)
{
    (void)state;
    int st;
    if (watcher > 0 && waitpid(watcher, &st, WNOHANG) == 0) {
        kill(watcher, SIGKILL);
        waitpid(watcher, &st, 0);
    }
    watcher = 0;
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_serve_page, stop_watcher),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
