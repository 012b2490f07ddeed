/* SPDX-License-Identifier: MIT */
/* `wetgraph render`: load, check, evaluate and write. Nothing is written unless the whole
 * render succeeded: all output files are written to temporaries first and renamed into place
 * together at the end. */
#include "render.h"

#include <errno.h>
#include <pthread.h>
#include <inttypes.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <sys/xattr.h>
#include <time.h>
#include <unistd.h>
#include <xxhash.h>
#if defined(__x86_64__) && __has_include(<xxh_x86dispatch.h>)
/* The same hashes by the widest vector code the processor runs, chosen at run time (libxxhash's
 * *_dispatch functions, which this header puts in place of the usual names): AVX2 hashes 2.3x
 * as fast as the default SSE2 code on the development VM. */
#include <xxh_x86dispatch.h>
#endif

static int jpeg_quality = 92; /* --jpeg-quality, also told to the writer */

static const char help[] =
    "usage: wetgraph render FILE [options]\n"
    "\n"
    "Evaluate the graph in FILE and write each requested output to DIR/<graph>_<output>.<ext>.\n"
    "\n"
    "  -o, --out DIR          output folder (created if missing; default: .)\n"
    "  --set NAME=VALUE       set a graph parameter (repeatable)\n"
    "  --input NAME=PATH      feed a graph input from an image file (repeatable)\n"
    "  --output NAME          render only this output, or this glTF asset and what it packs\n"
    "                         (repeatable; default: all)\n"
    "  --size WxH | N         override the graph size\n"
    "  --seed N               override the graph seed\n"
    "  --time T               value of $time (seconds; for animation); with --frames, the\n"
    "                         time of frame 0\n"
    "  --frames A:B           render frames A to B (whole numbers, both included) at\n"
    "                         $time = T + frame / fps, into DIR/<graph>_<output>_<frame>.<ext>\n"
    "                         (frame as 4 digits); nodes that do not depend on $time are\n"
    "                         computed once for the whole sequence\n"
    "  --fps F                frames per second for --frames (default 24)\n"
    "  --contact-sheet F.png  with --frames: also write a grid of all frames of the first\n"
    "                         output (pick it with --output) to F.png\n"
    "  --batch LIST           render every row of LIST (.csv with columns input:NAME,\n"
    "                         set:NAME, out; or .jsonl) through one engine: nodes equal\n"
    "                         across rows are computed once; a failed row does not stop\n"
    "                         the others\n"
    "  --shard I/N            with --batch: only the I-th of N blocks of consecutive rows\n"
    "                         (I from 0; the blocks' sizes differ by one row at most)\n"
    "  --shard-by COLUMN      with --shard: rows with one value in COLUMN (input:NAME,\n"
    "                         set:NAME, out or #NAME) go to one shard, so what they share\n"
    "                         is computed once\n"
    "  --batch-json           with --batch: one JSON line per row on stdout\n"
    "  --format FMT           png | png16 | tif16 | exr | exr32 | jpeg | tga for every output;\n"
    "                         --format NAME=FMT for one output (repeatable)\n"
    "  --jpeg-quality Q       quality of JPEG outputs, 1..100 (default 92)\n"
    "  --png-compression C    fast | deflate | none for every PNG output (default: each\n"
    "                         output's compression attribute, else fast): deflate is\n"
    "                         about 4x slower, smaller on images that repeat themselves;\n"
    "                         none writes uncompressed files\n"
    "  --name PATTERN         file names: {graph}, {output}, {group}, {frame}, {row}, a batch\n"
    "                         row's {input:NAME} {set:NAME} {#NAME} {out}; '/' makes\n"
    "                         folders (default {graph}_{output}, _{frame} in a sequence)\n"
    "  --layered FILE.exr     write all outputs as layers of one EXR instead of separate files\n"
    "                         (add -o to get both)\n"
    "  --threads N            worker threads (default: number of cores)\n"
    "  --cache DIR            persistent result cache: unchanged nodes are not recomputed\n"
    "  --cache-max SIZE       after rendering, remove the cache's least recently used entries\n"
    "                         until it holds at most SIZE (bytes, or with K, M, G or T:\n"
    "                         binary multiples; 'wetgraph cache' manages the folder)\n"
    "  --memory-budget MB     image memory for the working set and the cache\n"
    "  --stats[=json]         per-node time, cache outcome and size, fused groups, and peak\n"
    "                         memory (table on stderr, or JSON on stdout)\n"
    "  --no-fuse              evaluate every node whole: no point operations fused into bands\n"
    "  -q, --quiet            print nothing but errors (no warnings either)\n";

void prune_cache(const Options *o)
{
    if (!o->has_cache_max || !o->cache) return;
    WgError err = {0};
    WgCachePruned p;
    if (wg_cache_dir_prune(o->cache, o->cache_max, &p, &err)) {
        cli_report(&err);
        return;
    }
    if (o->stats && !o->stats_json)
        fprintf(stderr, "cache %s: %lld entries removed (%.1f MiB), %.1f MiB left (cap %.1f MiB)\n",
                o->cache, p.removed, p.freed / 1048576.0, p.left / 1048576.0,
                o->cache_max / 1048576.0);
}

static int mkdir_p(const char *path)
{
    char buf[4096];
    snprintf(buf, sizeof buf, "%s", path);
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/') continue;
        *p = '\0';
        if (mkdir(buf, 0777) && errno != EEXIST) return -1;
        *p = '/';
    }
    if (mkdir(buf, 0777) && errno != EEXIST) return -1;
    struct stat st;
    return stat(buf, &st) == 0 && S_ISDIR(st.st_mode) ? 0 : -1;
}

static double now_ms(void);

/* Where the progress line's render started: its start time, and the last count seen (a
 * lower count is the next frame's render, which starts the clock again). */
typedef struct {
    double start;
    int last;
} Progress;

/* The progress line on a terminal: nodes done, the share, the node that just finished, the
 * time so far and, once a tenth is done, a guess of the time left (the time so far times the
 * nodes left over the nodes done). */
static void progress(void *user, int done, int total, const char *node)
{
    Progress *p = user;
    if (done < p->last) p->start = now_ms();
    p->last = done;
    double elapsed = (now_ms() - p->start) / 1e3;
    char left[64] = "";
    if (done > 0 && done < total && 10 * done >= total)
        snprintf(left, sizeof left, ", about %.1f s left", elapsed * (total - done) / done);
    fprintf(stderr, "\r\x1b[K[%d/%d] %3d%% %.40s, %.1f s%s", done, total,
            total ? 100 * done / total : 100, node ? node : "", elapsed, left);
    if (done == total) fprintf(stderr, "\r\x1b[K");
    fflush(stderr);
}

/* "--opt VALUE" or "--opt=VALUE" */
static bool take(int argc, char **argv, int *i, const char *opt, const char **val, bool *missing)
{
    const char *a = argv[*i];
    size_t n = strlen(opt);
    if (!strcmp(a, opt)) {
        if (*i + 1 >= argc)
            *missing = true;
        else
            *val = argv[++*i];
        return true;
    }
    if (!strncmp(a, opt, n) && a[n] == '=') {
        *val = a + n + 1;
        return true;
    }
    return false;
}

/* "A:B" with 0 <= A <= B <= MAX_FRAME and B - A < MAX_FRAMES */
static bool parse_frames(const char *text, Options *o)
{
    const char *colon = strchr(text, ':');
    if (!colon) return false;
    char first[32];
    uint64_t a, b;
    if ((size_t)(colon - text) >= sizeof first) return false;
    snprintf(first, sizeof first, "%.*s", (int)(colon - text), text);
    if (!wg_parse_whole(first, &a) || !wg_parse_whole(colon + 1, &b)) return false;
    if (a > b || b > MAX_FRAME || b - a >= MAX_FRAMES) return false;
    o->frame_first = (int)a;
    o->frame_last = (int)b;
    o->has_frames = true;
    return true;
}

/* "I/N" with 0 <= I < N <= MAX_SHARDS */
static bool parse_shard(const char *text, Options *o)
{
    const char *slash = strchr(text, '/');
    if (!slash) return false;
    char first[32];
    uint64_t i, n;
    if ((size_t)(slash - text) >= sizeof first) return false;
    snprintf(first, sizeof first, "%.*s", (int)(slash - text), text);
    if (!wg_parse_whole(first, &i) || !wg_parse_whole(slash + 1, &n)) return false;
    if (n < 1 || n > MAX_SHARDS || i >= n) return false;
    o->shard_index = (int)i;
    o->shard_count = (int)n;
    o->has_shard = true;
    return true;
}

int parse_args(int argc, char **argv, Options *o)
{
    if (!o->cmd) o->cmd = "render";
    if (!o->help) o->help = help;
    o->sets = calloc((size_t)argc, sizeof(char *));
    o->inputs = calloc((size_t)argc, sizeof(char *));
    o->outputs = calloc((size_t)argc, sizeof(char *));
    o->format = -1;
    o->png_compression = -1;
    if (!o->sets || !o->inputs || !o->outputs) return cli_usage_error(o->cmd, "out of memory");
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *val = NULL;
        bool missing = false;
#define TAKE(opt) take(argc, argv, &i, opt, &val, &missing)
#define NEED                                                                                       \
    if (missing) return cli_usage_error(o->cmd, "%s needs a value", a)
        if (cli_is_help(a)) {
            fputs(o->help, stdout);
            return 1;
        } else if (TAKE("-o") || TAKE("--out")) {
            NEED;
            o->out_dir = val;
        } else if (TAKE("--set")) {
            NEED;
            if (!strchr(val, '='))
                return cli_usage_error(o->cmd, "--set wants NAME=VALUE, not '%s'", val);
            o->sets[o->n_sets++] = val;
        } else if (TAKE("--input")) {
            NEED;
            if (!strchr(val, '='))
                return cli_usage_error(o->cmd, "--input wants NAME=PATH, not '%s'", val);
            o->inputs[o->n_inputs++] = val;
        } else if (TAKE("--output")) {
            NEED;
            o->outputs[o->n_outputs++] = val;
        } else if (TAKE("--size")) {
            NEED;
            if (!wg_parse_size(val, &o->width, &o->height))
                return cli_usage_error(o->cmd, "bad --size '%s' (N or WxH, sides 1..%d)", val,
                                       WG_MAX_SIDE);
        } else if (TAKE("--seed")) {
            NEED;
            uint64_t seed;
            if (!wg_parse_whole(val, &seed))
                return cli_usage_error(o->cmd,
                                       "bad --seed '%s' (a whole number from 0 to %" PRIu64
                                       ", decimal digits only)",
                                       val, UINT64_MAX);
            o->seed = seed;
            o->has_seed = true;
        } else if (TAKE("--time")) {
            NEED;
            if (!wg_parse_number(val, &o->time))
                return cli_usage_error(
                    "render", "bad --time '%s' (a finite decimal number of seconds, like 1.5)",
                    val);
            o->has_time = true;
        } else if (TAKE("--frames")) {
            NEED;
            if (!parse_frames(val, o))
                return cli_usage_error(o->cmd,
                                       "bad --frames '%s' (A:B, whole numbers 0 <= A <= B <= %d, "
                                       "at most %d frames)",
                                       val, MAX_FRAME, MAX_FRAMES);
        } else if (TAKE("--fps")) {
            NEED;
            if (!wg_parse_number(val, &o->fps) || !(o->fps > 0) || o->fps > 1000)
                return cli_usage_error(o->cmd, "bad --fps '%s' (a decimal number, 0 < F <= 1000)",
                                       val);
            o->has_fps = true;
        } else if (TAKE("--contact-sheet")) {
            NEED;
            size_t n = strlen(val);
            if (n < 5 || strcasecmp(val + n - 4, ".png"))
                return cli_usage_error(o->cmd,
                                       "--contact-sheet writes a PNG: '%s' must end in .png", val);
            o->contact_sheet = val;
        } else if (TAKE("--batch")) {
            NEED;
            o->batch = val;
        } else if (TAKE("--shard-by")) {
            NEED;
            o->shard_by = val;
        } else if (TAKE("--shard")) {
            NEED;
            if (!parse_shard(val, o))
                return cli_usage_error(o->cmd,
                                       "bad --shard '%s' (I/N, whole numbers with 0 <= I < N <= "
                                       "%d)",
                                       val, MAX_SHARDS);
        } else if (!strcmp(a, "--batch-json")) {
            o->batch_json = true;
        } else if (TAKE("--format")) {
            NEED;
            const char *eq = strchr(val, '=');
            if (wg_format_parse(eq ? eq + 1 : val) < 0)
                return cli_usage_error(
                    o->cmd,
                    "unknown --format '%s' (png, png16, tif16, exr, exr32, jpeg, "
                    "tga; or NAME=FORMAT for one output)",
                    val);
            if (eq) {
                const char **f = realloc(o->formats, sizeof *f * (size_t)(o->n_formats + 1));
                if (!f) return cli_usage_error(o->cmd, "out of memory");
                o->formats = f;
                o->formats[o->n_formats++] = val;
            } else {
                o->format = wg_format_parse(val);
            }
        } else if (TAKE("--png-compression")) {
            NEED;
            if ((o->png_compression = wg_png_compression_parse(val)) < 0)
                return cli_usage_error(o->cmd,
                                       "unknown --png-compression '%s' (fast, deflate, none)", val);
        } else if (TAKE("--jpeg-quality")) {
            NEED;
            uint64_t q;
            if (!wg_parse_whole(val, &q) || q < 1 || q > 100)
                return cli_usage_error(o->cmd, "bad --jpeg-quality '%s' (a whole number, 1..100)",
                                       val);
            jpeg_quality = (int)q;
            wg_set_jpeg_quality(jpeg_quality);
        } else if (TAKE("--name")) {
            NEED;
            o->name = val;
        } else if (TAKE("--layered")) {
            NEED;
            o->layered = val;
        } else if (TAKE("--threads")) {
            NEED;
            uint64_t n;
            if (!wg_parse_whole(val, &n) || n < 1 || n > 256)
                return cli_usage_error(o->cmd, "bad --threads '%s' (a whole number, 1..256)", val);
            o->threads = (int)n;
        } else if (TAKE("--cache-max")) {
            NEED;
            if (!cli_parse_bytes(val, &o->cache_max))
                return cli_usage_error(o->cmd,
                                       "bad --cache-max '%s' (a size: bytes, or a decimal number "
                                       "with K, M, G or T)",
                                       val);
            o->has_cache_max = true;
        } else if (TAKE("--cache")) {
            NEED;
            o->cache = val;
        } else if (TAKE("--memory-budget")) {
            NEED;
            double mb;
            if (!wg_parse_number(val, &mb) || mb < 1 || mb > 1e9)
                return cli_usage_error(
                    "render", "bad --memory-budget '%s' (MiB, a decimal number from 1 to 1e9)",
                    val);
            o->budget = (size_t)(mb * 1048576.0);
        } else if (!strcmp(a, "--stats")) {
            o->stats = true;
        } else if (!strcmp(a, "--stats=json")) {
            o->stats = o->stats_json = true;
        } else if (!strncmp(a, "--stats=", 8)) {
            return cli_usage_error(o->cmd, "--stats takes no value or =json, not '%s'", a + 8);
        } else if (!strcmp(a, "--no-fuse")) {
            o->no_fuse = true;
        } else if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            o->quiet = true;
        } else if (a[0] == '-' && a[1]) {
            return cli_unknown_option(o->cmd, o->help, a);
        } else if (!o->file) {
            o->file = a;
        } else {
            return cli_usage_error(o->cmd, "one graph file at a time ('%s' and '%s')", o->file, a);
        }
#undef TAKE
#undef NEED
    }
    if (!o->file) return cli_usage_error(o->cmd, "no graph file given");
    if (o->has_cache_max && !o->cache)
        return cli_usage_error(o->cmd, "--cache-max needs --cache DIR");
    char why[400];
    if (o->name && !name_pattern_check(o->name, o->has_frames, o->batch != NULL, why, sizeof why))
        return cli_usage_error(o->cmd, "bad --name '%s': %s", o->name, why);
    if (!o->has_frames && (o->has_fps || o->contact_sheet))
        return cli_usage_error(o->cmd, "%s needs --frames",
                               o->has_fps ? "--fps" : "--contact-sheet");
    if (!o->has_fps) o->fps = 24;
    if (o->shard_by && !o->has_shard) return cli_usage_error(o->cmd, "--shard-by needs --shard");
    if (!o->batch && (o->has_shard || o->batch_json))
        return cli_usage_error(o->cmd, "%s needs --batch",
                               o->has_shard ? "--shard" : "--batch-json");
    if (o->batch && (o->has_frames || o->layered || o->stats))
        return cli_usage_error(o->cmd,
                               "--batch renders one image set per row: it does not "
                               "combine with %s",
                               o->has_frames ? "--frames"
                               : o->layered  ? "--layered"
                                             : "--stats");
    /* last, so that usage errors come first: the graph a path or a name gives */
    if (cli_find_graph(o->file, o->file_found, sizeof o->file_found)) return EXIT_USAGE;
    o->file = o->file_found;
    return 0;
}

/* Fused groups, numbered 1..n in the stats; each group's members in plan order, its sink last;
 * `whole` of them materialised (the sink, and the members read outside the group). */
typedef struct {
    int first, last, count, whole;
    double ms;
} Group;

static Group *fused_groups(const WgResult *res, int *count)
{
    int n = wg_result_stat_count(res), most = 0;
    for (int i = 0; i < n; i++)
        if (wg_result_stat(res, i)->fused > most) most = wg_result_stat(res, i)->fused;
    *count = most;
    Group *g = calloc((size_t)most + 1, sizeof *g);
    if (!g) {
        *count = 0;
        return NULL;
    }
    for (int i = 0; i < n; i++) {
        const WgNodeStat *s = wg_result_stat(res, i);
        Group *x = &g[s->fused];
        if (!s->fused) continue;
        if (!x->count) x->first = i;
        x->last = i;
        x->count++;
        x->whole += s->bytes > 0;
        x->ms += s->ms;
    }
    return g;
}

/* What the last write_outputs did with each output, for --stats. */
static struct {
    int n;
    char (*paths)[4096];
    bool *kept;
    bool *copied;     /* streamed: written as a copy of an identical output's file (NULL: none) */
    double ms;        /* from the first key to the last rename; streamed: from the render's end */
    double output_ms; /* streamed: the time of the output calls (hash, encode, flush), summed */
    bool streamed;
} last_write;

void print_stats(const WgEngine *e, const WgResult *res, bool json)
{
    int n = wg_result_stat_count(res), n_groups;
    Group *groups = fused_groups(res, &n_groups);
    WgMemoryStats m;
    wg_engine_memory_stats(e, &m);
    if (json) {
        printf("{\n  \"total_ms\": %.3f,\n  \"peak_bytes\": %zu,\n  \"evaluated\": %d,\n  "
               "\"pool\": {\"bytes\": %zu, \"buffers\": %d, \"hits\": %llu, \"misses\": %llu, "
               "\"released_bytes\": %zu},\n  \"nodes\": [\n",
               wg_result_total_ms(res), wg_result_peak_bytes(res), wg_result_evaluated_count(res),
               m.pool_bytes, m.pool_buffers, (unsigned long long)m.pool_hits,
               (unsigned long long)m.pool_misses, m.pool_released);
        for (int i = 0; i < n; i++) {
            const WgNodeStat *s = wg_result_stat(res, i);
            static const char *const cache[] = {"miss", "memory", "disk", "held"};
            printf("    {\"id\": ");
            cli_json_string(stdout, s->id);
            printf(", \"type\": ");
            cli_json_string(stdout, s->type);
            printf(", \"ms\": %.3f, \"cache\": \"%s\", \"width\": %d, \"height\": %d, "
                   "\"channels\": %d, \"bytes\": %zu, \"fused\": %d}%s\n",
                   s->ms, cache[s->cache], s->width, s->height, s->channels, s->bytes, s->fused,
                   i + 1 < n ? "," : "");
        }
        printf("  ],\n  \"fused\": [");
        for (int k = 1; k <= n_groups; k++) {
            printf("%s\n    {\"group\": %d, \"nodes\": %d, \"ms\": %.3f, \"first\": ",
                   k > 1 ? "," : "", k, groups[k].count, groups[k].ms);
            cli_json_string(stdout, wg_result_stat(res, groups[k].first)->id);
            printf(", \"sink\": ");
            cli_json_string(stdout, wg_result_stat(res, groups[k].last)->id);
            printf(", \"materialised\": %d}", groups[k].whole);
        }
        printf("\n  ],\n  \"outputs\": [");
        for (int k = 0; k < last_write.n; k++) {
            printf("%s\n    {\"path\": ", k ? "," : "");
            cli_json_string(stdout, last_write.paths[k]);
            printf(", \"file\": \"%s\"}", last_write.kept[k]                          ? "kept"
                                          : last_write.copied && last_write.copied[k] ? "copied"
                                                                                      : "written");
        }
        printf("\n  ],\n  \"write_ms\": %.3f,\n", last_write.ms);
        if (last_write.streamed) printf("  \"output_ms\": %.3f,\n", last_write.output_ms);
        printf("  \"warnings\": [");
        for (int k = 0; k < wg_result_warning_count(res); k++) {
            printf("%s\n    ", k ? "," : "");
            cli_json_warning(stdout, wg_result_warning(res, k));
        }
        printf("\n  ]\n}\n");
        free(groups);
        return;
    }
    fprintf(stderr, "%-32s %-12s %10s  %-6s %11s %9s  %s\n", "node", "type", "ms", "cache", "size",
            "MiB", "fused");
    for (int i = 0; i < n; i++) {
        const WgNodeStat *s = wg_result_stat(res, i);
        static const char *const cache[] = {"miss", "memory", "disk", "held"};
        char size[32], group[16] = "";
        snprintf(size, sizeof size, "%dx%d%s", s->width, s->height, s->channels == 4 ? "c" : "g");
        if (s->fused) snprintf(group, sizeof group, "#%d", s->fused);
        fprintf(stderr, "%-32s %-12s %10.2f  %-6s %11s %9.2f  %s\n", s->id, s->type, s->ms,
                cache[s->cache], size, s->bytes / 1048576.0, group);
    }
    for (int k = 1; k <= n_groups; k++) {
        const char *sink = wg_result_stat(res, groups[k].last)->id;
        fprintf(stderr,
                "fused group #%d: %d point operations from '%s' to '%s', in bands, %.2f ms in "
                "all; ",
                k, groups[k].count, wg_result_stat(res, groups[k].first)->id, sink, groups[k].ms);
        if (groups[k].whole > 1)
            fprintf(stderr, "%d are materialised (the other %d exist only in bands)\n",
                    groups[k].whole, groups[k].count - groups[k].whole);
        else
            fprintf(stderr, "only '%s' is materialised\n", sink);
    }
    free(groups);
    fprintf(stderr, "%d of %d nodes computed, %.1f ms in all, peak image memory %.1f MiB\n",
            wg_result_evaluated_count(res), n, wg_result_total_ms(res),
            wg_result_peak_bytes(res) / 1048576.0);
    fprintf(stderr,
            "buffer pool: %llu hits, %llu misses; %d idle buffers, %.1f MiB, kept for reuse; "
            "%.1f MiB given back\n",
            (unsigned long long)m.pool_hits, (unsigned long long)m.pool_misses, m.pool_buffers,
            m.pool_bytes / 1048576.0, m.pool_released / 1048576.0);
    int n_kept = 0, n_copied = 0;
    for (int k = 0; k < last_write.n; k++) {
        if (last_write.kept[k]) {
            fprintf(stderr, "kept %s (it already holds these pixels)\n", last_write.paths[k]);
            n_kept++;
        }
        n_copied += last_write.copied && last_write.copied[k];
    }
    char copies[64] = "";
    if (n_copied)
        snprintf(copies, sizeof copies, " (%d a copy of another output's file)", n_copied);
    if (last_write.n && last_write.streamed)
        fprintf(stderr,
                "outputs: %d written%s, %d kept, %.1f ms after the render to put them in place; "
                "%.1f ms of hashing, encoding and flushing in all, during the render\n",
                last_write.n - n_kept, copies, n_kept, last_write.ms, last_write.output_ms);
    else if (last_write.n)
        fprintf(stderr, "outputs: %d written%s, %d kept, %.1f ms\n", last_write.n - n_kept, copies,
                n_kept, last_write.ms);
}

/* The folder part of a file path ("." when there is none). */
static void folder_of(const char *path, char *buf, size_t size)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(buf, size, ".");
    else if (slash == path)
        snprintf(buf, size, "/");
    else
        snprintf(buf, size, "%.*s", (int)(slash - path), path);
}

/* path with "_<frame>" (4 digits) before its extension; path itself for frame < 0. */
void frame_path(const char *path, int frame, char *buf, size_t size)
{
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    if (frame < 0)
        snprintf(buf, size, "%s", path);
    else if (!dot || (slash && dot < slash))
        snprintf(buf, size, "%s_%04d", path, frame);
    else
        snprintf(buf, size, "%.*s_%04d%s", (int)(dot - path), path, frame, dot);
}

static const char *layered_name(const Options *o, int frame)
{
    static char buf[4096];
    frame_path(o->layered, frame, buf, sizeof buf);
    return buf;
}

/* The path of the output `name` written as `f` (the --format already applied). */
WgFormat output_format(const Options *o, const char *output, WgFormat graph_format)
{
    size_t n = strlen(output);
    for (int k = o->n_formats - 1; k >= 0; k--) /* the last one given wins */
        if (!strncmp(o->formats[k], output, n) && o->formats[k][n] == '=')
            return (WgFormat)wg_format_parse(o->formats[k] + n + 1);
    return o->format >= 0 ? (WgFormat)o->format : graph_format;
}

WgPngCompression output_compression(const Options *o, WgPngCompression graph_compression)
{
    return o->png_compression >= 0 ? (WgPngCompression)o->png_compression : graph_compression;
}

/* The value of placeholder `key` ({graph}, {output}, {frame}, {row}, {input:NAME}, {set:NAME},
 * {#NAME}, {out}) into buf; false when it has none here. */
/* `group` is the file's kind when it is not one of the graph's outputs (a glTF asset), else
 * NULL: the output's own group is looked up. */
static bool placeholder(const Options *o, const WgGraph *g, const char *output, const char *group,
                        int frame, const char *key, size_t len, char *buf, size_t size)
{
    if (len == 5 && !strncmp(key, "graph", 5))
        return snprintf(buf, size, "%s", wg_graph_name(g)) >= 0;
    if (len == 6 && !strncmp(key, "output", 6)) return snprintf(buf, size, "%s", output) >= 0;
    if (len == 5 && !strncmp(key, "group", 5)) { /* the output's group, or "other" */
        for (int i = 0; i < wg_graph_output_count(g) && !group; i++)
            if (!strcmp(wg_graph_output_info(g, i)->name, output))
                group = wg_graph_output_info(g, i)->group;
        return snprintf(buf, size, "%s", group ? group : "other") >= 0;
    }
    if (len == 5 && !strncmp(key, "frame", 5)) {
        if (frame < 0) return false;
        return snprintf(buf, size, "%04d", frame) >= 0;
    }
    if (len == 3 && !strncmp(key, "row", 3)) {
        if (!o->row) return false;
        return snprintf(buf, size, "%d", o->row->index) >= 0;
    }
    for (int k = 0; o->row && k < o->row->n; k++)
        if (strlen(o->row->columns[k]) == len && !strncmp(o->row->columns[k], key, len)) {
            /* a value with a folder (an input's path) gives its file name without extension */
            const char *v = o->row->values[k], *slash = strrchr(v, '/'),
                       *base = slash ? slash + 1 : v;
            const char *dot = strncmp(key, "input:", 6) ? NULL : strrchr(base, '.');
            return snprintf(buf, size, "%.*s", dot ? (int)(dot - base) : (int)strlen(base), base) >=
                   0;
        }
    return false;
}

bool name_pattern_check(const char *pattern, bool frames, bool batch, char *why, size_t size)
{
    static const char *const plain[] = {"graph", "output", "group", "frame", "row", NULL};
    bool has_output = false, has_frame = false;
    for (const char *p = pattern; *p; p++) {
        if (*p == '}') return snprintf(why, size, "'}' without '{'") < 0;
        if (*p != '{') continue;
        const char *end = strchr(p, '}');
        if (!end) return snprintf(why, size, "'{' without '}'") < 0;
        size_t len = (size_t)(end - p - 1);
        bool known = false;
        for (int k = 0; plain[k] && !known; k++)
            known = strlen(plain[k]) == len && !strncmp(plain[k], p + 1, len);
        bool column = (len > 6 && !strncmp(p + 1, "input:", 6)) ||
                      (len > 4 && !strncmp(p + 1, "set:", 4)) || (len > 1 && p[1] == '#') ||
                      (len == 3 && !strncmp(p + 1, "out", 3));
        if (!known && !column)
            return snprintf(why, size,
                            "unknown placeholder {%.*s} (graph, output, group, frame, row, and a "
                            "batch row's input:NAME, set:NAME, #NAME or out)",
                            (int)len, p + 1) < 0;
        if ((column || !strncmp(p + 1, "row}", 4)) && !batch)
            return snprintf(why, size, "{%.*s} takes a batch row: it needs --batch", (int)len,
                            p + 1) < 0;
        if (!strncmp(p + 1, "frame}", 6) && !frames)
            return snprintf(why, size, "{frame} needs --frames") < 0;
        has_output |= !strncmp(p + 1, "output}", 7);
        has_frame |= !strncmp(p + 1, "frame}", 6);
        p = end;
    }
    if (!pattern[0] || pattern[strlen(pattern) - 1] == '/')
        return snprintf(why, size, "the pattern ends without a file name") < 0;
    if (frames && !has_frame)
        return snprintf(why, size, "a frame sequence needs {frame} in the name") < 0;
    (void)has_output; /* without it several outputs collide: checked against the graph */
    return true;
}

/* DIR/<pattern>.<ext> for the file named `name` (an output, or a glTF asset of kind `group`). */
static bool pattern_file(const Options *o, const WgGraph *g, const char *name, const char *group,
                         int frame, const char *ext, char *buf, size_t size)
{
    const char *dir = o->out_dir ? o->out_dir : ".";
    const char *pattern = o->name      ? o->name
                          : frame >= 0 ? "{graph}_{output}_{frame}"
                                       : "{graph}_{output}";
    size_t at = (size_t)snprintf(buf, size, "%s/", dir);
    for (const char *p = pattern; *p && at < size; p++) {
        if (*p != '{') {
            buf[at++] = *p;
            continue;
        }
        const char *end = strchr(p, '}');
        char value[1024];
        if (!end ||
            !placeholder(o, g, name, group, frame, p + 1, (size_t)(end - p - 1), value,
                         sizeof value))
            return false;
        at += (size_t)snprintf(buf + at, size - at, "%s", value);
        p = end;
    }
    if (at >= size) at = size - 1;
    snprintf(buf + at, size - at, ".%s", ext);
    return true;
}

bool output_file(const Options *o, const WgGraph *g, const char *name, WgFormat f, int frame,
                 char *buf, size_t size)
{
    return pattern_file(o, g, name, NULL, frame, wg_format_extension(f), buf, size);
}

bool gltf_file(const Options *o, const WgGraph *g, int i, int frame, char *buf, size_t size)
{
    const WgGraphGltfInfo *a = wg_graph_gltf_info(g, i);
    return pattern_file(o, g, a->name, "gltf", frame, a->binary ? "glb" : "gltf", buf, size);
}

int name_folder(const char *path, WgError *err)
{
    char folder[4096];
    folder_of(path, folder, sizeof folder);
    struct stat st;
    if (stat(folder, &st) == 0) return WG_OK;
    if (mkdir_p(folder))
        return wg_error_set_at(err, WG_ERR_IO, folder, 0, 0, "cannot create the folder: %s",
                               strerror(errno));
    return WG_OK;
}

static void output_path_of(const Options *o, const WgGraph *g, const char *name, WgFormat f,
                           int frame, char *buf, size_t size)
{
    if (!output_file(o, g, name, f, frame, buf, size)) buf[0] = '\0';
}

int output_files_check(const Options *o, const WgGraph *g, const WgRequest *r, int frame,
                       WgError *err)
{
    (void)r;
    /* every --format NAME=FMT names an output */
    for (int k = 0; k < o->n_formats; k++) {
        const char *f = o->formats[k], *eq = strchr(f, '=');
        bool found = false;
        const char *names[512];
        int n = 0;
        for (int i = 0; i < wg_graph_output_count(g) && n < 512; i++) {
            names[n++] = wg_graph_output_info(g, i)->name;
            found |= strlen(names[n - 1]) == (size_t)(eq - f) &&
                     !strncmp(names[n - 1], f, (size_t)(eq - f));
        }
        if (found) continue;
        char given[256];
        snprintf(given, sizeof given, "%.*s", (int)(eq - f), f);
        const char *near = wg_suggest(given, names, n);
        return wg_error_set(err, WG_ERR_USAGE, NULL,
                            "--format %s: graph '%s' has no output '%s'%s%s%s", f, wg_graph_name(g),
                            given, near ? "; did you mean '" : "", near ? near : "",
                            near ? "'?" : "");
    }
    /* the files the outputs (those asked for, or all) and the glTF assets would be written to:
     * two that are one file are refused before anything is rendered */
    int n = wg_graph_output_count(g) + wg_graph_gltf_count(g);
    char(*paths)[4096] = calloc((size_t)n + 1, sizeof *paths);
    const char **owner = calloc((size_t)n + 1, sizeof *owner);
    int rc = WG_OK, m = 0;
    if (!paths || !owner) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; !rc && i < wg_graph_output_count(g); i++) {
        const WgGraphOutputInfo *info = wg_graph_output_info(g, i);
        bool asked = !o->n_outputs;
        for (int k = 0; k < o->n_outputs && !asked; k++) asked = !strcmp(o->outputs[k], info->name);
        asked |= gltf_needs_output(o, g, info->name);
        if (!asked) continue;
        WgFormat f = output_format(o, info->name, info->format ? info->format : WG_FORMAT_DEFAULT);
        if (f == WG_FORMAT_DEFAULT) f = WG_FORMAT_PNG; /* the extension is all that matters here */
        if (!output_file(o, g, info->name, f, frame, paths[m], sizeof paths[m]))
            rc = wg_error_set(err, WG_ERR_USAGE, NULL,
                              "--name '%s' names what this render does not have", o->name);
        owner[m++] = info->name;
    }
    for (int i = 0; !rc && i < wg_graph_gltf_count(g); i++) {
        if (!gltf_selected(o, g, i)) continue;
        if (!gltf_file(o, g, i, frame, paths[m], sizeof paths[m]))
            rc = wg_error_set(err, WG_ERR_USAGE, NULL,
                              "--name '%s' names what this render does not have", o->name);
        owner[m++] = wg_graph_gltf_info(g, i)->name;
    }
    for (int i = 0; !rc && i < m; i++)
        for (int k = 0; !rc && k < i; k++)
            if (!strcmp(paths[i], paths[k]))
                rc = wg_error_set(err, WG_ERR_USAGE, NULL,
                                  "'%s' and '%s' would both be written to %s%s%s", owner[k],
                                  owner[i], paths[i], o->name ? " (--name '" : "",
                                  o->name ? o->name : "");
    if (rc == WG_ERR_USAGE && o->name && strstr(err->message, "(--name '"))
        snprintf(err->message + strlen(err->message), sizeof err->message - strlen(err->message),
                 "')");
    free(paths);
    free(owner);
    return rc;
}

void output_path(const Options *o, const WgGraph *g, const WgResult *res, int i, int frame,
                 char *buf, size_t size)
{
    WgFormat f = output_format(o, wg_result_output_name(res, i), wg_result_output_format(res, i));
    output_path_of(o, g, wg_result_output_name(res, i), f, frame, buf, size);
}

/* ---- outputs kept: a key per written file, in an extended attribute of the file -------------
 * An output's key is a hash (XXH3, 128 bits) of its image (size, channels, every sample's
 * bits) with the format and colour space it is written in and the writer's version; its source
 * key the same of the engine's key for the output (everything its pixels depend on, known
 * before anything is computed) instead of the pixels. After a write, the file's attribute
 * "user.wetgraph.key" holds both keys with the file's size and modification time. The next
 * render of that file, when the attribute holds the same source key and the file still has that
 * size and time (no one edited it; a file replaced by another program has lost the attribute
 * with its inode), neither computes nor reads nor writes the output (the engine is told the
 * caller holds it); when it holds the same image key, the file is not written again: it already
 * holds exactly these pixels. Where a file system keeps no such attributes every file is
 * written. */

#define KEY_ATTR "user.wetgraph.key"
#define KEYS_VERSION 4 /* changes whenever a file written from the same image would differ */

typedef struct {
    unsigned long long hi, lo;
} OutKey;

/* The file's size and modification time as the attribute holds them; false when it is not a
 * regular file. */
static bool file_text(const char *path, char *buf, size_t size)
{
    struct stat st;
    if (lstat(path, &st) || !S_ISREG(st.st_mode)) return false;
    snprintf(buf, size, "%llu %lld.%09ld", (unsigned long long)st.st_size,
             (long long)st.st_mtim.tv_sec, st.st_mtim.tv_nsec);
    return true;
}

/* The attribute of the file at path, split: image key, source key, and the file's size and
 * time as written; false when there is none (or another version's). */
static bool key_read(const char *path, OutKey *image, OutKey *source, char *file, size_t size)
{
    char have[160];
    ssize_t n = lgetxattr(path, KEY_ATTR, have, sizeof have - 1);
    if (n < 0) return false;
    have[n] = 0;
    int used = 0, version = 0;
    if (sscanf(have, "v%d %16llx%16llx %16llx%16llx %n", &version, &image->hi, &image->lo,
               &source->hi, &source->lo, &used) != 5 ||
        version != KEYS_VERSION)
        return false;
    snprintf(file, size, "%s", have + used);
    return true;
}

/* What else than the pixels, the format and the colour space makes another file: a JPEG's
 * quality, a PNG's compression (0 for deflate, which every PNG was written with before there was
 * a choice, so that those files' keys still match a deflate render; 1 fast, 2 none). */
static int file_setting(WgFormat f, WgPngCompression png)
{
    if (f == WG_FORMAT_JPEG) return jpeg_quality;
    if (f != WG_FORMAT_PNG && f != WG_FORMAT_PNG16) return 0;
    return png == WG_PNG_COMPRESSION_DEFLATE ? 0 : png == WG_PNG_COMPRESSION_FAST ? 1 : 2;
}

/* An image's key hashes its rows in KEY_BANDS bands (one a row in shorter images), each band on
 * whichever worker takes it, then the bands' hashes in order: the same key whoever computes it,
 * and during a render the last outputs' keys are not made on one worker while the others wait.
 * The same pass finds whether every alpha of a colour image is 1, each row looked at while it is
 * in the cache, so that the writer need not read the image again to choose RGB or RGBA. */
#define KEY_BANDS 64

typedef struct {
    const WgImage *img;
    int bands;
    XXH128_hash_t *band;
    atomic_bool failed;
    atomic_bool transparent; /* some alpha of the colour image is not 1 */
} KeyJob;

static void hash_bands(void *user, int b0, int b1)
{
    KeyJob *j = user;
    const WgImage *img = j->img;
    size_t bytes = (size_t)img->width * (size_t)img->channels * sizeof(float);
    XXH3_state_t *st = XXH3_createState();
    if (!st) {
        atomic_store(&j->failed, true);
        return;
    }
    for (int b = b0; b < b1; b++) {
        int y0 = (int)((long long)b * img->height / j->bands);
        int y1 = (int)((long long)(b + 1) * img->height / j->bands);
        XXH3_128bits_reset(st);
        for (int y = y0; y < y1; y++) {
            XXH3_128bits_update(st, wg_image_row(img, y), bytes);
            if (img->channels == 4 &&
                !atomic_load_explicit(&j->transparent, memory_order_relaxed) &&
                !wg_image_row_alpha_one(img, y))
                atomic_store_explicit(&j->transparent, true, memory_order_relaxed);
        }
        j->band[b] = XXH3_128bits_digest(st);
    }
    XXH3_freeState(st);
}

/* 0, 0 when out of memory: no key, never matched nor stored. The bands run on `workers` (NULL:
 * here). *alpha_one (when not NULL): for a colour image, 1 when every alpha is 1 and 0 when one
 * is not; -1 for a gray one, or when not found. */
static OutKey output_key(const WgImage *img, WgFormat f, WgColorspace cs, WgPngCompression png,
                         const WgWorkers *workers, int *alpha_one)
{
    OutKey k = {0, 0};
    if (alpha_one) *alpha_one = -1;
    int bands = img->height < KEY_BANDS ? img->height : KEY_BANDS;
    /* a JPEG written at another quality, a PNG at another compression, is another file */
    int head[8] = {KEYS_VERSION, img->width, img->height,          img->channels,
                   (int)f,       (int)cs,    file_setting(f, png), bands};
    size_t size = sizeof head + (size_t)bands * sizeof(XXH128_hash_t);
    unsigned char *all = wg_malloc(size);
    if (!all) return k;
    KeyJob j = {img, bands, (XXH128_hash_t *)(all + sizeof head)};
    atomic_init(&j.failed, false);
    atomic_init(&j.transparent, false);
    memcpy(all, head, sizeof head);
    if (!workers || !workers->run || workers->run(workers->ctx, bands, hash_bands, &j))
        hash_bands(&j, 0, bands);
    if (!atomic_load(&j.failed)) {
        XXH128_hash_t h = XXH3_128bits(all, size);
        k.hi = h.high64;
        k.lo = h.low64;
        if (alpha_one && img->channels == 4) *alpha_one = !atomic_load(&j.transparent);
    }
    wg_free(all);
    return k;
}

/* The file at path holds the image of `key` (source: false) or the output of source key `key`
 * (source: true), untouched since it was written. */
static bool key_matches_as(const char *path, OutKey key, bool source)
{
    OutKey image, from;
    char want[64], had[64];
    if ((!key.hi && !key.lo) || !key_read(path, &image, &from, had, sizeof had) ||
        !file_text(path, want, sizeof want))
        return false;
    OutKey k = source ? from : image;
    return k.hi == key.hi && k.lo == key.lo && !strcmp(had, want);
}

static bool key_matches(const char *path, OutKey key)
{
    return key_matches_as(path, key, false);
}

/* The source key of an output written in format f: the engine's key for it, the format and
 * colour space it is written in (with a PNG's compression) and the writer's version. */
static OutKey source_key(const WgOutputInfo *out, WgFormat f, WgPngCompression png)
{
    int head[4] = {KEYS_VERSION, (int)f, (int)out->colorspace, file_setting(f, png)};
    uint64_t buf[6] = {out->key[0], out->key[1], 0, 0, 0, 0};
    memcpy(buf + 2, head, sizeof head);
    XXH128_hash_t h = XXH3_128bits(buf, sizeof buf);
    return (OutKey){h.high64, h.low64};
}

/* Record the keys on a file just written (source {0, 0} when unknown: never matched). Best
 * effort: a file without them is only written again next time. Setting them changes the file's
 * status time, not its modification time. */
static void key_store(const char *path, OutKey key, OutKey source)
{
    char text[160], file[64];
    if ((!key.hi && !key.lo) || !file_text(path, file, sizeof file)) return;
    snprintf(text, sizeof text, "v%d %016llx%016llx %016llx%016llx %s", KEYS_VERSION, key.hi,
             key.lo, source.hi, source.lo, file);
    lsetxattr(path, KEY_ATTR, text, strlen(text), 0);
}

static void last_write_clear(void)
{
    free(last_write.paths);
    free(last_write.kept);
    free(last_write.copied);
    last_write.paths = NULL;
    last_write.kept = NULL;
    last_write.copied = NULL;
    last_write.n = 0;
    last_write.streamed = false;
    last_write.output_ms = 0;
}

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

/* ---- outputs streamed: each one hashed and encoded as soon as the render has it ------------
 * The engine calls stream_output on one of its workers for each output as soon as its image is
 * final (wg_request_set_output_fn), while other nodes still run. Each output is staged in a
 * write set of its own, so the calls need no lock; when the render has succeeded the sets are
 * gathered in output order and committed together, so that, as with write_outputs, a failed
 * render or a failed output leaves every target as it was and no temporary behind. */

struct Stream {
    const Options *o;
    const WgGraph *g;
    int frame;
    int n; /* slots: one per output of the graph */
    char (*paths)[4096];
    WgWriteSet **sets; /* each output's staged temporary (NULL: none) */
    OutKey *keys, *sources;
    bool *seen, *skip, *wrote;
    /* Under mu: claimed, its key is final and its file is being staged (or is); staged, the file
     * is complete, for others to copy. copy_of: 1 + the output whose file this one's is to be a
     * copy of, once the render is over (it was being staged when this one came); 0 none. */
    bool *claimed, *staged;
    int *copy_of;
    bool *copied;  /* staged as a copy of another output's file, the same image */
    bool *refresh; /* kept (the same image): its keys stored again, with the source key */
    double *ms;
    bool keep_first;      /* keep output 0's image (for the contact sheet) */
    const WgImage **held; /* the images of the outputs the render's glTF assets pack */
    char **names;         /* their names */
    /* The output folder is made by the first output call, so that a render that fails before
     * any output is final creates nothing, and removed again when the render fails after
     * making it. */
    pthread_mutex_t mu;
    bool folder_tried, folder_made;
    int folder_rc;
    WgError folder_err;
    const WgImage *first;
    WgColorspace first_cs;
};

static void stream_free(Stream *s)
{
    if (!s) return;
    for (int i = 0; s->sets && i < s->n; i++) wg_write_set_free(s->sets[i]);
    for (int i = 0; s->held && i < s->n; i++) wg_image_unref(s->held[i]);
    for (int i = 0; s->names && i < s->n; i++) free(s->names[i]);
    free(s->held);
    free(s->names);
    pthread_mutex_destroy(&s->mu);
    wg_image_unref(s->first);
    free(s->paths);
    free(s->sets);
    free(s->keys);
    free(s->sources);
    free(s->refresh);
    free(s->seen);
    free(s->skip);
    free(s->wrote);
    free(s->claimed);
    free(s->staged);
    free(s->copy_of);
    free(s->copied);
    free(s->ms);
    free(s);
}

int stream_new(const Options *o, const WgGraph *g, int frame, bool keep_first, Stream **out,
               WgError *err)
{
    Stream *s = *out = calloc(1, sizeof *s);
    if (!s) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    s->o = o;
    s->g = g;
    s->frame = frame;
    s->keep_first = keep_first;
    pthread_mutex_init(&s->mu, NULL);
    s->n = wg_graph_output_count(g);
    size_t n = (size_t)s->n + 1;
    s->paths = calloc(n, sizeof *s->paths);
    s->sets = calloc(n, sizeof *s->sets);
    s->keys = calloc(n, sizeof *s->keys);
    s->sources = calloc(n, sizeof *s->sources);
    s->refresh = calloc(n, sizeof *s->refresh);
    s->seen = calloc(n, sizeof *s->seen);
    s->skip = calloc(n, sizeof *s->skip);
    s->wrote = calloc(n, sizeof *s->wrote);
    s->claimed = calloc(n, sizeof *s->claimed);
    s->staged = calloc(n, sizeof *s->staged);
    s->copy_of = calloc(n, sizeof *s->copy_of);
    s->copied = calloc(n, sizeof *s->copied);
    s->ms = calloc(n, sizeof *s->ms);
    s->held = calloc(n, sizeof *s->held);
    s->names = calloc(n, sizeof *s->names);
    if (!s->paths || !s->sets || !s->keys || !s->sources || !s->refresh || !s->seen || !s->skip ||
        !s->wrote || !s->claimed || !s->staged || !s->copy_of || !s->copied || !s->ms || !s->held ||
        !s->names) {
        stream_free(s);
        *out = NULL;
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    return WG_OK;
}

/* Once per stream, from whichever output call comes first. */
static int stream_folder(Stream *s, WgError *err)
{
    pthread_mutex_lock(&s->mu);
    if (!s->folder_tried) {
        const char *dir = s->o->out_dir ? s->o->out_dir : ".";
        struct stat st;
        bool existed = stat(dir, &st) == 0;
        s->folder_tried = true;
        if (mkdir_p(dir)) {
            s->folder_rc = wg_error_set_at(&s->folder_err, WG_ERR_IO, dir, 0, 0,
                                           "cannot create the output folder: %s", strerror(errno));
        } else {
            s->folder_made = !existed;
            wg_remove_stale_temporaries(dir);
        }
    }
    int rc = s->folder_rc;
    if (rc && err) *err = s->folder_err;
    pthread_mutex_unlock(&s->mu);
    return rc;
}

/* Output i, whose key is final, claims its file unless another output of this render with the
 * same key (the same pixels, format, colour space and compression: the same file) has: then
 * that one's index, and whether its file is complete already. */
static int claim(Stream *s, int i, bool *complete)
{
    OutKey key = s->keys[i];
    int from = -1;
    pthread_mutex_lock(&s->mu);
    for (int j = 0; j < s->n && from < 0 && (key.hi || key.lo); j++)
        if (j != i && s->claimed[j] && s->keys[j].hi == key.hi && s->keys[j].lo == key.lo) from = j;
    if (from < 0)
        s->claimed[i] = true;
    else
        *complete = s->staged[from];
    pthread_mutex_unlock(&s->mu);
    return from;
}

/* In a sequence, whether the previous frame's file of output i (its path in buf) holds this
 * output's image, untouched: an output that does not change with $time is then a copy of that
 * file instead of being encoded again every frame. */
static bool previous_frame_holds(const Stream *s, const char *name, WgFormat f, int i, char *buf,
                                 size_t size)
{
    if (!s->o->has_frames || s->frame <= s->o->frame_first) return false;
    output_path_of(s->o, s->g, name, f, s->frame - 1, buf, size);
    return buf[0] && strcmp(buf, s->paths[i]) && key_matches(buf, s->keys[i]);
}

/* The engine's output function: on a worker, concurrently with other outputs and nodes. An
 * output the same as another of this render (two outputs of one node, or of nodes that made the
 * same pixels) is staged as a copy of that one's file instead of being encoded again: at once
 * when that file is complete, else after the render (stream_finish), so that no worker waits. */
int stream_output(void *user, const WgOutputInfo *out, WgError *err)
{
    Stream *s = user;
    int i = out->index;
    double t0 = now_ms();
    int rc = stream_folder(s, err);
    if (rc) return rc;
    WgFormat f = output_format(s->o, out->name, out->format);
    output_path_of(s->o, s->g, out->name, f, s->frame, s->paths[i], sizeof s->paths[i]);
    if ((rc = name_folder(s->paths[i], err))) return rc;
    s->seen[i] = true;
    /* the name outlives the render's plan (the glTF assets are made after it) */
    if (gltf_needs_output(s->o, s->g, out->name)) {
        if (!(s->names[i] = strdup(out->name)))
            return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        s->held[i] = wg_image_ref(out->image);
    }
    if (i == 0 && s->keep_first) {
        s->first = wg_image_ref(out->image);
        s->first_cs = out->colorspace;
    }
    WgPngCompression png = output_compression(s->o, out->compression);
    int alpha_one;
    s->keys[i] = output_key(out->image, f, out->colorspace, png, &out->workers, &alpha_one);
    s->sources[i] = source_key(out, f, png);
    char previous[4096];
    if (key_matches(s->paths[i], s->keys[i])) {
        s->skip[i] = s->refresh[i] = true;
    } else if (previous_frame_holds(s, out->name, f, i, previous, sizeof previous)) {
        if (!(s->sets[i] = wg_write_set_new()))
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        else
            rc = wg_write_set_copy_file(s->sets[i], s->paths[i], previous, err);
        s->wrote[i] = s->copied[i] = !rc;
    } else {
        bool complete = false;
        int from = claim(s, i, &complete);
        if (from >= 0 && !complete) {
            s->copy_of[i] = from + 1;
        } else if (!(s->sets[i] = wg_write_set_new())) {
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        } else {
            if (from >= 0)
                rc = wg_write_set_copy(s->sets[i], s->paths[i], s->sets[from], 0, err);
            else
                rc = wg_write_set_image_alpha_on(s->sets[i], s->paths[i], out->image, f,
                                                 out->colorspace, png, &out->workers, alpha_one,
                                                 err);
            s->wrote[i] = !rc;
            s->copied[i] = !rc && from >= 0;
            pthread_mutex_lock(&s->mu);
            s->staged[i] = !rc && from < 0;
            pthread_mutex_unlock(&s->mu);
        }
    }
    s->ms[i] = now_ms() - t0;
    return rc;
}

/* The engine's question before it computes or reads an output: does its file already hold it
 * (the same source key, untouched)? Not for the outputs whose images the render needs (the
 * contact sheet's, the glTF assets'). On the calling thread, before any output call. */
bool stream_held(void *user, const WgOutputInfo *out)
{
    Stream *s = user;
    int i = out->index;
    if ((i == 0 && s->keep_first) || gltf_needs_output(s->o, s->g, out->name)) return false;
    WgFormat f = output_format(s->o, out->name, out->format);
    char path[4096];
    output_path_of(s->o, s->g, out->name, f, s->frame, path, sizeof path);
    OutKey source = source_key(out, f, output_compression(s->o, out->compression));
    if (!path[0] || !key_matches_as(path, source, true)) return false;
    /* temporaries a killed render left in the folder go, as when an output is written */
    if (stream_folder(s, NULL)) return false;
    memcpy(s->paths[i], path, sizeof path);
    s->seen[i] = s->skip[i] = true;
    return true;
}

static const WgImage *stream_image_of(void *user, const char *output)
{
    const Stream *s = user;
    for (int i = 0; i < s->n; i++)
        if (s->held[i] && !strcmp(s->names[i], output)) return s->held[i];
    return NULL;
}

/* After the render (render_rc its outcome): on success the staged files, and the glTF assets
 * made from the images held for them, are renamed into place together and listed; in any case
 * the stream is freed, and with it every temporary left. */
int stream_finish(Stream *s, const WgResult *res, int render_rc, WgError *err)
{
    double t0 = now_ms();
    int rc = render_rc;
    WgWriteSet *set = NULL;
    int n_gltf = 0;
    char(*gltf_paths)[4096] = NULL;
    if (!rc && (!(set = wg_write_set_new()) ||
                !(gltf_paths = calloc((size_t)wg_graph_gltf_count(s->g) + 1, sizeof *gltf_paths))))
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; !rc && i < s->n; i++) { /* the copies that waited for their file */
        if (!s->copy_of[i]) continue;
        int from = s->copy_of[i] - 1;
        if (!(s->sets[i] = wg_write_set_new()))
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        else
            rc = wg_write_set_copy(s->sets[i], s->paths[i], s->sets[from], 0, err);
        s->wrote[i] = s->copied[i] = !rc;
    }
    for (int i = 0; !rc && i < s->n; i++)
        if (s->sets[i]) rc = wg_write_set_move(set, s->sets[i], err);
    if (!rc)
        rc = gltf_stage(s->o, s->g, res, stream_image_of, s, s->frame, set, gltf_paths, &n_gltf,
                        err);
    if (!rc) rc = wg_write_set_commit(set, err);
    wg_write_set_free(set);
    for (int i = 0; !rc && i < s->n; i++)
        if (s->wrote[i] || s->refresh[i]) key_store(s->paths[i], s->keys[i], s->sources[i]);
    /* with --stats=json stdout holds the one JSON document, which lists the files itself */
    if (!rc && !s->o->quiet && !s->o->stats_json) {
        for (int i = 0; i < s->n; i++)
            if (s->seen[i] && !s->skip[i]) printf("%s\n", s->paths[i]);
        for (int k = 0; k < n_gltf; k++) printf("%s\n", gltf_paths[k]);
    }
    free(gltf_paths);
    last_write_clear();
    if (!rc) {
        /* the outputs in order: the stream's slots are the result's output indexes */
        int n = 0;
        while (n < s->n && s->seen[n]) n++;
        last_write.n = n;
        last_write.paths = s->paths;
        last_write.kept = s->skip;
        last_write.copied = s->copied;
        last_write.streamed = true;
        for (int i = 0; i < n; i++) last_write.output_ms += s->ms[i];
        s->paths = NULL;
        s->skip = NULL;
        s->copied = NULL;
    }
    last_write.ms = now_ms() - t0;
    for (int i = 0; rc && i < s->n; i++) { /* the temporaries first, then the folder */
        wg_write_set_free(s->sets[i]);
        s->sets[i] = NULL;
    }
    if (rc && s->folder_made) rmdir(s->o->out_dir ? s->o->out_dir : ".");
    stream_free(s);
    return rc;
}

double stream_last_output_ms(void)
{
    return last_write.streamed ? last_write.output_ms : 0;
}

void stream_last_files(int *written, int *copied, int *kept)
{
    *written = *copied = *kept = 0;
    for (int i = 0; last_write.streamed && i < last_write.n; i++) {
        if (last_write.kept[i])
            ++*kept;
        else if (last_write.copied[i])
            ++*copied;
        else
            ++*written;
    }
}

const WgImage *stream_first(const Stream *s, WgColorspace *cs)
{
    *cs = s->first_cs;
    return s->first;
}

/* Every file is first written whole to a temporary beside its target; only when all of them
 * are complete are they renamed into place, one after the other. Temporaries that killed
 * renders left in the target folders are removed first. */
int write_outputs(const Options *o, const WgGraph *g, const WgResult *res, int frame, WgError *err)
{
    return write_outputs_except(o, g, res, frame, NULL, err);
}

int write_outputs_except(const Options *o, const WgGraph *g, const WgResult *res, int frame,
                         const bool *kept, WgError *err)
{
    int n = wg_result_output_count(res);
    bool separate = o->out_dir || !o->layered;
    const char *dir = o->out_dir ? o->out_dir : ".";
    char(*paths)[4096] = calloc((size_t)n + 1, sizeof *paths);
    WgWriteSet *set = wg_write_set_new();
    if (!paths || !set) {
        free(paths);
        wg_write_set_free(set);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    int rc = WG_OK;
    if (o->layered) {
        char folder[4096], layered[4096];
        folder_of(o->layered, folder, sizeof folder);
        frame_path(o->layered, frame, layered, sizeof layered);
        if (mkdir_p(folder))
            rc = wg_error_set_at(err, WG_ERR_IO, folder, 0, 0, "cannot create the folder of %s: %s",
                                 layered, strerror(errno));
        wg_remove_stale_temporaries(folder);
        const char **names = calloc((size_t)n + 1, sizeof *names);
        const WgImage **images = calloc((size_t)n + 1, sizeof *images);
        if (!names || !images) {
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        } else if (!rc) {
            for (int i = 0; i < n; i++) {
                names[i] = wg_result_output_name(res, i);
                images[i] = wg_result_output_image(res, i);
            }
            bool half = o->format != WG_FORMAT_EXR32;
            WgWorkers workers = wg_workers_threads(&o->threads);
            rc = wg_write_set_exr_layers_on(set, layered, n, names, images, half, &workers, err);
        }
        free(names);
        free(images);
    }
    if (!rc && separate) {
        if (mkdir_p(dir))
            rc = wg_error_set_at(err, WG_ERR_IO, dir, 0, 0, "cannot create the output folder: %s",
                                 strerror(errno));
        else
            wg_remove_stale_temporaries(dir);
    }
    /* the outputs are encoded concurrently, by as many threads as the render had */
    const char **wpaths = calloc((size_t)n + 1, sizeof *wpaths);
    const WgImage **wimages = calloc((size_t)n + 1, sizeof *wimages);
    WgFormat *wformats = calloc((size_t)n + 1, sizeof *wformats);
    WgColorspace *wcs = calloc((size_t)n + 1, sizeof *wcs);
    WgPngCompression *wpng = calloc((size_t)n + 1, sizeof *wpng);
    if (!rc && (!wpaths || !wimages || !wformats || !wcs || !wpng))
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    OutKey *keys = calloc((size_t)n + 1, sizeof *keys);
    bool *skip = calloc((size_t)n + 1, sizeof *skip), *wrote = calloc((size_t)n + 1, sizeof *wrote);
    bool *copied = calloc((size_t)n + 1, sizeof *copied);
    /* an output whose key equals an earlier one's being encoded (the same pixels, format, colour
     * space and compression: the same file) is a copy of that file: staged[i] is output i's place
     * among the encoded ones, copy_of[i] the output it copies, or -1 */
    int *staged = calloc((size_t)n + 1, sizeof *staged),
        *copy_of = calloc((size_t)n + 1, sizeof *copy_of);
    WgWriteSet *encoded = wg_write_set_new();
    if (!rc && (!keys || !skip || !wrote || !copied || !staged || !copy_of || !encoded))
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    int nw = 0;
    for (int i = 0; !rc && separate && i < n; i++) {
        output_path(o, g, res, i, frame, paths[i], sizeof paths[i]);
        if ((rc = name_folder(paths[i], err))) break;
        WgFormat f =
            output_format(o, wg_result_output_name(res, i), wg_result_output_format(res, i));
        WgPngCompression png = output_compression(o, wg_result_output_compression(res, i));
        keys[i] = output_key(wg_result_output_image(res, i), f, wg_result_output_colorspace(res, i),
                             png, NULL, NULL);
        skip[i] = (kept && kept[i]) || key_matches(paths[i], keys[i]);
        copy_of[i] = -1;
        if (skip[i]) continue;
        wrote[i] = true;
        for (int j = 0; j < i && copy_of[i] < 0 && (keys[i].hi || keys[i].lo); j++)
            if (wrote[j] && !copied[j] && keys[j].hi == keys[i].hi && keys[j].lo == keys[i].lo)
                copy_of[i] = j;
        if (copy_of[i] >= 0) {
            copied[i] = true;
            continue;
        }
        staged[i] = nw;
        wpaths[nw] = paths[i];
        wimages[nw] = wg_result_output_image(res, i);
        wformats[nw] = f;
        wpng[nw] = png;
        wcs[nw++] = wg_result_output_colorspace(res, i);
    }
    if (!rc && nw)
        rc =
            wg_write_set_images(encoded, nw, wpaths, wimages, wformats, wcs, wpng, o->threads, err);
    for (int i = 0; !rc && separate && i < n; i++)
        if (copied[i]) rc = wg_write_set_copy(set, paths[i], encoded, staged[copy_of[i]], err);
    if (!rc) rc = wg_write_set_move(set, encoded, err);
    wg_write_set_free(encoded);
    int n_gltf = 0;
    char(*gltf_paths)[4096] = calloc((size_t)wg_graph_gltf_count(g) + 1, sizeof *gltf_paths);
    if (!rc && !gltf_paths) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!rc && separate)
        rc = gltf_stage(o, g, res, gltf_image_of_result, (void *)res, frame, set, gltf_paths, &n_gltf,
                        err);
    free(wpaths);
    free(wimages);
    free(wformats);
    free(wcs);
    free(wpng);
    if (!rc) rc = wg_write_set_commit(set, err);
    wg_write_set_free(set);
    for (int i = 0; !rc && separate && i < n; i++)
        if (wrote[i]) key_store(paths[i], keys[i], (OutKey){0, 0});
    if (!rc && !o->quiet) {
        if (o->layered) fprintf(stderr, "wrote %s (%d layers)\n", layered_name(o, frame), n);
    }
    if (!rc && !o->quiet && !o->stats_json) {
        for (int i = 0; separate && i < n; i++)
            if (!skip[i]) printf("%s\n", paths[i]);
        for (int k = 0; k < n_gltf; k++) printf("%s\n", gltf_paths[k]);
    }
    free(gltf_paths);
    last_write_clear();
    clock_gettime(CLOCK_MONOTONIC, &t1);
    last_write.ms = (t1.tv_sec - t0.tv_sec) * 1e3 + (t1.tv_nsec - t0.tv_nsec) / 1e6;
    if (!rc && separate) {
        last_write.n = n;
        last_write.paths = paths;
        last_write.kept = skip;
        last_write.copied = copied;
        paths = NULL;
        skip = NULL;
        copied = NULL;
    }
    free(keys);
    free(skip);
    free(wrote);
    free(copied);
    free(staged);
    free(copy_of);
    free(paths);
    return rc;
}

int build_request(const Options *o, const WgGraph *g, WgRequest **out, WgError *err)
{
    WgRequest *r = *out = wg_request_new(g);
    if (!r) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; i < o->n_sets; i++) {
        char name[256];
        const char *eq = strchr(o->sets[i], '=');
        snprintf(name, sizeof name, "%.*s", (int)(eq - o->sets[i]), o->sets[i]);
        if (wg_request_set(r, name, eq + 1, err)) {
            char msg[1200];
            snprintf(msg, sizeof msg, "--set %s: %s", o->sets[i], err->message);
            return wg_error_set(err, err->code, NULL, "%s", msg);
        }
    }
    for (int i = 0; i < o->n_inputs; i++) {
        char name[256];
        const char *eq = strchr(o->inputs[i], '=');
        snprintf(name, sizeof name, "%.*s", (int)(eq - o->inputs[i]), o->inputs[i]);
        if (wg_request_set_input_file(r, name, eq + 1, err)) return err->code;
    }
    for (int i = 0; i < o->n_outputs; i++) {
        const char *name = o->outputs[i];
        if (wg_graph_find_gltf(g, name) >= 0) continue; /* gltf_request_outputs adds its maps */
        bool output = false;
        for (int k = 0; k < wg_graph_output_count(g) && !output; k++)
            output = !strcmp(wg_graph_output_info(g, k)->name, name);
        if (output || !wg_graph_gltf_count(g)) {
            if (wg_request_add_output(r, name, err)) return err->code;
            continue;
        }
        /* neither: the closest of the outputs and the glTF assets */
        const char *names[512];
        int n = 0;
        for (int k = 0; k < wg_graph_output_count(g) && n < 512; k++)
            names[n++] = wg_graph_output_info(g, k)->name;
        for (int k = 0; k < wg_graph_gltf_count(g) && n < 512; k++)
            names[n++] = wg_graph_gltf_info(g, k)->name;
        const char *near = wg_suggest(name, names, n);
        return wg_error_set(err, WG_ERR_USAGE, NULL,
                            "graph '%s' has no output or glTF asset '%s'%s%s%s", wg_graph_name(g),
                            name, near ? "; did you mean '" : "", near ? near : "",
                            near ? "'?" : "");
    }
    if (gltf_request_outputs(o, g, *out, err)) return err->code;
    if (o->width) wg_request_set_size(r, o->width, o->height);
    if (o->has_seed) wg_request_set_seed(r, o->seed);
    if (o->has_time) wg_request_set_time(r, o->time);
    return WG_OK;
}

int cmd_render(int argc, char **argv)
{
    Options o = {0};
    WgGraph *g = NULL;
    WgRequest *r = NULL;
    WgEngine *e = NULL;
    WgResult *res = NULL;
    WgError err = {0};
    int status = parse_args(argc, argv, &o);
    if (status) {
        status = status == 1 ? EXIT_OK : status;
        goto out;
    }
    status = EXIT_USAGE;
    if (wg_graph_load(o.file, &g, &err)) goto fail;
    if (o.batch) {
        status = render_batch(&o, g);
        goto out;
    }
    if (build_request(&o, g, &r, &err)) goto fail;
    if (output_files_check(&o, g, r, o.has_frames ? o.frame_first : -1, &err)) goto fail;
    Progress prog = {now_ms(), 0};
    if (!o.quiet && isatty(2)) wg_request_set_progress(r, progress, &prog);
    if (wg_request_check(r, &err)) goto fail;

    status = EXIT_FAILED;
    /* one render: results kept in memory would never be read again, and freeing intermediates
     * lets the engine reuse their buffers. A frame sequence keeps them: the nodes that do not
     * depend on $time are taken from the memory cache for every frame after the first. */
    WgEngineOptions eo = {o.threads, o.budget, o.cache, !o.has_frames, o.no_fuse};
    if (wg_engine_new(&eo, &e, &err)) goto fail;
    if (o.has_frames) {
        if (render_frames(&o, g, r, e, &err)) goto fail;
    } else if (o.layered) { /* every image at once, for the one file */
        if (wg_render(e, r, &res, &err)) goto fail;
        if (!o.quiet)
            for (int i = 0; i < wg_result_warning_count(res); i++)
                cli_warning(wg_result_warning(res, i), NULL);
        if (write_outputs(&o, g, res, -1, &err)) goto fail;
        if (o.stats) print_stats(e, res, o.stats_json);
    } else { /* each output written while the rest renders */
        Stream *s = NULL;
        if (stream_new(&o, g, -1, false, &s, &err)) goto fail;
        wg_request_set_output_fn(r, stream_output, s);
        /* with --cache, work of earlier renders is reused: outputs already in their files too */
        if (o.cache) wg_request_set_output_held(r, stream_held, s);
        int rc = wg_render(e, r, &res, &err);
        if (!rc && !o.quiet)
            for (int i = 0; i < wg_result_warning_count(res); i++)
                cli_warning(wg_result_warning(res, i), NULL);
        if (stream_finish(s, res, rc, &err)) goto fail;
        if (o.stats) print_stats(e, res, o.stats_json);
    }
    status = EXIT_OK;
    goto out;
fail:
    cli_report(&err);
    /* once evaluation has started every failure is an evaluation failure */
    if (status != EXIT_FAILED) status = cli_exit_for(err.code);
out:
    if (g) prune_cache(&o); /* also after a failure: the cap holds whatever was stored */
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
    free(o.sets);
    free(o.inputs);
    free(o.outputs);
    free(o.formats);
    return status;
}
