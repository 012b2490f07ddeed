/* SPDX-License-Identifier: MIT */
/* Expressions: the small language of `=...` attribute values and of the `pixel` node.
 *
 * Grammar (lowest precedence first):
 *   expr    := cond
 *   cond    := or ('?' expr ':' expr)?
 *   or      := and ('||' and)*          and := cmp ('&&' cmp)*
 *   cmp     := add (('<'|'<='|'>'|'>='|'=='|'!=') add)*
 *   add     := mul (('+'|'-') mul)*     mul := unary (('*'|'/'|'%') unary)*
 *   unary   := ('-'|'+'|'!') unary | pow
 *   pow     := atom ('^' unary)?        (right-associative)
 *   atom    := number | name | name '(' args ')' | '(' expr ')'
 * Names are letters, digits, '_' and '.', optionally prefixed by '$' ($time, $seed, ...).
 * Arithmetic is IEEE double; comparisons and logic give 0 or 1; `%` and mod() are floored
 * (the result has the sign of the divisor). Division by zero follows IEEE (±inf or NaN);
 * the callers decide what to do with non-finite results (parameters reject them).
 *
 * The parser resolves every name through a callback, so each caller decides what is in scope,
 * and reports errors with a 1-based column inside the source text. An expression is at most
 * WG_EXPR_MAX_LENGTH characters long, and nests at most WG_EXPR_MAX_DEPTH levels deep: each
 * parenthesis, function argument list, unary operator, '^' exponent and '?:' branch inside
 * another is one level, while a chain of binary operators at one level (1 + 1 + ... + 1, of any
 * length) is not nesting. The nodes array holds the tree in postorder (every node after its
 * operands, the root last), so evaluators can walk it with a loop instead of recursing. */
#ifndef WETGRAPH_EXPR_H
#define WETGRAPH_EXPR_H

#include "error.h"
#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Parse a finite decimal number as graph files write them: an optional sign, digits with an
 * optional fraction, an optional exponent (-2, 0.5, .5, 1e-3). No spaces, hex, inf or nan;
 * false when malformed or beyond the range of a double. Nodes use it for numbers inside their
 * string parameters, so those follow the file's rules too. */
bool wg_parse_number(const char *text, double *out);
/* Parse a whole number >= 0 in decimal digits only, up to 2^64-1 (seeds); false when
 * malformed or larger. */
bool wg_parse_whole(const char *text, uint64_t *out);

#define WG_EXPR_MAX_LENGTH 1000000 /* characters */
#define WG_EXPR_MAX_DEPTH 200      /* nesting levels */

typedef enum {
    WG_EX_NUM, /* value */
    WG_EX_VAR, /* slot (resolved by the caller's callback) */
    WG_EX_NEG, /* -a */
    WG_EX_NOT, /* !a */
    WG_EX_ADD,
    WG_EX_SUB,
    WG_EX_MUL,
    WG_EX_DIV,
    WG_EX_MOD,
    WG_EX_POW,
    WG_EX_LT,
    WG_EX_LE,
    WG_EX_GT,
    WG_EX_GE,
    WG_EX_EQ,
    WG_EX_NE,
    WG_EX_AND,
    WG_EX_OR,
    WG_EX_COND, /* a ? b : c */
    WG_EX_CALL, /* func(args) */
} WgExprOp;

typedef enum {
    WG_FN_ABS,
    WG_FN_MIN,
    WG_FN_MAX,
    WG_FN_CLAMP,
    WG_FN_LERP,
    WG_FN_SMOOTHSTEP,
    WG_FN_STEP,
    WG_FN_FLOOR,
    WG_FN_CEIL,
    WG_FN_FRACT,
    WG_FN_MOD,
    WG_FN_SQRT,
    WG_FN_POW,
    WG_FN_EXP,
    WG_FN_LOG,
    WG_FN_SIN,
    WG_FN_COS,
    WG_FN_TAN,
    WG_FN_ATAN2,
    WG_FN_ROUND,
    WG_FN_SIGN,
    WG_FN_ASIN,
    WG_FN_ACOS,
    WG_FN_ATAN,
    /* only where the caller enables them (the pixel node): */
    WG_FN_SAMPLE,
    WG_FN_NOISE,
    WG_FN_RGB,
    WG_FN_RGBA,
    WG_FN_COUNT_
} WgExprFunc;

typedef struct WgExprNode WgExprNode;
struct WgExprNode {
    WgExprOp op;
    int column;      /* 1-based position in the source, for error messages */
    double value;    /* WG_EX_NUM */
    int slot;        /* WG_EX_VAR: what the resolver returned */
    WgExprFunc func; /* WG_EX_CALL */
    int nargs;
    WgExprNode *args[4]; /* operands (unary 1, binary 2, cond 3) or call arguments */
};

typedef struct WgExpr {
    WgExprNode *root;
    char *source;
    /* private (the tree in postorder, root last; see above): */
    WgExprNode *nodes_;
    int count_, cap_;
} WgExpr;

/* Name resolver: return true and set *slot when `name` (length len, including a leading '$' if
 * written) is known. */
typedef bool (*WgExprResolve)(void *user, const char *name, size_t len, int *slot);

typedef struct WgExprOptions {
    WgExprResolve resolve;
    void *user;
    bool pixel_functions; /* allow sample(), noise(), rgb(), rgba() */
} WgExprOptions;

/* Parse `src`. On error returns a status and sets err->column (1-based in src) and a message
 * such as "unknown name 'wter_level'". The caller owns *out (wg_expr_free). */
int wg_expr_parse(const char *src, const WgExprOptions *opt, WgExpr **out, WgError *err);
void wg_expr_free(WgExpr *e);

/* Evaluate with slot values. Only for expressions without pixel functions. */
double wg_expr_eval(const WgExpr *e, const double *slots);

/* Name of a function, and its arity range. */
const char *wg_expr_func_name(WgExprFunc f);

/* Scalar helpers shared by the evaluators so all give the same answers. */
double wg_expr_apply(WgExprOp op, double a, double b);
double wg_expr_call(WgExprFunc f, const double *args, int nargs);

#ifdef __cplusplus
}
#endif
#endif
