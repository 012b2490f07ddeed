/* SPDX-License-Identifier: MIT */
/* The PNG encoder alone, per compression mode: each PNG given is decoded once (wg__png_read)
 * into packed rows, then encoded from memory by png_write.c in each mode, one file after the
 * other on one thread, best of --reps; nothing is written to disk. Prints, per mode, the time,
 * the speed in MB/s of raw image data (width x height x channels x bytes per sample), the total
 * size of the encoded files and their ratio to the default mode's (fast); where the fast coder's
 * wide path runs (AVX-512 with VBMI), the fast mode once more with the scalar coder alone
 * ("scalar": the same files). Run on the wet material's outputs by bench/run_write.sh.
 * Usage: bench_png [--reps R] [--mode fast|deflate|none] FILE.png... (--mode: that mode only, for
 * a profiler) */
#include "wgio.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct {
    int w, h, c, bits;
    unsigned char *px; /* packed rows, 16-bit samples in host order */
} Img;

static void sink_row(void *user, int y, const unsigned char *data, int depth)
{
    Img *im = user;
    size_t row = (size_t)im->w * (size_t)im->c * (size_t)(depth / 8);
    unsigned char *o = im->px + row * (size_t)y;
    if (depth == 8) {
        memcpy(o, data, row);
        return;
    }
    for (size_t i = 0; i < row; i += 2) {
        uint16_t v = (uint16_t)(data[i] << 8 | data[i + 1]);
        memcpy(o + i, &v, 2);
    }
}

static void pack_row(void *user, int y, void *row)
{
    const Img *im = user;
    size_t n = (size_t)im->w * (size_t)im->c * (size_t)(im->bits / 8);
    memcpy(row, im->px + n * (size_t)y, n);
}

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

int main(int argc, char **argv)
{
    int reps = 3, first = 1, only = -1;
    while (first + 1 < argc && (!strcmp(argv[first], "--reps") || !strcmp(argv[first], "--mode"))) {
        if (!strcmp(argv[first], "--reps"))
            reps = atoi(argv[first + 1]);
        else if ((only = wg_png_compression_parse(argv[first + 1])) < 0)
            reps = 0;
        first += 2;
    }
    if (first >= argc || reps < 1) {
        fprintf(stderr, "usage: bench_png [--reps R] [--mode fast|deflate|none] FILE.png...\n");
        return 1;
    }
    int n = argc - first;
    Img *imgs = calloc((size_t)n, sizeof *imgs);
    double raw = 0;
    for (int i = 0; i < n; i++) {
        Img *im = &imgs[i];
        char msg[256];
        int w, h, c;
        if (wg__png_probe(argv[first + i], &w, &h, &c, msg, sizeof msg)) {
            fprintf(stderr, "%s: not a PNG\n", argv[first + i]);
            return 1;
        }
        /* 16-bit until the first row says otherwise: the buffer fits either */
        *im = (Img){w, h, c, 16, malloc((size_t)w * (size_t)h * (size_t)c * 2)};
        WgPngSink sink = {w, h, c, sink_row, im};
        FILE *f = fopen(argv[first + i], "rb");
        unsigned char head[25];
        if (!f || fread(head, 1, 25, f) != 25) {
            fprintf(stderr, "%s: cannot read\n", argv[first + i]);
            return 1;
        }
        fclose(f);
        im->bits = head[24];
        if (!im->px || wg__png_read(argv[first + i], &sink, msg, sizeof msg)) {
            fprintf(stderr, "%s: %s\n", argv[first + i], msg);
            return 1;
        }
        raw += (double)w * h * c * (im->bits / 8);
    }
    /* the fast mode once more through its scalar coder alone, where the wide one runs */
    static const char *const names[] = {"fast", "deflate", "none", "scalar"};
    int modes = wg__deflate_wide(true) ? 4 : 3;
    double base_size = 0;
    printf("%d files, %.1f MB of raw image data, one thread, best of %d\n", n, raw / 1e6, reps);
    printf("mode      ms      MB/s    size MB   / fast\n");
    for (int m = 0; m < modes; m++) {
        if (only >= 0 && m != only) continue;
        wg__deflate_wide(m != 3);
        WgPngCompression mode = m == 3 ? WG_PNG_COMPRESSION_FAST : (WgPngCompression)m;
        double best = 0, size = 0;
        for (int r = 0; r < reps; r++) {
            double t0 = now_ms();
            size = 0;
            for (int i = 0; i < n; i++) {
                unsigned char *out;
                size_t out_size;
                char msg[256];
                if (wg__png_encode_rows(imgs[i].w, imgs[i].h, imgs[i].c, imgs[i].bits, mode,
                                        pack_row, &imgs[i], false, NULL, &out, &out_size, msg,
                                        sizeof msg)) {
                    fprintf(stderr, "%s: %s\n", argv[first + i], msg);
                    return 1;
                }
                size += (double)out_size;
                wg_free(out);
            }
            double t = now_ms() - t0;
            if (r == 0 || t < best) best = t;
        }
        if (m == 0 || base_size == 0) base_size = size;
        printf("%-8s %6.0f %7.0f %9.2f %8.2f\n", names[m], best, raw / 1e3 / best, size / 1e6,
               size / base_size);
    }
    wg__deflate_wide(true);
    for (int i = 0; i < n; i++) free(imgs[i].px);
    free(imgs);
    return 0;
}
