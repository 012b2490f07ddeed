/* SPDX-License-Identifier: MIT */
/* `wetgraph render --batch`: CSV and JSON-lines lists give the same files as single renders
 * with the same --input and --set; CSV quoting (commas, doubled quotes, CRLF, empty lines);
 * a failing row is reported with its LIST line and does not stop the others (exit 1); three
 * --shard processes running at the same time into one --cache folder write the same files as
 * one unsharded batch, byte for byte; nodes equal across rows are computed once; malformed
 * lists and bad options are usage errors naming the file and line. Runs WETGRAPH_BIN. */
#include "wgtest.h"

#include <dirent.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>

static const char gen[] = "<wetgraph version=\"1\" size=\"48x32\">\n"
                          "  <node id=\"n\" type=\"noise\" scale=\"3\"/>\n"
                          "  <output name=\"img\" from=\"n\" format=\"png16\"/>\n"
                          "</wetgraph>\n";

static const char graph[] =
    "<wetgraph version=\"1\" size=\"48x32\">\n"
    "  <param name=\"level\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <input name=\"tex\" type=\"gray\" default=\"0.25\"/>\n"
    "  <node id=\"soft\" type=\"blur\" sigma=\"3\"><in name=\"source\" from=\"$tex\"/></node>\n"
    "  <node id=\"lvl\" type=\"uniform\" value=\"=level\"/>\n"
    "  <node id=\"mix\" type=\"blend\" mode=\"multiply\">\n"
    "    <in name=\"foreground\" from=\"soft\"/><in name=\"background\" from=\"lvl\"/>\n"
    "  </node>\n"
    "  <output name=\"a\" from=\"mix\" format=\"exr32\"/>\n"
    "  <output name=\"b\" from=\"soft\" format=\"png\"/>\n"
    "</wetgraph>\n";

static char dir[1024];

static const char *path(const char *name)
{
    return wgt_join(dir, name);
}

/* Run a shell command in dir ("$WG" is the wetgraph binary); returns the exit status, stdout
 * and stderr in files out / err. */
static int sh(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int sh(const char *fmt, ...)
{
    char command[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(command, sizeof command, fmt, ap);
    va_end(ap);
    return wgt_shell(dir, "%s", command);
}

static void put_file(const char *name, const char *text)
{
    wgt_write_file(path(name), text);
}

static bool contains(const char *name, const char *needle)
{
    char *text = wgt_read_file(path(name), NULL);
    bool found = strstr(text, needle) != NULL;
    if (!found) fprintf(stderr, "'%s' not in %s:\n%s\n", needle, name, text);
    free(text);
    return found;
}

/* Two files hold the same bytes. */
static void assert_same_file(const char *a, const char *b)
{
    if (!wgt_same_file(path(a), path(b))) fail_msg("%s and %s differ", a, b);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s/batch", wgt_tmpdir());
    mkdir(dir, 0777);
    put_file("gen.wetgraph", gen);
    put_file("g.wetgraph", graph);
    for (int s = 1; s <= 3; s++) {
        char cmd[128];
        snprintf(cmd, sizeof cmd, "\"$WG\" render gen.wetgraph --seed %d -o in%d -q", s, s);
        if (sh("%s", cmd)) return -1;
    }
    return 0;
}

/* Each row's files (in folder out) equal a single render with the same --input and --set. */
static void assert_row_equals_single(const char *out, const char *input, const char *level)
{
    static int count;
    char cmd[512], single[64], a[256], b[256];
    snprintf(single, sizeof single, "single%d", count++);
    snprintf(cmd, sizeof cmd, "\"$WG\" render g.wetgraph -q -o %s %s%s --set level=%s", single,
             input ? "--input tex=" : "", input ? input : "", level);
    assert_int_equal(sh("%s", cmd), 0);
    for (int k = 0; k < 2; k++) {
        snprintf(a, sizeof a, "%s/g_%s", out, k ? "b.png" : "a.exr");
        snprintf(b, sizeof b, "%s/g_%s", single, k ? "b.png" : "a.exr");
        assert_same_file(a, b);
    }
}

static void test_csv_rows_equal_single_renders(void **state)
{
    (void)state;
    put_file("list.csv", "input:tex,set:level,out\n"
                         "in1/gen_img.png,0.2,c1\n"
                         "in2/gen_img.png,0.7,c2\n"
                         "in1/gen_img.png,0.9,c3\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch list.csv"), 0);
    assert_true(contains("out", "c3/g_a.exr"));
    assert_true(contains("err", "3 rendered, 0 failed"));
    assert_row_equals_single("c1", "in1/gen_img.png", "0.2");
    assert_row_equals_single("c2", "in2/gen_img.png", "0.7");
    assert_row_equals_single("c3", "in1/gen_img.png", "0.9");
}

/* Columns named #... (an id, a comment) are carried along and ignored; the rows render as
 * without them. */
static void test_ignored_columns(void **state)
{
    (void)state;
    put_file("ids.csv", "#id,input:tex,#note,set:level,out\n"
                        "first,in1/gen_img.png,\"a note, with a comma\",0.2,i1\n"
                        "second,in2/gen_img.png,,0.7,i2\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch ids.csv"), 0);
    assert_true(contains("err", "2 rendered, 0 failed"));
    assert_row_equals_single("i1", "in1/gen_img.png", "0.2");
    assert_row_equals_single("i2", "in2/gen_img.png", "0.7");
}

/* JSON lines; relative paths are relative to the LIST's folder, not the current one; an
 * input left out keeps the graph's default; numbers, strings and booleans as values. */
static void test_jsonl_rows(void **state)
{
    (void)state;
    mkdir(path("lists"), 0777);
    put_file("lists/l.jsonl",
             "{\"inputs\": {\"tex\": \"../in3/gen_img.png\"}, \"set\": {\"level\": 0.25}, \"out\": "
             "\"../j1\"}\n"
             "\n"
             "  {\"out\": \"../j2\", \"set\": {\"level\": \"0.5\"}}\r\n"
             "{\"set\": {\"level\": \"=0.1 * 3\"}, \"inputs\": {\"tex\": \"../in2/gen_img.png\"}, "
             "\"out\": \"../j\\u0033\"}\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch lists/l.jsonl --batch-json"), 0);
    assert_true(contains("out", "{\"row\": 0, \"line\": 1, \"status\": \"ok\", \"outputs\": "
                                "[\"lists/../j1/g_a.exr\", \"lists/../j1/g_b.png\"]"));
    assert_true(contains("out", "{\"row\": 2, \"line\": 4, \"status\": \"ok\""));
    assert_row_equals_single("j1", "in3/gen_img.png", "0.25");
    assert_row_equals_single("j2", NULL, "0.5");
    assert_row_equals_single("j3", "in2/gen_img.png", "0.3");
}

/* Quoted fields with commas, doubled quotes and line breaks; CRLF; empty lines; spaces around
 * unquoted fields; a UTF-8 byte order mark; empty cells leave the value as it was. */
static void test_csv_quoting(void **state)
{
    (void)state;
    put_file("q.csv", "\xef\xbb\xbfset:level , out\r\n"
                      "\r\n"
                      "\"0.4\",\"q, \"\"one\"\"\"\r\n"
                      "  \"=0.2 + 0.1\" , \"q\ntwo\"\r\n"
                      "\n"
                      ",q3\r\n"
                      "0.5,q4\r");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch q.csv --set level=0.6"), 0);
    assert_row_equals_single("q, \"one\"", NULL, "0.4");
    assert_row_equals_single("q\ntwo", NULL, "0.3");
    assert_row_equals_single("q3", NULL, "0.6");
    assert_row_equals_single("q4", NULL, "0.5"); /* a CR at the very end ends the line */
}

/* A bad value and a missing file fail their rows, named with the LIST's line; the other rows
 * are written; exit 1; a failed row writes nothing. */
static void test_failing_rows(void **state)
{
    (void)state;
    put_file("f.csv", "input:tex,set:level,out\n"
                      "in1/gen_img.png,0.3,f1\n"
                      "in1/gen_img.png,2,f2\n"
                      "missing.png,0.3,f3\n"
                      "in2/gen_img.png,0.3,f4\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch f.csv --batch-json"), 1);
    assert_true(wgt_exists(path("f1/g_a.exr")));
    assert_true(wgt_exists(path("f4/g_a.exr")));
    assert_false(wgt_exists(path("f2")));
    assert_false(wgt_exists(path("f3")));
    assert_true(contains("err", "f.csv:3:17: row 1: set 'level'"));
    assert_true(contains("err", "f.csv:4:1: row 2: input 'tex': cannot open"));
    assert_true(contains("err", "missing.png"));
    assert_true(contains("err", "2 rendered, 2 failed"));
    assert_true(
        contains("out", "{\"row\": 1, \"line\": 3, \"status\": \"failed\", \"outputs\": []"));
    assert_true(contains("out", "{\"row\": 3, \"line\": 5, \"status\": \"ok\""));
}

/* A graph warning is printed for each row it applies to, after the row, and listed in the
 * row's JSON line; -q hides it. */
static void test_warnings_per_row(void **state)
{
    (void)state;
    put_file("wv.wetgraph",
             "<wetgraph version=\"1\" size=\"8\">\n"
             "  <param name=\"level\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
             "  <warning when=\"=level > 0.7\" message=\"level {level} is high\"/>\n"
             "  <node id=\"u\" type=\"uniform\" value=\"=level\"/>\n"
             "  <output name=\"o\" from=\"u\"/>\n"
             "</wetgraph>\n");
    put_file("wv.csv", "set:level,out\n"
                       "0.3,w0\n"
                       "0.8,w1\n"
                       "0.25,w2\n"
                       "0.9,w3\n");
    assert_int_equal(sh("\"$WG\" render wv.wetgraph --batch wv.csv --batch-json"), 0);
    assert_int_equal(wgt_count_in(path("err"), "wetgraph: warning:"), 2);
    assert_true(contains("err", "wetgraph: warning: wv.csv:3: row 1: wv.wetgraph:3: level 0.8 "
                                "is high\n"));
    assert_true(contains("err", "wetgraph: warning: wv.csv:5: row 3: wv.wetgraph:3: level 0.9 "
                                "is high\n"));
    assert_true(contains("out", "\"warnings\": [], \"error\": null}\n{\"row\": 1"));
    assert_true(contains("out", "\"warnings\": [{\"file\": \"wv.wetgraph\", \"line\": 3, "
                                "\"node\": null, \"message\": \"level 0.9 is high\"}]"));
    assert_int_equal(sh("\"$WG\" render wv.wetgraph --batch wv.csv -q"), 0);
    assert_int_equal(wgt_count_in(path("err"), "warning"), 0);
}

/* The rows after the first compute only what differs: same input, other level: only the
 * level and the blend; the same row again: nothing. */
static void test_shared_nodes_computed_once(void **state)
{
    (void)state;
    put_file("s.csv", "input:tex,set:level,out\n"
                      "in1/gen_img.png,0.3,s1\n"
                      "in1/gen_img.png,0.4,s2\n"
                      "in1/gen_img.png,0.4,s3\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch s.csv --batch-json"), 0);
    assert_true(contains("out", "\"row\": 1, \"line\": 3, \"status\": \"ok\", \"outputs\": "
                                "[\"s2/g_a.exr\", \"s2/g_b.png\"], \"computed\": 2,"));
    assert_true(contains("out", "[\"s3/g_a.exr\", \"s3/g_b.png\"], \"computed\": 0,"));
}

/* The memory cache after each row stays near what a row uses instead of growing with every
 * row, and what the rows share is still served from it: 16 rows over one texture, each with a
 * level of its own, compute the shared blur once; the cache holds no more after the last row
 * than after the fourth, and a level seen two rows before is still cached. */
static void test_cache_bounded_across_rows(void **state)
{
    (void)state;
    FILE *f = fopen(path("many.csv"), "w");
    assert_non_null(f);
    fprintf(f, "input:tex,set:level,out\n");
    for (int i = 0; i < 16; i++) fprintf(f, "in1/gen_img.png,0.%02d,m%d\n", 10 + i, i);
    fprintf(f, "in1/gen_img.png,0.24,m16\n"); /* row 14's level again */
    fclose(f);
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch many.csv --batch-json"), 0);
    FILE *in = fopen(path("out"), "r");
    assert_non_null(in);
    char line[8192];
    long long cached[17];
    int computed[17], n = 0;
    while (n < 17 && fgets(line, sizeof line, in)) {
        const char *c = strstr(line, "\"computed\": "), *b = strstr(line, "\"cached_bytes\": ");
        assert_non_null(c);
        assert_non_null(b);
        computed[n] = atoi(c + 12);
        cached[n++] = atoll(b + 16);
    }
    fclose(in);
    assert_int_equal(n, 17);
    /* the texture, soft, lvl and mix; then lvl and mix, the texture and soft cached */
    assert_int_equal(computed[0], 4);
    for (int i = 1; i < 16; i++) assert_int_equal(computed[i], 2);
    assert_int_equal(computed[16], 0);
    assert_true(cached[3] > 0);
    if (cached[15] > cached[3])
        fail_msg("the cache grew from %lld bytes after row 3 to %lld after row 15", cached[3],
                 cached[15]);
}

/* The sum of the "computed" counts of the JSON lines in `name`, and the rows there. */
static int computed_sum(const char *name, int *rows)
{
    FILE *f = fopen(path(name), "r");
    assert_non_null(f);
    char line[8192];
    int sum = 0, n = 0;
    while (fgets(line, sizeof line, f)) {
        const char *k = strstr(line, "\"computed\": ");
        assert_non_null(k);
        sum += atoi(k + 12);
        n++;
    }
    fclose(f);
    if (rows) *rows = n;
    return sum;
}

/* Shards are blocks of consecutive rows, so a material listed together stays on one shard and
 * what its rows share is computed once: the shards together compute what the unsharded batch
 * does. With --shard-by, rows of one value go together however the list interleaves them. */
static void test_shard_blocks(void **state)
{
    (void)state;
    put_file("blk.csv", "#material,input:tex,set:level,out\n"
                        "one,in1/gen_img.png,0.1,b0\n"
                        "one,in1/gen_img.png,0.2,b1\n"
                        "one,in1/gen_img.png,0.3,b2\n"
                        "two,in2/gen_img.png,0.1,b3\n"
                        "two,in2/gen_img.png,0.2,b4\n"
                        "two,in2/gen_img.png,0.3,b5\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch blk.csv --batch-json > all.jsonl"), 0);
    int all = computed_sum("all.jsonl", NULL), rows0, rows1;
    for (int i = 0; i < 2; i++)
        assert_int_equal(
            sh("\"$WG\" render g.wetgraph --batch blk.csv --batch-json --shard %d/2 > s%d.jsonl", i,
               i),
            0);
    int sharded = computed_sum("s0.jsonl", &rows0) + computed_sum("s1.jsonl", &rows1);
    assert_int_equal(rows0, 3);
    assert_int_equal(rows1, 3);
    assert_int_equal(sharded, all);
    assert_true(contains("s0.jsonl", "\"row\": 2,"));
    assert_true(contains("s1.jsonl", "\"row\": 3,"));
    /* the same materials interleaved: --shard-by keeps each on one shard */
    put_file("mix.csv", "#material,input:tex,set:level,out\n"
                        "one,in1/gen_img.png,0.1,m0\n"
                        "two,in2/gen_img.png,0.1,m1\n"
                        "one,in1/gen_img.png,0.2,m2\n"
                        "two,in2/gen_img.png,0.2,m3\n"
                        "three,in3/gen_img.png,0.2,m4\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch mix.csv --batch-json > all.jsonl"), 0);
    all = computed_sum("all.jsonl", NULL);
    for (int by = 0; by < 2; by++) {
        const char *column = by ? "input:tex" : "#material";
        for (int i = 0; i < 2; i++)
            assert_int_equal(sh("\"$WG\" render g.wetgraph --batch mix.csv --batch-json --shard "
                                "%d/2 --shard-by '%s' > s%d.jsonl",
                                i, column, i),
                             0);
        sharded = computed_sum("s0.jsonl", &rows0) + computed_sum("s1.jsonl", &rows1);
        assert_int_equal(rows0 + rows1, 5);
        assert_int_equal(sharded, all);
        assert_true(contains("s0.jsonl", "\"row\": 0,"));
        assert_true(contains("s0.jsonl", "\"row\": 2,"));
        assert_true(contains("s1.jsonl", "\"row\": 1,"));
        assert_true(contains("s1.jsonl", "\"row\": 3,"));
    }
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch mix.csv --shard 0/2 --shard-by "
                        "'#colour'"),
                     2);
    assert_true(contains("err", "--shard-by '#colour': the list has no such column"));
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch mix.csv --shard 0/2 --shard-by tex"), 2);
    assert_true(contains("err", "bad --shard-by 'tex'"));
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch mix.csv --shard-by out"), 2);
    assert_true(contains("err", "--shard-by needs --shard"));
}

static void list_files(const char *root, const char *sub, char *acc, size_t size)
{
    char full[2048];
    snprintf(full, sizeof full, "%s/%s", root, sub);
    DIR *d = opendir(full);
    assert_non_null(d);
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        if (e->d_name[0] == '.') fail_msg("unexpected file %s/%s", full, e->d_name);
        char rel[1024];
        snprintf(rel, sizeof rel, "%s%s%s", sub, sub[0] ? "/" : "", e->d_name);
        snprintf(full, sizeof full, "%s/%s", root, rel);
        struct stat st;
        assert_int_equal(stat(full, &st), 0);
        if (S_ISDIR(st.st_mode))
            list_files(root, rel, acc, size);
        else
            snprintf(acc + strlen(acc), size - strlen(acc), "%s\n", rel);
    }
    closedir(d);
}

/* Three shards at once into one cache folder write, together, exactly the files of one
 * unsharded batch; no temporaries are left in the cache, and a batch reading that cache gives
 * the same files again. Every input image is in rows of two shards, so two processes write the
 * cache entries of its blur at the same time. */
static void test_concurrent_shards(void **state)
{
    (void)state;
    char list[4096] = "input:tex,set:level,out\n";
    for (int i = 0; i < 12; i++)
        snprintf(list + strlen(list), sizeof list - strlen(list),
                 "../in%d/gen_img.png,0.%d,r%02d\n", 1 + (i / 2) % 3, 1 + i % 7, i);
    mkdir(path("one"), 0777);
    mkdir(path("shards"), 0777);
    mkdir(path("again"), 0777);
    put_file("one/l.csv", list);
    put_file("shards/l.csv", list);
    put_file("again/l.csv", list);
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch one/l.csv -q"), 0);
    assert_int_equal(sh("for i in 0 1 2; do (\"$WG\" render g.wetgraph --batch shards/l.csv "
                        "--shard $i/3 --cache cache --threads 1 -q; echo $? > rc$i) & done; wait"),
                     0);
    for (int i = 0; i < 3; i++) {
        char name[8];
        snprintf(name, sizeof name, "rc%d", i);
        assert_true(contains(name, "0\n"));
    }
    char a[8192] = "", b[8192] = "";
    list_files(path("one"), "", a, sizeof a);
    list_files(path("shards"), "", b, sizeof b);
    assert_string_equal(a, b);
    assert_true(strstr(a, "r11/g_b.png") != NULL);
    for (int i = 0; i < 12; i++)
        for (int k = 0; k < 2; k++) {
            char x[64], y[64];
            snprintf(x, sizeof x, "one/r%02d/g_%s", i, k ? "b.png" : "a.exr");
            snprintf(y, sizeof y, "shards/r%02d/g_%s", i, k ? "b.png" : "a.exr");
            assert_same_file(x, y);
        }
    char entries[65536] = "";
    list_files(path("cache"), "", entries, sizeof entries); /* fails on a leftover temporary */
    assert_true(strstr(entries, ".wgc") != NULL);
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch again/l.csv --cache cache -q"), 0);
    for (int i = 0; i < 12; i++) {
        char x[64], y[64];
        snprintf(x, sizeof x, "one/r%02d/g_a.exr", i);
        snprintf(y, sizeof y, "again/r%02d/g_a.exr", i);
        assert_same_file(x, y);
    }
}

/* Malformed lists, unknown names and bad options: exit 2 with the LIST's name and line, and
 * nothing rendered. */
static void test_usage_errors(void **state)
{
    (void)state;
    static const struct {
        const char *name, *text, *needle;
    } bad[] = {
        {"u1.csv", "set:level,out\n0.1,u1\n0.2,\"u2\n",
         "u1.csv:3:5: the quoted field is not closed"},
        {"u2.csv", "set:level,out\n0.1,u\"2\n", "u2.csv:2:6: a \" inside an unquoted field"},
        {"u3.csv", "set:level,out\n0.1,\"u3\"x\n", "u3.csv:2:9: unexpected 'x' after a quoted"},
        {"u4.csv", "set:level,colour\n0.1,u4\n", "u4.csv:1:11: unknown column 'colour'"},
        {"u5.csv", "set:level,out\n0.1,u5,extra\n",
         "u5.csv:2: the row has 3 fields, the header has 2"},
        {"u6.csv", "set:levl,out\n0.1,u6\n",
         "u6.csv:1:1: the graph g has no parameter 'levl'; did you mean 'level'?"},
        {"u7.csv", "", "u7.csv:1: the file is empty"},
        {"u8.jsonl", "{\"out\": \"u8\"}\n{\"set\": {\"level\": 0.1,}}\n",
         "u8.jsonl:2:23: a string in double quotes"},
        {"u9.jsonl", "{\"output\": \"u9\"}\n", "u9.jsonl:1:2: unknown key"},
        {"u10.jsonl", "{\"inputs\": {\"tex\": 3}}\n",
         "u10.jsonl:1:20: an input's value is a file path"},
        {"u11.jsonl", "{\"out\": \"u11\"} x\n", "u11.jsonl:1:16: unexpected text after"},
        {"u12.jsonl", "{\"inputs\": {\"text\": \"in1/gen_img.png\"}}\n",
         "u12.jsonl:1:13: the graph g has no image input 'text'"},
        {"u13.jsonl", "{\"set\": {\"level\": 1e}}\n",
         "u13.jsonl:1:21: a digit must follow the exponent"},
        /* a header alone is checked against the graph all the same */
        {"u14.csv", "#id,input:text,set:level,out\n",
         "u14.csv:1:5: the graph g has no image input 'text'"},
        {"u15.csv", "set:level,set:levl,out\n0.1,,u15\n",
         "u15.csv:1:11: the graph g has no parameter 'levl'; did you mean 'level'?"},
        /* a list saved with ';' between fields */
        {"u16.csv", "input:tex;set:level;out\nin1/gen_img.png;0.2;u16\n",
         "u16.csv:1:1: the header 'input:tex;set:level;out' is one column: its names are "
         "separated by ';'"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        put_file(bad[i].name, bad[i].text);
        assert_int_equal(sh("\"$WG\" render g.wetgraph --batch %s", bad[i].name), 2);
        assert_true(contains("err", bad[i].needle));
    }
    assert_false(wgt_exists(path("u1")));
    assert_false(wgt_exists(path("u8")));
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch list.txt"), 2);
    assert_true(contains("err", "list.txt: a batch list is a .csv or a .jsonl file"));
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch nothere.csv"), 1);
    assert_true(contains("err", "nothere.csv: cannot open the batch list: No such file"));
    assert_int_equal(sh("\"$WG\" render g.wetgraph --shard 0/2"), 2);
    assert_true(contains("err", "--shard needs --batch"));
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch-json"), 2);
    assert_true(contains("err", "--batch-json needs --batch"));
    static const char *const shards[] = {"2/2", "0/0", "1", "a/3", "-1/3", "0/1000001"};
    for (size_t i = 0; i < sizeof shards / sizeof shards[0]; i++) {
        assert_int_equal(sh("\"$WG\" render g.wetgraph --batch list.csv --shard '%s'", shards[i]),
                         2);
        assert_true(contains("err", "bad --shard"));
    }
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch list.csv --frames 0:2"), 2);
    assert_true(contains("err", "does not combine with --frames"));
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch list.csv --layered x.exr"), 2);
    assert_true(contains("err", "does not combine with --layered"));
}

/* Rows writing to one folder, spelled alike or not, are refused before anything is rendered,
 * naming both rows and their lines; rows without `out` write to -o, so they count too. */
static void test_shared_output_folders(void **state)
{
    (void)state;
    static const struct {
        const char *name, *text, *options, *needle;
    } bad[] = {
        {"d1.csv", "set:level,out\n0.1,d/a\n0.2,d/b\n0.3,d/./a/\n", "",
         "d1.csv:4: rows 0 (line 2) and 2 (line 4) write to the same output folder 'd/a' (as "
         "'d/./a/')"},
        {"d2.csv", "set:level,out\n\n0.1,d/x\n0.2,d//y\n\"0.3\",\"d/z/../y\"\n0.4,d/x2\n", "",
         "d2.csv:5: rows 1 (line 4) and 2 (line 5) write to the same output folder 'd//y'"},
        {"d3.jsonl",
         "{\"out\": \"d/j\"}\n{\"out\": \"d/k\"}\n{\"out\": \"d/k\"}\n{\"out\": \"./d/j\"}\n", "",
         "d3.jsonl:3: rows 1 (line 2) and 2 (line 3) write to the same output folder 'd/k':"},
        {"d4.csv", "set:level,out\n0.1,\n0.2,d/n\n0.3,\n", "-o d/m",
         "d4.csv:4: rows 0 (line 2) and 2 (line 4) write to the same output folder 'd/m' (a row "
         "without out writes to -o)"},
        {"d5.jsonl", "{\"set\": {\"level\": 0.1}}\n{\"out\": \"d/o/\"}\n", "-o ./d/o",
         "d5.jsonl:2: rows 0 (line 1) and 1 (line 2) write to the same output folder './d/o' (as "
         "'d/o/')"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        put_file(bad[i].name, bad[i].text);
        assert_int_equal(
            sh("\"$WG\" render g.wetgraph --batch %s %s --shard 0/2", bad[i].name, bad[i].options),
            2);
        assert_true(contains("err", bad[i].needle));
        assert_int_equal(wgt_count_in(path("err"), "\n"), 1);
        assert_false(wgt_exists(path("d")));
    }
    /* the same rows with folders of their own render */
    put_file("d6.csv", "set:level,out\n0.1,d/a\n0.2,d/a/b\n0.3,d/./c/\n0.4,\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch d6.csv -o d/m -q"), 0);
    assert_true(wgt_exists(path("d/a/b/g_a.exr")));
    assert_true(wgt_exists(path("d/m/g_a.exr")));
}

/* Names and text from the LIST are shown with control characters escaped: one line. */
static void test_errors_are_one_line(void **state)
{
    (void)state;
    static const struct {
        const char *name, *text, *needle;
    } bad[] = {
        {"e1.csv", "\"colour\nx\",out\n0.1,e1\n", "e1.csv:1:1: unknown column 'colour\\nx'"},
        {"e2.csv", "\"set:lev\r\nel\",out\n0.1,e2\n",
         "e2.csv:1:1: the graph g has no parameter 'lev\\r\\nel'"},
        {"e3.csv", "set:level,out\n\"0.1\"\x1b,e3\n",
         "e3.csv:2:6: unexpected '\\x1b' after a quoted field"},
        {"e4.jsonl", "{\"set\": {\"a\\tb\\u001b\": 1}}\n",
         "e4.jsonl:1:10: the graph g has no parameter 'a\\tb\\x1b'"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        put_file(bad[i].name, bad[i].text);
        assert_int_equal(sh("\"$WG\" render g.wetgraph --batch %s", bad[i].name), 2);
        assert_true(contains("err", bad[i].needle));
        assert_int_equal(wgt_count_in(path("err"), "\n"), 1);
    }
    put_file("e5.csv", "input:tex,out\n\"no\nsuch.png\",e5\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch e5.csv"), 1);
    assert_true(contains("err", "e5.csv:2:1: row 0: input 'tex': cannot open no\\nsuch.png: No "
                                "such file"));
}

/* The render options apply to every row: --output, --format, --size. */
static void test_options_apply_to_rows(void **state)
{
    (void)state;
    put_file("o.csv", "set:level,out\n0.1,p0\n0.2,p1\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch o.csv --output b --format exr32 "
                        "--size 16x8 -q"),
                     0);
    for (int i = 0; i < 2; i++) {
        char name[32];
        snprintf(name, sizeof name, "p%d/g_b.exr", i);
        WgImage *img = NULL;
        WgError err = {0};
        if (wg_image_read(path(name), 1, WG_LINEAR, &img, &err)) fail_msg("%s", err.message);
        assert_int_equal(img->width, 16);
        assert_int_equal(img->height, 8);
        wg_image_unref(img);
        snprintf(name, sizeof name, "p%d/g_a.exr", i);
        assert_false(wgt_exists(path(name)));
    }
}

/* An empty shard (more shards than rows) renders nothing and succeeds: of 5 blocks of 2 rows,
 * [⌊2I/5⌋, ⌊2(I+1)/5⌋), only the third and the fifth hold a row. */
static void test_empty_shard(void **state)
{
    (void)state;
    put_file("two.csv", "set:level,out\n0.1,e0\n0.2,e1\n");
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch two.csv --shard 3/5"), 0);
    assert_true(contains("err", "batch: 0 rows (shard 3/5 of 2 rows)"));
    assert_false(wgt_exists(path("e0")));
    assert_false(wgt_exists(path("e1")));
    assert_int_equal(sh("\"$WG\" render g.wetgraph --batch two.csv --shard 4/5"), 0);
    assert_false(wgt_exists(path("e0")));
    assert_true(wgt_exists(path("e1/g_a.exr")));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_csv_rows_equal_single_renders),
        cmocka_unit_test(test_ignored_columns),
        cmocka_unit_test(test_jsonl_rows),
        cmocka_unit_test(test_csv_quoting),
        cmocka_unit_test(test_failing_rows),
        cmocka_unit_test(test_warnings_per_row),
        cmocka_unit_test(test_shared_nodes_computed_once),
        cmocka_unit_test(test_cache_bounded_across_rows),
        cmocka_unit_test(test_shard_blocks),
        cmocka_unit_test(test_concurrent_shards),
        cmocka_unit_test(test_usage_errors),
        cmocka_unit_test(test_shared_output_folders),
        cmocka_unit_test(test_errors_are_one_line),
        cmocka_unit_test(test_options_apply_to_rows),
        cmocka_unit_test(test_empty_shard),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
