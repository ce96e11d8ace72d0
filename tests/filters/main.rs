//! Image-space techniques: filters, morphology, hole filling, epipolar operators, depth-aware upsampling.
//!
//! One test binary per area (`cargo test --test filters`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod clear;
mod epipolar;
mod filters;
mod holes;
mod morphology;
mod upsample;
