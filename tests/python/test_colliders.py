"""`skinspheres.colliders`: the arrays, and every writer's file read back by a parser written here.

Each format is parsed on its own terms (the .tscn's nodes and properties, the C# script's shape table,
the .usda's prims and attributes, the JSON list) and every shape rebuilt in world space at rest with
the joints' rest matrices from the tests' own glTF reader (gltf_sampler.py, no product code): the
heads, tails and radii must be those of the arrays colliders() returns for the same call.
"""

import json
import re

import numpy as np
import pytest

import skinspheres
from gltf_sampler import Gltf


def rigid(m):
    """The matrix with its scale divided out of each column."""
    out = np.array(m, dtype=np.float64)
    out[:3, :3] /= np.linalg.norm(out[:3, :3], axis=0)
    return out


def world_shapes(result, rest):
    """(heads, tails) in world space at rest, from the arrays (heads and tails in rigid frames)."""
    heads, tails = [], []
    for j, h, t in zip(result["joint"], result["head"], result["tail"]):
        f = rigid(rest[result["joint_names"][j]])
        heads.append(f[:3, :3] @ h + f[:3, 3])
        tails.append(f[:3, :3] @ t + f[:3, 3])
    return np.array(heads), np.array(tails)


def quat_rotate(q, v):
    """Rotates v by the unit quaternion q = (w, x, y, z)."""
    w, u = q[0], np.array(q[1:])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def numbers(text):
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?", text)]


@pytest.fixture(scope="module")
def rest(builtin_glb):
    return Gltf(builtin_glb).world_by_name(None, 0.0)


def run(builtin_glb, tmp_path, fmt, suffix):
    out = tmp_path / f"out{suffix}"
    result = skinspheres.colliders(builtin_glb, budget=10, fps=5, format=fmt, output=out)
    assert result["exit_code"] == 0
    assert len(result["joint"]) == len(result["colliders"]) <= 10
    return result, out.read_text()


def test_arrays_and_report(builtin_glb):
    r = skinspheres.colliders(builtin_glb, budget=10, fps=5, compare=True)
    assert r["format"] == "skinspheres.colliders"
    n = len(r["joint"])
    assert 8 <= n <= 10 and r["head"].shape == (n, 3) and r["tail"].shape == (n, 3)
    assert r["head"].dtype == np.float32 and r["joint"].dtype == np.uint32
    assert (r["head_radius"] > 0).all() and (r["tail_radius"] > 0).all()
    assert r["summary"]["min_covered"] >= 0.97
    # At 10 shapes the per-bone capsules keep the 10 largest bones and leave the rest uncovered.
    assert r["summary"]["min_covered"] > r["baseline"]["per_bone_covering"]["min_covered"]
    assert [c["joint"] for c in r["colliders"]] == [r["joint_names"][j] for j in r["joint"]]


def test_json(builtin_glb, tmp_path, rest):
    r, text = run(builtin_glb, tmp_path, "json", ".json")
    doc = json.loads(text)
    heads, tails = world_shapes(r, rest)
    for k, c in enumerate(doc["colliders"]):
        m = np.array(rest[c["joint"]])
        assert np.allclose(m[:3, :3] @ c["offset"] + m[:3, 3], heads[k], atol=1e-4)
        assert np.allclose(m[:3, :3] @ c["tail"] + m[:3, 3], tails[k], atol=1e-4)
        assert c["radius"] == pytest.approx(r["head_radius"][k], rel=1e-6)
        assert c["tail_radius"] == pytest.approx(r["tail_radius"][k], rel=1e-6)


def test_godot(builtin_glb, tmp_path, rest):
    r, text = run(builtin_glb, tmp_path, "godot", ".tscn")
    assert text.startswith("[gd_scene format=3]")
    nodes = re.split(r"\n(?=\[node )", text)[2:]  # after the header and the simulator
    assert len(nodes) == len(r["joint"])
    heads, tails = world_shapes(r, rest)
    for k, node in enumerate(nodes):
        kind = re.search(r'type="(\w+)"', node).group(1)
        bone = re.search(r'bone_name = "([^"]*)"', node).group(1)
        assert bone == r["joint_names"][r["joint"][k]]
        assert int(re.search(r"\nbone = (\d+)", node).group(1)) == r["joint"][k]
        pos = np.array(numbers(re.search(r"position_offset = Vector3\(([^)]*)\)", node).group(1)))
        qx, qy, qz, qw = numbers(re.search(r"rotation_offset = Quaternion\(([^)]*)\)", node).group(1))
        radius = numbers(re.search(r"\nradius = (\S+)", node).group(1))[0]
        assert radius == pytest.approx(max(r["head_radius"][k], r["tail_radius"][k]), rel=1e-6)
        f = rigid(rest[bone])
        if kind == "SpringBoneCollisionSphere3D":
            ends = [pos, pos]
        else:
            assert kind == "SpringBoneCollisionCapsule3D"
            half = numbers(re.search(r"\nheight = (\S+)", node).group(1))[0] / 2 - radius  # the mid height's half
            axis = quat_rotate((qw, qx, qy, qz), np.array([0.0, 1.0, 0.0]))
            ends = [pos - half * axis, pos + half * axis]
        world = [f[:3, :3] @ e + f[:3, 3] for e in ends]
        assert np.allclose(world[0], heads[k], atol=1e-4) and np.allclose(world[1], tails[k], atol=1e-4)


def test_unity(builtin_glb, tmp_path, rest):
    r, text = run(builtin_glb, tmp_path, "unity", ".cs")
    assert "[MenuItem(\"Tools/skinspheres/Add colliders\")]" in text and "ClothSphereColliderPair" in text
    rows = re.findall(r"new Shape \{ bone = \"([^\"]*)\", head = new Vector3\(([^)]*)\), tail = new Vector3\(([^)]*)\), "
                      r"headRadius = (\S+)f, tailRadius = (\S+)f, sphere = (true|false) \}", text)
    assert len(rows) == len(r["joint"])
    heads, tails = world_shapes(r, rest)
    for k, (bone, head, tail, rh, rt, sphere) in enumerate(rows):
        m = np.array(rest[bone])
        scale = np.linalg.norm(m[:3, :3], axis=0).mean()
        for text_vec, want in ((head, heads[k]), (tail, tails[k])):
            x, y, z = (float(v.rstrip("f")) for v in text_vec.split(","))
            assert np.allclose(m[:3, :3] @ np.array([-x, y, z]) + m[:3, 3], want, atol=1e-4)  # x mirrored back
        assert float(rh) * scale == pytest.approx(r["head_radius"][k], rel=1e-5)
        assert float(rt) * scale == pytest.approx(r["tail_radius"][k], rel=1e-5)
        assert (sphere == "true") == bool(np.array_equal(r["head"][k], r["tail"][k]))


def test_usd(builtin_glb, tmp_path, rest):
    r, text = run(builtin_glb, tmp_path, "usd", ".usda")
    assert text.startswith("#usda 1.0")
    prims = re.split(r"\n    def Xform ", text)[1:]
    assert len(prims) == len(r["joint"])
    heads, tails = world_shapes(r, rest)
    for k, prim in enumerate(prims):
        rows = numbers(re.search(r"matrix4d xformOp:transform = (.*)", prim).group(1))
        frame = np.array(rows).reshape(4, 4).T  # USD rows are row vectors
        kind = re.search(r"def (\w+) \"shape\"", prim).group(1)
        assert "PhysicsCollisionAPI" in prim
        t = np.array(numbers(re.search(r"xformOp:translate = \(([^)]*)\)", prim).group(1)))
        q = numbers(re.search(r"xformOp:orient = \(([^)]*)\)", prim).group(1))
        if kind == "Sphere":
            ends, radii = [t, t], [numbers(re.search(r"double radius = (\S+)", prim).group(1))[0]] * 2
        else:
            half = numbers(re.search(r"double height = (\S+)", prim).group(1))[0] / 2
            axis = quat_rotate(q, np.array([0.0, 0.0, 1.0]))
            ends = [t - half * axis, t + half * axis]
            if kind == "Capsule_1":
                radii = [numbers(re.search(r"radiusBottom = (\S+)", prim).group(1))[0],
                         numbers(re.search(r"radiusTop = (\S+)", prim).group(1))[0]]
            else:
                assert kind == "Capsule"
                radii = [numbers(re.search(r"double radius = (\S+)", prim).group(1))[0]] * 2
        world = [frame[:3, :3] @ e + frame[:3, 3] for e in ends]
        assert np.allclose(world[0], heads[k], atol=1e-4) and np.allclose(world[1], tails[k], atol=1e-4)
        assert radii == pytest.approx([r["head_radius"][k], r["tail_radius"][k]], rel=1e-6)


def test_refusals(builtin_glb, tmp_path):
    with pytest.raises(skinspheres.InvalidArgument, match="holds spheres only"):
        skinspheres.colliders(builtin_glb, format="vrm0", shapes="capsules")
    with pytest.raises(skinspheres.InvalidArgument, match="--format"):
        skinspheres.colliders(builtin_glb, format="fbx")
    with pytest.raises(skinspheres.InvalidArgument, match="--budget"):
        skinspheres.colliders(builtin_glb, budget=0)
    with pytest.raises(skinspheres.FileNotFound):
        skinspheres.colliders(str(tmp_path / "missing.glb"))
