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

use bytemuck::{Pod, Zeroable};
use std::sync::Arc;

use super::util::size_or_default;
use crate::eval::{Matrices, NodeError, NodeKind, PortValue, RunCtx};
use crate::gpu::{MeshDraw, RasterTarget, Shader, TexFormat, UniformLayout};
use crate::graph::{DefaultValue, NodeSchema, ParamKind, ParamSpec, PortSpec, PortType};
use crate::scene::GpuScene;

/// The `GBuffer` node kind.
pub struct GBufferNode;

static SCHEMA: NodeSchema = NodeSchema {
    kind: "GBuffer",
    category: "Scene",
    doc: "Camera linear depth (sky: far distance), world normals and albedo of the scene.",
    inputs: &[PortSpec {
        name: "scene",
        types: &[PortType::Scene],
        required: true,
        doc: "The scene seen by its camera.",
    }],
    outputs: &[
        PortSpec {
            name: "depth",
            types: &[PortType::Depth],
            required: false,
            doc: "Distance to the first surface (sky: far).",
        },
        PortSpec {
            name: "normal",
            types: &[PortType::Image],
            required: false,
            doc: "World normal facing the camera; alpha 1 on geometry.",
        },
        PortSpec {
            name: "albedo",
            types: &[PortType::Image],
            required: false,
            doc: "Base colour; alpha 1 on geometry, 0 on sky.",
        },
    ],
    params: &[
        ParamSpec {
            name: "width",
            kind: ParamKind::Int,
            default: DefaultValue::Int(0),
            min: 0.0,
            max: 16384.0,
            unit: "px",
            doc: "Width; 0 uses the evaluation size.",
        },
        ParamSpec {
            name: "height",
            kind: ParamKind::Int,
            default: DefaultValue::Int(0),
            min: 0.0,
            max: 16384.0,
            unit: "px",
            doc: "Height; 0 uses the evaluation size.",
        },
    ],
};

static SHADER: Shader = Shader {
    stem: "g_buffer",
    source: include_str!("../shaders/g_buffer.wgsl"),
};

/// Uniforms of `shaders/g_buffer.wgsl` (struct `Params`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GBufferParams {
    /// World → camera clip.
    pub view_proj: [[f32; 4]; 4],
    /// Camera position.
    pub eye: [f32; 3],
    /// Far distance.
    pub far: f32,
}

impl NodeKind for GBufferNode {
    fn schema(&self) -> &'static NodeSchema {
        &SCHEMA
    }

    fn shader(&self) -> Option<Shader> {
        Some(SHADER)
    }

    fn uniform_layouts(&self) -> Vec<UniformLayout> {
        vec![crate::uniform_layout!(
            GBufferParams,
            "Params",
            view_proj,
            eye,
            far
        )]
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let scene =
            ctx.require("scene")?
                .payload::<GpuScene>()
                .ok_or_else(|| NodeError::Input {
                    port: "scene".into(),
                    message: "is not a scene".into(),
                })?;
        let (w, h) = size_or_default(ctx, "width", "height")?;
        let cam = scene.scene.camera;
        let (view, proj) = (cam.view(), cam.proj(w as f32 / h as f32));
        let u = GBufferParams {
            view_proj: (proj * view).to_cols_array_2d(),
            eye: cam.position.to_array(),
            far: cam.far,
        };
        let depth = ctx.gpu.texture(w, h, TexFormat::R32F)?;
        let normal = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        let albedo = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        ctx.gpu.raster(
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
        let m = Matrices {
            view: view.to_cols_array_2d(),
            proj: proj.to_cols_array_2d(),
            far: cam.far,
            radiance: [0.0; 3],
        };
        ctx.set("depth", PortValue::Depth(Arc::new(depth), m));
        ctx.set("normal", PortValue::Image(Arc::new(normal)));
        ctx.set("albedo", PortValue::Image(Arc::new(albedo)));
        Ok(())
    }
}
