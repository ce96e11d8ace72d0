//! The 3D splat brush (id `splat_brush`; seed 000 §4.3, SPEC §6): painting a `BlendVolume` from
//! the viewer. Shown under the parameters of a selected node naming it (`BlendVolume`,
//! `Heterogeneity`); it paints into a node naming `splat_volume`.
//!
//! A plane orthogonal to the camera's view direction sits at `depth` metres along it (the
//! slider moves it along its normal). While the brush is armed the viewer tints the pixels
//! whose surface lies behind the plane, so the artist sees where the plane cuts the scene, and
//! draws the brush's outline under the pointer at its size on the plane. A drag over the viewer
//! casts the pixel's view ray onto the plane and leaves an ellipsoidal splat there — semi-axes
//! `radii` along the camera's right, up and viewing axes (rotation = the camera's), `opacity`,
//! `hardness`, the painted `value` or, with the eraser, a splat restoring the base — one splat
//! whenever the pointer has moved `spacing` × the smaller in-plane radius from the last one.
//! The splats land in the chosen volume's data block (`(splats: [...])`), so the graph file
//! reproduces the painting exactly; one drag is one undo step.
//!
//! The camera is the scene's (the one feeding the volume's `scene` input, else the graph's
//! first `Scene`) at the viewer picture's aspect; the tint needs that scene's depth, rendered
//! once per scene and picture size by the kind that renders a scene's depth (found by its
//! ports: the G-buffer), as a job of the editor's evaluation worker (the brush paints once the
//! depth has arrived).

use std::any::Any;

use eframe::egui;
use glam::Vec3;

use tyndall_editor::tool::{picture_pixel, stroke_points};
use tyndall_editor::{panel as panels, EditorState, Tool, ToolContext};
use tyndall_engine::eval::{Matrices, Registry};
use tyndall_engine::graph::Graph;
use tyndall_nodes::blend_volume::{BlendData, Role, Splat};

mod view;

use view::view_key;
pub use view::{camera_rotation, plane_mask, plane_point, render_view, view_depth, BrushView};

/// The brush's state.
pub struct BrushPanel {
    /// The `BlendVolume` painted into (None: the default for the selection).
    pub target: Option<String>,
    /// Distance of the painting plane along the camera's view direction, m (> 0; default 10).
    pub depth: f32,
    /// Semi-axes of the ellipsoid along the camera's right, up and viewing axes, m (default 1).
    pub radii: [f32; 3],
    /// Weight at the centre, 0…1 (default 0.5).
    pub opacity: f32,
    /// Fraction of the radius painted at full opacity, 0…1 (default 0.5).
    pub hardness: f32,
    /// The value painted (clamped by the volume to its role's range; default 1).
    pub value: f32,
    /// Paint erasing splats (restore the volume's base value).
    pub erase: bool,
    /// Distance between splats along a drag, as a fraction of the smaller in-plane radius
    /// (0.05…4; default 0.5).
    pub spacing: f32,
    /// A drag over the viewer paints.
    pub armed: bool,
    /// The pointer over the viewer, in picture pixels (for the outline).
    pub hover: Option<[f32; 2]>,
    view: Option<BrushView>,
    /// The key of the view asked of the worker, until its answer is taken.
    asked: Option<String>,
    /// The key of a view that failed to render, and why (not asked again until it changes).
    failed: Option<(String, String)>,
    last: Option<Vec3>,
    /// The painting plane's tint over the viewer, by (picture size, plane depth).
    tint: Option<(String, egui::TextureHandle)>,
}

impl Default for BrushPanel {
    fn default() -> Self {
        Self {
            target: None,
            depth: 10.0,
            radii: [1.0; 3],
            opacity: 0.5,
            hardness: 0.5,
            value: 1.0,
            erase: false,
            spacing: 0.5,
            armed: false,
            hover: None,
            view: None,
            asked: None,
            failed: None,
            last: None,
            tint: None,
        }
    }
}

impl Tool for BrushPanel {
    fn id(&self) -> &'static str {
        "splat_brush"
    }

    fn panel(&mut self, ui: &mut egui::Ui, cx: &mut ToolContext) -> Option<String> {
        show(ui, cx.registry, cx.state, cx.node, self)
    }

    /// While armed: the plane's tint, the outline under the pointer, and painting on drags.
    fn viewer(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        size: (u32, u32),
        cx: &mut ToolContext,
    ) -> Option<String> {
        if !self.armed {
            return None;
        }
        in_viewer(self, ui, response, size, cx).err()
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// The armed brush over the viewer picture (`size` pixels shown in `response.rect`).
fn in_viewer(
    brush: &mut BrushPanel,
    ui: &egui::Ui,
    response: &egui::Response,
    size: (u32, u32),
    cx: &mut ToolContext,
) -> Result<(), String> {
    let Some(target) = target_for(cx.registry, cx.state.graph(), brush, cx.node) else {
        return Ok(());
    };
    // The view is rendered from the whole document, so a scene wired in from outside the
    // group entered is found; the painting goes to the node of the graph shown.
    let flat = cx
        .state
        .root()
        .flatten(cx.registry.catalog())
        .map_err(|e| e.to_string())?;
    let full = cx.state.full_id(&target);
    let Some(view) = brush.view_for(cx, &flat, &full, size)?.cloned() else {
        // The worker renders the scene's depth; the brush paints once it has it.
        return Ok(());
    };
    let r = response.rect;
    // The plane: pixels whose surface lies behind it are tinted.
    let key = format!("{}@{}", view.key, brush.depth);
    if brush.tint.as_ref().is_none_or(|(k, _)| *k != key) {
        let tint = egui::Color32::from_rgba_unmultiplied(60, 130, 255, 100);
        let pixels = plane_mask(&view, brush.depth)
            .iter()
            .map(|m| if *m { tint } else { egui::Color32::TRANSPARENT })
            .collect();
        let image = egui::ColorImage::new([view.size.0 as usize, view.size.1 as usize], pixels);
        let tex = ui
            .ctx()
            .load_texture("brush-plane", image, egui::TextureOptions::NEAREST);
        brush.tint = Some((key, tex));
    }
    let Some((_, tex)) = &brush.tint else {
        return Ok(());
    };
    let painter = ui.painter_at(r);
    painter.image(
        tex.id(),
        r,
        egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
        egui::Color32::WHITE,
    );
    brush.hover = response
        .hover_pos()
        .map(|p| picture_pixel(response, size, p));
    if let Some(p) = response.hover_pos() {
        let [rx, ry] = outline_radii(brush, &view.camera, view.size);
        let scale = r.width() / size.0.max(1) as f32;
        let colour = if brush.erase {
            egui::Color32::from_gray(20)
        } else {
            egui::Color32::WHITE
        };
        painter.add(egui::epaint::EllipseShape::stroke(
            p,
            egui::vec2(rx, ry) * scale,
            egui::Stroke::new(1.5, colour),
        ));
    }
    let mut result = Ok(());
    for (p, start) in stroke_points(ui, response) {
        let at = picture_pixel(response, size, p);
        if let Err(e) = paint(cx.state, brush, &target, &view.camera, at, size, start) {
            result = Err(e);
        }
    }
    if response.drag_stopped() || response.clicked() {
        end_stroke(cx.state, brush);
    }
    result
}

/// Whether node `id` is a volume the brush paints into (its kind names `splat_volume`).
fn is_volume(registry: &Registry, graph: &Graph, id: &str) -> bool {
    graph
        .node(id)
        .and_then(|n| registry.get(&n.kind))
        .is_some_and(|k| k.has_tool("splat_volume"))
}

/// The volumes of the graph the brush can paint into, with their role, by id.
pub fn volumes(registry: &Registry, graph: &Graph) -> Vec<(String, Role)> {
    graph
        .nodes()
        .filter(|n| is_volume(registry, graph, &n.id))
        .map(|n| (n.id.clone(), role_of(graph, &n.id)))
        .collect()
}

/// The role of volume `id` (its default, α, when unset or unknown).
fn role_of(graph: &Graph, id: &str) -> Role {
    match graph.node(id).and_then(|n| n.params.get("role")) {
        Some(tyndall_engine::graph::ParamValue::Enum(r)) => {
            Role::from_name(r).unwrap_or(Role::Alpha)
        }
        _ => Role::Alpha,
    }
}

/// The volume the brush paints into when none was chosen: the selected `BlendVolume`, else the
/// first one feeding the selected node, else the graph's first.
pub fn default_target(registry: &Registry, graph: &Graph, selected: &str) -> Option<String> {
    let vols = volumes(registry, graph);
    if vols.iter().any(|(id, _)| id == selected) {
        return Some(selected.to_string());
    }
    ["alpha", "frequency", "intensity"]
        .iter()
        .filter_map(|p| graph.source_of(selected, p))
        .map(|(n, _)| n.to_string())
        .find(|n| vols.iter().any(|(id, _)| id == n))
        .or_else(|| vols.first().map(|(id, _)| id.clone()))
}

/// The volume painted now for `selected`: the chosen one while it exists, else the default.
pub fn target_for(
    registry: &Registry,
    graph: &Graph,
    panel: &BrushPanel,
    selected: &str,
) -> Option<String> {
    panel
        .target
        .clone()
        .filter(|t| is_volume(registry, graph, t))
        .or_else(|| default_target(registry, graph, selected))
}

/// The key of the brush's view job.
const VIEW_JOB: &str = "splat_brush/view";

impl BrushPanel {
    /// The brush's view of the scene for `target` at `size` and `time`: `None` while the
    /// evaluation worker renders it (asked here when the scene or the size changed since the
    /// view shown), the reason when rendering it failed.
    pub fn view_for(
        &mut self,
        cx: &mut ToolContext,
        graph: &Graph,
        target: &str,
        size: (u32, u32),
    ) -> Result<Option<&BrushView>, String> {
        let key = view_key(cx.registry, graph, target, size);
        if let Some(answer) = cx.jobs.take::<BrushView>(VIEW_JOB) {
            let asked = self.asked.take().unwrap_or_default();
            match answer {
                Ok(view) => self.view = Some(view),
                Err(e) => self.failed = Some((asked, e)),
            }
        }
        if self.view.as_ref().is_some_and(|v| v.key == key) {
            return Ok(self.view.as_ref());
        }
        if let Some((k, e)) = &self.failed {
            if *k == key {
                return Err(e.clone());
            }
        }
        if self.asked.as_deref() != Some(key.as_str()) || !cx.jobs.waiting_for(VIEW_JOB) {
            let (graph, target, time) = (graph.clone(), target.to_string(), cx.time);
            cx.jobs.ask(
                VIEW_JOB,
                Box::new(move |ev| {
                    render_view(ev, &graph, &target, size, time)
                        .map(|v| Box::new(v) as Box<dyn Any + Send>)
                }),
            );
            self.asked = Some(key);
        }
        Ok(None)
    }

    /// The view of the scene last rendered for the brush, if any.
    pub fn view(&self) -> Option<&BrushView> {
        self.view.as_ref()
    }

    /// The splat this brush leaves at `centre` under `camera`.
    pub fn splat_at(&self, centre: Vec3, camera: &Matrices) -> Splat {
        Splat {
            centre: centre.to_array(),
            radii: self.radii.map(|r| r.max(0.0)),
            rotation: camera_rotation(camera).to_array(),
            opacity: self.opacity.clamp(0.0, 1.0),
            hardness: self.hardness.clamp(0.0, 1.0),
            value: self.value,
            erase: self.erase,
        }
    }
}

/// The brush outline's semi-axes in picture pixels on a `size` picture (the in-plane radii
/// projected at the plane's depth).
pub fn outline_radii(panel: &BrushPanel, camera: &Matrices, size: (u32, u32)) -> [f32; 2] {
    let d = panel.depth.max(1e-3);
    [
        panel.radii[0] * camera.proj[0][0] * size.0 as f32 * 0.5 / d,
        panel.radii[1] * camera.proj[1][1] * size.1 as f32 * 0.5 / d,
    ]
}

/// Paint at picture position `point` of the viewer: `start` begins a new stroke (a new undo
/// step), otherwise the point continues the current one. Returns whether a splat was added
/// (points closer than the spacing to the last splat add none).
pub fn paint(
    state: &mut EditorState,
    panel: &mut BrushPanel,
    target: &str,
    camera: &Matrices,
    point: [f32; 2],
    size: (u32, u32),
    start: bool,
) -> Result<bool, String> {
    if start {
        state.end_merge();
        panel.last = None;
    }
    let Some(centre) = plane_point(camera, point, size, panel.depth) else {
        return Ok(false);
    };
    let step = panel.spacing.clamp(0.05, 4.0) * panel.radii[0].min(panel.radii[1]).max(1e-4);
    if panel.last.is_some_and(|l| l.distance(centre) < step) {
        return Ok(false);
    }
    let mut data = state.node_data::<BlendData>(target)?;
    data.splats.push(panel.splat_at(centre, camera));
    state.store_node_data(target, &data, Some("brush"))?;
    panel.last = Some(centre);
    Ok(true)
}

/// The drag is over: the next splat starts a new undo step.
pub fn end_stroke(state: &mut EditorState, panel: &mut BrushPanel) {
    if panel.last.take().is_some() {
        state.end_merge();
    }
}

/// Draw the panel for the selected node `selected`; returns a status message when an edit was
/// refused.
pub fn show(
    ui: &mut egui::Ui,
    registry: &Registry,
    state: &mut EditorState,
    selected: &str,
    panel: &mut BrushPanel,
) -> Option<String> {
    ui.separator();
    ui.heading("3D brush");
    let vols = volumes(registry, state.graph());
    let Some(target) = target_for(registry, state.graph(), panel, selected) else {
        ui.label("Add a BlendVolume to paint into.");
        return None;
    };
    ui.horizontal(|ui| {
        ui.label("volume");
        egui::ComboBox::from_id_salt("brush-volume")
            .selected_text(&target)
            .show_ui(ui, |ui| {
                for (id, role) in &vols {
                    if ui
                        .selectable_label(*id == target, format!("{id} ({})", role.name()))
                        .clicked()
                    {
                        panel.target = Some(id.clone());
                    }
                }
            });
        ui.toggle_value(&mut panel.armed, "Paint")
            .on_hover_text("Drag over the viewer to paint splats on the plane");
        ui.toggle_value(&mut panel.erase, "eraser")
            .on_hover_text("Splats restore the volume's base value");
    });
    let range = role_of(state.graph(), &target).range();
    let far = panel.view.as_ref().map_or(1e4, |v| v.camera.far.max(1.0));
    egui::Grid::new("brush-grid").num_columns(2).show(ui, |ui| {
        ui.label("plane depth");
        ui.add(
            egui::DragValue::new(&mut panel.depth)
                .range(0.01..=far)
                .speed(0.05)
                .suffix(" m"),
        )
        .on_hover_text("Distance of the painting plane along the view direction");
        ui.end_row();
        ui.label("size");
        ui.horizontal(|ui| {
            for (r, tip) in panel
                .radii
                .iter_mut()
                .zip(["across", "up", "along the view"])
            {
                ui.add(
                    egui::DragValue::new(r)
                        .range(0.0..=1e4)
                        .speed(0.02)
                        .suffix(" m"),
                )
                .on_hover_text(format!("semi-axis {tip}"));
            }
        });
        ui.end_row();
        ui.label("opacity");
        ui.add(egui::Slider::new(&mut panel.opacity, 0.0..=1.0));
        ui.end_row();
        ui.label("hardness");
        ui.add(egui::Slider::new(&mut panel.hardness, 0.0..=1.0));
        ui.end_row();
        ui.label("value");
        ui.add(egui::Slider::new(&mut panel.value, range.0..=range.1));
        ui.end_row();
        ui.label("spacing");
        ui.add(egui::Slider::new(&mut panel.spacing, 0.05..=4.0))
            .on_hover_text("Distance between splats along a drag, × the smaller in-plane radius");
        ui.end_row();
    });
    let mut data = panels::data_block::<BlendData>(ui, state, &target)?;
    let mut changed = false;
    ui.horizontal(|ui| {
        ui.label(format!("{} splat(s) in {target}", data.splats.len()));
        if ui
            .add_enabled(!data.splats.is_empty(), egui::Button::new("Clear splats"))
            .clicked()
        {
            data.splats.clear();
            changed = true;
        }
    });
    if changed {
        if let Err(e) = state.store_node_data(&target, &data, None) {
            return Some(e);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use tyndall_engine::scene::Camera;

    fn camera(size: (u32, u32)) -> Matrices {
        let c = Camera {
            position: Vec3::new(1.0, 2.0, 9.0),
            target: Vec3::new(-2.0, 1.0, 0.0),
            fov_y: 50.0,
            near: 0.1,
            far: 80.0,
        };
        Matrices::of_camera(&c, size.0, size.1)
    }

    #[test]
    fn plane_points_lie_on_the_plane_and_project_back_to_their_pixel() {
        let size = (480, 270);
        let m = camera(size);
        for (p, d) in [
            ([240.0, 135.0], 10.0),
            ([3.5, 260.0], 2.0),
            ([479.0, 0.5], 55.0),
        ] {
            let q = plane_point(&m, p, size, d).expect("in front");
            assert!((view_depth(&m, q) - d).abs() < 1e-3 * d, "{p:?} {d}");
            let c = m.view_proj().project_point3(q);
            let back = [(c.x + 1.0) * 0.5 * 480.0, (1.0 - c.y) * 0.5 * 270.0];
            assert!((back[0] - p[0]).abs() < 1e-2 && (back[1] - p[1]).abs() < 1e-2);
        }
        assert!(plane_point(&m, [10.0, 10.0], size, 0.0).is_none());
        assert!(plane_point(&m, [10.0, 10.0], size, f32::INFINITY).is_none());
    }

    #[test]
    fn splats_face_the_camera_and_the_outline_matches_their_projection() {
        let size = (480, 270);
        let m = camera(size);
        let panel = BrushPanel {
            radii: [0.7, 0.4, 2.0],
            depth: 6.0,
            ..Default::default()
        };
        let q = glam::Quat::from_array(camera_rotation(&m).to_array());
        let right = q * Vec3::X;
        let back = q * Vec3::Z;
        assert!((back - m.backward()).length() < 1e-5);
        let centre = plane_point(&m, [200.0, 100.0], size, panel.depth).expect("point");
        let s = panel.splat_at(centre, &m);
        assert_eq!(s.radii, [0.7, 0.4, 2.0]);
        // The splat's edge along its x axis lands the outline's x radius away on screen.
        let edge = centre + right * s.radii[0];
        let px = |p: Vec3| {
            let c = m.view_proj().project_point3(p);
            Vec3::new((c.x + 1.0) * 240.0, (1.0 - c.y) * 135.0, 0.0)
        };
        let got = (px(edge) - px(centre)).length();
        let want = outline_radii(&panel, &m, size)[0];
        assert!((got - want).abs() < 0.05 * want, "{got} vs {want}");
    }
}
