//! Phase functions for the scattering chain (SPEC §7, seed 002 §3): `HenyeyGreenstein`,
//! `Rayleigh`, `Mie` and `MultipleScatteringPhase`, each producing a `Phase` table that
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
//! - `Mie`: the Lorenz–Mie series (`nodes/lorenz_mie.rs`, Bohren–Huffman in f64) for spheres of
//!   refractive index `n_real` + i `n_imag` whose radii follow a log-normal number distribution
//!   (median `radius` µm, geometric standard deviation `spread`), averaged over `radii` sizes;
//!   each texel is the mean of up to four sub-angles when the size parameter makes the ripple
//!   finer than a texel. Presets (seed 002 Table 2 sizes; spreads chosen here, as the seed gives
//!   Pruppacher & Klett's distributions without numbers): `cloud` = 10 µm, σ_g 1.5, n 1.33;
//!   `rain` = 1 mm, σ_g 1.2, n 1.33; `custom` uses the parameters. The series is computed on the
//!   CPU (as the issue asks) and normalised on the GPU.
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
//! | Mie | out `phase` | `preset` (cloud; custom, cloud, rain), `radius` (10 µm, 0.001…2000), `spread` (1.5, 1…3), `n_real` (1.33, 1…3), `n_imag` (0, 0…10), `radii` (64, 1…256), `samples` |
//! | MultipleScatteringPhase | in `phase` (required); out `phase`, `forward` | `select` (count; count, transmittance), `n` (2, 1…26), `albedo` (1, 0…1), `transmittance` (0.5, 1e-12…1) |

use std::sync::Arc;

use num_complex::Complex64;

use super::lorenz_mie::{self, Population};
use crate::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use crate::gpu::{Bind, Gpu, GpuTexture, Shader, TexFormat};
use crate::graph::{NodeSchema, ParamSpec, PortSpec, PortType};

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
    /// `MultipleScatteringPhase`.
    MultipleScattering,
}

/// A phase-function node kind.
pub struct PhaseNode(pub Model);

crate::choice_enum! {
    /// Mie particle presets.
    pub enum Preset { Custom = "custom", Cloud = "cloud", Rain = "rain" }
}

crate::choice_enum! {
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
crate::params! {
    /// `HenyeyGreenstein`'s parameters.
    pub struct HgParams {
        g: f32 = ParamSpec::float("g", 0.5, -0.999, 0.999, "", "Asymmetry: the mean cosine of the scattering angle (> 0 forward)."),
        samples: i64 = SAMPLES,
    }
}

#[rustfmt::skip]
crate::params! {
    /// `Rayleigh`'s parameters.
    pub struct RayleighParams {
        samples: i64 = SAMPLES,
    }
}

#[rustfmt::skip]
crate::params! {
    /// `Mie`'s parameters: the population's are in effect only under `preset = custom`.
    pub struct MieParams {
        preset: Preset = ParamSpec::choice("preset", Preset::NAMES, "cloud", "cloud: 10 µm, spread 1.5; rain: 1 mm, spread 1.2 (both n = 1.33); custom: the parameters below."),
        radius: f64 = ParamSpec::float("radius", 10.0, 0.001, 2000.0, "µm", "Median radius of the log-normal number distribution (custom).").when("preset", &["custom"]),
        spread: f64 = ParamSpec::float("spread", 1.5, 1.0, 3.0, "", "Geometric standard deviation of the radius; 1 = a single size (custom).").when("preset", &["custom"]),
        n_real: f64 = ParamSpec::float("n_real", 1.33, 1.0, 3.0, "", "Real refractive index relative to air (custom; water 1.33).").when("preset", &["custom"]),
        n_imag: f64 = ParamSpec::float("n_imag", 0.0, 0.0, 10.0, "", "Imaginary refractive index, ≥ 0 absorbs (custom).").when("preset", &["custom"]),
        radii: i64 = ParamSpec::int("radii", 64, 1, 256, "sizes", "Radii sampled over ±3 ln(spread) (quality knob; time is linear in it)."),
        samples: i64 = SAMPLES,
    }
}

#[rustfmt::skip]
crate::params! {
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

const SHADER: Shader = Shader::new("phase", include_str!("../shaders/phase.wgsl"));

crate::uniforms! {
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

/// A phase-function table on the CPU, in f64 (see the module docs for the layout).
#[derive(Debug, Clone, PartialEq)]
pub struct PhaseTable {
    /// p(θ_i) per channel, i = 0…W−1.
    pub rgb: Vec<[f64; 3]>,
}

impl PhaseTable {
    /// Table width W.
    pub fn width(&self) -> usize {
        self.rgb.len()
    }

    /// θ of texel `i` of a `w`-wide table.
    pub fn theta(i: usize, w: usize) -> f64 {
        std::f64::consts::PI * (i as f64 + 0.5) / w as f64
    }

    /// Tabulate `f(θ) → [r, g, b]` on `w` angles (not normalised).
    pub fn from_fn(w: usize, f: impl Fn(f64) -> [f64; 3]) -> Self {
        Self {
            rgb: (0..w).map(|i| f(Self::theta(i, w))).collect(),
        }
    }

    /// 2π Σ p sin θ Δθ over the texels with θ below `limit`, per channel.
    pub fn integral_below(&self, limit: f64) -> [f64; 3] {
        let w = self.width();
        let dt = std::f64::consts::PI / w as f64;
        let mut s = [0.0; 3];
        for (i, v) in self.rgb.iter().enumerate() {
            let t = Self::theta(i, w);
            if t < limit {
                for c in 0..3 {
                    s[c] += v[c] * t.sin() * dt * 2.0 * std::f64::consts::PI;
                }
            }
        }
        s
    }

    /// ∫ p dΩ per channel (midpoint rule).
    pub fn integral(&self) -> [f64; 3] {
        self.integral_below(f64::INFINITY)
    }

    /// The table scaled to integrate to one per channel (a zero channel becomes isotropic).
    pub fn normalised(mut self) -> Self {
        let total = self.integral();
        for v in &mut self.rgb {
            for c in 0..3 {
                v[c] = if total[c] > 0.0 {
                    v[c] / total[c]
                } else {
                    0.25 / std::f64::consts::PI
                };
            }
        }
        self
    }

    /// The mean cosine ∫ p cos θ dΩ per channel (the asymmetry g).
    pub fn mean_cosine(&self) -> [f64; 3] {
        let w = self.width();
        let mut m = self.clone();
        for (i, v) in m.rgb.iter_mut().enumerate() {
            let c = Self::theta(i, w).cos();
            *v = v.map(|x| x * c);
        }
        m.integral()
    }

    /// p at cos θ = `cos_theta`: linear between texel centres, clamped at the ends — as
    /// `SingleScattering`'s shader reads it.
    pub fn lookup(&self, cos_theta: f32) -> [f32; 3] {
        let w = self.width();
        let t = cos_theta.clamp(-1.0, 1.0).acos();
        let x = (t / std::f32::consts::PI * w as f32 - 0.5).clamp(0.0, (w - 1) as f32);
        let i0 = x.floor() as usize;
        let i1 = (i0 + 1).min(w - 1);
        let f = (x - i0 as f32) as f64;
        let (a, b) = (self.rgb[i0], self.rgb[i1]);
        [0, 1, 2].map(|c| (a[c] * (1.0 - f) + b[c] * f) as f32)
    }

    /// Legendre moments χ_l = 2π Σ p P_l(cos θ) sin θ Δθ, l = 0…count−1, per channel.
    pub fn moments(&self, count: usize) -> Vec<[f64; 3]> {
        let w = self.width();
        let dt = std::f64::consts::PI / w as f64;
        let mut out = vec![[0.0; 3]; count];
        for (i, v) in self.rgb.iter().enumerate() {
            let t = Self::theta(i, w);
            let (mu, s) = (t.cos(), t.sin() * dt * 2.0 * std::f64::consts::PI);
            for (o, pl) in out.iter_mut().zip(legendre(mu)) {
                for c in 0..3 {
                    o[c] += v[c] * pl * s;
                }
            }
        }
        out
    }

    /// Σ_l (2l + 1)/(4π) c_l P_l(cos θ) on `w` angles, clamped at 0 (not normalised).
    pub fn series(coeffs: &[[f64; 3]], w: usize) -> Self {
        Self::from_fn(w, |t| {
            let mut acc = [0.0; 3];
            for (l, (c, pl)) in coeffs.iter().zip(legendre(t.cos())).enumerate() {
                for k in 0..3 {
                    acc[k] += (2.0 * l as f64 + 1.0) * c[k] * pl;
                }
            }
            acc.map(|a| (a / (4.0 * std::f64::consts::PI)).max(0.0))
        })
    }

    /// The table as the texels of a `Phase` value (RGBA, alpha 1).
    pub fn texels(&self) -> Vec<f32> {
        self.rgb
            .iter()
            .flat_map(|v| [v[0] as f32, v[1] as f32, v[2] as f32, 1.0])
            .collect()
    }

    /// Read a `Phase` value back.
    pub fn read(gpu: &Gpu, value: &PortValue) -> Result<Self, NodeError> {
        let r = crate::eval::download(gpu, value)?;
        Ok(Self {
            rgb: r
                .data
                .chunks(4)
                .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64])
                .collect(),
        })
    }
}

/// The Legendre polynomials P_0(μ), P_1(μ), … by the three-term recurrence
/// l P_l = (2l − 1) μ P_{l−1} − (l − 1) P_{l−2} (as the shader's `legendre_series`).
pub fn legendre(mu: f64) -> impl Iterator<Item = f64> {
    let mut prev = (0.0, 1.0); // (P_{l−2}, P_{l−1}) before l = 1: P_{−1} taken as 0
    (0..).map(move |l: u32| {
        let pl = match l {
            0 => 1.0,
            _ => {
                let lf = l as f64;
                ((2.0 * lf - 1.0) * mu * prev.1 - (lf - 1.0) * prev.0) / lf
            }
        };
        if l > 0 {
            prev = (prev.1, pl);
        }
        pl
    })
}

/// Henyey–Greenstein (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}), 1/sr.
pub fn hg_value(g: f64, cos_theta: f64) -> f64 {
    let d = (1.0 + g * g - 2.0 * g * cos_theta).max(1e-12);
    (1.0 - g * g) / (4.0 * std::f64::consts::PI * d * d.sqrt())
}

/// Rayleigh 3/(16π) (1 + cos²θ), 1/sr.
pub fn rayleigh_value(cos_theta: f64) -> f64 {
    3.0 / (16.0 * std::f64::consts::PI) * (1.0 + cos_theta * cos_theta)
}

/// CPU reference of `HenyeyGreenstein`.
pub fn henyey_greenstein(g: f64, w: usize) -> PhaseTable {
    PhaseTable::from_fn(w, |t| [hg_value(g, t.cos()); 3]).normalised()
}

/// CPU reference of `Rayleigh`.
pub fn rayleigh(w: usize) -> PhaseTable {
    PhaseTable::from_fn(w, |t| [rayleigh_value(t.cos()); 3]).normalised()
}

/// The particles of a Mie preset (`custom`: `custom` itself).
pub fn population(preset: Preset, custom: Population) -> Population {
    let water = Complex64::new(1.33, 0.0);
    match preset {
        Preset::Custom => custom,
        Preset::Cloud => Population {
            radius_um: 10.0,
            spread: 1.5,
            m: water,
        },
        Preset::Rain => Population {
            radius_um: 1000.0,
            spread: 1.2,
            m: water,
        },
    }
}

/// Sub-angles per texel for a population on a `w`-wide table: enough that the ripple of the
/// largest size parameter (period ≈ π/x) is averaged, at most 4.
pub fn sub_angles(p: &Population, radii: usize, w: usize) -> usize {
    let r_max = lorenz_mie::radii(p, radii)
        .last()
        .map_or(p.radius_um, |(r, _)| *r);
    let x_max = 2.0 * std::f64::consts::PI * r_max / (WAVELENGTHS_NM[2] * 1e-3);
    let dtheta = std::f64::consts::PI / w as f64;
    ((x_max * dtheta / 4.0).ceil() as usize).clamp(1, 4)
}

/// The Mie table before normalisation (what the node uploads), on `threads` threads;
/// `done(k)` is called after channel k.
pub fn mie_raw(
    p: &Population,
    radii: usize,
    w: usize,
    threads: usize,
    done: impl Fn(usize),
) -> PhaseTable {
    let thetas: Vec<f64> = (0..w).map(|i| PhaseTable::theta(i, w)).collect();
    let sub = sub_angles(p, radii, w);
    let dtheta = std::f64::consts::PI / w as f64;
    let ch: Vec<Vec<f64>> = WAVELENGTHS_NM
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let v = lorenz_mie::phase(p, *l, &thetas, dtheta, sub, radii, threads);
            done(k);
            v
        })
        .collect();
    PhaseTable {
        rgb: (0..w).map(|i| [ch[0][i], ch[1][i], ch[2][i]]).collect(),
    }
}

/// CPU reference of `Mie`.
pub fn mie(p: &Population, radii: usize, w: usize) -> PhaseTable {
    mie_raw(p, radii, w, threads(), |_| {}).normalised()
}

/// The number of scatters `MultipleScatteringPhase` uses.
pub fn scatter_count(select: Select, n: u32, albedo: f64, transmittance: f64) -> u32 {
    match select {
        Select::Count => n.clamp(1, MAX_SCATTERS),
        Select::Transmittance => {
            let expected = -albedo * transmittance.clamp(1e-300, 1.0).ln();
            ((expected.max(0.0).floor() as u32).saturating_add(1)).clamp(1, MAX_SCATTERS)
        }
    }
}

/// The Legendre coefficients χ_l^n of Ams_n for an input table (l < W, at most the GPU's
/// texture width).
pub fn ams_coefficients(p: &PhaseTable, n: u32, max_count: usize) -> Vec<[f64; 3]> {
    let count = p.width().min(max_count).max(1);
    p.moments(count)
        .into_iter()
        .map(|m| m.map(|x| x.powi(n as i32)))
        .collect()
}

/// CPU reference of `MultipleScatteringPhase`: (Ams_n, F_n).
pub fn multiple(p: &PhaseTable, n: u32) -> (PhaseTable, [f64; 3]) {
    let table = if n <= 1 {
        p.clone()
    } else {
        PhaseTable::series(&ams_coefficients(p, n, usize::MAX), p.width()).normalised()
    };
    let f = table.integral_below(std::f64::consts::FRAC_PI_2);
    (table, f)
}

fn threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

// ---- GPU ------------------------------------------------------------------------------------

fn params(width: u32, count: u32, g: f32) -> PhaseParams {
    PhaseParams {
        width,
        count,
        g,
        _pad0: 0,
    }
}

/// Normalise a raw table on the GPU (one workgroup reduction): the `Phase` value.
fn normalise(gpu: &Gpu, raw: &GpuTexture) -> Result<GpuTexture, NodeError> {
    let out = gpu.texture(raw.width, 1, TexFormat::Rgba32F)?;
    let u = params(raw.width, 0, 0.0);
    gpu.dispatch(
        SHADER,
        "normalise",
        &[
            (0, Bind::Uniform(bytemuck::bytes_of(&u))),
            (1, Bind::Storage(&out)),
            (3, Bind::Texture(raw)),
        ],
        8,
        8,
    )?;
    Ok(out)
}

/// Tabulate an analytic entry point (`henyey_greenstein`, `rayleigh`) and normalise it.
fn analytic(gpu: &Gpu, entry: &str, w: u32, g: f32) -> Result<GpuTexture, NodeError> {
    let raw = gpu.texture(w, 1, TexFormat::Rgba32F)?;
    let u = params(w, 0, g);
    gpu.dispatch(
        SHADER,
        entry,
        &[
            (0, Bind::Uniform(bytemuck::bytes_of(&u))),
            (1, Bind::Storage(&raw)),
        ],
        w,
        1,
    )?;
    normalise(gpu, &raw)
}

/// The input table of `MultipleScatteringPhase`.
fn input_table(ctx: &RunCtx) -> Result<(Arc<GpuTexture>, PhaseTable), NodeError> {
    match ctx.require("phase")? {
        v @ PortValue::Phase(t) => Ok((t.clone(), PhaseTable::read(ctx.gpu, v)?)),
        _ => Err(NodeError::Input {
            port: "phase".into(),
            message: "is not a phase function".into(),
        }),
    }
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
                (0, Bind::Uniform(bytemuck::bytes_of(&u))),
                (1, Bind::Storage(&raw)),
                (2, Bind::Texture(&c)),
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
                (0, Bind::Uniform(bytemuck::bytes_of(&u))),
                (3, Bind::Texture(&out)),
                (4, Bind::Storage(&f)),
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
                let custom = Population {
                    radius_um: prm.radius,
                    spread: prm.spread,
                    m: Complex64::new(prm.n_real, prm.n_imag),
                };
                let p = population(prm.preset, custom);
                let radii = prm.radii.clamp(1, 256) as usize;
                let report = |k: usize| {
                    let nm = WAVELENGTHS_NM[k.min(2)];
                    ctx.report(k as u64 + 1, 3, format!("Lorenz–Mie series at {nm} nm"));
                };
                ctx.report(0, 3, "Lorenz–Mie series");
                let raw = mie_raw(&p, radii, w as usize, threads(), report);
                let t = ctx.gpu.upload(w, 1, 4, &raw.texels())?;
                normalise(ctx.gpu, &t)?
            }
            Model::MultipleScattering => return run_multiple(ctx),
        };
        ctx.set("phase", PortValue::Phase(Arc::new(table)));
        Ok(())
    }
}
