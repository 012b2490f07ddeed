/* SPDX-License-Identifier: MIT */
/* Distance benchmark: `distance`, `dilate` and `erode` at N×N (default 2048²) on two masks made
 * by the graph itself: random blobs (perlin noise, which the node thresholds at 0.5, about half
 * covered) and sparse seeds (white noise through a hard threshold at 0.9999, a few hundred
 * isolated pixels). Reports the median over the repetitions of the node's own evaluation time
 * (the engine's per-node stat; the mask's generation is not counted; cache cleared each time).
 *   bench_distance [--size N] [--threads T] [--reps R] [--only NAME]
 * Output: one line per case, "name<TAB>median ms<TAB>min ms<TAB>ms_per_MP (median)<TAB>mask
 * pixels<TAB>node". The minimum is the steadier figure on a shared machine. */
#include <wetgraph/wetgraph.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    const char *name;
    int mask;         /* 0 blobs, 1 sparse seeds */
    const char *node; /* type and attributes of the measured node */
    int fill;         /* connect a colour source */
} Case;

static const Case cases[] = {
    {"blobs_pixels", 0, "type=\"distance\" mode=\"pixels\"", 0},
    {"blobs_falloff", 0, "type=\"distance\" distance=\"20\"", 0},
    {"blobs_signed", 0, "type=\"distance\" mode=\"signed\"", 0},
    {"blobs_fill", 0, "type=\"distance\"", 1},
    {"blobs_pixels_nowrap", 0, "type=\"distance\" mode=\"pixels\" wrap=\"false\"", 0},
    {"seeds_pixels", 1, "type=\"distance\" mode=\"pixels\"", 0},
    {"seeds_fill", 1, "type=\"distance\"", 1},
    {"seeds_pixels_nowrap", 1, "type=\"distance\" mode=\"pixels\" wrap=\"false\"", 0},
    {"blobs_dilate", 0, "type=\"dilate\" radius=\"4\"", 0},
    {"blobs_erode", 0, "type=\"erode\" radius=\"4\"", 0},
};

static const char *const masks[] = {
    "  <node id=\"mask\" type=\"noise\" kind=\"perlin\" scale=\"8\" octaves=\"4\"/>\n",
    "  <node id=\"white\" type=\"noise\" kind=\"white\" scale=\"%d\" octaves=\"1\"/>\n"
    "  <node id=\"mask\" type=\"threshold\" position=\"0.9999\"><in name=\"source\" "
    "from=\"white\"/></node>\n",
};

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static long count_mask(const WgImage *m)
{
    long n = 0;
    for (int y = 0; y < m->height; y++)
        for (int x = 0; x < m->width; x++) n += m->data[(size_t)y * m->stride + x] >= 0.5f;
    return n;
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
    printf("# %dx%d, %d threads, median and min of %d (node time only)\n", size, size, threads,
           reps);
    int failed = 0;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        if (only && strcmp(only, cases[c].name)) continue;
        char mask[512], xml[2048];
        snprintf(mask, sizeof mask, masks[cases[c].mask], size);
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"7\">\n%s"
                 "  <node id=\"src\" type=\"noise\" kind=\"value\" scale=\"16\" octaves=\"1\"/>\n"
                 "  <node id=\"col\" type=\"gradient_map\"><in name=\"source\" from=\"src\"/>"
                 "</node>\n"
                 "  <node id=\"d\" %s><in name=\"mask\" from=\"mask\"/>%s</node>\n"
                 "  <output name=\"out\" from=\"d\"/>\n  <output name=\"mask\" from=\"mask\"/>\n"
                 "</wetgraph>\n",
                 size, size, mask, cases[c].node,
                 cases[c].fill ? "<in name=\"source\" from=\"col\"/>" : "");
        WgGraph *g = NULL;
        if (wg_graph_load_memory(xml, strlen(xml), "bench.wetgraph", &g, &err)) {
            fprintf(stderr, "%s: %s\n", cases[c].name, err.message);
            failed = 1;
            continue;
        }
        WgRequest *r = wg_request_new(g);
        double t[1000];
        long pixels = 0;
        int ok = 1;
        for (int k = 0; k < reps && ok; k++) {
            wg_engine_clear_cache(e);
            WgResult *res = NULL;
            if (wg_render(e, r, &res, &err)) {
                fprintf(stderr, "%s: %s\n", cases[c].name, err.message);
                ok = 0;
                failed = 1;
                break;
            }
            for (int i = 0; i < wg_result_stat_count(res); i++)
                if (!strcmp(wg_result_stat(res, i)->id, "d")) t[k] = wg_result_stat(res, i)->ms;
            for (int i = 0; i < wg_result_output_count(res); i++)
                if (!strcmp(wg_result_output_name(res, i), "mask"))
                    pixels = count_mask(wg_result_output_image(res, i));
            wg_result_free(res);
        }
        if (ok) {
            qsort(t, (size_t)reps, sizeof t[0], cmp_double);
            double med = t[reps / 2];
            printf("%s\t%.2f\t%.2f\t%.2f\t%ld\t%s\n", cases[c].name, med, t[0], med / mp, pixels,
                   cases[c].node);
            fflush(stdout);
        }
        wg_request_free(r);
        wg_graph_free(g);
    }
    wg_engine_free(e);
    return failed;
}
