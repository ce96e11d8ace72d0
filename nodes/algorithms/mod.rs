//! Algorithms several techniques share: a least-squares solver ([`cgls`]), a multigrid Poisson
//! solver ([`multigrid`]), the Lorenz–Mie series ([`lorenz_mie`]), ice crystals' geometric optics ([`ice_optics`]), phase-function tables and
//! models ([`phase_function`]), GPU passes several kinds dispatch — point sampling
//! ([`point_sample`]), a volume's mip chain ([`volume_mips`]), a scene's G-buffer
//! ([`g_buffer`]), a map's quantile ([`quantile`]), a seedable random generator ([`random`]), a point light's cube atlas padded across its seams ([`cube_atlas`]), each with its shader under `shaders/algorithms/` —, and the CPU twins of the
//! WGSL library ([`shader_lib`], mirroring `shaders/lib/`). Nothing here is a node and nothing
//! here names one; nodes call it, and a kind that dispatches a shared pass lists its shader.

pub mod box_volume;
pub mod cgls;
pub mod cube_atlas;
pub mod g_buffer;
pub mod ice_optics;
pub mod lorenz_mie;
pub mod multigrid;
pub mod ocio;
pub mod phase_function;
pub mod point_sample;
pub mod quantile;
pub mod random;
pub mod ray_cast;
pub mod shader_lib;
pub mod volume_mips;
