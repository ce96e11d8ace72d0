//! The editor (`tyndall edit`). This module holds the document-side core the egui window is a
//! view of: every change as an undoable command on the petgraph document, copy/paste and
//! duplicate with fresh ids, preset libraries, atomic save and autosave with recovery.
//! The window itself (node canvas, viewer, panels) is not written yet.

mod state;

pub use state::{autosave_path, list_presets, EditorError, EditorState, PresetEntry, UNDO_LIMIT};
