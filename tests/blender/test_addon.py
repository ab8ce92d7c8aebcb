"""The Blender add-on in real Blender, headless, against the command-line tool as the oracle.

    blender -b --factory-startup --python-exit-code 1 --python tests/blender/test_addon.py -- \
        --zip build/skinspheres_blender.zip --module-dir build/python --tool build/samples/skinspheres \
        --character CHARACTER.glb|builtin --work DIR

Installs the add-on from the built zip, imports the character with Blender's glTF importer and runs
each operator as a script would (EXEC_DEFAULT), then compares with the tool, clip by clip:

1. Fit: the set it saved has the parts `skinspheres fit` gives the original file; the spheres
   object has one sphere per sphere of the set, bound to bones, hidden from renders, and at rest it
   holds every vertex of Blender's meshes (the fit covers every triangle).
2. Check (every action): Blender's pose at scene frame k is the tool's frame k (every bone's head
   against the joints `play --dump` samples); each action's markers are, frame by frame, the frames where
   `skinspheres play --dump` finds a part pair penetrating (and the deepest pair), on the very file
   the add-on checked (exact) and on the original file (equal but for frames whose deepest depth
   lies within ROUND_TRIP of the touch tolerance: Blender's import and export round floats); its
   report is `skinspheres check --report`'s on that file; the list's pairs are the report's.
3. Check (active action): the timeline holds that action's markers; clicking a pair jumps.
4. Fix: the verdicts are `skinspheres fix`'s on the original file; every "NAME (fixed)" action,
   exported again, passes `skinspheres check` at the same limit; joints the fix did not change
   pose as in the original action; the original actions are unchanged.
5. Cancelling a job mid-way restores the armature's animation state; a wrong module folder gives
   the panel's message.

A character path that does not exist exits 77 (CTest: skipped) with a message.
Debian 12's Blender 3.4.1 glTF importer uses np.bool, which numpy 1.24 removed: it is set back to
bool below, before the importer runs (only when missing).
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy

if "bool" not in numpy.__dict__:  # Blender 3.4's glTF importer calls np.bool (gone in numpy 1.24)
    numpy.bool = bool

import bpy  # noqa: E402
from mathutils import Matrix  # noqa: E402

ROUND_TRIP = 0.0005  # share of the body height: how far a depth may move through Blender's import/export
ADDON = "skinspheres_blender"


def parse():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    parser = argparse.ArgumentParser()
    for name in ("--zip", "--module-dir", "--tool", "--character", "--work"):
        parser.add_argument(name, required=True)
    return parser.parse_args(argv)


def tool(args, *command, check=True):
    run = subprocess.run([args.tool, *command], capture_output=True, text=True)
    if check and run.returncode not in (0, 1):
        raise AssertionError(f"skinspheres {' '.join(command)}: exit {run.returncode}: {run.stderr}")
    return run


def play_dump(args, glb, clip, fps):
    """The lines of `skinspheres play --dump`: per frame its contacts and joints' world positions."""
    dump = os.path.join(args.work, "dump.jsonl")
    tool(args, "play", glb, "--clip", clip, "--fps", repr(fps), "--dump", dump)
    with open(dump) as f:
        return [json.loads(line) for line in f]


def penetrating_by_frame(lines):
    """{frame: (part_a, part_b, depth)} of the deepest penetrating pair per frame."""
    frames = {}
    for line in lines:
        penetrating = [c for c in line["contacts"] if c["kind"] == "penetrating"]
        if penetrating:
            worst = max(penetrating, key=lambda c: c["depth"])
            frames[line["frame"]] = (*worst["parts"], worst["depth"])
    return frames


def check_frames_match(armature, action, lines):
    """Blender's pose at scene frame k is the tool's frame k: every bone's head, in the file's Y-up
    world, against the joint positions `play --dump` samples (every 5th frame)."""
    y_up = Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))
    data, kept = armature.animation_data, armature.animation_data.action
    data.action = action
    worst = 0.0
    names = lines[0]["joint_names"]  # the first line names the joints
    for line in lines[::5]:
        for bone in armature.pose.bones:
            bone.matrix_basis = Matrix()
        bpy.context.scene.frame_set(line["frame"])
        for name, position in zip(names, line["joints"]):
            if name in armature.pose.bones:
                head = (y_up @ armature.matrix_world @ armature.pose.bones[name].matrix).translation
                worst = max(worst, max(abs(a - b) for a, b in zip(head, position)))
    data.action = kept
    assert worst < 1e-4 * max(armature.dimensions), f"{action.name}: Blender's frames are not the tool's ({worst})"
    return worst


def install(args):
    bpy.ops.preferences.addon_install(filepath=os.path.abspath(args.zip), overwrite=True)
    bpy.ops.preferences.addon_enable(module=ADDON)
    bpy.context.preferences.addons[ADDON].preferences.module_dir = args.module_dir
    addon = sys.modules[ADDON]
    ss, error = addon.module.load()
    assert ss is not None, error
    assert hasattr(bpy.types, "SKINSPHERES_PT_panel"), "the panel is registered"
    return addon, ss


def load_character(args, ss):
    bpy.ops.import_scene.gltf(filepath=args.character)
    armatures = [o for o in bpy.data.objects if o.type == "ARMATURE"]
    assert len(armatures) == 1, f"one armature expected, got {armatures}"
    armature = armatures[0]
    for obj in bpy.context.view_layer.objects:
        obj.select_set(False)
    bpy.context.view_layer.objects.active = armature
    # The importer puts each clip on an NLA track named for it, "Anim_<index>" when it has no name:
    # action name -> the tool's name of the clip in the original file.
    names = ss.clip_names(args.character)
    clips = {}
    for track in armature.animation_data.nla_tracks:
        index = int(track.name[5:]) if track.name not in names and track.name.startswith("Anim_") else None
        for strip in track.strips:
            clips[strip.action.name] = names[index] if index is not None else track.name
    assert sorted(clips.values()) == sorted(names), (clips, names)
    return armature, clips


def action_state(armature):
    """Everything Fix and the exports must leave alone: the actions' keys and the NLA."""
    keys = {}
    for action in bpy.data.actions:
        for curve in action.fcurves:
            co = numpy.empty(2 * len(curve.keyframe_points), numpy.float32)
            curve.keyframe_points.foreach_get("co", co)
            keys[(action.name, curve.data_path, curve.array_index)] = co.tobytes()
    data = armature.animation_data
    nla = [(t.name, t.mute, [(s.action.name, s.mute) for s in t.strips]) for t in data.nla_tracks]
    return keys, nla, data.action.name if data.action else None


def test_fit(args, ss, armature, state):
    assert bpy.ops.skinspheres.fit() == {"FINISHED"}, state.status
    path = armature["skinspheres_ssb"]
    spheres = ss.load(path)
    reference = os.path.join(args.work, "tool_fit.json")
    tool(args, "fit", args.character, "-o", reference)
    with open(reference) as f:
        parts = [p["name"] for p in json.load(f)["parts"]]
    assert sorted(spheres.part_names) == sorted(parts), (spheres.part_names, parts)
    obj = bpy.data.objects[f"{armature.name} spheres"]
    assert obj.hide_render and obj.parent == armature
    assert obj["skinspheres_spheres"] == len(spheres)
    assert len(obj.data.vertices) % len(spheres) == 0
    bones = {b.name for b in armature.data.bones}
    assert {g.name for g in obj.vertex_groups} <= bones
    assert len(obj.data.materials) == len(spheres.part_names)
    outside = spheres_hold_the_mesh(armature, obj, len(spheres))
    print(f"fit: {len(spheres)} spheres, parts {spheres.part_names} (the tool's: {len(parts)}); at rest in "
          f"Blender the spheres object holds every vertex of the meshes (deepest outside: {outside:.2g})")


def world_vertices(obj):
    """An object's evaluated vertices in world space, (V, 3)."""
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    co = numpy.empty(3 * len(mesh.vertices), numpy.float64)
    mesh.vertices.foreach_get("co", co)
    evaluated.to_mesh_clear()
    m = numpy.array(obj.matrix_world)
    return co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]


def spheres_hold_the_mesh(armature, obj, count):
    """At rest, every vertex of the character's meshes lies inside some sphere of the spheres object,
    as Blender places it (the fit covers every triangle): the add-on's conversion from the file's
    space to the armature's, checked against Blender's own meshes."""
    armature.data.pose_position = "REST"
    bpy.context.view_layer.update()
    try:
        points = world_vertices(obj).reshape(count, -1, 3)
        centres = points.mean(axis=1)
        radii = numpy.linalg.norm(points - centres[:, None], axis=2).max(axis=1)
        meshes = [o for o in bpy.data.objects if o.type == "MESH" and o != obj
                  and any(m.type == "ARMATURE" and m.object == armature for m in o.modifiers)]
        vertices = numpy.concatenate([world_vertices(o) for o in meshes])
    finally:
        armature.data.pose_position = "POSE"
    height = float(numpy.ptp(vertices, axis=0).max())
    worst = 0.0
    for chunk in numpy.array_split(vertices, max(1, len(vertices) // 2000)):
        gap = numpy.linalg.norm(chunk[:, None] - centres[None], axis=2) - radii[None]
        worst = max(worst, float(gap.min(axis=1).max()))
    assert worst <= 1e-4 * height, f"a vertex lies {worst} outside every sphere"
    return worst


def test_check_all(args, armature, clips, state, fps):
    state.scope, state.keep_glb = "ALL", True
    assert bpy.ops.skinspheres.check() == {"FINISHED"}, state.status
    checked = os.path.join(state.output_dir, f"{bpy.path.clean_name(armature.name)}_checked.glb")
    with open(state.check_report) as f:
        report = json.load(f)
    reference_path = os.path.join(args.work, "tool_check.json")
    tool(args, "check", checked, "--clip", "all", "--fps", repr(fps), "--report", reference_path)
    with open(reference_path) as f:
        reference = json.load(f)
    assert [c["name"] for c in report["clips"]] == [c["name"] for c in reference["clips"]]
    for ours, theirs in zip(report["clips"], reference["clips"]):
        assert ours == theirs, f"{ours['name']}: the add-on's report differs from the tool's"
    differences = 0
    for action_name, clip in sorted(clips.items()):
        action = bpy.data.actions[action_name]
        markers = sorted((m.frame, m.name) for m in action.pose_markers if m.name.startswith("ss "))
        lines = play_dump(args, checked, action_name, fps)
        exact = penetrating_by_frame(lines)
        check_frames_match(armature, action, lines)
        assert [f for f, _ in markers] == sorted(exact), f"{action_name}: markers {markers} vs the tool's {exact}"
        for frame, name in markers:
            a, b, _ = exact[frame]
            assert name.startswith(f"ss {a}-{b} "), (frame, name, exact[frame])
        differences += compare_with_original(args, clip, fps, report, {f for f, _ in markers})
        check_list(state, action_name, next(c for c in reference["clips"] if c["name"] == action_name))
    print(f"check: {len(clips)} actions: poses frame by frame, markers and report equal to the tool's on the "
          f"checked file; {differences} borderline frames differ from the original file")


def compare_with_original(args, clip, fps, report, marked):
    """Markers against the tool on the original file: equal except where the depth is borderline."""
    original = penetrating_by_frame(play_dump(args, args.character, clip, fps))
    tolerance = report["touch_tolerance"] if "touch_tolerance" in report else 0.005
    height = report["body_height"]
    borderline = ROUND_TRIP * height
    differ = marked.symmetric_difference(original)
    for frame in differ:
        depth = original[frame][2] if frame in original else None
        assert depth is None or abs(depth - tolerance * height) <= borderline, (clip, frame, depth)
    if differ:
        print(f"  {clip}: frames {sorted(differ)} differ from the original file (borderline depths)")
    return len(differ)


def check_list(state, action_name, reference_clip):
    rows = {(p.part_a, p.part_b): p for p in state.pairs if p.action == action_name}
    expected = {tuple(p["parts"]): p for p in reference_clip["part_pairs"] if p["penetrating_frames"]}
    assert {tuple(sorted(k)) for k in rows} == {tuple(sorted(k)) for k in expected}, (rows.keys(), expected.keys())
    for key, pair in expected.items():
        row = rows.get(key) or rows[key[::-1]]
        assert row.frames == pair["penetrating_frames"], (key, row.frames, pair)
        assert row.worst_frame == pair["worst_frame"], (key, row.worst_frame, pair)
        assert abs(row.depth_share - pair["max_depth_share"]) < 1e-6, (key, row.depth_share, pair)


def test_check_active_and_jump(armature, state):
    penetrating = [p.action for p in state.pairs]
    if not penetrating:
        print("check active: no action penetrates; skipped the jump")
        return
    action = bpy.data.actions[penetrating[0]]
    armature.animation_data.action = action
    state.scope = "ACTIVE"
    assert bpy.ops.skinspheres.check() == {"FINISHED"}, state.status
    with open(state.check_report) as f:
        assert [c["name"] for c in json.load(f)["clips"]] == [action.name]
    timeline = sorted(m.frame for m in bpy.context.scene.timeline_markers if m.name.startswith("ss "))
    assert timeline == sorted(m.frame for m in action.pose_markers), "the timeline shows the active action's markers"
    last = len(state.pairs) - 1
    state.pair_index = last
    assert bpy.context.scene.frame_current == state.pairs[last].worst_frame
    assert armature.animation_data.action.name == state.pairs[last].action
    print(f"check active: {len(timeline)} timeline markers; the list jumps to frame {bpy.context.scene.frame_current}")


def test_fix(args, addon, armature, clips, state, fps):
    before = action_state(armature)
    state.scope, state.fix_depth = "ALL", 1.0
    assert bpy.ops.skinspheres.fix() == {"FINISHED"}, state.status
    after = action_state(armature)
    assert {k: v for k, v in after[0].items() if " (fixed)" not in k[0]} == before[0], "original actions changed"
    assert after[1:] == before[1:], "the NLA or the active action changed"
    with open(state.fix_report) as f:
        report = {c["name"]: c for c in json.load(f)["clips"]}
    reference_path = os.path.join(args.work, "tool_fix.json")
    tool(args, "fix", args.character, "-o", os.path.join(args.work, "tool_fixed.glb"), "--clip", "all", "--fps",
         repr(fps), "--max-depth", "0.01", "--report", reference_path)
    with open(reference_path) as f:
        reference = {c["name"]: c for c in json.load(f)["clips"]}
    fixed = 0
    for action_name, clip in sorted(clips.items()):
        verdict = report[action_name]["verdict"]
        assert verdict == reference[clip]["verdict"], (action_name, verdict, reference[clip]["verdict"])
        if report[action_name]["verdict"] == "fixed":
            check_fixed_action(args, addon, armature, action_name, report[action_name], fps)
            fixed += 1
    print(f"fix: verdicts equal to the tool's on the original file; {fixed} fixed actions pass check at 1%")


def check_fixed_action(args, addon, armature, action_name, clip_report, fps):
    source, fixed = bpy.data.actions[action_name], bpy.data.actions[action_name + " (fixed)"]
    assert fixed.use_fake_user
    path = os.path.join(args.work, "fixed_export.glb")
    addon.character.export_glb(bpy.context, armature, path, [fixed])
    run = tool(args, "check", path, "--clip", "all", "--fps", repr(fps), "--max-depth", "0.01")
    assert run.returncode == 0, f"{fixed.name} still penetrates: {run.stdout}"
    unchanged = [b for b in armature.pose.bones if b.name not in clip_report["joints_changed"]]
    worst = 0.0
    data = armature.animation_data
    kept = data.action
    for frame in range(int(source.frame_range[0]), int(source.frame_range[1]) + 1, 5):
        poses = []
        for action in (source, fixed):
            for bone in armature.pose.bones:  # bones an action does not key stay at rest, as exported
                bone.matrix_basis = Matrix()
            data.action = action
            bpy.context.scene.frame_set(frame)
            poses.append({b.name: numpy.array(b.matrix_basis) for b in unchanged})
        worst = max(worst, max(float(numpy.abs(poses[0][n] - poses[1][n]).max()) for n in poses[0]))
    data.action = kept
    assert worst < 1e-3, f"{fixed.name}: the local transforms of joints the fix left alone moved by {worst}"
    print(f"  {fixed.name}: passes check; unchanged joints within {worst:.2g} of the original")


def test_check_clip_files(args, armature, state, fps):
    """Check with the original file as a clip file (retargeted onto the exported character): the
    report's clips are `skinspheres check CHECKED --clips FILE --report`'s; the list has their pairs."""
    state.scope, state.keep_glb, state.retarget = "NONE", True, "auto"
    state.clip_files.clear()
    state.clip_files.add().path = args.character
    assert bpy.ops.skinspheres.check() == {"FINISHED"}, state.status
    state.clip_files.clear()
    checked = os.path.join(state.output_dir, f"{bpy.path.clean_name(armature.name)}_checked.glb")
    with open(state.check_report) as f:
        report = json.load(f)
    reference_path = os.path.join(args.work, "tool_check_files.json")
    tool(args, "check", checked, "--clips", args.character, "--fps", repr(fps), "--retarget", "auto", "--report",
         reference_path)
    with open(reference_path) as f:
        reference = json.load(f)
    assert len(report["clips"]) == len(reference["clips"]) > 0
    for ours, theirs in zip(report["clips"], reference["clips"]):
        for key in ("name", "frames", "verdict", "worst_frame", "worst_depth", "worst_parts", "part_pairs"):
            assert ours[key] == theirs[key], (ours["name"], key, ours[key], theirs[key])
    for clip in reference["clips"]:
        check_list(state, clip["name"], clip)
        assert all(p.clip_file == args.character for p in state.pairs if p.action == clip["name"])
    print(f"check clip files: {len(report['clips'])} clips of {os.path.basename(args.character)}: frames, depths "
          f"and part pairs equal to `check --clips`")


Y_UP = numpy.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)), numpy.float64)


def round_cone_distance(points, a, b, r0, r1):
    """Signed distance from points (N, 3) to the hull of the balls (a, r0) and (b, r1)."""
    axis = b - a
    length = numpy.linalg.norm(axis)
    if length < 1e-12 or abs(r0 - r1) >= length:
        centre, radius = (a, r0) if r0 >= r1 else (b, r1)
        return numpy.linalg.norm(points - centre, axis=1) - radius
    u = axis / length
    d = points - a
    x = d @ u
    y = numpy.linalg.norm(d - x[:, None] * u, axis=1)
    s = (r0 - r1) / length  # the side's normal is (s, c) in (axial, radial) coordinates
    c = numpy.sqrt(1 - s * s)
    along = x * c - y * s  # along the side, from the head's tangent circle (0) to the tail's (length * c)
    side = x * s + y * c - r0
    head = numpy.hypot(x, y) - r0
    tail = numpy.hypot(x - length, y) - r1
    return numpy.where(along < 0, head, numpy.where(along > length * c, tail, side))


def world_points(obj):
    """An object's evaluated vertices in the file's (glTF) world, (V, 3)."""
    v = world_vertices(obj)
    return v @ Y_UP[:3, :3].T


def test_colliders(args, ss, armature, state, fps):
    """Fit Colliders: one object per shape of the report, parented to its bone; at rest each lies on
    the surface of its shape computed from colliders()' arrays on the same file; posed, each keeps
    its offset in its bone's frame."""
    state.scope, state.keep_glb, state.collider_fps, state.collider_budget = "ALL", True, 5.0, 32
    assert bpy.ops.skinspheres.colliders() == {"FINISHED"}, state.status
    with open(state.colliders_report) as f:
        report = json.load(f)
    collection = bpy.data.collections["skinspheres colliders"]
    objects = sorted((o for o in collection.objects if o.get("skinspheres_collider_of") == armature.name),
                     key=lambda o: o["skinspheres_collider"])
    assert len(objects) == len(report["colliders"]) > 0, (len(objects), len(report["colliders"]))
    kept = os.path.join(state.output_dir, f"{bpy.path.clean_name(armature.name)}_colliders_input.glb")
    result = ss.colliders(kept, [], budget=32, fps=5.0)
    assert result["colliders"] == report["colliders"], "the add-on's fit is the module's on the file it exported"
    rigid = numpy.array(result["joint_rest_world"], numpy.float64)
    rigid[:, :3, :3] /= numpy.linalg.norm(rigid[:, :3, :3], axis=1, keepdims=True)
    height = report["height"]
    armature.data.pose_position = "REST"
    bpy.context.view_layer.update()
    worst = 0.0
    rest = {}
    try:
        for k, obj in enumerate(objects):
            joint = result["joint_names"][int(result["joint"][k])]
            assert obj.parent == armature and obj.hide_render and obj["joint"] == joint
            assert obj.parent_type == "BONE" and obj.parent_bone == joint, (obj.name, obj.parent_type, joint)
            head = rigid[result["joint"][k]] @ numpy.append(result["head"][k], 1.0)
            tail = rigid[result["joint"][k]] @ numpy.append(result["tail"][k], 1.0)
            r0, r1 = float(result["head_radius"][k]), float(result["tail_radius"][k])
            points = world_points(obj)
            distance = numpy.abs(round_cone_distance(points, head[:3], tail[:3], r0, r1)).max()
            if numpy.linalg.norm(tail - head) > 1e-9:  # the poles: the ends of the axis
                u = (tail - head)[:3] / numpy.linalg.norm(tail - head)
                reach = points @ u
                distance = max(distance, abs(reach.max() - (tail[:3] @ u + r1)), abs(reach.min() - (head[:3] @ u - r0)))
            else:
                distance = max(distance, numpy.abs(points.mean(axis=0) - head[:3]).max())
            worst = max(worst, float(distance))
            covered = report["colliders"][k]["covered"]
            assert ("covered" in obj.data.materials[0].name) == (covered >= 1.0), (obj.name, covered)
            bone = armature.pose.bones[joint]
            rest[obj.name] = numpy.linalg.inv(numpy.array(armature.matrix_world @ bone.matrix)) @ numpy.array(
                obj.matrix_world)
    finally:
        armature.data.pose_position = "POSE"
    assert worst < 1e-5 * height, f"a collider object lies {worst} off its shape"
    moved = following(armature, objects, rest)
    print(f"colliders: {len(objects)} objects, as the report; at rest on their shapes within {worst:.2g}; "
          f"posed, each keeps its bone offset (within {moved[0]:.2g}, bones moved up to {moved[1]:.2g})")


def following(armature, objects, rest):
    """At two frames of an action, every collider's world matrix is its bone's times the rest offset."""
    data = armature.animation_data
    kept = data.action
    action = max((a for a in bpy.data.actions if not a.name.endswith(" (fixed)")), key=lambda a: a.frame_range[1])
    data.action = action
    worst, moved = 0.0, 0.0
    first, last = (int(f) for f in action.frame_range)
    for frame in (first + (last - first) // 3, first + 2 * (last - first) // 3):
        bpy.context.scene.frame_set(frame)
        for obj in objects:
            bone = armature.pose.bones[obj.parent_bone]
            bone_world = numpy.array(armature.matrix_world @ bone.matrix)
            expected = bone_world @ rest[obj.name]
            worst = max(worst, float(numpy.abs(numpy.array(obj.matrix_world) - expected).max()))
            moved = max(moved, float(numpy.abs(bone_world[:3, 3] - numpy.array(
                armature.matrix_world @ bone.bone.matrix_local)[:3, 3]).max()))
    data.action = kept
    assert worst < 1e-5 * max(armature.dimensions), f"a collider left its bone by {worst}"
    assert moved > 1e-3 * max(armature.dimensions), "the action moves the bones"
    return worst, moved


def test_collider_exports(args, armature, state):
    """Each export button writes what `skinspheres colliders` writes from the same file."""
    name = bpy.path.clean_name(armature.name)
    kept = os.path.join(state.output_dir, f"{name}_colliders_input.glb")
    formats = []
    for fmt in ("vrm1", "vrm0", "godot", "unity", "usd", "json"):
        started = time.monotonic()
        assert bpy.ops.skinspheres.colliders_export(format=fmt) == {"FINISHED"}, state.status
        path = state.colliders_export
        assert os.path.basename(path).startswith(name + "_colliders"), path
        reference = os.path.join(args.work, "tool_colliders" + os.path.basename(path)[len(name) + 10 :])
        tool(args, "colliders", kept, "--format", fmt, "-o", reference, "--fps", "5", "--budget", "32")
        with open(path, "rb") as f, open(reference, "rb") as g:
            ours, theirs = f.read(), g.read()
        if fmt == "json":  # the report inside names the input and the time taken
            ours, theirs = json.loads(ours), json.loads(theirs)
            for data in (ours, theirs):
                for key in ("seconds", "character"):
                    data["report"].pop(key)
        assert ours == theirs, f"{fmt}: the add-on's {path} differs from the tool's {reference}"
        formats.append(f"{fmt} {time.monotonic() - started:.1f} s")
    print(f"collider exports equal to the tool's: {', '.join(formats)}")


def test_cancel_and_message(args, addon, armature, state):
    before = action_state(armature)
    state.scope = "ALL"
    operator = addon.operators.SKINSPHERES_OT_check
    job = operator.job(operator, bpy.context)
    steps = 0
    for step in job:  # up to the first clip: the export is done, its state restored
        steps += 1
        if step is None:
            time.sleep(0.005)
        if step is not None and step[1].startswith("Check: ") and "(1/" in step[1]:
            break
    job.close()  # what Esc does
    assert action_state(armature) == before, "cancelling left the animation state changed"
    prefs = bpy.context.preferences.addons[ADDON].preferences
    folder = prefs.module_dir
    prefs.module_dir = os.path.join(args.work, "no-such-folder")
    ss, error = addon.module.load()
    assert ss is None and "no skinspheres package" in error, error
    prefs.module_dir = folder
    assert addon.module.load()[0] is not None
    print(f"cancel: state restored after {steps} steps; a wrong module folder says: {error}")


def main():
    args = parse()
    if args.character != "builtin" and not os.path.exists(args.character):
        print(f"{args.character}: not present (the shared characters are not in the repository): skipped")
        sys.exit(77)
    os.makedirs(args.work, exist_ok=True)
    if args.character == "builtin":
        args.character = os.path.join(args.work, "builtin.glb")
        tool(args, "export-builtin", args.character)
    addon, ss = install(args)
    armature, clips = load_character(args, ss)
    state = bpy.context.scene.skinspheres
    state.output_dir = args.work
    fps = addon.character.fps(bpy.context.scene)
    test_fit(args, ss, armature, state)
    test_check_all(args, armature, clips, state, fps)
    test_check_active_and_jump(armature, state)
    test_fix(args, addon, armature, clips, state, fps)
    test_check_clip_files(args, armature, state, fps)
    test_colliders(args, ss, armature, state, fps)
    test_collider_exports(args, armature, state)
    test_cancel_and_message(args, addon, armature, state)
    print(f"blender add-on: every check passed on {os.path.basename(args.character)}")


main()
