"""The two samples of samples/python: the dataset screener against the tool's `check` report, and
the Blender snippet's logic (without Blender) against the tool's `play --dump`."""

import csv
import json
import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, shared, tool

SAMPLES = ROOT / "samples" / "python"
sys.path.insert(0, str(SAMPLES))
import blender_mark_penetrations as blender  # noqa: E402


@pytest.mark.parametrize("case", ["builtin", "Soldier on Xbot"])
def test_screener_agrees_with_the_tool_check_report(case, builtin_glb, tmp_path):
    if case == "builtin":  # its own clips, as a clip file
        character, clips = builtin_glb, builtin_glb
    else:  # Soldier's clips retargeted onto Xbot
        character, clips = shared("Xbot.glb"), shared("Soldier.glb")
    folder = tmp_path / "clips"
    folder.mkdir()
    shutil.copy(clips, folder / os.path.basename(clips))
    (folder / "broken.glb").write_bytes(b"glTF not really")
    (folder / "notes.txt").write_text("not an animation file")
    out = tmp_path / "frames.csv"
    run = subprocess.run(
        [sys.executable, str(SAMPLES / "screen_dataset.py"), character, str(folder), "-o", str(out), "--mode", "fast"],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 2, run.stderr  # broken.glb was skipped
    errors = run.stderr.strip().splitlines()
    assert len(errors) == 1 and "broken.glb" in errors[0], run.stderr
    with open(out) as f:
        rows = list(csv.DictReader(f))
    report_path = tmp_path / "report.json"
    subprocess.run(
        [tool(), "check", character, "--clips", str(folder / os.path.basename(clips)), "--mode", "fast", "--report",
         str(report_path)],
        capture_output=True,
    )
    report = json.loads(report_path.read_text())
    expected = {}
    stem = pathlib.Path(clips).stem + "/"  # check names a clip as added: "<file stem>/<name>" when taken
    for clip in report["clips"]:
        name = clip["name"][len(stem) :] if clip["name"].startswith(stem) else clip["name"]
        for pair in clip["part_pairs"]:
            if pair["penetrating_frames"]:
                expected[(name, *pair["parts"])] = (pair["penetrating_frames"], pair["max_depth"])
    got = {}
    for r in rows:
        key = (r["clip"], r["part_a"], r["part_b"])
        count, depth = got.get(key, (0, 0.0))
        got[key] = (count + 1, max(depth, float(r["depth"])))
    assert expected, "the case must penetrate somewhere for the comparison to mean something"
    assert set(got) == set(expected)
    for key, (count, depth) in expected.items():
        assert got[key][0] == count, key
        assert np.float32(got[key][1]) == np.float32(depth), key
    print(f"case {case}: {len(rows)} penetrating frame rows, {len(expected)} clip part pairs, equal to check's report")


class FakeMarkers(list):
    def new(self, name, frame):
        marker = type("Marker", (), {"name": name, "frame": frame})()
        self.append(marker)
        return marker


class FakeScene:
    def __init__(self):
        self.timeline_markers = FakeMarkers()


def test_blender_markers_are_the_tool_penetrating_frames(builtin_glb, tmp_path):
    fps, start, clip = 24.0, 10, 1  # the built-in character's "touch" clip
    markers = blender.penetrating_markers(builtin_glb, fps, start, clip=clip)
    dump = tmp_path / "dump.jsonl"
    subprocess.run(
        [tool(), "play", builtin_glb, "--clip", str(clip), "--fps", str(fps), "--dump", str(dump)],
        check=True,
        capture_output=True,
    )
    expected = []
    for line in map(json.loads, dump.read_text().splitlines()):
        penetrating = [c for c in line["contacts"] if c["kind"] == "penetrating"]
        if penetrating:
            worst = max(penetrating, key=lambda c: c["depth"])
            expected.append((start + line["frame"], worst["parts"]))
    assert expected, "the touch clip penetrates"
    assert [f for f, _ in markers] == [f for f, _ in expected]
    for (_, name), (_, parts) in zip(markers, expected):
        assert name.startswith(f"ss {parts[0]}-{parts[1]} ")
    scene = FakeScene()
    scene.timeline_markers.new("keep: a user's marker", 3)
    scene.timeline_markers.new("ss old run", 5)
    blender.mark(scene, markers)
    names = [m.name for m in scene.timeline_markers]
    assert "keep: a user's marker" in names and "ss old run" not in names
    assert sorted(m.frame for m in scene.timeline_markers if m.name.startswith("ss ")) == [f for f, _ in markers]


def test_blender_snippet_outside_blender_says_so():
    run = subprocess.run([sys.executable, str(SAMPLES / "blender_mark_penetrations.py")], capture_output=True, text=True)
    assert run.returncode == 1 and "inside Blender" in run.stderr


def test_quickstart_counts_the_frames_the_tool_finds(builtin_glb, tmp_path):
    character = shared("CesiumMan.glb")
    run = subprocess.run([sys.executable, str(SAMPLES / "quickstart.py"), character], capture_output=True, text=True,
                         check=True)
    lines = dict(line.split(": ", 1) for line in run.stdout.splitlines() if line.startswith("frames "))
    dump = tmp_path / "dump.jsonl"
    subprocess.run([tool(), "play", character, "--dump", str(dump)], check=True, capture_output=True)
    frames = [json.loads(line) for line in dump.read_text().splitlines()]
    assert int(lines["frames with contacts"]) == sum(1 for f in frames if f["contacts"])
    assert int(lines["frames penetrating"]) == sum(
        1 for f in frames if any(c["kind"] == "penetrating" for c in f["contacts"])
    )
    print(run.stdout)
