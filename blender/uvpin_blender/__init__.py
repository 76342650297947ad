"""uvpin for Blender: "uvpin: Solve pinned (fold-free)" in the UV editor,
and "uvpin: Photo onto head" in the 3D view's Object menu.

The active mesh's pinned UVs are the landmarks, at their current positions.
uvpin lays out the UV island holding them again so that every pin lands
exactly where it is, no triangle folds, and (with the free boundary) the
island stays one-to-one and clear of the other islands. Every other UV keeps
its value. One undo step; the status bar says reached or partial.
"""

from __future__ import annotations

import bpy
import numpy as np

BOUNDARIES = [
    ("FREE", "Free", "The island's outline moves freely inside the region, clear of other islands"),
    ("SQUARE", "Square", "The island's outer loop on the region's square (the paper's bar-net)"),
    ("AUTO", "Auto", "uvpin's default rule"),
]


def mesh_arrays(mesh: bpy.types.Mesh, uv_layer) -> dict:
    """The mesh as uvpin sees it: one vertex per distinct (Blender vertex,
    UV), triangles from Blender's own triangulation.

    Blender's UVs have v up, uvpin's (glTF's) v down. Instead of flipping v,
    which would round every float32 UV once each way, the triangles are
    handed over with their winding reversed: the mirror image of the same
    problem, so the pins and the untouched islands keep their bits and the
    orientation uvpin keeps is the one Blender draws."""
    n_loops = len(mesh.loops)
    co = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", co)
    loop_vertex = np.empty(n_loops, dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", loop_vertex)
    loop_uv = np.empty(n_loops * 2, dtype=np.float32)
    uv_layer.uv.foreach_get("vector", loop_uv)
    loop_uv = loop_uv.reshape(-1, 2)
    pinned = np.zeros(n_loops, dtype=bool)
    if len(uv_layer.pin) == n_loops:
        uv_layer.pin.foreach_get("value", pinned)
    mesh.calc_loop_triangles()
    tri_loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", tri_loops)
    keys = np.c_[loop_vertex, loop_uv.view(np.int32)]
    unique, first, corner = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    corner = corner.reshape(-1)
    return {
        "vertices": co.reshape(-1, 3)[unique[:, 0]],
        "faces": corner[tri_loops].reshape(-1, 3)[:, ::-1].copy(),
        "uvs": loop_uv[first].astype(np.float64),
        "corner": corner,
        "loop_uv": loop_uv,
        "pinned": pinned,
    }


def pins_of(arrays: dict) -> dict[int, tuple[float, float]]:
    """Each pinned corner's uvpin vertex, held where it is."""
    ids = np.unique(arrays["corner"][arrays["pinned"]])
    return {int(i): (float(arrays["uvs"][i, 0]), float(arrays["uvs"][i, 1])) for i in ids}


def write_back(mesh: bpy.types.Mesh, uv_layer, arrays: dict, uv: np.ndarray) -> int:
    """Writes the new UVs of the corners that changed; returns their count.
    uvpin's UVs are float32 values, as Blender stores them: the corners uvpin
    left alone keep their bits."""
    new = uv.astype(np.float32)[arrays["corner"]]
    old = arrays["loop_uv"]
    changed = np.any(new.view(np.int32) != old.view(np.int32), axis=1)
    out = old.copy()
    out[changed] = new[changed]
    uv_layer.uv.foreach_set("vector", out.ravel())
    mesh.update()
    return int(changed.sum())


def solved(operator, solve):
    """`solve()`'s result, or None with the reason in the status bar (bad
    input, or nothing laid out)."""
    import uvpin

    try:
        result = solve()
    except uvpin.InputError as e:
        operator.report({"ERROR"}, f"uvpin: {e}")
        return None
    if result.uv is None:
        operator.report({"ERROR"}, f"uvpin: nothing laid out: {result.report.get('message')}")
        return None
    return result


def region_of(settings) -> tuple[float, float, float, float]:
    """The region (u min, v min, u max, v max), in Blender's UV coordinates
    as uvpin is given them."""
    u0, v0, u1, v1 = settings
    return (min(u0, u1), min(v0, v1), max(u0, u1), max(v0, v1))


class UVPIN_OT_solve_pinned(bpy.types.Operator):
    """Lay out the island holding the pinned UVs again: every pin exact, no fold"""

    bl_idname = "uv.uvpin_solve_pinned"
    bl_label = "uvpin: Solve pinned (fold-free)"
    bl_options = {"REGISTER", "UNDO"}

    boundary: bpy.props.EnumProperty(name="Boundary", items=BOUNDARIES, default="FREE")
    region: bpy.props.FloatVectorProperty(
        name="Region",
        description="Where the island may go: u min, v min, u max, v max",
        size=4,
        default=(0.0, 0.0, 1.0, 1.0),
        min=0.0,
        max=1.0,
    )

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH"

    def execute(self, context):
        obj = context.active_object
        editing = obj.mode == "EDIT"
        if editing:
            bpy.ops.object.mode_set(mode="OBJECT")
        try:
            return self.solve(obj.data)
        finally:
            if editing:
                bpy.ops.object.mode_set(mode="EDIT")

    def solve(self, mesh):
        try:
            import uvpin
        except ImportError as e:
            self.report({"ERROR"}, f"uvpin: the uvpin wheel is not installed ({e})")
            return {"CANCELLED"}
        uv_layer = mesh.uv_layers.active
        if uv_layer is None:
            self.report({"ERROR"}, "uvpin: the mesh has no UV map: unwrap it and pin some UVs first")
            return {"CANCELLED"}
        arrays = mesh_arrays(mesh, uv_layer)
        pins = pins_of(arrays)
        if not pins:
            self.report({"ERROR"}, "uvpin: no pinned UVs: pin the landmarks (P in the UV editor) first")
            return {"CANCELLED"}
        result = solved(
            self,
            lambda: uvpin.solve(
                arrays["vertices"],
                arrays["faces"],
                pins,
                uvs=arrays["uvs"],
                boundary=self.boundary.lower(),
                region=region_of(self.region) if self.boundary == "FREE" else None,
            ),
        )
        if result is None:
            return {"CANCELLED"}
        changed = write_back(mesh, uv_layer, arrays, result.uv)
        worst = float(np.nanmax(result.residuals))
        words = f"uvpin: {result.status}, {len(pins)} pins, max residual {worst:.2e}, {changed} UVs moved"
        if result.status == "reached":
            self.report({"INFO"}, words)
        else:
            short = [c for c in result.report["constraints"] if not c["reached"]]
            self.report({"WARNING"}, f"{words}; {len(short)} pins short: {result.report.get('message', '')}")
        return {"FINISHED"}


PHOTO_INSTALL = (
    "uvpin: the photo step needs MediaPipe 0.10.21 in Blender's Python: "
    "{python} -m pip install mediapipe==0.10.21"
)


def triangles_of(mesh: bpy.types.Mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (n, 3), Blender's own triangulation (m, 3) and the loop of
    each triangle corner (m, 3)."""
    co = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", co)
    mesh.calc_loop_triangles()
    m = len(mesh.loop_triangles)
    tris = np.empty(m * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", tris)
    loops = np.empty(m * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    return co.reshape(-1, 3), tris.reshape(-1, 3), loops.reshape(-1, 3)


def photo_material(name: str, image: bpy.types.Image, uv_map: str) -> bpy.types.Material:
    """A material showing `image` through the UV map `uv_map`."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    bsdf = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    uv = nodes.new("ShaderNodeUVMap")
    uv.uv_map = uv_map
    links.new(uv.outputs["UV"], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], bsdf.inputs["Base Color"])
    return material


class UVPIN_OT_photo(bpy.types.Operator):
    """Lay a face photo onto the active head mesh: its landmarks found on the photo and on the mesh, exact and fold-free"""

    bl_idname = "object.uvpin_photo"
    bl_label = "uvpin: Photo onto head"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(name="Photo", subtype="FILE_PATH")
    filter_image: bpy.props.BoolProperty(default=True, options={"HIDDEN"})
    uv_map: bpy.props.StringProperty(name="UV map", default="uvpin photo")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH"

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        import sys

        try:
            from uvpin import photo
            import uvpin

            photo._mediapipe()
        except ImportError as e:
            self.report({"ERROR"}, f"{PHOTO_INSTALL.format(python=sys.executable)} ({e})")
            return {"CANCELLED"}
        obj = context.active_object
        if obj.mode != "OBJECT":
            bpy.ops.object.mode_set(mode="OBJECT")
        mesh = obj.data
        vertices, faces, loops = triangles_of(mesh)
        try:
            pins = photo.photo_pins(vertices, faces, bpy.path.abspath(self.filepath))
        except uvpin.InputError as e:
            self.report({"ERROR"}, f"uvpin: {e}")
            return {"CANCELLED"}
        result = solved(self, lambda: uvpin.solve(vertices, faces, (pins.ids, pins.uv)))
        if result is None:
            return {"CANCELLED"}
        corner = result.corner_uv if result.corner_uv is not None else result.uv[faces]
        layer = mesh.uv_layers.get(self.uv_map) or mesh.uv_layers.new(name=self.uv_map)
        loop_uv = np.zeros((len(mesh.loops), 2), dtype=np.float32)
        # glTF's v runs down the image, Blender's up.
        loop_uv[loops.ravel()] = np.c_[corner[..., 0].ravel(), 1.0 - corner[..., 1].ravel()]
        layer.uv.foreach_set("vector", loop_uv.ravel())
        mesh.uv_layers.active = layer
        image = bpy.data.images.load(bpy.path.abspath(self.filepath), check_existing=True)
        obj.data.materials.clear()
        obj.data.materials.append(photo_material("uvpin photo", image, layer.name))
        mesh.update()
        words = f"uvpin: {result.status}, {len(pins.ids)} landmarks from the photo, {len(pins.dropped)} dropped"
        self.report({"INFO"} if result.status == "reached" else {"WARNING"}, words)
        return {"FINISHED"}


def object_menu_entry(self, context):
    self.layout.operator(UVPIN_OT_photo.bl_idname)


class UVPIN_PT_panel(bpy.types.Panel):
    bl_label = "uvpin"
    bl_space_type = "IMAGE_EDITOR"
    bl_region_type = "UI"
    bl_category = "uvpin"

    def draw(self, context):
        scene = context.scene
        layout = self.layout
        layout.prop(scene, "uvpin_boundary")
        if scene.uvpin_boundary == "FREE":
            layout.prop(scene, "uvpin_region")
        op = layout.operator(UVPIN_OT_solve_pinned.bl_idname)
        op.boundary = scene.uvpin_boundary
        op.region = scene.uvpin_region


def menu_entry(self, context):
    self.layout.operator(UVPIN_OT_solve_pinned.bl_idname)


CLASSES = (UVPIN_OT_solve_pinned, UVPIN_OT_photo, UVPIN_PT_panel)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.uvpin_boundary = bpy.props.EnumProperty(name="Boundary", items=BOUNDARIES, default="FREE")
    bpy.types.Scene.uvpin_region = bpy.props.FloatVectorProperty(
        name="Region", size=4, default=(0.0, 0.0, 1.0, 1.0), min=0.0, max=1.0
    )
    bpy.types.IMAGE_MT_uvs.append(menu_entry)
    bpy.types.VIEW3D_MT_object.append(object_menu_entry)


def unregister():
    bpy.types.VIEW3D_MT_object.remove(object_menu_entry)
    bpy.types.IMAGE_MT_uvs.remove(menu_entry)
    del bpy.types.Scene.uvpin_region
    del bpy.types.Scene.uvpin_boundary
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
