/* SPDX-License-Identifier: MIT */
/* The local web view of `wetgraph watch --serve [ADDR:]PORT` (cli/serve.c): an HTTP server on
 * its own threads that shows the latest render of the watch loop and queues parameter changes
 * for it. */
#ifndef WETGRAPH_CLI_SERVE_H
#define WETGRAPH_CLI_SERVE_H

#include "cli.h"

typedef struct Serve Serve;

/* Parse spec ("PORT", "ADDR:PORT" with an IPv4 ADDR, or "[ADDR]:PORT" with an IPv6 ADDR, "[::]"
 * taking IPv4 too; default 127.0.0.1) and start listening; the caller owns *out. A bad spec is
 * WG_ERR_RANGE, a failed listen WG_ERR_IO. */
int serve_start(const char *spec, const char *graph_file, Serve **out, WgError *err);
/* A descriptor that becomes readable when a parameter change is queued; serve_drain empties
 * it. */
int serve_fd(const Serve *s);
void serve_drain(Serve *s);
/* The --set list of the next render as "name=value" strings: base (the command line's --set
 * list) followed by the queued changes, a later entry for a name replacing an earlier one, and
 * its $time: the last one the page set (/api/set?$time=T), else base_time (the command line's
 * --time, or 0). Read together with emptying serve_fd, under the lock /api/set queues and
 * signals under: a wake-up left on serve_fd afterwards is always a change this list does not
 * have yet. The caller frees *out with serve_sets_free. */
int serve_sets(Serve *s, const char **base, int n_base, double base_time, char ***out, int *n,
               double *time);
void serve_sets_free(char **sets, int n);
/* Publish a finished render attempt: g (NULL when the graph did not load: the parameter list
 * stays as it was), the request r (NULL when it was not built), res (NULL when it failed; the
 * images stay as they were), err (NULL on success) and the --set list it used. Encodes the output
 * previews, finds whether the graph reads $time, draws the graph with dot when its Graphviz text
 * changed, and wakes /events. */
void serve_publish(Serve *s, const WgGraph *g, const WgRequest *r, const WgResult *res,
                   const WgError *err, const char *const *sets, int n_sets);
/* The 3D view's material and light, set once before the first render: inputs, the --input
 * list (NAME=FILE: the graph's image inputs are served at /map/$NAME as the dry material), and
 * envs, the --env files (equirectangular HDR environments); the graph's --input
 * environment=FILE is one too, and without any the built-in sky is used. */
int serve_view_setup(Serve *s, const char *const *inputs, int n_inputs, const char *const *envs,
                     int n_envs);
/* Prefilter (env_prefilter) the environments that have no atlas yet, with the watch thread's
 * engine e: once per environment and session; a file that cannot be read is reported (on
 * stderr and in the state) and not tried again. */
void serve_prefilter(Serve *s, WgEngine *e);
/* The node whose image the page asked to see (POST /api/set with $view=ID; $view= with no
 * value: none), or NULL; the caller frees it. */
char *serve_view_node(Serve *s);
/* Publish node id's image img (NULL when it could not be made, err says why), shown at
 * /view.png; the page hears of it as of a render. */
void serve_publish_view(Serve *s, const char *id, const WgImage *img, WgColorspace cs,
                        const WgError *err);
void serve_stop(Serve *s);

#endif
