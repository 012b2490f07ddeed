/* SPDX-License-Identifier: MIT */
/* `wetgraph dot`: Graphviz description of a graph on stdout. */
#include "cli.h"

#include <string.h>

static const char help[] =
    "usage: wetgraph dot [--fused] FILE\n"
    "\n"
    "Print a Graphviz description of the graph (render it with 'dot -Tsvg').\n"
    "\n"
    "  --fused   draw a cluster around each group of point operations a render evaluates\n"
    "            fused, band by band (all outputs, default values, nothing cached)\n";

int cmd_dot(int argc, char **argv)
{
    const char *file = NULL;
    bool fused = false;
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(help, stdout);
            return EXIT_OK;
        }
        if (!strcmp(argv[i], "--fused")) {
            fused = true;
            continue;
        }
        if (argv[i][0] == '-' && argv[i][1]) return cli_unknown_option("dot", help, argv[i]);
        if (file) return cli_usage_error("dot", "one graph file at a time");
        file = argv[i];
    }
    if (!file) return cli_usage_error("dot", "no graph file given");
    char path[4096];
    if (cli_find_graph(file, path, sizeof path)) return EXIT_USAGE;
    WgError err = {0};
    WgGraph *g;
    if (wg_graph_load(path, &g, &err)) {
        cli_report(&err);
        return cli_exit_for(err.code);
    }
    int rc;
    if (fused) { /* groups need a plan: default values, placeholders for required inputs */
        WgRequest *r = wg_request_new(g);
        rc = r ? cli_fill_placeholders(g, r, &err)
               : wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
        if (!rc) rc = wg_request_write_dot(r, stdout, &err);
        wg_request_free(r);
        if (rc) {
            cli_report(&err);
            wg_graph_free(g);
            return rc == WG_ERR_IO || rc == WG_ERR_NOMEM ? EXIT_FAILED : cli_exit_for(err.code);
        }
    } else {
        rc = wg_graph_write_dot(g, stdout);
    }
    wg_graph_free(g);
    return rc ? EXIT_FAILED : EXIT_OK;
}
