//! Phase functions for the scattering chain (SPEC §7, seed 002 §3): `HenyeyGreenstein`,
//! `Rayleigh`, `Mie`, `IceCrystals` and `MultipleScatteringPhase`, each producing a `Phase` table that
//! `SingleScattering` uses instead of its built-in Henyey–Greenstein when connected.
//!
//! **The table** (a `Phase` port; `--output node.phase=p.exr` writes it as a W×1 RGB EXR):
//! texel i holds p(θ_i) at θ_i = π (i + 0.5)/W for 680 / 550 / 440 nm in the R, G, B channels, in
//! 1/sr, normalised so that the midpoint rule integrates it to one:
//! 2π Σ_i p(θ_i) sin θ_i · π/W = 1 per channel. Consumers interpolate linearly between texel
//! centres and clamp at the ends ([`PhaseTable::lookup`]).
//!
//! - `HenyeyGreenstein`: p = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}).
//! - `Rayleigh`: p = 3/(16π) (1 + cos²θ) (air molecules; the wavelength dependence is in the
//!   scattering coefficient, not the phase function).
//! - `Mie`: the Lorenz–Mie series (`nodes/algorithms/lorenz_mie.rs`, Bohren–Huffman in f64) for spheres of
//!   refractive index `n_real` + i `n_imag` whose radii follow a log-normal number distribution
//!   (median `radius` µm, geometric standard deviation `spread`), averaged over `radii` sizes;
//!   each texel is the mean of up to four sub-angles when the size parameter makes the ripple
//!   finer than a texel. Presets (seed 002 Table 2 sizes; spreads chosen here, as the seed gives
//!   Pruppacher & Klett's distributions without numbers): `cloud` = `cloud_radius` (10 µm,
//!   1…50) with σ_g `cloud_spread` (1.5); `rain` = `rain_radius` (1 mm, 0.1…4 mm) with σ_g 1.2;
//!   both water with its dispersion (`lorenz_mie::water_index`: 1.3307 / 1.3342 / 1.3401 at
//!   680 / 550 / 440 nm, which separates a rainbow's colours); `custom` uses the parameters
//!   (one index in every channel). The series is computed on the
//!   CPU (as the issue asks) and normalised on the GPU.
//! - `IceCrystals` (seed 002 §3, Fig. 3: randomly oriented hexagonal crystals, after Hess and
//!   Wiegner): geometric optics traced through the prism with Fresnel terms plus the
//!   diffraction peak, per channel with ice's dispersion (`nodes/algorithms/ice_optics.rs`, on
//!   the CPU as Mie's series; normalised on the GPU). Its halos fall at the minimum deviations
//!   D = 2 asin(n sin(A/2)) − A of the 60° (22°) and 90° (46°) prisms, red inside blue.
//! - `MultipleScatteringPhase` (seed 002 eq. 20, 23): Ams_n = δ ∗ P ∗ … ∗ P (n-fold spherical
//!   self-convolution of the input table P). A convolution of rotationally symmetric functions
//!   multiplies their Legendre moments, so with χ_l = 2π Σ_i P(θ_i) P_l(cos θ_i) sin θ_i · π/W
//!   (l < W), Ams_n = Σ_l (2l + 1)/(4π) χ_l^n P_l(cos θ), summed on the GPU (ringing of the
//!   truncated series clamped at 0, then normalised); Ams_1 = P exactly. n is the parameter `n`
//!   (`select = count`) or, with `select = transmittance`, the expected number of scatters of
//!   the light reaching the sample plus the one towards the eye, ⌊−α ln T⌋ + 1 (eq. 22, 26),
//!   clamped to 1…26. The `forward` output (1×1 Image) holds F_n = ∫_{θ<π/2} Ams_n dΩ per channel.
//!
//! | kind | ports | params (default, range) |
//! |---|---|---|
//! | HenyeyGreenstein | out `phase` | `g` (0.5, −0.999…0.999), `samples` (1800, 900…8192) |
//! | Rayleigh | out `phase` | `samples` |
//! | Mie | out `phase` | `preset` (cloud; custom, cloud, rain), `cloud_radius` (10 µm, 1…50), `cloud_spread` (1.5, 1…3), `rain_radius` (1000 µm, 100…4000), `radius` (10 µm, 0.001…2000), `spread` (1.5, 1…3), `n_real` (1.33, 1…3), `n_imag` (0, 0…10), `radii` (64, 1…256), `samples` |
//! | IceCrystals | out `phase` | `shape` (column; column, plate), `aspect` (2.5, 1…20), `size` (100 µm, 10…2000), `rays` (1 000 000, 10 000…50 000 000), `samples` |
//! | MultipleScatteringPhase | in `phase` (required); out `phase`, `forward` | `select` (count; count, transmittance), `n` (2, 1…26), `albedo` (1, 0…1), `transmittance` (0.5, 1e-12…1) |

use tables::threads;
use tyndall_engine::gpu::Recorder;

use std::sync::Arc;

use num_complex::Complex64;

use crate::algorithms::lorenz_mie::{self, Population};
use crate::algorithms::phase_function::PhaseTable;
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};

mod tables;
pub use tables::{
    ams_coefficients, henyey_greenstein, ice, mie, mie_raw, multiple, population, rayleigh,
    scatter_count, sub_angles, RAIN_SPREAD,
};

/// Wavelengths of the R, G, B channels, nm.
pub const WAVELENGTHS_NM: [f64; 3] = [680.0, 550.0, 440.0];

/// Largest number of scattering events `MultipleScatteringPhase` models (seed 002: rain is
/// isotropic to 1e-6 by then).
pub const MAX_SCATTERS: u32 = 26;

/// Which phase-function node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    /// `HenyeyGreenstein`.
    HenyeyGreenstein,
    /// `Rayleigh`.
    Rayleigh,
    /// `Mie`.
    Mie,
    /// `IceCrystals`.
    IceCrystals,
    /// `MultipleScatteringPhase`.
    MultipleScattering,
}

/// A phase-function node kind.
pub struct PhaseNode(pub Model);

tyndall_engine::choice_enum! {
    /// Mie particle presets.
    pub enum Preset { Custom = "custom", Cloud = "cloud", Rain = "rain" }
}

tyndall_engine::choice_enum! {
    /// Ice crystal habits.
    pub enum Shape { Column = "column", Plate = "plate" }
}

tyndall_engine::choice_enum! {
    /// How `MultipleScatteringPhase` picks n.
    pub enum Select { Count = "count", Transmittance = "transmittance" }
}

const OUT: &[PortSpec] = &[PortSpec::output(
    "phase",
    &[PortType::Phase],
    "p(θ) per RGB channel (680/550/440 nm), W×1, 1/sr, ∫ p dΩ = 1.",
)];
const SAMPLES: ParamSpec = ParamSpec::int(
    "samples",
    1800,
    900,
    8192,
    "angles",
    "Table width W: angles θ = π (i + 0.5)/W (900 = 0.2°; quality knob).",
);

#[rustfmt::skip]
tyndall_engine::params! {
    /// `HenyeyGreenstein`'s parameters.
    pub struct HgParams {
        g: f32 = ParamSpec::float("g", 0.5, -0.999, 0.999, "", "Asymmetry: the mean cosine of the scattering angle (> 0 forward)."),
        samples: i64 = SAMPLES,
    }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// `Rayleigh`'s parameters.
    pub struct RayleighParams {
        samples: i64 = SAMPLES,
    }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// `Mie`'s parameters: the drop sizes are in effect under their preset, the population's under `preset = custom`.
    pub struct MieParams {
        preset: Preset = ParamSpec::choice("preset", Preset::NAMES, "cloud", "cloud: droplets of `cloud_radius` and `cloud_spread`; rain: drops of `rain_radius`, spread 1.2; both water with its dispersion (n = 1.3307 / 1.3342 / 1.3401 at 680 / 550 / 440 nm, 20 °C); custom: the parameters below."),
        cloud_radius: f64 = ParamSpec::float("cloud_radius", 10.0, 1.0, 50.0, "µm", "Median radius of cloud and fog droplets (1–50 µm; small narrow droplets show the glory's and corona's rings, wider than larger ones).").when("preset", &["cloud"]),
        cloud_spread: f64 = ParamSpec::float("cloud_spread", 1.5, 1.0, 3.0, "", "Geometric standard deviation of the cloud droplets' radius (1 = one size: sharpest rings; 1.5 washes them out).").when("preset", &["cloud"]),
        rain_radius: f64 = ParamSpec::float("rain_radius", 1000.0, 100.0, 4000.0, "µm", "Median radius of the raindrops (drizzle 100 µm … heavy rain 4 mm; smaller drops give paler, wider bows; time grows with the radius).").when("preset", &["rain"]),
        radius: f64 = ParamSpec::float("radius", 10.0, 0.001, 2000.0, "µm", "Median radius of the log-normal number distribution (custom).").when("preset", &["custom"]),
        spread: f64 = ParamSpec::float("spread", 1.5, 1.0, 3.0, "", "Geometric standard deviation of the radius; 1 = a single size (custom).").when("preset", &["custom"]),
        n_real: f64 = ParamSpec::float("n_real", 1.33, 1.0, 3.0, "", "Real refractive index relative to air (custom; water 1.33).").when("preset", &["custom"]),
        n_imag: f64 = ParamSpec::float("n_imag", 0.0, 0.0, 10.0, "", "Imaginary refractive index, ≥ 0 absorbs (custom).").when("preset", &["custom"]),
        radii: i64 = ParamSpec::int("radii", 64, 1, 256, "sizes", "Radii sampled over ±3 ln(spread) (quality knob; time is linear in it)."),
        samples: i64 = SAMPLES,
    }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// `IceCrystals`' parameters.
    pub struct IceParams {
        shape: Shape = ParamSpec::choice("shape", Shape::NAMES, "column", "Crystal habit: column (long along its axis: 22° and 46° halos) or plate (flat hexagons)."),
        aspect: f64 = ParamSpec::float("aspect", 2.5, 1.0, 20.0, "", "Column: length / diameter; plate: diameter / thickness (cirrus: about 1.5–5 for columns, 5–20 for plates)."),
        size: f64 = ParamSpec::float("size", 100.0, 10.0, 2000.0, "µm", "Largest dimension of a crystal (cirrus: 20–1000 µm); sets the diffraction peak's width."),
        rays: i64 = ParamSpec::int("rays", 1_000_000, 10_000, 50_000_000, "rays", "Rays traced per channel (quality knob: noise falls as 1/√rays, time is linear)."),
        samples: i64 = SAMPLES,
    }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// `MultipleScatteringPhase`'s parameters.
    pub struct MultipleParams {
        select: Select = ParamSpec::choice("select", Select::NAMES, "count", "count: use n; transmittance: n = ⌊−albedo · ln(transmittance)⌋ + 1."),
        n: i64 = ParamSpec::int("n", 2, 1, 26, "scatters", "Number of scattering events (select = count).").when("select", &["count"]),
        albedo: f64 = ParamSpec::float("albedo", 1.0, 0.0, 1.0, "", "Single-scattering albedo α (select = transmittance).").when("select", &["transmittance"]),
        transmittance: f64 = ParamSpec::float("transmittance", 0.5, 1e-12, 1.0, "", "Transparency T towards the light (select = transmittance).").when("select", &["transmittance"]),
    }
}

#[rustfmt::skip]
static HG: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "HenyeyGreenstein",
    category: "Scattering",
    doc: "Henyey–Greenstein phase function (1 − g²)/(4π (1 + g² − 2g cos θ)^{3/2}) as a table.",
    inputs: &[],
    outputs: OUT,
    params: HgParams::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[PhaseParams::LAYOUT]);

#[rustfmt::skip]
static RAYLEIGH: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Rayleigh",
    category: "Scattering",
    doc: "Rayleigh phase function 3/(16π)(1 + cos²θ) of air molecules, as a table.",
    inputs: &[],
    outputs: OUT,
    params: RayleighParams::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[PhaseParams::LAYOUT]);

#[rustfmt::skip]
static MIE: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Mie",
    category: "Scattering",
    doc: "Lorenz–Mie phase function of water droplets (or any spheres) with a log-normal size distribution.",
    inputs: &[],
    outputs: OUT,
    params: MieParams::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[PhaseParams::LAYOUT]);

#[rustfmt::skip]
static ICE: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "IceCrystals",
    category: "Scattering",
    doc: "Phase function of randomly oriented hexagonal ice crystals (seed 002): 22° and 46° halos, red inside blue, plus the diffraction peak.",
    inputs: &[],
    outputs: OUT,
    params: IceParams::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[PhaseParams::LAYOUT]);

#[rustfmt::skip]
static MULTIPLE: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "MultipleScatteringPhase",
    category: "Scattering",
    doc: "The angular spread after n scatters, Ams_n = P ∗ … ∗ P (seed 002), and its forward fraction F_n.",
    inputs: &[PortSpec::required("phase", &[PortType::Phase], "The single-scattering phase function P.")],
    outputs: &[
        PortSpec::output("phase", &[PortType::Phase], "Ams_n, normalised."),
        PortSpec::output("forward", &[PortType::Image], "1×1: F_n per channel, the part of Ams_n in the forward hemisphere."),
    ],
    params: MultipleParams::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[PhaseParams::LAYOUT]);

const SHADER: Shader = crate::shader("phase", include_str!("../../shaders/phase.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/phase.wgsl` (struct `Params`).
    pub struct PhaseParams as "Params" {
        /// Table width W.
        pub width: u32,
        /// Number of Legendre coefficients (legendre_series).
        pub count: u32,
        /// Henyey–Greenstein g.
        pub g: f32,
        /// Padding.
        pub _pad0: u32,
    }
}

// ---- CPU reference -------------------------------------------------------------------------

fn params(width: u32, count: u32, g: f32) -> PhaseParams {
    PhaseParams {
        width,
        count,
        g,
        _pad0: 0,
    }
}

/// Normalise a raw table on the GPU (one workgroup reduction): the `Phase` value.
fn normalise(gpu: &Recorder, raw: &GpuTexture) -> Result<GpuTexture, NodeError> {
    let out = gpu.texture(raw.width, 1, TexFormat::Rgba32F)?;
    let u = params(raw.width, 0, 0.0);
    gpu.dispatch(
        SHADER,
        "normalise",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("table_out", Bind::Storage(&out)),
            ("table_in", Bind::Texture(raw)),
        ],
        8,
        8,
    )?;
    Ok(out)
}

/// Tabulate an analytic entry point (`henyey_greenstein`, `rayleigh`) and normalise it.
fn analytic(gpu: &Recorder, entry: &str, w: u32, g: f32) -> Result<GpuTexture, NodeError> {
    let raw = gpu.texture(w, 1, TexFormat::Rgba32F)?;
    let u = params(w, 0, g);
    gpu.dispatch(
        SHADER,
        entry,
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("table_out", Bind::Storage(&raw)),
        ],
        w,
        1,
    )?;
    normalise(gpu, &raw)
}

/// The input table of `MultipleScatteringPhase`.
fn input_table(ctx: &RunCtx) -> Result<(Arc<GpuTexture>, PhaseTable), NodeError> {
    let t = ctx.phase("phase")?;
    let table = PhaseTable::read(ctx.gpu, ctx.require("phase")?)?;
    Ok((t, table))
}

fn run_multiple(ctx: &mut RunCtx) -> Result<(), NodeError> {
    let p = MultipleParams::from_ctx(ctx)?;
    let (input, table) = input_table(ctx)?;
    let n = scatter_count(p.select, p.n.max(1) as u32, p.albedo, p.transmittance);
    let w = input.width;
    let out = if n <= 1 {
        input
    } else {
        let max = ctx.gpu.limits.max_texture_dimension_2d as usize;
        let coeffs = ams_coefficients(&table, n, max);
        let c_tex: Vec<f32> = coeffs
            .iter()
            .flat_map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 0.0])
            .collect();
        let c = ctx.gpu.upload(coeffs.len() as u32, 1, 4, &c_tex)?;
        let raw = ctx.gpu.texture(w, 1, TexFormat::Rgba32F)?;
        let u = params(w, coeffs.len() as u32, 0.0);
        ctx.gpu.dispatch(
            SHADER,
            "legendre_series",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("table_out", Bind::Storage(&raw)),
                ("coeffs", Bind::Texture(&c)),
            ],
            w,
            1,
        )?;
        Arc::new(normalise(ctx.gpu, &raw)?)
    };
    if ctx.wants("forward") {
        let f = ctx.gpu.texture(1, 1, TexFormat::Rgba32F)?;
        let u = params(w, 0, 0.0);
        ctx.gpu.dispatch(
            SHADER,
            "forward_fraction",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("table_in", Bind::Texture(&out)),
                ("forward_out", Bind::Storage(&f)),
            ],
            8,
            8,
        )?;
        ctx.set("forward", PortValue::Image(Arc::new(f)));
    }
    ctx.set("phase", PortValue::Phase(out));
    Ok(())
}

impl NodeKind for PhaseNode {
    fn decl(&self) -> &'static NodeDecl {
        match self.0 {
            Model::HenyeyGreenstein => &HG,
            Model::Rayleigh => &RAYLEIGH,
            Model::Mie => &MIE,
            Model::IceCrystals => &ICE,
            Model::MultipleScattering => &MULTIPLE,
        }
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let samples = |n: i64| n.clamp(1, 8192) as u32;
        let table = match self.0 {
            Model::HenyeyGreenstein => {
                let p = HgParams::from_ctx(ctx)?;
                analytic(ctx.gpu, "henyey_greenstein", samples(p.samples), p.g)?
            }
            Model::Rayleigh => {
                let p = RayleighParams::from_ctx(ctx)?;
                analytic(ctx.gpu, "rayleigh", samples(p.samples), 0.0)?
            }
            Model::Mie => {
                let prm = MieParams::from_ctx(ctx)?;
                let w = samples(prm.samples);
                let pops = WAVELENGTHS_NM.map(|l| population(&prm, l));
                let radii = prm.radii.clamp(1, 256) as usize;
                let report = |k: usize| {
                    let nm = WAVELENGTHS_NM[k.min(2)];
                    ctx.report(k as u64 + 1, 3, format!("Lorenz–Mie series at {nm} nm"));
                };
                ctx.report(0, 3, "Lorenz–Mie series");
                let raw = mie_raw(&pops, radii, w as usize, threads(), report);
                let t = ctx.gpu.upload(w, 1, 4, &raw.texels())?;
                normalise(ctx.gpu, &t)?
            }
            Model::IceCrystals => {
                let p = IceParams::from_ctx(ctx)?;
                let w = samples(p.samples);
                ctx.report(0, 1, "tracing rays through the ice crystals");
                let raw = ice(
                    p.shape,
                    p.aspect,
                    p.size,
                    p.rays.max(1) as usize,
                    w as usize,
                );
                let t = ctx.gpu.upload(w, 1, 4, &raw.texels())?;
                normalise(ctx.gpu, &t)?
            }
            Model::MultipleScattering => return run_multiple(ctx),
        };
        ctx.set("phase", PortValue::Phase(Arc::new(table)));
        Ok(())
    }
}
