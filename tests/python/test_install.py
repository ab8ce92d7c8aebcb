"""`import skinspheres` works from an install prefix (cmake --install), away from the build tree."""

import os
import subprocess
import sys

import pytest


def test_import_from_an_install_prefix(tmp_path):
    build = os.environ.get("SKINSPHERES_BUILD_DIR")
    if not build:
        pytest.skip("SKINSPHERES_BUILD_DIR is not set: run through CTest")
    prefix = tmp_path / "prefix"
    subprocess.run(["cmake", "--install", build, "--prefix", str(prefix)], check=True, capture_output=True)
    site = prefix / "lib" / "python3" / "dist-packages"
    assert (site / "skinspheres" / "__init__.py").exists()
    assert (site / "skinspheres" / "_skinspheres.pyi").exists()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    env["PYTHONPATH"] = str(site)
    script = (
        "import skinspheres as ss, numpy as np\n"
        "print(ss.__file__)\n"
        "s = ss.fit(); i = ss.Asset(s).instance(); i.update_fast(s.joint_rest_world)\n"
        "print(len(s), len(i.sphere_pairs()), ss.__version__)\n"
    )
    out = subprocess.run([sys.executable, "-c", script], check=True, capture_output=True, text=True, env=env,
                         cwd=tmp_path).stdout.splitlines()
    assert out[0].startswith(str(site)), out
    assert int(out[1].split()[0]) > 0
