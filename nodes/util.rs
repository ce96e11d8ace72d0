//! Small helpers shared by node files (no node kind lives here).

use std::collections::BTreeMap;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

use crate::eval::{NodeError, PortValue, RunCtx};
use crate::gpu::{GpuTexture, TexFormat};
use crate::graph::ParamValue;

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

/// Cache-key material for a file named by a `Text` parameter: its size and modification time
/// (so editing the file on disk re-runs the node).
pub fn file_stamp(params: &BTreeMap<String, ParamValue>, param: &str) -> u64 {
    match params.get(param) {
        Some(ParamValue::Text(p)) => path_stamp(std::path::Path::new(p)),
        _ => 0,
    }
}

/// Cache-key material for a file: its size and modification time (0 when it cannot be read).
pub fn path_stamp(path: &std::path::Path) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    if let Ok(m) = std::fs::metadata(path) {
        m.len().hash(&mut h);
        m.modified().ok().hash(&mut h);
    }
    h.finish()
}

/// The world box a volume covers: the bounds of the scene on the `scene` input, else the
/// `box_min`…`box_max` parameters (refused when inverted). Shared by the volume nodes.
pub fn volume_box(ctx: &RunCtx) -> Result<[[f32; 3]; 2], NodeError> {
    if let Some(v) = ctx.input("scene") {
        let s = v
            .payload::<crate::scene::GpuScene>()
            .ok_or_else(|| NodeError::Input {
                port: "scene".into(),
                message: "is not a scene".into(),
            })?;
        let (lo, hi) = s.scene.bounds();
        return Ok([lo.to_array(), hi.to_array()]);
    }
    let (lo, hi) = (ctx.vec3("box_min")?, ctx.vec3("box_max")?);
    if (0..3).any(|k| lo[k] > hi[k]) {
        return Err(NodeError::Param {
            param: "box_max".into(),
            message: format!("{hi:?} is below box_min {lo:?} on some axis"),
        });
    }
    Ok([lo, hi])
}
