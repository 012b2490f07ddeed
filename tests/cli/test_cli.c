/* SPDX-License-Identifier: MIT */
/* The wetgraph command (WETGRAPH_BIN): exit codes (0 ok, 1 evaluation or I/O failure, 2 usage
 * or graph error), help and error messages, every render option and the files it writes (or,
 * on failure, does not write), and the check, info, nodes and dot subcommands.
 *
 * Commands that do not depend on each other run as one concurrent batch (a command that loads
 * OpenImageIO takes about 0.2 s to start), each with its own stdout and stderr files, and every
 * command checks as much as it can. */
#include "wgtest.h"

#include "internal.h"
#include "wgio.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

/* ---- running the command ----------------------------------------------------------------- */

typedef struct {
    const char *args; /* shell fragment after `wetgraph` */
    int status;
    char *out, *err;
} Cmd;

static char *slurp(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        if (size) *size = 0;
        return NULL;
    }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *buf = malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    buf[n] = '\0';
    fclose(f);
    if (size) *size = (size_t)n;
    return buf;
}

/* The scratch folder commands run in. */
static const char *work(void)
{
    static char dir[1024];
    if (!dir[0]) {
        snprintf(dir, sizeof dir, "%s/work", wgt_tmpdir());
        mkdir(dir, 0777);
    }
    return dir;
}

/* work()/name in a rotating buffer */
static const char *at(const char *name)
{
    static char buf[8][1200];
    static int next;
    char *p = buf[next++ & 7];
    snprintf(p, sizeof buf[0], "%s/%s", work(), name);
    return p;
}

/* Run every command concurrently in work() and collect status, stdout and stderr. */
static void run_batch(Cmd *cmds, int n)
{
    const char *bin = getenv("WETGRAPH_BIN");
    if (!bin || !bin[0]) fail_msg("WETGRAPH_BIN is not set");
    char script[1200];
    snprintf(script, sizeof script, "%s/batch.sh", wgt_tmpdir());
    FILE *f = fopen(script, "w");
    assert_non_null(f);
    fprintf(f, "cd '%s' || exit 99\n", work());
    for (int i = 0; i < n; i++)
        fprintf(f, "'%s' %s >'%s/out%d' 2>'%s/err%d' </dev/null & p%d=$!\n", bin, cmds[i].args,
                wgt_tmpdir(), i, wgt_tmpdir(), i, i);
    for (int i = 0; i < n; i++)
        fprintf(f, "wait $p%d; echo $? >'%s/status%d'\n", i, wgt_tmpdir(), i);
    fclose(f);
    char cmd[1300];
    snprintf(cmd, sizeof cmd, "sh '%s'", script);
    if (system(cmd) != 0) fail_msg("the batch script failed");
    for (int i = 0; i < n; i++) {
        char p[1200];
        snprintf(p, sizeof p, "%s/status%d", wgt_tmpdir(), i);
        char *st = slurp(p, NULL);
        if (!st) fail_msg("no status for '%s'", cmds[i].args);
        cmds[i].status = atoi(st);
        free(st);
        snprintf(p, sizeof p, "%s/out%d", wgt_tmpdir(), i);
        cmds[i].out = slurp(p, NULL);
        snprintf(p, sizeof p, "%s/err%d", wgt_tmpdir(), i);
        cmds[i].err = slurp(p, NULL);
        if (!cmds[i].out) cmds[i].out = calloc(1, 1);
        if (!cmds[i].err) cmds[i].err = calloc(1, 1);
    }
}

static void free_batch(Cmd *cmds, int n)
{
    for (int i = 0; i < n; i++) {
        free(cmds[i].out);
        free(cmds[i].err);
        cmds[i].out = cmds[i].err = NULL;
    }
}

static void expect_status(const Cmd *c, int status)
{
    if (c->status != status)
        fail_msg("'wetgraph %s' exited %d, expected %d\nstdout:\n%s\nstderr:\n%s", c->args,
                 c->status, status, c->out, c->err);
}

static void expect_in(const char *haystack, const char *needle, const Cmd *c, const char *where)
{
    if (!strstr(haystack, needle))
        fail_msg("'wetgraph %s': expected '%s' in %s:\n%s", c->args, needle, where, haystack);
}
#define OUT_HAS(c, s) expect_in((c)->out, s, c, "stdout")
#define ERR_HAS(c, s) expect_in((c)->err, s, c, "stderr")

/* One command on its own. */
static void run1(Cmd *c)
{
    run_batch(c, 1);
}

static bool exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static int count_files(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) n++;
    closedir(d);
    return n;
}

static void rm_rf(const char *path)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", path);
    if (system(cmd) != 0) fail_msg("cannot remove %s", path);
}

static WgImage *read_image(const char *path)
{
    WgImage *img = NULL;
    WgError err = {0};
    if (wg_image_read(path, 0, WG_LINEAR, &img, &err)) fail_msg("read %s: %s", path, err.message);
    return img;
}

/* Integer value after "key": in a JSON text (first occurrence). */
static long long json_int(const char *json, const char *key)
{
    char pat[128];
    snprintf(pat, sizeof pat, "\"%s\": ", key);
    const char *p = strstr(json, pat);
    if (!p) fail_msg("no %s in:\n%s", key, json);
    return strtoll(p + strlen(pat), NULL, 10);
}

static int count_substr(const char *s, const char *needle)
{
    int n = 0;
    for (const char *p = strstr(s, needle); p; p = strstr(p + 1, needle)) n++;
    return n;
}

/* ---- files used by the tests ------------------------------------------------------------- */

static const char *const main_graph =
    "<wetgraph version=\"1\" size=\"16x8\" seed=\"3\">\n"
    "  <param name=\"level\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\" label=\"Level\"/>\n"
    "  <param name=\"mode\" type=\"enum\" values=\"add|multiply\" default=\"multiply\"/>\n"
    "  <input name=\"base\" type=\"color\" default=\"0.2 0.3 0.4 1\"/>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=level\"/>\n"
    "  <node id=\"t\" type=\"uniform\" value=\"=$time\"/>\n"
    "  <node id=\"s\" type=\"uniform\" value=\"=$seed / 100\"/>\n"
    "  <node id=\"b\" type=\"blur\" sigma=\"1\"><in name=\"source\" from=\"u\"/></node>\n"
    "  <node id=\"c\" type=\"blend\" mode=\"=mode\"><in name=\"foreground\" from=\"b\"/>"
    "<in name=\"background\" from=\"$base\"/></node>\n"
    "  <output name=\"mask\" from=\"b\" format=\"png16\"/>\n"
    "  <output name=\"color\" from=\"c\"/>\n"
    "  <output name=\"time\" from=\"t\" format=\"exr32\"/>\n"
    "  <output name=\"seed\" from=\"s\" format=\"exr32\"/>\n"
    "</wetgraph>\n";

/* unknown node type on line 3 */
static const char *const bad_graph =
    "<wetgraph version=\"1\" size=\"8\">\n"
    "  <node id=\"u\" type=\"uniform\"/>\n"
    "  <node id=\"x\" type=\"bluur\"><in name=\"source\" from=\"u\"/></node>\n"
    "  <output name=\"out\" from=\"x\"/>\n"
    "</wetgraph>\n";

/* unknown name in an expression on line 2 */
static const char *const bad2_graph = "<wetgraph version=\"1\" size=\"8\">\n"
                                      "  <node id=\"u\" type=\"uniform\" value=\"=nope\"/>\n"
                                      "  <output name=\"out\" from=\"u\"/>\n"
                                      "</wetgraph>\n";

/* a value out of range only once the expression is evaluated (line 4) */
static const char *const range_graph =
    "<wetgraph version=\"1\" size=\"8\">\n"
    "  <param name=\"s\" type=\"float\" default=\"1\"/>\n"
    "  <node id=\"u\" type=\"uniform\"/>\n"
    "  <node id=\"b\" type=\"blur\" sigma=\"=s - 5\"><in name=\"source\" from=\"u\"/></node>\n"
    "  <output name=\"out\" from=\"b\"/>\n"
    "</wetgraph>\n";

/* an input without default that sets the size */
static const char *const input_graph =
    "<wetgraph version=\"1\" size=\"$src\">\n"
    "  <input name=\"src\" type=\"gray\"/>\n"
    "  <node id=\"inv\" type=\"invert\"><in name=\"source\" from=\"$src\"/></node>\n"
    "  <node id=\"blur\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"$src\"/></node>\n"
    "  <output name=\"inv\" from=\"inv\"/>\n"
    "  <output name=\"blur\" from=\"blur\"/>\n"
    "</wetgraph>\n";

/* an image node reading `file` on line 2 */
static void write_image_graph(const char *name, const char *file)
{
    char xml[1024];
    snprintf(xml, sizeof xml,
             "<wetgraph version=\"1\" size=\"32\">\n"
             "  <node id=\"pic\" type=\"image\" path=\"%s\"/>\n"
             "  <node id=\"inv\" type=\"invert\"><in name=\"source\" from=\"pic\"/></node>\n"
             "  <output name=\"inv\" from=\"inv\"/>\n"
             "</wetgraph>\n",
             file);
    wgt_write_file(at(name), xml);
}

static double noise_fn(int x, int y, int k)
{
    (void)k;
    return (wg_hash3((uint32_t)x, (uint32_t)y, 5) & 0xffff) / 65535.0;
}

static void write_noise_png(const char *path, int size)
{
    WgImage *img = wgt_image_fn(size, size, 1, noise_fn);
    WgError err = {0};
    assert_int_equal(wg_image_write(path, img, WG_FORMAT_PNG16, WG_LINEAR, &err), WG_OK);
    wg_image_unref(img);
}

/* Keep the first `keep` bytes: the PNG header still reads, the pixels do not. */
static void truncate_file(const char *path, size_t keep)
{
    size_t n;
    char *data = slurp(path, &n);
    assert_non_null(data);
    assert_true(n > keep);
    FILE *f = fopen(path, "wb");
    fwrite(data, 1, keep, f);
    fclose(f);
    free(data);
}

static int setup(void **state)
{
    (void)state;
    wgt_write_file(at("g.wetgraph"), main_graph);
    wgt_write_file(at("bad.wetgraph"), bad_graph);
    wgt_write_file(at("bad2.wetgraph"), bad2_graph);
    wgt_write_file(at("range.wetgraph"), range_graph);
    wgt_write_file(at("inp.wetgraph"), input_graph);
    wgt_write_file(at("plainfile"), "not a folder\n");
    return 0;
}

/* ---- help and usage ---------------------------------------------------------------------- */

static void test_help_and_usage_errors(void **state)
{
    (void)state;
    static const char *const subs[] = {"render", "check", "info", "nodes", "dot"};
    Cmd c[] = {
        {"render --help"},
        {"check --help"},
        {"info --help"},
        {"nodes --help"},
        {"dot -h"},
        {"--help"},
        {""},
        {"rendr g.wetgraph"},
        {"render g.wetgraph --frob"},
        {"render g.wetgraph --size 0x5 --format tif"},
    };
    int n = (int)(sizeof c / sizeof c[0]);
    run_batch(c, n);
    for (int i = 0; i < 5; i++) {
        expect_status(&c[i], 0);
        char want[64];
        snprintf(want, sizeof want, "usage: wetgraph %s", subs[i]);
        if (strncmp(c[i].out, want, strlen(want)))
            fail_msg("'%s' printed:\n%s", c[i].args, c[i].out);
        assert_string_equal(c[i].err, "");
    }
    OUT_HAS(&c[0], "--memory-budget MB");
    OUT_HAS(&c[0], "--layered FILE.exr");
    OUT_HAS(&c[0], "--stats[=json]");
    OUT_HAS(&c[0], "-q, --quiet");
    OUT_HAS(&c[3], "--markdown");

    expect_status(&c[5], 0);
    OUT_HAS(&c[5], "usage: wetgraph COMMAND");
    OUT_HAS(&c[5], "Exit codes: 0 ok, 1 evaluation or I/O");
    for (int k = 0; k < 5; k++) OUT_HAS(&c[5], subs[k]);
    expect_status(&c[6], 2); /* no command: usage on stderr */
    ERR_HAS(&c[6], "usage: wetgraph COMMAND");
    assert_string_equal(c[6].out, "");

    struct {
        int i;
        const char *msg;
    } errors[] = {
        {7, "wetgraph: unknown command 'rendr'; did you mean 'render'?"},
        {8, "wetgraph render: unknown option '--frob'\n(see 'wetgraph render --help')"},
        {9, "bad --size '0x5' (N or WxH"}, /* the first bad option is reported */
    };
    for (size_t k = 0; k < sizeof errors / sizeof errors[0]; k++) {
        Cmd *e = &c[errors[k].i];
        expect_status(e, 2);
        ERR_HAS(e, errors[k].msg);
        assert_string_equal(e->out, "");
    }
    free_batch(c, n);
    /* nothing was written by any of them */
    assert_false(exists(at("g_mask.png")));
}

/* check reports every independent error of a file, one line each, not what follows from them. */
static void test_check_reports_every_error(void **state)
{
    (void)state;
    wgt_write_file(at("three.wetgraph"),
                   "<wetgraph version=\"1\" size=\"8\">\n"
                   "  <param name=\"a\" type=\"float\" default=\"5\" min=\"0\" max=\"1\"/>\n"
                   "  <node id=\"n\" type=\"noize\"/>\n"
                   "  <node id=\"k\" type=\"invert\"><in name=\"source\" from=\"n\"/></node>\n"
                   "  <output name=\"o\" from=\"k\" format=\"gif\"/>\n"
                   "</wetgraph>\n");
    Cmd c = {"check three.wetgraph g.wetgraph"};
    run1(&c);
    expect_status(&c, 2);
    ERR_HAS(&c, "three.wetgraph:2: 'a' = 5 is outside [0, 1]");
    ERR_HAS(&c, "three.wetgraph:5: unknown format 'gif'");
    ERR_HAS(&c, "three.wetgraph:3: unknown node type 'noize'");
    assert_int_equal(count_substr(c.err, "wetgraph: error:"), 3); /* not k's reading of n */
    OUT_HAS(&c, "g.wetgraph: ok");
    free_batch(&c, 1);
}

/* --stats=json: stdout is the one JSON document (the files written are in it, not before it);
 * on a terminal the progress line names the node that finished, the share and the time. */
static void test_json_stdout_and_progress(void **state)
{
    (void)state;
    Cmd c = {"render g.wetgraph -o js --stats=json"};
    run1(&c);
    expect_status(&c, 0);
    if (c.out[0] != '{' || strcmp(c.out + strlen(c.out) - 2, "}\n") || strstr(c.out, "\njs/"))
        fail_msg("stdout is not one JSON document:\n%s", c.out);
    OUT_HAS(&c, "\"outputs\"");
    OUT_HAS(&c, "js/g_mask.png");
    free_batch(&c, 1);
    /* a terminal for stderr, as `script` gives one */
    assert_int_equal(wgt_shell(work(), "script -qec \"'$WG' render g.wetgraph -o pg\" /dev/null"),
                     0);
    const char *out = wgt_join(work(), "out");
    if (!wgt_count_in(out, "%") || !wgt_count_in(out, "] ") || !wgt_count_in(out, " s"))
        fail_msg("no progress line on a terminal");
    assert_true(wgt_count_in(out, "100% ") > 0);
}

/* A misspelt option, graph input or output, or expression function gets the closest correct
 * name, from the command's own --help for options (exit 2 each). */
static void test_suggestions(void **state)
{
    (void)state;
    wgt_write_file(at("fn.wetgraph"), "<wetgraph version=\"1\" size=\"8\">\n"
                                      "  <node id=\"d\" type=\"pixel\" expr=\"sine(x)\"/>\n"
                                      "  <output name=\"o\" from=\"d\"/>\n"
                                      "</wetgraph>\n");
    Cmd c[] = {
        {"render g.wetgraph --thread 2"},
        {"render g.wetgraph --cache-maxx=1G"},
        {"watch g.wetgraph --serv 8080"},
        {"info g.wetgraph --jsn"},
        {"dot g.wetgraph --fusd"},
        {"nodes --markdwn"},
        {"render g.wetgraph --frobnicate"},
        {"render g.wetgraph --output mas -o sg"},
        {"render g.wetgraph --input bsae=a.png"},
        {"check fn.wetgraph"},
        {"graphs --pths"},
        {"cache info . --mx 1"},
    };
    static const char *const want[] = {
        "unknown option '--thread'; did you mean '--threads'?",
        "unknown option '--cache-maxx=1G'; did you mean '--cache-max'?",
        "unknown option '--serv'; did you mean '--serve'?",
        "unknown option '--jsn'; did you mean '--json'?",
        "unknown option '--fusd'; did you mean '--fused'?",
        "unknown option '--markdwn'; did you mean '--markdown'?",
        "unknown option '--frobnicate'\n",
        "has no output 'mas'; did you mean 'mask'?",
        "has no input 'bsae'; did you mean 'base'?",
        "unknown function 'sine'; did you mean 'sin'?",
        "unknown option '--pths'; did you mean '--paths'?",
        "unknown option '--mx'; did you mean '--max'?",
    };
    int n = (int)(sizeof c / sizeof c[0]);
    run_batch(c, n);
    for (int i = 0; i < n; i++) {
        expect_status(&c[i], 2);
        ERR_HAS(&c[i], want[i]);
    }
    free_batch(c, n);
}

/* ---- render ------------------------------------------------------------------------------ */

static void test_render_outputs_and_options(void **state)
{
    (void)state;
    static const char *const dirs[] = {"out", "opt", "fmt", "lay", "sj", "inp"};
    for (int i = 0; i < 6; i++) rm_rf(at(dirs[i]));
    unlink(at("lay.exr"));
    unlink(at("only.exr"));
    write_noise_png(at("noise.png"), 24);
    float px[] = {0.2f, 0.4f, 0.6f, 1};
    WgImage *basecol = wgt_image(1, 1, 4, px);
    WgError err = {0};
    assert_int_equal(wg_image_write(at("base.exr"), basecol, WG_FORMAT_EXR32, WG_LINEAR, &err),
                     WG_OK);
    wg_image_unref(basecol);

    Cmd c[] = {
        {"render g.wetgraph -o out/deep/er --stats"},
        {"render g.wetgraph -o opt --set level=0.25 --set=mode=add --output mask --output=color "
         "--input base=base.exr"},
        {"render g.wetgraph -o fmt --size 32x20 --seed 42 --time 0.75 --format exr32 --threads 3"},
        {"render g.wetgraph --layered lay.exr -o lay"},
        {"render g.wetgraph --layered only.exr -q"},
        {"render g.wetgraph -o sj --stats=json -q --memory-budget 64"},
        {"render inp.wetgraph -o inp --input src=noise.png"},
        {"render g.wetgraph -o plainfile"},
    };
    int n = (int)(sizeof c / sizeof c[0]);
    run_batch(c, n);

    /* -o DIR is created, files are <graph>_<output>.<ext>, each path printed */
    expect_status(&c[0], 0);
    static const char *const files[] = {"out/deep/er/g_mask.png", "out/deep/er/g_color.png",
                                        "out/deep/er/g_time.exr", "out/deep/er/g_seed.exr"};
    for (int i = 0; i < 4; i++) {
        if (!exists(at(files[i]))) fail_msg("%s was not written", files[i]);
        OUT_HAS(&c[0], files[i]);
    }
    assert_int_equal(count_files(at("out/deep/er")), 4);
    assert_int_equal(count_substr(c[0].out, "\n"), 4);
    /* --stats: a table on stderr, the paths still alone on stdout */
    ERR_HAS(&c[0], "6 of 6 nodes computed");
    ERR_HAS(&c[0], "peak image memory");
    ERR_HAS(&c[0], "buffer pool: ");
    ERR_HAS(&c[0], "blur");
    ERR_HAS(&c[0], "16x8c");
    WgImage *mask = read_image(at("out/deep/er/g_mask.png"));
    assert_int_equal(mask->width, 16);
    assert_int_equal(mask->height, 8);
    assert_int_equal(mask->channels, 1);
    assert_float_equal(wgt_px(mask, 5, 5, 0), 0.5, 1.0 / 65535);
    wg_image_unref(mask);
    WgImage *color = read_image(at("out/deep/er/g_color.png"));
    assert_int_equal(color->channels, 4);
    static const float base[] = {0.2f, 0.3f, 0.4f};
    for (int k = 0; k < 3; k++)
        assert_float_equal(wgt_px(color, 3, 2, k), 0.5 * base[k], 0.5 / 255 + 1e-6);
    wg_image_unref(color);
    WgImage *img = read_image(at("out/deep/er/g_time.exr"));
    assert_true(wgt_px(img, 0, 0, 0) == 0.0f);
    wg_image_unref(img);
    img = read_image(at("out/deep/er/g_seed.exr"));
    assert_true(wgt_px(img, 0, 0, 0) == (float)(3 / 100.0)); /* the graph's seed */
    wg_image_unref(img);

    /* --set (both forms), --output, --input */
    expect_status(&c[1], 0);
    assert_int_equal(count_files(at("opt")), 2);
    mask = read_image(at("opt/g_mask.png"));
    assert_float_equal(wgt_px(mask, 0, 0, 0), 0.25, 1.0 / 65535);
    wg_image_unref(mask);
    color = read_image(at("opt/g_color.png"));
    for (int k = 0; k < 3; k++)
        assert_float_equal(wgt_px(color, 0, 0, k), 0.25 + px[k], 0.5 / 255 + 1e-6);
    wg_image_unref(color);

    /* --size, --seed, --time, --format, --threads */
    expect_status(&c[2], 0);
    assert_int_equal(count_files(at("fmt")), 4);
    mask = read_image(at("fmt/g_mask.exr"));
    assert_int_equal(mask->width, 32);
    assert_int_equal(mask->height, 20);
    assert_float_equal(wgt_px(mask, 31, 19, 0), 0.5, 1e-6); /* float: not quantised */
    wg_image_unref(mask);
    assert_true(exists(at("fmt/g_color.exr")));
    img = read_image(at("fmt/g_time.exr"));
    assert_true(wgt_px(img, 31, 19, 0) == 0.75f);
    wg_image_unref(img);
    img = read_image(at("fmt/g_seed.exr"));
    assert_true(wgt_px(img, 0, 0, 0) == (float)(42 / 100.0));
    wg_image_unref(img);

    /* --layered with -o: both; the note on stderr */
    expect_status(&c[3], 0);
    ERR_HAS(&c[3], "wrote lay.exr (4 layers)");
    assert_int_equal(count_files(at("lay")), 4);
    int w, h, ch;
    assert_int_equal(wg_image_probe(at("lay.exr"), &w, &h, &ch, &err), WG_OK);
    assert_int_equal(w, 16);
    assert_int_equal(h, 8);
    assert_int_equal(ch, 7); /* mask.Y, color.RGBA, time.Y, seed.Y */
    /* --layered alone writes only the EXR; -q prints nothing */
    expect_status(&c[4], 0);
    assert_true(exists(at("only.exr")));
    assert_false(exists(at("g_color.png")));
    assert_false(exists(at("g_mask.png")));
    assert_string_equal(c[4].out, "");
    assert_string_equal(c[4].err, "");

    /* --stats=json with -q: only the JSON, on stdout */
    expect_status(&c[5], 0);
    const char *j = c[5].out;
    assert_string_equal(c[5].err, "");
    assert_int_equal(j[0], '{');
    assert_int_equal(json_int(j, "evaluated"), 6);
    long long peak = json_int(j, "peak_bytes");
    /* the gray 16x8 output alive while the colour one is made from it (outputs are let go of
     * once written, so the two uniform ones need not be alive then) */
    assert_true(peak >= 8 * 64 + 8 * 256);
    assert_true(peak <= 64ll << 20);
    assert_int_equal(count_substr(j, "\"id\": "), 6);
    expect_in(j, "\"pool\": {\"bytes\": ", &c[5], "stdout");
    assert_true(json_int(j, "misses") >= 1); /* the first buffers are new */
    expect_in(j, "{\"id\": \"$base\", \"type\": \"uniform\"", &c[5], "stdout");
    expect_in(j, "\"width\": 16, \"height\": 8, \"channels\": 4", &c[5], "stdout");
    assert_int_equal(count_substr(j, "\"cache\": \"miss\""), 6);
    /* the files are named in the JSON only, not listed after it */
    expect_in(j, "{\"path\": \"sj/g_mask.png\", \"file\": \"written\"}", &c[5], "stdout");
    assert_int_equal(count_substr(j, "sj/g_mask.png"), 1);
    assert_int_equal(count_files(at("sj")), 4);

    /* --input feeding a graph whose size comes from the input */
    expect_status(&c[6], 0);
    WgImage *inv = read_image(at("inp/inp_inv.png"));
    assert_int_equal(inv->width, 24);
    for (int y = 0; y < 24; y++)
        for (int x = 0; x < 24; x++) {
            double want = 1.0 - round(noise_fn(x, y, 0) * 65535) / 65535.0;
            if (fabs(wgt_px(inv, x, y, 0) - want) > 1.0 / 65535)
                fail_msg("(%d,%d): %g vs %g", x, y, wgt_px(inv, x, y, 0), want);
        }
    wg_image_unref(inv);

    /* -o naming a file: an I/O failure after rendering */
    expect_status(&c[7], 1);
    ERR_HAS(&c[7], "cannot create the output folder");

    free_batch(c, n);
    for (int i = 0; i < 6; i++) rm_rf(at(dirs[i]));
    unlink(at("lay.exr"));
    unlink(at("only.exr"));
}

static void test_render_failures_write_nothing(void **state)
{
    (void)state;
    static const char *const dirs[] = {"e1", "e2", "e3", "e4", "e5", "e6"};
    for (int i = 0; i < 6; i++) rm_rf(at(dirs[i]));
    /* pre-existing outputs that must survive */
    mkdir(at("e4"), 0777);
    wgt_write_file(at("e4/inp_inv.png"), "old content\n");
    mkdir(at("e5"), 0777);
    wgt_write_file(at("e5/cut_inv.png"), "old content\n");
    /* the header reads (so the check passes) but the pixels are cut off */
    write_noise_png(at("cut.png"), 64);
    truncate_file(at("cut.png"), 2000);
    write_image_graph("cut.wetgraph", "cut.png");

    Cmd c[] = {
        {"render g.wetgraph -o e1 --set levl=0.3"},
        {"render bad.wetgraph -o e2"},
        {"render g.wetgraph -o e3 --size 1024 --memory-budget 1"},
        {"render inp.wetgraph -o e4 --input src=cut.png"},
        {"render cut.wetgraph -o e5"},
        {"render g.wetgraph -o e6 --input base=missing.png"},
    };
    int n = (int)(sizeof c / sizeof c[0]);
    run_batch(c, n);

    /* graph and usage errors: 2, with file:line where there is one */
    expect_status(&c[0], 2);
    ERR_HAS(&c[0], "--set levl=0.3");
    ERR_HAS(&c[0], "no parameter 'levl'; did you mean 'level'?");
    expect_status(&c[1], 2);
    ERR_HAS(&c[1], "bad.wetgraph:3:");
    ERR_HAS(&c[1], "bluur");
    /* evaluation failures: 1 */
    expect_status(&c[2], 1);
    ERR_HAS(&c[2], "--memory-budget");
    ERR_HAS(&c[2], "the largest image is node");
    expect_status(&c[3], 1);
    ERR_HAS(&c[3], "cannot read the image");
    ERR_HAS(&c[3], "cut.png");
    expect_status(&c[4], 1);
    ERR_HAS(&c[4], "cut.wetgraph:2: node 'pic'");
    ERR_HAS(&c[4], "cut.png");
    /* a missing input file is an I/O failure, found before anything is evaluated */
    expect_status(&c[5], 1);
    ERR_HAS(&c[5], "missing.png");

    for (int i = 0; i < n; i++) {
        assert_string_equal(c[i].out, "");      /* no path printed */
        int expect = i == 3 || i == 4 ? 1 : -1; /* only the pre-existing file */
        if (count_files(at(dirs[i])) != expect)
            fail_msg("'%s' left %d files in %s", c[i].args, count_files(at(dirs[i])), dirs[i]);
    }
    char *old = slurp(at("e4/inp_inv.png"), NULL);
    assert_string_equal(old, "old content\n");
    free(old);
    old = slurp(at("e5/cut_inv.png"), NULL);
    assert_string_equal(old, "old content\n");
    free(old);
    free_batch(c, n);
    for (int i = 0; i < 6; i++) rm_rf(at(dirs[i]));
}

/* A damaged input image: one "wetgraph: error:" line naming the file and what is wrong, exit 1,
 * nothing written, and none of the image libraries' own messages (libpng prints
 * "libpng error: ..." to stderr by itself). */
static void test_damaged_images_one_clear_line(void **state)
{
    (void)state;
    static const char *const dirs[] = {"dm1", "dm2", "dm3"};
    for (int i = 0; i < 3; i++) rm_rf(at(dirs[i]));
    write_noise_png(at("dmg.png"), 64);
    truncate_file(at("dmg.png"), 2000);
    write_image_graph("dmgp.wetgraph", "dmg.png");
    /* a JPEG of noise (so it is well over 20000 bytes), cut short */
    int side = 256;
    unsigned char *px = malloc((size_t)side * side * 3);
    assert_non_null(px);
    for (int i = 0; i < side * side * 3; i++)
        px[i] = (unsigned char)(wg_hash3((uint32_t)i, 1, 2) & 0xff);
    char msg[256];
    assert_int_equal(wg__oiio_write(at("dmg.jpg"), "jpg", px, side, side, 3, 8, msg, sizeof msg),
                     0);
    free(px);
    truncate_file(at("dmg.jpg"), 20000);
    write_image_graph("dmgj.wetgraph", "dmg.jpg");

    Cmd c[] = {
        {"render dmgp.wetgraph -o dm1"},
        {"render inp.wetgraph -o dm2 --input src=dmg.png"},
        {"render dmgj.wetgraph -o dm3"},
    };
    static const char *const expect[][3] = {
        {"dmgp.wetgraph:2: node 'pic'", "dmg.png: cannot read the image", "truncated"},
        {"dmg.png", "cannot read the image", "truncated"},
        {"dmgj.wetgraph:2: node 'pic'", "dmg.jpg: cannot read the image",
         "Premature end of JPEG file"},
    };
    int n = (int)(sizeof c / sizeof c[0]);
    run_batch(c, n);
    for (int i = 0; i < n; i++) {
        expect_status(&c[i], 1);
        for (int k = 0; k < 3; k++) ERR_HAS(&c[i], expect[i][k]);
        if (strncmp(c[i].err, "wetgraph: error: ", 17) || count_substr(c[i].err, "\n") != 1)
            fail_msg("'%s': expected one error line, got:\n%s", c[i].args, c[i].err);
        if (strstr(c[i].err, "libpng") || strstr(c[i].err, "PNG library"))
            fail_msg("'%s': a library's message on stderr:\n%s", c[i].args, c[i].err);
        if (count_files(at(dirs[i])) > 0) fail_msg("'%s' wrote files", c[i].args);
    }
    free_batch(c, n);
    for (int i = 0; i < 3; i++) rm_rf(at(dirs[i]));
}

/* Numbers on the command line follow the graph file's rules: decimal only, no spaces, no hex,
 * no inf or nan, nothing clamped; every refusal is a usage error (2) and names the option. */
static void test_numeric_options_are_strict(void **state)
{
    (void)state;
    rm_rf(at("num"));
    static const struct {
        const char *args, *msg;
    } bad[] = {
        {"--seed 99999999999999999999999", "bad --seed '99999999999999999999999' (a whole number "
                                           "from 0 to 18446744073709551615"},
        {"--seed 18446744073709551616", "bad --seed '18446744073709551616'"},
        {"--seed -1", "bad --seed '-1'"},
        {"--seed ' 5'", "bad --seed ' 5'"},
        {"--seed 0x10", "bad --seed '0x10'"},
        {"--seed 5.0", "bad --seed '5.0'"},
        {"--set level=0x10", "--set level=0x10: 'level' expects a number, got '0x10' (written in "
                             "decimal"},
        {"--set 'level= 0.5'", "'level' expects a number, got ' 0.5'"},
        {"--set 'level=0.5 '", "'level' expects a number, got '0.5 '"},
        {"--set level=nan", "'level' is NaN, not a finite number"},
        {"--set level=-inf", "'level' is infinite, not a finite number"},
        {"--set level=1e999", "'level' is infinite, not a finite number"},
        {"--set level==0x1", "--set level==0x1: unexpected letter after a number"},
        {"--set level=1.0000001", "--set level=1.0000001: 'level' = 1.0000001 is outside [0, 1]"},
        {"--set 'level=0.5\n1'", "wetgraph: error: --set level=0.5\\n1: 'level' expects a number, "
                                 "got '0.5\\n1'"},
        {"--set 'level=\033[31m\r'", "--set level=\\x1b[31m\\r: 'level' expects"},
        {"--set level=-0.000000001", "'level' = -1e-09 is outside [0, 1]"},
        {"--set level=1.0000000000000002", "'level' = 1.0000000000000002 is outside [0, 1]"},
        {"--time 0x1", "bad --time '0x1' (a finite decimal number"},
        {"--time ' 1'", "bad --time ' 1'"},
        {"--time nan", "bad --time 'nan'"},
        {"--time inf", "bad --time 'inf'"},
        {"--time 1e400", "bad --time '1e400'"},
        {"--threads ' 2'", "bad --threads ' 2' (a whole number, 1..256)"},
        {"--threads +2", "bad --threads '+2'"},
        {"--threads 2.0", "bad --threads '2.0'"},
        {"--threads 99999999999999999999", "bad --threads '99999999999999999999'"},
        {"--memory-budget 0x40", "bad --memory-budget '0x40' (MiB, a decimal number"},
        {"--memory-budget ' 64'", "bad --memory-budget ' 64'"},
        {"--memory-budget inf", "bad --memory-budget 'inf'"},
        {"--memory-budget nan", "bad --memory-budget 'nan'"},
        {"--size ' 8'", "bad --size ' 8'"},
        {"--size +8", "bad --size '+8'"},
        {"--size 8x+8", "bad --size '8x+8'"},
        {"--size 99999999999999999999", "bad --size '99999999999999999999'"},
    };
    enum { N_BAD = sizeof bad / sizeof bad[0] };
    Cmd c[N_BAD + 1];
    char args[N_BAD + 1][200];
    for (int i = 0; i < N_BAD; i++) {
        snprintf(args[i], sizeof args[i], "render g.wetgraph -o num %s", bad[i].args);
        c[i] = (Cmd){args[i]};
    }
    /* the edges of what is allowed */
    snprintf(args[N_BAD], sizeof args[N_BAD],
             "render g.wetgraph -o num -q --output time --output mask --seed 18446744073709551615 "
             "--set level=.25 --time -1.5e0 --threads 1 --memory-budget 64.5 --size 4x2");
    c[N_BAD] = (Cmd){args[N_BAD]};
    run_batch(c, N_BAD + 1);
    for (int i = 0; i < N_BAD; i++) {
        expect_status(&c[i], 2);
        ERR_HAS(&c[i], bad[i].msg);
        assert_string_equal(c[i].out, "");
    }
    expect_status(&c[N_BAD], 0);
    assert_int_equal(count_files(at("num")), 2);
    WgImage *img = read_image(at("num/g_time.exr"));
    assert_int_equal(img->width, 4);
    assert_true(wgt_px(img, 0, 0, 0) == -1.5f);
    wg_image_unref(img);
    img = read_image(at("num/g_mask.png"));
    assert_float_equal(wgt_px(img, 0, 0, 0), 0.25, 1.0 / 65535);
    wg_image_unref(img);
    free_batch(c, N_BAD + 1);
    rm_rf(at("num"));
}

static void test_cache_option(void **state)
{
    (void)state;
    rm_rf(at("cache"));
    rm_rf(at("c1"));
    Cmd first = {
        "render g.wetgraph -o c1 --cache cache --output mask --output color --stats=json -q"};
    run1(&first);
    expect_status(&first, 0);
    assert_int_equal(json_int(first.out, "evaluated"), 4); /* u, b, $base, c */
    assert_int_equal(count_substr(first.out, "\"cache\": \"miss\""), 4);
    assert_true(exists(at("cache")));
    /* into another folder: the blur comes from the disk, the blend (a point operation only
     * the caller reads: not stored) is computed from it */
    Cmd second = {
        "render g.wetgraph -o c2 --cache cache --output mask --output color --stats=json -q"};
    run1(&second);
    expect_status(&second, 0);
    assert_int_equal(json_int(second.out, "evaluated"), 2); /* $base and c */
    assert_int_equal(count_substr(second.out, "\"cache\": \"disk\""), 1);
    /* into the same folder: its files hold the outputs, which are neither read nor written */
    struct stat before, after;
    assert_int_equal(stat(at("c1/g_color.png"), &before), 0);
    Cmd again = {first.args};
    run1(&again);
    expect_status(&again, 0);
    assert_int_equal(json_int(again.out, "evaluated"), 0);
    assert_int_equal(count_substr(again.out, "\"cache\": \"held\""), 2);
    assert_int_equal(count_substr(again.out, "\"cache\": \"disk\""), 0);
    assert_int_equal(stat(at("c1/g_color.png"), &after), 0);
    assert_true(before.st_mtim.tv_sec == after.st_mtim.tv_sec &&
                before.st_mtim.tv_nsec == after.st_mtim.tv_nsec);
    /* an edit downstream: the blur still comes from the disk */
    Cmd edit = {
        "render g.wetgraph -o c1 --cache=cache --set mode=add --output color --stats=json -q"};
    run1(&edit);
    expect_status(&edit, 0);
    assert_int_equal(json_int(edit.out, "evaluated"), 2); /* $base and c */
    const char *b = strstr(edit.out, "{\"id\": \"b\", \"type\": \"blur\"");
    if (!b) fail_msg("no stats for b:\n%s", edit.out);
    expect_in(b, "\"cache\": \"disk\"", &edit, "the stats of b");
    free_batch(&first, 1);
    free_batch(&second, 1);
    free_batch(&again, 1);
    free_batch(&edit, 1);
    rm_rf(at("cache"));
    rm_rf(at("c1"));
    rm_rf(at("c2"));
}

/* A --cache that is not a usable folder (a file, /dev/null, a path under a file, one that cannot
 * be created) is one error naming the path and why, exit 1, nothing written; never a render
 * that quietly keeps nothing. */
static void test_cache_must_be_a_folder(void **state)
{
    (void)state;
    wgt_write_file(at("plain.txt"), "not a folder\n");
    static const struct {
        const char *cache, *why;
    } bad[] = {
        {"plain.txt", "Not a directory"},
        {"/dev/null", "Not a directory"},
        {"plain.txt/sub", "Not a directory"},
        {"plain.txt/a/b", "Not a directory"},
        {"/proc/wetgraph-no-such/cache", "No such file or directory"},
    };
    enum { N = sizeof bad / sizeof bad[0] };
    Cmd c[N];
    char args[N][300];
    for (int i = 0; i < N; i++) {
        snprintf(args[i], sizeof args[i], "render g.wetgraph -o nocache%d --cache %s", i,
                 bad[i].cache);
        c[i] = (Cmd){args[i]};
    }
    run_batch(c, N);
    for (int i = 0; i < N; i++) {
        char msg[400], dir[64];
        expect_status(&c[i], 1);
        snprintf(msg, sizeof msg, "wetgraph: error: cannot use '%s' as the cache folder: %s\n",
                 bad[i].cache, bad[i].why);
        assert_string_equal(c[i].err, msg);
        assert_string_equal(c[i].out, "");
        snprintf(dir, sizeof dir, "nocache%d", i);
        assert_false(exists(at(dir)));
    }
    assert_false(exists("/dev/null/objects"));
    free_batch(c, N);
    unlink(at("plain.txt"));
}

/* ---- check, info, nodes, dot ------------------------------------------------------------- */

/* Occurrences of needle in text. */
static int count_of(const char *text, const char *needle)
{
    int n = 0;
    for (const char *p = text; (p = strstr(p, needle)); p += strlen(needle)) n++;
    return n;
}

/* A graph's <warning>s: printed once per render on stderr with file and line (and the subgraph
 * instance), exit 0; -q hides them; a frame sequence prints each once; check prints them with
 * the defaults; --stats=json lists them. */
static void test_graph_warnings(void **state)
{
    (void)state;
    wgt_write_file(
        at("warn.wetgraph"),
        "<wetgraph version=\"1\" size=\"8\">\n"
        "  <param name=\"k\" type=\"float\" default=\"0.05\" min=\"0\" max=\"9\"/>\n"
        "  <warning when=\"=k &lt; 0.1\" message=\"k {k} is below 0.1 ({=0.1 / k}x)\"/>\n"
        "  <node id=\"u\" type=\"uniform\" value=\"=k\"/>\n"
        "  <node id=\"t\" type=\"uniform\" value=\"=fract($time)\"/>\n"
        "  <output name=\"o\" from=\"u\"/>\n"
        "  <output name=\"t\" from=\"t\"/>\n"
        "</wetgraph>\n");
    wgt_write_file(at("warnsub.wetgraph"), "<wetgraph version=\"1\" size=\"8\">\n"
                                           "  <node id=\"one\" type=\"warn\" k=\"0.5\"/>\n"
                                           "  <node id=\"two\" type=\"warn\" k=\"0.02\"/>\n"
                                           "  <output name=\"a\" from=\"one\"/>\n"
                                           "  <output name=\"b\" from=\"two\"/>\n"
                                           "</wetgraph>\n");
    Cmd c[] = {
        {"render warn.wetgraph -o wout1"},
        {"render warn.wetgraph -o wout2 -q"},
        {"render warn.wetgraph -o wout3 --set k=0.1"},
        {"render warn.wetgraph -o wout4 --frames 0:4 --fps 2"},
        {"check warn.wetgraph warnsub.wetgraph"},
        {"render warn.wetgraph -o wout5 --stats=json -q --set k=0.025"},
        {"render warnsub.wetgraph -o wout6"},
        {"render warn.wetgraph -o wout7 --frames 0:2 -q"},
    };
    int n = (int)(sizeof c / sizeof c[0]);
    run_batch(c, n);
    const char *line = "wetgraph: warning: warn.wetgraph:3: k 0.05 is below 0.1 (2x)\n";
    for (int i = 0; i < n; i++) expect_status(&c[i], 0);
    assert_string_equal(c[0].err, line);
    OUT_HAS(&c[0], "wout1/warn_o.png");
    assert_true(exists(at("wout1/warn_o.png")));
    assert_string_equal(c[1].err, "");
    assert_string_equal(c[2].err, "");
    assert_string_equal(c[3].err, line); /* five frames, one line */
    assert_int_equal(count_of(c[3].out, "\n"), 10);
    assert_string_equal(c[4].out, "warn.wetgraph: ok\nwarnsub.wetgraph: ok\n");
    assert_string_equal(c[4].err, "wetgraph: warning: warn.wetgraph:3: k 0.05 is below 0.1 (2x)\n"
                                  "wetgraph: warning: ./warn.wetgraph:3: node 'two': k 0.02 is "
                                  "below 0.1 (5x)\n");
    OUT_HAS(&c[5], "\"warnings\": [\n    {\"file\": \"warn.wetgraph\", \"line\": 3, \"node\": "
                   "null, \"message\": \"k 0.025 is below 0.1 (4x)\"}\n  ]\n}");
    assert_string_equal(c[5].err, "");
    assert_string_equal(
        c[6].err, "wetgraph: warning: ./warn.wetgraph:3: node 'two': k 0.02 is below 0.1 (5x)\n");
    assert_string_equal(c[7].err, "");
    free_batch(c, n);
}

static void test_inspection_commands(void **state)
{
    (void)state;
    Cmd c[] = {
        {"check g.wetgraph inp.wetgraph"},
        {"check g.wetgraph bad.wetgraph inp.wetgraph bad2.wetgraph missing.wetgraph "
         "range.wetgraph"},
        {"info g.wetgraph"},
        {"info --json g.wetgraph"},
        {"info bad.wetgraph"},
        {"nodes"},
        {"nodes blur"},
        {"nodes bluur"},
        {"nodes --markdown"},
        {"dot g.wetgraph"},
        {"info --json wet_material"},
    };
    int n = (int)(sizeof c / sizeof c[0]);
    run_batch(c, n);

    /* check: ok lines on stdout (an input without default gets a placeholder) */
    expect_status(&c[0], 0);
    assert_string_equal(c[0].out, "g.wetgraph: ok\ninp.wetgraph: ok\n");
    assert_string_equal(c[0].err, "");
    /* errors in the middle: every file is checked, every error reported, exit 2 */
    expect_status(&c[1], 2);
    assert_string_equal(c[1].out, "g.wetgraph: ok\ninp.wetgraph: ok\n");
    ERR_HAS(&c[1], "bad.wetgraph:3:");
    ERR_HAS(&c[1], "bluur");
    ERR_HAS(&c[1], "bad2.wetgraph:2:");
    ERR_HAS(&c[1], "unknown name 'nope'");
    ERR_HAS(&c[1], "missing.wetgraph");
    ERR_HAS(&c[1], "range.wetgraph:4:"); /* found by resolving, without rendering */
    assert_int_equal(count_substr(c[1].err, "wetgraph: error: "), 4);

    /* info */
    expect_status(&c[2], 0);
    OUT_HAS(&c[2], "graph g (g.wetgraph)");
    OUT_HAS(&c[2], "size 16x8, seed 3, 5 nodes");
    OUT_HAS(&c[2], "default 0.5  range [0, 1]");
    OUT_HAS(&c[2], "\"Level\"");
    OUT_HAS(&c[2], "values add|multiply");
    OUT_HAS(&c[2], "default 0.2 0.3 0.4 1");
    OUT_HAS(&c[2], "png16");
    expect_status(&c[3], 0);
    const char *j = c[3].out;
    OUT_HAS(&c[3], "\"name\": \"g\"");
    OUT_HAS(&c[3], "\"size\": \"16x8\"");
    assert_int_equal(json_int(j, "seed"), 3);
    assert_int_equal(json_int(j, "nodes"), 5);
    OUT_HAS(&c[3], "{\"name\": \"level\", \"type\": \"float\", \"default\": \"0.5\", \"min\": 0, "
                   "\"max\": 1, \"label\": \"Level\"}");
    OUT_HAS(&c[3], "\"values\": [\"add\", \"multiply\"]");
    OUT_HAS(&c[3], "{\"name\": \"base\", \"type\": \"color\", \"colorspace\": \"linear\", "
                   "\"default\": \"0.2 0.3 0.4 1\"}");
    OUT_HAS(&c[3], "{\"name\": \"mask\", \"from\": \"b\", \"format\": \"png16\", \"colorspace\": "
                   "\"linear\", \"group\": null, \"compression\": \"fast\"}");
    OUT_HAS(&c[3], "{\"name\": \"color\", \"from\": \"c\", \"format\": \"default\"");
    assert_int_equal(count_substr(j, "{"), 1 + 2 + 1 + 4);
    expect_status(&c[4], 2);
    ERR_HAS(&c[4], "bad.wetgraph:3:");
    assert_string_equal(c[4].out, "");

    /* nodes: one line per registered type */
    expect_status(&c[5], 0);
    int count = 0;
    for (; wg_node_types[count]; count++) {
        char line[80];
        snprintf(line, sizeof line, "\n%s ", wg_node_types[count]->name);
        bool first = !strncmp(c[5].out, line + 1, strlen(line + 1));
        if (!first && !strstr(c[5].out, line))
            fail_msg("'%s' not listed:\n%s", wg_node_types[count]->name, c[5].out);
    }
    assert_int_equal(count_substr(c[5].out, "\n"), count);
    expect_status(&c[6], 0);
    OUT_HAS(&c[6], "blur - Gaussian blur");
    OUT_HAS(&c[6], "sigma");
    OUT_HAS(&c[6], "source");
    expect_status(&c[7], 2);
    ERR_HAS(&c[7], "unknown node type 'bluur'; did you mean 'blur'?");
    expect_status(&c[8], 0);
    assert_int_equal(strncmp(c[8].out, "# Node reference\n", 17), 0);
    for (int i = 0; wg_node_types[i]; i++) {
        char hd[80];
        snprintf(hd, sizeof hd, "\n## `%s`\n", wg_node_types[i]->name);
        OUT_HAS(&c[8], hd);
    }
    OUT_HAS(&c[8], "| `sigma` | float | `1` |");

    /* dot */
    expect_status(&c[9], 0);
    assert_int_equal(strncmp(c[9].out, "digraph \"g\" {", 13), 0);
    OUT_HAS(&c[9], "\"n:u\" -> \"n:b\" [label=\"source\"]");
    OUT_HAS(&c[9], "\"n:b\" -> \"n:c\" [label=\"foreground\"]");
    OUT_HAS(&c[9], "\"$base\" -> \"n:c\"");

    /* info --json reports the parameters' UI hints (the wet material's relief depth) */
    expect_status(&c[10], 0);
    OUT_HAS(&c[10], "{\"name\": \"height_scale\", \"type\": \"float\", \"default\": \"16\", "
                    "\"min\": 0.001, \"max\": 4096, \"label\": \"Relief depth\", \"soft_min\": 1, "
                    "\"soft_max\": 64, \"step\": 0.5, \"group\": \"Zones\", \"description\": ");
    OUT_HAS(&c[10], "\"name\": \"absorption_depth\"");
    OUT_HAS(&c[10], "\"soft_max\": 64, \"step\": 0.10000000000000001, \"group\": \"Liquid\"");
    free_batch(c, n);
}

/* `render --output basecolor --stats=json` of the wet material (the Bricks102 maps of
 * ../shared, at 64²): only what the base colour needs runs, which the JSON shows: the albedo
 * and the masks are there, the normals, the meniscus and the zones view are not. */
static void test_wet_basecolor_alone(void **state)
{
    (void)state;
    const char *shared = getenv("WETGRAPH_SHARED"), *source = getenv("WETGRAPH_SOURCE");
    if (!shared || !source) fail_msg("WETGRAPH_SHARED or WETGRAPH_SOURCE is not set");
    char out[1024];
    snprintf(out, sizeof out, "%s", wgt_path("wet_base"));
    mkdir(out, 0777);
    const char *m = "bricks102_stonewall_1k/Bricks102_1K-JPG";
    int st = wgt_shell(out,
                       "\"$WG\" render '%s/graphs/wet_material.wetgraph' -o . -q --size 64 "
                       "--input basecolor='%s/materials/%s_Color.jpg' "
                       "--input height='%s/materials/%s_Displacement.jpg' "
                       "--set water_level=0.6 --output basecolor --stats=json",
                       source, shared, m, shared, m);
    assert_int_equal(st, 0);
    size_t size;
    char *j = wgt_read_file(wgt_join(out, "out"), &size);
    assert_non_null(strstr(j, "\"id\": \"tex/albedo\""));
    assert_non_null(strstr(j, "\"id\": \"masks/immersed\""));
    static const char *const unneeded[] = {"tex/surf/normal_out", "tex/surf/water_normal",
                                           "tex/surf/meniscus", "masks/zones"};
    for (size_t i = 0; i < sizeof unneeded / sizeof unneeded[0]; i++) {
        char key[128];
        snprintf(key, sizeof key, "\"id\": \"%s\"", unneeded[i]);
        if (strstr(j, key)) fail_msg("%s ran for the base colour alone", unneeded[i]);
    }
    assert_true(wgt_exists(wgt_join(out, "wet_material_basecolor.png")));
    assert_false(wgt_exists(wgt_join(out, "wet_material_normal.png")));
    free(j);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_help_and_usage_errors),
        cmocka_unit_test(test_suggestions),
        cmocka_unit_test(test_json_stdout_and_progress),
        cmocka_unit_test(test_check_reports_every_error),
        cmocka_unit_test(test_render_outputs_and_options),
        cmocka_unit_test(test_render_failures_write_nothing),
        cmocka_unit_test(test_damaged_images_one_clear_line),
        cmocka_unit_test(test_numeric_options_are_strict),
        cmocka_unit_test(test_cache_option),
        cmocka_unit_test(test_cache_must_be_a_folder),
        cmocka_unit_test(test_inspection_commands),
        cmocka_unit_test(test_graph_warnings),
        cmocka_unit_test(test_wet_basecolor_alone),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
