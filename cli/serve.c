/* SPDX-License-Identifier: MIT */
/* `wetgraph watch --serve`: a libmicrohttpd server (a listening thread and one thread per
 * connection) beside the watch loop, on IPv4 or IPv6 ([ADDR]:PORT; [::] is dual stack). It
 * serves exactly these things: the page (web/index.html with the run's token filled in, at / and
 * /index.html) and its files (web/page.js, web/page.css and the shaders of docs/shaders under
 * /shaders/, compiled in by web/embed.c, looked up by exact address), GET /map/NAME and
 * GET /map/$INPUT (an output's image, or a graph input given as a file, as half floats for the
 * page's 3D view), GET /env/K (environment K's env_prefilter atlas, made once by the watch
 * thread before the first render), GET /view.png (the image of the node the page picked with
 * $view, rendered by the watch thread after each render), GET /api/state (JSON; ?after=V waits
 * for a newer render), GET /out/NAME.png (the latest preview of output NAME, looked up in the
 * output list by exact name and never used as a path), GET /graph.svg (the request's graph
 * drawn by graphviz, 404 when `dot` is not installed), POST /api/set (parameters, or $time, as
 * name=value pairs in the query string or an application/x-www-form-urlencoded body; all are
 * checked before any is queued) and GET /events (server-sent events, one per finished render);
 * any other path is 404. Only this server's own page may use it: a request whose Host is not
 * this server (localhost, a loopback address or the bound one, with the port) is 421, so a
 * name an attacker points here (DNS rebinding) reads nothing; a request another site's page
 * makes (Sec-Fetch-Site) is 403 unless it is a navigation, and a change also needs POST, no
 * foreign Origin and the run's random token, which only the page carries (in a header, which
 * another site's page cannot send without the server's consent). A target with %00 is refused
 * (it would decode to a shorter name). Connections that send nothing for IDLE_S seconds are
 * closed and there are many connection threads, so half-sent requests do not lock the page
 * out. Renders never run here: the watch thread publishes a snapshot (the
 * previews encoded as PNG, the parameters, the graph's nodes and picture, whether it reads
 * $time, node times, the last error) under a mutex, and /api/set only queues the change under
 * that mutex and wakes the watch thread through an eventfd; the watch thread reads the queue
 * when it starts a render, so changes that arrive before it starts are applied together and
 * no render runs for a superseded value. The picture is made by running `dot -Tsvg` (found
 * through PATH, with fixed arguments, the graph on its standard input) in the watch thread
 * when the graph's Graphviz text changes, not on every render. */
#include "serve.h"

#include "png_preview.h"
#include "web.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* A connection that sends nothing for IDLE_S seconds is closed (a request whose headers never
 * end holds a thread only that long); the event stream and /api/state?after=V, which wait for
 * a render, get LONG_S, and PING_S keeps an idle event stream inside it (the time-out frees the
 * threads of clients that went away). Up to CONNECTIONS connections, PER_ADDRESS from one
 * client address: half-sent requests from one address cannot take every thread. */
enum { MAX_NAME = 128, MAX_VALUE = 512, MAX_CHANGES = 64, MAX_BODY = 16384 };
enum { PING_S = 15, IDLE_S = 5, LONG_S = 60, CONNECTIONS = 512, PER_ADDRESS = 128 };
/* the header that carries the run's token with a change (the page has it) */
#define TOKEN_HEADER "X-Wetgraph-Token"
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

static enum MHD_Result not_found(struct MHD_Connection *c);

static void png_drop(Png *p)
{
    if (p && --p->refs == 0) {
        free(p->bytes);
        free(p);
    }
}

typedef struct Env Env;

typedef struct {
    char *name;
    Png *png;
    int channels;       /* 1: a gray map (the page may show it in false colour), 4: colour */
    const WgImage *img; /* the image it shows (a reference: its address stays unique) */
    uint64_t version;   /* the render that made the image: the page reloads it when it changes */
} Output;

struct Serve {
    struct MHD_Daemon *d;
    struct sockaddr_storage addr; /* the address it listens on */
    int port;
    bool wildcard;  /* it listens on every address (0.0.0.0 or [::]) */
    char token[33]; /* a random token per run, in hex: /api/set needs it */
    char *page[2];  /* the page with the token: [1] applies its address's ?set=, [0] not */
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
    /* the graph's image inputs given as files (--input NAME=FILE), for the 3D view's dry
     * material: read by the watch thread when the file changes, under lock when swapped */
    char **in_spec; /* NAME=FILE */
    struct stat *in_st;
    int n_in_spec;
    Output *ins; /* named "$NAME" */
    int n_ins;
    /* the node whose image the page asked to see ($view; "" none), the graph's node ids (what
     * $view may name), and that node's last image, under lock */
    char *view_node;
    char **node_ids;
    int n_node_ids;
    Output view;
    char *view_error;
    /* the 3D view's environments: their names and files, and their env_prefilter atlases
     * (NULL until the watch thread has made them, once each) */
    Env *envs;
    int n_envs;
};

/* An environment of the 3D view: an equirectangular HDR file, or the built-in sky (path NULL),
 * and its atlas. */
struct Env {
    char *name, *path;
    WgImage *atlas;
    char *error; /* why it has no atlas, or NULL */
};

/* A request's own state (libmicrohttpd's con_cls), from its first line to its end. */
typedef struct {
    bool started; /* the headers are in */
    bool nul;     /* the target, as sent, has %00 */
    char *body;   /* up to MAX_BODY bytes of the body */
    size_t body_size;
    bool body_too_big;
} Req;

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
        fprintf(f, ",\"type\":\"%s\",\"label\":", wg_param_type_name(p->type));
        cli_json_string(f, p->label ? p->label : "");
        fputs(",\"default\":", f);
        cli_json_string(f, p->default_text);
        fputs(",\"value\":", f);
        cli_json_string(f, value);
        if (p->has_min) fprintf(f, ",\"min\":%.17g", p->min);
        if (p->has_max) fprintf(f, ",\"max\":%.17g", p->max);
        if (p->has_soft_min) fprintf(f, ",\"soft_min\":%.17g", p->soft_min);
        if (p->has_soft_max) fprintf(f, ",\"soft_max\":%.17g", p->soft_max);
        if (p->has_step) fprintf(f, ",\"step\":%.17g", p->step);
        if (p->group) {
            fputs(",\"group\":", f);
            cli_json_string(f, p->group);
        }
        if (p->description) {
            fputs(",\"description\":", f);
            cli_json_string(f, p->description);
        }
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

static void outputs_free_one(Output *o)
{
    free(o->name);
    png_drop(o->png);
    wg_image_unref(o->img);
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

/* ---- the 3D view's maps and environments ------------------------------------------------- */

/* f as an IEEE 754 half float, rounded to nearest even; values beyond the largest half (65504,
 * an HDR sun can be brighter) and infinities become it, NaN 0. */
static uint16_t to_half(float f)
{
    if (f != f) return 0;
    uint32_t x;
    memcpy(&x, &f, sizeof x);
    uint16_t sign = (uint16_t)((x >> 16) & 0x8000);
    x &= 0x7fffffff;
    if (x >= 0x477fe000) return sign | 0x7bff; /* 65504 and above (65504 rounds to itself) */
    if (x < 0x38800000) {                      /* below 2^-14: a subnormal half, or 0 */
        float a;
        memcpy(&a, &x, sizeof a);
        return sign | (uint16_t)lrintf(a * 16777216.0f); /* units of 2^-24 */
    }
    /* the exponent rebiased (127 to 15) and the mantissa rounded to 10 bits, to nearest even */
    return sign | (uint16_t)((x - 0x38000000u + 0xfffu + ((x >> 13) & 1u)) >> 13);
}

/* img reduced by the whole factor k (each value the mean of a k x k block, the edge's blocks
 * smaller), as little-endian half floats, row by row from the top, the channels of a pixel
 * together; *w, *h the reduced size. The caller frees the bytes. */
static uint16_t *half_pixels(const WgImage *img, int k, int *w, int *h, size_t *size)
{
    int ch = img->channels;
    *w = (img->width + k - 1) / k;
    *h = (img->height + k - 1) / k;
    *size = sizeof(uint16_t) * (size_t)*w * (size_t)*h * (size_t)ch;
    uint16_t *out = malloc(*size);
    if (!out) return NULL;
    for (int y = 0; y < *h; y++)
        for (int x = 0; x < *w; x++)
            for (int c = 0; c < ch; c++) {
                double sum = 0;
                int n = 0;
                for (int j = y * k; j < y * k + k && j < img->height; j++) {
                    const float *row = wg_image_row(img, j);
                    for (int i = x * k; i < x * k + k && i < img->width; i++, n++)
                        sum += row[(size_t)i * (size_t)ch + (size_t)c];
                }
                uint16_t v = to_half((float)(sum / n));
                unsigned char *b =
                    (unsigned char *)&out[((size_t)y * (size_t)*w + (size_t)x) * ch + c];
                b[0] = (unsigned char)(v & 0xff); /* little-endian whatever the machine */
                b[1] = (unsigned char)(v >> 8);
            }
    return out;
}

/* GET /map/NAME (an output) or /map/$NAME (a graph input given as a file): the image at the
 * previews' size (reduced by the same whole factor), as half floats (half_pixels); the header
 * X-Wetgraph-Size gives "WIDTH HEIGHT CHANNELS". GET /env/K: environment K's env_prefilter
 * atlas the same way, at its full size; 404 while it is being made. */
static enum MHD_Result pixels(Serve *s, struct MHD_Connection *c, const char *name, int env)
{
    const WgImage *img = NULL;
    pthread_mutex_lock(&s->lock);
    if (env >= 0) {
        if (env < s->n_envs && s->envs[env].atlas) img = wg_image_ref(s->envs[env].atlas);
    } else {
        for (int i = 0; !img && i < s->n_outs; i++)
            if (!strcmp(s->outs[i].name, name) && s->outs[i].img)
                img = wg_image_ref(s->outs[i].img);
        for (int i = 0; !img && i < s->n_ins; i++)
            if (!strcmp(s->ins[i].name, name) && s->ins[i].img) img = wg_image_ref(s->ins[i].img);
    }
    pthread_mutex_unlock(&s->lock);
    if (!img) return not_found(c);
    int side = img->width > img->height ? img->width : img->height;
    int k = env >= 0 ? 1 : (side + PREVIEW_MAX - 1) / PREVIEW_MAX, w, h;
    size_t size;
    uint16_t *data = half_pixels(img, k, &w, &h, &size);
    int ch = img->channels;
    wg_image_unref(img);
    if (!data) return MHD_NO;
    struct MHD_Response *r = MHD_create_response_from_buffer(size, data, MHD_RESPMEM_MUST_FREE);
    if (!r) {
        free(data);
        return MHD_NO;
    }
    char dims[64];
    snprintf(dims, sizeof dims, "%d %d %d", w, h, ch);
    MHD_add_response_header(r, "Content-Type", "application/octet-stream");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    MHD_add_response_header(r, "X-Wetgraph-Size", dims);
    enum MHD_Result ok = MHD_queue_response(c, MHD_HTTP_OK, r);
    MHD_destroy_response(r);
    return ok;
}

int serve_view_setup(Serve *s, const char *const *inputs, int n_inputs, const char *const *envs,
                     int n_envs)
{
    s->in_spec = calloc((size_t)n_inputs + 1, sizeof *s->in_spec);
    s->in_st = calloc((size_t)n_inputs + 1, sizeof *s->in_st);
    s->envs = calloc((size_t)n_envs + n_inputs + 1, sizeof *s->envs);
    if (!s->in_spec || !s->in_st || !s->envs) return WG_ERR_NOMEM;
    for (int i = 0; i < n_inputs; i++) {
        if (!(s->in_spec[i] = strdup(inputs[i]))) return WG_ERR_NOMEM;
        s->n_in_spec++;
    }
    /* the environments: every --env FILE, and the graph's own --input environment=FILE */
    for (int i = 0; i < n_envs + n_inputs; i++) {
        const char *path = i < n_envs ? envs[i] : NULL;
        if (i >= n_envs && !strncmp(inputs[i - n_envs], "environment=", 12))
            path = inputs[i - n_envs] + 12;
        if (!path) continue;
        const char *slash = strrchr(path, '/');
        Env *v = &s->envs[s->n_envs];
        v->path = strdup(path);
        v->name = strdup(slash ? slash + 1 : path);
        if (!v->path || !v->name) return WG_ERR_NOMEM;
        s->n_envs++;
    }
    return WG_OK;
}

/* The atlas of an environment: env_prefilter at 512 (blocks of 256 x 128) over the file, or
 * over the built-in sky (path NULL: a blue gradient above the horizon, a dim ground below and
 * a small sun, bright enough to give highlights). */
static const char prefilter_xml[] =
    "<wetgraph version=\"1\" size=\"512\">\n"
    "  <input name=\"environment\" type=\"color\"/>\n"
    "  <node id=\"atlas\" type=\"env_prefilter\"><in name=\"environment\" "
    "from=\"$environment\"/></node>\n"
    "  <output name=\"atlas\" from=\"atlas\" format=\"exr32\"/>\n"
    "</wetgraph>\n";
static const char sky_xml[] =
    "<wetgraph version=\"1\" size=\"512\">\n"
    "  <node id=\"sky\" type=\"pixel\" kind=\"color\" expr=\"rgb("
    "(v &lt; 0.5 ? 0.25 + 1.3 * v : 0.22) + 60 * (abs(u - 0.3) &lt; 0.012) * (abs(v - 0.3) &lt; "
    "0.012),"
    " (v &lt; 0.5 ? 0.45 + 0.9 * v : 0.2) + 58 * (abs(u - 0.3) &lt; 0.012) * (abs(v - 0.3) &lt; "
    "0.012),"
    " (v &lt; 0.5 ? 1.0 - 0.1 * v : 0.16) + 52 * (abs(u - 0.3) &lt; 0.012) * (abs(v - 0.3) &lt; "
    "0.012))\"/>\n"
    "  <node id=\"atlas\" type=\"env_prefilter\"><in name=\"environment\" from=\"sky\"/></node>\n"
    "  <output name=\"atlas\" from=\"atlas\" format=\"exr32\"/>\n"
    "</wetgraph>\n";

static int prefilter(WgEngine *e, const char *path, WgImage **atlas, WgError *err)
{
    const char *xml = path ? prefilter_xml : sky_xml;
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgResult *res = NULL;
    int rc = wg_graph_load_memory(xml, strlen(xml), "environment.wetgraph", &g, err);
    if (!rc && !(r = wg_request_new(g)))
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!rc && path) rc = wg_request_set_input_file(r, "environment", path, err);
    if (!rc) rc = wg_render(e, r, &res, err);
    if (!rc) *atlas = wg_image_ref(wg_result_output_image(res, 0));
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
    return rc;
}

void serve_prefilter(Serve *s, WgEngine *e)
{
    if (!s->n_envs) { /* no environment given: the built-in sky */
        s->envs[0].name = strdup("sky (built in)");
        if (!s->envs[0].name) return;
        s->n_envs = 1;
    }
    for (int i = 0; i < s->n_envs; i++) {
        Env *v = &s->envs[i];
        if (v->atlas || v->error) continue; /* made once per session */
        WgError err = {0};
        WgImage *atlas = NULL;
        char *why = NULL;
        if (prefilter(e, v->path, &atlas, &err)) {
            char buf[1024];
            wg_error_format(&err, buf, sizeof buf);
            why = strdup(buf);
            fprintf(stderr, "wetgraph: warning: the 3D view's environment %s: %s\n", v->name, buf);
        }
        pthread_mutex_lock(&s->lock);
        v->atlas = atlas;
        v->error = why ? why : atlas ? NULL : strdup("out of memory");
        pthread_mutex_unlock(&s->lock);
    }
}

/* Read the graph's image inputs given as files again where the file changed (the 3D view shows
 * them as the dry material); runs on the watch thread. An input that cannot be read keeps its
 * last image. */
static void read_inputs(Serve *s, const WgGraph *g)
{
    Output *ins = calloc((size_t)s->n_in_spec + 1, sizeof *ins);
    if (!ins) return;
    int n = 0;
    for (int i = 0; i < s->n_in_spec; i++) {
        const char *spec = s->in_spec[i], *eq = strchr(spec, '=');
        if (!eq) continue;
        const WgGraphInputInfo *in = NULL;
        for (int k = 0; k < wg_graph_input_count(g); k++) {
            const WgGraphInputInfo *x = wg_graph_input_info(g, k);
            if (strlen(x->name) == (size_t)(eq - spec) && !strncmp(x->name, spec, eq - spec))
                in = x;
        }
        if (!in || !strcmp(in->name, "environment")) continue;
        char name[MAX_NAME + 2];
        snprintf(name, sizeof name, "$%s", in->name);
        const Output *old = NULL;
        for (int k = 0; k < s->n_ins; k++)
            if (!strcmp(s->ins[k].name, name)) old = &s->ins[k];
        struct stat st;
        bool same = !stat(eq + 1, &st) && old && st.st_mtim.tv_sec == s->in_st[i].st_mtim.tv_sec &&
                    st.st_mtim.tv_nsec == s->in_st[i].st_mtim.tv_nsec &&
                    st.st_size == s->in_st[i].st_size && st.st_ino == s->in_st[i].st_ino;
        Output *o = &ins[n];
        if (!(o->name = strdup(name))) break;
        WgImage *img = NULL;
        WgError err = {0};
        if (!same &&
            !wg_image_read(eq + 1, in->kind == WG_GRAY ? 1 : 4, in->colorspace, &img, &err)) {
            o->img = img;
            o->channels = img->channels;
            o->version = s->version + 1;
            s->in_st[i] = st;
        } else if (old) {
            o->img = wg_image_ref(old->img);
            o->channels = old->channels;
            o->version = old->version;
        } else {
            free(o->name);
            continue;
        }
        n++;
    }
    pthread_mutex_lock(&s->lock);
    Output *gone = s->ins;
    int n_gone = s->n_ins;
    s->ins = ins;
    s->n_ins = n;
    pthread_mutex_unlock(&s->lock);
    outputs_free(gone, n_gone);
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
        read_inputs(s, g);
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
        char **ids = calloc((size_t)wg_graph_node_count(g) + 1, sizeof *ids);
        int n_ids = 0;
        for (int i = 0; ids && i < wg_graph_node_count(g); i++)
            if ((ids[n_ids] = strdup(wg_graph_node_info(g, i)->id))) n_ids++;
        if (ids) {
            pthread_mutex_lock(&s->lock);
            for (int i = 0; i < s->n_node_ids; i++) free(s->node_ids[i]);
            free(s->node_ids);
            s->node_ids = ids;
            s->n_node_ids = n_ids;
            pthread_mutex_unlock(&s->lock);
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

/* The maps the page can load: [{"name":..,"version":..,"channels":..},...] */
static void json_maps(FILE *f, const Output *maps, int n)
{
    fputc('[', f);
    for (int i = 0; i < n; i++) {
        fputs(i ? ",{\"name\":" : "{\"name\":", f);
        cli_json_string(f, maps[i].name);
        fprintf(f, ",\"version\":%llu,\"channels\":%d}", (unsigned long long)maps[i].version,
                maps[i].channels);
    }
    fputc(']', f);
}

static enum MHD_Result state(Serve *s, struct MHD_Connection *c)
{
    /* ?after=V: answer once render V+1 is published (at most PING_S later): a page that does not
     * keep /events open waits for the next render without polling */
    const char *after = MHD_lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "after");
    unsigned long long v = 0;
    if (after) { /* digits only: strtoull would take a sign and wrap "-1" round */
        errno = 0;
        v = strtoull(after, NULL, 10);
        if (!*after || strspn(after, "0123456789") != strlen(after) || errno == ERANGE)
            return respond_text(c, MHD_HTTP_BAD_REQUEST, "text/plain",
                                "after: a render number from 0 to 18446744073709551615\n");
        MHD_set_connection_option(c, MHD_CONNECTION_OPTION_TIMEOUT, (unsigned)LONG_S);
    }
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
    fputs(",\"outputs\":", f);
    json_maps(f, s->outs, s->n_outs);
    fputs(",\"inputs\":", f);
    json_maps(f, s->ins, s->n_ins);
    fputs(",\"view\":", f);
    if (s->view_node && s->view_node[0]) {
        /* asked: the node the page asked for; node: the one whose image (or error) is there */
        fputs("{\"asked\":", f);
        cli_json_string(f, s->view_node);
        fprintf(f,
                ",\"version\":%llu,\"channels\":%d,\"node\":", (unsigned long long)s->view.version,
                s->view.channels);
        cli_json_string(f, s->view.name ? s->view.name : "");
        fputs(",\"error\":", f);
        if (s->view_error)
            cli_json_string(f, s->view_error);
        else
            fputs("null", f);
        fputc('}', f);
    } else {
        fputs("null", f);
    }
    fputs(",\"environments\":[", f);
    for (int i = 0; i < s->n_envs; i++) {
        fputs(i ? ",{\"name\":" : "{\"name\":", f);
        cli_json_string(f, s->envs[i].name);
        fprintf(f, ",\"ready\":%s,\"error\":", s->envs[i].atlas ? "true" : "false");
        if (s->envs[i].error)
            cli_json_string(f, s->envs[i].error);
        else
            fputs("null", f);
        fputc('}', f);
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

char *serve_view_node(Serve *s)
{
    pthread_mutex_lock(&s->lock);
    char *id = s->view_node && s->view_node[0] ? strdup(s->view_node) : NULL;
    pthread_mutex_unlock(&s->lock);
    return id;
}

void serve_publish_view(Serve *s, const char *id, const WgImage *img, WgColorspace cs,
                        const WgError *err)
{
    Output o = {0};
    char *why = NULL;
    o.name = strdup(id);
    if (img) {
        o.img = wg_image_ref(img);
        o.channels = img->channels;
        int side = img->width > img->height ? img->width : img->height;
        o.png = calloc(1, sizeof *o.png);
        if (o.png && wg_png_preview(img, (side + PREVIEW_MAX - 1) / PREVIEW_MAX, cs, &o.png->bytes,
                                    &o.png->size)) {
            free(o.png);
            o.png = NULL;
        }
        if (o.png) o.png->refs = 1;
    }
    if (err) {
        char buf[2048];
        wg_error_format(err, buf, sizeof buf);
        why = strdup(buf);
    }
    pthread_mutex_lock(&s->lock);
    Output old = s->view;
    o.version = s->view.version + 1;
    s->view = o;
    free(s->view_error);
    s->view_error = why;
    s->version++; /* the page hears of it as of a render */
    pthread_cond_broadcast(&s->rendered);
    pthread_mutex_unlock(&s->lock);
    outputs_free_one(&old);
}

static enum MHD_Result view_png(Serve *s, struct MHD_Connection *c)
{
    pthread_mutex_lock(&s->lock);
    if (!s->view.png) {
        pthread_mutex_unlock(&s->lock);
        return not_found(c);
    }
    enum MHD_Result ok =
        respond(c, MHD_HTTP_OK, "image/png", s->view.png->bytes, s->view.png->size);
    pthread_mutex_unlock(&s->lock);
    return ok;
}

/* One name=value change of /api/set, decoded. */
typedef struct {
    char *name, *value;
} Change;

typedef struct {
    Change *c;
    int n, cap;
    char msg[256]; /* the first problem, or "" */
} Changes;

static void changes_free(Changes *x)
{
    for (int i = 0; i < x->n; i++) {
        free(x->c[i].name);
        free(x->c[i].value);
    }
    free(x->c);
}

/* Add a copy of name and value, of these lengths (a decoded NUL makes strlen shorter). */
static void changes_add(Changes *x, const char *name, size_t name_len, const char *value,
                        size_t value_len)
{
    if (x->msg[0]) return;
    if (x->n == MAX_CHANGES) {
        snprintf(x->msg, sizeof x->msg, "at most %d changes at once", MAX_CHANGES);
        return;
    }
    if (!name_len || name_len > MAX_NAME || value_len > MAX_VALUE) {
        snprintf(x->msg, sizeof x->msg,
                 "'%.64s': a name of 1 to %d characters and a value of at most %d are needed", name,
                 MAX_NAME, MAX_VALUE);
        return;
    }
    if (strlen(name) != name_len || strlen(value) != value_len) {
        snprintf(x->msg, sizeof x->msg, "'%.64s': a NUL character in the name or the value", name);
        return;
    }
    for (const char *p = value; *p; p++)
        if ((unsigned char)*p < 0x20) {
            snprintf(x->msg, sizeof x->msg, "'%.64s': the value has a control character", name);
            return;
        }
    if (x->n == x->cap) {
        int cap = x->cap ? 2 * x->cap : 8;
        Change *grown = realloc(x->c, sizeof *grown * (size_t)cap);
        if (!grown) {
            snprintf(x->msg, sizeof x->msg, "out of memory");
            return;
        }
        x->c = grown;
        x->cap = cap;
    }
    Change *c = &x->c[x->n];
    c->name = strndup(name, name_len);
    c->value = strndup(value, value_len);
    if (!c->name || !c->value) {
        free(c->name);
        free(c->value);
        snprintf(x->msg, sizeof x->msg, "out of memory");
        return;
    }
    x->n++;
}

static enum MHD_Result query_change(void *cls, enum MHD_ValueKind kind, const char *key,
                                    size_t key_size, const char *value, size_t value_size)
{
    (void)kind;
    Changes *x = cls;
    if (!value) {
        snprintf(x->msg, sizeof x->msg, "'%.64s': name=value is needed", key);
        return MHD_NO;
    }
    changes_add(x, key, key_size, value, value_size);
    return x->msg[0] ? MHD_NO : MHD_YES;
}

static int hex_digit(char c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* Decode one application/x-www-form-urlencoded field (len bytes) into out, which has room for
 * len + 1; its length, or -1 for a malformed %-escape. */
static long form_decode(const char *p, size_t len, char *out)
{
    size_t k = 0;
    for (size_t i = 0; i < len; i++) {
        if (p[i] == '%') {
            int hi = i + 2 < len ? hex_digit(p[i + 1]) : -1;
            int lo = hi >= 0 ? hex_digit(p[i + 2]) : -1;
            if (lo < 0) return -1;
            out[k++] = (char)(hi * 16 + lo);
            i += 2;
        } else {
            out[k++] = p[i] == '+' ? ' ' : p[i];
        }
    }
    out[k] = '\0';
    return (long)k;
}

/* The changes of a form body: name=value pairs joined by '&'. */
static void body_changes(Changes *x, const char *body, size_t size)
{
    for (size_t at = 0; at < size && !x->msg[0];) {
        const char *pair = body + at;
        const char *amp = memchr(pair, '&', size - at);
        size_t len = amp ? (size_t)(amp - pair) : size - at;
        at += len + 1;
        if (!len) continue;
        const char *eq = memchr(pair, '=', len);
        if (!eq) {
            snprintf(x->msg, sizeof x->msg, "'%.*s': name=value is needed in the body",
                     (int)(len > 64 ? 64 : len), pair);
            return;
        }
        size_t name_len = (size_t)(eq - pair), value_len = len - name_len - 1;
        /* an encoded field longer than this decodes to more than the limit */
        if (name_len > 3 * (MAX_NAME + 1) || value_len > 3 * (MAX_VALUE + 1)) {
            snprintf(x->msg, sizeof x->msg,
                     "a name of 1 to %d characters and a value of at most %d are needed", MAX_NAME,
                     MAX_VALUE);
            return;
        }
        char name[3 * (MAX_NAME + 1) + 1], value[3 * (MAX_VALUE + 1) + 1];
        long nl = form_decode(pair, name_len, name);
        long vl = form_decode(eq + 1, value_len, value);
        if (nl < 0 || vl < 0) {
            snprintf(x->msg, sizeof x->msg, "a malformed %%-escape in the body");
            return;
        }
        changes_add(x, name, (size_t)nl, value, (size_t)vl);
    }
}

static bool known_param(const Serve *s, const char *name)
{
    for (int i = 0; i < s->n_params; i++)
        if (!strcmp(s->param_names[i], name)) return true;
    return false;
}

/* Called with s->lock held: is change c one the graph takes? */
static bool change_ok(const Serve *s, const Change *c, char *msg, size_t size)
{
    if (!strcmp(c->name, "$time")) {
        double t;
        if (wg_parse_number(c->value, &t)) return true;
        snprintf(msg, size, "$time: '%.64s' is not a number", c->value);
        return false;
    }
    if (!strcmp(c->name, "$view")) {
        for (int i = 0; i < s->n_node_ids; i++)
            if (!strcmp(s->node_ids[i], c->value)) return true;
        if (!c->value[0]) return true; /* none */
        snprintf(msg, size, "$view: the graph has no node '%.64s'", c->value);
        return false;
    }
    if (known_param(s, c->name)) return true;
    snprintf(msg, size, "the graph has no parameter '%.64s'", c->name);
    return false;
}

/* Called with s->lock held: queue change c (checked by change_ok); false when out of memory. */
static bool queue_change(Serve *s, const Change *c)
{
    if (!strcmp(c->name, "$time")) {
        wg_parse_number(c->value, &s->q_time);
        s->q_has_time = true;
        return true;
    }
    if (!strcmp(c->name, "$view")) {
        char *v = strdup(c->value);
        if (!v) return false;
        free(s->view_node);
        s->view_node = v;
        return true;
    }
    for (int i = 0; i < s->n_q; i++)
        if (!strcmp(s->q_name[i], c->name)) {
            char *v = strdup(c->value);
            if (!v) return false;
            free(s->q_value[i]);
            s->q_value[i] = v;
            return true;
        }
    char **nn = realloc(s->q_name, sizeof *nn * (size_t)(s->n_q + 1));
    if (nn) s->q_name = nn;
    char **vv = realloc(s->q_value, sizeof *vv * (size_t)(s->n_q + 1));
    if (vv) s->q_value = vv;
    char *k = strdup(c->name), *v = strdup(c->value);
    if (!nn || !vv || !k || !v) {
        free(k);
        free(v);
        return false;
    }
    s->q_name[s->n_q] = k;
    s->q_value[s->n_q++] = v;
    return true;
}

static enum MHD_Result set_error(struct MHD_Connection *c, unsigned status, const char *msg)
{
    Mem m;
    FILE *f = mem_open(&m);
    if (!f) return MHD_NO;
    fputs("{\"ok\":false,\"error\":", f);
    cli_json_string(f, msg);
    fputs("}\n", f);
    char *text = mem_take(&m);
    if (!text) return MHD_NO;
    enum MHD_Result ok = respond_text(c, status, "application/json", text);
    free(text);
    return ok;
}

/* Is the media type of a Content-Type value type (parameters such as charset aside)? */
static bool media_type_is(const char *value, const char *type)
{
    while (*value == ' ' || *value == '\t') value++;
    size_t len = strlen(type);
    if (strncasecmp(value, type, len)) return false;
    value += len;
    while (*value == ' ' || *value == '\t') value++;
    return !*value || *value == ';';
}

/* POST /api/set: the changes in the query string and in a form body, all checked before any
 * is queued (a request with one bad change changes nothing). */
static enum MHD_Result set(Serve *s, struct MHD_Connection *c, const Req *q)
{
    if (q->body_too_big) {
        char msg[96];
        snprintf(msg, sizeof msg, "the body is larger than %d bytes", MAX_BODY);
        return set_error(c, MHD_HTTP_CONTENT_TOO_LARGE, msg);
    }
    Changes x = {0};
    MHD_get_connection_values_n(c, MHD_GET_ARGUMENT_KIND, query_change, &x);
    if (q->body_size) {
        const char *type = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Content-Type");
        if (!type || !media_type_is(type, "application/x-www-form-urlencoded")) {
            changes_free(&x);
            return set_error(c, MHD_HTTP_UNSUPPORTED_MEDIA_TYPE,
                             "the body must be application/x-www-form-urlencoded "
                             "(name=value&name=value)");
        }
        body_changes(&x, q->body, q->body_size);
    }
    if (!x.msg[0] && !x.n)
        snprintf(x.msg, sizeof x.msg,
                 "nothing to set: send name=value pairs in the query string or in an "
                 "application/x-www-form-urlencoded body");
    int queued = 0;
    bool nomem = false;
    pthread_mutex_lock(&s->lock);
    for (int i = 0; !x.msg[0] && i < x.n; i++) change_ok(s, &x.c[i], x.msg, sizeof x.msg);
    for (int i = 0; !x.msg[0] && i < x.n; i++) {
        if (!queue_change(s, &x.c[i])) {
            nomem = true;
            break;
        }
        queued++;
    }
    if (queued) { /* under the lock: serve_sets reads the queue and the wake-ups together */
        uint64_t one = 1;
        if (write(s->efd, &one, sizeof one) < 0) {
        } /* a full counter still wakes the loop */
    }
    pthread_mutex_unlock(&s->lock);
    if (nomem) snprintf(x.msg, sizeof x.msg, "out of memory");
    changes_free(&x);
    if (x.msg[0])
        return set_error(c, nomem ? MHD_HTTP_INTERNAL_SERVER_ERROR : MHD_HTTP_BAD_REQUEST, x.msg);
    char body[64];
    snprintf(body, sizeof body, "{\"ok\":true,\"queued\":%d}\n", queued);
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
    MHD_set_connection_option(c, MHD_CONNECTION_OPTION_TIMEOUT, (unsigned)LONG_S);
    MHD_add_response_header(r, "Content-Type", "text/event-stream");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    enum MHD_Result ok = MHD_queue_response(c, MHD_HTTP_OK, r);
    MHD_destroy_response(r);
    return ok;
}

/* libmicrohttpd's URI log callback: a request's own state, made before its headers are read,
 * from its target as it was sent (%-escapes not yet decoded). */
static void *req_new(void *cls, const char *uri, struct MHD_Connection *c)
{
    (void)cls;
    (void)c;
    Req *q = calloc(1, sizeof *q);
    if (q) q->nul = strstr(uri, "%00") != NULL;
    return q;
}

static void req_done(void *cls, struct MHD_Connection *c, void **con_cls,
                     enum MHD_RequestTerminationCode toe)
{
    (void)cls;
    (void)c;
    (void)toe;
    Req *q = *con_cls;
    if (q) free(q->body);
    free(q);
    *con_cls = NULL;
}

static bool is_loopback(const struct sockaddr_storage *ss)
{
    if (ss->ss_family == AF_INET)
        return (ntohl(((const struct sockaddr_in *)ss)->sin_addr.s_addr) >> 24) == 127;
    const struct in6_addr *a = &((const struct sockaddr_in6 *)ss)->sin6_addr;
    return IN6_IS_ADDR_LOOPBACK(a) ||
           (IN6_IS_ADDR_V4MAPPED(a) && a->s6_addr[12] == 127); /* ::ffff:127.x.y.z */
}

static bool is_wildcard(const struct sockaddr_storage *ss)
{
    if (ss->ss_family == AF_INET)
        return ((const struct sockaddr_in *)ss)->sin_addr.s_addr == htonl(INADDR_ANY);
    return IN6_IS_ADDR_UNSPECIFIED(&((const struct sockaddr_in6 *)ss)->sin6_addr);
}

/* Is host (a Host header: NAME[:PORT]) this server? localhost, a loopback address, the bound
 * address, or, bound to every address, any address literal, each with the bound port (80 when
 * it has none). Any other name is refused: a name an attacker controls could be made to point
 * here (DNS rebinding), while an address literal cannot. */
static bool host_ok(const Serve *s, const char *host)
{
    char name[64];
    const char *port = NULL;
    if (host[0] == '[') {
        const char *close = strchr(host, ']');
        if (!close || (size_t)(close - host - 1) >= sizeof name) return false;
        snprintf(name, sizeof name, "%.*s", (int)(close - host - 1), host + 1);
        if (close[1] && close[1] != ':') return false;
        port = close[1] ? close + 2 : NULL;
    } else {
        const char *colon = strchr(host, ':');
        size_t len = colon ? (size_t)(colon - host) : strlen(host);
        if (len >= sizeof name) return false;
        snprintf(name, sizeof name, "%.*s", (int)len, host);
        port = colon ? colon + 1 : NULL;
    }
    if (port) {
        if (!*port || strlen(port) > 5 || strspn(port, "0123456789") != strlen(port) ||
            atoi(port) != s->port)
            return false;
    } else if (s->port != 80) {
        return false;
    }
    if (!strcasecmp(name, "localhost")) return true;
    struct sockaddr_storage a = {0};
    if (inet_pton(AF_INET, name, &((struct sockaddr_in *)&a)->sin_addr) == 1 && host[0] != '[')
        a.ss_family = AF_INET;
    else if (host[0] == '[' && inet_pton(AF_INET6, name, &((struct sockaddr_in6 *)&a)->sin6_addr))
        a.ss_family = AF_INET6;
    else
        return false;
    if (is_loopback(&a) || s->wildcard) return true;
    if (a.ss_family != s->addr.ss_family) return false;
    if (a.ss_family == AF_INET)
        return ((struct sockaddr_in *)&a)->sin_addr.s_addr ==
               ((const struct sockaddr_in *)&s->addr)->sin_addr.s_addr;
    return !memcmp(&((struct sockaddr_in6 *)&a)->sin6_addr,
                   &((const struct sockaddr_in6 *)&s->addr)->sin6_addr, sizeof(struct in6_addr));
}

/* Compare the token in constant time (its length is public). */
static bool token_ok(const Serve *s, const char *token)
{
    if (!token || strlen(token) != sizeof s->token - 1) return false;
    unsigned char diff = 0;
    for (size_t i = 0; i < sizeof s->token - 1; i++)
        diff |= (unsigned char)(token[i] ^ s->token[i]);
    return diff == 0;
}

/* Was the request made by another site's page (Sec-Fetch-Site, sent by current browsers)? */
static bool from_elsewhere(struct MHD_Connection *c)
{
    const char *site = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Sec-Fetch-Site");
    return site && strcasecmp(site, "same-origin") && strcasecmp(site, "none");
}

/* The page, with the run's token; address_settings: whether it applies ?set= and ?play= of
 * its address (not when another site sent the browser to it). */
static enum MHD_Result page(Serve *s, struct MHD_Connection *c, bool address_settings)
{
    return respond_text(c, MHD_HTTP_OK, "text/html; charset=utf-8",
                        s->page[address_settings ? 1 : 0]);
}

static enum MHD_Result refuse(struct MHD_Connection *c, unsigned status, const char *text)
{
    return respond_text(c, status, "text/plain", text);
}

static enum MHD_Result handle(void *cls, struct MHD_Connection *c, const char *url,
                              const char *method, const char *version, const char *upload,
                              size_t *upload_size, void **con_cls)
{
    (void)version;
    Serve *s = cls;
    Req *q = *con_cls;
    if (!q) return MHD_NO; /* out of memory */
    if (!q->started) {     /* first call: headers only */
        q->started = true;
        return MHD_YES;
    }
    if (*upload_size) { /* the body, kept up to MAX_BODY bytes (only /api/set reads it) */
        if (!q->body_too_big && q->body_size + *upload_size <= MAX_BODY) {
            if (!q->body && !(q->body = malloc(MAX_BODY))) return MHD_NO;
            memcpy(q->body + q->body_size, upload, *upload_size);
            q->body_size += *upload_size;
        } else {
            q->body_too_big = true;
        }
        *upload_size = 0;
        return MHD_YES;
    }
    const char *host = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Host");
    if (!host || !host_ok(s, host))
        return refuse(c, MHD_HTTP_MISDIRECTED_REQUEST,
                      "the Host header does not name this server (localhost or the address "
                      "it listens on, with its port)\n");
    if (q->nul) return refuse(c, MHD_HTTP_BAD_REQUEST, "the address has a NUL character (%00)\n");
    const char *mode = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Sec-Fetch-Mode");
    bool navigate = mode && !strcasecmp(mode, "navigate");
    bool elsewhere = from_elsewhere(c);
    if (elsewhere && !navigate)
        return refuse(c, MHD_HTTP_FORBIDDEN, "requests from another site's page are refused\n");
    bool get = !strcmp(method, "GET") || !strcmp(method, "HEAD");
    bool post = !strcmp(method, "POST");
    if (!strcmp(url, "/api/set")) {
        if (!post) {
            struct MHD_Response *r = MHD_create_response_from_buffer(
                strlen("/api/set takes POST\n"), "/api/set takes POST\n", MHD_RESPMEM_PERSISTENT);
            if (!r) return MHD_NO;
            MHD_add_response_header(r, "Allow", "POST");
            MHD_add_response_header(r, "Content-Type", "text/plain");
            enum MHD_Result ok = MHD_queue_response(c, MHD_HTTP_METHOD_NOT_ALLOWED, r);
            MHD_destroy_response(r);
            return ok;
        }
        /* a change comes from this server's own page: same origin, with the run's token */
        const char *origin = MHD_lookup_connection_value(c, MHD_HEADER_KIND, "Origin");
        if (elsewhere || (origin && (strncmp(origin, "http://", 7) || strcmp(origin + 7, host))))
            return set_error(c, MHD_HTTP_FORBIDDEN, "changes from another site are refused");
        if (!token_ok(s, MHD_lookup_connection_value(c, MHD_HEADER_KIND, TOKEN_HEADER)))
            return set_error(c, MHD_HTTP_FORBIDDEN,
                             "a missing or wrong " TOKEN_HEADER
                             " header: changes come from the page this server serves");
        return set(s, c, q);
    }
    if (!get) return refuse(c, MHD_HTTP_METHOD_NOT_ALLOWED, "method not allowed\n");
    if (!strcmp(url, "/") || !strcmp(url, "/index.html")) return page(s, c, !elsewhere);
    if (!strcmp(url, "/api/state")) return state(s, c);
    if (!strcmp(url, "/events")) return events(s, c);
    if (!strcmp(url, "/graph.svg")) return graph_svg(s, c);
    for (const WgWebFile *w = wg_web_files; w->address; w++)
        if (strcmp(w->address, "/index.html") && !strcmp(url, w->address))
            return respond(c, MHD_HTTP_OK, w->type, w->bytes, w->size);
    if (!strcmp(url, "/view.png")) return view_png(s, c);
    if (!strncmp(url, "/map/", 5) && url[5]) return pixels(s, c, url + 5, -1);
    if (!strncmp(url, "/env/", 5) && url[5] && strlen(url + 5) <= 4 &&
        strspn(url + 5, "0123456789") == strlen(url + 5))
        return pixels(s, c, NULL, atoi(url + 5));
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
    free(s->page[0]);
    free(s->page[1]);
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
    outputs_free(s->ins, s->n_ins);
    outputs_free_one(&s->view);
    free(s->view_node);
    free(s->view_error);
    for (int i = 0; i < s->n_node_ids; i++) free(s->node_ids[i]);
    free(s->node_ids);
    for (int i = 0; s->in_spec && i < s->n_in_spec; i++) free(s->in_spec[i]);
    free(s->in_spec);
    free(s->in_st);
    for (int i = 0; s->envs && i < s->n_envs; i++) {
        free(s->envs[i].name);
        free(s->envs[i].path);
        free(s->envs[i].error);
        wg_image_unref(s->envs[i].atlas);
    }
    free(s->envs);
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

/* The page with its placeholders filled: @TOKEN@ (the run's token) and @SETTINGS@ ("1" when it
 * applies its address's settings); the caller owns the text. */
static char *make_page(const char *token, bool address_settings)
{
    Mem m;
    FILE *f = mem_open(&m);
    if (!f) return NULL;
    const char *html = NULL;
    for (const WgWebFile *w = wg_web_files; w->address; w++)
        if (!strcmp(w->address, "/index.html")) html = (const char *)w->bytes;
    if (!html) return NULL;
    for (const char *p = html; *p;) {
        if (!strncmp(p, "@TOKEN@", 7)) {
            fputs(token, f);
            p += 7;
        } else if (!strncmp(p, "@SETTINGS@", 10)) {
            fputs(address_settings ? "1" : "0", f);
            p += 10;
        } else {
            fputc(*p++, f);
        }
    }
    return mem_take(&m);
}

/* A random token of 2 * (sizeof s->token / 2) hex digits from the kernel's generator. */
static bool make_token(Serve *s)
{
    unsigned char raw[sizeof s->token / 2];
    size_t got = 0;
    while (got < sizeof raw) {
        ssize_t n = getrandom(raw + got, sizeof raw - got, 0);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        got += (size_t)n;
    }
    for (size_t i = 0; i < sizeof raw; i++) snprintf(s->token + 2 * i, 3, "%02x", raw[i]);
    return true;
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
    s->addr = ss;
    s->port =
        ntohs(v6 ? ((struct sockaddr_in6 *)&ss)->sin6_port : ((struct sockaddr_in *)&ss)->sin_port);
    s->wildcard = is_wildcard(&ss);
    s->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    s->file = strdup(graph_file);
    if (!make_token(s)) {
        int e = errno;
        serve_free(s);
        return wg_error_set(err, WG_ERR_IO, NULL, "--serve: cannot make a random token: %s",
                            strerror(e));
    }
    s->page[0] = make_page(s->token, false);
    s->page[1] = make_page(s->token, true);
    if (s->efd < 0 || !s->file || !s->page[0] || !s->page[1]) {
        serve_free(s);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "--serve: cannot create the server");
    }
    /* no MHD_USE_ERROR_LOG: its messages would duplicate the error below (and call the port
     * given with MHD_OPTION_SOCK_ADDR 0); poll, not select: CONNECTIONS may pass FD_SETSIZE */
    unsigned flags = MHD_USE_POLL_INTERNAL_THREAD | MHD_USE_THREAD_PER_CONNECTION;
    if (v6) /* [::] also takes IPv4 connections (dual stack) */
        flags |= IN6_IS_ADDR_UNSPECIFIED(&((struct sockaddr_in6 *)&ss)->sin6_addr)
                     ? MHD_USE_DUAL_STACK
                     : MHD_USE_IPv6;
    s->d = MHD_start_daemon(flags, 0, NULL, NULL, handle, s, MHD_OPTION_SOCK_ADDR,
                            (struct sockaddr *)&ss, MHD_OPTION_CONNECTION_LIMIT,
                            (unsigned)CONNECTIONS, MHD_OPTION_PER_IP_CONNECTION_LIMIT,
                            (unsigned)PER_ADDRESS, MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)IDLE_S,
                            MHD_OPTION_URI_LOG_CALLBACK, req_new, NULL, MHD_OPTION_NOTIFY_COMPLETED,
                            req_done, NULL, MHD_OPTION_END);
    if (!s->d) {
        int e = errno;
        serve_free(s);
        return wg_error_set(err, WG_ERR_IO, NULL, "--serve %s: cannot listen: %s", spec,
                            strerror(e));
    }
    if (!is_loopback(&ss))
        fprintf(stderr,
                "wetgraph: warning: --serve %s: the page has no authentication: anyone who can "
                "reach this address can see the outputs and change the parameters\n",
                spec);
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
