/* SPDX-License-Identifier: MIT */
/* `wetgraph dot`: Graphviz description of a graph on stdout. */
#include "cli.h"

static const char help[] = "usage: wetgraph dot FILE\n"
                           "\n"
                           "Print a Graphviz description of the graph (render it with "
                           "'dot -Tsvg').\n";

int cmd_dot(int argc, char **argv)
{
    const char *file = NULL;
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(help, stdout);
            return EXIT_OK;
        }
        if (argv[i][0] == '-' && argv[i][1])
            return cli_usage_error("dot", "unknown option '%s'", argv[i]);
        if (file) return cli_usage_error("dot", "one graph file at a time");
        file = argv[i];
    }
    if (!file) return cli_usage_error("dot", "no graph file given");
    WgError err = {0};
    WgGraph *g;
    if (wg_graph_load(file, &g, &err)) {
        cli_report(&err);
        return cli_exit_for(err.code);
    }
    int rc = wg_graph_write_dot(g, stdout);
    wg_graph_free(g);
    return rc ? EXIT_FAILED : EXIT_OK;
}
