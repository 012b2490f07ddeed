/* SPDX-License-Identifier: MIT */
/* Instantiation: a request (graph + values + inputs + size + seed + time) is flattened into a
 * list of concrete node instances in topological order, subgraphs inlined with their ids
 * prefixed ("wet/mask"). Work is demand-driven: only what the requested outputs reach is
 * instantiated, so a broken node nothing asks for is never resolved. Each instance gets its
 * size, fully resolved parameters (expressions evaluated, ranges checked), input types checked,
 * output channel counts, and a cache key: xxh3-128 of everything its result depends on. Two
 * instances with the same key are merged. */
#include "internal.h"
#include "wgio.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <xxhash.h>

#define KEY_VERSION "wetgraph-key-1"

typedef struct Frame {
    const WgGraph *g;
    char *prefix;
    WgValue *values;
    WgRef *inputs;      /* bound input refs; inst -1 = unbound */
    int *input_default; /* memo of the default uniform per input, -1 */
    int width, height;
    uint64_t seed;
    double time;
    int *node_inst;          /* memo per built-in node, -1 */
    struct Frame **node_sub; /* memo per subgraph node */
} Frame;

typedef struct Builder {
    const WgRequest *r;
    WgPlan *plan;
    WgError *err;
    Frame **frames;
    int n_frames, cap_frames;
    struct Want *wants; /* the stack of build_node */
    int n_wants, cap_wants;
    WgKeyIndex merged; /* key -> instance, to merge identical instances */
} Builder;

static int resolve_ref(Builder *b, Frame *f, int node, int port, int input, int line, WgRef *out);
static int input_default(Builder *b, Frame *f, int input, int line, WgRef *out);
static int frame_warnings(Builder *b, const Frame *f);

/* ---- frames ------------------------------------------------------------------------------ */

static Frame *frame_new(Builder *b, const WgGraph *g, const char *prefix)
{
    if (b->n_frames == b->cap_frames) {
        int cap = b->cap_frames ? 2 * b->cap_frames : 8;
        Frame **p = wg_realloc_array(b->frames, (size_t)b->n_frames, (size_t)cap, sizeof *p);
        if (!p) return NULL;
        b->frames = p;
        b->cap_frames = cap;
    }
    Frame *f = wg_calloc(1, sizeof *f);
    if (!f) return NULL;
    b->frames[b->n_frames++] = f;
    f->g = g;
    f->prefix = wg_strdup(prefix);
    f->values = wg_calloc((size_t)g->n_params + 1, sizeof(WgValue));
    f->inputs = wg_calloc((size_t)g->n_inputs + 1, sizeof(WgRef));
    f->input_default = wg_calloc((size_t)g->n_inputs + 1, sizeof(int));
    f->node_inst = wg_calloc((size_t)g->n_nodes + 1, sizeof(int));
    f->node_sub = wg_calloc((size_t)g->n_nodes + 1, sizeof(Frame *));
    if (!f->prefix || !f->values || !f->inputs || !f->input_default || !f->node_inst ||
        !f->node_sub)
        return NULL;
    for (int i = 0; i < g->n_inputs; i++) {
        f->inputs[i].inst = -1;
        f->input_default[i] = -1;
    }
    for (int i = 0; i < g->n_nodes; i++) f->node_inst[i] = -1;
    for (int i = 0; i < g->n_params; i++)
        if (wg__value_copy(&f->values[i], &g->params[i].def)) return NULL;
    return f;
}

static void frame_free(Frame *f)
{
    if (!f) return;
    if (f->values)
        for (int i = 0; i < f->g->n_params; i++) wg__value_clear(&f->values[i]);
    wg_free(f->values);
    wg_free(f->prefix);
    wg_free(f->inputs);
    wg_free(f->input_default);
    wg_free(f->node_inst);
    wg_free(f->node_sub);
    wg_free(f);
}

/* Numeric scope of a frame for expressions: params then $time, $seed, $width, $height. */
static void fill_scope(const Frame *f, double *slots, uint64_t seed, int w, int h)
{
    for (int i = 0; i < f->g->n_params; i++) slots[i] = f->values[i].num;
    slots[f->g->n_params + WG_SCOPE_TIME] = f->time;
    slots[f->g->n_params + WG_SCOPE_SEED] = (double)seed;
    slots[f->g->n_params + WG_SCOPE_WIDTH] = w;
    slots[f->g->n_params + WG_SCOPE_HEIGHT] = h;
}

/* ---- instances --------------------------------------------------------------------------- */

static void inst_clear(WgInst *in)
{
    for (int i = 0; i < in->n_strings; i++) wg_free(in->strings[i]);
    wg_free(in->strings);
    wg_free(in->params);
    wg_free(in->id);
    wg_free(in->in);
    if (in->in_names)
        for (int i = 0; i < in->n_in; i++) wg_free(in->in_names[i]);
    wg_free(in->in_names);
    wg_free(in->in_channels);
    wg_free(in->in_lines);
    wg_free(in->out_channels);
    if (in->extra_names)
        for (int i = 0; i < in->n_extra; i++) wg_free(in->extra_names[i]);
    wg_free(in->extra_names);
    wg_free(in->extra_values);
    if (in->scope_names)
        for (int i = 0; i < in->n_scope; i++) wg_free(in->scope_names[i]);
    wg_free(in->scope_names);
    wg_free(in->scope_values);
    wg_image_unref(in->constant);
    memset(in, 0, sizeof *in);
}

void wg__plan_free(WgPlan *plan)
{
    for (int i = 0; i < plan->n_insts; i++) inst_clear(&plan->insts[i]);
    wg_free(plan->insts);
    for (int i = 0; i < plan->n_outputs; i++) wg_free(plan->outputs[i].name);
    wg_free(plan->outputs);
    wg_warnings_free(plan->warnings, plan->n_warnings);
    wg_free(plan->gltf_height_scales);
    memset(plan, 0, sizeof *plan);
}

static WgInst *inst_push(Builder *b)
{
    WgPlan *p = b->plan;
    if (p->n_insts == p->cap_insts) {
        int cap = p->cap_insts ? 2 * p->cap_insts : 32;
        WgInst *n = wg_realloc_array(p->insts, (size_t)p->n_insts, (size_t)cap, sizeof *n);
        if (!n) return NULL;
        p->insts = n;
        p->cap_insts = cap;
    }
    WgInst *in = &p->insts[p->n_insts++];
    memset(in, 0, sizeof *in);
    return in;
}

static int param_index(const WgNodeType *t, const char *name)
{
    for (int i = 0; t->params && t->params[i].name; i++)
        if (!strcmp(t->params[i].name, name)) return i;
    return -1;
}

static int keep_string(WgInst *in, const char *s, const char **out)
{
    char **n = wg_realloc_array(in->strings, (size_t)in->n_strings, (size_t)in->n_strings + 1,
                                sizeof(char *));
    if (!n) return WG_ERR_NOMEM;
    in->strings = n;
    if (!(n[in->n_strings] = wg_strdup(s ? s : ""))) return WG_ERR_NOMEM;
    *out = n[in->n_strings++];
    return WG_OK;
}

static int write_param(WgInst *in, const WgParamSpec *s, const WgValue *v)
{
    char *field = (char *)in->params + s->offset;
    switch (s->type) {
    case WG_PARAM_FLOAT_T:
        *(float *)field = (float)v->num;
        break;
    case WG_PARAM_INT_T:
    case WG_PARAM_ENUM_T:
        *(int *)field = (int)v->num;
        break;
    case WG_PARAM_BOOL_T:
        *(bool *)field = v->num != 0;
        break;
    case WG_PARAM_COLOR_T:
        memcpy(field, v->color, 4 * sizeof(float));
        break;
    case WG_PARAM_STRING_T:
        return keep_string(in, v->str, (const char **)field);
    }
    return WG_OK;
}

static int write_defaults(WgInst *in, WgError *err)
{
    const WgNodeType *t = in->type;
    in->params = wg_calloc(1, t->params_size ? t->params_size : 1);
    if (!in->params) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; t->params && t->params[i].name; i++) {
        const WgParamSpec *s = &t->params[i];
        WgValue v = {.type = s->type, .num = s->def};
        if (s->type == WG_PARAM_COLOR_T &&
            wg__color_parse(s->def_string ? s->def_string : "0", v.color))
            return wg_error_set(err, WG_ERR_TYPE, NULL, "bad colour default in '%s'", t->name);
        if (s->type == WG_PARAM_STRING_T) v.str = (char *)(s->def_string ? s->def_string : "");
        if (s->type == WG_PARAM_ENUM_T) v.str = (char *)s->values[(int)s->def];
        int rc = write_param(in, s, &v);
        if (rc) return rc;
    }
    return WG_OK;
}

static int set_param(WgInst *in, const char *name, const char *text, WgError *err)
{
    int i = param_index(in->type, name);
    if (i < 0) return wg_error_set(err, WG_ERR_TYPE, NULL, "internal: no param '%s'", name);
    WgParamDesc d;
    wg__param_desc_from_spec(&d, &in->type->params[i]);
    WgValue v;
    int rc = wg__value_parse(&d, text, &v, err);
    if (!rc) rc = write_param(in, &in->type->params[i], &v);
    wg__value_clear(&v);
    return rc;
}

static bool file_readable(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

/* Hash everything that determines the outputs of `in` (inputs already keyed). */
static int compute_key(Builder *b, WgInst *in)
{
    XXH3_state_t *st = XXH3_createState();
    if (!st) return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    XXH3_128bits_reset(st);
#define ADD(ptr, n) XXH3_128bits_update(st, (ptr), (n))
#define ADD_STR(s) ADD((s), strlen(s) + 1)
    ADD_STR(KEY_VERSION);
    ADD_STR(in->type->name);
    const uint64_t *plugin = wg__node_type_plugin_key(in->type);
    if (plugin) ADD(plugin, 2 * sizeof *plugin);
    int dims[2] = {in->width, in->height};
    ADD(dims, sizeof dims);
    ADD(in->out_channels, sizeof(int) * (size_t)in->n_out);
    const WgNodeType *t = in->type;
    for (int i = 0; t->params && t->params[i].name; i++) {
        const WgParamSpec *s = &t->params[i];
        const char *field = (const char *)in->params + s->offset;
        ADD_STR(s->name);
        switch (s->type) {
        case WG_PARAM_FLOAT_T:
            ADD(field, sizeof(float));
            break;
        case WG_PARAM_INT_T:
        case WG_PARAM_ENUM_T:
            ADD(field, sizeof(int));
            break;
        case WG_PARAM_BOOL_T:
            ADD(field, sizeof(bool));
            break;
        case WG_PARAM_COLOR_T:
            ADD(field, 4 * sizeof(float));
            break;
        case WG_PARAM_STRING_T: {
            const char *str = *(const char *const *)field;
            ADD_STR(str ? str : "");
            if ((s->flags & WG_PARAM_PATH) && str && str[0]) {
                uint64_t h[2];
                if (!wg__hash_file(str, h)) {
                    XXH3_freeState(st);
                    return wg_error_set(b->err, WG_ERR_IO, NULL, "cannot read '%s'", str);
                }
                ADD(h, sizeof h);
            }
            break;
        }
        }
    }
    if (t->flags & WG_NODE_SEEDED) ADD(&in->seed, sizeof in->seed);
    if (t->flags & WG_NODE_TIMED) ADD(&in->time, sizeof in->time);
    for (int i = 0; i < in->n_extra; i++) {
        ADD_STR(in->extra_names[i]);
        ADD(&in->extra_values[i], sizeof(double));
    }
    for (int i = 0; i < in->n_scope; i++) {
        ADD_STR(in->scope_names[i]);
        ADD(&in->scope_values[i], sizeof(double));
    }
    for (int i = 0; i < in->n_in; i++) {
        ADD_STR(in->in_names[i]);
        if (in->in[i].inst < 0) {
            ADD("-", 1);
            continue;
        }
        const WgInst *src = &b->plan->insts[in->in[i].inst];
        ADD(src->key, sizeof src->key);
        ADD(&in->in[i].port, sizeof(int));
    }
    if (in->constant) {
        const WgImage *im = in->constant;
        int shape[3] = {im->width, im->height, im->channels};
        ADD(shape, sizeof shape);
        for (int y = 0; y < im->height; y++)
            ADD(wg_image_row(im, y), sizeof(float) * (size_t)im->width * (size_t)im->channels);
    }
#undef ADD
#undef ADD_STR
    XXH128_hash_t h = XXH3_128bits_digest(st);
    XXH3_freeState(st);
    in->key[0] = h.low64;
    in->key[1] = h.high64;
    return WG_OK;
}

WgNodeContext wg__inst_context(const WgInst *in)
{
    WgNodeContext ctx = {0};
    ctx.node_id = in->id;
    ctx.params = in->params;
    ctx.width = in->width;
    ctx.height = in->height;
    ctx.seed = in->seed;
    ctx.time = in->time;
    ctx.n_inputs = in->n_in;
    ctx.input_names = (const char *const *)in->in_names;
    ctx.input_channels = in->in_channels;
    ctx.n_outputs = in->n_out;
    ctx.n_extra = in->n_extra;
    ctx.extra_names = (const char *const *)in->extra_names;
    ctx.extra_values = in->extra_values;
    ctx.n_scope = in->n_scope;
    ctx.scope_names = (const char *const *)in->scope_names;
    ctx.scope_values = in->scope_values;
    return ctx;
}

/* Finish an instance whose type, id, size, params and inputs are set: check input kinds,
 * decide output channels, run the node's check, key it, and merge with an identical one.
 * Returns the final index in *index. */
static int finish_inst(Builder *b, int *index)
{
    WgInst *in = &b->plan->insts[*index];
    const WgNodeType *t = in->type;
    int rc;
    for (int i = 0; i < in->n_in; i++) {
        if (in->in[i].inst < 0) continue;
        const WgInst *src = &b->plan->insts[in->in[i].inst];
        in->in_channels[i] = src->out_channels[in->in[i].port];
    }
    int n_fixed = 0;
    while (t->inputs && t->inputs[n_fixed].name) n_fixed++;
    for (int i = 0; i < in->n_in && i < n_fixed; i++) {
        if (t->inputs[i].kind == WG_GRAY && in->in_channels[i] == 4) {
            wg_error_set_at(b->err, WG_ERR_TYPE, in->file, in->in_lines[i], 0,
                            "input '%s' takes a gray image but gets a colour one; convert it "
                            "with a 'grayscale' node",
                            in->in_names[i]);
            wg_error_locate(b->err, NULL, 0, in->id);
            wg_error_locate_type(b->err, t->name);
            return WG_ERR_TYPE;
        }
    }
    for (int o = 0; o < in->n_out && !in->constant; o++) { /* constants: set by the caller */
        int kind = t->outputs[o].kind;
        if (kind == WG_ANY) {
            WgNodeContext ctx = wg__inst_context(in);
            if (t->output_channels) {
                kind = t->output_channels(&ctx, o);
            } else {
                kind = 1;
                for (int i = 0; i < in->n_in; i++)
                    if (in->in_channels[i] > kind) kind = in->in_channels[i];
            }
        }
        in->out_channels[o] = kind == WG_COLOR ? 4 : 1;
    }
    if (t->check) {
        WgNodeContext ctx = wg__inst_context(in);
        WgError e = {0};
        if ((rc = t->check(&ctx, &e))) {
            wg_error_set_at(b->err, rc, in->file, in->line, e.column, "%s", e.message);
            wg_error_locate(b->err, NULL, 0, in->id);
            wg_error_locate_type(b->err, t->name);
            return rc;
        }
    }
    if ((rc = compute_key(b, in))) {
        wg_error_locate(b->err, in->file, in->line, in->id);
        return rc;
    }
    int same = wg__key_index_get(&b->merged, in->key, 0);
    if (same >= 0 && b->plan->insts[same].type == t) {
        inst_clear(in);
        b->plan->n_insts--;
        *index = same;
        return WG_OK;
    }
    if (wg__key_index_put(&b->merged, in->key, 0, *index))
        return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    return WG_OK;
}

static int alloc_ports(WgInst *in, int n_in, int n_out)
{
    in->n_in = n_in;
    in->n_out = n_out;
    in->in = wg_calloc((size_t)n_in + 1, sizeof(WgRef));
    in->in_names = wg_calloc((size_t)n_in + 1, sizeof(char *));
    in->in_channels = wg_calloc((size_t)n_in + 1, sizeof(int));
    in->in_lines = wg_calloc((size_t)n_in + 1, sizeof(int));
    in->out_channels = wg_calloc((size_t)n_out + 1, sizeof(int));
    if (!in->in || !in->in_names || !in->in_channels || !in->in_lines || !in->out_channels)
        return WG_ERR_NOMEM;
    for (int i = 0; i < n_in; i++) in->in[i].inst = -1;
    return WG_OK;
}

static int count_ports(const WgPortSpec *p)
{
    int n = 0;
    while (p && p[n].name) n++;
    return n;
}

/* A source instance made by the engine (input defaults, input files, constant images). */
static int engine_source(Builder *b, const char *type_name, const char *id, const char *file,
                         int line, int w, int h, int *index)
{
    const WgNodeType *t = !strcmp(type_name, "constant")  ? &wg__node_constant
                          : !strcmp(type_name, "promote") ? &wg__node_promote
                                                          : wg__node_type_lookup(type_name);
    if (!t) return wg_error_set(b->err, WG_ERR_TYPE, NULL, "internal: no node '%s'", type_name);
    WgInst *in = inst_push(b);
    if (!in) return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    *index = b->plan->n_insts - 1;
    in->type = t;
    in->id = wg_strdup(id);
    in->file = file;
    in->line = line;
    in->width = w;
    in->height = h;
    if (!in->id || alloc_ports(in, 0, count_ports(t->outputs)))
        return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    return write_defaults(in, b->err);
}

/* ---- sizes ------------------------------------------------------------------------------- */

static int resolve_size(Builder *b, Frame *f, const NodeDef *n, const WgRef *inputs, int n_in,
                        int *w, int *h)
{
    const char *s = n->size_text;
    *w = f->width;
    *h = f->height;
    if (!s || !strcmp(s, "graph")) return WG_OK;
    if (!strcmp(s, "input")) {
        for (int i = 0; i < n_in; i++) {
            if (inputs[i].inst < 0) continue;
            *w = b->plan->insts[inputs[i].inst].width;
            *h = b->plan->insts[inputs[i].inst].height;
            return WG_OK;
        }
        return wg_error_set_at(b->err, WG_ERR_PARSE, f->g->path, n->line, 0,
                               "size=\"input\" but no input is connected");
    }
    if (s[0] == 'x' || s[0] == '/') {
        double k = strtod(s + 1, NULL);
        double fw = s[0] == 'x' ? f->width * k : f->width / k;
        double fh = s[0] == 'x' ? f->height * k : f->height / k;
        long lw = lround(fw), lh = lround(fh);
        if (lw < 1 || lh < 1 || lw > WG_MAX_SIDE || lh > WG_MAX_SIDE)
            return wg_error_set_at(b->err, WG_ERR_RANGE, f->g->path, n->line, 0,
                                   "size '%s' of %dx%d gives %.0fx%.0f, outside 1..%d", s, f->width,
                                   f->height, fw, fh, WG_MAX_SIDE);
        *w = (int)lw;
        *h = (int)lh;
        return WG_OK;
    }
    wg_parse_size(s, w, h); /* validated at load */
    return WG_OK;
}

/* ---- attribute values -------------------------------------------------------------------- */

static int eval_attr(Builder *b, Frame *f, const NodeDef *n, const AttrDef *a, const WgParamDesc *d,
                     const double *slots, WgValue *out)
{
    int rc;
    if (a->expr) {
        for (int i = 0; i < a->expr->count_ && !b->plan->reads_time; i++)
            b->plan->reads_time = a->expr->nodes_[i].op == WG_EX_VAR &&
                                  a->expr->nodes_[i].slot == f->g->n_params + WG_SCOPE_TIME;
        memset(out, 0, sizeof *out);
        out->type = d ? d->type : WG_PARAM_FLOAT_T;
        out->num = wg_expr_eval(a->expr, slots);
        WgParamDesc any = {.name = a->name, .type = WG_PARAM_FLOAT_T};
        rc = wg__value_check(d ? d : &any, out, b->err);
        if (rc) {
            char msg[1024];
            snprintf(msg, sizeof msg, "expression '%s' gives: %s", a->text + 1,
                     b->err ? b->err->message : "");
            return wg_error_set_at(b->err, rc, f->g->path, a->line, 0, "%s", msg);
        }
        return WG_OK;
    }
    if (a->ref_param >= 0) {
        const WgValue *src = &f->values[a->ref_param];
        if (d && d->type == WG_PARAM_ENUM_T) {
            /* match by name: the graph's enum may list other values */
            WgError e = {0};
            rc = wg__value_parse(d, src->str ? src->str : "", out, &e);
            if (rc) return wg_error_set_at(b->err, rc, f->g->path, a->line, 0, "%s", e.message);
            return WG_OK;
        }
        return wg__value_copy(out, src);
    }
    return wg__value_copy(out, &a->literal);
}

/* ---- built-in nodes ---------------------------------------------------------------------- */

static int inst_builtin(Builder *b, Frame *f, int idx, int *result)
{
    const WgGraph *g = f->g;
    const NodeDef *n = &g->nodes[idx];
    const WgNodeType *t = n->type;
    int rc;
    int n_fixed = count_ports(t->inputs);
    int n_in = n_fixed;
    for (int k = 0; k < n->n_ins; k++)
        if (n->ins[k].port_index >= n_in) n_in = n->ins[k].port_index + 1;
    WgRef *refs = wg_calloc((size_t)n_in + 1, sizeof(WgRef));
    int *lines = wg_calloc((size_t)n_in + 1, sizeof(int));
    const char **names = wg_calloc((size_t)n_in + 1, sizeof(char *));
    if (!refs || !lines || !names) {
        wg_free(refs);
        wg_free(lines);
        wg_free(names);
        return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    for (int i = 0; i < n_in; i++) refs[i].inst = -1;
    for (int i = 0; i < n_fixed; i++) names[i] = t->inputs[i].name;
    for (int k = 0; k < n->n_ins; k++) {
        const InDef *in = &n->ins[k];
        lines[in->port_index] = in->line;
        names[in->port_index] = in->port;
        if ((rc = resolve_ref(b, f, in->from_node, in->from_port, in->from_input, in->line,
                              &refs[in->port_index])))
            goto out;
    }
    /* dynamic ports are numbered by <in> order; squeeze out the gaps */
    int used = n_fixed;
    for (int i = n_fixed; i < n_in; i++) {
        if (!names[i]) continue;
        refs[used] = refs[i];
        lines[used] = lines[i];
        names[used] = names[i];
        used++;
    }
    n_in = used;
    int w, h;
    if ((rc = resolve_size(b, f, n, refs, n_in, &w, &h))) goto out;
    uint64_t seed = n->seed_text ? strtoull(n->seed_text, NULL, 10) : f->seed;
    double *slots = wg_calloc((size_t)g->n_params + WG_SCOPE_COUNT_, sizeof(double));
    WgInst *in = inst_push(b);
    if (!in || !slots) {
        wg_free(slots);
        rc = wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    int index = b->plan->n_insts - 1;
    fill_scope(f, slots, seed, w, h);
    in->type = t;
    if (t->flags & WG_NODE_TIMED) b->plan->reads_time = true;
    size_t idl = strlen(f->prefix) + strlen(n->id) + 1;
    in->id = wg_malloc(idl);
    if (in->id) snprintf(in->id, idl, "%s%s", f->prefix, n->id);
    in->file = g->path;
    in->line = n->line;
    in->width = w;
    in->height = h;
    in->seed = seed;
    in->time = f->time;
    if (!in->id || alloc_ports(in, n_in, count_ports(t->outputs))) {
        rc = wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out_slots;
    }
    for (int i = 0; i < n_in; i++) {
        in->in[i] = refs[i];
        in->in_lines[i] = lines[i] ? lines[i] : n->line;
        if (!(in->in_names[i] = wg_strdup(names[i]))) {
            rc = WG_ERR_NOMEM;
            goto out_slots;
        }
    }
    if ((rc = write_defaults(in, b->err))) goto out_slots;
    for (int k = 0; k < n->n_attrs; k++) {
        const AttrDef *a = &n->attrs[k];
        WgValue v;
        if (a->param < 0) { /* extra numeric attribute */
            if ((rc = eval_attr(b, f, n, a, NULL, slots, &v))) goto out_slots;
            char **names = wg_realloc_array(in->extra_names, (size_t)in->n_extra,
                                            (size_t)in->n_extra + 1, sizeof(char *));
            double *vals = names ? wg_realloc_array(in->extra_values, (size_t)in->n_extra,
                                                    (size_t)in->n_extra + 1, sizeof(double))
                                 : NULL;
            if (names) in->extra_names = names;
            if (vals) in->extra_values = vals;
            if (!names || !vals || !(names[in->n_extra] = wg_strdup(a->name))) {
                rc = WG_ERR_NOMEM;
                goto out_slots;
            }
            vals[in->n_extra++] = v.num;
            continue;
        }
        const WgParamSpec *s = &t->params[a->param];
        WgParamDesc d;
        wg__param_desc_from_spec(&d, s);
        if ((rc = eval_attr(b, f, n, a, &d, slots, &v))) goto out_slots;
        if ((s->flags & WG_PARAM_PATH) && v.str && v.str[0]) {
            char *full = v.str[0] == '/' ? wg_strdup(v.str) : NULL;
            if (!full) {
                size_t l = strlen(g->dir) + strlen(v.str) + 2;
                if ((full = wg_malloc(l))) snprintf(full, l, "%s/%s", g->dir, v.str);
            }
            wg_free(v.str);
            v.str = full;
            if (!full) {
                rc = WG_ERR_NOMEM;
                goto out_slots;
            }
            if (!file_readable(full)) {
                rc = wg_error_set_at(b->err, WG_ERR_IO, g->path, a->line, 0, "file '%s' not found",
                                     full);
                wg__value_clear(&v);
                goto out_slots;
            }
        }
        rc = write_param(in, s, &v);
        wg__value_clear(&v);
        if (rc) goto out_slots;
    }
    if (t->flags & WG_NODE_SCOPED) {
        int ns = g->n_params + WG_SCOPE_COUNT_;
        in->scope_names = wg_calloc((size_t)ns, sizeof(char *));
        in->scope_values = wg_calloc((size_t)ns, sizeof(double));
        if (!in->scope_names || !in->scope_values) {
            rc = WG_ERR_NOMEM;
            goto out_slots;
        }
        static const char *const specials[] = {"$time", "$seed", "$width", "$height"};
        for (int i = 0; i < ns; i++) {
            WgParamType pt = i < g->n_params ? g->params[i].info.type : WG_PARAM_FLOAT_T;
            if (pt == WG_PARAM_COLOR_T || pt == WG_PARAM_STRING_T) continue;
            const char *nm = i < g->n_params ? g->params[i].info.name : specials[i - g->n_params];
            if (t->uses_scope_name && !t->uses_scope_name(in->params, nm)) continue;
            if (!(in->scope_names[in->n_scope] = wg_strdup(nm))) {
                rc = WG_ERR_NOMEM;
                goto out_slots;
            }
            if (i == g->n_params + WG_SCOPE_TIME) b->plan->reads_time = true;
            in->scope_values[in->n_scope++] = slots[i];
        }
    }
    rc = finish_inst(b, &index);
    if (!rc) *result = index;
out_slots:
    wg_free(slots);
out:
    wg_free(refs);
    wg_free(lines);
    wg_free(names);
    return rc;
}

/* ---- subgraph nodes ---------------------------------------------------------------------- */

/* A subgraph input declared gray refuses colour; one declared colour promotes gray through an
 * engine-made `promote` instance, as a colour port of a built-in node would. */
static int match_input_kind(Builder *b, Frame *f, const NodeDef *n, const InDef *in, WgRef *ref)
{
    const InputDef *d = &n->sub->inputs[in->port_index];
    const WgInst *src = &b->plan->insts[ref->inst];
    int channels = src->out_channels[ref->port];
    if (d->info.kind == WG_GRAY && channels == 4)
        return wg_error_set_at(b->err, WG_ERR_TYPE, f->g->path, in->line, 0,
                               "input '%s' of subgraph '%s' takes a gray image but gets a colour "
                               "one; convert it with a 'grayscale' node",
                               in->port, n->type_name);
    if (d->info.kind != WG_COLOR || channels == 4) return WG_OK;
    char id[600];
    snprintf(id, sizeof id, "%s%s/$%s", f->prefix, n->id, in->port);
    int index;
    int rc = engine_source(b, "promote", id, f->g->path, in->line, src->width, src->height, &index);
    if (rc) return rc;
    WgInst *p = &b->plan->insts[index];
    wg_free(p->in);
    wg_free(p->in_names);
    wg_free(p->in_channels);
    wg_free(p->in_lines);
    wg_free(p->out_channels);
    if (alloc_ports(p, 1, 1) || !(p->in_names[0] = wg_strdup("source")))
        return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    p->in[0] = *ref;
    p->in_lines[0] = in->line;
    if ((rc = finish_inst(b, &index))) return rc;
    ref->inst = index;
    ref->port = 0;
    return WG_OK;
}

static int inst_sub(Builder *b, Frame *f, int idx, Frame **out)
{
    const WgGraph *g = f->g;
    const NodeDef *n = &g->nodes[idx];
    const WgGraph *sg = n->sub;
    int rc;
    size_t pl = strlen(f->prefix) + strlen(n->id) + 2;
    char *prefix = wg_malloc(pl);
    if (!prefix) return WG_ERR_NOMEM;
    snprintf(prefix, pl, "%s%s/", f->prefix, n->id);
    Frame *c = frame_new(b, sg, prefix);
    wg_free(prefix);
    if (!c) return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    WgRef *refs = wg_calloc((size_t)sg->n_inputs + 1, sizeof(WgRef));
    if (!refs) return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int i = 0; i < sg->n_inputs; i++) refs[i].inst = -1;
    rc = WG_OK;
    for (int k = 0; k < n->n_ins && !rc; k++) {
        const InDef *in = &n->ins[k];
        rc = resolve_ref(b, f, in->from_node, in->from_port, in->from_input, in->line,
                         &refs[in->port_index]);
        if (!rc) rc = match_input_kind(b, f, n, in, &refs[in->port_index]);
    }
    if (!rc) rc = resolve_size(b, f, n, refs, sg->n_inputs, &c->width, &c->height);
    if (!rc) {
        memcpy(c->inputs, refs, sizeof(WgRef) * (size_t)sg->n_inputs);
        c->seed = n->seed_text ? strtoull(n->seed_text, NULL, 10) : f->seed;
        c->time = f->time;
        double *slots = wg_calloc((size_t)g->n_params + WG_SCOPE_COUNT_, sizeof(double));
        if (!slots)
            rc = WG_ERR_NOMEM;
        else
            fill_scope(f, slots, c->seed, c->width, c->height);
        for (int k = 0; k < n->n_attrs && !rc; k++) {
            const AttrDef *a = &n->attrs[k];
            WgValue v;
            rc = eval_attr(b, f, n, a, &sg->params[a->param].desc, slots, &v);
            if (!rc) {
                wg__value_clear(&c->values[a->param]);
                c->values[a->param] = v;
            }
        }
        wg_free(slots);
    }
    wg_free(refs);
    if (!rc) rc = frame_warnings(b, c);
    if (!rc) *out = c;
    return rc;
}

/* ---- warnings ---------------------------------------------------------------------------- */

void wg_warnings_free(WgWarning *w, int count)
{
    if (!w) return;
    for (int i = 0; i < count; i++) {
        wg_free((char *)w[i].file);
        wg_free((char *)w[i].node);
        wg_free((char *)w[i].message);
    }
    wg_free(w);
}

/* Appends `s` to the growing message *buf (length *len). */
static int append(char **buf, size_t *len, const char *s)
{
    size_t n = strlen(s);
    char *p = wg_realloc_array(*buf, *buf ? *len + 1 : 0, *len + n + 1, 1);
    if (!p) return WG_ERR_NOMEM;
    memcpy(p + *len, s, n + 1);
    *buf = p;
    *len += n;
    return WG_OK;
}

static int warning_value(Builder *b, const Frame *f, const WarningDef *w, const WgExpr *e,
                         const char *what, const double *slots, double *out)
{
    *out = wg_expr_eval(e, slots);
    if (isfinite(*out)) return WG_OK;
    char id[512] = "";
    if (f->prefix[0])
        snprintf(id, sizeof id, "node '%.*s': ", (int)strlen(f->prefix) - 1, f->prefix);
    return wg_error_set_at(b->err, WG_ERR_RANGE, f->g->path, w->line, 0,
                           "%swarning: %s gives %g, not a finite number", id, what, *out);
}

/* The frame's <warning>s whose `when` is non-zero, with their messages filled in, added to the
 * plan. Evaluated once the frame's parameters, size and seed are known. */
static int frame_warnings(Builder *b, const Frame *f)
{
    const WgGraph *g = f->g;
    if (!g->n_warnings) return WG_OK;
    double *slots = wg_calloc((size_t)g->n_params + WG_SCOPE_COUNT_, sizeof(double));
    if (!slots) return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    fill_scope(f, slots, f->seed, f->width, f->height);
    WgPlan *p = b->plan;
    int rc = WG_OK;
    for (int i = 0; i < g->n_warnings && !rc; i++) {
        const WarningDef *w = &g->warnings[i];
        double v;
        char what[300];
        snprintf(what, sizeof what, "'when' expression '%.200s'", w->when_text + 1);
        if ((rc = warning_value(b, f, w, w->when, what, slots, &v)) || v == 0) continue;
        char *msg = NULL;
        size_t len = 0;
        rc = append(&msg, &len, "");
        for (int k = 0; k < w->n_parts && !rc; k++) {
            const WarnPart *part = &w->parts[k];
            char num[128];
            if (part->text) {
                rc = append(&msg, &len, part->text);
                continue;
            }
            if (part->expr) {
                if ((rc = warning_value(b, f, w, part->expr, "an expression in its message", slots,
                                        &v)))
                    break;
                snprintf(num, sizeof num, "%.6g", v);
                rc = append(&msg, &len, num);
                continue;
            }
            const WgValue *pv = &f->values[part->param];
            if (pv->type == WG_PARAM_FLOAT_T)
                wg__number_text(pv->num, num, sizeof num);
            else
                wg__value_format(pv, num, sizeof num);
            rc = append(&msg, &len, pv->type == WG_PARAM_STRING_T && pv->str ? pv->str : num);
        }
        if (!rc) {
            WgWarning *nw = wg_realloc_array(p->warnings, (size_t)p->n_warnings,
                                             (size_t)p->n_warnings + 1, sizeof *nw);
            if (!nw)
                rc = WG_ERR_NOMEM;
            else {
                p->warnings = nw;
                nw = &p->warnings[p->n_warnings];
                memset(nw, 0, sizeof *nw);
                nw->line = w->line;
                nw->message = msg;
                msg = NULL;
                p->n_warnings++;
                nw->file = wg_strdup(g->path);
                if (f->prefix[0]) {
                    size_t pl = strlen(f->prefix) - 1; /* without the trailing '/' */
                    char *node = wg_malloc(pl + 1);
                    if (node) {
                        memcpy(node, f->prefix, pl);
                        node[pl] = '\0';
                    }
                    nw->node = node;
                    if (!node) rc = WG_ERR_NOMEM;
                }
                if (!nw->file) rc = WG_ERR_NOMEM;
            }
        }
        wg_free(msg);
        if (rc == WG_ERR_NOMEM) rc = wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    wg_free(slots);
    return rc;
}

/* ---- references -------------------------------------------------------------------------- */

static int input_default(Builder *b, Frame *f, int input, int line, WgRef *out)
{
    const WgGraph *g = f->g;
    const InputDef *d = &g->inputs[input];
    if (f->input_default[input] < 0) {
        if (!d->info.has_default) {
            if (!f->prefix[0])
                return wg_error_set_at(b->err, WG_ERR_USAGE, g->path, d->info.line, 0,
                                       "graph input '%s' has no default and no image was given "
                                       "(--input %s=FILE)",
                                       d->info.name, d->info.name);
            return wg_error_set_at(b->err, WG_ERR_PARSE, g->path, line, 0,
                                   "graph input '%s' has no default and is not connected",
                                   d->info.name);
        }
        char id[512];
        snprintf(id, sizeof id, "%s$%s", f->prefix, d->info.name);
        int index;
        int rc =
            engine_source(b, "uniform", id, g->path, d->info.line, f->width, f->height, &index);
        if (rc) return rc;
        WgInst *in = &b->plan->insts[index];
        char text[160];
        snprintf(text, sizeof text, "%.9g %.9g %.9g %.9g", d->def[0], d->def[1], d->def[2],
                 d->def[3]);
        char value[64];
        snprintf(value, sizeof value, "%.9g", d->def[0]);
        /* only the field in use: a colour default need not fit the gray value's range */
        bool color = d->info.kind == WG_COLOR;
        if ((rc = set_param(in, "kind", color ? "color" : "gray", b->err)) ||
            (rc = set_param(in, color ? "color" : "value", color ? text : value, b->err)) ||
            (rc = finish_inst(b, &index)))
            return rc;
        f->input_default[input] = index;
    }
    out->inst = f->input_default[input];
    out->port = 0;
    return WG_OK;
}

/* A node of a frame that must be instantiated before what asked for it. */
typedef struct Want {
    Frame *f;
    int node;
    int next_in; /* its inputs before this one are known to be ready */
} Want;

/* Follows a reference through subgraph outputs into the frames that produce it, building
 * nothing but input defaults. Sets *out and leaves need->f NULL when the reference resolves;
 * otherwise names in *need the node to instantiate first. A loop, not recursion, so nesting
 * depth costs no stack. */
static int peek_ref(Builder *b, Frame *f, int node, int port, int input, int line, WgRef *out,
                    Want *need)
{
    need->f = NULL;
    for (;;) {
        if (node < 0) {
            if (f->inputs[input].inst >= 0) {
                *out = f->inputs[input];
                return WG_OK;
            }
            return input_default(b, f, input, line, out);
        }
        const NodeDef *n = &f->g->nodes[node];
        if (n->type) {
            if (f->node_inst[node] < 0) break;
            out->inst = f->node_inst[node];
            out->port = port;
            return WG_OK;
        }
        Frame *c = f->node_sub[node];
        if (!c) break;
        const WgGraph *sg = c->g;
        f = c;
        line = sg->outputs[port].line;
        node = sg->output_node[port];
        input = sg->output_input[port];
        port = sg->output_port[port];
    }
    need->f = f;
    need->node = node;
    need->next_in = 0;
    return WG_OK;
}

/* For a node whose inputs are all built: the reference must resolve now. */
static int resolve_ref(Builder *b, Frame *f, int node, int port, int input, int line, WgRef *out)
{
    Want need;
    int rc = peek_ref(b, f, node, port, input, line, out, &need);
    if (!rc && need.f)
        rc = wg_error_set(b->err, WG_ERR_EVAL, NULL, "internal: '%s' used before it was built",
                          need.f->g->nodes[need.node].id);
    return rc;
}

/* An error while building node `node` of frame f: say where, unless a deeper place said so. */
static int locate_node(Builder *b, Frame *f, int node, int rc)
{
    const NodeDef *n = &f->g->nodes[node];
    char id[512];
    snprintf(id, sizeof id, "%s%s", f->prefix, n->id);
    bool ours = b->err && (!b->err->node[0] || !strcmp(b->err->node, id));
    wg_error_locate(b->err, f->g->path, n->line, id);
    if (ours) wg_error_locate_type(b->err, n->type_name);
    return rc;
}

/* Instantiates `start` and everything it needs, dependencies first, with an explicit stack:
 * a chain of 100,000 nodes is as safe as a chain of three. */
static int build_node(Builder *b, Want start)
{
    if (b->n_wants == b->cap_wants) {
        int cap = b->cap_wants ? 2 * b->cap_wants : 64;
        Want *w = wg_realloc_array(b->wants, (size_t)b->n_wants, (size_t)cap, sizeof *w);
        if (!w) return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
        b->wants = w;
        b->cap_wants = cap;
    }
    int base = b->n_wants;
    b->wants[b->n_wants++] = start;
    while (b->n_wants > base) {
        Want *w = &b->wants[b->n_wants - 1];
        Frame *f = w->f;
        const NodeDef *n = &f->g->nodes[w->node];
        if (n->type ? f->node_inst[w->node] >= 0 : f->node_sub[w->node] != NULL) {
            b->n_wants--;
            continue;
        }
        Want need = {0};
        for (; w->next_in < n->n_ins; w->next_in++) {
            const InDef *in = &n->ins[w->next_in];
            WgRef ref;
            int rc =
                peek_ref(b, f, in->from_node, in->from_port, in->from_input, in->line, &ref, &need);
            if (rc) return locate_node(b, f, w->node, rc);
            if (need.f) break;
        }
        if (need.f) {
            if (b->n_wants == b->cap_wants) {
                int cap = 2 * b->cap_wants;
                Want *nw = wg_realloc_array(b->wants, (size_t)b->n_wants, (size_t)cap, sizeof *nw);
                if (!nw) return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
                b->wants = nw;
                b->cap_wants = cap;
            }
            b->wants[b->n_wants++] = need;
            continue;
        }
        int rc, node = w->node;
        if (n->type) {
            int index = -1;
            rc = inst_builtin(b, f, node, &index);
            if (!rc) f->node_inst[node] = index;
        } else {
            rc = inst_sub(b, f, node, &f->node_sub[node]);
        }
        if (rc) return locate_node(b, f, node, rc);
        b->n_wants--;
    }
    return WG_OK;
}

/* Resolves a reference, building what it needs first. */
static int demand_ref(Builder *b, Frame *f, int node, int port, int input, int line, WgRef *out)
{
    for (;;) {
        Want need;
        int rc = peek_ref(b, f, node, port, input, line, out, &need);
        if (rc || !need.f) return rc;
        if ((rc = build_node(b, need))) return rc;
    }
}

/* ---- the top frame ----------------------------------------------------------------------- */

static int top_size(Builder *b, const WgGraph *g, int *w, int *h)
{
    const WgRequest *r = b->r;
    if (r->width != 0 || r->height != 0) {
        if (r->width < 1 || r->height < 1 || r->width > WG_MAX_SIDE || r->height > WG_MAX_SIDE)
            return wg_error_set(b->err, WG_ERR_RANGE, NULL, "size %dx%d is outside 1..%d per side",
                                r->width, r->height, WG_MAX_SIDE);
        *w = r->width;
        *h = r->height;
        return WG_OK;
    }
    const char *s = g->size_text;
    if (s[0] != '$') {
        wg_parse_size(s, w, h);
        return WG_OK;
    }
    int i = wg__graph_find_input(g, s + 1);
    if (r->input_images[i]) {
        *w = r->input_images[i]->width;
        *h = r->input_images[i]->height;
        return WG_OK;
    }
    if (r->input_paths[i]) {
        int c;
        WgError e = {0};
        if (wg_image_probe(r->input_paths[i], w, h, &c, &e)) {
            if (b->err) *b->err = e;
            return e.code;
        }
        return WG_OK;
    }
    return wg_error_set_at(b->err, WG_ERR_USAGE, g->path, g->size_line, 0,
                           "the graph size is '%s' but no image was given for input '%s' "
                           "(--input %s=FILE or --size WxH)",
                           s, s + 1, s + 1);
}

/* The height_scale of each <gltf> of the top graph for this request: a number as written, an
 * expression evaluated over the parameters' values, which must give 0 .. 1e6. */
static int gltf_height_scales(Builder *b, const Frame *f)
{
    const WgGraph *g = f->g;
    if (g->n_gltfs == 0) return WG_OK;
    double *slots = wg_calloc((size_t)g->n_params + WG_SCOPE_COUNT_, sizeof(double));
    b->plan->gltf_height_scales = wg_calloc((size_t)g->n_gltfs, sizeof(double));
    if (!slots || !b->plan->gltf_height_scales) {
        wg_free(slots);
        return wg_error_set(b->err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    fill_scope(f, slots, f->seed, f->width, f->height);
    b->plan->n_gltfs = g->n_gltfs;
    int rc = WG_OK;
    for (int i = 0; i < g->n_gltfs && !rc; i++) {
        const WgGraphGltfInfo *a = &g->gltfs[i];
        double v = a->height_scale;
        if (g->gltf_height_exprs[i]) v = wg_expr_eval(g->gltf_height_exprs[i], slots);
        if (!(v >= 0 && v <= 1e6))
            rc = wg_error_set_at(b->err, WG_ERR_RANGE, g->path, a->line, 0,
                                 "gltf '%s': height_scale =%s gives %g, outside 0 .. 1e6", a->name,
                                 a->height_scale_expr, v);
        b->plan->gltf_height_scales[i] = v;
    }
    wg_free(slots);
    return rc;
}

int wg__plan_build(const WgRequest *r, WgPlan *plan, WgError *err)
{
    memset(plan, 0, sizeof *plan);
    Builder b = {.r = r, .plan = plan, .err = err};
    const WgGraph *g = r->graph;
    int rc;
    Frame *top = frame_new(&b, g, "");
    if (!top) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    if ((rc = top_size(&b, g, &top->width, &top->height))) goto out;
    top->seed = r->has_seed ? r->seed : g->seed;
    top->time = r->time;
    for (int i = 0; i < g->n_params; i++) {
        if (!r->value_set[i]) continue;
        wg__value_clear(&top->values[i]);
        if ((rc = wg__value_copy(&top->values[i], &r->values[i]))) goto out;
    }
    if ((rc = frame_warnings(&b, top))) goto out;
    if ((rc = gltf_height_scales(&b, top))) goto out;
    for (int i = 0; i < g->n_inputs; i++) {
        const InputDef *d = &g->inputs[i];
        char id[300];
        snprintf(id, sizeof id, "$%s", d->info.name);
        int index;
        if (r->input_images[i]) {
            if ((rc = engine_source(&b, "constant", id, g->path, d->info.line, top->width,
                                    top->height, &index)))
                goto out;
            WgInst *in = &plan->insts[index];
            in->constant = wg_image_ref(r->input_images[i]);
            in->out_channels[0] = d->info.kind == WG_COLOR ? 4 : 1;
        } else if (r->input_paths[i]) {
            if ((rc = engine_source(&b, "image", id, g->path, d->info.line, top->width, top->height,
                                    &index)))
                goto out;
            WgInst *in = &plan->insts[index];
            if ((rc = set_param(in, "path", r->input_paths[i], err)) ||
                (rc = set_param(in, "colorspace", d->info.colorspace == WG_SRGB ? "srgb" : "linear",
                                err)) ||
                (rc = set_param(in, "kind", d->info.kind == WG_COLOR ? "color" : "gray", err)))
                goto out;
        } else {
            continue;
        }
        if ((rc = finish_inst(&b, &index))) goto out;
        top->inputs[i].inst = index;
        top->inputs[i].port = 0;
    }
    int n_out = r->n_outputs ? r->n_outputs : g->n_outputs;
    plan->outputs = wg_calloc((size_t)n_out + 1, sizeof(WgPlanOutput));
    if (!plan->outputs) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    for (int k = 0; k < n_out; k++) {
        int o = r->n_outputs ? wg__graph_find_output(g, r->outputs[k]) : k;
        WgPlanOutput *po = &plan->outputs[plan->n_outputs++];
        po->name = wg_strdup(g->outputs[o].name);
        po->format = g->outputs[o].format;
        po->colorspace = g->outputs[o].colorspace;
        po->compression = g->outputs[o].compression;
        if (!po->name) {
            rc = WG_ERR_NOMEM;
            goto out;
        }
        if ((rc = demand_ref(&b, top, g->output_node[o], g->output_port[o], g->output_input[o],
                             g->outputs[o].line, &po->ref)))
            goto out;
        if (po->format == WG_FORMAT_DEFAULT)
            po->format = plan->insts[po->ref.inst].out_channels[po->ref.port] == 4
                             ? WG_FORMAT_PNG
                             : WG_FORMAT_PNG16;
    }
out:
    if (rc && err && err->code == WG_OK)
        wg_error_set(err, rc, NULL, "%s",
                     rc == WG_ERR_NOMEM ? "out of memory" : wg_status_name(rc));
    for (int i = 0; i < b.n_frames; i++) frame_free(b.frames[i]);
    wg_free(b.frames);
    wg_free(b.wants);
    wg__key_index_free(&b.merged);
    if (rc) wg__plan_free(plan);
    return rc;
}

int wg_request_reads_time(const WgRequest *r, bool *out, WgError *err)
{
    WgPlan plan;
    int rc = wg__plan_build(r, &plan, err);
    if (rc) return rc;
    *out = plan.reads_time;
    wg__plan_free(&plan);
    return WG_OK;
}

int wg_request_warnings(const WgRequest *r, WgWarning **out, int *count, WgError *err)
{
    WgPlan plan;
    *out = NULL;
    *count = 0;
    int rc = wg__plan_build(r, &plan, err);
    if (rc) return rc;
    *out = plan.warnings;
    *count = plan.n_warnings;
    plan.warnings = NULL;
    plan.n_warnings = 0;
    wg__plan_free(&plan);
    return WG_OK;
}

/* The engine-internal node behind wg_request_set_input_image. */
static int constant_eval(WgNodeContext *ctx, WgError *err)
{
    (void)ctx;
    return wg_error_set(err, WG_ERR_EVAL, NULL, "internal: constant images are not evaluated");
}

static const WgPortSpec constant_out[] = {WG_PORT("image", WG_ANY), WG_PORT_END};
const WgNodeType wg__node_constant = {
    .name = "constant",
    .summary = "An image given through the API",
    .category = "internal",
    .outputs = constant_out,
    .flags = WG_NODE_SOURCE | WG_NODE_SERIAL,
    .eval = constant_eval,
};

/* The engine-internal node that turns a gray image into colour for a subgraph's colour input
 * (the engine promotes the input of a colour port; the node copies it). */
static int promote_eval(WgNodeContext *ctx, WgError *err)
{
    (void)err;
    const WgImage *in = ctx->inputs[0];
    WgImage *out = ctx->outputs[0];
    for (int y = 0; y < out->height; y++)
        memcpy(wg_image_row(out, y), wg_image_row(in, y), sizeof(float) * 4 * (size_t)out->width);
    return WG_OK;
}

static const WgPortSpec promote_in[] = {WG_PORT("source", WG_COLOR), WG_PORT_END};
static const WgPortSpec promote_out[] = {WG_PORT("output", WG_COLOR), WG_PORT_END};
const WgNodeType wg__node_promote = {
    .name = "promote",
    .summary = "Gray to colour for a subgraph's colour input",
    .category = "internal",
    .inputs = promote_in,
    .outputs = promote_out,
    .flags = WG_NODE_POINT | WG_NODE_CHEAP | WG_NODE_SERIAL,
    .eval = promote_eval,
};
