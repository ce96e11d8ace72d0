//! `SingleScattering`: physically based single scattering in a homogeneous medium lit by the
//! sun (SPEC §3, seed 000 eq. 1–2).
//!
//! `L_scat = σt ρ f(θ) · L_i (1 − e^{−sσt})/σt · V̄`, with `V̄ = s⁻¹ ∫₀ˢ V(x_t) dt` the average
//! visibility of the view ray up to the first surface at distance `s` (sky: the camera's far
//! distance), found by marching the shadow map, and `f` the Henyey–Greenstein phase function
//! `(1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2})`, cos θ = dot(view direction, direction to the sun)
//! — or, with a `phase` table connected, that table per RGB channel (`nodes/phase.rs`).
//! The factor `(1 − e^{−sσt})/σt` is evaluated without cancellation and tends to `s` as σt → 0.
//! A sample is lit when it lies outside the map or the light box, or when its light-space depth
//! is at most the map's depth plus `bias`. Units: the sun's irradiance E (W/m², from the
//! `Scene`) times f (1/sr) times σt·length (dimensionless) gives `inscatter` in W/(m²·sr).
//!
//! Bounded media (beyond the seed): with `bounds = box` (or `tagged`: the bounds of the scene's
//! objects tagged `medium`, connected on `scene`) the view ray scatters only on [t0, t1], its
//! part inside the box, and the transmittance of surfaces is e^{−σt (t1 − t0)}. With
//! `light_extinction = on` the sun reaching a point is attenuated by e^{−σt ℓ}, ℓ the distance
//! from the point to the box's boundary towards the sun, and the factored form no longer holds:
//! `L_scat = σt ρ f E ∫_{t0}^{t1} V(t) e^{−σt (t − t0)} e^{−σt ℓ(t)} dt`. ℓ is piecewise linear
//! along the ray (the nearest of three faces), so the integral of the weight over any stretch is
//! exact; `BruteForce` weights each sample by its interval's integral, `MinMax` integrates its
//! lit stretches exactly. `light_extinction = on` with `bounds = none` is refused (an unbounded
//! medium would extinguish the sun completely).
//!
//! Light map (SPEC §5): with `light_map` connected the sun reaching x is multiplied by the map's
//! colour at x (bilinear, clamp to edge, in the map's own light projection), so the factored
//! form no longer holds: `L_scat = σt ρ f E Σ_i V_i M(x_i) ∫_{interval i} E(t) dt` — the same
//! interval weights as light extinction. `BruteForce` only; `MinMax` with a light map is refused.
//!
//! Methods: `BruteForce` marches `steps` samples per pixel at the centres of equal intervals
//! (moved by up to ±`jitter`/2 of an interval with a per-pixel hash). `MinMax` (the accelerated
//! method, in the spirit of Chen et al.'s min-max mip-maps, here as a 2D quadtree over the map
//! instead of 1D rows of an epipolar rectification) builds a pyramid of per-block minimum and
//! maximum depth and walks each view ray through it: blocks the ray passes entirely in front of
//! their minimum are lit, blocks it passes entirely behind their maximum are shadowed, and only
//! mixed blocks are refined down to texels, where the lit length is solved exactly. It computes
//! the limit of `BruteForce` as steps → ∞ (the same nearest-texel test and bias), so `steps`
//! and `jitter` do not apply to it; its cost grows with the number of light/shadow transitions
//! along a ray, not with the ray's length in texels.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `shadow` | in | ShadowMap (required) | the map the medium sees (possibly manipulated) |
//! | `depth` | in | Depth (required) | camera linear depth and camera matrices |
//! | `light_map` | in | LightMap (optional) | multiplies the incoming light (BruteForce only); unconnected: 1 |
//! | `phase` | in | Phase (optional) | tabulated phase function per RGB channel (`HenyeyGreenstein`, `Rayleigh`, `Mie`, `MultipleScatteringPhase`), read linearly between its texel centres; unconnected: Henyey–Greenstein `g` |
//! | `soft` | in | SoftShadow (optional) | visibility 1 − A from a `SoftVisibility` volume (nearest light texel, linear between slice ends) instead of the hard test; BruteForce only |
//! | `scene` | in | Scene (optional) | for `bounds = tagged`: its objects tagged `medium` |
//! | `visibility` | out | Scalar | V̄ ∈ [0, 1] |
//! | `depth` | out | Depth | the input depth, passed on for transfer functions |
//! | `inscatter` | out | Image | L_scat, W/(m²·sr) (linear RGB, alpha 1) |
//! | `transmittance` | out | Scalar | e^{−sσt}, for compositing surfaces behind the medium |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `sigma_t` | Float | 0.08 | 0…1e4 1/m | extinction σt |
//! | `albedo` | Float | 0.9 | 0…1 | scattering albedo ρ |
//! | `g` | Float | 0.5 | −0.999…0.999 | Henyey–Greenstein asymmetry |
//! | `tint` | Colour | (1, 1, 1, 1) | 0…1e6 | multiplies the sun's colour |
//! | `intensity` | Float | 1 | 0…1e6 | multiplies the sun's irradiance |
//! | `steps` | Int | 128 | 1…8192 | samples per view ray (quality knob) |
//! | `jitter` | Float | 0 | 0…1 | per-pixel offset of the samples, in intervals |
//! | `bias` | Float | 0.002 | 0…0.1 | depth bias of the shadow test |
//! | `method` | Enum | BruteForce | BruteForce, MinMax | visibility algorithm |
//! | `bounds` | Enum | none | none, box, tagged | where the medium is |
//! | `box_min`, `box_max` | Vec3 | (−5, 0, −5), (5, 5, 5) | ±1e6 m | the box (bounds = box) |
//! | `light_extinction` | Enum | off | off, on | attenuate the sun through the medium |
//! | `min_level` | Int | 0 | 0…14 | MinMax quality knob: mixed blocks of 2^level texels at and below this level are estimated (occluder depth taken as spread evenly over the block's [min, max]) instead of refined; 0 = exact |

use glam::{Mat4, Vec3};
use std::sync::Arc;

use crate::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx, IDENTITY};
use crate::gpu::{Bind, Gpu, GpuError, GpuTexture, Shader, TexFormat};
use crate::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use crate::io::Raster;
use crate::scene::GpuScene;

/// The `SingleScattering` node kind.
pub struct SingleScattering;

/// Visibility methods.
pub const METHODS: &[&str] = Method::NAMES;

crate::choice_enum! {
    /// Visibility algorithms.
    pub enum Method { BruteForce = "BruteForce", MinMax = "MinMax" }
}

crate::choice_enum! {
    /// Where the medium is.
    pub enum Bounds { None = "none", Box = "box", Tagged = "tagged" }
}

crate::choice_enum! {
    /// Whether the sun is attenuated on its way through the medium.
    pub enum Extinction { Off = "off", On = "on" }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "SingleScattering",
    category: "Scattering",
    doc: "Single scattering of the sun in a homogeneous medium: average visibility V̄, in-scatter and transmittance along each view ray.",
    inputs: &[
        PortSpec::required("shadow", &[PortType::ShadowMap], "Shadow map the medium sees."),
        PortSpec::required("depth", &[PortType::Depth], "Camera linear depth (from GBuffer)."),
        PortSpec::input("light_map", &[PortType::LightMap], "Light map multiplying the incoming light (unconnected: 1)."),
        PortSpec::input("phase", &[PortType::Phase], "Tabulated phase function (unconnected: Henyey–Greenstein g)."),
        PortSpec::input("soft", &[PortType::SoftShadow], "Soft visibility (SoftVisibility) instead of the hard shadow-map test; BruteForce only."),
        PortSpec::input("scene", &[PortType::Scene], "The scene whose objects tagged `medium` bound the medium (bounds = tagged)."),
    ],
    outputs: &[
        PortSpec::output("visibility", &[PortType::Scalar], "Average visibility V̄ of the view ray."),
        PortSpec::output("depth", &[PortType::Depth], "The input depth, passed on."),
        PortSpec::output("inscatter", &[PortType::Image], "In-scattered radiance, W/(m²·sr) (linear RGB)."),
        PortSpec::output("transmittance", &[PortType::Scalar], "e^(−s σt) along the view ray."),
    ],
    params: &[
        ParamSpec::float("sigma_t", 0.08, 0.0, 1e4, "1/m", "Extinction coefficient σt."),
        ParamSpec::float("albedo", 0.9, 0.0, 1.0, "", "Scattering albedo ρ."),
        ParamSpec::float("g", 0.5, -0.999, 0.999, "", "Henyey–Greenstein asymmetry (>0 forward scattering)."),
        ParamSpec::colour("tint", [1.0; 4], 0.0, 1e6, "linear RGB", "Multiplies the sun's colour."),
        ParamSpec::float("intensity", 1.0, 0.0, 1e6, "", "Multiplies the sun's irradiance."),
        ParamSpec::int("steps", 128, 1, 8192, "samples", "Samples per view ray (quality knob)."),
        ParamSpec::float("jitter", 0.0, 0.0, 1.0, "intervals", "Per-pixel random offset of the samples."),
        ParamSpec::float("bias", 0.002, 0.0, 0.1, "depth", "Shadow test bias in light-space depth."),
        ParamSpec::choice("method", Method::NAMES, "BruteForce", "Visibility algorithm."),
        ParamSpec::int("min_level", 0, 0, 14, "level", "MinMax quality knob: blocks of 2^level texels at and below this level are estimated, not refined (0 = exact)."),
        ParamSpec::choice("bounds", Bounds::NAMES, "none", "Where the medium is: none (fills every view ray, the seed's model), box (box_min…box_max), tagged (the bounds of the scene's objects tagged `medium`)."),
        ParamSpec::vec3("box_min", [-5.0, 0.0, -5.0], -1e6, 1e6, "m", "Low corner of the medium box (bounds = box), scene coordinates."),
        ParamSpec::vec3("box_max", [5.0, 5.0, 5.0], -1e6, 1e6, "m", "High corner of the medium box (bounds = box), scene coordinates."),
        ParamSpec::choice("light_extinction", Extinction::NAMES, "off", "off: the sun reaches every point unattenuated (seed eq. 1); on: by e^(−σt ℓ), ℓ = distance to the medium's boundary towards the sun (needs bounds)."),
    ],
})
.shader(SHADER)
.uniforms(&[ScatterParams::LAYOUT, SoftView::LAYOUT, LevelsParams::LAYOUT, BuildParams::LAYOUT, LightMapView::LAYOUT]);

const SHADER: Shader = Shader::new(
    "single_scattering",
    include_str!("../shaders/single_scattering.wgsl"),
);

crate::uniforms! {
    /// Uniforms of `shaders/single_scattering.wgsl` (struct `Params`).
    pub struct ScatterParams as "Params" {
        /// Camera clip → world.
        pub inv_view_proj: [[f32; 4]; 4],
        /// World → light clip.
        pub light_view_proj: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// Samples per ray.
        pub steps: u32,
        /// Unit direction towards the sun.
        pub to_sun: [f32; 3],
        /// σt.
        pub sigma_t: f32,
        /// Incoming radiance (sun × tint × intensity).
        pub radiance: [f32; 3],
        /// ρ.
        pub albedo: f32,
        /// HG g.
        pub g: f32,
        /// Jitter in intervals.
        pub jitter: f32,
        /// Shadow bias.
        pub bias: f32,
        /// MinMax: pyramid level at and below which mixed blocks are estimated, not refined
        /// (0 = exact).
        pub min_level: u32,
        /// Medium box, low corner (when `bounded`).
        pub box_min: [f32; 3],
        /// 1 when the medium is the box, 0 when it fills the view ray.
        pub bounded: u32,
        /// Medium box, high corner.
        pub box_max: [f32; 3],
        /// 1 when the sun is attenuated on its way through the medium.
        pub light_extinction: u32,
        /// Width of the connected phase table (0: Henyey–Greenstein `g`).
        pub phase_width: u32,
        /// Slices of the connected soft visibility volume (0: the hard shadow-map test).
        pub soft_slices: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

impl ScatterParams {
    /// Build the uniforms from the camera and light metadata.
    pub fn new(camera: &Matrices, light: &Matrices, p: Medium) -> ScatterParams {
        let (vp, lvp) = (camera.view_proj(), light.view_proj());
        let (eye, to_sun) = (camera.eye(), light.backward());
        ScatterParams {
            inv_view_proj: vp.inverse().to_cols_array_2d(),
            light_view_proj: lvp.to_cols_array_2d(),
            eye: eye.to_array(),
            steps: p.steps,
            to_sun: to_sun.to_array(),
            sigma_t: p.sigma_t,
            radiance: [0, 1, 2].map(|i| light.radiance[i] * p.tint[i] * p.intensity),
            albedo: p.albedo,
            g: p.g,
            jitter: p.jitter,
            bias: p.bias,
            min_level: p.min_level,
            box_min: [0.0; 3],
            bounded: 0,
            box_max: [0.0; 3],
            light_extinction: 0,
            phase_width: 0,
            soft_slices: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }

    /// Bound the medium to the box `(min, max)` (`None`: it fills every view ray) and switch
    /// the sun's extinction on its way through it.
    pub fn with_bounds(mut self, bounds: Option<(Vec3, Vec3)>, light_extinction: bool) -> Self {
        if let Some((lo, hi)) = bounds {
            (self.box_min, self.box_max, self.bounded) = (lo.to_array(), hi.to_array(), 1);
        }
        self.light_extinction = light_extinction as u32;
        self
    }
}

crate::uniforms! {
    /// Uniforms of the soft visibility lookup (struct `SoftView`).
    pub struct SoftView as "SoftView" {
        /// World → light clip of the soft volume.
        pub view_proj: [[f32; 4]; 4],
    }
}

crate::uniforms! {
    /// Uniforms of the light-map lookup (struct `LightMapView`).
    pub struct LightMapView as "LightMapView" {
        /// World → light clip of the light map.
        pub view_proj: [[f32; 4]; 4],
        /// 1 when a light map is connected (BruteForce multiplies each sample by it).
        pub enabled: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

crate::uniforms! {
    /// Uniforms of the MinMax traversal (struct `Levels`): level k ≥ 1 of the pyramid lives in
    /// the atlas at `rect[k] = (x, y, width, height)`.
    pub struct LevelsParams as "Levels" {
        /// Number of levels above the map (the top one is 1×1).
        pub count: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
        /// Atlas rectangles; entry 0 unused (level 0 is the map).
        pub rect: [[u32; 4]; 16],
    }
}

crate::uniforms! {
    /// Uniforms of the pyramid build pass (struct `Build`).
    pub struct BuildParams as "Build" {
        /// Level being built (≥ 1).
        pub level: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
        /// Source rectangle (the map for level 1, else level − 1 in the atlas).
        pub src: [u32; 4],
        /// Destination rectangle in the atlas.
        pub dst: [u32; 4],
    }
}

/// The atlas layout of a min-max pyramid over a `w × h` map: `(levels, atlas width, atlas
/// height)`. Level k has size ⌈w/2^k⌉ × ⌈h/2^k⌉ and they are stacked vertically.
pub fn pyramid_layout(w: u32, h: u32) -> (LevelsParams, u32, u32) {
    let mut p = LevelsParams {
        count: 0,
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
        rect: [[0; 4]; 16],
    };
    let (mut lw, mut lh, mut y) = (w, h, 0u32);
    let mut width = 1;
    while (lw > 1 || lh > 1) && (p.count as usize) < 15 {
        lw = lw.div_ceil(2);
        lh = lh.div_ceil(2);
        p.count += 1;
        p.rect[p.count as usize] = [0, y, lw, lh];
        width = width.max(lw);
        y += lh;
    }
    (p, width, y.max(1))
}

/// Medium and quality settings (the node's parameters).
#[derive(Clone, Copy, Debug)]
pub struct Medium {
    /// σt.
    pub sigma_t: f32,
    /// ρ.
    pub albedo: f32,
    /// HG g.
    pub g: f32,
    /// Tint.
    pub tint: [f32; 3],
    /// Intensity.
    pub intensity: f32,
    /// Samples per ray.
    pub steps: u32,
    /// Jitter.
    pub jitter: f32,
    /// Bias.
    pub bias: f32,
    /// MinMax estimate level (0 = exact).
    pub min_level: u32,
}

/// `(1 − e^{−sσt})/σt` without cancellation; exactly `s` at σt = 0.
pub fn transmittance_integral(s: f32, sigma_t: f32) -> f32 {
    let x = s * sigma_t;
    if x < 1e-3 {
        s * (1.0 - x * 0.5 + x * x / 6.0)
    } else {
        (1.0 - (-x).exp()) / sigma_t
    }
}

/// Henyey–Greenstein phase function.
pub fn henyey_greenstein(g: f32, cos_theta: f32) -> f32 {
    let d = (1.0 + g * g - 2.0 * g * cos_theta).max(1e-12);
    (1.0 - g * g) / (4.0 * std::f32::consts::PI * d * d.sqrt())
}

/// The per-pixel jitter hash (PCG), identical to the shader's.
pub fn hash(x: u32, y: u32) -> f32 {
    let mut v = x
        .wrapping_mul(1_973)
        .wrapping_add(y.wrapping_mul(9_277))
        .wrapping_add(26_699)
        | 1;
    v = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let w = ((v >> ((v >> 28) + 4)) ^ v).wrapping_mul(277_803_737);
    ((w >> 22) ^ w) as f32 / 4_294_967_296.0
}

/// Result of one pixel: (V̄, in-scatter RGB, transmittance).
pub type PixelResult = (f32, [f32; 3], f32);

/// The part `[t0, t1]` of `[0, s]` inside the medium along the ray `eye + dir·t` (t1 ≤ t0: none).
pub fn medium_segment(p: &ScatterParams, dir: Vec3, s: f32) -> (f32, f32) {
    if p.bounded == 0 {
        return (0.0, s);
    }
    let (mut t0, mut t1) = (0.0f32, s);
    for k in 0..3 {
        if dir[k] == 0.0 {
            if p.eye[k] < p.box_min[k] || p.eye[k] > p.box_max[k] {
                return (0.0, -1.0);
            }
        } else {
            let ta = (p.box_min[k] - p.eye[k]) / dir[k];
            let tb = (p.box_max[k] - p.eye[k]) / dir[k];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    (t0, t1)
}

/// `(1 − e^{−len·m})/m` for m ≥ 0, accurate on short stretches (series below len·m = 0.5).
pub fn decay_integral(len: f32, m: f32) -> f32 {
    let x = len * m;
    if x < 0.5 {
        let series = 1.0
            - x / 2.0
                * (1.0
                    - x / 3.0
                        * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0 * (1.0 - x / 7.0)))));
        return len * series;
    }
    (1.0 - (-x).exp()) / m
}

/// ℓ along the ray through the face the sun shines through on axis k: `(α, β)` with
/// ℓ_k(t) = α + β t (an axis parallel to the sun never limits ℓ).
fn light_line(p: &ScatterParams, dir: Vec3, k: usize) -> (f32, f32) {
    let sk = p.to_sun[k];
    if sk.abs() < 1e-12 {
        return (3.0e38, 0.0);
    }
    let face = if sk > 0.0 { p.box_max[k] } else { p.box_min[k] };
    ((face - p.eye[k]) / sk, -dir[k] / sk)
}

/// ℓ at distance t along the view ray, computed from the point itself (the lines of
/// [`light_line`] carry terms of order 1/|sun_k| that cancel badly in f32).
fn light_exit(p: &ScatterParams, dir: Vec3, t: f32) -> f32 {
    let q = Vec3::from(p.eye) + dir * t;
    let mut ell = 3.0e38f32;
    for k in 0..3 {
        let sk = p.to_sun[k];
        if sk.abs() >= 1e-12 {
            let face = if sk > 0.0 { p.box_max[k] } else { p.box_min[k] };
            ell = ell.min((face - q[k]) / sk);
        }
    }
    ell.max(0.0)
}

/// `∫_a^b E(t) dt`, E(t) = e^{−σt (t − t0)} · e^{−σt ℓ(t)} (ℓ = 0 with light extinction off):
/// the weight of a stretch of the view ray in the medium (see the shader's comment).
pub fn weight(p: &ScatterParams, dir: Vec3, t0: f32, a: f32, b: f32) -> f32 {
    if b <= a {
        return 0.0;
    }
    let sig = p.sigma_t;
    if p.light_extinction == 0 {
        return (-sig * (a - t0)).exp() * decay_integral(b - a, sig);
    }
    let lines = [0, 1, 2].map(|k| light_line(p, dir, k));
    let mut cuts = vec![a];
    for i in 0..3 {
        for j in i + 1..3 {
            let db = lines[i].1 - lines[j].1;
            if db != 0.0 {
                let tc = (lines[j].0 - lines[i].0) / db;
                if tc > a && tc < b {
                    cuts.push(tc);
                }
            }
        }
    }
    cuts[1..].sort_by(f32::total_cmp);
    cuts.push(b);
    let mut total = 0.0;
    for w in cuts.windows(2) {
        let (p0, p1) = (w[0], w[1]);
        if p1 <= p0 {
            continue;
        }
        let mid = 0.5 * (p0 + p1);
        let line = lines.iter().copied().fold(lines[0], |m, l| {
            if l.0 + l.1 * mid < m.0 + m.1 * mid {
                l
            } else {
                m
            }
        });
        let m = sig * (1.0 + line.1);
        let (integral, at) = if m >= 0.0 {
            (decay_integral(p1 - p0, m), p0)
        } else {
            (decay_integral(p1 - p0, -m), p1)
        };
        let e = (-sig * ((at - t0) + light_exit(p, dir, at))).exp();
        total += e * integral;
    }
    total
}

/// CPU reference of the brute-force method for pixel (x, y) of a `w × h` image, with the
/// built-in Henyey–Greenstein phase function.
pub fn reference_pixel(
    p: &ScatterParams,
    shadow: &Raster,
    s: f32,
    x: u32,
    y: u32,
    w: u32,
    h: u32,
) -> PixelResult {
    reference_pixel_phase(p, None, shadow, s, (x, y), (w, h))
}

/// [`reference_pixel`] with a phase table (`None`: Henyey–Greenstein `g`) for pixel `xy` of a
/// `size` image.
pub fn reference_pixel_phase(
    p: &ScatterParams,
    phase: Option<&crate::nodes::phase::PhaseTable>,
    shadow: &Raster,
    s: f32,
    (x, y): (u32, u32),
    (w, h): (u32, u32),
) -> PixelResult {
    let inv = Mat4::from_cols_array_2d(&p.inv_view_proj);
    let lvp = Mat4::from_cols_array_2d(&p.light_view_proj);
    let eye = Vec3::from(p.eye);
    let dir = crate::eval::pixel_ray(inv, eye, x, y, w, h);
    let (t0, t1) = medium_segment(p, dir, s);
    let len = (t1 - t0).max(0.0);
    let offset = p.jitter * (hash(x, y) - 0.5);
    let mut lit = 0u32;
    let mut weighted = 0.0f32;
    let n = p.steps as f32;
    for i in 0..p.steps {
        let t = t0 + (i as f32 + 0.5 + offset) / n * len;
        let c = lvp * (eye + dir * t).extend(1.0);
        let (u, v, z) = (c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z);
        let inside = (0.0..1.0).contains(&u) && (0.0..1.0).contains(&v) && (0.0..=1.0).contains(&z);
        let visible = if inside {
            let tx = ((u * shadow.width as f32) as u32).min(shadow.width - 1);
            let ty = ((v * shadow.height as f32) as u32).min(shadow.height - 1);
            z <= shadow.pixel(tx, ty)[0] + p.bias
        } else {
            true
        };
        lit += visible as u32;
        if p.light_extinction != 0 && visible {
            let a = t0 + i as f32 / n * len;
            let b = t0 + (i + 1) as f32 / n * len;
            weighted += weight(p, dir, t0, a, b);
        }
    }
    let vbar = if len > 0.0 || p.bounded == 0 {
        lit as f32 / n
    } else {
        1.0
    };
    let cos = dir.dot(Vec3::from(p.to_sun));
    let f = phase.map_or([henyey_greenstein(p.g, cos); 3], |t| t.lookup(cos));
    let k = if p.light_extinction != 0 {
        weighted
    } else {
        transmittance_integral(len, p.sigma_t) * vbar
    };
    let rad = [0, 1, 2].map(|c| p.radiance[c] * p.sigma_t * p.albedo * f[c] * k);
    (vbar, rad, (-len * p.sigma_t).exp())
}

/// Build the min-max pyramid of `map`: returns the level table and the RG32F atlas.
pub fn build_pyramid(gpu: &Gpu, map: &GpuTexture) -> Result<(LevelsParams, GpuTexture), GpuError> {
    let (levels, aw, ah) = pyramid_layout(map.width, map.height);
    let front = gpu.texture(aw, ah, TexFormat::Rg32F)?;
    let back = gpu.texture(aw, ah, TexFormat::Rg32F)?;
    for k in 1..=levels.count as usize {
        let dst = levels.rect[k];
        let src = if k == 1 {
            [0, 0, map.width, map.height]
        } else {
            levels.rect[k - 1]
        };
        let b = BuildParams {
            level: k as u32,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
            src,
            dst,
        };
        let source = if k == 1 { map } else { &front };
        gpu.dispatch(
            SHADER,
            "build_level",
            &[
                (7, Bind::Uniform(bytemuck::bytes_of(&b))),
                (8, Bind::Texture(source)),
                (9, Bind::Storage(&back)),
            ],
            dst[2],
            dst[3],
        )?;
        // The next level reads this one: copy it into the texture that is read.
        gpu.copy_region(&back, &front, dst[0], dst[1], dst[2], dst[3])?;
    }
    Ok((levels, front))
}

/// The bounds of the objects tagged `medium` in the scene on the `scene` port.
fn tagged_bounds(ctx: &RunCtx) -> Result<(Vec3, Vec3), NodeError> {
    let input = |message: &str| NodeError::Input {
        port: "scene".into(),
        message: message.into(),
    };
    let scene = ctx
        .input("scene")
        .ok_or_else(|| input("must be connected when bounds = tagged"))?
        .payload::<GpuScene>()
        .ok_or_else(|| input("is not a scene"))?;
    scene.scene.medium.ok_or_else(|| {
        input("has no objects tagged `medium` (glTF node extras: {\"tags\": [\"medium\"]})")
    })
}

impl NodeKind for SingleScattering {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let (shadow, light) = match ctx.require("shadow")? {
            PortValue::ShadowMap(t, m) => (t.clone(), *m),
            _ => {
                return Err(NodeError::Input {
                    port: "shadow".into(),
                    message: "is not a shadow map".into(),
                })
            }
        };
        let depth_value = ctx.require("depth")?.clone();
        let (depth, camera) = match &depth_value {
            PortValue::Depth(t, m) => (t.clone(), *m),
            _ => {
                return Err(NodeError::Input {
                    port: "depth".into(),
                    message: "is not a depth image".into(),
                })
            }
        };
        let phase = match ctx.input("phase") {
            None => None,
            Some(PortValue::Phase(t)) => Some(t.clone()),
            Some(_) => {
                return Err(NodeError::Input {
                    port: "phase".into(),
                    message: "is not a phase function".into(),
                })
            }
        };
        let soft = match ctx.input("soft") {
            None => None,
            Some(PortValue::SoftShadow(v, m)) => Some((v.clone(), *m)),
            Some(_) => {
                return Err(NodeError::Input {
                    port: "soft".into(),
                    message: "is not a soft visibility volume".into(),
                })
            }
        };
        let light_map = match ctx.input("light_map") {
            None => None,
            Some(PortValue::LightMap(t, m)) => Some((t.clone(), *m)),
            Some(_) => {
                return Err(NodeError::Input {
                    port: "light_map".into(),
                    message: "is not a light map".into(),
                })
            }
        };
        let tint = ctx.colour("tint")?;
        let medium = Medium {
            sigma_t: ctx.f32("sigma_t")?,
            albedo: ctx.f32("albedo")?,
            g: ctx.f32("g")?,
            tint: [tint[0], tint[1], tint[2]],
            intensity: ctx.f32("intensity")?,
            steps: ctx.int("steps")? as u32,
            jitter: ctx.f32("jitter")?,
            bias: ctx.f32("bias")?,
            min_level: ctx.int("min_level")? as u32,
        };
        let extinction = ctx.choice::<Extinction>("light_extinction")? == Extinction::On;
        let bounds = match ctx.choice::<Bounds>("bounds")? {
            Bounds::None if extinction => {
                return Err(NodeError::Param {
                    param: "light_extinction".into(),
                    message: "on needs a bounded medium (the sun is attenuated up to its \
                              boundary): set bounds to box or tagged"
                        .into(),
                })
            }
            Bounds::None => None,
            Bounds::Box => {
                let (lo, hi) = (
                    Vec3::from(ctx.vec3("box_min")?),
                    Vec3::from(ctx.vec3("box_max")?),
                );
                if lo.cmpgt(hi).any() {
                    return Err(NodeError::Param {
                        param: "box_max".into(),
                        message: format!("{hi} is below box_min {lo} on some axis"),
                    });
                }
                Some((lo, hi))
            }
            Bounds::Tagged => Some(tagged_bounds(ctx)?),
        };
        let mut u = ScatterParams::new(&camera, &light, medium).with_bounds(bounds, extinction);
        let phase = match phase {
            Some(t) => t,
            None => Arc::new(ctx.gpu.upload(1, 1, 4, &[0.0; 4])?),
        };
        u.phase_width = if ctx.input("phase").is_some() {
            phase.width
        } else {
            0
        };
        let (w, h) = (depth.width, depth.height);
        let vis = ctx.gpu.texture(w, h, TexFormat::R32F)?;
        let ins = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        let tr = ctx.gpu.texture(w, h, TexFormat::R32F)?;
        let soft_volume = match &soft {
            Some((v, _)) => v.clone(),
            None => Arc::new(ctx.gpu.volume([1, 1, 1])?),
        };
        let sv = SoftView {
            view_proj: soft
                .as_ref()
                .map_or(light, |(_, m)| *m)
                .view_proj()
                .to_cols_array_2d(),
        };
        if soft.is_some() {
            if ctx.choice::<Method>("method")? != Method::BruteForce {
                return Err(NodeError::Input {
                    port: "soft".into(),
                    message: "needs method BruteForce (MinMax walks the hard shadow map)".into(),
                });
            }
            u.soft_slices = soft_volume.size[2];
        }
        let mut binds = vec![
            (0, Bind::Uniform(bytemuck::bytes_of(&u))),
            (1, Bind::Texture(&shadow)),
            (2, Bind::Texture(&depth)),
            (3, Bind::Storage(&vis)),
            (4, Bind::Storage(&ins)),
            (5, Bind::Storage(&tr)),
            (13, Bind::Texture(&phase)),
        ];
        let method = ctx.choice::<Method>("method")?;
        binds.push((14, Bind::Volume(&soft_volume)));
        binds.push((15, Bind::Uniform(bytemuck::bytes_of(&sv))));
        if let Some((map, m)) = &light_map {
            if method != Method::BruteForce {
                return Err(NodeError::Input {
                    port: "light_map".into(),
                    message: "needs method BruteForce (MinMax integrates visibility only)".into(),
                });
            }
            let lm = LightMapView {
                view_proj: m.view_proj().to_cols_array_2d(),
                enabled: 1,
                _pad0: 0,
                _pad1: 0,
                _pad2: 0,
            };
            binds.push((11, Bind::Texture(map)));
            binds.push((12, Bind::Uniform(bytemuck::bytes_of(&lm))));
            ctx.gpu.dispatch(SHADER, "brute_force", &binds, w, h)?;
        } else if method == Method::MinMax {
            let (levels, atlas) = build_pyramid(ctx.gpu, &shadow)?;
            binds.push((6, Bind::Texture(&atlas)));
            binds.push((10, Bind::Uniform(bytemuck::bytes_of(&levels))));
            ctx.gpu.dispatch(SHADER, "min_max", &binds, w, h)?;
        } else {
            let lm = LightMapView {
                view_proj: IDENTITY,
                enabled: 0,
                _pad0: 0,
                _pad1: 0,
                _pad2: 0,
            };
            let none = ctx.gpu.upload(1, 1, 4, &[1.0; 4])?;
            binds.push((11, Bind::Texture(&none)));
            binds.push((12, Bind::Uniform(bytemuck::bytes_of(&lm))));
            ctx.gpu.dispatch(SHADER, "brute_force", &binds, w, h)?;
        }
        ctx.set("visibility", PortValue::Scalar(Arc::new(vis)));
        ctx.set("inscatter", PortValue::Image(Arc::new(ins)));
        ctx.set("transmittance", PortValue::Scalar(Arc::new(tr)));
        ctx.set("depth", depth_value);
        Ok(())
    }
}
