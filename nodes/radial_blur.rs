//! `RadialBlur`: seed 003 Algorithm 1 (after GPU Gems 3 ch. 13), the screen-space light-shaft
//! post-process game artists know — the baseline the physical and stylised shafts are compared
//! with.
//!
//! p = the pixel centre, Δ = (p − light)·density/samples; for i = 0…samples−1: p −= Δ,
//! sum += bilinear(p)·decay^i·weight; `image` = sum·exposure. Pixel coordinates, texel centres
//! at i + 0.5, bilinear between texel centres, clamped to the edge. The light is at
//! (`light_x`, `light_y`) pixels, or — with a `scene` connected — at the position of the
//! scene's light `light` (empty: its first directional light, the sun, else its first light)
//! seen by the scene's camera: a directional
//! light's the projection of the direction to it, a spot's or point light's the projection of
//! its position (either may lie off screen; one behind the camera gives a mirrored position, as
//! the screen-space method does). A `light` the scene lacks is refused, naming its lights.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `occlusion` | in | Image \| Scalar (required) | bright where the light is seen |
//! | `scene` | in | Scene | places the light at the screen position of its light `light` |
//! | `image` | out | same type as `occlusion` | |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `light_x`, `light_y` | Float | 480, 100 | ±1e6 px | light position (no `scene`) |
//! | `light` | Text | "" | | with a `scene`: which of its lights (empty: the first directional one, else the first; a name or an index) |
//! | `samples` | Int | 64 | 1…1024 | samples per pixel (quality knob) |
//! | `density` | Float | 0.9 | 0…10 | fraction of the way to the light covered |
//! | `decay` | Float | 0.96 | 0…1 | per-sample falloff |
//! | `weight` | Float | 0.4 | 0…1e3 | per-sample weight |
//! | `exposure` | Float | 0.1 | 0…1e3 | output scale |

use std::sync::Arc;

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `RadialBlur` node kind.
pub struct RadialBlur;

const IMG: &[PortType] = &[PortType::Scalar, PortType::Image];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        light_x: f32 = ParamSpec::float("light_x", 480.0, -1e6, 1e6, "px", "Light position x in pixels (pixel centres at i + 0.5)."),
        light_y: f32 = ParamSpec::float("light_y", 100.0, -1e6, 1e6, "px", "Light position y in pixels (down)."),
        light: String = ParamSpec::text("light", "", "With a scene: the light whose screen position the blur converges on (empty: the scene's first directional light, else its first light; or a name or an index). A light the scene lacks is refused, naming its lights."),
        samples: i64 = ParamSpec::int("samples", 64, 1, 1024, "samples", "Samples per pixel (quality knob)."),
        density: f32 = ParamSpec::float("density", 0.9, 0.0, 10.0, "", "Fraction of the way to the light the samples cover."),
        decay: f32 = ParamSpec::float("decay", 0.96, 0.0, 1.0, "", "Falloff per sample."),
        weight: f32 = ParamSpec::float("weight", 0.4, 0.0, 1e3, "", "Weight of each sample."),
        exposure: f32 = ParamSpec::float("exposure", 0.1, 0.0, 1e3, "", "Scales the sum."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "RadialBlur",
    category: "Scattering",
    doc: "Screen-space radial blur towards the light (seed 003 Algorithm 1): the classic post-process light shafts, as a baseline.",
    inputs: &[
        PortSpec::required("occlusion", IMG, "Bright where the light is seen (e.g. the sky and sun, black occluders)."),
        PortSpec::input("scene", &[PortType::Scene], "Places the light at the screen position of the scene's light `light` (overrides light_x, light_y)."),
    ],
    outputs: &[PortSpec::output("image", IMG, "The blurred shafts, same type as `occlusion`.")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[RadialParams::LAYOUT]);

const SHADER: Shader = crate::shader("radial_blur", include_str!("../shaders/radial_blur.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/radial_blur.wgsl` (struct `Params`).
    pub struct RadialParams as "Params" {
        /// Light position, pixels.
        pub light: [f32; 2],
        /// Samples per pixel.
        pub samples: u32,
        /// Density.
        pub density: f32,
        /// Decay per sample.
        pub decay: f32,
        /// Weight per sample.
        pub weight: f32,
        /// Output scale.
        pub exposure: f32,
        /// Padding.
        pub _pad0: u32,
    }
}

use crate::algorithms::shader_lib::bilinear_texels as bilinear;

/// CPU reference of the node.
pub fn reference(src: &Raster, p: &RadialParams) -> Raster {
    let mut out = src.clone();
    let c = src.channels as usize;
    for y in 0..src.height {
        for x in 0..src.width {
            let mut q = [x as f32 + 0.5, y as f32 + 0.5];
            let n = p.samples as f32;
            let d = [
                (q[0] - p.light[0]) * p.density / n,
                (q[1] - p.light[1]) * p.density / n,
            ];
            let mut sum = vec![0.0f32; c];
            let mut decay = 1.0f32;
            for _ in 0..p.samples {
                q = [q[0] - d[0], q[1] - d[1]];
                for (s, v) in sum.iter_mut().zip(bilinear(src, q)) {
                    *s += v * decay * p.weight;
                }
                decay *= p.decay;
            }
            let k = (y * src.width + x) as usize * c;
            for (i, s) in sum.iter().enumerate() {
                out.data[k + i] = s * p.exposure;
            }
        }
    }
    out
}

/// The position in pixels of `light` in a `w × h` view of the scene's camera: a directional
/// light's direction, a spot's or point light's position.
pub fn light_pixel(
    scene: &tyndall_engine::scene::Scene,
    light: &tyndall_engine::scene::Light,
    w: u32,
    h: u32,
) -> [f32; 2] {
    use tyndall_engine::scene::LightKind;
    let cam = scene.camera;
    let vp = cam.proj(w as f32 / h as f32) * cam.view();
    let at = match (light.kind, light.as_sun()) {
        (LightKind::Spot { position, .. } | LightKind::Point { position }, _) => position,
        (_, Some(sun)) => cam.position + sun.to_sun() * cam.far * 0.5,
        (_, None) => cam.target,
    };
    let c = vp * at.extend(1.0);
    let w_ = if c.w.abs() < 1e-12 { 1e-12 } else { c.w };
    [
        (c.x / w_ * 0.5 + 0.5) * w as f32,
        (0.5 - c.y / w_ * 0.5) * h as f32,
    ]
}

impl NodeKind for RadialBlur {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let prm = Params::from_ctx(ctx)?;
        let src = ctx.require_texture("occlusion")?;
        if src.format == TexFormat::Rg32F {
            return Err(NodeError::Input {
                port: "occlusion".into(),
                message: "has an internal two-channel format".into(),
            });
        }
        let light = match ctx.scene_opt("scene")? {
            Some(scene) => {
                // Empty: the first directional light (the sun), as before lamps came in, else
                // the first light.
                let first_sun = (prm.light.trim().is_empty())
                    .then(|| scene.scene.lights.iter().find(|l| l.as_sun().is_some()))
                    .flatten()
                    .cloned();
                let light =
                    match first_sun {
                        Some(l) => l,
                        None => scene.scene.find_light(&prm.light).map_err(|message| {
                            NodeError::Param {
                                param: "light".into(),
                                message,
                            }
                        })?,
                    };
                light_pixel(&scene.scene, &light, src.width, src.height)
            }
            None => [prm.light_x, prm.light_y],
        };
        let p = RadialParams {
            light,
            samples: prm.samples as u32,
            density: prm.density,
            decay: prm.decay,
            weight: prm.weight,
            exposure: prm.exposure,
            _pad0: 0,
        };
        let out = ctx.gpu.texture(src.width, src.height, src.format)?;
        let (entry, slot) = if src.format == TexFormat::R32F {
            ("radial_scalar", "out_scalar")
        } else {
            ("radial_image", "out_image")
        };
        ctx.gpu.dispatch(
            SHADER,
            entry,
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&p))),
                ("src", Bind::Texture(&src)),
                (slot, Bind::Storage(&out)),
            ],
            src.width,
            src.height,
        )?;
        ctx.set("image", super::util::image_like(Arc::new(out)));
        Ok(())
    }
}
