//! `LightMapSolve`: the light map whose shafts take the colours an artist painted in a few
//! views (SPEC §5, seed 000 §4.2, after Klehm et al.).
//!
//! Constraint pixel k (a view ray to its first surface at distance s, marched in `steps` equal
//! intervals) asks for `L_k = L_desired,k ⊙ L_scat^white(k)`. With the light map x multiplying the
//! sun, `L_scat(k) = σt ρ f E ∫₀ˢ V(t) x(t) e^{−σt t} dt`; the factor σt ρ f E is the same on
//! both sides, so the solve works with the normalised row `(T x)_k = Σ_i V_i ŵ_i x(uv_i)`,
//! `ŵ_i = ∫_{interval i} e^{−σt t} dt / ∫₀ˢ e^{−σt t} dt`, x looked up bilinearly (clamp to edge)
//! in the light projection of the `shadow` input, and `b_k = L_desired,k (T 1)_k`. It minimises
//! ½‖T x − b‖² per RGB channel by conjugate gradients on the normal equations `TᵀT x = Tᵀb`
//! (CGLS), matrix-free on the GPU: `T x` marches the constraint pixels reading x (pass
//! `forward`), `Tᵀ r` marches them again and adds `r_k ŵ_i V_i` times the bilinear weights into
//! the four texels around each sample (pass `adjoint`) — in 64-bit fixed point built from pairs
//! of u32 atomics (WGSL has no float atomics; one i32 word loses ~1e-4 per contribution and CG's
//! conjugacy with it), the scale per channel chosen so that no sum can overflow (see the shader).
//! The vector updates and the dot products run on the CPU between the passes.
//!
//! It starts from the constant map `start`; texels no constraint ray reaches get no gradient
//! and keep the start value. The residual ‖T x − b‖ is reported per iteration (`RunCtx::report`:
//! the CLI's progress bar, the editor's top bar; and the `residual` output, one texel per
//! iteration). It stops after `iterations`, or when
//! ‖Tᵀ r‖ has fallen below `tolerance` × its first value. Non-negativity (`non_negative`, on by
//! default): when a CG step would make texels negative, they are projected to 0 if that lowers
//! the residual, else the step is shortened to the largest one that keeps every texel ≥ 0 (which
//! lowers it: the quadratic along the step is convex with its minimum at the full step); texels
//! at 0 whose gradient pushes them below are frozen, and CG restarts from steepest descent on
//! the free texels. So the residual never increases (up to rounding), with or without the
//! constraint; projection instead of shortening alone matters — on the window preset shortening
//! alone left the residual at 40 % of its start after 30 iterations, where plain CG reaches 1 %.
//!
//! The medium for the solve is the seed's: unbounded, no light extinction, σt = `sigma_t`, with
//! the shadow test of `SingleScattering` (nearest texel, `bias`). Use the same σt, steps and bias
//! as the `SingleScattering` the light map feeds; albedo, phase and the sun's colour cancel out.
//!
//! The data block holds the views and their strokes, in pixels of each view's `width × height`:
//!
//! ```ron
//! (views: [
//!     (camera: Scene, width: 480, height: 270, strokes: [
//!         (colour: (1.0, 0.2, 0.0), width: 12.0, points: [(100.0, 80.0), (220.0, 140.0)]),
//!         (colour: (0.0, 0.0, 0.0), width: 20.0, points: [(150.0, 100.0)], erase: true),
//!     ]),
//!     (camera: Look(position: (6.0, 3.0, 8.0), target: (0.0, 1.5, 0.0), fov: 40.0), strokes: []),
//! ])
//! ```
//!
//! A pixel is a constraint when its centre lies within `width`/2 of a stroke's polyline (a single
//! point: a disc); later strokes override earlier ones, `erase` strokes remove constraints.
//! `camera: Scene` is the scene's camera (named cameras of a glTF file are not supported yet).
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `scene` | in | Scene (required) | the views' geometry |
//! | `shadow` | in | ShadowMap (required) | visibility, and the light matrices placing the map |
//! | `light_map` | out | LightMap | the solved map |
//! | `residual` | out | Scalar | ‖T x − b‖ after each iteration (iterations × 1; texel 0: the start) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `resolution` | Int | 256 | 2…4096 | side of the light map |
//! | `iterations` | Int | 32 | 0…10000 | CG iterations at most |
//! | `tolerance` | Float | 1e-4 | 0…1 | stop when ‖Tᵀr‖ < tolerance · ‖Tᵀr₀‖ |
//! | `non_negative` | Bool | true | | keep every texel ≥ 0 |
//! | `start` | Float | 1 | 0…1e6 | the constant start map |
//! | `sigma_t` | Float | 0.08 | 0…1e4 1/m | σt of the medium |
//! | `steps` | Int | 128 | 1…8192 | samples per constraint ray |
//! | `bias` | Float | 0.002 | 0…0.1 | shadow test bias |

use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use crate::gpu::{Bind, Gpu, GpuError, GpuTexture, Shader, TexFormat};
use crate::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use crate::io::Raster;
use crate::scene::{Camera, GpuScene};

/// The `LightMapSolve` node kind.
pub struct LightMapSolve;

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "LightMapSolve",
    category: "Colour",
    doc: "Solve the light map whose shafts take the colours painted as strokes in a few views (conjugate gradients on the normal equations, on the GPU).",
    inputs: &[
        PortSpec::required("scene", &[PortType::Scene], "The scene the views look at."),
        PortSpec::required("shadow", &[PortType::ShadowMap], "Shadow map the scattering sees; its light matrices place the light map."),
    ],
    outputs: &[
        PortSpec::output("light_map", &[PortType::LightMap], "The solved light map."),
        PortSpec::output("residual", &[PortType::Scalar], "‖T x − b‖ at the start and after each iteration (one texel each)."),
    ],
    params: &[
        ParamSpec::int("resolution", 256, 2, 4096, "texels", "Side of the light map."),
        ParamSpec::int("iterations", 32, 0, 10000, "", "Conjugate-gradient iterations at most."),
        ParamSpec::float("tolerance", 1e-4, 0.0, 1.0, "", "Stop when ‖Tᵀ r‖ falls below tolerance × its first value."),
        ParamSpec::flag("non_negative", true, "Keep every texel ≥ 0 (shortened steps, frozen texels, CG restarts)."),
        ParamSpec::float("start", 1.0, 0.0, 1e6, "", "The constant start map; texels no stroke reaches keep it."),
        ParamSpec::float("sigma_t", 0.08, 0.0, 1e4, "1/m", "Extinction σt of the medium (as on SingleScattering)."),
        ParamSpec::int("steps", 128, 1, 8192, "samples", "Samples per constraint ray."),
        ParamSpec::float("bias", 0.002, 0.0, 0.1, "depth", "Shadow test bias (as on SingleScattering)."),
    ],
})
.shaders(&[SHADER])
.uniforms(&[ViewParams::LAYOUT]);

const SHADER: Shader = Shader::new(
    "light_map_solve",
    include_str!("../shaders/light_map_solve.wgsl"),
);

// ---------------------------------------------------------------------------------------------
// The data block.

/// The strokes, per view.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolveData {
    /// The views.
    #[serde(default)]
    pub views: Vec<View>,
}

/// A view and the strokes painted in it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct View {
    /// Where the view looks from.
    pub camera: ViewCamera,
    /// Width of the view in pixels (strokes are in these pixels).
    #[serde(default = "default_width")]
    pub width: u32,
    /// Height of the view in pixels.
    #[serde(default = "default_height")]
    pub height: u32,
    /// Strokes, painted in order.
    #[serde(default)]
    pub strokes: Vec<Stroke>,
}

fn default_width() -> u32 {
    480
}

fn default_height() -> u32 {
    270
}

/// A view's camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ViewCamera {
    /// The scene's camera.
    Scene,
    /// A camera at `position` looking at `target` with a vertical field of view `fov` (degrees);
    /// near and far planes as the scene's camera.
    Look {
        /// Eye position.
        position: [f32; 3],
        /// Point looked at.
        target: [f32; 3],
        /// Vertical field of view, degrees.
        fov: f32,
    },
}

/// A painted polyline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stroke {
    /// Desired colour of the shafts (linear RGB, relative to a white light map).
    #[serde(default = "white")]
    pub colour: [f32; 3],
    /// Brush diameter in pixels.
    #[serde(default = "default_brush")]
    pub width: f32,
    /// The polyline, pixel coordinates (x right, y down).
    pub points: Vec<[f32; 2]>,
    /// Remove constraints instead of adding them.
    #[serde(default)]
    pub erase: bool,
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

fn default_brush() -> f32 {
    8.0
}

/// Distance from p to the segment a–b.
fn segment_distance(p: [f32; 2], a: [f32; 2], b: [f32; 2]) -> f32 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + d[0] * t - p[0], a[1] + d[1] * t - p[1]];
    (q[0] * q[0] + q[1] * q[1]).sqrt()
}

/// Rasterise a view's strokes: RGBA per pixel, rgb = desired colour, a = 1 on constraints.
pub fn rasterise_strokes(view: &View) -> Raster {
    let (w, h) = (view.width, view.height);
    let mut r = Raster::new(w, h, 4, 0.0);
    for s in &view.strokes {
        let radius = s.width.max(0.0) * 0.5;
        let pts = &s.points;
        if pts.is_empty() {
            continue;
        }
        let lo = pts
            .iter()
            .fold([f32::MAX; 2], |m, p| [m[0].min(p[0]), m[1].min(p[1])]);
        let hi = pts
            .iter()
            .fold([f32::MIN; 2], |m, p| [m[0].max(p[0]), m[1].max(p[1])]);
        let x0 = (lo[0] - radius - 1.0).floor().max(0.0) as u32;
        let y0 = (lo[1] - radius - 1.0).floor().max(0.0) as u32;
        let x1 = ((hi[0] + radius + 1.0).ceil().max(0.0) as u32).min(w);
        let y1 = ((hi[1] + radius + 1.0).ceil().max(0.0) as u32).min(h);
        for y in y0..y1 {
            for x in x0..x1 {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let d = if pts.len() == 1 {
                    segment_distance(p, pts[0], pts[0])
                } else {
                    pts.windows(2)
                        .map(|ab| segment_distance(p, ab[0], ab[1]))
                        .fold(f32::INFINITY, f32::min)
                };
                if d <= radius {
                    let k = ((y * w + x) * 4) as usize;
                    let v = if s.erase {
                        [0.0; 4]
                    } else {
                        [s.colour[0], s.colour[1], s.colour[2], 1.0]
                    };
                    r.data[k..k + 4].copy_from_slice(&v);
                }
            }
        }
    }
    r
}

/// The scene camera a view uses.
pub fn view_camera(v: &View, scene: &Camera) -> Camera {
    match &v.camera {
        ViewCamera::Scene => *scene,
        ViewCamera::Look {
            position,
            target,
            fov,
        } => Camera {
            position: Vec3::from(*position),
            target: Vec3::from(*target),
            fov_y: *fov,
            ..*scene
        },
    }
}

// ---------------------------------------------------------------------------------------------
// The problem: what both the CPU reference and the GPU passes need.

/// Medium and sampling of the solve.
#[derive(Debug, Clone, Copy)]
pub struct Sampling {
    /// σt.
    pub sigma_t: f32,
    /// Samples per ray.
    pub steps: u32,
    /// Shadow bias.
    pub bias: f32,
}

/// One view, ready to solve: camera matrices, linear depth, and the rasterised targets.
#[derive(Debug, Clone)]
pub struct ViewProblem {
    /// Camera matrices.
    pub camera: Matrices,
    /// Linear depth (one channel) at the view's size.
    pub depth: Raster,
    /// Targets: RGBA, a = 1 on constraint pixels.
    pub targets: Raster,
}

impl ViewProblem {
    /// Indices of the constraint pixels.
    pub fn constrained(&self) -> Vec<usize> {
        (0..(self.targets.width * self.targets.height) as usize)
            .filter(|k| self.targets.data[k * 4 + 3] > 0.0)
            .collect()
    }
}

use crate::nodes::algorithms::shader_lib::decay_integral;

/// The samples of constraint pixel k of a view with nonzero weight: `(texel indices, bilinear
/// weights × ŵ_i)` for each lit sample (CPU reference of the shader's marching).
fn row(
    v: &ViewProblem,
    k: usize,
    shadow: &Raster,
    light: &Matrices,
    n: u32,
    s: Sampling,
) -> Vec<([usize; 4], [f32; 4])> {
    let (w, h) = (v.depth.width, v.depth.height);
    let (x, y) = ((k as u32) % w, (k as u32) / w);
    let lvp = light.view_proj();
    let eye = v.camera.eye();
    let dir = v.camera.pixel_ray(x, y, w, h);
    let depth = v.depth.data[k];
    let total = decay_integral(depth, s.sigma_t);
    let steps = s.steps as f32;
    let mut out = Vec::new();
    if total <= 0.0 {
        return out;
    }
    for i in 0..s.steps {
        let t = (i as f32 + 0.5) / steps * depth;
        let c = lvp * (eye + dir * t).extend(1.0);
        let (u, vv, z) = (c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z);
        let inside =
            (0.0..1.0).contains(&u) && (0.0..1.0).contains(&vv) && (0.0..=1.0).contains(&z);
        if inside {
            let tx = ((u * shadow.width as f32) as u32).min(shadow.width - 1);
            let ty = ((vv * shadow.height as f32) as u32).min(shadow.height - 1);
            if z > shadow.pixel(tx, ty)[0] + s.bias {
                continue;
            }
        }
        let a = i as f32 / steps * depth;
        let wi = (-s.sigma_t * a).exp() * decay_integral(depth / steps, s.sigma_t) / total;
        let q = [u * n as f32 - 0.5, vv * n as f32 - 0.5];
        let f = [q[0] - q[0].floor(), q[1] - q[1].floor()];
        let i0 = [q[0].floor() as i64, q[1].floor() as i64];
        let cl = |v: i64| v.clamp(0, n as i64 - 1) as usize;
        let (x0, x1, y0, y1) = (cl(i0[0]), cl(i0[0] + 1), cl(i0[1]), cl(i0[1] + 1));
        let nn = n as usize;
        out.push((
            [y0 * nn + x0, y0 * nn + x1, y1 * nn + x0, y1 * nn + x1],
            [
                wi * (1.0 - f[0]) * (1.0 - f[1]),
                wi * f[0] * (1.0 - f[1]),
                wi * (1.0 - f[0]) * f[1],
                wi * f[0] * f[1],
            ],
        ));
    }
    out
}

/// The operator T on the CPU, rows precomputed (the reference for small problems).
pub struct CpuOperator {
    rows: Vec<Vec<([usize; 4], [f32; 4])>>,
    texels: usize,
}

impl CpuOperator {
    /// Build the rows of every constraint pixel of every view, in view order.
    pub fn new(
        views: &[ViewProblem],
        shadow: &Raster,
        light: &Matrices,
        n: u32,
        s: Sampling,
    ) -> Self {
        let rows = views
            .iter()
            .flat_map(|v| {
                v.constrained()
                    .into_iter()
                    .map(|k| row(v, k, shadow, light, n, s))
                    .collect::<Vec<_>>()
            })
            .collect();
        Self {
            rows,
            texels: (n * n) as usize,
        }
    }
}

/// What the solver needs from T: `T x` and `Tᵀ r` (RGB per texel / per constraint pixel).
pub trait Operator {
    /// Number of constraint pixels.
    fn rows(&self) -> usize;
    /// Number of light-map texels.
    fn texels(&self) -> usize;
    /// T x.
    fn forward(&mut self, x: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NodeError>;
    /// Tᵀ r.
    fn adjoint(&mut self, r: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NodeError>;
}

impl Operator for CpuOperator {
    fn rows(&self) -> usize {
        self.rows.len()
    }

    fn texels(&self) -> usize {
        self.texels
    }

    fn forward(&mut self, x: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NodeError> {
        Ok(self
            .rows
            .iter()
            .map(|r| {
                let mut s = [0.0f32; 3];
                for (idx, w) in r {
                    for c in 0..4 {
                        for ch in 0..3 {
                            s[ch] += w[c] * x[idx[c]][ch];
                        }
                    }
                }
                s
            })
            .collect())
    }

    fn adjoint(&mut self, res: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NodeError> {
        let mut out = vec![[0.0f64; 3]; self.texels];
        for (r, rv) in self.rows.iter().zip(res) {
            for (idx, w) in r {
                for c in 0..4 {
                    for ch in 0..3 {
                        out[idx[c]][ch] += (w[c] * rv[ch]) as f64;
                    }
                }
            }
        }
        Ok(out.iter().map(|v| v.map(|x| x as f32)).collect())
    }
}

// ---------------------------------------------------------------------------------------------
// The solver (shared by the CPU reference and the GPU node).

/// Solver settings (the node's parameters).
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// Iterations at most.
    pub iterations: u32,
    /// Relative tolerance on ‖Tᵀ r‖.
    pub tolerance: f64,
    /// Keep x ≥ 0.
    pub non_negative: bool,
    /// The constant start value.
    pub start: f32,
}

/// What a solve returns.
#[derive(Debug, Clone)]
pub struct Solution {
    /// The light map, RGB per texel (row-major, N×N).
    pub x: Vec<[f32; 3]>,
    /// ‖T x − b‖ at the start and after each iteration.
    pub residuals: Vec<f64>,
}

fn dot(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (0..3).map(|c| x[c] as f64 * y[c] as f64).sum::<f64>())
        .sum()
}

/// CGLS on `min ½‖T x − b‖²` with b = desired ⊙ T 1, from the constant start map (see the
/// module docs for the non-negativity rule). `progress` is called after each iteration with
/// (iteration, residual).
pub fn solve(
    op: &mut dyn Operator,
    desired: &[[f32; 3]],
    set: Settings,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<Solution, NodeError> {
    let texels = op.texels();
    let ones = vec![[1.0f32; 3]; texels];
    let white = op.forward(&ones)?;
    let b: Vec<[f32; 3]> = desired
        .iter()
        .zip(&white)
        .map(|(d, w)| [d[0] * w[0], d[1] * w[1], d[2] * w[2]])
        .collect();
    let mut x = vec![[set.start; 3]; texels];
    let residual_of = |tx: &[[f32; 3]]| -> Vec<[f32; 3]> {
        b.iter()
            .zip(tx)
            .map(|(b, t)| [b[0] - t[0], b[1] - t[1], b[2] - t[2]])
            .collect()
    };
    let mut r = residual_of(&op.forward(&x)?);
    let mut residuals = vec![dot(&r, &r).sqrt()];
    if op.rows() == 0 || set.iterations == 0 {
        return Ok(Solution { x, residuals });
    }
    let mut s = op.adjoint(&r)?;
    // Texels frozen at 0 (non-negativity): x = 0 and the descent direction points below 0.
    let freeze = |x: &[[f32; 3]], s: &mut [[f32; 3]]| {
        if set.non_negative {
            for (xi, si) in x.iter().zip(s.iter_mut()) {
                for c in 0..3 {
                    if xi[c] <= 0.0 && si[c] < 0.0 {
                        si[c] = 0.0;
                    }
                }
            }
        }
    };
    freeze(&x, &mut s);
    let s0 = dot(&s, &s).sqrt();
    let mut p = s.clone();
    let mut gamma = dot(&s, &s);
    for it in 0..set.iterations {
        if gamma.sqrt() <= set.tolerance * s0 || gamma == 0.0 {
            break;
        }
        // Exact minimiser along p: (Tᵀr · p)/‖T p‖² (p is 0 on frozen texels, where s and Tᵀr
        // differ); a direction that is no longer a descent one restarts from s.
        let mut sp = dot(&s, &p);
        if sp <= 0.0 {
            p = s.clone();
            sp = gamma;
        }
        let q = op.forward(&p)?;
        let qq = dot(&q, &q);
        if qq <= 0.0 {
            break;
        }
        let alpha = sp / qq;
        let a = alpha as f32;
        let step = |x: &[[f32; 3]], a: f32| -> Vec<[f32; 3]> {
            x.iter()
                .zip(&p)
                .map(|(xi, pi)| std::array::from_fn(|c| xi[c] + a * pi[c]))
                .collect()
        };
        let full = step(&x, a);
        let leaves = set.non_negative && full.iter().flatten().any(|v| *v < 0.0);
        let hit = if leaves {
            // The full step leaves x ≥ 0: project it back; keep the projection if it lowers
            // the residual, else take the longest step that stays feasible (which always
            // does). Either way CG restarts below.
            let projected: Vec<[f32; 3]> = full.iter().map(|v| v.map(|c| c.max(0.0))).collect();
            let rp = residual_of(&op.forward(&projected)?);
            let last = residuals[residuals.len() - 1];
            if dot(&rp, &rp).sqrt() < last {
                x = projected;
                r = rp;
            } else {
                let mut limit = alpha;
                for (xi, pi) in x.iter().zip(&p) {
                    for c in 0..3 {
                        if pi[c] < 0.0 {
                            limit = limit.min((-(xi[c] as f64) / pi[c] as f64).max(0.0));
                        }
                    }
                }
                x = step(&x, limit as f32)
                    .into_iter()
                    .map(|v| v.map(|c| c.max(0.0)))
                    .collect();
                r = residual_of(&op.forward(&x)?);
            }
            true
        } else {
            x = full;
            for (ri, qi) in r.iter_mut().zip(&q) {
                for c in 0..3 {
                    ri[c] -= a * qi[c];
                }
            }
            false
        };
        let res = dot(&r, &r).sqrt();
        residuals.push(res);
        progress(it + 1, res);
        s = op.adjoint(&r)?;
        freeze(&x, &mut s);
        let new_gamma = dot(&s, &s);
        if hit {
            p = s.clone();
        } else {
            let beta = (new_gamma / gamma) as f32;
            for (pi, si) in p.iter_mut().zip(&s) {
                for c in 0..3 {
                    pi[c] = si[c] + beta * pi[c];
                }
            }
        }
        if set.non_negative {
            // Frozen texels do not move.
            for ((pi, si), xi) in p.iter_mut().zip(&s).zip(&x) {
                for c in 0..3 {
                    if xi[c] <= 0.0 && si[c] == 0.0 {
                        pi[c] = 0.0;
                    }
                }
            }
        }
        gamma = new_gamma;
    }
    Ok(Solution { x, residuals })
}

/// The desired colours of every constraint pixel, in view order.
pub fn desired(views: &[ViewProblem]) -> Vec<[f32; 3]> {
    views
        .iter()
        .flat_map(|v| {
            v.constrained()
                .into_iter()
                .map(|k| {
                    [
                        v.targets.data[k * 4],
                        v.targets.data[k * 4 + 1],
                        v.targets.data[k * 4 + 2],
                    ]
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// GPU.

crate::uniforms! {
    /// Uniforms of `shaders/light_map_solve.wgsl` (struct `View`).
    pub struct ViewParams as "View" {
        /// Camera clip → world.
        pub inv_view_proj: [[f32; 4]; 4],
        /// World → light clip.
        pub light_view_proj: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// Samples per ray.
        pub steps: u32,
        /// Fixed-point scale per channel (adjoint), 2^61 / Σ|r|.
        pub scale: [f32; 3],
        /// σt.
        pub sigma_t: f32,
        /// Light map size.
        pub map_size: [u32; 2],
        /// Shadow bias.
        pub bias: f32,
        /// Padding.
        pub _pad0: u32,
    }
}

/// One view's textures on the GPU.
struct GpuView {
    problem: ViewProblem,
    depth: GpuTexture,
    targets: GpuTexture,
    pixels: Vec<usize>,
}

/// The operator T on the GPU.
pub struct GpuOperator<'a> {
    gpu: &'a Gpu,
    views: Vec<GpuView>,
    shadow: &'a GpuTexture,
    light: Matrices,
    n: u32,
    sampling: Sampling,
    rows: usize,
}

impl<'a> GpuOperator<'a> {
    /// Upload the views' depths and targets.
    pub fn new(
        gpu: &'a Gpu,
        views: Vec<ViewProblem>,
        shadow: &'a GpuTexture,
        light: Matrices,
        n: u32,
        sampling: Sampling,
    ) -> Result<Self, GpuError> {
        let mut out = Vec::new();
        let mut rows = 0;
        for v in views {
            let (w, h) = (v.depth.width, v.depth.height);
            let depth = gpu.upload(w, h, 1, &v.depth.data)?;
            let targets = gpu.upload(w, h, 4, &v.targets.data)?;
            let pixels = v.constrained();
            rows += pixels.len();
            out.push(GpuView {
                problem: v,
                depth,
                targets,
                pixels,
            });
        }
        Ok(Self {
            gpu,
            views: out,
            shadow,
            light,
            n,
            sampling,
            rows,
        })
    }

    fn params(&self, v: &ViewProblem, scale: [f32; 3]) -> ViewParams {
        ViewParams {
            inv_view_proj: v.camera.view_proj().inverse().to_cols_array_2d(),
            light_view_proj: self.light.view_proj().to_cols_array_2d(),
            eye: v.camera.eye().to_array(),
            steps: self.sampling.steps,
            scale,
            sigma_t: self.sampling.sigma_t,
            map_size: [self.n, self.n],
            bias: self.sampling.bias,
            _pad0: 0,
        }
    }

    fn upload_map(&self, x: &[[f32; 3]]) -> Result<GpuTexture, GpuError> {
        let data: Vec<f32> = x.iter().flat_map(|v| [v[0], v[1], v[2], 1.0]).collect();
        self.gpu.upload(self.n, self.n, 4, &data)
    }
}

impl Operator for GpuOperator<'_> {
    fn rows(&self) -> usize {
        self.rows
    }

    fn texels(&self) -> usize {
        (self.n * self.n) as usize
    }

    fn forward(&mut self, x: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NodeError> {
        let map = self.upload_map(x)?;
        let mut out = Vec::with_capacity(self.rows);
        for v in &self.views {
            let (w, h) = (v.problem.depth.width, v.problem.depth.height);
            let p = self.params(&v.problem, [0.0; 3]);
            let tx = self.gpu.texture(w, h, TexFormat::Rgba32F)?;
            self.gpu.dispatch(
                SHADER,
                "forward",
                &[
                    (0, Bind::Uniform(bytemuck::bytes_of(&p))),
                    (1, Bind::Texture(self.shadow)),
                    (2, Bind::Texture(&v.depth)),
                    (3, Bind::Texture(&v.targets)),
                    (4, Bind::Texture(&map)),
                    (5, Bind::Storage(&tx)),
                ],
                w,
                h,
            )?;
            let data = self.gpu.read_texture(&tx)?;
            out.extend(
                v.pixels
                    .iter()
                    .map(|&k| [data[k * 4], data[k * 4 + 1], data[k * 4 + 2]]),
            );
        }
        Ok(out)
    }

    fn adjoint(&mut self, r: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NodeError> {
        // Scale per channel so that no texel's sum can leave the i32 range (see the shader).
        let mut mass = [0.0f64; 3];
        for v in r {
            for c in 0..3 {
                mass[c] += v[c].abs() as f64;
            }
        }
        // 2^61 / Σ|r|, capped so that it stays a finite f32 for tiny residuals.
        let scale = mass.map(|m| {
            if m > 0.0 {
                (2f64.powi(61) / m).min(1e37) as f32
            } else {
                0.0
            }
        });
        let texels = self.texels();
        let acc = self.gpu.buffer_zeroed(6 * texels as u32)?;
        let mut offset = 0;
        for v in &self.views {
            let (w, h) = (v.problem.depth.width, v.problem.depth.height);
            let mut img = vec![0.0f32; (w * h * 4) as usize];
            for (i, &k) in v.pixels.iter().enumerate() {
                img[k * 4..k * 4 + 3].copy_from_slice(&r[offset + i]);
            }
            offset += v.pixels.len();
            let res = self.gpu.upload(w, h, 4, &img)?;
            let p = self.params(&v.problem, scale);
            self.gpu.dispatch(
                SHADER,
                "adjoint",
                &[
                    (0, Bind::Uniform(bytemuck::bytes_of(&p))),
                    (1, Bind::Texture(self.shadow)),
                    (2, Bind::Texture(&v.depth)),
                    (3, Bind::Texture(&v.targets)),
                    (6, Bind::Texture(&res)),
                    (7, Bind::Buffer(&acc)),
                ],
                w,
                h,
            )?;
        }
        let words = self.gpu.read_buffer_i32(&acc)?;
        let value = |w: usize| -> f64 {
            let lo = words[2 * w] as u32 as u64;
            let hi = words[2 * w + 1] as u32 as u64;
            ((hi << 32) | lo) as i64 as f64
        };
        Ok((0..texels)
            .map(|i| {
                std::array::from_fn(|c| {
                    if scale[c] > 0.0 {
                        (value(c * texels + i) / scale[c] as f64) as f32
                    } else {
                        0.0
                    }
                })
            })
            .collect())
    }
}

/// Render each view's depth and rasterise its strokes.
pub fn view_problems(
    gpu: &Gpu,
    scene: &GpuScene,
    data: &SolveData,
) -> Result<Vec<ViewProblem>, NodeError> {
    data.views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            if v.width == 0 || v.height == 0 || v.width > 8192 || v.height > 8192 {
                return Err(NodeError::Data(format!(
                    "view {i}: size {}×{} is outside 1…8192",
                    v.width, v.height
                )));
            }
            if let ViewCamera::Look { fov, .. } = v.camera {
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(NodeError::Data(format!(
                        "view {i}: fov {fov} is outside 0…180 degrees"
                    )));
                }
            }
            let cam = view_camera(v, &scene.scene.camera);
            let (depth, _, _, camera) =
                super::g_buffer::render(gpu, scene, &cam, v.width, v.height)?;
            let depth = Raster {
                width: v.width,
                height: v.height,
                channels: 1,
                data: gpu.read_texture(&depth)?,
            };
            Ok(ViewProblem {
                camera,
                depth,
                targets: rasterise_strokes(v),
            })
        })
        .collect()
}

impl NodeKind for LightMapSolve {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let scene =
            ctx.require("scene")?
                .payload::<GpuScene>()
                .ok_or_else(|| NodeError::Input {
                    port: "scene".into(),
                    message: "is not a scene".into(),
                })?;
        let (shadow, light) = match ctx.require("shadow")? {
            PortValue::ShadowMap(t, m) => (t.clone(), *m),
            _ => {
                return Err(NodeError::Input {
                    port: "shadow".into(),
                    message: "is not a shadow map".into(),
                })
            }
        };
        let data: SolveData = ctx.data()?;
        let n = ctx.texture_side("resolution", 2)?;
        ctx.check_bytes("resolution", u64::from(n).pow(2) * 16)?;
        let sampling = Sampling {
            sigma_t: ctx.f32("sigma_t")?,
            steps: ctx.int("steps")? as u32,
            bias: ctx.f32("bias")?,
        };
        let set = Settings {
            iterations: ctx.int("iterations")? as u32,
            tolerance: ctx.f64("tolerance")?,
            non_negative: ctx.bool("non_negative")?,
            start: ctx.f32("start")?,
        };
        for (i, v) in data.views.iter().enumerate() {
            let bad = v.strokes.iter().any(|s| {
                !s.width.is_finite()
                    || s.colour
                        .iter()
                        .chain(s.points.iter().flatten())
                        .any(|x| !x.is_finite())
            });
            if bad {
                return Err(NodeError::Data(format!(
                    "view {i}: a stroke has a number that is not finite"
                )));
            }
        }
        let views = view_problems(ctx.gpu, scene, &data)?;
        let want = desired(&views);
        let mut op = GpuOperator::new(ctx.gpu, views, &shadow, light, n, sampling)?;
        let pixels = want.len();
        ctx.report(
            0,
            set.iterations as u64,
            format!("{pixels} constraint pixels, {n}² map"),
        );
        let sol = solve(&mut op, &want, set, &mut |it, res| {
            ctx.report(
                it as u64,
                set.iterations as u64,
                format!("residual {res:.3e}"),
            );
        })?;
        ctx.report(
            set.iterations as u64,
            set.iterations as u64,
            format!(
                "{} iterations, residual {:.3e}",
                sol.residuals.len() - 1,
                sol.residuals.last().copied().unwrap_or(0.0)
            ),
        );
        let data: Vec<f32> = sol.x.iter().flat_map(|v| [v[0], v[1], v[2], 1.0]).collect();
        let map = ctx.gpu.upload(n, n, 4, &data)?;
        let res: Vec<f32> = sol.residuals.iter().map(|&r| r as f32).collect();
        let residual = ctx.gpu.upload(res.len() as u32, 1, 1, &res)?;
        ctx.set("light_map", PortValue::LightMap(Arc::new(map), light));
        ctx.set("residual", PortValue::Scalar(Arc::new(residual)));
        Ok(())
    }
}

/// The CPU reference of the whole node for given views (tests): the same solver with the CPU
/// operator.
pub fn solve_reference(
    views: &[ViewProblem],
    shadow: &Raster,
    light: &Matrices,
    n: u32,
    sampling: Sampling,
    set: Settings,
) -> Result<Solution, NodeError> {
    let mut op = CpuOperator::new(views, shadow, light, n, sampling);
    solve(&mut op, &desired(views), set, &mut |_, _| {})
}

/// The GPU solve for given views (tests and the bench): the node's path without the graph.
pub fn solve_gpu(
    gpu: &Gpu,
    views: Vec<ViewProblem>,
    shadow: &GpuTexture,
    light: Matrices,
    n: u32,
    sampling: Sampling,
    set: Settings,
) -> Result<Solution, NodeError> {
    let want = desired(&views);
    let mut op = GpuOperator::new(gpu, views, shadow, light, n, sampling)?;
    solve(&mut op, &want, set, &mut |_, _| {})
}
