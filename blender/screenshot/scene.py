"""Background Blender: the scene docs/images/blender_panel.png shows. Installs the add-on, imports
the built-in character, fits it, fixes every action, checks every action with the touch clip
active and selects the deepest pair; saves the .blend.

    blender -b --factory-startup --python scene.py -- ADDON.zip BUILTIN.glb OUT_DIR SCENE.blend
"""

import sys

import numpy

if "bool" not in numpy.__dict__:  # Blender 3.4's glTF importer calls np.bool (gone in numpy 1.24)
    numpy.bool = bool

import bpy  # noqa: E402

zip_path, character, out_dir, blend = sys.argv[sys.argv.index("--") + 1 :]
bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True)
bpy.ops.preferences.addon_enable(module="skinspheres_blender")
bpy.ops.wm.save_userpref()  # the UI run that follows loads the add-on from the preferences
for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj)
bpy.ops.import_scene.gltf(filepath=character)
armature = next(o for o in bpy.data.objects if o.type == "ARMATURE")
bpy.context.view_layer.objects.active = armature
state = bpy.context.scene.skinspheres
state.output_dir, state.scope = out_dir, "ALL"
assert bpy.ops.skinspheres.fit() == {"FINISHED"}, state.status
assert bpy.ops.skinspheres.fix() == {"FINISHED"}, state.status
armature.animation_data.action = bpy.data.actions["touch_skin"]
assert bpy.ops.skinspheres.check() == {"FINISHED"}, state.status
state.pair_index = 0  # the deepest pair: its action and frame
bpy.context.scene.frame_start, bpy.context.scene.frame_end = 0, 96
bpy.ops.wm.save_as_mainfile(filepath=blend)
