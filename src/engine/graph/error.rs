//! Errors of the graph document and its file format.

use std::fmt;
use std::path::PathBuf;

use thiserror::Error;

use super::types::PortType;

/// Something wrong with a graph document. Every variant names the node (and port or parameter)
/// at fault.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GraphError {
    /// The text is not valid RON, or does not have the graph file's shape.
    #[error("syntax error: {message}")]
    Syntax {
        /// What the parser expected.
        message: String,
    },
    /// A node names a kind the catalog does not know.
    #[error("node '{node}': unknown node kind '{kind}' (known kinds: {known})")]
    UnknownKind {
        /// Node id.
        node: String,
        /// The unknown kind.
        kind: String,
        /// Known kinds.
        known: String,
    },
    /// A parameter the node kind does not declare.
    #[error("node '{node}' ({kind}): unknown parameter '{param}' (its parameters: {known})")]
    UnknownParam {
        /// Node id.
        node: String,
        /// Node kind.
        kind: String,
        /// The unknown parameter.
        param: String,
        /// Declared parameters.
        known: String,
    },
    /// A parameter value of the wrong type.
    #[error("node '{node}' parameter '{param}': wrong type, expected {expected}, found {found}")]
    WrongParamType {
        /// Node id.
        node: String,
        /// Parameter name.
        param: String,
        /// What the parameter accepts.
        expected: String,
        /// What was given.
        found: String,
    },
    /// A numeric value outside the parameter's hard range (or not finite).
    #[error(
        "node '{node}' parameter '{param}': value {value} is out of range, expected {expected}"
    )]
    OutOfRange {
        /// Node id.
        node: String,
        /// Parameter name.
        param: String,
        /// The refused value.
        value: f64,
        /// The accepted range.
        expected: String,
    },
    /// Two nodes with one id.
    #[error("duplicate node id '{node}'")]
    DuplicateNode {
        /// The repeated id.
        node: String,
    },
    /// An operation named a node that is not in the document.
    #[error("no node with id '{node}'")]
    UnknownNode {
        /// The missing id.
        node: String,
    },
    /// An edge endpoint that is not `node.port`.
    #[error("edge endpoint '{text}' is not of the form node.port")]
    BadEndpoint {
        /// The endpoint as written.
        text: String,
    },
    /// An edge to or from a node that does not exist.
    #[error("edge {from} -> {to}: no node '{node}'")]
    EdgeMissingNode {
        /// Source endpoint.
        from: String,
        /// Destination endpoint.
        to: String,
        /// The missing node id.
        node: String,
    },
    /// An edge to or from a port the node does not have.
    #[error("edge {from} -> {to}: node '{node}' ({kind}) has no {direction} port '{port}' (its {direction} ports: {known})")]
    EdgeMissingPort {
        /// Source endpoint.
        from: String,
        /// Destination endpoint.
        to: String,
        /// Node id.
        node: String,
        /// Node kind.
        kind: String,
        /// "input" or "output".
        direction: &'static str,
        /// The missing port.
        port: String,
        /// The ports the node has in that direction.
        known: String,
    },
    /// An edge between ports of incompatible types.
    #[error("edge {from} -> {to}: port type mismatch, {from} produces {from_type} but {to} accepts {to_types}")]
    TypeMismatch {
        /// Source endpoint.
        from: String,
        /// Destination endpoint.
        to: String,
        /// Type produced by the source.
        from_type: PortType,
        /// Types accepted by the destination.
        to_types: String,
    },
    /// An edge that would close a cycle.
    #[error("edge {from} -> {to}: would close a cycle (node '{to_node}' already feeds node '{from_node}')")]
    Cycle {
        /// Source endpoint.
        from: String,
        /// Destination endpoint.
        to: String,
        /// Source node id.
        from_node: String,
        /// Destination node id.
        to_node: String,
    },
    /// A second edge into one input port.
    #[error("edge {from} -> {to}: input {to} is already connected from {existing}")]
    InputTaken {
        /// Source endpoint.
        from: String,
        /// Destination endpoint.
        to: String,
        /// The edge already there.
        existing: String,
    },
    /// Key-frames that cannot be used.
    #[error("key-frames on '{target}': {reason}")]
    BadKeys {
        /// `node.param`.
        target: String,
        /// What is wrong.
        reason: String,
    },
    /// The file's format version is newer than this build understands.
    #[error("format version {found} is newer than this build supports ({supported}); use a newer Tyndall")]
    VersionTooNew {
        /// Version in the file.
        found: u32,
        /// Newest version supported.
        supported: u32,
    },
    /// Reading or writing the file failed.
    #[error("{0}")]
    Io(String),
    /// A group definition is inconsistent (a port or knob naming a missing inner endpoint, a
    /// knob range wider than its target's, …).
    #[error("group '{group}': {message}")]
    Group {
        /// The group's name.
        group: String,
        /// What is wrong.
        message: String,
    },
    /// A group contains itself, directly or through other groups.
    #[error("group '{group}' contains itself: {chain}")]
    GroupCycle {
        /// The group.
        group: String,
        /// The chain of groups, `A → B → A`.
        chain: String,
    },
    /// A node names a library group that cannot be found or does not match.
    #[error("node '{node}': library group '{group}' {reason}")]
    LibraryGroup {
        /// The node (or the group that references it).
        node: String,
        /// The group's name (and version).
        group: String,
        /// Why: not found in the folders searched, or another version.
        reason: String,
    },
}

/// A 1-based line and column in a graph file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Location {
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1.
    pub col: usize,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.line, self.col)
    }
}

/// A [`GraphError`] found while loading a file, with the file and where in it.
#[derive(Debug, Clone, Error)]
pub struct LoadError {
    /// The file (or `<string>`).
    pub file: PathBuf,
    /// Where the text is at fault, when a place in the text can be named.
    pub location: Option<Location>,
    /// What is wrong.
    pub error: GraphError,
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.location {
            Some(loc) => write!(f, "{}:{}: {}", self.file.display(), loc, self.error),
            None => write!(f, "{}: {}", self.file.display(), self.error),
        }
    }
}
