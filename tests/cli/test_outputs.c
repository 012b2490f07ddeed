/* SPDX-License-Identifier: MIT */
/* How `wetgraph render` (WETGRAPH_BIN) replaces its output files: all of them or none. Outputs
 * are written while the render runs, and the files are byte for byte those the library writes
 * after a whole render, at 1 and 4 threads and from a cold and a warm cache; an output that
 * fails mid-render (after others were staged) leaves the previous set and no temporaries. A
 * render that cannot write its last output leaves the previous render's files byte for byte and
 * no temporaries; temporaries left by writers killed with SIGKILL are removed by the next render
 * into the folder while those of live processes stay; on a full disk (a small tmpfs in a private
 * mount namespace, skipped where namespaces are not allowed) the error says so and nothing is
 * replaced. */
#include "wgtest.h"

#include "internal.h"
#include "wgio.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/xattr.h>
#include <sys/wait.h>
#include <unistd.h>

/* ---- helpers ----------------------------------------------------------------------------- */

static const char *bin(void)
{
    const char *b = getenv("WETGRAPH_BIN");
    if (!b || !b[0]) fail_msg("WETGRAPH_BIN is not set");
    return b;
}

static const char *at(const char *name)
{
    return wgt_path(name);
}

typedef struct {
    int status;
    char *out, *err;
} Run;

/* Run `wetgraph ARGS...` (NULL-terminated) in wgt_tmpdir(); collect status, stdout, stderr. */
static Run run(const char *first, ...)
{
    const char *argv[32] = {bin(), first};
    int n = 2;
    va_list ap;
    va_start(ap, first);
    for (const char *a; n < 31 && (a = va_arg(ap, const char *));) argv[n++] = a;
    va_end(ap);
    argv[n] = NULL;
    char out[1200], err[1200];
    snprintf(out, sizeof out, "%s", at("run.out"));
    snprintf(err, sizeof err, "%s", at("run.err"));
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        int o = open(out, O_WRONLY | O_CREAT | O_TRUNC, 0666);
        int e = open(err, O_WRONLY | O_CREAT | O_TRUNC, 0666);
        if (o < 0 || e < 0 || chdir(wgt_tmpdir()) || dup2(o, 1) < 0 || dup2(e, 2) < 0) _exit(98);
        execv(argv[0], (char *const *)argv);
        _exit(99);
    }
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    Run r = {WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st), NULL, NULL};
    r.out = wgt_read_file(out, NULL);
    r.err = wgt_read_file(err, NULL);
    return r;
}

static void expect(const Run *r, int status, const char *what)
{
    if (r->status != status)
        fail_msg("%s: exited %d, expected %d\nstdout:\n%s\nstderr:\n%s", what, r->status, status,
                 r->out, r->err);
}

static void expect_err(const Run *r, const char *needle)
{
    if (!strstr(r->err, needle)) fail_msg("expected '%s' in stderr:\n%s", needle, r->err);
}

static void run_free(Run *r)
{
    free(r->out);
    free(r->err);
}

static void rm_rf(const char *path)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", path);
    if (system(cmd) != 0) fail_msg("cannot remove %s", path);
}

static bool exists(const char *path)
{
    struct stat st;
    return lstat(path, &st) == 0;
}

/* Names in a folder (without . and ..), sorted, joined by spaces. */
static void listing(const char *dir, char *buf, size_t size)
{
    char cmd[1300];
    snprintf(cmd, sizeof cmd, "ls -A '%s' | tr '\\n' ' ' >'%s'", dir, at("ls.txt"));
    if (system(cmd) != 0) fail_msg("cannot list %s", dir);
    char *t = wgt_read_file(at("ls.txt"), NULL);
    snprintf(buf, size, "%s", t);
    free(t);
}

static int count_hidden(const char *dir)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (e->d_name[0] == '.' && strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) n++;
    closedir(d);
    return n;
}

static void expect_same_file(const char *a, const char *b)
{
    if (!wgt_same_file(a, b)) fail_msg("%s and %s differ", a, b);
}

static void copy_file(const char *from, const char *to)
{
    size_t n;
    char *data = wgt_read_file(from, &n);
    FILE *f = fopen(to, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
    free(data);
}

/* The id of a process that has exited and been reaped. */
static pid_t dead_pid(void)
{
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) _exit(0);
    assert_int_equal(waitpid(pid, NULL, 0), pid);
    return pid;
}

/* Four outputs (png16, png, exr32, exr32); `level` changes every one of them. */
static const char *const graph4 =
    "<wetgraph version=\"1\" size=\"16x8\" seed=\"3\">\n"
    "  <param name=\"level\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <node id=\"n\" type=\"noise\"/>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=level\"/>\n"
    "  <node id=\"m\" type=\"blend\" mode=\"multiply\"><in name=\"foreground\" from=\"n\"/>"
    "<in name=\"background\" from=\"u\"/></node>\n"
    "  <node id=\"a\" type=\"blend\" mode=\"add\"><in name=\"foreground\" from=\"n\"/>"
    "<in name=\"background\" from=\"u\"/></node>\n"
    "  <output name=\"mask\" from=\"m\" format=\"png16\"/>\n"
    "  <output name=\"color\" from=\"a\" format=\"png\"/>\n"
    "  <output name=\"time\" from=\"m\" format=\"exr32\"/>\n"
    "  <output name=\"seed\" from=\"a\" format=\"exr32\"/>\n"
    "</wetgraph>\n";

static const char *const outputs4[] = {"g_mask.png", "g_color.png", "g_time.exr", "g_seed.exr"};

static int setup(void **state)
{
    (void)state;
    wgt_write_file(at("g.wetgraph"), graph4);
    return 0;
}

/* dir/name in a rotating buffer */
static const char *in(const char *dir, const char *name)
{
    static char buf[8][1400];
    static int next;
    char *p = buf[next++ & 7];
    snprintf(p, sizeof buf[0], "%s/%s", at(dir), name);
    return p;
}

/* ---- all outputs or none ----------------------------------------------------------------- */

static void test_unwritable_last_output_replaces_nothing(void **state)
{
    (void)state;
    rm_rf(at("r1"));
    rm_rf(at("keep"));
    unlink(at("r1lay.exr"));
    Run r = run("render", "g.wetgraph", "-o", "r1", "--set", "level=0.2", "-q", NULL);
    expect(&r, 0, "first render");
    run_free(&r);
    /* keep the first three results; the fourth target becomes a folder */
    mkdir(at("keep"), 0777);
    for (int i = 0; i < 3; i++) copy_file(in("r1", outputs4[i]), in("keep", outputs4[i]));
    assert_int_equal(unlink(in("r1", outputs4[3])), 0);
    assert_int_equal(mkdir(in("r1", outputs4[3]), 0777), 0);

    r = run("render", "g.wetgraph", "-o", "r1", "--set", "level=0.9", NULL);
    expect(&r, 1, "render onto a folder");
    expect_err(&r, "r1/g_seed.exr: cannot replace the file: Is a directory");
    expect_err(&r, "no file was replaced");
    assert_string_equal(r.out, ""); /* no path printed */
    run_free(&r);
    for (int i = 0; i < 3; i++) expect_same_file(in("r1", outputs4[i]), in("keep", outputs4[i]));
    char names[1024];
    listing(at("r1"), names, sizeof names);
    assert_string_equal(names, "g_color.png g_mask.png g_seed.exr g_time.exr ");
    assert_int_equal(count_hidden(in("r1", outputs4[3])), 0);

    /* with --layered too: neither the layered file nor any output is written */
    r = run("render", "g.wetgraph", "-o", "r1", "--layered", "r1lay.exr", "--set", "level=0.9",
            NULL);
    expect(&r, 1, "layered render onto a folder");
    expect_err(&r, "g_seed.exr: cannot replace the file");
    run_free(&r);
    assert_false(exists(at("r1lay.exr")));
    for (int i = 0; i < 3; i++) expect_same_file(in("r1", outputs4[i]), in("keep", outputs4[i]));
    listing(at("r1"), names, sizeof names);
    assert_string_equal(names, "g_color.png g_mask.png g_seed.exr g_time.exr ");
    char root[1024];
    listing(wgt_tmpdir(), root, sizeof root);
    if (strstr(root, ".tmp")) fail_msg("temporaries left: %s", root);

    /* the same render succeeds once the folder is gone, and changes every file: the checks
     * above did look at files this render writes */
    assert_int_equal(rmdir(in("r1", outputs4[3])), 0);
    r = run("render", "g.wetgraph", "-o", "r1", "--set", "level=0.9", NULL);
    expect(&r, 0, "render after removing the folder");
    for (int i = 0; i < 4; i++)
        if (!strstr(r.out, outputs4[i])) fail_msg("%s not printed:\n%s", outputs4[i], r.out);
    run_free(&r);
    for (int i = 0; i < 3; i++)
        if (wgt_same_file(in("r1", outputs4[i]), in("keep", outputs4[i])))
            fail_msg("%s did not change", outputs4[i]);
    assert_int_equal(count_hidden(at("r1")), 0);
    rm_rf(at("r1"));
    rm_rf(at("keep"));
}

/* ---- stale temporaries ------------------------------------------------------------------- */

static void touch(const char *path)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs("partial\n", f);
    fclose(f);
}

static void test_stale_temporaries_are_removed(void **state)
{
    (void)state;
    rm_rf(at("s1"));
    rm_rf(at("s2"));
    mkdir(at("s1"), 0777);
    mkdir(at("s2"), 0777);
    pid_t dead = dead_pid();
    long me = (long)getpid();
    char name[256];
    /* removed: regular files named exactly like temporaries of a process that is gone */
    unsigned host = (unsigned)wg__temp_host(); /* this machine's id in the names */
    const char *gone[] = {".g_mask.tmp%ld-1-%08x.png", ".g_color.tmp%ld-12-%08x.png",
                          ".other.tmp%ld-3-%08x", ".x.y.tmp%ld-4294967295-%08x.exr"};
    for (int i = 0; i < 4; i++) {
        snprintf(name, sizeof name, gone[i], (long)dead, host);
        touch(in("s1", name));
    }
    snprintf(name, sizeof name, ".lay.tmp%ld-2-%08x.exr", (long)dead, host);
    touch(in("s2", name));
    /* kept: live processes (this one, init), another machine's and earlier versions' recent
     * temporaries, other names, and anything not a regular file */
    const char *live[] = {".g_mask.tmp%ld-1-%08x.png", ".g_seed.tmp%ld-9-%08x.exr"};
    for (int i = 0; i < 2; i++) {
        snprintf(name, sizeof name, live[i], me, host);
        touch(in("s1", name));
    }
    char init[64], foreign[64], legacy[64];
    snprintf(init, sizeof init, ".g_mask.tmp1-1-%08x.png", host);
    snprintf(foreign, sizeof foreign, ".g_mask.tmp%ld-2-%08x.png", (long)dead, host ^ 1u);
    snprintf(legacy, sizeof legacy, ".g_mask.tmp%ld-3.png", (long)dead);
    touch(in("s1", init));
    touch(in("s1", foreign));
    touch(in("s1", legacy));
    const char *other[] = {"g_mask.tmp%ld-1.png",   ".g_mask.tmp%ld-1.png.part",
                           ".g_mask.tmp%ld-x.png",  ".g_mask.tmp%ld1.png",
                           ".g_mask.tmp0%ld-1.png", ".a.b.tmp%ld-1",
                           ".tmp%ld-1.png",         ".g_mask.tmp%ld-01.png"};
    for (int i = 0; i < 8; i++) {
        snprintf(name, sizeof name, other[i], (long)dead);
        touch(in("s1", name));
    }
    snprintf(name, sizeof name, ".dir.tmp%ld-1-%08x.png", (long)dead, host);
    assert_int_equal(mkdir(in("s1", name), 0777), 0);
    char link[256];
    snprintf(link, sizeof link, ".link.tmp%ld-2-%08x.png", (long)dead, host);
    assert_int_equal(symlink("g_mask.png", in("s1", link)), 0);
    char before[4096];
    listing(at("s1"), before, sizeof before);

    Run r = run("render", "g.wetgraph", "-o", "s1", "--layered", "s2/lay.exr", "-q", NULL);
    expect(&r, 0, "render into a folder with temporaries");
    run_free(&r);

    for (int i = 0; i < 4; i++) {
        snprintf(name, sizeof name, gone[i], (long)dead, host);
        if (exists(in("s1", name))) fail_msg("stale %s was not removed", name);
    }
    snprintf(name, sizeof name, ".lay.tmp%ld-2-%08x.exr", (long)dead, host);
    if (exists(in("s2", name))) fail_msg("stale %s was not removed", name);
    assert_true(exists(in("s2", "lay.exr")));
    for (int i = 0; i < 2; i++) {
        snprintf(name, sizeof name, live[i], me, host);
        if (!exists(in("s1", name))) fail_msg("%s of a live process was removed", name);
    }
    assert_true(exists(in("s1", init)));
    assert_true(exists(in("s1", foreign)));
    assert_true(exists(in("s1", legacy)));
    for (int i = 0; i < 8; i++) {
        snprintf(name, sizeof name, other[i], (long)dead);
        if (!exists(in("s1", name))) fail_msg("%s is not a temporary but was removed", name);
    }
    snprintf(name, sizeof name, ".dir.tmp%ld-1-%08x.png", (long)dead, host);
    assert_true(exists(in("s1", name)));
    assert_true(exists(in("s1", link)));
    for (int i = 0; i < 4; i++) assert_true(exists(in("s1", outputs4[i])));
    rm_rf(at("s1"));
    rm_rf(at("s2"));
}

/* A writer killed with SIGKILL while its set is half written (two of its temporaries complete,
 * nothing renamed): the targets are as before, and the next render removes the temporaries. */
static void test_killed_writer_leaves_temporaries_the_next_render_removes(void **state)
{
    (void)state;
    rm_rf(at("k1"));
    Run r = run("render", "g.wetgraph", "-o", "k1", "--set", "level=0.3", "-q", NULL);
    expect(&r, 0, "first render");
    run_free(&r);
    rm_rf(at("kkeep"));
    mkdir(at("kkeep"), 0777);
    for (int i = 0; i < 4; i++) copy_file(in("k1", outputs4[i]), in("kkeep", outputs4[i]));

    int go[2];
    assert_int_equal(pipe(go), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        WgImage *img = wgt_image(64, 64, 1, NULL);
        WgWriteSet *set = wg_write_set_new();
        WgError err = {0};
        if (!set ||
            wg_write_set_image(set, in("k1", outputs4[0]), img, WG_FORMAT_PNG16, WG_LINEAR, &err) ||
            wg_write_set_image(set, in("k1", outputs4[2]), img, WG_FORMAT_EXR32, WG_LINEAR, &err))
            _exit(3);
        char c = 1;
        if (write(go[1], &c, 1) != 1) _exit(4);
        raise(SIGKILL);
        _exit(5);
    }
    close(go[1]);
    char c;
    assert_int_equal(read(go[0], &c, 1), 1);
    close(go[0]);
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    assert_true(WIFSIGNALED(st) && WTERMSIG(st) == SIGKILL);
    for (int i = 0; i < 4; i++) expect_same_file(in("k1", outputs4[i]), in("kkeep", outputs4[i]));
    assert_int_equal(count_hidden(at("k1")), 2);
    char names[1024], want[256];
    listing(at("k1"), names, sizeof names);
    snprintf(want, sizeof want, ".g_mask.tmp%ld-", (long)pid);
    if (!strstr(names, want)) fail_msg("no %s in %s", want, names);
    snprintf(want, sizeof want, ".g_time.tmp%ld-", (long)pid);
    if (!strstr(names, want)) fail_msg("no %s in %s", want, names);

    r = run("render", "g.wetgraph", "-o", "k1", "--set", "level=0.3", "-q", NULL);
    expect(&r, 0, "render after the kill");
    run_free(&r);
    assert_int_equal(count_hidden(at("k1")), 0);
    listing(at("k1"), names, sizeof names);
    assert_string_equal(names, "g_color.png g_mask.png g_seed.exr g_time.exr ");
    rm_rf(at("k1"));
    rm_rf(at("kkeep"));
}

/* ---- full disk --------------------------------------------------------------------------- */

/* In a child with a private mount namespace (as root, or in a new user namespace), mount a
 * 256 KiB tmpfs on `mnt` and run `script` there with sh. Returns the script's exit status, or -1
 * when namespaces or the mount are not allowed here. */
static int run_on_small_disk(const char *mnt, const char *script)
{
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        uid_t uid = geteuid();
        gid_t gid = getegid();
        if (unshare(CLONE_NEWNS) != 0) {
            if (unshare(CLONE_NEWUSER | CLONE_NEWNS) != 0) _exit(77);
            char map[64];
            int fd = open("/proc/self/setgroups", O_WRONLY);
            if (fd >= 0) {
                if (write(fd, "deny", 4) != 4) _exit(77);
                close(fd);
            }
            snprintf(map, sizeof map, "0 %u 1", (unsigned)uid);
            fd = open("/proc/self/uid_map", O_WRONLY);
            if (fd < 0 || write(fd, map, strlen(map)) < 0) _exit(77);
            close(fd);
            snprintf(map, sizeof map, "0 %u 1", (unsigned)gid);
            fd = open("/proc/self/gid_map", O_WRONLY);
            if (fd < 0 || write(fd, map, strlen(map)) < 0) _exit(77);
            close(fd);
        }
        if (mount("none", "/", NULL, MS_REC | MS_PRIVATE, NULL) != 0) _exit(77);
        if (mount("wgtest", mnt, "tmpfs", 0, "size=256k") != 0) _exit(77);
        execl("/bin/sh", "sh", "-c", script, (char *)NULL);
        _exit(77);
    }
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    if (!WIFEXITED(st)) fail_msg("the script died");
    return WEXITSTATUS(st) == 77 ? -1 : WEXITSTATUS(st);
}

static void test_full_disk_replaces_nothing(void **state)
{
    (void)state;
    rm_rf(at("disk"));
    rm_rf(at("dkeep"));
    rm_rf(at("dafter"));
    mkdir(at("disk"), 0777);
    mkdir(at("dkeep"), 0777);
    mkdir(at("dafter"), 0777);
    /* a small render fits; a large one (incompressible noise) does not */
    char script[4096];
    snprintf(script, sizeof script,
             "cd '%s' || exit 90\n"
             "'%s' render g.wetgraph -o disk/o --format png16 -q || exit 91\n"
             "cp disk/o/* dkeep/ || exit 92\n"
             "'%s' render g.wetgraph -o disk/o --format png16 --size 512 >big.out 2>big.err\n"
             "echo $? >big.status\n"
             "ls -A disk/o >after.ls; cp disk/o/* dafter/ || exit 93\n",
             wgt_tmpdir(), bin(), bin());
    int rc = run_on_small_disk(at("disk"), script);
    if (rc < 0) {
        print_message("no private mount namespace here: the full-disk case is not run\n");
        skip();
    }
    if (rc) fail_msg("the script failed at step %d", rc);
    char *status = wgt_read_file(at("big.status"), NULL);
    char *err = wgt_read_file(at("big.err"), NULL);
    char *out = wgt_read_file(at("big.out"), NULL);
    if (atoi(status) != 1) fail_msg("the large render exited %s, stderr:\n%s", status, err);
    if (!strstr(err, "cannot write the image: no space left on device"))
        fail_msg("stderr does not give the cause:\n%s", err);
    if (!strstr(err, "disk/o/g_")) fail_msg("stderr does not name the file:\n%s", err);
    assert_string_equal(out, "");
    char *ls = wgt_read_file(at("after.ls"), NULL);
    assert_string_equal(ls, "g_color.png\ng_mask.png\ng_seed.png\ng_time.png\n");
    const char *png[] = {"g_mask.png", "g_color.png", "g_time.png", "g_seed.png"};
    for (int i = 0; i < 4; i++) expect_same_file(in("dafter", png[i]), in("dkeep", png[i]));
    free(status);
    free(err);
    free(out);
    free(ls);
    rm_rf(at("disk"));
    rm_rf(at("dkeep"));
    rm_rf(at("dafter"));
}

/* ---- unchanged outputs are kept --------------------------------------------------------- */

/* `a` changes only "first", `b` only "second"; "third" depends on neither. */
static const char *const graph_keys =
    "<wetgraph version=\"1\" size=\"37x21\" seed=\"5\">\n"
    "  <param name=\"a\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <param name=\"b\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <node id=\"n\" type=\"noise\"/>\n"
    "  <node id=\"ua\" type=\"uniform\" value=\"=a\"/>\n"
    "  <node id=\"ub\" type=\"uniform\" value=\"=b\"/>\n"
    "  <node id=\"m\" type=\"blend\" mode=\"multiply\"><in name=\"foreground\" from=\"n\"/>"
    "<in name=\"background\" from=\"ua\"/></node>\n"
    "  <node id=\"s\" type=\"blend\" mode=\"add\"><in name=\"foreground\" from=\"n\"/>"
    "<in name=\"background\" from=\"ub\"/></node>\n"
    "  <output name=\"first\" from=\"m\" format=\"png16\"/>\n"
    "  <output name=\"second\" from=\"s\" format=\"png\"/>\n"
    "  <output name=\"third\" from=\"n\" format=\"exr32\"/>\n"
    "</wetgraph>\n";

/* A render of k.wetgraph (a = 0.6, b = 0.4) into kd writes `file` (one of its three) again and
 * keeps the other two; the file is then the one a fresh render wrote into kfresh. */
static void expect_written_again(const char *file, const char *what)
{
    Run r = run("render", "k.wetgraph", "-o", "kd", "--set", "a=0.6", "--set", "b=0.4", "--stats",
                NULL);
    expect(&r, 0, what);
    char kept[256];
    snprintf(kept, sizeof kept, "kept kd/%s", file);
    if (!strstr(r.err, "outputs: 1 written, 2 kept, ") || strstr(r.err, kept))
        fail_msg("%s was kept:\n%s", what, r.err);
    run_free(&r);
    expect_same_file(in("kd", file), in("kfresh", file));
}

static void test_unchanged_outputs_are_kept(void **state)
{
    (void)state;
    static const char *const files[] = {"k_first.png", "k_second.png", "k_third.exr"};
    wgt_write_file(at("k.wetgraph"), graph_keys);
    rm_rf(at("kd"));
    rm_rf(at("kfresh"));
    Run r = run("render", "k.wetgraph", "-o", "kd", "--set", "a=0.3", "--set", "b=0.4", NULL);
    expect(&r, 0, "first render");
    run_free(&r);
    struct stat before[3], after[3];
    for (int i = 0; i < 3; i++) assert_int_equal(stat(in("kd", files[i]), &before[i]), 0);
    wgt_sleep_ms(20);

    /* a changes: first is written again, second and third stay as they were */
    r = run("render", "k.wetgraph", "-o", "kd", "--set", "a=0.6", "--set", "b=0.4", "--stats",
            NULL);
    expect(&r, 0, "render with a changed");
    if (!strstr(r.err, "outputs: 1 written, 2 kept, ") || !strstr(r.err, "kept kd/k_second.png") ||
        !strstr(r.err, "kept kd/k_third.exr") || strstr(r.err, "kept kd/k_first.png"))
        fail_msg("--stats does not say what was kept:\n%s", r.err);
    assert_string_equal(r.out, "kd/k_first.png\n");
    run_free(&r);
    for (int i = 0; i < 3; i++) {
        assert_int_equal(stat(in("kd", files[i]), &after[i]), 0);
        bool same = after[i].st_ino == before[i].st_ino &&
                    after[i].st_mtim.tv_sec == before[i].st_mtim.tv_sec &&
                    after[i].st_mtim.tv_nsec == before[i].st_mtim.tv_nsec;
        if (same != (i > 0)) fail_msg("%s was %s", files[i], same ? "kept" : "rewritten");
    }
    /* the kept files are the ones a fresh render writes, byte for byte */
    r = run("render", "k.wetgraph", "-o", "kfresh", "--set", "a=0.6", "--set", "b=0.4", "-q", NULL);
    expect(&r, 0, "fresh render");
    run_free(&r);
    for (int i = 0; i < 3; i++) expect_same_file(in("kd", files[i]), in("kfresh", files[i]));

    /* a file changed by someone else since is written again, even for the same pixels */
    FILE *f = fopen(in("kd", files[1]), "r+b");
    assert_non_null(f);
    assert_int_equal(fputc('x', f) == 'x', 1);
    assert_int_equal(fclose(f), 0);
    expect_written_again(files[1], "the edited file");

    /* a file whose keys an earlier version of the writers recorded is written again too: that
     * version may have written other bytes for the same pixels */
    char key[256];
    ssize_t kn = lgetxattr(in("kd", files[2]), "user.wetgraph.key", key, sizeof key);
    if (kn < 3 || key[0] != 'v' || key[1] < '2' || key[1] > '9')
        fail_msg("no key attribute of the form v<version> on %s", files[2]);
    key[1]--;
    assert_int_equal(lsetxattr(in("kd", files[2]), "user.wetgraph.key", key, (size_t)kn, 0), 0);
    expect_written_again(files[2], "the file with an older version's keys");
}

/* The keys made on the render's workers while it runs are the ones made after it (outputs
 * written after the render, as with --layered and -o): files written one way are kept the other
 * way, for images of several rows a band. */
static void test_keys_on_workers_are_the_keys_after_the_render(void **state)
{
    (void)state;
    wgt_write_file(at("k.wetgraph"), graph_keys);
    rm_rf(at("kw"));
    Run r = run("render", "k.wetgraph", "-o", "kw", "--layered", "kw/all.exr", "--size", "61x300",
                "--threads", "2", "-q", NULL);
    expect(&r, 0, "render written after it");
    run_free(&r);
    r = run("render", "k.wetgraph", "-o", "kw", "--size", "61x300", "--threads", "2", "--stats",
            NULL);
    expect(&r, 0, "render written during it");
    if (!strstr(r.err, "outputs: 0 written, 3 kept, "))
        fail_msg("the files written after the render were not kept:\n%s", r.err);
    run_free(&r);
}

/* A layered EXR, written after the render, has its chunks encoded on as many threads as the
 * render had: the same file as the library's writer makes on the calling thread, on one thread
 * and on three (1100 rows: more chunks than one window of them). */
static void test_layered_exr_on_threads_is_the_same_file(void **state)
{
    (void)state;
    wgt_write_file(at("k.wetgraph"), graph_keys);
    rm_rf(at("lt"));
    Run r = run("render", "k.wetgraph", "--layered", "lt/one.exr", "--size", "23x1100", "--threads",
                "1", "-q", NULL);
    expect(&r, 0, "layered on one thread");
    run_free(&r);
    r = run("render", "k.wetgraph", "--layered", "lt/three.exr", "--size", "23x1100", "--threads",
            "3", "-q", NULL);
    expect(&r, 0, "layered on three threads");
    run_free(&r);
    /* the reference: the same images through wg_exr_write_layers, here */
    WgGraph *g = wgt_load_at(graph_keys, at("k.wetgraph"));
    WgRequest *req = wg_request_new(g);
    assert_non_null(req);
    wg_request_set_size(req, 23, 1100);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, req);
    int n = wg_result_output_count(res);
    const char *names[8];
    const WgImage *images[8];
    assert_true(n <= 8);
    for (int i = 0; i < n; i++) {
        names[i] = wg_result_output_name(res, i);
        images[i] = wg_result_output_image(res, i);
    }
    WgError err = {0};
    assert_int_equal(wg_exr_write_layers(at("lt/here.exr"), n, names, images, true, &err), WG_OK);
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(req);
    wg_graph_free(g);
    expect_same_file(at("lt/here.exr"), at("lt/one.exr"));
    expect_same_file(at("lt/here.exr"), at("lt/three.exr"));
}

/* ---- outputs written while the render runs ----------------------------------------------- */

static int count_words(const char *text)
{
    int n = 0;
    for (const char *p = text; *p; p++)
        if (*p != ' ' && (p == text || p[-1] == ' ')) n++;
    return n;
}

/* Outputs of every kind the writers handle, from nodes computed at different times: gray and
 * colour, opaque and with alpha (everywhere, or at one pixel at the end of the last row or in the
 * middle, or at none depending on the size), sRGB and linear, 8 and 16 bits, half and float EXR,
 * TIFF, and a uniform image. */
static const char *const graph_kinds =
    "<wetgraph version=\"1\" size=\"37x23\" seed=\"5\">\n"
    "  <param name=\"k\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\" octaves=\"3\"/>\n"
    "  <node id=\"b\" type=\"blur\" sigma=\"2\"><in name=\"source\" from=\"n\"/></node>\n"
    "  <node id=\"c\" type=\"pixel\" kind=\"color\" expr=\"rgb(n, b * k, 1 - n)\">"
    "<in name=\"n\" from=\"n\"/><in name=\"b\" from=\"b\"/></node>\n"
    "  <node id=\"a\" type=\"pixel\" kind=\"color\" expr=\"rgba(b, n, k, n * 0.9)\">"
    "<in name=\"n\" from=\"n\"/><in name=\"b\" from=\"b\"/></node>\n"
    "  <node id=\"e\" type=\"pixel\" kind=\"color\" "
    "expr=\"rgba(n, b, k, u &gt; 0.97 &amp;&amp; v &gt; 0.97 ? 0.5 : 1)\">"
    "<in name=\"n\" from=\"n\"/><in name=\"b\" from=\"b\"/></node>\n"
    "  <node id=\"i\" type=\"pixel\" kind=\"color\" expr=\"rgba(b, k, n, u &gt; 0.4 &amp;&amp; "
    "u &lt; 0.45 &amp;&amp; v &gt; 0.5 &amp;&amp; v &lt; 0.56 ? 0.25 : 1)\">"
    "<in name=\"n\" from=\"n\"/><in name=\"b\" from=\"b\"/></node>\n"
    "  <node id=\"u\" type=\"uniform\" value=\"=k * 0.3\"/>\n"
    "  <output name=\"gray16\" from=\"n\" format=\"png16\"/>\n"
    "  <output name=\"gray8\" from=\"b\" format=\"png\" colorspace=\"srgb\"/>\n"
    "  <output name=\"rgb8\" from=\"c\" format=\"png\" colorspace=\"srgb\"/>\n"
    "  <output name=\"rgba8\" from=\"a\" format=\"png\"/>\n"
    "  <output name=\"rgba16\" from=\"a\" format=\"png16\" colorspace=\"srgb\"/>\n"
    "  <output name=\"half\" from=\"c\" format=\"exr\"/>\n"
    "  <output name=\"float\" from=\"b\" format=\"exr32\"/>\n"
    "  <output name=\"tiff\" from=\"c\" format=\"tif16\"/>\n"
    "  <output name=\"flat\" from=\"u\" format=\"png16\"/>\n"
    "  <output name=\"corner8\" from=\"e\" format=\"png\"/>\n"
    "  <output name=\"inner8\" from=\"i\" format=\"png\" colorspace=\"srgb\"/>\n"
    "</wetgraph>\n";
static const char *const kinds[] = {"gray16", "gray8", "rgb8", "rgba8",   "rgba16", "half",
                                    "float",  "tiff",  "flat", "corner8", "inner8"};
#define N_KINDS ((int)(sizeof kinds / sizeof *kinds))

/* The files a render of graph_kinds writes, as the library writes them when the whole render
 * is done: each output of the result through wg_image_write. */
static void write_after_render(const char *dir, const char *size, const char *k)
{
    WgGraph *g = wgt_load_at(graph_kinds, at("kinds.wetgraph"));
    WgRequest *r = wg_request_new(g);
    assert_non_null(r);
    WgError err = {0};
    int w, h;
    assert_true(wg_parse_size(size, &w, &h));
    wg_request_set_size(r, w, h);
    assert_int_equal(wg_request_set(r, "k", k, &err), WG_OK);
    WgEngine *e = wgt_engine(2, 0, NULL);
    WgResult *res = wgt_render_request(e, r);
    mkdir(at(dir), 0777);
    for (int i = 0; i < wg_result_output_count(res); i++) {
        WgFormat f = wg_result_output_format(res, i);
        char name[256];
        snprintf(name, sizeof name, "kinds_%s.%s", wg_result_output_name(res, i),
                 wg_format_extension(f));
        assert_non_null(wg_result_output_image(res, i));
        if (wg_image_write(in(dir, name), wg_result_output_image(res, i), f,
                           wg_result_output_colorspace(res, i), &err))
            fail_msg("writing %s: %s", name, err.message);
    }
    wg_result_free(res);
    wg_engine_free(e);
    wg_request_free(r);
    wg_graph_free(g);
}

/* Byte for byte; a TIFF holds the time it was written (OpenImageIO's DateTime tag), so two
 * TIFFs are compared by their decoded samples. */
static bool same_output(const char *a, const char *b)
{
    size_t n = strlen(a);
    if (n < 4 || strcmp(a + n - 4, ".tif")) return wgt_same_file(a, b);
    WgImage *x = NULL, *y = NULL;
    WgError err = {0};
    if (wg_image_read(a, 0, WG_LINEAR, &x, &err) || wg_image_read(b, 0, WG_LINEAR, &y, &err))
        fail_msg("cannot read: %s", err.message);
    bool same = x->width == y->width && x->height == y->height && x->channels == y->channels &&
                wgt_max_abs_diff(x, y) == 0;
    wg_image_unref(x);
    wg_image_unref(y);
    return same;
}

static void test_streamed_outputs_are_the_files_written_after_the_render(void **state)
{
    (void)state;
    static const char *const ext[N_KINDS] = {"png", "png", "png", "png", "png", "exr",
                                             "exr", "tif", "png", "png", "png"};
    static const char *const sizes[] = {"37x23", "64x5", "3x41"};
    static const char *const ks[] = {"0.5", "0.83", "0.1"};
    wgt_write_file(at("kinds.wetgraph"), graph_kinds);
    for (int v = 0; v < 3; v++) {
        rm_rf(at("ref"));
        write_after_render("ref", sizes[v], ks[v]);
        char set[32];
        snprintf(set, sizeof set, "k=%s", ks[v]);
        rm_rf(at("stcache"));
        /* 1 and 4 threads, then twice with a cache folder: cold, then every node from it */
        for (int t = 0; t < 4; t++) {
            static const char *const dirs[] = {"st1", "st4", "stcold", "stwarm"};
            const char *threads = t == 1 ? "4" : t == 3 ? "3" : "1", *dir = dirs[t];
            rm_rf(at(dir));
            Run r = t < 2 ? run("render", "kinds.wetgraph", "-o", dir, "--size", sizes[v], "--set",
                                set, "--threads", threads, NULL)
                          : run("render", "kinds.wetgraph", "-o", dir, "--size", sizes[v], "--set",
                                set, "--threads", threads, "--cache", "stcache", NULL);
            expect(&r, 0, "streamed render");
            for (int i = 0; i < N_KINDS; i++) {
                char name[64];
                snprintf(name, sizeof name, "kinds_%s.%s", kinds[i], ext[i]);
                if (!strstr(r.out, name)) fail_msg("%s not printed:\n%s", name, r.out);
                if (!same_output(in(dir, name), in("ref", name)))
                    fail_msg("%s, %s, %s threads: %s differs from the file written after the "
                             "render",
                             sizes[v], set, threads, name);
            }
            run_free(&r);
            assert_int_equal(count_hidden(at(dir)), 0);
            char names[1024];
            listing(at(dir), names, sizeof names);
            assert_int_equal(count_words(names), N_KINDS);
        }
    }
    rm_rf(at("ref"));
    rm_rf(at("st1"));
    rm_rf(at("st4"));
    rm_rf(at("stcold"));
    rm_rf(at("stwarm"));
    rm_rf(at("stcache"));
}

/* The first outputs are final, encoded and staged long before the last one, which fails: its
 * format needs the OpenImageIO module, which cannot be found. */
static const char *const graph_late_failure =
    "<wetgraph version=\"1\" size=\"48x40\">\n"
    "  <param name=\"k\" type=\"float\" default=\"0.5\" min=\"0\" max=\"1\"/>\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
    "  <node id=\"m\" type=\"pixel\" expr=\"n * k\"><in name=\"n\" from=\"n\"/></node>\n"
    "  <node id=\"b1\" type=\"blur\" sigma=\"3\"><in name=\"source\" from=\"m\"/></node>\n"
    "  <node id=\"b2\" type=\"blur\" sigma=\"5\"><in name=\"source\" from=\"b1\"/></node>\n"
    "  <node id=\"b3\" type=\"blur\" sigma=\"7\"><in name=\"source\" from=\"b2\"/></node>\n"
    "  <output name=\"early\" from=\"m\" format=\"png16\"/>\n"
    "  <output name=\"middle\" from=\"b1\" format=\"png\"/>\n"
    "  <output name=\"late\" from=\"b3\" format=\"%s\"/>\n"
    "</wetgraph>\n";

static void test_failing_output_mid_render_replaces_nothing(void **state)
{
    (void)state;
    static const char *const files[] = {"late_early.png", "late_middle.png", "late_late.tif"};
    char xml[2048];
    snprintf(xml, sizeof xml, graph_late_failure, "tif16");
    wgt_write_file(at("late.wetgraph"), xml);
    rm_rf(at("lf"));
    rm_rf(at("lfkeep"));
    Run r = run("render", "late.wetgraph", "-o", "lf", "--set", "k=0.3", "-q", NULL);
    expect(&r, 0, "first render");
    run_free(&r);
    mkdir(at("lfkeep"), 0777);
    for (int i = 0; i < 3; i++) copy_file(in("lf", files[i]), in("lfkeep", files[i]));

    /* without the module, with one worker (so that the early outputs are staged before the
     * last node runs) and with four */
    static const char *const threads[] = {"1", "4"};
    for (int t = 0; t < 2; t++) {
        char cmd[1024];
        snprintf(cmd, sizeof cmd,
                 "WETGRAPH_MODULE_DIR=/nonexistent-module-dir \"%s\" render late.wetgraph -o lf "
                 "--set k=0.9 --threads %s >lf.out 2>lf.err",
                 bin(), threads[t]);
        int rc = wgt_shell(wgt_tmpdir(), "%s", cmd);
        char *err = wgt_read_file(at("lf.err"), NULL), *out = wgt_read_file(at("lf.out"), NULL);
        if (rc != 1 || !strstr(err, "late_late.tif") || !strstr(err, "OpenImageIO"))
            fail_msg("render without the module: exit %d, stderr:\n%s", rc, err);
        assert_string_equal(out, ""); /* no path printed */
        free(err);
        free(out);
        for (int i = 0; i < 3; i++) expect_same_file(in("lf", files[i]), in("lfkeep", files[i]));
        assert_int_equal(count_hidden(at("lf")), 0);
    }
    /* the same failure into a folder that does not exist yet leaves no folder */
    rm_rf(at("lfnew"));
    int rc = wgt_shell(wgt_tmpdir(),
                       "WETGRAPH_MODULE_DIR=/nonexistent-module-dir \"%s\" render late.wetgraph "
                       "-o lfnew --threads 1 >lf.out 2>lf.err",
                       bin());
    assert_int_equal(rc, 1);
    assert_false(exists(at("lfnew")));

    /* with the module the same render replaces all three */
    r = run("render", "late.wetgraph", "-o", "lf", "--set", "k=0.9", NULL);
    expect(&r, 0, "render with the module");
    run_free(&r);
    for (int i = 0; i < 3; i++)
        if (wgt_same_file(in("lf", files[i]), in("lfkeep", files[i])))
            fail_msg("%s did not change", files[i]);
    rm_rf(at("lf"));
    rm_rf(at("lfkeep"));
}

/* ---- PNG compression ----------------------------------------------------------------------- */

/* `deflate` compresses "first" in the graph; the other PNG is compressed by default (fast). */
static const char *const graph_compression =
    "<wetgraph version=\"1\" size=\"160x90\" seed=\"5\">\n"
    "  <node id=\"n\" type=\"noise\" scale=\"4\"/>\n"
    "  <node id=\"g\" type=\"gradient\"/>\n"
    "  <output name=\"first\" from=\"n\" format=\"png16\" compression=\"deflate\"/>\n"
    "  <output name=\"second\" from=\"g\" format=\"png\"/>\n"
    "</wetgraph>\n";

static long file_size(const char *path)
{
    struct stat st;
    if (stat(path, &st)) fail_msg("no %s", path);
    return (long)st.st_size;
}

/* The pixels of two files are the same (read back by the library). */
static void expect_same_pixels(const char *a, const char *b)
{
    WgImage *ia = NULL, *ib = NULL;
    WgError err = {0};
    if (wg_image_read(a, 0, WG_LINEAR, &ia, &err) || wg_image_read(b, 0, WG_LINEAR, &ib, &err))
        fail_msg("cannot read back: %s", err.message);
    wgt_assert_identical(ia, ib);
    wg_image_unref(ia);
    wg_image_unref(ib);
}

/* The graph's compression attribute and --png-compression (which overrides it for every PNG)
 * change the files, never their pixels; a file kept from a render with another compression is
 * written again; unknown values are errors naming the option or the file and line. */
static void test_png_compression_from_graph_and_command_line(void **state)
{
    (void)state;
    static const char *const files[] = {"c_first.png", "c_second.png"};
    wgt_write_file(at("c.wetgraph"), graph_compression);
    static const char *const dirs[] = {"cgraph", "cfast", "cdeflate", "cnone"};
    for (int d = 0; d < 4; d++) rm_rf(at(dirs[d]));
    Run r = run("render", "c.wetgraph", "-o", "cgraph", "-q", NULL);
    expect(&r, 0, "render with the graph's compression");
    run_free(&r);
    static const char *const modes[] = {"fast", "deflate", "none"};
    for (int m = 0; m < 3; m++) {
        r = run("render", "c.wetgraph", "-o", dirs[m + 1], "-q", "--png-compression", modes[m],
                NULL);
        expect(&r, 0, modes[m]);
        run_free(&r);
        for (int i = 0; i < 2; i++)
            expect_same_pixels(in("cgraph", files[i]), in(dirs[m + 1], files[i]));
    }
    /* the graph's: first deflate, second the default, fast */
    expect_same_file(in("cgraph", files[0]), in("cdeflate", files[0]));
    expect_same_file(in("cgraph", files[1]), in("cfast", files[1]));
    if (wgt_same_file(in("cgraph", files[0]), in("cfast", files[0])))
        fail_msg("compression=\"deflate\" wrote the default's file");
    /* none: the raw rows (160 x 90 16-bit and 8-bit gray), a filter byte each */
    assert_true(file_size(in("cnone", files[0])) >= 90 * (160 * 2 + 1));
    assert_true(file_size(in("cnone", files[1])) >= 90 * (160 + 1));
    assert_true(file_size(in("cfast", files[1])) < 90 * (160 + 1) / 2);
    assert_true(file_size(in("cdeflate", files[1])) < 90 * (160 + 1) / 2);

    /* the same folder with another compression: both files are written again; with the same,
     * both are kept */
    r = run("render", "c.wetgraph", "-o", "cgraph", "--png-compression", "none", NULL);
    expect(&r, 0, "render with another compression");
    assert_string_equal(r.out, "cgraph/c_first.png\ncgraph/c_second.png\n");
    run_free(&r);
    for (int i = 0; i < 2; i++) expect_same_file(in("cgraph", files[i]), in("cnone", files[i]));
    r = run("render", "c.wetgraph", "-o", "cgraph", "--png-compression", "none", NULL);
    expect(&r, 0, "render with the same compression");
    assert_string_equal(r.out, "");
    run_free(&r);
    r = run("render", "c.wetgraph", "-o", "cgraph", NULL);
    expect(&r, 0, "render with the graph's compression again");
    assert_string_equal(r.out, "cgraph/c_first.png\ncgraph/c_second.png\n");
    run_free(&r);
    expect_same_file(in("cgraph", files[0]), in("cdeflate", files[0]));
    expect_same_file(in("cgraph", files[1]), in("cfast", files[1]));

    /* unknown values */
    r = run("render", "c.wetgraph", "-o", "cbad", "--png-compression", "fastest", NULL);
    expect(&r, 2, "unknown --png-compression");
    expect_err(&r, "unknown --png-compression 'fastest' (fast, deflate, none)");
    run_free(&r);
    char *bad = strdup(graph_compression);
    assert_non_null(bad);
    memcpy(strstr(bad, "\"deflate\""), "\"zip\"    ", 9);
    wgt_write_file(at("cbad.wetgraph"), bad);
    free(bad);
    r = run("render", "cbad.wetgraph", "-o", "cbad", NULL);
    if (r.status == 0) fail_msg("a graph with compression=\"zip\" rendered");
    expect_err(&r, "cbad.wetgraph:4: output 'first': unknown compression 'zip' (fast, deflate, "
                   "none)");
    run_free(&r);
    assert_false(exists(at("cbad")));
    for (int d = 0; d < 4; d++) rm_rf(at(dirs[d]));
}

/* ---- identical outputs ---------------------------------------------------------------------- */

/* Two outputs of one node, a third of another node that makes the same pixels (the same
 * expression), a fourth of the first node in another format. */
static const char *const graph_twins =
    "<wetgraph version=\"1\" size=\"96x64\" seed=\"2\">\n"
    "  <node id=\"n\" type=\"pixel\" expr=\"u * v + 0.25 * sin(40 * u)\"/>\n"
    "  <node id=\"m\" type=\"pixel\" expr=\"u * v + 0.25 * sin(40 * u)\"/>\n"
    "  <output name=\"a\" from=\"n\" format=\"png16\"/>\n"
    "  <output name=\"b\" from=\"n\" format=\"png16\"/>\n"
    "  <output name=\"c\" from=\"m\" format=\"png16\"/>\n"
    "  <output name=\"d\" from=\"n\" format=\"png\"/>\n"
    "</wetgraph>\n";

/* An output whose file would be the same as another's of the same render is staged as a copy of
 * that file: the four files are what a render of each alone writes (the same bytes), --stats=json
 * lists one of a, b, c as written and the two others as copied, and d (8-bit: another file) as
 * written. With 1 and 2 threads, and with the outputs written after the render (--layered). */
static void test_identical_outputs_are_copied(void **state)
{
    (void)state;
    wgt_write_file(at("tw.wetgraph"), graph_twins);
    static const char *const names[] = {"a", "b", "c", "d"};
    for (int k = 0; k < 4; k++) { /* each output alone: its own file */
        char dir[32];
        snprintf(dir, sizeof dir, "tw_%s", names[k]);
        rm_rf(at(dir));
        Run r = run("render", "tw.wetgraph", "-o", dir, "-q", "--output", names[k], NULL);
        expect(&r, 0, "one output");
        run_free(&r);
    }
    for (int threads = 1; threads <= 2; threads++) {
        rm_rf(at("tw"));
        Run r = run("render", "tw.wetgraph", "-o", "tw", "--threads", threads == 1 ? "1" : "2",
                    "--stats=json", NULL);
        expect(&r, 0, "the four outputs");
        int copied = 0, written = 0;
        for (const char *p = r.out; (p = strstr(p, "\"file\": \"")); p++) {
            p += strlen("\"file\": \"");
            copied += !strncmp(p, "copied\"", 7);
            written += !strncmp(p, "written\"", 8);
        }
        if (copied != 2 || written != 2)
            fail_msg("%d threads: %d copied, %d written (expected 2 and 2):\n%s", threads, copied,
                     written, r.out);
        if (!strstr(r.out, "\"path\": \"tw/tw_d.png\", \"file\": \"written\""))
            fail_msg("the 8-bit output was not written: %s", r.out);
        run_free(&r);
        for (int k = 0; k < 4; k++) {
            char dir[32], file[32];
            snprintf(dir, sizeof dir, "tw_%s", names[k]);
            snprintf(file, sizeof file, "tw_%s.png", names[k]);
            expect_same_file(in("tw", file), in(dir, file));
        }
    }
    /* a second render keeps all four */
    Run r = run("render", "tw.wetgraph", "-o", "tw", NULL);
    expect(&r, 0, "again");
    assert_string_equal(r.out, "");
    run_free(&r);
    rm_rf(at("tw"));
    /* outputs written after the render (the way of --layered with -o, of batches and of watch)
     * are copied the same way */
    rm_rf(at("twl"));
    r = run("render", "tw.wetgraph", "--layered", "twl/all.exr", "-o", "twl", "--stats=json", NULL);
    expect(&r, 0, "the four outputs and the layered file");
    static const char *const how[] = {"written", "copied", "copied", "written"};
    for (int k = 0; k < 4; k++) {
        char want[96], file[32];
        snprintf(want, sizeof want, "\"path\": \"twl/tw_%s.png\", \"file\": \"%s\"", names[k],
                 how[k]);
        if (!strstr(r.out, want)) fail_msg("no '%s' in:\n%s", want, r.out);
        snprintf(file, sizeof file, "tw_%s.png", names[k]);
        char dir[32];
        snprintf(dir, sizeof dir, "tw_%s", names[k]);
        expect_same_file(in("twl", file), in(dir, file));
    }
    run_free(&r);
    rm_rf(at("twl"));
    for (int k = 0; k < 4; k++) {
        char dir[32];
        snprintf(dir, sizeof dir, "tw_%s", names[k]);
        rm_rf(at(dir));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_unwritable_last_output_replaces_nothing),
        cmocka_unit_test(test_stale_temporaries_are_removed),
        cmocka_unit_test(test_killed_writer_leaves_temporaries_the_next_render_removes),
        cmocka_unit_test(test_full_disk_replaces_nothing),
        cmocka_unit_test(test_unchanged_outputs_are_kept),
        cmocka_unit_test(test_keys_on_workers_are_the_keys_after_the_render),
        cmocka_unit_test(test_layered_exr_on_threads_is_the_same_file),
        cmocka_unit_test(test_streamed_outputs_are_the_files_written_after_the_render),
        cmocka_unit_test(test_failing_output_mid_render_replaces_nothing),
        cmocka_unit_test(test_png_compression_from_graph_and_command_line),
        cmocka_unit_test(test_identical_outputs_are_copied),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
