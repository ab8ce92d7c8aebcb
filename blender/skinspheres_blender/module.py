"""The add-on's preference (where the skinspheres module is) and importing the module from there."""

import importlib
import os
import sys

import bpy

try:  # written by the build into the zip: the build tree's python/ folder
    from ._build import MODULE_DIR as _BUILD_MODULE_DIR
except ImportError:
    _BUILD_MODULE_DIR = ""

_state = {"module": None, "error": None, "dir": None}


def _forget(_self, _context):
    _state.update(module=None, error=None, dir=None)


class Preferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    module_dir: bpy.props.StringProperty(
        name="skinspheres module folder",
        description="The folder holding the skinspheres Python package: the build's python/ folder, or the "
        "install's lib/python3/dist-packages. Empty: Blender's own search path",
        subtype="DIR_PATH",
        default=_BUILD_MODULE_DIR,
        update=_forget,
    )

    def draw(self, _context):
        self.layout.prop(self, "module_dir")
        ss, error = load()
        if ss is None:
            box = self.layout.box()
            for i, line in enumerate(error_lines(error)):
                box.label(text=line, icon="ERROR" if i == 0 else "BLANK1")
        else:
            where = os.path.dirname(ss.__file__)
            self.layout.label(text=f"skinspheres {ss.__version__} from {where}", icon="CHECKMARK")


def preferences():
    addon = bpy.context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


def load():
    """(module, None) or (None, the reason it cannot be imported). The attempt is remembered until
    the preference changes."""
    prefs = preferences()
    folder = bpy.path.abspath(prefs.module_dir) if prefs and prefs.module_dir else ""
    if _state["dir"] == folder and (_state["module"] or _state["error"]):
        return _state["module"], _state["error"]
    _state.update(dir=folder, module=None, error=None)
    if folder and not os.path.isdir(os.path.join(folder, "skinspheres")):
        _state["error"] = f"no skinspheres package in '{folder}'"
        return None, _state["error"]
    if folder and folder not in sys.path:
        sys.path.insert(0, folder)
    try:
        if "skinspheres" in sys.modules and folder:
            loaded = os.path.dirname(os.path.dirname(sys.modules["skinspheres"].__file__))
            if os.path.realpath(loaded) != os.path.realpath(folder):
                raise ImportError(f"skinspheres is already loaded from '{loaded}': restart Blender to switch")
        _state["module"] = importlib.import_module("skinspheres")
    except ImportError as error:  # a missing package, or one built for another Python
        version = f"{sys.version_info.major}.{sys.version_info.minor}"
        _state["error"] = f"cannot import skinspheres ({error}); Blender runs Python {version}"
    return _state["module"], _state["error"]


def error_lines(error):
    """The panel's message when the module cannot be imported."""
    return [
        "skinspheres module not found",
        error,
        "Set its folder in Preferences > Add-ons > skinspheres",
        "(the build's python/ folder, built for this Python)",
    ]
