# SPDX-License-Identifier: MIT
# Peer benchmark of `blur` and `distance` against scipy.ndimage, on the inputs and float64
# references bench/peer_opencv writes with --dir (float32 / uint8 / float64 raw, row-major N×N):
# scipy.ndimage.gaussian_filter(mode='wrap', default truncate 4σ, float32 output) at σ = 2, 16,
# 64, 256 px, and scipy.ndimage.distance_transform_edt of the mask's complement (distance of each
# pixel to the nearest site, not periodic, float64 output). scipy runs on one thread. Times are
# the median of R runs (3 when one run takes over 2 s, 1 over 10 s), wall clock around the call alone.
#   python3 bench/peer_scipy.py DIR SIZE [REPS]
# Output: the same TSV as peer_opencv, "size op case sigma_px method runs median_ms min_ms err".
import os
import sys
import time

import numpy as np
import scipy
from scipy import ndimage


def timed(f, reps):
    t, keep = [], None
    for k in range(reps):
        t0 = time.perf_counter()
        r = f()
        t.append((time.perf_counter() - t0) * 1000)
        if k == 0:
            keep = r
            if t[0] > 10000:
                break
            if t[0] > 2000 and reps > 3:
                for _ in range(2):
                    t0 = time.perf_counter()
                    f()
                    t.append((time.perf_counter() - t0) * 1000)
                break
    t.sort()
    return len(t), t[len(t) // 2], t[0], keep


def load(d, name, dtype, n):
    path = os.path.join(d, name)
    a = np.fromfile(path, dtype=dtype)
    if a.size != n * n:
        sys.exit(f"peer_scipy.py: {path}: {a.size} values, expected {n * n}")
    return a.reshape(n, n)


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit("usage: peer_scipy.py DIR SIZE [REPS]")
    d, n = sys.argv[1], int(sys.argv[2])
    reps = int(sys.argv[3]) if len(sys.argv) == 4 else 5
    print(f"# {n}x{n} scipy {scipy.__version__} numpy {np.__version__}, one thread, median of {reps}")
    src = load(d, f"blur_src_{n}.f32", np.float32, n)
    for s in (2, 16, 64, 256):
        ref = load(d, f"blur_ref_{n}_{s}.f64", np.float64, n)
        runs, med, mn, out = timed(lambda: ndimage.gaussian_filter(src, s, mode="wrap"), reps)
        err = float(np.max(np.abs(out.astype(np.float64) - ref)))
        print(f"{n}\tblur\tnoise\t{s}\tscipy gaussian_filter\t{runs}\t{med:.2f}\t{mn:.2f}\t{err:.3g}",
              flush=True)
    for m in ("blobs", "seeds"):
        free = load(d, f"dist_{m}_{n}.u8", np.uint8, n) == 0
        ref = load(d, f"dist_{m}_ref_{n}.f64", np.float64, n)
        runs, med, mn, out = timed(lambda: ndimage.distance_transform_edt(free), reps)
        err = float(np.max(np.abs(out - ref)))
        print(f"{n}\tdistance\t{m}\t0\tscipy distance_transform_edt\t{runs}\t{med:.2f}\t{mn:.2f}\t{err:.3g}",
              flush=True)


main()
