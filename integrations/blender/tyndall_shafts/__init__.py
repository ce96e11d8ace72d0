"""Tyndall Shafts: volumetric light shafts from Tyndall, from inside Blender.

Render Properties > Tyndall Shafts: choose a preset graph, press "Render shafts". The add-on
exports the scene as glTF (cameras, lights in lux, animation, custom properties as extras, so an
object's `tyndall_tag` becomes a Tyndall tag; each Volume object and each smoke domain with an
OpenVDB cache carries its file as the custom property `vdb`, which `VdbVolume` reads), renders Blender's own beauty and depth for a
plate preset, runs `tyndall render` over the scene's frame range with progress in the status
bar (Esc cancels), and wires the result into the compositor: Render Layers × transmittance +
inscatter → Composite. Errors from Tyndall appear as reports.
"""

bl_info = {
    "name": "Tyndall Shafts",
    "author": "Tyndall",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Render > Tyndall Shafts",
    "description": "Stylized volumetric light shafts rendered by Tyndall and composited over the render",
    "category": "Render",
}

import os

import bpy

from . import runner
from .runner import TyndallError

ADDON = __name__


def prefs(context):
    return context.preferences.addons[ADDON].preferences


class TyndallPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON

    binary: bpy.props.StringProperty(
        name="Tyndall binary",
        description="Path to the tyndall executable; empty: 'tyndall' on PATH",
        subtype="FILE_PATH",
        default="",
    )
    graphs_folder: bpy.props.StringProperty(
        name="Preset folder",
        description="Tyndall's graphs/ folder; empty: the one beside a binary built in the repository, or $TYNDALL_GRAPHS",
        subtype="DIR_PATH",
        default="",
    )
    user_presets: bpy.props.StringProperty(
        name="User presets",
        description="Your own folder of preset graphs (.ron), listed after Tyndall's",
        subtype="DIR_PATH",
        default="",
    )

    def draw(self, _context):
        for p in ("binary", "graphs_folder", "user_presets"):
            self.layout.prop(self, p)


def preset_folders(context):
    p = prefs(context)
    folders = []
    graphs = bpy.path.abspath(p.graphs_folder) if p.graphs_folder else ""
    if not graphs:
        try:
            graphs = runner.default_graphs_folder(runner.find_binary(p.binary))
        except TyndallError:
            graphs = ""
    folders.append(graphs)
    if p.user_presets:
        folders.append(bpy.path.abspath(p.user_presets))
    return folders


_preset_items = []


def preset_items(_self, context):
    # Blender keeps only the strings a callback returns while a reference to them lives.
    global _preset_items
    found = runner.list_presets(preset_folders(context))
    _preset_items = [(path, label, path) for path, label in found] or [
        ("", "(no presets found: set the preset folder in the add-on's preferences)", "")
    ]
    return _preset_items


class TyndallSettings(bpy.types.PropertyGroup):
    preset: bpy.props.EnumProperty(name="Preset", description="The graph that renders the shafts", items=preset_items)
    preset_path: bpy.props.StringProperty(
        name="Preset file",
        description="A graph file to use instead of the list (scripts, farm jobs)",
        subtype="FILE_PATH",
        default="",
    )
    output_dir: bpy.props.StringProperty(
        name="Output folder",
        description="Where the glTF, Blender's plate and Tyndall's EXRs are written",
        subtype="DIR_PATH",
        default="//tyndall/",
    )


class TYNDALL_OT_render_shafts(bpy.types.Operator):
    """Export the scene, render shafts with Tyndall over the frame range and composite them over the render"""

    bl_idname = "tyndall.render_shafts"
    bl_label = "Render shafts"
    bl_options = {"REGISTER"}

    _timer = None
    _proc = None
    _job = None

    def prepare(self, context):
        scene = context.scene
        s = scene.tyndall
        binary = runner.find_binary(prefs(context).binary)
        graph = bpy.path.abspath(s.preset_path) if s.preset_path else s.preset
        if not graph or not os.path.isfile(graph):
            raise TyndallError(f"preset graph not found: '{graph}'")
        if scene.camera is None:
            raise TyndallError("the scene has no camera: Tyndall renders the scene camera's view")
        out_dir = os.path.abspath(bpy.path.abspath(s.output_dir))
        os.makedirs(out_dir, exist_ok=True)
        r = scene.render
        size = (r.resolution_x * r.resolution_percentage // 100,
                r.resolution_y * r.resolution_percentage // 100)
        fps = r.fps / r.fps_base
        job = runner.Job(binary, graph, out_dir, os.path.join(out_dir, "shot.glb"),
                         (scene.frame_start, scene.frame_end), size, fps,
                         context.view_layer.name)
        nodes = runner.graph_nodes(binary, graph)
        cmd = job.command(nodes)
        export_gltf(job.glb)
        if job.uses_plate(nodes):
            render_plate(scene, context.view_layer, job)
        return job, cmd

    def finish(self, context):
        wire_compositor(context.scene, self._job)
        n = self._job.frames[1] - self._job.frames[0] + 1
        self.report({"INFO"}, f"Tyndall: {n} frame{'s' if n != 1 else ''} of shafts in {self._job.out_dir}")

    def execute(self, context):
        # Without a window (blender -b) there is no event loop to poll from: run to the end.
        try:
            self._job, cmd = self.prepare(context)
            proc = runner.Process(cmd)
            code = proc.p.wait()
            proc.poll()
            if code != 0:
                raise TyndallError(f"tyndall render failed (exit {code}): {proc.error()}")
            self.finish(context)
        except TyndallError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return {"FINISHED"}

    def invoke(self, context, _event):
        if bpy.app.background:
            return self.execute(context)
        try:
            self._job, cmd = self.prepare(context)
            self._proc = runner.Process(cmd)
        except TyndallError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.25, window=context.window)
        wm.progress_begin(0, self.total())
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def total(self):
        return self._job.frames[1] - self._job.frames[0] + 1

    def end(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)

    def modal(self, context, event):
        if event.type == "ESC":
            self._proc.cancel()
            self.end(context)
            self.report({"WARNING"}, "Tyndall: cancelled")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        done, code = self._proc.poll()
        context.window_manager.progress_update(done)
        context.workspace.status_text_set(
            f"Tyndall: {done} of {self.total()} frames rendered (Esc to cancel)")
        if code is None:
            return {"RUNNING_MODAL"}
        self.end(context)
        if code != 0:
            self.report({"ERROR"}, f"tyndall render failed (exit {code}): {self._proc.error()}")
            return {"CANCELLED"}
        try:
            self.finish(context)
        except TyndallError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        return {"FINISHED"}


VDB_PROPERTY = "vdb"


def vdb_pattern(volume):
    """A Volume data-block's file, absolute; a sequence's frame number as `####` (Blender's
    sequences number files by frame: fluid_data_0001.vdb …)."""
    path = bpy.path.abspath(volume.filepath, library=volume.library)
    if volume.is_sequence:
        head, name = os.path.split(path)
        stem, ext = os.path.splitext(name)
        digits = len(stem) - len(stem.rstrip("0123456789"))
        if digits:
            path = os.path.join(head, stem[:-digits] + "#" * max(digits, 4) + ext)
    return path


def smoke_cache(obj):
    """The OpenVDB cache pattern of a gas domain (Fluid modifier, OpenVDB cache format), or None."""
    for m in obj.modifiers:
        if m.type == "FLUID" and m.fluid_type == "DOMAIN":
            s = m.domain_settings
            if s.domain_type == "GAS" and s.cache_data_format == "OPENVDB":
                cache = bpy.path.abspath(s.cache_directory)
                return os.path.join(cache, "data", "fluid_data_####.vdb")
    return None


class VolumeExport:
    """While the glTF is written: each Volume object carries its file as the custom property
    `vdb` (the exporter writes Volume objects as nodes with their custom properties); each
    smoke domain is tagged `medium` (its box bounds the medium instead of being drawn) and an
    Empty `<domain>_cache` stands at the domain's low corner with the cache's pattern (the cache's
    index 0 is that corner, its voxels in world units). Everything is put back afterwards."""

    def __init__(self, scene):
        self.scene = scene
        self.saved = []  # (object, property, value or None)
        self.empties = []

    def _set(self, obj, key, value):
        self.saved.append((obj, key, obj.get(key)))
        obj[key] = value

    def __enter__(self):
        from mathutils import Matrix, Vector
        for obj in list(self.scene.objects):
            if obj.type == "VOLUME" and obj.data is not None and obj.data.filepath:
                self._set(obj, VDB_PROPERTY, vdb_pattern(obj.data))
            pattern = smoke_cache(obj) if obj.type == "MESH" else None
            if pattern:
                tags = obj.get("tyndall_tag", "")
                self._set(obj, "tyndall_tag", (tags + ", " if tags else "") + "medium")
                lo = Vector([min(c[k] for c in obj.bound_box) for k in range(3)])
                empty = bpy.data.objects.new(f"{obj.name}_cache", None)
                self.scene.collection.objects.link(empty)
                rot = obj.matrix_world.to_quaternion().to_matrix().to_4x4()
                empty.matrix_world = Matrix.Translation(obj.matrix_world @ lo) @ rot
                empty[VDB_PROPERTY] = pattern
                self.empties.append(empty)
        return self

    def __exit__(self, *exc):
        for obj, key, value in reversed(self.saved):
            if value is None:
                del obj[key]
            else:
                obj[key] = value
        for empty in self.empties:
            bpy.data.objects.remove(empty)
        return False


def export_gltf(path):
    """The scene as Tyndall reads it: +Y up, cameras, punctual lights in lux (Blender's
    'Standard' lighting mode: a sun of S W/m² is written as 683·S lux and read back as S W/m²),
    animation over the scene's frame range, custom properties as extras (`tyndall_tag`)."""
    kwargs = dict(
        filepath=path,
        export_format="GLB",
        export_cameras=True,
        export_lights=True,
        export_extras=True,
        export_yup=True,
        export_apply=True,
        export_animations=True,
        export_frame_range=True,
        export_force_sampling=True,
    )
    props = bpy.ops.export_scene.gltf.get_rna_type().properties
    if "convert_lighting_mode" in props:
        kwargs["convert_lighting_mode"] = "SPEC"
    if "export_draco_mesh_compression_enable" in props:
        kwargs["export_draco_mesh_compression_enable"] = False
    try:
        with VolumeExport(bpy.context.scene):
            bpy.ops.export_scene.gltf(**kwargs)
    except RuntimeError as e:
        raise TyndallError(f"glTF export failed: {e}") from e


def render_plate(scene, view_layer, job):
    """Blender's own beauty and depth over the frame range, as multi-layer EXRs: the plate a
    plate preset puts the shafts over, its depth bounding Tyndall's view rays."""
    r = scene.render
    saved = (r.filepath, r.image_settings.file_format, r.image_settings.color_depth,
             r.use_compositing, view_layer.use_pass_z, r.use_file_extension)
    try:
        r.filepath = job.plate_pattern[: -len(".exr")]
        r.use_file_extension = True
        r.image_settings.file_format = "OPEN_EXR_MULTILAYER"
        r.image_settings.color_depth = "32"
        r.use_compositing = False
        view_layer.use_pass_z = True
        bpy.ops.render.render(animation=True)
    finally:
        (r.filepath, r.image_settings.file_format, r.image_settings.color_depth,
         r.use_compositing, view_layer.use_pass_z, r.use_file_extension) = saved
    first, last = job.frames
    missing = [f for f in range(first, last + 1)
               if not os.path.isfile(job.frame_file(job.plate_pattern, f))]
    if missing:
        raise TyndallError(f"Blender's plate render wrote no file for frames {missing}")


def wire_compositor(scene, job):
    """An Image node reading Tyndall's EXR sequence, mixed over the Render Layers:
    Render Layers × transmittance + inscatter → Composite (nodes named `Tyndall …`, reused on
    the next run)."""
    first, last = job.frames
    first_file = job.frame_file(job.shafts_pattern, first)
    if not os.path.isfile(first_file):
        raise TyndallError(f"Tyndall wrote no {first_file}")
    scene.use_nodes = True
    tree = scene.node_tree
    nodes, links = tree.nodes, tree.links

    def node(kind, name, location):
        n = nodes.get(name)
        if n is None or n.bl_idname != kind:
            n = nodes.new(kind)
            n.name = name
        n.label = name
        n.location = location
        return n

    rl = next((n for n in nodes if n.bl_idname == "CompositorNodeRLayers"), None)
    if rl is None:
        rl = nodes.new("CompositorNodeRLayers")
        rl.location = (-500, 200)
    comp = next((n for n in nodes if n.bl_idname == "CompositorNodeComposite"), None)
    if comp is None:
        comp = nodes.new("CompositorNodeComposite")
        comp.location = (500, 200)
    img = bpy.data.images.get("Tyndall shafts")
    if img is not None:
        bpy.data.images.remove(img)
    img = bpy.data.images.load(first_file, check_existing=False)
    img.name = "Tyndall shafts"
    img.source = "SEQUENCE"
    shafts = node("CompositorNodeImage", "Tyndall shafts", (-500, -150))
    shafts.image = img
    shafts.frame_duration = last - first + 1
    shafts.frame_start = first
    shafts.frame_offset = first - 1
    shafts.use_auto_refresh = True
    mul = node("CompositorNodeMixRGB", "Tyndall transmittance", (0, 200))
    mul.blend_type = "MULTIPLY"
    add = node("CompositorNodeMixRGB", "Tyndall inscatter", (250, 200))
    add.blend_type = "ADD"
    mul.inputs[0].default_value = 1.0
    add.inputs[0].default_value = 1.0
    out = {s.name: s for s in shafts.outputs}
    if "inscatter" not in out or "transmittance" not in out:
        raise TyndallError(
            f"{first_file} has no inscatter/transmittance layers (outputs: {', '.join(out) or 'none'})"
        )
    links.new(rl.outputs["Image"], mul.inputs[1])
    links.new(out["transmittance"], mul.inputs[2])
    links.new(mul.outputs[0], add.inputs[1])
    links.new(out["inscatter"], add.inputs[2])
    links.new(add.outputs[0], comp.inputs["Image"])


class TYNDALL_PT_panel(bpy.types.Panel):
    bl_label = "Tyndall Shafts"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"

    def draw(self, context):
        s = context.scene.tyndall
        r = context.scene.render
        col = self.layout.column()
        col.prop(s, "preset")
        col.prop(s, "preset_path")
        col.prop(s, "output_dir")
        col.label(text=f"{r.resolution_x * r.resolution_percentage // 100} × "
                       f"{r.resolution_y * r.resolution_percentage // 100} px, frames "
                       f"{context.scene.frame_start}–{context.scene.frame_end} (from the scene)")
        col.operator(TYNDALL_OT_render_shafts.bl_idname, icon="LIGHT_SUN")


classes = (TyndallPreferences, TyndallSettings, TYNDALL_OT_render_shafts, TYNDALL_PT_panel)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Scene.tyndall = bpy.props.PointerProperty(type=TyndallSettings)


def unregister():
    del bpy.types.Scene.tyndall
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
