// The mip chain of a volume (nodes/algorithms/volume_mips.rs; `NoiseVolume` and `BlendVolume`):
// each level the mean of the (up to) 2×2×2 texels of the level below it covers.

@group(0) @binding(0) var out_level: texture_storage_3d<r32float, write>;
@group(0) @binding(1) var src_level: texture_3d<f32>;

// One mip level from the level below: the mean of the (up to) 2×2×2 texels it covers.
@compute @workgroup_size(4, 4, 4)
fn mip(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_level);
    if any(id >= size) {
        return;
    }
    let below = vec3<i32>(textureDimensions(src_level));
    var sum = 0.0;
    var n = 0.0;
    for (var k = 0; k < 8; k++) {
        let q = vec3<i32>(id) * 2 + vec3<i32>(k & 1, (k >> 1u) & 1, (k >> 2u) & 1);
        if all(q < below) {
            sum += textureLoad(src_level, q, 0).r;
            n += 1.0;
        }
    }
    textureStore(out_level, id, vec4<f32>(sum / max(n, 1.0), 0.0, 0.0, 1.0));
}
