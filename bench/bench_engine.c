/* SPDX-License-Identifier: MIT */
/* The engine's own costs around the nodes: what a node pays for its output memory. Prints one
 * memcpy of a gray image of the size (into fresh pages, into fresh pages advised as huge pages as
 * the engine maps its buffers, and into a buffer written before), then per-node times of a chain
 * of point nodes (a gradient followed by CHAIN nodes: invert, levels, clamp in turn) rendered
 * through the library:
 * - pool "cold": a new engine's first render (the buffer pool is empty; the nodes reuse the
 *   buffers of the nodes two before them, the first two take new memory);
 * - pool "warm": a later render of the same request on the same engine (every buffer from the
 *   pool);
 * - pool "none": a new engine that keeps results in its memory cache, so every node takes new
 *   memory: how every render ran before the pool.
 * Engines are made with no_memory_cache (as the command line makes them) except for "none".
 * Each row is the render with the median mean node time over --reps renders (a new engine for
 * each cold and none one; the first cold render is the process's first): `node_ms`, the mean over
 * the chain's nodes, and `x_memcpy`, that over one memcpy into a written buffer; `min_ms` and
 * `min_x`, the fastest node of that render (invert or clamp, the nodes closest to a copy); the
 * pool's hits and misses and the minor page faults of the render; `touch_ms`, the mean node time
 * above the warm row's, i.e. what first touching new memory costs a node on average. A comment
 * line under each row gives the mean time of each node type in that render. The last lines are
 * the process's peak resident memory (VmHWM) after the pooled renders and at the end. Table:
 * TAB-separated with a header line; `mode` names how the chain is evaluated (the rows here are
 * "unfused": one image per node); add modes to the `modes` table. */
#include "benchlib.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdint.h>
#include <sys/mman.h>
#include <sys/resource.h>

#define CHAIN 10
#define OPS 3 /* node types in the chain, in turn */
static const char *const op_names[OPS] = {"invert", "levels", "clamp"};

/* How the chain is evaluated: a name for the `mode` column and the engine options. */
typedef struct Mode {
    const char *name;
    void (*options)(WgEngineOptions *opt);
} Mode;

static void unfused(WgEngineOptions *opt)
{
    opt->no_fuse = true;
}

static void fused(WgEngineOptions *opt)
{
    opt->no_fuse = false;
}

static const Mode modes[] = {
    {"unfused", unfused},
    {"fused", fused},
};

/* A gradient and CHAIN point nodes "p1".."pCHAIN" on one line, gray, size x size. */
static char *chain_xml(int size)
{
    static const char *const ops[OPS] = {
        "type=\"invert\"",
        "type=\"levels\" in_low=\"0.05\" in_high=\"0.95\"",
        "type=\"clamp\" min=\"0.1\" max=\"0.9\"",
    };
    size_t cap = 4096;
    char *xml = malloc(cap);
    if (!xml) return NULL;
    int at = snprintf(xml, cap,
                      "<wetgraph version=\"1\" size=\"%d\">\n"
                      "  <node id=\"p0\" type=\"gradient\"/>\n",
                      size);
    for (int i = 1; i <= CHAIN; i++)
        at += snprintf(xml + at, cap - (size_t)at,
                       "  <node id=\"p%d\" %s><in name=\"source\" from=\"p%d\"/></node>\n", i,
                       ops[(i - 1) % OPS], i - 1);
    snprintf(xml + at, cap - (size_t)at, "  <output name=\"out\" from=\"p%d\"/>\n</wetgraph>\n",
             CHAIN);
    return xml;
}

/* One memcpy into fresh pages advised as huge pages (as the engine maps its buffers), median of
 * reps; -1 when the memory cannot be had. */
static double memcpy_huge_ms(size_t bytes, int reps)
{
    size_t huge = (size_t)2 << 20, span = bytes + huge;
    char *src = malloc(bytes);
    if (!src) return -1;
    memset(src, 1, bytes);
    double t[1000];
    int k = 0;
    for (; k < reps; k++) {
        char *raw = mmap(NULL, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (raw == MAP_FAILED) break;
        char *p = (char *)(((uintptr_t)raw + huge - 1) & ~(uintptr_t)(huge - 1));
        madvise(p, bytes, MADV_HUGEPAGE);
        double t0 = bench_now_ms();
        memcpy(p, src, bytes);
        t[k] = bench_now_ms() - t0;
        src[k] = p[bytes - 1 - (size_t)k]; /* keep the copy observable */
        munmap(raw, span);
    }
    free(src);
    return k ? bench_median(t, k) : -1;
}

/* The process's peak resident memory so far (VmHWM), kB; 0 when unknown. */
static long peak_kb(void)
{
    char line[256];
    long kb = 0;
    FILE *f = fopen("/proc/self/status", "r");
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, "VmHWM:", 6)) kb = atol(line + 6);
    if (f) fclose(f);
    return kb;
}

static long minor_faults(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_minflt;
}

typedef struct Sample {
    double node_ms;    /* mean over the chain's nodes */
    double min_ms;     /* the fastest of them */
    double op_ms[OPS]; /* mean per node type */
    double hits, misses, minflt;
} Sample;

static int cmp_sample(const void *a, const void *b)
{
    double x = ((const Sample *)a)->node_ms, y = ((const Sample *)b)->node_ms;
    return x < y ? -1 : x > y;
}

static WgEngine *engine(const Mode *m, int threads, bool memory_cache)
{
    WgEngineOptions opt = {threads, 0, NULL, !memory_cache};
    m->options(&opt);
    WgEngine *e = NULL;
    WgError err = {0};
    if (wg_engine_new(&opt, &e, &err)) fprintf(stderr, "engine: %s\n", err.message);
    return e;
}

static bool render(WgEngine *e, const WgRequest *r, Sample *s)
{
    WgMemoryStats before, after;
    wg_engine_memory_stats(e, &before);
    long f0 = minor_faults();
    WgResult *res = NULL;
    WgError err = {0};
    if (wg_render(e, r, &res, &err)) {
        fprintf(stderr, "render: %s\n", err.message);
        return false;
    }
    s->minflt = (double)(minor_faults() - f0);
    wg_engine_memory_stats(e, &after);
    s->hits = (double)(after.pool_hits - before.pool_hits);
    s->misses = (double)(after.pool_misses - before.pool_misses);
    double sum = 0, op_sum[OPS] = {0};
    int n = 0, op_n[OPS] = {0};
    s->min_ms = -1;
    for (int i = 0; i < wg_result_stat_count(res); i++) {
        const WgNodeStat *st = wg_result_stat(res, i);
        if (strcmp(st->id, "p0")) {
            sum += st->ms;
            n++;
            if (s->min_ms < 0 || st->ms < s->min_ms) s->min_ms = st->ms;
            for (int k = 0; k < OPS; k++)
                if (!strcmp(st->type, op_names[k])) {
                    op_sum[k] += st->ms;
                    op_n[k]++;
                }
        }
    }
    s->node_ms = n ? sum / n : -1;
    for (int k = 0; k < OPS; k++) s->op_ms[k] = op_n[k] ? op_sum[k] / op_n[k] : -1;
    wg_result_free(res);
    wg_engine_clear_cache(e);
    return true;
}

static const Sample *median(Sample *s, int n)
{
    qsort(s, (size_t)n, sizeof *s, cmp_sample);
    return &s[n / 2];
}

static void print_row(const char *mode, int size, const char *pool, const Sample *m,
                      double memcpy_ms, const Sample *warm)
{
    printf("%s\t%d\t%s\t%.2f\t%.2f\t%.2f\t%.2f\t%.0f\t%.0f\t%.0f\t%.2f\n", mode, size, pool,
           m->node_ms, m->node_ms / memcpy_ms, m->min_ms, m->min_ms / memcpy_ms, m->hits, m->misses,
           m->minflt, m->node_ms - warm->node_ms);
    printf("#\t%d\t%s\tper type (ms, this render):", size, pool);
    for (int k = 0; k < OPS; k++) printf(" %s %.2f", op_names[k], m->op_ms[k]);
    printf("\n");
    fflush(stdout);
}

static void print_memcpy(int size, const char *what, double ms, double warm)
{
    printf("memcpy\t%d\t%s\t%.2f\t%.2f\t-\t-\t-\t-\t-\t%.2f\n", size, what, ms, ms / warm,
           ms - warm);
}

int main(int argc, char **argv)
{
    BenchArgs a;
    if (bench_args(argc, argv, &a)) return 2;
    int reps = a.reps < 50 ? a.reps : 50;
    size_t bytes = (size_t)a.size * (size_t)a.size * sizeof(float);
    char *xml = chain_xml(a.size);
    WgGraph *g = NULL;
    WgError err = {0};
    if (!xml || wg_graph_load_memory(xml, strlen(xml), "chain.wetgraph", &g, &err)) {
        fprintf(stderr, "chain: %s\n", err.message);
        return 1;
    }
    WgRequest *r = wg_request_new(g);
    Sample cold[50], hot[50], none[50];
    int status = 0;
    long hwm_pooled = 0;
    printf("# %dx%d gray, %d threads, median of %d\n", a.size, a.size, a.threads, reps);
    printf("mode\tsize\tpool\tnode_ms\tx_memcpy\tmin_ms\tmin_x\thits\tmisses\tminflt\ttouch_ms\n");
    for (size_t k = 0; k < sizeof modes / sizeof *modes && !status; k++) {
        const Mode *m = &modes[k];
        /* cold first: the first render of the process is one of them */
        for (int i = 0; i < reps && !status; i++) {
            WgEngine *e = engine(m, a.threads, false);
            if (!e || !render(e, r, &cold[i])) status = 1;
            if (!status && i == 0) /* the warm renders share the first engine */
                for (int j = 0; j < reps && !status; j++)
                    if (!render(e, r, &hot[j])) status = 1;
            wg_engine_free(e);
        }
        if (k == 0) hwm_pooled = peak_kb();
        for (int i = 0; i < reps && !status; i++) {
            WgEngine *e = engine(m, a.threads, true);
            if (!e || !render(e, r, &none[i])) status = 1;
            wg_engine_free(e);
        }
        if (status) break;
        double warm = bench_memcpy_ms(bytes, a.reps, false);
        if (k == 0) {
            print_memcpy(a.size, "fresh", bench_memcpy_ms(bytes, a.reps, true), warm);
            print_memcpy(a.size, "fresh_huge", memcpy_huge_ms(bytes, a.reps), warm);
            print_memcpy(a.size, "reused", warm, warm);
        }
        const Sample *w = median(hot, reps);
        print_row(m->name, a.size, "cold", median(cold, reps), warm, w);
        print_row(m->name, a.size, "warm", w, warm, w);
        print_row(m->name, a.size, "none", median(none, reps), warm, w);
    }
    printf("peak\t%d\tpooled\t%ld kB\tVmHWM after the cold and warm renders\n", a.size, hwm_pooled);
    printf("peak\t%d\tall\t%ld kB\tVmHWM at the end (none keeps every image cached)\n", a.size,
           peak_kb());
    wg_request_free(r);
    wg_graph_free(g);
    free(xml);
    return status;
}
