//! Editor tools: what edits a node beyond its parameters — a panel under them, pointer input
//! over the viewer's picture and what it draws there, the tool's own state — as one [`Tool`]
//! trait, and the [`Tools`] an editor window is opened with.
//!
//! A node names the tools that edit it by id in its declaration (`NodeDecl::tools`); the
//! editor core shows, for the selected node, the panel of every registered tool it names, in
//! that order, and hands viewer input to the same tools. The core names no tool and no node
//! kind: Tyndall's tools live in their own crate (`src/tools/`, `tyndall_tools::registry()`),
//! each in one file, registered in one line. Every edit a tool makes goes through the
//! document ([`EditorState`]), so it is one undoable step like any other.

use std::any::Any;
use std::collections::BTreeMap;
use std::sync::Arc;

use eframe::egui;

use tyndall_engine::eval::Registry;

use crate::worker::{Answer, Job, Worker};
use crate::EditorState;

/// What a tool sees while it draws: the document, the node kinds, the node it edits, the
/// time shown and the viewer's picture size.
pub struct ToolContext<'a> {
    /// The document: read the node's data block with [`EditorState::node_data`], write it with
    /// [`EditorState::store_node_data`] (one undoable step).
    pub state: &'a mut EditorState,
    /// The node kinds.
    pub registry: &'a Arc<Registry>,
    /// The node the tool edits: an id of the graph shown (inside a group, the inner id;
    /// [`EditorState::full_id`] gives the id in the flattened document).
    pub node: &'a str,
    /// The document time shown (the timeline's frame).
    pub time: f64,
    /// The size in pixels of the pictures the viewer requests.
    pub view_size: (u32, u32),
    /// Evaluations the tool needs beyond the document's pictures (a scene's depth, a pick
    /// under the pointer): asked here, run by the editor's evaluation worker with its cache,
    /// answered on a later frame.
    pub jobs: &'a mut Jobs,
}

/// The tools' jobs for the evaluation worker, by key (one open job per key: asking again
/// under the same key drops the older job's answer). The window sends what was asked at the
/// end of each frame and files the answers; a tool takes its answer with [`Jobs::take`] when
/// it next draws. The window is not idle while a job is open.
#[derive(Default)]
pub struct Jobs {
    /// Asked this frame, not sent yet.
    outbox: Vec<(String, Job)>,
    /// Sent: the number of the newest job of each key.
    open: BTreeMap<String, u64>,
    /// Answered, not taken yet.
    answers: BTreeMap<String, Answer>,
}

impl Jobs {
    /// Ask the worker to run `job` with its evaluator, under `key` (by convention
    /// `tool_id/what`): replaces an open job of the same key and any answer not taken.
    pub fn ask(&mut self, key: &str, job: Job) {
        self.outbox.retain(|(k, _)| k != key);
        self.open.remove(key);
        self.answers.remove(key);
        self.outbox.push((key.to_string(), job));
    }

    /// A job is asked under `key` and not answered yet.
    pub fn waiting_for(&self, key: &str) -> bool {
        self.open.contains_key(key) || self.outbox.iter().any(|(k, _)| k == key)
    }

    /// Some job is asked and not answered yet.
    pub fn waiting(&self) -> bool {
        !self.open.is_empty() || !self.outbox.is_empty()
    }

    /// The answer to the job asked under `key`, once, as the `T` the job returned.
    pub fn take<T: Any>(&mut self, key: &str) -> Option<Result<T, String>> {
        let answer = self.answers.remove(key)?;
        Some(answer.and_then(|b| {
            b.downcast::<T>()
                .map(|t| *t)
                .map_err(|_| format!("the answer to {key} is not of the type asked for"))
        }))
    }

    /// Send what was asked to `worker` (with none, every job is answered with an error: the
    /// editor runs without a GPU) and file the worker's answers. Returns whether an answer was
    /// filed.
    pub fn exchange(&mut self, worker: Option<&mut Worker>) -> bool {
        let filed = self.answers.len();
        let Some(worker) = worker else {
            for (key, _) in self.outbox.drain(..) {
                self.answers
                    .insert(key, Err("no GPU: the editor evaluates nothing".into()));
            }
            self.open.clear();
            return self.answers.len() > filed;
        };
        for (key, job) in self.outbox.drain(..) {
            match worker.job(job) {
                Some(n) => {
                    self.open.insert(key, n);
                }
                None => {
                    self.answers
                        .insert(key, Err("the evaluation worker has stopped".into()));
                }
            }
        }
        for (n, answer) in worker.answers() {
            let key = self
                .open
                .iter()
                .find_map(|(k, m)| (*m == n).then(|| k.clone()));
            // An answer no key waits for was superseded by a newer ask: dropped.
            if let Some(key) = key {
                self.open.remove(&key);
                self.answers.insert(key, answer);
            }
        }
        self.answers.len() > filed
    }

    /// Forget every open job and answer (the worker was replaced: its jobs will never be
    /// answered); tools ask again when they next need them.
    pub fn reset(&mut self) {
        self.outbox.clear();
        self.open.clear();
        self.answers.clear();
    }
}

/// One editor tool (see the module doc). `id` is what nodes name in `NodeDecl::tools`; a
/// tool with nothing to show in the viewer keeps the default [`Tool::viewer`].
pub trait Tool: Any {
    /// The id nodes name in their declaration (`layer_list`, `stroke_painting`, …).
    fn id(&self) -> &'static str;

    /// The tool's panel, under the selected node's parameters. Returns a message for the
    /// status bar (what an edit did, or why it was refused).
    fn panel(&mut self, ui: &mut egui::Ui, cx: &mut ToolContext) -> Option<String>;

    /// Pointer input over the viewer's picture — `size` pixels shown in `response.rect` — and
    /// what the tool draws over it, while the node is selected. Returns a status message.
    fn viewer(
        &mut self,
        _ui: &egui::Ui,
        _response: &egui::Response,
        _size: (u32, u32),
        _cx: &mut ToolContext,
    ) -> Option<String> {
        None
    }

    /// The tool as `Any`, for [`Tools::get`].
    fn as_any(&self) -> &dyn Any;

    /// The tool as `Any`, for [`Tools::get_mut`].
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

/// The tools an editor window offers, each once, by id.
#[derive(Default)]
pub struct Tools(Vec<Box<dyn Tool>>);

impl Tools {
    /// No tools: nodes show their parameters only.
    pub fn new() -> Self {
        Self::default()
    }

    /// These tools and `tool` (replacing a tool of the same id).
    pub fn with(mut self, tool: impl Tool) -> Self {
        self.0.retain(|t| t.id() != tool.id());
        self.0.push(Box::new(tool));
        self
    }

    /// The ids, in registration order.
    pub fn ids(&self) -> Vec<&'static str> {
        self.0.iter().map(|t| t.id()).collect()
    }

    /// The tool answering to `id`.
    pub fn by_id_mut(&mut self, id: &str) -> Option<&mut dyn Tool> {
        self.0.iter_mut().find(|t| t.id() == id).map(|t| &mut **t)
    }

    /// The tool of type `T` (tests and scripts read a tool's state this way).
    pub fn get<T: Tool>(&self) -> Option<&T> {
        self.0.iter().find_map(|t| t.as_any().downcast_ref::<T>())
    }

    /// The tool of type `T`, to change its state.
    pub fn get_mut<T: Tool>(&mut self) -> Option<&mut T> {
        self.0
            .iter_mut()
            .find_map(|t| t.as_any_mut().downcast_mut::<T>())
    }
}

/// The pointer positions a painting stroke takes from `response` this frame, each with whether
/// it starts a stroke. egui recognises a drag only once the pointer has moved, so a stroke
/// starts where the button was pressed, then follows the pointer; a click is a one-point stroke.
pub fn stroke_points(ui: &egui::Ui, response: &egui::Response) -> Vec<(egui::Pos2, bool)> {
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

/// A point of the viewer (`response.rect`) in the pixels of the `size` picture shown there.
pub fn picture_pixel(response: &egui::Response, size: (u32, u32), p: egui::Pos2) -> [f32; 2] {
    let rel = (p - response.rect.min) / response.rect.size();
    [rel.x * size.0 as f32, rel.y * size.1 as f32]
}
