/* SPDX-License-Identifier: MIT */
/* Shared parts of the node benchmarks: see benchlib.h. */
#include "benchlib.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

int bench_args_pos(int argc, char **argv, BenchArgs *a, int max_pos)
{
    *a = (BenchArgs){2048, 2, 9, {0}, 0};
    for (int i = 1; i < argc; i++) {
        if (argv[i][0] != '-' && a->n_pos < max_pos && a->n_pos < BENCH_MAX_POS) {
            a->pos[a->n_pos++] = argv[i];
            continue;
        }
        int *field = !strcmp(argv[i], "--size")      ? &a->size
                     : !strcmp(argv[i], "--threads") ? &a->threads
                     : !strcmp(argv[i], "--reps")    ? &a->reps
                                                     : NULL;
        if (!field || i + 1 >= argc) {
            fprintf(stderr, "usage: %s [--size N] [--threads T] [--reps R]%s\n", argv[0],
                    max_pos ? " ARGUMENTS" : "");
            return 2;
        }
        *field = atoi(argv[++i]);
    }
    if (a->reps < 1 || a->reps > 1000) a->reps = 9;
    if (a->size < 1 || a->size > 16384) a->size = 2048;
    return 0;
}

int bench_args(int argc, char **argv, BenchArgs *a)
{
    return bench_args_pos(argc, argv, a, 0);
}

double bench_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

double bench_median(double *t, int n)
{
    qsort(t, (size_t)n, sizeof t[0], cmp_double);
    return t[n / 2];
}

WgEngine *bench_engine(int threads)
{
    WgError err = {0};
    WgEngineOptions opt = {threads, 0, NULL};
    WgEngine *e = NULL;
    if (wg_engine_new(&opt, &e, &err)) fprintf(stderr, "engine: %s\n", err.message);
    return e;
}

double bench_node_ms(WgEngine *e, const char *xml, const char *node_id, int reps, const char *label)
{
    WgError err = {0};
    WgGraph *g = NULL;
    if (wg_graph_load_memory(xml, strlen(xml), "bench.wetgraph", &g, &err)) {
        fprintf(stderr, "%s: %s\n", label, err.message);
        return -1;
    }
    WgRequest *r = wg_request_new(g);
    double t[1000];
    double result = -1;
    int k = 0;
    for (; k < reps; k++) {
        wg_engine_clear_cache(e);
        WgResult *res = NULL;
        if (wg_render(e, r, &res, &err)) {
            fprintf(stderr, "%s: %s\n", label, err.message);
            break;
        }
        t[k] = -1;
        for (int i = 0; i < wg_result_stat_count(res); i++)
            if (!strcmp(wg_result_stat(res, i)->id, node_id)) t[k] = wg_result_stat(res, i)->ms;
        wg_result_free(res);
    }
    if (k == reps) result = bench_median(t, reps);
    wg_request_free(r);
    wg_graph_free(g);
    return result;
}

bool bench_node_line(WgEngine *e, const char *xml, const char *label, const char *description,
                     const BenchArgs *a)
{
    double ms = bench_node_ms(e, xml, "n", a->reps, label);
    if (ms < 0) return false;
    double mp = (double)a->size * a->size / 1e6;
    printf("%s\t%.2f\t%.2f\t%s\n", label, ms, ms / mp, description);
    fflush(stdout);
    return true;
}

double bench_memcpy_ms(size_t bytes, int reps, bool fresh)
{
    char *a = malloc(bytes), *b = fresh ? NULL : malloc(bytes);
    if (!a || (!fresh && !b)) {
        free(a);
        free(b);
        return -1;
    }
    memset(a, 1, bytes);
    if (b) memset(b, 2, bytes);
    double t[1000];
    int k = 0;
    for (; k < reps; k++) {
        /* mmap: malloc may hand back the pages of the previous round */
        if (fresh && (b = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1,
                               0)) == MAP_FAILED) {
            b = NULL;
            break;
        }
        double t0 = bench_now_ms();
        memcpy(b, a, bytes);
        t[k] = bench_now_ms() - t0;
        a[k] = b[bytes - 1 - (size_t)k]; /* keep the copy observable */
        if (fresh) {
            munmap(b, bytes);
            b = NULL;
        }
    }
    free(a);
    free(b);
    return k ? bench_median(t, k) : -1;
}

/* The last-level cache this CPU shares, from sysfs: inside a VM, sysconf's figure can be the
 * host's whole package (384 MiB read where lscpu shows 32 MiB); 64 MiB when unknown. */
static size_t last_level_cache(void)
{
    size_t bytes = (size_t)64 << 20;
    FILE *f = fopen("/sys/devices/system/cpu/cpu0/cache/index3/size", "r");
    if (!f) return bytes;
    unsigned long v;
    char unit = 0;
    if (fscanf(f, "%lu%c", &v, &unit) >= 1 && v > 0)
        bytes = unit == 'K' ? (size_t)v << 10 : unit == 'M' ? (size_t)v << 20 : (size_t)v;
    fclose(f);
    return bytes;
}

double bench_memcpy_memory_ms(size_t bytes, int reps, size_t *span)
{
    size_t cache = last_level_cache();
    int planes = (int)((4 * cache + bytes - 1) / bytes);
    if (planes < 4) planes = 4;
    if (planes > 64) planes = 64;
    planes += planes % 2;
    char *p[64] = {0};
    double t[1000];
    int k = 0, ok = 1;
    for (int i = 0; i < planes && ok; i++) {
        ok = (p[i] = malloc(bytes)) != NULL;
        if (ok) memset(p[i], i, bytes);
    }
    /* pairs in turn: each copy reads and writes planes the previous ones pushed out of the cache */
    for (; ok && k < reps && k < 1000; k++) {
        int i = 2 * (k % (planes / 2));
        double t0 = bench_now_ms();
        memcpy(p[i + 1], p[i], bytes);
        t[k] = bench_now_ms() - t0;
        p[i][k % bytes] = p[i + 1][bytes - 1 - (size_t)k % bytes]; /* keep the copy observable */
    }
    for (int i = 0; i < planes; i++) free(p[i]);
    if (span) *span = (size_t)planes * bytes;
    return ok && k ? bench_median(t, k) : -1;
}

void bench_memcpy_lines(const BenchArgs *a)
{
    size_t px = (size_t)a->size * (size_t)a->size;
    double mp = px / 1e6;
    static const char *const what[] = {"warm", "fresh"};
    for (int fresh = 0; fresh < 2; fresh++) {
        double m1 = bench_memcpy_ms(px * 4, a->reps, fresh),
               m4 = bench_memcpy_ms(px * 16, a->reps, fresh);
        printf("memcpy_gray_%s\t%.2f\t%.2f\tone memcpy of a gray image (%zu MB)\n", what[fresh], m1,
               m1 / mp, px * 4 >> 20);
        printf("memcpy_color_%s\t%.2f\t%.2f\tone memcpy of a colour image (%zu MB)\n", what[fresh],
               m4, m4 / mp, px * 16 >> 20);
    }
}
