"""What the panel shows and keeps in the .blend: the settings, the part pairs Check found and Fix's
verdicts (scene.skinspheres), and the markers.

Markers: Check puts one pose marker per penetrating frame on each action it checked (shown in the
Action Editor), and copies the active action's onto the scene's timeline. A marker is named for the
deepest part pair of its frame and its depth as a share of the body height: "ss torso-arm_r 2.3%".
Markers named "ss ..." are the add-on's; it replaces them and leaves every other marker alone.
"""

import bpy

PREFIX = "ss "


def _jump(self, context):
    """Clicking a part pair: its action becomes the armature's active one, the scene goes to the
    pair's deepest frame and the timeline shows that action's markers."""
    if not 0 <= self.pair_index < len(self.pairs):
        return
    pair = self.pairs[self.pair_index]
    if pair.clip_file:  # a clip from a file: no action to show, only its frame
        context.scene.frame_set(pair.worst_frame)
        return
    armature = bpy.data.objects.get(self.armature)
    action = bpy.data.actions.get(pair.action)
    if armature is not None and action is not None and armature.animation_data is not None:
        if armature.animation_data.action != action and not armature.animation_data.use_tweak_mode:
            armature.animation_data.action = action
        show_action_markers(context.scene, action)
    context.scene.frame_set(pair.worst_frame)


class PartPair(bpy.types.PropertyGroup):
    action: bpy.props.StringProperty(description="The action, or the clip's name for a clip from a file")
    clip_file: bpy.props.StringProperty(description="The file of a clip Check read from a file (no action)")
    part_a: bpy.props.StringProperty()
    part_b: bpy.props.StringProperty()
    first_frame: bpy.props.IntProperty()
    last_frame: bpy.props.IntProperty()
    worst_frame: bpy.props.IntProperty()
    frames: bpy.props.IntProperty(description="Frames where the pair penetrates")
    depth_share: bpy.props.FloatProperty(description="Deepest penetration, a share of the body height")


class ClipFile(bpy.types.PropertyGroup):
    path: bpy.props.StringProperty(name="File", subtype="FILE_PATH", description="A glTF/FBX/BVH file of clips")


class FixedClip(bpy.types.PropertyGroup):
    action: bpy.props.StringProperty()
    verdict: bpy.props.StringProperty()
    summary: bpy.props.StringProperty()


class SceneState(bpy.types.PropertyGroup):
    scope: bpy.props.EnumProperty(
        name="Actions",
        items=[("ACTIVE", "Active action", "The armature's active action"),
               ("ALL", "Every action", "Every action that animates the armature's bones"),
               ("NONE", "No action", "Only the clip files")],
        default="ACTIVE",
    )
    max_depth: bpy.props.FloatProperty(
        name="Max depth %", default=1.0, min=0.0, max=100.0, precision=2,
        description="Check: a clip fails where a part pair penetrates deeper than this share of the body height",
    )
    fix_depth: bpy.props.FloatProperty(
        name="Fix to %", default=0.5, min=0.0, max=100.0, precision=2,
        description="Fix: no part pair may penetrate deeper than this share of the body height afterwards",
    )
    mode: bpy.props.EnumProperty(
        name="Mode", items=[("exact", "Exact", "Triangles at their skinned positions"),
                            ("fast", "Fast", "The fast sphere refit")], default="exact",
    )
    output_dir: bpy.props.StringProperty(
        name="Output", subtype="DIR_PATH",
        description="Where Fit saves the sphere set (<armature>.ssb) and Check and Fix their reports "
        "(<armature>_check.json, <armature>_fix.json). Empty: beside the .blend, or a temporary folder",
    )
    keep_glb: bpy.props.BoolProperty(
        name="Keep the exported GLB",
        description="Check also writes the character as it handed it to skinspheres (<armature>_checked.glb), "
        "so that the command-line tool can check the same file",
    )
    clip_files: bpy.props.CollectionProperty(type=ClipFile)
    clip_file_index: bpy.props.IntProperty(default=-1)
    joint_map: bpy.props.StringProperty(
        name="Joint map", subtype="FILE_PATH",
        description="Clip files: a JSON map from the files' joint names to the character's (--joint-map)",
    )
    source_rest: bpy.props.StringProperty(
        name="Source rest",
        description="Clip files without a skin: their rest pose, RIG (a file), FRAME, nodes or identity "
        "(--source-rest)",
    )
    retarget: bpy.props.EnumProperty(
        name="Retarget", default="auto",
        items=[("auto", "Auto", "Copy the rotations when the rigs match, else transfer them in world space"),
               ("copy", "Copy", "Copy the local rotations"),
               ("world", "World", "Transfer the rotations in world space relative to each rig's rest pose")],
    )
    collider_budget: bpy.props.IntProperty(
        name="Budget", default=32, min=1, max=256, description="Colliders: the number of shapes (--budget)"
    )
    collider_shapes: bpy.props.EnumProperty(
        name="Shapes", default="auto",
        items=[("auto", "Auto", "What the format holds (capsules and spheres for the add-on's objects)"),
               ("spheres", "Spheres", "Spheres only"), ("capsules", "Capsules", "Capsules only"),
               ("both", "Both", "Spheres and capsules")],
    )
    collider_fps: bpy.props.FloatProperty(
        name="Poses per second", default=10.0, min=0.1, max=240.0,
        description="Colliders: the clips' frames fitted and measured, sampled at this rate (--fps)",
    )
    colliders_report: bpy.props.StringProperty()
    colliders_export: bpy.props.StringProperty()
    armature: bpy.props.StringProperty(description="The armature the results are for")
    pairs: bpy.props.CollectionProperty(type=PartPair)
    pair_index: bpy.props.IntProperty(default=-1, update=_jump)
    fixed: bpy.props.CollectionProperty(type=FixedClip)
    check_report: bpy.props.StringProperty()
    fix_report: bpy.props.StringProperty()
    status: bpy.props.StringProperty()
    progress: bpy.props.FloatProperty(min=0.0, max=1.0)


def mark_action(action, markers):
    """Replaces the add-on's pose markers of an action with markers [(frame, name)]."""
    for old in [m for m in action.pose_markers if m.name.startswith(PREFIX)]:
        action.pose_markers.remove(old)
    for frame, name in markers:
        action.pose_markers.new(name).frame = frame


def show_action_markers(scene, action):
    """The scene's timeline gets the add-on's markers of the action (its others are kept)."""
    for old in [m for m in scene.timeline_markers if m.name.startswith(PREFIX)]:
        scene.timeline_markers.remove(old)
    if action is None:
        return
    for marker in action.pose_markers:
        if marker.name.startswith(PREFIX):
            scene.timeline_markers.new(marker.name, frame=marker.frame)


classes = (PartPair, ClipFile, FixedClip, SceneState)
