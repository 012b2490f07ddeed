/* SPDX-License-Identifier: MIT */
/* Error values: set, locate, format. See wetgraph/error.h. */
#include "wetgraph/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static void copy_text(char *dst, size_t size, const char *src)
{
    if (!src) src = "";
    size_t n = strlen(src);
    if (n >= size) n = size - 1;
    memcpy(dst, src, n);
    dst[n] = '\0';
}

int wg_error_set(WgError *err, int code, const char *node, const char *fmt, ...)
{
    if (!err) return code;
    err->code = code;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->message, sizeof err->message, fmt, ap);
    va_end(ap);
    if (node && node[0]) copy_text(err->node, sizeof err->node, node);
    return code;
}

int wg_error_set_at(WgError *err, int code, const char *file, int line, int column, const char *fmt,
                    ...)
{
    if (!err) return code;
    err->code = code;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->message, sizeof err->message, fmt, ap);
    va_end(ap);
    copy_text(err->file, sizeof err->file, file);
    err->line = line;
    err->column = column;
    return code;
}

void wg_error_locate(WgError *err, const char *file, int line, const char *node)
{
    if (!err) return;
    if (!err->file[0] && file) {
        copy_text(err->file, sizeof err->file, file);
        err->line = line;
    }
    if (!err->node[0] && node) copy_text(err->node, sizeof err->node, node);
}

void wg_error_locate_type(WgError *err, const char *type)
{
    if (err && !err->node_type[0] && type) copy_text(err->node_type, sizeof err->node_type, type);
}

void wg_error_clear(WgError *err)
{
    if (err) memset(err, 0, sizeof *err);
}

void wg_error_format(const WgError *err, char *buf, size_t size)
{
    size_t n = 0;
    buf[0] = '\0';
#define PUT(...)                                                                                   \
    do {                                                                                           \
        if (n < size) {                                                                            \
            int k = snprintf(buf + n, size - n, __VA_ARGS__);                                      \
            if (k > 0) n += (size_t)k;                                                             \
        }                                                                                          \
    } while (0)
    if (err->file[0]) {
        PUT("%s", err->file);
        if (err->line > 0) PUT(":%d", err->line);
        if (err->line > 0 && err->column > 0) PUT(":%d", err->column);
        PUT(": ");
    }
    if (err->node[0] && err->node_type[0])
        PUT("node '%s' (%s): ", err->node, err->node_type);
    else if (err->node[0])
        PUT("node '%s': ", err->node);
    PUT("%s", err->message[0] ? err->message : wg_status_name(err->code));
#undef PUT
}

const char *wg_status_name(int code)
{
    switch (code) {
    case WG_OK:
        return "ok";
    case WG_ERR_NOMEM:
        return "out of memory";
    case WG_ERR_PARSE:
        return "parse error";
    case WG_ERR_TYPE:
        return "type error";
    case WG_ERR_RANGE:
        return "value out of range";
    case WG_ERR_IO:
        return "I/O error";
    case WG_ERR_CYCLE:
        return "cycle";
    case WG_ERR_USAGE:
        return "usage error";
    case WG_ERR_EVAL:
        return "evaluation error";
    case WG_ERR_CANCELLED:
        return "cancelled";
    case WG_ERR_BUDGET:
        return "memory budget exceeded";
    default:
        return "error";
    }
}
