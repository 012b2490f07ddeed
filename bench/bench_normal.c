/* SPDX-License-Identifier: MIT */
/* Height-field filter benchmark: a 1-octave Perlin height at N×N (default 2048²) feeds `normal`
 * or `slope`; the time of that node alone (its WgNodeStat, so the noise is not counted) is the
 * median over the repetitions, cache cleared before each. For scale it also times one memcpy of
 * the gray height (N²·4 bytes) and of the colour output (N²·16 bytes), single-threaded, median
 * of the same number of repetitions: into a buffer written before (warm) and into a fresh
 * allocation (first-touch page faults, which a node's newly allocated output also pays).
 *   bench_normal [--size N] [--threads T] [--reps R]
 * Output: one line per case, "name<TAB>ms<TAB>ms_per_MP<TAB>description". */
#include "benchlib.h"

#include <stdio.h>
#include <string.h>

static const struct {
    const char *name, *node;
} cases[] = {
    {"normal_central", "type=\"normal\" intensity=\"8\""},
    {"normal_sobel", "type=\"normal\" intensity=\"8\" method=\"sobel\""},
    {"slope_central", "type=\"slope\" intensity=\"8\""},
    {"slope_sobel", "type=\"slope\" intensity=\"8\" method=\"sobel\""},
};

int main(int argc, char **argv)
{
    BenchArgs a;
    if (bench_args(argc, argv, &a)) return 2;
    WgEngine *e = bench_engine(a.threads);
    if (!e) return 1;
    printf("# %dx%d, %d threads, median of %d\n", a.size, a.size, a.threads, a.reps);
    int failed = 0;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char xml[1024];
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"7\">\n"
                 "  <node id=\"h\" type=\"noise\" kind=\"perlin\" scale=\"8\" octaves=\"1\"/>\n"
                 "  <node id=\"n\" %s><in name=\"height\" from=\"h\"/></node>\n"
                 "  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n",
                 a.size, a.size, cases[c].node);
        failed |= !bench_node_line(e, xml, cases[c].name, cases[c].node, &a);
    }
    wg_engine_free(e);
    bench_memcpy_lines(&a);
    return failed;
}
