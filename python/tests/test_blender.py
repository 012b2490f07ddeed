# SPDX-License-Identifier: MIT
# The Blender add-on, headless (blender -b) on the shared Bricks102 material: python/blender/
# check_addon.py builds the material, runs the add-on and checks the wiring, the maps and the
# cache across runs. Skipped with the reason where Blender is not installed (scripts/
# install-deps.sh installs it) and in the sanitizer build (Blender's Python would load the
# instrumented module without the sanitizer runtime).
import os
import shutil
import subprocess

import pytest

from conftest import BRICKS, SOURCE

pytestmark = pytest.mark.blender


def test_addon_wets_a_shared_material_headless():
    if os.environ.get("WETGRAPH_SANITIZED") == "1":
        pytest.skip("sanitizer build: Blender does not load the sanitizer runtimes the "
                    "instrumented module needs (the optimised build runs this test)")
    blender = shutil.which("blender")
    if not blender:
        pytest.skip("Blender is not installed: the add-on's headless test needs it "
                    "(Debian package blender, installed by scripts/install-deps.sh)")
    addon = os.environ.get("WETGRAPH_ADDON_DIR", os.path.join(SOURCE, "python", "blender"))
    module = os.environ["PYTHONPATH"].split(os.pathsep)[0]
    p = subprocess.run([blender, "-b", "--factory-startup", "--python-exit-code", "1",
                        "--python", os.path.join(addon, "check_addon.py"), "--",
                        addon, module, BRICKS],
                       capture_output=True, text=True, timeout=240)
    log = p.stdout + p.stderr
    assert p.returncode == 0 and "addon check: ok" in p.stdout, log[-4000:]
    assert "nodes computed" in p.stdout
