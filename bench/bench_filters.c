/* SPDX-License-Identifier: MIT */
/* Filter benchmark: `sharpen`, `emboss`, `edge_detect`, `directional_blur`, `normal_blend` and
 * `normal_normalize` at N×N (default 2048²). The inputs are a 1-octave Perlin height (gray) and
 * normal maps made from two such heights (colour); the time of the filter node alone (its
 * WgNodeStat, so the inputs are not counted) is the median over the repetitions, cache cleared
 * before each.
 *   bench_filters [--size N] [--threads T] [--reps R]
 * Output: one line per case, "name<TAB>ms<TAB>ms_per_MP<TAB>description". */
#include "benchlib.h"

#include <stdio.h>
#include <string.h>

static const struct {
    const char *name, *node;
} cases[] = {
    {"sharpen_gray_r1", "type=\"sharpen\" radius=\"1\"><in name=\"source\" from=\"h\"/>"},
    {"sharpen_color_r1", "type=\"sharpen\" radius=\"1\"><in name=\"source\" from=\"nb\"/>"},
    {"sharpen_gray_r4", "type=\"sharpen\" radius=\"4\"><in name=\"source\" from=\"h\"/>"},
    {"sharpen_exact_gray_r1",
     "type=\"sharpen\" radius=\"1\" quality=\"exact\"><in name=\"source\" from=\"h\"/>"},
    {"sharpen_exact_gray_r4",
     "type=\"sharpen\" radius=\"4\" quality=\"exact\"><in name=\"source\" from=\"h\"/>"},
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

int main(int argc, char **argv)
{
    BenchArgs a;
    if (bench_args(argc, argv, &a)) return 2;
    WgEngine *e = bench_engine(a.threads);
    if (!e) return 1;
    printf("# %dx%d, %d threads, median of %d\n", a.size, a.size, a.threads, a.reps);
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
                 a.size, a.size, cases[c].node);
        failed |= !bench_node_line(e, xml, cases[c].name, cases[c].node, &a);
    }
    wg_engine_free(e);
    return failed;
}
