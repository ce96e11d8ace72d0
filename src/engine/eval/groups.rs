//! Evaluating a graph with group nodes: it is flattened first (`group/inner` ids, in statistics
//! too), and targets on a group's ports or on a group node are translated to inner ports.

use super::{EvalError, EvalOptions, Evaluation, Evaluator, NodeError, Target};
use crate::graph::Graph;

impl Evaluator {
    /// Evaluate `targets` of `graph`: only nodes they depend on are considered, and of those only
    /// nodes whose key changed since their cached result run again. A graph with group nodes is
    /// evaluated flattened (`group/inner` ids, in statistics too); a target on a group node's
    /// output port is its inner port's value, returned under the group's (node, port).
    pub fn evaluate(
        &mut self,
        graph: &Graph,
        targets: &[Target],
        opts: &EvalOptions,
    ) -> Result<Evaluation, EvalError> {
        if graph.has_group_nodes() {
            let (flat, ports) = graph.flatten_ports(self.registry.catalog())?;
            let mut renamed = Vec::new();
            let targets: Vec<Target> = targets
                .iter()
                .flat_map(|t| match t {
                    Target::Port(n, p) => match ports.get(&(n.clone(), p.clone())) {
                        Some((fnode, fport)) => {
                            renamed.push(((fnode.clone(), fport.clone()), (n.clone(), p.clone())));
                            vec![Target::Port(fnode.clone(), fport.clone())]
                        }
                        None => vec![t.clone()],
                    },
                    Target::Node(n)
                        if graph
                            .node(n)
                            .is_some_and(|x| graph.groups().contains_key(&x.kind)) =>
                    {
                        let mut out: Vec<Target> = Vec::new();
                        for ((inst, port), (fnode, fport)) in &ports {
                            if inst == n {
                                renamed.push((
                                    (fnode.clone(), fport.clone()),
                                    (inst.clone(), port.clone()),
                                ));
                                out.push(Target::Port(fnode.clone(), fport.clone()));
                            }
                        }
                        let prefix = format!("{n}/");
                        out.extend(
                            self.sinks(&flat).into_iter().filter(
                                |s| matches!(s, Target::Node(id) if id.starts_with(&prefix)),
                            ),
                        );
                        out
                    }
                    _ => vec![t.clone()],
                })
                .collect();
            let mut ev = self
                .evaluate_flat(&flat, &targets, opts)
                .map_err(|e| in_group(graph, e))?;
            for (from, to) in renamed {
                if let Some(v) = ev.outputs.get(&from).cloned() {
                    ev.outputs.insert(to, v);
                }
            }
            return Ok(ev);
        }
        self.evaluate_flat(graph, targets, opts)
    }
}

/// A failure of a node inside a group node (`group/inner` in the flattened graph) names the
/// group node and its group: `node 'irregular/noise' (NoiseVolume): inside group node
/// 'irregular' (IrregularMedium): …`. Nested groups name the outermost.
fn in_group(graph: &Graph, e: EvalError) -> EvalError {
    let EvalError::Node { node, kind, source } = e else {
        return e;
    };
    let group = node.split('/').next().unwrap_or_default();
    match graph.node(group).filter(|_| node.contains('/')) {
        Some(g) if graph.groups().contains_key(&g.kind) => EvalError::Node {
            source: NodeError::InGroup {
                group: group.to_string(),
                definition: g.kind.clone(),
                error: Box::new(source),
            },
            node,
            kind,
        },
        _ => EvalError::Node { node, kind, source },
    }
}
