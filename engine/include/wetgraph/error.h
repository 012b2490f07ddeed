/* SPDX-License-Identifier: MIT */
/* Error reporting: every fallible function returns an int status and fills a caller-owned
 * WgError with a message and, where known, the file, line, column and node that caused it.
 * There is no global error state. */
#ifndef WETGRAPH_ERROR_H
#define WETGRAPH_ERROR_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

enum {
    WG_OK = 0,
    WG_ERR_NOMEM = -1,     /* allocation failed */
    WG_ERR_PARSE = -2,     /* malformed graph file or expression */
    WG_ERR_TYPE = -3,      /* wrong kind of value, port or node */
    WG_ERR_RANGE = -4,     /* value outside its allowed range */
    WG_ERR_IO = -5,        /* file could not be read or written */
    WG_ERR_CYCLE = -6,     /* graph or subgraph recursion */
    WG_ERR_USAGE = -7,     /* bad API or command-line use */
    WG_ERR_EVAL = -8,      /* a node failed while computing */
    WG_ERR_CANCELLED = -9, /* evaluation stopped: another node failed, or wg_cancel_request */
    WG_ERR_BUDGET = -10,   /* working set does not fit the memory budget */
};

typedef struct WgError {
    int code;
    char message[1024];
    char file[1024];    /* empty when unknown */
    int line;           /* 1-based, 0 when unknown */
    int column;         /* 1-based, 0 when unknown */
    char node[256];     /* node id (path for nodes inside subgraphs), empty when unknown */
    char node_type[64]; /* that node's type, empty when unknown */
} WgError;

/* Set code and message (printf-style); keeps any location already set. Returns code.
 * `node` may be NULL. `err` may be NULL (then only the code is returned). */
int wg_error_set(WgError *err, int code, const char *node, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Same, with a source location. */
int wg_error_set_at(WgError *err, int code, const char *file, int line, int column, const char *fmt,
                    ...) __attribute__((format(printf, 6, 7)));

/* Fill in a location if the error has none yet (used when an error bubbles up). */
void wg_error_locate(WgError *err, const char *file, int line, const char *node);

void wg_error_clear(WgError *err);

/* Also record the node's type (shown as "node 'id' (type)"), if none is set yet. */
void wg_error_locate_type(WgError *err, const char *type);

/* "file:line:column: node 'id' (type): message" with the parts that are known. */
void wg_error_format(const WgError *err, char *buf, size_t size);

/* Short name of a status code ("parse error", "I/O error", ...). */
const char *wg_status_name(int code);

#ifdef __cplusplus
}
#endif
#endif
