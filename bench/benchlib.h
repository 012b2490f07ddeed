/* SPDX-License-Identifier: MIT */
/* What the node benchmarks share: the common command line (--size, --threads, --reps), the
 * median time of one node over repeated renders with the cache cleared, and the time of one
 * memcpy of an image for scale (into memory written before, and into fresh pages). Output lines
 * are "name<TAB>ms<TAB>ms_per_MP<TAB>description". */
#ifndef WETGRAPH_BENCHLIB_H
#define WETGRAPH_BENCHLIB_H

#include <wetgraph/wetgraph.h>

#include <stdbool.h>
#include <stddef.h>

enum { BENCH_MAX_POS = 4 };

typedef struct BenchArgs {
    int size, threads, reps;
    const char *pos[BENCH_MAX_POS]; /* the arguments that are not options, in order */
    int n_pos;
} BenchArgs;

/* Parses --size N (default 2048), --threads T (2), --reps R (9); 2 after printing the usage. */
int bench_args(int argc, char **argv, BenchArgs *a);
/* The same, with up to max_pos (at most BENCH_MAX_POS) other arguments kept in a->pos. */
int bench_args_pos(int argc, char **argv, BenchArgs *a, int max_pos);
double bench_now_ms(void);
/* The median of t[0..n) (sorts t). */
double bench_median(double *t, int n);
/* An engine with `threads` workers and no disk cache; NULL after printing the error. */
WgEngine *bench_engine(int threads);
/* The median over `reps` renders of `xml` (cache cleared before each) of the evaluation time of
 * node `node_id`; -1 after printing the error, prefixed by `label`. */
double bench_node_ms(WgEngine *e, const char *xml, const char *node_id, int reps,
                     const char *label);
/* Runs bench_node_ms and prints its line; false on failure. */
bool bench_node_line(WgEngine *e, const char *xml, const char *label, const char *description,
                     const BenchArgs *a);
/* One memcpy of `bytes`, median of `reps`: into a buffer written before, or (fresh) into newly
 * mapped pages, which the kernel maps on first touch as it does for a node's new output. */
double bench_memcpy_ms(size_t bytes, int reps, bool fresh);
/* One memcpy of `bytes` between planes that are not in the cache: pairs of a set of planes
 * four times the last-level cache (or more, at least four planes; *span: their total) copied in
 * turn, as a node reads and writes images the render's other images pushed out; median of
 * `reps`. */
double bench_memcpy_memory_ms(size_t bytes, int reps, size_t *span);
/* The memcpy lines for a gray and a colour image of the benchmark's size, warm and fresh. */
void bench_memcpy_lines(const BenchArgs *a);

#endif
