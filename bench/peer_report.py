# SPDX-License-Identifier: MIT
# Writes the blur and distance peer report from the raw results of bench/run_peers.sh, one file
# per host (bench/peers/<host>.tsv, that host's latest run: "size op case sigma_px method runs
# median_ms min_ms max_abs_error" lines and "# key: value" notes): a markdown page with the
# targets at 2048² as one row per host, then per host its tables (time, ratios to OpenCV and
# scipy, error against the float64 reference) and an SVG plot of time against error (one panel
# per operation and size, drawn here with no packages beyond the standard library), written
# beside the page as report-<host>.svg. Ratios are given per host and never carried from one
# host to another: the same code gave different ratios on AMD and Intel VMs.
#   python3 bench/peer_report.py PEERS_DIR REPORT.md
import math
import os
import sys
from collections import defaultdict

FAST, EXACT, WG = "wetgraph fast", "wetgraph exact", "wetgraph"
CV_BLUR, SP_BLUR = "OpenCV GaussianBlur", "scipy gaussian_filter"
CV_DIST, SP_DIST = "OpenCV distanceTransform precise", "scipy distance_transform_edt"
COLOURS = {FAST: "#d62728", EXACT: "#ff9896", WG: "#d62728", CV_BLUR: "#1f77b4",
           CV_DIST: "#1f77b4", SP_BLUR: "#2ca02c", SP_DIST: "#2ca02c"}


def load(path):
    notes, rows = [], {}
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if not line:
                continue
            if line.startswith("#"):
                notes.append(line[1:].strip())
                continue
            p = line.split("\t")
            if len(p) != 9:
                sys.exit(f"peer_report.py: {path}: bad line: {line!r}")
            key = (int(p[0]), p[1], p[2], float(p[3]), p[4])
            rows[key] = (int(p[5]), float(p[6]), float(p[7]), float(p[8]))
    return notes, rows


def ms(r):
    if r is None:
        return "–"
    runs, med = r[0], r[1]
    s = f"{med:.1f}" if med < 100 else f"{med:.0f}"
    return s if runs >= 5 else f"{s} (n={runs})"


def ratio(a, b):
    if a is None or b is None:
        return "–"
    q = a[1] / b[1]
    return f"{q:.1f}" if q < 10 else f"{q:.0f}"


def err(r):
    return "–" if r is None else ("0" if r[3] == 0 else f"{r[3]:.1e}")


def tables(rows):
    sizes = sorted({k[0] for k in rows})
    out = []
    for n in sizes:
        out.append(f"### {n}²\n")
        out.append("Blur (wrap), ms and max |error| against the float64 reference:\n")
        out.append("| σ px | wetgraph fast | wetgraph exact | OpenCV | scipy | OpenCV / fast | "
                   "scipy / fast | OpenCV / exact | err fast | err exact | err OpenCV | err scipy |")
        out.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for s in sorted({k[3] for k in rows if k[0] == n and k[1] == "blur"}):
            g = lambda m: rows.get((n, "blur", "noise", s, m))
            f, e, c, p = g(FAST), g(EXACT), g(CV_BLUR), g(SP_BLUR)
            out.append(f"| {s:g} | {ms(f)} | {ms(e)} | {ms(c)} | {ms(p)} | {ratio(c, f)} | "
                       f"{ratio(p, f)} | {ratio(c, e)} | {err(f)} | {err(e)} | {err(c)} | {err(p)} |")
        out.append("")
        out.append("Distance transform (not periodic), ms and max |error| against the float64 EDT:\n")
        out.append("| mask | wetgraph | OpenCV precise | scipy | OpenCV / wetgraph | scipy / wetgraph | "
                   "err wetgraph | err OpenCV | err scipy |")
        out.append("|---|---|---|---|---|---|---|---|---|")
        for c in ("blobs", "seeds"):
            g = lambda m: rows.get((n, "distance", c, 0.0, m))
            w, o, p = g(WG), g(CV_DIST), g(SP_DIST)
            if w is None:
                continue
            out.append(f"| {c} | {ms(w)} | {ms(o)} | {ms(p)} | {ratio(o, w)} | {ratio(p, w)} | "
                       f"{err(w)} | {err(o)} | {err(p)} |")
        out.append("")
    return out


def target_row(host, notes, rows, n=2048):
    """One host's row of the targets table: its measures at n², each marked met or not met."""
    b = lambda s, m: rows.get((n, "blur", "noise", float(s), m))
    d = lambda c, m: rows.get((n, "distance", c, 0.0, m))
    when = next((x.split(":", 1)[1].strip() for x in notes if x.startswith("date:")), "?")
    load = next((x.split(":", 1)[1].strip() for x in notes if x.startswith("load average at start")), "?")
    head = f"| {host} ({when}, load {load}) "
    fast = [b(s, FAST) for s in (2, 16, 64, 256)]
    if any(r is None for r in fast) or b(16, CV_BLUR) is None:
        return head + f"| (no complete {n}² run) |" + " |" * 6
    yes = lambda ok: "" if ok else " (**not met**)"
    worst = max(r[1] for r in fast)
    r16 = b(16, CV_BLUR)[1] / b(16, FAST)[1]
    e = max(r[3] for r in fast)
    cells = [f"{worst:.1f} ms{yes(worst <= 15)}", f"{r16:.1f}×{yes(r16 >= 5)}",
             f"{e:.1e}{yes(e <= 1e-4)}"]
    for c in ("blobs", "seeds"):
        w, o = d(c, WG), d(c, CV_DIST)
        if w and o:
            cells.append(f"{w[1]:.1f} ms{yes(w[1] <= 30)}")
            cells.append(f"{o[1] / w[1]:.1f}×{yes(o[1] / w[1] >= 2.5)}")
        else:
            cells += ["–", "–"]
    return head + "| " + " | ".join(cells) + " |"


TARGET_HEAD = ["| host (run, load average at its start) | blur fast, slowest σ (≤ 15 ms) | "
               "blur fast vs OpenCV at σ = 16 px (≥ 5×) | blur fast error (≤ 1e-4) | "
               "distance blobs (≤ 30 ms) | blobs vs OpenCV precise (≥ 2.5×) | "
               "distance seeds (≤ 30 ms) | seeds vs OpenCV precise (≥ 2.5×) |",
               "|---|---|---|---|---|---|---|---|"]


def svg(rows, path):
    sizes = sorted({k[0] for k in rows})
    pw, ph, ml, mt, mb = 330, 260, 60, 40, 45
    W, H = ml + len(sizes) * (pw + 30), 2 * (ph + mt + mb) + 60
    lo_e, hi_e = -9, -3
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" '
             f'font-family="sans-serif" font-size="11">',
             f'<rect width="{W}" height="{H}" fill="white"/>',
             f'<text x="{ml}" y="18" font-size="14">Time (ms, log) against max |error| (log): '
             f'wetgraph (red), OpenCV (blue), scipy (green); 2 threads, scipy 1</text>']
    for row, op in enumerate(("blur", "distance")):
        for col, n in enumerate(sizes):
            x0, y0 = ml + col * (pw + 30), 40 + row * (ph + mt + mb) + mt
            pts = [(k, v) for k, v in rows.items() if k[0] == n and k[1] == op]
            if not pts:
                continue
            tl = math.floor(math.log10(min(v[1] for _, v in pts)))
            th = math.ceil(math.log10(2 * max(v[1] for _, v in pts)))  # no point on the edge
            th = max(th, tl + 1)
            X = lambda t: x0 + (math.log10(t) - tl) / (th - tl) * pw
            Y = lambda e: y0 + ph - (math.log10(max(e, 10 ** lo_e)) - lo_e) / (hi_e - lo_e) * ph
            title = f"{op} {n}²" + (" (σ px labelled)" if op == "blur" else " (0 error drawn at 1e-9)")
            parts.append(f'<text x="{x0}" y="{y0 - 8}" font-size="12">{title}</text>')
            parts.append(f'<rect x="{x0}" y="{y0}" width="{pw}" height="{ph}" fill="none" stroke="#888"/>')
            for t in range(tl, th + 1):
                parts.append(f'<line x1="{X(10 ** t):.1f}" y1="{y0}" x2="{X(10 ** t):.1f}" '
                             f'y2="{y0 + ph}" stroke="#eee"/>')
                parts.append(f'<text x="{X(10 ** t):.1f}" y="{y0 + ph + 14}" text-anchor="middle">'
                             f'{10 ** t:g}</text>')
            for e in range(lo_e, hi_e + 1):
                parts.append(f'<line x1="{x0}" y1="{Y(10 ** e):.1f}" x2="{x0 + pw}" '
                             f'y2="{Y(10 ** e):.1f}" stroke="#eee"/>')
                parts.append(f'<text x="{x0 - 4}" y="{Y(10 ** e) + 4:.1f}" text-anchor="end">'
                             f'1e{e}</text>')
            parts.append(f'<text x="{x0 + pw / 2}" y="{y0 + ph + 30}" text-anchor="middle">ms</text>')
            placed = []  # label boxes already drawn in this panel: a label that would overlap
            for (_, _, case, s, m), v in sorted(pts):  # one moves down (or up) until it does not
                cx, cy = X(v[1]), Y(v[3])
                c = COLOURS.get(m, "black")
                if m == EXACT:
                    parts.append(f'<rect x="{cx - 4:.1f}" y="{cy - 4:.1f}" width="8" height="8" fill="{c}"/>')
                else:
                    parts.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="4" fill="{c}"/>')
                label = f"{s:g}" if op == "blur" else case
                lw, lx, ly = 6.5 * len(label), cx + 5, cy - 5
                for dy in (0, 11, -11, 22, -22, 33, -33):
                    if not any(lx < px + pw_ and px < lx + lw and abs(ly + dy - py) < 11
                               for px, py, pw_ in placed):
                        ly += dy
                        break
                placed.append((lx, ly, lw))
                parts.append(f'<text x="{lx:.1f}" y="{ly:.1f}" fill="{c}">{label}</text>')
    parts.append(f'<text x="{ml}" y="{H - 10}">blur: circles wetgraph fast / OpenCV / scipy, '
                 f'squares wetgraph exact</text>')
    parts.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(parts) + "\n")


def host_name(notes, slug):
    cpu = next((x.split(":", 1)[1].strip() for x in notes if x.startswith("cpu:")), None)
    return cpu or slug


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: peer_report.py PEERS_DIR REPORT.md")
    folder, report = sys.argv[1], sys.argv[2]
    files = sorted(f for f in os.listdir(folder) if f.endswith(".tsv"))
    if not files:
        sys.exit(f"peer_report.py: {folder}: no results (bench/run_peers.sh writes them)")
    runs = []
    for f in files:
        notes, rows = load(os.path.join(folder, f))
        if not rows:
            sys.exit(f"peer_report.py: {os.path.join(folder, f)}: no results")
        runs.append((f[:-4], notes, rows))
    md = ["# Blur and distance against OpenCV and scipy", "",
          "Generated by `bench/run_peers.sh` from `bench/peers/` (do not edit by hand; the notes "
          "on method are in bench/README.md). Each host keeps its latest run; a ratio holds for "
          "the host it was measured on and is never the current figure for another (the same "
          "code gave different ratios on AMD and Intel VMs). The machines are 2-core VMs shared "
          "with other builds and tests, so the times carry their load (the load averages below); "
          "the ratios within one size are steadier than the absolute times.", "",
          "## Targets at 2048², 2 threads, a row per host", ""]
    md += TARGET_HEAD + [target_row(host_name(n, slug), n, r) for slug, n, r in runs]
    for slug, notes, rows in runs:
        md += ["", f"## {host_name(notes, slug)}", "", "Run notes:", ""]
        md += [f"- {n}" for n in notes]
        md += ["", "Times in ms, median of 5 runs (n=3 when a run took over 2 s, n=1 over 10 s); "
               "ratios are peer time / wetgraph time (above 1: wetgraph is faster), measured on "
               "this host. Errors are max |result − float64 reference| over the image.", ""]
        md += tables(rows)
        picture = f"report-{slug}.svg"
        svg(rows, os.path.join(os.path.dirname(os.path.abspath(report)), picture))
        md += [f"![time against error on {host_name(notes, slug)}]({picture})", ""]
    with open(report, "w") as f:
        f.write("\n".join(md))


main()
