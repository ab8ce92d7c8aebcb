"""check() is the tool's check; the type stubs describe the module that is there."""

import ast
import json
import pathlib
import subprocess

import skinspheres as ss
import skinspheres._skinspheres as native
from conftest import shared, tool


def without_times(report):
    report = dict(report)
    report["summary"] = {k: v for k, v in report["summary"].items() if k != "seconds"}
    report.pop("exit_code", None)
    return report


def test_check_returns_the_tool_report(tmp_path):
    character, clips = shared("Xbot.glb"), shared("Soldier.glb")
    path = tmp_path / "report.json"
    run = subprocess.run([tool(), "check", character, "--clips", clips, "--mode", "fast", "--report", str(path)],
                         capture_output=True)
    mine = ss.check(character, [clips], mode="fast")
    assert mine["exit_code"] == run.returncode
    assert without_times(mine) == without_times(json.loads(path.read_text()))
    assert mine["summary"]["clips"] == len(ss.clip_names(clips))


def test_check_reports_an_unreadable_file_and_runs_the_others(tmp_path, builtin_glb):
    broken = tmp_path / "broken.glb"
    broken.write_bytes(b"glTF?")
    report = ss.check(builtin_glb, [str(broken), builtin_glb], mode="fast")
    assert report["exit_code"] == 2
    assert [e["file"] for e in report["errors"]] == [str(broken)]
    assert report["summary"]["clips"] == len(ss.clip_names(builtin_glb)) > 0


def test_fit_meets_the_sphere_budget_and_refuses_one_below_the_parts():
    default = ss.fit()  # the built-in character
    assert len(default.radii) > 25
    budget = ss.fit(max_spheres=25)
    assert len(budget.radii) <= 25
    parts = len(set(budget.sphere_part.tolist()))
    try:
        ss.fit(max_spheres=parts - 1)
    except ss.InvalidArgument as e:
        assert f"max spheres {parts - 1} is below its {parts} body parts" in str(e)
    else:
        raise AssertionError("a budget below the part count was accepted")


def test_fit_takes_split_rounds_and_refuses_them_out_of_range():
    # docs/FIT_REPORT.md, "Split rounds": with no standoff target the rounds spend more of the budget.
    one = ss.fit(target_standoff=0.0, split_rounds=1)
    rounds = ss.fit(target_standoff=0.0, split_rounds=8)
    assert len(one) < len(rounds) <= 200
    assert one.fit_report["split_rounds"] == 1
    assert 1 < rounds.fit_report["split_rounds"] <= 8
    assert rounds.fit_report["standoff_after"] < one.fit_report["standoff_after"]
    try:
        ss.fit(split_rounds=0)
    except ss.InvalidArgument as e:
        assert "--split-rounds must be in 1..64 (got 0)" in str(e)
    else:
        raise AssertionError("0 split rounds were accepted")


def test_fit_with_piece_edge_writes_triangle_pieces(tmp_path):
    # docs/TRIANGLE_PIECES.md: the built-in character's triangles longer than 2% of its height cut;
    # the set is written as JSON version 4 (rules on triangles) with pieces, and reads back.
    cut = ss.fit(piece_edge=0.02)
    path = tmp_path / "cut.json"
    cut.save(path)
    doc = json.loads(path.read_text())
    assert doc["version"] == 4
    assert sum(len(s.get("pieces", [])) for s in doc["spheres"]) > 0
    assert len(ss.load(path)) == len(cut)
    whole = tmp_path / "whole.json"
    ss.fit().save(whole)
    assert json.loads(whole.read_text())["version"] == 4
    assert "pieces" not in json.dumps(json.loads(whole.read_text())["spheres"])


def test_fit_states_its_contact_rules(tmp_path):
    # contact_rules.h: rules on triangles, hops and the rest gap as fitted (a share of the rest
    # height, stored in model units), kept through a file; out-of-range values are refused.
    default = ss.fit()
    assert default.contact_rules == "triangles"
    assert default.contact_hops == 1
    wide = ss.fit(hops=2, rest_gap=0.02)
    assert wide.contact_hops == 2
    assert abs(wide.rest_gap - 2 * default.rest_gap) <= 1e-6 * wide.rest_gap
    path = tmp_path / "wide.ssb"
    wide.save(path)
    back = ss.load(path)
    assert (back.contact_rules, back.contact_hops, back.rest_gap) == ("triangles", 2, wide.rest_gap)
    assert set(default.excluded_reasons) <= {"same_joint", "adjacent_joints"}
    for bad in ({"hops": 3}, {"rest_gap": 0.06}, {"rest_gap": -0.01}):
        try:
            ss.fit(**bad)
        except ss.InvalidArgument:
            pass
        else:
            raise AssertionError(f"{bad} was accepted")


def test_fit_group_blends_can_be_turned_off(tmp_path):
    # docs/FIT_REPORT.md (fast mode): the built-in character keeps its reach groups' blends by
    # default (JSON group rows [radius, reaches, blends, deviations]: 1 + 3K numbers for K
    # influences); group_blends=False, as `fit --no-group-blends`, stores rows of 1 + K.
    def row_lengths(sphere_set, name):
        path = tmp_path / name
        sphere_set.save(path)
        doc = json.loads(path.read_text())
        return [
            (len(row), len(s["influences"]))
            for s in doc["spheres"]
            for row in s.get("reach_groups", [])
        ]

    with_blends = row_lengths(ss.fit(), "with.json")
    without = row_lengths(ss.fit(group_blends=False), "without.json")
    assert with_blends and without
    assert all(n == 1 + 3 * k for n, k in with_blends)
    assert all(n == 1 + k for n, k in without)


def test_the_stubs_name_what_the_module_has():
    stub = pathlib.Path(ss.__file__).with_name("_skinspheres.pyi")
    tree = ast.parse(stub.read_text())
    declared = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            declared.add(node.target.id)
    declared -= {"FloatArray", "Path"}  # type aliases of the stubs
    public = {n for n in dir(native) if not n.startswith("_")} | {"__version__"}
    assert declared == public, (declared - public, public - declared)
    for cls in ("SphereSet", "Asset", "Instance"):
        node = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == cls)
        members = {n.name for n in node.body if isinstance(n, ast.FunctionDef)} - {"__init__"}
        present = {n for n in dir(getattr(native, cls)) if not n.startswith("_")} | {"__len__"} & set(
            dir(getattr(native, cls))
        )
        assert members == present, (cls, members - present, present - members)
