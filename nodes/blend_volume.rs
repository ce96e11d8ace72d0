//! `BlendVolume`: a painted volume — the heterogeneity amount α, the noise frequency f or the
//! intensity I of `Heterogeneity` (SPEC §6, seed 000 §4.3) — kept as splats in the node's data
//! block and baked on the GPU, so a graph file reproduces the painted volume exactly.
//!
//! Every texel starts at `base`; splats apply in order: with d the ellipsoidal distance of the
//! texel centre from the splat's centre in its rotated frame (d = 1 on the ellipsoid with semi-axes
//! `radii`), the weight is `opacity` for d ≤ `hardness`, falling smoothly (smoothstep) to 0 at
//! d = 1; the texel becomes mix(v, value, w), or mix(v, base, w) for an `erase` splat. `base` and
//! the splats' values are clamped to the `role`'s range (α: 0…1, frequency: 0…16 levels,
//! intensity: 0…1e3), so every texel is too; opacity and hardness to 0…1. A splat with a radius
//! ≤ 0 does nothing. Levels 1… are the 2×2×2 means (as `NoiseVolume`).
//!
//! ```ron
//! (splats: [
//!     (centre: (0.0, 1.0, 0.0), radii: (3.0, 1.0, 3.0), value: 1.0, opacity: 1.0, hardness: 0.5),
//!     (centre: (2.0, 1.0, 0.0), radii: (1.0, 1.0, 1.0), rotation: (0.0, 0.0, 0.0, 1.0), erase: true),
//! ])
//! ```
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `scene` | in | Scene | its bounds place the volume |
//! | `volume` | out | Volume | |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `role` | Enum | alpha | alpha, frequency, intensity | the range the values are clamped to |
//! | `base` | Float | 0 | 0…1e3 | value before any splat |
//! | `resolution` | Int | 64 | 16…256 | side of the cube |
//! | `box_min`, `box_max` | Vec3 | (−5, 0, −5), (5, 5, 5) | ±1e6 m | the box without a scene |

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use serde::{Deserialize, Serialize};

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuVolume, Shader};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};

use crate::algorithms::volume_mips;

/// The `BlendVolume` node kind.
pub struct BlendVolume;

tyndall_engine::choice_enum! {
    /// What the volume drives in `Heterogeneity`.
    pub enum Role { Alpha = "alpha", Frequency = "frequency", Intensity = "intensity" }
}

impl Role {
    /// The range values are clamped to.
    pub fn range(self) -> (f32, f32) {
        match self {
            Role::Alpha => (0.0, 1.0),
            Role::Frequency => (0.0, 16.0),
            Role::Intensity => (0.0, 1e3),
        }
    }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        role: Role = ParamSpec::choice("role", Role::NAMES, "alpha", "What the volume drives: alpha (0…1), frequency (mip levels 0…16) or intensity (0…1e3); values are clamped to that range."),
        base: f32 = ParamSpec::float("base", 0.0, 0.0, 1e3, "", "Value before any splat (and what erasers restore)."),
        resolution: i64 = ParamSpec::int("resolution", 64, 16, 256, "texels", "Side of the cube."),
        box_min: [f32; 3] = ParamSpec::vec3("box_min", [-5.0, 0.0, -5.0], -1e6, 1e6, "m", "Low corner when no scene is connected."),
        box_max: [f32; 3] = ParamSpec::vec3("box_max", [5.0, 5.0, 5.0], -1e6, 1e6, "m", "High corner when no scene is connected."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "BlendVolume",
    category: "Medium",
    doc: "A painted volume (α, frequency or intensity for Heterogeneity): splats in the data block baked on the GPU.",
    inputs: &[PortSpec::input("scene", &[PortType::Scene], "Its bounds place the volume (else box_min…box_max).")],
    outputs: &[PortSpec::output("volume", &[PortType::Volume], "The painted volume and its world-space box.")],
    params: Params::SPECS,
}).tools(&["splat_volume", "splat_brush"])

.shaders(&[SHADER, volume_mips::SHADER])
.uniforms(&[BlendParams::LAYOUT]);

const SHADER: Shader = crate::shader("blend_volume", include_str!("../shaders/blend_volume.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/blend_volume.wgsl` (struct `Params`).
    pub struct BlendParams as "Params" {
        /// Level-0 size.
        pub size: [u32; 3],
        /// Number of splats.
        pub count: u32,
        /// Box, low corner.
        pub box_min: [f32; 3],
        /// Base value.
        pub base: f32,
        /// Box, high corner.
        pub box_max: [f32; 3],
        /// Padding.
        pub _pad0: u32,
    }
}

/// The data block: the splats, in painting order.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlendData {
    /// The splats.
    #[serde(default)]
    pub splats: Vec<Splat>,
}

/// One ellipsoidal brush stamp.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Splat {
    /// Centre, world space (m).
    pub centre: [f32; 3],
    /// Semi-axes along the splat's rotated x, y, z (m).
    pub radii: [f32; 3],
    /// Rotation, unit quaternion (x, y, z, w); default none.
    #[serde(default = "identity")]
    pub rotation: [f32; 4],
    /// Weight at the centre, 0…1.
    #[serde(default = "one")]
    pub opacity: f32,
    /// Fraction of the radius painted at full opacity, 0…1.
    #[serde(default = "half")]
    pub hardness: f32,
    /// The value painted.
    #[serde(default = "one")]
    pub value: f32,
    /// Restore the base value instead.
    #[serde(default)]
    pub erase: bool,
}

fn identity() -> [f32; 4] {
    [0.0, 0.0, 0.0, 1.0]
}
fn one() -> f32 {
    1.0
}
fn half() -> f32 {
    0.5
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The weight of splat `s` at world point x.
pub fn weight(s: &Splat, x: [f32; 3]) -> f32 {
    if s.radii.iter().any(|r| *r <= 0.0) {
        return 0.0;
    }
    let q = glam::Quat::from_array(s.rotation).normalize();
    let local = q.inverse() * (glam::Vec3::from(x) - glam::Vec3::from(s.centre));
    let d = (local / glam::Vec3::from(s.radii)).length();
    if d >= 1.0 {
        return 0.0;
    }
    let fall = if d > s.hardness {
        1.0 - smoothstep(s.hardness, 1.0, d)
    } else {
        1.0
    };
    s.opacity * fall
}

/// CPU reference of level 0 (x fastest).
pub fn reference(
    splats: &[Splat],
    base: f32,
    role: Role,
    n: u32,
    bounds: [[f32; 3]; 2],
) -> Vec<f32> {
    let (lo, hi) = role.range();
    let mut out = Vec::with_capacity((n * n * n) as usize);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p: [f32; 3] = std::array::from_fn(|k| {
                    let i = [x, y, z][k];
                    bounds[0][k] + (i as f32 + 0.5) / n as f32 * (bounds[1][k] - bounds[0][k])
                });
                let mut v = base;
                for s in splats {
                    let w = weight(s, p);
                    let t = if s.erase { base } else { s.value };
                    v += (t - v) * w;
                }
                out.push(v.clamp(lo, hi));
            }
        }
    }
    out
}

/// Bake the splats into a volume on the GPU (level 0, then the mips). The caller clamps `base`
/// and the splats' values to the role's range; every texel is then a convex combination of
/// them, so it stays in range.
pub fn bake(
    gpu: &Recorder,
    splats: &[Splat],
    base: f32,
    n: u32,
    bounds: [[f32; 3]; 2],
) -> Result<GpuVolume, NodeError> {
    let v = gpu.volume([n; 3])?;
    let mut data = Vec::with_capacity(splats.len().max(1) * 16);
    for s in splats {
        let q = glam::Quat::from_array(s.rotation).normalize();
        data.extend_from_slice(&[s.centre[0], s.centre[1], s.centre[2], s.value]);
        data.extend_from_slice(&[s.radii[0], s.radii[1], s.radii[2], s.opacity]);
        data.extend_from_slice(&q.to_array());
        data.extend_from_slice(&[s.hardness, s.erase as u32 as f32, 0.0, 0.0]);
    }
    if data.is_empty() {
        data.resize(16, 0.0);
    }
    let tex = gpu.upload(4, splats.len().max(1) as u32, 4, &data)?;
    let u = BlendParams {
        size: [n; 3],
        count: splats.len() as u32,
        box_min: bounds[0],
        base,
        box_max: bounds[1],
        _pad0: 0,
    };
    gpu.dispatch_3d(
        SHADER,
        "bake",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("out_level", Bind::VolumeLevel(&v, 0)),
            ("splats", Bind::Texture(&tex)),
        ],
        [n; 3],
    )?;
    volume_mips::build(gpu, &v)?;
    Ok(v)
}

impl NodeKind for BlendVolume {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let role = p.role;
        let (lo, hi) = role.range();
        let mut data: BlendData = ctx.data()?;
        for (i, s) in data.splats.iter_mut().enumerate() {
            let finite = s
                .centre
                .iter()
                .chain(&s.radii)
                .chain(&s.rotation)
                .chain([&s.opacity, &s.hardness, &s.value])
                .all(|v| v.is_finite());
            if !finite {
                return Err(NodeError::Data(format!(
                    "splat {i}: a number is not finite"
                )));
            }
            if s.rotation.iter().all(|v| *v == 0.0) {
                s.rotation = identity();
            }
            s.opacity = s.opacity.clamp(0.0, 1.0);
            s.hardness = s.hardness.clamp(0.0, 1.0);
            s.value = s.value.clamp(lo, hi);
        }
        let base = p.base.clamp(lo, hi);
        let bounds = super::util::volume_box(ctx, [p.box_min, p.box_max])?;
        let n = ctx.side("resolution", p.resolution, 3)?;
        ctx.check_bytes("resolution", u64::from(n).pow(3) * 4)?;
        let v = bake(ctx.gpu, &data.splats, base, n, bounds)?;
        ctx.set("volume", PortValue::Volume(Arc::new(v), bounds));
        Ok(())
    }
}
