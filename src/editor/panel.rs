//! Pieces the tools' panels share (see [`crate::tool`]).

use eframe::egui;

use crate::EditorState;

/// The colour of refusals and parse errors in the panels.
pub const ERROR: egui::Color32 = egui::Color32::from_rgb(240, 90, 80);

/// Node `id`'s data block parsed into `T`, or `None` after showing the parse error in the panel
/// (the panel then shows nothing it could edit wrongly).
pub fn data_block<T: serde::de::DeserializeOwned + Default>(
    ui: &mut egui::Ui,
    state: &EditorState,
    id: &str,
) -> Option<T> {
    match state.node_data::<T>(id) {
        Ok(d) => Some(d),
        Err(e) => {
            ui.colored_label(ERROR, format!("data block: {e}"));
            None
        }
    }
}
