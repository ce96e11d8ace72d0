//! GPU driving: the min-max pyramid, the Epipolar passes, and the one dispatch of each method.

use super::{
    epipolar_geometry, pyramid_layout, Bind, BuildParams, EpiKnobs, EpiParams, GpuError,
    GpuTexture, LevelsParams, LightMapView, Matrices, Method, NodeError, Params, ScatterParams,
    SoftView, TexFormat, BRUTE_FORCE, EPIPOLAR, IDENTITY, MIN_MAX,
};
use tyndall_engine::gpu::Recorder;

/// Build the min-max pyramid of `map`: returns the level table and the RG32F atlas.
pub fn build_pyramid(
    gpu: &Recorder,
    map: &GpuTexture,
) -> Result<(LevelsParams, GpuTexture), GpuError> {
    let (levels, aw, ah) = pyramid_layout(map.width, map.height);
    let front = gpu.texture(aw, ah, TexFormat::Rg32F)?;
    let back = gpu.texture(aw, ah, TexFormat::Rg32F)?;
    for k in 1..=levels.count as usize {
        let dst = levels.rect[k];
        let src = if k == 1 {
            [0, 0, map.width, map.height]
        } else {
            levels.rect[k - 1]
        };
        let b = BuildParams {
            level: k as u32,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
            src,
            dst,
        };
        let source = if k == 1 { map } else { &front };
        gpu.dispatch(
            MIN_MAX,
            "build_level",
            &[
                ("B", Bind::Uniform(bytemuck::bytes_of(&b))),
                ("build_src", Bind::Texture(source)),
                ("build_dst", Bind::Storage(&back)),
            ],
            dst[2],
            dst[3],
        )?;
        // The next level reads this one: copy it into the texture that is read.
        gpu.copy_region(&back, &front, dst[0], dst[1], dst[2], dst[3])?;
    }
    Ok((levels, front))
}

/// Method `Epipolar` on the GPU: rectify each slice's line of the map and build its min-max
/// tree (`epi_rectify`, `epi_tree` per level), trace the slices' samples (`epi_sample`),
/// interpolate every pixel (`epi_gather`), and trace their own ray for the pixels it listed as
/// having no usable sample (`epi_fallback`).
/// `binds` are the `MinMax` dispatch's.
pub(super) fn dispatch_epipolar(
    gpu: &Recorder,
    u: &ScatterParams,
    knobs: EpiKnobs,
    shadow: &GpuTexture,
    (w, h): (u32, u32),
    binds: &[(&str, Bind)],
) -> Result<(), NodeError> {
    let g = epipolar_geometry(u, (w, h), (shadow.width, shadow.height), knobs.slices);
    let table = gpu.upload(knobs.slices, 3, 4, &EpiParams::slice_texels(&g))?;
    let words = knobs.slices as u64 * 4 * g.tree_n as u64;
    let too_many = || NodeError::Param {
        param: "epi_slices".into(),
        message: format!(
            "{} slices of {} tree entries need {} MiB, over the adapter's storage-buffer limit \
             of {} MiB: use fewer slices or a smaller shadow map",
            knobs.slices,
            2 * g.tree_n,
            (words * 4) >> 20,
            gpu.limits.max_storage_buffer_binding_size >> 20
        ),
    };
    if words * 4 > gpu.limits.max_storage_buffer_binding_size {
        return Err(too_many());
    }
    let tree = gpu.buffer_zeroed(u32::try_from(words).map_err(|_| too_many())?)?;
    let samples = gpu.texture(knobs.samples, knobs.slices, TexFormat::Rgba32F)?;
    let base = EpiParams::new(&g, knobs);
    let constants = [
        ("EXTINCTION", u.light_extinction as f64),
        ("LIGHT_MAP", 0.0),
        ("SOFT", 0.0),
        ("LOCAL", if u.light.kind == 1 { 1.0 } else { 0.0 }),
        ("POINT", 0.0),
    ];
    let pass = |entry: &str, level: u32, extra: Option<(&str, Bind)>, size: (u32, u32)| {
        let e = EpiParams { level, ..base };
        let mut b = binds.to_vec();
        b.push(("E", Bind::Uniform(bytemuck::bytes_of(&e))));
        b.push(("slice_table", Bind::Texture(&table)));
        b.push(("tree", Bind::Buffer(&tree)));
        b.extend(extra);
        gpu.dispatch_with(EPIPOLAR, entry, &b, size, &constants)
    };
    pass("epi_rectify", 0, None, (g.tree_n, knobs.slices))?;

    for level in 1..=base.tree_top {
        pass("epi_tree", level, None, (g.tree_n >> level, knobs.slices))?;
    }
    pass(
        "epi_sample",
        0,
        Some(("out_samples", Bind::Storage(&samples))),
        (knobs.samples, knobs.slices),
    )?;
    let list = gpu.buffer_zeroed(w * h)?;
    let count = gpu.buffer_zeroed(1)?;
    let args = gpu.buffer_zeroed(3)?;
    let e = EpiParams { level: 0, ..base };
    let mut b = binds.to_vec();
    b.extend([
        ("E", Bind::Uniform(bytemuck::bytes_of(&e))),
        ("slice_table", Bind::Texture(&table)),
        ("samples_in", Bind::Texture(&samples)),
        ("fallback", Bind::Buffer(&list)),
        ("fallback_count", Bind::Buffer(&count)),
    ]);
    gpu.dispatch_with(EPIPOLAR, "epi_gather", &b, (w, h), &constants)?;
    // The fall-back pixels (depth discontinuities) trace their own ray, in a dispatch the GPU
    // sizes from the list's length: nothing is read back between the passes.
    b.push(("fallback_args", Bind::Buffer(&args)));
    gpu.dispatch_with(EPIPOLAR, "epi_fallback_args", &b, (1, 1), &constants)?;
    b.pop();
    gpu.dispatch_indirect(EPIPOLAR, "epi_fallback", &b, &args, &constants)?;
    Ok(())
}

/// What the passes read besides the uniforms.
pub(super) struct Inputs<'a> {
    /// The shadow map.
    pub shadow: &'a GpuTexture,
    /// Linear camera depth.
    pub depth: &'a GpuTexture,
    /// The shadow map's light.
    pub light: Matrices,
    /// A tabulated phase function (`None`: Henyey–Greenstein g).
    pub phase: Option<&'a GpuTexture>,
    /// A soft visibility volume and its light (BruteForce only).
    pub soft: Option<(&'a tyndall_engine::gpu::GpuVolume, Matrices)>,
    /// A light map and its matrices (BruteForce only).
    pub light_map: Option<(&'a GpuTexture, Matrices)>,
    /// A density volume and its world box (the density path, whatever the method).
    pub density: Option<(&'a tyndall_engine::gpu::GpuVolume, [[f32; 3]; 2])>,
}

/// The outputs of a run: `[visibility, in-scatter, transmittance]`, and with a density the light
/// transmittance volume and its box.
type Scattered = (
    [GpuTexture; 3],
    Option<(tyndall_engine::gpu::GpuVolume, [[f32; 3]; 2])>,
);

/// The method's passes. Placeholders fill the bindings of unconnected inputs; pipeline constants
/// compile away what is off.
pub(super) fn scatter(
    gpu: &Recorder,
    u: &ScatterParams,
    i: &Inputs,
    p: &Params,
) -> Result<Scattered, NodeError> {
    let (w, h) = (i.depth.width, i.depth.height);
    let vis = gpu.texture(w, h, TexFormat::R32F)?;
    let ins = gpu.texture(w, h, TexFormat::Rgba32F)?;
    let tr = gpu.texture(w, h, TexFormat::R32F)?;
    let no_phase;
    let phase = match i.phase {
        Some(t) => t,
        None => {
            no_phase = gpu.upload(1, 1, 4, &[0.0; 4])?;
            &no_phase
        }
    };
    let no_soft;
    let soft_volume = match i.soft {
        Some((v, _)) => v,
        None => {
            no_soft = gpu.volume([1, 1, 1])?;
            &no_soft
        }
    };
    let soft_light = i.soft.map_or(i.light, |(_, m)| m);
    let (near, far) = soft_light.local.map_or((0.0, 1.0), |l| (l.near, l.far));
    let sv = SoftView {
        view_proj: soft_light.view_proj().to_cols_array_2d(),
        position: soft_light.local.map_or([0.0; 3], |l| l.position),
        persp: soft_light.local.map_or(0, |l| if l.point { 2 } else { 1 }),
        near,
        far,
        _pad0: 0,
        _pad1: 0,
    };
    let mut binds = vec![
        ("P", Bind::Uniform(bytemuck::bytes_of(u))),
        ("shadow", Bind::Texture(i.shadow)),
        ("depth", Bind::Texture(i.depth)),
        ("out_vis", Bind::Storage(&vis)),
        ("out_inscatter", Bind::Storage(&ins)),
        ("out_transmittance", Bind::Storage(&tr)),
        ("phase_table", Bind::Texture(phase)),
        ("soft_volume", Bind::Volume(soft_volume)),
        ("SV", Bind::Uniform(bytemuck::bytes_of(&sv))),
    ];
    // Pipeline constants: code for what is off is compiled away.
    let on = |b: bool| if b { 1.0 } else { 0.0 };
    let constants = [
        ("EXTINCTION", on(u.light_extinction != 0)),
        ("LIGHT_MAP", on(i.light_map.is_some())),
        ("SOFT", on(i.soft.is_some())),
        ("LOCAL", on(u.light.kind != 0)),
        ("POINT", on(u.light.kind == 2)),
    ];
    // A spot or point light: MinMax walks its perspective map's pyramid, face by face for a
    // point light's atlas (min_max.wgsl, `min_max_local`), for a point light's Epipolar too
    // (the atlas has no single projection to rectify); Epipolar runs for a spot as for the sun
    // (its slices' planes hold the spot); with a light map BruteForce marches whatever the
    // method (the node's docs).
    if let Some(density) = i.density {
        let light_tr = super::density::dispatch(gpu, &binds, density, p, (w, h), &constants)?;
        return Ok(([vis, ins, tr], Some(light_tr)));
    }
    let lamp_light_map = u.light.kind != 0 && i.light_map.is_some();
    let point_min_max = u.light.kind == 2 && p.method == Method::Epipolar;
    if p.method == Method::BruteForce || lamp_light_map {
        let no_map;
        let (map, lm) = match i.light_map {
            Some((t, m)) => (t, LightMapView::new(m.view_proj().to_cols_array_2d(), 1)),
            None => {
                no_map = gpu.upload(1, 1, 4, &[1.0; 4])?;
                (&no_map, LightMapView::new(IDENTITY, 0))
            }
        };
        binds.push(("light_map", Bind::Texture(map)));
        binds.push(("LM", Bind::Uniform(bytemuck::bytes_of(&lm))));
        gpu.dispatch_with(BRUTE_FORCE, "brute_force", &binds, (w, h), &constants)?;
        return Ok(([vis, ins, tr], None));
    }
    // MinMax traverses the pyramid; Epipolar's fall-back rays do too.
    let (levels, atlas) = build_pyramid(gpu, i.shadow)?;
    binds.push(("atlas", Bind::Texture(&atlas)));
    binds.push(("L", Bind::Uniform(bytemuck::bytes_of(&levels))));
    if p.method == Method::MinMax || point_min_max {
        gpu.dispatch_with(MIN_MAX, "min_max", &binds, (w, h), &constants)?;
    } else {
        let knobs = EpiKnobs {
            slices: p.epi_slices as u32,
            samples: p.epi_samples as u32,
            threshold: p.epi_threshold,
            tree_level: p.tree_level as u32,
        };
        dispatch_epipolar(gpu, u, knobs, i.shadow, (w, h), &binds)?;
    }
    Ok(([vis, ins, tr], None))
}
