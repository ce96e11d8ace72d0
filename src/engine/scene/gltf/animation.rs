//! glTF animation: channels that move nodes (translation, rotation, scale), sampled with the
//! file's interpolation (glTF 2.0 §3.11 and Appendix C).
//!
//! - `STEP`: the value of the last key at or before t.
//! - `LINEAR`: linear between the two keys around t; rotations are slerped (shortest arc).
//! - `CUBICSPLINE`: the cubic Hermite spline with each key's in- and out-tangent, tangents
//!   scaled by the key interval `t_d = t_{k+1} − t_k`:
//!   `p(s) = (2s³ − 3s² + 1) v_k + (s³ − 2s² + s) t_d b_k + (−2s³ + 3s²) v_{k+1} + (s³ − s²) t_d a_{k+1}`,
//!   s = (t − t_k)/t_d; rotations are normalised afterwards.
//!
//! Before the first key and after the last the value holds (clamped, never extrapolated).

use glam::{Quat, Vec3, Vec4};

/// How a channel interpolates between keys.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    /// Hold the previous key.
    Step,
    /// Linear (slerp for rotations).
    Linear,
    /// Cubic Hermite with per-key tangents.
    CubicSpline,
}

/// Which property of a node a channel drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    /// Translation (metres).
    Translation,
    /// Rotation (unit quaternion x, y, z, w).
    Rotation,
    /// Scale.
    Scale,
}

/// One channel: key times (seconds, increasing) and values (x, y, z, w; w unused for
/// translation and scale). For `CUBICSPLINE` there are three values per key: in-tangent,
/// value, out-tangent.
#[derive(Debug, Clone)]
pub struct Channel {
    /// The glTF node index it moves.
    pub node: usize,
    /// The property it drives.
    pub target: Target,
    /// Interpolation.
    pub interpolation: Interpolation,
    /// Key times, seconds.
    pub times: Vec<f32>,
    /// Values (see the struct's doc for `CUBICSPLINE`'s layout).
    pub values: Vec<Vec4>,
}

/// One animation of the file: its name and channels.
#[derive(Debug, Clone)]
pub struct Animation {
    /// Name (`animation N` when the file gives none).
    pub name: String,
    /// Channels moving nodes (morph-target weights are not played).
    pub channels: Vec<Channel>,
}

impl Animation {
    /// First and last key time over all channels, seconds (`(0, 0)` with no channels).
    pub fn range(&self) -> (f32, f32) {
        let lo = self
            .channels
            .iter()
            .filter_map(|c| c.times.first())
            .fold(f32::INFINITY, |a, b| a.min(*b));
        let hi = self
            .channels
            .iter()
            .filter_map(|c| c.times.last())
            .fold(f32::NEG_INFINITY, |a, b| a.max(*b));
        if lo > hi {
            (0.0, 0.0)
        } else {
            (lo, hi)
        }
    }
}

impl Channel {
    /// The channel's value at `t` seconds (held before the first key and after the last).
    pub fn sample(&self, t: f32) -> Vec4 {
        let n = self.times.len();
        let value = |k: usize| match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        };
        if n == 0 {
            return Vec4::ZERO;
        }
        if n == 1 || t.is_nan() || t <= self.times[0] {
            return value(0);
        }
        if t >= self.times[n - 1] {
            return value(n - 1);
        }
        // The key interval [t_k, t_{k+1}) holding t.
        let k = self.times.partition_point(|x| *x <= t).saturating_sub(1);
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let td = t1 - t0;
        let s = if td > 0.0 { (t - t0) / td } else { 0.0 };
        let rotation = self.target == Target::Rotation;
        match self.interpolation {
            Interpolation::Step => value(k),
            Interpolation::Linear if rotation => {
                let (a, b) = (Quat::from_vec4(value(k)), Quat::from_vec4(value(k + 1)));
                Vec4::from(a.normalize().slerp(b.normalize(), s))
            }
            Interpolation::Linear => value(k).lerp(value(k + 1), s),
            Interpolation::CubicSpline => {
                let (s2, s3) = (s * s, s * s * s);
                let v0 = self.values[3 * k + 1];
                let b0 = self.values[3 * k + 2];
                let a1 = self.values[3 * (k + 1)];
                let v1 = self.values[3 * (k + 1) + 1];
                let p = v0 * (2.0 * s3 - 3.0 * s2 + 1.0)
                    + b0 * td * (s3 - 2.0 * s2 + s)
                    + v1 * (-2.0 * s3 + 3.0 * s2)
                    + a1 * td * (s3 - s2);
                if rotation {
                    p.normalize_or(Vec4::W)
                } else {
                    p
                }
            }
        }
    }
}

/// A node's local transform as translation, rotation and scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trs {
    /// Translation.
    pub translation: Vec3,
    /// Rotation.
    pub rotation: Quat,
    /// Scale.
    pub scale: Vec3,
}

impl Trs {
    /// This transform with the animation's channels for `node` applied at `t` seconds.
    pub fn animated(mut self, node: usize, anims: &[&Animation], t: f32) -> Self {
        for c in anims.iter().flat_map(|a| a.channels.iter()) {
            if c.node != node {
                continue;
            }
            let v = c.sample(t);
            match c.target {
                Target::Translation => self.translation = v.truncate(),
                Target::Rotation => self.rotation = Quat::from_vec4(v).normalize(),
                Target::Scale => self.scale = v.truncate(),
            }
        }
        self
    }

    /// The 4×4 matrix T·R·S.
    pub fn matrix(&self) -> glam::Mat4 {
        glam::Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// Which animations play: the `animation` parameter of `Scene` — empty (every animation of
/// the file, together: Blender's exporter writes one per animated object), a name, an index, or
/// `none` (the rest pose). The indices, in file order; the error lists the file's animations.
pub fn find_animation(animations: &[Animation], which: &str) -> Result<Vec<usize>, String> {
    let which = which.trim();
    if which.is_empty() {
        return Ok((0..animations.len()).collect());
    }
    if which.eq_ignore_ascii_case("none") {
        return Ok(Vec::new());
    }
    if let Some(i) = animations.iter().position(|a| a.name == which) {
        return Ok(vec![i]);
    }
    if let Ok(i) = which.parse::<usize>() {
        if i < animations.len() {
            return Ok(vec![i]);
        }
    }
    let names: Vec<String> = animations
        .iter()
        .enumerate()
        .map(|(i, a)| format!("{i} '{}'", a.name))
        .collect();
    Err(format!(
        "no animation '{which}' in the file (animations: {})",
        if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        }
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(interpolation: Interpolation, target: Target, values: Vec<Vec4>) -> Channel {
        Channel {
            node: 0,
            target,
            interpolation,
            times: vec![1.0, 2.0],
            values,
        }
    }

    #[test]
    fn step_linear_and_hold() {
        let v = vec![Vec4::ZERO, Vec4::new(2.0, 4.0, 6.0, 0.0)];
        let lin = channel(Interpolation::Linear, Target::Translation, v.clone());
        assert_eq!(lin.sample(1.5), Vec4::new(1.0, 2.0, 3.0, 0.0));
        assert_eq!(lin.sample(0.0), Vec4::ZERO, "holds before the first key");
        assert_eq!(lin.sample(9.0), v[1], "holds after the last key");
        let step = channel(Interpolation::Step, Target::Translation, v.clone());
        assert_eq!(step.sample(1.99), Vec4::ZERO);
        assert_eq!(step.sample(2.0), v[1]);
    }

    #[test]
    fn cubic_spline_meets_its_keys_and_tangents() {
        // In-tangent, value, out-tangent per key: p(s) = s³ for v0 = 0, v1 = 1, b0 = 0, a1 = 3.
        let v = vec![
            Vec4::ZERO,
            Vec4::ZERO,
            Vec4::ZERO,
            Vec4::splat(3.0),
            Vec4::splat(1.0),
            Vec4::ZERO,
        ];
        let c = channel(Interpolation::CubicSpline, Target::Translation, v);
        for s in [0.0f32, 0.25, 0.5, 0.75, 1.0] {
            let p = c.sample(1.0 + s).x;
            assert!((p - s * s * s).abs() < 1e-6, "s {s}: {p}");
        }
    }

    #[test]
    fn rotations_slerp_at_constant_angular_speed() {
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let c = channel(
            Interpolation::Linear,
            Target::Rotation,
            vec![Vec4::from(a), Vec4::from(b)],
        );
        let q = Quat::from_vec4(c.sample(1.5));
        let angle = q.angle_between(a).to_degrees();
        assert!((angle - 45.0).abs() < 1e-3, "{angle}");
    }
}
