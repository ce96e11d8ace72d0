//! `ShadowMap`: orthographic light-space depth of the scene, fitted to its bounds (SPEC §1–2).
//!
//! The sun looks along −`to_sun`; the orthographic box is the light-space bounding box of the
//! scene, so depth is 0 at the light's near plane and 1 at the far plane, and texels no geometry
//! covers hold 1 ("no occluder"). With `include`/`exclude` (comma-separated tags) only some
//! objects are drawn, so tagged objects can get a map of their own.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `scene` | in | Scene (required) |
//! | `map` | out | ShadowMap (depth + light matrices + sun radiance) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `resolution` | Int | 2048 | 16…16384 texels | map size (square); beyond the device limit: an error naming the limit |
//! | `include` | Text | "" | | only objects with one of these tags (empty: all) |
//! | `exclude` | Text | "" | | leave out objects with any of these tags |

use std::sync::Arc;

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{MeshDraw, RasterTarget, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::scene::fit_light;
use tyndall_engine::scene::ScenePart;

/// The `ShadowMap` node kind.
pub struct ShadowMapNode;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        resolution: i64 = ParamSpec::int("resolution", 2048, 16, 16384, "texels", "Width and height of the map.").light_texels(),
        include: String = ParamSpec::text("include", "", "Comma-separated tags: draw only objects with one of them (empty: all)."),
        exclude: String = ParamSpec::text("exclude", "", "Comma-separated tags: leave out objects with any of them."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "ShadowMap",
    category: "Scene",
    doc: "Orthographic light-space depth of the scene (0 near, 1 far / no occluder), fitted to the scene bounds.",
    inputs: &[PortSpec::required("scene", &[PortType::Scene], "The scene to render from the sun.")],
    outputs: &[PortSpec::output("map", &[PortType::ShadowMap], "Depth in [0, 1] with the light's matrices.")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[ShadowMapParams::LAYOUT])
.scene_parts(&[ScenePart::Sun, ScenePart::Geometry]);

const SHADER: Shader = crate::shader("shadow_map", include_str!("../shaders/shadow_map.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/shadow_map.wgsl` (struct `Params`).
    pub struct ShadowMapParams as "Params" {
        /// World → light clip.
        pub light_view_proj: [[f32; 4]; 4],
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
/// [0, 1] across the map (v down), depth in [0, 1].
pub fn project(m: &Matrices, p: glam::Vec3) -> glam::Vec3 {
    let vp = glam::Mat4::from_cols_array_2d(&m.proj) * glam::Mat4::from_cols_array_2d(&m.view);
    let c = vp.project_point3(p);
    glam::Vec3::new(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z)
}

impl NodeKind for ShadowMapNode {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let scene = ctx.scene("scene")?;
        let res = ctx.side("resolution", p.resolution, 2)?;
        ctx.check_bytes("resolution", u64::from(res).pow(2) * 4)?;
        let (view, proj) = fit_light(scene.scene.sun.to_sun(), scene.scene.bounds());
        let u = ShadowMapParams {
            light_view_proj: (proj * view).to_cols_array_2d(),
        };
        let ranges = scene.select(&tags(p.include.as_str()), &tags(p.exclude.as_str()));
        let out = ctx.gpu.texture(res, res, TexFormat::R32F)?;
        ctx.gpu.raster(
            SHADER,
            bytemuck::bytes_of(&u),
            &[RasterTarget {
                texture: &out,
                clear: [1.0, 0.0, 0.0, 0.0],
            }],
            &MeshDraw {
                vertices: &scene.vertices,
                indices: &scene.indices,
                ranges: &ranges,
            },
        )?;
        let m = Matrices {
            view: view.to_cols_array_2d(),
            proj: proj.to_cols_array_2d(),
            far: 1.0,
            radiance: scene.scene.sun.radiance(),
        };
        ctx.set("map", PortValue::ShadowMap(Arc::new(out), m));
        Ok(())
    }
}
