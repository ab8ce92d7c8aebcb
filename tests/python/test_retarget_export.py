"""`skinspheres retarget`: clips of another rig written as glTF animations on the character.

What another tool plays from the written file is checked with the tests' own glTF sampler
(gltf_sampler.py: numpy, no product code): every joint's world position at every frame time equals
what `play CHARACTER --clips FILE` sampled for the retargeted clip (its --dump), to float rounding.
The file itself is read back by the tool and played: the same triangle contacts in every frame. The animations hold one key per frame at --fps for every joint (translation, rotation and
scale: the root's translation too).
"""

import json
import subprocess

import numpy as np
import pytest

from conftest import shared, tool
from gltf_sampler import Gltf


def run(*args):
    return subprocess.run([tool(), *map(str, args)], capture_output=True, text=True)


def dump(path):
    return [json.loads(line) for line in open(path)]


def check_written(character, clips_file, clip_names, out, tmp_path, fps=30):
    gltf = Gltf(out)
    names = [a.get("name") for a in gltf.animations]
    assert names == clip_names
    joint_nodes = {gltf.nodes[j]["name"] for s in gltf.doc.get("skins", []) for j in s["joints"]}
    for k, name in enumerate(clip_names):
        played = tmp_path / f"played_{k}.jsonl"
        replayed = tmp_path / f"replayed_{k}.jsonl"
        r = run("play", character, "--clips", clips_file, "--clip", name, "--fps", fps, "--dump", played)
        assert r.returncode == 0, r.stderr
        r = run("play", out, "--clip", name, "--fps", fps, "--dump", replayed)
        assert r.returncode == 0, r.stderr
        a, b = dump(played), dump(replayed)
        assert len(a) == len(b) > 1
        # One key per frame for every joint node and channel, at f / fps.
        anim = gltf.animations[k]
        channels = {}
        for ch in anim["channels"]:
            node = gltf.nodes[ch["target"]["node"]]["name"]
            times = gltf.accessor(anim["samplers"][ch["sampler"]]["input"])[:, 0]
            channels.setdefault(node, set()).add(ch["target"]["path"])
            assert len(times) == len(a), (name, node)
            np.testing.assert_allclose(times, np.arange(len(a)) / fps, rtol=0, atol=1e-6)
        for node in joint_nodes:
            assert channels.get(node) == {"translation", "rotation", "scale"}, (name, node, channels.get(node))
        height = max(np.ptp(np.array(f["joints"])[:, 1]) for f in a)
        joint_names = a[0]["joint_names"]  # the dump names them in its first line
        for f, (x, y) in enumerate(zip(a, b)):
            # The tool plays the written file as it played the retargeted clip: the same triangle
            # pairs (a property of the posed mesh), depths to float rounding. The sphere pairs too
            # where the written mesh fits to the same spheres (the exporter may store a mesh in
            # another space: Xbot's fit differs by a float's rounding, which the contacts do not see).
            assert [(c["parts"], c["kind"], c["triangles"]) for c in x["contacts"]] == [
                (c["parts"], c["kind"], c["triangles"]) for c in y["contacts"]], (name, f)
            for c, d in zip(x["contacts"], y["contacts"]):
                assert abs(c["depth"] - d["depth"]) <= 1e-6 * height, (name, f, c["parts"])
            if x["spheres"] == y["spheres"]:
                assert x["pairs"] == y["pairs"], (name, f)
            # Another reader plays it the same: world positions from the tests' own sampler.
            world = gltf.world_by_name(k, f / fps)
            for joint, p in zip(joint_names, x["joints"]):
                np.testing.assert_allclose(world[joint][:3, 3], p, rtol=0, atol=1e-5 * height, err_msg=f"{name} {f} {joint}")


def test_other_rig_onto_the_builtin_character(tmp_path):
    character, rig = tmp_path / "builtin.glb", tmp_path / "rotated.glb"
    assert run("export-builtin", character).returncode == 0
    assert run("export-builtin", rig, "--rotate-frames", 3, "--bone-scale", 1.3).returncode == 0
    out = tmp_path / "out.glb"
    r = run("retarget", character, "--clips", rig, "-o", out)
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and "2 clips, 152 frames at 30 fps" in r.stdout
    check_written(character, rig, ["rotated/walk", "rotated/touch"], out, tmp_path)
    # --clip picks one; the character's own clips are not written.
    one = tmp_path / "one.glb"
    assert run("retarget", character, "--clips", rig, "--clip", "touch", "-o", one).returncode == 0
    assert [a["name"] for a in Gltf(one).animations] == ["rotated/touch"]


def test_shared_characters_on_each_other(tmp_path):
    soldier, xbot = shared("Soldier.glb"), shared("Xbot.glb")
    out = tmp_path / "xbot_with_soldier.glb"
    r = run("retarget", xbot, "--clips", soldier, "--clip", "Walk", "-o", out)
    assert r.returncode == 0, r.stderr
    check_written(xbot, soldier, ["Walk"], out, tmp_path)  # a name Xbot's own clips do not take


@pytest.mark.parametrize("args,message", [
    ([], "retarget needs --clips"),
    (["--clips", "{rig}", "-o", "{tmp}/x.fbx"], "-o takes a .glb file"),
    (["--clips", "{rig}", "--clip", "nosuch"], "--clip nosuch: no such clip among rotated/walk, rotated/touch"),
    (["--clips", "{rig}", "--source-rest", "99999"], "lies past the end of clip"),
])
def test_bad_input_is_one_line_and_exit_2(args, message, tmp_path):
    character, rig = tmp_path / "builtin.glb", tmp_path / "rotated.glb"
    assert run("export-builtin", character).returncode == 0
    assert run("export-builtin", rig, "--rotate-frames", 3).returncode == 0
    args = [a.format(rig=rig, tmp=tmp_path) for a in args]
    if "-o" not in args:
        args += ["-o", str(tmp_path / "out.glb")]
    r = run("retarget", character, *args)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and message in r.stderr, r.stderr
    assert not (tmp_path / "out.glb").exists()


def test_python_retarget_writes_what_the_tool_writes(tmp_path):
    import skinspheres

    character, rig = tmp_path / "builtin.glb", tmp_path / "rotated.glb"
    assert run("export-builtin", character).returncode == 0
    assert run("export-builtin", rig, "--rotate-frames", 3, "--bone-scale", 1.3).returncode == 0
    (tmp_path / "tool").mkdir()
    (tmp_path / "python").mkdir()
    by_tool, by_python = tmp_path / "tool" / "out.glb", tmp_path / "python" / "out.glb"  # the name is written too
    assert run("retarget", character, "--clips", rig, "-o", by_tool).returncode == 0
    result = skinspheres.retarget(character, [rig], by_python)
    assert result["clips"] == ["rotated/walk", "rotated/touch"]
    assert result["frames"] == 152 and result["joints"] == 26
    np.testing.assert_allclose(result["durations"], [1.0, 4.0])
    assert any("retargeted in world space" in n for n in result["notes"])
    assert by_python.read_bytes() == by_tool.read_bytes()
    with pytest.raises(skinspheres.InvalidArgument, match="lies past the end of clip"):
        skinspheres.retarget(character, [rig], tmp_path / "no.glb", source_rest="99999")
    with pytest.raises(skinspheres.NotFound, match="no such clip"):
        skinspheres.retarget(character, [rig], tmp_path / "no.glb", clip="nosuch")
    assert not (tmp_path / "no.glb").exists()
