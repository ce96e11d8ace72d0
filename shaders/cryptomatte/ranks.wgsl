// Cryptomatte, pass 2 (nodes/cryptomatte.rs, `ranks_reference` is its CPU twin): per pixel, the
// IDs its sub-pixel samples see weighed by the pixel filter, ranked by weight; one RGBA layer per
// dispatch: (id, coverage) of ranks 2·layer and 2·layer + 1.

struct RankParams {
    // Output size, px.
    size: vec2<u32>,
    // Sub-pixel samples per axis.
    samples: u32,
    // The layer written: ranks 2·layer, 2·layer + 1.
    layer: u32,
    // Samples the filter reaches past the pixel's own on each side.
    reach: u32,
    _pad1: u32,
    // Ranks kept (pairs past it are 0).
    ranks: u32,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> P: RankParams;
// Object index + 1 per sample (0: no surface), `samples` × the output size.
@group(0) @binding(1) var ids: texture_2d<f32>;
// Object index → the ID's bits (0: the object has no ID of this kind, e.g. no material).
@group(0) @binding(2) var<storage, read_write> table: array<u32>;
@group(0) @binding(3) var out: texture_storage_2d<rgba32float, write>;
// What the IDs look like (layer 0's dispatch writes it): Σ coverage · the ID's colour.
@group(0) @binding(4) var preview: texture_storage_2d<rgba32float, write>;
// The filter's weight along one axis for a sample j samples right of (or below) the pixel's
// first sample, at weights[j + reach] for j in [−reach, samples + reach): the same for every
// pixel, so it is computed once on the CPU (`axis_weights`).
@group(0) @binding(5) var<storage, read_write> weights: array<f32>;
// Distinct IDs per pixel: written by layer 0's dispatch (`count_out`), read by the later layers'
// (`counts`), which skip the pixels holding no pair for them (most pixels see one object).
@group(0) @binding(6) var count_out: texture_storage_2d<r32float, write>;
@group(0) @binding(7) var counts: texture_2d<f32>;

// An ID's colour in the preview: three bytes of its bits, as linear RGB in [0.05, 1].
fn id_colour(id: u32) -> vec3<f32> {
    let c = vec3<f32>(vec3<u32>(id, id >> 8u, id >> 16u) & vec3<u32>(255u)) / 255.0;
    return 0.05 + 0.95 * c * c;
}

// Distinct IDs one pixel keeps (more is rare: a pixel's footprint holds a few objects).
const SLOTS: u32 = 16u;

@compute @workgroup_size(8, 8)
fn ranks(@builtin(global_invocation_id) gid: vec3<u32>) {
    if any(gid.xy >= P.size) {
        return;
    }
    if P.layer > 0u && u32(textureLoad(counts, gid.xy, 0).r) <= 2u * P.layer {
        textureStore(out, gid.xy, vec4<f32>(0.0));
        return;
    }
    var slot_id: array<u32, SLOTS>;
    var slot_w: array<f32, SLOTS>;
    var used = 0u;
    var total = 0.0;
    let s = i32(P.samples);
    let reach = i32(P.reach);
    let full = vec2<i32>(P.size * P.samples);
    let first = vec2<i32>(gid.xy) * s;
    let lo = max(first - reach, vec2<i32>(0));
    let hi = min(first + s + reach, full);
    for (var y = lo.y; y < hi.y; y++) {
        let wy = weights[y - first.y + reach];
        if wy <= 0.0 {
            continue;
        }
        for (var x = lo.x; x < hi.x; x++) {
            let w = wy * weights[x - first.x + reach];
            if w <= 0.0 {
                continue;
            }
            total += w;
            let object = u32(textureLoad(ids, vec2<i32>(x, y), 0).r);
            if object == 0u {
                continue;
            }
            let id = table[object - 1u];
            if id == 0u {
                continue;
            }
            var k = 0u;
            while k < used && slot_id[k] != id {
                k++;
            }
            if k < used {
                slot_w[k] += w;
            } else if used < SLOTS {
                slot_id[used] = id;
                slot_w[used] = w;
                used++;
            }
        }
    }
    if P.layer == 0u {
        var colour = vec3<f32>(0.0);
        var seen = 0.0;
        for (var k = 0u; k < used; k++) {
            colour += slot_w[k] * id_colour(slot_id[k]);
            seen += slot_w[k];
        }
        let t = max(total, 1e-20);
        textureStore(preview, gid.xy, vec4<f32>(colour / t, seen / t));
        textureStore(count_out, gid.xy, vec4<f32>(f32(used), 0.0, 0.0, 0.0));
    }
    // Selection sort of the heaviest 2·layer + 2 (ties: the smaller ID first).
    let want = min(2u * P.layer + 2u, used);
    for (var i = 0u; i < want; i++) {
        var best = i;
        for (var j = i + 1u; j < used; j++) {
            if slot_w[j] > slot_w[best] || (slot_w[j] == slot_w[best] && slot_id[j] < slot_id[best]) {
                best = j;
            }
        }
        let id = slot_id[i];
        let w = slot_w[i];
        slot_id[i] = slot_id[best];
        slot_w[i] = slot_w[best];
        slot_id[best] = id;
        slot_w[best] = w;
    }
    var o = vec4<f32>(0.0);
    let a = 2u * P.layer;
    if a < used && a < P.ranks && total > 0.0 {
        o.x = bitcast<f32>(slot_id[a]);
        o.y = slot_w[a] / total;
    }
    if a + 1u < used && a + 1u < P.ranks && total > 0.0 {
        o.z = bitcast<f32>(slot_id[a + 1u]);
        o.w = slot_w[a + 1u] / total;
    }
    textureStore(out, gid.xy, o);
}
