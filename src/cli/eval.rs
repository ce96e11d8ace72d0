//! `tyndall eval`: evaluate a graph once, writing its sinks or the ports asked for.

use super::*;
use crate::eval::FileRole;

/// `tyndall eval`.
#[derive(Args, Debug)]
pub struct EvalArgs {
    /// The graph file.
    pub graph: PathBuf,
    /// Replace the file a node reads (e.g. an ImageInput's `path`): NODE=FILE (repeatable).
    #[arg(long = "input", value_name = "NODE=FILE")]
    pub inputs: Vec<String>,
    /// Write an output port to a file: NODE.PORT=FILE (repeatable). Without any, the graph's
    /// outputs (sinks) are evaluated.
    #[arg(long = "output", value_name = "NODE.PORT=FILE")]
    pub outputs: Vec<String>,
    /// Time at which key-frames are sampled.
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
}

pub(super) fn run_eval(registry: Arc<Registry>, a: EvalArgs) -> Result<(), CliError> {
    let mut g = load_graph(&registry, &a.graph, &a.common)?;
    for i in &a.inputs {
        let (node, file) = split_eq(i, "NODE=FILE")?;
        // The first file the node's kind declares it reads.
        let param = g
            .node(&node)
            .and_then(|n| registry.get(&n.kind))
            .and_then(|k| k.file_params(FileRole::Read).next())
            .ok_or_else(|| {
                bad(format!(
                    "--input {node}=...: node '{node}' is not in the graph or reads no file"
                ))
            })?;
        g.set_param(registry.catalog(), &node, param, ParamValue::Text(file))
            .map_err(bad)?;
    }
    let mut targets = Vec::new();
    let mut files = Vec::new();
    for o in &a.outputs {
        let (target, file) = split_eq(o, "NODE.PORT=FILE")?;
        let (node, port) = split_endpoint(&target).map_err(bad)?;
        targets.push(Target::Port(node.to_string(), port.to_string()));
        files.push(((node.to_string(), port.to_string()), file));
    }
    let gpu = gpu()?;
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    if targets.is_empty() {
        targets = ev.sinks(&g);
        if targets.is_empty() {
            return Err(bad(format!(
                "{}: the graph has no outputs; give --output NODE.PORT=FILE",
                a.graph.display()
            )));
        }
    }
    let vars = variants(&registry, &g, &a.common)?;
    for v in &vars {
        let opts = EvalOptions {
            time: a.time,
            size: a.common.size_or((512, 512)),
            output_suffix: v.suffix.clone(),
            frame: None,
            gpu_timings: a.common.stats,
            // The GPU works while later nodes are recorded; --stats reads its per-node
            // time from timestamps, not from waits.
            pipelined: true,
            inject: BTreeMap::new(),
            progress: Some(node_progress()),
            ..Default::default()
        };
        let result = ev.evaluate(&v.graph, &targets, &opts)?;
        print_notes(&result);
        for (key, file) in &files {
            if let Some(val) = result.outputs.get(key) {
                write_value(&gpu, val, &with_suffix(file, &v.suffix))?;
            }
        }
        if a.common.stats {
            print_stats(&result, &v.label);
        }
    }
    Ok(())
}
