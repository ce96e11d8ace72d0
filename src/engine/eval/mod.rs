//! The evaluator: pull-based from the requested outputs, cached per node under keys of (kind,
//! parameter values at t, input keys) — several keys per node, so other frames and earlier
//! knob values stay until the memory budget evicts them —, with per-node statistics. A node
//! with a history also gets its inputs at earlier frames (`history.rs`).
//!
//! The evaluator knows no node kind: a [`Registry`] of [`NodeKind`]s is handed to it.

mod cache;
mod convert;
mod error;
mod groups;
mod history;
mod inputs;
mod key;
mod light_block;
use key::{key_and_inputs, Upstream};
mod node;
mod params;
mod paths;
pub mod pick;
pub mod proxy;
mod stats;
mod value;

use std::collections::{BTreeMap, BTreeSet};
use std::hash::{DefaultHasher, Hash, Hasher};
use std::sync::Arc;
use std::time::{Duration, Instant};

pub use convert::{download, download_later, upload_raster, PendingRaster};
pub use error::EvalError;
pub use history::MAX_HISTORY_DEPTH;
pub use light_block::LightBlock;
pub use node::{
    check_side, Earlier, FileRole, KeyInput, NodeDecl, NodeError, NodeKind, Registry, RunCtx,
};
pub use params::{FromParam, ParamReader};
pub use paths::{
    file_stamp, output_path, parse_frame_spec, resolve_files, with_frame, with_suffix, FrameList,
    PathPolicy, PathRefused,
};
use stats::{report, NodeRun};
pub use stats::{CancelCheck, NodeStat, Progress, ProgressSink, Stats, Status};
pub use value::{
    is_clear, pixel_ray, screen_ray, LayerSet, Mat4, Matrices, NamedLayer, PortValue, IDENTITY,
    SHADOW_CLEAR,
};

use crate::gpu::{Gpu, Recorder};
use crate::graph::{Graph, GraphError, NodeSchema, ParamValue};

/// What to evaluate.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// A node: a sink is committed (its file written); other nodes compute all their outputs.
    Node(String),
    /// One output port of a node.
    Port(String, String),
}

/// Settings of one evaluation.
#[derive(Debug, Clone)]
pub struct EvalOptions {
    /// Time at which key-frames are sampled.
    pub time: f64,
    /// Default image size for nodes that make images from nothing.
    pub size: (u32, u32),
    /// Suffix inserted before the extension of every file a sink writes.
    pub output_suffix: String,
    /// The frame being rendered, for file names: a `####` run (as many digits as `#`) or a
    /// `%04d` in a sink's path becomes the zero-padded frame; a path without either gets
    /// `_NNNN` before its extension. `None`: names are left as they are (a single evaluation).
    pub frame: Option<i64>,
    /// Measure each node's GPU time with timestamp queries (when the adapter has them): every
    /// pass's timestamps, read once the evaluation is submitted (no wait between nodes for
    /// them), summed per node. For statistics, benchmarks and traces.
    pub gpu_timings: bool,
    /// Let each node's GPU work run while the next nodes are recorded, instead of waiting for
    /// it after every node: what a long chain of small nodes needs (the wait per submission
    /// dominates there). A node's time is then the time to record and submit its passes, and
    /// an error the GPU raises while executing shows at the next read-back; its GPU cost is
    /// what `gpu_timings` measures. Off by default (a node's wall time then includes its GPU
    /// work, as the editor shows it); `tyndall eval` and `render` pipeline, `--stats` included.
    pub pipelined: bool,
    /// Values injected on unconnected input ports, by (node, port) — how `tyndall node` feeds
    /// files to a node. Each carries its own cache key.
    pub inject: BTreeMap<(String, String), (PortValue, u64)>,
    /// Where long-running nodes report their progress (the CLI draws a progress bar, the editor
    /// shows it in its top bar); `None`: nowhere.
    pub progress: Option<ProgressSink>,
    /// Asked before each node runs; `true` stops the evaluation with
    /// [`EvalError::Cancelled`] (the editor's worker: a newer request arrived). `None`: never.
    pub cancel: Option<CancelCheck>,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            time: 0.0,
            size: (512, 512),
            output_suffix: String::new(),
            frame: None,
            gpu_timings: false,
            pipelined: false,
            inject: BTreeMap::new(),
            progress: None,
            cancel: None,
        }
    }
}

/// The result of an evaluation.
#[derive(Debug)]
pub struct Evaluation {
    /// Values of the requested `Target::Port`s, by (node, port).
    pub outputs: BTreeMap<(String, String), PortValue>,
    /// Per-node statistics.
    pub stats: Stats,
}

/// Evaluates documents against a registry on a GPU, keeping a bounded cache between calls.
pub struct Evaluator {
    registry: Arc<Registry>,
    gpu: Arc<Gpu>,
    cache: cache::Cache,
    /// Node runs for earlier frames in the current evaluation (see [`Stats::earlier_runs`]).
    earlier_runs: usize,
    /// What the nodes that ran in the current evaluation said ([`RunCtx::note`]): node id, note.
    notes: Vec<(String, String)>,
    /// The pipeline cache could not be saved, and that was said once.
    cache_warned: bool,
    /// The colour config of its evaluations (empty: the current config).
    colour_config: String,
    /// The colour settings of the evaluation under way (its config, its graph's working space).
    colour: crate::colour::ColourCtx,
}

/// Default cache budget: 1 GiB of GPU memory.
pub const DEFAULT_CACHE_BUDGET: usize = 1 << 30;

impl Evaluator {
    /// An evaluator with the default cache budget.
    pub fn new(registry: Arc<Registry>, gpu: Arc<Gpu>) -> Self {
        Self {
            registry,
            gpu,
            cache: cache::Cache::new(DEFAULT_CACHE_BUDGET),
            earlier_runs: 0,
            notes: Vec::new(),
            cache_warned: false,
            colour_config: String::new(),
            colour: Default::default(),
        }
    }

    /// Evaluate under colour config CONFIG (a file or an `ocio://` name; empty: the current
    /// config) instead of the process's: what Python's `Evaluator(ocio=…)` sets. The config is
    /// read now, so a bad one is reported here.
    pub fn set_colour_config(&mut self, spec: &str) -> Result<(), crate::colour::ColourError> {
        if !spec.is_empty() {
            crate::colour::load(spec)?;
        }
        self.colour_config = spec.to_string();
        Ok(())
    }

    /// The colour config set by [`Evaluator::set_colour_config`] (empty: the current config).
    pub fn colour_config(&self) -> &str {
        &self.colour_config
    }

    /// Set the cache budget in bytes (results of the latest evaluation are kept regardless).
    pub fn set_budget(&mut self, bytes: usize) {
        self.cache.set_budget(bytes);
    }

    /// Bytes held by the cache.
    pub fn cached_bytes(&self) -> usize {
        self.cache.bytes()
    }

    /// Number of nodes with at least one cached result (a node keeps one per key it was
    /// evaluated under: other frames, earlier knob values, until the budget evicts them).
    pub fn cached_nodes(&self) -> usize {
        self.cache.nodes()
    }

    /// Drop the cached results of one node (its next evaluation runs it again).
    pub fn invalidate(&mut self, id: &str) {
        self.cache.invalidate(id);
    }

    /// Drop every cached result the latest evaluation did not use: what a cache of one result
    /// per node would hold. A benchmark of a change calls it so that a value it measured before
    /// is computed again, not found in the cache.
    pub fn keep_latest(&mut self) {
        self.cache
            .keep_used_since(self.cache.clock().saturating_sub(1));
    }

    /// Evaluations made so far: an epoch for [`Evaluator::keep_used_since`].
    pub fn epoch(&self) -> u64 {
        self.cache.clock()
    }

    /// Drop every cached result that no evaluation after `epoch` used. A render of a frame
    /// sequence calls it after each frame with the epoch before it: the next frame needs only
    /// what this one used (its earlier frames, for nodes with a history, included), so the
    /// cache holds about one frame's window instead of filling its budget.
    pub fn keep_used_since(&mut self, epoch: u64) {
        self.cache.keep_used_since(epoch);
    }

    /// Drop every cached result.
    pub fn clear(&mut self) {
        self.cache.clear();
    }

    /// The registry.
    pub fn registry(&self) -> &Arc<Registry> {
        &self.registry
    }

    /// The GPU context.
    pub fn gpu(&self) -> &Arc<Gpu> {
        &self.gpu
    }

    /// Every sink of the document (the graph's outputs), ordered by id; sinks inside groups as
    /// `group/inner`.
    pub fn sinks(&self, graph: &Graph) -> Vec<Target> {
        let flat;
        let graph = if graph.has_group_nodes() {
            match graph.flatten(self.registry.catalog()) {
                Ok(g) => {
                    flat = g;
                    &flat
                }
                Err(_) => graph,
            }
        } else {
            graph
        };
        graph
            .nodes()
            .filter(|n| self.registry.get(&n.kind).is_some_and(|k| k.is_sink()))
            .map(|n| Target::Node(n.id.clone()))
            .collect()
    }

    fn kind_of(&self, graph: &Graph, id: &str) -> Result<(Arc<dyn NodeKind>, String), EvalError> {
        let node = graph.node(id).ok_or_else(|| GraphError::UnknownNode {
            node: id.to_string(),
        })?;
        let k = self
            .registry
            .get(&node.kind)
            .ok_or_else(|| GraphError::UnknownKind {
                node: id.to_string(),
                kind: node.kind.clone(),
                known: self.registry.catalog().kind_names(),
            })?;
        Ok((k.clone(), node.kind.clone()))
    }

    /// [`Evaluator::evaluate`] of a graph without group nodes (`groups.rs` flattens first).
    fn evaluate_flat(
        &mut self,
        graph: &Graph,
        targets: &[Target],
        opts: &EvalOptions,
    ) -> Result<Evaluation, EvalError> {
        self.cache.tick();
        self.earlier_runs = 0;
        self.notes.clear();
        crate::trace::set_frame(opts.frame);
        self.colour = crate::colour::ColourCtx {
            config: self.colour_config.clone(),
            working_space: if graph.has_working_space() {
                graph.working_space().to_string()
            } else {
                String::new()
            },
        };
        self.colour.check()?;
        let plan = self.plan(graph, targets)?;
        let order = graph.topo_order();
        let mut stats: BTreeMap<String, NodeRun> = BTreeMap::new();
        let pipelines = self.gpu.pipeline_counts();
        let prepared = self.gpu.pipelines_prepared();
        // The pipelines these nodes used before are created on worker threads meanwhile
        // (gpu/prepare.rs).
        let kinds = self.kinds_in(graph, &order, &plan)?;
        let preparing = self.gpu.prepare_pipelines(&kinds);
        // The nodes' passes go into one recorder, submitted in chunks, not per node
        // (gpu/recorder.rs).
        let gpu = self.gpu.clone();
        let rec = gpu.recorder();
        let done = self.run_plan(graph, &plan, &order, opts, &mut stats, 0, &rec);
        preparing.finish();
        let submitted = rec.flush();
        let done = done.and_then(|d| submitted.map(|()| d).map_err(EvalError::Submit));
        // Every pass's GPU time, read once now that everything is submitted.
        let done = done.and_then(|d| {
            let mut times = rec.resolve_timings().map_err(EvalError::Submit)?;
            let timed = opts.gpu_timings
                && gpu
                    .device
                    .features()
                    .contains(wgpu::Features::TIMESTAMP_QUERY);
            for (id, run) in stats.iter_mut() {
                // A node that ran without a pass took no GPU time.
                let none = (timed && run.0.ran()).then_some(Duration::ZERO);
                run.2 = times.remove(id).or(none);
            }
            Ok(d)
        });
        let submits = rec.submits();
        drop(rec);
        self.cache.evict();
        // The pipelines compiled by this evaluation go to the cache on disk for the next
        // process; a cache that cannot be written only costs that process the compilation.
        let saved = self.gpu.save_pipeline_cache();
        if let Err(e) = saved.and_then(|()| self.gpu.save_pipeline_recipes()) {
            if !self.cache_warned {
                self.cache_warned = true;
                eprintln!("warning: the pipeline cache was not saved: {e}");
            }
        }
        let (compiled, cached) = self.gpu.pipeline_counts();
        let runs = self.earlier_runs;
        let mut r = report(graph, targets, &order, &done?.results, &stats, runs);
        r.stats.pipelines = (compiled - pipelines.0, cached - pipelines.1);
        r.stats.prepared = self.gpu.pipelines_prepared() - prepared;
        r.stats.submits = submits;
        r.stats.notes = std::mem::take(&mut self.notes);
        Ok(r)
    }

    /// The kinds of the nodes `plan` needs, in the order they run, with their shaders.
    fn kinds_in(
        &self,
        graph: &Graph,
        order: &[String],
        plan: &Plan,
    ) -> Result<Vec<(&'static str, &'static [crate::gpu::Shader])>, EvalError> {
        let mut kinds = Vec::new();
        for id in order.iter().filter(|id| plan.needed.contains(*id)) {
            let (k, _) = self.kind_of(graph, id)?;
            let kind = (k.schema().kind, k.decl().shaders);
            if !kinds.iter().any(|(n, _)| *n == kind.0) {
                kinds.push(kind);
            }
        }
        Ok(kinds)
    }

    /// Steps 2–4 for every node of `plan`, in `order`; `depth` counts the histories this
    /// evaluation is nested in (0: the requested time); the passes go into `rec`.
    #[allow(clippy::too_many_arguments)]
    fn run_plan(
        &mut self,
        graph: &Graph,
        plan: &Plan,
        order: &[String],
        opts: &EvalOptions,
        stats: &mut BTreeMap<String, NodeRun>,
        depth: usize,
        rec: &Recorder,
    ) -> Result<Upstream, EvalError> {
        let mut done = Upstream::default();
        let empty = BTreeSet::new();
        let colour = self.colour.clone();
        for id in order.iter().filter(|id| plan.needed.contains(*id)) {
            if opts.cancel.as_ref().is_some_and(|c| (c.0)()) {
                return Err(EvalError::Cancelled { before: id.clone() });
            }
            let (k, kind) = self.kind_of(graph, id)?;
            let node_err = |source: NodeError| EvalError::Node {
                node: id.clone(),
                kind: kind.clone(),
                source,
            };
            let params = self.params_at(graph, id, k.schema(), opts.time)?;
            let history =
                self.history_of(graph, id, &*k, &params, order, opts, depth, &node_err, rec)?;
            let (key, inputs) = key_and_inputs(graph, id, &*k, &kind, &params, &done, opts)
                .map_err(|e| e.into_eval(&node_err))?;
            let key = if history.earlier.is_empty() {
                key
            } else {
                let mut h = DefaultHasher::new();
                (key, history.key).hash(&mut h);
                h.finish()
            };
            // A node reading the colour settings is keyed by them too.
            let key = if k.decl().colour {
                let mut h = DefaultHasher::new();
                (key, &colour).hash(&mut h);
                h.finish()
            } else {
                key
            };
            done.keys.insert(id.clone(), key);
            let want = plan.wanted.get(id).unwrap_or(&empty);
            let data = graph.node(id).and_then(|n| n.data.as_ref());
            let mut ctx = RunCtx {
                gpu: rec,
                id,
                params: &params,
                data,
                time: opts.time,
                progress: opts.progress.as_ref(),
                inputs: &inputs,
                wanted: want,
                size: opts.size,
                output_suffix: &opts.output_suffix,
                frame: opts.frame,
                outputs: BTreeMap::new(),
                passed_through: false,
                earlier: &history.earlier,
                colour: &colour,
                notes: Vec::new(),
            };
            let outputs = match self.cache.reuse(id, key, want) {
                Some((outputs, cost)) => {
                    let status = (Status::Reused, history.time, None, 0, cost);
                    stats.insert(id.clone(), status);
                    outputs
                }
                None => {
                    let (outputs, wall, submits) =
                        self.run(&*k, &mut ctx, want, opts).map_err(node_err)?;
                    let time = wall + history.time;
                    self.cache.record(id, key, &outputs, time);
                    let said = std::mem::take(&mut ctx.notes);
                    self.notes.extend(said.into_iter().map(|m| (id.clone(), m)));
                    let status = if ctx.passed_through {
                        Status::PassedThrough
                    } else {
                        Status::Ran
                    };
                    // Its GPU time comes once the evaluation is submitted.
                    stats.insert(id.clone(), (status, time, None, submits, time));
                    outputs
                }
            };
            if plan.sinks.contains(id) {
                k.commit(&ctx, &outputs).map_err(node_err)?;
            }
            done.results.insert(id.clone(), outputs);
        }
        Ok(done)
    }

    /// Step 1, plan: which nodes the targets need, which outputs of each, and which sinks commit.
    fn plan(&self, graph: &Graph, targets: &[Target]) -> Result<Plan, EvalError> {
        let mut plan = Plan::default();
        let mut stack: Vec<String> = Vec::new();
        for t in targets {
            match t {
                Target::Node(id) => {
                    let (k, _) = self.kind_of(graph, id)?;
                    let entry = plan.wanted.entry(id.clone()).or_default();
                    if k.is_sink() {
                        plan.sinks.insert(id.clone());
                    } else {
                        entry.extend(k.schema().outputs.iter().map(|p| p.name.to_string()));
                    }
                    stack.push(id.clone());
                }
                Target::Port(id, port) => {
                    let (k, kind) = self.kind_of(graph, id)?;
                    if k.schema().output(port).is_none() {
                        return Err(EvalError::UnknownOutput {
                            node: id.clone(),
                            kind,
                            port: port.clone(),
                            known: k.schema().output_names(),
                        });
                    }
                    plan.wanted
                        .entry(id.clone())
                        .or_default()
                        .insert(port.clone());
                    stack.push(id.clone());
                }
            }
        }
        plan.needed = stack.iter().cloned().collect();
        while let Some(id) = stack.pop() {
            let (k, _) = self.kind_of(graph, &id)?;
            for input in k.schema().inputs {
                if let Some((src, sport)) = graph.source_of(&id, input.name) {
                    plan.wanted
                        .entry(src.to_string())
                        .or_default()
                        .insert(sport.to_string());
                    if plan.needed.insert(src.to_string()) {
                        stack.push(src.to_string());
                    }
                }
            }
        }
        Ok(plan)
    }

    /// Every declared parameter of node `id` at time `t` (key-frames sampled).
    fn params_at(
        &self,
        graph: &Graph,
        id: &str,
        schema: &NodeSchema,
        t: f64,
    ) -> Result<BTreeMap<String, ParamValue>, EvalError> {
        let catalog = self.registry.catalog();
        let mut params = BTreeMap::new();
        for p in schema.params {
            params.insert(p.name.to_string(), graph.param_at(catalog, id, p.name, t)?);
        }
        Ok(params)
    }

    /// Step 3b, run: the node's GPU work, waited for and timed; every wanted port must be set.
    fn run(
        &self,
        k: &dyn NodeKind,
        ctx: &mut RunCtx,
        want: &BTreeSet<String>,
        opts: &EvalOptions,
    ) -> Result<(BTreeMap<String, PortValue>, Duration, u64), NodeError> {
        // An adapter that cannot give this node's shader what it needs: one line naming what
        // is missing, before any of its passes is recorded (a shader only some parameter
        // values dispatch is checked at its dispatch instead).
        let decl = k.decl();
        for shader in decl.shaders {
            if !decl.on_demand.iter().any(|s| s.stem == shader.stem) {
                self.gpu.supports(*shader)?;
            }
        }
        let rec = ctx.gpu;
        rec.set_timing(opts.gpu_timings);
        rec.set_node(ctx.id, k.schema().kind);
        let start = Instant::now();
        let submitted = rec.submits();
        // The node's passes go into the evaluation's encoder, submitted with its neighbours'
        // (see gpu/recorder.rs) — at once, and waited for, when not pipelined. Its GPU time is
        // read once the evaluation is submitted (`Recorder::resolve_timings`).
        let ran = k.run(ctx);
        let ended = if opts.pipelined {
            rec.end_node()
        } else {
            rec.flush()
        };
        let ran = ran.and(ended.map_err(NodeError::from)).and_then(|()| {
            if !opts.pipelined {
                rec.wait()?;
            }
            rec.take_errors()?;
            Ok(())
        });
        let submits = rec.submits() - submitted;
        let elapsed = start.elapsed();
        crate::trace::record(
            "node",
            ctx.id,
            start,
            elapsed,
            serde_json::json!({ "kind": k.schema().kind }),
        );
        rec.set_timing(false);
        ran?;
        if let Some(p) = want.iter().find(|p| !ctx.outputs.contains_key(*p)) {
            return Err(NodeError::Other(format!("did not produce output '{p}'")));
        }
        Ok((std::mem::take(&mut ctx.outputs), elapsed, submits))
    }
}

/// What an evaluation needs: nodes, their wanted output ports, and the sinks to commit.
#[derive(Default)]
struct Plan {
    needed: BTreeSet<String>,
    wanted: BTreeMap<String, BTreeSet<String>>,
    sinks: BTreeSet<String>,
}
