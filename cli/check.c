/* SPDX-License-Identifier: MIT */
/* `wetgraph check`: load each file and resolve it with default values (placeholder images for
 * inputs without a default), without evaluating anything. */
#include "cli.h"

#include <string.h>

static const char help[] =
    "usage: wetgraph check FILE...\n"
    "\n"
    "Validate graph files: syntax, node types, parameters, connections, types, cycles,\n"
    "subgraphs, and every value with the defaults (inputs without a default get a placeholder\n"
    "image). Nothing is evaluated. Prints 'FILE: ok' per valid file; exit 2 if any is not.\n"
    "Every independent error of a file is reported (up to 20), not those that follow from one.\n"
    "The graph's warnings that apply with the defaults are printed on stderr (they do not\n"
    "make a file invalid).\n";

int cmd_check(int argc, char **argv)
{
    int files = 0, bad = 0;
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(help, stdout);
            return EXIT_OK;
        }
        if (argv[i][0] == '-' && argv[i][1]) return cli_unknown_option("check", help, argv[i]);
    }
    for (int i = 1; i < argc; i++) {
        files++;
        WgError err = {0};
        WgGraph *g = NULL;
        WgRequest *r = NULL;
        char *path = NULL;
        int rc = wg_graph_find(argv[i], &path, &err);
        /* every independent error of the file, up to MAX_ERRORS, before its first is reported
         * below as before */
        if (!rc) {
            enum { MAX_ERRORS = 20 };
            WgError all[MAX_ERRORS];
            int n = 0;
            if (wg_graph_check_all(path, all, MAX_ERRORS, &n) && n > 1) {
                for (int k = 0; k < n; k++) cli_report(&all[k]);
                if (n == MAX_ERRORS)
                    fprintf(stderr, "wetgraph: %s: stopped after %d errors\n", argv[i], n);
                bad++;
                wg_free(path);
                continue;
            }
        }
        if (!rc) rc = wg_graph_load(path, &g, &err);
        wg_free(path);
        if (!rc && !(r = wg_request_new(g)))
            rc = wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
        if (!rc) rc = cli_fill_placeholders(g, r, &err);
        WgWarning *warnings = NULL;
        int n_warnings = 0;
        if (!rc) rc = wg_request_warnings(r, &warnings, &n_warnings, &err);
        if (rc) {
            cli_report(&err);
            bad++;
        } else {
            for (int k = 0; k < n_warnings; k++) cli_warning(&warnings[k], NULL);
            printf("%s: ok\n", argv[i]);
        }
        wg_warnings_free(warnings, n_warnings);
        wg_request_free(r);
        wg_graph_free(g);
    }
    if (!files) return cli_usage_error("check", "no graph file given");
    return bad ? EXIT_USAGE : EXIT_OK;
}
