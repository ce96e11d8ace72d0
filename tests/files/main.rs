//! Files from elsewhere: image reading and writing, plates and their depth.
//!
//! One test binary per area (`cargo test --test files`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod colour;
mod cryptomatte;
mod deep;
mod io;
mod plate;
mod vdb;
