/* SPDX-License-Identifier: MIT */
/* Rendering a request: build the plan, decide what must be computed (walking back from the
 * requested outputs, stopping at cache hits), order the jobs for memory and check that the
 * working set fits the memory budget, then run ready nodes on the worker pool. Intermediates
 * are released as soon as their last consumer has run; the in-memory cache keeps what fits in
 * the budget. With an output function on the request, each output is handed to it by a job of
 * its own as soon as it is final, and then released like an intermediate. The first failing
 * node cancels the rest and its error is reported; so does the request's cancel token, from
 * another thread: wg_cancel_request sets the cancel flag of every render registered with the
 * token, which the scheduler, wg_parallel_rows' chunks and the fused bands already check. */
#include "internal.h"

#include <errno.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <xxhash.h>

struct WgEngine {
    WgPool *pool;
    WgCache *cache;
    WgMemPool *mem; /* freed image and scratch buffers, for reuse */
    size_t budget;
    bool memory_cache;
    bool fuse;
    int band_rows; /* rows of a fused band, 0: the engine's choice */
};

typedef struct Run Run;

typedef struct {
    int *h;
    int n;
} Heap;

typedef struct Node {
    Run *run;
    int index;
    bool needed, evaluate, requested, done;
    bool feeds; /* read by a node being computed */
    bool held;  /* requested, and the caller holds every output it makes */
    int pending;   /* inputs still being computed */
    int consumers; /* evaluations that still have to read this node */
    int holds;     /* output calls (WgRequest.output_fn) not yet returned that read it */
    bool released;
    int *dependents;
    int n_dependents;
    const WgImage **out;
    size_t out_bytes; /* its outputs, held after it has run until its last consumer has */
    size_t need;      /* held while it runs: outputs, inputs converted for it, scratch */
    bool started, ahead;
    bool parallel;      /* counted in Run.running_parallel while it runs */
    size_t ahead_bytes; /* what it adds to Run.ahead */
    /* Fusion (fuse.c): a group runs as one job, its sink's. `fused` marks the other members,
     * which are never scheduled on their own; a sink lists the members (plan order, itself
     * last). */
    bool fused;
    bool whole; /* a group member that is materialised (its sink, or read outside the group) */
    int job;    /* the node whose job evaluates this one: itself, or its group's sink */
    int *members;
    int n_members;
    WgNodeStat stat;
} Node;

struct Run {
    WgEngine *e;
    const WgRequest *r;
    WgPlan *plan;
    Node *nodes;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int running, completed, total;
    int running_parallel; /* running jobs that split their rows over the workers */
    /* nodes whose inputs are done, not started: binary min-heaps of plan indexes, taken lowest
     * first, so one thread follows the plan order the budget estimate assumes; the row-parallel
     * nodes in ready[0], the serial ones (WG_NODE_SERIAL) in ready[1] */
    Heap ready[2];
    int *ready_storage;
    int *dependents;   /* storage of every node's dependents list */
    int *members;      /* storage of every fused group's members list */
    size_t live, peak; /* outputs held and needs of the running nodes */
    /* The memory guarantee. A sequential run in the order of plan_order needs at most
     * seq_peak[r] from place r on. Nodes started ahead of the frontier (the place of the first
     * node not yet started) hold `ahead` bytes. Keeping ahead + seq_peak[frontier] within the
     * ceiling means that once the running jobs finish, the rest can always run in that order
     * within it, so the render never waits for memory it cannot get. */
    size_t *seq_peak;
    int last_done; /* the job that finished last (its sink's id names a fused group) */
    int biggest, largest; /* the node with the largest need, and the largest image */
    size_t biggest_bytes;
    size_t ahead;
    int frontier;
    size_t ceiling; /* the least of the budget and the sequential run's peak (Run.need) */
    /* The order that sequential run follows (plan_order): rank[i] is node i's place in it,
     * by_rank[r] the node at place r. The ready heaps hold ranks, and seq_peak and frontier
     * count in ranks. */
    int *rank, *by_rank;
    volatile int cancel;
    WgCancel *token; /* the request's cancel token, with this run registered in it */
    Run *token_next; /* the token's other running renders */
    int rc;
    bool skipped; /* a node ended with WG_ERR_CANCELLED: counted as completed, but not done */
    bool disk_hits; /* some node was read from the disk cache: an edit's re-render */
    /* Outputs streamed to the request's output function: one job per output, submitted to the
     * pool when its node is done and counted in `running` while it runs. The node's image is
     * held (Node.holds) until the job has returned, then released like an intermediate. */
    struct OutputJob *output_jobs;
    int outputs_left; /* output jobs not yet returned */
    WgError err;
    bool fuse;   /* fuse point operations (fuse.c) */
    size_t need; /* the sequential peak the plan needs */
};

struct WgResult {
    int n_outputs;
    char **names;
    const WgImage **images;
    WgFormat *formats;
    WgColorspace *colorspaces;
    WgPngCompression *compressions;
    int n_stats;
    WgNodeStat *stats;
    int evaluated;
    size_t peak;
    double total_ms;
    WgWarning *warnings; /* taken over from the plan */
    int n_warnings;
    double *gltf_height_scales; /* taken over from the plan */
    int n_gltfs;
};

double wg__now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

/* ---- cancel tokens ----------------------------------------------------------------------- */

struct WgCancel {
    pthread_mutex_t mu; /* taken before a run's mu, never while holding one */
    atomic_int requested;
    Run *runs; /* the renders using the token now */
};

WgCancel *wg_cancel_new(void)
{
    WgCancel *c = wg_calloc(1, sizeof *c);
    if (!c) return NULL;
    pthread_mutex_init(&c->mu, NULL);
    atomic_init(&c->requested, 0);
    return c;
}

void wg_cancel_free(WgCancel *c)
{
    if (!c) return;
    pthread_mutex_destroy(&c->mu);
    wg_free(c);
}

void wg_cancel_request(WgCancel *c)
{
    pthread_mutex_lock(&c->mu);
    atomic_store(&c->requested, 1);
    for (Run *run = c->runs; run; run = run->token_next) {
        pthread_mutex_lock(&run->mu);
        run->cancel = 1;
        pthread_cond_broadcast(&run->cv); /* the control thread may be waiting for a node */
        pthread_mutex_unlock(&run->mu);
    }
    pthread_mutex_unlock(&c->mu);
}

void wg_cancel_reset(WgCancel *c)
{
    atomic_store(&c->requested, 0);
}

bool wg_cancel_requested(const WgCancel *c)
{
    return atomic_load((atomic_int *)&c->requested) != 0;
}

/* From here on a request of the token sets run->cancel (also when it already was). */
static void token_register(Run *run, WgCancel *c)
{
    if (!c) return;
    pthread_mutex_lock(&c->mu);
    run->token = c;
    run->token_next = c->runs;
    c->runs = run;
    if (atomic_load(&c->requested)) run->cancel = 1;
    pthread_mutex_unlock(&c->mu);
}

static void token_unregister(Run *run)
{
    WgCancel *c = run->token;
    if (!c) return;
    pthread_mutex_lock(&c->mu);
    for (Run **pp = &c->runs; *pp; pp = &(*pp)->token_next)
        if (*pp == run) {
            *pp = run->token_next;
            break;
        }
    pthread_mutex_unlock(&c->mu);
}

static int cancelled_error(WgError *err)
{
    return wg_error_set(err, WG_ERR_CANCELLED, NULL,
                        "the render was cancelled (its cancel token was requested)");
}

/* ---- engine ------------------------------------------------------------------------------ */

static size_t default_budget(void)
{
    long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
    size_t half = pages > 0 && size > 0 ? (size_t)pages * (size_t)size / 2 : (size_t)4 << 30;
    size_t cap = (size_t)16 << 30;
    return half < cap ? half : cap;
}

int wg_engine_new(const WgEngineOptions *opt, WgEngine **out, WgError *err)
{
    WgEngineOptions none = {0};
    if (!opt) opt = &none;
    *out = NULL;
    int threads = opt->threads;
    if (threads <= 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        threads = n > 0 ? (int)n : 1;
    }
    if (threads > 256)
        return wg_error_set(err, WG_ERR_RANGE, NULL, "%d threads is more than the limit of 256",
                            threads);
    WgEngine *e = wg_calloc(1, sizeof *e);
    if (!e) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    e->budget = opt->memory_budget ? opt->memory_budget : default_budget();
    e->memory_cache = !opt->no_memory_cache;
    e->fuse = !opt->no_fuse;
    e->band_rows = opt->band_rows > 0 ? opt->band_rows : 0;
    e->pool = wg__pool_new(threads);
    e->cache = wg__cache_new(opt->cache_dir);
    int cache_errno = errno;
    e->mem = wg__mempool_new(e->budget);
    if (!e->pool || !e->cache || !e->mem) {
        int rc =
            !e->mem ? wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory")
            : opt->cache_dir && e->pool
                ? wg_error_set(err, WG_ERR_IO, NULL, "cannot use '%s' as the cache folder: %s",
                               opt->cache_dir, strerror(cache_errno))
                : wg_error_set(err, WG_ERR_NOMEM, NULL, "cannot start %d worker threads", threads);
        wg_engine_free(e);
        return rc;
    }
    *out = e;
    return WG_OK;
}

void wg_engine_free(WgEngine *e)
{
    if (!e) return;
    wg__pool_free(e->pool);
    wg__cache_free(e->cache);
    wg__mempool_close(e->mem);
    wg_free(e);
}

void wg_engine_clear_cache(WgEngine *e)
{
    wg__cache_clear(e->cache);
}

size_t wg_engine_memory_budget(const WgEngine *e)
{
    return e->budget;
}

void wg_engine_memory_stats(const WgEngine *e, WgMemoryStats *out)
{
    wg__mempool_stats(e->mem, out);
    out->cache_bytes = wg__cache_bytes(e->cache);
    out->cache_entries = wg__cache_count(e->cache);
}

void wg_engine_drop_unused(WgEngine *e)
{
    wg__cache_drop_unused(e->cache);
}

WgMemPool *wg__engine_mempool(WgEngine *e)
{
    return e->mem;
}

/* The cache and the pool's idle buffers share what the working set (`live`) leaves of the
 * budget; the pool gives way first. Images the cache evicts go to the pool, hence the second
 * trim. */
void wg_engine_trim(WgEngine *e, size_t max_cache, size_t max_pool)
{
    wg__cache_trim(e->cache, max_cache);
    wg__mempool_trim(e->mem, max_pool);
}

static void fit_budget(WgEngine *e, size_t live)
{
    size_t room = live < e->budget ? e->budget - live : 0;
    size_t cached = wg__cache_bytes(e->cache);
    if (cached <= room) {
        wg__mempool_trim(e->mem, room - cached);
        return;
    }
    wg__mempool_trim(e->mem, 0);
    wg__cache_trim(e->cache, room);
    cached = wg__cache_bytes(e->cache);
    wg__mempool_trim(e->mem, cached < room ? room - cached : 0);
}

/* With the run's lock held, when a job has let go of memory. An engine without a memory cache
 * renders once: idle buffers are kept only within what the render itself needs (Run.ceiling),
 * not up to the whole budget, so that buffers of sizes the rest of the render does not ask for
 * are given back. What is left is at least the need of the next job that may start (the
 * scheduler keeps live + need within the ceiling), which takes its buffers from there. */
static void fit_run(Run *run)
{
    fit_budget(run->e, run->live);
    if (!run->e->memory_cache && run->ceiling)
        wg__mempool_trim(run->e->mem, run->live < run->ceiling ? run->ceiling - run->live : 0);
}

/* ---- evaluating one node ----------------------------------------------------------------- */

/* Whether a node's results are looked for in the disk cache: not a node whose type says it is
 * cheaper to compute than to read (WG_NODE_CHEAP), nor an internal constant. */
static bool disk_cacheable(const WgInst *in)
{
    return !(in->type->flags & WG_NODE_CHEAP) && !in->constant;
}

/* Whether a node just computed is stored in the disk cache. A point operation (one that runs
 * in bands, fuse.c) is stored only when it is read by other nodes in a render that read nothing
 * from the disk cache (a first render, which fills it). Not a leaf, which only the caller
 * reads: its output file holds it (the CLI keeps that file by its source key without
 * computing anything). Not in a render that read results from the disk (an edit's re-render):
 * the point operations it computes lie downstream of the edit, which the next edit changes
 * again. Computing a point operation again from its inputs costs about a pass over memory,
 * about what writing its entry costs, and writing is what varies: on a VM whose first touch of
 * memory is slow, a 2048² colour entry is 64 MiB of fresh page cache, 60 to 300 ms depending on
 * how much the kernel still has to write back. The wet material's re-render after a change of
 * one texturing parameter writes no entry, and reads the masks it needs back. */
static bool disk_stores(const Run *run, const Node *n, const WgInst *in)
{
    if (!wg__cache_has_disk(run->e->cache) || !disk_cacheable(in)) return false;
    return !wg__fuse_capable(in) || (!run->disk_hits && !(n->requested && !n->feeds));
}

/* Names the failing node (and a file it read) in its error. */
static void locate_error(const WgInst *in, WgError *err)
{
    if (err->file[0]) { /* a file the node read: name it in the message, locate the node */
        char msg[sizeof err->message];
        snprintf(msg, sizeof msg, "%s: %s", err->file, err->message);
        memcpy(err->message, msg, sizeof msg);
        err->file[0] = '\0';
        err->line = err->column = 0;
    }
    wg_error_locate(err, in->file, in->line, in->id);
    wg_error_locate_type(err, in->type->name);
}

static int eval_node(Run *run, Node *node, WgError *err)
{
    WgInst *in = &run->plan->insts[node->index];
    const WgNodeType *t = in->type;
    int rc = WG_OK;
    const WgImage **inputs = wg_calloc((size_t)in->n_in + 1, sizeof *inputs);
    const WgImage **owned = wg_calloc((size_t)in->n_in + 1, sizeof *owned);
    WgImage **outputs = wg_calloc((size_t)in->n_out + 1, sizeof *outputs);
    if (!inputs || !owned || !outputs) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    if (in->constant) {
        WgImage *img = wg__image_convert_in(run->e->mem, in->constant, in->width, in->height,
                                            in->out_channels[0]);
        if (!img) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        outputs[0] = img;
        goto out;
    }
    int n_fixed = 0;
    while (t->inputs && t->inputs[n_fixed].name) n_fixed++;
    for (int i = 0; i < in->n_in; i++) {
        if (in->in[i].inst < 0) continue;
        const WgImage *src = run->nodes[in->in[i].inst].out[in->in[i].port];
        int want = src->channels;
        if (i < n_fixed && t->inputs[i].kind == WG_COLOR) want = 4;
        if (src->width != in->width || src->height != in->height || src->channels != want) {
            owned[i] = wg__image_convert_in(run->e->mem, src, in->width, in->height, want);
            if (!owned[i]) {
                rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory converting input '%s'",
                                  in->in_names[i]);
                goto out;
            }
            in->in_channels[i] = want;
            src = owned[i];
        }
        inputs[i] = src;
    }
    for (int o = 0; o < in->n_out; o++) {
        outputs[o] =
            t->flags & WG_NODE_UNIFORM
                ? wg__image_new_uniform_in(run->e->mem, in->width, in->height, in->out_channels[o])
                : wg__image_new_in(run->e->mem, in->width, in->height, in->out_channels[o]);
        if (!outputs[o]) {
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory for a %dx%d image", in->width,
                              in->height);
            goto out;
        }
    }
    WgNodeContext ctx = wg__inst_context(in);
    ctx.inputs = inputs;
    ctx.outputs = outputs;
    ctx.pool_ = run->e->pool;
    ctx.cancel_ = &run->cancel;
    ctx.mem_ = run->e->mem;
    rc = t->eval(&ctx, err);
    if (!rc && run->cancel) rc = WG_ERR_CANCELLED;
out:
    if (owned)
        for (int i = 0; i < in->n_in; i++) wg_image_unref(owned[i]);
    if (rc == WG_OK) {
        for (int o = 0; o < in->n_out; o++) node->out[o] = outputs[o];
    } else if (outputs) {
        for (int o = 0; o < in->n_out; o++) wg_image_unref(outputs[o]);
    }
    wg_free(inputs);
    wg_free(owned);
    wg_free(outputs);
    if (rc && rc != WG_ERR_CANCELLED) locate_error(in, err);
    return rc;
}

static const WgImage *group_source(void *user, int inst, int port)
{
    Run *run = user;
    return run->nodes[inst].out[port];
}

/* A fused group (fuse.c), run as its sink's job. Leaves each member's own time, summed over
 * threads, in its stat.ms (node_job turns them into shares of the group's time). */
static int eval_group(Run *run, Node *node, WgError *err)
{
    double *ms = wg_calloc((size_t)node->n_members + 1, sizeof(double));
    WgImage ***outputs = wg_calloc((size_t)node->n_members + 1, sizeof *outputs);
    int failed = node->n_members - 1, rc;
    if (!ms || !outputs) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    } else {
        for (int k = 0; k < node->n_members; k++) {
            Node *m = &run->nodes[node->members[k]];
            outputs[k] = m->whole ? (WgImage **)m->out : NULL;
        }
        rc = wg__fuse_eval(run->plan, node->members, node->n_members, outputs, run->e->mem,
                           group_source, run, run->e->pool, &run->cancel, run->e->band_rows, ms,
                           &failed, err);
        for (int k = 0; k < node->n_members; k++) run->nodes[node->members[k]].stat.ms = ms[k];
    }
    wg_free(ms);
    wg_free(outputs);
    if (rc && rc != WG_ERR_CANCELLED) locate_error(&run->plan->insts[node->members[failed]], err);
    return rc;
}

static void heap_push(Heap *q, int index)
{
    int *h = q->h;
    int k = q->n++;
    while (k > 0 && h[(k - 1) / 2] > index) {
        h[k] = h[(k - 1) / 2];
        k = (k - 1) / 2;
    }
    h[k] = index;
}

static void heap_pop(Heap *q)
{
    int *h = q->h;
    int last = h[--q->n];
    int k = 0, n = q->n;
    for (;;) {
        int c = 2 * k + 1;
        if (c >= n) break;
        if (c + 1 < n && h[c + 1] < h[c]) c++;
        if (h[c] >= last) break;
        h[k] = h[c];
        k = c;
    }
    if (n > 0) h[k] = last;
}

static bool parallel_job(const Run *run, const Node *n)
{
    return !(run->plan->insts[n->index].type->flags & WG_NODE_SERIAL) || n->n_members;
}

static void ready_push(Run *run, int index)
{
    heap_push(&run->ready[parallel_job(run, &run->nodes[index]) ? 0 : 1], run->rank[index]);
}

/* A requested node's image stays with the result, unless an output function takes it. */
static bool keeps(const Run *run, const Node *n)
{
    return n->requested && !run->r->output_fn;
}

static void release(Run *run, int index)
{
    Node *n = &run->nodes[index];
    if (keeps(run, n) || n->holds > 0 || n->released || !n->out) return;
    n->released = true;
    WgInst *in = &run->plan->insts[index];
    for (int o = 0; o < in->n_out; o++) {
        wg_image_unref(n->out[o]);
        n->out[o] = NULL;
    }
    run->live -= n->out_bytes;
    Node *j = &run->nodes[n->job]; /* a group's results are counted ahead with its job */
    if (j->ahead) {
        size_t b = n->out_bytes < j->ahead_bytes ? n->out_bytes : j->ahead_bytes;
        run->ahead -= b;
        j->ahead_bytes -= b;
    }
}

typedef struct OutputJob {
    Run *run;
    int index; /* in plan->outputs */
} OutputJob;

/* The key of output k: its node's cache key and its port, hashed. */
static void output_key(const WgPlan *p, int k, uint64_t key[2])
{
    const WgPlanOutput *po = &p->outputs[k];
    uint64_t buf[3] = {p->insts[po->ref.inst].key[0], p->insts[po->ref.inst].key[1],
                       (uint64_t)po->ref.port};
    XXH128_hash_t h = XXH3_128bits(buf, sizeof buf);
    key[0] = h.low64;
    key[1] = h.high64;
}

/* WgOutputInfo.workers: parts as row chunks on the render's workers, every one of them run
 * also when the render is cancelled meanwhile (an output call is never cut short, so that its
 * caller does not take a cancel for a failure); scratch memory from the render's buffer pool
 * (the kind of a buffer follows from its size, as for a node's scratch) */
static int output_run(const void *ctx, int n, void (*fn)(void *user, int i0, int i1), void *user)
{
    const Run *run = ctx;
    return wg__pool_rows(run->e->pool, NULL, n, fn, user);
}

static void *output_alloc(const void *ctx, size_t bytes)
{
    int mapped;
    return wg__mempool_get(((const Run *)ctx)->e->mem, bytes, &mapped);
}

static void output_free(const void *ctx, void *p, size_t bytes)
{
    wg__mempool_release(((const Run *)ctx)->e->mem, p, bytes);
}

static WgOutputInfo output_info(const Run *run, int k)
{
    const WgPlanOutput *po = &run->plan->outputs[k];
    const Node *src = &run->nodes[po->ref.inst];
    WgOutputInfo info = {k,
                         po->name,
                         src->out ? src->out[po->ref.port] : NULL,
                         po->format,
                         po->colorspace,
                         po->compression,
                         {0, 0},
                         {output_run, output_alloc, output_free, run}};
    output_key(run->plan, k, info.key);
    return info;
}

static void output_job(void *user)
{
    OutputJob *j = user;
    Run *run = j->run;
    const WgPlanOutput *po = &run->plan->outputs[j->index];
    Node *src = &run->nodes[po->ref.inst];
    WgOutputInfo info = output_info(run, j->index);
    WgError err = {0};
    int rc = run->cancel ? WG_ERR_CANCELLED : run->r->output_fn(run->r->output_user, &info, &err);
    if (rc && !err.code) rc = wg_error_set(&err, rc, NULL, "writing output '%s' failed", po->name);
    pthread_mutex_lock(&run->mu);
    run->running--;
    run->outputs_left--;
    if (rc) {
        if (run->rc == WG_OK && rc != WG_ERR_CANCELLED) {
            run->rc = rc;
            run->err = err;
        }
        if (rc == WG_ERR_CANCELLED) run->skipped = true;
        run->cancel = 1;
    }
    if (--src->holds == 0 && src->consumers == 0) release(run, po->ref.inst);
    fit_run(run);
    pthread_cond_signal(&run->cv);
    pthread_mutex_unlock(&run->mu);
}

/* With run->mu held: hand the outputs of node `index` (done, or from the cache) to the output
 * function. A job that cannot be submitted fails the render like a node out of memory. */
static void submit_outputs(Run *run, int index)
{
    if (!run->r->output_fn) return;
    for (int k = 0; k < run->plan->n_outputs; k++) {
        if (run->plan->outputs[k].ref.inst != index) continue;
        run->running++;
        if (wg__pool_submit(run->e->pool, output_job, &run->output_jobs[k])) {
            run->running--;
            if (run->rc == WG_OK)
                run->rc = wg_error_set(&run->err, WG_ERR_NOMEM, NULL, "out of memory");
            run->cancel = 1;
        }
    }
}

static void node_job(void *user)
{
    Node *node = user;
    Run *run = node->run;
    WgError err = {0};
    double t0 = wg__now_ms();
    int rc = run->cancel       ? WG_ERR_CANCELLED
             : node->n_members ? eval_group(run, node, &err)
                               : eval_node(run, node, &err);
    double ms = wg__now_ms() - t0;
    /* one job, many nodes: the group's members (or the node alone) */
    int n_members = node->n_members ? node->n_members : 1;
    const int *members = node->n_members ? node->members : &node->index;
    if (node->n_members) { /* the group's time, shared as the members' own times were */
        double sum = 0;
        for (int k = 0; k < n_members; k++) sum += run->nodes[members[k]].stat.ms;
        for (int k = 0; k < n_members; k++) {
            WgNodeStat *st = &run->nodes[members[k]].stat;
            st->ms = sum > 0 ? ms * (st->ms / sum) : ms / n_members;
        }
    } else {
        node->stat.ms = ms;
    }
    /* what the job materialised: the node, or its group's whole members */
    size_t made = 0;
    for (int m = 0; m < n_members && !rc; m++) {
        Node *mn = &run->nodes[members[m]];
        const WgInst *mi = &run->plan->insts[members[m]];
        if (node->n_members && !mn->whole) continue;
        made += mn->out_bytes;
        for (int o = 0; o < mi->n_out; o++) {
            if (run->e->memory_cache) wg__cache_put(run->e->cache, mi->key, o, mn->out[o]);
            if (disk_stores(run, mn, mi)) wg__cache_disk_put(run->e->cache, mi->key, o, mn->out[o]);
        }
    }
    pthread_mutex_lock(&run->mu);
    run->running--;
    run->running_parallel -= node->parallel;
    run->completed += n_members;
    run->last_done = node->index; /* named by the progress callback */
    node->done = true;
    if (rc) {
        if (run->rc == WG_OK && rc != WG_ERR_CANCELLED) {
            run->rc = rc;
            run->err = err;
        }
        if (rc == WG_ERR_CANCELLED) run->skipped = true;
        run->cancel = 1;
        run->live -= node->need;
    } else {
        run->live -= node->need - made;
        if (node->ahead) {
            run->ahead -= node->ahead_bytes - made;
            node->ahead_bytes = made;
        }
        for (int m = 0; m < n_members; m++) {
            const WgInst *mi = &run->plan->insts[members[m]];
            for (int i = 0; i < mi->n_in; i++) {
                int src = mi->in[i].inst;
                if (src < 0) continue;
                if (--run->nodes[src].consumers == 0) release(run, src);
            }
        }
        for (int k = 0; k < node->n_dependents; k++) {
            Node *d = &run->nodes[node->dependents[k]];
            if (--d->pending == 0) ready_push(run, node->dependents[k]);
        }
        for (int m = 0; m < n_members; m++)
            if (run->nodes[members[m]].requested) submit_outputs(run, members[m]);
        for (int m = 0; m < n_members; m++)
            if (run->nodes[members[m]].consumers == 0) release(run, members[m]);
    }
    /* The cache and the pool may hold what the working set leaves of the budget (images in the
     * cache and the working set are counted twice, so this errs towards evicting). */
    fit_run(run);
    pthread_cond_signal(&run->cv);
    pthread_mutex_unlock(&run->mu);
}

/* ---- planning ---------------------------------------------------------------------------- */

static size_t inst_bytes(const WgInst *in)
{
    size_t b = 0;
    int rows = in->type->flags & WG_NODE_UNIFORM ? 1 : in->height; /* one row for all */
    for (int o = 0; o < in->n_out; o++)
        b += wg_image_bytes_for(in->width, rows, in->out_channels[o]);
    return b;
}

/* Bytes wg_image_convert holds at once converting a sw x sh x sc image to w x h x c, the
 * result included: the resampling's horizontal pass, its result, its filter taps, and the
 * channel conversion. */
static size_t convert_bytes(int sw, int sh, int sc, int w, int h, int c)
{
    if (sw == w && sh == h) return wg_image_bytes_for(w, h, c);
    size_t tx = (size_t)(2 * (sw / w) + 5), ty = (size_t)(2 * (sh / h) + 5);
    size_t b = wg_image_bytes_for(w, sh, sc) + wg_image_bytes_for(w, h, sc) +
               (tx * (size_t)w + ty * (size_t)h) * (sizeof(int) + sizeof(float));
    return sc == c ? b : b + wg_image_bytes_for(w, h, c);
}

/* What eval_node holds while the node runs, beside its inputs (fuse.c weighs groups by it). */
size_t wg__inst_need(const WgPlan *p, const WgInst *in)
{
    const WgNodeType *t = in->type;
    size_t need = inst_bytes(in);
    if (in->constant) {
        const WgImage *c = in->constant;
        size_t b = convert_bytes(c->width, c->height, c->channels, in->width, in->height,
                                 in->out_channels[0]);
        return b > need ? b : need;
    }
    int n_fixed = 0;
    while (t->inputs && t->inputs[n_fixed].name) n_fixed++;
    for (int i = 0; i < in->n_in; i++) {
        if (in->in[i].inst < 0) continue;
        const WgInst *src = &p->insts[in->in[i].inst];
        int sc = src->out_channels[in->in[i].port], want = sc;
        if (i < n_fixed && t->inputs[i].kind == WG_COLOR) want = 4;
        if (src->width != in->width || src->height != in->height || sc != want)
            need += convert_bytes(src->width, src->height, sc, in->width, in->height, want);
    }
    if (t->scratch_bytes) {
        WgNodeContext ctx = wg__inst_context(in);
        need += t->scratch_bytes(&ctx);
    }
    return need;
}

static bool lookup_cache(Run *run, int i)
{
    WgInst *in = &run->plan->insts[i];
    Node *n = &run->nodes[i];
    WgCache *c = run->e->cache;
    bool all = true;
    for (int o = 0; o < in->n_out && all; o++) all = (n->out[o] = wg__cache_get(c, in->key, o));
    if (all) {
        n->stat.cache = WG_HIT_MEMORY;
        return true;
    }
    for (int o = 0; o < in->n_out; o++) {
        wg_image_unref(n->out[o]);
        n->out[o] = NULL;
    }
    if (!wg__cache_has_disk(c) || !disk_cacheable(in)) return false;
    all = true;
    for (int o = 0; o < in->n_out && all; o++)
        all = (n->out[o] =
                   wg__cache_disk_get(c, in->key, o, in->width, in->height, in->out_channels[o],
                                      in->type->flags & WG_NODE_UNIFORM));
    if (all) {
        if (run->e->memory_cache)
            for (int o = 0; o < in->n_out; o++) wg__cache_put(c, in->key, o, n->out[o]);
        n->stat.cache = WG_HIT_DISK;
        run->disk_hits = true;
        return true;
    }
    for (int o = 0; o < in->n_out; o++) {
        wg_image_unref(n->out[o]);
        n->out[o] = NULL;
    }
    return false;
}

/* Which evaluations run fused (fuse.c): each group's members, numbers and jobs. */
static int plan_fusion(Run *run, WgError *err)
{
    WgPlan *p = run->plan;
    int n = p->n_insts, rc = WG_OK;
    for (int i = 0; i < n; i++) run->nodes[i].job = i;
    if (!run->fuse) return WG_OK;
    bool *flags = wg_calloc(3 * (size_t)n + 1, sizeof(bool));
    int *sink = wg_calloc((size_t)n + 1, sizeof(int));
    int groups = -1;
    if (flags && sink) {
        for (int i = 0; i < n; i++) {
            flags[i] = run->nodes[i].evaluate;
            flags[n + i] = run->nodes[i].requested;
        }
        groups = wg__fuse_find(p, flags, flags + n, sink, flags + 2 * (size_t)n);
    }
    size_t total = 0;
    for (int i = 0; i < n && groups > 0; i++)
        if (sink[i] >= 0) {
            run->nodes[sink[i]].n_members++;
            total++;
        }
    if (groups > 0 && !(run->members = wg_calloc(total + 1, sizeof(int)))) groups = -1;
    if (groups < 0) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    } else if (groups > 0) {
        size_t at = 0;
        int number = 0;
        for (int i = 0; i < n; i++) {
            Node *s = &run->nodes[i];
            if (sink[i] != i) continue;
            s->members = run->members + at;
            at += (size_t)s->n_members;
            s->n_members = 0;
            s->stat.fused = ++number;
        }
        for (int i = 0; i < n; i++) { /* in plan order: the sink comes last */
            if (sink[i] < 0) continue;
            Node *m = &run->nodes[i], *s = &run->nodes[sink[i]];
            s->members[s->n_members++] = i;
            m->stat.fused = s->stat.fused;
            m->job = sink[i];
            m->whole = flags[2 * (size_t)n + i];
            if (i != sink[i]) m->fused = true;
            if (!m->whole) m->out_bytes = 0; /* only in bands */
        }
    }
    wg_free(flags);
    wg_free(sink);
    return rc;
}

/* What a job holds while it runs, beside its inputs: a node's need, or for a fused group its
 * members' needs without the intermediates' images (the band buffers are fixed overhead, like
 * other per-band rows: their size does not grow with the image, docs/engine.md). */
static size_t job_need(Run *run, int i)
{
    const WgPlan *p = run->plan;
    Node *n = &run->nodes[i];
    if (!n->n_members) return wg__inst_need(p, &p->insts[i]);
    size_t need = 0;
    for (int k = 0; k < n->n_members; k++) {
        const WgInst *m = &p->insts[n->members[k]];
        need += wg__inst_need(p, m) - (run->nodes[n->members[k]].whole ? 0 : inst_bytes(m));
    }
    return need;
}

/* Jobs are ordered greedily for memory when there are at most this many; beyond it the
 * quadratic search would cost more than it saves, and plan order is kept. */
#define ORDER_LIMIT 2000
/* ... and improved by moving jobs (sink_jobs) when there are at most this many (each try is a
 * run of the whole order). */
#define SINK_LIMIT 300

static bool is_job(const Node *n)
{
    return n->evaluate && !n->fused;
}

/* Bytes that running job i frees: its inputs (of all its members) that no other evaluation
 * reads afterwards; left[] holds how many reads each node still has. */
static size_t job_frees(Run *run, int i, int *left)
{
    const WgPlan *p = run->plan;
    Node *n = &run->nodes[i];
    size_t freed = 0;
    for (int pass = 0; pass < 2; pass++)
        for (int m = 0; m < (n->n_members ? n->n_members : 1); m++) {
            const WgInst *mi = &p->insts[n->n_members ? n->members[m] : i];
            for (int k = 0; k < mi->n_in; k++) {
                int src = mi->in[k].inst;
                if (src < 0) continue;
                if (pass == 1) { /* put the counts back */
                    left[src]++;
                    continue;
                }
                if (--left[src] == 0 && !keeps(run, &run->nodes[src]))
                    freed += run->nodes[src].out_bytes;
            }
        }
    return freed;
}

/* The peak of a sequential run of the `count` jobs of `order`, as plan_work counts it;
 * left[] is scratch. */
static size_t order_peak(Run *run, const int *order, int count, int *left)
{
    const WgPlan *p = run->plan;
    size_t live = 0, peak = 0;
    for (int i = 0; i < p->n_insts; i++) {
        left[i] = run->nodes[i].consumers;
        if (run->nodes[i].needed && !run->nodes[i].evaluate) live += run->nodes[i].out_bytes;
    }
    peak = live;
    for (int r = 0; r < count; r++) {
        Node *n = &run->nodes[order[r]];
        /* a job materialises its node, or its group's members that have bytes */
        int n_members = n->n_members ? n->n_members : 1;
        const int *members = n->n_members ? n->members : &order[r];
        if (live + n->need > peak) peak = live + n->need;
        for (int m = 0; m < n_members; m++) live += run->nodes[members[m]].out_bytes;
        for (int m = 0; m < n_members; m++) {
            const WgInst *mi = &p->insts[members[m]];
            for (int k = 0; k < mi->n_in; k++) {
                int src = mi->in[k].inst;
                if (src >= 0 && --left[src] == 0 && !keeps(run, &run->nodes[src]))
                    live -= run->nodes[src].out_bytes;
            }
        }
        for (int m = 0; m < n_members; m++) {
            const Node *mn = &run->nodes[members[m]];
            if (mn->consumers == 0 && !keeps(run, mn)) live -= mn->out_bytes;
        }
    }
    return peak;
}

/* The greedy order looks one step ahead only: it may make an image early that waits long for a
 * consumer whose other inputs come much later (a normal map made before the base colour's whole
 * branch, read only at the end with a picture decoded last). So each job in turn is tried right
 * before its first consumer instead, and kept there when that lowers the peak; a few passes. */
static void sink_jobs(Run *run, int *order, int count, int *left, int *trial)
{
    size_t best = order_peak(run, order, count, left);
    for (int pass = 0; pass < 3; pass++) {
        bool moved = false;
        for (int r = 0; r < count; r++) {
            Node *n = &run->nodes[order[r]];
            int first = count; /* the place of its first consumer */
            for (int k = 0; k < n->n_dependents; k++)
                for (int q = r + 1; q < first; q++)
                    if (order[q] == n->dependents[k]) first = q;
            if (first == count || first == r + 1) continue;
            memcpy(trial, order, (size_t)count * sizeof *trial);
            memmove(trial + r, trial + r + 1, (size_t)(first - 1 - r) * sizeof *trial);
            trial[first - 1] = order[r];
            size_t peak = order_peak(run, trial, count, left);
            if (peak < best) {
                best = peak;
                memcpy(order, trial, (size_t)count * sizeof *trial);
                moved = true;
                r--; /* another job is at place r now */
            }
        }
        if (!moved) break;
    }
}

/* The order of the sequential run the memory guarantee is built on, which is also the order
 * the scheduler prefers among ready jobs. Plan order (the file's order, subgraphs in place)
 * makes every input image first and keeps it until its last reader, however late; instead,
 * each step takes, among the jobs whose inputs are done, the one whose run leaves the least
 * memory held (its output, unless no one reads it and it is handed over, less the inputs it is
 * the last to read), the earliest in plan order on ties. So outputs that are written and let
 * go of run early and free their inputs, and large sources wait until they are needed. The
 * images are the same in any order. */
static int plan_order(Run *run, int *left, WgError *err)
{
    const WgPlan *p = run->plan;
    int n = p->n_insts, jobs = 0;
    for (int i = 0; i < n; i++) {
        run->rank[i] = run->by_rank[i] = i;
        jobs += is_job(&run->nodes[i]);
    }
    if (jobs > ORDER_LIMIT) return WG_OK;
    int *pend = wg_calloc((size_t)n + 1, sizeof(int));
    bool *placed = wg_calloc((size_t)n + 1, sizeof(bool));
    if (!pend || !placed) {
        wg_free(pend);
        wg_free(placed);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    for (int i = 0; i < n; i++) {
        left[i] = run->nodes[i].consumers;
        pend[i] = run->nodes[i].pending;
    }
    int at = 0;
    for (int step = 0; step < jobs; step++) {
        int best = -1;
        long long best_delta = 0;
        for (int i = 0; i < n; i++) {
            Node *c = &run->nodes[i];
            if (!is_job(c) || placed[i] || pend[i]) continue;
            size_t own = 0; /* what it materialises that is read later or kept */
            for (int m = 0; m < (c->n_members ? c->n_members : 1); m++) {
                const Node *mn = &run->nodes[c->n_members ? c->members[m] : i];
                if (mn->consumers > 0 || keeps(run, mn)) own += mn->out_bytes;
            }
            long long delta = (long long)own - (long long)job_frees(run, i, left);
            if (best < 0 || delta < best_delta) {
                best = i;
                best_delta = delta;
            }
        }
        if (best < 0) break; /* cannot happen: the plan is acyclic */
        Node *b = &run->nodes[best];
        placed[best] = true;
        run->by_rank[at++] = best;
        for (int m = 0; m < (b->n_members ? b->n_members : 1); m++) {
            const WgInst *mi = &p->insts[b->n_members ? b->members[m] : best];
            for (int k = 0; k < mi->n_in; k++)
                if (mi->in[k].inst >= 0) left[mi->in[k].inst]--;
        }
        for (int k = 0; k < b->n_dependents; k++) pend[b->dependents[k]]--;
    }
    int *trial = at == jobs && jobs <= SINK_LIMIT ? wg_calloc((size_t)jobs + 1, sizeof(int)) : NULL;
    if (trial) {
        for (int i = 0; i < n; i++)
            if (is_job(&run->nodes[i])) run->nodes[i].need = job_need(run, i);
        sink_jobs(run, run->by_rank, jobs, left, trial);
        wg_free(trial);
    }
    if (at == jobs) { /* the other nodes after the jobs, in plan order */
        for (int i = 0; i < n; i++)
            if (!placed[i]) run->by_rank[at++] = i;
        for (int r = 0; r < n; r++) run->rank[run->by_rank[r]] = r;
    } else {
        for (int i = 0; i < n; i++) run->rank[i] = run->by_rank[i] = i;
    }
    wg_free(pend);
    wg_free(placed);
    return WG_OK;
}

/* The jobs of the work (fused groups, their dependents), their order and the sequential peak
 * run->need; done again by plan_work without fusion, undone by unplan_jobs. */
static int plan_jobs(Run *run, WgError *err)
{
    WgPlan *p = run->plan;
    int rc = plan_fusion(run, err);
    if (rc) return rc;
    /* dependents lists: counted, then laid out in one array and filled */
    size_t n_edges = 0;
    for (int i = 0; i < p->n_insts; i++) {
        Node *n = &run->nodes[i];
        WgInst *in = &p->insts[i];
        if (!n->evaluate) continue;
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst;
            if (s < 0) continue;
            run->nodes[s].consumers++;
            int js = run->nodes[s].job;
            if (run->nodes[s].evaluate && js != n->job) { /* else within n's group */
                run->nodes[n->job].pending++;
                run->nodes[js].n_dependents++;
                n_edges++;
            }
        }
    }
    run->dependents = wg_calloc(n_edges + 1, sizeof(int));
    if (!run->dependents) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    size_t at = 0;
    for (int i = 0; i < p->n_insts; i++) {
        run->nodes[i].dependents = run->dependents + at;
        at += (size_t)run->nodes[i].n_dependents;
        run->nodes[i].n_dependents = 0;
    }
    for (int i = 0; i < p->n_insts; i++) {
        WgInst *in = &p->insts[i];
        if (!run->nodes[i].evaluate) continue;
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst;
            int js = s < 0 ? -1 : run->nodes[s].job;
            if (s >= 0 && run->nodes[s].evaluate && js != run->nodes[i].job)
                run->nodes[js].dependents[run->nodes[js].n_dependents++] = run->nodes[i].job;
        }
    }
    /* Peak memory of a sequential run in plan order: what node i holds while it runs plus the
     * outputs alive then. No schedule needs less, so a render that cannot fit fails here,
     * before any work; the scheduler keeps every schedule within it (see Run.seq_peak). */
    size_t live = 0, peak = 0;
    int *left = wg_calloc((size_t)p->n_insts + 1, sizeof(int));
    if (!left) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    int biggest = -1, largest = -1;
    size_t biggest_bytes = 0;
    rc = plan_order(run, left, err);
    if (rc) {
        wg_free(left);
        return rc;
    }
    for (int i = 0; i < p->n_insts; i++) {
        left[i] = run->nodes[i].consumers;
        if (run->nodes[i].needed && !run->nodes[i].evaluate) live += run->nodes[i].out_bytes;
    }
    peak = live;
    for (int r = 0; r < p->n_insts; r++) {
        int i = run->by_rank[r];
        Node *n = &run->nodes[i];
        if (!n->evaluate || n->fused) continue; /* a group runs at its sink's place */
        WgInst *in = &p->insts[i];
        n->need = job_need(run, i);
        size_t own = n->need; /* its inputs too */
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst;
            bool repeated = false;
            for (int q = 0; q < k && !repeated; q++) repeated = in->in[q].inst == s;
            if (s >= 0 && !repeated) own += run->nodes[s].out_bytes;
        }
        if (largest < 0 || n->out_bytes > run->nodes[largest].out_bytes) largest = i;
        if (biggest < 0 || own > biggest_bytes) {
            biggest = i;
            biggest_bytes = own;
        }
        run->seq_peak[r] = live + n->need;
        if (live + n->need > peak) peak = live + n->need;
        int n_members = n->n_members ? n->n_members : 1;
        const int *members = n->n_members ? n->members : &n->index;
        for (int m = 0; m < n_members; m++) live += run->nodes[members[m]].out_bytes;
        for (int m = 0; m < n_members; m++) {
            const WgInst *mi = &p->insts[members[m]];
            for (int k = 0; k < mi->n_in; k++) {
                int s = mi->in[k].inst;
                if (s >= 0 && --left[s] == 0 && !keeps(run, &run->nodes[s]))
                    live -= run->nodes[s].out_bytes;
            }
        }
        for (int m = 0; m < n_members; m++) {
            const Node *mn = &run->nodes[members[m]];
            if (mn->consumers == 0 && !keeps(run, mn)) live -= mn->out_bytes;
        }
    }
    wg_free(left);
    for (int r = p->n_insts - 1, after = -1; r >= 0; r--) { /* from place r on */
        size_t later = after >= 0 ? run->seq_peak[after] : 0;
        const Node *n = &run->nodes[run->by_rank[r]];
        if (!n->evaluate || n->fused) {
            run->seq_peak[r] = later;
            continue;
        }
        if (later > run->seq_peak[r]) run->seq_peak[r] = later;
        after = r;
    }
    run->need = peak;
    run->biggest = biggest, run->largest = largest, run->biggest_bytes = biggest_bytes;
    return WG_OK;
}

/* What plan_jobs set, back to before it: every node a job of its own again. */
static void unplan_jobs(Run *run)
{
    const WgPlan *p = run->plan;
    for (int i = 0; i < p->n_insts; i++) {
        Node *n = &run->nodes[i];
        n->job = i;
        n->members = NULL;
        n->n_members = 0;
        n->fused = n->whole = false;
        n->stat.fused = 0;
        n->consumers = n->pending = n->n_dependents = 0;
        n->dependents = NULL;
        n->need = 0;
        if (n->needed) n->out_bytes = inst_bytes(&p->insts[i]);
    }
    wg_free(run->members);
    wg_free(run->dependents);
    run->members = NULL;
    run->dependents = NULL;
    memset(run->seq_peak, 0, sizeof(size_t) * (size_t)p->n_insts);
}

/* Does the caller hold every output node i makes (wg_request_set_output_held)? Then the node is
 * left out: not needed, its output calls not made. */
static bool held_by_caller(Run *run, int i)
{
    const WgRequest *r = run->r;
    if (!r->held_fn || !r->output_fn) return false;
    WgPlan *p = run->plan;
    int count = 0;
    for (int k = 0; k < p->n_outputs; k++) {
        if (p->outputs[k].ref.inst != i) continue;
        WgOutputInfo info = output_info(run, k);
        if (!r->held_fn(r->held_user, &info)) return false;
        count++;
    }
    if (count == 0) return false;
    Node *n = &run->nodes[i];
    n->held = true;
    n->needed = false;
    n->stat.cache = WG_HELD;
    n->holds -= count; /* no output call will read it */
    run->outputs_left -= count;
    return true;
}

static int plan_work(Run *run, WgError *err)
{
    WgPlan *p = run->plan;
    for (int k = 0; k < p->n_outputs; k++) {
        run->nodes[p->outputs[k].ref.inst].needed = true;
        run->nodes[p->outputs[k].ref.inst].requested = true;
    }
    for (int i = p->n_insts - 1; i >= 0; i--) {
        Node *n = &run->nodes[i];
        WgInst *in = &p->insts[i];
        if (!n->needed) continue;
        if (n->requested && !n->feeds && held_by_caller(run, i)) continue;
        n->out_bytes = inst_bytes(in);
        if (!in->constant && lookup_cache(run, i)) continue;
        n->evaluate = true;
        run->total++;
        for (int k = 0; k < in->n_in; k++)
            if (in->in[k].inst >= 0) {
                run->nodes[in->in[k].inst].needed = true;
                run->nodes[in->in[k].inst].feeds = true;
            }
    }
    int rc = plan_jobs(run, err);
    /* Fused groups that raise the peak in the order the scheduler runs the jobs are given up:
     * a group materialises its members together, where the unfused order can free one image
     * before the next is made. The jobs are planned both ways and stay fused when that needs at
     * most one image more (the largest of the render) than unfused: a group that only moves
     * when one image is freed keeps its bands, groups that hold several more images at once
     * (the wet material's, 10 float planes more) run unfused. */
    if (!rc && run->fuse && run->members) {
        size_t fused = run->need;
        unplan_jobs(run);
        run->fuse = false;
        rc = plan_jobs(run, err);
        size_t slack = run->largest >= 0 ? run->nodes[run->largest].out_bytes : 0;
        if (!rc && fused <= run->need + slack && fused <= run->e->budget) {
            unplan_jobs(run);
            run->fuse = true;
            rc = plan_jobs(run, err);
        }
    }
    if (rc) return rc;
    size_t peak = run->need;
    int biggest = run->biggest, largest = run->largest;
    size_t biggest_bytes = run->biggest_bytes;
    if (peak > run->e->budget) {
        char detail[1024] = "";
        if (biggest >= 0) {
            const WgInst *l = &p->insts[largest], *b = &p->insts[biggest];
            snprintf(detail, sizeof detail,
                     "; the largest image is node '%s' (%.1f MiB); the largest need of one node is "
                     "'%s' (%s): %.1f MiB for its inputs, outputs and working memory",
                     l->id, run->nodes[largest].out_bytes / 1048576.0, b->id, b->type->name,
                     biggest_bytes / 1048576.0);
        }
        return wg_error_set(err, WG_ERR_BUDGET, NULL,
                            "this render needs at least %.1f MiB of image memory but the budget "
                            "is %.1f MiB (--memory-budget)%s",
                            peak / 1048576.0, run->e->budget / 1048576.0, detail);
    }
    return WG_OK;
}

/* ---- render ------------------------------------------------------------------------------ */

double wg_result_gltf_height_scale(const WgResult *r, int i)
{
    return r && i >= 0 && i < r->n_gltfs ? r->gltf_height_scales[i] : 0;
}

void wg_result_free(WgResult *r)
{
    if (!r) return;
    for (int i = 0; i < r->n_outputs; i++) {
        wg_free(r->names[i]);
        wg_image_unref(r->images[i]);
    }
    wg_free(r->names);
    wg_free(r->images);
    wg_free(r->formats);
    wg_free(r->colorspaces);
    wg_free(r->compressions);
    for (int i = 0; i < r->n_stats; i++) wg_free((char *)r->stats[i].id);
    wg_free(r->stats);
    wg_warnings_free(r->warnings, r->n_warnings);
    wg_free(r->gltf_height_scales);
    wg_free(r);
}

static int collect(Run *run, WgResult **out, double t0, WgError *err)
{
    WgPlan *p = run->plan;
    WgResult *r = wg_calloc(1, sizeof *r);
    if (!r) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    r->n_outputs = p->n_outputs;
    r->names = wg_calloc((size_t)p->n_outputs + 1, sizeof(char *));
    r->images = wg_calloc((size_t)p->n_outputs + 1, sizeof(WgImage *));
    r->formats = wg_calloc((size_t)p->n_outputs + 1, sizeof(WgFormat));
    r->colorspaces = wg_calloc((size_t)p->n_outputs + 1, sizeof(WgColorspace));
    r->compressions = wg_calloc((size_t)p->n_outputs + 1, sizeof(WgPngCompression));
    r->stats = wg_calloc((size_t)p->n_insts + 1, sizeof(WgNodeStat));
    if (!r->names || !r->images || !r->formats || !r->colorspaces || !r->compressions ||
        !r->stats) {
        r->n_outputs = 0;
        wg_result_free(r);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    bool ok = true;
    for (int k = 0; k < p->n_outputs; k++) {
        WgPlanOutput *po = &p->outputs[k];
        ok &= (r->names[k] = wg_strdup(po->name)) != NULL;
        if (!run->r->output_fn)
            r->images[k] = wg_image_ref(run->nodes[po->ref.inst].out[po->ref.port]);
        r->formats[k] = po->format;
        r->colorspaces[k] = po->colorspace;
        r->compressions[k] = po->compression;
    }
    for (int i = 0; i < p->n_insts; i++) {
        Node *n = &run->nodes[i];
        if (!n->needed && !n->held) continue;
        WgInst *in = &p->insts[i];
        WgNodeStat *s = &r->stats[r->n_stats++];
        *s = n->stat;
        ok &= (s->id = wg_strdup(in->id)) != NULL;
        s->type = in->type->name;
        s->width = in->width;
        s->height = in->height;
        s->channels = in->out_channels[0];
        s->bytes = n->out_bytes;
        r->evaluated += n->evaluate;
    }
    if (!ok) {
        wg_result_free(r);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    r->peak = run->peak;
    r->total_ms = wg__now_ms() - t0;
    r->warnings = p->warnings;
    r->n_warnings = p->n_warnings;
    p->warnings = NULL;
    p->n_warnings = 0;
    r->gltf_height_scales = p->gltf_height_scales;
    r->n_gltfs = p->n_gltfs;
    p->gltf_height_scales = NULL;
    *out = r;
    return WG_OK;
}

static int render(WgEngine *e, const WgRequest *req, bool fuse, WgResult **out, size_t *need,
                  WgError *err)
{
    double t0 = wg__now_ms();
    *out = NULL;
    if (req->cancel && wg_cancel_requested(req->cancel)) return cancelled_error(err);
    WgPlan *plan = wg_calloc(1, sizeof *plan);
    if (!plan) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    int rc = wg__plan_build(req, plan, err);
    if (rc) {
        wg_free(plan);
        return rc;
    }
    Run run = {.e = e, .r = req, .plan = plan, .fuse = fuse};
    pthread_mutex_init(&run.mu, NULL);
    pthread_cond_init(&run.cv, NULL);
    token_register(&run, req->cancel);
    run.nodes = wg_calloc((size_t)plan->n_insts + 1, sizeof(Node));
    run.ready_storage = wg_calloc(2 * ((size_t)plan->n_insts + 1), sizeof(int));
    run.ready[0].h = run.ready_storage;
    run.ready[1].h = run.ready_storage ? run.ready_storage + plan->n_insts + 1 : NULL;
    run.seq_peak = wg_calloc((size_t)plan->n_insts + 1, sizeof(size_t));
    run.rank = wg_calloc(2 * ((size_t)plan->n_insts + 1), sizeof(int));
    run.by_rank = run.rank ? run.rank + plan->n_insts + 1 : NULL;
    run.output_jobs = wg_calloc((size_t)plan->n_outputs + 1, sizeof(OutputJob));
    if (!run.nodes || !run.ready_storage || !run.seq_peak || !run.output_jobs || !run.rank) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto done;
    }
    for (int i = 0; i < plan->n_insts; i++) {
        run.nodes[i].run = &run;
        run.nodes[i].index = i;
        run.nodes[i].out = wg_calloc((size_t)plan->insts[i].n_out + 1, sizeof(WgImage *));
        if (!run.nodes[i].out) {
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
            goto done;
        }
    }
    if (req->output_fn)
        for (int k = 0; k < plan->n_outputs; k++) {
            run.output_jobs[k] = (OutputJob){&run, k};
            run.nodes[plan->outputs[k].ref.inst].holds++;
            run.outputs_left++;
        }
    if ((rc = plan_work(&run, err))) goto done;
    for (int i = 0; i < plan->n_insts; i++)
        if (run.nodes[i].needed && !run.nodes[i].evaluate) run.live += run.nodes[i].out_bytes;
    run.peak = run.live;
    pthread_mutex_lock(&run.mu); /* outputs that are cache hits go first */
    for (int i = 0; i < plan->n_insts; i++)
        if (run.nodes[i].requested && !run.nodes[i].evaluate && !run.nodes[i].held)
            submit_outputs(&run, i);
    pthread_mutex_unlock(&run.mu);
    for (int i = 0; i < plan->n_insts; i++)
        if (run.nodes[i].evaluate && !run.nodes[i].fused && run.nodes[i].pending == 0)
            ready_push(&run, i);

    /* Starting a job ahead of the frontier must not take the render past what the sequential
     * run needs: overlap uses the room below that peak, never more memory than the budget or
     * than rendering in order would take. */
    run.ceiling = run.need < e->budget ? run.need : e->budget;
    int reported = 0;
    pthread_mutex_lock(&run.mu);
    while (run.completed < run.total || run.outputs_left > 0) {
        while (!run.cancel && run.ready[0].n + run.ready[1].n > 0) {
            while (run.frontier < plan->n_insts &&
                   (!run.nodes[run.by_rank[run.frontier]].evaluate ||
                    run.nodes[run.by_rank[run.frontier]].started ||
                    run.nodes[run.by_rank[run.frontier]].fused)) {
                Node *f = &run.nodes[run.by_rank[run.frontier++]];
                if (f->ahead) { /* now in plan order: covered by seq_peak */
                    run.ahead -= f->ahead_bytes;
                    f->ahead = false;
                    f->ahead_bytes = 0;
                }
            }
            /* Row-parallel nodes run one at a time, each on every worker: the same work in no
             * more wall time than running several side by side, with fewer images alive at
             * once, and each node's time is its real latency. Serial nodes (file decoding) run
             * beside them on the workers the row chunks leave: while a parallel node runs, the
             * first ready serial one may start. */
            Heap *from = &run.ready[1];
            if (run.running_parallel > 0) {
                if (from->n == 0) break;
            } else if (from->n == 0 || (run.ready[0].n > 0 && run.ready[0].h[0] < from->h[0])) {
                from = &run.ready[0];
            }
            Node *n = &run.nodes[run.by_rank[from->h[0]]];
            bool parallel = from == &run.ready[0];
            bool ahead = run.rank[n->index] != run.frontier;
            size_t after = run.live + n->need;
            /* wait for memory; the frontier node can always run once the others are done */
            if (run.running > 0 &&
                (after > run.ceiling ||
                 (ahead && run.ahead + n->need + run.seq_peak[run.frontier] > run.ceiling)))
                break;
            /* make room: the cache and the pool keep only what the working set leaves */
            fit_budget(e, after);
            heap_pop(from);
            run.running++;
            run.running_parallel += parallel;
            n->parallel = parallel;
            run.live = after;
            n->started = true;
            if (ahead) {
                n->ahead = true;
                n->ahead_bytes = n->need;
                run.ahead += n->need;
            }
            if (run.live > run.peak) run.peak = run.live;
            if (wg__pool_submit(e->pool, node_job, n)) { /* fails like a node that ran out */
                run.running--;
                run.live -= n->need;
                if (run.rc == WG_OK)
                    run.rc = wg_error_set(&run.err, WG_ERR_NOMEM, NULL, "out of memory");
                run.cancel = 1;
            }
        }
        if (run.cancel && run.running == 0) break;
        int before = run.completed;
        pthread_cond_wait(&run.cv, &run.mu);
        if (req->progress && run.completed != before && !run.cancel) { /* not past a cancel */
            int done = run.completed, total = run.total;
            const char *id = plan->insts[run.last_done].id; /* the plan outlives the call */
            reported = done;
            pthread_mutex_unlock(&run.mu);
            req->progress(req->progress_user, done, total, id);
            pthread_mutex_lock(&run.mu);
        }
    }
    /* cancelled by the token (not by a failing node) before every node had run */
    if (run.rc == WG_OK && run.cancel && (run.skipped || run.completed < run.total))
        run.rc = cancelled_error(&run.err);
    pthread_mutex_unlock(&run.mu);
    /* the last nodes may have finished while the callback ran: always end on done == total */
    if (req->progress && !run.rc && reported < run.total)
        req->progress(req->progress_user, run.total, run.total, NULL);
    if (run.rc) {
        rc = run.rc;
        if (err) *err = run.err;
        goto done;
    }
    rc = collect(&run, out, t0, err);
done:
    if (run.nodes) {
        for (int i = 0; i < plan->n_insts; i++) {
            if (run.nodes[i].out)
                for (int o = 0; o < plan->insts[i].n_out; o++) wg_image_unref(run.nodes[i].out[o]);
            wg_free(run.nodes[i].out);
        }
    }
    /* the result's images stay alive with the result: the cache keeps what they leave */
    size_t kept = 0;
    if (rc == WG_OK)
        for (int k = 0; k < plan->n_outputs; k++)
            if (wg_result_output_image(*out, k))
                kept += wg_image_bytes(wg_result_output_image(*out, k));
    fit_budget(e, kept);
    token_unregister(&run);
    wg_free(run.nodes);
    wg_free(run.ready_storage);
    wg_free(run.dependents);
    wg_free(run.members);
    wg_free(run.seq_peak);
    wg_free(run.rank);
    wg_free(run.output_jobs);
    pthread_mutex_destroy(&run.mu);
    pthread_cond_destroy(&run.cv);
    *need = run.need;
    wg__plan_free(plan);
    wg_free(plan);
    return rc;
}

int wg_render(WgEngine *e, const WgRequest *req, WgResult **out, WgError *err)
{
    size_t need = 0, unfused = 0;
    int rc = render(e, req, e->fuse, out, &need, err);
    /* A group keeps its inputs until its sink has run: where a chain's ends are larger than
     * its middle, fused needs more than unfused. Nothing has run yet when the plan is refused:
     * try again unfused, which may fit; if neither fits, report the smaller need. */
    if (rc == WG_ERR_BUDGET && e->fuse) {
        WgError fused = err ? *err : (WgError){0};
        rc = render(e, req, false, out, &unfused, err);
        if (rc == WG_ERR_BUDGET && err && need < unfused) *err = fused;
    }
    return rc;
}

int wg_result_output_count(const WgResult *r)
{
    return r->n_outputs;
}
const char *wg_result_output_name(const WgResult *r, int i)
{
    return r->names[i];
}
const WgImage *wg_result_output_image(const WgResult *r, int i)
{
    return r->images[i];
}
WgFormat wg_result_output_format(const WgResult *r, int i)
{
    return r->formats[i];
}
WgColorspace wg_result_output_colorspace(const WgResult *r, int i)
{
    return r->colorspaces[i];
}
WgPngCompression wg_result_output_compression(const WgResult *r, int i)
{
    return r->compressions[i];
}
int wg_result_stat_count(const WgResult *r)
{
    return r->n_stats;
}
const WgNodeStat *wg_result_stat(const WgResult *r, int i)
{
    return &r->stats[i];
}
int wg_result_evaluated_count(const WgResult *r)
{
    return r->evaluated;
}
size_t wg_result_peak_bytes(const WgResult *r)
{
    return r->peak;
}
double wg_result_total_ms(const WgResult *r)
{
    return r->total_ms;
}
int wg_result_warning_count(const WgResult *r)
{
    return r->n_warnings;
}
const WgWarning *wg_result_warning(const WgResult *r, int i)
{
    return &r->warnings[i];
}
