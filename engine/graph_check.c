/* SPDX-License-Identifier: MIT */
/* Checks of a graph read from its document that need all of it: `from` references resolved to
 * nodes, output ports and graph inputs (with spelling suggestions), input ports checked
 * against the node type or subgraph, inputs connected twice, required inputs left
 * unconnected, and cycles between nodes (an iterative depth-first search, so deep graphs do
 * not exhaust the stack). Errors carry the file and line of the element at fault. */
#include "load.h"

#include <ctype.h>
#include <stdio.h>
#include <string.h>

bool wg__valid_id(const char *s)
{
    if (!isalpha((unsigned char)*s) && *s != '_') return false;
    for (s++; *s; s++)
        if (!isalnum((unsigned char)*s) && *s != '_' && *s != '-') return false;
    return true;
}

static int node_input_count(const NodeDef *n)
{
    if (n->sub) return n->sub->n_inputs;
    int k = 0;
    while (n->type->inputs && n->type->inputs[k].name) k++;
    return k;
}

static const char *node_input_name(const NodeDef *n, int i)
{
    return n->sub ? n->sub->inputs[i].info.name : n->type->inputs[i].name;
}

/* Resolve "node", "node.port" or "$input" in graph g. */
int wg__resolve_from(Doc *d, WgGraph *g, const char *from, int line, int *node, int *port,
                     int *input)
{
    *node = -1;
    *port = 0;
    *input = -1;
    if (from[0] == '$') {
        *input = wg__graph_find_input(g, from + 1);
        if (*input < 0) {
            const char *names[256];
            int count = 0;
            for (int i = 0; i < g->n_inputs && count < 256; i++)
                names[count++] = g->inputs[i].info.name;
            const char *s = wg_suggest(from + 1, names, count);
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                   "no graph input '%s'%s%s%s", from + 1,
                                   s ? "; did you mean '$" : "", s ? s : "", s ? "'?" : "");
        }
        return WG_OK;
    }
    /* looked up by length in `from` itself: a copy in a buffer could cut a long id short and
     * find another node (id is only for messages) */
    const char *dot = strchr(from, '.');
    size_t len = dot ? (size_t)(dot - from) : strlen(from);
    char id[256];
    snprintf(id, sizeof id, "%.*s", (int)len, from);
    *node = wg__name_index_get(&g->node_index, from, len);
    if (*node < 0) {
        const char *names[1024];
        int count = 0;
        for (int i = 0; i < g->n_nodes && count < 1024; i++) names[count++] = g->nodes[i].id;
        const char *s = wg_suggest(id, names, count);
        if (s)
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                   "no node '%s'; did you mean '%s'?", id, s);
        return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                               "no node '%s' (a graph input is written '$name')", id);
    }
    NodeDef *src = &g->nodes[*node];
    int count = wg__node_output_count(src);
    if (dot) {
        *port = -1;
        for (int i = 0; i < count; i++)
            if (!strcmp(wg__node_output_name(src, i), dot + 1)) *port = i;
        if (*port < 0) {
            char list[512] = "";
            for (int i = 0; i < count; i++) {
                size_t l = strlen(list);
                snprintf(list + l, sizeof list - l, "%s%s", i ? ", " : "",
                         wg__node_output_name(src, i));
            }
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                   "node '%s' has no output '%s' (outputs: %s)", id, dot + 1, list);
        }
    }
    return WG_OK;
}

/* `seen` starts empty and collects the node's connected port names. */
int wg__link_node(Doc *d, WgGraph *g, NodeDef *n, WgNameIndex *seen)
{
    int n_ports = node_input_count(n);
    bool dynamic = n->type && (n->type->flags & WG_NODE_DYNAMIC_INPUTS);
    for (int k = 0; k < n->n_ins; k++) {
        InDef *in = &n->ins[k];
        int first = wg__name_index_get(seen, in->port, strlen(in->port));
        if (first >= 0)
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, in->line, 0,
                                   "node '%s': input '%s' is connected twice (first at line %d)",
                                   n->id, in->port, n->ins[first].line);
        if (wg__name_index_put(seen, in->port, strlen(in->port), k)) return nomem(d->err);
        in->port_index = -1;
        if (n->sub)
            in->port_index = wg__graph_find_input(n->sub, in->port);
        else
            for (int i = 0; i < n_ports; i++)
                if (!strcmp(node_input_name(n, i), in->port)) in->port_index = i;
        if (in->port_index < 0) {
            if (dynamic) {
                if (!wg__valid_id(in->port) || strchr(in->port, '-'))
                    return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, in->line, 0,
                                           "node '%s': input name '%s' must be a plain name "
                                           "(letters, digits, '_')",
                                           n->id, in->port);
                in->port_index = n_ports + k;
            } else {
                const char *names[64];
                int count = 0;
                for (int i = 0; i < n_ports && i < 64; i++) names[count++] = node_input_name(n, i);
                const char *s = wg_suggest(in->port, names, count);
                char list[512] = "";
                for (int i = 0; i < count; i++) {
                    size_t l = strlen(list);
                    snprintf(list + l, sizeof list - l, "%s%s", i ? ", " : "", names[i]);
                }
                if (s)
                    return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, in->line, 0,
                                           "node '%s' (%s) has no input '%s'; did you mean '%s'?",
                                           n->id, n->type_name, in->port, s);
                return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, in->line, 0,
                                       "node '%s' (%s) has no input '%s' (inputs: %s)", n->id,
                                       n->type_name, in->port, count ? list : "none");
            }
        }
        int rc = wg__resolve_from(d, g, in->from, in->line, &in->from_node, &in->from_port,
                                  &in->from_input);
        if (rc) return rc;
    }
    for (int i = 0; i < n_ports; i++) {
        bool required =
            n->type ? !n->type->inputs[i].optional : !n->sub->inputs[i].info.has_default;
        if (!required) continue;
        if (wg__name_index_get(seen, node_input_name(n, i), strlen(node_input_name(n, i))) < 0)
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, n->line, 0,
                                   "node '%s' (%s): required input '%s' is not connected; add "
                                   "<in name=\"%s\" from=\"...\"/>",
                                   n->id, n->type_name, node_input_name(n, i),
                                   node_input_name(n, i));
    }
    return WG_OK;
}

/* Depth-first search for a cycle; reports the node ids around it. */
int wg__find_cycle(Doc *d, WgGraph *g)
{
    int n = g->n_nodes;
    int *state = wg_calloc((size_t)n + 1, sizeof(int)); /* 0 new, 1 on stack, 2 done */
    int *stack = wg_calloc((size_t)n + 1, sizeof(int));
    int *edge = wg_calloc((size_t)n + 1, sizeof(int));
    int rc = WG_OK;
    if (!state || !stack || !edge) {
        rc = nomem(d->err);
        goto out;
    }
    for (int start = 0; start < n && !rc; start++) {
        if (state[start]) continue;
        int sp = 0;
        stack[sp] = start;
        edge[sp] = 0;
        state[start] = 1;
        while (sp >= 0 && !rc) {
            NodeDef *cur = &g->nodes[stack[sp]];
            if (edge[sp] >= cur->n_ins) {
                state[stack[sp]] = 2;
                sp--;
                continue;
            }
            int next = cur->ins[edge[sp]++].from_node;
            if (next < 0 || state[next] == 2) continue;
            if (state[next] == 1) {
                char path[1024] = "";
                int from = 0;
                while (stack[from] != next) from++;
                for (int i = from; i <= sp; i++) {
                    size_t l = strlen(path);
                    snprintf(path + l, sizeof path - l, "%s -> ", g->nodes[stack[i]].id);
                }
                size_t l = strlen(path);
                snprintf(path + l, sizeof path - l, "%s", g->nodes[next].id);
                rc = wg_error_set_at(d->err, WG_ERR_CYCLE, d->path, g->nodes[next].line, 0,
                                     "cycle between nodes: %s", path);
                break;
            }
            state[next] = 1;
            stack[++sp] = next;
            edge[sp] = 0;
        }
    }
out:
    wg_free(state);
    wg_free(stack);
    wg_free(edge);
    return rc;
}
