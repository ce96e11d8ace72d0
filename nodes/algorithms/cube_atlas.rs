//! Neighbourhood filters on a point light's cube atlas without seams (issue #44, item 4).
//!
//! A point light's shadow map is six 90° faces in a 3 × 2 atlas (`ShadowMap`); faces that touch
//! on the cube are not neighbours in the atlas, so a filter that reads a texel's neighbours
//! (`Dilate2D`, `Erode2D`, `Closure2D`) would mix unrelated faces along every seam and leave a
//! closed hole open in a strip along it. [`pad`] gives every face a gutter of `g` texels: the
//! face's image plane extended past its edges (direction `f + a·s + b·u`, `|a|` or `|b| > 1`),
//! each gutter texel looked up on the face that direction falls on and its depth re-measured
//! along this face's axis — what rendering the face with a wider field of view would store
//! (an occluder at depth `d'` along the other face's axis `f'` lies at `k · dir` with
//! `k (f'·dir) = d'`, and `f·dir = 1`, so its depth here is `k`). A filter of radius ≤ `g` then
//! runs on the padded atlas as on any map, and [`crop`] takes each face's inner square back.
//! A clear texel (no occluder, [`tyndall_engine::eval::SHADOW_CLEAR`]) stays clear. [`pad_reference`] / [`crop_reference`] are the
//! CPU twins; `shaders/algorithms/cube_atlas.wgsl` the GPU passes.

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use glam::Vec3;
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat, UniformLayout};
use tyndall_engine::io::Raster;
use tyndall_engine::scene::{cube_face, face_basis, LocalLight};

/// The pad and crop passes.
pub const SHADER: Shader = crate::shader(
    "algorithms/cube_atlas",
    include_str!("../../shaders/algorithms/cube_atlas.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/algorithms/cube_atlas.wgsl` (struct `CubeParams`).
    pub struct CubeParams as "CubeParams" {
        /// Face size, texels.
        pub face: u32,
        /// Gutter width, texels.
        pub gutter: u32,
        /// Depth 0 along each face's axis, m.
        pub near: f32,
        /// Depth 1 along each face's axis, m.
        pub far: f32,
    }
}

/// The uniform layouts a node using these passes declares.
pub const UNIFORMS: UniformLayout = CubeParams::LAYOUT;

/// The gutter a filter of radius `r` needs, at most the face size (a wider filter sees the
/// whole cube anyway).
pub fn gutter_for(r: i32, face: u32) -> u32 {
    (r.max(0) as u32).min(face)
}

fn params(face: u32, gutter: u32, light: &LocalLight) -> CubeParams {
    CubeParams {
        face,
        gutter,
        near: light.near,
        far: light.far,
    }
}

/// `atlas` (3 × 2 faces of `w / 3` texels) with a gutter of `gutter` texels around every face:
/// 3 × 2 faces of `w / 3 + 2 · gutter`.
pub fn pad(
    gpu: &Recorder,
    atlas: &GpuTexture,
    light: &LocalLight,
    gutter: u32,
) -> Result<Arc<GpuTexture>, GpuError> {
    let face = atlas.width / 3;
    let pf = face + 2 * gutter;
    let out = gpu.texture(3 * pf, 2 * pf, TexFormat::R32F)?;
    let u = params(face, gutter, light);
    gpu.dispatch(
        SHADER,
        "pad",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(atlas)),
            ("out_map", Bind::Storage(&out)),
        ],
        3 * pf,
        2 * pf,
    )?;
    Ok(Arc::new(out))
}

/// The inner faces of a padded atlas (see [`pad`]) of faces `face` texels wide.
pub fn crop(
    gpu: &Recorder,
    padded: &GpuTexture,
    face: u32,
    light: &LocalLight,
) -> Result<Arc<GpuTexture>, GpuError> {
    let gutter = (padded.width / 3 - face) / 2;
    let out = gpu.texture(3 * face, 2 * face, TexFormat::R32F)?;
    let u = params(face, gutter, light);
    gpu.dispatch(
        SHADER,
        "crop",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(padded)),
            ("out_map", Bind::Storage(&out)),
        ],
        3 * face,
        2 * face,
    )?;
    Ok(Arc::new(out))
}

/// CPU reference of [`pad`] on a one-channel atlas.
pub fn pad_reference(atlas: &Raster, light: &LocalLight, gutter: u32) -> Raster {
    let n = atlas.width / 3;
    let pf = n + 2 * gutter;
    let mut out = Raster::new(3 * pf, 2 * pf, 1, 0.0);
    let span = light.far - light.near;
    for y in 0..2 * pf {
        for x in 0..3 * pf {
            let face = (x / pf + 3 * (y / pf)) as usize;
            let t = glam::Vec2::new(
                (x % pf) as f32 + 0.5 - gutter as f32,
                (y % pf) as f32 + 0.5 - gutter as f32,
            );
            let ndc = glam::Vec2::new(t.x / n as f32 * 2.0 - 1.0, 1.0 - t.y / n as f32 * 2.0);
            let (f, s, u) = face_basis(face);
            let dir: Vec3 = f + ndc.x * s + ndc.y * u;
            let other = cube_face(dir);
            let (fo, so, uo) = face_basis(other);
            let along = fo.dot(dir);
            let nd = glam::Vec2::new(so.dot(dir), uo.dot(dir)) / along;
            let uv = glam::Vec2::new(nd.x * 0.5 + 0.5, 0.5 - nd.y * 0.5)
                .clamp(glam::Vec2::ZERO, glam::Vec2::splat(0.999_999));
            let tx = ((uv.x * n as f32) as u32).min(n - 1) + (other as u32 % 3) * n;
            let ty = ((uv.y * n as f32) as u32).min(n - 1) + (other as u32 / 3) * n;
            let v = atlas.data[(ty * atlas.width + tx) as usize];
            let value = if !tyndall_engine::eval::is_clear(v) && other != face {
                let k = (light.near + v * span) / along;
                (k - light.near) / span
            } else {
                v
            };
            out.data[(y * 3 * pf + x) as usize] = value;
        }
    }
    out
}

/// CPU reference of [`crop`].
pub fn crop_reference(padded: &Raster, face: u32) -> Raster {
    let pf = padded.width / 3;
    let g = (pf - face) / 2;
    let mut out = Raster::new(3 * face, 2 * face, 1, 0.0);
    for y in 0..2 * face {
        for x in 0..3 * face {
            let f = x / face + 3 * (y / face);
            let sx = (f % 3) * pf + g + x % face;
            let sy = (f / 3) * pf + g + y % face;
            out.data[(y * 3 * face + x) as usize] = padded.data[(sy * padded.width + sx) as usize];
        }
    }
    out
}
