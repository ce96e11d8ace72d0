//! `GBuffer`: what the camera sees — linear depth, normals and albedo (SPEC §1–2).
//!
//! Linear depth is the distance from the camera to the first visible surface; sky pixels get
//! the camera's far distance (normal and albedo alpha 0 there). Normals face the camera.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `scene` | in | Scene (required) |
//! | `depth` | out | Depth (distance, camera matrices, far) |
//! | `normal` | out | Image (world normal, alpha 1 on geometry) |
//! | `albedo` | out | Image (base colour, alpha 1 on geometry) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `width`, `height` | Int | 0 | 0…16384 px | output size; 0 = the evaluation size (`--size`) |
//! | `method` | Choice | raster | raster, ray_cast | the graphics pipeline, or a compute pass casting a ray per pixel through a BVH ([`crate::algorithms::ray_cast`]); the same picture but for pixels centred exactly on an edge two triangles share |

use std::sync::Arc;

use super::util::size_or_default;
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::scene::ScenePart;

use crate::algorithms::g_buffer;
use crate::algorithms::ray_cast::{self, Method};

/// The `GBuffer` node kind.
pub struct GBufferNode;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        width: i64 = ParamSpec::int("width", 0, 0, 16384, "px", "Width; 0 uses the evaluation size."),
        height: i64 = ParamSpec::int("height", 0, 0, 16384, "px", "Height; 0 uses the evaluation size."),
        method: Method = ParamSpec::choice("method", Method::NAMES, "raster", ray_cast::METHOD_DOC),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "GBuffer",
    category: "Scene",
    doc: "Camera linear depth (sky: far distance), world normals and albedo of the scene.",
    inputs: &[PortSpec::required("scene", &[PortType::Scene], "The scene seen by its camera.")],
    outputs: &[
        PortSpec::output("depth", &[PortType::Depth], "Distance to the first surface (sky: far)."),
        PortSpec::output("normal", &[PortType::Image], "World normal facing the camera; alpha 1 on geometry."),
        PortSpec::output("albedo", &[PortType::Image], "Base colour; alpha 1 on geometry, 0 on sky."),
    ],
    params: Params::SPECS,
})
.shaders(&[g_buffer::SHADER, ray_cast::G_BUFFER_SHADER])
.on_demand(&[ray_cast::G_BUFFER_SHADER])
.uniforms(&[g_buffer::GBufferParams::LAYOUT, ray_cast::RayCastParams::LAYOUT])
.scene_parts(&[ScenePart::Camera, ScenePart::Geometry]);

impl NodeKind for GBufferNode {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let scene = ctx.scene("scene")?;
        let (w, h) = size_or_default(ctx, p.width, p.height);
        let (depth, normal, albedo, m) =
            g_buffer::render(ctx.gpu, scene, &scene.scene.camera, (w, h), p.method)?;
        ctx.set("depth", PortValue::Depth(Arc::new(depth), m));
        ctx.set("normal", PortValue::Image(Arc::new(normal)));
        ctx.set("albedo", PortValue::Image(Arc::new(albedo)));
        Ok(())
    }
}
