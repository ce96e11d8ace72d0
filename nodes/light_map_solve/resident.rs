//! The GPU-resident solve: the CGLS of [`crate::algorithms::cgls::solve`] step for step
//! (same start, same non-negativity rule, same restarts), with every vector on the GPU. The
//! light map's vectors (x, p, s) are buffers of n² vec4, the constraint pixels' (b, r, q) buffers
//! of one vec4 per constraint pixel (each view's pixels listed once, at an offset); T and Tᵀ run
//! over those lists (`forward_rows`, `adjoint_rows`), updates are `combine` / `mask_frozen`,
//! dot products, squared norms, sums and minima `reduce` to 64 partial values each, which are what comes back
//! inside the loop (added in f64 here): 4–6 small read-backs per iteration, a few KB, where the
//! operator path (`GpuOperator`) read every view and the 3 × n² fixed-point sums back.

use super::{
    desired, fixed_point_scale, Bind, GpuError, GpuTexture, Matrices, NodeError, Sampling,
    Settings, Solution, ViewParams, ViewProblem, SHADER,
};
use tyndall_engine::gpu::Recorder;

use tyndall_engine::gpu::GpuBuffer;

tyndall_engine::uniforms! {
    /// Uniforms of the vector passes of `shaders/light_map_solve.wgsl` (struct `Vectors`).
    pub struct VectorParams as "Vectors" {
        /// Fixed-point scale per channel (`decode`).
        pub scale: [f32; 4],
        /// Elements (vec4) the pass covers.
        pub count: u32,
        /// `reduce`: 0 Σ u·v, 1 Σ|u|, 2 min u, 3 longest step along v keeping u ≥ 0.
        pub mode: u32,
        /// `reduce`: which 64 partials to write.
        pub slot: u32,
        /// `combine`: clamp at 0; `decode`: freeze texels at 0.
        pub clamp_at_zero: u32,
        /// `combine`: u + alpha v.
        pub alpha: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// Partials per reduction at most (`reduce` runs up to 64 workgroups of 256).
const PARTIALS: u32 = 64;
/// Elements per `reduce` workgroup (its `@workgroup_size`).
const REDUCE_GROUP: u32 = 256;

/// Workgroups of a `reduce` over `count` elements: one per 256 elements, 1 to 64 (they stride
/// over longer vectors), so a short vector is not swept by 16384 mostly idle invocations.
fn reduce_groups(count: u32) -> u32 {
    count.div_ceil(REDUCE_GROUP).clamp(1, PARTIALS)
}
/// Reductions one read-back can carry.
const SLOTS: u32 = 4;

/// What a `reduce` computes.
#[derive(Clone, Copy)]
enum Reduce {
    Dot = 0,
    AbsSum = 1,
    Min = 2,
    StepLimit = 3,
    Square = 4,
}

struct View {
    problem: ViewProblem,
    depth: GpuTexture,
    pixels: GpuBuffer,
    offset: u32,
}

/// The resident solver's state: the views and the scratch buffers.
struct Resident<'a> {
    gpu: &'a Recorder<'a>,
    views: Vec<View>,
    shadow: &'a GpuTexture,
    light: Matrices,
    n: u32,
    sampling: Sampling,
    rows: u32,
    acc: GpuBuffer,
    partials: GpuBuffer,
}

fn vec4_words(count: u32) -> u32 {
    count.max(1) * 4
}

impl<'a> Resident<'a> {
    /// Upload the views with constrained pixels (their depths and pixel lists) and the
    /// solver's scratch buffers.
    fn upload(
        gpu: &'a Recorder<'a>,
        views: Vec<ViewProblem>,
        shadow: &'a GpuTexture,
        light: Matrices,
        n: u32,
        sampling: Sampling,
    ) -> Result<Self, NodeError> {
        let mut list = Vec::new();
        let mut rows = 0u32;
        for v in views {
            let (w, h) = (v.depth.width, v.depth.height);
            let depth = gpu.upload(w, h, 1, &v.depth.data)?;
            let pixels: Vec<u32> = v.constrained().into_iter().map(|k| k as u32).collect();
            let count = pixels.len() as u32;
            if count == 0 {
                continue;
            }
            list.push(View {
                problem: v,
                depth,
                pixels: gpu.buffer_from(&pixels)?,
                offset: rows,
            });
            rows += count;
        }
        Ok(Resident {
            gpu,
            views: list,
            shadow,
            light,
            n,
            sampling,
            rows,
            acc: gpu.buffer_zeroed(6 * n * n)?,
            partials: gpu.buffer_zeroed(SLOTS * PARTIALS * 4)?,
        })
    }

    /// b = desired ⊙ T 1 (the only row vector that comes back, once).
    fn right_side(&self, want: &[[f32; 3]]) -> Result<GpuBuffer, GpuError> {
        let ones = self
            .gpu
            .buffer_from(&vec4_data(&vec![[1.0; 3]; self.texels() as usize]))?;
        let white = self.rows_buffer()?;
        self.forward(&ones, &white)?;
        let w = self.read_vec3(&white, self.rows)?;
        let b: Vec<[f32; 3]> = want
            .iter()
            .zip(&w)
            .map(|(d, w)| [d[0] * w[0], d[1] * w[1], d[2] * w[2]])
            .collect();
        self.gpu.buffer_from(&vec4_data(&b))
    }

    /// Frozen texels do not move: the search direction `p` becomes 0 where x = 0 and `s` was
    /// frozen (the GPU twin of `cgls`'s rule).
    fn hold_frozen(&self, x: &GpuBuffer, s: &GpuBuffer, p: &GpuBuffer) -> Result<(), GpuError> {
        self.vector_pass(
            "mask_frozen",
            &[
                ("vin", Bind::Buffer(x)),
                ("vin2", Bind::Buffer(s)),
                ("vout", Bind::Buffer(p)),
            ],
            VectorParams {
                count: self.texels(),
                ..params()
            },
        )
    }

    fn texels(&self) -> u32 {
        self.n * self.n
    }

    fn view_params(&self, v: &View, scale: [f32; 3]) -> ViewParams {
        ViewParams::new(
            &v.problem.camera,
            &self.light,
            self.sampling,
            self.n,
            scale,
            v.offset,
        )
    }

    fn rows_buffer(&self) -> Result<GpuBuffer, GpuError> {
        self.gpu.buffer_zeroed(vec4_words(self.rows))
    }

    fn texel_buffer(&self) -> Result<GpuBuffer, GpuError> {
        self.gpu.buffer_zeroed(vec4_words(self.texels()))
    }

    /// out = T x (x: texels, out: rows).
    fn forward(&self, x: &GpuBuffer, out: &GpuBuffer) -> Result<(), GpuError> {
        for v in &self.views {
            let p = self.view_params(v, [0.0; 3]);
            self.gpu.dispatch(
                SHADER,
                "forward_rows",
                &[
                    ("P", Bind::Uniform(bytemuck::bytes_of(&p))),
                    ("shadow", Bind::Texture(self.shadow)),
                    ("depth", Bind::Texture(&v.depth)),
                    ("vin", Bind::Buffer(x)),
                    ("vout", Bind::Buffer(out)),
                    ("pixels", Bind::Buffer(&v.pixels)),
                ],
                v.pixels.words,
                1,
            )?;
        }
        Ok(())
    }

    /// out = Tᵀ r, texels frozen at 0 (x ≤ 0) with a negative gradient set to 0 when `freeze`;
    /// `mass` is Σ|r| per channel (it sets the fixed-point scale).
    fn adjoint(
        &self,
        r: &GpuBuffer,
        mass: [f64; 3],
        x: &GpuBuffer,
        freeze: bool,
        out: &GpuBuffer,
    ) -> Result<(), GpuError> {
        let scale = fixed_point_scale(mass);
        self.vector_pass(
            "clear",
            &[("acc", Bind::Buffer(&self.acc))],
            VectorParams {
                count: self.acc.words,
                ..params()
            },
        )?;
        for v in &self.views {
            let p = self.view_params(v, scale);
            self.gpu.dispatch(
                SHADER,
                "adjoint_rows",
                &[
                    ("P", Bind::Uniform(bytemuck::bytes_of(&p))),
                    ("shadow", Bind::Texture(self.shadow)),
                    ("depth", Bind::Texture(&v.depth)),
                    ("acc", Bind::Buffer(&self.acc)),
                    ("vin", Bind::Buffer(r)),
                    ("pixels", Bind::Buffer(&v.pixels)),
                ],
                v.pixels.words,
                1,
            )?;
        }
        self.vector_pass(
            "decode",
            &[
                ("acc", Bind::Buffer(&self.acc)),
                ("vin", Bind::Buffer(x)),
                ("vout", Bind::Buffer(out)),
            ],
            VectorParams {
                scale: [scale[0], scale[1], scale[2], 0.0],
                count: self.texels(),
                clamp_at_zero: u32::from(freeze),
                ..params()
            },
        )
    }

    /// One vector pass over `p.count` elements (`reduce`: [`reduce_groups`] workgroups, which
    /// stride over the elements; each writes its partial).
    fn vector_pass(
        &self,
        entry: &str,
        binds: &[(&str, Bind)],
        p: VectorParams,
    ) -> Result<(), GpuError> {
        let mut all = vec![("V", Bind::Uniform(bytemuck::bytes_of(&p)))];
        all.extend_from_slice(binds);
        let width = if entry == "reduce" {
            reduce_groups(p.count) * REDUCE_GROUP
        } else {
            p.count
        };
        self.gpu.dispatch(SHADER, entry, &all, width, 1)
    }

    /// out = u + alpha v (count elements), clamped at 0 when `clamp`.
    fn combine(
        &self,
        u: &GpuBuffer,
        alpha: f32,
        v: &GpuBuffer,
        clamp: bool,
        out: &GpuBuffer,
    ) -> Result<(), GpuError> {
        self.vector_pass(
            "combine",
            &[
                ("vin", Bind::Buffer(u)),
                ("vin2", Bind::Buffer(v)),
                ("vout", Bind::Buffer(out)),
            ],
            VectorParams {
                count: u.words / 4,
                alpha,
                clamp_at_zero: u32::from(clamp),
                ..params()
            },
        )
    }

    /// Queue the reductions `(what, u, v)` (v is ignored by `AbsSum` and `Min` but must be a
    /// buffer other than u) and read their results back: sums over the rgb channels (f64), or
    /// the minimum over them.
    fn reduce(&self, what: &[(Reduce, &GpuBuffer, &GpuBuffer)]) -> Result<Vec<f64>, NodeError> {
        let mut per_channel = self.reduce_channels(what)?;
        Ok(what
            .iter()
            .zip(per_channel.iter_mut())
            .map(|((kind, ..), c)| match kind {
                Reduce::Dot | Reduce::AbsSum | Reduce::Square => c.iter().sum(),
                Reduce::Min | Reduce::StepLimit => c.iter().copied().fold(f64::INFINITY, f64::min),
            })
            .collect())
    }

    /// [`Resident::reduce`] per rgb channel.
    /// ‖r‖ and Σ|r| per channel (the adjoint's normalisation), `scratch` a rows buffer.
    fn residual_norms(
        &self,
        r: &GpuBuffer,
        scratch: &GpuBuffer,
    ) -> Result<(f64, [f64; 3]), NodeError> {
        let v =
            self.reduce_channels(&[(Reduce::Square, r, scratch), (Reduce::AbsSum, r, scratch)])?;
        Ok((v[0].iter().sum::<f64>().sqrt(), v[1]))
    }

    fn reduce_channels(
        &self,
        what: &[(Reduce, &GpuBuffer, &GpuBuffer)],
    ) -> Result<Vec<[f64; 3]>, NodeError> {
        let mut out = Vec::with_capacity(what.len());
        for chunk in what.chunks(SLOTS as usize) {
            for (slot, (kind, u, v)) in chunk.iter().enumerate() {
                self.vector_pass(
                    "reduce",
                    &[
                        ("vin", Bind::Buffer(u)),
                        ("vin2", Bind::Buffer(v)),
                        ("partials", Bind::Buffer(&self.partials)),
                    ],
                    VectorParams {
                        count: u.words / 4,
                        mode: *kind as u32,
                        slot: slot as u32,
                        ..params()
                    },
                )?;
            }
            let words = self.gpu.read_buffer_i32(&self.partials)?;
            let values: &[f32] = bytemuck::cast_slice(&words);
            for (slot, (kind, u, _)) in chunk.iter().enumerate() {
                let start = slot * PARTIALS as usize * 4;
                let part = &values[start..start + reduce_groups(u.words / 4) as usize * 4];
                let minimum = matches!(kind, Reduce::Min | Reduce::StepLimit);
                out.push(std::array::from_fn(|c| {
                    let lane = part.chunks(4).map(|p| p[c] as f64);
                    if minimum {
                        lane.fold(f64::INFINITY, f64::min)
                    } else {
                        lane.sum()
                    }
                }));
            }
        }
        Ok(out)
    }

    fn read_vec3(&self, b: &GpuBuffer, count: u32) -> Result<Vec<[f32; 3]>, GpuError> {
        let words = self.gpu.read_buffer_i32(b)?;
        let values: &[f32] = bytemuck::cast_slice(&words);
        Ok(values
            .chunks(4)
            .take(count as usize)
            .map(|v| [v[0], v[1], v[2]])
            .collect())
    }
}

fn params() -> VectorParams {
    VectorParams {
        scale: [0.0; 4],
        count: 0,
        mode: 0,
        slot: 0,
        clamp_at_zero: 0,
        alpha: 0.0,
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
    }
}

/// The words of a vec4 buffer holding `v` (a = 0); at least one vec4, as the passes bind it.
fn vec4_data(v: &[[f32; 3]]) -> Vec<u32> {
    let mut out: Vec<u32> = v
        .iter()
        .flat_map(|c| [c[0].to_bits(), c[1].to_bits(), c[2].to_bits(), 0])
        .collect();
    out.resize(out.len().max(4), 0);
    out
}

/// The resident CGLS on the views (see the module docs); `progress` as in
/// [`crate::algorithms::cgls::solve`].
#[allow(clippy::too_many_arguments)]
pub fn solve_resident(
    gpu: &Recorder,
    views: Vec<ViewProblem>,
    shadow: &GpuTexture,
    light: Matrices,
    n: u32,
    sampling: Sampling,
    set: Settings,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<Solution, NodeError> {
    let want = desired(&views);
    let texels = n * n;
    let g = Resident::upload(gpu, views, shadow, light, n, sampling)?;
    let b = g.right_side(&want)?;
    let mut x = gpu.buffer_from(&vec4_data(&vec![[set.start; 3]; texels as usize]))?;
    let mut x_new = g.texel_buffer()?;
    let (mut p, mut p_new, s) = (g.texel_buffer()?, g.texel_buffer()?, g.texel_buffer()?);
    let (mut r, mut r_new, q) = (g.rows_buffer()?, g.rows_buffer()?, g.rows_buffer()?);
    // r = b − T x.
    let residual_into = |x: &GpuBuffer, out: &GpuBuffer| -> Result<(), GpuError> {
        g.forward(x, &q)?;
        g.combine(&b, -1.0, &q, false, out)
    };
    residual_into(&x, &r)?;
    let mut residuals = vec![g.reduce(&[(Reduce::Square, &r, &r_new)])?[0].sqrt()];
    let read_x = |x: &GpuBuffer| g.read_vec3(x, texels);
    if g.rows == 0 || set.iterations == 0 {
        return Ok(Solution {
            x: read_x(&x)?,
            residuals,
        });
    }
    let mass = g.reduce_channels(&[(Reduce::AbsSum, &r, &q)])?[0];
    g.adjoint(&r, mass, &x, set.non_negative, &s)?;
    let gamma0 = g.reduce(&[(Reduce::Square, &s, &p)])?[0];
    g.combine(&s, 0.0, &x, false, &p)?;
    let s0 = gamma0.sqrt();
    let mut gamma = gamma0;
    for it in 0..set.iterations {
        if gamma.sqrt() <= set.tolerance * s0 || gamma == 0.0 {
            break;
        }
        let mut sp = g.reduce(&[(Reduce::Dot, &s, &p)])?[0];
        if sp <= 0.0 {
            g.combine(&s, 0.0, &x, false, &p)?;
            sp = gamma;
        }
        g.forward(&p, &q)?;
        let qq = g.reduce(&[(Reduce::Square, &q, &r)])?[0];
        if qq <= 0.0 {
            break;
        }
        let alpha = sp / qq;
        let a = alpha as f32;
        g.combine(&x, a, &p, false, &x_new)?;
        let leaves = set.non_negative && g.reduce(&[(Reduce::Min, &x_new, &x)])?[0] < 0.0;
        let hit = if leaves {
            // Project; keep it if the residual falls, else the longest feasible step.
            g.combine(&x, a, &p, true, &x_new)?;
            residual_into(&x_new, &r_new)?;
            let rp = g.reduce(&[(Reduce::Square, &r_new, &r)])?[0];
            if rp.sqrt() < residuals[residuals.len() - 1] {
                std::mem::swap(&mut x, &mut x_new);
                std::mem::swap(&mut r, &mut r_new);
            } else {
                let limit = alpha.min(g.reduce(&[(Reduce::StepLimit, &x, &p)])?[0].max(0.0));
                g.combine(&x, limit as f32, &p, true, &x_new)?;
                std::mem::swap(&mut x, &mut x_new);
                residual_into(&x, &r)?;
            }
            true
        } else {
            std::mem::swap(&mut x, &mut x_new);
            g.combine(&r, -a, &q, false, &r_new)?;
            std::mem::swap(&mut r, &mut r_new);
            false
        };
        let (res, mass) = g.residual_norms(&r, &q)?;
        residuals.push(res);
        progress(it + 1, res);
        g.adjoint(&r, mass, &x, set.non_negative, &s)?;
        let new_gamma = g.reduce(&[(Reduce::Square, &s, &p)])?[0];
        if hit {
            g.combine(&s, 0.0, &x, false, &p)?;
        } else {
            let beta = (new_gamma / gamma) as f32;
            g.combine(&s, beta, &p, false, &p_new)?;
            std::mem::swap(&mut p, &mut p_new);
        }
        if set.non_negative {
            g.hold_frozen(&x, &s, &p)?;
        }
        gamma = new_gamma;
    }
    Ok(Solution {
        x: read_x(&x)?,
        residuals,
    })
}
