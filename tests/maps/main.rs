//! Colour from maps: light maps (projected and solved from strokes) and transfer functions.
//!
//! One test binary per area (`cargo test --test maps`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod light_map;
mod transfer_function;
