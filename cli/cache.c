/* SPDX-License-Identifier: MIT */
/* `wetgraph cache`: the persistent result cache folder (render --cache DIR) as a whole: what it
 * holds, its least recently used entries removed down to a size, or all of them. */
#include "cli.h"

#include <string.h>
#include <time.h>

static const char help[] =
    "usage: wetgraph cache info DIR\n"
    "       wetgraph cache prune DIR --max SIZE\n"
    "       wetgraph cache clear DIR\n"
    "\n"
    "The result cache folder of 'render --cache DIR'. info: its entries, their size and their\n"
    "last use. prune: remove the least recently used entries (an entry is used when a render\n"
    "reads it back or writes it) until the entries take at most SIZE (bytes, or a decimal\n"
    "number with K, M, G or T: binary multiples). clear: remove every entry. Only the cache's\n"
    "own entry files (and the temporaries of processes that no longer run) are removed; renders\n"
    "using the folder meanwhile recompute what they miss. 'render --cache-max SIZE' prunes\n"
    "after each render.\n";

static void print_time(const char *label, time_t t)
{
    char buf[64];
    struct tm tm;
    if (t && localtime_r(&t, &tm) && strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", &tm))
        printf("%s %s\n", label, buf);
}

int cmd_cache(int argc, char **argv)
{
    const char *action = NULL, *dir = NULL, *max = NULL;
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(help, stdout);
            return EXIT_OK;
        }
        if (!strcmp(argv[i], "--max") || !strncmp(argv[i], "--max=", 6)) {
            if (argv[i][5] == '=')
                max = argv[i] + 6;
            else if (i + 1 < argc)
                max = argv[++i];
            else
                return cli_usage_error("cache", "--max needs a size");
        } else if (argv[i][0] == '-' && argv[i][1]) {
            return cli_unknown_option("cache", help, argv[i]);
        } else if (!action) {
            action = argv[i];
        } else if (!dir) {
            dir = argv[i];
        } else {
            return cli_usage_error("cache", "unexpected argument '%s'", argv[i]);
        }
    }
    static const char *const actions[] = {"info", "prune", "clear"};
    if (!action) return cli_usage_error("cache", "no action given (info, prune or clear)");
    int a = 0;
    while (a < 3 && strcmp(action, actions[a])) a++;
    if (a == 3) {
        const char *s = wg_suggest(action, actions, 3);
        return cli_usage_error("cache", "unknown action '%s'%s%s%s (info, prune or clear)", action,
                               s ? "; did you mean '" : "", s ? s : "", s ? "'?" : "");
    }
    if (!dir) return cli_usage_error("cache", "%s needs the cache folder", action);
    uint64_t cap = 0;
    if (a == 1 && !max) return cli_usage_error("cache", "prune needs --max SIZE");
    if (a != 1 && max) return cli_usage_error("cache", "--max goes with prune, not %s", action);
    if (max && !cli_parse_bytes(max, &cap))
        return cli_usage_error("cache",
                               "bad --max '%s' (a size: bytes, or a decimal number with K, M, "
                               "G or T)",
                               max);
    WgError err = {0};
    if (a == 0) {
        WgCacheDirInfo info;
        if (wg_cache_dir_info(dir, &info, &err)) {
            cli_report(&err);
            return EXIT_USAGE;
        }
        printf("%s: %lld entries, %.1f MiB\n", dir, info.entries, info.bytes / 1048576.0);
        print_time("least recently used:", info.oldest);
        print_time("most recently used: ", info.newest);
        return EXIT_OK;
    }
    WgCachePruned p;
    if (wg_cache_dir_prune(dir, cap, &p, &err)) {
        cli_report(&err);
        return EXIT_USAGE;
    }
    printf("%s: %lld entries removed (%.1f MiB), %.1f MiB left\n", dir, p.removed,
           p.freed / 1048576.0, p.left / 1048576.0);
    return EXIT_OK;
}
