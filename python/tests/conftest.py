# SPDX-License-Identifier: MIT
# Shared set-up of the Python suite: the module from the build tree (PYTHONPATH, set by meson),
# the command line it is compared with, the shared materials, small graphs written per test,
# and an independent image reader (OpenImageIO's Python binding) for the CLI's files.
import os
import subprocess

import numpy as np
import pytest

import wetgraph

SOURCE = os.environ.get("WETGRAPH_SOURCE", os.path.join(os.path.dirname(__file__), "..", ".."))
SHARED = os.environ.get("WETGRAPH_SHARED", os.path.join(SOURCE, "..", "shared"))
BRICKS = os.path.join(SHARED, "materials", "bricks102_stonewall_1k")


def pytest_configure(config):
    config.addinivalue_line("markers", "blender: runs Blender headless (the add-on's test)")


def pytest_sessionfinish(session, exitstatus):
    # meson counts exit status 77 as a skipped test: say so when every test run was skipped
    # (the Blender test without Blender), instead of reporting a pass
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if exitstatus == 0 and reporter and reporter.stats.get("skipped") and \
            not reporter.stats.get("passed"):
        session.exitstatus = 77


@pytest.fixture(scope="session")
def cli():
    """Run the wetgraph command line; returns the CompletedProcess (text)."""
    exe = os.environ.get("WETGRAPH_BIN")
    if not exe or not os.access(exe, os.X_OK):
        pytest.fail("WETGRAPH_BIN does not name the built wetgraph program (run through meson test)")

    def run(*args, check=True):
        p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
        if check and p.returncode != 0:
            pytest.fail(f"wetgraph {' '.join(map(str, args))} failed ({p.returncode}): {p.stderr}")
        return p
    return run


@pytest.fixture(scope="session")
def bricks():
    """The Bricks102 maps of the shared materials: {input name: file}."""
    files = {
        "basecolor": "Bricks102_1K-JPG_Color.jpg",
        "height": "Bricks102_1K-JPG_Displacement.jpg",
        "normal": "Bricks102_1K-JPG_NormalGL.jpg",
        "roughness": "Bricks102_1K-JPG_Roughness.jpg",
        "ao": "Bricks102_1K-JPG_AmbientOcclusion.jpg",
    }
    paths = {k: os.path.join(BRICKS, v) for k, v in files.items()}
    missing = [p for p in paths.values() if not os.path.isfile(p)]
    if missing:
        pytest.fail(f"the shared materials are missing ({missing[0]}): expected at ../shared")
    return paths


@pytest.fixture
def write_graph(tmp_path):
    """Write a .wetgraph file from its text; returns its path."""
    def write(text, name="g"):
        path = tmp_path / f"{name}.wetgraph"
        path.write_text(text)
        return str(path)
    return write


def read_image(path):
    """A file's samples as OpenImageIO reads them, in the file's own type: (h, w) for one
    channel, else (h, w, c)."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    assert inp, f"OpenImageIO cannot open {path}: {oiio.geterror()}"
    spec = inp.spec()
    fmt = {8: oiio.UINT8, 16: oiio.UINT16}.get(spec.format.size() * 8, oiio.FLOAT)
    if spec.format.basetype == oiio.HALF or spec.format.basetype == oiio.FLOAT:
        fmt = oiio.FLOAT
    pixels = inp.read_image(0, 0, 0, spec.nchannels, fmt)
    inp.close()
    assert pixels is not None, f"OpenImageIO cannot read {path}"
    a = np.asarray(pixels)
    return a[..., 0] if a.ndim == 3 and a.shape[2] == 1 else a


def write_image(path, array):
    """Write a (h, w[, c]) uint8, uint16 or float32 array as a file through OpenImageIO."""
    import OpenImageIO as oiio
    a = array if array.ndim == 3 else array[..., None]
    fmt = {np.dtype(np.uint8): oiio.UINT8, np.dtype(np.uint16): oiio.UINT16,
           np.dtype(np.float32): oiio.FLOAT}[a.dtype]
    spec = oiio.ImageSpec(a.shape[1], a.shape[0], a.shape[2], fmt)
    spec.attribute("oiio:UnassociatedAlpha", 1)  # the samples as given, alpha not multiplied in
    out = oiio.ImageOutput.create(str(path))
    assert out and out.open(str(path), spec), oiio.geterror()
    assert out.write_image(np.ascontiguousarray(a)), out.geterror()
    out.close()
