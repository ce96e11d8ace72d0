//! Phase-function tables on the CPU: sampling, Legendre series, the analytic models, Lorenz–Mie
//! populations and the multiple-scattering spread (the references of the GPU passes).

use super::{
    lorenz_mie, Complex64, MieParams, Population, Preset, Select, Shape, MAX_SCATTERS,
    WAVELENGTHS_NM,
};

use crate::algorithms::ice_optics::{ice_table, Habit, Prism};

use crate::algorithms::phase_function::{hg_value, rayleigh_value, PhaseTable};

/// CPU reference of `HenyeyGreenstein`.
pub fn henyey_greenstein(g: f64, w: usize) -> PhaseTable {
    PhaseTable::from_fn(w, |t| [hg_value(g, t.cos()); 3]).normalised()
}

/// CPU reference of `Rayleigh`.
pub fn rayleigh(w: usize) -> PhaseTable {
    PhaseTable::from_fn(w, |t| [rayleigh_value(t.cos()); 3]).normalised()
}

/// Spread of the `rain` preset's raindrops (σ_g).
pub const RAIN_SPREAD: f64 = 1.2;

/// The particles `Mie` with parameters `p` scatters at `nm` nanometres: for `cloud` and `rain`
/// water (with its dispersion, [`lorenz_mie::water_index`]) of `cloud_radius` and
/// `cloud_spread`, or `rain_radius` and [`RAIN_SPREAD`]; for `custom` the population parameters
/// (one index at every wavelength).
pub fn population(p: &MieParams, nm: f64) -> Population {
    let water = Complex64::new(lorenz_mie::water_index(nm), 0.0);
    match p.preset {
        Preset::Custom => Population {
            radius_um: p.radius,
            spread: p.spread,
            m: Complex64::new(p.n_real, p.n_imag),
        },
        Preset::Cloud => Population {
            radius_um: p.cloud_radius,
            spread: p.cloud_spread,
            m: water,
        },
        Preset::Rain => Population {
            radius_um: p.rain_radius,
            spread: RAIN_SPREAD,
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

/// The Mie table before normalisation (what the node uploads), on `threads` threads: channel k
/// is population `pops[k]` at `WAVELENGTHS_NM[k]`; `done(k)` is called after channel k.
pub fn mie_raw(
    pops: &[Population; 3],
    radii: usize,
    w: usize,
    threads: usize,
    done: impl Fn(usize),
) -> PhaseTable {
    let thetas: Vec<f64> = (0..w).map(|i| PhaseTable::theta(i, w)).collect();
    let dtheta = std::f64::consts::PI / w as f64;
    let ch: Vec<Vec<f64>> = WAVELENGTHS_NM
        .iter()
        .zip(pops)
        .enumerate()
        .map(|(k, (l, p))| {
            let sub = sub_angles(p, radii, w);
            let v = lorenz_mie::phase(p, *l, &thetas, dtheta, sub, radii, threads);
            done(k);
            v
        })
        .collect();
    PhaseTable {
        rgb: (0..w).map(|i| [ch[0][i], ch[1][i], ch[2][i]]).collect(),
    }
}

/// CPU reference of `Mie` for one population in every channel (`preset = custom`).
pub fn mie(p: &Population, radii: usize, w: usize) -> PhaseTable {
    mie_raw(&[*p; 3], radii, w, threads(), |_| {}).normalised()
}

/// CPU reference of `IceCrystals` (the node uploads it and normalises it on the GPU): crystals
/// of `shape`, `aspect` and `size` µm, `rays` rays per channel, `w` angles.
pub fn ice(shape: Shape, aspect: f64, size: f64, rays: usize, w: usize) -> PhaseTable {
    let habit = match shape {
        Shape::Column => Habit::Column,
        Shape::Plate => Habit::Plate,
    };
    ice_table(
        &Prism::new(habit, aspect, size),
        WAVELENGTHS_NM,
        rays,
        w,
        threads(),
    )
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

pub(super) fn threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

// ---- GPU ------------------------------------------------------------------------------------
