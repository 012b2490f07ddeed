/* SPDX-License-Identifier: MIT */
/* Helpers shared by the subcommands: error reporting, JSON strings, sizes. */
#include "cli.h"

#include <ctype.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

int cli_exit_for(int code)
{
    switch (code) {
    case WG_ERR_IO:
    case WG_ERR_EVAL:
    case WG_ERR_NOMEM:
    case WG_ERR_BUDGET:
    case WG_ERR_CANCELLED:
        return EXIT_FAILED;
    default:
        return EXIT_USAGE;
    }
}

void cli_report(const WgError *err)
{
    char buf[4096];
    wg_error_format(err, buf, sizeof buf);
    /* messages quote what the user wrote (a --set value, a file name), which may hold a line
     * break: one error stays one line */
    fputs("wetgraph: error: ", stderr);
    for (const char *s = buf; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '\n')
            fputs("\\n", stderr);
        else if (c == '\r')
            fputs("\\r", stderr);
        else if ((c < 0x20 && c != '\t') || c == 0x7f)
            fprintf(stderr, "\\x%02x", c);
        else
            fputc(c, stderr);
    }
    fputc('\n', stderr);
}

int cli_find_graph(const char *arg, char *buf, size_t size)
{
    WgError err = {0};
    char *path = NULL;
    if (!wg_graph_find(arg, &path, &err) && strlen(path) >= size)
        wg_error_set_at(&err, WG_ERR_IO, arg, 0, 0, "path of the graph file too long");
    else if (path)
        memcpy(buf, path, strlen(path) + 1);
    bool ok = path && strlen(path) < size;
    wg_free(path);
    if (ok) return 0;
    cli_report(&err);
    return EXIT_USAGE;
}

bool cli_parse_bytes(const char *text, uint64_t *out)
{
    static const char units[] = "KMGT";
    size_t n = strlen(text), unit = 0;
    char num[64];
    const char *end = text + n;
    if (n >= 3 && !strcmp(end - 2, "iB")) end -= 2;
    if (end > text && strchr(units, end[-1]) && end[-1]) {
        unit = (size_t)(strchr(units, end[-1]) - units) + 1;
        end--;
    }
    if (end == text || (size_t)(end - text) >= sizeof num) return false;
    memcpy(num, text, (size_t)(end - text));
    num[end - text] = '\0';
    double v;
    if (!wg_parse_number(num, &v) || v < 0) return false;
    for (size_t i = 0; i < unit; i++) v *= 1024;
    if (v > 1152921504606846976.0) return false; /* 2^60 */
    *out = (uint64_t)v;
    return true;
}

int cli_unknown_option(const char *cmd, const char *help, const char *arg)
{
    enum { MAX = 128, LEN = 40 };
    char words[MAX][LEN];
    const char *names[MAX];
    int n = 0;
    for (const char *p = help; *p && n < MAX; p++) {
        bool start = p == help || *(p - 1) == ' ' || *(p - 1) == '\n' || *(p - 1) == '[';
        if (!start || *p != '-' || !(isalnum((unsigned char)p[1]) || p[1] == '-')) continue;
        size_t len = 1;
        while (len < LEN - 1 && (isalnum((unsigned char)p[len]) || p[len] == '-')) len++;
        snprintf(words[n], LEN, "%.*s", (int)len, p);
        bool seen = len < 2 || !strcmp(words[n], "--");
        for (int k = 0; k < n && !seen; k++) seen = !strcmp(words[k], words[n]);
        if (!seen) names[n] = words[n], n++;
    }
    char given[LEN];
    snprintf(given, sizeof given, "%.*s", (int)strcspn(arg, "="), arg);
    const char *near = wg_suggest(given, names, n);
    if (near) return cli_usage_error(cmd, "unknown option '%s'; did you mean '%s'?", arg, near);
    return cli_usage_error(cmd, "unknown option '%s'", arg);
}

int cli_usage_error(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "wetgraph %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n(see 'wetgraph %s --help')\n", cmd);
    va_end(ap);
    return EXIT_USAGE;
}

bool cli_is_help(const char *arg)
{
    return !strcmp(arg, "--help") || !strcmp(arg, "-h");
}

void cli_json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; s && *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(f, "\\%c", c);
        else if (c == '\n')
            fputs("\\n", f);
        else if (c == '\t')
            fputs("\\t", f);
        else if (c < 0x20)
            fprintf(f, "\\u%04x", c);
        else
            fputc(c, f);
    }
    fputc('"', f);
}

void cli_warning(const WgWarning *w, const char *prefix)
{
    fprintf(stderr, "wetgraph: warning: %s%s:%d: ", prefix ? prefix : "", w->file, w->line);
    if (w->node) fprintf(stderr, "node '%s': ", w->node);
    fprintf(stderr, "%s\n", w->message);
}

void cli_json_warning(FILE *f, const WgWarning *w)
{
    fprintf(f, "{\"file\": ");
    cli_json_string(f, w->file);
    fprintf(f, ", \"line\": %d, \"node\": ", w->line);
    if (w->node)
        cli_json_string(f, w->node);
    else
        fprintf(f, "null");
    fprintf(f, ", \"message\": ");
    cli_json_string(f, w->message);
    fprintf(f, "}");
}

int cli_fill_placeholders(const WgGraph *g, WgRequest *r, WgError *err)
{
    const char *size = wg_graph_size_text(g);
    if (size[0] == '$') wg_request_set_size(r, 256, 256);
    for (int i = 0; i < wg_graph_input_count(g); i++) {
        const WgGraphInputInfo *in = wg_graph_input_info(g, i);
        if (in->has_default) continue;
        WgImage *img = wg_image_new_zero(1, 1, in->kind == WG_COLOR ? 4 : 1);
        if (!img) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        int rc = wg_request_set_input_image(r, in->name, img, err);
        wg_image_unref(img);
        if (rc) return rc;
    }
    return WG_OK;
}

void cli_trim_after(WgEngine *e, const WgResult *res)
{
    size_t used = 0;
    for (int i = 0; i < wg_result_stat_count(res); i++) used += wg_result_stat(res, i)->bytes;
    wg_engine_trim(e, 2 * used, wg_result_peak_bytes(res));
}
