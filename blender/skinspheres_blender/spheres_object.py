"""The fitted spheres as one mesh object following the bones: each sphere a small icosphere bound
rigidly to its dominant joint's bone (a vertex group, an Armature modifier), one material per body
part, transparent in the viewport and hidden from renders.

It shows where the spheres sit; the runtime refits them every frame (docs/REFIT.md), so on a bent
limb the true spheres differ a little from these rigid copies.
"""

import colorsys

import bmesh
import bpy
import numpy as np

from .character import Y_UP


def _unit_sphere():
    mesh = bmesh.new()
    bmesh.ops.create_icosphere(mesh, subdivisions=2, radius=1.0)
    verts = np.array([v.co[:] for v in mesh.verts])
    faces = [[v.index for v in f.verts] for f in mesh.faces]
    mesh.free()
    return verts, faces


def part_colour(index):
    """A distinct colour per body part (golden-ratio hues), RGBA."""
    hue = (index * 0.618034) % 1.0
    return (*colorsys.hsv_to_rgb(hue, 0.65, 0.95), 0.35)


def build(armature, sphere_set):
    """Creates (or replaces) the object "<armature> spheres" for a fitted SphereSet whose centres
    are in the exported file's space (glTF, Y-up)."""
    name = f"{armature.name} spheres"
    old = bpy.data.objects.get(name)
    if old is not None:
        old_mesh = old.data
        bpy.data.objects.remove(old)
        if old_mesh.users == 0:
            bpy.data.meshes.remove(old_mesh)
    unit, unit_faces = _unit_sphere()
    to_armature = np.array(armature.matrix_world.inverted() @ Y_UP.inverted())
    centers = np.c_[sphere_set.centers, np.ones(len(sphere_set))] @ to_armature.T
    scale = np.cbrt(abs(np.linalg.det(to_armature[:3, :3])))
    radii = sphere_set.radii * scale
    verts = (centers[:, None, :3] + radii[:, None, None] * unit[None]).reshape(-1, 3)
    per = len(unit)
    faces = [[i * per + v for v in face] for i in range(len(sphere_set)) for face in unit_faces]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts.tolist(), [], faces)
    obj = bpy.data.objects.new(name, mesh)
    for collection in armature.users_collection:
        collection.objects.link(obj)
    obj.parent = armature
    obj.matrix_parent_inverse.identity()
    _bind(obj, sphere_set, per)
    _colour(obj, mesh, sphere_set, len(unit_faces))
    obj.hide_render = True
    obj.hide_select = True
    obj.show_transparent = True
    obj["skinspheres_spheres"] = len(sphere_set)
    return obj


def _bind(obj, sphere_set, per):
    joints = sphere_set.joint_names
    groups = {}
    for s, joint in enumerate(sphere_set.sphere_joint):
        name = joints[int(joint)]
        if name not in groups:
            groups[name] = obj.vertex_groups.new(name=name)
        groups[name].add(list(range(s * per, (s + 1) * per)), 1.0, "REPLACE")
    modifier = obj.modifiers.new("Armature", "ARMATURE")
    modifier.object = obj.parent


def _colour(obj, mesh, sphere_set, faces_per_sphere):
    parts = sphere_set.part_names
    for i, part in enumerate(parts):
        material = bpy.data.materials.get(f"ss part {part}") or bpy.data.materials.new(f"ss part {part}")
        material.diffuse_color = part_colour(i)
        material.blend_method = "BLEND"
        mesh.materials.append(material)
    indices = np.repeat(np.asarray(sphere_set.sphere_part, np.int32), faces_per_sphere)
    mesh.polygons.foreach_set("material_index", indices)
    mesh.update()
