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
//! interval weights as light extinction. `BruteForce` only; `MinMax` or `Epipolar` with a light
//! map is refused.
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
//! along a ray, not with the ray's length in texels. `Epipolar` (the fast method, after
//! Engelhardt & Dachsbacher 2010, Yusov 2013 and Chen et al. 2011) traces only `epi_slices` ×
//! `epi_samples` rays placed on epipolar lines through the sun's screen position, each through a
//! 1D min-max tree over its line's rectified shadow-map texels, and interpolates every pixel from
//! the four nearest samples whose depth is within `epi_threshold` of its own; pixels without one
//! (depth discontinuities) trace their own ray as `MinMax` does. See "Method Epipolar" below.
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
//! | `method` | Enum | BruteForce | BruteForce, MinMax, Epipolar | visibility algorithm |
//! | `bounds` | Enum | none | none, box, tagged | where the medium is |
//! | `box_min`, `box_max` | Vec3 | (−5, 0, −5), (5, 5, 5) | ±1e6 m | the box (bounds = box) |
//! | `light_extinction` | Enum | off | off, on | attenuate the sun through the medium |
//! | `min_level` | Int | 0 | 0…14 | MinMax quality knob: mixed blocks of 2^level texels at and below this level are estimated (occluder depth taken as spread evenly over the block's [min, max]) instead of refined; 0 = exact |
//! | `epi_slices` | Int | 512 | 4…2048 | Epipolar quality knob: slices (lines through the epipole) |
//! | `epi_samples` | Int | 256 | 2…4096 | Epipolar quality knob: traced rays per slice, ends included |
//! | `epi_threshold` | Float | 0.02 | 0…100 | Epipolar quality knob: relative depth / medium-length difference above which a sample is not used for a pixel (0: every pixel traces its own ray) |
//! | `tree_level` | Int | 0 | 0…14 | Epipolar quality knob: 1D tree nodes of 2^level texels at and below this level are estimated like `min_level`; 0 = exact |

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
    pub enum Method { BruteForce = "BruteForce", MinMax = "MinMax", Epipolar = "Epipolar" }
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
        ParamSpec::int("epi_slices", 512, 4, 2048, "slices", "Epipolar quality knob: lines through the sun's screen position whose rays are traced."),
        ParamSpec::int("epi_samples", 256, 2, 4096, "samples", "Epipolar quality knob: traced rays per slice, end points included."),
        ParamSpec::float("epi_threshold", 0.02, 0.0, 100.0, "relative", "Epipolar quality knob: a sample whose camera depth (or medium length) differs from a pixel's by more than this share is not used for it; a pixel left with none traces its own ray (0: every pixel does)."),
        ParamSpec::int("tree_level", 0, 0, 14, "level", "Epipolar quality knob: nodes of the 1D min-max trees spanning 2^level texels at and below this level are estimated, not refined (0 = exact)."),
        ParamSpec::choice("bounds", Bounds::NAMES, "none", "Where the medium is: none (fills every view ray, the seed's model), box (box_min…box_max), tagged (the bounds of the scene's objects tagged `medium`)."),
        ParamSpec::vec3("box_min", [-5.0, 0.0, -5.0], -1e6, 1e6, "m", "Low corner of the medium box (bounds = box), scene coordinates."),
        ParamSpec::vec3("box_max", [5.0, 5.0, 5.0], -1e6, 1e6, "m", "High corner of the medium box (bounds = box), scene coordinates."),
        ParamSpec::choice("light_extinction", Extinction::NAMES, "off", "off: the sun reaches every point unattenuated (seed eq. 1); on: by e^(−σt ℓ), ℓ = distance to the medium's boundary towards the sun (needs bounds)."),
    ],
})
.shader(SHADER)
.uniforms(&[ScatterParams::LAYOUT, SoftView::LAYOUT, LevelsParams::LAYOUT, BuildParams::LAYOUT, LightMapView::LAYOUT, EpiParams::LAYOUT]);

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

crate::uniforms! {
    /// Uniforms of method `Epipolar` (struct `Epi`); the slices themselves are in a texture.
    pub struct EpiParams as "Epi" {
        /// The epipole, pixels.
        pub epipole: [f32; 2],
        /// Border coordinate where the slices' arc starts.
        pub u_start: f32,
        /// Length of the arc in border coordinates.
        pub arc: f32,
        /// The view, pixels.
        pub size: [f32; 2],
        /// Slices.
        pub slices: u32,
        /// Samples per slice.
        pub samples: u32,
        /// 1 when the epipole is on screen (slices wrap around).
        pub inside: u32,
        /// Leaves per rectified row (a power of two).
        pub tree_n: u32,
        /// log2 of `tree_n`: the root's level.
        pub tree_top: u32,
        /// Tree level at and below which mixed nodes are estimated (0 = exact).
        pub tree_level: u32,
        /// Relative depth / medium-length threshold of a usable sample.
        pub threshold: f32,
        /// Level being built (pass `epi_tree`); pixels in the fall-back list (`epi_fallback`).
        pub level: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

impl EpiParams {
    /// The uniforms of geometry `g` with `knobs`.
    pub fn new(g: &EpiGeometry, knobs: EpiKnobs) -> EpiParams {
        EpiParams {
            epipole: g.epipole,
            u_start: g.u_start,
            arc: g.arc,
            size: g.size,
            slices: knobs.slices,
            samples: knobs.samples,
            inside: g.inside as u32,
            tree_n: g.tree_n,
            tree_top: g.tree_n.trailing_zeros(),
            tree_level: knobs.tree_level,
            threshold: knobs.threshold,
            level: 0,
            _pad0: 0,
            _pad1: 0,
        }
    }

    /// The slice table texture's texels (width = slices, 3 rows of RGBA): entry and direction;
    /// length, chord; the map line's origin and direction.
    pub fn slice_texels(g: &EpiGeometry) -> Vec<f32> {
        let row = |f: fn(&EpiSlice) -> [f32; 4]| g.slices.iter().flat_map(f);
        row(|s| [s.entry[0], s.entry[1], s.dir[0], s.dir[1]])
            .chain(row(|s| [s.len, s.chord, 0.0, 0.0]))
            .chain(row(|s| {
                [s.line_o[0], s.line_o[1], s.line_d[0], s.line_d[1]]
            }))
            .collect()
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

// ---- Method Epipolar: epipolar sampling with 1D min-max trees --------------------------------
//
// The sun's screen position (the epipole e: the projection of the direction to the sun, or of
// its opposite when the sun is behind the camera) is where every shaft's screen image
// converges. `epi_slices` lines from e to points spaced equally along the part of the screen's
// border that lines from e leave the screen through (the whole border when e is on screen)
// carry `epi_samples` view rays each, end points included. The view rays of one slice lie in one
// plane through the eye and the sun, whose image in the (orthographic) shadow map is one line:
// that line is rectified into a row of texels, one leaf per texel of length, each leaf holding
// the minimum and maximum depth of the texels the line crosses over it, and a binary min-max
// tree over the row (Chen et al. 2011) gives each sample ray its visibility in O(log n) per
// light/shadow transition; inside a mixed leaf the ray's own texels are solved exactly, so at
// `tree_level` 0 a sample is the exact brute-force limit, like `MinMax`. Each pixel then takes
// the two slices on either side of its own line through e and, on each, the two samples at its
// distance along the line, bilinearly weighted; a sample whose camera depth or medium length
// differs from the pixel's by more than `epi_threshold` (relative) is left out, and a pixel
// left with none (a depth discontinuity: a silhouette, a thin branch) traces its own ray
// through the 2D min-max pyramid of `MinMax`. V̄ varies smoothly along a slice away from depth
// discontinuities (shaft boundaries run along the slices), so few samples per slice suffice.

/// Largest distance of the epipole from the screen's centre, pixels: a sun at right angles to
/// the view axis puts the epipole at infinity; lines through a point 10⁷ px away are parallel
/// to within 2·10⁻⁴ rad over a 2000 px screen.
const EPIPOLE_FAR: f64 = 1e7;

/// Quality knobs of method `Epipolar`.
#[derive(Clone, Copy, Debug)]
pub struct EpiKnobs {
    /// Slices (lines through the epipole).
    pub slices: u32,
    /// Samples per slice, end points included (≥ 2).
    pub samples: u32,
    /// Relative difference of camera depth (and medium length) above which a sample is not used
    /// for a pixel.
    pub threshold: f32,
    /// Tree level at and below which mixed nodes are estimated, not refined (0 = exact).
    pub tree_level: u32,
}

/// One epipolar slice: its segment on screen and its line in the shadow map.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EpiSlice {
    /// Where the segment enters the screen (the epipole when it is on screen), pixels.
    pub entry: [f32; 2],
    /// Unit direction of the segment, away from the epipole.
    pub dir: [f32; 2],
    /// Length of the segment, pixels (0: the line only touches the screen).
    pub len: f32,
    /// Length of the line's chord through the shadow map, texels (0: it misses the map).
    pub chord: f32,
    /// Where the line enters the shadow map, texels.
    pub line_o: [f32; 2],
    /// Unit direction of the line in the shadow map, texels.
    pub line_d: [f32; 2],
}

/// The epipolar layout of one view on one shadow map.
#[derive(Clone, Debug)]
pub struct EpiGeometry {
    /// The epipole, pixels (y down; possibly far off screen).
    pub epipole: [f32; 2],
    /// The screen, pixels.
    pub size: [f32; 2],
    /// Whether the epipole is on the screen (slices then go all the way round).
    pub inside: bool,
    /// Border coordinate where the slices' arc starts (0 top-left corner, 1 top-right, 2
    /// bottom-right, 3 bottom-left, clockwise).
    pub u_start: f32,
    /// Length of the arc in border coordinates (4: the whole border).
    pub arc: f32,
    /// The slices, in border order.
    pub slices: Vec<EpiSlice>,
    /// Leaves per rectified row (a power of two ≥ the longest chord + 1).
    pub tree_n: u32,
}

/// The point at border coordinate `u` of a `w × h` screen (0 top-left corner, clockwise, one
/// unit per edge).
fn border_point(u: f64, w: f64, h: f64) -> glam::DVec2 {
    let u = u.rem_euclid(4.0);
    let f = u - u.floor();
    match u.floor() as u32 {
        0 => glam::DVec2::new(f * w, 0.0),
        1 => glam::DVec2::new(w, f * h),
        2 => glam::DVec2::new((1.0 - f) * w, h),
        _ => glam::DVec2::new(0.0, (1.0 - f) * h),
    }
}

/// The border coordinate where the ray `pc + r·t`, t > 0, from a point on a `size` screen
/// leaves it (CPU twin of the shader's `border_coordinate`).
fn border_coordinate(pc: glam::Vec2, r: glam::Vec2, size: glam::Vec2) -> f32 {
    let exit = |k: usize| {
        if r[k] > 1e-9 {
            (size[k] - pc[k]) / r[k]
        } else if r[k] < -1e-9 {
            -pc[k] / r[k]
        } else {
            3.0e38
        }
    };
    let (tx, ty) = (exit(0), exit(1));
    if tx <= ty {
        let y = ((pc.y + r.y * tx) / size.y).clamp(0.0, 1.0);
        if r.x > 0.0 {
            1.0 + y
        } else {
            4.0 - y
        }
    } else {
        let x = ((pc.x + r.x * ty) / size.x).clamp(0.0, 1.0);
        if r.y < 0.0 {
            x
        } else {
            3.0 - x
        }
    }
}

/// The parameters `[s_in, s_out]` of the line `o + s·d` inside the box `[0, size]`
/// (Liang–Barsky; empty when `s_out < s_in`).
fn clip_line(o: glam::DVec2, d: glam::DVec2, size: glam::DVec2) -> (f64, f64) {
    let (mut s_in, mut s_out) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..2 {
        if d[k].abs() < 1e-15 {
            if o[k] < 0.0 || o[k] > size[k] {
                return (1.0, 0.0);
            }
        } else {
            let (a, b) = ((0.0 - o[k]) / d[k], (size[k] - o[k]) / d[k]);
            s_in = s_in.max(a.min(b));
            s_out = s_out.min(a.max(b));
        }
    }
    (s_in, s_out)
}

/// The epipolar layout of a `size` view (uniforms `p`) over a `map` (width, height) shadow map
/// with `slices` slices.
pub fn epipolar_geometry(
    p: &ScatterParams,
    (w, h): (u32, u32),
    map: (u32, u32),
    slices: u32,
) -> EpiGeometry {
    use glam::{DVec2, DVec3, DVec4};
    let inv = Mat4::from_cols_array_2d(&p.inv_view_proj).as_dmat4();
    let vp = inv.inverse();
    let lvp = Mat4::from_cols_array_2d(&p.light_view_proj).as_dmat4();
    let sun = Vec3::from(p.to_sun).as_dvec3();
    let eye = Vec3::from(p.eye).as_dvec3();
    let size = DVec2::new(w as f64, h as f64);
    let msize = DVec2::new(map.0 as f64, map.1 as f64);
    let centre = size * 0.5;
    // The epipole: the image of the point at infinity towards the sun (projective, so a sun
    // behind the camera gives the point the lines converge to on the other side).
    let c = vp * sun.extend(0.0);
    let towards = DVec2::new(c.x * size.x * 0.5, -c.y * size.y * 0.5);
    let mut e = centre + towards / c.w;
    if !e.is_finite() || (e - centre).length() > EPIPOLE_FAR {
        e = centre + towards.normalize_or_zero() * EPIPOLE_FAR;
    }
    let inside = e.x >= 0.0 && e.x <= w as f64 && e.y >= 0.0 && e.y <= h as f64;
    // Edges seen from an outside epipole (top, right, bottom, left): lines leave the screen
    // through the others, a contiguous run of the border.
    let (u_start, arc) = if inside {
        (0.0, 4.0)
    } else {
        let seen = [e.y < 0.0, e.x > size.x, e.y > size.y, e.x < 0.0];
        let start = (0..4).find(|&i| !seen[i] && seen[(i + 3) % 4]).unwrap_or(0);
        (start as f64, seen.iter().filter(|s| !**s).count() as f64)
    };
    let light_texel = |x: DVec3| {
        let c = lvp * x.extend(1.0);
        DVec2::new((c.x * 0.5 + 0.5) * msize.x, (0.5 - c.y * 0.5) * msize.y)
    };
    let eye_texel = light_texel(eye);
    let mut longest = 0.0f64;
    let list = (0..slices)
        .map(|k| {
            let b = border_point(
                u_start + (k as f64 + 0.5) / slices as f64 * arc,
                size.x,
                size.y,
            );
            let entry = if inside {
                e
            } else {
                let (s_in, _) = clip_line(e, b - e, size);
                e + (b - e) * s_in.clamp(0.0, 1.0)
            };
            let len = (b - entry).length();
            let dir = if len > 1e-9 {
                (b - entry) / len
            } else {
                (b - e).normalize_or(DVec2::X)
            };
            // The slice's plane holds the sun and the view ray through b; its image in the map
            // is the image of the in-plane direction at right angles to the sun.
            let q = DVec4::new(b.x / size.x * 2.0 - 1.0, 1.0 - b.y / size.y * 2.0, 1.0, 1.0);
            let far = inv * q;
            let v = far.truncate() / far.w - eye;
            let across = sun.cross(v).cross(sun);
            let line_d =
                (light_texel(eye + across.normalize_or_zero()) - eye_texel).normalize_or(DVec2::X);
            // Every ray of the slice leaves the eye's texel towards +line_d (its component
            // across the sun points the way `across` does), so the line before the eye's texel
            // is never walked.
            let (s_in, s_out) = clip_line(eye_texel, line_d, msize);
            let s_in = s_in.max(0.0);
            let chord = (s_out - s_in).max(0.0);
            let line_o = if chord > 0.0 {
                eye_texel + line_d * s_in
            } else {
                DVec2::ZERO
            };
            longest = longest.max(chord);
            EpiSlice {
                entry: entry.as_vec2().to_array(),
                dir: dir.as_vec2().to_array(),
                len: len as f32,
                chord: chord as f32,
                line_o: line_o.as_vec2().to_array(),
                line_d: line_d.as_vec2().to_array(),
            }
        })
        .collect();
    EpiGeometry {
        epipole: e.as_vec2().to_array(),
        size: [w as f32, h as f32],
        inside,
        u_start: u_start as f32,
        arc: arc as f32,
        slices: list,
        tree_n: ((longest.ceil() as u32) + 1).next_power_of_two().max(2),
    }
}

/// WGSL's `sign`: −1, 0 or 1 per component (Rust's `signum` gives 1 for 0).
fn sign(v: glam::Vec2) -> glam::Vec2 {
    let s = |x: f32| {
        if x > 0.0 {
            1.0
        } else if x < 0.0 {
            -1.0
        } else {
            0.0
        }
    };
    glam::Vec2::new(s(v.x), s(v.y))
}

/// "Lit" depth of texels outside the map and of leaves past the end of a chord.
const FAR_DEPTH: f32 = 3.0e38;

/// The texel of the map at integer coordinates `c` (outside: [`FAR_DEPTH`], always lit).
fn map_depth(shadow: &Raster, c: glam::IVec2) -> f32 {
    if c.x < 0 || c.y < 0 || c.x >= shadow.width as i32 || c.y >= shadow.height as i32 {
        FAR_DEPTH
    } else {
        shadow.pixel(c.x as u32, c.y as u32)[0]
    }
}

/// One slice's rectified row and its min-max tree: `2n` entries, level k (width n/2^k) at
/// offset 2n − 2n/2^k. Leaf i is the (minimum, maximum) depth over the texels the line crosses
/// between distances i and i + 1 from `line_o` (walked texel by texel).
pub fn epi_tree_row(shadow: &Raster, slice: &EpiSlice, n: u32) -> Vec<[f32; 2]> {
    let mut row = vec![[FAR_DEPTH; 2]; 2 * n as usize];
    let o = glam::Vec2::from(slice.line_o);
    let d = glam::Vec2::from(slice.line_d);
    for (i, leaf) in row.iter_mut().take(n as usize).enumerate() {
        if i as f32 >= slice.chord {
            continue;
        }
        let start = o + d * i as f32;
        let len = (slice.chord - i as f32).min(1.0);
        *leaf = leaf_range(shadow, start, d, len);
    }
    let mut level_n = n as usize;
    let mut src = 0usize;
    while level_n > 1 {
        let dst = src + level_n;
        for j in 0..level_n / 2 {
            let (a, b) = (row[src + 2 * j], row[src + 2 * j + 1]);
            row[dst + j] = [a[0].min(b[0]), a[1].max(b[1])];
        }
        src = dst;
        level_n /= 2;
    }
    row
}

/// (minimum, maximum) depth over the texels the segment `start + d·t`, t ∈ [0, len] crosses.
fn leaf_range(shadow: &Raster, start: glam::Vec2, d: glam::Vec2, len: f32) -> [f32; 2] {
    let nudge = sign(d) * 1e-4;
    let (mut mn, mut mx) = (FAR_DEPTH, -FAR_DEPTH);
    let mut t = 0.0f32;
    for _ in 0..4 {
        if t >= len {
            break;
        }
        let cell = (start + d * t + nudge).floor();
        let mut te = len;
        for k in 0..2 {
            if d[k] > 1e-9 {
                te = te.min((cell[k] + 1.0 - start[k]) / d[k]);
            } else if d[k] < -1e-9 {
                te = te.min((cell[k] - start[k]) / d[k]);
            }
        }
        let z = map_depth(shadow, cell.as_ivec2());
        (mn, mx) = (mn.min(z), mx.max(z));
        t = te.max(t + 1e-4);
    }
    [mn, mx]
}

/// A view ray in the map's texel units and light depth, `a + d·t`, and the part `[tin, tout]`
/// of its medium segment `[t0, t1]` inside the map and the light box (the CPU twin of the
/// shader's `map_ray`).
struct MapRay {
    a: Vec3,
    d: Vec3,
    t0: f32,
    t1: f32,
    tin: f32,
    tout: f32,
}

fn map_ray(p: &ScatterParams, msize: glam::Vec2, dir: Vec3, s: f32) -> MapRay {
    let (t0, t1) = medium_segment(p, dir, s);
    let t1 = t1.max(t0);
    let lvp = Mat4::from_cols_array_2d(&p.light_view_proj);
    let eye = Vec3::from(p.eye);
    let c0 = lvp * eye.extend(1.0);
    let c1 = lvp * (eye + dir).extend(1.0);
    let a = Vec3::new(
        (c0.x * 0.5 + 0.5) * msize.x,
        (0.5 - c0.y * 0.5) * msize.y,
        c0.z,
    );
    let d = Vec3::new(
        (c1.x - c0.x) * 0.5 * msize.x,
        -(c1.y - c0.y) * 0.5 * msize.y,
        c1.z - c0.z,
    );
    let (mut tin, mut tout) = (t0, t1);
    let hi = msize.extend(1.0);
    for k in 0..3 {
        if d[k].abs() < 1e-12 {
            if a[k] < 0.0 || a[k] > hi[k] {
                tout = -1.0;
            }
        } else {
            let ta = (0.0 - a[k]) / d[k];
            let tb = (hi[k] - a[k]) / d[k];
            tin = tin.max(ta.min(tb));
            tout = tout.min(ta.max(tb));
        }
    }
    MapRay {
        a,
        d,
        t0,
        t1,
        tin,
        tout,
    }
}

/// Lit length and lit weight of the stretch `[from, to]` of a ray, texel by texel (at most
/// `max_cells` texels; the last one taken takes the rest of the stretch).
fn texel_walk(
    p: &ScatterParams,
    shadow: &Raster,
    r: &MapRay,
    dir: Vec3,
    (from, to): (f32, f32),
    max_cells: u32,
) -> (f32, f32) {
    let nudge = sign(r.d.truncate()) * 1e-3;
    let (mut lit, mut weighted) = (0.0f32, 0.0f32);
    let mut t = from;
    let ext = p.light_extinction != 0;
    for i in 0..max_cells {
        if t >= to {
            break;
        }
        let q = r.a + r.d * t;
        let cell = (q.truncate() + nudge).floor();
        let mut te = to;
        if i + 1 < max_cells {
            for k in 0..2 {
                if r.d[k] > 1e-12 {
                    te = te.min((cell[k] + 1.0 - r.a[k]) / r.d[k]);
                } else if r.d[k] < -1e-12 {
                    te = te.min((cell[k] - r.a[k]) / r.d[k]);
                }
            }
        }
        let te = te.max(t);
        let c = map_depth(shadow, cell.as_ivec2()) + p.bias;
        let (z0, z1) = (r.a.z + r.d.z * t, r.a.z + r.d.z * te);
        let part = lit_part(t, te, z0, z1, c);
        lit += part;
        if ext {
            weighted += if z0 <= c {
                weight(p, dir, r.t0, t, t + part)
            } else {
                weight(p, dir, r.t0, te - part, te)
            };
        }
        t = if te > t { te } else { to };
    }
    (lit, weighted)
}

/// Length of `[t0, t1]` where the depth, linear from z0 to z1, is at most c.
fn lit_part(t0: f32, t1: f32, z0: f32, z1: f32, c: f32) -> f32 {
    if z0 <= c && z1 <= c {
        return t1 - t0;
    }
    if z0 > c && z1 > c {
        return 0.0;
    }
    let u = ((c - z0) / (z1 - z0)).clamp(0.0, 1.0);
    if z0 <= c {
        (t1 - t0) * u
    } else {
        (t1 - t0) * (1.0 - u)
    }
}

/// `(V̄, medium length, lit weight)` from the lit length and weight inside the map.
fn ray_result(p: &ScatterParams, r: &MapRay, dir: Vec3, inner: (f32, f32)) -> (f32, f32, f32) {
    let len = r.t1 - r.t0;
    let ext = p.light_extinction != 0;
    let (mut lit, mut weighted) = (
        len,
        if ext {
            weight(p, dir, r.t0, r.t0, r.t1)
        } else {
            0.0
        },
    );
    if r.tout > r.tin {
        lit = len - (r.tout - r.tin) + inner.0;
        if ext {
            weighted =
                weight(p, dir, r.t0, r.t0, r.tin) + weight(p, dir, r.t0, r.tout, r.t1) + inner.1;
        }
    }
    let vbar = if len > 0.0 {
        (lit / len).clamp(0.0, 1.0)
    } else {
        1.0
    };
    (vbar, len, weighted)
}

/// The exact visibility of one view ray (every texel it crosses, no tree): the limit that
/// `MinMax` and `Epipolar` at `tree_level` 0 compute. `(V̄, medium length, lit weight)`.
pub fn exact_ray(p: &ScatterParams, shadow: &Raster, dir: Vec3, s: f32) -> (f32, f32, f32) {
    let msize = glam::Vec2::new(shadow.width as f32, shadow.height as f32);
    let r = map_ray(p, msize, dir, s);
    let inner = if r.tout > r.tin {
        texel_walk(p, shadow, &r, dir, (r.tin, r.tout), u32::MAX)
    } else {
        (0.0, 0.0)
    };
    ray_result(p, &r, dir, inner)
}

/// Visibility of one sample ray of a slice through the slice's min-max tree `row` (CPU twin of
/// the shader's `tree_ray`). `(V̄, medium length, lit weight)`.
pub fn tree_ray(
    p: &ScatterParams,
    shadow: &Raster,
    (row, n, slice): (&[[f32; 2]], u32, &EpiSlice),
    tree_level: u32,
    dir: Vec3,
    s: f32,
) -> (f32, f32, f32) {
    let msize = glam::Vec2::new(shadow.width as f32, shadow.height as f32);
    let r = map_ray(p, msize, dir, s);
    if r.tout <= r.tin {
        return ray_result(p, &r, dir, (0.0, 0.0));
    }
    let o = glam::Vec2::from(slice.line_o);
    let ld = glam::Vec2::from(slice.line_d);
    let b0 = (r.a.truncate() - o).dot(ld);
    let bd = r.d.truncate().dot(ld);
    let nudge = if bd > 0.0 { 1e-3 } else { -1e-3 };
    let top = n.trailing_zeros();
    let (mut level, mut t, mut iter) = (top, r.tin, 0u32);
    let (mut lit, mut weighted) = (0.0f32, 0.0f32);
    let ext = p.light_extinction != 0;
    while t < r.tout && iter < MAX_ITER {
        iter += 1;
        let scale = (1u32 << level) as f32;
        let width = n >> level;
        let idx = (((b0 + bd * t + nudge) / scale).floor().max(0.0) as u32).min(width - 1);
        let (lo, hi) = (idx as f32 * scale, (idx + 1) as f32 * scale);
        let mut t_exit = r.tout;
        if bd > 1e-12 {
            t_exit = t_exit.min((hi - b0) / bd);
        } else if bd < -1e-12 {
            t_exit = t_exit.min((lo - b0) / bd);
        }
        let t_exit = t_exit.max(t);
        let (z0, z1) = (r.a.z + r.d.z * t, r.a.z + r.d.z * t_exit);
        let mm = row[(2 * n - 2 * width) as usize + idx as usize];
        let next = ((b0 + bd * t_exit + nudge) / (2.0 * scale))
            .floor()
            .max(0.0) as u32;
        let up = if next != idx >> 1 {
            (level + 1).min(top)
        } else {
            level
        };
        // What this node settles (the shader's comments say why it is one branch).
        let (mut lit_end, mut share, mut walk) = (t, 0.0f32, false);
        let (mut t_next, mut next_level) = (t_exit, up);
        let lit_all = z0.max(z1) <= mm[0] + p.bias;
        let dark_all = z0.min(z1) > mm[1] + p.bias;
        if lit_all || dark_all || (level > 0 && level <= tree_level) {
            let zm = 0.5 * (z0 + z1);
            let estimate = ((mm[1] + p.bias - zm) / (mm[1] - mm[0]).max(1e-6)).clamp(0.0, 1.0);
            share = if lit_all {
                1.0
            } else if dark_all {
                0.0
            } else {
                estimate
            };
            lit_end = t_exit;
        } else if level == 0 {
            walk = true;
            next_level = level;
        } else {
            (t_next, next_level) = (t, level - 1);
        }
        if walk {
            let (l, wt) = texel_walk(p, shadow, &r, dir, (t, t_exit), LEAF_CELLS);
            lit += l;
            weighted += wt;
        }
        lit += (lit_end - t) * share;
        if ext && lit_end > t && share > 0.0 {
            weighted += weight(p, dir, r.t0, t, lit_end) * share;
        }
        (t, level) = (t_next, next_level);
    }
    if t < r.tout {
        let (l, wt) = texel_walk(p, shadow, &r, dir, (t, r.tout), MAX_ITER);
        lit += l;
        weighted += wt;
    }
    ray_result(p, &r, dir, (lit, weighted))
}

/// Iteration cap of a tree walk (the shader's `MAX_ITER`).
const MAX_ITER: u32 = 16384;

/// Texels a leaf's stretch of a ray can cross (a unit stretch crosses at most three; the
/// fourth takes any rounding left-over).
const LEAF_CELLS: u32 = 4;

/// One sample of the sample pass: `(V̄, lit fraction of the weight, camera depth, medium
/// length)` — the texel of the shader's `samples` texture.
pub type EpiSample = [f32; 4];

/// The screen point of sample `j` of a slice.
fn sample_point(slice: &EpiSlice, j: u32, samples: u32) -> glam::Vec2 {
    let f = j as f32 / (samples - 1).max(1) as f32;
    glam::Vec2::from(slice.entry) + glam::Vec2::from(slice.dir) * (slice.len * f)
}

/// CPU reference of method `Epipolar`: V̄ of every pixel of the `depth` view (row-major),
/// with the per-pixel fall-back traced exactly ([`exact_ray`]).
pub fn epipolar_reference(
    p: &ScatterParams,
    shadow: &Raster,
    depth: &Raster,
    knobs: EpiKnobs,
) -> Vec<f32> {
    let (w, h) = (depth.width, depth.height);
    let g = epipolar_geometry(p, (w, h), (shadow.width, shadow.height), knobs.slices);
    let inv = Mat4::from_cols_array_2d(&p.inv_view_proj);
    let eye = Vec3::from(p.eye);
    let trees: Vec<Vec<[f32; 2]>> = g
        .slices
        .iter()
        .map(|s| epi_tree_row(shadow, s, g.tree_n))
        .collect();
    let samples: Vec<Vec<EpiSample>> = g
        .slices
        .iter()
        .zip(&trees)
        .map(|(slice, row)| {
            (0..knobs.samples)
                .map(|j| {
                    let q = sample_point(slice, j, knobs.samples);
                    let px = (q.x.floor().max(0.0) as u32).min(w - 1);
                    let py = (q.y.floor().max(0.0) as u32).min(h - 1);
                    let s = depth.pixel(px, py)[0];
                    let dir = crate::eval::screen_ray(inv, eye, q, w, h);
                    let (vbar, len, wt) =
                        tree_ray(p, shadow, (row, g.tree_n, slice), knobs.tree_level, dir, s);
                    [vbar, lit_fraction(p, dir, len, wt, s), s, len]
                })
                .collect()
        })
        .collect();
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let dir = crate::eval::pixel_ray(inv, eye, x, y, w, h);
            let s = depth.pixel(x, y)[0];
            let (t0, t1) = medium_segment(p, dir, s);
            let len = (t1 - t0).max(0.0);
            let pc = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let got = epi_interpolate(&g, knobs, pc, s, len, |k, j| {
                samples[k as usize][j as usize]
            });
            out.push(match got {
                Some(v) => v[0],
                None => exact_ray(p, shadow, dir, s).0,
            });
        }
    }
    out
}

/// The lit share of a ray's weight (1 when the weight is 0 or light extinction is off).
fn lit_fraction(p: &ScatterParams, dir: Vec3, len: f32, weighted: f32, s: f32) -> f32 {
    if p.light_extinction == 0 {
        return 1.0;
    }
    let (t0, _) = medium_segment(p, dir, s);
    let full = weight(p, dir, t0, t0, t0 + len);
    if full > 0.0 {
        (weighted / full).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// The pixel centred at `pc` (camera depth `s`, medium length `len`) interpolated from the
/// samples (`sample(slice, j)`) of the two slices around its line through the epipole:
/// `Some((V̄, lit fraction))`, or `None` when no neighbouring sample is within the threshold
/// (CPU twin of the shader's `epi_gather`).
pub fn epi_interpolate(
    g: &EpiGeometry,
    knobs: EpiKnobs,
    pc: glam::Vec2,
    s: f32,
    len: f32,
    sample: impl Fn(u32, u32) -> EpiSample,
) -> Option<[f32; 2]> {
    let e = glam::Vec2::from(g.epipole);
    let rv = pc - e;
    if rv.length_squared() < 1e-6 {
        return None;
    }
    let u = border_coordinate(pc, rv.normalize(), glam::Vec2::from(g.size));
    let count = knobs.slices;
    let mut rel = u - g.u_start;
    if rel < 0.0 {
        rel += 4.0;
    }
    let mut f = rel / g.arc * count as f32 - 0.5;
    let (k0, k1, wk);
    if g.inside {
        if f < 0.0 {
            f += count as f32;
        }
        k0 = (f.floor().max(0.0) as u32).min(count - 1);
        wk = (f - k0 as f32).clamp(0.0, 1.0);
        k1 = (k0 + 1) % count;
    } else {
        f = f.clamp(0.0, (count - 1) as f32);
        k0 = (f.floor() as u32).min(count - 1);
        wk = f - k0 as f32;
        k1 = (k0 + 1).min(count - 1);
    }
    let m = knobs.samples;
    let (mut total, mut acc) = (0.0f32, [0.0f32; 2]);
    for (k, wslice) in [(k0, 1.0 - wk), (k1, wk)] {
        let slice = &g.slices[k as usize];
        let along = (pc - glam::Vec2::from(slice.entry)).dot(glam::Vec2::from(slice.dir));
        let j = if slice.len > 1e-6 {
            (along / slice.len * (m - 1) as f32).clamp(0.0, (m - 1) as f32)
        } else {
            0.0
        };
        let j0 = (j.floor() as u32).min(m - 1);
        let j1 = (j0 + 1).min(m - 1);
        let wj = j - j0 as f32;
        for (jj, wsample) in [(j0, 1.0 - wj), (j1, wj)] {
            let v = sample(k, jj);
            let wt = wslice * wsample;
            let near = (v[2] - s).abs() <= knobs.threshold * s.abs()
                && (v[3] - len).abs() <= knobs.threshold * len;
            if near && wt > 0.0 {
                total += wt;
                acc[0] += wt * v[0];
                acc[1] += wt * v[1];
            }
        }
    }
    (total > 1e-6).then(|| [acc[0] / total, acc[1] / total])
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

/// Method `Epipolar` on the GPU: rectify each slice's line of the map and build its min-max
/// tree (`epi_rectify`, `epi_tree` per level), trace the slices' samples (`epi_sample`),
/// interpolate every pixel (`epi_gather`), and trace their own ray for the pixels it listed as
/// having no usable sample (`epi_fallback`).
/// `binds` are the `MinMax` dispatch's.
fn dispatch_epipolar(
    gpu: &Gpu,
    u: &ScatterParams,
    knobs: EpiKnobs,
    shadow: &GpuTexture,
    (w, h): (u32, u32),
    binds: &[(u32, Bind)],
) -> Result<(), NodeError> {
    let g = epipolar_geometry(u, (w, h), (shadow.width, shadow.height), knobs.slices);
    let table = gpu.upload(knobs.slices, 3, 4, &EpiParams::slice_texels(&g))?;
    let words = knobs.slices as u64 * 4 * g.tree_n as u64;
    let too_many = || NodeError::Param {
        param: "epi_slices".into(),
        message: format!(
            "{} slices of {} tree entries need {} MiB, over the adapter's storage-buffer limit \
             of {} MiB: use fewer slices or a smaller shadow map",
            knobs.slices,
            2 * g.tree_n,
            (words * 4) >> 20,
            gpu.limits.max_storage_buffer_binding_size >> 20
        ),
    };
    if words * 4 > gpu.limits.max_storage_buffer_binding_size {
        return Err(too_many());
    }
    let tree = gpu.buffer_zeroed(u32::try_from(words).map_err(|_| too_many())?)?;
    let samples = gpu.texture(knobs.samples, knobs.slices, TexFormat::Rgba32F)?;
    let base = EpiParams::new(&g, knobs);
    let constants = [
        ("EXTINCTION", u.light_extinction as f64),
        ("LIGHT_MAP", 0.0),
        ("SOFT", 0.0),
    ];
    let pass = |entry: &str, level: u32, extra: Option<(u32, Bind)>, size: (u32, u32)| {
        let e = EpiParams { level, ..base };
        let mut b = binds.to_vec();
        b.push((16, Bind::Uniform(bytemuck::bytes_of(&e))));
        b.push((17, Bind::Texture(&table)));
        b.push((18, Bind::Buffer(&tree)));
        b.extend(extra);
        gpu.dispatch_with(SHADER, entry, &b, size, &constants)
    };
    pass("epi_rectify", 0, None, (g.tree_n, knobs.slices))?;

    for level in 1..=base.tree_top {
        pass("epi_tree", level, None, (g.tree_n >> level, knobs.slices))?;
    }
    pass(
        "epi_sample",
        0,
        Some((19, Bind::Storage(&samples))),
        (knobs.samples, knobs.slices),
    )?;
    let list = gpu.buffer_zeroed(w * h)?;
    let count = gpu.buffer_zeroed(1)?;
    let with_list = |entry: &str, level: u32, size: (u32, u32)| {
        let e = EpiParams { level, ..base };
        let mut b = binds.to_vec();
        b.push((16, Bind::Uniform(bytemuck::bytes_of(&e))));
        b.push((17, Bind::Texture(&table)));
        b.push((20, Bind::Texture(&samples)));
        b.push((21, Bind::Buffer(&list)));
        b.push((22, Bind::Buffer(&count)));
        gpu.dispatch_with(SHADER, entry, &b, size, &constants)
    };
    with_list("epi_gather", 0, (w, h))?;
    // The fall-back pixels (depth discontinuities) trace their own ray: one read-back of the
    // count sizes that dispatch.
    let n = gpu
        .read_buffer_i32(&count)?
        .first()
        .copied()
        .unwrap_or(0)
        .max(0) as u32;
    if n > 0 {
        with_list(
            "epi_fallback",
            n.min(w * h),
            (256, n.min(w * h).div_ceil(256)),
        )?;
    }
    Ok(())
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
                    message:
                        "needs method BruteForce (MinMax and Epipolar walk the hard shadow map)"
                            .into(),
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
        // Pipeline constant: light extinction's code is compiled away when it is off.
        let extinction_constant = if extinction { 1.0 } else { 0.0 };
        let soft_constant = if soft.is_some() { 1.0 } else { 0.0 };
        binds.push((14, Bind::Volume(&soft_volume)));
        binds.push((15, Bind::Uniform(bytemuck::bytes_of(&sv))));
        if let Some((map, m)) = &light_map {
            if method != Method::BruteForce {
                return Err(NodeError::Input {
                    port: "light_map".into(),
                    message:
                        "needs method BruteForce (MinMax and Epipolar integrate visibility only)"
                            .into(),
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
            let constants = [
                ("EXTINCTION", extinction_constant),
                ("LIGHT_MAP", 1.0),
                ("SOFT", soft_constant),
            ];
            ctx.gpu
                .dispatch_with(SHADER, "brute_force", &binds, (w, h), &constants)?;
        } else if method != Method::BruteForce {
            let (levels, atlas) = build_pyramid(ctx.gpu, &shadow)?;
            binds.push((6, Bind::Texture(&atlas)));
            binds.push((10, Bind::Uniform(bytemuck::bytes_of(&levels))));
            if method == Method::MinMax {
                let constants = [
                    ("EXTINCTION", extinction_constant),
                    ("LIGHT_MAP", 0.0),
                    ("SOFT", 0.0),
                ];
                ctx.gpu
                    .dispatch_with(SHADER, "min_max", &binds, (w, h), &constants)?;
            } else {
                let knobs = EpiKnobs {
                    slices: ctx.int("epi_slices")? as u32,
                    samples: ctx.int("epi_samples")? as u32,
                    threshold: ctx.f32("epi_threshold")?,
                    tree_level: ctx.int("tree_level")? as u32,
                };
                dispatch_epipolar(ctx.gpu, &u, knobs, &shadow, (w, h), &binds)?;
            }
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
            let constants = [
                ("EXTINCTION", extinction_constant),
                ("LIGHT_MAP", 0.0),
                ("SOFT", soft_constant),
            ];
            ctx.gpu
                .dispatch_with(SHADER, "brute_force", &binds, (w, h), &constants)?;
        }
        ctx.set("visibility", PortValue::Scalar(Arc::new(vis)));
        ctx.set("inscatter", PortValue::Image(Arc::new(ins)));
        ctx.set("transmittance", PortValue::Scalar(Arc::new(tr)));
        ctx.set("depth", depth_value);
        Ok(())
    }
}
