//! What an evaluation reports: per node, ran, reused or not needed, its times and its GPU
//! submissions (`tyndall eval --stats`); the progress of long-running nodes; and the check
//! that stops a superseded evaluation.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Duration;

use super::{Evaluation, PortValue, Target};
use crate::graph::Graph;

/// What happened to one node in one evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Computed in this evaluation.
    Ran,
    /// Run in this evaluation, but the node found its work unnecessary for these inputs and
    /// parameters and forwarded an input unchanged (see [`RunCtx::pass_through`](super::RunCtx::pass_through)).
    PassedThrough,
    /// Its cached result was reused.
    Reused,
    /// No requested output depends on it.
    NotNeeded,
}

impl Status {
    /// Whether the node ran in this evaluation (fully or as a pass-through).
    pub fn ran(self) -> bool {
        matches!(self, Status::Ran | Status::PassedThrough)
    }
}

impl fmt::Display for Status {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Status::Ran => "ran",
            Status::PassedThrough => "passed through",
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
    /// Wall-clock time of its GPU work including completion (zero unless it ran), plus, for a
    /// node with a history, the runs of its inputs at earlier frames this evaluation made.
    pub time: Duration,
    /// What its result cost: [`NodeStat::time`] when it ran, else the time recorded when the
    /// cached result it reused was computed (what a benchmark of a frame sequence charges a
    /// node that another evaluation of the same frame already ran).
    pub cost: Duration,
    /// GPU time of its passes from timestamp queries (with `gpu_timings`, when supported).
    pub gpu_time: Option<Duration>,
    /// Command buffers the evaluation's recorder submitted while it ran: 0 for a node whose
    /// passes wait in the encoder for the next chunk, 1 for one that ended a chunk, more for one
    /// that reads results back between passes (an evaluation on another thread does not add to
    /// it).
    pub submits: u64,
}

/// Statistics of one evaluation, one entry per node of the document in topological order.
#[derive(Debug, Clone, Default)]
pub struct Stats {
    /// Per node.
    pub nodes: Vec<NodeStat>,
    /// Node runs made for earlier frames of nodes with a history (`NodeKind::history`): 0 when
    /// every earlier frame was in the cache, as in a sequential render after its first frames.
    pub earlier_runs: usize,
    /// Pipelines created during the evaluation: (compiled, taken from the pipeline cache on
    /// disk) — counted over the whole GPU context.
    pub pipelines: (u64, u64),
    /// Of those, how many worker threads made up front ([`crate::gpu::Gpu::prepare_pipelines`]).
    pub prepared: u64,
    /// Command buffers the evaluation submitted: its nodes' and the last chunk's.
    pub submits: u64,
    /// What nodes that ran said about their run ([`RunCtx::note`](super::RunCtx::note)): node
    /// id and note, in the order they ran.
    pub notes: Vec<(String, String)>,
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
            "{:<w$}  {:<k$}  {:<14}  {:>10}  {:>10}",
            "node", "kind", "status", "wall ms", "gpu ms"
        )?;
        let ms = |d: Duration| format!("{:.3}", d.as_secs_f64() * 1e3);
        for n in &self.nodes {
            let (wall, gpu) = if n.status.ran() {
                (ms(n.time), n.gpu_time.map_or("-".into(), ms))
            } else {
                ("-".into(), "-".into())
            };
            writeln!(
                f,
                "{:<w$}  {:<k$}  {:<14}  {:>10}  {:>10}",
                n.id,
                n.kind,
                n.status.to_string(),
                wall,
                gpu
            )?;
        }
        writeln!(f, "GPU submissions: {}", self.submits)?;
        writeln!(
            f,
            "pipelines: {} compiled, {} from the cache",
            self.pipelines.0, self.pipelines.1
        )?;
        if self.prepared > 0 {
            writeln!(
                f,
                "pipelines made up front on worker threads: {} (of those above)",
                self.prepared
            )?;
        }
        if self.earlier_runs > 0 {
            writeln!(
                f,
                "earlier frames for nodes with a history: {} node runs (in those nodes' wall ms)",
                self.earlier_runs
            )?;
        }
        Ok(())
    }
}

/// One progress report of a running node.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    /// The node's id.
    pub node: String,
    /// Steps done.
    pub done: u64,
    /// Steps in all (0 when unknown).
    pub total: u64,
    /// What is going on (e.g. "residual 4.3e-1").
    pub message: String,
}

/// Whether an evaluation should stop before its next node (see `EvalOptions::cancel`).
#[derive(Clone)]
pub struct CancelCheck(pub std::sync::Arc<dyn Fn() -> bool + Send + Sync>);

impl fmt::Debug for CancelCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("CancelCheck")
    }
}

/// A receiver of [`Progress`] reports, shared with the nodes of an evaluation.
#[derive(Clone)]
pub struct ProgressSink(pub std::sync::Arc<dyn Fn(&Progress) + Send + Sync>);

impl std::fmt::Debug for ProgressSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ProgressSink")
    }
}

/// How one node's run went: status, wall time, GPU time, submissions, cost.
pub(super) type NodeRun = (Status, Duration, Option<Duration>, u64, Duration);

/// Step 5, report: the requested ports' values and one statistic per node in topological order.
pub(super) fn report(
    graph: &Graph,
    targets: &[Target],
    order: &[String],
    results: &BTreeMap<String, BTreeMap<String, PortValue>>,
    stats: &BTreeMap<String, NodeRun>,
    earlier_runs: usize,
) -> Evaluation {
    let mut outputs = BTreeMap::new();
    for t in targets {
        if let Target::Port(id, port) = t {
            if let Some(v) = results.get(id).and_then(|r| r.get(port)) {
                outputs.insert((id.clone(), port.clone()), v.clone());
            }
        }
    }
    let nodes = order
        .iter()
        .filter_map(|id| {
            let node = graph.node(id)?;
            let (status, time, gpu_time, submits, cost) = stats.get(id).copied().unwrap_or((
                Status::NotNeeded,
                Duration::ZERO,
                None,
                0,
                Duration::ZERO,
            ));
            Some(NodeStat {
                id: id.clone(),
                kind: node.kind.clone(),
                status,
                time,
                cost,
                gpu_time,
                submits,
            })
        })
        .collect();
    Evaluation {
        outputs,
        stats: Stats {
            nodes,
            earlier_runs,
            pipelines: (0, 0),
            prepared: 0,
            submits: 0,
            notes: Vec::new(),
        },
    }
}
