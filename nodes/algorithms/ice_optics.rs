//! Geometric optics of randomly oriented hexagonal ice crystals (seed 002 §3, Fig. 3, after Hess
//! and Wiegner): the phase function of `IceCrystals`, on the CPU.
//!
//! **The crystal.** A hexagonal prism, axis z: six side faces at apothem a (normals every 60° in
//! the xy-plane), two basal faces at z = ±h. A `column` is long along its axis (length 2h =
//! `aspect` × the diameter 2a across its flats), a `plate` flat (thickness 2h = 2a / `aspect`);
//! `size` is the largest dimension (a column's length, a plate's diameter across its corners).
//!
//! **Rays.** Random orientation is random incidence on a fixed crystal: a direction uniform on
//! the sphere and a point uniform on a disc of the bounding sphere's radius across it (rays that
//! miss are dropped, so each orientation counts by its projected area, as it does in the sky).
//! At each face the unpolarised Fresnel reflectance R ((R_s + R_p)/2; 1 past the critical angle)
//! picks reflection with probability R, refraction otherwise (Russian roulette: each ray carries
//! its whole weight, the expectation is the split one). A ray leaves when it refracts out, or
//! reflects off the outside at its first face; after [`MAX_BOUNCES`] internal reflections its
//! weight (below 1e-3 of the rays) is dropped. Ice absorbs nothing at 440–680 nm here. The
//! scattering angle θ = acos(d_in · d_out) is histogrammed on the table's angles and divided by
//! the bins' solid angles.
//!
//! **Diffraction.** Ice crystals are large (x = 2πr/λ ≫ 1), so extinction is twice the
//! geometric cross-section: half the scattered light is the diffraction peak around θ = 0.
//! It is the Fraunhofer pattern of a circular aperture of the crystal's mean projected area
//! (S/4, Cauchy's theorem): p ∝ (2 J₁(x sin θ) / (x sin θ))², averaged over each bin.
//!
//! **Dispersion.** Ice's refractive index (ordinary ray) from a Cauchy fit n = A + B/λ² through
//! 1.3078 at 656.3 nm and 1.3136 at 486.1 nm (the C and F lines; it gives 1.3095 at the D line,
//! 589 nm, where tables give 1.3098): 1.3073, 1.3108, 1.3164 at 680, 550, 440 nm. So the halos'
//! minimum deviations D = 2 asin(n sin(A/2)) − A are 21.6°, 21.9°, 22.3° (A = 60°) and 45.2°,
//! 45.9°, 47.1° (A = 90°): red inside, blue outside.

use glam::DVec3;

use super::phase_function::PhaseTable;
use super::random::SplitMix64;

/// Cauchy coefficients of ice's refractive index: n = A + B / λ², λ in µm.
const CAUCHY: (f64, f64) = (1.300_752, 0.003_036);

/// Internal reflections followed before a ray is dropped.
pub const MAX_BOUNCES: usize = 16;

/// Rays per chunk: chunks are traced in parallel, each from its own seed, so the table does not
/// depend on the number of threads.
const CHUNK: usize = 8192;

/// Ice's refractive index at `nm` nanometres.
pub fn ice_index(nm: f64) -> f64 {
    let um = nm * 1e-3;
    CAUCHY.0 + CAUCHY.1 / (um * um)
}

/// Minimum deviation of a prism of apex angle `apex` (radians) and index `n`:
/// D = 2 asin(n sin(A/2)) − A.
pub fn minimum_deviation(n: f64, apex: f64) -> f64 {
    2.0 * (n * (apex / 2.0).sin()).asin() - apex
}

/// Crystal habits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Habit {
    /// Long along the axis.
    Column,
    /// Flat across the axis.
    Plate,
}

/// A hexagonal prism: apothem `a`, half-height `h` (µm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prism {
    /// Distance from the axis to a side face.
    pub a: f64,
    /// Half the length along the axis.
    pub h: f64,
}

impl Prism {
    /// The prism of `habit` with `aspect` (≥ 1: length / diameter for a column, diameter /
    /// thickness for a plate) whose largest dimension is `size` µm.
    pub fn new(habit: Habit, aspect: f64, size: f64) -> Prism {
        let aspect = aspect.max(1.0);
        let cos30 = 3f64.sqrt() / 2.0;
        match habit {
            Habit::Column => {
                let h = size / 2.0;
                Prism { a: h / aspect, h }
            }
            Habit::Plate => {
                let a = size / 2.0 * cos30;
                Prism { a, h: a / aspect }
            }
        }
    }

    /// The faces as (outward normal, offset d): inside is n · x ≤ d.
    fn planes(&self) -> [(DVec3, f64); 8] {
        let mut p = [(DVec3::ZERO, 0.0); 8];
        for (k, plane) in p.iter_mut().take(6).enumerate() {
            let phi = k as f64 * std::f64::consts::PI / 3.0;
            *plane = (DVec3::new(phi.cos(), phi.sin(), 0.0), self.a);
        }
        p[6] = (DVec3::Z, self.h);
        p[7] = (DVec3::NEG_Z, self.h);
        p
    }

    /// Surface area (µm²).
    pub fn area(&self) -> f64 {
        let side = 2.0 * self.a / 3f64.sqrt();
        let hexagon = 2.0 * 3f64.sqrt() * self.a * self.a;
        2.0 * hexagon + 6.0 * side * 2.0 * self.h
    }

    /// Radius of the bounding sphere.
    fn bound(&self) -> f64 {
        let corner = 2.0 * self.a / 3f64.sqrt();
        (corner * corner + self.h * self.h).sqrt()
    }
}

/// Unpolarised Fresnel reflectance for a ray meeting a face at cos i = `cos_i` (> 0) going from
/// index `n1` into `n2`; the refracted cosine, None past the critical angle.
fn fresnel(cos_i: f64, n1: f64, n2: f64) -> (f64, Option<f64>) {
    let eta = n1 / n2;
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return (1.0, None);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i);
    (0.5 * (rs * rs + rp * rp), Some(cos_t))
}

/// The direction after meeting a face of outward normal `n` (d · n ≠ 0) going from `n1` into
/// `n2`: reflected with probability R, else refracted. Returns (direction, refracted).
fn interact(d: DVec3, n: DVec3, n1: f64, n2: f64, rng: &mut SplitMix64) -> (DVec3, bool) {
    // Normal facing the incoming ray.
    let facing = if d.dot(n) < 0.0 { n } else { -n };
    let cos_i = -d.dot(facing);
    let (r, cos_t) = fresnel(cos_i, n1, n2);
    match cos_t {
        Some(cos_t) if rng.next_f64() >= r => {
            let eta = n1 / n2;
            (facing * (eta * cos_i - cos_t) + d * eta, true)
        }
        _ => (facing * (2.0 * cos_i) + d, false),
    }
}

/// One ray's scattering angle (radians), or None when it misses or is dropped.
fn trace(prism: &Prism, planes: &[(DVec3, f64); 8], n: f64, rng: &mut SplitMix64) -> Option<f64> {
    // A direction uniform on the sphere and a point on the bounding disc across it.
    let z = 2.0 * rng.next_f64() - 1.0;
    let phi = 2.0 * std::f64::consts::PI * rng.next_f64();
    let s = (1.0 - z * z).max(0.0).sqrt();
    let d0 = DVec3::new(s * phi.cos(), s * phi.sin(), z);
    let (u, v) = d0.any_orthonormal_pair();
    let rb = prism.bound();
    let rad = rb * rng.next_f64().sqrt();
    let ang = 2.0 * std::f64::consts::PI * rng.next_f64();
    let mut o = d0 * (-2.0 * rb) + u * (rad * ang.cos()) + v * (rad * ang.sin());
    // Entry: the slab test against the eight faces.
    let (mut t_in, mut t_out, mut face) = (f64::NEG_INFINITY, f64::INFINITY, usize::MAX);
    for (k, (nk, dk)) in planes.iter().enumerate() {
        let dn = d0.dot(*nk);
        let dist = dk - o.dot(*nk);
        if dn.abs() < 1e-12 {
            if dist < 0.0 {
                return None;
            }
            continue;
        }
        let t = dist / dn;
        if dn < 0.0 {
            if t > t_in {
                t_in = t;
                face = k;
            }
        } else {
            t_out = t_out.min(t);
        }
    }
    if face == usize::MAX || t_in >= t_out {
        return None;
    }
    o += d0 * t_in;
    let (mut d, refracted) = interact(d0, planes[face].0, 1.0, n, rng);
    if !refracted {
        return Some(d0.dot(d).clamp(-1.0, 1.0).acos());
    }
    for _ in 0..=MAX_BOUNCES {
        // The face the ray leaves by.
        let (mut t_min, mut exit) = (f64::INFINITY, usize::MAX);
        for (k, (nk, dk)) in planes.iter().enumerate() {
            let dn = d.dot(*nk);
            if dn > 1e-12 {
                let t = (dk - o.dot(*nk)) / dn;
                if t < t_min {
                    t_min = t;
                    exit = k;
                }
            }
        }
        if exit == usize::MAX {
            return None;
        }
        o += d * t_min.max(0.0);
        let (next, out) = interact(d, planes[exit].0, n, 1.0, rng);
        if out {
            return Some(d0.dot(next).clamp(-1.0, 1.0).acos());
        }
        d = next;
    }
    None
}

/// The ray-traced part for index `n`: a histogram of `rays` rays on `w` angles (counts per bin),
/// on up to `threads` threads, deterministic for a `seed`.
pub fn ray_histogram(
    prism: &Prism,
    n: f64,
    rays: usize,
    w: usize,
    threads: usize,
    seed: u64,
) -> Vec<f64> {
    let planes = prism.planes();
    let chunks = rays.div_ceil(CHUNK).max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let total = std::sync::Mutex::new(vec![0.0; w]);
    std::thread::scope(|s| {
        for _ in 0..threads.clamp(1, chunks) {
            s.spawn(|| {
                let mut mine = vec![0.0; w];
                loop {
                    let c = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if c >= chunks {
                        break;
                    }
                    let mut rng = SplitMix64(seed ^ (c as u64).wrapping_mul(0x2545_f491_4f6c_dd1d));
                    let count = CHUNK.min(rays - (c * CHUNK).min(rays));
                    for _ in 0..count {
                        if let Some(theta) = trace(prism, &planes, n, &mut rng) {
                            let i = ((theta / std::f64::consts::PI) * w as f64) as usize;
                            mine[i.min(w - 1)] += 1.0;
                        }
                    }
                }
                let mut t = total.lock().unwrap_or_else(|e| e.into_inner());
                t.iter_mut().zip(&mine).for_each(|(a, b)| *a += b);
            });
        }
    });
    total.into_inner().unwrap_or_else(|e| e.into_inner())
}

/// J₁(z) by the trapezoid rule on Bessel's integral (1/2π) ∫₀^{2π} cos(τ − z sin τ) dτ, which
/// converges geometrically once the points outnumber z.
fn bessel_j1(z: f64) -> f64 {
    let n = (1.2 * z.abs()) as usize + 64;
    let step = 2.0 * std::f64::consts::PI / n as f64;
    (0..n)
        .map(|k| {
            let t = k as f64 * step;
            (t - z * t.sin()).cos()
        })
        .sum::<f64>()
        / n as f64
}

/// The Airy pattern (2 J₁(x sin θ) / (x sin θ))² averaged over each of `w` bins (4 sub-angles),
/// x = 2π r / λ; zero where x sin θ > 300 (below 1e-7 of the peak there).
pub fn diffraction(x: f64, w: usize) -> Vec<f64> {
    let dtheta = std::f64::consts::PI / w as f64;
    (0..w)
        .map(|i| {
            (0..4)
                .map(|k| {
                    let theta = (i as f64 + (k as f64 + 0.5) / 4.0) * dtheta;
                    let z = x * theta.sin();
                    if z < 1e-6 {
                        1.0
                    } else if z > 300.0 {
                        0.0
                    } else {
                        let a = 2.0 * bessel_j1(z) / z;
                        a * a
                    }
                })
                .sum::<f64>()
                / 4.0
        })
        .collect()
}

/// The phase table of ice crystals `prism` at wavelengths `nm` (one per channel): half the
/// ray-traced part (`rays` rays per channel), half diffraction, normalised.
pub fn ice_table(prism: &Prism, nm: [f64; 3], rays: usize, w: usize, threads: usize) -> PhaseTable {
    let dtheta = std::f64::consts::PI / w as f64;
    let solid = |i: usize| 2.0 * std::f64::consts::PI * PhaseTable::theta(i, w).sin() * dtheta;
    let r_eq = (prism.area() / (4.0 * std::f64::consts::PI)).sqrt();
    let mut rgb = vec![[0.0; 3]; w];
    for (c, l) in nm.iter().enumerate() {
        let hist = ray_histogram(prism, ice_index(*l), rays, w, threads, 0x1ce + c as u64);
        let geo = PhaseTable {
            rgb: hist
                .iter()
                .enumerate()
                .map(|(i, h)| [h / solid(i); 3])
                .collect(),
        }
        .normalised();
        let x = 2.0 * std::f64::consts::PI * r_eq / (l * 1e-3);
        let diff = PhaseTable {
            rgb: diffraction(x, w).into_iter().map(|v| [v; 3]).collect(),
        }
        .normalised();
        for ((out, g), d) in rgb.iter_mut().zip(&geo.rgb).zip(&diff.rgb) {
            out[c] = 0.5 * g[0] + 0.5 * d[0];
        }
    }
    PhaseTable { rgb }.normalised()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bessel_j1_matches_tabulated_values() {
        // Abramowitz & Stegun Table 9.1: J₁(1) = 0.4400505857, J₁(5) = −0.3275791376,
        // J₁(10) = 0.0434727462; the first zero of J₁ is 3.8317059702.
        assert!((bessel_j1(1.0) - 0.440_050_585_7).abs() < 1e-9);
        assert!((bessel_j1(5.0) + 0.327_579_137_6).abs() < 1e-9);
        assert!((bessel_j1(10.0) - 0.043_472_746_2).abs() < 1e-9);
        assert!(bessel_j1(3.831_705_970_2).abs() < 1e-9);
    }

    #[test]
    fn ice_index_and_minimum_deviation() {
        // The fit passes through its two lines and near the D line's tabulated 1.3098.
        assert!((ice_index(656.3) - 1.3078).abs() < 2e-4);
        assert!((ice_index(486.1) - 1.3136).abs() < 2e-4);
        assert!((ice_index(589.3) - 1.3098).abs() < 5e-4);
        let d = minimum_deviation(1.31, 60f64.to_radians()).to_degrees();
        assert!((d - 21.84).abs() < 0.01, "{d}");
    }

    #[test]
    fn a_prism_has_the_habit_and_size_asked() {
        let c = Prism::new(Habit::Column, 3.0, 120.0);
        assert!((2.0 * c.h - 120.0).abs() < 1e-12 && (c.h / c.a - 3.0).abs() < 1e-12);
        let p = Prism::new(Habit::Plate, 5.0, 120.0);
        let corner = 2.0 * p.a / 3f64.sqrt();
        assert!((2.0 * corner - 120.0).abs() < 1e-9 && (p.a / p.h - 5.0).abs() < 1e-12);
    }
}
