/* SPDX-License-Identifier: MIT */
/* `wetgraph graphs`: the graphs a name finds (render, watch, check, info and dot take a graph's
 * name as well as its file), from the WETGRAPH_PATH folders and the built-in one. */
#include "cli.h"

#include <string.h>

static const char help[] =
    "usage: wetgraph graphs [--paths]\n"
    "\n"
    "List the graphs that commands find by name ('wetgraph render wet_material'): the\n"
    ".wetgraph files in each folder of WETGRAPH_PATH (':'-separated), then in the built-in\n"
    "folder, each name once (the first folder holding it wins). One line per graph: its name\n"
    "and label; with --paths, its name and file.\n";

int cmd_graphs(int argc, char **argv)
{
    bool paths = false;
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(help, stdout);
            return EXIT_OK;
        }
        if (!strcmp(argv[i], "--paths"))
            paths = true;
        else if (argv[i][0] == '-')
            return cli_unknown_option("graphs", help, argv[i]);
        else
            return cli_usage_error("graphs", "unexpected argument '%s'", argv[i]);
    }
    WgError err = {0};
    WgGraphEntry *list = NULL;
    int count = 0;
    if (wg_graph_list(&list, &count, &err)) {
        cli_report(&err);
        return cli_exit_for(err.code);
    }
    for (int i = 0; i < count; i++) {
        if (paths) {
            printf("%-20s %s\n", list[i].name, list[i].path);
            continue;
        }
        /* the label from the file; a graph that does not load is listed with its error */
        WgGraph *g = NULL;
        WgError gerr = {0};
        if (wg_graph_load(list[i].path, &g, &gerr))
            printf("%-20s (does not load: %s)\n", list[i].name, gerr.message);
        else
            printf("%-20s %s\n", list[i].name, wg_graph_label(g) ? wg_graph_label(g) : "");
        wg_graph_free(g);
    }
    wg_graph_list_free(list, count);
    return EXIT_OK;
}
