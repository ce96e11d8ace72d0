//! Every node kind on the GPU against its CPU reference, and every preset against its look.
//!
//! One test binary per area (`cargo test --test nodes`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod colour;
mod looks;
mod nodes_gpu;
mod ray_cast;
