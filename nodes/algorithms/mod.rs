//! Algorithms several techniques share: a least-squares solver ([`cgls`]), a multigrid Poisson
//! solver ([`multigrid`]), and the CPU twins of the WGSL library ([`shader_lib`], mirroring
//! `shaders/lib/`). Nothing here is a node and nothing here names one; nodes call it.

pub mod cgls;
pub mod multigrid;
pub mod shader_lib;
