"""skinspheres: sphere sets for skinned characters, and the contacts of a character with itself.

Fit a character, load or save its sphere set, then move it with joint matrices (or skinned
positions) frame by frame and read its contacts as numpy structured arrays; or hand a whole clip
(play) or animation library (check) to the library, which loops in C++ without the GIL.

    import skinspheres as ss
    spheres = ss.fit("Xbot.glb")                 # or ss.load("xbot.ssb")
    asset = ss.Asset(spheres)
    inst = asset.instance(joint_names)           # the engine's joint order; None: the set's own
    inst.update_fast(world)                      # (J, 4, 4) float32/float64, any strides
    parts, triangles = inst.contacts()           # structured arrays (PART_CONTACT_DTYPE, ...)
    result = ss.play("Xbot.glb", fps=30, mode="fast")   # every frame of a clip at once

docs/PYTHON.md has the whole guide; _skinspheres.pyi the types.
"""

from ._skinspheres import (  # noqa: F401  (the public names)
    DEFAULT_TOUCH_TOLERANCE,
    FRAME_PART_CONTACT_DTYPE,
    FRAME_SPHERE_PAIR_DTYPE,
    FRAME_TRIANGLE_CONTACT_DTYPE,
    INTERSECTING,
    PART_CONTACT_DTYPE,
    PENETRATING,
    SPHERE_PAIR_DTYPE,
    TOUCHING,
    TRIANGLE_CONTACT_DTYPE,
    WITHIN_MARGIN,
    Asset,
    CheckFailed,
    Contacts,
    Error,
    FileNotFound,
    FileUnreadable,
    FormatRejected,
    Instance,
    InvalidArgument,
    InvalidData,
    MismatchedAsset,
    NotFound,
    SphereSet,
    VersionMismatch,
    __version__,
    check,
    clip_names,
    colliders,
    fit,
    fix,
    load,
    play,
    retarget,
)


def part_pair_names(part_contacts, part_names):
    """The (name_a, name_b) of each row of a part-contact array (PART_CONTACT_DTYPE or the
    per-frame FRAME_PART_CONTACT_DTYPE), by the asset's or play result's part_names."""
    return [(part_names[int(a)], part_names[int(b)]) for a, b in zip(part_contacts["part_a"], part_contacts["part_b"])]


def penetrating_frames(result):
    """The sorted frame numbers of a play() result where some part pair penetrates."""
    import numpy as np

    parts = result["part_contacts"]
    return np.unique(parts["frame"][parts["kind"] == PENETRATING])
