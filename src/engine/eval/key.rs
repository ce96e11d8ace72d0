//! Step 2 of an evaluation, the key: what a node's cache key covers, and the input values it
//! runs on (see the module documentation of `eval`).

use super::*;

/// What the nodes evaluated so far produced: their keys and outputs.
#[derive(Default)]
pub(super) struct Upstream {
    pub(super) keys: BTreeMap<String, u64>,
    pub(super) results: BTreeMap<String, BTreeMap<String, PortValue>>,
}

/// A missing upstream value, reported against the node that needed it.
pub(super) struct MissingInput {
    port: String,
    message: String,
}

impl MissingInput {
    pub(super) fn into_eval(self, node_err: &dyn Fn(NodeError) -> EvalError) -> EvalError {
        node_err(NodeError::Input {
            port: self.port,
            message: self.message,
        })
    }
}

/// Step 2, key: the node's cache key — kind, parameters (less the exempt ones), data block,
/// volatile material, evaluation size, and each input's upstream key — and its input values.
pub(super) fn key_and_inputs(
    graph: &Graph,
    id: &str,
    k: &dyn NodeKind,
    kind: &str,
    params: &BTreeMap<String, ParamValue>,
    done: &Upstream,
    opts: &EvalOptions,
) -> Result<(u64, BTreeMap<String, PortValue>), MissingInput> {
    let mut h = DefaultHasher::new();
    kind.hash(&mut h);
    for (name, v) in params {
        if !k.key_exempt().contains(&name.as_str()) {
            name.hash(&mut h);
            v.hash_into(&mut h);
        }
    }
    let data = graph.node(id).and_then(|n| n.data.as_ref());
    data.hash(&mut h);
    k.volatile_key(&KeyInput {
        params,
        data,
        time: opts.time,
    })
    .hash(&mut h);
    // Every file the node declares it reads: its size and modification time, so editing the
    // file on disk re-runs the node.
    for name in k.file_params(FileRole::Read) {
        if let Some(ParamValue::Text(p)) = params.get(name) {
            paths::file_stamp(std::path::Path::new(p)).hash(&mut h);
        }
    }
    opts.size.hash(&mut h);
    let mut inputs = BTreeMap::new();
    for input in k.schema().inputs {
        if let Some((src, sport)) = graph.source_of(id, input.name) {
            let v = done
                .results
                .get(src)
                .and_then(|r| r.get(sport))
                .cloned()
                .ok_or_else(|| MissingInput {
                    port: input.name.to_string(),
                    message: format!("upstream {src}.{sport} produced no value"),
                })?;
            // A scene is keyed by the parts the node reads, where it declares them; any other
            // input by its upstream node's key.
            match (k.decl().scene_parts, v.payload::<crate::scene::GpuScene>()) {
                (Some(parts), Some(scene)) => {
                    (input.name, "scene", scene.parts.select(parts)).hash(&mut h)
                }
                _ => (input.name, done.keys.get(src), sport).hash(&mut h),
            }
            inputs.insert(input.name.to_string(), v);
        } else if let Some((v, vkey)) = opts.inject.get(&(id.to_string(), input.name.to_string())) {
            (input.name, "inject", vkey).hash(&mut h);
            inputs.insert(input.name.to_string(), v.clone());
        }
    }
    Ok((h.finish(), inputs))
}
