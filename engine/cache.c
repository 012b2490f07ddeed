/* SPDX-License-Identifier: MIT */
/* Result cache. In memory: entries keyed by (node key, output port), least recently used
 * evicted first, bounded by the engine's memory budget. On disk (optional): one file per
 * entry, DIR/ab/<32 hex digits>-<port>.wgc, holding a header (magic, version, shape) and the
 * packed float pixels followed by an xxh3-64 checksum of header and pixels. An entry whose size,
 * shape or checksum does not match is deleted and treated as a miss, never trusted. Entries are
 * written to a temporary file and renamed, so concurrent renders never see half a file. */
#include "internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#define DISK_MAGIC "WGCACHE1"

typedef struct Entry {
    uint64_t key[2];
    int port;
    const WgImage *img;
    uint64_t used; /* LRU clock */
} Entry;

struct WgCache {
    pthread_mutex_t mu;
    Entry *entries;
    int count, cap;
    size_t held; /* bytes of the entries' images */
    uint64_t clock;
    char *dir;
};

static int mkdir_p(const char *path)
{
    char buf[4096];
    snprintf(buf, sizeof buf, "%s", path);
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/') continue;
        *p = '\0';
        if (mkdir(buf, 0777) && errno != EEXIST) return -1;
        *p = '/';
    }
    if (mkdir(buf, 0777) && errno != EEXIST) return -1;
    return 0;
}

WgCache *wg__cache_new(const char *dir)
{
    WgCache *c = wg_calloc(1, sizeof *c);
    if (!c) return NULL;
    pthread_mutex_init(&c->mu, NULL);
    if (dir) {
        c->dir = wg_strdup(dir);
        if (!c->dir || mkdir_p(dir)) {
            wg__cache_free(c);
            return NULL;
        }
    }
    return c;
}

void wg__cache_clear(WgCache *c)
{
    pthread_mutex_lock(&c->mu);
    for (int i = 0; i < c->count; i++) wg_image_unref(c->entries[i].img);
    c->count = 0;
    c->held = 0;
    pthread_mutex_unlock(&c->mu);
}

void wg__cache_free(WgCache *c)
{
    if (!c) return;
    wg__cache_clear(c);
    pthread_mutex_destroy(&c->mu);
    wg_free(c->entries);
    wg_free(c->dir);
    wg_free(c);
}

bool wg__cache_has_disk(const WgCache *c)
{
    return c->dir != NULL;
}

static int find(const WgCache *c, const uint64_t key[2], int port)
{
    for (int i = 0; i < c->count; i++)
        if (c->entries[i].key[0] == key[0] && c->entries[i].key[1] == key[1] &&
            c->entries[i].port == port)
            return i;
    return -1;
}

const WgImage *wg__cache_get(WgCache *c, const uint64_t key[2], int port)
{
    pthread_mutex_lock(&c->mu);
    int i = find(c, key, port);
    const WgImage *img = NULL;
    if (i >= 0) {
        c->entries[i].used = ++c->clock;
        img = wg_image_ref(c->entries[i].img);
    }
    pthread_mutex_unlock(&c->mu);
    return img;
}

void wg__cache_put(WgCache *c, const uint64_t key[2], int port, const WgImage *img)
{
    pthread_mutex_lock(&c->mu);
    int i = find(c, key, port);
    if (i < 0) {
        if (c->count == c->cap) {
            int cap = c->cap ? 2 * c->cap : 64;
            Entry *e = wg_realloc_array(c->entries, (size_t)c->count, (size_t)cap, sizeof *e);
            if (!e) goto out; /* caching is best effort */
            c->entries = e;
            c->cap = cap;
        }
        i = c->count++;
        c->entries[i].key[0] = key[0];
        c->entries[i].key[1] = key[1];
        c->entries[i].port = port;
        c->entries[i].img = wg_image_ref(img);
        c->held += wg_image_bytes(img);
    }
    c->entries[i].used = ++c->clock;
out:
    pthread_mutex_unlock(&c->mu);
}

void wg__cache_trim(WgCache *c, size_t max_bytes)
{
    pthread_mutex_lock(&c->mu);
    while (c->held > max_bytes && c->count > 0) {
        int victim = 0;
        for (int i = 1; i < c->count; i++)
            if (c->entries[i].used < c->entries[victim].used) victim = i;
        c->held -= wg_image_bytes(c->entries[victim].img);
        wg_image_unref(c->entries[victim].img);
        c->entries[victim] = c->entries[--c->count];
    }
    pthread_mutex_unlock(&c->mu);
}

char *wg__cache_entry_path(const WgCache *c, const uint64_t key[2], int port)
{
    if (!c->dir) return NULL;
    size_t n = strlen(c->dir) + 64;
    char *p = wg_malloc(n);
    if (p)
        snprintf(p, n, "%s/%02x/%016llx%016llx-%d.wgc", c->dir, (unsigned)(key[1] >> 56),
                 (unsigned long long)key[1], (unsigned long long)key[0], port);
    return p;
}

typedef struct DiskHeader {
    char magic[8];
    int32_t width, height, channels, reserved;
} DiskHeader;

const WgImage *wg__cache_disk_get(WgCache *c, const uint64_t key[2], int port, int width,
                                  int height, int channels)
{
    char *path = wg__cache_entry_path(c, key, port);
    if (!path) return NULL;
    FILE *f = fopen(path, "rb");
    WgImage *img = NULL;
    bool bad = false;
    if (!f) goto out;
    DiskHeader h;
    size_t row = (size_t)width * (size_t)channels;
    if (fread(&h, sizeof h, 1, f) != 1 || memcmp(h.magic, DISK_MAGIC, 8) || h.width != width ||
        h.height != height || h.channels != channels) {
        bad = true;
        goto out;
    }
    img = wg_image_new(width, height, channels);
    if (!img) goto out;
    XXH3_state_t *st = XXH3_createState();
    if (!st) {
        wg_image_unref(img);
        img = NULL;
        goto out;
    }
    XXH3_64bits_reset(st);
    XXH3_64bits_update(st, &h, sizeof h);
    for (int y = 0; y < height && !bad; y++) {
        float *r = wg_image_row(img, y);
        if (fread(r, sizeof(float), row, f) != row)
            bad = true;
        else
            XXH3_64bits_update(st, r, sizeof(float) * row);
    }
    uint64_t sum, expect = XXH3_64bits_digest(st);
    XXH3_freeState(st);
    if (bad || fread(&sum, sizeof sum, 1, f) != 1 || sum != expect || fgetc(f) != EOF) bad = true;
    if (bad) {
        wg_image_unref(img);
        img = NULL;
    }
out:
    if (f) fclose(f);
    if (bad) unlink(path); /* corrupt or stale: recompute and rewrite */
    wg_free(path);
    return img;
}

int wg__cache_disk_put(WgCache *c, const uint64_t key[2], int port, const WgImage *img)
{
    char *path = wg__cache_entry_path(c, key, port);
    if (!path) return WG_ERR_NOMEM;
    char *slash = strrchr(path, '/');
    *slash = '\0';
    mkdir_p(path);
    *slash = '/';
    char *tmp = wg__temp_path_for(path);
    int rc = WG_ERR_IO;
    FILE *f = tmp ? fopen(tmp, "wb") : NULL;
    if (f) {
        DiskHeader h = {DISK_MAGIC, img->width, img->height, img->channels, 0};
        memcpy(h.magic, DISK_MAGIC, 8);
        XXH3_state_t *st = XXH3_createState();
        bool ok = st && fwrite(&h, sizeof h, 1, f) == 1;
        if (ok) {
            XXH3_64bits_reset(st);
            XXH3_64bits_update(st, &h, sizeof h);
        }
        size_t row = (size_t)img->width * (size_t)img->channels;
        for (int y = 0; y < img->height && ok; y++) {
            const float *r = wg_image_row(img, y);
            ok = fwrite(r, sizeof(float), row, f) == row;
            XXH3_64bits_update(st, r, sizeof(float) * row);
        }
        if (ok) {
            uint64_t sum = XXH3_64bits_digest(st);
            ok = fwrite(&sum, sizeof sum, 1, f) == 1;
        }
        if (st) XXH3_freeState(st);
        ok = (fclose(f) == 0) && ok;
        if (ok && rename(tmp, path) == 0)
            rc = WG_OK;
        else
            unlink(tmp);
    }
    wg_free(tmp);
    wg_free(path);
    return rc;
}
