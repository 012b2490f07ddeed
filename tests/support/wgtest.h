/* SPDX-License-Identifier: MIT */
/* Shared helpers for the cmocka test suites: building small images, loading graphs from
 * strings, rendering, evaluating one node on given inputs, comparing images, and running the CLI in
 * the background. Every helper fails the current test (cmocka fail_msg) on unexpected errors, so
 * tests stay short. */
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
/* dir/name, in a static rotating buffer (valid for the next 16 calls of it or wgt_path). */
const char *wgt_join(const char *dir, const char *name);
/* wgt_tmpdir()/name, as wgt_join. */
const char *wgt_path(const char *name);
/* Write text to a file (e.g. a .wetgraph under wgt_tmpdir()). */
void wgt_write_file(const char *path, const char *text);
/* Run a shell command in `dir` with $WG set to the wetgraph binary (WETGRAPH_BIN), stdin from
 * /dev/null, stdout and stderr into dir/out and dir/err. Returns its exit status (-1 if it did
 * not exit). */
int wgt_shell(const char *dir, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* wgt_shell that must exit `want`: otherwise its stdout and stderr are printed and the test
 * fails naming `what` (WGT_SH passes the command's own text). */
void wgt_shell_expect(const char *dir, int want, const char *what, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
#define WGT_SH(dir, want, ...) wgt_shell_expect(dir, want, #__VA_ARGS__, __VA_ARGS__)
/* An empty folder wgt_tmpdir()/name, made again if it was there (static rotating buffer, valid
 * for the next 8 calls). */
const char *wgt_fresh_dir(const char *name);
/* Khronos' glTF-Validator (tools/gltf-validator) on `files`, relative to dir: no error and no
 * warning, or the test fails with its report (and says how to install it when it is not). */
void wgt_gltf_validate(const char *dir, const char *files);
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
/* Start WETGRAPH_BIN with args (NULL-terminated, without the program name) in the background:
 * in folder dir, stdout and stderr into dir/out_name and dir/err_name, and PATH set to path_env
 * unless it is NULL. Returns the process id (exit status 99: no such folder or files, 98: the
 * program did not start). */
pid_t wgt_spawn(const char *dir, const char *out_name, const char *err_name, const char *path_env,
                const char *const args[]);
/* Send sig to process pid and wait until it ends; after limit_ms (a harness limit) it is killed
 * and the test fails. Returns its wait status. */
int wgt_stop(pid_t pid, int sig, int limit_ms);
/* End process pid with SIGKILL if it still runs, and reap it (a teardown after a failure). */
void wgt_kill(pid_t pid);
/* Files under folder, recursively, whose names do not start with '.'; *hidden (may be NULL)
 * gets those whose names do (temporaries). A missing folder has none. */
int wgt_count_files(const char *folder, int *hidden);
/* Wait until folder holds more than `count` files (wgt_count_files). Fails when process pid
 * ends first, or after limit_ms (a harness limit). */
void wgt_wait_for_files(pid_t pid, const char *folder, int count, int limit_ms);
/* Text of a 1024x1024 graph that is slow to render: `params` (parameter declarations, with a
 * float `level`), a uniform u of level, a noise and a blur, then a chain of 16 ambient_occlusion
 * nodes with the given radius and directions attributes; output a is u, output c the last
 * occlusion. With radius 16 and 64 directions it is about 20 s of work on two threads. malloc'd:
 * free it. */
char *wgt_slow_graph(const char *params, const char *radius, const char *directions);

/* Image from values (row-major, `channels` per pixel; channels 1 or 4). values may be NULL
 * (zeros). Caller unrefs. */
WgImage *wgt_image(int w, int h, int channels, const float *values);
/* Image whose pixel (x, y, channel k) is fn(x, y, k). */
WgImage *wgt_image_fn(int w, int h, int channels, double (*fn)(int x, int y, int k));
static inline float wgt_px(const WgImage *img, int x, int y, int k)
{
    return wg_image_row(img, y)[x * img->channels + k];
}
/* A tile's seams, channel 0: the mean |difference| between each column and the next one inside
 * the image (inner_c) and across the wrap, last column to first (seam_c); rows the same way. A
 * seam shows as a wrap step far above the steps inside. */
typedef struct {
    double inner_c, inner_r, seam_c, seam_r;
} WgtSeams;
WgtSeams wgt_seams(const WgImage *img);

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
/* Do the files at paths a and b hold the same bytes? Fails the test if one cannot be read. */
bool wgt_same_file(const char *a, const char *b);

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
/* The images in the files at paths a and b (channels as stored) are bit-identical. */
void wgt_assert_identical_files(const char *a, const char *b);
/* max |a - b| <= tol over every channel. */
void wgt_assert_near(const WgImage *a, const WgImage *b, double tol);
double wgt_max_abs_diff(const WgImage *a, const WgImage *b);
/* Every value within [lo, hi] and finite. */
void wgt_assert_range(const WgImage *img, double lo, double hi);
/* The error has `code`, is located at `line` (0: don't check), and its formatted text contains
 * every part of `needles` (parts separated by '|'; NULL: don't check). */
void wgt_assert_error(const WgError *err, int code, int line, const char *needles);

/* WgWorkers runners for the writers' tests. wgt_run_backwards runs each part on a thread of its
 * own, the last parts first, and adds the parts to wgt_parts_run; with a ctx (any non-NULL) it
 * runs none and says it stopped early. wgt_run_skipping_one breaks the runners' contract: it
 * runs every part but the second, on the calling thread. */
int wgt_run_backwards(const void *ctx, int n, void (*fn)(void *, int, int), void *user);
int wgt_run_skipping_one(const void *ctx, int n, void (*fn)(void *, int, int), void *user);
extern _Atomic int wgt_parts_run;

#endif
