//! `PerlinNoise2D`: 2D gradient noise in [0, 1] for hole maps (SPEC §4, seed 000 eq. 4–5).
//!
//! The lookup point of texel t (normalised map coordinates) is `q = t · g · f` (grid size ×
//! frequency). `mode = seed` sums octaves as SPEC §4 reads the garbled eq. 5,
//! `N(q) = Σ_{i<o} p^i · P(q / max(1, o − i − 1))`; `mode = fbm` is classic fractal Brownian
//! motion `Σ p^i · P(2^i q)`. Both are divided by `Σ p^i` and mapped to [0, 1]. With `speed` ≠ 0
//! the noise animates by the seed's two-step lookup: rotate q by `time · speed` radians, look
//! the noise up, use the value as an offset of the original point, look up again.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `like` | in | ShadowMap \| Scalar (optional) | take the output size from this map |
//! | `noise` | out | Scalar | N ∈ [0, 1] |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `frequency` | Float | 1 | 0…1e4 | f; 0 gives a constant map |
//! | `grid` | Float | 16 | 0…4096 cells | g, gradient cells across the map |
//! | `octaves` | Int | 4 | 1…8 | o |
//! | `persistence` | Float | 0.5 | 0…1 | p, amplitude ratio between octaves |
//! | `seed` | Int | 0 | 0…2³¹ | lattice hash seed |
//! | `mode` | Enum | seed | seed, fbm | octave scheme |
//! | `time` | Float | 0 | ±1e6 | animation time (key-frame it) |
//! | `speed` | Float | 0 | ±1e3 rad per unit time | rotation speed of the two-step lookup; 0 = static |
//! | `width`, `height` | Int | 0 | 0…16384 | size when `like` is unconnected; 0 = evaluation size |

use std::sync::Arc;

use super::util::size_or_default;
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `PerlinNoise2D` node kind.
pub struct PerlinNoise2D;

/// Octave schemes.
pub const MODES: &[&str] = Mode::NAMES;

tyndall_engine::choice_enum! {
    /// Octave sums, in the shader's order.
    pub enum Mode { Seed = "seed", Fbm = "fbm" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        frequency: f64 = ParamSpec::float("frequency", 1.0, 0.0, 1e4, "", "Frequency f (lookup point t·g·f); 0 gives a constant map."),
        grid: f64 = ParamSpec::float("grid", 16.0, 0.0, 4096.0, "cells", "Gradient grid size g across the map."),
        octaves: i64 = ParamSpec::int("octaves", 4, 1, 8, "", "Number of octaves o."),
        persistence: f32 = ParamSpec::float("persistence", 0.5, 0.0, 1.0, "", "Amplitude ratio p between octaves."),
        seed: i64 = ParamSpec::int("seed", 0, 0, 2147483647, "", "Lattice hash seed."),
        mode: Mode = ParamSpec::choice("mode", Mode::NAMES, "seed", "seed: eq. 5 as read in SPEC §4; fbm: classic fBm (lacunarity 2)."),
        time: f64 = ParamSpec::float("time", 0.0, -1e6, 1e6, "", "Animation time (key-frame it)."),
        speed: f64 = ParamSpec::float("speed", 0.0, -1e3, 1e3, "rad/unit", "Rotation speed of the two-step lookup; 0 = static."),
        width: i64 = ParamSpec::int("width", 0, 0, 16384, "texels", "Width when `like` is unconnected; 0 = evaluation size."),
        height: i64 = ParamSpec::int("height", 0, 0, 16384, "texels", "Height when `like` is unconnected; 0 = evaluation size."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "PerlinNoise2D",
    category: "Occluders",
    doc: "2D Perlin noise in [0, 1] (seed eq. 5 octaves or fBm), optionally animated by the two-step rotated lookup.",
    inputs: &[PortSpec::input("like", &[PortType::ShadowMap, PortType::Scalar], "Take the output size from this map.")],
    outputs: &[PortSpec::output("noise", &[PortType::Scalar], "Noise N in [0, 1].")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[NoiseParams::LAYOUT]);

const SHADER: Shader = crate::shader(
    "perlin_noise2d",
    include_str!("../shaders/perlin_noise2d.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/perlin_noise2d.wgsl` (struct `Params`).
    pub struct NoiseParams as "Params" {
        /// g · f.
        pub scale: f32,
        /// p.
        pub persistence: f32,
        /// o.
        pub octaves: u32,
        /// 0 seed, 1 fbm.
        pub mode: u32,
        /// Seed.
        pub seed: u32,
        /// time · speed (radians).
        pub angle: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

fn hash(x: i32, y: i32, s: u32) -> u32 {
    crate::algorithms::shader_lib::pcg(
        (x as u32).wrapping_mul(1_597_334_677)
            ^ (y as u32).wrapping_mul(3_812_015_801)
            ^ s.wrapping_mul(2_891_336_453),
    )
}

fn gradient(h: u32) -> (f32, f32) {
    const D: f32 = std::f32::consts::FRAC_1_SQRT_2;
    [
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (0.0, -1.0),
        (D, D),
        (-D, D),
        (D, -D),
        (-D, -D),
    ][(h & 7) as usize]
}

fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// CPU reference of classic 2D Perlin noise (same lattice hash and gradients as the shader).
pub fn perlin(qx: f32, qy: f32, s: u32) -> f32 {
    let (cx, cy) = (qx.floor(), qy.floor());
    let (fx, fy) = (qx - cx, qy - cy);
    let (ix, iy) = (cx as i32, cy as i32);
    let dot = |h: u32, x: f32, y: f32| {
        let g = gradient(h);
        g.0 * x + g.1 * y
    };
    let n00 = dot(hash(ix, iy, s), fx, fy);
    let n10 = dot(hash(ix + 1, iy, s), fx - 1.0, fy);
    let n01 = dot(hash(ix, iy + 1, s), fx, fy - 1.0);
    let n11 = dot(hash(ix + 1, iy + 1, s), fx - 1.0, fy - 1.0);
    let (ux, uy) = (fade(fx), fade(fy));
    let a = n00 + (n10 - n00) * ux;
    let b = n01 + (n11 - n01) * ux;
    a + (b - a) * uy
}

/// CPU reference of the normalised octave sum at lookup point q.
pub fn octaves(p: &NoiseParams, qx: f32, qy: f32) -> f32 {
    let (mut sum, mut norm, mut amp) = (0.0f32, 0.0f32, 1.0f32);
    for i in 0..p.octaves {
        let (x, y) = if p.mode == 0 {
            let d = (p.octaves as f32 - i as f32 - 1.0).max(1.0);
            (qx / d, qy / d)
        } else {
            let k = (i as f32).exp2();
            (qx * k, qy * k)
        };
        sum += amp * perlin(x, y, p.seed.wrapping_add(i.wrapping_mul(7919)));
        norm += amp;
        amp *= p.persistence;
    }
    let n = if norm > 0.0 { sum / norm } else { 0.0 };
    (n / std::f32::consts::SQRT_2 + 0.5).clamp(0.0, 1.0)
}

/// CPU reference of the node for a static (angle 0) map.
pub fn reference(p: &NoiseParams, w: u32, h: u32) -> Raster {
    let mut r = Raster::new(w, h, 1, 0.0);
    for y in 0..h {
        for x in 0..w {
            let (u, v) = ((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            r.data[(y * w + x) as usize] = octaves(p, u * p.scale, v * p.scale);
        }
    }
    r
}

impl NodeKind for PerlinNoise2D {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let (w, h) = match ctx.input("like").and_then(|v| v.texture()) {
            Some(t) => (t.width, t.height),
            None => size_or_default(ctx, p.width, p.height),
        };
        let u = NoiseParams {
            scale: (p.grid * p.frequency) as f32,
            persistence: p.persistence,
            octaves: p.octaves as u32,
            mode: p.mode as u32,
            seed: p.seed as u32,
            angle: (p.time * p.speed) as f32,
            _pad0: 0,
            _pad1: 0,
        };
        let out = ctx.gpu.texture(w, h, TexFormat::R32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "noise",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("out_noise", Bind::Storage(&out)),
            ],
            w,
            h,
        )?;
        ctx.set("noise", PortValue::Scalar(Arc::new(out)));
        Ok(())
    }
}
