/* SPDX-License-Identifier: MIT */
/* Result cache. In memory: entries keyed by (node key, output port), least recently used
 * evicted first, bounded by the engine's memory budget. On disk (optional): one file per
 * entry, DIR/ab/<32 hex digits>-<port>.wgc, holding a header (magic with the format version,
 * shape, output port and the full 128-bit key), the packed float pixels and an xxh3-64 checksum
 * of header and pixels. An entry whose size, key, port, shape or checksum does not match what
 * was asked for, or that is not a regular file, is deleted and treated as a miss, never trusted:
 * a file copied over another one, or a FIFO or symbolic link in its place, cannot make a render
 * return the wrong image or block. On a local file system a hit maps the entry's file rather
 * than reading it (map_entry). Entries are written to a temporary file
 * (.<name>.tmp<pid>-<n>.wgc) and renamed, so concurrent renders never see half a file; opening
 * the cache removes the temporaries left behind by processes that no longer exist. */
#include "internal.h"
#include "wgio.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/vfs.h>
#include <unistd.h>
#include <xxhash.h>
#if defined(__x86_64__) && __has_include(<xxh_x86dispatch.h>)
/* The same hashes by the widest vector code the processor runs, chosen at run time (libxxhash's
 * *_dispatch functions, which this header puts in place of the usual names): AVX2 hashes 2.3x
 * as fast as the default SSE2 code on the development VM. */
#include <xxh_x86dispatch.h>
#endif

/* The last character is the format version: entries of any other version are misses. */
#define DISK_MAGIC "WGCACHE2"

typedef struct Entry {
    uint64_t key[2];
    int port;
    const WgImage *img;
    int newer, older; /* the recency list, -1 at its ends */
    unsigned used;    /* the cache's `round` when it was last stored or read */
} Entry;

/* Entries sit densely in an array (removal moves the last one into the hole), found through a
 * hash index, and ordered by a doubly linked recency list: lookups, insertions and evictions
 * cost the same with a hundred thousand entries as with ten. */
struct WgCache {
    pthread_mutex_t mu;
    Entry *entries;
    int count, cap;
    WgKeyIndex index;   /* (key, port) -> entry */
    int newest, oldest; /* ends of the recency list, -1 when empty */
    size_t held;        /* bytes of all entries' images */
    unsigned round;     /* advanced by wg__cache_drop_unused */
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
    /* an existing file (or /dev/null) is no folder, and one that cannot be written to would
     * make every entry fail to be stored: either would leave the cache off without a word */
    struct stat st;
    if (stat(buf, &st)) return -1;
    if (!S_ISDIR(st.st_mode)) {
        errno = ENOTDIR;
        return -1;
    }
    if (access(buf, W_OK | X_OK)) return -1;
    return 0;
}

/* Delete, in every entry folder, the temporaries of processes that no longer exist (killed
 * while writing an entry); wg_remove_stale_temporaries knows their names. */
static void remove_stale_temporaries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d))) {
        const char *sub = e->d_name;
        if (!isxdigit((unsigned char)sub[0]) || !isxdigit((unsigned char)sub[1]) || sub[2])
            continue;
        char path[4096];
        if (snprintf(path, sizeof path, "%s/%s", dir, sub) >= (int)sizeof path) continue;
        struct stat st;
        if (lstat(path, &st) == 0 && S_ISDIR(st.st_mode)) wg_remove_stale_temporaries(path);
    }
    closedir(d);
}

WgCache *wg__cache_new(const char *dir)
{
    WgCache *c = wg_calloc(1, sizeof *c);
    if (!c) return NULL;
    pthread_mutex_init(&c->mu, NULL);
    c->newest = c->oldest = -1;
    if (dir) {
        c->dir = wg_strdup(dir);
        if (!c->dir || mkdir_p(dir)) {
            int e = c->dir ? errno : ENOMEM;
            wg__cache_free(c);
            errno = e; /* why, for the caller's message */
            return NULL;
        }
        remove_stale_temporaries(dir);
    }
    return c;
}

void wg__cache_clear(WgCache *c)
{
    pthread_mutex_lock(&c->mu);
    for (int i = 0; i < c->count; i++) wg_image_unref(c->entries[i].img);
    c->count = 0;
    c->held = 0;
    c->newest = c->oldest = -1;
    wg__key_index_free(&c->index);
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

static void unlink_entry(WgCache *c, int i)
{
    Entry *e = &c->entries[i];
    if (e->newer >= 0)
        c->entries[e->newer].older = e->older;
    else
        c->newest = e->older;
    if (e->older >= 0)
        c->entries[e->older].newer = e->newer;
    else
        c->oldest = e->newer;
}

static void link_newest(WgCache *c, int i)
{
    Entry *e = &c->entries[i];
    e->newer = -1;
    e->older = c->newest;
    if (c->newest >= 0) c->entries[c->newest].newer = i;
    c->newest = i;
    if (c->oldest < 0) c->oldest = i;
}

static void touch(WgCache *c, int i)
{
    c->entries[i].used = c->round;
    if (c->newest == i) return;
    unlink_entry(c, i);
    link_newest(c, i);
}

/* Drops entry i; the last entry moves into its place. */
static void remove_entry(WgCache *c, int i)
{
    Entry *e = &c->entries[i];
    unlink_entry(c, i);
    wg__key_index_remove(&c->index, e->key, e->port);
    c->held -= wg_image_bytes(e->img);
    wg_image_unref(e->img);
    int last = --c->count;
    if (i == last) return;
    c->entries[i] = c->entries[last];
    Entry *m = &c->entries[i];
    if (m->newer >= 0)
        c->entries[m->newer].older = i;
    else
        c->newest = i;
    if (m->older >= 0)
        c->entries[m->older].newer = i;
    else
        c->oldest = i;
    wg__key_index_put(&c->index, m->key, m->port, i); /* replaces: never allocates */
}

const WgImage *wg__cache_get(WgCache *c, const uint64_t key[2], int port)
{
    pthread_mutex_lock(&c->mu);
    int i = wg__key_index_get(&c->index, key, port);
    const WgImage *img = NULL;
    if (i >= 0) {
        touch(c, i);
        img = wg_image_ref(c->entries[i].img);
    }
    pthread_mutex_unlock(&c->mu);
    return img;
}

void wg__cache_put(WgCache *c, const uint64_t key[2], int port, const WgImage *img)
{
    pthread_mutex_lock(&c->mu);
    int i = wg__key_index_get(&c->index, key, port);
    if (i >= 0) {
        touch(c, i);
        goto out;
    }
    if (c->count == c->cap) {
        int cap = c->cap ? 2 * c->cap : 64;
        Entry *e = wg_realloc_array(c->entries, (size_t)c->count, (size_t)cap, sizeof *e);
        if (!e) goto out; /* caching is best effort */
        c->entries = e;
        c->cap = cap;
    }
    i = c->count;
    if (wg__key_index_put(&c->index, key, port, i)) goto out;
    c->count++;
    Entry *e = &c->entries[i];
    e->key[0] = key[0];
    e->key[1] = key[1];
    e->port = port;
    e->img = wg_image_ref(img);
    e->used = c->round;
    c->held += wg_image_bytes(img);
    link_newest(c, i);
out:
    pthread_mutex_unlock(&c->mu);
}

size_t wg__cache_bytes(WgCache *c)
{
    pthread_mutex_lock(&c->mu);
    size_t held = c->held;
    pthread_mutex_unlock(&c->mu);
    return held;
}

void wg__cache_trim(WgCache *c, size_t max_bytes)
{
    pthread_mutex_lock(&c->mu);
    while (c->held > max_bytes && c->oldest >= 0) remove_entry(c, c->oldest);
    pthread_mutex_unlock(&c->mu);
}

/* Every use moves an entry to the newest end of the recency list: the entries not used in this
 * round are the oldest ones. */
void wg__cache_drop_unused(WgCache *c)
{
    pthread_mutex_lock(&c->mu);
    while (c->oldest >= 0 && c->entries[c->oldest].used != c->round) remove_entry(c, c->oldest);
    c->round++;
    pthread_mutex_unlock(&c->mu);
}

int wg__cache_count(WgCache *c)
{
    pthread_mutex_lock(&c->mu);
    int n = c->count;
    pthread_mutex_unlock(&c->mu);
    return n;
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
    int32_t width, height, channels, port;
    uint64_t key[2];
} DiskHeader;
_Static_assert(sizeof(DiskHeader) == 40, "the header is written as is, without padding");

/* Open an entry for reading without ever blocking (a FIFO in its place) or following a
 * symbolic link. Returns -1 with *bad set when something that is not a valid entry file is
 * there; -1 with *bad clear when there is nothing (a plain miss). */
static int open_entry(const char *path, off_t size, bool *bad)
{
    *bad = false;
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) {
        *bad = errno == ELOOP || errno == ENXIO; /* a symbolic link, a socket */
        return -1;
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size != size) {
        *bad = true;
        close(fd);
        return -1;
    }
    return fd;
}

static bool header_matches(const DiskHeader *h, const uint64_t key[2], int port, int width,
                           int height, int channels)
{
    return !memcmp(h->magic, DISK_MAGIC, 8) && h->width == width && h->height == height &&
           h->channels == channels && h->port == port && h->key[0] == key[0] && h->key[1] == key[1];
}

static _Atomic bool no_mapping; /* wg__cache_map_entries(false): every entry is read */

void wg__cache_map_entries(bool on)
{
    no_mapping = !on;
}

/* Whether an entry can be mapped rather than read: on a local file system, unlinking the file
 * or renaming another over it (all that pruning, clearing and other renders do to an entry)
 * leaves its pages to whoever maps it. Not on a network or FUSE file system, where a file
 * another machine deletes faults when its pages are read again. */
static bool maps_safely(int fd)
{
    if (no_mapping) return false;
    struct statfs fs;
    if (fstatfs(fd, &fs)) return false;
    switch ((unsigned long)fs.f_type) {
    case 0xEF53UL:     /* ext2, ext3, ext4 */
    case 0x58465342UL: /* xfs */
    case 0x9123683EUL: /* btrfs */
    case 0x01021994UL: /* tmpfs */
    case 0xF2F52010UL: /* f2fs */
        return true;
    default:
        return false;
    }
}

typedef struct Mapping {
    void *addr;
    size_t len;
} Mapping;

static void unmap_entry(void *user)
{
    Mapping *m = user;
    munmap(m->addr, m->len);
    wg_free(m);
}

/* The entry at fd (size bytes) as an image over a private read-only mapping of the file: its
 * pixels are the page cache's, neither copied nor written into fresh memory, which on a VM
 * whose first touch of memory is slow costs more than the copy. A uniform image (one row for
 * all) gets the file's first row, copied, once the whole file is checked. NULL with *bad set
 * for an entry that does not match; NULL with *bad clear when it cannot be mapped (then it is
 * read). */
static WgImage *map_entry(int fd, size_t size, const uint64_t key[2], int port, int width,
                          int height, int channels, bool uniform, bool *bad)
{
    void *addr = mmap(NULL, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
    if (addr == MAP_FAILED) return NULL;
    const unsigned char *p = addr;
    DiskHeader h;
    uint64_t sum;
    memcpy(&h, p, sizeof h);
    memcpy(&sum, p + size - 8, 8);
    if (!header_matches(&h, key, port, width, height, channels) ||
        XXH3_64bits(p, size - 8) != sum) {
        *bad = true;
        munmap(addr, size);
        return NULL;
    }
    WgImage *img = NULL;
    if (uniform) {
        img = wg__image_new_uniform_in(NULL, width, height, channels);
        if (img)
            memcpy(wg_image_row(img, 0), p + sizeof h,
                   sizeof(float) * (size_t)width * (size_t)channels);
        munmap(addr, size);
        return img;
    }
    Mapping *m = wg_malloc(sizeof *m);
    if (m) {
        *m = (Mapping){addr, size};
        img = wg_image_wrap(width, height, channels, (size_t)width * (size_t)channels,
                            (float *)(void *)(p + sizeof h), unmap_entry, m);
    }
    if (!img) {
        wg_free(m);
        munmap(addr, size);
    }
    return img;
}

/* The entry read into a new image (a uniform image has one row for all: every row of the file
 * is read into it). NULL with *bad set for an entry that does not match. */
static WgImage *read_entry(int fd, const uint64_t key[2], int port, int width, int height,
                           int channels, bool uniform, bool *bad)
{
    int own = dup(fd); /* the stream's, closed with it */
    FILE *f = own < 0 ? NULL : fdopen(own, "rb");
    if (!f) {
        if (own >= 0) close(own);
        return NULL;
    }
    WgImage *img = NULL;
    size_t row = (size_t)width * (size_t)channels;
    DiskHeader h;
    if (fread(&h, sizeof h, 1, f) != 1 || !header_matches(&h, key, port, width, height, channels)) {
        *bad = true;
        goto out;
    }
    img = uniform ? wg__image_new_uniform_in(NULL, width, height, channels)
                  : wg_image_new(width, height, channels);
    if (!img) goto out;
    XXH3_state_t *st = XXH3_createState();
    if (!st) {
        wg_image_unref(img);
        img = NULL;
        goto out;
    }
    XXH3_64bits_reset(st);
    XXH3_64bits_update(st, &h, sizeof h);
    for (int y = 0; y < height && !*bad; y++) {
        float *r = wg_image_row(img, y);
        if (fread(r, sizeof(float), row, f) != row)
            *bad = true;
        else
            XXH3_64bits_update(st, r, sizeof(float) * row);
    }
    uint64_t sum, expect = XXH3_64bits_digest(st);
    XXH3_freeState(st);
    if (*bad || fread(&sum, sizeof sum, 1, f) != 1 || sum != expect || fgetc(f) != EOF) *bad = true;
    if (*bad) {
        wg_image_unref(img);
        img = NULL;
    }
out:
    fclose(f);
    return img;
}

const WgImage *wg__cache_disk_get(WgCache *c, const uint64_t key[2], int port, int width,
                                  int height, int channels, bool uniform)
{
    char *path = wg__cache_entry_path(c, key, port);
    if (!path) return NULL;
    WgImage *img = NULL;
    bool bad = false;
    size_t row = (size_t)width * (size_t)channels;
    size_t size = sizeof(DiskHeader) + sizeof(float) * row * (size_t)height + 8;
    int fd = open_entry(path, (off_t)size, &bad);
    if (fd < 0) goto out;
    if (maps_safely(fd))
        img = map_entry(fd, size, key, port, width, height, channels, uniform, &bad);
    if (!img && !bad) img = read_entry(fd, key, port, width, height, channels, uniform, &bad);
    /* a hit marks the entry as just used: pruning the folder removes the least recently used */
    if (img) futimens(fd, NULL);
    close(fd);
out:
    if (bad) unlink(path); /* corrupt, stale or someone else's: recompute and rewrite */
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
    /* The name holds this process's id, so a file already there is a dead process's. */
    int fd = -1;
    for (int attempt = 0; tmp && fd < 0 && attempt < 2; attempt++) {
        fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
        if (fd < 0 && (errno != EEXIST || unlink(tmp) != 0)) break;
    }
    FILE *f = fd >= 0 ? fdopen(fd, "wb") : NULL;
    if (fd >= 0 && !f) {
        close(fd);
        unlink(tmp);
    }
    if (f) {
        DiskHeader h;
        memset(&h, 0, sizeof h);
        memcpy(h.magic, DISK_MAGIC, 8);
        h.width = img->width;
        h.height = img->height;
        h.channels = img->channels;
        h.port = port;
        h.key[0] = key[0];
        h.key[1] = key[1];
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
