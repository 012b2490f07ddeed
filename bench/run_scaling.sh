#!/usr/bin/env bash
# How loading, checking, planning and rendering grow with the number of nodes. For each shape
# (a chain where every node reads the previous one; a balanced tree of blends over distinct
# uniforms) at 1,000, 10,000 and 100,000 nodes, times `check`, `dot`, `info --json` and
# `render` (8x8 pixels, so image work is nil and the engine's own costs show), and reports the
# growth factor per 10x more nodes: about 10 is linear, 100 would be quadratic. The peer is
# `xmllint --noout` on the same file, the cost of merely parsing the XML, and the fixed cost of
# starting the process (`wetgraph nodes`) is shown on its own line.
#   bench/run_scaling.sh [BUILD_DIR] [RUNS]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
runs=${2:-3}
bin=$build/cli/wetgraph
[[ -x $bin ]] || { echo "no $bin: build first (bench/run.sh builds)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

chain() { # n
    awk -v n="$1" 'BEGIN {
        print "<wetgraph version=\"1\" size=\"8\">"
        print "<node id=\"n0\" type=\"uniform\" value=\"0.25\"/>"
        for (i = 1; i < n; i++)
            printf "<node id=\"n%d\" type=\"invert\"><in name=\"source\" from=\"n%d\"/></node>\n", i, i - 1
        printf "<output name=\"out\" from=\"n%d\" format=\"exr\"/>\n</wetgraph>\n", n - 1 }'
}

tree() { # n: about n nodes, n/2 distinct uniform leaves
    awk -v n="$1" 'BEGIN {
        print "<wetgraph version=\"1\" size=\"8\">"
        leaves = int(n / 2)
        for (i = 0; i < leaves; i++) {
            printf "<node id=\"a%d\" type=\"uniform\" value=\"%.9f\"/>\n", i, i / leaves
            name[i] = "a" i
        }
        count = leaves; k = 0
        while (count > 1) {
            m = 0
            for (j = 0; j + 1 < count; j += 2) {
                printf "<node id=\"b%d\" type=\"blend\" mode=\"add\"><in name=\"foreground\" from=\"%s\"/><in name=\"background\" from=\"%s\"/></node>\n", k, name[j], name[j + 1]
                next_name[m++] = "b" k; k++
            }
            if (count % 2) next_name[m++] = name[count - 1]
            for (j = 0; j < m; j++) name[j] = next_name[j]
            count = m
        }
        printf "<output name=\"out\" from=\"%s\" format=\"exr\"/>\n</wetgraph>\n", name[0] }'
}

# best of $runs wall-clock seconds of a command
best() {
    local best_t=""
    for ((r = 0; r < runs; r++)); do
        local t0 t1
        t0=$(date +%s.%N)
        "$@" >/dev/null 2>&1 || { echo "failed: $*" >&2; exit 1; }
        t1=$(date +%s.%N)
        best_t=$(awk -v a="$t0" -v b="$t1" -v m="$best_t" 'BEGIN { d = b - a; if (m == "" || d < m) m = d; printf "%.3f", m }')
    done
    echo "$best_t"
}

have_xmllint=0
command -v xmllint >/dev/null && have_xmllint=1
echo "start-up (wetgraph nodes): $(best "$bin" nodes) s"
echo
printf '| shape | nodes | xmllint | check | dot | info --json | render 8² | check / xmllint | growth of check per 10x | growth of render per 10x |\n'
printf '|---|---|---|---|---|---|---|---|---|---|\n'
for shape in chain tree; do
    prev_check="" prev_render=""
    for n in 1000 10000 100000; do
        f=$work/$shape$n.wetgraph
        "$shape" "$n" >"$f"
        x="–"
        [[ $have_xmllint == 1 ]] && x=$(best xmllint --noout --huge "$f")
        c=$(best "$bin" check "$f")
        d=$(best "$bin" dot "$f")
        i=$(best "$bin" info --json "$f")
        rdr=$(best "$bin" render "$f" -o "$work/out" --threads 2)
        ratio=$(awk -v c="$c" -v x="$x" 'BEGIN { if (x == "–" || x == 0) print "–"; else printf "%.0f", c / x }')
        gc=$(awk -v a="$prev_check" -v b="$c" 'BEGIN { if (a == "") print "–"; else printf "%.1f", b / a }')
        gr=$(awk -v a="$prev_render" -v b="$rdr" 'BEGIN { if (a == "") print "–"; else printf "%.1f", b / a }')
        printf '| %s | %d | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$shape" "$n" "$x" "$c" "$d" "$i" "$rdr" "$ratio" "$gc" "$gr"
        prev_check=$c
        prev_render=$rdr
    done
done
echo
echo "Seconds, best of $runs, whole process (start-up included: see its line above)."
