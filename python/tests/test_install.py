# SPDX-License-Identifier: MIT
# `meson install` puts the module in the Python site folder below the prefix (the one Debian's
# python3 and Blender read for /usr/local) with its stubs, and the Blender add-on as a folder and
# a zip; the installed module imports in a fresh interpreter and renders a graph by name.
import json
import os
import subprocess
import sys
import zipfile

from conftest import BRICKS


def test_meson_install_puts_the_module_where_python_finds_it(tmp_path):
    build = os.environ["WETGRAPH_BUILD_ROOT"]
    dest = tmp_path / "dest"
    subprocess.run(["meson", "install", "-C", build, "--no-rebuild", "--quiet", "--destdir",
                    str(dest)], check=True, capture_output=True)
    found = {p.name: p for p in dest.rglob("*") if p.is_file()}
    ext = [n for n in found if n.startswith("_wetgraph.") and n.endswith(".so")]
    assert ext, "the extension was not installed"
    pkg = found[ext[0]].parent
    assert pkg.name == "wetgraph"
    for f in ("__init__.py", "__init__.pyi", "py.typed"):
        assert (pkg / f).is_file(), f
    # the site folder: for /usr/local and /usr, one on this (Debian) python3's sys.path, which
    # Blender's Python shares
    prefix = subprocess.run(["meson", "introspect", build, "--buildoptions"], check=True,
                            capture_output=True, text=True).stdout
    prefix = next(o["value"] for o in json.loads(prefix) if o["name"] == "prefix")
    site = str(pkg.parent)[len(str(dest)):]
    assert site.startswith(prefix + "/")
    if prefix in ("/usr/local", "/usr"):
        assert site in sys.path, (site, sys.path)
    # the add-on, as a folder and as a zip for Preferences > Add-ons > Install
    addon = found["wetgraph_wet.zip"]
    assert (addon.parent / "wetgraph_wet" / "__init__.py").is_file()
    with zipfile.ZipFile(addon) as z:
        assert z.namelist() == ["wetgraph_wet/__init__.py"]
    # a fresh interpreter imports the installed module and renders by name
    lib = next(p.parent for n, p in found.items() if n.startswith("libwetgraph.so"))
    graphs = found["wet_material.wetgraph"].parent
    env = dict(os.environ, PYTHONPATH=str(pkg.parent), LD_LIBRARY_PATH=str(lib),
               WETGRAPH_MODULE_DIR=str(lib / "wetgraph"), WETGRAPH_GRAPHS_DIR=str(graphs))
    code = ("import wetgraph, sys; g = wetgraph.Graph('wet_material'); "
            f"g.set_input('basecolor', {os.path.join(BRICKS, 'Bricks102_1K-JPG_Color.jpg')!r}); "
            f"g.set_input('height', {os.path.join(BRICKS, 'Bricks102_1K-JPG_Displacement.jpg')!r}); "
            "g.size = (32, 32); m = g.render(['basecolor']); "
            "print(wetgraph.__file__, g.path, m['basecolor'].shape)")
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    where, graph, shape = p.stdout.split(" ", 2)
    assert where == str(pkg / "__init__.py") and graph.startswith(str(graphs))
    assert shape.strip() == "(32, 32, 4)"
