//! `Cryptomatte`: ID mattes of the surfaces the camera sees, as Psyop's Cryptomatte 1.1 lays
//! them out and Blender's compositor and Nuke's Cryptomatte node read them (issue #62).
//!
//! Every sub-pixel sample (`samples` × `samples` per pixel) records the object it sees — a raster
//! pass; the fog has no ID, so a surface seen through fog is what the sample holds (a shallow
//! matte). Each pixel weighs the samples under the pixel filter centred on it and ranks the IDs
//! it saw by weight. Rank k holds
//!
//! ```text
//! id_k       = f32::from_bits(clamp(MurmurHash3_32(name, seed 0)))
//! coverage_k = Σ_{samples seeing id_k} w(s) / Σ_{all samples} w(s),   w(s) = f(dx) f(dy)
//! ```
//!
//! where `clamp` flips bit 23 of a hash whose exponent bits are 0 or 255, so no ID is a
//! denormal, an infinity or a NaN (which GPUs flush and files mangle), and f is the filter:
//! `box` (1 inside ±width/2) or `blackman_harris` (0.35875 − 0.48829 cos v + 0.14128 cos 2v −
//! 0.01168 cos 3v, v = 2π (d / width + ½), over the same support). Coverages of a pixel add up to
//! the share of its filter that sees a surface (1 inside an object, less where the sky shows).
//!
//! Names: an object is its glTF node's name (Blender's object name; every primitive of the node
//! is the one object), a material the glTF material's name (Blender's material); an object
//! without a material has no material ID. Two layers of `ranks` / 2 RGBA layers each,
//! `<view_layer>.CryptoObject00` … and `<view_layer>.CryptoMaterial00` …, channels `R G B A` =
//! (id, coverage) of ranks 2i and 2i + 1. Header attributes, per kind, with key = the first 7
//! hex digits of the hash of the kind's layer name (`ViewLayer.CryptoObject` → `542cafa`):
//! `cryptomatte/<key>/name` (that layer name), `/hash` = `MurmurHash3_32`, `/conversion` =
//! `uint32_to_float32`, `/manifest` (JSON: every name of the scene → the 8 hex digits of its ID's
//! bits).
//!
//! | port | dir | type |
//! |---|---|---|
//! | `scene` | in | Scene (required) |
//! | `layers` | out | Layers — `AovOutput`'s `layers` writes them with their header |
//! | `preview` | out | Image — the first kind's IDs as colours (three bytes of each ID), weighted by coverage; alpha = the share of the filter that sees a surface |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `kinds` | Choice | object_material | object_material, object, material | which IDs |
//! | `ranks` | Int | 6 | 2…16 | ID/coverage pairs per pixel (Blender's "Levels"); an odd count leaves the last layer's second pair 0 |
//! | `samples` | Int | 4 | 1…8 | sub-pixel samples per axis: the quality knob (edges resolve to 1/samples² of coverage) |
//! | `filter` | Choice | blackman_harris | blackman_harris, box | pixel filter |
//! | `filter_width` | Float | 3 | 0.25…6 px | the filter's full support (Cycles' default Blackman–Harris, "1.50 px", spans 3 px) |
//! | `view_layer` | Text | "ViewLayer" | | layer-name prefix, as Blender writes it; empty: none |
//! | `width`, `height` | Int | 0 | 0…16384 px | output size; 0 = the evaluation size |

use std::collections::BTreeMap;
use std::sync::Arc;

use super::util::size_or_default;
use tyndall_engine::eval::{
    LayerSet, NamedLayer, NodeDecl, NodeError, NodeKind, PortValue, RunCtx,
};
use tyndall_engine::gpu::{Bind, GpuTexture, MeshDraw, RasterTarget, Recorder, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::scene::{GpuScene, ScenePart};

/// The `Cryptomatte` node kind.
pub struct Cryptomatte;

tyndall_engine::choice_enum! {
    /// The `kinds` parameter: which IDs the node writes.
    pub enum Kinds { ObjectMaterial = "object_material", Object = "object", Material = "material" }
}

tyndall_engine::choice_enum! {
    /// The `filter` parameter: the pixel filter weighing the sub-pixel samples.
    pub enum Filter { BlackmanHarris = "blackman_harris", Box = "box" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        kinds: Kinds = ParamSpec::choice("kinds", Kinds::NAMES, "object_material", "Which IDs: objects (glTF node names) and materials, or one of them."),
        ranks: i64 = ParamSpec::int("ranks", 6, 2, 16, "", "ID/coverage pairs per pixel (Blender's Levels), two per RGBA layer."),
        samples: i64 = ParamSpec::int("samples", 4, 1, 8, "", "Sub-pixel samples per axis (samples² per pixel): the quality knob."),
        filter: Filter = ParamSpec::choice("filter", Filter::NAMES, "blackman_harris", "Pixel filter: Blackman-Harris (Cycles' default) or box."),
        filter_width: f64 = ParamSpec::float("filter_width", 3.0, 0.25, 6.0, "px", "The filter's full support (Cycles' Blackman-Harris at its default 1.50 px spans 3 px)."),
        view_layer: String = ParamSpec::text("view_layer", "ViewLayer", "Prefix of the layer names, as Blender writes them; empty: none."),
        width: i64 = ParamSpec::int("width", 0, 0, 16384, "px", "Width; 0 uses the evaluation size."),
        height: i64 = ParamSpec::int("height", 0, 0, 16384, "px", "Height; 0 uses the evaluation size."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Cryptomatte",
    category: "Compositing",
    doc: "Cryptomatte ID mattes (object and material names, ranked ID/coverage pairs, manifest) of the surfaces the camera sees, for AovOutput's layers.",
    inputs: &[PortSpec::required("scene", &[PortType::Scene], "The scene seen by its camera.")],
    outputs: &[
        PortSpec::output("layers", &[PortType::Layers], "CryptoObject00… and CryptoMaterial00… with their header (name, hash, conversion, manifest)."),
        PortSpec::output("preview", &[PortType::Image], "The first kind's IDs as colours weighted by coverage (alpha: surface coverage), to look at."),
    ],
    params: Params::SPECS,
})
.shaders(&[IDS, RANKS])
.uniforms(&[IdParams::LAYOUT, RankParams::LAYOUT])
.scene_parts(&[ScenePart::Camera, ScenePart::Geometry]);

const IDS: Shader = crate::shader(
    "cryptomatte/ids",
    include_str!("../shaders/cryptomatte/ids.wgsl"),
);
const RANKS: Shader = crate::shader(
    "cryptomatte/ranks",
    include_str!("../shaders/cryptomatte/ranks.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/cryptomatte/ids.wgsl` (struct `IdParams`).
    pub struct IdParams as "IdParams" {
        /// World → camera clip.
        pub view_proj: [[f32; 4]; 4],
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/cryptomatte/ranks.wgsl` (struct `RankParams`).
    pub struct RankParams as "RankParams" {
        /// Output size, px.
        pub size: [u32; 2],
        /// Sub-pixel samples per axis.
        pub samples: u32,
        /// The layer written: ranks 2·layer and 2·layer + 1.
        pub layer: u32,
        /// Samples the filter reaches past the pixel's own on each side.
        pub reach: u32,
        /// Padding.
        pub _pad1: u32,
        /// Ranks kept.
        pub ranks: u32,
        /// Padding.
        pub _pad0: u32,
    }
}

/// MurmurHash3_x86_32 of `data` with `seed` (Austin Appleby's public-domain reference).
pub fn murmur3_32(data: &[u8], seed: u32) -> u32 {
    const C1: u32 = 0xcc9e_2d51;
    const C2: u32 = 0x1b87_3593;
    let mut h = seed;
    let mut blocks = data.chunks_exact(4);
    for b in &mut blocks {
        let mut k = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        k = k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
        h ^= k;
        h = h.rotate_left(13).wrapping_mul(5).wrapping_add(0xe654_6b64);
    }
    let tail = blocks.remainder();
    if !tail.is_empty() {
        let mut k = 0u32;
        for (i, b) in tail.iter().enumerate() {
            k |= u32::from(*b) << (8 * i);
        }
        h ^= k.wrapping_mul(C1).rotate_left(15).wrapping_mul(C2);
    }
    h ^= data.len() as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// The ID of `name` as stored: MurmurHash3_32 (seed 0) of its UTF-8 bytes with the exponent
/// clamp (bit 23 flipped where the exponent bits are 0 or 255), as the bits of an `f32`.
pub fn id_bits(name: &str) -> u32 {
    let h = murmur3_32(name.as_bytes(), 0);
    let exponent = (h >> 23) & 0xff;
    if exponent == 0 || exponent == 255 {
        h ^ (1 << 23)
    } else {
        h
    }
}

/// The header key of a Cryptomatte layer name: the first 7 hex digits of its hash.
pub fn layer_key(layer: &str) -> String {
    format!("{:08x}", murmur3_32(layer.as_bytes(), 0))[..7].to_string()
}

/// The manifest of `names`: a JSON object name → 8 hex digits of the ID's bits, sorted by name.
pub fn manifest<'a>(names: impl IntoIterator<Item = &'a str>) -> String {
    let map: BTreeMap<&str, String> = names
        .into_iter()
        .filter(|n| !n.is_empty())
        .map(|n| (n, format!("{:08x}", id_bits(n))))
        .collect();
    serde_json::to_string(&map).unwrap_or_else(|_| "{}".into())
}

/// How the sub-pixel samples become ranked pairs.
#[derive(Clone, Copy, Debug)]
pub struct Sampling {
    /// Sub-pixel samples per axis.
    pub samples: u32,
    /// The pixel filter.
    pub filter: Filter,
    /// Its full support, px.
    pub width: f32,
    /// Ranks kept.
    pub ranks: u32,
}

/// The filter's weight at an offset of `d` px from the pixel centre, along one axis (the 2D
/// weight is the product of the two axes').
pub fn filter_weight(filter: Filter, width: f32, d: f32) -> f32 {
    let radius = width / 2.0;
    if d.abs() > radius {
        0.0
    } else if filter == Filter::Box {
        1.0
    } else {
        let v = std::f32::consts::TAU * (d / width + 0.5);
        (0.35875 - 0.48829 * v.cos() + 0.14128 * (2.0 * v).cos() - 0.01168 * (3.0 * v).cos())
            .max(0.0)
    }
}

/// The samples the filter reaches past a pixel's own on each side, and the weight of each sample
/// column (or row) j ∈ [−reach, samples + reach) relative to the pixel's first, at j + reach:
/// the same for every pixel (the `ranks` pass reads it).
pub fn axis_weights(s: &Sampling) -> (u32, Vec<f32>) {
    let n = s.samples as f32;
    let reach = ((s.width / 2.0 - 0.5) * n).ceil().max(0.0) as i64;
    let weights = (-reach..s.samples as i64 + reach)
        .map(|j| filter_weight(s.filter, s.width, (j as f32 + 0.5) / n - 0.5))
        .collect();
    (reach as u32, weights)
}

/// CPU reference of the `ranks` pass: `objects` holds each sample's object index + 1 (0: no
/// surface), `size.0·samples × size.1·samples` of them, rows top to bottom; `table[i]` is object
/// i's ID bits (0: none). Returns `ranks.div_ceil(2)` layers of RGBA per pixel.
pub fn ranks_reference(
    objects: &[u32],
    size: (u32, u32),
    table: &[u32],
    sampling: &Sampling,
) -> Vec<Vec<[f32; 4]>> {
    let Sampling {
        samples,
        filter,
        width,
        ranks,
    } = *sampling;
    let (w, h) = size;
    let (fw, fh) = ((w * samples) as i64, (h * samples) as i64);
    let s = samples as f32;
    let radius = width / 2.0;
    let weight = |d: f32| filter_weight(filter, width, d);
    let layers = ranks.div_ceil(2) as usize;
    let mut out = vec![vec![[0.0f32; 4]; (w * h) as usize]; layers];
    for py in 0..h {
        for px in 0..w {
            let c = ((px as f32 + 0.5) * s, (py as f32 + 0.5) * s);
            let r = radius * s;
            let (x0, x1) = (
                ((c.0 - r).floor() as i64).max(0),
                ((c.0 + r).ceil() as i64).min(fw),
            );
            let (y0, y1) = (
                ((c.1 - r).floor() as i64).max(0),
                ((c.1 + r).ceil() as i64).min(fh),
            );
            let mut seen: Vec<(u32, f32)> = Vec::new();
            let mut total = 0.0f32;
            for y in y0..y1 {
                for x in x0..x1 {
                    let wgt =
                        weight((y as f32 + 0.5 - c.1) / s) * weight((x as f32 + 0.5 - c.0) / s);
                    if wgt <= 0.0 {
                        continue;
                    }
                    total += wgt;
                    let o = objects[(y * fw + x) as usize];
                    let id = if o == 0 { 0 } else { table[o as usize - 1] };
                    if id == 0 {
                        continue;
                    }
                    match seen.iter_mut().find(|(i, _)| *i == id) {
                        Some(e) => e.1 += wgt,
                        None => seen.push((id, wgt)),
                    }
                }
            }
            seen.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            let i = (py * w + px) as usize;
            for (rank, (id, wgt)) in seen.iter().take(ranks as usize).enumerate() {
                let pair = [f32::from_bits(*id), wgt / total];
                out[rank / 2][i][2 * (rank % 2)] = pair[0];
                out[rank / 2][i][2 * (rank % 2) + 1] = pair[1];
            }
        }
    }
    out
}

/// The object seen by each sub-pixel sample (`index + 1`, 0: none) at `size × samples`.
fn sample_objects(
    gpu: &Recorder,
    scene: &GpuScene,
    (w, h): (u32, u32),
) -> Result<GpuTexture, NodeError> {
    let cam = &scene.scene.camera;
    let u = IdParams {
        view_proj: (cam.proj(w as f32 / h as f32) * cam.view()).to_cols_array_2d(),
    };
    let ids = gpu.texture(w, h, TexFormat::R32F)?;
    let draws = scene.draws();
    gpu.raster(
        IDS,
        bytemuck::bytes_of(&u),
        &[RasterTarget {
            texture: &ids,
            clear: [0.0; 4],
        }],
        &MeshDraw {
            vertices: &scene.vertices,
            indices: &scene.indices,
            placements: &scene.placements,
            ranges: &draws,
        },
    )?;
    Ok(ids)
}

/// The `ranks` pass: from `ids` (each sample's object index + 1, `size × samples`) and `table`
/// (object index → ID bits, 0: none), the `ranks.div_ceil(2)` RGBA layers of (id, coverage)
/// pairs at `size` ([`ranks_reference`] is its CPU twin), and the preview of those IDs.
pub fn rank_layers(
    gpu: &Recorder,
    ids: &GpuTexture,
    table: &[u32],
    size: (u32, u32),
    s: &Sampling,
) -> Result<(Vec<GpuTexture>, GpuTexture), NodeError> {
    let table = gpu.buffer_from(table)?;
    let (reach, weights) = axis_weights(s);
    let weights: Vec<u32> = weights.iter().map(|w| w.to_bits()).collect();
    let weights = gpu.buffer_from(&weights)?;
    let preview = gpu.texture(size.0, size.1, TexFormat::Rgba32F)?;
    // Layer 0 writes each pixel's count of distinct IDs, which the later layers read (a texture
    // is never written and read in one dispatch: a 1×1 stand-in takes the other binding).
    let counts = gpu.texture(size.0, size.1, TexFormat::R32F)?;
    let stand_in = gpu.texture(1, 1, TexFormat::R32F)?;
    let mut out = Vec::new();
    for layer in 0..s.ranks.div_ceil(2) {
        let texture = gpu.texture(size.0, size.1, TexFormat::Rgba32F)?;
        let u = RankParams {
            size: [size.0, size.1],
            samples: s.samples,
            layer,
            reach,
            _pad1: 0,
            ranks: s.ranks,
            _pad0: 0,
        };
        gpu.dispatch(
            RANKS,
            "ranks",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("ids", Bind::Texture(ids)),
                ("table", Bind::Buffer(&table)),
                ("out", Bind::Storage(&texture)),
                ("preview", Bind::Storage(&preview)),
                ("weights", Bind::Buffer(&weights)),
                (
                    "count_out",
                    Bind::Storage(if layer == 0 { &counts } else { &stand_in }),
                ),
                (
                    "counts",
                    Bind::Texture(if layer == 0 { &stand_in } else { &counts }),
                ),
            ],
            size.0,
            size.1,
        )?;
        out.push(texture);
    }
    Ok((out, preview))
}

/// The kinds written: (layer name without the rank digits, each object's name of that kind).
fn kinds<'a>(p: &Params, scene: &'a GpuScene) -> Vec<(String, Vec<&'a str>)> {
    let prefix = match p.view_layer.trim() {
        "" => String::new(),
        v => format!("{v}."),
    };
    let objects = &scene.scene.objects;
    let mut out = Vec::new();
    if p.kinds != Kinds::Material {
        let names = objects.iter().map(|o| o.node.as_str()).collect();
        out.push((format!("{prefix}CryptoObject"), names));
    }
    if p.kinds != Kinds::Object {
        let names = objects.iter().map(|o| o.material.as_str()).collect();
        out.push((format!("{prefix}CryptoMaterial"), names));
    }
    out
}

impl NodeKind for Cryptomatte {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let scene = ctx.scene("scene")?;
        let size = size_or_default(ctx, p.width, p.height);
        // Sub-pixel samples as many as the adapter's largest texture allows.
        let limit = ctx.gpu.limits.max_texture_dimension_2d;
        let wanted = p.samples as u32;
        let samples = wanted.min(limit / size.0.max(size.1).max(1)).max(1);
        let ids = sample_objects(ctx.gpu, scene, (size.0 * samples, size.1 * samples))?;
        let mut set = LayerSet::default();
        let filter = Sampling {
            samples,
            filter: p.filter,
            width: p.filter_width as f32,
            ranks: p.ranks as u32,
        };
        let mut preview = None;
        for (name, names) in kinds(&p, scene) {
            let table: Vec<u32> = names
                .iter()
                .map(|n| if n.is_empty() { 0 } else { id_bits(n) })
                .collect();
            let (textures, look) = rank_layers(ctx.gpu, &ids, &table, size, &filter)?;
            preview.get_or_insert(look);
            for (layer, texture) in textures.into_iter().enumerate() {
                set.layers.push(NamedLayer {
                    name: format!("{name}{layer:02}"),
                    channels: ["r", "g", "b", "a"].map(String::from).to_vec(),
                    texture: Arc::new(texture),
                    float: true,
                });
            }
            let key = format!("cryptomatte/{}", layer_key(&name));
            set.attributes.extend([
                (format!("{key}/name"), name.clone()),
                (format!("{key}/hash"), "MurmurHash3_32".into()),
                (format!("{key}/conversion"), "uint32_to_float32".into()),
                (format!("{key}/manifest"), manifest(names.iter().copied())),
            ]);
        }
        if samples < wanted {
            ctx.note(format!(
                "samples {wanted} → {samples}: {}×{} sub-pixel samples would pass the adapter's {limit} px texture limit",
                size.0 * wanted,
                size.1 * wanted
            ));
        }
        ctx.set("layers", PortValue::Layers(Arc::new(set)));
        if let Some(look) = preview {
            ctx.set("preview", PortValue::Image(Arc::new(look)));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The issue's vectors (Blender's and the Cryptomatte specification's).
    #[test]
    fn hashes_match_the_known_vectors() {
        assert_eq!(format!("{:08x}", id_bits("Ball")), "74d3ebe9");
        assert_eq!(format!("{:08x}", id_bits("Occluder.Left")), "1040d0ab");
        assert_eq!(
            format!("{:08x}", murmur3_32(b"ViewLayer.CryptoObject", 0)),
            "542cafaf"
        );
        assert_eq!(layer_key("ViewLayer.CryptoObject"), "542cafa");
        // MurmurHash3_x86_32's published check values (seed 0 and 1 on "", "a", "abcd").
        assert_eq!(murmur3_32(b"", 0), 0);
        assert_eq!(murmur3_32(b"", 1), 0x514e_28b7);
        assert_eq!(murmur3_32(b"a", 0x9747_b28c), 0x7fa0_9ea6);
        assert_eq!(murmur3_32(b"abcd", 0x9747_b28c), 0xf047_8627);
    }

    /// No ID is a denormal, infinity or NaN: the clamp flips bit 23 where the exponent bits
    /// are all 0 or all 1, and leaves every other hash alone.
    #[test]
    fn the_exponent_clamp_keeps_every_id_a_normal_float() {
        for i in 0..20000 {
            let name = format!("object{i}");
            let bits = id_bits(&name);
            assert!(f32::from_bits(bits).is_normal(), "{name}: {bits:08x}");
            let raw = murmur3_32(name.as_bytes(), 0);
            assert_eq!(bits ^ raw, if bits == raw { 0 } else { 1 << 23 });
        }
    }

    #[test]
    fn the_manifest_lists_each_name_once_sorted() {
        let m = manifest(["Ball", "Occluder.Left", "Ball", ""]);
        assert_eq!(m, r#"{"Ball":"74d3ebe9","Occluder.Left":"1040d0ab"}"#);
    }

    /// A pixel half on one object and half on another (box filter, 2×2 samples): two ranks of
    /// coverage ½ each, the larger ID second on a tie.
    #[test]
    fn the_cpu_ranks_split_a_pixel_by_coverage() {
        let objects = [1, 2, 1, 2];
        let table = [id_bits("a"), id_bits("b")];
        let sampling = Sampling {
            samples: 2,
            filter: Filter::Box,
            width: 1.0,
            ranks: 4,
        };
        let out = ranks_reference(&objects, (1, 1), &table, &sampling);
        let px = out[0][0];
        assert_eq!((px[1], px[3]), (0.5, 0.5));
        let (lo, hi) = (table[0].min(table[1]), table[0].max(table[1]));
        assert_eq!((px[0].to_bits(), px[2].to_bits()), (lo, hi));
        assert_eq!(out[1][0], [0.0; 4]);
    }
}
