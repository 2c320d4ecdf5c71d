"""glTF 2.0 binary (.glb): an animated run scene written, and a .glb read back and checked.

Layout of a written file (docs/viewer.md):

* one root node per frame of the cell (object, device base, link, sensor, auxiliary frame, TCP),
  named after the frame, ``extras.kind`` saying which; its static TRS is the pose at the first
  sample, and the one animation ("run") moves it by translation and rotation keyframes
  (LINEAR: glTF viewers interpolate translations linearly and rotations by slerp);
* a body's mesh hangs on its node (vertices in the frame's coordinates); a body without
  geometry, a frame and a TCP get an x-y-z triad (LINES, red-green-blue);
* each sensor cell is two child nodes of the sensor, free (green) and sensing (red), one of
  them at scale 0 at any time (STEP keyframes at the reading changes);
* a body in a collision or clearance violation hangs as two children, itself and a red twin,
  one of them at scale 0 at any time (STEP keyframes at the spans' ends).

Keyframes are decimated: a sample is left out where interpolating its neighbours reproduces
it within ``tolerance`` (translation error plus rotation error times the body's radius), so
held objects and idle devices cost two keyframes.  Numbers are float32, as glTF stores them.
"""

from __future__ import annotations

import json
import struct

import numpy as np

from ..errors import UserError

GLB_MAGIC = 0x46546C67  # "glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942
FLOAT, UINT16, UINT32 = 5126, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
LINES, TRIANGLES = 1, 4

TOLERANCE = 1e-4  # keyframe decimation [m]
CONTACT, FREE = "#d62728", "#3a9d5d"


class _Builder:
    """Accumulates the binary chunk, buffer views and accessors."""

    def __init__(self):
        self.blob = bytearray()
        self.gltf: dict = {
            "asset": {"version": "2.0", "generator": "rworld"},
            "scene": 0,
            "scenes": [{"nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }
        self._materials: dict[str, int] = {}

    def view(self, data: bytes, target: int | None = None) -> int:
        while len(self.blob) % 4:
            self.blob.append(0)
        entry = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if target is not None:
            entry["target"] = target
        self.blob += data
        self.gltf["bufferViews"].append(entry)
        return len(self.gltf["bufferViews"]) - 1

    def accessor(self, array: np.ndarray, kind: str, target: int | None = None, bounds=False):
        """An accessor of ``array`` ((count,) or (count, width)) as float32 or its index type."""
        if array.dtype.kind in "iu":
            component = UINT16 if array.max(initial=0) < 65535 else UINT32
            array = array.astype(np.uint16 if component == UINT16 else np.uint32)
        else:
            component = FLOAT
            array = array.astype(np.float32)
        entry = {
            "bufferView": self.view(array.tobytes(), target),
            "componentType": component,
            "count": int(len(array)),
            "type": kind,
        }
        if bounds:
            flat = array.reshape(len(array), -1)
            entry["min"] = flat.min(axis=0).astype(float).tolist()
            entry["max"] = flat.max(axis=0).astype(float).tolist()
        self.gltf["accessors"].append(entry)
        return len(self.gltf["accessors"]) - 1

    def material(self, colour: str) -> int:
        if colour not in self._materials:
            rgb = [int(colour[i : i + 2], 16) / 255 for i in (1, 3, 5)]
            self.gltf["materials"].append(
                {
                    "name": colour,
                    "pbrMetallicRoughness": {
                        "baseColorFactor": rgb + [1.0],
                        "metallicFactor": 0.0,
                        "roughnessFactor": 0.8,
                    },
                    "doubleSided": True,
                }
            )
            self._materials[colour] = len(self.gltf["materials"]) - 1
        return self._materials[colour]

    def mesh(self, name: str, primitive: dict) -> int:
        self.gltf["meshes"].append({"name": name, "primitives": [primitive]})
        return len(self.gltf["meshes"]) - 1

    def node(self, entry: dict, parent: int | None = None) -> int:
        self.gltf["nodes"].append(entry)
        index = len(self.gltf["nodes"]) - 1
        if parent is None:
            self.gltf["scenes"][0]["nodes"].append(index)
        else:
            self.gltf["nodes"][parent].setdefault("children", []).append(index)
        return index

    def glb(self) -> bytes:
        while len(self.blob) % 4:
            self.blob.append(0)
        self.gltf["buffers"] = [{"byteLength": len(self.blob)}]
        for key in ("meshes", "materials", "accessors", "bufferViews"):
            if not self.gltf[key]:
                del self.gltf[key]
        text = json.dumps(self.gltf, separators=(",", ":"), allow_nan=False).encode()
        text += b" " * (-len(text) % 4)
        total = 12 + 8 + len(text) + (8 + len(self.blob) if self.blob else 0)
        out = bytearray(struct.pack("<III", GLB_MAGIC, 2, total))
        out += struct.pack("<II", len(text), CHUNK_JSON) + text
        if self.blob:
            out += struct.pack("<II", len(self.blob), CHUNK_BIN) + self.blob
        return bytes(out)


def _quaternions(R: np.ndarray) -> np.ndarray:
    """glTF rotations ``(x, y, z, w)`` of rotation matrices (K, 3, 3), signs made continuous so
    that interpolation takes the short way."""
    from ..spatial import matrix_to_quat

    q = matrix_to_quat(R)[:, [1, 2, 3, 0]]
    if len(q) > 1:
        flips = np.cumprod(np.where(np.einsum("ki,ki->k", q[1:], q[:-1]) < 0, -1.0, 1.0))
        q[1:] *= flips[:, None]
    return q


def _slerp(q0: np.ndarray, q1: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Spherical interpolation of unit quaternions (4,) at fractions u (M,); shape (M, 4)."""
    dot = float(np.clip(q0 @ q1, -1.0, 1.0))
    if dot < 0:
        q1, dot = -q1, -dot
    angle = np.arccos(dot)
    if angle < 1e-9:
        out = q0 + u[:, None] * (q1 - q0)
    else:
        s = np.sin(angle)
        out = (np.sin((1 - u) * angle) / s)[:, None] * q0 + (np.sin(u * angle) / s)[:, None] * q1
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def interpolation_error(
    t: np.ndarray, p: np.ndarray, q: np.ndarray, radius: float, i: int, j: int
) -> float:
    """Largest error [m] of samples i+1..j-1 when interpolated between samples i and j."""
    if j - i < 2:
        return 0.0
    u = (t[i + 1 : j] - t[i]) / (t[j] - t[i])
    p_lin = p[i] + u[:, None] * (p[j] - p[i])
    q_lin = _slerp(q[i], q[j], u)
    translation = np.linalg.norm(p[i + 1 : j] - p_lin, axis=1)
    dots = np.clip(np.abs(np.einsum("ki,ki->k", q[i + 1 : j], q_lin)), 0.0, 1.0)
    return float(np.max(translation + radius * 2 * np.arccos(dots)))


def keyframes(t: np.ndarray, p: np.ndarray, q: np.ndarray, radius: float, tolerance: float):
    """Indices of the samples to keep so that interpolating between kept samples reproduces
    every sample within ``tolerance`` [m] (greedy: each keyframe reaches as far as it can,
    found by doubling then bisection)."""
    K = len(t)
    if K <= 2 or tolerance <= 0:
        return np.arange(K)
    keep, i = [0], 0
    while i < K - 1:
        step = 1
        while (
            i + 2 * step < K and interpolation_error(t, p, q, radius, i, i + 2 * step) <= tolerance
        ):
            step *= 2
        lo, hi = i + step, min(i + 2 * step, K - 1)  # lo reaches; hi may not
        if interpolation_error(t, p, q, radius, i, hi) <= tolerance:
            lo = hi
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if interpolation_error(t, p, q, radius, i, mid) <= tolerance:
                lo = mid
            else:
                hi = mid
        keep.append(lo)
        i = lo
    return np.array(keep)


def _toggles(times: np.ndarray, on: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """STEP keyframes (times, on) at the first sample and wherever ``on`` changes."""
    changes = np.flatnonzero(np.diff(on.astype(np.int8))) + 1
    picks = np.concatenate([[0], changes])
    return times[picks], on[picks]


def _span_toggles(times: np.ndarray, spans) -> tuple[np.ndarray, np.ndarray]:
    """STEP keyframes of ``spans`` [(t0, t1)] over a run of ``times``."""
    edges = sorted({float(times[0])} | {t for span in spans for t in span})
    on = np.array([any(t0 <= t < t1 for t0, t1 in spans) for t in edges])
    return np.array(edges), on


def scene_glb(scene, tolerance: float = TOLERANCE) -> bytes:
    """The bytes of an animated .glb of a :class:`rworld_cli.simulate.scene.RunScene`.

    Parameters
    ----------
    tolerance : float
        Keyframe decimation [m]; 0 keeps every sample.
    """
    b = _Builder()
    times = np.asarray(scene.times, dtype=float)
    animated = len(times) > 1
    channels, samplers = [], []
    time_accessors: dict[bytes, int] = {}

    def sampler(t: np.ndarray, values: np.ndarray, kind: str, interpolation: str) -> int:
        key = t.astype(np.float32).tobytes()
        if key not in time_accessors:
            time_accessors[key] = b.accessor(t, "SCALAR", bounds=True)
        samplers.append(
            {
                "input": time_accessors[key],
                "output": b.accessor(values, kind),
                "interpolation": interpolation,
            }
        )
        return len(samplers) - 1

    def animate(node: int, path: str, t, values, kind: str, interpolation: str = "LINEAR"):
        channels.append(
            {
                "sampler": sampler(t, values, kind, interpolation),
                "target": {"node": node, "path": path},
            }
        )

    axes = _axes_mesh(b)
    cube = _cube(b)
    for node in scene.nodes:
        p = node.poses[:, :3, 3]
        q = _quaternions(node.poses[:, :3, :3])
        entry = {
            "name": node.name,
            "translation": p[0].tolist(),
            "rotation": q[0].tolist(),
            "extras": {"kind": node.kind, "frame": node.name},
        }
        primitive = None
        radius = node.axes
        if node.mesh is not None:
            v = node.mesh.vertices
            primitive = {
                "attributes": {"POSITION": b.accessor(v, "VEC3", ARRAY_BUFFER, bounds=True)},
                "indices": b.accessor(node.mesh.faces.reshape(-1), "SCALAR", ELEMENT_ARRAY_BUFFER),
                "mode": TRIANGLES,
            }
            body = b.mesh(node.name, {**primitive, "material": b.material(node.mesh.colour)})
            if not node.highlight:
                entry["mesh"] = body
            radius = float(np.linalg.norm(v, axis=1).max(initial=0.0))
        index = b.node(entry)
        if node.axes:
            b.node({"name": f"{node.name}.axes", "mesh": axes, "scale": [node.axes] * 3}, index)
        if node.lines is not None:  # a camera's field of view
            segments = np.asarray(node.lines, dtype=float).reshape(-1, 3)
            lines = b.mesh(
                f"{node.name}.frustum",
                {
                    "attributes": {
                        "POSITION": b.accessor(segments, "VEC3", ARRAY_BUFFER, bounds=True)
                    },
                    "mode": LINES,
                    "material": b.material(node.line_colour),
                },
            )
            b.node(
                {
                    "name": f"{node.name}.frustum",
                    "mesh": lines,
                    "extras": {"kind": "frustum", "camera": node.name},  # no "frame": not a frame
                },
                index,
            )
        if animated:
            keep = keyframes(times, p, q, max(radius, 0.01), tolerance)
            if len(keep) > 2 or not (
                np.array_equal(p[keep[0]], p[keep[-1]]) and np.array_equal(q[keep[0]], q[keep[-1]])
            ):
                animate(index, "translation", times[keep], p[keep], "VEC3")
                animate(index, "rotation", times[keep], q[keep], "VEC4")
        if node.highlight and primitive is not None:  # the body, or its red twin in contact
            twin = b.mesh(f"{node.name}.collision", {**primitive, "material": b.material(CONTACT)})
            t_on, on = _span_toggles(times, node.highlight)
            for mesh, label, shown in ((body, "body", ~on), (twin, "collision", on)):
                scale = np.repeat(np.where(shown, 1.0, 0.0)[:, None], 3, axis=1)
                child = b.node(
                    {"name": f"{node.name}.{label}", "mesh": mesh, "scale": scale[0].tolist()},
                    index,
                )
                if animated:
                    animate(child, "scale", t_on, scale, "VEC3", "STEP")
    by_name = {node["name"]: i for i, node in enumerate(b.gltf["nodes"])}
    free, contact = (
        b.mesh("cell free", {**cube, "material": b.material(FREE)}),
        b.mesh("cell sensing", {**cube, "material": b.material(CONTACT)}),
    )
    for sensor in scene.sensors:
        parent = by_name[sensor.name]
        for k, (T, size) in enumerate(sensor.boxes):
            place = {
                "translation": T[:3, 3].tolist(),
                "rotation": _quaternions(T[None, :3, :3])[0].tolist(),
            }
            extent = (np.asarray(size) * 0.96).tolist()  # a small gap shows the cells apart
            t_on, on = _toggles(sensor.times, sensor.sensed[:, k])
            for mesh, label, shown in ((free, "free", ~on), (contact, "sensing", on)):
                scales = np.where(shown[:, None], extent, 0.0)
                child = b.node(
                    {
                        "name": f"{sensor.name}[{k}].{label}",
                        "mesh": mesh,
                        **place,
                        "scale": scales[0].tolist(),
                    },
                    parent,
                )
                if animated and len(t_on) > 1:
                    animate(child, "scale", t_on, scales, "VEC3", "STEP")
    if channels:
        b.gltf["animations"] = [{"name": "run", "channels": channels, "samplers": samplers}]
    b.gltf["scenes"][0]["name"] = scene.title
    return b.glb()


def _axes_mesh(b: _Builder) -> int:
    """A unit x-y-z triad as LINES coloured red, green, blue."""
    positions = np.array(
        [[0, 0, 0], [1, 0, 0], [0, 0, 0], [0, 1, 0], [0, 0, 0], [0, 0, 1]], dtype=float
    )
    colours = np.repeat(np.eye(3), 2, axis=0)
    return b.mesh(
        "axes",
        {
            "attributes": {
                "POSITION": b.accessor(positions, "VEC3", ARRAY_BUFFER, bounds=True),
                "COLOR_0": b.accessor(colours, "VEC3", ARRAY_BUFFER),
            },
            "mode": LINES,
        },
    )


def _cube(b: _Builder) -> dict:
    """A unit cube centred on its origin: the primitive of sensor cells (material added)."""
    import itertools

    corners = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))
    faces = np.array(
        [
            [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5],  # -x, +x
            [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],  # -y, +y
            [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],  # -z, +z
        ]
    )  # fmt: skip
    return {
        "attributes": {"POSITION": b.accessor(corners, "VEC3", ARRAY_BUFFER, bounds=True)},
        "indices": b.accessor(faces.reshape(-1), "SCALAR", ELEMENT_ARRAY_BUFFER),
        "mode": TRIANGLES,
    }


# ---------------------------------------------------------------------------------- read
def read_glb(data: bytes, where: str) -> tuple[dict, bytes]:
    """The JSON and binary chunks of a .glb, checked for structure; UserError naming ``where``
    and what is wrong otherwise."""

    def bad(what: str):
        return UserError(f"{where}: not a valid glTF binary file: {what}")

    if len(data) < 20:
        raise bad(f"{len(data)} bytes, shorter than a header")
    magic, version, total = struct.unpack_from("<III", data)
    if magic != GLB_MAGIC:
        raise bad("it does not start with 'glTF'")
    if version != 2:
        raise bad(f"version {version}, not 2")
    if total != len(data):
        raise bad(f"the header says {total} bytes, the file has {len(data)} (cut short?)")
    length, kind = struct.unpack_from("<II", data, 12)
    if kind != CHUNK_JSON or 20 + length > len(data):
        raise bad("no JSON chunk first")
    try:
        gltf = json.loads(data[20 : 20 + length], parse_constant=_no_constant)
    except (UnicodeDecodeError, json.JSONDecodeError, ValueError) as exc:
        raise bad(f"its JSON chunk does not parse ({exc})") from None
    except RecursionError:
        raise bad("its JSON chunk nests too deep") from None
    blob = b""
    offset = 20 + length
    if offset < len(data):
        if offset + 8 > len(data):
            raise bad("a truncated binary chunk")
        blob_length, kind = struct.unpack_from("<II", data, offset)
        if kind != CHUNK_BIN or offset + 8 + blob_length > len(data):
            raise bad("a damaged binary chunk")
        blob = data[offset + 8 : offset + 8 + blob_length]
    asset = gltf.get("asset") if isinstance(gltf, dict) else None
    if not isinstance(asset, dict) or asset.get("version") != "2.0":
        raise bad("no asset version 2.0")
    if not isinstance(asset.get("generator", ""), str):
        raise bad("its asset's generator is not text")
    problem = _structure_problem(gltf, blob)
    if problem:
        raise bad(problem)
    return gltf, blob


def _no_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_TYPE_SIZE = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_PATH_SIZE = {"translation": "VEC3", "rotation": "VEC4", "scale": "VEC3"}


def _structure_problem(gltf: dict, blob: bytes) -> str | None:
    """What makes ``gltf`` (with its binary chunk) unusable by a viewer, or None: the glTF 2.0
    rules this file's kind uses - every index in range, every accessor inside its view, float
    data finite, animation inputs and outputs of one length, a node tree without cycles."""

    def is_int(v) -> bool:
        return isinstance(v, int) and not isinstance(v, bool)

    def items(key: str) -> list:
        value = gltf.get(key, [])
        if not isinstance(value, list) or not all(isinstance(x, dict) for x in value):
            raise _Bad(f"'{key}' is not a list of objects")
        return value

    def index(value, key: str, what: str) -> int:
        if not is_int(value) or not 0 <= value < len(items(key)):
            raise _Bad(f"{what} is {value!r}, not an index into '{key}' ({len(items(key))})")
        return value

    def numbers(value, n: int, what: str) -> None:
        if (
            not isinstance(value, list)
            or len(value) != n
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)
            or not np.isfinite(np.asarray(value, dtype=float)).all()
        ):
            raise _Bad(f"{what} is not {n} finite numbers")

    try:
        buffers = items("buffers")
        if len(buffers) > 1 or not all(
            is_int(b.get("byteLength")) and b["byteLength"] >= 0 for b in buffers
        ):
            raise _Bad("'buffers' is not one buffer with a whole byteLength >= 0")
        declared = sum(b["byteLength"] for b in buffers)
        if declared > len(blob):
            raise _Bad(f"its buffer declares {declared} bytes, the binary chunk has {len(blob)}")
        for key in ("bufferViews", "accessors", "materials", "meshes", "nodes", "scenes"):
            for k, item in enumerate(items(key)):
                if not isinstance(item.get("name", ""), str):
                    raise _Bad(f"{key} {k}'s name is not text")
        for k, anim in enumerate(items("animations")):
            if not isinstance(anim.get("name", ""), str):
                raise _Bad(f"animation {k}'s name is not text")
        views = items("bufferViews")
        for k, v in enumerate(views):
            if v.get("target", ARRAY_BUFFER) not in (ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER) or (
                isinstance(v.get("target"), bool)
            ):
                raise _Bad(f"bufferView {k} has target {v.get('target')!r}")
            index(v.get("buffer"), "buffers", f"bufferView {k}'s buffer")
            offset, length = v.get("byteOffset", 0), v.get("byteLength")
            if not (is_int(offset) and is_int(length) and offset >= 0 and length >= 0):
                raise _Bad(f"bufferView {k} has no whole byteOffset and byteLength")
            if offset + length > len(blob):
                raise _Bad(f"bufferView {k} reaches past the binary chunk")
        accessors = items("accessors")
        for k, a in enumerate(accessors):
            view = views[index(a.get("bufferView"), "bufferViews", f"accessor {k}'s bufferView")]
            kind, component, count = a.get("type"), a.get("componentType"), a.get("count")
            known = isinstance(kind, str) and kind in _TYPE_SIZE
            if not known or not (is_int(component) and component in _COMPONENT_BYTES):
                raise _Bad(f"accessor {k} has type {kind!r} / componentType {component!r}")
            offset = a.get("byteOffset", 0)
            if not (is_int(count) and count >= 1 and is_int(offset) and offset >= 0):
                raise _Bad(f"accessor {k} has no whole count >= 1 and byteOffset")
            for bound in ("min", "max"):
                if bound in a:
                    numbers(a[bound], _TYPE_SIZE[kind], f"accessor {k}'s {bound}")
            size = _TYPE_SIZE[kind] * _COMPONENT_BYTES[component]
            if offset + count * size > view["byteLength"]:
                raise _Bad(f"accessor {k} ({count} x {size} bytes) reaches past its bufferView")
            if component == FLOAT:
                start = view.get("byteOffset", 0) + offset
                values = np.frombuffer(blob, "<f4", count * _TYPE_SIZE[kind], start)
                if not np.isfinite(values).all():
                    raise _Bad(f"accessor {k} holds numbers that are not finite")
        for k, m in enumerate(items("materials")):
            pbr = m.get("pbrMetallicRoughness", {})
            if not isinstance(pbr, dict):
                raise _Bad(f"material {k}'s pbrMetallicRoughness is not an object")
            numbers(pbr.get("baseColorFactor", [1, 1, 1, 1]), 4, f"material {k}'s baseColorFactor")
            for factor in ("metallicFactor", "roughnessFactor"):
                value = pbr.get(factor, 1.0)
                if not isinstance(value, (int, float)) or isinstance(value, bool):
                    raise _Bad(f"material {k}'s {factor} is not a number")
                if not 0.0 <= value <= 1.0:
                    raise _Bad(f"material {k}'s {factor} {value} is outside [0, 1]")
            if not isinstance(m.get("doubleSided", False), bool):
                raise _Bad(f"material {k}'s doubleSided is not true or false")
        for k, mesh in enumerate(items("meshes")):
            primitives = mesh.get("primitives")
            if not isinstance(primitives, list) or not primitives:
                raise _Bad(f"mesh {k} has no primitives")
            for prim in primitives:
                attributes = prim.get("attributes") if isinstance(prim, dict) else None
                if not isinstance(attributes, dict) or "POSITION" not in attributes:
                    raise _Bad(f"mesh {k} has a primitive without POSITION")
                for name, acc in attributes.items():
                    index(acc, "accessors", f"mesh {k}'s {name}")
                if "indices" in prim:
                    acc = accessors[index(prim["indices"], "accessors", f"mesh {k}'s indices")]
                    if acc["componentType"] not in (5121, 5123, 5125) or acc["type"] != "SCALAR":
                        raise _Bad(f"mesh {k}'s indices are not unsigned integers")
                    vertices = accessors[attributes["POSITION"]]["count"]
                    view = views[acc["bufferView"]]
                    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
                    dtype = {5121: "<u1", 5123: "<u2", 5125: "<u4"}[acc["componentType"]]
                    if np.frombuffer(blob, dtype, acc["count"], start).max() >= vertices:
                        raise _Bad(f"mesh {k}'s indices reach past its {vertices} vertices")
                if "material" in prim:
                    index(prim["material"], "materials", f"mesh {k}'s material")
                if not is_int(prim.get("mode", 4)) or prim.get("mode", 4) not in range(7):
                    raise _Bad(f"mesh {k} has primitive mode {prim.get('mode')!r}")
        nodes = items("nodes")
        parent: dict[int, int] = {}
        for k, node in enumerate(nodes):
            if "mesh" in node:
                index(node["mesh"], "meshes", f"node {k}'s mesh")
            children = node.get("children", [])
            if not isinstance(children, list):
                raise _Bad(f"node {k}'s children are not a list")
            for c in children:
                index(c, "nodes", f"node {k}'s child")
                if c in parent or c == k:
                    raise _Bad(f"node {c} has two parents, or is its own")
                parent[c] = k
            for key, n in (("translation", 3), ("rotation", 4), ("scale", 3)):
                if key in node:
                    numbers(node[key], n, f"node {k}'s {key}")
            extras = node.get("extras", {})
            if not isinstance(extras, dict) or not all(isinstance(v, str) for v in extras.values()):
                raise _Bad(f"node {k}'s extras are not names (text)")
        for k in parent:  # a chain of parents that comes back is a cycle
            seen, node = {k}, parent.get(k)
            while node is not None:
                if node in seen:
                    raise _Bad(f"the node tree has a cycle through node {node}")
                seen.add(node)
                node = parent.get(node)
        scenes = items("scenes")
        if "scene" in gltf:
            index(gltf["scene"], "scenes", "'scene'")
        shown: set[int] = set()
        for k, scene in enumerate(scenes):
            for n in scene.get("nodes", []) if isinstance(scene.get("nodes", []), list) else [None]:
                shown.add(index(n, "nodes", f"scene {k}'s node"))
        hidden = sorted(set(range(len(nodes))) - set(parent) - shown)
        if hidden:  # a root node outside every scene is never drawn
            raise _Bad(f"node {hidden[0]} is in no scene and is no node's child")
        for k, anim in enumerate(items("animations")):
            samplers, channels = anim.get("samplers"), anim.get("channels")
            if not isinstance(samplers, list) or not isinstance(channels, list):
                raise _Bad(f"animation {k} has no samplers and channels lists")
            for j, sampler in enumerate(samplers):
                if not isinstance(sampler, dict):
                    raise _Bad(f"animation {k}'s sampler {j} is not an object")
                times = accessors[index(sampler.get("input"), "accessors", "a sampler's input")]
                values = accessors[index(sampler.get("output"), "accessors", "a sampler's output")]
                if times["type"] != "SCALAR" or times["componentType"] != FLOAT:
                    raise _Bad(f"animation {k}'s sampler {j} has no float times")
                if sampler.get("interpolation", "LINEAR") not in ("LINEAR", "STEP"):
                    raise _Bad(f"animation {k}'s sampler {j} interpolates by an unknown rule")
                if times["count"] != values["count"]:
                    raise _Bad(
                        f"animation {k}'s sampler {j} has {times['count']} times for "
                        f"{values['count']} values"
                    )
                view = views[times["bufferView"]]
                start = view.get("byteOffset", 0) + times.get("byteOffset", 0)
                t = np.frombuffer(blob, "<f4", times["count"], start)
                if np.any(np.diff(t) < 0):
                    raise _Bad(f"animation {k}'s sampler {j} has times that go back")
            for j, channel in enumerate(channels):
                target = channel.get("target") if isinstance(channel, dict) else None
                if not isinstance(target, dict):
                    raise _Bad(f"animation {k}'s channel {j} has no target")
                if not is_int(channel.get("sampler")) or not 0 <= channel["sampler"] < len(
                    samplers
                ):
                    raise _Bad(f"animation {k}'s channel {j} names no sampler of it")
                index(target.get("node"), "nodes", f"animation {k}'s channel {j} node")
                path = target.get("path")
                if not isinstance(path, str) or path not in _PATH_SIZE:
                    raise _Bad(f"animation {k}'s channel {j} animates {path!r}")
                output = accessors[samplers[channel["sampler"]]["output"]]
                if output["type"] != _PATH_SIZE[path]:
                    raise _Bad(f"animation {k}'s channel {j} gives {output['type']} for {path}")
    except _Bad as exc:
        return str(exc)
    return None


class _Bad(Exception):
    """One structural problem of a glTF file (internal to :func:`_structure_problem`)."""


def accessor_array(gltf: dict, blob: bytes, index: int) -> np.ndarray:
    """The values of accessor ``index``: (count,) or (count, width)."""
    accessor = gltf["accessors"][index]
    view = gltf["bufferViews"][accessor["bufferView"]]
    dtype = {FLOAT: np.float32, UINT16: np.uint16, UINT32: np.uint32}[accessor["componentType"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[accessor["type"]]
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    values = np.frombuffer(blob, dtype, accessor["count"] * width, start)
    return values if width == 1 else values.reshape(-1, width)
