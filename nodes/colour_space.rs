//! `ColourSpace`: converts an image between two colour spaces of an OpenColorIO config
//! (issue #45), e.g. a plate in ACEScg to the working space, or the working space to ACES2065-1
//! for delivery.
//!
//! The conversion is OpenColorIO's processor from `from` to `to` (names, aliases or roles of
//! the config), run on the GPU from the WGSL the `ocio` crate writes for it
//! (`algorithms::ocio`); the CPU reference is the crate's CPU processor. Alpha is passed
//! through OpenColorIO, which leaves it as it is for colour-space conversions.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `image` | in | Image (required) |
//! | `image` | out | Image |
//!
//! | param | type | default | |
//! |---|---|---|---|
//! | `config` | Text | "" | a config file or `ocio://…` name; empty: the current config (`--ocio`, `$OCIO`, the built-in ACES 2.0 CG config) |
//! | `from` | Text | "" | colour space of the input; empty: the working space |
//! | `to` | Text | "" | colour space of the output; empty: the working space |

use std::sync::Arc;

use tyndall_engine::colour::ColourCtx;
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};

use crate::algorithms::ocio;

/// The `ColourSpace` node kind.
pub struct ColourSpace;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        config: String = ParamSpec::text("config", "", "OpenColorIO config: a file or an ocio:// name; empty: the current config (--ocio, $OCIO, else the built-in ACES 2.0 CG config)."),
        from: String = ParamSpec::text("from", "", "Colour space of the input (a name, alias or role of the config); empty: the working space (Linear Rec.709 (sRGB))."),
        to: String = ParamSpec::text("to", "", "Colour space of the output; empty: the working space."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "ColourSpace",
    category: "Colour",
    doc: "Converts an image between two colour spaces of an OpenColorIO config (GPU pass from OpenColorIO's WGSL).",
    inputs: &[PortSpec::required("image", &[PortType::Image], "The image, in `from`.")],
    outputs: &[PortSpec::output("image", &[PortType::Image], "The image, in `to`.")],
    params: Params::SPECS,
})
.colour();

/// The processor the parameters ask for, under the evaluation's colour settings.
pub fn processor(colour: &ColourCtx, p: &Params) -> Result<::ocio::Processor, NodeError> {
    ocio::colour_space_processor(colour, &p.config, &p.from, &p.to)
}

impl NodeKind for ColourSpace {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let tex = ctx.require_texture("image")?;
        let pass = ocio::prepare(&processor(ctx.colour, &p)?, "to")?;
        let out = ocio::apply(ctx.gpu, &pass, &tex)?;
        ctx.set("image", PortValue::Image(Arc::new(out)));
        Ok(())
    }
}
