//! `EpipolarDilation`, `EpipolarClosure`: silhouette enhancement by 1D morphology along
//! epipolar lines (SPEC §4, seed 000 eq. 3, seed 001 §4.1, Fig. 8).
//!
//! The epipole `l` is the camera position projected into the shadow map (texel units, may lie
//! far outside the map) with light-space depth `z_l` (may lie outside [0, 1]). For texel t at
//! distance d_t > 0 from l, samples s are taken at i = 1…`length` texels along the unit
//! direction from t towards l (nearest texel, stopping at the map border and before reaching
//! l), each giving `d_t/d_s · (z_s − z_l) + z_l`; the dilation is the minimum of these and z_t
//! (eq. 3). In slope space κ = (z − z_l)/d this is a plain 1D minimum of κ along the ray. The
//! closure follows with the dual erosion (maximum, samples on the far side from l). A texel at
//! the epipole is unchanged; samples at the epipole are skipped.
//!
//! The epipole comes from the `camera` input (a Depth's camera, projected with the map's light
//! matrices) when connected, else from the parameters.
//!
//! Any light's map: on a spot's perspective map eq. 3 holds for q = 1 − near / w (w the
//! distance along the spot's axis; 1/w, not the linear depth, is affine across a perspective
//! map), so the passes run on q and convert back ([`Perspective`]); a camera behind the spot's
//! plane swaps the sides each operation samples. `method = Fast` runs the definition there.
//! Test: `cargo test --test filters -- spot`: every filled texel lies on the view ray through
//! the occluder, within its footprint (129 texels off without the conversion). A point light's
//! cube atlas is six such maps, each with its own epipole (the camera's direction from the
//! light projected onto the face's plane), padded with its neighbours (`cube_atlas`) so a
//! line that leaves a face goes on in the next (`run_cube`); it needs the `camera` input and
//! runs the definition whatever `method` says (`cargo test --test filters -- cube`).
//!
//! | port | dir | type |
//! |---|---|---|
//! | `map` | in | ShadowMap (required) |
//! | `camera` | in | Depth (optional; needed on a point light's atlas): camera whose position is the epipole |
//! | `map` | out | ShadowMap (same matrices) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `length` | Int | 15 | 0…4096 texels | kernel length k; 0 is the identity |
//! | `epipole_x`, `epipole_y` | Float | 0, 0 | ±1e9 texels | epipole when `camera` is unconnected |
//! | `epipole_depth` | Float | 0 | ±1e9 | z_l when `camera` is unconnected |
//! | `method` | Enum | Reference | Reference, Fast | algorithm |
//!
//! `method = Reference` runs the definition above on the GPU, O(length) per texel. `Fast`
//! gives the same result on every texel with a cost that does not grow with `length` on shadow
//! maps: each texel takes its first and last [`ENDS`] samples exactly and bounds the samples in
//! between with a rectified grid of epipolar rays (rows one texel of arc apart at the far edge,
//! columns one texel of distance apart; each cell holds the min, or max, of κ over the 3×3
//! texels around its point, then a van Herk / Gil–Werman 1D filter runs along each row). When
//! the ends already beat the bound, they are the definition's answer; otherwise, or when the
//! texel's samples stray further from the grid points than a block covers (epipoles ~1e7
//! texels away, where f32 angles are too coarse), that texel runs the exact loop. How many
//! texels fall back depends on the map (a small share on the built-in scenes' shadow maps,
//! growing with `length`; most texels on noise); only their share of the work grows with
//! `length`. The grid costs several texels' worth of
//! work per texel (its disc around the epipole is larger than the map), so on lavapipe `Fast`
//! is slower than `Reference` at lengths up to 60 (BENCHMARKS.md), which is why `Reference`
//! stays the default.

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat, UniformLayout};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

use crate::algorithms::shader_lib::keep_clear;

mod fast;
mod lamp;
use fast::fast_pass;
pub use fast::{rect_params, RectParams, Rectified, ENDS};
pub use lamp::{
    cube_epipoles, reference_cube, reference_spot, spot_epipole, PerspParams, Perspective,
};
use lamp::{from_q, run_cube, to_q};

/// Which epipolar operation a kind performs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EpiOp {
    /// Minimum towards the epipole.
    Dilation,
    /// Dilation then the dual erosion.
    Closure,
}

/// An epipolar morphology node kind.
pub struct Epipolar(pub EpiOp);

tyndall_engine::choice_enum! {
    /// Algorithms (same result).
    pub enum Method { Reference = "Reference", Fast = "Fast" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The family's parameters, read once per run.
    pub struct Params {
        method: Method = ParamSpec::choice("method", Method::NAMES, "Reference", "Reference (the definition, O(length) per texel) or Fast (same result; exact end samples proven against a rectified-grid van Herk bound, cost flat in length on shadow maps; faster on CPU drivers, but 20× slower than Reference on an NVIDIA H200 at 2048²: keep Reference on a GPU)."),
        length: i64 = ParamSpec::int("length", 15, 0, 4096, "texels", "Kernel length k along the epipolar line; 0 is the identity.").light_texels(),
        epipole_x: f32 = ParamSpec::float("epipole_x", 0.0, -1e9, 1e9, "texels", "Epipole x (when `camera` is unconnected); may lie outside the map.").light_texels(),
        epipole_y: f32 = ParamSpec::float("epipole_y", 0.0, -1e9, 1e9, "texels", "Epipole y (when `camera` is unconnected); may lie outside the map.").light_texels(),
        epipole_depth: f32 = ParamSpec::float("epipole_depth", 0.0, -1e9, 1e9, "depth", "Epipole light-space depth z_l (when `camera` is unconnected); may lie outside [0, 1]."),
    }
}

#[rustfmt::skip]
const IN: &[PortSpec] = &[
    PortSpec::required("map", &[PortType::ShadowMap], "Shadow map to sharpen."),
    PortSpec::input("camera", &[PortType::Depth], "Camera whose position gives the epipole (needed on a point light's cube atlas)."),
];
#[rustfmt::skip]
const OUT: &[PortSpec] = &[PortSpec::output("map", &[PortType::ShadowMap], "The filtered map.")];

const SHADER: Shader = crate::shader("epipolar", include_str!("../../shaders/epipolar.wgsl"));

const fn decl(kind: &'static str, doc: &'static str) -> NodeDecl {
    let schema = NodeSchema {
        kind,
        category: "Occluders",
        doc,
        inputs: IN,
        outputs: OUT,
        params: Params::SPECS,
    };
    NodeDecl::new(schema).shaders(&[SHADER]).uniforms(UNIFORMS)
}
const UNIFORMS: &[UniformLayout] = &[EpiParams::LAYOUT, RectParams::LAYOUT, PerspParams::LAYOUT];

static DILATION: NodeDecl = decl(
    "EpipolarDilation",
    "1D dilation along epipolar lines (seed eq. 3): silhouettes extrude towards the camera, shafts sharpen.",
);
static CLOSURE: NodeDecl = decl(
    "EpipolarClosure",
    "Epipolar dilation then the dual erosion: occlusion stays behind objects, shaft edges sharpen.",
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/epipolar.wgsl` (struct `Params`).
    pub struct EpiParams as "Params" {
        /// Epipole, texel units.
        pub epipole: [f32; 2],
        /// z_l.
        pub z_l: f32,
        /// k.
        pub length: i32,
        /// 0 dilation (min towards l), 1 erosion (max away from l).
        pub op: u32,
        /// 1: each operation samples the other side of the texel (see [`Perspective`]).
        pub reverse: u32,
        /// Tiles across and down: [1, 1], or [3, 2] for a point light's padded cube faces.
        pub tiles: [u32; 2],
        /// Per cube face (tiles [3, 2]): epipole (texels from its tile's corner), z_l, reverse.
        pub faces: [[f32; 4]; 6],
    }
}

/// CPU reference of one pass (`erode = false`: the dilation of eq. 3), in the same f32 steps as
/// the shader.
pub fn reference(map: &Raster, l: [f32; 2], z_l: f32, length: i32, erode: bool) -> Raster {
    reference_sides(map, l, z_l, length, erode, false)
}

/// [`reference()`] with the sides swapped when `reverse` (the `reverse` uniform).
pub fn reference_sides(
    map: &Raster,
    l: [f32; 2],
    z_l: f32,
    length: i32,
    erode: bool,
    reverse: bool,
) -> Raster {
    let (w, h) = (map.width as i32, map.height as i32);
    let mut out = map.clone();
    for y in 0..h {
        for x in 0..w {
            let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
            let z = map.data[(y * w + x) as usize];
            let (tx, ty) = (l[0] - cx, l[1] - cy);
            let d_t = (tx * tx + ty * ty).sqrt();
            if d_t <= 0.0 {
                continue;
            }
            let towards = erode == reverse;
            let (dx, dy) = if towards {
                (tx / d_t, ty / d_t)
            } else {
                (-tx / d_t, -ty / d_t)
            };
            let mut k = keep_clear(z, (z - z_l) / d_t);
            for i in 1..=length {
                if towards && i as f32 >= d_t {
                    break;
                }
                let (sx, sy) = (
                    (cx + dx * i as f32).floor() as i32,
                    (cy + dy * i as f32).floor() as i32,
                );
                if sx < 0 || sy < 0 || sx >= w || sy >= h {
                    break;
                }
                let (ex, ey) = (l[0] - (sx as f32 + 0.5), l[1] - (sy as f32 + 0.5));
                let d_s = (ex * ex + ey * ey).sqrt();
                if d_s <= 0.0 {
                    continue;
                }
                let zs = map.data[(sy * w + sx) as usize];
                let ks = keep_clear(zs, (zs - z_l) / d_s);
                k = if erode { k.max(ks) } else { k.min(ks) };
            }
            out.data[(y * w + x) as usize] = keep_clear(k, z_l + d_t * k);
        }
    }
    out
}

/// The epipole (texel units) and its depth: the camera position projected with the light's
/// matrices into a `w × h` map.
pub fn epipole(light: &Matrices, camera: &Matrices, w: u32, h: u32) -> ([f32; 2], f32) {
    let c = light.view_proj().project_point3(camera.eye());
    (
        [(c.x * 0.5 + 0.5) * w as f32, (0.5 - c.y * 0.5) * h as f32],
        c.z,
    )
}

fn pass(gpu: &Recorder, src: &GpuTexture, p: EpiParams) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(src.width, src.height, TexFormat::R32F)?;
    gpu.dispatch(
        SHADER,
        "reference",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&p))),
            ("src", Bind::Texture(src)),
            ("out_map", Bind::Storage(&out)),
        ],
        src.width,
        src.height,
    )?;
    Ok(out)
}

impl NodeKind for Epipolar {
    fn decl(&self) -> &'static NodeDecl {
        match self.0 {
            EpiOp::Dilation => &DILATION,
            EpiOp::Closure => &CLOSURE,
        }
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let prm = Params::from_ctx(ctx)?;
        let (tex, light) = ctx.shadow_map("map")?;
        if let Some(l) = light.local.filter(|l| l.point) {
            let Some((_, cam)) = ctx.depth_opt("camera")? else {
                return Err(NodeError::Input {
                    port: "camera".into(),
                    message: "is needed on a point light's cube atlas: each of its six faces has \
                              its own epipole, the camera seen from the light"
                        .into(),
                });
            };
            let out = run_cube(ctx.gpu, &tex, &l, &cam, prm.length as i32, self.0)?;
            ctx.set("map", PortValue::ShadowMap(out, light));
            return Ok(());
        }
        let persp = light.local.map(|l| Perspective {
            near: l.near,
            far: l.far,
        });
        let (l, z_l, reverse) = match (ctx.depth_opt("camera")?, persp) {
            (Some((_, cam)), Some(p)) => spot_epipole(&light, &cam, p, tex.width, tex.height)
                .map_err(|message| NodeError::Input {
                    port: "camera".into(),
                    message,
                })?,
            (Some((_, cam)), None) => {
                let (l, z) = epipole(&light, &cam, tex.width, tex.height);
                (l, z, false)
            }
            (None, Some(p)) => (
                [prm.epipole_x, prm.epipole_y],
                p.q(prm.epipole_depth),
                false,
            ),
            (None, None) => ([prm.epipole_x, prm.epipole_y], prm.epipole_depth, false),
        };
        let length = prm.length as i32;
        if length == 0 {
            ctx.set("map", PortValue::ShadowMap(tex, light));
            return Ok(());
        }
        let p = EpiParams {
            epipole: l,
            z_l,
            length,
            op: 0,
            reverse: reverse as u32,
            tiles: [1, 1],
            faces: [[0.0; 4]; 6],
        };
        // The fast path's grid is built for a sun's map; a spot's runs the definition.
        let run_pass = if prm.method == Method::Fast && persp.is_none() {
            fast_pass
        } else {
            pass
        };
        let src = match persp {
            Some(q) => Arc::new(to_q(ctx.gpu, &tex, q)?),
            None => tex.clone(),
        };
        let mut out = run_pass(ctx.gpu, &src, p)?;
        if self.0 == EpiOp::Closure {
            out = run_pass(ctx.gpu, &out, EpiParams { op: 1, ..p })?;
        }
        if let Some(q) = persp {
            out = from_q(ctx.gpu, &tex, &src, &out, q)?;
        }
        ctx.set("map", PortValue::ShadowMap(Arc::new(out), light));
        Ok(())
    }
}
