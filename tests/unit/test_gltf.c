/* SPDX-License-Identifier: MIT */
/* glTF 2.0 assets (wg_gltf_write): a text asset (.gltf, .bin and PNGs) with every map, a binary
 * one (.glb) on a grid displaced by a height map, and one of a base colour alone pass Khronos'
 * glTF-Validator with no error and no warning; the textures decode to the maps (8-bit codes,
 * sRGB for the base colour and the specular level), packed as the JSON says (occlusion,
 * roughness, metallic in R, G, B; the coat's weight and roughness in R, G); the JSON names the
 * extensions of the maps given and no others; the displaced grid's vertices follow the height
 * map; and bad assets are refused before anything is written. */
#include "wgtest.h"

#include <json-c/json.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { S = 24 };

static double f_base(int x, int y, int k)
{
    return k == 3 ? 1 : fmod(0.13 * x + 0.29 * y + 0.31 * k, 1.0);
}
static double f_gray(int x, int y, int k)
{
    return fmod(0.05 * x * (k + 1) + 0.021 * y * y, 1.0);
}
static double f_normal(int x, int y, int k)
{
    return k == 2 ? 0.9 + 0.004 * x : k == 3 ? 1 : 0.5 + 0.01 * (k ? y - 12 : x - 12);
}
static double f_height(int x, int y, int k)
{
    (void)k;
    return 0.5 + 0.5 * sin(2 * M_PI * x / S) * cos(2 * M_PI * y / S);
}
static double f_rough(int x, int y, int k)
{
    return f_gray(x, y, k + 1);
}
static double f_metal(int x, int y, int k)
{
    return (x + y) % 3 == 0 ? 1 : 0;
}
static double f_spec(int x, int y, int k)
{
    return f_gray(y, x, k + 2);
}
static double f_mask(int x, int y, int k)
{
    (void)k;
    return x < S / 2 ? 1 : y < S / 2 ? 0.5 : 0;
}

typedef struct {
    WgImage *img[WG_GLTF_SLOT_COUNT];
} Maps;

static void maps_make(Maps *m)
{
    memset(m, 0, sizeof *m);
    m->img[WG_GLTF_BASE_COLOR] = wgt_image_fn(S, S, 4, f_base);
    m->img[WG_GLTF_METALLIC] = wgt_image_fn(S, S, 1, f_metal);
    m->img[WG_GLTF_ROUGHNESS] = wgt_image_fn(S, S, 1, f_rough);
    m->img[WG_GLTF_OCCLUSION] = wgt_image_fn(S, S, 1, f_gray);
    m->img[WG_GLTF_NORMAL] = wgt_image_fn(S, S, 4, f_normal);
    m->img[WG_GLTF_SPECULAR] = wgt_image_fn(S, S, 1, f_spec);
    m->img[WG_GLTF_CLEARCOAT] = wgt_image_fn(S, S, 1, f_mask);
    m->img[WG_GLTF_CLEARCOAT_ROUGHNESS] = wgt_image_fn(S, S, 1, f_gray);
    m->img[WG_GLTF_CLEARCOAT_NORMAL] = wgt_image_fn(S, S, 4, f_normal);
    m->img[WG_GLTF_HEIGHT] = wgt_image_fn(S / 2, S / 2, 1, f_height);
}

static void maps_free(Maps *m)
{
    for (int k = 0; k < WG_GLTF_SLOT_COUNT; k++) wg_image_unref(m->img[k]);
}

static void write_asset(const char *path, const WgGltfAsset *a)
{
    WgWriteSet *s = wg_write_set_new();
    WgError err = {0};
    if (wg_gltf_write(s, path, a, &err) || wg_write_set_commit(s, &err))
        fail_msg("%s: %s", path, err.message);
    wg_write_set_free(s);
}

static json_object *read_json(const char *path)
{
    json_object *j = json_object_from_file(path);
    if (!j) fail_msg("%s: not JSON", path);
    return j;
}

static json_object *at(json_object *o, const char *key)
{
    json_object *v = NULL;
    if (!json_object_object_get_ex(o, key, &v)) fail_msg("no key '%s'", key);
    return v;
}

/* The texture file `name` decodes to the maps' 8-bit codes, channel by channel. */
static void expect_texture(const char *name, const Maps *m, int slots[4], bool srgb, int channels)
{
    WgImage *img = NULL;
    WgError err = {0};
    int read_channels = channels == 1 ? 1 : 4;
    if (wg_image_read(wgt_path(name), read_channels, WG_LINEAR, &img, &err))
        fail_msg("%s: %s", name, err.message);
    assert_int_equal(img->width, S);
    for (int y = 0; y < S; y++)
        for (int x = 0; x < S; x++)
            for (int c = 0; c < channels; c++) {
                if (slots[c] < 0) continue;
                const WgImage *src = m->img[slots[c]];
                float v = wg_image_row(src, y)[x * src->channels + (src->channels == 1 ? 0 : c)];
                int want = wg_quantize8(v, srgb && c < 3);
                int got = (int)lrintf(wg_image_row(img, y)[x * read_channels + c] * 255);
                if (want != got)
                    fail_msg("%s (%d,%d) channel %d: code %d, expected %d", name, x, y, c, got,
                             want);
            }
    wg_image_unref(img);
}

static void test_text_asset(void **state)
{
    (void)state;
    Maps m;
    maps_make(&m);
    WgGltfAsset a = {.name = "wet stone", .repeat = 2};
    for (int k = 0; k < WG_GLTF_HEIGHT; k++) a.maps[k] = m.img[k];
    write_asset(wgt_path("stone.gltf"), &a);
    wgt_gltf_validate(wgt_tmpdir(), "stone.gltf");
    json_object *j = read_json(wgt_path("stone.gltf"));
    json_object *mat = json_object_array_get_idx(at(j, "materials"), 0);
    json_object *ext = at(mat, "extensions");
    at(ext, "KHR_materials_clearcoat");
    at(ext, "KHR_materials_specular");
    assert_int_equal(json_object_array_length(at(j, "extensionsUsed")), 3);
    assert_int_equal(json_object_array_length(at(j, "images")), 6);
    json_object_put(j);
    expect_texture("stone_basecolor.png", &m, (int[]){0, 0, 0, 0}, true, 4);
    expect_texture("stone_orm.png", &m,
                   (int[]){WG_GLTF_OCCLUSION, WG_GLTF_ROUGHNESS, WG_GLTF_METALLIC, -1}, false, 3);
    expect_texture("stone_normal.png", &m,
                   (int[]){WG_GLTF_NORMAL, WG_GLTF_NORMAL, WG_GLTF_NORMAL, -1}, false, 3);
    expect_texture("stone_clearcoat.png", &m,
                   (int[]){WG_GLTF_CLEARCOAT, WG_GLTF_CLEARCOAT_ROUGHNESS, -1, -1}, false, 3);
    expect_texture("stone_specular.png", &m,
                   (int[]){WG_GLTF_SPECULAR, WG_GLTF_SPECULAR, WG_GLTF_SPECULAR, -1}, true, 3);
    assert_true(wgt_exists(wgt_path("stone.bin")));
    maps_free(&m);
}

/* The .glb's chunks: JSON first, then the binary buffer. */
static void read_glb(const char *path, json_object **json, unsigned char **bin, size_t *bin_size)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    uint32_t head[5];
    assert_int_equal(fread(head, 4, 5, f), 5);
    assert_int_equal(head[0], 0x46546C67u);
    assert_int_equal(head[1], 2);
    assert_int_equal(head[4], 0x4E4F534Au);
    char *text = calloc(head[3] + 1, 1);
    assert_int_equal(fread(text, 1, head[3], f), head[3]);
    *json = json_tokener_parse(text);
    assert_non_null(*json);
    free(text);
    uint32_t bh[2];
    assert_int_equal(fread(bh, 4, 2, f), 2);
    assert_int_equal(bh[1], 0x004E4942u);
    *bin = malloc(bh[0]);
    assert_int_equal(fread(*bin, 1, bh[0], f), bh[0]);
    *bin_size = bh[0];
    assert_int_equal(fgetc(f), EOF);
    assert_int_equal(head[2], 12 + 8 + head[3] + 8 + bh[0]);
    fclose(f);
}

static void test_binary_grid(void **state)
{
    (void)state;
    Maps m;
    maps_make(&m);
    WgGltfAsset a = {.name = "water", .binary = true, .grid = 8, .height_scale = 0.1, .repeat = 1};
    a.maps[WG_GLTF_BASE_COLOR] = m.img[WG_GLTF_BASE_COLOR];
    a.maps[WG_GLTF_CLEARCOAT] = m.img[WG_GLTF_CLEARCOAT];
    a.maps[WG_GLTF_CLEARCOAT_ROUGHNESS] = m.img[WG_GLTF_CLEARCOAT_ROUGHNESS];
    a.maps[WG_GLTF_HEIGHT] = m.img[WG_GLTF_HEIGHT];
    write_asset(wgt_path("water.glb"), &a);
    wgt_gltf_validate(wgt_tmpdir(), "water.glb");
    json_object *j;
    unsigned char *bin;
    size_t size;
    read_glb(wgt_path("water.glb"), &j, &bin, &size);
    /* the vertices: a 9 x 9 grid whose y follows the height map (y = 0.1 (h - 1)) */
    json_object *acc = json_object_array_get_idx(at(j, "accessors"), 0);
    assert_int_equal(json_object_get_int(at(acc, "count")), 81);
    json_object *view =
        json_object_array_get_idx(at(j, "bufferViews"), json_object_get_int(at(acc, "bufferView")));
    const float *pos = (const float *)(bin + json_object_get_int(at(view, "byteOffset")));
    for (int k = 0; k < 81; k++) {
        double u = pos[3 * k] + 0.5, v = pos[3 * k + 2] + 0.5;
        int i = (int)lround(u * 8), jj = (int)lround(v * 8);
        assert_true(fabs(u - i / 8.0) < 1e-6 && fabs(v - jj / 8.0) < 1e-6);
        /* the height map between texel centres, bilinear, wrapping */
        int n = S / 2;
        double fx = u * n - 0.5, fy = v * n - 0.5, ax = fx - floor(fx), ay = fy - floor(fy);
        int x0 = ((int)floor(fx) + n) % n, y0 = ((int)floor(fy) + n) % n;
        int x1 = (x0 + 1) % n, y1 = (y0 + 1) % n;
        const WgImage *h = m.img[WG_GLTF_HEIGHT];
        double hv = (wg_image_row(h, y0)[x0] * (1 - ax) + wg_image_row(h, y0)[x1] * ax) * (1 - ay) +
                    (wg_image_row(h, y1)[x0] * (1 - ax) + wg_image_row(h, y1)[x1] * ax) * ay;
        if (fabs(pos[3 * k + 1] - 0.1 * (hv - 1)) > 1e-5)
            fail_msg("vertex %d (%g, %g): y %g, expected %g", k, u, v, pos[3 * k + 1],
                     0.1 * (hv - 1));
    }
    /* only the clear coat's extension; the embedded coat texture decodes to the mask and the
     * roughness */
    json_object *used = at(j, "extensionsUsed");
    assert_int_equal(json_object_array_length(used), 1);
    assert_string_equal(json_object_get_string(json_object_array_get_idx(used, 0)),
                        "KHR_materials_clearcoat");
    json_object *images = at(j, "images");
    assert_int_equal(json_object_array_length(images), 2);
    json_object *img = json_object_array_get_idx(images, 1);
    json_object *iv =
        json_object_array_get_idx(at(j, "bufferViews"), json_object_get_int(at(img, "bufferView")));
    FILE *f = fopen(wgt_path("coat_from_glb.png"), "wb");
    fwrite(bin + json_object_get_int(at(iv, "byteOffset")), 1,
           (size_t)json_object_get_int(at(iv, "byteLength")), f);
    fclose(f);
    expect_texture("coat_from_glb.png", &m,
                   (int[]){WG_GLTF_CLEARCOAT, WG_GLTF_CLEARCOAT_ROUGHNESS, -1, -1}, false, 3);
    free(bin);
    json_object_put(j);
    maps_free(&m);
}

static void test_base_colour_alone(void **state)
{
    (void)state;
    Maps m;
    maps_make(&m);
    WgGltfAsset a = {.name = "plain", .repeat = 1};
    a.maps[WG_GLTF_BASE_COLOR] = m.img[WG_GLTF_BASE_COLOR];
    write_asset(wgt_path("plain.gltf"), &a);
    wgt_gltf_validate(wgt_tmpdir(), "plain.gltf");
    json_object *j = read_json(wgt_path("plain.gltf"));
    json_object *dummy;
    assert_false(json_object_object_get_ex(j, "extensionsUsed", &dummy));
    json_object_put(j);
    assert_false(wgt_exists(wgt_path("plain_orm.png")));
    maps_free(&m);
}

static void test_refused(void **state)
{
    (void)state;
    Maps m;
    maps_make(&m);
    WgImage *small = wgt_image_fn(S / 2, S / 2, 1, f_gray);
    struct {
        const char *path;
        WgGltfAsset a;
        const char *msg;
    } bad[] = {
        {"x.gltf", {.name = "x", .repeat = 1}, "needs a base colour"},
        {"x.gltf", {.name = "x", .repeat = 1, .grid = 4}, "a displaced grid needs a height map"},
        {"x.obj", {.name = "x", .repeat = 1}, "ends in .gltf or .glb"},
        {"x.gltf", {.name = "x", .repeat = 1, .binary = true}, "ends in .glb"},
        {"x.gltf", {.name = "x", .repeat = 0}, "out of range"},
        {"x.gltf", {.name = "x", .repeat = 1}, "differ in size"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        if (i != 0) bad[i].a.maps[WG_GLTF_BASE_COLOR] = m.img[WG_GLTF_BASE_COLOR];
        if (i == 5) bad[i].a.maps[WG_GLTF_ROUGHNESS] = small;
        WgWriteSet *s = wg_write_set_new();
        WgError err = {0};
        assert_int_not_equal(wg_gltf_write(s, wgt_path(bad[i].path), &bad[i].a, &err), WG_OK);
        if (!strstr(err.message, bad[i].msg))
            fail_msg("case %zu: '%s', expected '%s'", i, err.message, bad[i].msg);
        assert_int_equal(wg_write_set_commit(s, &err), WG_OK);
        wg_write_set_free(s);
        assert_false(wgt_exists(wgt_path(bad[i].path)));
    }
    wg_image_unref(small);
    maps_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_text_asset),
        cmocka_unit_test(test_binary_grid),
        cmocka_unit_test(test_base_colour_alone),
        cmocka_unit_test(test_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
