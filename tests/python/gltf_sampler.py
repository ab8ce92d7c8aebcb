"""An independent glTF 2.0 pose sampler in numpy, for the Python tests.

It shares no code with the library: it reads the GLB container and accessors itself, samples the
animation channels (STEP, LINEAR with slerp for rotations, CUBICSPLINE Hermite) at a time, and
composes the node tree in float64 into world matrices, keyed by node name. The tests pose the
characters with it, so that the joint matrices they feed the module do not come from the library
they check.
"""

import json
import struct

import numpy as np

_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


class Gltf:
    def __init__(self, path):
        with open(path, "rb") as f:
            data = f.read()
        magic, version, _ = struct.unpack_from("<4sII", data, 0)
        if magic != b"glTF" or version != 2:
            raise ValueError(f"{path}: not a GLB 2.0 file")
        offset, self.bin = 12, b""
        while offset < len(data):
            length, kind = struct.unpack_from("<I4s", data, offset)
            chunk = data[offset + 8 : offset + 8 + length]
            if kind == b"JSON":
                self.doc = json.loads(chunk)
            elif kind == b"BIN\x00":
                self.bin = chunk
            offset += 8 + length
        self.nodes = self.doc.get("nodes", [])
        self.parent = [-1] * len(self.nodes)
        for i, n in enumerate(self.nodes):
            for c in n.get("children", []):
                self.parent[c] = i
        self.animations = self.doc.get("animations", [])
        self._accessors = {}

    def accessor(self, index):
        if index not in self._accessors:
            self._accessors[index] = self._read_accessor(index)
        return self._accessors[index]

    def _read_accessor(self, index):
        a = self.doc["accessors"][index]
        width = _WIDTH[a["type"]]
        dtype = np.dtype(_COMPONENTS[a["componentType"]])
        count = a["count"]
        if "bufferView" not in a:
            return np.zeros((count, width), np.float64)
        view = self.doc["bufferViews"][a["bufferView"]]
        start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        stride = view.get("byteStride", width * dtype.itemsize)
        rows = np.ndarray((count, width), dtype, self.bin, start, (stride, dtype.itemsize))
        out = rows.astype(np.float64)
        if a.get("normalized"):
            out /= float(np.iinfo(dtype).max)
        return out

    def rest_trs(self, node):
        n = self.nodes[node]
        if "matrix" in n:
            return np.array(n["matrix"], np.float64).reshape(4, 4).T, None
        t = np.array(n.get("translation", [0, 0, 0]), np.float64)
        r = np.array(n.get("rotation", [0, 0, 0, 1]), np.float64)
        s = np.array(n.get("scale", [1, 1, 1]), np.float64)
        return None, (t, r, s)

    def duration(self, animation):
        anim = self.animations[animation]
        return max(float(self.accessor(s["input"]).max()) for s in anim["samplers"])

    def world(self, animation, time, turns=None):
        """Every node's world matrix (4x4, float64) at `time` seconds of the animation (None: rest);
        turns: {node: 4x4} applied after the node's local transform (a posed joint)."""
        overrides = {}
        if animation is not None:
            anim = self.animations[animation]
            for channel in anim["channels"]:
                target = channel["target"]
                if "node" not in target or target["path"] not in ("translation", "rotation", "scale"):
                    continue
                sampler = anim["samplers"][channel["sampler"]]
                value = _sample(
                    self.accessor(sampler["input"])[:, 0],
                    self.accessor(sampler["output"]),
                    sampler.get("interpolation", "LINEAR"),
                    target["path"],
                    time,
                )
                overrides.setdefault(target["node"], {})[target["path"]] = value
        local = []
        for i in range(len(self.nodes)):
            matrix, trs = self.rest_trs(i)
            if matrix is not None and i not in overrides:
                local.append(matrix)
                continue
            t, r, s = trs if trs is not None else (np.zeros(3), np.array([0, 0, 0, 1.0]), np.ones(3))
            o = overrides.get(i, {})
            local.append(_compose(o.get("translation", t), o.get("rotation", r), o.get("scale", s)))
        for i, turn in (turns or {}).items():
            local[i] = local[i] @ turn
        world = [None] * len(self.nodes)

        def resolve(i):
            if world[i] is None:
                p = self.parent[i]
                world[i] = local[i] if p < 0 else resolve(p) @ local[i]
            return world[i]

        for i in range(len(self.nodes)):
            resolve(i)
        return world

    def world_by_name(self, animation, time, turns=None):
        world = self.world(animation, time, turns)
        return {n.get("name", f"node{i}"): m for i, (n, m) in enumerate(zip(self.nodes, world))}

    def random_turns(self, rng, nodes, max_angle):
        """A random rotation of up to max_angle radians about a random axis for each node."""
        turns = {}
        for i in nodes:
            axis = rng.normal(size=3)
            axis /= np.linalg.norm(axis)
            q = np.append(axis * np.sin(rng.uniform(0, max_angle) / 2), 0.0)
            q[3] = np.sqrt(max(0.0, 1.0 - float(q[:3] @ q[:3])))
            turns[i] = _compose(np.zeros(3), q, np.ones(3))
        return turns


def _compose(t, q, s):
    x, y, z, w = q / np.linalg.norm(q)
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    m = np.eye(4)
    m[:3, :3] = r * s[None, :]
    m[:3, 3] = t
    return m


def _slerp(a, b, u):
    d = float(np.dot(a, b))
    if d < 0:
        b, d = -b, -d
    if d > 0.9995:
        q = a + u * (b - a)
    else:
        theta = np.arccos(d)
        q = (np.sin((1 - u) * theta) * a + np.sin(u * theta) * b) / np.sin(theta)
    return q / np.linalg.norm(q)


def _sample(times, values, interpolation, path, t):
    n = len(times)
    if interpolation == "CUBICSPLINE":
        values = values.reshape(n, 3, -1)
        keys = values[:, 1]
    else:
        keys = values
    if t <= times[0] or n == 1:
        return keys[0].copy()
    if t >= times[-1]:
        return keys[-1].copy()
    k = int(np.searchsorted(times, t, side="right")) - 1
    t0, t1 = times[k], times[k + 1]
    u = (t - t0) / (t1 - t0)
    if interpolation == "STEP":
        return keys[k].copy()
    if interpolation == "CUBICSPLINE":
        dt = t1 - t0
        p0, m0 = values[k, 1], values[k, 2] * dt
        p1, m1 = values[k + 1, 1], values[k + 1, 0] * dt
        u2, u3 = u * u, u * u * u
        v = (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * m1
        return v / np.linalg.norm(v) if path == "rotation" else v
    if path == "rotation":
        return _slerp(keys[k], keys[k + 1], u)
    return keys[k] + u * (keys[k + 1] - keys[k])


def playback_time(time, duration):
    """The clip time a playback time samples: the clip's end at t = duration, then looping."""
    if duration <= 0:
        return 0.0
    if time <= duration:
        return time
    return time - np.floor(time / duration) * duration


def skin(mesh, world):
    """Linear blend skinning in float64 of a SphereSet's mesh (SphereSet.mesh) by set-joint world
    matrices world[j] (4x4): v' = sum_k w_k G_{joint(k)} IBM_k v."""
    positions = mesh["positions_bind"].astype(np.float64)
    offsets = mesh["influence_offsets"].astype(np.int64)
    binds = mesh["influence_binds"].astype(np.int64)
    weights = mesh["influence_weights"].astype(np.float64)
    skinning = np.stack([world[j] @ ibm.astype(np.float64) for j, ibm in zip(mesh["bind_joints"], mesh["inverse_binds"])])
    vertex = np.repeat(np.arange(len(positions)), np.diff(offsets))
    homogeneous = np.concatenate([positions, np.ones((len(positions), 1))], axis=1)
    moved = np.einsum("kij,kj->ki", skinning[binds], homogeneous[vertex])[:, :3] * weights[:, None]
    out = np.zeros((len(positions), 3))
    np.add.at(out, vertex, moved)
    return out
