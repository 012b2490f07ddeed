# SPDX-License-Identifier: MIT
# The add-on, headless: blender -b --factory-startup --python-exit-code 1 --python check_addon.py
#     -- ADDON_FOLDER MODULE_FOLDER MATERIAL_FOLDER
# builds a material from the shared Bricks102 maps the way a user wires them (base colour
# multiplied by AO, roughness, normal through a Normal Map, height through a Displacement node),
# runs the add-on's operator, and checks the wiring (each dry map's links moved to its wet map,
# the water layer in the clear coat), the wet maps' pixels (darker under water, water where the
# mask says), that a second run after a water level change computes only some nodes, that a
# generated (unsaved) image is read from its pixels, and that "Dry" restores the links. Prints
# "addon check: ok" and exits 0, or raises (exit 1).
import os
import sys

import bpy
import numpy as np

argv = sys.argv[sys.argv.index("--") + 1:]
addon_dir, module_dir, material_dir = argv[:3]
sys.path.insert(0, module_dir)
sys.path.insert(0, addon_dir)
import wetgraph_wet  # noqa: E402

wetgraph_wet.register()
SIZE = 128


def image(name, colour):
    img = bpy.data.images.load(os.path.join(material_dir, name))
    img.colorspace_settings.name = "sRGB" if colour else "Non-Color"
    return img


mat = bpy.data.materials.new("Bricks102")
mat.use_nodes = True
nt = mat.node_tree
bsdf = nt.nodes["Principled BSDF"]
out = nt.nodes["Material Output"]


def tex(name, file, colour, x, y):
    n = nt.nodes.new("ShaderNodeTexImage")
    n.name = name
    n.image = image(file, colour)
    n.location = (x, y)
    return n


base = tex("Color", "Bricks102_1K-JPG_Color.jpg", True, -900, 300)
ao = tex("AmbientOcclusion", "Bricks102_1K-JPG_AmbientOcclusion.jpg", False, -900, 0)
mix = nt.nodes.new("ShaderNodeMixRGB")
mix.blend_type = "MULTIPLY"
mix.inputs["Fac"].default_value = 1.0
nt.links.new(base.outputs["Color"], mix.inputs["Color1"])
nt.links.new(ao.outputs["Color"], mix.inputs["Color2"])
nt.links.new(mix.outputs["Color"], bsdf.inputs["Base Color"])
rough = tex("Roughness", "Bricks102_1K-JPG_Roughness.jpg", False, -900, -300)
nt.links.new(rough.outputs["Color"], bsdf.inputs["Roughness"])
normal = tex("NormalGL", "Bricks102_1K-JPG_NormalGL.jpg", False, -900, -600)
nm = nt.nodes.new("ShaderNodeNormalMap")
nt.links.new(normal.outputs["Color"], nm.inputs["Color"])
nt.links.new(nm.outputs["Normal"], bsdf.inputs["Normal"])
height = tex("Displacement", "Bricks102_1K-JPG_Displacement.jpg", False, -900, -900)
disp = nt.nodes.new("ShaderNodeDisplacement")
nt.links.new(height.outputs["Color"], disp.inputs["Height"])
nt.links.new(disp.outputs["Displacement"], out.inputs["Displacement"])

s = mat.wetgraph
s.water_level = 0.7
s.resolution = SIZE

# the operator, as the panel's button runs it, on the material of the active object
bpy.ops.mesh.primitive_plane_add()
obj = bpy.context.active_object
obj.data.materials.append(mat)
with bpy.context.temp_override(object=obj, material=mat):
    assert bpy.ops.wetgraph.wet_material.poll(), "the operator is not available for the material"
    result = bpy.ops.wetgraph.wet_material()
assert result == {"FINISHED"}, f"the operator returned {result}: {s.report}"
print("first run:", s.report)


def source(socket):
    assert socket.is_linked, f"{socket.node.name}.{socket.name} is not linked"
    return socket.links[0].from_node


W = wetgraph_wet.NODE_PREFIX
# the dry maps were found, and their links moved to the wet maps
assert (s.dry_basecolor, s.dry_ao, s.dry_roughness, s.dry_normal, s.dry_height) == \
    ("Color", "AmbientOcclusion", "Roughness", "NormalGL", "Displacement"), \
    (s.dry_basecolor, s.dry_ao, s.dry_roughness, s.dry_normal, s.dry_height)
assert source(mix.inputs["Color1"]).name == W + "basecolor"
assert source(mix.inputs["Color2"]).name == W + "ao"
assert source(bsdf.inputs["Roughness"]).name == W + "roughness"
assert source(nm.inputs["Color"]).name == W + "normal"
assert source(disp.inputs["Height"]).name == W + "height"
for dry_node in (base, ao, rough, normal, height):
    assert not any(o.is_linked for o in dry_node.outputs), f"{dry_node.name} is still wired"
# the water layer is the clear coat
assert source(bsdf.inputs["Clearcoat"]).name == W + "watermask"
assert source(bsdf.inputs["Clearcoat Roughness"]).name == W + "waterroughness"
cn = source(bsdf.inputs["Clearcoat Normal"])
assert cn.type == "NORMAL_MAP" and source(cn.inputs["Color"]).name == W + "waternormal"


def pixels(node):
    img = node.image
    assert tuple(img.size) == (SIZE, SIZE), (node.name, tuple(img.size))
    px = np.empty(SIZE * SIZE * 4, np.float32)
    img.pixels.foreach_get(px)
    return px.reshape(SIZE, SIZE, 4)[::-1]


wet_base = pixels(nt.nodes[W + "basecolor"])[..., :3]
mask = pixels(nt.nodes[W + "watermask"])[..., 0]
assert nt.nodes[W + "basecolor"].image.colorspace_settings.name == "Linear"
assert nt.nodes[W + "watermask"].image.colorspace_settings.name == "Non-Color"
assert nt.nodes[W + "basecolor"].image.packed_file is not None, "the wet maps are not packed"
assert 0.05 < mask.mean() < 0.95, f"water mask mean {mask.mean()} at water level 0.7"
# the same maps as the module gives for the same files and values
import wetgraph  # noqa: E402
g = wetgraph.Graph("wet_material")
g.set_inputs(basecolor=bpy.path.abspath(base.image.filepath),
             height=bpy.path.abspath(height.image.filepath),
             normal=bpy.path.abspath(normal.image.filepath),
             roughness=bpy.path.abspath(rough.image.filepath),
             ao=bpy.path.abspath(ao.image.filepath))
g.size = (SIZE, SIZE)
g.set(water_level=0.7, normal_format="opengl")
want = g.render(["basecolor", "watermask"])
assert np.array_equal(wet_base, want["basecolor"][..., :3]), "the wet base colour differs"
assert np.array_equal(mask, want["watermask"]), "the water mask differs"
dry_lin = g.render(["basecolor"])["basecolor"]
g.set(water_level=0.0)
dry_lin = g.render(["basecolor"])["basecolor"][..., :3]
under = mask > 0.5
assert wet_base[under].mean() < dry_lin[under].mean() * 0.9, "not darker under water"

# a second run after a slider change: only the nodes the water level reaches are computed
s.water_level = 0.6
with bpy.context.temp_override(object=obj, material=mat):
    assert bpy.ops.wetgraph.wet_material() == {"FINISHED"}
print("second run:", s.report)
st = wetgraph_wet._sessions[mat.name].stats
assert 0 < st["evaluated"] < len(st["nodes"]), (st["evaluated"], len(st["nodes"]))
assert any(n["cache"] == "memory" for n in st["nodes"])
mask2 = pixels(nt.nodes[W + "watermask"])[..., 0]
assert mask2.mean() < mask.mean(), "less water at a lower level"
assert s.dry_basecolor == "Color"  # still read from the dry maps

# a generated image (no file) is read from its pixels
gen = bpy.data.images.new("flat ao", 64, 64, alpha=True)
gen.generated_color = (1.0, 1.0, 1.0, 1.0)
ao.image = gen
with bpy.context.temp_override(object=obj, material=mat):
    assert bpy.ops.wetgraph.wet_material() == {"FINISHED"}, s.report
print("generated AO:", s.report)

# "Dry" puts the dry maps back and unlinks the clear coat
with bpy.context.temp_override(object=obj, material=mat):
    assert bpy.ops.wetgraph.dry_material() == {"FINISHED"}
assert source(mix.inputs["Color1"]).name == "Color"
assert source(mix.inputs["Color2"]).name == "AmbientOcclusion"
assert source(bsdf.inputs["Roughness"]).name == "Roughness"
assert source(nm.inputs["Color"]).name == "NormalGL"
assert source(disp.inputs["Height"]).name == "Displacement"
assert not bsdf.inputs["Clearcoat"].is_linked
assert not bsdf.inputs["Clearcoat Normal"].is_linked

# height through a Bump node, no normal map: the bump reads the wet height, the wet film's
# normal goes under the bump
bumpy = bpy.data.materials.new("bumpy")
bumpy.use_nodes = True
bt = bumpy.node_tree
bb = bt.nodes["Principled BSDF"]
c2 = bt.nodes.new("ShaderNodeTexImage")
c2.image = base.image
bt.links.new(c2.outputs["Color"], bb.inputs["Base Color"])
h2 = bt.nodes.new("ShaderNodeTexImage")
h2.image = height.image
bump = bt.nodes.new("ShaderNodeBump")
bt.links.new(h2.outputs["Color"], bump.inputs["Height"])
bt.links.new(bump.outputs["Normal"], bb.inputs["Normal"])
bumpy.wetgraph.resolution = SIZE
wetgraph_wet.wet(bumpy)
assert bumpy.wetgraph.dry_height == h2.name and bumpy.wetgraph.dry_normal == ""
assert source(bump.inputs["Height"]).name == W + "height"
assert source(bb.inputs["Normal"]) == bump
assert source(bump.inputs["Normal"]).name == W + "normal map"
assert bumpy.wetgraph.dry_ao == ""  # no AO map in this material
print("bump:", bumpy.wetgraph.report)

# a material without a height map: a clear error, nothing rewired
flat = bpy.data.materials.new("flat")
flat.use_nodes = True
t = flat.node_tree.nodes.new("ShaderNodeTexImage")
t.image = base.image
flat.node_tree.links.new(t.outputs["Color"], flat.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
try:
    wetgraph_wet.wet(flat)
except RuntimeError as e:
    assert "no height image found" in str(e), e
else:
    raise AssertionError("a material without a height map was wetted")

wetgraph_wet.unregister()
print("addon check: ok")
