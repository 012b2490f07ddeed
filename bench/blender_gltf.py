# SPDX-License-Identifier: MIT
# Imports a glTF asset into Blender (headless) the way an artist would, checks that the
# material arrived whole, and renders it: bench/run_gltf.sh drives it.
#   blender -b --factory-startup -P bench/blender_gltf.py -- ASSET.gltf ENV.hdr OUT.png [samples]
# Checks (exit 1 with the reason when one fails): one mesh with one material whose Principled
# BSDF has image textures linked into Base Color, Metallic, Roughness, Normal (through a Normal
# Map node), and the clear coat's three inputs (Clearcoat, Clearcoat Roughness, Clearcoat
# Normal); prints each input and the image behind it, and Specular's, which Blender 3.4's
# importer converts from KHR_materials_specular to a value rather than linking a texture. Then renders the tile seen from
# 35 degrees above under the HDR with Cycles (CPU) to OUT.png.
import math
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(argv) < 3:
    sys.exit("usage: blender -b -P blender_gltf.py -- ASSET.gltf ENV.hdr OUT.png [samples]")
asset, env_path, out_path = argv[:3]
samples = int(argv[3]) if len(argv) > 3 else 64

# Debian 12's Blender 3.4 glTF importer still uses numpy's `np.bool`, which Debian's numpy 1.24
# removed: give it back the alias it means (the builtin bool), or every mesh import fails
import numpy  # noqa: E402

if not hasattr(numpy, "bool"):
    numpy.bool = bool

for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
bpy.ops.import_scene.gltf(filepath=asset)
meshes = [o for o in bpy.data.objects if o.type == "MESH"]
if len(meshes) != 1:
    sys.exit("expected one mesh, got %d" % len(meshes))
tile = meshes[0]
if len(tile.data.materials) != 1:
    sys.exit("expected one material, got %d" % len(tile.data.materials))
mat = tile.data.materials[0]
bsdf = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
if not bsdf:
    sys.exit("no Principled BSDF in the material")


def image_behind(socket, depth=0):
    """The image texture feeding a socket, through separate/normal-map nodes."""
    for link in socket.links:
        node = link.from_node
        if node.type == "TEX_IMAGE":
            return node.image.name if node.image else "(no image)"
        if depth < 4:
            for inp in node.inputs:
                found = image_behind(inp, depth + 1)
                if found:
                    return found
    return None


failed = []
for name in ("Base Color", "Metallic", "Roughness", "Normal", "Clearcoat", "Clearcoat Roughness",
             "Clearcoat Normal", "Specular"):
    img = image_behind(bsdf.inputs[name])
    if name == "Specular" and not img:
        print("%-20s %.3f (a value: converted by the importer)" %
              (name, bsdf.inputs[name].default_value))
        continue
    print("%-20s %s" % (name, img or "NOT LINKED"))
    if not img:
        failed.append(name)
if failed:
    sys.exit("not linked to a texture: " + ", ".join(failed))

scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = samples
scene.cycles.use_denoising = False  # Debian builds Blender without OpenImageDenoise
scene.render.resolution_x = scene.render.resolution_y = 512
scene.render.film_transparent = False
world = bpy.data.worlds.new("env")
scene.world = world
world.use_nodes = True
tex = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
tex.image = bpy.data.images.load(env_path)
world.node_tree.links.new(tex.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(cam)
el = math.radians(35)
cam.location = (0, -1.6 * math.cos(el), 1.6 * math.sin(el))  # glTF's Y up is Blender's Z up
cam.rotation_euler = (math.pi / 2 - el, 0, 0)
cam.data.lens = 50
scene.camera = cam
scene.render.filepath = out_path
bpy.ops.render.render(write_still=True)
print("rendered %s" % out_path)
