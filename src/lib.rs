//! Tyndall: a GPU node-graph compositor for stylizing volumetric light shafts.
//!
//! This package is the `tyndall` command line ([`cli`]) and one name for the workspace's
//! layers (ARCHITECTURE.md in the repository is the map), re-exported here so that tests and
//! examples reach them as `tyndall::…`: [`graph`] is the document, [`eval`] the evaluator and
//! the node interface, [`gpu`] the wgpu context, [`scene`] scenes, [`io`] image files (these
//! five are the `tyndall-engine` crate); [`nodes`] the node kinds (techniques) and their
//! registry (`tyndall-nodes`); [`editor`] the egui editor (`tyndall-editor`) and [`tools`] its
//! editing tools (`tyndall-tools`);
//! [`bench`](mod@bench) speed-against-accuracy measurements (`tyndall-bench`).
#![deny(missing_docs)]

pub mod cli;

pub use tyndall_bench as bench;
pub use tyndall_editor as editor;
pub use tyndall_engine::{
    choice_enum, colour, colour_pass, display, eval, gpu, graph, io, params, scene, trace, uniforms,
};
pub use tyndall_nodes as nodes;
pub use tyndall_tools as tools;
