//! Parameter blocks (`var<uniform>` in the WGSL): bound as uniform buffers, or on Mesa's CPU
//! drivers for small passes as read-only storage buffers
//! ([`Capabilities::params_in_storage_below`]; [`Capabilities::adapt_source`] rewrites the
//! declaration, and a block valid as a uniform is laid out alike as storage).
//!
//! Why: those drivers *inline* uniform values that steer a branch or a loop into the shader
//! and compile that variant at every dispatch that binds a new buffer (Debian 12's Mesa 22.3
//! keeps no cache of them). On a big pass the specialised code pays for its compile (a 2048²
//! polygon closure runs 2× faster with it); on a small one the compile is the whole cost (a
//! cold chain of 10,000 Math nodes at 8×8: 10 s of JIT, 1.3 s without). Storage buffers are
//! never inlined.

use super::adapter::Capabilities;

/// Where [`Capabilities::params_in_storage_below`] is set on Mesa's CPU drivers: 64² invocations.
/// Measured there: a chain of 300 Math nodes runs 3× faster from storage at 8×8 and at 63×63
/// (0.10 s against 0.32 s), since each uniform dispatch compiles ~0.7 ms; but a pass of few
/// invocations can still be heavy — the light-map solve's constraint-row marches (9–19
/// thousand invocations of 768 steps) run 15 % faster inlined, a 2048² polygon closure 2×
/// (0.84–1.0 s against 2.0 s, session 19; the command is in BENCHMARKS.md, "Occluder
/// manipulation").
pub const PARAMS_IN_STORAGE_BELOW: u64 = 64 * 64;

/// [`Capabilities::params_in_storage_below`] as read off an adapter: [`PARAMS_IN_STORAGE_BELOW`]
/// on Mesa's CPU drivers whose vertex stages may read storage buffers (rasterisation binds the
/// block there too, which GL may not allow), else 0.
///
/// Never on wgpu's GL backend: llvmpipe's GLSL path read a read-only storage block as zeros in
/// the phase tables' reductions (`shaders/phase.wgsl`: `P.width` in the loop condition of a
/// function that then meets a workgroup barrier), so every `Phase` table of `tests/light/phase.rs`
/// came out empty, with no error (`TYNDALL_GPU_PARAMS=storage WGPU_BACKEND=gl cargo test --test
/// phase` still shows it; the same passes in another test process read right, so the driver's
/// fault was not pinned down further). The same block as a uniform, and the same WGSL through
/// SPIR-V on lavapipe, read right every time. Hoisting the read into a local made that shader
/// work, but nothing would find the next shader of that shape, so GL keeps the path every
/// driver reads as written.
pub(super) fn default_params_in_storage_below(adapter: &wgpu::Adapter) -> u64 {
    let vertex_storage = adapter
        .get_downlevel_capabilities()
        .flags
        .contains(wgpu::DownlevelFlags::VERTEX_STORAGE);
    let gl = adapter.get_info().backend == wgpu::Backend::Gl;
    if mesa_cpu(&adapter.get_info()) && vertex_storage && !gl {
        PARAMS_IN_STORAGE_BELOW
    } else {
        0
    }
}

impl Capabilities {
    /// Whether a pass of `invocations` invocations gets its parameter block as a storage
    /// buffer (see [`Capabilities::params_in_storage_below`]).
    pub fn params_in_storage(&self, invocations: u64) -> bool {
        invocations < self.params_in_storage_below
    }

    /// The binding type of a pass's parameter block, as a storage buffer or not.
    pub fn params_binding(storage: bool) -> wgpu::BufferBindingType {
        if storage {
            wgpu::BufferBindingType::Storage { read_only: true }
        } else {
            wgpu::BufferBindingType::Uniform
        }
    }

    /// The usages of a pass's parameter buffer, as a storage buffer or not.
    pub fn params_usage(storage: bool) -> wgpu::BufferUsages {
        let kind = if storage {
            wgpu::BufferUsages::STORAGE
        } else {
            wgpu::BufferUsages::UNIFORM
        };
        kind | wgpu::BufferUsages::COPY_DST
    }
}

/// Whether an adapter is one of Mesa's CPU drivers (lavapipe on Vulkan, llvmpipe on GL), which
/// inline uniform values into shaders (see [`Capabilities::params_in_storage_below`]).
fn mesa_cpu(info: &wgpu::AdapterInfo) -> bool {
    info.device_type == wgpu::DeviceType::Cpu
        && ["llvmpipe", "lavapipe"]
            .iter()
            .any(|n| info.name.to_lowercase().contains(n))
}
