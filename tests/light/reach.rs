//! Light reaches every part of the medium (issue #60): an occluder shadows everything behind it,
//! at any distance, and a texel with no occluder is "clear", not a depth of 1.
//!
//! The scene is `tests/fixtures/cycles_roof/scene.gltf` (`scripts/cycles_compare.py --scene
//! roof`): a 16 m × 16 m roof of tiles with three openings at y = 8 m and a column of fog below
//! it reaching y = −8 m, with nothing under the fog. The lights sit 1.3–2 m above the roof, so
//! along their rays the fog reaches 8× (lamps) and 16 m past (sun, whose map spans the roof's
//! 0.2 m) the farthest occluder: before the issue every medium point beyond the map's far plane,
//! a little under the roof, read "no occluder" and was lit.
//!
//! The reference tests occlusion by casting each light ray through the scene's triangles
//! (`ray_cast::Bvh`, the CPU reference of the ray-cast shadow map, built from the file's
//! meshes: no shadow map involved) at the midpoints of `STEPS` equal intervals of the view ray
//! in the fog, weighted as `BruteForce` weights them.

use crate::scattering::run_scene;

use glam::Vec3;
use tyndall::graph::ParamValue;
use tyndall::nodes::algorithms::ray_cast::Bvh;
use tyndall::nodes::algorithms::shader_lib::henyey_greenstein;
use tyndall::nodes::single_scattering::{
    light_path, medium_segment, weight, Params as ScatteringParams, ScatterParams,
};

/// Samples per view ray of the reference and of the GPU `BruteForce`.
const STEPS: u32 = 512;

/// Below this height (m) the pre-issue maps read "no occluder": the roof spans 8–8.2 m.
const OLD_FAR: f32 = 7.5;

fn f(v: f64) -> ParamValue {
    ParamValue::Float(v)
}

fn e(v: &str) -> ParamValue {
    ParamValue::Enum(v.into())
}

fn roof() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/cycles_roof/scene.gltf")
}

/// The Scene parameters of each light: the file's sun, or a spot or point light 1.3–2 m above
/// the roof (glTF's y up; the openings are at x ∈ [−4, −3], [−2, −1], [0, 1]).
fn lights() -> Vec<(&'static str, Vec<(&'static str, ParamValue)>)> {
    let path = ("path", ParamValue::Text(roof().display().to_string()));
    let lamp = |kind: &str, y: f64| {
        vec![
            path.clone(),
            ("light", e("custom")),
            ("light_type", e(kind)),
            ("light_x", f(-1.5)),
            ("light_y", f(y)),
            ("light_z", f(0.0)),
            ("light_target_x", f(-1.5)),
            ("light_target_y", f(0.0)),
            ("light_target_z", f(0.0)),
            ("cone_inner", f(45.0)),
            ("cone_outer", f(55.0)),
            ("light_intensity", f(400.0)),
            ("sun_colour", ParamValue::Colour([1.0, 1.0, 1.0, 1.0])),
        ]
    };
    vec![
        ("sun", vec![path.clone()]),
        ("spot", lamp("spot", 10.2)),
        ("point", lamp("point", 9.5)),
    ]
}

/// The medium of every run: the fog tagged in the file, the light attenuated through it.
fn medium(method: &str) -> Vec<(&'static str, ParamValue)> {
    vec![
        ("sigma_t", f(0.1)),
        ("albedo", f(1.0)),
        ("g", f(0.5)),
        ("bias", f(0.0005)),
        ("bounds", e("tagged")),
        ("light_extinction", e("on")),
        ("steps", ParamValue::Int(STEPS.into())),
        ("method", e(method)),
    ]
}

/// In-scatter (mean of RGB) of pixel (x, y) with occlusion found by casting light rays through
/// `bvh`: `(exact, pre-issue)`, the second counting every sample below [`OLD_FAR`] as lit.
fn traced_pixel(
    p: &ScatterParams,
    bvh: &Bvh,
    s: f32,
    xy: (u32, u32),
    size: (u32, u32),
) -> [f32; 2] {
    let inv = glam::Mat4::from_cols_array_2d(&p.inv_view_proj);
    let eye = Vec3::from(p.eye);
    let dir = tyndall::eval::pixel_ray(inv, eye, xy.0, xy.1, size.0, size.1);
    let (t0, t1) = medium_segment(p, dir, s);
    let len = (t1 - t0).max(0.0);
    let n = STEPS as f32;
    let radiance = (p.light.radiance[0] + p.light.radiance[1] + p.light.radiance[2]) / 3.0;
    let mut acc = [0.0f32; 2];
    for i in 0..STEPS {
        let t = t0 + (i as f32 + 0.5) / n * len;
        let x = eye + dir * t;
        let (reach, contribution) = match p.local() {
            Some(light) => {
                let to_light = light.position() - x;
                // The segment stops a hair short of the lamp.
                let reach = bvh.cast(x, to_light * (1.0 - 1e-4)).is_none();
                let attenuation =
                    (-p.sigma_t * (t - t0)).exp() * (-p.sigma_t * light_path(p, &light, x)).exp();
                let cos = dir.dot(to_light.normalize());
                let k = light.falloff(x) * attenuation * len / n;
                (reach, henyey_greenstein(p.g, cos) * k)
            }
            None => {
                let to_sun = p.to_sun();
                let reach = bvh.cast(x, to_sun * 100.0).is_none();
                let a = t0 + i as f32 / n * len;
                let b = t0 + (i + 1) as f32 / n * len;
                let cos = dir.dot(to_sun);
                (
                    reach,
                    henyey_greenstein(p.g, cos) * weight(p, dir, t0, a, b),
                )
            }
        };
        let c = radiance * p.sigma_t * p.albedo * contribution;
        if reach {
            acc[0] += c;
        }
        if reach || x.y < OLD_FAR {
            acc[1] += c;
        }
    }
    acc
}

/// For the sun, a spot and a point light over the roof, every method's GPU in-scatter against
/// the ray-cast reference: the level (sum over the image) within 2 % and the mean absolute
/// difference per pixel within 4 % of the mean in-scatter (measured: levels 0.998–1.0004, gaps
/// 0.13–0.61 %); Epipolar's pixels by RMSE (below). What separates them: the map's
/// texels (2048², 1–2 cm on the roof) move each shaft's edges by up to half a texel, MinMax and
/// Epipolar integrate the limit of the reference's 512 midpoints (each crossing of a shaft's
/// edge off by up to 1/512 of the ray), Epipolar interpolates between its samples. Before the
/// issue every method lit the fog below the roof's depth: there the reference is at least 3×
/// darker than that reading (asserted), far outside these bounds.
#[test]
fn every_method_lights_deep_fog_only_through_the_openings() {
    let gpu = require_gpu!();
    let scene = tyndall::scene::load_gltf(&roof()).expect("roof fixture");
    let triangles: Vec<[Vec3; 3]> = scene
        .objects
        .iter()
        .flat_map(|o| {
            o.indices
                .chunks_exact(3)
                .map(|t| [0, 1, 2].map(|k| o.positions[t[k] as usize]))
        })
        .collect();
    let bvh = Bvh::build(&triangles);
    let fog = scene.medium.expect("the fog is tagged medium");
    assert!(fog.0.y <= -7.9 && fog.1.y <= 8.0, "fog {fog:?}");
    let size = (64, 36);
    for (light, scene_params) in lights() {
        let mut reference: Option<(Vec<f32>, f64)> = None;
        for method in ["BruteForce", "MinMax", "Epipolar"] {
            let r = run_scene(&gpu, &scene_params, 2048, size, &medium(method));
            let got: Vec<f32> = (0..size.0 * size.1)
                .map(|i| {
                    let p = &r.inscatter.data[i as usize * 4..i as usize * 4 + 3];
                    (p[0] + p[1] + p[2]) / 3.0
                })
                .collect();
            let (want, old_total) = reference.get_or_insert_with(|| {
                let m = ScatteringParams::with_overrides(&medium(method)).expect("parameters");
                let p = ScatterParams::new(&r.camera, &r.light, &m).with_bounds(Some(fog), true);
                let mut old = 0.0f64;
                let want = (0..size.1)
                    .flat_map(|y| (0..size.0).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        let s = r.depth.pixel(x, y)[0];
                        let [exact, before] = traced_pixel(&p, &bvh, s, (x, y), size);
                        old += f64::from(before);
                        exact
                    })
                    .collect();
                (want, old)
            });
            let total_want: f64 = want.iter().map(|v| f64::from(*v)).sum();
            let total_got: f64 = got.iter().map(|v| f64::from(*v)).sum();
            let mean_gap = want
                .iter()
                .zip(&got)
                .map(|(a, b)| f64::from((a - b).abs()))
                .sum::<f64>()
                / total_want;
            let level = total_got / total_want;
            let peak = want.iter().cloned().fold(0.0f32, f32::max) as f64;
            let rmse = (want
                .iter()
                .zip(&got)
                .map(|(a, b)| f64::from(a - b).powi(2))
                .sum::<f64>()
                / want.len() as f64)
                .sqrt()
                / peak;
            eprintln!(
                "{light} {method}: level {level:.4}, mean |gap| {:.2} % of the mean, RMSE {:.3} % \
                 of the peak, pre-issue reading {:.2}× the reference",
                mean_gap * 100.0,
                rmse * 100.0,
                *old_total / total_want
            );
            assert!(total_want > 0.0, "{light}: no light reaches the fog");
            assert!(
                *old_total >= 3.0 * total_want,
                "{light}: the scene should be one the far plane got wrong"
            );
            assert!(
                (level - 1.0).abs() <= 0.02,
                "{light} {method}: level {level}"
            );
            if method == "Epipolar" {
                // The sun's shafts lie along the epipolar lines, and the sides of this roof's
                // openings are planes through the sun seen nearly edge-on from the camera: V̄
                // steps from 0.2 to 0 within a tenth of a pixel, and a pixel whose centre falls
                // between slices on either side of a step takes their average (measured: 0.17
                // off at such pixels, RMSE 1.0 % of the peak, level 0.993). That is Epipolar's
                // interpolation, not the light's reach: its sample rays walk the clear texels
                // exactly (`epipolar_sample_rays_walk_clear_texels_exactly`). A lamp's shafts
                // fan out and are held to Epipolar's bound against MinMax (0.5 %; measured
                // 0.07 % and 0.015 %).
                let bound = if light == "sun" { 0.015 } else { 0.005 };
                assert!(rmse <= bound, "{light} {method}: RMSE {rmse} of the peak");
            } else {
                assert!(
                    mean_gap <= 0.04,
                    "{light} {method}: mean gap {mean_gap} of the mean"
                );
            }
        }
    }
}

/// Epipolar's sample rays on the roof's sun map: every slice's 1D min-max tree walk (clear
/// texels as +∞) gives the exact walk's V̄ (every texel the ray crosses, `exact_ray`, which
/// MinMax computes and the ray-cast reference confirms above) to 1e-5: the trees and the
/// unclipped rays reach the whole fog, and what Epipolar's image adds is interpolation.
#[test]
fn epipolar_sample_rays_walk_clear_texels_exactly() {
    use tyndall::nodes::single_scattering::{epi_tree_row, epipolar_geometry, exact_ray, tree_ray};
    let gpu = require_gpu!();
    let (_, scene_params) = lights().remove(0);
    let size = (64u32, 36u32);
    let r = run_scene(&gpu, &scene_params, 2048, size, &medium("Epipolar"));
    let fog = tyndall::scene::load_gltf(&roof())
        .expect("roof")
        .medium
        .expect("fog");
    let m = ScatteringParams::with_overrides(&medium("Epipolar")).expect("parameters");
    let p = ScatterParams::new(&r.camera, &r.light, &m).with_bounds(Some(fog), true);
    let g = epipolar_geometry(&p, size, (r.shadow.width, r.shadow.height), 128);
    let inv = glam::Mat4::from_cols_array_2d(&p.inv_view_proj);
    let eye = Vec3::from(p.eye);
    let (mut worst, mut lit) = (0.0f32, 0);
    for slice in &g.slices {
        let row = epi_tree_row(&r.shadow, slice, g.tree_n);
        for j in 0..32 {
            let q = glam::Vec2::from(slice.entry)
                + glam::Vec2::from(slice.dir) * (slice.len * j as f32 / 31.0);
            let px = (q.x.max(0.0) as u32).min(size.0 - 1);
            let py = (q.y.max(0.0) as u32).min(size.1 - 1);
            let s = r.depth.pixel(px, py)[0];
            let dir = tyndall::eval::screen_ray(inv, eye, q, size.0, size.1);
            let tree = tree_ray(&p, &r.shadow, (&row, g.tree_n, slice), 0, dir, s).0;
            let exact = exact_ray(&p, &r.shadow, dir, s).0;
            worst = worst.max((tree - exact).abs());
            lit += (exact > 0.0) as u32;
        }
    }
    assert!(lit > 100, "only {lit} sample rays reach a shaft");
    assert!(worst <= 1e-5, "tree walk against the exact walk: {worst}");
}
