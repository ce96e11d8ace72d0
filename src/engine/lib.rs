//! Tyndall's engine: everything a node graph needs to be loaded, evaluated and written, and
//! nothing of a user interface or of any one technique.
//!
//! [`graph`] is the document, [`eval`] the evaluator and the node interface (`NodeKind`,
//! `RunCtx`, the `Registry` a technique crate fills), [`gpu`] the wgpu context, [`scene`]
//! scenes (built-in and glTF), [`io`] image files. The techniques (the `tyndall-nodes` crate),
//! the editor, the benchmark harness and the command line are built on it; ARCHITECTURE.md in
//! the repository is the map.
#![deny(missing_docs)]

pub mod colour;
pub mod colour_pass;
pub mod display;
pub mod eval;
pub mod gpu;
pub mod graph;
pub mod io;
pub mod scene;
pub mod trace;
