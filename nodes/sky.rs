//! `Sky`: an analytic single-scattering sky and aerial perspective (SPEC §7, seed 002 eq. 8–15)
//! over a flat earth whose air thins exponentially with height.
//!
//! Scattering coefficient β(h) = β_sl e^{−γh} (γ = 1/`scale_height`; air's sea-level β_sl per
//! channel, 680 / 550 / 440 nm, plus an optional aerosol `aerosol` with the same profile and
//! phase function from the `phase` input, else Henyey–Greenstein `aerosol_g`). Extinction
//! equals scattering (albedo 1). For a view ray of direction d from the eye at height h₀
//! (`altitude` + eye y · `distance_scale`) to distance K, with β_eye = β_sl e^{−γh₀}:
//!
//! - optical depth to the eye (eq. 11) τ_e = β_eye K (1 − e^{−γ d_y K})/(γ d_y K), T = e^{−τ_e};
//! - sun at a point of height h (eq. 12): I e^{−τ_s(h)}, τ_s(h) = β_sl e^{−γh}/(γ l_y);
//! - in-scatter (eq. 15, derived again here in a form that stays finite everywhere):
//!   L = I P_eff τ_e (e^{−τ_s(h₀)} − e^{−τ_e − τ_s(h_K)}) / z, z = τ_e − τ_s(h₀) + τ_s(h_K),
//!   evaluated as I P_eff τ_e e^{−min(τ_s(h₀), τ_e + τ_s(h_K))} e1(|z|), e1(x) = (1 − e^{−x})/x
//!   (→ 1 at x = 0: the limit where the seed's eq. 15 divides by zero, p_Ωy = l_y; no overflow
//!   for either sign of z), P_eff = (β_air P_Rayleigh + β_aer P_aer)/β. Optical depths are
//!   taken as differences of e^{−γh} where γ d_y K is large and capped at 1e30, so an underflowing
//!   density never meets an infinite length.
//!
//! The sun's irradiance I (W/m², outside the atmosphere) and direction come from the `scene`
//! (its directional light `light`, × `intensity`; a scene without one is refused) or from `sun_azimuth`, `sun_elevation`, `sun_irradiance`. A sun at
//! or below the horizon (l_y ≤ 1e-4) lights nothing. Surfaces (depth below the camera's far
//! distance) are at K = depth × `distance_scale`; background pixels look up to 10⁷ m (or down
//! to sea level), and a 0.5° sun disk of radiance I T / Ω_sun is added where the view ray
//! meets the sun. Outputs: `inscatter` = aerial in-scatter on surfaces and sky radiance on the
//! background; `transmittance` = T on surfaces, 0 on the background (nothing shows through the
//! sky); `sky` = the background alone. `Composite` applies them when connected
//! (out · T + inscatter). Units: W/(m²·sr).
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `depth` | in | Depth (required) | camera and distance per pixel; the far distance marks the sky |
//! | `scene` | in | Scene | the sun's direction and irradiance |
//! | `phase` | in | Phase | the aerosol's phase function |
//! | `inscatter`, `transmittance`, `sky` | out | Image | see above |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `beta_sea_level` | Vec3 | (5.8e-6, 1.35e-5, 3.31e-5) | 0…1 1/m | air's scattering at sea level (seed 002 Table 3) |
//! | `scale_height` | Float | 8000 | 1…1e6 m | 1/γ |
//! | `aerosol` | Float | 0 | 0…1 1/m | aerosol scattering at sea level |
//! | `aerosol_g` | Float | 0.76 | −0.999…0.999 | its HG asymmetry without `phase` |
//! | `altitude` | Float | 0 | −1e4…1e5 m | height of the scene's y = 0 above sea level |
//! | `distance_scale` | Float | 1 | 1e-3…1e6 | metres per scene unit (exaggerates aerial perspective) |
//! | `intensity` | Float | 1 | 0…1e6 | multiplies the sun's irradiance |
//! | `light` | Text | "" | | with a scene: which of its directional lights is the sun (empty: the first; a name or an index); a scene with none, or a light of another kind, is refused naming the scene's lights |
//! | `sun_azimuth`, `sun_elevation` | Float | 0, 20 | degrees | sun without a scene |
//! | `sun_irradiance` | Float | 20 | 0…1e6 W/m² | sun without a scene |
//! | `sun_disk` | Bool | true | | draw the 0.5° sun disk |

use std::sync::Arc;

use glam::Vec3;

use crate::algorithms::phase_function::{hg_value, rayleigh_value, PhaseTable};
use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::scene::Sun;

/// The `Sky` node kind.
pub struct Sky;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        beta_sea_level: [f32; 3] = ParamSpec::vec3("beta_sea_level", [5.8e-6, 1.35e-5, 3.31e-5], 0.0, 1.0, "1/m", "Air's scattering coefficient at sea level for 680/550/440 nm."),
        scale_height: f32 = ParamSpec::float("scale_height", 8000.0, 1.0, 1e6, "m", "Height over which the density falls by e (1/γ)."),
        aerosol: f32 = ParamSpec::float("aerosol", 0.0, 0.0, 1.0, "1/m", "Aerosol scattering coefficient at sea level (same profile as air)."),
        aerosol_g: f32 = ParamSpec::float("aerosol_g", 0.76, -0.999, 0.999, "", "Aerosol Henyey–Greenstein asymmetry when no phase is connected."),
        altitude: f32 = ParamSpec::float("altitude", 0.0, -1e4, 1e5, "m", "Height of the scene's y = 0 above sea level."),
        distance_scale: f32 = ParamSpec::float("distance_scale", 1.0, 1e-3, 1e6, "m/unit", "Metres per scene unit: exaggerates aerial perspective in small scenes."),
        intensity: f32 = ParamSpec::float("intensity", 1.0, 0.0, 1e6, "", "Multiplies the sun's irradiance."),
        light: String = ParamSpec::text("light", "", "With a scene: its directional light the sky is lit by (empty: the first; else a name or an index). A scene without one is refused, naming its lights."),
        sun_azimuth: f32 = ParamSpec::float("sun_azimuth", 0.0, -360.0, 360.0, "°", "Sun azimuth without a scene (clockwise from +Z seen from above)."),
        sun_elevation: f32 = ParamSpec::float("sun_elevation", 20.0, -90.0, 90.0, "°", "Sun elevation without a scene."),
        sun_irradiance: f32 = ParamSpec::float("sun_irradiance", 20.0, 0.0, 1e6, "W/m²", "Sun irradiance without a scene."),
        sun_disk: bool = ParamSpec::flag("sun_disk", true, "Draw the 0.5° sun disk on the background."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Sky",
    category: "Scattering",
    doc: "Analytic sky and aerial perspective (seed 002): Rayleigh air (+ aerosol) thinning with height, a 0.5° sun disk.",
    inputs: &[
        PortSpec::required("depth", &[PortType::Depth], "Camera and distance per pixel; the far distance marks sky pixels."),
        PortSpec::input("scene", &[PortType::Scene], "The sun's direction and irradiance (else the sun_* parameters)."),
        PortSpec::input("phase", &[PortType::Phase], "The aerosol's phase function (else Henyey–Greenstein aerosol_g)."),
    ],
    outputs: &[
        PortSpec::output("inscatter", &[PortType::Image], "Aerial in-scatter on surfaces, sky radiance on the background, W/(m²·sr)."),
        PortSpec::output("transmittance", &[PortType::Image], "Per channel, eye to surface; 0 on the background."),
        PortSpec::output("sky", &[PortType::Image], "The background alone (sky and sun disk); 0 on surfaces."),
    ],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[SkyParams::LAYOUT]);

const SHADER: Shader = crate::shader("sky", include_str!("../shaders/sky.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/sky.wgsl` (struct `Params`).
    pub struct SkyParams as "Params" {
        /// Camera clip → world.
        pub inv_view_proj: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// The camera's far distance (depth of sky pixels).
        pub far: f32,
        /// Unit direction towards the sun.
        pub to_sun: [f32; 3],
        /// γ = 1/scale height, 1/m.
        pub gamma: f32,
        /// Sun irradiance per channel, W/m².
        pub sun: [f32; 3],
        /// Height of y = 0 above sea level, m.
        pub altitude: f32,
        /// Air's sea-level scattering per channel, 1/m.
        pub beta_air: [f32; 3],
        /// Aerosol sea-level scattering, 1/m.
        pub aerosol: f32,
        /// Metres per scene unit.
        pub distance_scale: f32,
        /// Aerosol HG g (no phase table).
        pub aerosol_g: f32,
        /// Width of the aerosol phase table (0: HG).
        pub phase_width: u32,
        /// 1: draw the sun disk.
        pub sun_disk: u32,
    }
}

/// The longest path considered (m).
pub const K_MAX: f64 = 1e7;
/// Solid angle of the 0.5° sun disk, 2π (1 − cos 0.25°), sr.
pub const SUN_SR: f64 = 5.9811e-5;

/// One pixel of the sky: (inscatter, transmittance, sky) per channel, in f64.
pub fn reference_pixel(
    u: &SkyParams,
    phase: Option<&PhaseTable>,
    dir: Vec3,
    depth: f32,
) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let dir = dir.as_dvec3().normalize();
    let background = depth >= u.far * 0.999;
    let h = u.altitude as f64 + u.eye[1] as f64 * u.distance_scale as f64;
    let gamma = u.gamma as f64;
    let dy = dir.y;
    let mut k = depth as f64 * u.distance_scale as f64;
    if background {
        k = K_MAX;
        if dy < 0.0 && h > 0.0 {
            k = K_MAX.min(h / -dy);
        }
    }
    let to_sun = Vec3::from(u.to_sun).as_dvec3();
    let c = dir.dot(to_sun);
    let ray = rayleigh_value(c);
    let aer = match phase {
        Some(t) => t.lookup(c as f32).map(|v| v as f64),
        None => [hg_value(u.aerosol_g as f64, c); 3],
    };
    let e1 = |x: f64| {
        if x.abs() < 1e-4 {
            1.0 - 0.5 * x
        } else {
            -(-x).exp_m1() / x
        }
    };
    let finite = |x: f64| if x < 1e30 { x } else { 1e30 };
    let ly = to_sun.y;
    let (mut ins, mut t, mut sky) = ([0.0; 3], [0.0; 3], [0.0; 3]);
    for ch in 0..3 {
        let air = u.beta_air[ch] as f64;
        let beta = air + u.aerosol as f64;
        let x = gamma * dy * k;
        let tau_e = finite(if x.abs() < 1.0 {
            beta * (-gamma * h).exp() * k * e1(x)
        } else {
            beta * ((-gamma * h).exp() - (-gamma * (h + dy * k)).exp()) / (gamma * dy)
        });
        let p_eff = (air * ray + u.aerosol as f64 * aer[ch]) / beta.max(1e-30);
        let mut l = 0.0;
        if ly > 1e-4 {
            let tau_s0 = finite(beta * (-gamma * h).exp() / (gamma * ly));
            let tau_sk = finite(beta * (-gamma * (h + dy * k)).exp() / (gamma * ly));
            let z = tau_e - tau_s0 + tau_sk;
            l = u.sun[ch] as f64
                * p_eff
                * tau_e
                * (-(tau_s0.min(tau_e + tau_sk))).exp()
                * e1(z.abs());
        }
        let tr = (-tau_e).exp();
        if background {
            let mut s = l;
            if u.sun_disk != 0 && c >= (0.25f64).to_radians().cos() {
                s += u.sun[ch] as f64 * tr / SUN_SR;
            }
            (ins[ch], t[ch], sky[ch]) = (s, 0.0, s);
        } else {
            (ins[ch], t[ch]) = (l, tr);
        }
    }
    (ins, t, sky)
}

/// The in-scatter of eq. 8 integrated numerically for channel `ch` (`steps` midpoints in f64,
/// air and HG aerosol, no phase table) along a ray of direction `dir` from the eye to distance
/// `k` (m): the independent check of the closed form in [`reference_pixel`].
pub fn integrate_inscatter(u: &SkyParams, ch: usize, dir: Vec3, k: f64, steps: usize) -> f64 {
    let dir = dir.as_dvec3().normalize();
    let to_sun = Vec3::from(u.to_sun).as_dvec3();
    let (dy, ly) = (dir.y, to_sun.y);
    if ly <= 1e-4 {
        return 0.0;
    }
    let gamma = u.gamma as f64;
    let h0 = u.altitude as f64 + u.eye[1] as f64 * u.distance_scale as f64;
    let (air, aer) = (u.beta_air[ch] as f64, u.aerosol as f64);
    let c = dir.dot(to_sun);
    let hg = hg_value(u.aerosol_g as f64, c);
    let ray = rayleigh_value(c);
    let dt = k / steps as f64;
    let mut tau_e = 0.0;
    let mut acc = 0.0;
    for i in 0..steps {
        let t = (i as f64 + 0.5) * dt;
        let density = (-gamma * (h0 + dy * t)).exp();
        let beta = (air + aer) * density;
        // Optical depth to the eye up to the midpoint: the intervals before plus half of this.
        let tau_mid = tau_e + 0.5 * beta * dt;
        let tau_sun = beta / (gamma * ly);
        let scatter = (air * ray + aer * hg) * density;
        acc += scatter * u.sun[ch] as f64 * (-tau_mid - tau_sun).exp() * dt;
        tau_e += beta * dt;
    }
    acc
}

impl NodeKind for Sky {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let (depth, cam): (_, Matrices) = ctx.depth("depth")?;
        let intensity = p.intensity;
        let (to_sun, sun) = match ctx.scene_opt("scene")? {
            Some(v) => {
                let s = v
                    .scene
                    .find_sun(&p.light)
                    .map_err(|message| NodeError::Param {
                        param: "light".into(),
                        message,
                    })?;
                (s.to_sun(), s.radiance().map(|c| c * intensity))
            }
            None => {
                let s = Sun {
                    azimuth: p.sun_azimuth,
                    elevation: p.sun_elevation,
                    colour: [1.0; 3],
                    intensity: p.sun_irradiance,
                };
                (s.to_sun(), s.radiance().map(|c| c * intensity))
            }
        };
        let phase = ctx.phase_opt("phase")?;
        let u = SkyParams {
            inv_view_proj: cam.view_proj().inverse().to_cols_array_2d(),
            eye: cam.eye().to_array(),
            far: cam.far,
            to_sun: to_sun.to_array(),
            gamma: 1.0 / p.scale_height.max(1e-6),
            sun,
            altitude: p.altitude,
            beta_air: p.beta_sea_level,
            aerosol: p.aerosol,
            distance_scale: p.distance_scale,
            aerosol_g: p.aerosol_g,
            phase_width: phase.as_ref().map_or(0, |t| t.width),
            sun_disk: p.sun_disk as u32,
        };
        let table = match phase {
            Some(t) => t,
            None => Arc::new(ctx.gpu.upload(1, 1, 4, &[0.0; 4])?),
        };
        let (w, h) = (depth.width, depth.height);
        let ins = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        let tr = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        let sky = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "sky",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("depth", Bind::Texture(&depth)),
                ("phase_table", Bind::Texture(&table)),
                ("out_inscatter", Bind::Storage(&ins)),
                ("out_transmittance", Bind::Storage(&tr)),
                ("out_sky", Bind::Storage(&sky)),
            ],
            w,
            h,
        )?;
        ctx.set("inscatter", PortValue::Image(Arc::new(ins)));
        ctx.set("transmittance", PortValue::Image(Arc::new(tr)));
        ctx.set("sky", PortValue::Image(Arc::new(sky)));
        Ok(())
    }
}
