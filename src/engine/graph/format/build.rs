//! Building a graph from its parsed file: nodes with their parameters and key tracks, edges,
//! then the checks (acyclic, types), each error located in the file.

use std::collections::BTreeMap;

use super::{value_to_param, FileGraph, FileNode, Locator};
use crate::graph::document::{split_endpoint, Graph, Node};
use crate::graph::error::GraphError;
use crate::graph::schema::Catalog;
use crate::graph::types::{Key, ParamValue};

/// Build a graph from its parsed file, with `groups` (resolved definitions) available to its
/// nodes; the graph keeps those its nodes use.
pub(in crate::graph) fn build(
    f: FileGraph,
    loc: &Locator,
    catalog: &Catalog,
    groups: &BTreeMap<String, std::sync::Arc<crate::graph::GroupDef>>,
    inner: bool,
) -> Result<Graph, (Option<usize>, GraphError)> {
    let mut g = Graph::new();
    if let Some(c) = &f.colour {
        g.set_working_space(&c.working_space);
    }
    for (_, fnode) in &f.nodes {
        if let Some(def) = groups.get(&fnode.kind) {
            g.add_group(def.clone());
        }
    }
    let mut seen: BTreeMap<&str, usize> = BTreeMap::new();
    let mut key_tracks = key_tracks(&f, loc)?;
    for (id, fnode) in &f.nodes {
        let count = seen.entry(id.as_str()).or_insert(0);
        if *count > 0 {
            return Err((
                loc.node(id, *count),
                GraphError::DuplicateNode { node: id.clone() },
            ));
        }
        *count += 1;
        let node = Node {
            id: id.clone(),
            kind: fnode.kind.clone(),
            params: file_params(id, fnode, loc, catalog)?,
            keys: key_tracks.remove(id).unwrap_or_default(),
            pos: fnode.pos.map(|(x, y)| [x, y]),
            data: fnode.data.clone(),
        };
        g.insert_node(catalog, node).map_err(|e| {
            let at = match &e {
                GraphError::UnknownParam { param, .. }
                | GraphError::WrongParamType { param, .. }
                | GraphError::OutOfRange { param, .. } => loc
                    .param(id, param)
                    .or_else(|| loc.key(&format!("{id}.{param}"))),
                GraphError::BadKeys { target, .. } => loc.key(target),
                _ => loc.node(id, 0),
            };
            (at, e)
        })?;
    }
    if let Some((node, tracks)) = key_tracks.into_iter().next() {
        let target = format!(
            "{node}.{}",
            tracks.keys().next().map(String::as_str).unwrap_or("")
        );
        return Err((
            loc.key(&target),
            GraphError::BadKeys {
                reason: format!("no node '{node}'"),
                target,
            },
        ));
    }
    for (from, to) in &f.edges {
        g.connect_loading(catalog, from, to).map_err(|e| {
            let at = match &e {
                GraphError::EdgeMissingNode { node, .. }
                | GraphError::EdgeMissingPort { node, .. }
                    if to.starts_with(&format!("{node}.")) =>
                {
                    loc.edge(to)
                }
                _ => loc.edge(from),
            };
            (at, e)
        })?;
    }
    if let Err(e) = g.check_acyclic() {
        // Named by the edge that closes it in file order (only a file with a cycle pays).
        return Err(match g.first_cycle_edge(catalog, &f.edges) {
            Some((i, e)) => (loc.edge(&f.edges[i].0), e),
            None => (None, e),
        });
    }
    if inner {
        // A group's inner types depend on what reaches its inputs: they are checked in the
        // flattened graph of the document that instantiates it (below).
        return Ok(g);
    }
    // Types last: polymorphic outputs take their type from edges that may come later. Edges to
    // and from groups first against the groups' ports, then the flattened graph (what the
    // groups' insides make of what reaches them).
    g.check_all_types(catalog).map_err(|e| {
        let at = match &e {
            GraphError::TypeMismatch { from, .. } => loc.edge(from),
            _ => None,
        };
        (at, e)
    })?;
    if g.has_group_nodes() {
        let flat = g.flatten(catalog).map_err(|e| (None, e))?;
        flat.check_known_types(catalog).map_err(|e| (None, e))?;
    }
    Ok(g)
}

/// Key tracks by node, then parameter.
type KeyTracks = BTreeMap<String, BTreeMap<String, Vec<Key>>>;

/// The file's key tracks by node, then parameter.
fn key_tracks(f: &FileGraph, loc: &Locator) -> Result<KeyTracks, (Option<usize>, GraphError)> {
    let mut key_tracks = KeyTracks::new();
    for (target, keys) in &f.keys {
        let (node, param) = split_endpoint(target).map_err(|e| (loc.key(target), e))?;
        let keys = keys
            .iter()
            .map(|(t, v, interp)| Key {
                t: *t,
                v: *v,
                interp: *interp,
            })
            .collect();
        key_tracks
            .entry(node.to_string())
            .or_default()
            .insert(param.to_string(), keys);
    }
    Ok(key_tracks)
}

/// Node `id`'s parameter values as written (a value of no parameter type names what its
/// parameter expects).
fn file_params(
    id: &str,
    fnode: &FileNode,
    loc: &Locator,
    catalog: &Catalog,
) -> Result<BTreeMap<String, ParamValue>, (Option<usize>, GraphError)> {
    let mut params = BTreeMap::new();
    for (name, v) in &fnode.params {
        let pv = value_to_param(v).map_err(|found| {
            let expected = catalog
                .get(&fnode.kind)
                .and_then(|s| s.param(name))
                .map(|p| p.expected())
                .unwrap_or_else(|| "a parameter value".into());
            (
                loc.param(id, name),
                GraphError::WrongParamType {
                    node: id.to_string(),
                    param: name.clone(),
                    expected,
                    found,
                },
            )
        })?;
        params.insert(name.clone(), pv);
    }
    Ok(params)
}
