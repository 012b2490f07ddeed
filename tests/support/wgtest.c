/* SPDX-License-Identifier: MIT */
/* Test helpers; see wgtest.h. */
#include "wgtest.h"

#include <arpa/inet.h>
#include <dirent.h>
#include <signal.h>
#include <sys/socket.h>
#include <netinet/in.h>
#include <time.h>
#include <ftw.h>
#include <stdarg.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char tmp_dir[512];

static int remove_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st;
    (void)flag;
    (void)ftw;
    remove(path);
    return 0;
}

/* Scratch folders go away with the process (set WGTEST_KEEP=1 to keep them for debugging). */
static void remove_tmpdir(void)
{
    if (tmp_dir[0] && !getenv("WGTEST_KEEP")) nftw(tmp_dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
}

const char *wgt_tmpdir(void)
{
    if (!tmp_dir[0]) {
        const char *base = getenv("TMPDIR");
        snprintf(tmp_dir, sizeof tmp_dir, "%s/wgtest-%ld", base && base[0] ? base : "/tmp",
                 (long)getpid());
        mkdir(tmp_dir, 0777);
        atexit(remove_tmpdir);
    }
    return tmp_dir;
}

const char *wgt_join(const char *dir, const char *name)
{
    static char buf[16][2048];
    static int next;
    char *p = buf[next++ & 15];
    snprintf(p, sizeof buf[0], "%s/%s", dir, name);
    return p;
}

const char *wgt_path(const char *name)
{
    return wgt_join(wgt_tmpdir(), name);
}

void wgt_write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    if (!f) fail_msg("cannot write %s", path);
    fputs(text, f);
    fclose(f);
}

WgImage *wgt_image(int w, int h, int channels, const float *values)
{
    WgImage *img = wg_image_new_zero(w, h, channels);
    assert_non_null(img);
    if (values)
        for (int y = 0; y < h; y++)
            memcpy(wg_image_row(img, y), values + (size_t)y * w * channels,
                   sizeof(float) * (size_t)w * channels);
    return img;
}

WgImage *wgt_image_fn(int w, int h, int channels, double (*fn)(int x, int y, int k))
{
    WgImage *img = wg_image_new(w, h, channels);
    assert_non_null(img);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int k = 0; k < channels; k++)
                wg_image_row(img, y)[x * channels + k] = (float)fn(x, y, k);
    return img;
}

/* Mean |difference| of channel 0 between column c and the next one (wrapping), and for rows. */
static double column_step(const WgImage *f, int c)
{
    double s = 0;
    for (int y = 0; y < f->height; y++)
        s += fabs(wgt_px(f, c, y, 0) - wgt_px(f, (c + 1) % f->width, y, 0));
    return s / f->height;
}

static double row_step(const WgImage *f, int r)
{
    double s = 0;
    for (int x = 0; x < f->width; x++)
        s += fabs(wgt_px(f, x, r, 0) - wgt_px(f, x, (r + 1) % f->height, 0));
    return s / f->width;
}

WgtSeams wgt_seams(const WgImage *img)
{
    WgtSeams s = {0};
    int w = img->width, h = img->height;
    for (int c = 0; c < w - 1; c++) s.inner_c += column_step(img, c) / (w - 1);
    for (int r = 0; r < h - 1; r++) s.inner_r += row_step(img, r) / (h - 1);
    s.seam_c = column_step(img, w - 1);
    s.seam_r = row_step(img, h - 1);
    return s;
}

static void fail_with(const char *what, const WgError *err)
{
    char buf[2048];
    wg_error_format(err, buf, sizeof buf);
    fail_msg("%s: %s", what, buf);
}

WgGraph *wgt_load_at(const char *xml, const char *path)
{
    WgGraph *g = NULL;
    WgError err = {0};
    if (!path) path = wgt_path("test.wetgraph");
    if (wg_graph_load_memory(xml, strlen(xml), path, &g, &err)) fail_with("load", &err);
    return g;
}

WgGraph *wgt_load(const char *xml)
{
    return wgt_load_at(xml, NULL);
}

int wgt_load_error(const char *xml, WgError *err)
{
    WgGraph *g = NULL;
    memset(err, 0, sizeof *err);
    int rc = wg_graph_load_memory(xml, strlen(xml), wgt_path("test.wetgraph"), &g, err);
    if (rc == WG_OK) {
        wg_graph_free(g);
        fail_msg("expected the graph to be rejected");
    }
    return rc;
}

WgResult *wgt_render(const WgGraph *g, int threads)
{
    WgError err = {0};
    WgEngineOptions opt = {threads, 0, NULL};
    WgEngine *e = NULL;
    if (wg_engine_new(&opt, &e, &err)) fail_with("engine", &err);
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) fail_with("render", &err);
    wg_request_free(r);
    wg_engine_free(e);
    return res;
}

WgEngine *wgt_engine(int threads, size_t memory_budget, const char *cache_dir)
{
    WgEngineOptions opt = {threads, memory_budget, cache_dir};
    WgEngine *e = NULL;
    WgError err = {0};
    if (wg_engine_new(&opt, &e, &err)) fail_with("engine", &err);
    return e;
}

WgResult *wgt_render_request(WgEngine *e, const WgRequest *r)
{
    WgResult *res = NULL;
    WgError err = {0};
    if (wg_render(e, r, &res, &err)) fail_with("render", &err);
    return res;
}

const WgNodeStat *wgt_stat(const WgResult *r, const char *id)
{
    for (int i = 0; i < wg_result_stat_count(r); i++)
        if (!strcmp(wg_result_stat(r, i)->id, id)) return wg_result_stat(r, i);
    return NULL;
}

char *wgt_read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) fail_msg("cannot open %s", path);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    buf[n] = '\0';
    fclose(f);
    if (size) *size = (size_t)n;
    return buf;
}

bool wgt_same_file(const char *a, const char *b)
{
    size_t na, nb;
    char *x = wgt_read_file(a, &na), *y = wgt_read_file(b, &nb);
    bool same = na == nb && !memcmp(x, y, na);
    free(x);
    free(y);
    return same;
}

const WgImage *wgt_output(const WgResult *r, const char *name)
{
    for (int i = 0; i < wg_result_output_count(r); i++)
        if (!strcmp(wg_result_output_name(r, i), name)) return wg_result_output_image(r, i);
    fail_msg("no output '%s'", name);
    return NULL;
}

static char *node_xml(const char *type, const char *attrs, int w, int h, int n, const char **names,
                      const WgImage **images, const char *port)
{
    size_t cap = 4096 + strlen(attrs) + 256 * (size_t)n;
    char *xml = malloc(cap);
    assert_non_null(xml);
    size_t l = (size_t)snprintf(xml, cap, "<wetgraph version=\"1\" size=\"%dx%d\">\n", w, h);
    for (int i = 0; i < n; i++)
        l += (size_t)snprintf(xml + l, cap - l, "  <input name=\"in%d\" type=\"%s\"/>\n", i,
                              images[i]->channels == 4 ? "color" : "gray");
    l += (size_t)snprintf(xml + l, cap - l, "  <node id=\"n\" type=\"%s\" %s>\n", type, attrs);
    for (int i = 0; i < n; i++)
        l += (size_t)snprintf(xml + l, cap - l, "    <in name=\"%s\" from=\"$in%d\"/>\n", names[i],
                              i);
    snprintf(xml + l, cap - l, "  </node>\n  <output name=\"out\" from=\"n%s%s\"/>\n</wetgraph>\n",
             port ? "." : "", port ? port : "");
    return xml;
}

static int run_node(const char *type, const char *attrs, int w, int h, int n, const char **names,
                    const WgImage **images, const char *port, int threads, WgImage **out,
                    WgError *err)
{
    char *xml = node_xml(type, attrs, w, h, n, names, images, port);
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgEngine *e = NULL;
    WgResult *res = NULL;
    memset(err, 0, sizeof *err);
    int rc = wg_graph_load_memory(xml, strlen(xml), wgt_path("node.wetgraph"), &g, err);
    free(xml);
    if (!rc && !(r = wg_request_new(g))) rc = WG_ERR_NOMEM;
    for (int i = 0; i < n && !rc; i++) {
        char name[16];
        snprintf(name, sizeof name, "in%d", i);
        rc = wg_request_set_input_image(r, name, images[i], err);
    }
    WgEngineOptions opt = {threads, 0, NULL};
    if (!rc) rc = wg_engine_new(&opt, &e, err);
    if (!rc) rc = wg_request_check(r, err);
    if (!rc) rc = wg_render(e, r, &res, err);
    if (!rc && out) *out = wg_image_ref(wg_result_output_image(res, 0));
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
    return rc;
}

WgImage *wgt_node(const char *type, const char *attrs, int w, int h, int n, const char **names,
                  const WgImage **images, int port, int threads)
{
    const WgNodeType *t = wg_node_type_find(type);
    if (!t) fail_msg("no node type '%s'", type);
    const char *pname = port > 0 ? t->outputs[port].name : NULL;
    WgError err = {0};
    WgImage *out = NULL;
    if (run_node(type, attrs, w, h, n, names, images, pname, threads, &out, &err))
        fail_with(type, &err);
    return out;
}

int wgt_node_error(const char *type, const char *attrs, int w, int h, int n, const char **names,
                   const WgImage **images, WgError *err)
{
    WgImage *out = NULL;
    int rc = run_node(type, attrs, w, h, n, names, images, NULL, 1, &out, err);
    if (rc == WG_OK) {
        wg_image_unref(out);
        fail_msg("expected node '%s' with %s to fail", type, attrs);
    }
    return rc;
}

void wgt_assert_same_shape(const WgImage *a, const WgImage *b)
{
    assert_non_null(a);
    assert_non_null(b);
    if (a->width != b->width || a->height != b->height || a->channels != b->channels)
        fail_msg("shape %dx%dx%d vs %dx%dx%d", a->width, a->height, a->channels, b->width,
                 b->height, b->channels);
}

void wgt_assert_identical(const WgImage *a, const WgImage *b)
{
    wgt_assert_same_shape(a, b);
    for (int y = 0; y < a->height; y++)
        if (memcmp(wg_image_row(a, y), wg_image_row(b, y),
                   sizeof(float) * (size_t)a->width * a->channels)) {
            for (int i = 0; i < a->width * a->channels; i++)
                if (memcmp(&wg_image_row(a, y)[i], &wg_image_row(b, y)[i], sizeof(float)))
                    fail_msg("images differ at x=%d y=%d channel %d: %.9g vs %.9g", i / a->channels,
                             y, i % a->channels, wg_image_row(a, y)[i], wg_image_row(b, y)[i]);
        }
}

void wgt_assert_identical_files(const char *a, const char *b)
{
    WgImage *x = NULL, *y = NULL;
    WgError err = {0};
    if (wg_image_read(a, 0, WG_LINEAR, &x, &err)) fail_with(a, &err);
    if (wg_image_read(b, 0, WG_LINEAR, &y, &err)) fail_with(b, &err);
    wgt_assert_identical(x, y);
    wg_image_unref(x);
    wg_image_unref(y);
}

double wgt_max_abs_diff(const WgImage *a, const WgImage *b)
{
    wgt_assert_same_shape(a, b);
    double m = 0;
    for (int y = 0; y < a->height; y++)
        for (int i = 0; i < a->width * a->channels; i++) {
            double d = fabs((double)wg_image_row(a, y)[i] - wg_image_row(b, y)[i]);
            if (!(d <= m)) m = d; /* NaN counts as a difference */
        }
    return m;
}

void wgt_assert_near(const WgImage *a, const WgImage *b, double tol)
{
    double d = wgt_max_abs_diff(a, b);
    if (!(d <= tol)) fail_msg("max difference %.3g exceeds %.3g", d, tol);
}

void wgt_assert_range(const WgImage *img, double lo, double hi)
{
    for (int y = 0; y < img->height; y++)
        for (int i = 0; i < img->width * img->channels; i++) {
            float v = wg_image_row(img, y)[i];
            if (!(v >= lo && v <= hi))
                fail_msg("value %.9g at x=%d y=%d outside [%g, %g]", v, i / img->channels, y, lo,
                         hi);
        }
}

void wgt_assert_error(const WgError *err, int code, int line, const char *needles)
{
    char buf[2048], parts[1024];
    wg_error_format(err, buf, sizeof buf);
    if (err->code != code) fail_msg("expected code %d, got %d: %s", code, err->code, buf);
    if (line && err->line != line) fail_msg("expected line %d, got %d: %s", line, err->line, buf);
    if (!needles) return;
    snprintf(parts, sizeof parts, "%s", needles);
    char *save = NULL;
    for (char *p = strtok_r(parts, "|", &save); p; p = strtok_r(NULL, "|", &save))
        if (!strstr(buf, p)) fail_msg("expected '%s' in: %s", p, buf);
}

int wgt_shell(const char *dir, const char *fmt, ...)
{
    char command[4096], line[8192];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(command, sizeof command, fmt, ap);
    va_end(ap);
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) fail_msg("WETGRAPH_BIN is not set");
    snprintf(line, sizeof line, "cd '%s' && WG='%s' && { %s ; } >out 2>err </dev/null", dir, bin,
             command);
    int st = system(line);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

void wgt_shell_expect(const char *dir, int want, const char *what, const char *fmt, ...)
{
    char command[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(command, sizeof command, fmt, ap);
    va_end(ap);
    int st = wgt_shell(dir, "%s", command);
    if (st == want) return;
    char dump[2200];
    snprintf(dump, sizeof dump, "cat '%s/out' '%s/err' >&2", dir, dir);
    if (system(dump)) {
    }
    fail_msg("exit %d, expected %d: %s", st, want, what);
}

const char *wgt_fresh_dir(const char *name)
{
    static char buf[8][1024];
    static int next;
    char *p = buf[next++ & 7];
    snprintf(p, sizeof buf[0], "%s/%s", wgt_tmpdir(), name);
    char cmd[2200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", p, p);
    if (system(cmd) != 0) fail_msg("cannot make the folder %s", p);
    return p;
}

void wgt_gltf_validate(const char *dir, const char *files)
{
    const char *src = getenv("WETGRAPH_SOURCE");
    if (!src || !src[0]) fail_msg("WETGRAPH_SOURCE is not set");
    char check[1200];
    snprintf(check, sizeof check,
             "%s/tools/gltf-validator/node_modules/gltf-validator/package.json", src);
    if (!wgt_exists(check))
        fail_msg("Khronos' glTF-Validator is not installed: run scripts/install-deps.sh (npm ci in "
                 "tools/gltf-validator)");
    wgt_shell_expect(dir, 0, files, "node '%s/tools/gltf-validator/validate.js' %s", src, files);
}

bool wgt_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

int wgt_count_in(const char *path, const char *needle)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    size_t cap = 1 << 16, n = 0;
    char *text = malloc(cap);
    assert_non_null(text);
    for (size_t got; (got = fread(text + n, 1, cap - n - 1, f)) > 0;) {
        n += got;
        if (n + 1 == cap) {
            cap *= 2;
            text = realloc(text, cap);
            assert_non_null(text);
        }
    }
    fclose(f);
    text[n] = '\0';
    int count = 0;
    for (const char *p = strstr(text, needle); p; p = strstr(p + 1, needle)) count++;
    free(text);
    return count;
}

void wgt_sleep_ms(int ms)
{
    struct timespec t = {ms / 1000, (ms % 1000) * 1000000L};
    nanosleep(&t, NULL);
}

void wgt_wait_for(pid_t pid, const char *log_path, const char *needle, int count, int limit_ms)
{
    for (int waited = 0; wgt_count_in(log_path, needle) < count; waited += 5) {
        if (waited > limit_ms)
            fail_msg("%s: '%s' did not appear %d times", log_path, needle, count);
        int st;
        if (waitpid(pid, &st, WNOHANG) == pid) fail_msg("the process ended early (%s)", log_path);
        wgt_sleep_ms(5);
    }
}

int wgt_free_port(void)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(fd >= 0);
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = 0};
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    assert_int_equal(bind(fd, (struct sockaddr *)&sa, sizeof sa), 0);
    socklen_t len = sizeof sa;
    assert_int_equal(getsockname(fd, (struct sockaddr *)&sa, &len), 0);
    close(fd);
    return ntohs(sa.sin_port);
}

pid_t wgt_spawn(const char *dir, const char *out_name, const char *err_name, const char *path_env,
                const char *const args[])
{
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) fail_msg("WETGRAPH_BIN is not set");
    const char *argv[64] = {bin};
    int n = 1;
    while (args[n - 1]) {
        assert_true(n < 63);
        argv[n] = args[n - 1];
        n++;
    }
    argv[n] = NULL;
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        if (chdir(dir) || !freopen(out_name, "w", stdout) || !freopen(err_name, "w", stderr))
            _exit(99);
        if (path_env) setenv("PATH", path_env, 1);
        execv(bin, (char *const *)argv);
        _exit(98);
    }
    return pid;
}

int wgt_stop(pid_t pid, int sig, int limit_ms)
{
    assert_int_equal(kill(pid, sig), 0);
    int st = 0;
    for (int waited = 0; waitpid(pid, &st, WNOHANG) != pid; waited += 5) {
        if (waited > limit_ms) {
            kill(pid, SIGKILL);
            waitpid(pid, &st, 0);
            fail_msg("process %ld did not stop on signal %d", (long)pid, sig);
        }
        wgt_sleep_ms(5);
    }
    return st;
}

void wgt_kill(pid_t pid)
{
    int st;
    if (pid > 0 && waitpid(pid, &st, WNOHANG) == 0) {
        kill(pid, SIGKILL);
        waitpid(pid, &st, 0);
    }
}

int wgt_count_files(const char *folder, int *hidden)
{
    DIR *d = opendir(folder);
    if (!d) return 0;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        char p[2048];
        snprintf(p, sizeof p, "%s/%s", folder, e->d_name);
        struct stat st;
        if (stat(p, &st)) continue; /* gone meanwhile (a temporary renamed) */
        if (S_ISDIR(st.st_mode))
            n += wgt_count_files(p, hidden);
        else if (e->d_name[0] != '.')
            n++;
        else if (hidden)
            ++*hidden;
    }
    closedir(d);
    return n;
}

void wgt_wait_for_files(pid_t pid, const char *folder, int count, int limit_ms)
{
    for (int waited = 0; wgt_count_files(folder, NULL) <= count; waited += 5) {
        if (waited > limit_ms) fail_msg("%s: no more than %d files appeared", folder, count);
        int st;
        if (waitpid(pid, &st, WNOHANG) == pid) fail_msg("the process ended early (%s)", folder);
        wgt_sleep_ms(5);
    }
}

char *wgt_slow_graph(const char *params, const char *radius, const char *directions)
{
    size_t cap = 8192 + strlen(params);
    char *text = malloc(cap);
    assert_non_null(text);
    int n = snprintf(text, cap,
                     "<wetgraph version=\"1\" size=\"1024\">\n"
                     "%s"
                     "  <node id=\"u\" type=\"uniform\" value=\"=level\"/>\n"
                     "  <node id=\"n\" type=\"noise\" scale=\"5\"/>\n"
                     "  <node id=\"ao0\" type=\"blur\" sigma=\"1\"><in name=\"source\" "
                     "from=\"n\"/></node>\n",
                     params);
    for (int i = 1; i <= 16; i++)
        n += snprintf(text + n, cap - (size_t)n,
                      "  <node id=\"ao%d\" type=\"ambient_occlusion\" radius=\"%s\" "
                      "directions=\"%s\"><in name=\"height\" from=\"ao%d\"/></node>\n",
                      i, radius, directions, i - 1);
    snprintf(text + n, cap - (size_t)n,
             "  <output name=\"a\" from=\"u\" format=\"exr32\"/>\n"
             "  <output name=\"c\" from=\"ao16\" format=\"exr32\"/>\n"
             "</wetgraph>\n");
    return text;
}

/* ---- WgWorkers runners ------------------------------------------------------------------- */

_Atomic int wgt_parts_run;

typedef struct {
    void (*fn)(void *, int, int);
    void *user;
    int i;
} Part;

static void *run_part(void *arg)
{
    Part *p = arg;
    p->fn(p->user, p->i, p->i + 1);
    return NULL;
}

int wgt_run_backwards(const void *ctx, int n, void (*fn)(void *, int, int), void *user)
{
    if (ctx) return 1; /* stopped early */
    Part *parts = calloc((size_t)n + 1, sizeof *parts);
    pthread_t *t = calloc((size_t)n + 1, sizeof *t);
    assert_non_null(parts);
    assert_non_null(t);
    for (int i = n - 1; i >= 0; i--) {
        parts[i] = (Part){fn, user, i};
        assert_int_equal(pthread_create(&t[i], NULL, run_part, &parts[i]), 0);
    }
    for (int i = n - 1; i >= 0; i--) pthread_join(t[i], NULL);
    wgt_parts_run += n;
    free(parts);
    free(t);
    return 0;
}

int wgt_run_skipping_one(const void *ctx, int n, void (*fn)(void *, int, int), void *user)
{
    (void)ctx;
    for (int i = 0; i < n; i++)
        if (i != 1) fn(user, i, i + 1);
    return 0;
}
