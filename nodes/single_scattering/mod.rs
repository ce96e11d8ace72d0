//! `SingleScattering`: physically based single scattering in a homogeneous medium lit by the
//! sun (SPEC §3, seed 000 eq. 1–2), or in a heterogeneous one (a `density` volume).
//!
//! `L_scat = σt ρ f(θ) · L_i (1 − e^{−sσt})/σt · V̄`, with `V̄ = s⁻¹ ∫₀ˢ V(x_t) dt` the average
//! visibility of the view ray up to the first surface at distance `s` (sky: the camera's far
//! distance), found by marching the shadow map, and `f` the Henyey–Greenstein phase function
//! `(1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2})`, cos θ = dot(view direction, direction to the sun)
//! — or, with a `phase` table connected, that table per RGB channel (`nodes/phase/`).
//! The factor `(1 − e^{−sσt})/σt` is evaluated without cancellation and tends to `s` as σt → 0.
//! A sample is lit when it lies outside the map's footprint (no caster is there), under a clear
//! texel (no occluder), or when its light-space depth is at most its texel's depth plus `bias`;
//! an occluder shadows every sample behind it at any distance, past the map's far plane too, so
//! the light is right wherever the medium is: fog far below a roof, a spot's cone far past its
//! gobo (`ShadowMap`'s docs say how the map is fitted; `cargo test --test light -- reach`). Units: the sun's irradiance E (W/m², from the
//! `Scene`) times f (1/sr) times σt·length (dimensionless) gives `inscatter` in W/(m²·sr).
//!
//! Spot and point lights (seed 003 Fig. 5; seed 000 §5.3: the techniques need only a shadow
//! map): when the `shadow` map is a spot's or point light's (`ShadowMap`'s `light`), each
//! sample at distance t of the view ray adds `V(x) · I · a(x) · f(θ_x) · e^{−σt (t − t0)}`
//! (`· e^{−σt ℓ(x)}` with light extinction, ℓ now the distance from x towards the light inside
//! the box, at most the distance to the light; `· M(x)` with a light map in the spot's
//! projection, a gobo) over its interval Δ = len/steps (the midpoint rule, converging as steps
//! grow): `L_scat = σt ρ Σ_i …`, with I the light's intensity (W/sr), a glTF's attenuation —
//! inverse square, a spot's smooth cone, the range window — and θ_x the angle between the view
//! ray and the direction from x to the light. The factored form does not hold. `MinMax` with a
//! spot walks the pyramid of its perspective map along the ray's image (a line in the map; the
//! map's line parameter σ and the ray's t are related by t(σ) = t_a + (t_b − t_a) σ w_a /
//! ((1 − σ) w_b + σ w_a), w the clip w, and the linear depth is affine in t, so a cell is settled
//! by its two ends as for the sun): the lit stretches are exact, and each run of them is
//! integrated equiangularly (θ seen from the light's closest approach to the ray, so dt/d² =
//! dθ/h and what is left is smooth) with `steps` midpoint nodes per π of θ, at least one per
//! run; `visibility` is then the exact lit fraction (`min_max.wgsl`, `min_max_local`;
//! `cargo test --test light -- min_max_converges`). A point light's cube atlas is walked face
//! by face (each face a 90° perspective map whose pyramid cells stay inside it), in order along
//! the ray, the runs carried across the faces' seams. `Epipolar` with a spot places its slices
//! through the spot's screen position: each slice's rays lie in one plane through the spot,
//! which its perspective map images as one line, rectified and treed as the sun's; a sample ray
//! walks its tree in σ (a mixed leaf's texels one by one) and keeps ρ, the lit share of its
//! in-scatter integral; a pixel takes ρ from the samples and integrates its own unshadowed
//! in-scatter (`epipolar_lamp.wgsl`; `cargo test --test light -- spot_epipolar`). With a point
//! light (six projections, no single epipole) `Epipolar` runs MinMax. A lamp with a light map is marched by
//! BruteForce whatever the method. A lamp's `soft` volume
//! (SoftVisibility of radius `light_radius`) is read with the perspective divide (a point
//! light's: on the face the sample lies in) and its slices in q = 1 − near / w. BruteForce's `visibility` is the fraction of lit samples (outside the map's
//! footprint or behind a spot counts as lit, as for the sun).
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
//! Heterogeneous media (issue #61): with a `density` Volume connected (`VdbVolume`,
//! `NoiseVolume`, `BlendVolume`), σt(x) = `sigma_t` · density(x) inside the volume's box and 0
//! outside (`bounds` none or density: the box bounds the medium; box or tagged: the ray is
//! clipped to both). The light reaching a point is attenuated by the density between it and the
//! light — every light: sun, spot, point —, so the smoke shadows itself and what lies behind it
//! in the medium, on top of the occluders' shadow map: T_light(x) = e^{−σt ∫ density} towards the
//! light, read from a transmittance volume over the density's box built once per run
//! (`transmittance_resolution` texels on its longest side, `light_steps` midpoints per texel;
//! `density.rs`). The view ray is marched by `steps` midpoints: sample i, standing for its
//! interval Δ with σ_i = σt · density(x_i), adds ρ f(θ) L_i T_i (1 − e^{−σ_i Δ}) with T_i the view
//! ray's transmittance before it and L_i = V(x_i) · T_light(x_i) (· a lamp's falloff); the
//! `transmittance` output is the product of the e^{−σ_i Δ}, and V̄ the mean of V · T_light over
//! the samples where the density is above 0 — the mean light reaching the smoke along the ray
//! (1 on a ray that meets none), so transfer functions, hole filling and every stylization
//! downstream keep working. Empty space is skipped: both marches step over 4³-texel bricks of
//! the density holding nothing (exact: what they skip adds 0), so a small plume in a large box
//! costs less than marching all of it (1.3× on lavapipe, BENCHMARKS.md). MinMax and Epipolar walk the shadow map's trees and do
//! not integrate a density: with one they run this BruteForce march, and the node says so (a
//! note). `light_extinction` does not apply (the density's own attenuation is always on); a light
//! map with a density is refused. A constant density equals the homogeneous box with light
//! extinction to 1.3e-5 of the peak, and the GPU the CPU reference (a direct march towards the
//! light from every sample) to 1.2e-4 (`cargo test --test light -- density`).
//!
//! Light map (SPEC §5): with `light_map` connected the sun reaching x is multiplied by the map's
//! colour at x (bilinear, clamp to edge, in the map's own light projection), so the factored
//! form no longer holds: `L_scat = σt ρ f E Σ_i V_i M(x_i) ∫_{interval i} E(t) dt` — the same
//! interval weights as light extinction. `BruteForce` only; `MinMax` or `Epipolar` with a light
//! map is refused.
//!
//! Methods: `BruteForce` marches `steps` samples per pixel at the centres of equal intervals
//! (moved by up to ±`jitter`/2 of an interval with a per-pixel hash, the same every frame or,
//! with `jitter_pattern = frame`, rotated by the golden ratio each frame). `MinMax` (the accelerated
//! method, in the spirit of Chen et al.'s min-max mip-maps, here as a 2D quadtree over the map
//! instead of 1D rows of an epipolar rectification) builds a pyramid of per-block minimum and
//! maximum depth and walks each view ray through it: blocks the ray passes entirely in front of
//! their minimum are lit, blocks it passes entirely behind their maximum are shadowed, and only
//! mixed blocks are refined down to texels, where the lit length is solved exactly. It computes
//! the limit of `BruteForce` as steps → ∞ (the same nearest-texel test and bias), so `steps`
//! and `jitter` do not apply to it; its cost grows with the number of light/shadow transitions
//! along a ray, not with the ray's length in texels. `Epipolar` (the fast method, after
//! Engelhardt & Dachsbacher 2010, Yusov 2013 and Chen et al. 2011) traces only `epi_slices` ×
//! `epi_samples` rays placed on epipolar lines through the light's screen position, each through a
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
//! | `density` | in | Volume (optional) | a heterogeneous medium: σt(x) = sigma_t · density(x) in its box, the light attenuated by it |
//! | `visibility` | out | Scalar | V̄ ∈ [0, 1] |
//! | `depth` | out | Depth | the input depth, passed on for transfer functions |
//! | `inscatter` | out | Image | L_scat, W/(m²·sr) (linear RGB, alpha 1) |
//! | `transmittance` | out | Scalar | e^{−sσt}, for compositing surfaces behind the medium |
//! | `light_transmittance` | out | Volume | with a density, the light's transmittance through it over its box (for `Composite`, so surfaces under the smoke are shadowed by it); without one, a 1×1×1 volume of 1 |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `sigma_t` | Float | 0.08 | 0…1e4 1/m | extinction σt |
//! | `albedo` | Float | 0.9 | 0…1 | scattering albedo ρ |
//! | `g` | Float | 0.5 | −0.999…0.999 | Henyey–Greenstein asymmetry |
//! | `tint` | Colour | (1, 1, 1, 1) | 0…1e6 | multiplies the sun's colour |
//! | `intensity` | Float | 1 | 0…1e6 | multiplies the sun's irradiance |
//! | `steps` | Int | 128 | 1…8192 | samples per view ray (quality knob); MinMax with a spot: equiangular nodes per π integrating its lit stretches |
//! | `jitter` | Float | 0 | 0…1 | per-pixel offset of the samples, in intervals |
//! | `jitter_pattern` | Enum | screen | screen, frame | screen: the per-pixel offset is the same every frame; frame: the hash h(x, y) becomes fract(h + φ·⌊t⌋), φ = 0.618… (golden-ratio steps), so consecutive frames put the samples elsewhere and a `TemporalAccumulate` window of n frames sees n evenly spread offsets |
//! | `bias` | Float | 0.002 | 0…0.1 | depth bias of the shadow test |
//! | `method` | Enum | BruteForce | BruteForce, MinMax, Epipolar | visibility algorithm |
//! | `bounds` | Enum | none | none, box, tagged, density | where the medium is (density: the `density` volume's box) |
//! | `box_min`, `box_max` | Vec3 | (−5, 0, −5), (5, 5, 5) | ±1e6 m | the box (bounds = box) |
//! | `light_extinction` | Enum | off | off, on | attenuate the sun through the medium (homogeneous media; a density always attenuates) |
//! | `transmittance_resolution` | Int | 64 | 2…512 texels | with a density, quality knob: the light transmittance volume's longest side |
//! | `light_steps` | Int | 64 | 1…4096 | with a density, quality knob: samples per light ray of that volume |
//! | `min_level` | Int | 0 | 0…14 | MinMax quality knob: mixed blocks of 2^level texels at and below this level are estimated (occluder depth taken as spread evenly over the block's [min, max]) instead of refined; 0 = exact |
//! | `epi_slices` | Int | 512 | 4…2048 | Epipolar quality knob: slices (lines through the epipole) |
//! | `epi_samples` | Int | 256 | 2…4096 | Epipolar quality knob: traced rays per slice, ends included |
//! | `epi_threshold` | Float | 0.02 | 0…100 | Epipolar quality knob: relative depth / medium-length difference above which a sample is not used for a pixel (0: every pixel traces its own ray) |
//! | `tree_level` | Int | 0 | 0…14 | Epipolar quality knob: 1D tree nodes of 2^level texels at and below this level are estimated like `min_level`; 0 = exact |

use glam::{Mat4, Vec3};
use std::sync::Arc;

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx, IDENTITY};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

mod brute_force;
mod density;
mod epipolar;
mod epipolar_lines;
mod gpu;
mod map_ray;
mod medium;
mod params;

pub use brute_force::{light_path, reference_pixel, reference_pixel_phase};
pub use density::{density_reference_pixel, light_transmittance, Density, DensityView};
pub use epipolar::{
    epi_interpolate, epi_tree_row, epipolar_geometry, epipolar_reference, tree_ray, EpiGeometry,
    EpiKnobs, EpiSample, EpiSlice,
};
pub use gpu::build_pyramid;
pub use map_ray::exact_ray;
pub use medium::{medium_segment, weight, PixelResult};
pub use params::{
    pyramid_layout, BuildParams, EpiParams, LevelsParams, LightMapView, ScatterParams, SoftView,
};

/// The `SingleScattering` node kind.
pub struct SingleScattering;

tyndall_engine::choice_enum! {
    /// Visibility algorithms.
    pub enum Method { BruteForce = "BruteForce", MinMax = "MinMax", Epipolar = "Epipolar" }
}

tyndall_engine::choice_enum! {
    /// Where the medium is.
    pub enum Bounds { None = "none", Box = "box", Tagged = "tagged", Density = "density" }
}

tyndall_engine::choice_enum! {
    /// Whether the per-pixel jitter is the same every frame or drawn anew each frame.
    pub enum JitterPattern { Screen = "screen", Frame = "frame" }
}

tyndall_engine::choice_enum! {
    /// Whether the sun is attenuated on its way through the medium.
    pub enum Extinction { Off = "off", On = "on" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        sigma_t: f32 = ParamSpec::float("sigma_t", 0.08, 0.0, 1e4, "1/m", "Extinction coefficient σt."),
        albedo: f32 = ParamSpec::float("albedo", 0.9, 0.0, 1.0, "", "Scattering albedo ρ."),
        g: f32 = ParamSpec::float("g", 0.5, -0.999, 0.999, "", "Henyey–Greenstein asymmetry (>0 forward scattering)."),
        tint: [f32; 4] = ParamSpec::colour("tint", [1.0; 4], 0.0, 1e6, "linear RGB", "Multiplies the sun's colour."),
        intensity: f32 = ParamSpec::float("intensity", 1.0, 0.0, 1e6, "", "Multiplies the sun's irradiance."),
        steps: i64 = ParamSpec::int("steps", 128, 1, 8192, "samples", "Samples per view ray (quality knob); with a spot and MinMax: the equiangular nodes per π of angle seen from the light that integrate its lit stretches."),
        jitter: f32 = ParamSpec::float("jitter", 0.0, 0.0, 1.0, "intervals", "Per-pixel random offset of the samples."),
        jitter_pattern: JitterPattern = ParamSpec::choice("jitter_pattern", JitterPattern::NAMES, "screen", "screen: the jitter is fixed on the screen (the same every frame); frame: its phase moves on by the golden ratio each frame, so a TemporalAccumulate window of n frames sees n evenly spread offsets per pixel.").when("method", &["BruteForce"]),
        bias: f32 = ParamSpec::float("bias", 0.002, 0.0, 0.1, "depth", "Shadow test bias in light-space depth."),
        method: Method = ParamSpec::choice("method", Method::NAMES, "BruteForce", "Visibility algorithm. On an NVIDIA H200 at 1080p Epipolar's fixed cost (~2 ms) makes it 0.3–0.6× the speed of BruteForce at equal error; MinMax 0.4–1×: BruteForce is the GPU default (BENCHMARKS.md, per adapter). Lamps: a spot runs all three; with a point light Epipolar runs MinMax (six faces, no single epipole); a lamp with a light map runs BruteForce."),
        min_level: i64 = ParamSpec::int("min_level", 0, 0, 14, "level", "MinMax quality knob: blocks of 2^level texels at and below this level are estimated, not refined (0 = exact).").when("method", &["MinMax", "Epipolar"]),
        epi_slices: i64 = ParamSpec::int("epi_slices", 512, 4, 2048, "slices", "Epipolar quality knob: lines through the light's screen position (the sun's, or a spot's) whose rays are traced.").when("method", &["Epipolar"]),
        epi_samples: i64 = ParamSpec::int("epi_samples", 256, 2, 4096, "samples", "Epipolar quality knob: traced rays per slice, end points included.").when("method", &["Epipolar"]),
        epi_threshold: f32 = ParamSpec::float("epi_threshold", 0.02, 0.0, 100.0, "relative", "Epipolar quality knob: a sample whose camera depth (or medium length) differs from a pixel's by more than this share is not used for it; a pixel left with none traces its own ray (0: every pixel does).").when("method", &["Epipolar"]),
        tree_level: i64 = ParamSpec::int("tree_level", 0, 0, 14, "level", "Epipolar quality knob: nodes of the 1D min-max trees spanning 2^level texels at and below this level are estimated, not refined (0 = exact).").when("method", &["Epipolar"]),
        bounds: Bounds = ParamSpec::choice("bounds", Bounds::NAMES, "none", "Where the medium is: none (fills every view ray, the seed's model; with a density: the density's box), box (box_min…box_max), tagged (the bounds of the scene's objects tagged `medium`), density (the box of the volume on `density`)."),
        box_min: [f32; 3] = ParamSpec::vec3("box_min", [-5.0, 0.0, -5.0], -1e6, 1e6, "m", "Low corner of the medium box (bounds = box), scene coordinates.").when("bounds", &["box"]),
        box_max: [f32; 3] = ParamSpec::vec3("box_max", [5.0, 5.0, 5.0], -1e6, 1e6, "m", "High corner of the medium box (bounds = box), scene coordinates.").when("bounds", &["box"]),
        transmittance_resolution: i64 = ParamSpec::int("transmittance_resolution", 64, 2, 512, "texels", "With a density, quality knob: texels on the longest side of the light transmittance volume over the density's box (the light reaching each point through the smoke)."),
        light_steps: i64 = ParamSpec::int("light_steps", 64, 1, 4096, "samples", "With a density, quality knob: samples per light ray when the light transmittance volume is built."),
        light_extinction: Extinction = ParamSpec::choice("light_extinction", Extinction::NAMES, "off", "off: the sun reaches every point unattenuated (seed eq. 1); on: by e^(−σt ℓ), ℓ = distance to the medium's boundary towards the sun (needs bounds)."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "SingleScattering",
    category: "Scattering",
    doc: "Single scattering of a light in a homogeneous medium, or a heterogeneous one from a density volume: average visibility V̄, in-scatter and transmittance along each view ray.",
    inputs: &[
        PortSpec::required("shadow", &[PortType::ShadowMap], "Shadow map the medium sees."),
        PortSpec::required("depth", &[PortType::Depth], "Camera linear depth (from GBuffer)."),
        PortSpec::input("light_map", &[PortType::LightMap], "Light map multiplying the incoming light (unconnected: 1)."),
        PortSpec::input("phase", &[PortType::Phase], "Tabulated phase function (unconnected: Henyey–Greenstein g)."),
        PortSpec::input("soft", &[PortType::SoftShadow], "Soft visibility (SoftVisibility) instead of the hard shadow-map test; BruteForce only."),
        PortSpec::input("scene", &[PortType::Scene], "The scene whose objects tagged `medium` bound the medium (bounds = tagged)."),
        PortSpec::input("density", &[PortType::Volume], "Density of a heterogeneous medium (VdbVolume, NoiseVolume, BlendVolume): σt(x) = sigma_t · density(x) inside its box, 0 outside; the light is attenuated by it (self-shadowing)."),
    ],
    outputs: &[
        PortSpec::output("visibility", &[PortType::Scalar], "Average visibility V̄ of the view ray."),
        PortSpec::output("depth", &[PortType::Depth], "The input depth, passed on."),
        PortSpec::output("inscatter", &[PortType::Image], "In-scattered radiance, W/(m²·sr) (linear RGB)."),
        PortSpec::output("transmittance", &[PortType::Scalar], "e^(−s σt) along the view ray."),
        PortSpec::output("light_transmittance", &[PortType::Volume], "With a density: the light's transmittance through it over the density's box (Composite's light_transmittance shadows surfaces by the smoke); without one: 1."),
    ],
    params: Params::SPECS,
})
.shaders(&[BRUTE_FORCE, MIN_MAX, EPIPOLAR, density::DENSITY])
.uniforms(&[ScatterParams::LAYOUT, tyndall_engine::eval::LightBlock::LAYOUT, SoftView::LAYOUT, LevelsParams::LAYOUT, BuildParams::LAYOUT, LightMapView::LAYOUT, EpiParams::LAYOUT, DensityView::LAYOUT]);

/// Method `BruteForce` (and its light-map variant).
const BRUTE_FORCE: Shader = crate::shader(
    "single_scattering/brute_force",
    include_str!("../../shaders/single_scattering/brute_force.wgsl"),
);
/// Method `MinMax`: the pyramid's levels and the traversal.
const MIN_MAX: Shader = crate::shader(
    "single_scattering/min_max",
    include_str!("../../shaders/single_scattering/min_max.wgsl"),
);
/// Method `Epipolar`: rectification, trees, samples, gather, fall-back.
const EPIPOLAR: Shader = crate::shader(
    "single_scattering/epipolar",
    include_str!("../../shaders/single_scattering/epipolar.wgsl"),
);

/// The jitter's phase at frame `time` for `jitter_pattern = frame`: fract(φ·⌊time⌋) with φ the
/// golden ratio's fractional part (a Kronecker sequence: any n consecutive frames' phases are
/// spread over [0, 1) within about 1/n of evenly).
pub fn jitter_phase(time: f64) -> f32 {
    const PHI: f64 = 0.618_033_988_749_894_9;
    let v = time.floor() * PHI;
    (v - v.floor()) as f32
}

/// A soft visibility volume and a light map work with BruteForce only.
fn check_method(method: Method, soft: bool, light_map: bool) -> Result<(), NodeError> {
    let refuse = |port: &str, why: &str| NodeError::Input {
        port: port.into(),
        message: format!("needs method BruteForce ({why})"),
    };
    if method == Method::BruteForce {
        Ok(())
    } else if soft {
        Err(refuse(
            "soft",
            "MinMax and Epipolar walk the hard shadow map",
        ))
    } else if light_map {
        Err(refuse(
            "light_map",
            "MinMax and Epipolar integrate visibility only",
        ))
    } else {
        Ok(())
    }
}

/// Where the medium is: `None` (everywhere), the box, or the tagged objects' bounds.
fn medium_bounds(
    ctx: &RunCtx,
    p: &Params,
    extinction: bool,
) -> Result<Option<(Vec3, Vec3)>, NodeError> {
    match p.bounds {
        Bounds::None if extinction => Err(NodeError::Param {
            param: "light_extinction".into(),
            message: "on needs a bounded medium (the sun is attenuated up to its boundary): set \
                      bounds to box or tagged"
                .into(),
        }),
        Bounds::None => Ok(None),
        Bounds::Box => {
            let (lo, hi) = (Vec3::from(p.box_min), Vec3::from(p.box_max));
            if lo.cmpgt(hi).any() {
                return Err(NodeError::Param {
                    param: "box_max".into(),
                    message: format!("{hi} is below box_min {lo} on some axis"),
                });
            }
            Ok(Some((lo, hi)))
        }
        Bounds::Tagged => Ok(Some(tagged_bounds(ctx)?)),
        Bounds::Density => Err(NodeError::Input {
            port: "density".into(),
            message: "must be connected when bounds = density".into(),
        }),
    }
}

/// The bounds of the objects tagged `medium` in the scene on the `scene` port.
fn tagged_bounds(ctx: &RunCtx) -> Result<(Vec3, Vec3), NodeError> {
    let input = |message: &str| NodeError::Input {
        port: "scene".into(),
        message: message.into(),
    };
    let scene = ctx
        .scene_opt("scene")?
        .ok_or_else(|| input("must be connected when bounds = tagged"))?;
    scene.scene.medium.ok_or_else(|| {
        input("has no objects tagged `medium` (glTF node extras: {\"tags\": [\"medium\"]})")
    })
}

impl NodeKind for SingleScattering {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    /// With `jitter_pattern = frame` the picture changes with the frame: its phase is keyed.
    fn volatile_key(&self, key: &tyndall_engine::eval::KeyInput) -> u64 {
        match Params::from_params(key.params).map(|p| p.jitter_pattern) {
            Ok(JitterPattern::Frame) => jitter_phase(key.time).to_bits() as u64 | 1 << 32,
            _ => 0,
        }
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let (shadow, light) = ctx.shadow_map("shadow")?;
        let depth_value = ctx.require("depth")?.clone();
        let (depth, camera) = ctx.depth("depth")?;
        let phase = ctx.phase_opt("phase")?;
        let soft = ctx.soft_shadow_opt("soft")?;
        let light_map = ctx.light_map_opt("light_map")?;
        check_method(p.method, soft.is_some(), light_map.is_some())?;
        if let Some((_, sm)) = &soft {
            if sm.local.map(|l| l.point) != light.local.map(|l| l.point) {
                return Err(NodeError::Input {
                    port: "soft".into(),
                    message: "the SoftVisibility volume was built from another light's map than \
                              `shadow`: connect both to the same ShadowMap"
                        .into(),
                });
            }
        }
        let density = ctx.volume_opt("density")?;
        let extinction = p.light_extinction == Extinction::On;
        let bounds = match &density {
            // The density's box bounds the medium (and the box or tagged bounds, when set, too:
            // the passes clip the ray to both).
            Some((_, b)) if matches!(p.bounds, Bounds::None | Bounds::Density) => {
                Some((Vec3::from(b[0]), Vec3::from(b[1])))
            }
            _ => medium_bounds(ctx, &p, extinction && density.is_none())?,
        };
        if density.is_some() {
            density::check(light_map.is_some())?;
            if p.method != Method::BruteForce {
                ctx.note(format!(
                    "method {} runs BruteForce with a density (its trees walk the shadow map only)",
                    p.method.name()
                ));
            }
        }
        // With a density the light's attenuation is the density's own (self-shadowing).
        let extinction = extinction && density.is_none();
        let mut u = ScatterParams::new(&camera, &light, &p).with_bounds(bounds, extinction);
        u.phase_width = phase.as_ref().map_or(0, |t| t.width);
        if p.jitter_pattern == JitterPattern::Frame {
            u.jitter_phase = jitter_phase(ctx.time);
        }
        if let Some((v, _)) = &soft {
            u.soft_slices = v.size[2];
        }
        let inputs = gpu::Inputs {
            shadow: &shadow,
            depth: &depth,
            light,
            phase: phase.as_deref(),
            soft: soft.as_ref().map(|(v, m)| (&**v, *m)),
            light_map: light_map.as_ref().map(|(t, m)| (&**t, *m)),
            density: density.as_ref().map(|(v, b)| (&**v, *b)),
        };
        let ([vis, ins, tr], light_tr) = gpu::scatter(ctx.gpu, &u, &inputs, &p)?;
        let light_tr = match light_tr {
            Some(v) => Some(v),
            // Without a density the light crosses nothing: a volume of 1, made when wanted.
            None if ctx.wants("light_transmittance") => {
                Some((ctx.gpu.upload_volume([1, 1, 1], &[1.0])?, [[0.0; 3]; 2]))
            }
            None => None,
        };
        if let Some((v, b)) = light_tr {
            ctx.set("light_transmittance", PortValue::Volume(Arc::new(v), b));
        }
        ctx.set("visibility", PortValue::Scalar(Arc::new(vis)));
        ctx.set("inscatter", PortValue::Image(Arc::new(ins)));
        ctx.set("transmittance", PortValue::Scalar(Arc::new(tr)));
        ctx.set("depth", depth_value);
        Ok(())
    }
}
