/* SPDX-License-Identifier: MIT */
/* The buffer pool: pixel buffers of freed images and nodes' scratch memory go back to the
 * engine's pool and are handed out again before anything new is allocated, so a render does not
 * pay for fresh pages (the kernel's first touch of new memory costs more than a copy of it) for
 * every node. Idle buffers sit in free lists by size class (the size rounded up to 64 bytes, or
 * to a page from 1 MiB on); a request takes the most recently freed buffer of exactly its class,
 * else, for a mapping, a piece cut from the smallest larger idle mapping (see split). A graph's
 * images come in a few sizes, so CLASSES lists suffice; a buffer of yet another size while all of
 * them hold buffers is given back to the system.
 * The engine counts the idle bytes against its memory budget and trims the pool before it evicts
 * cached images (eval.c); the pool never keeps more idle bytes than its limit. The free lists are
 * intrusive (an idle buffer's first bytes link it), so putting a buffer back never allocates.
 * Buffers of 1 MiB and more, without an allocation hook, are memory mappings of their own; from
 * 2 MiB on they are aligned to 2 MiB and advised as transparent huge pages where the kernel
 * allows (the advice failing changes nothing). Smaller buffers, and all buffers while an
 * allocation hook is installed, come from the hook or aligned_alloc (wg__malloc_aligned). The pool
 * is thread-safe (one mutex); each buffer handed out holds a reference to it, so images may outlive
 * their engine: after wg__mempool_close, returned buffers go straight back to the system. */
#include "internal.h"

#include <stdatomic.h>
#include <string.h>
#include <sys/mman.h>

#define MAP_MIN_BYTES ((size_t)1 << 20)
#define HUGE_BYTES ((size_t)2 << 20)
#define PAGE_BYTES ((size_t)4096)
#define CLASSES 32

/* Header written into an idle buffer. */
typedef struct Idle {
    struct Idle *next;
    size_t bytes;
    int mapped;
} Idle;

/* One free list: buffers of one size and one kind (mapping or heap block), newest first. */
typedef struct Class {
    size_t bytes; /* 0: slot unused */
    int mapped;
    Idle *head;
    int count;
} Class;

struct WgMemPool {
    pthread_mutex_t mu;
    atomic_long refs; /* the owner's, plus one per buffer handed out */
    bool closed;
    size_t limit; /* most idle bytes kept */
    size_t idle;
    int idle_count;
    uint64_t hits, misses;
    size_t released;
    Class classes[CLASSES];
};

static atomic_bool poison;

void wg__mempool_set_poison(bool on)
{
    atomic_store(&poison, on);
}

static size_t class_bytes(size_t bytes)
{
    if (bytes < sizeof(Idle)) bytes = sizeof(Idle);
    size_t unit = bytes >= MAP_MIN_BYTES ? PAGE_BYTES : 64;
    return (bytes + unit - 1) & ~(unit - 1);
}

/* Whether a new buffer of class size cb is a mapping of its own: it is unless it is small or an
 * allocation hook is installed (which must see every allocation). */
static int kind_for(size_t cb)
{
    return !wg__alloc_hooked() && cb >= MAP_MIN_BYTES;
}

/* New memory from the system (or the hook). */
static void *fresh(size_t bytes, int mapped)
{
    if (!mapped) return wg__malloc_aligned(bytes);
    if (bytes < HUGE_BYTES) {
        void *p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        return p == MAP_FAILED ? NULL : p;
    }
    /* map 2 MiB more than asked, keep the 2 MiB aligned part */
    size_t span = bytes + HUGE_BYTES;
    if (span < bytes) return NULL;
    char *raw = mmap(NULL, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (raw == MAP_FAILED) return NULL;
    char *p = (char *)(((uintptr_t)raw + HUGE_BYTES - 1) & ~(uintptr_t)(HUGE_BYTES - 1));
    size_t head = (size_t)(p - raw), tail = span - head - bytes;
    if (head) munmap(raw, head);
    if (tail) munmap(p + bytes, tail);
#ifdef MADV_HUGEPAGE
    madvise(p, bytes, MADV_HUGEPAGE);
#endif
    return p;
}

static void give_back(void *ptr, size_t bytes, int mapped)
{
    if (mapped)
        munmap(ptr, bytes);
    else
        wg_free(ptr);
}

WgMemPool *wg__mempool_new(size_t limit)
{
    WgMemPool *p = wg_calloc(1, sizeof *p);
    if (!p) return NULL;
    pthread_mutex_init(&p->mu, NULL);
    atomic_init(&p->refs, 1);
    p->limit = limit;
    return p;
}

static void unref(WgMemPool *p)
{
    if (atomic_fetch_sub(&p->refs, 1) != 1) return;
    pthread_mutex_destroy(&p->mu);
    wg_free(p);
}

/* Detaches idle buffers until at most max_idle bytes are idle, from the class holding the most
 * bytes first; the caller gives the returned list back to the system outside the lock. Called
 * with the lock held. */
static Idle *detach(WgMemPool *p, size_t max_idle)
{
    Idle *out = NULL;
    while (p->idle > max_idle) {
        Class *best = NULL;
        for (int i = 0; i < CLASSES; i++) {
            Class *c = &p->classes[i];
            if (c->count && (!best || c->count * c->bytes > best->count * best->bytes)) best = c;
        }
        if (!best) break;
        Idle *b = best->head;
        best->head = b->next;
        best->count--;
        p->idle -= best->bytes;
        p->idle_count--;
        p->released += best->bytes;
        b->next = out;
        out = b;
    }
    return out;
}

static void release_list(Idle *list)
{
    while (list) {
        Idle *next = list->next;
        give_back(list, list->bytes, list->mapped);
        list = next;
    }
}

void wg__mempool_trim(WgMemPool *p, size_t max_idle)
{
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    Idle *list = detach(p, max_idle);
    pthread_mutex_unlock(&p->mu);
    release_list(list);
}

void wg__mempool_close(WgMemPool *p)
{
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    p->closed = true;
    Idle *list = detach(p, 0);
    pthread_mutex_unlock(&p->mu);
    release_list(list);
    unref(p);
}

/* Adds an idle buffer to the class of its size (a free slot when none has it yet); false when
 * every slot holds another size. Called with the lock held. */
static bool keep_idle(WgMemPool *p, void *ptr, size_t cb, int mapped)
{
    Class *c = NULL, *spare = NULL;
    for (int i = 0; i < CLASSES && !c; i++) {
        Class *k = &p->classes[i];
        if (k->bytes == cb && k->mapped == mapped) c = k;
        if (!spare && k->count == 0) spare = k;
    }
    if (!c && spare) {
        c = spare;
        c->bytes = cb;
        c->mapped = mapped;
    }
    if (!c) return false;
    Idle *b = ptr;
    b->next = c->head;
    b->bytes = cb;
    b->mapped = mapped;
    c->head = b;
    c->count++;
    p->idle += cb;
    p->idle_count++;
    return true;
}

/* A mapping of cb bytes cut from the smallest idle mapping larger than it, when there is one:
 * its pages were touched before, so the request costs no first touch (a fresh mapping's pages
 * are cleared by the kernel as they are first written, which in the virtual machines measured
 * costs more than the copy of a buffer). The rest stays idle as a buffer of its own when it is a
 * mapping's size and a class slot is free; otherwise it is returned in *tail for the caller to
 * give back outside the lock. Called with the lock held. */
static void *split(WgMemPool *p, size_t cb, void **tail, size_t *tail_bytes)
{
    Class *best = NULL;
    for (int i = 0; i < CLASSES; i++) {
        Class *k = &p->classes[i];
        if (k->mapped && k->head && k->bytes > cb && (!best || k->bytes < best->bytes)) best = k;
    }
    if (!best) return NULL;
    Idle *b = best->head;
    best->head = b->next;
    best->count--;
    p->idle -= best->bytes;
    p->idle_count--;
    char *rest = (char *)b + cb;
    size_t rest_bytes = best->bytes - cb;
    if (rest_bytes < MAP_MIN_BYTES || !keep_idle(p, rest, rest_bytes, 1))
        *tail = rest, *tail_bytes = rest_bytes;
    return b;
}

void *wg__mempool_get(WgMemPool *p, size_t bytes, int *mapped)
{
    size_t cb = class_bytes(bytes);
    int kind = kind_for(cb);
    void *ptr = NULL;
    if (p) {
        pthread_mutex_lock(&p->mu);
        for (int i = 0; i < CLASSES; i++) {
            Class *c = &p->classes[i];
            if (c->bytes != cb || c->mapped != kind || !c->head) continue;
            Idle *b = c->head;
            c->head = b->next;
            c->count--;
            p->idle -= cb;
            p->idle_count--;
            ptr = b;
            break;
        }
        void *tail = NULL;
        size_t tail_bytes = 0;
        if (!ptr && kind) ptr = split(p, cb, &tail, &tail_bytes);
        if (ptr)
            p->hits++;
        else
            p->misses++;
        pthread_mutex_unlock(&p->mu);
        if (tail) give_back(tail, tail_bytes, 1);
    }
    if (!ptr) ptr = fresh(cb, kind);
    if (!ptr) return NULL;
    if (p) atomic_fetch_add(&p->refs, 1);
    if (atomic_load_explicit(&poison, memory_order_relaxed)) memset(ptr, 0xff, cb);
    *mapped = kind;
    return ptr;
}

void wg__mempool_put(WgMemPool *p, void *ptr, size_t bytes, int mapped)
{
    if (!ptr) return;
    size_t cb = class_bytes(bytes);
    if (!p) {
        give_back(ptr, cb, mapped);
        return;
    }
    bool kept = false;
    pthread_mutex_lock(&p->mu);
    if (!p->closed && p->idle + cb <= p->limit) kept = keep_idle(p, ptr, cb, mapped);
    if (!kept) p->released += cb;
    pthread_mutex_unlock(&p->mu);
    if (!kept) give_back(ptr, cb, mapped);
    unref(p);
}

size_t wg__mempool_idle(WgMemPool *p)
{
    if (!p) return 0;
    pthread_mutex_lock(&p->mu);
    size_t idle = p->idle;
    pthread_mutex_unlock(&p->mu);
    return idle;
}

void wg__mempool_stats(WgMemPool *p, WgMemoryStats *out)
{
    memset(out, 0, sizeof *out);
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    out->pool_bytes = p->idle;
    out->pool_buffers = p->idle_count;
    out->pool_hits = p->hits;
    out->pool_misses = p->misses;
    out->pool_released = p->released;
    pthread_mutex_unlock(&p->mu);
}

/* ---- the node API ------------------------------------------------------------------------ */

/* Scratch memory is taken and given back within one eval, while the hook cannot change, so its
 * kind follows from its size as it did when it was taken. */
void *wg_scratch_alloc(const WgNodeContext *ctx, size_t bytes)
{
    int mapped;
    return wg__mempool_get(ctx ? ctx->mem_ : NULL, bytes, &mapped);
}

void wg_scratch_free(const WgNodeContext *ctx, void *ptr, size_t bytes)
{
    wg__mempool_put(ctx ? ctx->mem_ : NULL, ptr, bytes, kind_for(class_bytes(bytes)));
}

void wg__mempool_release(WgMemPool *p, void *ptr, size_t bytes)
{
    if (!ptr) return;
    size_t cb = class_bytes(bytes);
    give_back(ptr, cb, kind_for(cb));
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    p->released += cb;
    pthread_mutex_unlock(&p->mu);
    unref(p);
}

WgImage *wg_scratch_image(const WgNodeContext *ctx, int width, int height, int channels)
{
    return wg__image_new_in(ctx ? ctx->mem_ : NULL, width, height, channels);
}
