// SingleScattering, method Epipolar for a spot (local_kind 1; nodes/single_scattering/epipolar.rs):
// a sample ray's walk through its slice's 1D min-max tree over the spot's perspective map.
#import single_scattering/epipolar_tree

// ---- Epipolar for a spot -----------------------------------------------------------------
//
// Every view ray of a slice lies in the plane through the eye, the spot and the slice's screen
// line, and a plane through the spot is imaged by its perspective map as one line: the slice's
// row of texels (rectified and treed exactly as the sun's). Along a ray the map position is
// projective in t but affine in the map-line parameter σ (from the ray's frustum entry t_a to
// its exit t_b), t(σ) = t_a + (t_b − t_a) σ w_a / ((1 − σ) w_b + σ w_a) as in MinMax, and the
// linear depth is affine in t: the tree walk runs in σ and settles each node by the depth at
// its two ends, a mixed leaf walks its own texels one per step, and the lit runs are integrated
// as MinMax's (`settle`). A sample keeps V̄ and ρ, the lit share of its unshadowed in-scatter
// integral; a pixel then takes ρ from the samples (the shadows vary slowly along a slice) and
// integrates its own unshadowed in-scatter (the falloff and phase, which vary quickly near the
// light, are the pixel's own).

// The lamp's in-scatter integral over the ray's whole medium segment [t0, t1], as if unshadowed.
fn lamp_unshadowed(dir: vec3<f32>, s: f32) -> vec3<f32> {
    let seg = medium_segment(dir, s);
    return lamp_integral(dir, seg.x, seg.x, max(seg.y, seg.x));
}

// The tree walk of the ray's part [ta, tb] inside the spot's frustum (clip position c0 + dc t)
// along slice k's map line (`line`): lit pieces go to the run, shadows close it.
fn lamp_tree_walk(k: u32, line: vec4<f32>, dir: vec3<f32>, t0: f32, ta: f32, tb: f32, c0: vec4<f32>, dc: vec4<f32>, run: ptr<function, vec2<f32>>, lit: ptr<function, f32>, acc: ptr<function, vec3<f32>>) {
    let msize = vec2<f32>(textureDimensions(shadow));
    let ca = c0 + dc * ta;
    let cb = c0 + dc * tb;
    let pa = vec2<f32>((ca.x / ca.w * 0.5 + 0.5) * msize.x, (0.5 - ca.y / ca.w * 0.5) * msize.y);
    let pb = vec2<f32>((cb.x / cb.w * 0.5 + 0.5) * msize.x, (0.5 - cb.y / cb.w * 0.5) * msize.y);
    let d = pb - pa;
    let wa = ca.w;
    let wb = cb.w;
    let span = tb - ta;
    // Position along the line: b(σ) = b0 + bd σ.
    let b0 = dot(pa - line.xy, line.zw);
    let bd = dot(d, line.zw);
    let nudge_b = select(-1e-3, 1e-3, bd > 0.0);
    let nudge = sign(d) * 1e-3;
    let min_step = 1e-3 / max(max(abs(d.x), abs(d.y)), 1e-6);
    let n = E.tree_n;
    let top = E.tree_top;
    let row = k * 2u * n;
    var run_a = (*run).x;
    var run_b = (*run).y;
    var lit_sum = *lit;
    var acc_sum = *acc;
    var level = top;
    var sg = 0.0;
    var t = ta;
    var iter = 0u;
    // Walking a mixed leaf's own texels up to this σ (≤ sg: not).
    var leaf_end = -1.0;
    while sg < 1.0 && iter < MAX_ITER {
        iter++;
        var s_exit = 1.0;
        var la = 0.0;
        var lb = -1.0;
        var opens = false;
        var closes = false;
        var frac = 0.0;
        var settled = true;
        var next_level = level;
        // One texel of a mixed leaf (at the iteration cap: the rest of the ray against the
        // texel it is in), else one tree node: its σ exit and its depth bounds.
        var texel = leaf_end > sg || iter == MAX_ITER;
        var mm = vec2<f32>(0.0);
        var up = level;
        if texel {
            let cell = floor(pa + d * sg + nudge);
            s_exit = select(leaf_end, 1.0, iter == MAX_ITER);
            for (var a = 0; a < 2; a++) {
                if d[a] > 1e-12 {
                    s_exit = min(s_exit, (cell[a] + 1.0 - pa[a]) / d[a]);
                } else if d[a] < -1e-12 {
                    s_exit = min(s_exit, (cell[a] - pa[a]) / d[a]);
                }
            }
            s_exit = select(s_exit, 1.0, iter == MAX_ITER);
            mm = vec2<f32>(map_depth(cell));
        } else {
            let scale = f32(1u << level);
            let width = n >> level;
            let idx = min(u32(max(floor((b0 + bd * sg + nudge_b) / scale), 0.0)), width - 1u);
            if bd > 1e-12 {
                s_exit = min(s_exit, (f32(idx + 1u) * scale - b0) / bd);
            } else if bd < -1e-12 {
                s_exit = min(s_exit, (f32(idx) * scale - b0) / bd);
            }
            mm = tree[row + 2u * n - 2u * width + idx];
            let next = u32(max(floor((b0 + bd * s_exit + nudge_b) / (2.0 * scale)), 0.0));
            up = select(level, min(level + 1u, top), next != (idx >> 1u));
        }
        s_exit = select(s_exit, min(sg + min_step, 1.0), s_exit <= sg);
        let t_exit = select(ta + span * s_exit * wa / ((1.0 - s_exit) * wb + s_exit * wa), tb, s_exit >= 1.0);
        let z0 = c0.z + dc.z * t;
        let z1 = c0.z + dc.z * t_exit;
        if texel {
            // Exact: the lit length of a texel whose depth the ray crosses at most once.
            let c = mm.x + P.bias;
            let part = lit_part(t, t_exit, z0, z1, c);
            if part >= t_exit - t {
                la = t;
                lb = t_exit;
            } else if part <= 0.0 {
                closes = true;
            } else if z0 <= c {
                la = t;
                lb = t + part;
                closes = true;
            } else {
                opens = true;
                la = t_exit - part;
                lb = t_exit;
            }
        } else if max(z0, z1) <= mm.x + P.bias {
            la = t;
            lb = t_exit;
            next_level = up;
        } else if min(z0, z1) > mm.y + P.bias {
            closes = true;
            next_level = up;
        } else if level > 0u && level <= E.tree_level && mm.y < SHADOW_CLEAR {
            // Quality knob: a mixed node's occluders spread evenly (weighted, its own run); a
            // node with clear texels is refined.
            let zm = 0.5 * (z0 + z1);
            frac = clamp((mm.y + P.bias - zm) / max(mm.y - mm.x, 1e-6), 0.0, 1.0);
            opens = true;
            closes = true;
            la = t;
            lb = t_exit;
            next_level = up;
        } else if level == 0u {
            settled = false;
            leaf_end = s_exit;
        } else {
            settled = false;
            level -= 1u;
        }
        if settled {
            settle(dir, t0, vec2<f32>(t, t_exit), vec2<f32>(la, lb), opens, closes, frac, &run_a, &run_b, &lit_sum, &acc_sum);
            sg = s_exit;
            t = t_exit;
            level = next_level;
        }
    }
    *run = vec2<f32>(run_a, run_b);
    *lit = lit_sum;
    *acc = acc_sum;
}

// A sample ray of slice k (`line`: its map line) lit by the spot: (V̄, ρ the lit share of its
// unshadowed in-scatter integral (1 where that is 0), medium length). Outside the spot's
// frustum the ray is lit.
fn lamp_tree_ray(k: u32, line: vec4<f32>, dir: vec3<f32>, s: f32) -> vec3<f32> {
    let seg = medium_segment(dir, s);
    let t0 = seg.x;
    let t1 = max(seg.y, seg.x);
    let len = t1 - t0;
    let c0 = P.light.view_proj * vec4<f32>(P.eye, 1.0);
    let dc = P.light.view_proj * vec4<f32>(P.eye + dir, 1.0) - c0;
    let r = frustum_part(t0, t1, c0, dc);
    let ta = clamp(r.x, t0, t1);
    let tb = clamp(r.y, ta, t1);
    var lit = 0.0;
    var acc = vec3<f32>(0.0);
    var run = vec2<f32>(-1.0, -1.0);
    add_lit(dir, t0, t0, ta, &run, &lit, &acc);
    if tb > ta {
        lamp_tree_walk(k, line, dir, t0, ta, tb, c0, dc, &run, &lit, &acc);
    }
    add_lit(dir, t0, tb, t1, &run, &lit, &acc);
    close_run(dir, t0, &run, &acc);
    let full = dot(lamp_integral(dir, t0, t0, t1), vec3<f32>(1.0));
    let rho = select(1.0, clamp(dot(acc, vec3<f32>(1.0)) / full, 0.0, 1.0), full > 0.0);
    return vec3<f32>(select(1.0, clamp(lit / len, 0.0, 1.0), len > 0.0), rho, len);
}
