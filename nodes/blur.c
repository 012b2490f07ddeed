/* SPDX-License-Identifier: MIT */
/* `blur`: Gaussian blur with wrap-around edges. `sigma` is a length (docs/format.md "Lengths"):
 * σ_px = sigma · width / 256 pixels along both axes. Two qualities:
 *
 * exact: the reference. Separable; the kernel exp(-d²/2σ²) is sampled at integer offsets out to
 * ceil(6σ) (the dropped tail weighs < 2e-9 of the total), folded modulo the image side so kernels
 * wider than the image wrap correctly, and normalised to sum 1, so a constant image stays exactly
 * constant. Weights and sums are double, rounded once to float. When σ ≥ the side, the periodic
 * Gaussian differs from the mean by < 3e-9 relative and the mean is used. Cost O(σ) per pixel.
 *
 * fast (default): the same periodic Gaussian at a cost nearly independent of σ. Below
 * DIRECT_MAX_SIGMA pixels it is the same folded, normalised kernel (truncated at ceil(6σ)) summed
 * directly in float, separably. From there on it is a convolution by the DFT, which is periodic
 * by construction, so the wrap is exact: each row goes through a real-to-complex FFT (FFTW, single
 * precision), each column of that half spectrum through a complex FFT and back after being
 * multiplied by the exact transform of the sampled periodic Gaussian, and each row back through
 * a complex-to-real FFT. The transform is computed analytically by Poisson summation,
 * Ĝ(k) = Σ_j exp(-2π²σ²(k/n + j)²) / Σ_j exp(-2π²σ²j²), so Ĝ(0) = 1 and constants stay constant.
 * Spectrum columns whose factor is below 1e-10 are neither kept nor transformed (they weigh
 * < 1e-7 of the largest |value| in all), which is what makes large σ cheaper: at 2048² σ = 16 px
 * keeps 139 of 1025 columns, σ = 256 px keeps 9. Every 1D transform runs on one thread with a
 * plan made once per kind and length (FFTW_ESTIMATE, no wisdom, under a mutex) and executed on
 * 64-byte aligned buffers; the rows and the column blocks are split with wg_parallel_rows, so the
 * pixels are bit-identical for any thread count. Error against exact: float rounding of the
 * sums and FFTs, a few 1e-7 of the largest |value|: measured max |fast − exact| 2.4e-7 on random
 * [0, 1] images from σ = 0.5 px to the image size (sizes 97×61, 320×200, 40×33 colour, 1×150,
 * 150×1; 3.0e-7 at 2048²; the bound asked is 1e-4), and 2.5e-7 relative to the peak on [0, 1e6]
 * data (tests/nodes/test_blur.c). A constant image stays constant within 1e-6 relative. Working
 * memory: the kept columns of the half spectrum (at most ≈ one float plane), one channel at a time.
 * The crossover DIRECT_MAX_SIGMA = 3 px is where the two paths cost the same at 2048².
 *
 * All channels are blurred, alpha included; σ = 0 copies. NaN and infinities spread over the
 * whole image in the FFT path (over the kernel's reach in the others).
 *
 * Speed at 2048² gray, 2 threads (bench/bench_blur --reps 15, release, ms of the node alone; fast
 * the median of 15, exact one run; the shared 2-core VM), and max |fast − exact| over the image:
 *   σ px       1       2       3       4      16      64     256
 *   fast    7.75   11.33   14.14   14.34   11.01   10.17   10.00
 *   exact   51.6    81.8   116.8   144.4   482.7  1915.0  5796.8
 *   error  2.4e-7  3.0e-7  3.0e-7  3.0e-7  2.4e-7  2.4e-7  1.8e-7
 * Some 6 ms of each fast time are the first-touch page faults of the fresh 16 MB output (as
 * measured for the pixel node, bench/README.md). When the other jobs on the VM take the cores,
 * fast medians rise to 12-20 ms at σ ≤ 2 px, 17-27 ms at 16..256 px and 25-48 ms at 3..4 px (the
 * FFT's costliest range: most spectrum columns kept). */
#include "gaussian.h"
#include "hot.h"
#include "wetgraph/node.h"

#include <fftw3.h>
#include <math.h>
#include <pthread.h>
#include <string.h>

typedef struct {
    float sigma;
    int quality;
} BlurParams;

enum { QUALITY_FAST, QUALITY_EXACT };
static const char *const quality_values[] = {"fast", "exact", NULL};

static const WgParamSpec blur_params[] = {
    WG_PARAM_FLOAT_UI(BlurParams, sigma,
                      "Standard deviation, a length: pixels of a 256-wide image (× width/256)", 1.0,
                      0.0, 16384.0, 0, 64),
    WG_PARAM_ENUM(BlurParams, quality, "fast (FFT, error < 1e-6) or exact (float64 reference)",
                  QUALITY_FAST, quality_values),
    WG_PARAM_END,
};
static const WgPortSpec blur_in[] = {WG_PORT("source", WG_ANY), WG_PORT_END};
static const WgPortSpec blur_out[] = {WG_PORT("output", WG_ANY), WG_PORT_END};

/* Below this σ in pixels the direct sum is faster than the FFT at 2048² (bench/bench_blur:
 * direct 11 ms at σ = 2, 14.6 at 3, 15.4 at 4; FFT 16.6, 14.0, 14.8). */
#define DIRECT_MAX_SIGMA 3.0

static double blur_sigma_px(const WgNodeContext *ctx)
{
    const BlurParams *p = ctx->params;
    return (double)p->sigma * ctx->width / 256.0;
}

/* ---- exact ---------------------------------------------------------------------------- */

typedef struct {
    int taps; /* kernel covers offsets -radius .. taps-1-radius */
    int radius;
    double *weight; /* taps entries; NULL means "use the mean" */
} Kernel;

static int kernel_build(Kernel *k, double sigma, int n)
{
    k->weight = NULL;
    if (sigma >= n) {
        k->taps = 0;
        return WG_OK;
    }
    int r = (int)ceil(6 * sigma);
    /* fold offsets modulo n: at most n distinct taps, centred */
    int taps = 2 * r + 1 < n ? 2 * r + 1 : n;
    int radius = taps == n ? n / 2 : r;
    double *acc = wg_calloc((size_t)taps, sizeof(double));
    k->weight = wg_malloc(sizeof(double) * (size_t)taps);
    if (!acc || !k->weight) {
        wg_free(acc);
        wg_free(k->weight);
        k->weight = NULL;
        return WG_ERR_NOMEM;
    }
    double sum = 0;
    for (int d = -r; d <= r; d++) {
        double w = exp(-0.5 * d * d / (sigma * sigma));
        int slot = ((d + radius) % n + n) % n; /* offset d lands on tap (d + radius) mod n */
        acc[slot % taps] += w;
        sum += w;
    }
    for (int t = 0; t < taps; t++) k->weight[t] = acc[t] / sum;
    wg_free(acc);
    k->taps = taps;
    k->radius = radius;
    return WG_OK;
}

typedef struct {
    const WgImage *in;
    WgImage *tmp, *out;
    Kernel kx, ky;
} ExactJob;

static void exact_horizontal(void *user, int y0, int y1)
{
    const ExactJob *j = user;
    int w = j->in->width, c = j->in->channels;
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y);
        float *d = wg_image_row(j->tmp, y);
        if (!j->kx.weight) {
            double mean[4] = {0};
            for (int x = 0; x < w; x++)
                for (int k = 0; k < c; k++) mean[k] += s[x * c + k];
            for (int x = 0; x < w; x++)
                for (int k = 0; k < c; k++) d[x * c + k] = (float)(mean[k] / w);
            continue;
        }
        for (int x = 0; x < w; x++) {
            double acc[4] = {0, 0, 0, 0};
            int sx = x - j->kx.radius;
            sx = ((sx % w) + w) % w;
            for (int t = 0; t < j->kx.taps; t++) {
                const float *p = s + (size_t)sx * (size_t)c;
                double wt = j->kx.weight[t];
                for (int k = 0; k < c; k++) acc[k] += wt * p[k];
                if (++sx == w) sx = 0;
            }
            for (int k = 0; k < c; k++) d[x * c + k] = (float)acc[k];
        }
    }
}

static void exact_vertical(void *user, int y0, int y1)
{
    const ExactJob *j = user;
    int h = j->in->height, n = j->in->width * j->in->channels;
    for (int y = y0; y < y1; y++) {
        float *d = wg_image_row(j->out, y);
        if (!j->ky.weight) {
            for (int i = 0; i < n; i++) {
                double m = 0;
                for (int yy = 0; yy < h; yy++) m += wg_image_row(j->tmp, yy)[i];
                d[i] = (float)(m / h);
            }
            continue;
        }
        /* accumulate in double, a block of columns at a time */
        for (int i0 = 0; i0 < n; i0 += 256) {
            int len = n - i0 < 256 ? n - i0 : 256;
            double acc[256] = {0};
            int sy = ((y - j->ky.radius) % h + h) % h;
            for (int t = 0; t < j->ky.taps; t++) {
                const float *s = wg_image_row(j->tmp, sy) + i0;
                double wt = j->ky.weight[t];
                for (int i = 0; i < len; i++) acc[i] += wt * s[i];
                if (++sy == h) sy = 0;
            }
            for (int i = 0; i < len; i++) d[i0 + i] = (float)acc[i];
        }
    }
}

static int exact_eval(WgNodeContext *ctx, double sigma, WgError *err)
{
    const WgImage *in = ctx->inputs[0];
    ExactJob j = {in, NULL, ctx->outputs[0], {0}, {0}};
    int rc = kernel_build(&j.kx, sigma, in->width);
    if (!rc) rc = kernel_build(&j.ky, sigma, in->height);
    if (!rc && !(j.tmp = wg_scratch_image(ctx, in->width, in->height, in->channels)))
        rc = WG_ERR_NOMEM;
    if (rc) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    if (!rc) rc = wg_parallel_rows(ctx, in->height, exact_horizontal, &j);
    if (!rc) rc = wg_parallel_rows(ctx, in->height, exact_vertical, &j);
    wg_image_unref(j.tmp);
    wg_free(j.kx.weight);
    wg_free(j.ky.weight);
    return rc;
}

/* ---- fast: direct sum for small σ ----------------------------------------------------- */

/* The exact path's folded kernel in float; the mean (n equal taps) when σ reaches the side. */
typedef struct {
    int taps, radius;
    float *weight;
} FloatKernel;

static int float_kernel_build(FloatKernel *f, double sigma, int n)
{
    Kernel k;
    if (kernel_build(&k, sigma, n)) return WG_ERR_NOMEM;
    f->taps = k.weight ? k.taps : n;
    f->radius = k.weight ? k.radius : n / 2;
    f->weight = wg_malloc(sizeof(float) * (size_t)f->taps);
    if (!f->weight) {
        wg_free(k.weight);
        return WG_ERR_NOMEM;
    }
    for (int t = 0; t < f->taps; t++) f->weight[t] = k.weight ? (float)k.weight[t] : 1.0f / n;
    wg_free(k.weight);
    return WG_OK;
}

typedef struct {
    const WgImage *in;
    WgImage *out;
    FloatKernel kx, ky;
    int failed; /* a worker could not allocate its buffers (written atomically) */
} DirectJob;

/* d[i] = Σ_t w[t] · s[i + t·step], i < n, taps summed in order. */
HOT static void sum_taps(float *restrict d, const float *restrict s, int n, const float *w,
                         int taps, int step)
{
    for (int i = 0; i < n; i++) d[i] = w[0] * s[i];
    for (int t = 1; t < taps; t++) {
        const float *st = s + (size_t)t * (size_t)step;
        float wt = w[t];
        for (int i = 0; i < n; i++) d[i] += wt * st[i];
    }
}

/* d[i] += w · s[i] */
HOT static void add_scaled(float *restrict d, const float *restrict s, int n, float w)
{
    for (int i = 0; i < n; i++) d[i] += w * s[i];
}

/* Each output row on its own: the vertical sum of its source rows into a wrapped row buffer,
 * then the horizontal sum of that buffer, so no intermediate image is needed. */
static void direct_rows(void *user, int y0, int y1)
{
    DirectJob *j = user;
    int w = j->in->width, h = j->in->height, c = j->in->channels;
    int taps = j->kx.taps, r = j->kx.radius;
    size_t n = (size_t)w * (size_t)c;
    /* ext[x] is pixel (x - r) mod w of the vertically blurred row, x < w + taps - 1 */
    float *ext = wg_malloc(sizeof(float) * (size_t)(w + taps) * (size_t)c);
    if (!ext) {
        __atomic_store_n(&j->failed, 1, __ATOMIC_RELAXED);
        return;
    }
    float *mid = ext + (size_t)r * c; /* pixel 0 */
    for (int y = y0; y < y1; y++) {
        int sy = ((y - j->ky.radius) % h + h) % h;
        const float *s = wg_image_row(j->in, sy);
        for (size_t i = 0; i < n; i++) mid[i] = j->ky.weight[0] * s[i];
        for (int t = 1; t < j->ky.taps; t++) {
            if (++sy == h) sy = 0;
            add_scaled(mid, wg_image_row(j->in, sy), (int)n, j->ky.weight[t]);
        }
        /* wrap: r pixels before pixel 0 and taps-1-r after pixel w-1 (each < w + 1 copies) */
        for (int x = 0; x < r; x++)
            memcpy(ext + (size_t)x * c, mid + (size_t)(((x - r) % w + w) % w) * c,
                   sizeof(float) * (size_t)c);
        for (int x = r + w; x < w + taps - 1; x++)
            memcpy(ext + (size_t)x * c, mid + (size_t)((x - r) % w) * c, sizeof(float) * (size_t)c);
        sum_taps(wg_image_row(j->out, y), ext, (int)n, j->kx.weight, taps, c);
    }
    wg_free(ext);
}

static int direct_eval(WgNodeContext *ctx, const WgImage *in, WgImage *out, double sigma,
                       WgError *err)
{
    DirectJob j = {in, out, {0}, {0}, 0};
    int rc = float_kernel_build(&j.kx, sigma, in->width);
    if (!rc) rc = float_kernel_build(&j.ky, sigma, in->height);
    if (!rc) rc = wg_parallel_rows(ctx, in->height, direct_rows, &j);
    if (!rc && j.failed) rc = WG_ERR_NOMEM;
    if (rc == WG_ERR_NOMEM) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    wg_free(j.kx.weight);
    wg_free(j.ky.weight);
    return rc;
}

/* ---- fast: FFT convolution ------------------------------------------------------------ */

enum { PLAN_R2C, PLAN_C2R, PLAN_FORWARD, PLAN_BACKWARD };

/* Plans live for the life of the process, one per kind and length. FFTW's planner is not
 * thread-safe, hence the lock; executing a plan on new arrays is. The plans are made on
 * fftwf_malloc'd (SIMD-aligned) arrays and executed only on arrays aligned to 64 bytes, as
 * FFTW's new-array execute requires. */
typedef struct PlanEntry {
    int kind, n;
    fftwf_plan plan;
    struct PlanEntry *next;
} PlanEntry;

static pthread_mutex_t plan_lock = PTHREAD_MUTEX_INITIALIZER;
static PlanEntry *plan_list;

static fftwf_plan plan_get(int kind, int n)
{
    pthread_mutex_lock(&plan_lock);
    PlanEntry *e = plan_list;
    while (e && (e->kind != kind || e->n != n)) e = e->next;
    fftwf_plan plan = e ? e->plan : NULL;
    if (!e && (e = wg_malloc(sizeof *e))) {
        float *a = fftwf_malloc(sizeof(float) * 2 * ((size_t)n + 1));
        float *b = fftwf_malloc(sizeof(float) * 2 * ((size_t)n + 1));
        fftwf_complex *ca = (fftwf_complex *)a, *cb = (fftwf_complex *)b;
        unsigned flags = FFTW_ESTIMATE;
        if (a && b) {
            if (kind == PLAN_R2C)
                plan = fftwf_plan_dft_r2c_1d(n, a, cb, flags);
            else if (kind == PLAN_C2R)
                plan = fftwf_plan_dft_c2r_1d(n, ca, b, flags | FFTW_DESTROY_INPUT);
            else
                plan = fftwf_plan_dft_1d(
                    n, ca, ca, kind == PLAN_FORWARD ? FFTW_FORWARD : FFTW_BACKWARD, flags);
        }
        fftwf_free(a);
        fftwf_free(b);
        if (plan) {
            *e = (PlanEntry){kind, n, plan, plan_list};
            plan_list = e;
        } else
            wg_free(e);
    }
    pthread_mutex_unlock(&plan_lock);
    return plan;
}

/* Fourier factor of the normalised, sampled periodic Gaussian on a ring of n pixels, k < n. */
static void gaussian_spectrum(double *g, int n, double sigma)
{
    /* Poisson summation: Σ_t exp(-t²/2σ²) e^{-2πikt/n} = σ√(2π) Σ_j exp(-2π²σ²(k/n + j)²). For
     * 0 ≤ k/n < 1 the terms left out are below exp(-2π²σ²(J+1)²) < 4e-15 (e^-33) of the total,
     * far less for the σ ≥ DIRECT_MAX_SIGMA this is used at. The same j range for k = 0 makes
     * the DC factor exactly 1. */
    int J = 2 + (int)ceil(1.3 / sigma);
    double a = 2 * M_PI * M_PI * sigma * sigma, zero = 0;
    for (int j = -J - 1; j <= J; j++) zero += exp(-a * j * j);
    for (int k = 0; k < n; k++) {
        double f = (double)k / n, sum = 0;
        for (int j = -J - 1; j <= J; j++) sum += exp(-a * (f + j) * (f + j));
        g[k] = sum / zero;
    }
}

/* Complex numbers per row of the kept spectrum and per column buffer, rounded up to 64 bytes. */
static size_t spectrum_stride(int kmax)
{
    return ((size_t)kmax + 7) & ~(size_t)7;
}
static size_t column_stride(int h)
{
    return ((size_t)h + 7) & ~(size_t)7;
}
enum { COLUMN_BLOCK = 8 }; /* spectrum columns transformed per work item */
#define NEGLIGIBLE 1e-10   /* spectrum columns with a smaller factor are dropped */

static void *aligned_alloc64(size_t bytes, void **raw)
{
    *raw = wg_malloc(bytes + 64);
    if (!*raw) return NULL;
    return (void *)(((uintptr_t)*raw + 63) & ~(uintptr_t)63);
}

typedef struct {
    const WgImage *in;
    WgImage *out;
    int channel, kmax; /* spectrum columns [0, kmax) are kept, the rest zeroed */
    fftwf_plan r2c, c2r, fwd, bwd;
    fftwf_complex *spec; /* h rows of sstride: spectrum columns [0, kmax) */
    size_t sstride;
    const double *gx, *gy; /* factors along x (w/2+1) and y (h) */
    int failed;
} FftJob;

/* A row's buffers: the real row and its whole half spectrum, both 64-byte aligned. */
static float *row_buffers(int w, fftwf_complex **full, void **raw)
{
    size_t real = ((size_t)w + 15) & ~(size_t)15;
    float *row =
        aligned_alloc64(sizeof(float) * real + sizeof(fftwf_complex) * ((size_t)w / 2 + 1), raw);
    if (row) *full = (fftwf_complex *)(row + real);
    return row;
}

static void fft_rows_forward(void *user, int y0, int y1)
{
    FftJob *j = user;
    int w = j->in->width, c = j->in->channels;
    void *raw;
    fftwf_complex *full;
    float *row = row_buffers(w, &full, &raw);
    if (!row) {
        __atomic_store_n(&j->failed, 1, __ATOMIC_RELAXED);
        return;
    }
    for (int y = y0; y < y1; y++) {
        const float *s = wg_image_row(j->in, y) + j->channel;
        for (int x = 0; x < w; x++) row[x] = s[(size_t)x * c];
        fftwf_execute_dft_r2c(j->r2c, row, full);
        memcpy(j->spec + (size_t)y * j->sstride, full, sizeof(fftwf_complex) * (size_t)j->kmax);
    }
    wg_free(raw);
}

static void fft_columns(void *user, int b0, int b1)
{
    FftJob *j = user;
    int h = j->in->height, w = j->in->width;
    size_t cs = column_stride(h);
    double scale = 1.0 / ((double)w * h);
    void *raw;
    fftwf_complex *col = aligned_alloc64(sizeof(fftwf_complex) * cs * COLUMN_BLOCK, &raw);
    if (!col) {
        __atomic_store_n(&j->failed, 1, __ATOMIC_RELAXED);
        return;
    }
    for (int b = b0; b < b1; b++) {
        int k0 = b * COLUMN_BLOCK, nk = j->kmax - k0 < COLUMN_BLOCK ? j->kmax - k0 : COLUMN_BLOCK;
        for (int y = 0; y < h; y++) {
            const fftwf_complex *s = j->spec + (size_t)y * j->sstride + k0;
            for (int i = 0; i < nk; i++) {
                col[(size_t)i * cs + y][0] = s[i][0];
                col[(size_t)i * cs + y][1] = s[i][1];
            }
        }
        for (int i = 0; i < nk; i++) {
            fftwf_complex *v = col + (size_t)i * cs;
            fftwf_execute_dft(j->fwd, v, v);
            double gx = j->gx[k0 + i] * scale;
            for (int ky = 0; ky < h; ky++) {
                float m = (float)(gx * j->gy[ky]);
                v[ky][0] *= m;
                v[ky][1] *= m;
            }
            fftwf_execute_dft(j->bwd, v, v);
        }
        for (int y = 0; y < h; y++) {
            fftwf_complex *d = j->spec + (size_t)y * j->sstride + k0;
            for (int i = 0; i < nk; i++) {
                d[i][0] = col[(size_t)i * cs + y][0];
                d[i][1] = col[(size_t)i * cs + y][1];
            }
        }
    }
    wg_free(raw);
}

static void fft_rows_inverse(void *user, int y0, int y1)
{
    FftJob *j = user;
    int w = j->in->width, c = j->in->channels;
    void *raw;
    fftwf_complex *full;
    float *row = row_buffers(w, &full, &raw);
    if (!row) {
        __atomic_store_n(&j->failed, 1, __ATOMIC_RELAXED);
        return;
    }
    for (int y = y0; y < y1; y++) {
        memcpy(full, j->spec + (size_t)y * j->sstride, sizeof(fftwf_complex) * (size_t)j->kmax);
        memset(full + j->kmax, 0, sizeof(fftwf_complex) * (size_t)(w / 2 + 1 - j->kmax));
        fftwf_execute_dft_c2r(j->c2r, full, row);
        float *d = wg_image_row(j->out, y) + j->channel;
        for (int x = 0; x < w; x++) d[(size_t)x * c] = row[x];
    }
    wg_free(raw);
}

/* Spectrum columns [0, kmax) of a row of w pixels whose factor is not negligible. */
static int kept_columns(const double *gx, int w)
{
    int kmax = w / 2 + 1;
    while (kmax > 1 && gx[kmax - 1] < NEGLIGIBLE) kmax--;
    return kmax;
}

/* An upper bound of kept_columns without computing the factors (for scratch_bytes): the factor
 * at frequency f = k/w is ≥ exp(-2π²σ²f²), below 1e-10 beyond f = 1.08/σ. */
static int kept_columns_bound(int w, double sigma)
{
    double k = ceil(1.1 / sigma * w) + 2;
    return k < w / 2 + 1 ? (int)k : w / 2 + 1;
}

static int fft_eval(WgNodeContext *ctx, const WgImage *in, WgImage *out, double sigma, WgError *err)
{
    int w = in->width, h = in->height;
    FftJob j = {.in = in, .out = out};
    j.r2c = plan_get(PLAN_R2C, w);
    j.c2r = plan_get(PLAN_C2R, w);
    j.fwd = plan_get(PLAN_FORWARD, h);
    j.bwd = plan_get(PLAN_BACKWARD, h);
    if (!j.r2c || !j.c2r || !j.fwd || !j.bwd)
        return wg_error_set(err, WG_ERR_NOMEM, NULL, "cannot plan FFTs of %d and %d points", w, h);
    double *gx = wg_malloc(sizeof(double) * ((size_t)w + 1)),
           *gy = wg_malloc(sizeof(double) * (size_t)h);
    size_t spec_bytes = 0;
    int rc = gx && gy ? WG_OK : WG_ERR_NOMEM;
    if (!rc) {
        gaussian_spectrum(gx, w, sigma);
        gaussian_spectrum(gy, h, sigma);
        j.gx = gx;
        j.gy = gy;
        j.kmax = kept_columns(gx, w);
        j.sstride = spectrum_stride(j.kmax);
        spec_bytes = sizeof(fftwf_complex) * j.sstride * (size_t)h;
        j.spec = wg_scratch_alloc(ctx, spec_bytes);
        if (!j.spec) rc = WG_ERR_NOMEM;
    }
    int blocks = (j.kmax + COLUMN_BLOCK - 1) / COLUMN_BLOCK;
    for (j.channel = 0; !rc && j.channel < in->channels; j.channel++) {
        rc = wg_parallel_rows(ctx, h, fft_rows_forward, &j);
        if (!rc && j.failed) rc = WG_ERR_NOMEM;
        if (!rc) rc = wg_parallel_rows(ctx, blocks, fft_columns, &j);
        if (!rc && j.failed) rc = WG_ERR_NOMEM;
        if (!rc) rc = wg_parallel_rows(ctx, h, fft_rows_inverse, &j);
        if (!rc && j.failed) rc = WG_ERR_NOMEM;
    }
    if (rc == WG_ERR_NOMEM) rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    wg_scratch_free(ctx, j.spec, spec_bytes);
    wg_free(gx);
    wg_free(gy);
    return rc;
}

/* ---- dispatch ------------------------------------------------------------------------- */

int wg__gaussian_fast(WgNodeContext *ctx, const WgImage *in, WgImage *out, double sigma_px,
                      WgError *err)
{
    if (sigma_px == 0) {
        for (int y = 0; y < in->height; y++)
            memcpy(wg_image_row(out, y), wg_image_row(in, y),
                   sizeof(float) * (size_t)in->width * (size_t)in->channels);
        return WG_OK;
    }
    if (sigma_px < DIRECT_MAX_SIGMA) return direct_eval(ctx, in, out, sigma_px, err);
    return fft_eval(ctx, in, out, sigma_px, err);
}

/* direct: the kernels (its row buffers are a few rows); FFT: the kept part of the half
 * spectrum, the factors and one column block. */
size_t wg__gaussian_fast_scratch(int width, int height, double sigma_px)
{
    size_t w = (size_t)width, h = (size_t)height;
    if (sigma_px == 0) return 0;
    if (sigma_px < DIRECT_MAX_SIGMA) return (sizeof(double) + sizeof(float)) * 2 * (w + h);
    size_t kept = spectrum_stride(kept_columns_bound(width, sigma_px));
    return sizeof(fftwf_complex) * (kept * h + column_stride(height) * COLUMN_BLOCK) +
           sizeof(double) * (w + 1 + h) + 64;
}

static int blur_eval(WgNodeContext *ctx, WgError *err)
{
    const BlurParams *p = ctx->params;
    double sigma = blur_sigma_px(ctx);
    if (p->quality == QUALITY_EXACT && sigma > 0) return exact_eval(ctx, sigma, err);
    return wg__gaussian_fast(ctx, ctx->inputs[0], ctx->outputs[0], sigma, err);
}

/* exact: the horizontal pass's image and the kernels; fast: as wg__gaussian_fast needs. */
static size_t blur_scratch(const WgNodeContext *ctx)
{
    const BlurParams *p = ctx->params;
    double sigma = blur_sigma_px(ctx);
    if (sigma == 0) return 0;
    int c = ctx->input_channels[0] == 4 ? 4 : 1;
    size_t w = (size_t)ctx->width, h = (size_t)ctx->height;
    if (p->quality == QUALITY_EXACT)
        return wg_image_bytes_for(ctx->width, ctx->height, c) + sizeof(double) * 2 * (w + h);
    return wg__gaussian_fast_scratch(ctx->width, ctx->height, sigma);
}

const WgNodeType wg_node_blur = {
    .name = "blur",
    .summary = "Gaussian blur with wrap-around edges (fast FFT or exact reference)",
    .category = "filter",
    .doc = "`sigma` is the standard deviation as a length: pixels of a 256-pixel-wide image, "
           "so σ = sigma × width / 256 pixels along both axes (docs/format.md, Lengths). "
           "`exact`: separable, kernel sampled to ±ceil(6σ) (dropped tail < 2e-9), folded modulo "
           "the image side and normalised in float64, so it tiles and keeps constants exact; "
           "σ ≥ the image side gives the mean (error < 3e-9); cost O(σ) per pixel. `fast`: the "
           "same periodic Gaussian, summed directly in float below σ = 3 pixels and by FFT "
           "convolution (FFTW, exact periodic kernel spectrum) above, at a cost nearly "
           "independent of σ; max error against `exact` ~1e-7 of the largest |value| (< 1e-6). "
           "σ = 0 copies.",
    .params = blur_params,
    .params_size = sizeof(BlurParams),
    .inputs = blur_in,
    .outputs = blur_out,
    .flags = WG_NODE_NEIGHBOURHOOD,
    .eval = blur_eval,
    .scratch_bytes = blur_scratch,
};
