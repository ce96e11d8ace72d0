//! `SideBySide`: two images next to each other (left, then right), for before/after views of a
//! stylization. The output is as wide as both and as tall as the taller; uncovered texels are
//! opaque black.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `left`, `right` | in | Image (required) |
//! | `image` | out | Image |

use std::sync::Arc;

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `SideBySide` node kind.
pub struct SideBySide;

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "SideBySide",
    category: "Image",
    doc: "Places two images next to each other (before/after views).",
    inputs: &[
        PortSpec::required("left", &[PortType::Image], "Left image."),
        PortSpec::required("right", &[PortType::Image], "Right image."),
    ],
    outputs: &[PortSpec::output("image", &[PortType::Image], "Both images, left then right.")],
    params: &[],
})
.shaders(&[SHADER]);

const SHADER: Shader = crate::shader("side_by_side", include_str!("../shaders/side_by_side.wgsl"));

/// CPU reference.
pub fn reference(l: &Raster, r: &Raster) -> Raster {
    let (w, h) = (l.width + r.width, l.height.max(r.height));
    let mut out = Raster::new(w, h, 4, 0.0);
    for y in 0..h {
        for x in 0..w {
            let v: [f32; 4] = if x < l.width {
                if y < l.height {
                    l.pixel(x, y).try_into().unwrap_or([0.0; 4])
                } else {
                    [0.0, 0.0, 0.0, 1.0]
                }
            } else if y < r.height {
                r.pixel(x - l.width, y).try_into().unwrap_or([0.0; 4])
            } else {
                [0.0, 0.0, 0.0, 1.0]
            };
            let i = ((y * w + x) * 4) as usize;
            out.data[i..i + 4].copy_from_slice(&v);
        }
    }
    out
}

impl NodeKind for SideBySide {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let (l, r) = (ctx.require_texture("left")?, ctx.require_texture("right")?);
        let (w, h) = (l.width + r.width, l.height.max(r.height));
        let out = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "join",
            &[
                ("left", Bind::Texture(&l)),
                ("right", Bind::Texture(&r)),
                ("out_image", Bind::Storage(&out)),
            ],
            w,
            h,
        )?;
        ctx.set("image", PortValue::Image(Arc::new(out)));
        Ok(())
    }
}
