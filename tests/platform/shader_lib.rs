//! The shared WGSL library (`shaders/lib/`) against its CPU twins
//! (`tyndall::nodes::algorithms::shader_lib`) and against f64: the decay integral at the limits
//! of σ (0, tiny, the series' switch, large), and the hash bit for bit.

use crate::common;
use tyndall::gpu::{Bind, TexFormat};
use tyndall::nodes::algorithms::shader_lib::{decay_integral, pcg, pixel_jitter};

/// `(1 − e^{−len·m})/m` in f64: the reference.
fn decay_f64(len: f32, m: f32) -> f64 {
    let (len, m) = (len as f64, m as f64);
    if m == 0.0 {
        len
    } else {
        -(-len * m).exp_m1() / m
    }
}

/// (len, m) pairs spanning σ = 0 to σ·len = 10⁹, with points on both sides of the series'
/// switch at len·m = 0.5 and of the old switch at 10⁻³ (where `1 − e^{−x}` lost three digits).
fn cases() -> Vec<(f32, f32)> {
    let mut out = Vec::new();
    for len in [1e-3f32, 0.37, 1.0, 10.0, 1e3] {
        for x in [
            0.0, 1e-12, 1e-9, 1e-6, 9.9e-4, 1e-3, 2e-3, 0.1, 0.499, 0.5, 0.501, 1.0, 7.0, 30.0,
            1e3, 1e9,
        ] {
            out.push((len, x / len));
        }
    }
    out
}

/// Relative error allowed on the CPU: a few f32 roundings (the series' seven multiply-adds, or
/// `exp` and one division), each at most 2⁻²⁴ ≈ 6·10⁻⁸ relative.
const CPU_TOLERANCE: f64 = 5e-7;

#[test]
fn decay_integral_is_accurate_from_zero_to_large_sigma() {
    for (len, m) in cases() {
        let got = decay_integral(len, m) as f64;
        let want = decay_f64(len, m);
        let rel = (got - want).abs() / want;
        assert!(
            rel <= CPU_TOLERANCE,
            "len {len}, m {m}: {got} vs {want} (relative {rel:e})"
        );
    }
    assert_eq!(decay_integral(7.5, 0.0), 7.5, "exactly len at σ = 0");
}

const PROBE: &str = "#import lib/hash\n#import lib/medium\n\
@group(0) @binding(0) var cases: texture_2d<f32>;\n\
@group(0) @binding(1) var out: texture_storage_2d<rgba32float, write>;\n\
@compute @workgroup_size(8, 8)\n\
fn main(@builtin(global_invocation_id) id: vec3<u32>) {\n\
    let size = textureDimensions(cases);\n\
    if id.x >= size.x || id.y >= size.y { return; }\n\
    let c = textureLoad(cases, id.xy, 0);\n\
    let h = pcg(id.x * 2654435761u + 12345u);\n\
    textureStore(out, id.xy, vec4<f32>(decay_integral(c.x, c.y), f32(h >> 16u), f32(h & 65535u), pixel_jitter(id.x, id.y)));\n\
}\n";

/// Relative error allowed on the GPU: WGSL's `exp` is accurate to 3 + 2·|x| ULP only (WGSL §
/// "Floating Point Accuracy"), so for x = len·m a little above the switch (0.5 … 30) the
/// closed form may be off by up to ~60 ULP ≈ 4·10⁻⁶; the series below it is exact arithmetic.
const GPU_TOLERANCE: f64 = 4e-6;

#[test]
fn the_wgsl_library_matches_its_cpu_twins_and_f64() {
    let Some(gpu) = common::gpu() else { return };
    let cases = cases();
    let n = cases.len() as u32;
    let data: Vec<f32> = cases.iter().flat_map(|&(l, m)| [l, m, 0.0, 0.0]).collect();
    let input = gpu.upload(n, 1, 4, &data).expect("upload");
    let out = gpu.texture(n, 1, TexFormat::Rgba32F).expect("texture");
    let shader = tyndall::nodes::shader("test/shader_lib_probe", PROBE);
    gpu.recorder()
        .dispatch(
            shader,
            "main",
            &[
                ("cases", Bind::Texture(&input)),
                ("out", Bind::Storage(&out)),
            ],
            n,
            1,
        )
        .expect("dispatch");
    let got = gpu.recorder().read_texture(&out).expect("read");
    for (i, &(len, m)) in cases.iter().enumerate() {
        let texel = &got[i * 4..i * 4 + 4];
        let want = decay_f64(len, m);
        let rel = (texel[0] as f64 - want).abs() / want;
        assert!(
            rel <= GPU_TOLERANCE,
            "GPU decay_integral(len {len}, m {m}) = {} vs {want} (relative {rel:e})",
            texel[0]
        );
        let h = pcg((i as u32).wrapping_mul(2_654_435_761).wrapping_add(12_345));
        assert_eq!(
            (texel[1] as u32, texel[2] as u32),
            (h >> 16, h & 65_535),
            "pcg differs at {i}"
        );
        assert_eq!(
            texel[3],
            pixel_jitter(i as u32, 0),
            "pixel_jitter differs at {i}"
        );
    }
}
