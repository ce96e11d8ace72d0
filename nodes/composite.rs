//! `Composite`: surfaces lit by the sun (Lambert) and an ambient term, shadowed with the
//! ORIGINAL shadow map on its own port, seen through the medium, plus the in-scatter (SPEC §1).
//!
//! `out = ((albedo · (ambient + E · M · max(0, n·l) · S) or sky) · T + L_scat) · T_air + L_air`,
//! with `T_air`, `L_air` the atmosphere's transmittance and in-scatter (`Sky`: on the background
//! T_air = 0 and L_air is the sky; 1 and 0 when unconnected), `E` the sun's
//! radiance carried by the shadow map, `S` the surface shadow (percentage-closer filtered over
//! (2·pcf + 1)² texels), `T` the transmittance (1 when unconnected), `L_scat` the in-scatter
//! (0 when unconnected), `M` the light map's colour at the surface point (1 when unconnected:
//! the same light-space texture SingleScattering multiplies the medium's light by, so sunlit
//! patches under stained glass take its colours too). Surface shadows always use the
//! unmodified map: only the scattering sees a manipulated one. When the map is a spot's or
//! point light's, `E · max(0, n·l)` becomes `I · a(x) · max(0, n·l(x))`: its intensity (W/sr)
//! times glTF's falloff at the surface point (inverse square, cone, range) and l(x) the
//! direction from the point to the light. With `light_transmittance` connected (SingleScattering's
//! output of that name, with a density) the direct light is also multiplied by the light's
//! transmittance through the smoke seen from the surface point towards the light — read at the
//! point inside the density's box, where the ray towards the light enters the box from outside,
//! 1 when it misses it: the ground under a plume lies in its shadow. Several lights: one `Composite` per light, summed
//! (`Math`, `op = add`), with the ambient in one of them.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `albedo`, `normal` | in | Image (required, from GBuffer) |
//! | `depth` | in | Depth (required, from GBuffer) |
//! | `shadow` | in | ShadowMap (required: the original map) |
//! | `inscatter` | in | Image (optional) |
//! | `transmittance` | in | Scalar (optional) |
//! | `aerial_transmittance`, `aerial_inscatter` | in | Image (optional, from `Sky`) |
//! | `light_map` | in | LightMap (optional, from `LightMap`) |
//! | `light_transmittance` | in | Volume (optional, from `SingleScattering` with a density) |
//! | `image` | out | Image (linear RGB, alpha 1) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `ambient` | Colour | (0.04, 0.05, 0.07, 1) | 0…1e6 | ambient light on surfaces |
//! | `sky` | Colour | (0.2, 0.27, 0.38, 1) | 0…1e6 | radiance of sky pixels behind the medium |
//! | `bias` | Float | 0.002 | 0…0.1 | depth bias of the surface shadow test |
//! | `pcf` | Int | 1 | 0…4 texels | radius of the surface shadow filter |

use std::sync::Arc;

use super::util::placeholder;
use tyndall_engine::eval::{
    LightBlock, Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx,
};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `Composite` node kind.
pub struct Composite;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        ambient: [f32; 4] = ParamSpec::colour("ambient", [0.04, 0.05, 0.07, 1.0], 0.0, 1e6, "linear RGB", "Ambient light on surfaces."),
        sky: [f32; 4] = ParamSpec::colour("sky", [0.2, 0.27, 0.38, 1.0], 0.0, 1e6, "linear RGB", "Radiance of sky pixels."),
        bias: f32 = ParamSpec::float("bias", 0.002, 0.0, 0.1, "depth", "Surface shadow bias in light-space depth."),
        pcf: i64 = ParamSpec::int("pcf", 1, 0, 4, "texels", "Radius of the surface shadow filter.").light_texels(),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Composite",
    category: "Scattering",
    doc: "Lambert + ambient surfaces shadowed with the original shadow map, attenuated by the medium, plus in-scatter.",
    inputs: &[
        PortSpec::required("albedo", &[PortType::Image], "Surface colour (GBuffer)."),
        PortSpec::required("normal", &[PortType::Image], "Surface normal (GBuffer)."),
        PortSpec::required("depth", &[PortType::Depth], "Camera linear depth (GBuffer)."),
        PortSpec::required("shadow", &[PortType::ShadowMap], "The ORIGINAL shadow map, for surface shadows."),
        PortSpec::input("inscatter", &[PortType::Image], "In-scattered light added on top."),
        PortSpec::input("transmittance", &[PortType::Scalar], "Attenuation of surfaces by the medium."),
        PortSpec::input("aerial_transmittance", &[PortType::Image], "Per-channel attenuation by the atmosphere (Sky.transmittance), applied last."),
        PortSpec::input("aerial_inscatter", &[PortType::Image], "The atmosphere's in-scatter and sky (Sky.inscatter), added last."),
        PortSpec::input("light_map", &[PortType::LightMap], "Light map multiplying the sun on surfaces (unconnected: 1), as SingleScattering.light_map does for the medium."),
        PortSpec::input("light_transmittance", &[PortType::Volume], "The light's transmittance through a density (SingleScattering.light_transmittance): surfaces under the smoke are shadowed by it (unconnected: 1)."),
    ],
    outputs: &[PortSpec::output("image", &[PortType::Image], "Linear radiance.")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[CompositeParams::LAYOUT, LightBlock::LAYOUT]);

const SHADER: Shader = crate::shader("composite", include_str!("../shaders/composite.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/composite.wgsl` (struct `Params`).
    pub struct CompositeParams as "Params" {
        /// Camera clip → world.
        pub inv_view_proj: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// PCF radius.
        pub pcf: u32,
        /// Shadow bias.
        pub bias: f32,
        /// 1 when in-scatter is connected.
        pub has_inscatter: u32,
        /// 1 when transmittance is connected.
        pub has_transmittance: u32,
        /// 1 when aerial_transmittance is connected.
        pub has_aerial_transmittance: u32,
        /// 1 when aerial_inscatter is connected.
        pub has_aerial_inscatter: u32,
        /// 1 when a light map is connected.
        pub has_light_map: u32,
        /// 1 when a light transmittance volume is connected.
        pub has_light_transmittance: u32,
        /// Padding.
        pub _pad1: u32,
        /// Ambient colour.
        pub ambient: [f32; 4],
        /// Sky colour.
        pub sky: [f32; 4],
        /// World → light-map clip (identity without one).
        pub light_map_view_proj: [[f32; 4]; 4],
        /// The light transmittance volume's box, low corner, m.
        pub tr_lo: [f32; 3],
        /// Padding.
        pub _pad2: u32,
        /// High corner, m.
        pub tr_hi: [f32; 3],
        /// Padding.
        pub _pad3: u32,
        /// The shadow map's light: the sun, or a spot or point light lighting each point by
        /// its falloff and direction.
        pub light: LightBlock,
    }
}

/// What [`reference()`] reads: the node's inputs as rasters with their matrices.
pub struct RefInputs<'a> {
    /// `albedo` (RGBA; alpha > 0.5: geometry).
    pub albedo: &'a Raster,
    /// `normal` (RGB).
    pub normal: &'a Raster,
    /// `depth` (camera linear depth) and the camera.
    pub depth: (&'a Raster, &'a Matrices),
    /// `shadow` (light-space depth) and the light.
    pub shadow: (&'a Raster, &'a Matrices),
    /// `inscatter` (RGB), if connected.
    pub inscatter: Option<&'a Raster>,
    /// `transmittance` (one channel), if connected.
    pub transmittance: Option<&'a Raster>,
    /// `aerial_transmittance` (RGB), if connected.
    pub aerial_transmittance: Option<&'a Raster>,
    /// `aerial_inscatter` (RGB), if connected.
    pub aerial_inscatter: Option<&'a Raster>,
    /// `light_map` (RGB) and its projection, if connected.
    pub light_map: Option<(&'a Raster, &'a Matrices)>,
    /// `light_transmittance`, if connected.
    pub light_transmittance: Option<&'a crate::algorithms::box_volume::BoxVolume>,
}

/// CPU reference of the node (the formula of the module docs, as `shaders/composite.wgsl`
/// computes it): `ambient`, `sky` (rgb), `bias` and `pcf` as the parameters.
pub fn reference(i: &RefInputs, ambient: [f32; 3], sky: [f32; 3], bias: f32, pcf: i32) -> Raster {
    use crate::algorithms::shader_lib::{bilinear_texels, light_uvz};
    let (depth, cam) = i.depth;
    let (shadow, light) = i.shadow;
    let (w, h) = (depth.width, depth.height);
    let (inv, eye) = (cam.view_proj().inverse(), cam.eye());
    let (lvp, to_sun) = (light.view_proj(), light.backward());
    let surface_shadow = |x: glam::Vec3| {
        let uvz = match light.local {
            Some(l) => l.uvz(lvp, x).unwrap_or(glam::Vec3::new(-1.0, -1.0, 2.0)),
            None => light_uvz(lvp, x),
        };
        let (sw, sh) = (shadow.width as i32, shadow.height as i32);
        let cx = (uvz.x * sw as f32).floor() as i32;
        let cy = (uvz.y * sh as f32).floor() as i32;
        let mut lit = 0.0f32;
        let mut n = 0.0f32;
        for dy in -pcf..=pcf {
            for dx in -pcf..=pcf {
                let (tx, ty) = (cx + dx, cy + dy);
                n += 1.0;
                let outside = tx < 0 || ty < 0 || tx >= sw || ty >= sh;
                if outside || uvz.z <= shadow.pixel(tx as u32, ty as u32)[0] + bias {
                    lit += 1.0;
                }
            }
        }
        lit / n
    };
    let sun_colour = |x: glam::Vec3| match i.light_map {
        None => [1.0f32; 3],
        Some((map, m)) => {
            let c = m.view_proj() * x.extend(1.0);
            let uv = [c.x / c.w * 0.5 + 0.5, 0.5 - c.y / c.w * 0.5];
            let v = bilinear_texels(map, [uv[0] * map.width as f32, uv[1] * map.height as f32]);
            [v[0], v[1], v[2]]
        }
    };
    let mut out = Raster::new(w, h, 4, 1.0);
    for y in 0..h {
        for x in 0..w {
            let a = i.albedo.pixel(x, y);
            let mut colour = if a[3] > 0.5 {
                let dir = tyndall_engine::eval::pixel_ray(inv, eye, x, y, w, h);
                let p = eye + dir * depth.pixel(x, y)[0];
                let nrm = i.normal.pixel(x, y);
                let (to_light, falloff) = match light.local {
                    Some(l) => ((l.position() - p).normalize(), l.falloff(p)),
                    None => (to_sun, 1.0),
                };
                let lambert = glam::Vec3::new(nrm[0], nrm[1], nrm[2])
                    .dot(to_light)
                    .max(0.0)
                    * falloff;
                let through = i.light_transmittance.map_or(1.0, |v| match light.local {
                    Some(l) => v.towards(p, to_light, (l.position() - p).length()),
                    None => v.towards(p, to_light, f32::MAX),
                });
                let (m, s) = (sun_colour(p), surface_shadow(p) * through);
                std::array::from_fn(|c| {
                    a[c] * (ambient[c] + light.radiance[c] * m[c] * lambert * s)
                })
            } else {
                sky
            };
            let each = |colour: &mut [f32; 3], r: Option<&Raster>, f: fn(f32, f32) -> f32| {
                if let Some(r) = r {
                    let v = r.pixel(x, y);
                    for (c, value) in colour.iter_mut().enumerate() {
                        // One-channel inputs (transmittance) apply to every channel.
                        *value = f(*value, v[c.min(v.len() - 1)]);
                    }
                }
            };
            each(&mut colour, i.transmittance, |a, b| a * b);
            each(&mut colour, i.inscatter, |a, b| a + b);
            each(&mut colour, i.aerial_transmittance, |a, b| a * b);
            each(&mut colour, i.aerial_inscatter, |a, b| a + b);
            let o = &mut out.data[((y * w + x) * 4) as usize..][..3];
            o.copy_from_slice(&colour);
        }
    }
    out
}

impl NodeKind for Composite {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let albedo = ctx.require_texture("albedo")?;
        let normal = ctx.require_texture("normal")?;
        let (depth, cam) = ctx.depth("depth")?;
        let (shadow, light) = ctx.shadow_map("shadow")?;
        let (w, h) = (depth.width, depth.height);
        for (port, t) in [("albedo", &albedo), ("normal", &normal)] {
            if (t.width, t.height) != (w, h) {
                return Err(NodeError::Input {
                    port: port.into(),
                    message: format!("size {}x{} differs from depth's {w}x{h}", t.width, t.height),
                });
            }
        }
        let dummy = placeholder(ctx)?;
        let inscatter = ctx.input("inscatter").and_then(|v| v.texture().cloned());
        let transmittance = ctx
            .input("transmittance")
            .and_then(|v| v.texture().cloned());
        let aerial_t = ctx
            .input("aerial_transmittance")
            .and_then(|v| v.texture().cloned());
        let aerial_l = ctx
            .input("aerial_inscatter")
            .and_then(|v| v.texture().cloned());
        let light_map = ctx.light_map_opt("light_map")?;
        let light_tr = ctx.volume_opt("light_transmittance")?;
        let tr_box = light_tr.as_ref().map_or([[0.0; 3]; 2], |(_, b)| *b);
        let u = CompositeParams {
            inv_view_proj: cam.view_proj().inverse().to_cols_array_2d(),
            eye: cam.eye().to_array(),
            pcf: p.pcf as u32,
            bias: p.bias,
            has_inscatter: inscatter.is_some() as u32,
            has_transmittance: transmittance.is_some() as u32,
            has_aerial_transmittance: aerial_t.is_some() as u32,
            has_aerial_inscatter: aerial_l.is_some() as u32,
            has_light_map: light_map.is_some() as u32,
            has_light_transmittance: light_tr.is_some() as u32,
            _pad1: 0,
            ambient: p.ambient,
            sky: p.sky,
            light_map_view_proj: light_map
                .as_ref()
                .map_or(glam::Mat4::IDENTITY, |(_, m)| m.view_proj())
                .to_cols_array_2d(),
            tr_lo: tr_box[0],
            _pad2: 0,
            tr_hi: tr_box[1],
            _pad3: 0,
            light: LightBlock::of_map(&light),
        };
        let no_volume;
        let light_tr_volume = match &light_tr {
            Some((v, _)) => &**v,
            None => {
                no_volume = ctx.gpu.volume([1, 1, 1])?;
                &no_volume
            }
        };
        let out = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        let ins = inscatter.unwrap_or_else(|| dummy.clone());
        let tr = transmittance.unwrap_or_else(|| dummy.clone());
        let at = aerial_t.unwrap_or_else(|| dummy.clone());
        let lm = light_map.map_or_else(|| dummy.clone(), |(t, _)| t);
        let al = aerial_l.unwrap_or(dummy);
        ctx.gpu.dispatch(
            SHADER,
            "composite",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("light_tr", Bind::Volume(light_tr_volume)),
                ("albedo", Bind::Texture(&albedo)),
                ("normal", Bind::Texture(&normal)),
                ("depth", Bind::Texture(&depth)),
                ("shadow", Bind::Texture(&shadow)),
                ("inscatter", Bind::Texture(&ins)),
                ("transmittance", Bind::Texture(&tr)),
                ("out_image", Bind::Storage(&out)),
                ("aerial_transmittance", Bind::Texture(&at)),
                ("aerial_inscatter", Bind::Texture(&al)),
                ("light_map", Bind::Texture(&lm)),
            ],
            w,
            h,
        )?;
        ctx.set("image", PortValue::Image(Arc::new(out)));
        Ok(())
    }
}
