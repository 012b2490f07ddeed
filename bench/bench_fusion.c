/* SPDX-License-Identifier: MIT */
/* Fused point operations: a gray noise followed by a chain of 10 point operations (levels,
 * invert, clamp, threshold), rendered fused (the default) or with
 * WgEngineOptions.no_fuse, in one process: the first render (every page fresh), the second
 * (cache cleared, same engine) and the best of the following ones (per node, its least time).
 * Printed per node: the engine's time (a fused node's share of its group's time); then the chain's
 * total (p1..p10), the whole render, the engine's counted peak and the growth of the process's peak
 * resident memory (VmHWM) over its size before the first render. With --recycle, a recycling
 * allocator (freed blocks of 1 MiB and more kept per exact size) keeps image memory warm between
 * renders, as an image pool in the engine would; without it each render maps its images anew. Run
 * one mode per process (bench/run_fusion.sh) so that the resident peak is the mode's own. */
#include <wetgraph/wetgraph.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define CHAIN 10

static const char *const chain_types[CHAIN] = {"levels", "invert",    "clamp",  "levels", "invert",
                                               "clamp",  "threshold", "levels", "invert", "clamp"};
static const char *const chain_attrs[CHAIN] = {"in_low=\"0.1\" in_high=\"0.9\"",
                                               "",
                                               "min=\"0.05\" max=\"0.95\"",
                                               "out_low=\"0.1\" out_high=\"0.8\"",
                                               "",
                                               "min=\"0.1\" max=\"0.9\"",
                                               "position=\"0.5\" contrast=\"0.3\"",
                                               "in_low=\"0.05\" in_high=\"0.95\"",
                                               "",
                                               "max=\"0.85\""};

/* ---- a recycling allocator ---------------------------------------------------------------- */

enum { POOL = 64, HEADER = 64 };
static struct {
    pthread_mutex_t mu;
    void *block[POOL];
    size_t size[POOL];
    int n;
} pool = {PTHREAD_MUTEX_INITIALIZER, {0}, {0}, 0};

static void *pool_alloc(size_t size, void *user)
{
    (void)user;
    size = (size + 63) & ~(size_t)63;
    pthread_mutex_lock(&pool.mu);
    for (int i = 0; i < pool.n; i++)
        if (pool.size[i] == size) {
            char *p = pool.block[i];
            pool.block[i] = pool.block[--pool.n];
            pool.size[i] = pool.size[pool.n];
            pthread_mutex_unlock(&pool.mu);
            return p + HEADER;
        }
    pthread_mutex_unlock(&pool.mu);
    char *p = aligned_alloc(64, size + HEADER);
    if (!p) return NULL;
    memcpy(p, &size, sizeof size);
    return p + HEADER;
}

static void pool_free(void *ptr, void *user)
{
    (void)user;
    if (!ptr) return;
    char *p = (char *)ptr - HEADER;
    size_t size;
    memcpy(&size, p, sizeof size);
    pthread_mutex_lock(&pool.mu);
    if (size >= (1u << 20) && pool.n < POOL) {
        pool.block[pool.n] = p;
        pool.size[pool.n++] = size;
        p = NULL;
    }
    pthread_mutex_unlock(&pool.mu);
    free(p);
}

/* ---- measuring ----------------------------------------------------------------------------- */

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

/* A field of /proc/self/status in KiB (VmRSS, VmHWM), 0 when unavailable. */
static long status_kib(const char *field)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f) return 0;
    char line[256];
    long v = 0;
    size_t n = strlen(field);
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, field, n) && line[n] == ':') v = atol(line + n + 1);
    fclose(f);
    return v;
}

static double memcpy_ms(size_t bytes, int reps)
{
    char *a = malloc(bytes), *b = malloc(bytes);
    if (!a || !b) return -1;
    memset(a, 1, bytes);
    memset(b, 2, bytes);
    double best = 1e30;
    for (int i = 0; i < reps; i++) {
        double t0 = now_ms();
        memcpy(b, a, bytes);
        double t = now_ms() - t0;
        if (t < best) best = t;
    }
    volatile char sink = b[bytes / 2];
    (void)sink;
    free(a);
    free(b);
    return best;
}

int main(int argc, char **argv)
{
    int size = 2048, threads = 2, reps = 10;
    bool fuse = true, recycle = false;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc)
            size = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--no-fuse"))
            fuse = false;
        else if (!strcmp(argv[i], "--recycle"))
            recycle = true;
        else {
            fprintf(stderr,
                    "usage: %s [--size N] [--threads T] [--reps R] [--no-fuse] "
                    "[--recycle]\n",
                    argv[0]);
            return 2;
        }
    }
    if (size < 16 || size > 16384) size = 2048;
    if (reps < 2 || reps > 100) reps = 10;
    if (recycle) wg_set_allocator(pool_alloc, pool_free, NULL);

    char xml[8192];
    size_t n = (size_t)snprintf(xml, sizeof xml,
                                "<wetgraph version=\"1\" size=\"%d\" seed=\"1\">\n"
                                "  <node id=\"src\" type=\"noise\" scale=\"8\" octaves=\"2\"/>\n",
                                size);
    for (int k = 0; k < CHAIN; k++) {
        char from[8] = "src";
        if (k) snprintf(from, sizeof from, "p%d", k);
        n += (size_t)snprintf(xml + n, sizeof xml - n,
                              "  <node id=\"p%d\" type=\"%s\" %s><in name=\"source\" "
                              "from=\"%s\"/></node>\n",
                              k + 1, chain_types[k], chain_attrs[k], from);
    }
    snprintf(xml + n, sizeof xml - n, "  <output name=\"out\" from=\"p%d\"/>\n</wetgraph>\n",
             CHAIN);

    WgError err = {0};
    WgGraph *g = NULL;
    WgEngine *e = NULL;
    WgEngineOptions opt = {.threads = threads, .no_fuse = !fuse};
    if (wg_graph_load_memory(xml, strlen(xml), "chain.wetgraph", &g, &err) ||
        wg_engine_new(&opt, &e, &err)) {
        fprintf(stderr, "bench_fusion: %s\n", err.message);
        return 1;
    }
    WgRequest *r = wg_request_new(g);
    double image_mib = (double)size * size * 4 / 1048576.0;
    long base_kib = status_kib("VmRSS");

    enum { NODES = CHAIN + 1 };
    double node_ms[3][NODES], chain_ms[3], total_ms[3];
    for (int k = 0; k < 3; k++) chain_ms[k] = total_ms[k] = 1e30;
    size_t peak = 0;
    int groups = 0;
    for (int rep = 0; rep < reps; rep++) {
        wg_engine_clear_cache(e);
        WgResult *res = NULL;
        if (wg_render(e, r, &res, &err)) {
            fprintf(stderr, "bench_fusion: %s\n", err.message);
            return 1;
        }
        double ms[NODES] = {0}, chain = 0;
        for (int i = 0; i < wg_result_stat_count(res); i++) {
            const WgNodeStat *s = wg_result_stat(res, i);
            int k = !strcmp(s->id, "src") ? 0 : atoi(s->id + 1);
            if (k < 0 || k >= NODES) continue;
            ms[k] = s->ms;
            if (k > 0) chain += s->ms;
            if (s->fused > groups) groups = s->fused;
        }
        /* first, second, and the best of the rest: per node its least time (load on a shared
         * machine lands on whichever node runs), the chain and render at their least */
        int slot = rep < 2 ? rep : 2;
        for (int k = 0; k < NODES; k++)
            if (slot < 2 || rep == 2 || ms[k] < node_ms[2][k]) node_ms[slot][k] = ms[k];
        if (slot < 2 || chain < chain_ms[2]) chain_ms[slot] = chain;
        if (slot < 2 || wg_result_total_ms(res) < total_ms[2])
            total_ms[slot] = wg_result_total_ms(res);
        if (wg_result_peak_bytes(res) > peak) peak = wg_result_peak_bytes(res);
        wg_result_free(res);
    }
    long hwm_kib = status_kib("VmHWM");
    double copy = memcpy_ms((size_t)size * size * 4, 5); /* after: its buffers are not the peak */

    printf("# %dx%d gray (%.0f MiB per image), %d threads, %s, %s allocator; memcpy of one "
           "image %.2f ms (x10 = %.1f ms)\n",
           size, size, image_mib, threads, fuse ? "fused" : "unfused",
           recycle ? "recycling" : "default", copy, 10 * copy);
    printf("%-6s %-11s %10s %10s %12s\n", "node", "type", "1st ms", "2nd ms", "best of rest");
    for (int k = 0; k < NODES; k++) {
        char id[8] = "src";
        if (k) snprintf(id, sizeof id, "p%d", k);
        printf("%-6s %-11s %10.2f %10.2f %12.2f\n", id, k ? chain_types[k - 1] : "noise",
               node_ms[0][k], node_ms[1][k], reps > 2 ? node_ms[2][k] : 0.0);
    }
    printf("%-18s %10.2f %10.2f %12.2f   (%s)\n", "chain p1..p10", chain_ms[0], chain_ms[1],
           reps > 2 ? chain_ms[2] : 0.0, groups ? "one fused group" : "10 separate nodes");
    double best_sum = 0;
    for (int k = 1; k < NODES; k++) best_sum += node_ms[2][k];
    if (reps > 2)
        printf("%-18s %10s %10s %12.2f   (the least the machine's load let each node take)\n",
               "sum of node bests", "", "", best_sum);
    printf("%-18s %10.2f %10.2f %12.2f\n", "whole render", total_ms[0], total_ms[1],
           reps > 2 ? total_ms[2] : 0.0);
    printf("engine peak (counted) %.1f MiB; peak resident growth %.1f MiB\n", peak / 1048576.0,
           base_kib && hwm_kib ? (hwm_kib - base_kib) / 1024.0 : -1.0);
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
    return 0;
}
