//! `SoftVisibility` on a lamp's map (see the parent module's docs): a spot's perspective map
//! sliced in q = 1 − start / w, its per-slice variance on and off the axis, and a point light's
//! cube atlas as six padded faces.

use std::sync::Arc;

use crate::algorithms::quantile;
use tyndall_engine::eval::{Matrices, NodeError, RunCtx};

/// One slice's per-axis variance in texels² on a spot's perspective map or a point light's cube
/// face (always linear growth):
/// a ray from a point L of a sphere of light (radius R, per-axis standard deviation R/2 over
/// its disc) through an occluder at distance w_o along the axis meets depth w_r at map offset
/// L (1/w_o − 1/w_r) in tangent units, and 1/w_o − 1/w_r = Δq / s with q = 1 − s / w, s the
/// distance where the slices start ([`spot_start`]). Slices are equal steps
/// Δq = (1 − s / far) / slices, so each adds ((R/2) Δq / s)² in tangent units², times
/// (k res / 2)² in texels² (k = 1 / tan of the map's half-angle; 1 on a cube face).
pub fn spot_step_variance(
    light: &Matrices,
    res: u32,
    slices: u32,
    radius_m: f64,
    start: f64,
    shape: [f64; 2],
) -> [f64; 2] {
    let Some(l) = light.local else {
        return [0.0; 2];
    };
    let far = l.far as f64;
    let dq = (1.0 - start / far) / slices.max(1) as f64;
    // A cube face spans 90°: tan of its half-angle is 1.
    let k = if l.point {
        1.0
    } else {
        light.proj[0][0] as f64
    };
    let sigma = radius_m / 2.0 * dq / start * k * res as f64 / 2.0;
    [sigma * sigma * shape[0], sigma * sigma * shape[1]]
}

/// The gutter, in buffer texels, a point light's faces need (at most `res`): the probe of the
/// occluders' age reaches two standard deviations of the widest spread (all `slices` steps of
/// [`spot_step_variance`], twice the variance at a face's edge: [`off_axis`]) plus a texel,
/// and a texel more.
pub fn cube_gutter(light: &Matrices, res: u32, slices: u32, radius_m: f64, start: f64) -> u32 {
    let v = spot_step_variance(light, res, slices, radius_m, start, [1.0, 1.0]);
    let spread = slices as f64 * (2.0 * v[0].max(v[1])).sqrt();
    ((2.0 * spread).ceil() as u32 + 2).min(res)
}

/// Where a spot's slices start: the distance along its axis of the map's nearest occluder
/// (`z_min`, its smallest depth), at least the map's near and at most 0.99 of its far — so the
/// slices cover the occluders' range of 1/w, not the empty space near the lamp (a map's near is
/// a thousandth of its far).
pub fn spot_start(near: f32, far: f32, z_min: f32) -> f32 {
    (near + z_min * (far - near)).max(near).min(0.99 * far)
}

/// How a lamp's map is sliced: slices in equal steps of q = 1 − `start` / w.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LampSlices {
    /// The map's depth-0 distance along its axis, m.
    pub near: f32,
    /// The map's depth-1 distance, m.
    pub far: f32,
    /// Where the slices start (q = 0), m: the nearest occluder ([`spot_start`]).
    pub start: f32,
    /// Tangent of the map's half-angle (1 on a cube face).
    pub tan_half: f32,
}

/// Where light depth `z` falls along the slices (the shader's `slice_coord`): `z`, or on a
/// lamp's map q / q_far with q = 1 − start / w.
pub fn slice_coord(z: f32, lamp: Option<LampSlices>) -> f32 {
    match lamp {
        None => z,
        Some(l) => {
            let w = l.near + z * (l.far - l.near);
            (1.0 - l.start / w) / (1.0 - l.start / l.far)
        }
    }
}

/// The per-axis factor on a lamp's per-slice variance at buffer position `(x, y)` of a
/// `res`-texel map (texel centres at integers): a sphere of light seen off the axis, at map
/// tangent m, spreads a shadow edge by (1/w_o − 1/w_r)(m ℓ_f − ℓ_⊥) (ℓ the light point's offsets
/// along and across the axis), whose variance over the sphere's silhouette (at right angles to
/// the ray) is (R/2)² (1 + m²) per axis: twice the on-axis spread at a cube face's edge.
pub fn off_axis(x: f32, y: f32, res: u32, tan_half: f32) -> [f32; 2] {
    let m = [x, y].map(|t| ((t + 0.5) / res as f32 * 2.0 - 1.0) * tan_half);
    [1.0 + m[0] * m[0], 1.0 + m[1] * m[1]]
}

/// How a run lays out its buffers over the map: one tile, or a point light's six faces.
pub(super) struct Tiles {
    /// The map the occluders are read from (a cube atlas padded with `map_gutter`).
    pub(super) map: Arc<tyndall_engine::gpu::GpuTexture>,
    /// Tiles across and down.
    pub(super) count: [u32; 2],
    /// Each buffer tile's gutter, texels.
    pub(super) gutter: u32,
    /// Each map tile's gutter, map texels.
    pub(super) map_gutter: u32,
    /// The side of one face of the map without its gutter, map texels.
    pub(super) map_face: u32,
    /// A lamp's slicing.
    pub(super) lamp: Option<LampSlices>,
}

/// The nearest occluder's depth: the map's smallest, selected on the GPU.
fn nearest(ctx: &RunCtx, map: &tyndall_engine::gpu::GpuTexture) -> Result<f32, NodeError> {
    let form = quantile::Histogram::for_adapter(ctx.gpu);
    let sel = quantile::select(ctx.gpu, map, 0.0, quantile::Rank::Floor, None, form)?;
    Ok(quantile::read_value(ctx.gpu, &sel)?.unwrap_or(1.0))
}

/// The tiles of a run: the sun's or a spot's map as one tile; a point light's cube atlas as six
/// faces, each padded (`cube_atlas::pad`) with the gutter its penumbrae spread into, so a
/// penumbra crosses a seam. The slices start at the faces' own nearest occluder: a gutter shows
/// a face its neighbours' occluders obliquely, nearer along its axis than along their own (a
/// point 1.5 m below the lamp is 0.7 m along a side face's axis, seen 2.2 tangents out), and
/// starting there would spend the slices near the lamp and widen every spread; such an
/// occluder falls in the first slice.
pub(super) fn tiles_of(
    ctx: &RunCtx,
    map: &Arc<tyndall_engine::gpu::GpuTexture>,
    light: &Matrices,
    res: u32,
    slices: u32,
    radius: f64,
) -> Result<Tiles, NodeError> {
    let one = |lamp| Tiles {
        map: map.clone(),
        count: [1, 1],
        gutter: 0,
        map_gutter: 0,
        map_face: map.width.max(map.height),
        lamp,
    };
    let Some(l) = light.local else {
        return Ok(one(None));
    };
    let start = spot_start(l.near, l.far, nearest(ctx, map)?);
    let slicing = |start| LampSlices {
        near: l.near,
        far: l.far,
        start,
        tan_half: if l.point { 1.0 } else { 1.0 / light.proj[0][0] },
    };
    if !l.point {
        return Ok(one(Some(slicing(start))));
    }
    let limit = ctx.gpu.limits.max_texture_dimension_3d;
    if 3 * res > limit {
        return Err(NodeError::Param {
            param: "resolution".into(),
            message: format!(
                "a point light's volume is 3 × {res} texels wide, beyond this adapter's limit \
                 of {limit} (max_texture_dimension_3d): use at most {}",
                limit / 3
            ),
        });
    }
    let face = map.width / 3;
    let mut tiles = Tiles {
        map: map.clone(),
        count: [3, 2],
        gutter: 0,
        map_gutter: 0,
        map_face: face,
        lamp: None,
    };
    tiles.gutter = cube_gutter(light, res, slices, radius, start as f64);
    tiles.map_gutter = (tiles.gutter * face).div_ceil(res).min(face);
    tiles.map = crate::algorithms::cube_atlas::pad(ctx.gpu, map, &l, tiles.map_gutter)?;
    tiles.lamp = Some(slicing(start));
    Ok(tiles)
}
