"""Tyndall's physical mode against a path tracer: Blender's Cycles, single scattering only.

Run (Debian: apt-get install blender), from the repository root, after `cargo build --release`:

    blender -b --factory-startup --python scripts/cycles_compare.py [-- --scene S --samples N --out DIR]

`--scene` picks the light (default `sun`):

- `sun`: ground, a wall with a vertical slit, a sun behind the wall, and a box of homogeneous fog
  (Volume Scatter: density σ = σt, albedo 1, anisotropy g) on the camera's side;
- `spot`: a spot light (hard cone: blend 0, radius 0) above a grille of bars over a fog box;
- `point`: a point light (radius 0) in a cage of vertical bars with a solid floor, above a fog box;
- `spot_soft`: `spot` with a light of radius 0.2 m (soft shadows), which Tyndall renders through
  `SoftVisibility` (`light_radius` 0.2, 256² × 256 slices: 64 MiB, within GL's 128 MiB storage
  buffers);
- `roof`: a roof with openings over deep fog (16 m below it, σ = 0.1 /m) and no floor: the barn
  loft's shafts, where the fog reaches far past the only occluder (issue #60);
- `spot_deep`: `spot`'s grille with the fog reaching 12 m below it and no floor;
- `point_inside`: a point light inside the fog box, in a cage of bars, no floor;
- `smoke`: a Mantaflow smoke cache (scenes/smoke/forest_plume_0090.vdb, made by
  scripts/scenes/smoke.py) imported as a Volume object, Volume Scatter whose density is
  SMOKE_SIGMA × the `density` grid, under a roof with openings in a steep sun (issue #61): the
  smoke shadows itself. Tyndall reads the same file with `VdbVolume` (`up_axis` z,
  `voxel_centers` blender, `translate` = the object's location in Y-up) into `SingleScattering`'s
  `density` (`bounds = density`).

For each it
renders Cycles' Volume Direct pass with volume bounces 0 (single scattering of the light, shadowed,
attenuated on the way in and on the way out, which is Tyndall's `bounds = tagged`,
`light_extinction = on`), exports the same scene as glTF (the fog box tagged `medium`, the sun's
W/m² written as lux × 683, a lamp's P watts as P / 4π × 683 cd by Blender's exporter), renders it with `target/release/tyndall`, and prints the correlation
and the mean relative error over the pixels whose Cycles in-scatter is above 10 % of its maximum.

`TYNDALL=path/to/tyndall` renders with another binary (e.g. `target/debug/tyndall`; the result is
the same).

Default output is tests/fixtures/cycles/ (`cycles_spot/`, `cycles_point/` for the lamps): `scene.gltf`, `cycles_volume_direct.exr` (what the test
`tests/light/cycles.rs` compares against, so CI needs no Blender) and `compare.ron` (the Tyndall graph).
"""
import math
import os
import subprocess
import sys

import bpy

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))

# The scene's physical values (the test reads the same ones from compare.ron).
SIGMA = 0.25        # 1/m, Volume Scatter density = σt (albedo 1)
G = 0.5             # Henyey–Greenstein anisotropy
SUN_W_M2 = 5.0      # sun irradiance, W/m²
LAMP_W = 600.0      # spot and point light power, W (Blender's Standard units: P / 4π W/sr)
SOFT_RADIUS = 0.2   # the soft spot's radius, m
DEEP_SIGMA = 0.1    # 1/m, the deep fogs of `roof` and `spot_deep` (light crosses 16 m of it)
SMOKE_SIGMA = 1.5   # 1/m per unit of the smoke's density grid (its values reach ~1)
SMOKE_VDB = os.path.join(ROOT, "scenes", "smoke", "forest_plume_0090.vdb")
SMOKE_AT = (-7.0, -9.0, 0.0)  # the Volume object's location: the cache's index 0 at the domain's corner
WIDTH, HEIGHT = 160, 90
FOG_MIN = (-4.0, -6.0, 0.0)   # Blender coordinates (z up)
FOG_MAX = (4.0, -0.2, 4.0)


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    samples, out, which = 2048, None, "sun"
    for i, a in enumerate(argv):
        if a == "--samples":
            samples = int(argv[i + 1])
        if a == "--out":
            out = os.path.abspath(argv[i + 1])
        if a == "--scene":
            which = argv[i + 1]
    if which not in SCENES:
        sys.exit(f"--scene {which}: expected one of {', '.join(SCENES)}")
    if out is None:
        name = "cycles" if which == "sun" else f"cycles_{which}"
        out = os.path.join(ROOT, "tests", "fixtures", name)
    return samples, out, which


def box(name, lo, hi):
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    o = bpy.context.active_object
    o.name = name
    o.location = [(a + b) / 2 for a, b in zip(lo, hi)]
    o.scale = [(b - a) / 2 for a, b in zip(lo, hi)]
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    return o


def material(name, colour=None, volume=False, sigma=SIGMA):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    out = nodes["Material Output"]
    bsdf = nodes.get("Principled BSDF")
    if volume:
        nodes.remove(bsdf)
        scatter = nodes.new("ShaderNodeVolumeScatter")
        scatter.inputs["Density"].default_value = sigma
        scatter.inputs["Anisotropy"].default_value = G
        scatter.inputs["Color"].default_value = (1, 1, 1, 1)
        links.new(scatter.outputs["Volume"], out.inputs["Volume"])
    else:
        bsdf.inputs["Base Color"].default_value = colour
        bsdf.inputs["Roughness"].default_value = 1.0
    return m


def start(ground=True):
    """An empty scene with a black world and (unless `ground` is false) a ground plane."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    if ground:
        g = box("ground", (-10, -12, -0.1), (10, 8, 0.0))
        g.data.materials.append(material("ground", (0.6, 0.58, 0.55, 1)))
        g["tags"] = ["ground"]
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    return scene


def fog(lo, hi, sigma=SIGMA):
    f = box("fog", lo, hi)
    f.data.materials.append(material("fog", volume=True, sigma=sigma))
    f["tags"] = ["medium"]


def camera(scene, location, target):
    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens_unit = "FOV"
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = math.radians(40)
    cam_data.clip_start, cam_data.clip_end = 0.1, 60.0
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = location
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = look(tuple(t - c for t, c in zip(target, cam.location)))
    scene.camera = cam


def occluders(boxes):
    m = material("occluder", (0.3, 0.3, 0.32, 1))
    for i, (lo, hi) in enumerate(boxes):
        o = box(f"occluder_{i}", lo, hi)
        o.data.materials.append(m)
        o["tags"] = ["occluder"]


def sun_light(scene, travel):
    """A sun of SUN_W_M2 whose light travels along `travel`."""
    sun_data = bpy.data.lights.new("sun", type="SUN")
    sun_data.energy = SUN_W_M2
    sun_data.angle = 0.0
    sun = bpy.data.objects.new("sun", sun_data)
    scene.collection.objects.link(sun)
    sun.rotation_mode = "QUATERNION"
    sun.rotation_quaternion = look(travel)


def build_sun():
    scene = start()
    wall = material("wall", (0.7, 0.4, 0.3, 1))
    for name, lo, hi in (("wall_left", (-7, -0.1, 0), (-0.35, 0.1, 9.0)),
                         ("wall_right", (0.35, -0.1, 0), (7, 0.1, 9.0))):
        w = box(name, lo, hi)
        w.data.materials.append(wall)
        w["tags"] = ["wall", "occluder"]
    fog(FOG_MIN, FOG_MAX)

    # The light travels towards −y (through the slit to the camera's side), down and a little −x.
    sun_light(scene, (-0.25, -1.0, -0.45))
    camera(scene, (6.0, -13.0, 2.2), (0.0, -1.0, 2.0))
    return scene


def lamp(scene, kind, location, travel=None, radius=0.0):
    data = bpy.data.lights.new(kind, type=kind.upper())
    data.energy = LAMP_W
    data.shadow_soft_size = radius
    if kind == "spot":
        data.spot_size = math.radians(70)
        data.spot_blend = 0.0
        # Cycles (3.4, measured: a spot over a plane against a point light, ratio = cos θ to
        # 4 digits out to 71°) multiplies a spot's intensity by cos θ, θ from its axis; glTF's
        # spot (and Blender's exporter, which writes P / 4π × 683 cd regardless) has no such
        # factor. The light's strength 1 / cos θ (Texture Coordinate's Normal is the direction
        # in the light's frame, z = −cos θ) makes Cycles render glTF's spot. The exporter finds
        # no Light Falloff node behind the strength and writes the lamp's power as usual.
        data.use_nodes = True
        nt = data.node_tree
        coord = nt.nodes.new("ShaderNodeTexCoord")
        xyz = nt.nodes.new("ShaderNodeSeparateXYZ")
        nt.links.new(coord.outputs["Normal"], xyz.inputs[0])
        inv = nt.nodes.new("ShaderNodeMath")
        inv.operation = "DIVIDE"
        inv.inputs[0].default_value = -1.0
        nt.links.new(xyz.outputs["Z"], inv.inputs[1])
        nt.links.new(inv.outputs[0], nt.nodes["Emission"].inputs["Strength"])
    o = bpy.data.objects.new(kind, data)
    scene.collection.objects.link(o)
    o.location = location
    if travel is not None:
        o.rotation_mode = "QUATERNION"
        o.rotation_quaternion = look(travel)


GRILLE = [((x, -1.6, 4.5), (x + 0.35, 1.6, 4.6)) for x in (-1.55, -0.75, 0.05, 0.85)]
GRILLE += [((-1.6, y, 4.6), (1.6, y + 0.3, 4.7)) for y in (-0.9, 0.5)]


def build_spot(radius=0.0):
    """A spot 2 m above a fog box, shining down through a grille of bars and two cross bars."""
    scene = start()
    fog((-4, -4, 0), (4, 4, 4))
    occluders(GRILLE)
    lamp(scene, "spot", (0.0, 0.0, 6.0), travel=(0.1, 0.05, -1.0), radius=radius)
    # Looking along the bars, whose shadows are sheets seen edge-on.
    camera(scene, (0.6, -10.5, 2.6), (0.0, 0.0, 2.2))
    return scene


def build_spot_deep():
    """`spot`'s lamp and grille over fog reaching 12 m below the grille (8× the lamp's distance
    to it), with no floor: beyond the grille's depth nothing stops the shafts but the grille."""
    scene = start(ground=False)
    fog((-5, -5, -8), (5, 5, 4), sigma=DEEP_SIGMA)
    occluders(GRILLE)
    lamp(scene, "spot", (0.0, 0.0, 6.0), travel=(0.1, 0.05, -1.0))
    camera(scene, (0.6, -19.0, -1.5), (0.0, 0.0, -1.5))
    return scene


def build_roof():
    """A 16 m × 16 m roof of 1 m tiles with three tiles missing, over an 8 m × 8 m column of fog
    reaching 16 m below it and no floor; the sun falls steeply through the openings, and the
    roof is wide enough that all of its light reaching the fog comes through them."""
    scene = start(ground=False)
    fog((-4, -4, -8), (4, 4, 7.9), sigma=DEEP_SIGMA)
    holes = {(-4, 0), (-2, -2), (0, 1)}
    occluders([((x, y, 8.0), (x + 1, y + 1, 8.2))
               for x in range(-8, 8) for y in range(-8, 8) if (x, y) not in holes])
    sun_light(scene, (0.25, 0.15, -1.0))
    camera(scene, (1.0, -26.0, 0.0), (0.0, 0.0, 0.0))
    return scene


def build_smoke():
    """The forest plume's smoke (Mantaflow, 64 voxels on the domain's longest side) under a 20 m
    roof of 1 m tiles with four 3 m openings above it, a steep sun, a floor: shafts cut by the roof
    that the smoke dims as they cross it."""
    scene = start()
    vol = bpy.data.volumes.new("smoke")
    vol.filepath = SMOKE_VDB
    o = bpy.data.objects.new("smoke", vol)
    scene.collection.objects.link(o)
    o.location = SMOKE_AT
    m = bpy.data.materials.new("smoke")
    m.use_nodes = True
    nodes, links = m.node_tree.nodes, m.node_tree.links
    nodes.remove(nodes["Principled BSDF"])
    attr = nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "density"
    mul = nodes.new("ShaderNodeMath")
    mul.operation = "MULTIPLY"
    mul.inputs[1].default_value = SMOKE_SIGMA
    links.new(attr.outputs["Fac"], mul.inputs[0])
    scatter = nodes.new("ShaderNodeVolumeScatter")
    scatter.inputs["Anisotropy"].default_value = G
    scatter.inputs["Color"].default_value = (1, 1, 1, 1)
    links.new(mul.outputs[0], scatter.inputs["Density"])
    links.new(scatter.outputs["Volume"], nodes["Material Output"].inputs["Volume"])
    vol.materials.append(m)
    holes = {(x0 + i, y0 + j) for x0, y0 in ((-7, -8), (-3, -5), (0, -9), (-6, -3))
             for i in range(3) for j in range(3)}
    # Each 1 m row of the roof as runs of tiles between the openings (a few dozen boxes, so the
    # fixture's glTF stays small).
    boxes = []
    for y in range(-12, 8):
        x = -10
        while x < 10:
            if (x, y) in holes:
                x += 1
                continue
            end = x
            while end < 10 and (end, y) not in holes:
                end += 1
            boxes.append(((x, y, 8.0), (end, y + 1, 8.2)))
            x = end
    occluders(boxes)
    sun_light(scene, (0.3, 0.2, -1.0))
    camera(scene, (1.5, -15.0, 3.0), (-1.5, -3.0, 3.2))
    return scene


SMOKE_GRAPH = """(
    version: 2,
    nodes: {{
        "scene": (kind: "Scene", params: {{"path": "scene.gltf"}}),
        "shadow": (kind: "ShadowMap", params: {{"resolution": 2048}}),
        "gbuffer": (kind: "GBuffer"),
        "smoke": (kind: "VdbVolume", params: {{"path": "{vdb}", "up_axis": "z", "voxel_centers": "blender", "translate": ({x}, {y}, {z})}}),
        "scatter": (kind: "SingleScattering", params: {{"sigma_t": {sigma}, "albedo": 1.0, "g": {g}, "method": "BruteForce", "steps": 1024, "bias": 0.0005, "bounds": "density", "light_extinction": "on", "transmittance_resolution": 128, "light_steps": 128}}),
        "out": (kind: "ImageOutput", params: {{"path": "{exr}"}}),
    }},
    edges: [
        ("scene.scene", "shadow.scene"),
        ("scene.scene", "gbuffer.scene"),
        ("scene.scene", "scatter.scene"),
        ("shadow.map", "scatter.shadow"),
        ("gbuffer.depth", "scatter.depth"),
        ("smoke.volume", "scatter.density"),
        ("scatter.inscatter", "out.image"),
    ],
)
"""


def cage(z):
    """Twelve vertical bars 0.45 m around (0, 0, z), 1.8 m tall, over a solid floor plate just
    below z − 0.9: a point light at (0, 0, z) shines out between the bars and up."""
    bars = []
    for k in range(12):
        a = 2 * math.pi * k / 12
        cx, cy = 0.45 * math.cos(a), 0.45 * math.sin(a)
        bars.append(((cx - 0.06, cy - 0.06, z - 0.9), (cx + 0.06, cy + 0.06, z + 0.9)))
    bars.append(((-0.5, -0.5, z - 0.95), (0.5, 0.5, z - 0.85)))
    occluders(bars)


def build_point_inside():
    """A point light 2 m inside a fog box reaching 10 m below it, in a cage of twelve vertical
    bars, with no floor. The lamp is above the frame (the in-scatter of rays passing it closely
    would dominate the comparison's lit pixels)."""
    scene = start(ground=False)
    fog((-4, -4, -8), (4, 4, 4))
    cage(2.0)
    lamp(scene, "point", (0.0, 0.0, 2.0))
    camera(scene, (8.0, -11.0, -3.0), (0.0, 0.0, -4.5))
    return scene


def build_point():
    """A point light 1 m above a fog box, in a cage of twelve vertical bars with a solid floor."""
    scene = start()
    fog((-4, -4, 0), (4, 4, 4))
    cage(5.0)
    lamp(scene, "point", (0.0, 0.0, 5.0))
    camera(scene, (8.0, -11.0, 3.5), (0.0, 0.0, 2.0))
    return scene


def look(direction):
    """Rotation taking Blender's −Z (the camera's and the sun's forward) onto `direction`."""
    from mathutils import Vector
    return Vector(direction).normalized().to_track_quat("-Z", "Y")


def render_cycles(scene, samples, out):
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_denoising = False
    c.use_adaptive_sampling = False
    c.max_bounces = 0
    c.volume_bounces = 0
    c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 0
    c.transparent_max_bounces = 8
    # A heterogeneous volume is ray-marched in steps of volume_step_rate × its voxel size (0.22 m
    # for the smoke): a quarter of a voxel keeps Cycles' marching error below its noise.
    c.volume_step_rate = 0.25
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    # Tyndall evaluates one ray through each pixel's centre: a (nearly) zero-width pixel filter
    # makes Cycles average over the same ray instead of a 1.5-pixel footprint.
    c.filter_type = "BOX"
    c.filter_width = 0.01
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    layer = scene.view_layers[0]
    layer.cycles.use_pass_volume_direct = True
    scene.use_nodes = True
    tree = scene.node_tree
    for n in list(tree.nodes):
        tree.nodes.remove(n)
    rl = tree.nodes.new("CompositorNodeRLayers")
    comp = tree.nodes.new("CompositorNodeComposite")
    tree.links.new(rl.outputs["Image"], comp.inputs["Image"])
    fo = tree.nodes.new("CompositorNodeOutputFile")
    fo.base_path = out
    fo.format.file_format = "OPEN_EXR"
    fo.format.color_depth = "32"
    fo.format.color_mode = "RGB"
    fo.file_slots[0].path = "cycles_volume_direct"
    tree.links.new(rl.outputs["VolumeDir"], fo.inputs[0])
    scene.frame_set(1)
    bpy.ops.render.render(write_still=False)
    produced = os.path.join(out, "cycles_volume_direct0001.exr")
    final = os.path.join(out, "cycles_volume_direct.exr")
    os.replace(produced, final)
    return final


GRAPH = """(
    version: 2,
    nodes: {{
        "scene": (kind: "Scene", params: {{"path": "{gltf}"}}),
        "shadow": (kind: "ShadowMap", params: {{"resolution": 2048}}),
        "gbuffer": (kind: "GBuffer"),
        "scatter": (kind: "SingleScattering", params: {{"sigma_t": {sigma}, "albedo": 1.0, "g": {g}, {method}, "bias": 0.0005, "bounds": "tagged", "light_extinction": "on"}}),
        "out": (kind: "ImageOutput", params: {{"path": "{exr}"}}),{soft_node}
    }},
    edges: [
        ("scene.scene", "shadow.scene"),
        ("scene.scene", "gbuffer.scene"),
        ("scene.scene", "scatter.scene"),
        ("shadow.map", "scatter.shadow"),
        ("gbuffer.depth", "scatter.depth"),
        ("scatter.inscatter", "out.image"),{soft_edges}
    ],
)
"""


def export_and_render_tyndall(out, which):
    gltf = os.path.join(out, "scene.gltf")
    bpy.ops.export_scene.gltf(filepath=gltf, export_format="GLTF_EMBEDDED", export_cameras=True,
                              export_lights=True, export_extras=True, export_yup=True,
                              export_apply=True)
    rel = "scene.gltf"  # graph paths are relative to the graph's folder
    # A lamp's falloff and phase change along the ray: BruteForce with many samples.
    method = '"method": "MinMax"' if which in ("sun", "roof") else '"method": "BruteForce", "steps": 1024'
    exr = f"out/{os.path.basename(out)}/tyndall_inscatter.exr"
    soft_node, soft_edges = "", ""
    if which == "spot_soft":
        soft_node = ('\n        "soft": (kind: "SoftVisibility", params: {"resolution": 256, '
                     f'"slices": 256, "light_radius": {SOFT_RADIUS}, "bias": 0.0005}}),')
        soft_edges = ('\n        ("shadow.map", "soft.shadow"),'
                      '\n        ("soft.soft", "scatter.soft"),')
    graph = GRAPH.format(gltf=rel, sigma=SCENE_SIGMA.get(which, SIGMA), g=G, method=method, exr=exr,
                         soft_node=soft_node, soft_edges=soft_edges)
    if which == "smoke":
        # Blender's (x, y, z) is Tyndall's (x, z, −y); the graph names the file from its folder.
        x, y, z = SMOKE_AT
        graph = SMOKE_GRAPH.format(vdb=os.path.relpath(SMOKE_VDB, out), x=x, y=z, z=-y,
                                   sigma=SMOKE_SIGMA, g=G, exr=exr)
    with open(os.path.join(out, "compare.ron"), "w") as f:
        f.write(graph)
    exe = os.environ.get("TYNDALL", os.path.join(ROOT, "target", "release", "tyndall"))
    subprocess.run([exe, "render", os.path.join(out, "compare.ron"), "--size", f"{WIDTH}x{HEIGHT}",
                    "--output-dir", ROOT], cwd=ROOT, check=True)
    return os.path.join(ROOT, exr)


def pixels(path):
    img = bpy.data.images.load(path)
    px = list(img.pixels)  # RGBA, rows bottom to top
    w, h = img.size
    rows = [px[r * w * 4:(r + 1) * w * 4] for r in range(h)]
    return [v for row in reversed(rows) for v in row], w, h


def compare(cycles_exr, tyndall_exr):
    a, w, h = pixels(cycles_exr)
    b, w2, h2 = pixels(tyndall_exr)
    assert (w, h) == (w2, h2)
    lum = lambda p, i: sum(p[i * 4 + c] for c in range(3)) / 3
    ref = [lum(a, i) for i in range(w * h)]
    got = [lum(b, i) for i in range(w * h)]
    peak = max(ref)
    lit = [i for i in range(w * h) if ref[i] > 0.1 * peak]
    mx, my = sum(ref[i] for i in lit) / len(lit), sum(got[i] for i in lit) / len(lit)
    sxy = sum((ref[i] - mx) * (got[i] - my) for i in lit)
    sxx = sum((ref[i] - mx) ** 2 for i in lit)
    syy = sum((got[i] - my) ** 2 for i in lit)
    corr = sxy / math.sqrt(sxx * syy)
    rel = sum(abs(got[i] - ref[i]) / ref[i] for i in lit) / len(lit)
    ratio = sum(got[i] for i in lit) / sum(ref[i] for i in lit)
    print(f"compare: {len(lit)} lit pixels (Cycles in-scatter > 10 % of its max {peak:.5g} W/(m²·sr))")
    print(f"compare: correlation {corr:.4f}, mean relative error {rel * 100:.2f} %, "
          f"Tyndall/Cycles level {ratio:.4f}")


SCENES = {"sun": build_sun, "spot": build_spot, "point": build_point,
          "spot_soft": lambda: build_spot(SOFT_RADIUS), "roof": build_roof,
          "spot_deep": build_spot_deep, "point_inside": build_point_inside, "smoke": build_smoke}
SCENE_SIGMA = {"roof": DEEP_SIGMA, "spot_deep": DEEP_SIGMA}


def main():
    samples, out, which = args()
    os.makedirs(out, exist_ok=True)
    scene = SCENES[which]()
    cycles_exr = render_cycles(scene, samples, out)
    tyndall_exr = export_and_render_tyndall(out, which)
    compare(cycles_exr, tyndall_exr)


main()
