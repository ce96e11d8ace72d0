//! `ShadowMap`: light-space depth of the scene from one of its lights (SPEC §1–2; seed 003 Fig. 5
//! renders shafts of directional, spot and point lights from such maps).
//!
//! `light` chooses the light: empty = the scene's first light (the sun for every built-in scene
//! and every file lit by one), else a light's name or its index (`tyndall validate` lists them).
//! - **Directional**: the sun looks along −`to_sun`; the orthographic box is the light-space
//!   bounding box of the scene, so depth is 0 at the light's near plane and 1 at the far plane.
//! - **Spot**: a perspective map from the spot's position along its direction, over its outer
//!   cone (half-angle at most 85°; a wider cone is cut there and points outside the map count as
//!   lit). Depth is *linear*: (distance along the axis − near) / (far − near), far the farthest
//!   corner of the scene's bounds, near a thousandth of it (`scene::local_proj`).
//! - **Point**: six 90° faces (+X, −X, +Y, −Y, +Z, −Z), each `resolution`², in one 3 × 2 atlas
//!   (face f at column f mod 3, row f div 3), with the spot's linear depth along each face's axis.
//!
//! Texels no geometry covers are *clear* ([`SHADOW_CLEAR`], no depth): they shadow nothing.
//! A texel with an occluder at depth d shadows every point farther than d along its ray, at any
//! distance — past the far plane too, and outside the geometry's bounds — so the medium may
//! reach as far as it likes below the casters (a cloud deck, fog in a valley, a spot's cone far
//! past its gobo). How far the light reaches: everywhere; points outside the map's footprint
//! are lit, which is right because no caster lies there.
//!
//! The footprint (the sun's orthographic box, a lamp's near/far) is fitted to the *casters*:
//! the scene's drawn objects. The map stores occluders, so that is all it has to resolve, and a
//! medium much larger than the casters (a whole valley of fog under a few trees) costs no
//! resolution and needs no setting: the shadow of a caster is read from its texel wherever
//! along the light's ray the medium point lies. What the user sets is `resolution` for the
//! casters' detail, and `include`/`exclude` to leave out large objects that cast nothing the
//! medium can see (a distant ground plane), which shrinks the footprint. The map carries its light (matrices,
//! radiance, and for a spot or point light its position, cone, range and depth range), so
//! scattering and lighting downstream use the right one. With `include`/`exclude`
//! (comma-separated tags) only some objects are drawn, so tagged objects can get a map of their
//! own.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `scene` | in | Scene (required) |
//! | `map` | out | ShadowMap (depth + light matrices + radiance + the light) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `resolution` | Int | 2048 | 16…16384 texels | map size (square; a point light's atlas is 3 × 2 of these); beyond the device limit: an error naming the limit |
//! | `light` | Text | "" | | the light: empty = the first, a name or an index |
//! | `include` | Text | "" | | only objects with one of these tags (empty: all) |
//! | `exclude` | Text | "" | | leave out objects with any of these tags |
//! | `method` | Choice | raster | raster, ray_cast | the graphics pipeline, or a compute pass casting a ray per texel through a BVH of the drawn objects ([`crate::algorithms::ray_cast`]); the same map but for texels centred exactly on an edge two triangles share |

use std::sync::Arc;

use tyndall_engine::eval::{
    Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx, SHADOW_CLEAR,
};
use tyndall_engine::gpu::{MeshDraw, RasterTarget, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::scene::{face_view, fit_light, local_proj, spot_view, LightKind, ScenePart};

use crate::algorithms::ray_cast::{self, Method};

/// The `ShadowMap` node kind.
pub struct ShadowMapNode;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        resolution: i64 = ParamSpec::int("resolution", 2048, 16, 16384, "texels", "Width and height of the map.").light_texels(),
        light: String = ParamSpec::text("light", "", "The light the map is made for: empty = the scene's first light (its sun), else a light's name or index in the scene (tyndall validate lists them)."),
        include: String = ParamSpec::text("include", "", "Comma-separated tags: draw only objects with one of them (empty: all)."),
        exclude: String = ParamSpec::text("exclude", "", "Comma-separated tags: leave out objects with any of them."),
        method: Method = ParamSpec::choice("method", Method::NAMES, "raster", ray_cast::METHOD_DOC),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "ShadowMap",
    category: "Scene",
    doc: "Light-space depth of the scene from one light (0 near, 1 far; clear where no occluder): orthographic for the sun, perspective for a spot, a cube atlas for a point light. An occluder shadows everything behind it, at any distance.",
    inputs: &[PortSpec::required("scene", &[PortType::Scene], "The scene to render from the light.")],
    outputs: &[PortSpec::output("map", &[PortType::ShadowMap], "Depth in [0, 1] (clear texels: no occluder) with the light's matrices.")],
    params: Params::SPECS,
})
.shaders(&[SHADER, ray_cast::SHADOW_SHADER])
.on_demand(&[ray_cast::SHADOW_SHADER])
.uniforms(&[ShadowMapParams::LAYOUT, ray_cast::RayCastParams::LAYOUT])
.scene_parts(&[ScenePart::Lights, ScenePart::Geometry]);

const SHADER: Shader = crate::shader("shadow_map", include_str!("../shaders/shadow_map.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/shadow_map.wgsl` (struct `Params`).
    pub struct ShadowMapParams as "Params" {
        /// World → light clip.
        pub light_view_proj: [[f32; 4]; 4],
        /// 1 for a perspective map with linear clip z (spot, point): the fragment writes clip z.
        pub linear_depth: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// Split a comma-separated tag list.
pub fn tags(list: &str) -> Vec<String> {
    list.split(',')
        .map(str::trim)
        .filter(|t| !t.is_empty())
        .map(str::to_string)
        .collect()
}

/// CPU reference of the projection: light-space (u, v, depth) of a world point, u and v in
/// [0, 1] across the map (v down), depth in [0, 1] between the map's near and far planes (less
/// or more outside them); for a spot or point light, its own lookup
/// (`LocalLight::uvz`, the atlas for a point light), or (0, 0, 2) — outside — behind a spot.
pub fn project(m: &Matrices, p: glam::Vec3) -> glam::Vec3 {
    let vp = glam::Mat4::from_cols_array_2d(&m.proj) * glam::Mat4::from_cols_array_2d(&m.view);
    if let Some(l) = m.local {
        return l.uvz(vp, p).unwrap_or(glam::Vec3::new(0.0, 0.0, 2.0));
    }
    let c = vp.project_point3(p);
    glam::Vec3::new(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z)
}

/// The widest half-angle a spot's map covers, degrees.
pub const MAX_SPOT_HALF_ANGLE: f32 = 85.0;

impl NodeKind for ShadowMapNode {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let scene = ctx.scene("scene")?;
        let light = scene
            .scene
            .find_light(&p.light)
            .map_err(|message| NodeError::Param {
                param: "light".into(),
                message,
            })?;
        let res = ctx.side("resolution", p.resolution, 2)?;
        let bounds = scene.scene.bounds();
        let local = light.local(bounds);
        let ranges = scene.select(&tags(p.include.as_str()), &tags(p.exclude.as_str()));
        let mesh = MeshDraw {
            vertices: &scene.vertices,
            indices: &scene.indices,
            placements: &scene.placements,
            ranges: &ranges,
        };
        let bvh = match p.method {
            Method::RayCast => Some(ray_cast::scene_bvh(ctx.gpu, scene, &ranges)?),
            Method::Raster => None,
        };
        let draw = |ctx: &RunCtx, view_proj: glam::Mat4, linear: bool, side: u32| {
            if let Some(bvh) = &bvh {
                let out = ctx.gpu.texture(side, side, TexFormat::R32F)?;
                let u = ray_cast::RayCastParams {
                    linear_depth: linear as u32,
                    far_ndc: match local {
                        Some(l) if linear => ray_cast::linear_far(l.near, l.far),
                        _ => 1.0,
                    },
                    ..ray_cast::params(view_proj, side, side)
                };
                ray_cast::shadow(ctx.gpu, bvh, &u, &out)?;
                return Ok(out);
            }
            let u = ShadowMapParams {
                light_view_proj: view_proj.to_cols_array_2d(),
                linear_depth: linear as u32,
                _pad0: 0,
                _pad1: 0,
                _pad2: 0,
            };
            let out = ctx.gpu.texture(side, side, TexFormat::R32F)?;
            ctx.gpu.raster(
                SHADER,
                bytemuck::bytes_of(&u),
                &[RasterTarget {
                    texture: &out,
                    clear: [f64::from(SHADOW_CLEAR), 0.0, 0.0, 0.0],
                }],
                &mesh,
            )?;
            Ok::<_, NodeError>(out)
        };
        let (out, view, proj) = match (light.kind, local) {
            (
                LightKind::Spot {
                    position,
                    direction,
                    outer,
                    ..
                },
                Some(l),
            ) => {
                ctx.check_bytes("resolution", u64::from(res).pow(2) * 4)?;
                let half = outer.min(MAX_SPOT_HALF_ANGLE.to_radians());
                let (view, proj) = (
                    spot_view(position, direction),
                    local_proj(half, l.near, l.far),
                );
                (draw(ctx, proj * view, true, res)?, view, proj)
            }
            (LightKind::Point { position }, Some(l)) => {
                ctx.check_bytes("resolution", u64::from(res).pow(2) * 4 * 6)?;
                ctx.side("resolution", p.resolution * 3, 2)?;
                let proj = local_proj(std::f32::consts::FRAC_PI_4, l.near, l.far);
                let atlas = ctx.gpu.texture(3 * res, 2 * res, TexFormat::R32F)?;
                for face in 0..6 {
                    let f = draw(ctx, proj * face_view(position, face), true, res)?;
                    let (col, row) = ((face % 3) as u32, (face / 3) as u32);
                    ctx.gpu.copy_into(&f, &atlas, col * res, row * res)?;
                }
                (atlas, glam::Mat4::IDENTITY, glam::Mat4::IDENTITY)
            }
            _ => {
                ctx.check_bytes("resolution", u64::from(res).pow(2) * 4)?;
                // A directional light (spot and point lights took the arms above).
                let to_sun = light.as_sun().map_or(glam::Vec3::Y, |s| s.to_sun());
                let (view, proj) = fit_light(to_sun, bounds);
                (draw(ctx, proj * view, false, res)?, view, proj)
            }
        };
        let m = Matrices {
            view: view.to_cols_array_2d(),
            proj: proj.to_cols_array_2d(),
            far: 1.0,
            radiance: light.radiance(),
            local,
        };
        ctx.set("map", PortValue::ShadowMap(Arc::new(out), m));
        Ok(())
    }
}
