//! The document: graph files, formats, edits, layout, groups and libraries.
//!
//! One test binary per area (`cargo test --test document`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod graph;
mod groups;
