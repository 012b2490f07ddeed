/* SPDX-License-Identifier: MIT */
/* `wetgraph render --frames A:B`: one engine renders every frame in turn with $time = T +
 * frame / fps, so its memory cache hands each frame the results of the nodes that do not depend
 * on $time (their cache keys do not contain it) and only the timed part of the graph is
 * recomputed. Each frame's files are written all or none before the next frame starts; a failed
 * frame stops the sequence with the frames before it complete. --stats sums the sequence up per
 * node: how many frames computed it and the time it took in all. A graph warning is printed once
 * for the sequence, when a frame first gives it (the same place and message in later frames is
 * not repeated). */
#include "contact_sheet.h"
#include "render.h"

#include <stdlib.h>
#include <string.h>

typedef struct {
    char *id;
    const char *type;
    int computed, reused;
    double ms;
} NodeTotal;

typedef struct {
    NodeTotal *nodes;
    int n, cap, frames;
    double ms;
    size_t peak;
    size_t held;      /* the most the memory cache and the buffer pool held after a frame */
    double output_ms; /* the outputs' hashing, encoding and flushing, summed over the workers */
    int written, copied, kept; /* files (stream_last_files), summed over the frames */
} Totals;

/* The distinct warnings of the sequence so far (own copies). */
typedef struct {
    WgWarning *w;
    int n;
} Seen;

static bool same_warning(const WgWarning *a, const WgWarning *b)
{
    return a->line == b->line && !strcmp(a->file, b->file) && !strcmp(a->message, b->message) &&
           (a->node && b->node ? !strcmp(a->node, b->node) : a->node == b->node);
}

/* Prints (unless quiet) and keeps the warnings of res not given by an earlier frame. */
static int seen_add(Seen *s, const WgResult *res, bool quiet)
{
    for (int i = 0; i < wg_result_warning_count(res); i++) {
        const WgWarning *w = wg_result_warning(res, i);
        bool old = false;
        for (int k = 0; k < s->n && !old; k++) old = same_warning(&s->w[k], w);
        if (old) continue;
        WgWarning *grown = realloc(s->w, sizeof *grown * (size_t)(s->n + 1));
        if (!grown) return WG_ERR_NOMEM;
        s->w = grown;
        WgWarning *c = &s->w[s->n];
        *c = (WgWarning){strdup(w->file), w->line, w->node ? strdup(w->node) : NULL,
                         strdup(w->message)};
        s->n++;
        if (!c->file || !c->message || (w->node && !c->node)) return WG_ERR_NOMEM;
        if (!quiet) cli_warning(c, NULL);
    }
    return WG_OK;
}

static void seen_free(Seen *s)
{
    for (int i = 0; i < s->n; i++) {
        free((char *)s->w[i].file);
        free((char *)s->w[i].node);
        free((char *)s->w[i].message);
    }
    free(s->w);
}

static int totals_add(Totals *t, const WgResult *res, const WgEngine *e)
{
    WgMemoryStats m;
    wg_engine_memory_stats(e, &m);
    if (m.cache_bytes + m.pool_bytes > t->held) t->held = m.cache_bytes + m.pool_bytes;
    int n = wg_result_stat_count(res);
    for (int i = 0; i < n; i++) {
        const WgNodeStat *s = wg_result_stat(res, i);
        int k = i < t->n && !strcmp(t->nodes[i].id, s->id) ? i : -1;
        for (int j = 0; k < 0 && j < t->n; j++)
            if (!strcmp(t->nodes[j].id, s->id)) k = j;
        if (k < 0) {
            if (t->n == t->cap) {
                int cap = t->cap ? 2 * t->cap : 64;
                NodeTotal *grown = realloc(t->nodes, sizeof *grown * (size_t)cap);
                if (!grown) return WG_ERR_NOMEM;
                t->nodes = grown;
                t->cap = cap;
            }
            k = t->n;
            t->nodes[k] = (NodeTotal){strdup(s->id), s->type, 0, 0, 0};
            if (!t->nodes[k].id) return WG_ERR_NOMEM;
            t->n++;
        }
        if (s->cache == WG_COMPUTED)
            t->nodes[k].computed++;
        else
            t->nodes[k].reused++;
        t->nodes[k].ms += s->ms;
    }
    t->frames++;
    t->ms += wg_result_total_ms(res);
    if (wg_result_peak_bytes(res) > t->peak) t->peak = wg_result_peak_bytes(res);
    return WG_OK;
}

static void totals_print(const Totals *t, const Seen *seen, bool json)
{
    if (json) {
        printf("{\n  \"frames\": %d,\n  \"total_ms\": %.3f,\n  \"output_ms\": %.3f,\n  "
               "\"files\": {\"written\": %d, \"copied\": %d, \"kept\": %d},\n  "
               "\"peak_bytes\": %zu,\n  \"held_bytes\": %zu,\n  \"nodes\": [\n",
               t->frames, t->ms, t->output_ms, t->written, t->copied, t->kept, t->peak, t->held);
        for (int i = 0; i < t->n; i++) {
            const NodeTotal *n = &t->nodes[i];
            printf("    {\"id\": ");
            cli_json_string(stdout, n->id);
            printf(", \"type\": ");
            cli_json_string(stdout, n->type);
            printf(", \"computed\": %d, \"reused\": %d, \"ms\": %.3f}%s\n", n->computed, n->reused,
                   n->ms, i + 1 < t->n ? "," : "");
        }
        printf("  ],\n  \"warnings\": [");
        for (int k = 0; k < seen->n; k++) {
            printf("%s\n    ", k ? "," : "");
            cli_json_warning(stdout, &seen->w[k]);
        }
        printf("\n  ]\n}\n");
        return;
    }
    fprintf(stderr, "%-32s %-12s %9s %9s %10s\n", "node", "type", "computed", "reused", "ms");
    for (int i = 0; i < t->n; i++) {
        const NodeTotal *n = &t->nodes[i];
        fprintf(stderr, "%-32s %-12s %9d %9d %10.2f\n", n->id, n->type, n->computed, n->reused,
                n->ms);
    }
    fprintf(stderr,
            "%d frames, %.1f ms in all (with %.1f ms of output work during the renders), peak "
            "image memory %.1f MiB; between frames the cache and the buffer pool held at most "
            "%.1f MiB\n",
            t->frames, t->ms, t->output_ms, t->peak / 1048576.0, t->held / 1048576.0);
    fprintf(stderr,
            "files: %d written, %d copied (the same image as another file of the frame or of "
            "the frame before), %d kept (they held these images already)\n",
            t->written, t->copied, t->kept);
}

static void totals_free(Totals *t)
{
    for (int i = 0; i < t->n; i++) free(t->nodes[i].id);
    free(t->nodes);
}

static int write_sheet(const Options *o, const ContactSheet *cs, WgColorspace cspace, WgError *err)
{
    WgWriteSet *set = wg_write_set_new();
    if (!set) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    int rc = wg_write_set_image(set, o->contact_sheet, contact_sheet_image(cs), WG_FORMAT_PNG,
                                cspace, err);
    if (!rc) rc = wg_write_set_commit(set, err);
    wg_write_set_free(set);
    if (!rc && !o->quiet) fprintf(stderr, "wrote %s\n", o->contact_sheet);
    return rc;
}

int render_frames(const Options *o, const WgGraph *g, WgRequest *r, WgEngine *e, WgError *err)
{
    Totals totals = {0};
    Seen seen = {0};
    ContactSheet *sheet = NULL;
    WgColorspace sheet_space = WG_LINEAR;
    int count = o->frame_last - o->frame_first + 1, rc = WG_OK;
    for (int f = o->frame_first; !rc && f <= o->frame_last; f++) {
        double t = (o->has_time ? o->time : 0) + f / o->fps;
        WgResult *res = NULL;
        Stream *stream = NULL;
        wg_request_set_time(r, t);
        /* separate files are written while the frame renders; a layered EXR wants them all */
        if (!o->layered) {
            rc = stream_new(o, g, f, o->contact_sheet != NULL, &stream, err);
            wg_request_set_output_fn(r, rc ? NULL : stream_output, stream);
            wg_request_set_output_held(r, rc || !o->cache ? NULL : stream_held, stream);
        }
        if (!rc) rc = wg_render(e, r, &res, err);
        if (!rc && seen_add(&seen, res, o->quiet))
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        const WgImage *img = NULL;
        WgColorspace img_space = WG_LINEAR;
        if (!rc && !stream) {
            rc = write_outputs(o, g, res, f, err);
            if (wg_result_output_count(res) > 0) {
                img = wg_result_output_image(res, 0);
                img_space = wg_result_output_colorspace(res, 0);
            }
        }
        if (!rc && stream && o->contact_sheet && (img = stream_first(stream, &img_space)))
            img = wg_image_ref(img); /* outlives the stream */
        if (stream) {
            rc = stream_finish(stream, res, rc, err);
            if (!rc) {
                int w, c, k;
                stream_last_files(&w, &c, &k);
                totals.output_ms += stream_last_output_ms();
                totals.written += w;
                totals.copied += c;
                totals.kept += k;
            }
            wg_request_set_output_fn(r, NULL, NULL);
            wg_request_set_output_held(r, NULL, NULL);
        }
        if (!rc && o->contact_sheet && img) {
            if (!sheet) {
                sheet = contact_sheet_new(count, img->width, img->height, img->channels);
                sheet_space = img_space;
                if (!sheet) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
            }
            if (sheet) contact_sheet_add(sheet, f - o->frame_first, img);
        }
        if (!o->layered) wg_image_unref(img);
        /* what earlier frames' times computed is never read again: only what this frame used
         * stays cached (the nodes that do not depend on $time, and this frame's results) */
        wg_engine_drop_unused(e);
        if (!rc && o->stats && totals_add(&totals, res, e))
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        if (rc && err && err->message[0]) { /* say which frame failed */
            char msg[sizeof err->message];
            snprintf(msg, sizeof msg, "frame %d ($time = %g): %s", f, t, err->message);
            snprintf(err->message, sizeof err->message, "%s", msg);
        }
        wg_result_free(res);
    }
    if (!rc && sheet) rc = write_sheet(o, sheet, sheet_space, err);
    if (!rc && o->stats) totals_print(&totals, &seen, o->stats_json);
    contact_sheet_free(sheet);
    seen_free(&seen);
    totals_free(&totals);
    return rc;
}
