/* SPDX-License-Identifier: MIT */
/* Compute and allocation in the wet-material pipeline. Renders graphs/wet_material.wetgraph on
 * a material folder of ../shared (Bricks102 by default) at --size with --threads workers, all
 * outputs, in one engine made as the command line makes it (no memory cache, so every render
 * computes every node):
 * - "first": the engine's first render: its buffer pool is empty, so every buffer the render
 *   cannot reuse from its own earlier nodes is new memory, which the kernel maps and clears on
 *   first touch (as in a `wetgraph render` process);
 * - "pooled": the median of --reps later renders of the same request on the same engine, whose
 *   buffers all come from the pool: the nodes' compute time alone.
 * Node time is the sum of the nodes' own times (WgNodeStat.ms) without the `image` nodes that
 * read the input files, as `wetgraph render --stats` reports it. The difference between the two
 * rows is what first touching new memory cost that render; the minor page faults of each render
 * are printed with it. Then one line per node: its first and pooled time, slowest first.
 * The yardstick, timed in the same run: one memcpy of a gray float plane of the render's size
 * into memory written before (median of 9, after the renders: at 2048² both planes can sit in a
 * large last-level cache), and one between planes out of the cache (planes four times the
 * cache's size copied in turn, as the render's nodes meet their images); node time is also
 * given in both kinds of copies. The host's CPU model and load average (at the start and the end)
 * are printed first and last, since a loaded machine's figures are not a quiet one's.
 * --no-fuse evaluates every node whole (WgEngineOptions.no_fuse), for comparison.
 * Usage: bench_wet [--size N] [--threads T] [--reps R] [--no-fuse] [GRAPH [MATERIAL_DIR]] */
#include "benchlib.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <unistd.h>

static long minor_faults(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_minflt;
}

/* CPU time of the process, user and system: steadier than node time on a loaded machine */
static double cpu_ms(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) * 1e3 +
           (ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) / 1e3;
}

typedef struct Render {
    double node_ms, total_ms, cpu_ms;
    long minflt;
    int n;
    double *ms; /* per node, in stat order */
} Render;

static int render_once(WgEngine *e, const WgRequest *r, Render *out)
{
    WgResult *res = NULL;
    WgError err = {0};
    long f0 = minor_faults();
    double c0 = cpu_ms();
    if (wg_render(e, r, &res, &err)) {
        fprintf(stderr, "bench_wet: %s\n", err.message);
        return -1;
    }
    out->minflt = minor_faults() - f0;
    out->cpu_ms = cpu_ms() - c0;
    out->total_ms = wg_result_total_ms(res);
    out->n = wg_result_stat_count(res);
    out->ms = calloc((size_t)out->n + 1, sizeof(double));
    out->node_ms = 0;
    for (int i = 0; i < out->n; i++) {
        const WgNodeStat *s = wg_result_stat(res, i);
        out->ms[i] = s->ms;
        if (strcmp(s->type, "image") != 0) out->node_ms += s->ms;
    }
    wg_result_free(res);
    return 0;
}

/* The CPU model (lscpu's "Model name") and the load average, for the record. */
static void print_host(const char *when)
{
    char line[512], model[256] = "unknown";
    FILE *f = fopen("/proc/cpuinfo", "r");
    while (f && fgets(line, sizeof line, f))
        if (!strncmp(line, "model name", 10) && strchr(line, ':')) {
            snprintf(model, sizeof model, "%s", strchr(line, ':') + 2);
            model[strcspn(model, "\n")] = '\0';
            break;
        }
    if (f) fclose(f);
    double load[3] = {0};
    f = fopen("/proc/loadavg", "r");
    if (!f || fscanf(f, "%lf %lf %lf", &load[0], &load[1], &load[2]) != 3) load[0] = -1;
    if (f) fclose(f);
    printf("# host (%s): %s, %ld CPUs online; load average %.2f %.2f %.2f\n", when, model,
           sysconf(_SC_NPROCESSORS_ONLN), load[0], load[1], load[2]);
}

static const char *const maps[][2] = {
    {"basecolor", "Color"},     {"height", "Displacement"}, {"normal", "NormalGL"},
    {"roughness", "Roughness"}, {"ao", "AmbientOcclusion"},
};

int main(int argc, char **argv)
{
    /* --no-fuse apart, the options and GRAPH and MATERIAL_DIR go to bench_args_pos */
    const char *prefix = "Bricks102_1K-JPG_";
    char **opts = calloc((size_t)argc + 1, sizeof(char *));
    int n_opts = 0;
    bool no_fuse = false;
    for (int i = 0; i < argc; i++) {
        if (i && !strcmp(argv[i], "--no-fuse"))
            no_fuse = true;
        else
            opts[n_opts++] = argv[i];
    }
    BenchArgs a;
    int rc = bench_args_pos(n_opts, opts, &a, 2);
    free(opts);
    if (rc) return rc == 2 ? 0 : 1;
    const char *graph = a.n_pos > 0 ? a.pos[0] : "graphs/wet_material.wetgraph";
    const char *dir = a.n_pos > 1 ? a.pos[1] : "../shared/materials/bricks102_stonewall_1k";
    WgGraph *g = NULL;
    WgError err = {0};
    if (wg_graph_load(graph, &g, &err)) {
        fprintf(stderr, "bench_wet: %s\n", err.message);
        return 1;
    }
    WgRequest *r = wg_request_new(g);
    for (size_t k = 0; k < sizeof maps / sizeof maps[0]; k++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s%s.jpg", dir, prefix, maps[k][1]);
        if (wg_request_set_input_file(r, maps[k][0], path, &err)) {
            fprintf(stderr, "bench_wet: %s\n", err.message);
            return 1;
        }
    }
    wg_request_set(r, "water_level", "0.65", &err);
    wg_request_set_size(r, a.size, a.size);
    WgEngineOptions opt = {.threads = a.threads, .no_memory_cache = true, .no_fuse = no_fuse};
    WgEngine *e = NULL;
    if (wg_engine_new(&opt, &e, &err)) {
        fprintf(stderr, "bench_wet: %s\n", err.message);
        return 1;
    }
    print_host("start");
    Render first, *pooled = calloc((size_t)a.reps + 1, sizeof(Render));
    if (!pooled || render_once(e, r, &first)) return 1;
    double *node = calloc((size_t)a.reps + 1, sizeof(double));
    for (int k = 0; k < a.reps; k++) {
        if (render_once(e, r, &pooled[k])) return 1;
        node[k] = pooled[k].node_ms;
    }
    double med = bench_median(node, a.reps);
    const Render *m = &pooled[0];
    for (int k = 0; k < a.reps; k++)
        if (pooled[k].node_ms == med) m = &pooled[k];
    printf("render\tsize\tthreads\tnode_ms\ttotal_ms\tcpu_ms\tminflt\n");
    printf("first\t%d\t%d\t%.1f\t%.1f\t%.1f\t%ld\n", a.size, a.threads, first.node_ms,
           first.total_ms, first.cpu_ms, first.minflt);
    printf("pooled\t%d\t%d\t%.1f\t%.1f\t%.1f\t%ld\n", a.size, a.threads, m->node_ms, m->total_ms,
           m->cpu_ms, m->minflt);
    printf("# first touch of new memory: %.1f ms of the first render's node time\n",
           first.node_ms - m->node_ms);
    double copy = bench_memcpy_ms((size_t)a.size * (size_t)a.size * sizeof(float), 9, false);
    printf("# memcpy of a %dx%d float plane: %.4f ms; node time in such copies: first %.0f, "
           "pooled %.0f\n",
           a.size, a.size, copy, first.node_ms / copy, m->node_ms / copy);
    size_t span = 0;
    double mem = bench_memcpy_memory_ms((size_t)a.size * (size_t)a.size * sizeof(float), 24, &span);
    printf("# memcpy of a %dx%d float plane from memory (planes of %zu MiB in turn, beyond the "
           "cache): %.4f ms; node time in such copies: first %.0f, pooled %.0f\n",
           a.size, a.size, span >> 20, mem, first.node_ms / mem, m->node_ms / mem);
    /* per node, slowest pooled first */
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) return 1;
    int n = first.n;
    int *order = calloc((size_t)n + 1, sizeof(int));
    for (int i = 0; i < n; i++) order[i] = i;
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && m->ms[order[j]] > m->ms[order[j - 1]]; j--) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    printf("node\ttype\tfirst_ms\tpooled_ms\n");
    for (int k = 0; k < n; k++) {
        const WgNodeStat *s = wg_result_stat(res, order[k]);
        printf("%s\t%s\t%.1f\t%.1f\n", s->id, s->type, first.ms[order[k]], m->ms[order[k]]);
    }
    wg_result_free(res);
    print_host("end");
    free(order);
    for (int k = 0; k < a.reps; k++) free(pooled[k].ms);
    free(pooled);
    free(first.ms);
    free(node);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
    return 0;
}
