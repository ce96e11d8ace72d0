//! Tyndall: a GPU node-graph compositor for stylizing volumetric light shafts.
//!
//! Layout (see DESIGN.md): [`graph`] is the document, [`eval`] the evaluator, [`gpu`] the wgpu
//! context, [`io`] image files, [`nodes`] the node kinds and their registry, [`cli`] the command
//! line.
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
