/* SPDX-License-Identifier: MIT */
/* The result cache folder kept in bounds: `wetgraph cache info` counts the entries and their
 * bytes (and nothing else in the folder), `cache prune --max` removes the least recently used
 * first (an entry read back by a render counts as used), `render --cache-max` holds the cap
 * after every render, `cache clear` removes every entry and only entries, and bad folders,
 * sizes and combinations are usage errors (exit 2). With --cache, outputs whose files already
 * hold them (the same source key, the file untouched) are neither computed, read nor written,
 * and the files stay those a fresh render writes. */
#include "wgtest.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* noise -> blur -> levels(p): a render with a new p reuses the first two from the cache; the
 * levels, a point operation only the caller reads, is not stored */
static const char *const graph =
    "<wetgraph version=\"1\" size=\"64\">\n"
    "  <param name=\"p\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <param name=\"s\" type=\"int\" default=\"1\" min=\"0\" max=\"100\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"=4 + s\"/>\n"
    "  <node id=\"b\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"l\" type=\"levels\" in_high=\"=0.5 + p / 2\"><in name=\"source\" "
    "from=\"b\"/></node>\n"
    "  <output name=\"o\" from=\"l\"/>\n"
    "</wetgraph>\n";

/* An empty folder holding g.wetgraph. */
static const char *fresh(const char *name)
{
    const char *d = wgt_fresh_dir(name);
    wgt_write_file(wgt_join(d, "g.wetgraph"), graph);
    return d;
}

/* Entry files (<32 hex digits>-<port>.wgc) under dir/c and their bytes. */
static long long entries(const char *d, long long *bytes)
{
    char cmd[1200];
    snprintf(cmd, sizeof cmd,
             "find '%s/c' -regextype posix-extended -regex '.*/[0-9a-f]{32}-[0-9]+\\.wgc' -printf "
             "'%%s\\n' | awk '{n++; b+=$1} END "
             "{printf \"%%d %%d\\n\", n, b}' > '%s/count'",
             d, d);
    assert_int_equal(system(cmd), 0);
    FILE *f = fopen(wgt_join(d, "count"), "r");
    assert_non_null(f);
    long long n = 0, b = 0;
    assert_int_equal(fscanf(f, "%lld %lld", &n, &b), 2);
    fclose(f);
    if (bytes) *bytes = b;
    return n;
}

/* Nodes a render computed (not read from a cache), from --stats=json. */
static int computed(const char *d)
{
    FILE *f = fopen(wgt_join(d, "out"), "r");
    assert_non_null(f);
    char buf[1 << 16];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = 0;
    const char *k = strstr(buf, "\"evaluated\":");
    assert_non_null(k);
    return atoi(k + 12);
}

static void test_info_prune_clear(void **state)
{
    (void)state;
    const char *d = fresh("prune");
    for (int s = 0; s < 3; s++) {
        WGT_SH(d, 0, "$WG render g.wetgraph -o r%d -q --cache c --set s=%d", s, s);
        wgt_sleep_ms(30); /* distinct last uses */
    }
    long long bytes, n = entries(d, &bytes);
    assert_int_equal(n, 6);
    /* not entries: left alone and not counted */
    wgt_write_file(wgt_join(d, "c/notes.txt"), "mine");
    mkdir(wgt_join(d, "c/zz"), 0777);
    wgt_write_file(wgt_join(d, "c/zz/0123.wgc"), "not an entry");
    WGT_SH(d, 0, "$WG cache info c");
    char want[128];
    snprintf(want, sizeof want, "c: 6 entries, %.1f MiB", bytes / 1048576.0);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), want), 1);
    /* the first render's entries are the oldest: reading them back (into another folder, so
     * that they are read) makes them the newest */
    WGT_SH(d, 0, "$WG render g.wetgraph -o r0b -q --cache c --set s=0 --stats=json");
    assert_int_equal(computed(d), 1); /* the levels */
    /* keep about one render's worth: the entries used last are what stays */
    long long per = bytes / 6;
    WGT_SH(d, 0, "$WG cache prune c --max %lld", 2 * per + per / 2);
    assert_int_equal(entries(d, NULL), 2);
    WGT_SH(d, 0, "$WG render g.wetgraph -o r0c -q --cache c --set s=0 --stats=json");
    assert_int_equal(computed(d), 1);
    WGT_SH(d, 0, "$WG render g.wetgraph -o r1b -q --cache c --set s=1 --stats=json");
    assert_int_equal(computed(d), 3);
    /* clear: every entry, nothing else */
    WGT_SH(d, 0, "$WG cache clear c");
    assert_int_equal(entries(d, NULL), 0);
    assert_true(wgt_exists(wgt_join(d, "c/notes.txt")));
    assert_true(wgt_exists(wgt_join(d, "c/zz/0123.wgc")));
    WGT_SH(d, 0, "$WG cache info c");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "c: 0 entries, 0.0 MiB"), 1);
}

static void test_cache_max(void **state)
{
    (void)state;
    const char *d = fresh("cap");
    WGT_SH(d, 0, "$WG render g.wetgraph -o r -q --cache c --set s=0");
    long long bytes;
    entries(d, &bytes);
    long long cap = bytes * 2; /* two renders' worth (three nodes each) */
    for (int s = 1; s < 6; s++) {
        WGT_SH(d, 0, "$WG render g.wetgraph -o r -q --cache c --set s=%d --cache-max %lld", s, cap);
        long long now;
        entries(d, &now);
        if (now > cap)
            fail_msg("render %d: the cache holds %lld bytes, over the cap %lld", s, now, cap);
    }
    /* the last render's own entries are kept: its re-render computes nothing */
    WGT_SH(d, 0, "$WG render g.wetgraph -o r -q --cache c --set s=5 --stats=json");
    assert_int_equal(computed(d), 0);
    /* and what a render prunes is reported with --stats */
    WGT_SH(d, 0, "$WG render g.wetgraph -o r -q --cache c --set s=9 --cache-max 1 --stats");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "entries removed"), 1);
    assert_int_equal(entries(d, NULL), 0);
}

static void test_errors(void **state)
{
    (void)state;
    const char *d = fresh("errors");
    WGT_SH(d, 2, "$WG cache info nowhere");
    assert_int_equal(
        wgt_count_in(wgt_join(d, "err"), "nowhere: cannot open the cache folder: no such folder"),
        1);
    WGT_SH(d, 2, "$WG cache info g.wetgraph");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "it is not a folder"), 1);
    WGT_SH(d, 2, "$WG cache prune .");
    WGT_SH(d, 2, "$WG cache clear . --max 1K");
    WGT_SH(d, 2, "$WG cache purge .");
    WGT_SH(d, 2, "$WG cache");
    WGT_SH(d, 2, "$WG render g.wetgraph --cache-max 1G");
    assert_int_equal(wgt_count_in(wgt_join(d, "err"), "--cache-max needs --cache DIR"), 1);
    static const char *const bad[] = {"-1", "K", "1X", "1e30", "", "1.5.5M"};
    for (int i = 0; i < 6; i++) {
        WGT_SH(d, 2, "$WG render g.wetgraph --cache c --cache-max '%s'", bad[i]);
        assert_int_equal(wgt_count_in(wgt_join(d, "err"), "bad --cache-max"), 1);
    }
    static const char *const good[] = {"0", "1536", "1.5K", "2M", "1MiB", "3G", "1T"};
    for (int i = 0; i < 7; i++)
        WGT_SH(d, 0, "$WG render g.wetgraph -o r -q --cache c --cache-max %s", good[i]);
}

static const char *const three =
    "<wetgraph version=\"1\" size=\"32x24\">\n"
    "  <param name=\"k\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
    "  <node id=\"b\" type=\"blur\" sigma=\"3\"><in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"l\" type=\"levels\" out_high=\"=k\"><in name=\"source\" from=\"b\"/></node>\n"
    "  <output name=\"noise\" from=\"n\" format=\"exr32\"/>\n"
    "  <output name=\"blurred\" from=\"b\" format=\"png16\"/>\n"
    "  <output name=\"level\" from=\"l\" format=\"png16\"/>\n"
    "</wetgraph>\n";

/* How many nodes the last render's --stats=json (in d/out) gives `outcome`. */
static int outcome_count(const char *d, const char *outcome)
{
    char key[64];
    snprintf(key, sizeof key, "\"cache\": \"%s\"", outcome);
    return wgt_count_in(wgt_join(d, "out"), key);
}

static long long mtime_ns(const char *path)
{
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    return (long long)st.st_mtim.tv_sec * 1000000000LL + st.st_mtim.tv_nsec;
}

static void test_outputs_held_by_their_files(void **state)
{
    (void)state;
    const char *d = wgt_fresh_dir("held");
    wgt_write_file(wgt_join(d, "t.wetgraph"), three);
    const char *render = "$WG render t.wetgraph -o o -q --cache c --stats=json";
    WGT_SH(d, 0, "%s", render);
    assert_int_equal(computed(d), 3);
    long long noise = mtime_ns(wgt_join(d, "o/t_noise.exr")),
              blurred = mtime_ns(wgt_join(d, "o/t_blurred.png")),
              level = mtime_ns(wgt_join(d, "o/t_level.png"));
    /* the same render again: nothing computed, read or written */
    WGT_SH(d, 0, "%s", render);
    assert_int_equal(computed(d), 0);
    assert_int_equal(outcome_count(d, "held"), 3);
    assert_int_equal(outcome_count(d, "disk"), 0);
    assert_true(mtime_ns(wgt_join(d, "o/t_level.png")) == level);
    /* a change downstream: levels computed, the blur it reads comes from the disk and its
     * file is kept (the same pixels), the noise is held */
    WGT_SH(d, 0, "%s --set k=0.25", render);
    assert_int_equal(computed(d), 1);
    assert_int_equal(outcome_count(d, "held"), 1);
    assert_int_equal(outcome_count(d, "disk"), 1);
    assert_true(mtime_ns(wgt_join(d, "o/t_noise.exr")) == noise);
    assert_true(mtime_ns(wgt_join(d, "o/t_blurred.png")) == blurred);
    assert_true(mtime_ns(wgt_join(d, "o/t_level.png")) != level);
    /* a file edited by someone else, one deleted, one asked in another format: written again */
    WGT_SH(d, 0, "printf x >> o/t_noise.exr && rm o/t_blurred.png");
    WGT_SH(d, 0, "%s --set k=0.25 --format level=exr32", render);
    assert_int_equal(outcome_count(d, "held"), 0);
    assert_true(wgt_exists(wgt_join(d, "o/t_blurred.png")));
    assert_true(wgt_exists(wgt_join(d, "o/t_level.exr")));
    /* every file is what a render into an empty folder writes (1 thread, no cache) */
    WGT_SH(d, 0,
           "$WG render t.wetgraph -o fresh -q --threads 1 --set k=0.25 --format level=exr32 && "
           "cmp o/t_noise.exr fresh/t_noise.exr && cmp o/t_blurred.png fresh/t_blurred.png && "
           "cmp o/t_level.exr fresh/t_level.exr");
    /* without --cache every output is computed (and its unchanged file kept) */
    WGT_SH(d, 0, "$WG render t.wetgraph -o o -q --set k=0.25 --format level=exr32 --stats=json");
    assert_int_equal(computed(d), 3);
    /* a sequence: the frames already in their files are held, so no image is even read (the
     * same frames into another folder read them from the disk) */
    WGT_SH(d, 0, "$WG render t.wetgraph -o f -q --cache c --frames 0:2 --stats=json");
    WGT_SH(d, 0, "$WG render t.wetgraph -o f2 -q --cache c --frames 0:2 --stats=json");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "\"peak_bytes\": 0,"), 0);
    WGT_SH(d, 0, "$WG render t.wetgraph -o f -q --cache c --frames 0:2 --stats=json");
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "\"computed\": 0, \"reused\": 3"), 3);
    assert_int_equal(wgt_count_in(wgt_join(d, "out"), "\"peak_bytes\": 0,"), 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_info_prune_clear),
        cmocka_unit_test(test_cache_max),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_outputs_held_by_their_files),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
