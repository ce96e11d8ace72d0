//! The mip chain of a volume: level k + 1 is the mean of the (up to) 2×2×2 texels of level k it
//! covers. `NoiseVolume` and `BlendVolume` build it after writing level 0; a kind that calls
//! [`build`] lists [`SHADER`] in its `NodeDecl::shaders`.

use tyndall_engine::gpu::Recorder;
use tyndall_engine::gpu::{Bind, GpuError, GpuVolume, Shader};

/// The pass (`shaders/algorithms/volume_mips.wgsl`, entry point `mip`).
pub const SHADER: Shader = crate::shader(
    "algorithms/volume_mips",
    include_str!("../../shaders/algorithms/volume_mips.wgsl"),
);

/// Fill levels 1… of `v` from level 0, one pass per level.
pub fn build(gpu: &Recorder, v: &GpuVolume) -> Result<(), GpuError> {
    for level in 1..v.mips() {
        gpu.dispatch_3d(
            SHADER,
            "mip",
            &[
                ("out_level", Bind::VolumeLevel(v, level)),
                ("src_level", Bind::VolumeLevelRead(v, level - 1)),
            ],
            v.level_size(level),
        )?;
    }
    Ok(())
}
