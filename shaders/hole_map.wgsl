// HoleMap: H = 1 (hole) where the noise is below the threshold, else 0 (nodes/hole_map.rs;
// SPEC §4 eq. 4). Struct Params; bindings P, noise, out_holes, sel.
//
// The calibrated threshold — the k-th smallest finite value, k = ⌊hq·n / 2³²⌋ — is selected on
// the GPU by radix select over order-preserving keys of the values' bits: four `histogram`
// passes (8 bits each, from the top), each followed by one `pick` invocation that finds the bin
// holding the k-th key and narrows the prefix. `sel` holds the 256 bins, then n, k, the prefix.
// Keys order values exactly as `f32::total_cmp` does, so the result is the CPU reference's bit
// for bit; nothing is read back.

struct Params {
    threshold: f32,
    hq: u32,
    shift: u32,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var noise: texture_2d<f32>;
@group(0) @binding(2) var out_holes: texture_storage_2d<r32float, write>;
@group(0) @binding(3) var<storage, read_write> sel: array<atomic<u32>>;

const BINS: u32 = 256u;
const N: u32 = 256u;
const K: u32 = 257u;
const PREFIX: u32 = 258u;

// Order-preserving key of a float's bits: negatives inverted, positives with the sign bit set.
fn key_of(b: u32) -> u32 {
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

fn value_of(k: u32) -> f32 {
    return bitcast<f32>(select(~k, k & 0x7fffffffu, (k & 0x80000000u) != 0u));
}

// The high 32 bits of the 64-bit product a·b.
fn mul_hi(a: u32, b: u32) -> u32 {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = ((a0 * b0) >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
}

@compute @workgroup_size(8, 8)
fn threshold(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_holes);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let n = textureLoad(noise, id.xy, 0).r;
    textureStore(out_holes, id.xy, vec4<f32>(select(0.0, 1.0, n < P.threshold), 0.0, 0.0, 1.0));
}

// The key of texel `id` when it takes part in this digit's histogram (finite, and sharing the
// prefix picked so far), else NONE (no finite value has that key: it would be a NaN's).
const NONE: u32 = 0xffffffffu;

fn digit_key(id: vec2<u32>, prefix: u32) -> u32 {
    let size = textureDimensions(noise);
    if id.x >= size.x || id.y >= size.y {
        return NONE;
    }
    let b = bitcast<u32>(textureLoad(noise, id, 0).r);
    if (b & 0x7f800000u) == 0x7f800000u {
        return NONE; // ±∞ and NaN take no part
    }
    let key = key_of(b);
    if P.shift != 24u {
        let high = 0xffffffffu << (P.shift + 8u);
        if (key & high) != (prefix & high) {
            return NONE;
        }
    }
    return key;
}

// One digit's histogram of the finite values' keys that share the prefix picked so far (the
// first pass, shift 24, also counts the finite values), straight into `sel`: for CPU drivers,
// where workgroup memory and barriers cost more than the atomics they save.
@compute @workgroup_size(8, 8)
fn histogram(@builtin(global_invocation_id) id: vec3<u32>) {
    let key = digit_key(id.xy, atomicLoad(&sel[PREFIX]));
    if key == NONE {
        return;
    }
    if P.shift == 24u {
        atomicAdd(&sel[N], 1u);
    }
    atomicAdd(&sel[(key >> P.shift) & 0xffu], 1u);
}

// The same histogram for GPUs: each workgroup counts into its own bins, then adds the non-empty
// ones to `sel` (the first digit of a noise map takes a few bins per workgroup: ~30× fewer
// atomics on the shared bins).
var<workgroup> local_bins: array<atomic<u32>, 256>;
var<workgroup> local_n: atomic<u32>;
var<workgroup> local_prefix: u32;

@compute @workgroup_size(8, 8)
fn histogram_workgroup(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
) {
    for (var i = li; i < BINS; i += 64u) {
        atomicStore(&local_bins[i], 0u);
    }
    if li == 0u {
        atomicStore(&local_n, 0u);
        local_prefix = atomicLoad(&sel[PREFIX]);
    }
    workgroupBarrier();
    let key = digit_key(id.xy, local_prefix);
    if key != NONE {
        if P.shift == 24u {
            atomicAdd(&local_n, 1u);
        }
        atomicAdd(&local_bins[(key >> P.shift) & 0xffu], 1u);
    }
    workgroupBarrier();
    for (var i = li; i < BINS; i += 64u) {
        let c = atomicLoad(&local_bins[i]);
        if c > 0u {
            atomicAdd(&sel[i], c);
        }
    }
    if li == 0u {
        let n = atomicLoad(&local_n);
        if n > 0u {
            atomicAdd(&sel[N], n);
        }
    }
}

// The bin holding the k-th key: its digit joins the prefix, k becomes the rank inside it, and
// the bins are cleared for the next digit.
@compute @workgroup_size(1)
fn pick() {
    if P.shift == 24u {
        let n = atomicLoad(&sel[N]);
        atomicStore(&sel[K], min(mul_hi(P.hq, n), max(n, 1u) - 1u));
        atomicStore(&sel[PREFIX], 0u);
    }
    var k = atomicLoad(&sel[K]);
    var digit = 0u;
    for (var i = 0u; i < BINS; i++) {
        let c = atomicLoad(&sel[i]);
        if k < c {
            digit = i;
            break;
        }
        k -= c;
    }
    atomicStore(&sel[K], k);
    atomicStore(&sel[PREFIX], atomicLoad(&sel[PREFIX]) | (digit << P.shift));
    for (var i = 0u; i < BINS; i++) {
        atomicStore(&sel[i], 0u);
    }
}

// The threshold at the selected key (no finite value: no holes).
@compute @workgroup_size(8, 8)
fn threshold_selected(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_holes);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let t = value_of(atomicLoad(&sel[PREFIX]));
    let n = textureLoad(noise, id.xy, 0).r;
    let hole = atomicLoad(&sel[N]) > 0u && n < t;
    textureStore(out_holes, id.xy, vec4<f32>(select(0.0, 1.0, hole), 0.0, 0.0, 1.0));
}
