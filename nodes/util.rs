//! Small helpers shared by node files (no node kind lives here).

use std::sync::Arc;

use tyndall_engine::eval::{NodeError, PortValue, RunCtx};
use tyndall_engine::gpu::{GpuTexture, TexFormat};

/// Resolve a `width`/`height` pair of parameter values where 0 means "the evaluation size".
pub fn size_or_default(ctx: &RunCtx, w: i64, h: i64) -> (u32, u32) {
    let (dw, dh) = ctx.size;
    let pick = |v: i64, d: u32| if v <= 0 { d } else { v as u32 };
    (pick(w, dw), pick(h, dh))
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

/// The world box a volume covers: the bounds of the scene on the `scene` input, else the
/// `box_min`…`box_max` parameters' values `[lo, hi]` (refused when inverted). Shared by the
/// volume nodes.
pub fn volume_box(ctx: &RunCtx, [lo, hi]: [[f32; 3]; 2]) -> Result<[[f32; 3]; 2], NodeError> {
    if let Some(s) = ctx.scene_opt("scene")? {
        let (lo, hi) = s.scene.bounds();
        return Ok([lo.to_array(), hi.to_array()]);
    }
    if (0..3).any(|k| lo[k] > hi[k]) {
        return Err(NodeError::Param {
            param: "box_max".into(),
            message: format!("{hi:?} is below box_min {lo:?} on some axis"),
        });
    }
    Ok([lo, hi])
}

/// A file parameter's `path` with its frame pattern (`####`, `%04d`) replaced by the frame (the
/// rendered frame, else the time rounded); as written when it has none. Shared by the readers
/// of sequences (`ImageInput`, `VdbVolume`).
pub fn frame_path(path: &str, frame: Option<i64>, time: f64) -> String {
    let f = frame.unwrap_or(time.round() as i64);
    tyndall_engine::eval::with_frame(path, f).unwrap_or_else(|| path.to_string())
}
