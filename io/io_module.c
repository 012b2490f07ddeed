/* SPDX-License-Identifier: MIT */
/* Loading the OpenImageIO module (io_oiio.h) on first use. OpenImageIO pulls in some 260 shared
 * libraries, which take 0.2 to 0.4 s to map and relocate; the library does not link it, so
 * `wetgraph nodes`, `check` and renders of EXR files start in milliseconds, and the first read
 * or write of another format loads wetgraph-oiio.so with dlopen, once per process under
 * pthread_once. Where it is looked for, first found wins:
 *   1. $WETGRAPH_MODULE_DIR, when set (then nothing else: tests and packagers choose the module);
 *   2. the folder of the object holding this code (libwetgraph.so, or the program when linked
 *      statically): the build tree keeps the module beside the library;
 *   3. that folder's wetgraph/ subfolder: the installed layout, LIBDIR/wetgraph/;
 *   4. LIBDIR/wetgraph of the configured install prefix;
 *   5. the build tree's top folder, only for a program that is itself inside the build tree
 *      (the fuzz targets link the library statically).
 * When no candidate loads, every call fails with a message that lists the paths tried and why
 * (the caller adds the image file's name). */
#include "internal.h"
#include "wgio.h"
#include "io_oiio.h"

#include <dlfcn.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static pthread_once_t load_once = PTHREAD_ONCE_INIT;
static const WgOiioModule *module;
static char load_error[2048];

/* Append "; " and the formatted text to load_error, cut when it is full. */
static void note(const char *fmt, const char *a, const char *b)
{
    size_t len = strlen(load_error);
    if (len + 1 >= sizeof load_error) return;
    snprintf(load_error + len, sizeof load_error - len, fmt, len ? "; " : "", a, b);
}

/* 1 loaded, 0 not there (keep looking), -1 there but unusable (stop: a broken module must not
 * silently give way to another one). */
static int try_dir(const char *dir)
{
    char path[4096];
    int n = snprintf(path, sizeof path, "%s/%s", dir[0] ? dir : ".", WG_OIIO_MODULE_FILE);
    if (n < 0 || (size_t)n >= sizeof path) return 0;
    if (access(path, F_OK) != 0) {
        note("%s%s: %s", path, strerror(errno));
        return 0;
    }
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        const char *e = dlerror();
        note("%s%s: %s", path, e ? e : "cannot be loaded");
        return -1;
    }
    WgOiioModuleGet get = (WgOiioModuleGet)dlsym(h, WG_OIIO_MODULE_ENTRY);
    const WgOiioModule *m = get ? get() : NULL;
    if (!m || m->abi != WG_OIIO_MODULE_ABI || m->size != sizeof(WgOiioModule)) {
        note("%s%s: %s", path, "not a module of this version of wetgraph");
        dlclose(h);
        return -1;
    }
    module = m;
    return 1;
}

/* dirname of the object that holds this function, in buf ("" when unknown). */
static void own_dir(char *buf, size_t size)
{
    buf[0] = 0;
    Dl_info info;
    if (!dladdr((void *)own_dir, &info) || !info.dli_fname) return;
    char *real = realpath(info.dli_fname, NULL);
    const char *p = real ? real : info.dli_fname;
    const char *slash = strrchr(p, '/');
    if (slash) snprintf(buf, size, "%.*s", (int)(slash - p), p);
    free(real);
}

static void load(void)
{
    const char *env = getenv("WETGRAPH_MODULE_DIR");
    if (env && env[0]) {
        try_dir(env);
        return;
    }
    char dir[4096], sub[4200];
    own_dir(dir, sizeof dir);
    int r = 0;
    if (dir[0]) {
        r = try_dir(dir);
        snprintf(sub, sizeof sub, "%s/wetgraph", dir);
        if (!r) r = try_dir(sub);
    }
    if (!r) r = try_dir(WG_INSTALL_MODULE_DIR);
    size_t len = strlen(WG_BUILD_DIR);
    if (!r && !strncmp(dir, WG_BUILD_DIR, len) && (dir[len] == '/' || !dir[len]))
        try_dir(WG_BUILD_DIR);
}

/* The module, or NULL with msg saying which paths were tried (and the file to be read, which
 * an error about a node's parameters would not name otherwise). */
static const WgOiioModule *get(const char *reading, char *msg, size_t msg_size)
{
    pthread_once(&load_once, load);
    if (!module && reading)
        snprintf(msg, msg_size,
                 "reading '%s' needs the OpenImageIO module, which cannot be loaded (%s)", reading,
                 load_error);
    else if (!module)
        snprintf(msg, msg_size,
                 "this format needs the OpenImageIO module, which cannot be loaded (%s)",
                 load_error);
    return module;
}

bool wg__oiio_loaded(void)
{
    return module != NULL;
}

int wg__oiio_probe(const char *path, int *w, int *h, int *c, char *msg, size_t msg_size)
{
    const WgOiioModule *m = get(path, msg, msg_size);
    return m ? m->probe(path, w, h, c, msg, msg_size) : -1;
}

int wg__oiio_open(const char *path, WgOiioIn **in, int *w, int *h, int *c, int *bits,
                  size_t *decoder_bytes, char *msg, size_t msg_size)
{
    *in = NULL;
    const WgOiioModule *m = get(path, msg, msg_size);
    return m ? m->open(path, in, w, h, c, bits, decoder_bytes, msg, msg_size) : -1;
}

int wg__oiio_read_rows(WgOiioIn *in, int y0, int y1, int cb, int ce, int bits, void *data,
                       ptrdiff_t xstride, ptrdiff_t ystride, char *msg, size_t msg_size)
{
    return module->read_rows(in, y0, y1, cb, ce, bits, data, xstride, ystride, msg, msg_size);
}

void wg__oiio_close(WgOiioIn *in)
{
    if (in) module->close(in);
}

int wg__oiio_create(const char *path, const char *format_ext, int w, int h, int c, int bits,
                    WgOiioOut **out, char *msg, size_t msg_size)
{
    *out = NULL;
    const WgOiioModule *m = get(NULL, msg, msg_size);
    return m ? m->create(path, format_ext, w, h, c, bits, out, msg, msg_size) : -1;
}

int wg__oiio_write_rows(WgOiioOut *o, int y0, int y1, const void *data, char *msg, size_t msg_size)
{
    return module->write_rows(o, y0, y1, data, msg, msg_size);
}

int wg__oiio_finish(WgOiioOut *o, bool ok, char *msg, size_t msg_size)
{
    if (!o) return -1;
    return module->finish(o, ok, msg, msg_size);
}

int wg__oiio_write(const char *path, const char *format_ext, const void *data, int w, int h, int c,
                   int bits, char *msg, size_t msg_size)
{
    WgOiioOut *o;
    if (wg__oiio_create(path, format_ext, w, h, c, bits, &o, msg, msg_size)) return -1;
    bool ok = !wg__oiio_write_rows(o, 0, h, data, msg, msg_size);
    return wg__oiio_finish(o, ok, msg, msg_size);
}
