// Ray casting a scene's triangles through a BVH, one ray per texel: what the G-buffer and the
// shadow-map passes beside this file share — the parameters, the BVH's buffers, the texel's ray
// and the traversal (nodes/algorithms/ray_cast.rs; its `Bvh::cast` is the CPU reference).

struct RayCastParams {
    inv_view_proj: mat4x4<f32>,
    view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    far: f32,
    width: u32,
    height: u32,
    // Shadow map: 1 writes clip z before the divide by w (linear depth of a spot or point light).
    linear_depth: u32,
    // Normalised depth where rays end: 1, or for a linear-depth map (no far plane) the depth of
    // twice its far distance (ray_cast::linear_far).
    far_ndc: f32,
}

@group(0) @binding(0) var<uniform> P: RayCastParams;
// Two vec4 per node: (min, first as bits), (max, count as bits); count 0 = inner node whose
// children are `first` and `first + 1`.
@group(0) @binding(1) var<storage, read_write> bvh_nodes: array<vec4<f32>>;
// Three vec4 per triangle (leaf order): the corners.
@group(0) @binding(2) var<storage, read_write> corners: array<vec4<f32>>;

const STACK: u32 = 32u;

struct Hit {
    s: f32,
    tri: u32,
    u: f32,
    v: f32,
    found: bool,
}

// The segment texel `id` spans in normalised depth 0…far_ndc: origin in .a, direction in .b.
struct Ray {
    a: vec3<f32>,
    b: vec3<f32>,
}

fn texel_ray(id: vec2<u32>) -> Ray {
    let n = vec2<f32>(
        (f32(id.x) + 0.5) / f32(P.width) * 2.0 - 1.0,
        1.0 - (f32(id.y) + 0.5) / f32(P.height) * 2.0,
    );
    let a = P.inv_view_proj * vec4<f32>(n, 0.0, 1.0);
    let b = P.inv_view_proj * vec4<f32>(n, P.far_ndc, 1.0);
    let pa = a.xyz / a.w;
    return Ray(pa, b.xyz / b.w - pa);
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let tiny = abs(d) < vec3<f32>(1e-30);
    let signed = select(vec3<f32>(1e30), vec3<f32>(-1e30), d < vec3<f32>(0.0));
    return select(1.0 / d, signed, tiny);
}

// Where the segment enters the box (0 when it starts inside), or 2 (past any segment
// parameter) when it misses it or enters at or after `limit`.
fn entry(n: u32, o: vec3<f32>, inv: vec3<f32>, limit: f32) -> f32 {
    let t0 = (bvh_nodes[2u * n].xyz - o) * inv;
    let t1 = (bvh_nodes[2u * n + 1u].xyz - o) * inv;
    let a = min(t0, t1);
    let b = max(t0, t1);
    let near = max(max(max(a.x, a.y), a.z), 0.0);
    let far = min(min(min(b.x, b.y), b.z), limit);
    return select(2.0, near, near <= far && near < limit);
}

// The nearest hit on the segment o → o + d: boxes visited nearest first, a box skipped once
// its entry is no nearer than the best hit (as ray_cast.rs' Bvh::cast).
fn nearest_hit(o: vec3<f32>, d: vec3<f32>) -> Hit {
    var best = Hit(1.0, 0u, 0.0, 0.0, false);
    let inv = safe_inverse(d);
    var stack: array<u32, STACK>;
    var near: array<f32, STACK>;
    var top = 0u;
    let root = entry(0u, o, inv, 1.0);
    if root < 2.0 {
        stack[0] = 0u;
        near[0] = root;
        top = 1u;
    }
    while top > 0u {
        top -= 1u;
        if near[top] >= best.s {
            continue;
        }
        let n = stack[top];
        let first = bitcast<u32>(bvh_nodes[2u * n].w);
        let count = bitcast<u32>(bvh_nodes[2u * n + 1u].w);
        if count == 0u {
            let tl = entry(first, o, inv, best.s);
            let tr = entry(first + 1u, o, inv, best.s);
            // The farther child first onto the stack, so the nearer is visited first.
            let near_child = select(first + 1u, first, tl <= tr);
            let far_child = select(first, first + 1u, tl <= tr);
            let t_near = min(tl, tr);
            let t_far = max(tl, tr);
            if t_far < 2.0 && top < STACK {
                stack[top] = far_child;
                near[top] = t_far;
                top += 1u;
            }
            if t_near < 2.0 && top < STACK {
                stack[top] = near_child;
                near[top] = t_near;
                top += 1u;
            }
            continue;
        }
        for (var t = first; t < first + count; t += 1u) {
            let c0 = corners[3u * t].xyz;
            let e1 = corners[3u * t + 1u].xyz - c0;
            let e2 = corners[3u * t + 2u].xyz - c0;
            let p = cross(d, e2);
            let det = dot(e1, p);
            if det == 0.0 {
                continue;
            }
            let inv_det = 1.0 / det;
            let to = o - c0;
            let u = dot(to, p) * inv_det;
            let q = cross(to, e1);
            let v = dot(d, q) * inv_det;
            let s = dot(e2, q) * inv_det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && s >= 0.0 && s < best.s {
                best = Hit(s, t, u, v, true);
            }
        }
    }
    return best;
}
