//! The q-quantile of a map on the GPU, with no read-back: radix select over order-preserving
//! keys of the values' bits (`shaders/algorithms/quantile.wgsl`) — four histogram passes of 8
//! bits, each followed by one invocation picking the bin that holds the k-th key. The selected
//! key stays in a small storage buffer ([`KEY_WORD`] of [`select`]'s result) for a later pass,
//! or is read back (the buffer's 1,036 bytes) when the CPU needs the number. Bit for bit
//! [`reference()`]. Hole maps' calibrated thresholds and transfer functions' automatic depth
//! ranges use it.

use tyndall_engine::gpu::Recorder;
use tyndall_engine::gpu::{Bind, GpuBuffer, GpuError, GpuTexture, Shader};

/// The passes; a kind that calls [`select`] lists it in its `NodeDecl::shaders`, and
/// [`QuantileParams::LAYOUT`] in its uniforms.
pub const SHADER: Shader = crate::shader(
    "algorithms/quantile",
    include_str!("../../shaders/algorithms/quantile.wgsl"),
);

tyndall_engine::uniforms! {
    /// The passes' parameter block.
    pub struct QuantileParams as "QuantileParams" {
        /// q as a 32-bit fraction ([`fraction_bits`]).
        pub q: u32,
        /// 0: rank ⌊q·n⌋, 1: rank round(q·(n − 1)) ([`Rank`]).
        pub rank: u32,
        /// The digit of a histogram or pick pass: 24, 16, 8, 0.
        pub shift: u32,
        /// 1: only values below `limit` take part.
        pub use_limit: u32,
        /// See `use_limit`.
        pub limit: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// Words of [`select`]'s buffer: 256 bins, n, k, the key.
pub const WORDS: u32 = 259;
/// The word holding the number of values that took part.
pub const N_WORD: usize = 256;
/// The word holding the selected key ([`value_of`] gives the value).
pub const KEY_WORD: usize = 258;

/// Which rank of the n values taking part (sorted) the q-quantile is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rank {
    /// ⌊q_b·n / 2³²⌋ (within one of ⌊q·n⌋): exactly that many values lie below it.
    Floor,
    /// round(q_b·(n − 1) / 2³²) (within one of round(q·(n − 1))): a percentile.
    Round,
}

/// How the histograms count (same result, different cost).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Histogram {
    /// Every texel adds to the shared bins: for CPU drivers (2.3× faster than `Workgroup` on
    /// lavapipe, where workgroup memory and barriers cost more than the atomics they save).
    Shared,
    /// Each workgroup counts into its own bins first: for GPUs (a map's top digit takes a few
    /// bins per workgroup, so far fewer atomics reach the shared bins).
    Workgroup,
}

impl Histogram {
    /// The form for `gpu`'s adapter.
    pub fn for_adapter(gpu: &Recorder) -> Self {
        if gpu.is_cpu() {
            Self::Shared
        } else {
            Self::Workgroup
        }
    }
}

/// q (0…1) as the 32-bit fraction q_b = ⌊q·2³²⌋.
pub fn fraction_bits(q: f64) -> u32 {
    (q * 4_294_967_296.0).floor().clamp(0.0, u32::MAX as f64) as u32
}

/// The rank of the `rank` kind for q among `n` values (n > 0).
pub fn rank_of(q: f64, rank: Rank, n: usize) -> usize {
    let qb = fraction_bits(q) as u64;
    let k = match rank {
        Rank::Floor => (qb * n as u64) >> 32,
        Rank::Round => (qb * (n as u64 - 1) + (1 << 31)) >> 32,
    };
    (k as usize).min(n - 1)
}

/// CPU reference: of the values taking part — finite, and below `limit` when given — sorted
/// with `f32::total_cmp`, the one at [`rank_of`]; `None` when none takes part.
pub fn reference(values: &[f32], q: f64, rank: Rank, limit: Option<f32>) -> Option<f32> {
    let mut v: Vec<f32> = values
        .iter()
        .copied()
        .filter(|x| x.is_finite() && limit.is_none_or(|l| *x < l))
        .collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f32::total_cmp);
    Some(v[rank_of(q, rank, v.len())])
}

/// The value of a key (the inverse of the shader's `key_of`).
pub fn value_of(key: u32) -> f32 {
    f32::from_bits(if key & 0x8000_0000 != 0 {
        key & 0x7fff_ffff
    } else {
        !key
    })
}

/// Select the q-quantile of `values` (channel r) on the GPU; the result's [`KEY_WORD`] holds
/// its key and [`N_WORD`] how many values took part (0: none, the key means nothing).
pub fn select(
    gpu: &Recorder,
    values: &GpuTexture,
    q: f64,
    rank: Rank,
    limit: Option<f32>,
    form: Histogram,
) -> Result<GpuBuffer, GpuError> {
    let sel = gpu.buffer_zeroed(WORDS)?;
    let entry = match form {
        Histogram::Shared => "quantile_histogram",
        Histogram::Workgroup => "quantile_histogram_workgroup",
    };
    for shift in [24, 16, 8, 0] {
        let u = QuantileParams {
            q: fraction_bits(q),
            rank: u32::from(rank == Rank::Round),
            shift,
            use_limit: u32::from(limit.is_some()),
            limit: limit.unwrap_or(0.0),
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        };
        let binds = [
            ("QP", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("values", Bind::Texture(values)),
            ("sel", Bind::Buffer(&sel)),
        ];
        gpu.dispatch(SHADER, entry, &binds, values.width, values.height)?;
        gpu.dispatch(SHADER, "quantile_pick", &[binds[0], binds[2]], 1, 1)?;
    }
    Ok(sel)
}

/// The value a [`select`] chose, read back (the buffer's 1,036 bytes), or `None` when no value
/// took part.
pub fn read_value(gpu: &Recorder, sel: &GpuBuffer) -> Result<Option<f32>, GpuError> {
    let words = gpu.read_buffer_i32(sel)?;
    Ok((words[N_WORD] != 0).then(|| value_of(words[KEY_WORD] as u32)))
}
