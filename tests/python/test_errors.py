"""Every wrong call raises a Python exception with a one-line message; none crashes."""

import threading

import numpy as np
import pytest

import skinspheres as ss


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    folder = tmp_path_factory.mktemp("errors")
    spheres = ss.fit()
    spheres.save(str(folder / "set.ssb"))
    spheres.save(str(folder / "fast.ssb"), fast_only=True)
    (folder / "garbage.ssb").write_bytes(b"\x00\x01not a sphere set")
    (folder / "broken.json").write_text('{"format": "skinspheres.sphere_set", "version": 2, "spheres": [')
    (folder / "notes.txt").write_text("hello")
    return folder, spheres, ss.Asset(spheres)


def one_line(e):
    text = str(e)
    assert text and "\n" not in text, repr(text)
    return text


def calls(folder, spheres, asset):
    world = spheres.joint_rest_world
    nan = world.copy()
    nan[3, 0, 3] = np.nan
    fast_asset = ss.Asset(ss.load(str(folder / "fast.ssb")))
    return [
        ("load a missing file", lambda: ss.load(str(folder / "missing.ssb")), ss.FileNotFound),
        ("load garbage", lambda: ss.load(str(folder / "garbage.ssb")), ss.Error),
        ("load broken JSON", lambda: ss.load(str(folder / "broken.json")), ss.Error),
        ("load a folder", lambda: ss.load(str(folder)), ss.Error),
        ("fit a missing file", lambda: ss.fit(str(folder / "missing.glb")), ss.FileNotFound),
        ("fit a text file", lambda: ss.fit(str(folder / "notes.txt")), ss.Error),
        ("fit with a bad method", lambda: ss.fit(method="m9"), ss.InvalidArgument),
        ("fit with rays 0", lambda: ss.fit(rays=0), ss.InvalidArgument),
        ("save to an unknown extension", lambda: spheres.save(str(folder / "set.txt")), ss.InvalidArgument),
        ("save fast-only as JSON", lambda: spheres.save(str(folder / "x.json"), fast_only=True), ss.InvalidArgument),
        ("save into a missing folder", lambda: spheres.save(str(folder / "no" / "x.ssb")), ss.Error),
        ("asset with a negative margin", lambda: ss.Asset(spheres, margin=-1.0), ss.InvalidArgument),
        ("asset with a NaN tolerance", lambda: ss.Asset(spheres, touch_tolerance=float("nan")), ss.Error),
        ("instance missing joints", lambda: asset.instance(["Hips", "Spine"]), ss.MismatchedAsset),
        ("instance with repeated names", lambda: asset.instance(spheres.joint_names + ["Hips"]), ss.MismatchedAsset),
        ("check another character", lambda: asset.check(spheres.joint_names, 3), ss.MismatchedAsset),
        ("update with too few matrices", lambda: asset.instance().update_fast(world[:3]), ss.InvalidArgument),
        ("update with 3x4 matrices", lambda: asset.instance().update_fast(world[:, :3, :]), ss.InvalidArgument),
        ("update with integers", lambda: asset.instance().update_fast(world.astype(np.int64)), TypeError),
        ("update with a list", lambda: asset.instance().update_fast(world.tolist()), TypeError),
        ("update with None", lambda: asset.instance().update_fast(None), TypeError),
        ("update with float16", lambda: asset.instance().update_fast(world.astype(np.float16)), TypeError),
        ("update with big-endian floats", lambda: asset.instance().update_fast(world.astype(">f8")), TypeError),
        ("update with NaN", lambda: asset.instance().update_fast(nan), ss.InvalidData),
        ("update with infinity", lambda: asset.instance().update_fast(np.full_like(world, np.inf)), ss.InvalidData),
        ("exact with too few positions",
         lambda: asset.instance().update_exact(np.zeros((5, 3)), world), ss.InvalidArgument),
        ("exact with (V, 4) positions",
         lambda: asset.instance().update_exact(np.zeros((spheres.vertex_count, 4)), world), ss.InvalidArgument),
        ("pairs before any update", lambda: asset.instance().sphere_pairs(), ss.Error),
        ("contacts before any update", lambda: asset.instance().contacts(), ss.Error),
        ("exact mode on a fast-only set",
         lambda: fast_asset.instance().update_exact(np.zeros((spheres.vertex_count, 3)), world), ss.Error),
        ("contacts on a fast-only set", lambda: fast_contacts(fast_asset, world), ss.Error),
        ("sphere_joints out of range", lambda: spheres.sphere_joints(len(spheres)), ss.InvalidArgument),
        ("play a missing file", lambda: ss.play(str(folder / "missing.glb")), ss.FileNotFound),
        ("play a missing clip", lambda: ss.play(clip="nope"), ss.Error),
        ("play in a bad mode", lambda: ss.play(mode="slow"), ss.InvalidArgument),
        ("play at 0 fps", lambda: ss.play(fps=0), ss.InvalidArgument),
        ("play with a missing clip file", lambda: ss.play(clip_file=str(folder / "missing.glb")), ss.FileNotFound),
        ("play with a bad retarget mode", lambda: ss.play(clip_file=str(folder / "missing.glb"), retarget="zzz"),
         ss.InvalidArgument),
        ("play a negative clip index", lambda: ss.play(clip=-1), ss.InvalidArgument),
        ("play clip None", lambda: ss.play(clip=None), TypeError),
        ("play 10^12 frames", lambda: ss.play(frames=10**12), ss.InvalidArgument),
        ("load a path with a NUL byte", lambda: ss.load(str(folder / "set.ssb") + "\0.json"), ValueError),
        ("fit a path with a NUL byte", lambda: ss.fit(str(folder / "x.glb") + "\0"), ValueError),
        ("save to a path with a NUL byte", lambda: spheres.save(str(folder / "x.ssb") + "\0.json"), ValueError),
        ("load bytes that are not UTF-8", lambda: ss.load(bytes(folder) + b"/\xff.ssb"), ValueError),
        ("load a number as a path", lambda: ss.load(3), TypeError),
        ("update with a masked array", lambda: asset.instance().update_fast(np.ma.masked_array(world)), TypeError),
        ("play with a missing set", lambda: ss.play(spheres=str(folder / "missing.ssb")), ss.FileNotFound),
        ("check a missing character", lambda: ss.check(str(folder / "missing.glb")), ss.FileNotFound),
        ("check with max_depth 2", lambda: ss.check("", max_depth=2.0), ss.InvalidArgument),
        ("play with a keyword that does not exist", lambda: ss.play(speed=2), TypeError),
    ]


def fast_contacts(asset, world):
    inst = asset.instance()
    inst.update_fast(world)
    return inst.contacts()


def test_every_wrong_call_raises_with_one_line(setup):
    folder, spheres, asset = setup
    for what, call, expected in calls(folder, spheres, asset):
        with pytest.raises(expected) as info:
            call()
        if isinstance(info.value, ss.Error):
            text = one_line(info.value)  # the library's own message
            assert info.value.code and info.value.code != "ok", what
        else:  # TypeError, from the argument conversion: it names the call
            text = str(info.value).splitlines()[0]
            assert text, what
        print(f"{what}: {type(info.value).__name__}: {text}")


def test_paths_may_be_pathlike_or_bytes(setup):
    folder, spheres, _ = setup
    assert len(ss.load(folder / "set.ssb")) == len(spheres)
    assert len(ss.load(bytes(folder / "set.ssb"))) == len(spheres)
    spheres.save(folder / "again.json")
    assert ss.load(str(folder / "again.json")).joint_names == spheres.joint_names


def test_errors_are_also_the_builtin_kinds(setup):
    folder, _, _ = setup
    with pytest.raises(FileNotFoundError):
        ss.load(str(folder / "missing.ssb"))
    with pytest.raises(ValueError):
        ss.fit(method="m9")


def test_an_instance_used_by_two_threads_at_once_raises_instead_of_racing(setup):
    _, spheres, asset = setup
    inst = asset.instance()
    world = spheres.joint_rest_world
    errors, stop = [], threading.Event()

    def hammer():
        while not stop.is_set():
            try:
                inst.update_fast(world)
                inst.contacts()
                assert inst.spheres.shape == (len(spheres), 4)
            except ValueError as e:
                errors.append(str(e))

    threads = [threading.Thread(target=hammer) for _ in range(2)]
    for t in threads:
        t.start()
    for _ in range(2000):
        if errors:
            break
        threading.Event().wait(0.001)
    stop.set()
    for t in threads:
        t.join()
    # Either the two threads met (and one was told), or they never overlapped; never a crash.
    assert all("two threads at once" in e for e in errors)
