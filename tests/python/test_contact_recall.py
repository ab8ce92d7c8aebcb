"""The tool's triangle contacts against an independent checker: bench/contact_recall.py skins the
mesh in float64 from the set's JSON, poses it with the tests' own glTF sampler (gltf_sampler.py),
finds the intersecting triangle pairs with its own box sweep and separating-axis test, and applies
the three rules of contact_rules.h itself (rule 3 by an exact float64 distance at rest). No product
contact code runs on that side.

Per case: three fits (default, --max-spheres = the parts, --piece-edge 0.02), every frame of each
clip dumped in exact and fast mode; the checker's pairs on a few frames spread over the clips. The
tool must report at least 99% of them (the misses it may have are rounding at 1e-8 of the height or
triangles of no area, bench/results/2026-12-07-contact-recall.md), nothing the checker finds apart
or excluded by a rule, and the same pairs from every fit and both modes in every frame.
"""

import json
import subprocess
import sys

import pytest

from conftest import ROOT, character_path, shared, tool

CHECKER = ROOT / "bench" / "contact_recall.py"

# (character, clips file or None, the clips to play: indices as `play --clip N` lists them)
CASES = [
    ("builtin", None, "0,1"),
    ("CesiumMan.glb", None, "0"),
    ("Xbot.glb", "Soldier.glb", "1,2,3,4"),  # Soldier's clips retargeted onto Xbot (after its own clip 0)
]


@pytest.mark.parametrize("name,clips,indices", CASES, ids=[c[0].removesuffix(".glb") for c in CASES])
def test_contacts_match_an_independent_checker(name, clips, indices, builtin_glb, tmp_path):
    character = character_path(name, builtin_glb)
    out = tmp_path / "result.json"
    args = [sys.executable, str(CHECKER), "case", character, "--tool", tool(), "--work", str(tmp_path),
            "--name", name.removesuffix(".glb"), "--clip-indices", indices, "--budget", "8", "--out", str(out)]
    if clips:
        args += ["--clips", shared(clips)]
    run = subprocess.run(args, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    result = json.loads(out.read_text())
    assert result["max_joint_dev_share"] < 1e-5, "the checker's poses are not the tool's"
    for mode, m in result["modes"].items():
        summary = f"{name} {mode}: {json.dumps({k: v for k, v in m.items() if not isinstance(v, dict)})}"
        assert m["frames"] > 0 and m["mine"] > 0, summary  # every case has contacts to find
        assert m["both"] >= 0.99 * m["mine"], summary
        assert m["extra_apart"] == 0, summary
        assert sum(m["extra_rule"].values()) == 0, summary
        assert m["fit_diff_frames_all"] == 0 and m["all_frames"] > 0, summary
        assert m["mode_diff_frames"] == 0, summary
