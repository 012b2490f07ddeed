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
#include "benchlib.h"

#include <stdio.h>
#include <string.h>

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
                 "  <node id=\"i\" type=\"noise\" kind=\"perlin\" scale=\"4\" octaves=\"4\"/>\n"
                 "  <node id=\"c\" type=\"merge\"><in name=\"r\" from=\"h\"/>"
                 "<in name=\"g\" from=\"i\"/><in name=\"b\" from=\"h\"/></node>\n"
                 "  <node id=\"n\" %s><in name=\"source\" from=\"%s\"/>%s</node>\n"
                 "  <output name=\"out\" from=\"n\"/>\n</wetgraph>\n",
                 a.size, a.size, cases[c].node, cases[c].source,
                 strstr(cases[c].node, "transform") ? "" : "<in name=\"intensity\" from=\"i\"/>");
        failed |= !bench_node_line(e, xml, cases[c].name, cases[c].node, &a);
    }
    wg_engine_free(e);
    bench_memcpy_lines(&a);
    return failed;
}
