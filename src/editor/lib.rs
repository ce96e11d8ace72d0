//! The editor (`tyndall edit`). This module holds the document-side core the egui window is a
//! view of: every change as an undoable command on the petgraph document, copy/paste and
//! duplicate with fresh ids, preset libraries, atomic save and autosave with recovery.
//! The window (`app`) draws the canvas (`canvas`), viewer (`view`), parameters, timeline and
//! preset browser; evaluation runs on a worker thread (`worker`). What edits a node beyond
//! its parameters is a [`Tool`] ([`tool`]); the window is opened with the [`Tools`] it offers
//! (Tyndall's are the `tyndall-tools` crate). This crate names no node kind and no tool.

#![deny(missing_docs)]

mod app;
pub mod bench_panel;
mod canvas;
pub mod panel;
mod state;
pub mod tool;
pub mod view;
pub mod worker;

/// The display pass (in the engine, which `tyndall bench interactive` shares).
pub use tyndall_engine::display;

pub use app::pump::ProxyState;
pub use app::{run, user_preset_folder, EditorApp, Zoom, VIEW_SIZE};
pub use canvas::port_colour;
pub use state::{
    autosave_path, list_presets, preset_thumbnail, EditorError, EditorState, PresetEntry,
    UNDO_LIMIT,
};
pub use tool::{stroke_points, Jobs, Tool, ToolContext, Tools};
