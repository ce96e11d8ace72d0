//! `VdbVolume`: one scalar grid of an OpenVDB file (smoke, clouds, dust from Houdini, EmberGen,
//! Blender's Mantaflow caches) as a Volume — the density a heterogeneous medium reads.
//!
//! The grid's active bounding box (active voxels and tiles) is densified into a 3D texture
//! (`tyndall_engine::io::read_vdb_grid`; the background outside active voxels), mip-mapped
//! (2×2×2 means, as `NoiseVolume`). A box wider than `max_resolution` along any axis is filtered
//! down by the smallest integer factor f that fits — each texel the mean of f³ voxels — and the
//! node says so (a note on stderr and in `--stats`).
//!
//! **Placement.** A voxel's world position is W · i with
//! W = T(`translate`) · R(`rotate`) · S(`scale`) · U · M · C, where M is the file's own
//! index-to-world map (uniform, scale-translate, affine…), U maps a Z-up file into Tyndall's
//! Y-up world when `up_axis` = `z` — (x, y, z) → (x, z, −y), as glTF exporters do — and C is
//! `voxel_centers`: `openvdb` puts voxel i's value at index i (OpenVDB, Houdini, EmberGen);
//! `blender` at i + ½ (the centre of the cell from i to i + 1: how Cycles renders a Mantaflow
//! cache imported as a Volume object). R applies x, then y, then z (degrees).
//!
//! A Volume is a world-aligned box whose texel (i, j, k) is sampled at the box's point
//! ((i, j, k) + ½) / dims. When W keeps the grid's axes on the world's (any scale, up axis,
//! translation, rotation by multiples of 90°) the texels are the voxels themselves, permuted and
//! flipped — exact. Otherwise (an affine map, an oblique rotation) the grid is resampled
//! trilinearly into the world box around it, at its smallest voxel spacing, at most
//! `max_resolution` texels per side (outside the grid: the background). Outside the box a
//! density reads 0 where `SingleScattering` bounds the medium by it.
//!
//! **Volume objects.** With a `scene` connected, the grid is placed in the space of one of its
//! objects whose custom property `vdb` names a file (glTF `extras`, which Blender's exporter
//! writes; the add-on adds it to each Volume object and smoke domain it exports): `object`
//! names it ("" = the first), W above gains the object's matrix N between the user's transform
//! and the file's, W = T · R · S · N · U · M · C, and the file is the object's unless `path`
//! is set. The object's space is that of the glTF node, Y-up: a file from Blender is Z-up in
//! it (`up_axis` = z, as for a file placed by hand).
//!
//! **Sequences.** With a frame pattern in `path`, each run starts reading the next frame's file on
//! a worker thread, and the next run takes that grid instead of reading it (if its file is
//! unchanged); one frame is held ahead, so memory stays bounded over a long shot.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `scene` | in | Scene | optional: its volume objects place the file (and name it) |
//! | `volume` | out | Volume | the grid and its world box |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `path` | Text | "" | | the `.vdb` file; `####` or `%04d` follows the frame; with a scene, "" = the object's |
//! | `object` | Text | "" | | with a scene: the volume object placing the grid ("" = the first) |
//! | `grid` | Text | density | | the grid to read (a wrong name lists the file's grids) |
//! | `up_axis` | Enum | y | y, z | the file's up axis (`z`: Blender, Houdini set to Z-up) |
//! | `voxel_centers` | Enum | openvdb | openvdb, blender | where a voxel's value sits |
//! | `translate` | Vec3 | (0, 0, 0) | ±1e6 m | moves the grid in the world |
//! | `rotate` | Vec3 | (0, 0, 0) | ±360° | about x, then y, then z |
//! | `scale` | Vec3 | (1, 1, 1) | ±1e6, not 0 | per axis |
//! | `max_resolution` | Int | 256 | 8…1024 texels | widest side of the texture |

use std::path::Path;
use std::sync::Arc;

use glam::{DMat3, DMat4, DVec3};
use tyndall_engine::eval::{KeyInput, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::VdbGrid;
use tyndall_engine::scene::{ScenePart, VolumeObject};

use crate::algorithms::volume_mips;

/// The `VdbVolume` node kind.
pub struct VdbVolume;

tyndall_engine::choice_enum! {
    /// The file's up axis.
    pub enum UpAxis { Y = "y", Z = "z" }
}

tyndall_engine::choice_enum! {
    /// Where a voxel's value sits.
    pub enum VoxelCenters { OpenVdb = "openvdb", Blender = "blender" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        path: String = ParamSpec::text("path", "", "The OpenVDB file (.vdb); a `####` or `%04d` in it is replaced by the frame (simulation caches). With a scene connected, empty = the file its volume object names."),
        object: String = ParamSpec::text("object", "", "With a scene connected: the object (glTF node name) whose custom property `vdb` names the file and whose space places it; empty = the first such object."),
        grid: String = ParamSpec::text("grid", "density", "The grid to read (a scalar float, double or half grid)."),
        up_axis: UpAxis = ParamSpec::choice("up_axis", UpAxis::NAMES, "y", "The file's up axis: z for files from Z-up tools (Blender, Houdini set to Z-up), mapped to Y-up as (x, y, z) → (x, z, −y)."),
        voxel_centers: VoxelCenters = ParamSpec::choice("voxel_centers", VoxelCenters::NAMES, "openvdb", "Where a voxel's value sits: openvdb = at its index coordinate (OpenVDB, Houdini, EmberGen); blender = half a voxel further, at the centre of the cell from i to i + 1 (Cycles with a Mantaflow cache)."),
        translate: [f32; 3] = ParamSpec::vec3("translate", [0.0; 3], -1e6, 1e6, "m", "Moves the grid in the world (after rotate and scale)."),
        rotate: [f32; 3] = ParamSpec::vec3("rotate", [0.0; 3], -360.0, 360.0, "°", "Rotates the grid about x, then y, then z (about the world origin, after scale)."),
        scale: [f32; 3] = ParamSpec::vec3("scale", [1.0; 3], -1e6, 1e6, "", "Scales the grid per axis (about the world origin); 0 is refused."),
        max_resolution: i64 = ParamSpec::int("max_resolution", 256, 8, 1024, "texels", "Widest side of the texture: a larger grid is filtered down by an integer factor (a box mean), and the node says so."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "VdbVolume",
    category: "Medium",
    doc: "One scalar grid of an OpenVDB file (smoke, clouds, dust; a sequence follows the frame) as a mip-mapped Volume placed by the file's transform, up axis and voxel-centre convention.",
    inputs: &[PortSpec::input("scene", &[PortType::Scene], "Optional: the scene whose volume object (custom property `vdb`) names the file and places it in its space.")],
    outputs: &[PortSpec::output("volume", &[PortType::Volume], "The grid's values and its world-space box.")],
    params: Params::SPECS,
})
.scene_parts(&[ScenePart::Volumes])
.files(&[("path", tyndall_engine::eval::FileRole::Read)])
.shaders(&[volume_mips::SHADER]);

/// How the grid is placed in the world (the parameters after the file's own map).
#[derive(Debug, Clone, Copy)]
pub struct Placement {
    /// The file's up axis.
    pub up_axis: UpAxis,
    /// Where a voxel's value sits.
    pub voxel_centers: VoxelCenters,
    /// Translation, m.
    pub translate: [f32; 3],
    /// Rotation about x, y, z, degrees.
    pub rotate: [f32; 3],
    /// Scale per axis.
    pub scale: [f32; 3],
    /// The volume object's matrix (object → world; identity without one).
    pub object: DMat4,
    /// Widest side of a resampled texture.
    pub max_resolution: u32,
}

/// A grid placed in the world: the texture's size, values (x fastest) and world box.
#[derive(Debug, Clone, PartialEq)]
pub struct Placed {
    /// Texels along x, y, z.
    pub dims: [u32; 3],
    /// Values, x fastest, then y, then z.
    pub data: Vec<f32>,
    /// World box `[min, max]`, m.
    pub bounds: [[f32; 3]; 2],
    /// Whether the grid was resampled (its axes are not the world's).
    pub resampled: bool,
}

/// Z-up → Y-up: (x, y, z) → (x, z, −y).
const Z_UP: DMat4 = DMat4::from_cols_array(&[
    1.0, 0.0, 0.0, 0.0, //
    0.0, 0.0, -1.0, 0.0, //
    0.0, 1.0, 0.0, 0.0, //
    0.0, 0.0, 0.0, 1.0,
]);

/// World ← texel coordinates of `grid` (texel a's sample sits at W · a).
pub fn texel_to_world(grid: &VdbGrid, p: &Placement) -> DMat4 {
    let up = match p.up_axis {
        UpAxis::Y => DMat4::IDENTITY,
        UpAxis::Z => Z_UP,
    };
    let r = p.rotate.map(|d| (d as f64).to_radians());
    let rot =
        DMat4::from_rotation_z(r[2]) * DMat4::from_rotation_y(r[1]) * DMat4::from_rotation_x(r[0]);
    let user = DMat4::from_translation(DVec3::from(p.translate.map(f64::from)))
        * rot
        * DMat4::from_scale(DVec3::from(p.scale.map(f64::from)));
    let half = match p.voxel_centers {
        VoxelCenters::OpenVdb => 0.0,
        VoxelCenters::Blender => 0.5,
    };
    let first = DVec3::from(grid.first_sample_index()) + DVec3::splat(half);
    let texel =
        DMat4::from_translation(first) * DMat4::from_scale(DVec3::splat(grid.reduce as f64));
    user * p.object * up * grid.index_to_world * texel
}

/// For each world axis, the texel axis it runs along and whether it runs backwards — when the
/// linear part of `w` maps texel axes onto world axes (one non-zero per column and row; an
/// entry below 1e-6 of the largest counts as zero: a glTF object's f32 quaternion turned by 90°
/// leaves ~1e-8, and 1e-6 of a turn moves a 1,000-voxel grid's far end by 1e-3 voxel).
fn axis_map(w: &DMat3) -> Option<[(usize, bool); 3]> {
    let cols = [w.x_axis, w.y_axis, w.z_axis];
    let big = cols
        .iter()
        .map(|c| c.abs().max_element())
        .fold(0.0, f64::max);
    let mut out = [(usize::MAX, false); 3];
    for (a, c) in cols.iter().enumerate() {
        let nz: Vec<usize> = (0..3).filter(|&o| c[o].abs() > 1e-6 * big).collect();
        let [o] = nz[..] else { return None };
        if out[o].0 != usize::MAX {
            return None;
        }
        out[o] = (a, c[o] < 0.0);
    }
    Some(out)
}

/// CPU reference of the placement: the texture and box the node uploads.
pub fn place(grid: &VdbGrid, p: &Placement) -> Result<Placed, String> {
    let w = texel_to_world(grid, p);
    if !w.is_finite() || w.determinant().abs() < 1e-300 {
        return Err("the grid's placement is singular (a scale of 0?)".into());
    }
    let n = grid.dims.map(|d| d as usize);
    let lin = DMat3::from_mat4(w);
    if let Some(map) = axis_map(&lin) {
        // Exact: world axis o runs along texel axis map[o].0.
        let dims = [0, 1, 2].map(|o| grid.dims[map[o].0]);
        let t = w.w_axis.truncate();
        let mut bounds = [[0.0f32; 3]; 2];
        for o in 0..3 {
            let (a, _) = map[o];
            let step = lin.col(a)[o];
            let ends = [t[o] - 0.5 * step, t[o] + (n[a] as f64 - 0.5) * step];
            bounds[0][o] = ends[0].min(ends[1]) as f32;
            bounds[1][o] = ends[0].max(ends[1]) as f32;
        }
        let mut data = vec![0.0f32; grid.data.len()];
        let d = dims.map(|v| v as usize);
        for z in 0..d[2] {
            for y in 0..d[1] {
                for x in 0..d[0] {
                    let mut src = [0usize; 3];
                    for (o, i) in [x, y, z].into_iter().enumerate() {
                        let (a, back) = map[o];
                        src[a] = if back { n[a] - 1 - i } else { i };
                    }
                    data[(z * d[1] + y) * d[0] + x] =
                        grid.data[(src[2] * n[1] + src[1]) * n[0] + src[0]];
                }
            }
        }
        return Ok(Placed {
            dims,
            data,
            bounds,
            resampled: false,
        });
    }
    // Resampled: the world box around the grid's cells, at its smallest spacing.
    let mut lo = DVec3::splat(f64::MAX);
    let mut hi = DVec3::splat(f64::MIN);
    for k in 0..8 {
        let c = DVec3::new(
            if k & 1 == 0 { -0.5 } else { n[0] as f64 - 0.5 },
            if k & 2 == 0 { -0.5 } else { n[1] as f64 - 0.5 },
            if k & 4 == 0 { -0.5 } else { n[2] as f64 - 0.5 },
        );
        let q = w.transform_point3(c);
        lo = lo.min(q);
        hi = hi.max(q);
    }
    let spacing = [lin.x_axis, lin.y_axis, lin.z_axis]
        .iter()
        .map(|c| c.length())
        .fold(f64::MAX, f64::min);
    let ext = hi - lo;
    let widest = ext.max_element() / spacing;
    let factor = (widest / p.max_resolution.max(1) as f64).max(1.0);
    let dims = [0, 1, 2].map(|o| ((ext[o] / spacing / factor).ceil() as u32).max(1));
    let inv = w.inverse();
    let d = dims.map(|v| v as usize);
    let mut data = vec![grid.background; d[0] * d[1] * d[2]];
    for z in 0..d[2] {
        for y in 0..d[1] {
            for x in 0..d[0] {
                let f = DVec3::new(
                    (x as f64 + 0.5) / d[0] as f64,
                    (y as f64 + 0.5) / d[1] as f64,
                    (z as f64 + 0.5) / d[2] as f64,
                );
                let a = inv.transform_point3(lo + ext * f);
                data[(z * d[1] + y) * d[0] + x] = trilinear(grid, a);
            }
        }
    }
    Ok(Placed {
        dims,
        data,
        bounds: [lo.as_vec3().to_array(), hi.as_vec3().to_array()],
        resampled: true,
    })
}

/// The grid at texel coordinates `a` (samples at integers), trilinear; the background outside
/// the cells (half a texel beyond the outer samples the edge value holds).
fn trilinear(grid: &VdbGrid, a: DVec3) -> f32 {
    let n = grid.dims.map(|d| d as f64);
    if (0..3).any(|k| a[k] < -0.5 || a[k] > n[k] - 0.5) {
        return grid.background;
    }
    let c = [0, 1, 2].map(|k| a[k].clamp(0.0, n[k] - 1.0));
    let i0 = c.map(|v| v.floor() as usize);
    let f = [0, 1, 2].map(|k| c[k] - i0[k] as f64);
    let d = grid.dims.map(|v| v as usize);
    let at = |x: usize, y: usize, z: usize| {
        grid.data[(z.min(d[2] - 1) * d[1] + y.min(d[1] - 1)) * d[0] + x.min(d[0] - 1)] as f64
    };
    let mut v = 0.0;
    for k in 0..8 {
        let (dx, dy, dz) = (k & 1, (k >> 1) & 1, (k >> 2) & 1);
        let wt = (if dx == 1 { f[0] } else { 1.0 - f[0] })
            * (if dy == 1 { f[1] } else { 1.0 - f[1] })
            * (if dz == 1 { f[2] } else { 1.0 - f[2] });
        if wt > 0.0 {
            v += wt * at(i0[0] + dx, i0[1] + dy, i0[2] + dz);
        }
    }
    v as f32
}

/// Sequences: the next frame's grid, read on a worker thread while the current frame renders.
/// One entry (the frame after the last one read) per process, so memory stays bounded over a
/// long shot; an entry is used only if the file's stamp is unchanged.
mod prefetch {
    use std::sync::{Arc, Mutex, OnceLock};
    use tyndall_engine::io::VdbGrid;

    /// What was read ahead: (path, grid, limit, file stamp) and the result.
    type Slot = Option<((String, String, u32, u64), Arc<Mutex<Option<VdbGrid>>>)>;

    fn slot() -> &'static Mutex<Slot> {
        static SLOT: OnceLock<Mutex<Slot>> = OnceLock::new();
        SLOT.get_or_init(|| Mutex::new(None))
    }

    static HITS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

    /// How many runs found their grid read ahead (for tests and `--stats` readers).
    pub fn hits() -> u64 {
        HITS.load(std::sync::atomic::Ordering::Relaxed)
    }

    fn stamp(path: &str) -> u64 {
        tyndall_engine::eval::file_stamp(std::path::Path::new(path))
    }

    /// The grid read ahead for this request, waiting for the worker if it is still reading.
    pub fn take(path: &str, grid: &str, limit: u32) -> Option<VdbGrid> {
        let key = (path.to_string(), grid.to_string(), limit, stamp(path));
        let entry = {
            let mut s = slot().lock().unwrap_or_else(|e| e.into_inner());
            match s.take() {
                Some((k, v)) if k == key => v,
                other => {
                    *s = other;
                    return None;
                }
            }
        };
        let got = entry.lock().unwrap_or_else(|e| e.into_inner()).take();
        if got.is_some() {
            HITS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        got
    }

    /// Start reading `path`'s grid on a worker thread (replacing what was read ahead before).
    pub fn start(path: String, grid: String, limit: u32) {
        if !std::path::Path::new(&path).is_file() {
            return;
        }
        let result = Arc::new(Mutex::new(None));
        // The worker holds the result's lock while it reads, so a `take` waits for it.
        let worker = result.clone();
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let key = (path.clone(), grid.clone(), limit, stamp(&path));
        std::thread::spawn(move || {
            let mut held = worker.lock().unwrap_or_else(|e| e.into_inner());
            let _ = ready_tx.send(());
            *held =
                tyndall_engine::io::read_vdb_grid(std::path::Path::new(&path), &grid, limit).ok();
        });
        let _ = ready_rx.recv();
        *slot().lock().unwrap_or_else(|e| e.into_inner()) = Some((key, result));
    }
}

pub use prefetch::hits as prefetch_hits;

/// The volume object `name` names ("" = the first) among a scene's.
fn volume_object(volumes: &[VolumeObject], name: &str) -> Result<VolumeObject, NodeError> {
    let name = name.trim();
    let found = if name.is_empty() {
        volumes.first()
    } else {
        volumes.iter().find(|v| v.name == name)
    };
    found.cloned().ok_or_else(|| {
        let names: Vec<&str> = volumes.iter().map(|v| v.name.as_str()).collect();
        let have = if names.is_empty() {
            "it has no object with a custom property `vdb` naming a file".to_string()
        } else {
            format!("its volume objects: {}", names.join(", "))
        };
        NodeError::Input {
            port: "scene".into(),
            message: if name.is_empty() {
                format!("the scene has no volume object: {have}")
            } else {
                format!("the scene has no volume object '{name}': {have}")
            },
        }
    })
}

impl NodeKind for VdbVolume {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn volatile_key(&self, key: &KeyInput) -> u64 {
        // The file's stamp (an edited or re-baked cache re-runs the node), and for a sequence
        // the frame's file.
        match Params::from_params(key.params) {
            Ok(p) => {
                let sequence = tyndall_engine::eval::with_frame(&p.path, 0).is_some();
                let path = super::util::frame_path(&p.path, None, key.time);
                let frame = if sequence {
                    key.time.round().to_bits()
                } else {
                    0
                };
                frame ^ tyndall_engine::eval::file_stamp(Path::new(&path))
            }
            Err(_) => 0,
        }
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let prm = Params::from_ctx(ctx)?;
        let object = match ctx.scene_opt("scene")? {
            Some(s) => Some(volume_object(&s.scene.volumes, &prm.object)?),
            None if !prm.object.trim().is_empty() => {
                return Err(NodeError::Param {
                    param: "object".into(),
                    message: format!(
                        "names '{}' but no scene is connected to `scene`",
                        prm.object.trim()
                    ),
                })
            }
            None => None,
        };
        // The file: `path`, else the volume object's (its pattern, and this frame's file).
        let (pattern, path) = match &object {
            Some(o) if prm.path.trim().is_empty() => (o.file.clone(), o.frame_file.clone()),
            _ => (
                prm.path.clone(),
                super::util::frame_path(&prm.path, ctx.frame, ctx.time),
            ),
        };
        if path.trim().is_empty() {
            return Err(NodeError::Param {
                param: "path".into(),
                message:
                    "is empty: set the .vdb file to read (or connect a scene with a volume object)"
                        .into(),
            });
        }
        if prm.scale.contains(&0.0) {
            return Err(NodeError::Param {
                param: "scale".into(),
                message: format!("{:?} has a 0: the grid would have no extent", prm.scale),
            });
        }
        let limit = ctx.side("max_resolution", prm.max_resolution, 3)?;
        ctx.report(0, 2, format!("reading {path}"));
        let grid = match prefetch::take(&path, prm.grid.trim(), limit) {
            Some(g) => g,
            None => tyndall_engine::io::read_vdb_grid(Path::new(&path), prm.grid.trim(), limit)
                .map_err(|e| NodeError::BadFile(e.to_string()))?,
        };
        // A sequence: read the next frame's file while this frame renders.
        if tyndall_engine::eval::with_frame(&pattern, 0).is_some() {
            let next = ctx.frame.unwrap_or(ctx.time.round() as i64) + 1;
            let next_path = super::util::frame_path(&pattern, Some(next), ctx.time);
            prefetch::start(next_path, prm.grid.trim().to_string(), limit);
        }
        if grid.reduce > 1 {
            let [x, y, z] = grid.active_dims;
            ctx.note(format!(
                "grid '{}' of {path} ({x}×{y}×{z} voxels) filtered down {}× to {}×{}×{} texels to fit max_resolution = {limit}",
                grid.name, grid.reduce, grid.dims[0], grid.dims[1], grid.dims[2]
            ));
        }
        let placement = Placement {
            up_axis: prm.up_axis,
            voxel_centers: prm.voxel_centers,
            translate: prm.translate,
            rotate: prm.rotate,
            scale: prm.scale,
            object: object.map_or(DMat4::IDENTITY, |o| o.world.as_dmat4()),
            max_resolution: limit,
        };
        let placed = place(&grid, &placement).map_err(|m| NodeError::Param {
            param: "scale".into(),
            message: m,
        })?;
        ctx.check_bytes(
            "max_resolution",
            placed.dims.iter().map(|&d| u64::from(d)).product::<u64>() * 4,
        )?;
        ctx.report(1, 2, format!("uploading {path}"));
        let v = ctx.gpu.upload_volume(placed.dims, &placed.data)?;
        volume_mips::build(ctx.gpu, &v)?;
        ctx.set("volume", PortValue::Volume(Arc::new(v), placed.bounds));
        Ok(())
    }
}
