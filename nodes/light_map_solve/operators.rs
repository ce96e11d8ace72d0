//! The operator T of the least-squares problem (a constraint pixel's view ray, marched to its
//! first surface, spread bilinearly over the light map): the CPU reference and the GPU passes.

use super::{Bind, GpuError, GpuTexture, Matrices, NodeError, Operator, Raster, TexFormat, SHADER};
use tyndall_engine::eval::LightBlock;
use tyndall_engine::gpu::Recorder;

use crate::algorithms::shader_lib::{decay_integral, henyey_greenstein, light_uvz, sun_reaches};

/// Medium and sampling of the solve.
#[derive(Debug, Clone, Copy)]
pub struct Sampling {
    /// σt.
    pub sigma_t: f32,
    /// Samples per ray.
    pub steps: u32,
    /// Shadow bias.
    pub bias: f32,
    /// Henyey–Greenstein g of the medium: used with a spot, whose phase changes along the ray
    /// (the sun's is one factor of every row and cancels).
    pub g: f32,
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

/// The samples of constraint pixel k of a view with nonzero weight: `(texel indices, bilinear
/// weights × ŵ_i)` for each lit sample (CPU reference of the shader's marching).
pub(super) fn row(
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
    let steps = s.steps as f32;
    // A spot: each sample weighs its falloff and phase too (they change along the ray), and
    // the row is normalised by the sum over all its samples, lit or not (so Σ ŵ_i ≤ 1 still).
    let lamp = |t: f32| -> f32 {
        light.local.map_or(1.0, |l| {
            let p = eye + dir * t;
            let to_light = (l.position() - p).normalize_or_zero();
            l.falloff(p) * henyey_greenstein(s.g, dir.dot(to_light))
        })
    };
    let total = match light.local {
        None => decay_integral(depth, s.sigma_t),
        Some(_) => {
            (0..s.steps)
                .map(|i| {
                    let t = (i as f32 + 0.5) / steps * depth;
                    lamp(t) * (-s.sigma_t * (i as f32 / steps * depth)).exp()
                })
                .sum::<f32>()
                * decay_integral(depth / steps, s.sigma_t)
        }
    };
    let mut out = Vec::new();
    if total <= 0.0 {
        return out;
    }
    for i in 0..s.steps {
        let t = (i as f32 + 0.5) / steps * depth;
        let l = match light.local {
            None => light_uvz(lvp, eye + dir * t),
            Some(local) => local
                .uvz(lvp, eye + dir * t)
                .unwrap_or(glam::Vec3::new(-1.0, -1.0, 2.0)),
        };
        if !sun_reaches(shadow, l, s.bias) {
            continue;
        }
        let (u, vv) = (l.x, l.y);
        let a = i as f32 / steps * depth;
        let wi =
            lamp(t) * (-s.sigma_t * a).exp() * decay_integral(depth / steps, s.sigma_t) / total;
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

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/light_map_solve.wgsl` (struct `View`).
    pub struct ViewParams as "View" {
        /// Camera clip → world.
        pub inv_view_proj: [[f32; 4]; 4],
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
        /// The view's first row in the resident solve's row vectors (`forward_rows`,
        /// `adjoint_rows`; unused by `forward` and `adjoint`).
        pub row_offset: u32,
        /// Henyey–Greenstein g (a spot's rows).
        pub g: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
        /// The light map's light: the sun, or a spot whose falloff and phase weigh each
        /// sample (a point light is refused).
        pub light: LightBlock,
    }
}

impl ViewParams {
    /// The uniforms of one view: its camera, the light (a spot's falloff and cone when its map
    /// is a spot's), the sampling, the map's side `n`, the adjoint's `scale` and the view's
    /// first row.
    pub fn new(
        camera: &Matrices,
        light: &Matrices,
        s: Sampling,
        n: u32,
        scale: [f32; 3],
        row_offset: u32,
    ) -> Self {
        ViewParams {
            inv_view_proj: camera.view_proj().inverse().to_cols_array_2d(),
            eye: camera.eye().to_array(),
            steps: s.steps,
            scale,
            sigma_t: s.sigma_t,
            map_size: [n, n],
            bias: s.bias,
            row_offset,
            g: s.g,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
            light: LightBlock::of_map(light),
        }
    }
}

/// The adjoint's fixed-point scale per channel from Σ|r| per channel: 2^61 / Σ|r|, capped so
/// that it stays a finite f32 for tiny residuals (0 for a channel with no residual).
pub fn fixed_point_scale(mass: [f64; 3]) -> [f32; 3] {
    mass.map(|m| {
        if m > 0.0 {
            (2f64.powi(61) / m).min(1e37) as f32
        } else {
            0.0
        }
    })
}

/// One view's textures on the GPU.
pub(super) struct GpuView {
    problem: ViewProblem,
    depth: GpuTexture,
    targets: GpuTexture,
    pixels: Vec<usize>,
}

/// The operator T on the GPU.
pub struct GpuOperator<'a> {
    gpu: &'a Recorder<'a>,
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
        gpu: &'a Recorder<'a>,
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
        ViewParams::new(&v.camera, &self.light, self.sampling, self.n, scale, 0)
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
                    ("P", Bind::Uniform(bytemuck::bytes_of(&p))),
                    ("shadow", Bind::Texture(self.shadow)),
                    ("depth", Bind::Texture(&v.depth)),
                    ("targets", Bind::Texture(&v.targets)),
                    ("x_map", Bind::Texture(&map)),
                    ("out_tx", Bind::Storage(&tx)),
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
        let scale = fixed_point_scale(mass);
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
                    ("P", Bind::Uniform(bytemuck::bytes_of(&p))),
                    ("shadow", Bind::Texture(self.shadow)),
                    ("depth", Bind::Texture(&v.depth)),
                    ("targets", Bind::Texture(&v.targets)),
                    ("residual", Bind::Texture(&res)),
                    ("acc", Bind::Buffer(&acc)),
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
