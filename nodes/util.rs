//! Small helpers shared by node files (no node kind lives here).

use std::sync::Arc;

use crate::eval::{NodeError, PortValue, RunCtx};
use crate::gpu::{GpuTexture, TexFormat};

/// Resolve a `width`/`height` pair of parameters where 0 means "the evaluation size".
pub fn size_or_default(ctx: &RunCtx, w: &str, h: &str) -> Result<(u32, u32), NodeError> {
    let (dw, dh) = ctx.size;
    let pick = |v: i64, d: u32| if v <= 0 { d } else { v as u32 };
    Ok((pick(ctx.int(w)?, dw), pick(ctx.int(h)?, dh)))
}

/// A 1×1 texture to bind where an optional input is not connected (the shader does not read it).
pub fn placeholder(ctx: &RunCtx) -> Result<Arc<GpuTexture>, NodeError> {
    Ok(Arc::new(ctx.gpu.texture(1, 1, TexFormat::R32F)?))
}

/// Wrap a texture as `Scalar` or `Image` by its format.
pub fn image_like(t: Arc<GpuTexture>) -> PortValue {
    match t.format {
        TexFormat::R32F => PortValue::Scalar(t),
        TexFormat::Rgba32F | TexFormat::Rg32F => PortValue::Image(t),
    }
}
