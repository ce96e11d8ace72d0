//! The penumbra kernel: its taps (Poisson disk, box, Gaussian), stencils and their variance.

use super::{BTreeMap, Kernel};
use crate::algorithms::random::SplitMix64;

/// Everything that shapes the kernels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelSpec {
    /// Which kernel.
    pub kernel: Kernel,
    /// Per-axis variance of the kernel in texels² (x, y) before rotation.
    pub variance: [f64; 2],
    /// Rotation, radians.
    pub rotation: f64,
    /// Poisson samples.
    pub samples: u32,
    /// Gaussian taps per axis.
    pub size: u32,
    /// Seed.
    pub seed: u32,
}

/// A stencil: integer texel offsets and weights (summing to 1).
pub type Stencil = Vec<(i32, i32, f64)>;

/// A small deterministic generator ([`SplitMix64`]) for the stochastic kernels.
pub(super) fn random(seed: u64) -> impl FnMut() -> f64 {
    let mut r = SplitMix64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1));
    move || r.next_f64()
}

/// The continuous taps of slice `k` for a unit per-axis variance: (x, y, weight).
pub(super) fn unit_taps(spec: &KernelSpec, k: u32, sigma: f64) -> Vec<(f64, f64, f64)> {
    let mut rng = random(((spec.seed as u64) << 32) ^ k as u64);
    match spec.kernel {
        Kernel::TopHat => {
            let n = ((12f64.sqrt() * sigma).ceil() as usize).clamp(2, 15);
            let s = (12.0 / ((n * n - 1) as f64)).sqrt();
            let c = (n as f64 - 1.0) / 2.0;
            let w = 1.0 / (n * n) as f64;
            (0..n * n)
                .map(|i| (((i % n) as f64 - c) * s, ((i / n) as f64 - c) * s, w))
                .collect()
        }
        Kernel::Dirac2 => [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
            .map(|(x, y)| (x, y, 0.25))
            .to_vec(),
        Kernel::StochasticDirac => {
            let rx = (2.0 * rng()).sqrt();
            let ry = (2.0 * rng()).sqrt();
            [(-rx, -ry), (rx, -ry), (-rx, ry), (rx, ry)]
                .map(|(x, y)| (x, y, 0.25))
                .to_vec()
        }
        Kernel::Ellipse2 => {
            let phi = rng() * std::f64::consts::TAU;
            let (x, y) = (2f64.sqrt() * phi.cos(), 2f64.sqrt() * phi.sin());
            vec![(x, y, 0.5), (-x, -y, 0.5)]
        }
        Kernel::Poisson => {
            // Centred, so the kernel's mean is 0 for any sample count.
            let raw = poisson_disk(spec.samples.max(1) as usize, spec.seed);
            let (mx, my) = raw.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
            let (mx, my) = (mx / raw.len() as f64, my / raw.len() as f64);
            let pts: Vec<(f64, f64)> = raw.iter().map(|(x, y)| (x - mx, y - my)).collect();
            let turn = rng() * std::f64::consts::TAU;
            let (c, s) = (turn.cos(), turn.sin());
            let m2: f64 = pts.iter().map(|(x, y)| x * x + y * y).sum::<f64>() / pts.len() as f64;
            let scale = if m2 > 0.0 { (2.0 / m2).sqrt() } else { 0.0 };
            let w = 1.0 / pts.len() as f64;
            pts.iter()
                .map(|(x, y)| ((c * x - s * y) * scale, (s * x + c * y) * scale, w))
                .collect()
        }
        Kernel::Gaussian => {
            let n = spec.size.max(1) as usize;
            let c = (n as f64 - 1.0) / 2.0;
            let h = if n > 1 { 6.0 / (n as f64 - 1.0) } else { 0.0 };
            let g: Vec<f64> = (0..n)
                .map(|i| (-0.5 * ((i as f64 - c) * h).powi(2)).exp())
                .collect();
            let total: f64 = g.iter().sum::<f64>().powi(2);
            (0..n * n)
                .map(|i| {
                    let (a, b) = (i % n, i / n);
                    ((a as f64 - c) * h, (b as f64 - c) * h, g[a] * g[b] / total)
                })
                .collect()
        }
    }
}

/// `n` points of a Poisson disk in the unit disk (dart throwing with a shrinking radius).
pub fn poisson_disk(n: usize, seed: u32) -> Vec<(f64, f64)> {
    let mut rng = random(seed as u64 ^ 0xD15C);
    let mut pts: Vec<(f64, f64)> = Vec::with_capacity(n);
    let mut r = 2.0 / (n as f64).sqrt();
    while pts.len() < n {
        let mut placed = false;
        for _ in 0..200 {
            let (x, y) = (rng() * 2.0 - 1.0, rng() * 2.0 - 1.0);
            if x * x + y * y > 1.0 {
                continue;
            }
            if pts
                .iter()
                .all(|(a, b)| (a - x).powi(2) + (b - y).powi(2) >= r * r)
            {
                pts.push((x, y));
                placed = true;
                break;
            }
        }
        if !placed {
            r *= 0.9;
        }
    }
    pts
}

/// Splat continuous taps, scaled by `scale` and shaped by the light, onto integer offsets.
pub(super) fn splat(spec: &KernelSpec, taps: &[(f64, f64, f64)], scale: f64) -> Stencil {
    let (c, s) = (spec.rotation.cos(), spec.rotation.sin());
    let (sx, sy) = (spec.variance[0].sqrt(), spec.variance[1].sqrt());
    let mut map: BTreeMap<(i32, i32), f64> = BTreeMap::new();
    for (x, y, w) in taps {
        let (x, y) = (x * scale * sx, y * scale * sy);
        let (x, y) = (c * x - s * y, s * x + c * y);
        let (fx, fy) = (x.floor(), y.floor());
        let (ax, ay) = (x - fx, y - fy);
        for (dx, dy, f) in [
            (0, 0, (1.0 - ax) * (1.0 - ay)),
            (1, 0, ax * (1.0 - ay)),
            (0, 1, (1.0 - ax) * ay),
            (1, 1, ax * ay),
        ] {
            if f > 0.0 {
                *map.entry((fx as i32 + dx, fy as i32 + dy)).or_default() += w * f;
            }
        }
    }
    map.into_iter().map(|((x, y), w)| (x, y, w)).collect()
}

/// The mean per-axis variance of a stencil, in texels².
pub fn stencil_variance(st: &Stencil) -> f64 {
    let w: f64 = st.iter().map(|t| t.2).sum();
    let mx: f64 = st.iter().map(|t| t.0 as f64 * t.2).sum::<f64>() / w;
    let my: f64 = st.iter().map(|t| t.1 as f64 * t.2).sum::<f64>() / w;
    let vx: f64 = st
        .iter()
        .map(|t| (t.0 as f64 - mx).powi(2) * t.2)
        .sum::<f64>()
        / w;
    let vy: f64 = st
        .iter()
        .map(|t| (t.1 as f64 - my).powi(2) * t.2)
        .sum::<f64>()
        / w;
    0.5 * (vx + vy)
}

/// The stencil of slice `k`: the kernel's taps, their spread scaled (bisection) so that the
/// stencil's mean per-axis variance equals the target's.
pub fn stencil(spec: &KernelSpec, k: u32) -> Stencil {
    let target = 0.5 * (spec.variance[0] + spec.variance[1]);
    if target <= 0.0 {
        return vec![(0, 0, 1.0)];
    }
    let taps = unit_taps(spec, k, target.sqrt());
    let (mut lo, mut hi) = (0.0, 1.0);
    while stencil_variance(&splat(spec, &taps, hi)) < target && hi < 1e6 {
        hi *= 2.0;
    }
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if stencil_variance(&splat(spec, &taps, mid)) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    splat(spec, &taps, 0.5 * (lo + hi))
}
