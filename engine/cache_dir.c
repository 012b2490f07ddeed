/* SPDX-License-Identifier: MIT */
/* The disk cache as a folder: its entries counted, and the least recently used removed until
 * it holds at most a given size. Entries are the files the result cache writes,
 * DIR/xx/<32 hex digits>-<port>.wgc (xx the first two digits); an entry's modification time is
 * its last use, since the cache sets it when it reads an entry back and writing one sets it
 * too. Only entry files are removed (and the temporaries of processes that no longer exist,
 * which wg_remove_stale_temporaries recognises), then the subfolders they leave empty: anything
 * else in the folder is left alone, so pointing the commands at the wrong folder deletes
 * nothing of the user's. */
#include "internal.h"
#include "wgio.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct DirEntry {
    char *path;
    uint64_t bytes;
    struct timespec used;
} DirEntry;

static bool is_hex(const char *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isxdigit((unsigned char)s[i]) || isupper((unsigned char)s[i])) return false;
    return true;
}

/* "<32 hex digits>-<port>.wgc" whose first two digits are the subfolder's name `sub` */
static bool is_entry_name(const char *name, const char *sub)
{
    size_t n = strlen(name);
    if (n < 38 || !is_hex(name, 32) || name[32] != '-' || strcmp(name + n - 4, ".wgc"))
        return false;
    for (size_t i = 33; i < n - 4; i++)
        if (!isdigit((unsigned char)name[i])) return false;
    return n - 4 > 33 && name[0] == sub[0] && name[1] == sub[1];
}

static void free_entries(DirEntry *list, size_t n)
{
    for (size_t i = 0; i < n; i++) wg_free(list[i].path);
    wg_free(list);
}

/* Every entry of the cache folder `dir`, with its size and last use. */
static int list_entries(const char *dir, DirEntry **out, size_t *count, WgError *err)
{
    *out = NULL, *count = 0;
    struct stat st;
    if (stat(dir, &st))
        return wg_error_set_at(err, WG_ERR_IO, dir, 0, 0, "cannot open the cache folder: %s",
                               errno == ENOENT ? "no such folder" : strerror(errno));
    if (!S_ISDIR(st.st_mode))
        return wg_error_set_at(err, WG_ERR_IO, dir, 0, 0,
                               "cannot open the cache folder: it is not a folder");
    DIR *top = opendir(dir);
    if (!top)
        return wg_error_set_at(err, WG_ERR_IO, dir, 0, 0, "cannot open the cache folder: %s",
                               strerror(errno));
    DirEntry *list = NULL;
    size_t n = 0, cap = 0;
    int rc = WG_OK;
    for (struct dirent *e; !rc && (e = readdir(top));) {
        if (strlen(e->d_name) != 2 || !is_hex(e->d_name, 2)) continue;
        size_t sl = strlen(dir) + 4;
        char *sub = wg_malloc(sl);
        if (!sub) {
            rc = WG_ERR_NOMEM;
            break;
        }
        snprintf(sub, sl, "%s/%s", dir, e->d_name);
        DIR *d = opendir(sub);
        for (struct dirent *f; d && !rc && (f = readdir(d));) {
            if (!is_entry_name(f->d_name, e->d_name)) continue;
            size_t pl = strlen(sub) + strlen(f->d_name) + 2;
            char *path = wg_malloc(pl);
            if (!path) {
                rc = WG_ERR_NOMEM;
                break;
            }
            snprintf(path, pl, "%s/%s", sub, f->d_name);
            struct stat fs;
            if (lstat(path, &fs) || !S_ISREG(fs.st_mode)) {
                wg_free(path);
                continue;
            }
            if (n == cap) {
                size_t c = cap ? 2 * cap : 256;
                DirEntry *bigger = wg_realloc_array(list, cap, c, sizeof *list);
                if (!bigger) {
                    wg_free(path);
                    rc = WG_ERR_NOMEM;
                    break;
                }
                list = bigger, cap = c;
            }
            list[n++] = (DirEntry){path, (uint64_t)fs.st_size, fs.st_mtim};
        }
        if (d) closedir(d);
        wg_free(sub);
    }
    closedir(top);
    if (rc) {
        free_entries(list, n);
        return wg_error_set(err, rc, NULL, "out of memory");
    }
    *out = list, *count = n;
    return WG_OK;
}

int wg_cache_dir_info(const char *dir, WgCacheDirInfo *info, WgError *err)
{
    memset(info, 0, sizeof *info);
    DirEntry *list;
    size_t n;
    int rc = list_entries(dir, &list, &n, err);
    if (rc) return rc;
    for (size_t i = 0; i < n; i++) {
        info->entries++;
        info->bytes += list[i].bytes;
        time_t t = list[i].used.tv_sec;
        if (i == 0 || t < info->oldest) info->oldest = t;
        if (i == 0 || t > info->newest) info->newest = t;
    }
    free_entries(list, n);
    return WG_OK;
}

/* Oldest use first; equal times by path, so that the order never depends on the listing. */
static int by_use(const void *a, const void *b)
{
    const DirEntry *x = a, *y = b;
    if (x->used.tv_sec != y->used.tv_sec) return x->used.tv_sec < y->used.tv_sec ? -1 : 1;
    if (x->used.tv_nsec != y->used.tv_nsec) return x->used.tv_nsec < y->used.tv_nsec ? -1 : 1;
    return strcmp(x->path, y->path);
}

int wg_cache_dir_prune(const char *dir, uint64_t max_bytes, WgCachePruned *out, WgError *err)
{
    memset(out, 0, sizeof *out);
    DirEntry *list;
    size_t n;
    int rc = list_entries(dir, &list, &n, err);
    if (rc) return rc;
    uint64_t total = 0;
    for (size_t i = 0; i < n; i++) total += list[i].bytes;
    if (n > 1) qsort(list, n, sizeof *list, by_use);
    for (size_t i = 0; i < n && total > max_bytes; i++) {
        /* an entry another process removed first is gone all the same */
        if (unlink(list[i].path) && errno != ENOENT) continue;
        total -= list[i].bytes;
        out->removed++;
        out->freed += list[i].bytes;
        char *slash = strrchr(list[i].path, '/');
        *slash = '\0';
        rmdir(list[i].path); /* only succeeds when the subfolder is empty */
    }
    out->left = total;
    free_entries(list, n);
    /* temporaries of dead processes in every subfolder (live ones are being written) */
    DIR *top = opendir(dir);
    for (struct dirent *e; top && (e = readdir(top));) {
        if (strlen(e->d_name) != 2 || !is_hex(e->d_name, 2)) continue;
        char sub[4096];
        snprintf(sub, sizeof sub, "%s/%s", dir, e->d_name);
        wg_remove_stale_temporaries(sub);
        if (max_bytes == 0) rmdir(sub);
    }
    if (top) closedir(top);
    return WG_OK;
}
