//! The `Sky` node (seed 002 eq. 8–15): the closed form against a direct numerical integration
//! of the single-scattering integral, GPU against the CPU reference, the limits where eq. 15
//! divides by zero, the extremes, and the reddening of a low sun.

use crate::common;
use glam::Vec3;
use tyndall::eval::PortValue;
use tyndall::nodes::sky::{integrate_inscatter, reference_pixel, SkyParams};

/// Sky parameters for an eye at height `h` (m) and a sun at `elevation` degrees (azimuth 0).
fn params(h: f32, elevation: f32, aerosol: f32) -> SkyParams {
    let e = elevation.to_radians();
    SkyParams {
        inv_view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
        eye: [0.0, h, 0.0],
        far: 1e9,
        to_sun: [0.0, e.sin(), e.cos()],
        gamma: 1.0 / 8000.0,
        sun: [20.0, 20.0, 20.0],
        altitude: 0.0,
        beta_air: [5.8e-6, 1.35e-5, 3.31e-5],
        aerosol,
        distance_scale: 1.0,
        aerosol_g: 0.7,
        phase_width: 0,
        sun_disk: 1,
    }
}

/// A direction at `elevation` degrees, azimuth `azimuth` degrees.
fn dir(elevation: f32, azimuth: f32) -> Vec3 {
    let (e, a) = (elevation.to_radians(), azimuth.to_radians());
    Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
}

#[test]
fn closed_form_equals_the_integral_it_solves() {
    for aerosol in [0.0, 4e-5] {
        for (h, sun, view, k) in [
            (10.0, 30.0, dir(20.0, 90.0), 30_000.0),
            (10.0, 30.0, dir(0.0, 45.0), 50_000.0), // horizontal: d_y = 0
            (500.0, 15.0, dir(-5.0, 10.0), 5_000.0), // looking down at a surface
            (10.0, 40.0, dir(40.0, 0.0), 20_000.0), // straight at the sun: d_y = l_y
            (10.0, 60.0, dir(90.0, 0.0), 80_000.0), // zenith
        ] {
            let u = params(h, sun, aerosol);
            let (ins, _, _) = reference_pixel(&u, None, view, k as f32);
            for (ch, got) in ins.iter().enumerate() {
                let want = integrate_inscatter(&u, ch, view, k, 200_000);
                // 1e-5 relative: the midpoint rule's O(Δt²) error at 200 000 steps.
                assert!(
                    (got / want - 1.0).abs() <= 1e-5,
                    "h {h}, sun {sun}°, view {view}, aerosol {aerosol}, ch {ch}: closed form {got} vs integral {want}"
                );
            }
        }
    }
}

#[test]
fn limits_and_extremes_stay_finite() {
    for sun in [89.9, 45.0, 0.0, -10.0] {
        for view in [
            dir(90.0, 0.0),
            dir(0.0, 0.0),
            dir(-90.0, 0.0),
            dir(sun, 0.0),
            dir(sun + 1e-4, 0.0),
        ] {
            for (h, k) in [(0.0, 1e3), (2000.0, 1e9), (-100.0, 1e5), (0.0, 0.0)] {
                let u = params(h, sun, 1e-4);
                let (ins, t, sky) = reference_pixel(&u, None, view, k as f32);
                let all = ins.iter().chain(&t).chain(&sky);
                assert!(
                    all.clone().all(|v| v.is_finite() && *v >= 0.0),
                    "sun {sun}, view {view}, h {h}, K {k}: {ins:?} {t:?} {sky:?}"
                );
                if k < 1e9 {
                    assert!(t.iter().all(|v| (0.0..=1.0).contains(v)), "T {t:?}");
                    // Positive wherever the ray stays above 1 km below sea level (deeper, the
                    // exponential atmosphere's density makes e^{−τ} underflow, correctly).
                    if h as f64 + view.y as f64 * k >= -1000.0 {
                        assert!(t.iter().all(|v| *v > 0.0), "T {t:?}");
                    }
                }
                if sun <= 0.0 {
                    assert!(
                        ins.iter().all(|v| *v == 0.0) || k >= 1e9,
                        "a set sun lights nothing"
                    );
                }
            }
        }
    }
}

#[test]
fn the_sky_reddens_as_the_sun_lowers() {
    let mut last = 0.0;
    for sun in [60.0, 30.0, 10.0, 3.0, 1.0] {
        // The sky 10° above the horizon, 90° from the sun's azimuth (no disk, no surface).
        let u = params(10.0, sun, 0.0);
        let (_, _, sky) = reference_pixel(&u, None, dir(10.0, 90.0), 1e9);
        let ratio = sky[0] / sky[2];
        assert!(ratio > last, "sun {sun}°: red/blue {ratio} after {last}");
        last = ratio;
    }
    assert!(last > 1.0, "a low sun's sky is redder than blue: {last}");
}

#[test]
fn gpu_equals_cpu_and_composite_applies_it() {
    let Some(gpu) = common::gpu() else { return };
    let text = r#"(version: 2, nodes: {
        "scene": (kind: "Scene", params: {"name": "fence", "light": "custom", "sun_elevation": 12.0}),
        "shadow": (kind: "ShadowMap", params: {"resolution": 256}),
        "gbuffer": (kind: "GBuffer"),
        "sky": (kind: "Sky", params: {"distance_scale": 400.0, "aerosol": 2e-5}),
        "comp": (kind: "Composite"),
    }, edges: [("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"),
        ("gbuffer.depth", "sky.depth"), ("scene.scene", "sky.scene"),
        ("gbuffer.albedo", "comp.albedo"), ("gbuffer.normal", "comp.normal"),
        ("gbuffer.depth", "comp.depth"), ("shadow.map", "comp.shadow"),
        ("sky.transmittance", "comp.aerial_transmittance"), ("sky.inscatter", "comp.aerial_inscatter")])"#;
    let (w, h) = (48, 27);
    let out = common::eval_ron(
        &gpu,
        text,
        &[
            ("gbuffer", "depth"),
            ("scene", "scene"),
            ("sky", "inscatter"),
            ("sky", "transmittance"),
            ("sky", "sky"),
            ("comp", "image"),
        ],
        (w, h),
    );
    let get = |n: &str, p: &str| out.get(n, p);
    let dl = |n: &str, p: &str| out.read(n, p);
    let PortValue::Depth(_, cam) = get("gbuffer", "depth") else {
        panic!("depth")
    };
    let scene = get("scene", "scene")
        .payload::<tyndall::scene::GpuScene>()
        .expect("scene");
    let sun = &scene.scene.find_sun("").expect("sun");
    let u = SkyParams {
        inv_view_proj: cam.view_proj().inverse().to_cols_array_2d(),
        eye: cam.eye().to_array(),
        far: cam.far,
        to_sun: sun.to_sun().to_array(),
        gamma: 1.0 / 8000.0,
        sun: sun.radiance(),
        altitude: 0.0,
        beta_air: [5.8e-6, 1.35e-5, 3.31e-5],
        aerosol: 2e-5,
        distance_scale: 400.0,
        aerosol_g: 0.76,
        phase_width: 0,
        sun_disk: 1,
    };
    let (depth, ins, tr, sky) = (
        dl("gbuffer", "depth"),
        dl("sky", "inscatter"),
        dl("sky", "transmittance"),
        dl("sky", "sky"),
    );
    let (mut background, mut surfaces) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let d = depth.pixel(x, y)[0];
            let (wi, wt, ws) = reference_pixel(&u, None, cam.pixel_ray(x, y, w, h), d);
            if d >= cam.far * 0.999 {
                background += 1;
            } else {
                surfaces += 1;
            }
            for c in 0..3 {
                for (what, got, want) in [
                    ("inscatter", ins.pixel(x, y)[c], wi[c]),
                    ("transmittance", tr.pixel(x, y)[c], wt[c]),
                    ("sky", sky.pixel(x, y)[c], ws[c]),
                ] {
                    // 1e-3 relative: f32 exponentials of optical depths up to ~10 on the GPU
                    // against f64 (and the GPU's own acos-free but f32 view ray).
                    assert!(
                        (got as f64 - want).abs() <= 1e-3 * want.abs() + 1e-6,
                        "{what} at ({x},{y}) ch {c}: {got} vs {want}"
                    );
                }
            }
        }
    }
    assert!(
        background > 0 && surfaces > 0,
        "{background} sky, {surfaces} surface pixels"
    );
    // Composite: on the background the output is the sky itself.
    let comp = dl("comp", "image");
    for y in 0..h {
        for x in 0..w {
            if depth.pixel(x, y)[0] >= cam.far * 0.999 {
                for c in 0..3 {
                    let (got, want) = (comp.pixel(x, y)[c], sky.pixel(x, y)[c]);
                    assert!((got - want).abs() <= 1e-6 * want.abs().max(1.0));
                }
            }
        }
    }
}

/// The node itself at the extremes: the sun on and below the horizon, straight overhead, no
/// air, a thick aerosol and a huge distance scale — every output finite and non-negative.
#[test]
fn node_extremes_stay_finite() {
    let Some(gpu) = common::gpu() else { return };
    for (elev, aerosol, scale, beta) in [
        (0.0, 0.0, 1.0, 1.35e-5),
        (-5.0, 1e-3, 1e6, 1.35e-5),
        (90.0, 1.0, 1e-3, 0.0),
        (0.01, 0.0, 1e6, 1.0),
    ] {
        let text = format!(
            r#"(version: 2, nodes: {{
            "scene": (kind: "Scene", params: {{"name": "fence"}}),
            "gbuffer": (kind: "GBuffer"),
            "sky": (kind: "Sky", params: {{"sun_elevation": {elev}, "aerosol": {aerosol}, "distance_scale": {scale}, "beta_sea_level": [{beta}, {beta}, {beta}]}}),
        }}, edges: [("scene.scene", "gbuffer.scene"), ("gbuffer.depth", "sky.depth")])"#
        );
        let ports = ["inscatter", "transmittance", "sky"];
        let out = common::eval_ron(&gpu, &text, &ports.map(|p| ("sky", p)), (24, 14));
        for p in ports {
            let img = out.read("sky", p);
            assert!(
                img.data.iter().all(|v| v.is_finite() && *v >= 0.0),
                "sun {elev}°, aerosol {aerosol}, scale {scale}, β {beta}: {p}"
            );
        }
    }
}
