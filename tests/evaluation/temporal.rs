//! Nodes with a history (`TemporalAccumulate`): the GPU equals the CPU reference on a moving
//! camera, a still camera reprojects every pixel onto itself, a frame rendered alone equals the
//! same frame in a sequence, a sequence evaluates each earlier frame once, and the per-frame
//! jitter moves the samples while keeping a frame reproducible; a failure at an earlier frame
//! names that frame.

use crate::common;
use std::sync::Arc;

use tyndall::eval::{download, EvalOptions, Evaluator, Matrices, PortValue, Status, Target};
use tyndall::graph::{load_str, Graph};
use tyndall::io::Raster;
use tyndall::nodes::temporal_accumulate::{reference, Frame};

/// The tree under a low sun, the camera dollying sideways 5 cm a frame (`cam_x` keyed from 8 m
/// at frame 0 to 9 m at frame 20) unless `still`; an 8-step march jittered per frame (`pattern`),
/// accumulated over `frames` with the default clamp.
fn graph(still: bool, pattern: &str, frames: u32) -> Graph {
    graph_with(still, pattern, frames, "neighbourhood")
}

/// [`graph`] with TemporalAccumulate's `clamp`.
fn graph_with(still: bool, pattern: &str, frames: u32, clamp: &str) -> Graph {
    let keys = if still {
        String::new()
    } else {
        r#""scene.cam_x": [(0.0, 8.0, Linear), (20.0, 9.0, Linear)],"#.to_string()
    };
    let text = format!(
        r#"(
    version: 2,
    nodes: {{
        "scene": (kind: "Scene", params: {{"name": "tree", "camera": "custom", "light": "custom", "sun_elevation": 25.0}}),
        "shadow": (kind: "ShadowMap", params: {{"resolution": 256}}),
        "gbuffer": (kind: "GBuffer"),
        "s": (kind: "SingleScattering", params: {{"sigma_t": 0.05, "g": 0.6, "steps": 8, "jitter": 1.0, "jitter_pattern": "{pattern}"}}),
        "acc": (kind: "TemporalAccumulate", params: {{"frames": {frames}, "clamp": "{clamp}"}}),
    }},
    edges: [
        ("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"),
        ("shadow.map", "s.shadow"), ("gbuffer.depth", "s.depth"),
        ("s.inscatter", "acc.image"), ("gbuffer.depth", "acc.depth"),
    ],
    keys: {{ {keys} }},
)"#
    );
    load_str(
        &text,
        std::path::Path::new("temporal.ron"),
        tyndall::nodes::registry().catalog(),
    )
    .expect("graph")
}

const SIZE: (u32, u32) = (64, 36);

fn at(time: f64) -> EvalOptions {
    EvalOptions {
        time,
        size: SIZE,
        ..Default::default()
    }
}

fn evaluator(gpu: &Arc<tyndall::gpu::Gpu>) -> Evaluator {
    Evaluator::new(Arc::new(tyndall::nodes::registry()), gpu.clone())
}

/// The accumulated image and `accepted` at `time`, and the evaluation's earlier-frame runs.
fn accumulated(
    ev: &mut Evaluator,
    gpu: &tyndall::gpu::Gpu,
    g: &Graph,
    time: f64,
) -> (Raster, Raster, usize, Option<Status>) {
    let targets = [
        Target::Port("acc".into(), "image".into()),
        Target::Port("acc".into(), "accepted".into()),
    ];
    let r = ev.evaluate(g, &targets, &at(time)).expect("evaluate");
    let image =
        download(&gpu.recorder(), &r.outputs[&("acc".into(), "image".into())]).expect("image");
    let accepted = download(
        &gpu.recorder(),
        &r.outputs[&("acc".into(), "accepted".into())],
    )
    .expect("accepted");
    (image, accepted, r.stats.earlier_runs, r.stats.status("s"))
}

/// The march's in-scatter, the depth and the camera at `time`, evaluated on their own.
fn frame(
    ev: &mut Evaluator,
    gpu: &tyndall::gpu::Gpu,
    g: &Graph,
    time: f64,
) -> (Raster, Raster, Matrices) {
    let targets = [
        Target::Port("s".into(), "inscatter".into()),
        Target::Port("gbuffer".into(), "depth".into()),
    ];
    let r = ev.evaluate(g, &targets, &at(time)).expect("frame");
    let image = download(
        &gpu.recorder(),
        &r.outputs[&("s".into(), "inscatter".into())],
    )
    .expect("dl");
    let d = &r.outputs[&("gbuffer".into(), "depth".into())];
    let PortValue::Depth(_, camera) = d else {
        panic!("depth is not a Depth value")
    };
    (image, download(&gpu.recorder(), d).expect("dl"), *camera)
}

/// The largest in-scatter value (RGB; alpha is 1 everywhere): the scale errors are read against.
fn rgb_max(r: &Raster) -> f32 {
    r.data
        .chunks(4)
        .flat_map(|p| p[..3].iter())
        .fold(0.0f32, |m, v| m.max(v.abs()))
}

#[test]
fn gpu_equals_the_cpu_reference_on_a_moving_camera() {
    let gpu = require_gpu!();
    fn as_frame(f: &(Raster, Raster, Matrices)) -> Frame<'_> {
        Frame {
            image: &f.0,
            depth: &f.1,
            camera: f.2,
        }
    }
    let mut ev = evaluator(&gpu);
    let g = graph(false, "frame", 4);
    let frames: Vec<_> = [10.0, 9.0, 8.0, 7.0]
        .iter()
        .map(|&t| frame(&mut ev, &gpu, &g, t))
        .collect();
    let earlier: Vec<Frame> = frames[1..].iter().map(as_frame).collect();
    let mut results = Vec::new();
    for clamp in [true, false] {
        let g = graph_with(
            false,
            "frame",
            4,
            if clamp { "neighbourhood" } else { "off" },
        );
        let (got, accepted, _, _) = accumulated(&mut ev, &gpu, &g, 10.0);
        let (want, want_accepted) = reference(&as_frame(&frames[0]), &earlier, 0.05, clamp, 4);
        // f32 arithmetic in a different order: the projection lands within ~1e-5 px of the
        // CPU's, which moves bilinear weights by as much; a texel right at the depth test's
        // threshold could flip, but none does here (the largest difference is printed).
        let scale = rgb_max(&want);
        let diff = common::max_abs_diff(&got, &want);
        eprintln!("clamp {clamp}: image max diff {diff} of {scale}");
        assert!(
            diff <= 1e-4 * scale,
            "clamp {clamp}: max diff {diff} (scale {scale})"
        );
        // `accepted` sums three frames' bilinear weights, each off by the projection's
        // difference in pixels (measured 2.9e-4 in all at most): 1e-3 is three times that.
        let diff = common::max_abs_diff(&accepted, &want_accepted);
        assert!(diff <= 1e-3, "accepted: max diff {diff}");
        // The dolly moves 15 cm over the window: most pixels reproject from every earlier
        // frame, and not all (the image edge the camera moves away from, depth edges).
        let n = (SIZE.0 * SIZE.1) as usize;
        let full = accepted.data.iter().filter(|&&a| a > 0.99).count();
        assert!(
            full > n / 2 && full < n,
            "{full} of {n} pixels fully reprojected"
        );
        assert!(accepted
            .data
            .iter()
            .all(|&a| (0.25 - 1e-6..=1.0 + 1e-6).contains(&a)));
        results.push(got);
    }
    assert_ne!(
        results[0].data, results[1].data,
        "the clamp changes some pixels"
    );
}

#[test]
fn a_still_camera_reprojects_every_pixel_onto_itself() {
    let gpu = require_gpu!();
    // The same picture every frame (jitter fixed on the screen, nothing moves): the mean of four
    // copies is the copy, every earlier texel accepted.
    let g = graph(true, "screen", 4);
    let mut ev = evaluator(&gpu);
    let (got, accepted, _, _) = accumulated(&mut ev, &gpu, &g, 10.0);
    let (input, _, _) = frame(&mut ev, &gpu, &g, 10.0);
    let scale = rgb_max(&input);
    // Bilinear weights of a reprojection onto the texel centre are 1 within f32 rounding of
    // the projection (≈ 1e-5 px), so the mean equals the input within that share of a texel
    // step.
    let diff = common::max_abs_diff(&got, &input);
    assert!(diff <= 1e-4 * scale, "max diff {diff} (scale {scale})");
    let low = accepted.data.iter().fold(1.0f32, |m, &a| m.min(a));
    assert!(low > 0.999, "lowest accepted {low}");
    // One frame: the input passes through.
    let g1 = graph(true, "screen", 1);
    let (one, _, runs, _) = accumulated(&mut ev, &gpu, &g1, 10.0);
    assert_eq!(one.data, input.data);
    assert_eq!(runs, 0, "no earlier frame is evaluated for a window of one");
}

#[test]
fn a_frame_alone_equals_the_same_frame_in_a_sequence() {
    let gpu = require_gpu!();
    let g = graph(false, "frame", 4);
    let mut seq = evaluator(&gpu);
    let mut last = None;
    for t in 6..=10 {
        let (image, _, runs, status) = accumulated(&mut seq, &gpu, &g, t as f64);
        assert_eq!(status, Some(Status::Ran), "frame {t}: the march runs once");
        if t == 6 {
            // The first frame computes its three earlier frames: scene, G-buffer and march
            // each; the shadow map reads the sun and the geometry only (`scene_parts`), which
            // the camera move leaves alone, so this frame's is reused at the earlier ones.
            assert_eq!(runs, 9, "frame {t}");
        } else {
            assert_eq!(runs, 0, "frame {t}: every earlier frame is in the cache");
        }
        last = Some(image);
    }
    let mut alone = evaluator(&gpu);
    let (image, _, runs, _) = accumulated(&mut alone, &gpu, &g, 10.0);
    assert_eq!(
        runs, 9,
        "the same three earlier frames, the shadow map reused"
    );
    assert_eq!(Some(image.data), last.map(|r| r.data), "bit for bit");
}

#[test]
fn per_frame_jitter_moves_the_samples_and_keeps_a_frame_reproducible() {
    let gpu = require_gpu!();
    use tyndall::nodes::single_scattering::jitter_phase;
    // Golden-ratio phases: any four consecutive frames split [0, 1) (as a circle) into gaps of
    // φ³ ≈ 0.236, φ² ≈ 0.382 and φ⁴ ≈ 0.146 (the three-distance theorem), so no two are closer
    // than 0.14.
    for start in [0.0, 7.0, 40.0, 1000.0] {
        let mut p: Vec<f32> = (0..4).map(|k| jitter_phase(start + k as f64)).collect();
        p.sort_by(f32::total_cmp);
        let gaps = p.windows(2).map(|w| w[1] - w[0]).chain([1.0 - p[3] + p[0]]);
        let smallest = gaps.fold(1.0f32, f32::min);
        assert!(smallest > 0.14, "frames from {start}: phases {p:?}");
    }
    assert_eq!(
        jitter_phase(3.0),
        jitter_phase(3.75),
        "the phase is the frame's"
    );
    let g = graph(true, "frame", 1);
    let mut ev = evaluator(&gpu);
    let (a, _, _) = frame(&mut ev, &gpu, &g, 3.0);
    let (b, _, _) = frame(&mut ev, &gpu, &g, 4.0);
    let (a2, _, _) = frame(&mut evaluator(&gpu), &gpu, &g, 3.0);
    assert_ne!(
        a.data, b.data,
        "a still picture changes with the frame's jitter"
    );
    assert_eq!(a.data, a2.data, "and frame 3 is frame 3 in any evaluator");
    let screen = graph(true, "screen", 1);
    let (c, _, _) = frame(&mut ev, &gpu, &screen, 3.0);
    let (d, _, _) = frame(&mut ev, &gpu, &screen, 4.0);
    assert_eq!(
        c.data, d.data,
        "jitter_pattern = screen is the same every frame"
    );
}

#[test]
fn a_render_keeping_what_each_frame_used_holds_one_window() {
    let gpu = require_gpu!();
    let g = graph(false, "frame", 4);
    // As `tyndall render --frames` does: after each frame, keep what it used.
    let mut trimmed = evaluator(&gpu);
    let mut full = evaluator(&gpu);
    let mut bytes = Vec::new();
    for t in 6..=12 {
        let epoch = trimmed.epoch();
        let (image, _, runs, _) = accumulated(&mut trimmed, &gpu, &g, t as f64);
        trimmed.keep_used_since(epoch);
        let (same, _, _, _) = accumulated(&mut full, &gpu, &g, t as f64);
        assert_eq!(image.data, same.data, "frame {t}: trimming changes nothing");
        if t > 6 {
            assert_eq!(runs, 0, "frame {t}: its earlier frames were kept");
        }
        bytes.push((trimmed.cached_bytes(), full.cached_bytes()));
    }
    // The trimmed cache holds the window (four frames' upstream and one accumulation), the
    // same amount every frame; the untrimmed one grows by a frame each frame.
    let (a, b) = (bytes[bytes.len() - 2], bytes[bytes.len() - 1]);
    assert_eq!(a.0, b.0, "trimmed: {bytes:?}");
    assert!(b.1 > a.1 && b.1 > b.0, "untrimmed: {bytes:?}");
}

#[test]
fn a_failure_at_an_earlier_frame_names_that_frame_and_the_node_that_reads_it() {
    // An image sequence with frame 5 only: frame 5 alone renders, but accumulating two frames
    // at frame 5 reads frame 4, whose file is missing.
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let plate = Raster::new(SIZE.0, SIZE.1, 4, 0.25);
    tyndall::io::write_image(
        &dir.path().join("plate_0005.exr"),
        &plate,
        tyndall::io::Precision::F32,
        false,
    )
    .expect("write plate");
    let text = format!(
        r#"(
    version: 2,
    nodes: {{
        "scene": (kind: "Scene", params: {{"name": "tree"}}),
        "gbuffer": (kind: "GBuffer"),
        "plate": (kind: "ImageInput", params: {{"path": "{}"}}),
        "acc": (kind: "TemporalAccumulate", params: {{"frames": 2}}),
    }},
    edges: [
        ("scene.scene", "gbuffer.scene"),
        ("plate.image", "acc.image"), ("gbuffer.depth", "acc.depth"),
    ],
)"#,
        dir.path().join("plate_####.exr").display()
    );
    let g = load_str(
        &text,
        std::path::Path::new("t.ron"),
        tyndall::nodes::registry().catalog(),
    )
    .expect("graph");
    let mut ev = evaluator(&gpu);
    let plate_only = [Target::Port("plate".into(), "image".into())];
    ev.evaluate(&g, &plate_only, &at(5.0))
        .expect("frame 5 on its own reads its file");
    let acc = [Target::Port("acc".into(), "image".into())];
    let err = ev
        .evaluate(&g, &acc, &at(5.0))
        .expect_err("frame 4 is missing")
        .to_string();
    for want in [
        "node 'plate' (ImageInput)",
        "at time 4",
        "1 back",
        "node 'acc' reads",
        "plate_0004.exr",
    ] {
        assert!(err.contains(want), "{want:?} not in: {err}");
    }
}
