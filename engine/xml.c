/* SPDX-License-Identifier: MIT */
/* Reading .wetgraph documents with libxml2 into validated definitions. Everything that can be
 * checked without parameter values or images is checked while loading, with the file and line
 * of the offending element: here unknown elements and attributes, node types, parameters,
 * malformed literals and expressions, duplicate ids and recursion between graph files; in
 * graph_check.c ports, dangling references, unconnected required inputs and cycles between
 * nodes. libxml2's line numbers are corrected to where elements and attributes start (one pass
 * over the text). Subgraphs are loaded once per load and shared (graph_files.c finds them).
 * Instantiation with concrete values is in plan.c. */
#include "load.h"

#include <ctype.h>
#include <math.h>
#include <stdint.h>
#include <libxml/parser.h>
#include <libxml/tree.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void load_ctx_free(LoadCtx *lc)
{
    for (int i = 0; i < lc->n_loaded; i++) wg_free(lc->loaded_real[i]);
    wg_free(lc->loaded);
    wg_free(lc->loaded_real);
    wg__name_index_free(&lc->loaded_index);
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

/* ---- XML helpers ------------------------------------------------------------------------- */

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
        const char *colon = memchr(name, ':', len); /* libxml2 keeps a prefix apart */
        if (colon) {
            len -= (size_t)(colon + 1 - name);
            name = colon + 1;
        }
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

/* A <param>'s UI hints (soft_min, soft_max, step: numbers, for float and int parameters): the
 * soft range lies within the hard range (min, max) and is not empty, the step is positive (and
 * whole for an int); each error at the attribute's line. */
static int parse_hints(Doc *d, xmlNodePtr x, ParamDef *p, const char *soft_min,
                       const char *soft_max, const char *step)
{
    bool numeric = p->info.type == WG_PARAM_FLOAT_T || p->info.type == WG_PARAM_INT_T;
    const char *names[] = {"soft_min", "soft_max", "step"}, *texts[] = {soft_min, soft_max, step};
    bool *has[] = {&p->info.has_soft_min, &p->info.has_soft_max, &p->info.has_step};
    double *val[] = {&p->info.soft_min, &p->info.soft_max, &p->info.step};
    for (int i = 0; i < 3; i++) {
        if (!texts[i]) continue;
        int line = attr_line(xmlHasProp(x, (const xmlChar *)names[i]), line_of(x));
        if (!numeric)
            return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                   "%s applies only to float and int parameters", names[i]);
        WgParamDesc bound = {.name = names[i], .type = WG_PARAM_FLOAT_T};
        WgValue v;
        int rc = wg__value_parse(&bound, texts[i], &v, d->err);
        if (rc) {
            wg_error_locate(d->err, d->path, line, NULL);
            return rc;
        }
        char num[32], lim[32];
        wg__number_text(v.num, num, sizeof num);
        if (i < 2 && ((p->info.has_min && v.num < p->info.min) ||
                      (p->info.has_max && v.num > p->info.max))) {
            wg__number_text(p->info.has_min && v.num < p->info.min ? p->info.min : p->info.max, lim,
                            sizeof lim);
            return wg_error_set_at(d->err, WG_ERR_RANGE, d->path, line, 0,
                                   "%s %s of parameter '%s' is outside its range (%s %s)", names[i],
                                   num, p->info.name,
                                   p->info.has_min && v.num < p->info.min ? "min" : "max", lim);
        }
        if (i == 2 && !(v.num > 0 && (p->info.type == WG_PARAM_FLOAT_T || v.num == floor(v.num))))
            return wg_error_set_at(d->err, WG_ERR_RANGE, d->path, line, 0,
                                   "step %s of parameter '%s' must be a positive %s", num,
                                   p->info.name,
                                   p->info.type == WG_PARAM_INT_T ? "whole number" : "number");
        *has[i] = true;
        *val[i] = v.num;
    }
    if (p->info.has_soft_min && p->info.has_soft_max && p->info.soft_min >= p->info.soft_max) {
        char lo[32], hi[32];
        wg__number_text(p->info.soft_min, lo, sizeof lo);
        wg__number_text(p->info.soft_max, hi, sizeof hi);
        return wg_error_set_at(d->err, WG_ERR_RANGE, d->path, line_of(x), 0,
                               "soft_min %s of parameter '%s' is not below its soft_max %s", lo,
                               p->info.name, hi);
    }
    return WG_OK;
}

static int parse_param(Doc *d, WgGraph *g, xmlNodePtr x)
{
    static const char *const allowed[] = {"name",  "type",        "default",  "min",      "max",
                                          "label", "values",      "soft_min", "soft_max", "step",
                                          "group", "description", NULL};
    int line = line_of(x);
    int rc = check_attrs(d, x, allowed);
    if (rc) return rc;
    ParamDef *p = &g->params[g->n_params];
    memset(p, 0, sizeof *p);
    p->info.line = line;
    char *name = NULL, *type = NULL, *label = NULL, *def = NULL, *min = NULL, *max = NULL,
         *values = NULL, *soft_min = NULL, *soft_max = NULL, *step = NULL, *group = NULL,
         *description = NULL;
    if ((rc = need_attr(d, x, "name", &name)) || (rc = need_attr(d, x, "type", &type)) ||
        (rc = attr(d, x, "label", &label)) || (rc = attr(d, x, "default", &def)) ||
        (rc = attr(d, x, "min", &min)) || (rc = attr(d, x, "max", &max)) ||
        (rc = attr(d, x, "values", &values)) || (rc = attr(d, x, "soft_min", &soft_min)) ||
        (rc = attr(d, x, "soft_max", &soft_max)) || (rc = attr(d, x, "step", &step)) ||
        (rc = attr(d, x, "group", &group)) || (rc = attr(d, x, "description", &description)))
        goto out;
    if (!wg__valid_id(name) || strchr(name, '-')) {
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
    p->info.group = group;
    group = NULL;
    p->info.description = description;
    description = NULL;
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
        int values_line = attr_line(xmlHasProp(x, (const xmlChar *)"values"), line);
        if (n <= 0) {
            rc = n < 0 ? nomem(d->err)
                       : wg_error_set_at(d->err, WG_ERR_PARSE, d->path, values_line, 0,
                                         "enum parameter '%s' has no values", p->info.name);
            goto out;
        }
        /* a value listed twice could only ever select the first of its indices */
        for (int i = 1; i < n; i++)
            for (int k = 0; k < i; k++)
                if (!strcmp(p->info.values[i], p->info.values[k])) {
                    rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, values_line, 0,
                                         "enum parameter '%s' lists the value '%s' twice",
                                         p->info.name, p->info.values[i]);
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
        char lo[32], hi[32];
        wg__number_text(p->info.min, lo, sizeof lo);
        wg__number_text(p->info.max, hi, sizeof hi);
        rc = wg_error_set_at(d->err, WG_ERR_RANGE, d->path, line, 0,
                             "min %s is greater than max %s", lo, hi);
        goto out;
    }
    if ((rc = parse_hints(d, x, p, soft_min, soft_max, step))) goto out;
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
        wg_free((char *)p->info.group);
        wg_free((char *)p->info.description);
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
    wg_free(soft_min);
    wg_free(soft_max);
    wg_free(step);
    wg_free(group);
    wg_free(description);
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
    if (!wg__valid_id(name)) {
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
        sr->bad = wg_param_type_name(t);
        return false;
    }
    *slot = p;
    return true;
}

/* A numeric expression over the graph's scope (its numeric parameters, $time, $seed, $width,
 * $height); errors name `what` and the column, with a suggestion for a misspelt name. */
static int parse_scope_expr(Doc *d, const WgGraph *g, const char *src, int line, const char *what,
                            WgExpr **out)
{
    ScopeResolve sr = {g, NULL};
    WgExprOptions opt = {resolve_scope, &sr, false};
    WgError e = {0};
    int rc = wg_expr_parse(src, &opt, out, &e);
    if (rc == WG_ERR_NOMEM) return nomem(d->err);
    if (!rc) return WG_OK;
    char extra[160] = "";
    if (sr.bad) {
        snprintf(extra, sizeof extra, " (it is %s %s parameter, not a number)", article(sr.bad),
                 sr.bad);
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
    return wg_error_set_at(d->err, rc, d->path, line, e.column + 1, "%s, column %d: %s%s", what,
                           e.column + 1, e.message, extra);
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
                                       n->id, a->name, article(wg_param_type_name(desc->type)),
                                       wg_param_type_name(desc->type), wg_param_type_name(desc->type));
            a->ref_param = p;
            return WG_OK;
        }
        char what[512];
        snprintf(what, sizeof what, "node '%s', attribute '%s'", n->id, a->name);
        return parse_scope_expr(d, g, src, a->line, what, &a->expr);
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
    if (!wg__valid_id(n->id)) {
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
    n->type = wg__node_type_lookup(n->type_name);
    if (!n->type) {
        /* a subgraph type resolves the same way every time within one file */
        int same = wg__name_index_get(&d->subgraphs, n->type_name, strlen(n->type_name));
        if (same >= 0) {
            n->sub = g->nodes[same].sub;
            n->sub->refs++;
        } else if ((rc = wg__resolve_subgraph(lc, d, g, n, d->err))) {
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
        if (a->param < 0 && !wg__valid_id(name)) {
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

static int parse_output(Doc *d, WgGraph *g, xmlNodePtr x)
{
    static const char *const allowed[] = {"name",  "from",  "format",      "colorspace",
                                          "label", "group", "compression", NULL};
    int line = line_of(x);
    int rc = check_attrs(d, x, allowed);
    if (rc) return rc;
    WgGraphOutputInfo *o = &g->outputs[g->n_outputs];
    memset(o, 0, sizeof *o);
    o->line = line;
    char *name = NULL, *from = NULL, *format = NULL, *cs = NULL, *group = NULL, *comp = NULL;
    if ((rc = need_attr(d, x, "name", &name)) || (rc = need_attr(d, x, "from", &from)) ||
        (rc = attr(d, x, "format", &format)) || (rc = attr(d, x, "colorspace", &cs)) ||
        (rc = attr(d, x, "group", &group)) || (rc = attr(d, x, "compression", &comp)))
        goto out;
    if (group && !wg__valid_id(group)) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "output '%s': bad group '%s' (letters, digits, '_' and '-', "
                             "starting with a letter)",
                             name, group);
        goto out;
    }
    if (!wg__valid_id(name)) {
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
                                 "unknown format '%s' (png, png16, tif16, exr, exr32, jpeg, tga)",
                                 format);
            goto out;
        }
        o->format = (WgFormat)f;
    }
    if (comp) {
        int c = wg_png_compression_parse(comp);
        if (c < 0) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                                 "output '%s': unknown compression '%s' (fast, deflate, none)",
                                 name, comp);
            goto out;
        }
        o->compression = (WgPngCompression)c;
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
    o->group = group;
    name = from = group = NULL;
    g->n_outputs++;
out:
    wg_free(name);
    wg_free(from);
    wg_free(group);
    wg_free(format);
    wg_free(cs);
    wg_free(comp);
    return rc;
}

/* ---- <warning> --------------------------------------------------------------------------- */

static int add_part(Doc *d, WarningDef *w, const char *text, size_t len, WgExpr *expr, int param)
{
    WarnPart *p = wg_realloc_array(w->parts, (size_t)w->n_parts, (size_t)w->n_parts + 1, sizeof *p);
    if (!p) {
        wg_expr_free(expr);
        return nomem(d->err);
    }
    w->parts = p;
    p = &w->parts[w->n_parts];
    *p = (WarnPart){NULL, expr, param};
    if (text && !(p->text = wg_malloc(len + 1))) return nomem(d->err);
    if (text) {
        memcpy(p->text, text, len);
        p->text[len] = '\0';
    }
    w->n_parts++;
    return WG_OK;
}

/* The message: literal text with {name} (a graph parameter's value) and {=expression} (its
 * value); {{ and }} are literal braces. */
static int parse_message(Doc *d, const WgGraph *g, WarningDef *w, const char *msg, int line)
{
    char *lit = wg_malloc(strlen(msg) + 1);
    if (!lit) return nomem(d->err);
    size_t n = 0;
    int rc = WG_OK;
    for (const char *s = msg; *s && !rc;) {
        if ((s[0] == '{' && s[1] == '{') || (s[0] == '}' && s[1] == '}')) {
            lit[n++] = s[0];
            s += 2;
            continue;
        }
        if (s[0] == '}') {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, (int)(s - msg) + 1,
                                 "warning, attribute 'message', column %d: '}' without '{' "
                                 "(write '}}' for a brace)",
                                 (int)(s - msg) + 1);
            break;
        }
        if (s[0] != '{') {
            lit[n++] = *s++;
            continue;
        }
        const char *end = strchr(s, '}');
        if (!end) {
            rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, (int)(s - msg) + 1,
                                 "warning, attribute 'message', column %d: '{' without '}' "
                                 "(write '{{' for a brace)",
                                 (int)(s - msg) + 1);
            break;
        }
        if (n && (rc = add_part(d, w, lit, n, NULL, -1))) break;
        n = 0;
        size_t len = (size_t)(end - s - 1);
        char *inner = wg_malloc(len + 1);
        if (!inner) {
            rc = nomem(d->err);
            break;
        }
        memcpy(inner, s + 1, len);
        inner[len] = '\0';
        if (inner[0] == '=') {
            char what[64];
            snprintf(what, sizeof what, "warning, attribute 'message' at column %d",
                     (int)(s - msg) + 2);
            WgExpr *e = NULL;
            rc = parse_scope_expr(d, g, inner + 1, line, what, &e);
            if (!rc) rc = add_part(d, w, NULL, 0, e, -1);
        } else {
            int p = wg__graph_find_param(g, inner, len);
            if (p < 0) {
                const char *names[256];
                int count = 0;
                for (; count < g->n_params && count < 256; count++)
                    names[count] = g->params[count].info.name;
                const char *sug = wg_suggest(inner, names, count);
                rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, (int)(s - msg) + 2,
                                     "warning, attribute 'message', column %d: no parameter "
                                     "'%s'%s%s%s (write {=expression} for a value, '{{' for a "
                                     "brace)",
                                     (int)(s - msg) + 2, inner, sug ? "; did you mean '" : "",
                                     sug ? sug : "", sug ? "'?" : "");
            } else {
                rc = add_part(d, w, NULL, 0, NULL, p);
            }
        }
        wg_free(inner);
        s = end + 1;
    }
    if (!rc && n) rc = add_part(d, w, lit, n, NULL, -1);
    wg_free(lit);
    return rc;
}

static int parse_warning(Doc *d, WgGraph *g, xmlNodePtr x)
{
    static const char *const allowed[] = {"when", "message", NULL};
    int rc = check_attrs(d, x, allowed);
    if (rc) return rc;
    WarningDef *w = &g->warnings[g->n_warnings++]; /* counted so wg_graph_free releases it */
    memset(w, 0, sizeof *w);
    w->line = line_of(x);
    char *message = NULL;
    if ((rc = need_attr(d, x, "when", &w->when_text)) ||
        (rc = need_attr(d, x, "message", &message)))
        goto out;
    int when_line = attr_line(xmlHasProp(x, (const xmlChar *)"when"), w->line);
    int msg_line = attr_line(xmlHasProp(x, (const xmlChar *)"message"), w->line);
    if (w->when_text[0] != '=') {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, when_line, 0,
                             "warning: 'when' must be an expression starting with '=', not '%s'",
                             w->when_text);
        goto out;
    }
    if ((rc = parse_scope_expr(d, g, w->when_text + 1, when_line, "warning, attribute 'when'",
                               &w->when)))
        goto out;
    const char *m = message;
    while (isspace((unsigned char)*m)) m++;
    if (!*m) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, msg_line, 0,
                             "warning: 'message' is empty");
        goto out;
    }
    rc = parse_message(d, g, w, message, msg_line);
out:
    wg_free(message);
    return rc;
}

/* ---- <gltf> ------------------------------------------------------------------------------ */

/* The attribute of each map, in WgGltfSlot order. */
static const char *const gltf_slots[WG_GLTF_SLOT_COUNT + 1] = {
    "base_color",       "metallic", "roughness", "occlusion",
    "normal",           "specular", "clearcoat", "clearcoat_roughness",
    "clearcoat_normal", "height",   NULL};

static int gltf_number(Doc *d, xmlNodePtr x, const char *name, double lo, double hi, bool whole,
                       double def, double *out)
{
    char *text = NULL;
    int rc = attr(d, x, name, &text);
    if (rc || !text) {
        *out = def;
        return rc;
    }
    double v;
    if (!wg_parse_number(text, &v) || v < lo || v > hi || (whole && v != floor(v)))
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path,
                             attr_line(xmlHasProp(x, (const xmlChar *)name), line_of(x)), 0,
                             "gltf: '%s' must be %s from %g to %g, not '%s'", name,
                             whole ? "a whole number" : "a number", lo, hi, text);
    *out = v;
    wg_free(text);
    return rc;
}

static int parse_gltf(Doc *d, WgGraph *g, xmlNodePtr x)
{
    const char *allowed[WG_GLTF_SLOT_COUNT + 6];
    int n_allowed = 0;
    for (const char *const *a =
             (const char *const[]){"name", "binary", "grid", "height_scale", "repeat", NULL};
         *a; a++)
        allowed[n_allowed++] = *a;
    for (int k = 0; k < WG_GLTF_SLOT_COUNT; k++) allowed[n_allowed++] = gltf_slots[k];
    allowed[n_allowed] = NULL;
    int rc = check_attrs(d, x, allowed);
    if (rc) return rc;
    int line = line_of(x);
    WgGraphGltfInfo *a = &g->gltfs[g->n_gltfs++]; /* counted so wg_graph_free releases it */
    memset(a, 0, sizeof *a);
    a->line = line;
    char *name = NULL, *binary = NULL;
    if ((rc = need_attr(d, x, "name", &name))) return rc;
    a->name = name;
    if (!wg__valid_id(name))
        return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0, "bad gltf name '%s'", name);
    if (wg__graph_find_output(g, name) >= 0 || wg_graph_find_gltf(g, name) < g->n_gltfs - 1)
        return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                               "gltf '%s': the name is taken by an output or another gltf", name);
    if ((rc = attr(d, x, "binary", &binary))) return rc;
    if (binary && strcmp(binary, "true") && strcmp(binary, "false")) {
        rc = wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                             "gltf '%s': binary must be true or false, not '%s'", name, binary);
        wg_free(binary);
        return rc;
    }
    a->binary = binary && !strcmp(binary, "true");
    wg_free(binary);
    double grid;
    char *hs = NULL;
    if ((rc = attr(d, x, "height_scale", &hs))) return rc;
    if (hs && hs[0] == '=') {
        /* an expression over the graph's parameters, evaluated for each render; the graph
         * owns its text (the '=' dropped) from here */
        memmove(hs, hs + 1, strlen(hs));
        a->height_scale_expr = hs;
        rc = parse_scope_expr(d, g, hs,
                              attr_line(xmlHasProp(x, (const xmlChar *)"height_scale"), line),
                              "gltf, attribute 'height_scale'",
                              &g->gltf_height_exprs[g->n_gltfs - 1]);
        if (rc) return rc;
    } else {
        wg_free(hs);
        if ((rc = gltf_number(d, x, "height_scale", 0, 1e6, false, 0, &a->height_scale))) return rc;
    }
    if ((rc = gltf_number(d, x, "grid", 0, 4096, true, 0, &grid)) ||
        (rc = gltf_number(d, x, "repeat", 1, 1e6, false, 1, &a->repeat)))
        return rc;
    a->grid = (int)grid;
    for (int k = 0; k < WG_GLTF_SLOT_COUNT && !rc; k++) {
        char *out = NULL;
        if ((rc = attr(d, x, gltf_slots[k], &out)) || !out) continue;
        a->maps[k] = out;
        if (wg__graph_find_output(g, out) >= 0) continue;
        const char *names[256];
        int n = g->n_outputs < 256 ? g->n_outputs : 256;
        for (int i = 0; i < n; i++) names[i] = g->outputs[i].name;
        const char *near = wg_suggest(out, names, n);
        char hint[300] = "";
        if (near) snprintf(hint, sizeof hint, "; did you mean '%s'?", near);
        rc =
            wg_error_set_at(d->err, WG_ERR_PARSE, d->path,
                            attr_line(xmlHasProp(x, (const xmlChar *)gltf_slots[k]), line), 0,
                            "gltf '%s': %s names no output '%s'%s", name, gltf_slots[k], out, hint);
    }
    if (rc) return rc;
    if (!a->maps[WG_GLTF_BASE_COLOR])
        return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                               "gltf '%s' needs base_color (the output of its base colour)", name);
    if (a->grid > 0 && !a->maps[WG_GLTF_HEIGHT])
        return wg_error_set_at(d->err, WG_ERR_PARSE, d->path, line, 0,
                               "gltf '%s': a grid (grid=\"%d\") needs height (the output of its "
                               "relief)",
                               name, a->grid);
    return check_leaf(d, x);
}

/* ---- expansion --------------------------------------------------------------------------- */

/* Instances one instantiation of g can make, from its subgraphs' counts (each file is counted
 * once, when it is loaded, so this is linear in distinct files however often they are used).
 * Saturates just above the limit: 40 files each using the next twice would overflow. */
static uint64_t count_instances(const WgGraph *g)
{
    const uint64_t cap = (uint64_t)WG_MAX_INSTANCES + 1;
    /* an input's default is an instance per use, and a subgraph use is one more however few
     * nodes it holds: subgraphs that only pass inputs on must not expand for free */
    uint64_t total = (uint64_t)g->n_inputs;
    for (int i = 0; i < g->n_nodes && total < cap; i++)
        total += g->nodes[i].sub ? 1 + g->nodes[i].sub->instances : 1;
    return total < cap ? total : cap;
}

/* Refuse a graph that expands beyond WG_MAX_INSTANCES. The chain named goes from g down
 * through subgraphs that are over the limit themselves, to the one whose own uses of smaller
 * subgraphs cross it: the file to change. */
static int check_expansion(WgGraph *g, WgError *err)
{
    if (g->instances <= WG_MAX_INSTANCES) return WG_OK;
    const char *names[66]; /* nesting stops at 64 files */
    int n = 0;
    for (const WgGraph *at = g; at && n < 66;) {
        const char *b = strrchr(at->path, '/');
        names[n++] = b ? b + 1 : at->path;
        const WgGraph *next = NULL;
        for (int i = 0; i < at->n_nodes && !next; i++)
            if (at->nodes[i].sub && at->nodes[i].sub->instances > WG_MAX_INSTANCES)
                next = at->nodes[i].sub;
        at = next;
    }
    /* a chain too long for one message keeps its first and last files */
    char chain[640] = "";
    size_t len = 0;
    for (int i = 0; i < n; i++) {
        size_t room = sizeof chain - len;
        bool last = i == n - 1;
        int w;
        if (!last && len + strlen(names[i]) > sizeof chain - 200) {
            w = snprintf(chain + len, room, " -> ...");
            i = n - 2;
        } else {
            w = snprintf(chain + len, room, "%s%s", i ? " -> " : "", names[i]);
        }
        len = w > 0 && (size_t)w < room ? len + (size_t)w : sizeof chain - 1;
    }
    return wg_error_set_at(err, WG_ERR_RANGE, g->path, 0, 0,
                           "subgraphs expand to more than %d node instances (each use of a "
                           "subgraph copies all its nodes): %s",
                           WG_MAX_INSTANCES, chain);
}

/* ---- the document ------------------------------------------------------------------------ */

/* The format has no namespaces: <x:node xmlns:x="..."> or xmlns="..." would make an element or
 * attribute that is read as if it had none, or one that is silently something else. */
static int check_no_namespaces(Doc *d, xmlNodePtr root)
{
    for (xmlNodePtr e = root; e;) {
        if (e->type == XML_ELEMENT_NODE) {
            if (e->ns)
                return wg_error_set_at(
                    d->err, WG_ERR_PARSE, d->path, line_of(e), 0,
                    "element <%s%s%s> is in the XML namespace '%s': wetgraph elements have none",
                    e->ns->prefix ? (const char *)e->ns->prefix : "", e->ns->prefix ? ":" : "",
                    (const char *)e->name, e->ns->href ? (const char *)e->ns->href : "");
            for (xmlAttrPtr a = e->properties; a; a = a->next)
                if (a->ns)
                    return wg_error_set_at(
                        d->err, WG_ERR_PARSE, d->path, attr_line(a, line_of(e)), 0,
                        "attribute '%s:%s' on <%s> is in the XML namespace '%s': wetgraph "
                        "attributes have none",
                        a->ns->prefix ? (const char *)a->ns->prefix : "", (const char *)a->name,
                        (const char *)e->name, a->ns->href ? (const char *)a->ns->href : "");
        }
        /* depth first without recursion: a deeply nested file costs no stack */
        if (e->children && e->type == XML_ELEMENT_NODE) {
            e = e->children;
            continue;
        }
        while (e && e != root && !e->next) e = e->parent;
        e = e && e != root ? e->next : NULL;
    }
    return WG_OK;
}

static int load_doc(LoadCtx *lc, xmlDocPtr doc, const char *path, WgGraph **out, WgError *err)
{
    Doc d = {path, err, {0}};
    xmlNodePtr root = xmlDocGetRootElement(doc);
    if (root) {
        int nrc = check_no_namespaces(&d, root);
        if (nrc) return nrc;
    }
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
    g->dir = wg__dir_of(path);
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    g->name = wg_strdup(base);
    char *seed = NULL;
    if (!g->path || !g->dir || !g->name) rc = nomem(err);
    if (!rc && wg__ends_with(g->name, ".wetgraph")) g->name[strlen(g->name) - 9] = '\0';
    if (!rc) rc = attr(&d, root, "label", &g->label);
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

    int counts[6] = {0};
    static const char *const elements[] = {"param",   "input", "node", "output",
                                           "warning", "gltf",  NULL};
    for (xmlNodePtr c = root->children; c && !rc; c = c->next) {
        if (c->type != XML_ELEMENT_NODE) continue;
        int k = -1;
        for (int i = 0; elements[i]; i++)
            if (!strcmp(elements[i], (const char *)c->name)) k = i;
        if (k < 0) {
            const char *s = wg_suggest((const char *)c->name, elements, 6);
            rc = wg_error_set_at(err, WG_ERR_PARSE, path, line_of(c), 0,
                                 "unknown element <%s>%s%s%s", (const char *)c->name,
                                 s ? "; did you mean <"
                                   : " (expected param, input, node, output, warning or gltf)",
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
    if (!rc && !(g->warnings = wg_calloc((size_t)counts[4] + 1, sizeof(WarningDef))))
        rc = nomem(err);
    if (!rc && !(g->gltfs = wg_calloc((size_t)counts[5] + 1, sizeof(WgGraphGltfInfo))))
        rc = nomem(err);
    if (!rc && !(g->gltf_height_exprs = wg_calloc((size_t)counts[5] + 1, sizeof(WgExpr *))))
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
    /* glTF assets after the outputs they name */
    for (xmlNodePtr c = root->children; c && !rc; c = c->next)
        if (c->type == XML_ELEMENT_NODE && !strcmp((const char *)c->name, "gltf"))
            rc = parse_gltf(&d, g, c);
    /* warnings after the declarations, so they may name any parameter */
    for (xmlNodePtr c = root->children; c && !rc; c = c->next)
        if (c->type == XML_ELEMENT_NODE && !strcmp((const char *)c->name, "warning"))
            rc = parse_warning(&d, g, c);
    for (xmlNodePtr c = root->children; c && !rc; c = c->next)
        if (c->type == XML_ELEMENT_NODE && !strcmp((const char *)c->name, "node"))
            rc = parse_node(lc, &d, g, c);
    for (int i = 0; i < g->n_nodes && !rc; i++) {
        WgNameIndex seen = {0};
        rc = wg__link_node(&d, g, &g->nodes[i], &seen);
        wg__name_index_free(&seen);
    }
    if (!rc) rc = wg__find_cycle(&d, g);
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
        rc = wg__resolve_from(&d, g, g->outputs[i].from, g->outputs[i].line, &g->output_node[i],
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
    if (!rc) g->instances = count_instances(g);
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
    /* some of libxml2's messages have a second line ("Bytes: 0xE9 0x22 ..." after an encoding
     * error): one error is one line */
    for (char *c = msg; *c; c++)
        if (*c == '\n' || *c == '\r') *c = ' ';
    if (e->domain == XML_FROM_IO || e->code == XML_IO_LOAD_ERROR)
        return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot read the file: %s", msg);
    return wg_error_set_at(err, WG_ERR_PARSE, path, e->line, e->int2, "XML: %s", msg);
}

/* The element of the root that holds line `line` (the last one starting at or before it). */
static xmlNodePtr element_at(xmlNodePtr root, int line)
{
    xmlNodePtr found = NULL;
    for (xmlNodePtr c = root->children; c; c = c->next)
        if (c->type == XML_ELEMENT_NODE && line_of(c) <= line) found = c;
    return found;
}

/* Loading the outermost file for wg_graph_check_all: after an error in one of its elements,
 * that element is taken out of the document and the file loaded again, so that the errors of
 * the other elements are found too. An error that names an element taken out before (a node
 * reading a node that was refused) follows from that one and is not counted. Stops at an error
 * that no element holds (the root, a subgraph's file, memory) or at collect_max. */
static int load_collecting(LoadCtx *lc, xmlDocPtr doc, const char *path, WgGraph **out,
                           WgError *err)
{
    char removed[64][128];
    int n_removed = 0;
    xmlNodePtr root = xmlDocGetRootElement(doc);
    int rc = load_doc(lc, doc, path, out, err);
    while (rc && lc->n_collected < lc->collect_max) {
        bool cascade = false;
        for (int k = 0; k < n_removed && !cascade; k++) cascade = strstr(err->message, removed[k]);
        xmlNodePtr el = root && rc != WG_ERR_NOMEM && !strcmp(err->file, path) && err->line > 0 &&
                                err->line > line_of(root)
                            ? element_at(root, err->line)
                            : NULL;
        /* the root's own error after elements were set aside (no <output> left) follows too */
        bool root_after =
            !el && n_removed > 0 && root && err->line <= line_of(root) && !strcmp(err->file, path);
        if ((!cascade || !el) && !root_after) lc->collected[lc->n_collected++] = *err;
        if (!el || n_removed == 64) break;
        xmlChar *id = xmlGetProp(el, (const xmlChar *)"id");
        if (!id) id = xmlGetProp(el, (const xmlChar *)"name");
        if (id) {
            snprintf(removed[n_removed++], sizeof removed[0], "'%s'", (const char *)id);
            xmlFree(id);
        }
        xmlUnlinkNode(el);
        xmlFreeNode(el);
        wg_error_clear(err);
        rc = load_doc(lc, doc, path, out, err);
    }
    if (lc->n_collected) {
        if (!rc) wg_graph_free(*out); /* what was left loads, but the file has errors */
        *out = NULL;
        *err = lc->collected[0];
        return lc->collected[0].code;
    }
    return rc;
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
        rc = lc->collected && lc->depth == 1 ? load_collecting(lc, doc, path, out, err)
                                             : load_doc(lc, doc, path, out, err);
    }
    xmlResetError(&first);
    if (doc) xmlFreeDoc(doc);
    xmlFreeParserCtxt(ctxt);
    return rc;
}

int wg__load_file(LoadCtx *lc, const char *path, WgGraph **out, WgError *err)
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
    int rc = wg__read_text(path, &text, &len, err);
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
    int rc = wg__load_file(&lc, path, out, err);
    load_ctx_free(&lc);
    if (!rc && (rc = check_expansion(*out, err))) {
        wg_graph_free(*out);
        *out = NULL;
    }
    return rc;
}

int wg_graph_check_all(const char *path, WgError *errors, int max, int *count)
{
    LoadCtx lc = {0};
    lc.collected = errors;
    lc.collect_max = max > 0 ? max : 1;
    WgGraph *g = NULL;
    WgError err = {0};
    int rc = wg__load_file(&lc, path, &g, &err);
    load_ctx_free(&lc);
    if (!rc && (rc = check_expansion(g, &err))) errors[lc.n_collected++] = err;
    if (rc && !lc.n_collected) errors[lc.n_collected++] = err; /* before any element: the file */
    wg_graph_free(g);
    *count = lc.n_collected;
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
    if (!rc && (rc = check_expansion(*out, err))) {
        wg_graph_free(*out);
        *out = NULL;
    }
    return rc;
}
