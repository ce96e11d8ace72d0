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
//! conductance of [`pin`](crate::algorithms::multigrid::pin) rather than fixed. Each V-cycle divides the error by about 3 at every
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

use anchors::resolve_anchors;
use diffusion::mg_pass;

use std::path::Path;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use tyndall_engine::eval::pick::{PickAt, TablePick};
use tyndall_engine::eval::{
    KeyInput, Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx, IDENTITY,
};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `TransferFunction` node kind.
pub struct TransferFunction;

tyndall_engine::choice_enum! {
    /// What the TF colour does to the shafts.
    pub enum Mode { Replace = "Replace", Modulate = "Modulate" }
}

tyndall_engine::choice_enum! {
    /// Where the depth range comes from.
    pub enum DepthRange { Manual = "manual", Auto = "auto" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        mode: Mode = ParamSpec::choice("mode", Mode::NAMES, "Replace", "Replace: output = TF colour × intensity; Modulate: in-scatter × TF colour × intensity."),
        intensity: f32 = ParamSpec::float("intensity", 1.0, 0.0, 1e6, "", "Scales the output."),
        depth_range: DepthRange = ParamSpec::choice("depth_range", DepthRange::NAMES, "manual", "manual: depth_min…depth_max; auto: the frame's 1st…99th percentile of finite surface depth (transfers between scenes of different size)."),
        depth_min: f32 = ParamSpec::float("depth_min", 0.0, 0.0, 1e7, "m", "Depth at v = 0 (depth_range = manual).").when("depth_range", &["manual"]),
        depth_max: f32 = ParamSpec::float("depth_max", 50.0, 0.0, 1e7, "m", "Depth at v = 1 (depth_range = manual).").when("depth_range", &["manual"]),
        resolution: i64 = ParamSpec::int("resolution", 256, 2, 4096, "texels", "Side N of the baked table."),
        diffusion_cycles: i64 = ParamSpec::int("diffusion_cycles", 8, 1, 64, "cycles", "Multigrid V-cycles per diffusion layer (quality knob)."),
    }
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
    params: Params::SPECS,
}).tools(&["layer_list"])

.shaders(&[SHADER, crate::algorithms::quantile::SHADER])
.uniforms(&[LayerParams::LAYOUT, MultigridParams::LAYOUT, LookupParams::LAYOUT, crate::algorithms::quantile::QuantileParams::LAYOUT]);

const SHADER: Shader = crate::shader(
    "transfer_function",
    include_str!("../../shaders/transfer_function.wgsl"),
);

// ---------------------------------------------------------------------------------------------
// The data block.

mod anchors;
mod bake;
mod data;
mod diffusion;

pub use anchors::anchor_tf_position;
pub use bake::{
    auto_range, auto_range_gpu, auto_range_select, bake_gpu, bake_reference, bilinear, blend,
    depth_coordinate, gradient_colour, LayerParams, LookupParams,
};
pub use data::{layer_name, Anchor, Blend, Constraint, Layer, LayerEntry, TfData, TfKey};
pub use diffusion::{diffuse_gpu, diffuse_reference, rasterise_constraints, MultigridParams};

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
        let (Some(vis), Some((depth, camera))) =
            (ctx.scalar_opt("visibility")?, ctx.depth_opt("depth")?)
        else {
            return Ok(None);
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

    /// The depth range: the parameters, or the frame's percentiles as selected on the GPU.
    fn range(&self, ctx: &RunCtx) -> Result<Range, NodeError> {
        let p = Params::from_ctx(ctx)?;
        Ok(match p.depth_range {
            DepthRange::Manual => Range::Manual(p.depth_min, p.depth_max),
            DepthRange::Auto => {
                Range::Selected(auto_range_select(ctx.gpu, &self.depth, &self.camera)?)
            }
        })
    }
}

impl Frame {
    /// The depth range as numbers, `depth` being this frame's depth read back (the automatic
    /// range from it on the CPU, bit for bit the GPU's).
    fn range_values(&self, ctx: &RunCtx, depth: &Raster) -> Result<(f32, f32), NodeError> {
        let p = Params::from_ctx(ctx)?;
        Ok(match p.depth_range {
            DepthRange::Manual => (p.depth_min, p.depth_max),
            DepthRange::Auto => auto_range(&depth.data, &self.camera),
        })
    }
}

/// A frame's depth range: numbers, or percentile selections left on the GPU for the lookup.
enum Range {
    Manual(f32, f32),
    Selected([tyndall_engine::gpu::GpuBuffer; 2]),
}

/// Where a picked pixel lands in the TF: the depth range as the node would use it this frame.
fn table_pick(at: &PickAt) -> Result<TablePick, NodeError> {
    let p = Params::from_params(at.params)?;
    let auto = p.depth_range == DepthRange::Auto;
    let (lo, hi) = if auto {
        auto_range(&at.depth_image.data, at.camera)
    } else {
        (p.depth_min, p.depth_max)
    };
    let v = at.visibility;
    Ok(TablePick {
        node: at.id.to_string(),
        u: if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) },
        v: depth_coordinate(at.depth, lo, hi),
        depth_min: lo,
        depth_max: hi,
        depth_range: if auto { "auto" } else { "manual" }.into(),
    })
}

impl NodeKind for TransferFunction {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    /// The key-frames of the layer stack.
    fn data_key_times(&self, data: &tyndall_engine::graph::NodeData) -> Vec<f64> {
        data.parse::<TfData>()
            .map(|d| d.keys.iter().map(|k| k.t).collect())
            .unwrap_or_default()
    }

    /// (u, v) = (V̄ clamped to [0, 1], the depth normalised over this frame's range).
    fn table_coordinates(&self, at: &PickAt) -> Option<Result<TablePick, NodeError>> {
        Some(table_pick(at))
    }

    fn data_files(
        &self,
        data: &tyndall_engine::graph::NodeData,
        resolve: &dyn Fn(&str) -> String,
    ) -> Result<Option<tyndall_engine::graph::NodeData>, String> {
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
        tyndall_engine::graph::NodeData::from_value(&tf).map(Some)
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
                tyndall_engine::eval::file_stamp(Path::new(path)).hash(&mut h);
            }
        }
        h.finish()
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let frame = Frame::of(ctx)?;
        let lut = match ctx.lut2d_opt("lut")? {
            Some(t) => t,
            None => {
                let n = ctx.side("resolution", p.resolution, 2)?;
                ctx.check_bytes("resolution", u64::from(n).pow(2) * 16)?;
                let cycles = p.diffusion_cycles as u32;
                let mut layers = stack(ctx)?;
                resolve_anchors(ctx, &mut layers, frame.as_ref())?;
                Arc::new(bake_gpu(ctx.gpu, &layers, n, cycles)?)
            }
        };
        if ctx.wants("image") {
            let f = frame.ok_or_else(|| {
                input_err("visibility", "must be connected, with `depth`, for `image`")
            })?;
            let mode = p.mode;
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
            let range = f.range(ctx)?;
            let (depth_min, depth_max) = match range {
                Range::Manual(lo, hi) => (lo, hi),
                Range::Selected(_) => (0.0, 1.0),
            };
            let k = LookupParams {
                depth_min,
                depth_max,
                intensity: p.intensity,
                modulate: (mode == Mode::Modulate) as u32,
            };
            let mut binds = vec![
                ("a_tex", Bind::Texture(&lut)),
                ("b_tex", Bind::Texture(inscatter.as_deref().unwrap_or(&lut))),
                ("K", Bind::Uniform(bytemuck::bytes_of(&k))),
                ("vis_tex", Bind::Texture(&f.vis)),
                ("depth_tex", Bind::Texture(&f.depth)),
            ];
            let entry = match &range {
                Range::Manual(..) => "lookup",
                Range::Selected([lo, hi]) => {
                    binds.extend([("sel_lo", Bind::Buffer(lo)), ("sel_hi", Bind::Buffer(hi))]);
                    "lookup_selected"
                }
            };
            let image = mg_pass(ctx.gpu, entry, (f.vis.width, f.vis.height), &binds)?;
            ctx.set("image", PortValue::Image(Arc::new(image)));
        }
        ctx.set("lut", PortValue::Lut2D(lut));
        Ok(())
    }
}
