//! Constraints anchored to surface points: where they land in TF space each frame.

use super::{
    depth_coordinate, input_err, Frame, GpuTexture, Layer, LayerEntry, Matrices, NodeError, Raster,
    RunCtx,
};

/// Where an anchored constraint lands in TF space this frame: the surface point projected into
/// the view; `None` when it is off screen, behind the camera, or hidden by a nearer surface
/// (linear depth at its pixel more than 1 % + 1 mm short of its distance).
pub fn anchor_tf_position(
    p: glam::Vec3,
    camera: &Matrices,
    vis: &Raster,
    depth: &Raster,
    range: (f32, f32),
) -> Option<[f32; 2]> {
    let c = camera.view_proj() * p.extend(1.0);
    if c.w <= 0.0 {
        return None;
    }
    let (w, h) = (depth.width as f32, depth.height as f32);
    let x = (c.x / c.w * 0.5 + 0.5) * w;
    let y = (0.5 - c.y / c.w * 0.5) * h;
    if !(0.0..w).contains(&x) || !(0.0..h).contains(&y) {
        return None;
    }
    let k = (y as usize) * depth.width as usize + x as usize;
    let (d, dist) = (depth.data[k], (p - camera.eye()).length());
    if d < dist * 0.99 - 1e-3 {
        return None;
    }
    Some([vis.data[k], depth_coordinate(d, range.0, range.1)])
}

/// Move anchored diffusion constraints to where their surface points are this frame (see
/// [`anchor_tf_position`]); a constraint that is not visible keeps its `at`.
pub(super) fn resolve_anchors(
    ctx: &RunCtx,
    layers: &mut [LayerEntry],
    frame: Option<&Frame>,
) -> Result<(), NodeError> {
    let anchored = layers.iter().any(|e| match &e.layer {
        Layer::Diffusion { constraints } => constraints.iter().any(|c| c.anchor.is_some()),
        _ => false,
    });
    if !anchored {
        return Ok(());
    }
    let scene = ctx
        .scene_opt("scene")?
        .ok_or_else(|| input_err("scene", "must be connected for anchored constraints"))?;
    let f = frame.ok_or_else(|| {
        input_err(
            "visibility",
            "and `depth` must be connected for anchored constraints",
        )
    })?;
    let read = |t: &GpuTexture| -> Result<Raster, NodeError> {
        Ok(Raster {
            width: t.width,
            height: t.height,
            channels: 1,
            data: ctx.gpu.read_texture(t)?,
        })
    };
    let (vis, depth) = (read(&f.vis)?, read(&f.depth)?);
    // The maps are on the CPU already: the range as the node uses it, from them.
    let range = f.range_values(ctx, &depth)?;
    for (i, e) in layers.iter_mut().enumerate() {
        if let Layer::Diffusion { constraints } = &mut e.layer {
            for c in constraints.iter_mut() {
                if let Some(a) = &c.anchor {
                    let p = scene
                        .scene
                        .surface_position(&a.object, a.triangle, a.bary)
                        .ok_or_else(|| {
                            NodeError::Data(format!(
                                "layer {i}: anchor: the scene has no object {:?} with a triangle {}",
                                a.object, a.triangle
                            ))
                        })?;
                    if let Some(at) = anchor_tf_position(p, &f.camera, &vis, &depth, range) {
                        c.at = at;
                    }
                }
            }
        }
    }
    Ok(())
}
