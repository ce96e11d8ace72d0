//! Clear texels (no occluder, `SHADOW_CLEAR`) through every shadow-map editing filter's CPU
//! reference (issue #60): a texel no filter reaches stays exactly clear, a texel a filter writes
//! is either clear or a depth taken from an occluder (never a value between, such as a slope
//! computed from 1e30 or a blend of clear and a depth), and a dilation still grows the occluder.

use glam::Vec3;
use tyndall::eval::{is_clear, Matrices, SHADOW_CLEAR};
use tyndall::io::Raster;
use tyndall::nodes::epipolar::{self, Perspective};
use tyndall::nodes::{hole_composite, morphology2d};
use tyndall::scene::LocalLight;

/// A `size`² map, clear but for a square occluder over [lo, hi)² whose depth ramps 0.3 → 0.5.
fn map(size: u32, lo: u32, hi: u32) -> Raster {
    let mut m = Raster::new(size, size, 1, SHADOW_CLEAR);
    for y in lo..hi {
        for x in lo..hi {
            m.data[(y * size + x) as usize] = 0.3 + 0.2 * (x - lo) as f32 / (hi - lo) as f32;
        }
    }
    m
}

/// Chebyshev distance of texel (x, y) from the square [lo, hi)².
fn distance(x: u32, y: u32, lo: u32, hi: u32) -> u32 {
    let d = |v: u32| {
        if v < lo {
            lo - v
        } else if v >= hi {
            v + 1 - hi
        } else {
            0
        }
    };
    d(x).max(d(y))
}

/// Every texel is clear or a depth in [0, `max_depth`]; texels farther than `reach` from the
/// occluder are clear. Returns (clear texels, occluded texels).
fn check(what: &str, out: &Raster, lo: u32, hi: u32, reach: u32, max_depth: f32) -> (u32, u32) {
    let (mut clear, mut occluded) = (0, 0);
    for y in 0..out.height {
        for x in 0..out.width {
            let v = out.data[(y * out.width + x) as usize];
            if is_clear(v) {
                assert_eq!(
                    v, SHADOW_CLEAR,
                    "{what}: ({x},{y}) is {v}, not exactly clear"
                );
                clear += 1;
            } else {
                assert!(
                    (0.0..=max_depth).contains(&v),
                    "{what}: ({x},{y}) is {v}, neither clear nor an occluder's depth"
                );
                assert!(
                    distance(x, y, lo, hi) <= reach,
                    "{what}: ({x},{y}) got {v}, {} texels from the occluder (reach {reach})",
                    distance(x, y, lo, hi)
                );
                occluded += 1;
            }
        }
    }
    (clear, occluded)
}

#[test]
fn morphology_keeps_clear_texels_clear() {
    let (n, lo, hi, r) = (48, 18, 30, 4);
    let m = map(n, lo, hi);
    let square = (hi - lo) * (hi - lo);
    for circle in [false, true] {
        let dilated = morphology2d::reference(&m, r, circle, false);
        let (_, occ) = check("Dilation2D", &dilated, lo, hi, r as u32, 0.5);
        assert!(occ > square, "the dilation should grow the occluder");
        let eroded = morphology2d::reference(&m, r, circle, true);
        let (_, occ) = check("Erosion2D", &eroded, lo, hi, 0, 0.5);
        assert!(occ < square, "the erosion should shrink the occluder");
        let closed = morphology2d::reference_closure(&m, r, circle);
        check("Closure2D", &closed, lo, hi, r as u32, 0.5);
    }
}

#[test]
fn epipolar_filters_keep_clear_texels_clear() {
    let (n, lo, hi, length) = (48, 18, 30, 6);
    let m = map(n, lo, hi);
    // The camera's texel above the map and nearer the light than the occluder, then below it.
    for (l, z_l) in [([24.0, -20.0], 0.1), ([40.5, 70.0], 0.05)] {
        let dilated = epipolar::reference(&m, l, z_l, length, false);
        // The extrusion continues each silhouette's depth slope along its epipolar line, so
        // the depths it writes grow past the occluder's own (at most by `length` slopes).
        let (_, occ) = check("EpipolarDilation", &dilated, lo, hi, length as u32, 2.0);
        assert!(
            occ > (hi - lo) * (hi - lo),
            "the extrusion should grow the occluder"
        );
        let closed = epipolar::reference(&dilated, l, z_l, length, true);
        check("EpipolarClosure", &closed, lo, hi, length as u32, 2.0);
        // A spot's map: the same passes in q = 1 − near / w and back.
        let persp = Perspective {
            near: 0.5,
            far: 20.0,
        };
        for closure in [false, true] {
            let spot = epipolar::reference_spot(&m, persp, (l, z_l, false), length, closure);
            // In q a slope extruded past q = 1 reaches infinity along the spot's axis: very far
            // depths are right there, a negative one (1 − q < 0) would shadow everything.
            let (_, occ) = check(
                "EpipolarDilation (spot)",
                &spot,
                lo,
                hi,
                length as u32,
                1e20,
            );
            assert!(occ >= (hi - lo) * (hi - lo));
        }
    }
}

#[test]
fn a_point_lights_cube_atlas_keeps_clear_texels_clear_across_its_seams() {
    // A 32² face atlas, an occluder on face 0 next to its seam with face 4, the rest clear.
    let face = 32u32;
    let mut atlas = Raster::new(3 * face, 2 * face, 1, SHADOW_CLEAR);
    for y in 10..20 {
        for x in 26..32 {
            atlas.data[(y * 3 * face + x) as usize] = 0.2;
        }
    }
    let light = LocalLight {
        point: true,
        position: [0.0, 0.0, 0.0],
        direction: [0.0, -1.0, 0.0],
        cos_inner: -1.0,
        cos_outer: -1.0,
        range: 0.0,
        near: 0.05,
        far: 10.0,
    };
    let camera = Matrices {
        view: glam::camera::rh::view::look_at_mat4(Vec3::new(3.0, 1.0, 2.0), Vec3::ZERO, Vec3::Y)
            .to_cols_array_2d(),
        proj: glam::camera::rh::proj::directx::perspective(0.8, 1.0, 0.1, 50.0).to_cols_array_2d(),
        ..Default::default()
    };
    let occluded = |r: &Raster| r.data.iter().filter(|v| !is_clear(**v)).count();
    let padded = tyndall::nodes::algorithms::cube_atlas::pad_reference(&atlas, &light, 4);
    for v in &padded.data {
        assert!(
            *v == SHADOW_CLEAR || (0.0..=1.0).contains(v),
            "gutter texel {v}"
        );
    }
    assert!(
        occluded(&padded) > occluded(&atlas),
        "the gutter copies the occluder"
    );
    for closure in [false, true] {
        let out = epipolar::reference_cube(&atlas, &light, &camera, 4, closure);
        for v in &out.data {
            assert!(*v == SHADOW_CLEAR || (0.0..=1.0).contains(v), "texel {v}");
        }
        let far_clear = (0..2 * face)
            .flat_map(|y| (0..3 * face).map(move |x| (x, y)))
            .filter(|(x, y)| *x >= face && *x < 2 * face && *y < face) // face 1 (−x), opposite face 0
            .all(|(x, y)| out.data[(y * 3 * face + x) as usize] == SHADOW_CLEAR);
        assert!(far_clear, "a face far from the occluder stays clear");
        assert!(occluded(&out) >= occluded(&atlas));
    }
}

#[test]
fn hole_composite_opens_holes_to_clear() {
    let (n, lo, hi) = (16, 4, 12);
    let object = map(n, lo, hi);
    let rest = map(n, 0, 0); // all clear
    let mut holes = Raster::new(n, n, 1, 0.0);
    for x in lo..hi {
        holes.data[(8 * n + x) as usize] = 1.0;
    }
    let out = hole_composite::reference(&object, &holes, &rest);
    for y in 0..n {
        for x in 0..n {
            let v = out.data[(y * n + x) as usize];
            let inside = (lo..hi).contains(&x) && (lo..hi).contains(&y);
            if !inside || y == 8 {
                assert_eq!(v, SHADOW_CLEAR, "({x},{y}): a hole or no occluder is clear");
            } else {
                assert_eq!(v, object.data[(y * n + x) as usize]);
            }
        }
    }
}
