# SPDX-License-Identifier: MIT
"""Blender add-on: wet a material in place with wetgraph's wet_material graph.

A panel in the material's properties takes the image textures that feed the material's
Principled BSDF (base colour, roughness, normal through a Normal Map node, height through a
Displacement or Bump node, ambient occlusion), renders wet_material with the water level and the
main parameters of the panel, and wires the wet maps back: each dry image node's links are moved
to a node holding its wet map, and the water layer becomes the BSDF's clear coat (weight from the
water mask, the water surface's roughness and normal). The dry nodes stay in the tree, so
running again renders from them, and "Dry" puts the links back. Each material keeps one wetgraph
Graph (and its engine's cache) for the session: after a slider change only the nodes the change
reaches are computed again. The wetgraph Python module must be importable (installed by meson
into the site folder Debian's Blender reads).
"""
import os
import re
import time

import bpy
import numpy as np

bl_info = {
    "name": "wetgraph: wet material",
    "author": "wetgraph",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Material > Wetgraph",
    "description": "Wet a material up to a water level with wetgraph's wet_material graph",
    "category": "Material",
}

# what each role of the graph reads, the BSDF input it is found from, and the wet output
ROLES = ("basecolor", "roughness", "normal", "height", "ao")
NODE_PREFIX = "wetgraph "
# the wet maps wired back, with the colour space their Blender image is in
OUTPUTS = {
    "basecolor": "Linear", "roughness": "Non-Color", "normal": "Non-Color",
    "height": "Non-Color", "ao": "Non-Color", "watermask": "Non-Color",
    "waterroughness": "Non-Color", "waternormal": "Non-Color",
}
# an ambient occlusion map's node or image name: "AO" as a word of its own, or "occlusion"
AO_NAME = re.compile(r"(^|[^a-z])ao([^a-z]|$)|occlusion")

# per material name: the Graph (and so the engine and its cache) kept for the session
_sessions = {}


def _wetgraph():
    try:
        import wetgraph
    except ImportError as e:
        raise RuntimeError(
            "the wetgraph Python module is not importable from Blender's Python "
            f"({e}); install wetgraph (meson install) for Blender's python3") from None
    return wetgraph


class WetgraphSettings(bpy.types.PropertyGroup):
    water_level: bpy.props.FloatProperty(
        name="Water level", default=0.6, min=0.0, max=1.0,
        description="0 dry, 1 fully immersed (fraction of the height map's own range)")
    liquid: bpy.props.EnumProperty(
        name="Liquid", default="water",
        items=[(v, v.replace("_", " ").capitalize(), "") for v in
               ("water", "muddy_water", "tea", "milk", "blood", "oil")],
        description="Liquid preset: tint, absorption, scattering, IOR, meniscus width")
    porosity: bpy.props.FloatProperty(
        name="Porosity", default=1.0, min=0.0, max=1.0,
        description="How much the material soaks up liquid (0: metal, glazed tile; 1: stone)")
    height_scale: bpy.props.FloatProperty(
        name="Height scale", default=16.0, min=0.001, max=4096.0,
        description="Relief depth: the length (pixels of a 256-wide image) the height range is")
    puddle_density: bpy.props.FloatProperty(
        name="Puddles", default=0.45, min=0.0, max=1.0,
        description="How much of the low ground above the water level holds puddles")
    wet_roughness: bpy.props.FloatProperty(
        name="Wet roughness", default=0.3, min=0.0, max=1.0,
        description="Roughness cap in the wet zone (the water film)")
    water_roughness: bpy.props.FloatProperty(
        name="Water roughness", default=0.02, min=0.0, max=1.0,
        description="Roughness of the liquid surface (immersed parts, puddles)")
    resolution: bpy.props.IntProperty(
        name="Resolution", default=0, min=0, max=16384,
        description="Side of the wet maps in pixels (0: the base colour's own size)")
    # the dry image nodes found on the first run, so later runs read them, not the wet maps
    dry_basecolor: bpy.props.StringProperty()
    dry_roughness: bpy.props.StringProperty()
    dry_normal: bpy.props.StringProperty()
    dry_height: bpy.props.StringProperty()
    dry_ao: bpy.props.StringProperty()
    report: bpy.props.StringProperty(name="Last run")

    PARAMS = ("water_level", "liquid", "porosity", "height_scale", "puddle_density",
              "wet_roughness", "water_roughness")


def _principled(tree):
    out = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output),
               None) or next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"), None)
    if out and out.inputs["Surface"].is_linked:
        n = out.inputs["Surface"].links[0].from_node
        if n.type == "BSDF_PRINCIPLED":
            return n, out
    bsdf = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    return bsdf, out


def _upstream_images(socket, depth=4):
    """The image texture nodes feeding `socket`, nearest first, through at most `depth` nodes
    (not through the add-on's own nodes)."""
    found, seen, frontier = [], set(), [socket]
    for _ in range(depth):
        nxt = []
        for s in frontier:
            for link in s.links:
                n = link.from_node
                if n.name in seen or n.name.startswith(NODE_PREFIX):
                    continue
                seen.add(n.name)
                if n.type == "TEX_IMAGE" and n.image is not None:
                    found.append(n)
                else:
                    nxt.extend(n.inputs)
        frontier = nxt
    return found


def _is_ao(node):
    return any(AO_NAME.search(t.lower()) for t in (node.label, node.name, node.image.name))


def _find_dry(tree, settings):
    """{role: image node} of the material's dry maps (the ones found before, where they
    still exist)."""
    bsdf, out = _principled(tree)
    if bsdf is None:
        raise RuntimeError("the material has no Principled BSDF")
    nodes = {}
    for role in ROLES:
        name = getattr(settings, "dry_" + role)
        n = tree.nodes.get(name) if name else None
        if n is not None and n.type == "TEX_IMAGE" and n.image is not None:
            nodes[role] = n
    if len(nodes) == len(ROLES) or any(n.name.startswith(NODE_PREFIX) for n in tree.nodes):
        return nodes, bsdf, out
    base = [n for n in _upstream_images(bsdf.inputs["Base Color"]) if not _is_ao(n)]
    if base:
        nodes.setdefault("basecolor", base[0])
    rough = _upstream_images(bsdf.inputs["Roughness"])
    if rough:
        nodes.setdefault("roughness", rough[0])
    for n in _upstream_images(bsdf.inputs["Normal"], depth=3):
        if not _is_ao(n):
            # through a Normal Map node it is the normal; through a Bump node, the height
            via_bump = any(l.to_node.type == "BUMP" for o in n.outputs for l in o.links)
            nodes.setdefault("height" if via_bump else "normal", n)
    if out is not None and out.inputs["Displacement"].is_linked:
        h = _upstream_images(out.inputs["Displacement"])
        if h:
            nodes.setdefault("height", h[0])
    ao = [n for n in tree.nodes if n.type == "TEX_IMAGE" and n.image is not None and _is_ao(n)]
    if ao:
        nodes.setdefault("ao", ao[0])
    return nodes, bsdf, out


def _image_input(img):
    """What the graph reads for a Blender image: its file when it has one on disk, unchanged,
    else its pixels (8-bit images as their codes, float ones as their linear values), rows top
    first."""
    if img.source == "FILE" and not img.packed_file and not img.is_dirty:
        path = bpy.path.abspath(img.filepath, library=img.library)
        if os.path.isfile(path):
            return path
    w, h = img.size
    if w == 0 or h == 0:
        raise RuntimeError(f"image '{img.name}' has no pixels")
    px = np.empty(w * h * img.channels, np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, img.channels)[::-1]
    if img.channels == 2:
        px = px[..., :1]
    if img.is_float:
        return np.ascontiguousarray(px)
    return np.ascontiguousarray(np.rint(px * 255.0).astype(np.uint8))


def _store_image(name, array, colorspace):
    """A float Blender image named `name` holding the map (rows bottom first, as Blender's)."""
    h, w = array.shape[:2]
    img = bpy.data.images.get(name)
    if img is not None and (tuple(img.size) != (w, h) or not img.is_float):
        bpy.data.images.remove(img)
        img = None
    if img is None:
        img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    try:
        img.colorspace_settings.name = colorspace
    except TypeError:  # later Blenders name linear "Linear Rec.709"
        img.colorspace_settings.name = "Linear Rec.709"
    if array.ndim == 2:
        rgba = np.empty((h, w, 4), np.float32)
        rgba[..., :3] = array[..., None]
        rgba[..., 3] = 1.0
    else:
        rgba = array
    img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1], dtype=np.float32).ravel())
    img.update()
    try:
        img.pack()  # kept in the .blend file
    except RuntimeError:
        pass
    return img


def _wet_node(tree, output, image, near):
    name = NODE_PREFIX + output
    n = tree.nodes.get(name)
    if n is None:
        n = tree.nodes.new("ShaderNodeTexImage")
        n.name = n.label = name
        n.location = (near.location.x - 300, near.location.y - 40) if near else (-900, 0)
    n.image = image
    return n


def _normal_map(tree, name, colour_node, near):
    n = tree.nodes.get(NODE_PREFIX + name)
    if n is None:
        n = tree.nodes.new("ShaderNodeNormalMap")
        n.name = n.label = NODE_PREFIX + name
        n.location = (near.location.x - 220, near.location.y - 500)
    tree.links.new(colour_node.outputs["Color"], n.inputs["Color"])
    return n


def _move_links(tree, src, dst):
    """Every link leaving `src` leaves `dst` instead (same output socket names)."""
    for o in src.outputs:
        for link in list(o.links):
            to = link.to_socket
            tree.links.remove(link)
            tree.links.new(dst.outputs[o.name], to)


def wet(material, context=None):
    """Render the wet maps of `material` from its dry image textures and wire them in. Returns
    the render's stats (wetgraph.Graph.stats)."""
    wetgraph = _wetgraph()
    s = material.wetgraph
    tree = material.node_tree
    if tree is None:
        raise RuntimeError(f"material '{material.name}' does not use nodes")
    dry, bsdf, _ = _find_dry(tree, s)
    for role in ("basecolor", "height"):
        if role not in dry:
            raise RuntimeError(
                f"material '{material.name}': no {role} image found (base colour: an image "
                "texture into the Principled BSDF's Base Color; height: into a Displacement "
                "node's Height at the Material Output, or a Bump node's Height)")
    for role, node in dry.items():
        setattr(s, "dry_" + role, node.name)

    g = _sessions.get(material.name)
    if g is None:
        g = _sessions[material.name] = wetgraph.Graph("wet_material")
    for role in ROLES:
        g.set_input(role, _image_input(dry[role].image) if role in dry else None)
    g.size = (s.resolution, s.resolution) if s.resolution else None
    for p in WetgraphSettings.PARAMS:
        v = getattr(s, p)
        # Blender keeps float properties in single precision: 0.7 is 0.699999988...; give the
        # shortest text of that float, the value the user typed
        g.set(p, str(np.float32(v)) if isinstance(v, float) else v)
    g.set(normal_format="opengl")  # Blender's normal maps: green up

    wm = context.window_manager if context else None
    if wm:
        wm.progress_begin(0, 1)
    t0 = time.monotonic()
    try:
        maps = g.render(list(OUTPUTS), progress=(lambda d, t, n: wm.progress_update(d / t))
                        if wm else None)
    finally:
        if wm:
            wm.progress_end()
    seconds = time.monotonic() - t0

    images = {k: _store_image(f"{material.name} wet {k}", v, OUTPUTS[k]) for k, v in maps.items()}
    wet_nodes = {}
    for k, img in images.items():
        wet_nodes[k] = _wet_node(tree, k, img, dry.get(k, bsdf))
    for role, node in dry.items():
        _move_links(tree, node, wet_nodes[role])
    if "normal" not in dry:  # the wet film's relief, also on a material without a normal map
        nm = _normal_map(tree, "normal map", wet_nodes["normal"], bsdf)
        target = bsdf.inputs["Normal"]
        if target.is_linked and target.links[0].from_node.type == "BUMP":
            target = target.links[0].from_node.inputs["Normal"]  # under the bump, not instead
        tree.links.new(nm.outputs["Normal"], target)
    if "roughness" not in dry:
        tree.links.new(wet_nodes["roughness"].outputs["Color"], bsdf.inputs["Roughness"])
    # the water layer as the clear coat
    tree.links.new(wet_nodes["watermask"].outputs["Color"], bsdf.inputs["Clearcoat"])
    tree.links.new(wet_nodes["waterroughness"].outputs["Color"],
                   bsdf.inputs["Clearcoat Roughness"])
    cn = _normal_map(tree, "water normal map", wet_nodes["waternormal"], bsdf)
    tree.links.new(cn.outputs["Normal"], bsdf.inputs["Clearcoat Normal"])

    st = g.stats
    s.report = (f"{st['evaluated']} of {len(st['nodes'])} nodes computed, {seconds * 1000:.0f} ms, "
                f"{maps['basecolor'].shape[1]}x{maps['basecolor'].shape[0]}")
    return st


def dry(material):
    """Put the dry maps back: the wet nodes' links go back to the dry image nodes and the clear
    coat is unlinked."""
    s = material.wetgraph
    tree = material.node_tree
    for role in ROLES:
        node = tree.nodes.get(getattr(s, "dry_" + role))
        wet_node = tree.nodes.get(NODE_PREFIX + role)
        if node is not None and wet_node is not None:
            _move_links(tree, wet_node, node)
    bsdf, _ = _principled(tree)
    for name in ("Clearcoat", "Clearcoat Roughness", "Clearcoat Normal"):
        for link in list(bsdf.inputs[name].links):
            tree.links.remove(link)
    for name in ("normal map",):  # the relief added to a material without a normal map
        n = tree.nodes.get(NODE_PREFIX + name)
        if n is not None:
            for link in list(n.outputs["Normal"].links):
                tree.links.remove(link)
    s.report = "dry"


class WETGRAPH_OT_wet_material(bpy.types.Operator):
    """Render the wet maps of the active material from its image textures and wire them in"""
    bl_idname = "wetgraph.wet_material"
    bl_label = "Wet"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        m = getattr(context, "material", None)
        return m is not None and m.use_nodes

    def execute(self, context):
        try:
            wet(context.material, context)
        except Exception as e:  # wetgraph.Error carries the graph's file:line text
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, "wetgraph: " + context.material.wetgraph.report)
        return {"FINISHED"}


class WETGRAPH_OT_dry_material(bpy.types.Operator):
    """Wire the dry image textures back into the active material"""
    bl_idname = "wetgraph.dry_material"
    bl_label = "Dry"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        m = getattr(context, "material", None)
        return m is not None and m.use_nodes and m.wetgraph.dry_basecolor != ""

    def execute(self, context):
        dry(context.material)
        return {"FINISHED"}


class WETGRAPH_PT_material(bpy.types.Panel):
    bl_label = "Wetgraph"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return getattr(context, "material", None) is not None

    def draw(self, context):
        s = context.material.wetgraph
        col = self.layout.column()
        for p in WetgraphSettings.PARAMS:
            col.prop(s, p)
        col.prop(s, "resolution")
        row = col.row()
        row.operator(WETGRAPH_OT_wet_material.bl_idname)
        row.operator(WETGRAPH_OT_dry_material.bl_idname)
        if s.report:
            col.label(text=s.report)


CLASSES = (WetgraphSettings, WETGRAPH_OT_wet_material, WETGRAPH_OT_dry_material,
           WETGRAPH_PT_material)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Material.wetgraph = bpy.props.PointerProperty(type=WetgraphSettings)


def unregister():
    del bpy.types.Material.wetgraph
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
    _sessions.clear()
