// SingleScattering, method Epipolar (nodes/single_scattering/epipolar.rs): the sun's sample
// rays through the slices' trees, the gather and the fall-back; a spot's walk is imported.
#import single_scattering/epipolar_lamp

// Lit length and lit weight of the stretch [from, to] of a ray, texel by texel (at most
// `max_cells` texels; the last one taken takes the rest of the stretch).
fn texel_walk(r: MapRay, dir: vec3<f32>, t_from: f32, t_to: f32, max_cells: u32) -> vec2<f32> {
    let nudge = sign(r.d.xy) * 1e-3;
    var lit = 0.0;
    var weighted = 0.0;
    var t = t_from;
    let ext = extinction();
    for (var i = 0u; i < max_cells; i++) {
        if t >= t_to {
            break;
        }
        let q = r.a + r.d * t;
        let cell = floor(q.xy + nudge);
        var te = t_to;
        if i + 1u < max_cells {
            for (var k = 0; k < 2; k++) {
                if r.d[k] > 1e-12 {
                    te = min(te, (cell[k] + 1.0 - r.a[k]) / r.d[k]);
                } else if r.d[k] < -1e-12 {
                    te = min(te, (cell[k] - r.a[k]) / r.d[k]);
                }
            }
        }
        te = max(te, t);
        let c = map_depth(cell) + P.bias;
        let z0 = r.a.z + r.d.z * t;
        let z1 = r.a.z + r.d.z * te;
        let part = lit_part(t, te, z0, z1, c);
        lit += part;
        if ext {
            if z0 <= c {
                weighted += weight(dir, r.t0, t, t + part);
            } else {
                weighted += weight(dir, r.t0, te - part, te);
            }
        }
        t = select(t_to, te, te > t);
    }
    return vec2<f32>(lit, weighted);
}

// Visibility of a sample ray of slice k through the slice's min-max tree (`line`: the slice's
// map line): (V̄, medium length, lit weight). The walk is MinMax's, in one dimension: the ray's
// position along the line, b(t) = b0 + bd t, and its light depth are affine in t.
fn tree_ray(k: u32, line: vec4<f32>, dir: vec3<f32>, s: f32) -> vec3<f32> {
    let r = map_ray(dir, s);
    if r.tout <= r.tin {
        return ray_result(r, dir, 0.0, 0.0);
    }
    let b0 = dot(r.a.xy - line.xy, line.zw);
    let bd = dot(r.d.xy, line.zw);
    let nudge = select(-1e-3, 1e-3, bd > 0.0);
    let n = E.tree_n;
    let top = E.tree_top;
    let coarse = E.tree_level;
    let row = k * 2u * n;
    let ext = extinction();
    var level = top;
    var t = r.tin;
    var iter = 0u;
    var lit = 0.0;
    var weighted = 0.0;
    while t < r.tout && iter < MAX_ITER {
        iter++;
        let scale = f32(1u << level);
        let width = n >> level;
        let idx = min(u32(max(floor((b0 + bd * t + nudge) / scale), 0.0)), width - 1u);
        let lo = f32(idx) * scale;
        let hi = f32(idx + 1u) * scale;
        var t_exit = r.tout;
        if bd > 1e-12 {
            t_exit = min(t_exit, (hi - b0) / bd);
        } else if bd < -1e-12 {
            t_exit = min(t_exit, (lo - b0) / bd);
        }
        t_exit = max(t_exit, t);
        let z0 = r.a.z + r.d.z * t;
        let z1 = r.a.z + r.d.z * t_exit;
        let mm = tree[row + 2u * n - 2u * width + idx];
        let next = u32(max(floor((b0 + bd * t_exit + nudge) / (2.0 * scale)), 0.0));
        let up = select(level, min(level + 1u, top), next != (idx >> 1u));
        // What this node settles: the lit stretch [t, lit_end] (times `share`), or a walk over
        // the leaf's own texels; then the next position and level. One `weight` and one
        // `texel_walk` per iteration (several inlined copies in this loop crashed lavapipe's
        // shader compiler).
        var lit_end = t;
        var share = 0.0;
        var walk = false;
        var t_next = t_exit;
        var next_level = up;
        let lit_all = max(z0, z1) <= mm.x + P.bias;
        let dark_all = min(z0, z1) > mm.y + P.bias;
        if lit_all || dark_all || (level > 0u && level <= coarse && mm.y < SHADOW_CLEAR) {
            // Settled: lit, shadowed, or (quality knob) a mixed node estimated with its
            // occluder depth spread evenly over [min, max] (one with clear texels is refined).
            let zm = 0.5 * (z0 + z1);
            let estimate = clamp((mm.y + P.bias - zm) / max(mm.y - mm.x, 1e-6), 0.0, 1.0);
            share = select(select(estimate, 0.0, dark_all), 1.0, lit_all);
            lit_end = t_exit;
        } else if level == 0u {
            walk = true;
            next_level = level;
        } else {
            t_next = t;
            next_level = level - 1u;
        }
        if walk {
            let w = texel_walk(r, dir, t, t_exit, LEAF_CELLS);
            lit += w.x;
            weighted += w.y;
        }
        lit += (lit_end - t) * share;
        // `ext` is false at compile time when the pipeline constant EXTINCTION is off.
        if ext {
            if lit_end > t && share > 0.0 {
                weighted += weight(dir, r.t0, t, lit_end) * share;
            }
        }
        t = t_next;
        level = next_level;
    }
    if t < r.tout {
        let w = texel_walk(r, dir, t, r.tout, MAX_ITER);
        lit += w.x;
        weighted += w.y;
    }
    return ray_result(r, dir, lit, weighted);
}

// The lit share of a ray's weight (1 when it is 0 or light extinction is off).
fn lit_fraction(dir: vec3<f32>, len: f32, weighted: f32, s: f32) -> f32 {
    if !extinction() {
        return 1.0;
    }
    let t0 = medium_segment(dir, s).x;
    let full = weight(dir, t0, t0, t0 + len);
    if full > 0.0 {
        return clamp(weighted / full, 0.0, 1.0);
    }
    return 1.0;
}

// Sample (id.x) of slice (id.y): (V̄, lit fraction of the weight, camera depth, medium length);
// for a spot the lit share of its in-scatter integral.
@compute @workgroup_size(8, 8)
fn epi_sample(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= E.samples || id.y >= E.slices {
        return;
    }
    let seg = textureLoad(slice_table, vec2<u32>(id.y, 0u), 0);
    let lengths = textureLoad(slice_table, vec2<u32>(id.y, 1u), 0);
    let line = textureLoad(slice_table, vec2<u32>(id.y, 2u), 0);
    let f = f32(id.x) / f32(max(E.samples - 1u, 1u));
    let q = seg.xy + seg.zw * (lengths.x * f);
    let size = textureDimensions(depth);
    let px = min(vec2<u32>(max(floor(q), vec2<f32>(0.0))), size - 1u);
    let s = textureLoad(depth, px, 0).r;
    let dir = screen_ray(q, size);
    if LOCAL && P.light.kind != 0u {
        // A spot: (V̄, lit share of the in-scatter integral, medium length).
        let res = lamp_tree_ray(id.y, line, dir, s);
        textureStore(out_samples, id.xy, vec4<f32>(res.x, res.y, s, res.z));
        return;
    }
    let res = tree_ray(id.y, line, dir, s);
    let frac = lit_fraction(dir, res.y, res.z, s);
    textureStore(out_samples, id.xy, vec4<f32>(res.x, frac, s, res.y));
}

// The border coordinate where the ray pc + r t, t > 0, from a point on the screen leaves it
// (0 top-left corner, clockwise, one unit per edge).
fn border_coordinate(pc: vec2<f32>, r: vec2<f32>) -> f32 {
    var tx = 3.0e38;
    var ty = 3.0e38;
    if r.x > 1e-9 {
        tx = (E.size.x - pc.x) / r.x;
    } else if r.x < -1e-9 {
        tx = -pc.x / r.x;
    }
    if r.y > 1e-9 {
        ty = (E.size.y - pc.y) / r.y;
    } else if r.y < -1e-9 {
        ty = -pc.y / r.y;
    }
    if tx <= ty {
        let y = clamp((pc.y + r.y * tx) / E.size.y, 0.0, 1.0);
        return select(4.0 - y, 1.0 + y, r.x > 0.0);
    }
    let x = clamp((pc.x + r.x * ty) / E.size.x, 0.0, 1.0);
    return select(3.0 - x, x, r.y < 0.0);
}

// The pixel centred at pc (camera depth s, medium length len) from the samples of the two
// slices around its line through the epipole, bilinearly, leaving out samples farther than the
// threshold in depth or medium length: (V̄, lit fraction, 1), or (0, 0, 0) when none is usable.
fn epi_interpolate(pc: vec2<f32>, s: f32, len: f32) -> vec3<f32> {
    let rv = pc - E.epipole;
    if dot(rv, rv) < 1e-6 {
        return vec3<f32>(0.0);
    }
    let u = border_coordinate(pc, normalize(rv));
    let count = E.slices;
    var rel = u - E.u_start;
    if rel < 0.0 {
        rel += 4.0;
    }
    var f = rel / E.arc * f32(count) - 0.5;
    var k0: u32;
    var k1: u32;
    var wk: f32;
    if E.inside != 0u {
        if f < 0.0 {
            f += f32(count);
        }
        k0 = min(u32(max(floor(f), 0.0)), count - 1u);
        wk = clamp(f - f32(k0), 0.0, 1.0);
        k1 = (k0 + 1u) % count;
    } else {
        f = clamp(f, 0.0, f32(count - 1u));
        k0 = min(u32(floor(f)), count - 1u);
        wk = f - f32(k0);
        k1 = min(k0 + 1u, count - 1u);
    }
    let m = E.samples;
    var total = 0.0;
    var acc = vec2<f32>(0.0);
    for (var side = 0u; side < 2u; side++) {
        let k = select(k0, k1, side == 1u);
        let wslice = select(1.0 - wk, wk, side == 1u);
        let seg = textureLoad(slice_table, vec2<u32>(k, 0u), 0);
        let slen = textureLoad(slice_table, vec2<u32>(k, 1u), 0).x;
        let along = dot(pc - seg.xy, seg.zw);
        var j = 0.0;
        if slen > 1e-6 {
            j = clamp(along / slen * f32(m - 1u), 0.0, f32(m - 1u));
        }
        let j0 = min(u32(floor(j)), m - 1u);
        let j1 = min(j0 + 1u, m - 1u);
        let wj = j - f32(j0);
        for (var q = 0u; q < 2u; q++) {
            let jj = select(j0, j1, q == 1u);
            let wt = wslice * select(1.0 - wj, wj, q == 1u);
            let v = textureLoad(samples_in, vec2<u32>(jj, k), 0);
            let near = abs(v.z - s) <= E.threshold * abs(s) && abs(v.w - len) <= E.threshold * len;
            if near && wt > 0.0 {
                total += wt;
                acc += wt * v.xy;
            }
        }
    }
    if total > 1e-6 {
        return vec3<f32>(acc / total, 1.0);
    }
    return vec3<f32>(0.0);
}

@group(0) @binding(21) var<storage, read_write> fallback: array<u32>;
@group(0) @binding(22) var<storage, read_write> fallback_count: array<atomic<u32>>;
// `epi_fallback`'s workgroup counts (x, y, z), written by `epi_fallback_args`.
@group(0) @binding(23) var<storage, read_write> fallback_args: array<u32>;

// Every pixel interpolated from the samples; one with no usable sample is appended to the
// fall-back list (its own ray is traced by `epi_fallback`: kept out of this pass, whose SIMD
// lanes would otherwise all step through the MinMax walk's code masked).
@compute @workgroup_size(8, 8)
fn epi_gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
    let s = textureLoad(depth, id.xy, 0).r;
    let seg = medium_segment(dir, s);
    let len = max(seg.y - seg.x, 0.0);
    let got = epi_interpolate(vec2<f32>(id.xy) + 0.5, s, len);
    if got.z > 0.5 && LOCAL && P.light.kind != 0u {
        store_lamp(id.xy, got.x, len, got.y * lamp_unshadowed(dir, s));
    } else if got.z > 0.5 {
        var weighted = 0.0;
        if extinction() {
            weighted = got.y * weight(dir, seg.x, seg.x, seg.x + len);
        }
        store(id.xy, dir, got.x, len, weighted);
    } else {
        let slot = atomicAdd(&fallback_count[0], 1u);
        fallback[min(slot, arrayLength(&fallback) - 1u)] = id.y * size.x + id.x;
    }
}

// How many pixels the list holds (the count may pass its length when every pixel falls back).
fn listed() -> u32 {
    return min(atomicLoad(&fallback_count[0]), arrayLength(&fallback));
}

// The fall-back list's length as `epi_fallback`'s workgroups (8 × 8 over rows of 256 pixels),
// for an indirect dispatch: the list is never read back to size it.
@compute @workgroup_size(1)
fn epi_fallback_args() {
    let rows = (listed() + 255u) / 256u;
    fallback_args[0] = 32u;
    fallback_args[1] = (rows + 7u) / 8u;
    fallback_args[2] = 1u;
}

// The listed pixels (256 per row of the dispatch) trace their own MinMax ray.
@compute @workgroup_size(8, 8)
fn epi_fallback(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.y * 256u + id.x;
    if id.x >= 256u || i >= listed() {
        return;
    }
    let size = textureDimensions(depth);
    let index = fallback[i];
    let p = vec2<u32>(index % size.x, min(index / size.x, size.y - 1u));
    let dir = view_ray(p, size);
    if LOCAL && P.light.kind != 0u {
        min_max_local(p, dir, textureLoad(depth, p, 0).r);
        return;
    }
    let r = min_max_ray(dir, textureLoad(depth, p, 0).r);
    store(p, dir, r.x, r.y, r.z);
}
