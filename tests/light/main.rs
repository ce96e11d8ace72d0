//! Light and media: single scattering (every method, against CPU references and Cycles), phase functions, sky, soft visibility, volumes.
//!
//! One test binary per area (`cargo test --test light`); each module was a binary of its own.

#[macro_use]
#[path = "../common/mod.rs"]
mod common;

mod cycles;
mod density;
mod light_model;
mod lights;
mod phase;
mod phenomena;
mod reach;
mod scattering;
mod sky;
mod soft;
mod soft_lamps;
mod volumes;
