//! The editor window: a node canvas (egui-snarl, a view of the document) with per-node
//! thumbnails and timings, a viewer (pins 1–9, channel, exposure, fit/1:1, pixel probe), the
//! parameters panel with key-frame toggles, a timeline, a preset browser and the add-node
//! catalog. Evaluation runs on a worker thread ([`super::worker`]); the window never waits.

mod commands;
mod panels;
mod parameters;
mod presets;
pub mod pump;
mod scope;
pub mod shown;
mod timeline;
mod viewer;
pub mod viewer_colour;

pub use presets::user_preset_folder;
use timeline::key_range;
use viewer::colour_image;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use eframe::egui;
use egui_snarl::ui::{get_selected_nodes, SnarlWidget};
use egui_snarl::Snarl;

use super::canvas::CanvasView;
use super::view::Channel;
use super::worker::{NodeReport, Picture, Request, Worker};
use super::{list_presets, EditorState, PresetEntry};
use tyndall_engine::eval::Registry;

use crate::Tools;
use tyndall_engine::gpu::Gpu;
use tyndall_engine::graph::{save_string, Interp, Key, ParamKind, ParamValue};
use tyndall_engine::io::Raster;

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
    /// Every output's type in the document shown, resolved when it last changed (the canvas
    /// draws every pin each frame; one resolution per pin would be quadratic in a chain).
    port_types: BTreeMap<(String, String), tyndall_engine::graph::PortType>,
    /// Id of the node shown in the parameters panel (and the viewer unless a pin is active).
    pub selected: Option<String>,
    /// Last message (refused connection, save result…).
    pub status: String,
    /// Why evaluation could not start (no adapter qualifies): shown in a window, the same
    /// message the command line prints.
    pub gpu_problem: Option<String>,
    worker: Option<Worker>,
    requested: String,
    /// Proxy evaluation while a knob is dragged: the factor and what the viewer shows.
    pub proxy: pump::ProxyState,
    /// The worker's last report per node: ran / cached, time, error.
    pub reports: BTreeMap<String, NodeReport>,
    thumbs: BTreeMap<String, shown::ShownTexture>,
    /// Group instance → the flattened node its thumbnail comes from (the worker's).
    aliases: BTreeMap<String, String>,
    /// The viewed node's picture outputs, by port.
    pub pictures: Option<(String, Vec<(String, Picture)>)>,
    /// The A/B wipe (Nuke's): the node shown right of the split, over the viewed one (`W`
    /// toggles it with the node being viewed as B); `None`: off.
    pub wipe: Option<String>,
    /// Where the wipe splits the picture, 0 (all B) to 1 (all A).
    pub wipe_split: f32,
    /// The wipe node's picture outputs, by port.
    pub compare: Option<(String, Vec<(String, Picture)>)>,
    wipe_tex: Option<(String, shown::ShownTexture)>,
    view_port: Option<String>,
    view_tex: Option<(String, shown::ShownTexture)>,
    /// The window's device, while the evaluation shares it (pictures arrive as textures and
    /// are drawn by the display pass; see `app/shown.rs`).
    window: Option<shown::WindowGpu>,
    /// Whether the window's device was looked at (on the first frame).
    window_checked: bool,
    /// The pixel probe's texel reads in flight (textures only).
    probe_reads: shown::Probe,
    /// Viewer channel.
    pub channel: Channel,
    /// Viewer exposure in stops.
    pub exposure: f32,
    /// Viewer display, view and look (after the exposure).
    pub viewer_colour: viewer_colour::ViewerColour,
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
    /// The canvas's graph-to-screen transform, as last drawn.
    canvas_transform: egui::emath::TSTransform,
    /// Bumped when the canvas shows a new set of nodes: the canvas widget's id (its selection
    /// starts empty).
    canvas_gen: u64,
    /// The view to put back on the next frame (after `canvas_gen` changed).
    restore_transform: Option<egui::emath::TSTransform>,
    /// The scope the canvas was last built for.
    synced_scope: Vec<String>,
    /// Library groups listed in the Add-node menu (folder, reference); read again on refresh.
    library: Option<Vec<(PathBuf, String)>>,
    presets: Vec<PresetEntry>,
    preset_thumbs: BTreeMap<PathBuf, Option<egui::TextureHandle>>,
    preset_name: String,
    search: String,
    save_as: Option<String>,
    frame_all: bool,
    clipboard: String,
    /// Show per-node timings on the canvas (off for reproducible screenshots).
    pub show_timings: bool,
    /// Where the trace being recorded goes ("Record trace"), while one is.
    pub trace_file: Option<PathBuf>,
    /// An autosave left by a session that did not save, offered for recovery at start.
    pub recovery: Option<PathBuf>,
    /// The window was asked to close with unsaved changes: the save/discard/cancel prompt.
    pub confirm_quit: bool,
    /// The tools offered for the nodes that name them (see [`crate::tool`]), with their state.
    pub tools: Tools,
    /// The tools' jobs for the worker (asked while drawing, sent at the end of the frame).
    jobs: crate::Jobs,
    /// The node kinds.
    registry: Arc<Registry>,
    /// The newest progress report of a long-running node (shown while the worker is busy).
    pub progress: Option<tyndall_engine::eval::Progress>,
    /// How many times the GPU device was lost and evaluation restarted on a new one.
    pub device_restarts: u32,
    /// Measured speed/accuracy curves from `bench/results.csv`.
    bench: super::bench_panel::Curves,
    allow_close: bool,
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
        let adapter = gpu.as_ref().map(|g| g.describe());
        let worker = gpu.map(|g| Worker::start(registry.clone(), g));
        let mut preset_folders = vec![PathBuf::from("graphs")];
        preset_folders.extend(user_preset_folder());
        let range = key_range(&state).unwrap_or((0.0, 48.0));
        let mut bench = super::bench_panel::Curves::find(state.path());
        bench.adapter = adapter.clone();
        Self {
            bench,
            state,
            snarl: Snarl::new(),
            synced: None,
            port_types: BTreeMap::new(),
            selected: None,
            status: if worker.is_none() {
                "no GPU adapter: pictures are off".into()
            } else {
                String::new()
            },
            gpu_problem: None,
            worker,
            requested: String::new(),
            proxy: Default::default(),
            reports: BTreeMap::new(),
            thumbs: BTreeMap::new(),
            aliases: BTreeMap::new(),
            pictures: None,
            wipe: None,
            wipe_split: 0.5,
            compare: None,
            wipe_tex: None,
            view_port: None,
            view_tex: None,
            window: None,
            window_checked: false,
            probe_reads: shown::Probe::default(),
            channel: Channel::Rgb,
            exposure: 0.0,
            viewer_colour: Default::default(),
            zoom: Zoom::Fit,
            probe: String::new(),
            pins: Default::default(),
            active_pin: None,
            time: 0.0,
            range,
            fps: 24.0,
            playing: false,
            preset_folders,
            library: None,
            canvas_transform: Default::default(),
            canvas_gen: 0,
            restore_transform: None,
            synced_scope: Vec::new(),
            presets: Vec::new(),
            preset_thumbs: BTreeMap::new(),
            preset_name: String::new(),
            search: String::new(),
            save_as: None,
            frame_all: true,
            clipboard: String::new(),
            show_timings: true,
            trace_file: None,
            recovery: None,
            confirm_quit: false,
            allow_close: false,
            tools: Tools::new(),
            jobs: crate::Jobs::default(),
            registry,
            progress: None,
            device_restarts: 0,
        }
    }

    /// The same editor offering `tools` to the nodes that name them.
    pub fn with_tools(mut self, tools: Tools) -> Self {
        self.tools = tools;
        self
    }

    /// The state of the tool of type `T`, if it is offered (tests and scripts read it).
    pub fn tool<T: crate::Tool>(&self) -> Option<&T> {
        self.tools.get::<T>()
    }

    /// The state of the tool of type `T`, to change it.
    pub fn tool_mut<T: crate::Tool>(&mut self) -> Option<&mut T> {
        self.tools.get_mut::<T>()
    }

    /// Read the measured speed/accuracy curves from `path` (a `bench/results.csv`) instead of
    /// the one found next to the working directory or the graph.
    pub fn set_bench_results(&mut self, path: &Path) {
        let adapter = self.bench.adapter.take();
        self.bench = super::bench_panel::Curves::at(path);
        self.bench.adapter = adapter;
    }

    /// The node the viewer shows: the active pin's, else the selected one — or, when the
    /// selected node has no picture output (a volume, a scene), the nearest node downstream
    /// of it that has one (so painting a `BlendVolume` shows what it does).
    /// Ids are flattened (`look/fill` inside group `look`); pins keep the path they were made
    /// at, so a pin inside a group still shows after leaving it.
    pub fn viewed(&self) -> Option<String> {
        let g = self.state.graph();
        self.active_pin
            .and_then(|i| self.pins[i].clone())
            .filter(|id| self.state.node_at(id).is_some())
            .or_else(|| {
                let s = self.selected.clone()?;
                let local = if super::worker::picture_ports(g, &self.registry, &s).is_empty() {
                    super::worker::nearest_picture(g, &self.registry, &s).unwrap_or(s)
                } else {
                    s
                };
                Some(self.state.full_id(&local))
            })
    }

    /// The worker's report on node `id` of the graph shown (a group node: its inner nodes').
    pub fn report(&self, id: &str) -> Option<NodeReport> {
        let full = self.state.full_id(id);
        self.reports
            .get(&full)
            .cloned()
            .or_else(|| super::worker::group_report(&self.reports, &full))
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

    /// Where a point of the canvas's graph space (where nodes and their widgets lie, what
    /// accessibility rectangles report) is on the screen.
    pub fn canvas_to_screen(&self, p: egui::Pos2) -> egui::Pos2 {
        self.canvas_transform * p
    }

    /// The canvas widget's id (it holds the canvas's selection).
    pub(super) fn canvas_id(&self) -> egui::Id {
        egui::Id::new(("tyndall-canvas", self.canvas_gen))
    }

    /// Whether node `id` (a flattened id) has a thumbnail on the canvas.
    pub fn has_thumbnail(&self, id: &str) -> bool {
        self.thumbs.contains_key(id)
    }

    /// Call `f` with each offered tool that node `id` (of the graph shown) names in its
    /// declaration, in that order (an id no offered tool answers to, such as a tag another
    /// tool reads, is skipped), and the tool's context; a message it returns goes to the
    /// status bar.
    fn each_tool(
        &mut self,
        id: &str,
        mut f: impl FnMut(&mut dyn crate::Tool, &mut crate::ToolContext) -> Option<String>,
    ) {
        let Some(kind) = self.state.graph().node(id).map(|n| n.kind.clone()) else {
            return;
        };
        let tool_ids = self.registry.get(&kind).map_or(&[][..], |k| k.decl().tools);
        for tool_id in tool_ids {
            let Some(tool) = self.tools.by_id_mut(tool_id) else {
                continue;
            };
            let mut cx = crate::ToolContext {
                state: &mut self.state,
                registry: &self.registry,
                node: id,
                time: self.time,
                view_size: VIEW_SIZE,
                jobs: &mut self.jobs,
            };
            if let Some(m) = f(tool, &mut cx) {
                self.status = m;
            }
        }
    }

    /// "Record trace": start recording (`tyndall-trace-<seconds>.json` beside the document, or
    /// in the working directory), or stop and write the file (the status bar says where).
    pub fn toggle_trace(&mut self) {
        match self.trace_file.take() {
            None => {
                let stamp = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs());
                let dir = self
                    .state
                    .path()
                    .and_then(Path::parent)
                    .map(Path::to_path_buf)
                    .unwrap_or_default();
                let path = dir.join(format!("tyndall-trace-{stamp}.json"));
                tyndall_engine::trace::start();
                self.status = format!("recording a trace into {}", path.display());
                self.trace_file = Some(path);
            }
            Some(path) => {
                self.status = match tyndall_engine::trace::finish(&path) {
                    Ok(()) => format!("trace written: {} (open it in Perfetto)", path.display()),
                    Err(e) => format!("the trace was not written: {}: {e}", path.display()),
                };
            }
        }
    }

    /// Every evaluation and tool job asked for has landed (or there is no GPU).
    pub fn idle(&self) -> bool {
        self.worker.as_ref().is_none_or(|w| w.idle()) && !self.jobs.waiting()
    }

    /// Rebuild the canvas from the document when the document changed.
    fn sync(&mut self) {
        let text = format!(
            "{}\n{}",
            self.state.scope().join("/"),
            save_string(self.state.graph())
        );
        if self.synced.as_deref() == Some(text.as_str()) {
            return;
        }
        let g = self.state.graph();
        // A different set of nodes (or another group entered) is a new canvas: the canvas's
        // selection is by position in the node list, which now means other nodes. The view
        // (pan and zoom) carries over.
        let order: Vec<String> = g.nodes().map(|n| n.id.clone()).collect();
        let before: Vec<String> = self.snarl.nodes().cloned().collect();
        if order != before || self.synced_scope != self.state.scope() {
            self.canvas_gen += 1;
            self.restore_transform = (!before.is_empty()).then_some(self.canvas_transform);
            self.synced_scope = self.state.scope().to_vec();
        }
        let mut snarl = Snarl::new();
        let mut ids = BTreeMap::new();
        // Nodes the document places nowhere: the layered layout (columns by dependency depth).
        let mut laid = g.clone();
        laid.place_unplaced(self.state.catalog());
        for n in laid.nodes() {
            let pos = n.pos.unwrap_or_default();
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
                .and_then(|n| g.kind_schema(cat, &n.kind))
                .and_then(|s| s.outputs.iter().position(|p| p.name == e.from_port));
            let in_ix = g
                .node(&e.to_node)
                .and_then(|n| g.kind_schema(cat, &n.kind))
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
        self.port_types = self.state.graph().output_types(self.state.catalog());
        self.synced = Some(text);
    }
}

impl eframe::App for EditorApp {
    fn ui(&mut self, root: &mut egui::Ui, frame: &mut eframe::Frame) {
        let ctx = root.ctx().clone();
        self.share_window_device(frame);
        self.dialogs(&ctx);
        self.shortcuts(&ctx);
        self.sync();
        self.play(&ctx);
        self.pump(&ctx);
        if let Err(e) = self.state.tick_autosave(Instant::now()) {
            self.status = e.to_string();
        }
        self.top_bar(root);
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
        self.canvas_panel(root);
        self.exchange_jobs(&ctx);
    }
}

/// How far the canvas zooms out (canvas pixels per unit): far enough to frame a graph of a few
/// hundred nodes.
pub(super) const MIN_CANVAS_SCALE: f32 = 0.03;

/// Open the editor window on `path` (or an empty graph), with the node kinds of `registry` and
/// the editing `tools` (the command line passes the techniques' registry and Tyndall's tools).
pub fn run(path: Option<PathBuf>, registry: Arc<Registry>, tools: Tools) -> Result<(), String> {
    let state = match &path {
        Some(p) => EditorState::open(registry.catalog().clone(), p).map_err(|e| e.to_string())?,
        None => EditorState::new(registry.catalog().clone()),
    };
    let mut app = EditorApp::new(state, registry.clone()).with_tools(tools);
    app.recovery = path.as_deref().and_then(EditorState::recoverable);
    // Start on the picture: the node feeding the graph's first output, else the last node.
    let g = app.state.graph();
    let sink = g
        .nodes()
        .find(|n| registry.get(&n.kind).is_some_and(|k| k.is_sink()));
    app.selected = sink
        .and_then(|n| {
            // The node feeding the sink's first connected input, in its declared order.
            let kind = registry.get(&n.kind)?;
            kind.schema()
                .inputs
                .iter()
                .find_map(|p| g.source_of(&n.id, p.name))
                .map(|(src, _)| src.to_string())
        })
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
        // The device asks what the evaluation asks (all the adapter's limits, Tyndall's
        // features), so the evaluation can move onto it (`share_window_device`); on GL the
        // window keeps egui's own request (the evaluation stays on its own device there).
        let egui_request = c.device_descriptor.clone();
        c.instance_descriptor.flags = tyndall_engine::gpu::instance_flags(
            tyndall_engine::gpu::GpuOptions::from_env().validation,
        );
        c.device_descriptor = Arc::new(move |adapter| {
            if adapter.get_info().backend == eframe::wgpu::Backend::Gl {
                return egui_request(adapter);
            }
            let (features, limits) = tyndall_engine::gpu::device_request(adapter);
            eframe::wgpu::DeviceDescriptor {
                label: Some("tyndall editor"),
                required_features: features,
                required_limits: limits,
                ..Default::default()
            }
        });
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
