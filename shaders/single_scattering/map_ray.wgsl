// SingleScattering: a view ray in the shadow map's texel units, shared by the MinMax and
// Epipolar traversals (nodes/single_scattering/map_ray.rs, epipolar.rs).
#import single_scattering/common

// Length of [t0, t1] where the depth, linear from z0 to z1, is at most c.
fn lit_part(t0: f32, t1: f32, z0: f32, z1: f32, c: f32) -> f32 {
    if z0 <= c && z1 <= c {
        return t1 - t0;
    }
    if z0 > c && z1 > c {
        return 0.0;
    }
    let u = clamp((c - z0) / (z1 - z0), 0.0, 1.0);
    if z0 <= c {
        return (t1 - t0) * u;
    }
    return (t1 - t0) * (1.0 - u);
}

const MAX_ITER: u32 = 16384u;

// A view ray in the map's texel units and light depth, p(t) = a + d t, its medium segment
// [t0, t1] and the part [tin, tout] of it over the map's footprint (tout ≤ tin: none), at any
// light depth (an occluder shadows what lies behind it however far); the rest of the segment
// is lit: no caster lies outside the footprint.
struct MapRay {
    a: vec3<f32>,
    d: vec3<f32>,
    t0: f32,
    t1: f32,
    tin: f32,
    tout: f32,
}

fn map_ray(dir: vec3<f32>, s: f32) -> MapRay {
    let seg = medium_segment(dir, s);
    let msize = vec2<f32>(textureDimensions(shadow));
    let c0 = P.light.view_proj * vec4<f32>(P.eye, 1.0);
    let c1 = P.light.view_proj * vec4<f32>(P.eye + dir, 1.0);
    var r: MapRay;
    r.a = vec3<f32>((c0.x * 0.5 + 0.5) * msize.x, (0.5 - c0.y * 0.5) * msize.y, c0.z);
    r.d = vec3<f32>((c1.x - c0.x) * 0.5 * msize.x, -(c1.y - c0.y) * 0.5 * msize.y, c1.z - c0.z);
    r.t0 = seg.x;
    r.t1 = max(seg.y, seg.x);
    r.tin = r.t0;
    r.tout = r.t1;
    let hi = msize;
    for (var k = 0; k < 2; k++) {
        if abs(r.d[k]) < 1e-12 {
            if r.a[k] < 0.0 || r.a[k] > hi[k] {
                r.tout = -1.0;
            }
        } else {
            let ta = (0.0 - r.a[k]) / r.d[k];
            let tb = (hi[k] - r.a[k]) / r.d[k];
            r.tin = max(r.tin, min(ta, tb));
            r.tout = min(r.tout, max(ta, tb));
        }
    }
    return r;
}

// (V̄, medium length, lit weight) of a ray from the lit length and weight found inside the map.
fn ray_result(r: MapRay, dir: vec3<f32>, lit_inside: f32, weighted_inside: f32) -> vec3<f32> {
    let len = r.t1 - r.t0;
    let ext = extinction();
    var lit = len;
    var weighted = 0.0;
    if ext {
        weighted = weight(dir, r.t0, r.t0, r.t1);
    }
    if r.tout > r.tin {
        lit = len - (r.tout - r.tin) + lit_inside;
        if ext {
            weighted = weight(dir, r.t0, r.t0, r.tin) + weight(dir, r.t0, r.tout, r.t1) + weighted_inside;
        }
    }
    let vbar = select(1.0, clamp(lit / len, 0.0, 1.0), len > 0.0);
    return vec3<f32>(vbar, len, weighted);
}
