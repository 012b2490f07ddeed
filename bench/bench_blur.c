/* SPDX-License-Identifier: MIT */
/* Blur benchmark: per-pixel white noise in [0, 1] at N×N (default 2048²) feeds `blur` with
 * quality fast at σ = 2, 16, 64 and 256 pixels (sigma = σ·256/N) and, once per σ, quality exact.
 * The time is that of the blur node alone (its WgNodeStat, so the noise is not counted): the
 * median over the repetitions for fast (cache cleared before each), one run for exact (its cost
 * grows with σ: tens of seconds at 256 px). Also the max |fast − exact| over the image.
 *   bench_blur [--size N] [--threads T] [--reps R] [--no-exact]
 * Output: one line per σ, "sigma_px<TAB>fast_ms<TAB>exact_ms<TAB>max_abs_error". */
#include <wetgraph/wetgraph.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Render `quality` blur at sigma_px; returns the node's ms and (if keep) the output image. */
static double run(WgEngine *e, int size, double sigma_px, const char *quality, WgImage **keep)
{
    char xml[1024];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"7\">\n"
             "  <node id=\"h\" type=\"noise\" kind=\"white\" scale=\"%d\" octaves=\"1\"/>\n"
             "  <node id=\"n\" type=\"blur\" sigma=\"%.17g\" quality=\"%s\">"
             "<in name=\"source\" from=\"h\"/></node>\n"
             "  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n",
             size, size, size, sigma_px * 256 / size, quality);
    WgError err = {0};
    WgGraph *g = NULL;
    if (wg_graph_load_memory(xml, strlen(xml), "bench.wetgraph", &g, &err)) {
        fprintf(stderr, "%s\n", err.message);
        exit(1);
    }
    WgRequest *r = wg_request_new(g);
    wg_engine_clear_cache(e);
    WgResult *res = NULL;
    if (wg_render(e, r, &res, &err)) {
        fprintf(stderr, "%s\n", err.message);
        exit(1);
    }
    double ms = -1;
    for (int i = 0; i < wg_result_stat_count(res); i++)
        if (!strcmp(wg_result_stat(res, i)->id, "n")) ms = wg_result_stat(res, i)->ms;
    if (keep) *keep = wg_image_ref((WgImage *)wg_result_output_image(res, 0));
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
    return ms;
}

int main(int argc, char **argv)
{
    int size = 2048, threads = 2, reps = 9, exact = 1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc)
            size = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--no-exact"))
            exact = 0;
        else {
            fprintf(stderr, "usage: %s [--size N] [--threads T] [--reps R] [--no-exact]\n",
                    argv[0]);
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
    printf("# %dx%d gray, %d threads, fast: median of %d, exact: one run\n", size, size, threads,
           reps);
    static const double sigmas[] = {1, 2, 3, 4, 16, 64, 256};
    for (size_t s = 0; s < sizeof sigmas / sizeof sigmas[0]; s++) {
        double t[1000];
        WgImage *fast = NULL, *ref = NULL;
        for (int k = 0; k < reps; k++) t[k] = run(e, size, sigmas[s], "fast", k ? NULL : &fast);
        qsort(t, (size_t)reps, sizeof t[0], cmp_double);
        double te = -1, d = -1;
        if (exact) {
            te = run(e, size, sigmas[s], "exact", &ref);
            d = 0;
            for (int y = 0; y < size; y++)
                for (int x = 0; x < size; x++)
                    d = fmax(d, fabs((double)wg_image_row(fast, y)[x] - wg_image_row(ref, y)[x]));
            wg_image_unref(ref);
        }
        wg_image_unref(fast);
        printf("%g\t%.2f\t%.1f\t%.3g\n", sigmas[s], t[reps / 2], te, d);
        fflush(stdout);
    }
    wg_engine_free(e);
    return 0;
}
