/* SPDX-License-Identifier: MIT */
/* Expression parser and scalar evaluator (grammar in wetgraph/expr.h). A hand-written
 * recursive-descent parser builds a small AST in one node array; names are resolved at parse
 * time through the caller's callback so unknown names are reported with their column. Every
 * node is appended after its operands, so the array is the tree in postorder: evaluators walk
 * it as a loop (no recursion over the tree, so a flat sum of any length is no deeper than one
 * of two terms), and the scalar evaluator runs it on a value stack whose size is bounded by
 * the nesting (see expr_stack below). Only the parser recurses, once per nesting level. */
#include "internal.h"

#include <assert.h>
#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const struct {
    const char *name;
    int min_args, max_args;
    bool pixel_only;
} funcs[WG_FN_COUNT_] = {
    [WG_FN_ABS] = {"abs", 1, 1},
    [WG_FN_MIN] = {"min", 2, 4},
    [WG_FN_MAX] = {"max", 2, 4},
    [WG_FN_CLAMP] = {"clamp", 3, 3},
    [WG_FN_LERP] = {"lerp", 3, 3},
    [WG_FN_SMOOTHSTEP] = {"smoothstep", 3, 3},
    [WG_FN_STEP] = {"step", 2, 2},
    [WG_FN_FLOOR] = {"floor", 1, 1},
    [WG_FN_CEIL] = {"ceil", 1, 1},
    [WG_FN_FRACT] = {"fract", 1, 1},
    [WG_FN_MOD] = {"mod", 2, 2},
    [WG_FN_SQRT] = {"sqrt", 1, 1},
    [WG_FN_POW] = {"pow", 2, 2},
    [WG_FN_EXP] = {"exp", 1, 1},
    [WG_FN_LOG] = {"log", 1, 1},
    [WG_FN_SIN] = {"sin", 1, 1},
    [WG_FN_COS] = {"cos", 1, 1},
    [WG_FN_TAN] = {"tan", 1, 1},
    [WG_FN_ATAN2] = {"atan2", 2, 2},
    [WG_FN_ROUND] = {"round", 1, 1},
    [WG_FN_SIGN] = {"sign", 1, 1},
    [WG_FN_ASIN] = {"asin", 1, 1},
    [WG_FN_ACOS] = {"acos", 1, 1},
    [WG_FN_ATAN] = {"atan", 1, 1},
    [WG_FN_SAMPLE] = {"sample", 3, 3, true},
    [WG_FN_NOISE] = {"noise", 3, 3, true},
    [WG_FN_RGB] = {"rgb", 3, 3, true},
    [WG_FN_RGBA] = {"rgba", 4, 4, true},
};

const char *wg_expr_func_name(WgExprFunc f)
{
    return (unsigned)f < WG_FN_COUNT_ ? funcs[f].name : "?";
}

static bool find_func(const char *name, size_t len, WgExprFunc *out)
{
    if (len == 3 && !strncmp(name, "mix", 3)) {
        *out = WG_FN_LERP; /* GLSL spelling */
        return true;
    }
    for (int i = 0; i < WG_FN_COUNT_; i++) {
        if (strlen(funcs[i].name) == len && !strncmp(funcs[i].name, name, len)) {
            *out = (WgExprFunc)i;
            return true;
        }
    }
    return false;
}

typedef struct {
    const char *src;
    const char *p;
    WgExpr *e;
    const WgExprOptions *opt;
    WgError *err;
    int status;
    int depth;
    int *stack; /* per node: values on the evaluation stack while its subtree is evaluated */
} Parser;

/* Nesting (parentheses, function arguments, unary operators, '^', '?:') is what the parser
 * recurses on; chains of binary operators at one level are loops. */
#define MAX_DEPTH WG_EXPR_MAX_DEPTH
/* Within one level, a right operand waits on at most 5 values (one per binary precedence
 * level: || && comparison + *); entering the next level adds at most 3 more (the 4th argument
 * of a call), so the value stack never holds more than this. Checked at parse time all the
 * same. */
#define MAX_STACK (8 * (MAX_DEPTH + 1) + 1)

static int col(Parser *ps, const char *at)
{
    return (int)(at - ps->src) + 1;
}

static WgExprNode *fail(Parser *ps, const char *at, int code, const char *fmt, const char *arg)
{
    if (ps->status == WG_OK) {
        wg_error_set(ps->err, code, NULL, fmt, arg);
        if (ps->err) ps->err->column = col(ps, at);
        ps->status = code;
    }
    return NULL;
}

static WgExprNode *new_node(Parser *ps, WgExprOp op, const char *at)
{
    WgExpr *e = ps->e;
    /* cannot happen (cap_ counts the characters); the parser holds pointers into the array,
     * so it never grows */
    if (e->count_ == e->cap_) return fail(ps, at, WG_ERR_PARSE, "%s", "expression too long");
    ps->stack[e->count_] = 1;
    WgExprNode *n = &e->nodes_[e->count_++];
    memset(n, 0, sizeof *n);
    n->op = op;
    n->column = col(ps, at);
    return n;
}

static WgExprNode *too_deep(Parser *ps, const char *at)
{
    char msg[160];
    snprintf(msg, sizeof msg,
             "expression nested more than %d levels deep (parentheses, function calls, "
             "unary operators, '^' or '?:' inside one another)",
             MAX_DEPTH);
    return fail(ps, at, WG_ERR_PARSE, "%s", msg);
}

/* Append an operation on operands already in the array (they come before it: postorder),
 * recording how deep the value stack gets while evaluating it: operand i waits with i values
 * below it. */
static WgExprNode *new_op(Parser *ps, WgExprOp op, const char *at, WgExprNode *const *args,
                          int nargs)
{
    for (int i = 0; i < nargs; i++)
        if (!args[i]) return NULL;
    WgExprNode *n = new_node(ps, op, at);
    if (!n) return NULL;
    int need = nargs;
    for (int i = 0; i < nargs; i++) {
        n->args[i] = args[i];
        int k = i + ps->stack[args[i] - ps->e->nodes_];
        if (k > need) need = k;
    }
    n->nargs = nargs;
    ps->stack[n - ps->e->nodes_] = need;
    if (need > MAX_STACK) return too_deep(ps, at);
    return n;
}

static void skip_space(Parser *ps)
{
    while (isspace((unsigned char)*ps->p)) ps->p++;
}

static bool accept(Parser *ps, const char *tok)
{
    skip_space(ps);
    size_t n = strlen(tok);
    if (strncmp(ps->p, tok, n)) return false;
    /* do not take '<' out of '<=' etc. */
    if (n == 1 && (tok[0] == '<' || tok[0] == '>' || tok[0] == '=' || tok[0] == '!') &&
        ps->p[1] == '=')
        return false;
    ps->p += n;
    return true;
}

static WgExprNode *parse_expr(Parser *ps);
static WgExprNode *parse_unary(Parser *ps);

static WgExprNode *binary(Parser *ps, WgExprOp op, const char *at, WgExprNode *a, WgExprNode *b)
{
    WgExprNode *args[2] = {a, b};
    return new_op(ps, op, at, args, 2);
}

static bool is_name_start(char c)
{
    return isalpha((unsigned char)c) || c == '_' || c == '$';
}

static bool is_name_char(char c)
{
    return isalnum((unsigned char)c) || c == '_' || c == '.';
}

static WgExprNode *parse_atom(Parser *ps)
{
    skip_space(ps);
    const char *at = ps->p;
    if (*ps->p == '(') {
        ps->p++;
        WgExprNode *n = parse_expr(ps);
        if (!n) return NULL;
        if (!accept(ps, ")")) return fail(ps, ps->p, WG_ERR_PARSE, "%s", "expected ')'");
        return n;
    }
    if (isdigit((unsigned char)*ps->p) || (*ps->p == '.' && isdigit((unsigned char)ps->p[1]))) {
        const char *end = ps->p + wg__number_length(ps->p);
        if (isalpha((unsigned char)*end) || *end == '_' || *end == '.')
            return fail(ps, end, WG_ERR_PARSE, "%s",
                        *end == '.' ? "unexpected '.' after a number"
                                    : "unexpected letter after a number");
        double v = strtod(ps->p, NULL);
        if (!isfinite(v)) return fail(ps, at, WG_ERR_PARSE, "%s", "number too large");
        ps->p = end;
        WgExprNode *n = new_node(ps, WG_EX_NUM, at);
        if (n) n->value = v;
        return n;
    }
    if (is_name_start(*ps->p)) {
        const char *s = ps->p++;
        while (is_name_char(*ps->p)) ps->p++;
        size_t len = (size_t)(ps->p - s);
        char name[128];
        snprintf(name, sizeof name, "%.*s", (int)(len < 100 ? len : 100), s);
        skip_space(ps);
        if (*ps->p == '(') {
            WgExprFunc f;
            if (!find_func(s, len, &f) || (funcs[f].pixel_only && !ps->opt->pixel_functions)) {
                if (find_func(s, len, &f))
                    return fail(ps, at, WG_ERR_PARSE,
                                "function '%s' is only available in the pixel node", name);
                /* the closest function this expression may call */
                const char *names[WG_FN_COUNT_ + 1];
                int count = 0;
                for (int i = 0; i < WG_FN_COUNT_; i++)
                    if (!funcs[i].pixel_only || ps->opt->pixel_functions)
                        names[count++] = funcs[i].name;
                names[count++] = "mix";
                const char *near = wg_suggest(name, names, count);
                if (near) {
                    char text[200];
                    snprintf(text, sizeof text, "unknown function '%s'; did you mean '%s'?", name,
                             near);
                    return fail(ps, at, WG_ERR_PARSE, "%s", text);
                }
                return fail(ps, at, WG_ERR_PARSE, "unknown function '%s'", name);
            }
            ps->p++;
            WgExprNode *args[4];
            int nargs = 0;
            skip_space(ps);
            if (*ps->p != ')') {
                for (;;) {
                    if (nargs == 4)
                        return fail(ps, ps->p, WG_ERR_PARSE, "too many arguments to '%s'", name);
                    if (!(args[nargs++] = parse_expr(ps))) return NULL;
                    if (accept(ps, ",")) continue;
                    if (accept(ps, ")")) break;
                    return fail(ps, ps->p, WG_ERR_PARSE, "%s", "expected ',' or ')'");
                }
            } else {
                ps->p++;
            }
            if (nargs < funcs[f].min_args || nargs > funcs[f].max_args) {
                char msg[160];
                if (funcs[f].min_args == funcs[f].max_args)
                    snprintf(msg, sizeof msg, "'%s' takes %d argument%s, got %d", funcs[f].name,
                             funcs[f].min_args, funcs[f].min_args == 1 ? "" : "s", nargs);
                else
                    snprintf(msg, sizeof msg, "'%s' takes %d to %d arguments, got %d",
                             funcs[f].name, funcs[f].min_args, funcs[f].max_args, nargs);
                return fail(ps, at, WG_ERR_PARSE, "%s", msg);
            }
            WgExprNode *n = new_op(ps, WG_EX_CALL, at, args, nargs);
            if (n) n->func = f;
            return n;
        }
        int slot = -1;
        if (!ps->opt->resolve || !ps->opt->resolve(ps->opt->user, s, len, &slot)) {
            WgExprFunc f;
            if (find_func(s, len, &f))
                return fail(ps, at, WG_ERR_PARSE, "'%s' is a function: write it with (...)", name);
            return fail(ps, at, WG_ERR_PARSE, "unknown name '%s'", name);
        }
        WgExprNode *n = new_node(ps, WG_EX_VAR, at);
        if (n) n->slot = slot;
        return n;
    }
    if (!*ps->p) return fail(ps, at, WG_ERR_PARSE, "%s", "unexpected end of expression");
    char c[2] = {*ps->p, 0};
    return fail(ps, at, WG_ERR_PARSE, "unexpected '%s'", c);
}

/* The operand of a unary operator or the exponent of '^': one level deeper. */
static WgExprNode *parse_nested_unary(Parser *ps, const char *at)
{
    if (++ps->depth > MAX_DEPTH + 1) return too_deep(ps, at);
    WgExprNode *r = parse_unary(ps);
    ps->depth--;
    return r;
}

static WgExprNode *parse_pow(Parser *ps)
{
    WgExprNode *a = parse_atom(ps);
    if (!a) return NULL;
    skip_space(ps);
    const char *at = ps->p;
    if (accept(ps, "^")) return binary(ps, WG_EX_POW, at, a, parse_nested_unary(ps, at));
    return a;
}

static WgExprNode *parse_unary(Parser *ps)
{
    skip_space(ps);
    const char *at = ps->p;
    if (accept(ps, "-") || accept(ps, "!")) {
        WgExprOp op = *at == '-' ? WG_EX_NEG : WG_EX_NOT;
        WgExprNode *a = parse_nested_unary(ps, at);
        return new_op(ps, op, at, &a, 1);
    }
    if (accept(ps, "+")) return parse_nested_unary(ps, at);
    return parse_pow(ps);
}

static WgExprNode *parse_mul(Parser *ps)
{
    WgExprNode *a = parse_unary(ps);
    while (a) {
        skip_space(ps);
        const char *at = ps->p;
        if (accept(ps, "*"))
            a = binary(ps, WG_EX_MUL, at, a, parse_unary(ps));
        else if (accept(ps, "/"))
            a = binary(ps, WG_EX_DIV, at, a, parse_unary(ps));
        else if (accept(ps, "%"))
            a = binary(ps, WG_EX_MOD, at, a, parse_unary(ps));
        else
            break;
    }
    return a;
}

static WgExprNode *parse_add(Parser *ps)
{
    WgExprNode *a = parse_mul(ps);
    while (a) {
        skip_space(ps);
        const char *at = ps->p;
        if (accept(ps, "+"))
            a = binary(ps, WG_EX_ADD, at, a, parse_mul(ps));
        else if (accept(ps, "-"))
            a = binary(ps, WG_EX_SUB, at, a, parse_mul(ps));
        else
            break;
    }
    return a;
}

static WgExprNode *parse_cmp(Parser *ps)
{
    static const struct {
        const char *tok;
        WgExprOp op;
    } ops[] = {{"<=", WG_EX_LE}, {">=", WG_EX_GE}, {"==", WG_EX_EQ},
               {"!=", WG_EX_NE}, {"<", WG_EX_LT},  {">", WG_EX_GT}};
    WgExprNode *a = parse_add(ps);
    while (a) {
        skip_space(ps);
        const char *at = ps->p;
        int k = -1;
        for (int i = 0; i < 6 && k < 0; i++)
            if (accept(ps, ops[i].tok)) k = i;
        if (k < 0) break;
        a = binary(ps, ops[k].op, at, a, parse_add(ps));
    }
    return a;
}

static WgExprNode *parse_and(Parser *ps)
{
    WgExprNode *a = parse_cmp(ps);
    while (a) {
        skip_space(ps);
        const char *at = ps->p;
        if (!accept(ps, "&&")) break;
        a = binary(ps, WG_EX_AND, at, a, parse_cmp(ps));
    }
    return a;
}

static WgExprNode *parse_or(Parser *ps)
{
    WgExprNode *a = parse_and(ps);
    while (a) {
        skip_space(ps);
        const char *at = ps->p;
        if (!accept(ps, "||")) break;
        a = binary(ps, WG_EX_OR, at, a, parse_and(ps));
    }
    return a;
}

static WgExprNode *parse_expr(Parser *ps)
{
    /* the whole expression is level 0: each parenthesis, argument list and branch one more */
    if (++ps->depth > MAX_DEPTH + 1) return too_deep(ps, ps->p);
    WgExprNode *c = parse_or(ps);
    skip_space(ps);
    const char *at = ps->p;
    if (c && accept(ps, "?")) {
        WgExprNode *a = parse_expr(ps);
        if (!a) return NULL;
        if (!accept(ps, ":")) return fail(ps, ps->p, WG_ERR_PARSE, "%s", "expected ':' after '?'");
        WgExprNode *b = parse_expr(ps);
        if (!b) return NULL;
        WgExprNode *args[3] = {c, a, b};
        c = new_op(ps, WG_EX_COND, at, args, 3);
    }
    ps->depth--;
    return c;
}

int wg_expr_parse(const char *src, const WgExprOptions *opt, WgExpr **out, WgError *err)
{
    *out = NULL;
    WgExprOptions none = {0};
    if (!opt) opt = &none;
    WgExpr *e = wg_calloc(1, sizeof *e);
    if (!e) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    size_t len = strlen(src);
    if (len > WG_EXPR_MAX_LENGTH) {
        wg_expr_free(e);
        wg_error_set(err, WG_ERR_PARSE, NULL, "expression too long: %zu characters, at most %d",
                     len, WG_EXPR_MAX_LENGTH);
        if (err) err->column = 1;
        return WG_ERR_PARSE;
    }
    e->cap_ = (int)len + 8; /* every AST node consumes at least one character */
    e->nodes_ = wg_calloc((size_t)e->cap_, sizeof(WgExprNode));
    e->source = wg_strdup(src);
    Parser ps = {.src = src, .p = src, .e = e, .opt = opt, .err = err};
    ps.stack = wg_calloc((size_t)e->cap_, sizeof(int));
    if (!e->nodes_ || !e->source || !ps.stack) {
        wg_free(ps.stack);
        wg_expr_free(e);
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    }
    skip_space(&ps);
    if (!*ps.p)
        fail(&ps, ps.p, WG_ERR_PARSE, "%s", "empty expression");
    else
        e->root = parse_expr(&ps);
    skip_space(&ps);
    if (ps.status == WG_OK && *ps.p) {
        char c[2] = {*ps.p, 0};
        fail(&ps, ps.p, WG_ERR_PARSE, "unexpected '%s'", c);
    }
    wg_free(ps.stack);
    if (ps.status != WG_OK) {
        wg_expr_free(e);
        return ps.status;
    }
    assert(e->root == &e->nodes_[e->count_ - 1]); /* postorder: the root comes last */
    *out = e;
    return WG_OK;
}

void wg_expr_free(WgExpr *e)
{
    if (!e) return;
    wg_free(e->nodes_);
    wg_free(e->source);
    wg_free(e);
}

double wg_expr_apply(WgExprOp op, double a, double b)
{
    switch (op) {
    case WG_EX_NEG:
        return -a;
    case WG_EX_NOT:
        return a == 0 ? 1 : 0;
    case WG_EX_ADD:
        return a + b;
    case WG_EX_SUB:
        return a - b;
    case WG_EX_MUL:
        return a * b;
    case WG_EX_DIV:
        return a / b;
    case WG_EX_MOD:
        return a - b * floor(a / b);
    case WG_EX_POW:
        return pow(a, b);
    case WG_EX_LT:
        return a < b;
    case WG_EX_LE:
        return a <= b;
    case WG_EX_GT:
        return a > b;
    case WG_EX_GE:
        return a >= b;
    case WG_EX_EQ:
        return a == b;
    case WG_EX_NE:
        return a != b;
    case WG_EX_AND:
        return (a != 0) && (b != 0);
    case WG_EX_OR:
        return (a != 0) || (b != 0);
    default:
        return NAN;
    }
}

double wg_expr_call(WgExprFunc f, const double *x, int n)
{
    switch (f) {
    case WG_FN_ABS:
        return fabs(x[0]);
    case WG_FN_MIN: {
        double m = x[0];
        for (int i = 1; i < n; i++) m = x[i] < m ? x[i] : m;
        return m;
    }
    case WG_FN_MAX: {
        double m = x[0];
        for (int i = 1; i < n; i++) m = x[i] > m ? x[i] : m;
        return m;
    }
    case WG_FN_CLAMP:
        return x[0] < x[1] ? x[1] : x[0] > x[2] ? x[2] : x[0];
    case WG_FN_LERP:
        return x[0] + (x[1] - x[0]) * x[2];
    case WG_FN_SMOOTHSTEP: {
        if (x[0] == x[1]) return x[2] < x[0] ? 0 : 1; /* degenerate: a step */
        double t = (x[2] - x[0]) / (x[1] - x[0]);
        t = t < 0 ? 0 : t > 1 ? 1 : t;
        return t * t * (3 - 2 * t);
    }
    case WG_FN_STEP:
        return x[1] < x[0] ? 0 : 1;
    case WG_FN_FLOOR:
        return floor(x[0]);
    case WG_FN_CEIL:
        return ceil(x[0]);
    case WG_FN_FRACT:
        return x[0] - floor(x[0]);
    case WG_FN_MOD:
        return x[0] - x[1] * floor(x[0] / x[1]);
    case WG_FN_SQRT:
        return sqrt(x[0]);
    case WG_FN_POW:
        return pow(x[0], x[1]);
    case WG_FN_EXP:
        return exp(x[0]);
    case WG_FN_LOG:
        return log(x[0]);
    case WG_FN_SIN:
        return sin(x[0]);
    case WG_FN_COS:
        return cos(x[0]);
    case WG_FN_TAN:
        return tan(x[0]);
    case WG_FN_ATAN2:
        return atan2(x[0], x[1]);
    case WG_FN_ROUND:
        return floor(x[0] + 0.5);
    case WG_FN_SIGN:
        return x[0] > 0 ? 1 : x[0] < 0 ? -1 : 0;
    case WG_FN_ASIN:
        return asin(x[0]);
    case WG_FN_ACOS:
        return acos(x[0]);
    case WG_FN_ATAN:
        return atan(x[0]);
    default:
        return NAN;
    }
}

double wg_expr_eval(const WgExpr *e, const double *slots)
{
    /* the nodes in postorder on a value stack; the parser bounded its height */
    double stack[MAX_STACK];
    int top = 0;
    for (int i = 0; i < e->count_; i++) {
        const WgExprNode *n = &e->nodes_[i];
        double *a = &stack[top - n->nargs]; /* the operands, in order */
        double v;
        switch (n->op) {
        case WG_EX_NUM:
            v = n->value;
            break;
        case WG_EX_VAR:
            v = slots[n->slot];
            break;
        case WG_EX_COND:
            v = a[0] != 0 ? a[1] : a[2];
            break;
        case WG_EX_CALL:
            v = wg_expr_call(n->func, a, n->nargs);
            break;
        default:
            v = wg_expr_apply(n->op, a[0], n->nargs > 1 ? a[1] : 0);
            break;
        }
        top -= n->nargs;
        stack[top++] = v;
    }
    return stack[0];
}
