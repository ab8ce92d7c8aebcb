"""Blender's UI (under Xvfb, with --enable-event-simulate): screenshots scene.py's .blend with the
add-on's tab open in the 3D view's sidebar and the markers on a taller timeline.

    blender --enable-event-simulate SCENE.blend --python shoot.py -- OUT.png
"""

import sys

import bpy

OUT = sys.argv[sys.argv.index("--") + 1]
TABS_BEFORE = 3  # the sidebar's tabs before the add-on's: Item, Tool, View


def window_area(kind):
    window = bpy.context.window_manager.windows[0]
    return window, next(a for a in window.screen.areas if a.type == kind)


def region_of(area, kind):
    return next(r for r in area.regions if r.type == kind)


def arrange():
    window, view = window_area("VIEW_3D")
    for obj in bpy.context.view_layer.objects:  # frame the character's meshes, then select the armature
        obj.select_set(obj.type == "MESH" and "skinspheres_spheres" not in obj)
    view.spaces.active.show_region_ui = True
    view.spaces.active.shading.type = "SOLID"
    with bpy.context.temp_override(window=window, area=view, region=region_of(view, "WINDOW")):
        bpy.ops.view3d.view_axis(type="FRONT")
        bpy.ops.view3d.view_selected()
    armature = next(o for o in bpy.context.view_layer.objects if o.type == "ARMATURE")
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj == armature)
    bpy.context.view_layer.objects.active = armature
    armature.data.display_type = "STICK"
    window, timeline = window_area("DOPESHEET_EDITOR")
    with bpy.context.temp_override(window=window, area=timeline):
        bpy.ops.screen.area_move(x=timeline.x + timeline.width // 2, y=timeline.y + timeline.height, delta=90)
    with bpy.context.temp_override(window=window, area=timeline, region=region_of(timeline, "WINDOW")):
        bpy.ops.action.view_all()
    bpy.app.timers.register(open_tab, first_interval=1.0)


def open_tab():
    """Blender 3.4 has no API for the sidebar's active tab: Ctrl+wheel over its tab strip cycles it."""
    window, view = window_area("VIEW_3D")
    sidebar = region_of(view, "UI")
    x, y = sidebar.x + sidebar.width - 8, sidebar.y + sidebar.height - 60  # the tabs, not a field
    window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    for _ in range(TABS_BEFORE):
        window.event_simulate(type="WHEELDOWNMOUSE", value="PRESS", x=x, y=y, ctrl=True)
    bpy.app.timers.register(shoot, first_interval=2.0)


def shoot():
    window, _ = window_area("VIEW_3D")
    with bpy.context.temp_override(window=window):
        bpy.ops.screen.screenshot(filepath=OUT)
    bpy.ops.wm.quit_blender()


bpy.app.timers.register(arrange, first_interval=1.0)
