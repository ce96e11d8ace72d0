//! Tyndall: a GPU node-graph compositor for stylizing volumetric light shafts.
//!
//! Layout (ARCHITECTURE.md in the repository is the map): [`graph`] is the document, [`eval`]
//! the evaluator and the node interface, [`gpu`] the wgpu context, [`nodes`] the node kinds
//! (techniques) and their registry, [`scene`] scenes, [`io`] image files, [`cli`] the command
//! line, [`editor`] the egui editor, [`bench`](mod@bench) speed-against-accuracy measurements.
#![deny(missing_docs)]

pub mod bench;
pub mod cli;
pub mod editor;
pub mod eval;
pub mod gpu;
pub mod graph;
pub mod io;
#[path = "../nodes/mod.rs"]
pub mod nodes;
pub mod scene;
