//! A heterogeneous medium (issue #61): σt(x) = `sigma_t` · density(x) from the `density` Volume,
//! the light attenuated by the density between each point and the light, and the view ray
//! marched through the varying σt. The CPU reference (an independent march towards the light
//! from every sample) and the GPU passes (`shaders/single_scattering/density.wgsl`).
//!
//! Light transmittance: a volume over the density's box, `transmittance_resolution` texels on
//! its longest side, each texel the light's transmittance from its centre to the box's boundary
//! (or to a lamp inside it), e^{−σt Σ density Δ} over `light_steps` midpoints; a sample reads it
//! trilinearly. Built once per run, for any light (a spot's and a point light's rays converge on
//! the light, the sun's are parallel). Both are quality knobs, measured in the `density` bench.
//!
//! Empty-space skipping: an occupancy volume (one texel per 4³ density texels, the largest
//! density a trilinear read inside that brick can weigh) lets both marches step over empty
//! bricks whole. It is exact:
//! a skipped sample reads a density of 0 and adds nothing. After a sample reads 0 the next one
//! looks the occupancy up (inside the smoke only a branch is added: 6 % on lavapipe; the plume
//! in a 40 m box runs 1.3× faster than without skipping, BENCHMARKS.md). `visibility`
//! (V̄) is the mean light over the samples where the density is above 0 (the light reaching
//! the smoke), 1 on a ray that meets none.

use super::{medium_segment, Bind, NodeError, PixelResult, Raster, ScatterParams, Vec3};
pub use crate::algorithms::box_volume::BoxVolume as Density;
use crate::algorithms::shader_lib::{henyey_greenstein, light_uvz, sun_reaches};
use tyndall_engine::gpu::{GpuVolume, Recorder, Shader};

/// Density texels per side of an occupancy brick (`BRICK` in the shader).
const BRICK: u32 = 4;

/// The density passes.
pub(super) const DENSITY: Shader = crate::shader(
    "single_scattering/density",
    include_str!("../../shaders/single_scattering/density.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/single_scattering/density.wgsl` (struct `DensityView`).
    pub struct DensityView as "DensityView" {
        /// The density volume's world box, low corner, m.
        pub lo: [f32; 3],
        /// Samples per light ray of the transmittance volume.
        pub light_steps: u32,
        /// High corner, m.
        pub hi: [f32; 3],
        /// Padding.
        pub _pad0: u32,
    }
}

/// CPU reference of the light reaching `x` through the density: e^{−σt ∫ density} from x to
/// the box's boundary towards the light (or to a lamp inside it), `m` midpoints — marched from
/// x itself, not read from a transmittance volume.
pub fn light_transmittance(p: &ScatterParams, density: &Density, x: Vec3, m: u32) -> f32 {
    let (d, far) = match p.local() {
        Some(l) => {
            let v = l.position() - x;
            (v.normalize_or(Vec3::Y), v.length())
        }
        None => (p.to_sun(), f32::MAX),
    };
    let (_, t1) = density.segment(x, d);
    let len = t1.min(far).max(0.0);
    let delta = len / m as f32;
    let tau: f32 = (0..m)
        .map(|i| density.at(x + d * ((i as f32 + 0.5) * delta)))
        .sum();
    (-p.sigma_t * tau * delta).exp()
}

/// CPU reference of one pixel through the density (the oracle of the GPU passes): `steps`
/// samples of the medium's part of the view ray inside the density's box, each lit by the
/// shadow map's test times [`light_transmittance`] with `light_steps` midpoints, with the
/// Henyey–Greenstein phase function (`p.g`); `s` the pixel's depth. V̄ is the mean light over
/// the samples where the density is above 0 (1 where there is none). Every sample is marched
/// (no skipping).
pub fn density_reference_pixel(
    p: &ScatterParams,
    shadow: &Raster,
    density: &Density,
    s: f32,
    (x, y): (u32, u32),
    (w, h): (u32, u32),
    light_steps: u32,
) -> PixelResult {
    let inv = glam::Mat4::from_cols_array_2d(&p.inv_view_proj);
    let eye = Vec3::from(p.eye);
    let dir = tyndall_engine::eval::pixel_ray(inv, eye, x, y, w, h);
    let (a, b) = medium_segment(p, dir, s);
    let (da, db) = density.segment(eye, dir);
    let (t0, t1) = (a.max(da), b.min(db));
    let len = (t1 - t0).max(0.0);
    let hash = crate::algorithms::shader_lib::pixel_jitter(x, y) + p.jitter_phase;
    let offset = p.jitter * ((hash - hash.floor()) - 0.5);
    let delta = len / p.steps as f32;
    let lvp = glam::Mat4::from_cols_array_2d(&p.light.view_proj);
    let (mut tr, mut lit, mut in_smoke, mut acc) = (1.0f32, 0.0f32, 0u32, [0.0f32; 3]);
    for i in 0..p.steps {
        let t = t0 + (i as f32 + 0.5 + offset) * delta;
        let xs = eye + dir * t;
        let dens = density.at(xs);
        if dens <= 0.0 {
            continue; // no medium: nothing scattered or absorbed, and not part of V̄
        }
        let sigma = p.sigma_t * dens;
        let (v, f) = match p.local() {
            Some(l) => {
                let uvz = l.uvz(lvp, xs).unwrap_or(Vec3::new(-1.0, -1.0, 2.0));
                let cos = dir.dot((l.position() - xs).normalize_or_zero());
                (
                    sun_reaches(shadow, uvz, p.bias),
                    henyey_greenstein(p.g, cos) * l.falloff(xs),
                )
            }
            None => (
                sun_reaches(shadow, light_uvz(lvp, xs), p.bias),
                henyey_greenstein(p.g, dir.dot(p.to_sun())),
            ),
        };
        let light = if v {
            light_transmittance(p, density, xs, light_steps)
        } else {
            0.0
        };
        lit += light;
        in_smoke += 1;
        let absorbed = 1.0 - (-sigma * delta).exp();
        for (c, a) in acc.iter_mut().enumerate() {
            *a += p.light.radiance[c] * p.albedo * f * light * tr * absorbed;
        }
        tr *= (-sigma * delta).exp();
    }
    let vbar = if in_smoke > 0 {
        lit / in_smoke as f32
    } else {
        1.0
    };
    (vbar, acc, tr)
}

/// The density path's passes, after the method's shared bindings `binds`: the light
/// transmittance volume over the density's box (`transmittance_resolution` texels on its longest
/// side, at least 2 on every side), then the march (`brute_force_density`); the occupancy of
/// 4³-texel bricks before both (empty-space skipping). Returns that volume
/// and its box (the `light_transmittance` output).
pub(super) fn dispatch<'a>(
    gpu: &Recorder,
    binds: &[(&'static str, Bind<'a>)],
    (volume, bounds): (&'a GpuVolume, [[f32; 3]; 2]),
    p: &super::Params,
    size: (u32, u32),
    constants: &[(&str, f64)],
) -> Result<(GpuVolume, [[f32; 3]; 2]), NodeError> {
    let view = DensityView {
        lo: bounds[0],
        light_steps: p.light_steps as u32,
        hi: bounds[1],
        _pad0: 0,
    };
    let resolution = p.transmittance_resolution as u32;
    let ext = [0, 1, 2].map(|k| (bounds[1][k] - bounds[0][k]).max(0.0));
    let longest = ext.iter().copied().fold(0.0f32, f32::max).max(1e-12);
    let tr_size =
        ext.map(|e| ((e / longest * resolution as f32).round() as u32).clamp(2, resolution.max(2)));
    let light_tr = gpu.volume(tr_size)?;
    let occ_size = volume.size.map(|n| n.div_ceil(BRICK).max(1));
    let occupancy = gpu.volume(occ_size)?;
    let mut b = binds.to_vec();
    b.push(("density_volume", Bind::Volume(volume)));
    b.push(("D", Bind::Uniform(bytemuck::bytes_of(&view))));
    let mut occ = b.clone();
    occ.push(("out_occupancy", Bind::VolumeLevel(&occupancy, 0)));
    gpu.dispatch_3d(DENSITY, "occupancy_build", &occ, occ_size)?;
    b.push(("occupancy", Bind::Volume(&occupancy)));
    let mut build = b.clone();
    build.push(("out_light_tr", Bind::VolumeLevel(&light_tr, 0)));
    gpu.dispatch_3d(DENSITY, "light_transmittance", &build, tr_size)?;
    b.push(("light_tr", Bind::Volume(&light_tr)));
    gpu.dispatch_with(DENSITY, "brute_force_density", &b, size, constants)?;
    Ok((light_tr, bounds))
}

/// Refuse what the density path does not do.
pub(super) fn check(light_map: bool) -> Result<(), NodeError> {
    if light_map {
        return Err(NodeError::Input {
            port: "light_map".into(),
            message: "cannot be combined with a density (the density path does not read a light \
                      map yet): disconnect one"
                .into(),
        });
    }
    Ok(())
}
