//! OpenVDB files (`tyndall::io::read_vdb_grid`): the values, boxes and transforms of files Debian's
//! python3-openvdb wrote (`tests/fixtures/make_vdb.py`), and every malformed file refused with
//! its path, never a panic.

use std::path::{Path, PathBuf};

use tyndall::io::{read_vdb_grid, vdb_grids, VdbError};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/vdb")
        .join(name)
}

fn at(g: &tyndall::io::VdbGrid, ijk: [i32; 3]) -> f32 {
    let t = [0, 1, 2].map(|a| (ijk[a] - g.index_min[a]) as usize);
    g.data[(t[2] * g.dims[1] as usize + t[1]) * g.dims[0] as usize + t[0]]
}

/// Half-float storage: 0.1 is stored as the half nearest to it, 0.0999755859375 exactly.
#[test]
fn half_floats_read_their_exact_values() {
    let g = read_vdb_grid(&fixture("half.vdb"), "density", 256).expect("half.vdb");
    assert_eq!(g.index_min, [10, 20, 30]);
    assert_eq!(g.dims, [3, 4, 5]);
    assert_eq!(g.reduce, 1);
    assert_eq!(at(&g, [10, 20, 30]), 1638.0 / 16384.0, "0.0999755859375");
    assert_eq!(at(&g, [12, 23, 34]), 2.5);
    assert_eq!(
        at(&g, [11, 20, 30]),
        0.0,
        "an inactive voxel holds the background"
    );
    assert_eq!(g.active_voxels, 2);
}

/// Full floats: every voxel of a 3×4×5 block, the voxel size and translation of the file's
/// map, and the file's other grids listed.
#[test]
fn a_float_grid_reads_every_voxel_and_its_transform() {
    let path = fixture("float.vdb");
    let names: Vec<String> = vdb_grids(&path)
        .expect("grids")
        .into_iter()
        .map(|g| format!("{} {}", g.name, g.grid_type))
        .collect();
    assert_eq!(
        names,
        [
            "density Tree_float_5_4_3",
            "temperature Tree_float_5_4_3",
            "vel Tree_vec3s_5_4_3"
        ]
    );
    let g = read_vdb_grid(&path, "density", 256).expect("density");
    assert_eq!((g.index_min, g.dims), ([10, 20, 30], [3, 4, 5]));
    for i in 0..3 {
        for j in 0..4 {
            for k in 0..5 {
                // Python's double arithmetic, stored as a float.
                let want = (0.1 + 0.01 * i as f64 + 0.1 * j as f64 + k as f64) as f32;
                assert_eq!(at(&g, [10 + i, 20 + j, 30 + k]), want, "({i}, {j}, {k})");
            }
        }
    }
    // Index (10, 20, 30) · 0.25 m + (1, 2, −3).
    let w = g
        .index_to_world
        .transform_point3(glam::DVec3::new(10.0, 20.0, 30.0));
    assert!(
        (w - glam::DVec3::new(3.5, 7.0, 4.5)).length() < 1e-12,
        "{w}"
    );
    let t = read_vdb_grid(&path, "temperature", 256).expect("temperature");
    assert_eq!(t.data, vec![300.0]);
}

/// Active tiles count as the voxels they cover: a filled 16³ block (stored as tiles or leaves,
/// as OpenVDB chose) next to one voxel.
#[test]
fn active_tiles_fill_their_voxels() {
    let g = read_vdb_grid(&fixture("tiles.vdb"), "density", 256).expect("tiles.vdb");
    assert_eq!(g.index_min, [0, 0, 0]);
    assert_eq!(g.dims, [21, 16, 16]);
    assert_eq!(g.active_voxels, 16 * 16 * 16 + 1);
    assert_eq!(at(&g, [0, 0, 0]), 0.5);
    assert_eq!(at(&g, [15, 15, 15]), 0.5);
    assert_eq!(at(&g, [20, 3, 4]), 1.5);
    assert_eq!(at(&g, [18, 3, 4]), 0.0);
}

/// An affine map (rotation about y by 30°, 0.5 m voxels, a translation), OpenVDB's row-vector
/// matrix read as world = M · index.
#[test]
fn an_affine_map_places_the_grid() {
    let g = read_vdb_grid(&fixture("affine.vdb"), "density", 256).expect("affine.vdb");
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let w = g
        .index_to_world
        .transform_point3(glam::DVec3::new(4.0, 0.0, 0.0));
    let want = glam::DVec3::new(1.0 + 2.0 * c, 2.0, 3.0 - 2.0 * s);
    assert!((w - want).length() < 1e-9, "{w} vs {want}");
    assert_eq!(at(&g, [4, 0, 0]), 2.0);
    assert_eq!(at(&g, [0, 0, 4]), 3.0);
}

/// A grid larger than the limit is filtered down by an integer factor: each texel the mean of
/// factor³ voxels, inactive ones counting as the background.
#[test]
fn a_grid_over_the_limit_is_filtered_down() {
    let g = read_vdb_grid(&fixture("tiles.vdb"), "density", 8).expect("tiles.vdb");
    assert_eq!(g.reduce, 3, "21 voxels into at most 8 texels");
    assert_eq!(g.dims, [7, 6, 6]);
    assert_eq!(g.data[0], 0.5, "a texel inside the filled block");
    // Texel (5, 0, 0) covers x 15…17: one filled column of 3×3 in 27 voxels.
    assert!((g.data[5] - 0.5 * 9.0 / 27.0).abs() < 1e-6, "{}", g.data[5]);
}

/// A wrong grid name lists the file's grids; a vector grid is refused naming its type.
#[test]
fn wrong_grids_are_refused_by_name() {
    let path = fixture("float.vdb");
    let e = read_vdb_grid(&path, "smoke", 256).expect_err("no such grid");
    assert!(matches!(e, VdbError::NoGrid { .. }), "{e}");
    let m = e.to_string();
    assert!(
        m.contains("float.vdb") && m.contains("density (Tree_float_5_4_3)") && m.contains("vel"),
        "{m}"
    );
    let m = read_vdb_grid(&path, "vel", 256)
        .expect_err("vector grid")
        .to_string();
    assert!(m.contains("'vel'") && m.contains("Tree_vec3s_5_4_3"), "{m}");
}

/// Every truncation of a real file, and bytes flipped through it, give an error naming the file
/// (or, for a flip that leaves the data readable, a grid), never a panic.
#[test]
fn malformed_files_are_errors_naming_the_file() {
    let bytes = std::fs::read(fixture("float.vdb")).expect("float.vdb");
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("broken.vdb");
    let mut tried = 0;
    let mut check = |data: &[u8]| {
        std::fs::write(&path, data).expect("write");
        let r = std::panic::catch_unwind(|| read_vdb_grid(&path, "density", 64));
        let r = r.expect("the reader panicked");
        if let Err(e) = r {
            assert!(e.to_string().contains("broken.vdb"), "{e}");
        }
        tried += 1;
    };
    for len in (0..bytes.len()).step_by(97) {
        check(&bytes[..len]);
    }
    for at in (0..bytes.len()).step_by(61) {
        let mut b = bytes.clone();
        b[at] ^= 0xA5;
        check(&b);
    }
    assert!(tried > 500);
    let e = read_vdb_grid(Path::new("/no/such/file.vdb"), "density", 64).expect_err("missing");
    assert!(e.to_string().contains("/no/such/file.vdb"), "{e}");
    std::fs::write(&path, b"not a vdb file at all").expect("write");
    let e = read_vdb_grid(&path, "density", 64).expect_err("not vdb");
    assert!(e.to_string().contains("not an OpenVDB file"), "{e}");
}

// ---- The VdbVolume node: placement, the texture on the GPU, notes, errors ----

use std::sync::Arc;
use tyndall::eval::{EvalError, EvalOptions, Evaluator, PortValue, Target};
use tyndall::graph::{Graph, ParamValue};
use tyndall::nodes::vdb_volume::{self as vv, Placement, UpAxis, VoxelCenters};

fn placement() -> Placement {
    Placement {
        up_axis: UpAxis::Y,
        voxel_centers: VoxelCenters::OpenVdb,
        translate: [0.0; 3],
        rotate: [0.0; 3],
        scale: [1.0; 3],
        object: glam::DMat4::IDENTITY,
        max_resolution: 256,
    }
}

/// Evaluate a VdbVolume with these parameters: the volume's level 0, its size and box, and the
/// notes; or the error.
#[allow(clippy::type_complexity)]
fn vdb_node(
    gpu: &Arc<tyndall::gpu::Gpu>,
    params: &[(&str, ParamValue)],
) -> Result<(Vec<f32>, [u32; 3], [[f32; 3]; 2], Vec<String>), EvalError> {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let id = g.add_node(&cat, "VdbVolume").expect("node");
    for (k, v) in params {
        g.set_param(&cat, &id, k, v.clone()).expect("param");
    }
    let mut ev = Evaluator::new(registry, gpu.clone());
    let r = ev.evaluate(
        &g,
        &[Target::Port(id.clone(), "volume".into())],
        &EvalOptions::default(),
    )?;
    let notes = r.stats.notes.iter().map(|(_, n)| n.clone()).collect();
    match &r.outputs[&(id, "volume".to_string())] {
        PortValue::Volume(v, b) => {
            let data = gpu.recorder().read_volume(v, 0).expect("read");
            Ok((data, v.size, *b, notes))
        }
        other => panic!("not a volume: {other:?}"),
    }
}

fn text(s: &str) -> ParamValue {
    ParamValue::Text(s.into())
}

/// The voxels themselves on the GPU, in a box half a voxel beyond the outer voxels' positions;
/// `blender` voxel centres move the box half a voxel up every axis.
#[test]
fn the_node_uploads_the_voxels_in_their_box() {
    let gpu = require_gpu!();
    let path = fixture("float.vdb").display().to_string();
    let (data, size, b, notes) = vdb_node(&gpu, &[("path", text(&path))]).expect("evaluate");
    let g = read_vdb_grid(&fixture("float.vdb"), "density", 256).expect("read");
    assert_eq!(size, [3, 4, 5]);
    assert_eq!(data, g.data, "the texture holds the voxels bit for bit");
    assert!(notes.is_empty(), "{notes:?}");
    // Voxel (10, 20, 30) at (3.5, 7, 4.5); the box from half a 0.25 m voxel below it.
    let want = [[3.375, 6.875, 4.375], [4.125, 7.875, 5.625]];
    for k in 0..3 {
        assert!(
            (b[0][k] - want[0][k]).abs() < 1e-5 && (b[1][k] - want[1][k]).abs() < 1e-5,
            "{b:?}"
        );
    }
    let (_, _, bb, _) = vdb_node(
        &gpu,
        &[
            ("path", text(&path)),
            ("voxel_centers", ParamValue::Enum("blender".into())),
        ],
    )
    .expect("blender");
    assert!(
        (bb[0][0] - (b[0][0] + 0.125)).abs() < 1e-5,
        "{bb:?} vs {b:?}"
    );
}

/// `up_axis = z` maps (x, y, z) → (x, z, −y): the texture's y runs along the file's z, its z
/// against the file's y; the CPU reference's texture is what the GPU holds.
#[test]
fn a_z_up_file_is_turned_y_up() {
    let gpu = require_gpu!();
    let g = read_vdb_grid(&fixture("float.vdb"), "density", 256).expect("read");
    let p = Placement {
        up_axis: UpAxis::Z,
        ..placement()
    };
    let placed = vv::place(&g, &p).expect("place");
    assert!(!placed.resampled);
    assert_eq!(placed.dims, [3, 5, 4]);
    // Texel (x, y, z) of the result holds voxel (x, 3 − z, y) of the file: file z is world y,
    // and file y runs against world z.
    let at = |d: &[f32], x: usize, y: usize, z: usize| d[(z * 5 + y) * 3 + x];
    let src = |i: usize, j: usize, k: usize| g.data[(k * 4 + j) * 3 + i];
    for (x, y, z) in [(0, 0, 0), (2, 4, 3), (1, 2, 0), (0, 3, 2)] {
        assert_eq!(
            at(&placed.data, x, y, z),
            src(x, 3 - z, y),
            "texel ({x}, {y}, {z})"
        );
    }
    // World box: x as before, y from the file's z (4.375…5.625), z from −y (−7.875…−6.875).
    let b = placed.bounds;
    assert!(
        (b[0][1] - 4.375).abs() < 1e-5 && (b[1][2] + 6.875).abs() < 1e-5,
        "{b:?}"
    );
    let path = fixture("float.vdb").display().to_string();
    let (data, size, bb, _) = vdb_node(
        &gpu,
        &[
            ("path", text(&path)),
            ("up_axis", ParamValue::Enum("z".into())),
        ],
    )
    .expect("evaluate");
    assert_eq!((data, size, bb), (placed.data, placed.dims, placed.bounds));
}

/// An affine map is resampled: at the voxels' own positions the texture reads their values
/// (within the trilinear weights' rounding), and a rotation by 90° stays exact.
#[test]
fn oblique_grids_are_resampled_and_right_angles_stay_exact() {
    let g = read_vdb_grid(&fixture("affine.vdb"), "density", 256).expect("read");
    let placed = vv::place(&g, &placement()).expect("place");
    assert!(placed.resampled);
    // Voxel (4, 0, 0) (value 2) at 1 + 2 cos 30°, 2, 3 − 2 sin 30°; read the texel there.
    let w = vv::texel_to_world(&g, &placement()).transform_point3(glam::DVec3::new(
        4.0 - g.index_min[0] as f64,
        0.0,
        -g.index_min[2] as f64,
    ));
    let b = placed.bounds;
    let t = [0, 1, 2].map(|k| {
        let f = (w[k] - b[0][k] as f64) / (b[1][k] - b[0][k]) as f64;
        ((f * placed.dims[k] as f64) as usize).min(placed.dims[k] as usize - 1)
    });
    let d = placed.dims.map(|v| v as usize);
    let v = placed.data[(t[2] * d[1] + t[1]) * d[0] + t[0]];
    // The texel's centre is within half a texel of the voxel: the trilinear value is between
    // the voxel's and its empty neighbours'.
    assert!(v > 0.3 && v <= 2.0, "{v}");
    let right = Placement {
        rotate: [0.0, 90.0, 0.0],
        ..placement()
    };
    let f = read_vdb_grid(&fixture("float.vdb"), "density", 256).expect("read");
    let p = vv::place(&f, &right).expect("place");
    assert!(!p.resampled, "a right angle keeps the voxels");
    assert_eq!(p.dims, [5, 4, 3]);
}

/// A grid over `max_resolution` is filtered down and the node says so; a wrong grid, a missing
/// or malformed file and a zero scale are errors naming the node and what is wrong.
#[test]
fn the_node_notes_filtering_and_refuses_bad_input() {
    let gpu = require_gpu!();
    let tiles = fixture("tiles.vdb").display().to_string();
    let (_, size, _, notes) = vdb_node(
        &gpu,
        &[
            ("path", text(&tiles)),
            ("max_resolution", ParamValue::Int(8)),
        ],
    )
    .expect("evaluate");
    assert_eq!(size, [7, 6, 6]);
    assert!(
        notes.len() == 1 && notes[0].contains("filtered down 3×") && notes[0].contains("21×16×16"),
        "{notes:?}"
    );
    let e = vdb_node(&gpu, &[("path", text(&tiles)), ("grid", text("smoke"))]).expect_err("grid");
    assert!(e.bad_input(), "{e}");
    assert!(
        e.to_string().contains("VdbVolume") && e.to_string().contains("its grids: density"),
        "{e}"
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("cut.vdb");
    let bytes = std::fs::read(fixture("tiles.vdb")).expect("read");
    std::fs::write(&bad, &bytes[..bytes.len() / 2]).expect("write");
    let e = vdb_node(&gpu, &[("path", text(&bad.display().to_string()))]).expect_err("cut");
    assert!(e.bad_input() && e.to_string().contains("cut.vdb"), "{e}");
    let e = vdb_node(
        &gpu,
        &[
            ("path", text(&tiles)),
            ("scale", ParamValue::Vec3([1.0, 0.0, 1.0])),
        ],
    )
    .expect_err("scale 0");
    assert!(!e.bad_input() && e.to_string().contains("'scale'"), "{e}");
    let e = vdb_node(&gpu, &[]).expect_err("no path");
    assert!(e.to_string().contains("'path'"), "{e}");
}

/// A sequence follows the frame (`####`), and each frame after the first takes the grid read
/// ahead on a worker thread while the frame before rendered — the same values as reading it.
#[test]
fn a_sequence_follows_the_frame_and_reads_ahead() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let files = ["float.vdb", "tiles.vdb", "half.vdb"];
    for (i, f) in files.iter().enumerate() {
        std::fs::copy(fixture(f), dir.path().join(format!("seq_{:04}.vdb", i + 1))).expect("copy");
    }
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let id = g.add_node(&cat, "VdbVolume").expect("node");
    let pattern = dir.path().join("seq_####.vdb").display().to_string();
    g.set_param(&cat, &id, "path", text(&pattern))
        .expect("path");
    let mut ev = Evaluator::new(registry, gpu.clone());
    let before = vv::prefetch_hits();
    for (i, f) in files.iter().enumerate() {
        let frame = i as i64 + 1;
        let opts = EvalOptions {
            frame: Some(frame),
            time: frame as f64,
            ..Default::default()
        };
        let r = ev
            .evaluate(&g, &[Target::Port(id.clone(), "volume".into())], &opts)
            .expect("evaluate");
        let PortValue::Volume(v, _) = &r.outputs[&(id.clone(), "volume".to_string())] else {
            panic!("a volume");
        };
        let want = read_vdb_grid(&fixture(f), "density", 256).expect("read");
        assert_eq!(v.size, want.dims, "frame {frame}");
        assert_eq!(
            gpu.recorder().read_volume(v, 0).expect("read"),
            want.data,
            "frame {frame}"
        );
    }
    assert_eq!(
        vv::prefetch_hits() - before,
        2,
        "frames 2 and 3 were read ahead"
    );
}

/// On the command line a malformed VDB file is bad input: exit 2, the message naming the node
/// and the file.
#[test]
fn the_cli_exits_2_on_a_malformed_vdb_file() {
    let _gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = dir.path().join("cut.vdb");
    let bytes = std::fs::read(fixture("tiles.vdb")).expect("read");
    std::fs::write(&bad, &bytes[..bytes.len() / 3]).expect("write");
    let preset = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/medium/forest_smoke.ron");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(["render", &preset.display().to_string(), "--size", "32x18"])
        .arg("--set")
        .arg(format!("smoke.path={}", bad.display()))
        .arg("--output-dir")
        .arg(dir.path())
        .output()
        .expect("run tyndall");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("'smoke' (VdbVolume)") && err.contains("cut.vdb"),
        "{err}"
    );
}

/// A glTF file in `dir` with one triangle and an object `smoke` (translated, turned 90° about y,
/// scaled 2×) whose `vdb` extra names `vdb` (relative to the file), as Blender's exporter writes
/// a Volume object's custom property.
fn scene_with_volume_object(dir: &Path, vdb: &str) -> PathBuf {
    use base64::Engine;
    let tri: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let b64 = base64::engine::general_purpose::STANDARD.encode(&tri);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
        "nodes": [{{"name": "ground", "mesh": 0}},
                  {{"name": "smoke", "translation": [1, 2, 3], "rotation": [0, {h}, 0, {h}],
                    "scale": [2, 2, 2], "extras": {{"vdb": "{vdb}"}}}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
        "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0, 0, 0], "max": [1, 0, 1]}}],
        "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
        "buffers": [{{"byteLength": 36, "uri": "data:application/octet-stream;base64,{b64}"}}]}}"#
    );
    let path = dir.join("scene.gltf");
    std::fs::write(&path, json).expect("write glTF");
    path
}

/// Evaluate Scene (`gltf`) → VdbVolume with these parameters at `time`: the volume's level 0,
/// size and box; or the error.
#[allow(clippy::type_complexity)]
fn vdb_object_node(
    gpu: &Arc<tyndall::gpu::Gpu>,
    gltf: &Path,
    params: &[(&str, ParamValue)],
    time: f64,
) -> Result<(Vec<f32>, [u32; 3], [[f32; 3]; 2]), EvalError> {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let scene = g.add_node(&cat, "Scene").expect("scene");
    g.set_param(&cat, &scene, "path", text(&gltf.display().to_string()))
        .expect("path");
    let id = g.add_node(&cat, "VdbVolume").expect("node");
    for (k, v) in params {
        g.set_param(&cat, &id, k, v.clone()).expect("param");
    }
    g.connect(&cat, &format!("{scene}.scene"), &format!("{id}.scene"))
        .expect("edge");
    let mut ev = Evaluator::new(registry, gpu.clone());
    let r = ev.evaluate(
        &g,
        &[Target::Port(id.clone(), "volume".into())],
        &EvalOptions {
            time,
            ..Default::default()
        },
    )?;
    match &r.outputs[&(id, "volume".to_string())] {
        PortValue::Volume(v, b) => {
            let data = gpu.recorder().read_volume(v, 0).expect("read");
            Ok((data, v.size, *b))
        }
        other => panic!("not a volume: {other:?}"),
    }
}

/// Issue #61, item 5: a glTF object whose custom property `vdb` names a file places that file
/// in the object's space — the same texture and box as the object's transform given to the
/// node by hand (translate, rotate, scale) — and its `####` follows the frame. `object` picks
/// the object by name; a wrong name, a scene without one, or `object` without a scene are
/// errors naming what is there.
#[test]
fn a_gltf_object_naming_a_vdb_file_places_it_in_its_space() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tmp");
    std::fs::copy(fixture("float.vdb"), dir.path().join("float.vdb")).expect("copy");
    let gltf = scene_with_volume_object(dir.path(), "float.vdb");
    let (data, size, b) = vdb_object_node(&gpu, &gltf, &[], 0.0).expect("object");
    let by_hand = vdb_node(
        &gpu,
        &[
            ("path", text(&fixture("float.vdb").display().to_string())),
            ("translate", ParamValue::Vec3([1.0, 2.0, 3.0])),
            ("rotate", ParamValue::Vec3([0.0, 90.0, 0.0])),
            ("scale", ParamValue::Vec3([2.0, 2.0, 2.0])),
        ],
    )
    .expect("by hand");
    assert_eq!((&data, size), (&by_hand.0, by_hand.1), "the same texels");
    for k in 0..3 {
        for e in 0..2 {
            // The glTF's quaternion is f32 (sin 45° rounded): the box agrees to its rounding.
            assert!(
                (b[e][k] - by_hand.2[e][k]).abs() < 1e-5,
                "box {b:?} vs by hand {:?}",
                by_hand.2
            );
        }
    }
    // Named, and a sequence: frame 7 reads smoke_0007.vdb.
    std::fs::copy(fixture("tiles.vdb"), dir.path().join("smoke_0007.vdb")).expect("copy");
    let seq = scene_with_volume_object(dir.path(), "smoke_####.vdb");
    let (_, size7, _) =
        vdb_object_node(&gpu, &seq, &[("object", text("smoke"))], 7.0).expect("frame 7");
    let tiles = read_vdb_grid(&fixture("tiles.vdb"), "density", 256).expect("tiles");
    let mut want = tiles.dims;
    want.swap(0, 2); // turned 90° about y: x runs along the file's z
    assert_eq!(size7, want);
    let e = vdb_object_node(&gpu, &gltf, &[("object", text("plume"))], 0.0)
        .expect_err("no such object")
        .to_string();
    assert!(e.contains("'plume'") && e.contains("smoke"), "{e}");
    let e = vdb_node(
        &gpu,
        &[
            ("path", text(&fixture("float.vdb").display().to_string())),
            ("object", text("smoke")),
        ],
    )
    .expect_err("object without a scene")
    .to_string();
    assert!(e.contains("object") && e.contains("no scene"), "{e}");
}
