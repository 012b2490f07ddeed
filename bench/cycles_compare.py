# SPDX-License-Identifier: MIT
# Holds the preview's picture against the Cycles render of the same scene, zone by zone
# (bench/run_cycles.sh drives it). Run with Blender's Python, which reads EXR:
#   blender -b --factory-startup -P bench/cycles_compare.py -- PREVIEW.exr ZONES.exr CYCLES.exr
#       elevation azimuth fov zoom height_scale [SIDE_BY_SIDE.png]
# ZONES.exr is the preview of the zone masks in a white environment (cycles_scene.wetgraph's
# `zones`: red moist, green wet, blue immersed, each lit to e + (1 − e)·mask with e the lobe's
# small albedo), which names each pixel's zone: immersed where blue > 0.5, else wet where green >
# 0.5, else moist where red > 0.5, dry where all three are below 0.15 (mixed pixels, between
# zones, count in none). Pixels whose 3 × 3 neighbourhood is not all of one zone are left out,
# and so are those whose camera ray (the preview's camera, from the arguments) does not cross
# the tile both at its top plane and at the depth height_scale below, i.e. the background and
# the tile's edges. Per zone: the pixel count and the mean luminance (Rec. 709 weights, linear)
# of both pictures, and their ratio preview / Cycles. SIDE_BY_SIDE.png, when given: the two
# pictures through the preview's filmic curve and sRGB, preview left, Cycles right.
import math
import sys

import bpy
import numpy as np

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(argv) < 8:
    sys.exit("usage: blender -b -P cycles_compare.py -- PREVIEW.exr ZONES.exr CYCLES.exr "
             "elevation azimuth fov zoom height_scale [SIDE_BY_SIDE.png]")
elevation, azimuth, fov, zoom, hs = (float(a) for a in argv[3:8])


def read(path):
    """RGB float array, row 0 at the top of the picture."""
    try:
        img = bpy.data.images.load(path)
    except RuntimeError as e:
        sys.exit("%s: cannot read (%s)" % (path, e))
    w, h = img.size
    a = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(a)
    return a.reshape(h, w, 4)[::-1, :, :3].astype(np.float64)


pv, zones, cy = read(argv[0]), read(argv[1]), read(argv[2])
if pv.shape != cy.shape or pv.shape != zones.shape:
    sys.exit("%s: %dx%d, but %s is %dx%d and %s %dx%d: render all three at one size" % (
        argv[2], cy.shape[1], cy.shape[0], argv[0], pv.shape[1], pv.shape[0], argv[1],
        zones.shape[1], zones.shape[0]))
h, w = pv.shape[:2]

# the preview's camera rays, crossed with the planes z = 0 and z = −hs
el, az = math.radians(elevation), math.radians(azimuth)
back = np.array([math.sin(az) * math.cos(el), -math.cos(az) * math.cos(el), math.sin(el)])
right = np.array([math.cos(az), math.sin(az), 0.0])
up = np.cross(back, right)
up /= np.linalg.norm(up)
tan_half = math.tan(math.radians(fov) / 2)
cam = np.array([0.5, 0.5, 0]) + back * (0.5 / zoom / tan_half)
ys, xs = np.mgrid[0:h, 0:w]
u = (2 * (xs + 0.5) / w - 1) * (w / h)
v = 1 - 2 * (ys + 0.5) / h
d = -back + (u[..., None] * right + v[..., None] * up) * tan_half
on_tile = np.ones((h, w), bool)
for z in (0.0, -hs):
    t = (z - cam[2]) / np.minimum(d[..., 2], -1e-9)
    p = cam + d * t[..., None]
    on_tile &= (t > 0) & (p[..., 0] > 0.01) & (p[..., 0] < 0.99) & (p[..., 1] > 0.01) & (
        p[..., 1] < 0.99)

r, g, b = zones[..., 0], zones[..., 1], zones[..., 2]
zone = np.full((h, w), -1)
zone[(r < 0.15) & (g < 0.15) & (b < 0.15)] = 0
zone[(r > 0.5) & (g < 0.5) & (b < 0.5)] = 1
zone[(g > 0.5) & (b < 0.5)] = 2
zone[b > 0.5] = 3
zone[~on_tile] = -1
same = np.ones((h, w), bool)
pad = np.pad(zone, 1, constant_values=-1)
for dy in range(3):
    for dx in range(3):
        same &= pad[dy:dy + h, dx:dx + w] == zone

lum_w = np.array([0.2126, 0.7152, 0.0722])
lp, lc = pv @ lum_w, cy @ lum_w
print("%-9s %7s %10s %10s %8s" % ("zone", "pixels", "preview", "cycles", "ratio"))
worst = 0.0
for k, name in enumerate(["dry", "moist", "wet", "immersed"]):
    sel = same & (zone == k)
    n = int(sel.sum())
    if n < 50:
        print("%-9s %7d %10s %10s %8s" % (name, n, "-", "-", "-"))
        continue
    a, c = lp[sel].mean(), lc[sel].mean()
    worst = max(worst, abs(a / c - 1))
    print("%-9s %7d %10.4f %10.4f %8.3f" % (name, n, a, c, a / c))
sel = on_tile
print("%-9s %7d %10.4f %10.4f %8.3f" % ("tile", int(sel.sum()), lp[sel].mean(), lc[sel].mean(),
                                       lp[sel].mean() / lc[sel].mean()))
print("largest zone difference: %.1f %%" % (100 * worst))

if len(argv) > 8:
    def display(x):
        x = np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0, 1)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)

    gap = np.ones((h, 8, 3))
    pic = np.concatenate([display(pv), gap, display(cy)], 1)
    ph, pw = pic.shape[:2]
    out = bpy.data.images.new("side_by_side", pw, ph, alpha=False)
    rgba = np.concatenate([pic[::-1], np.ones((ph, pw, 1))], 2).astype(np.float32)
    out.pixels.foreach_set(rgba.ravel())
    out.filepath_raw = argv[8]
    out.file_format = "PNG"
    out.save()
    print("side by side (preview left, Cycles right): %s" % argv[8])
