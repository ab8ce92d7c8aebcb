"""skinspheres for Blender: fit the sphere set of the active armature's character, check its actions
for self-penetration (timeline markers, a list of part pairs, the JSON report), fix them into new
actions and fit colliders (objects on the bones, or files for engines). A sidebar panel in the 3D
view (N, tab "skinspheres"); docs/BLENDER.md is the guide.

The work is done by the `skinspheres` Python module (the project's pybind11 module), found through
this add-on's preference (the build's or the install's python/ folder).
"""

bl_info = {
    "name": "skinspheres",
    "author": "skinspheres",
    "version": (0, 5, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > skinspheres",
    "description": "Sphere sets, self-penetration checks, fixes and colliders for skinned characters",
    "doc_url": "https://github.com/skinspheres/skinspheres/blob/main/docs/BLENDER.md",
    "category": "Animation",
}

if "bpy" in locals():  # reloading the add-on (F3 > Reload Scripts): reload the submodules too
    import importlib

    _submodules = ("module", "gltf_pose", "character", "jobs", "spheres_object", "colliders", "results", "fixed_action",
                   "operators", "panel")
    for _name in _submodules:
        if _name in locals():
            importlib.reload(locals()[_name])

import bpy  # noqa: E402

from . import module, operators, panel, results  # noqa: E402

_classes = (
    module.Preferences,
    *results.classes,
    *operators.classes,
    *panel.classes,
)


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.skinspheres = bpy.props.PointerProperty(type=results.SceneState)


def unregister():
    del bpy.types.Scene.skinspheres
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
