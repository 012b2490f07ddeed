/* SPDX-License-Identifier: MIT */
/* The files of the page `wetgraph watch --serve` serves (web/index.html, page.js, page.css,
 * view3d.js and the shaders of docs/shaders), compiled in by web/embed.c when the program is
 * built, so an uninstalled build serves the page of its own source tree. */
#ifndef WETGRAPH_WEB_H
#define WETGRAPH_WEB_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    const char *address;        /* "/page.js": the path it is served at */
    const char *type;           /* its Content-Type */
    const unsigned char *bytes; /* followed by a NUL, not counted in size */
    size_t size;
} WgWebFile;

/* ended by an entry with a NULL address */
extern const WgWebFile wg_web_files[];

#ifdef __cplusplus
}
#endif

#endif
