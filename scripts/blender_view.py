"""Save an EXR through one of Blender's view transforms, "as render" (issue #45, item 6).

    blender -b --factory-startup --python scripts/blender_view.py -- IN.exr OUT.png VIEW [LOOK]

The image is read as Blender's scene-linear ("Linear"), shown on the `sRGB` display through
VIEW (e.g. Filmic, Standard) with LOOK (default: None), exposure 0, gamma 1, and saved as a
16-bit RGB PNG with the view applied (`Image.save_render`, what File > Save As > "Save as
Render" does). Prints `OCIO_CONFIG <path>`: the config Blender read, for the caller to give
Tyndall.
"""
import os
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
src, dst, view = argv[0], argv[1], argv[2]
look = argv[3] if len(argv) > 3 else "None"

img = bpy.data.images.load(src)
img.colorspace_settings.name = "Linear"
scene = bpy.context.scene
scene.display_settings.display_device = "sRGB"
scene.view_settings.view_transform = view
scene.view_settings.look = look
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
scene.view_settings.use_curve_mapping = False
settings = scene.render.image_settings
settings.file_format = "PNG"
settings.color_mode = "RGB"
settings.color_depth = "16"
img.save_render(dst, scene=scene)
config = os.path.join(bpy.utils.system_resource("DATAFILES"), "colormanagement", "config.ocio")
print("OCIO_CONFIG", config)
