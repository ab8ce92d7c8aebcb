"""The character the panel works on (the active armature and its meshes) and its export to GLB.

skinspheres reads files, so the add-on hands it the character as Blender's glTF exporter writes it:
the armature, the meshes it deforms, and the chosen actions, each as its own clip named for the
action. The exporter samples each action at the scene's frame rate from time 0, so the tools' frame
k is the scene's frame k (at fps / fps_base).
"""

import bpy
from mathutils import Matrix

# Blender's Z-up world to glTF's Y-up world, as the exporter converts it (x, y, z) -> (x, z, -y).
Y_UP = Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))


FIXED = " (fixed)"  # Fix's action for NAME is "NAME (fixed)"


class Failure(Exception):
    """A reason the work cannot go on, shown to the user as is."""


def active_armature(context):
    """The active object if it is an armature, the armature deforming the active mesh, or None."""
    obj = context.active_object
    if obj is None:
        return None
    if obj.type == "ARMATURE":
        return obj
    if obj.type == "MESH":
        for modifier in obj.modifiers:
            if modifier.type == "ARMATURE" and modifier.object is not None:
                return modifier.object
        if obj.parent is not None and obj.parent.type == "ARMATURE":
            return obj.parent
    return None


def meshes_of(armature):
    """The meshes the armature deforms (an Armature modifier on it), in name order."""
    found = [
        obj
        for obj in bpy.data.objects
        if obj.type == "MESH"
        and "skinspheres_spheres" not in obj  # Fit's spheres object is not part of the character
        and any(m.type == "ARMATURE" and m.object == armature for m in obj.modifiers)
    ]
    return sorted(found, key=lambda o: o.name)


def fps(scene):
    return scene.render.fps / scene.render.fps_base


def actions_of(armature, scope, fixed=True):
    """scope "ACTIVE": the active action; "ALL": every action that animates this armature's bones
    (with fixed=False, not the "NAME (fixed)" ones Fix made); "NONE": none (only clip files)."""
    if scope == "NONE":
        return []
    data = armature.animation_data
    if scope == "ACTIVE":
        if data is None or data.action is None:
            raise Failure(f"{armature.name} has no active action")
        return [data.action]
    bones = {b.name for b in armature.data.bones}
    found = [a for a in bpy.data.actions if _animates(a, bones) and (fixed or not a.name.endswith(FIXED))]
    if not found:
        raise Failure(f"no action animates {armature.name}'s bones")
    return sorted(found, key=lambda a: a.name.lower())


def _animates(action, bones):
    for fcurve in action.fcurves:
        path = fcurve.data_path
        if path.startswith('pose.bones["') and path[12 : path.find('"]')] in bones:
            return True
    return False


def export_glb(context, armature, path, actions):
    """Writes the armature, its meshes and `actions` (each a clip named for the action) to path,
    the nodes at the rest pose. Selection, the active action, the pose and the NLA are restored.

    Two exports of the same character may differ in the last bits of the vertex positions (the
    exporter moves them into the skeleton's space through evaluated matrices), and a sphere set
    is tied to its file's exact positions: so Check and Fix fit the file they export."""
    meshes = meshes_of(armature)
    if not meshes:
        raise Failure(f"no mesh is deformed by {armature.name} (an Armature modifier pointing at it)")
    options = {
        "filepath": path,
        "export_format": "GLB",
        "use_selection": True,
        "export_animations": bool(actions),
        "export_skins": True,
        "export_nla_strips": True,  # 3.x: one clip per NLA track
        "export_anim_single_armature": False,  # 3.x: not every action of the file besides
        "export_animation_mode": "NLA_TRACKS",  # 4.x: one clip per NLA track
        "export_force_sampling": True,
        "export_materials": "NONE",
        "export_texcoords": False,
        "export_colors": False,
        "export_extras": False,
        "export_cameras": False,
        "export_lights": False,
    }
    # Options come and go between Blender versions: pass the ones this exporter has.
    known = bpy.ops.export_scene.gltf.get_rna_type().properties.keys()
    with _ExportState(context, armature, meshes, actions):
        bpy.ops.export_scene.gltf(**{k: v for k, v in options.items() if k in known})


class _ExportState:
    """Selects exactly the character and puts each action on a track of its own (muting the others'
    strips) for the exporter; restores everything on exit."""

    def __init__(self, context, armature, meshes, actions):
        self.context, self.armature, self.meshes, self.actions = context, armature, meshes, actions

    def __enter__(self):
        data = self.armature.animation_data or self.armature.animation_data_create()
        if data.use_tweak_mode:
            raise Failure(f"{self.armature.name} is in NLA tweak mode: leave it first")
        view_layer = self.context.view_layer
        # Everything changed below, saved before anything changes: __exit__ restores it all.
        self.selected = [o for o in view_layer.objects if o.select_get()]
        self.active = view_layer.objects.active
        self.action = data.action
        self.muted = [(s, s.mute) for t in data.nla_tracks for s in t.strips] + [(t, t.mute) for t in data.nla_tracks]
        self.frame = self.context.scene.frame_current
        self.basis = [(b, b.matrix_basis.copy()) for b in self.armature.pose.bones]
        self.ranges = [(a, a.use_frame_range, a.frame_start, a.frame_end) for a in self.actions]
        self.tracks = []
        try:
            self._prepare(view_layer, data)
        except BaseException:
            self.__exit__()
            raise
        return self

    def _prepare(self, view_layer, data):
        for obj in self.selected:
            obj.select_set(False)
        for obj in [self.armature, *self.meshes]:
            obj.select_set(True)
        view_layer.objects.active = self.armature
        for strip_or_track, _ in self.muted:
            strip_or_track.mute = True
        data.action = None
        # The exporter writes the bones' current pose into the nodes: make it the rest pose, so that
        # the file does not depend on the frame the scene is at.
        for bone, _ in self.basis:
            bone.matrix_basis = Matrix()
        # Blender 3.4's exporter samples frame int(f) but writes it at time f / fps, f running from the
        # first key: with keys a hair below whole frames (0.9999988, as glTF imports give) every
        # sample lands one frame late. A whole-frame manual range makes f whole.
        for action in self.actions:
            first, last = (round(f) for f in action.frame_range)
            action.use_frame_range = True
            action.frame_start, action.frame_end = first, max(first, last)
        for action in self.actions:
            track = data.nla_tracks.new()
            self.tracks.append(track)
            track.name = action.name  # the clip's name in the file
            track.strips.new(action.name, int(action.frame_range[0]), action)

    def __exit__(self, *_):
        data = self.armature.animation_data
        for track in self.tracks:
            data.nla_tracks.remove(track)
        for strip_or_track, mute in self.muted:
            strip_or_track.mute = mute
        for action, use, start, end in self.ranges:
            action.frame_start, action.frame_end = start, end
            action.use_frame_range = use
        data.action = self.action
        for bone, basis in self.basis:
            bone.matrix_basis = basis
        self.context.scene.frame_set(self.frame)
        for obj in self.context.view_layer.objects:
            obj.select_set(obj in self.selected)
        self.context.view_layer.objects.active = self.active
        return False
