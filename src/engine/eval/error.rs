//! How an evaluation fails: [`EvalError`], naming the node (and port or parameter) at fault.

use thiserror::Error;

use super::NodeError;
use crate::gpu::GpuError;
use crate::graph::GraphError;

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
    /// The evaluation was stopped between two nodes because its [`EvalOptions::cancel`](super::EvalOptions::cancel) said
    /// so (a newer request superseded it); the nodes that ran keep their cached results.
    #[error("evaluation cancelled before node '{before}' (superseded by a newer request)")]
    Cancelled {
        /// The node that would have run next.
        before: String,
    },
    /// The document is inconsistent with the registry.
    #[error(transparent)]
    Graph(#[from] GraphError),
    /// The graph's working space is not in the evaluation's colour config.
    #[error("the graph's working space: {0}")]
    Colour(#[from] crate::colour::ColourError),
    /// The last chunk of the evaluation's GPU commands could not be submitted (every node had
    /// recorded its passes without an error).
    #[error("submitting the evaluation's GPU work: {0}")]
    Submit(#[source] GpuError),
}

impl EvalError {
    /// Whether a node failed on a bad input file ([`NodeError::BadFile`]): bad input, not a
    /// failed evaluation.
    pub fn bad_input(&self) -> bool {
        matches!(self, EvalError::Node { source, .. } if matches!(source.innermost(), NodeError::BadFile(_)))
    }

    /// Whether the GPU device was lost (or hung past the watchdog): nothing later can run on it,
    /// so a batch stops instead of failing every remaining frame.
    pub fn device_lost(&self) -> bool {
        match self {
            EvalError::Node { source, .. } => matches!(
                source.innermost(),
                NodeError::Gpu(GpuError::Lost(_) | GpuError::Hung(_))
            ),
            EvalError::Submit(e) => matches!(e, GpuError::Lost(_) | GpuError::Hung(_)),
            _ => false,
        }
    }
}
