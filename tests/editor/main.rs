//! The egui editor: the document core, the brush, the colour tools, and the window driven headless (egui_kittest snapshots).
//!
//! One test binary per area (`cargo test --test editor`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod brush;
mod colour;
mod display;
mod state;
mod ui;
