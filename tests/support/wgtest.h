/* SPDX-License-Identifier: MIT */
/* Shared helpers for the cmocka test suites: building small images, loading graphs from
 * strings, rendering, evaluating one node on given inputs, and comparing images. Every helper
 * fails the current test (cmocka fail_msg) on unexpected errors, so tests stay short. */
#ifndef WGTEST_H
#define WGTEST_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>
#include <cmocka.h>

#include <wetgraph/wetgraph.h>

/* Folder for scratch files of this test process (created on first use, under the build dir's
 * TMPDIR or /tmp); never shared between test executables. */
const char *wgt_tmpdir(void);
/* wgt_tmpdir()/name, in a static rotating buffer (valid for the next 8 calls). */
const char *wgt_path(const char *name);
/* Write text to a file (e.g. a .wetgraph under wgt_tmpdir()). */
void wgt_write_file(const char *path, const char *text);
/* Run a shell command in `dir` with $WG set to the wetgraph binary (WETGRAPH_BIN), stdin from
 * /dev/null, stdout and stderr into dir/out and dir/err. Returns its exit status (-1 if it did
 * not exit). */
int wgt_shell(const char *dir, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Does the path exist? */
bool wgt_exists(const char *path);
/* Occurrences of needle in the file at path (0 when the file does not exist). */
int wgt_count_in(const char *path, const char *needle);
void wgt_sleep_ms(int ms);
/* Wait until the file at log_path holds `count` occurrences of needle (a log a child process
 * writes). Fails when process pid ends first, or after limit_ms: a harness limit against hangs,
 * not a timing assertion. */
void wgt_wait_for(pid_t pid, const char *log_path, const char *needle, int count, int limit_ms);
/* A loopback TCP port nothing listens on now (bind port 0, read what the system chose). */
int wgt_free_port(void);

/* Image from values (row-major, `channels` per pixel; channels 1 or 4). values may be NULL
 * (zeros). Caller unrefs. */
WgImage *wgt_image(int w, int h, int channels, const float *values);
/* Image whose pixel (x, y, channel k) is fn(x, y, k). */
WgImage *wgt_image_fn(int w, int h, int channels, double (*fn)(int x, int y, int k));
static inline float wgt_px(const WgImage *img, int x, int y, int k)
{
    return wg_image_row(img, y)[x * img->channels + k];
}

/* Load a graph from text; `path` (may be NULL) is where it pretends to live (default:
 * wgt_tmpdir()/test.wetgraph). Fails the test on error. */
WgGraph *wgt_load(const char *xml);
WgGraph *wgt_load_at(const char *xml, const char *path);
/* Load expecting failure; returns the status and fills err. */
int wgt_load_error(const char *xml, WgError *err);

/* Render all outputs of a graph with `threads` workers and no cache. */
WgResult *wgt_render(const WgGraph *g, int threads);
/* An engine with these options; fails the test on error. */
WgEngine *wgt_engine(int threads, size_t memory_budget, const char *cache_dir);
/* Render a request on an engine; fails the test (with the formatted error) on failure. */
WgResult *wgt_render_request(WgEngine *e, const WgRequest *r);
/* The stats of node `id` in a result, or NULL. */
const WgNodeStat *wgt_stat(const WgResult *r, const char *id);
/* A whole file, NUL-terminated (malloc'd; free it); fails the test if it cannot be read. */
char *wgt_read_file(const char *path, size_t *size);

/* Output image by name from a result (borrowed). */
const WgImage *wgt_output(const WgResult *r, const char *name);

/* Evaluate one node of type `type` with attributes `attrs` (XML attribute text, may be "") at
 * size w x h. Inputs are connected by name: names[i] <- images[i] (any size; resampled).
 * Returns a new reference to output port `port`. */
WgImage *wgt_node(const char *type, const char *attrs, int w, int h, int n, const char **names,
                  const WgImage **images, int port, int threads);
/* Same, expecting failure at load, check or render; returns the status, fills err. */
int wgt_node_error(const char *type, const char *attrs, int w, int h, int n, const char **names,
                   const WgImage **images, WgError *err);

/* Assertions */
void wgt_assert_same_shape(const WgImage *a, const WgImage *b);
/* Bit-identical pixels. */
void wgt_assert_identical(const WgImage *a, const WgImage *b);
/* max |a - b| <= tol over every channel. */
void wgt_assert_near(const WgImage *a, const WgImage *b, double tol);
double wgt_max_abs_diff(const WgImage *a, const WgImage *b);
/* Every value within [lo, hi] and finite. */
void wgt_assert_range(const WgImage *img, double lo, double hi);
/* The error has `code`, is located at `line` (0: don't check), and its formatted text contains
 * every part of `needles` (parts separated by '|'; NULL: don't check). */
void wgt_assert_error(const WgError *err, int code, int line, const char *needles);

#endif
