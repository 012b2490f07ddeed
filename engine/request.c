/* SPDX-License-Identifier: MIT */
/* WgRequest: what to render (parameter overrides, input images, outputs, size, seed, time).
 * Values are type- and range-checked when set, so a bad --set fails before anything runs. */
#include "internal.h"

#include <stdio.h>
#include <string.h>

WgRequest *wg_request_new(const WgGraph *g)
{
    WgRequest *r = wg_calloc(1, sizeof *r);
    if (!r) return NULL;
    r->graph = g;
    r->values = wg_calloc((size_t)g->n_params + 1, sizeof(WgValue));
    r->value_set = wg_calloc((size_t)g->n_params + 1, sizeof(bool));
    r->input_paths = wg_calloc((size_t)g->n_inputs + 1, sizeof(char *));
    r->input_images = wg_calloc((size_t)g->n_inputs + 1, sizeof(WgImage *));
    r->outputs = wg_calloc((size_t)g->n_outputs + 1, sizeof(char *));
    if (!r->values || !r->value_set || !r->input_paths || !r->input_images || !r->outputs) {
        wg_request_free(r);
        return NULL;
    }
    return r;
}

void wg_request_free(WgRequest *r)
{
    if (!r) return;
    const WgGraph *g = r->graph;
    if (r->values)
        for (int i = 0; i < g->n_params; i++) wg__value_clear(&r->values[i]);
    if (r->input_paths)
        for (int i = 0; i < g->n_inputs; i++) wg_free(r->input_paths[i]);
    if (r->input_images)
        for (int i = 0; i < g->n_inputs; i++) wg_image_unref(r->input_images[i]);
    if (r->outputs)
        for (int i = 0; i < r->n_outputs; i++) wg_free(r->outputs[i]);
    wg_free(r->values);
    wg_free(r->value_set);
    wg_free(r->input_paths);
    wg_free(r->input_images);
    wg_free(r->outputs);
    wg_free(r);
}

static int list_names(char *buf, size_t size, int count, const char *(*name)(const WgGraph *, int),
                      const WgGraph *g)
{
    buf[0] = '\0';
    for (int i = 0; i < count; i++) {
        size_t l = strlen(buf);
        snprintf(buf + l, size - l, "%s%s", i ? ", " : "", name(g, i));
    }
    if (!count) snprintf(buf, size, "none");
    return count;
}

static const char *param_name(const WgGraph *g, int i)
{
    return g->params[i].info.name;
}
static const char *input_name(const WgGraph *g, int i)
{
    return g->inputs[i].info.name;
}
static const char *output_name(const WgGraph *g, int i)
{
    return g->outputs[i].name;
}

int wg_request_set(WgRequest *r, const char *name, const char *value, WgError *err)
{
    const WgGraph *g = r->graph;
    int i = wg__graph_find_param(g, name, strlen(name));
    if (i < 0) {
        char list[1024];
        list_names(list, sizeof list, g->n_params, param_name, g);
        const char *names[256];
        int n = 0;
        for (; n < g->n_params && n < 256; n++) names[n] = g->params[n].info.name;
        const char *s = wg_suggest(name, names, n);
        return wg_error_set(err, WG_ERR_USAGE, NULL,
                            "graph '%s' has no parameter '%s'%s%s%s (parameters: %s)", g->name,
                            name, s ? "; did you mean '" : "", s ? s : "", s ? "'?" : "", list);
    }
    const ParamDef *p = &g->params[i];
    WgValue v;
    int rc;
    if (value[0] == '=') {
        /* a constant expression over the other parameters' defaults is not allowed here:
         * only numbers, for clarity of what was set */
        WgExpr *e = NULL;
        WgExprOptions opt = {0};
        rc = wg_expr_parse(value + 1, &opt, &e, err);
        if (rc) return rc;
        memset(&v, 0, sizeof v);
        v.type = p->info.type;
        v.num = wg_expr_eval(e, NULL);
        wg_expr_free(e);
        if (p->info.type != WG_PARAM_FLOAT_T && p->info.type != WG_PARAM_INT_T &&
            p->info.type != WG_PARAM_BOOL_T)
            return wg_error_set(err, WG_ERR_TYPE, NULL, "'%s' is %s %s parameter, not a number",
                                name, p->info.type == WG_PARAM_ENUM_T ? "an" : "a",
                                wg_param_type_name(p->info.type));
        rc = wg__value_check(&p->desc, &v, err);
    } else {
        rc = wg__value_parse(&p->desc, value, &v, err);
    }
    if (rc) return rc;
    wg__value_clear(&r->values[i]);
    r->values[i] = v;
    r->value_set[i] = true;
    return WG_OK;
}

static int find_input(WgRequest *r, const char *name, WgError *err)
{
    const WgGraph *g = r->graph;
    int i = wg__graph_find_input(g, name);
    if (i < 0) {
        char list[1024];
        list_names(list, sizeof list, g->n_inputs, input_name, g);
        const char *names[256];
        int n = g->n_inputs < 256 ? g->n_inputs : 256;
        for (int k = 0; k < n; k++) names[k] = g->inputs[k].info.name;
        const char *near = wg_suggest(name, names, n);
        if (near)
            return wg_error_set(err, WG_ERR_USAGE, NULL,
                                "graph '%s' has no input '%s'; did you mean '%s'? (inputs: %s)",
                                g->name, name, near, list);
        return wg_error_set(err, WG_ERR_USAGE, NULL, "graph '%s' has no input '%s' (inputs: %s)",
                            g->name, name, list);
    }
    return i;
}

int wg_request_set_input_file(WgRequest *r, const char *name, const char *path, WgError *err)
{
    int i = find_input(r, name, err);
    if (i < 0) return i;
    int w, h, c;
    int rc = wg_image_probe(path, &w, &h, &c, err);
    if (rc) return rc;
    char *copy = wg_strdup(path);
    if (!copy) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    wg_free(r->input_paths[i]);
    r->input_paths[i] = copy;
    wg_image_unref(r->input_images[i]);
    r->input_images[i] = NULL;
    return WG_OK;
}

int wg_request_set_input_image(WgRequest *r, const char *name, const WgImage *img, WgError *err)
{
    int i = find_input(r, name, err);
    if (i < 0) return i;
    wg_image_unref(r->input_images[i]);
    r->input_images[i] = wg_image_ref(img);
    wg_free(r->input_paths[i]);
    r->input_paths[i] = NULL;
    return WG_OK;
}

int wg_request_add_output(WgRequest *r, const char *name, WgError *err)
{
    const WgGraph *g = r->graph;
    if (wg__graph_find_output(g, name) < 0) {
        char list[1024];
        list_names(list, sizeof list, g->n_outputs, output_name, g);
        const char *names[256];
        int n = g->n_outputs < 256 ? g->n_outputs : 256;
        for (int k = 0; k < n; k++) names[k] = g->outputs[k].name;
        const char *near = wg_suggest(name, names, n);
        if (near)
            return wg_error_set(err, WG_ERR_USAGE, NULL,
                                "graph '%s' has no output '%s'; did you mean '%s'? (outputs: %s)",
                                g->name, name, near, list);
        return wg_error_set(err, WG_ERR_USAGE, NULL, "graph '%s' has no output '%s' (outputs: %s)",
                            g->name, name, list);
    }
    for (int i = 0; i < r->n_outputs; i++)
        if (!strcmp(r->outputs[i], name)) return WG_OK;
    if (!(r->outputs[r->n_outputs] = wg_strdup(name)))
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    r->n_outputs++;
    return WG_OK;
}

void wg_request_set_size(WgRequest *r, int width, int height)
{
    r->width = width;
    r->height = height;
}

void wg_request_set_seed(WgRequest *r, uint64_t seed)
{
    r->has_seed = true;
    r->seed = seed;
}

void wg_request_set_time(WgRequest *r, double time)
{
    r->time = time;
}

void wg_request_set_progress(WgRequest *r, WgProgressFn fn, void *user)
{
    r->progress = fn;
    r->progress_user = user;
}

void wg_request_set_output_held(WgRequest *r, WgOutputHeldFn held, void *user)
{
    r->held_fn = held;
    r->held_user = user;
}

void wg_request_set_output_fn(WgRequest *r, WgOutputFn fn, void *user)
{
    r->output_fn = fn;
    r->output_user = user;
}

void wg_request_set_cancel(WgRequest *r, WgCancel *c)
{
    r->cancel = c;
}

int wg_request_check(const WgRequest *r, WgError *err)
{
    WgPlan plan;
    int rc = wg__plan_build(r, &plan, err);
    if (!rc) wg__plan_free(&plan);
    return rc;
}
