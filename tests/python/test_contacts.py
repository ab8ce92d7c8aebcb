"""Python contacts equal the C++ API's (through the C API) on every frame of every clip of the
shared characters and the built-in one, and on random poses, in both modes, from joint matrices and skinned positions
computed here by an independent numpy sampler; and play() equals the command-line tool's play."""

import json
import subprocess

import numpy as np
import pytest

import skinspheres as ss
from capi_client import CApi, CInstance
from characters import FPS, character
from conftest import SHARED, c_library, character_path, tool

NAMES = ["builtin"] + SHARED


def bits(a):
    """An array's bytes as unsigned integers: equality is bit for bit (-0.0 != 0.0, NaN == NaN)."""
    a = np.ascontiguousarray(a)
    return a.view(np.uint32 if a.dtype.itemsize % 4 == 0 else np.uint16)


def same(a, b):
    return a.shape == b.shape and np.array_equal(bits(a), bits(b))


def assert_frame_equal(py_pairs, py_contacts, c_pairs, c_parts, c_tris, where):
    for field in ("sphere_i", "sphere_j", "depth", "part_i", "part_j"):
        assert same(py_pairs[field], c_pairs[field]), f"{where}: sphere pairs differ in {field}"
    parts, tris = py_contacts
    mapping = {
        "part_a": "part_a",
        "part_b": "part_b",
        "kind": "kind",
        "depth": "depth",
        "min_distance": "min_distance",
        "normal": "normal",
        "center": "center",
        "triangle_pairs": "triangle_pair_count",
        "intersecting": "intersecting_count",
        "sphere_pairs": "sphere_pair_count",
        "first_triangle_pair": "first_triangle_pair",
    }
    for mine, theirs in mapping.items():
        assert same(parts[mine], c_parts[theirs].astype(parts[mine].dtype)), f"{where}: part contacts differ in {mine}"
    owner = np.repeat(np.arange(len(c_parts), dtype=np.uint32), c_parts["triangle_pair_count"])
    assert same(tris["part_contact"], owner), f"{where}: triangle contacts' part pairs differ"
    for mine, theirs in {"triangle_a": "triangle_a", "triangle_b": "triangle_b", "kind": "kind", "distance": "distance",
                         "point": "point", "on_a": "on_a", "on_b": "on_b"}.items():
        assert same(tris[mine], c_tris[theirs]), f"{where}: triangle contacts differ in {mine}"


@pytest.mark.parametrize("mode", ["fast", "exact"])
@pytest.mark.parametrize("name", NAMES)
def test_contacts_equal_the_c_api_on_every_clip_frame(name, mode, builtin_glb, tmp_path_factory):
    ch = character(name, character_path(name, builtin_glb), tmp_path_factory)
    api = CApi(c_library())
    asset = ss.Asset(ss.load(ch.set_path), touch_tolerance=ss.DEFAULT_TOUCH_TOLERANCE)
    inst = asset.instance(ch.engine_names)
    assert inst.extra_joints == ([] if ch.engine_names is None else ["engine_helper_bone"])
    oracle = CInstance(api, ch.set_path, ch.engine_names, touch_tolerance=ss.DEFAULT_TOUCH_TOLERANCE)
    frames = pairs_total = contacts_total = 0
    try:
        for clip, time, turns in ch.poses():
            engine, set_world = ch.pose(clip, time, turns)
            where = f"{name} clip {clip} t={time:.4f}{' random pose' if turns else ''} {mode}"
            # float64 and not contiguous (every other matrix of a doubled stack) on the Python side.
            doubled = np.repeat(engine, 2, axis=0)[::2]
            if mode == "fast":
                inst.update_fast(doubled)
                py_pairs = inst.sphere_pairs()
                py_contacts = inst.contacts()
                c_frame = oracle.frame(engine)
            else:
                positions = ch.skinned(set_world)
                inst.update_exact(positions, doubled)
                py_pairs = inst.sphere_pairs()
                py_contacts = inst.contacts(positions)
                c_frame = oracle.frame(engine, positions)
            assert_frame_equal(py_pairs, py_contacts, *c_frame, where)
            frames += 1
            pairs_total += len(py_pairs)
            contacts_total += len(py_contacts.triangles)
    finally:
        oracle.close()
    print(f"{name} {mode}: {frames} frames, {pairs_total} sphere pairs, {contacts_total} triangle contacts, all equal")
    assert frames > 0 and pairs_total > 0


def read_dump(path):
    with open(path) as f:
        return [json.loads(line) for line in f]


@pytest.mark.parametrize("mode", ["fast", "exact"])
@pytest.mark.parametrize("name", NAMES)
def test_play_equals_the_tool_and_the_sampler_agrees(name, mode, builtin_glb, tmp_path_factory, tmp_path):
    ch = character(name, character_path(name, builtin_glb), tmp_path_factory)
    clip = len(ch.gltf.animations) - 1  # the last clip (RobotExpressive: Wave; Soldier: Walk)
    dump = tmp_path / "dump.jsonl"
    subprocess.run(
        [tool(), "play", ch.glb, "--spheres", ch.set_path, "--clip", str(clip), "--mode", mode, "--fps", str(FPS),
         "--dump", str(dump)],
        check=True,
        capture_output=True,
    )
    lines = read_dump(dump)
    result = ss.play(ch.glb, clip=clip, mode=mode, fps=FPS, spheres=ch.set_path)
    assert result["frames"] == len(lines)
    names = result["part_names"]
    sp, pc, tc = result["sphere_pairs"], result["part_contacts"], result["triangle_contacts"]
    height = result["body_height"]
    joint_names = lines[0]["joint_names"]
    for line in lines:
        f = line["frame"]
        mine = sp[sp["frame"] == f]
        assert [[int(i), int(j)] for i, j in zip(mine["sphere_i"], mine["sphere_j"])] == line["pairs"], f"frame {f}: sphere pairs"
        parts = pc[pc["frame"] == f]
        assert len(parts) == len(line["contacts"]), f"frame {f}: part pairs"
        for row, entry in zip(parts, line["contacts"]):
            assert [names[row["part_a"]], names[row["part_b"]]] == entry["parts"]
            assert np.float32(entry["depth"]) == row["depth"]
            assert ("penetrating" if row["kind"] == ss.PENETRATING else "touching") == entry["kind"]
            first, count = int(row["first_triangle_pair"]), int(row["triangle_pairs"])
            tris = tc[first : first + count]
            assert (tris["frame"] == f).all()
            intersecting = tris[tris["kind"] == ss.INTERSECTING]
            assert [[int(t), int(u)] for t, u in zip(intersecting["triangle_a"], intersecting["triangle_b"])] == entry[
                "triangles"
            ]
        # The independent sampler poses the skin's joints where the library does.
        # (by name, where the name is the node's alone: RobotExpressive repeats some).
        by_name = ch.gltf.world_by_name(clip, line["clip_time"])
        unique = [k for k, n in enumerate(joint_names) if [m.get("name") for m in ch.gltf.nodes].count(n) == 1]
        assert len(unique) >= 0.5 * len(joint_names)
        mine = np.array([by_name[joint_names[k]][:3, 3] for k in unique])
        theirs = np.array(line["joints"])[unique]
        assert np.abs(mine - theirs).max() <= 1e-4 * height, f"frame {f}: the sampler disagrees"
    print(f"{name} {mode}: {len(lines)} frames, {len(sp)} sphere pairs, {len(tc)} triangle contacts, equal to the tool")
