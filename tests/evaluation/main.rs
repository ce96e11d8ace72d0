//! The evaluator: what runs, caching, key-frames and animation, earlier frames, and every parameter at its extremes.
//!
//! One test binary per area (`cargo test --test evaluation`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod animation;
mod eval;
mod stability;
mod temporal;
