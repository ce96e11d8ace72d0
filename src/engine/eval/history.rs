//! Inputs at earlier frames, for nodes that declare a history ([`NodeKind::history`]).
//!
//! Before such a node runs at time t, every connected input is evaluated again at t − offset
//! for each of its offsets, through the same plan, keys and cache as the evaluation itself (a
//! nested evaluation of the node's upstream only, committing no sink). In a sequential render
//! the earlier frames were the current frame of an earlier call and are cache hits; a frame
//! rendered alone (a farm chunk's first frame) computes them. Either way the node sees the same
//! values, so its output does not depend on which frames were rendered before.

use std::collections::BTreeMap;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::time::Duration;

use super::stats::{NodeRun, Status};
use super::{EvalError, EvalOptions, Evaluator, NodeError, NodeKind, Target};
use crate::gpu::Recorder;
use crate::graph::{Graph, ParamValue};

use super::node::Earlier;

/// How deeply histories may nest (a node with history upstream of another one's earlier
/// frames): each level multiplies the frames evaluated.
pub const MAX_HISTORY_DEPTH: usize = 3;

/// What [`Evaluator::history_of`] gathered for one node.
#[derive(Default)]
pub(super) struct History {
    /// The inputs at each earlier frame.
    pub earlier: Vec<Earlier>,
    /// Hash of the offsets and of the upstream keys at each earlier frame.
    pub key: u64,
    /// Time the earlier frames' nodes took to run (zero when all were cached).
    pub time: Duration,
}

impl Evaluator {
    /// The connected inputs of node `id` at the earlier frames its kind asks for (none for a
    /// node without history); `depth` is how many histories this evaluation is nested in.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn history_of(
        &mut self,
        graph: &Graph,
        id: &str,
        k: &dyn NodeKind,
        params: &BTreeMap<String, ParamValue>,
        order: &[String],
        opts: &EvalOptions,
        depth: usize,
        node_err: &dyn Fn(NodeError) -> EvalError,
        rec: &Recorder,
    ) -> Result<History, EvalError> {
        let offsets = k.history(params).map_err(node_err)?;
        if offsets.is_empty() {
            return Ok(History::default());
        }
        if let Some(bad) = offsets.iter().find(|o| !(o.is_finite() && **o > 0.0)) {
            return Err(node_err(NodeError::Other(format!(
                "asked for its inputs {bad} frames back (an earlier frame needs an offset > 0)"
            ))));
        }
        if depth >= MAX_HISTORY_DEPTH {
            return Err(node_err(NodeError::Other(format!(
                "its earlier frames are needed by {depth} nested nodes with history (at most {})",
                MAX_HISTORY_DEPTH - 1
            ))));
        }
        let sources: Vec<(&str, &str, &str)> = k
            .schema()
            .inputs
            .iter()
            .filter_map(|i| graph.source_of(id, i.name).map(|(s, p)| (i.name, s, p)))
            .collect();
        let targets: Vec<Target> = sources
            .iter()
            .map(|(_, s, p)| Target::Port(s.to_string(), p.to_string()))
            .collect();
        let plan = self.plan(graph, &targets)?;
        let mut history = History::default();
        let mut h = DefaultHasher::new();
        for offset in offsets {
            let at = EvalOptions {
                time: opts.time - offset,
                frame: None,
                ..opts.clone()
            };
            let mut stats: BTreeMap<String, NodeRun> = BTreeMap::new();
            let up = self
                .run_plan(graph, &plan, order, &at, &mut stats, depth + 1, rec)
                .map_err(|e| at_earlier_frame(e, id, offset, at.time))?;
            let ran = stats.values().filter(|s| s.0 != Status::Reused);
            self.earlier_runs += ran.clone().count();
            history.time += ran.map(|s| s.1).sum::<Duration>();
            offset.to_bits().hash(&mut h);
            let mut inputs = BTreeMap::new();
            for (port, src, sport) in &sources {
                (port, up.keys.get(*src), sport).hash(&mut h);
                if let Some(v) = up.results.get(*src).and_then(|r| r.get(*sport)) {
                    inputs.insert(port.to_string(), v.clone());
                }
            }
            history.earlier.push(Earlier { offset, inputs });
        }
        history.key = h.finish();
        Ok(history)
    }
}

/// A node's failure at an earlier frame, saying which frame and which node with a history
/// asked for it (other errors, a cancellation among them, pass unchanged).
fn at_earlier_frame(e: EvalError, by: &str, offset: f64, time: f64) -> EvalError {
    match e {
        EvalError::Node { node, kind, source } => EvalError::Node {
            node,
            kind,
            source: NodeError::EarlierFrame {
                time,
                offset,
                by: by.to_string(),
                error: Box::new(source),
            },
        },
        other => other,
    }
}
