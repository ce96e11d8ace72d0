// SingleScattering, method MinMax: the pyramid of the shadow map and its traversal
// (nodes/single_scattering/map_ray.rs, gpu.rs).
#import single_scattering/min_max_lamp

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

struct Build {
    level: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    src: vec4<u32>,
    dst: vec4<u32>,
}

@group(0) @binding(7) var<uniform> B: Build;
@group(0) @binding(8) var build_src: texture_2d<f32>;
@group(0) @binding(9) var build_dst: texture_storage_2d<rg32float, write>;

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
            } else if level <= P.min_level && mm.y < SHADOW_CLEAR {
                // Quality knob: estimate a mixed block instead of refining it, taking its
                // occluder depth as spread evenly over [min, max]. A block with clear texels
                // (its max is SHADOW_CLEAR) has no such spread: it is refined.
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

@compute @workgroup_size(8, 8)
fn min_max(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
    if LOCAL && P.light.kind != 0u {
        min_max_local(id.xy, dir, textureLoad(depth, id.xy, 0).r);
        return;
    }
    let r = min_max_ray(dir, textureLoad(depth, id.xy, 0).r);
    store(id.xy, dir, r.x, r.y, r.z);
}
