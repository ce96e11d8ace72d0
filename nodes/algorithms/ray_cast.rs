//! Ray casting a scene's triangles in a compute pass: the other way to make a G-buffer or a
//! shadow map than the graphics pipeline's rasteriser.
//!
//! Why: a data-centre GPU (NVIDIA H100/H200, what render farms rent) runs the graphics pipeline
//! on a small part of the chip, while compute runs on all of it — the H200 measured 1.8 ns per
//! pixel for the G-buffer's raster pass of a few thousand triangles (15.2 ms at 4K,
//! `../shared/gpu/h200/`). A compute pass casts one ray per texel through a bounding-volume
//! hierarchy instead; on a workstation GPU or a CPU driver the rasteriser is usually faster,
//! so `method` chooses (`tyndall bench raster` measures both on the adapter in use).
//!
//! Each texel's ray is the segment its centre spans in the view's clip volume: from clip depth
//! 0 to 1 through `(x + ½, y + ½)` — exactly what the rasteriser keeps (depth clipping at the
//! near and far planes, samples at texel centres), so the nearest hit on the segment is the
//! fragment the depth test keeps. Attributes come from the hit's barycentrics, which are the
//! rasteriser's perspective-correct interpolation at the same point. Only texels whose centre
//! lies exactly on an edge shared by two triangles may take the other triangle (the rasteriser's
//! top-left rule is not reproduced) — tests compare the two methods with that allowance.
//!
//! The hierarchy ([`Bvh`]) is built on the CPU (object-median splits along the longest axis of
//! the centroids, ≤ [`LEAF_SIZE`] triangles per leaf, depth ≤ log₂ of the triangle count + 1,
//! so a 32-entry traversal stack suffices for any scene below 2³¹ triangles), once per geometry
//! and object selection ([`GpuScene::derived`]): a shot whose camera or light moves builds it
//! once. [`Bvh::cast`] is its CPU reference.

use std::hash::{Hash, Hasher};
use std::ops::Range;
use tyndall_engine::eval::SHADOW_CLEAR;
use tyndall_engine::gpu::Recorder;

use glam::{Mat4, Vec3, Vec4};
use tyndall_engine::gpu::{Bind, GpuBuffer, GpuError, GpuTexture, Shader};
use tyndall_engine::scene::{GpuScene, MeshVertex, Scene};

/// The G-buffer pass (`shaders/algorithms/ray_cast/g_buffer.wgsl`); a kind that casts lists the
/// pass it dispatches in its `NodeDecl::shaders`, and [`RayCastParams::LAYOUT`] in its uniforms.
/// Two files, not one: a kind is checked against every entry point of the shaders it lists, and
/// the G-buffer's binds three storage textures where the shadow map's binds one.
pub const G_BUFFER_SHADER: Shader = crate::shader(
    "algorithms/ray_cast/g_buffer",
    include_str!("../../shaders/algorithms/ray_cast/g_buffer.wgsl"),
);

/// The shadow-map pass (`shaders/algorithms/ray_cast/shadow.wgsl`).
pub const SHADOW_SHADER: Shader = crate::shader(
    "algorithms/ray_cast/shadow",
    include_str!("../../shaders/algorithms/ray_cast/shadow.wgsl"),
);

/// Most triangles in a leaf.
pub const LEAF_SIZE: usize = 4;

/// Depth of the shader's traversal stack (`STACK` in the WGSL).
pub const STACK_DEPTH: usize = 32;

tyndall_engine::choice_enum! {
    /// How a scene is drawn into a G-buffer or a shadow map: the graphics pipeline's rasteriser
    /// or a compute pass casting a ray per texel through a BVH (same picture but for texels
    /// centred exactly on a shared edge).
    pub enum Method { Raster = "raster", RayCast = "ray_cast" }
}

/// The `method` parameter's documentation, shared by the kinds that offer it.
pub const METHOD_DOC: &str = "raster (the graphics pipeline) or ray_cast (a compute pass casting one ray per texel through a BVH of the triangles, built once per geometry): the same picture but for texels centred exactly on an edge two triangles share. Raster is faster on CPU drivers and workstation GPUs; data-centre GPUs (H100/H200) run raster on a small part of the chip, where ray_cast is meant to win — tyndall bench raster measures both on the adapter in use.";

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/algorithms/ray_cast/common.wgsl` (struct `RayCastParams`).
    pub struct RayCastParams as "RayCastParams" {
        /// Clip → world (the inverse of `view_proj`): texel rays are unprojected with it.
        pub inv_view_proj: [[f32; 4]; 4],
        /// World → clip.
        pub view_proj: [[f32; 4]; 4],
        /// The camera's position (G-buffer: depth is the distance to it).
        pub eye: [f32; 3],
        /// The camera's far distance (G-buffer: the sky's depth and the largest depth).
        pub far: f32,
        /// Output width, texels.
        pub width: u32,
        /// Output height, texels.
        pub height: u32,
        /// Shadow map: 1 writes clip z before the divide by w (a spot's or point light's linear
        /// depth), 0 after it.
        pub linear_depth: u32,
        /// Normalised-device depth where texel rays end: 1 (the far plane) for the camera and
        /// the sun; for a linear-depth map, whose clip volume has no far plane (`z ≤ w` holds
        /// at any distance), the depth of twice the map's far distance ([`linear_far`]).
        pub far_ndc: f32,
    }
}

/// One node of a [`Bvh`]: a box and either two children (`count` 0: at `first` and
/// `first + 1`) or `count` triangles from `first` in [`Bvh::triangles`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BvhNode {
    /// Low corner of the box.
    pub min: Vec3,
    /// High corner of the box.
    pub max: Vec3,
    /// First child (inner node) or first triangle (leaf).
    pub first: u32,
    /// Triangles of a leaf; 0 for an inner node.
    pub count: u32,
}

/// A bounding-volume hierarchy over triangles: the CPU side of the ray-cast pass.
#[derive(Debug, Clone, Default)]
pub struct Bvh {
    /// Nodes, the root first.
    pub nodes: Vec<BvhNode>,
    /// Triangles in leaf order: corner positions.
    pub triangles: Vec<[Vec3; 3]>,
    /// For each triangle in leaf order, its place in the list it was built from.
    pub source: Vec<u32>,
}

/// The nearest hit of a ray: where along it, which triangle (in the build list's numbering),
/// barycentric weights of its second and third corners.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Position along the segment, 0…1.
    pub s: f32,
    /// The triangle's place in the list the BVH was built from.
    pub triangle: u32,
    /// Weight of the second corner.
    pub u: f32,
    /// Weight of the third corner.
    pub v: f32,
}

impl Bvh {
    /// Build over `triangles` (any order; the numbering [`Hit::triangle`] and [`Bvh::source`]
    /// refer to).
    pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let centroid = |i: u32| {
            let t = triangles[i as usize];
            (t[0] + t[1] + t[2]) / 3.0
        };
        let mut nodes = vec![BvhNode {
            min: Vec3::splat(f32::INFINITY),
            max: Vec3::splat(f32::NEG_INFINITY),
            first: 0,
            count: 0,
        }];
        // (node, range of `order`) still to place; iterative, so no recursion depth to mind.
        let mut todo = vec![(0usize, 0usize..order.len())];
        while let Some((at, range)) = todo.pop() {
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            let (mut clo, mut chi) = (lo, hi);
            for &i in &order[range.clone()] {
                for p in triangles[i as usize] {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
                clo = clo.min(centroid(i));
                chi = chi.max(centroid(i));
            }
            nodes[at].min = lo;
            nodes[at].max = hi;
            if range.len() <= LEAF_SIZE {
                nodes[at].first = range.start as u32;
                nodes[at].count = range.len() as u32;
                continue;
            }
            let extent = chi - clo;
            let axis = if extent.x >= extent.y && extent.x >= extent.z {
                0
            } else if extent.y >= extent.z {
                1
            } else {
                2
            };
            let mid = range.len() / 2;
            order[range.clone()].select_nth_unstable_by(mid, |a, b| {
                centroid(*a)[axis].total_cmp(&centroid(*b)[axis])
            });
            let left = nodes.len();
            nodes[at].first = left as u32;
            nodes[at].count = 0;
            nodes.extend([nodes[at]; 2]);
            todo.push((left, range.start..range.start + mid));
            todo.push((left + 1, range.start + mid..range.end));
        }
        Bvh {
            nodes,
            triangles: order.iter().map(|&i| triangles[i as usize]).collect(),
            source: order,
        }
    }

    /// The nearest hit of the segment `origin → origin + dir` (s in 0…1), as the shader finds
    /// it — boxes visited nearest first, a box skipped once its entry is no nearer than the
    /// best hit: the CPU reference of its traversal.
    pub fn cast(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        if self.triangles.is_empty() {
            return None;
        }
        let inv = safe_inverse(dir);
        let entry = |n: u32, limit: f32| slab(self.nodes[n as usize], origin, inv, limit);
        let mut best: Option<Hit> = None;
        let limit = |best: &Option<Hit>| best.map_or(1.0, |h| h.s);
        let mut stack: Vec<(u32, f32)> = entry(0, 1.0).map(|t| (0, t)).into_iter().collect();
        while let Some((n, near)) = stack.pop() {
            if near >= limit(&best) {
                continue;
            }
            let node = self.nodes[n as usize];
            if node.count == 0 {
                let (l, r) = (node.first, node.first + 1);
                let (tl, tr) = (entry(l, limit(&best)), entry(r, limit(&best)));
                let ((a, ta), (b, tb)) = if tl.unwrap_or(2.0) <= tr.unwrap_or(2.0) {
                    ((r, tr), (l, tl))
                } else {
                    ((l, tl), (r, tr))
                };
                // The farther child first onto the stack, so the nearer is visited first.
                stack.extend(ta.map(|t| (a, t)));
                stack.extend(tb.map(|t| (b, t)));
                continue;
            }
            for t in node.first..node.first + node.count {
                if let Some((s, u, v)) =
                    intersect(self.triangles[t as usize], origin, dir, limit(&best))
                {
                    best = Some(Hit {
                        s,
                        triangle: self.source[t as usize],
                        u,
                        v,
                    });
                }
            }
        }
        best
    }
}

/// `1 / d` with components too close to zero replaced by ±1e30 (the slab test's infinities).
fn safe_inverse(d: Vec3) -> Vec3 {
    let f = |x: f32| {
        if x.abs() < 1e-30 {
            1e30_f32.copysign(x)
        } else {
            1.0 / x
        }
    };
    Vec3::new(f(d.x), f(d.y), f(d.z))
}

/// Where the segment enters the node's box (0 when it starts inside), if it does before
/// `limit`.
fn slab(node: BvhNode, origin: Vec3, inv: Vec3, limit: f32) -> Option<f32> {
    let (t0, t1) = ((node.min - origin) * inv, (node.max - origin) * inv);
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element().min(limit);
    (near <= far && near < limit).then_some(near)
}

/// Möller–Trumbore: the segment's parameter and the barycentric weights of the second and third
/// corners where it crosses `tri`, when that is in `[0, limit)` (edges included: a texel centred
/// on a shared edge hits one of the two triangles, never neither).
fn intersect(tri: [Vec3; 3], origin: Vec3, dir: Vec3, limit: f32) -> Option<(f32, f32, f32)> {
    let (e1, e2) = (tri[1] - tri[0], tri[2] - tri[0]);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let t = origin - tri[0];
    let u = t.dot(p) * inv;
    let q = t.cross(e1);
    let v = dir.dot(q) * inv;
    let s = e2.dot(q) * inv;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && s >= 0.0 && s < limit).then_some((s, u, v))
}

/// The segment texel `(x, y)` of a `w × h` view spans from normalised depth 0 to `far_ndc`, in
/// world space: `(origin, direction)`.
pub fn texel_ray(
    inv_view_proj: Mat4,
    (x, y): (u32, u32),
    (w, h): (u32, u32),
    far_ndc: f32,
) -> (Vec3, Vec3) {
    let nx = (x as f32 + 0.5) / w as f32 * 2.0 - 1.0;
    let ny = 1.0 - (y as f32 + 0.5) / h as f32 * 2.0;
    let a = inv_view_proj * Vec4::new(nx, ny, 0.0, 1.0);
    let b = inv_view_proj * Vec4::new(nx, ny, far_ndc, 1.0);
    let (a, b) = (a.truncate() / a.w, b.truncate() / b.w);
    (a, b - a)
}

/// A scene's BVH on the GPU: nodes, triangle corners and per-corner attributes.
pub struct GpuBvh {
    /// Two `vec4`s per node: `(min, first)`, `(max, count)` (integers as bits).
    pub nodes: GpuBuffer,
    /// Three `vec4`s per triangle: its corners.
    pub corners: GpuBuffer,
    /// Six `vec4`s per triangle: the corners' normals, then their colours.
    pub attributes: GpuBuffer,
    /// Triangles.
    pub triangles: usize,
}

/// The BVH of the objects `draws` selects ([`GpuScene::draws`], [`GpuScene::select`]) in world
/// space, built and uploaded once per geometry, placement and selection.
pub fn scene_bvh(
    gpu: &Recorder,
    scene: &GpuScene,
    draws: &[(u32, Range<u32>)],
) -> Result<std::sync::Arc<GpuBvh>, GpuError> {
    let ranges: Vec<Range<u32>> = draws.iter().map(|(_, r)| r.clone()).collect();
    let ranges = &ranges[..];
    let mut h = std::hash::DefaultHasher::new();
    // The world-space geometry (placements included) and the selection.
    (scene.parts.geometry, ranges).hash(&mut h);
    let (bvh, _) = scene.derived(h.finish(), || {
        let corners = triangles(&scene.scene, ranges);
        let bvh = Bvh::build(&positions(&corners));
        upload(gpu, &bvh, |t| {
            let v = corners[t as usize];
            [v[0].normal, v[1].normal, v[2].normal]
                .map(|n| [n[0], n[1], n[2], 0.0])
                .into_iter()
                .chain(v.map(|v| v.colour))
                .collect()
        })
    })?;
    Ok(bvh)
}

/// The corners of the triangles of the objects `ranges` selects ([`GpuScene::ranges`]), in
/// order: the list a scene's BVH is built from.
pub fn triangles(scene: &Scene, ranges: &[Range<u32>]) -> Vec<[MeshVertex; 3]> {
    let (verts, indices) = tyndall_engine::scene::flatten(scene);
    ranges
        .iter()
        .flat_map(|r| {
            let (start, end) = (r.start as usize, (r.end as usize).min(indices.len()));
            indices.get(start..end).unwrap_or(&[]).chunks_exact(3)
        })
        .map(|c| [c[0], c[1], c[2]].map(|i| verts[i as usize]))
        .collect()
}

/// The corner positions of `triangles`.
pub fn positions(triangles: &[[MeshVertex; 3]]) -> Vec<[Vec3; 3]> {
    triangles
        .iter()
        .map(|t| t.map(|v| Vec3::from_array(v.position)))
        .collect()
}

/// One texel of a G-buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GBufferTexel {
    /// Distance to the camera (sky: the far distance).
    pub depth: f32,
    /// World normal facing the camera, alpha 1 (sky: 0).
    pub normal: [f32; 4],
    /// Base colour, alpha 1 (sky: 0).
    pub albedo: [f32; 4],
}

/// CPU reference of the `g_buffer` pass over `triangles` ([`triangles`]): per texel, row by
/// row, depth, normal and albedo as the shader writes them.
pub fn reference_g_buffer(triangles: &[[MeshVertex; 3]], p: &RayCastParams) -> Vec<GBufferTexel> {
    let bvh = Bvh::build(&positions(triangles));
    texels(p)
        .map(|(o, d)| match bvh.cast(o, d) {
            None => GBufferTexel {
                depth: p.far,
                normal: [0.0; 4],
                albedo: [0.0; 4],
            },
            Some(h) => {
                let t = triangles[h.triangle as usize];
                let w = [1.0 - h.u - h.v, h.u, h.v];
                let mix =
                    |f: &dyn Fn(&MeshVertex) -> Vec4| (0..3).map(|i| f(&t[i]) * w[i]).sum::<Vec4>();
                let normal = mix(&|v| Vec3::from_array(v.normal).extend(0.0)).truncate();
                let colour = mix(&|v| Vec4::from_array(v.colour));
                let to_eye = Vec3::from_array(p.eye) - (o + h.s * d);
                let n = normal.normalize();
                let n = if n.dot(to_eye) < 0.0 { -n } else { n };
                GBufferTexel {
                    depth: to_eye.length().min(p.far),
                    normal: n.extend(1.0).to_array(),
                    albedo: colour.truncate().extend(1.0).to_array(),
                }
            }
        })
        .collect()
}

/// CPU reference of the `shadow` pass over `triangles`: per texel, row by row, the clip depth
/// of the nearest surface ([`SHADOW_CLEAR`] where none).
pub fn reference_shadow(triangles: &[[MeshVertex; 3]], p: &RayCastParams) -> Vec<f32> {
    let bvh = Bvh::build(&positions(triangles));
    let view_proj = Mat4::from_cols_array_2d(&p.view_proj);
    texels(p)
        .map(|(o, d)| match bvh.cast(o, d) {
            None => SHADOW_CLEAR,
            Some(h) => {
                let c = view_proj * (o + h.s * d).extend(1.0);
                if p.linear_depth != 0 {
                    c.z
                } else {
                    c.z / c.w
                }
            }
        })
        .collect()
}

/// Every texel's ray of `p`'s view, row by row.
fn texels(p: &RayCastParams) -> impl Iterator<Item = (Vec3, Vec3)> + '_ {
    let inv = Mat4::from_cols_array_2d(&p.inv_view_proj);
    let size = (p.width, p.height);
    (0..p.height)
        .flat_map(move |y| (0..p.width).map(move |x| texel_ray(inv, (x, y), size, p.far_ndc)))
}

/// Upload `bvh`, with `attributes(t)` the six `vec4`s of triangle `t` of its build list.
fn upload(
    gpu: &Recorder,
    bvh: &Bvh,
    attributes: impl Fn(u32) -> Vec<[f32; 4]>,
) -> Result<GpuBvh, GpuError> {
    let bits = |v: f32| v.to_bits();
    let mut nodes = Vec::with_capacity(bvh.nodes.len() * 8);
    for n in &bvh.nodes {
        nodes.extend(n.min.to_array().map(bits));
        nodes.push(n.first);
        nodes.extend(n.max.to_array().map(bits));
        nodes.push(n.count);
    }
    let corners: Vec<u32> = bvh
        .triangles
        .iter()
        .flat_map(|t| t.iter().flat_map(|p| [p.x, p.y, p.z, 0.0].map(bits)))
        .collect();
    let attrs: Vec<u32> = bvh
        .source
        .iter()
        .flat_map(|&t| attributes(t))
        .flat_map(|a| a.map(bits))
        .collect();
    Ok(GpuBvh {
        nodes: gpu.buffer_from(&nodes)?,
        corners: gpu.buffer_from(&corners)?,
        attributes: gpu.buffer_from(&attrs)?,
        triangles: bvh.triangles.len(),
    })
}

/// The uniforms of a cast through `view_proj` at `w × h`.
pub fn params(view_proj: Mat4, w: u32, h: u32) -> RayCastParams {
    RayCastParams {
        inv_view_proj: view_proj.inverse().to_cols_array_2d(),
        view_proj: view_proj.to_cols_array_2d(),
        eye: [0.0; 3],
        far: 0.0,
        width: w,
        height: h,
        linear_depth: 0,
        far_ndc: 1.0,
    }
}

/// [`RayCastParams::far_ndc`] of a linear-depth map (`scene::local_proj(_, near, far)`: clip
/// z = (d − near) / (far − near), w = d at distance d along the axis): the normalised depth at
/// d = 2 · far — past the farthest corner of the scene's bounds the map is fitted to, short of
/// the asymptote (d → ∞) where unprojection loses precision.
pub fn linear_far(near: f32, far: f32) -> f32 {
    let d = 2.0 * far;
    (d - near) / (far - near).max(f32::MIN_POSITIVE) / d
}

/// A G-buffer by ray casting: writes `depth`, `normal`, `albedo` as
/// `shaders/algorithms/g_buffer.wgsl` does (`p.eye` and `p.far` set).
pub fn g_buffer(
    gpu: &Recorder,
    bvh: &GpuBvh,
    p: &RayCastParams,
    (depth, normal, albedo): (&GpuTexture, &GpuTexture, &GpuTexture),
) -> Result<(), GpuError> {
    gpu.dispatch(
        G_BUFFER_SHADER,
        "g_buffer",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(p))),
            ("bvh_nodes", Bind::Buffer(&bvh.nodes)),
            ("corners", Bind::Buffer(&bvh.corners)),
            ("attributes", Bind::Buffer(&bvh.attributes)),
            ("depth_out", Bind::Storage(depth)),
            ("normal_out", Bind::Storage(normal)),
            ("albedo_out", Bind::Storage(albedo)),
        ],
        p.width,
        p.height,
    )
}

/// A shadow map by ray casting: the clip depth of the nearest surface per texel (1 where
/// none), as `shaders/shadow_map.wgsl` writes it.
pub fn shadow(
    gpu: &Recorder,
    bvh: &GpuBvh,
    p: &RayCastParams,
    out: &GpuTexture,
) -> Result<(), GpuError> {
    gpu.dispatch(
        SHADOW_SHADER,
        "shadow",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(p))),
            ("bvh_nodes", Bind::Buffer(&bvh.nodes)),
            ("corners", Bind::Buffer(&bvh.corners)),
            ("depth_out", Bind::Storage(out)),
        ],
        p.width,
        p.height,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small random soup of triangles.
    fn soup(n: usize) -> Vec<[Vec3; 3]> {
        let mut rng = crate::algorithms::random::SplitMix64(7);
        let mut r = || rng.next_f64() as f32;
        (0..n)
            .map(|_| {
                let c = Vec3::new(r(), r(), r()) * 10.0;
                [0, 1, 2].map(|_| c + Vec3::new(r(), r(), r()) - 0.5)
            })
            .collect()
    }

    #[test]
    fn the_bvh_finds_the_nearest_hit_brute_force_finds() {
        let tris = soup(500);
        let bvh = Bvh::build(&tris);
        fn depth(bvh: &Bvh, n: usize) -> usize {
            let node = bvh.nodes[n];
            if node.count > 0 {
                1
            } else {
                let first = node.first as usize;
                1 + depth(bvh, first).max(depth(bvh, first + 1))
            }
        }
        // Object-median splits: depth ≤ ⌈log₂(500 / 4)⌉ + 1 = 8 levels.
        assert!(depth(&bvh, 0) <= 8, "depth {}", depth(&bvh, 0));
        let mut rng = crate::algorithms::random::SplitMix64(3);
        let mut hits = 0;
        for _ in 0..2000 {
            let mut r = || rng.next_f64() as f32;
            let o = Vec3::new(r(), r(), -1.0) * Vec3::new(10.0, 10.0, 1.0);
            let d = Vec3::new(r() - 0.5, r() - 0.5, 12.0);
            let brute = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| intersect(*t, o, d, 1.0).map(|(s, _, _)| (s, i as u32)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let found = bvh.cast(o, d).map(|h| (h.s, h.triangle));
            assert_eq!(found, brute);
            hits += usize::from(brute.is_some());
        }
        assert!(
            hits > 200,
            "only {hits} rays hit: the test would prove little"
        );
    }

    #[test]
    fn an_empty_or_degenerate_list_casts_nothing() {
        assert_eq!(Bvh::build(&[]).cast(Vec3::ZERO, Vec3::Z), None);
        let flat = [[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]];
        assert_eq!(
            Bvh::build(&flat).cast(Vec3::new(0.5, 0.0, -1.0), Vec3::Z * 2.0),
            None
        );
    }
}
