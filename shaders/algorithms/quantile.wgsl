// The k-th smallest value of a map, selected on the GPU (nodes/algorithms/quantile.rs): radix
// select over order-preserving keys of the values' bits — four `quantile_histogram` passes (8
// bits each, from the top), each followed by one `quantile_pick` invocation that finds the bin
// holding the k-th key and narrows the prefix. Struct QuantileParams; bindings QP, values, sel.
// `sel` holds the 256 bins, then n (values taking part), k, and the selected key. Keys order
// values as `f32::total_cmp` does, so the result is the CPU reference's bit for bit.

struct QuantileParams {
    q: u32,
    rank: u32,
    shift: u32,
    use_limit: u32,
    limit: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> QP: QuantileParams;
@group(0) @binding(1) var values: texture_2d<f32>;
@group(0) @binding(2) var<storage, read_write> sel: array<atomic<u32>>;

const BINS: u32 = 256u;
const N: u32 = 256u;
const K: u32 = 257u;
const PREFIX: u32 = 258u;
// No value taking part has this key (it would be a NaN's).
const NONE: u32 = 0xffffffffu;

// Order-preserving key of a float's bits: negatives inverted, positives with the sign bit set.
fn key_of(b: u32) -> u32 {
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

// The high and low 32 bits of the 64-bit product a·b.
fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let mid = ((a0 * b0) >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    let hi = a1 * b1 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    return vec2<u32>(hi, a * b);
}

// The key of texel `id` when it takes part in this digit's histogram (finite, below the limit
// when there is one, sharing the prefix picked so far), else NONE.
fn digit_key(id: vec2<u32>, prefix: u32) -> u32 {
    let size = textureDimensions(values);
    if id.x >= size.x || id.y >= size.y {
        return NONE;
    }
    let v = textureLoad(values, id, 0).r;
    let b = bitcast<u32>(v);
    if (b & 0x7f800000u) == 0x7f800000u || (QP.use_limit != 0u && !(v < QP.limit)) {
        return NONE;
    }
    let key = key_of(b);
    if QP.shift != 24u {
        let high = 0xffffffffu << (QP.shift + 8u);
        if (key & high) != (prefix & high) {
            return NONE;
        }
    }
    return key;
}

// One digit's histogram straight into `sel`: for CPU drivers, where workgroup memory and
// barriers cost more than the atomics they save.
@compute @workgroup_size(8, 8)
fn quantile_histogram(@builtin(global_invocation_id) id: vec3<u32>) {
    let key = digit_key(id.xy, atomicLoad(&sel[PREFIX]));
    if key == NONE {
        return;
    }
    if QP.shift == 24u {
        atomicAdd(&sel[N], 1u);
    }
    atomicAdd(&sel[(key >> QP.shift) & 0xffu], 1u);
}

// The same histogram for GPUs: each workgroup counts into its own bins, then adds the
// non-empty ones to `sel`.
var<workgroup> local_bins: array<atomic<u32>, 256>;
var<workgroup> local_n: atomic<u32>;
var<workgroup> local_prefix: u32;

@compute @workgroup_size(8, 8)
fn quantile_histogram_workgroup(
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
        if QP.shift == 24u {
            atomicAdd(&local_n, 1u);
        }
        atomicAdd(&local_bins[(key >> QP.shift) & 0xffu], 1u);
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
// the bins are cleared for the next digit. The first pick sets k from n: rank 0 is
// ⌊q·n / 2³²⌋, rank 1 is round(q·(n − 1) / 2³²) (q a 32-bit fraction).
@compute @workgroup_size(1)
fn quantile_pick() {
    if QP.shift == 24u {
        let n = atomicLoad(&sel[N]);
        let last = max(n, 1u) - 1u;
        var k = mul_wide(QP.q, n).x;
        if QP.rank == 1u {
            let p = mul_wide(QP.q, last);
            k = p.x + select(0u, 1u, p.y >= 0x80000000u);
        }
        atomicStore(&sel[K], min(k, last));
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
    atomicStore(&sel[PREFIX], atomicLoad(&sel[PREFIX]) | (digit << QP.shift));
    for (var i = 0u; i < BINS; i++) {
        atomicStore(&sel[i], 0u);
    }
}
