/* SPDX-License-Identifier: MIT */
/* Fused point operations. Point operations (WG_NODE_POINT: each output pixel depends only on
 * the same pixel of the inputs) that read one another as they are (same size, no promotion)
 * are evaluated as one group, band by band: every member computes a band of rows before the
 * next band starts, so what one member writes is still in the L2 cache when the next reads it.
 * A member whose result is requested, is read by a node outside the group, or is the group's
 * last node (its sink) writes its rows into a whole image, which is materialised and cached like
 * any node's; the others (read only inside the group) exist only as per-thread band buffers,
 * never as whole images: fewer allocations, less memory traffic, lower peak memory. A group is
 * convex: no path leaves it and comes back (a member feeding a blur that feeds another member
 * would need the whole image before the band), so the group as a whole depends on nothing it
 * feeds and runs as one job once its inputs from outside are there.
 *
 * A member is evaluated by handing its eval a context whose images are views of the band: the
 * data pointer of each input and output starts at the band's first row and the height is the
 * band's. ctx->height is the band's height too; nodes see no absolute row. Point nodes only
 * address pixels through wg_image_row and the sizes, so this is exact: results are
 * bit-identical to unfused evaluation, and the bands do not depend on the thread count. Bands
 * run in parallel on the worker pool; a member's own wg_parallel_rows runs inline then. Work
 * every band shares (a `pixel` node's compiled expression) is done once per evaluation of the
 * group by the type's prepare hook. */
#include "internal.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* Bytes of all the rows a band touches (the group's inputs, its whole results and its band
 * buffers): small enough that they stay in L2 while the members pass over them. */
#define FUSE_BAND_BYTES ((size_t)384 << 10)
/* The fewest bytes of one gray image in a band: below this each band's overhead (every
 * member's call) starts to show. */
#define FUSE_MIN_BAND_BYTES ((size_t)32 << 10)
/* The most band buffers of one group hold, per thread. A group is evaluated in plan order; a
 * wide one can hold many intermediates at once (a balanced tree of blends, one per level):
 * beyond this, its nodes run alone. */
#define FUSE_MAX_SCRATCH ((size_t)4 << 20)
/* Groups are found with bit sets of every node's ancestors (n^2 bits, three times: 6 MiB at
 * 4096 nodes): larger plans fuse only trees of single-consumer intermediates. */
#define FUSE_MAX_PLAN 4096

/* Node kinds that cannot work on a band even if they claim to be point operations. */
enum {
    NOT_BANDED = WG_NODE_NEIGHBOURHOOD | WG_NODE_GLOBAL | WG_NODE_SEEDED | WG_NODE_TIMED |
                 WG_NODE_SCOPED | WG_NODE_DYNAMIC_INPUTS | WG_NODE_EXTRA_PARAMS,
};

bool wg__fuse_capable(const WgInst *in)
{
    const WgNodeType *t = in->type;
    if (in->constant || t->scratch_bytes) return false;
    /* the instance's params decide: the flags describe every instance of the type */
    if (t->banded) return t->banded(in->params);
    return (t->flags & WG_NODE_POINT) && !(t->flags & NOT_BANDED);
}

/* Channels input k of `in` is evaluated with: colour ports promote gray sources. */
static int input_want(const WgInst *in, int k, int source_channels)
{
    const WgPortSpec *ports = in->type->inputs;
    for (int i = 0; ports && ports[i].name; i++)
        if (i == k) return ports[i].kind == WG_COLOR ? 4 : source_channels;
    return source_channels;
}

/* Whether input k of `in` reads its source as it is (no resampling, no promotion). */
static bool direct_input(const WgPlan *p, const WgInst *in, int k)
{
    const WgInst *src = &p->insts[in->in[k].inst];
    int sc = src->out_channels[in->in[k].port];
    return src->width == in->width && src->height == in->height && input_want(in, k, sc) == sc;
}

/* ---- finding the groups ------------------------------------------------------------------ */

typedef uint64_t Bits;

static bool has_bit(const Bits *s, int i)
{
    return s[i >> 6] >> (i & 63) & 1;
}

static void set_bit(Bits *s, int i)
{
    s[i >> 6] |= (Bits)1 << (i & 63);
}

/* Whether node j may join the set `s` (bits of plan indexes; j is in it): it reads the
 * members it reads as they are, and none of its other inputs is or depends on a member
 * (anc: each node's ancestors, `words` words per node). */
static bool may_join(const WgPlan *p, const Bits *anc, const Bits *s, size_t words, int j)
{
    const WgInst *in = &p->insts[j];
    for (int k = 0; k < in->n_in; k++) {
        int x = in->in[k].inst;
        if (x < 0) continue;
        if (has_bit(s, x)) {
            if (!direct_input(p, in, k)) return false;
            continue;
        }
        const Bits *a = anc + (size_t)x * words;
        for (size_t w = 0; w < words; w++)
            if (a[w] & s[w]) return false;
    }
    return true;
}

static bool disjoint(const Bits *a, const Bits *b, size_t words)
{
    for (size_t w = 0; w < words; w++)
        if (a[w] & b[w]) return false;
    return true;
}

static int limit_scratch(const WgPlan *p, int *sink, const bool *whole, int *groups);

/* The groups of plans too large for ancestor sets: chains and trees of point operations whose
 * intermediates have one consumer, which is in the group, and are not requested; only the sink
 * is materialised. */
static int find_trees(const WgPlan *p, const bool *run, const bool *requested, int *sink,
                      bool *whole)
{
    int n = p->n_insts, groups = 0;
    /* the one node reading node i through direct inputs only; -1 none yet, -2 anything else */
    int *consumer = wg_calloc((size_t)n + 1, sizeof(int));
    if (!consumer) return WG_ERR_NOMEM;
    for (int i = 0; i < n; i++) consumer[i] = -1;
    for (int j = 0; j < n; j++) {
        if (!run[j]) continue;
        const WgInst *in = &p->insts[j];
        bool capable = wg__fuse_capable(in);
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst;
            if (s < 0) continue;
            int c = consumer[s];
            consumer[s] = (c == -1 || c == j) && capable && direct_input(p, in, k) ? j : -2;
        }
    }
    /* consumers come after their inputs in the plan: a consumer's group is known first */
    for (int i = n - 1; i >= 0; i--) {
        int j = consumer[i];
        if (!run[i] || requested[i] || j <= i || !wg__fuse_capable(&p->insts[i])) continue;
        if (sink[j] < 0) {
            sink[j] = j;
            whole[j] = true;
            groups++;
        }
        sink[i] = sink[j];
    }
    wg_free(consumer);
    return groups;
}

/* Bytes of node i's outputs (one row for a uniform node's). */
static size_t out_bytes(const WgInst *in)
{
    size_t b = 0;
    int rows = in->type->flags & WG_NODE_UNIFORM ? 1 : in->height;
    for (int o = 0; o < in->n_out; o++)
        b += wg_image_bytes_for(in->width, rows, in->out_channels[o]);
    return b;
}

/* The peak memory of a sequential run in plan order as the scheduler estimates it (eval.c,
 * plan_work): each job (a node, or a group at its sink's place) needs what its nodes hold while
 * they run (wg__inst_need, without the results that exist only in bands) on top of the results
 * alive; then it keeps its materialised results and releases the inputs it read last. sink NULL:
 * nothing fused. need_of and bytes: each node's need and outputs; first and next: n ints. */
static size_t seq_peak(const WgPlan *p, const bool *run, const bool *requested, const int *sink,
                       const bool *whole, const size_t *need_of, const size_t *bytes, int *first,
                       int *next)
{
    int n = p->n_insts;
    size_t live = 0, peak = 0;
    /* members of each group in plan order, as linked lists from their sink */
    for (int i = 0; i < n; i++) first[i] = -1;
    for (int i = n - 1; i >= 0 && sink; i--)
        if (sink[i] >= 0) {
            next[i] = first[sink[i]];
            first[sink[i]] = i;
        }
    int *readers = wg_calloc((size_t)n + 1, sizeof(int)); /* the readers each node has left */
    if (!readers) return (size_t)-1;                      /* taken as higher: nothing fuses */
    for (int j = 0; j < n; j++) {
        const WgInst *in = &p->insts[j];
        for (int k = 0; run[j] && k < in->n_in; k++)
            if (in->in[k].inst >= 0) readers[in->in[k].inst]++;
    }
    for (int i = 0; i < n; i++) {
        if (!run[i] || (sink && sink[i] >= 0 && sink[i] != i)) continue;
        bool group = sink && sink[i] == i;
        size_t need = 0, kept = 0;
        for (int m = group ? first[i] : i; m >= 0; m = group ? next[m] : -1) {
            size_t own = bytes[m];
            bool held = !group || whole[m];
            need += need_of[m] - (held ? 0 : own);
            kept += held ? own : 0;
        }
        if (live + need > peak) peak = live + need;
        live += kept;
        for (int m = group ? first[i] : i; m >= 0; m = group ? next[m] : -1) {
            const WgInst *in = &p->insts[m];
            for (int k = 0; k < in->n_in; k++) {
                int x = in->in[k].inst;
                if (x < 0 || !run[x] || --readers[x] > 0 || requested[x]) continue;
                if (!(sink && sink[x] >= 0 && !whole[x])) live -= bytes[x];
            }
        }
        for (int m = group ? first[i] : i; m >= 0; m = group ? next[m] : -1)
            if (readers[m] == 0 && !requested[m] && (!group || whole[m])) live -= bytes[m];
    }
    wg_free(readers);
    return peak;
}

/* From the groups in leader[] (-1: alone): what is materialised (requested results and those
 * read outside their group), and each group's sink (its last member, materialised too), in
 * sink[] and whole[]. A constant node (uniform) materialised would have its one row written by
 * every band at once: it leaves its group instead (it has no inputs, so the group stays
 * convex). Returns the number of groups of two or more. */
static int settle(const WgPlan *p, const bool *run, const bool *requested, int *leader, int *sink,
                  bool *whole, int *last, int *count)
{
    int n = p->n_insts, groups = 0;
    for (int i = 0; i < n; i++) {
        whole[i] = false;
        sink[i] = -1;
    }
    for (int j = 0; j < n; j++) {
        if (!run[j]) continue;
        const WgInst *in = &p->insts[j];
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst;
            if (s >= 0 && leader[s] >= 0 && leader[s] != leader[j]) whole[s] = true;
        }
    }
    for (int i = 0; i < n; i++) {
        if (leader[i] < 0) continue;
        if (requested[i]) whole[i] = true;
        if (whole[i] && (p->insts[i].type->flags & WG_NODE_UNIFORM)) leader[i] = -1;
    }
    memset(count, 0, sizeof(int) * (size_t)n);
    for (int i = 0; i < n; i++)
        if (leader[i] >= 0) count[leader[i]]++;
    for (int i = 0; i < n; i++) last[i] = -1;
    for (int i = n - 1; i >= 0; i--) {
        int l = leader[i];
        if (l < 0 || count[l] < 2) continue;
        if (last[l] < 0) {
            last[l] = i;
            whole[i] = true;
            groups++;
        }
        sink[i] = last[l];
    }
    for (int i = 0; i < n; i++)
        if (sink[i] < 0) whole[i] = false;
    return groups;
}

int wg__fuse_find(const WgPlan *p, const bool *run, const bool *requested, int *sink, bool *whole)
{
    int n = p->n_insts, groups = 0, rc = WG_OK;
    for (int i = 0; i < n; i++) {
        sink[i] = -1;
        whole[i] = false;
    }
    if (n > FUSE_MAX_PLAN) {
        groups = find_trees(p, run, requested, sink, whole);
        if (groups > 0) rc = limit_scratch(p, sink, whole, &groups);
        for (int i = 0; i < n; i++)
            if (sink[i] < 0) whole[i] = false;
        return rc ? rc : groups;
    }
    size_t words = ((size_t)n + 63) / 64;
    /* anc: every node's ancestors; by group (its leader, the member it started from): set, its
     * members, and ext, the nodes outside it that its members read, with their ancestors (the
     * group stays convex as long as ext holds no member); leader: node i's group, or -1 */
    Bits *anc = wg_calloc((size_t)n * words + 1, sizeof(Bits));
    Bits *set = wg_calloc((size_t)n * words + 1, sizeof(Bits));
    Bits *ext = wg_calloc((size_t)n * words + 1, sizeof(Bits));
    Bits *cur = wg_calloc(words + 1, sizeof(Bits)), *cur_ext = wg_calloc(words + 1, sizeof(Bits));
    Bits *trial = wg_calloc(words + 1, sizeof(Bits));
    int *leader = wg_calloc((size_t)n + 1, sizeof(int)),
        *found = wg_calloc((size_t)n + 1, sizeof(int));
    int *count = wg_calloc((size_t)n + 1, sizeof(int));
    int *trial_leader = wg_calloc((size_t)n + 1, sizeof(int)),
        *trial_sink = wg_calloc((size_t)n + 1, sizeof(int));
    bool *trial_whole = wg_calloc((size_t)n + 1, sizeof(bool));
    size_t *need_of = wg_calloc((size_t)n + 1, sizeof(size_t)),
           *bytes = wg_calloc((size_t)n + 1, sizeof(size_t));
    if (!anc || !set || !ext || !cur || !cur_ext || !trial || !leader || !found || !count ||
        !trial_leader || !trial_sink || !trial_whole || !need_of || !bytes) {
        rc = WG_ERR_NOMEM;
        goto out;
    }
    /* in plan order (inputs before their consumers): a node joins the groups of the inputs it
     * reads as they are, the largest first, each one that keeps the union convex */
    for (int j = 0; j < n; j++) {
        const WgInst *in = &p->insts[j];
        Bits *aj = anc + (size_t)j * words;
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst;
            if (s < 0) continue;
            set_bit(aj, s);
            for (size_t w = 0; w < words; w++) aj[w] |= anc[(size_t)s * words + w];
        }
        leader[j] = -1;
        if (!run[j] || !wg__fuse_capable(in)) continue;
        leader[j] = j;
        count[j] = 1;
        set_bit(set + (size_t)j * words, j);
        memcpy(ext + (size_t)j * words, aj, words * sizeof(Bits)); /* alone: its ancestors */
        int n_found = 0;
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst;
            if (s < 0 || leader[s] < 0 || !direct_input(p, in, k)) continue;
            bool seen = false;
            for (int q = 0; q < n_found && !seen; q++) seen = found[q] == leader[s];
            if (!seen) found[n_found++] = leader[s];
        }
        if (n_found == 0) continue;
        /* the largest groups first, each taken if the union stays convex: no group's outside
         * reads (ext) hold a member of the others, and j reads none of them through a path
         * that leaves the union. A group that reads another one directly but could not join it
         * is not merged with it here either: a missed fusion, never a wrong one. */
        for (int q = 1; q < n_found; q++)
            for (int r = q; r > 0 && count[found[r]] > count[found[r - 1]]; r--) {
                int t = found[r];
                found[r] = found[r - 1];
                found[r - 1] = t;
            }
        memset(cur, 0, words * sizeof(Bits));
        memset(cur_ext, 0, words * sizeof(Bits));
        set_bit(cur, j);
        int to = -1;
        for (int q = 0; q < n_found; q++) {
            const Bits *sq = set + (size_t)found[q] * words, *eq = ext + (size_t)found[q] * words;
            for (size_t w = 0; w < words; w++) trial[w] = cur[w] | sq[w];
            if (!disjoint(eq, trial, words) || !disjoint(cur_ext, sq, words) ||
                !may_join(p, anc, trial, words, j))
                continue;
            memcpy(cur, trial, words * sizeof(Bits));
            for (size_t w = 0; w < words; w++) cur_ext[w] |= eq[w];
            if (to < 0) to = found[q];
            if (found[q] != to) {
                memset(set + (size_t)found[q] * words, 0, words * sizeof(Bits));
                count[to] += count[found[q]];
                count[found[q]] = 0;
            }
        }
        if (to < 0) continue;
        /* j's own outside reads join the group's */
        for (int k = 0; k < in->n_in; k++) {
            int x = in->in[k].inst;
            if (x < 0 || has_bit(cur, x)) continue;
            set_bit(cur_ext, x);
            for (size_t w = 0; w < words; w++) cur_ext[w] |= anc[(size_t)x * words + w];
        }
        memcpy(set + (size_t)to * words, cur, words * sizeof(Bits));
        memcpy(ext + (size_t)to * words, cur_ext, words * sizeof(Bits));
        memset(set + (size_t)j * words, 0, words * sizeof(Bits));
        count[to]++;
        count[j] = 0;
        for (size_t w = 0; w < words; w++)
            for (Bits b = cur[w]; b; b &= b - 1) leader[(int)(w * 64) + __builtin_ctzll(b)] = to;
    }
    /* A group runs as one job at its sink's place (its last member in plan order), and the
     * scheduler's memory estimate walks the plan in that order: a node outside a group that reads
     * a member must come after the group's sink. Where one comes before, the group is cut
     * there and the members after it form a group of their own; both parts stay convex, since
     * a path between two members of one part only passes through nodes between them in plan
     * order, none of them in the other part. */
    int *last = found; /* each group's last member in plan order */
    for (bool cut = true; cut;) {
        cut = false;
        for (int i = 0; i < n; i++) last[i] = -1;
        for (int i = 0; i < n; i++)
            if (leader[i] >= 0) last[leader[i]] = i;
        for (int c = 0; c < n && !cut; c++) {
            const WgInst *in = &p->insts[c];
            for (int k = 0; run[c] && k < in->n_in && !cut; k++) {
                int x = in->in[k].inst, l = x < 0 ? -1 : leader[x];
                if (l < 0 || l == leader[c] || last[l] < c) continue;
                int head = -1, tail = -1;
                for (int i = 0; i < n; i++)
                    if (leader[i] == l) {
                        if (i < c && head < 0) head = i;
                        if (i > c && tail < 0) tail = i;
                    }
                for (int i = 0; i < n; i++)
                    if (leader[i] == l) leader[i] = i < c ? head : tail;
                cut = true;
            }
        }
    }
    /* A group holds its inputs from outside and all its materialised results from its start to
     * its end, where running its members one by one would release some inputs and allocate some
     * results in between: fusing can raise the render's peak memory. While the sequential peak
     * (as the scheduler estimates it) is higher fused than unfused, the group whose cut into two
     * runs in plan order lowers it most is cut (both parts stay convex, as above). At most
     * about 128 cuts are weighed per round and 32 rounds made; past them nothing is fused. */
    for (int i = 0; i < n; i++)
        if (run[i]) {
            need_of[i] = wg__inst_need(p, &p->insts[i]);
            bytes[i] = out_bytes(&p->insts[i]);
        }
    size_t unfused = seq_peak(p, run, requested, NULL, NULL, need_of, bytes, found, count);
    groups = settle(p, run, requested, leader, sink, whole, found, count);
    for (int round = 0; groups > 0; round++) {
        if (seq_peak(p, run, requested, sink, whole, need_of, bytes, found, count) <= unfused)
            break;
        if (round == 32) {
            for (int i = 0; i < n; i++) leader[i] = -1;
            groups = settle(p, run, requested, leader, sink, whole, found, count);
            break;
        }
        int fused_nodes = 0;
        for (int i = 0; i < n; i++) fused_nodes += sink[i] >= 0;
        int step = fused_nodes > 128 ? (fused_nodes + 127) / 128 : 1, seen = 0;
        int best_sink = -1, best_at = -1;
        size_t best = (size_t)-1;
        for (int g = 0; g < n; g++) {
            if (sink[g] != g) continue;
            int first_member = -1;
            for (int at = 0; at <= g; at++) { /* members before `at` form the first part */
                if (sink[at] != g) continue;
                if (first_member < 0) {
                    first_member = at;
                    continue;
                }
                if (seen++ % step) continue;
                memcpy(trial_leader, leader, sizeof(int) * (size_t)n);
                for (int i = first_member; i <= g; i++)
                    if (sink[i] == g) trial_leader[i] = i < at ? first_member : at;
                settle(p, run, requested, trial_leader, trial_sink, trial_whole, found, count);
                size_t peak = seq_peak(p, run, requested, trial_sink, trial_whole, need_of, bytes,
                                       found, count);
                if (peak < best) {
                    best = peak;
                    best_sink = g;
                    best_at = at;
                }
            }
        }
        if (best_sink < 0) break;
        int first_member = -1;
        for (int i = 0; i <= best_sink; i++)
            if (sink[i] == best_sink) {
                if (first_member < 0) first_member = i;
                leader[i] = i < best_at ? first_member : best_at;
            }
        groups = settle(p, run, requested, leader, sink, whole, found, count);
    }
    if (groups > 0) rc = limit_scratch(p, sink, whole, &groups);
    for (int i = 0; i < n; i++)
        if (sink[i] < 0) whole[i] = false;
out:
    wg_free(anc);
    wg_free(set);
    wg_free(ext);
    wg_free(cur);
    wg_free(cur_ext);
    wg_free(trial);
    wg_free(leader);
    wg_free(found);
    wg_free(count);
    wg_free(trial_leader);
    wg_free(trial_sink);
    wg_free(trial_whole);
    wg_free(need_of);
    wg_free(bytes);
    return rc ? rc : groups;
}

/* ---- band buffers ------------------------------------------------------------------------ */

static size_t stride_for(int width, int channels)
{
    return ((size_t)width * (size_t)channels + 15) & ~(size_t)15; /* as wg_image_new */
}

/* Channels of the widest result a band buffer holds. */
static int slot_channels(const WgPlan *p, const int *members, int n)
{
    for (int m = 0; m < n; m++) {
        const WgInst *in = &p->insts[members[m]];
        for (int o = 0; o < in->n_out; o++)
            if (in->out_channels[o] == 4) return 4;
    }
    return 1;
}

/* The position of plan index `inst` among the members (sorted), or -1. */
static int member_of(const int *members, int n, int inst)
{
    int lo = 0, hi = n - 1;
    while (lo <= hi) {
        int mid = (lo + hi) / 2;
        if (members[mid] == inst) return mid;
        if (members[mid] < inst)
            lo = mid + 1;
        else
            hi = mid - 1;
    }
    return -1;
}

/* Rows per band: the rows of every image the band touches (inputs from outside, counted once
 * each; whole results; band buffers) within FUSE_BAND_BYTES, but a gray row of the band at
 * least FUSE_MIN_BAND_BYTES, and eight bands or more to share between threads unless that
 * makes them smaller than that. */
static int band_rows_for(const WgPlan *p, const int *members, int n, const bool *whole, int n_slots)
{
    const WgInst *sink = &p->insts[members[n - 1]];
    size_t w = (size_t)sink->width, row = 0;
    for (int m = 0; m < n; m++) {
        const WgInst *in = &p->insts[members[m]];
        for (int o = 0; o < in->n_out && whole[m]; o++)
            row += stride_for(sink->width, in->out_channels[o]) * sizeof(float);
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst;
            if (s < 0 || member_of(members, n, s) >= 0) continue;
            if (p->insts[s].type->flags & WG_NODE_UNIFORM) continue; /* one row for all */
            bool seen = false;
            for (int q = 0; q <= m && !seen; q++) {
                const WgInst *iq = &p->insts[members[q]];
                for (int r = 0; r < (q == m ? k : iq->n_in) && !seen; r++)
                    seen = iq->in[r].inst == s && iq->in[r].port == in->in[k].port;
            }
            if (!seen)
                row += stride_for(sink->width,
                                  input_want(in, k, p->insts[s].out_channels[in->in[k].port])) *
                       sizeof(float);
        }
    }
    row += (size_t)n_slots * stride_for(sink->width, slot_channels(p, members, n)) * sizeof(float);
    size_t rows = row ? FUSE_BAND_BYTES / row : (size_t)sink->height;
    size_t fewest = (FUSE_MIN_BAND_BYTES + w * sizeof(float) - 1) / (w * sizeof(float));
    size_t eighth = ((size_t)sink->height + 7) / 8;
    if (rows > eighth) rows = eighth > fewest ? eighth : fewest;
    if (rows < fewest) rows = fewest;
    if (rows > (size_t)sink->height) rows = (size_t)sink->height;
    return rows < 1 ? 1 : (int)rows;
}

/* The band buffer of each output port of a member that is not materialised, reused once its
 * last reader in the group has run. slot[first_out[m] + o] (-1 for whole results); returns the
 * number of buffers, or -1. */
static int assign_slots(const WgPlan *p, const int *members, int n, const bool *whole,
                        int *first_out, int *slot)
{
    int n_ports = 0;
    for (int m = 0; m < n; m++) {
        first_out[m] = n_ports;
        n_ports += p->insts[members[m]].n_out;
    }
    first_out[n] = n_ports;
    int *free_slots = wg_calloc((size_t)n_ports + 1, sizeof(int));
    int *last = wg_calloc((size_t)n + 1, sizeof(int)); /* each member's last reader */
    if (!free_slots || !last) {
        wg_free(free_slots);
        wg_free(last);
        return -1;
    }
    for (int m = 0; m < n; m++) {
        const WgInst *in = &p->insts[members[m]];
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst < 0 ? -1 : member_of(members, n, in->in[k].inst);
            if (s >= 0) last[s] = m;
        }
    }
    int n_free = 0, n_slots = 0;
    for (int m = 0; m < n; m++) {
        const WgInst *in = &p->insts[members[m]];
        for (int o = 0; o < in->n_out; o++)
            slot[first_out[m] + o] = whole[m] ? -1 : n_free ? free_slots[--n_free] : n_slots++;
        /* free the buffers of inputs read here for the last time, after this member's outputs
         * took theirs, so no member writes what it reads */
        for (int k = 0; k < in->n_in; k++) {
            int s = in->in[k].inst < 0 ? -1 : member_of(members, n, in->in[k].inst);
            if (s < 0 || whole[s] || last[s] != m) continue;
            bool seen = false;
            for (int q = 0; q < k && !seen; q++) seen = in->in[q].inst == in->in[k].inst;
            if (seen) continue;
            for (int o = 0; o < p->insts[members[s]].n_out; o++)
                free_slots[n_free++] = slot[first_out[s] + o];
        }
    }
    wg_free(free_slots);
    wg_free(last);
    return n_slots;
}

/* Ungroups the groups whose band buffers would exceed FUSE_MAX_SCRATCH. */
static int limit_scratch(const WgPlan *p, int *sink, const bool *whole, int *groups)
{
    int n = p->n_insts, rc = WG_OK;
    int *start = wg_calloc((size_t)n + 2, sizeof(int)), *members = NULL, *first_out = NULL,
        *slot = NULL;
    bool *mwhole = NULL;
    size_t ports = 0;
    for (int i = 0; i < n; i++) ports += (size_t)p->insts[i].n_out;
    if (!start || !(members = wg_calloc((size_t)n + 1, sizeof(int))) ||
        !(first_out = wg_calloc((size_t)n + 1, sizeof(int))) ||
        !(slot = wg_calloc(ports + 1, sizeof(int))) ||
        !(mwhole = wg_calloc((size_t)n + 1, sizeof(bool)))) {
        rc = WG_ERR_NOMEM;
        goto out;
    }
    /* members of each sink, in plan order: a counting sort */
    for (int i = 0; i < n; i++)
        if (sink[i] >= 0) start[sink[i] + 1]++;
    for (int i = 0; i < n; i++) start[i + 1] += start[i];
    for (int i = 0; i < n; i++)
        if (sink[i] >= 0) members[start[sink[i]]++] = i;
    for (int s = 0, at = 0; s < n; s++) { /* start[s] is now the end of group s */
        int count = start[s] - at, *m = members + at;
        at = start[s];
        if (count == 0 || sink[s] != s) continue;
        for (int k = 0; k < count; k++) mwhole[k] = whole[m[k]];
        int slots = assign_slots(p, m, count, mwhole, first_out, slot);
        if (slots < 0) {
            rc = WG_ERR_NOMEM;
            goto out;
        }
        size_t band = (size_t)band_rows_for(p, m, count, mwhole, slots) *
                      stride_for(p->insts[s].width, slot_channels(p, m, count)) * sizeof(float);
        if ((size_t)slots * band <= FUSE_MAX_SCRATCH) continue;
        for (int k = 0; k < count; k++) sink[m[k]] = -1;
        --*groups;
    }
out:
    wg_free(start);
    wg_free(members);
    wg_free(first_out);
    wg_free(slot);
    wg_free(mwhole);
    return rc;
}

/* ---- evaluation -------------------------------------------------------------------------- */

/* What one thread holds while it runs bands: the band buffers, views and time sums. */
typedef struct Scratch {
    float *buffers;
    WgImage *views; /* max_in + max_out */
    const WgImage **in_ptrs;
    WgImage **out_ptrs;
    double *ms; /* per member */
    struct Scratch *next;
} Scratch;

typedef struct Group {
    const WgPlan *p;
    const int *members;
    int n;
    const WgImage **ext; /* per input of each member (first_in): a whole image, or NULL */
    int *from;           /* per input: the member making it, or -1 */
    int *first_in, *first_out, *slot;
    int n_slots, max_in, max_out;
    size_t slot_floats;
    int band_rows, n_bands, width, height;
    WgImage ***out;  /* per member: its whole outputs, or NULL */
    void **prepared; /* per member: its type's prepare state, or NULL */
    volatile int *cancel;
    volatile int stop;
    pthread_mutex_t mu;
    Scratch *spare;
    double *ms;
    int rc, failed;
    WgError err;
} Group;

static void scratch_free(Scratch *s)
{
    if (!s) return;
    wg_free(s->buffers);
    wg_free(s->views);
    wg_free(s->in_ptrs);
    wg_free(s->out_ptrs);
    wg_free(s->ms);
    wg_free(s);
}

static Scratch *scratch_new(const Group *g)
{
    Scratch *s = wg_calloc(1, sizeof *s);
    if (!s) return NULL;
    s->buffers = wg_malloc(((size_t)g->n_slots * g->slot_floats + 1) * sizeof(float));
    s->views = wg_calloc((size_t)(g->max_in + g->max_out) + 1, sizeof(WgImage));
    s->in_ptrs = wg_calloc((size_t)g->max_in + 1, sizeof(WgImage *));
    s->out_ptrs = wg_calloc((size_t)g->max_out + 1, sizeof(WgImage *));
    s->ms = wg_calloc((size_t)g->n + 1, sizeof(double));
    if (!s->buffers || !s->views || !s->in_ptrs || !s->out_ptrs || !s->ms) {
        scratch_free(s);
        return NULL;
    }
    return s;
}

static void fail(Group *g, int rc, int member, const WgError *err)
{
    pthread_mutex_lock(&g->mu);
    if (g->rc == WG_OK || (g->rc == WG_ERR_CANCELLED && rc != WG_ERR_CANCELLED)) {
        g->rc = rc;
        g->failed = member;
        if (err) g->err = *err;
    }
    g->stop = 1;
    pthread_mutex_unlock(&g->mu);
}

static WgImage band_view(const WgImage *whole, int y0, int rows)
{
    WgImage v = {0}; /* field by field: other threads may change whole's reference count */
    v.width = whole->width;
    v.height = rows;
    v.channels = whole->channels;
    v.stride = whole->stride;
    v.data = whole->data + (size_t)y0 * whole->stride;
    v.refcount_ = 1;
    return v;
}

static WgImage slot_view(const Group *g, const Scratch *s, int slot, int channels, int rows)
{
    WgImage v = {0};
    v.width = g->width;
    v.height = rows;
    v.channels = channels;
    v.stride = stride_for(g->width, channels);
    v.data = s->buffers + (size_t)slot * g->slot_floats;
    v.refcount_ = 1;
    return v;
}

static int run_band(Group *g, Scratch *s, int y0, int rows)
{
    for (int m = 0; m < g->n; m++) {
        if (*g->cancel || g->stop) return WG_ERR_CANCELLED;
        const WgInst *in = &g->p->insts[g->members[m]];
        int nv = 0;
        for (int k = 0; k < in->n_in; k++) {
            int at = g->first_in[m] + k, f = g->from[at];
            s->in_ptrs[k] = NULL;
            if (f >= 0) {
                int port = in->in[k].port;
                int c = g->p->insts[g->members[f]].out_channels[port];
                s->views[nv] = g->out[f]
                                   ? band_view(g->out[f][port], y0, rows)
                                   : slot_view(g, s, g->slot[g->first_out[f] + port], c, rows);
                s->in_ptrs[k] = &s->views[nv++];
            } else if (g->ext[at]) {
                s->views[nv] = band_view(g->ext[at], y0, rows);
                s->in_ptrs[k] = &s->views[nv++];
            }
        }
        for (int o = 0; o < in->n_out; o++) {
            if (g->out[m])
                s->views[nv] = band_view(g->out[m][o], y0, rows);
            else
                s->views[nv] =
                    slot_view(g, s, g->slot[g->first_out[m] + o], in->out_channels[o], rows);
            s->out_ptrs[o] = &s->views[nv++];
        }
        WgNodeContext ctx = wg__inst_context(in);
        ctx.height = rows;
        ctx.inputs = s->in_ptrs;
        ctx.outputs = s->out_ptrs;
        ctx.prepared = g->prepared[m];
        ctx.pool_ = NULL; /* the bands are what runs in parallel */
        ctx.cancel_ = g->cancel;
        WgError err = {0};
        double t0 = wg__now_ms();
        int rc = in->type->eval(&ctx, &err);
        s->ms[m] += wg__now_ms() - t0;
        if (!rc && *g->cancel) rc = WG_ERR_CANCELLED;
        if (rc) {
            fail(g, rc, m, &err);
            return rc;
        }
    }
    return WG_OK;
}

/* Bands [b0, b1): one chunk of the pool's row batch, run by one thread. */
static void run_bands(void *user, int b0, int b1)
{
    Group *g = user;
    pthread_mutex_lock(&g->mu);
    Scratch *s = g->spare;
    if (s) g->spare = s->next;
    pthread_mutex_unlock(&g->mu);
    if (!s && !(s = scratch_new(g))) {
        WgError err = {0};
        wg_error_set(&err, WG_ERR_NOMEM, NULL, "out of memory for the band buffers");
        fail(g, WG_ERR_NOMEM, g->n - 1, &err);
        return;
    }
    for (int b = b0; b < b1; b++) {
        int y0 = b * g->band_rows;
        int rows = g->height - y0 < g->band_rows ? g->height - y0 : g->band_rows;
        if (run_band(g, s, y0, rows)) break;
    }
    pthread_mutex_lock(&g->mu);
    s->next = g->spare;
    g->spare = s;
    pthread_mutex_unlock(&g->mu);
}

int wg__fuse_eval(const WgPlan *p, const int *members, int n, WgImage ***out, WgMemPool *mem,
                  WgFuseSourceFn source, void *user, WgPool *pool, volatile int *cancel,
                  int band_rows, double *ms, int *failed, WgError *err)
{
    const WgInst *sink = &p->insts[members[n - 1]];
    Group g = {.p = p, .members = members, .n = n, .cancel = cancel, .ms = ms, .out = out};
    g.width = sink->width;
    g.height = sink->height;
    *failed = n - 1;
    int n_in = 0, n_out = 0, rc = WG_OK;
    for (int m = 0; m < n; m++) {
        const WgInst *in = &p->insts[members[m]];
        n_in += in->n_in;
        n_out += in->n_out;
        if (in->n_in > g.max_in) g.max_in = in->n_in;
        if (in->n_out > g.max_out) g.max_out = in->n_out;
        ms[m] = 0;
    }
    g.ext = wg_calloc((size_t)n_in + 1, sizeof *g.ext);
    const WgImage **owned = wg_calloc((size_t)n_in + 1, sizeof *owned);
    bool *whole = wg_calloc((size_t)n + 1, sizeof(bool));
    g.prepared = wg_calloc((size_t)n + 1, sizeof(void *));
    g.from = wg_calloc((size_t)n_in + 1, sizeof(int));
    g.first_in = wg_calloc((size_t)n + 1, sizeof(int));
    g.first_out = wg_calloc((size_t)n + 1, sizeof(int));
    g.slot = wg_calloc((size_t)n_out + 1, sizeof(int));
    if (whole)
        for (int m = 0; m < n; m++) whole[m] = out[m] != NULL;
    if (!g.ext || !owned || !whole || !g.prepared || !g.from || !g.first_in || !g.first_out ||
        !g.slot || (g.n_slots = assign_slots(p, members, n, whole, g.first_out, g.slot)) < 0) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    g.band_rows = band_rows > 0 ? (band_rows < g.height ? band_rows : g.height)
                                : band_rows_for(p, members, n, whole, g.n_slots);
    g.n_bands = (g.height + g.band_rows - 1) / g.band_rows;
    g.slot_floats = (size_t)g.band_rows * stride_for(g.width, slot_channels(p, members, n));
    /* inputs from outside the group: whole images, converted here when the node needs it */
    for (int m = 0, at = 0; m < n; m++) {
        WgInst *in = &p->insts[members[m]];
        g.first_in[m] = at;
        for (int k = 0; k < in->n_in; k++, at++) {
            g.from[at] = in->in[k].inst < 0 ? -1 : member_of(members, n, in->in[k].inst);
            if (in->in[k].inst < 0 || g.from[at] >= 0) continue;
            const WgImage *src = source(user, in->in[k].inst, in->in[k].port);
            int want = input_want(in, k, src->channels);
            if (src->width != in->width || src->height != in->height || src->channels != want) {
                owned[at] = wg__image_convert_in(mem, src, in->width, in->height, want);
                if (!owned[at]) {
                    *failed = m;
                    rc = wg_error_set(err, WG_ERR_NOMEM, NULL,
                                      "out of memory converting input '%s'", in->in_names[k]);
                    goto out;
                }
                in->in_channels[k] = want;
                src = owned[at];
            }
            g.ext[at] = src;
        }
    }
    /* the work every band shares, once for the group, with the whole image's context */
    for (int m = 0; m < n; m++) {
        const WgInst *in = &p->insts[members[m]];
        if (!in->type->prepare) continue;
        WgNodeContext ctx = wg__inst_context(in);
        if ((rc = in->type->prepare(&ctx, &g.prepared[m], err))) {
            *failed = m;
            goto out;
        }
    }
    for (int m = 0; m < n; m++) {
        const WgInst *in = &p->insts[members[m]];
        for (int o = 0; o < in->n_out && out[m]; o++) {
            out[m][o] =
                in->type->flags & WG_NODE_UNIFORM /* as eval gives it */
                    ? wg__image_new_uniform_in(mem, in->width, in->height, in->out_channels[o])
                    : wg__image_new_in(mem, in->width, in->height, in->out_channels[o]);
            if (!out[m][o]) {
                *failed = m;
                rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory for a %dx%d image",
                                  in->width, in->height);
                goto out;
            }
        }
    }
    pthread_mutex_init(&g.mu, NULL);
    int prc = wg__pool_rows(pool, &g.stop, g.n_bands, run_bands, &g);
    pthread_mutex_destroy(&g.mu);
    while (g.spare) {
        Scratch *s = g.spare;
        g.spare = s->next;
        for (int m = 0; m < n; m++) ms[m] += s->ms[m];
        scratch_free(s);
    }
    if (g.rc) {
        rc = g.rc;
        *failed = g.failed;
        if (err) *err = g.err;
    } else if (prc || *cancel) {
        rc = WG_ERR_CANCELLED;
    }
out:
    for (int m = 0; m < n; m++) {
        const WgInst *in = &p->insts[members[m]];
        if (g.prepared && g.prepared[m] && in->type->finish) in->type->finish(g.prepared[m]);
        for (int o = 0; rc && out[m] && o < in->n_out; o++) {
            wg_image_unref(out[m][o]);
            out[m][o] = NULL;
        }
    }
    if (owned)
        for (int i = 0; i < n_in; i++) wg_image_unref(owned[i]);
    wg_free(owned);
    wg_free(whole);
    wg_free(g.prepared);
    wg_free(g.ext);
    wg_free(g.from);
    wg_free(g.first_in);
    wg_free(g.first_out);
    wg_free(g.slot);
    return rc;
}

/* ---- drawing the groups ------------------------------------------------------------------ */

int wg_request_write_dot(const WgRequest *r, FILE *f, WgError *err)
{
    const WgGraph *g = r->graph;
    WgPlan plan = {0};
    int rc = wg__plan_build(r, &plan, err);
    if (rc) return rc;
    int n = plan.n_insts;
    bool *flags = wg_calloc(2 * (size_t)n + 1, sizeof(bool));
    int *sink = wg_calloc((size_t)n + 1, sizeof(int));
    bool *whole = wg_calloc((size_t)n + 1, sizeof(bool));
    int *number = wg_calloc((size_t)n + 1, sizeof(int));
    int *size = wg_calloc((size_t)n + 1, sizeof(int));
    int *cluster = wg_calloc((size_t)g->n_nodes + 1, sizeof(int));
    if (!flags || !sink || !whole || !number || !size || !cluster) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    /* a render with nothing cached computes what the outputs reach */
    for (int k = 0; k < plan.n_outputs; k++)
        flags[plan.outputs[k].ref.inst] = flags[n + plan.outputs[k].ref.inst] = true;
    for (int i = n - 1; i >= 0; i--)
        for (int k = 0; k < plan.insts[i].n_in && flags[i]; k++)
            if (plan.insts[i].in[k].inst >= 0) flags[plan.insts[i].in[k].inst] = true;
    if (wg__fuse_find(&plan, flags, flags + n, sink, whole) < 0) {
        rc = wg_error_set(err, WG_ERR_NOMEM, NULL, "out of memory");
        goto out;
    }
    /* numbered as the render's --stats numbers them; only the graph's own nodes are drawn (a
     * subgraph is one box), and a group is drawn when two or more of them belong to it */
    for (int i = 0, groups = 0; i < n; i++)
        if (sink[i] == i) number[i] = ++groups;
    for (int i = 0; i < n; i++) {
        int node = sink[i] < 0 ? -1 : wg__graph_find_node(g, plan.insts[i].id);
        if (node < 0) continue;
        cluster[node] = number[sink[i]];
        size[cluster[node]]++;
    }
    for (int i = 0; i < g->n_nodes; i++)
        if (size[cluster[i]] < 2) cluster[i] = 0;
    wg__graph_write_dot(g, cluster, f);
    if (ferror(f)) rc = wg_error_set(err, WG_ERR_IO, NULL, "cannot write the dot output");
out:
    wg_free(flags);
    wg_free(sink);
    wg_free(whole);
    wg_free(number);
    wg_free(size);
    wg_free(cluster);
    wg__plan_free(&plan);
    return rc;
}
