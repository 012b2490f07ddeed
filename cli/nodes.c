/* SPDX-License-Identifier: MIT */
/* `wetgraph nodes`: the node catalogue, generated from the descriptors in the registry.
 * `--markdown` produces docs/nodes.md (a test checks the committed file is up to date). */
#include "cli.h"

#include <string.h>

static const char help[] =
    "usage: wetgraph nodes [TYPE] [--markdown]\n"
    "\n"
    "List the node types (built-in, then plugins'), or describe one: parameters (type,\n"
    "default, range), inputs and outputs. --markdown prints the reference in Markdown\n"
    "(docs/nodes.md).\n";

static const char *ptype(WgParamType t)
{
    static const char *const names[] = {"float", "int", "bool", "enum", "color", "string"};
    return (unsigned)t < 6 ? names[t] : "?";
}

static const char *kind(int k)
{
    return k == WG_GRAY ? "gray" : k == WG_COLOR ? "color" : "gray or color";
}

static void default_text(const WgParamSpec *s, char *buf, size_t n)
{
    switch (s->type) {
    case WG_PARAM_FLOAT_T:
        snprintf(buf, n, "%g", s->def);
        break;
    case WG_PARAM_INT_T:
        snprintf(buf, n, "%.0f", s->def);
        break;
    case WG_PARAM_BOOL_T:
        snprintf(buf, n, "%s", s->def != 0 ? "true" : "false");
        break;
    case WG_PARAM_ENUM_T:
        snprintf(buf, n, "%s", s->values[(int)s->def]);
        break;
    default:
        snprintf(buf, n, "%s", s->def_string ? s->def_string : "");
        break;
    }
}

static void range_text(const WgParamSpec *s, char *buf, size_t n)
{
    buf[0] = '\0';
    if (s->type == WG_PARAM_FLOAT_T || s->type == WG_PARAM_INT_T) {
        snprintf(buf, n, "%g .. %g", s->min, s->max);
        if (s->ui_min != s->min || s->ui_max != s->max) {
            size_t l = strlen(buf);
            snprintf(buf + l, n - l, " (UI %g .. %g)", s->ui_min, s->ui_max);
        }
    } else if (s->type == WG_PARAM_ENUM_T) {
        for (int k = 0; s->values[k]; k++) {
            size_t l = strlen(buf);
            snprintf(buf + l, n - l, "%s%s", k ? ", " : "", s->values[k]);
        }
    }
}

static void flags_text(unsigned f, char *buf, size_t n)
{
    static const struct {
        unsigned bit;
        const char *name;
    } names[] = {{WG_NODE_POINT, "point operation"},
                 {WG_NODE_NEIGHBOURHOOD, "neighbourhood"},
                 {WG_NODE_GLOBAL, "whole image"},
                 {WG_NODE_SOURCE, "source"},
                 {WG_NODE_SEEDED, "uses the seed"},
                 {WG_NODE_TIMED, "uses $time"},
                 {WG_NODE_DYNAMIC_INPUTS, "named inputs of your choice"},
                 {WG_NODE_EXTRA_PARAMS, "extra numeric attributes"}};
    buf[0] = '\0';
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        if (!(f & names[i].bit)) continue;
        size_t l = strlen(buf);
        snprintf(buf + l, n - l, "%s%s", l ? ", " : "", names[i].name);
    }
}

static void markdown(const WgNodeType *t)
{
    char a[512], b[512];
    printf("## `%s`\n\n%s.\n\n", t->name, t->summary);
    flags_text(t->flags, a, sizeof a);
    printf("Category: %s. %s%s\n\n", t->category, a[0] ? "Kind: " : "", a);
    if (t->doc) printf("%s\n\n", t->doc);
    if (t->params && t->params[0].name) {
        printf("| parameter | type | default | range | meaning |\n|---|---|---|---|---|\n");
        for (int i = 0; t->params[i].name; i++) {
            const WgParamSpec *s = &t->params[i];
            default_text(s, a, sizeof a);
            range_text(s, b, sizeof b);
            printf("| `%s` | %s | `%s` | %s | %s |\n", s->name, ptype(s->type), a, b,
                   s->label ? s->label : "");
        }
        printf("\n");
    }
    printf("Inputs: ");
    if (!t->inputs || !t->inputs[0].name) printf("none");
    for (int i = 0; t->inputs && t->inputs[i].name; i++)
        printf("%s`%s` (%s%s)", i ? ", " : "", t->inputs[i].name, kind(t->inputs[i].kind),
               t->inputs[i].optional ? ", optional" : "");
    printf(". Outputs: ");
    for (int i = 0; t->outputs[i].name; i++)
        printf("%s`%s` (%s)", i ? ", " : "", t->outputs[i].name, kind(t->outputs[i].kind));
    printf(".\n\n");
}

static void text(const WgNodeType *t)
{
    char a[512], b[512];
    printf("%s - %s\n", t->name, t->summary);
    flags_text(t->flags, a, sizeof a);
    printf("category: %s%s%s\n", t->category, a[0] ? "; " : "", a);
    if (wg_node_type_origin(t)) printf("plugin: %s\n", wg_node_type_origin(t));
    if (t->doc) printf("\n%s\n", t->doc);
    printf("\nparameters:%s\n", t->params && t->params[0].name ? "" : " none");
    for (int i = 0; t->params && t->params[i].name; i++) {
        const WgParamSpec *s = &t->params[i];
        default_text(s, a, sizeof a);
        range_text(s, b, sizeof b);
        printf("  %-14s %-6s default %-10s %s%s%s\n", s->name, ptype(s->type), a, b,
               s->label ? "  - " : "", s->label ? s->label : "");
    }
    printf("inputs:%s\n", t->inputs && t->inputs[0].name ? "" : " none");
    for (int i = 0; t->inputs && t->inputs[i].name; i++)
        printf("  %-14s %s%s\n", t->inputs[i].name, kind(t->inputs[i].kind),
               t->inputs[i].optional ? " (optional)" : "");
    printf("outputs:\n");
    for (int i = 0; t->outputs[i].name; i++)
        printf("  %-14s %s\n", t->outputs[i].name, kind(t->outputs[i].kind));
}

int cmd_nodes(int argc, char **argv)
{
    const char *type = NULL;
    bool md = false;
    const WgNodeType *const *types = wg_node_types_active();
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(help, stdout);
            return EXIT_OK;
        }
        if (!strcmp(argv[i], "--markdown"))
            md = true;
        else if (argv[i][0] == '-')
            return cli_unknown_option("nodes", help, argv[i]);
        else if (type)
            return cli_usage_error("nodes", "one node type at a time");
        else
            type = argv[i];
    }
    if (type) {
        const WgNodeType *t = wg_node_type_find(type);
        if (!t) {
            const char *names[256];
            int n = 0;
            for (; types[n] && n < 256; n++) names[n] = types[n]->name;
            const char *s = wg_suggest(type, names, n);
            fprintf(stderr, "wetgraph nodes: unknown node type '%s'%s%s%s\n", type,
                    s ? "; did you mean '" : "", s ? s : "", s ? "'?" : "");
            return EXIT_USAGE;
        }
        if (md)
            markdown(t);
        else
            text(t);
        return EXIT_OK;
    }
    if (md) {
        printf("# Node reference\n\n"
               "Generated by `wetgraph nodes --markdown` from the node descriptors; do not edit.\n"
               "Neighbourhood reads wrap around the edges, so filters keep tileable images "
               "tileable, and "
               "generators tile unless their description says otherwise. Inputs of another "
               "size are resampled to the node's size; a gray image fed to a colour input is "
               "promoted (R = G = B, alpha 1); colour fed to a gray input is an error.\n\n");
        for (int i = 0; types[i]; i++)
            printf("- [`%s`](#%s): %s\n", types[i]->name, types[i]->name, types[i]->summary);
        printf("\n");
        for (int i = 0; types[i]; i++) markdown(types[i]);
        return EXIT_OK;
    }
    for (int i = 0; types[i]; i++)
        if (wg_node_type_origin(types[i]))
            printf("%-14s %-9s %s  [plugin %s]\n", types[i]->name, types[i]->category,
                   types[i]->summary, wg_node_type_origin(types[i]));
        else
            printf("%-14s %-9s %s\n", types[i]->name, types[i]->category, types[i]->summary);
    return EXIT_OK;
}
