//! Proxy evaluation: a document evaluated at 1/f of the viewer's size while a knob is dragged,
//! as Nuke's proxy mode and Blender's viewer resolution do. The evaluation size is divided by
//! f, and so is every parameter measured in screen pixels (unit `px`: a filter's spatial σ, a
//! light position, an explicit G-buffer size), so the look holds at the smaller size. Sizes
//! in shadow-map texels or metres do not depend on the viewer and stay as they are.

use crate::graph::{Catalog, Graph, Key, ParamKind, ParamValue};

/// The unit of parameters scaled with the viewer's size.
pub const SCREEN_PIXELS: &str = "px";

/// `size` divided by `factor` (at least 1×1; factor 0 or 1: unchanged).
pub fn proxy_size(size: (u32, u32), factor: u32) -> (u32, u32) {
    let f = factor.max(1);
    ((size.0 / f).max(1), (size.1 / f).max(1))
}

/// A copy of `graph` (flattened: no group nodes) with every `px` parameter — its value and its
/// key-frames — divided by `factor`. An integer stays at least 1 where it was not 0 (0 means
/// "the evaluation size" for such parameters); values stay inside the parameter's range.
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
        for spec in schema.params.iter().filter(|p| p.unit == SCREEN_PIXELS) {
            let scale = |v: f64| -> f64 {
                let s = match spec.kind {
                    ParamKind::Int if v != 0.0 => (v / f).round().max(1.0),
                    _ => v / f,
                };
                s.clamp(spec.min, spec.max)
            };
            // The value in effect without key-frames: the one set, else the default.
            let current = node
                .params
                .get(spec.name)
                .cloned()
                .unwrap_or_else(|| spec.default.value());
            let scaled = match current {
                ParamValue::Float(v) => Some(ParamValue::Float(scale(v))),
                ParamValue::Int(v) => Some(ParamValue::Int(scale(v as f64) as i64)),
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
