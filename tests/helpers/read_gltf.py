#!/usr/bin/env python3
"""Independent glTF reader for uvpin's tests (standard library only).

Usage: read_gltf.py FILE.glb|FILE.gltf UV_SET [uvs]

Parses the container, decodes accessors (float / normalised integer UVs,
integer indices), and prints JSON per primitive of every mesh: vertex and
triangle counts and the orientation of each triangle in TEXCOORD_<UV_SET>:
`negative` is what a fold-free glTF layout has (front faces counter-clockwise
as displayed, v down), `positive` is a flipped triangle, `zero` is degenerate.
With `uvs`, each primitive also lists its texture coordinates.
"""
import base64, json, os, struct, sys

def load(path):
    data = open(path, "rb").read()
    if data[:4] == b"glTF":
        _, _, length = struct.unpack_from("<4sII", data, 0)
        assert length == len(data), f"GLB length {length} != file size {len(data)}"
        off, chunks = 12, []
        while off < length:
            clen, ctype = struct.unpack_from("<II", data, off)
            chunks.append((ctype, data[off + 8: off + 8 + clen]))
            off += 8 + clen
        doc = json.loads(chunks[0][1])
        bin_chunk = chunks[1][1] if len(chunks) > 1 else None
    else:
        doc, bin_chunk = json.loads(data), None
    buffers = []
    for b in doc.get("buffers", []):
        uri = b.get("uri")
        if uri is None:
            buffers.append(bin_chunk)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            from urllib.parse import unquote
            buffers.append(open(os.path.join(os.path.dirname(path), unquote(uri)), "rb").read())
        assert len(buffers[-1]) >= b["byteLength"], "buffer shorter than byteLength"
    return doc, buffers

FMT = {5120: "b", 5121: "B", 5122: "h", 5123: "H", 5125: "I", 5126: "f"}
NORM = {5120: 127.0, 5121: 255.0, 5122: 32767.0, 5123: 65535.0}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}

def accessor(doc, buffers, index):
    acc = doc["accessors"][index]
    view = doc["bufferViews"][acc["bufferView"]]
    buf = buffers[view["buffer"]]
    ct, n = acc["componentType"], NCOMP[acc["type"]]
    size = struct.calcsize("<" + FMT[ct])
    stride = view.get("byteStride") or size * n
    base = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    out = []
    for i in range(acc["count"]):
        vals = struct.unpack_from("<" + FMT[ct] * n, buf, base + i * stride)
        if acc.get("normalized") and ct in NORM:
            vals = tuple(max(v / NORM[ct], -1.0) for v in vals)
        out.append(vals)
    return out

def main():
    path, uv_set = sys.argv[1], int(sys.argv[2])
    doc, buffers = load(path)
    result = []
    for mi, mesh in enumerate(doc.get("meshes", [])):
        for pi, prim in enumerate(mesh["primitives"]):
            attrs = prim["attributes"]
            n = doc["accessors"][attrs["POSITION"]]["count"]
            idx = [i[0] for i in accessor(doc, buffers, prim["indices"])] if "indices" in prim else list(range(n))
            entry = {"mesh": mi, "primitive": pi, "vertices": n, "triangles": len(idx) // 3}
            key = f"TEXCOORD_{uv_set}"
            if key in attrs:
                uv = accessor(doc, buffers, attrs[key])
                neg = pos = zero = 0
                tri_orient = []
                for t in range(len(idx) // 3):
                    a, b, c = (uv[idx[3 * t + k]] for k in range(3))
                    d = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
                    if d < 0: neg += 1; tri_orient.append(-1)
                    elif d > 0: pos += 1; tri_orient.append(1)
                    else: zero += 1; tri_orient.append(0)
                entry.update(negative=neg, positive=pos, zero=zero, uv_count=len(uv), orientation=tri_orient)
                if len(sys.argv) > 3 and sys.argv[3] == "uvs":
                    entry["uv"] = uv
            result.append(entry)
    print(json.dumps(result))

main()
