//! `HoleComposite`: hole creation (SPEC §4): the tagged objects' own shadow map is made clear
//! ([`SHADOW_CLEAR`], no occluder) where the hole map says so, then the minimum with the rest of
//! the scene's map — so light bursts through the objects (foliage) while everything else still
//! occludes. A texel clear in both maps stays clear.
//!
//! `out = min(H > 0.5 ? clear : object, rest)`. The hole map is sampled at the same normalised
//! position (nearest texel) when its size differs. Any light: `object` and `rest` must be maps
//! of the same one (the same `ShadowMap.light`; a sun's, a spot's or a point light's cube
//! atlas, texel by texel), else the node refuses them.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `object` | in | ShadowMap (required): map of the tagged objects only (`ShadowMap include`) |
//! | `holes` | in | Scalar (required): 1 = hole (`HoleMap`) |
//! | `rest` | in | ShadowMap (required): map of everything else (`ShadowMap exclude`) |
//! | `map` | out | ShadowMap (the rest's matrices) |

use std::sync::Arc;

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx, SHADOW_CLEAR};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `HoleComposite` node kind.
pub struct HoleComposite;

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "HoleComposite",
    category: "Occluders",
    doc: "Makes the object-only map clear (no occluder) in holes, then takes the minimum with the rest of the scene's map.",
    inputs: &[
        PortSpec::required("object", &[PortType::ShadowMap], "Shadow map of the objects to punch holes into."),
        PortSpec::required("holes", &[PortType::Scalar], "Hole map (1 = hole)."),
        PortSpec::required("rest", &[PortType::ShadowMap], "Shadow map of the rest of the scene."),
    ],
    outputs: &[PortSpec::output("map", &[PortType::ShadowMap], "The combined map.")],
    params: &[],
})
.shaders(&[SHADER]);

const SHADER: Shader = crate::shader(
    "hole_composite",
    include_str!("../shaders/hole_composite.wgsl"),
);

/// CPU reference (hole map of the same size).
pub fn reference(object: &Raster, holes: &Raster, rest: &Raster) -> Raster {
    let mut out = rest.clone();
    for i in 0..out.data.len() {
        let o = if holes.data[i] > 0.5 {
            SHADOW_CLEAR
        } else {
            object.data[i]
        };
        out.data[i] = o.min(rest.data[i]);
    }
    out
}

fn map(
    ctx: &RunCtx,
    port: &str,
) -> Result<
    (
        Arc<tyndall_engine::gpu::GpuTexture>,
        tyndall_engine::eval::Matrices,
    ),
    NodeError,
> {
    ctx.shadow_map(port)
}

impl NodeKind for HoleComposite {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let (object, om) = map(ctx, "object")?;
        let (rest, m) = map(ctx, "rest")?;
        // Both maps must be of the same light (a sun's box, a spot's cone, a point light's
        // cube): a texel-wise minimum of two lights' maps means nothing.
        if om.view_proj() != m.view_proj() || om.local != m.local {
            return Err(NodeError::Input {
                port: "object".into(),
                message: "is a map of another light (or another light box) than rest's: give \
                          both ShadowMaps the same light"
                    .into(),
            });
        }
        let holes = ctx.require_texture("holes")?;
        if (object.width, object.height) != (rest.width, rest.height) {
            return Err(NodeError::Input {
                port: "object".into(),
                message: format!(
                    "size {}x{} differs from rest's {}x{}",
                    object.width, object.height, rest.width, rest.height
                ),
            });
        }
        let out = ctx.gpu.texture(rest.width, rest.height, TexFormat::R32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "composite",
            &[
                ("object_map", Bind::Texture(&object)),
                ("holes", Bind::Texture(&holes)),
                ("rest_map", Bind::Texture(&rest)),
                ("out_map", Bind::Storage(&out)),
            ],
            rest.width,
            rest.height,
        )?;
        ctx.set("map", PortValue::ShadowMap(Arc::new(out), m));
        Ok(())
    }
}
