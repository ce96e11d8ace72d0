//! The light block: one light as every uniform that carries one holds it, defined once here and
//! once in `shaders/lib/shadow.wgsl` (struct `Light`), filled once from what a shadow map
//! carries ([`LightBlock::of_map`]).

use super::Matrices;
use crate::scene::LocalLight;

crate::uniforms! {
    /// One light in a uniform buffer (WGSL struct `Light` of `shaders/lib/shadow.wgsl`, 128
    /// bytes, a member at a 16-byte offset of the uniform that holds it): kind, placement, cone,
    /// radiance and the matrices of its shadow map. The scattering, compositing and light-map
    /// solving uniforms each hold one as their member `light`.
    pub struct LightBlock as "Light" {
        /// World → clip of the light's map: the sun's orthographic box or a spot's perspective
        /// (a point light's cube atlas is addressed by direction: identity).
        pub view_proj: [[f32; 4]; 4],
        /// A spot's or point light's position, m (the sun: 0).
        pub position: [f32; 3],
        /// [`LightBlock::DIRECTIONAL`], [`LightBlock::SPOT`] or [`LightBlock::POINT`].
        pub kind: u32,
        /// The unit direction the light shines: the sun's travel (towards the sun is its
        /// negation, [`LightBlock::to_sun`]) or a spot's axis (a point light: −y, unused).
        pub direction: [f32; 3],
        /// cos of a spot's inner cone half-angle (others: −1).
        pub cos_inner: f32,
        /// Colour × intensity reaching the node: W/m² for the sun, W/sr for a spot or point
        /// light (times the node's own tint and intensity where it has them).
        pub radiance: [f32; 3],
        /// cos of a spot's outer cone half-angle (others: −1).
        pub cos_outer: f32,
        /// A spot's or point light's range, m (0: unlimited).
        pub range: f32,
        /// Distance along a lamp map's axis of depth 0, m (the sun: 0).
        pub near: f32,
        /// Distance along a lamp map's axis of depth 1, m (the sun: 1).
        pub far: f32,
        /// Padding.
        pub _pad: u32,
    }
}

impl LightBlock {
    /// `kind` of a directional light (the sun).
    pub const DIRECTIONAL: u32 = 0;
    /// `kind` of a spot light.
    pub const SPOT: u32 = 1;
    /// `kind` of a point light.
    pub const POINT: u32 = 2;

    /// The light a shadow map carries (`light`: the map's matrices, radiance and lamp).
    pub fn of_map(light: &Matrices) -> Self {
        let local = light.local;
        LightBlock {
            view_proj: light.view_proj().to_cols_array_2d(),
            position: local.map_or([0.0; 3], |l| l.position),
            kind: local.map_or(Self::DIRECTIONAL, |l| {
                if l.point {
                    Self::POINT
                } else {
                    Self::SPOT
                }
            }),
            direction: match local {
                Some(l) => l.direction,
                None => (-light.backward()).to_array(),
            },
            cos_inner: local.map_or(-1.0, |l| l.cos_inner),
            radiance: light.radiance,
            cos_outer: local.map_or(-1.0, |l| l.cos_outer),
            range: local.map_or(0.0, |l| l.range),
            near: local.map_or(0.0, |l| l.near),
            far: local.map_or(1.0, |l| l.far),
            _pad: 0,
        }
    }

    /// The unit direction towards the sun (a directional light's −`direction`).
    pub fn to_sun(&self) -> glam::Vec3 {
        -glam::Vec3::from(self.direction)
    }

    /// The spot or point light (`None`: the sun).
    pub fn local(&self) -> Option<LocalLight> {
        (self.kind != Self::DIRECTIONAL).then_some(LocalLight {
            point: self.kind == Self::POINT,
            position: self.position,
            direction: self.direction,
            cos_inner: self.cos_inner,
            cos_outer: self.cos_outer,
            range: self.range,
            near: self.near,
            far: self.far,
        })
    }
}
