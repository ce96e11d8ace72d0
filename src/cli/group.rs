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
}

fn unique_name(wanted: &str, fallback: String, taken: &[String]) -> String {
    if !taken.iter().any(|t| t == wanted) {
        wanted.to_string()
    } else {
        fallback
    }
}

pub(super) fn run_group(registry: Arc<Registry>, a: GroupArgs) -> Result<(), CliError> {
    use crate::graph::{GroupDef, GroupPort, Knob};
    let cat = registry.catalog();
    let g = load_file(&a.graph, cat).map_err(bad)?;
    let chosen: std::collections::BTreeSet<String> = a.nodes.iter().cloned().collect();
    for id in &chosen {
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
    let mut inner = Graph::new();
    for n in g.nodes().filter(|n| chosen.contains(&n.id)) {
        if let Some(def) = g.groups().get(&n.kind) {
            inner.add_group(def.clone());
        }
        inner.insert_node(cat, n.clone()).map_err(bad)?;
    }
    let mut inputs: Vec<GroupPort> = Vec::new();
    let mut outputs: Vec<GroupPort> = Vec::new();
    let mut sources: Vec<(String, String)> = Vec::new();
    let mut inner_sources: Vec<(String, String)> = Vec::new();
    for e in g.edges() {
        match (chosen.contains(&e.from_node), chosen.contains(&e.to_node)) {
            (true, true) => inner
                .connect_deferred(
                    cat,
                    &format!("{}.{}", e.from_node, e.from_port),
                    &format!("{}.{}", e.to_node, e.to_port),
                )
                .map_err(bad)?,
            (false, true) => {
                let src = (e.from_node.clone(), e.from_port.clone());
                let target = (e.to_node.clone(), e.to_port.clone());
                match sources.iter().position(|s| *s == src) {
                    Some(i) => inputs[i].targets.push(target),
                    None => {
                        let taken: Vec<String> = inputs.iter().map(|p| p.name.clone()).collect();
                        let name =
                            unique_name(&e.to_port, format!("{}_{}", e.to_node, e.to_port), &taken);
                        sources.push(src);
                        inputs.push(GroupPort {
                            name,
                            doc: format!(
                                "From {}.{} in {}.",
                                e.from_node,
                                e.from_port,
                                a.graph.display()
                            ),
                            targets: vec![target],
                        });
                    }
                }
            }
            (true, false) => {
                let src = (e.from_node.clone(), e.from_port.clone());
                if !inner_sources.contains(&src) {
                    let taken: Vec<String> = outputs.iter().map(|p| p.name.clone()).collect();
                    let name = unique_name(
                        &e.from_port,
                        format!("{}_{}", e.from_node, e.from_port),
                        &taken,
                    );
                    inner_sources.push(src.clone());
                    outputs.push(GroupPort {
                        name,
                        doc: format!("{}.{} of the grouped nodes.", e.from_node, e.from_port),
                        targets: vec![src],
                    });
                }
            }
            (false, false) => {}
        }
    }
    let mut knobs: Vec<Knob> = Vec::new();
    for x in &a.expose {
        let (target, name) = match x.split_once('=') {
            Some((t, n)) => (t, n.to_string()),
            None => (x.as_str(), split_endpoint(x).map_err(bad)?.1.to_string()),
        };
        let (n, p) = split_endpoint(target).map_err(bad)?;
        if !chosen.contains(n) {
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
    let def = GroupDef::new(
        cat, &a.name, a.version, &a.doc, inputs, outputs, knobs, inner, None,
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
    Ok(())
}
