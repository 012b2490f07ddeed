/* SPDX-License-Identifier: MIT */
/* The loaded graph object: name lookups (node ids, inputs, outputs, parameters, a node's output
 * ports), freeing (graphs are reference-counted: subgraphs are shared by every node and graph
 * that uses them), introspection for the API and the CLI, and the Graphviz view. Reading a
 * .wetgraph document is in xml.c, its checks in graph_check.c, finding graph files in
 * graph_files.c. */
#include "internal.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- lookups ----------------------------------------------------------------------------- */

int wg__graph_find_param(const WgGraph *g, const char *name, size_t len)
{
    return wg__name_index_get(&g->param_index, name, len);
}

int wg__graph_find_input(const WgGraph *g, const char *name)
{
    return wg__name_index_get(&g->input_index, name, strlen(name));
}

int wg__graph_find_node(const WgGraph *g, const char *id)
{
    return wg__name_index_get(&g->node_index, id, strlen(id));
}

int wg__graph_find_output(const WgGraph *g, const char *name)
{
    return wg__name_index_get(&g->output_index, name, strlen(name));
}

int wg__node_output_count(const NodeDef *n)
{
    if (n->sub) return n->sub->n_outputs;
    int k = 0;
    while (n->type->outputs[k].name) k++;
    return k;
}

const char *wg__node_output_name(const NodeDef *n, int i)
{
    return n->sub ? n->sub->outputs[i].name : n->type->outputs[i].name;
}

/* ---- freeing ----------------------------------------------------------------------------- */

void wg_graph_free(WgGraph *g)
{
    if (!g || --g->refs > 0) return;
    for (int i = 0; i < g->n_params; i++) {
        ParamDef *p = &g->params[i];
        wg_free((char *)p->info.name);
        wg_free((char *)p->info.default_text);
        wg_free((char *)p->info.label);
        wg_free((char *)p->info.group);
        wg_free((char *)p->info.description);
        if (p->value_storage)
            for (int k = 0; p->value_storage[k]; k++) wg_free(p->value_storage[k]);
        wg_free(p->value_storage);
        wg__value_clear(&p->def);
    }
    wg_free(g->params);
    for (int i = 0; i < g->n_inputs; i++) {
        wg_free((char *)g->inputs[i].info.name);
        wg_free((char *)g->inputs[i].info.default_text);
    }
    wg_free(g->inputs);
    for (int i = 0; i < g->n_outputs; i++) {
        wg_free((char *)g->outputs[i].name);
        wg_free((char *)g->outputs[i].from);
        wg_free((char *)g->outputs[i].group);
    }
    wg_free(g->outputs);
    for (int i = 0; i < g->n_gltfs; i++) {
        wg_free((char *)g->gltfs[i].name);
        for (int k = 0; k < WG_GLTF_SLOT_COUNT; k++) wg_free((char *)g->gltfs[i].maps[k]);
        wg_free((char *)g->gltfs[i].height_scale_expr);
        if (g->gltf_height_exprs) wg_expr_free(g->gltf_height_exprs[i]);
    }
    wg_free(g->gltfs);
    wg_free(g->gltf_height_exprs);
    wg_free(g->output_node);
    wg_free(g->output_port);
    wg_free(g->output_input);
    for (int i = 0; i < g->n_nodes; i++) {
        NodeDef *n = &g->nodes[i];
        for (int k = 0; k < n->n_attrs; k++) {
            wg_free(n->attrs[k].name);
            wg_free(n->attrs[k].text);
            wg_expr_free(n->attrs[k].expr);
            wg__value_clear(&n->attrs[k].literal);
        }
        wg_free(n->attrs);
        for (int k = 0; k < n->n_ins; k++) {
            wg_free(n->ins[k].port);
            wg_free(n->ins[k].from);
        }
        wg_free(n->ins);
        wg_free(n->info_ports);
        wg_free(n->info_from);
        wg_free(n->id);
        wg_free(n->type_name);
        wg_free(n->size_text);
        wg_free(n->seed_text);
        wg_free(n->label);
        wg_graph_free(n->sub);
    }
    wg_free(g->nodes);
    for (int i = 0; i < g->n_warnings; i++) {
        WarningDef *w = &g->warnings[i];
        wg_free(w->when_text);
        wg_expr_free(w->when);
        for (int k = 0; k < w->n_parts; k++) {
            wg_free(w->parts[k].text);
            wg_expr_free(w->parts[k].expr);
        }
        wg_free(w->parts);
    }
    wg_free(g->warnings);
    wg_free(g->node_info);
    wg__name_index_free(&g->node_index);
    wg__name_index_free(&g->input_index);
    wg__name_index_free(&g->output_index);
    wg__name_index_free(&g->param_index);
    wg_free(g->path);
    wg_free(g->dir);
    wg_free(g->name);
    wg_free(g->label);
    wg_free(g->size_text);
    wg_free(g);
}

/* ---- introspection ----------------------------------------------------------------------- */

const char *wg_graph_name(const WgGraph *g)
{
    return g->name;
}
int wg_graph_gltf_count(const WgGraph *g)
{
    return g->n_gltfs;
}
const WgGraphGltfInfo *wg_graph_gltf_info(const WgGraph *g, int i)
{
    return i >= 0 && i < g->n_gltfs ? &g->gltfs[i] : NULL;
}
int wg_graph_find_gltf(const WgGraph *g, const char *name)
{
    for (int i = 0; i < g->n_gltfs; i++)
        if (!strcmp(g->gltfs[i].name, name)) return i;
    return -1;
}
const char *wg_graph_label(const WgGraph *g)
{
    return g->label;
}
const char *wg_graph_path(const WgGraph *g)
{
    return g->path;
}
const char *wg_graph_size_text(const WgGraph *g)
{
    return g->size_text;
}
uint64_t wg_graph_seed(const WgGraph *g)
{
    return g->seed;
}
int wg_graph_param_count(const WgGraph *g)
{
    return g->n_params;
}
const WgGraphParamInfo *wg_graph_param_info(const WgGraph *g, int i)
{
    return &g->params[i].info;
}
int wg_graph_input_count(const WgGraph *g)
{
    return g->n_inputs;
}
const WgGraphInputInfo *wg_graph_input_info(const WgGraph *g, int i)
{
    return &g->inputs[i].info;
}
int wg_graph_output_count(const WgGraph *g)
{
    return g->n_outputs;
}
const WgGraphOutputInfo *wg_graph_output_info(const WgGraph *g, int i)
{
    return &g->outputs[i];
}
int wg_graph_node_count(const WgGraph *g)
{
    return g->n_nodes;
}
const WgGraphNodeInfo *wg_graph_node_info(const WgGraph *g, int i)
{
    return &g->node_info[i];
}

static void dot_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        if (*s == '"' || *s == '\\') fputc('\\', f);
        fputc(*s, f);
    }
    fputc('"', f);
}

int wg_graph_write_dot(const WgGraph *g, FILE *f)
{
    wg__graph_write_dot(g, NULL, f);
    return ferror(f) ? WG_ERR_IO : WG_OK;
}

void wg__graph_write_dot(const WgGraph *g, const int *cluster, FILE *f)
{
    fprintf(f, "digraph ");
    dot_string(f, g->name);
    fprintf(f, " {\n  rankdir=LR;\n  node [fontname=\"Helvetica\", fontsize=10];\n");
    for (int i = 0; i < g->n_inputs; i++) {
        fprintf(
            f,
            "  \"$%s\" [shape=ellipse, style=filled, fillcolor=\"#dde8f0\", label=\"$%s\\n%s\"];\n",
            g->inputs[i].info.name, g->inputs[i].info.name,
            g->inputs[i].info.kind == WG_COLOR ? "color" : "gray");
    }
    for (int i = 0; i < g->n_nodes; i++) {
        const NodeDef *n = &g->nodes[i];
        fprintf(f, "  \"n:%s\" [shape=box, %slabel=\"%s\\n%s\"];\n", n->id,
                n->sub ? "style=\"rounded,filled\", fillcolor=\"#f0e8d8\", " : "", n->id,
                n->type_name);
    }
    for (int i = 0; i < g->n_nodes; i++) {
        const NodeDef *n = &g->nodes[i];
        for (int k = 0; k < n->n_ins; k++) {
            const InDef *in = &n->ins[k];
            if (in->from_node >= 0)
                fprintf(f, "  \"n:%s\" -> \"n:%s\" [label=\"%s\"];\n", g->nodes[in->from_node].id,
                        n->id, in->port);
            else
                fprintf(f, "  \"$%s\" -> \"n:%s\" [label=\"%s\"];\n",
                        g->inputs[in->from_input].info.name, n->id, in->port);
        }
    }
    for (int i = 0; i < g->n_outputs; i++) {
        fprintf(f, "  \"out:%s\" [shape=doubleoctagon, label=\"%s\"];\n", g->outputs[i].name,
                g->outputs[i].name);
        if (g->output_node[i] >= 0)
            fprintf(f, "  \"n:%s\" -> \"out:%s\";\n", g->nodes[g->output_node[i]].id,
                    g->outputs[i].name);
        else
            fprintf(f, "  \"$%s\" -> \"out:%s\";\n", g->inputs[g->output_input[i]].info.name,
                    g->outputs[i].name);
    }
    /* clusters by number, their nodes listed in file order: a counting sort */
    int most = 0;
    for (int i = 0; cluster && i < g->n_nodes; i++)
        if (cluster[i] > most) most = cluster[i];
    int *first = most ? wg_calloc((size_t)most + 2, sizeof(int)) : NULL;
    int *order = most ? wg_calloc((size_t)g->n_nodes + 1, sizeof(int)) : NULL;
    if (first && order) {
        for (int i = 0; i < g->n_nodes; i++) first[cluster[i] + 1] += cluster[i] > 0;
        for (int c = 1; c <= most; c++) first[c + 1] += first[c];
        for (int i = 0; i < g->n_nodes; i++)
            if (cluster[i] > 0) order[first[cluster[i]]++] = i;
        for (int c = 1, at = 0; c <= most; c++) {
            if (at == first[c]) continue;
            fprintf(f,
                    "  subgraph cluster_fused_%d {\n    label=\"fused #%d\";\n    style=\"dashed,"
                    "rounded\";\n    color=\"#4070a0\";\n",
                    c, c);
            for (; at < first[c]; at++) fprintf(f, "    \"n:%s\";\n", g->nodes[order[at]].id);
            fprintf(f, "  }\n");
        }
    } else if (most) {
        fprintf(f, "  /* out of memory: fused groups not drawn */\n");
    }
    wg_free(first);
    wg_free(order);
    fprintf(f, "}\n");
}
