/* SPDX-License-Identifier: MIT */
/* glTF 2.0 assets of a material: a mesh (a flat square, or a grid displaced by a height map),
 * its material and the textures packed as glTF wants them, staged in a write set so that they
 * replace an earlier asset all together or not at all. The JSON is built with json-c.
 * Textures: base colour (sRGB RGB, or RGBA when the map has alpha), occlusion-roughness-metallic
 * (linear RGB: R occlusion, G roughness, B metallic; also the occlusion texture), normal (RGB),
 * clear coat (R weight, G roughness), clear-coat normal, specular colour (sRGB gray: the
 * specular level s times specularColorFactor 2 makes F0 = 0.04 · 2s = 0.08 s, the level's own
 * convention, with F90 left at 1). Maps that are absent are left out with their extension; a
 * missing occlusion or roughness or metallic map is 1, 1, 0 in the packed texture. The mesh's
 * UVs run from 0 to `repeat`, with repeating samplers; its normals and tangents are given, so
 * a client needs no tangent generation for the normal maps. .gltf: the JSON, PATH.bin with the
 * mesh, and the PNGs beside them by relative URI; .glb: one file with the JSON chunk and a
 * binary chunk holding the mesh and the PNGs. */
#include "internal.h"
#include "wgio.h"
#include "wetgraph/wetgraph.h"

#include <json-c/json.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* The textures of the asset, in the order their images are written. */
enum { TEX_BASE, TEX_ORM, TEX_NORMAL, TEX_COAT, TEX_COAT_NORMAL, TEX_SPECULAR, TEX_COUNT };
static const char *const tex_suffix[TEX_COUNT] = {
    "basecolor", "orm", "normal", "clearcoat", "clearcoat_normal", "specular"};

typedef struct {
    unsigned char *data; /* encoded PNG */
    size_t size;
} Png;

typedef struct {
    unsigned char *data;
    size_t size, cap;
} Bytes;

static int bytes_put(Bytes *b, const void *p, size_t n)
{
    if (b->size + n > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->size + n) cap *= 2;
        unsigned char *d = wg_realloc_array(b->data, b->cap, cap, 1);
        if (!d) return WG_ERR_NOMEM;
        b->data = d, b->cap = cap;
    }
    if (n) memcpy(b->data + b->size, p, n);
    b->size += n;
    return WG_OK;
}

static int bytes_align4(Bytes *b, unsigned char fill)
{
    int rc = WG_OK;
    while (!rc && b->size % 4) rc = bytes_put(b, &fill, 1);
    return rc;
}

/* A map's value at pixel (x, y), channel k (a gray map's only one for every k), clamped to
 * [0, 1]; `def` without a map. */
static float sample(const WgImage *m, int x, int y, int k, float def)
{
    if (!m) return def;
    const float *r = wg_image_row(m, y);
    float v = r[x * m->channels + (m->channels == 1 ? 0 : k)];
    return isfinite(v) ? (v < 0 ? 0 : v > 1 ? 1 : v) : def;
}

static unsigned char code8(float v, bool srgb)
{
    return wg_quantize8(v, srgb);
}

/* One texture as PNG: c channels from the maps, each channel j of pixel (x, y) given by
 * chan(maps, x, y, j). */
typedef float (*Channel)(const WgImage *const *maps, int x, int y, int j);

static float ch_base(const WgImage *const *m, int x, int y, int j)
{
    return sample(m[WG_GLTF_BASE_COLOR], x, y, j, j == 3 ? 1 : 0.5f);
}
static float ch_orm(const WgImage *const *m, int x, int y, int j)
{
    return j == 0   ? sample(m[WG_GLTF_OCCLUSION], x, y, 0, 1)
           : j == 1 ? sample(m[WG_GLTF_ROUGHNESS], x, y, 0, 1)
                    : sample(m[WG_GLTF_METALLIC], x, y, 0, 0);
}
static float ch_normal(const WgImage *const *m, int x, int y, int j)
{
    return sample(m[WG_GLTF_NORMAL], x, y, j, j == 2 ? 1 : 0.5f);
}
static float ch_coat(const WgImage *const *m, int x, int y, int j)
{
    return j == 0   ? sample(m[WG_GLTF_CLEARCOAT], x, y, 0, 1)
           : j == 1 ? sample(m[WG_GLTF_CLEARCOAT_ROUGHNESS], x, y, 0, 0)
                    : 0;
}
static float ch_coat_normal(const WgImage *const *m, int x, int y, int j)
{
    return sample(m[WG_GLTF_CLEARCOAT_NORMAL], x, y, j, j == 2 ? 1 : 0.5f);
}
static float ch_specular(const WgImage *const *m, int x, int y, int j)
{
    (void)j;
    return sample(m[WG_GLTF_SPECULAR], x, y, 0, 0.5f);
}

static int encode_texture(const WgImage *size_of, const WgImage *const *maps, Channel chan, int c,
                          bool srgb, Png *out, const char *path, WgError *err)
{
    int w = size_of->width, h = size_of->height;
    unsigned char *px = wg_malloc((size_t)w * (size_t)h * (size_t)c);
    if (!px) return wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int j = 0; j < c; j++)
                px[((size_t)y * (size_t)w + (size_t)x) * (size_t)c + (size_t)j] =
                    code8(chan(maps, x, y, j), srgb && j < 3);
    char msg[256];
    int rc = wg__png_encode(px, w, h, c, 8, WG_PNG_COMPRESSION_DEFLATE, &out->data, &out->size, msg,
                            sizeof msg);
    wg_free(px);
    if (rc) return wg_error_set_at(err, WG_ERR_IO, path, 0, 0, "cannot encode a texture: %s", msg);
    return WG_OK;
}

/* ---- the mesh ---------------------------------------------------------------------------- */

typedef struct {
    int n_vertices, n_indices;
    float *pos, *normal, *tangent, *uv; /* 3, 3, 4 and 2 floats per vertex */
    uint32_t *index;
    float min[3], max[3];
} Mesh;

static void mesh_free(Mesh *m)
{
    wg_free(m->pos);
    wg_free(m->normal);
    wg_free(m->tangent);
    wg_free(m->uv);
    wg_free(m->index);
}

/* The relief at tile coordinates (u, v) in [0, 1] (v down the image), bilinear, wrapping. */
static double relief(const WgImage *h, double u, double v)
{
    double fx = u * h->width - 0.5, fy = v * h->height - 0.5;
    int x0 = (int)floor(fx), y0 = (int)floor(fy);
    double ax = fx - x0, ay = fy - y0;
    int w = h->width, hh = h->height;
    int xa = ((x0 % w) + w) % w, xb = (xa + 1) % w, ya = ((y0 % hh) + hh) % hh, yb = (ya + 1) % hh;
    double a = sample(h, xa, ya, 0, 1), b = sample(h, xb, ya, 0, 1);
    double c = sample(h, xa, yb, 0, 1), d = sample(h, xb, yb, 0, 1);
    return (a * (1 - ax) + b * ax) * (1 - ay) + (c * (1 - ax) + d * ax) * ay;
}

/* n x n quads over the square x, z in [-0.5, 0.5] (x along u, z along v), y = height_scale ·
 * (h − 1); n = 0 is one flat quad. Counter-clockwise seen from +Y. */
static int mesh_build(const WgGltfAsset *a, Mesh *m)
{
    int n = a->grid > 0 ? a->grid : 1;
    const WgImage *h = a->grid > 0 ? a->maps[WG_GLTF_HEIGHT] : NULL;
    int nv = (n + 1) * (n + 1);
    m->n_vertices = nv;
    m->n_indices = 6 * n * n;
    m->pos = wg_malloc(sizeof(float) * 3 * (size_t)nv);
    m->normal = wg_malloc(sizeof(float) * 3 * (size_t)nv);
    m->tangent = wg_malloc(sizeof(float) * 4 * (size_t)nv);
    m->uv = wg_malloc(sizeof(float) * 2 * (size_t)nv);
    m->index = wg_malloc(sizeof(uint32_t) * (size_t)m->n_indices);
    if (!m->pos || !m->normal || !m->tangent || !m->uv || !m->index) return WG_ERR_NOMEM;
    double hs = h ? a->height_scale : 0, step = 1.0 / n, e = 0.5 / n;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            int k = j * (n + 1) + i;
            double u = (double)i / n, v = (double)j / n;
            double y = h ? hs * (relief(h, u, v) - 1) : 0;
            /* the surface's slopes by central differences (the relief wraps) */
            double dx = h ? hs * (relief(h, u + e, v) - relief(h, u - e, v)) / (2 * e) : 0;
            double dz = h ? hs * (relief(h, u, v + e) - relief(h, u, v - e)) / (2 * e) : 0;
            double nx = -dx, ny = 1, nz = -dz, nl = sqrt(nx * nx + ny * ny + nz * nz);
            double tx = 1, ty = dx, tz = 0, tl = sqrt(tx * tx + ty * ty);
            float p[3] = {(float)(u - 0.5), (float)y, (float)(v - 0.5)};
            memcpy(m->pos + 3 * k, p, sizeof p);
            m->normal[3 * k] = (float)(nx / nl);
            m->normal[3 * k + 1] = (float)(ny / nl);
            m->normal[3 * k + 2] = (float)(nz / nl);
            /* +u, and w = 1: the bitangent cross(N, T) points towards −v, up the image, where
             * glTF's normal maps have +Y */
            m->tangent[4 * k] = (float)(tx / tl);
            m->tangent[4 * k + 1] = (float)(ty / tl);
            m->tangent[4 * k + 2] = (float)(tz / tl);
            m->tangent[4 * k + 3] = 1;
            m->uv[2 * k] = (float)(u * a->repeat);
            m->uv[2 * k + 1] = (float)(v * a->repeat);
            for (int c = 0; c < 3; c++) {
                if (k == 0 || p[c] < m->min[c]) m->min[c] = p[c];
                if (k == 0 || p[c] > m->max[c]) m->max[c] = p[c];
            }
        }
    (void)step;
    int t = 0;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t a0 = (uint32_t)(j * (n + 1) + i), b0 = a0 + 1, c0 = a0 + (uint32_t)n + 1,
                     d0 = c0 + 1;
            uint32_t tri[6] = {a0, c0, d0, a0, d0, b0};
            memcpy(m->index + t, tri, sizeof tri);
            t += 6;
        }
    return WG_OK;
}

/* ---- JSON -------------------------------------------------------------------------------- */

static json_object *num_array(const float *v, int n)
{
    json_object *a = json_object_new_array();
    for (int i = 0; a && i < n; i++) json_object_array_add(a, json_object_new_double(v[i]));
    return a;
}

static json_object *tex_ref(int texture)
{
    json_object *o = json_object_new_object();
    json_object_object_add(o, "index", json_object_new_int(texture));
    return o;
}

/* bufferView of `size` bytes at `offset` of buffer 0 (target 0: none) */
static int add_view(json_object *views, size_t offset, size_t size, int stride, int target)
{
    json_object *v = json_object_new_object();
    json_object_object_add(v, "buffer", json_object_new_int(0));
    json_object_object_add(v, "byteOffset", json_object_new_int64((int64_t)offset));
    json_object_object_add(v, "byteLength", json_object_new_int64((int64_t)size));
    if (stride) json_object_object_add(v, "byteStride", json_object_new_int(stride));
    if (target) json_object_object_add(v, "target", json_object_new_int(target));
    json_object_array_add(views, v);
    return (int)json_object_array_length(views) - 1;
}

static int add_accessor(json_object *accessors, int view, int component, int count,
                        const char *type, const float *min, const float *max, int n_minmax)
{
    json_object *acc = json_object_new_object();
    json_object_object_add(acc, "bufferView", json_object_new_int(view));
    json_object_object_add(acc, "componentType", json_object_new_int(component));
    json_object_object_add(acc, "count", json_object_new_int(count));
    json_object_object_add(acc, "type", json_object_new_string(type));
    if (min) json_object_object_add(acc, "min", num_array(min, n_minmax));
    if (max) json_object_object_add(acc, "max", num_array(max, n_minmax));
    json_object_array_add(accessors, acc);
    return (int)json_object_array_length(accessors) - 1;
}

static bool ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && !strcmp(s + a - b, suffix);
}

/* The file name of a path (for relative URIs). */
static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

int wg_gltf_write(WgWriteSet *s, const char *path, const WgGltfAsset *a, WgError *err)
{
    const WgImage *const *maps = a->maps;
    bool glb = ends_with(path, ".glb");
    if (!glb && !ends_with(path, ".gltf"))
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0,
                               "a glTF asset's file ends in .gltf or .glb");
    if (glb != a->binary)
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0, "a %s asset's file ends in %s",
                               a->binary ? "binary" : "text", a->binary ? ".glb" : ".gltf");
    if (!maps[WG_GLTF_BASE_COLOR])
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0, "a glTF asset needs a base colour");
    if (a->grid > 0 && !maps[WG_GLTF_HEIGHT])
        return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0,
                               "a displaced grid needs a height map");
    if (a->grid < 0 || a->grid > 4096 || !(a->repeat >= 1 && a->repeat <= 1e6) ||
        !isfinite(a->height_scale))
        return wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0,
                               "grid %d, repeat %g or height scale %g out of range (grid 0..4096, "
                               "repeat 1..1e6)",
                               a->grid, a->repeat, a->height_scale);
    const WgImage *ref = maps[WG_GLTF_BASE_COLOR];
    for (int k = 0; k < WG_GLTF_SLOT_COUNT; k++)
        if (maps[k] && k != WG_GLTF_HEIGHT &&
            (maps[k]->width != ref->width || maps[k]->height != ref->height))
            return wg_error_set_at(err, WG_ERR_USAGE, path, 0, 0,
                                   "the asset's maps differ in size (%dx%d and %dx%d)", ref->width,
                                   ref->height, maps[k]->width, maps[k]->height);

    /* which textures there are */
    bool has[TEX_COUNT] = {true,
                           maps[WG_GLTF_METALLIC] || maps[WG_GLTF_ROUGHNESS] ||
                               maps[WG_GLTF_OCCLUSION],
                           maps[WG_GLTF_NORMAL] != NULL,
                           maps[WG_GLTF_CLEARCOAT] != NULL,
                           maps[WG_GLTF_CLEARCOAT] && maps[WG_GLTF_CLEARCOAT_NORMAL],
                           maps[WG_GLTF_SPECULAR] != NULL};
    static const Channel chans[TEX_COUNT] = {ch_base, ch_orm,         ch_normal,
                                             ch_coat, ch_coat_normal, ch_specular};
    int base_channels = ref->channels == 4 ? 4 : 3;
    const int channels[TEX_COUNT] = {base_channels, 3, 3, 3, 3, 3};
    const bool srgb[TEX_COUNT] = {true, false, false, false, false, true};

    Png png[TEX_COUNT] = {0};
    Mesh mesh = {0};
    Bytes bin = {0}, file = {0};
    json_object *root = NULL;
    char *stem = NULL, *aux = NULL;
    int rc = WG_OK;
    for (int t = 0; t < TEX_COUNT && !rc; t++)
        if (has[t])
            rc = encode_texture(ref, maps, chans[t], channels[t], srgb[t], &png[t], path, err);
    if (rc) goto out;
    if ((rc = mesh_build(a, &mesh))) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    size_t stem_len = strlen(path) - (glb ? 4 : 5);
    stem = wg_strndup(path, stem_len);
    aux = wg_malloc(stem_len + 64);
    root = json_object_new_object();
    if (!stem || !aux || !root) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }

    /* the binary buffer: the mesh, then (.glb) the PNGs */
    json_object *views = json_object_new_array(), *accessors = json_object_new_array();
    size_t nv = (size_t)mesh.n_vertices;
    size_t off_pos = bin.size;
    rc = bytes_put(&bin, mesh.pos, 12 * nv);
    size_t off_nrm = bin.size;
    if (!rc) rc = bytes_put(&bin, mesh.normal, 12 * nv);
    size_t off_tan = bin.size;
    if (!rc) rc = bytes_put(&bin, mesh.tangent, 16 * nv);
    size_t off_uv = bin.size;
    if (!rc) rc = bytes_put(&bin, mesh.uv, 8 * nv);
    size_t off_idx = bin.size;
    if (!rc) rc = bytes_put(&bin, mesh.index, 4 * (size_t)mesh.n_indices);
    int img_view[TEX_COUNT];
    for (int t = 0; t < TEX_COUNT && !rc; t++) {
        img_view[t] = -1;
        if (!has[t] || !glb) continue;
        if ((rc = bytes_align4(&bin, 0))) break;
        img_view[t] = add_view(views, bin.size, png[t].size, 0, 0);
        rc = bytes_put(&bin, png[t].data, png[t].size);
    }
    if (!rc) rc = bytes_align4(&bin, 0);
    if (rc) {
        json_object_put(views);
        json_object_put(accessors);
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    enum { ARRAY_BUFFER = 34962, ELEMENT_ARRAY_BUFFER = 34963, FLOAT = 5126, UINT = 5125 };
    int v_pos = add_view(views, off_pos, 12 * nv, 12, ARRAY_BUFFER);
    int v_nrm = add_view(views, off_nrm, 12 * nv, 12, ARRAY_BUFFER);
    int v_tan = add_view(views, off_tan, 16 * nv, 16, ARRAY_BUFFER);
    int v_uv = add_view(views, off_uv, 8 * nv, 8, ARRAY_BUFFER);
    int v_idx = add_view(views, off_idx, 4 * (size_t)mesh.n_indices, 0, ELEMENT_ARRAY_BUFFER);
    int a_pos =
        add_accessor(accessors, v_pos, FLOAT, mesh.n_vertices, "VEC3", mesh.min, mesh.max, 3);
    int a_nrm = add_accessor(accessors, v_nrm, FLOAT, mesh.n_vertices, "VEC3", NULL, NULL, 0);
    int a_tan = add_accessor(accessors, v_tan, FLOAT, mesh.n_vertices, "VEC4", NULL, NULL, 0);
    int a_uv = add_accessor(accessors, v_uv, FLOAT, mesh.n_vertices, "VEC2", NULL, NULL, 0);
    float imax = (float)(mesh.n_vertices - 1), imin = 0;
    int a_idx = add_accessor(accessors, v_idx, UINT, mesh.n_indices, "SCALAR", &imin, &imax, 1);

    json_object *asset = json_object_new_object();
    json_object_object_add(asset, "version", json_object_new_string("2.0"));
    json_object_object_add(asset, "generator",
                           json_object_new_string("wetgraph " WETGRAPH_VERSION));
    json_object_object_add(root, "asset", asset);
    json_object_object_add(root, "scene", json_object_new_int(0));
    json_object *scene = json_object_new_object(), *scene_nodes = json_object_new_array();
    json_object_array_add(scene_nodes, json_object_new_int(0));
    json_object_object_add(scene, "nodes", scene_nodes);
    json_object *scenes = json_object_new_array();
    json_object_array_add(scenes, scene);
    json_object_object_add(root, "scenes", scenes);
    json_object *node = json_object_new_object(), *nodes = json_object_new_array();
    json_object_object_add(node, "name", json_object_new_string(a->name));
    json_object_object_add(node, "mesh", json_object_new_int(0));
    json_object_array_add(nodes, node);
    json_object_object_add(root, "nodes", nodes);

    json_object *attrs = json_object_new_object();
    json_object_object_add(attrs, "POSITION", json_object_new_int(a_pos));
    json_object_object_add(attrs, "NORMAL", json_object_new_int(a_nrm));
    json_object_object_add(attrs, "TANGENT", json_object_new_int(a_tan));
    json_object_object_add(attrs, "TEXCOORD_0", json_object_new_int(a_uv));
    json_object *prim = json_object_new_object();
    json_object_object_add(prim, "attributes", attrs);
    json_object_object_add(prim, "indices", json_object_new_int(a_idx));
    json_object_object_add(prim, "material", json_object_new_int(0));
    json_object *prims = json_object_new_array(), *mesh_o = json_object_new_object();
    json_object_array_add(prims, prim);
    json_object_object_add(mesh_o, "name", json_object_new_string(a->name));
    json_object_object_add(mesh_o, "primitives", prims);
    json_object *meshes = json_object_new_array();
    json_object_array_add(meshes, mesh_o);
    json_object_object_add(root, "meshes", meshes);

    /* images, one sampler (linear, mipmapped, repeating), textures */
    json_object *images = json_object_new_array(), *textures = json_object_new_array();
    int tex_index[TEX_COUNT];
    for (int t = 0; t < TEX_COUNT; t++) {
        tex_index[t] = -1;
        if (!has[t]) continue;
        json_object *img = json_object_new_object();
        if (glb) {
            json_object_object_add(img, "bufferView", json_object_new_int(img_view[t]));
            json_object_object_add(img, "mimeType", json_object_new_string("image/png"));
        } else {
            snprintf(aux, stem_len + 64, "%s_%s.png", base_name(stem), tex_suffix[t]);
            json_object_object_add(img, "uri", json_object_new_string(aux));
        }
        json_object_array_add(images, img);
        json_object *tex = json_object_new_object();
        json_object_object_add(tex, "sampler", json_object_new_int(0));
        json_object_object_add(tex, "source",
                               json_object_new_int((int)json_object_array_length(images) - 1));
        json_object_array_add(textures, tex);
        tex_index[t] = (int)json_object_array_length(textures) - 1;
    }
    json_object *sampler = json_object_new_object(), *samplers = json_object_new_array();
    json_object_object_add(sampler, "magFilter", json_object_new_int(9729));
    json_object_object_add(sampler, "minFilter", json_object_new_int(9987));
    json_object_object_add(sampler, "wrapS", json_object_new_int(10497));
    json_object_object_add(sampler, "wrapT", json_object_new_int(10497));
    json_object_array_add(samplers, sampler);
    json_object_object_add(root, "samplers", samplers);
    json_object_object_add(root, "images", images);
    json_object_object_add(root, "textures", textures);

    /* the material */
    json_object *mat = json_object_new_object(), *pbr = json_object_new_object();
    json_object_object_add(mat, "name", json_object_new_string(a->name));
    json_object_object_add(pbr, "baseColorTexture", tex_ref(tex_index[TEX_BASE]));
    if (has[TEX_ORM]) {
        json_object_object_add(pbr, "metallicRoughnessTexture", tex_ref(tex_index[TEX_ORM]));
        if (maps[WG_GLTF_OCCLUSION])
            json_object_object_add(mat, "occlusionTexture", tex_ref(tex_index[TEX_ORM]));
    }
    /* without maps: a rough dielectric, as the packed texture's defaults */
    json_object_object_add(pbr, "metallicFactor", json_object_new_double(has[TEX_ORM] ? 1 : 0));
    json_object_object_add(pbr, "roughnessFactor", json_object_new_double(1));
    json_object_object_add(mat, "pbrMetallicRoughness", pbr);
    if (has[TEX_NORMAL])
        json_object_object_add(mat, "normalTexture", tex_ref(tex_index[TEX_NORMAL]));
    json_object *ext = json_object_new_object(), *used = json_object_new_array();
    if (has[TEX_COAT]) {
        json_object *cc = json_object_new_object();
        json_object_object_add(cc, "clearcoatFactor", json_object_new_double(1));
        json_object_object_add(cc, "clearcoatTexture", tex_ref(tex_index[TEX_COAT]));
        json_object_object_add(cc, "clearcoatRoughnessFactor", json_object_new_double(1));
        json_object_object_add(cc, "clearcoatRoughnessTexture", tex_ref(tex_index[TEX_COAT]));
        if (has[TEX_COAT_NORMAL])
            json_object_object_add(cc, "clearcoatNormalTexture",
                                   tex_ref(tex_index[TEX_COAT_NORMAL]));
        json_object_object_add(ext, "KHR_materials_clearcoat", cc);
        json_object_array_add(used, json_object_new_string("KHR_materials_clearcoat"));
    }
    if (has[TEX_SPECULAR]) {
        json_object *sp = json_object_new_object(), *ior = json_object_new_object();
        float two[3] = {2, 2, 2};
        json_object_object_add(sp, "specularColorFactor", num_array(two, 3));
        json_object_object_add(sp, "specularColorTexture", tex_ref(tex_index[TEX_SPECULAR]));
        json_object_object_add(ext, "KHR_materials_specular", sp);
        json_object_array_add(used, json_object_new_string("KHR_materials_specular"));
        json_object_object_add(ior, "ior", json_object_new_double(1.5));
        json_object_object_add(ext, "KHR_materials_ior", ior);
        json_object_array_add(used, json_object_new_string("KHR_materials_ior"));
    }
    if (json_object_array_length(used)) {
        json_object_object_add(mat, "extensions", ext);
        json_object_object_add(root, "extensionsUsed", used);
    } else {
        json_object_put(ext);
        json_object_put(used);
    }
    json_object *materials = json_object_new_array();
    json_object_array_add(materials, mat);
    json_object_object_add(root, "materials", materials);

    json_object *buffer = json_object_new_object(), *buffers = json_object_new_array();
    json_object_object_add(buffer, "byteLength", json_object_new_int64((int64_t)bin.size));
    if (!glb) {
        snprintf(aux, stem_len + 64, "%s.bin", base_name(stem));
        json_object_object_add(buffer, "uri", json_object_new_string(aux));
    }
    json_object_array_add(buffers, buffer);
    json_object_object_add(root, "buffers", buffers);
    json_object_object_add(root, "bufferViews", views);
    json_object_object_add(root, "accessors", accessors);

    const char *json = json_object_to_json_string_ext(
        root, glb ? JSON_C_TO_STRING_PLAIN : JSON_C_TO_STRING_PRETTY | JSON_C_TO_STRING_SPACED);
    if (!json) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    size_t json_len = strlen(json);
    if (glb) {
        /* header, JSON chunk padded with spaces, BIN chunk padded with zeros */
        size_t json_padded = (json_len + 3) & ~(size_t)3;
        uint32_t total = (uint32_t)(12 + 8 + json_padded + 8 + bin.size);
        uint32_t head[5] = {0x46546C67u, 2, total, (uint32_t)json_padded, 0x4E4F534Au};
        uint32_t bin_head[2] = {(uint32_t)bin.size, 0x004E4942u};
        if ((uint64_t)12 + 8 + json_padded + 8 + bin.size > 0xffffffffu) {
            rc = wg_error_set_at(err, WG_ERR_RANGE, path, 0, 0,
                                 "the asset is larger than a .glb can hold (4 GiB)");
            goto out;
        }
        rc = bytes_put(&file, head, sizeof head);
        if (!rc) rc = bytes_put(&file, json, json_len);
        if (!rc) rc = bytes_align4(&file, ' ');
        if (!rc) rc = bytes_put(&file, bin_head, sizeof bin_head);
        if (!rc) rc = bytes_put(&file, bin.data, bin.size);
        if (rc) {
            rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
            goto out;
        }
        rc = wg_write_set_bytes(s, path, file.data, file.size, err);
        goto out;
    }
    rc = wg_write_set_bytes(s, path, json, json_len, err);
    snprintf(aux, stem_len + 64, "%s.bin", stem);
    if (!rc) rc = wg_write_set_bytes(s, aux, bin.data, bin.size, err);
    for (int t = 0; t < TEX_COUNT && !rc; t++) {
        if (!has[t]) continue;
        snprintf(aux, stem_len + 64, "%s_%s.png", stem, tex_suffix[t]);
        rc = wg_write_set_bytes(s, aux, png[t].data, png[t].size, err);
    }
out:
    for (int t = 0; t < TEX_COUNT; t++) wg_free(png[t].data);
    mesh_free(&mesh);
    wg_free(bin.data);
    wg_free(file.data);
    wg_free(stem);
    wg_free(aux);
    if (root) json_object_put(root);
    return rc;
}
