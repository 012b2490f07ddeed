/* SPDX-License-Identifier: MIT */
/* `wetgraph info`: what a graph declares, as text or JSON. */
#include "cli.h"

#include <string.h>

static const char help[] =
    "usage: wetgraph info FILE [--json]\n"
    "\n"
    "List the graph's size, seed, parameters (type, default, range), image inputs and outputs.\n";

static const char *type_name(WgParamType t)
{
    static const char *const names[] = {"float", "int", "bool", "enum", "color", "string"};
    return (unsigned)t < 6 ? names[t] : "?";
}

static const char *gltf_slot_name(int k)
{
    static const char *const names[WG_GLTF_SLOT_COUNT] = {
        "base_color", "metallic",  "roughness",           "occlusion",        "normal",
        "specular",   "clearcoat", "clearcoat_roughness", "clearcoat_normal", "height"};
    return names[k];
}

static void print_json(const WgGraph *g)
{
    printf("{\n  \"name\": ");
    cli_json_string(stdout, wg_graph_name(g));
    printf(",\n  \"label\": ");
    if (wg_graph_label(g))
        cli_json_string(stdout, wg_graph_label(g));
    else
        printf("null");
    printf(",\n  \"size\": ");
    cli_json_string(stdout, wg_graph_size_text(g));
    printf(",\n  \"seed\": %llu,\n  \"params\": [", (unsigned long long)wg_graph_seed(g));
    for (int i = 0; i < wg_graph_param_count(g); i++) {
        const WgGraphParamInfo *p = wg_graph_param_info(g, i);
        printf("%s\n    {\"name\": ", i ? "," : "");
        cli_json_string(stdout, p->name);
        printf(", \"type\": \"%s\", \"default\": ", type_name(p->type));
        cli_json_string(stdout, p->default_text);
        if (p->has_min) printf(", \"min\": %.17g", p->min);
        if (p->has_max) printf(", \"max\": %.17g", p->max);
        if (p->label) {
            printf(", \"label\": ");
            cli_json_string(stdout, p->label);
        }
        if (p->has_soft_min) printf(", \"soft_min\": %.17g", p->soft_min);
        if (p->has_soft_max) printf(", \"soft_max\": %.17g", p->soft_max);
        if (p->has_step) printf(", \"step\": %.17g", p->step);
        if (p->group) {
            printf(", \"group\": ");
            cli_json_string(stdout, p->group);
        }
        if (p->description) {
            printf(", \"description\": ");
            cli_json_string(stdout, p->description);
        }
        if (p->values) {
            printf(", \"values\": [");
            for (int k = 0; p->values[k]; k++) {
                printf("%s", k ? ", " : "");
                cli_json_string(stdout, p->values[k]);
            }
            printf("]");
        }
        printf("}");
    }
    printf("\n  ],\n  \"inputs\": [");
    for (int i = 0; i < wg_graph_input_count(g); i++) {
        const WgGraphInputInfo *in = wg_graph_input_info(g, i);
        printf("%s\n    {\"name\": ", i ? "," : "");
        cli_json_string(stdout, in->name);
        printf(", \"type\": \"%s\", \"colorspace\": \"%s\"",
               in->kind == WG_COLOR ? "color" : "gray",
               in->colorspace == WG_SRGB ? "srgb" : "linear");
        if (in->has_default) {
            printf(", \"default\": ");
            cli_json_string(stdout, in->default_text);
        }
        printf("}");
    }
    printf("\n  ],\n  \"outputs\": [");
    for (int i = 0; i < wg_graph_output_count(g); i++) {
        const WgGraphOutputInfo *o = wg_graph_output_info(g, i);
        printf("%s\n    {\"name\": ", i ? "," : "");
        cli_json_string(stdout, o->name);
        printf(", \"from\": ");
        cli_json_string(stdout, o->from);
        printf(", \"format\": \"%s\", \"colorspace\": \"%s\", \"group\": ",
               o->format ? wg_format_name(o->format) : "default",
               o->colorspace == WG_SRGB ? "srgb" : "linear");
        if (o->group)
            cli_json_string(stdout, o->group);
        else
            printf("null");
        printf(", \"compression\": \"%s\"}", wg_png_compression_name(o->compression));
    }
    printf("\n  ],\n  \"gltf\": [");
    for (int i = 0; i < wg_graph_gltf_count(g); i++) {
        const WgGraphGltfInfo *a = wg_graph_gltf_info(g, i);
        printf("%s\n    {\"name\": ", i ? "," : "");
        cli_json_string(stdout, a->name);
        printf(", \"binary\": %s, \"grid\": %d, \"height_scale\": ", a->binary ? "true" : "false",
               a->grid);
        if (a->height_scale_expr) { /* an expression: its text, as written */
            char text[1100];
            snprintf(text, sizeof text, "=%s", a->height_scale_expr);
            cli_json_string(stdout, text);
        } else {
            printf("%.17g", a->height_scale);
        }
        printf(", \"repeat\": %.17g, \"maps\": {", a->repeat);
        for (int k = 0, n = 0; k < WG_GLTF_SLOT_COUNT; k++) {
            if (!a->maps[k]) continue;
            printf("%s\"%s\": ", n++ ? ", " : "", gltf_slot_name(k));
            cli_json_string(stdout, a->maps[k]);
        }
        printf("}}");
    }
    printf("\n  ],\n  \"nodes\": %d\n}\n", wg_graph_node_count(g));
}

static void print_text(const WgGraph *g)
{
    printf("graph %s (%s)\n", wg_graph_name(g), wg_graph_path(g));
    if (wg_graph_label(g)) printf("  \"%s\"\n", wg_graph_label(g));
    printf("  size %s, seed %llu, %d nodes\n", wg_graph_size_text(g),
           (unsigned long long)wg_graph_seed(g), wg_graph_node_count(g));
    printf("parameters:%s\n", wg_graph_param_count(g) ? "" : " none");
    for (int i = 0; i < wg_graph_param_count(g); i++) {
        const WgGraphParamInfo *p = wg_graph_param_info(g, i);
        printf("  %-20s %-6s default %s", p->name, type_name(p->type), p->default_text);
        if (p->has_min || p->has_max) {
            printf("  range [");
            if (p->has_min) printf("%g", p->min);
            printf(", ");
            if (p->has_max) printf("%g", p->max);
            printf("]");
        }
        if (p->has_soft_min || p->has_soft_max) {
            printf("  slider [");
            if (p->has_soft_min) printf("%g", p->soft_min);
            printf(", ");
            if (p->has_soft_max) printf("%g", p->soft_max);
            printf("]");
        }
        if (p->has_step) printf("  step %g", p->step);
        if (p->group) printf("  group %s", p->group);
        if (p->values) {
            printf("  values");
            for (int k = 0; p->values[k]; k++) printf("%s%s", k ? "|" : " ", p->values[k]);
        }
        if (p->label) printf("  \"%s\"", p->label);
        printf("\n");
    }
    printf("inputs:%s\n", wg_graph_input_count(g) ? "" : " none");
    for (int i = 0; i < wg_graph_input_count(g); i++) {
        const WgGraphInputInfo *in = wg_graph_input_info(g, i);
        printf("  %-20s %-6s %s%s%s\n", in->name, in->kind == WG_COLOR ? "color" : "gray",
               in->colorspace == WG_SRGB ? "srgb" : "linear",
               in->has_default ? "  default " : "  required",
               in->has_default ? in->default_text : "");
    }
    printf("outputs:\n");
    for (int i = 0; i < wg_graph_output_count(g); i++) {
        const WgGraphOutputInfo *o = wg_graph_output_info(g, i);
        printf("  %-20s from %-20s %s %s%s%s%s%s\n", o->name, o->from,
               o->format ? wg_format_name(o->format) : "default",
               o->colorspace == WG_SRGB ? "srgb" : "linear", o->group ? " group " : "",
               o->group ? o->group : "", o->compression ? " compression " : "",
               o->compression ? wg_png_compression_name(o->compression) : "");
    }
    if (wg_graph_gltf_count(g)) printf("glTF assets:\n");
    for (int i = 0; i < wg_graph_gltf_count(g); i++) {
        const WgGraphGltfInfo *a = wg_graph_gltf_info(g, i);
        printf("  %-20s %s", a->name, a->binary ? ".glb" : ".gltf");
        if (a->grid && a->height_scale_expr)
            printf(", grid %d, height scale =%s", a->grid, a->height_scale_expr);
        else if (a->grid)
            printf(", grid %d, height scale %g", a->grid, a->height_scale);
        if (a->repeat != 1) printf(", repeat %g", a->repeat);
        for (int k = 0; k < WG_GLTF_SLOT_COUNT; k++)
            if (a->maps[k]) printf(", %s %s", gltf_slot_name(k), a->maps[k]);
        printf("\n");
    }
}

int cmd_info(int argc, char **argv)
{
    const char *file = NULL;
    bool json = false;
    for (int i = 1; i < argc; i++) {
        if (cli_is_help(argv[i])) {
            fputs(help, stdout);
            return EXIT_OK;
        }
        if (!strcmp(argv[i], "--json"))
            json = true;
        else if (argv[i][0] == '-' && argv[i][1])
            return cli_unknown_option("info", help, argv[i]);
        else if (file)
            return cli_usage_error("info", "one graph file at a time");
        else
            file = argv[i];
    }
    if (!file) return cli_usage_error("info", "no graph file given");
    char path[4096];
    if (cli_find_graph(file, path, sizeof path)) return EXIT_USAGE;
    WgError err = {0};
    WgGraph *g;
    if (wg_graph_load(path, &g, &err)) {
        cli_report(&err);
        return cli_exit_for(err.code);
    }
    if (json)
        print_json(g);
    else
        print_text(g);
    wg_graph_free(g);
    return EXIT_OK;
}
