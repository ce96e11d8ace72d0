//! `NoiseVolume`: 3D Perlin noise in [0, 1] for heterogeneous media (SPEC §6, seed 000 §4.3),
//! mip-mapped so a sample can choose its frequency (a coarser level = lower frequencies).
//!
//! N(q) = clamp(½ + ½ Σ_{o<octaves} pᵒ P(2ᵒ q) / Σ pᵒ, 0, 1), P Perlin's improved noise on a
//! hashed integer lattice (octave o uses seed + o), at q = (texel centre / resolution) ·
//! frequency plus (0, 0, speed · time): with `speed` ≠ 0 the noise drifts through the volume as
//! frames advance. Level k of the mip chain is the 2×2×2 mean of level k − 1, down to one texel.
//! The volume covers a world-space box: the bounds of a connected `scene`, else
//! `box_min`…`box_max`.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `scene` | in | Scene | its bounds place the volume |
//! | `volume` | out | Volume | the noise and its box |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `resolution` | Int | 64 | 32…256 texels | side of the cube |
//! | `frequency` | Float | 4 | 0…256 cells | noise cells across the volume (octave 0) |
//! | `octaves` | Int | 3 | 1…8 | |
//! | `persistence` | Float | 0.5 | 0…1 | amplitude ratio between octaves |
//! | `seed` | Int | 1 | 0…2³¹ | |
//! | `speed` | Float | 0 | −100…100 cells/frame | drift along z with time |
//! | `box_min`, `box_max` | Vec3 | (−5, 0, −5), (5, 5, 5) | ±1e6 m | the box without a scene |

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use tyndall_engine::eval::{KeyInput, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuError, GpuVolume, Shader};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};

use crate::algorithms::volume_mips;

/// The `NoiseVolume` node kind.
pub struct NoiseVolume;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        resolution: i64 = ParamSpec::int("resolution", 64, 32, 256, "texels", "Side of the cube."),
        frequency: f32 = ParamSpec::float("frequency", 4.0, 0.0, 256.0, "cells", "Noise cells across the volume at the first octave."),
        octaves: i64 = ParamSpec::int("octaves", 3, 1, 8, "", "Octaves summed (each twice the frequency)."),
        persistence: f32 = ParamSpec::float("persistence", 0.5, 0.0, 1.0, "", "Amplitude ratio between octaves."),
        seed: i64 = ParamSpec::int("seed", 1, 0, 2147483647, "", "Variation."),
        speed: f32 = ParamSpec::float("speed", 0.0, -100.0, 100.0, "cells/frame", "Drift of the noise along z per frame (animation)."),
        box_min: [f32; 3] = ParamSpec::vec3("box_min", [-5.0, 0.0, -5.0], -1e6, 1e6, "m", "Low corner of the volume when no scene is connected."),
        box_max: [f32; 3] = ParamSpec::vec3("box_max", [5.0, 5.0, 5.0], -1e6, 1e6, "m", "High corner of the volume when no scene is connected."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "NoiseVolume",
    category: "Medium",
    doc: "3D Perlin noise in [0, 1] (octaves, persistence, seed, drift with time), mip-mapped, covering the scene's bounds or a box.",
    inputs: &[PortSpec::input("scene", &[PortType::Scene], "Its bounds place the volume (else box_min…box_max).")],
    outputs: &[PortSpec::output("volume", &[PortType::Volume], "The noise volume and its world-space box.")],
    params: Params::SPECS,
})
.shaders(&[SHADER, volume_mips::SHADER])
.uniforms(&[NoiseParams::LAYOUT]);

const SHADER: Shader = crate::shader("noise_volume", include_str!("../shaders/noise_volume.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/noise_volume.wgsl` (struct `Params`).
    pub struct NoiseParams as "Params" {
        /// Level-0 size.
        pub size: [u32; 3],
        /// Octaves.
        pub octaves: u32,
        /// Domain offset (the drift).
        pub offset: [f32; 3],
        /// Cells across the volume.
        pub frequency: f32,
        /// Amplitude ratio.
        pub persistence: f32,
        /// Seed.
        pub seed: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

fn hash(i: [i32; 3], seed: u32) -> u32 {
    crate::algorithms::shader_lib::pcg(
        (i[0] as u32).wrapping_mul(73_856_093)
            ^ (i[1] as u32).wrapping_mul(19_349_663)
            ^ (i[2] as u32).wrapping_mul(83_492_791)
            ^ seed.wrapping_mul(2_654_435_761),
    )
}

fn grad(h: u32, p: [f32; 3]) -> f32 {
    let k = h & 15;
    let u = if k < 8 { p[0] } else { p[1] };
    let v = if k < 4 {
        p[1]
    } else if k == 12 || k == 14 {
        p[0]
    } else {
        p[2]
    };
    (if k & 1 == 0 { u } else { -u }) + (if k & 2 == 0 { v } else { -v })
}

fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// Perlin's improved noise at p (about −1…1).
pub fn perlin(p: [f32; 3], seed: u32) -> f32 {
    let i = p.map(|v| v.floor() as i32);
    let f = [0, 1, 2].map(|k| p[k] - p[k].floor());
    let u = f.map(fade);
    let mut c = [0.0f32; 8];
    for (k, ck) in c.iter_mut().enumerate() {
        let o = [(k & 1) as i32, ((k >> 1) & 1) as i32, ((k >> 2) & 1) as i32];
        *ck = grad(
            hash([i[0] + o[0], i[1] + o[1], i[2] + o[2]], seed),
            [f[0] - o[0] as f32, f[1] - o[1] as f32, f[2] - o[2] as f32],
        );
    }
    let x00 = lerp(c[0], c[1], u[0]);
    let x10 = lerp(c[2], c[3], u[0]);
    let x01 = lerp(c[4], c[5], u[0]);
    let x11 = lerp(c[6], c[7], u[0]);
    lerp(lerp(x00, x10, u[1]), lerp(x01, x11, u[1]), u[2])
}

/// CPU reference of level 0: x fastest, then y, then z.
pub fn reference(p: &NoiseParams) -> Vec<f32> {
    let [w, h, d] = p.size;
    let mut out = Vec::with_capacity((w * h * d) as usize);
    for z in 0..d {
        for y in 0..h {
            for x in 0..w {
                let q = [
                    (x as f32 + 0.5) / w as f32 * p.frequency + p.offset[0],
                    (y as f32 + 0.5) / h as f32 * p.frequency + p.offset[1],
                    (z as f32 + 0.5) / d as f32 * p.frequency + p.offset[2],
                ];
                let (mut sum, mut norm, mut amp, mut scale) = (0.0f32, 0.0f32, 1.0f32, 1.0f32);
                for o in 0..p.octaves {
                    sum += amp * perlin(q.map(|v| v * scale), p.seed.wrapping_add(o));
                    norm += amp;
                    amp *= p.persistence;
                    scale *= 2.0;
                }
                out.push((0.5 + 0.5 * sum / norm.max(1e-12)).clamp(0.0, 1.0));
            }
        }
    }
    out
}

/// CPU reference of one mip step: the 2×2×2 means of `below` (size `s`).
pub fn reference_mip(below: &[f32], s: [u32; 3]) -> Vec<f32> {
    let n = tyndall_engine::gpu::mip_size(s, 1);
    let mut out = Vec::with_capacity((n[0] * n[1] * n[2]) as usize);
    for z in 0..n[2] {
        for y in 0..n[1] {
            for x in 0..n[0] {
                let (mut sum, mut c) = (0.0f32, 0.0f32);
                for k in 0..8u32 {
                    let q = [
                        x * 2 + (k & 1),
                        y * 2 + ((k >> 1) & 1),
                        z * 2 + ((k >> 2) & 1),
                    ];
                    if q[0] < s[0] && q[1] < s[1] && q[2] < s[2] {
                        sum += below[((q[2] * s[1] + q[1]) * s[0] + q[0]) as usize];
                        c += 1.0;
                    }
                }
                out.push(sum / c.max(1.0));
            }
        }
    }
    out
}

/// Build the noise volume and its mip chain on the GPU.
pub fn build(gpu: &Recorder, p: &NoiseParams) -> Result<GpuVolume, GpuError> {
    let v = gpu.volume(p.size)?;
    gpu.dispatch_3d(
        SHADER,
        "noise",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(p))),
            ("out_level", Bind::VolumeLevel(&v, 0)),
        ],
        p.size,
    )?;
    volume_mips::build(gpu, &v)?;
    Ok(v)
}

impl NodeKind for NoiseVolume {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn volatile_key(&self, key: &KeyInput) -> u64 {
        // The drift makes the volume depend on the time.
        match Params::from_params(key.params) {
            Ok(p) if p.speed != 0.0 => key.time.to_bits(),
            _ => 0,
        }
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let prm = Params::from_ctx(ctx)?;
        let n = ctx.side("resolution", prm.resolution, 3)?;
        ctx.check_bytes("resolution", u64::from(n).pow(3) * 4)?;
        let drift = prm.speed * ctx.time as f32;
        let p = NoiseParams {
            size: [n; 3],
            octaves: prm.octaves as u32,
            offset: [0.0, 0.0, drift],
            frequency: prm.frequency,
            persistence: prm.persistence,
            seed: prm.seed as u32,
            _pad0: 0,
            _pad1: 0,
        };
        let bounds = super::util::volume_box(ctx, [prm.box_min, prm.box_max])?;
        let v = build(ctx.gpu, &p)?;
        ctx.set("volume", PortValue::Volume(Arc::new(v), bounds));
        Ok(())
    }
}
