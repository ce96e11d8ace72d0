//! `TransferFunction`: recolour shafts by a 2D table indexed by the view ray's average
//! visibility V̄ and linear depth (SPEC §5, seed 000 §4.2).
//!
//! TF space: u = V̄ ∈ [0, 1] along x, v = (d − depth_min)/(depth_max − depth_min) clamped to
//! [0, 1] along y (depth_min = depth_max: v = 0 up to depth_min, 1 beyond). The table is baked
//! at `resolution` N: texel (i, j) holds the colour at ((i + 0.5)/N, (j + 0.5)/N); the lookup is
//! bilinear between texel centres with clamp to edge. `Replace`: output = TF rgb × intensity;
//! `Modulate`: output = inscatter ⊙ TF rgb × intensity (a grey TF scales the physical result, so
//! surfaces and shafts stay consistent). Output alpha is 1.
//!
//! The layer stack is the node's data block:
//!
//! ```ron
//! (layers: [
//!     (layer: Solid(colour: (0.05, 0.05, 0.1, 1.0)), blend: Alpha, opacity: 1.0),
//!     (layer: Gradient(from: (0.0, 0.0), to: (1.0, 0.0),
//!                      from_colour: (0.0, 0.0, 0.0, 1.0), to_colour: (1.0, 0.6, 0.2, 1.0)),
//!      blend: Multiply, opacity: 0.5),
//!     (layer: Diffusion(constraints: [(at: (0.8, 0.2), colour: (1.0, 0.1, 0.0, 1.0))]),
//!      blend: Alpha, opacity: 1.0),
//!     (layer: Image(path: "tf.png"), blend: Add, opacity: 1.0),
//! ])
//! ```
//!
//! Colours are linear RGB with alpha. Layers composite bottom to top over transparent black;
//! with a = opacity × the layer's alpha at the texel: `Alpha` dst = dst·(1 − a) + src·a;
//! `Multiply` dst = dst·(1 − a) + dst·src·a; `Add` dst = dst + src·a (rgb; alpha always
//! composites as `Alpha`: dst.a = dst.a·(1 − a) + a). `Solid` is one colour; `Gradient` colours a
//! point p by t = clamp((p − from)·(to − from)/|to − from|², 0, 1) (from = to: t = 0); `Image`
//! samples a picture file (PNG is decoded from sRGB, EXR is linear) stretched over the square,
//! row 0 at v = 0; `Diffusion` spreads its constraints' colours (rgba) over the layer like
//! diffusion curves: the harmonic function on the N×N grid (graph Laplacian, zero-flux edges)
//! taking each constraint's colour at the texel containing it (constraints sharing a texel are
//! averaged). One constraint gives a uniform layer, two a gradient along their segment; no
//! constraint gives a transparent layer. It is solved by multigrid V-cycles from the mean of the
//! constraint colours: weighted Jacobi (ω = 0.8, two sweeps before and after each correction),
//! restriction by summing 2×2 residuals, cell-centred bilinear prolongation, 40 sweeps on the
//! coarsest grid (≤ 4 texels a side); a coarse texel holding a constraint is tied to zero by the
//! conductance of [`pin`] rather than fixed. Each V-cycle divides the error by about 3 at every
//! resolution; `diffusion_cycles` (the quality knob) runs that many, and the default 8 is within
//! 1.0e-4 of the exact discrete solution on 256² (8e-4 after 6, 6e-3 after 4: measured once
//! against conjugate gradients in f64 with a probe that was not kept; the kept test,
//! `diffusion_converges_and_gpu_equals_cpu`, asserts ≤ 2e-4 after 8 cycles at 64²).
//!
//! Key-frames (the seed's sunrise): `(keys: [(t: 0.0, layers: [...]), (t: 48.0, layers: [...])])`
//! instead of `layers`; at time t the two neighbouring stacks are interpolated linearly in every
//! number (colours, positions, opacities); before the first key the first stack holds, after the
//! last the last. Stacks of neighbouring keys must have the same layers (kinds, blend modes,
//! image paths, constraint counts): to make a layer appear, give it opacity 0 in the earlier key.
//!
//! `lut` input: a baked table from another `TransferFunction` (one TF feeding several lookups);
//! when connected the data block is not used.
//!
//! 3D constraints (seed 000 §4.2): a diffusion constraint may carry `anchor: Some((object:
//! "walls", triangle: 1234, bary: (0.2, 0.3, 0.5)))`, a surface point as `tyndall pick` prints
//! it. Every frame the point is projected into the view of the `depth` input and the constraint
//! moves to that pixel's (V̄, normalised depth), so it follows the scene and the camera; while
//! the point is off screen or hidden behind a nearer surface the constraint keeps its `at`.
//! Anchors need the `scene`, `visibility` and `depth` inputs.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `visibility` | in | Scalar | V̄ (needed for `image`) |
//! | `depth` | in | Depth | linear depth (needed for `image` and `depth_range = auto`) |
//! | `inscatter` | in | Image | the physical in-scatter (needed for `Modulate`) |
//! | `lut` | in | Lut2D | a baked table to use instead of the data block |
//! | `scene` | in | Scene | for anchored constraints: the objects their surface points lie on |
//! | `image` | out | Image | the recoloured in-scatter |
//! | `lut` | out | Lut2D | the baked table (N×N RGBA) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `mode` | Enum | Replace | Replace, Modulate | what the TF colour does |
//! | `intensity` | Float | 1 | 0…1e6 | scales the output |
//! | `depth_range` | Enum | manual | manual, auto | auto: the frame's 1st…99th percentile of finite surface depth |
//! | `depth_min`, `depth_max` | Float | 0, 50 | 0…1e7 m | the depth range (manual) |
//! | `resolution` | Int | 256 | 2…4096 | N of the baked table |
//! | `diffusion_cycles` | Int | 8 | 1…64 | multigrid V-cycles per diffusion layer (quality knob) |

use std::path::Path;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::eval::{KeyInput, Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx, IDENTITY};
use crate::gpu::{Bind, Gpu, GpuError, GpuTexture, Shader, TexFormat};
use crate::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use crate::io::Raster;

/// The `TransferFunction` node kind.
pub struct TransferFunction;

crate::choice_enum! {
    /// What the TF colour does to the shafts.
    pub enum Mode { Replace = "Replace", Modulate = "Modulate" }
}

crate::choice_enum! {
    /// Where the depth range comes from.
    pub enum DepthRange { Manual = "manual", Auto = "auto" }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "TransferFunction",
    category: "Colour",
    doc: "Recolour shafts with a 2D table indexed by average visibility V̄ (x) and linear depth (y), baked from a layer stack (solid, gradient, diffusion, image) in the data block.",
    inputs: &[
        PortSpec::input("visibility", &[PortType::Scalar], "Average visibility V̄ (from SingleScattering); needed for `image`."),
        PortSpec::input("depth", &[PortType::Depth], "Linear depth; needed for `image` and depth_range = auto."),
        PortSpec::input("inscatter", &[PortType::Image], "Physical in-scatter, multiplied in Modulate mode."),
        PortSpec::input("lut", &[PortType::Lut2D], "A baked table to use instead of this node's layers."),
        PortSpec::input("scene", &[PortType::Scene], "The scene, for diffusion constraints anchored to surface points."),
    ],
    outputs: &[
        PortSpec::output("image", &[PortType::Image], "The recoloured in-scatter (linear RGB)."),
        PortSpec::output("lut", &[PortType::Lut2D], "The baked table: N×N RGBA, x = V̄, y = normalised depth."),
    ],
    params: &[
        ParamSpec::choice("mode", Mode::NAMES, "Replace", "Replace: output = TF colour × intensity; Modulate: in-scatter × TF colour × intensity."),
        ParamSpec::float("intensity", 1.0, 0.0, 1e6, "", "Scales the output."),
        ParamSpec::choice("depth_range", DepthRange::NAMES, "manual", "manual: depth_min…depth_max; auto: the frame's 1st…99th percentile of finite surface depth (transfers between scenes of different size)."),
        ParamSpec::float("depth_min", 0.0, 0.0, 1e7, "m", "Depth at v = 0 (depth_range = manual)."),
        ParamSpec::float("depth_max", 50.0, 0.0, 1e7, "m", "Depth at v = 1 (depth_range = manual)."),
        ParamSpec::int("resolution", 256, 2, 4096, "texels", "Side N of the baked table."),
        ParamSpec::int("diffusion_cycles", 8, 1, 64, "cycles", "Multigrid V-cycles per diffusion layer (quality knob)."),
    ],
})
.shaders(&[SHADER])
.uniforms(&[LayerParams::LAYOUT, MultigridParams::LAYOUT, LookupParams::LAYOUT]);

const SHADER: Shader = Shader::new(
    "transfer_function",
    include_str!("../shaders/transfer_function.wgsl"),
);

// ---------------------------------------------------------------------------------------------
// The data block.

/// Linear RGB and alpha.
pub type Rgba = [f32; 4];

/// The node's data block: a layer stack, or key-framed stacks.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TfData {
    /// The layer stack, bottom first (used when `keys` is empty).
    #[serde(default)]
    pub layers: Vec<LayerEntry>,
    /// Key-framed stacks, interpolated linearly in time.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub keys: Vec<TfKey>,
}

/// A layer stack at a time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TfKey {
    /// Time (frames).
    pub t: f64,
    /// The stack at that time.
    pub layers: Vec<LayerEntry>,
}

/// One layer with its blend mode and opacity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerEntry {
    /// What the layer paints.
    pub layer: Layer,
    /// How it composites over the layers below (default `Alpha`).
    #[serde(default)]
    pub blend: Blend,
    /// Opacity, 0…1 (default 1).
    #[serde(default = "one")]
    pub opacity: f32,
}

fn one() -> f32 {
    1.0
}

/// How a layer composites over the ones below.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Blend {
    /// dst·(1 − a) + src·a.
    #[default]
    Alpha,
    /// dst·(1 − a) + dst·src·a.
    Multiply,
    /// dst + src·a.
    Add,
}

/// What a layer paints over TF space.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Layer {
    /// One colour.
    Solid {
        /// The colour.
        colour: Rgba,
    },
    /// A linear gradient along the segment `from` → `to` (TF coordinates), clamped.
    Gradient {
        /// Start point (u, v).
        from: [f32; 2],
        /// End point (u, v).
        to: [f32; 2],
        /// Colour at `from` and before.
        from_colour: Rgba,
        /// Colour at `to` and beyond.
        to_colour: Rgba,
    },
    /// Constraints diffused over the layer (harmonic interpolation).
    Diffusion {
        /// The constraints.
        constraints: Vec<Constraint>,
    },
    /// A picture stretched over TF space.
    Image {
        /// The file (PNG or EXR); a relative path is read from the graph file's folder.
        path: String,
    },
}

/// A diffusion constraint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Constraint {
    /// Position (u, v) in TF space.
    pub at: [f32; 2],
    /// Colour and alpha.
    pub colour: Rgba,
    /// A surface point the constraint follows (not supported yet).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub anchor: Option<Anchor>,
}

/// A surface point: an object's triangle and barycentric coordinates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Anchor {
    /// Object name in the scene.
    pub object: String,
    /// Triangle index within the object.
    pub triangle: u32,
    /// Barycentric coordinates.
    pub bary: [f32; 3],
}

fn lerp(a: f32, b: f32, f: f32) -> f32 {
    a + (b - a) * f
}

fn lerp_n<const N: usize>(a: [f32; N], b: [f32; N], f: f32) -> [f32; N] {
    std::array::from_fn(|i| lerp(a[i], b[i], f))
}

/// Interpolate layer `i` of two stacks; `Err` says why they cannot be.
fn lerp_layer(a: &LayerEntry, b: &LayerEntry, f: f32) -> Result<LayerEntry, String> {
    if a.blend != b.blend {
        return Err(format!("blend {:?} vs {:?}", a.blend, b.blend));
    }
    let layer = match (&a.layer, &b.layer) {
        (Layer::Solid { colour: x }, Layer::Solid { colour: y }) => Layer::Solid {
            colour: lerp_n(*x, *y, f),
        },
        (
            Layer::Gradient {
                from: f0,
                to: t0,
                from_colour: c0,
                to_colour: d0,
            },
            Layer::Gradient {
                from: f1,
                to: t1,
                from_colour: c1,
                to_colour: d1,
            },
        ) => Layer::Gradient {
            from: lerp_n(*f0, *f1, f),
            to: lerp_n(*t0, *t1, f),
            from_colour: lerp_n(*c0, *c1, f),
            to_colour: lerp_n(*d0, *d1, f),
        },
        (Layer::Diffusion { constraints: x }, Layer::Diffusion { constraints: y }) => {
            if x.len() != y.len() {
                return Err(format!("{} vs {} constraints", x.len(), y.len()));
            }
            Layer::Diffusion {
                constraints: x
                    .iter()
                    .zip(y)
                    .map(|(p, q)| Constraint {
                        at: lerp_n(p.at, q.at, f),
                        colour: lerp_n(p.colour, q.colour, f),
                        anchor: p.anchor.clone(),
                    })
                    .collect(),
            }
        }
        (Layer::Image { path: p }, Layer::Image { path: q }) if p == q => a.layer.clone(),
        (x, y) => {
            return Err(format!(
                "{} vs {}",
                layer_name(x, true),
                layer_name(y, true)
            ))
        }
    };
    Ok(LayerEntry {
        layer,
        blend: a.blend,
        opacity: lerp(a.opacity, b.opacity, f),
    })
}

/// A layer's kind name (with its image path when `detail`).
pub fn layer_name(l: &Layer, detail: bool) -> String {
    match l {
        Layer::Solid { .. } => "Solid".into(),
        Layer::Gradient { .. } => "Gradient".into(),
        Layer::Diffusion { .. } => "Diffusion".into(),
        Layer::Image { path } if detail => format!("Image({path:?})"),
        Layer::Image { .. } => "Image".into(),
    }
}

impl TfData {
    /// The layer stack at time `t` (key-frames interpolated linearly).
    pub fn stack_at(&self, t: f64) -> Result<Vec<LayerEntry>, String> {
        if self.keys.is_empty() {
            return Ok(self.layers.clone());
        }
        if !self.layers.is_empty() {
            return Err("give either `layers` or `keys`, not both".into());
        }
        let mut keys: Vec<&TfKey> = self.keys.iter().collect();
        keys.sort_by(|a, b| a.t.total_cmp(&b.t));
        let first = keys[0];
        let last = keys[keys.len() - 1];
        if t <= first.t {
            return Ok(first.layers.clone());
        }
        if t >= last.t {
            return Ok(last.layers.clone());
        }
        let i = keys.iter().rposition(|k| k.t <= t).unwrap_or(0);
        let (a, b) = (keys[i], keys[i + 1]);
        let f = ((t - a.t) / (b.t - a.t).max(1e-12)) as f32;
        if a.layers.len() != b.layers.len() {
            return Err(format!(
                "keys at t = {} and t = {} have {} and {} layers: key-framed stacks must have the same layers",
                a.t,
                b.t,
                a.layers.len(),
                b.layers.len()
            ));
        }
        a.layers
            .iter()
            .zip(&b.layers)
            .enumerate()
            .map(|(n, (x, y))| {
                lerp_layer(x, y, f).map_err(|e| {
                    format!(
                        "keys at t = {} and t = {} differ in layer {n} ({e}): key-framed stacks must have the same layers",
                        a.t, b.t
                    )
                })
            })
            .collect()
    }

    /// Whether the stack changes with time.
    pub fn keyed(&self) -> bool {
        self.keys.len() > 1
    }
}

// ---------------------------------------------------------------------------------------------
// CPU reference.

/// The colour of a gradient at p.
pub fn gradient_colour(from: [f32; 2], to: [f32; 2], c0: Rgba, c1: Rgba, p: [f32; 2]) -> Rgba {
    let d = [to[0] - from[0], to[1] - from[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        (((p[0] - from[0]) * d[0] + (p[1] - from[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    lerp_n(c0, c1, t)
}

/// `dst` with `src` composited by `blend` at opacity `opacity`.
pub fn blend(dst: Rgba, src: Rgba, blend: Blend, opacity: f32) -> Rgba {
    let a = opacity * src[3];
    let rgb: [f32; 3] = std::array::from_fn(|c| match blend {
        Blend::Alpha => dst[c] * (1.0 - a) + src[c] * a,
        Blend::Multiply => dst[c] * (1.0 - a) + dst[c] * src[c] * a,
        Blend::Add => dst[c] + src[c] * a,
    });
    [rgb[0], rgb[1], rgb[2], dst[3] * (1.0 - a) + a]
}

/// Bilinear sample of an RGBA raster at (u, v): texel centres at (i + 0.5)/size, clamp to edge.
pub fn bilinear(r: &Raster, u: f32, v: f32) -> Rgba {
    let (w, h) = (r.width as i64, r.height as i64);
    let (x, y) = (u * w as f32 - 0.5, v * h as f32 - 0.5);
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let (x0, y0) = (x.floor() as i64, y.floor() as i64);
    let at = |i: i64, j: i64| -> Rgba {
        let (i, j) = (i.clamp(0, w - 1), j.clamp(0, h - 1));
        let k = ((j * w + i) * 4) as usize;
        [r.data[k], r.data[k + 1], r.data[k + 2], r.data[k + 3]]
    };
    let top = lerp_n(at(x0, y0), at(x0 + 1, y0), fx);
    let bottom = lerp_n(at(x0, y0 + 1), at(x0 + 1, y0 + 1), fx);
    lerp_n(top, bottom, fy)
}

/// A grid level of the diffusion solve: size and which texels are constrained.
#[derive(Debug, Clone)]
pub struct Level {
    /// Width.
    pub w: u32,
    /// Height.
    pub h: u32,
    /// 1 where a constraint fixes the texel (at coarse levels: where any finer texel below it
    /// is fixed), else 0.
    pub mask: Vec<f32>,
}

/// The constrained texels of an N×N diffusion layer: the mask and the fixed colours (constraints
/// sharing a texel averaged), and the mean of all constraint colours (the start value).
pub fn rasterise_constraints(cs: &[Constraint], n: u32) -> (Vec<f32>, Vec<Rgba>, Rgba) {
    let len = (n * n) as usize;
    let mut sum = vec![[0.0f32; 4]; len];
    let mut count = vec![0u32; len];
    let mut mean = [0.0f32; 4];
    for c in cs {
        let cell = |x: f32| ((x * n as f32).floor().max(0.0) as u32).min(n - 1);
        let (i, j) = (cell(c.at[0]), cell(c.at[1]));
        let k = (j * n + i) as usize;
        for ch in 0..4 {
            sum[k][ch] += c.colour[ch];
            mean[ch] += c.colour[ch] / cs.len() as f32;
        }
        count[k] += 1;
    }
    let mask = count.iter().map(|&c| (c > 0) as u32 as f32).collect();
    let values = sum
        .iter()
        .zip(&count)
        .map(|(s, &c)| s.map(|v| if c > 0 { v / c as f32 } else { 0.0 }))
        .collect();
    (mask, values, mean)
}

/// The multigrid hierarchy: the finest level first, halving (rounding up) while both sides are
/// above 4.
pub fn levels(n: u32, finest_mask: Vec<f32>) -> Vec<Level> {
    let mut out = vec![Level {
        w: n,
        h: n,
        mask: finest_mask,
    }];
    loop {
        let prev = &out[out.len() - 1];
        if prev.w <= 4 || prev.h <= 4 {
            break;
        }
        let (w, h) = (prev.w.div_ceil(2), prev.h.div_ceil(2));
        let mut mask = vec![0.0f32; (w * h) as usize];
        for y in 0..prev.h {
            for x in 0..prev.w {
                let m = prev.mask[(y * prev.w + x) as usize];
                let k = ((y / 2) * w + x / 2) as usize;
                mask[k] = mask[k].max(m);
            }
        }
        out.push(Level { w, h, mask });
    }
    out
}

/// Weighted-Jacobi factor of the smoother.
pub const OMEGA: f32 = 0.8;
/// Smoothing sweeps before and after each coarse-grid correction.
pub const SWEEPS: u32 = 2;
/// Sweeps on the coarsest grid.
pub const COARSE_SWEEPS: u32 = 40;

type Grid = Vec<Rgba>;

fn nbr(u: &Grid, w: u32, h: u32, x: u32, y: u32) -> (Rgba, f32) {
    let mut s = [0.0f32; 4];
    let mut c = 0.0f32;
    let mut add = |q: &Rgba| {
        for ch in 0..4 {
            s[ch] += q[ch];
        }
        c += 1.0;
    };
    if x + 1 < w {
        add(&u[(y * w + x + 1) as usize]);
    }
    if x > 0 {
        add(&u[(y * w + x - 1) as usize]);
    }
    if y + 1 < h {
        add(&u[((y + 1) * w + x) as usize]);
    }
    if y > 0 {
        add(&u[((y - 1) * w + x) as usize]);
    }
    (s, c)
}

/// The pin of a constrained coarse texel at level `i` ≥ 1: a conductance to zero of
/// 2π/(i ln 2) instead of a hard zero. In 2D a pinned cell's pull on its surroundings grows
/// with its size (the resistance from a disc of radius r to a far circle R is ln(R/r)/2π), and a
/// coarse texel is 2^i times the constrained fine one; the conductance adds back the
/// resistance i·ln 2/2π that the larger cell lacks, so coarse corrections near constraints
/// are not pinned too hard (with hard zeros the V-cycle converges ~4× slower).
pub fn pin(i: usize) -> f32 {
    if i == 0 {
        f32::INFINITY
    } else {
        std::f32::consts::TAU / (i as f32 * std::f32::consts::LN_2)
    }
}

fn smooth(l: &Level, i: usize, u: &Grid, f: &Grid, fixed: Option<&Grid>) -> Grid {
    let mut out = u.clone();
    for y in 0..l.h {
        for x in 0..l.w {
            let k = (y * l.w + x) as usize;
            let pinned = l.mask[k] > 0.5;
            if pinned && i == 0 {
                out[k] = fixed.map_or([0.0; 4], |v| v[k]);
                continue;
            }
            let (s, c) = nbr(u, l.w, l.h, x, y);
            let diag = c + if pinned { pin(i) } else { 0.0 };
            if diag == 0.0 {
                continue;
            }
            out[k] = std::array::from_fn(|ch| {
                let jacobi = (f[k][ch] + s[ch]) / diag;
                u[k][ch] + OMEGA * (jacobi - u[k][ch])
            });
        }
    }
    out
}

fn residual(l: &Level, i: usize, u: &Grid, f: &Grid) -> Grid {
    let mut r = vec![[0.0f32; 4]; u.len()];
    for y in 0..l.h {
        for x in 0..l.w {
            let k = (y * l.w + x) as usize;
            let pinned = l.mask[k] > 0.5;
            if pinned && i == 0 {
                continue;
            }
            let (s, c) = nbr(u, l.w, l.h, x, y);
            let diag = c + if pinned { pin(i) } else { 0.0 };
            r[k] = std::array::from_fn(|ch| f[k][ch] - (diag * u[k][ch] - s[ch]));
        }
    }
    r
}

fn restrict(fine: &Level, coarse: &Level, r: &Grid) -> Grid {
    let mut out = vec![[0.0f32; 4]; (coarse.w * coarse.h) as usize];
    for y in 0..coarse.h {
        for x in 0..coarse.w {
            let mut s = [0.0f32; 4];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (qx, qy) = (2 * x + dx, 2 * y + dy);
                if qx < fine.w && qy < fine.h {
                    let q = r[(qy * fine.w + qx) as usize];
                    for ch in 0..4 {
                        s[ch] += q[ch];
                    }
                }
            }
            out[(y * coarse.w + x) as usize] = s;
        }
    }
    out
}

fn prolong(fine: &Level, coarse: &Level, u: &Grid, e: &Grid) -> Grid {
    let raster = Raster {
        width: coarse.w,
        height: coarse.h,
        channels: 4,
        data: e.iter().flatten().copied().collect(),
    };
    let mut out = u.clone();
    for y in 0..fine.h {
        for x in 0..fine.w {
            let k = (y * fine.w + x) as usize;
            if fine.mask[k] > 0.5 {
                continue;
            }
            let c = bilinear(
                &raster,
                (x as f32 + 0.5) / (2.0 * coarse.w as f32),
                (y as f32 + 0.5) / (2.0 * coarse.h as f32),
            );
            out[k] = std::array::from_fn(|ch| u[k][ch] + c[ch]);
        }
    }
    out
}

fn vcycle(ls: &[Level], i: usize, u: Grid, f: &Grid, fixed: Option<&Grid>) -> Grid {
    let l = &ls[i];
    if i + 1 == ls.len() {
        return (0..COARSE_SWEEPS).fold(u, |u, _| smooth(l, i, &u, f, fixed));
    }
    let mut u = (0..SWEEPS).fold(u, |u, _| smooth(l, i, &u, f, fixed));
    let fc = restrict(l, &ls[i + 1], &residual(l, i, &u, f));
    let zero = vec![[0.0f32; 4]; fc.len()];
    let e = vcycle(ls, i + 1, zero, &fc, None);
    u = prolong(l, &ls[i + 1], &u, &e);
    (0..SWEEPS).fold(u, |u, _| smooth(l, i, &u, f, fixed))
}

/// CPU reference of a diffusion layer on an N×N grid (`cycles` V-cycles): RGBA, row-major.
pub fn diffuse_reference(cs: &[Constraint], n: u32, cycles: u32) -> Raster {
    let len = (n * n) as usize;
    if cs.is_empty() {
        return Raster::new(n, n, 4, 0.0);
    }
    let (mask, values, mean) = rasterise_constraints(cs, n);
    let ls = levels(n, mask);
    let zero = vec![[0.0f32; 4]; len];
    let mut u: Grid = vec![mean; len];
    for _ in 0..cycles {
        u = vcycle(&ls, 0, u, &zero, Some(&values));
    }
    Raster {
        width: n,
        height: n,
        channels: 4,
        data: u.into_iter().flatten().collect(),
    }
}

/// Read an image layer's file as RGBA (one channel becomes grey, alpha 1).
pub fn read_layer_image(path: &str) -> Result<Raster, NodeError> {
    let r = crate::io::read_image(Path::new(path), true)?;
    Ok(match r.channels {
        4 => r,
        _ => Raster {
            width: r.width,
            height: r.height,
            channels: 4,
            data: r.data.iter().flat_map(|v| [*v, *v, *v, 1.0]).collect(),
        },
    })
}

/// CPU reference of the baked table. `images[i]` is layer i's picture (image layers only).
pub fn bake_reference(
    stack: &[LayerEntry],
    n: u32,
    cycles: u32,
    images: &[Option<Raster>],
) -> Raster {
    let mut acc = Raster::new(n, n, 4, 0.0);
    for (li, e) in stack.iter().enumerate() {
        let solved = match &e.layer {
            Layer::Diffusion { constraints } => Some(diffuse_reference(constraints, n, cycles)),
            Layer::Image { .. } => images.get(li).cloned().flatten(),
            _ => None,
        };
        for j in 0..n {
            for i in 0..n {
                let p = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                let src = match &e.layer {
                    Layer::Solid { colour } => *colour,
                    Layer::Gradient {
                        from,
                        to,
                        from_colour,
                        to_colour,
                    } => gradient_colour(*from, *to, *from_colour, *to_colour, p),
                    _ => solved
                        .as_ref()
                        .map_or([0.0; 4], |r| bilinear(r, p[0], p[1])),
                };
                let k = ((j * n + i) * 4) as usize;
                let dst = [
                    acc.data[k],
                    acc.data[k + 1],
                    acc.data[k + 2],
                    acc.data[k + 3],
                ];
                acc.data[k..k + 4].copy_from_slice(&blend(dst, src, e.blend, e.opacity));
            }
        }
    }
    acc
}

/// The TF coordinate v of depth `d`.
pub fn depth_coordinate(d: f32, depth_min: f32, depth_max: f32) -> f32 {
    let span = depth_max - depth_min;
    let v = if span > 0.0 {
        (d - depth_min) / span
    } else if d > depth_min {
        1.0
    } else {
        0.0
    };
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// CPU reference of the lookup: one RGBA pixel per visibility texel.
pub fn lookup_reference(
    lut: &Raster,
    vis: &Raster,
    depth: &Raster,
    inscatter: Option<&Raster>,
    range: (f32, f32),
    intensity: f32,
) -> Raster {
    let mut out = Raster::new(vis.width, vis.height, 4, 1.0);
    for k in 0..(vis.width * vis.height) as usize {
        let u = vis.data[k];
        let u = if u.is_nan() { 0.0 } else { u.clamp(0.0, 1.0) };
        let v = depth_coordinate(depth.data[k], range.0, range.1);
        let tf = bilinear(lut, u, v);
        for (c, tc) in tf.iter().take(3).enumerate() {
            let t = tc * intensity;
            out.data[k * 4 + c] = inscatter.map_or(t, |s| s.data[k * 4 + c] * t);
        }
    }
    out
}

/// `depth_range = auto`: the 1st and 99th percentiles (nearest rank) of the finite surface
/// depths — below the camera's far distance when the depth comes from a camera (sky pixels sit
/// at the far distance), all finite values when it comes from a file (identity matrices).
/// `(0, 1)` when no pixel qualifies.
pub fn auto_range(depth: &[f32], m: &Matrices) -> (f32, f32) {
    let from_camera = m.view != IDENTITY || m.proj != IDENTITY;
    let mut v: Vec<f32> = depth
        .iter()
        .copied()
        .filter(|d| d.is_finite() && (!from_camera || *d < m.far))
        .collect();
    if v.is_empty() {
        return (0.0, 1.0);
    }
    v.sort_by(f32::total_cmp);
    let at = |q: f64| v[((q * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
    (at(0.01), at(0.99))
}

// ---------------------------------------------------------------------------------------------
// GPU.

crate::uniforms! {
    /// Uniforms of `bake_layer` (struct `Layer`).
    pub struct LayerParams as "Layer" {
        /// 0 solid, 1 gradient, 2 sampled from the bound texture.
        pub kind: u32,
        /// 0 alpha, 1 multiply, 2 add.
        pub blend: u32,
        /// Opacity.
        pub opacity: f32,
        /// Padding.
        pub _pad0: u32,
        /// Solid colour / gradient start colour.
        pub colour0: [f32; 4],
        /// Gradient end colour.
        pub colour1: [f32; 4],
        /// Gradient start point.
        pub from_uv: [f32; 2],
        /// Gradient end point.
        pub to_uv: [f32; 2],
    }
}

crate::uniforms! {
    /// Uniforms of the multigrid passes (struct `Multigrid`).
    pub struct MultigridParams as "Multigrid" {
        /// 1: constrained texels take their colour (finest level); 0: they stay 0.
        pub fixed_values: u32,
        /// Weighted-Jacobi factor.
        pub omega: f32,
        /// Coarse levels: the conductance tying a constrained texel to zero ([`pin`]).
        pub pin: f32,
        /// Padding.
        pub _pad0: u32,
    }
}

crate::uniforms! {
    /// Uniforms of `lookup` (struct `Lookup`).
    pub struct LookupParams as "Lookup" {
        /// Depth at v = 0.
        pub depth_min: f32,
        /// Depth at v = 1.
        pub depth_max: f32,
        /// Output scale.
        pub intensity: f32,
        /// 1 for Modulate.
        pub modulate: u32,
    }
}

/// A level's textures on the GPU.
struct GpuLevel {
    level: Level,
    mask: GpuTexture,
}

fn mg_pass(
    gpu: &Gpu,
    entry: &str,
    size: (u32, u32),
    binds: &[(u32, Bind)],
) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(size.0, size.1, TexFormat::Rgba32F)?;
    let mut all: Vec<(u32, Bind)> = binds.to_vec();
    all.push((3, Bind::Storage(&out)));
    gpu.dispatch(SHADER, entry, &all, size.0, size.1)?;
    Ok(out)
}

struct Multigrid<'a> {
    gpu: &'a Gpu,
    levels: Vec<GpuLevel>,
    values: GpuTexture,
}

fn mg_params(i: usize) -> MultigridParams {
    MultigridParams {
        fixed_values: (i == 0) as u32,
        omega: OMEGA,
        pin: if i == 0 { 0.0 } else { pin(i) },
        _pad0: 0,
    }
}

impl Multigrid<'_> {
    fn smooth(&self, i: usize, u: &GpuTexture, f: &GpuTexture) -> Result<GpuTexture, GpuError> {
        let l = &self.levels[i];
        let p = mg_params(i);
        mg_pass(
            self.gpu,
            "mg_smooth",
            (l.level.w, l.level.h),
            &[
                (1, Bind::Texture(u)),
                (2, Bind::Texture(f)),
                (4, Bind::Texture(&l.mask)),
                (5, Bind::Texture(&self.values)),
                (6, Bind::Uniform(bytemuck::bytes_of(&p))),
            ],
        )
    }

    fn sweeps(
        &self,
        i: usize,
        mut u: GpuTexture,
        f: &GpuTexture,
        n: u32,
    ) -> Result<GpuTexture, GpuError> {
        for _ in 0..n {
            u = self.smooth(i, &u, f)?;
        }
        Ok(u)
    }

    fn vcycle(&self, i: usize, u: GpuTexture, f: &GpuTexture) -> Result<GpuTexture, GpuError> {
        let gpu = self.gpu;
        if i + 1 == self.levels.len() {
            return self.sweeps(i, u, f, COARSE_SWEEPS);
        }
        let (l, c) = (&self.levels[i], &self.levels[i + 1]);
        let u = self.sweeps(i, u, f, SWEEPS)?;
        let p = mg_params(i);
        let r = mg_pass(
            gpu,
            "mg_residual",
            (l.level.w, l.level.h),
            &[
                (1, Bind::Texture(&u)),
                (2, Bind::Texture(f)),
                (4, Bind::Texture(&l.mask)),
                (6, Bind::Uniform(bytemuck::bytes_of(&p))),
            ],
        )?;
        let fc = mg_pass(
            gpu,
            "mg_restrict",
            (c.level.w, c.level.h),
            &[(1, Bind::Texture(&r))],
        )?;
        let zero = gpu.zeroed(c.level.w, c.level.h, TexFormat::Rgba32F)?;
        let e = self.vcycle(i + 1, zero, &fc)?;
        let u = mg_pass(
            gpu,
            "mg_prolong",
            (l.level.w, l.level.h),
            &[
                (1, Bind::Texture(&u)),
                (2, Bind::Texture(&e)),
                (4, Bind::Texture(&l.mask)),
            ],
        )?;
        self.sweeps(i, u, f, SWEEPS)
    }
}

/// Solve a diffusion layer on the GPU (the same V-cycles as [`diffuse_reference`]).
pub fn diffuse_gpu(
    gpu: &Gpu,
    cs: &[Constraint],
    n: u32,
    cycles: u32,
) -> Result<GpuTexture, GpuError> {
    if cs.is_empty() {
        return gpu.zeroed(n, n, TexFormat::Rgba32F);
    }
    let (mask, values, mean) = rasterise_constraints(cs, n);
    let levels = levels(n, mask)
        .into_iter()
        .map(|level| {
            let mask = gpu.upload(level.w, level.h, 1, &level.mask)?;
            Ok(GpuLevel { level, mask })
        })
        .collect::<Result<Vec<_>, GpuError>>()?;
    let flat: Vec<f32> = values.into_iter().flatten().collect();
    let mg = Multigrid {
        gpu,
        levels,
        values: gpu.upload(n, n, 4, &flat)?,
    };
    let start: Vec<f32> = (0..n * n).flat_map(|_| mean).collect();
    let mut u = gpu.upload(n, n, 4, &start)?;
    let zero = gpu.zeroed(n, n, TexFormat::Rgba32F)?;
    for _ in 0..cycles {
        u = mg.vcycle(0, u, &zero)?;
    }
    Ok(u)
}

/// Bake a layer stack into an N×N table on the GPU.
pub fn bake_gpu(
    gpu: &Gpu,
    stack: &[LayerEntry],
    n: u32,
    cycles: u32,
) -> Result<GpuTexture, NodeError> {
    let mut acc = gpu.zeroed(n, n, TexFormat::Rgba32F)?;
    let dummy = gpu.zeroed(1, 1, TexFormat::Rgba32F)?;
    for e in stack {
        let mut p = LayerParams {
            kind: 0,
            blend: match e.blend {
                Blend::Alpha => 0,
                Blend::Multiply => 1,
                Blend::Add => 2,
            },
            opacity: e.opacity,
            _pad0: 0,
            colour0: [0.0; 4],
            colour1: [0.0; 4],
            from_uv: [0.0; 2],
            to_uv: [0.0; 2],
        };
        let src = match &e.layer {
            Layer::Solid { colour } => {
                p.colour0 = *colour;
                None
            }
            Layer::Gradient {
                from,
                to,
                from_colour,
                to_colour,
            } => {
                (p.kind, p.colour0, p.colour1, p.from_uv, p.to_uv) =
                    (1, *from_colour, *to_colour, *from, *to);
                None
            }
            Layer::Diffusion { constraints } => {
                p.kind = 2;
                Some(diffuse_gpu(gpu, constraints, n, cycles)?)
            }
            Layer::Image { path } => {
                p.kind = 2;
                let r = read_layer_image(path)?;
                Some(gpu.upload(r.width, r.height, 4, &r.data)?)
            }
        };
        acc = mg_pass(
            gpu,
            "bake_layer",
            (n, n),
            &[
                (0, Bind::Uniform(bytemuck::bytes_of(&p))),
                (1, Bind::Texture(&acc)),
                (2, Bind::Texture(src.as_ref().unwrap_or(&dummy))),
            ],
        )?;
    }
    Ok(acc)
}

fn input_err(port: &str, message: impl Into<String>) -> NodeError {
    NodeError::Input {
        port: port.into(),
        message: message.into(),
    }
}

/// The layer stack of the data block at the evaluation time, checked.
fn stack(ctx: &RunCtx) -> Result<Vec<LayerEntry>, NodeError> {
    let data: TfData = ctx.data()?;
    let stack = data.stack_at(ctx.time).map_err(NodeError::Data)?;
    for (i, e) in stack.iter().enumerate() {
        if !(0.0..=1.0).contains(&e.opacity) {
            return Err(NodeError::Data(format!(
                "layer {i}: opacity {} is outside 0…1",
                e.opacity
            )));
        }
        let finite = match &e.layer {
            Layer::Solid { colour } => colour.iter().all(|v| v.is_finite()),
            Layer::Gradient {
                from,
                to,
                from_colour,
                to_colour,
            } => from
                .iter()
                .chain(to)
                .chain(from_colour)
                .chain(to_colour)
                .all(|v| v.is_finite()),
            Layer::Diffusion { constraints } => constraints
                .iter()
                .all(|c| c.at.iter().chain(&c.colour).all(|v| v.is_finite())),
            Layer::Image { .. } => true,
        };
        if !finite || !e.opacity.is_finite() {
            return Err(NodeError::Data(format!(
                "layer {i}: a number is not finite"
            )));
        }
    }
    Ok(stack)
}

/// The frame the TF is looked up in: V̄ and depth (with the camera's matrices).
struct Frame {
    vis: Arc<GpuTexture>,
    depth: Arc<GpuTexture>,
    camera: Matrices,
}

impl Frame {
    /// The connected `visibility` and `depth`, checked; `None` when either is unconnected.
    fn of(ctx: &RunCtx) -> Result<Option<Frame>, NodeError> {
        let vis = match ctx.input("visibility") {
            None => return Ok(None),
            Some(v) => v
                .texture()
                .cloned()
                .ok_or_else(|| input_err("visibility", "is not an image"))?,
        };
        let (depth, camera) = match ctx.input("depth") {
            None => return Ok(None),
            Some(PortValue::Depth(t, m)) => (t.clone(), *m),
            Some(_) => return Err(input_err("depth", "is not a depth image")),
        };
        if (depth.width, depth.height) != (vis.width, vis.height) {
            return Err(input_err(
                "depth",
                format!(
                    "is {}×{} but visibility is {}×{}",
                    depth.width, depth.height, vis.width, vis.height
                ),
            ));
        }
        Ok(Some(Frame { vis, depth, camera }))
    }

    /// The depth range: the parameters, or the frame's percentiles.
    fn range(&self, ctx: &RunCtx) -> Result<(f32, f32), NodeError> {
        Ok(match ctx.choice::<DepthRange>("depth_range")? {
            DepthRange::Manual => (ctx.f32("depth_min")?, ctx.f32("depth_max")?),
            DepthRange::Auto => auto_range(&ctx.gpu.read_texture(&self.depth)?, &self.camera),
        })
    }
}

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
fn resolve_anchors(
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
        .input("scene")
        .ok_or_else(|| input_err("scene", "must be connected for anchored constraints"))?
        .payload::<crate::scene::GpuScene>()
        .ok_or_else(|| input_err("scene", "is not a scene"))?;
    let f = frame.ok_or_else(|| {
        input_err(
            "visibility",
            "and `depth` must be connected for anchored constraints",
        )
    })?;
    let range = f.range(ctx)?;
    let read = |t: &GpuTexture| -> Result<Raster, NodeError> {
        Ok(Raster {
            width: t.width,
            height: t.height,
            channels: 1,
            data: ctx.gpu.read_texture(t)?,
        })
    };
    let (vis, depth) = (read(&f.vis)?, read(&f.depth)?);
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

impl NodeKind for TransferFunction {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn data_files(
        &self,
        data: &crate::graph::NodeData,
        resolve: &dyn Fn(&str) -> String,
    ) -> Result<Option<crate::graph::NodeData>, String> {
        let mut tf: TfData = data.parse()?;
        let mut any = false;
        let stacks =
            std::iter::once(&mut tf.layers).chain(tf.keys.iter_mut().map(|k| &mut k.layers));
        for entry in stacks.flatten() {
            if let Layer::Image { path } = &mut entry.layer {
                *path = resolve(path);
                any = true;
            }
        }
        if !any {
            return Ok(None);
        }
        crate::graph::NodeData::from_value(&tf).map(Some)
    }

    fn volatile_key(&self, key: &KeyInput) -> u64 {
        use std::hash::{Hash, Hasher};
        let Some(data) = key.data.and_then(|d| d.parse::<TfData>().ok()) else {
            return 0;
        };
        let mut h = std::collections::hash_map::DefaultHasher::new();
        if data.keyed() {
            key.time.to_bits().hash(&mut h);
        }
        for e in data
            .layers
            .iter()
            .chain(data.keys.iter().flat_map(|k| &k.layers))
        {
            if let Layer::Image { path } = &e.layer {
                super::util::path_stamp(Path::new(path)).hash(&mut h);
            }
        }
        h.finish()
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let frame = Frame::of(ctx)?;
        let lut = match ctx.input("lut") {
            Some(PortValue::Lut2D(t)) => t.clone(),
            Some(_) => return Err(input_err("lut", "is not a Lut2D")),
            None => {
                let n = ctx.texture_side("resolution", 2)?;
                ctx.check_bytes("resolution", u64::from(n).pow(2) * 16)?;
                let cycles = ctx.int("diffusion_cycles")? as u32;
                let mut layers = stack(ctx)?;
                resolve_anchors(ctx, &mut layers, frame.as_ref())?;
                Arc::new(bake_gpu(ctx.gpu, &layers, n, cycles)?)
            }
        };
        if ctx.wants("image") {
            let f = frame.ok_or_else(|| {
                input_err("visibility", "must be connected, with `depth`, for `image`")
            })?;
            let mode = ctx.choice::<Mode>("mode")?;
            let inscatter = match mode {
                Mode::Modulate => {
                    let t = ctx
                        .input("inscatter")
                        .and_then(|v| v.texture().cloned())
                        .ok_or_else(|| input_err("inscatter", "must be connected for Modulate"))?;
                    if (t.width, t.height) != (f.vis.width, f.vis.height) {
                        return Err(input_err("inscatter", "differs in size from visibility"));
                    }
                    Some(t)
                }
                Mode::Replace => None,
            };
            let (depth_min, depth_max) = f.range(ctx)?;
            let k = LookupParams {
                depth_min,
                depth_max,
                intensity: ctx.f32("intensity")?,
                modulate: (mode == Mode::Modulate) as u32,
            };
            let image = mg_pass(
                ctx.gpu,
                "lookup",
                (f.vis.width, f.vis.height),
                &[
                    (1, Bind::Texture(&lut)),
                    (2, Bind::Texture(inscatter.as_deref().unwrap_or(&lut))),
                    (7, Bind::Uniform(bytemuck::bytes_of(&k))),
                    (8, Bind::Texture(&f.vis)),
                    (9, Bind::Texture(&f.depth)),
                ],
            )?;
            ctx.set("image", PortValue::Image(Arc::new(image)));
        }
        ctx.set("lut", PortValue::Lut2D(lut));
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// `tyndall pick`: what a pixel's view ray sees, for placing 3D constraints.

/// Where a picked pixel lands in a transfer function's space.
#[derive(Debug, Clone, Serialize)]
pub struct TfPick {
    /// The TransferFunction node.
    pub node: String,
    /// u = V̄.
    pub u: f32,
    /// v = normalised depth.
    pub v: f32,
    /// The depth range used (manual parameters or the frame's percentiles).
    pub depth_min: f32,
    /// Upper end of the depth range.
    pub depth_max: f32,
    /// `manual` or `auto`.
    pub depth_range: String,
}

/// The surface point under a pixel.
#[derive(Debug, Clone, Serialize)]
pub struct SurfacePick {
    /// Object name.
    pub object: String,
    /// Triangle index in the object.
    pub triangle: u32,
    /// Barycentric coordinates.
    pub bary: [f32; 3],
    /// World position.
    pub position: [f32; 3],
}

/// What `tyndall pick` reports for one pixel.
#[derive(Debug, Clone, Serialize)]
pub struct Pick {
    /// The pixel (x right, y down).
    pub pixel: [u32; 2],
    /// The evaluation size the pixel refers to.
    pub size: [u32; 2],
    /// Evaluation time.
    pub time: f64,
    /// The node whose inputs were read.
    pub node: String,
    /// V̄ of the view ray.
    pub visibility: f32,
    /// Linear depth, metres (sky: the camera's far distance).
    pub depth: f32,
    /// TF coordinates, when the node is a TransferFunction.
    pub tf: Option<TfPick>,
    /// The first surface along the ray, when the graph's scene can be found.
    pub surface: Option<SurfacePick>,
}

fn pick_err(message: impl Into<String>) -> crate::eval::EvalError {
    crate::eval::EvalError::Node {
        node: "-".into(),
        kind: "pick".into(),
        source: NodeError::Other(message.into()),
    }
}

/// The node and port feeding `id.port`.
fn source(g: &crate::graph::Graph, id: &str, port: &str) -> Option<(String, String)> {
    g.source_of(id, port)
        .map(|(n, p)| (n.to_string(), p.to_string()))
}

/// Follow `depth` inputs upstream from `start` to the first node with a connected `scene`
/// input: the scene the depth was rendered from.
fn scene_of(g: &crate::graph::Graph, start: &str) -> Option<(String, String)> {
    let mut id = start.to_string();
    for _ in 0..64 {
        if let Some(s) = source(g, &id, "scene") {
            return Some(s);
        }
        id = source(g, &id, "depth")?.0;
    }
    None
}

/// Evaluate what pixel `pixel` of the `node` TransferFunction (default: the first one by id,
/// else the first SingleScattering) sees: V̄, linear depth, TF coordinates and the surface
/// point (object, triangle, barycentrics) under it.
pub fn pick(
    ev: &mut crate::eval::Evaluator,
    g: &crate::graph::Graph,
    node: Option<&str>,
    pixel: (u32, u32),
    opts: &crate::eval::EvalOptions,
) -> Result<Pick, crate::eval::EvalError> {
    use crate::eval::Target;
    let of_kind = |k: &str| g.nodes().find(|n| n.kind == k).map(|n| n.id.clone());
    let id = match node {
        Some(n) => n.to_string(),
        None => of_kind("TransferFunction")
            .or_else(|| of_kind("SingleScattering"))
            .ok_or_else(|| {
                pick_err("the graph has no TransferFunction or SingleScattering node")
            })?,
    };
    let kind = g
        .node(&id)
        .map(|n| n.kind.clone())
        .ok_or_else(|| pick_err(format!("no node '{id}' in the graph")))?;
    let (vis_src, depth_src) = match kind.as_str() {
        "TransferFunction" => (
            source(g, &id, "visibility")
                .ok_or_else(|| pick_err(format!("{id}.visibility is not connected")))?,
            source(g, &id, "depth")
                .ok_or_else(|| pick_err(format!("{id}.depth is not connected")))?,
        ),
        "SingleScattering" => (
            (id.clone(), "visibility".to_string()),
            (id.clone(), "depth".to_string()),
        ),
        other => {
            return Err(pick_err(format!(
                "node '{id}' is a {other}: pick reads a TransferFunction or SingleScattering"
            )))
        }
    };
    let scene_src = scene_of(g, &depth_src.0);
    let mut targets = vec![
        Target::Port(vis_src.0.clone(), vis_src.1.clone()),
        Target::Port(depth_src.0.clone(), depth_src.1.clone()),
    ];
    if let Some((n, p)) = &scene_src {
        targets.push(Target::Port(n.clone(), p.clone()));
    }
    let r = ev.evaluate(g, &targets, opts)?;
    let gpu = ev.gpu().clone();
    let get = |src: &(String, String)| {
        r.outputs
            .get(src)
            .ok_or_else(|| pick_err(format!("{}.{} produced nothing", src.0, src.1)))
    };
    let vis = crate::eval::download(&gpu, get(&vis_src)?).map_err(|e| pick_err(e.to_string()))?;
    let depth_value = get(&depth_src)?;
    let camera = match depth_value {
        PortValue::Depth(_, m) => *m,
        _ => return Err(pick_err("the depth input is not a Depth value")),
    };
    let depth = crate::eval::download(&gpu, depth_value).map_err(|e| pick_err(e.to_string()))?;
    let (x, y) = pixel;
    if x >= depth.width || y >= depth.height {
        return Err(pick_err(format!(
            "pixel {x},{y} is outside the {}×{} image",
            depth.width, depth.height
        )));
    }
    let k = (y * depth.width + x) as usize;
    let (visibility, d) = (vis.data[k], depth.data[k]);
    let tf = if kind == "TransferFunction" {
        let cat = ev.registry().catalog().clone();
        let param = |name: &str| {
            g.param_at(&cat, &id, name, opts.time)
                .map_err(|e| pick_err(e.to_string()))
        };
        let auto =
            matches!(param("depth_range")?, crate::graph::ParamValue::Enum(ref s) if s == "auto");
        let (lo, hi) = if auto {
            auto_range(&depth.data, &camera)
        } else {
            let f = |v: crate::graph::ParamValue| v.as_f64().unwrap_or(0.0) as f32;
            (f(param("depth_min")?), f(param("depth_max")?))
        };
        Some(TfPick {
            node: id.clone(),
            u: if visibility.is_nan() {
                0.0
            } else {
                visibility.clamp(0.0, 1.0)
            },
            v: depth_coordinate(d, lo, hi),
            depth_min: lo,
            depth_max: hi,
            depth_range: if auto { "auto" } else { "manual" }.into(),
        })
    } else {
        None
    };
    let surface = match scene_src.as_ref().and_then(|s| r.outputs.get(s)) {
        Some(v) => {
            let scene = v
                .payload::<crate::scene::GpuScene>()
                .ok_or_else(|| pick_err("the scene port holds no scene"))?;
            let eye = camera.eye();
            let dir = camera.pixel_ray(x, y, depth.width, depth.height);
            scene.scene.ray_hit(eye, dir).map(|h| SurfacePick {
                object: h.object,
                triangle: h.triangle,
                bary: h.bary,
                position: h.position.to_array(),
            })
        }
        None => None,
    };
    Ok(Pick {
        pixel: [x, y],
        size: [depth.width, depth.height],
        time: opts.time,
        node: id,
        visibility,
        depth: d,
        tf,
        surface,
    })
}
