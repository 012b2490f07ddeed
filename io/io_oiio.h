/* SPDX-License-Identifier: MIT */
/* The interface of the OpenImageIO module (io_oiio.cpp, built as the shared module
 * wetgraph-oiio.so and loaded by io_module.c on the first read or write of a file that is not
 * handled natively). The module exports one function, wg_oiio_module_get, returning a table of
 * the functions below; the library checks the table's ABI number and size before using it, so a
 * stale module from another build is refused instead of called. */
#ifndef WETGRAPH_IO_OIIO_H
#define WETGRAPH_IO_OIIO_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define WG_OIIO_MODULE_ABI 3
#define WG_OIIO_MODULE_FILE "wetgraph-oiio.so"
#define WG_OIIO_MODULE_ENTRY "wg_oiio_module_get"

typedef struct WgOiioIn WgOiioIn;
typedef struct WgOiioOut WgOiioOut;

typedef struct WgOiioModule {
    int abi;     /* WG_OIIO_MODULE_ABI */
    size_t size; /* sizeof(WgOiioModule) */
    int (*probe)(const char *path, int *w, int *h, int *c, char *msg, size_t msg_size);
    /* *decoder_bytes: what the decoder itself holds while reading (the whole file at its native
     * type for formats decoded at once, such as PNG); *bits: 8 or 16 when every channel is
     * stored as unsigned 8- or 16-bit integers, else 0 */
    int (*open)(const char *path, WgOiioIn **in, int *w, int *h, int *c, int *bits,
                size_t *decoder_bytes, char *msg, size_t msg_size);
    /* Rows [y0, y1), channels [cb, ce) to data as `bits` (0: float, 8 or 16: the file's own
     * unsigned integers), pixels xstride and rows ystride bytes apart. */
    int (*read_rows)(WgOiioIn *in, int y0, int y1, int cb, int ce, int bits, void *data,
                     ptrdiff_t xstride, ptrdiff_t ystride, char *msg, size_t msg_size);
    void (*close)(WgOiioIn *in);
    int (*create)(const char *path, const char *format_ext, int w, int h, int c, int bits,
                  WgOiioOut **out, char *msg, size_t msg_size);
    int (*write_rows)(WgOiioOut *o, int y0, int y1, const void *data, char *msg, size_t msg_size);
    int (*finish)(WgOiioOut *o, int ok, char *msg, size_t msg_size);
} WgOiioModule;

typedef const WgOiioModule *(*WgOiioModuleGet)(void);

#ifdef __cplusplus
}
#endif

#endif
