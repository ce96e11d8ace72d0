//! OpenVDB files: one scalar grid densified over its active bounding box, through the patched
//! `vdb-rs` (`vendor/vdb-rs`, PATCHES.md there).
//!
//! What loads: float, double and half grids (`Tree_float_5_4_3`, `Tree_double_5_4_3`,
//! `Tree_half_5_4_3`), half-float storage (`saveFloatAsHalf`), Blosc, zip and uncompressed
//! blocks, file versions 218–225 (OpenVDB 4 to 12 write 222–224), uniform-scale,
//! scale-translate, scale, translation, affine and unitary maps, active voxels and active
//! tiles at every level. Vector, boolean, integer and point grids, frustum maps and
//! multi-buffer trees are refused naming the grid. A malformed or truncated file is an error
//! naming the file, never a panic (`fuzz/fuzz_targets/vdb_read.rs`).
//!
//! Index coordinates: a grid's voxel (i, j, k) is at index (i, j, k); [`VdbGrid::index_to_world`]
//! places index space in the file's world. The dense array holds the box
//! `index_min … index_min + dims·reduce − 1`, x fastest; with `reduce` > 1 each texel is the mean
//! of reduce³ voxels (inactive ones count as the background), centred at
//! `index_min + (reduce − 1)/2 + reduce·texel`.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use glam::DMat4;
use thiserror::Error;

/// Reading a VDB file failed.
#[derive(Debug, Error, Clone)]
pub enum VdbError {
    /// The file cannot be opened, is malformed or truncated, or uses an unsupported feature.
    #[error("cannot read OpenVDB file {path}: {reason}")]
    File {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The file has no grid of that name.
    #[error("{path} has no grid '{grid}' (its grids: {known})")]
    NoGrid {
        /// The file.
        path: PathBuf,
        /// The requested grid.
        grid: String,
        /// The file's grids and their types.
        known: String,
    },
    /// The grid's type or layout cannot be read as a scalar density.
    #[error("{path}, grid '{grid}': {reason}")]
    Grid {
        /// The file.
        path: PathBuf,
        /// The grid.
        grid: String,
        /// Why.
        reason: String,
    },
}

/// A grid's name and its OpenVDB type (e.g. `Tree_float_5_4_3`).
#[derive(Debug, Clone, PartialEq)]
pub struct GridInfo {
    /// The grid's name.
    pub name: String,
    /// Its tree type.
    pub grid_type: String,
    /// Whether its leaves are stored as half floats.
    pub half: bool,
}

/// One scalar grid, densified.
#[derive(Debug, Clone)]
pub struct VdbGrid {
    /// The grid's name.
    pub name: String,
    /// Its tree type.
    pub grid_type: String,
    /// The file's index → world transform (column vectors, world = M · index).
    pub index_to_world: DMat4,
    /// Lowest active index of the active bounding box (voxels and tiles).
    pub index_min: [i32; 3],
    /// Side of the active bounding box, voxels.
    pub active_dims: [u32; 3],
    /// Voxels per texel along each axis (1: every voxel; > 1: filtered down to fit the limit).
    pub reduce: u32,
    /// Texels of [`VdbGrid::data`] along x, y, z.
    pub dims: [u32; 3],
    /// The values, x fastest, then y, then z.
    pub data: Vec<f32>,
    /// The value of every voxel the file does not store (the grid's background).
    pub background: f32,
    /// Active voxels (tiles counted by the voxels they cover).
    pub active_voxels: u64,
}

impl VdbGrid {
    /// Index coordinates of texel (0, 0, 0)'s sample (the centre of its reduce³ block).
    pub fn first_sample_index(&self) -> [f64; 3] {
        let h = (self.reduce as f64 - 1.0) / 2.0;
        self.index_min.map(|v| v as f64 + h)
    }
}

fn file_err(path: &Path, reason: impl std::fmt::Display) -> VdbError {
    VdbError::File {
        path: path.to_path_buf(),
        reason: reason.to_string(),
    }
}

type Reader = vdb_rs::VdbReader<BufReader<File>>;

fn open(path: &Path) -> Result<Reader, VdbError> {
    let f = File::open(path).map_err(|e| file_err(path, e))?;
    guarded(path, || vdb_rs::VdbReader::new(BufReader::new(f)))
}

/// Runs a vdb-rs call; an error or a panic the patches missed becomes an error naming the file.
fn guarded<T>(
    path: &Path,
    f: impl FnOnce() -> Result<T, vdb_rs::ParseError>,
) -> Result<T, VdbError> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(file_err(path, e)),
        Err(_) => Err(file_err(path, "the reader failed on malformed data")),
    }
}

/// The grids of a VDB file, sorted by name.
pub fn vdb_grids(path: &Path) -> Result<Vec<GridInfo>, VdbError> {
    let r = open(path)?;
    let mut grids: Vec<GridInfo> = r
        .grid_descriptors
        .values()
        .map(|d| GridInfo {
            name: d.name.clone(),
            grid_type: d.grid_type.clone(),
            half: d.meta_data.is_half_float(),
        })
        .collect();
    grids.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(grids)
}

/// The scalar types a grid can be densified from.
enum Scalar {
    F32,
    F64,
    F16,
}

fn scalar_type(grid_type: &str) -> Option<Scalar> {
    // A tree type is `Tree_<value>_5_4_3`; files before version 215 append `_HalfFloat` etc.
    let value = grid_type.strip_prefix("Tree_")?.split('_').next()?;
    let layout = grid_type.strip_prefix("Tree_")?.split_once('_')?.1;
    if !layout.starts_with("5_4_3") {
        return None;
    }
    match value {
        "float" => Some(Scalar::F32),
        "double" => Some(Scalar::F64),
        "half" => Some(Scalar::F16),
        _ => None,
    }
}

/// Read grid `grid` of `path` and densify its active bounding box; a box wider than `limit`
/// texels along any axis is filtered down by the smallest integer factor that fits (a box mean).
pub fn read_vdb_grid(path: &Path, grid: &str, limit: u32) -> Result<VdbGrid, VdbError> {
    let mut r = open(path)?;
    let Some(desc) = r.grid_descriptors.get(grid).cloned() else {
        let mut known: Vec<String> = r
            .grid_descriptors
            .values()
            .map(|d| format!("{} ({})", d.name, d.grid_type))
            .collect();
        known.sort();
        return Err(VdbError::NoGrid {
            path: path.to_path_buf(),
            grid: grid.to_string(),
            known: if known.is_empty() {
                "none".into()
            } else {
                known.join(", ")
            },
        });
    };
    let grid_err = |reason: String| VdbError::Grid {
        path: path.to_path_buf(),
        grid: grid.to_string(),
        reason,
    };
    if !desc.instance_parent.is_empty() {
        return Err(grid_err(format!(
            "is an instance of grid '{}'; read that grid",
            desc.instance_parent
        )));
    }
    let Some(kind) = scalar_type(&desc.grid_type) else {
        return Err(grid_err(format!(
            "is a {} grid; VdbVolume reads scalar float, double or half grids",
            desc.grid_type
        )));
    };
    let limit = limit.max(1);
    let densify = |r: &mut Reader| -> Result<VdbGrid, VdbError> {
        match kind {
            Scalar::F32 => {
                let g = guarded(path, || r.read_grid::<f32>(grid))?;
                dense(&g, |v| v, limit, &desc.grid_type).map_err(grid_err)
            }
            Scalar::F64 => {
                let g = guarded(path, || r.read_grid::<f64>(grid))?;
                dense(&g, |v| v as f32, limit, &desc.grid_type).map_err(grid_err)
            }
            Scalar::F16 => {
                let g = guarded(path, || r.read_grid::<half::f16>(grid))?;
                dense(&g, half::f16::to_f32, limit, &desc.grid_type).map_err(grid_err)
            }
        }
    };
    densify(&mut r)
}

/// Every leaf node of `g` (the 8³ blocks of voxels under the internal nodes).
fn leaves<T: Copy>(g: &vdb_rs::Grid<T>) -> impl Iterator<Item = &vdb_rs::Node3<T>> {
    g.tree.root_nodes.iter().flat_map(|n5| {
        n5.child_mask
            .iter_ones()
            .filter_map(|c5| n5.nodes.get(&(c5 as u32)))
            .flat_map(|n4| {
                n4.child_mask
                    .iter_ones()
                    .filter_map(|c4| n4.nodes.get(&(c4 as u32)))
            })
    })
}

/// The active bounding box of `g` (inclusive) and its number of active voxels: a leaf whose 512
/// voxels are all active counts as its cube, others voxel by voxel; tiles as in
/// [`for_each_active`].
fn active_bounds<T: Copy>(g: &vdb_rs::Grid<T>) -> ([i32; 3], [i32; 3], u64) {
    let (mut lo, mut hi) = ([i32::MAX; 3], [i32::MIN; 3]);
    let mut active = 0u64;
    let mut add = |o: [i32; 3], s: i32, n: u64| {
        for a in 0..3 {
            lo[a] = lo[a].min(o[a]);
            hi[a] = hi[a].max(o[a].saturating_add(s - 1));
        }
        active += n;
    };
    for leaf in leaves(g) {
        let o = leaf.origin.to_array();
        if leaf.value_mask.count_ones() == 512 {
            add(o, 8, 512);
            continue;
        }
        for v in leaf.value_mask.iter_ones() {
            let (x, y, z) = ((v >> 6) as i32, ((v >> 3) & 7) as i32, (v & 7) as i32);
            add([o[0] + x, o[1] + y, o[2] + z], 1, 1);
        }
    }
    // The tiles.
    for_tiles(g, &mut |o, s, _| add(o, s, (s as u64).pow(3)));
    (lo, hi, active)
}

/// Call `f(origin, side, value)` for every active item of `g`: each active voxel of a leaf
/// (side 1), each active tile of an internal node (8 or 128) and of the root (4096) — what
/// vdb-rs's `GridIter` yields, in the same order within a node, with the same value lookup.
fn for_each_active<T: Copy>(g: &vdb_rs::Grid<T>, f: &mut dyn FnMut([i32; 3], i32, T)) {
    for leaf in leaves(g) {
        let o = leaf.origin.to_array();
        for v in leaf.value_mask.iter_ones() {
            let Some(value) = leaf.buffer.get(v) else {
                continue;
            };
            // A leaf's offset runs z fastest, then y, then x.
            let (x, y, z) = ((v >> 6) as i32, ((v >> 3) & 7) as i32, (v & 7) as i32);
            f([o[0] + x, o[1] + y, o[2] + z], 1, *value);
        }
    }
    for_tiles(g, f);
}

/// Call `f(origin, side, value)` for every active tile of `g`: an internal node's (8 or 128
/// voxels wide) and the root's (4096).
fn for_tiles<T: Copy>(g: &vdb_rs::Grid<T>, f: &mut dyn FnMut([i32; 3], i32, T)) {
    use vdb_rs::{Index, Node};
    // Before node-mask compression an internal node stored only its non-child values.
    let old = g.descriptor.file_version < vdb_rs::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION;
    for n5 in &g.tree.root_nodes {
        for c5 in n5.child_mask.iter_ones() {
            let Some(n4) = n5.nodes.get(&(c5 as u32)) else {
                continue;
            };
            for t in n4.value_mask.iter_ones() {
                let k = if old {
                    n4.child_mask
                        .iter()
                        .by_vals()
                        .take(t)
                        .filter(|c| !c)
                        .count()
                } else {
                    t
                };
                if let Some(value) = n4.data.get(k) {
                    f(
                        n4.offset_to_global_coord(Index(t as u32)).0.to_array(),
                        8,
                        *value,
                    );
                }
            }
        }
        for t in n5.value_mask.iter_ones() {
            if let Some(value) = n5.data.get(t) {
                f(
                    n5.offset_to_global_coord(Index(t as u32)).0.to_array(),
                    128,
                    *value,
                );
            }
        }
    }
    for t in g.tree.tiles.iter().filter(|t| t.active) {
        f(t.origin.to_array(), ROOT_TILE, t.value);
    }
}

/// The unfiltered densify: each leaf of `g` written straight into `data` (the box from `lo`,
/// `dims` texels, x fastest; a leaf's buffer runs z fastest) — a full leaf without looking at
/// its mask — then the tiles.
fn fill_unfiltered<T: Copy>(
    g: &vdb_rs::Grid<T>,
    to_f32: &impl Fn(T) -> f32,
    data: &mut [f32],
    lo: [i32; 3],
    dims: [u32; 3],
) {
    let (d0, d1) = (dims[0] as i64, dims[1] as i64);
    let lo64 = lo.map(i64::from);
    for leaf in leaves(g) {
        let o = leaf.origin.to_array().map(i64::from);
        let base = ((o[2] - lo64[2]) * d1 + (o[1] - lo64[1])) * d0 + (o[0] - lo64[0]);
        let full = leaf.value_mask.count_ones() == 512 && leaf.buffer.len() >= 512;
        let mut put = |v: usize, value: T| {
            let (x, y, z) = ((v >> 6) as i64, ((v >> 3) & 7) as i64, (v & 7) as i64);
            data[(base + (z * d1 + y) * d0 + x) as usize] = to_f32(value);
        };
        if full {
            for (v, value) in leaf.buffer.iter().take(512).enumerate() {
                put(v, *value);
            }
        } else {
            for v in leaf.value_mask.iter_ones() {
                if let Some(value) = leaf.buffer.get(v) {
                    put(v, *value);
                }
            }
        }
    }
    for_tiles(g, &mut |o, s, v| {
        let v = to_f32(v);
        let o = o.map(i64::from);
        for z in o[2]..o[2] + s as i64 {
            for y in o[1]..o[1] + s as i64 {
                let row = ((z - lo64[2]) * d1 + (y - lo64[1])) * d0 - lo64[0];
                for x in o[0]..o[0] + s as i64 {
                    data[(row + x) as usize] = v;
                }
            }
        }
    });
}

/// The largest box side densified before filtering, voxels (a root tile is 4096 wide).
const ROOT_TILE: i32 = 4096;

fn dense<T: Copy>(
    g: &vdb_rs::Grid<T>,
    to_f32: impl Fn(T) -> f32,
    limit: u32,
    grid_type: &str,
) -> Result<VdbGrid, String> {
    // Every active item: (origin, side, value), walked leaf by leaf (not voxel by voxel through
    // vdb-rs's `GridIter`, whose per-voxel bookkeeping was most of a 256³ grid's load).
    let items = |f: &mut dyn FnMut([i32; 3], i32, T)| for_each_active(g, f);
    let (lo, hi, active) = active_bounds(g);
    let background = to_f32(g.tree.background);
    let index_to_world = g.transform.index_to_world();
    if !index_to_world.is_finite() || index_to_world.determinant().abs() < 1e-300 {
        return Err("its transform is singular or not finite".into());
    }
    if active == 0 {
        // An empty grid: one background texel at the origin.
        return Ok(VdbGrid {
            name: g.descriptor.name.clone(),
            grid_type: grid_type.to_string(),
            index_to_world,
            index_min: [0; 3],
            active_dims: [0; 3],
            reduce: 1,
            dims: [1; 3],
            data: vec![background],
            background,
            active_voxels: 0,
        });
    }
    let side = [0, 1, 2].map(|a| (hi[a] as i64 - lo[a] as i64 + 1) as u64);
    let widest = side.iter().copied().max().unwrap_or(1);
    let reduce = widest.div_ceil(limit as u64).max(1);
    let dims = side.map(|s| s.div_ceil(reduce) as u32);
    let n = dims.iter().map(|d| *d as u64).product::<u64>();
    if n > 1 << 31 {
        return Err(format!("its dense box of {dims:?} texels is too large"));
    }
    let r = reduce as i64;
    // Unfiltered, a texel no active item sets holds the background; filtered, the sums start at 0.
    let mut data = vec![if reduce > 1 { 0.0 } else { background }; n as usize];
    let (d0, d1) = (dims[0] as i64, dims[1] as i64);
    let lo64 = lo.map(i64::from);
    if reduce == 1 {
        fill_unfiltered(g, &to_f32, &mut data, lo, dims);
        return Ok(VdbGrid {
            name: g.descriptor.name.clone(),
            grid_type: grid_type.to_string(),
            index_to_world,
            index_min: lo,
            active_dims: side.map(|s| s as u32),
            reduce: 1,
            dims,
            data,
            background,
            active_voxels: active,
        });
    }
    let mut hits = vec![0u32; n as usize];
    items(&mut |o, s, v| {
        let v = to_f32(v);
        let o = o.map(i64::from);
        for z in o[2]..o[2] + s as i64 {
            for y in o[1]..o[1] + s as i64 {
                let row = (((z - lo64[2]) / r) * d1 + (y - lo64[1]) / r) * d0;
                for x in o[0]..o[0] + s as i64 {
                    let i = (row + (x - lo64[0]) / r) as usize;
                    data[i] += v;
                    hits[i] += 1;
                }
            }
        }
    });
    // A box mean over reduce³ voxels: the ones no active item covers hold the background.
    let full = (reduce * reduce * reduce) as f32;
    for (d, h) in data.iter_mut().zip(&hits) {
        *d = (*d + background * (full - *h as f32)) / full;
    }
    Ok(VdbGrid {
        name: g.descriptor.name.clone(),
        grid_type: grid_type.to_string(),
        index_to_world,
        index_min: lo,
        active_dims: side.map(|s| s as u32),
        reduce: reduce as u32,
        dims,
        data,
        background,
        active_voxels: active,
    })
}
