"""The add-on's long work as the UI runs it: modal, with progress, cancelled by Esc. Needs Blender's
UI (under Xvfb) and simulated events:

    xvfb-run -a blender --factory-startup --enable-event-simulate --python tests/blender/test_modal.py -- \
        --zip build/skinspheres_blender.zip --module-dir build/python --tool build/samples/skinspheres --work DIR

On the built-in character:
1. Check invoked from the 3D view runs modal: the timer that watches it keeps running while it works
   (the UI is not blocked), its progress passes through each action, and it ends with the markers
   and part pairs the same job gives run at once (EXEC_DEFAULT).
2. Fix invoked, then Esc at its first step: it reports "cancelled", makes no "(fixed)" action, and
   the armature's actions, NLA and active action are as they were.
Prints "modal: ok" and exits 0, or prints the failure and exits 1. test_addon.py checks the numbers.
"""

import argparse
import os
import subprocess
import sys
import traceback

import numpy

if "bool" not in numpy.__dict__:  # Blender 3.4's glTF importer calls np.bool (gone in numpy 1.24)
    numpy.bool = bool

import bpy  # noqa: E402

ADDON = "skinspheres_blender"
TICK = 0.05
TIMEOUT_TICKS = int(120 / TICK)


def parse():
    argv = sys.argv[sys.argv.index("--") + 1 :]
    parser = argparse.ArgumentParser()
    for name in ("--zip", "--module-dir", "--tool", "--work"):
        parser.add_argument(name, required=True)
    return parser.parse_args(argv)


def finish(code, message):
    print(message, flush=True)
    os._exit(code)  # from a timer: Blender's own exit would not carry the code


def guarded(step):
    """A timer callback that ends the run with exit 1 on any failure."""

    def run():
        try:
            return step()
        except Exception:
            finish(1, "modal: FAILED\n" + traceback.format_exc())

    return run


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    return window, area


def animation_state(armature):
    data = armature.animation_data
    return (
        sorted(a.name for a in bpy.data.actions),
        [(t.name, t.mute, [(s.action.name, s.mute) for s in t.strips]) for t in data.nla_tracks],
        data.action.name if data.action else None,
    )


def markers():
    return {a.name: sorted((m.frame, m.name) for m in a.pose_markers) for a in bpy.data.actions}


class Run:
    def __init__(self, args):
        self.args = args
        addon = sys.modules[ADDON]
        self.jobs = addon.jobs
        self.state = bpy.context.scene.skinspheres
        self.armature = next(o for o in bpy.data.objects if o.type == "ARMATURE")
        self.ticks, self.seen = 0, []

    def start_check(self):
        window, area = view3d()
        with bpy.context.temp_override(window=window, area=area):
            assert bpy.ops.skinspheres.check("INVOKE_DEFAULT") == {"RUNNING_MODAL"}
        assert self.jobs.busy(), "a modal job is running"
        bpy.app.timers.register(guarded(self.watch_check), first_interval=TICK)

    def watch_check(self):
        self.ticks += 1
        assert self.ticks < TIMEOUT_TICKS, "Check did not end"
        if self.jobs.busy():
            if not self.seen or self.seen[-1] != self.state.status:
                self.seen.append(self.state.status)
            return TICK
        actions = len({p.action for p in self.state.pairs} | {"walk_skin", "touch_skin"})
        steps = [s for s in self.seen if s.startswith("Check: ") and "/" in s]
        assert len(steps) >= 1, f"progress through the actions: {self.seen}"
        assert self.ticks > 2, "the watching timer ran while Check worked"
        assert self.state.status.startswith("Check: ") and "fail" in self.state.status, self.state.status
        modal_markers, modal_pairs = markers(), [(p.action, p.part_a, p.part_b) for p in self.state.pairs]
        assert bpy.ops.skinspheres.check() == {"FINISHED"}
        assert markers() == modal_markers, "the modal run's markers are the same job's run at once"
        assert [(p.action, p.part_a, p.part_b) for p in self.state.pairs] == modal_pairs
        print(f"modal check: {self.ticks} ticks, {actions} actions, progress {steps}", flush=True)
        self.before = animation_state(self.armature)
        window, area = view3d()
        with bpy.context.temp_override(window=window, area=area):
            assert bpy.ops.skinspheres.fix("INVOKE_DEFAULT") == {"RUNNING_MODAL"}
        self.ticks = 0
        bpy.app.timers.register(guarded(self.escape), first_interval=TICK)
        return None

    def escape(self):
        window, _ = view3d()
        window.event_simulate(type="ESC", value="PRESS")
        bpy.app.timers.register(guarded(self.watch_fix), first_interval=TICK)
        return None

    def watch_fix(self):
        self.ticks += 1
        assert self.ticks < TIMEOUT_TICKS, "Fix did not end after Esc"
        if self.jobs.busy():
            return TICK
        assert self.state.status == "Fix: cancelled", self.state.status
        assert animation_state(self.armature) == self.before, "Esc left the animation state changed"
        assert not [a for a in bpy.data.actions if a.name.endswith(" (fixed)")]
        finish(0, f"modal fix: cancelled by Esc after {self.ticks} ticks, nothing changed\nmodal: ok")


def set_up(args):
    os.makedirs(args.work, exist_ok=True)
    character = os.path.join(args.work, "builtin.glb")
    subprocess.run([args.tool, "export-builtin", character], check=True, capture_output=True)
    bpy.ops.preferences.addon_install(filepath=os.path.abspath(args.zip), overwrite=True)
    bpy.ops.preferences.addon_enable(module=ADDON)
    bpy.context.preferences.addons[ADDON].preferences.module_dir = args.module_dir
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    bpy.ops.import_scene.gltf(filepath=character)
    armature = next(o for o in bpy.data.objects if o.type == "ARMATURE")
    bpy.context.view_layer.objects.active = armature
    state = bpy.context.scene.skinspheres
    state.output_dir, state.scope = args.work, "ALL"
    return Run(args)


def main():
    args = parse()
    try:
        run = set_up(args)
    except Exception:
        finish(1, "modal: FAILED in set-up\n" + traceback.format_exc())
    bpy.app.timers.register(guarded(run.start_check), first_interval=1.0)


main()
