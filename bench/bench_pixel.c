/* SPDX-License-Identifier: MIT */
/* The pixel node against the same maths written in C. For each case, one 2048x2048 render of a
 * `pixel` node over two gray inputs (time of the node alone, from the render statistics, best of
 * several runs with the cache cleared) is compared with hand-written single-threaded C loops
 * over the same float arrays (best of the same number of runs), in the same process:
 *   fused  one loop, the expression as one would write it;
 *   split  (when given) the libm call in a loop of its own, then the rest: faster here, as the
 *          fused loop runs at half speed around sinf (SSE code interleaved with glibc's
 *          AVX/FMA sinf, and a clamp compiled to a branch);
 *   fresh  the best loop writing into a newly mmap'ed buffer each run, as the node does (the
 *          engine allocates the node's output for every render, and a 16 MiB block comes
 *          fresh from the kernel: first-touch page faults are part of the node's time).
 * The node is timed twice: with the default allocator (`node 1t`), and with a recycling
 * allocator installed through wg_set_allocator (`recycled`) so the output buffer is warm like
 * the C loop's: the difference is the engine's allocation, the rest is the row program.
 * Reported: milliseconds, ratio = node(1 thread, recycled) / best warm C loop, ratio of
 * node(1 thread, default) / C fresh, the node with all threads, and the max abs difference of
 * the node to the C loop and to a double-precision evaluation. Timing is measured, never
 * asserted.
 * Usage: bench_pixel [SIZE] [RUNS] [CASE] */
#include <wetgraph/wetgraph.h>

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

/* A recycling allocator: freed blocks of 1 MiB and more are kept (per exact size) and handed
 * out again, so image buffers stay mapped between renders. A 64-byte header holds the size. */
enum { POOL = 32, HEADER = 64 };
static struct {
    pthread_mutex_t mu;
    void *block[POOL];
    size_t size[POOL];
    int n;
} pool = {PTHREAD_MUTEX_INITIALIZER, {0}, {0}, 0};

static void *pool_alloc(size_t size, void *user)
{
    (void)user;
    size = (size + 63) & ~(size_t)63;
    pthread_mutex_lock(&pool.mu);
    for (int i = 0; i < pool.n; i++)
        if (pool.size[i] == size) {
            char *p = pool.block[i];
            pool.block[i] = pool.block[--pool.n];
            pool.size[i] = pool.size[pool.n];
            pthread_mutex_unlock(&pool.mu);
            return p + HEADER;
        }
    pthread_mutex_unlock(&pool.mu);
    char *p = aligned_alloc(64, size + HEADER);
    if (!p) return NULL;
    memcpy(p, &size, sizeof size);
    return p + HEADER;
}

static void pool_free(void *ptr, void *user)
{
    (void)user;
    if (!ptr) return;
    char *p = (char *)ptr - HEADER;
    size_t size;
    memcpy(&size, p, sizeof size);
    pthread_mutex_lock(&pool.mu);
    if (size >= (1u << 20) && pool.n < POOL) {
        pool.block[pool.n] = p;
        pool.size[pool.n++] = size;
        p = NULL;
    }
    pthread_mutex_unlock(&pool.mu);
    free(p);
}

static void pool_clear(void)
{
    for (int i = 0; i < pool.n; i++) free(pool.block[i]);
    pool.n = 0;
}

/* Extras of every case, and $time. */
static const double FREQ = 12.5, SPEED = 2, A = 0.35, B = -0.2, TIME = 1.25;

typedef struct {
    const char *name;
    const char *expr; /* XML-escaped */
    int ops;          /* varying operations per pixel */
    void (*c_loop)(const float *n, const float *m, float *out, size_t count);
    void (*c_split)(const float *n, const float *m, float *out, size_t count); /* or NULL */
    double (*ref)(double n, double m);
} Case;

/* 1: the shore-foam expression, with `v` an input (10 operations, one sin). */
static void foam_c(const float *n, const float *m, float *out, size_t count)
{
    const float freq = (float)FREQ, a = (float)A, b = (float)B, phase = (float)(SPEED * TIME);
    for (size_t i = 0; i < count; i++) {
        float t = (freq + 0.3f * n[i]) * m[i] + phase;
        float r = sinf(t) + a * m[i] * m[i] + b;
        out[i] = r < 0 ? 0 : r > 1 ? 1 : r;
    }
}
static void foam_split(const float *n, const float *m, float *out, size_t count)
{
    const float freq = (float)FREQ, a = (float)A, b = (float)B, phase = (float)(SPEED * TIME);
    for (size_t i = 0; i < count; i++) out[i] = sinf((freq + 0.3f * n[i]) * m[i] + phase);
    for (size_t i = 0; i < count; i++) {
        float r = out[i] + a * m[i] * m[i] + b;
        out[i] = r < 0 ? 0 : r > 1 ? 1 : r;
    }
}
static double foam_ref(double n, double m)
{
    double r = sin((FREQ + 0.3 * n) * m + SPEED * TIME) + A * m * m + B;
    return r < 0 ? 0 : r > 1 ? 1 : r;
}

/* 2: arithmetic only (10 operations, no libm call): the hardest case for a row program,
 * since the C compiler keeps every intermediate in registers. */
static void arith_c(const float *n, const float *m, float *out, size_t count)
{
    const float a = (float)A, b = (float)B;
    for (size_t i = 0; i < count; i++) {
        float t = n[i] * m[i] + a;
        float s = (n[i] - m[i]) * (n[i] + b);
        float l = t + (s - t) * m[i];
        float r = l * l - 0.25f * n[i];
        out[i] = r < 0 ? 0 : r > 1 ? 1 : r;
    }
}
static double arith_ref(double n, double m)
{
    double t = n * m + A, s = (n - m) * (n + B), l = t + (s - t) * m, r = l * l - 0.25 * n;
    return r < 0 ? 0 : r > 1 ? 1 : r;
}

static const Case cases[] = {
    {"foam (sin)", "clamp(sin((freq + 0.3*n) * m + speed*$time) + a*m*m + b, 0, 1)", 10, foam_c,
     foam_split, foam_ref},
    {"arithmetic", "clamp(lerp(n*m + a, (n - m)*(n + b), m) ^ 2 - 0.25*n, 0, 1)", 10, arith_c, NULL,
     arith_ref},
};

static float hashf(unsigned x)
{
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return (float)(x >> 8) / 16777216.0f;
}

static int fail(const char *what, const WgError *err)
{
    char buf[2048];
    wg_error_format(err, buf, sizeof buf);
    fprintf(stderr, "bench_pixel: %s: %s\n", what, buf);
    return 1;
}

/* Render the node `runs` times; best node time in *ms, the image in *out (caller unrefs). */
static int run_node(const Case *c, int size, int threads, int runs, const WgImage *n,
                    const WgImage *m, double *ms, WgImage **out)
{
    char xml[2048];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"%d\">\n"
             "  <input name=\"n\" type=\"gray\"/>\n  <input name=\"m\" type=\"gray\"/>\n"
             "  <node id=\"p\" type=\"pixel\" freq=\"%.17g\" speed=\"%.17g\" a=\"%.17g\" "
             "b=\"%.17g\" expr=\"%s\">\n"
             "    <in name=\"n\" from=\"$n\"/>\n    <in name=\"m\" from=\"$m\"/>\n  </node>\n"
             "  <output name=\"out\" from=\"p\" format=\"exr32\"/>\n</wetgraph>\n",
             size, FREQ, SPEED, A, B, c->expr);
    WgError err = {0};
    WgGraph *g = NULL;
    if (wg_graph_load_memory(xml, strlen(xml), "bench_pixel.wetgraph", &g, &err))
        return fail("load", &err);
    WgEngineOptions opt = {threads, 0, NULL};
    WgEngine *e = NULL;
    WgRequest *r = wg_request_new(g);
    if (!r || wg_engine_new(&opt, &e, &err) || wg_request_set_input_image(r, "n", n, &err) ||
        wg_request_set_input_image(r, "m", m, &err))
        return fail("setup", &err);
    wg_request_set_time(r, TIME);
    *ms = INFINITY;
    *out = NULL;
    for (int k = 0; k < runs; k++) {
        wg_engine_clear_cache(e);
        WgResult *res = NULL;
        if (wg_render(e, r, &res, &err)) return fail("render", &err);
        for (int i = 0; i < wg_result_stat_count(res); i++) {
            const WgNodeStat *s = wg_result_stat(res, i);
            if (!strcmp(s->id, "p") && s->ms < *ms) *ms = s->ms;
        }
        if (!*out) *out = wg_image_ref(wg_result_output_image(res, 0));
        wg_result_free(res);
    }
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
    return 0;
}

int main(int argc, char **argv)
{
    int size = argc > 1 ? atoi(argv[1]) : 2048;
    int runs = argc > 2 ? atoi(argv[2]) : 7;
    if (size < 1 || size > 16384 || runs < 1) {
        fprintf(stderr, "usage: bench_pixel [SIZE] [RUNS]\n");
        return 2;
    }
    size_t count = (size_t)size * size;
    WgImage *n = wg_image_new(size, size, 1), *m = wg_image_new(size, size, 1);
    float *nf = malloc(count * sizeof(float)), *mf = malloc(count * sizeof(float));
    float *cf = malloc(count * sizeof(float));
    if (!n || !m || !nf || !mf || !cf) return 1;
    for (int y = 0; y < size; y++)
        for (int x = 0; x < size; x++) {
            size_t i = (size_t)y * size + x;
            nf[i] = wg_image_row(n, y)[x] = hashf((unsigned)(2 * i));
            mf[i] = wg_image_row(m, y)[x] = hashf((unsigned)(2 * i + 1));
        }
    printf("pixel node vs C, %dx%d gray, best of %d runs (ms); ratio = node 1 thread "
           "(recycled) / best C, fresh = node 1 thread / C fresh\n",
           size, size, runs);
    printf("%-11s %3s %8s %8s %8s %9s %9s %6s %6s %9s %10s %10s\n", "case", "ops", "C fused",
           "C split", "C fresh", "node 1t", "recycled", "ratio", "fresh", "node all", "|node-C|",
           "|node-f64|");
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        const Case *c = &cases[k];
        if (argc > 3 && !strstr(c->name, argv[3])) continue;
        double fused_ms = INFINITY, split_ms = INFINITY, fresh_ms = INFINITY;
        for (int r = 0; r < runs; r++) {
            double t0 = now_ms();
            c->c_loop(nf, mf, cf, count);
            double t1 = now_ms();
            if (c->c_split) c->c_split(nf, mf, cf, count);
            double t2 = now_ms();
            fused_ms = fmin(fused_ms, t1 - t0);
            if (c->c_split) split_ms = fmin(split_ms, t2 - t1);
        }
        void (*best)(const float *, const float *, float *, size_t) =
            split_ms < fused_ms ? c->c_split : c->c_loop;
        for (int r = 0; r < runs; r++) {
            double t0 = now_ms();
            float *fresh = mmap(NULL, count * sizeof(float), PROT_READ | PROT_WRITE,
                                MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
            if (fresh == MAP_FAILED) return 1;
            best(nf, mf, fresh, count);
            double t1 = now_ms();
            if (memcmp(fresh, cf, count * sizeof(float))) {
                fprintf(stderr, "bench_pixel: the C variants disagree\n");
                return 1;
            }
            munmap(fresh, count * sizeof(float));
            fresh_ms = fmin(fresh_ms, t1 - t0);
        }
        double c_ms = fmin(fused_ms, split_ms);
        double node1_ms, nodeN_ms, recycled_ms;
        WgImage *o1 = NULL, *oN = NULL, *oR = NULL;
        if (run_node(c, size, 1, runs, n, m, &node1_ms, &o1) ||
            run_node(c, size, 0, runs, n, m, &nodeN_ms, &oN))
            return 1;
        wg_set_allocator(pool_alloc, pool_free, NULL);
        int rc = run_node(c, size, 1, runs, n, m, &recycled_ms, &oR);
        wg_image_unref(oR); /* allocated by the pool: released while it is installed */
        wg_set_allocator(NULL, NULL, NULL);
        pool_clear();
        if (rc) return 1;
        double err_c = 0, err_ref = 0, err_c_ref = 0;
        for (int y = 0; y < size; y++)
            for (int x = 0; x < size; x++) {
                size_t i = (size_t)y * size + x;
                double v = wg_image_row(o1, y)[x], ref = c->ref(nf[i], mf[i]);
                if (memcmp(&wg_image_row(o1, y)[x], &wg_image_row(oN, y)[x], sizeof(float))) {
                    fprintf(stderr, "bench_pixel: 1 and N threads differ at %d,%d\n", x, y);
                    return 1;
                }
                err_c = fmax(err_c, fabs(v - cf[i]));
                err_ref = fmax(err_ref, fabs(v - ref));
                err_c_ref = fmax(err_c_ref, fabs(cf[i] - ref));
            }
        char split[16] = "-";
        if (c->c_split) snprintf(split, sizeof split, "%.2f", split_ms);
        printf("%-11s %3d %8.2f %8s %8.2f %9.2f %9.2f %6.2f %6.2f %9.2f %10.3g %10.3g  (C vs "
               "f64: %.3g)\n",
               c->name, c->ops, fused_ms, split, fresh_ms, node1_ms, recycled_ms,
               recycled_ms / c_ms, node1_ms / fresh_ms, nodeN_ms, err_c, err_ref, err_c_ref);
        wg_image_unref(o1);
        wg_image_unref(oN);
    }
    wg_image_unref(n);
    wg_image_unref(m);
    free(nf);
    free(mf);
    free(cf);
    return 0;
}
