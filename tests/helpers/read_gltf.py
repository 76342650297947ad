#!/usr/bin/env python3
"""Independent glTF reader for uvpin's tests (standard library only).

Usage: read_gltf.py FILE.glb|FILE.gltf UV_SET [uvs | injectivity]

Parses the container, decodes accessors (float / normalised integer UVs,
integer indices), and prints JSON per primitive of every mesh: vertex and
triangle counts and the orientation of each triangle in TEXCOORD_<UV_SET>:
`negative` is what a fold-free glTF layout has (front faces counter-clockwise
as displayed, v down), `positive` is a flipped triangle, `zero` is degenerate.
With `uvs`, each primitive also lists its texture coordinates. With `corners`,
each primitive lists, for every vertex attribute and morph target
attribute, its values per triangle corner (indices applied). With
`injectivity`, it prints for the whole mesh (all primitives, vertices welded
by equal UV within a primitive) how many pairs of UV boundary edges properly
cross, how many pairs of islands overlap (crossing boundaries, or one inside
the other), and the UV bounding box, all decided with exact rational
arithmetic.
"""
import base64, json, os, struct, sys
from fractions import Fraction

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

def corner_values(doc, buffers):
    """Every attribute's values per triangle corner, per primitive of every mesh."""
    out = []
    for mesh in doc.get("meshes", []):
        for prim in mesh["primitives"]:
            attrs = prim["attributes"]
            n = doc["accessors"][attrs["POSITION"]]["count"]
            idx = [i[0] for i in accessor(doc, buffers, prim["indices"])] if "indices" in prim else list(range(n))
            named = dict(attrs)
            for t, target in enumerate(prim.get("targets", [])):
                named.update({f"target{t}:{k}": v for k, v in target.items()})
            entry = {}
            for name, acc in named.items():
                values = accessor(doc, buffers, acc)
                entry[name] = [list(values[i]) for i in idx]
            out.append(entry)
    return out

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

def orient(a, b, c):
    """Sign of the doubled area of a b c, exact (floats are exact rationals)."""
    d = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
    bound = 1e-9 * (abs(b[0] - a[0]) + abs(c[0] - a[0])) * (abs(b[1] - a[1]) + abs(c[1] - a[1]))
    if abs(d) > bound:
        return 1 if d > 0 else -1
    fa, fb, fc = [tuple(map(Fraction, p)) for p in (a, b, c)]
    e = (fb[0] - fa[0]) * (fc[1] - fa[1]) - (fc[0] - fa[0]) * (fb[1] - fa[1])
    return (e > 0) - (e < 0)

def proper_crossing(a, b, c, d):
    """Interiors cross at one point, or collinear segments share a stretch."""
    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    if o1 == 0 and o2 == 0:
        k = 0 if (a[0] != b[0] or c[0] != d[0]) else 1
        lo = max(min(a[k], b[k]), min(c[k], d[k]))
        hi = min(max(a[k], b[k]), max(c[k], d[k]))
        return hi > lo
    return False

def inside(p, t):
    s = [orient(t[0], t[1], p), orient(t[1], t[2], p), orient(t[2], t[0], p)]
    return all(x > 0 for x in s) or all(x < 0 for x in s)

def injectivity(doc, buffers, uv_set):
    points, tris = {}, []
    key = f"TEXCOORD_{uv_set}"
    for mesh in doc.get("meshes", [])[:1]:
        for pi, prim in enumerate(mesh["primitives"]):
            if key not in prim["attributes"]:
                continue
            uv = accessor(doc, buffers, prim["attributes"][key])
            n = len(uv)
            idx = [i[0] for i in accessor(doc, buffers, prim["indices"])] if "indices" in prim else list(range(n))
            ids = [points.setdefault((pi, tuple(uv[i])), len(points)) for i in range(n)]
            tris += [tuple(ids[idx[3 * t + k]] for k in range(3)) for t in range(len(idx) // 3)]
    pts = [None] * len(points)
    for (pi, p), i in points.items():
        pts[i] = p
    parent = list(range(len(pts)))
    def find(x):
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x
    for t in tris:
        for v in t[1:]:
            parent[find(v)] = find(t[0])
    directed = set()
    for t in tris:
        for k in range(3):
            directed.add((t[k], t[(k + 1) % 3]))
    edges = [e for e in directed if (e[1], e[0]) not in directed]
    edges.sort(key=lambda e: min(pts[e[0]][0], pts[e[1]][0]))
    crossings, pairs = 0, set()
    for i, e in enumerate(edges):
        a, b = pts[e[0]], pts[e[1]]
        xmax = max(a[0], b[0])
        for f in edges[i + 1:]:
            c, d = pts[f[0]], pts[f[1]]
            if min(c[0], d[0]) > xmax:
                break
            if len({e[0], e[1], f[0], f[1]}) < 4:
                continue
            if proper_crossing(a, b, c, d):
                ia, ib = find(e[0]), find(f[0])
                if ia == ib:
                    crossings += 1
                else:
                    pairs.add((min(ia, ib), max(ia, ib)))
    probes = {}
    for t in tris:
        r = find(t[0])
        a, b, c = (pts[v] for v in t)
        if r not in probes and orient(a, b, c) != 0:
            probes[r] = tuple((a[k] + b[k] + c[k]) / 3 for k in range(2))
    for t in tris:
        r = find(t[0])
        tri = [pts[v] for v in t]
        for other, p in probes.items():
            if other != r and inside(p, tri):
                pairs.add((min(r, other), max(r, other)))
    us = [p[0] for p in pts] or [0.0]
    vs = [p[1] for p in pts] or [0.0]
    return {"islands": len({find(v) for v in range(len(pts))}), "crossings": crossings,
            "overlapping_pairs": len(pairs), "min": [min(us), min(vs)], "max": [max(us), max(vs)]}

def main():
    path, uv_set = sys.argv[1], int(sys.argv[2])
    doc, buffers = load(path)
    if len(sys.argv) > 3 and sys.argv[3] == "corners":
        print(json.dumps(corner_values(doc, buffers)))
        return
    if len(sys.argv) > 3 and sys.argv[3] == "injectivity":
        print(json.dumps(injectivity(doc, buffers, uv_set)))
        return
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
