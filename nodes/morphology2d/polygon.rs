//! The circle at a cost flat in its radius: a 16-gon close to the disk, built as a Minkowski sum
//! of digital line segments (Jones & Soille's periodic-line decomposition; Adams), each filtered
//! by one van Herk / Gil–Werman pass along its direction (`shaders/morphology2d/lines.wgsl`).
//!
//! Directions: the axes (1, 0), (0, 1) with `m[0]` steps each way, the diagonals (1, ±1) with
//! `m[1]`, the knight's moves (2, ±1), (1, ±2) with `m[2]`. The discrete sum
//! {Σ iⱼ·vⱼ : |iⱼ| ≤ mⱼ} is exactly the set of texels inside the continuous zonotope with the
//! same generators (checked in `tests/morphology.rs`), so its row spans follow from the
//! half-planes |n·p| ≤ Σ mⱼ·|n·vⱼ|, one per direction's normal n. [`polygon`] picks the lengths
//! whose footprint differs from the disk dx² + dy² ≤ r² in the fewest texels.
//!
//! Each pass keeps to the map: a footprint texel reached only through texels outside the map
//! is not part of the result (within r of the map's edge only). The CPU reference
//! [`reference_lines`] applies the same segments in the same order.

use std::sync::Arc;

use super::{chord, SHADER_LINES};
use crate::gpu::{Bind, Gpu, GpuBuffer, GpuError, GpuTexture, TexFormat};
use crate::io::Raster;

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

/// The lengths whose polygon is closest to the disk of radius `r` (fewest texels different),
/// found by descent from the large-radius proportions (0.275, 0.125, 0.075)·r over the 26
/// neighbouring length triples. Axis length ≥ 1, so the sum has no gaps.
pub fn polygon(r: i32) -> [i32; 3] {
    let rf = r as f64;
    let mut best = [
        ((0.275 * rf).round() as i32).max(1),
        (0.125 * rf).round() as i32,
        (0.075 * rf).round() as i32,
    ];
    let mut cost = footprint_difference(r, best);
    // Each step lowers the cost, which is a count: the loop ends.
    loop {
        let mut next = None;
        for d0 in -1..=1 {
            for d1 in -1..=1 {
                for d2 in -1..=1 {
                    let m = [best[0] + d0, best[1] + d1, best[2] + d2];
                    if m[0] < 1 || m[1] < 0 || m[2] < 0 {
                        continue;
                    }
                    let c = footprint_difference(r, m);
                    if c < cost {
                        cost = c;
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
/// exact chords cost about as much (at r 5 on the 2048² tree map: 1.8 s exact, 1.5 s polygon,
/// `benches/morphology.ron`).
pub const POLYGON_FROM: i32 = 8;

/// Whether `method = Fast` takes the polygon at radius `r` (else the exact chords): from
/// [`POLYGON_FROM`] on, where the chords also need more dispatches than its segments.
pub fn polygon_pays(r: i32) -> bool {
    r >= POLYGON_FROM && chord_dispatches(r) > 2 * segments(polygon(r)).len()
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

/// Where one direction's lines lie in the prefix and suffix buffers.
struct Layout {
    /// Bezout coefficients of the direction.
    ab: (i32, i32),
    /// Smallest and largest line index over the map.
    lines: (i32, i32),
    /// Slots per line: the longest line plus m on each side, rounded up to whole blocks.
    width: i32,
}

fn layout(w: i32, h: i32, v: (i32, i32), m: i32) -> Layout {
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
    let k = 2 * m + 1;
    Layout {
        ab: bezout(v.0, v.1),
        lines: (lo, hi),
        width: (longest + 2 * m + k - 1) / k * k,
    }
}

/// Words the prefix (and the suffix) buffer needs for the segments on a `w × h` map in one
/// pass per direction.
pub fn buffer_words(w: u32, h: u32, segs: &[((i32, i32), i32)]) -> u64 {
    segs.iter()
        .map(|(v, m)| {
            let l = layout(w as i32, h as i32, *v, *m);
            (l.lines.1 - l.lines.0 + 1) as u64 * l.width as u64
        })
        .max()
        .unwrap_or(0)
}

/// One segment on the GPU: min (or max) along direction `v`, `m` steps each way, in as many
/// passes as the buffers' size needs (`words` words each).
fn line_pass(
    gpu: &Gpu,
    src: &GpuTexture,
    (v, m): ((i32, i32), i32),
    max: bool,
    (prefix, suffix, words): (&GpuBuffer, &GpuBuffer, u64),
) -> Result<GpuTexture, GpuError> {
    let l = layout(src.width as i32, src.height as i32, v, m);
    let per_pass = (words / l.width as u64).max(1) as i32;
    let out = gpu.texture(src.width, src.height, TexFormat::R32F)?;
    let k = 2 * m + 1;
    let mut lo = l.lines.0;
    while lo <= l.lines.1 {
        let lines = per_pass.min(l.lines.1 - lo + 1);
        let u = LineParams {
            vx: v.0,
            vy: v.1,
            a: l.ab.0,
            b: l.ab.1,
            m,
            op: max as u32,
            lo,
            lines,
            width: l.width,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        };
        let bytes = bytemuck::bytes_of(&u);
        gpu.dispatch(
            SHADER_LINES,
            "blocks",
            &[
                (0, Bind::Uniform(bytes)),
                (1, Bind::Texture(src)),
                (2, Bind::Buffer(prefix)),
                (3, Bind::Buffer(suffix)),
            ],
            (l.width / k) as u32,
            lines as u32,
        )?;
        gpu.dispatch(
            SHADER_LINES,
            "combine",
            &[
                (0, Bind::Uniform(bytes)),
                (1, Bind::Texture(src)),
                (2, Bind::Buffer(prefix)),
                (3, Bind::Buffer(suffix)),
                (6, Bind::Storage(&out)),
            ],
            src.width,
            src.height,
        )?;
        lo += lines;
    }
    Ok(out)
}

/// The polygon filter on the GPU: [`segments`] of [`polygon`]`(r)` in order. The two buffers
/// are shared by the passes; a map whose lines do not fit the adapter's largest storage buffer
/// runs each direction in several passes.
pub fn filter(
    gpu: &Gpu,
    src: &Arc<GpuTexture>,
    r: i32,
    max: bool,
) -> Result<Arc<GpuTexture>, GpuError> {
    let segs = segments(polygon(r));
    let limit = gpu.limits.max_storage_buffer_binding_size / 4;
    let words = buffer_words(src.width, src.height, &segs).min(limit);
    let prefix = gpu.buffer_zeroed(words as u32)?;
    let suffix = gpu.buffer_zeroed(words as u32)?;
    let mut cur = src.clone();
    for seg in segs {
        cur = Arc::new(line_pass(gpu, &cur, seg, max, (&prefix, &suffix, words))?);
    }
    Ok(cur)
}

crate::uniforms! {
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
        /// Slots per line in the buffers.
        pub width: i32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
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
    fn lengths_match_an_exhaustive_search_at_radius_20() {
        // Exhaustive: the best triple over a ≤ 20, b ≤ 20, c ≤ 10 (28 texels, found by brute
        // force over the discrete sums as well).
        let best = (1..=20)
            .flat_map(|a| (0..=20).flat_map(move |b| (0..=10).map(move |c| [a, b, c])))
            .map(|m| footprint_difference(20, m))
            .min()
            .unwrap_or(0);
        assert_eq!(footprint_difference(20, polygon(20)), best);
        assert_eq!(best, 28);
    }
}
