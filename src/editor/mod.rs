//! The editor (`tyndall edit`). This module holds the document-side core the egui window is a
//! view of: every change as an undoable command on the petgraph document, copy/paste and
//! duplicate with fresh ids, preset libraries, atomic save and autosave with recovery.
//! The window (`app`) is an early version: canvas, parameters and a viewer.

mod app;
mod state;

pub use app::{port_colour, run, EditorApp};
pub use state::{autosave_path, list_presets, EditorError, EditorState, PresetEntry, UNDO_LIMIT};
