//! `tyndall node`: run one node on image files.

use super::*;

/// `tyndall node`.
#[derive(Args, Debug)]
pub struct NodeArgs {
    /// Node kind (see `tyndall nodes`).
    pub kind: String,
    /// Parameter: NAME=VALUE (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// RON file holding the node's data block.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Input port fed from a file: PORT=FILE (repeatable).
    #[arg(long = "input", value_name = "PORT=FILE")]
    pub inputs: Vec<String>,
    /// Output port written to a file: PORT=FILE (repeatable).
    #[arg(long = "output", value_name = "PORT=FILE")]
    pub outputs: Vec<String>,
    /// Time at which key-frames are sampled.
    #[arg(long, default_value_t = 0.0)]
    pub time: f64,
    /// Default image size, WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Print statistics.
    #[arg(long)]
    pub stats: bool,
}

pub(super) fn file_key(path: &Path) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    path.hash(&mut h);
    if let Ok(m) = std::fs::metadata(path) {
        m.len().hash(&mut h);
        m.modified().ok().hash(&mut h);
    }
    h.finish()
}

pub(super) fn run_node(registry: Arc<Registry>, a: NodeArgs) -> Result<(), CliError> {
    let catalog = registry.catalog().clone();
    let schema: &NodeSchema = catalog.get(&a.kind).ok_or_else(|| {
        bad(format!(
            "unknown node kind '{}' (known kinds: {})",
            a.kind,
            catalog.kind_names()
        ))
    })?;
    let id = a.kind.to_lowercase();
    let data = match &a.data {
        Some(d) => {
            let text =
                std::fs::read_to_string(d).map_err(|e| bad(format!("{}: {e}", d.display())))?;
            let v = crate::graph::NodeData::from_text(&text)
                .map_err(|e| bad(format!("{}:{e}", d.display())))?;
            Some(v)
        }
        None => None,
    };
    let mut g = Graph::new();
    g.insert_node(
        &catalog,
        crate::graph::Node {
            id: id.clone(),
            kind: a.kind.clone(),
            params: BTreeMap::new(),
            keys: BTreeMap::new(),
            pos: None,
            data,
        },
    )
    .map_err(bad)?;
    let mut set = Vec::new();
    for p in &a.params {
        let (name, value) = split_eq(p, "NAME=VALUE")?;
        set_param_str(&registry, &mut g, &id, &name, &value)?;
        set.push((id.clone(), name));
    }
    warn_not_in_effect(&registry, &g, &set);
    let gpu = gpu()?;
    let mut opts = EvalOptions {
        time: a.time,
        gpu_timings: a.stats,
        progress: Some(node_progress()),
        ..Default::default()
    };
    if let Some(s) = a.size {
        opts.size = s;
    }
    inject_inputs(&gpu, schema, &a, &id, &mut opts)?;
    let mut targets = Vec::new();
    let mut files = Vec::new();
    for o in &a.outputs {
        let (port, file) = split_eq(o, "PORT=FILE")?;
        if schema.output(&port).is_none() {
            return Err(bad(format!(
                "{} has no output port '{port}' (its outputs: {})",
                a.kind,
                schema.output_names()
            )));
        }
        targets.push(Target::Port(id.clone(), port.clone()));
        files.push((port, PathBuf::from(file)));
    }
    let is_sink = registry.get(&a.kind).is_some_and(|k| k.is_sink());
    if is_sink {
        targets.push(Target::Node(id.clone()));
    } else if targets.is_empty() {
        return Err(bad(format!(
            "nothing to write: give --output PORT=FILE (outputs of {}: {})",
            a.kind,
            schema.output_names()
        )));
    }
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    let result = ev.evaluate(&g, &targets, &opts)?;
    print_notes(&result);
    for (port, file) in files {
        if let Some(v) = result.outputs.get(&(id.clone(), port)) {
            write_value(&gpu, v, &file)?;
        }
    }
    if a.stats {
        print_stats(&result, "");
    }
    Ok(())
}

/// Feed `--input PORT=FILE` images to the node's input ports (uploaded as the port's type).
fn inject_inputs(
    gpu: &crate::gpu::Gpu,
    schema: &NodeSchema,
    a: &NodeArgs,
    id: &str,
    opts: &mut EvalOptions,
) -> Result<(), CliError> {
    for i in &a.inputs {
        let (port, file) = split_eq(i, "PORT=FILE")?;
        let spec = schema.input(&port).ok_or_else(|| {
            bad(format!(
                "{} has no input port '{port}' (its inputs: {})",
                a.kind,
                schema.input_names()
            ))
        })?;
        let path = PathBuf::from(&file);
        let raster = read_image(&path, true).map_err(bad)?;
        let ty = type_for_file(spec.types, raster.channels).ok_or_else(|| {
            bad(format!(
                "{file}: a {}-channel image cannot feed {}.{port}",
                raster.channels, a.kind
            ))
        })?;
        let v = upload_raster(gpu, &raster, ty).map_err(|e| bad(format!("{file}: {e}")))?;
        opts.inject
            .insert((id.to_string(), port.clone()), (v, file_key(&path)));
    }
    Ok(())
}
