/* SPDX-License-Identifier: MIT */
/* The Python module's C half (wetgraph._wetgraph), over the public C API only: Engine (threads,
 * memory budget, the result cache kept across renders), Cancel (a cancel token), Graph (a loaded
 * graph with the parameter values and input images of its next render) and Error. Each render
 * builds a fresh WgRequest from the Graph's state, so the outputs can differ from one render to
 * the next while the engine's cache keeps what they share. The GIL is released while the engine
 * renders, converts or writes; renders on one Engine are serialised by its lock, renders on two
 * Engines run side by side. Input arrays of float32 with 1 or 4 channels and packed pixels are
 * lent to the engine (wg_image_wrap) without a copy; float32 outputs are read-only views of the
 * engine's images. Integer arrays follow the files' conventions: codes k / 255 or k / 65535,
 * sRGB-decoded where the input is declared srgb (alpha never), and outputs quantised as
 * wg_image_write quantises PNG 8 and 16 bits. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <wetgraph/wetgraph.h>

#include <math.h>
#include <pythread.h>
#include <stdbool.h>
#include <string.h>

static PyObject *Error;     /* wetgraph.Error */
static PyObject *Cancelled; /* wetgraph.Cancelled, a subclass for WG_ERR_CANCELLED */

/* Raise Error (or Cancelled) carrying the text the CLI prints after "wetgraph: error: " and the
 * parts of the location as attributes. Returns NULL. */
static PyObject *raise_error(const WgError *err)
{
    char text[4096];
    wg_error_format(err, text, sizeof text);
    PyObject *type = err->code == WG_ERR_CANCELLED ? Cancelled : Error;
    /* paths need not be UTF-8: undecodable bytes are shown escaped, not refused */
    PyObject *str = PyUnicode_DecodeUTF8(text, (Py_ssize_t)strlen(text), "backslashreplace");
    PyObject *exc = str ? PyObject_CallOneArg(type, str) : NULL;
    Py_XDECREF(str);
    if (!exc) return NULL;
    PyObject *v;
#define SET(name, obj)                                                                             \
    do {                                                                                           \
        v = (obj);                                                                                 \
        if (!v || PyObject_SetAttrString(exc, name, v)) {                                          \
            Py_XDECREF(v);                                                                         \
            Py_DECREF(exc);                                                                        \
            return NULL;                                                                           \
        }                                                                                          \
        Py_DECREF(v);                                                                              \
    } while (0)
    SET("code", PyLong_FromLong(err->code));
    SET("status", PyUnicode_FromString(wg_status_name(err->code)));
    SET("message",
        PyUnicode_DecodeUTF8(err->message, (Py_ssize_t)strlen(err->message), "backslashreplace"));
    SET("file", err->file[0] ? PyUnicode_DecodeFSDefault(err->file) : Py_NewRef(Py_None));
    SET("line", PyLong_FromLong(err->line));
    SET("column", PyLong_FromLong(err->column));
    SET("node", err->node[0] ? PyUnicode_FromString(err->node) : Py_NewRef(Py_None));
#undef SET
    PyErr_SetObject(type, exc);
    Py_DECREF(exc);
    return NULL;
}

/* ---- Cancel ------------------------------------------------------------------------------ */

typedef struct {
    PyObject_HEAD WgCancel *token;
} CancelObject;

static int Cancel_init(CancelObject *self, PyObject *args, PyObject *kw)
{
    static char *names[] = {NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kw, ":Cancel", names)) return -1;
    if (!self->token && !(self->token = wg_cancel_new())) {
        PyErr_NoMemory();
        return -1;
    }
    return 0;
}

static void Cancel_dealloc(CancelObject *self)
{
    wg_cancel_free(self->token);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *Cancel_request(CancelObject *self, PyObject *unused)
{
    wg_cancel_request(self->token);
    Py_RETURN_NONE;
}

static PyObject *Cancel_reset(CancelObject *self, PyObject *unused)
{
    wg_cancel_reset(self->token);
    Py_RETURN_NONE;
}

static PyObject *Cancel_requested(CancelObject *self, void *closure)
{
    return PyBool_FromLong(wg_cancel_requested(self->token));
}

static PyMethodDef Cancel_methods[] = {
    {"request", (PyCFunction)Cancel_request, METH_NOARGS,
     "request()\n--\n\nStop every render using this token, now and until reset(): running nodes "
     "stop at their next band of rows. Thread-safe."},
    {"reset", (PyCFunction)Cancel_reset, METH_NOARGS,
     "reset()\n--\n\nLet renders using this token run again."},
    {NULL},
};

static PyGetSetDef Cancel_getset[] = {
    {"requested", (getter)Cancel_requested, NULL,
     "Whether request() was called since the last reset().", NULL},
    {NULL},
};

static PyTypeObject CancelType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "wetgraph.Cancel",
    .tp_basicsize = sizeof(CancelObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc =
        "Cancel()\n--\n\nA cancel token: pass it to Graph.render(cancel=...) and call request() "
        "from any thread to stop the render, which then raises Cancelled.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Cancel_init,
    .tp_dealloc = (destructor)Cancel_dealloc,
    .tp_methods = Cancel_methods,
    .tp_getset = Cancel_getset,
};

/* ---- Engine ------------------------------------------------------------------------------ */

typedef struct {
    PyObject_HEAD WgEngine *engine;
    PyThread_type_lock lock; /* held by the render using the engine */
} EngineObject;

static int Engine_init(EngineObject *self, PyObject *args, PyObject *kw)
{
    static char *names[] = {"threads", "memory_budget", "cache_dir", NULL};
    int threads = 0;
    unsigned long long budget = 0;
    PyObject *cache_dir = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "|$iKO:Engine", names, &threads, &budget,
                                     &cache_dir))
        return -1;
    if (self->engine) {
        PyErr_SetString(PyExc_RuntimeError, "Engine.__init__ called twice");
        return -1;
    }
    if (threads < 0) {
        PyErr_Format(PyExc_ValueError, "threads is %d; give 0 (one per core) or more", threads);
        return -1;
    }
    PyObject *dir_bytes = NULL;
    if (cache_dir != Py_None && !PyUnicode_FSConverter(cache_dir, &dir_bytes)) return -1;
    WgEngineOptions opt = {.threads = threads,
                           .memory_budget = (size_t)budget,
                           .cache_dir = dir_bytes ? PyBytes_AS_STRING(dir_bytes) : NULL};
    WgError err = {0};
    int rc = wg_engine_new(&opt, &self->engine, &err);
    Py_XDECREF(dir_bytes);
    if (rc) {
        raise_error(&err);
        return -1;
    }
    if (!(self->lock = PyThread_allocate_lock())) {
        PyErr_NoMemory();
        return -1;
    }
    return 0;
}

static void Engine_dealloc(EngineObject *self)
{
    wg_engine_free(self->engine);
    if (self->lock) PyThread_free_lock(self->lock);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int engine_ready(EngineObject *self)
{
    if (self->engine) return 0;
    PyErr_SetString(PyExc_RuntimeError,
                    "the Engine was not initialised (Engine.__init__ not called)");
    return -1;
}

static PyObject *Engine_clear_cache(EngineObject *self, PyObject *unused)
{
    if (engine_ready(self)) return NULL;
    PyThreadState *ts = PyEval_SaveThread();
    PyThread_acquire_lock(self->lock, WAIT_LOCK);
    wg_engine_clear_cache(self->engine);
    PyThread_release_lock(self->lock);
    PyEval_RestoreThread(ts);
    Py_RETURN_NONE;
}

static PyObject *Engine_memory_stats(EngineObject *self, PyObject *unused)
{
    if (engine_ready(self)) return NULL;
    WgMemoryStats m;
    wg_engine_memory_stats(self->engine, &m);
    return Py_BuildValue("{s:n,s:i,s:K,s:K,s:n,s:n,s:i}", "budget",
                         (Py_ssize_t)wg_engine_memory_budget(self->engine), "pool_buffers",
                         m.pool_buffers, "pool_hits", (unsigned long long)m.pool_hits,
                         "pool_misses", (unsigned long long)m.pool_misses, "pool_bytes",
                         (Py_ssize_t)m.pool_bytes, "cache_bytes", (Py_ssize_t)m.cache_bytes,
                         "cache_entries", m.cache_entries);
}

static PyMethodDef Engine_methods[] = {
    {"clear_cache", (PyCFunction)Engine_clear_cache, METH_NOARGS,
     "clear_cache()\n--\n\nDrop every result kept in memory: the next render computes all."},
    {"memory_stats", (PyCFunction)Engine_memory_stats, METH_NOARGS,
     "memory_stats()\n--\n\nThe memory budget, the buffer pool's counts and the memory cache's "
     "size (bytes, entries), as a dict."},
    {NULL},
};

static PyTypeObject EngineType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "wetgraph.Engine",
    .tp_basicsize = sizeof(EngineObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Engine(*, threads=0, memory_budget=0, cache_dir=None)\n--\n\n"
              "Worker threads (0: one per core), a memory budget in bytes (0: half the memory, at "
              "most 16 GiB) and the result cache, kept across renders: a render after a change "
              "computes only the nodes the change reaches. cache_dir adds a cache on disk that "
              "outlives the process. Renders on one Engine run one at a time; give each thread its "
              "own Engine to render side by side.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Engine_init,
    .tp_dealloc = (destructor)Engine_dealloc,
    .tp_methods = Engine_methods,
};

/* ---- arrays in --------------------------------------------------------------------------- */

/* The array a wrapped image lends; dropped with the GIL from whichever thread lets go. */
static void release_array(void *user)
{
    PyGILState_STATE s = PyGILState_Ensure();
    Py_DECREF((PyObject *)user);
    PyGILState_Release(s);
}

static float srgb_lut8[256], lin_lut8[256];

/* The floats wg_image_read gives 8- and 16-bit codes: k times the float reciprocal of the code
 * range, then the sRGB curve where decoded. */
static void luts_init(void)
{
    volatile float r8 = 1.0f / 255.0f;
    for (int i = 0; i < 256; i++) {
        lin_lut8[i] = (float)i * r8;
        srgb_lut8[i] = wg_srgb_to_linear(lin_lut8[i]);
    }
}

static float code16(unsigned v, bool srgb)
{
    volatile float r16 = 1.0f / 65535.0f;
    float f = (float)v * r16;
    return srgb ? wg_srgb_to_linear(f) : f;
}

/* An input error located at the input's line in the graph file. Returns NULL. */
static PyObject *input_error(const WgGraph *g, int input, int code, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static PyObject *input_error(const WgGraph *g, int input, int code, const char *fmt, ...)
{
    const WgGraphInputInfo *in = wg_graph_input_info(g, input);
    WgError err = {0};
    char msg[900];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    wg_error_set_at(&err, code, wg_graph_path(g), in->line, 0, "input '%s': %s", in->name, msg);
    return raise_error(&err);
}

/* The image a numpy array stands for, for the graph's input `input` (colorspace cs): float32 of
 * 1 or 4 channels wrapped, the rest converted. New reference, or NULL with an exception. */
static WgImage *image_from_array(const WgGraph *g, int input, PyObject *obj)
{
    PyArrayObject *a = (PyArrayObject *)obj;
    int nd = PyArray_NDIM(a);
    const npy_intp *shape = PyArray_DIMS(a), *st = PyArray_STRIDES(a);
    char shape_text[64];
    if (nd == 2)
        snprintf(shape_text, sizeof shape_text, "(%ld, %ld)", (long)shape[0], (long)shape[1]);
    else if (nd == 3)
        snprintf(shape_text, sizeof shape_text, "(%ld, %ld, %ld)", (long)shape[0], (long)shape[1],
                 (long)shape[2]);
    else
        snprintf(shape_text, sizeof shape_text, "of %d dimensions", nd);
    int type = PyArray_TYPE(a);
    if (type != NPY_UINT8 && type != NPY_UINT16 && type != NPY_FLOAT32) {
        PyArray_Descr *d = PyArray_DESCR(a);
        return (WgImage *)input_error(g, input, WG_ERR_TYPE,
                                      "array of dtype %c%d: give uint8, uint16 or float32", d->kind,
                                      (int)d->elsize);
    }
    if (!PyArray_ISNOTSWAPPED(a))
        return (WgImage *)input_error(g, input, WG_ERR_TYPE,
                                      "array %s is in the other byte order: pass "
                                      "a.astype(a.dtype.newbyteorder('='))",
                                      shape_text);
    if (nd != 2 && nd != 3)
        return (WgImage *)input_error(
            g, input, WG_ERR_TYPE,
            "array %s: give (height, width) for gray or (height, width, channels) with 1, 3 or "
            "4 channels",
            shape_text);
    int c = nd == 2 ? 1 : (int)shape[2];
    if (c != 1 && c != 3 && c != 4)
        return (WgImage *)input_error(
            g, input, WG_ERR_TYPE, "array %s has %d channels: give 1 (gray), 3 (RGB) or 4 (RGBA)",
            shape_text, c);
    if (shape[0] < 1 || shape[1] < 1)
        return (WgImage *)input_error(g, input, WG_ERR_RANGE, "array %s holds no pixels",
                                      shape_text);
    if (shape[0] > WG_MAX_SIDE || shape[1] > WG_MAX_SIDE)
        return (WgImage *)input_error(g, input, WG_ERR_RANGE,
                                      "array %s: a side is larger than %d pixels", shape_text,
                                      WG_MAX_SIDE);
    int h = (int)shape[0], w = (int)shape[1];
    npy_intp item = PyArray_ITEMSIZE(a);
    /* rows anywhere (a crop is fine), pixels packed in each row */
    bool packed = (w == 1 || st[1] == c * item) && (nd == 2 || c == 1 || st[2] == item);
    if (!packed || (h > 1 && st[0] <= 0) || !PyArray_ISALIGNED(a))
        return (WgImage *)input_error(
            g, input, WG_ERR_TYPE,
            "array %s is not contiguous within its rows (strides %ld, %ld%s): pass "
            "numpy.ascontiguousarray(a)",
            shape_text, (long)st[0], (long)st[1], nd == 3 ? ", ..." : "");
    const char *base = PyArray_BYTES(a);
    size_t row_bytes = h > 1 ? (size_t)st[0] : (size_t)w * (size_t)c * (size_t)item;
    const WgGraphInputInfo *info = wg_graph_input_info(g, input);
    bool srgb = info->colorspace == WG_SRGB;

    if (type == NPY_FLOAT32) { /* non-finite values are refused, as in files */
        long bad_x = -1, bad_y = -1;
        float bad = 0;
        PyThreadState *ts = PyEval_SaveThread();
        for (int y = 0; y < h && bad_y < 0; y++) {
            const float *r = (const float *)(base + (size_t)y * row_bytes);
            for (long i = 0; i < (long)w * c; i++)
                if (!isfinite(r[i])) {
                    bad_x = i / c;
                    bad_y = y;
                    bad = r[i];
                    break;
                }
        }
        PyEval_RestoreThread(ts);
        if (bad_y >= 0)
            return (WgImage *)input_error(g, input, WG_ERR_RANGE,
                                          "array %s holds %s at pixel (x %ld, y %ld)", shape_text,
                                          isnan(bad) ? "NaN" : "an infinite value", bad_x, bad_y);
        if ((c == 1 || c == 4) && row_bytes % sizeof(float) == 0) {
            WgImage *img = wg_image_wrap(w, h, c, row_bytes / sizeof(float), (float *)base,
                                         release_array, obj);
            if (!img) return (WgImage *)PyErr_NoMemory();
            Py_INCREF(obj);
            return img;
        }
    }
    WgImage *img = wg_image_new(w, h, c == 1 ? 1 : 4);
    if (!img) return (WgImage *)PyErr_NoMemory();
    PyThreadState *ts = PyEval_SaveThread();
    for (int y = 0; y < h; y++) {
        const char *src = base + (size_t)y * row_bytes;
        float *dst = wg_image_row(img, y);
        int dc = img->channels;
        for (int x = 0; x < w; x++) {
            for (int k = 0; k < c; k++) {
                bool colour = k < 3; /* gray counts as colour; alpha never does */
                size_t i = (size_t)x * (size_t)c + (size_t)k;
                float v;
                if (type == NPY_UINT8) {
                    uint8_t code = ((const uint8_t *)src)[i];
                    v = srgb && colour ? srgb_lut8[code] : lin_lut8[code];
                } else if (type == NPY_UINT16) {
                    v = code16(((const uint16_t *)src)[i], srgb && colour);
                } else {
                    v = ((const float *)src)[i];
                }
                dst[(size_t)x * (size_t)dc + (size_t)k] = v;
            }
            if (c == 3) dst[(size_t)x * 4 + 3] = 1.0f;
        }
    }
    PyEval_RestoreThread(ts);
    return img;
}

/* ---- arrays out -------------------------------------------------------------------------- */

enum { OUT_FLOAT32, OUT_UINT8, OUT_UINT16 };

static void image_capsule_free(PyObject *cap)
{
    wg_image_unref(PyCapsule_GetPointer(cap, "wetgraph.image"));
}

/* A read-only float32 view of img (which the view keeps alive), or a uint8/uint16 array of the
 * codes a PNG of it holds. Gray: (height, width); colour: (height, width, 4). */
static PyObject *array_from_image(const WgImage *img, WgColorspace cs, int kind)
{
    int c = img->channels;
    npy_intp dims[3] = {img->height, img->width, c};
    int nd = c == 1 ? 2 : 3;
    if (kind == OUT_FLOAT32) {
        npy_intp strides[3] = {(npy_intp)(img->stride * sizeof(float)),
                               (npy_intp)(c * sizeof(float)), sizeof(float)};
        PyObject *cap = PyCapsule_New(wg_image_ref(img), "wetgraph.image", image_capsule_free);
        if (!cap) {
            wg_image_unref(img);
            return NULL;
        }
        PyObject *arr = PyArray_New(&PyArray_Type, nd, dims, NPY_FLOAT32, strides, img->data, 0, 0,
                                    NULL); /* flags 0: read-only, the engine's image */
        if (!arr) {
            Py_DECREF(cap);
            return NULL;
        }
        if (PyArray_SetBaseObject((PyArrayObject *)arr, cap)) {
            Py_DECREF(arr);
            return NULL;
        }
        return arr;
    }
    PyObject *arr = PyArray_SimpleNew(nd, dims, kind == OUT_UINT8 ? NPY_UINT8 : NPY_UINT16);
    if (!arr) return NULL;
    void *out = PyArray_DATA((PyArrayObject *)arr);
    bool srgb = cs == WG_SRGB;
    PyThreadState *ts = PyEval_SaveThread();
    for (int y = 0; y < img->height; y++) {
        const float *r = wg_image_row(img, y);
        size_t n = (size_t)img->width * (size_t)c, o = (size_t)y * n;
        for (size_t i = 0; i < n; i++) {
            bool colour = c == 1 || i % 4 < 3;
            float v = r[i];
            if (kind == OUT_UINT8) {
                ((uint8_t *)out)[o + i] = wg_quantize8(v, srgb && colour);
            } else { /* as wg_image_write's 16-bit samples */
                if (isnan(v)) v = 0;
                if (srgb && colour) v = wg_linear_to_srgb(v);
                double d = v < 0 ? 0 : v > 1 ? 1 : v;
                ((uint16_t *)out)[o + i] = (uint16_t)floor(d * 65535.0 + 0.5);
            }
        }
    }
    PyEval_RestoreThread(ts);
    return arr;
}

/* ---- Graph ------------------------------------------------------------------------------- */

typedef struct {
    PyObject_HEAD WgGraph *graph;
    EngineObject *engine;
    char **values;        /* per parameter: the text set, or NULL for the graph's default */
    char **input_paths;   /* per input: a file, or NULL */
    WgImage **input_imgs; /* per input: an image (maybe over an array), or NULL */
    int width, height;    /* 0: the graph's own size */
    bool has_seed;
    unsigned long long seed;
    double time;
    WgCancel *own_cancel;   /* the token of renders given none, for Graph.cancel() */
    WgCancel *running;      /* the token of the render running now, or NULL */
    PyObject *stats;        /* of the last render, or None */
    PyObject *progress_exc; /* raised by the progress callback during a render */
    PyObject *progress_fn;
    int n_params, n_inputs;
} GraphObject;

static void graph_clear_state(GraphObject *self)
{
    for (int i = 0; i < self->n_params && self->values; i++) PyMem_Free(self->values[i]);
    for (int i = 0; i < self->n_inputs && self->input_paths; i++) {
        PyMem_Free(self->input_paths[i]);
        wg_image_unref(self->input_imgs[i]);
    }
    PyMem_Free(self->values);
    PyMem_Free(self->input_paths);
    PyMem_Free(self->input_imgs);
    self->values = NULL;
    self->input_paths = NULL;
    self->input_imgs = NULL;
}

static void Graph_dealloc(GraphObject *self)
{
    graph_clear_state(self);
    wg_graph_free(self->graph);
    wg_cancel_free(self->own_cancel);
    Py_XDECREF(self->engine);
    Py_XDECREF(self->stats);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static char *dup_text(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = PyMem_Malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

static int Graph_init(GraphObject *self, PyObject *args, PyObject *kw)
{
    static char *names[] = {"graph", "engine", NULL};
    PyObject *name_obj, *engine = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|O:Graph", names, &name_obj, &engine)) return -1;
    if (self->graph) {
        PyErr_SetString(PyExc_RuntimeError, "Graph.__init__ called twice");
        return -1;
    }
    if (engine != Py_None && !PyObject_TypeCheck(engine, &EngineType)) {
        PyErr_Format(PyExc_TypeError, "engine must be a wetgraph.Engine or None, not %.100s",
                     Py_TYPE(engine)->tp_name);
        return -1;
    }
    PyObject *name_bytes = NULL;
    if (!PyUnicode_FSConverter(name_obj, &name_bytes)) return -1;
    WgError err = {0};
    char *path = NULL;
    int rc;
    PyThreadState *ts = PyEval_SaveThread();
    rc = wg_graph_find(PyBytes_AS_STRING(name_bytes), &path, &err);
    if (!rc) rc = wg_graph_load(path, &self->graph, &err);
    PyEval_RestoreThread(ts);
    wg_free(path);
    Py_DECREF(name_bytes);
    if (rc) {
        raise_error(&err);
        return -1;
    }
    if (engine == Py_None) {
        engine = PyObject_CallNoArgs((PyObject *)&EngineType);
        if (!engine) return -1;
    } else {
        Py_INCREF(engine);
    }
    self->engine = (EngineObject *)engine;
    if (engine_ready(self->engine)) return -1;
    self->n_params = wg_graph_param_count(self->graph);
    self->n_inputs = wg_graph_input_count(self->graph);
    self->values = PyMem_Calloc((size_t)self->n_params + 1, sizeof(char *));
    self->input_paths = PyMem_Calloc((size_t)self->n_inputs + 1, sizeof(char *));
    self->input_imgs = PyMem_Calloc((size_t)self->n_inputs + 1, sizeof(WgImage *));
    self->own_cancel = wg_cancel_new();
    self->stats = Py_NewRef(Py_None);
    if (!self->values || !self->input_paths || !self->input_imgs || !self->own_cancel) {
        PyErr_NoMemory();
        return -1;
    }
    return 0;
}

static int graph_ready(GraphObject *self)
{
    if (self->graph) return 0;
    PyErr_SetString(PyExc_RuntimeError, "the Graph was not loaded (Graph.__init__ not called)");
    return -1;
}

static int find_param(GraphObject *self, const char *name)
{
    for (int i = 0; i < self->n_params; i++)
        if (!strcmp(wg_graph_param_info(self->graph, i)->name, name)) return i;
    return -1;
}

static int find_input(GraphObject *self, const char *name)
{
    for (int i = 0; i < self->n_inputs; i++)
        if (!strcmp(wg_graph_input_info(self->graph, i)->name, name)) return i;
    return -1;
}

/* A request with the Graph's state; NULL with an exception. */
static WgRequest *build_request(GraphObject *self, WgError *err, int *rc)
{
    WgRequest *r = wg_request_new(self->graph);
    if (!r) {
        *rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        return NULL;
    }
    *rc = WG_OK;
    for (int i = 0; i < self->n_params && !*rc; i++)
        if (self->values[i])
            *rc =
                wg_request_set(r, wg_graph_param_info(self->graph, i)->name, self->values[i], err);
    for (int i = 0; i < self->n_inputs && !*rc; i++) {
        const char *name = wg_graph_input_info(self->graph, i)->name;
        if (self->input_paths[i])
            *rc = wg_request_set_input_file(r, name, self->input_paths[i], err);
        else if (self->input_imgs[i])
            *rc = wg_request_set_input_image(r, name, self->input_imgs[i], err);
    }
    if (self->width) wg_request_set_size(r, self->width, self->height);
    if (self->has_seed) wg_request_set_seed(r, self->seed);
    wg_request_set_time(r, self->time);
    if (*rc) {
        wg_request_free(r);
        return NULL;
    }
    return r;
}

static PyObject *Graph_set(GraphObject *self, PyObject *args)
{
    const char *name, *text;
    if (!PyArg_ParseTuple(args, "ss:set", &name, &text) || graph_ready(self)) return NULL;
    WgRequest *r = wg_request_new(self->graph);
    if (!r) return PyErr_NoMemory();
    WgError err = {0};
    int rc = wg_request_set(r, name, text, &err);
    wg_request_free(r);
    if (rc) {
        if (!err.file[0]) { /* say which file, as the CLI's --set errors name the graph */
            int i = find_param(self, name);
            wg_error_locate(&err, wg_graph_path(self->graph),
                            i >= 0 ? wg_graph_param_info(self->graph, i)->line : 0, NULL);
        }
        return raise_error(&err);
    }
    int i = find_param(self, name);
    char *copy = dup_text(text);
    if (!copy) return PyErr_NoMemory();
    PyMem_Free(self->values[i]);
    self->values[i] = copy;
    Py_RETURN_NONE;
}

static PyObject *Graph_unset(GraphObject *self, PyObject *args)
{
    const char *name;
    if (!PyArg_ParseTuple(args, "s:unset", &name) || graph_ready(self)) return NULL;
    int i = find_param(self, name);
    if (i < 0) {
        WgRequest *r = wg_request_new(self->graph);
        if (!r) return PyErr_NoMemory();
        WgError err = {0};
        wg_request_set(r, name, "0", &err); /* the engine's "no parameter" message */
        wg_request_free(r);
        wg_error_locate(&err, wg_graph_path(self->graph), 0, NULL);
        return raise_error(&err);
    }
    PyMem_Free(self->values[i]);
    self->values[i] = NULL;
    Py_RETURN_NONE;
}

static PyObject *Graph_value(GraphObject *self, PyObject *args)
{
    const char *name;
    if (!PyArg_ParseTuple(args, "s:value", &name) || graph_ready(self)) return NULL;
    int i = find_param(self, name);
    if (i < 0)
        return PyErr_Format(PyExc_KeyError, "graph '%s' has no parameter '%s'",
                            wg_graph_name(self->graph), name);
    if (self->values[i]) return PyUnicode_FromString(self->values[i]);
    return PyUnicode_FromString(wg_graph_param_info(self->graph, i)->default_text);
}

static PyObject *Graph_set_input(GraphObject *self, PyObject *args)
{
    const char *name;
    PyObject *value;
    if (!PyArg_ParseTuple(args, "sO:set_input", &name, &value) || graph_ready(self)) return NULL;
    int i = find_input(self, name);
    WgError err = {0};
    if (i < 0) { /* the engine's message, with its suggestion */
        WgRequest *r = wg_request_new(self->graph);
        if (!r) return PyErr_NoMemory();
        wg_request_set_input_file(r, name, "-", &err);
        wg_request_free(r);
        wg_error_locate(&err, wg_graph_path(self->graph), 0, NULL);
        return raise_error(&err);
    }
    char *path = NULL;
    WgImage *img = NULL;
    if (value == Py_None) {
        /* back to the input's default */
    } else if (PyArray_Check(value)) {
        if (!(img = image_from_array(self->graph, i, value))) return NULL;
    } else if (PyUnicode_Check(value) || PyBytes_Check(value) ||
               PyObject_HasAttrString(value, "__fspath__")) {
        PyObject *b = NULL;
        if (!PyUnicode_FSConverter(value, &b)) return NULL;
        WgRequest *r = wg_request_new(self->graph);
        int rc = r ? WG_OK : wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
        if (!rc) {
            PyThreadState *ts = PyEval_SaveThread();
            rc = wg_request_set_input_file(r, name, PyBytes_AS_STRING(b), &err);
            PyEval_RestoreThread(ts);
        }
        wg_request_free(r);
        if (rc) {
            Py_DECREF(b);
            if (!err.file[0])
                wg_error_locate(&err, wg_graph_path(self->graph),
                                wg_graph_input_info(self->graph, i)->line, NULL);
            return raise_error(&err);
        }
        path = dup_text(PyBytes_AS_STRING(b));
        Py_DECREF(b);
        if (!path) return PyErr_NoMemory();
    } else {
        return PyErr_Format(PyExc_TypeError,
                            "input '%s': give a file path, a numpy array or None, not %.100s", name,
                            Py_TYPE(value)->tp_name);
    }
    PyMem_Free(self->input_paths[i]);
    wg_image_unref(self->input_imgs[i]);
    self->input_paths[i] = path;
    self->input_imgs[i] = img;
    Py_RETURN_NONE;
}

static PyObject *opt_float(bool has, double v)
{
    return has ? PyFloat_FromDouble(v) : Py_NewRef(Py_None);
}

static PyObject *opt_str(const char *s)
{
    return s ? PyUnicode_FromString(s) : Py_NewRef(Py_None);
}

static PyObject *Graph_param_info(GraphObject *self, PyObject *unused)
{
    if (graph_ready(self)) return NULL;
    PyObject *list = PyList_New(self->n_params);
    for (int i = 0; list && i < self->n_params; i++) {
        const WgGraphParamInfo *p = wg_graph_param_info(self->graph, i);
        PyObject *values = Py_NewRef(Py_None);
        if (p->values) {
            int n = 0;
            while (p->values[n]) n++;
            Py_DECREF(values);
            values = PyTuple_New(n);
            for (int k = 0; values && k < n; k++)
                PyTuple_SET_ITEM(values, k, PyUnicode_FromString(p->values[k]));
        }
        PyObject *t =
            values ? Py_BuildValue("(sssNNNNi)", p->name, wg_param_type_name(p->type), p->default_text,
                                   opt_float(p->has_min, p->min), opt_float(p->has_max, p->max),
                                   opt_str(p->label), values, p->line)
                   : NULL;
        if (!t) {
            Py_DECREF(list);
            return NULL;
        }
        PyList_SET_ITEM(list, i, t);
    }
    return list;
}

static PyObject *Graph_input_info(GraphObject *self, PyObject *unused)
{
    if (graph_ready(self)) return NULL;
    PyObject *list = PyList_New(self->n_inputs);
    for (int i = 0; list && i < self->n_inputs; i++) {
        const WgGraphInputInfo *p = wg_graph_input_info(self->graph, i);
        PyObject *t = Py_BuildValue("(sssNi)", p->name, p->kind == WG_COLOR ? "color" : "gray",
                                    p->colorspace == WG_SRGB ? "srgb" : "linear",
                                    opt_str(p->has_default ? p->default_text : NULL), p->line);
        if (!t) {
            Py_DECREF(list);
            return NULL;
        }
        PyList_SET_ITEM(list, i, t);
    }
    return list;
}

static PyObject *Graph_output_info(GraphObject *self, PyObject *unused)
{
    if (graph_ready(self)) return NULL;
    int n = wg_graph_output_count(self->graph);
    PyObject *list = PyList_New(n);
    for (int i = 0; list && i < n; i++) {
        const WgGraphOutputInfo *p = wg_graph_output_info(self->graph, i);
        PyObject *t = Py_BuildValue(
            "(ssNsNi)", p->name, p->from,
            opt_str(p->format == WG_FORMAT_DEFAULT ? NULL : wg_format_name(p->format)),
            p->colorspace == WG_SRGB ? "srgb" : "linear", opt_str(p->group), p->line);
        if (!t) {
            Py_DECREF(list);
            return NULL;
        }
        PyList_SET_ITEM(list, i, t);
    }
    return list;
}

/* Called on the rendering thread (the GIL released) after each job. */
static void progress_cb(void *user, int done, int total, const char *node)
{
    GraphObject *self = user;
    PyGILState_STATE s = PyGILState_Ensure();
    if (!self->progress_exc) {
        PyObject *r = PyObject_CallFunction(self->progress_fn, "iis", done, total, node);
        if (r) {
            Py_DECREF(r);
        } else { /* stop the render; render() raises this exception */
            PyObject *t, *v, *tb;
            PyErr_Fetch(&t, &v, &tb);
            PyErr_NormalizeException(&t, &v, &tb);
            if (tb) PyException_SetTraceback(v, tb);
            self->progress_exc = v;
            Py_XDECREF(t);
            Py_XDECREF(tb);
            wg_cancel_request(self->running);
        }
    }
    PyGILState_Release(s);
}

static const char *cache_name(WgCacheOutcome c)
{
    return c == WG_HIT_MEMORY ? "memory" : c == WG_HIT_DISK ? "disk" : c == WG_HELD ? "held" : "computed";
}

static PyObject *stats_of(const WgResult *res)
{
    int n = wg_result_stat_count(res);
    PyObject *nodes = PyList_New(n);
    for (int i = 0; nodes && i < n; i++) {
        const WgNodeStat *s = wg_result_stat(res, i);
        PyObject *d =
            Py_BuildValue("{s:s,s:s,s:d,s:s,s:(iii),s:n,s:i}", "id", s->id, "type", s->type, "ms",
                          s->ms, "cache", cache_name(s->cache), "shape", s->height, s->width,
                          s->channels, "bytes", (Py_ssize_t)s->bytes, "fused", s->fused);
        if (!d) {
            Py_DECREF(nodes);
            return NULL;
        }
        PyList_SET_ITEM(nodes, i, d);
    }
    int nw = wg_result_warning_count(res);
    PyObject *warnings = nodes ? PyList_New(nw) : NULL;
    for (int i = 0; warnings && i < nw; i++) {
        const WgWarning *w = wg_result_warning(res, i);
        PyObject *s = w->node ? PyUnicode_FromFormat("%s:%d: node '%s': %s", w->file, w->line,
                                                     w->node, w->message)
                              : PyUnicode_FromFormat("%s:%d: %s", w->file, w->line, w->message);
        if (!s) {
            Py_CLEAR(warnings);
            break;
        }
        PyList_SET_ITEM(warnings, i, s);
    }
    if (!warnings) {
        Py_XDECREF(nodes);
        return NULL;
    }
    return Py_BuildValue("{s:i,s:d,s:n,s:N,s:N}", "evaluated", wg_result_evaluated_count(res),
                         "total_ms", wg_result_total_ms(res), "peak_bytes",
                         (Py_ssize_t)wg_result_peak_bytes(res), "nodes", nodes, "warnings",
                         warnings);
}

/* The render behind render() and render_files(): the result, or NULL with an exception. */
static WgResult *graph_render(GraphObject *self, PyObject *outputs, PyObject *progress,
                              PyObject *cancel)
{
    if (graph_ready(self)) return NULL;
    if (progress != Py_None && !PyCallable_Check(progress))
        return (WgResult *)PyErr_Format(PyExc_TypeError, "progress must be callable, not %.100s",
                                        Py_TYPE(progress)->tp_name);
    if (cancel != Py_None && !PyObject_TypeCheck(cancel, &CancelType))
        return (WgResult *)PyErr_Format(PyExc_TypeError,
                                        "cancel must be a wetgraph.Cancel, not %.100s",
                                        Py_TYPE(cancel)->tp_name);
    if (self->running) {
        PyErr_SetString(
            PyExc_RuntimeError,
            "this Graph is rendering in another thread; give each thread its own Graph");
        return NULL;
    }
    WgError err = {0};
    int rc;
    WgRequest *r = build_request(self, &err, &rc);
    if (!r) return (WgResult *)raise_error(&err);
    if (outputs != Py_None) {
        PyObject *seq = PyUnicode_Check(outputs) ? PyTuple_Pack(1, outputs)
                                                 : PySequence_Fast(outputs, "outputs must be a "
                                                                            "list of output names");
        if (!seq) {
            wg_request_free(r);
            return NULL;
        }
        for (Py_ssize_t k = 0; k < PySequence_Fast_GET_SIZE(seq) && !rc; k++) {
            const char *name = PyUnicode_AsUTF8(PySequence_Fast_GET_ITEM(seq, k));
            if (!name) {
                Py_DECREF(seq);
                wg_request_free(r);
                return NULL;
            }
            if ((rc = wg_request_add_output(r, name, &err)))
                wg_error_locate(&err, wg_graph_path(self->graph), 0, NULL);
        }
        Py_DECREF(seq);
        if (rc) {
            wg_request_free(r);
            return (WgResult *)raise_error(&err);
        }
    }
    WgCancel *token = cancel != Py_None ? ((CancelObject *)cancel)->token : self->own_cancel;
    if (token == self->own_cancel) wg_cancel_reset(token);
    wg_request_set_cancel(r, token);
    if (progress != Py_None) {
        self->progress_fn = progress;
        wg_request_set_progress(r, progress_cb, self);
    }
    self->running = token;
    Py_INCREF(cancel); /* the token must outlive the render */
    Py_INCREF(self->engine);
    EngineObject *e = self->engine;
    WgResult *res = NULL;
    PyThreadState *ts = PyEval_SaveThread();
    PyThread_acquire_lock(e->lock, WAIT_LOCK);
    rc = wg_render(e->engine, r, &res, &err);
    PyThread_release_lock(e->lock);
    PyEval_RestoreThread(ts);
    self->running = NULL;
    self->progress_fn = NULL;
    wg_request_free(r);
    Py_DECREF(e);
    Py_DECREF(cancel);
    PyObject *exc = self->progress_exc;
    self->progress_exc = NULL;
    if (exc) {
        wg_result_free(res);
        PyErr_SetObject((PyObject *)Py_TYPE(exc), exc);
        Py_DECREF(exc);
        return NULL;
    }
    if (rc) return (WgResult *)raise_error(&err);
    PyObject *stats = stats_of(res);
    if (!stats) {
        wg_result_free(res);
        return NULL;
    }
    Py_SETREF(self->stats, stats);
    return res;
}

static int parse_dtype(PyObject *obj, int *kind)
{
    if (obj == Py_None) {
        *kind = OUT_FLOAT32;
        return 0;
    }
    PyArray_Descr *d = NULL;
    if (!PyArray_DescrConverter(obj, &d)) return -1;
    int t = d->type_num;
    Py_DECREF(d);
    if (t == NPY_FLOAT32)
        *kind = OUT_FLOAT32;
    else if (t == NPY_UINT8)
        *kind = OUT_UINT8;
    else if (t == NPY_UINT16)
        *kind = OUT_UINT16;
    else {
        PyErr_SetString(PyExc_TypeError, "dtype must be float32, uint8 or uint16");
        return -1;
    }
    return 0;
}

static PyObject *Graph_render(GraphObject *self, PyObject *args, PyObject *kw)
{
    static char *names[] = {"outputs", "dtype", "progress", "cancel", NULL};
    PyObject *outputs = Py_None, *dtype = Py_None, *progress = Py_None, *cancel = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "|O$OOO:render", names, &outputs, &dtype, &progress,
                                     &cancel))
        return NULL;
    int kind;
    if (parse_dtype(dtype, &kind)) return NULL;
    WgResult *res = graph_render(self, outputs, progress, cancel);
    if (!res) return NULL;
    PyObject *dict = PyDict_New();
    for (int i = 0; dict && i < wg_result_output_count(res); i++) {
        PyObject *a = array_from_image(wg_result_output_image(res, i),
                                       wg_result_output_colorspace(res, i), kind);
        if (!a || PyDict_SetItemString(dict, wg_result_output_name(res, i), a)) Py_CLEAR(dict);
        Py_XDECREF(a);
    }
    wg_result_free(res);
    return dict;
}

static PyObject *Graph_render_files(GraphObject *self, PyObject *args, PyObject *kw)
{
    static char *names[] = {"folder", "outputs", "format", "progress", "cancel", NULL};
    PyObject *folder, *outputs = Py_None, *format = Py_None, *progress = Py_None, *cancel = Py_None;
    if (!PyArg_ParseTupleAndKeywords(args, kw, "O|O$OOO:render_files", names, &folder, &outputs,
                                     &format, &progress, &cancel))
        return NULL;
    PyObject *folder_b = NULL;
    if (!PyUnicode_FSConverter(folder, &folder_b)) return NULL;
    WgResult *res = graph_render(self, outputs, progress, cancel);
    if (!res) {
        Py_DECREF(folder_b);
        return NULL;
    }
    int n = wg_result_output_count(res);
    char **paths = PyMem_Calloc((size_t)n + 1, sizeof(char *));
    const WgImage **images = PyMem_Calloc((size_t)n + 1, sizeof(WgImage *));
    WgFormat *formats = PyMem_Calloc((size_t)n + 1, sizeof(WgFormat));
    WgColorspace *spaces = PyMem_Calloc((size_t)n + 1, sizeof(WgColorspace));
    PyObject *dict = NULL;
    WgError err = {0};
    if (!paths || !images || !formats || !spaces) {
        PyErr_NoMemory();
        goto out;
    }
    for (int i = 0; i < n; i++) {
        const char *name = wg_result_output_name(res, i);
        formats[i] = wg_result_output_format(res, i);
        PyObject *f = format;
        if (PyDict_Check(format)) f = PyDict_GetItemString(format, name);
        if (f && f != Py_None) {
            const char *text = PyUnicode_AsUTF8(f);
            if (!text) goto out;
            int fmt = wg_format_parse(text);
            if (fmt < 0) {
                wg_error_set(&err, WG_ERR_USAGE, NULL,
                             "unknown format '%s' for output '%s' (png, png16, tif16, exr, "
                             "exr32, jpeg, tga)",
                             text, name);
                raise_error(&err);
                goto out;
            }
            formats[i] = (WgFormat)fmt;
        }
        images[i] = wg_result_output_image(res, i);
        spaces[i] = wg_result_output_colorspace(res, i);
        PyObject *p =
            PyUnicode_FromFormat("%s/%s_%s.%s", PyBytes_AS_STRING(folder_b),
                                 wg_graph_name(self->graph), name, wg_format_extension(formats[i]));
        if (!p) goto out;
        PyObject *pb = NULL;
        int ok = PyUnicode_FSConverter(p, &pb);
        Py_DECREF(p);
        if (!ok) goto out;
        paths[i] = dup_text(PyBytes_AS_STRING(pb));
        Py_DECREF(pb);
        if (!paths[i]) {
            PyErr_NoMemory();
            goto out;
        }
    }
    int rc;
    PyThreadState *ts = PyEval_SaveThread();
    WgWriteSet *set = wg_write_set_new();
    rc = set ? WG_OK : wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!rc)
        rc = wg_write_set_images(set, n, (const char *const *)paths, images, formats, spaces, NULL,
                                 0, &err);
    if (!rc) rc = wg_write_set_commit(set, &err);
    wg_write_set_free(set);
    PyEval_RestoreThread(ts);
    if (rc) {
        raise_error(&err);
        goto out;
    }
    dict = PyDict_New();
    for (int i = 0; dict && i < n; i++) {
        PyObject *p = PyUnicode_DecodeFSDefault(paths[i]);
        if (!p || PyDict_SetItemString(dict, wg_result_output_name(res, i), p)) Py_CLEAR(dict);
        Py_XDECREF(p);
    }
out:
    for (int i = 0; paths && i < n; i++) PyMem_Free(paths[i]);
    PyMem_Free(paths);
    PyMem_Free(images);
    PyMem_Free(formats);
    PyMem_Free(spaces);
    wg_result_free(res);
    Py_DECREF(folder_b);
    return dict;
}

static PyObject *Graph_check(GraphObject *self, PyObject *unused)
{
    if (graph_ready(self)) return NULL;
    WgError err = {0};
    int rc;
    WgRequest *r = build_request(self, &err, &rc);
    if (!r) return raise_error(&err);
    PyThreadState *ts = PyEval_SaveThread();
    rc = wg_request_check(r, &err);
    PyEval_RestoreThread(ts);
    wg_request_free(r);
    if (rc) return raise_error(&err);
    Py_RETURN_NONE;
}

static PyObject *Graph_cancel(GraphObject *self, PyObject *unused)
{
    WgCancel *t = self->running;
    if (t) wg_cancel_request(t);
    return PyBool_FromLong(t != NULL);
}

static PyObject *Graph_get_size(GraphObject *self, void *closure)
{
    if (!self->width) Py_RETURN_NONE;
    return Py_BuildValue("(ii)", self->width, self->height);
}

static int Graph_set_size(GraphObject *self, PyObject *value, void *closure)
{
    if (!value || value == Py_None) {
        self->width = self->height = 0;
        return 0;
    }
    long w, h;
    if (PyLong_Check(value)) {
        w = h = PyLong_AsLong(value);
    } else if (PyTuple_Check(value)) {
        if (!PyArg_ParseTuple(value, "ll;size is (width, height), a number or None", &w, &h))
            return -1;
    } else {
        PyErr_Format(PyExc_TypeError, "size is (width, height), a number or None, not %.100s",
                     Py_TYPE(value)->tp_name);
        return -1;
    }
    if (PyErr_Occurred()) return -1;
    if (w < 1 || h < 1 || w > WG_MAX_SIDE || h > WG_MAX_SIDE) {
        WgError err = {0};
        wg_error_set(&err, WG_ERR_RANGE, NULL, "size %ldx%ld is outside 1..%d per side", w, h,
                     WG_MAX_SIDE);
        raise_error(&err);
        return -1;
    }
    self->width = (int)w;
    self->height = (int)h;
    return 0;
}

static PyObject *Graph_get_seed(GraphObject *self, void *closure)
{
    if (!self->has_seed) Py_RETURN_NONE;
    return PyLong_FromUnsignedLongLong(self->seed);
}

static int Graph_set_seed(GraphObject *self, PyObject *value, void *closure)
{
    if (!value || value == Py_None) {
        self->has_seed = false;
        return 0;
    }
    unsigned long long s = PyLong_AsUnsignedLongLong(value);
    if (PyErr_Occurred()) return -1;
    self->seed = s;
    self->has_seed = true;
    return 0;
}

static PyObject *Graph_get_time(GraphObject *self, void *closure)
{
    return PyFloat_FromDouble(self->time);
}

static int Graph_set_time(GraphObject *self, PyObject *value, void *closure)
{
    double t = value ? PyFloat_AsDouble(value) : 0.0;
    if (PyErr_Occurred()) return -1;
    if (!isfinite(t)) {
        PyErr_SetString(PyExc_ValueError, "time must be a finite number of seconds");
        return -1;
    }
    self->time = t;
    return 0;
}

static PyObject *Graph_get_text(GraphObject *self, void *closure)
{
    if (graph_ready(self)) return NULL;
    const char *which = closure, *s;
    if (!strcmp(which, "name"))
        s = wg_graph_name(self->graph);
    else if (!strcmp(which, "path"))
        s = wg_graph_path(self->graph);
    else if (!strcmp(which, "label"))
        s = wg_graph_label(self->graph);
    else
        s = wg_graph_size_text(self->graph);
    return opt_str(s);
}

static PyObject *Graph_get_stats(GraphObject *self, void *closure)
{
    return Py_NewRef(self->stats ? self->stats : Py_None);
}

static PyObject *Graph_get_engine(GraphObject *self, void *closure)
{
    if (graph_ready(self)) return NULL;
    return Py_NewRef((PyObject *)self->engine);
}

static PyMethodDef Graph_methods[] = {
    {"set", (PyCFunction)Graph_set, METH_VARARGS,
     "set(name, text)\n--\n\nSet a parameter from its text as written in a graph file ('0.4', "
     "'true', '#ff8000', an enum name, '=expression'); checked against its type and range at "
     "once."},
    {"unset", (PyCFunction)Graph_unset, METH_VARARGS,
     "unset(name)\n--\n\nGive a parameter its default value back."},
    {"value", (PyCFunction)Graph_value, METH_VARARGS,
     "value(name)\n--\n\nThe text of a parameter's value for the next render (its default when "
     "not set)."},
    {"set_input", (PyCFunction)Graph_set_input, METH_VARARGS,
     "set_input(name, value)\n--\n\nFeed an input from an image file (a path), from a numpy array "
     "(uint8, uint16 or float32; (h, w) gray, (h, w, 1|3|4)) or give it its default back (None)."},
    {"_param_info", (PyCFunction)Graph_param_info, METH_NOARGS, NULL},
    {"_input_info", (PyCFunction)Graph_input_info, METH_NOARGS, NULL},
    {"_output_info", (PyCFunction)Graph_output_info, METH_NOARGS, NULL},
    {"render", (PyCFunction)(void (*)(void))Graph_render, METH_VARARGS | METH_KEYWORDS,
     "render(outputs=None, *, dtype=None, progress=None, cancel=None)\n--\n\n"
     "Render the outputs named (default all) and return {name: array}: gray (height, width), "
     "colour (height, width, 4) linear RGBA. dtype float32 (default) gives read-only views of "
     "the engine's images; uint8 and uint16 the codes of a PNG of that depth (sRGB-encoded where "
     "the output is srgb). progress(done, total, node) is called after each job; cancel is a "
     "Cancel token."},
    {"render_files", (PyCFunction)(void (*)(void))Graph_render_files, METH_VARARGS | METH_KEYWORDS,
     "render_files(folder, outputs=None, *, format=None, progress=None, cancel=None)\n--\n\n"
     "Render and write each output to folder/<graph>_<output>.<ext> in its format (or format: "
     "one name for all, or {output: name}); the files are replaced together. Returns {name: "
     "path}."},
    {"check", (PyCFunction)Graph_check, METH_NOARGS,
     "check()\n--\n\nResolve sizes, parameters, types and files of the next render without "
     "rendering; raises Error on the first problem."},
    {"cancel", (PyCFunction)Graph_cancel, METH_NOARGS,
     "cancel()\n--\n\nStop the render of this Graph running in another thread (True), if any "
     "(False)."},
    {NULL},
};

static PyGetSetDef Graph_getset[] = {
    {"name", (getter)Graph_get_text, NULL, "The graph's name (its file name without .wetgraph).",
     "name"},
    {"path", (getter)Graph_get_text, NULL, "The graph's file.", "path"},
    {"label", (getter)Graph_get_text, NULL, "The graph's label, or None.", "label"},
    {"size_text", (getter)Graph_get_text, NULL,
     "The graph's own size attribute ('512', '$height').", "size"},
    {"size", (getter)Graph_get_size, (setter)Graph_set_size,
     "The size of the next render, (width, height), or None for the graph's own.", NULL},
    {"seed", (getter)Graph_get_seed, (setter)Graph_set_seed,
     "The seed of the next render, or None for the graph's own.", NULL},
    {"time", (getter)Graph_get_time, (setter)Graph_set_time, "$time of the next render (seconds).",
     NULL},
    {"stats", (getter)Graph_get_stats, NULL,
     "Statistics of the last render: evaluated (nodes computed), total_ms, peak_bytes, warnings, "
     "and nodes: one dict per node (id, type, ms, cache 'computed'|'memory'|'disk', shape, "
     "bytes, fused). None before the first render.",
     NULL},
    {"engine", (getter)Graph_get_engine, NULL, "The Engine this graph renders on.", NULL},
    {NULL},
};

static PyTypeObject GraphType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "wetgraph._wetgraph.Graph",
    .tp_basicsize = sizeof(GraphObject),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE,
    .tp_doc = "Graph(graph, engine=None)\n--\n\nA graph loaded by file or by name (as `wetgraph "
              "render NAME` finds it), with the parameter values and inputs of its next render.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)Graph_init,
    .tp_dealloc = (destructor)Graph_dealloc,
    .tp_methods = Graph_methods,
    .tp_getset = Graph_getset,
};

/* ---- module functions -------------------------------------------------------------------- */

static PyObject *mod_graphs(PyObject *m, PyObject *unused)
{
    WgGraphEntry *list;
    int n;
    WgError err = {0};
    if (wg_graph_list(&list, &n, &err)) return raise_error(&err);
    PyObject *d = PyDict_New();
    for (int i = 0; d && i < n; i++) {
        PyObject *p = PyUnicode_DecodeFSDefault(list[i].path);
        if (!p || PyDict_SetItemString(d, list[i].name, p)) Py_CLEAR(d);
        Py_XDECREF(p);
    }
    wg_graph_list_free(list, n);
    return d;
}

static PyObject *mod_find_graph(PyObject *m, PyObject *arg)
{
    PyObject *b = NULL;
    if (!PyUnicode_FSConverter(arg, &b)) return NULL;
    char *path = NULL;
    WgError err = {0};
    int rc = wg_graph_find(PyBytes_AS_STRING(b), &path, &err);
    Py_DECREF(b);
    if (rc) return raise_error(&err);
    PyObject *p = PyUnicode_DecodeFSDefault(path);
    wg_free(path);
    return p;
}

static PyObject *mod_load_plugin(PyObject *m, PyObject *arg)
{
    PyObject *b = NULL;
    if (!PyUnicode_FSConverter(arg, &b)) return NULL;
    WgError err = {0};
    /* not thread-safe in the engine: the GIL is kept, so no render of this module runs meanwhile
     * unless another thread has released it; the docs say to load plugins first */
    int rc = wg_plugin_load(PyBytes_AS_STRING(b), &err);
    Py_DECREF(b);
    if (rc) return raise_error(&err);
    Py_RETURN_NONE;
}

static PyMethodDef module_methods[] = {
    {"graphs", mod_graphs, METH_NOARGS,
     "graphs()\n--\n\nThe graphs found by name: {name: file}, from WETGRAPH_PATH's folders, then "
     "the built-in ones."},
    {"find_graph", mod_find_graph, METH_O,
     "find_graph(name)\n--\n\nThe file a graph name or path stands for (Error when none)."},
    {"load_plugin", mod_load_plugin, METH_O,
     "load_plugin(path)\n--\n\nLoad a node plugin (a shared library of node types, "
     "docs/plugins.md) so that graphs loaded after it can use its types, as `--plugin` does "
     "for the command line. Load plugins before loading graphs and rendering; a file loaded "
     "before is not loaded again. Error (naming the file) when it cannot be loaded."},
    {NULL},
};

static struct PyModuleDef module_def = {
    PyModuleDef_HEAD_INIT,
    .m_name = "wetgraph._wetgraph",
    .m_doc = "The C half of the wetgraph module; use `import wetgraph`.",
    .m_size = -1,
    .m_methods = module_methods,
};

PyMODINIT_FUNC PyInit__wetgraph(void)
{
    import_array();
    luts_init();
    if (PyType_Ready(&CancelType) || PyType_Ready(&EngineType) || PyType_Ready(&GraphType))
        return NULL;
    PyObject *m = PyModule_Create(&module_def);
    if (!m) return NULL;
    Error = PyErr_NewExceptionWithDoc(
        "wetgraph.Error",
        "A graph, a value or an input the engine refuses, or a render that failed. str() is the "
        "text the command line prints ('file:line:column: node 'id' (type): message' with the "
        "parts that are known); the attributes code, status, message, file, line, column and "
        "node hold the parts.",
        NULL, NULL);
    Cancelled = Error ? PyErr_NewExceptionWithDoc("wetgraph.Cancelled",
                                                  "The render was cancelled (Cancel.request() or "
                                                  "Graph.cancel()).",
                                                  Error, NULL)
                      : NULL;
    if (!Cancelled || PyModule_AddObjectRef(m, "Error", Error) ||
        PyModule_AddObjectRef(m, "Cancelled", Cancelled) ||
        PyModule_AddObjectRef(m, "Cancel", (PyObject *)&CancelType) ||
        PyModule_AddObjectRef(m, "Engine", (PyObject *)&EngineType) ||
        PyModule_AddObjectRef(m, "Graph", (PyObject *)&GraphType) ||
        PyModule_AddStringConstant(m, "VERSION", WETGRAPH_VERSION)) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
