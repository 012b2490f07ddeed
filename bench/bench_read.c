/* SPDX-License-Identifier: MIT */
/* The `image` node's compute alone: reads FILE (colorspace COLORSPACE) as an `image` node of a
 * WxH graph (the file's own size, or another for resampling) --reps times on one engine with the
 * cache cleared before each render, so that every render after the first decodes into buffers
 * from the engine's pool, and prints the node's median time in ms. `wetgraph render --stats`
 * gives the same node in a new process, where its output is new memory the kernel clears on
 * first touch; the difference is that allocation. The first render of the engine is one of the
 * reps (the median drops it for reps >= 3).
 * Usage: bench_read [--threads T] [--reps R] FILE COLORSPACE WxH */
#include "benchlib.h"

#include <stdio.h>
#include <string.h>

/* s with XML's special characters escaped, into out (size bytes); false when it does not fit */
static bool xml_escape(const char *s, char *out, size_t size)
{
    size_t n = 0;
    for (; *s; s++) {
        const char *e = *s == '&'   ? "&amp;"
                        : *s == '<' ? "&lt;"
                        : *s == '>' ? "&gt;"
                        : *s == '"' ? "&quot;"
                                    : NULL;
        size_t k = e ? strlen(e) : 1;
        if (n + k + 1 > size) return false;
        memcpy(out + n, e ? e : s, k);
        n += k;
    }
    out[n] = 0;
    return true;
}

int main(int argc, char **argv)
{
    BenchArgs a;
    int rc = bench_args_pos(argc, argv, &a, 3);
    if (rc) return rc == 2 ? 0 : 1;
    if (a.n_pos != 3) {
        fprintf(stderr, "usage: bench_read [--threads T] [--reps R] FILE COLORSPACE WxH\n");
        return 1;
    }
    const char *const *pos = a.pos;
    char file[4096], xml[8192];
    if (!xml_escape(pos[0], file, sizeof file)) {
        fprintf(stderr, "bench_read: the path is too long\n");
        return 1;
    }
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"%s\">\n"
             "  <node id=\"n\" type=\"image\" path=\"%s\" colorspace=\"%s\"/>\n"
             "  <output name=\"o\" from=\"n\"/>\n"
             "</wetgraph>\n",
             pos[2], file, pos[1]);
    WgEngine *e = bench_engine(a.threads);
    if (!e) return 1;
    double ms = bench_node_ms(e, xml, "n", a.reps, "bench_read");
    wg_engine_free(e);
    if (ms < 0) return 1;
    printf("%.2f\n", ms);
    return 0;
}
