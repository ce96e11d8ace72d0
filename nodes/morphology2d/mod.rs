//! `Dilate2D`, `Erode2D`, `Closure2D`: 2D morphology on shadow maps (SPEC §4 hole filling,
//! seed 000 §4.1).
//!
//! Dilation takes the per-texel **minimum** over the footprint (occluders grow), erosion the
//! **maximum**, closure a dilation then an erosion with the same footprint, so holes smaller
//! than the kernel close. Footprint: `Circle` (dx² + dy² ≤ r²) or `Square` (|dx|, |dy| ≤ r),
//! kernel size 2r + 1; texels outside the map are not part of it. The three kinds share one
//! implementation and its shaders (`shaders/morphology2d/`).
//!
//! Methods. Square: two van Herk / Gil–Werman passes, constant per texel whatever r (`Fast` and
//! `Exact` are the same). Circle, `Exact`: one horizontal van Herk pass per distinct chord
//! width, folded row by row (`chords.wgsl`), linear in r. Circle, `Fast`: a 16-gon close to the
//! disk (closest in support, so edges move as the disk moves them), the Minkowski sum of
//! segments in eight directions, one van Herk pass each (`polygon.rs`, `lines.wgsl`), flat in r; at radii where the chords need no more passes
//! (r ≤ 7) it is the exact disk. `BruteForce` visits the whole footprint (O(r²)), for
//! benchmarks. Each equals its CPU reference exactly (min and max involve no rounding); how far
//! the polygon is from the disk is measured in `benches/morphology.ron` and bounded in
//! `tests/filters/morphology.rs`.
//!
//! Any light's map: a spot's perspective map is filtered like a sun's (radii in its texels); a
//! point light's cube atlas is filtered face by face with a gutter taken from the neighbouring
//! faces (`nodes/algorithms/cube_atlas.rs`), so a hole straddling two faces closes as one hole.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `map` | in | ShadowMap \| Scalar (required) |
//! | `map` | out | same as the input (a ShadowMap keeps its matrices) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `shape` | Enum | Circle | Circle, Square | footprint |
//! | `radius` | Float | 4 | 0…4096 | r, rounded to whole texels (kernel 2r + 1); 0 is the identity |
//! | `unit` | Enum | texels | texels, metres | metres: r is a world size, converted with the map's light matrices, so a preset keeps its look at any map resolution (a sun's map only: a lamp's is perspective, refused) |
//! | `method` | Enum | Fast | Fast, Exact, BruteForce | algorithm: Fast = the polygon for a circle of r ≥ 8 (cost flat in r), Exact = the exact disk (chords, linear in r), BruteForce = whole footprint |

mod polygon;

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use crate::algorithms::cube_atlas;

pub use polygon::{
    disk_support, footprint_difference, polygon, polygon_pays, polygon_span, reference_lines,
    segments, support_error, LineParams, DIRECTIONS, EXHAUSTIVE_BELOW, POLYGON_FROM,
    SUPPORT_DIRECTIONS,
};

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat, UniformLayout};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// Which morphological operation a kind performs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// Minimum (occluders grow).
    Dilate,
    /// Maximum (occluders shrink).
    Erode,
    /// Dilation then erosion.
    Closure,
}

/// A 2D morphology node kind.
pub struct Morphology2D(pub Op);

tyndall_engine::choice_enum! {
    /// Footprint shapes.
    pub enum Shape { Circle = "Circle", Square = "Square" }
}
tyndall_engine::choice_enum! {
    /// Radius units.
    pub enum Unit { Texels = "texels", Metres = "metres" }
}
tyndall_engine::choice_enum! {
    /// Algorithms.
    pub enum Method { Fast = "Fast", Exact = "Exact", BruteForce = "BruteForce" }
}

const MAPS: &[PortType] = &[PortType::Scalar, PortType::ShadowMap];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The family's parameters, read once per run.
    pub struct Params {
        shape: Shape = ParamSpec::choice("shape", Shape::NAMES, "Circle", "Footprint: Circle (dx² + dy² ≤ r²) or Square."),
        radius: f64 = ParamSpec::float("radius", 4.0, 0.0, 4096.0, "texels or m", "Kernel radius r (kernel size 2r + 1), rounded to whole texels; 0 is the identity.").light_texels_when("unit", &["texels"]),
        unit: Unit = ParamSpec::choice("unit", Unit::NAMES, "texels", "texels, or metres (converted with the shadow map's light matrices)."),
        method: Method = ParamSpec::choice("method", Method::NAMES, "Fast", "Fast (square: van Herk / Gil–Werman; circle of r ≥ 8: a 16-gon of line passes, cost flat in r), Exact (circle: the exact disk, chords, linear in r) or BruteForce (whole footprint)."),
    }
}

#[rustfmt::skip]
const IN: &[PortSpec] = &[PortSpec::required("map", MAPS, "Shadow map (or any one-channel image).")];
#[rustfmt::skip]
const OUT: &[PortSpec] = &[PortSpec::output("map", MAPS, "The filtered map, same type as the input.")];

/// The square and the exact circle (chords), and brute force.
const SHADER: Shader = crate::shader(
    "morphology2d/chords",
    include_str!("../../shaders/morphology2d/chords.wgsl"),
);
/// The polygon's line passes.
const SHADER_LINES: Shader = crate::shader(
    "morphology2d/lines",
    include_str!("../../shaders/morphology2d/lines.wgsl"),
);

const fn decl(kind: &'static str, doc: &'static str) -> NodeDecl {
    let schema = NodeSchema {
        kind,
        category: "Occluders",
        doc,
        inputs: IN,
        outputs: OUT,
        params: Params::SPECS,
    };
    NodeDecl::new(schema)
        .shaders(&[SHADER, SHADER_LINES, cube_atlas::SHADER])
        .uniforms(UNIFORMS)
}
const UNIFORMS: &[UniformLayout] = &[
    MorphParams::LAYOUT,
    LineParams::LAYOUT,
    cube_atlas::UNIFORMS,
];

static DILATE: NodeDecl = decl(
    "Dilate2D",
    "Per-texel minimum over a circle or square: occluders in the shadow map grow.",
);
static ERODE: NodeDecl = decl(
    "Erode2D",
    "Per-texel maximum over a circle or square: occluders in the shadow map shrink.",
);
static CLOSURE: NodeDecl = decl(
    "Closure2D",
    "Dilation then erosion (seed 000 hole filling): holes smaller than the kernel close, shafts simplify.",
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/morphology2d/chords.wgsl` (struct `Params`).
    pub struct MorphParams as "Params" {
        /// Radius in texels.
        pub r: i32,
        /// 0 min, 1 max.
        pub op: u32,
        /// 0 rows, 1 columns.
        pub axis: u32,
        /// 0 circle, 1 square.
        pub shape: u32,
        /// Accumulate: first |dy|.
        pub dy_lo: i32,
        /// Accumulate: last |dy|.
        pub dy_hi: i32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

/// CPU reference: min (`max = false`) or max over the footprint, texels outside ignored.
pub fn reference(map: &Raster, r: i32, circle: bool, max: bool) -> Raster {
    let (w, h) = (map.width as i32, map.height as i32);
    let mut out = map.clone();
    for y in 0..h {
        for x in 0..w {
            let mut v = if max { f32::MIN } else { f32::MAX };
            for dy in -r..=r {
                for dx in -r..=r {
                    if circle && dx * dx + dy * dy > r * r {
                        continue;
                    }
                    let (qx, qy) = (x + dx, y + dy);
                    if qx >= 0 && qy >= 0 && qx < w && qy < h {
                        let s = map.data[(qy * w + qx) as usize];
                        v = if max { v.max(s) } else { v.min(s) };
                    }
                }
            }
            out.data[(y * w + x) as usize] = v;
        }
    }
    out
}

/// CPU reference of the closure.
pub fn reference_closure(map: &Raster, r: i32, circle: bool) -> Raster {
    reference(&reference(map, r, circle, false), r, circle, true)
}

/// The radius filtered: beyond the map's extent (square) or diagonal (circle) a larger kernel
/// covers nothing more; capping keeps block sizes and loops bounded.
pub fn capped(r: i32, w: u32, h: u32, circle: bool) -> i32 {
    let extent = if circle {
        ((w as f64).hypot(h as f64)).ceil() as i32
    } else {
        w.max(h) as i32
    };
    r.min(extent)
}

/// CPU reference of `method = Fast`: the polygon's line passes where [`polygon_pays`], else
/// [`reference()`].
pub fn reference_fast(map: &Raster, r: i32, circle: bool, max: bool) -> Raster {
    let r = capped(r, map.width, map.height, circle);
    if circle && polygon_pays(r) {
        reference_lines(map, &segments(polygon(r)), max)
    } else {
        reference(map, r, circle, max)
    }
}

/// Half-width of the circle's chord at row offset `dy`: the largest w with w² + dy² ≤ r².
pub fn chord(r: i32, dy: i32) -> i32 {
    let rem = (r as i64 * r as i64 - dy as i64 * dy as i64).max(0);
    let mut w = (rem as f64).sqrt() as i64;
    while w * w > rem {
        w -= 1;
    }
    while (w + 1) * (w + 1) <= rem {
        w += 1;
    }
    w as i32
}

/// Radius in texels for `radius` in `unit` on a map with these matrices and width.
pub fn radius_texels(
    radius: f64,
    unit: Unit,
    m: Option<&Matrices>,
    width: u32,
) -> Result<i32, NodeError> {
    let texels = match (unit, m) {
        (Unit::Metres, Some(m)) if m.local.is_some() => {
            return Err(NodeError::Param {
                param: "unit".into(),
                message: "metres needs a sun's (orthographic) map: a spot's or point light's \
                          texel grows with the distance from the light, so give the radius in texels"
                    .into(),
            })
        }
        (Unit::Metres, Some(m)) => {
            // Orthographic: clip x = proj[0][0] · view x, over 2 clip units = width texels.
            let sx = m.proj[0][0].abs() as f64;
            radius * sx * width as f64 / 2.0
        }
        (Unit::Metres, None) => {
            return Err(NodeError::Param {
                param: "unit".into(),
                message: "metres needs a ShadowMap input (a Scalar has no light matrices)".into(),
            })
        }
        (Unit::Texels, _) => radius,
    };
    Ok(texels.round().clamp(0.0, 1e6) as i32)
}

fn pass(
    gpu: &Recorder,
    src: &GpuTexture,
    r: i32,
    max: bool,
    axis: u32,
) -> Result<GpuTexture, GpuError> {
    let (w, h) = (src.width, src.height);
    let u = MorphParams {
        r,
        op: max as u32,
        axis,
        shape: 0,
        dy_lo: 0,
        dy_hi: 0,
        _pad0: 0,
        _pad1: 0,
    };
    let prefix = gpu.texture(w, h, TexFormat::R32F)?;
    let suffix = gpu.texture(w, h, TexFormat::R32F)?;
    let (n, lines) = if axis == 0 { (w, h) } else { (h, w) };
    let k = 2 * r as u32 + 1;
    let bytes = bytemuck::bytes_of(&u);
    gpu.dispatch(
        SHADER,
        "blocks",
        &[
            ("P", Bind::Uniform(bytes)),
            ("src", Bind::Texture(src)),
            ("prefix_out", Bind::Storage(&prefix)),
            ("suffix_out", Bind::Storage(&suffix)),
        ],
        n.div_ceil(k),
        lines,
    )?;
    let out = gpu.texture(w, h, TexFormat::R32F)?;
    gpu.dispatch(
        SHADER,
        "combine",
        &[
            ("P", Bind::Uniform(bytes)),
            ("src", Bind::Texture(src)),
            ("prefix_in", Bind::Texture(&prefix)),
            ("suffix_in", Bind::Texture(&suffix)),
            ("out_map", Bind::Storage(&out)),
        ],
        w,
        h,
    )?;
    Ok(out)
}

/// Min (or max) filter of `src` on the GPU by `method`.
pub fn filter(
    gpu: &Recorder,
    src: &Arc<GpuTexture>,
    r: i32,
    circle: bool,
    max: bool,
    method: Method,
) -> Result<Arc<GpuTexture>, GpuError> {
    if r == 0 {
        return Ok(src.clone());
    }
    let (w, h) = (src.width, src.height);
    let r = capped(r, w, h, circle);
    if method == Method::BruteForce {
        let u = MorphParams {
            r,
            op: max as u32,
            axis: 0,
            shape: if circle { 0 } else { 1 },
            dy_lo: 0,
            dy_hi: 0,
            _pad0: 0,
            _pad1: 0,
        };
        let out = gpu.texture(w, h, TexFormat::R32F)?;
        gpu.dispatch(
            SHADER,
            "brute",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("src", Bind::Texture(src)),
                ("out_map", Bind::Storage(&out)),
            ],
            w,
            h,
        )?;
        return Ok(Arc::new(out));
    }
    if !circle {
        let rows = pass(gpu, src, r, max, 0)?;
        return Ok(Arc::new(pass(gpu, &rows, r, max, 1)?));
    }
    if method == Method::Fast && polygon_pays(r) {
        return polygon::filter(gpu, src, r, max);
    }
    // Circle: group row offsets |dy| by chord half-width (w decreases as |dy| grows).
    let mut acc: Option<GpuTexture> = None;
    let mut dy = 0;
    while dy <= r {
        let half = chord(r, dy);
        let mut last = dy;
        while last < r && chord(r, last + 1) == half {
            last += 1;
        }
        let rows = if half == 0 {
            None
        } else {
            Some(pass(gpu, src, half, max, 0)?)
        };
        let row_src: &GpuTexture = rows.as_ref().unwrap_or(src);
        let u = MorphParams {
            r,
            op: max as u32,
            axis: 0,
            shape: 0,
            dy_lo: dy,
            dy_hi: last,
            _pad0: 0,
            _pad1: 0,
        };
        let out = gpu.texture(w, h, TexFormat::R32F)?;
        let acc_tex: &GpuTexture = acc.as_ref().unwrap_or(row_src);
        gpu.dispatch(
            SHADER,
            "accumulate",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("src", Bind::Texture(row_src)),
                ("out_map", Bind::Storage(&out)),
                ("acc_in", Bind::Texture(acc_tex)),
            ],
            w,
            h,
        )?;
        acc = Some(out);
        dy = last + 1;
    }
    match acc {
        Some(a) => Ok(Arc::new(a)),
        None => Ok(src.clone()),
    }
}

impl NodeKind for Morphology2D {
    fn decl(&self) -> &'static NodeDecl {
        match self.0 {
            Op::Dilate => &DILATE,
            Op::Erode => &ERODE,
            Op::Closure => &CLOSURE,
        }
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let input = ctx.require("map")?.clone();
        let (tex, m) = match &input {
            PortValue::ShadowMap(t, m) => (t.clone(), Some(*m)),
            PortValue::Scalar(t) => (t.clone(), None),
            _ => {
                return Err(NodeError::Input {
                    port: "map".into(),
                    message: "is not a one-channel map".into(),
                })
            }
        };
        let p = Params::from_ctx(ctx)?;
        let r = radius_texels(p.radius, p.unit, m.as_ref(), tex.width)?;
        let circle = p.shape == Shape::Circle;
        let method = p.method;
        let op = |src: &Arc<GpuTexture>| -> Result<Arc<GpuTexture>, GpuError> {
            Ok(match self.0 {
                Op::Dilate => filter(ctx.gpu, src, r, circle, false, method)?,
                Op::Erode => filter(ctx.gpu, src, r, circle, true, method)?,
                Op::Closure => {
                    let d = filter(ctx.gpu, src, r, circle, false, method)?;
                    filter(ctx.gpu, &d, r, circle, true, method)?
                }
            })
        };
        // A point light's cube atlas: every face padded with what lies past its edges on the
        // cube, filtered, cropped — no seams (nodes/algorithms/cube_atlas.rs). A closure reads 2r deep.
        let cube = m.and_then(|m| m.local).filter(|l| l.point);
        let out = match cube {
            Some(light) if r > 0 => {
                let face = tex.width / 3;
                let reach = if self.0 == Op::Closure { 2 * r } else { r };
                let padded =
                    cube_atlas::pad(ctx.gpu, &tex, &light, cube_atlas::gutter_for(reach, face))?;
                cube_atlas::crop(ctx.gpu, &*op(&padded)?, face, &light)?
            }
            _ => op(&tex)?,
        };
        ctx.set(
            "map",
            match m {
                Some(m) => PortValue::ShadowMap(out, m),
                None => PortValue::Scalar(out),
            },
        );
        Ok(())
    }
}
