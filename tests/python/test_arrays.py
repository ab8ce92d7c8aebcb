"""Inputs of any float type and layout give the same bits as packed float32 input of the same values;
outputs are arrays the caller owns."""

import numpy as np
import pytest

import skinspheres as ss


@pytest.fixture(scope="module")
def builtin():
    spheres = ss.fit()
    asset = ss.Asset(spheres)
    rng = np.random.default_rng(3)
    rest = spheres.joint_rest_world.astype(np.float64)
    # A posed frame: each joint moved and turned a little (any matrices will do: the same in, the same out).
    world = rest.copy()
    world[:, :3, 3] += rng.normal(scale=0.05, size=(len(world), 3))
    positions = None
    return spheres, asset, world, positions


def run(asset, world, positions=None, joint_names=None):
    inst = asset.instance(joint_names)
    if positions is None:
        inst.update_fast(world)
        return inst.spheres, inst.sphere_pairs(), inst.contacts()
    inst.update_exact(positions, world)
    return inst.spheres, inst.sphere_pairs(), inst.contacts(positions)


def assert_same(a, b):
    sa, pa, ca = a
    sb, pb, cb = b
    assert np.array_equal(sa.view(np.uint32), sb.view(np.uint32))
    assert pa.tobytes() == pb.tobytes()
    assert ca.parts.tobytes() == cb.parts.tobytes() and ca.triangles.tobytes() == cb.triangles.tobytes()


def layouts(m):
    """The same (J, 4, 4) values in other layouts."""
    yield "float32 C order", np.ascontiguousarray(m, np.float32)
    yield "float64", m.astype(np.float64)
    yield "Fortran order", np.asfortranarray(m)
    yield "transposed storage", np.ascontiguousarray(np.swapaxes(m, 1, 2)).swapaxes(1, 2)
    big = np.zeros((len(m) * 3, 8, 12))
    big[::3, ::2, ::3] = m
    yield "strided view", big[::3, ::2, ::3]
    yield "reversed twice", m[::-1][::-1]
    yield "read-only", np.array(m, copy=True).view()


def test_every_layout_and_float_type_gives_the_same_bits(builtin):
    _, asset, world, _ = builtin
    reference = run(asset, world.astype(np.float32))
    assert len(reference[1]) > 0, "the pose must give sphere pairs for the comparison to mean something"
    for name, m in layouts(world):
        assert np.array_equal(m, world.astype(m.dtype)), name
        assert_same(run(asset, m), reference)


def test_float64_rounds_to_nearest_as_numpy_astype(builtin):
    _, asset, world, _ = builtin
    # Values between two floats: float64 input must equal its numpy float32 rounding, not truncation.
    nudged = world + 1e-9
    assert_same(run(asset, nudged), run(asset, nudged.astype(np.float32)))


def test_exact_mode_positions_in_any_layout(builtin):
    spheres, asset, world, _ = builtin
    from gltf_sampler import skin

    positions = skin(spheres.mesh, world)
    reference = run(asset, world.astype(np.float32), positions.astype(np.float32))
    assert len(reference[1]) > 0
    padded = np.zeros((len(positions), 7))
    padded[:, 2:5] = positions
    for p in (positions, np.asfortranarray(positions), padded[:, 2:5], positions.T.copy().T):
        assert_same(run(asset, world, p), reference)


def test_outputs_are_owned_copies(builtin):
    _, asset, world, _ = builtin
    inst = asset.instance()
    inst.update_fast(world)
    first = inst.sphere_pairs()
    kept = first.copy()
    inst.update_fast(world * 1.0)
    inst.sphere_pairs()
    first["depth"] = -1  # writable, and writing it changes nothing in the instance
    assert inst.sphere_pairs().tobytes() == kept.tobytes()
    assert first.dtype == ss.SPHERE_PAIR_DTYPE
    assert inst.contacts().parts.dtype == ss.PART_CONTACT_DTYPE
    assert inst.contacts().triangles.dtype == ss.TRIANGLE_CONTACT_DTYPE


def test_set_arrays_round_trip_through_save_and_load(tmp_path):
    spheres = ss.fit()
    for name in ("set.json", "set.ssb"):
        spheres.save(str(tmp_path / name))
        back = ss.load(str(tmp_path / name))
        for field in ("centers", "radii", "radii_fast", "sphere_part", "sphere_joint", "excluded_pairs", "triangles"):
            assert np.array_equal(getattr(back, field), getattr(spheres, field)), (name, field)
        assert back.part_names == spheres.part_names and back.joint_names == spheres.joint_names
        assert back.excluded_reasons == spheres.excluded_reasons
    joints, weights = spheres.sphere_joints(0)
    assert len(joints) == len(weights) > 0 and abs(float(weights.sum()) - 1.0) < 1e-5
    assert spheres.sphere_joint[0] in joints
