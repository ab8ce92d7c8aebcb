"""Background Blender: keeps the left part of a screenshot, scales it to a width and writes an
8-bit RGB PNG with 64 levels a channel (a picture for the docs, under 200 KB).

    blender -b --factory-startup --python shrink.py -- IN.png OUT.png WIDTH KEEP_SHARE
"""

import sys

import bpy
import numpy as np

source, target, width, keep = sys.argv[sys.argv.index("--") + 1 :]
width, keep = int(width), float(keep)
image = bpy.data.images.load(source)
w, h = image.size
pixels = np.empty(w * h * 4, np.float32)
image.pixels.foreach_get(pixels)
kept = int(w * keep)
out = bpy.data.images.new("shrunk", kept, h)
out.pixels.foreach_set(pixels.reshape(h, w, 4)[:, :kept].ravel())
out.scale(width, int(h * width / kept))
scaled = np.empty(len(out.pixels), np.float32)
out.pixels.foreach_get(scaled)
out.pixels.foreach_set(np.round(scaled * 63) / 63)
settings = bpy.context.scene.render.image_settings
settings.file_format, settings.color_mode, settings.color_depth, settings.compression = "PNG", "RGB", "8", 100
out.save_render(target, scene=bpy.context.scene)
