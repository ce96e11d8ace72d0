//! Error metrics of a measured output against its reference: RMSE and maximum error, errors
//! masked to depth discontinuities, and connected components (holes).

use tyndall_engine::io::Raster;

pub(super) fn errors(a: &Raster, b: &Raster) -> (f64, f64) {
    if a.data.len() != b.data.len() {
        return (f64::NAN, f64::NAN);
    }
    let n = a.data.len().max(1) as f64;
    let mut sq = 0.0;
    let mut mx = 0.0f64;
    for (x, y) in a.data.iter().zip(&b.data) {
        let d = (*x as f64 - *y as f64).abs();
        sq += d * d;
        mx = mx.max(d);
    }
    ((sq / n).sqrt(), mx)
}

/// Texels at depth discontinuities: the depth differs from a 4-neighbour's by more than
/// `threshold` times its own.
pub fn discontinuities(depth: &Raster, threshold: f32) -> Vec<bool> {
    let (w, h) = (depth.width as usize, depth.height as usize);
    let d = |x: usize, y: usize| depth.data[(y * w + x) * depth.channels as usize];
    let mut out = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let here = d(x, y);
            let mut n = Vec::with_capacity(4);
            if x > 0 {
                n.push(d(x - 1, y));
            }
            if x + 1 < w {
                n.push(d(x + 1, y));
            }
            if y > 0 {
                n.push(d(x, y - 1));
            }
            if y + 1 < h {
                n.push(d(x, y + 1));
            }
            out[y * w + x] = n.iter().any(|v| (v - here).abs() > threshold * here.abs());
        }
    }
    out
}

/// RMSE of `a` against `b` over the texels where `mask` is set (all channels).
pub fn masked_rmse(a: &Raster, b: &Raster, mask: &[bool]) -> f64 {
    if a.data.len() != b.data.len() || a.data.len() != mask.len() * a.channels as usize {
        return f64::NAN;
    }
    let c = a.channels as usize;
    let (mut sq, mut n) = (0.0f64, 0usize);
    for (i, m) in mask.iter().enumerate() {
        if *m {
            for k in 0..c {
                let d = a.data[i * c + k] as f64 - b.data[i * c + k] as f64;
                sq += d * d;
                n += 1;
            }
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        (sq / n as f64).sqrt()
    }
}

/// Number of 4-connected components of texels ≥ `threshold` in a one-channel raster.
pub fn count_components(r: &Raster, threshold: f32) -> usize {
    let (w, h) = (r.width as usize, r.height as usize);
    let on = |i: usize| r.data[i * r.channels as usize] >= threshold;
    let mut seen = vec![false; w * h];
    let mut count = 0;
    let mut stack = Vec::new();
    for start in 0..w * h {
        if seen[start] || !on(start) {
            continue;
        }
        count += 1;
        seen[start] = true;
        stack.push(start);
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            let mut visit = |j: usize| {
                if !seen[j] && on(j) {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
    }
    count
}
