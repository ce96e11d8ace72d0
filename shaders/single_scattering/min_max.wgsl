// SingleScattering, method MinMax: the pyramid of the shadow map and its traversal
// (nodes/single_scattering/map_ray.rs, gpu.rs).
#import single_scattering/map_ray

// ---- Method MinMax: a min-max pyramid of the shadow map, traversed hierarchically ----------
//
// Level 0 is the map itself; levels 1.. live in one RG32F atlas (min, max of the 2^k × 2^k
// texels below), level k at rect[k] = (x offset, y offset, width, height). Along a view ray the
// light-space position is affine in t, so over any stretch of the ray inside one pyramid cell
// the ray's depth is bounded by its values at the ends: a cell whose max depth bound the ray
// stays under is lit throughout, one whose min the ray stays above is shadowed throughout, and
// only mixed cells are refined, down to single texels where the lit part is solved exactly.
// The result is the exact average of the brute-force visibility (nearest texel, same bias) as
// its number of steps goes to infinity.

struct Levels {
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    rect: array<vec4<u32>, 16>,
}

struct Build {
    level: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    src: vec4<u32>,
    dst: vec4<u32>,
}

@group(0) @binding(6) var atlas: texture_2d<f32>;
@group(0) @binding(7) var<uniform> B: Build;
@group(0) @binding(8) var build_src: texture_2d<f32>;
@group(0) @binding(9) var build_dst: texture_storage_2d<rg32float, write>;
@group(0) @binding(10) var<uniform> L: Levels;

// One level of the pyramid: level 1 reads the map (min = max = depth), later levels the atlas.
@compute @workgroup_size(8, 8)
fn build_level(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= B.dst.z || id.y >= B.dst.w {
        return;
    }
    var mn = 3.0e38;
    var mx = -3.0e38;
    for (var b = 0u; b < 2u; b++) {
        for (var a = 0u; a < 2u; a++) {
            let c = min(id.xy * 2u + vec2<u32>(a, b), B.src.zw - 1u);
            let v = textureLoad(build_src, B.src.xy + c, 0);
            if B.level == 1u {
                mn = min(mn, v.r);
                mx = max(mx, v.r);
            } else {
                mn = min(mn, v.r);
                mx = max(mx, v.g);
            }
        }
    }
    textureStore(build_dst, B.dst.xy + id.xy, vec4<f32>(mn, mx, 0.0, 1.0));
}

// The MinMax traversal of one view ray (direction `dir`, surface at `s`): (V̄, medium length,
// extinction-weighted lit integral).
fn min_max_ray(dir: vec3<f32>, s: f32) -> vec3<f32> {
    let r = map_ray(dir, s);
    let a = r.a;
    let d = r.d;
    let t0 = r.t0;
    let tout = r.tout;
    let ext = extinction();
    let msize = vec2<f32>(textureDimensions(shadow));
    var lit = 0.0;
    var weighted = 0.0;
    if tout > r.tin {
        let top = L.count;
        var level = top;
        var t = r.tin;
        var iter = 0u;
        let nudge = sign(d.xy) * 1e-3;
        let msz = vec2<u32>(msize);
        while t < tout && iter < MAX_ITER {
            iter++;
            let scale = f32(1u << level);
            let p = a + d * t;
            var dims = msz;
            if level > 0u {
                dims = L.rect[level].zw;
            }
            let cell = min(vec2<u32>(max(floor((p.xy + nudge) / scale), vec2<f32>(0.0))), dims - 1u);
            let cell_lo = vec2<f32>(cell) * scale;
            let cell_hi = cell_lo + scale;
            var t_exit = tout;
            for (var k = 0; k < 2; k++) {
                if d[k] > 1e-12 {
                    t_exit = min(t_exit, (cell_hi[k] - a[k]) / d[k]);
                } else if d[k] < -1e-12 {
                    t_exit = min(t_exit, (cell_lo[k] - a[k]) / d[k]);
                }
            }
            t_exit = max(t_exit, t);
            let z0 = a.z + d.z * t;
            let z1 = a.z + d.z * t_exit;
            var mm: vec2<f32>;
            if level == 0u {
                mm = vec2<f32>(textureLoad(shadow, cell, 0).r);
            } else {
                mm = textureLoad(atlas, L.rect[level].xy + cell, 0).rg;
            }
            // After a block is settled, go up a level only when the ray leaves the parent
            // block too: the parent of the next block, if it is the same, was found mixed.
            let next = a.xy + d.xy * t_exit + nudge;
            let parent_changes = any(vec2<u32>(max(floor(next / (2.0 * scale)), vec2<f32>(0.0))) != (cell >> vec2<u32>(1u)));
            let up = select(level, min(level + 1u, top), parent_changes);
            if max(z0, z1) <= mm.x + P.bias {
                lit += t_exit - t;
                if ext {
                    weighted += weight(dir, t0, t, t_exit);
                }
                t = t_exit;
                level = up;
            } else if min(z0, z1) > mm.y + P.bias {
                t = t_exit;
                level = up;
            } else if level == 0u {
                let part = lit_part(t, t_exit, z0, z1, mm.x + P.bias);
                lit += part;
                if ext {
                    // The lit part is at the end where the depth is under the occluder.
                    if z0 <= mm.x + P.bias {
                        weighted += weight(dir, t0, t, t + part);
                    } else {
                        weighted += weight(dir, t0, t_exit - part, t_exit);
                    }
                }
                t = t_exit;
            } else if level <= P.min_level {
                // Quality knob: estimate a mixed block instead of refining it, taking its
                // occluder depth as spread evenly over [min, max].
                let zm = 0.5 * (z0 + z1);
                let frac = clamp((mm.y + P.bias - zm) / max(mm.y - mm.x, 1e-6), 0.0, 1.0);
                lit += (t_exit - t) * frac;
                if ext {
                    weighted += weight(dir, t0, t, t_exit) * frac;
                }
                t = t_exit;
                level = up;
            } else {
                level -= 1u;
            }
        }
        // Safety net for pathological rays: sample what is left.
        if t < tout {
            let n = 64u;
            for (var i = 0u; i < n; i++) {
                let ti = t + (f32(i) + 0.5) / f32(n) * (tout - t);
                let v = visible(P.eye + dir * ti);
                lit += v * (tout - t) / f32(n);
                if ext && v > 0.0 {
                    let a = t + f32(i) / f32(n) * (tout - t);
                    weighted += weight(dir, t0, a, a + (tout - t) / f32(n));
                }
            }
        }
    }
    return ray_result(r, dir, lit, weighted);
}

// ---- MinMax for a spot light (local_kind 1) ----------------------------------------------
//
// The spot's map is perspective with linear depth: along a view ray its homogeneous clip
// position c(t) = c0 + (c1 − c0) t is affine in t, the depth z(t) = c.z too, but the map
// position c.xy / c.w is not. The ray's image is still a straight line in the map, though, and
// with σ ∈ [0, 1] along it from the map point at t_a to the one at t_b,
//   t(σ) = t_a + (t_b − t_a) σ w_a / ((1 − σ) w_b + σ w_a)      (w = c.w > 0 in the map),
// so the pyramid walk runs in σ as the sun's does in t, each cell's exit converted to t, where
// the depth is affine again: a cell is settled by its depths at the two ends exactly as for the
// sun, and the lit stretches are exact. What is lit is then integrated — the lamp's falloff and
// phase change along the ray — equiangularly: with θ the angle seen from the light's closest
// approach to the ray (distance h, at t_c), dt / d² = dθ / h, so the inverse square leaves the
// integrand and what is left (cone, range, phase, extinction) is smooth; `steps` midpoint nodes
// per π of θ, at least one per lit stretch. Outside the map's frustum the ray is lit.

// Narrow `r` to where f0 + f1 t ≥ 0.
fn clip_half(r: ptr<function, vec2<f32>>, f0: f32, f1: f32) {
    if abs(f1) < 1e-12 {
        if f0 < 0.0 {
            (*r).y = (*r).x - 1.0;
        }
        return;
    }
    let t = -f0 / f1;
    if f1 > 0.0 {
        (*r).x = max((*r).x, t);
    } else {
        (*r).y = min((*r).y, t);
    }
}

// ∫_u^v of the lamp's in-scatter integrand (without radiance, σt and albedo) along `dir`,
// entering the medium at t0.
fn lamp_integral(dir: vec3<f32>, t0: f32, u: f32, v: f32) -> vec3<f32> {
    if v <= u {
        return vec3<f32>(0.0);
    }
    let tc = dot(P.light_pos - P.eye, dir);
    let h = max(length(P.eye + dir * tc - P.light_pos), 1e-4);
    let au = atan((u - tc) / h);
    let av = atan((v - tc) / h);
    let n = u32(clamp(ceil(f32(P.steps) * (av - au) / PI), 1.0, f32(P.steps)));
    let dth = (av - au) / f32(n);
    var acc = vec3<f32>(0.0);
    for (var i = 0u; i < n; i++) {
        let t = tc + h * tan(au + (f32(i) + 0.5) * dth);
        let x = P.eye + dir * t;
        let l = P.light_pos - x;
        var e = exp(-P.sigma_t * (t - t0));
        if extinction() {
            e *= exp(-P.sigma_t * local_light_path(x));
        }
        acc += phase(dot(dir, normalize(l))) * (local_falloff(x) * dot(l, l) * e);
    }
    return acc * (dth / h);
}

fn min_max_spot(p: vec2<u32>, dir: vec3<f32>, s: f32) {
    let seg = medium_segment(dir, s);
    let t0 = seg.x;
    let t1 = max(seg.y, seg.x);
    let len = t1 - t0;
    let c0 = P.light_view_proj * vec4<f32>(P.eye, 1.0);
    let dc = P.light_view_proj * vec4<f32>(P.eye + dir, 1.0) - c0;
    // [t_a, t_b]: the part of [t0, t1] inside the map's frustum (|x|, |y| ≤ w, 0 ≤ z ≤ 1, w > 0).
    var r = vec2<f32>(t0, t1);
    clip_half(&r, c0.w - c0.x, dc.w - dc.x);
    clip_half(&r, c0.w + c0.x, dc.w + dc.x);
    clip_half(&r, c0.w - c0.y, dc.w - dc.y);
    clip_half(&r, c0.w + c0.y, dc.w + dc.y);
    clip_half(&r, c0.z, dc.z);
    clip_half(&r, 1.0 - c0.z, -dc.z);
    clip_half(&r, c0.w - 1e-4, dc.w);
    var lit = len;
    var acc = vec3<f32>(0.0);
    if r.y > r.x {
        let ta = r.x;
        let tb = r.y;
        lit = (ta - t0) + (t1 - tb);
        acc = lamp_integral(dir, t0, t0, ta) + lamp_integral(dir, t0, tb, t1);
        let msize = vec2<f32>(textureDimensions(shadow));
        let ca = c0 + dc * ta;
        let cb = c0 + dc * tb;
        let pa = vec2<f32>((ca.x / ca.w * 0.5 + 0.5) * msize.x, (0.5 - ca.y / ca.w * 0.5) * msize.y);
        let pb = vec2<f32>((cb.x / cb.w * 0.5 + 0.5) * msize.x, (0.5 - cb.y / cb.w * 0.5) * msize.y);
        let d = pb - pa;
        let wa = ca.w;
        let wb = cb.w;
        let span = tb - ta;
        let top = L.count;
        var level = top;
        var sg = 0.0;
        var t = ta;
        var iter = 0u;
        let nudge = sign(d) * 1e-3;
        // The smallest step in σ: 1e-3 texel (a position rounded just past the map's edge
        // would otherwise find its clamped cell behind it and never move).
        let min_step = 1e-3 / max(max(abs(d.x), abs(d.y)), 1e-6);
        let msz = vec2<u32>(msize);
        // The lit run being gathered, [run_a, run_b] (run_a < 0: none): consecutive lit pieces
        // are integrated once, when a shadow (or the end) closes the run.
        var run_a = -1.0;
        var run_b = -1.0;
        while sg < 1.0 && iter < MAX_ITER {
            iter++;
            let scale = f32(1u << level);
            let q = pa + d * sg;
            var dims = msz;
            if level > 0u {
                dims = L.rect[level].zw;
            }
            let cell = min(vec2<u32>(max(floor((q + nudge) / scale), vec2<f32>(0.0))), dims - 1u);
            let cell_lo = vec2<f32>(cell) * scale;
            let cell_hi = cell_lo + scale;
            var s_exit = 1.0;
            for (var k = 0; k < 2; k++) {
                if d[k] > 1e-12 {
                    s_exit = min(s_exit, (cell_hi[k] - pa[k]) / d[k]);
                } else if d[k] < -1e-12 {
                    s_exit = min(s_exit, (cell_lo[k] - pa[k]) / d[k]);
                }
            }
            s_exit = select(s_exit, min(sg + min_step, 1.0), s_exit <= sg);
            let t_exit = select(ta + span * s_exit * wa / ((1.0 - s_exit) * wb + s_exit * wa), tb, s_exit >= 1.0);
            let z0 = c0.z + dc.z * t;
            let z1 = c0.z + dc.z * t_exit;
            var mm: vec2<f32>;
            if level == 0u {
                mm = vec2<f32>(textureLoad(shadow, cell, 0).r);
            } else {
                mm = textureLoad(atlas, L.rect[level].xy + cell, 0).rg;
            }
            let next = pa + d * s_exit + nudge;
            let parent_changes = any(vec2<u32>(max(floor(next / (2.0 * scale)), vec2<f32>(0.0))) != (cell >> vec2<u32>(1u)));
            let up = select(level, min(level + 1u, top), parent_changes);
            // The lit piece [la, lb] of this step (lb ≤ la: none) and whether a shadow follows
            // it within the step.
            var la = 0.0;
            var lb = -1.0;
            var closes = false;
            var settled = true;
            // Go up a level after this step (not after a mixed texel: the sun's rule).
            var go_up = true;
            if max(z0, z1) <= mm.x + P.bias {
                la = t;
                lb = t_exit;
            } else if min(z0, z1) > mm.y + P.bias {
                closes = true;
            } else if level == 0u {
                go_up = false;
                let part = lit_part(t, t_exit, z0, z1, mm.x + P.bias);
                if z0 <= mm.x + P.bias {
                    la = t;
                    lb = t + part;
                    closes = true;
                } else {
                    // The shadow comes first: it closes the run before this piece opens one.
                    if run_a >= 0.0 {
                        acc += lamp_integral(dir, t0, run_a, run_b);
                        run_a = -1.0;
                    }
                    la = t_exit - part;
                    lb = t_exit;
                }
            } else if level <= P.min_level {
                // Quality knob, as for the sun: a mixed block's occluders spread evenly.
                let zm = 0.5 * (z0 + z1);
                let frac = clamp((mm.y + P.bias - zm) / max(mm.y - mm.x, 1e-6), 0.0, 1.0);
                if run_a >= 0.0 {
                    acc += lamp_integral(dir, t0, run_a, run_b);
                    run_a = -1.0;
                }
                lit += (t_exit - t) * frac;
                acc += lamp_integral(dir, t0, t, t_exit) * frac;
            } else {
                settled = false;
                level -= 1u;
            }
            if settled {
                if lb > la {
                    lit += lb - la;
                    if run_a < 0.0 {
                        run_a = la;
                    }
                    run_b = lb;
                }
                if closes && run_a >= 0.0 {
                    acc += lamp_integral(dir, t0, run_a, run_b);
                    run_a = -1.0;
                }
                sg = s_exit;
                t = t_exit;
                if go_up {
                    level = up;
                }
            }
        }
        if run_a >= 0.0 {
            acc += lamp_integral(dir, t0, run_a, run_b);
        }
        // Safety net for pathological rays: sample what is left.
        if t < tb {
            let n = 64u;
            let dt = (tb - t) / f32(n);
            for (var i = 0u; i < n; i++) {
                let a = t + f32(i) * dt;
                if visible(P.eye + dir * (a + 0.5 * dt)) > 0.0 {
                    lit += dt;
                    acc += lamp_integral(dir, t0, a, a + dt);
                }
            }
        }
    } else {
        acc = lamp_integral(dir, t0, t0, t1);
    }
    let vbar = select(1.0, clamp(lit / len, 0.0, 1.0), len > 0.0);
    textureStore(out_vis, p, vec4<f32>(vbar, 0.0, 0.0, 1.0));
    textureStore(out_inscatter, p, vec4<f32>(P.radiance * (P.sigma_t * P.albedo) * acc, 1.0));
    textureStore(out_transmittance, p, vec4<f32>(exp(-len * P.sigma_t), 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn min_max(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
    if LOCAL && P.local_kind == 1u {
        min_max_spot(id.xy, dir, textureLoad(depth, id.xy, 0).r);
        return;
    }
    let r = min_max_ray(dir, textureLoad(depth, id.xy, 0).r);
    store(id.xy, dir, r.x, r.y, r.z);
}
