//! `LightMap`: a light-space RGB texture multiplying the sun (SPEC §5, seed 000 §4.2), for
//! `SingleScattering.light_map`.
//!
//! The map is projected along the light with the matrices of the `shadow` input (the same
//! orthographic box as the shadow map): a point x takes the colour at (u, v) = (c.x/2 + 1/2,
//! 1/2 − c.y/2) of its light clip position c, bilinear between texel centres, clamp to edge.
//! Its texels come from the `image` input when connected, else from the file `path`, else the
//! map is the constant `colour`. A map solved from painted strokes comes from `LightMapSolve`.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `shadow` | in | ShadowMap (required) | its light matrices place the map |
//! | `image` | in | Image | the map's texels (overrides `path`) |
//! | `light_map` | out | LightMap | |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `path` | Text | "" | | PNG (sRGB) or EXR (linear) file; empty: `colour` |
//! | `colour` | Colour | (1, 1, 1, 1) | 0…1e6 | the constant map (no image, no path) |

use std::sync::Arc;

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `LightMap` node kind.
pub struct LightMap;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        path: String = ParamSpec::text("path", "", "PNG (sRGB) or EXR (linear) file with the map; empty: the constant `colour`."),
        colour: [f32; 4] = ParamSpec::colour("colour", [1.0; 4], 0.0, 1e6, "linear RGB", "The constant map when no image or file is given."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "LightMap",
    category: "Colour",
    doc: "A light-space RGB texture multiplying the sun, placed by the shadow map's light matrices: from an image, a file, or a constant colour.",
    inputs: &[
        PortSpec::required("shadow", &[PortType::ShadowMap], "Shadow map whose light matrices place the light map."),
        PortSpec::input("image", &[PortType::Image], "The map's texels (overrides `path`)."),
    ],
    outputs: &[PortSpec::output("light_map", &[PortType::LightMap], "The light map (for SingleScattering.light_map).")],
    params: Params::SPECS,
})
.files(&[("path", tyndall_engine::eval::FileRole::Read)]);

impl NodeKind for LightMap {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let (_, m) = ctx.shadow_map("shadow")?;
        let tex = match ctx.texture_opt("image")? {
            Some(t) => t,
            None => {
                let path = p.path.as_str();
                if path.is_empty() {
                    let c = p.colour;
                    Arc::new(ctx.gpu.upload(1, 1, 4, &[c[0], c[1], c[2], 1.0])?)
                } else {
                    let r = tyndall_engine::io::read_image(std::path::Path::new(path), true)
                        .map(Raster::into_rgba)
                        .map_err(|e| NodeError::Param {
                            param: "path".into(),
                            message: e.to_string(),
                        })?;
                    Arc::new(ctx.gpu.upload(r.width, r.height, 4, &r.data)?)
                }
            }
        };
        ctx.set("light_map", PortValue::LightMap(tex, m));
        Ok(())
    }
}
