/* SPDX-License-Identifier: MIT */
/* Image files: reading any format OpenImageIO knows, writing PNG 8/16, TIFF 16 and EXR
 * half/float, and one multi-layer EXR through OpenEXR's C API. Every write goes to a temporary
 * file in the destination folder and is renamed over the target only when complete, so a failed
 * write never leaves a partial file or damages an existing one. */
#ifndef WETGRAPH_IO_H
#define WETGRAPH_IO_H

#include "error.h"
#include "image.h"
#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    WG_FORMAT_DEFAULT = 0, /* png16 for gray, png for colour */
    WG_FORMAT_PNG,         /* 8-bit */
    WG_FORMAT_PNG16,
    WG_FORMAT_TIF16,
    WG_FORMAT_EXR,   /* half */
    WG_FORMAT_EXR32, /* float */
    WG_FORMAT_JPEG,  /* 8-bit, lossy, no alpha (quality: wg_set_jpeg_quality) */
    WG_FORMAT_TGA,   /* 8-bit Targa */
} WgFormat;

typedef enum { WG_LINEAR = 0, WG_SRGB = 1 } WgColorspace;

/* How PNG files are compressed (other formats ignore it). FAST, the default, chooses the filter
 * on one row in 32 and codes the rows with one Huffman code and runs of equal bytes; DEFLATE
 * filters every row with the best of the five PNG filters and deflates with libdeflate's level 1
 * (string matching: about 4x slower, files the same size on maps made from photographs, up to
 * about a tenth smaller on images that repeat themselves, such as screenshots or procedural
 * patterns); NONE writes the rows unfiltered in stored deflate blocks (fastest, files of the raw
 * image size). */
typedef enum {
    WG_PNG_COMPRESSION_FAST = 0,
    WG_PNG_COMPRESSION_DEFLATE,
    WG_PNG_COMPRESSION_NONE,
} WgPngCompression;
/* "fast", "deflate", "none" -> compression; -1 when unknown. */
int wg_png_compression_parse(const char *name);
const char *wg_png_compression_name(WgPngCompression c);

/* "png", "png16", ... -> format; -1 when unknown. */
/* The quality (1..100, default 92) of every JPEG this process writes from now on. */
void wg_set_jpeg_quality(int quality);
int wg_format_parse(const char *name);
const char *wg_format_name(WgFormat f);
const char *wg_format_extension(WgFormat f); /* "png", "tif", "exr" */

/* Size and channel count of an image file without decoding its pixels. */
int wg_image_probe(const char *path, int *width, int *height, int *channels, WgError *err);

/* Read a file as float. channels: 1 or 4 to convert, 0 to keep (1-2 channels -> gray, 3-4 ->
 * RGBA). SRGB decodes the colour channels to linear (values the curve takes past the float range
 * saturate at FLT_MAX). Non-finite values are an error.
 * The caller owns *out. */
int wg_image_read(const char *path, int channels, WgColorspace cs, WgImage **out, WgError *err);
/* Read a file into an existing image of the file's size (or of a size wg_image_decode_size
 * gives), converting to its channel count as wg_image_read does. Decodes a strip of rows at a
 * time: beside `dst` it needs only what wg_image_read_scratch says. */
int wg_image_read_into(const char *path, WgColorspace cs, WgImage *dst, WgError *err);
/* The size wg_image_read_into reads `path` at for a picture of width x height: the file's own
 * size, or, for a JPEG larger than that, the smallest of its DCT scales (each side n/8 of the
 * file's, rounded up, n = 1..7) with both sides at least width and height, which libjpeg decodes
 * in a fraction of the time of the whole. Resample the result to the size wanted. */
int wg_image_decode_size(const char *path, int width, int height, int *dw, int *dh, WgError *err);
/* Memory that reading this file needs beyond the destination image: the decoder's own buffer
 * (the whole file at its native type for formats decoded at once, such as PNG) and a strip of
 * rows. 0 when the file cannot be opened. */
size_t wg_image_read_scratch(const char *path);

/* Write atomically, encoding a strip of rows at a time (no copy of the whole image). Gray images
 * are written with 1 channel; colour images as RGB when every alpha is 1, else RGBA. Integer
 * formats clamp to [0,1] and round to nearest; SRGB encodes the colour channels (EXR is always
 * linear and ignores it). NaN is written as 0 in integer files. */
int wg_image_write(const char *path, const WgImage *img, WgFormat format, WgColorspace cs,
                   WgError *err);

/* One EXR with a layer per image: gray images become channel "<name>.Y", colour images
 * "<name>.R/G/B/A". half or float, ZIP compression. Written atomically. */
int wg_exr_write_layers(const char *path, int count, const char *const *names,
                        const WgImage *const *images, bool half, WgError *err);

/* sRGB transfer functions (IEC 61966-2-1), exact formulas in double. */
float wg_srgb_to_linear(float v);
float wg_linear_to_srgb(float v);
/* The code an 8-bit file stores for v: NaN as 0, sRGB-encoded first (wg_linear_to_srgb) when
 * srgb, clamped to [0, 1], rounded to nearest (floor(x * 255 + 0.5)). The sRGB case looks the
 * value up in a table of the 255 thresholds between codes (no pow): bit-identical. */
uint8_t wg_quantize8(float v, bool srgb);

/* Write sets: several files replaced together. Each add writes one complete file to a
 * temporary beside its target (same folder, hidden name ".NAME.tmpPID-N-HOST.EXT" with this
 * process's id and 8 hex digits identifying this machine) and flushes it to the disk; the targets
 * are untouched. Commit then renames every temporary over its target in one tight loop, after
 * checking that no target is a folder, and flushes the folders. If an add fails, the caller frees
 * the set and no target changes. If a rename fails (rare: the target changed meanwhile), the files
 * before it are replaced and the ones from it on are not; their temporaries are removed and the
 * error names the file, the cause and both lists. Freeing a set removes the temporaries it still
 * holds. A target whose name has the form of a temporary is refused. */
typedef struct WgWriteSet WgWriteSet;
WgWriteSet *wg_write_set_new(void); /* NULL when out of memory; free with wg_write_set_free */
/* Same conversions as wg_image_write. */
int wg_write_set_image(WgWriteSet *s, const char *path, const WgImage *img, WgFormat format,
                       WgColorspace cs, WgError *err);
/* The same, a PNG compressed as `png` says. */
int wg_write_set_image_png(WgWriteSet *s, const char *path, const WgImage *img, WgFormat format,
                           WgColorspace cs, WgPngCompression png, WgError *err);
/* Threads and memory a writer may borrow (an output function gets a render's in
 * WgOutputInfo.workers). run(ctx, n, fn, user) calls fn(user, i0, i1) on ranges that together
 * cover [0, n) once each, on whichever threads it has (the calling one among them), and returns
 * when all are done: 0, or nonzero when it stopped early, and then the work is dropped (a
 * render's workers never stop early, also when the render is cancelled meanwhile). alloc(ctx,
 * bytes) gives a scratch buffer (NULL when out of memory), from a pool whose buffers were touched
 * before where it has one, and free(ctx, p, bytes) gives it back. */
typedef struct WgWorkers {
    int (*run)(const void *ctx, int n, void (*fn)(void *user, int i0, int i1), void *user);
    void *(*alloc)(const void *ctx, size_t bytes);
    void (*free)(const void *ctx, void *p, size_t bytes);
    const void *ctx;
} WgWorkers;
/* Workers of their own: each run starts *threads threads (0: one per core, never more than the
 * parts nor 256), the calling one among them, which take the parts one at a time; no scratch
 * memory of their own (writers then use new memory). For a writer called outside a render,
 * whose workers are gone. *threads must outlive the workers' use. */
WgWorkers wg_workers_threads(const int *threads);
/* wg_write_set_image_png with the PNG's rows filtered and coded in pieces run by `workers`, in
 * their scratch memory (NULL: on this thread, in new memory): the same file, sooner when other
 * threads are idle. Other formats are written as by wg_write_set_image_png. */
int wg_write_set_image_png_on(WgWriteSet *s, const char *path, const WgImage *img, WgFormat format,
                              WgColorspace cs, WgPngCompression png, const WgWorkers *workers,
                              WgError *err);
/* wg_write_set_image_png_on for a caller that has already looked at a colour image's alpha (as
 * while hashing its rows): alpha_one 1 when every alpha is 1 (the file is written without alpha
 * where its format allows), 0 when one is not, -1 when not known (the writer reads the image to
 * find out). A colour image's layout then follows alpha_one without the image being read again:
 * it must be true of the image. Ignored for gray images. */
int wg_write_set_image_alpha_on(WgWriteSet *s, const char *path, const WgImage *img,
                                WgFormat format, WgColorspace cs, WgPngCompression png,
                                const WgWorkers *workers, int alpha_one, WgError *err);
/* Several images at once, the same as adding each with wg_write_set_image_png (png NULL: every
 * PNG compressed by default), but encoded and flushed by `threads` threads (0: one per core)
 * concurrently. If any fails, none of the n is added (their temporaries are removed) and err is
 * the failure of the first in order. */
int wg_write_set_images(WgWriteSet *s, int n, const char *const *paths,
                        const WgImage *const *images, const WgFormat *formats,
                        const WgColorspace *cs, const WgPngCompression *png, int threads,
                        WgError *err);
/* Same layout as wg_exr_write_layers. */
int wg_write_set_exr_layers(WgWriteSet *s, const char *path, int count, const char *const *names,
                            const WgImage *const *images, bool half, WgError *err);
/* The same with the file's chunks converted and compressed by `workers` (NULL: on this thread),
 * a window of them at a time, then written in order: the same file, sooner on several threads. */
int wg_write_set_exr_layers_on(WgWriteSet *s, const char *path, int count, const char *const *names,
                               const WgImage *const *images, bool half, const WgWorkers *workers,
                               WgError *err);
/* Move every file staged in `from` to the end of `into`, in order (a set per thread can be
 * filled concurrently, then gathered for one commit); `from` is empty afterwards. When out of
 * memory both sets are left as they were. */
int wg_write_set_move(WgWriteSet *into, WgWriteSet *from, WgError *err);
/* Rename everything into place; the set is empty afterwards, whatever the outcome. */
/* Stage the file `path` with the bytes of the k-th file staged in `from` (0 the first): an
 * image the same as one already staged is copied instead of encoded again. */
int wg_write_set_copy(WgWriteSet *s, const char *path, const WgWriteSet *from, int k, WgError *err);
/* Stage the file `path` with the bytes of the file `source` (a file in place, such as the
 * previous frame's of a sequence whose output did not change). */
int wg_write_set_copy_file(WgWriteSet *s, const char *path, const char *source, WgError *err);
/* Stage `size` bytes of `data` as the file `path`. */
int wg_write_set_bytes(WgWriteSet *s, const char *path, const void *data, size_t size,
                       WgError *err);
int wg_write_set_commit(WgWriteSet *s, WgError *err);
void wg_write_set_free(WgWriteSet *s);

/* Remove, from the folder `dir`, the temporaries of writers that no longer run: regular files
 * named like a write set's temporaries of this machine whose process id belongs to no live
 * process (a render killed with SIGKILL or by a power cut leaves them). Another machine's
 * temporaries, and those whose name has no machine id (earlier versions), cannot be checked:
 * they are removed only when not modified for 24 hours. Temporaries of live processes and every
 * other file are kept. Best effort; returns how many were removed. */
int wg_remove_stale_temporaries(const char *dir);

/* ---- glTF 2.0 ----------------------------------------------------------------------------- */

/* The maps of a material for a glTF asset. Colour maps are linear RGB(A) images (the base colour
 * and specular level are written sRGB, as glTF wants); normal maps are tangent-space normals
 * encoded 0..1, OpenGL convention (green up), as glTF's are; gray maps are 0..1. */
typedef enum {
    WG_GLTF_BASE_COLOR,          /* colour */
    WG_GLTF_METALLIC,            /* gray \                                                   */
    WG_GLTF_ROUGHNESS,           /* gray  } one texture: R occlusion, G roughness, B metallic */
    WG_GLTF_OCCLUSION,           /* gray /                                                    */
    WG_GLTF_NORMAL,              /* colour */
    WG_GLTF_SPECULAR,            /* gray: specular level, 0.5 = F0 0.04 (KHR_materials_specular) */
    WG_GLTF_CLEARCOAT,           /* gray: the coat's weight \ one texture: R weight, G roughness */
    WG_GLTF_CLEARCOAT_ROUGHNESS, /* gray                    / (KHR_materials_clearcoat)          */
    WG_GLTF_CLEARCOAT_NORMAL,    /* colour */
    WG_GLTF_HEIGHT,              /* gray: the grid's relief, 1 the tile's plane, 0 height_scale
                                    below it */
    WG_GLTF_SLOT_COUNT
} WgGltfSlot;

typedef struct WgGltfAsset {
    const char *name;                        /* the material's and the mesh's name */
    const WgImage *maps[WG_GLTF_SLOT_COUNT]; /* NULL where the material has none */
    bool binary;         /* one .glb holding everything, else .gltf + .bin + PNG textures */
    int grid;            /* 0: a flat square of 4 vertices; N >= 1: N x N quads displaced by
                            the HEIGHT map (needed then) */
    double height_scale; /* tile widths between height 1 and height 0 (grid only) */
    double repeat;       /* the texture repeats this many times across the tile (>= 1) */
} WgGltfAsset;

/* Stage a glTF 2.0 asset in s: the tile as a square one unit wide in the XZ plane (Y up,
 * centred on the origin) with its material, the core metallic-roughness maps plus the
 * KHR_materials_clearcoat, KHR_materials_specular and KHR_materials_ior extensions where their
 * maps are given. `path` ends in .gltf (then PATH.bin and PATH-without-extension_<map>.png are
 * staged beside it) or .glb (when binary). */
int wg_gltf_write(WgWriteSet *s, const char *path, const WgGltfAsset *a, WgError *err);

#ifdef __cplusplus
}
#endif
#endif

