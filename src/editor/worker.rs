//! Evaluation off the UI thread: a worker owns the [`Evaluator`] (and with it the cache of
//! every node's last result), takes the newest request, evaluates it and sends back per-node
//! thumbnails, statistics and errors plus the viewed port's full picture. Only nodes whose
//! inputs or parameters changed run again (the evaluator's cache), so dragging a slider
//! re-runs the chain below it while the window keeps drawing.

use std::any::Any;
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender, TryRecvError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use tyndall_engine::eval::{Evaluator, Registry, Status};
use tyndall_engine::gpu::{Gpu, GpuTexture};
use tyndall_engine::graph::{Graph, PortType};
use tyndall_engine::io::Raster;

mod evaluate;

use evaluate::evaluate;
pub use evaluate::{shrink, thumbnail_of};

/// Longest side of a node's thumbnail on the canvas, in pixels.
pub const THUMB: u32 = 96;

/// A picture the worker sends the window: read back to the CPU, or the GPU texture it was
/// evaluated into (when the window draws with the evaluation's device: [`Request::textures`]).
#[derive(Clone, Debug)]
pub enum Picture {
    /// Read back (a window on another device).
    Pixels(Raster),
    /// The evaluated texture itself, drawn by the window's display pass (`crate::display`).
    Texture(Arc<GpuTexture>),
}

impl Picture {
    /// Width and height in pixels.
    pub fn size(&self) -> (u32, u32) {
        match self {
            Picture::Pixels(r) => (r.width, r.height),
            Picture::Texture(t) => (t.width, t.height),
        }
    }

    /// The values, when read back.
    pub fn pixels(&self) -> Option<&Raster> {
        match self {
            Picture::Pixels(r) => Some(r),
            Picture::Texture(_) => None,
        }
    }
}

/// What to evaluate.
#[derive(Clone)]
pub struct Request {
    /// Increasing number; results carry the request's.
    pub generation: u64,
    /// The document as it is now.
    pub graph: Graph,
    /// Time at which key-frames are sampled.
    pub time: f64,
    /// Image size for nodes that make images from nothing.
    pub size: (u32, u32),
    /// The node shown in the viewer, by flattened id (`look/fill` inside a group; a group
    /// instance shows its output ports): all its picture outputs are read back at full size.
    pub view: Option<String>,
    /// The viewer's A/B wipe: the node compared with `view`, read back at full size too.
    pub compare: Option<String>,
    /// Proxy factor: 1 evaluates at `size`; f > 1 (while a knob is dragged) evaluates the
    /// viewed pictures only, at `size` / f with the screen-pixel knobs scaled
    /// ([`tyndall_engine::eval::proxy`]), no thumbnails.
    pub proxy: u32,
    /// Send the evaluated textures ([`Picture::Texture`]) instead of reading pictures back: the
    /// window draws with the evaluation's device. Default (false): read back.
    pub textures: bool,
}

/// One node's part of a result.
#[derive(Clone, Debug)]
pub struct NodeReport {
    /// Ran, reused or not needed in this evaluation.
    pub status: Status,
    /// Time of its last run.
    pub time: Duration,
    /// Its error, or the upstream node whose error stopped it.
    pub error: Option<String>,
    /// A small picture of its first picture output (read back and shrunk, or its texture for the
    /// window to shrink), when it ran (or was never sent); keep the previous one when `None`.
    pub thumb: Option<Picture>,
}

impl Default for NodeReport {
    /// Not needed, no time, no error, no thumbnail.
    fn default() -> Self {
        Self {
            status: Status::NotNeeded,
            time: Duration::ZERO,
            error: None,
            thumb: None,
        }
    }
}

/// A finished evaluation.
pub struct Outcome {
    /// The request's generation.
    pub generation: u64,
    /// Per node of the flattened graph (`group/inner` ids).
    pub nodes: BTreeMap<String, NodeReport>,
    /// Each group instance (flattened path) → the flattened node its first output comes from
    /// (whose thumbnail the group node shows).
    pub aliases: BTreeMap<String, String>,
    /// The viewed node and its picture outputs by port name.
    pub view: Option<(String, Vec<(String, Picture)>)>,
    /// The wipe's compared node and its picture outputs, when asked for.
    pub compare: Option<(String, Vec<(String, Picture)>)>,
    /// Wall-clock time of the whole evaluation.
    pub elapsed: Duration,
    /// The GPU device was lost during this evaluation (the reason): nothing more runs on this
    /// worker's device, so the editor starts a new worker on a new one.
    pub device_lost: Option<String>,
    /// The request's proxy factor (1: full resolution).
    pub proxy: u32,
    /// The evaluation size used (the request's size divided by the proxy factor).
    pub size: (u32, u32),
    /// Stopped because a newer request arrived (never sent to the window).
    pub cancelled: bool,
}

/// Work an editor tool asks of the worker's evaluator (the same one, with its cache, that
/// evaluates the document): render what the tool needs — a scene's depth, a pick under the
/// pointer — and return it as `Any`. Jobs run in the order asked, before the next document
/// evaluation; an evaluation under way is finished (or cancelled by a newer request) first.
pub type Job = Box<dyn FnOnce(&mut Evaluator) -> Answer + Send>;

/// What a [`Job`] returns: its result, or why it failed (for the status bar).
pub type Answer = Result<Box<dyn Any + Send>, String>;

/// What the window sends the thread.
enum Message {
    Evaluate(Box<Request>),
    Job(u64, Job),
}

/// The evaluation thread and its channels.
pub struct Worker {
    tx: Option<Sender<Message>>,
    rx: Receiver<Outcome>,
    answers: Receiver<(u64, Answer)>,
    /// Number of the last job sent.
    jobs_sent: u64,
    /// Jobs sent and not answered yet.
    jobs_open: BTreeSet<u64>,
    progress: Receiver<tyndall_engine::eval::Progress>,
    thread: Option<JoinHandle<()>>,
    /// Generation of the newest request sent.
    pub sent: u64,
    /// The same, shared with the thread: an evaluation older than it stops before its next
    /// node (a stale request never delays or overwrites a newer one).
    newest: Arc<AtomicU64>,
    /// Generation of the newest outcome received.
    pub done: u64,
    /// The context it evaluates on.
    gpu: Arc<Gpu>,
}

impl Worker {
    /// The context it evaluates on.
    pub fn gpu(&self) -> &Arc<Gpu> {
        &self.gpu
    }

    /// Start a worker evaluating with `registry` on `gpu`.
    pub fn start(registry: Arc<Registry>, gpu: Arc<Gpu>) -> Self {
        let (tx, messages) = channel::<Message>();
        let (results, rx) = channel::<Outcome>();
        let (answer_tx, answers) = channel::<(u64, Answer)>();
        let (progress_tx, progress) = channel::<tyndall_engine::eval::Progress>();
        let newest = Arc::new(AtomicU64::new(0));
        let newest_seen = newest.clone();
        let context = gpu.clone();
        let thread = std::thread::Builder::new()
            .name("tyndall-eval".into())
            .spawn(move || {
                let mut ev = Evaluator::new(registry, gpu);
                let mut thumbed = BTreeSet::new();
                let progress_tx = std::sync::Mutex::new(progress_tx);
                let sink = tyndall_engine::eval::ProgressSink(std::sync::Arc::new(move |p| {
                    if let Ok(tx) = progress_tx.lock() {
                        let _ = tx.send(p.clone());
                    }
                }));
                let mut request: Option<Request> = None;
                let mut jobs = VecDeque::new();
                loop {
                    if request.is_none() && jobs.is_empty() {
                        match messages.recv() {
                            Ok(m) => take(m, &mut request, &mut jobs),
                            Err(_) => return,
                        }
                    }
                    // Every job waiting, but only the newest request.
                    loop {
                        match messages.try_recv() {
                            Ok(m) => take(m, &mut request, &mut jobs),
                            Err(TryRecvError::Empty) => break,
                            Err(TryRecvError::Disconnected) => return,
                        }
                    }
                    if let Some((n, job)) = jobs.pop_front() {
                        let answer: Answer = job(&mut ev);
                        if answer_tx.send((n, answer)).is_err() {
                            return;
                        }
                        continue;
                    }
                    let Some(req) = request.take() else {
                        continue;
                    };
                    let generation = req.generation;
                    let seen = newest_seen.clone();
                    let cancel = tyndall_engine::eval::CancelCheck(Arc::new(move || {
                        seen.load(Ordering::Acquire) > generation
                    }));
                    let out = evaluate(&mut ev, &req, &mut thumbed, &sink, cancel);
                    if out.cancelled {
                        // Superseded: its thumbnails were never delivered, so they are sent
                        // with a later outcome; the newer request is already waiting.
                        for (id, rep) in &out.nodes {
                            if rep.thumb.is_some() {
                                thumbed.remove(id);
                            }
                        }
                        continue;
                    }
                    if results.send(out).is_err() {
                        return;
                    }
                }
            })
            .ok();
        Self {
            tx: thread.as_ref().map(|_| tx),
            rx,
            answers,
            jobs_sent: 0,
            jobs_open: BTreeSet::new(),
            progress,
            thread,
            sent: 0,
            done: 0,
            newest,
            gpu: context,
        }
    }

    /// Ask for an evaluation; returns its generation.
    pub fn request(&mut self, mut req: Request) -> u64 {
        self.sent += 1;
        req.generation = self.sent;
        self.newest.store(self.sent, Ordering::Release);
        if let Some(tx) = &self.tx {
            if tx.send(Message::Evaluate(Box::new(req))).is_err() {
                self.tx = None;
            }
        }
        self.sent
    }

    /// Ask for a tool's job; returns its number, which its answer carries ([`Worker::answers`]),
    /// or `None` when the thread is gone (the job will never run).
    pub fn job(&mut self, job: Job) -> Option<u64> {
        self.jobs_sent += 1;
        let n = self.jobs_sent;
        let sent = self
            .tx
            .as_ref()
            .is_some_and(|tx| tx.send(Message::Job(n, job)).is_ok());
        if !sent {
            self.tx = None;
            return None;
        }
        self.jobs_open.insert(n);
        Some(n)
    }

    /// Every job answered since the last call, by number, oldest first.
    pub fn answers(&mut self) -> Vec<(u64, Answer)> {
        let mut out = Vec::new();
        while let Ok((n, a)) = self.answers.try_recv() {
            self.jobs_open.remove(&n);
            out.push((n, a));
        }
        out
    }

    /// Every outcome finished since the last call, oldest first. All of them, not only the
    /// newest: a thumbnail is sent once (the worker remembers it was delivered), so an outcome
    /// skipped here would lose its thumbnails until the node reruns.
    pub fn poll(&mut self) -> Vec<Outcome> {
        let mut outs = Vec::new();
        while let Ok(o) = self.rx.try_recv() {
            self.done = o.generation;
            outs.push(o);
        }
        outs
    }

    /// The newest progress report of a long-running node since the last call, if any.
    pub fn poll_progress(&mut self) -> Option<tyndall_engine::eval::Progress> {
        let mut last = None;
        while let Ok(p) = self.progress.try_recv() {
            last = Some(p);
        }
        last
    }

    /// Let the thread go without waiting for it: it ends after the evaluation it is running, if
    /// any (used when its device was lost, so the window does not wait on a long CPU node).
    pub fn abandon(mut self) {
        self.tx = None;
        drop(self.thread.take());
    }

    /// Every request sent has its outcome and every job its answer (or the worker is gone). A
    /// superseded request has none: the newest one's outcome counts for it.
    pub fn idle(&self) -> bool {
        self.tx.is_none() || (self.done >= self.sent && self.jobs_open.is_empty())
    }
}

/// File a message from the window: a job joins the queue, a request replaces the older one.
fn take(m: Message, request: &mut Option<Request>, jobs: &mut VecDeque<(u64, Job)>) {
    match m {
        Message::Evaluate(r) => *request = Some(*r),
        Message::Job(n, job) => jobs.push_back((n, job)),
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// A node's outputs that are pictures (not a scene or a phase function), in schema order;
/// none for sinks (evaluating them writes files).
pub fn picture_ports(graph: &Graph, registry: &Registry, id: &str) -> Vec<String> {
    let cat = registry.catalog();
    let Some(node) = graph.node(id) else {
        return Vec::new();
    };
    // A group's outputs are pictures like its inner ports; a built-in sink has none.
    let schema = match registry.get(&node.kind) {
        Some(kind) if kind.is_sink() => return Vec::new(),
        Some(kind) => kind.schema(),
        None => match graph.kind_schema(cat, &node.kind) {
            Some(s) => s,
            None => return Vec::new(),
        },
    };
    schema
        .outputs
        .iter()
        .filter(|p| {
            let t = graph.output_type(cat, id, p.name).unwrap_or(p.types[0]);
            !matches!(
                t,
                PortType::Scene
                    | PortType::Phase
                    | PortType::Volume
                    | PortType::SoftShadow
                    | PortType::Layers
            )
        })
        .map(|p| p.name.to_string())
        .collect()
}

/// The report a group instance `path` (flattened) shows: its inner nodes' together — ran when
/// one ran (their times added), reused when all that were needed were, their first error.
pub fn group_report(reports: &BTreeMap<String, NodeReport>, path: &str) -> Option<NodeReport> {
    let prefix = format!("{path}/");
    let inner: Vec<&NodeReport> = reports
        .range(prefix.clone()..)
        .take_while(|(k, _)| k.starts_with(&prefix))
        .map(|(_, r)| r)
        .collect();
    if inner.is_empty() {
        return None;
    }
    let ran: Vec<&&NodeReport> = inner.iter().filter(|r| r.status.ran()).collect();
    let status = match ran.first() {
        Some(r) => r.status,
        None if inner.iter().any(|r| r.status == Status::Reused) => Status::Reused,
        None => Status::NotNeeded,
    };
    Some(NodeReport {
        status,
        time: ran.iter().map(|r| r.time).sum(),
        error: inner.iter().find_map(|r| r.error.clone()),
        thumb: None,
    })
}

/// The document with its input files (file parameters, files inside data blocks) resolved
/// against the graph file's folder, as the CLI reads them. The editor evaluates no sinks,
/// so output paths are left as written.
pub(super) fn graph_for_evaluation(
    registry: &Registry,
    state: &crate::EditorState,
) -> tyndall_engine::graph::Graph {
    let graph = state.root();
    let Some(dir) = state.path().and_then(std::path::Path::parent) else {
        return graph.clone();
    };
    let policy = tyndall_engine::eval::PathPolicy {
        graph_dir: dir.to_path_buf(),
        output_dir: dir.to_path_buf(),
        allow_any: true,
    };
    // With `allow_any` nothing is refused; the fall-back keeps the document as it is.
    tyndall_engine::eval::resolve_files(registry, graph, &policy).unwrap_or_else(|_| graph.clone())
}

/// The nearest node downstream of `id` (breadth first, consumers in id order) that has a
/// picture output: what the viewer shows for a node that has none itself (a volume, a scene).
pub fn nearest_picture(graph: &Graph, registry: &Registry, id: &str) -> Option<String> {
    let mut seen = BTreeSet::from([id.to_string()]);
    let mut queue = VecDeque::from([id.to_string()]);
    while let Some(n) = queue.pop_front() {
        if n != id && !picture_ports(graph, registry, &n).is_empty() {
            return Some(n);
        }
        for c in graph.consumers(&n) {
            if seen.insert(c.to_string()) {
                queue.push_back(c.to_string());
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shrink_averages_blocks_and_keeps_channels() {
        let r = Raster {
            width: 4,
            height: 2,
            channels: 1,
            data: vec![0.0, 2.0, 4.0, 6.0, 2.0, 4.0, 6.0, 8.0],
        };
        let s = shrink(&r, 2);
        assert_eq!((s.width, s.height, s.channels), (2, 1, 1));
        assert_eq!(s.data, vec![2.0, 6.0]);
        // Already small: unchanged.
        assert_eq!(shrink(&r, 96), r);
    }
}
