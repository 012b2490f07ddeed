/* SPDX-License-Identifier: MIT */
/* Resampling benchmark: `warp`, `directional_warp` and `transform` at N×N (default 2048²) on a
 * gray source (1-octave Perlin noise) or a colour one (two noises merged into RGBA), with a
 * 4-octave Perlin intensity whose gradient moves pixels by up to about 10 pixels; the time of
 * the node alone (its WgNodeStat, so the inputs are not counted) is the median over the
 * repetitions, cache cleared before each. For scale it also times one memcpy of a gray image
 * (N²·4 bytes) and of a colour one (N²·16 bytes), single-threaded, median of the same number
 * of repetitions: into a buffer written before (warm) and into a fresh allocation (first-touch
 * page faults, which a node's newly allocated output also pays).
 *   bench_warp [--size N] [--threads T] [--reps R]
 * Output: one line per case, "name<TAB>ms<TAB>ms_per_MP<TAB>description". */
#include <wetgraph/wetgraph.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

static const struct {
    const char *name, *node, *source;
} cases[] = {
    {"warp_gray", "type=\"warp\" amount=\"64\"", "h"},
    {"warp_color", "type=\"warp\" amount=\"64\"", "c"},
    {"warp_color_bicubic", "type=\"warp\" amount=\"64\" filter=\"bicubic\"", "c"},
    {"directional_warp_gray", "type=\"directional_warp\" amount=\"16\" angle=\"30\"", "h"},
    {"directional_warp_color", "type=\"directional_warp\" amount=\"16\" angle=\"30\"", "c"},
    {"transform_gray", "type=\"transform\" rotation=\"30\" scale_x=\"1.5\" scale_y=\"1.5\"", "h"},
    {"transform_color", "type=\"transform\" rotation=\"30\" scale_x=\"1.5\" scale_y=\"1.5\"", "c"},
    {"transform_color_bicubic",
     "type=\"transform\" rotation=\"30\" scale_x=\"1.5\" scale_y=\"1.5\" filter=\"bicubic\"", "c"},
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

/* One memcpy of `bytes`: into a buffer written before (warm) or into a fresh allocation, whose
 * pages the kernel maps on first touch, as it does for a node's freshly allocated output. */
static double memcpy_ms(size_t bytes, int reps, int fresh)
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
    for (int k = 0; k < reps; k++) {
        /* mmap: malloc may hand back the pages of the previous round */
        if (fresh && (b = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1,
                               0)) == MAP_FAILED)
            break;
        double t0 = now_ms();
        memcpy(b, a, bytes);
        t[k] = now_ms() - t0;
        a[k] = b[bytes - 1 - (size_t)k]; /* keep the copy observable */
        if (fresh) munmap(b, bytes), b = NULL;
    }
    free(a);
    free(b);
    qsort(t, (size_t)reps, sizeof t[0], cmp_double);
    return t[reps / 2];
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
        char xml[1024];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"7\">\n"
                 "  <node id=\"h\" type=\"noise\" kind=\"perlin\" scale=\"8\" octaves=\"1\"/>\n"
                 "  <node id=\"i\" type=\"noise\" kind=\"perlin\" scale=\"4\" octaves=\"4\"/>\n"
                 "  <node id=\"c\" type=\"merge\"><in name=\"r\" from=\"h\"/>"
                 "<in name=\"g\" from=\"i\"/><in name=\"b\" from=\"h\"/></node>\n"
                 "  <node id=\"n\" %s><in name=\"source\" from=\"%s\"/>%s</node>\n"
                 "  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n",
                 size, size, cases[c].node, cases[c].source,
                 strstr(cases[c].node, "transform") ? "" : "<in name=\"intensity\" from=\"i\"/>");
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
    size_t px = (size_t)size * (size_t)size;
    static const char *const what[] = {"warm", "fresh"};
    for (int fresh = 0; fresh < 2; fresh++) {
        double m1 = memcpy_ms(px * 4, reps, fresh), m4 = memcpy_ms(px * 16, reps, fresh);
        printf("memcpy_gray_%s\t%.2f\t%.2f\tone memcpy of a gray image (%zu MB)\n", what[fresh], m1,
               m1 / mp, px * 4 >> 20);
        printf("memcpy_color_%s\t%.2f\t%.2f\tone memcpy of a colour image (%zu MB)\n", what[fresh],
               m4, m4 / mp, px * 16 >> 20);
    }
    return failed;
}
