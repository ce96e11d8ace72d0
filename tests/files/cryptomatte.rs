//! Cryptomatte (issue #62): the `ranks` pass against its CPU twin, mattes decoded back against
//! each object's own mask (a CPU ray cast of the scene), and against Blender's Cryptomatte render
//! of the same scene (tests/fixtures/cryptomatte, made by scripts/cryptomatte_blender.py).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;
use exr::prelude::{self as exrp, ReadChannels, ReadLayers};
use glam::{Vec3, Vec4Swizzles};
use tyndall::nodes::cryptomatte::{self, Filter, Sampling};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/cryptomatte")
        .join(name)
}

/// Every channel of an EXR as floats, and its string attributes.
struct Exr {
    size: (usize, usize),
    channels: HashMap<String, Vec<f32>>,
    text: BTreeMap<String, String>,
}

fn read_exr(path: &Path) -> Exr {
    let img = exrp::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .expect("read the EXR");
    let layer = img.layer_data;
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let v = match &c.sample_data {
                exrp::FlatSamples::F32(v) => v.clone(),
                exrp::FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
                exrp::FlatSamples::U32(v) => v.iter().map(|x| *x as f32).collect(),
            };
            (String::from_utf8_lossy(c.name.as_slice()).into_owned(), v)
        })
        .collect();
    let text = layer
        .attributes
        .other
        .iter()
        .chain(&img.attributes.other)
        .filter_map(|(k, v)| match v {
            exr::meta::attribute::AttributeValue::Text(t) => Some((
                String::from_utf8_lossy(k.as_slice()).into_owned(),
                String::from_utf8_lossy(t.as_slice()).into_owned(),
            )),
            _ => None,
        })
        .collect();
    Exr {
        size: (layer.size.width(), layer.size.height()),
        channels,
        text,
    }
}

impl Exr {
    /// The manifest of the Cryptomatte layer `name` (`ViewLayer.CryptoObject`).
    fn manifest(&self, name: &str) -> BTreeMap<String, String> {
        let key = self
            .text
            .iter()
            .find(|(k, v)| k.ends_with("/name") && v.as_str() == name)
            .map(|(k, _)| k.trim_end_matches("/name").to_string())
            .unwrap_or_else(|| panic!("no cryptomatte/<key>/name = {name}: {:?}", self.text));
        assert_eq!(self.text[&format!("{key}/hash")], "MurmurHash3_32");
        assert_eq!(self.text[&format!("{key}/conversion")], "uint32_to_float32");
        serde_json::from_str(&self.text[&format!("{key}/manifest")]).expect("manifest JSON")
    }

    /// The reference decoder: the matte of `id` is the sum of the coverages of the ranks that
    /// hold it, over layers `<name>00`, `<name>01`, … (channels r g b a = id, cov, id, cov).
    fn matte(&self, name: &str, id: u32) -> Vec<f32> {
        let n = self.size.0 * self.size.1;
        let mut matte = vec![0.0f32; n];
        for layer in 0.. {
            let ch = |c: &str| self.channels.get(&format!("{name}{layer:02}.{c}"));
            let (Some(r), Some(g), Some(b), Some(a)) = (ch("r"), ch("g"), ch("b"), ch("a")) else {
                assert!(layer > 0, "no layer {name}00");
                break;
            };
            for i in 0..n {
                if r[i].to_bits() == id {
                    matte[i] += g[i];
                }
                if b[i].to_bits() == id {
                    matte[i] += a[i];
                }
            }
        }
        matte
    }
}

/// `tyndall render graphs/comp/cryptomatte.ron` on the fixture scene at 160×90 with `sets`.
fn render(dir: &Path, sets: &[&str]) -> Exr {
    let out = dir.join("crypto.exr");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_tyndall"));
    cmd.arg("render")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/comp/cryptomatte.ron"))
        .arg("--set")
        .arg(format!("scene.path={}", fixture("scene.glb").display()))
        .args(["--size", "160x90", "-o"])
        .arg(&out);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let o = cmd.output().expect("run tyndall");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    read_exr(&out)
}

fn mean_abs(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f32>() / a.len() as f32
}

/// The `ranks` pass on the GPU gives its CPU twin's pairs for a random field of sample IDs
/// (several objects per pixel, some samples on nothing, an object without an ID), both filters.
#[test]
fn gpu_ranks_match_the_cpu_reference() {
    let gpu = require_gpu!();
    let (w, h, samples) = (24u32, 16u32, 3u32);
    let mut rng = common::Rng(7);
    let objects: Vec<u32> = (0..w * h * samples * samples)
        .map(|_| (rng.next_f32() * 7.0) as u32)
        .collect();
    let table: Vec<u32> = ["a", "b", "", "c", "d", "e"]
        .iter()
        .map(|n| {
            if n.is_empty() {
                0
            } else {
                cryptomatte::id_bits(n)
            }
        })
        .collect();
    let data: Vec<f32> = objects.iter().map(|o| *o as f32).collect();
    let ids = gpu
        .upload(w * samples, h * samples, 1, &data)
        .expect("upload");
    for (filter, width) in [(Filter::Box, 1.0), (Filter::BlackmanHarris, 3.0)] {
        let s = Sampling {
            samples,
            filter,
            width,
            ranks: 5,
        };
        let rec = gpu.recorder();
        let (layers, _) =
            cryptomatte::rank_layers(&rec, &ids, &table, (w, h), &s).expect("rank layers");
        let got: Vec<Vec<f32>> = layers
            .iter()
            .map(|t| rec.read_texture(t).expect("read"))
            .collect();
        drop(rec);
        let want = cryptomatte::ranks_reference(&objects, (w, h), &table, &s);
        assert_eq!(got.len(), 3);
        for (l, (g, c)) in got.iter().zip(&want).enumerate() {
            for (i, px) in c.iter().enumerate() {
                for k in 0..4 {
                    let (a, b) = (g[i * 4 + k], px[k]);
                    if k % 2 == 0 {
                        // IDs: the same bits.
                        assert_eq!(a.to_bits(), b.to_bits(), "{filter:?} layer {l} pixel {i}");
                    } else {
                        // Coverage: f32 sums of the same weights in another order.
                        assert!(
                            (a - b).abs() <= 1e-5,
                            "{filter:?} layer {l} pixel {i}: {a} vs {b}"
                        );
                    }
                }
            }
        }
    }
}

/// Each object's bounding sphere (centre, radius), so that a ray tests the triangles of the
/// objects it may meet only.
fn spheres(scene: &tyndall::scene::Scene) -> Vec<(Vec3, f32)> {
    scene
        .objects
        .iter()
        .map(|o| {
            let c = o.positions.iter().copied().sum::<Vec3>() / o.positions.len() as f32;
            let r = o
                .positions
                .iter()
                .map(|p| p.distance(c))
                .fold(0.0, f32::max);
            (c, r * 1.001)
        })
        .collect()
}

/// The first surface a ray meets among the scene's triangles (Möller–Trumbore), by object.
fn first_hit(
    scene: &tyndall::scene::Scene,
    bounds: &[(Vec3, f32)],
    from: Vec3,
    dir: Vec3,
) -> Option<usize> {
    let mut best = (f32::INFINITY, None);
    for (oi, o) in scene.objects.iter().enumerate() {
        let (c, r) = bounds[oi];
        let along = (c - from).dot(dir);
        if (c - from).length_squared() - along * along > r * r {
            continue;
        }
        for t in o.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| o.positions[t[k] as usize]);
            let (e1, e2) = (b - a, c - a);
            let p = dir.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-12 {
                continue;
            }
            let s = from - a;
            let u = s.dot(p) / det;
            let q = s.cross(e1);
            let v = dir.dot(q) / det;
            let d = e2.dot(q) / det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && d > 1e-4 && d < best.0 {
                best = (d, Some(oi));
            }
        }
    }
    best.1
}

/// Each object's matte, decoded, is its own mask: the share of 2×2 sub-pixel rays (box filter)
/// whose first hit is that object, found by a CPU ray cast of the same glTF file.
#[test]
fn mattes_decode_to_each_objects_own_mask() {
    let _gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let exr = render(
        dir.path(),
        &[
            "crypto.filter=box",
            "crypto.filter_width=1",
            "crypto.samples=2",
        ],
    );
    let scene = tyndall::scene::load_gltf(&fixture("scene.glb")).expect("glTF");
    let (w, h) = (160usize, 90usize);
    let cam = scene.camera;
    let inv = (cam.proj(w as f32 / h as f32) * cam.view()).inverse();
    let bounds = spheres(&scene);
    let mut masks = vec![vec![0.0f32; w * h]; scene.objects.len()];
    for py in 0..h {
        for px in 0..w {
            for (sx, sy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let ndc = (
                    2.0 * (px as f32 + sx) / w as f32 - 1.0,
                    1.0 - 2.0 * (py as f32 + sy) / h as f32,
                );
                let far = inv * glam::Vec4::new(ndc.0, ndc.1, 0.5, 1.0);
                let dir = (far.xyz() / far.w - cam.position).normalize();
                if let Some(o) = first_hit(&scene, &bounds, cam.position, dir) {
                    masks[o][py * w + px] += 0.25;
                }
            }
        }
    }
    let manifest = exr.manifest("ViewLayer.CryptoObject");
    for (o, mask) in scene.objects.iter().zip(&masks) {
        let id = u32::from_str_radix(&manifest[&o.node], 16).expect("hex");
        let matte = exr.matte("ViewLayer.CryptoObject", id);
        let err = mean_abs(&matte, mask);
        let area = mask.iter().sum::<f32>();
        let worst = matte
            .iter()
            .zip(mask)
            .filter(|(a, b)| (*a - *b).abs() > 0.3)
            .count();
        eprintln!(
            "{}: area {area:.0} px, mean |matte − mask| {err:.2e}, {worst} pixels off by > 0.3",
            o.node
        );
        // The raster and the ray cast may split a sample lying on an edge differently (one
        // sample = 0.25): a handful of pixels, far under 1 % of the object's area.
        assert!(err <= 2e-3, "{}: mean error {err}", o.node);
        assert!(
            (worst as f32) <= 0.01 * area.max(100.0),
            "{}: {worst} pixels off",
            o.node
        );
    }
}

/// Against Blender: the same manifest entries for every object and material, and each decoded
/// matte close to Blender's (Cycles' Cryptomatte at 256 samples through its default
/// Blackman-Harris 1.50 px filter, which spans 3 px; Tyndall's default filter, at `samples` 8,
/// its high-quality end). Measured: mean |difference| ≤ 4.1e-4 per object and material, IoU of
/// the mattes above ½ ≥ 0.9885 (the 5 px wide pillar); at the default `samples` 4, ≤ 1.5e-3 and
/// ≥ 0.965; with a 1.5 px wide filter, 3–10× larger, which is how the 3 px were found.
#[test]
fn mattes_agree_with_blenders_cryptomatte() {
    let _gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let ours = render(dir.path(), &["crypto.samples=8"]);
    let blender = read_exr(&fixture("blender.exr"));
    assert_eq!(ours.size, blender.size);
    for kind in ["ViewLayer.CryptoObject", "ViewLayer.CryptoMaterial"] {
        let (mo, mb) = (ours.manifest(kind), blender.manifest(kind));
        assert!(!mo.is_empty());
        for (name, hex) in &mo {
            // Blender's hex is the raw hash, ours the clamped ID's bits: equal unless the
            // exponent clamp flipped bit 23 (for none of these names).
            assert_eq!(mb.get(name), Some(hex), "{kind} {name}");
            let id = u32::from_str_radix(hex, 16).expect("hex");
            let (a, b) = (ours.matte(kind, id), blender.matte(kind, id));
            let err = mean_abs(&a, &b);
            let area = b.iter().sum::<f32>();
            let iou = {
                let inter = a
                    .iter()
                    .zip(&b)
                    .filter(|(x, y)| **x > 0.5 && **y > 0.5)
                    .count();
                let union = a
                    .iter()
                    .zip(&b)
                    .filter(|(x, y)| **x > 0.5 || **y > 0.5)
                    .count();
                inter as f32 / union.max(1) as f32
            };
            eprintln!(
                "{kind} {name}: area {area:.0} px, mean |ours − Blender| {err:.2e}, IoU {iou:.4}"
            );
            // Cycles' coverage is a Monte-Carlo estimate (256 samples of its importance-sampled
            // filter) where ours is an 8×8 grid: they differ at edges by its noise, ~1/256 per
            // edge pixel — about 2.5× the worst measured mean.
            assert!(err <= 1e-3, "{kind} {name}: mean difference {err}");
            assert!(iou >= 0.98, "{kind} {name}: IoU {iou}");
        }
    }
}

/// Names and manifests in any script survive the EXR (the exr crate's `Text::from` panics on
/// characters above U+00FF, which glTF object names may hold): written as UTF-8 bytes.
#[test]
fn layer_names_and_header_text_keep_any_unicode_name() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("names.exr");
    let manifest = r#"{"Сарай":"0a1b2c3d","納屋":"11223344"}"#;
    tyndall::io::write_exr_layers(
        &path,
        (2, 1),
        &[tyndall::io::ExrLayer {
            name: "Слой".into(),
            channels: vec![("r".into(), vec![1.0, 2.0])],
            half: false,
        }],
        &tyndall::io::ExrHeader {
            text: vec![("cryptomatte/abc1234/manifest".into(), manifest.into())],
            ..Default::default()
        },
    )
    .expect("write");
    let exr = read_exr(&path);
    assert_eq!(exr.channels["Слой.r"], vec![1.0, 2.0]);
    assert_eq!(exr.text["cryptomatte/abc1234/manifest"], manifest);
}
