/* SPDX-License-Identifier: MIT */
/* Peer benchmark of `blur` and `distance` against OpenCV, in one process on the same data, with
 * each result's max |error| against a float64 reference computed here. At N×N it renders the
 * inputs with wetgraph (per-pixel white noise in [0, 1] for blur; perlin blobs thresholded at 0.5
 * and white noise through a 0.9999 threshold, sparse seeds, for distance) and times:
 *   blur σ = 2, 16, 64, 256 px, wrap: wetgraph quality fast and exact (the node's own time from
 *   the engine's stats, output allocation included) and cv::GaussianBlur(CV_32F, ksize 0 = OpenCV's
 *   own choice for float, 2·round(4σ)+1, a fresh output each time) on a copy padded by
 *   copyMakeBorder(BORDER_WRAP), cropped after: OpenCV's filters refuse BORDER_WRAP itself.
 *   distance to the nearest site (mask >= 0.5), not periodic: wetgraph `distance` mode pixels
 *   wrap false and cv::distanceTransform(DIST_L2, DIST_MASK_PRECISE, CV_32F) on the 8-bit mask
 *   (0 at sites; the conversion is not timed).
 * References, all float64: blur, the circular convolution by the sampled Gaussian exp(-d²/2σ²)
 * taken out to 10σ, folded modulo N and normalised to sum 1, done by a double-precision FFT
 * (FFTW) with the kernel's exact DFT; distance, a double Felzenszwalb-Huttenlocher EDT written
 * here. --check verifies both against brute force (direct double convolution, all-pairs distance)
 * at 128². Times are medians of R runs (3 when one run takes over 2 s, 1 over 10 s). With --dir,
 * the inputs (float32 raw, row-major N×N) and references (float64 raw) are written there for
 * bench/peer_scipy.py.
 *   peer_opencv [--size N] [--threads T] [--reps R] [--dir DIR] [--check]
 * Output: TSV "size op case sigma_px method runs median_ms min_ms max_abs_error". */
#include <wetgraph/wetgraph.h>

#include <fftw3.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

static int g_size = 2048, g_threads = 2, g_reps = 5;
static std::string g_dir;
static WgEngine *g_engine;

[[noreturn]] static void die(const char *what, const char *msg)
{
    fprintf(stderr, "peer_opencv: %s: %s\n", what, msg);
    exit(1);
}

/* Renders a graph; returns the node `id`'s ms and copies the named outputs into dense arrays. */
static double render(const std::string &xml, const char *id, std::vector<float> *out,
                     std::vector<float> *src)
{
    WgError err = {};
    WgGraph *g = nullptr;
    if (wg_graph_load_memory(xml.c_str(), xml.size(), "peer.wetgraph", &g, &err))
        die("graph", err.message);
    WgRequest *r = wg_request_new(g);
    wg_engine_clear_cache(g_engine);
    WgResult *res = nullptr;
    if (wg_render(g_engine, r, &res, &err)) die("render", err.message);
    double ms = -1;
    for (int i = 0; i < wg_result_stat_count(res); i++)
        if (!strcmp(wg_result_stat(res, i)->id, id)) ms = wg_result_stat(res, i)->ms;
    for (int i = 0; i < wg_result_output_count(res); i++) {
        std::vector<float> *dst = !strcmp(wg_result_output_name(res, i), "out") ? out : src;
        if (!dst) continue;
        const WgImage *im = wg_result_output_image(res, i);
        dst->resize((size_t)im->width * im->height);
        for (int y = 0; y < im->height; y++)
            memcpy(dst->data() + (size_t)y * im->width, wg_image_row(im, y),
                   sizeof(float) * im->width);
    }
    wg_result_free(res);
    wg_request_free(r);
    wg_graph_free(g);
    return ms;
}

struct Timing {
    int runs;
    double median, min;
};

/* Runs f (which returns its own ms) R times; 3 times when the first run exceeds 2 s, once when it
 * exceeds 10 s. */
static Timing timed(const std::function<double(bool first)> &f)
{
    std::vector<double> t;
    for (int k = 0; k < g_reps; k++) {
        t.push_back(f(k == 0));
        if (k == 0 && t[0] > 10000) break;
        if (k == 0 && t[0] > 2000 && g_reps > 3) {
            t.push_back(f(false));
            t.push_back(f(false));
            break;
        }
    }
    std::sort(t.begin(), t.end());
    return {(int)t.size(), t[t.size() / 2], t[0]};
}

static double now_ms()
{
    using namespace std::chrono;
    return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

template <class T> static double max_err(const std::vector<T> &a, const std::vector<double> &ref)
{
    double d = 0;
    for (size_t i = 0; i < ref.size(); i++) d = std::max(d, std::fabs((double)a[i] - ref[i]));
    return d;
}

static void write_raw(const std::string &name, const void *p, size_t bytes)
{
    if (g_dir.empty()) return;
    std::string path = g_dir + "/" + name, tmp = path + ".part";
    FILE *f = fopen(tmp.c_str(), "wb");
    if (!f || fwrite(p, 1, bytes, f) != bytes || fclose(f) || rename(tmp.c_str(), path.c_str()))
        die(path.c_str(), strerror(errno));
}

static void row(const char *op, const char *cas, double sigma, const char *method, Timing t,
                double err)
{
    printf("%d\t%s\t%s\t%g\t%s\t%d\t%.2f\t%.2f\t%.3g\n", g_size, op, cas, sigma, method, t.runs,
           t.median, t.min, err);
    fflush(stdout);
}

/* ---- float64 references ---- */

/* The periodic sampled Gaussian of side n, normalised. */
static std::vector<double> folded_kernel(int n, double sigma)
{
    std::vector<double> k(n, 0.0);
    long r = (long)std::ceil(10 * sigma);
    double sum = 0;
    for (long d = -r; d <= r; d++) {
        double w = std::exp(-(double)d * d / (2 * sigma * sigma));
        k[(size_t)(((d % n) + n) % n)] += w;
        sum += w;
    }
    for (double &v : k) v /= sum;
    return k;
}

static std::vector<double> blur_reference(const std::vector<float> &src, int n, double sigma)
{
    std::vector<double> k = folded_kernel(n, sigma), kh(n / 2 + 1);
    for (int f = 0; f <= n / 2; f++) { /* the kernel is even: its DFT is real */
        double s = 0;
        for (int i = 0; i < n; i++) s += k[i] * std::cos(2 * M_PI * (double)((long)f * i % n) / n);
        kh[f] = s;
    }
    size_t nc = (size_t)n * (n / 2 + 1);
    double *in = fftw_alloc_real((size_t)n * n);
    fftw_complex *sp = fftw_alloc_complex(nc);
    fftw_plan fw = fftw_plan_dft_r2c_2d(n, n, in, sp, FFTW_ESTIMATE);
    fftw_plan bw = fftw_plan_dft_c2r_2d(n, n, sp, in, FFTW_ESTIMATE);
    for (size_t i = 0; i < (size_t)n * n; i++) in[i] = src[i];
    fftw_execute(fw);
    double scale = 1.0 / ((double)n * n);
    for (int y = 0; y < n; y++) {
        double ky = kh[y <= n / 2 ? y : n - y] * scale;
        for (int x = 0; x <= n / 2; x++) {
            double m = ky * kh[x];
            sp[(size_t)y * (n / 2 + 1) + x][0] *= m;
            sp[(size_t)y * (n / 2 + 1) + x][1] *= m;
        }
    }
    fftw_execute(bw);
    std::vector<double> out(in, in + (size_t)n * n);
    fftw_destroy_plan(fw);
    fftw_destroy_plan(bw);
    fftw_free(in);
    fftw_free(sp);
    return out;
}

/* 1-D lower envelope of parabolas (Felzenszwalb & Huttenlocher); f = INF where no site. */
static void edt1d(const double *f, double *d, int n, std::vector<int> &v, std::vector<double> &z)
{
    const double inf = HUGE_VAL;
    int k = -1;
    for (int q = 0; q < n; q++) {
        if (f[q] == inf) continue;
        for (;;) {
            if (k < 0) {
                v[++k] = q;
                z[k] = -inf;
                break;
            }
            double s =
                ((f[q] + (double)q * q) - (f[v[k]] + (double)v[k] * v[k])) / (2.0 * (q - v[k]));
            if (s <= z[k]) {
                k--;
                continue;
            }
            v[++k] = q;
            z[k] = s;
            break;
        }
    }
    if (k < 0) {
        for (int q = 0; q < n; q++) d[q] = inf;
        return;
    }
    z[k + 1] = inf;
    int j = 0;
    for (int q = 0; q < n; q++) {
        while (z[j + 1] < q) j++;
        d[q] = (double)(q - v[j]) * (q - v[j]) + f[v[j]];
    }
}

/* Non-periodic Euclidean distance (pixels) to the nearest site, in double. */
static std::vector<double> edt_reference(const std::vector<unsigned char> &site, int n)
{
    const double inf = HUGE_VAL;
    std::vector<double> g((size_t)n * n), f(n), d(n), z(n + 1);
    std::vector<int> v(n);
    for (int x = 0; x < n; x++) {
        for (int y = 0; y < n; y++) f[y] = site[(size_t)y * n + x] ? 0 : inf;
        edt1d(f.data(), d.data(), n, v, z);
        for (int y = 0; y < n; y++) g[(size_t)y * n + x] = d[y];
    }
    for (int y = 0; y < n; y++) {
        edt1d(&g[(size_t)y * n], d.data(), n, v, z);
        for (int x = 0; x < n; x++) g[(size_t)y * n + x] = std::sqrt(d[x]);
    }
    return g;
}

/* ---- the cases ---- */

static std::string blur_xml(double sigma_px, const char *quality)
{
    char xml[1024];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"7\">\n"
             "  <node id=\"h\" type=\"noise\" kind=\"white\" scale=\"%d\" octaves=\"1\"/>\n"
             "  <node id=\"n\" type=\"blur\" sigma=\"%.17g\" quality=\"%s\">"
             "<in name=\"source\" from=\"h\"/></node>\n"
             "  <output name=\"out\" from=\"n\"/>\n  <output name=\"src\" from=\"h\"/>\n"
             "</wetgraph>\n",
             g_size, g_size, g_size, sigma_px * 256 / g_size, quality);
    return xml;
}

/* OpenCV 4's filters refuse BORDER_WRAP (an assertion in FilterEngine), so the periodic blur is
 * OpenCV's own copyMakeBorder(BORDER_WRAP) by the kernel radius, GaussianBlur with ksize 0 (for
 * float, 2·round(4σ)+1) and a crop; the time includes the padding and the crop. */
static cv::Mat opencv_blur(const cv::Mat &src, double sigma)
{
    int r = (cvRound(sigma * 4 * 2 + 1) | 1) / 2;
    cv::Mat pad, dst;
    cv::copyMakeBorder(src, pad, r, r, r, r, cv::BORDER_WRAP);
    cv::GaussianBlur(pad, dst, cv::Size(0, 0), sigma, sigma, cv::BORDER_REFLECT_101);
    return dst(cv::Rect(r, r, src.cols, src.rows)).clone();
}

static void bench_blur()
{
    static const double sigmas[] = {2, 16, 64, 256};
    std::vector<float> src;
    render(blur_xml(2, "fast"), "n", nullptr, &src);
    char name[256];
    snprintf(name, sizeof name, "blur_src_%d.f32", g_size);
    write_raw(name, src.data(), src.size() * sizeof(float));
    cv::Mat csrc(g_size, g_size, CV_32F, src.data());
    for (double s : sigmas) {
        std::vector<double> ref = blur_reference(src, g_size, s);
        snprintf(name, sizeof name, "blur_ref_%d_%g.f64", g_size, s);
        write_raw(name, ref.data(), ref.size() * sizeof(double));
        for (const char *q : {"fast", "exact"}) {
            std::vector<float> out;
            std::string xml = blur_xml(s, q);
            Timing t = timed(
                [&](bool first) { return render(xml, "n", first ? &out : nullptr, nullptr); });
            row("blur", "noise", s, q[0] == 'f' ? "wetgraph fast" : "wetgraph exact", t,
                max_err(out, ref));
        }
        cv::Mat keep;
        Timing t = timed([&](bool first) {
            double t0 = now_ms();
            cv::Mat d = opencv_blur(csrc, s);
            double ms = now_ms() - t0;
            if (first) keep = d;
            return ms;
        });
        std::vector<float> out(keep.begin<float>(), keep.end<float>());
        row("blur", "noise", s, "OpenCV GaussianBlur", t, max_err(out, ref));
    }
}

static void bench_distance()
{
    static const char *const masks[] = {
        "  <node id=\"mask\" type=\"noise\" kind=\"perlin\" scale=\"8\" octaves=\"4\"/>\n",
        "  <node id=\"white\" type=\"noise\" kind=\"white\" scale=\"%d\" octaves=\"1\"/>\n"
        "  <node id=\"mask\" type=\"threshold\" position=\"0.9999\"><in name=\"source\" "
        "from=\"white\"/></node>\n",
    };
    static const char *const names[] = {"blobs", "seeds"};
    for (int m = 0; m < 2; m++) {
        char mask[512], xml[2048], name[256];
        snprintf(mask, sizeof mask, masks[m], g_size);
        snprintf(xml, sizeof xml,
                 "<wetgraph version=\"1\" size=\"%dx%d\" seed=\"7\">\n%s"
                 "  <node id=\"d\" type=\"distance\" mode=\"pixels\" wrap=\"false\">"
                 "<in name=\"mask\" from=\"mask\"/></node>\n"
                 "  <output name=\"out\" from=\"d\"/>\n  <output name=\"src\" from=\"mask\"/>\n"
                 "</wetgraph>\n",
                 g_size, g_size, mask);
        std::vector<float> out, msk;
        Timing t = timed([&](bool first) {
            return render(xml, "d", first ? &out : nullptr, first ? &msk : nullptr);
        });
        std::vector<unsigned char> site(msk.size());
        for (size_t i = 0; i < msk.size(); i++) site[i] = msk[i] >= 0.5f;
        std::vector<double> ref = edt_reference(site, g_size);
        snprintf(name, sizeof name, "dist_%s_%d.u8", names[m], g_size);
        write_raw(name, site.data(), site.size());
        snprintf(name, sizeof name, "dist_%s_ref_%d.f64", names[m], g_size);
        write_raw(name, ref.data(), ref.size() * sizeof(double));
        row("distance", names[m], 0, "wetgraph", t, max_err(out, ref));
        cv::Mat c8(g_size, g_size, CV_8U);
        for (size_t i = 0; i < site.size(); i++) c8.data[i] = site[i] ? 0 : 255;
        cv::Mat keep;
        t = timed([&](bool first) {
            cv::Mat d;
            double t0 = now_ms();
            cv::distanceTransform(c8, d, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
            double ms = now_ms() - t0;
            if (first) keep = d;
            return ms;
        });
        std::vector<float> o(keep.begin<float>(), keep.end<float>());
        row("distance", names[m], 0, "OpenCV distanceTransform precise", t, max_err(o, ref));
    }
}

/* The references against brute force at 128²; returns non-zero on a mismatch. */
static int check()
{
    const int n = 128;
    std::vector<float> src((size_t)n * n);
    unsigned s = 12345;
    for (float &v : src) v = (float)((s = s * 1103515245u + 12345u) >> 8) / 16777216.0f;
    int bad = 0;
    for (double sigma : {0.7, 2.0, 16.0, 64.0, 256.0}) {
        std::vector<double> ref = blur_reference(src, n, sigma), k = folded_kernel(n, sigma);
        std::vector<double> tmp((size_t)n * n), direct((size_t)n * n);
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++) {
                double a = 0;
                for (int i = 0; i < n; i++) a += k[i] * src[(size_t)y * n + (x - i + n) % n];
                tmp[(size_t)y * n + x] = a;
            }
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++) {
                double a = 0;
                for (int i = 0; i < n; i++) a += k[i] * tmp[(size_t)((y - i + n) % n) * n + x];
                direct[(size_t)y * n + x] = a;
            }
        double e = max_err(direct, ref);
        printf("# check blur sigma %g px at %d²: max |FFT reference - direct double| = %.3g\n",
               sigma, n, e);
        bad |= e > 1e-12;
    }
    for (int m = 0; m < 2; m++) {
        std::vector<unsigned char> site((size_t)n * n);
        std::vector<int> sx, sy;
        for (size_t i = 0; i < site.size(); i++) {
            s = s * 1103515245u + 12345u;
            site[i] = m ? (s >> 8) % 997 == 0 : (s >> 8) % 2 == 0;
            if (site[i]) sx.push_back((int)(i % n)), sy.push_back((int)(i / n));
        }
        std::vector<double> ref = edt_reference(site, n);
        double e = 0;
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++) {
                long best = -1;
                for (size_t j = 0; j < sx.size(); j++) {
                    long d = (long)(x - sx[j]) * (x - sx[j]) + (long)(y - sy[j]) * (y - sy[j]);
                    if (best < 0 || d < best) best = d;
                }
                e = std::max(e, std::fabs(std::sqrt((double)best) - ref[(size_t)y * n + x]));
            }
        printf("# check distance (%zu sites) at %d²: max |EDT reference - brute force| = %.3g\n",
               sx.size(), n, e);
        bad |= e != 0;
    }
    return bad;
}

int main(int argc, char **argv)
{
    bool do_check = false;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--size") && i + 1 < argc)
            g_size = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc)
            g_threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            g_reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--dir") && i + 1 < argc)
            g_dir = argv[++i];
        else if (!strcmp(argv[i], "--check"))
            do_check = true;
        else {
            fprintf(stderr, "usage: %s [--size N] [--threads T] [--reps R] [--dir DIR] [--check]\n",
                    argv[0]);
            return 2;
        }
    }
    if (g_size < 16 || g_size > 16384 || g_reps < 1 || g_reps > 1000 || g_threads < 1) {
        fprintf(stderr, "peer_opencv: size 16..16384, reps 1..1000, threads >= 1\n");
        return 2;
    }
    if (do_check) return check();
    cv::setNumThreads(g_threads);
    WgError err = {};
    WgEngineOptions opt = {};
    opt.threads = g_threads;
    if (wg_engine_new(&opt, &g_engine, &err)) die("engine", err.message);
    printf("# %dx%d gray float, %d threads (wetgraph and OpenCV), median of %d; OpenCV %s\n",
           g_size, g_size, g_threads, g_reps, CV_VERSION);
    bench_blur();
    bench_distance();
    wg_engine_free(g_engine);
    return 0;
}
