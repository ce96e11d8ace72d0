// A one-channel volume covering a world box [lo, hi] (a density, a light transmittance): texel
// (i, j, k)'s value sits at the box point ((i, j, k) + ½)/n; CPU twin nodes/algorithms/box_volume.rs.

// The volume at world point x: trilinear between texel centres, the edge texels held over the
// outer half texel; `outside` beyond the box.
fn box_trilinear(v: texture_3d<f32>, lo: vec3<f32>, hi: vec3<f32>, x: vec3<f32>, outside: f32) -> f32 {
    let u = (x - lo) / max(hi - lo, vec3<f32>(1e-12));
    if any(u < vec3<f32>(0.0)) || any(u > vec3<f32>(1.0)) {
        return outside;
    }
    let n = vec3<i32>(textureDimensions(v, 0));
    let q = u * vec3<f32>(n) - 0.5;
    let b = vec3<i32>(floor(q));
    let f = q - floor(q);
    let i0 = clamp(b, vec3<i32>(0), n - 1);
    let i1 = clamp(b + 1, vec3<i32>(0), n - 1);
    let c000 = textureLoad(v, vec3<i32>(i0.x, i0.y, i0.z), 0).r;
    let c100 = textureLoad(v, vec3<i32>(i1.x, i0.y, i0.z), 0).r;
    let c010 = textureLoad(v, vec3<i32>(i0.x, i1.y, i0.z), 0).r;
    let c110 = textureLoad(v, vec3<i32>(i1.x, i1.y, i0.z), 0).r;
    let c001 = textureLoad(v, vec3<i32>(i0.x, i0.y, i1.z), 0).r;
    let c101 = textureLoad(v, vec3<i32>(i1.x, i0.y, i1.z), 0).r;
    let c011 = textureLoad(v, vec3<i32>(i0.x, i1.y, i1.z), 0).r;
    let c111 = textureLoad(v, vec3<i32>(i1.x, i1.y, i1.z), 0).r;
    let y0 = mix(mix(c000, c100, f.x), mix(c010, c110, f.x), f.y);
    let y1 = mix(mix(c001, c101, f.x), mix(c011, c111, f.x), f.y);
    return mix(y0, y1, f.z);
}

// A light transmittance volume seen from x towards the light (unit d, the light `far` away):
// at x inside the box; from outside, where the ray enters the box (no density lies between x
// and that point); 1 when the ray misses the box or meets it beyond the light.
fn box_towards(v: texture_3d<f32>, lo: vec3<f32>, hi: vec3<f32>, x: vec3<f32>, d: vec3<f32>, far: f32) -> f32 {
    var t0 = 0.0;
    var t1 = far;
    for (var k = 0; k < 3; k++) {
        if d[k] != 0.0 {
            let a = (lo[k] - x[k]) / d[k];
            let b = (hi[k] - x[k]) / d[k];
            t0 = max(t0, min(a, b));
            t1 = min(t1, max(a, b));
        } else if x[k] < lo[k] || x[k] > hi[k] {
            return 1.0;
        }
    }
    if t1 < t0 {
        return 1.0;
    }
    // Half a micron inside, so the entry point is not read as outside by rounding.
    let e = x + d * (t0 + 1e-6 * max(length(hi - lo), 1.0));
    return box_trilinear(v, lo, hi, e, 1.0);
}
