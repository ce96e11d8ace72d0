//! The circle at a cost flat in its radius: a 16-gon close to the disk, built as a Minkowski sum
//! of digital line segments (Jones & Soille's periodic-line decomposition; Adams), each filtered
//! by one van Herk / Gil–Werman pass along its direction (`shaders/morphology2d/lines.wgsl`).
//!
//! Directions: the axes (1, 0), (0, 1) with `m[0]` steps each way, the diagonals (1, ±1) with
//! `m[1]`, the knight's moves (2, ±1), (1, ±2) with `m[2]`. The discrete sum
//! {Σ iⱼ·vⱼ : |iⱼ| ≤ mⱼ} is exactly the set of texels inside the continuous zonotope with the
//! same generators (checked in `tests/filters/morphology.rs`), so its row spans follow from the
//! half-planes |n·p| ≤ Σ mⱼ·|n·vⱼ|, one per direction's normal n. [`polygon`] picks the lengths
//! whose support (how far it moves an edge) is closest to the disk dx² + dy² ≤ r².
//!
//! On the GPU each segment is one dispatch, reading one map-sized buffer and writing the other
//! (`from_map` and `to_map` copy the map in and out): sixteen passes for a closure whatever r.
//!
//! Each pass keeps to the map: a footprint texel reached only through texels outside the map
//! is not part of the result (within r of the map's edge only). The CPU reference
//! [`reference_lines`] applies the same segments in the same order.

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use super::{chord, SHADER_LINES};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, TexFormat};
use tyndall_engine::io::Raster;

/// The eight directions and which of the three lengths each uses.
pub const DIRECTIONS: [((i32, i32), usize); 8] = [
    ((1, 0), 0),
    ((0, 1), 0),
    ((1, 1), 1),
    ((1, -1), 1),
    ((2, 1), 2),
    ((1, 2), 2),
    ((2, -1), 2),
    ((1, -2), 2),
];

/// The segments `(direction, half-length in steps)` of the lengths `m`, those with length 0
/// left out, in the order the passes run.
pub fn segments(m: [i32; 3]) -> Vec<((i32, i32), i32)> {
    DIRECTIONS
        .iter()
        .filter(|(_, k)| m[*k] > 0)
        .map(|(v, k)| (*v, m[*k]))
        .collect()
}

/// ⌊a / b⌋ for any signs (b ≠ 0).
fn floor_div(a: i64, b: i64) -> i64 {
    let q = a / b;
    if a % b != 0 && ((a < 0) != (b < 0)) {
        q - 1
    } else {
        q
    }
}

/// The polygon's row span at row offset `dy`: `(lo, hi)` for lo ≤ dx ≤ hi (empty: lo > hi).
pub fn polygon_span(m: [i32; 3], dy: i64) -> (i64, i64) {
    let (mut lo, mut hi) = (i64::MIN, i64::MAX);
    for ((vx, vy), _) in DIRECTIONS {
        // Normal n = (−vy, vx); the support value h = Σ mⱼ |n·vⱼ|; −h ≤ n·p ≤ h.
        let (nx, ny) = (-(vy as i64), vx as i64);
        let h: i64 = DIRECTIONS
            .iter()
            .map(|((wx, wy), k)| m[*k] as i64 * (nx * *wx as i64 + ny * *wy as i64).abs())
            .sum();
        let (l, u) = (-h - ny * dy, h - ny * dy);
        if nx == 0 {
            if l > 0 || u < 0 {
                return (1, 0);
            }
            continue;
        }
        // l ≤ nx·x ≤ u; dividing by a negative nx swaps the bounds.
        let (a, b) = if nx > 0 { (l, u) } else { (u, l) };
        lo = lo.max(-floor_div(-a, nx));
        hi = hi.min(floor_div(b, nx));
    }
    (lo, hi)
}

/// Texels in which the polygon of lengths `m` and the disk of radius `r` differ.
pub fn footprint_difference(r: i32, m: [i32; 3]) -> i64 {
    let reach = (m[0] + 2 * m[1] + 6 * m[2]).max(r) as i64;
    let size = |(lo, hi): (i64, i64)| (hi - lo + 1).max(0);
    (-reach..=reach)
        .map(|dy| {
            let disk = if dy.abs() <= r as i64 {
                let q = chord(r, dy as i32) as i64;
                (-q, q)
            } else {
                (1, 0)
            };
            let poly = polygon_span(m, dy);
            let both = (disk.0.max(poly.0), disk.1.min(poly.1));
            size(disk) + size(poly) - 2 * size(both)
        })
        .sum()
}

/// Directions [`support_error`] compares in (evenly spaced, offset by half a step).
pub const SUPPORT_DIRECTIONS: usize = 360;

/// Below this radius [`polygon`] searches every length triple up to the proportions' reach;
/// from it on, a descent (the box holds ~r³/48 triples).
pub const EXHAUSTIVE_BELOW: i32 = 48;

/// The unit normal n(θ) of direction `i` of `n` evenly spaced ones, offset by half a step.
fn normal(i: usize, n: usize) -> (f64, f64) {
    let th = std::f64::consts::TAU * (i as f64 + 0.5) / n as f64;
    (th.cos(), th.sin())
}

/// The disk's support values h(θ) = max p·n(θ) over its texels p, at the
/// [`SUPPORT_DIRECTIONS`] directions.
pub fn disk_support(r: i32) -> Vec<f64> {
    (0..SUPPORT_DIRECTIONS)
        .map(|i| {
            let (nx, ny) = normal(i, SUPPORT_DIRECTIONS);
            (-r..=r)
                .map(|dy| chord(r, dy) as f64 * nx.abs() + dy as f64 * ny)
                .fold(f64::MIN, f64::max)
        })
        .collect()
}

/// Mean |h_P(θ) − h_D(θ)| over directions, in texels: how far the polygon of lengths `m`
/// moves a straight occluder edge at angle θ, dilating, further or less far than the disk
/// (`disk` from [`disk_support`]). The zonotope's support is Σ mⱼ |n·vⱼ|, and its vertices
/// are texels, so that is also its texels' support.
pub fn support_error(m: [i32; 3], disk: &[f64]) -> f64 {
    let n = disk.len();
    disk.iter()
        .enumerate()
        .map(|(i, hd)| {
            let (nx, ny) = normal(i, n);
            let hp: f64 = DIRECTIONS
                .iter()
                .map(|((vx, vy), k)| m[*k] as f64 * (nx * *vx as f64 + ny * *vy as f64).abs())
                .sum();
            (hp - hd).abs()
        })
        .sum::<f64>()
        / n as f64
}

/// The lengths whose polygon moves edges most nearly as the disk of radius `r` does: least
/// [`support_error`], ties to the fewest texels different ([`footprint_difference`]). Axis
/// length ≥ 1, so the sum has no gaps.
///
/// Why the support and not the texel count: a closure moves each occluder edge out by the
/// element's support in its normal's direction and back, so where the two elements' supports
/// differ by a texel the results differ along the whole edge. Measured on the tree's 2048²
/// map at r 20: the triple with the fewest texels different from the disk, (7, 3, 1), whose
/// reach along the axes is one texel short, changes 1.02 % of the closure's texels; (4, 2, 2),
/// least support error, 0.87 % (`benches/morphology.ron`).
///
/// Search: every triple with m₀ ≤ r/2 + 1, m₁ ≤ r/4 + 1, m₂ ≤ r/6 + 1 below
/// [`EXHAUSTIVE_BELOW`] (a descent from the proportions misses the best at r 14 and 20); from
/// it on, descent from the large-radius proportions (0.275, 0.125, 0.075)·r over the 26
/// neighbouring triples. Results are kept per radius.
pub fn polygon(r: i32) -> [i32; 3] {
    static CHOSEN: std::sync::OnceLock<std::sync::Mutex<std::collections::HashMap<i32, [i32; 3]>>> =
        std::sync::OnceLock::new();
    let chosen = CHOSEN.get_or_init(Default::default);
    if let Some(m) = chosen.lock().ok().and_then(|c| c.get(&r).copied()) {
        return m;
    }
    let m = choose_polygon(r);
    if let Ok(mut c) = chosen.lock() {
        c.insert(r, m);
    }
    m
}

fn choose_polygon(r: i32) -> [i32; 3] {
    let disk = disk_support(r);
    let cost = |m: [i32; 3]| (support_error(m, &disk), footprint_difference(r, m));
    let better =
        |a: (f64, i64), b: (f64, i64)| a.0 < b.0 - 1e-9 || (a.0 <= b.0 + 1e-9 && a.1 < b.1);
    if r < EXHAUSTIVE_BELOW {
        let mut best = ([1, 0, 0], cost([1, 0, 0]));
        for m0 in 1..=r / 2 + 1 {
            for m1 in 0..=r / 4 + 1 {
                for m2 in 0..=r / 6 + 1 {
                    let c = cost([m0, m1, m2]);
                    if better(c, best.1) {
                        best = ([m0, m1, m2], c);
                    }
                }
            }
        }
        return best.0;
    }
    let rf = r as f64;
    let mut best = [
        ((0.275 * rf).round() as i32).max(1),
        (0.125 * rf).round() as i32,
        (0.075 * rf).round() as i32,
    ];
    let mut c_best = cost(best);
    // Each step lowers the cost (in the order `better` defines) over finitely many triples:
    // the loop ends.
    loop {
        let mut next = None;
        for d0 in -1..=1 {
            for d1 in -1..=1 {
                for d2 in -1..=1 {
                    let m = [best[0] + d0, best[1] + d1, best[2] + d2];
                    if m[0] < 1 || m[1] < 0 || m[2] < 0 {
                        continue;
                    }
                    let c = cost(m);
                    if better(c, c_best) {
                        c_best = c;
                        next = Some(m);
                    }
                }
            }
        }
        match next {
            Some(m) => best = m,
            None => return best,
        }
    }
}

/// Dispatches of the exact chord method at radius `r` (a row pass of two dispatches per
/// distinct non-zero chord width, one fold per width).
pub fn chord_dispatches(r: i32) -> usize {
    let mut n = 0;
    let mut dy = 0;
    while dy <= r {
        let half = chord(r, dy);
        n += if half > 0 { 3 } else { 1 };
        while dy <= r && chord(r, dy) == half {
            dy += 1;
        }
    }
    n
}

/// The smallest radius `method = Fast` takes the polygon at. Below it the polygon needs only
/// a few of the eight directions and differs from the disk in 3.5–31 % of its texels, while the
/// exact chords cost about as much as its sixteen passes (at 2048², the chords at r 5 and the
/// polygon at r 10 and 20 take the same time within lavapipe's noise, `benches/morphology.ron`).
pub const POLYGON_FROM: i32 = 8;

/// Whether `method = Fast` takes the polygon at radius `r` (else the exact chords): from
/// [`POLYGON_FROM`] on, where the chords also need more dispatches than its passes.
pub fn polygon_pays(r: i32) -> bool {
    r >= POLYGON_FROM && chord_dispatches(r) > segments(polygon(r)).len()
}

/// CPU reference: the segments applied in order, each the min (`max = false`) or max over the
/// in-map texels p + i·v, |i| ≤ m.
pub fn reference_lines(map: &Raster, segs: &[((i32, i32), i32)], max: bool) -> Raster {
    let (w, h) = (map.width as i32, map.height as i32);
    let mut cur = map.clone();
    for ((vx, vy), m) in segs {
        let mut out = cur.clone();
        for y in 0..h {
            for x in 0..w {
                let mut v = if max { f32::MIN } else { f32::MAX };
                for i in -m..=*m {
                    let (qx, qy) = (x + i * vx, y + i * vy);
                    if qx >= 0 && qy >= 0 && qx < w && qy < h {
                        let s = cur.data[(qy * w + qx) as usize];
                        v = if max { v.max(s) } else { v.min(s) };
                    }
                }
                out.data[(y * w + x) as usize] = v;
            }
        }
        cur = out;
    }
    cur
}

/// `a`, `b` with a·vx + b·vy = 1 (v primitive).
fn bezout(vx: i32, vy: i32) -> (i32, i32) {
    // Extended Euclid on (vx, vy).
    let (mut r0, mut r1) = (vx, vy);
    let (mut s0, mut s1) = (1, 0);
    let (mut t0, mut t1) = (0, 1);
    while r1 != 0 {
        let q = r0.div_euclid(r1);
        (r0, r1) = (r1, r0 - q * r1);
        (s0, s1) = (s1, s0 - q * s1);
        (t0, t1) = (t1, t0 - q * t1);
    }
    // r0 = ±1 for a primitive direction.
    (s0 * r0, t0 * r0)
}

/// Outputs per thread of a pass are at least this many (whole blocks of 2m + 1).
const RUN: i32 = 64;

/// One direction's lines over a `w × h` map: the smallest and largest line index and the
/// most texels a line holds.
fn lines(w: i32, h: i32, v: (i32, i32)) -> ((i32, i32), i32) {
    let corners = [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)];
    let line = |(x, y): &(i32, i32)| v.1 * x - v.0 * y;
    let lo = corners.iter().map(line).min().unwrap_or(0);
    let hi = corners.iter().map(line).max().unwrap_or(0);
    let along = |n: i32, step: i32| (step != 0).then(|| (n + step.abs() - 1) / step.abs());
    let longest = [along(w, v.0), along(h, v.1)]
        .into_iter()
        .flatten()
        .min()
        .unwrap_or(1);
    ((lo, hi), longest)
}

/// The parameter block of one pass along `v` with half-length `m` on a `w × h` map, and its
/// dispatch size (runs per line, lines). On Mesa's CPU drivers its values are inlined into the
/// pass (see `src/engine/gpu/params.rs`): the loops' bounds become constants.
fn line_params(
    (w, h): (u32, u32),
    (v, m): ((i32, i32), i32),
    max: bool,
) -> (LineParams, (u32, u32)) {
    let ((lo, hi), longest) = lines(w as i32, h as i32, v);
    let (a, b) = bezout(v.0, v.1);
    let k = 2 * m + 1;
    let n = (RUN + k - 1) / k;
    let u = LineParams {
        vx: v.0,
        vy: v.1,
        a,
        b,
        m,
        op: u32::from(max),
        lo,
        lines: hi - lo + 1,
        n,
        w: w as i32,
        h: h as i32,
        _pad: 0,
    };
    let runs = (longest + n * k - 1) / (n * k);
    (u, (runs as u32, (hi - lo + 1) as u32))
}

/// The polygon filter on the GPU: the [`segments`] of [`polygon`]`(r)` in order, one dispatch
/// each between two buffers the map's size (copied in from `src` and out to the result).
pub fn filter(
    gpu: &Recorder,
    src: &Arc<GpuTexture>,
    r: i32,
    max: bool,
) -> Result<Arc<GpuTexture>, GpuError> {
    let (w, h) = (src.width, src.height);
    let words = w.checked_mul(h).ok_or_else(|| {
        GpuError::Validation(format!(
            "a {w}×{h} map is too large for the polygon's buffers"
        ))
    })?;
    let mut cur = gpu.buffer_zeroed(words)?;
    let mut next = gpu.buffer_zeroed(words)?;
    // The copies read only the size.
    let (size, _) = line_params((w, h), ((1, 0), 1), max);
    let size = bytemuck::bytes_of(&size);
    gpu.dispatch(
        SHADER_LINES,
        "from_map",
        &[
            ("L", Bind::Uniform(size)),
            ("src", Bind::Texture(src)),
            ("out_buf", Bind::Buffer(&cur)),
        ],
        w,
        h,
    )?;
    for seg in segments(polygon(r)) {
        let (u, (runs, lines)) = line_params((w, h), seg, max);
        gpu.dispatch(
            SHADER_LINES,
            "segment",
            &[
                ("L", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("src_buf", Bind::Buffer(&cur)),
                ("out_buf", Bind::Buffer(&next)),
            ],
            runs,
            lines,
        )?;
        std::mem::swap(&mut cur, &mut next);
    }
    let out = gpu.texture(w, h, TexFormat::R32F)?;
    gpu.dispatch(
        SHADER_LINES,
        "to_map",
        &[
            ("L", Bind::Uniform(size)),
            ("src_buf", Bind::Buffer(&cur)),
            ("out_map", Bind::Storage(&out)),
        ],
        w,
        h,
    )?;
    Ok(Arc::new(out))
}

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/morphology2d/lines.wgsl` (struct `Line`).
    pub struct LineParams as "Line" {
        /// Direction x.
        pub vx: i32,
        /// Direction y.
        pub vy: i32,
        /// Bezout a (a·vx + b·vy = 1).
        pub a: i32,
        /// Bezout b.
        pub b: i32,
        /// Half-length in steps.
        pub m: i32,
        /// 0 min, 1 max.
        pub op: u32,
        /// First line of this pass.
        pub lo: i32,
        /// Lines in this pass.
        pub lines: i32,
        /// Blocks of 2m + 1 outputs per thread.
        pub n: i32,
        /// Map width.
        pub w: i32,
        /// Map height.
        pub h: i32,
        /// Padding.
        pub _pad: u32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bezout_solves_every_direction() {
        for ((vx, vy), _) in DIRECTIONS {
            let (a, b) = bezout(vx, vy);
            assert_eq!(a * vx + b * vy, 1, "({vx}, {vy})");
        }
    }

    #[test]
    fn the_chosen_lengths_have_the_least_support_error_at_radius_20() {
        // (4, 2, 2) reaches the disk's axis texels (±20, 0), (0, ±20); (7, 3, 1), the fewest
        // texels off (28 against 32), stops one short of them.
        let disk = disk_support(20);
        assert_eq!(polygon(20), [4, 2, 2]);
        assert_eq!(footprint_difference(20, [4, 2, 2]), 32);
        assert_eq!(footprint_difference(20, [7, 3, 1]), 28);
        assert!(support_error([4, 2, 2], &disk) < support_error([7, 3, 1], &disk));
        // The descent beyond the exhaustive range ends at a triple no neighbour improves on.
        let r = EXHAUSTIVE_BELOW + 12;
        let (m, disk) = (polygon(r), disk_support(r));
        for d in [
            [1, 0, 0],
            [0, 1, 0],
            [0, 0, 1],
            [-1, 0, 0],
            [0, -1, 0],
            [0, 0, -1],
        ] {
            let n = [m[0] + d[0], m[1] + d[1], m[2] + d[2]];
            assert!(
                support_error(n, &disk) >= support_error(m, &disk) - 1e-9,
                "{n:?}"
            );
        }
    }
}
