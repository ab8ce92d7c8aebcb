"""The panel's operators: Fit, Check, Fix and Colliders, each a job of jobs.LongOperator (modal with progress
from the UI, to the end at once from scripts)."""

import json
import os
import shutil
import tempfile

import bpy
import numpy as np

from . import colliders, fixed_action, results, spheres_object
from .character import Failure, active_armature, actions_of, export_glb, fps
from .jobs import LongOperator, in_thread, module_or_fail


def output_path(context, armature, suffix):
    """<output folder>/<armature><suffix>; the folder is the setting, else the .blend's, else a
    temporary one."""
    setting = context.scene.skinspheres.output_dir
    if setting:
        folder = bpy.path.abspath(setting)
    elif bpy.data.filepath:
        folder = bpy.path.abspath("//")
    else:
        folder = os.path.join(tempfile.gettempdir(), "skinspheres")
    os.makedirs(folder, exist_ok=True)
    return os.path.join(folder, bpy.path.clean_name(armature.name) + suffix)


def _fit_into(ss, glb, scratch):
    """Generator: fits glb (the file Check or Fix exported: a set is tied to its file's vertex
    positions, bit for bit) into scratch; returns the .ssb's path."""
    spheres = yield from in_thread(ss.fit, glb)
    path = os.path.join(scratch, "spheres.ssb")
    spheres.save(path)
    return path


def _clip_indices(ss, glb, actions):
    """{action name: its clip's index in the exported file}; every action must be there."""
    clips = ss.clip_names(glb)
    missing = [a.name for a in actions if a.name not in clips]
    if missing:
        raise Failure(f"the glTF exporter wrote no clip for {', '.join(missing)} (does it key the bones?)")
    return {name: i for i, name in enumerate(clips)}


def _write_json(path, report):
    with open(path, "w") as f:
        json.dump(report, f, indent=1, sort_keys=True)


class SKINSPHERES_OT_fit(LongOperator, bpy.types.Operator):
    bl_idname = "skinspheres.fit"
    bl_label = "Fit"
    bl_description = "Fit the sphere set of the active armature's meshes, show it on the bones and save it (.ssb)"

    def job(self, context):
        ss = module_or_fail()
        armature = active_armature(context)
        yield 0.0, f"Fit: exporting {armature.name}"
        with tempfile.TemporaryDirectory(prefix="skinspheres_") as scratch:
            glb = os.path.join(scratch, "character.glb")
            export_glb(context, armature, glb, [])
            yield 0.1, f"Fit: fitting {armature.name}"
            spheres = yield from in_thread(ss.fit, glb)
        path = output_path(context, armature, ".ssb")
        spheres.save(path)
        armature["skinspheres_ssb"] = path
        spheres_object.build(armature, spheres)
        yield 1.0, f"Fit: {len(spheres)} spheres, {len(spheres.part_names)} body parts, saved {path}"


def penetrations(ss, result):
    """From a play() result: the markers [(frame, name)] (one per penetrating frame, for its deepest
    pair) and the part pairs {(a, b): dict} with their frames and depths."""
    parts = result["part_contacts"]
    parts = parts[parts["kind"] == ss.PENETRATING]
    height = result["body_height"] or 1.0
    names = result["part_names"]
    markers, pairs = [], {}
    for frame in np.unique(parts["frame"]):
        rows = parts[parts["frame"] == frame]
        worst = rows[np.argmax(rows["depth"])]
        share = float(worst["depth"]) / height
        pair = f"{names[worst['part_a']]}-{names[worst['part_b']]}"
        markers.append((int(frame), f"{results.PREFIX}{pair} {100 * share:.1f}%"))
    for row in parts:
        key = (names[row["part_a"]], names[row["part_b"]])
        pair = pairs.setdefault(key, {"frames": set(), "depth": -1.0, "worst": 0})
        pair["frames"].add(int(row["frame"]))
        if row["depth"] > pair["depth"]:
            pair["depth"], pair["worst"] = float(row["depth"]), int(row["frame"])
    for pair in pairs.values():
        pair["share"] = pair["depth"] / height
    return markers, pairs


class SKINSPHERES_OT_check(LongOperator, bpy.types.Operator):
    bl_idname = "skinspheres.check"
    bl_label = "Check"
    bl_description = (
        "Play the active action (or every action) with skinspheres: markers on the penetrating frames, "
        "the part pairs in the list, the JSON report"
    )

    def job(self, context):
        ss = module_or_fail()
        scene, state = context.scene, context.scene.skinspheres
        armature = active_armature(context)
        actions = actions_of(armature, state.scope)
        files = clip_files(state)
        if not actions and not files:
            raise Failure("no action and no clip file to check")
        rate = fps(scene)
        yield 0.0, f"Check: exporting {len(actions)} action(s)"
        with tempfile.TemporaryDirectory(prefix="skinspheres_") as scratch:
            glb = os.path.join(scratch, "character.glb")
            export_glb(context, armature, glb, actions)
            yield 0.02, f"{self.bl_label}: fitting the spheres"
            ssb = yield from _fit_into(ss, glb, scratch)
            clips = _clip_indices(ss, glb, actions)
            state.pairs.clear()
            state.pair_index = -1
            state.armature = armature.name
            for i, action in enumerate(actions):
                yield 0.05 + 0.8 * i / len(actions), f"Check: {action.name} ({i + 1}/{len(actions)})"
                result = yield from in_thread(
                    ss.play, glb, clip=clips[action.name], fps=rate, mode=state.mode, spheres=ssb
                )
                markers, pairs = penetrations(ss, result)
                results.mark_action(action, markers)
                self._list(state, action, pairs)
            reports = []
            if actions:
                yield 0.85, "Check: the report"
                reports.append((yield from in_thread(
                    ss.check, glb, max_depth=state.max_depth / 100, fps=rate, mode=state.mode, spheres=ssb
                )))
            if files:
                yield 0.9, f"Check: {len(files)} clip file(s)"
                report = yield from in_thread(
                    ss.check, glb, files, max_depth=state.max_depth / 100, fps=rate, mode=state.mode, spheres=ssb,
                    **retarget_options(state),
                )
                self._list_files(state, report)
                reports.append(report)
            if state.keep_glb:
                shutil.copyfile(glb, output_path(context, armature, "_checked.glb"))
        report = merge_reports(reports)
        report["blender"] = {"file": bpy.data.filepath, "armature": armature.name, "scene_fps": rate,
                             "clip_files": files}
        path = output_path(context, armature, "_check.json")
        _write_json(path, report)
        state.check_report = path
        active = armature.animation_data.action if armature.animation_data else None
        results.show_action_markers(scene, active)
        failing = sum(c["verdict"] == "penetrating" for c in report["clips"])
        yield 1.0, f"Check: {failing} of {len(report['clips'])} fail ({state.max_depth:g}%)"

    @staticmethod
    def _list_files(state, report):
        """The part pairs of the clips read from files, from the report (no markers: no action)."""
        for clip in report["clips"]:
            penetrating = [p for p in clip.get("part_pairs", []) if p["penetrating_frames"]]
            for pair in sorted(penetrating, key=lambda p: -p["max_depth_share"]):
                row = state.pairs.add()
                row.action, row.clip_file = clip["name"], clip.get("file", "")
                row.part_a, row.part_b = pair["parts"]
                row.first_frame, row.last_frame = pair["first_frame"], pair["last_frame"]
                row.frames, row.worst_frame = pair["penetrating_frames"], pair["worst_frame"]
                row.depth_share = pair["max_depth_share"]

    @staticmethod
    def _list(state, action, pairs):
        for (a, b), pair in sorted(pairs.items(), key=lambda kv: -kv[1]["depth"]):
            row = state.pairs.add()
            row.action, row.part_a, row.part_b = action.name, a, b
            row.first_frame, row.last_frame = min(pair["frames"]), max(pair["frames"])
            row.frames, row.worst_frame, row.depth_share = len(pair["frames"]), pair["worst"], pair["share"]


def clip_files(state):
    """The Check list's clip files, absolute."""
    return [bpy.path.abspath(f.path) for f in state.clip_files if f.path.strip()]


def retarget_options(state):
    """The retarget options `check` and `colliders` take for clip files."""
    return {"joint_map": bpy.path.abspath(state.joint_map) if state.joint_map else "",
            "source_rest": state.source_rest, "retarget": state.retarget}


def merge_reports(reports):
    """One report from several `check` or `fix` reports of the same character: their clips, the
    summary's counts added up, the worst exit code."""
    merged = {k: v for k, v in reports[0].items() if k not in ("clips", "exit_code", "output")}
    merged["clips"] = [clip for report in reports for clip in report["clips"]]
    summary = {}
    for report in reports:
        for key, value in report["summary"].items():
            summary[key] = summary.get(key, 0) + value
    merged["summary"] = summary
    if all("exit_code" in r for r in reports):
        merged["exit_code"] = max(r["exit_code"] for r in reports)
    return merged


def _fix_summary(clip):
    before, after = clip["before"], clip["after"]
    text = f"{before['frames_penetrating']} -> {after['frames_penetrating']} frames penetrating"
    if clip["joints_changed"]:
        text += f", {len(clip['joints_changed'])} joints, up to {clip['rotation_change_deg']['max']:.1f} deg"
    return text


class SKINSPHERES_OT_fix(LongOperator, bpy.types.Operator):
    bl_idname = "skinspheres.fix"
    bl_label = "Fix"
    bl_description = (
        "Fix the active action (or every action) so that no part pair penetrates deeper than the limit: "
        "a new action \"NAME (fixed)\" beside the original, which is not changed"
    )

    def job(self, context):
        ss = module_or_fail()
        scene, state = context.scene, context.scene.skinspheres
        armature = active_armature(context)
        actions = actions_of(armature, state.scope, fixed=False)
        if not actions:
            raise Failure("no action to fix (Actions: No action)")
        rate = fps(scene)
        yield 0.0, f"Fix: exporting {len(actions)} action(s)"
        reports = []
        state.fixed.clear()
        with tempfile.TemporaryDirectory(prefix="skinspheres_") as scratch:
            glb = os.path.join(scratch, "character.glb")
            export_glb(context, armature, glb, actions)
            yield 0.02, f"{self.bl_label}: fitting the spheres"
            ssb = yield from _fit_into(ss, glb, scratch)
            clips = _clip_indices(ss, glb, actions)
            for i, action in enumerate(actions):
                yield 0.05 + 0.9 * i / len(actions), f"Fix: {action.name} ({i + 1}/{len(actions)})"
                out = os.path.join(scratch, f"fixed{i}.glb")
                report = yield from in_thread(
                    ss.fix, glb, out, clip=str(clips[action.name]), max_depth=state.fix_depth / 100,
                    spheres=ssb, fps=rate,
                )
                reports.append(report)
                clip = report["clips"][0]
                row = state.fixed.add()
                row.verdict, row.summary = clip["verdict"], _fix_summary(clip)
                row.action = action.name
                if clip["verdict"] == "fixed":
                    row.action = fixed_action.create(armature, action, out, clip["name"], rate).name
        report = merge_reports(reports)
        report.pop("exit_code", None)
        report["blender"] = {"file": bpy.data.filepath, "armature": armature.name, "scene_fps": rate}
        path = output_path(context, armature, "_fix.json")
        _write_json(path, report)
        state.fix_report = path
        s = report["summary"]
        yield 1.0, f"Fix: {s.get('fixed', 0)} fixed, {s.get('clean', 0)} clean, {s.get('unfixed', 0)} unfixed"


# Colliders' export formats: (name in the panel, the file's suffix after the armature's name).
EXPORTS = {
    "vrm1": ("VRM 1.0", "_colliders_vrm1.glb"),
    "vrm0": ("VRM 0.x", "_colliders_vrm0.glb"),
    "godot": ("Godot", "_colliders.tscn"),
    "unity": ("Unity", "_colliders.cs"),
    "usd": ("USD", "_colliders.usda"),
    "json": ("JSON", "_colliders_shapes.json"),
}


def _colliders(context, label, fmt="json", output=None):
    """Generator: exports the armature with the chosen actions (Actions: No action: the clip files,
    retargeted as Check does), runs `skinspheres.colliders` on it; returns (armature, result)."""
    ss = module_or_fail()
    state = context.scene.skinspheres
    armature = active_armature(context)
    actions = [] if state.scope == "NONE" else actions_of(armature, state.scope)
    files = clip_files(state) if state.scope == "NONE" else []
    yield 0.0, f"{label}: exporting {len(actions)} action(s)"
    with tempfile.TemporaryDirectory(prefix="skinspheres_") as scratch:
        glb = os.path.join(scratch, "character.glb")
        export_glb(context, armature, glb, actions)
        yield 0.1, f"{label}: fitting {state.collider_budget} shapes"
        result = yield from in_thread(
            ss.colliders, glb, files, budget=state.collider_budget, shapes=state.collider_shapes, format=fmt,
            output=output, fps=state.collider_fps, **retarget_options(state),
        )
        if state.keep_glb:
            shutil.copyfile(glb, output_path(context, armature, "_colliders_input.glb"))
    result["blender"] = {"file": bpy.data.filepath, "armature": armature.name, "clip_files": files,
                         "actions": [a.name for a in actions]}
    return armature, result


def _colliders_summary(result):
    kinds = [c["type"] for c in result["colliders"]]
    covered = result["summary"]["min_covered"]
    return (f"{len(kinds)} shapes ({kinds.count('sphere')} spheres, {len(kinds) - kinds.count('sphere')} capsules), "
            f"{100 * covered:.1f}% covered on the worst of {result['poses']['measured']} poses")


class SKINSPHERES_OT_colliders(LongOperator, bpy.types.Operator):
    bl_idname = "skinspheres.colliders"
    bl_label = "Fit Colliders"
    bl_description = (
        "Fit spheres and capsules covering the character over its actions' poses: objects parented to their "
        "bones, coloured by coverage, in the collection \"skinspheres colliders\""
    )

    def job(self, context):
        armature, result = yield from _colliders(context, "Colliders")
        objects = colliders.build(context, armature, result)
        report = {k: v for k, v in result.items() if k not in _ARRAYS}
        path = output_path(context, armature, "_colliders.json")
        _write_json(path, report)
        context.scene.skinspheres.colliders_report = path
        yield 1.0, f"Colliders: {len(objects)} objects: {_colliders_summary(result)}"


# colliders()' shapes as arrays, beside its report.
_ARRAYS = ("joint", "head", "tail", "head_radius", "tail_radius", "part", "joint_names", "joint_rest_world")


class SKINSPHERES_OT_colliders_export(LongOperator, bpy.types.Operator):
    bl_idname = "skinspheres.colliders_export"
    bl_label = "Export Colliders"
    bl_description = "Fit the colliders and write them in an engine's format into the output folder"

    format: bpy.props.EnumProperty(items=[(k, v[0], f"{v[0]}: <armature>{v[1]}") for k, v in EXPORTS.items()])
    filepath: bpy.props.StringProperty(
        subtype="FILE_PATH", options={"SKIP_SAVE"},
        description="Where to write (its extension the format's); empty: <output>/<armature><suffix>",
    )

    def job(self, context):
        armature = active_armature(context)
        path = bpy.path.abspath(self.filepath) if self.filepath else output_path(
            context, armature, EXPORTS[self.format][1])
        _, result = yield from _colliders(context, f"Export {self.format}", self.format, path)
        context.scene.skinspheres.colliders_export = path
        yield 1.0, f"Colliders: wrote {path}: {_colliders_summary(result)}"


class SKINSPHERES_OT_clip_file_add(bpy.types.Operator):
    bl_idname = "skinspheres.clip_file_add"
    bl_label = "Add clip files"
    bl_description = "Add files of clips (glTF, FBX, BVH) for Check to play on the character, retargeted"

    filepath: bpy.props.StringProperty(subtype="FILE_PATH")
    directory: bpy.props.StringProperty(subtype="DIR_PATH")
    files: bpy.props.CollectionProperty(type=bpy.types.OperatorFileListElement)
    filter_glob: bpy.props.StringProperty(default="*.glb;*.gltf;*.fbx;*.bvh;*.vrm", options={"HIDDEN"})

    def invoke(self, context, _event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        state = context.scene.skinspheres
        paths = [os.path.join(self.directory, f.name) for f in self.files if f.name] or [self.filepath]
        for path in paths:
            if path:
                state.clip_files.add().path = path
        state.clip_file_index = len(state.clip_files) - 1
        return {"FINISHED"}


class SKINSPHERES_OT_clip_file_remove(bpy.types.Operator):
    bl_idname = "skinspheres.clip_file_remove"
    bl_label = "Remove clip file"
    bl_description = "Remove the selected clip file from the list"

    def execute(self, context):
        state = context.scene.skinspheres
        if 0 <= state.clip_file_index < len(state.clip_files):
            state.clip_files.remove(state.clip_file_index)
            state.clip_file_index = min(state.clip_file_index, len(state.clip_files) - 1)
        return {"FINISHED"}


class SKINSPHERES_OT_show_action(bpy.types.Operator):
    bl_idname = "skinspheres.show_action"
    bl_label = "Show"
    bl_description = "Make this action the armature's active one"

    action: bpy.props.StringProperty()

    def execute(self, context):
        armature = active_armature(context)
        action = bpy.data.actions.get(self.action)
        if armature is None or action is None:
            return {"CANCELLED"}
        data = armature.animation_data or armature.animation_data_create()
        if data.use_tweak_mode:
            self.report({"ERROR"}, "leave NLA tweak mode first")
            return {"CANCELLED"}
        data.action = action
        results.show_action_markers(context.scene, action)
        return {"FINISHED"}


classes = (
    SKINSPHERES_OT_fit,
    SKINSPHERES_OT_check,
    SKINSPHERES_OT_fix,
    SKINSPHERES_OT_colliders,
    SKINSPHERES_OT_colliders_export,
    SKINSPHERES_OT_clip_file_add,
    SKINSPHERES_OT_clip_file_remove,
    SKINSPHERES_OT_show_action,
)
