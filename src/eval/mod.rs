//! The evaluator: pull-based from the requested outputs, cached per node under a key of
//! (kind, parameter values at t, input keys), bounded in memory, with per-node statistics.
//!
//! The evaluator knows no node kind: a [`Registry`] of [`NodeKind`]s is handed to it.

mod convert;
mod node;
mod value;

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::sync::Arc;
use std::time::{Duration, Instant};

use thiserror::Error;

pub use convert::{download, upload_raster};
pub use node::{with_suffix, NodeError, NodeKind, Registry, RunCtx};
pub use value::{Mat4, Matrices, PortValue, IDENTITY};

use crate::gpu::Gpu;
use crate::graph::{Graph, GraphError};

/// An evaluation failure, naming the node (and port or parameter) at fault.
#[derive(Debug, Error)]
pub enum EvalError {
    /// A node failed.
    #[error("node '{node}' ({kind}): {source}")]
    Node {
        /// Node id.
        node: String,
        /// Node kind.
        kind: String,
        /// What went wrong.
        #[source]
        source: NodeError,
    },
    /// A requested output port does not exist.
    #[error("node '{node}' ({kind}) has no output port '{port}' (its outputs: {known})")]
    UnknownOutput {
        /// Node id.
        node: String,
        /// Node kind.
        kind: String,
        /// The requested port.
        port: String,
        /// Its output ports.
        known: String,
    },
    /// The document is inconsistent with the registry.
    #[error(transparent)]
    Graph(#[from] GraphError),
}

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
    /// Measure each node's GPU time with timestamp queries (when the adapter has them); this
    /// waits for every pass, so it is meant for statistics and benchmarks.
    pub gpu_timings: bool,
    /// Values injected on unconnected input ports, by (node, port) — how `tyndall node` feeds
    /// files to a node. Each carries its own cache key.
    pub inject: BTreeMap<(String, String), (PortValue, u64)>,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            time: 0.0,
            size: (512, 512),
            output_suffix: String::new(),
            gpu_timings: false,
            inject: BTreeMap::new(),
        }
    }
}

/// What happened to one node in one evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Computed in this evaluation.
    Ran,
    /// Its cached result was reused.
    Reused,
    /// No requested output depends on it.
    NotNeeded,
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Status::Ran => "ran",
            Status::Reused => "reused",
            Status::NotNeeded => "not needed",
        })
    }
}

/// Statistics of one node.
#[derive(Debug, Clone)]
pub struct NodeStat {
    /// Node id.
    pub id: String,
    /// Node kind.
    pub kind: String,
    /// Ran, reused or not needed.
    pub status: Status,
    /// Wall-clock time of its GPU work including completion (zero unless it ran).
    pub time: Duration,
    /// GPU time of its passes from timestamp queries (with `gpu_timings`, when supported).
    pub gpu_time: Option<Duration>,
}

/// Statistics of one evaluation, one entry per node of the document in topological order.
#[derive(Debug, Clone, Default)]
pub struct Stats {
    /// Per node.
    pub nodes: Vec<NodeStat>,
}

impl Stats {
    /// The status of node `id`.
    pub fn status(&self, id: &str) -> Option<Status> {
        self.nodes.iter().find(|n| n.id == id).map(|n| n.status)
    }

    /// Ids of nodes with this status.
    pub fn with_status(&self, s: Status) -> Vec<&str> {
        self.nodes
            .iter()
            .filter(|n| n.status == s)
            .map(|n| n.id.as_str())
            .collect()
    }
}

impl fmt::Display for Stats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = self
            .nodes
            .iter()
            .map(|n| n.id.len())
            .max()
            .unwrap_or(4)
            .max(4);
        let k = self
            .nodes
            .iter()
            .map(|n| n.kind.len())
            .max()
            .unwrap_or(4)
            .max(4);
        writeln!(
            f,
            "{:<w$}  {:<k$}  {:<10}  {:>10}  {:>10}",
            "node", "kind", "status", "wall ms", "gpu ms"
        )?;
        let ms = |d: Duration| format!("{:.3}", d.as_secs_f64() * 1e3);
        for n in &self.nodes {
            let (wall, gpu) = if n.status == Status::Ran {
                (ms(n.time), n.gpu_time.map_or("-".into(), ms))
            } else {
                ("-".into(), "-".into())
            };
            writeln!(
                f,
                "{:<w$}  {:<k$}  {:<10}  {:>10}  {:>10}",
                n.id,
                n.kind,
                n.status.to_string(),
                wall,
                gpu
            )?;
        }
        Ok(())
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

struct Entry {
    key: u64,
    outputs: BTreeMap<String, PortValue>,
    bytes: usize,
    last_used: u64,
}

/// Evaluates documents against a registry on a GPU, keeping a bounded cache between calls.
pub struct Evaluator {
    registry: Arc<Registry>,
    gpu: Arc<Gpu>,
    cache: HashMap<String, Entry>,
    budget: usize,
    clock: u64,
}

/// Default cache budget: 1 GiB of GPU memory.
pub const DEFAULT_CACHE_BUDGET: usize = 1 << 30;

impl Evaluator {
    /// An evaluator with the default cache budget.
    pub fn new(registry: Arc<Registry>, gpu: Arc<Gpu>) -> Self {
        Self {
            registry,
            gpu,
            cache: HashMap::new(),
            budget: DEFAULT_CACHE_BUDGET,
            clock: 0,
        }
    }

    /// Set the cache budget in bytes (results of the latest evaluation are kept regardless).
    pub fn set_budget(&mut self, bytes: usize) {
        self.budget = bytes;
    }

    /// Bytes held by the cache.
    pub fn cached_bytes(&self) -> usize {
        self.cache.values().map(|e| e.bytes).sum()
    }

    /// Number of nodes with a cached result.
    pub fn cached_nodes(&self) -> usize {
        self.cache.len()
    }

    /// Drop the cached result of one node (its next evaluation runs it again).
    pub fn invalidate(&mut self, id: &str) {
        self.cache.remove(id);
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

    /// Every sink of the document (the graph's outputs), ordered by id.
    pub fn sinks(&self, graph: &Graph) -> Vec<Target> {
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

    /// Evaluate `targets` of `graph`: only nodes they depend on are considered, and of those only
    /// nodes whose key changed since their cached result run again.
    pub fn evaluate(
        &mut self,
        graph: &Graph,
        targets: &[Target],
        opts: &EvalOptions,
    ) -> Result<Evaluation, EvalError> {
        self.clock += 1;
        let catalog = self.registry.catalog().clone();
        // 1. What is needed, and which outputs of each node.
        let mut wanted: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        let mut sinks: BTreeSet<String> = BTreeSet::new();
        let mut stack: Vec<String> = Vec::new();
        for t in targets {
            match t {
                Target::Node(id) => {
                    let (k, _) = self.kind_of(graph, id)?;
                    let entry = wanted.entry(id.clone()).or_default();
                    if k.is_sink() {
                        sinks.insert(id.clone());
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
                    wanted.entry(id.clone()).or_default().insert(port.clone());
                    stack.push(id.clone());
                }
            }
        }
        let mut needed: BTreeSet<String> = stack.iter().cloned().collect();
        while let Some(id) = stack.pop() {
            let (k, _) = self.kind_of(graph, &id)?;
            for input in k.schema().inputs {
                if let Some((src, sport)) = graph.source_of(&id, input.name) {
                    wanted
                        .entry(src.to_string())
                        .or_default()
                        .insert(sport.to_string());
                    if needed.insert(src.to_string()) {
                        stack.push(src.to_string());
                    }
                }
            }
        }
        // 2. Run or reuse, sources first.
        let order = graph.topo_order();
        let mut keys: BTreeMap<String, u64> = BTreeMap::new();
        let mut results: BTreeMap<String, BTreeMap<String, PortValue>> = BTreeMap::new();
        let mut stats: BTreeMap<String, (Status, Duration, Option<Duration>)> = BTreeMap::new();
        let empty = BTreeSet::new();
        for id in order.iter().filter(|id| needed.contains(*id)) {
            let (k, kind) = self.kind_of(graph, id)?;
            let schema = k.schema();
            let node_err = |source: NodeError| EvalError::Node {
                node: id.clone(),
                kind: kind.clone(),
                source,
            };
            let mut params = BTreeMap::new();
            for p in schema.params {
                params.insert(
                    p.name.to_string(),
                    graph.param_at(&catalog, id, p.name, opts.time)?,
                );
            }
            let mut h = DefaultHasher::new();
            kind.hash(&mut h);
            for (name, v) in &params {
                if !k.key_exempt().contains(&name.as_str()) {
                    name.hash(&mut h);
                    v.hash_into(&mut h);
                }
            }
            k.volatile_key(&params).hash(&mut h);
            opts.size.hash(&mut h);
            let mut inputs = BTreeMap::new();
            for input in schema.inputs {
                if let Some((src, sport)) = graph.source_of(id, input.name) {
                    (input.name, keys.get(src), sport).hash(&mut h);
                    let v = results
                        .get(src)
                        .and_then(|r| r.get(sport))
                        .cloned()
                        .ok_or_else(|| {
                            node_err(NodeError::Input {
                                port: input.name.to_string(),
                                message: format!("upstream {src}.{sport} produced no value"),
                            })
                        })?;
                    inputs.insert(input.name.to_string(), v);
                } else if let Some((v, vkey)) =
                    opts.inject.get(&(id.clone(), input.name.to_string()))
                {
                    (input.name, "inject", vkey).hash(&mut h);
                    inputs.insert(input.name.to_string(), v.clone());
                }
            }
            let key = h.finish();
            keys.insert(id.clone(), key);
            let want = wanted.get(id).unwrap_or(&empty);
            let mut ctx = RunCtx {
                gpu: &self.gpu,
                id,
                params: &params,
                inputs: &inputs,
                wanted: want,
                size: opts.size,
                output_suffix: &opts.output_suffix,
                outputs: BTreeMap::new(),
            };
            let cached = self
                .cache
                .get_mut(id)
                .filter(|e| e.key == key && want.iter().all(|p| e.outputs.contains_key(p)));
            let outputs = if let Some(e) = cached {
                e.last_used = self.clock;
                stats.insert(id.clone(), (Status::Reused, Duration::ZERO, None));
                e.outputs.clone()
            } else {
                self.gpu.set_timing(opts.gpu_timings);
                let start = Instant::now();
                k.run(&mut ctx).map_err(node_err)?;
                self.gpu.wait().map_err(|e| node_err(e.into()))?;
                self.gpu.take_errors().map_err(|e| node_err(e.into()))?;
                let elapsed = start.elapsed();
                let gpu_time = self.gpu.take_gpu_time();
                self.gpu.set_timing(false);
                for p in want {
                    if !ctx.outputs.contains_key(p) {
                        return Err(node_err(NodeError::Other(format!(
                            "did not produce output '{p}'"
                        ))));
                    }
                }
                let outputs = std::mem::take(&mut ctx.outputs);
                let bytes = outputs.values().map(PortValue::bytes).sum();
                self.cache.insert(
                    id.clone(),
                    Entry {
                        key,
                        outputs: outputs.clone(),
                        bytes,
                        last_used: self.clock,
                    },
                );
                stats.insert(id.clone(), (Status::Ran, elapsed, gpu_time));
                outputs
            };
            if sinks.contains(id) {
                k.commit(&ctx, &outputs).map_err(node_err)?;
            }
            results.insert(id.clone(), outputs);
        }
        self.evict();
        // 3. Report.
        let mut outputs = BTreeMap::new();
        for t in targets {
            if let Target::Port(id, port) = t {
                if let Some(v) = results.get(id).and_then(|r| r.get(port)) {
                    outputs.insert((id.clone(), port.clone()), v.clone());
                }
            }
        }
        let stats = Stats {
            nodes: order
                .iter()
                .filter_map(|id| {
                    let node = graph.node(id)?;
                    let (status, time, gpu_time) =
                        stats
                            .get(id)
                            .copied()
                            .unwrap_or((Status::NotNeeded, Duration::ZERO, None));
                    Some(NodeStat {
                        id: id.clone(),
                        kind: node.kind.clone(),
                        status,
                        time,
                        gpu_time,
                    })
                })
                .collect(),
        };
        Ok(Evaluation { outputs, stats })
    }

    fn evict(&mut self) {
        while self.cached_bytes() > self.budget {
            let oldest = self
                .cache
                .iter()
                .filter(|(_, e)| e.last_used < self.clock)
                .min_by_key(|(_, e)| e.last_used)
                .map(|(k, _)| k.clone());
            match oldest {
                Some(k) => {
                    self.cache.remove(&k);
                }
                None => break,
            }
        }
    }
}
