//! Phase functions on the CPU, shared by the techniques that tabulate, read or evaluate them
//! (the `Phase` kinds, `Sky`, `SingleScattering`'s reference): [`PhaseTable`] — a table on W
//! angles θ_i = π (i + ½) / W, RGB per angle, in 1/sr, as a `Phase` port's texels —, the
//! Legendre recurrence, and the analytic Henyey–Greenstein and Rayleigh models.

use tyndall_engine::eval::{NodeError, PortValue};
use tyndall_engine::gpu::Recorder;

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
    pub fn read(gpu: &Recorder, value: &PortValue) -> Result<Self, NodeError> {
        let r = tyndall_engine::eval::download(gpu, value)?;
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
