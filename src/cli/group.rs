//! `tyndall group`: make a library group from nodes of a graph.
//!
//! The chosen nodes become the group's inner graph; every edge from outside into them becomes an
//! input (one per outside source, feeding every inner port it fed), every edge from them to
//! outside an output (one per inner source); `--expose node.param[=name]` makes knobs.

use super::*;

/// `tyndall group`.
#[derive(Args, Debug)]
pub struct GroupArgs {
    /// The graph holding the nodes.
    pub graph: PathBuf,
    /// Comma-separated ids of the nodes to group.
    #[arg(long, value_delimiter = ',', required = true)]
    pub nodes: Vec<String>,
    /// The group's name: the kind graphs instantiate it as (`HoleFilling`).
    #[arg(long)]
    pub name: String,
    /// The library file to write (`graphs/lib/stylize/hole_filling.ron`); a graph references it
    /// by its path under the `lib/` folder, without `.ron`.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Expose an inner parameter as a knob: `node.param` (knob named `param`) or
    /// `node.param=name` (repeatable; several with the same name make one knob driving them all).
    #[arg(long)]
    pub expose: Vec<String>,
    /// The group's one-line doc.
    #[arg(long, default_value = "")]
    pub doc: String,
    /// The group's version (a graph references a group by name and version).
    #[arg(long, default_value_t = 1)]
    pub version: u32,
    /// Also rewrite GRAPH: the nodes replaced by one instance with this id of the new library
    /// group (the output must lie under a `lib/` folder the graph finds).
    #[arg(long, value_name = "ID")]
    pub rewrite: Option<String>,
}

/// The reference graphs use for the library file `path`: its path under the nearest `lib/`
/// folder, without `.ron` (`graphs/lib/stylize/hole_filling.ron` → `stylize/hole_filling`).
fn reference_of(path: &Path) -> Option<String> {
    let comps: Vec<String> = path
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let i = comps.iter().rposition(|c| c == "lib")?;
    (i + 1 < comps.len()).then(|| comps[i + 1..].join("/"))
}

pub(super) fn run_group(registry: Arc<Registry>, a: GroupArgs) -> Result<(), CliError> {
    use crate::graph::{Knob, LibraryRef};
    let cat = registry.catalog();
    let g = load_file(&a.graph, cat).map_err(bad)?;
    for id in &a.nodes {
        if g.node(id).is_none() {
            return Err(bad(format!(
                "{}: no node '{id}' (its nodes: {})",
                a.graph.display(),
                g.nodes()
                    .map(|n| n.id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
    }
    let mut knobs: Vec<Knob> = Vec::new();
    for x in &a.expose {
        let (target, name) = match x.split_once('=') {
            Some((t, n)) => (t, n.to_string()),
            None => (x.as_str(), split_endpoint(x).map_err(bad)?.1.to_string()),
        };
        let (n, p) = split_endpoint(target).map_err(bad)?;
        if !a.nodes.iter().any(|id| id == n) {
            return Err(bad(format!(
                "--expose {x}: node '{n}' is not one of --nodes"
            )));
        }
        let t = (n.to_string(), p.to_string());
        match knobs.iter_mut().find(|k| k.name == name) {
            Some(k) => k.targets.push(t),
            None => knobs.push(Knob {
                name,
                doc: String::new(),
                targets: vec![t],
                default: None,
                min: None,
                max: None,
            }),
        }
    }
    let reference = reference_of(&a.output);
    if a.rewrite.is_some() && reference.is_none() {
        return Err(bad(format!(
            "--rewrite: {} is not under a lib/ folder, so a graph cannot reference it",
            a.output.display()
        )));
    }
    let library = reference.clone().map(|name| LibraryRef {
        name,
        path: a.output.clone(),
    });
    let instance = a.rewrite.clone().unwrap_or_else(|| "group".into());
    let (def, outer) = g
        .group_nodes(
            cat, &a.nodes, &a.name, a.version, &a.doc, knobs, &instance, library,
        )
        .map_err(bad)?;
    if let Some(dir) = a.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| bad(format!("cannot create {}: {e}", dir.display())))?;
    }
    crate::graph::write_atomic(&a.output, crate::graph::library_text(&def).as_bytes())
        .map_err(bad)?;
    let s = def.schema();
    println!(
        "{}: group {} version {} — {} inputs, {} outputs, {} knobs",
        a.output.display(),
        a.name,
        a.version,
        s.inputs.len(),
        s.outputs.len(),
        s.params.len()
    );
    if a.rewrite.is_some() {
        crate::graph::save_file(&a.graph, &outer).map_err(bad)?;
        println!(
            "{}: the nodes are now '{instance}' ({}, library \"{}\")",
            a.graph.display(),
            a.name,
            reference.unwrap_or_default()
        );
    }
    Ok(())
}
