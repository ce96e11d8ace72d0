//! The editor window: a node canvas (egui-snarl, a view of the document) with per-node
//! thumbnails and timings, a viewer (pins 1–9, channel, exposure, fit/1:1, pixel probe), the
//! parameters panel with key-frame toggles, a timeline, a preset browser and the add-node
//! catalog. Evaluation runs on a worker thread ([`super::worker`]); the window never waits.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui;
use egui_snarl::ui::{get_selected_nodes, SnarlWidget};
use egui_snarl::Snarl;

use super::canvas::CanvasView;
use super::view::{probe, to_srgb8, Channel};
use super::worker::{NodeReport, Request, Worker};
use super::{list_presets, EditorState, PresetEntry};
use crate::eval::{EditorTool, Registry};
use crate::gpu::Gpu;
use crate::graph::{save_string, Interp, Key, ParamKind, ParamValue};
use crate::io::Raster;

/// Viewer zoom.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Zoom {
    /// Fit the panel.
    Fit,
    /// One picture pixel per screen pixel (scrolls).
    One,
}

/// Size of pictures made from nothing (scattering, composites) in the editor.
pub const VIEW_SIZE: (u32, u32) = (480, 270);

/// The editor application.
pub struct EditorApp {
    /// The document and its history.
    pub state: EditorState,
    snarl: Snarl<String>,
    synced: Option<String>,
    /// Id of the node shown in the parameters panel (and the viewer unless a pin is active).
    pub selected: Option<String>,
    /// Last message (refused connection, save result…).
    pub status: String,
    /// Why evaluation could not start (no adapter qualifies): shown in a window, the same
    /// message the command line prints.
    pub gpu_problem: Option<String>,
    worker: Option<Worker>,
    requested: String,
    /// The worker's last report per node: ran / cached, time, error.
    pub reports: BTreeMap<String, NodeReport>,
    thumbs: BTreeMap<String, egui::TextureHandle>,
    /// The viewed node's picture outputs, by port.
    pub pictures: Option<(String, Vec<(String, Raster)>)>,
    view_port: Option<String>,
    view_tex: Option<(String, egui::TextureHandle)>,
    /// Viewer channel.
    pub channel: Channel,
    /// Viewer exposure in stops.
    pub exposure: f32,
    /// Viewer zoom.
    pub zoom: Zoom,
    /// The probe's last line.
    pub probe: String,
    /// Pinned viewers: keys 1–9 show them, Shift+1–9 pin the selected node.
    pub pins: [Option<String>; 9],
    /// The pin being shown (None: the selected node).
    pub active_pin: Option<usize>,
    /// Current time (frames).
    pub time: f64,
    /// Timeline range (frames, inclusive).
    pub range: (f64, f64),
    /// Frames per second of playback.
    pub fps: f64,
    /// Playing.
    pub playing: bool,
    /// Folders the preset browser lists.
    pub preset_folders: Vec<PathBuf>,
    presets: Vec<PresetEntry>,
    preset_thumbs: BTreeMap<PathBuf, Option<egui::TextureHandle>>,
    preset_name: String,
    search: String,
    save_as: Option<String>,
    frame_all: bool,
    clipboard: String,
    /// Show per-node timings on the canvas (off for reproducible screenshots).
    pub show_timings: bool,
    /// An autosave left by a session that did not save, offered for recovery at start.
    pub recovery: Option<PathBuf>,
    /// The window was asked to close with unsaved changes: the save/discard/cancel prompt.
    pub confirm_quit: bool,
    /// The transfer-function panel's state.
    pub tf: super::tf_panel::TfPanel,
    /// The stroke panel's state.
    pub strokes: super::stroke_panel::StrokePanel,
    /// The 3D brush's state.
    pub brush: super::brush_panel::BrushPanel,
    /// The painting plane's tint over the viewer, by (picture size, plane depth).
    brush_tex: Option<(String, egui::TextureHandle)>,
    /// The node kinds (for picking 3D constraints on the UI thread).
    registry: Arc<Registry>,
    /// The newest progress report of a long-running node (shown while the worker is busy).
    pub progress: Option<crate::eval::Progress>,
    /// How many times the GPU device was lost and evaluation restarted on a new one.
    pub device_restarts: u32,
    /// Measured speed/accuracy curves from `bench/results.csv`.
    bench: super::bench_panel::Curves,
    allow_close: bool,
}

/// The user preset folder: `$TYNDALL_PRESETS`, else `~/.config/tyndall/presets`.
pub fn user_preset_folder() -> Option<PathBuf> {
    std::env::var_os("TYNDALL_PRESETS")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config/tyndall/presets"))
        })
}

impl EditorApp {
    /// An editor on `state`; evaluation starts on a worker thread when a GPU adapter is found
    /// (the process-wide [`Gpu::shared`]).
    pub fn new(state: EditorState, registry: Arc<Registry>) -> Self {
        match Gpu::shared() {
            Ok(gpu) => Self::on_gpu(state, registry, Some(gpu)),
            Err(e) => {
                let mut app = Self::on_gpu(state, registry, None);
                app.gpu_problem = Some(e.to_string());
                app
            }
        }
    }

    /// An editor on `state` evaluating on `gpu` (`None`: no pictures). Should that device be
    /// lost, evaluation moves to a new [`Gpu::shared`] device.
    pub fn on_gpu(state: EditorState, registry: Arc<Registry>, gpu: Option<Arc<Gpu>>) -> Self {
        let worker = gpu.map(|g| Worker::start(registry.clone(), g));
        let mut preset_folders = vec![PathBuf::from("graphs")];
        preset_folders.extend(user_preset_folder());
        let range = key_range(&state).unwrap_or((0.0, 48.0));
        let bench = super::bench_panel::Curves::find(state.path());
        Self {
            bench,
            state,
            snarl: Snarl::new(),
            synced: None,
            selected: None,
            status: if worker.is_none() {
                "no GPU adapter: pictures are off".into()
            } else {
                String::new()
            },
            gpu_problem: None,
            worker,
            requested: String::new(),
            reports: BTreeMap::new(),
            thumbs: BTreeMap::new(),
            pictures: None,
            view_port: None,
            view_tex: None,
            channel: Channel::Rgb,
            exposure: 0.0,
            zoom: Zoom::Fit,
            probe: String::new(),
            pins: Default::default(),
            active_pin: None,
            time: 0.0,
            range,
            fps: 24.0,
            playing: false,
            preset_folders,
            presets: Vec::new(),
            preset_thumbs: BTreeMap::new(),
            preset_name: String::new(),
            search: String::new(),
            save_as: None,
            frame_all: true,
            clipboard: String::new(),
            show_timings: true,
            recovery: None,
            confirm_quit: false,
            allow_close: false,
            tf: Default::default(),
            strokes: Default::default(),
            brush: Default::default(),
            brush_tex: None,
            registry,
            progress: None,
            device_restarts: 0,
        }
    }

    /// Set node `id`'s parameters to a measured setting (`name → value` text, as in
    /// `bench/results.csv`) as one undoable step; a value that no longer parses is reported in
    /// the status line and nothing changes.
    fn use_measured(&mut self, id: &str, setting: &BTreeMap<String, String>) {
        let result = self.state.apply(|g, c| {
            for (name, text) in setting {
                g.set_param_text(c, id, name, text)?;
            }
            Ok(())
        });
        self.status = match result {
            Ok(()) => format!("{id}: measured setting applied"),
            Err(e) => e.to_string(),
        };
    }

    /// Read the measured speed/accuracy curves from `path` (a `bench/results.csv`) instead of
    /// the one found next to the working directory or the graph.
    pub fn set_bench_results(&mut self, path: &Path) {
        self.bench = super::bench_panel::Curves::at(path);
    }

    /// The node the viewer shows: the active pin's, else the selected one — or, when the
    /// selected node has no picture output (a volume, a scene), the nearest node downstream
    /// of it that has one (so painting a `BlendVolume` shows what it does).
    pub fn viewed(&self) -> Option<String> {
        let g = self.state.graph();
        self.active_pin
            .and_then(|i| self.pins[i].clone())
            .filter(|id| g.node(id).is_some())
            .or_else(|| {
                let s = self.selected.clone()?;
                if super::worker::picture_ports(g, &self.registry, &s).is_empty() {
                    super::brush_panel::nearest_picture(g, &self.registry, &s).or(Some(s))
                } else {
                    Some(s)
                }
            })
    }

    /// Connect output `from` (`node.port`) to input `to`, replacing the input's edge as other
    /// compositors do; a refusal (type mismatch, cycle, unknown port) lands in the status line
    /// with its reason. The canvas's wire drops come here.
    pub fn connect_ports(&mut self, from: &str, to: &str) -> bool {
        let res = self.state.connect_replacing(from, to);
        self.status = match &res {
            Ok(()) => String::new(),
            Err(e) => format!("refused: {e}"),
        };
        res.is_ok()
    }

    /// Fit the canvas view to all nodes on the next frame (F, "Frame all").
    pub fn request_frame_all(&mut self) {
        self.frame_all = true;
    }

    /// Whether node `id` has a thumbnail on the canvas.
    pub fn has_thumbnail(&self, id: &str) -> bool {
        self.thumbs.contains_key(id)
    }

    /// Every evaluation asked for has landed (or there is no GPU).
    pub fn idle(&self) -> bool {
        self.worker.as_ref().is_none_or(|w| w.idle())
    }

    /// Rebuild the canvas from the document when the document changed.
    fn sync(&mut self) {
        let text = save_string(self.state.graph());
        if self.synced.as_deref() == Some(text.as_str()) {
            return;
        }
        let g = self.state.graph();
        let mut snarl = Snarl::new();
        let mut ids = BTreeMap::new();
        for (i, n) in g.nodes().enumerate() {
            let pos = n.pos.unwrap_or([i as f32 * 40.0, i as f32 * 30.0]);
            ids.insert(
                n.id.clone(),
                snarl.insert_node(egui::pos2(pos[0], pos[1]), n.id.clone()),
            );
        }
        let cat = self.state.catalog();
        for e in g.edges() {
            let (Some(a), Some(b)) = (ids.get(&e.from_node), ids.get(&e.to_node)) else {
                continue;
            };
            let out_ix = g
                .node(&e.from_node)
                .and_then(|n| cat.get(&n.kind))
                .and_then(|s| s.outputs.iter().position(|p| p.name == e.from_port));
            let in_ix = g
                .node(&e.to_node)
                .and_then(|n| cat.get(&n.kind))
                .and_then(|s| s.inputs.iter().position(|p| p.name == e.to_port));
            if let (Some(o), Some(i)) = (out_ix, in_ix) {
                snarl.connect(
                    egui_snarl::OutPinId {
                        node: *a,
                        output: o,
                    },
                    egui_snarl::InPinId { node: *b, input: i },
                );
            }
        }
        self.snarl = snarl;
        self.synced = Some(text);
        let g = self.state.graph();
        self.thumbs.retain(|id, _| g.node(id).is_some());
        self.reports.retain(|id, _| g.node(id).is_some());
    }

    /// Send the worker a request when the document, the time or the viewed node changed, and
    /// take in what it finished.
    fn pump(&mut self, ctx: &egui::Context) {
        let view = self.viewed();
        let Some(worker) = self.worker.as_mut() else {
            return;
        };
        let key = format!(
            "{:?}@{}:{}",
            view,
            self.time,
            self.synced.as_deref().unwrap_or("")
        );
        if key != self.requested {
            self.requested = key;
            worker.request(Request {
                generation: 0,
                graph: graph_for_evaluation(&self.registry, &self.state),
                time: self.time,
                size: VIEW_SIZE,
                view,
            });
        }
        if let Some(p) = worker.poll_progress() {
            self.progress = Some(p);
        }
        let mut lost = None;
        for out in worker.poll() {
            lost = lost.or(out.device_lost);
            for (id, rep) in out.nodes {
                if let Some(t) = &rep.thumb {
                    let image = colour_image(t, Channel::Rgb, 0.0);
                    self.thumbs.insert(
                        id.clone(),
                        ctx.load_texture(
                            format!("thumb-{id}"),
                            image,
                            egui::TextureOptions::LINEAR,
                        ),
                    );
                }
                self.reports.insert(id, NodeReport { thumb: None, ..rep });
            }
            if out.view.is_some() {
                self.pictures = out.view;
                self.view_tex = None;
            }
            let ran = self.reports.values().filter(|r| r.status.ran()).count();
            let errors = self.reports.values().filter(|r| r.error.is_some()).count();
            self.status = match errors {
                0 => format!("{ran} ran in {:.0} ms", out.elapsed.as_secs_f64() * 1e3),
                n => format!("{n} node(s) failed; see the canvas"),
            };
            if self.device_restarts > 0 {
                // Kept in view: the restart message itself is replaced by the first summary.
                self.status +=
                    &format!(" (GPU device lost and replaced {}×)", self.device_restarts);
            }
        }
        if let Some(reason) = lost {
            self.restart_after_loss(&reason);
            ctx.request_repaint();
        } else if !worker.idle() {
            ctx.request_repaint_after(Duration::from_millis(30));
        }
    }

    /// The worker's device was lost: drop the worker (and its cache, which lived on that
    /// device), start a new one on a new device and ask for the whole evaluation again.
    fn restart_after_loss(&mut self, reason: &str) {
        if let Some(old) = self.worker.take() {
            old.abandon();
        }
        self.requested.clear();
        self.progress = None;
        match Gpu::shared() {
            Ok(gpu) => {
                self.worker = Some(Worker::start(self.registry.clone(), gpu));
                self.device_restarts += 1;
                self.status = format!("{reason}: restarted on a new device");
            }
            Err(e) => {
                self.status = format!("{reason}; no new device ({e}): pictures are off");
            }
        }
    }
}

/// The pointer positions a painting stroke takes from `response` this frame, each with whether
/// it starts a stroke. egui recognises a drag only once the pointer has moved, so a stroke
/// starts where the button was pressed, then follows the pointer; a click is a one-point stroke.
/// The document with its input files (file parameters, files inside data blocks) resolved
/// against the graph file's folder, as the CLI reads them. The editor evaluates no sinks,
/// so output paths are left as written.
fn graph_for_evaluation(registry: &Registry, state: &EditorState) -> crate::graph::Graph {
    let graph = state.graph();
    let Some(dir) = state.path().and_then(Path::parent) else {
        return graph.clone();
    };
    let policy = crate::eval::PathPolicy {
        graph_dir: dir.to_path_buf(),
        output_dir: dir.to_path_buf(),
        allow_any: true,
    };
    // With `allow_any` nothing is refused; the fall-back keeps the document as it is.
    crate::eval::resolve_files(registry, graph, &policy).unwrap_or_else(|_| graph.clone())
}

fn stroke_points(ui: &egui::Ui, response: &egui::Response) -> Vec<(egui::Pos2, bool)> {
    let mut points = Vec::new();
    if response.drag_started() || response.clicked() {
        let origin = ui.input(|i| i.pointer.press_origin());
        points.extend(
            origin
                .or(response.interact_pointer_pos())
                .map(|p| (p, true)),
        );
    }
    if response.dragged() {
        points.extend(response.interact_pointer_pos().map(|p| (p, false)));
    }
    points
}

/// The first and last key-frame times of the document, when it has keys.
fn key_range(state: &EditorState) -> Option<(f64, f64)> {
    let ts: Vec<f64> = state
        .graph()
        .nodes()
        .flat_map(|n| n.keys.values().flatten().map(|k| k.t))
        .collect();
    let lo = ts.iter().cloned().reduce(f64::min)?;
    let hi = ts.iter().cloned().reduce(f64::max)?;
    Some((lo.min(0.0), if hi > lo { hi } else { lo + 48.0 }))
}

/// An egui picture of `r` as the viewer shows it.
fn colour_image(r: &Raster, channel: Channel, stops: f32) -> egui::ColorImage {
    let pixels = to_srgb8(r, channel, stops)
        .into_iter()
        .map(|p| egui::Color32::from_rgb(p[0], p[1], p[2]))
        .collect();
    egui::ColorImage::new([r.width as usize, r.height as usize], pixels)
}

impl EditorApp {
    fn viewer(&mut self, ui: &mut egui::Ui) {
        let viewed = self.viewed();
        ui.horizontal(|ui| {
            ui.heading("Viewer");
            ui.label(viewed.as_deref().unwrap_or("(nothing selected)"));
            if self.active_pin.is_none() && viewed.is_some() && viewed != self.selected {
                if let Some(s) = &self.selected {
                    ui.weak(format!("(the nearest picture downstream of {s})"));
                }
            }
        });
        ui.horizontal(|ui| {
            for i in 0..9 {
                let label = format!("{}", i + 1);
                let text = match &self.pins[i] {
                    Some(id) => format!("pin {} → {id} (key {})", i + 1, i + 1),
                    None => format!("pin {}: Shift+{} pins the selected node", i + 1, i + 1),
                };
                let on = self.active_pin == Some(i);
                let b = ui
                    .add_enabled(self.pins[i].is_some(), egui::Button::selectable(on, label))
                    .on_hover_text(text);
                if b.clicked() {
                    self.active_pin = if on { None } else { Some(i) };
                }
            }
        });
        ui.horizontal(|ui| {
            let ports: Vec<String> = self
                .pictures
                .as_ref()
                .map(|(_, p)| p.iter().map(|(n, _)| n.clone()).collect())
                .unwrap_or_default();
            let current = self
                .view_port
                .clone()
                .filter(|p| ports.contains(p))
                .or_else(|| ports.first().cloned());
            egui::ComboBox::from_id_salt("view-port")
                .selected_text(current.clone().unwrap_or_else(|| "-".into()))
                .show_ui(ui, |ui| {
                    for p in &ports {
                        if ui
                            .selectable_label(current.as_ref() == Some(p), p)
                            .clicked()
                        {
                            self.view_port = Some(p.clone());
                            self.view_tex = None;
                        }
                    }
                });
            egui::ComboBox::from_id_salt("view-channel")
                .selected_text(self.channel.label())
                .show_ui(ui, |ui| {
                    for c in Channel::ALL {
                        if ui.selectable_label(self.channel == c, c.label()).clicked() {
                            self.channel = c;
                            self.view_tex = None;
                        }
                    }
                });
            ui.label("exposure");
            if ui
                .add(
                    egui::DragValue::new(&mut self.exposure)
                        .range(-16.0..=16.0)
                        .speed(0.05)
                        .suffix(" stops"),
                )
                .changed()
            {
                self.view_tex = None;
            }
            ui.selectable_value(&mut self.zoom, Zoom::Fit, "Fit");
            ui.selectable_value(&mut self.zoom, Zoom::One, "1:1");
        });
        // Borrow the pictures out for the frame instead of copying them.
        let Some((node, pictures)) = self.pictures.take() else {
            ui.label("(no picture yet)");
            return;
        };
        self.show_picture(ui, &node, &pictures);
        self.pictures = Some((node, pictures));
    }

    fn show_picture(&mut self, ui: &mut egui::Ui, node: &str, pictures: &[(String, Raster)]) {
        let port = self
            .view_port
            .clone()
            .filter(|p| pictures.iter().any(|(n, _)| n == p))
            .or_else(|| pictures.first().map(|(n, _)| n.clone()));
        let Some((port, raster)) = port.and_then(|p| pictures.iter().find(|(n, _)| *n == p)) else {
            ui.label("(this node has no picture output)");
            return;
        };
        let tex_key = format!("{node}.{port}:{:?}:{}", self.channel, self.exposure);
        if self.view_tex.as_ref().is_none_or(|(k, _)| *k != tex_key) {
            let image = colour_image(raster, self.channel, self.exposure);
            let tex = ui
                .ctx()
                .load_texture("viewer", image, egui::TextureOptions::NEAREST);
            self.view_tex = Some((tex_key, tex));
        }
        let Some((_, tex)) = &self.view_tex else {
            return;
        };
        let size = egui::vec2(raster.width as f32, raster.height as f32);
        let shown = match self.zoom {
            Zoom::Fit => size * (ui.available_width() / size.x).min(300.0 / size.y),
            Zoom::One => size,
        };
        let image = egui::Image::new(tex)
            .fit_to_exact_size(shown)
            .sense(egui::Sense::click_and_drag());
        let response = match self.zoom {
            Zoom::Fit => ui.add(image),
            Zoom::One => {
                egui::ScrollArea::both()
                    .max_height(300.0)
                    .show(ui, |ui| ui.add(image))
                    .inner
            }
        };
        let response = response.on_hover_cursor(egui::CursorIcon::Crosshair);
        response.widget_info(|| {
            egui::WidgetInfo::labeled(egui::WidgetType::Other, true, "viewer picture")
        });
        if let Some(pos) = response.hover_pos() {
            let rel = (pos - response.rect.min) / response.rect.size();
            let x = (rel.x * raster.width as f32).floor().max(0.0) as u32;
            let y = (rel.y * raster.height as f32).floor().max(0.0) as u32;
            self.probe = probe(pictures, x, y);
        }
        let size = (raster.width, raster.height);
        let at = |p: egui::Pos2| {
            let rel = (p - response.rect.min) / response.rect.size();
            [rel.x * size.0 as f32, rel.y * size.1 as f32]
        };
        let selected = self
            .selected
            .as_ref()
            .and_then(|id| self.state.graph().node(id))
            .and_then(|n| Some((n.id.clone(), self.registry.get(&n.kind)?.clone())));
        let tool = |t: EditorTool| selected.as_ref().is_some_and(|(_, k)| k.has_tool(t));
        let id = selected.as_ref().map(|(id, _)| id.clone());
        match id {
            Some(id) if tool(EditorTool::LayerList) && self.tf.arm_3d => {
                if let (true, Some(p)) = (response.clicked(), response.interact_pointer_pos()) {
                    let [x, y] = at(p);
                    let px = ((x as u32).min(size.0 - 1), (y as u32).min(size.1 - 1));
                    self.add_3d_constraint(&id, px, size);
                }
            }
            Some(id) if tool(EditorTool::StrokePainting) => {
                if self.strokes.armed {
                    for (p, start) in stroke_points(ui, &response) {
                        if let Err(e) = super::stroke_panel::paint(
                            &self.state,
                            &id,
                            &mut self.strokes,
                            at(p),
                            size,
                            start,
                        ) {
                            self.status = e;
                        }
                    }
                }
                // The waiting strokes, drawn over the picture.
                let painter = ui.painter_at(response.rect);
                let r = response.rect;
                for (s, (w, h)) in
                    super::stroke_panel::pending_in(&self.state, &id, &self.strokes, size)
                {
                    let (w, h) = (w.max(1) as f32, h.max(1) as f32);
                    let to = |q: &[f32; 2]| {
                        r.min + egui::vec2(q[0] / w * r.width(), q[1] / h * r.height())
                    };
                    let c8 = |v: f32| (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
                    let c = if s.erase {
                        egui::Color32::from_black_alpha(160)
                    } else {
                        egui::Color32::from_rgba_unmultiplied(
                            c8(s.colour[0]),
                            c8(s.colour[1]),
                            c8(s.colour[2]),
                            160,
                        )
                    };
                    let width = (s.width / w * r.width()).max(1.0);
                    let pts: Vec<egui::Pos2> = s.points.iter().map(to).collect();
                    if pts.len() == 1 {
                        painter.circle_filled(pts[0], width * 0.5, c);
                    } else {
                        painter.add(egui::Shape::line(pts, egui::Stroke::new(width, c)));
                    }
                }
            }
            Some(id) if tool(EditorTool::SplatBrush) => {
                self.brush_in_viewer(ui, &response, &id, size);
            }
            _ => {}
        }
        ui.label(egui::RichText::new(&self.probe).monospace().small());
    }

    fn parameters(&mut self, ui: &mut egui::Ui) {
        let Some(id) = self.selected.clone() else {
            ui.label("Select a node to edit its parameters.");
            return;
        };
        let Some(node) = self.state.graph().node(&id).cloned() else {
            return;
        };
        let Some(schema) = self.state.catalog().get(&node.kind) else {
            return;
        };
        ui.heading(format!("{id} - {}", node.kind));
        ui.label(schema.doc);
        if let Some(err) = self.reports.get(&id).and_then(|r| r.error.clone()) {
            ui.colored_label(super::panel::ERROR, err);
        }
        ui.separator();
        for p in schema.params {
            let current = self
                .state
                .graph()
                .param_at(self.state.catalog(), &id, p.name, self.time)
                .unwrap_or(p.default.value());
            let mut changed: Option<ParamValue> = None;
            let mut toggle_key = false;
            ui.horizontal(|ui| {
                ui.label(p.name)
                    .on_hover_text(format!("{} ({})", p.doc, p.expected()));
                match (&p.kind, &current) {
                    (ParamKind::Float, ParamValue::Float(v)) => {
                        let mut x = *v;
                        let speed = ((p.max - p.min) / 500.0).clamp(1e-4, 1.0);
                        if ui
                            .add(
                                egui::DragValue::new(&mut x)
                                    .range(p.min..=p.max)
                                    .speed(speed),
                            )
                            .on_hover_text(p.doc)
                            .changed()
                        {
                            changed = Some(ParamValue::Float(x));
                        }
                    }
                    (ParamKind::Int, ParamValue::Int(v)) => {
                        let mut x = *v;
                        if ui
                            .add(egui::DragValue::new(&mut x).range(p.min as i64..=p.max as i64))
                            .on_hover_text(p.doc)
                            .changed()
                        {
                            changed = Some(ParamValue::Int(x));
                        }
                    }
                    (ParamKind::Bool, ParamValue::Bool(v)) => {
                        let mut x = *v;
                        if ui.checkbox(&mut x, "").on_hover_text(p.doc).changed() {
                            changed = Some(ParamValue::Bool(x));
                        }
                    }
                    (ParamKind::Enum(names), ParamValue::Enum(v)) => {
                        egui::ComboBox::from_id_salt(p.name)
                            .selected_text(v.as_str())
                            .show_ui(ui, |ui| {
                                for n in *names {
                                    if ui.selectable_label(v == n, *n).clicked() {
                                        changed = Some(ParamValue::Enum(n.to_string()));
                                    }
                                }
                            });
                    }
                    (ParamKind::Text, ParamValue::Text(v)) => {
                        let mut x = v.clone();
                        if ui.text_edit_singleline(&mut x).lost_focus() && &x != v {
                            changed = Some(ParamValue::Text(x));
                        }
                    }
                    (ParamKind::Colour, ParamValue::Colour(c)) => {
                        let mut rgba = [c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32];
                        if ui.color_edit_button_rgba_unmultiplied(&mut rgba).changed() {
                            changed = Some(ParamValue::Colour(rgba.map(|x| x as f64)));
                        }
                    }
                    (ParamKind::Vec3, ParamValue::Vec3(c)) => {
                        let mut v = *c;
                        let mut edited = false;
                        for x in &mut v {
                            edited |= ui
                                .add(egui::DragValue::new(x).range(p.min..=p.max).speed(0.05))
                                .on_hover_text(p.doc)
                                .changed();
                        }
                        if edited {
                            changed = Some(ParamValue::Vec3(v));
                        }
                    }
                    _ => {
                        ui.label(current.to_string());
                    }
                }
                if matches!(p.kind, ParamKind::Float | ParamKind::Int) {
                    let keys = node.keys.get(p.name);
                    let here = keys.is_some_and(|k| k.iter().any(|k| k.t == self.time));
                    let (mark, tip) = match (keys.is_some(), here) {
                        (_, true) => ("◆", "key at this frame: click to remove it"),
                        (true, false) => ("◇", "animated: click to add a key at this frame"),
                        (false, _) => ("○", "click to key this parameter at this frame"),
                    };
                    if ui
                        .add(egui::Button::new(mark).small())
                        .on_hover_text(tip)
                        .clicked()
                    {
                        toggle_key = true;
                    }
                }
            });
            let keys = node.keys.get(p.name).cloned();
            let numeric = |v: &ParamValue| match v {
                ParamValue::Float(x) => Some(*x),
                ParamValue::Int(x) => Some(*x as f64),
                _ => None,
            };
            let result = if toggle_key {
                let mut k = keys.unwrap_or_default();
                if let Some(i) = k.iter().position(|k| k.t == self.time) {
                    k.remove(i);
                } else if let Some(v) = numeric(&current) {
                    k.push(Key {
                        t: self.time,
                        v,
                        interp: Interp::Linear,
                    });
                }
                Some(self.state.set_keys(&id, p.name, k))
            } else if let Some(v) = changed {
                // A keyed parameter edits (or adds) its key at this frame, as in Blender.
                match (keys, numeric(&v)) {
                    (Some(mut k), Some(x)) => {
                        match k.iter_mut().find(|k| k.t == self.time) {
                            Some(key) => key.v = x,
                            None => k.push(Key {
                                t: self.time,
                                v: x,
                                interp: Interp::Linear,
                            }),
                        }
                        Some(self.state.set_keys(&id, p.name, k))
                    }
                    _ => Some(self.state.set_param(&id, p.name, v)),
                }
            } else {
                None
            };
            if let Some(Err(e)) = result {
                self.status = e.to_string();
            }
        }
        let current: BTreeMap<String, String> = schema
            .params
            .iter()
            .map(|p| {
                let v = self
                    .state
                    .graph()
                    .param_at(self.state.catalog(), &id, p.name, self.time)
                    .unwrap_or(p.default.value());
                (p.name.to_string(), v.to_string())
            })
            .collect();
        if let Some(setting) = self.bench.show(ui, &node.kind, &current) {
            self.use_measured(&id, &setting);
        }
        // The tools the node's declaration names, in its order.
        let tools = self
            .registry
            .get(&node.kind)
            .map_or(&[][..], |k| k.decl().tools);
        for tool in tools {
            let message = match tool {
                EditorTool::LayerList => {
                    super::tf_panel::show(ui, &mut self.state, &id, self.time, &mut self.tf)
                }
                EditorTool::StrokePainting => super::stroke_panel::show(
                    ui,
                    &mut self.state,
                    &id,
                    &mut self.strokes,
                    VIEW_SIZE,
                ),
                // A volume that is also brushed shows the brush once.
                EditorTool::SplatBrush => super::brush_panel::show(
                    ui,
                    &self.registry,
                    &mut self.state,
                    &id,
                    &mut self.brush,
                ),
                EditorTool::SplatVolume => None,
            };
            if let Some(m) = message {
                self.status = m;
            }
        }
    }

    /// The 3D brush over the viewer picture (`size` pixels shown in `response.rect`) while it is
    /// armed: the plane's tint, the outline under the pointer, and painting on drags.
    fn brush_in_viewer(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        selected: &str,
        size: (u32, u32),
    ) {
        use super::brush_panel as brush;
        if !self.brush.armed {
            return;
        }
        let Some(target) =
            brush::target_for(&self.registry, self.state.graph(), &self.brush, selected)
        else {
            return;
        };
        let view = match self
            .brush
            .view_for(&self.registry, self.state.graph(), &target, size)
        {
            Ok(v) => v.clone(),
            Err(e) => {
                self.status = e;
                return;
            }
        };
        let r = response.rect;
        let at = |p: egui::Pos2| {
            let rel = (p - r.min) / r.size();
            [rel.x * size.0 as f32, rel.y * size.1 as f32]
        };
        // The plane: pixels whose surface lies behind it are tinted.
        let tex_key = format!("{}@{}", view.key, self.brush.depth);
        if self.brush_tex.as_ref().is_none_or(|(k, _)| *k != tex_key) {
            let tint = egui::Color32::from_rgba_unmultiplied(60, 130, 255, 100);
            let pixels = brush::plane_mask(&view, self.brush.depth)
                .iter()
                .map(|m| if *m { tint } else { egui::Color32::TRANSPARENT })
                .collect();
            let image = egui::ColorImage::new([view.size.0 as usize, view.size.1 as usize], pixels);
            let tex = ui
                .ctx()
                .load_texture("brush-plane", image, egui::TextureOptions::NEAREST);
            self.brush_tex = Some((tex_key, tex));
        }
        let Some((_, tex)) = &self.brush_tex else {
            return;
        };
        let painter = ui.painter_at(r);
        painter.image(
            tex.id(),
            r,
            egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
            egui::Color32::WHITE,
        );
        self.brush.hover = response.hover_pos().map(at);
        if let Some(p) = response.hover_pos() {
            let [rx, ry] = brush::outline_radii(&self.brush, &view.camera, view.size);
            let scale = r.width() / size.0.max(1) as f32;
            let colour = if self.brush.erase {
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
        for (p, start) in stroke_points(ui, response) {
            if let Err(e) = brush::paint(
                &mut self.state,
                &mut self.brush,
                &target,
                &view.camera,
                at(p),
                size,
                start,
            ) {
                self.status = e;
            }
        }
        if response.drag_stopped() || response.clicked() {
            brush::end_stroke(&mut self.state, &mut self.brush);
        }
    }

    /// A click in the viewer while a TF's 3D constraint is armed: pick the surface under the
    /// pixel (an evaluation on this thread) and add a constraint anchored to it.
    pub fn add_3d_constraint(&mut self, id: &str, pixel: (u32, u32), size: (u32, u32)) {
        use crate::eval::pick::pick;
        use crate::nodes::transfer_function::{Anchor, Constraint};
        let result = (|| -> Result<String, String> {
            let gpu = Gpu::shared().map_err(|e| e.to_string())?;
            let mut ev = crate::eval::Evaluator::new(self.registry.clone(), gpu);
            let opts = crate::eval::EvalOptions {
                time: self.time,
                size,
                ..Default::default()
            };
            let p = pick(&mut ev, self.state.graph(), Some(id), pixel, &opts)
                .map_err(|e| e.to_string())?;
            let s = p
                .surface
                .ok_or("no surface under this pixel (sky): nothing to anchor to")?;
            let tf = p.tf.ok_or("not a TransferFunction")?;
            let mut data = self
                .state
                .node_data::<crate::nodes::transfer_function::TfData>(id)?;
            let stack = super::tf_panel::editable(&mut data, self.time)
                .ok_or("add a key at this frame to edit the stack")?;
            let c = Constraint {
                at: [tf.u, tf.v],
                colour: self.tf.brush,
                anchor: Some(Anchor {
                    object: s.object.clone(),
                    triangle: s.triangle,
                    bary: s.bary,
                }),
            };
            self.tf.layer = super::tf_panel::add_constraint(stack, self.tf.layer, c);
            self.state.store_node_data(id, &data, None)?;
            Ok(format!(
                "3D constraint on {:?} triangle {} at V̄ {:.3}, depth {:.2} m",
                s.object, s.triangle, p.visibility, p.depth
            ))
        })();
        self.status = result.unwrap_or_else(|e| e);
    }

    fn timeline(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            let play = if self.playing { "⏸" } else { "▶" };
            if ui
                .button(play)
                .on_hover_text("play / pause (Space)")
                .clicked()
            {
                self.playing = !self.playing;
            }
            ui.label("frame");
            ui.add(egui::DragValue::new(&mut self.time).speed(0.25));
            ui.label("range");
            ui.add(egui::DragValue::new(&mut self.range.0).speed(1.0));
            ui.add(egui::DragValue::new(&mut self.range.1).speed(1.0));
            ui.label("fps");
            ui.add(egui::DragValue::new(&mut self.fps).range(1.0..=120.0));
            if self.range.1 <= self.range.0 {
                self.range.1 = self.range.0 + 1.0;
            }
            // The scrub bar with key-frame marks of the selected node (all nodes when none).
            let (rect, response) = ui.allocate_exact_size(
                egui::vec2(ui.available_width().max(100.0), 22.0),
                egui::Sense::click_and_drag(),
            );
            let span = (self.range.1 - self.range.0) as f32;
            let x_of = |t: f64| rect.left() + ((t - self.range.0) as f32 / span) * rect.width();
            let painter = ui.painter_at(rect);
            painter.rect_filled(rect, 3.0, ui.visuals().extreme_bg_color);
            for n in self.state.graph().nodes() {
                if self.selected.as_ref().is_some_and(|s| *s != n.id) {
                    continue;
                }
                for k in n.keys.values().flatten() {
                    let x = x_of(k.t);
                    painter.line_segment(
                        [
                            egui::pos2(x, rect.top() + 3.0),
                            egui::pos2(x, rect.bottom() - 3.0),
                        ],
                        egui::Stroke::new(2.0, egui::Color32::from_rgb(240, 200, 60)),
                    );
                }
                // Key-frames inside the node's data block (a layer stack's), as its kind reads
                // them.
                let kind = self.registry.get(&n.kind);
                let data_keys = match (kind, n.data.as_ref()) {
                    (Some(k), Some(d)) => k.data_key_times(d),
                    _ => Vec::new(),
                };
                for t in data_keys {
                    let x = x_of(t);
                    painter.circle_filled(
                        egui::pos2(x, rect.center().y),
                        4.0,
                        egui::Color32::from_rgb(230, 90, 220),
                    );
                }
            }
            let x = x_of(self.time);
            painter.line_segment(
                [egui::pos2(x, rect.top()), egui::pos2(x, rect.bottom())],
                egui::Stroke::new(2.0, egui::Color32::from_rgb(90, 170, 255)),
            );
            if let Some(pos) = response.interact_pointer_pos() {
                let f = ((pos.x - rect.left()) / rect.width()).clamp(0.0, 1.0) as f64;
                self.time = (self.range.0 + f * span as f64).round();
            }
        });
    }

    fn play(&mut self, ctx: &egui::Context) {
        if !self.playing {
            return;
        }
        let dt = ctx.input(|i| i.stable_dt).min(0.1) as f64;
        self.time += dt * self.fps;
        if self.time > self.range.1 {
            self.time = self.range.0;
        }
        ctx.request_repaint();
    }
}

impl EditorApp {
    /// Ids of the nodes selected on the canvas.
    fn selection(&self, ctx: &egui::Context) -> Vec<String> {
        get_selected_nodes(egui::Id::new("tyndall-canvas"), ctx)
            .into_iter()
            .filter_map(|n| self.snarl.get_node(n).cloned())
            .collect()
    }

    /// The add-node catalog: a search field and the kinds by category; a click adds the node
    /// near the canvas's top-left and selects it.
    fn catalog(&mut self, ui: &mut egui::Ui) {
        ui.heading("Add node");
        ui.horizontal(|ui| {
            let label = ui.label("Find");
            ui.add(egui::TextEdit::singleline(&mut self.search).hint_text("node or category"))
                .labelled_by(label.id);
        });
        let needle = self.search.to_lowercase();
        let mut by_category: BTreeMap<&str, Vec<(&str, &str)>> = BTreeMap::new();
        for s in self.state.catalog().iter() {
            if needle.is_empty()
                || s.kind.to_lowercase().contains(&needle)
                || s.category.to_lowercase().contains(&needle)
            {
                by_category
                    .entry(s.category)
                    .or_default()
                    .push((s.kind, s.doc));
            }
        }
        for (category, kinds) in by_category {
            egui::CollapsingHeader::new(category)
                .open((!needle.is_empty()).then_some(true))
                .show(ui, |ui| {
                    for (kind, doc) in kinds {
                        if ui.button(kind).on_hover_text(doc).clicked() {
                            let n = self.state.graph().nodes().count() as f32;
                            match self
                                .state
                                .add_node(kind, [40.0 + 20.0 * n, 40.0 + 10.0 * n])
                            {
                                Ok(id) => self.selected = Some(id),
                                Err(e) => self.status = e.to_string(),
                            }
                        }
                    }
                });
        }
    }

    /// The preset browser: `graphs/` and the user folder, with thumbnails (the preset's
    /// `NAME.png` beside it, else its render under `docs/`), load / merge, save.
    fn presets_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Presets");
        if self.presets.is_empty() || ui.small_button("refresh").clicked() {
            self.presets = list_presets(&self.preset_folders);
        }
        ui.horizontal(|ui| {
            ui.add(
                egui::TextEdit::singleline(&mut self.preset_name)
                    .hint_text("name")
                    .desired_width(110.0),
            );
            let selection = self.selection(ui.ctx());
            let folder = user_preset_folder();
            let save = |ids: &[String], what: &str| {
                let Some(dir) = folder.clone() else {
                    return "no user preset folder (set TYNDALL_PRESETS)".to_string();
                };
                let name = self.preset_name.trim();
                if name.is_empty() || name.contains(['/', '\\']) {
                    return "give the preset a name (no slashes)".to_string();
                }
                let path = dir.join(format!("{name}.ron"));
                let res = std::fs::create_dir_all(&dir)
                    .map_err(|e| e.to_string())
                    .and_then(|()| {
                        self.state
                            .save_preset(ids, &path)
                            .map_err(|e| e.to_string())
                    });
                match res {
                    Ok(()) => format!("saved {what} as {}", path.display()),
                    Err(e) => e,
                }
            };
            if ui
                .button("Save graph")
                .on_hover_text("save the whole graph as a preset in the user folder")
                .clicked()
            {
                let all: Vec<String> = self.state.graph().nodes().map(|n| n.id.clone()).collect();
                self.status = save(&all, "the graph");
                self.presets.clear();
            }
            if ui
                .add_enabled(!selection.is_empty(), egui::Button::new("Save selection"))
                .clicked()
            {
                self.status = save(&selection, "the selection");
                self.presets.clear();
            }
        });
        let entries = self.presets.clone();
        egui::ScrollArea::vertical()
            .id_salt("presets")
            .show(ui, |ui| {
                for p in entries {
                    ui.horizontal(|ui| {
                        match self.preset_thumb(ui.ctx(), &p.path) {
                            Some(t) => {
                                ui.add(
                                    egui::Image::new(&t).fit_to_exact_size(egui::vec2(64.0, 36.0)),
                                );
                            }
                            None => {
                                let (r, _) = ui.allocate_exact_size(
                                    egui::vec2(64.0, 36.0),
                                    egui::Sense::hover(),
                                );
                                ui.painter()
                                    .rect_filled(r, 2.0, ui.visuals().faint_bg_color);
                            }
                        }
                        ui.vertical(|ui| {
                            ui.label(&p.name);
                            ui.horizontal(|ui| {
                                if ui.small_button("Load").clicked() {
                                    self.load_preset(&p.path);
                                }
                                if ui.small_button("Merge").clicked() {
                                    self.merge_preset(&p.path);
                                }
                            });
                        });
                    });
                }
            });
    }

    fn preset_thumb(&mut self, ctx: &egui::Context, path: &Path) -> Option<egui::TextureHandle> {
        if let Some(t) = self.preset_thumbs.get(path) {
            return t.clone();
        }
        let tex = super::preset_thumbnail(path)
            .and_then(|p| image::open(p).ok())
            .map(|img| {
                let img = img.thumbnail(128, 72).to_rgba8();
                let size = [img.width() as usize, img.height() as usize];
                let image = egui::ColorImage::from_rgba_unmultiplied(size, img.as_raw());
                ctx.load_texture(
                    format!("preset-{}", path.display()),
                    image,
                    egui::TextureOptions::LINEAR,
                )
            });
        self.preset_thumbs.insert(path.to_path_buf(), tex.clone());
        tex
    }

    /// Replace the document with a preset (undoable; the file path stays the current one).
    pub fn load_preset(&mut self, path: &Path) {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) => {
                self.status = format!("{}: {e}", path.display());
                return;
            }
        };
        let res = crate::graph::load_str(&text, path, self.state.catalog())
            .map_err(|e| e.to_string())
            .and_then(|fresh| {
                self.state
                    .apply(|g, _| {
                        *g = fresh;
                        Ok(())
                    })
                    .map_err(|e| e.to_string())
            });
        self.status = match res {
            Ok(()) => format!("loaded {}", path.display()),
            Err(e) => e,
        };
        self.frame_all = true;
    }

    /// Add a preset's nodes to the document with fresh ids (one undo step).
    pub fn merge_preset(&mut self, path: &Path) {
        let res = std::fs::read_to_string(path)
            .map_err(|e| e.to_string())
            .and_then(|t| {
                self.state
                    .paste(&t, [60.0, 60.0])
                    .map_err(|e| e.to_string())
            });
        self.status = match res {
            Ok(ids) => format!("merged {} node(s) from {}", ids.len(), path.display()),
            Err(e) => e,
        };
    }

    /// Keyboard shortcuts (when no text field has the keyboard) and clipboard events.
    fn shortcuts(&mut self, ctx: &egui::Context) {
        let typing = ctx.egui_wants_keyboard_input();
        let events = ctx.input(|i| i.events.clone());
        let selection = self.selection(ctx);
        for e in &events {
            match e {
                egui::Event::Copy | egui::Event::Cut if !typing && !selection.is_empty() => {
                    self.clipboard = self.state.copy(&selection);
                    ctx.copy_text(self.clipboard.clone());
                    if matches!(e, egui::Event::Cut) {
                        let _ = self.state.delete(&selection);
                    }
                    self.status = format!("copied {} node(s)", selection.len());
                }
                egui::Event::Paste(text) if !typing => {
                    let text = if text.trim_start().starts_with('(') {
                        text.clone()
                    } else {
                        self.clipboard.clone()
                    };
                    self.status = match self.state.paste(&text, [40.0, 40.0]) {
                        Ok(ids) => format!("pasted {} node(s)", ids.len()),
                        Err(e) => format!("nothing to paste: {e}"),
                    };
                }
                _ => {}
            }
        }
        let (undo, redo, save) = ctx.input(|i| {
            let cmd = i.modifiers.command;
            (
                cmd && i.key_pressed(egui::Key::Z) && !i.modifiers.shift,
                cmd && (i.key_pressed(egui::Key::Y)
                    || (i.modifiers.shift && i.key_pressed(egui::Key::Z))),
                cmd && i.key_pressed(egui::Key::S),
            )
        });
        if undo && !typing {
            self.state.undo();
        }
        if redo && !typing {
            self.state.redo();
        }
        if save {
            self.save();
        }
        if typing {
            return;
        }
        let keys = [
            egui::Key::Num1,
            egui::Key::Num2,
            egui::Key::Num3,
            egui::Key::Num4,
            egui::Key::Num5,
            egui::Key::Num6,
            egui::Key::Num7,
            egui::Key::Num8,
            egui::Key::Num9,
        ];
        ctx.input(|i| {
            for (slot, k) in keys.iter().enumerate() {
                if i.key_pressed(*k) && !i.modifiers.command {
                    if i.modifiers.shift {
                        if let Some(id) = self.selected.clone() {
                            self.pins[slot] = Some(id);
                            self.active_pin = Some(slot);
                        }
                    } else if self.pins[slot].is_some() {
                        self.active_pin = if self.active_pin == Some(slot) {
                            None
                        } else {
                            Some(slot)
                        };
                    }
                }
            }
            if i.key_pressed(egui::Key::F) && !i.modifiers.command {
                self.frame_all = true;
            }
            if i.key_pressed(egui::Key::Space) {
                self.playing = !self.playing;
            }
            if i.key_pressed(egui::Key::D) && i.modifiers.command && !selection.is_empty() {
                let _ = self.state.duplicate(&selection);
            }
            if (i.key_pressed(egui::Key::Delete) || i.key_pressed(egui::Key::Backspace))
                && !selection.is_empty()
            {
                let _ = self.state.delete(&selection);
            }
        });
    }

    /// Save to the document's file, or ask for one.
    pub fn save(&mut self) {
        if self.state.path().is_none() {
            self.save_as = Some("graphs/untitled.ron".into());
            return;
        }
        self.status = match self.state.save() {
            Ok(()) => "saved".into(),
            Err(e) => e.to_string(),
        };
    }
}

impl EditorApp {
    /// The recovery offer and the unsaved-changes prompt.
    fn dialogs(&mut self, ctx: &egui::Context) {
        if let Some(problem) = &self.gpu_problem {
            let mut open = true;
            egui::Window::new("No usable GPU adapter")
                .collapsible(false)
                .open(&mut open)
                .show(ctx, |ui| {
                    ui.label(problem);
                    ui.label("The graph can be edited and saved; pictures are off. `tyndall info` says more.");
                });
            if !open {
                self.gpu_problem = None;
            }
        }
        if let Some(mut path) = self.save_as.take() {
            let mut keep = true;
            egui::Window::new("Save as")
                .collapsible(false)
                .resizable(false)
                .show(ctx, |ui| {
                    ui.text_edit_singleline(&mut path);
                    ui.horizontal(|ui| {
                        if ui.button("Save").clicked() {
                            self.status = match self.state.save_as(Path::new(&path)) {
                                Ok(()) => format!("saved {path}"),
                                Err(e) => e.to_string(),
                            };
                            keep = false;
                        }
                        if ui.button("Cancel").clicked() {
                            keep = false;
                        }
                    });
                });
            if keep {
                self.save_as = Some(path);
            }
        }
        if let Some(side) = self.recovery.clone() {
            egui::Window::new("Recover unsaved changes?")
                .collapsible(false)
                .resizable(false)
                .show(ctx, |ui| {
                    ui.label(format!(
                        "An autosave newer than the graph was found: {}",
                        side.display()
                    ));
                    ui.horizontal(|ui| {
                        if ui.button("Recover").clicked() {
                            self.status = match self.state.recover(&side) {
                                Ok(()) => "recovered the autosave (not saved yet)".into(),
                                Err(e) => e.to_string(),
                            };
                            self.recovery = None;
                        }
                        if ui.button("Ignore").clicked() {
                            self.recovery = None;
                        }
                    });
                });
        }
        if ctx.input(|i| i.viewport().close_requested())
            && self.state.is_dirty()
            && !self.allow_close
        {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.confirm_quit = true;
        }
        if self.confirm_quit {
            egui::Window::new("Unsaved changes")
                .collapsible(false)
                .resizable(false)
                .show(ctx, |ui| {
                    ui.label("The graph has changes that are not saved.");
                    ui.horizontal(|ui| {
                        if ui.button("Save and quit").clicked() {
                            match self.state.save() {
                                Ok(()) => {
                                    self.allow_close = true;
                                    ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                                }
                                Err(e) => self.status = e.to_string(),
                            }
                            self.confirm_quit = false;
                        }
                        if ui.button("Discard and quit").clicked() {
                            self.allow_close = true;
                            self.confirm_quit = false;
                            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                        }
                        if ui.button("Cancel").clicked() {
                            self.confirm_quit = false;
                        }
                    });
                });
        }
    }
}

impl eframe::App for EditorApp {
    fn ui(&mut self, root: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = root.ctx().clone();
        self.dialogs(&ctx);
        self.shortcuts(&ctx);
        self.sync();
        self.play(&ctx);
        self.pump(&ctx);
        if let Err(e) = self.state.tick_autosave(Instant::now()) {
            self.status = e.to_string();
        }
        egui::Panel::top("bar").show(root, |ui| {
            ui.horizontal(|ui| {
                let title = self
                    .state
                    .path()
                    .and_then(|p| p.file_name())
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "untitled".into());
                ui.strong(format!(
                    "Tyndall — {title}{}",
                    if self.state.is_dirty() { " •" } else { "" }
                ));
                if ui.button("Undo").on_hover_text("Ctrl+Z").clicked() {
                    self.state.undo();
                }
                if ui
                    .button("Redo")
                    .on_hover_text("Ctrl+Y / Ctrl+Shift+Z")
                    .clicked()
                {
                    self.state.redo();
                }
                if ui.button("Save").on_hover_text("Ctrl+S").clicked() {
                    self.save();
                }
                if ui.button("Save as…").clicked() {
                    self.save_as = Some(
                        self.state
                            .path()
                            .map(|p| p.display().to_string())
                            .unwrap_or_else(|| "graphs/untitled.ron".into()),
                    );
                }
                if ui
                    .button("Frame all")
                    .on_hover_text("F, or double-click the canvas")
                    .clicked()
                {
                    self.frame_all = true;
                }
                ui.separator();
                if !self.idle() {
                    ui.spinner();
                    if let Some(p) = &self.progress {
                        ui.label(format!("{} {}/{} {}", p.node, p.done, p.total, p.message));
                    }
                }
                ui.label(&self.status);
            });
        });
        egui::Panel::bottom("timeline").show(root, |ui| self.timeline(ui));
        egui::Panel::left("library")
            .default_size(230.0)
            .show(root, |ui| {
                egui::ScrollArea::vertical()
                    .id_salt("catalog")
                    .max_height(ui.available_height() * 0.45)
                    .show(ui, |ui| self.catalog(ui));
                ui.separator();
                self.presets_panel(ui);
            });
        egui::Panel::right("params")
            .default_size(380.0)
            .show(root, |ui| {
                self.viewer(ui);
                ui.separator();
                egui::ScrollArea::vertical()
                    .id_salt("parameters")
                    .show(ui, |ui| self.parameters(ui));
            });
        egui::CentralPanel::default().show(root, |ui| {
            let canvas = egui::Id::new("tyndall-canvas");
            // Frame from the document's positions with a nominal node size, so the framing does
            // not depend on when thumbnails (which change node sizes) arrive.
            let frame = if self.frame_all && self.snarl.nodes_pos_ids().next().is_some() {
                self.frame_all = false;
                let bb = self
                    .snarl
                    .nodes_pos_ids()
                    .map(|(_, pos, _)| egui::Rect::from_min_size(pos, egui::vec2(220.0, 140.0)))
                    .fold(egui::Rect::NOTHING, |a, r| a.union(r));
                Some((bb, ui.max_rect()))
            } else {
                None
            };
            let mut view = CanvasView {
                state: &mut self.state,
                status: &mut self.status,
                reports: &self.reports,
                show_timings: self.show_timings,
                thumbs: &self.thumbs,
                frame,
            };
            SnarlWidget::new()
                .id(canvas)
                .show(&mut self.snarl, &mut view, ui);
            let selected = get_selected_nodes(canvas, ui.ctx());
            if let Some(n) = selected.first() {
                self.selected = self.snarl.get_node(*n).cloned();
            }
            // Node moves become one undoable change when the drag ends.
            if ui.input(|i| i.pointer.any_released()) {
                let moved: Vec<(String, [f32; 2])> = self
                    .snarl
                    .nodes_pos_ids()
                    .filter_map(|(_, pos, id)| {
                        let doc = self.state.graph().node(id)?.pos;
                        (doc != Some([pos.x, pos.y])).then(|| (id.clone(), [pos.x, pos.y]))
                    })
                    .collect();
                if !moved.is_empty() {
                    let _ = self.state.apply(|g, _| {
                        for (id, p) in &moved {
                            g.set_pos(id, Some(*p))?;
                        }
                        Ok(())
                    });
                }
            }
        });
    }
}

/// Open the editor window on `path` (or an empty graph).
pub fn run(path: Option<PathBuf>) -> Result<(), String> {
    let registry = Arc::new(crate::nodes::registry());
    let state = match &path {
        Some(p) => EditorState::open(registry.catalog().clone(), p).map_err(|e| e.to_string())?,
        None => EditorState::new(registry.catalog().clone()),
    };
    let mut app = EditorApp::new(state, registry.clone());
    app.recovery = path.as_deref().and_then(EditorState::recoverable);
    // Start on the picture: the node feeding the graph's first output, else the last node.
    let g = app.state.graph();
    let sink = g
        .nodes()
        .find(|n| registry.get(&n.kind).is_some_and(|k| k.is_sink()));
    app.selected = sink
        .and_then(|n| g.source_of(&n.id, "image").map(|(src, _)| src.to_string()))
        .or_else(|| g.topo_order().last().cloned());
    let mut options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size([1400.0, 860.0])
            .with_title("Tyndall"),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    // The window is drawn on the adapter the evaluation uses where it can present to the
    // window (GL included), else on any that can; without one, the command fails with the
    // evaluation's own message.
    let want = app
        .gpu_problem
        .is_none()
        .then(Gpu::shared)
        .and_then(Result::ok)
        .map(|g| (g.info.name.clone(), g.info.backend));
    let problem = app.gpu_problem.clone();
    if let eframe::egui_wgpu::WgpuSetup::CreateNew(c) = &mut options.wgpu_options.wgpu_setup {
        c.native_adapter_selector = Some(Arc::new(move |adapters, surface| {
            let presents =
                |a: &&eframe::wgpu::Adapter| surface.is_none_or(|s| a.is_surface_supported(s));
            let same = |a: &&eframe::wgpu::Adapter| {
                let i = a.get_info();
                want.as_ref()
                    .is_some_and(|(n, b)| i.name == *n && i.backend == *b)
            };
            adapters
                .iter()
                .filter(presents)
                .find(same)
                .or_else(|| adapters.iter().find(presents))
                .cloned()
                .ok_or_else(|| {
                    problem
                        .clone()
                        .unwrap_or_else(|| "no GPU adapter can draw the editor window".into())
                })
        }));
    }
    let problem = app.gpu_problem.clone();
    // No adapter can even draw the window: the evaluation's own message, not eframe's.
    eframe::run_native("Tyndall", options, Box::new(|_cc| Ok(Box::new(app))))
        .map_err(|e| problem.unwrap_or_else(|| e.to_string()))
}
