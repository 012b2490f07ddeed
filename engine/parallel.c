/* SPDX-License-Identifier: MIT */
/* The worker pool. It runs node jobs and, inside them, row chunks: a node that calls
 * wg_parallel_rows publishes a batch, works on it itself, and idle workers help. Chunk
 * boundaries depend only on the image height, so any reduction done per chunk and combined in
 * chunk order gives bit-identical results for every thread count. */
#include "internal.h"

#include <stdlib.h>
#include <string.h>

typedef struct Job {
    WgJobFn fn;
    void *user;
    struct Job *next;
} Job;

typedef struct Batch {
    WgRowsFn fn;
    void *user;
    int height, chunks;
    int next, done;
    volatile int *cancel;
    struct Batch *next_batch;
} Batch;

struct WgPool {
    int threads;
    pthread_t *tids;
    pthread_mutex_t mu;
    pthread_cond_t work;       /* new job or batch, or stop */
    pthread_cond_t batch_done; /* some batch finished a chunk */
    Job *head, *tail;
    Batch *batches;
    bool stop;
};

int wg_parallel_chunks(int height)
{
    if (height <= 0) return 0;
    return height < 64 ? height : 64;
}

static void chunk_rows(const Batch *b, int i, int *y0, int *y1)
{
    *y0 = (int)((long long)i * b->height / b->chunks);
    *y1 = (int)((long long)(i + 1) * b->height / b->chunks);
}

/* With the lock held: take a chunk from any open batch, run it unlocked. */
static bool help_batches(WgPool *p)
{
    for (Batch *b = p->batches; b; b = b->next_batch) {
        if (b->next >= b->chunks) continue;
        int i = b->next++;
        pthread_mutex_unlock(&p->mu);
        if (!*b->cancel) {
            int y0, y1;
            chunk_rows(b, i, &y0, &y1);
            b->fn(b->user, y0, y1);
        }
        pthread_mutex_lock(&p->mu);
        b->done++;
        pthread_cond_broadcast(&p->batch_done);
        return true;
    }
    return false;
}

static void *worker(void *arg)
{
    WgPool *p = arg;
    pthread_mutex_lock(&p->mu);
    while (!p->stop) {
        if (help_batches(p)) continue;
        if (p->head) {
            Job *j = p->head;
            p->head = j->next;
            if (!p->head) p->tail = NULL;
            pthread_mutex_unlock(&p->mu);
            j->fn(j->user);
            wg_free(j);
            pthread_mutex_lock(&p->mu);
            continue;
        }
        pthread_cond_wait(&p->work, &p->mu);
    }
    pthread_mutex_unlock(&p->mu);
    return NULL;
}

WgPool *wg__pool_new(int threads)
{
    WgPool *p = wg_calloc(1, sizeof *p);
    if (!p) return NULL;
    p->threads = threads < 1 ? 1 : threads;
    pthread_mutex_init(&p->mu, NULL);
    pthread_cond_init(&p->work, NULL);
    pthread_cond_init(&p->batch_done, NULL);
    p->tids = wg_calloc((size_t)p->threads, sizeof(pthread_t));
    if (!p->tids) {
        wg_free(p);
        return NULL;
    }
    for (int i = 0; i < p->threads; i++) {
        if (pthread_create(&p->tids[i], NULL, worker, p)) {
            p->threads = i;
            wg__pool_free(p);
            return NULL;
        }
    }
    return p;
}

void wg__pool_free(WgPool *p)
{
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    p->stop = true;
    pthread_cond_broadcast(&p->work);
    pthread_mutex_unlock(&p->mu);
    for (int i = 0; i < p->threads; i++) pthread_join(p->tids[i], NULL);
    while (p->head) {
        Job *j = p->head;
        p->head = j->next;
        wg_free(j);
    }
    pthread_mutex_destroy(&p->mu);
    pthread_cond_destroy(&p->work);
    pthread_cond_destroy(&p->batch_done);
    wg_free(p->tids);
    wg_free(p);
}

int wg__pool_threads(const WgPool *p)
{
    return p ? p->threads : 1;
}

int wg__pool_submit(WgPool *p, WgJobFn fn, void *user)
{
    /* Not run inline on failure: the caller holds locks the job takes (wg_render's run.mu). */
    Job *j = wg_malloc(sizeof *j);
    if (!j) return WG_ERR_NOMEM;
    j->fn = fn;
    j->user = user;
    j->next = NULL;
    pthread_mutex_lock(&p->mu);
    if (p->tail)
        p->tail->next = j;
    else
        p->head = j;
    p->tail = j;
    pthread_cond_signal(&p->work);
    pthread_mutex_unlock(&p->mu);
    return WG_OK;
}

int wg__pool_rows(WgPool *p, volatile int *cancel, int height, WgRowsFn fn, void *user)
{
    static volatile int never = 0;
    if (!cancel) cancel = &never;
    Batch b = {fn, user, height, wg_parallel_chunks(height), 0, 0, cancel, NULL};
    if (!p || p->threads <= 1 || b.chunks <= 1) {
        for (int i = 0; i < b.chunks && !*cancel; i++) {
            int y0, y1;
            chunk_rows(&b, i, &y0, &y1);
            fn(user, y0, y1);
        }
        return *cancel ? WG_ERR_CANCELLED : WG_OK;
    }
    pthread_mutex_lock(&p->mu);
    b.next_batch = p->batches;
    p->batches = &b;
    pthread_cond_broadcast(&p->work);
    while (b.next < b.chunks) {
        int i = b.next++;
        pthread_mutex_unlock(&p->mu);
        if (!*cancel) {
            int y0, y1;
            chunk_rows(&b, i, &y0, &y1);
            fn(user, y0, y1);
        }
        pthread_mutex_lock(&p->mu);
        b.done++;
    }
    while (b.done < b.chunks) pthread_cond_wait(&p->batch_done, &p->mu);
    for (Batch **pp = &p->batches; *pp; pp = &(*pp)->next_batch) {
        if (*pp == &b) {
            *pp = b.next_batch;
            break;
        }
    }
    pthread_mutex_unlock(&p->mu);
    return *cancel ? WG_ERR_CANCELLED : WG_OK;
}

int wg_parallel_rows(const WgNodeContext *ctx, int height, WgRowsFn fn, void *user)
{
    return wg__pool_rows(ctx ? ctx->pool_ : NULL, ctx ? ctx->cancel_ : NULL, height, fn, user);
}
