"""The sidebar panel (View3D > N > skinspheres) and its list of part pairs."""

import os
import textwrap

import bpy

from . import module
from .character import active_armature, meshes_of
from .jobs import busy
from .operators import EXPORTS


def wrapped(layout, context, text, icon="NONE"):
    """Labels for text wrapped to the region's width (Blender 3.4's labels do not wrap)."""
    scale = context.preferences.view.ui_scale
    chars = max(16, int((context.region.width - 40 * scale) / (7 * scale)))  # less the icon and margins
    column = layout.column(align=True)
    for i, line in enumerate(textwrap.wrap(text, chars) or [""]):
        column.label(text=line, icon=icon if i == 0 else ("BLANK1" if icon != "NONE" else "NONE"))


class SKINSPHERES_UL_pairs(bpy.types.UIList):
    """One row per action and penetrating part pair: parts, frames, deepest share of the height."""

    def draw_item(self, _context, layout, _data, item, _icon, _active_data, _active_propname, _index=0):
        row = layout.split(factor=0.62, align=True)
        row.label(text=f"{item.part_a}-{item.part_b}", icon="ERROR" if item.depth_share >= 0.01 else "DOT")
        row.label(text=f"{100 * item.depth_share:.2f}%")


class SKINSPHERES_UL_clip_files(bpy.types.UIList):
    def draw_item(self, _context, layout, _data, item, _icon, _active_data, _active_propname, _index=0):
        layout.prop(item, "path", text="", emboss=False, icon="FILE_MOVIE")


class SKINSPHERES_PT_panel(bpy.types.Panel):
    bl_label = "skinspheres"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "skinspheres"

    def draw(self, context):
        layout = self.layout
        ss, error = module.load()
        if ss is None:
            box = layout.box()
            for i, line in enumerate(module.error_lines(error)):
                wrapped(box, context, line, icon="ERROR" if i == 0 else "NONE")
            box.operator("preferences.addon_show", text="Open preferences").module = __package__
            return
        armature = active_armature(context)
        if armature is None:
            layout.label(text="Select an armature or one of its meshes", icon="INFO")
            return
        state = context.scene.skinspheres
        action = armature.animation_data.action if armature.animation_data else None
        layout.label(text=f"{armature.name}: {len(meshes_of(armature))} meshes", icon="ARMATURE_DATA")
        layout.label(text=f"Action: {action.name if action else '(none)'}", icon="ACTION")
        layout.prop(state, "output_dir")
        if busy() or state.status:
            wrapped(layout, context, state.status + (" (Esc cancels)" if busy() else ""), "TIME" if busy() else "INFO")
        self._fit(layout, armature)
        self._check(layout, state)
        self._fix(layout, state)
        self._colliders(layout, state)

    @staticmethod
    def _fit(layout, armature):
        box = layout.box()
        box.label(text="Fit", icon="SPHERE")
        box.operator("skinspheres.fit", text="Fit spheres")
        spheres = bpy.data.objects.get(f"{armature.name} spheres")
        if spheres is not None:
            box.prop(spheres, "hide_viewport", text="Hide spheres")
            box.label(text=f"{spheres.get('skinspheres_spheres', 0)} spheres: {armature.get('skinspheres_ssb', '')}")

    @staticmethod
    def _check(layout, state):
        box = layout.box()
        box.label(text="Check", icon="VIEWZOOM")
        box.prop(state, "scope", text="")
        row = box.row()
        row.label(text="Fail over %")
        row.prop(state, "max_depth", text="")
        row.prop(state, "mode", text="")
        box.prop(state, "keep_glb")
        box.label(text="Clip files (retargeted, checked too)")
        row = box.row()
        row.template_list("SKINSPHERES_UL_clip_files", "", state, "clip_files", state, "clip_file_index", rows=2)
        column = row.column(align=True)
        column.operator("skinspheres.clip_file_add", text="", icon="ADD")
        column.operator("skinspheres.clip_file_remove", text="", icon="REMOVE")
        if state.clip_files:
            column = box.column(align=True)
            column.prop(state, "retarget")
            column.prop(state, "joint_map")
            column.prop(state, "source_rest")
        box.operator("skinspheres.check", text="Check")
        if state.pairs:
            box.label(text="Part pairs (click: deepest frame)")
            box.template_list("SKINSPHERES_UL_pairs", "", state, "pairs", state, "pair_index", rows=4)
            if 0 <= state.pair_index < len(state.pairs):
                pair = state.pairs[state.pair_index]
                column = box.column(align=True)
                source = f"{os.path.basename(pair.clip_file)}: " if pair.clip_file else ""
                column.label(text=f"{source}{pair.action}: {pair.part_a} - {pair.part_b}")
                span = "in contact" if pair.clip_file else ""  # a file's pairs: the report's contact span
                column.label(text=f"frames {pair.first_frame}-{pair.last_frame} {span}, {pair.frames} penetrating")
                column.label(text=f"deepest {100 * pair.depth_share:.2f}% at frame {pair.worst_frame}")
        if state.check_report:
            box.label(text=f"Report: {state.check_report}")

    @staticmethod
    def _fix(layout, state):
        box = layout.box()
        box.label(text="Fix", icon="MODIFIER")
        row = box.row()
        row.label(text="Fix to %")
        row.prop(state, "fix_depth", text="")
        box.operator("skinspheres.fix", text="Fix into new actions")
        for row in state.fixed:
            column = box.column(align=True)
            line = column.row()
            line.label(text=f"{row.action}: {row.verdict}", icon="CHECKMARK" if row.verdict != "unfixed" else "ERROR")
            if row.verdict == "fixed":
                line.operator("skinspheres.show_action", text="", icon="PLAY").action = row.action
            column.label(text=row.summary)
        if state.fix_report:
            box.label(text=f"Report: {state.fix_report}")


    @staticmethod
    def _colliders(layout, state):
        box = layout.box()
        box.label(text="Colliders", icon="MESH_CAPSULE")
        row = box.row()
        row.prop(state, "collider_budget")
        row.prop(state, "collider_shapes", text="")
        box.prop(state, "collider_fps")
        if state.scope == "NONE":
            box.label(text="Poses: the rest pose and the clip files")
        box.operator("skinspheres.colliders", text="Fit Colliders")
        if state.colliders_report:
            box.label(text=f"Report: {state.colliders_report}")
        box.label(text="Export (fits again):")
        grid = box.grid_flow(columns=3, align=True)
        for key, (name, _) in EXPORTS.items():
            grid.operator("skinspheres.colliders_export", text=name).format = key
        if state.colliders_export:
            box.label(text=f"Wrote {state.colliders_export}")


classes = (SKINSPHERES_UL_pairs, SKINSPHERES_UL_clip_files, SKINSPHERES_PT_panel)
