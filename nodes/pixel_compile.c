/* SPDX-License-Identifier: MIT */
/* The compiler of the `pixel` node: expression text -> row program (nodes/pixel_program.h).
 * The shared parser (engine/expr.c) builds the AST and resolves names through `resolve` below
 * (inputs, then extras, then graph scope, then u v x y). One pass over the tree in postorder
 * (the order of the parser's node array: a loop, so flat chains of any length cost no stack)
 * then type-checks and lowers it: each subexpression is a number or a colour (four numbers, one
 * value per channel; arithmetic and the maths functions work per channel, broadcasting a number to
 * the four channels), every operation whose operands are all constants is folded at once with the
 * scalar semantics of wg_expr_apply / wg_expr_call in double, and identical operations are
 * shared (hash-consing, so a channel read or a broadcast used twice is computed once). A
 * constant condition selects its branch. Afterwards dead values are dropped, the live ones are
 * split into row-uniform and varying lists, and varying values get scratch registers by a
 * linear scan over their last uses (a result never shares a register with its operands, so the
 * kernels can promise `restrict`). Type errors carry the column of the offending operand. */
#include "pixel_program.h"

#include <math.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

/* ---- operation table --------------------------------------------------------------------- */

static const struct {
    const char *name;
    int nargs;
    int exop; /* WgExprOp used to fold, or -1 */
    int fn;   /* WgExprFunc used to fold, or -1 */
} ops[WG_PX_COUNT_] = {
    [WG_PX_CONST] = {"const", 0, -1, -1},
    [WG_PX_X] = {"x", 0, -1, -1},
    [WG_PX_U] = {"u", 0, -1, -1},
    [WG_PX_Y] = {"y", 0, -1, -1},
    [WG_PX_V] = {"v", 0, -1, -1},
    [WG_PX_INPUT] = {"input", 0, -1, -1},
    [WG_PX_NEG] = {"neg", 1, WG_EX_NEG, -1},
    [WG_PX_NOT] = {"not", 1, WG_EX_NOT, -1},
    [WG_PX_ABS] = {"abs", 1, -1, WG_FN_ABS},
    [WG_PX_FLOOR] = {"floor", 1, -1, WG_FN_FLOOR},
    [WG_PX_CEIL] = {"ceil", 1, -1, WG_FN_CEIL},
    [WG_PX_FRACT] = {"fract", 1, -1, WG_FN_FRACT},
    [WG_PX_SQRT] = {"sqrt", 1, -1, WG_FN_SQRT},
    [WG_PX_EXP] = {"exp", 1, -1, WG_FN_EXP},
    [WG_PX_LOG] = {"log", 1, -1, WG_FN_LOG},
    [WG_PX_SIN] = {"sin", 1, -1, WG_FN_SIN},
    [WG_PX_COS] = {"cos", 1, -1, WG_FN_COS},
    [WG_PX_TAN] = {"tan", 1, -1, WG_FN_TAN},
    [WG_PX_ROUND] = {"round", 1, -1, WG_FN_ROUND},
    [WG_PX_SIGN] = {"sign", 1, -1, WG_FN_SIGN},
    [WG_PX_ASIN] = {"asin", 1, -1, WG_FN_ASIN},
    [WG_PX_ACOS] = {"acos", 1, -1, WG_FN_ACOS},
    [WG_PX_ATAN] = {"atan", 1, -1, WG_FN_ATAN},
    [WG_PX_ADD] = {"add", 2, WG_EX_ADD, -1},
    [WG_PX_SUB] = {"sub", 2, WG_EX_SUB, -1},
    [WG_PX_MUL] = {"mul", 2, WG_EX_MUL, -1},
    [WG_PX_DIV] = {"div", 2, WG_EX_DIV, -1},
    [WG_PX_MOD] = {"mod", 2, WG_EX_MOD, -1},
    [WG_PX_POW] = {"pow", 2, WG_EX_POW, -1},
    [WG_PX_LT] = {"lt", 2, WG_EX_LT, -1},
    [WG_PX_LE] = {"le", 2, WG_EX_LE, -1},
    [WG_PX_GT] = {"gt", 2, WG_EX_GT, -1},
    [WG_PX_GE] = {"ge", 2, WG_EX_GE, -1},
    [WG_PX_EQ] = {"eq", 2, WG_EX_EQ, -1},
    [WG_PX_NE] = {"ne", 2, WG_EX_NE, -1},
    [WG_PX_AND] = {"and", 2, WG_EX_AND, -1},
    [WG_PX_OR] = {"or", 2, WG_EX_OR, -1},
    [WG_PX_MIN] = {"min", 2, -1, WG_FN_MIN},
    [WG_PX_MAX] = {"max", 2, -1, WG_FN_MAX},
    [WG_PX_STEP] = {"step", 2, -1, WG_FN_STEP},
    [WG_PX_ATAN2] = {"atan2", 2, -1, WG_FN_ATAN2},
    [WG_PX_CLAMP] = {"clamp", 3, -1, WG_FN_CLAMP},
    [WG_PX_LERP] = {"lerp", 3, -1, WG_FN_LERP},
    [WG_PX_SMOOTHSTEP] = {"smoothstep", 3, -1, WG_FN_SMOOTHSTEP},
    [WG_PX_SELECT] = {"select", 3, -1, -1},
    [WG_PX_SAMPLE] = {"sample", 2, -1, -1},
    [WG_PX_NOISE] = {"noise", 3, -1, -1},
};

const char *wg__px_op_name(WgPxOp op)
{
    return (unsigned)op < WG_PX_COUNT_ ? ops[op].name : "?";
}

/* clang-format off */
/* Expression functions that map one-to-one onto a per-channel operation. */
static int func_op(WgExprFunc f)
{
    switch (f) {
    case WG_FN_ABS: return WG_PX_ABS;
    case WG_FN_FLOOR: return WG_PX_FLOOR;
    case WG_FN_CEIL: return WG_PX_CEIL;
    case WG_FN_FRACT: return WG_PX_FRACT;
    case WG_FN_SQRT: return WG_PX_SQRT;
    case WG_FN_EXP: return WG_PX_EXP;
    case WG_FN_LOG: return WG_PX_LOG;
    case WG_FN_SIN: return WG_PX_SIN;
    case WG_FN_COS: return WG_PX_COS;
    case WG_FN_TAN: return WG_PX_TAN;
    case WG_FN_ROUND: return WG_PX_ROUND;
    case WG_FN_SIGN: return WG_PX_SIGN;
    case WG_FN_ASIN: return WG_PX_ASIN;
    case WG_FN_ACOS: return WG_PX_ACOS;
    case WG_FN_ATAN: return WG_PX_ATAN;
    case WG_FN_MIN: return WG_PX_MIN;
    case WG_FN_MAX: return WG_PX_MAX;
    case WG_FN_STEP: return WG_PX_STEP;
    case WG_FN_ATAN2: return WG_PX_ATAN2;
    case WG_FN_MOD: return WG_PX_MOD;
    case WG_FN_POW: return WG_PX_POW;
    case WG_FN_CLAMP: return WG_PX_CLAMP;
    case WG_FN_LERP: return WG_PX_LERP;
    case WG_FN_SMOOTHSTEP: return WG_PX_SMOOTHSTEP;
    default: return -1;
    }
}

static int binary_op(WgExprOp op)
{
    switch (op) {
    case WG_EX_ADD: return WG_PX_ADD;
    case WG_EX_SUB: return WG_PX_SUB;
    case WG_EX_MUL: return WG_PX_MUL;
    case WG_EX_DIV: return WG_PX_DIV;
    case WG_EX_MOD: return WG_PX_MOD;
    case WG_EX_POW: return WG_PX_POW;
    case WG_EX_LT: return WG_PX_LT;
    case WG_EX_LE: return WG_PX_LE;
    case WG_EX_GT: return WG_PX_GT;
    case WG_EX_GE: return WG_PX_GE;
    case WG_EX_EQ: return WG_PX_EQ;
    case WG_EX_NE: return WG_PX_NE;
    case WG_EX_AND: return WG_PX_AND;
    case WG_EX_OR: return WG_PX_OR;
    default: return -1;
    }
}
/* clang-format on */

static const char *op_text(WgExprOp op)
{
    static const char *const text[] = {
        [WG_EX_NEG] = "-",  [WG_EX_NOT] = "!", [WG_EX_LT] = "<",  [WG_EX_LE] = "<=",
        [WG_EX_GT] = ">",   [WG_EX_GE] = ">=", [WG_EX_EQ] = "==", [WG_EX_NE] = "!=",
        [WG_EX_AND] = "&&", [WG_EX_OR] = "||",
    };
    return (unsigned)op < sizeof text / sizeof text[0] && text[op] ? text[op] : "?";
}

/* ---- names ------------------------------------------------------------------------------- */

/* Resolver slots: a class in the high bits, an index below. */
enum {
    SLOT_INPUT = 1 << 24,   /* index: input (its whole value: gray number or colour) */
    SLOT_CHANNEL = 2 << 24, /* index: input * 4 + channel of a colour input */
    SLOT_EXTRA = 3 << 24,
    SLOT_SCOPE = 4 << 24,
    SLOT_BUILTIN = 5 << 24, /* index: 0 u, 1 v, 2 x, 3 y */
    SLOT_LOCAL = 6 << 24,   /* index: a name defined by an earlier `name = ...;` statement */
    SLOT_CLASS = 0xff << 24,
};

/* A typed subexpression: n = 1 (number) or 4 (colour, one value per channel). `col` is the
 * column of the first thing that made it a colour, for error messages. */
typedef struct Typed {
    int n;
    int c[4];
    int col;
} Typed;

/* A name defined by a statement `name = expression;` before the result. */
typedef struct {
    const char *name; /* in the source text, not terminated */
    size_t len;
    Typed value;
} Local;

enum { MAX_LOCALS = 256 };

typedef struct {
    const WgNodeContext *ctx;
    const int *in_ch;
    char hint[256]; /* why the last unknown name is unknown, when we can tell */
    Local locals[MAX_LOCALS];
    int n_locals;
} Names;

static bool same(const char *s, const char *name, size_t len)
{
    return s && strlen(s) == len && !strncmp(s, name, len);
}

static bool resolve(void *user, const char *name, size_t len, int *slot)
{
    Names *nm = user;
    const WgNodeContext *ctx = nm->ctx;
    nm->hint[0] = '\0';
    for (int i = 0; i < nm->n_locals; i++)
        if (nm->locals[i].len == len && !strncmp(nm->locals[i].name, name, len)) {
            *slot = SLOT_LOCAL | i;
            return true;
        }
    for (int i = 0; i < ctx->n_inputs; i++)
        if (same(ctx->input_names[i], name, len)) {
            *slot = SLOT_INPUT | i;
            return true;
        }
    const char *dot = memchr(name, '.', len);
    if (dot && len - (size_t)(dot - name) == 2) {
        const char *chan = strchr("rgba", dot[1]);
        for (int i = 0; chan && dot[1] && i < ctx->n_inputs; i++) {
            if (!same(ctx->input_names[i], name, (size_t)(dot - name))) continue;
            if (nm->in_ch[i] == 4) {
                *slot = SLOT_CHANNEL | (i * 4 + (int)(chan - "rgba"));
                return true;
            }
            snprintf(nm->hint, sizeof nm->hint,
                     "input '%s' is gray: write '%s' (.r .g .b .a are for colour inputs)",
                     ctx->input_names[i], ctx->input_names[i]);
        }
    }
    for (int i = 0; i < ctx->n_extra; i++)
        if (same(ctx->extra_names[i], name, len)) {
            *slot = SLOT_EXTRA | i;
            return true;
        }
    for (int i = 0; i < ctx->n_scope; i++)
        if (same(ctx->scope_names[i], name, len)) {
            *slot = SLOT_SCOPE | i;
            return true;
        }
    static const char *const builtins[] = {"u", "v", "x", "y"};
    for (int i = 0; i < 4; i++)
        if (same(builtins[i], name, len)) {
            *slot = SLOT_BUILTIN | i;
            return true;
        }
    return false;
}

/* ---- building values --------------------------------------------------------------------- */

typedef struct {
    WgPxProgram *p;
    const WgNodeContext *ctx;
    const int *in_ch;
    const char *src;
    WgError *err;
    const WgExprNode *nodes; /* the expression's nodes, in postorder */
    struct Typed *typed;     /* per node: its lowered value */
    int *first;              /* per node: the column where its subexpression starts */
    int *index;              /* hash set of the values, for sharing: value + 1, 0 = free */
    int index_cap;           /* a power of two, at least twice the values */
    int col0;                /* columns of src count from col0 + 1 in the whole `expr` */
    const Names *names;      /* for the values of locals */
} Compiler;

static int error_at(Compiler *k, int code, int column, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static int error_at(Compiler *k, int code, int column, const char *fmt, ...)
{
    char msg[700];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    wg_error_set(k->err, code, NULL, "expr column %d: %s", k->col0 + column, msg);
    if (k->err) k->err->column = k->col0 + column;
    return code;
}

static int nomem(Compiler *k)
{
    return wg_error_set(k->err, WG_ERR_NOMEM, NULL, "out of memory");
}

/* Fold an operation on constants, with the double semantics of the scalar evaluator. */
static double fold(const Compiler *k, WgPxOp op, const double *a)
{
    if (op == WG_PX_SELECT) return a[0] != 0 ? a[1] : a[2];
    if (op == WG_PX_NOISE) return wg__px_noise(k->p->seed, (float)a[0], (float)a[1], (float)a[2]);
    if (ops[op].exop >= 0)
        return wg_expr_apply((WgExprOp)ops[op].exop, a[0], ops[op].nargs > 1 ? a[1] : 0);
    return wg_expr_call((WgExprFunc)ops[op].fn, a, ops[op].nargs);
}

static uint32_t val_hash(WgPxOp op, const int *args, int nargs, int input, int channel,
                         double value)
{
    uint64_t h = (uint64_t)op * 0x9E3779B97F4A7C15u;
    h = (h ^ (uint32_t)input) * 0xBF58476D1CE4E5B9u;
    h = (h ^ (uint32_t)channel) * 0x94D049BB133111EBu;
    for (int i = 0; i < nargs; i++) h = (h ^ (uint32_t)args[i]) * 0x9E3779B97F4A7C15u;
    if (op == WG_PX_CONST) {
        uint64_t bits;
        memcpy(&bits, &value, sizeof bits);
        h = (h ^ bits) * 0xBF58476D1CE4E5B9u;
    }
    return (uint32_t)(h ^ h >> 31 ^ h >> 47);
}

static uint32_t hash_of(const WgPxVal *v)
{
    return val_hash(v->op, v->args, v->nargs, v->input, v->channel, v->value);
}

/* Make room in the hash set for one more value; false when out of memory. */
static bool index_reserve(Compiler *k)
{
    const WgPxProgram *p = k->p;
    if ((p->n_vals + 1) * 2 <= k->index_cap) return true;
    int cap = k->index_cap ? 2 * k->index_cap : 256;
    int *index = wg_calloc((size_t)cap, sizeof(int));
    if (!index) return false;
    for (int i = 0; i < p->n_vals; i++) {
        uint32_t h = hash_of(&p->vals[i]) & (uint32_t)(cap - 1);
        while (index[h]) h = (h + 1) & (uint32_t)(cap - 1);
        index[h] = i + 1;
    }
    wg_free(k->index);
    k->index = index;
    k->index_cap = cap;
    return true;
}

/* Append a value (or find an identical one); returns its index, -1 when out of memory. */
static int emit(Compiler *k, WgPxOp op, const int *args, int input, int channel, double value)
{
    WgPxProgram *p = k->p;
    int nargs = ops[op].nargs;
    bool all_const = op != WG_PX_SAMPLE;
    for (int i = 0; i < nargs; i++) all_const &= p->vals[args[i]].op == WG_PX_CONST;
    if (nargs && all_const) {
        double a[3];
        for (int i = 0; i < nargs; i++) a[i] = p->vals[args[i]].value;
        value = fold(k, op, a);
        op = WG_PX_CONST;
        nargs = 0;
    }
    if (op == WG_PX_POW && p->vals[args[1]].op == WG_PX_CONST && p->vals[args[1]].value == 2) {
        int square[2] = {args[0], args[0]}; /* x^2 is x*x: both correctly rounded */
        return emit(k, WG_PX_MUL, square, 0, 0, 0);
    }
    if (!index_reserve(k)) return -1;
    uint32_t mask = (uint32_t)k->index_cap - 1,
             h = val_hash(op, args, nargs, input, channel, value);
    for (h &= mask; k->index[h]; h = (h + 1) & mask) {
        int i = k->index[h] - 1;
        const WgPxVal *v = &p->vals[i];
        if (v->op != op || v->input != input || v->channel != channel) continue;
        if (op == WG_PX_CONST && memcmp(&v->value, &value, sizeof value)) continue;
        bool match = true;
        for (int j = 0; j < nargs; j++) match &= v->args[j] == args[j];
        if (match) return i;
    }
    if (p->n_vals == p->cap_vals) {
        int cap = p->cap_vals ? 2 * p->cap_vals : 64;
        WgPxVal *n = wg_realloc_array(p->vals, (size_t)p->n_vals, (size_t)cap, sizeof *n);
        if (!n) return -1;
        p->vals = n;
        p->cap_vals = cap;
    }
    WgPxVal *v = &p->vals[p->n_vals];
    memset(v, 0, sizeof *v);
    v->op = op;
    v->nargs = nargs;
    v->input = input;
    v->channel = channel;
    v->value = op == WG_PX_CONST ? value : 0;
    v->reg = v->bcast = -1;
    switch (op) {
    case WG_PX_CONST:
        v->cls = WG_PX_CLASS_CONST;
        break;
    case WG_PX_Y:
    case WG_PX_V:
        v->cls = WG_PX_CLASS_UNIFORM;
        break;
    case WG_PX_X:
    case WG_PX_U:
    case WG_PX_INPUT:
        v->cls = WG_PX_CLASS_VARYING;
        break;
    default:
        /* sample() at coordinates that are constant on a row is constant on that row */
        v->cls = op == WG_PX_SAMPLE ? WG_PX_CLASS_UNIFORM : WG_PX_CLASS_CONST;
        for (int i = 0; i < nargs; i++) {
            v->args[i] = args[i];
            if (p->vals[args[i]].cls > v->cls) v->cls = p->vals[args[i]].cls;
        }
    }
    k->index[h] = p->n_vals + 1;
    return p->n_vals++;
}

static int emit_const(Compiler *k, double value)
{
    return emit(k, WG_PX_CONST, NULL, 0, 0, value);
}

/* Per-channel operation on typed operands, broadcasting numbers to colours. */
static int emit_map(Compiler *k, WgPxOp op, const Typed *a, int nargs, Typed *out)
{
    out->n = 1;
    out->col = 0;
    for (int i = 0; i < nargs; i++)
        if (a[i].n == 4) {
            out->n = 4;
            if (!out->col) out->col = a[i].col;
        }
    for (int j = 0; j < out->n; j++) {
        int args[3];
        for (int i = 0; i < nargs; i++) args[i] = a[i].c[a[i].n == 4 ? j : 0];
        if ((out->c[j] = emit(k, op, args, 0, 0, 0)) < 0) return nomem(k);
    }
    return WG_OK;
}

/* ---- lowering ---------------------------------------------------------------------------- */

/* Text of the token starting at a column (a name, or a function name), for messages. */
static void token_at(const Compiler *k, int column, char *buf, size_t size)
{
    const char *s = k->src + column - 1;
    size_t n = 0;
    while (s[n] && (s[n] == '_' || s[n] == '.' || s[n] == '$' || (s[n] >= '0' && s[n] <= '9') ||
                    (s[n] >= 'a' && s[n] <= 'z') || (s[n] >= 'A' && s[n] <= 'Z')))
        n++;
    if (s[n] == '(') {
        snprintf(buf, size, "%.*s(...)", (int)(n < 60 ? n : 60), s);
        return;
    }
    snprintf(buf, size, "%.*s", (int)(n ? (n < 60 ? n : 60) : 1), s);
}

/* Column where a subexpression starts (a binary node's own column is its operator). */
static int first_column(const Compiler *k, const WgExprNode *e)
{
    return k->first[e - k->nodes];
}

/* The lowered value of operand i of e (lowered before e: postorder). */
static const Typed *operand(const Compiler *k, const WgExprNode *e, int i)
{
    return &k->typed[e->args[i] - k->nodes];
}

static int need_number(Compiler *k, const Typed *t, const char *where)
{
    if (t->n == 1) return WG_OK;
    char tok[80];
    token_at(k, t->col, tok, sizeof tok);
    return error_at(k, WG_ERR_TYPE, t->col,
                    "'%s' is a colour but %s needs a number; take one channel (for an input "
                    "'c': c.r, c.g, c.b or c.a)",
                    tok, where);
}

static int lower_var(Compiler *k, const WgExprNode *e, Typed *out)
{
    const WgNodeContext *ctx = k->ctx;
    int cls = e->slot & SLOT_CLASS, i = e->slot & ~SLOT_CLASS;
    out->n = 1;
    out->col = 0;
    switch (cls) {
    case SLOT_INPUT:
        if (k->in_ch[i] == 4) {
            out->n = 4;
            out->col = e->column;
            for (int j = 0; j < 4; j++)
                if ((out->c[j] = emit(k, WG_PX_INPUT, NULL, i, j, 0)) < 0) return nomem(k);
            return WG_OK;
        }
        out->c[0] = emit(k, WG_PX_INPUT, NULL, i, 0, 0);
        break;
    case SLOT_CHANNEL:
        out->c[0] = emit(k, WG_PX_INPUT, NULL, i / 4, i % 4, 0);
        break;
    case SLOT_EXTRA:
        out->c[0] = emit_const(k, ctx->extra_values[i]);
        break;
    case SLOT_SCOPE:
        out->c[0] = emit_const(k, ctx->scope_values[i]);
        break;
    case SLOT_LOCAL: /* already lowered; a colour is blamed on this use of its name */
        *out = k->names->locals[i].value;
        if (out->n == 4) out->col = e->column;
        return WG_OK;
    default: {
        static const WgPxOp b[] = {WG_PX_U, WG_PX_V, WG_PX_X, WG_PX_Y};
        out->c[0] = emit(k, b[i & 3], NULL, 0, 0, 0);
    }
    }
    return out->c[0] < 0 ? nomem(k) : WG_OK;
}

static int lower_call(Compiler *k, const WgExprNode *e, Typed *out)
{
    Typed a[4];
    const char *fname = wg_expr_func_name(e->func);
    char where[96];
    int rc;
    if (e->func == WG_FN_SAMPLE) {
        const WgExprNode *src = e->args[0];
        int cls = src->op == WG_EX_VAR ? src->slot & SLOT_CLASS : 0;
        if (cls != SLOT_INPUT && cls != SLOT_CHANNEL) {
            char what[120];
            int column = first_column(k, src);
            if (src->op == WG_EX_VAR) {
                char tok[80];
                token_at(k, column, tok, sizeof tok);
                snprintf(what, sizeof what, "'%s' is %s", tok,
                         cls == SLOT_EXTRA   ? "an extra parameter"
                         : cls == SLOT_SCOPE ? "a graph parameter"
                         : cls == SLOT_LOCAL ? "a local name"
                                             : "a coordinate");
            } else {
                snprintf(what, sizeof what, "here it is an expression");
            }
            return error_at(k, WG_ERR_TYPE, column,
                            "the first argument of sample() must name an input (or one "
                            "channel of a colour input, like c.r); %s",
                            what);
        }
        for (int i = 1; i < 3; i++) {
            a[i] = *operand(k, e, i);
            if ((rc = need_number(k, &a[i],
                                  i == 1 ? "the u coordinate of sample()"
                                         : "the v coordinate of sample()")))
                return rc;
        }
        int args[2] = {a[1].c[0], a[2].c[0]};
        int i = src->slot & ~SLOT_CLASS;
        out->col = 0;
        if (cls == SLOT_CHANNEL) {
            out->n = 1;
            out->c[0] = emit(k, WG_PX_SAMPLE, args, i / 4, i % 4, 0);
        } else {
            out->n = k->in_ch[i] == 4 ? 4 : 1;
            if (out->n == 4) out->col = e->column;
            for (int j = 0; j < out->n; j++) out->c[j] = emit(k, WG_PX_SAMPLE, args, i, j, 0);
        }
        for (int j = 0; j < out->n; j++)
            if (out->c[j] < 0) return nomem(k);
        return WG_OK;
    }
    for (int i = 0; i < e->nargs; i++) a[i] = *operand(k, e, i);
    if (e->func == WG_FN_NOISE || e->func == WG_FN_RGB || e->func == WG_FN_RGBA) {
        for (int i = 0; i < e->nargs; i++) {
            snprintf(where, sizeof where, "argument %d of %s()", i + 1, fname);
            if ((rc = need_number(k, &a[i], where))) return rc;
        }
        if (e->func == WG_FN_NOISE) {
            int args[3] = {a[0].c[0], a[1].c[0], a[2].c[0]};
            out->n = 1;
            out->col = 0;
            return (out->c[0] = emit(k, WG_PX_NOISE, args, 0, 0, 0)) < 0 ? nomem(k) : WG_OK;
        }
        out->n = 4;
        out->col = e->column;
        for (int j = 0; j < 3; j++) out->c[j] = a[j].c[0];
        out->c[3] = e->nargs == 4 ? a[3].c[0] : emit_const(k, 1.0);
        return out->c[3] < 0 ? nomem(k) : WG_OK;
    }
    int op = func_op(e->func);
    if (op < 0)
        return error_at(k, WG_ERR_TYPE, e->column, "internal: no operation for %s()", fname);
    if (e->func == WG_FN_MIN || e->func == WG_FN_MAX) {
        /* left fold, as wg_expr_call does */
        Typed m = a[0];
        for (int i = 1; i < e->nargs; i++) {
            Typed pair[2] = {m, a[i]};
            if ((rc = emit_map(k, (WgPxOp)op, pair, 2, &m))) return rc;
        }
        *out = m;
        return WG_OK;
    }
    return emit_map(k, (WgPxOp)op, a, e->nargs, out);
}

/* Lower one node whose operands are lowered. */
static int lower_node(Compiler *k, const WgExprNode *e, Typed *out)
{
    Typed a[3];
    int rc;
    for (int i = 0; i < e->nargs && i < 3 && e->op != WG_EX_CALL; i++) a[i] = *operand(k, e, i);
    switch (e->op) {
    case WG_EX_NUM:
        out->n = 1;
        out->col = 0;
        return (out->c[0] = emit_const(k, e->value)) < 0 ? nomem(k) : WG_OK;
    case WG_EX_VAR:
        return lower_var(k, e, out);
    case WG_EX_CALL:
        return lower_call(k, e, out);
    case WG_EX_COND: {
        if ((rc = need_number(k, &a[0], "the condition of '?:'"))) return rc;
        if (a[1].n != a[2].n) {
            const Typed *col = a[1].n == 4 ? &a[1] : &a[2];
            char tok[80];
            token_at(k, col->col, tok, sizeof tok);
            return error_at(k, WG_ERR_TYPE, col->col,
                            "'%s' is a colour but the other branch of '?:' is a number; both "
                            "branches must be numbers or both colours (wrap the number in "
                            "rgb(n, n, n))",
                            tok);
        }
        const WgPxVal *c = &k->p->vals[a[0].c[0]];
        if (c->op == WG_PX_CONST) {
            *out = c->value != 0 ? a[1] : a[2];
            return WG_OK;
        }
        return emit_map(k, WG_PX_SELECT, a, 3, out);
    }
    case WG_EX_NEG:
        return emit_map(k, WG_PX_NEG, a, 1, out);
    case WG_EX_NOT:
        if ((rc = need_number(k, &a[0], "'!'"))) return rc;
        return emit_map(k, WG_PX_NOT, a, 1, out);
    default: {
        int op = binary_op(e->op);
        if (op < 0) return error_at(k, WG_ERR_TYPE, e->column, "internal: bad operator");
        if (op >= WG_PX_LT && op <= WG_PX_OR) {
            char where[64];
            snprintf(where, sizeof where, "'%s'", op_text(e->op));
            for (int i = 0; i < 2; i++)
                if ((rc = need_number(k, &a[i], where))) return rc;
        }
        return emit_map(k, (WgPxOp)op, a, 2, out);
    }
    }
}

/* Lower the whole tree, operands before the operations that read them, into *out. The first
 * argument of sample() only names an input: its subtree is not lowered. */
static int lower(Compiler *k, const WgExpr *x, Typed *out)
{
    int n = x->count_;
    const WgExprNode *nodes = x->nodes_;
    bool *skip = wg_calloc((size_t)n + 1, sizeof(bool));
    k->nodes = nodes;
    k->typed = wg_calloc((size_t)n + 1, sizeof(Typed));
    k->first = wg_calloc((size_t)n + 1, sizeof(int));
    int rc = skip && k->typed && k->first ? WG_OK : nomem(k);
    for (int i = 0; i < n && !rc; i++) {
        k->first[i] = nodes[i].column;
        for (int j = 0; j < nodes[i].nargs; j++) {
            int c = k->first[nodes[i].args[j] - nodes];
            if (c < k->first[i]) k->first[i] = c;
        }
    }
    for (int i = n - 1; i >= 0 && !rc; i--) { /* parents first */
        const WgExprNode *e = &nodes[i];
        if (skip[i])
            for (int j = 0; j < e->nargs; j++) skip[e->args[j] - nodes] = true;
        else if (e->op == WG_EX_CALL && e->func == WG_FN_SAMPLE)
            skip[e->args[0] - nodes] = true;
    }
    for (int i = 0; i < n && !rc; i++)
        if (!skip[i]) rc = lower_node(k, &nodes[i], &k->typed[i]);
    if (!rc) *out = k->typed[n - 1];
    wg_free(skip);
    wg_free(k->typed);
    wg_free(k->first);
    k->typed = NULL;
    k->first = NULL;
    return rc;
}

/* ---- after lowering: liveness, classes, registers ---------------------------------------- */

static int *int_array(int n)
{
    return wg_calloc((size_t)n + 1, sizeof(int));
}

static int finish(Compiler *k)
{
    WgPxProgram *p = k->p;
    int n = p->n_vals;
    bool *live = wg_calloc((size_t)n + 1, sizeof(bool));
    int *last = int_array(n), *free_regs = int_array(n);
    p->uniform = int_array(n);
    p->varying = int_array(n);
    p->consts = int_array(n);
    if (!live || !last || !free_regs || !p->uniform || !p->varying || !p->consts) {
        wg_free(live);
        wg_free(last);
        wg_free(free_regs);
        return nomem(k);
    }
    for (int j = 0; j < p->out_channels; j++) live[p->out[j]] = true;
    for (int i = n - 1; i >= 0; i--)
        if (live[i])
            for (int j = 0; j < p->vals[i].nargs; j++) live[p->vals[i].args[j]] = true;
    for (int i = 0; i < n; i++) {
        if (!live[i]) continue;
        WgPxVal *v = &p->vals[i];
        if (v->cls == WG_PX_CLASS_CONST)
            p->consts[p->n_consts++] = i;
        else if (v->cls == WG_PX_CLASS_UNIFORM)
            p->uniform[p->n_uniform++] = i;
        else
            p->varying[p->n_varying++] = i;
    }
    /* constants and uniform values read by varying code: one float for the kernels with
     * scalar variants, a broadcast row for sample(), noise() and the output */
    for (int s = 0; s < p->n_varying; s++) {
        WgPxVal *v = &p->vals[p->varying[s]];
        bool rows = v->op == WG_PX_SAMPLE || v->op == WG_PX_NOISE;
        for (int j = 0; j < v->nargs; j++) {
            WgPxVal *a = &p->vals[v->args[j]];
            if (a->cls == WG_PX_CLASS_VARYING) continue;
            if (!rows)
                v->scalars |= 1 << j;
            else if (a->bcast < 0)
                a->bcast = p->n_bcast++;
        }
    }
    for (int j = 0; j < p->out_channels; j++) {
        WgPxVal *a = &p->vals[p->out[j]];
        if (a->cls != WG_PX_CLASS_VARYING && a->bcast < 0) a->bcast = p->n_bcast++;
    }
    /* linear scan over the varying list: last[i] = position of the last reader */
    for (int i = 0; i < n; i++) last[i] = -1;
    for (int s = 0; s < p->n_varying; s++) {
        const WgPxVal *v = &p->vals[p->varying[s]];
        for (int j = 0; j < v->nargs; j++) last[v->args[j]] = s;
    }
    for (int j = 0; j < p->out_channels; j++) last[p->out[j]] = p->n_varying;
    int n_free = 0;
    for (int s = 0; s < p->n_varying; s++) {
        WgPxVal *v = &p->vals[p->varying[s]];
        bool in_place = v->op == WG_PX_INPUT && k->in_ch[v->input] == 1;
        if (!in_place) v->reg = n_free ? free_regs[--n_free] : p->n_regs++;
        for (int j = 0; j < v->nargs; j++) {
            int a = v->args[j];
            bool dup = false;
            for (int q = 0; q < j; q++) dup |= v->args[q] == a;
            if (!dup && last[a] == s && p->vals[a].cls == WG_PX_CLASS_VARYING &&
                p->vals[a].reg >= 0)
                free_regs[n_free++] = p->vals[a].reg;
        }
    }
    wg_free(live);
    wg_free(last);
    wg_free(free_regs);
    return WG_OK;
}

void wg__px_free(WgPxProgram *p)
{
    if (!p) return;
    wg_free(p->vals);
    wg_free(p->uniform);
    wg_free(p->varying);
    wg_free(p->consts);
    wg_free(p);
}

/* The statements of `expr`, split at the semicolons outside parentheses: [start, end) of each. */
static int split_statements(const char *src, int *start, int *end, int max)
{
    int n = 0, depth = 0, from = 0;
    for (int i = 0;; i++) {
        char c = src[i];
        depth += c == '(' ? 1 : c == ')' ? -1 : 0;
        if (c == '\0' || (c == ';' && depth <= 0)) {
            if (n == max) return -1;
            start[n] = from;
            end[n++] = i;
            if (!c) return n;
            from = i + 1;
        }
    }
}

/* "name =" (and not "==") at the start of src[from, to): the name's extent and where the
 * expression after '=' starts. */
static bool definition(const char *src, int from, int to, int *name, int *len, int *rhs)
{
    int i = from;
    while (i < to && (src[i] == ' ' || src[i] == '\t' || src[i] == '\n' || src[i] == '\r')) i++;
    int n0 = i;
    if (i >= to || !(src[i] == '_' || ((src[i] | 32) >= 'a' && (src[i] | 32) <= 'z'))) return false;
    while (i < to && (src[i] == '_' || (src[i] >= '0' && src[i] <= '9') ||
                      ((src[i] | 32) >= 'a' && (src[i] | 32) <= 'z')))
        i++;
    int n1 = i;
    while (i < to && (src[i] == ' ' || src[i] == '\t' || src[i] == '\n' || src[i] == '\r')) i++;
    if (i >= to || src[i] != '=' || (i + 1 < to && src[i + 1] == '=')) return false;
    *name = n0;
    *len = n1 - n0;
    *rhs = i + 1;
    return true;
}

static bool blank(const char *src, int from, int to)
{
    for (int i = from; i < to; i++)
        if (!(src[i] == ' ' || src[i] == '\t' || src[i] == '\n' || src[i] == '\r')) return false;
    return true;
}

/* Parse and lower src[from, to) (columns offset by `from`) into *t. */
static int lower_text(Compiler *k, Names *names, const char *src, int from, int to, Typed *t)
{
    char *text = wg_strndup(src + from, (size_t)(to - from));
    if (!text) return nomem(k);
    WgExprOptions opt = {resolve, names, true};
    WgExpr *e = NULL;
    WgError pe = {0};
    int rc = wg_expr_parse(text, &opt, &e, &pe);
    if (rc) {
        int column = from + pe.column;
        if (names->hint[0] && strstr(pe.message, "unknown name"))
            wg_error_set(k->err, rc, NULL, "expr column %d: %s; %s", column, pe.message,
                         names->hint);
        else
            wg_error_set(k->err, rc, NULL, "expr column %d: %s", column, pe.message);
        if (k->err) k->err->column = column;
    } else {
        k->src = src + from; /* stays valid after text is freed, for messages about this value */
        k->col0 = from;
        rc = lower(k, e, t);
    }
    wg_expr_free(e);
    wg_free(text);
    return rc;
}

/* A name a statement may define: not one that already means something here. */
static const char *taken(const WgNodeContext *ctx, const Names *names, const char *name, int len)
{
    for (int i = 0; i < names->n_locals; i++)
        if (names->locals[i].len == (size_t)len && !strncmp(names->locals[i].name, name, len))
            return "is already defined by an earlier statement";
    int slot;
    Names probe = {ctx, names->in_ch, "", {{0}}, 0};
    if (resolve(&probe, name, (size_t)len, &slot))
        return "already names an input, an extra attribute, a graph parameter or a coordinate";
    return NULL;
}

/* Programs compiled since the process started: a fused group compiles each member once, not
 * once per band; the tests count on it. */
static atomic_long compiled;

long wg__px_compiled(void)
{
    return atomic_load(&compiled);
}

int wg__px_compile(const WgNodeContext *ctx, const char *src, int out_channels,
                   const int *input_channels, WgPxProgram **out, WgError *err)
{
    *out = NULL;
    atomic_fetch_add(&compiled, 1);
    src = src ? src : "";
    WgPxProgram *p = wg_calloc(1, sizeof *p);
    Names *names = wg_calloc(1, sizeof *names);
    int *start = wg_malloc(sizeof(int) * 2 * (MAX_LOCALS + 1)), *end = start + MAX_LOCALS + 1;
    if (!p || !names || !start) {
        wg_free(p);
        wg_free(names);
        wg_free(start);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    p->width = ctx->width;
    p->height = ctx->height;
    p->seed = wg__px_seed(ctx->seed);
    p->out_channels = out_channels;
    const int *in_ch = input_channels ? input_channels : ctx->input_channels;
    names->ctx = ctx;
    names->in_ch = in_ch;
    Compiler k = {p, ctx, in_ch, src, err};
    k.names = names;
    Typed t = {0};
    int rc = WG_OK, n = split_statements(src, start, end, MAX_LOCALS + 1);
    if (n < 0)
        rc = error_at(&k, WG_ERR_PARSE, 1, "more than %d statements (name = ...;)", MAX_LOCALS);
    /* name = expression; ... then the result */
    for (int s = 0; !rc && s < n; s++) {
        int name, len, rhs;
        bool def = definition(src, start[s], end[s], &name, &len, &rhs);
        if (s == n - 1) {
            if (def || blank(src, start[s], end[s])) {
                k.src = src;
                k.col0 = 0;
                rc = error_at(&k, WG_ERR_PARSE, start[s] + 1,
                              "the expression must end with its result, after the last "
                              "'name = ...;' statement");
                break;
            }
            rc = lower_text(&k, names, src, start[s], end[s], &t);
            break;
        }
        if (!def) {
            k.src = src;
            k.col0 = 0;
            rc = error_at(&k, WG_ERR_PARSE, start[s] + 1,
                          "a statement before the result must define a name: 'name = "
                          "expression;'");
            break;
        }
        const char *why = taken(ctx, names, src + name, len);
        if (why) {
            k.src = src;
            k.col0 = 0;
            rc = error_at(&k, WG_ERR_PARSE, name + 1, "'%.*s' %s", len, src + name, why);
            break;
        }
        Typed value;
        rc = lower_text(&k, names, src, rhs, end[s], &value);
        if (!rc) names->locals[names->n_locals++] = (Local){src + name, (size_t)len, value};
    }
    if (!rc && t.n == 4 && out_channels == 1) {
        char tok[80];
        token_at(&k, t.col, tok, sizeof tok);
        rc = error_at(&k, WG_ERR_TYPE, t.col,
                      "the expression gives a colour (from '%s') but kind is \"gray\"; take "
                      "one channel (c.r ...) or set kind=\"color\"",
                      tok);
    }
    if (!rc) {
        if (out_channels == 1) {
            p->out[0] = t.c[0];
        } else if (t.n == 4) {
            memcpy(p->out, t.c, sizeof t.c);
        } else { /* a number for kind="color": gray, opaque */
            p->out[0] = p->out[1] = p->out[2] = t.c[0];
            if ((p->out[3] = emit_const(&k, 1.0)) < 0) rc = nomem(&k);
        }
    }
    if (!rc) rc = finish(&k);
    wg_free(k.index);
    wg_free(names);
    wg_free(start);
    if (rc) {
        wg__px_free(p);
        return rc;
    }
    *out = p;
    return WG_OK;
}
