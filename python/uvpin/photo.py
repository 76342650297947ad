"""A face photo onto a head mesh in one step.

``uvpin photo HEAD PHOTO -o OUT.glb`` (or :func:`photo`) finds the face's
landmarks on the photo, renders the head from the front, finds the same
landmarks on the render and carries each back to the mesh (the triangle the
pixel shows → its nearest corner), keeps the reliable pairs, writes a
constraint file naming each landmark (``label: "left_eye_outer"``) and solves
it: the named vertices land exactly on the photo's points, no triangle folds,
and the photo becomes the material's base-colour texture.

The detection is MediaPipe's face mesh (the ``photo`` extra:
``pip install 'uvpin[photo]'``, CPython 3.11 or 3.12): its detector and
468-point landmark model ship inside the wheel, nothing is downloaded.

Coordinates: image points are in pixels with pixel (i, j) spanning i..i+1,
j..j+1 (as a constraint file's ``px``); MediaPipe's normalised x times the
width puts pixel centres at integers, so half a pixel is added.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from . import InputError, _native, read_mesh, solve_file

__all__ = ["LANDMARKS", "Detector", "Face", "Facing", "PhotoError", "PhotoPins", "main", "photo", "photo_pins"]

#: Semantic landmarks and their index in MediaPipe's 468-point face mesh
#: ("left" and "right" as the person sees them). Ordered by priority: when
#: two land on one vertex, the earlier keeps it.
LANDMARKS: dict[str, int] = {
    "nose_tip": 1,
    "right_eye_outer": 33,
    "left_eye_outer": 263,
    "right_eye_inner": 133,
    "left_eye_inner": 362,
    "mouth_right": 61,
    "mouth_left": 291,
    "chin": 152,
    "upper_lip_top": 0,
    "lower_lip_bottom": 17,
    "subnasale": 2,
    "nasion": 168,
    "glabella": 9,
    "forehead_centre": 151,
    "forehead_top": 10,
    "right_eye_upper": 159,
    "right_eye_lower": 145,
    "left_eye_upper": 386,
    "left_eye_lower": 374,
    "right_brow_outer": 70,
    "right_brow_middle": 105,
    "right_brow_inner": 107,
    "left_brow_outer": 300,
    "left_brow_middle": 334,
    "left_brow_inner": 336,
    "right_nose_wing": 129,
    "left_nose_wing": 358,
    "right_cheek": 50,
    "left_cheek": 280,
    "right_cheek_low": 205,
    "left_cheek_low": 425,
    "right_forehead": 54,
    "left_forehead": 284,
    "right_temple": 127,
    "left_temple": 356,
    "right_jaw_angle": 172,
    "left_jaw_angle": 397,
    "right_jaw": 136,
    "left_jaw": 365,
    "right_chin": 148,
    "left_chin": 377,
}

#: Points that say where the face is and which way it looks.
_NOSE, _RIGHT_EDGE, _LEFT_EDGE, _FOREHEAD, _CHIN = 1, 234, 454, 10, 152
_RIGHT_EYE, _LEFT_EYE = 33, 263

#: The side, in pixels, of the square crop the landmark model sees.
_CROP = 384

#: A point whose two detections (two crops) differ by more than this share
#: of the eye distance is not reliable.
_JITTER = 0.06

#: A photo's face turned further than this (degrees) from the camera is
#: refused: the side turned away is too foreshortened to carry landmarks.
_PROFILE = 30.0

#: Fewer kept pairs than this cannot place a face.
_MIN_PAIRS = 8


class PhotoError(InputError):
    """The photo or the mesh cannot be used: no face, a profile, no head."""


def _mediapipe() -> Any:
    try:
        import mediapipe as mp  # type: ignore[import-not-found]

        return mp.solutions
    except (ImportError, AttributeError) as e:
        raise PhotoError(
            "the photo step needs MediaPipe 0.10.21: pip install 'uvpin[photo]' "
            f"(CPython 3.11 or 3.12) ({e})"
        ) from None


@dataclass(frozen=True)
class Face:
    """A face found on an image: its 468 points in pixels, the detector's
    score, how far each point moved between two crops (pixels) and each
    point's depth as the model estimates it (pixels, towards the viewer
    negative)."""

    points: np.ndarray
    score: float
    jitter: np.ndarray
    depth: np.ndarray

    @property
    def eye_distance(self) -> float:
        return float(np.linalg.norm(self.points[_LEFT_EYE] - self.points[_RIGHT_EYE]))

    @property
    def yaw(self) -> float:
        """How far the face is turned from the viewer (degrees, signed):
        the slope, in depth, of the line between its two face edges."""
        d = self.points[_LEFT_EDGE] - self.points[_RIGHT_EDGE]
        dz = self.depth[_LEFT_EDGE] - self.depth[_RIGHT_EDGE]
        return float(math.degrees(math.atan2(dz, float(np.linalg.norm(d)))))

    @property
    def tilt(self) -> float:
        """Angle (degrees) between the forehead-to-chin direction and the
        image's down."""
        d = self.points[_CHIN] - self.points[_FOREHEAD]
        return float(abs(math.degrees(math.atan2(d[0], d[1]))))

    def reliable(self, index: int) -> bool:
        return bool(self.jitter[index] <= _JITTER * max(self.eye_distance, 1.0))


@contextlib.contextmanager
def _native_stderr_muted() -> Iterator[None]:
    """Silences what MediaPipe's native code writes to the process's
    standard error (TensorFlow Lite and glog chatter) while inside."""
    try:
        saved = os.dup(2)
    except OSError:
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


class Detector:
    """MediaPipe's face detector and face mesh, opened once; its native
    chatter on standard error is muted while it is open."""

    def __init__(self) -> None:
        solutions = _mediapipe()
        self._muted = _native_stderr_muted()
        self._muted.__enter__()
        try:
            self._detect = solutions.face_detection.FaceDetection(model_selection=1, min_detection_confidence=0.5)
            self._mesh = solutions.face_mesh.FaceMesh(
                static_image_mode=True, max_num_faces=1, refine_landmarks=False, min_detection_confidence=0.5
            )
        except BaseException:
            self._muted.__exit__(None, None, None)
            raise

    def close(self) -> None:
        try:
            self._detect.close()
            self._mesh.close()
        finally:
            self._muted.__exit__(None, None, None)

    def __enter__(self) -> Detector:
        return self

    def __exit__(self, *_: Any) -> None:
        self.close()

    def find(self, image: np.ndarray) -> Face | None:
        """The most confident face on an (h, w, 3) uint8 image, or None:
        the detector's box, then the landmark model on two square crops
        around it (their mean, their disagreement as jitter)."""
        image = np.ascontiguousarray(image[..., :3], dtype=np.uint8)
        found = self._detect.process(image).detections
        if not found:
            return None
        best = max(found, key=lambda d: d.score[0])
        h, w = image.shape[:2]
        box = best.location_data.relative_bounding_box
        centre = np.array([(box.xmin + box.width / 2) * w, (box.ymin + box.height / 2) * h])
        side = max(box.width * w, box.height * h)
        runs = [self._crop_points(image, centre, side * s) for s in (1.8, 2.3)]
        runs = [r for r in runs if r is not None]
        if not runs:
            return None
        mean = np.mean(runs, axis=0)
        jitter = np.linalg.norm(runs[0][:, :2] - runs[-1][:, :2], axis=1) if len(runs) == 2 else np.full(len(mean), np.inf)
        return Face(points=mean[:, :2], score=float(best.score[0]), jitter=jitter, depth=mean[:, 2])

    def _crop_points(self, image: np.ndarray, centre: np.ndarray, side: float) -> np.ndarray | None:
        from PIL import Image

        left, top = (centre - side / 2).round().astype(int)
        side_px = max(int(round(side)), 8)
        crop = Image.fromarray(image).crop((left, top, left + side_px, top + side_px))
        crop = np.asarray(crop.resize((_CROP, _CROP), Image.BILINEAR))
        result = self._mesh.process(np.ascontiguousarray(crop)).multi_face_landmarks
        if not result:
            return None
        norm = np.array([(p.x, p.y, p.z) for p in result[0].landmark[:468]])
        # z is on the scale of x (the crop's width), its origin the head's centre.
        return np.array([left, top, 0.0]) + (norm * _CROP + [0.5, 0.5, 0.0]) * (side_px / _CROP)


def load_image(path: str | os.PathLike[str]) -> np.ndarray:
    """An image file as (h, w, 3) uint8, turned upright by its EXIF tag."""
    from PIL import Image, ImageOps, UnidentifiedImageError

    try:
        with Image.open(path) as im:
            return np.asarray(ImageOps.exif_transpose(im).convert("RGB"))
    except (OSError, UnidentifiedImageError) as e:
        raise PhotoError(f"{os.fspath(path)}: not a readable image ({e})") from None


def face_on_photo(detector: Detector, image: np.ndarray, name: str) -> Face:
    """The photo's face; refuses none and a profile."""
    face = detector.find(image)
    if face is None:
        raise PhotoError(f"{name}: no face found on the photo")
    if abs(face.yaw) > _PROFILE:
        raise PhotoError(
            f"{name}: the face is turned {abs(face.yaw):.0f}° to one side (more than {_PROFILE:.0f}°); "
            "use a photo from the front"
        )
    return face


@dataclass(frozen=True)
class Facing:
    """Where the head is looked at from: ``view`` the direction looked
    along (into the face), ``up`` the direction shown up."""

    view: np.ndarray
    up: np.ndarray


def _unit(v: Sequence[float], what: str) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    n = float(np.linalg.norm(a)) if a.shape == (3,) and np.all(np.isfinite(a)) else 0.0
    if n == 0.0:
        raise PhotoError(f"{what} must be three finite numbers, not all zero")
    return a / n


def _candidates() -> list[Facing]:
    """Views around each axis taken as up: eight directions across it."""
    out = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            up = np.zeros(3)
            up[axis] = sign
            a = np.zeros(3)
            a[(axis + 1) % 3] = 1.0
            b = np.cross(up, a)
            for k in range(8):
                t = k * math.pi / 4
                out.append(Facing(view=math.cos(t) * a + math.sin(t) * b, up=up))
    return out


def _turned(f: Facing, degrees: float) -> Facing:
    """`f` turned about its up axis."""
    t = math.radians(degrees)
    side = np.cross(f.up, f.view)
    return Facing(view=math.cos(t) * f.view + math.sin(t) * side, up=f.up)


def _shown_at(at: np.ndarray, triangle: np.ndarray) -> int | None:
    """The triangle a render's triangle buffer shows at pixel `at`, if any."""
    side = triangle.shape[0]
    i, j = int(math.floor(at[0])), int(math.floor(at[1]))
    if not (0 <= i < side and 0 <= j < side) or triangle[j, i] < 0:
        return None
    return int(triangle[j, i])


def _depth_at(at: np.ndarray, triangle: np.ndarray, faces: np.ndarray, v: np.ndarray, view: np.ndarray) -> float | None:
    """How far along `view` the surface the render shows at pixel `at` is."""
    t = _shown_at(at, triangle)
    return None if t is None else float(np.mean(v[faces[t]] @ view))


def _hollow(face: Face, triangle: np.ndarray, faces: np.ndarray, v: np.ndarray, view: np.ndarray) -> bool:
    """A face seen from inside (the hollow-face illusion: an open mask
    seen from behind looks like a face, mirrored): its nose tip is no
    nearer than its eye corners."""
    nose = _depth_at(face.points[_NOSE], triangle, faces, v, view)
    eyes = [_depth_at(face.points[e], triangle, faces, v, view) for e in (_RIGHT_EYE, _LEFT_EYE)]
    known = [e for e in eyes if e is not None]
    return nose is None or not known or nose >= min(known)


def _look(detector: Detector, v: np.ndarray, faces: np.ndarray, f: Facing, size: int) -> Face | None:
    """The face a render from `f` shows, upright and seen from outside."""
    image, triangle, _ = _native.render_view(v, faces, f.view.tolist(), f.up.tolist(), size)
    face = detector.find(image)
    if face is None or face.tilt > 35.0 or _hollow(face, triangle, faces, v, f.view):
        return None
    return face


def find_facing(detector: Detector, v: np.ndarray, faces: np.ndarray, size: int = 320) -> Facing:
    """The view that shows the head's face upright and most frontal: every
    axis as up, eight views across it; the least turned face, then turned
    by its own measured yaw."""
    seen = [(f, _look(detector, v, faces, f, size)) for f in _candidates()]
    seen = [(f, face) for f, face in seen if face is not None]
    if not seen:
        raise PhotoError("no face found on the mesh from any side; give its facing with --view X,Y,Z --up X,Y,Z")
    best, face = min(seen, key=lambda s: abs(s[1].yaw))
    return turn_to(detector, v, faces, (best, face), 0.0, size)


def turn_to(
    detector: Detector, v: np.ndarray, faces: np.ndarray, start: tuple[Facing, Face], yaw: float, size: int = 320
) -> Facing:
    """The view, turned about its up axis from `start`, whose render shows
    the face turned by `yaw` degrees (the photo's pose): a few turns by the
    measured difference, either way, kept while they get closer."""
    best, face = start
    for _ in range(3):
        miss = face.yaw - yaw
        if abs(miss) < 2.0:
            break
        tried = [(f, _look(detector, v, faces, f, size)) for f in (_turned(best, miss), _turned(best, -miss))]
        tried = [(f, x) for f, x in tried if x is not None and abs(x.yaw - yaw) < abs(miss)]
        if not tried:
            break
        best, face = min(tried, key=lambda t: abs(t[1].yaw - yaw))
    return best


@dataclass
class Pair:
    """One named landmark: the mesh vertex, its 3D position and its target
    on the photo (pixels)."""

    label: str
    vertex: int
    position: np.ndarray
    target: np.ndarray


@dataclass
class Pairs:
    kept: list[Pair] = field(default_factory=list)
    dropped: dict[str, str] = field(default_factory=dict)


def _local_map(source: np.ndarray, target: np.ndarray, at: np.ndarray, k: int = 12) -> np.ndarray:
    """Carries the point `at` from the render's face to the photo's by the
    affine map fitted (weighted least squares) to the `k` nearest points."""
    d = np.linalg.norm(source - at, axis=1)
    near = np.argsort(d)[:k]
    w = 1.0 / (d[near] ** 2 + 1.0)
    a = np.hstack([source[near], np.ones((len(near), 1))]) * w[:, None]
    coef, *_ = np.linalg.lstsq(a, target[near] * w[:, None], rcond=None)
    return np.append(at, 1.0) @ coef


def _render_face(detector: Detector, v: np.ndarray, faces: np.ndarray, facing: Facing) -> tuple[Face, np.ndarray, np.ndarray]:
    """The face on a render large enough that it spans ~500 pixels, with
    the render's triangle buffer and vertices' pixel positions."""
    size = 1024
    for _ in range(3):
        image, triangle, screen = _native.render_view(v, faces, facing.view.tolist(), facing.up.tolist(), size)
        face = detector.find(image)
        if face is None:
            raise PhotoError("the face found on the mesh from afar is lost up close; give its facing with --view")
        span = float(np.ptp(face.points, axis=0).max())
        if span >= 400 or size >= 4096:
            return face, triangle, screen
        size = min(4096, int(size * 500 / max(span, 1.0)))
    return face, triangle, screen


def _nearest_corner(at: np.ndarray, triangle: np.ndarray, screen: np.ndarray, faces: np.ndarray) -> int | str:
    """The corner nearest `at` of the triangle the render shows there, or
    why there is none."""
    t = _shown_at(at, triangle)
    if t is None:
        return "off the mesh on the render"
    # The front-most surface there (the depth buffer's); its winding says
    # nothing, meshes come wound either way.
    corners = faces[t]
    return int(corners[np.argmin(np.linalg.norm(screen[corners] - at, axis=1))])


#: Gives a landmark's target on the photo (pixels) from its label, its
#: MediaPipe index and its vertex's pixel on the render; None drops it.
Targets = Callable[[str, int, np.ndarray], "np.ndarray | None"]


def photo_targets(render_face: Face, photo_face: Face) -> Targets:
    """Targets where the photo shows what the render shows at the vertex."""

    def target(_label: str, index: int, at: np.ndarray) -> np.ndarray | None:
        if not photo_face.reliable(index):
            return None
        return _local_map(render_face.points, photo_face.points, at)

    return target


def pair_landmarks(
    v: np.ndarray, faces: np.ndarray, facing: Facing, seen: tuple[Face, np.ndarray, np.ndarray], targets: Targets
) -> Pairs:
    """Each named landmark carried from the render (`seen`: its face,
    triangle buffer and vertex pixels) to a mesh vertex and given its
    target; the unreliable ones dropped, with why."""
    render_face, triangle, screen = seen
    pairs, used = Pairs(), set()
    for label, index in LANDMARKS.items():
        if not render_face.reliable(index):
            pairs.dropped[label] = "found unsteadily on the render (low confidence)"
            continue
        vertex = _nearest_corner(render_face.points[index], triangle, screen, faces)
        if isinstance(vertex, str):
            pairs.dropped[label] = vertex
            continue
        if vertex in used:
            pairs.dropped[label] = f"on vertex {vertex}, taken by an earlier landmark"
            continue
        target = targets(label, index, screen[vertex])
        if target is None:
            pairs.dropped[label] = "no steady target (low confidence on the photo, or not in the template)"
            continue
        used.add(vertex)
        pairs.kept.append(Pair(label, vertex, v[vertex].copy(), np.asarray(target, dtype=np.float64)))
    if len(pairs.kept) < _MIN_PAIRS:
        raise PhotoError(
            f"only {len(pairs.kept)} landmarks could be paired (need {_MIN_PAIRS}): "
            + "; ".join(f"{k}: {why}" for k, why in list(pairs.dropped.items())[:3])
        )
    return pairs


def _ron_string(s: str) -> str:
    return json.dumps(s, ensure_ascii=False)


def constraint_text(
    asset: str, image: str, image_size: tuple[int, int], uv_set: int, pairs: Pairs, header: str
) -> str:
    """A constraint file: each kept landmark by its 3D position (robust to
    how a reader numbers vertices), its pixel target and its name."""
    lines = [f"// {line}" for line in header.splitlines()]
    for label, why in pairs.dropped.items():
        lines.append(f"// dropped {label}: {why}")
    lines += [
        "(",
        f"    asset: {_ron_string(asset)},",
        f"    image: {_ron_string(image)},",
        f"    image_size: ({image_size[0]}, {image_size[1]}),",
        f"    uv_set: {uv_set},",
        "    constraints: [",
    ]
    for p in pairs.kept:
        x, y, z = (repr(float(c)) for c in p.position)
        u, w = (repr(round(float(c), 3)) for c in p.target)
        lines.append(f"        (near: ({x}, {y}, {z}), px: ({u}, {w}), label: {_ron_string(p.label)}),")
    lines += ["    ],", ")", ""]
    return "\n".join(lines)


def template_targets(path: str | os.PathLike[str]) -> tuple[Targets, dict[str, Any]]:
    """A constraint file's labelled targets (pixels of its `image_size`, or
    texture coordinates) as targets by name; the file's fields beside."""
    spec = json.loads(_native.read_constraints(os.fspath(path)))
    size = spec.get("image_size")
    by_label: dict[str, np.ndarray] = {}
    for c in spec["constraints"]:
        if c.get("label") is None:
            continue
        if c.get("px") is not None:
            by_label[c["label"]] = np.asarray(c["px"], dtype=np.float64)
        elif size is not None:
            by_label[c["label"]] = np.asarray(c["uv"], dtype=np.float64) * np.asarray(size, dtype=np.float64)
    if not by_label or size is None:
        raise PhotoError(f"{os.fspath(path)}: a template needs labelled constraints and an image_size")
    return (lambda label, _i, _at: by_label.get(label)), spec


def embed_texture(glb: str, image_bytes: bytes, mime: str, tex_coord: int) -> None:
    """Makes `image_bytes` the base-colour texture (read through
    TEXCOORD_`tex_coord`) of every primitive of a .glb file, in place."""
    with open(glb, "rb") as fh:
        data = fh.read()
    magic, _version, _length = np.frombuffer(data[:12], dtype="<u4")
    if magic != 0x46546C67:
        raise PhotoError(f"{glb}: not a binary glTF")
    jlen = int(np.frombuffer(data[12:16], dtype="<u4")[0])
    doc = json.loads(data[20 : 20 + jlen])
    rest = data[20 + jlen :]
    binary = b""
    if len(rest) >= 8:
        blen = int(np.frombuffer(rest[:4], dtype="<u4")[0])
        binary = rest[8 : 8 + blen]
    offset = (len(binary) + 3) // 4 * 4
    binary = binary.ljust(offset, b"\0") + image_bytes
    doc.setdefault("buffers", [{}])
    doc["buffers"][0]["byteLength"] = len(binary)
    views = doc.setdefault("bufferViews", [])
    views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(image_bytes)})
    images = doc.setdefault("images", [])
    images.append({"bufferView": len(views) - 1, "mimeType": mime, "name": "photo"})
    textures = doc.setdefault("textures", [])
    textures.append({"source": len(images) - 1})
    materials = doc.setdefault("materials", [])
    photo_material = {"name": "photo", "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0}}
    used = sorted({p.get("material", -1) for m in doc.get("meshes", []) for p in m.get("primitives", [])})
    if -1 in used:
        materials.append(photo_material)
        for m in doc.get("meshes", []):
            for p in m.get("primitives", []):
                p.setdefault("material", len(materials) - 1)
    for i in {p["material"] for m in doc.get("meshes", []) for p in m.get("primitives", [])}:
        pbr = materials[i].setdefault("pbrMetallicRoughness", {})
        pbr["baseColorTexture"] = {"index": len(textures) - 1, "texCoord": tex_coord}
        pbr.pop("baseColorFactor", None)
    text = json.dumps(doc, separators=(",", ":")).encode()
    text = text.ljust((len(text) + 3) // 4 * 4, b" ")
    binary = binary.ljust((len(binary) + 3) // 4 * 4, b"\0")
    out = b"".join(
        [
            np.array([0x46546C67, 2, 12 + 8 + len(text) + 8 + len(binary)], dtype="<u4").tobytes(),
            np.array([len(text), 0x4E4F534A], dtype="<u4").tobytes(),
            text,
            np.array([len(binary), 0x004E4942], dtype="<u4").tobytes(),
            binary,
        ]
    )
    with open(glb, "wb") as fh:
        fh.write(out)


def _image_bytes(path: str, image: np.ndarray) -> tuple[bytes, str]:
    """The photo as stored when it is an upright PNG or JPEG, else
    re-encoded as PNG (turned upright by its EXIF tag)."""
    import io

    from PIL import Image

    with Image.open(path) as im:
        fmt, size = im.format, im.size
    if fmt in ("PNG", "JPEG") and size == (image.shape[1], image.shape[0]):
        with open(path, "rb") as fh:
            return fh.read(), "image/png" if fmt == "PNG" else "image/jpeg"
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    return buf.getvalue(), "image/png"


@dataclass(frozen=True)
class Check:
    """The photo's landmarks against the textured render's: per landmark
    index, the distance in photo pixels between where the photo shows it
    and where the textured head shows it."""

    errors: dict[str, float]

    @property
    def median(self) -> float:
        return float(np.median(list(self.errors.values()))) if self.errors else math.inf

    @property
    def worst(self) -> float:
        return float(max(self.errors.values())) if self.errors else math.inf


def _photo_point(at: np.ndarray, triangle: np.ndarray, screen: np.ndarray, faces: np.ndarray, uvs: np.ndarray, size: tuple[int, int]) -> np.ndarray | None:
    """The photo pixel the textured render shows at `at` (barycentric)."""
    t = _shown_at(at, triangle)
    if t is None:
        return None
    c = faces[t]
    a, b, d = screen[c]
    m = np.array([b - a, d - a]).T
    if abs(np.linalg.det(m)) < 1e-12:
        return None
    s, t = np.linalg.solve(m, at - a)
    uv = (1 - s - t) * uvs[c[0]] + s * uvs[c[1]] + t * uvs[c[2]]
    return uv * np.asarray(size, dtype=np.float64)


def check_result(
    detector: Detector,
    glb: str,
    uv_set: int,
    facing: Facing,
    photo: tuple[np.ndarray, Face | None],
    labels: Sequence[str],
    size: int,
) -> tuple[Check, np.ndarray, Face | None]:
    """Renders the solved head with the photo on it, finds the face on the
    render and measures, for each of `labels`, how far the photo pixel it
    shows is from the photo's own landmark; returns the render and the face
    found on it too."""
    photo, photo_face = photo
    mesh = read_mesh(glb, uv_set=uv_set)
    if mesh.uvs is None:
        raise PhotoError(f"{glb}: the written file has no UV set {uv_set}")
    image, triangle, screen = _native.render_view(
        mesh.vertices, mesh.faces, facing.view.tolist(), facing.up.tolist(), size, uvs=mesh.uvs, texture=photo
    )
    found = detector.find(image)
    errors: dict[str, float] = {}
    if found is not None and photo_face is not None:
        wh = (photo.shape[1], photo.shape[0])
        for label in labels:
            index = LANDMARKS[label]
            p = _photo_point(found.points[index], triangle, screen, mesh.faces, mesh.uvs, wh)
            if p is not None:
                errors[label] = float(np.linalg.norm(p - photo_face.points[index]))
    return Check(errors), image, found


def _face_crop(image: np.ndarray, face: Face | None, scale: float = 2.4) -> np.ndarray:
    """The square around `face` (`scale` × its extent), or the whole image."""
    if face is None:
        return image
    lo, hi = face.points.min(axis=0), face.points.max(axis=0)
    half = float((hi - lo).max()) * scale / 2
    cx, cy = (lo + hi) / 2
    h, w = image.shape[:2]
    x0, y0 = max(0, int(cx - half)), max(0, int(cy - half))
    x1, y1 = min(w, int(cx + half) + 1), min(h, int(cy + half) + 1)
    return image[y0:y1, x0:x1] if x1 > x0 and y1 > y0 else image


def before_after(photo: np.ndarray, render: np.ndarray, faces: tuple[Face | None, Face | None], height: int = 512) -> np.ndarray:
    """The photo's face beside the textured head's (`faces`: where each is
    found), both `height` pixels high."""
    from PIL import Image

    parts = []
    for a, face in zip((photo, render), faces):
        im = Image.fromarray(np.ascontiguousarray(_face_crop(a, face)))
        parts.append(im.resize((max(1, round(im.width * height / im.height)), height), Image.LANCZOS))
    out = Image.new("RGB", (parts[0].width + parts[1].width + 8, height), "white")
    out.paste(parts[0], (0, 0))
    out.paste(parts[1], (parts[0].width + 8, 0))
    return np.asarray(out)


def _relative(path: str, start: str) -> str:
    return os.path.relpath(os.path.abspath(path), os.path.dirname(os.path.abspath(start))).replace(os.sep, "/")


@dataclass
class Outputs:
    """Where a photo run writes: the model, its constraint file, the
    before/after picture and (optionally) the JSON report."""

    model: str
    constraints: str
    picture: str
    report: str | None = None

    @staticmethod
    def beside(output: str, constraints: str | None, picture: str | None, report: str | None) -> Outputs:
        if not output.lower().endswith(".glb"):
            raise PhotoError(f"{output}: the photo step writes a .glb (the photo goes inside as its texture)")
        stem = output[:-4]
        return Outputs(output, constraints or stem + ".uvpin.ron", picture or stem + ".photo.png", report)


def _staged(final: str, suffix: str) -> str:
    """A hidden temporary file beside `final` (same folder: relative paths
    hold and the final rename is atomic)."""
    fd, path = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(final)), prefix=".uvpin-photo-", suffix=suffix)
    os.close(fd)
    return path


def photo(
    head: str | os.PathLike[str],
    image: str | os.PathLike[str] | None,
    output: str | os.PathLike[str],
    *,
    constraints: str | os.PathLike[str] | None = None,
    picture: str | os.PathLike[str] | None = None,
    report: str | os.PathLike[str] | None = None,
    view: Sequence[float] | None = None,
    up: Sequence[float] | None = None,
    template: str | os.PathLike[str] | None = None,
    uv_set: int | None = None,
) -> dict[str, Any]:
    """Lays the face photo `image` onto the head mesh `head` and writes
    `output` (.glb, the photo as its base-colour texture), the constraint
    file (default: beside it, ``.uvpin.ron``) and a before/after picture
    (``.photo.png``): all of them or, on an error, none.

    `view`/`up`: the direction looked along into the face and the head's
    up (default: found by rendering the head from every side). `template`:
    a constraint file whose labelled targets are used by name instead of
    the photo's landmarks (its `image` is the photo when `image` is None).
    Returns the solver's report with a ``photo`` section: the landmarks kept
    and dropped (with why) and the check of the textured render against the
    photo. Raises PhotoError (an InputError) with a one-line reason."""
    out = Outputs.beside(os.fspath(output), *(None if p is None else os.fspath(p) for p in (constraints, picture, report)))
    mesh = read_mesh(head)
    spec: dict[str, Any] = {}
    if template is not None:
        by_name, spec = template_targets(template)
        if image is None and spec.get("image"):
            image = os.path.join(os.path.dirname(os.path.abspath(template)), spec["image"])
    if image is None:
        raise PhotoError("no photo given (and the template names no image)")
    image = os.fspath(image)
    picture_rgb = load_image(image)
    given = None if view is None and up is None else _given_facing(view, up)
    with Detector() as detector:
        photo_face = detector.find(picture_rgb) if template is not None else face_on_photo(detector, picture_rgb, image)
        if template is not None and tuple(spec["image_size"]) != (picture_rgb.shape[1], picture_rgb.shape[0]):
            raise PhotoError(
                f"the template's image_size {tuple(spec['image_size'])} is not the photo's {picture_rgb.shape[1::-1]}"
            )
        facing, pairs, size = landmark_pairs(
            detector, (mesh.vertices, mesh.faces), photo_face, given, by_name if template is not None else None
        )
        if uv_set is None:
            uv_set = 1 if mesh.uvs is not None and not os.fspath(head).lower().endswith(".obj") else 0
        return _solve_and_write(detector, os.fspath(head), image, picture_rgb, photo_face, facing, pairs, uv_set, out, size)


def _given_facing(view: Sequence[float] | None, up: Sequence[float] | None) -> Facing:
    return Facing(
        _unit(view if view is not None else (0, 0, -1), "--view"), _unit(up if up is not None else (0, 1, 0), "--up")
    )


def landmark_pairs(
    detector: Detector,
    mesh: tuple[np.ndarray, np.ndarray],
    photo_face: Face | None,
    given: Facing | None = None,
    by_name: Targets | None = None,
) -> tuple[Facing, Pairs, int]:
    """The head's facing (`given`, or found and turned to the photo's
    pose), the named landmarks paired to its vertices with their targets
    (the photo's, or `by_name`'s), and the size of the render they were
    found on."""
    v, faces = mesh
    facing = given
    if facing is None:
        facing = find_facing(detector, v, faces)
        front = _look(detector, v, faces, facing, 320) if photo_face is not None else None
        if photo_face is not None and front is not None:
            facing = turn_to(detector, v, faces, (facing, front), photo_face.yaw)
    seen = _render_face(detector, v, faces, facing)
    if by_name is None:
        if photo_face is None:
            raise PhotoError("no face found on the photo")
        by_name = photo_targets(seen[0], photo_face)
    return facing, pair_landmarks(v, faces, facing, seen, by_name), seen[1].shape[0]


@dataclass(frozen=True)
class PhotoPins:
    """Pins for :func:`uvpin.solve` from a photo: vertex ids (k,), targets
    (k, 2, glTF texture coordinates), their names, and what was dropped."""

    ids: np.ndarray
    uv: np.ndarray
    labels: list[str]
    dropped: dict[str, str]
    facing: Facing


def photo_pins(
    vertices: np.ndarray,
    faces: np.ndarray,
    image: str | os.PathLike[str],
    *,
    view: Sequence[float] | None = None,
    up: Sequence[float] | None = None,
) -> PhotoPins:
    """The photo step on arrays (as Blender holds a mesh): the face's named
    landmarks found on the photo and on the mesh, as pins whose targets are
    the photo's texture coordinates. Solve them with
    ``uvpin.solve(vertices, faces, (pins.ids, pins.uv))``."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int64)
    picture_rgb = load_image(image)
    given = None if view is None and up is None else _given_facing(view, up)
    with Detector() as detector:
        photo_face = face_on_photo(detector, picture_rgb, os.fspath(image))
        facing, pairs, _ = landmark_pairs(detector, (v, f), photo_face, given)
    size = np.array([picture_rgb.shape[1], picture_rgb.shape[0]], dtype=np.float64)
    return PhotoPins(
        ids=np.array([p.vertex for p in pairs.kept], dtype=np.int64),
        uv=np.array([p.target / size for p in pairs.kept]),
        labels=[p.label for p in pairs.kept],
        dropped=pairs.dropped,
        facing=facing,
    )


def _solve_and_write(
    detector: Detector,
    head: str,
    image: str,
    picture_rgb: np.ndarray,
    photo_face: Face | None,
    facing: Facing,
    pairs: Pairs,
    uv_set: int,
    out: Outputs,
    size: int,
) -> dict[str, Any]:
    """Writes the constraint file, solves it, puts the photo in the model,
    checks and draws the result, then moves everything into place."""
    from PIL import Image

    header = (
        f"Written by uvpin photo: {os.path.basename(image)} onto {os.path.basename(head)}, "
        f"seen along {np.round(facing.view, 4).tolist()} with up {np.round(facing.up, 4).tolist()}.\n"
        f"{len(pairs.kept)} landmarks kept, {len(pairs.dropped)} dropped."
    )
    finals = [out.constraints, out.model, out.picture] + ([out.report] if out.report else [])
    staged = [_staged(f, s) for f, s in zip(finals, [".uvpin.ron", ".glb", ".png", ".json"])]
    try:
        text = constraint_text(
            _relative(head, out.constraints), _relative(image, out.constraints), (picture_rgb.shape[1], picture_rgb.shape[0]), uv_set, pairs, header
        )
        with open(staged[0], "w", encoding="utf-8") as fh:
            fh.write(text)
        result = solve_file(staged[0], staged[1])
        if result.get("status") == "error":
            raise PhotoError(result.get("error") or "the solve wrote nothing")
        embed_texture(staged[1], *_image_bytes(image, picture_rgb), uv_set)
        labels = [p.label for p in pairs.kept]
        check, render, found = check_result(detector, staged[1], uv_set, facing, (picture_rgb, photo_face), labels, size)
        Image.fromarray(before_after(picture_rgb, render, (photo_face, found))).save(staged[2], format="PNG")
        result["photo"] = {
            "view": facing.view.tolist(),
            "up": facing.up.tolist(),
            "uv_set": uv_set,
            "kept": [{"label": p.label, "vertex": p.vertex, "px": p.target.tolist()} for p in pairs.kept],
            "dropped": pairs.dropped,
            "check": {"median_px": check.median, "worst_px": check.worst, "per_landmark_px": check.errors},
        }
        if out.report:
            with open(staged[3], "w", encoding="utf-8") as fh:
                json.dump(result, fh, indent=1)
        for tmp, final in zip(staged, finals):
            os.replace(tmp, final)
        staged = []
        return result
    finally:
        for tmp in staged:
            if os.path.exists(tmp):
                os.remove(tmp)


def _vector(text: str) -> tuple[float, float, float]:
    parts = text.replace(",", " ").split()
    if len(parts) != 3:
        raise PhotoError(f"{text!r}: give three numbers, e.g. 0,0,-1")
    try:
        x, y, z = (float(p) for p in parts)
    except ValueError:
        raise PhotoError(f"{text!r}: give three numbers, e.g. 0,0,-1") from None
    return x, y, z


def _summary(result: dict[str, Any], out: str) -> str:
    info = result["photo"]
    reached = sum(1 for c in result.get("constraints", []) if c.get("reached"))
    total = len(result.get("constraints", []))
    lines = [
        f"{out}: {result['status']}, {reached} of {total} landmarks on the photo's, "
        f"{len(info['dropped'])} dropped" + (f" ({', '.join(info['dropped'])})" if info["dropped"] else ""),
    ]
    check = info["check"]
    if math.isfinite(check["median_px"]):
        lines.append(
            f"check: on the textured head the photo's landmarks are {check['median_px']:.1f} px off "
            f"(median; worst {check['worst_px']:.1f} px)"
        )
    else:
        lines.append("check: no face found on the textured render")
    return "\n".join(lines)


def _stamp(paths: Sequence[str]) -> tuple[tuple[int, int] | None, ...]:
    """Each file's size and modification time (None when absent)."""
    out = []
    for p in paths:
        try:
            st = os.stat(p)
            out.append((st.st_size, st.st_mtime_ns))
        except OSError:
            out.append(None)
    return tuple(out)


def _run_once(args: Any) -> int:
    """One photo step as the command line asked; prints its summary or its
    error; the exit code."""
    import sys

    try:
        result = photo(
            args.head,
            args.photo,
            args.output,
            constraints=args.constraints,
            picture=args.picture,
            report=args.report,
            view=None if args.view is None else _vector(args.view),
            up=None if args.up is None else _vector(args.up),
            template=args.template,
            uv_set=args.uv_set,
        )
    except (InputError, OSError) as e:
        print(f"error: {e}", file=sys.stderr, flush=True)
        return 1
    if not args.quiet:
        print(_summary(result, args.output), file=sys.stderr, flush=True)
    return 0 if result["status"] == "reached" else 2


def _watch(args: Any) -> int:
    """Runs the step, then again whenever the head, the photo or the
    template changes (a new size or time, the same on two looks in a row:
    written whole), until interrupted."""
    import sys
    import time

    inputs = [os.fspath(p) for p in (args.head, args.photo, args.template) if p is not None]
    print(f"watching {', '.join(inputs)} (Ctrl-C to stop)", file=sys.stderr, flush=True)
    done = _stamp(inputs)
    _run_once(args)
    seen = done
    try:
        while True:
            time.sleep(0.25)
            now = _stamp(inputs)
            if now != done and now == seen and all(now):
                done = now
                print(f"changed: {', '.join(p for p, a, b in zip(inputs, now, seen) if a)}", file=sys.stderr, flush=True)
                _run_once(args)
            seen = now
    except KeyboardInterrupt:
        return 0


def _interrupt(*_: Any) -> None:
    """SIGTERM ends a watch as Ctrl-C does."""
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m uvpin.photo HEAD PHOTO -o OUT.glb``: exit 0 reached, 2
    partial (written, fold-free, some landmarks short), 1 error (nothing
    written)."""
    import argparse
    import signal

    ap = argparse.ArgumentParser(prog="uvpin photo", description="Lay a face photo onto a head mesh.")
    ap.add_argument("head", help="the head mesh (.glb, .gltf, .obj, .ply, .stl, .off)")
    ap.add_argument("photo", nargs="?", help="the face photo (PNG or JPEG); optional with --template")
    ap.add_argument("-o", "--output", required=True, help="the textured model to write (.glb)")
    ap.add_argument("--constraints", help="the constraint file to write (default: OUTPUT's stem + .uvpin.ron)")
    ap.add_argument("--picture", help="the before/after picture (default: OUTPUT's stem + .photo.png)")
    ap.add_argument("--report", help="write the JSON report here")
    ap.add_argument("--view", help="direction looked along into the face, e.g. 0,0,-1 (default: found)")
    ap.add_argument("--up", help="the head's up, e.g. 0,1,0 (default: found)")
    ap.add_argument("--template", help="a constraint file whose labelled targets are used by name")
    ap.add_argument("--uv-set", type=int, help="the UV set written (default: 1 beside a glTF's atlas, else 0)")
    ap.add_argument("--watch", action="store_true", help="run again whenever the head or the photo changes")
    ap.add_argument("-q", "--quiet", action="store_true", help="no summary (errors are still printed)")
    args = ap.parse_args(argv)
    if not args.watch:
        return _run_once(args)
    signal.signal(signal.SIGTERM, _interrupt)
    return _watch(args)


if __name__ == "__main__":
    raise SystemExit(main())
