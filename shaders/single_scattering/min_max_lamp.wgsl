// SingleScattering, method MinMax for spot and point lights (nodes/single_scattering/mod.rs):
// the walk over a spot's perspective map or a point light's cube faces.
#import single_scattering/pyramid

// ---- MinMax for a spot (local_kind 1) or a point light (2) --------------------------------
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
    let tc = dot(P.light.position - P.eye, dir);
    let h = max(length(P.eye + dir * tc - P.light.position), 1e-4);
    let au = atan((u - tc) / h);
    let av = atan((v - tc) / h);
    let n = u32(clamp(ceil(f32(P.steps) * (av - au) / PI), 1.0, f32(P.steps)));
    let dth = (av - au) / f32(n);
    var acc = vec3<f32>(0.0);
    for (var i = 0u; i < n; i++) {
        let t = tc + h * tan(au + (f32(i) + 0.5) * dth);
        let x = P.eye + dir * t;
        let l = P.light.position - x;
        var e = exp(-P.sigma_t * (t - t0));
        if extinction() {
            e *= exp(-P.sigma_t * local_light_path(x));
        }
        acc += phase(dot(dir, normalize(l))) * (local_falloff(x) * dot(l, l) * e);
    }
    return acc * (dth / h);
}

// The lit run being gathered along the ray: run.x < 0: none. A lit piece [a, b] extends it
// when it starts where the run ends, else the run is integrated and a new one opens.
fn add_lit(dir: vec3<f32>, t0: f32, a: f32, b: f32, run: ptr<function, vec2<f32>>, lit: ptr<function, f32>, acc: ptr<function, vec3<f32>>) {
    if b <= a {
        return;
    }
    *lit += b - a;
    if (*run).x >= 0.0 && (*run).y != a {
        *acc += lamp_integral(dir, t0, (*run).x, (*run).y);
        (*run).x = -1.0;
    }
    if (*run).x < 0.0 {
        (*run).x = a;
    }
    (*run).y = b;
}

// A shadow closes the run: integrate it.
fn close_run(dir: vec3<f32>, t0: f32, run: ptr<function, vec2<f32>>, acc: ptr<function, vec3<f32>>) {
    if (*run).x >= 0.0 {
        *acc += lamp_integral(dir, t0, (*run).x, (*run).y);
        (*run).x = -1.0;
    }
}

// One settled step [t, t_exit] (`step`) of a lamp's walk: its lit piece [la, lb] (`piece`;
// lb ≤ la: none), whether a shadow precedes the piece (`opens`: the run so far ends first) or
// follows it (`closes`), or (`frac` > 0, or both flags) a mixed block lit by share `frac`,
// integrated alone. The run and the sums are the walk's locals. At most one integral per step
// (each inlined integral costs lavapipe registers and time).
fn settle(dir: vec3<f32>, t0: f32, step: vec2<f32>, piece: vec2<f32>, opens: bool, closes: bool, frac: f32, run_a: ptr<function, f32>, run_b: ptr<function, f32>, lit_sum: ptr<function, f32>, acc_sum: ptr<function, vec3<f32>>) {
    let t = step.x;
    let t_exit = step.y;
    let la = piece.x;
    let lb = piece.y;
    var fa = -1.0;
    var fb = -1.0;
    var weight = 1.0;
    if (opens || (lb > la && *run_a >= 0.0 && *run_b != la)) && *run_a >= 0.0 {
        fa = *run_a;
        fb = *run_b;
        *run_a = -1.0;
    }
    if frac > 0.0 || (opens && closes) {
        // The weighted block: integrated alone (after the run before it).
        *lit_sum += (t_exit - t) * frac;
        if fa < 0.0 {
            fa = t;
            fb = t_exit;
            weight = frac;
        } else {
            *acc_sum += lamp_integral(dir, t0, t, t_exit) * frac;
        }
    } else {
        if lb > la {
            *lit_sum += lb - la;
            if *run_a < 0.0 {
                *run_a = la;
            }
            *run_b = lb;
        }
        if closes && *run_a >= 0.0 && fa < 0.0 {
            fa = *run_a;
            fb = *run_b;
            *run_a = -1.0;
        }
    }
    if fa >= 0.0 {
        *acc_sum += lamp_integral(dir, t0, fa, fb) * weight;
    }
}

// [t_a, t_b]: the part of [t0, t1] inside a map's frustum, the ray's clip position c0 + dc t
// (|x|, |y| ≤ w, z ≥ 0, w > 0; not bounded by the far plane: an occluder shadows what lies
// behind it at any distance); t_b ≤ t_a when it misses.
fn frustum_part(t0: f32, t1: f32, c0: vec4<f32>, dc: vec4<f32>) -> vec2<f32> {
    var r = vec2<f32>(t0, t1);
    clip_half(&r, c0.w - c0.x, dc.w - dc.x);
    clip_half(&r, c0.w + c0.x, dc.w + dc.x);
    clip_half(&r, c0.w - c0.y, dc.w - dc.y);
    clip_half(&r, c0.w + c0.y, dc.w + dc.y);
    clip_half(&r, c0.z, dc.z);
    clip_half(&r, c0.w - 1e-4, dc.w);
    return r;
}

// The pyramid walk over one perspective map of `res` texels at `origin` in the shadow texture
// (a spot's whole map, or one face of a point light's atlas, whose cells are kept inside it),
// for the ray's part [ta, tb] in that map's frustum, its clip position c0 + dc t: lit pieces go
// to the run, shadows close it.
fn walk_map(dir: vec3<f32>, t0: f32, ta: f32, tb: f32, c0: vec4<f32>, dc: vec4<f32>, origin: vec2<f32>, res: vec2<f32>, top: u32, run: ptr<function, vec2<f32>>, lit: ptr<function, f32>, acc: ptr<function, vec3<f32>>) {
    let ca = c0 + dc * ta;
    let cb = c0 + dc * tb;
    let pa = origin + vec2<f32>((ca.x / ca.w * 0.5 + 0.5) * res.x, (0.5 - ca.y / ca.w * 0.5) * res.y);
    let pb = origin + vec2<f32>((cb.x / cb.w * 0.5 + 0.5) * res.x, (0.5 - cb.y / cb.w * 0.5) * res.y);
    let d = pb - pa;
    let wa = ca.w;
    let wb = cb.w;
    let span = tb - ta;
    let msz = vec2<u32>(textureDimensions(shadow));
    // The run and the sums live in locals through the loop (copied back at the end).
    var run_a = (*run).x;
    var run_b = (*run).y;
    var lit_sum = *lit;
    var acc_sum = *acc;
    var level = top;
    var sg = 0.0;
    var t = ta;
    var iter = 0u;
    let nudge = sign(d) * 1e-3;
    // The smallest step in σ: 1e-3 texel (a position rounded just past the map's edge would
    // otherwise find its clamped cell behind it and never move).
    let min_step = 1e-3 / max(max(abs(d.x), abs(d.y)), 1e-6);
    while sg < 1.0 && iter < MAX_ITER {
        iter++;
        let scale = f32(1u << level);
        let q = pa + d * sg;
        var dims = msz;
        if level > 0u {
            dims = L.rect[level].zw;
        }
        // The cells of this map at this level (a face's, inside the atlas).
        let lo = vec2<u32>(origin / scale);
        let hi = min(vec2<u32>(ceil((origin + res) / scale)), dims) - 1u;
        let cell = clamp(vec2<u32>(max(floor((q + nudge) / scale), vec2<f32>(0.0))), lo, hi);
        let cell_lo = max(vec2<f32>(cell) * scale, origin);
        let cell_hi = min(vec2<f32>(cell) * scale + scale, origin + res);
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
        // The lit piece [la, lb] of this step (lb ≤ la: none), whether a shadow precedes it
        // (`opens`: the run so far ends first) or follows it (`closes`).
        var la = 0.0;
        var lb = -1.0;
        var opens = false;
        var closes = false;
        var settled = true;
        // Go up a level after this step (not after a mixed texel: the sun's rule).
        var go_up = true;
        var frac = 0.0;
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
                opens = true;
                la = t_exit - part;
                lb = t_exit;
            }
        } else if level <= P.min_level && mm.y < SHADOW_CLEAR {
            // Quality knob, as for the sun: a mixed block's occluders spread evenly (the block
            // is its own run, weighted); a block with clear texels is refined.
            let zm = 0.5 * (z0 + z1);
            frac = clamp((mm.y + P.bias - zm) / max(mm.y - mm.x, 1e-6), 0.0, 1.0);
            opens = true;
            closes = true;
            la = t;
            lb = t_exit;
        } else {
            settled = false;
            level -= 1u;
        }
        if settled {
            settle(dir, t0, vec2<f32>(t, t_exit), vec2<f32>(la, lb), opens, closes, frac, &run_a, &run_b, &lit_sum, &acc_sum);
            sg = s_exit;
            t = t_exit;
            if go_up {
                level = up;
            }
        }
    }
    *run = vec2<f32>(run_a, run_b);
    *lit = lit_sum;
    *acc = acc_sum;
    // Safety net for pathological rays: sample what is left.
    if t < tb {
        let n = 64u;
        let dt = (tb - t) / f32(n);
        for (var i = 0u; i < n; i++) {
            let a = t + f32(i) * dt;
            if visible(P.eye + dir * (a + 0.5 * dt)) > 0.0 {
                add_lit(dir, t0, a, a + dt, run, lit, acc);
            } else {
                close_run(dir, t0, run, acc);
            }
        }
    }
}

// A spot (its map) or a point light (each face of its 3 × 2 atlas that the ray crosses, in
// order along the ray; a face's clip position is (s·x, u·x, (f·x − near)/(far − near), f·x) with
// x the point relative to the light and (f, s, u) the face's frame, a 90° perspective). Between
// and beyond the maps' frusta the ray is lit.
fn min_max_local(p: vec2<u32>, dir: vec3<f32>, s: f32) {
    let seg = medium_segment(dir, s);
    let t0 = seg.x;
    let t1 = max(seg.y, seg.x);
    let len = t1 - t0;
    let msize = vec2<f32>(textureDimensions(shadow));
    var lit = 0.0;
    var acc = vec3<f32>(0.0);
    var run = vec2<f32>(-1.0, -1.0);
    var cursor = t0;
    let point = POINT && P.light.kind == 2u;
    let face_res = vec2<f32>(msize.x / 3.0, msize.y / 2.0);
    // The pyramid levels whose cells stay inside one face.
    let face_top = min(L.count, u32(floor(log2(max(face_res.x, 1.0)))));
    let e0 = P.eye - P.light.position;
    let span = P.light.far - P.light.near;
    var done = 0u;
    // One map for a spot; for a point light the faces the ray crosses, in order along it. (One
    // call of the walk: a second copy of it costs lavapipe registers and time.)
    for (var k = 0u; k < select(1u, 6u, point); k++) {
        var c0 = P.light.view_proj * vec4<f32>(P.eye, 1.0);
        var dc = P.light.view_proj * vec4<f32>(P.eye + dir, 1.0) - c0;
        var r = frustum_part(t0, t1, c0, dc);
        var origin = vec2<f32>(0.0);
        var res = msize;
        var top = L.count;
        if point {
            // The next face along the ray: the smallest entry among those not walked yet.
            var best = 6u;
            for (var f = 0u; f < 6u; f++) {
                if (done & (1u << f)) != 0u {
                    continue;
                }
                let fr = cube_frame(f);
                let fc0 = vec4<f32>(dot(fr[1], e0), dot(fr[2], e0), (dot(fr[0], e0) - P.light.near) / span, dot(fr[0], e0));
                let fdc = vec4<f32>(dot(fr[1], dir), dot(fr[2], dir), dot(fr[0], dir) / span, dot(fr[0], dir));
                let fr_t = frustum_part(t0, t1, fc0, fdc);
                if fr_t.y > fr_t.x && (best == 6u || fr_t.x < r.x) {
                    best = f;
                    r = fr_t;
                    c0 = fc0;
                    dc = fdc;
                }
            }
            if best == 6u {
                break;
            }
            done |= 1u << best;
            origin = vec2<f32>(f32(best % 3u), f32(best / 3u)) * face_res;
            res = face_res;
            top = face_top;
        }
        let ta = max(r.x, cursor);
        if r.y > ta {
            add_lit(dir, t0, cursor, ta, &run, &lit, &acc);
            walk_map(dir, t0, ta, r.y, c0, dc, origin, res, top, &run, &lit, &acc);
            cursor = r.y;
        }
    }
    add_lit(dir, t0, cursor, t1, &run, &lit, &acc);
    close_run(dir, t0, &run, &acc);
    store_lamp(p, select(1.0, clamp(lit / len, 0.0, 1.0), len > 0.0), len, acc);
}

// The outputs of pixel p lit by a lamp: V̄, the in-scatter from the integral `acc` (without
// radiance, σt and albedo) and the transmittance over the medium length `len`.
fn store_lamp(p: vec2<u32>, vbar: f32, len: f32, acc: vec3<f32>) {
    textureStore(out_vis, p, vec4<f32>(vbar, 0.0, 0.0, 1.0));
    textureStore(out_inscatter, p, vec4<f32>(P.light.radiance * (P.sigma_t * P.albedo) * acc, 1.0));
    textureStore(out_transmittance, p, vec4<f32>(exp(-len * P.sigma_t), 0.0, 0.0, 1.0));
}
