//! `Heterogeneity`: an irregular medium from noise (SPEC §6, seed 000 §4.3) —
//! `h(x, ω) = s⁻¹ ∫₀ˢ I(x_t) (α(x_t) N(x_t, f(x_t)) + 1 − α(x_t)) dt`, `L̂_scat = L_scat · h`.
//!
//! The view ray of each pixel (the `depth` input's camera) is marched at `steps` interval
//! midpoints up to its surface (sky: the far distance). N is the `noise` volume at mip level f
//! (0 = its finest; fractional levels mix the two nearest); α (heterogeneity amount), f
//! (frequency as a mip level) and I (intensity) come from the `alpha`, `frequency`,
//! `intensity` volumes when connected, else from the parameters of the same names. Volumes are
//! read trilinearly between texel centres in their own world box, clamped to its edges (a point
//! outside takes the nearest face's value). With α = 0 and I = 1 (parameters, no volumes) h ≡ 1:
//! the node passes `inscatter` through without marching, and the evaluator's statistics show it
//! as `passed through` (`tyndall eval --stats`).
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `inscatter` | in | Image (required) | L_scat |
//! | `depth` | in | Depth (required) | camera and surface distance (same size) |
//! | `noise` | in | Volume (required) | N in [0, 1] (NoiseVolume) |
//! | `alpha`, `frequency`, `intensity` | in | Volume | painted α, f, I |
//! | `image` | out | Image | L̂_scat = L_scat · h |
//! | `h` | out | Scalar | h |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `alpha` | Float | 0.5 | 0…1 | α without a volume |
//! | `frequency` | Float | 0 | 0…16 levels | f without a volume (mip level of the noise) |
//! | `intensity` | Float | 1 | 0…1e3 | I without a volume |
//! | `steps` | Int | 64 | 1…4096 | samples per ray (quality knob) |

use std::sync::Arc;

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuVolume, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `Heterogeneity` node kind.
pub struct Heterogeneity;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        alpha: f32 = ParamSpec::float("alpha", 0.5, 0.0, 1.0, "", "Heterogeneity amount α when no volume is connected."),
        frequency: f32 = ParamSpec::float("frequency", 0.0, 0.0, 16.0, "level", "Noise mip level f when no volume is connected (0 = finest)."),
        intensity: f32 = ParamSpec::float("intensity", 1.0, 0.0, 1e3, "", "Intensity I when no volume is connected."),
        steps: i64 = ParamSpec::int("steps", 64, 1, 4096, "samples", "Samples per view ray (quality knob)."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Heterogeneity",
    category: "Medium",
    doc: "Irregular medium: in-scatter × the ray average of I (α N(x, f) + 1 − α), with α, f, I from volumes or constants.",
    inputs: &[
        PortSpec::required("inscatter", &[PortType::Image], "In-scattered light L_scat (SingleScattering)."),
        PortSpec::required("depth", &[PortType::Depth], "Camera linear depth (same size)."),
        PortSpec::required("noise", &[PortType::Volume], "Noise N in [0, 1] (NoiseVolume)."),
        PortSpec::input("alpha", &[PortType::Volume], "Heterogeneity amount α (unconnected: the `alpha` parameter)."),
        PortSpec::input("frequency", &[PortType::Volume], "Noise frequency f as a mip level (unconnected: `frequency`)."),
        PortSpec::input("intensity", &[PortType::Volume], "Intensity I (unconnected: `intensity`)."),
    ],
    outputs: &[
        PortSpec::output("image", &[PortType::Image], "L̂_scat = L_scat · h."),
        PortSpec::output("h", &[PortType::Scalar], "The heterogeneity factor h."),
    ],
    params: Params::SPECS,
}).tools(&["splat_brush"])

.shaders(&[SHADER])
.uniforms(&[HeteroParams::LAYOUT]);

const SHADER: Shader = crate::shader(
    "heterogeneity",
    include_str!("../shaders/heterogeneity.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/heterogeneity.wgsl` (struct `Params`).
    pub struct HeteroParams as "Params" {
        /// Camera clip → world.
        pub inv_view_proj: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// Samples per ray.
        pub steps: u32,
        /// Noise box, low corner.
        pub noise_min: [f32; 3],
        /// α constant.
        pub alpha: f32,
        /// Noise box, high corner.
        pub noise_max: [f32; 3],
        /// f constant.
        pub frequency: f32,
        /// α box, low corner.
        pub alpha_min: [f32; 3],
        /// I constant.
        pub intensity: f32,
        /// α box, high corner.
        pub alpha_max: [f32; 3],
        /// 1: α from its volume.
        pub use_alpha: u32,
        /// f box, low corner.
        pub freq_min: [f32; 3],
        /// 1: f from its volume.
        pub use_freq: u32,
        /// f box, high corner.
        pub freq_max: [f32; 3],
        /// 1: I from its volume.
        pub use_intensity: u32,
        /// I box, low corner.
        pub int_min: [f32; 3],
        /// Padding.
        pub _pad0: u32,
        /// I box, high corner.
        pub int_max: [f32; 3],
        /// Padding.
        pub _pad1: u32,
    }
}

/// A volume on the CPU: its levels (size, values x fastest) and world box.
#[derive(Debug, Clone)]
pub struct CpuVolume {
    /// Mip levels, finest first.
    pub levels: Vec<([u32; 3], Vec<f32>)>,
    /// World box `[min, max]`.
    pub bounds: [[f32; 3]; 2],
}

impl CpuVolume {
    /// Read a GPU volume back (every level).
    pub fn read(
        gpu: &tyndall_engine::gpu::Recorder,
        v: &GpuVolume,
        bounds: [[f32; 3]; 2],
    ) -> Result<Self, tyndall_engine::gpu::GpuError> {
        let levels = (0..v.mips())
            .map(|l| Ok((v.level_size(l), gpu.read_volume(v, l)?)))
            .collect::<Result<Vec<_>, tyndall_engine::gpu::GpuError>>()?;
        Ok(Self { levels, bounds })
    }

    fn uvw(&self, x: [f32; 3]) -> [f32; 3] {
        std::array::from_fn(|k| {
            let (lo, hi) = (self.bounds[0][k], self.bounds[1][k]);
            ((x[k] - lo) / (hi - lo).max(1e-12)).clamp(0.0, 1.0)
        })
    }

    fn trilinear(&self, level: usize, p: [f32; 3]) -> f32 {
        let (s, d) = &self.levels[level.min(self.levels.len() - 1)];
        let q: [f32; 3] = std::array::from_fn(|k| p[k] * s[k] as f32 - 0.5);
        let f: [f32; 3] = std::array::from_fn(|k| q[k] - q[k].floor());
        let b: [i64; 3] = std::array::from_fn(|k| q[k].floor() as i64);
        let at = |o: [i64; 3]| {
            let c: [i64; 3] = std::array::from_fn(|k| (b[k] + o[k]).clamp(0, s[k] as i64 - 1));
            d[((c[2] * s[1] as i64 + c[1]) * s[0] as i64 + c[0]) as usize]
        };
        let c: [f32; 8] = std::array::from_fn(|k| {
            at([(k & 1) as i64, ((k >> 1) & 1) as i64, ((k >> 2) & 1) as i64])
        });
        let l = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let x00 = l(c[0], c[1], f[0]);
        let x10 = l(c[2], c[3], f[0]);
        let x01 = l(c[4], c[5], f[0]);
        let x11 = l(c[6], c[7], f[0]);
        l(l(x00, x10, f[1]), l(x01, x11, f[1]), f[2])
    }

    /// The value at world point x, level 0.
    pub fn at(&self, x: [f32; 3]) -> f32 {
        self.trilinear(0, self.uvw(x))
    }

    /// The value at world point x and fractional level f.
    pub fn at_level(&self, x: [f32; 3], f: f32) -> f32 {
        let top = (self.levels.len() - 1) as f32;
        let l = f.clamp(0.0, top);
        let (l0, l1) = (
            l.floor() as usize,
            (l.floor() as usize + 1).min(top as usize),
        );
        let p = self.uvw(x);
        let (a, b) = (self.trilinear(l0, p), self.trilinear(l1, p));
        a + (b - a) * (l - l.floor())
    }
}

/// α, f and I: constants or volumes.
#[derive(Debug, Clone)]
pub struct Fields<'a> {
    /// α volume or constant.
    pub alpha: Result<&'a CpuVolume, f32>,
    /// f volume or constant.
    pub frequency: Result<&'a CpuVolume, f32>,
    /// I volume or constant.
    pub intensity: Result<&'a CpuVolume, f32>,
}

/// CPU reference: h per pixel of `depth` (the camera `m`).
pub fn reference_h(
    depth: &Raster,
    m: &Matrices,
    noise: &CpuVolume,
    fields: &Fields,
    steps: u32,
) -> Vec<f32> {
    let eye = m.eye();
    let (w, h) = (depth.width, depth.height);
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let dir = m.pixel_ray(x, y, w, h);
            let s = depth.data[(y * w + x) as usize];
            let mut sum = 0.0f32;
            for i in 0..steps {
                let p = (eye + dir * ((i as f32 + 0.5) / steps as f32 * s)).to_array();
                let v = |f: &Result<&CpuVolume, f32>| match f {
                    Ok(vol) => vol.at(p),
                    Err(c) => *c,
                };
                let (a, f, i_) = (v(&fields.alpha), v(&fields.frequency), v(&fields.intensity));
                sum += i_ * (a * noise.at_level(p, f) + 1.0 - a);
            }
            out.push(sum / steps as f32);
        }
    }
    out
}

/// A volume on a port and its world box.
type BoxedVolume = (Arc<GpuVolume>, [[f32; 3]; 2]);

fn volume(ctx: &RunCtx, port: &str) -> Result<Option<BoxedVolume>, NodeError> {
    ctx.volume_opt(port)
}

impl NodeKind for Heterogeneity {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let ins_value = ctx.require("inscatter")?.clone();
        let ins = ctx.require_texture("inscatter")?;
        let (depth, m) = ctx.depth("depth")?;
        if (depth.width, depth.height) != (ins.width, ins.height) {
            return Err(NodeError::Input {
                port: "depth".into(),
                message: format!(
                    "is {}×{} but inscatter is {}×{}",
                    depth.width, depth.height, ins.width, ins.height
                ),
            });
        }
        let (noise, nb) = volume(ctx, "noise")?.ok_or_else(|| NodeError::Input {
            port: "noise".into(),
            message: "must be connected".into(),
        })?;
        let (a, f, i) = (
            volume(ctx, "alpha")?,
            volume(ctx, "frequency")?,
            volume(ctx, "intensity")?,
        );
        let (alpha, intensity) = (p.alpha, p.intensity);
        if a.is_none() && i.is_none() && alpha == 0.0 && intensity == 1.0 {
            // h ≡ 1: nothing to march.
            ctx.pass_through();
            let ones = vec![1.0f32; (ins.width * ins.height) as usize];
            ctx.set("image", ins_value);
            if ctx.wants("h") {
                let h = ctx.gpu.upload(ins.width, ins.height, 1, &ones)?;
                ctx.set("h", PortValue::Scalar(Arc::new(h)));
            }
            return Ok(());
        }
        let dummy = Arc::new(ctx.gpu.volume([1, 1, 1])?);
        let pick =
            |v: &Option<BoxedVolume>| v.clone().unwrap_or((dummy.clone(), [[0.0; 3], [1.0; 3]]));
        let (av, ab) = pick(&a);
        let (fv, fb) = pick(&f);
        let (iv, ib) = pick(&i);
        let u = HeteroParams {
            inv_view_proj: m.view_proj().inverse().to_cols_array_2d(),
            eye: m.eye().to_array(),
            steps: p.steps as u32,
            noise_min: nb[0],
            alpha,
            noise_max: nb[1],
            frequency: p.frequency,
            alpha_min: ab[0],
            intensity,
            alpha_max: ab[1],
            use_alpha: a.is_some() as u32,
            freq_min: fb[0],
            use_freq: f.is_some() as u32,
            freq_max: fb[1],
            use_intensity: i.is_some() as u32,
            int_min: ib[0],
            _pad0: 0,
            int_max: ib[1],
            _pad1: 0,
        };
        let image = ctx.gpu.texture(ins.width, ins.height, TexFormat::Rgba32F)?;
        let h = ctx.gpu.texture(ins.width, ins.height, TexFormat::R32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "heterogeneity",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("inscatter", Bind::Texture(&ins)),
                ("depth", Bind::Texture(&depth)),
                ("noise", Bind::Volume(&noise)),
                ("alpha_vol", Bind::Volume(&av)),
                ("freq_vol", Bind::Volume(&fv)),
                ("int_vol", Bind::Volume(&iv)),
                ("out_image", Bind::Storage(&image)),
                ("out_h", Bind::Storage(&h)),
            ],
            ins.width,
            ins.height,
        )?;
        ctx.set("image", PortValue::Image(Arc::new(image)));
        ctx.set("h", PortValue::Scalar(Arc::new(h)));
        Ok(())
    }
}
