/* SPDX-License-Identifier: MIT */
/* The wetgraph command line: one file per subcommand, all on the public API only. */
#ifndef WETGRAPH_CLI_H
#define WETGRAPH_CLI_H

#include <wetgraph/wetgraph.h>
#include <stdio.h>

/* Exit codes */
enum { EXIT_OK = 0, EXIT_FAILED = 1, EXIT_USAGE = 2 };

int cmd_render(int argc, char **argv);
int cmd_check(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_nodes(int argc, char **argv);
int cmd_dot(int argc, char **argv);
int cmd_watch(int argc, char **argv);
int cmd_cache(int argc, char **argv);
int cmd_graphs(int argc, char **argv);

/* Exit code for an error: 1 for I/O, evaluation, memory and budget failures, 2 for usage and
 * graph errors (parse, type, range, cycle). */
int cli_exit_for(int code);
/* "wetgraph: error: <location>: <message>" on stderr. */
void cli_report(const WgError *err);
/* A size in bytes: a decimal number, optionally followed by K, M, G or T (powers of 1024,
 * also written KiB, MiB, ...); whole bytes up to 2^60. */
bool cli_parse_bytes(const char *text, uint64_t *out);
/* The graph file a command line names, a path or a graph's name (wg_graph_find), into buf;
 * 0, or EXIT_USAGE after reporting that there is none. */
int cli_find_graph(const char *arg, char *buf, size_t size);
/* Usage error with a hint to --help; returns EXIT_USAGE. */
/* An unknown option `arg` of `cmd`: the usage error, suggesting the closest option that the
 * command's help text names (its -x and --name words). */
int cli_unknown_option(const char *cmd, const char *help, const char *arg);
int cli_usage_error(const char *cmd, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
bool cli_is_help(const char *arg);
/* JSON string literal. */
void cli_json_string(FILE *f, const char *s);
/* One graph warning on stderr: "wetgraph: warning: [prefix]FILE:LINE: [node 'id': ]message"
 * (prefix: NULL or text such as "list.txt:3: row 2: "). */
void cli_warning(const WgWarning *w, const char *prefix);
/* A warning as a JSON object: {"file": ..., "line": ..., "node": ... or null, "message": ...}. */
void cli_json_warning(FILE *f, const WgWarning *w);
/* For an engine that renders one request after another (watch, a batch): the memory cache
 * trimmed to about twice what `res` used, least recently used first (room for what the next
 * render shares with this one, not every result so far), and the pool to what a render like it
 * takes, so a long session stays near the size of one render and each render reuses memory
 * instead of taking new. */
void cli_trim_after(WgEngine *e, const WgResult *res);
/* Make a graph runnable for checking: placeholder images for inputs without a default. */
int cli_fill_placeholders(const WgGraph *g, WgRequest *r, WgError *err);

#endif
