//! The GPU layer: readback with row padding, the texture pool, size limits, error reporting.

use crate::common;
use tyndall::gpu::{Bind, Shader, TexFormat};

#[test]
fn readback_strips_row_padding_for_odd_widths() {
    let gpu = require_gpu!();
    for (w, h, c) in [(1, 1, 1), (3, 2, 1), (65, 3, 1), (17, 5, 4), (63, 2, 4)] {
        let r = common::random_raster(w, h, c, -10.0, 10.0, (w * 31 + h) as u64);
        let t = gpu.upload(w, h, c, &r.data).expect("upload");
        assert_eq!(
            gpu.recorder().read_texture(&t).expect("readback"),
            r.data,
            "{w}x{h}x{c}"
        );
    }
}

/// A channel count `upload` has no format for, or data of the wrong length, is an error naming
/// both — not a texture of another layout (2 channels used to become RGBA with half the data).
#[test]
fn uploads_of_the_wrong_shape_are_refused() {
    let gpu = require_gpu!();
    for (w, h, c, n) in [(4, 1, 2, 8), (4, 1, 3, 12), (4, 1, 4, 8), (3, 3, 1, 10)] {
        let e = gpu
            .upload(w, h, c, &vec![0.5; n])
            .err()
            .unwrap_or_else(|| panic!("{w}x{h}x{c} with {n} values was accepted"));
        let text = e.to_string();
        assert!(
            matches!(e, tyndall::gpu::GpuError::BadData(_))
                && text.contains(&format!("{n} values")),
            "{text}"
        );
    }
}

/// Read-backs reuse their staging buffers: after the first read-back of a size, more of it (and
/// of a slightly smaller one) create none, and every read gives the texture's values.
#[test]
fn readbacks_reuse_their_staging_buffers() {
    let _ = require_gpu!();
    // A device of its own: other tests' read-backs do not count.
    let gpu = tyndall::gpu::Gpu::new(false).expect("device");
    let r = common::random_raster(200, 100, 4, -1.0, 1.0, 7);
    let t = gpu.upload(200, 100, 4, &r.data).expect("upload");
    let small = common::random_raster(190, 100, 4, -1.0, 1.0, 8);
    let s = gpu.upload(190, 100, 4, &small.data).expect("upload");
    assert_eq!(gpu.recorder().read_texture(&t).expect("read"), r.data);
    let created = gpu.staging_buffers_created();
    for _ in 0..5 {
        assert_eq!(gpu.recorder().read_texture(&t).expect("read"), r.data);
        assert_eq!(gpu.recorder().read_texture(&s).expect("read"), small.data);
    }
    assert_eq!(
        gpu.staging_buffers_created(),
        created,
        "reused, not created"
    );
}

/// `copy`: `o` = `i` + 1 over `o`'s size, in workgroups of 3 × 5; `one`: 7 into the invocation's
/// texel, in workgroups of 1.
const COPY_PLUS_ONE: Shader = Shader {
    stem: "test_only_binds",
    files: &[],
    source: "@group(0) @binding(0) var o: texture_storage_2d<r32float, write>;\n\
             @group(0) @binding(1) var i: texture_2d<f32>;\n\
             @compute @workgroup_size(3, 5) fn copy(@builtin(global_invocation_id) id: vec3<u32>) {\n\
                 let s = textureDimensions(o);\n\
                 if id.x >= s.x || id.y >= s.y { return; }\n\
                 textureStore(o, vec2<i32>(id.xy), textureLoad(i, vec2<i32>(id.xy), 0) + 1.0);\n\
             }\n\
             @compute @workgroup_size(1) fn one(@builtin(global_invocation_id) id: vec3<u32>) {\n\
                 textureStore(o, vec2<i32>(id.xy), vec4<f32>(7.0));\n\
             }",
};

/// A texture a recorded, unsubmitted pass reads goes back to the pool only once its recorder
/// submits: dropped in between, the next upload of its shape gets another texture, so the
/// upload (a queue write, which runs before the next submission) cannot change what the pass
/// reads; one that two recorders' unsubmitted passes read returns once both have submitted. On
/// GL, where every pass is submitted at once, it returns at once.
#[test]
fn a_texture_an_unsubmitted_pass_reads_returns_to_the_pool_after_the_submission() {
    let _ = require_gpu!();
    // A device of its own: its pool counts only this test's textures.
    let gpu = tyndall::gpu::Gpu::new(false).expect("device");
    let batched = gpu.info.backend != wgpu::Backend::Gl
        && std::env::var_os("TYNDALL_TRACE_PASSES").is_none_or(|v| v == "0");
    let shader = COPY_PLUS_ONE;
    let rec = gpu.recorder();
    let input = gpu.upload(5, 3, 1, &[2.0; 15]).expect("upload");
    let out = gpu.texture(5, 3, TexFormat::R32F).expect("texture");
    let binds = [("o", Bind::Storage(&out)), ("i", Bind::Texture(&input))];
    rec.dispatch(shader, "copy", &binds, 5, 3)
        .expect("dispatch");
    drop(input);
    assert_eq!(
        gpu.idle_textures(),
        usize::from(!batched),
        "back in the pool only if its pass was submitted"
    );
    let later = gpu.upload(5, 3, 1, &[9.0; 15]).expect("upload");
    rec.flush().expect("submit");
    assert_eq!(
        gpu.idle_textures(),
        usize::from(batched),
        "the later upload got another texture; the input returned after the submission"
    );
    assert_eq!(
        rec.read_texture(&out).expect("read"),
        vec![3.0; 15],
        "the pass read the input's values, not the later upload's"
    );
    drop(later);
    // Read by two recorders' unsubmitted passes: back once both have submitted.
    let (first, second) = (gpu.recorder(), gpu.recorder());
    let shared = gpu.upload(5, 3, 1, &[4.0; 15]).expect("upload");
    let outs = [0, 1].map(|_| gpu.texture(5, 3, TexFormat::R32F).expect("texture"));
    for (rec, out) in [(&first, &outs[0]), (&second, &outs[1])] {
        let binds = [("o", Bind::Storage(out)), ("i", Bind::Texture(&shared))];
        rec.dispatch(shader, "copy", &binds, 5, 3)
            .expect("dispatch");
    }
    let idle = gpu.idle_textures();
    drop(shared);
    // The recorder that used it last submits first.
    second.flush().expect("submit");
    assert_eq!(
        gpu.idle_textures(),
        idle + usize::from(!batched),
        "not back while the first recorder's pass waits"
    );
    first.flush().expect("submit");
    assert_eq!(gpu.idle_textures(), idle + 1, "back once both submitted");
    for out in &outs {
        assert_eq!(first.read_texture(out).expect("read"), vec![5.0; 15]);
    }
}

#[test]
fn pool_recycles_textures_of_same_size_and_format() {
    let gpu = require_gpu!();
    // A private pool, so parallel tests using the shared context do not disturb the counts.
    let pool = tyndall::gpu::TexturePool::new(gpu.device.clone(), 4, gpu.caps.clone());
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
        files: &[],
        source: "@group(0) @binding(0) var o: texture_storage_2d<r32float, write>;\n@compute @workgroup_size(8, 8) fn main(@builtin(global_invocation_id) id: vec3<u32>) { textureStore(o, vec2<i32>(id.xy), vec4<f32>(1.0)); }",
    };
    let t = gpu.texture(4, 4, TexFormat::R32F).expect("tex");
    // A storage texture of another format than the shader declares: wgpu's pipeline
    // validation refuses the layout (Tyndall's own binding check passes: same kind).
    let wide = gpu.texture(4, 4, TexFormat::Rgba32F).expect("tex");
    let err = gpu
        .recorder()
        .dispatch(shader, "main", &[("o", Bind::Storage(&wide))], 4, 4)
        .expect_err("invalid pipeline");
    assert!(err.to_string().contains("GPU error"), "{err}");
    // The context is usable afterwards and the error was consumed.
    gpu.recorder()
        .dispatch(shader, "main", &[("o", Bind::Storage(&t))], 4, 4)
        .expect("valid dispatch");
    assert_eq!(
        gpu.recorder().read_texture(&t).expect("read"),
        vec![1.0; 16]
    );
}

/// Bindings are named by WGSL variable and checked against what the entry point uses (a name
/// the shader does not declare, or a binding it uses that is missing or of another kind, is
/// refused, naming it), and the workgroup count comes from the
/// entry point's own `@workgroup_size`, not an assumed 8 × 8.
#[test]
fn dispatches_check_bindings_and_read_the_workgroup_size() {
    let gpu = require_gpu!();
    let shader = COPY_PLUS_ONE;
    let out = gpu.texture(7, 11, TexFormat::R32F).expect("tex");
    let input = gpu.upload(7, 11, 1, &vec![2.0; 77]).expect("upload");
    let missing = gpu
        .recorder()
        .dispatch(shader, "copy", &[("o", Bind::Storage(&out))], 7, 11)
        .expect_err("binding 1 missing");
    assert!(
        missing
            .to_string()
            .contains("binding 1 (`i`) is used but not bound"),
        "{missing}"
    );
    let wrong = gpu
        .recorder()
        .dispatch(
            shader,
            "copy",
            &[("o", Bind::Storage(&out)), ("i", Bind::Storage(&input))],
            7,
            11,
        )
        .expect_err("binding 1 of the wrong kind");
    assert!(
        wrong
            .to_string()
            .contains("is a 2D texture but was given a 2D storage texture"),
        "{wrong}"
    );
    let misnamed = gpu
        .recorder()
        .dispatch(
            shader,
            "copy",
            &[("o", Bind::Storage(&out)), ("in", Bind::Texture(&input))],
            7,
            11,
        )
        .expect_err("no binding named `in`");
    assert!(
        misnamed
            .to_string()
            .contains("has no binding `in` (it has `o`, `i`)"),
        "{misnamed}"
    );
    let unknown = gpu
        .recorder()
        .dispatch(shader, "nope", &[("o", Bind::Storage(&out))], 7, 11)
        .expect_err("no such entry point");
    assert!(
        unknown.to_string().contains("no entry point `nope`"),
        "{unknown}"
    );
    // 3 × 5 workgroups over 7 × 11: every texel written (8 × 8 groups would cover it too, so
    // also check a 1 × 1 workgroup covers exactly the invocations asked for).
    gpu.recorder()
        .dispatch(
            shader,
            "copy",
            &[("o", Bind::Storage(&out)), ("i", Bind::Texture(&input))],
            7,
            11,
        )
        .expect("copy");
    assert_eq!(
        gpu.recorder().read_texture(&out).expect("read"),
        vec![3.0; 77]
    );
    gpu.recorder()
        .dispatch(shader, "one", &[("o", Bind::Storage(&out))], 2, 3)
        .expect("one");
    let got = gpu.recorder().read_texture(&out).expect("read");
    let sevens = got.iter().filter(|v| **v == 7.0).count();
    assert_eq!(
        sevens, 6,
        "a 1 × 1 workgroup over 2 × 3 invocations writes 6 texels"
    );
}

/// A node's passes are submitted once: the default preset's multi-pass nodes (the window's
/// shadow map, the MinMax scattering with its pyramid) report one submission each. Not on
/// wgpu's GL backend, which submits every pass alone (see `src/engine/gpu/recorder.rs`).
#[test]
fn a_node_run_is_one_submission_unless_it_reads_back() {
    let gpu = require_gpu!();
    let batched = gpu.info.backend != wgpu::Backend::Gl;
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let graph = tyndall::graph::load_file(&path, registry.catalog()).expect("graph");
    let mut ev = tyndall::eval::Evaluator::new(registry, gpu);
    let target = [tyndall::eval::Target::Port("tonemap".into(), "out".into())];
    let opts = tyndall::eval::EvalOptions {
        size: (32, 18),
        ..Default::default()
    };
    let r = ev.evaluate(&graph, &target, &opts).expect("evaluate");
    let ran: Vec<_> = r.stats.nodes.iter().filter(|n| n.status.ran()).collect();
    assert!(!ran.is_empty());
    for n in ran.iter().filter(|_| batched) {
        assert!(
            n.submits <= 1,
            "{} ({}) submitted {} times",
            n.id,
            n.kind,
            n.submits
        );
    }
    assert!(
        r.stats.to_string().contains("GPU submissions: "),
        "{}",
        r.stats
    );
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

/// `graphs/physical/window.ron` (MinMax visibility: Rg32F pyramids; a shadow map and a G-buffer:
/// raster passes) on `gpu`, at 64×36: every port that matters, read back.
fn window_outputs(gpu: tyndall::gpu::Gpu) -> Vec<(String, tyndall::io::Raster)> {
    let gpu = std::sync::Arc::new(gpu);
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let graph = tyndall::graph::load_file(&path, registry.catalog()).expect("graph");
    let ports = [
        ("shadow", "map"),
        ("gbuffer", "depth"),
        ("gbuffer", "normal"),
        ("gbuffer", "albedo"),
        ("scatter", "visibility"),
        ("scatter", "inscatter"),
        ("tonemap", "out"),
    ];
    let targets: Vec<tyndall::eval::Target> = ports
        .iter()
        .map(|(n, p)| tyndall::eval::Target::Port(n.to_string(), p.to_string()))
        .collect();
    let opts = tyndall::eval::EvalOptions {
        size: (64, 36),
        ..Default::default()
    };
    let mut ev = tyndall::eval::Evaluator::new(registry, gpu.clone());
    let result = ev.evaluate(&graph, &targets, &opts).expect("evaluate");
    ports
        .iter()
        .map(|(n, p)| {
            let v = &result.outputs[&(n.to_string(), p.to_string())];
            (
                format!("{n}.{p}"),
                tyndall::eval::download(&gpu.recorder(), v).expect("download"),
            )
        })
        .collect()
}

/// Two runs' outputs (as [`window_outputs`] lists them) are equal bit for bit, and none is all
/// zero (a comparison of empty pictures would prove nothing).
fn assert_bit_identical(a: &[(String, tyndall::io::Raster)], b: &[(String, tyndall::io::Raster)]) {
    assert!(!a.is_empty() && a.len() == b.len());
    for ((name, x), (_, y)) in a.iter().zip(b) {
        assert_eq!(
            (x.width, x.height, x.channels),
            (y.width, y.height, y.channels),
            "{name}"
        );
        let differing = x
            .data
            .iter()
            .zip(&y.data)
            .filter(|(p, q)| p.to_bits() != q.to_bits())
            .count();
        assert_eq!(differing, 0, "{name}: {differing} samples differ");
        assert!(x.data.iter().any(|v| *v != 0.0), "{name} is not all zero");
    }
}

/// A context on the usual adapter, taking GL's substitutes or not (`TYNDALL_GPU_EMULATE=gl`).
fn gpu_emulating_gl(emulate_gl: bool) -> tyndall::gpu::Gpu {
    tyndall::gpu::Gpu::with_options(&tyndall::gpu::GpuOptions {
        emulate_gl,
        ..tyndall::gpu::GpuOptions::from_env()
    })
    .expect("device")
}

#[test]
fn gl_substitutes_give_bit_identical_results_on_one_adapter() {
    if common::gpu().is_none() {
        return;
    }
    // The same adapter twice: once as usual, once taking every substitute GL needs (Rg32F stored
    // as Rgba32F, rasterisation into integer bit patterns). Both are exact re-encodings, so the
    // results must be equal bit for bit.
    let (usual, emulated) = (gpu_emulating_gl(false), gpu_emulating_gl(true));
    assert_eq!(
        emulated.caps.stored(wgpu::TextureFormat::Rg32Float),
        wgpu::TextureFormat::Rgba32Float
    );
    assert_eq!(
        emulated.caps.render_format(wgpu::TextureFormat::R32Float),
        Some(wgpu::TextureFormat::R32Uint)
    );
    assert_bit_identical(&window_outputs(usual), &window_outputs(emulated));
}

#[test]
fn parameters_as_uniform_or_storage_buffers_give_bit_identical_results() {
    if common::gpu().is_none() {
        return;
    }
    // Mesa's CPU drivers get the passes' parameter blocks as read-only storage buffers (they
    // would compile a variant per dispatch of a uniform block); every other adapter as
    // uniforms. The block's layout and the shaders' arithmetic are the same either way, so
    // one adapter's results must be equal bit for bit.
    let with = |storage: bool| {
        let gpu = tyndall::gpu::Gpu::with_options(&tyndall::gpu::GpuOptions {
            params_in_storage: Some(storage),
            ..tyndall::gpu::GpuOptions::from_env()
        })
        .expect("device");
        assert_eq!(gpu.caps.params_in_storage(1 << 40), storage);
        assert_eq!(gpu.caps.params_in_storage(1), storage);
        window_outputs(gpu)
    };
    assert_bit_identical(&with(false), &with(true));
}

#[test]
fn a_node_whose_shader_needs_more_than_the_adapter_gives_fails_in_one_line() {
    if common::gpu().is_none() {
        return;
    }
    let mut gpu =
        tyndall::gpu::Gpu::with_options(&tyndall::gpu::GpuOptions::from_env()).expect("device");
    // As if the driver allowed two storage textures per stage (GL ES's minimum is 4; some
    // drivers give fewer to compute than SingleScattering's epipolar passes bind).
    gpu.caps.limits.max_storage_textures_per_shader_stage = 2;
    let gpu = std::sync::Arc::new(gpu);
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let graph = tyndall::graph::load_file(&path, registry.catalog()).expect("graph");
    let mut ev = tyndall::eval::Evaluator::new(registry.clone(), gpu);
    let opts = tyndall::eval::EvalOptions {
        size: (32, 18),
        ..Default::default()
    };
    let mut evaluate = |g: &tyndall::graph::Graph, node: &str, port: &str| {
        ev.evaluate(
            g,
            &[tyndall::eval::Target::Port(node.into(), port.into())],
            &opts,
        )
        .map(|_| ())
        .map_err(|e| e.to_string())
    };
    // A refusal names the node, what is missing and what the adapter allows, in one line.
    let refused = |msg: String, node: &str| {
        assert!(msg.starts_with(node), "{msg}");
        assert!(msg.contains("storage textures per shader stage"), "{msg}");
        assert!(msg.contains("allows 2"), "{msg}");
        assert!(!msg.contains('\n'), "one line: {msg}");
    };
    // The shadow map still renders (its passes bind fewer)…
    evaluate(&graph, "shadow", "map").expect("nodes within the limits run");
    // …but SingleScattering is refused before any pass.
    let msg = evaluate(&graph, "scatter", "inscatter").expect_err("SingleScattering needs more");
    refused(msg, "node 'scatter' (SingleScattering): this adapter");
    // A method whose pass needs more (GBuffer's ray cast binds three storage textures) does not
    // refuse the kind — the default raster G-buffer renders — but fails when chosen.
    evaluate(&graph, "gbuffer", "depth").expect("the raster G-buffer runs");
    let mut cast = graph.clone();
    cast.set_param_text(registry.catalog(), "gbuffer", "method", "ray_cast")
        .expect("method");
    let msg = evaluate(&cast, "gbuffer", "depth").expect_err("the ray cast needs three");
    refused(msg, "node 'gbuffer' (GBuffer)");
}

#[test]
fn shader_needs_are_read_from_the_wgsl() {
    let src = "@group(0) @binding(0) var a: texture_2d<f32>;\n\
        @group(0) @binding(1) var o: texture_storage_2d<rg32float, write>;\n\
        @group(0) @binding(2) var p: texture_storage_2d<r32float, write>;\n\
        @compute @workgroup_size(8, 4) fn one(@builtin(global_invocation_id) id: vec3<u32>) { textureStore(o, id.xy, textureLoad(a, id.xy, 0)); }\n\
        @compute @workgroup_size(8, 8) fn two(@builtin(global_invocation_id) id: vec3<u32>) { textureStore(p, id.xy, vec4<f32>(1.0)); }";
    let n = tyndall::gpu::adapter::ShaderNeeds::of(src).expect("parses");
    assert_eq!(n.entries.len(), 2);
    let one = &n.entries[0];
    assert_eq!(
        (
            one.entry.as_str(),
            one.storage_textures,
            one.sampled_textures
        ),
        ("one", 1, 1)
    );
    assert_eq!(one.workgroup, [8, 4, 1]);
    assert_eq!(one.storage_formats, vec![wgpu::TextureFormat::Rg32Float]);
    let two = &n.entries[1];
    assert_eq!((two.storage_textures, two.sampled_textures), (1, 0));
    assert_eq!(two.storage_formats, vec![wgpu::TextureFormat::R32Float]);
}

#[test]
fn the_bit_pattern_entry_point_wraps_every_raster_shader() {
    // Every raster shader a kind declares (a vertex stage): ShadowMap's and the G-buffer's.
    let mut raster = std::collections::BTreeSet::new();
    for kind in tyndall::nodes::registry().iter() {
        for shader in kind.shaders() {
            if shader.source.contains("@vertex") {
                raster.insert(shader.stem);
            }
        }
    }
    assert!(raster.len() >= 2, "raster shaders: {raster:?}");
    for stem in raster {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("shaders/{stem}.wgsl"));
        let src = std::fs::read_to_string(path).expect("shader");
        let m = tyndall::gpu::bits_module(&src).unwrap_or_else(|e| panic!("{stem}: {e}"));
        assert!(m.entry_points.iter().any(|e| e.name == "fs_bits"), "{stem}");
    }
    let err = tyndall::gpu::bits_module(
        "@vertex fn vs() -> @builtin(position) vec4<f32> { return vec4<f32>(0.0); }\n\
         @fragment fn fs() -> @location(0) f32 { return 1.0; }",
    )
    .expect_err("a scalar output is refused");
    assert!(err.contains("vec4<f32>"), "{err}");
}

/// Every volume level the volume presets make (noise and its mip chain, a painted blend volume,
/// soft visibility written slice by slice), evaluated on `gpu` at ¼ of 160×90.
fn volume_levels(gpu: tyndall::gpu::Gpu) -> Vec<(String, Vec<f32>)> {
    use tyndall::eval::{PortValue, Target};
    let gpu = std::sync::Arc::new(gpu);
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut out = Vec::new();
    for preset in [
        "medium/fence_noise",
        "medium/fence_painted",
        "atmosphere/fence_soft_kernels",
    ] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("graphs")
            .join(format!("{preset}.ron"));
        let g = tyndall::graph::load_file(&path, &cat).expect("graph");
        let g = tyndall::eval::proxy::proxy_graph(&g.flatten(&cat).expect("flatten"), &cat, 4);
        let ports: Vec<(String, String)> = g
            .output_types(&cat)
            .into_iter()
            .filter(|(_, t)| {
                matches!(
                    t,
                    tyndall::graph::PortType::Volume | tyndall::graph::PortType::SoftShadow
                )
            })
            .map(|(k, _)| k)
            .collect();
        assert!(!ports.is_empty(), "{preset} has no volume");
        let targets: Vec<Target> = ports
            .iter()
            .map(|(n, p)| Target::Port(n.clone(), p.clone()))
            .collect();
        let opts = tyndall::eval::EvalOptions {
            size: (160, 90),
            ..Default::default()
        };
        let mut ev = tyndall::eval::Evaluator::new(registry.clone(), gpu.clone());
        let r = ev.evaluate(&g, &targets, &opts).expect("evaluate");
        for (n, p) in &ports {
            let (PortValue::Volume(v, _) | PortValue::SoftShadow(v, _)) =
                &r.outputs[&(n.clone(), p.clone())]
            else {
                panic!("{preset} {n}.{p} is not a volume");
            };
            for level in 0..v.mips() {
                let texels = gpu.recorder().read_volume(v, level).expect("read");
                out.push((format!("{preset} {n}.{p} level {level}"), texels));
            }
        }
    }
    out
}

#[test]
fn volumes_written_through_storage_buffers_are_bit_identical_on_one_adapter() {
    if common::gpu().is_none() {
        return;
    }
    // wgpu's GL backend writes one slice of a 3D storage image, so there every volume level is
    // written into a storage buffer that is copied into the texture after the pass. Taken on
    // this adapter too (the GL emulation), it must give the same texels bit for bit as 3D
    // storage textures: the same arithmetic, only where the result is stored differs. Noise
    // builds its mip chain through it, soft visibility one slice per pass.
    let (usual, emulated) = (gpu_emulating_gl(false), gpu_emulating_gl(true));
    assert!(emulated.caps.volume_rows());
    let (a, b) = (volume_levels(usual), volume_levels(emulated));
    assert_eq!(a.len(), b.len());
    assert!(a.len() >= 4, "{} levels", a.len());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert_eq!(x.len(), y.len(), "{name}");
        let differing = x
            .iter()
            .zip(y)
            .filter(|(p, q)| p.to_bits() != q.to_bits())
            .count();
        assert_eq!(
            differing,
            0,
            "{name}: {differing} of {} texels differ",
            x.len()
        );
        // Level 0 of each is written (soft visibility's coarser levels are not: it reads level 0).
        if name.ends_with("level 0") {
            assert!(x.iter().any(|v| *v != 0.0), "{name} is all zero");
        }
    }
}

#[test]
fn a_gl_context_without_compute_is_refused_in_one_line() {
    use tyndall::gpu::adapter::gl_context_lacks;
    // What drivers report as GL_VERSION (wgpu's `driver_info` on its GL backend).
    for ok in [
        "4.5 (Core Profile) Mesa 22.3.6",
        "4.6.0 NVIDIA 580.95.05",
        "4.3 (Core Profile) Mesa 20.0.8",
        "OpenGL ES 3.2 Mesa 22.3.6",
        "OpenGL ES 3.1 NVIDIA 580.95.05",
    ] {
        assert_eq!(gl_context_lacks(ok), None, "{ok}");
    }
    for (bad, api) in [
        ("3.3.0 NVIDIA 580.95.05", "OpenGL 3.3"),
        ("4.1 (Core Profile) Mesa 22.3.6", "OpenGL 4.1"),
        ("OpenGL ES 3.0 Mesa 22.3.6", "OpenGL ES 3.0"),
    ] {
        let why = gl_context_lacks(bad).expect("refused");
        assert!(why.contains(api), "{why}");
        assert!(why.starts_with("compute shaders"), "{why}");
        assert!(!why.contains('\n'), "{why}");
    }
}

/// A pipelined evaluation submits its nodes' passes in chunks of
/// [`tyndall::gpu::CHUNK_PASSES`], not per node, and computes the same picture: a chain of 300
/// Math nodes (one pass each) is at most 300 / 64 + 1 submissions on a batching backend (GL
/// submits every pass alone), and its value equals the unpipelined evaluation's.
#[test]
fn a_pipelined_evaluation_submits_in_chunks_not_per_node() {
    let gpu = require_gpu!();
    let batched = gpu.info.backend != wgpu::Backend::Gl;
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let n = 300;
    let text = tyndall::bench::documents::math_chain(n, false);
    let graph =
        tyndall::graph::load_str(&text, std::path::Path::new("chain.ron"), registry.catalog())
            .expect("chain");
    let target = [tyndall::eval::Target::Port(
        format!("m{}", n - 1),
        "out".into(),
    )];
    let mut values = Vec::new();
    for pipelined in [false, true] {
        let mut ev = tyndall::eval::Evaluator::new(registry.clone(), gpu.clone());
        let opts = tyndall::eval::EvalOptions {
            size: (4, 2),
            pipelined,
            ..Default::default()
        };
        let r = ev.evaluate(&graph, &target, &opts).expect("evaluate");
        let submits = r.stats.submits;
        let ran = r.stats.nodes.iter().filter(|s| s.status.ran()).count();
        assert_eq!(ran, n + 1, "the constant and every Math node ran");
        let most = if !batched {
            u64::MAX
        } else if pipelined {
            (n as u64).div_ceil(tyndall::gpu::CHUNK_PASSES as u64) + 1
        } else {
            n as u64 + 1
        };
        assert!(
            submits <= most && (!pipelined || !batched || submits < 10),
            "pipelined={pipelined}: {submits} submissions (at most {most})"
        );
        let out = r
            .outputs
            .values()
            .next()
            .and_then(|v| v.texture())
            .expect("texture");
        values.push(gpu.recorder().read_texture(out).expect("read"));
    }
    assert_eq!(values[0], values[1]);
    let expected = 0.5 + 0.001 * n as f32;
    assert!(
        values[1].iter().all(|v| (v - expected).abs() < 1e-3),
        "{:?} (expected {expected}: 300 additions of 0.001 in f32)",
        &values[1][..2]
    );
}
