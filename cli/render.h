/* SPDX-License-Identifier: MIT */
/* `wetgraph render`'s options and the pieces its frame-sequence mode (cli/frames.c), its batch
 * mode (cli/batch.c) and `wetgraph watch` (cli/watch.c) share with the single render
 * (cli/render.c). */
#ifndef WETGRAPH_CLI_RENDER_H
#define WETGRAPH_CLI_RENDER_H

#include "cli.h"

#include <stddef.h>
#include <stdint.h>

enum { MAX_FRAME = 9999999, MAX_FRAMES = 100000, MAX_SHARDS = 1000000 };

/* A batch row as file names see it: its number, and its fields' column names and values. */
typedef struct {
    int index;
    int n;
    const char *const *columns; /* "input:NAME", "set:NAME", "#NAME", "out" */
    const char *const *values;
} BatchRowInfo;

typedef struct {
    const char *cmd, *help; /* the subcommand and its --help text (default: render's) */
    const char *file, *out_dir, *layered, *cache, *contact_sheet, *batch;
    const char **sets, **inputs, **outputs;
    int n_sets, n_inputs, n_outputs;
    const char **formats; /* --format NAME=FMT: one output's format */
    int n_formats;
    const char *name; /* --name PATTERN (NULL: {graph}_{output}, with _{frame} in a sequence) */
    const BatchRowInfo *row; /* the batch row being written, for {row} and its columns */
    int width, height, threads, format;
    int png_compression; /* --png-compression, -1 when not given */
    bool has_seed, has_time, has_frames, has_fps, quiet, stats, stats_json, no_fuse;
    bool has_shard, batch_json;
    int shard_index, shard_count;
    const char *shard_by; /* --shard-by COLUMN: rows of one value stay on one shard */
    uint64_t seed;
    double time, fps;
    int frame_first, frame_last;
    size_t budget;
    uint64_t cache_max; /* --cache-max: bytes the cache folder keeps after a render */
    bool has_cache_max;
    char file_found[4096]; /* the graph file `file` names (cli_find_graph) */
} Options;

/* Parse render's options into o (o->cmd and o->help may be set first); returns 0, 1 after
 * printing the help, or EXIT_USAGE after printing a usage error. */
int parse_args(int argc, char **argv, Options *o);
/* A request for g with the command line's --set, --input, --output, --size, --seed and
 * --time; the caller owns *out (also on failure, when it is not NULL). */
int build_request(const Options *o, const WgGraph *g, WgRequest **out, WgError *err);
/* The path output i of res is written to (frame >= 0: with "_<frame>"). */
/* An output's format: its --format NAME=FMT, else --format FMT, else the graph's. */
WgFormat output_format(const Options *o, const char *output, WgFormat graph_format);
/* A PNG output's compression: --png-compression, else the graph's. */
WgPngCompression output_compression(const Options *o, WgPngCompression graph_compression);
/* The file of output `name` (extension from f): --name's pattern, or {graph}_{output}[_{frame}],
 * in the output folder. Returns false when the pattern names what is not there (a batch column
 * outside a batch). */
bool output_file(const Options *o, const WgGraph *g, const char *name, WgFormat f, int frame,
                 char *buf, size_t size);
/* The file of glTF asset i (extension .gltf or .glb): --name's pattern with {output} the
 * asset's name and {group} "gltf", or {graph}_{name}[_{frame}]; false as output_file. */
bool gltf_file(const Options *o, const WgGraph *g, int i, int frame, char *buf, size_t size);
/* The folder of a file --name puts below the output folder, made when missing. */
int name_folder(const char *path, WgError *err);
/* --name's pattern holds only placeholders it can fill (frames and batch: whether the render
 * has them); false with why otherwise. */
bool name_pattern_check(const char *pattern, bool frames, bool batch, char *why, size_t size);
/* Before rendering: every --format NAME=FMT names an output, and no two of the files the render
 * writes (outputs and glTF assets; frame >= 0 in a sequence) are one file. */
int output_files_check(const Options *o, const WgGraph *g, const WgRequest *r, int frame,
                       WgError *err);
void output_path(const Options *o, const WgGraph *g, const WgResult *res, int i, int frame,
                 char *buf, size_t size);
/* The graph's glTF assets (cli/gltf_export.c): whether asset i is rendered (no --output, or
 * its name among them); whether an output is a map of one of those; the outputs of the maps of
 * the assets named by --output, added to r; and the assets staged in `set`, each map's image
 * from image_of(user, output name), their paths in paths[0..*n_paths). */
typedef const WgImage *(*GltfImageOf)(void *user, const char *output);
bool gltf_selected(const Options *o, const WgGraph *g, int i);
bool gltf_needs_output(const Options *o, const WgGraph *g, const char *output);
int gltf_request_outputs(const Options *o, const WgGraph *g, WgRequest *r, WgError *err);
/* Stage the selected assets of res's render (their height_scale is res's) into set. */
int gltf_stage(const Options *o, const WgGraph *g, const WgResult *res, GltfImageOf image_of,
               void *user, int frame, WgWriteSet *set, char (*paths)[4096], int *n_paths,
               WgError *err);
const WgImage *gltf_image_of_result(void *user, const char *output); /* user: a WgResult */
/* With --cache-max: remove the cache folder's least recently used entries until it holds at
 * most that much (with --stats, say what went, on stderr). */
void prune_cache(const Options *o);
/* Write every output of res (frame >= 0: with "_<frame>" in the names), all or none. */
int write_outputs(const Options *o, const WgGraph *g, const WgResult *res, int frame, WgError *err);
/* The same, leaving out (not writing, not listing) the separate files of the outputs i with
 * kept[i] true: their files already hold these images. kept NULL: none. */
int write_outputs_except(const Options *o, const WgGraph *g, const WgResult *res, int frame,
                         const bool *kept, WgError *err);
/* Outputs streamed (cli/render.c): written while the render runs, all or none. stream_new
 * makes the output folder and the state for one render (frame >= 0: with "_<frame>" in the
 * names; keep_first: keep output 0's image for stream_first); give the request
 * wg_request_set_output_fn(r, stream_output, s), render, then stream_finish(s, the render's
 * result and status) renames the files into place (only when that status is WG_OK) and frees s. */
typedef struct Stream Stream;
int stream_new(const Options *o, const WgGraph *g, int frame, bool keep_first, Stream **out,
               WgError *err);
int stream_output(void *user, const WgOutputInfo *out, WgError *err);
/* For wg_request_set_output_held(r, stream_held, s): the outputs whose files already hold them
 * are neither computed, read nor written. */
bool stream_held(void *user, const WgOutputInfo *out);
int stream_finish(Stream *s, const WgResult *res, int render_rc, WgError *err);
/* The time of the output calls of the last stream_finish that succeeded, summed (ms). */
double stream_last_output_ms(void);
/* What the last stream_finish that succeeded did with its outputs' files: encoded, staged as
 * copies of identical files (another output's of the render, the previous frame's), left as they
 * were (they held the images already). */
void stream_last_files(int *written, int *copied, int *kept);
/* Output 0's image (NULL unless kept) and its colour space; owned by the stream. */
const WgImage *stream_first(const Stream *s, WgColorspace *cs);
/* The per-node table (stderr) or JSON (stdout) of one render. */
void print_stats(const WgEngine *e, const WgResult *res, bool json);
/* path with "_<frame>" (4 digits at least) before its extension; path itself for frame < 0. */
void frame_path(const char *path, int frame, char *buf, size_t size);
/* Frames o->frame_first..o->frame_last of request r with engine e (cli/frames.c). */
int render_frames(const Options *o, const WgGraph *g, WgRequest *r, WgEngine *e, WgError *err);

/* `render --batch LIST` (cli/batch.c): every row of LIST through one engine; returns the exit
 * status. */
int render_batch(const Options *o, const WgGraph *g);

#endif
