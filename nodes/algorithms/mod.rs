//! Algorithms several techniques share: the CPU twins of the WGSL library (`shader_lib`,
//! mirroring `shaders/lib/`). Nothing here is a node; nodes call it.

pub mod shader_lib;
