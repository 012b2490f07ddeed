/* SPDX-License-Identifier: MIT */
/* The node test kit (wetgraph/testkit.h): a node rendered through a small graph written for it,
 * and the checks every built-in node is held to. Hard inputs run in child processes (fork), so
 * that a crash or a hang is a failed case. */
#include <wetgraph/testkit.h>
#include <wetgraph/wetgraph.h>

#include <errno.h>
#include <math.h>
#include <poll.h>
#include <stdarg.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* ---- images -------------------------------------------------------------------------------- */

WgImage *wg_testkit_image_fill(int width, int height, int channels, float value)
{
    WgImage *img = wg_image_new(width, height, channels);
    for (int y = 0; img && y < height; y++) {
        float *row = wg_image_row(img, y);
        for (int i = 0; i < width * channels; i++)
            row[i] = channels == 4 && i % 4 == 3 ? 1.0f : value;
    }
    return img;
}

static uint32_t mix32(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

WgImage *wg_testkit_image_noise(int width, int height, int channels, uint32_t seed)
{
    WgImage *img = wg_image_new(width, height, channels);
    for (int y = 0; img && y < height; y++) {
        float *row = wg_image_row(img, y);
        for (int x = 0; x < width; x++)
            for (int c = 0; c < channels; c++) {
                uint32_t h = mix32((uint32_t)x ^ mix32((uint32_t)y ^ mix32((uint32_t)c ^ mix32(seed))));
                row[x * channels + c] = channels == 4 && c == 3 ? 1.0f : (float)(h >> 8) / 16777216.0f;
            }
    }
    return img;
}

WgImage *wg_testkit_image_fn(int width, int height, int channels, WgTestkitPixelFn fn, void *user)
{
    WgImage *img = wg_image_new(width, height, channels);
    for (int y = 0; img && y < height; y++) {
        float *row = wg_image_row(img, y);
        for (int x = 0; x < width; x++)
            for (int c = 0; c < channels; c++) row[x * channels + c] = (float)fn(user, x, y, c);
    }
    return img;
}

WgImage *wg_testkit_image_roll(const WgImage *src, int dx, int dy)
{
    int w = src->width, h = src->height, ch = src->channels;
    WgImage *img = wg_image_new(w, h, ch);
    for (int y = 0; img && y < h; y++) {
        const float *s = wg_image_row(src, (((y - dy) % h) + h) % h);
        float *d = wg_image_row(img, y);
        for (int x = 0; x < w; x++) {
            int sx = (((x - dx) % w) + w) % w;
            memcpy(d + (size_t)x * ch, s + (size_t)sx * ch, sizeof(float) * (size_t)ch);
        }
    }
    return img;
}

/* ---- running a node ------------------------------------------------------------------------ */

typedef struct {
    int threads;
    bool no_fuse;
    int band_rows;
    bool between_points; /* fed by and feeding identity point operations, so it can fuse */
    int out_channels;    /* the checked output's channels (between_points needs them) */
} RunHow;

static void put(char **buf, size_t *len, size_t *cap, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static void put(char **buf, size_t *len, size_t *cap, const char *fmt, ...)
{
    va_list ap;
    for (;;) {
        va_start(ap, fmt);
        int n = *buf ? vsnprintf(*buf + *len, *cap - *len, fmt, ap) : -1;
        va_end(ap);
        if (n >= 0 && *len + (size_t)n < *cap) {
            *len += (size_t)n;
            return;
        }
        size_t grown = *cap ? 2 * *cap + (size_t)(n > 0 ? n : 0) : 4096;
        char *more = realloc(*buf, grown);
        if (!more) return; /* the graph text ends short and fails to parse: reported there */
        *buf = more;
        *cap = grown;
    }
}

/* The value of an attribute, escaped for XML. */
static void put_escaped(char **buf, size_t *len, size_t *cap, const char *s)
{
    for (; *s; s++) {
        switch (*s) {
        case '&': put(buf, len, cap, "&amp;"); break;
        case '<': put(buf, len, cap, "&lt;"); break;
        case '>': put(buf, len, cap, "&gt;"); break;
        case '"': put(buf, len, cap, "&quot;"); break;
        default: put(buf, len, cap, "%c", *s);
        }
    }
}

static int count_inputs(const WgTestkitNode *n)
{
    int k = 0;
    while (n->input_names && n->input_names[k]) k++;
    return k;
}

static void node_size(const WgTestkitNode *n, int *w, int *h)
{
    *w = n->width;
    *h = n->height;
    if (*w > 0 && *h > 0) return;
    if (count_inputs(n) > 0 && n->inputs[0]) {
        *w = n->inputs[0]->width;
        *h = n->inputs[0]->height;
    } else {
        *w = *h = 64;
    }
}

/* The graph: one <input> per fed port, optionally through an identity point node, the node,
 * and its checked output (optionally through another identity point node). */
static char *graph_text(const WgTestkitNode *n, const RunHow *how, int w, int h)
{
    char *buf = NULL;
    size_t len = 0, cap = 0;
    int n_in = count_inputs(n);
    put(&buf, &len, &cap, "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"%llu\">\n", w, h,
        (unsigned long long)n->seed);
    for (int i = 0; i < n_in; i++) {
        const char *kind = n->inputs[i] && n->inputs[i]->channels == 4 ? "color" : "gray";
        put(&buf, &len, &cap, "<input name=\"in%d\" type=\"%s\"/>\n", i, kind);
        if (how->between_points)
            put(&buf, &len, &cap,
                "<node id=\"pre%d\" type=\"pixel\" kind=\"%s\" expr=\"a\" allow_nonfinite=\"true\">"
                "<in name=\"a\" from=\"$in%d\"/></node>\n",
                i, kind, i);
    }
    put(&buf, &len, &cap, "<node id=\"node\" type=\"");
    put_escaped(&buf, &len, &cap, n->type ? n->type : "");
    put(&buf, &len, &cap, "\"");
    for (int k = 0; n->params && n->params[k]; k++) {
        const char *eq = strchr(n->params[k], '=');
        if (!eq) {
            put(&buf, &len, &cap, " %s", n->params[k]); /* a parse error naming it */
            continue;
        }
        put(&buf, &len, &cap, " %.*s=\"", (int)(eq - n->params[k]), n->params[k]);
        put_escaped(&buf, &len, &cap, eq + 1);
        put(&buf, &len, &cap, "\"");
    }
    put(&buf, &len, &cap, ">");
    for (int i = 0; i < n_in; i++) {
        put(&buf, &len, &cap, "<in name=\"");
        put_escaped(&buf, &len, &cap, n->input_names[i]);
        put(&buf, &len, &cap, how->between_points ? "\" from=\"pre%d\"/>" : "\" from=\"$in%d\"/>", i);
    }
    put(&buf, &len, &cap, "</node>\n");
    char from[256];
    snprintf(from, sizeof from, "node%s%s", n->output ? "." : "", n->output ? n->output : "");
    if (how->between_points) {
        put(&buf, &len, &cap,
            "<node id=\"post\" type=\"pixel\" kind=\"%s\" expr=\"a\" "
            "allow_nonfinite=\"true\"><in name=\"a\" from=\"%s\"/></node>\n",
            how->out_channels == 4 ? "color" : "gray", from);
        snprintf(from, sizeof from, "post");
    }
    put(&buf, &len, &cap, "<output name=\"out\" from=\"%s\" format=\"exr32\"/>\n</wetgraph>\n", from);
    return buf;
}

static int run_how(const WgTestkitNode *n, const RunHow *how, int w, int h, WgImage **out,
                   WgError *err)
{
    *out = NULL;
    char *text = graph_text(n, how, w, h);
    if (!text) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgEngine *e = NULL;
    WgResult *res = NULL;
    int rc = wg_graph_load_memory(text, strlen(text), "testkit.wetgraph", &g, err);
    free(text);
    if (!rc && !(r = wg_request_new(g))) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    char name[32];
    for (int i = 0; !rc && i < count_inputs(n); i++) {
        snprintf(name, sizeof name, "in%d", i);
        rc = wg_request_set_input_image(r, name, n->inputs[i], err);
    }
    WgEngineOptions opt = {0};
    opt.threads = how->threads;
    opt.no_fuse = how->no_fuse;
    opt.band_rows = how->band_rows;
    opt.no_memory_cache = true;
    if (!rc) rc = wg_engine_new(&opt, &e, err);
    if (!rc) rc = wg_render(e, r, &res, err);
    if (!rc) *out = wg_image_ref(wg_result_output_image(res, 0));
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
    return rc;
}

int wg_testkit_run(const WgTestkitNode *n, int threads, WgImage **out, WgError *err)
{
    int w, h;
    node_size(n, &w, &h);
    RunHow how = {.threads = threads};
    return run_how(n, &how, w, h, out, err);
}

int wg_testkit_run_graph(const char *xml, const char *path, const char *const *params,
                         const char *const *input_names, const WgImage *const *inputs,
                         const char *output, int threads, WgImage **out, WgError *err)
{
    *out = NULL;
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgEngine *e = NULL;
    WgResult *res = NULL;
    int rc = wg_graph_load_memory(xml, strlen(xml), path ? path : "testkit.wetgraph", &g, err);
    if (!rc && !(r = wg_request_new(g))) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int k = 0; !rc && params && params[k]; k++) {
        const char *eq = strchr(params[k], '=');
        char name[256];
        if (!eq || (size_t)(eq - params[k]) >= sizeof name) {
            rc = wg_error_set(err, WG_ERR_USAGE, NULL, "parameter '%s' is not name=value",
                              params[k]);
            break;
        }
        snprintf(name, sizeof name, "%.*s", (int)(eq - params[k]), params[k]);
        rc = wg_request_set(r, name, eq + 1, err);
    }
    for (int i = 0; !rc && input_names && input_names[i]; i++)
        rc = wg_request_set_input_image(r, input_names[i], inputs[i], err);
    if (!rc && output) rc = wg_request_add_output(r, output, err);
    WgEngineOptions opt = {0};
    opt.threads = threads;
    opt.no_memory_cache = true;
    if (!rc) rc = wg_engine_new(&opt, &e, err);
    if (!rc) rc = wg_render(e, r, &res, err);
    if (!rc && wg_result_output_count(res) < 1)
        rc = wg_error_set(err, WG_ERR_USAGE, NULL, "the graph has no output");
    if (!rc) *out = wg_image_ref(wg_result_output_image(res, 0));
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
    return rc;
}

/* ---- comparing ----------------------------------------------------------------------------- */

static bool same_value(double got, double want, double tol, double *diff)
{
    if (isnan(want) || isnan(got)) {
        *diff = isnan(want) && isnan(got) ? 0 : NAN;
        return isnan(want) && isnan(got);
    }
    if (isinf(want) || isinf(got)) {
        *diff = got == want ? 0 : INFINITY;
        return got == want;
    }
    *diff = fabs(got - want);
    return *diff <= tol;
}

typedef double (*ValueAt)(const void *a, const void *b, int x, int y, int c);

static bool compare_with(const WgImage *got, double (*want)(const void *, int, int, int),
                         const void *user, double tol, WgTestkitReport *rep)
{
    memset(rep, 0, sizeof *rep);
    rep->ok = true;
    bool first_bad = true;
    for (int y = 0; y < got->height; y++) {
        const float *row = wg_image_row(got, y);
        for (int x = 0; x < got->width; x++)
            for (int c = 0; c < got->channels; c++) {
                double g = row[x * got->channels + c], w = want(user, x, y, c), d;
                bool same = same_value(g, w, tol, &d);
                /* the first NaN mismatch, else the largest difference */
                if (!same && (first_bad || (!isnan(rep->worst) && (isnan(d) || d > rep->worst)))) {
                    first_bad = false;
                    rep->ok = false;
                    rep->worst = d;
                    rep->x = x, rep->y = y, rep->c = c, rep->got = g, rep->want = w;
                } else if (same && rep->ok && d > rep->worst) {
                    rep->worst = d;
                    rep->x = x, rep->y = y, rep->c = c, rep->got = g, rep->want = w;
                }
            }
    }
    if (rep->ok)
        snprintf(rep->message, sizeof rep->message,
                 "%dx%dx%d within %g (largest difference %.3g at (%d, %d) channel %d)",
                 got->width, got->height, got->channels, tol, rep->worst, rep->x, rep->y, rep->c);
    else
        snprintf(rep->message, sizeof rep->message,
                 "at (%d, %d) channel %d: got %.9g, want %.9g (difference %.3g, tolerance %g)",
                 rep->x, rep->y, rep->c, rep->got, rep->want, rep->worst, tol);
    return rep->ok;
}

typedef struct {
    WgTestkitRefFn fn;
    void *user;
} RefCall;

static double want_ref(const void *user, int x, int y, int c)
{
    const RefCall *r = user;
    return r->fn(r->user, x, y, c);
}

bool wg_testkit_compare_fn(const WgImage *got, WgTestkitRefFn ref, void *user, double tol,
                           WgTestkitReport *rep)
{
    RefCall call = {ref, user};
    return compare_with(got, want_ref, &call, tol, rep);
}

static double want_image(const void *user, int x, int y, int c)
{
    const WgImage *img = user;
    return wg_image_row(img, y)[x * img->channels + c];
}

bool wg_testkit_compare(const WgImage *got, const WgImage *want, double tol, WgTestkitReport *rep)
{
    if (!got || !want || got->width != want->width || got->height != want->height ||
        got->channels != want->channels) {
        memset(rep, 0, sizeof *rep);
        snprintf(rep->message, sizeof rep->message, "the images differ in size or channels "
                 "(%dx%dx%d against %dx%dx%d)", got ? got->width : 0, got ? got->height : 0,
                 got ? got->channels : 0, want ? want->width : 0, want ? want->height : 0,
                 want ? want->channels : 0);
        return false;
    }
    return compare_with(got, want_image, want, tol, rep);
}

static bool failed(WgTestkitReport *rep, const char *what, const WgError *err)
{
    memset(rep, 0, sizeof *rep);
    char text[1024];
    wg_error_format(err, text, sizeof text);
    snprintf(rep->message, sizeof rep->message, "%s: %s", what, text);
    return false;
}

/* ---- tiling -------------------------------------------------------------------------------- */

bool wg_testkit_check_tiling(const WgTestkitNode *n, int dx, int dy, double tol,
                             WgTestkitReport *rep)
{
    int n_in = count_inputs(n), w, h;
    node_size(n, &w, &h);
    if (n_in == 0) {
        memset(rep, 0, sizeof *rep);
        snprintf(rep->message, sizeof rep->message,
                 "a source has no input to roll: check its output with wg_testkit_check_seamless");
        return false;
    }
    for (int i = 0; i < n_in; i++)
        if (n->inputs[i]->width != w || n->inputs[i]->height != h) {
            memset(rep, 0, sizeof *rep);
            snprintf(rep->message, sizeof rep->message,
                     "input '%s' is %dx%d, not the node's %dx%d: a rolled input must not be "
                     "resampled", n->input_names[i], n->inputs[i]->width, n->inputs[i]->height, w, h);
            return false;
        }
    WgError err = {0};
    WgImage *plain = NULL, *rolled_out = NULL;
    if (wg_testkit_run(n, 0, &plain, &err)) return failed(rep, "the node failed", &err);
    const WgImage **rolled = calloc((size_t)n_in, sizeof *rolled);
    bool ok = rolled != NULL;
    for (int i = 0; ok && i < n_in; i++) ok = (rolled[i] = wg_testkit_image_roll(n->inputs[i], dx, dy));
    WgTestkitNode m = *n;
    m.inputs = rolled;
    int rc = ok ? wg_testkit_run(&m, 0, &rolled_out, &err) : WG_ERR_NOMEM;
    for (int i = 0; rolled && i < n_in; i++) wg_image_unref(rolled[i]);
    free(rolled);
    if (rc) {
        wg_image_unref(plain);
        return failed(rep, "the node failed on the rolled inputs", &err);
    }
    WgImage *want = wg_testkit_image_roll(plain, dx, dy);
    ok = wg_testkit_compare(rolled_out, want, tol, rep);
    char detail[1024];
    snprintf(detail, sizeof detail, "%s by (%d, %d): %s", ok ? "tiles: rolled" : "does not tile: rolled",
             dx, dy, rep->message);
    snprintf(rep->message, sizeof rep->message, "%s", detail);
    wg_image_unref(want);
    wg_image_unref(plain);
    wg_image_unref(rolled_out);
    return ok;
}

bool wg_testkit_check_seamless(const WgImage *img, double factor, WgTestkitReport *rep)
{
    memset(rep, 0, sizeof *rep);
    int w = img->width, h = img->height, ch = img->channels;
    double inside = 0, across = 0;
    for (int y = 0; y < h; y++) {
        const float *row = wg_image_row(img, y), *next = wg_image_row(img, (y + 1) % h);
        for (int x = 0; x < w; x++)
            for (int c = 0; c < ch; c++) {
                double v = row[x * ch + c];
                double right = fabs(row[((x + 1) % w) * ch + c] - v);
                double down = fabs(next[x * ch + c] - v);
                if (x + 1 < w) inside = fmax(inside, right);
                else if (right > across) across = right, rep->x = x, rep->y = y, rep->c = c;
                if (y + 1 < h) inside = fmax(inside, down);
                else if (down > across) across = down, rep->x = x, rep->y = y, rep->c = c;
            }
    }
    rep->worst = across;
    rep->ok = across <= factor * inside;
    snprintf(rep->message, sizeof rep->message,
             "%s: largest change across an edge %.3g (at (%d, %d) channel %d), inside %.3g, "
             "allowed %g times that",
             rep->ok ? "seamless" : "not seamless", across, rep->x, rep->y, rep->c, inside, factor);
    return rep->ok;
}

/* ---- invariance ---------------------------------------------------------------------------- */

/* a and b hold the same bits; else the report names the first sample that differs (also
 * where the values compare equal: 0 and -0, NaNs of other payloads) */
static bool same_bits(const WgImage *a, const WgImage *b, WgTestkitReport *rep)
{
    if (a->width != b->width || a->height != b->height || a->channels != b->channels)
        return wg_testkit_compare(a, b, 0, rep);
    memset(rep, 0, sizeof *rep);
    rep->ok = true;
    int n = a->width * a->channels;
    for (int y = 0; y < a->height && rep->ok; y++) {
        const float *ra = wg_image_row(a, y), *rb = wg_image_row(b, y);
        for (int i = 0; i < n; i++) {
            if (!memcmp(&ra[i], &rb[i], sizeof(float))) continue;
            rep->ok = false;
            rep->x = i / a->channels, rep->y = y, rep->c = i % a->channels;
            rep->got = ra[i], rep->want = rb[i];
            rep->worst = fabs(rep->got - rep->want);
            snprintf(rep->message, sizeof rep->message,
                     "at (%d, %d) channel %d: %.9g against %.9g (not the same bits)", rep->x,
                     rep->y, rep->c, rep->got, rep->want);
            break;
        }
    }
    return rep->ok;
}

bool wg_testkit_check_invariance(const WgTestkitNode *n, WgTestkitReport *rep)
{
    int w, h;
    node_size(n, &w, &h);
    RunHow hows[] = {
        {.threads = 2},
        {.threads = 3},
        {.threads = 8},
        {.threads = 2, .no_fuse = true, .between_points = true},
        {.threads = 2, .band_rows = 1, .between_points = true},
        {.threads = 3, .band_rows = 3, .between_points = true},
        {.threads = 8, .band_rows = 7, .between_points = true},
    };
    static const char *const names[] = {
        "2 threads", "3 threads", "8 threads", "whole between point operations",
        "bands of 1 row", "bands of 3 rows", "bands of 7 rows"};
    WgError err = {0};
    WgImage *ref = NULL;
    RunHow one = {.threads = 1};
    if (run_how(n, &one, w, h, &ref, &err)) return failed(rep, "the node failed with 1 thread", &err);
    bool ok = true;
    for (size_t k = 0; k < sizeof hows / sizeof *hows; k++) hows[k].out_channels = ref->channels;
    for (size_t k = 0; ok && k < sizeof hows / sizeof *hows; k++) {
        WgImage *got = NULL;
        if (run_how(n, &hows[k], w, h, &got, &err)) {
            char what[128];
            snprintf(what, sizeof what, "the node failed with %s", names[k]);
            ok = failed(rep, what, &err);
            break;
        }
        if (!same_bits(got, ref, rep)) {
            char detail[1024];
            snprintf(detail, sizeof detail, "%s differs from 1 thread, whole: %s", names[k],
                     rep->message);
            snprintf(rep->message, sizeof rep->message, "%s", detail);
            ok = false;
        }
        wg_image_unref(got);
    }
    if (ok)
        snprintf(rep->message, sizeof rep->message,
                 "the same bits with 1, 2, 3 and 8 threads, whole and in bands of 1, 3 and 7 rows");
    wg_image_unref(ref);
    return ok;
}

/* ---- hard inputs --------------------------------------------------------------------------- */

typedef struct {
    const char *name;
    int w, h;         /* 0: the node's size */
    float value;      /* a flat image of it, when !noise */
    bool noise;
    float special;    /* put at one pixel of the noise: NaN or Inf (0: none) */
    bool nonfinite;   /* NaN or Inf: may be refused, may give non-finite output */
} HardCase;

static WgImage *hard_image(const HardCase *c, int w, int h, int channels, uint32_t seed)
{
    if (!c->noise) return wg_testkit_image_fill(w, h, channels, c->value);
    WgImage *img = wg_testkit_image_noise(w, h, channels, seed);
    if (img && c->special != 0) wg_image_row(img, h / 2)[(w / 2) * channels] = c->special;
    return img;
}

/* What the child reports: passed or not, and a message. */
static void run_case(const WgTestkitNode *n, const HardCase *c, int w, int h, int fd)
{
    int n_in = count_inputs(n);
    const WgImage **imgs = calloc((size_t)n_in + 1, sizeof *imgs);
    for (int i = 0; imgs && i < n_in; i++)
        imgs[i] = hard_image(c, w, h, n->inputs[i] ? n->inputs[i]->channels : 1, (uint32_t)(i + 1));
    WgTestkitNode m = *n;
    m.inputs = imgs;
    m.width = w;
    m.height = h;
    WgImage *out = NULL;
    WgError err = {0};
    RunHow how = {.threads = 2};
    int rc = run_how(&m, &how, w, h, &out, &err);
    char msg[256];
    bool ok;
    if (rc) {
        char text[1024];
        wg_error_format(&err, text, sizeof text);
        /* a size the node cannot take may be refused, as NaN and Inf may: with an error */
        ok = c->nonfinite || c->w > 0;
        snprintf(msg, sizeof msg, "%s: %s", ok ? "refused" : "failed", text);
    } else {
        long bad = 0;
        for (int y = 0; y < out->height; y++) {
            const float *row = wg_image_row(out, y);
            for (int i = 0; i < out->width * out->channels; i++) bad += !isfinite(row[i]);
        }
        ok = bad == 0 || c->nonfinite;
        if (bad)
            snprintf(msg, sizeof msg, "%ld non-finite output values of %ld", bad,
                     (long)out->width * out->height * out->channels);
        else
            snprintf(msg, sizeof msg, "finite output");
    }
    wg_image_unref(out);
    for (int i = 0; imgs && i < n_in; i++) wg_image_unref(imgs[i]);
    free(imgs);
    char line[260];
    int len = snprintf(line, sizeof line, "%c%s", ok ? '1' : '0', msg);
    if (write(fd, line, (size_t)len + 1) < 0) _exit(3);
}

static void child_case(const WgTestkitNode *n, const HardCase *c, int w, int h,
                       WgTestkitCase *out)
{
    out->name = c->name;
    out->ok = false;
    int fds[2];
    if (pipe(fds)) {
        snprintf(out->message, sizeof out->message, "no pipe: %s", strerror(errno));
        return;
    }
    fflush(NULL);
    pid_t pid = fork();
    if (pid < 0) {
        close(fds[0]);
        close(fds[1]);
        snprintf(out->message, sizeof out->message, "cannot fork: %s", strerror(errno));
        return;
    }
    if (pid == 0) {
        /* a crash is this case's result: not the handler of a test framework or sanitizer */
        static const int fatal[] = {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT};
        for (size_t i = 0; i < sizeof fatal / sizeof *fatal; i++) signal(fatal[i], SIG_DFL);
        close(fds[0]);
        run_case(n, c, w, h, fds[1]);
        _exit(0);
    }
    close(fds[1]);
    char buf[300] = {0};
    size_t got = 0;
    struct timespec start;
    clock_gettime(CLOCK_MONOTONIC, &start);
    bool timed_out = false;
    for (;;) {
        struct pollfd p = {fds[0], POLLIN, 0};
        int r = poll(&p, 1, 1000);
        if (r > 0) {
            ssize_t k = read(fds[0], buf + got, sizeof buf - 1 - got);
            if (k <= 0) break;
            got += (size_t)k;
            if (got >= sizeof buf - 1) break;
            continue;
        }
        struct timespec now;
        clock_gettime(CLOCK_MONOTONIC, &now);
        if (now.tv_sec - start.tv_sec > 60) {
            timed_out = true;
            kill(pid, SIGKILL);
            break;
        }
    }
    close(fds[0]);
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
    if (timed_out)
        snprintf(out->message, sizeof out->message, "did not finish within 60 s");
    else if (WIFSIGNALED(status))
        snprintf(out->message, sizeof out->message, "crashed: signal %d (%s)", WTERMSIG(status),
                 strsignal(WTERMSIG(status)));
    else if (got == 0 || (buf[0] != '0' && buf[0] != '1'))
        snprintf(out->message, sizeof out->message,
                 "crashed: exited with %d before it could report",
                 WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    else {
        out->ok = buf[0] == '1';
        snprintf(out->message, sizeof out->message, "%s", buf + 1);
    }
}

bool wg_testkit_check_hard_inputs(const WgTestkitNode *n, WgTestkitHardReport *rep)
{
    memset(rep, 0, sizeof *rep);
    int w, h;
    node_size(n, &w, &h);
    static const HardCase with_inputs[] = {
        {"zeros", 0, 0, 0.0f, false, 0, false},
        {"ones", 0, 0, 1.0f, false, 0, false},
        {"flat", 0, 0, 0.5f, false, 0, false},
        {"huge", 0, 0, 1e6f, false, 0, false},
        {"negative", 0, 0, -1.0f, false, 0, false},
        {"nan", 0, 0, 0, true, NAN, true},
        {"inf", 0, 0, 0, true, INFINITY, true},
        {"1x1", 1, 1, 0, true, 0, false},
        {"13x5", 13, 5, 0, true, 0, false},
    };
    static const HardCase source[] = {
        {"1x1", 1, 1, 0, false, 0, false},
        {"13x5", 13, 5, 0, false, 0, false},
        {"1x64", 1, 64, 0, false, 0, false},
    };
    bool has_inputs = count_inputs(n) > 0;
    const HardCase *cases = has_inputs ? with_inputs : source;
    int count = has_inputs ? (int)(sizeof with_inputs / sizeof *with_inputs)
                           : (int)(sizeof source / sizeof *source);
    size_t at = 0;
    for (int i = 0; i < count; i++) {
        int cw = cases[i].w ? cases[i].w : w, chh = cases[i].h ? cases[i].h : h;
        WgTestkitCase *c = &rep->cases[rep->n_cases++];
        child_case(n, &cases[i], cw, chh, c);
        if (!c->ok) {
            rep->n_failed++;
            int k = snprintf(rep->summary + at, sizeof rep->summary - at, "%s: %s\n", c->name,
                             c->message);
            if (k > 0 && at + (size_t)k < sizeof rep->summary) at += (size_t)k;
        }
    }
    if (rep->n_failed == 0)
        snprintf(rep->summary, sizeof rep->summary, "all %d cases pass", rep->n_cases);
    return rep->n_failed == 0;
}
