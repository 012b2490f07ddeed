/* SPDX-License-Identifier: MIT */
/* Loading .wetgraph files with libxml2 into validated definitions. Everything that can be
 * checked without parameter values or images is checked here, with the file and line of the
 * offending element: unknown elements and attributes, node types, parameters and ports,
 * malformed literals and expressions, duplicate ids, dangling references, unconnected required
 * inputs, cycles between nodes and recursion between graph files. Subgraphs are loaded once per
 * load and shared. Instantiation with concrete values is in plan.c. */
#include "internal.h"

#include <ctype.h>
#include <stdint.h>
#include <errno.h>
#include <libxml/parser.h>
#include <libxml/tree.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#ifndef WG_SOURCE_GRAPHS_DIR
#define WG_SOURCE_GRAPHS_DIR ""
#endif
#ifndef WG_INSTALL_GRAPHS_DIR
#define WG_INSTALL_GRAPHS_DIR ""
#endif

typedef struct LoadCtx {
    char *stack[64]; /* real paths of the graphs being loaded, outermost first */
    int depth;
    WgGraph **loaded; /* every graph file loaded so far, shared by all that use it */
    char **loaded_real;
    int n_loaded, cap_loaded;
    WgNameIndex loaded_index; /* real path -> position in loaded */
} LoadCtx;

static void load_ctx_free(LoadCtx *lc)
{
    for (int i = 0; i < lc->n_loaded; i++) wg_free(lc->loaded_real[i]);
    wg_free(lc->loaded);
    wg_free(lc->loaded_real);
    wg__name_index_free(&lc->loaded_index);
}

static int load_file(LoadCtx *lc, const char *path, WgGraph **out, WgError *err);
static int load_doc(LoadCtx *lc, xmlDocPtr doc, const char *path, WgGraph **out, WgError *err);

/* ---- small helpers ----------------------------------------------------------------------- */

static bool file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static bool dir_exists(const char *path)
{
    struct stat st;
    return path[0] && stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

const char *wg_builtin_graphs_dir(void)
{
    const char *env = getenv("WETGRAPH_GRAPHS_DIR");
    if (env && dir_exists(env)) return env;
    if (dir_exists(WG_SOURCE_GRAPHS_DIR)) return WG_SOURCE_GRAPHS_DIR;
    return WG_INSTALL_GRAPHS_DIR;
}

static char *dir_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash) return wg_strdup(".");
    if (slash == path) return wg_strdup("/");
    return wg_strndup(path, (size_t)(slash - path));
}

static char *join_path(const char *dir, const char *name)
{
    if (name[0] == '/' || !dir || !dir[0]) return wg_strdup(name);
    size_t n = strlen(dir) + strlen(name) + 2;
    char *p = wg_malloc(n);
    if (p) snprintf(p, n, "%s/%s", dir, name);
    return p;
}

static bool ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

static int levenshtein(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 64 || lb > 64) return 99;
    int row[65];
    for (size_t j = 0; j <= lb; j++) row[j] = (int)j;
    for (size_t i = 1; i <= la; i++) {
        int prev = row[0];
        row[0] = (int)i;
        for (size_t j = 1; j <= lb; j++) {
            int cur = row[j];
            int cost = tolower((unsigned char)a[i - 1]) != tolower((unsigned char)b[j - 1]);
            int best = prev + cost;
            if (row[j] + 1 < best) best = row[j] + 1;
            if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
            row[j] = best;
            prev = cur;
        }
    }
    return row[lb];
}

const char *wg_suggest(const char *word, const char *const *candidates, int count)
{
    const char *best = NULL;
    int best_d = 3;
    size_t wl = strlen(word);
    for (int i = 0; i < count; i++) {
        if (!candidates[i]) continue;
        int d = levenshtein(word, candidates[i]);
        int limit = wl <= 3 ? 1 : 2;
        if (d <= limit && d < best_d) {
            best = candidates[i];
            best_d = d;
        }
    }
    if (!best && wl >= 3) {
        for (int i = 0; i < count; i++)
            if (candidates[i] && !strncmp(candidates[i], word, wl)) return candidates[i];
    }
    return best;
}

static bool valid_id(const char *s)
{
    if (!isalpha((unsigned char)*s) && *s != '_') return false;
    for (s++; *s; s++)
        if (!isalnum((unsigned char)*s) && *s != '_' && *s != '-') return false;
    return true;
}

bool wg_parse_size(const char *text, int *w, int *h)
{
    char *end;
    if (!isdigit((unsigned char)*text)) return false; /* strtol would take spaces and signs */
    long a = strtol(text, &end, 10);
    long b = a;
    if (*end == 'x' || *end == 'X') {
        const char *s = end + 1;
        if (!isdigit((unsigned char)*s)) return false;
        b = strtol(s, &end, 10);
    }
    if (*end) return false;
    if (a < 1 || b < 1 || a > WG_MAX_SIDE || b > WG_MAX_SIDE) return false;
    *w = (int)a;
    *h = (int)b;
    return true;
}

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

/* ---- freeing ----------------------------------------------------------------------------- */

void wg_graph_free(WgGraph *g)
{
    if (!g || --g->refs > 0) return;
    for (int i = 0; i < g->n_params; i++) {
        ParamDef *p = &g->params[i];
        wg_free((char *)p->info.name);
        wg_free((char *)p->info.default_text);
        wg_free((char *)p->info.label);
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
    }
    wg_free(g->outputs);
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
    wg_free(g->node_info);
    wg__name_index_free(&g->node_index);
    wg__name_index_free(&g->input_index);
    wg__name_index_free(&g->output_index);
    wg__name_index_free(&g->param_index);
    wg_free(g->path);
    wg_free(g->dir);
    wg_free(g->name);
    wg_free(g->size_text);
    wg_free(g);
}

/* ---- XML helpers ------------------------------------------------------------------------- */

typedef struct Doc {
    const char *path;
    WgError *err;
    WgNameIndex subgraphs; /* node type -> the first node of this file using that subgraph */
} Doc;

/* libxml2 numbers an element by the line where its start tag ends. People look for the line
 * where it starts, and for the line of the attribute at fault, so after parsing, one pass over
 * the text (elements appear in it in document order) stores both in the nodes' _private field. */
typedef struct Scan {
    const char *p, *end;
    int line;
    bool lost; /* the text did not match the tree: keep libxml2's lines */
} Scan;

static void scan_advance(Scan *sc, const char *to)
{
    for (; sc->p < to && sc->p < sc->end; sc->p++) sc->line += *sc->p == '\n';
}

static void scan_skip_past(Scan *sc, const char *token)
{
    size_t n = strlen(token);
    const char *q = sc->p;
    while (q + n <= sc->end && memcmp(q, token, n)) q++;
    scan_advance(sc, q + n <= sc->end ? q + n : sc->end);
}

static void scan_element(Scan *sc, xmlNodePtr e)
{
    /* find the start tag of e, skipping comments, processing instructions and end tags */
    for (;;) {
        const char *lt = memchr(sc->p, '<', (size_t)(sc->end - sc->p));
        if (!lt) {
            sc->lost = true;
            return;
        }
        scan_advance(sc, lt);
        if (!strncmp(sc->p, "<!--", 4))
            scan_skip_past(sc, "-->");
        else if (!strncmp(sc->p, "<![CDATA[", 9))
            scan_skip_past(sc, "]]>");
        else if (!strncmp(sc->p, "<?", 2))
            scan_skip_past(sc, "?>");
        else if (sc->p[1] == '!' || sc->p[1] == '/')
            scan_skip_past(sc, ">");
        else
            break;
    }
    size_t nl = strlen((const char *)e->name);
    if ((size_t)(sc->end - sc->p) < nl + 1 || memcmp(sc->p + 1, e->name, nl)) {
        sc->lost = true;
        return;
    }
    e->_private = (void *)(intptr_t)sc->line;
    scan_advance(sc, sc->p + 1 + nl);
    /* attributes: name, '=', quoted value; until '>' or '/>' */
    while (sc->p < sc->end && *sc->p != '>' && *sc->p != '/') {
        if (isspace((unsigned char)*sc->p)) {
            scan_advance(sc, sc->p + 1);
            continue;
        }
        const char *name = sc->p;
        int line = sc->line;
        while (sc->p < sc->end && *sc->p != '=' && !isspace((unsigned char)*sc->p)) sc->p++;
        size_t len = (size_t)(sc->p - name);
        for (xmlAttrPtr a = e->properties; a; a = a->next)
            if (strlen((const char *)a->name) == len && !memcmp(a->name, name, len))
                a->_private = (void *)(intptr_t)line;
        const char *quote = sc->p;
        while (quote < sc->end && *quote != '"' && *quote != '\'') quote++;
        if (quote >= sc->end) {
            sc->lost = true;
            return;
        }
        const char *close = memchr(quote + 1, *quote, (size_t)(sc->end - quote - 1));
        if (!close) {
            sc->lost = true;
            return;
        }
        scan_advance(sc, close + 1);
    }
    for (xmlNodePtr c = e->children; c && !sc->lost; c = c->next)
        if (c->type == XML_ELEMENT_NODE) scan_element(sc, c);
}

static void annotate_lines(xmlDocPtr doc, const char *text, size_t len)
{
    Scan sc = {text, text + len, 1, false};
    xmlNodePtr root = xmlDocGetRootElement(doc);
    if (root) scan_element(&sc, root);
}

static int line_of(xmlNodePtr n)
{
    return n->_private ? (int)(intptr_t)n->_private : (int)xmlGetLineNo(n);
}

static int attr_line(xmlAttrPtr a, int fallback)
{
    return a && a->_private ? (int)(intptr_t)a->_private : fallback;
}

/* Out of memory, with a message like every other error (the bare code would leave it empty). */
static int nomem(WgError *err)
{
    return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
}

/* Copy of attribute `name` in *out, NULL when it is absent. A failed copy is WG_ERR_NOMEM:
 * it must not pass for a missing attribute. */
static int attr(Doc *d, xmlNodePtr n, const char *name, char **out)
{
    *out = NULL;
    xmlChar *v = xmlGetProp(n, (const xmlChar *)name);
    if (!v) return WG_OK;
    *out = wg_strdup((const char *)v);
    xmlFree(v);
    return *out ? WG_OK : nomem(d->err);
}

/* Report the first attribute of `n` not in `allowed` (NULL-terminated). */
static int check_attrs(Doc *d, xmlNodePtr n, const char *const *allowed)
{
    for (xmlAttrPtr a = n->properties; a; a = a->next) {
        const char *name = (const char *)a->name;
        bool ok = false;
        int count = 0;
        for (; allowed[count]; count++) ok |= !strcmp(allowed[count], name);
        if (ok) continue;
        const char *s = wg_suggest(name, allowed, count);
        if (s)
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, attr_line(a, line_of(n)), 0,
                                   "unknown attribute '%s' on <%s>; did you mean '%s'?", name,
                                   (const char *)n->name, s);
        return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, attr_line(a, line_of(n)), 0,
                               "unknown attribute '%s' on <%s>", name, (const char *)n->name);
    }
    return WG_OK;
}

static int need_attr(Doc *d, xmlNodePtr n, const char *name, char **out)
{
    int rc = attr(d, n, name, out);
    if (!rc && !*out)
        return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line_of(n), 0,
                               "<%s> needs a '%s' attribute", (const char *)n->name, name);
    return rc;
}

static int check_no_text(Doc *d, xmlNodePtr n)
{
    for (xmlNodePtr c = n->children; c; c = c->next) {
        /* entities are not expanded (that could read files): their text or elements would be
         * skipped unseen */
        if (c->type == XML_ENTITY_REF_NODE)
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line_of(c), 0,
                                   "unexpected entity reference '&%s;' inside <%s>",
                                   (const char *)c->name, (const char *)n->name);
        if (c->type != XML_TEXT_NODE && c->type != XML_CDATA_SECTION_NODE) continue;
        for (const xmlChar *s = c->content; s && *s; s++)
            if (!isspace(*s))
                return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line_of(c), 0,
                                       "unexpected text inside <%s>", (const char *)n->name);
    }
    return WG_OK;
}

/* <param>, <input>, <output> and <in> hold neither text nor elements. */
static int check_leaf(Doc *d, xmlNodePtr n)
{
    for (xmlNodePtr c = n->children; c; c = c->next)
        if (c->type == XML_ELEMENT_NODE)
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line_of(c), 0,
                                   "unexpected <%s> inside <%s>", (const char *)c->name,
                                   (const char *)n->name);
    return check_no_text(d, n);
}

/* ---- <param> ----------------------------------------------------------------------------- */

static const char *const param_types[] = {"float", "int", "bool", "color", "enum", "string", NULL};
static const WgParamType param_type_values[] = {WG_PARAM_FLOAT_T, WG_PARAM_INT_T,
                                                WG_PARAM_BOOL_T,  WG_PARAM_COLOR_T,
                                                WG_PARAM_ENUM_T,  WG_PARAM_STRING_T};

static int parse_enum_values(ParamDef *p, const char *text)
{
    int cap = 1;
    for (const char *s = text; *s; s++) cap += (*s == '|' || *s == ',' || *s == ' ');
    p->value_storage = wg_calloc((size_t)cap + 1, sizeof(char *));
    if (!p->value_storage) return WG_ERR_NOMEM;
    int n = 0;
    const char *s = text;
    while (*s) {
        while (*s == '|' || *s == ',' || *s == ' ') s++;
        const char *e = s;
        while (*e && *e != '|' && *e != ',' && *e != ' ') e++;
        if (e > s && !(p->value_storage[n++] = wg_strndup(s, (size_t)(e - s)))) return WG_ERR_NOMEM;
        s = e;
    }
    p->info.values = (const char *const *)p->value_storage;
    return n;
}

static int parse_param(Doc *d, WgGraph *g, xmlNodePtr x)
{
    static const char *const allowed[] = {"name", "type",  "default", "min",
                                          "max",  "label", "values",  NULL};
    int line = line_of(x);
    int rc = check_attrs(d, x, allowed);
    if (rc) return rc;
    ParamDef *p = &g->params[g->n_params];
    memset(p, 0, sizeof *p);
    p->info.line = line;
    char *name = NULL, *type = NULL, *label = NULL, *def = NULL, *min = NULL, *max = NULL,
         *values = NULL;
    if ((rc = need_attr(d, x, "name", &name)) || (rc = need_attr(d, x, "type", &type)) ||
        (rc = attr(d, x, "label", &label)) || (rc = attr(d, x, "default", &def)) ||
        (rc = attr(d, x, "min", &min)) || (rc = attr(d, x, "max", &max)) ||
        (rc = attr(d, x, "values", &values)))
        goto out;
    if (!valid_id(name) || strchr(name, '-')) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "parameter name '%s' must start with a letter and contain only "
                             "letters, digits and '_'",
                             name);
        goto out;
    }
    if (wg__graph_find_param(g, name, strlen(name)) >= 0) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "parameter '%s' is declared twice", name);
        goto out;
    }
    int t = -1;
    for (int i = 0; param_types[i]; i++)
        if (!strcmp(param_types[i], type)) t = i;
    if (t < 0) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "unknown parameter type '%s' (float, int, bool, color, enum, string)",
                             type);
        goto out;
    }
    p->info.name = name;
    name = NULL;
    p->info.type = param_type_values[t];
    p->info.label = label;
    label = NULL;
    p->desc.name = p->info.name;
    p->desc.type = p->info.type;
    bool numeric = p->info.type == WG_PARAM_FLOAT_T || p->info.type == WG_PARAM_INT_T;
    if ((min || max) && !numeric) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "min/max apply only to float and int parameters");
        goto out;
    }
    if (values && p->info.type != WG_PARAM_ENUM_T) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "'values' applies only to enum parameters");
        goto out;
    }
    if (p->info.type == WG_PARAM_ENUM_T) {
        if (!values) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                 "enum parameter '%s' needs values=\"a|b|c\"", p->info.name);
            goto out;
        }
        int n = parse_enum_values(p, values);
        if (n <= 0) {
            rc = n < 0 ? nomem(d->err)
                       : wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                         "enum parameter '%s' has no values", p->info.name);
            goto out;
        }
        p->desc.values = p->info.values;
    }
    WgParamDesc bound = {.name = "min", .type = WG_PARAM_FLOAT_T};
    WgValue v;
    if (min) {
        if ((rc = wg__value_parse(&bound, min, &v, d->err))) goto located;
        p->info.has_min = p->desc.has_min = true;
        p->info.min = p->desc.min = v.num;
    }
    if (max) {
        bound.name = "max";
        if ((rc = wg__value_parse(&bound, max, &v, d->err))) goto located;
        p->info.has_max = p->desc.has_max = true;
        p->info.max = p->desc.max = v.num;
    }
    if (min && max && p->info.min > p->info.max) {
        rc = wg_error_set_at(d->err, WG_ERR_RANGE, d->path, line, 0,
                             "min %g is greater than max %g", p->info.min, p->info.max);
        goto out;
    }
    if (!def) {
        static const char *const natural[] = {"0", "0", "false", "0 0 0 1", NULL, ""};
        const char *text = p->info.type == WG_PARAM_ENUM_T ? p->info.values[0] : natural[t];
        if (numeric && p->info.has_min && p->info.min > 0) {
            char buf[64];
            snprintf(buf, sizeof buf, "%.17g", p->info.min);
            def = wg_strdup(buf);
        } else {
            def = wg_strdup(text);
        }
        if (!def) {
            rc = nomem(d->err);
            goto out;
        }
    }
    if ((rc = wg__value_parse(&p->desc, def, &p->def, d->err))) goto located;
    if (wg__name_index_put(&g->param_index, p->info.name, strlen(p->info.name), g->n_params)) {
        wg__value_clear(&p->def);
        rc = nomem(d->err);
        goto out;
    }
    p->info.default_text = def;
    def = NULL;
    g->n_params++;
    goto out;
located:
    wg_error_locate(d->err, d->path, line, NULL);
out:
    if (rc) {
        wg_free((char *)p->info.name);
        wg_free((char *)p->info.label);
        if (p->value_storage)
            for (int k = 0; p->value_storage[k]; k++) wg_free(p->value_storage[k]);
        wg_free(p->value_storage);
        memset(p, 0, sizeof *p);
    }
    wg_free(name);
    wg_free(type);
    wg_free(label);
    wg_free(def);
    wg_free(min);
    wg_free(max);
    wg_free(values);
    return rc;
}

/* ---- <input> ----------------------------------------------------------------------------- */

static int parse_input(Doc *d, WgGraph *g, xmlNodePtr x)
{
    static const char *const allowed[] = {"name", "type", "colorspace", "default", "label", NULL};
    int line = line_of(x);
    int rc = check_attrs(d, x, allowed);
    if (rc) return rc;
    char *name = NULL, *type = NULL, *cs = NULL, *def = NULL;
    InputDef *in = &g->inputs[g->n_inputs];
    memset(in, 0, sizeof *in);
    if ((rc = need_attr(d, x, "name", &name)) || (rc = need_attr(d, x, "type", &type)) ||
        (rc = attr(d, x, "colorspace", &cs)) || (rc = attr(d, x, "default", &def)))
        goto out;
    if (!valid_id(name)) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0, "bad input name '%s'", name);
        goto out;
    }
    if (wg__graph_find_input(g, name) >= 0) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0, "input '%s' is declared twice",
                             name);
        goto out;
    }
    if (!strcmp(type, "gray"))
        in->info.kind = WG_GRAY;
    else if (!strcmp(type, "color"))
        in->info.kind = WG_COLOR;
    else {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "input type must be 'gray' or 'color', not '%s'", type);
        goto out;
    }
    in->info.colorspace = WG_LINEAR;
    if (cs) {
        if (!strcmp(cs, "srgb"))
            in->info.colorspace = WG_SRGB;
        else if (strcmp(cs, "linear")) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                 "colorspace must be 'linear' or 'srgb', not '%s'", cs);
            goto out;
        }
    }
    if (def) {
        if (wg__color_parse(def, in->def)) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                 "bad default '%s' for input '%s' (a number, or a colour such "
                                 "as #808080 or '0.5 0.5 0.5')",
                                 def, name);
            goto out;
        }
        /* a gray default is carried by a `uniform` value, whose range is +-1e6 */
        if (in->info.kind == WG_GRAY && (in->def[0] < -1e6f || in->def[0] > 1e6f)) {
            rc = wg_error_set_at(d->err, WG_ERR_RANGE, d->path, line, 0,
                                 "default '%s' of gray input '%s' is outside [-1e6, 1e6]", def,
                                 name);
            goto out;
        }
        in->info.has_default = true;
    }
    if (wg__name_index_put(&g->input_index, name, strlen(name), g->n_inputs)) {
        rc = nomem(d->err);
        goto out;
    }
    in->info.name = name;
    in->info.default_text = def;
    in->info.line = line;
    name = def = NULL;
    g->n_inputs++;
out:
    wg_free(name);
    wg_free(type);
    wg_free(cs);
    wg_free(def);
    return rc;
}

/* ---- <node> ------------------------------------------------------------------------------ */

static const char *const reserved_node_attrs[] = {"id",    "type", "size", "seed",
                                                  "label", "pos",  NULL};

static bool is_reserved(const char *name)
{
    for (int i = 0; reserved_node_attrs[i]; i++)
        if (!strcmp(reserved_node_attrs[i], name)) return true;
    return false;
}

/* *found = dir/file when that file exists. A path that cannot be built is WG_ERR_NOMEM: it
 * must not pass for a missing file. */
static int try_path(const char *dir, const char *file, char **found, WgError *err)
{
    char *cand = join_path(dir, file);
    if (!cand) return nomem(err);
    if (file_exists(cand))
        *found = cand;
    else
        wg_free(cand);
    return WG_OK;
}

static int resolve_subgraph(LoadCtx *lc, Doc *d, WgGraph *g, NodeDef *n, WgError *err)
{
    char *found = NULL;
    int rc = WG_OK;
    if (ends_with(n->type_name, ".wetgraph")) {
        found = join_path(g->dir, n->type_name);
        if (found && !file_exists(found)) {
            wg_free(found);
            return wg_error_set_at(err, WG_ERR_IO, d->path, n->line, 0,
                                   "subgraph file '%s' not found (relative to %s)", n->type_name,
                                   g->dir);
        }
    } else {
        size_t fl = strlen(n->type_name) + 10;
        char *file = wg_malloc(fl);
        if (!file) return nomem(err);
        snprintf(file, fl, "%s.wetgraph", n->type_name);
        rc = try_path(g->dir, file, &found, err);
        const char *env = getenv("WETGRAPH_PATH");
        if (!rc && !found && env) {
            char *copy = wg_strdup(env);
            if (!copy) rc = nomem(err);
            for (char *save = NULL, *tok = copy ? strtok_r(copy, ":", &save) : NULL;
                 tok && !found && !rc; tok = strtok_r(NULL, ":", &save))
                rc = try_path(tok, file, &found, err);
            wg_free(copy);
        }
        if (!rc && !found) rc = try_path(wg_builtin_graphs_dir(), file, &found, err);
        wg_free(file);
        if (rc) return rc;
        if (!found) {
            const char *names[256];
            int count = 0;
            for (; wg_node_types[count] && count < 256; count++)
                names[count] = wg_node_types[count]->name;
            const char *s = wg_suggest(n->type_name, names, count);
            if (s)
                return wg_error_set_at(err, WG_ERR_TYPE, d->path, n->line, 0,
                                       "unknown node type '%s'; did you mean '%s'?", n->type_name,
                                       s);
            return wg_error_set_at(
                err, WG_ERR_TYPE, d->path, n->line, 0,
                "unknown node type '%s' (not a built-in node, and no %s.wetgraph "
                "next to this file, in WETGRAPH_PATH or in %s)",
                n->type_name, n->type_name, wg_builtin_graphs_dir());
        }
    }
    if (!found) return nomem(err);
    rc = load_file(lc, found, &n->sub, err);
    if (rc && err && !err->file[0]) wg_error_locate(err, d->path, n->line, n->id);
    if (rc == WG_ERR_CYCLE || rc == WG_ERR_PARSE || rc == WG_ERR_TYPE || rc == WG_ERR_RANGE ||
        rc == WG_ERR_IO) {
        /* keep the inner location, say where it was used */
        if (err) {
            size_t l = strlen(err->message);
            snprintf(err->message + l, sizeof err->message - l, " (used by node '%s' at %s:%d)",
                     n->id, d->path, n->line);
        }
    }
    wg_free(found);
    return rc;
}

static const char *article(const char *word)
{
    return strchr("aeiou", word[0]) ? "an" : "a";
}

typedef struct ScopeResolve {
    const WgGraph *g;
    const char *bad; /* set when a name exists but is not numeric */
} ScopeResolve;

static bool resolve_scope(void *user, const char *name, size_t len, int *slot)
{
    ScopeResolve *sr = user;
    static const char *const specials[WG_SCOPE_COUNT_] = {"$time", "$seed", "$width", "$height"};
    for (int i = 0; i < WG_SCOPE_COUNT_; i++) {
        if (strlen(specials[i]) == len && !strncmp(specials[i], name, len)) {
            *slot = sr->g->n_params + i;
            return true;
        }
    }
    int p = wg__graph_find_param(sr->g, name, len);
    if (p < 0) return false;
    WgParamType t = sr->g->params[p].info.type;
    if (t == WG_PARAM_COLOR_T || t == WG_PARAM_STRING_T) {
        sr->bad = wg__type_name(t);
        return false;
    }
    *slot = p;
    return true;
}

/* Parse an attribute value against the descriptor of its parameter. */
static int parse_attr_value(Doc *d, const WgGraph *g, NodeDef *n, AttrDef *a,
                            const WgParamDesc *desc)
{
    a->ref_param = -1;
    if (a->text[0] == '=') {
        const char *src = a->text + 1;
        bool numeric = !desc || desc->type == WG_PARAM_FLOAT_T || desc->type == WG_PARAM_INT_T ||
                       desc->type == WG_PARAM_BOOL_T;
        if (!numeric) {
            const char *s = src;
            while (isspace((unsigned char)*s)) s++;
            size_t len = strlen(s);
            while (len && isspace((unsigned char)s[len - 1])) len--;
            int p = wg__graph_find_param(g, s, len);
            if (p < 0 || g->params[p].info.type != desc->type)
                return wg_error_set_at(d->err, WG_ERR_TYPE, d->path, a->line, 0,
                                       "node '%s': '%s' is %s %s parameter: its value can only "
                                       "be a literal or '=name' of a graph %s parameter",
                                       n->id, a->name, article(wg__type_name(desc->type)),
                                       wg__type_name(desc->type), wg__type_name(desc->type));
            a->ref_param = p;
            return WG_OK;
        }
        ScopeResolve sr = {g, NULL};
        WgExprOptions opt = {resolve_scope, &sr, false};
        WgError e = {0};
        int rc = wg_expr_parse(src, &opt, &a->expr, &e);
        if (rc == WG_ERR_NOMEM) return nomem(d->err);
        if (rc) {
            char extra[160] = "";
            if (sr.bad) {
                snprintf(extra, sizeof extra, " (it is %s %s parameter, not a number)",
                         article(sr.bad), sr.bad);
            } else if (!strncmp(e.message, "unknown name '", 14)) {
                char name[128];
                snprintf(name, sizeof name, "%s", e.message + 14);
                char *q = strchr(name, '\'');
                if (q) *q = '\0';
                const char *names[260];
                int count = 0;
                static const char *const specials[] = {"$time", "$seed", "$width", "$height"};
                for (int i = 0; i < 4; i++) names[count++] = specials[i];
                for (int i = 0; i < g->n_params && count < 260; i++)
                    names[count++] = g->params[i].info.name;
                const char *sug = wg_suggest(name, names, count);
                if (sug) snprintf(extra, sizeof extra, "; did you mean '%s'?", sug);
            }
            return wg_error_set_at(d->err, rc, d->path, a->line, e.column + 1,
                                   "node '%s', attribute '%s', column %d: %s%s", n->id, a->name,
                                   e.column + 1, e.message, extra);
        }
        return WG_OK;
    }
    WgParamDesc numeric = {.name = a->name, .type = WG_PARAM_FLOAT_T};
    int rc = wg__value_parse(desc ? desc : &numeric, a->text, &a->literal, d->err);
    if (rc) {
        char msg[1024];
        snprintf(msg, sizeof msg, "node '%s': %s", n->id, d->err ? d->err->message : "");
        return wg_error_set_at(d->err, rc, d->path, a->line, 0, "%s", msg);
    }
    return WG_OK;
}

static int parse_node(LoadCtx *lc, Doc *d, WgGraph *g, xmlNodePtr x)
{
    int line = line_of(x);
    NodeDef *n = &g->nodes[g->n_nodes];
    memset(n, 0, sizeof *n);
    n->line = line;
    int rc;
    if ((rc = need_attr(d, x, "id", &n->id)) || (rc = need_attr(d, x, "type", &n->type_name)))
        goto fail;
    if (!valid_id(n->id)) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "bad node id '%s': use letters, digits, '_' and '-', starting with a "
                             "letter",
                             n->id);
        goto fail;
    }
    int dup = wg__graph_find_node(g, n->id);
    if (dup >= 0) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "duplicate node id '%s' (first defined at line %d)", n->id,
                             g->nodes[dup].line);
        goto fail;
    }
    n->type = wg_node_type_find(n->type_name);
    if (!n->type) {
        /* a subgraph type resolves the same way every time within one file */
        int same = wg__name_index_get(&d->subgraphs, n->type_name, strlen(n->type_name));
        if (same >= 0) {
            n->sub = g->nodes[same].sub;
            n->sub->refs++;
        } else if ((rc = resolve_subgraph(lc, d, g, n, d->err))) {
            goto fail;
        } else if (wg__name_index_put(&d->subgraphs, n->type_name, strlen(n->type_name),
                                      g->n_nodes)) {
            rc = nomem(d->err);
            goto fail;
        }
    }
    if ((rc = attr(d, x, "size", &n->size_text)) || (rc = attr(d, x, "seed", &n->seed_text)) ||
        (rc = attr(d, x, "label", &n->label)))
        goto fail;
    if (n->seed_text) {
        uint64_t seed;
        if (!wg_parse_whole(n->seed_text, &seed)) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                 "node '%s': seed must be a whole number >= 0, not '%s'", n->id,
                                 n->seed_text);
            goto fail;
        }
    }
    if (n->size_text) {
        const char *s = n->size_text;
        int w, h;
        bool ok = !strcmp(s, "graph") || !strcmp(s, "input") || wg_parse_size(s, &w, &h);
        if (!ok && (s[0] == 'x' || s[0] == '/')) {
            double f;
            ok = wg_parse_number(s + 1, &f) && f > 0 && f <= WG_MAX_SIDE;
        }
        if (!ok) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                 "node '%s': bad size '%s' (N, WxH, xK, /K, input or graph; "
                                 "sides 1..%d)",
                                 n->id, s, WG_MAX_SIDE);
            goto fail;
        }
    }

    /* parameters */
    int n_props = 0;
    for (xmlAttrPtr a = x->properties; a; a = a->next) n_props++;
    n->attrs = wg_calloc((size_t)n_props + 1, sizeof(AttrDef));
    if (!n->attrs) {
        rc = nomem(d->err);
        goto fail;
    }
    for (xmlAttrPtr xa = x->properties; xa; xa = xa->next) {
        const char *name = (const char *)xa->name;
        if (is_reserved(name)) continue;
        AttrDef *a = &n->attrs[n->n_attrs++];
        a->param = -1;
        a->ref_param = -1;
        a->line = attr_line(xa, line);
        if ((rc = attr(d, x, name, &a->text))) goto fail;
        if (!a->text || !(a->name = wg_strdup(name))) {
            rc = nomem(d->err);
            goto fail;
        }
        WgParamDesc desc;
        const WgParamDesc *dp = NULL;
        const char *names[128];
        int count = 0;
        if (n->type) {
            for (int i = 0; n->type->params && n->type->params[i].name; i++) {
                if (count < 128) names[count++] = n->type->params[i].name;
                if (!strcmp(n->type->params[i].name, name)) {
                    a->param = i;
                    wg__param_desc_from_spec(&desc, &n->type->params[i]);
                    dp = &desc;
                }
            }
        } else {
            for (int i = 0; i < n->sub->n_params; i++) {
                if (count < 128) names[count++] = n->sub->params[i].info.name;
                if (!strcmp(n->sub->params[i].info.name, name)) {
                    a->param = i;
                    dp = &n->sub->params[i].desc;
                }
            }
        }
        for (int k = 0; k < n->n_attrs - 1; k++) {
            if (!strcmp(n->attrs[k].name, name)) {
                rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, a->line, 0,
                                     "node '%s': attribute '%s' given twice", n->id, name);
                goto fail;
            }
        }
        if (a->param < 0 && !(n->type && (n->type->flags & WG_NODE_EXTRA_PARAMS))) {
            for (int r = 0; reserved_node_attrs[r] && count < 128; r++)
                names[count++] = reserved_node_attrs[r];
            const char *s = wg_suggest(name, names, count);
            if (s)
                rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, a->line, 0,
                                     "node '%s': %s '%s' has no parameter '%s'; did you mean "
                                     "'%s'?",
                                     n->id, n->type ? "node type" : "subgraph", n->type_name, name,
                                     s);
            else
                rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, a->line, 0,
                                     "node '%s': %s '%s' has no parameter '%s'", n->id,
                                     n->type ? "node type" : "subgraph", n->type_name, name);
            goto fail;
        }
        if (a->param < 0 && !valid_id(name)) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, a->line, 0,
                                 "node '%s': bad parameter name '%s'", n->id, name);
            goto fail;
        }
        if ((rc = parse_attr_value(d, g, n, a, dp))) goto fail;
    }

    /* connections */
    int n_children = 0;
    for (xmlNodePtr c = x->children; c; c = c->next) n_children += c->type == XML_ELEMENT_NODE;
    n->ins = wg_calloc((size_t)n_children + 1, sizeof(InDef));
    if (!n->ins) {
        rc = nomem(d->err);
        goto fail;
    }
    if ((rc = check_no_text(d, x))) goto fail;
    for (xmlNodePtr c = x->children; c; c = c->next) {
        if (c->type != XML_ELEMENT_NODE) continue;
        if (strcmp((const char *)c->name, "in")) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line_of(c), 0,
                                 "unexpected <%s> inside <node>; only <in name=... from=...> "
                                 "belongs there",
                                 (const char *)c->name);
            goto fail;
        }
        static const char *const in_allowed[] = {"name", "from", NULL};
        if ((rc = check_attrs(d, c, in_allowed)) || (rc = check_leaf(d, c))) goto fail;
        InDef *in = &n->ins[n->n_ins++]; /* counted now so that a failure frees its port */
        in->line = line_of(c);
        if ((rc = need_attr(d, c, "name", &in->port)) || (rc = need_attr(d, c, "from", &in->from)))
            goto fail;
    }
    if (wg__name_index_put(&g->node_index, n->id, strlen(n->id), g->n_nodes)) {
        rc = nomem(d->err);
        goto fail;
    }
    g->n_nodes++;
    return WG_OK;
fail:
    g->n_nodes++; /* let wg_graph_free release what was filled in */
    return rc;
}

/* Resolve "node", "node.port" or "$input" in graph g. */
static int resolve_from(Doc *d, WgGraph *g, const char *from, int line, int *node, int *port,
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
static int link_node(Doc *d, WgGraph *g, NodeDef *n, WgNameIndex *seen)
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
                if (!valid_id(in->port) || strchr(in->port, '-'))
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
        int rc =
            resolve_from(d, g, in->from, in->line, &in->from_node, &in->from_port, &in->from_input);
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
static int find_cycle(Doc *d, WgGraph *g)
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

static int parse_output(Doc *d, WgGraph *g, xmlNodePtr x)
{
    static const char *const allowed[] = {"name", "from", "format", "colorspace", "label", NULL};
    int line = line_of(x);
    int rc = check_attrs(d, x, allowed);
    if (rc) return rc;
    WgGraphOutputInfo *o = &g->outputs[g->n_outputs];
    memset(o, 0, sizeof *o);
    o->line = line;
    char *name = NULL, *from = NULL, *format = NULL, *cs = NULL;
    if ((rc = need_attr(d, x, "name", &name)) || (rc = need_attr(d, x, "from", &from)) ||
        (rc = attr(d, x, "format", &format)) || (rc = attr(d, x, "colorspace", &cs)))
        goto out;
    if (!valid_id(name)) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0, "bad output name '%s'", name);
        goto out;
    }
    if (wg__graph_find_output(g, name) >= 0) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "output '%s' is declared twice", name);
        goto out;
    }
    if (format) {
        int f = wg_format_parse(format);
        if (f < 0) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                 "unknown format '%s' (png, png16, tif16, exr, exr32)", format);
            goto out;
        }
        o->format = (WgFormat)f;
    }
    if (cs) {
        if (!strcmp(cs, "srgb"))
            o->colorspace = WG_SRGB;
        else if (strcmp(cs, "linear")) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                 "colorspace must be 'linear' or 'srgb', not '%s'", cs);
            goto out;
        }
    }
    if (wg__name_index_put(&g->output_index, name, strlen(name), g->n_outputs)) {
        rc = nomem(d->err);
        goto out;
    }
    o->name = name;
    o->from = from;
    name = from = NULL;
    g->n_outputs++;
out:
    wg_free(name);
    wg_free(from);
    wg_free(format);
    wg_free(cs);
    return rc;
}

/* ---- the document ------------------------------------------------------------------------ */

static int load_doc(LoadCtx *lc, xmlDocPtr doc, const char *path, WgGraph **out, WgError *err)
{
    Doc d = {path, err, {0}};
    xmlNodePtr root = xmlDocGetRootElement(doc);
    if (!root || strcmp((const char *)root->name, "wetgraph"))
        return wg_error_set_at(err, WG_ERR_PARSE, path, root ? line_of(root) : 1, 0,
                               "the root element must be <wetgraph>, not <%s>",
                               root ? (const char *)root->name : "nothing");
    static const char *const allowed[] = {"version", "size", "seed", "label", "description", NULL};
    int rc = check_attrs(&d, root, allowed);
    if (rc) return rc;
    char *version;
    if ((rc = attr(&d, root, "version", &version))) return rc;
    if (!version || strcmp(version, "1")) {
        rc = wg_error_set_at(err, WG_ERR_PARSE, path, line_of(root), 0,
                             version ? "unsupported version '%s' (this engine reads version 1)"
                                     : "<wetgraph> needs version=\"1\"%s",
                             version ? version : "");
        wg_free(version);
        return rc;
    }
    wg_free(version);

    WgGraph *g = wg_calloc(1, sizeof *g);
    if (!g) return nomem(err);
    g->refs = 1;
    g->path = wg_strdup(path);
    g->dir = dir_of(path);
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    g->name = wg_strdup(base);
    char *seed = NULL;
    if (!g->path || !g->dir || !g->name) rc = nomem(err);
    if (!rc && ends_with(g->name, ".wetgraph")) g->name[strlen(g->name) - 9] = '\0';
    if (!rc) rc = attr(&d, root, "size", &g->size_text);
    if (!rc && !g->size_text && !(g->size_text = wg_strdup("1024"))) rc = nomem(err);
    g->size_line = line_of(root);
    if (!rc) rc = attr(&d, root, "seed", &seed);
    if (seed) {
        if (!wg_parse_whole(seed, &g->seed))
            rc = wg_error_set_at(err, WG_ERR_PARSE, path, line_of(root), 0,
                                 "seed must be a whole number >= 0, not '%s'", seed);
        wg_free(seed);
    }

    int counts[4] = {0};
    static const char *const elements[] = {"param", "input", "node", "output", NULL};
    for (xmlNodePtr c = root->children; c && !rc; c = c->next) {
        if (c->type != XML_ELEMENT_NODE) continue;
        int k = -1;
        for (int i = 0; elements[i]; i++)
            if (!strcmp(elements[i], (const char *)c->name)) k = i;
        if (k < 0) {
            const char *s = wg_suggest((const char *)c->name, elements, 4);
            rc =
                wg_error_set_at(err, WG_ERR_PARSE, path, line_of(c), 0,
                                "unknown element <%s>%s%s%s", (const char *)c->name,
                                s ? "; did you mean <" : " (expected param, input, node or output)",
                                s ? s : "", s ? ">?" : "");
            break;
        }
        counts[k]++;
    }
    if (!rc) rc = check_no_text(&d, root);
    if (!rc && !(g->params = wg_calloc((size_t)counts[0] + 1, sizeof(ParamDef)))) rc = nomem(err);
    if (!rc && !(g->inputs = wg_calloc((size_t)counts[1] + 1, sizeof(InputDef)))) rc = nomem(err);
    if (!rc && !(g->nodes = wg_calloc((size_t)counts[2] + 1, sizeof(NodeDef)))) rc = nomem(err);
    if (!rc && !(g->outputs = wg_calloc((size_t)counts[3] + 1, sizeof(WgGraphOutputInfo))))
        rc = nomem(err);
    /* declarations first so node attributes can refer to any parameter */
    for (xmlNodePtr c = root->children; c && !rc; c = c->next) {
        if (c->type != XML_ELEMENT_NODE) continue;
        if (!strcmp((const char *)c->name, "param"))
            rc = parse_param(&d, g, c);
        else if (!strcmp((const char *)c->name, "input"))
            rc = parse_input(&d, g, c);
        else if (!strcmp((const char *)c->name, "output"))
            rc = parse_output(&d, g, c);
        if (!rc && strcmp((const char *)c->name, "node")) rc = check_leaf(&d, c);
    }
    for (xmlNodePtr c = root->children; c && !rc; c = c->next)
        if (c->type == XML_ELEMENT_NODE && !strcmp((const char *)c->name, "node"))
            rc = parse_node(lc, &d, g, c);
    for (int i = 0; i < g->n_nodes && !rc; i++) {
        WgNameIndex seen = {0};
        rc = link_node(&d, g, &g->nodes[i], &seen);
        wg__name_index_free(&seen);
    }
    if (!rc) rc = find_cycle(&d, g);
    if (!rc && g->n_outputs == 0)
        rc = wg_error_set_at(err, WG_ERR_PARSE, path, line_of(root), 0,
                             "the graph declares no <output>");
    if (!rc) {
        g->output_node = wg_calloc((size_t)g->n_outputs, sizeof(int));
        g->output_port = wg_calloc((size_t)g->n_outputs, sizeof(int));
        g->output_input = wg_calloc((size_t)g->n_outputs, sizeof(int));
        if (!g->output_node || !g->output_port || !g->output_input) rc = nomem(err);
    }
    for (int i = 0; i < g->n_outputs && !rc; i++)
        rc = resolve_from(&d, g, g->outputs[i].from, g->outputs[i].line, &g->output_node[i],
                          &g->output_port[i], &g->output_input[i]);
    if (!rc) {
        int w, h;
        const char *s = g->size_text;
        if (s[0] == '$') {
            if (wg__graph_find_input(g, s + 1) < 0)
                rc = wg_error_set_at(err, WG_ERR_PARSE, path, g->size_line, 0,
                                     "size '%s' names no graph input", s);
        } else if (!wg_parse_size(s, &w, &h)) {
            rc = wg_error_set_at(err, WG_ERR_PARSE, path, g->size_line, 0,
                                 "bad graph size '%s' (N, WxH or $input; sides 1..%d)", s,
                                 WG_MAX_SIDE);
        }
    }
    if (!rc) {
        g->node_info = wg_calloc((size_t)g->n_nodes + 1, sizeof(WgGraphNodeInfo));
        if (!g->node_info) rc = nomem(err);
        for (int i = 0; i < g->n_nodes && !rc; i++) {
            NodeDef *n = &g->nodes[i];
            WgGraphNodeInfo *ni = &g->node_info[i];
            n->info_ports = wg_calloc((size_t)n->n_ins + 1, sizeof(char *));
            n->info_from = wg_calloc((size_t)n->n_ins + 1, sizeof(char *));
            if (!n->info_ports || !n->info_from) {
                rc = nomem(err);
                break;
            }
            for (int k = 0; k < n->n_ins; k++) {
                n->info_ports[k] = n->ins[k].port;
                n->info_from[k] = n->ins[k].from;
            }
            ni->id = n->id;
            ni->type = n->type_name;
            ni->is_subgraph = n->sub != NULL;
            ni->subgraph_path = n->sub ? n->sub->path : NULL;
            ni->n_inputs = n->n_ins;
            ni->input_ports = n->info_ports;
            ni->input_from = n->info_from;
            ni->line = n->line;
        }
    }
    wg__name_index_free(&d.subgraphs);
    if (rc) {
        wg_graph_free(g);
        return rc;
    }
    *out = g;
    return WG_OK;
}

static void silent_xml_error(void *user, const xmlError *e)
{
    (void)user;
    (void)e;
}

/* libxml2 goes on after the first error and its last one is often a consequence ("Premature
 * end of data" at the end of the file for a tag left open); report the first. */
static void first_xml_error(void *user, const xmlError *e)
{
    xmlError *first = user;
    if (first->code == 0 && e && e->code != 0 && e->level >= XML_ERR_ERROR)
        xmlCopyError((xmlErrorPtr)e, first);
}

static int xml_error(const char *path, xmlParserCtxtPtr ctxt, const xmlError *first, WgError *err)
{
    const xmlError *e = first->code ? first : xmlCtxtGetLastError(ctxt);
    if (!e) return wg_error_set_at(err, WG_ERR_PARSE, path, 0, 0, "not a readable XML file");
    char msg[512];
    snprintf(msg, sizeof msg, "%s", e->message ? e->message : "malformed XML");
    size_t l = strlen(msg);
    while (l && (msg[l - 1] == '\n' || msg[l - 1] == ' ')) msg[--l] = '\0';
    if (e->domain == XML_FROM_IO || e->code == XML_IO_LOAD_ERROR)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the file: %s", msg);
    return wg_error_set_at(err, WG_ERR_PARSE, path, e->line, e->int2, "XML: %s", msg);
}

/* The whole file (the line annotation needs the text); graph files are small. */
static int read_text(const char *path, char **text, size_t *len, WgError *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the graph file: %s",
                               strerror(errno));
    size_t cap = 1 << 16, n = 0;
    char *buf = wg_malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap) break;
        if (cap >= ((size_t)1 << 30)) {
            wg_free(buf);
            fclose(f);
            return wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0, "graph file larger than 1 GiB");
        }
        char *bigger = wg_realloc_array(buf, cap, cap * 2, 1);
        if (!bigger) wg_free(buf);
        buf = bigger;
        cap *= 2;
    }
    bool bad = buf && ferror(f);
    fclose(f);
    if (!buf) return nomem(err);
    if (bad) {
        wg_free(buf);
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the graph file: %s",
                               strerror(errno));
    }
    *text = buf;
    *len = n;
    return WG_OK;
}

static int parse_xml(LoadCtx *lc, const char *path, const char *mem, size_t len, WgGraph **out,
                     WgError *err)
{
    xmlSetStructuredErrorFunc(NULL, (xmlStructuredErrorFunc)silent_xml_error);
    xmlParserCtxtPtr ctxt = xmlNewParserCtxt();
    if (!ctxt) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    xmlError first = {0};
    xmlSetStructuredErrorFunc(&first, (xmlStructuredErrorFunc)first_xml_error);
    int opts = XML_PARSE_NONET | XML_PARSE_NOCDATA;
    xmlDocPtr doc = xmlCtxtReadMemory(ctxt, mem, (int)len, path, NULL, opts);
    xmlSetStructuredErrorFunc(NULL, (xmlStructuredErrorFunc)silent_xml_error);
    int rc;
    if (!doc) {
        rc = xml_error(path, ctxt, &first, err);
    } else {
        annotate_lines(doc, mem, len);
        rc = load_doc(lc, doc, path, out, err);
    }
    xmlResetError(&first);
    if (doc) xmlFreeDoc(doc);
    xmlFreeParserCtxt(ctxt);
    return rc;
}

static int load_file(LoadCtx *lc, const char *path, WgGraph **out, WgError *err)
{
    char real[PATH_MAX];
    if (!realpath(path, real))
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0,
                               "cannot open the graph file: no such file");
    for (int i = 0; i < lc->depth; i++) {
        if (!strcmp(lc->stack[i], real)) {
            char chain[1024] = "";
            for (int k = i; k < lc->depth; k++) {
                const char *b = strrchr(lc->stack[k], '/');
                size_t l = strlen(chain);
                snprintf(chain + l, sizeof chain - l, "%s -> ", b ? b + 1 : lc->stack[k]);
            }
            const char *b = strrchr(real, '/');
            size_t l = strlen(chain);
            snprintf(chain + l, sizeof chain - l, "%s", b ? b + 1 : real);
            return wg_error_set_at(err, WG_ERR_CYCLE, path, 0, 0, "subgraph recursion: %s", chain);
        }
    }
    if (lc->depth >= 64)
        return wg_error_set_at(err, WG_ERR_CYCLE, path, 0, 0, "subgraphs nested more than 64 deep");
    int seen = wg__name_index_get(&lc->loaded_index, real, strlen(real));
    if (seen >= 0) {
        lc->loaded[seen]->refs++;
        *out = lc->loaded[seen];
        return WG_OK;
    }
    lc->stack[lc->depth++] = real;
    char *text = NULL;
    size_t len = 0;
    int rc = read_text(path, &text, &len, err);
    if (!rc) rc = parse_xml(lc, path, text, len, out, err);
    wg_free(text);
    lc->depth--;
    if (rc) return rc;
    /* sharing is only an optimisation: out of memory here just loads the file again later */
    if (lc->n_loaded == lc->cap_loaded) {
        int cap = lc->cap_loaded ? lc->cap_loaded * 2 : 8;
        WgGraph **p = wg_realloc_array(lc->loaded, (size_t)lc->n_loaded, (size_t)cap, sizeof *p);
        if (p) lc->loaded = p;
        char **r = wg_realloc_array(lc->loaded_real, (size_t)lc->n_loaded, (size_t)cap, sizeof *r);
        if (r) lc->loaded_real = r;
        if (!p || !r) return WG_OK;
        lc->cap_loaded = cap;
    }
    char *copy = wg_strdup(real);
    if (!copy) return WG_OK;
    if (wg__name_index_put(&lc->loaded_index, copy, strlen(copy), lc->n_loaded)) {
        wg_free(copy);
        return WG_OK;
    }
    lc->loaded_real[lc->n_loaded] = copy;
    lc->loaded[lc->n_loaded++] = *out;
    return WG_OK;
}

int wg_graph_load(const char *path, WgGraph **out, WgError *err)
{
    LoadCtx lc = {0};
    *out = NULL;
    int rc = load_file(&lc, path, out, err);
    load_ctx_free(&lc);
    return rc;
}

int wg_graph_load_memory(const char *xml, size_t len, const char *path, WgGraph **out, WgError *err)
{
    LoadCtx lc = {0};
    char real[PATH_MAX];
    *out = NULL;
    if (realpath(path, real)) lc.stack[lc.depth++] = real;
    int rc = parse_xml(&lc, path, xml, len, out, err);
    load_ctx_free(&lc);
    return rc;
}

/* ---- introspection ----------------------------------------------------------------------- */

const char *wg_graph_name(const WgGraph *g)
{
    return g->name;
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
