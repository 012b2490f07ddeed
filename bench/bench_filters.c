/* SPDX-License-Identifier: MIT */
/* Filter benchmark: `sharpen`, `emboss`, `edge_detect`, `directional_blur`, `normal_blend` and
 * `normal_normalize` at N×N (default 2048²). The inputs are a 1-octave Perlin height (gray) and
 * normal maps made from two such heights (colour); the time of the filter node alone (its
 * WgNodeStat, so the inputs are not counted) is the median over the repetitions, cache cleared
 * before each.
 *   bench_filters [--size N] [--threads T] [--reps R]
 * Output: one line per case, "name<TAB>ms<TAB>ms_per_MP<TAB>description". */
#include <wetgraph/wetgraph.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const struct {
    const char *name, *node;
} cases[] = {
    {"sharpen_gray_r1", "type=\"sharpen\" radius=\"1\"><in name=\"source\" from=\"h\"/>"},
    {"sharpen_color_r1", "type=\"sharpen\" radius=\"1\"><in name=\"source\" from=\"nb\"/>"},
    {"sharpen_gray_r4", "type=\"sharpen\" radius=\"4\"><in name=\"source\" from=\"h\"/>"},
    {"emboss", "type=\"emboss\" intensity=\"8\"><in name=\"height\" from=\"h\"/>"},
    {"edge_detect", "type=\"edge_detect\"><in name=\"source\" from=\"h\"/>"},
    {"dirblur_box_l4", "type=\"directional_blur\" angle=\"30\" length=\"4\"><in name=\"source\" "
                       "from=\"h\"/>"},
    {"dirblur_gauss_l4", "type=\"directional_blur\" angle=\"30\" length=\"4\" "
                         "kernel=\"gaussian\"><in name=\"source\" from=\"h\"/>"},
    {"dirblur_box_l4_color", "type=\"directional_blur\" angle=\"30\" length=\"4\"><in "
                             "name=\"source\" from=\"nb\"/>"},
    {"normal_blend_rnm", "type=\"normal_blend\"><in name=\"base\" from=\"nb\"/><in "
                         "name=\"detail\" from=\"nd\"/>"},
    {"normal_blend_whiteout", "type=\"normal_blend\" method=\"whiteout\"><in name=\"base\" "
                              "from=\"nb\"/><in name=\"detail\" from=\"nd\"/>"},
    {"normal_normalize", "type=\"normal_normalize\"><in name=\"normal\" from=\"nb\"/>"},
};

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int main(int argc, char **argv)
{
    int size = 2048, threads = 2, reps = 9;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc)
            size = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else {
            fprintf(stderr, "usage: %s [--size N] [--threads T] [--reps R]\n", argv[0]);
            return 2;
        }
    }
    if (reps < 1 || reps > 1000) reps = 9;
    if (size < 1 || size > 16384) size = 2048;
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
        char xml[2048];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"7\">\n"
                 "  <node id=\"h\" type=\"noise\" kind=\"perlin\" scale=\"8\" octaves=\"1\"/>\n"
                 "  <node id=\"h2\" type=\"noise\" kind=\"perlin\" scale=\"32\" octaves=\"1\"/>\n"
                 "  <node id=\"nb\" type=\"normal\" intensity=\"8\"><in name=\"height\" "
                 "from=\"h\"/></node>\n"
                 "  <node id=\"nd\" type=\"normal\" intensity=\"4\"><in name=\"height\" "
                 "from=\"h2\"/></node>\n"
                 "  <node id=\"n\" %s</node>\n"
                 "  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n",
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
            if (wg_render(e, r, &res, &err)) {
                fprintf(stderr, "%s: %s\n", cases[c].name, err.message);
                ok = 0;
                failed = 1;
                break;
            }
            t[k] = -1;
            for (int i = 0; i < wg_result_stat_count(res); i++)
                if (!strcmp(wg_result_stat(res, i)->id, "n")) t[k] = wg_result_stat(res, i)->ms;
            wg_result_free(res);
        }
        if (ok) {
            qsort(t, (size_t)reps, sizeof t[0], cmp_double);
            printf("%s\t%.2f\t%.2f\t%s\n", cases[c].name, t[reps / 2], t[reps / 2] / mp,
                   cases[c].node);
            fflush(stdout);
        }
        wg_request_free(r);
        wg_graph_free(g);
    }
    wg_engine_free(e);
    return failed;
}
