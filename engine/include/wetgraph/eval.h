/* SPDX-License-Identifier: MIT */
/* Rendering: an engine (worker threads, memory budget, result cache) evaluates requests (a
 * graph plus parameter values, input images, size, seed and time). Only the nodes the requested
 * outputs depend on are evaluated, and only those whose result is not already cached. Keep one
 * engine alive to re-render after an edit: unchanged nodes come from the in-memory cache; with a
 * cache folder they also survive across processes. Results are bit-identical for any thread
 * count and whether the cache is warm or cold. */
#ifndef WETGRAPH_EVAL_H
#define WETGRAPH_EVAL_H

#include "error.h"
#include "graph.h"
#include "image.h"
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <time.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct WgEngine WgEngine;
typedef struct WgRequest WgRequest;
typedef struct WgResult WgResult;

typedef struct WgEngineOptions {
    int threads;           /* worker threads; 0 = number of cores */
    size_t memory_budget;  /* bytes of image memory: node outputs, what running nodes hold
                              and the cache (docs/engine.md); 0 = default: half of physical
                              memory, at most 16 GiB */
    const char *cache_dir; /* persistent cache folder (created if missing); NULL = none */
    bool no_memory_cache;  /* keep no results in memory between renders (for a process that
                              renders once): every intermediate's buffer is then reused as soon
                              as its last consumer has run */
    bool no_fuse;          /* evaluate every node whole, also runs of point operations that are
                              otherwise fused into bands (docs/engine.md) */
    int band_rows;         /* rows of each band of a fused run (the last may be shorter); 0 =
                              chosen for the memory a band touches. Results do not depend on
                              it: a test sets it to check that they do not */
} WgEngineOptions;

/* The caller owns the engine. NULL options means defaults. */
int wg_engine_new(const WgEngineOptions *opt, WgEngine **out, WgError *err);
void wg_engine_free(WgEngine *e);
/* The disk cache folder (WgEngineOptions.cache_dir) as a whole, for keeping it in bounds: its
 * entries (the .wgc files the engine writes, in two-hex-digit subfolders) and their last use
 * (an entry's modification time: reading an entry back sets it). Nothing else in the folder
 * is counted or removed. */
typedef struct WgCacheDirInfo {
    long long entries;
    uint64_t bytes;        /* the entries' file sizes */
    time_t oldest, newest; /* the least and the most recent last use (0 when empty) */
} WgCacheDirInfo;
typedef struct WgCachePruned {
    long long removed;
    uint64_t freed, left; /* bytes removed, bytes of the entries left */
} WgCachePruned;
int wg_cache_dir_info(const char *dir, WgCacheDirInfo *info, WgError *err);
/* Remove the least recently used entries until the folder's entries take at most max_bytes
 * (0: remove them all), then the temporaries of processes that no longer exist. Safe beside
 * renders using the folder: an entry removed under one is a miss, recomputed. */
int wg_cache_dir_prune(const char *dir, uint64_t max_bytes, WgCachePruned *out, WgError *err);

/* Drop every in-memory cache entry. */
void wg_engine_clear_cache(WgEngine *e);
size_t wg_engine_memory_budget(const WgEngine *e);

/* The engine's buffer pool: pixel and scratch buffers freed by a render are kept (within the
 * memory budget, given up before cached images) and handed out again. Counts since the engine
 * was created. */
typedef struct WgMemoryStats {
    size_t pool_bytes;    /* idle buffers held now */
    int pool_buffers;     /* how many */
    uint64_t pool_hits;   /* buffer requests served by an idle buffer */
    uint64_t pool_misses; /* requests that took new memory */
    size_t pool_released; /* bytes given back to the system (trimmed or not kept) */
    size_t cache_bytes;   /* images held by the memory cache now */
    int cache_entries;    /* how many */
} WgMemoryStats;
void wg_engine_memory_stats(const WgEngine *e, WgMemoryStats *out);
/* Keep at most max_cache bytes of images in the memory cache (the least recently used go
 * first) and at most max_pool bytes of idle buffers in the pool (the rest goes back to the
 * system). For a long session that only needs about what its last render used: `wetgraph
 * watch` keeps twice that. Not while a render of this engine runs. */
void wg_engine_trim(WgEngine *e, size_t max_cache, size_t max_pool);
/* Drop the memory cache's images that no render since the previous call (or since the engine
 * was made) computed or read; their buffers go to the pool. For a sequence of renders each of
 * which reuses what the one before it used, such as the frames of an animation: the results of
 * an earlier frame's time are never read again, and dropping them after each frame keeps the
 * cache at what one frame uses instead of growing with every frame. Not while a render of this
 * engine runs. */
void wg_engine_drop_unused(WgEngine *e);

/* A request refers to the graph (which must outlive it). */
WgRequest *wg_request_new(const WgGraph *g);
void wg_request_free(WgRequest *r);
/* Override a graph parameter with a value written as in the file ("0.4", "true", "#ff8000",
 * an enum name, or an expression starting with '='). Checked against type and range. */
int wg_request_set(WgRequest *r, const char *name, const char *value, WgError *err);
/* Feed a graph input from a file or from an image (the request takes its own reference). */
int wg_request_set_input_file(WgRequest *r, const char *name, const char *path, WgError *err);
int wg_request_set_input_image(WgRequest *r, const char *name, const WgImage *img, WgError *err);
/* Restrict to some outputs (default: all). */
int wg_request_add_output(WgRequest *r, const char *name, WgError *err);
void wg_request_set_size(WgRequest *r, int width, int height); /* override root size */
void wg_request_set_seed(WgRequest *r, uint64_t seed);
void wg_request_set_time(WgRequest *r, double time);
/* Called from the engine's control thread after each job (done of total nodes); node_id is the
 * node that finished last (a fused group's last node), valid during the call. */
typedef void (*WgProgressFn)(void *user, int done, int total, const char *node_id);
void wg_request_set_progress(WgRequest *r, WgProgressFn fn, void *user);

/* Outputs handed over as soon as they are final. With an output function set, a render calls
 * it once for each requested output, on one of the engine's worker threads, as soon as the node
 * that makes the output has run (at once for an output taken from the cache), while the rest of
 * the graph is still being computed: encoding and writing files then overlaps the render. Calls
 * for different outputs run concurrently, in no fixed order; the function must be thread-safe
 * for that (each output's own state needs no lock). The image is borrowed for the call: after it
 * the render lets go of it (the memory cache may keep it), and the result holds no images
 * (wg_result_output_image returns NULL); take a reference (wg_image_ref) to keep one. A
 * non-zero return (with err set) fails the render like a failing node: nothing else starts,
 * wg_render returns that error, and the outputs already handed over are the caller's to undo.
 * wg_render returns only when every call has returned. Memory the function allocates is not
 * counted in the engine's budget. */
typedef struct WgOutputInfo {
    int index;        /* as in wg_result_output_name(res, index) */
    const char *name; /* the output's name */
    const WgImage *image;
    WgFormat format; /* resolved, never DEFAULT */
    WgColorspace colorspace;
    WgPngCompression compression; /* the graph's, for a PNG */
    /* the output's key: a hash of everything its pixels depend on (the cache key of the node
     * that makes it, and the port), known before anything is computed; the same key, the same
     * pixels, in any render, engine or process of this version */
    uint64_t key[2];
    /* the render's workers, to run parts of the output function's own work (the calling one
     * among them; idle ones help, so the last outputs of a render are not encoded on one thread
     * while the others wait), and its buffer pool, for scratch memory touched before
     * (wg_write_set_image_png_on) */
    WgWorkers workers;
} WgOutputInfo;
typedef int (*WgOutputFn)(void *user, const WgOutputInfo *out, WgError *err);
/* fn NULL: the result keeps the output images (the default). */
void wg_request_set_output_fn(WgRequest *r, WgOutputFn fn, void *user);
/* Outputs the caller already holds. With an output function set, a render first asks `held`,
 * on the calling thread while it plans (out->image is NULL), for each requested output whose
 * node no node being computed reads: true means the caller holds the pixels of out->key (a file
 * written from them, say), and the output is then neither computed nor read from the cache nor
 * handed to the output function, and its node's stat says WG_HELD. A node that makes several
 * outputs is left out only when all of them are held. NULL (the default): every output is
 * handed over. */
typedef bool (*WgOutputHeldFn)(void *user, const WgOutputInfo *out);
void wg_request_set_output_held(WgRequest *r, WgOutputHeldFn held, void *user);

/* Cancelling a render from another thread (or from its progress callback). A cancel token is
 * set on requests; wg_cancel_request makes every render of those requests that is running, and
 * every one started later, stop and return WG_ERR_CANCELLED: nodes not started are not started,
 * and running nodes stop at their next band of rows (docs/engine.md says how soon). Nothing a
 * cancelled node had begun enters the memory or disk cache; nodes that had finished stay cached,
 * so the next render reuses them and gives the same pixels as an uncancelled one. A token stays
 * requested until wg_cancel_reset. Renders of other requests (on the same engine) carry on. */
typedef struct WgCancel WgCancel;
/* The caller owns the token (NULL when out of memory). Free it only when no render uses it. */
WgCancel *wg_cancel_new(void);
void wg_cancel_free(WgCancel *c);
/* Thread-safe; not async-signal-safe (it takes a lock). */
void wg_cancel_request(WgCancel *c);
void wg_cancel_reset(WgCancel *c);
bool wg_cancel_requested(const WgCancel *c);
/* Renders of r stop when c is requested (NULL: never). The request borrows the token. */
void wg_request_set_cancel(WgRequest *r, WgCancel *c);

/* Resolve everything (sizes, parameters, types, files) without evaluating. */
int wg_request_check(const WgRequest *r, WgError *err);
/* A graph's <warning> that applies to a request: its `when` is non-zero with the request's
 * parameters (docs/format.md). `node` is the path of the subgraph instance it belongs to
 * ("wet" or "wet/masks"), NULL for the requested graph itself; `file` and `line` are where the
 * <warning> is written. */
typedef struct WgWarning {
    const char *file;
    int line;
    const char *node;
    const char *message;
} WgWarning;

/* The warnings that apply to the request, resolved as wg_request_check does (the same errors),
 * in the order the graph's instances are made. On success the caller owns *out (*count
 * entries, NULL when there are none) and frees it with wg_warnings_free. */
int wg_request_warnings(const WgRequest *r, WgWarning **out, int *count, WgError *err);
void wg_warnings_free(WgWarning *w, int count);

/* Graphviz description of the request's graph (as wg_graph_write_dot) with a cluster around
 * each group of its nodes that a render of the request with nothing cached evaluates fused. */
int wg_request_write_dot(const WgRequest *r, FILE *f, WgError *err);

/* Does a render of the request read $time: does an output depend on a node that reads it
 * directly (a timed node or a node's own expression scope) or on a parameter given as an
 * expression that names $time? When *out is false, renders at any time give the same
 * images. */
int wg_request_reads_time(const WgRequest *r, bool *out, WgError *err);

/* Evaluate. On success the caller owns *out. WG_ERR_CANCELLED (and *out NULL) when the
 * request's cancel token was requested before the render finished. */
int wg_render(WgEngine *e, const WgRequest *r, WgResult **out, WgError *err);

/* WG_HELD: not needed, the caller holds its outputs (wg_request_set_output_held) */
typedef enum { WG_COMPUTED = 0, WG_HIT_MEMORY = 1, WG_HIT_DISK = 2, WG_HELD = 3 } WgCacheOutcome;

typedef struct WgNodeStat {
    const char *id;
    const char *type;
    double ms; /* evaluation time (0 for cache hits); in a fused group, the node's share of the
                  group's time */
    WgCacheOutcome cache;
    int width, height, channels; /* first output */
    size_t bytes;                /* all outputs (0 for a fused intermediate: never materialised) */
    int fused;                   /* 0, or the number (1, 2, ...) of the fused group it ran in */
} WgNodeStat;

int wg_result_output_count(const WgResult *r);
const char *wg_result_output_name(const WgResult *r, int i);
/* Owned by the result; NULL when the request had an output function. */
const WgImage *wg_result_output_image(const WgResult *r, int i);
WgFormat wg_result_output_format(const WgResult *r, int i); /* resolved, never DEFAULT */
WgColorspace wg_result_output_colorspace(const WgResult *r, int i);
WgPngCompression wg_result_output_compression(const WgResult *r, int i); /* the graph's */
int wg_result_stat_count(const WgResult *r);
const WgNodeStat *wg_result_stat(const WgResult *r, int i);
int wg_result_evaluated_count(const WgResult *r); /* nodes computed (not cache hits) */
size_t wg_result_peak_bytes(const WgResult *r);   /* peak image memory as the budget counts it */
double wg_result_total_ms(const WgResult *r);
/* The warnings that applied to the render (as wg_request_warnings), owned by the result. */
int wg_result_warning_count(const WgResult *r);
const WgWarning *wg_result_warning(const WgResult *r, int i);
/* The height_scale of the graph's glTF asset i (wg_graph_gltf_info) for this render: its
 * expression evaluated with the request's parameters, or the number written. */
double wg_result_gltf_height_scale(const WgResult *r, int i);
void wg_result_free(WgResult *r);

#ifdef __cplusplus
}
#endif
#endif
