/* SPDX-License-Identifier: MIT */
/* Engine internals shared between the engine source files (not installed, not for nodes). */
#ifndef WETGRAPH_INTERNAL_H
#define WETGRAPH_INTERNAL_H

#include "wetgraph/wetgraph.h"

#include <pthread.h>
#include <stdbool.h>
#include <stdint.h>

/* ---- hash indexes (index.c) --------------------------------------------------------------- */

/* Names to positions; the names are borrowed and must outlive the index. Zeroed = empty. */
typedef struct WgNameSlot {
    const char *name;
    size_t len;
    int value;
} WgNameSlot;
typedef struct WgNameIndex {
    WgNameSlot *slots;
    size_t cap, count;
} WgNameIndex;
/* Adds or replaces; WG_ERR_NOMEM leaves the index as it was. */
int wg__name_index_put(WgNameIndex *ix, const char *name, size_t len, int value);
int wg__name_index_get(const WgNameIndex *ix, const char *name, size_t len); /* -1: none */
void wg__name_index_free(WgNameIndex *ix);

/* 128-bit keys plus a small integer (an output port) to positions >= 0. Zeroed = empty. */
typedef struct WgKeySlot {
    uint64_t key[2];
    int aux;
    int value; /* -1: free slot */
} WgKeySlot;
typedef struct WgKeyIndex {
    WgKeySlot *slots;
    size_t cap, count;
} WgKeyIndex;
int wg__key_index_put(WgKeyIndex *ix, const uint64_t key[2], int aux, int value);
int wg__key_index_get(const WgKeyIndex *ix, const uint64_t key[2], int aux); /* -1: none */
void wg__key_index_remove(WgKeyIndex *ix, const uint64_t key[2], int aux);
void wg__key_index_free(WgKeyIndex *ix);

/* ---- node types (types.c) ----------------------------------------------------------------- */

/* The type of that name in the table given to wg_set_node_types, or NULL. */
const WgNodeType *wg__node_type_lookup(const char *name);
/* The first `max` names of that table, in order; returns how many. */
int wg__node_type_names(const char **names, int max);
/* The identity of the plugin a type came from (plugin.c), which enters its cache keys, or
 * NULL for a type of the table the library started with. */
const uint64_t *wg__node_type_plugin_key(const WgNodeType *t);

/* ---- values ------------------------------------------------------------------------------ */

typedef struct WgValue {
    WgParamType type;
    double num;     /* float, int, bool (0/1), enum (index) */
    float color[4]; /* colour */
    char *str;      /* string; enum: value name */
} WgValue;

/* What a value must satisfy: built from a node's WgParamSpec or a graph's <param>. */
typedef struct WgParamDesc {
    const char *name;
    WgParamType type;
    bool has_min, has_max;
    double min, max;
    const char *const *values;
    unsigned flags;
} WgParamDesc;

void wg__param_desc_from_spec(WgParamDesc *d, const WgParamSpec *s);
/* Parse literal text into *out (owned: wg__value_clear). Error message names `what`. */
int wg__value_parse(const WgParamDesc *d, const char *text, WgValue *out, WgError *err);
/* Range/finiteness check of a numeric value (after expressions). */
int wg__value_check(const WgParamDesc *d, WgValue *v, WgError *err);
int wg__value_copy(WgValue *dst, const WgValue *src);
void wg__value_clear(WgValue *v);
/* Text form (for --set echo, info, dot). */
void wg__value_format(const WgValue *v, char *buf, size_t size);
/* The shortest text that reads back as exactly v (%.6g .. %.17g), for messages: a value just
 * outside a range must not print as the bound itself. */
void wg__number_text(double v, char *buf, size_t size);
int wg__color_parse(const char *text, float out[4]);
/* Length of the unsigned decimal number at s (digits, optional fraction, optional exponent;
 * no sign, no hex, no inf/nan), 0 when s does not start with one. */
size_t wg__number_length(const char *s);

/* ---- loaded graph definitions ------------------------------------------------------------ */

typedef struct AttrDef {
    char *name;
    char *text;
    int line;        /* where the attribute is written */
    int param;       /* index in the node type's params (or the subgraph's); -1 for extras */
    WgExpr *expr;    /* numeric expression (text starts with '=') */
    int ref_param;   /* '=name' forwarding a non-numeric graph param: its index, else -1 */
    WgValue literal; /* parsed literal when neither of the above */
} AttrDef;

typedef struct InDef {
    char *port;
    char *from;     /* as written */
    int from_node;  /* node index, or -1 for a graph input */
    int from_input; /* graph input index when from_node < 0 */
    int from_port;  /* output port index of the source node */
    int port_index; /* input port index on this node (dynamic inputs: order of <in>) */
    int line;
} InDef;

typedef struct NodeDef {
    char *id;
    char *type_name;
    int line;
    const WgNodeType *type; /* built-in, or NULL */
    WgGraph *sub;           /* subgraph, or NULL */
    AttrDef *attrs;
    int n_attrs;
    char *size_text; /* NULL = "graph" */
    char *seed_text; /* NULL = inherit */
    char *label;
    InDef *ins;
    int n_ins;
    /* info view */
    const char **info_ports, **info_from;
} NodeDef;

typedef struct ParamDef {
    WgGraphParamInfo info;
    WgParamDesc desc;
    WgValue def;
    char **value_storage; /* enum values */
} ParamDef;

/* A <warning>: `when` and the message's {…} parts are parsed at load time, evaluated per
 * instance of the graph once its parameters are known. */
typedef struct WarnPart {
    char *text;   /* literal text, or NULL */
    WgExpr *expr; /* {=expression}, or NULL */
    int param;    /* {name}: graph parameter index, else -1 */
} WarnPart;

typedef struct WarningDef {
    int line;
    char *when_text;
    WgExpr *when;
    WarnPart *parts;
    int n_parts;
} WarningDef;

typedef struct InputDef {
    WgGraphInputInfo info;
    float def[4];
} InputDef;

struct WgGraph {
    int refs;
    char *path, *dir, *name;
    char *label; /* the root's label, or NULL */
    char *size_text;
    int size_line;
    uint64_t seed;
    ParamDef *params;
    int n_params;
    InputDef *inputs;
    int n_inputs;
    WgGraphOutputInfo *outputs;
    int *output_node, *output_port, *output_input; /* resolved `from` */
    int n_outputs;
    NodeDef *nodes;
    int n_nodes;
    WarningDef *warnings;
    int n_warnings;
    WgGraphGltfInfo *gltfs;
    WgExpr **gltf_height_exprs; /* per gltf: its height_scale expression, or NULL */
    int n_gltfs;
    WgGraphNodeInfo *node_info;
    /* instances one instantiation of this graph can make: its built-in nodes and inputs plus,
     * per subgraph node, one and the subgraph's count (saturating at WG_MAX_INSTANCES + 1) */
    uint64_t instances;
    /* name lookups: node ids, input names, output names, param names */
    WgNameIndex node_index, input_index, output_index, param_index;
};

/* Slots of the graph scope in expressions: params first, then these. */
enum { WG_SCOPE_TIME, WG_SCOPE_SEED, WG_SCOPE_WIDTH, WG_SCOPE_HEIGHT, WG_SCOPE_COUNT_ };

int wg__graph_find_param(const WgGraph *g, const char *name, size_t len);
int wg__graph_find_input(const WgGraph *g, const char *name);
int wg__graph_find_node(const WgGraph *g, const char *id);
int wg__graph_find_output(const WgGraph *g, const char *name);
/* Output port names of a node def (built-in ports, or the subgraph's outputs). */
int wg__node_output_count(const NodeDef *n);
const char *wg__node_output_name(const NodeDef *n, int i);

/* ---- instances (a request flattened into concrete nodes) --------------------------------- */

typedef struct WgRef {
    int inst; /* -1 none */
    int port;
} WgRef;

typedef struct WgInst {
    const WgNodeType *type;
    char *id; /* path: "sub/node" inside subgraphs */
    const char *file;
    int line;
    void *params;   /* resolved params struct */
    char **strings; /* owned strings referenced by params */
    int n_strings;
    int width, height;
    uint64_t seed;
    double time;
    int n_in;
    WgRef *in;
    char **in_names;
    int *in_channels;
    int *in_lines;
    int n_out;
    int *out_channels;
    int n_extra;
    char **extra_names;
    double *extra_values;
    int n_scope;
    char **scope_names;
    double *scope_values;
    uint64_t key[2];         /* xxh3-128 of everything that determines the outputs */
    const WgImage *constant; /* internal "constant" node: the image itself */
} WgInst;

typedef struct WgPlanOutput {
    char *name;
    WgRef ref;
    WgFormat format;
    WgColorspace colorspace;
    WgPngCompression compression;
} WgPlanOutput;

typedef struct WgPlan {
    WgInst *insts;
    int n_insts, cap_insts;
    WgPlanOutput *outputs;
    int n_outputs;
    bool reads_time;     /* an instance reads $time (a timed node, an expression, a node's scope) */
    WgWarning *warnings; /* the <warning>s that apply, in instantiation order (owned strings) */
    int n_warnings;
    double *gltf_height_scales; /* per <gltf> of the top graph: its height_scale for this
                                   request (an expression evaluated), or NULL without any */
    int n_gltfs;
} WgPlan;

struct WgRequest {
    const WgGraph *graph;
    WgValue *values; /* per graph param */
    bool *value_set;
    char **input_paths; /* per graph input */
    const WgImage **input_images;
    char **outputs;
    int n_outputs;
    int width, height; /* 0 = from the graph */
    bool has_seed;
    uint64_t seed;
    double time;
    WgProgressFn progress;
    void *progress_user;
    WgCancel *cancel;     /* borrowed; NULL: none */
    WgOutputFn output_fn; /* NULL: the result keeps the outputs */
    void *output_user;
    WgOutputHeldFn held_fn; /* NULL: every output is handed over */
    void *held_user;
};

int wg__plan_build(const WgRequest *r, WgPlan *plan, WgError *err);
/* The context a node sees, without images (eval adds inputs, outputs and the pool). */
WgNodeContext wg__inst_context(const WgInst *in);
void wg__plan_free(WgPlan *plan);
extern const WgNodeType wg__node_constant, wg__node_promote;

/* ---- cache ------------------------------------------------------------------------------- */

typedef struct WgCache WgCache;
WgCache *wg__cache_new(const char *dir);
void wg__cache_free(WgCache *c);
/* Memory lookup; returns a new reference or NULL. */
const WgImage *wg__cache_get(WgCache *c, const uint64_t key[2], int port);
void wg__cache_put(WgCache *c, const uint64_t key[2], int port, const WgImage *img);
/* Disk lookup: a new reference when a valid entry of exactly that shape exists; invalid
 * entries are removed. `uniform`: read it as an image of one row for all (stride 0). */
const WgImage *wg__cache_disk_get(WgCache *c, const uint64_t key[2], int port, int width,
                                  int height, int channels, bool uniform);
int wg__cache_disk_put(WgCache *c, const uint64_t key[2], int port, const WgImage *img);
/* Whether disk-cache entries on local file systems are mapped (the default) rather than read
 * into new images: for tests of the reading path. */
void wg__cache_map_entries(bool on);
bool wg__cache_has_disk(const WgCache *c);
/* Evict least recently used memory entries until they hold at most max_bytes that nothing
 * else references. */
void wg__cache_trim(WgCache *c, size_t max_bytes);
/* Bytes of the memory entries' images (shared ones too). */
size_t wg__cache_bytes(WgCache *c);
int wg__cache_count(WgCache *c);
/* Remove the entries not stored or read since the previous call. */
void wg__cache_drop_unused(WgCache *c);
void wg__cache_clear(WgCache *c);
/* The disk file of an entry (for tests and tools); caller frees. */
char *wg__cache_entry_path(const WgCache *c, const uint64_t key[2], int port);

/* ---- buffer pool (mempool.c) ------------------------------------------------------------- */

/* Free lists of pixel and scratch buffers by size class, keeping at most `limit` idle bytes.
 * NULL everywhere means no pool: new memory, freed at once. */
WgMemPool *wg__mempool_new(size_t limit);
/* Releases the idle buffers and drops the owner's reference: buffers still out go back to the
 * system when they are returned. */
void wg__mempool_close(WgMemPool *p);
/* A 64-byte aligned buffer of at least `bytes`, an idle one of its class when there is one;
 * *mapped says which kind it is (pass it back to wg__mempool_put). NULL when out of memory. */
void *wg__mempool_get(WgMemPool *p, size_t bytes, int *mapped);
void wg__mempool_put(WgMemPool *p, void *ptr, size_t bytes, int mapped);
/* A buffer of wg__mempool_get given back to the system, not kept idle (its kind follows from
 * its size, as long as the allocation hook has not changed since it was taken). */
void wg__mempool_release(WgMemPool *p, void *ptr, size_t bytes);
/* Gives idle buffers back to the system until at most max_idle bytes are idle. */
void wg__mempool_trim(WgMemPool *p, size_t max_idle);
size_t wg__mempool_idle(WgMemPool *p);
void wg__mempool_stats(WgMemPool *p, WgMemoryStats *out);
/* Fill every buffer handed out with 0xff bytes (NaN floats), fresh or reused (for tests: a node
 * that reads memory it has not written then shows). */
void wg__mempool_set_poison(bool on);
/* An image whose pixels come from (and go back to) `pool`. */
WgImage *wg__image_new_in(WgMemPool *pool, int width, int height, int channels);
/* An image whose rows are all one row of memory (stride 0): for outputs of WG_NODE_UNIFORM. */
WgImage *wg__image_new_uniform_in(WgMemPool *pool, int width, int height, int channels);
/* wg_image_convert with the new images from (and back to) `pool`. */
WgImage *wg__image_convert_in(WgMemPool *pool, const WgImage *src, int width, int height,
                              int channels);
bool wg__alloc_hooked(void);
void *wg__malloc_aligned(size_t size);
/* The engine's pool (for tests). */
WgMemPool *wg__engine_mempool(WgEngine *e);

/* ---- worker pool ------------------------------------------------------------------------- */

typedef void (*WgJobFn)(void *user);
WgPool *wg__pool_new(int threads);
void wg__pool_free(WgPool *p);
int wg__pool_threads(const WgPool *p);
/* WG_ERR_NOMEM when the job cannot be queued (it is then not run). */
int wg__pool_submit(WgPool *p, WgJobFn fn, void *user);
int wg__pool_rows(WgPool *p, volatile int *cancel, int height, WgRowsFn fn, void *user);

/* ---- fused point operations (fuse.c) -------------------------------------------------- */

/* Whether a node can be evaluated on a band of rows (a point operation). */
bool wg__fuse_capable(const WgInst *in);
/* The groups a render fuses. run[i]: node i is computed; requested[i]: an output refers to it.
 * On return sink[i] is the node whose group node i belongs to (the group's last member in plan
 * order, which runs it), or -1 when node i runs alone; whole[i] says that member i is
 * materialised (requested, read outside its group, or the sink), the other members exist only
 * in bands. Returns the number of groups, or WG_ERR_NOMEM. */
int wg__fuse_find(const WgPlan *p, const bool *run, const bool *requested, int *sink, bool *whole);
/* What a node holds while it runs, beside its inputs: its outputs, the inputs converted for it
 * and its working memory (eval.c; the scheduler's memory estimate counts it). */
size_t wg__inst_need(const WgPlan *p, const WgInst *in);
/* The image a group reads from node `inst`'s output `port` (outside the group). */
typedef const WgImage *(*WgFuseSourceFn)(void *user, int inst, int port);
/* Evaluate a group (members: plan indexes, ascending, the sink last) band by band. out[k] is
 * NULL for a member that exists only in bands, else an array of its n_out outputs that this
 * fills (images from `mem`; the caller owns them). ms[k] is the time member k took, summed over
 * its bands and threads. band_rows > 0 sets the rows of a band (else they are chosen for the
 * memory they touch). On failure the outputs are released and *failed is the member the
 * error belongs to. */
int wg__fuse_eval(const WgPlan *p, const int *members, int n, WgImage ***out, WgMemPool *mem,
                  WgFuseSourceFn source, void *user, WgPool *pool, volatile int *cancel,
                  int band_rows, double *ms, int *failed, WgError *err);
/* Graphviz description of the request's graph with a cluster around each group of its own
 * nodes that a render with nothing cached fuses (graph.c writes it). */
void wg__graph_write_dot(const WgGraph *g, const int *cluster, FILE *f);

/* ---- misc -------------------------------------------------------------------------------- */

float wg__luminance(const float *rgba);
double wg__now_ms(void);

#endif
