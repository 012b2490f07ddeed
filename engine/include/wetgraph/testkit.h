/* SPDX-License-Identifier: MIT */
/* The node test kit: what every built-in node is checked for, for node authors (docs/plugins.md).
 *
 * A node under test is a WgTestkitNode: its type, its parameters as "name=value" texts, and the
 * images fed to its input ports. The kit renders it through a small graph with the engine (so
 * parameters are parsed, checked and resampled exactly as in a .wetgraph file) and checks:
 *
 *   wg_testkit_run_graph      a small graph of several nodes, rendered the same way;
 *   wg_testkit_compare_fn     the output against a float64 reference function, within a
 *                             tolerance, reporting the worst pixel;
 *   wg_testkit_check_tiling   wrap-around: a rolled input gives the rolled output;
 *   wg_testkit_check_seamless a source's picture continues across its edges as inside;
 *   wg_testkit_check_invariance  bit-identical for 1 to 8 threads, whole or in bands of any
 *                             height (a point operation fused with its neighbours);
 *   wg_testkit_check_hard_inputs a battery of hard inputs (empty and full masks, flat, huge and
 *                             negative values, NaN and Inf, 1x1, non-square), each in a child
 *                             process, so a crash or a hang is reported, not suffered.
 *
 * Checks return true when they pass and fill a report saying what failed (or what was
 * checked), so a cmocka, Check or plain-assert test can print it. Not thread-safe: run checks
 * one at a time, with no other thread of the program running (the hard-input battery forks). */
#ifndef WETGRAPH_TESTKIT_H
#define WETGRAPH_TESTKIT_H

#include "error.h"
#include "image.h"
#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct WgTestkitNode {
    const char *type;
    const char *const *params;      /* "name=value" texts, NULL-terminated; NULL: defaults */
    const char *const *input_names; /* the input ports fed, NULL-terminated; NULL: none */
    const WgImage *const *inputs;   /* one image per port name, gray or RGBA */
    int width, height;              /* the node's size; 0: the first input's (64 for a source) */
    uint64_t seed;
    const char *output; /* the output port checked; NULL: the first */
} WgTestkitNode;

typedef struct WgTestkitReport {
    bool ok;
    double worst;    /* largest difference found (NaN where one side is NaN and not the other) */
    int x, y, c;     /* where */
    double got, want;
    char message[1024]; /* what failed, or what was checked */
} WgTestkitReport;

/* Render the node with `threads` workers (0: the machine's). *out is the checked output port's
 * image (the caller owns it). The engine's error otherwise. */
int wg_testkit_run(const WgTestkitNode *n, int threads, WgImage **out, WgError *err);

/* Render a small graph given as text (a .wetgraph document; `path` names it in errors and
 * resolves relative files, may be NULL) with `threads` workers: its parameters set from
 * "name=value" texts (NULL-terminated, or NULL), its image inputs fed (input_names and inputs,
 * NULL-terminated names), and *out the image of its output `output` (NULL: the first). The
 * caller owns *out. The engine's error otherwise. */
int wg_testkit_run_graph(const char *xml, const char *path, const char *const *params,
                         const char *const *input_names, const WgImage *const *inputs,
                         const char *output, int threads, WgImage **out, WgError *err);

/* got against ref(user, x, y, c), computed in double: |got - ref| <= tol everywhere (NaN only
 * where ref is NaN). */
typedef double (*WgTestkitRefFn)(void *user, int x, int y, int c);
bool wg_testkit_compare_fn(const WgImage *got, WgTestkitRefFn ref, void *user, double tol,
                           WgTestkitReport *rep);
/* got against want (same size and channels). */
bool wg_testkit_compare(const WgImage *got, const WgImage *want, double tol, WgTestkitReport *rep);

/* Roll every input by (dx, dy) pixels, with wrap-around: the output must be the first
 * output rolled by the same amount, within tol. Inputs must have the node's size. */
bool wg_testkit_check_tiling(const WgTestkitNode *n, int dx, int dy, double tol,
                             WgTestkitReport *rep);
/* Across each edge (last column to first, last row to first) the picture changes no more than
 * `factor` times the largest change between neighbours inside it: a generator's output tiles. */
bool wg_testkit_check_seamless(const WgImage *img, double factor, WgTestkitReport *rep);
/* The same bits with 1, 2, 3 and 8 threads, evaluated whole and, between two identity point
 * operations, fused in bands of 1, 3 and 7 rows. */
bool wg_testkit_check_invariance(const WgTestkitNode *n, WgTestkitReport *rep);

enum { WG_TESTKIT_MAX_CASES = 16 };
typedef struct WgTestkitCase {
    const char *name; /* "zeros", "ones", "flat", "huge", "negative", "nan", "inf", "1x1", ... */
    bool ok;
    char message[256]; /* what happened: "finite output", "refused: ...", "crashed: signal 11" */
} WgTestkitCase;
typedef struct WgTestkitHardReport {
    int n_cases, n_failed;
    WgTestkitCase cases[WG_TESTKIT_MAX_CASES];
    char summary[1024]; /* the failed cases, one per line, or "all N cases pass" */
} WgTestkitHardReport;
/* Each case replaces every input (keeping its channels): zeros (an empty mask), ones (a full
 * mask), flat 0.5, huge (1e6), negative (-1), nan and inf (a noise with one NaN or +Inf
 * pixel), 1x1 and 13x5 (noise at that size, the node at that size); a source runs at 1x1, 13x5
 * and 1x64. A case of values passes when the render succeeds with a finite output; nan and inf
 * pass when the render refuses them with an error or returns; a case of size passes when the
 * render succeeds with a finite output or refuses the size with an error (a node may need
 * sizes, as env_prefilter a square); every case fails on a crash or after 60 s. */
bool wg_testkit_check_hard_inputs(const WgTestkitNode *n, WgTestkitHardReport *rep);

/* Images for tests (the caller owns them; NULL for a bad size). */
WgImage *wg_testkit_image_fill(int width, int height, int channels, float value);
/* Deterministic values in [0, 1) from a hash of (x, y, c, seed); alpha 1. */
WgImage *wg_testkit_image_noise(int width, int height, int channels, uint32_t seed);
typedef double (*WgTestkitPixelFn)(void *user, int x, int y, int c);
WgImage *wg_testkit_image_fn(int width, int height, int channels, WgTestkitPixelFn fn, void *user);
/* src rolled by (dx, dy): out(x, y) = src(x - dx, y - dy), wrapping. */
WgImage *wg_testkit_image_roll(const WgImage *src, int dx, int dy);

#ifdef __cplusplus
}
#endif
#endif
