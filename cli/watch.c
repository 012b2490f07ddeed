/* SPDX-License-Identifier: MIT */
/* `wetgraph watch FILE [render options]`: render, then wait for the graph file, the subgraph
 * files it uses (found through each subgraph node's resolved path, recursively) or an --input
 * image to change, and render again, in one process with one engine: its memory cache hands
 * the new render every node whose parameters and inputs did not change, so only what the edit
 * touched is recomputed. inotify watches the folders holding those files (editors often save
 * by writing a new file and renaming it over the old one, which a watch on the file itself
 * would lose) and events are matched by name. A burst of events (an editor's save) is
 * gathered until 50 ms pass without one (at most 1 s), then the render runs once. A file is
 * compared with what stat said before it was read; a file that can only be stat'ed after it is
 * read (a subgraph, or any file of a graph that did not load) and whose ctime falls during the
 * read counts as changed, so a save that a render read half-written (an editor that truncates,
 * then writes) is read again and the last save is always rendered. A graph that
 * does not load or check, or a render that fails, prints the error (file:line) and leaves the
 * last good outputs as they are (outputs are written all or none); the next change is tried
 * again. A change that arrives while a render runs (an event for a watched file, a queued change
 * from the web view) cancels that render through its cancel token: a monitor thread polls the
 * same descriptors during wg_render, only to request the cancel; the loop then reads them and
 * starts the next render with everything that changed. A cancelled render prints one line and
 * keeps the last good outputs. SIGINT and SIGTERM end the session cleanly (exit 0), cancelling a
 * running render too: they are blocked in every thread and read from a signalfd next to the
 * inotify descriptor. */
#include "render.h"
#ifdef WG_HAVE_SERVE
#include "serve.h"
#else
typedef struct Serve Serve; /* built without libmicrohttpd: never created */
#endif

#include <errno.h>
#include <limits.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <sys/signalfd.h>
#include <time.h>
#include <unistd.h>

enum { QUIET_MS = 50, BURST_MAX_MS = 1000, MAX_DEPTH = 64 };

static const char help[] =
    "usage: wetgraph watch FILE [render options]\n"
    "\n"
    "Render FILE as `wetgraph render` does, then render again each time FILE, a subgraph\n"
    "file it uses or an --input image changes, in the same process: nodes the change does\n"
    "not touch come from the memory cache. Prints the nodes that ran and their time. A change\n"
    "made while a render runs cancels it (\"render superseded\") and renders again. A graph\n"
    "error while editing is printed and the last good outputs are kept. Ctrl-C stops.\n"
    "\n"
    "Options: as `wetgraph render` (see 'wetgraph render --help'), except --frames, --fps,\n"
    "--contact-sheet, --batch, --shard and --batch-json, and:\n"
#ifdef WG_HAVE_SERVE
    "  --serve [ADDR:]PORT    also serve a web view of the outputs with controls for the\n"
    "                         graph's parameters (and $time) on http://ADDR:PORT/ (ADDR:\n"
    "                         an IPv4 address, or an IPv6 one in brackets such as [::1];\n"
    "                         default 127.0.0.1, this machine only: the page has no\n"
    "                         authentication, only a token against other sites' pages)\n"
    "  --env FILE             an equirectangular HDR environment for the page's 3D view\n"
    "                         (repeatable; --input environment=FILE is one too; without\n"
    "                         any, a built-in sky)\n";
#else
    "  --serve [ADDR:]PORT    not available: this wetgraph was built without libmicrohttpd\n";
#endif

/* A watched file: the folder it is in, its name there, and what stat said when it was read
 * (to notice a change made while the render ran, before the folders were watched again). */
typedef struct {
    char *dir, *name, *path;
    struct stat st;
    bool exists;
} File;

typedef struct {
    File *f;
    int n, cap;
} FileSet;

static void files_clear(FileSet *s)
{
    for (int i = 0; i < s->n; i++) {
        free(s->f[i].dir);
        free(s->f[i].name);
        free(s->f[i].path);
    }
    s->n = 0;
}

static void files_free(FileSet *s)
{
    files_clear(s);
    free(s->f);
    *s = (FileSet){0};
}

static bool files_has(const FileSet *s, const char *dir, const char *name)
{
    for (int i = 0; i < s->n; i++)
        if (!strcmp(s->f[i].dir, dir) && !strcmp(s->f[i].name, name)) return true;
    return false;
}

static bool same_stat(const struct stat *a, const struct stat *b)
{
    return a->st_ino == b->st_ino && a->st_dev == b->st_dev && a->st_size == b->st_size &&
           a->st_mtim.tv_sec == b->st_mtim.tv_sec && a->st_mtim.tv_nsec == b->st_mtim.tv_nsec;
}

/* Has a file changed since it was read? */
static bool files_changed(const FileSet *s)
{
    for (int i = 0; i < s->n; i++) {
        struct stat st;
        bool exists = stat(s->f[i].path, &st) == 0;
        if (exists != s->f[i].exists || (exists && !same_stat(&st, &s->f[i].st))) return true;
    }
    return false;
}

/* Bounds on the file timestamps of changes made from now on (before) or up to now (after).
 * File systems stamp a change from the kernel's coarse clock, which lags the fine one by up to
 * its resolution (a tick), or (multigrain timestamps, Linux 6.13 and later) from the fine one
 * when the file's times were looked at since. So the fine clock less one tick of the coarse one
 * is a lower bound (so only saves within a tick before the reading count as made during it, and
 * are read again) and the fine clock an upper bound. */
static struct timespec file_clock_before(void)
{
    struct timespec t, res;
    clock_gettime(CLOCK_REALTIME, &t);
    if (clock_getres(CLOCK_REALTIME_COARSE, &res) || res.tv_sec > 0)
        res = (struct timespec){0, 10000000};
    t.tv_nsec -= res.tv_nsec;
    if (t.tv_nsec < 0) {
        t.tv_nsec += 1000000000L;
        t.tv_sec--;
    }
    return t;
}

static struct timespec file_clock_after(void)
{
    struct timespec t;
    clock_gettime(CLOCK_REALTIME, &t);
    return t;
}

static bool ts_before(struct timespec a, struct timespec b)
{
    return a.tv_sec < b.tv_sec || (a.tv_sec == b.tv_sec && a.tv_nsec < b.tv_nsec);
}

/* A file stat'ed after it was read (a subgraph, or any file of a graph that did not load) may
 * have been saved after the read and before the stat: its inotify events came before the
 * folders were watched again and the stat matches the new file, so that save would never be
 * rendered (an editor that truncates and then writes makes a read in between see an empty or
 * cut file). Each file whose ctime lies between from (taken before anything was read) and now
 * is therefore recorded as unknown, so that it counts as changed and is read again; a ctime in
 * the future (another machine's clock) is left alone, or it would be read again for ever. */
static void files_forget_recent(FileSet *s, struct timespec from)
{
    struct timespec to = file_clock_after();
    for (int i = 0; i < s->n; i++) {
        File *f = &s->f[i];
        if (f->exists && !ts_before(f->st.st_ctim, from) && !ts_before(to, f->st.st_ctim))
            memset(&f->st, 0, sizeof f->st);
    }
}

/* Add path; before: its stat from before it was read, or NULL to take it now. */
static int files_add(FileSet *s, const char *path, const struct stat *before)
{
    const char *slash = strrchr(path, '/');
    char dir[PATH_MAX];
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (slash == path)
        snprintf(dir, sizeof dir, "/");
    else
        snprintf(dir, sizeof dir, "%.*s", (int)(slash - path), path);
    const char *name = slash ? slash + 1 : path;
    if (files_has(s, dir, name)) return WG_OK;
    if (s->n == s->cap) {
        int cap = s->cap ? 2 * s->cap : 16;
        File *f = realloc(s->f, sizeof *f * (size_t)cap);
        if (!f) return WG_ERR_NOMEM;
        s->f = f;
        s->cap = cap;
    }
    File *f = &s->f[s->n];
    *f = (File){strdup(dir), strdup(name), strdup(path), {0}, false};
    if (!f->dir || !f->name || !f->path) {
        free(f->dir);
        free(f->name);
        free(f->path);
        return WG_ERR_NOMEM;
    }
    if (before) {
        f->st = *before;
        f->exists = before->st_nlink > 0;
    } else {
        f->exists = stat(path, &f->st) == 0;
    }
    s->n++;
    return WG_OK;
}

/* The subgraph files g uses, and theirs, into s. A subgraph that does not load on its own is
 * still watched; what it uses is not (its error is the main graph's). */
static int add_subgraphs(FileSet *s, const WgGraph *g, int depth)
{
    for (int i = 0; i < wg_graph_node_count(g); i++) {
        const WgGraphNodeInfo *n = wg_graph_node_info(g, i);
        if (!n->is_subgraph || !n->subgraph_path) continue;
        const char *slash = strrchr(n->subgraph_path, '/');
        char dir[PATH_MAX];
        snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash - n->subgraph_path) : 1,
                 slash ? n->subgraph_path : ".");
        if (files_has(s, dir, slash ? slash + 1 : n->subgraph_path)) continue;
        if (files_add(s, n->subgraph_path, NULL)) return WG_ERR_NOMEM;
        WgGraph *sub = NULL;
        WgError err = {0};
        if (depth < MAX_DEPTH && !wg_graph_load(n->subgraph_path, &sub, &err)) {
            int rc = add_subgraphs(s, sub, depth + 1);
            wg_graph_free(sub);
            if (rc) return rc;
        }
    }
    return WG_OK;
}

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

/* The nodes that ran (not taken from a cache) and their time, on stderr. */
static void print_ran(const WgResult *res, double ms)
{
    int n = wg_result_stat_count(res), ran = wg_result_evaluated_count(res);
    fprintf(stderr, "watch: rendered in %.1f ms: %d of %d nodes computed\n", ms, ran, n);
    for (int i = 0; i < n; i++) {
        const WgNodeStat *s = wg_result_stat(res, i);
        if (s->cache == WG_COMPUTED)
            fprintf(stderr, "  %-32s %-12s %10.2f ms\n", s->id, s->type, s->ms);
    }
}

static int watch_files(const FileSet *files, int *wds, bool warn);
static bool read_events(int fd, const FileSet *files, const int *wds);

/* While a render runs: requests its cancel token when a watched file changes, a parameter
 * change is queued by the web view or a signal arrives. Signals and queued changes are left for
 * the loop to read; file events are read here (the loop watches anew after the render and
 * compares the files' stat). */
typedef struct {
    WgCancel *cancel;
    const FileSet *files;
    int *wds;
    int ifd, sfd, serve_fd, stop_fd;
    pthread_t tid;
    bool running;
    bool signalled; /* it was a signal (read after the join) */
} Monitor;

static void *monitor_main(void *arg)
{
    Monitor *m = arg;
    for (;;) {
        struct pollfd p[4] = {{m->stop_fd, POLLIN, 0},
                              {m->ifd, POLLIN, 0},
                              {m->sfd, POLLIN, 0},
                              {m->serve_fd, POLLIN, 0}};
        if (poll(p, 4, -1) < 0) {
            if (errno == EINTR) continue;
            return NULL;
        }
        if (p[0].revents) return NULL;
        m->signalled = p[2].revents != 0;
        if (p[2].revents || p[3].revents || (p[1].revents && read_events(m->ifd, m->files, m->wds)))
            break;
    }
    wg_cancel_request(m->cancel);
    return NULL;
}

/* Start watching for what supersedes the render about to start; a change made since the files
 * were read cancels it at once. Without a monitor (no memory, no thread) the render just runs to
 * the end. */
static void monitor_start(Monitor *m, WgCancel *cancel, const FileSet *files, int sfd, Serve *serve)
{
    *m = (Monitor){
        .cancel = cancel, .files = files, .ifd = -1, .sfd = sfd, .serve_fd = -1, .stop_fd = -1};
#ifdef WG_HAVE_SERVE
    if (serve) m->serve_fd = serve_fd(serve);
#else
    (void)serve;
#endif
    if (!cancel || !(m->wds = calloc((size_t)files->n + 1, sizeof *m->wds))) return;
    if ((m->ifd = watch_files(files, m->wds, false)) < 0 ||
        (m->stop_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) < 0)
        return;
    if (files_changed(files)) {
        wg_cancel_request(cancel);
        return;
    }
    m->running = pthread_create(&m->tid, NULL, monitor_main, m) == 0;
}

static void monitor_stop(Monitor *m)
{
    if (m->running) {
        uint64_t one = 1;
        if (write(m->stop_fd, &one, sizeof one) < 0) {
        } /* an eventfd write of 1 does not fail */
        pthread_join(m->tid, NULL);
    }
    if (m->ifd >= 0) close(m->ifd);
    if (m->stop_fd >= 0) close(m->stop_fd);
    free(m->wds);
}

/* Load, check, render and write once. On success files holds what to watch next; when the
 * graph does not load, files keeps what it held (and the graph file itself). Returns true when
 * the render was cancelled by a newer change (or a signal). */
/* The files the last render wrote, with a reference to each image: an output whose image is
 * the same object again (the engine's memory cache handed it back: nothing it depends on
 * changed) to the same path is not written again. Holding the reference keeps the address from
 * being reused by another image. */
typedef struct {
    int n;
    char **paths;
    const WgImage **images;
} Written;

static void written_clear(Written *w)
{
    for (int i = 0; i < w->n; i++) {
        free(w->paths[i]);
        wg_image_unref(w->images[i]);
    }
    free(w->paths);
    free(w->images);
    *w = (Written){0};
}

/* kept[i]: output i of res would be written to a file that already holds its image. */
static void written_compare(const Written *w, const Options *o, const WgGraph *g,
                            const WgResult *res, bool *kept)
{
    for (int i = 0; i < wg_result_output_count(res); i++) {
        char path[4096];
        output_path(o, g, res, i, -1, path, sizeof path);
        const WgImage *img = wg_result_output_image(res, i);
        struct stat st;
        for (int k = 0; k < w->n && !kept[i]; k++)
            kept[i] = w->images[k] == img && !strcmp(w->paths[k], path) && stat(path, &st) == 0;
    }
}

/* Remember what res wrote (all its outputs now are in their files). */
static void written_update(Written *w, const Options *o, const WgGraph *g, const WgResult *res)
{
    written_clear(w);
    int n = wg_result_output_count(res);
    w->paths = calloc((size_t)n + 1, sizeof *w->paths);
    w->images = calloc((size_t)n + 1, sizeof *w->images);
    if (!w->paths || !w->images) {
        written_clear(w); /* forgetting only costs writing them again */
        return;
    }
    for (int i = 0; i < n; i++) {
        char path[4096];
        output_path(o, g, res, i, -1, path, sizeof path);
        w->paths[i] = strdup(path);
        w->images[i] = wg_image_ref(wg_result_output_image(res, i));
        w->n++;
    }
}

#ifdef WG_HAVE_SERVE
/* The image of the node the page asked to see: the graph file again with one more output, from
 * that node (its first port), rendered with the same values, inputs and engine, so that
 * everything it needs comes from the memory cache; published at /view.png, or why not. */
static void render_view(const Options *o, WgEngine *e, Serve *serve)
{
    char *id = serve_view_node(serve);
    if (!id) return;
    static const char name[] = "wetgraph_view";
    WgError err = {0};
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgResult *res = NULL;
    char *text = NULL, *xml = NULL;
    size_t size = 0;
    FILE *f = fopen(o->file, "rb");
    int rc = WG_OK;
    if (f) {
        if (!fseek(f, 0, SEEK_END) && (size = (size_t)ftell(f)) && !fseek(f, 0, SEEK_SET) &&
            (text = malloc(size + 1)) && fread(text, 1, size, f) == size)
            text[size] = '\0';
        else {
            free(text);
            text = NULL;
        }
        fclose(f);
    }
    char *end = NULL;
    for (char *at = text; at && (at = strstr(at, "</wetgraph>")); at++) end = at;
    if (!end) {
        rc = wg_error_set(&err, WG_ERR_IO, NULL, "%s: cannot read the graph again", o->file);
    } else if (!(xml = malloc(size + strlen(id) + 64))) {
        rc = wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
    } else {
        int n = sprintf(xml, "%.*s<output name=\"%s\" from=\"%s\"/>\n", (int)(end - text), text,
                        name, id);
        strcpy(xml + n, end);
        Options vo = *o;
        vo.outputs = NULL; /* only the node's image */
        vo.n_outputs = 0;
        rc = wg_graph_load_memory(xml, strlen(xml), o->file, &g, &err);
        if (!rc) rc = build_request(&vo, g, &r, &err);
        if (!rc) rc = wg_request_add_output(r, name, &err);
        if (!rc) rc = wg_render(e, r, &res, &err);
    }
    int k = -1;
    for (int i = 0; !rc && i < wg_result_output_count(res); i++)
        if (!strcmp(wg_result_output_name(res, i), name)) k = i;
    if (!rc && k < 0) rc = wg_error_set(&err, WG_ERR_USAGE, NULL, "node '%s' made no image", id);
    if (rc)
        serve_publish_view(serve, id, NULL, WG_LINEAR, &err);
    else
        serve_publish_view(serve, id, wg_result_output_image(res, k),
                           wg_result_output_colorspace(res, k), NULL);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
    free(xml);
    free(text);
    free(id);
}
#endif

static bool render_once(const Options *base, WgEngine *e, FileSet *files, Serve *serve, int sfd,
                        Written *written)
{
    bool superseded = false;
    Options opt = *base, *o = &opt;
    char **sets = NULL;
    int n_sets = 0;
    struct stat *before = NULL;
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgResult *res = NULL;
    WgError err = {0};
    double t0 = now_ms();
    struct timespec read_from = file_clock_before(); /* before any file is stat'ed or read */
#ifdef WG_HAVE_SERVE
    /* the parameter changes from the web view, read as the render starts: changes made since
     * the last render are applied together */
    if (serve) {
        if (serve_sets(serve, base->sets, base->n_sets, base->has_time ? base->time : 0, &sets,
                       &n_sets, &opt.time)) { /* $time: the page's play */
            wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
            goto fail;
        }
        opt.sets = (const char **)sets;
        opt.n_sets = n_sets;
        opt.has_time = true;
    }
#endif
    /* the graph file and the inputs as they are before they are read */
    before = calloc((size_t)o->n_inputs + 1, sizeof *before);
    if (!before) {
        wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
        goto fail;
    }
    for (int i = 0; i <= o->n_inputs; i++)
        if (stat(i ? strchr(o->inputs[i - 1], '=') + 1 : o->file, &before[i]))
            memset(&before[i], 0, sizeof before[i]); /* st_nlink 0: not there */
    int rc = wg_graph_load(o->file, &g, &err);
    if (rc) {
        /* keep watching what the last good graph used, and at least the graph file */
        for (int i = 0; i < files->n; i++)
            files->f[i].exists = stat(files->f[i].path, &files->f[i].st) == 0;
        bool nomem = files_add(files, o->file, &before[0]);
        for (int i = 0; i < o->n_inputs; i++)
            nomem |= files_add(files, strchr(o->inputs[i], '=') + 1, &before[i + 1]);
        files_forget_recent(files, read_from);
        if (nomem) wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
        goto fail;
    }
    files_clear(files);
    rc = files_add(files, o->file, &before[0]);
    for (int i = 0; !rc && i < o->n_inputs; i++)
        rc = files_add(files, strchr(o->inputs[i], '=') + 1, &before[i + 1]);
    if (!rc) rc = add_subgraphs(files, g, 0);
    files_forget_recent(files, read_from);
    if (rc) {
        wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
        goto fail;
    }
    if (build_request(o, g, &r, &err) || wg_request_check(r, &err)) goto fail;
    WgCancel *cancel = wg_cancel_new();
    Monitor m;
    wg_request_set_cancel(r, cancel);
    monitor_start(&m, cancel, files, sfd, serve);
    rc = wg_render(e, r, &res, &err);
    monitor_stop(&m);
    superseded = rc == WG_ERR_CANCELLED && cancel && wg_cancel_requested(cancel);
    wg_request_set_cancel(r, NULL);
    wg_cancel_free(cancel);
    if (superseded) {
        if (!o->quiet)
            fprintf(stderr, "watch: render %s after %.2f s\n",
                    m.signalled ? "stopped" : "superseded", (now_ms() - t0) / 1e3);
        goto out;
    }
    if (rc) goto fail;
    if (!o->quiet)
        for (int i = 0; i < wg_result_warning_count(res); i++)
            cli_warning(wg_result_warning(res, i), NULL);
#ifdef WG_HAVE_SERVE
    /* the page first: the files follow (a failure to write them is published then) */
    if (serve) {
        serve_publish(serve, g, r, res, NULL, (const char *const *)o->sets, o->n_sets);
        render_view(o, e, serve);
    }
#endif
    bool layered = o->layered != NULL;
    bool *kept = calloc((size_t)wg_result_output_count(res) + 1, sizeof *kept);
    if (!kept) {
        wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
        goto fail;
    }
    if (!layered) written_compare(written, o, g, res, kept);
    rc = write_outputs_except(o, g, res, -1, kept, &err);
    free(kept);
    if (rc) goto fail;
    if (!layered) written_update(written, o, g, res);
    /* room for a change and its undo, not a version of every node for every edit so far */
    cli_trim_after(e, res);
    if (!o->quiet) {
        if (o->stats)
            print_stats(e, res, o->stats_json);
        else
            print_ran(res, now_ms() - t0);
    }
    goto out;
fail:
    cli_report(&err);
    if (!o->quiet) fprintf(stderr, "watch: the last good outputs are kept; waiting for a change\n");
#ifdef WG_HAVE_SERVE
    if (serve) serve_publish(serve, g, r, NULL, &err, (const char *const *)o->sets, o->n_sets);
#endif
out:
#ifdef WG_HAVE_SERVE
    serve_sets_free(sets, n_sets);
#else
    (void)sets;
    (void)n_sets;
    (void)serve;
#endif
    free(before);
    fflush(stdout);
    fflush(stderr);
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
    return superseded;
}

/* An inotify descriptor watching the folders of files; wds[i] is file i's folder's watch. warn:
 * say which folders cannot be watched. */
static int watch_files(const FileSet *files, int *wds, bool warn)
{
    int fd = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (fd < 0) return -1;
    for (int i = 0; i < files->n; i++) {
        wds[i] = inotify_add_watch(fd, files->f[i].dir,
                                   IN_CLOSE_WRITE | IN_MOVED_TO | IN_MOVED_FROM | IN_CREATE |
                                       IN_DELETE | IN_ATTRIB);
        if (wds[i] < 0 && warn)
            fprintf(stderr, "wetgraph: warning: %s: cannot watch the folder: %s\n", files->f[i].dir,
                    strerror(errno));
    }
    return fd;
}

/* Read the pending events; true if one names a watched file. */
static bool read_events(int fd, const FileSet *files, const int *wds)
{
    char buf[16384] __attribute__((aligned(__alignof__(struct inotify_event))));
    bool hit = false;
    ssize_t len;
    while ((len = read(fd, buf, sizeof buf)) > 0) {
        for (char *p = buf; p < buf + len;) {
            const struct inotify_event *ev = (const struct inotify_event *)p;
            for (int i = 0; ev->len && i < files->n && !hit; i++)
                hit = wds[i] == ev->wd && !strcmp(files->f[i].name, ev->name);
            p += sizeof *ev + ev->len;
        }
    }
    return hit;
}

/* Take --serve VALUE / --serve=VALUE and --env FILE / --env=FILE (into envs, argc of them at
 * most) out of argv (render's parser does not know them); returns the new argc, or -1 after a
 * usage error. */
static int take_serve(int argc, char **argv, const char **spec, const char **envs, int *n_envs)
{
    int k = 0;
    for (int i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "--")) {
            while (i < argc) argv[k++] = argv[i++];
            break;
        }
        if (!strcmp(argv[i], "--serve")) {
            if (i + 1 >= argc) return cli_usage_error("watch", "--serve needs [ADDR:]PORT"), -1;
            *spec = argv[++i];
        } else if (!strncmp(argv[i], "--serve=", 8)) {
            *spec = argv[i] + 8;
        } else if (!strcmp(argv[i], "--env")) {
            if (i + 1 >= argc) return cli_usage_error("watch", "--env needs FILE"), -1;
            envs[(*n_envs)++] = argv[++i];
        } else if (!strncmp(argv[i], "--env=", 6)) {
            envs[(*n_envs)++] = argv[i] + 6;
        } else {
            argv[k++] = argv[i];
        }
    }
    return k;
}

int cmd_watch(int argc, char **argv)
{
    Options o = {.cmd = "watch", .help = help};
    const char *serve_spec = NULL;
    Serve *serve = NULL;
    int status, n_envs = 0;
    const char **envs = calloc((size_t)argc + 1, sizeof *envs);
    if (!envs) {
        fprintf(stderr, "wetgraph: error: out of memory\n");
        return EXIT_FAILED;
    }
    argc = take_serve(argc, argv, &serve_spec, envs, &n_envs);
    if (argc < 0) {
        free(envs);
        return EXIT_USAGE;
    }
    if (n_envs && !serve_spec) {
        free(envs);
        return cli_usage_error("watch", "--env is for the page's 3D view: it needs --serve");
    }
#ifndef WG_HAVE_SERVE
    if (serve_spec)
        return cli_usage_error("watch", "--serve is not available: this wetgraph was built "
                                        "without libmicrohttpd");
#endif
    status = parse_args(argc, argv, &o);
    if (status) {
        status = status == 1 ? EXIT_OK : status;
        goto out;
    }
    if (o.has_frames || o.batch) {
        status = cli_usage_error("watch", "watch renders one image set: it does not take %s",
                                 o.has_frames ? "--frames" : "--batch");
        goto out;
    }
    /* blocked before the engine starts its threads, so that every thread inherits the mask
     * and the signals reach only the signalfd */
    sigset_t mask;
    sigemptyset(&mask);
    sigaddset(&mask, SIGINT);
    sigaddset(&mask, SIGTERM);
    sigprocmask(SIG_BLOCK, &mask, NULL);
    int sfd = signalfd(-1, &mask, SFD_CLOEXEC);
    WgEngine *e = NULL;
    WgError err = {0};
    WgEngineOptions eo = {o.threads, o.budget, o.cache, false, o.no_fuse};
    if (sfd < 0 || wg_engine_new(&eo, &e, &err)) {
        if (sfd < 0)
            wg_error_set(&err, WG_ERR_IO, NULL, "cannot receive signals: %s", strerror(errno));
        cli_report(&err);
        if (sfd >= 0) close(sfd);
        status = EXIT_FAILED;
        goto out;
    }
#ifdef WG_HAVE_SERVE
    /* after the signals are blocked: the server's threads inherit the mask */
    if (serve_spec && (serve_start(serve_spec, o.file, &serve, &err) ||
                       serve_view_setup(serve, o.inputs, o.n_inputs, envs, n_envs))) {
        if (serve) {
            wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
            serve_stop(serve);
        }
        cli_report(&err);
        wg_engine_free(e);
        close(sfd);
        status = err.code == WG_ERR_RANGE ? EXIT_USAGE : EXIT_FAILED;
        goto out;
    }
    if (serve && !o.quiet) {
        fprintf(stderr, "watch: serving on http://%s%s/\n",
                strchr(serve_spec, ':') ? "" : "127.0.0.1:", serve_spec);
        fflush(stderr);
    }
#endif
#ifdef WG_HAVE_SERVE
    /* the 3D view's lighting, before the first render is published, so that its page has it */
    if (serve) serve_prefilter(serve, e);
#endif
    FileSet files = {0};
    Written written = {0};
    int *wds = NULL;
    for (bool stop = false; !stop;) {
        bool superseded = render_once(&o, e, &files, serve, sfd, &written);
        prune_cache(&o);
        int *grown = realloc(wds, sizeof *wds * (size_t)(files.n + 1));
        if (!grown) {
            fprintf(stderr, "wetgraph: error: out of memory\n");
            status = EXIT_FAILED;
            break;
        }
        wds = grown;
        int ifd = watch_files(&files, wds, true);
        if (ifd < 0) {
            fprintf(stderr, "wetgraph: error: cannot watch files: %s\n", strerror(errno));
            status = EXIT_FAILED;
            break;
        }
        if (!o.quiet && !superseded) {
            fprintf(stderr, "watch: waiting for changes to %d file%s (Ctrl-C to stop)\n", files.n,
                    files.n == 1 ? "" : "s");
            fflush(stderr);
        }
        /* a change made while the render ran (a cancelled render was superseded by one: a
         * file event, a parameter change or a signal, all read below) */
        double burst = superseded || files_changed(&files) ? now_ms() : -1; /* burst's start */
        for (;;) {
            struct pollfd p[3] = {{ifd, POLLIN, 0}, {sfd, POLLIN, 0}, {-1, POLLIN, 0}};
#ifdef WG_HAVE_SERVE
            if (serve) p[2].fd = serve_fd(serve);
#endif
            int wait = burst < 0 ? -1 : QUIET_MS;
            if (burst >= 0 && now_ms() - burst > BURST_MAX_MS) break;
            int n = poll(p, 3, wait);
            if (n < 0 && errno == EINTR) continue;
            if (p[1].revents) {
                stop = true;
                break;
            }
#ifdef WG_HAVE_SERVE
            if (p[2].revents) { /* a parameter change from the web view: render now */
                serve_drain(serve);
                break;
            }
#endif
            if (n == 0) break; /* quiet for QUIET_MS after a change */
            if (read_events(ifd, &files, wds) && burst < 0) burst = now_ms();
        }
        close(ifd);
    }
#ifdef WG_HAVE_SERVE
    serve_stop(serve);
#endif
    if (!o.quiet) fprintf(stderr, "watch: stopped\n");
    files_free(&files);
    written_clear(&written);
    free(wds);
    wg_engine_free(e);
    close(sfd);
out:
    free(envs);
    free(o.sets);
    free(o.inputs);
    free(o.outputs);
    free(o.formats);
    return status;
}
