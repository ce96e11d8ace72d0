// SingleScattering, method Epipolar: the slices' uniforms and bindings, and their rectified
// map lines' 1D min-max trees (nodes/single_scattering/epipolar.rs), shared by the sun's sample
// rays (epipolar.wgsl) and a spot's (epipolar_lamp.wgsl); the fall-back pixels trace the
// MinMax traversal, hence the import.
#import single_scattering/min_max

// ---- Method Epipolar: epipolar sampling with 1D min-max trees (see the node's doc) ----------
//
// The slice table (width = slices): row 0 (entry.xy, dir.xy) of the slice's screen segment,
// row 1 (length, chord), row 2 (origin.xy, direction.xy) of its line in the map (texels). The
// trees: row k of `tree` holds 2n entries (min, max), level j (n/2^j wide) at 2n − 2n/2^j.

struct Epi {
    epipole: vec2<f32>,
    u_start: f32,
    arc: f32,
    size: vec2<f32>,
    slices: u32,
    samples: u32,
    inside: u32,
    tree_n: u32,
    tree_top: u32,
    tree_level: u32,
    threshold: f32,
    // Level being built (epi_tree).
    level: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(16) var<uniform> E: Epi;
@group(0) @binding(17) var slice_table: texture_2d<f32>;
@group(0) @binding(18) var<storage, read_write> tree: array<vec2<f32>>;
@group(0) @binding(19) var out_samples: texture_storage_2d<rgba32float, write>;
@group(0) @binding(20) var samples_in: texture_2d<f32>;

// Texels one leaf's stretch of a ray can cross (three, and one for rounding left-overs).
const LEAF_CELLS: u32 = 4u;

// The map's depth at the texel whose corner is `cell` (floored texel coordinates); texels
// outside the map, like leaves past a chord's end, are clear (always lit).
fn map_depth(cell: vec2<f32>) -> f32 {
    let size = vec2<f32>(textureDimensions(shadow));
    if !(cell.x >= 0.0 && cell.y >= 0.0 && cell.x < size.x && cell.y < size.y) {
        return SHADOW_CLEAR;
    }
    let t = min(vec2<u32>(cell), vec2<u32>(size) - 1u);
    return textureLoad(shadow, t, 0).r;
}

// Leaf i of slice k: (min, max) depth over the texels the slice's map line crosses between
// distances i and i + 1 from its origin, walked texel by texel.
@compute @workgroup_size(8, 8)
fn epi_rectify(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= E.tree_n || id.y >= E.slices {
        return;
    }
    let chord = textureLoad(slice_table, vec2<u32>(id.y, 1u), 0).y;
    let line = textureLoad(slice_table, vec2<u32>(id.y, 2u), 0);
    var leaf = vec2<f32>(SHADOW_CLEAR);
    let i = f32(id.x);
    if i < chord {
        let d = line.zw;
        let start = line.xy + d * i;
        let len = min(chord - i, 1.0);
        let nudge = sign(d) * 1e-4;
        var mn = SHADOW_CLEAR;
        var mx = -SHADOW_CLEAR;
        var t = 0.0;
        for (var it = 0; it < 4; it++) {
            if t >= len {
                break;
            }
            let cell = floor(start + d * t + nudge);
            var te = len;
            for (var k = 0; k < 2; k++) {
                if d[k] > 1e-9 {
                    te = min(te, (cell[k] + 1.0 - start[k]) / d[k]);
                } else if d[k] < -1e-9 {
                    te = min(te, (cell[k] - start[k]) / d[k]);
                }
            }
            let z = map_depth(cell);
            mn = min(mn, z);
            mx = max(mx, z);
            t = max(te, t + 1e-4);
        }
        leaf = vec2<f32>(mn, mx);
    }
    tree[id.y * 2u * E.tree_n + id.x] = leaf;
}

// Level E.level of every slice's tree from the level below.
@compute @workgroup_size(8, 8)
fn epi_tree(@builtin(global_invocation_id) id: vec3<u32>) {
    let width = E.tree_n >> E.level;
    if id.x >= width || id.y >= E.slices {
        return;
    }
    let row = id.y * 2u * E.tree_n;
    let src = row + 2u * E.tree_n - 4u * width;
    let dst = row + 2u * E.tree_n - 2u * width;
    let a = tree[src + 2u * id.x];
    let b = tree[src + 2u * id.x + 1u];
    tree[dst + id.x] = vec2<f32>(min(a.x, b.x), max(a.y, b.y));
}
