/* SPDX-License-Identifier: MIT */
/* The result cache: re-renders on one engine reuse memory entries, an edit recomputes only the
 * edited node and what depends on it, the seed does not invalidate unseeded nodes, the disk
 * cache serves a fresh engine (mapping its entries), damaged entries are ignored, recomputed and
 * rewritten, and an image node's key follows the content of its file. Results are bit-identical
 * cold or warm. */
#include "wgtest.h"

#include "internal.h"
#include "wgio.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

/* ---- helpers ----------------------------------------------------------------------------- */

/* The node has a stat with that outcome (or, for outcome -1, no stat at all). */
static void expect_stat(const WgResult *res, const char *id, int outcome)
{
    const WgNodeStat *s = wgt_stat(res, id);
    if (outcome < 0) {
        if (s) fail_msg("node '%s' should not have been needed (outcome %d)", id, s->cache);
        return;
    }
    if (!s) fail_msg("no stat for node '%s'", id);
    if ((int)s->cache != outcome)
        fail_msg("node '%s': cache outcome %d, expected %d", id, s->cache, outcome);
    if (outcome != WG_COMPUTED && s->ms != 0) fail_msg("node '%s': a hit took %g ms", id, s->ms);
}

static void expect_same_outputs(const WgResult *a, const WgResult *b)
{
    assert_int_equal(wg_result_output_count(a), wg_result_output_count(b));
    for (int i = 0; i < wg_result_output_count(a); i++) {
        assert_string_equal(wg_result_output_name(a, i), wg_result_output_name(b, i));
        wgt_assert_identical(wg_result_output_image(a, i), wg_result_output_image(b, i));
    }
}

static double pic_fn(int x, int y, int k)
{
    if (k == 3) return 1;
    return ((x * 37 + y * 101 + k * 53) % 256) / 255.0;
}

static double other_fn(int x, int y, int k)
{
    if (k == 3) return 1;
    return ((x * 11 + y * 7 + k * 199 + 40) % 256) / 255.0;
}

static void write_picture(const char *path, double (*fn)(int, int, int))
{
    WgImage *img = wgt_image_fn(16, 12, 4, fn);
    WgError err = {0};
    assert_int_equal(wg_image_write(path, img, WG_FORMAT_PNG, WG_LINEAR, &err), WG_OK);
    wg_image_unref(img);
}

/* image -> two blurs; one blur -> levels (driven by `gain`) -> blend with the other blur. */
static const char *const chain_xml =
    "<wetgraph version=\"1\" size=\"32x24\" seed=\"7\">\n"
    "  <param name=\"gain\" type=\"float\" default=\"0.8\" min=\"0\" max=\"2\"/>\n"
    "  <node id=\"img\" type=\"image\" path=\"chain.png\" size=\"16x12\"/>\n"
    "  <node id=\"soft\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"img\"/></node>\n"
    "  <node id=\"sharp\" type=\"blur\" sigma=\"0.5\"><in name=\"source\" from=\"img\"/></node>\n"
    "  <node id=\"lev\" type=\"levels\" out_high=\"=gain\"><in name=\"source\" "
    "from=\"soft\"/></node>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"multiply\"><in name=\"foreground\" from=\"lev\"/>"
    "<in name=\"background\" from=\"sharp\"/></node>\n"
    "  <output name=\"mix\" from=\"mix\"/>\n"
    "  <output name=\"soft\" from=\"soft\"/>\n"
    "</wetgraph>\n";

static WgGraph *chain_graph(void)
{
    write_picture(wgt_path("chain.png"), pic_fn);
    return wgt_load_at(chain_xml, wgt_path("chain.wetgraph"));
}

static WgRequest *chain_request(const WgGraph *g, const char *gain)
{
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    if (gain) {
        WgError err = {0};
        assert_int_equal(wg_request_set(r, "gain", gain, &err), WG_OK);
    }
    return r;
}

/* Render on a fresh engine without any cache. */
static WgResult *cold(const WgRequest *r)
{
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    wg_engine_free(e);
    return res;
}

typedef struct {
    char path[1024];
    int width, height, channels;
} Entry;

/* Every .wgc file under dir (one level of subfolders), with its header's shape; hidden files
 * are temporaries, not entries. */
static int cache_entries(const char *dir, Entry *out, int max)
{
    int n = 0;
    DIR *d = opendir(dir);
    if (!d) return 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        char sub[1024];
        snprintf(sub, sizeof sub, "%s/%s", dir, e->d_name);
        DIR *s = opendir(sub);
        if (!s) continue;
        struct dirent *f;
        while ((f = readdir(s))) {
            size_t l = strlen(f->d_name);
            if (l < 4 || strcmp(f->d_name + l - 4, ".wgc") || f->d_name[0] == '.') continue;
            if (n < max) {
                snprintf(out[n].path, sizeof out[n].path, "%s/%s", sub, f->d_name);
                FILE *fp = fopen(out[n].path, "rb");
                int32_t hdr[6] = {0};
                if (fp) {
                    if (fread(hdr, sizeof hdr, 1, fp) != 1) memset(hdr, 0, sizeof hdr);
                    fclose(fp);
                }
                out[n].width = hdr[2];
                out[n].height = hdr[3];
                out[n].channels = hdr[4];
            }
            n++;
        }
        closedir(s);
    }
    closedir(d);
    return n;
}

/* Temporary files left in the cache folders. */
static int cache_temp_files(const char *dir)
{
    int n = 0;
    DIR *d = opendir(dir);
    if (!d) return 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        char sub[1024];
        snprintf(sub, sizeof sub, "%s/%s", dir, e->d_name);
        DIR *s = opendir(sub);
        if (!s) continue;
        struct dirent *f;
        while ((f = readdir(s)))
            if (f->d_name[0] == '.' && strcmp(f->d_name, ".") && strcmp(f->d_name, "..")) n++;
        closedir(s);
    }
    closedir(d);
    return n;
}

static void spit(const char *path, const char *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

/* The test's cache folder `name` under the temporary folder, into buf. */
static void cache_dir(char *buf, size_t size, const char *name)
{
    snprintf(buf, size, "%s/%s", wgt_tmpdir(), name);
}

/* ---- in memory --------------------------------------------------------------------------- */

static void test_rerender_uses_memory_cache(void **state)
{
    (void)state;
    WgGraph *g = chain_graph();
    WgRequest *r = chain_request(g, NULL);
    WgEngine *e = wgt_engine(3, 0, NULL);
    WgResult *first = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(first), 5);
    static const char *const all[] = {"img", "soft", "sharp", "lev", "mix"};
    for (int i = 0; i < 5; i++) expect_stat(first, all[i], WG_COMPUTED);

    WgResult *second = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(second), 0);
    /* the outputs come straight from the cache: nothing upstream is even looked at */
    assert_int_equal(wg_result_stat_count(second), 2);
    expect_stat(second, "mix", WG_HIT_MEMORY);
    expect_stat(second, "soft", WG_HIT_MEMORY);
    expect_stat(second, "img", -1);
    expect_same_outputs(first, second);

    /* clearing the cache recomputes everything, identically */
    wg_engine_clear_cache(e);
    WgResult *third = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(third), 5);
    expect_same_outputs(first, third);

    wg_result_free(third);
    wg_result_free(second);
    wg_result_free(first);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_edit_recomputes_only_dependents(void **state)
{
    (void)state;
    WgGraph *g = chain_graph();
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgRequest *r = chain_request(g, NULL);
    WgResult *base = wgt_render_request(e, r);
    wg_request_free(r);

    r = chain_request(g, "0.5");
    WgResult *edited = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(edited), 2);
    expect_stat(edited, "lev", WG_COMPUTED);
    expect_stat(edited, "mix", WG_COMPUTED);
    expect_stat(edited, "soft", WG_HIT_MEMORY);
    expect_stat(edited, "sharp", WG_HIT_MEMORY);
    expect_stat(edited, "img", -1);
    /* the unchanged output is the same image, the edited one differs */
    wgt_assert_identical(wgt_output(edited, "soft"), wgt_output(base, "soft"));
    assert_true(wgt_max_abs_diff(wgt_output(edited, "mix"), wgt_output(base, "mix")) > 0.01);
    /* and equals a cold render of the edited request */
    WgResult *ref = cold(r);
    expect_same_outputs(edited, ref);
    wg_result_free(ref);
    wg_request_free(r);

    /* going back to the old value is a pure cache hit */
    r = chain_request(g, "0.8");
    WgResult *back = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(back), 0);
    expect_same_outputs(back, base);
    wg_result_free(back);

    /* the expression gives the same float as the default: same key */
    wg_request_free(r);
    r = chain_request(g, "=0.4 * 2");
    back = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(back), 0);
    wg_result_free(back);

    wg_result_free(edited);
    wg_result_free(base);
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
}

static void test_seed_does_not_invalidate_unseeded_nodes(void **state)
{
    (void)state;
    for (int i = 0; wg_node_types[i]; i++) {
        const char *n = wg_node_types[i]->name;
        if (!strcmp(n, "uniform") || !strcmp(n, "image") || !strcmp(n, "blur") ||
            !strcmp(n, "blend") || !strcmp(n, "levels") || !strcmp(n, "invert") ||
            !strcmp(n, "grayscale"))
            assert_false(wg_node_types[i]->flags & WG_NODE_SEEDED);
    }
    WgGraph *g = chain_graph();
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgRequest *r = chain_request(g, NULL);
    WgResult *base = wgt_render_request(e, r);
    wg_request_set_seed(r, 123456789);
    WgResult *seeded = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(seeded), 0);
    expect_stat(seeded, "mix", WG_HIT_MEMORY);
    expect_same_outputs(base, seeded);
    /* time does not matter to untimed nodes either */
    wg_request_set_time(r, 2.5);
    WgResult *timed = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(timed), 0);
    wg_result_free(timed);
    wg_result_free(seeded);
    wg_result_free(base);
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
}

static void test_seed_in_an_expression_is_a_parameter_change(void **state)
{
    (void)state;
    WgGraph *g =
        wgt_load("<wetgraph version=\"1\" size=\"8\" seed=\"3\">\n"
                 "  <node id=\"u\" type=\"uniform\" value=\"0.5\"/>\n"
                 "  <node id=\"b\" type=\"blur\" sigma=\"=$seed % 4\">"
                 "<in name=\"source\" from=\"u\"/></node>\n"
                 "  <node id=\"i\" type=\"invert\"><in name=\"source\" from=\"u\"/></node>\n"
                 "  <output name=\"b\" from=\"b\"/>\n"
                 "  <output name=\"i\" from=\"i\"/>\n"
                 "</wetgraph>\n");
    WgEngine *e = wgt_engine(1, 0, NULL);
    WgRequest *r = wg_request_new(g);
    WgResult *a = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(a), 3);
    wg_request_set_seed(r, 6);
    WgResult *b = wgt_render_request(e, r);
    /* the blur's sigma changed (3 -> 2): it recomputes from the cached u; invert does not */
    assert_int_equal(wg_result_evaluated_count(b), 1);
    expect_stat(b, "b", WG_COMPUTED);
    expect_stat(b, "u", WG_HIT_MEMORY);
    expect_stat(b, "i", WG_HIT_MEMORY);
    wg_request_set_seed(r, 7); /* 7 % 4 = 3 as with seed 3 */
    WgResult *c = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(c), 0);
    wg_result_free(c);
    wg_result_free(b);
    wg_result_free(a);
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
}

/* ---- on disk ----------------------------------------------------------------------------- */

static void test_disk_cache_serves_a_fresh_engine(void **state)
{
    (void)state;
    char dirbuf[1024];
    cache_dir(dirbuf, sizeof dirbuf, "disk1/nested/cache"); /* created if missing */
    WgGraph *g = chain_graph();
    WgRequest *r = chain_request(g, NULL);
    WgResult *ref = cold(r);

    WgEngine *e1 = wgt_engine(2, 0, dirbuf);
    WgResult *computed = wgt_render_request(e1, r);
    assert_int_equal(wg_result_evaluated_count(computed), 5);
    wg_engine_free(e1);
    expect_same_outputs(computed, ref);
    Entry entries[32];
    /* img and the blurs; not mix, a point operation only the caller reads (computing it
     * again from its inputs costs about what storing it would), nor lev, which runs fused
     * into it (docs/engine.md) and is never materialised */
    assert_int_equal(cache_entries(dirbuf, entries, 32), 3);
    assert_int_equal(cache_temp_files(dirbuf), 0);

    /* a new engine: no memory cache, the disk serves the blurs, lev and mix are computed from
     * them */
    WgEngine *e2 = wgt_engine(3, 0, dirbuf);
    WgResult *warm = wgt_render_request(e2, r);
    assert_int_equal(wg_result_evaluated_count(warm), 2);
    expect_stat(warm, "mix", WG_COMPUTED);
    expect_stat(warm, "lev", WG_COMPUTED);
    expect_stat(warm, "soft", WG_HIT_DISK);
    expect_stat(warm, "sharp", WG_HIT_DISK);
    expect_stat(warm, "img", -1);
    expect_same_outputs(warm, ref);
    /* the same engine again: now from memory */
    WgResult *again = wgt_render_request(e2, r);
    expect_stat(again, "mix", WG_HIT_MEMORY);
    wg_result_free(again);
    wg_engine_free(e2);
    wg_request_free(r);

    /* an edit in a new engine: the disk serves the upstream nodes */
    r = chain_request(g, "1.7");
    WgEngine *e3 = wgt_engine(1, 0, dirbuf);
    WgResult *edited = wgt_render_request(e3, r);
    assert_int_equal(wg_result_evaluated_count(edited), 2);
    expect_stat(edited, "lev", WG_COMPUTED);
    expect_stat(edited, "mix", WG_COMPUTED);
    expect_stat(edited, "soft", WG_HIT_DISK);
    expect_stat(edited, "sharp", WG_HIT_DISK);
    expect_stat(edited, "img", -1);
    WgResult *edited_ref = cold(r);
    expect_same_outputs(edited, edited_ref);
    assert_int_equal(cache_entries(dirbuf, entries, 32), 3); /* nothing new stored */
    wg_engine_free(e3);

    wg_result_free(edited_ref);
    wg_result_free(edited);
    wg_result_free(warm);
    wg_result_free(computed);
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

/* Not stored: cheap types (uniform), and a point operation that only the caller reads (the
 * pixel expression, a leaf); the blend, read by the blur, and the blur are. */
static void test_cheap_nodes_and_point_leaves_are_not_written_to_disk(void **state)
{
    (void)state;
    char dirbuf[1024];
    cache_dir(dirbuf, sizeof dirbuf, "disk_cheap");
    WgGraph *g = wgt_load(
        "<wetgraph version=\"1\" size=\"16\">\n"
        "  <input name=\"src\" type=\"gray\"/>\n"
        "  <node id=\"u\" type=\"uniform\" value=\"0.25\"/>\n"
        "  <node id=\"m\" type=\"blend\" mode=\"add\"><in name=\"foreground\" from=\"u\"/>"
        "<in name=\"background\" from=\"$src\"/></node>\n"
        "  <node id=\"b\" type=\"blur\" sigma=\"1\"><in name=\"source\" from=\"m\"/></node>\n"
        "  <node id=\"p\" type=\"pixel\" expr=\"A * A\"><in name=\"A\" from=\"b\"/></node>\n"
        "  <output name=\"u\" from=\"u\"/>\n"
        "  <output name=\"m\" from=\"m\"/>\n"
        "  <output name=\"p\" from=\"p\"/>\n"
        "</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    WgImage *src = wgt_image_fn(16, 16, 1, pic_fn);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "src", src, &err), WG_OK);
    WgEngine *e = wgt_engine(2, 0, dirbuf);
    WgResult *a = wgt_render_request(e, r);
    wg_engine_free(e);
    Entry entries[8];
    /* the blend and the blur: the uniform is cheaper to compute, the expression is computed
     * again from the blur, the input image is not a node */
    assert_int_equal(cache_entries(dirbuf, entries, 8), 2);
    e = wgt_engine(2, 0, dirbuf);
    WgResult *b = wgt_render_request(e, r);
    expect_stat(b, "b", WG_HIT_DISK);
    expect_stat(b, "m", WG_HIT_DISK);
    expect_stat(b, "u", WG_COMPUTED);
    expect_stat(b, "p", WG_COMPUTED);
    expect_stat(b, "$src", -1);
    assert_int_equal(wg_result_evaluated_count(b), 2);
    assert_int_equal(cache_entries(dirbuf, entries, 8), 2);
    expect_same_outputs(a, b);
    wg_result_free(b);
    wg_result_free(a);
    wg_engine_free(e);
    wg_image_unref(src);
    wg_request_free(r);
    wg_graph_free(g);
}

/* blur -> pixel (gain) -> blur: the expression is an interior point operation. A first render
 * stores it; an edit's re-render, which reads the first blur back from the disk, computes it
 * and stores only the second blur; the edit undone reads everything back. */
static void test_point_operations_of_a_rerender_are_not_stored(void **state)
{
    (void)state;
    char dirbuf[1024];
    cache_dir(dirbuf, sizeof dirbuf, "disk_rerender");
    WgGraph *g = wgt_load(
        "<wetgraph version=\"1\" size=\"16\">\n"
        "  <param name=\"gain\" type=\"float\" default=\"0.5\" min=\"0\" max=\"2\"/>\n"
        "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
        "  <node id=\"b1\" type=\"blur\" sigma=\"1\"><in name=\"source\" from=\"n\"/></node>\n"
        "  <node id=\"p\" type=\"pixel\" expr=\"A * gain\"><in name=\"A\" from=\"b1\"/></node>\n"
        "  <node id=\"b2\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"p\"/></node>\n"
        "  <output name=\"b2\" from=\"b2\"/>\n"
        "</wetgraph>\n");
    WgRequest *r = wg_request_new(g);
    WgEngine *e = wgt_engine(2, 0, dirbuf);
    WgResult *first = wgt_render_request(e, r);
    wg_engine_free(e);
    Entry entries[8];
    assert_int_equal(cache_entries(dirbuf, entries, 8), 4); /* n, b1, p and b2 */
    expect_stat(first, "p", WG_COMPUTED);

    WgError err = {0};
    assert_int_equal(wg_request_set(r, "gain", "1.5", &err), WG_OK);
    e = wgt_engine(2, 0, dirbuf);
    WgResult *edited = wgt_render_request(e, r);
    wg_engine_free(e);
    expect_stat(edited, "b1", WG_HIT_DISK);
    expect_stat(edited, "p", WG_COMPUTED);
    expect_stat(edited, "b2", WG_COMPUTED);
    assert_int_equal(cache_entries(dirbuf, entries, 8), 5); /* the new b2, not p */
    WgResult *edited_ref = cold(r);
    expect_same_outputs(edited, edited_ref);

    /* the edit undone: the first render's entries, p's among them */
    assert_int_equal(wg_request_set(r, "gain", "0.5", &err), WG_OK);
    e = wgt_engine(2, 0, dirbuf);
    WgResult *undone = wgt_render_request(e, r);
    wg_engine_free(e);
    assert_int_equal(wg_result_evaluated_count(undone), 0);
    expect_stat(undone, "b2", WG_HIT_DISK);
    expect_same_outputs(undone, first);
    wg_result_free(undone);
    wg_result_free(edited_ref);
    wg_result_free(edited);
    wg_result_free(first);
    wg_request_free(r);
    wg_graph_free(g);
}

/* image (16x12) -> blur (32x24): two disk entries of different shapes. */
static const char *const pair_xml =
    "<wetgraph version=\"1\" size=\"32x24\">\n"
    "  <node id=\"img\" type=\"image\" path=\"pair.png\" size=\"16x12\"/>\n"
    "  <node id=\"soft\" type=\"blur\" sigma=\"1.5\"><in name=\"source\" from=\"img\"/></node>\n"
    "  <output name=\"soft\" from=\"soft\"/>\n"
    "</wetgraph>\n";

/* An entry's header: magic (8 bytes), width, height, channels, port (int32), key (2 x 64 bits). */
enum { HEADER = 40 };

enum {
    FLIP_PIXEL,
    FLIP_MAGIC,
    FLIP_SHAPE,
    FLIP_PORT,
    FLIP_KEY,
    FLIP_CHECKSUM,
    TRUNCATE,
    APPEND,
    EMPTY,
    N_DAMAGE
};

static void damage(const char *path, int how)
{
    size_t n;
    char *data = wgt_read_file(path, &n);
    switch (how) {
    case FLIP_PIXEL:
        data[HEADER + 4 * 37 + 1] ^= 0x10;
        break;
    case FLIP_MAGIC:
        data[0] ^= 1;
        break;
    case FLIP_SHAPE:
        data[8] ^= 1;
        break; /* width */
    case FLIP_PORT:
        data[20] ^= 1;
        break;
    case FLIP_KEY:
        data[24 + 11] ^= 4;
        break;
    case FLIP_CHECKSUM:
        data[n - 1] ^= 0x80;
        break;
    case TRUNCATE:
        n = n / 2;
        break;
    case APPEND:
        data = realloc(data, n + 1);
        data[n++] = 0;
        break;
    case EMPTY:
        n = 0;
        break;
    }
    spit(path, data, n);
    free(data);
}

static void test_damaged_entries_are_recomputed_and_rewritten(void **state)
{
    (void)state;
    write_picture(wgt_path("pair.png"), pic_fn);
    WgGraph *g = wgt_load_at(pair_xml, wgt_path("pair.wetgraph"));
    WgRequest *r = wg_request_new(g);
    WgResult *ref = cold(r);
    for (int how = 0; how < N_DAMAGE; how++) {
        char dir[1024];
        snprintf(dir, sizeof dir, "%s/damage%d", wgt_tmpdir(), how);
        WgEngine *e = wgt_engine(2, 0, dir);
        WgResult *res = wgt_render_request(e, r);
        wg_result_free(res);
        wg_engine_free(e);
        Entry entries[4];
        assert_int_equal(cache_entries(dir, entries, 4), 2);
        /* the blur's entry is the 32x24 one */
        int soft = entries[0].width == 32 ? 0 : 1;
        assert_int_equal(entries[soft].width, 32);
        assert_int_equal(entries[soft].height, 24);
        assert_int_equal(entries[soft].channels, 4);
        assert_int_equal(entries[1 - soft].width, 16);
        size_t n0;
        char *original = wgt_read_file(entries[soft].path, &n0);
        assert_int_equal(n0, HEADER + 32 * 24 * 4 * sizeof(float) + 8);

        damage(entries[soft].path, how);
        e = wgt_engine(2, 0, dir);
        res = wgt_render_request(e, r);
        /* the damaged entry is a miss; its input still comes from the disk */
        if (wg_result_evaluated_count(res) != 1)
            fail_msg("damage %d: %d nodes evaluated", how, wg_result_evaluated_count(res));
        expect_stat(res, "soft", WG_COMPUTED);
        expect_stat(res, "img", WG_HIT_DISK);
        expect_same_outputs(res, ref);
        wg_result_free(res);
        wg_engine_free(e);
        /* rewritten, byte for byte as before */
        size_t n1;
        char *rewritten = wgt_read_file(entries[soft].path, &n1);
        assert_int_equal(n1, n0);
        assert_memory_equal(original, rewritten, n0);
        assert_int_equal(cache_temp_files(dir), 0);
        free(rewritten);
        free(original);

        /* and trusted again */
        e = wgt_engine(1, 0, dir);
        res = wgt_render_request(e, r);
        assert_int_equal(wg_result_evaluated_count(res), 0);
        expect_stat(res, "soft", WG_HIT_DISK);
        expect_same_outputs(res, ref);
        wg_result_free(res);
        wg_engine_free(e);
    }
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_all_entries_damaged(void **state)
{
    (void)state;
    write_picture(wgt_path("pair.png"), pic_fn);
    WgGraph *g = wgt_load_at(pair_xml, wgt_path("pair.wetgraph"));
    WgRequest *r = wg_request_new(g);
    char dirbuf[1024];
    cache_dir(dirbuf, sizeof dirbuf, "damage_all");
    WgEngine *e = wgt_engine(2, 0, dirbuf);
    WgResult *ref = wgt_render_request(e, r);
    wg_engine_free(e);
    Entry entries[4];
    assert_int_equal(cache_entries(dirbuf, entries, 4), 2);
    damage(entries[0].path, FLIP_PIXEL);
    damage(entries[1].path, TRUNCATE);
    e = wgt_engine(4, 0, dirbuf);
    WgResult *res = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(res), 2);
    expect_same_outputs(res, ref);
    wg_result_free(res);
    wg_engine_free(e);
    assert_int_equal(cache_entries(dirbuf, entries, 4), 2);
    e = wgt_engine(1, 0, dirbuf);
    res = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(res), 0);
    expect_same_outputs(res, ref);
    wg_result_free(res);
    wg_engine_free(e);
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

/* How many lines of /proc/self/maps name a file under dir: the entries mapped now. */
static int mapped_entries(const char *dir)
{
    FILE *f = fopen("/proc/self/maps", "r");
    assert_non_null(f);
    char line[4096];
    int n = 0;
    while (fgets(line, sizeof line, f))
        if (strstr(line, dir) && strstr(line, ".wgc")) n++;
    fclose(f);
    return n;
}

/* A disk hit maps its entry (on a local file system): the image is the file's pages, held
 * while the image is, and unmapped with it. Removing the files (pruning, clearing) or putting
 * others at their paths does not touch what a render holds. The same render reading the
 * entries into new images gives the same outputs. */
static void test_disk_hits_map_their_entries(void **state)
{
    (void)state;
    char dirbuf[1024];
    cache_dir(dirbuf, sizeof dirbuf, "mapped");
    WgGraph *g = chain_graph();
    WgRequest *r = chain_request(g, NULL);
    WgResult *ref = cold(r);
    WgEngine *e = wgt_engine(2, 0, dirbuf);
    wg_result_free(wgt_render_request(e, r));
    wg_engine_free(e);
    Entry entries[8];
    int n = cache_entries(dirbuf, entries, 8);
    assert_int_equal(n, 3); /* img, soft, sharp */
    assert_int_equal(mapped_entries(dirbuf), 0);

    e = wgt_engine(2, 0, dirbuf);
    WgResult *warm = wgt_render_request(e, r);
    expect_stat(warm, "soft", WG_HIT_DISK);
    expect_stat(warm, "sharp", WG_HIT_DISK);
    /* soft is an output, held by the result; both are held by the memory cache */
    assert_int_equal(mapped_entries(dirbuf), 2);
    /* the files go, and others take their paths */
    for (int i = 0; i < n; i++) {
        assert_int_equal(unlink(entries[i].path), 0);
        spit(entries[i].path, "not an entry", 12);
    }
    expect_same_outputs(warm, ref);
    /* an edit computes from the mapped images the memory cache holds */
    WgRequest *r2 = chain_request(g, "1.3");
    WgResult *edited = wgt_render_request(e, r2);
    expect_stat(edited, "soft", WG_HIT_MEMORY);
    expect_stat(edited, "sharp", WG_HIT_MEMORY);
    WgResult *edited_ref = cold(r2);
    expect_same_outputs(edited, edited_ref);
    wg_result_free(edited_ref);
    wg_result_free(edited);
    wg_request_free(r2);
    wg_result_free(warm);
    wg_engine_free(e);
    assert_int_equal(mapped_entries(dirbuf), 0); /* unmapped with the last reference */

    /* read rather than mapped: the same outputs, nothing mapped */
    for (int i = 0; i < n; i++) unlink(entries[i].path);
    e = wgt_engine(2, 0, dirbuf);
    wg_result_free(wgt_render_request(e, r));
    wg_engine_free(e);
    wg__cache_map_entries(false);
    e = wgt_engine(2, 0, dirbuf);
    WgResult *read = wgt_render_request(e, r);
    wg__cache_map_entries(true);
    expect_stat(read, "soft", WG_HIT_DISK);
    expect_stat(read, "sharp", WG_HIT_DISK);
    assert_int_equal(mapped_entries(dirbuf), 0);
    expect_same_outputs(read, ref);
    wg_result_free(read);
    wg_engine_free(e);

    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

/* Entries of the same shape have the same size: a file copied over another one is still a
 * well-formed entry with a valid checksum, but of the wrong key. Swap the two 32x24 colour
 * entries of the chain (soft and sharp; lev and mix have none) so each holds the other's
 * pixels. */
static void test_swapped_entries_are_misses(void **state)
{
    (void)state;
    WgGraph *g = chain_graph();
    WgRequest *r = chain_request(g, NULL);
    WgResult *ref = cold(r);
    char dirbuf[1024];
    cache_dir(dirbuf, sizeof dirbuf, "swap");
    WgEngine *e = wgt_engine(2, 0, dirbuf);
    wg_result_free(wgt_render_request(e, r));
    wg_engine_free(e);

    Entry entries[8];
    int n = cache_entries(dirbuf, entries, 8);
    assert_int_equal(n, 3);
    int same[2], k = 0;
    for (int i = 0; i < n; i++)
        if (entries[i].width == 32 && entries[i].height == 24 && entries[i].channels == 4 && k < 2)
            same[k++] = i;
    assert_int_equal(k, 2);
    char *data[2];
    size_t size[2];
    for (int i = 0; i < 2; i++) data[i] = wgt_read_file(entries[same[i]].path, &size[i]);
    for (int i = 0; i < 2; i++) {
        assert_int_equal(size[i], size[(i + 1) % 2]);
        spit(entries[same[i]].path, data[(i + 1) % 2], size[(i + 1) % 2]);
    }

    e = wgt_engine(2, 0, dirbuf);
    WgResult *res = wgt_render_request(e, r);
    expect_same_outputs(res, ref);
    assert_int_equal(wg_result_evaluated_count(res), 4);
    expect_stat(res, "mix", WG_COMPUTED);
    expect_stat(res, "soft", WG_COMPUTED);
    expect_stat(res, "sharp", WG_COMPUTED);
    expect_stat(res, "img", WG_HIT_DISK);
    wg_result_free(res);
    wg_engine_free(e);
    /* rewritten as they were, and trusted again */
    for (int i = 0; i < 2; i++) {
        size_t m;
        char *now = wgt_read_file(entries[same[i]].path, &m);
        assert_int_equal(m, size[i]);
        assert_memory_equal(now, data[i], m);
        free(now);
    }
    e = wgt_engine(1, 0, dirbuf);
    res = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(res), 2); /* lev and mix */
    expect_stat(res, "soft", WG_HIT_DISK);
    expect_stat(res, "sharp", WG_HIT_DISK);
    expect_same_outputs(res, ref);
    wg_result_free(res);
    wg_engine_free(e);

    for (int i = 0; i < 2; i++) free(data[i]);
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "test_cache: a render blocked on a cache entry\n";
    if (write(2, msg, sizeof msg - 1)) {
    }
    _exit(3);
}

/* A FIFO in place of an entry would block a plain open() forever, and a symbolic link could
 * point anywhere: both are misses, replaced by a real entry. alarm() is the harness time-out. */
static void test_fifo_and_symlink_entries(void **state)
{
    (void)state;
    write_picture(wgt_path("pair.png"), pic_fn);
    WgGraph *g = wgt_load_at(pair_xml, wgt_path("pair.wetgraph"));
    WgRequest *r = wg_request_new(g);
    WgResult *ref = cold(r);
    for (int how = 0; how < 2; how++) {
        char dir[1024];
        snprintf(dir, sizeof dir, "%s/special%d", wgt_tmpdir(), how);
        WgEngine *e = wgt_engine(2, 0, dir);
        wg_result_free(wgt_render_request(e, r));
        wg_engine_free(e);
        Entry entries[4];
        assert_int_equal(cache_entries(dir, entries, 4), 2);
        int soft = entries[0].width == 32 ? 0 : 1;
        const char *path = entries[soft].path;
        if (how == 0) {
            assert_int_equal(unlink(path), 0);
            assert_int_equal(mkfifo(path, 0666), 0);
        } else {
            /* a link to a valid copy of the very same entry: still not trusted */
            char copy[1100];
            snprintf(copy, sizeof copy, "%s/elsewhere.wgc", dir);
            assert_int_equal(rename(path, copy), 0);
            assert_int_equal(symlink(copy, path), 0);
        }
        signal(SIGALRM, on_alarm);
        alarm(30);
        e = wgt_engine(2, 0, dir);
        WgResult *res = wgt_render_request(e, r);
        alarm(0);
        expect_stat(res, "soft", WG_COMPUTED);
        expect_same_outputs(res, ref);
        wg_result_free(res);
        wg_engine_free(e);
        struct stat st;
        assert_int_equal(lstat(path, &st), 0);
        assert_true(S_ISREG(st.st_mode));
        e = wgt_engine(1, 0, dir);
        res = wgt_render_request(e, r);
        assert_int_equal(wg_result_evaluated_count(res), 0);
        wg_result_free(res);
        wg_engine_free(e);
    }
    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

/* Temporaries of killed processes are removed when a cache is opened; a live process's stay,
 * and no temporary is ever read as an entry. */
static void test_stale_temporaries_are_removed(void **state)
{
    (void)state;
    write_picture(wgt_path("pair.png"), pic_fn);
    WgGraph *g = wgt_load_at(pair_xml, wgt_path("pair.wetgraph"));
    WgRequest *r = wg_request_new(g);
    char dir[1024];
    cache_dir(dir, sizeof dir, "stale");
    WgEngine *e = wgt_engine(2, 0, dir);
    WgResult *ref = wgt_render_request(e, r);
    wg_engine_free(e);
    Entry entries[4];
    assert_int_equal(cache_entries(dir, entries, 4), 2);
    const char *soft = entries[entries[0].width == 32 ? 0 : 1].path;

    /* a process id that is certainly gone: a child that has exited and been reaped */
    pid_t child = fork();
    assert_true(child >= 0);
    if (child == 0) _exit(0);
    assert_int_equal(waitpid(child, NULL, 0), child);

    /* next to the blur's entry: a dead writer's partial file (a damaged copy of the entry, under
     * the name that entry's temporary would have), a live one's, and files that only look
     * similar */
    char sub[1024];
    snprintf(sub, sizeof sub, "%s", soft);
    char *slash = strrchr(sub, '/');
    const char *base = slash + 1;
    char stem[256];
    snprintf(stem, sizeof stem, "%.*s", (int)(strlen(base) - 4), base);
    *slash = '\0';
    char dead[1400], dead2[1400], live[1400], other[1400], other2[1400];
    unsigned host = (unsigned)wg__temp_host(); /* this machine's */
    snprintf(dead, sizeof dead, "%s/.%s.tmp%ld-1-%08x.wgc", sub, stem, (long)child, host);
    snprintf(dead2, sizeof dead2, "%s/.%s.tmp%ld-12-%08x.wgc", sub, stem, (long)child, host);
    snprintf(live, sizeof live, "%s/.%s.tmp%ld-3-%08x.wgc", sub, stem, (long)getpid(), host);
    snprintf(other, sizeof other, "%s/.%s.tmp%ld-1.png.bak", sub, stem, (long)child);
    snprintf(other2, sizeof other2, "%s/.notes.tmp%ldx-1.wgc", sub, (long)child);
    size_t n;
    char *data = wgt_read_file(soft, &n);
    spit(dead, data, n / 2);
    spit(dead2, data, n);
    spit(live, data, n / 3);
    spit(other, "x", 1);
    spit(other2, "x", 1);
    free(data);
    /* the entry itself is gone: a temporary must not stand in for it */
    assert_int_equal(unlink(soft), 0);
    assert_int_equal(cache_temp_files(dir), 5);

    e = wgt_engine(2, 0, dir);
    struct stat st;
    assert_int_equal(stat(dead, &st), -1);
    assert_int_equal(stat(dead2, &st), -1);
    assert_int_equal(stat(live, &st), 0);
    assert_int_equal(stat(other, &st), 0);
    assert_int_equal(stat(other2, &st), 0);
    WgResult *res = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(res), 1);
    expect_stat(res, "soft", WG_COMPUTED);
    expect_same_outputs(res, ref);
    wg_result_free(res);
    wg_engine_free(e);
    assert_int_equal(cache_entries(dir, entries, 4), 2);
    assert_int_equal(cache_temp_files(dir), 3);
    assert_int_equal(unlink(live), 0);
    assert_int_equal(unlink(other), 0);
    assert_int_equal(unlink(other2), 0);

    wg_result_free(ref);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_cache_dir_that_cannot_be_created(void **state)
{
    (void)state;
    const char *file = wgt_path("a_file");
    wgt_write_file(file, "x");
    char dir[1100];
    snprintf(dir, sizeof dir, "%s/sub", file);
    WgEngineOptions opt = {1, 0, dir};
    WgEngine *e = NULL;
    WgError err = {0};
    assert_int_equal(wg_engine_new(&opt, &e, &err), WG_ERR_IO);
    assert_null(e);
    assert_non_null(strstr(err.message, "cache folder"));
}

/* ---- image files in keys ----------------------------------------------------------------- */

static void test_image_key_follows_file_content(void **state)
{
    (void)state;
    const char *png = wgt_path("swap.png");
    write_picture(png, pic_fn);
    WgGraph *g =
        wgt_load_at("<wetgraph version=\"1\" size=\"16x12\">\n"
                    "  <node id=\"img\" type=\"image\" path=\"swap.png\"/>\n"
                    "  <node id=\"inv\" type=\"invert\"><in name=\"source\" from=\"img\"/></node>\n"
                    "  <output name=\"inv\" from=\"inv\"/>\n"
                    "</wetgraph>\n",
                    wgt_path("swap.wetgraph"));
    WgRequest *r = wg_request_new(g);
    char dirbuf[1024];
    cache_dir(dirbuf, sizeof dirbuf, "swapcache");
    WgEngine *e = wgt_engine(2, 0, dirbuf);
    WgResult *a = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(a), 2);
    WgResult *a2 = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(a2), 0);

    /* same path, other pixels */
    write_picture(png, other_fn);
    WgResult *b = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(b), 2);
    expect_stat(b, "img", WG_COMPUTED);
    expect_stat(b, "inv", WG_COMPUTED);
    const WgImage *out = wg_result_output_image(b, 0);
    for (int y = 0; y < 12; y++)
        for (int x = 0; x < 16; x++)
            for (int k = 0; k < 3; k++) {
                float want = 1.0f - (float)(lround(other_fn(x, y, k) * 255) / 255.0);
                if (fabs(wgt_px(out, x, y, k) - want) > 1e-6)
                    fail_msg("(%d,%d,%d): %g vs %g", x, y, k, wgt_px(out, x, y, k), want);
            }
    assert_true(wgt_max_abs_diff(out, wg_result_output_image(a, 0)) > 0.1);

    /* a fresh engine with the disk cache does not serve the old picture either (the image
     * comes from the disk, the invert, a point operation only the caller reads, is computed
     * from it) */
    wg_engine_free(e);
    e = wgt_engine(2, 0, dirbuf);
    WgResult *c = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(c), 1);
    expect_stat(c, "img", WG_HIT_DISK);
    expect_stat(c, "inv", WG_COMPUTED);
    expect_same_outputs(b, c);
    /* back to the first picture: both versions are cached */
    write_picture(png, pic_fn);
    WgResult *d = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(d), 1);
    expect_stat(d, "img", WG_HIT_DISK);
    expect_same_outputs(a, d);

    wg_result_free(d);
    wg_result_free(c);
    wg_result_free(b);
    wg_result_free(a2);
    wg_result_free(a);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

static void test_input_images_are_part_of_the_key(void **state)
{
    (void)state;
    WgGraph *g = wgt_load(
        "<wetgraph version=\"1\" size=\"16\">\n"
        "  <input name=\"src\" type=\"gray\"/>\n"
        "  <node id=\"b\" type=\"blur\" sigma=\"1\"><in name=\"source\" from=\"$src\"/></node>\n"
        "  <output name=\"b\" from=\"b\"/>\n"
        "</wetgraph>\n");
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgRequest *r = wg_request_new(g);
    WgImage *one = wgt_image_fn(16, 16, 1, pic_fn);
    WgImage *two = wgt_image_fn(16, 16, 1, other_fn);
    WgError err = {0};
    assert_int_equal(wg_request_set_input_image(r, "src", one, &err), WG_OK);
    WgResult *a = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(a), 2);
    assert_int_equal(wg_request_set_input_image(r, "src", two, &err), WG_OK);
    WgResult *b = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(b), 2);
    assert_true(wgt_max_abs_diff(wg_result_output_image(a, 0), wg_result_output_image(b, 0)) >
                0.01);
    /* a copy of the first image (another object, same pixels) hits */
    WgImage *copy = wgt_image_fn(16, 16, 1, pic_fn);
    assert_int_equal(wg_request_set_input_image(r, "src", copy, &err), WG_OK);
    WgResult *c = wgt_render_request(e, r);
    assert_int_equal(wg_result_evaluated_count(c), 0);
    expect_same_outputs(a, c);
    wg_result_free(c);
    wg_result_free(b);
    wg_result_free(a);
    wg_image_unref(copy);
    wg_image_unref(two);
    wg_image_unref(one);
    wg_request_free(r);
    wg_engine_free(e);
    wg_graph_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rerender_uses_memory_cache),
        cmocka_unit_test(test_edit_recomputes_only_dependents),
        cmocka_unit_test(test_seed_does_not_invalidate_unseeded_nodes),
        cmocka_unit_test(test_seed_in_an_expression_is_a_parameter_change),
        cmocka_unit_test(test_disk_cache_serves_a_fresh_engine),
        cmocka_unit_test(test_cheap_nodes_and_point_leaves_are_not_written_to_disk),
        cmocka_unit_test(test_point_operations_of_a_rerender_are_not_stored),
        cmocka_unit_test(test_damaged_entries_are_recomputed_and_rewritten),
        cmocka_unit_test(test_all_entries_damaged),
        cmocka_unit_test(test_disk_hits_map_their_entries),
        cmocka_unit_test(test_swapped_entries_are_misses),
        cmocka_unit_test(test_fifo_and_symlink_entries),
        cmocka_unit_test(test_stale_temporaries_are_removed),
        cmocka_unit_test(test_cache_dir_that_cannot_be_created),
        cmocka_unit_test(test_image_key_follows_file_content),
        cmocka_unit_test(test_input_images_are_part_of_the_key),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
