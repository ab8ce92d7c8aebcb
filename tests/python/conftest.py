"""Shared set-up of the Python tests (run by CTest: tests/CMakeLists.txt sets the environment).

SKINSPHERES_TOOL: the skinspheres command-line tool; SKINSPHERES_C_LIBRARY: libskinspheres_c;
SKINSPHERES_ASSETS: the shared characters (default ../shared/assets from the project root). A test
that needs a missing character is skipped with a message; a run where every test was skipped exits
77, which CTest reports as skipped, never as passed.
"""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
ASSETS = pathlib.Path(os.environ.get("SKINSPHERES_ASSETS", ROOT.parent / "shared" / "assets"))
SHARED = ["CesiumMan.glb", "Soldier.glb", "Xbot.glb", "RobotExpressive.glb"]


def tool():
    path = os.environ.get("SKINSPHERES_TOOL")
    if not path or not os.path.exists(path):
        pytest.skip("SKINSPHERES_TOOL is not set: run through CTest")
    return path


def c_library():
    path = os.environ.get("SKINSPHERES_C_LIBRARY")
    if not path or not os.path.exists(path):
        pytest.skip("SKINSPHERES_C_LIBRARY is not set: run through CTest")
    return path


def shared(name):
    path = ASSETS / name
    if not path.exists():
        pytest.skip(f"{path}: not present (the shared characters are not in the repository)")
    return str(path)


@pytest.fixture(scope="session")
def builtin_glb(tmp_path_factory):
    """The built-in character written as GLB by the tool (export-builtin)."""
    path = tmp_path_factory.mktemp("builtin") / "builtin.glb"
    subprocess.run([tool(), "export-builtin", str(path)], check=True, capture_output=True)
    return str(path)


def character_path(name, builtin_glb_path):
    return builtin_glb_path if name == "builtin" else shared(name)


_outcomes = {"passed": 0, "skipped": 0, "failed": 0}


def pytest_runtest_logreport(report):
    if report.when == "call" or (report.when == "setup" and report.outcome != "passed"):
        _outcomes[report.outcome] = _outcomes.get(report.outcome, 0) + 1


def pytest_sessionfinish(session, exitstatus):
    if exitstatus == 0 and _outcomes["passed"] == 0 and _outcomes["skipped"] > 0:
        session.exitstatus = 77
