// TransferFunction (nodes/transfer_function/): bake the layer stack into an N×N LUT, solve
// diffusion layers by multigrid, and look the LUT up per pixel with (V̄, normalised depth).
// Texel (i, j) of the LUT holds the colour at u = (i + 0.5)/N (V̄), v = (j + 0.5)/N (depth).
#import lib/sampling
#import lib/order_key

struct Layer {
    kind: u32,      // 0 solid, 1 gradient, 2 sampled from `src` (diffusion solution or image)
    blend: u32,     // 0 alpha, 1 multiply, 2 add
    opacity: f32,
    _pad0: u32,
    colour0: vec4<f32>,
    colour1: vec4<f32>,
    from_uv: vec2<f32>,
    to_uv: vec2<f32>,
}

struct Multigrid {
    fixed_values: u32, // 1: masked texels take `values` (the finest level); 0: coarse levels
    omega: f32,        // weighted-Jacobi factor
    pin: f32,          // coarse levels: conductance tying a masked texel to zero
    _pad0: u32,
}

struct Lookup {
    depth_min: f32,
    depth_max: f32,
    intensity: f32,
    modulate: u32,
}

@group(0) @binding(0) var<uniform> L: Layer;
@group(0) @binding(1) var a_tex: texture_2d<f32>;
@group(0) @binding(2) var b_tex: texture_2d<f32>;
@group(0) @binding(3) var out_tex: texture_storage_2d<rgba32float, write>;
@group(0) @binding(4) var mask_tex: texture_2d<f32>;
@group(0) @binding(5) var values_tex: texture_2d<f32>;
@group(0) @binding(6) var<uniform> M: Multigrid;
@group(0) @binding(7) var<uniform> K: Lookup;
@group(0) @binding(8) var vis_tex: texture_2d<f32>;
@group(0) @binding(9) var depth_tex: texture_2d<f32>;
// `lookup_selected`: the 1st and 99th percentile selections of the depth (quantile passes).
@group(0) @binding(10) var<storage, read_write> sel_lo: array<u32>;
@group(0) @binding(11) var<storage, read_write> sel_hi: array<u32>;

// Bilinear sample of `t` at (u, v) ∈ [0, 1]², texel centres at (i + 0.5)/size, clamp to edge.
fn bilinear(t: texture_2d<f32>, uv: vec2<f32>) -> vec4<f32> {
    return bilinear_texels(t, uv * vec2<f32>(textureDimensions(t)));
}

// One layer composited over the accumulator `a_tex`; `b_tex` is the layer's sampled source.
@compute @workgroup_size(8, 8)
fn bake_layer(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = textureDimensions(out_tex);
    if id.x >= n.x || id.y >= n.y {
        return;
    }
    let p = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(n);
    var src = L.colour0;
    if L.kind == 1u {
        let d = L.to_uv - L.from_uv;
        let len2 = dot(d, d);
        var t = 0.0;
        if len2 > 0.0 {
            t = clamp(dot(p - L.from_uv, d) / len2, 0.0, 1.0);
        }
        src = mix(L.colour0, L.colour1, t);
    } else if L.kind == 2u {
        src = bilinear(b_tex, p);
    }
    let dst = textureLoad(a_tex, vec2<i32>(id.xy), 0);
    let a = L.opacity * src.a;
    var rgb = dst.rgb * (1.0 - a) + src.rgb * a;
    if L.blend == 1u {
        rgb = dst.rgb * (1.0 - a) + dst.rgb * src.rgb * a;
    } else if L.blend == 2u {
        rgb = dst.rgb + src.rgb * a;
    }
    textureStore(out_tex, vec2<i32>(id.xy), vec4<f32>(rgb, dst.a * (1.0 - a) + a));
}

// Sum of the in-grid 4-neighbours of `a_tex` at p and their count (Neumann boundary: a missing
// neighbour is left out, so the operator is the graph Laplacian of the grid).
fn neighbours(p: vec2<i32>, size: vec2<i32>) -> vec4<f32> {
    var s = vec4<f32>(0.0);
    let offs = array<vec2<i32>, 4>(vec2<i32>(1, 0), vec2<i32>(-1, 0), vec2<i32>(0, 1), vec2<i32>(0, -1));
    for (var k = 0; k < 4; k++) {
        let q = p + offs[k];
        if all(q >= vec2<i32>(0)) && all(q < size) {
            s += textureLoad(a_tex, q, 0);
        }
    }
    return s;
}

fn neighbour_count(p: vec2<i32>, size: vec2<i32>) -> f32 {
    var c = 4.0;
    if p.x == 0 { c -= 1.0; }
    if p.x == size.x - 1 { c -= 1.0; }
    if p.y == 0 { c -= 1.0; }
    if p.y == size.y - 1 { c -= 1.0; }
    return c;
}

// Weighted Jacobi sweep of (c u − Σ u_n) = f on free texels; a_tex = u, b_tex = f.
@compute @workgroup_size(8, 8)
fn mg_smooth(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(out_tex));
    let p = vec2<i32>(id.xy);
    if p.x >= size.x || p.y >= size.y {
        return;
    }
    let pinned = textureLoad(mask_tex, p, 0).r > 0.5;
    if pinned && M.fixed_values == 1u {
        textureStore(out_tex, p, textureLoad(values_tex, p, 0));
        return;
    }
    let c = neighbour_count(p, size) + select(0.0, M.pin, pinned);
    let u = textureLoad(a_tex, p, 0);
    if c == 0.0 {
        textureStore(out_tex, p, u);
        return;
    }
    let jacobi = (textureLoad(b_tex, p, 0) + neighbours(p, size)) / c;
    textureStore(out_tex, p, u + M.omega * (jacobi - u));
}

// Residual r = f − ((c + pin) u − Σ u_n); 0 on the finest level's constrained texels.
@compute @workgroup_size(8, 8)
fn mg_residual(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(out_tex));
    let p = vec2<i32>(id.xy);
    if p.x >= size.x || p.y >= size.y {
        return;
    }
    let pinned = textureLoad(mask_tex, p, 0).r > 0.5;
    var r = vec4<f32>(0.0);
    if !(pinned && M.fixed_values == 1u) {
        let c = neighbour_count(p, size) + select(0.0, M.pin, pinned);
        r = textureLoad(b_tex, p, 0) - (c * textureLoad(a_tex, p, 0) - neighbours(p, size));
    }
    textureStore(out_tex, p, r);
}

// Coarse right-hand side: the sum of the (up to four) fine residuals a coarse texel covers.
@compute @workgroup_size(8, 8)
fn mg_restrict(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(out_tex));
    let p = vec2<i32>(id.xy);
    if p.x >= size.x || p.y >= size.y {
        return;
    }
    let fine = vec2<i32>(textureDimensions(a_tex));
    var s = vec4<f32>(0.0);
    for (var dy = 0; dy < 2; dy++) {
        for (var dx = 0; dx < 2; dx++) {
            let q = 2 * p + vec2<i32>(dx, dy);
            if q.x < fine.x && q.y < fine.y {
                s += textureLoad(a_tex, q, 0);
            }
        }
    }
    textureStore(out_tex, p, s);
}

// u += the coarse correction `b_tex` interpolated bilinearly (cell-centred) on free texels.
@compute @workgroup_size(8, 8)
fn mg_prolong(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(out_tex));
    let p = vec2<i32>(id.xy);
    if p.x >= size.x || p.y >= size.y {
        return;
    }
    let u = textureLoad(a_tex, p, 0);
    if textureLoad(mask_tex, p, 0).r > 0.5 {
        textureStore(out_tex, p, u);
        return;
    }
    let coarse = vec2<f32>(textureDimensions(b_tex));
    let uv = (vec2<f32>(p) + 0.5) / (2.0 * coarse);
    textureStore(out_tex, p, u + bilinear(b_tex, uv));
}

// The LUT (a_tex) looked up at (V̄, normalised depth); Modulate multiplies the in-scatter (b_tex).
@compute @workgroup_size(8, 8)
fn lookup(@builtin(global_invocation_id) id: vec3<u32>) {
    shade(vec2<i32>(id.xy), K.depth_min, K.depth_max);
}

// `lookup` over the depth range the quantile passes selected on the GPU (`depth_range = auto`:
// the 1st and 99th percentiles; none took part: 0…1), read here instead of by the CPU.
@compute @workgroup_size(8, 8)
fn lookup_selected(@builtin(global_invocation_id) id: vec3<u32>) {
    let have = sel_lo[SELECTED_N] > 0u && sel_hi[SELECTED_N] > 0u;
    let lo = select(0.0, value_of(sel_lo[SELECTED_KEY]), have);
    let hi = select(1.0, value_of(sel_hi[SELECTED_KEY]), have);
    shade(vec2<i32>(id.xy), lo, hi);
}

// The TF looked up at texel p's (V̄, depth normalised over depth_min…depth_max).
fn shade(p: vec2<i32>, depth_min: f32, depth_max: f32) {
    let size = vec2<i32>(textureDimensions(out_tex));
    if p.x >= size.x || p.y >= size.y {
        return;
    }
    var u = textureLoad(vis_tex, p, 0).r;
    u = clamp(select(0.0, u, u == u), 0.0, 1.0);
    let d = textureLoad(depth_tex, p, 0).r;
    let span = depth_max - depth_min;
    var v = select(0.0, 1.0, d > depth_min);
    if span > 0.0 {
        v = (d - depth_min) / span;
    }
    v = clamp(select(0.0, v, v == v), 0.0, 1.0);
    let tf = bilinear(a_tex, vec2<f32>(u, v)).rgb * K.intensity;
    var rgb = tf;
    if K.modulate == 1u {
        rgb = textureLoad(b_tex, p, 0).rgb * tf;
    }
    textureStore(out_tex, p, vec4<f32>(rgb, 1.0));
}
