# SPDX-License-Identifier: MIT
# Runs Blender's own Node Wrangler "Principled Texture Setup" (Ctrl+Shift+T) headless on every
# image of a folder, as an artist does who selects a whole render in the file browser, and prints
# which file it wired into which Principled BSDF input, one "INPUT<TAB>FILE" line each.
#   blender -b --factory-startup -P bench/blender_node_wrangler.py -- FOLDER [reverse] [WORD...]
# The operator matches files to inputs by the words of their names (split at _ . - # and
# camelCase, digits dropped) and takes the first file in the list that matches; "reverse" hands
# it the files in reverse name order, so a test can check that the wiring does not depend on
# which of two matching files comes first. Each WORD is added to the add-on's words for base
# colour, as a user does in its preferences. The operator needs a node editor; here its execute()
# is called with the same data a node editor would give it (the material's tree, its active
# Principled BSDF, the add-on's preferences).
import os
import sys
import types

import addon_utils
import bpy

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not argv:
    sys.exit("usage: blender -b -P blender_node_wrangler.py -- FOLDER [reverse] [WORD...]")
folder = os.path.abspath(argv[0])
reverse = len(argv) > 1 and argv[1] == "reverse"
words = argv[2:] if reverse else argv[1:]

addon_utils.enable("node_wrangler", default_set=True)
import node_wrangler  # noqa: E402  (importable once enabled)

tags = bpy.context.preferences.addons["node_wrangler"].preferences.principled_tags
tags.base_color = " ".join([tags.base_color] + words)

mat = bpy.data.materials.new("wet")
mat.use_nodes = True
tree = mat.node_tree
bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
tree.nodes.active = bsdf

names = sorted(f for f in os.listdir(folder)
               if os.path.splitext(f)[1].lower() in (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr", ".tga"))
if reverse:
    names.reverse()
operator = types.SimpleNamespace(
    directory=folder + os.sep,
    files=[types.SimpleNamespace(name=n) for n in names],
    relative_path=False,
    report=lambda level, text: print("node wrangler:", text, file=sys.stderr),
)
context = types.SimpleNamespace(
    space_data=types.SimpleNamespace(node_tree=tree, tree_type="ShaderNodeTree"),
    active_node=bsdf,
    preferences=bpy.context.preferences,
)
result = node_wrangler.NWAddPrincipledSetup.execute(operator, context)
if result != {"FINISHED"}:
    sys.exit("Principled Texture Setup did not finish: %s" % result)


# Node Wrangler labels each image texture node it adds with the input it wired it to (the
# ambient occlusion one goes through a multiply into Base Color, or stands alone without one)
for node in tree.nodes:
    if node.type == "TEX_IMAGE" and node.image:
        print("%s\t%s" % (node.label, os.path.basename(node.image.filepath)))
