"""Blender: marks the timeline frames where the active character penetrates itself.

Run it from Blender's Text Editor (or `blender file.blend --python blender_mark_penetrations.py`)
with the character's armature or mesh selected. It exports the selection with its active action
to a temporary GLB, plays it through skinspheres at the scene's frame rate, and adds one timeline
marker per penetrating frame, named for the deepest part pair ("ss arm_l-torso 1.2%"). Markers it
added before (names starting "ss ") are removed first.

The module must be importable by Blender's own Python: build skinspheres against the same Python
version (Blender 4.x bundles Python 3.11, as Debian 12 does) and add the build's python/ folder or
the install's dist-packages to sys.path below. The logic (penetrating_markers, mark) is tested
without Blender (tests/python/test_samples.py). The add-on (blender/, docs/BLENDER.md) does the
same from a panel, for every action, and is tested in Blender.
"""

import os
import sys
import tempfile

PREFIX = "ss "


def penetrating_markers(glb_path, fps, frame_start, mode="exact", min_depth=0.0, clip=0):
    """(scene frame, marker name) for each frame of the clip where a part pair penetrates at least
    min_depth of the height; the frame counts from frame_start at the scene's fps."""
    import skinspheres as ss

    result = ss.play(glb_path, clip=clip, fps=fps, mode=mode)
    parts = result["part_contacts"]
    height = result["body_height"] or 1.0
    names = result["part_names"]
    worst = {}
    for p in parts[parts["kind"] == ss.PENETRATING]:
        if p["depth"] >= min_depth * height and (p["frame"] not in worst or p["depth"] > worst[p["frame"]]["depth"]):
            worst[p["frame"]] = p
    return [
        (frame_start + int(f), f"{PREFIX}{names[p['part_a']]}-{names[p['part_b']]} {100 * p['depth'] / height:.1f}%")
        for f, p in sorted(worst.items())
    ]


def mark(scene, markers):
    """Replaces this script's markers on the scene's timeline (scene.timeline_markers)."""
    for old in [m for m in scene.timeline_markers if m.name.startswith(PREFIX)]:
        scene.timeline_markers.remove(old)
    for frame, name in markers:
        scene.timeline_markers.new(name, frame=frame)


def run_in_blender():  # pragma: no cover (needs Blender)
    import bpy

    scene = bpy.context.scene
    fps = scene.render.fps / scene.render.fps_base
    with tempfile.TemporaryDirectory() as scratch:
        path = os.path.join(scratch, "character.glb")
        bpy.ops.export_scene.gltf(filepath=path, use_selection=True, export_animations=True, export_skins=True)
        markers = penetrating_markers(path, fps, scene.frame_start)
    mark(scene, markers)
    print(f"skinspheres: {len(markers)} penetrating frames marked")


if __name__ == "__main__":
    if "bpy" in sys.modules or "blender" in os.path.basename(sys.executable).lower():
        run_in_blender()
    else:
        print("blender_mark_penetrations.py: run it inside Blender (see the header)", file=sys.stderr)
        sys.exit(1)
