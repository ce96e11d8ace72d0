//! OpenColorIO for the colour nodes (issue #45): the processors `ColourSpace`, `DisplayView`
//! and the file nodes build from their parameters (errors naming those parameters), run on the
//! GPU by the engine's [`tyndall_engine::colour_pass`] (the WGSL the `ocio` crate writes, with
//! its LUT textures) and on the CPU — the reference — by the crate's CPU processor.

use tyndall_engine::colour::{ColourCtx, ColourError};
use tyndall_engine::eval::NodeError;
use tyndall_engine::io::Raster;

/// A colour error as a node's: the parameter it came from.
pub fn param_error(param: &str) -> impl Fn(ColourError) -> NodeError + '_ {
    move |e| NodeError::Param {
        param: param.to_string(),
        message: e.to_string(),
    }
}

/// The processor from colour space `from` to `to` of `config` (empty: the evaluation's
/// config; an empty space: the working space), errors naming the parameters `config`, `from`,
/// `to`.
pub fn colour_space_processor(
    colour: &ColourCtx,
    config: &str,
    from: &str,
    to: &str,
) -> Result<ocio::Processor, NodeError> {
    let config = colour.config(config).map_err(param_error("config"))?;
    let working = colour.working_space();
    let from = config
        .colour_space(from, working)
        .map_err(param_error("from"))?;
    let to = config
        .colour_space(to, working)
        .map_err(param_error("to"))?;
    config.processor(&from, &to).map_err(param_error("to"))
}

/// The processor from colour space `source` through `display` / `view` with `look` of
/// `config` (empties: the evaluation's config, the working space, the config's default
/// display, the display's default view, no look), errors naming the parameters of those names.
pub fn display_view_processor(
    colour: &ColourCtx,
    config: &str,
    source: &str,
    display: &str,
    view: &str,
    look: &str,
) -> Result<ocio::Processor, NodeError> {
    let config = colour.config(config).map_err(param_error("config"))?;
    let source = config
        .colour_space(source, colour.working_space())
        .map_err(param_error("source"))?;
    let display = config.display(display).map_err(param_error("display"))?;
    let view = config.view(&display, view).map_err(param_error("view"))?;
    let look = if look.is_empty() {
        String::new()
    } else {
        config.look(look).map_err(param_error("look"))?
    };
    config
        .display_view_processor(&source, &display, &view, &look)
        .map_err(param_error("view"))
}

pub use tyndall_engine::colour_pass::{apply, OcioPass};

/// The GPU form of `processor`; why OpenColorIO could not write one is an error on the node's
/// parameter `param` (the one that chose the transform).
pub fn prepare(processor: &ocio::Processor, param: &str) -> Result<OcioPass, NodeError> {
    tyndall_engine::colour_pass::prepare(processor).map_err(|message| NodeError::Param {
        param: param.to_string(),
        message,
    })
}

/// CPU reference: `processor` on every pixel of a four-channel raster.
pub fn reference(processor: &ocio::Processor, image: &Raster) -> Raster {
    let mut out = image.clone();
    processor
        .default_cpu_processor()
        .apply_rgba_slice(&mut out.data);
    out
}
