"""Reads a clip of a GLB written by skinspheres (fix, retarget) as per-frame skinning matrices.

Pure numpy, no bpy: the skinning matrix of joint j at a frame is world(j) @ inverse_bind(j), in the
file's (glTF, Y-up) space; sampling is at k / fps for k = 0, 1, ... (the tools' frames), LINEAR
between keys (translation and scale lerped, rotations nlerped), holding the ends.
"""

import json
import struct

import numpy as np

_COMPONENTS = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def read_glb(path):
    """The glTF JSON (dict) and the binary chunk (bytes) of a .glb file."""
    with open(path, "rb") as f:
        data = f.read()
    magic, _, length = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or length > len(data):
        raise ValueError(f"{path}: not a GLB file")
    offset, document, binary = 12, None, b""
    while offset + 8 <= length:
        chunk_length, chunk_type = struct.unpack_from("<I4s", data, offset)
        chunk = data[offset + 8 : offset + 8 + chunk_length]
        if chunk_type == b"JSON":
            document = json.loads(chunk)
        elif chunk_type == b"BIN\x00":
            binary = chunk
        offset += 8 + chunk_length
    if document is None:
        raise ValueError(f"{path}: no JSON chunk")
    return document, binary


def accessor(document, binary, index):
    """A float accessor as an array (count, components)."""
    acc = document["accessors"][index]
    if acc.get("componentType") != 5126:
        raise ValueError(f"accessor {index}: not float32")
    width = _COMPONENTS[acc["type"]]
    view = document["bufferViews"][acc["bufferView"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride", 4 * width)
    rows = np.ndarray((acc["count"], width), np.float32, binary, start, (stride, 4))
    return rows.astype(np.float64)


def trs_matrices(translation, rotation, scale):
    """(N, 4, 4) from (N, 3) translations, (N, 4) xyzw quaternions and (N, 3) scales: T @ R @ S."""
    q = rotation / np.linalg.norm(rotation, axis=1, keepdims=True)
    x, y, z, w = q.T
    r = np.stack(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    ).transpose(2, 0, 1)
    m = np.tile(np.eye(4), (len(q), 1, 1))
    m[:, :3, :3] = r * scale[:, None, :]
    m[:, :3, 3] = translation
    return m


def _node_rest(node):
    if "matrix" in node:
        return np.array(node["matrix"], np.float64).reshape(4, 4).T
    t = np.array([node.get("translation", [0, 0, 0])], np.float64)
    r = np.array([node.get("rotation", [0, 0, 0, 1])], np.float64)
    s = np.array([node.get("scale", [1, 1, 1])], np.float64)
    return trs_matrices(t, r, s)[0]


def _sample(times, values, at, path):
    """values (K, C) keyed at times (K,), sampled at `at` (F,)."""
    if path == "rotation":  # nlerp: keys of opposite sign are made to agree first
        signs = np.sign(np.sum(values[1:] * values[:-1], axis=1))
        flips = np.concatenate([[1.0], np.cumprod(np.where(signs == 0, 1.0, signs))])
        values = values * flips[:, None]
    out = np.stack([np.interp(at, times, values[:, c]) for c in range(values.shape[1])], axis=1)
    if path == "rotation":
        out /= np.linalg.norm(out, axis=1, keepdims=True)
    return out


def _parents(document):
    parents = np.full(len(document["nodes"]), -1)
    for i, node in enumerate(document["nodes"]):
        for child in node.get("children", []):
            parents[child] = i
    return parents


def clip_skinning(path, clip_name, fps):
    """The clip named clip_name of a GLB: (joint names, (F, J, 4, 4) skinning matrices world @ inverse
    bind, in the file's space) at F = round(last key time * fps) + 1 frames."""
    document, binary = read_glb(path)
    names = [a.get("name", "") for a in document.get("animations", [])]
    if clip_name not in names:
        raise ValueError(f"{path}: no clip named '{clip_name}' (it has {names})")
    animation = document["animations"][names.index(clip_name)]
    nodes = document["nodes"]
    rest = [_node_rest(n) for n in nodes]
    keyed = {}
    last = 0.0
    for channel in animation["channels"]:
        sampler = animation["samplers"][channel["sampler"]]
        times = accessor(document, binary, sampler["input"])[:, 0]
        values = accessor(document, binary, sampler["output"])
        keyed[(channel["target"]["node"], channel["target"]["path"])] = (times, values)
        last = max(last, float(times[-1]))
    at = np.arange(int(round(last * fps)) + 1) / fps
    local = np.repeat(np.stack(rest)[None], len(at), axis=0)
    for i in {node for node, _ in keyed}:
        t, r, s = _decompose(rest[i])
        parts = {"translation": t, "rotation": r, "scale": s}
        for path_name in parts:
            if (i, path_name) in keyed:
                times, values = keyed[(i, path_name)]
                parts[path_name] = _sample(times, values, at, path_name)
            else:
                parts[path_name] = np.repeat(parts[path_name][None], len(at), axis=0)
        local[:, i] = trs_matrices(parts["translation"], parts["rotation"], parts["scale"])
    world = _world(local, _parents(document))
    skin = document["skins"][0]
    inverse_bind = accessor(document, binary, skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    joints = skin["joints"]
    return [nodes[j].get("name", f"node{j}") for j in joints], world[:, joints] @ inverse_bind[None]


def _decompose(m):
    """Translation (3,), xyzw quaternion (4,) and scale (3,) of an affine matrix without shear."""
    scale = np.linalg.norm(m[:3, :3], axis=0)
    r = m[:3, :3] / scale
    w = np.sqrt(max(0.0, 1 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    x = np.copysign(np.sqrt(max(0.0, 1 + r[0, 0] - r[1, 1] - r[2, 2])) / 2, r[2, 1] - r[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1 - r[0, 0] + r[1, 1] - r[2, 2])) / 2, r[0, 2] - r[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1 - r[0, 0] - r[1, 1] + r[2, 2])) / 2, r[1, 0] - r[0, 1])
    return m[:3, 3].copy(), np.array([x, y, z, w]), scale


def _world(local, parents):
    """(F, N, 4, 4) world matrices from local ones, parents before children or not."""
    world = np.empty_like(local)
    done = np.zeros(len(parents), bool)

    def solve(i):
        if not done[i]:
            p = parents[i]
            if p < 0:
                world[:, i] = local[:, i]
            else:
                solve(p)
                world[:, i] = world[:, p] @ local[:, i]
            done[i] = True

    for i in range(len(parents)):
        solve(i)
    return world
