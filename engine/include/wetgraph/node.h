/* SPDX-License-Identifier: MIT */
/* How to write a node
 * ===================
 * A node is a `const WgNodeType` descriptor plus an `eval` function, in nodes/<family>.c, listed
 * in nodes/registry.c. This header is all a node file includes.
 *
 * 1. Declare a plain params struct and a table of WgParamSpec addressing its fields with the
 *    WG_PARAM_* macros. XML attribute names are the field names. The engine parses, type-checks
 *    and range-checks every value (literal or `=expression`) before your code runs, so `eval`
 *    never sees an out-of-range or non-finite parameter.
 * 2. Declare input and output ports (WG_PORT). A WG_GRAY input receiving colour is a graph error;
 *    a WG_COLOR input receiving gray is promoted by the engine. Every input arrives already
 *    resampled to the node's size. Optional inputs that are not connected are NULL.
 * 3. Output images are allocated by the engine before `eval` (size and channel count known);
 *    fill every pixel of ctx->outputs[i]. Never keep or free inputs.
 * 4. Split heavy work over rows with wg_parallel_rows(); the chunking does not depend on the
 *    thread count, so results are bit-identical for any --threads. Randomness must come from
 *    hashing coordinates with ctx->seed, never from a running generator.
 * 5. Neighbourhood reads wrap around the edges (everything tiles) unless the node documents
 *    otherwise.
 * 6. Fail with `return wg_error_set(err, WG_ERR_..., NULL, "...")`; the engine adds the file,
 *    line and node id.
 * 7. If eval allocates image-sized memory of its own (an intermediate image, a decode buffer),
 *    take it with wg_scratch_alloc or wg_scratch_image (reused from the engine's buffer pool)
 *    and say how much in `scratch_bytes`, so the memory budget holds.
 * 8. Add the node to tests/nodes/: exact small cases, a float64 reference for fast paths,
 *    tiling, thread-count invariance, hard cases.
 * 9. A WG_NODE_POINT node may be evaluated a band of rows at a time, fused with the point
 *    operations around it (docs/engine.md): its inputs and outputs are then views of the band
 *    (data at the band's first row, height the band's) and ctx->height is the band's height.
 *    Address pixels only through wg_image_row() and the images' sizes, and never depend on a
 *    pixel's absolute row: a node that does is not a point operation.
 * 10. Inputs may be uniform images (stride 0: every row is the same memory), e.g. an
 *    unconnected graph input's default: read them through wg_image_row() like any other. A
 *    node whose outputs are one value everywhere declares WG_NODE_UNIFORM and gets such
 *    outputs; writing row 0 fills them.
 * 11. A node that never calls wg_parallel_rows (its work is one thread's) declares
 *    WG_NODE_SERIAL, so the scheduler runs it beside the row-parallel nodes rather than alone
 *    (docs/engine.md, Threads). One whose work is mostly one thread's may still split a last
 *    step over rows (`image` resampling what it decoded): the workers help when they are idle. */
#ifndef WETGRAPH_NODE_H
#define WETGRAPH_NODE_H

#include "error.h"
#include "expr.h"
#include "image.h"
#include "io.h"
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    WG_PARAM_FLOAT_T,
    WG_PARAM_INT_T,
    WG_PARAM_BOOL_T,
    WG_PARAM_ENUM_T,   /* int field: index into `values` */
    WG_PARAM_COLOR_T,  /* float[4] field: linear RGBA */
    WG_PARAM_STRING_T, /* const char * field, owned by the engine during eval */
} WgParamType;

enum {
    WG_PARAM_PATH = 1 << 0, /* string is a file path: resolved relative to the graph file, and
                               the file's content is part of the cache key */
};

/* "float", "int", "bool", "enum", "color" or "string": a parameter type as graph files and
 * messages write it. */
const char *wg_param_type_name(WgParamType t);

typedef struct WgParamSpec {
    const char *name;
    WgParamType type;
    size_t offset;
    const char *label;
    double def;                /* float/int/bool/enum default */
    double min, max;           /* hard range (float/int) */
    double ui_min, ui_max;     /* suggested slider range */
    const char *const *values; /* enum value names, NULL-terminated */
    const char *def_string;    /* string default; colour default as text */
    unsigned flags;
} WgParamSpec;

#define WG_PARAM_FLOAT_UI(S, f, label, def, lo, hi, ulo, uhi)                                      \
    {                                                                                              \
#f, WG_PARAM_FLOAT_T, offsetof(S, f), label, def, lo, hi, ulo, uhi, NULL, NULL, 0          \
    }
#define WG_PARAM_FLOAT(S, f, label, def, lo, hi) WG_PARAM_FLOAT_UI(S, f, label, def, lo, hi, lo, hi)
#define WG_PARAM_INT(S, f, label, def, lo, hi)                                                     \
    {                                                                                              \
#f, WG_PARAM_INT_T, offsetof(S, f), label, def, lo, hi, lo, hi, NULL, NULL, 0              \
    }
#define WG_PARAM_BOOL(S, f, label, def)                                                            \
    {                                                                                              \
#f, WG_PARAM_BOOL_T, offsetof(S, f), label, (def) ? 1 : 0, 0, 1, 0, 1, NULL, NULL, 0       \
    }
#define WG_PARAM_ENUM(S, f, label, def_index, values)                                              \
    {                                                                                              \
#f, WG_PARAM_ENUM_T, offsetof(S, f), label, def_index, 0, 0, 0, 0, values, NULL, 0         \
    }
#define WG_PARAM_COLOR(S, f, label, def_text)                                                      \
    {                                                                                              \
#f, WG_PARAM_COLOR_T, offsetof(S, f), label, 0, 0, 0, 0, 0, NULL, def_text, 0              \
    }
#define WG_PARAM_STRING(S, f, label, def_text)                                                     \
    {                                                                                              \
#f, WG_PARAM_STRING_T, offsetof(S, f), label, 0, 0, 0, 0, 0, NULL, def_text, 0             \
    }
#define WG_PARAM_PATH_STRING(S, f, label)                                                          \
    {                                                                                              \
#f, WG_PARAM_STRING_T, offsetof(S, f), label, 0, 0, 0, 0, 0, NULL, "", WG_PARAM_PATH       \
    }
#define WG_PARAM_END                                                                               \
    {                                                                                              \
        NULL, 0, 0, NULL, 0, 0, 0, 0, 0, NULL, NULL, 0                                             \
    }

enum { WG_ANY = 0, WG_GRAY = 1, WG_COLOR = 4 };

typedef struct WgPortSpec {
    const char *name;
    int kind;      /* WG_GRAY, WG_COLOR or WG_ANY */
    bool optional; /* inputs only */
    const char *doc;
} WgPortSpec;

#define WG_PORT(name, kind)                                                                        \
    {                                                                                              \
        name, kind, false, NULL                                                                    \
    }
#define WG_PORT_OPT(name, kind)                                                                    \
    {                                                                                              \
        name, kind, true, NULL                                                                     \
    }
#define WG_PORT_END                                                                                \
    {                                                                                              \
        NULL, 0, false, NULL                                                                       \
    }

enum {
    WG_NODE_POINT = 1 << 0,          /* each pixel depends only on the same pixel of the inputs
                                        (and may be evaluated on bands of rows, see 9 above) */
    WG_NODE_NEIGHBOURHOOD = 1 << 1,  /* reads a window around each pixel */
    WG_NODE_GLOBAL = 1 << 2,         /* needs the whole image (statistics, transforms) */
    WG_NODE_SOURCE = 1 << 3,         /* no image inputs */
    WG_NODE_SEEDED = 1 << 4,         /* output depends on the seed */
    WG_NODE_TIMED = 1 << 5,          /* output depends on $time directly (not only via params) */
    WG_NODE_DYNAMIC_INPUTS = 1 << 6, /* any <in name=...>; `inputs` lists none or fixed ones */
    WG_NODE_EXTRA_PARAMS = 1 << 7,   /* undeclared numeric attributes are passed as extras */
    WG_NODE_CHEAP = 1 << 8,          /* cheaper to recompute than to read from the disk cache:
                                        never stored (point operations are stored only by a
                                        first render, docs/engine.md) */
    WG_NODE_SCOPED = 1 << 9,         /* reads ctx->scope_* (graph params etc.) in its own maths */
    WG_NODE_SERIAL = 1 << 11,        /* evaluates on one thread (never calls wg_parallel_rows):
                                        the scheduler runs it beside the row-parallel nodes,
                                        which otherwise run one at a time on every thread */
    WG_NODE_UNIFORM = 1 << 10,       /* every pixel of every output has the same value: the
                                        engine gives it outputs whose rows all share one row of
                                        memory (stride 0), so writing row 0 is enough */
};

typedef struct WgPool WgPool;
typedef struct WgMemPool WgMemPool;

/* Everything a node sees while it is checked or evaluated. */
typedef struct WgNodeContext {
    const char *node_id;
    const void *params; /* the node's params struct, fully resolved */
    int width, height;  /* output size */
    uint64_t seed;
    double time;

    int n_inputs;
    const char *const *input_names;
    const int *input_channels;    /* 0 for an unconnected optional input */
    const WgImage *const *inputs; /* eval only; NULL for unconnected */

    int n_outputs;
    WgImage **outputs; /* eval only: allocated by the engine */
    /* eval only: what the type's prepare hook made for this evaluation (a fused group's
     * bands share it), or NULL when eval runs without it */
    const void *prepared;

    /* Extra numeric attributes (WG_NODE_EXTRA_PARAMS), and the numeric scope of the graph
     * (graph params, $time, $seed, $width, $height) for nodes with their own expressions. */
    int n_extra;
    const char *const *extra_names;
    const double *extra_values;
    int n_scope;
    const char *const *scope_names;
    const double *scope_values;

    WgPool *pool_;         /* private */
    volatile int *cancel_; /* private */
    WgMemPool *mem_;       /* private: the engine's buffer pool */
} WgNodeContext;

typedef struct WgNodeType {
    const char *name;
    const char *summary;  /* one line */
    const char *category; /* "source", "blend", "adjust", "filter", ... */
    const char *doc;      /* longer text for the node reference (may be NULL) */
    const WgParamSpec *params;
    size_t params_size;
    const WgPortSpec *inputs;
    const WgPortSpec *outputs;
    unsigned flags;
    /* Optional: channels (1 or 4) of an output port whose kind is WG_ANY. Default: the largest
     * channel count among the connected inputs, or 1 without inputs. */
    int (*output_channels)(const WgNodeContext *ctx, int port);
    /* Optional: checks that need the resolved params and input kinds (no images yet). */
    int (*check)(const WgNodeContext *ctx, WgError *err);
    int (*eval)(WgNodeContext *ctx, WgError *err);
    /* Optional: the most memory `eval` allocates for itself at once (intermediate images,
     * decode buffers, per-band scratch), beyond its outputs and inputs, for these params and
     * sizes (ctx has no images). The scheduler counts it against the memory budget while the
     * node runs; an estimate must not be below what eval really takes. Buffers of a few rows
     * may be left out: they are part of the budget's fixed overhead (docs/engine.md). */
    size_t (*scratch_bytes)(const WgNodeContext *ctx);
    /* Optional, for WG_NODE_SCOPED nodes: does the node read the scope name `name` (a graph
     * parameter or $time, $seed, $width, $height) with these params? Only the names it reads
     * enter its scope and its cache key, so a change of another parameter or of $time does not
     * recompute it. An over-estimate is safe. Default: every name. */
    bool (*uses_scope_name)(const void *params, const char *name);
    /* Optional, for nodes that are point operations with some params only (a `pixel`
     * expression that reads no row index and no other pixel): may the instance with these
     * params be evaluated a band of rows at a time and fused (point 9 holds for it, and its eval
     * takes what it needs from its context)? When set, it decides instead of the flags. An
     * under-estimate is safe. Default: WG_NODE_POINT types without flags that rule bands out. */
    bool (*banded)(const void *params);
    /* Optional, for banded instances: the work every band of a fused evaluation shares
     * (compiling an expression), done once before the bands with the whole image's context
     * (sizes, input channels, no images). eval then finds it in ctx->prepared; finish frees it
     * after the last band. eval must give the same pixels with ctx->prepared NULL. */
    int (*prepare)(const WgNodeContext *ctx, void **state, WgError *err);
    void (*finish)(void *state);
} WgNodeType;

/* The built-in registry: a NULL-terminated array in fixed order (wg_node_types_active in
 * plugin.h: with the plugins' types). wg_node_type_find looks among the active types. */
extern const WgNodeType *const wg_node_types[];
const WgNodeType *wg_node_type_find(const char *name);
/* The node types graphs are read with: a NULL-terminated table (borrowed: it and its
 * descriptors must outlive every graph loaded meanwhile), or NULL for none. The library hands
 * the engine the registry above when it loads; graph inputs need `uniform` and `image` in the
 * table. Not thread-safe: change it only while no graph is being loaded or rendered. */
void wg_set_node_types(const WgNodeType *const *types);

/* Run fn(user, y0, y1) over [0, height) in chunks of rows. The chunks depend only on `height`
 * (never on the thread count) so per-chunk reductions combine in a fixed order. Chunk i covers
 * rows [i*h/n, (i+1)*h/n) with n = wg_parallel_chunks(height). Returns WG_ERR_CANCELLED if the
 * render was cancelled meanwhile. */
typedef void (*WgRowsFn)(void *user, int y0, int y1);
int wg_parallel_rows(const WgNodeContext *ctx, int height, WgRowsFn fn, void *user);
int wg_parallel_chunks(int height);

/* Scratch memory for eval: 64-byte aligned, contents undefined, from the engine's buffer pool
 * (a buffer another node has freed, when one of that size is idle). NULL when out of memory.
 * Give it back with wg_scratch_free, with the same size, before eval returns. */
void *wg_scratch_alloc(const WgNodeContext *ctx, size_t bytes);
void wg_scratch_free(const WgNodeContext *ctx, void *ptr, size_t bytes);
/* An intermediate image from the same pool (undefined pixels); release it with wg_image_unref
 * before eval returns. NULL when out of memory or for an invalid size. */
WgImage *wg_scratch_image(const WgNodeContext *ctx, int width, int height, int channels);
/* src resampled to dst's size (both with the same channels) with the engine's wrapping tent
 * filter, as wg_image_convert resamples, the rows split over the render's threads (the same
 * values for any thread count); its intermediate (dst's width x src's height) comes from the
 * buffer pool. WG_ERR_NOMEM, WG_ERR_CANCELLED, or WG_ERR_TYPE for different channel counts. */
int wg_image_resample_into(const WgNodeContext *ctx, const WgImage *src, WgImage *dst);

/* Deterministic hashing for procedural nodes. */
static inline uint32_t wg_hash_u32(uint32_t x)
{
    /* lowbias32 (Chris Wellons' hash prospector): good avalanche, 2 multiplies */
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}
static inline uint32_t wg_hash3(uint32_t a, uint32_t b, uint32_t c)
{
    return wg_hash_u32(a ^ wg_hash_u32(b ^ wg_hash_u32(c)));
}

#ifdef __cplusplus
}
#endif
#endif
