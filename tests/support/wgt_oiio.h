/* SPDX-License-Identifier: MIT */
/* OpenImageIO for the image I/O tests, linked into them directly (not through wetgraph's
 * module): writing files the engine never writes (tiled, MIP-mapped, a data window apart from
 * the display window, integer samples) and reading any file the way OpenImageIO's own
 * read_image does, as the reference the engine's reading is compared with. */
#ifndef WGT_OIIO_H
#define WGT_OIIO_H

#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct WgtOiioSpec {
    int w, h, c;                        /* the data window's size and channels */
    int x, y;                           /* the data window's origin */
    int full_x, full_y, full_w, full_h; /* the display window (full_w 0: the data window) */
    int tile_w, tile_h;                 /* 0: scanlines */
    bool mipmap;                        /* all MIP levels (tiled files only) */
    const char *type;                   /* "float", "half", "uint8", "uint16" (NULL: float) */
    int parts;                          /* > 1: that many parts (subimages), all alike */
} WgtOiioSpec;

/* Write `data` (w*h*c floats, row-major) with the layout of `spec`; the format follows the
 * file name's extension. Part k > 0 of a multi-part file holds data + k. 0, or -1 with the
 * library's message in msg. */
int wgt_oiio_write(const char *path, const WgtOiioSpec *spec, const float *data, char *msg,
                   int msg_size);
/* ImageInput::read_image of subimage 0, level 0, as floats (the data window); *spec gets its
 * size, windows and tiles. malloc'd: free it; NULL with msg on failure. */
float *wgt_oiio_read(const char *path, WgtOiioSpec *spec, char *msg, int msg_size);

#ifdef __cplusplus
}
#endif

#endif
