//! A one-channel volume over a world box on the CPU — a density, a light transmittance — and how
//! it is read: the CPU twin of `shaders/lib/box_volume.wgsl`.

use glam::Vec3;

/// A one-channel volume over a world box on the CPU (level 0 of a Volume): a density, a light
/// transmittance.
#[derive(Debug, Clone)]
pub struct BoxVolume {
    /// Texels along x, y, z.
    pub size: [u32; 3],
    /// Values, x fastest.
    pub data: Vec<f32>,
    /// World box `[min, max]`.
    pub bounds: [[f32; 3]; 2],
}

impl BoxVolume {
    /// A density at world point `x`: [`BoxVolume::at_or`] with 0 outside the box, never
    /// negative.
    pub fn at(&self, x: Vec3) -> f32 {
        self.at_or(x, 0.0).max(0.0)
    }

    /// The value at world point `x`: trilinear between texel centres, the edge texels held over
    /// the outer half texel, `outside` beyond the box (`shaders/lib/box_volume.wgsl`'s
    /// `box_trilinear`).
    pub fn at_or(&self, x: Vec3, outside: f32) -> f32 {
        let [lo, hi] = self.bounds.map(Vec3::from);
        let u = (x - lo) / (hi - lo).max(Vec3::splat(1e-12));
        if u.cmplt(Vec3::ZERO).any() || u.cmpgt(Vec3::ONE).any() {
            return outside;
        }
        let n = self.size.map(|v| v as i64);
        let q = [0, 1, 2].map(|k| u[k] * n[k] as f32 - 0.5);
        let b = q.map(|v| v.floor() as i64);
        let f = [0, 1, 2].map(|k| q[k] - q[k].floor());
        let at = |o: [i64; 3]| {
            let c: [i64; 3] = std::array::from_fn(|k| (b[k] + o[k]).clamp(0, n[k] - 1));
            self.data[((c[2] * n[1] + c[1]) * n[0] + c[0]) as usize]
        };
        let mut v = 0.0;
        for k in 0..8 {
            let o = [(k & 1) as i64, ((k >> 1) & 1) as i64, ((k >> 2) & 1) as i64];
            let w: f32 = (0..3)
                .map(|a| if o[a] == 1 { f[a] } else { 1.0 - f[a] })
                .product();
            v += w * at(o);
        }
        v
    }

    /// A light transmittance volume seen from `x` towards the light (unit `d`, the light `far`
    /// away): at x inside the box, else where the ray enters it, 1 when it misses the box
    /// (`box_towards`).
    pub fn towards(&self, x: Vec3, d: Vec3, far: f32) -> f32 {
        let (a, b) = self.segment(x, d);
        let (t0, t1) = (a.max(0.0), b.min(far));
        if t1 < t0 {
            return 1.0;
        }
        let ext = (Vec3::from(self.bounds[1]) - Vec3::from(self.bounds[0])).length();
        self.at_or(x + d * (t0 + 1e-6 * ext.max(1.0)), 1.0)
    }

    /// Where a ray from `o` along `d` is inside the box: `[t0, t1]` (t1 < t0 when it misses).
    pub fn segment(&self, o: Vec3, d: Vec3) -> (f32, f32) {
        let (mut t0, mut t1) = (f32::MIN, f32::MAX);
        for k in 0..3 {
            let (lo, hi) = (self.bounds[0][k], self.bounds[1][k]);
            if d[k] != 0.0 {
                let (a, b) = ((lo - o[k]) / d[k], (hi - o[k]) / d[k]);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            } else if o[k] < lo || o[k] > hi {
                return (0.0, -1.0);
            }
        }
        (t0, t1)
    }
}
