//! Tyndall's editor tools, each a [`Tool`](tyndall_editor::Tool) in one file, over the data
//! blocks of the nodes that name it in their declaration (`NodeDecl::tools`):
//!
//! | id | file | edits |
//! |---|---|---|
//! | `layer_list` | [`layer_list`] | a transfer function's layer stack; a viewer click adds a constraint anchored to the surface under it |
//! | `stroke_painting` | [`stroke_painting`] | strokes painted over the viewer, per view, for a light-map solve |
//! | `splat_brush` | [`splat_brush`] | the 3D splat brush: painting a volume (a node naming `splat_volume`) from the viewer |
//!
//! Adding a tool: a file here with a type implementing `Tool`, and one line in [`registry`]
//! (CONTRIBUTING.md walks through it). The editor core (`tyndall-editor`) knows no tool.
#![deny(missing_docs)]

pub mod layer_list;
pub mod splat_brush;
pub mod stroke_painting;

use tyndall_editor::Tools;

/// Every tool Tyndall's editor offers.
pub fn registry() -> Tools {
    Tools::new()
        .with(layer_list::TfPanel::default())
        .with(stroke_painting::StrokePanel::default())
        .with(splat_brush::BrushPanel::default())
}
