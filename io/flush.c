/* SPDX-License-Identifier: MIT */
/* Staged temporaries flushed to the disk on a thread of their own. fsync waits milliseconds for
 * the file system's journal; on the worker that wrote the file it would leave that core idle
 * while the render still has work for it. A write set hands each temporary over as soon as it
 * is written and its commit waits for the flushes before renaming anything into place, so a
 * renamed file is still complete on the disk first.
 *
 * One thread for the process, started on first use, takes the temporaries in the order they
 * come. Each waits there with its file open, so at most WG_FLUSH_QUEUE_MAX wait at once: beyond,
 * the writer flushes its file itself (a set of thousands of files must not run the process out
 * of descriptors). A child process made by fork has no such thread: what was handed over and not
 * flushed when it forked comes back to the child as not flushed, for its writer to flush itself. */
#include "wgio.h"

#include "wetgraph/image.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <unistd.h>

struct WgFlush {
    WgFlush *next;
    int fd;       /* the temporary, open: a flush does not depend on its name (-1 once closed) */
    bool done;    /* flushed (error 0) or failed (error: its errno), or handed back (-1) */
    bool dropped; /* no longer wanted: whoever finishes with it last frees it */
    int error;
};

static pthread_mutex_t mu = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t work = PTHREAD_COND_INITIALIZER, finished = PTHREAD_COND_INITIALIZER;
static WgFlush *head, *tail, *current; /* the queue, and the one being flushed */
static int queued;                     /* in the queue: each holds its temporary open */
static bool running, atfork_set, paused;
static atomic_long flushed; /* temporaries the thread flushed, for tests */

static void release(WgFlush *f)
{
    if (f->fd >= 0) close(f->fd);
    wg_free(f);
}

/* With the lock held: f is done; its waiter is woken, or it is freed when no one waits. */
static void finish(WgFlush *f, int error)
{
    f->done = true;
    f->error = error;
    if (f->dropped)
        release(f);
    else
        pthread_cond_broadcast(&finished);
}

static void *flusher(void *arg)
{
    (void)arg;
    pthread_mutex_lock(&mu);
    for (;;) {
        while (!head || paused) pthread_cond_wait(&work, &mu);
        WgFlush *f = current = head;
        head = f->next;
        if (!head) tail = NULL;
        queued--;
        bool wanted = !f->dropped;
        pthread_mutex_unlock(&mu);
        int error = 0;
        if (wanted) {
            if (fsync(f->fd) != 0) error = errno;
            atomic_fetch_add(&flushed, 1);
        }
        /* the descriptor leaves the record under the lock, so that a fork never copies a record
         * naming a descriptor already closed (its number could be another file's by then) */
        pthread_mutex_lock(&mu);
        int fd = f->fd;
        f->fd = -1;
        current = NULL;
        finish(f, error);
        pthread_mutex_unlock(&mu);
        close(fd);
        pthread_mutex_lock(&mu);
    }
    return NULL;
}

/* fork: the lock is held across it, so the child sees a whole queue; there it has no thread,
 * so every temporary not yet flushed is handed back. */
static void before_fork(void)
{
    pthread_mutex_lock(&mu);
}

static void after_fork_parent(void)
{
    pthread_mutex_unlock(&mu);
}

static void after_fork_child(void)
{
    if (current) finish(current, -1);
    for (WgFlush *f = head, *next; f; f = next) {
        next = f->next;
        finish(f, -1);
    }
    head = tail = current = NULL;
    queued = 0;
    running = paused = false;
    pthread_mutex_unlock(&mu);
}

static bool start_locked(void)
{
    if (running) return true;
    if (!atfork_set) {
        if (pthread_atfork(before_fork, after_fork_parent, after_fork_child)) return false;
        atfork_set = true;
    }
    pthread_attr_t at;
    pthread_t t;
    if (pthread_attr_init(&at)) return false;
    pthread_attr_setdetachstate(&at, PTHREAD_CREATE_DETACHED);
    pthread_attr_setstacksize(&at, 64 * 1024);
    running = pthread_create(&t, &at, flusher, NULL) == 0;
    pthread_attr_destroy(&at);
    return running;
}

WgFlush *wg__flush_start(const char *temp)
{
    WgFlush *f = wg_calloc(1, sizeof *f);
    if (!f) return NULL;
    if ((f->fd = open(temp, O_RDONLY | O_CLOEXEC)) < 0) {
        wg_free(f);
        return NULL;
    }
    pthread_mutex_lock(&mu);
    bool ok = queued < WG_FLUSH_QUEUE_MAX && start_locked();
    if (ok) {
        queued++;
        if (tail)
            tail->next = f;
        else
            head = f;
        tail = f;
        pthread_cond_signal(&work);
    }
    pthread_mutex_unlock(&mu);
    if (!ok) release(f);
    return ok ? f : NULL;
}

int wg__flush_wait(WgFlush *f)
{
    pthread_mutex_lock(&mu);
    while (!f->done) pthread_cond_wait(&finished, &mu);
    int error = f->error;
    pthread_mutex_unlock(&mu);
    release(f);
    return error;
}

void wg__flush_drop(WgFlush *f)
{
    if (!f) return;
    pthread_mutex_lock(&mu);
    bool done = f->done;
    f->dropped = true;
    pthread_mutex_unlock(&mu);
    if (done) release(f);
}

void wg__flush_pause(bool on)
{
    pthread_mutex_lock(&mu);
    paused = on;
    pthread_cond_broadcast(&work);
    pthread_mutex_unlock(&mu);
}

long wg__flush_count(void)
{
    return atomic_load(&flushed);
}
