"""The README's picture of a Blender scene before and after "Render shafts":

    blender -b --factory-startup --python scripts/blender_before_after.py -- TYNDALL OUT_DIR

builds the colonnade shot of scripts/make_plate.py (crate included), installs the add-on from
integrations/blender, runs "Render shafts" with graphs/plate/colonnade.ron at 640 × 360, then
renders the scene twice through Blender's compositor: without the Tyndall nodes
(OUT_DIR/before.png) and with them (OUT_DIR/after.png). scripts/readme_blender.sh puts the
two side by side in docs/plate/blender_before_after.png."""

import os
import sys
import tempfile
import zipfile

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
binary, out = os.path.abspath(args[0]), os.path.abspath(args[1])
repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
tmp = tempfile.mkdtemp(prefix="tyndall_readme_")

# The shot, as make_plate.py builds it (it also writes its glTF and plate into tmp).
make_plate = os.path.join(repo, "scripts", "make_plate.py")
sys.argv = [sys.argv[0], "--", tmp]
exec(compile(open(make_plate).read(), make_plate, "exec"), {"__name__": "__main__"})

archive = os.path.join(tmp, "tyndall_shafts.zip")
src = os.path.join(repo, "integrations", "blender", "tyndall_shafts")
with zipfile.ZipFile(archive, "w") as z:
    for f in os.listdir(src):
        if f.endswith((".py", ".toml")):
            z.write(os.path.join(src, f), f"tyndall_shafts/{f}")
bpy.ops.preferences.addon_install(filepath=archive, overwrite=True)
bpy.ops.preferences.addon_enable(module="tyndall_shafts")

sc = bpy.context.scene
sc.render.resolution_x, sc.render.resolution_y = 640, 360
bpy.context.preferences.addons["tyndall_shafts"].preferences.binary = binary
sc.tyndall.preset_path = os.path.join(repo, "graphs", "plate", "colonnade.ron")
sc.tyndall.output_dir = os.path.join(tmp, "shafts")
assert bpy.ops.tyndall.render_shafts() == {"FINISHED"}

s = sc.render.image_settings
s.file_format, s.color_depth, s.color_mode = "PNG", "8", "RGB"
sc.view_settings.view_transform = "Filmic"
sc.render.use_compositing = True
os.makedirs(out, exist_ok=True)
sc.render.filepath = os.path.join(out, "after.png")
bpy.ops.render.render(write_still=True)
# Before: the same compositor without the Tyndall nodes.
tree = sc.node_tree
rl = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers")
comp = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeComposite")
tree.links.new(rl.outputs["Image"], comp.inputs["Image"])
sc.render.filepath = os.path.join(out, "before.png")
bpy.ops.render.render(write_still=True)
