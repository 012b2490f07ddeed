/* SPDX-License-Identifier: MIT */
/* `wetgraph watch --serve`: a libmicrohttpd server (a listening thread and one thread per
 * connection) beside the watch loop, on IPv4 or IPv6 ([ADDR]:PORT; [::] is dual stack). It
 * serves exactly six things: the page (cli/serve_page.h), GET /api/state (JSON; ?after=V waits
 * for a newer render), GET /out/NAME.png (the latest preview of output NAME, looked up in the
 * output list by exact name and never used as a path), GET /graph.svg (the request's graph
 * drawn by graphviz, 404 when `dot` is not installed), GET or POST /api/set?name=value (a
 * parameter, or $time) and GET /events (server-sent events, one per finished render); any
 * other path is 404. Renders never run here: the watch thread publishes a snapshot (the
 * previews encoded as PNG, the parameters, the graph's nodes and picture, whether it reads
 * $time, node times, the last error) under a mutex, and /api/set only queues the change under
 * that mutex and wakes the watch thread through an eventfd; the watch thread reads the queue
 * when it starts a render, so changes that arrive before it starts are applied together and
 * no render runs for a superseded value. The picture is made by running `dot -Tsvg` (found
 * through PATH, with fixed arguments, the graph on its standard input) in the watch thread
 * when the graph's Graphviz text changes, not on every render. */
#include "serve.h"

#include "png_preview.h"
#include "serve_page.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* PING_S keeps an idle event stream inside the 60 s connection time-out that frees the threads
 * of clients that went away */
enum { MAX_NAME = 128, MAX_VALUE = 512, PING_S = 15 };
/* previews have at most this many pixels on their longer side (the page scales them to fit) */
enum { PREVIEW_MAX = 1024 };
/* dot gets this long (it lays out graphs of a few hundred nodes in well under a second) and
 * may write this much before its picture is given up */
enum { DOT_LIMIT_MS = 10000, MAX_SVG = 16 << 20 };

extern char **environ;

/* A preview's PNG, shared by the snapshots that show the same image. Only the watch thread
 * makes, shares and frees them (HTTP threads copy the bytes under the lock), so the count
 * needs no atomics. */
typedef struct {
    int refs;
    size_t size;
    unsigned char *bytes;
} Png;

static void png_drop(Png *p)
{
    if (p && --p->refs == 0) {
        free(p->bytes);
        free(p);
    }
}

typedef struct {
    char *name;
    Png *png;
    int channels;       /* 1: a gray map (the page may show it in false colour), 4: colour */
    const WgImage *img; /* the image it shows (a reference: its address stays unique) */
    uint64_t version;   /* the render that made the image: the page reloads it when it changes */
} Output;

struct Serve {
    struct MHD_Daemon *d;
    int efd;
    char *file;
    pthread_mutex_t lock;
    pthread_cond_t rendered;
    bool stopping;
    /* the snapshot, under lock */
    uint64_t version; /* renders published */
    char *params_json, *times_json, *sets_json, *error;
    char **param_names;
    int n_params;
    Output *outs;
    int n_outs;
    double time;      /* $time of the last render */
    double next_time; /* $time of the render under way (the watch thread's) */
    bool reads_time;  /* the graph's outputs depend on $time */
    char *nodes_json; /* the graph's nodes: [{"id":..,"type":..},...] */
    char *svg;        /* the graph drawn by dot, or NULL */
    size_t svg_size;
    uint64_t svg_version; /* pictures made so far, for the page's cache-busting address */
    /* queued changes, under lock */
    char **q_name, **q_value;
    int n_q;
    bool q_has_time;
    double q_time;
    /* the watch thread's own: the Graphviz text the picture was made from */
    char *dot_text;
};

typedef struct {
    char *buf;
    size_t size;
    FILE *f;
} Mem;

static FILE *mem_open(Mem *m)
{
    *m = (Mem){0};
    m->f = open_memstream(&m->buf, &m->size);
    return m->f;
}

/* Close m and return its text (owned by the caller), or NULL. */
static char *mem_take(Mem *m)
{
    if (!m->f) return NULL;
    fclose(m->f);
    return m->buf;
}

static const char *type_name(WgParamType t)
{
    switch (t) {
    case WG_PARAM_FLOAT_T:
        return "float";
    case WG_PARAM_INT_T:
        return "int";
    case WG_PARAM_BOOL_T:
        return "bool";
    case WG_PARAM_ENUM_T:
        return "enum";
    case WG_PARAM_COLOR_T:
        return "color";
    default:
        return "string";
    }
}

int serve_fd(const Serve *s)
{
    return s->efd;
}

void serve_drain(Serve *s)
{
    uint64_t v;
    while (read(s->efd, &v, sizeof v) > 0) {
    }
}

int serve_sets(Serve *s, const char **base, int n_base, double base_time, char ***out, int *n,
               double *time)
{
    pthread_mutex_lock(&s->lock);
    serve_drain(s); /* the wake-ups of everything read here */
    *time = s->next_time = s->q_has_time ? s->q_time : base_time;
    char **sets = calloc((size_t)(n_base + s->n_q + 1), sizeof *sets);
    int count = 0, rc = sets ? WG_OK : WG_ERR_NOMEM;
    for (int i = 0; !rc && i < n_base + s->n_q; i++) {
        const char *name = i < n_base ? base[i] : s->q_name[i - n_base];
        size_t len = i < n_base ? strcspn(base[i], "=") : strlen(name);
        char *kv = malloc(len + 2 + strlen(i < n_base ? base[i] : s->q_value[i - n_base]));
        if (!kv) {
            rc = WG_ERR_NOMEM;
            break;
        }
        if (i < n_base)
            strcpy(kv, base[i]);
        else
            sprintf(kv, "%s=%s", name, s->q_value[i - n_base]);
        /* a later value for the same name replaces the earlier one */
        int k = 0;
        for (int j = 0; j < count; j++) {
            if (!strncmp(sets[j], kv, len + 1))
                free(sets[j]);
            else
                sets[k++] = sets[j];
        }
        count = k;
        sets[count++] = kv;
    }
    pthread_mutex_unlock(&s->lock);
    if (rc) {
        serve_sets_free(sets, count);
        return rc;
    }
    *out = sets;
    *n = count;
    return WG_OK;
}

void serve_sets_free(char **sets, int n)
{
    for (int i = 0; sets && i < n; i++) free(sets[i]);
    free(sets);
}

static char *params_json(const WgGraph *g, const char *const *sets, int n_sets)
{
    Mem m;
    FILE *f = mem_open(&m);
    if (!f) return NULL;
    fputc('[', f);
    for (int i = 0; i < wg_graph_param_count(g); i++) {
        const WgGraphParamInfo *p = wg_graph_param_info(g, i);
        const char *value = p->default_text;
        size_t len = strlen(p->name);
        for (int k = 0; k < n_sets; k++)
            if (!strncmp(sets[k], p->name, len) && sets[k][len] == '=') value = sets[k] + len + 1;
        fprintf(f, "%s{\"name\":", i ? "," : "");
        cli_json_string(f, p->name);
        fprintf(f, ",\"type\":\"%s\",\"label\":", type_name(p->type));
        cli_json_string(f, p->label ? p->label : "");
        fputs(",\"default\":", f);
        cli_json_string(f, p->default_text);
        fputs(",\"value\":", f);
        cli_json_string(f, value);
        if (p->has_min) fprintf(f, ",\"min\":%.17g", p->min);
        if (p->has_max) fprintf(f, ",\"max\":%.17g", p->max);
        if (p->values) {
            fputs(",\"values\":[", f);
            for (int k = 0; p->values[k]; k++) {
                if (k) fputc(',', f);
                cli_json_string(f, p->values[k]);
            }
            fputc(']', f);
        }
        fputc('}', f);
    }
    fputc(']', f);
    return mem_take(&m);
}

static char *times_json(const WgResult *res)
{
    Mem m;
    FILE *f = mem_open(&m);
    if (!f) return NULL;
    fputc('[', f);
    for (int i = 0; i < wg_result_stat_count(res); i++) {
        const WgNodeStat *st = wg_result_stat(res, i);
        fputs(i ? ",{\"id\":" : "{\"id\":", f);
        cli_json_string(f, st->id);
        fputs(",\"type\":", f);
        cli_json_string(f, st->type);
        fprintf(f, ",\"ms\":%.3f,\"computed\":%s}", st->ms,
                st->cache == WG_COMPUTED ? "true" : "false");
    }
    fputc(']', f);
    return mem_take(&m);
}

static char *sets_json(const char *const *sets, int n)
{
    Mem m;
    FILE *f = mem_open(&m);
    if (!f) return NULL;
    fputc('[', f);
    for (int i = 0; i < n; i++) {
        if (i) fputc(',', f);
        cli_json_string(f, sets[i]);
    }
    fputc(']', f);
    return mem_take(&m);
}

static void outputs_free(Output *o, int n)
{
    for (int i = 0; i < n; i++) {
        free(o[i].name);
        png_drop(o[i].png);
        wg_image_unref(o[i].img);
    }
    free(o);
}

static char *nodes_json(const WgGraph *g)
{
    Mem m;
    FILE *f = mem_open(&m);
    if (!f) return NULL;
    fputc('[', f);
    for (int i = 0; i < wg_graph_node_count(g); i++) {
        const WgGraphNodeInfo *n = wg_graph_node_info(g, i);
        fputs(i ? ",{\"id\":" : "{\"id\":", f);
        cli_json_string(f, n->id);
        fputs(",\"type\":", f);
        cli_json_string(f, n->type);
        fputc('}', f);
    }
    fputc(']', f);
    return mem_take(&m);
}

/* The graph's Graphviz text: the request's (with the fused groups) or, when there is no
 * request or it cannot be planned, the graph's. */
static char *dot_text(const WgGraph *g, const WgRequest *r)
{
    Mem m;
    FILE *f = mem_open(&m);
    if (!f) return NULL;
    WgError e = {0};
    if (r && !wg_request_write_dot(r, f, &e)) return mem_take(&m);
    free(mem_take(&m));
    if (!(f = mem_open(&m))) return NULL;
    wg_graph_write_dot(g, f);
    return mem_take(&m);
}

static bool write_all(int fd, const char *p, size_t n)
{
    while (n) {
        ssize_t k = write(fd, p, n);
        if (k < 0 && errno == EINTR) continue;
        if (k <= 0) return false;
        p += k;
        n -= (size_t)k;
    }
    return true;
}

/* Run `dot -Tsvg` (through PATH, fixed arguments) on text; the SVG (owned by the caller) or
 * NULL when dot is not installed, fails, takes longer than DOT_LIMIT_MS or writes more than
 * MAX_SVG bytes. The text goes through a memory file, so dot never blocks on a full pipe while
 * its output is read. */
static char *run_dot(const char *text, size_t *size)
{
    char *out = NULL;
    size_t len = 0, cap = 0;
    bool ok = false;
    pid_t pid = -1;
    int in = memfd_create("wetgraph-dot", MFD_CLOEXEC), pipefd[2] = {-1, -1};
    if (in < 0 || pipe2(pipefd, O_CLOEXEC) || !write_all(in, text, strlen(text)) ||
        lseek(in, 0, SEEK_SET))
        goto out;
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t at;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, in, 0);
    posix_spawn_file_actions_adddup2(&fa, pipefd[1], 1);
    posix_spawn_file_actions_addopen(&fa, 2, "/dev/null", O_WRONLY, 0);
    posix_spawnattr_init(&at);
    sigset_t none, dfl;
    sigemptyset(&none); /* the watch thread blocks SIGINT and SIGTERM; dot must not */
    sigemptyset(&dfl);
    sigaddset(&dfl, SIGPIPE);
    posix_spawnattr_setsigmask(&at, &none);
    posix_spawnattr_setsigdefault(&at, &dfl);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    char *argv[] = {"dot", "-Tsvg", NULL};
    int rc = posix_spawnp(&pid, "dot", &fa, &at, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&at);
    close(pipefd[1]);
    pipefd[1] = -1;
    if (rc) {
        pid = -1;
        goto out;
    }
    struct timespec t0, t;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (;;) {
        clock_gettime(CLOCK_MONOTONIC, &t);
        long left =
            DOT_LIMIT_MS - ((t.tv_sec - t0.tv_sec) * 1000 + (t.tv_nsec - t0.tv_nsec) / 1000000);
        struct pollfd pf = {pipefd[0], POLLIN, 0};
        if (left <= 0 || len > MAX_SVG) goto out;
        int n = poll(&pf, 1, (int)left);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) goto out;
        if (len + 65536 + 1 > cap) {
            char *grown = realloc(out, cap = 2 * cap + 65536 + 1);
            if (!grown) goto out;
            out = grown;
        }
        ssize_t k = read(pipefd[0], out + len, cap - len - 1);
        if (k < 0 && errno == EINTR) continue;
        if (k < 0) goto out;
        if (k == 0) break;
        len += (size_t)k;
    }
    ok = true;
out:
    if (pid > 0) {
        int st = 0;
        pid_t w;
        if (!ok) kill(pid, SIGKILL);
        while ((w = waitpid(pid, &st, 0)) < 0 && errno == EINTR) {
        }
        ok = ok && w == pid && WIFEXITED(st) && WEXITSTATUS(st) == 0;
    }
    if (in >= 0) close(in);
    if (pipefd[0] >= 0) close(pipefd[0]);
    if (pipefd[1] >= 0) close(pipefd[1]);
    if (ok && out) {
        out[len] = '\0';
        ok = strstr(out, "<svg") != NULL;
    }
    if (!ok) {
        free(out);
        return NULL;
    }
    *size = len;
    return out;
}

/* The PNG of o->img: the previous render's when that showed the same image under the same name
 * (the engine's memory cache handed the image back: nothing it depends on changed), else a new
 * one, reduced by the smallest whole factor that brings its longer side to PREVIEW_MAX or less
 * (each pixel the mean of a block). s->outs is only ever replaced by the
 * watch thread, which runs this, so reading it here needs no lock. */
static void preview(const Serve *s, Output *o, WgColorspace cs)
{
    for (int k = 0; k < s->n_outs; k++) {
        const Output *p = &s->outs[k];
        if (p->img == o->img && p->png && o->name && !strcmp(p->name, o->name)) {
            o->png = p->png;
            o->png->refs++;
            o->version = p->version;
            return;
        }
    }
    const WgImage *img = o->img;
    int side = img->width > img->height ? img->width : img->height;
    o->png = calloc(1, sizeof *o->png);
    if (o->png && wg_png_preview(img, (side + PREVIEW_MAX - 1) / PREVIEW_MAX, cs, &o->png->bytes,
                                 &o->png->size)) {
        free(o->png);
        o->png = NULL;
    }
    if (o->png) o->png->refs = 1;
    o->version = s->version + 1; /* the render being published */
}

void serve_publish(Serve *s, const WgGraph *g, const WgRequest *r, const WgResult *res,
                   const WgError *err, const char *const *sets, int n_sets)
{
    /* everything is prepared outside the lock: readers wait only for the swap */
    char *params = NULL, **names = NULL, *times = NULL, *setj = sets_json(sets, n_sets);
    char *error = NULL, *nodes = NULL, *svg = NULL, *dot = NULL;
    size_t svg_size = 0;
    bool reads = s->reads_time; /* kept while the request does not plan (an edit under way) */
    int n_names = 0, n_outs = 0;
    Output *outs = NULL;
    if (g) {
        params = params_json(g, sets, n_sets);
        nodes = nodes_json(g);
        WgError e = {0};
        bool b;
        if (r && !wg_request_reads_time(r, &b, &e)) reads = b;
        dot = dot_text(g, r);
        if (dot && s->dot_text && !strcmp(dot, s->dot_text)) { /* the same picture */
            free(dot);
            dot = NULL;
        } else if (dot) {
            svg = run_dot(dot, &svg_size);
            free(s->dot_text);
            s->dot_text = dot; /* only the watch thread reads it */
        }
        n_names = wg_graph_param_count(g);
        names = calloc((size_t)n_names + 1, sizeof *names);
        for (int i = 0; names && i < n_names; i++)
            names[i] = strdup(wg_graph_param_info(g, i)->name);
    }
    if (res) {
        times = times_json(res);
        n_outs = wg_result_output_count(res);
        outs = calloc((size_t)n_outs + 1, sizeof *outs);
        for (int i = 0; outs && i < n_outs; i++) {
            const WgImage *img = wg_result_output_image(res, i);
            outs[i].name = strdup(wg_result_output_name(res, i));
            outs[i].channels = img->channels;
            outs[i].img = wg_image_ref(img);
            preview(s, &outs[i], wg_result_output_colorspace(res, i));
        }
    }
    if (err) {
        char buf[4096];
        wg_error_format(err, buf, sizeof buf);
        error = strdup(buf);
    }
    pthread_mutex_lock(&s->lock);
    if (g && params && names) {
        free(s->params_json);
        for (int i = 0; i < s->n_params; i++) free(s->param_names[i]);
        free(s->param_names);
        s->params_json = params;
        s->param_names = names;
        s->n_params = n_names;
        params = NULL;
        names = NULL;
        s->reads_time = reads;
    }
    if (g && nodes) {
        free(s->nodes_json);
        s->nodes_json = nodes;
        nodes = NULL;
    }
    if (dot) { /* a new picture, or none when dot failed */
        free(s->svg);
        s->svg = svg;
        s->svg_size = svg_size;
        s->svg_version++;
        svg = NULL;
    }
    if (res && outs && times) {
        outputs_free(s->outs, s->n_outs);
        free(s->times_json);
        s->outs = outs;
        s->n_outs = n_outs;
        s->times_json = times;
        s->time = s->next_time;
        outs = NULL;
        times = NULL;
    }
    if (setj) {
        free(s->sets_json);
        s->sets_json = setj;
        setj = NULL;
    }
    free(s->error);
    s->error = error;
    s->version++;
    pthread_cond_broadcast(&s->rendered);
    pthread_mutex_unlock(&s->lock);
    free(params);
    for (int i = 0; names && i < n_names; i++) free(names[i]);
    free(names);
    outputs_free(outs, outs ? n_outs : 0);
    free(times);
    free(setj);
    free(nodes);
    free(svg);
}

static enum MHD_Result respond(struct MHD_Connection *c, unsigned status, const char *type,
                               const void *data, size_t size)
{
    struct MHD_Response *r =
        MHD_create_response_from_buffer(size, (void *)data, MHD_RESPMEM_MUST_COPY);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", type);
    MHD_add_response_header(r, "Cache-Control", "no-store");
    enum MHD_Result ok = MHD_queue_response(c, status, r);
    MHD_destroy_response(r);
    return ok;
}

static enum MHD_Result respond_text(struct MHD_Connection *c, unsigned status, const char *type,
                                    const char *text)
{
    return respond(c, status, type, text, strlen(text));
}

static enum MHD_Result not_found(struct MHD_Connection *c)
{
    return respond_text(c, MHD_HTTP_NOT_FOUND, "text/plain", "not found\n");
}

static enum MHD_Result state(Serve *s, struct MHD_Connection *c)
{
    /* ?after=V: answer once render V+1 is published (at most PING_S later): a page that does not
     * keep /events open waits for the next render without polling */
    const char *after = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "after");
    char *end = NULL;
    unsigned long long v = after ? strtoull(after, &end, 10) : 0;
    if (after && (!*after || *end))
        return respond_text(c, MHD_HTTP_BAD_REQUEST, "text/plain", "after: a render number\n");
    Mem m;
    FILE *f = mem_open(&m);
    if (!f) return MHD_NO;
    pthread_mutex_lock(&s->lock);
    if (after) {
        struct timespec until;
        clock_gettime(CLOCK_REALTIME, &until);
        until.tv_sec += PING_S;
        int rc = 0;
        while (!s->stopping && s->version <= v && rc != ETIMEDOUT)
            rc = pthread_cond_timedwait(&s->rendered, &s->lock, &until);
    }
    fprintf(f, "{\"version\":%llu,\"file\":", (unsigned long long)s->version);
    cli_json_string(f, s->file);
    fprintf(f, ",\"params\":%s,\"time\":%.17g,\"reads_time\":%s,\"nodes\":%s,\"svg\":",
            s->params_json ? s->params_json : "[]", s->time, s->reads_time ? "true" : "false",
            s->nodes_json ? s->nodes_json : "[]");
    if (s->svg)
        fprintf(f, "%llu", (unsigned long long)s->svg_version);
    else
        fputs("null", f);
    fputs(",\"outputs\":[", f);
    for (int i = 0; i < s->n_outs; i++) {
        fputs(i ? ",{\"name\":" : "{\"name\":", f);
        cli_json_string(f, s->outs[i].name);
        fprintf(f, ",\"version\":%llu,\"channels\":%d}", (unsigned long long)s->outs[i].version,
                s->outs[i].channels);
    }
    fprintf(f, "],\"times\":%s,\"sets\":%s,\"error\":", s->times_json ? s->times_json : "[]",
            s->sets_json ? s->sets_json : "[]");
    if (s->error)
        cli_json_string(f, s->error);
    else
        fputs("null", f);
    fputs("}\n", f);
    pthread_mutex_unlock(&s->lock);
    char *text = mem_take(&m);
    if (!text) return MHD_NO;
    enum MHD_Result ok = respond_text(c, MHD_HTTP_OK, "application/json", text);
    free(text);
    return ok;
}

static enum MHD_Result image(Serve *s, struct MHD_Connection *c, const char *name, size_t len)
{
    pthread_mutex_lock(&s->lock);
    for (int i = 0; i < s->n_outs; i++) {
        if (strlen(s->outs[i].name) != len || memcmp(s->outs[i].name, name, len) || !s->outs[i].png)
            continue;
        enum MHD_Result ok =
            respond(c, MHD_HTTP_OK, "image/png", s->outs[i].png->bytes, s->outs[i].png->size);
        pthread_mutex_unlock(&s->lock);
        return ok;
    }
    pthread_mutex_unlock(&s->lock);
    return not_found(c);
}

static enum MHD_Result graph_svg(Serve *s, struct MHD_Connection *c)
{
    pthread_mutex_lock(&s->lock);
    if (!s->svg) {
        pthread_mutex_unlock(&s->lock);
        return not_found(c);
    }
    struct MHD_Response *r =
        MHD_create_response_from_buffer(s->svg_size, s->svg, MHD_RESPMEM_MUST_COPY);
    pthread_mutex_unlock(&s->lock);
    if (!r) return MHD_NO;
    MHD_add_response_header(r, "Content-Type", "image/svg+xml");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    /* the picture is only ever shown as an image: nothing in it runs */
    MHD_add_response_header(r, "Content-Security-Policy",
                            "default-src 'none'; style-src 'unsafe-inline'");
    enum MHD_Result ok = MHD_queue_response(c, MHD_HTTP_OK, r);
    MHD_destroy_response(r);
    return ok;
}

typedef struct {
    Serve *s;
    char msg[256];
    int n;
} SetCtx;

static bool known_param(const Serve *s, const char *name)
{
    for (int i = 0; i < s->n_params; i++)
        if (!strcmp(s->param_names[i], name)) return true;
    return false;
}

/* Called with s->lock held: queue one change. */
static enum MHD_Result set_one(void *cls, enum MHD_ValueKind kind, const char *key,
                               const char *value)
{
    (void)kind;
    SetCtx *x = cls;
    Serve *s = x->s;
    if (x->msg[0]) return MHD_NO;
    if (!value || strlen(key) > MAX_NAME || strlen(value) > MAX_VALUE) {
        snprintf(x->msg, sizeof x->msg, "'%.64s': a value of at most %d characters is needed", key,
                 MAX_VALUE);
        return MHD_NO;
    }
    for (const char *p = value; *p; p++)
        if ((unsigned char)*p < 0x20) {
            snprintf(x->msg, sizeof x->msg, "'%.64s': the value has a control character", key);
            return MHD_NO;
        }
    if (!strcmp(key, "$time")) {
        double t;
        if (!wg_parse_number(value, &t)) {
            snprintf(x->msg, sizeof x->msg, "$time: '%.64s' is not a number", value);
            return MHD_NO;
        }
        s->q_has_time = true;
        s->q_time = t;
        x->n++;
        return MHD_YES;
    }
    if (!known_param(s, key)) {
        snprintf(x->msg, sizeof x->msg, "the graph has no parameter '%.64s'", key);
        return MHD_NO;
    }
    for (int i = 0; i < s->n_q; i++)
        if (!strcmp(s->q_name[i], key)) {
            char *v = strdup(value);
            if (!v) return MHD_NO;
            free(s->q_value[i]);
            s->q_value[i] = v;
            x->n++;
            return MHD_YES;
        }
    char **nn = realloc(s->q_name, sizeof *nn * (size_t)(s->n_q + 1));
    if (nn) s->q_name = nn;
    char **vv = realloc(s->q_value, sizeof *vv * (size_t)(s->n_q + 1));
    if (vv) s->q_value = vv;
    char *k = strdup(key), *v = strdup(value);
    if (!nn || !vv || !k || !v) {
        free(k);
        free(v);
        snprintf(x->msg, sizeof x->msg, "out of memory");
        return MHD_NO;
    }
    s->q_name[s->n_q] = k;
    s->q_value[s->n_q++] = v;
    x->n++;
    return MHD_YES;
}

static enum MHD_Result set(Serve *s, struct MHD_Connection *c)
{
    SetCtx x = {s, "", 0};
    pthread_mutex_lock(&s->lock);
    MHD_get_connection_values(c, MHD_GET_ARGUMENT_KIND, set_one, &x);
    if (x.n) { /* under the lock: serve_sets reads the queue and the wake-ups together */
        uint64_t one = 1;
        if (write(s->efd, &one, sizeof one) < 0) {
        } /* a full counter still wakes the loop */
    }
    pthread_mutex_unlock(&s->lock);
    char body[400];
    if (x.msg[0]) {
        Mem m;
        FILE *f = mem_open(&m);
        if (!f) return MHD_NO;
        fputs("{\"ok\":false,\"error\":", f);
        cli_json_string(f, x.msg);
        fputs("}\n", f);
        char *text = mem_take(&m);
        if (!text) return MHD_NO;
        enum MHD_Result ok = respond_text(c, MHD_HTTP_BAD_REQUEST, "application/json", text);
        free(text);
        return ok;
    }
    snprintf(body, sizeof body, "{\"ok\":true,\"queued\":%d}\n", x.n);
    return respond_text(c, MHD_HTTP_OK, "application/json", body);
}

typedef struct {
    Serve *s;
    uint64_t seen;
} Events;

static ssize_t events_read(void *cls, uint64_t pos, char *buf, size_t max)
{
    (void)pos;
    Events *ev = cls;
    Serve *s = ev->s;
    pthread_mutex_lock(&s->lock);
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    until.tv_sec += PING_S;
    int rc = 0;
    while (!s->stopping && s->version == ev->seen && rc != ETIMEDOUT)
        rc = pthread_cond_timedwait(&s->rendered, &s->lock, &until);
    bool stop = s->stopping;
    uint64_t v = s->version;
    bool err = s->error != NULL;
    pthread_mutex_unlock(&s->lock);
    if (stop) return MHD_CONTENT_READER_END_OF_STREAM;
    int n;
    if (v == ev->seen)
        n = snprintf(buf, max, ": ping\n\n"); /* finds closed connections */
    else
        n = snprintf(buf, max, "event: render\ndata: {\"version\":%llu,\"error\":%s}\n\n",
                     (unsigned long long)v, err ? "true" : "false");
    ev->seen = v;
    return n < 0 || (size_t)n >= max ? MHD_CONTENT_READER_END_WITH_ERROR : n;
}

static enum MHD_Result events(Serve *s, struct MHD_Connection *c)
{
    Events *ev = malloc(sizeof *ev);
    if (!ev) return MHD_NO;
    pthread_mutex_lock(&s->lock);
    *ev = (Events){s, s->version};
    pthread_mutex_unlock(&s->lock);
    struct MHD_Response *r =
        MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 1024, events_read, ev, free);
    if (!r) {
        free(ev);
        return MHD_NO;
    }
    MHD_add_response_header(r, "Content-Type", "text/event-stream");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    enum MHD_Result ok = MHD_queue_response(c, MHD_HTTP_OK, r);
    MHD_destroy_response(r);
    return ok;
}

static enum MHD_Result handle(void *cls, struct MHD_Connection *c, const char *url,
                              const char *method, const char *version, const char *upload,
                              size_t *upload_size, void **con_cls)
{
    (void)version;
    (void)upload;
    Serve *s = cls;
    static int started;
    if (!*con_cls) { /* first call: headers only */
        *con_cls = &started;
        return MHD_YES;
    }
    if (*upload_size) { /* a body is not used: POST /api/set takes the query string */
        *upload_size = 0;
        return MHD_YES;
    }
    bool get = !strcmp(method, "GET") || !strcmp(method, "HEAD");
    bool post = !strcmp(method, "POST");
    if (!get && !post)
        return respond_text(c, MHD_HTTP_METHOD_NOT_ALLOWED, "text/plain", "method not allowed\n");
    if (!strcmp(url, "/api/set")) return set(s, c);
    if (!get) return not_found(c);
    if (!strcmp(url, "/") || !strcmp(url, "/index.html"))
        return respond_text(c, MHD_HTTP_OK, "text/html; charset=utf-8", serve_page);
    if (!strcmp(url, "/api/state")) return state(s, c);
    if (!strcmp(url, "/events")) return events(s, c);
    if (!strcmp(url, "/graph.svg")) return graph_svg(s, c);
    size_t len = strlen(url);
    if (!strncmp(url, "/out/", 5) && len > 9 && !strcmp(url + len - 4, ".png"))
        return image(s, c, url + 5, len - 9);
    return not_found(c);
}

static void serve_free(Serve *s)
{
    if (!s) return;
    if (s->efd >= 0) close(s->efd);
    free(s->file);
    free(s->params_json);
    free(s->times_json);
    free(s->sets_json);
    free(s->error);
    free(s->nodes_json);
    free(s->svg);
    free(s->dot_text);
    for (int i = 0; i < s->n_params; i++) free(s->param_names[i]);
    free(s->param_names);
    outputs_free(s->outs, s->n_outs);
    for (int i = 0; i < s->n_q; i++) {
        free(s->q_name[i]);
        free(s->q_value[i]);
    }
    free(s->q_name);
    free(s->q_value);
    pthread_mutex_destroy(&s->lock);
    pthread_cond_destroy(&s->rendered);
    free(s);
}

/* Parse spec: PORT, IPV4:PORT or [IPV6]:PORT. */
static int parse_spec(const char *spec, struct sockaddr_storage *ss, bool *v6, WgError *err)
{
    char addr[64] = "127.0.0.1";
    const char *port_text = spec;
    *v6 = false;
    if (spec[0] == '[') {
        const char *close = strchr(spec, ']');
        if (!close || close[1] != ':' || (size_t)(close - spec - 1) >= sizeof addr)
            return wg_error_set(err, WG_ERR_RANGE, NULL,
                                "--serve %s: expected [IPV6]:PORT, such as [::1]:8080", spec);
        snprintf(addr, sizeof addr, "%.*s", (int)(close - spec - 1), spec + 1);
        port_text = close + 2;
        *v6 = true;
    } else if (strchr(spec, ':')) {
        const char *colon = strchr(spec, ':');
        if (strchr(colon + 1, ':'))
            return wg_error_set(err, WG_ERR_RANGE, NULL,
                                "--serve %s: an IPv6 address goes in brackets: [ADDR]:PORT, "
                                "such as [::1]:8080",
                                spec);
        if ((size_t)(colon - spec) >= sizeof addr || colon == spec)
            return wg_error_set(err, WG_ERR_RANGE, NULL,
                                "--serve %s: expected [ADDR:]PORT with an IPv4 address, or "
                                "[IPV6]:PORT",
                                spec);
        snprintf(addr, sizeof addr, "%.*s", (int)(colon - spec), spec);
        port_text = colon + 1;
    }
    char *end;
    errno = 0;
    long port = strtol(port_text, &end, 10);
    if (!*port_text || *end || errno || port < 1 || port > 65535 || *port_text == '+' ||
        *port_text == '-' || *port_text == ' ')
        return wg_error_set(err, WG_ERR_RANGE, NULL,
                            "--serve %s: the port must be a number from 1 to 65535", spec);
    memset(ss, 0, sizeof *ss);
    if (*v6) {
        struct sockaddr_in6 *sa = (struct sockaddr_in6 *)ss;
        sa->sin6_family = AF_INET6;
        sa->sin6_port = htons((uint16_t)port);
        if (inet_pton(AF_INET6, addr, &sa->sin6_addr) != 1)
            return wg_error_set(err, WG_ERR_RANGE, NULL,
                                "--serve %s: '%s' is not an IPv6 address such as ::1", spec, addr);
    } else {
        struct sockaddr_in *sa = (struct sockaddr_in *)ss;
        sa->sin_family = AF_INET;
        sa->sin_port = htons((uint16_t)port);
        if (inet_pton(AF_INET, addr, &sa->sin_addr) != 1)
            return wg_error_set(err, WG_ERR_RANGE, NULL,
                                "--serve %s: '%s' is not an IPv4 address such as 127.0.0.1", spec,
                                addr);
    }
    return WG_OK;
}

int serve_start(const char *spec, const char *graph_file, Serve **out, WgError *err)
{
    *out = NULL;
    struct sockaddr_storage ss;
    bool v6;
    int rc = parse_spec(spec, &ss, &v6, err);
    if (rc) return rc;
    Serve *s = calloc(1, sizeof *s);
    if (!s) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    pthread_mutex_init(&s->lock, NULL);
    pthread_cond_init(&s->rendered, NULL);
    s->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    s->file = strdup(graph_file);
    if (s->efd < 0 || !s->file) {
        serve_free(s);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "--serve: cannot create the server");
    }
    /* no MHD_USE_ERROR_LOG: its messages would duplicate the error below (and call the port
     * given with MHD_OPTION_SOCK_ADDR 0) */
    unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_THREAD_PER_CONNECTION;
    if (v6) /* [::] also takes IPv4 connections (dual stack) */
        flags |= IN6_IS_ADDR_UNSPECIFIED(&((struct sockaddr_in6 *)&ss)->sin6_addr)
                     ? MHD_USE_DUAL_STACK
                     : MHD_USE_IPv6;
    s->d = MHD_start_daemon(flags, 0, NULL, NULL, handle, s, MHD_OPTION_SOCK_ADDR,
                            (struct sockaddr *)&ss, MHD_OPTION_CONNECTION_LIMIT, 64u,
                            MHD_OPTION_CONNECTION_TIMEOUT, 60u, MHD_OPTION_END);
    if (!s->d) {
        int e = errno;
        serve_free(s);
        return wg_error_set(err, WG_ERR_IO, NULL, "--serve %s: cannot listen: %s", spec,
                            strerror(e));
    }
    *out = s;
    return WG_OK;
}

void serve_stop(Serve *s)
{
    if (!s) return;
    pthread_mutex_lock(&s->lock);
    s->stopping = true;
    pthread_cond_broadcast(&s->rendered);
    pthread_mutex_unlock(&s->lock);
    MHD_stop_daemon(s->d);
    serve_free(s);
}
