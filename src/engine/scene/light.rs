//! Lights other than the sun: spot and point lights (glTF `KHR_lights_punctual`), with the
//! attenuation glTF recommends, and the projections of their shadow maps (a perspective map over
//! a spot's cone, six 90° faces for a point light).
//!
//! Units. A directional light's intensity is irradiance in W/m² (a glTF file's lux / 683); a
//! spot or point light's is radiant intensity in W/sr (a glTF file's candela / 683, what
//! Blender's exporter writes for a lamp of P watts in its *Standard* mode: P / 4π · 683 cd).
//! A local light lights a point at distance d with I · a(d) · c(θ): `a` the inverse square
//! law windowed by `range` (glTF: `clamp(1 − (d/range)⁴, 0, 1) / d²`), `c` a spot's smooth
//! cone (glTF: `s²` with `s = clamp((cos θ − cos outer) / (cos inner − cos outer), 0, 1)`).

use glam::{Mat4, Vec3};

use super::Sun;

/// What kind of light, and where it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightKind {
    /// A directional light (the sun), given by the direction towards it.
    Directional {
        /// Degrees clockwise from +Z seen from above.
        azimuth: f32,
        /// Degrees above the horizon.
        elevation: f32,
    },
    /// A spot light at `position` shining along `direction` (unit), full intensity inside
    /// `inner`, none outside `outer` (half-angles, radians, 0 < inner ≤ outer ≤ π/2).
    Spot {
        /// World position, m.
        position: Vec3,
        /// Unit direction the spot points to.
        direction: Vec3,
        /// Inner cone half-angle, radians.
        inner: f32,
        /// Outer cone half-angle, radians.
        outer: f32,
    },
    /// A point light at `position`, shining equally in every direction.
    Point {
        /// World position, m.
        position: Vec3,
    },
}

/// One light of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    /// The name a `ShadowMap`'s `light` parameter finds it by (the glTF node's name).
    pub name: String,
    /// Kind and placement.
    pub kind: LightKind,
    /// Linear RGB colour.
    pub colour: [f32; 3],
    /// W/m² for a directional light, W/sr for a spot or point light (multiplies the colour).
    pub intensity: f32,
    /// Distance (m) beyond which a spot or point light gives nothing (`None`: unlimited).
    pub range: Option<f32>,
}

impl Light {
    /// The sun as a light named `name`.
    pub fn sun(name: &str, sun: Sun) -> Light {
        Light {
            name: name.to_string(),
            kind: LightKind::Directional {
                azimuth: sun.azimuth,
                elevation: sun.elevation,
            },
            colour: sun.colour,
            intensity: sun.intensity,
            range: None,
        }
    }

    /// This light as the sun, when it is directional.
    pub fn as_sun(&self) -> Option<Sun> {
        match self.kind {
            LightKind::Directional { azimuth, elevation } => Some(Sun {
                azimuth,
                elevation,
                colour: self.colour,
                intensity: self.intensity,
            }),
            _ => None,
        }
    }

    /// `directional`, `spot` or `point`.
    pub fn type_name(&self) -> &'static str {
        match self.kind {
            LightKind::Directional { .. } => "directional",
            LightKind::Spot { .. } => "spot",
            LightKind::Point { .. } => "point",
        }
    }

    /// Colour × intensity, per channel.
    pub fn radiance(&self) -> [f32; 3] {
        self.colour.map(|c| c * self.intensity)
    }

    /// The light as a shadow map's lookups need it (`None` for a directional light).
    pub fn local(&self, bounds: (Vec3, Vec3)) -> Option<LocalLight> {
        let (position, direction, cos) = match self.kind {
            LightKind::Directional { .. } => return None,
            LightKind::Spot {
                position,
                direction,
                inner,
                outer,
            } => (position, direction, [inner.cos(), outer.cos()]),
            LightKind::Point { position } => (position, Vec3::NEG_Y, [-1.0, -1.0]),
        };
        let (near, far) = depth_range(position, bounds);
        Some(LocalLight {
            point: matches!(self.kind, LightKind::Point { .. }),
            position: position.to_array(),
            direction: direction.normalize_or(Vec3::NEG_Y).to_array(),
            cos_inner: cos[0],
            cos_outer: cos[1],
            range: self.range.unwrap_or(0.0),
            near,
            far,
        })
    }

    /// One line for `tyndall validate`: name, kind, intensity with its unit, placement.
    pub fn describe(&self) -> String {
        let c = self.colour;
        let colour = format!("colour ({:.3}, {:.3}, {:.3})", c[0], c[1], c[2]);
        let range = self
            .range
            .map_or(String::new(), |r| format!(", range {r} m"));
        match self.kind {
            LightKind::Directional { azimuth, elevation } => format!(
                "light '{}': directional, {} W/m², {colour}, azimuth {azimuth:.1}°, elevation {elevation:.1}°",
                self.name, self.intensity
            ),
            LightKind::Spot {
                position,
                direction,
                inner,
                outer,
            } => format!(
                "light '{}': spot, {} W/sr, {colour}, at ({:.3}, {:.3}, {:.3}) towards ({:.3}, {:.3}, {:.3}), cone {:.1}°–{:.1}°{range}",
                self.name,
                self.intensity,
                position.x,
                position.y,
                position.z,
                direction.x,
                direction.y,
                direction.z,
                inner.to_degrees(),
                outer.to_degrees()
            ),
            LightKind::Point { position } => format!(
                "light '{}': point, {} W/sr, {colour}, at ({:.3}, {:.3}, {:.3}){range}",
                self.name, self.intensity, position.x, position.y, position.z
            ),
        }
    }

    /// Why this light cannot be used: a negative or non-finite intensity, a zero or negative
    /// range, a cone that is not 0 < inner ≤ outer ≤ 90°.
    pub fn problem(&self) -> Option<String> {
        if !self.intensity.is_finite() || self.intensity < 0.0 {
            return Some(format!(
                "light '{}': intensity {} (must be ≥ 0)",
                self.name, self.intensity
            ));
        }
        if let Some(r) = self.range {
            if !(r > 0.0 && r.is_finite()) {
                return Some(format!("light '{}': range {r} (must be > 0 m)", self.name));
            }
        }
        if let LightKind::Spot { inner, outer, .. } = self.kind {
            let right = std::f32::consts::FRAC_PI_2 + 1e-6;
            if !(outer > 0.0 && outer <= right && (0.0..=outer).contains(&inner)) {
                return Some(format!(
                    "light '{}': cone inner {:.3}°, outer {:.3}° (must be 0 ≤ inner ≤ outer, 0 < outer ≤ 90°)",
                    self.name,
                    inner.to_degrees(),
                    outer.to_degrees()
                ));
            }
        }
        None
    }
}

/// The light a shadow map of a spot or point light carries: what scattering and lighting need
/// besides its matrices. Plain numbers, so it travels with the map's metadata.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalLight {
    /// A point light (six faces in a 3 × 2 atlas), else a spot (one perspective map).
    pub point: bool,
    /// World position, m.
    pub position: [f32; 3],
    /// A spot's unit direction.
    pub direction: [f32; 3],
    /// cos of the inner cone half-angle (−1 for a point light).
    pub cos_inner: f32,
    /// cos of the outer cone half-angle (−1 for a point light).
    pub cos_outer: f32,
    /// Range in m, 0 for unlimited.
    pub range: f32,
    /// Distance along the map's axis where its depth is 0, m.
    pub near: f32,
    /// Distance along the map's axis where its depth is 1, m.
    pub far: f32,
}

impl LocalLight {
    /// The light's world position.
    pub fn position(&self) -> Vec3 {
        Vec3::from(self.position)
    }

    /// glTF's attenuation at world point `x`: inverse square, windowed by the range, times a
    /// spot's cone (multiply by the light's radiance for the irradiance at `x`, W/m²).
    pub fn falloff(&self, x: Vec3) -> f32 {
        let l = self.position() - x;
        let d2 = l.length_squared().max(1e-12);
        let mut a = 1.0 / d2;
        if self.range > 0.0 {
            let q = d2 / (self.range * self.range);
            a *= (1.0 - q * q).clamp(0.0, 1.0);
        }
        if !self.point {
            let cd = Vec3::from(self.direction).dot(-l / d2.sqrt());
            let s = ((cd - self.cos_outer) / (self.cos_inner - self.cos_outer).max(1e-3))
                .clamp(0.0, 1.0);
            a *= s * s;
        }
        a
    }

    /// Light-space (u, v, depth) of world point `x` in this light's map (u, v in [0, 1] across
    /// the whole texture, v down; depth in [0, 1] from `near` to `far`), given the spot map's
    /// world → clip `view_proj`; `None` behind a spot. The CPU twin of `shaders/lib/shadow.wgsl`'s
    /// `local_uvz`.
    pub fn uvz(&self, view_proj: Mat4, x: Vec3) -> Option<Vec3> {
        if self.point {
            let d = x - self.position();
            let face = cube_face(d);
            let (f, s, u) = face_basis(face);
            let depth = f.dot(d);
            let ndc = glam::Vec2::new(s.dot(d), u.dot(d)) / depth.max(1e-12);
            let uv = glam::Vec2::new(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5)
                .clamp(glam::Vec2::ZERO, glam::Vec2::splat(0.999_999));
            let (col, row) = ((face % 3) as f32, (face / 3) as f32);
            return Some(Vec3::new(
                (col + uv.x) / 3.0,
                (row + uv.y) / 2.0,
                (depth - self.near) / (self.far - self.near),
            ));
        }
        let c = view_proj * x.extend(1.0);
        (c.w > 1e-9).then(|| Vec3::new(c.x / c.w * 0.5 + 0.5, 0.5 - c.y / c.w * 0.5, c.z))
    }
}

/// Distances along any axis from `position` within which the scene's bounds lie, as a
/// shadow map's depth range: far the farthest corner, near a thousandth of it.
fn depth_range(position: Vec3, (lo, hi): (Vec3, Vec3)) -> (f32, f32) {
    let mut far = 1e-3f32;
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        far = far.max((c - position).length());
    }
    let far = far * 1.001;
    (far * 1e-3, far)
}

/// Which face of a cube map a direction `d` from the light falls on: 0 +X, 1 −X, 2 +Y, 3 −Y,
/// 4 +Z, 5 −Z (ties to the lower index), laid out in the atlas at column `face % 3`, row
/// `face / 3`.
pub fn cube_face(d: Vec3) -> usize {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        usize::from(d.x < 0.0)
    } else if a.y >= a.z {
        2 + usize::from(d.y < 0.0)
    } else {
        4 + usize::from(d.z < 0.0)
    }
}

/// Forward, right and up unit vectors of cube face `face` (see [`cube_face`]): the view a
/// face's map is rendered from, as `look_at` builds it (up +Y, or +Z for the ±Y faces).
pub fn face_basis(face: usize) -> (Vec3, Vec3, Vec3) {
    let (f, up) = match face {
        0 => (Vec3::X, Vec3::Y),
        1 => (Vec3::NEG_X, Vec3::Y),
        2 => (Vec3::Y, Vec3::Z),
        3 => (Vec3::NEG_Y, Vec3::Z),
        4 => (Vec3::Z, Vec3::Y),
        _ => (Vec3::NEG_Z, Vec3::Y),
    };
    let s = f.cross(up).normalize();
    (f, s, s.cross(f))
}

/// A perspective projection with a square field of view of half-angle `half` (radians) whose
/// clip z is the *linear* depth `(distance along the axis − near) / (far − near)` (not divided
/// by w): rasterised, z/w still grows with distance, so the depth test orders surfaces, and the
/// map stores clip z itself. x and y are the usual `x / tan(half)`, w = distance along the axis.
pub fn local_proj(half: f32, near: f32, far: f32) -> Mat4 {
    let k = 1.0 / half.tan();
    let r = far - near;
    Mat4::from_cols(
        glam::Vec4::new(k, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, k, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, -1.0 / r, -1.0),
        glam::Vec4::new(0.0, 0.0, -near / r, 0.0),
    )
}

/// World → view of cube face `face` of a light at `position` (see [`face_basis`]).
pub fn face_view(position: Vec3, face: usize) -> Mat4 {
    let (f, s, u) = face_basis(face);
    Mat4::from_cols(
        glam::Vec4::new(s.x, u.x, -f.x, 0.0),
        glam::Vec4::new(s.y, u.y, -f.y, 0.0),
        glam::Vec4::new(s.z, u.z, -f.z, 0.0),
        glam::Vec4::new(-s.dot(position), -u.dot(position), f.dot(position), 1.0),
    )
}

/// World → view of a spot at `position` looking along `direction`.
pub fn spot_view(position: Vec3, direction: Vec3) -> Mat4 {
    let d = direction.normalize_or(Vec3::NEG_Y);
    let up = if d.cross(Vec3::Y).length_squared() < 1e-6 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    glam::camera::rh::view::look_at_mat4(position, position + d, up)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point() -> LocalLight {
        Light {
            name: "p".into(),
            kind: LightKind::Point {
                position: Vec3::new(1.0, 2.0, 3.0),
            },
            colour: [1.0; 3],
            intensity: 10.0,
            range: None,
        }
        .local((Vec3::splat(-5.0), Vec3::splat(5.0)))
        .unwrap()
    }

    #[test]
    fn a_cube_face_projects_its_own_directions_inside_its_square() {
        let l = point();
        for face in 0..6 {
            let (f, s, u) = face_basis(face);
            let view_proj = local_proj(std::f32::consts::FRAC_PI_4, l.near, l.far)
                * face_view(l.position(), face);
            for (a, b) in [(0.0, 0.0), (0.9, -0.5), (-0.7, 0.8)] {
                let x = l.position() + (f + s * a + u * b) * 2.0;
                assert_eq!(cube_face(x - l.position()), face);
                // The face's own matrices and the atlas lookup agree.
                let c = view_proj * x.extend(1.0);
                let uvz = l.uvz(Mat4::IDENTITY, x).unwrap();
                let (col, row) = ((face % 3) as f32, (face / 3) as f32);
                let u_face = c.x / c.w * 0.5 + 0.5;
                let v_face = 0.5 - c.y / c.w * 0.5;
                assert!((uvz.x - (col + u_face) / 3.0).abs() < 1e-5, "face {face}");
                assert!((uvz.y - (row + v_face) / 2.0).abs() < 1e-5, "face {face}");
                assert!((uvz.z - c.z).abs() < 1e-5, "linear depth, face {face}");
                assert!((c.w - 2.0).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn falloff_is_inverse_square_then_the_cone_then_the_range() {
        let mut l = point();
        let at = |l: &LocalLight, d: Vec3| l.falloff(l.position() + d);
        assert!((at(&l, Vec3::new(2.0, 0.0, 0.0)) - 0.25).abs() < 1e-6);
        l.range = 4.0;
        // clamp(1 − (d/range)⁴) / d² at d = 2: (1 − 1/16) / 4.
        assert!((at(&l, Vec3::new(0.0, 2.0, 0.0)) - 15.0 / 64.0).abs() < 1e-6);
        assert_eq!(at(&l, Vec3::new(0.0, 5.0, 0.0)), 0.0);
        l.range = 0.0;
        l.point = false;
        l.direction = [0.0, -1.0, 0.0];
        (l.cos_inner, l.cos_outer) = (20f32.to_radians().cos(), 30f32.to_radians().cos());
        let dir = |deg: f32| {
            let r = deg.to_radians();
            Vec3::new(r.sin(), -r.cos(), 0.0)
        };
        assert!((at(&l, dir(10.0)) - 1.0).abs() < 1e-5);
        assert_eq!(at(&l, dir(31.0)), 0.0);
        let mid = at(&l, dir(25.0));
        assert!(mid > 0.1 && mid < 0.6, "{mid}");
    }
}
