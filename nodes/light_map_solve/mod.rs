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
//! The vectors stay on the GPU (`resident.rs`): updates, dot products and the non-negativity
//! projection are passes, and inside the loop only the scalars CG needs come back.
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
//! A spot's map (issue #44): the map is a gobo over its cone, looked up through its perspective
//! projection, and since the spot's falloff a(x) and phase f_g(θ_x) change along the ray they
//! weigh each sample, ŵ_i = a_i f_i ∫_{interval i} e^{−σt t} dt / Σ_j a_j f_j ∫_{interval j} …
//! (all samples j, lit or not, so Σ ŵ ≤ 1 still), with `g` the medium's (as on the
//! `SingleScattering` it feeds). Test: `cargo test --test maps -- through_a_spot` recovers a
//! known gobo to 0.63 % (117 % without the weights). A point light's cube atlas is refused.
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
//! | `g` | Float | 0.5 | −0.999…0.999 | the medium's Henyey–Greenstein g (weighs a spot's samples) |

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;
use tyndall_engine::scene::{Camera, GpuScene};

use crate::algorithms::g_buffer;
use crate::algorithms::ray_cast::Method;

mod data;
mod operators;
mod resident;

pub use crate::algorithms::cgls::{solve, Operator, Settings, Solution};
pub use data::{rasterise_strokes, view_camera, SolveData, Stroke, View, ViewCamera};
pub use operators::{
    desired, fixed_point_scale, CpuOperator, GpuOperator, Sampling, ViewParams, ViewProblem,
};
pub use resident::{solve_resident, VectorParams};

/// The `LightMapSolve` node kind.
pub struct LightMapSolve;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        resolution: i64 = ParamSpec::int("resolution", 256, 2, 4096, "texels", "Side of the light map."),
        iterations: i64 = ParamSpec::int("iterations", 32, 0, 10000, "", "Conjugate-gradient iterations at most."),
        tolerance: f64 = ParamSpec::float("tolerance", 1e-4, 0.0, 1.0, "", "Stop when ‖Tᵀ r‖ falls below tolerance × its first value."),
        non_negative: bool = ParamSpec::flag("non_negative", true, "Keep every texel ≥ 0 (shortened steps, frozen texels, CG restarts)."),
        start: f32 = ParamSpec::float("start", 1.0, 0.0, 1e6, "", "The constant start map; texels no stroke reaches keep it."),
        sigma_t: f32 = ParamSpec::float("sigma_t", 0.08, 0.0, 1e4, "1/m", "Extinction σt of the medium (as on SingleScattering)."),
        steps: i64 = ParamSpec::int("steps", 128, 1, 8192, "samples", "Samples per constraint ray."),
        bias: f32 = ParamSpec::float("bias", 0.002, 0.0, 0.1, "depth", "Shadow test bias (as on SingleScattering)."),
        g: f32 = ParamSpec::float("g", 0.5, -0.999, 0.999, "", "Henyey–Greenstein g of the medium (as on SingleScattering): with a spot its phase changes along the ray and weighs the samples; the sun's cancels."),
    }
}

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
    params: Params::SPECS,
}).tools(&["stroke_painting"])

.shaders(&[SHADER, g_buffer::SHADER])
.uniforms(&[ViewParams::LAYOUT, tyndall_engine::eval::LightBlock::LAYOUT, VectorParams::LAYOUT, g_buffer::GBufferParams::LAYOUT]);

const SHADER: Shader = crate::shader(
    "light_map_solve",
    include_str!("../../shaders/light_map_solve.wgsl"),
);

/// Render each view's depth and rasterise its strokes.
pub fn view_problems(
    gpu: &Recorder,
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
                g_buffer::render(gpu, scene, &cam, (v.width, v.height), Method::Raster)?;
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
        let p = Params::from_ctx(ctx)?;
        let scene = ctx.scene("scene")?;
        let (shadow, light) = ctx.shadow_map("shadow")?;
        if light.local.is_some_and(|l| l.point) {
            return Err(NodeError::Input {
                port: "shadow".into(),
                message: "is a point light's cube atlas: a light map is projected over a sun's \
                          box or a spot's cone"
                    .into(),
            });
        }
        let data: SolveData = ctx.data()?;
        let n = ctx.side("resolution", p.resolution, 2)?;
        ctx.check_bytes("resolution", u64::from(n).pow(2) * 16)?;
        let sampling = Sampling {
            sigma_t: p.sigma_t,
            steps: p.steps as u32,
            bias: p.bias,
            g: p.g,
        };
        let set = Settings {
            iterations: p.iterations as u32,
            tolerance: p.tolerance,
            non_negative: p.non_negative,
            start: p.start,
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
        let pixels = want.len();
        ctx.report(
            0,
            set.iterations as u64,
            format!("{pixels} constraint pixels, {n}² map"),
        );
        let sol = solve_resident(
            ctx.gpu,
            views,
            &shadow,
            light,
            n,
            sampling,
            set,
            &mut |it, res| {
                ctx.report(
                    it as u64,
                    set.iterations as u64,
                    format!("residual {res:.3e}"),
                );
            },
        )?;
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

/// The GPU solve for given views (tests and the bench): the node's path without the graph
/// (the resident solve).
pub fn solve_gpu(
    gpu: &Recorder,
    views: Vec<ViewProblem>,
    shadow: &GpuTexture,
    light: Matrices,
    n: u32,
    sampling: Sampling,
    set: Settings,
) -> Result<Solution, NodeError> {
    solve_resident(gpu, views, shadow, light, n, sampling, set, &mut |_, _| {})
}
