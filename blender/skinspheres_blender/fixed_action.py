"""A fixed clip (a GLB clip skinspheres fix wrote) as a new action on the original armature.

The clip's skinning matrices S_j (world @ inverse bind, glTF space) deform the mesh exactly as the
bones must: in the armature's space a bone's deformation is pose_j @ rest_j^-1 = A^-1 @ S_j @ A with
A = Y_UP @ armature.matrix_world, so pose_j = A^-1 @ S_j @ A @ rest_j whatever the bones' axes, and
each bone's local (basis) transform follows from its parent's pose: basis = rest_j^-1 @ rest_p @
pose_p^-1 @ pose_j (the root: rest_j^-1 @ pose_j). One key per frame, linear.
"""

import bpy
import numpy as np
from mathutils import Matrix

from .character import FIXED, Y_UP
from .gltf_pose import clip_skinning


def create(armature, source, glb_path, clip_name, fps):
    """Makes (or remakes) the action "<source> (fixed)" from the clip of glb_path; returns it. The
    source action is not touched; frames outside its range are dropped."""
    joints, skinning = clip_skinning(glb_path, clip_name, fps)
    bones = armature.data.bones
    names = [n for n in joints if n in bones]
    if not names:
        raise ValueError(f"{glb_path}: none of the clip's joints is a bone of {armature.name}")
    a = np.array(Y_UP @ armature.matrix_world)
    index = {n: joints.index(n) for n in names}
    first, last = (int(round(f)) for f in source.frame_range)
    frames = [f for f in range(first, last + 1) if f < len(skinning)]
    poses = {}
    for name in names:
        rest = np.array(bones[name].matrix_local)
        poses[name] = np.linalg.inv(a) @ skinning[frames, index[name]] @ a @ rest
    action = bpy.data.actions.get(source.name + FIXED)
    if action is not None:
        bpy.data.actions.remove(action)
    action = bpy.data.actions.new(source.name + FIXED)
    action.use_fake_user = True
    for name in names:
        basis = _basis(bones[name], poses)
        _key_bone(action, armature.pose.bones[name], frames, basis)
    return action


def _basis(bone, poses):
    """(F, 4, 4) local transforms of a bone from its and its parent's poses."""
    rest = np.array(bone.matrix_local)
    pose = poses[bone.name]
    parent = bone.parent
    if parent is None:
        return np.linalg.inv(rest) @ pose
    parent_rest = np.array(parent.matrix_local)
    parent_pose = poses.get(parent.name, parent_rest[None])  # a bone the clip does not move stays at rest
    return np.linalg.inv(rest) @ parent_rest @ np.linalg.inv(parent_pose) @ pose


def _key_bone(action, pose_bone, frames, basis):
    locations, rotations, scales = [], [], []
    previous = None
    for m in basis:
        location, rotation, scale = Matrix(m.tolist()).decompose()
        if previous is not None and previous.dot(rotation) < 0:
            rotation.negate()
        previous = rotation
        locations.append(location[:])
        rotations.append(rotation)
        scales.append(scale[:])
    path = f'pose.bones["{pose_bone.name}"]'
    _curves(action, path + ".location", pose_bone.name, frames, locations)
    mode = pose_bone.rotation_mode
    if mode == "QUATERNION":
        _curves(action, path + ".rotation_quaternion", pose_bone.name, frames, [q[:] for q in rotations])
    elif mode == "AXIS_ANGLE":
        values = [(q.to_axis_angle()[1], *q.to_axis_angle()[0]) for q in rotations]
        _curves(action, path + ".rotation_axis_angle", pose_bone.name, frames, values)
    else:
        eulers, last = [], None
        for q in rotations:
            last = q.to_euler(mode, last) if last is not None else q.to_euler(mode)
            eulers.append(last[:])
        _curves(action, path + ".rotation_euler", pose_bone.name, frames, eulers)
    _curves(action, path + ".scale", pose_bone.name, frames, scales)


def _curves(action, data_path, group, frames, values):
    values = np.asarray(values, np.float64)
    for i in range(values.shape[1]):
        curve = action.fcurves.new(data_path, index=i, action_group=group)
        curve.keyframe_points.add(len(frames))
        co = np.empty(2 * len(frames), np.float32)
        co[0::2], co[1::2] = frames, values[:, i]
        curve.keyframe_points.foreach_set("co", co)
        curve.keyframe_points.foreach_set("interpolation", [_LINEAR] * len(frames))
        curve.update()


_LINEAR = bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items["LINEAR"].value
