//! `method = ray_cast` of GBuffer and ShadowMap: against its CPU reference (the same rays and
//! triangles, `algorithms::ray_cast::reference_*`), and against the rasteriser — the
//! independent oracle, the driver's graphics pipeline — on real scenes with every light kind.

use glam::{Mat4, Vec3};
use tyndall::eval::PortValue;
use tyndall::io::Raster;
use tyndall::nodes::algorithms::ray_cast::{self, GBufferTexel, RayCastParams};
use tyndall::scene::GpuScene;

use crate::common;

/// The scenes: the cathedral (glTF, the sun), the window and the tree under the sun, the tree
/// under a spot and a point light.
fn scenes() -> Vec<(&'static str, String)> {
    let root = env!("CARGO_MANIFEST_DIR");
    let lamp = r#""name": "tree", "light": "custom", "light_x": 2.0, "light_y": 6.5, "light_z": 1.5, "light_target_y": 1.0, "cone_outer": 30.0,"#;
    vec![
        (
            "cathedral",
            format!(r#""path": "{root}/scenes/cathedral.glb","#),
        ),
        ("window", r#""name": "window","#.to_string()),
        ("tree", r#""name": "tree","#.to_string()),
        ("spot", format!(r#"{lamp} "light_type": "spot","#)),
        ("point", format!(r#"{lamp} "light_type": "point","#)),
    ]
}

const PORTS: [(&str, &str); 4] = [
    ("gbuffer", "depth"),
    ("gbuffer", "normal"),
    ("gbuffer", "albedo"),
    ("shadow", "map"),
];

/// Scene → ShadowMap (256²) and GBuffer (160×90), both with `method`.
fn evaluate(gpu: &std::sync::Arc<tyndall::gpu::Gpu>, scene: &str, method: &str) -> common::Outputs {
    let text = format!(
        r#"(version: 3, nodes: {{
        "scene": (kind: "Scene", params: {{{scene}}}),
        "shadow": (kind: "ShadowMap", params: {{"resolution": 256, "method": "{method}"}}),
        "gbuffer": (kind: "GBuffer", params: {{"method": "{method}"}}),
    }}, edges: [("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene")])"#
    );
    let mut ports = PORTS.to_vec();
    ports.push(("scene", "scene"));
    common::eval_ron(gpu, &text, &ports, (160, 90))
}

/// Pixels of `a` and `b` (same shape) whose channels differ by more than `rel` relative to
/// the larger of 1 and the first's magnitude.
fn pixels_apart(a: &Raster, b: &Raster, rel: f32) -> usize {
    assert_eq!(
        (a.width, a.height, a.channels),
        (b.width, b.height, b.channels)
    );
    let c = a.channels as usize;
    a.data
        .chunks(c)
        .zip(b.data.chunks(c))
        .filter(|(p, q)| {
            p.iter()
                .zip(*q)
                .any(|(x, y)| (x - y).abs() > rel * x.abs().max(1.0))
        })
        .count()
}

fn matrices(v: &PortValue) -> tyndall::eval::Matrices {
    match v {
        PortValue::Depth(_, m) | PortValue::ShadowMap(_, m) => *m,
        other => panic!("not a depth or a map: {other:?}"),
    }
}

/// Ray casting equals its CPU reference: the same BVH traversal and Möller–Trumbore test in
/// f32 on the same rays. The GPU may fuse multiply-adds and round the unprojection differently,
/// so a texel centred within rounding of an edge may take the neighbouring triangle — allowed
/// for 0.2 % of texels; every other texel within 1e-4 relative (depths of 5–60 m; colours of
/// magnitude ≤ 1), normals within 1e-3 (the driver's `normalize`, below).
#[test]
fn ray_cast_matches_its_cpu_reference() {
    let gpu = require_gpu!();
    for (name, scene) in scenes() {
        let out = evaluate(&gpu, &scene, "ray_cast");
        let gpu_scene = match out.get("scene", "scene") {
            PortValue::Other(_, s) => s.clone().downcast::<GpuScene>().expect("a scene"),
            other => panic!("{other:?}"),
        };
        let triangles = ray_cast::triangles(&gpu_scene.scene, &gpu_scene.ranges);
        // The G-buffer, from the camera matrices the node reports.
        let cam = matrices(out.get("gbuffer", "depth"));
        let view_proj = Mat4::from_cols_array_2d(&cam.proj) * Mat4::from_cols_array_2d(&cam.view);
        let p = RayCastParams {
            eye: Mat4::from_cols_array_2d(&cam.view)
                .inverse()
                .transform_point3(Vec3::ZERO)
                .to_array(),
            far: cam.far,
            ..ray_cast::params(view_proj, 160, 90)
        };
        let want = ray_cast::reference_g_buffer(&triangles, &p);
        let as_raster = |c: u32, f: &dyn Fn(&GBufferTexel) -> Vec<f32>| Raster {
            width: 160,
            height: 90,
            channels: c,
            data: want.iter().flat_map(f).collect(),
        };
        let checks = [
            ("depth", as_raster(1, &|t| vec![t.depth])),
            ("normal", as_raster(4, &|t| t.normal.to_vec())),
            ("albedo", as_raster(4, &|t| t.albedo.to_vec())),
        ];
        for (port, want) in checks {
            let got = out.read("gbuffer", port);
            // lavapipe's `normalize` is an approximate inverse square root: up to ~4e-4
            // relative measured on the tree's normals (0.6 % of texels beyond 1e-4).
            let rel = if port == "normal" { 1e-3 } else { 1e-4 };
            let apart = pixels_apart(&want, &got, rel);
            assert!(
                apart * 500 <= 160 * 90,
                "{name} gbuffer.{port}: {apart} texels apart"
            );
        }
        // The sun's and the spot's maps (a point light's atlas is six such views).
        let light = matrices(out.get("shadow", "map"));
        if name == "point" {
            continue;
        }
        let p = RayCastParams {
            linear_depth: u32::from(light.local.is_some()),
            far_ndc: light
                .local
                .map_or(1.0, |l| ray_cast::linear_far(l.near, l.far)),
            ..ray_cast::params(
                Mat4::from_cols_array_2d(&light.proj) * Mat4::from_cols_array_2d(&light.view),
                256,
                256,
            )
        };
        let want = Raster {
            width: 256,
            height: 256,
            channels: 1,
            data: ray_cast::reference_shadow(&triangles, &p),
        };
        let got = out.read("shadow", "map");
        let apart = pixels_apart(&want, &got, 1e-4);
        assert!(
            apart * 500 <= 256 * 256,
            "{name} shadow.map: {apart} texels apart"
        );
        assert!(
            got.data.iter().any(|d| *d < 1.0),
            "{name}: the map sees no geometry"
        );
    }
}

/// Ray casting draws what the rasteriser draws. The rasteriser snaps vertices to its subpixel
/// grid (llvmpipe: 1/256 pixel) and interpolates attributes in its own precision, so grazing
/// surfaces' depths and interpolated normals move by up to ~1e-3 relative: ≥ 99 % of pixels
/// agree within 1e-3, and ≥ 99.8 % within 1e-2 — what is left are texels centred on a
/// silhouette or a shared edge, where the two methods may pick different triangles (the
/// rasteriser's top-left rule is not reproduced).
#[test]
fn ray_cast_draws_what_the_rasteriser_draws() {
    let gpu = require_gpu!();
    for (name, scene) in scenes() {
        let raster = evaluate(&gpu, &scene, "raster");
        let cast = evaluate(&gpu, &scene, "ray_cast");
        for (node, port) in PORTS {
            let (a, b) = (raster.read(node, port), cast.read(node, port));
            let n = (a.width * a.height) as usize;
            let (fine, coarse) = (pixels_apart(&a, &b, 1e-3), pixels_apart(&a, &b, 1e-2));
            println!("{name} {node}.{port}: {fine} / {coarse} of {n} pixels apart (1e-3 / 1e-2)");
            assert!(
                fine * 100 <= n,
                "{name} {node}.{port}: {fine} of {n} pixels apart by 1e-3"
            );
            assert!(
                coarse * 500 <= n,
                "{name} {node}.{port}: {coarse} of {n} pixels apart by 1e-2"
            );
        }
        // Not vacuous: the views see geometry and sky.
        let depth = cast.read("gbuffer", "depth");
        let far = matrices(cast.get("gbuffer", "depth")).far;
        assert!(
            depth.data.iter().any(|d| *d < far) && depth.data.iter().any(|d| *d >= far),
            "{name}"
        );
    }
}

/// A shot whose camera or light moves builds its BVH once: the second evaluation after a sun
/// change reuses the first's (same geometry, same objects).
#[test]
fn the_bvh_is_built_once_per_geometry() {
    let gpu = require_gpu!();
    let a = evaluate(&gpu, r#""name": "tree", "sun_azimuth": 30.0,"#, "ray_cast");
    let scene = |o: &common::Outputs| match o.get("scene", "scene") {
        PortValue::Other(_, s) => s.clone().downcast::<GpuScene>().expect("a scene"),
        other => panic!("{other:?}"),
    };
    let first = scene(&a);
    let b = evaluate(&gpu, r#""name": "tree", "sun_azimuth": 80.0,"#, "ray_cast");
    let second = scene(&b);
    assert!(second.geometry_reused);
    let made = |s: &GpuScene| {
        let mut made = false;
        let bvh = s.derived(0xB0B, || {
            made = true;
            Ok(())
        });
        (bvh.is_ok(), made)
    };
    drop(first);
    // The mechanism the ray cast uses: a value derived from the first scene's geometry is found
    // from the second's.
    assert_eq!(made(&second), (true, true));
    assert_eq!(made(&second), (true, false));
    let all = ray_cast::scene_bvh(&gpu.recorder(), &second, &second.draws()).expect("bvh");
    let again = ray_cast::scene_bvh(&gpu.recorder(), &second, &second.draws()).expect("bvh");
    assert!(std::sync::Arc::ptr_eq(&all, &again));
    assert!(all.triangles > 100);
}
