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

use std::sync::Arc;

use super::util::size_or_default;
use crate::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use crate::gpu::{Gpu, GpuError, GpuTexture, MeshDraw, RasterTarget, Shader, TexFormat};
use crate::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use crate::scene::GpuScene;

/// The `GBuffer` node kind.
pub struct GBufferNode;

#[rustfmt::skip]
crate::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        width: i64 = ParamSpec::int("width", 0, 0, 16384, "px", "Width; 0 uses the evaluation size."),
        height: i64 = ParamSpec::int("height", 0, 0, 16384, "px", "Height; 0 uses the evaluation size."),
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
.shaders(&[SHADER])
.uniforms(&[GBufferParams::LAYOUT]);

const SHADER: Shader = Shader::new("g_buffer", include_str!("../shaders/g_buffer.wgsl"));

crate::uniforms! {
    /// Uniforms of `shaders/g_buffer.wgsl` (struct `Params`).
    pub struct GBufferParams as "Params" {
        /// World → camera clip.
        pub view_proj: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// Far distance.
        pub far: f32,
    }
}

impl NodeKind for GBufferNode {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let scene = ctx.scene("scene")?;
        let (w, h) = size_or_default(ctx, p.width, p.height);
        let (depth, normal, albedo, m) = render(ctx.gpu, scene, &scene.scene.camera, w, h)?;
        ctx.set("depth", PortValue::Depth(Arc::new(depth), m));
        ctx.set("normal", PortValue::Image(Arc::new(normal)));
        ctx.set("albedo", PortValue::Image(Arc::new(albedo)));
        Ok(())
    }
}

/// Render the G-buffer of `scene` seen by `cam` at `w × h`: linear depth (sky: the far
/// distance), normals, albedo, and the camera's matrices (for other nodes that need a view of
/// the scene, e.g. `LightMapSolve`).
pub fn render(
    gpu: &Gpu,
    scene: &GpuScene,
    cam: &crate::scene::Camera,
    w: u32,
    h: u32,
) -> Result<(GpuTexture, GpuTexture, GpuTexture, Matrices), GpuError> {
    let (view, proj) = (cam.view(), cam.proj(w as f32 / h as f32));
    let u = GBufferParams {
        view_proj: (proj * view).to_cols_array_2d(),
        eye: cam.position.to_array(),
        far: cam.far,
    };
    let depth = gpu.texture(w, h, TexFormat::R32F)?;
    let normal = gpu.texture(w, h, TexFormat::Rgba32F)?;
    let albedo = gpu.texture(w, h, TexFormat::Rgba32F)?;
    gpu.raster(
        SHADER,
        bytemuck::bytes_of(&u),
        &[
            RasterTarget {
                texture: &depth,
                clear: [cam.far as f64, 0.0, 0.0, 0.0],
            },
            RasterTarget {
                texture: &normal,
                clear: [0.0; 4],
            },
            RasterTarget {
                texture: &albedo,
                clear: [0.0; 4],
            },
        ],
        &MeshDraw {
            vertices: &scene.vertices,
            indices: &scene.indices,
            ranges: &scene.ranges,
        },
    )?;
    Ok((depth, normal, albedo, cam.matrices(w, h)))
}
