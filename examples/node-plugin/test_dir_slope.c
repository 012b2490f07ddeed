/* SPDX-License-Identifier: MIT */
/* dir_slope held to what every built-in node is held to, with wetgraph's test kit: the plugin
 * loads; a sine height gives its analytic slope (a float64 reference); the output tiles, does
 * not depend on the thread count, survives the hard inputs, and looks the same at two
 * resolutions. Usage: test_dir_slope PLUGIN.so */
#include <math.h>

#define PI 3.14159265358979323846
#include <stdio.h>
#include <stdlib.h>
#include <wetgraph/testkit.h>
#include <wetgraph/wetgraph.h>

static int failures;

#define CHECK(ok, what, message)                                                                   \
    do {                                                                                           \
        bool ok_ = (ok);                                                                           \
        printf("%s %s: %s\n", ok_ ? "ok  " : "FAIL", what, message);                              \
        failures += !ok_;                                                                          \
    } while (0)

static const char *const height_port[] = {"height", NULL};

/* h = 0.25 sin(2 pi (x + 0.5) / W): one period across, so it tiles */
static double sine(void *user, int x, int y, int c)
{
    (void)y, (void)c;
    int w = *(const int *)user;
    return 0.25 * sin(2 * PI * (x + 0.5) / w);
}

/* Its exact central difference along +x over s = length x W / 256 pixels, times
 * intensity / (2 length): 0.25 (sin(k(x + s)) - sin(k(x - s))) = 0.5 cos(kx) sin(ks). */
typedef struct {
    int w;
    double length, intensity;
} Sine;

static double sine_slope(void *user, int x, int y, int c)
{
    (void)y, (void)c;
    const Sine *s = user;
    double k = 2 * PI / s->w, step = s->length * s->w / 256.0;
    return s->intensity / (2 * s->length) * 0.5 * cos(k * (x + 0.5)) * sin(k * step);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: test_dir_slope PLUGIN.so\n");
        return 2;
    }
    WgError err = {0};
    if (wg_plugin_load(argv[1], &err)) {
        fprintf(stderr, "%s: %s\n", err.file, err.message);
        return 1;
    }
    int w = 64;
    WgImage *height = wg_testkit_image_fn(w, 48, 1, sine, &w);
    const WgImage *inputs[] = {height};
    static const char *const params[] = {"length=8", "intensity=4", NULL};
    WgTestkitNode node = {.type = "dir_slope", .params = params, .input_names = height_port,
                          .inputs = inputs};
    WgTestkitReport rep;

    /* exact: a step of 8 length units is 2 whole pixels at 64 wide, where bilinear sampling
     * is exact, so only float rounding separates the node from the analytic slope */
    WgImage *out = NULL;
    if (wg_testkit_run(&node, 2, &out, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    Sine s = {w, 8, 4};
    CHECK(wg_testkit_compare_fn(out, sine_slope, &s, 1e-6, &rep), "sine slope", rep.message);
    wg_image_unref(out);

    CHECK(wg_testkit_check_tiling(&node, 17, -5, 1e-6, &rep), "tiling", rep.message);
    CHECK(wg_testkit_check_invariance(&node, &rep), "threads and bands", rep.message);
    WgTestkitHardReport hard;
    CHECK(wg_testkit_check_hard_inputs(&node, &hard), "hard inputs", hard.summary);

    /* resolution independence: the same sine at 128 wide gives the same slope at the same
     * places (every other pixel), up to the bilinear error of a half-pixel step */
    int w2 = 128;
    WgImage *height2 = wg_testkit_image_fn(w2, 96, 1, sine, &w2);
    const WgImage *inputs2[] = {height2};
    WgTestkitNode node2 = node;
    node2.inputs = inputs2;
    WgImage *small = NULL, *large = NULL;
    if (wg_testkit_run(&node, 1, &small, &err) || wg_testkit_run(&node2, 1, &large, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    Sine s2 = {w2, 8, 4};
    CHECK(wg_testkit_compare_fn(large, sine_slope, &s2, 1e-6, &rep), "sine slope at 128", rep.message);
    double worst = 0;
    for (int y = 0; y < 48; y++)
        for (int x = 0; x < 64; x++) {
            /* pixel x at 64 wide is centred where pixels 2x and 2x + 1 meet at 128 */
            double a = wg_image_row(small, y)[x];
            double b = 0.5 * (wg_image_row(large, 2 * y)[2 * x] + wg_image_row(large, 2 * y)[2 * x + 1]);
            worst = fmax(worst, fabs(a - b));
        }
    char text[128];
    snprintf(text, sizeof text, "64 and 128 wide differ by at most %.2g (allowed 1e-4)", worst);
    CHECK(worst < 1e-4, "resolution independence", text);

    wg_image_unref(small);
    wg_image_unref(large);
    wg_image_unref(height);
    wg_image_unref(height2);
    printf("%d check%s failed\n", failures, failures == 1 ? "" : "s");
    return failures ? 1 : 0;
}
