"""Headless test of the Tyndall Shafts add-on against Debian's Blender:

    blender -b --factory-startup --python-exit-code 1 \
        --python integrations/blender/tests/test_addon.py -- /path/to/tyndall

(scripts/test_blender.sh runs it with a throw-away user scripts folder). Installs and enables
the add-on from a zip as a user would, builds a small scene whose camera moves over frames
1–3, runs "Render shafts" on graphs/plate/colonnade.ron, and checks: Blender's plate and
Tyndall's EXRs exist for each frame with the AOV layers, the camera in Tyndall's EXR header
moves with Blender's, the compositor holds the Image node wired over the Render Layers, and a
missing tyndall binary is a clear error. Then the same shot lit by a spot light instead of the
sun: the exported glTF carries it (KHR_lights_punctual, P / 4π × 683 cd, its cone) and
Tyndall's in-scatter layer shows its cone over the plate. Last, smoke (issue #61): a Volume
object reading the forest plume's cache and a gas domain with an OpenVDB cache are exported
with their files as the custom property `vdb` (the domain tagged `medium`, an Empty at its low
corner naming its cache), nothing of it is left in the .blend afterwards, and Tyndall renders
the smoke from the exported glTF alone (Scene → VdbVolume → SingleScattering)."""

import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import zipfile

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
BINARY = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
TMP = tempfile.mkdtemp(prefix="tyndall_blender_")


def exr_header(path):
    """{attribute: value} of an EXR's header: channel names (`channels`) and the
    `worldToCamera` matrix; other attributes as raw bytes."""
    with open(path, "rb") as f:
        data = f.read(1 << 16)
    assert struct.unpack("<i", data[:4])[0] == 20000630, f"{path} is not an EXR"
    pos, out = 8, {}
    while data[pos] != 0:
        end = data.index(b"\0", pos)
        name = data[pos:end].decode()
        tend = data.index(b"\0", end + 1)
        kind = data[end + 1:tend].decode()
        size = struct.unpack("<i", data[tend + 1:tend + 5])[0]
        value = data[tend + 5:tend + 5 + size]
        pos = tend + 5 + size
        if kind == "chlist":
            names, p = [], 0
            while value[p] != 0:
                e = value.index(b"\0", p)
                names.append(value[p:e].decode())
                p = e + 1 + 16
            out[name] = names
        elif kind == "m44f":
            out[name] = struct.unpack("<16f", value)
        else:
            out[name] = value
    return out


def install_addon():
    archive = os.path.join(TMP, "tyndall_shafts.zip")
    src = os.path.join(REPO, "integrations", "blender", "tyndall_shafts")
    with zipfile.ZipFile(archive, "w") as z:
        for f in sorted(os.listdir(src)):
            if f.endswith((".py", ".toml")):
                z.write(os.path.join(src, f), f"tyndall_shafts/{f}")
    bpy.ops.preferences.addon_install(filepath=archive, overwrite=True)
    bpy.ops.preferences.addon_enable(module="tyndall_shafts")
    assert hasattr(bpy.types.Scene, "tyndall"), "the add-on did not register"
    assert hasattr(bpy.ops.tyndall, "render_shafts")


def build_scene():
    sc = bpy.context.scene
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    bpy.ops.mesh.primitive_plane_add(size=20)
    for i in range(4):
        bpy.ops.mesh.primitive_cube_add(location=(-1.5 + i, 1.0, 1.0), scale=(0.2, 0.2, 1.0))
        bpy.context.active_object["tyndall_tag"] = "occluder"
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    sc.collection.objects.link(cam)
    cam.rotation_euler = (math.radians(85.0), 0.0, 0.0)
    for frame, x in ((1, -1.0), (3, 1.0)):
        cam.location = (x, -7.0, 1.2)
        cam.keyframe_insert("location", frame=frame)
    sc.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sc.collection.objects.link(sun)
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(60.0), 0.0, math.radians(180.0))
    sc.render.engine = "CYCLES"
    sc.cycles.samples = 2
    sc.cycles.use_denoising = False
    sc.render.resolution_x, sc.render.resolution_y = 64, 36
    sc.render.resolution_percentage = 100
    sc.frame_start, sc.frame_end = 1, 3
    sc.render.fps = 24


def check_missing_binary():
    p = bpy.context.preferences.addons["tyndall_shafts"].preferences
    p.binary = "/nonexistent/tyndall"
    try:
        bpy.ops.tyndall.render_shafts()
    except RuntimeError as e:
        assert "Tyndall binary not found at '/nonexistent/tyndall'" in str(e), str(e)
    else:
        raise AssertionError("a missing tyndall binary was not reported")
    p.binary = BINARY


def glb_json(path):
    """The JSON chunk of a binary glTF."""
    with open(path, "rb") as f:
        data = f.read()
    assert data[:4] == b"glTF", f"{path} is not a .glb"
    length, kind = struct.unpack("<I4s", data[12:20])
    assert kind == b"JSON"
    return json.loads(data[20:20 + length])


def lamp_run(sc):
    """The shot lit by a 2000 W spot (cone 60°) 4 m above the cubes, shining straight down."""
    bpy.data.objects.remove(bpy.data.objects["Sun"])
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "SPOT"))
    sc.collection.objects.link(lamp)
    lamp.data.energy = 2000.0
    lamp.data.spot_size = math.radians(60.0)
    lamp.data.spot_blend = 0.1
    lamp.location = (0.0, 3.0, 4.0)
    out = os.path.join(TMP, "lamp")
    sc.tyndall.output_dir = out
    assert bpy.ops.tyndall.render_shafts() == {"FINISHED"}
    lights = glb_json(os.path.join(out, "shot.glb"))["extensions"]["KHR_lights_punctual"]["lights"]
    assert len(lights) == 1 and lights[0]["type"] == "spot", lights
    want = 2000.0 / (4.0 * math.pi) * 683.0
    assert abs(lights[0]["intensity"] / want - 1.0) < 1e-4, (lights[0]["intensity"], want)
    assert abs(lights[0]["spot"]["outerConeAngle"] - math.radians(30.0)) < 1e-4, lights[0]
    # Tyndall's in-scatter layer of frame 2, written alone by `tyndall node`, read by Blender.
    shafts = os.path.join(out, "shafts_0002.exr")
    alone = os.path.join(out, "inscatter_0002.exr")
    subprocess.run([BINARY, "node", "ImageInput", "--param", f"path={shafts}",
                    "--param", "layer=inscatter", "--output", f"image={alone}"], check=True)
    px = bpy.data.images.load(alone).pixels[:]
    lum = [sum(px[i:i + 3]) / 3 for i in range(0, len(px), 4)]
    lit = sum(v > 0.02 * max(lum) for v in lum) / len(lum)
    print(f"lamp: in-scatter max {max(lum):.4g} W/(m²·sr), {lit * 100:.1f} % of pixels lit")
    # The cone (2.3 m wide at the ground) covers part of the view, not all of it, not nothing.
    assert max(lum) > 1e-2, max(lum)
    assert 0.05 < lit < 0.7, lit


SMOKE_GRAPH = """(
    version: 2,
    nodes: {{
        "scene": (kind: "Scene", params: {{"path": "{glb}"}}),
        "shadow": (kind: "ShadowMap", params: {{"resolution": 512}}),
        "gbuffer": (kind: "GBuffer", params: {{"width": 96, "height": 64}}),
        "smoke": (kind: "VdbVolume", params: {{"object": "Plume"}}),
        "scatter": (kind: "SingleScattering", params: {{"sigma_t": 1.0, "bounds": "density", "steps": 64, "transmittance_resolution": 32, "light_steps": 32}}),
        "out": (kind: "ImageOutput", params: {{"path": "{exr}"}}),
    }},
    edges: [
        ("scene.scene", "shadow.scene"),
        ("scene.scene", "gbuffer.scene"),
        ("scene.scene", "scatter.scene"),
        ("scene.scene", "smoke.scene"),
        ("shadow.map", "scatter.shadow"),
        ("gbuffer.depth", "scatter.depth"),
        ("smoke.volume", "scatter.density"),
        ("scatter.inscatter", "out.image"),
    ],
)
"""


def smoke_run(sc):
    """A Volume object and a smoke domain exported with their files; Tyndall renders the
    Volume object's smoke from the glTF alone."""
    import tyndall_shafts
    plume = os.path.join(REPO, "scenes", "smoke", "forest_plume_0090.vdb")
    vol = bpy.data.volumes.new("Plume")
    vol.filepath = plume
    obj = bpy.data.objects.new("Plume", vol)
    sc.collection.objects.link(obj)
    obj.location = (-7.0, -9.0, 0.0)
    bpy.data.objects.remove(bpy.data.objects["Lamp"])  # lamp_run's spot: back to a sun
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sc.collection.objects.link(sun)
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(30.0), 0.0, math.radians(180.0))
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(20.0, 0.0, 1.0))
    domain = bpy.context.active_object
    domain.name = "Domain"
    fluid = domain.modifiers.new("Fluid", "FLUID")
    fluid.fluid_type = "DOMAIN"
    fluid.domain_settings.domain_type = "GAS"
    fluid.domain_settings.cache_data_format = "OPENVDB"
    fluid.domain_settings.cache_directory = os.path.join(TMP, "cache")
    glb = os.path.join(TMP, "smoke.glb")
    tyndall_shafts.export_gltf(glb)
    nodes = {n["name"]: n for n in glb_json(glb)["nodes"]}
    extras = nodes["Plume"].get("extras", {})
    assert extras.get("vdb") == plume, nodes["Plume"]
    # Blender's (−7, −9, 0) is glTF's (−7, 0, 9).
    assert nodes["Plume"]["translation"] == [-7.0, 0.0, 9.0], nodes["Plume"]
    cache = nodes["Domain_cache"]
    assert cache["extras"]["vdb"] == os.path.join(TMP, "cache", "data", "fluid_data_####.vdb"), cache
    assert [round(v, 4) for v in cache["translation"]] == [19.0, 0.0, 1.0], cache  # low corner
    assert "medium" in nodes["Domain"]["extras"]["tyndall_tag"], nodes["Domain"]
    # Nothing of the export is left behind.
    assert "vdb" not in obj and "tyndall_tag" not in domain, (obj.keys(), domain.keys())
    assert "Domain_cache" not in bpy.data.objects
    bpy.data.objects.remove(domain)  # Mantaflow would look for its (empty) cache at exit
    exr = os.path.join(TMP, "smoke_inscatter.exr")
    graph = os.path.join(TMP, "smoke.ron")
    with open(graph, "w") as f:
        f.write(SMOKE_GRAPH.format(glb=glb, exr=os.path.basename(exr)))
    subprocess.run([BINARY, "render", graph, "--set", "smoke.up_axis=z",
                    "--set", "smoke.voxel_centers=blender", "--output-dir", TMP], check=True)
    px = bpy.data.images.load(exr).pixels[:]
    lum = [sum(px[i:i + 3]) / 3 for i in range(0, len(px), 4)]
    lit = sum(v > 0.05 * max(lum) for v in lum) / len(lum)
    print(f"smoke: in-scatter max {max(lum):.4g}, {lit * 100:.1f} % of pixels lit")
    # The plume fills part of the view (the camera looks at the cubes, the smoke beside them).
    assert max(lum) > 0.0 and 0.01 < lit < 0.9, (max(lum), lit)


def main():
    install_addon()
    build_scene()
    sc = bpy.context.scene
    bpy.context.preferences.addons["tyndall_shafts"].preferences.binary = BINARY
    sc.tyndall.preset_path = os.path.join(REPO, "graphs", "plate", "colonnade.ron")
    sc.tyndall.output_dir = os.path.join(TMP, "out")
    check_missing_binary()
    assert bpy.ops.tyndall.render_shafts() == {"FINISHED"}
    out = os.path.join(TMP, "out")
    cams = []
    for f in (1, 2, 3):
        plate = os.path.join(out, "plate", f"plate_{f:04d}.exr")
        shafts = os.path.join(out, f"shafts_{f:04d}.exr")
        assert os.path.isfile(plate), plate
        assert os.path.isfile(shafts), shafts
        h = exr_header(shafts)
        for c in ("R", "G", "B", "A", "inscatter.R", "inscatter.G", "inscatter.B",
                  "transmittance.Y", "visibility.Y", "depth.Z"):
            assert c in h["channels"], f"{shafts}: no channel {c} in {h['channels']}"
        cams.append(h["worldToCamera"])
        print(f"frame {f}: {shafts} layers {sorted(h['channels'])}")
    # The camera moved from x = -1 to x = 1 (Blender) over the three frames: Tyndall's camera
    # (the exported animation) moved with it.
    moved = max(abs(a - b) for a, b in zip(cams[0], cams[2]))
    assert moved > 0.5, f"Tyndall's camera did not follow Blender's: {cams[0]} vs {cams[2]}"
    tree = sc.node_tree
    shafts = tree.nodes["Tyndall shafts"]
    assert shafts.bl_idname == "CompositorNodeImage" and shafts.image.source == "SEQUENCE"
    links = {(l.from_node.name, l.from_socket.name, l.to_node.name, l.to_socket.identifier)
             for l in tree.links}
    rl = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers")
    comp = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeComposite")
    mul, add = tree.nodes["Tyndall transmittance"], tree.nodes["Tyndall inscatter"]
    want = {
        (rl.name, "Image", mul.name, mul.inputs[1].identifier),
        (shafts.name, "transmittance", mul.name, mul.inputs[2].identifier),
        (mul.name, "Image", add.name, add.inputs[1].identifier),
        (shafts.name, "inscatter", add.name, add.inputs[2].identifier),
        (add.name, "Image", comp.name, comp.inputs["Image"].identifier),
    }
    assert want <= links, f"compositor links: missing {want - links}"
    assert mul.blend_type == "MULTIPLY" and add.blend_type == "ADD"
    # Running again reuses the nodes instead of adding more.
    assert bpy.ops.tyndall.render_shafts() == {"FINISHED"}
    assert sum(n.name.startswith("Tyndall") for n in tree.nodes) == 3
    lamp_run(sc)
    smoke_run(sc)
    print("TYNDALL_ADDON_TEST OK")


main()
