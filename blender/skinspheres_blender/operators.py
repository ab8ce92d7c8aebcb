"""The panel's operators: Fit, Check and Fix, each a job of jobs.LongOperator (modal with progress
from the UI, to the end at once from scripts)."""

import json
import os
import shutil
import tempfile

import bpy
import numpy as np

from . import fixed_action, results, spheres_object
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
                yield 0.05 + 0.85 * i / len(actions), f"Check: {action.name} ({i + 1}/{len(actions)})"
                result = yield from in_thread(
                    ss.play, glb, clip=clips[action.name], fps=rate, mode=state.mode, spheres=ssb
                )
                markers, pairs = penetrations(ss, result)
                results.mark_action(action, markers)
                self._list(state, action, pairs)
            yield 0.9, "Check: the report"
            report = yield from in_thread(
                ss.check, glb, max_depth=state.max_depth / 100, fps=rate, mode=state.mode, spheres=ssb
            )
            if state.keep_glb:
                shutil.copyfile(glb, output_path(context, armature, "_checked.glb"))
        report["blender"] = {"file": bpy.data.filepath, "armature": armature.name, "scene_fps": rate}
        path = output_path(context, armature, "_check.json")
        _write_json(path, report)
        state.check_report = path
        active = armature.animation_data.action if armature.animation_data else None
        results.show_action_markers(scene, active)
        failing = sum(c["verdict"] == "penetrating" for c in report["clips"])
        yield 1.0, f"Check: {failing} of {len(actions)} fail ({state.max_depth:g}%)"

    @staticmethod
    def _list(state, action, pairs):
        for (a, b), pair in sorted(pairs.items(), key=lambda kv: -kv[1]["depth"]):
            row = state.pairs.add()
            row.action, row.part_a, row.part_b = action.name, a, b
            row.first_frame, row.last_frame = min(pair["frames"]), max(pair["frames"])
            row.frames, row.worst_frame, row.depth_share = len(pair["frames"]), pair["worst"], pair["share"]


def _fix_summary(clip):
    before, after = clip["before"], clip["after"]
    text = f"{before['frames_penetrating']} -> {after['frames_penetrating']} frames penetrating"
    if clip["joints_changed"]:
        text += f", {len(clip['joints_changed'])} joints, up to {clip['rotation_change_deg']['max']:.1f} deg"
    return text


def merge_fix_reports(reports):
    """One report from Fix's per-clip reports: their clips, the summary's counts added up."""
    merged = {k: v for k, v in reports[0].items() if k not in ("clips", "exit_code", "output")}
    merged["clips"] = [clip for report in reports for clip in report["clips"]]
    summary = {}
    for report in reports:
        for key, value in report["summary"].items():
            summary[key] = summary.get(key, 0) + value
    merged["summary"] = summary
    return merged


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
        report = merge_fix_reports(reports)
        report["blender"] = {"file": bpy.data.filepath, "armature": armature.name, "scene_fps": rate}
        path = output_path(context, armature, "_fix.json")
        _write_json(path, report)
        state.fix_report = path
        s = report["summary"]
        yield 1.0, f"Fix: {s.get('fixed', 0)} fixed, {s.get('clean', 0)} clean, {s.get('unfixed', 0)} unfixed"


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


classes = (SKINSPHERES_OT_fit, SKINSPHERES_OT_check, SKINSPHERES_OT_fix, SKINSPHERES_OT_show_action)
