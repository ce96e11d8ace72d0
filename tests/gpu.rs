//! The GPU layer: readback with row padding, the texture pool, size limits, error reporting.

mod common;

use tyndall::gpu::{Bind, Shader, TexFormat};

#[test]
fn readback_strips_row_padding_for_odd_widths() {
    let gpu = require_gpu!();
    for (w, h, c) in [(1, 1, 1), (3, 2, 1), (65, 3, 1), (17, 5, 4), (63, 2, 4)] {
        let r = common::random_raster(w, h, c, -10.0, 10.0, (w * 31 + h) as u64);
        let t = gpu.upload(w, h, c, &r.data).expect("upload");
        assert_eq!(
            gpu.read_texture(&t).expect("readback"),
            r.data,
            "{w}x{h}x{c}"
        );
    }
}

#[test]
fn pool_recycles_textures_of_same_size_and_format() {
    let gpu = require_gpu!();
    // A private pool, so parallel tests using the shared context do not disturb the counts.
    let pool = tyndall::gpu::TexturePool::new(gpu.device.clone(), 4);
    let a = pool.acquire(37, 11, TexFormat::R32F);
    let b = pool.acquire(37, 11, TexFormat::R32F);
    assert_eq!(pool.idle(), 0);
    drop((a, b));
    assert_eq!(pool.idle(), 2);
    let c = pool.acquire(37, 11, TexFormat::R32F);
    assert_eq!(
        pool.idle(),
        1,
        "an idle texture of the same shape was reused"
    );
    let d = pool.acquire(37, 11, TexFormat::Rgba32F);
    assert_eq!(
        pool.idle(),
        1,
        "a different format is not taken from the idle list"
    );
    drop((c, d));
    assert_eq!(pool.idle(), 3);
    let many: Vec<_> = (0..6)
        .map(|i| pool.acquire(8 + i, 8, TexFormat::R32F))
        .collect();
    drop(many);
    assert_eq!(pool.idle(), 4, "the pool keeps at most its capacity");
}

#[test]
fn textures_beyond_the_device_limit_are_refused_with_the_limit() {
    let gpu = require_gpu!();
    let limit = gpu.limits.max_texture_dimension_2d;
    let err = gpu
        .texture(limit + 1, 4, TexFormat::R32F)
        .expect_err("too large");
    assert!(err.to_string().contains(&limit.to_string()), "{err}");
    assert!(gpu.texture(0, 4, TexFormat::R32F).is_err());
}

#[test]
fn wgpu_validation_errors_surface_as_errors() {
    let gpu = require_gpu!();
    let shader = Shader {
        stem: "test_only",
        source: "@group(0) @binding(0) var o: texture_storage_2d<r32float, write>;\n@compute @workgroup_size(8, 8) fn main(@builtin(global_invocation_id) id: vec3<u32>) { textureStore(o, vec2<i32>(id.xy), vec4<f32>(1.0)); }",
    };
    let t = gpu.texture(4, 4, TexFormat::R32F).expect("tex");
    // Wrong entry point name: pipeline creation fails validation.
    let err = gpu
        .dispatch(shader, "no_such_entry", &[(0, Bind::Storage(&t))], 4, 4)
        .expect_err("invalid pipeline");
    assert!(err.to_string().contains("GPU error"), "{err}");
    // The context is usable afterwards and the error was consumed.
    gpu.dispatch(shader, "main", &[(0, Bind::Storage(&t))], 4, 4)
        .expect("valid dispatch");
    assert_eq!(gpu.read_texture(&t).expect("read"), vec![1.0; 16]);
}

#[test]
fn a_lost_device_ends_the_evaluation_with_an_error_not_a_hang() {
    if common::gpu().is_none() {
        return;
    }
    // A private device: destroying it must not disturb the tests sharing the process-wide one.
    let gpu = std::sync::Arc::new(tyndall::gpu::Gpu::new(false).expect("device"));
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let graph = tyndall::graph::load_file(&path, registry.catalog()).expect("graph");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut ev = tyndall::eval::Evaluator::new(registry, gpu.clone());
        let target = [tyndall::eval::Target::Port("tonemap".into(), "out".into())];
        let opts = tyndall::eval::EvalOptions {
            size: (32, 18),
            ..Default::default()
        };
        let before = ev.evaluate(&graph, &target, &opts).map(|_| ());
        gpu.simulate_loss();
        ev.clear();
        let after = ev.evaluate(&graph, &target, &opts).map(|_| ());
        let _ = tx.send((before, after));
    });
    // Generous: the two 32×18 evaluations take well under a second; a hang never returns.
    let (before, after) = rx
        .recv_timeout(std::time::Duration::from_secs(120))
        .expect("the evaluation on a lost device returned");
    before.expect("the evaluation before the loss succeeds");
    let err = after.expect_err("the evaluation after the loss fails");
    assert!(err.device_lost(), "reported as a lost device: {err}");
    assert!(err.to_string().contains("lost"), "{err}");
}
