# SPDX-License-Identifier: MIT
# The wetgraph module: what it lists of a graph against `wetgraph info --json`, renders against
# the command line's files (8-bit, 16-bit, float), numpy inputs of every accepted dtype and shape
# against the same pixels given as files, refused inputs and their messages, errors with the
# command line's text, the cache across renders (stats), progress, cancelling from another
# thread with the GIL released, and renders on two engines in two threads.
import gc
import json
import os
import sys
import threading
import time

import numpy as np
import pytest

import wetgraph
from conftest import read_image, write_image

SIZE = 128


@pytest.fixture
def wet(bricks):
    """wet_material over the Bricks102 maps at SIZE x SIZE."""
    g = wetgraph.Graph("wet_material")
    for name in ("basecolor", "height", "normal", "roughness", "ao"):
        g.set_input(name, bricks[name])
    g.size = (SIZE, SIZE)
    return g


# ---- what a graph declares ----------------------------------------------------------------

def test_lists_params_inputs_outputs_as_info_json(cli):
    g = wetgraph.Graph("wet_material")
    info = json.loads(cli("info", "wet_material", "--json").stdout)
    assert g.name == "wet_material" and g.size_text == info["size"]
    assert [p.name for p in g.params] == [p["name"] for p in info["params"]]
    for p, q in zip(g.params, info["params"]):
        assert p.type == q["type"] and p.default == q["default"], p.name
        assert p.min == q.get("min") and p.max == q.get("max"), p.name
        assert p.label == q.get("label"), p.name
        if p.type == "enum":
            assert list(p.values) == q["values"], p.name
        else:
            assert p.values is None
    level = next(p for p in g.params if p.name == "water_level")
    assert (level.type, level.default, level.min, level.max) == ("float", "0.6", 0.0, 1.0)
    liquid = next(p for p in g.params if p.name == "liquid")
    assert liquid.values == ("water", "muddy_water", "tea", "milk", "blood", "oil")
    assert [(i.name, i.kind, i.colorspace) for i in g.inputs] == \
        [(i["name"], i["type"], i["colorspace"]) for i in info["inputs"]]
    assert [i.default for i in g.inputs][:3] == [None, None, "0.5 0.5 1 1"]
    assert [(o.name, o.source, o.format, o.colorspace, o.group) for o in g.outputs] == \
        [(o["name"], o["from"], o.get("format"), o["colorspace"], o.get("group"))
         for o in info["outputs"]]
    with open(g.path) as f:  # the lines are where the declarations are
        lines = f.read().split("\n")
    assert 'name="water_level"' in lines[level.line - 1]
    assert 'name="height"' in lines[g.inputs[1].line - 1]


def test_load_by_name_and_by_path(write_graph):
    by_name = wetgraph.Graph("create_masks")
    by_path = wetgraph.Graph(by_name.path)
    assert by_path.path == by_name.path and by_path.name == "create_masks"
    assert wetgraph.graphs()["create_masks"] == by_name.path
    assert wetgraph.find_graph("create_masks") == by_name.path
    own = wetgraph.Graph(write_graph('<wetgraph version="1" size="8">'
                                     '<node id="u" type="uniform" value="0.25"/>'
                                     '<output name="o" from="u"/></wetgraph>', "own"))
    assert own.name == "own" and [o.name for o in own.outputs] == ["o"]
    a = own.render()["o"]
    assert a.shape == (8, 8) and a.dtype == np.float32 and np.all(a == 0.25)


def test_errors_carry_the_command_lines_text(cli, write_graph):
    bad = write_graph('<wetgraph version="1" size="8">\n'
                      '  <node id="b" type="blur" sigma="-1"/>\n'
                      '  <output name="o" from="b"/>\n</wetgraph>\n', "bad")
    with pytest.raises(wetgraph.Error) as e:
        wetgraph.Graph(bad)
    p = cli("check", bad, check=False)
    assert p.returncode != 0
    assert p.stderr.strip().splitlines()[0] == "wetgraph: error: " + str(e.value)
    assert e.value.file == bad and e.value.line == 2 and "node 'b'" in str(e.value)
    assert e.value.code == -4 and e.value.status == "value out of range"
    assert f"{bad}:2:" in str(e.value)
    # a name that finds nothing: the same suggestion as the command line's
    with pytest.raises(wetgraph.Error, match="did you mean 'wet_material'") as e:
        wetgraph.Graph("wet_materal")
    p = cli("render", "wet_materal", check=False)
    assert "wetgraph: error: " + str(e.value) in p.stderr


def test_parameter_values_and_errors(wet):
    wet.set(water_level=0.25, liquid="tea", normal_format="directx")
    wet.set("porosity", 1)
    assert wet.value("water_level") == "0.25" and wet.value("liquid") == "tea"
    assert wet.value("porosity") == "1" and wet.value("wet_height") == "0.08"
    wet.unset("liquid")
    assert wet.value("liquid") == "water"
    assert wetgraph.value_text(True) == "true"
    assert wetgraph.value_text((0.5, 0.25, 1)) == "0.5 0.25 1.0"
    assert wetgraph.value_text(0.1) == "0.1"
    with pytest.raises(wetgraph.Error, match=r"wet_material.wetgraph:29: 'water_level' = 3 is "
                                             r"outside \[0, 1\]") as e:
        wet.set(water_level=3)
    assert e.value.line == 29 and e.value.code == -4
    with pytest.raises(wetgraph.Error, match="has no parameter 'water_levle'; did you mean "
                                             "'water_level'"):
        wet.set(water_levle=0.3)
    with pytest.raises(wetgraph.Error, match="liquid"):
        wet.set(liquid="lava")
    with pytest.raises(TypeError):
        wet.set(water_level=object())
    assert wet.value("water_level") == "0.25"  # a refused value changes nothing


# ---- renders equal the command line's files -----------------------------------------------

@pytest.mark.parametrize("fmt,dtype", [("png", np.uint8), ("png16", np.uint16),
                                       ("exr32", np.float32)])
def test_render_equals_the_command_lines_files(cli, wet, bricks, tmp_path, fmt, dtype):
    wet.set(water_level=0.45)
    args = ["render", "wet_material", "-o", tmp_path, "--size", f"{SIZE}x{SIZE}", "--format", fmt,
            "--set", "water_level=0.45"]
    for name in ("basecolor", "height", "normal", "roughness", "ao"):
        args += ["--input", f"{name}={bricks[name]}"]
    cli(*args)
    maps = wet.render(dtype=dtype)
    assert sorted(maps) == sorted(o.name for o in wet.outputs)
    ext = "exr" if fmt == "exr32" else "png"
    for name, a in maps.items():
        f = read_image(tmp_path / f"wet_material_{name}.{ext}")
        assert a.dtype == dtype and f.dtype == dtype, name
        if a.ndim == 3 and f.ndim == 3 and f.shape[2] == 3:  # opaque colour is written as RGB
            assert np.all(a[..., 3] == (255 if dtype == np.uint8 else 65535 if dtype == np.uint16
                                        else 1.0)), name
            a = a[..., :3]
        assert a.shape == f.shape, name
        assert np.array_equal(a, f), f"{name}: {np.count_nonzero(a != f)} samples differ"


def test_render_files_writes_what_the_command_line_writes(cli, wet, bricks, tmp_path):
    mine, theirs = tmp_path / "mine", tmp_path / "theirs"
    mine.mkdir()
    args = ["render", "wet_material", "-o", theirs, "--size", f"{SIZE}x{SIZE}",
            "--output", "basecolor", "--output", "height", "--format", "height=exr32"]
    for name in ("basecolor", "height", "normal", "roughness", "ao"):
        args += ["--input", f"{name}={bricks[name]}"]
    cli(*args)
    paths = wet.render_files(mine, ["basecolor", "height"], format={"height": "exr32"})
    assert paths == {"basecolor": str(mine / "wet_material_basecolor.png"),
                     "height": str(mine / "wet_material_height.exr")}
    for name, p in paths.items():
        other = theirs / os.path.basename(p)
        assert np.array_equal(read_image(p), read_image(other)), name
    assert (mine / "wet_material_basecolor.png").read_bytes() == \
        (theirs / "wet_material_basecolor.png").read_bytes()
    with pytest.raises(wetgraph.Error, match="unknown format 'webp'"):
        wet.render_files(mine, ["height"], format="webp")


# ---- numpy inputs --------------------------------------------------------------------------

PASS = ('<wetgraph version="1" size="$l">'
        '<input name="c" type="color" colorspace="srgb" default="0"/>'
        '<input name="l" type="color"/>'
        '<input name="g" type="gray" default="0"/>'
        '<input name="s" type="gray" colorspace="srgb" default="0"/>'
        '<output name="c" from="$c" format="exr32"/><output name="l" from="$l" format="exr32"/>'
        '<output name="g" from="$g" format="exr32"/><output name="s" from="$s" format="exr32"/>'
        '</wetgraph>')


def sample_array(dtype, channels, h=24, w=40):
    """Every code of an 8-bit ramp (or a spread of 16-bit codes, or floats in [0, 1.5]) over an
    h x w image of `channels` channels (0: a 2-D gray array)."""
    rng = np.random.default_rng(channels * 7 + np.dtype(dtype).itemsize)
    shape = (h, w) if channels == 0 else (h, w, channels)
    if dtype == np.float32:
        return rng.uniform(0, 1.5, shape).astype(np.float32)
    top = 255 if dtype == np.uint8 else 65535
    return rng.integers(0, top + 1, shape, dtype=dtype)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
@pytest.mark.parametrize("channels", [0, 1, 3, 4])
def test_array_inputs_equal_the_same_pixels_from_files(write_graph, tmp_path, dtype, channels):
    g = wetgraph.Graph(write_graph(PASS))
    a = sample_array(dtype, channels)
    ext = "exr" if dtype == np.float32 else "png"
    path = tmp_path / f"in.{ext}"
    write_image(path, a)
    # the file and the array, each into every input: linear and sRGB, colour and gray
    names = ["l", "g"] if dtype == np.float32 else ["c", "l", "g", "s"]
    from_array, from_file = {}, {}
    for src, out in ((a, from_array), (str(path), from_file)):
        for n in names:
            g.set_input(n, src)
        if "c" not in names:
            g.set_input("c", None)
        res = g.render(names)
        out.update({k: v.copy() for k, v in res.items()})
    for n in names:
        assert from_array[n].shape == (24, 40, 4) if n in "cl" else (24, 40)
        assert np.array_equal(from_array[n], from_file[n]), \
            f"input {n}: {np.count_nonzero(from_array[n] != from_file[n])} samples differ"
    # the values themselves, through the linear input: codes k times the float 1 / 255 or
    # 1 / 65535, floats as they are; gray copied to R, G, B; alpha 1 unless given
    top = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(np.dtype(dtype))
    want = a if top is None else a.astype(np.float32) * np.float32(1.0 / top)
    if channels in (0, 1):
        want = np.repeat(want.reshape(24, 40, 1), 3, axis=2)
    lin = from_array["l"]
    assert np.array_equal(lin[..., :3], want[..., :3])
    assert np.array_equal(lin[..., 3], want[..., 3] if channels == 4 else np.ones((24, 40)))


def test_float_arrays_are_linear_values_even_on_srgb_inputs(write_graph):
    g = wetgraph.Graph(write_graph(PASS))
    a = sample_array(np.float32, 4)
    g.set_input("l", a)
    g.set_input("c", a)
    res = g.render(["c", "l"])
    assert np.array_equal(res["c"], a) and np.array_equal(res["l"], a)


def test_float_arrays_are_lent_not_copied(write_graph):
    g = wetgraph.Graph(write_graph(PASS))
    big = sample_array(np.float32, 4, 60, 70)
    crop = big[5:29, 10:50]  # rows 70 pixels apart: not contiguous, yet taken as it is
    assert not crop.flags.c_contiguous
    before = sys.getrefcount(big)
    g.set_input("l", crop)
    del crop
    gc.collect()
    # the crop (and through it the whole array) is held by the engine's image, not copied
    assert sys.getrefcount(big) == before
    out = g.render(["l"])["l"]
    assert np.array_equal(out, big[5:29, 10:50])
    gray = sample_array(np.float32, 0)
    n = sys.getrefcount(gray)
    g.set_input("g", gray)
    assert sys.getrefcount(gray) == n + 1  # held: no copy
    g.set_input("g", None)
    assert sys.getrefcount(gray) == n  # let go with the last reference
    rgb = sample_array(np.float32, 3)
    n = sys.getrefcount(rgb)
    g.set_input("g", rgb)
    assert sys.getrefcount(rgb) == n  # three channels are widened to four: a copy


def test_outputs_are_read_only_views_of_the_engines_images(write_graph):
    g = wetgraph.Graph(write_graph(PASS))
    a = sample_array(np.float32, 4)
    g.set_input("l", a)
    out = g.render(["l"])["l"]
    assert not out.flags.writeable and out.base is not None
    with pytest.raises(ValueError):
        out[0, 0, 0] = 5
    again = g.render(["l"])["l"]  # the cache still holds the same pixels
    assert np.array_equal(again, a)
    del g
    gc.collect()
    assert np.array_equal(out, a)  # the view keeps its image alive after the graph is gone


@pytest.mark.parametrize("bad,match", [
    (np.zeros((4, 4, 2), np.float32), r"array \(4, 4, 2\) has 2 channels: give 1 \(gray\), 3"),
    (np.zeros((2, 4, 4, 3), np.float32), r"array of 4 dimensions: give \(height, width\)"),
    (np.zeros(16, np.uint8), r"array of 1 dimensions"),
    (np.full((4, 4), np.nan, np.float32), r"array \(4, 4\) holds NaN at pixel \(x 0, y 0\)"),
    (np.pad(np.array([[np.inf]], np.float32), ((3, 0), (1, 0))),
     r"holds an infinite value at pixel \(x 1, y 3\)"),
    (np.zeros((8, 8), np.float32)[:, ::2], r"array \(8, 4\) is not contiguous within its rows"),
    (np.zeros((8, 6, 4), np.uint8)[:, :, ::-1], r"is not contiguous within its rows"),
    (np.zeros((8, 6), np.uint16).T, r"array \(6, 8\) is not contiguous within its rows"),
    (np.zeros((8, 6), np.uint16)[::-1], r"is not contiguous within its rows"),
    (np.zeros((0, 8), np.float32), r"array \(0, 8\) holds no pixels"),
    (np.zeros((8, 0, 4), np.uint8), r"array \(8, 0, 4\) holds no pixels"),
    (np.zeros((4, 4), np.float64), r"array of dtype f8: give uint8, uint16 or float32"),
    (np.zeros((4, 4), np.int32), r"array of dtype i4"),
    (np.zeros((4, 4), ">u2"), r"array \(4, 4\) is in the other byte order"),
])
def test_bad_arrays_are_refused_with_the_inputs_line(write_graph, bad, match):
    path = write_graph(PASS)
    g = wetgraph.Graph(path)
    with pytest.raises(wetgraph.Error, match=match) as e:
        g.set_input("g", bad)
    assert str(e.value).startswith(f"{path}:1: input 'g': ")
    assert e.value.file == path and e.value.line == 1
    g.set_input("l", np.zeros((4, 4), np.float32))
    assert np.all(g.render(["g"])["g"] == 0)  # the refused array changed nothing


def test_other_bad_inputs(write_graph, tmp_path):
    g = wetgraph.Graph(write_graph(PASS))
    with pytest.raises(TypeError, match="give a file path, a numpy array or None, not list"):
        g.set_input("g", [[0.5]])
    with pytest.raises(wetgraph.Error, match=r"has no input 'q'"):
        g.set_input("q", np.zeros((4, 4), np.float32))
    with pytest.raises(wetgraph.Error, match="cannot open the image"):
        g.set_input("g", str(tmp_path / "missing.png"))
    with pytest.raises(wetgraph.Error, match=r"no image was given for input 'l'"):
        g.render()  # the size comes from $l, which nothing feeds
    with pytest.raises(wetgraph.Error, match=r"no output 'x'"):
        g.render(["x"])
    with pytest.raises(wetgraph.Error, match=r"no output 'xy'"):
        g.render("xy")  # one name, not its letters
    with pytest.raises(TypeError, match="outputs must be a list of output names"):
        g.render(3)
    with pytest.raises(TypeError, match="dtype must be float32, uint8 or uint16"):
        g.render(dtype=np.float64)
    with pytest.raises(wetgraph.Error, match=r"size 0x3 is outside 1..16384 per side"):
        g.size = (0, 3)
    with pytest.raises(TypeError, match="size is"):
        g.size = "64"
    g.size = 16
    assert g.size == (16, 16)
    g.size = None
    assert g.size is None
    with pytest.raises(TypeError, match="engine must be a wetgraph.Engine"):
        wetgraph.Graph("wet_material", engine="fast")
    with pytest.raises(ValueError, match="threads is -1"):
        wetgraph.Engine(threads=-1)


# ---- the cache across renders, progress, cancel, threads -----------------------------------

def test_second_render_recomputes_only_what_the_change_reaches(wet, bricks):
    first = wet.render()
    s1 = wet.stats
    assert s1["evaluated"] == len(s1["nodes"]) > 20
    assert all(n["cache"] == "computed" for n in s1["nodes"])
    wet.set(wet_roughness=0.2)
    second = wet.render()
    s2 = wet.stats
    computed = {n["id"] for n in s2["nodes"] if n["cache"] == "computed"}
    cached = {n["id"] for n in s2["nodes"] if n["cache"] == "memory"}
    assert s2["evaluated"] == len(computed) > 0
    assert all(n["ms"] == 0 for n in s2["nodes"] if n["cache"] == "memory")
    # only the roughness nodes read wet_roughness: the masks, colours, normals come from the cache
    assert all("rough" in i for i in computed), computed
    assert {"masks/immersed", "masks/wet", "tex/albedo"} <= cached, cached
    changed = {k for k in first if not np.array_equal(first[k], second[k])}
    assert changed == {"roughness", "underroughness"}, changed
    # the same pixels as a render that computes everything
    fresh = wetgraph.Graph("wet_material", wetgraph.Engine(threads=1))
    fresh.set_inputs(**{name: bricks[name] for name in ("basecolor", "height", "normal",
                                                        "roughness", "ao")})
    fresh.size = (SIZE, SIZE)
    fresh.set(wet_roughness=0.2)
    again = fresh.render()
    assert fresh.stats["evaluated"] == len(fresh.stats["nodes"])
    for k in second:
        assert np.array_equal(second[k], again[k]), k
    # nothing changed: nothing computed
    wet.render(["basecolor"])
    assert wet.stats["evaluated"] == 0
    wet.engine.clear_cache()
    wet.render(["basecolor"])
    assert wet.stats["evaluated"] > 0


def test_progress_reports_every_job(wet):
    calls = []
    wet.render(["basecolor", "zones"], progress=lambda d, t, n: calls.append((d, t, n)))
    assert calls, "no progress reported"
    done = [c[0] for c in calls]
    assert done == sorted(done) and done[-1] == calls[-1][1]
    assert all(c[1] == calls[0][1] for c in calls)
    assert any(isinstance(c[2], str) for c in calls)


def test_an_exception_in_progress_stops_the_render(wet):
    seen = []

    def fail(done, total, node):
        seen.append(done)
        raise KeyError("stop here")
    with pytest.raises(KeyError, match="stop here"):
        wet.render(progress=fail)
    assert len(seen) == 1
    wet.render(["basecolor"])  # the graph renders again afterwards


SLOW = """<wetgraph version="1" size="1024">
  <node id="n" type="noise" scale="5"/>
  <node id="ao0" type="blur" sigma="1"><in name="source" from="n"/></node>
{aos}
  <output name="c" from="ao16" format="exr32"/>
</wetgraph>"""


def slow_graph(write_graph):
    aos = "\n".join(f'  <node id="ao{i}" type="ambient_occlusion" radius="16" directions="64">'
                    f'<in name="height" from="ao{i - 1}"/></node>' for i in range(1, 17))
    return write_graph(SLOW.format(aos=aos), "slow")


def test_cancel_from_another_thread_stops_a_slow_render_and_the_gil_is_free(write_graph):
    g = wetgraph.Graph(slow_graph(write_graph), wetgraph.Engine(threads=2))
    token = wetgraph.Cancel()
    progress = []
    outcome = {}

    def run():
        try:
            g.render(cancel=token, progress=lambda d, t, n: progress.append((d, t)))
            outcome["result"] = "finished"
        except wetgraph.Cancelled as e:
            outcome["result"] = e
        outcome["end"] = time.monotonic()

    t = threading.Thread(target=run)
    t.start()
    # Python keeps running beside the render: the GIL is released while it renders
    spins, end = 0, time.monotonic() + 0.4
    while time.monotonic() < end:
        spins += 1
    assert t.is_alive(), "the slow render finished within 0.4 s: it is not slow"
    assert spins > 10000
    asked = time.monotonic()
    token.request()
    t.join(30)
    assert not t.is_alive()
    e = outcome["result"]
    assert isinstance(e, wetgraph.Cancelled), e
    assert "cancelled" in str(e) and e.code == -9
    assert outcome["end"] - asked < 2.0, f"the render stopped {outcome['end'] - asked:.2f} s late"
    assert not progress or progress[-1][0] < progress[-1][1]
    # the token stays requested until reset: a render now stops at once
    with pytest.raises(wetgraph.Cancelled):
        g.render(cancel=token)
    token.reset()
    assert not token.requested


def test_graph_cancel_stops_its_own_render(write_graph):
    g = wetgraph.Graph(slow_graph(write_graph), wetgraph.Engine(threads=2))
    assert g.cancel() is False  # nothing running
    errors = []
    t = threading.Thread(target=lambda: errors.append(pytest.raises(wetgraph.Cancelled, g.render)))
    t.start()
    deadline = time.monotonic() + 10
    while not g.cancel() and time.monotonic() < deadline:
        time.sleep(0.01)
    t.join(30)
    assert errors and not t.is_alive()


def test_two_engines_render_in_two_threads(wet, bricks):
    want = wet.render(["basecolor", "roughness", "zones"])
    want = {k: v.copy() for k, v in want.items()}
    graphs = []
    for level in (0.6, 0.2):
        g = wetgraph.Graph("wet_material", wetgraph.Engine(threads=1))
        for name in ("basecolor", "height", "normal", "roughness", "ao"):
            g.set_input(name, bricks[name])
        g.size = (SIZE, SIZE)
        g.set(water_level=level)
        graphs.append(g)
    results = [None, None]

    def run(i):
        for _ in range(3):
            results[i] = graphs[i].render(["basecolor", "roughness", "zones"])
            graphs[i].engine.clear_cache()

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    for k in want:
        assert np.array_equal(results[0][k], want[k]), k
    assert not np.array_equal(results[1]["zones"], want["zones"])  # another water level
    wet.set(water_level=0.2)
    other = wet.render(["zones"])["zones"]
    assert np.array_equal(results[1]["zones"], other)


def test_one_graph_refuses_a_second_render_at_once(write_graph):
    g = wetgraph.Graph(slow_graph(write_graph), wetgraph.Engine(threads=1))
    started = threading.Event()
    outcome = []

    def run():
        try:
            g.render(progress=lambda *a: started.set())
            outcome.append("finished")
        except wetgraph.Cancelled as e:
            outcome.append(e)

    t = threading.Thread(target=run)
    t.start()
    assert started.wait(10)
    with pytest.raises(RuntimeError, match="rendering in another thread"):
        g.render()
    assert g.cancel() is True
    t.join(30)
    assert not t.is_alive() and isinstance(outcome[0], wetgraph.Cancelled), outcome


def test_two_graphs_on_one_engine_render_one_at_a_time(write_graph):
    engine = wetgraph.Engine(threads=2)
    text = ('<wetgraph version="1" size="256"><param name="s" type="float" default="4"/>'
            '<node id="n" type="noise" scale="=s"/>'
            '<node id="b" type="blur" sigma="3"><in name="source" from="n"/></node>'
            '<output name="o" from="b"/></wetgraph>')
    graphs = [wetgraph.Graph(write_graph(text, "shared"), engine) for _ in range(2)]
    graphs[1].set(s=9)
    want = [g.render()["o"].copy() for g in graphs]
    engine.clear_cache()
    got = [None, None]

    def run(i):
        for _ in range(5):
            got[i] = graphs[i].render()["o"]

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert all(np.array_equal(got[i], want[i]) for i in range(2))
    assert not np.array_equal(want[0], want[1])
    # the two graphs share the engine's cache: the same values are not computed again
    graphs[1].set(s=4)
    graphs[1].render()
    assert graphs[1].stats["evaluated"] == 0


def test_seed_and_time(write_graph):
    g = wetgraph.Graph(write_graph('<wetgraph version="1" size="32" seed="3">'
                                   '<node id="n" type="noise" scale="4"/>'
                                   '<output name="o" from="n"/></wetgraph>', "seeded"))
    assert g.seed is None and g.time == 0.0
    own = g.render()["o"].copy()
    g.seed = 3
    assert np.array_equal(g.render()["o"], own)  # the graph's own seed
    g.seed = 4
    assert not np.array_equal(g.render()["o"], own)
    g.seed = None
    assert np.array_equal(g.render()["o"], own)
    with pytest.raises(ValueError, match="time must be a finite number"):
        g.time = float("nan")
    g.time = 2.5
    assert g.time == 2.5


# ---- node plugins ---------------------------------------------------------------------------

def test_a_plugin_adds_its_node_types(write_graph):
    plugins = os.path.join(os.environ["WETGRAPH_BUILD_ROOT"], "tests", "plugins")
    path = write_graph("""<wetgraph version="1" size="8">
  <node id="g" type="uniform" value="0.125"/>
  <node id="o" type="plugin_offset" amount="0.25"><in name="source" from="g"/></node>
  <output name="out" from="o"/>
</wetgraph>""", name="offset")
    with pytest.raises(wetgraph.Error, match="plugin_offset"):
        wetgraph.Graph(path)
    with pytest.raises(wetgraph.Error, match="no_entry.so: not a wetgraph plugin"):
        wetgraph.load_plugin(os.path.join(plugins, "no_entry.so"))
    wetgraph.load_plugin(os.path.join(plugins, "offset_v1.so"))
    wetgraph.load_plugin(os.path.join(plugins, "offset_v1.so"))  # a second load does nothing
    out = wetgraph.Graph(path).render("out")["out"]
    assert out.shape[:2] == (8, 8) and np.all(out == np.float32(0.375))
