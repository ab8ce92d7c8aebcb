"""Colliders as Blender objects: one mesh object per shape `skinspheres.colliders` fitted (a UV
sphere, or a capsule: two balls and the cone between them, tapered when the radii differ), parented
to its joint's bone so that it follows the animation, in the collection "skinspheres colliders",
hidden from renders and semi-transparent, coloured by its coverage over the fitted poses.

A shape is given in its joint's rigid frame at rest (the joint's glTF world matrix with the scale
divided out of each column). Its object's origin is the shape's head, its local +Z the axis to the
tail; at rest its world matrix is Y_UP^-1 @ rigid @ T(head) @ R(Z -> axis).
"""

import math

import bpy
import numpy as np
from mathutils import Matrix, Vector

from .character import Y_UP

COLLECTION = "skinspheres colliders"
_SEGMENTS = 16  # around the axis
_RINGS = 8  # per half ball
# The viewer's colours: green when a shape covers all its vertices over the poses, amber from 97%.
_COVERAGE = ((1.0, "covered", (0.2, 0.8, 0.3, 0.4)), (0.97, "97%", (0.95, 0.65, 0.1, 0.4)),
             (-1.0, "under 97%", (0.9, 0.15, 0.1, 0.4)))


def rigid_frames(rest_world):
    """(J, 4, 4) the joints' rigid frames at rest: each column of the rotation part unit length."""
    rigid = np.array(rest_world, np.float64)
    rigid[:, :3, :3] /= np.linalg.norm(rigid[:, :3, :3], axis=1, keepdims=True)
    return rigid


def profile(r0, r1, length, rings=_RINGS):
    """The outline of a round cone along +Z from a ball of radius r0 at 0 to one of r1 at `length`:
    [(rho, z)] from the bottom pole to the top one, every point on its surface."""
    if length <= 1e-12 or abs(r0 - r1) >= length:  # one ball holds the other: a sphere
        r0 = r1 = max(r0, r1)
        length = 0.0
    beta = math.asin((r0 - r1) / length) if length > 0 else 0.0  # the cone's normal tilt
    points = []
    for i in range(rings + 1):  # the head's ball, from its pole to the tangent circle
        a = -math.pi / 2 + (beta + math.pi / 2) * i / rings
        points.append((r0 * math.cos(a), r0 * math.sin(a)))
    for i in range(0 if length > 0 else 1, rings + 1):  # the tail's, from the tangent circle up
        a = beta + (math.pi / 2 - beta) * i / rings
        points.append((r1 * math.cos(a), length + r1 * math.sin(a)))
    return points


def revolve(points, segments=_SEGMENTS):
    """A closed mesh (vertices, faces) revolving [(rho, z)] (poles at both ends) around Z."""
    verts = [(0.0, 0.0, points[0][1])]
    for rho, z in points[1:-1]:
        for s in range(segments):
            t = 2 * math.pi * s / segments
            verts.append((rho * math.cos(t), rho * math.sin(t), z))
    verts.append((0.0, 0.0, points[-1][1]))
    rings, top = len(points) - 2, len(verts) - 1
    faces = [(0, 1 + (s + 1) % segments, 1 + s) for s in range(segments)]
    for r in range(rings - 1):
        a, b = 1 + r * segments, 1 + (r + 1) * segments
        faces += [(a + s, a + (s + 1) % segments, b + (s + 1) % segments, b + s) for s in range(segments)]
    last = 1 + (rings - 1) * segments
    faces += [(last + s, last + (s + 1) % segments, top) for s in range(segments)]
    return verts, faces


def _axis_frame(direction):
    """A rotation taking +Z to `direction` (unit), 4x4."""
    return Vector((0, 0, 1)).rotation_difference(Vector(direction)).to_matrix().to_4x4()


def placements(result):
    """Per shape: (joint name, its glTF rest world matrix (rigid frame @ T(head) @ R(Z -> axis)),
    head radius, tail radius, axis length), from `skinspheres.colliders`' arrays."""
    rigid = rigid_frames(result["joint_rest_world"])
    names = result["joint_names"]
    out = []
    for k, joint in enumerate(result["joint"]):
        head = np.asarray(result["head"][k], np.float64)
        tail = np.asarray(result["tail"][k], np.float64)
        axis = tail - head
        length = float(np.linalg.norm(axis))
        local = Matrix.Translation(Vector(head)) @ (_axis_frame(axis / length) if length > 1e-12 else Matrix())
        world = Matrix(rigid[int(joint)].tolist()) @ local
        out.append((names[int(joint)], world, float(result["head_radius"][k]), float(result["tail_radius"][k]), length))
    return out


def _material(covered):
    for floor, name, colour in _COVERAGE:
        if covered >= floor:
            material = bpy.data.materials.get(f"ss collider {name}") or bpy.data.materials.new(f"ss collider {name}")
            material.diffuse_color = colour
            material.blend_method = "BLEND"
            return material, colour


def _collection(scene):
    collection = bpy.data.collections.get(COLLECTION)
    if collection is None:
        collection = bpy.data.collections.new(COLLECTION)
    if collection.name not in scene.collection.children:
        scene.collection.children.link(collection)
    return collection


def remove(armature):
    """Deletes the collider objects made for this armature."""
    for obj in [o for o in bpy.data.objects if o.get("skinspheres_collider_of") == armature.name]:
        mesh = obj.data
        bpy.data.objects.remove(obj)
        if mesh is not None and mesh.users == 0:
            bpy.data.meshes.remove(mesh)


def build(context, armature, result):
    """Creates (replacing the armature's earlier ones) one object per shape of a colliders() result
    computed on the armature as exported (glTF, Y-up); returns the objects."""
    remove(armature)
    collection = _collection(context.scene)
    to_blender = Y_UP.inverted()
    shapes = result["colliders"]
    objects = []
    for k, (joint, world, r0, r1, length) in enumerate(placements(result)):
        name = f"{armature.name} collider {k:02d} {joint}"
        verts, faces = revolve(profile(r0, r1, length))
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(verts, [], faces)
        for polygon in mesh.polygons:
            polygon.use_smooth = True
        obj = bpy.data.objects.new(name, mesh)
        collection.objects.link(obj)
        material, colour = _material(shapes[k]["covered"])
        mesh.materials.append(material)
        obj.color = colour
        _parent(obj, armature, joint, to_blender @ world)
        obj.hide_render = True
        obj.show_transparent = True
        obj.show_wire = True
        obj["skinspheres_collider_of"] = armature.name
        obj["skinspheres_collider"] = k
        obj["joint"], obj["part"], obj["type"] = joint, shapes[k]["part"], shapes[k]["type"]
        obj["radius"], obj["tail_radius"], obj["length"] = r0, r1, length
        obj["covered"] = shapes[k]["covered"]
        objects.append(obj)
    return objects


def _parent(obj, armature, joint, world):
    """Parents obj to the joint's bone (or to the armature when no bone has its name) so that at the
    rest pose its world matrix is `world`, and it moves with the bone."""
    obj.parent = armature
    obj.matrix_parent_inverse = Matrix()
    bone = armature.data.bones.get(joint)
    if bone is None:
        obj.matrix_basis = armature.matrix_world.inverted() @ world
        return
    obj.parent_type = "BONE"
    obj.parent_bone = bone.name
    # A bone's child hangs from the bone's tail: the parent matrix at rest.
    parent = armature.matrix_world @ bone.matrix_local @ Matrix.Translation((0, bone.length, 0))
    obj.matrix_basis = parent.inverted() @ world
