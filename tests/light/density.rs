//! A heterogeneous medium (issue #61, item 2): `SingleScattering` with a `density` Volume.
//! Checked against an independent case — a constant density is the homogeneous bounded medium
//! with light extinction, whose integral the existing path evaluates exactly piece by piece —
//! and against the CPU reference, which marches towards the light from every sample instead of
//! reading a transmittance volume: the sun and a spot, an occluder's shadow, self-shadowing.

use crate::common;
use std::sync::Arc;

use glam::Vec3;
use tyndall::eval::{Matrices, PortValue, SHADOW_CLEAR};
use tyndall::graph::ParamValue;
use tyndall::io::Raster;
use tyndall::nodes::single_scattering::{
    density_reference_pixel, Density, Params as ScatteringParams, ScatterParams,
};
use tyndall::scene::{fit_light, Camera};

const BOX: [[f32; 3]; 2] = [[-2.0, 0.0, -2.0], [2.0, 3.0, 2.0]];
const SIZE: (u32, u32) = (40, 30);

fn camera() -> Matrices {
    let cam = Camera {
        position: Vec3::new(0.5, 1.6, 7.0),
        target: Vec3::new(0.0, 1.3, 0.0),
        fov_y: 45.0,
        near: 0.1,
        far: 100.0,
    };
    Matrices::of_camera(&cam, SIZE.0, SIZE.1)
}

/// The sun, its map fitted to a 12 m box around the medium.
fn sun() -> Matrices {
    let (view, proj) = fit_light(
        Vec3::new(0.4, 1.0, 0.3),
        (Vec3::new(-6.0, -1.0, -6.0), Vec3::new(6.0, 5.0, 6.0)),
    );
    Matrices {
        view: view.to_cols_array_2d(),
        proj: proj.to_cols_array_2d(),
        far: 1.0,
        radiance: [2.0, 1.5, 1.0],
        local: None,
    }
}

/// A spot above the box looking down, its perspective map (as `ShadowMap` builds it).
fn spot() -> Matrices {
    let (position, direction) = (Vec3::new(0.5, 6.0, 0.5), Vec3::new(-0.05, -1.0, -0.05));
    let light = tyndall::scene::Light {
        name: "spot".into(),
        kind: tyndall::scene::LightKind::Spot {
            position,
            direction: direction.normalize(),
            inner: 0.35,
            outer: 0.5,
        },
        colour: [1.0; 3],
        intensity: 300.0,
        range: None,
    };
    let l = light
        .local((Vec3::new(-6.0, -1.0, -6.0), Vec3::new(6.0, 7.0, 6.0)))
        .expect("a spot");
    let view = tyndall::scene::spot_view(position, direction);
    let proj = tyndall::scene::local_proj(0.5, l.near, l.far);
    Matrices {
        view: view.to_cols_array_2d(),
        proj: proj.to_cols_array_2d(),
        far: 1.0,
        radiance: [300.0; 3],
        local: Some(l),
    }
}

/// A shadow map: clear, or with an occluder block covering part of the map at depth `d`.
fn shadow(occluder: Option<f32>) -> Raster {
    let mut r = Raster::new(32, 32, 1, SHADOW_CLEAR);
    if let Some(d) = occluder {
        for y in 10..16 {
            for x in 12..20 {
                r.data[y * 32 + x] = d;
            }
        }
    }
    r
}

/// A density: constant `c`, or a soft blob (a Gaussian around a point off the centre) plus a
/// thin haze, 24 × 18 × 24 texels over the box.
fn density(constant: Option<f32>) -> Density {
    blob(|g| constant.unwrap_or(0.05 + 2.5 * g))
}

/// The blob alone, cut to 0 where it falls below 0.05 (1.5 m from its centre): most of the
/// box's 4³-texel bricks are empty, so both marches skip space.
fn sparse_density() -> Density {
    blob(|g| (2.5 * g - 0.05).max(0.0))
}

/// 24 × 18 × 24 texels over the box, each `f` of the Gaussian e^{−d²/0.6} around a point off
/// the centre.
fn blob(f: impl Fn(f32) -> f32) -> Density {
    let size = [24u32, 18, 24];
    let mut data = Vec::new();
    for k in 0..size[2] {
        for j in 0..size[1] {
            for i in 0..size[0] {
                let p = [i, j, k].map(|v| v as f32 + 0.5);
                let x = Vec3::new(
                    BOX[0][0] + p[0] / 24.0 * 4.0,
                    BOX[0][1] + p[1] / 18.0 * 3.0,
                    BOX[0][2] + p[2] / 24.0 * 4.0,
                );
                let d = (x - Vec3::new(0.3, 1.5, -0.2)).length_squared();
                data.push(f((-d / 0.6).exp()));
            }
        }
    }
    Density {
        size,
        data,
        bounds: BOX,
    }
}

/// Camera depth: a wall at 9 m behind everything, except a floor-like band at the bottom rows.
fn depth() -> Raster {
    let mut r = Raster::new(SIZE.0, SIZE.1, 1, 9.0);
    for y in 24..SIZE.1 {
        for x in 0..SIZE.0 {
            r.data[(y * SIZE.0 + x) as usize] = 6.5;
        }
    }
    r
}

fn p(name: &str, v: f64) -> (&str, ParamValue) {
    (name, ParamValue::Float(v))
}

/// Run SingleScattering on injected inputs; returns (visibility, inscatter, transmittance).
fn run(
    gpu: &Arc<tyndall::gpu::Gpu>,
    light: Matrices,
    map: &Raster,
    dens: Option<&Density>,
    params: &[(&str, ParamValue)],
) -> (Raster, Raster, Raster) {
    let up = |r: &Raster| Arc::new(gpu.upload(r.width, r.height, 1, &r.data).expect("upload"));
    let mut inputs = vec![
        ("shadow", PortValue::ShadowMap(up(map), light)),
        ("depth", PortValue::Depth(up(&depth()), camera())),
    ];
    if let Some(d) = dens {
        let v = gpu.upload_volume(d.size, &d.data).expect("volume");
        inputs.push(("density", PortValue::Volume(Arc::new(v), d.bounds)));
    }
    let out = common::run_node(
        gpu,
        "SingleScattering",
        params,
        inputs,
        &["visibility", "inscatter", "transmittance"],
        SIZE,
    )
    .expect("evaluate");
    (
        out["visibility"].clone(),
        out["inscatter"].clone(),
        out["transmittance"].clone(),
    )
}

fn rgb_rel(a: &Raster, b: &Raster) -> f32 {
    let peak = b.data.iter().cloned().fold(0.0f32, f32::max).max(1e-12);
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
        / peak
}

/// A constant density c is the homogeneous medium of σt·c in its box with light extinction:
/// the existing path integrates that exactly (e^{−σt ℓ} piecewise exponential along the ray),
/// the density path by midpoints and a trilinear transmittance volume.
#[test]
fn a_constant_density_is_the_homogeneous_box_with_light_extinction() {
    let gpu = require_gpu!();
    let c = 0.75;
    let sigma_t = 0.4;
    let dens = density(Some(c));
    let knobs = [
        ("steps", ParamValue::Int(512)),
        ("transmittance_resolution", ParamValue::Int(128)),
        ("light_steps", ParamValue::Int(64)),
        p("sigma_t", sigma_t),
        p("g", 0.3),
    ];
    let (v1, i1, t1) = run(&gpu, sun(), &shadow(None), Some(&dens), &knobs);
    let homogeneous = [
        ("steps", ParamValue::Int(512)),
        p("sigma_t", sigma_t * c as f64),
        p("g", 0.3),
        ("bounds", ParamValue::Enum("box".into())),
        ("box_min", ParamValue::Vec3(BOX[0].map(f64::from))),
        ("box_max", ParamValue::Vec3(BOX[1].map(f64::from))),
        ("light_extinction", ParamValue::Enum("on".into())),
    ];
    let (_, i0, t0) = run(&gpu, sun(), &shadow(None), None, &homogeneous);
    let (ei, et) = (rgb_rel(&i1, &i0), rgb_rel(&t1, &t0));
    eprintln!(
        "constant density vs homogeneous: inscatter {ei:.2e} of the peak, transmittance {et:.2e}"
    );
    // Transmittance: both exact for a constant σt (the density path's intervals multiply to
    // e^{−σt c L}), up to f32 rounding of 512 factors (~6e-8 each): measured 5.4e-5.
    assert!(et <= 2e-4, "transmittance {et}");
    // In-scatter: the light's transmittance is read trilinearly from 128 texels over 4 m (its
    // curvature, (σ h)²/8 ≈ 7e-5 of a sample's light) and held over the outer half texel (a
    // thin layer at the faces the sun enters); measured 1.3e-5 of the peak.
    assert!(ei <= 1e-3, "inscatter {ei}");
    // V̄ is the mean light reaching the samples: below 1 (the medium dims the sun), above 0.
    let vmin = v1.data.iter().cloned().fold(1.0f32, f32::min);
    assert!(vmin > 0.0 && v1.data.iter().all(|v| *v <= 1.0));
    assert!(
        v1.data.iter().any(|v| *v < 0.9),
        "the density dims the light"
    );
}

/// GPU against the CPU reference, an occluder's shadow: the sun through a blob with haze, a spot
/// through the blob alone in empty space (the GPU skips the empty bricks, the reference marches
/// every sample; V̄ is 1 on the rays that miss it). The reference marches 256 midpoints towards
/// the light from every sample; the GPU reads a transmittance volume of 64 texels (64
/// midpoints per texel).
#[test]
fn the_density_path_matches_the_cpu_reference() {
    let gpu = require_gpu!();
    let steps = 96;
    for (what, light, dens) in [
        ("sun", sun(), density(None)),
        ("spot, sparse", spot(), sparse_density()),
    ] {
        let map = shadow(Some(0.3));
        let knobs = [
            ("steps", ParamValue::Int(steps)),
            ("transmittance_resolution", ParamValue::Int(64)),
            ("light_steps", ParamValue::Int(64)),
            p("sigma_t", 0.6),
        ];
        let (vis, ins, tr) = run(&gpu, light, &map, Some(&dens), &knobs);
        let m = ScatteringParams::with_overrides(&knobs).expect("params");
        let u = ScatterParams::new(&camera(), &light, &m)
            .with_bounds(Some((Vec3::from(BOX[0]), Vec3::from(BOX[1]))), false);
        let d = depth();
        let mut worst = (0.0f32, 0.0f32, 0.0f32);
        let mut missed = 0;
        let peak = ins.data.iter().cloned().fold(0.0f32, f32::max);
        assert!(peak > 0.0, "{what}: the medium is lit");
        for y in 0..SIZE.1 {
            for x in 0..SIZE.0 {
                let s = d.data[(y * SIZE.0 + x) as usize];
                let (v, rgb, t) = density_reference_pixel(&u, &map, &dens, s, (x, y), SIZE, 256);
                let i = (y * SIZE.0 + x) as usize;
                worst.0 = worst.0.max((vis.data[i] - v).abs());
                if v == 1.0 && rgb == [0.0; 3] {
                    // A ray meeting no smoke: V̄ exactly 1, nothing scattered, T exactly 1.
                    missed += 1;
                    assert_eq!((vis.data[i], tr.data[i]), (1.0, 1.0), "{what}: ({x}, {y})");
                }
                for (c, want) in rgb.iter().enumerate() {
                    worst.1 = worst.1.max((ins.data[i * 4 + c] - want).abs() / peak);
                }
                worst.2 = worst.2.max((tr.data[i] - t).abs());
            }
        }
        eprintln!(
            "{what}: |ΔV̄| {:.2e}, in-scatter {:.2e} of the peak, |ΔT| {:.2e}",
            worst.0, worst.1, worst.2
        );
        // Transmittance along the view ray: the same samples in f32 (measured 1.1e-5).
        assert!(worst.2 <= 1e-4, "{what}: transmittance {}", worst.2);
        // The light's transmittance from a 64-texel volume (trilinear between texel centres;
        // the blob's Gaussian spans ~10 texels) against a direct 256-step march: measured
        // 2.8e-5 (sun) and 1.4e-4 (the spot through the sparse blob) of the peak in-scatter,
        // V̄ within 2.3e-3.
        assert!(worst.1 <= 1e-3, "{what}: in-scatter {}", worst.1);
        assert!(worst.0 <= 0.01, "{what}: V̄ {}", worst.0);
        if what.contains("sparse") {
            assert!(missed > 0, "{what}: some rays miss the blob");
        }
    }
}

/// The smoke shadows itself and what lies behind it: the light reaching the blob's far side
/// (away from the sun) is dimmer than on its near side, and the view ray's transmittance drops
/// where it crosses the blob.
#[test]
fn the_smoke_shadows_itself() {
    let dens = density(None);
    let m = ScatteringParams::with_overrides(&[("sigma_t", ParamValue::Float(0.6))]).expect("p");
    let u = ScatterParams::new(&camera(), &sun(), &m);
    let centre = Vec3::new(0.3, 1.5, -0.2);
    let to_sun = u.to_sun();
    let near = tyndall::nodes::single_scattering::light_transmittance(
        &u,
        &dens,
        centre + to_sun * 0.9,
        256,
    );
    let far = tyndall::nodes::single_scattering::light_transmittance(
        &u,
        &dens,
        centre - to_sun * 0.9,
        256,
    );
    assert!(far < 0.5 * near, "far side {far} vs near side {near}");
    assert!(near < 1.0);
}

/// Composite shadows surfaces by the smoke: with SingleScattering's `light_transmittance`
/// connected the GPU equals the CPU reference (which reads the same volume from each surface
/// point towards the sun), and the ground under the plume of the forest-smoke preset is darker
/// than without it.
#[test]
fn composite_shadows_surfaces_by_the_smoke() {
    let gpu = require_gpu!();
    let root = env!("CARGO_MANIFEST_DIR");
    let text = format!(
        r#"(version: 2, nodes: {{
            "scene": (kind: "Scene", params: {{"path": "{root}/scenes/forest.glb"}}),
            "gbuffer": (kind: "GBuffer"),
            "shadow": (kind: "ShadowMap", params: {{"resolution": 1024}}),
            "smoke": (kind: "VdbVolume", params: {{"path": "{root}/scenes/smoke/forest_plume_0090.vdb", "up_axis": "z", "voxel_centers": "blender", "translate": (-7.0, 0.0, 9.0), "max_resolution": 32}}),
            "scatter": (kind: "SingleScattering", params: {{"sigma_t": 1.2, "bounds": "density", "steps": 32, "transmittance_resolution": 32, "light_steps": 32}}),
            "lit": (kind: "Composite"),
            "plain": (kind: "Composite"),
        }}, edges: [
            ("scene.scene", "gbuffer.scene"), ("scene.scene", "shadow.scene"),
            ("shadow.map", "scatter.shadow"), ("gbuffer.depth", "scatter.depth"),
            ("smoke.volume", "scatter.density"),
            ("gbuffer.albedo", "lit.albedo"), ("gbuffer.normal", "lit.normal"),
            ("gbuffer.depth", "lit.depth"), ("shadow.map", "lit.shadow"),
            ("scatter.light_transmittance", "lit.light_transmittance"),
            ("gbuffer.albedo", "plain.albedo"), ("gbuffer.normal", "plain.normal"),
            ("gbuffer.depth", "plain.depth"), ("shadow.map", "plain.shadow"),
        ])"#
    );
    let size = (96, 54);
    let o = common::eval_ron(
        &gpu,
        &text,
        &[
            ("gbuffer", "albedo"),
            ("gbuffer", "normal"),
            ("gbuffer", "depth"),
            ("shadow", "map"),
            ("scatter", "light_transmittance"),
            ("lit", "image"),
            ("plain", "image"),
        ],
        size,
    );
    let (PortValue::Depth(_, cam), PortValue::ShadowMap(_, light)) =
        (o.get("gbuffer", "depth"), o.get("shadow", "map"))
    else {
        panic!("depth and shadow map");
    };
    let PortValue::Volume(v, bounds) = o.get("scatter", "light_transmittance") else {
        panic!("a volume");
    };
    let tr = Density {
        size: v.size,
        data: gpu.recorder().read_volume(v, 0).expect("read"),
        bounds: *bounds,
    };
    assert!(
        tr.data.iter().any(|t| *t < 0.5),
        "the smoke blocks light somewhere"
    );
    let (albedo, normal, depth, map) = (
        o.read("gbuffer", "albedo"),
        o.read("gbuffer", "normal"),
        o.read("gbuffer", "depth"),
        o.read("shadow", "map"),
    );
    let want = tyndall::nodes::composite::reference(
        &tyndall::nodes::composite::RefInputs {
            albedo: &albedo,
            normal: &normal,
            depth: (&depth, cam),
            shadow: (&map, light),
            inscatter: None,
            transmittance: None,
            aerial_transmittance: None,
            aerial_inscatter: None,
            light_map: None,
            light_transmittance: Some(&tr),
        },
        [0.04, 0.05, 0.07],
        [0.2, 0.27, 0.38],
        0.002,
        1,
    );
    let (lit, plain) = (o.read("lit", "image"), o.read("plain", "image"));
    let peak = want.data.iter().cloned().fold(0.0f32, f32::max);
    let worst = common::max_abs_diff(&lit, &want) / peak;
    let (mut darker, mut sum_lit, mut sum_plain) = (0, 0.0f32, 0.0f32);
    for (a, b) in lit.data.iter().zip(&plain.data) {
        darker += (*a < 0.95 * *b) as usize;
        sum_lit += a;
        sum_plain += b;
    }
    eprintln!("composite vs reference: {worst:.2e} of the peak; {darker} channel values darker under the smoke, total {sum_lit:.1} vs {sum_plain:.1}");
    // The same volume, shadow map and formula in f32 (measured 3.4e-6 of the peak).
    assert!(worst <= 1e-4, "composite vs reference: {worst}");
    assert!(
        darker > 50,
        "the ground under the plume is in its shadow ({darker})"
    );
}

/// Extremes with a density (the stability matrix runs SingleScattering without one): every
/// method and bounds, σt 0 and 1e4, g ±0.999, one sample, the transmittance volume's smallest and
/// a large side (capped at 128: 512³ floats are 512 MiB on lavapipe), 1 and 1024 light steps, a
/// density of zeros and one of huge values: outputs finite, V̄ and transmittance in [0, 1].
#[test]
fn extremes_with_a_density_stay_finite() {
    let gpu = require_gpu!();
    let blob = density(None);
    let zeros = density(Some(0.0));
    let huge = density(Some(1e6));
    let e = |v: &str| ParamValue::Enum(v.into());
    let cases: Vec<Vec<(&str, ParamValue)>> = vec![
        vec![],
        vec![("method", e("MinMax"))],
        vec![("method", e("Epipolar"))],
        vec![("bounds", e("box"))],
        vec![("bounds", e("density"))],
        vec![p("sigma_t", 0.0)],
        vec![p("sigma_t", 1e4)],
        vec![p("g", 0.999)],
        vec![p("g", -0.999)],
        vec![("steps", ParamValue::Int(1))],
        vec![("transmittance_resolution", ParamValue::Int(2))],
        vec![("transmittance_resolution", ParamValue::Int(128))],
        vec![("light_steps", ParamValue::Int(1))],
        vec![("light_steps", ParamValue::Int(1024))],
        vec![p("jitter", 1.0)],
    ];
    // Every case on the blob with the sun; the defaults on each density with the sun and the
    // spot (the cases' code paths do not depend on the light's kind but for its direction).
    type Run<'a> = (&'a Density, &'a str, Matrices, &'a [(&'a str, ParamValue)]);
    let mut runs: Vec<Run> = cases
        .iter()
        .map(|c| (&blob, "blob", sun(), c.as_slice()))
        .collect();
    for (d, what) in [(&blob, "blob"), (&zeros, "zeros"), (&huge, "1e6")] {
        runs.push((d, what, spot(), &[]));
        runs.push((d, what, sun(), &[]));
    }
    for (d, what, light, c) in runs {
        let mut params = vec![("steps", ParamValue::Int(16))];
        params.extend(c.iter().cloned());
        let (v, ins, t) = run(&gpu, light, &shadow(Some(0.3)), Some(d), &params);
        let ok = ins.data.iter().all(|x| x.is_finite())
            && v.data
                .iter()
                .chain(&t.data)
                .all(|x| (0.0..=1.0).contains(x));
        assert!(ok, "density {what}, {c:?}: not finite or out of [0, 1]");
    }
}
