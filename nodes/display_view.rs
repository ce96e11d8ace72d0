//! `DisplayView`: an image through an OpenColorIO display / view transform (issue #45): the
//! studio's picture for a monitor — ACES 2.0 SDR, AgX, Filmic, un-tone-mapped sRGB — with an
//! optional look, as a viewer shows it and as a display-referred file should hold it.
//!
//! The transform is OpenColorIO's viewing pipeline from `source` through `display` / `view`,
//! `look` applied first in its process space (what a viewer's look menu does), run on the GPU
//! from the WGSL the `ocio` crate writes for it (`algorithms::ocio`); the CPU reference is the
//! crate's CPU processor.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `image` | in | Image (required) |
//! | `image` | out | Image |
//!
//! | param | type | default | |
//! |---|---|---|---|
//! | `config` | Text | "" | a config file or `ocio://…` name; empty: the current config |
//! | `source` | Text | "" | colour space of the input; empty: the working space |
//! | `display` | Text | "" | display; empty: the config's default (`sRGB - Display` in the built-in config) |
//! | `view` | Text | "" | view of the display; empty: the display's default (`ACES 2.0 - SDR 100 nits (Rec.709)`) |
//! | `look` | Text | "" | look; empty: none |

use std::sync::Arc;

use tyndall_engine::colour::ColourCtx;
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};

use crate::algorithms::ocio;

/// The `DisplayView` node kind.
pub struct DisplayView;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        config: String = ParamSpec::text("config", "", "OpenColorIO config: a file or an ocio:// name; empty: the current config (--ocio, $OCIO, else the built-in ACES 2.0 CG config)."),
        source: String = ParamSpec::text("source", "", "Colour space of the input; empty: the working space (Linear Rec.709 (sRGB))."),
        display: String = ParamSpec::text("display", "", "Display; empty: the config's default (sRGB - Display in the built-in config)."),
        view: String = ParamSpec::text("view", "", "View of the display; empty: the display's default (ACES 2.0 - SDR 100 nits (Rec.709) in the built-in config)."),
        look: String = ParamSpec::text("look", "", "Look applied before the view, in its process space; empty: none."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "DisplayView",
    category: "Colour",
    doc: "An image through an OpenColorIO display / view transform and look: the studio's picture for a monitor (GPU pass from OpenColorIO's WGSL).",
    inputs: &[PortSpec::required("image", &[PortType::Image], "Scene-linear image, in `source`.")],
    outputs: &[PortSpec::output("image", &[PortType::Image], "Display-referred values for `display`.")],
    params: Params::SPECS,
})
.colour();

/// The processor the parameters ask for, under the evaluation's colour settings.
pub fn processor(colour: &ColourCtx, p: &Params) -> Result<::ocio::Processor, NodeError> {
    ocio::display_view_processor(colour, &p.config, &p.source, &p.display, &p.view, &p.look)
}

impl NodeKind for DisplayView {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let tex = ctx.require_texture("image")?;
        let pass = ocio::prepare(&processor(ctx.colour, &p)?, "view")?;
        let out = ocio::apply(ctx.gpu, &pass, &tex)?;
        ctx.set("image", PortValue::Image(Arc::new(out)));
        Ok(())
    }
}
