//! Deep EXR (issue #62): what `io::write_deep_exr` writes, OpenImageIO reads as deep and
//! flattens (`oiiotool --flatten`) to Tyndall's own front-to-back composite; a depth holdout
//! (`oiiotool --deepholdout`) keeps only the samples in front of the held-out depth.

use std::path::Path;
use std::process::Command;

use crate::common;
use tyndall::io::{flatten, write_deep_exr, DeepSample};

const OIIOTOOL: &str = "apt-get install openimageio-tools";

/// A deep picture of `w × h` pixels: slabs of medium of random depths and colours (alpha
/// 1 − transmittance), some pixels ending in an opaque surface, some with no sample at all (a
/// whole line of them too).
fn picture(w: usize, h: usize) -> Vec<Vec<DeepSample>> {
    let mut rng = common::Rng(11);
    (0..w * h)
        .map(|i| {
            if i / w == 1 || i % 7 == 3 {
                return Vec::new();
            }
            let slabs = 1 + (rng.next_f32() * 6.0) as usize;
            let mut z = 0.5 + rng.next_f32();
            let mut out: Vec<DeepSample> = (0..slabs)
                .map(|_| {
                    let len = 0.1 + 2.0 * rng.next_f32();
                    let a = 1.0 - (-0.3 * len).exp();
                    let c = [rng.next_f32(), rng.next_f32(), rng.next_f32()].map(|v| v * a);
                    let s = DeepSample {
                        z,
                        z_back: z + len,
                        rgba: [c[0], c[1], c[2], a],
                    };
                    z += len;
                    s
                })
                .collect();
            if i % 3 == 0 {
                out.push(DeepSample {
                    z,
                    z_back: z,
                    rgba: [0.2, 0.4, 0.1, 1.0],
                });
            }
            out
        })
        .collect()
}

fn oiiotool(args: &[&str]) {
    let o = Command::new("oiiotool")
        .args(args)
        .output()
        .expect("oiiotool runs");
    assert!(
        o.status.success(),
        "oiiotool {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn run(args: &[&str]) -> String {
    let o = Command::new("oiiotool")
        .args(args)
        .output()
        .expect("oiiotool runs");
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn read_rgba(path: &Path) -> Vec<f32> {
    tyndall::io::read_image(path, false)
        .expect("read the flat EXR")
        .data
}

#[test]
fn oiiotool_reads_the_deep_file_and_flattens_it_to_the_same_picture() {
    if !common::tool("oiiotool", "--version", OIIOTOOL) {
        return;
    }
    let (w, h) = (9usize, 5usize);
    let pixels = picture(w, h);
    let dir = tempfile::tempdir().expect("tempdir");
    let deep = dir.path().join("deep.exr");
    write_deep_exr(&deep, (w as u32, h as u32), &pixels).expect("write");
    let deep_s = deep.display().to_string();
    let info = run(&["--info", "-v", &deep_s]);
    assert!(info.contains("deep float openexr"), "{info}");
    assert!(info.contains("R, G, B, A, Z, ZBack"), "{info}");
    let flat = dir.path().join("flat.exr");
    oiiotool(&[
        &deep_s,
        "--flatten",
        "-d",
        "float",
        "-o",
        &flat.display().to_string(),
    ]);
    let got = read_rgba(&flat);
    for (i, p) in pixels.iter().enumerate() {
        let want = flatten(p);
        for c in 0..4 {
            // Both composite the same f32 samples with `over`; only the order of f32 roundings
            // may differ.
            assert!(
                (got[i * 4 + c] - want[c]).abs() <= 1e-6,
                "pixel {i} channel {c}: oiiotool {} vs {}",
                got[i * 4 + c],
                want[c]
            );
        }
    }
    // Held out at depth d: what lies in front of d (a slab straddling d is split, its alpha
    // scaled as a uniform medium's, 1 − (1 − a)^fraction).
    let d = 2.0f32;
    let holdout = dir.path().join("holdout.exr");
    oiiotool(&[
        &deep_s,
        "--deepholdout",
        &make_wall(dir.path(), (w, h), d),
        "--flatten",
        "-d",
        "float",
        "-o",
        &holdout.display().to_string(),
    ]);
    let got = read_rgba(&holdout);
    for (i, p) in pixels.iter().enumerate() {
        let front: Vec<DeepSample> = p
            .iter()
            .filter(|s| s.z < d)
            .map(|s| {
                if s.z_back <= d || s.z_back == s.z {
                    return *s;
                }
                let f = (d - s.z) / (s.z_back - s.z);
                let a = 1.0 - (1.0 - s.rgba[3]).powf(f);
                let k = if s.rgba[3] > 0.0 { a / s.rgba[3] } else { f };
                DeepSample {
                    z: s.z,
                    z_back: d,
                    rgba: [s.rgba[0] * k, s.rgba[1] * k, s.rgba[2] * k, a],
                }
            })
            .collect();
        let want = flatten(&front);
        for c in 0..4 {
            // OpenImageIO splits the straddling slab in doubles and its own log form.
            assert!(
                (got[i * 4 + c] - want[c]).abs() <= 1e-5,
                "held out at {d} m, pixel {i} channel {c}: oiiotool {} vs {}",
                got[i * 4 + c],
                want[c]
            );
        }
    }
}

/// A deep wall at depth `d` over the whole picture (one opaque surface sample per pixel): the
/// holdout matte.
fn make_wall(dir: &Path, (w, h): (usize, usize), d: f32) -> String {
    let path = dir.join("wall.exr");
    let wall = vec![
        vec![DeepSample {
            z: d,
            z_back: d,
            rgba: [0.0, 0.0, 0.0, 1.0],
        }];
        w * h
    ];
    write_deep_exr(&path, (w as u32, h as u32), &wall).expect("write the wall");
    path.display().to_string()
}
