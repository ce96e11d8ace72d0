//! Diffusion layers: constraints rasterised onto the TF grid and diffused by the multigrid
//! solver of [`crate::algorithms::multigrid`] (CPU reference) or its GPU passes.

use super::{Bind, Constraint, GpuError, GpuTexture, Raster, TexFormat, SHADER};
use crate::algorithms::multigrid::{
    levels, pin, vcycle, Grid, Level, Rgba, COARSE_SWEEPS, OMEGA, SWEEPS,
};
use tyndall_engine::gpu::Recorder;

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

tyndall_engine::uniforms! {
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

/// A level's textures on the GPU.
pub(super) struct GpuLevel {
    level: Level,
    mask: GpuTexture,
}

pub(super) fn mg_pass(
    gpu: &Recorder,
    entry: &str,
    size: (u32, u32),
    binds: &[(&str, Bind)],
) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(size.0, size.1, TexFormat::Rgba32F)?;
    let mut all: Vec<(&str, Bind)> = binds.to_vec();
    all.push(("out_tex", Bind::Storage(&out)));
    gpu.dispatch(SHADER, entry, &all, size.0, size.1)?;
    Ok(out)
}

pub(super) struct Multigrid<'a> {
    gpu: &'a Recorder<'a>,
    levels: Vec<GpuLevel>,
    values: GpuTexture,
}

pub(super) fn mg_params(i: usize) -> MultigridParams {
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
                ("a_tex", Bind::Texture(u)),
                ("b_tex", Bind::Texture(f)),
                ("mask_tex", Bind::Texture(&l.mask)),
                ("values_tex", Bind::Texture(&self.values)),
                ("M", Bind::Uniform(bytemuck::bytes_of(&p))),
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
                ("a_tex", Bind::Texture(&u)),
                ("b_tex", Bind::Texture(f)),
                ("mask_tex", Bind::Texture(&l.mask)),
                ("M", Bind::Uniform(bytemuck::bytes_of(&p))),
            ],
        )?;
        let fc = mg_pass(
            gpu,
            "mg_restrict",
            (c.level.w, c.level.h),
            &[("a_tex", Bind::Texture(&r))],
        )?;
        let zero = gpu.zeroed(c.level.w, c.level.h, TexFormat::Rgba32F)?;
        let e = self.vcycle(i + 1, zero, &fc)?;
        let u = mg_pass(
            gpu,
            "mg_prolong",
            (l.level.w, l.level.h),
            &[
                ("a_tex", Bind::Texture(&u)),
                ("b_tex", Bind::Texture(&e)),
                ("mask_tex", Bind::Texture(&l.mask)),
            ],
        )?;
        self.sweeps(i, u, f, SWEEPS)
    }
}

/// Solve a diffusion layer on the GPU (the same V-cycles as [`diffuse_reference`]).
pub fn diffuse_gpu(
    gpu: &Recorder,
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
