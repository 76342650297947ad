"""Runs inside Blender's Python (the `bpy` wheel, with MediaPipe): installs
the extension zip argv[1], builds the head argv[2] as a Blender mesh, runs
"uvpin: Photo onto head" with the photo argv[3], and prints what Blender's
own data says afterwards as one JSON line."""

from __future__ import annotations

import json
import sys

import bpy
import numpy as np


def main(zip_path: str, head: str, picture: str) -> dict:
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    import uvpin
    from uvpin import photo

    arrays = uvpin.read_mesh(head)
    mesh = bpy.data.meshes.new("head")
    mesh.from_pydata(arrays.vertices.tolist(), [], arrays.faces.tolist())
    mesh.update()
    obj = bpy.data.objects.new("head", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    result = bpy.ops.object.uvpin_photo(filepath=picture)
    layer = mesh.uv_layers["uvpin photo"]
    loop_uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
    layer.uv.foreach_get("vector", loop_uv)
    loop_uv = loop_uv.reshape(-1, 2)
    loop_vertex = np.empty(len(mesh.loops), dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", loop_vertex)
    # The same detection, as pins: where each landmark's loops must be.
    pins = photo.photo_pins(arrays.vertices, arrays.faces, picture)
    worst = 0.0
    for vertex, (u, v) in zip(pins.ids, pins.uv):
        at = loop_uv[loop_vertex == vertex]
        worst = max(worst, float(np.abs(at - [u, 1.0 - v]).max()))
    mesh.calc_loop_triangles()
    tri_loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", tri_loops)
    t = loop_uv[tri_loops.reshape(-1, 3)].astype(np.float64)
    area = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    material = obj.data.materials[0]
    images = [n.image.name for n in material.node_tree.nodes if n.type == "TEX_IMAGE" and n.image]
    return {
        "result": sorted(result),
        "pins": len(pins.ids),
        "worst_pin_error": worst,
        "negative": int((area < 0).sum()),
        "positive": int((area > 0).sum()),
        "zero": int((area == 0).sum()),
        "images": images,
        "active_uv": mesh.uv_layers.active.name,
    }


if __name__ == "__main__":
    print("UVPIN-RESULT " + json.dumps(main(*sys.argv[1:4])), flush=True)
