// Order-preserving keys of f32 bits (shaders/algorithms/quantile.wgsl selects them): the value
// of a key, and where a selection buffer keeps what it chose.

// Word of a selection buffer: how many values took part.
const SELECTED_N: u32 = 256u;
// Word of a selection buffer: the selected key.
const SELECTED_KEY: u32 = 258u;

// The value of an order-preserving key (the inverse of the quantile pass's `key_of`).
fn value_of(k: u32) -> f32 {
    return bitcast<f32>(select(~k, k & 0x7fffffffu, (k & 0x80000000u) != 0u));
}
