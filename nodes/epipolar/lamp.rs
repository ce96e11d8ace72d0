//! `EpipolarDilation` / `EpipolarClosure` on a lamp's map (see the parent module's docs): a
//! spot's perspective map in q = 1 − near / w, and a point light's cube atlas face by face.

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use tyndall_engine::eval::Matrices;
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, TexFormat};
use tyndall_engine::io::Raster;

use super::{pass, reference_sides, EpiOp, EpiParams, SHADER};
use crate::algorithms::shader_lib::keep_clear;
use tyndall_engine::eval::SHADOW_CLEAR;

/// A spot's perspective map in eq. 3's slope space. Its depth z is linear in the distance
/// w = near + z (far − near) along the spot's axis, and a perspective projection keeps 1/w,
/// not w, affine across the map: along the image of a view ray (a line through the epipole),
/// q = 1 − near / w changes linearly with the distance from the epipole, so the passes run on
/// q with the camera's q_l and the depths are converted back (texels the filter left alone keep
/// their depth bit for bit). A camera behind the spot's plane (distance w_c < 0 along its axis)
/// projects through the light onto the far side: its view rays' images run *towards* the
/// epipole as they leave the camera, so each operation samples the other side (`reverse`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perspective {
    /// Distance along the spot's axis of depth 0, m.
    pub near: f32,
    /// Distance along the spot's axis of depth 1, m.
    pub far: f32,
}

impl Perspective {
    /// q of depth `z`.
    pub fn q(&self, z: f32) -> f32 {
        keep_clear(
            z,
            1.0 - self.near / (self.near + z * (self.far - self.near)),
        )
    }

    /// The depth of q (the inverse of [`Perspective::q`]); q ≥ 1 (at or past infinity along
    /// the axis: a silhouette extruded beyond it, or a clear texel) is clear.
    pub fn z(&self, q: f32) -> f32 {
        if q >= 1.0 {
            SHADOW_CLEAR
        } else {
            (self.near / (1.0 - q) - self.near) / (self.far - self.near)
        }
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of the perspective passes (struct `Persp` of `shaders/epipolar.wgsl`).
    pub struct PerspParams as "Persp" {
        /// [`Perspective::near`].
        pub near: f32,
        /// [`Perspective::far`].
        pub far: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

/// The epipole of a spot's `w × h` map seen from `camera`: texel position, q_l and whether the
/// sides are reversed (camera behind the spot's plane); an error when the camera lies in that
/// plane (the epipole is at infinity).
pub fn spot_epipole(
    light: &Matrices,
    camera: &Matrices,
    persp: Perspective,
    w: u32,
    h: u32,
) -> Result<([f32; 2], f32, bool), String> {
    let c = light.view_proj() * camera.eye().extend(1.0);
    if c.w.abs() < 1e-4 {
        return Err(format!(
            "the camera lies in the spot's plane ({} m along its axis): the epipole is at infinity",
            c.w
        ));
    }
    let (x, y) = (c.x / c.w, c.y / c.w);
    Ok((
        [(x * 0.5 + 0.5) * w as f32, (0.5 - y * 0.5) * h as f32],
        1.0 - persp.near / c.w,
        c.w < 0.0,
    ))
}

/// CPU reference of the node on a spot's map: [`reference_sides`] on q, converted back;
/// `closure`: the dilation then the erosion.
pub fn reference_spot(
    map: &Raster,
    persp: Perspective,
    (l, q_l, reverse): ([f32; 2], f32, bool),
    length: i32,
    closure: bool,
) -> Raster {
    let mut q = map.clone();
    for v in &mut q.data {
        *v = persp.q(*v);
    }
    let mut r = reference_sides(&q, l, q_l, length, false, reverse);
    if closure {
        r = reference_sides(&r, l, q_l, length, true, reverse);
    }
    let mut out = map.clone();
    for ((o, before), after) in out.data.iter_mut().zip(&q.data).zip(&r.data) {
        if after != before {
            *o = persp.z(*after);
        }
    }
    out
}

pub(super) fn to_q(
    gpu: &Recorder,
    src: &GpuTexture,
    persp: Perspective,
) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(src.width, src.height, TexFormat::R32F)?;
    let u = persp_params(persp);
    gpu.dispatch(
        SHADER,
        "to_q",
        &[
            ("Q", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(src)),
            ("out_map", Bind::Storage(&out)),
        ],
        src.width,
        src.height,
    )?;
    Ok(out)
}

pub(super) fn from_q(
    gpu: &Recorder,
    depth: &GpuTexture,
    before: &GpuTexture,
    after: &GpuTexture,
    persp: Perspective,
) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(depth.width, depth.height, TexFormat::R32F)?;
    let u = persp_params(persp);
    gpu.dispatch(
        SHADER,
        "from_q",
        &[
            ("Q", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(depth)),
            ("q_in", Bind::Texture(before)),
            ("kappa_in", Bind::Texture(after)),
            ("out_map", Bind::Storage(&out)),
        ],
        depth.width,
        depth.height,
    )?;
    Ok(out)
}

fn persp_params(p: Perspective) -> PerspParams {
    PerspParams {
        near: p.near,
        far: p.far,
        _pad0: 0,
        _pad1: 0,
    }
}

/// The epipoles of a point light's six faces seen from `camera`, each padded with `gutter`
/// texels around its `face` texels: per face [x, y, q_l, reverse] (x, y in texels from the
/// padded face's corner). Each face is a 90° perspective map; the camera's direction from the
/// light projects onto its plane (behind it: `reverse`), and a camera in the plane (w = 0)
/// is taken a micrometre in front, its epipole ~1e6 faces away: the lines are parallel.
pub fn cube_epipoles(
    light: &tyndall_engine::scene::LocalLight,
    camera: &Matrices,
    face: u32,
    gutter: u32,
) -> [[f32; 4]; 6] {
    let d = camera.eye() - glam::Vec3::from(light.position);
    let persp = Perspective {
        near: light.near,
        far: light.far,
    };
    std::array::from_fn(|k| {
        let (f, s, u) = tyndall_engine::scene::face_basis(k);
        let w = f.dot(d);
        let w = if w.abs() < 1e-6 {
            1e-6f32.copysign(w)
        } else {
            w
        };
        let (x, y) = (s.dot(d) / w, u.dot(d) / w);
        let n = face as f32;
        [
            gutter as f32 + (x * 0.5 + 0.5) * n,
            gutter as f32 + (0.5 - y * 0.5) * n,
            1.0 - persp.near / w,
            if w < 0.0 { 1.0 } else { 0.0 },
        ]
    })
}

/// The passes on a point light's cube atlas: every face padded (`cube_atlas::pad`) with the
/// texels its walks reach (`length`, twice that for the closure, at most a face), converted to
/// q (a face is a 90° perspective map), filtered with its own epipole within its padded tile —
/// so an extrusion crosses into the neighbouring face where its line does — and the inner faces
/// cropped back.
pub(super) fn run_cube(
    gpu: &Recorder,
    tex: &Arc<GpuTexture>,
    light: &tyndall_engine::scene::LocalLight,
    camera: &Matrices,
    length: i32,
    op: EpiOp,
) -> Result<Arc<GpuTexture>, GpuError> {
    if length == 0 {
        return Ok(tex.clone());
    }
    let face = tex.width / 3;
    let reach = if op == EpiOp::Closure { 2 } else { 1 } * length;
    let gutter = crate::algorithms::cube_atlas::gutter_for(reach, face);
    let padded = crate::algorithms::cube_atlas::pad(gpu, tex, light, gutter)?;
    let persp = Perspective {
        near: light.near,
        far: light.far,
    };
    let faces = cube_epipoles(light, camera, face, gutter);
    let p = EpiParams {
        epipole: [0.0; 2],
        z_l: 0.0,
        length,
        op: 0,
        reverse: 0,
        tiles: [3, 2],
        faces,
    };
    let src = to_q(gpu, &padded, persp)?;
    let mut out = pass(gpu, &src, p)?;
    if op == EpiOp::Closure {
        out = pass(gpu, &out, EpiParams { op: 1, ..p })?;
    }
    let out = from_q(gpu, &padded, &src, &out, persp)?;
    crate::algorithms::cube_atlas::crop(gpu, &out, face, light)
}

/// CPU reference of the node on a point light's cube atlas (`run_cube`'s steps: pad, q, each
/// padded face through [`reference_sides`] with its epipole, back, crop).
pub fn reference_cube(
    atlas: &Raster,
    light: &tyndall_engine::scene::LocalLight,
    camera: &Matrices,
    length: i32,
    closure: bool,
) -> Raster {
    use crate::algorithms::cube_atlas::{crop_reference, gutter_for, pad_reference};
    let face = atlas.width / 3;
    let gutter = gutter_for(if closure { 2 * length } else { length }, face);
    let padded = pad_reference(atlas, light, gutter);
    let pf = face + 2 * gutter;
    let persp = Perspective {
        near: light.near,
        far: light.far,
    };
    let faces = cube_epipoles(light, camera, face, gutter);
    let mut out = padded.clone();
    for (k, e) in faces.iter().enumerate() {
        let (ox, oy) = ((k as u32 % 3) * pf, (k as u32 / 3) * pf);
        let mut tile = Raster::new(pf, pf, 1, 0.0);
        for y in 0..pf {
            for x in 0..pf {
                tile.data[(y * pf + x) as usize] =
                    padded.data[((oy + y) * 3 * pf + ox + x) as usize];
            }
        }
        let r = reference_spot(
            &tile,
            persp,
            ([e[0], e[1]], e[2], e[3] != 0.0),
            length,
            closure,
        );
        for y in 0..pf {
            for x in 0..pf {
                out.data[((oy + y) * 3 * pf + ox + x) as usize] = r.data[(y * pf + x) as usize];
            }
        }
    }
    crop_reference(&out, face)
}
