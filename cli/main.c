/* SPDX-License-Identifier: MIT */
/* wetgraph: command-line entry point and subcommand dispatch. */
#include "cli.h"

#include <stdlib.h>
#include <string.h>

static const char usage[] =
    "wetgraph " WETGRAPH_VERSION " - node-graph texture engine\n"
    "\n"
    "usage: wetgraph COMMAND [ARGS]\n"
    "\n"
    "commands:\n"
    "  render FILE [options]   evaluate a graph and write its outputs\n"
    "  watch FILE [options]    render, then render again whenever the graph, a subgraph or\n"
    "                          an input image changes\n"
    "  check FILE...           validate graph files without evaluating them\n"
    "  info FILE [--json]      list a graph's parameters, inputs and outputs\n"
    "  nodes [TYPE] [--markdown]  the node catalogue (built-in and plugins')\n"
    "  graphs [--paths]        the graphs found by name\n"
    "  cache info|prune|clear DIR  the result cache folder: size, least recently used out\n"
    "  dot FILE [--fused]      Graphviz view of a graph\n"
    "\n"
    "FILE is a graph file, or the name of a graph in WETGRAPH_PATH or the built-in folder\n"
    "(wetgraph render wet_material; 'wetgraph graphs' lists them).\n"
    "\n"
    "Node plugins: every command takes --plugin LIB (repeatable), a shared library of node\n"
    "types, and loads those of the WETGRAPH_PLUGIN_PATH folders (colon-separated, every *.so).\n"
    "\n"
    "'wetgraph COMMAND --help' describes a command ('wetgraph --help-all': all of them).\n"
    "Exit codes: 0 ok, 1 evaluation or I/O failure, 2 usage or graph error.\n";

/* Load the plugins of WETGRAPH_PLUGIN_PATH and of every --plugin LIB (or --plugin=LIB), which
 * are taken out of argv: a node plugin's types are there for every command. */
static int load_plugins(int *argc, char **argv)
{
    WgError err = {0};
    if (wg_plugin_load_dirs(getenv("WETGRAPH_PLUGIN_PATH"), &err)) {
        cli_report(&err);
        return EXIT_USAGE;
    }
    int kept = 1;
    for (int i = 1; i < *argc; i++) {
        const char *lib = NULL;
        if (!strcmp(argv[i], "--plugin")) {
            if (i + 1 >= *argc) return cli_usage_error(argv[1], "--plugin needs a file");
            lib = argv[++i];
        } else if (!strncmp(argv[i], "--plugin=", 9)) {
            lib = argv[i] + 9;
        } else {
            argv[kept++] = argv[i];
            continue;
        }
        if (wg_plugin_load(lib, &err)) {
            cli_report(&err);
            return EXIT_USAGE;
        }
    }
    *argc = kept;
    argv[kept] = NULL;
    return EXIT_OK;
}

int main(int argc, char **argv)
{
    int rc = load_plugins(&argc, argv);
    if (rc) return rc;
    if (argc < 2) {
        fputs(usage, stderr);
        return EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (cli_is_help(cmd) || !strcmp(cmd, "help")) {
        fputs(usage, stdout);
        return EXIT_OK;
    }
    if (!strcmp(cmd, "--version")) {
        puts("wetgraph " WETGRAPH_VERSION);
        return EXIT_OK;
    }
    static const struct {
        const char *name;
        int (*fn)(int, char **);
    } cmds[] = {{"render", cmd_render}, {"check", cmd_check}, {"info", cmd_info},
                {"nodes", cmd_nodes},   {"dot", cmd_dot},     {"watch", cmd_watch},
                {"graphs", cmd_graphs}, {"cache", cmd_cache}};
    if (!strcmp(cmd, "--help-all")) {
        /* the overview and every command's --help, in one text: the man page's source */
        fputs(usage, stdout);
        for (size_t i = 0; i < sizeof cmds / sizeof cmds[0]; i++) {
            char name[16], help[] = "--help";
            snprintf(name, sizeof name, "%s", cmds[i].name);
            char *args[] = {name, help, NULL};
            printf("\n%s:\n\n", cmds[i].name);
            fflush(stdout);
            cmds[i].fn(2, args);
        }
        return EXIT_OK;
    }
    for (size_t i = 0; i < sizeof cmds / sizeof cmds[0]; i++)
        if (!strcmp(cmd, cmds[i].name)) return cmds[i].fn(argc - 1, argv + 1);
    const char *names[] = {"render", "check", "info", "nodes", "dot", "watch", "graphs", "cache"};
    const char *s = wg_suggest(cmd, names, 8);
    fprintf(stderr, "wetgraph: unknown command '%s'%s%s%s\n(see 'wetgraph --help')\n", cmd,
            s ? "; did you mean '" : "", s ? s : "", s ? "'?" : "");
    return EXIT_USAGE;
}
