//! Proxy evaluation: a document evaluated at 1/f of the viewer's size while a knob is dragged,
//! as Nuke's proxy mode and Blender's viewer resolution do. The evaluation size is divided by
//! f, and so is every parameter measured in screen pixels (unit `px`: a filter's spatial σ, a
//! light position, an explicit G-buffer size), so the look holds at the smaller size.
//!
//! The light's space is proxied too: every parameter declared a light-space size
//! ([`ParamSpec::light_texels`](crate::graph::ParamSpec::light_texels): a shadow map's
//! resolution, a closure radius in texels, a soft-visibility buffer's side, an epipolar kernel's
//! length, a PCF radius) is divided by the same f, so a sun angle or a closure radius dragged
//! over a 2048² map is shown from a 512² one at ¼. Sizes in metres, table sizes (a transfer
//! function's, a phase table's) and light-map resolutions (the unknowns of a solve) stay as
//! they are. An image read from a file is read at 1/f too (`ImageInput.reduce`, a
//! [`ProxyScale::Reduction`]), so a plate stays the size of the pictures it is composited with.
//! A size in texels of a node's input, whichever space that input is in
//! ([`ProxyScale::InputTexels`]: `Blur.sigma`), is divided too, since the proxy shrinks both
//! pictures and maps: a soft glow keeps its width on the picture.

use crate::graph::{
    condition_holds, Catalog, Graph, Key, ParamKind, ParamSpec, ParamValue, ProxyScale,
};

/// The unit of parameters scaled with the viewer's size.
pub const SCREEN_PIXELS: &str = "px";

/// `size` divided by `factor` (at least 1×1; factor 0 or 1: unchanged).
pub fn proxy_size(size: (u32, u32), factor: u32) -> (u32, u32) {
    let f = factor.max(1);
    ((size.0 / f).max(1), (size.1 / f).max(1))
}

/// A copy of `graph` (flattened: no group nodes) with every `px` parameter and every
/// light-space size (see the module docs) — its value and its key-frames — divided by `factor`,
/// and every reduction factor (an input file's) multiplied by it.
/// An integer stays at least 1 where it was not 0 (0 means "the evaluation size" for such
/// parameters); values stay inside the parameter's range.
pub fn proxy_graph(graph: &Graph, catalog: &Catalog, factor: u32) -> Graph {
    let mut out = graph.clone();
    if factor <= 1 {
        return out;
    }
    let f = factor as f64;
    for node in graph.nodes() {
        let Some(schema) = graph.kind_schema(catalog, &node.kind) else {
            continue;
        };
        // The value in effect without key-frames: the one set, else the default.
        let current = |name: &str| -> Option<ParamValue> {
            let spec = schema.param(name)?;
            Some(
                node.params
                    .get(name)
                    .cloned()
                    .unwrap_or_else(|| spec.default.value()),
            )
        };
        // The factor a parameter is multiplied by, if it changes.
        let by = |spec: &ParamSpec| -> Option<f64> {
            match spec.proxy {
                ProxyScale::LightTexels | ProxyScale::InputTexels => Some(1.0 / f),
                ProxyScale::LightTexelsWhen(param, values) => {
                    condition_holds((param, values), |p| current(p).map(|v| v.to_string()))
                        .then_some(1.0 / f)
                }
                ProxyScale::Reduction => Some(f),
                ProxyScale::ByUnit => (spec.unit == SCREEN_PIXELS).then_some(1.0 / f),
            }
        };
        for spec in schema.params {
            let Some(by) = by(spec) else { continue };
            let scale = |v: f64| -> f64 {
                let s = match spec.kind {
                    ParamKind::Int if v != 0.0 => (v * by).round().max(1.0),
                    _ => v * by,
                };
                s.clamp(spec.min, spec.max)
            };
            let scaled = match current(spec.name) {
                Some(ParamValue::Float(v)) => Some(ParamValue::Float(scale(v))),
                Some(ParamValue::Int(v)) => Some(ParamValue::Int(scale(v as f64) as i64)),
                _ => None,
            };
            if let Some(v) = scaled {
                // In range by construction (clamped); a refusal would leave the value as it is.
                let _ = out.set_param(catalog, &node.id, spec.name, v);
            }
            if let Some(keys) = node.keys.get(spec.name) {
                let scaled: Vec<Key> = keys
                    .iter()
                    .map(|k| Key {
                        v: scale(k.v),
                        ..*k
                    })
                    .collect();
                let _ = out.set_keys(catalog, &node.id, spec.name, scaled);
            }
        }
    }
    out
}
