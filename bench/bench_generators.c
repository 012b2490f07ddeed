/* SPDX-License-Identifier: MIT */
/* Generator benchmark: renders each generator node alone at N×N (default 2048²) through the
 * public API (graph loaded from a string, one WgEngine, cache cleared before every repetition),
 * times wg_render with clock_gettime(CLOCK_MONOTONIC) and prints the median of the repetitions
 * in ms and in ms per megapixel. bench/run_generators.sh runs it next to GEGL's perlin noise.
 *   bench_generators [--size N] [--threads T] [--reps R] [--only NAME]
 * Output: one line per case, "name<TAB>ms<TAB>ms_per_MP<TAB>description". */
#include <wetgraph/wetgraph.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
    const char *name;
    const char *node; /* type and attributes of the one node */
} Case;

static const Case cases[] = {
    {"fbm8_perlin", "type=\"noise\" kind=\"perlin\" scale=\"8\" octaves=\"8\""},
    {"perlin1", "type=\"noise\" kind=\"perlin\" scale=\"8\" octaves=\"1\""},
    {"fbm8_value", "type=\"noise\" kind=\"value\" scale=\"8\" octaves=\"8\""},
    {"fbm8_simplex", "type=\"noise\" kind=\"simplex\" scale=\"8\" octaves=\"8\""},
    {"fbm8_ridged", "type=\"noise\" kind=\"perlin\" scale=\"8\" octaves=\"8\" mode=\"ridged\""},
    {"white", "type=\"noise\" kind=\"white\" scale=\"2048\" octaves=\"1\""},
    {"cells_f1", "type=\"cells\" scale=\"16\""},
    {"bricks", "type=\"bricks\" bevel=\"0.2\" random_offset=\"0.3\""},
    {"checker", "type=\"checker\" scale=\"8\""},
    {"shape_star", "type=\"shape\" kind=\"star\" scale=\"4\" falloff=\"0.3\" rotation=\"10\""},
    {"sine", "type=\"sine\" angle=\"30\" frequency=\"12\""},
    {"gradient_radial", "type=\"gradient\" kind=\"radial\" repeat=\"mirror\" radius=\"0.1\""},
};

static double now_ms(void)
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

int main(int argc, char **argv)
{
    int size = 2048, threads = 2, reps = 9;
    const char *only = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc)
            size = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--only") && i + 1 < argc)
            only = argv[++i];
        else {
            fprintf(stderr, "usage: %s [--size N] [--threads T] [--reps R] [--only NAME]\n",
                    argv[0]);
            return 2;
        }
    }
    if (reps < 1 || reps > 1000) reps = 9;
    WgError err = {0};
    WgEngineOptions opt = {threads, 0, NULL};
    WgEngine *e = NULL;
    if (wg_engine_new(&opt, &e, &err)) {
        fprintf(stderr, "engine: %s\n", err.message);
        return 1;
    }
    double mp = (double)size * size / 1e6;
    printf("# %dx%d, %d threads, median of %d\n", size, size, threads, reps);
    int failed = 0;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        if (only && strcmp(only, cases[c].name)) continue;
        char xml[1024];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"7\">\n"
                 "  <node id=\"n\" %s/>\n  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n",
                 size, size, cases[c].node);
        WgGraph *g = NULL;
        if (wg_graph_load_memory(xml, strlen(xml), "bench.wetgraph", &g, &err)) {
            fprintf(stderr, "%s: %s\n", cases[c].name, err.message);
            failed = 1;
            continue;
        }
        WgRequest *r = wg_request_new(g);
        double t[1000];
        int ok = 1;
        for (int k = 0; k < reps && ok; k++) {
            wg_engine_clear_cache(e);
            WgResult *res = NULL;
            double t0 = now_ms();
            if (wg_render(e, r, &res, &err)) {
                fprintf(stderr, "%s: %s\n", cases[c].name, err.message);
                ok = 0;
                failed = 1;
                break;
            }
            t[k] = now_ms() - t0;
            wg_result_free(res);
        }
        if (ok) {
            qsort(t, (size_t)reps, sizeof t[0], cmp_double);
            double med = t[reps / 2];
            printf("%s\t%.2f\t%.2f\t%s\n", cases[c].name, med, med / mp, cases[c].node);
            fflush(stdout);
        }
        wg_request_free(r);
        wg_graph_free(g);
    }
    wg_engine_free(e);
    return failed;
}
