//! Epipolar dilation/closure against the reference definition (seed eq. 3).

use crate::common;
use std::sync::Arc;

use tyndall::eval::{Matrices, PortValue};
use tyndall::graph::ParamValue;
use tyndall::io::Raster;
use tyndall::nodes::epipolar::reference;
use tyndall::scene::LocalLight;

fn run(
    gpu: &Arc<tyndall::gpu::Gpu>,
    kind: &str,
    map: &Raster,
    l: [f64; 2],
    z_l: f64,
    length: i64,
) -> Raster {
    run_with(gpu, kind, map, l, z_l, length, "Reference")
}

fn run_with(
    gpu: &Arc<tyndall::gpu::Gpu>,
    kind: &str,
    map: &Raster,
    l: [f64; 2],
    z_l: f64,
    length: i64,
    method: &str,
) -> Raster {
    common::run_node(
        gpu,
        kind,
        &[
            ("method", ParamValue::Enum(method.into())),
            ("epipole_x", ParamValue::Float(l[0])),
            ("epipole_y", ParamValue::Float(l[1])),
            ("epipole_depth", ParamValue::Float(z_l)),
            ("length", ParamValue::Int(length)),
        ],
        vec![(
            "map",
            PortValue::ShadowMap(
                Arc::new(gpu.upload(map.width, map.height, 1, &map.data).expect("up")),
                Matrices::default(),
            ),
        )],
        &["map"],
        (1, 1),
    )
    .expect("evaluate")
    .remove("map")
    .expect("map")
}

/// Share of texels within 1e-4. GPU and CPU follow the same f32 steps, but a sample point
/// within rounding of a texel edge may land in the neighbouring texel; such flips are rare.
fn agreement(a: &Raster, b: &Raster) -> f64 {
    let close = a
        .data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| (*x - *y).abs() <= 1e-4)
        .count();
    close as f64 / a.data.len() as f64
}

#[test]
fn gpu_matches_reference_definition_in_all_epipole_cases() {
    let gpu = require_gpu!();
    let map = common::random_raster(48, 40, 1, 0.2, 0.9, 11);
    let cases: [([f64; 2], f64); 6] = [
        ([24.5, 20.5], 0.5),   // on a texel centre inside the map
        ([10.2, 33.7], 0.3),   // inside the map
        ([-300.0, 12.0], 0.4), // outside
        ([1e6, -2e6], 0.5),    // very far: nearly parallel rays
        ([60.0, -10.0], -0.5), // z_l below 0
        ([-20.0, 70.0], 1.7),  // z_l above 1
    ];
    for (l, z_l) in cases {
        for length in [1, 5, 15] {
            let lf = [l[0] as f32, l[1] as f32];
            let dil = reference(&map, lf, z_l as f32, length, false);
            let clo = reference(&dil, lf, z_l as f32, length, true);
            let g = run(&gpu, "EpipolarDilation", &map, l, z_l, length as i64);
            let gc = run(&gpu, "EpipolarClosure", &map, l, z_l, length as i64);
            assert!(
                g.data.iter().chain(&gc.data).all(|v| v.is_finite()),
                "{l:?} {z_l}: non-finite"
            );
            assert!(
                agreement(&g, &dil) >= 0.99,
                "dilation {l:?} z_l={z_l} k={length}: {}",
                agreement(&g, &dil)
            );
            assert!(
                agreement(&gc, &clo) >= 0.99,
                "closure {l:?} z_l={z_l} k={length}: {}",
                agreement(&gc, &clo)
            );
            // Dilation only lowers depths (occluders grow); closure lies between.
            assert!(g.data.iter().zip(&map.data).all(|(a, b)| *a <= *b + 1e-6));
        }
    }
}

#[test]
fn identity_and_flat_maps() {
    let gpu = require_gpu!();
    let map = common::random_raster(16, 16, 1, 0.0, 1.0, 12);
    assert_eq!(
        run(&gpu, "EpipolarClosure", &map, [3.0, 4.0], 0.5, 0),
        map,
        "length 0 is the identity"
    );
    // The texel at the epipole is unchanged.
    let g = run(&gpu, "EpipolarDilation", &map, [8.5, 8.5], 0.5, 5);
    assert_eq!(g.pixel(8, 8), map.pixel(8, 8));
    // With the epipole in front of the map (z_l < 1), an empty map stays empty; a fully
    // occluded one stays finite.
    let empty = Raster::new(16, 16, 1, tyndall::eval::SHADOW_CLEAR);
    let d = run(&gpu, "EpipolarDilation", &empty, [-40.0, 8.0], 0.2, 8);
    assert!(d.data.iter().all(|v| tyndall::eval::is_clear(*v)));
    // A map of occluders at the far plane (depth 1) stays at depth 1.
    let ones = Raster::new(16, 16, 1, 1.0);
    let d = run(&gpu, "EpipolarDilation", &ones, [-40.0, 8.0], 0.2, 8);
    assert!(d.data.iter().all(|v| (*v - 1.0).abs() <= 1e-6));
    let zeros = Raster::new(16, 16, 1, 0.0);
    let d = run(&gpu, "EpipolarClosure", &zeros, [-40.0, 8.0], 0.2, 8);
    assert!(d.data.iter().all(|v| v.is_finite()));
    assert!(
        agreement(
            &d,
            &reference(
                &reference(&zeros, [-40.0, 8.0], 0.2, 8, false),
                [-40.0, 8.0],
                0.2,
                8,
                true
            )
        ) >= 0.99
    );
}

/// The shadow map of a built-in scene (the foliage of the tree, the figure) and its epipole.
fn scene_map(gpu: &Arc<tyndall::gpu::Gpu>, scene: &str, res: i64) -> (Raster, [f64; 2], f64) {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = tyndall::graph::Graph::new();
    let s = g.add_node(&cat, "Scene").expect("scene");
    g.set_param(&cat, &s, "name", ParamValue::Enum(scene.into()))
        .expect("name");
    let m = g.add_node(&cat, "ShadowMap").expect("map");
    g.set_param(&cat, &m, "resolution", ParamValue::Int(res))
        .expect("res");
    let b = g.add_node(&cat, "GBuffer").expect("gbuffer");
    g.connect(&cat, &format!("{s}.scene"), &format!("{m}.scene"))
        .expect("edge");
    g.connect(&cat, &format!("{s}.scene"), &format!("{b}.scene"))
        .expect("edge");
    let r = tyndall::eval::Evaluator::new(registry, gpu.clone())
        .evaluate(
            &g,
            &[
                tyndall::eval::Target::Port(m.clone(), "map".into()),
                tyndall::eval::Target::Port(b.clone(), "depth".into()),
            ],
            &tyndall::eval::EvalOptions {
                size: (8, 8),
                ..Default::default()
            },
        )
        .expect("eval");
    let (PortValue::ShadowMap(_, light), PortValue::Depth(_, cam)) = (
        &r.outputs[&(m.clone(), "map".to_string())],
        &r.outputs[&(b, "depth".to_string())],
    ) else {
        panic!("types")
    };
    let (l, z_l) = tyndall::nodes::epipolar::epipole(light, cam, res as u32, res as u32);
    let map = tyndall::eval::download(&gpu.recorder(), &r.outputs[&(m, "map".to_string())])
        .expect("download");
    (map, [l[0] as f64, l[1] as f64], z_l as f64)
}

/// Texels where the fast path differs from the reference method by more than 1e-6, and the
/// largest difference. Both evaluate the same f32 expressions, but the driver compiles each
/// entry point on its own and may fuse `z_l + d_t · κ` into an FMA in one and not the other:
/// 1 ulp (≈ 6e-8 at depth 1) is seen with the epipole 1e9 texels away; 1e-6 allows that and
/// nothing else (a texel landing on a neighbouring sample differs by far more).
fn differences(a: &Raster, b: &Raster) -> (usize, f32) {
    let n = a
        .data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| (*x - *y).abs() > 1e-6)
        .count();
    let m = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    (n, m)
}

/// Compare the two methods on one map for both kinds, several epipoles and lengths.
fn assert_fast_equals_reference(
    gpu: &Arc<tyndall::gpu::Gpu>,
    what: &str,
    map: &Raster,
    epipoles: &[([f64; 2], f64)],
    lengths: &[i64],
) {
    for &(epi, zl) in epipoles {
        for kind in ["EpipolarDilation", "EpipolarClosure"] {
            for &length in lengths {
                let reference = run_with(gpu, kind, map, epi, zl, length, "Reference");
                let fast = run_with(gpu, kind, map, epi, zl, length, "Fast");
                let (n, m) = differences(&fast, &reference);
                eprintln!(
                    "{what} {kind} epipole ({:.1}, {:.1}) z_l {zl:.3} k {length}: {n} texels differ by > 1e-6, max {m}",
                    epi[0], epi[1]
                );
                assert_eq!(
                    n, 0,
                    "{what} {kind} epipole {epi:?} z_l {zl} k {length}: {n} texels differ (max {m})"
                );
            }
        }
    }
}

/// The fast path proves every texel's answer (exact end samples against a bound from the
/// rectified grid, else the exact loop), so it must equal the definition on every texel
/// (within 1e-6, see `differences`) on the built-in scenes' shadow
/// maps with the camera's epipole and with epipoles inside, outside and far from the map.
/// (The issue asks for ≥ 99 % of texels within 1e-4; this asserts 100 % within 1e-6.)
#[test]
fn fast_path_equals_the_definition_on_scene_maps() {
    let gpu = require_gpu!();
    for scene in ["tree", "figure"] {
        let (map, l, z_l) = scene_map(&gpu, scene, 256);
        let epipoles = [
            (l, z_l),
            ([128.5, 100.0], z_l),
            ([-1e5, 3e5], z_l),
            ([300.0, -40.0], -0.3),
        ];
        assert_fast_equals_reference(&gpu, scene, &map, &epipoles, &[15, 60]);
    }
}

/// The same on uniform noise, where the grid's bound rarely proves anything and most texels
/// take the exact loop, and at the edge cases: epipole on a texel centre, inside,
/// 1e6 and 1e9 texels away (where f32 angles are too coarse for the grid and the coverage
/// check sends texels to the exact loop), z_l below 0 and above 1, lengths at and around the
/// 2·ENDS cut-over.
#[test]
fn fast_path_equals_the_definition_on_noise_and_edge_cases() {
    let gpu = require_gpu!();
    let map = common::random_raster(61, 47, 1, 0.2, 0.9, 21);
    let epipoles = [
        ([30.5, 20.5], 0.5),
        ([10.2, 33.7], 0.3),
        ([-300.0, 12.0], 0.4),
        ([1e6, -2e6], 0.5),
        ([-1e9, 3e8], 0.6),
        ([80.0, -10.0], -0.5),
        ([-20.0, 70.0], 1.7),
    ];
    assert_fast_equals_reference(&gpu, "noise", &map, &epipoles, &[1, 6, 7, 9, 33]);
}

/// A spot at (0, 6, 0) shining straight down (60° cone, depth 0.5–20 m), its 128² perspective
/// map empty but for one occluder texel, and a camera; EpipolarDilation on the map with the
/// camera as epipole. Returns (light matrices, map, dilated map, the occluder's world point,
/// the camera's eye).
fn spot_dilation(eye: glam::Vec3) -> (Matrices, Raster, Raster, glam::Vec3, glam::Vec3) {
    use tyndall::scene::{local_proj, spot_view, LocalLight};
    let gpu = common::gpu().expect("gpu");
    let res = 128u32;
    let (pos, dir) = (glam::Vec3::new(0.0, 6.0, 0.0), glam::Vec3::NEG_Y);
    let (near, far, half) = (0.5f32, 20.0f32, 30f32.to_radians());
    let local = LocalLight {
        point: false,
        position: pos.to_array(),
        direction: dir.to_array(),
        cos_inner: half.cos(),
        cos_outer: half.cos(),
        range: 0.0,
        near,
        far,
    };
    let light = Matrices {
        view: spot_view(pos, dir).to_cols_array_2d(),
        proj: local_proj(half, near, far).to_cols_array_2d(),
        local: Some(local),
        ..Default::default()
    };
    // The occluder: texel (70, 60) at 3 m along the axis.
    let (ox, oy, ow) = (70u32, 60u32, 3.0f32);
    let mut map = Raster::new(res, res, 1, 1.0);
    map.data[(oy * res + ox) as usize] = (ow - near) / (far - near);
    let occluder = unproject(&light, ox as f32 + 0.5, oy as f32 + 0.5, ow, res);
    let cam = camera_at(eye);
    let input = match common::upload(&gpu, &map, tyndall::graph::PortType::ShadowMap) {
        PortValue::ShadowMap(t, _) => PortValue::ShadowMap(t, light),
        _ => unreachable!(),
    };
    let camera = match common::upload(
        &gpu,
        &Raster::new(1, 1, 1, 1.0),
        tyndall::graph::PortType::Depth,
    ) {
        PortValue::Depth(t, _) => PortValue::Depth(t, cam),
        _ => unreachable!(),
    };
    let out = common::run_node(
        &gpu,
        "EpipolarDilation",
        &[("length", ParamValue::Int(400))],
        vec![("map", input), ("camera", camera)],
        &["map"],
        (1, 1),
    )
    .expect("EpipolarDilation on a spot's map")
    .remove("map")
    .expect("map");
    (light, map, out, occluder, cam.eye())
}

/// World point of texel centre (x, y) at distance `w` along a spot map's axis.
fn unproject(light: &Matrices, x: f32, y: f32, w: f32, res: u32) -> glam::Vec3 {
    let ndc = glam::Vec2::new(x / res as f32 * 2.0 - 1.0, 1.0 - y / res as f32 * 2.0);
    let k = light.proj[0][0];
    let view_point = glam::Vec3::new(ndc.x * w / k, ndc.y * w / k, -w);
    glam::Mat4::from_cols_array_2d(&light.view)
        .inverse()
        .transform_point3(view_point)
}

/// A camera at `eye` looking at (0, 2, 0) (only its position matters here: the epipole).
fn camera_at(eye: glam::Vec3) -> Matrices {
    let view = tyndall::scene::spot_view(eye, glam::Vec3::new(0.0, 2.0, 0.0) - eye);
    Matrices {
        view: view.to_cols_array_2d(),
        ..Default::default()
    }
}

/// On a spot's perspective map the extrusion follows the camera's view rays (issue #44,
/// item 4): every texel the dilation fills holds a point on the view ray from the camera through
/// the occluder, within the texel's own footprint (the sample walk lands on the occluder from
/// texels up to a texel off the exact line); for a camera in front of the spot's plane and one
/// behind it (whose rays' images run towards the epipole). Extruding the map's linear depth as a
/// sun's (eq. 3 on z, not on 1/w) misses the ray by metres.
#[test]
fn epipolar_dilation_on_a_spot_follows_the_view_rays() {
    if common::gpu().is_none() {
        return;
    }
    for eye in [
        glam::Vec3::new(-4.0, 1.5, 5.0),
        glam::Vec3::new(-3.0, 7.5, 4.0),
    ] {
        let (light, map, out, occluder, c) = spot_dilation(eye);
        let local = light.local.expect("spot");
        let res = map.width;
        let mut filled = 0;
        let mut worst = 0.0f32;
        for y in 0..res {
            for x in 0..res {
                let i = (y * res + x) as usize;
                if out.data[i] == map.data[i] {
                    continue;
                }
                filled += 1;
                let w = local.near + out.data[i] * (local.far - local.near);
                let p = unproject(&light, x as f32 + 0.5, y as f32 + 0.5, w, res);
                let axis = (occluder - c).normalize();
                let off = (p - c) - axis * (p - c).dot(axis);
                // One texel at distance w spans 2 tan 30° · w / 128; allow 1.5 of them.
                let texel = 2.0 * 30f32.to_radians().tan() * w / res as f32;
                worst = worst.max(off.length() / texel);
            }
        }
        eprintln!("camera {eye}: {filled} texels filled, worst {worst:.2} texels off the ray");
        assert!(filled >= 10, "camera {eye}: only {filled} texels filled");
        assert!(
            worst <= 1.5,
            "camera {eye}: a filled texel lies {worst} texels off the view ray through the occluder"
        );
    }
}

/// The GPU passes on a spot's map equal their CPU reference (`reference_spot`): the same
/// filled texels, depths within 1e-5 (WGSL's division may be 2.5 ulp off the CPU's correctly
/// rounded one in the q conversions; a texel filled from another sample differs by far more).
#[test]
fn epipolar_dilation_on_a_spot_matches_its_cpu_reference() {
    if common::gpu().is_none() {
        return;
    }
    for eye in [
        glam::Vec3::new(-4.0, 1.5, 5.0),
        glam::Vec3::new(-3.0, 7.5, 4.0),
    ] {
        let (light, map, out, _, _) = spot_dilation(eye);
        let local = light.local.expect("spot");
        let persp = tyndall::nodes::epipolar::Perspective {
            near: local.near,
            far: local.far,
        };
        let cam = camera_at(eye);
        let epi =
            tyndall::nodes::epipolar::spot_epipole(&light, &cam, persp, map.width, map.height)
                .expect("epipole");
        let want = tyndall::nodes::epipolar::reference_spot(&map, persp, epi, 400, false);
        for (i, (a, b)) in out.data.iter().zip(&want.data).enumerate() {
            assert_eq!(
                *a == map.data[i],
                *b == map.data[i],
                "texel {i}: filled on one side only ({a} vs {b})"
            );
            assert!((a - b).abs() <= 1e-5, "texel {i}: {a} vs {b}");
        }
    }
}

/// A point light at (0, 6, 0) (depth 0.5–20 m along each face's axis), its 3 × 2 atlas of
/// 64-texel faces empty but for one occluder texel in the −Y face near its +X edge (3 m below
/// the light, 2.4 m out towards +X), and a camera at (−4, 1.5, 0.5), whose epipolar line
/// through the occluder runs from the −Y face across the seam into the +X face. Returns the
/// light, the atlas, the occluder's world point and the camera.
fn cube_scene() -> (LocalLight, Raster, glam::Vec3, Matrices) {
    let (near, far, n) = (0.5f32, 20.0f32, 64u32);
    let light = LocalLight {
        point: true,
        position: [0.0, 6.0, 0.0],
        direction: [0.0, -1.0, 0.0],
        cos_inner: -1.0,
        cos_outer: -1.0,
        range: 0.0,
        near,
        far,
    };
    let mut atlas = Raster::new(3 * n, 2 * n, 1, 1.0);
    // Face 3 (−Y) sits at cell (0, 1); its s axis is −X, so +X lies towards column 0.
    let (x, y, w) = (6u32, 32u32, 3.0f32);
    atlas.data[((n + y) * 3 * n + x) as usize] = (w - near) / (far - near);
    let occluder = cube_point(&light, x, n + y, w, n);
    (
        light,
        atlas,
        occluder,
        camera_at(glam::Vec3::new(-4.0, 1.5, 0.5)),
    )
}

/// World point of atlas texel (x, y) at distance `w` along its face's axis.
fn cube_point(light: &LocalLight, x: u32, y: u32, w: f32, n: u32) -> glam::Vec3 {
    let (f, s, u) = tyndall::scene::face_basis((x / n + 3 * (y / n)) as usize);
    let a = ((x % n) as f32 + 0.5) / n as f32 * 2.0 - 1.0;
    let b = 1.0 - ((y % n) as f32 + 0.5) / n as f32 * 2.0;
    glam::Vec3::from(light.position) + (f + a * s + b * u) * w
}

/// `kind` on the atlas of [`cube_scene`], with or without the camera input.
fn run_on_cube(
    kind: &str,
    length: i64,
    with_camera: bool,
) -> Result<Raster, tyndall::eval::EvalError> {
    let gpu = common::gpu().expect("gpu");
    let (light, atlas, _, cam) = cube_scene();
    let matrices = Matrices {
        far: light.far,
        local: Some(light),
        ..Default::default()
    };
    let input = match common::upload(&gpu, &atlas, tyndall::graph::PortType::ShadowMap) {
        PortValue::ShadowMap(t, _) => PortValue::ShadowMap(t, matrices),
        _ => unreachable!(),
    };
    let mut inputs = vec![("map", input)];
    if with_camera {
        let camera = match common::upload(
            &gpu,
            &Raster::new(1, 1, 1, 1.0),
            tyndall::graph::PortType::Depth,
        ) {
            PortValue::Depth(t, _) => PortValue::Depth(t, cam),
            _ => unreachable!(),
        };
        inputs.push(("camera", camera));
    }
    common::run_node(
        &gpu,
        kind,
        &[("length", ParamValue::Int(length))],
        inputs,
        &["map"],
        (1, 1),
    )
    .map(|mut out| out.remove("map").expect("map"))
}

/// Whether a texel was filled: moved by more than the passes' rounding (the q conversion and
/// z_l + d (z − z_l) / d leave an empty texel's depth of 1 a few 1e-6 off where the epipole is
/// far away; a filled texel moves by the occluder's depth, here 0.87).
fn moved(after: f32, before: f32) -> bool {
    (after - before).abs() > 1e-4
}

/// On a point light's cube atlas the extrusion follows the camera's view rays across the faces'
/// seams (issue #44, item 4): every texel `EpipolarDilation` fills, on either face, holds a
/// point on the view ray through the occluder within 1.5 of its own texels (the walk lands on
/// the occluder from texels up to a texel off the exact line, as on a spot's map), and some of
/// them lie in the +X face, past the seam. The GPU passes equal their CPU reference
/// (`reference_cube`: the same filled texels, depths within 1e-5 as on a spot's map), for the
/// dilation and the closure. Without the camera input the node says what it needs.
#[test]
fn epipolar_filters_on_a_cube_atlas_follow_the_view_rays_across_a_seam() {
    if common::gpu().is_none() {
        return;
    }
    let (light, atlas, occluder, cam) = cube_scene();
    let n = atlas.width / 3;
    let out = run_on_cube("EpipolarDilation", 100, true).expect("EpipolarDilation on a cube atlas");
    let c = cam.eye();
    let axis = (occluder - c).normalize();
    let (mut filled, mut past_seam, mut worst) = (0, 0, 0.0f32);
    for y in 0..2 * n {
        for x in 0..3 * n {
            let i = (y * 3 * n + x) as usize;
            if !moved(out.data[i], atlas.data[i]) {
                continue;
            }
            filled += 1;
            // Face 0 (+X) is cell (0, 0).
            if x < n && y < n {
                past_seam += 1;
            }
            let w = light.near + out.data[i] * (light.far - light.near);
            let p = cube_point(&light, x, y, w, n);
            let off = (p - c) - axis * (p - c).dot(axis);
            // A texel at distance w along its face's axis spans 2 w / n (a 90° face).
            worst = worst.max(off.length() / (2.0 * w / n as f32));
        }
    }
    eprintln!("cube atlas: {filled} texels filled, {past_seam} in the +X face, worst {worst:.2} texels off the ray");
    assert!(filled >= 10, "only {filled} texels filled");
    assert!(
        past_seam >= 5,
        "the extrusion should cross into the +X face: {past_seam} texels"
    );
    assert!(
        worst <= 1.5,
        "a filled texel lies {worst} texels off the view ray"
    );
    for (kind, closure) in [("EpipolarDilation", false), ("EpipolarClosure", true)] {
        let got = run_on_cube(kind, 100, true).expect("run");
        let want = tyndall::nodes::epipolar::reference_cube(&atlas, &light, &cam, 100, closure);
        for (i, (a, b)) in got.data.iter().zip(&want.data).enumerate() {
            assert_eq!(
                moved(*a, atlas.data[i]),
                moved(*b, atlas.data[i]),
                "{kind}, texel {i}: filled on one side only ({a} vs {b})"
            );
            assert!((a - b).abs() <= 1e-5, "{kind}, texel {i}: {a} vs {b}");
        }
    }
    let e = run_on_cube("EpipolarClosure", 10, false)
        .expect_err("a cube atlas needs the camera")
        .to_string();
    assert!(e.contains("camera") && e.contains("point light"), "{e}");
}
