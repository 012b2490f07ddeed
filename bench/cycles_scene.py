# SPDX-License-Identifier: MIT
# Renders, in Blender Cycles, the scene the `preview` node draws from the same maps, so that
# bench/cycles_compare.py can hold one against the other (bench/run_cycles.sh drives both).
# Run headless: blender -b --factory-startup -P bench/cycles_scene.py -- MAPS ENV OUT.exr
#   [elevation azimuth fov zoom height_scale env_rotation size samples]
# MAPS is the folder bench/cycles_scene.wetgraph wrote (cycles_scene_<map>.png). The scene:
# - the tile is the square [0,1]² of the plane z = 0 (x right, y towards the top of the maps),
#   a grid mesh with a vertex per texel corner displaced to z = height_scale·(h − 1) from
#   underheight (bilinear between texel centres, wrapping), as the preview's parallax search
#   puts the relief below the plane (height_scale in tile widths);
# - the material (brdf=preview, the default) is the preview's model: Principled BSDF's specular
#   lobe (Multiscatter GGX, Fresnel per microfacet, specular 0.5: F0 0.04, or the metal's
#   colour) plus Lambert diffuse weighted by 1 − E, E the lobe's albedo from the preview's own
#   split-sum table; brdf=principled is Principled BSDF as it is (Disney diffuse, not reduced by
#   what the lobe reflects). Both read the base colour (sRGB PNG), roughness, metallic and the
#   normal map in object space, which is the preview's frame (the maps' tangent space of a flat
#   tile): the relief's geometry gives parallax and occlusion, its shading normals come from the
#   map as in the preview;
# - the water is a second grid from waterheight, kept where watermask > 0, a Glass BSDF of
#   IOR 1.33 (GGX, waterroughness, object-space waternormal) mixed with a
#   Transparent BSDF by the mask: clear water, as the preview's default;
# - the world is the HDR through Blender's equirectangular mapping, which is the preview's
#   (u = 0.5 − φ/2π, φ from +x towards +y), turned by env_rotation about z;
# - the camera is the preview's: at elevation/azimuth around the tile's centre, at the distance
#   where the tile's width fills 1/zoom of the vertical field of view fov, looking at the centre,
#   its right vector (cos az, sin az, 0).
# The result is linear radiance (view transform Standard, no clamping, float EXR).
import math
import os
import sys

import bpy
import numpy as np

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
opts = {"elevation": "50", "azimuth": "20", "fov": "35", "zoom": "1", "height_scale": "0.0625",
        "env_rotation": "0", "size": "512", "samples": "256", "brdf": "preview",
        "layers": "single"}
for a in argv[3:]:
    k, eq, v = a.partition("=")
    if not eq or k not in opts:
        sys.exit("cycles_scene.py: %s: expected one of %s as NAME=VALUE" % (a, ", ".join(opts)))
    opts[k] = v
if len(argv) < 3 or opts["brdf"] not in ("preview", "principled") or opts["layers"] not in (
        "single", "two"):
    sys.exit("usage: blender -b -P cycles_scene.py -- MAPS ENV OUT.exr [NAME=VALUE...] (%s; "
             "brdf preview or principled, layers single or two)" % ", ".join(opts))
maps, env_path, out_path = argv[0], argv[1], argv[2]
try:
    elevation, azimuth, fov, zoom, height_scale, env_rotation, size, samples = (
        float(opts[k]) for k in ("elevation", "azimuth", "fov", "zoom", "height_scale",
                                 "env_rotation", "size", "samples"))
except ValueError as e:
    sys.exit("cycles_scene.py: %s" % e)
two_layers = opts["layers"] == "two"


def map_path(name):
    p = os.path.join(maps, "cycles_scene_%s.png" % name)
    if not os.path.isfile(p):
        sys.exit("%s: missing (render bench/cycles_scene.wetgraph into %s first)" % (p, maps))
    return p


def load(name, colour=False):
    img = bpy.data.images.load(map_path(name), check_existing=True)
    img.colorspace_settings.name = "sRGB" if colour else "Non-Color"
    return img


def gray_array(name):
    """The map's first channel as a float array, row 0 at the bottom (Blender's order)."""
    img = load(name)
    w, h = img.size
    a = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(a)
    return a.reshape(h, w, 4)[:, :, 0]


def grid(name, values, keep=None):
    """A mesh over the tile with a vertex at every texel corner, z from values (texel centres,
    averaged to the corners with wrapping, i.e. bilinear), faces where keep is true."""
    h, w = values.shape
    c = 0.25 * (values + np.roll(values, 1, 0) + np.roll(values, 1, 1)
                + np.roll(np.roll(values, 1, 0), 1, 1))
    c = np.vstack([c, c[:1]])
    c = np.hstack([c, c[:, :1]])
    ys, xs = np.mgrid[0:h + 1, 0:w + 1]
    verts = np.stack([xs / w, ys / h, height_scale * (c - 1)], -1).reshape(-1, 3)
    i = (ys[:-1, :-1] * (w + 1) + xs[:-1, :-1]).ravel()
    quads = np.stack([i, i + 1, i + w + 2, i + w + 1], -1)
    if keep is not None:
        quads = quads[keep.ravel()]
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(verts))
    mesh.vertices.foreach_set("co", verts.astype(np.float32).ravel())
    mesh.loops.add(quads.size)
    mesh.loops.foreach_set("vertex_index", quads.astype(np.int32).ravel())
    mesh.polygons.add(len(quads))
    mesh.polygons.foreach_set("loop_start", (np.arange(len(quads)) * 4).astype(np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(len(quads), 4, dtype=np.int32))
    uv = mesh.uv_layers.new(name="UVMap")
    uv.data.foreach_set("uv", verts[quads.ravel(), :2].astype(np.float32).ravel())
    mesh.update()
    mesh.validate()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def tex(nodes, links, name, colour=False):
    n = nodes.new("ShaderNodeTexImage")
    n.image = load(name, colour)
    n.interpolation = "Linear"
    n.extension = "REPEAT"
    return n


def object_normal(nodes, links, name):
    t = tex(nodes, links, name)
    nm = nodes.new("ShaderNodeNormalMap")
    nm.space = "OBJECT"
    links.new(t.outputs["Color"], nm.inputs["Color"])
    return nm.outputs["Normal"]


for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = int(samples)
scene.cycles.use_denoising = False
scene.cycles.use_adaptive_sampling = False
scene.cycles.sample_clamp_direct = 0
scene.cycles.sample_clamp_indirect = 0
scene.cycles.max_bounces = 16
scene.cycles.transmission_bounces = 16
scene.cycles.glossy_bounces = 16
scene.cycles.diffuse_bounces = 8
scene.cycles.caustics_reflective = True
scene.cycles.caustics_refractive = True
scene.cycles.blur_glossy = 0
scene.cycles.seed = 1
scene.render.resolution_x = scene.render.resolution_y = int(size)
scene.render.resolution_percentage = 100
scene.render.film_transparent = False
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure = 0
scene.view_settings.gamma = 1
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.image_settings.color_mode = "RGB"

# the material
prefix = "under" if two_layers else ""
floor = grid("tile", gray_array(prefix + "height"))
mat = bpy.data.materials.new("material")
mat.use_nodes = True
nodes, links = mat.node_tree.nodes, mat.node_tree.links
base = tex(nodes, links, prefix + "basecolor", True).outputs["Color"]
rough = tex(nodes, links, prefix + "roughness").outputs["Color"]
metal = tex(nodes, links, prefix + "metallic").outputs["Color"]
normal = object_normal(nodes, links, prefix + "normal")
bsdf = nodes["Principled BSDF"]
if opts["brdf"] == "principled":
    bsdf.distribution = "MULTI_GGX"
    bsdf.inputs["Specular"].default_value = 0.5
    links.new(base, bsdf.inputs["Base Color"])
    links.new(rough, bsdf.inputs["Roughness"])
    links.new(metal, bsdf.inputs["Metallic"])
    links.new(normal, bsdf.inputs["Normal"])
    shader = bsdf.outputs["BSDF"]
else:
    # the preview's model: the specular lobe is Principled's (GGX with Fresnel per microfacet,
    # multiple scattering, F0 0.04 or the metal's colour) with its diffuse turned off (base
    # colour × metallic), plus Lambert diffuse of colour dc · (1 − Fss − Ems·Fms), from the
    # preview's own split-sum table (the atlas's block 7, read at u = n·v, v = roughness), so
    # what the lobe reflects is not given to the diffuse layer as in nodes/preview.c
    bsdf.distribution = "MULTI_GGX"
    bsdf.inputs["Specular"].default_value = 0.5
    links.new(rough, bsdf.inputs["Roughness"])
    links.new(metal, bsdf.inputs["Metallic"])
    links.new(normal, bsdf.inputs["Normal"])

    def node_math(op, a, b=None):
        n = nodes.new("ShaderNodeMath")
        n.operation = op
        for i, x in enumerate((a, b)):
            if x is None:
                continue
            if isinstance(x, (int, float)):
                n.inputs[i].default_value = x
            else:
                links.new(x, n.inputs[i])
        return n.outputs[0]

    def vmath(op, a, b):
        n = nodes.new("ShaderNodeVectorMath")
        n.operation = op
        for i, x in enumerate((a, b)):
            if isinstance(x, (int, float)):
                n.inputs[i].default_value = (x, x, x)
            else:
                links.new(x, n.inputs[i])
        return n.outputs[0]

    links.new(vmath("MULTIPLY", base, metal), bsdf.inputs["Base Color"])
    # n·v at the shading normal: Layer Weight's facing is 1 − |n·v|
    lw = nodes.new("ShaderNodeLayerWeight")
    links.new(normal, lw.inputs["Normal"])
    nv = node_math("SUBTRACT", 1.0, lw.outputs["Facing"])
    def texel_clamp(x):  # keep the bilinear read inside the table's 128 texels
        return node_math("MINIMUM", node_math("MAXIMUM", x, 0.5 / 128), 1 - 0.5 / 128)

    u = node_math("ADD", 0.5, node_math("MULTIPLY", texel_clamp(nv), 0.25))
    v = node_math("SUBTRACT", 0.25, node_math("MULTIPLY", texel_clamp(rough), 0.25))
    xyz = nodes.new("ShaderNodeCombineXYZ")
    links.new(u, xyz.inputs["X"])
    links.new(v, xyz.inputs["Y"])
    lut = nodes.new("ShaderNodeTexImage")
    lut.image = bpy.data.images.load(os.path.join(maps, "cycles_scene_atlas.exr"))
    lut.image.colorspace_settings.name = "Non-Color"
    lut.interpolation = "Linear"
    lut.extension = "EXTEND"
    links.new(xyz.outputs["Vector"], lut.inputs["Vector"])
    sep = nodes.new("ShaderNodeSeparateColor")
    links.new(lut.outputs["Color"], sep.inputs["Color"])
    A, B = sep.outputs[0], sep.outputs[1]
    fss = node_math("ADD", node_math("MULTIPLY", A, 0.04), B)  # the dielectric's F0 0.04
    ems = node_math("SUBTRACT", 1.0, node_math("ADD", A, B))
    favg = 0.04 + 0.96 * 0.0539354  # the preview's F_avg (nodes/preview.c, W_AVG)
    fms = node_math("DIVIDE", node_math("MULTIPLY", fss, favg),
               node_math("SUBTRACT", 1.0, node_math("MULTIPLY", ems, favg)))
    e = node_math("ADD", fss, node_math("MULTIPLY", fms, ems))
    kd = node_math("MULTIPLY", node_math("SUBTRACT", 1.0, e), node_math("SUBTRACT", 1.0, metal))
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    links.new(vmath("MULTIPLY", base, kd), diffuse.inputs["Color"])
    links.new(normal, diffuse.inputs["Normal"])
    add = nodes.new("ShaderNodeAddShader")
    links.new(bsdf.outputs["BSDF"], add.inputs[0])
    links.new(diffuse.outputs["BSDF"], add.inputs[1])
    shader = add.outputs["Shader"]
links.new(shader, nodes["Material Output"].inputs["Surface"])
floor.data.materials.append(mat)

# the water
mask = gray_array("watermask") if two_layers else np.zeros((1, 1))
wet = mask > 0
keep = wet.copy()  # face (r, c) holds texel (r, c); one texel more all round
for axis in (0, 1):
    for step in (-1, 1):
        keep |= np.roll(wet, step, axis)
if two_layers and keep.any():
    water = grid("water", gray_array("waterheight"), keep)
    wm = bpy.data.materials.new("water")
    wm.use_nodes = True
    nodes, links = wm.node_tree.nodes, wm.node_tree.links
    for n in list(nodes):
        if n.type != "OUTPUT_MATERIAL":
            nodes.remove(n)
    glass = nodes.new("ShaderNodeBsdfGlass")
    # single-scattering GGX: at the water's roughness (0.02) light scattered between microfacets
    # is negligible, while Blender 3.4's Multiscatter GGX glass reflects less than half of what
    # the Fresnel equations give seen low (the immersed zone from 20° under the Venice sunset,
    # over a black floor: 0.036 with Multiscatter GGX, 0.075 with Sharp glass, 0.076 with GGX)
    glass.distribution = "GGX"
    glass.inputs["IOR"].default_value = 1.33
    links.new(tex(nodes, links, "waterroughness").outputs["Color"], glass.inputs["Roughness"])
    links.new(object_normal(nodes, links, "waternormal"), glass.inputs["Normal"])
    clear = nodes.new("ShaderNodeBsdfTransparent")
    mix = nodes.new("ShaderNodeMixShader")
    links.new(tex(nodes, links, "watermask").outputs["Color"], mix.inputs["Fac"])
    links.new(clear.outputs["BSDF"], mix.inputs[1])
    links.new(glass.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], nodes["Material Output"].inputs["Surface"])
    water.data.materials.append(wm)

# the environment
world = bpy.data.worlds.new("env")
scene.world = world
world.use_nodes = True
nodes, links = world.node_tree.nodes, world.node_tree.links
env = nodes.new("ShaderNodeTexEnvironment")
env.image = bpy.data.images.load(os.path.abspath(env_path))
env.interpolation = "Linear"
env.projection = "EQUIRECTANGULAR"
coord = nodes.new("ShaderNodeTexCoord")
mapping = nodes.new("ShaderNodeMapping")
mapping.vector_type = "POINT"
mapping.inputs["Rotation"].default_value = (0, 0, math.radians(env_rotation))
links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
links.new(mapping.outputs["Vector"], env.inputs["Vector"])
links.new(env.outputs["Color"], nodes["Background"].inputs["Color"])
nodes["Background"].inputs["Strength"].default_value = 1
world.cycles.sampling_method = "MANUAL"
world.cycles.sample_map_resolution = 1024

# the camera, as nodes/preview.c sets it up
el, az = math.radians(elevation), math.radians(azimuth)
back = np.array([math.sin(az) * math.cos(el), -math.cos(az) * math.cos(el), math.sin(el)])
right = np.array([math.cos(az), math.sin(az), 0.0])
up = np.cross(back, right)
up /= np.linalg.norm(up)
tan_half = math.tan(math.radians(fov) / 2)
dist = 0.5 / zoom / tan_half
pos = np.array([0.5, 0.5, 0.0]) + back * dist
cam_data = bpy.data.cameras.new("camera")
cam_data.sensor_fit = "VERTICAL"
cam_data.angle_y = math.radians(fov)
cam_data.clip_start = 1e-3
cam_data.clip_end = 100
cam = bpy.data.objects.new("camera", cam_data)
scene.collection.objects.link(cam)
import mathutils  # noqa: E402 (Blender's own module)

m = mathutils.Matrix.Identity(4)
for r in range(3):
    m[r][0], m[r][1], m[r][2], m[r][3] = right[r], up[r], back[r], pos[r]
cam.matrix_world = m
scene.camera = cam

scene.render.filepath = os.path.abspath(out_path)
bpy.ops.render.render(write_still=True)
