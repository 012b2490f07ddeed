/* SPDX-License-Identifier: MIT */
/* Private to the `pixel` node (nodes/pixel.c runs it, nodes/pixel_compile.c builds it): the
 * compiled form of a per-pixel expression. A program is a list of values in SSA form, each
 * produced by one operation on earlier values. Values are of three classes: constants (folded
 * at compile time in double and rounded once to float), row-uniform values (depend on y, v and
 * constants only: computed once per row as one float) and varying values (computed per span of
 * up to WG_PX_LANES pixels of a row into a scratch register, one straight loop per operation).
 * Colour expressions are scalarised: a colour is four scalar values, one per channel. */
#ifndef WG_PIXEL_PROGRAM_H
#define WG_PIXEL_PROGRAM_H

#include "wetgraph/node.h"

#include <stdbool.h>
#include <stdint.h>

/* Pixels per span: 256 floats = 1 KiB per register, so a program's registers stay in L1. */
#define WG_PX_LANES 256

/* clang-format off */
typedef enum {
    WG_PX_CONST, /* value */
    WG_PX_X, WG_PX_U, /* varying coordinates */
    WG_PX_Y, WG_PX_V, /* row-uniform coordinates */
    WG_PX_INPUT,      /* input `input`, channel `channel` (0 for gray) */
    /* one operand */
    WG_PX_NEG, WG_PX_NOT, WG_PX_ABS, WG_PX_FLOOR, WG_PX_CEIL, WG_PX_FRACT, WG_PX_SQRT,
    WG_PX_EXP, WG_PX_LOG, WG_PX_SIN, WG_PX_COS, WG_PX_TAN, WG_PX_ROUND, WG_PX_SIGN,
    WG_PX_ASIN, WG_PX_ACOS, WG_PX_ATAN,
    /* two operands */
    WG_PX_ADD, WG_PX_SUB, WG_PX_MUL, WG_PX_DIV, WG_PX_MOD, WG_PX_POW,
    WG_PX_LT, WG_PX_LE, WG_PX_GT, WG_PX_GE, WG_PX_EQ, WG_PX_NE, WG_PX_AND, WG_PX_OR,
    WG_PX_MIN, WG_PX_MAX, WG_PX_STEP, WG_PX_ATAN2,
    /* three operands */
    WG_PX_CLAMP, WG_PX_LERP, WG_PX_SMOOTHSTEP, WG_PX_SELECT, /* select: a != 0 ? b : c */
    WG_PX_SAMPLE, /* input `input`, channel `channel` at (a, b) */
    WG_PX_NOISE,  /* noise(a, b, c) */
    WG_PX_COUNT_
} WgPxOp;
/* clang-format on */

enum { WG_PX_CLASS_CONST, WG_PX_CLASS_UNIFORM, WG_PX_CLASS_VARYING };

typedef struct WgPxVal {
    WgPxOp op;
    int cls; /* WG_PX_CLASS_* */
    int nargs;
    int args[3]; /* earlier values */
    int input, channel;
    double value; /* WG_PX_CONST */
    /* storage, decided after dead-code elimination: */
    int reg;     /* varying: scratch register; -1 for a gray input read in place */
    int scalars; /* varying: bit i set when operand i is one float (constant or uniform) */
    int bcast;   /* constant or uniform read as a row (by sample(), noise() or the output):
                    broadcast row, or -1 */
} WgPxVal;

typedef struct WgPxProgram {
    WgPxVal *vals;
    int n_vals, cap_vals;
    int *uniform; /* live row-uniform values, in order */
    int n_uniform;
    int *varying; /* live varying values, in order */
    int n_varying;
    int *consts; /* live constants */
    int n_consts;
    int out[4]; /* the result: out_channels values */
    int out_channels;
    int n_regs, n_bcast;
    int width, height;
    uint32_t seed; /* folded from the node's seed, for noise() */
} WgPxProgram;

/* Compile `src` for a node with the given context (inputs by name with their channel counts,
 * extras, scope, size, seed) into a program producing `out_channels` (1 or 4) channels.
 * `input_channels` overrides ctx->input_channels when not NULL. Errors carry the 1-based column
 * in `src`. The caller owns *out (wg__px_free). */
int wg__px_compile(const WgNodeContext *ctx, const char *src, int out_channels,
                   const int *input_channels, WgPxProgram **out, WgError *err);
void wg__px_free(WgPxProgram *p);
/* How many programs wg__px_compile has compiled in this process (checks included). */
long wg__px_compiled(void);

/* Shared by the compiler (folding constant calls) and the kernels. */
uint32_t wg__px_seed(uint64_t seed);
float wg__px_noise(uint32_t seed, float u, float v, float scale);
const char *wg__px_op_name(WgPxOp op);

#endif
