//! CGLS (conjugate gradients on the normal equations) for `min ½‖T x − b‖²` with a matrix-free
//! operator T, optionally keeping x ≥ 0 (texels that would go negative are frozen at 0):
//! generic over [`Operator`], so a CPU reference and GPU passes share one solver. Used by
//! `LightMapSolve`; any node with a linear least-squares problem in RGB per unknown can use it.

use tyndall_engine::eval::NodeError;

/// What the solver needs from T: `T x` and `Tᵀ r` (RGB per texel / per constraint pixel).
pub trait Operator {
    /// Number of constraint pixels.
    fn rows(&self) -> usize;
    /// Number of light-map texels.
    fn texels(&self) -> usize;
    /// T x.
    fn forward(&mut self, x: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NodeError>;
    /// Tᵀ r.
    fn adjoint(&mut self, r: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NodeError>;
}

/// Solver settings (the node's parameters).
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// Iterations at most.
    pub iterations: u32,
    /// Relative tolerance on ‖Tᵀ r‖.
    pub tolerance: f64,
    /// Keep x ≥ 0.
    pub non_negative: bool,
    /// The constant start value.
    pub start: f32,
}

/// What a solve returns.
#[derive(Debug, Clone)]
pub struct Solution {
    /// The light map, RGB per texel (row-major, N×N).
    pub x: Vec<[f32; 3]>,
    /// ‖T x − b‖ at the start and after each iteration.
    pub residuals: Vec<f64>,
}

fn dot(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (0..3).map(|c| x[c] as f64 * y[c] as f64).sum::<f64>())
        .sum()
}

/// CGLS on `min ½‖T x − b‖²` with b = desired ⊙ T 1, from the constant start map (see the
/// module docs for the non-negativity rule). `progress` is called after each iteration with
/// (iteration, residual).
pub fn solve(
    op: &mut dyn Operator,
    desired: &[[f32; 3]],
    set: Settings,
    progress: &mut dyn FnMut(u32, f64),
) -> Result<Solution, NodeError> {
    let texels = op.texels();
    let ones = vec![[1.0f32; 3]; texels];
    let white = op.forward(&ones)?;
    let b: Vec<[f32; 3]> = desired
        .iter()
        .zip(&white)
        .map(|(d, w)| [d[0] * w[0], d[1] * w[1], d[2] * w[2]])
        .collect();
    let mut x = vec![[set.start; 3]; texels];
    let residual_of = |tx: &[[f32; 3]]| residual(&b, tx);
    let mut r = residual_of(&op.forward(&x)?);
    let mut residuals = vec![dot(&r, &r).sqrt()];
    if op.rows() == 0 || set.iterations == 0 {
        return Ok(Solution { x, residuals });
    }
    let mut s = op.adjoint(&r)?;
    let freeze = |x: &[[f32; 3]], s: &mut [[f32; 3]]| {
        if set.non_negative {
            freeze_descent(x, s);
        }
    };
    freeze(&x, &mut s);
    let s0 = dot(&s, &s).sqrt();
    let mut p = s.clone();
    let mut gamma = dot(&s, &s);
    for it in 0..set.iterations {
        if gamma.sqrt() <= set.tolerance * s0 || gamma == 0.0 {
            break;
        }
        // Exact minimiser along p: (Tᵀr · p)/‖T p‖² (p is 0 on frozen texels, where s and Tᵀr
        // differ); a direction that is no longer a descent one restarts from s.
        let mut sp = dot(&s, &p);
        if sp <= 0.0 {
            p = s.clone();
            sp = gamma;
        }
        let q = op.forward(&p)?;
        let qq = dot(&q, &q);
        if qq <= 0.0 {
            break;
        }
        let alpha = sp / qq;
        let a = alpha as f32;
        let full = step(&x, &p, a);
        let leaves = set.non_negative && full.iter().flatten().any(|v| *v < 0.0);
        let hit = if leaves {
            let last = residuals[residuals.len() - 1];
            (x, r) = feasible(op, &b, &x, &p, &full, alpha, last)?;
            true
        } else {
            x = full;
            for (ri, qi) in r.iter_mut().zip(&q) {
                for c in 0..3 {
                    ri[c] -= a * qi[c];
                }
            }
            false
        };
        let res = dot(&r, &r).sqrt();
        residuals.push(res);
        progress(it + 1, res);
        s = op.adjoint(&r)?;
        freeze(&x, &mut s);
        let new_gamma = dot(&s, &s);
        if hit {
            p = s.clone();
        } else {
            let beta = (new_gamma / gamma) as f32;
            for (pi, si) in p.iter_mut().zip(&s) {
                for c in 0..3 {
                    pi[c] = si[c] + beta * pi[c];
                }
            }
        }
        if set.non_negative {
            hold_frozen(&x, &s, &mut p);
        }
        gamma = new_gamma;
    }
    Ok(Solution { x, residuals })
}

/// b − T x, given T x.
fn residual(b: &[[f32; 3]], tx: &[[f32; 3]]) -> Vec<[f32; 3]> {
    b.iter()
        .zip(tx)
        .map(|(b, t)| [b[0] - t[0], b[1] - t[1], b[2] - t[2]])
        .collect()
}

/// The full step `full` = x + α p leaves x ≥ 0: project it back, and keep the projection if it
/// lowers the residual below `last`, else take the longest step that stays feasible (which
/// always does). Either way CG restarts after it. Returns the new x and its residual.
#[allow(clippy::type_complexity)]
fn feasible(
    op: &mut dyn Operator,
    b: &[[f32; 3]],
    x: &[[f32; 3]],
    p: &[[f32; 3]],
    full: &[[f32; 3]],
    alpha: f64,
    last: f64,
) -> Result<(Vec<[f32; 3]>, Vec<[f32; 3]>), NodeError> {
    let projected: Vec<[f32; 3]> = full.iter().map(|v| v.map(|c| c.max(0.0))).collect();
    let rp = residual(b, &op.forward(&projected)?);
    if dot(&rp, &rp).sqrt() < last {
        return Ok((projected, rp));
    }
    let limit = feasible_step(x, p, alpha);
    let x: Vec<[f32; 3]> = step(x, p, limit as f32)
        .into_iter()
        .map(|v| v.map(|c| c.max(0.0)))
        .collect();
    let r = residual(b, &op.forward(&x)?);
    Ok((x, r))
}

/// x + a·p.
fn step(x: &[[f32; 3]], p: &[[f32; 3]], a: f32) -> Vec<[f32; 3]> {
    x.iter()
        .zip(p)
        .map(|(xi, pi)| std::array::from_fn(|c| xi[c] + a * pi[c]))
        .collect()
}

/// The longest step along `p`, at most `alpha`, that keeps x ≥ 0.
fn feasible_step(x: &[[f32; 3]], p: &[[f32; 3]], alpha: f64) -> f64 {
    let mut limit = alpha;
    for (xi, pi) in x.iter().zip(p) {
        for c in 0..3 {
            if pi[c] < 0.0 {
                limit = limit.min((-(xi[c] as f64) / pi[c] as f64).max(0.0));
            }
        }
    }
    limit
}

/// Texels frozen at 0 (non-negativity): where x = 0 and the descent direction `s` points below
/// 0, `s` becomes 0.
fn freeze_descent(x: &[[f32; 3]], s: &mut [[f32; 3]]) {
    for (xi, si) in x.iter().zip(s.iter_mut()) {
        for c in 0..3 {
            if xi[c] <= 0.0 && si[c] < 0.0 {
                si[c] = 0.0;
            }
        }
    }
}

/// Frozen texels do not move: the search direction `p` is 0 where x = 0 and `s` was frozen.
fn hold_frozen(x: &[[f32; 3]], s: &[[f32; 3]], p: &mut [[f32; 3]]) {
    for ((pi, si), xi) in p.iter_mut().zip(s).zip(x) {
        for c in 0..3 {
            if xi[c] <= 0.0 && si[c] == 0.0 {
                pi[c] = 0.0;
            }
        }
    }
}
