//! Edges of a graph: connecting ports (type-checked against the catalog, one source per input,
//! no cycles) and disconnecting them.

use petgraph::visit::{EdgeRef, IntoEdgeReferences};
use petgraph::Direction as PgDir;

use super::document::*;
use super::*;

impl Graph {
    /// Connect output `from` (`node.port`) to input `to` (`node.port`).
    ///
    /// Refused (document unchanged) when a node or port is missing, the types are incompatible,
    /// the input already has an edge, or the edge would close a cycle; the error names both ends.
    pub fn connect(&mut self, catalog: &Catalog, from: &str, to: &str) -> Result<(), GraphError> {
        self.connect_impl(catalog, from, to, true, true)
    }

    /// Like [`Graph::connect`] but without the type checks, for loading a whole file: a
    /// polymorphic output's type depends on edges listed later, so the loader adds every edge
    /// and then calls [`Graph::check_all_types`] once.
    pub fn connect_deferred(
        &mut self,
        catalog: &Catalog,
        from: &str,
        to: &str,
    ) -> Result<(), GraphError> {
        self.connect_impl(catalog, from, to, false, true)
    }

    /// Like [`Graph::connect_deferred`], and without the cycle search: the loader adds a whole
    /// file's edges so, then checks for a cycle once ([`Graph::check_acyclic`]) — one search per
    /// edge made loading quadratic in the graph's size.
    pub(super) fn connect_loading(
        &mut self,
        catalog: &Catalog,
        from: &str,
        to: &str,
    ) -> Result<(), GraphError> {
        self.connect_impl(catalog, from, to, false, false)
    }

    /// A cycle anywhere, named by one of its edges (a linear-time topological sort).
    pub(super) fn check_acyclic(&self) -> Result<(), GraphError> {
        let Err(cycle) = petgraph::algo::toposort(&self.g, None) else {
            return Ok(());
        };
        let n = cycle.node_id();
        // An edge into `n` from a node that `n` reaches closes the cycle.
        for e in self.g.edges_directed(n, PgDir::Incoming) {
            if e.source() == n || petgraph::algo::has_path_connecting(&self.g, n, e.source(), None)
            {
                let (a, b) = (&self.g[e.source()].id, &self.g[n].id);
                return Err(GraphError::Cycle {
                    from: format!("{a}.{}", e.weight().from_port),
                    to: format!("{b}.{}", e.weight().to_port),
                    from_node: a.clone(),
                    to_node: b.clone(),
                });
            }
        }
        Err(GraphError::Cycle {
            from: self.g[n].id.clone(),
            to: self.g[n].id.clone(),
            from_node: self.g[n].id.clone(),
            to_node: self.g[n].id.clone(),
        })
    }

    pub(super) fn connect_impl(
        &mut self,
        catalog: &Catalog,
        from: &str,
        to: &str,
        check_types: bool,
        check_cycle: bool,
    ) -> Result<(), GraphError> {
        let (fnode, fport) = split_endpoint(from)?;
        let (tnode, tport) = split_endpoint(to)?;
        let missing = |node: &str| GraphError::EdgeMissingNode {
            from: from.to_string(),
            to: to.to_string(),
            node: node.to_string(),
        };
        let fix = *self.index.get(fnode).ok_or_else(|| missing(fnode))?;
        let tix = *self.index.get(tnode).ok_or_else(|| missing(tnode))?;
        let fschema = self.schema_of(catalog, fnode)?;
        let tschema = self.schema_of(catalog, tnode)?;
        if fschema.output(fport).is_none() {
            return Err(GraphError::EdgeMissingPort {
                from: from.into(),
                to: to.into(),
                node: fnode.into(),
                kind: fschema.kind.into(),
                direction: "output",
                port: fport.into(),
                known: fschema.output_names(),
            });
        }
        if tschema.input(tport).is_none() {
            return Err(GraphError::EdgeMissingPort {
                from: from.into(),
                to: to.into(),
                node: tnode.into(),
                kind: tschema.kind.into(),
                direction: "input",
                port: tport.into(),
                known: tschema.input_names(),
            });
        }
        if let Some((sn, sp)) = self.source_of(tnode, tport) {
            return Err(GraphError::InputTaken {
                from: from.into(),
                to: to.into(),
                existing: format!("{sn}.{sp}"),
            });
        }
        if fix == tix
            || (check_cycle && petgraph::algo::has_path_connecting(&self.g, tix, fix, None))
        {
            return Err(GraphError::Cycle {
                from: from.into(),
                to: to.into(),
                from_node: fnode.into(),
                to_node: tnode.into(),
            });
        }
        if check_types {
            self.check_edge_type(catalog, fnode, fport, tnode, tport)?;
        }
        let e = self.g.add_edge(
            fix,
            tix,
            Wire {
                from_port: fport.to_string(),
                to_port: tport.to_string(),
            },
        );
        // A polymorphic output may have changed type: re-check every edge downstream.
        if !check_types {
            return Ok(());
        }
        if let Err(err) = self.check_all_types(catalog) {
            self.g.remove_edge(e);
            return Err(err);
        }
        Ok(())
    }

    /// Remove the edge into input `port` of node `id`; returns whether there was one.
    pub fn disconnect(&mut self, id: &str, port: &str) -> bool {
        let Some(ix) = self.index.get(id) else {
            return false;
        };
        let e = self
            .g
            .edges_directed(*ix, PgDir::Incoming)
            .find(|e| e.weight().to_port == port)
            .map(|e| e.id());
        match e {
            Some(e) => self.g.remove_edge(e).is_some(),
            None => false,
        }
    }

    pub(super) fn check_edge_type(
        &self,
        catalog: &Catalog,
        fnode: &str,
        fport: &str,
        tnode: &str,
        tport: &str,
    ) -> Result<(), GraphError> {
        let Some(ft) = self.output_type(catalog, fnode, fport) else {
            return Ok(());
        };
        self.check_type_into(catalog, ft, (fnode, fport), (tnode, tport))
    }

    /// Check the type of every edge whose source type is known: a polymorphic output none of
    /// whose node's inputs is connected takes its type from what will reach it, so its edges
    /// are left for later (a group instance whose inputs are not wired yet).
    pub fn check_known_types(&self, catalog: &Catalog) -> Result<(), GraphError> {
        self.check_types_where(catalog, |g, e| {
            let from = e.source();
            let polymorphic = g
                .schema_of(catalog, &g.g[from].id)
                .ok()
                .and_then(|s| s.output(&e.weight().from_port))
                .is_some_and(|p| p.types.len() > 1);
            let fed = g.g.edges_directed(from, PgDir::Incoming).next().is_some();
            !polymorphic || fed
        })
    }

    /// Check the type of every edge.
    pub fn check_all_types(&self, catalog: &Catalog) -> Result<(), GraphError> {
        self.check_types_where(catalog, |_, _| true)
    }

    /// Check the edges `which` keeps against the output types resolved in one pass
    /// ([`Graph::resolve_types`]), in [`Graph::edges`] order so the first mismatch reported is
    /// the same whatever the graph's size.
    fn check_types_where(
        &self,
        catalog: &Catalog,
        which: impl Fn(&Graph, petgraph::stable_graph::EdgeReference<'_, Wire>) -> bool,
    ) -> Result<(), GraphError> {
        let types = self.resolve_types(catalog, &self.source_order());
        let mut edges: Vec<_> = (&self.g)
            .edge_references()
            .filter(|e| which(self, *e))
            .collect();
        type Edge<'e> = petgraph::stable_graph::EdgeReference<'e, Wire>;
        let key = |e: &Edge<'_>| {
            (
                self.g[e.target()].id.clone(),
                e.weight().to_port.clone(),
                self.g[e.source()].id.clone(),
                e.weight().from_port.clone(),
            )
        };
        edges.sort_by_cached_key(key);
        for e in edges {
            let Some(ft) = types.get(&(e.source(), e.weight().from_port.as_str())) else {
                continue;
            };
            self.check_edge_against(catalog, *ft, e)?;
        }
        Ok(())
    }

    /// Edge `e`, whose source gives type `ft`, type-checked against its input port.
    fn check_edge_against(
        &self,
        catalog: &Catalog,
        ft: PortType,
        e: petgraph::stable_graph::EdgeReference<'_, Wire>,
    ) -> Result<(), GraphError> {
        let from = (
            self.g[e.source()].id.as_str(),
            e.weight().from_port.as_str(),
        );
        let to = (self.g[e.target()].id.as_str(), e.weight().to_port.as_str());
        self.check_type_into(catalog, ft, from, to)
    }

    /// A value of type `ft` from `from` (node, port) accepted by input `to`, or the mismatch.
    fn check_type_into(
        &self,
        catalog: &Catalog,
        ft: PortType,
        (fnode, fport): (&str, &str),
        (tnode, tport): (&str, &str),
    ) -> Result<(), GraphError> {
        let tschema = self.schema_of(catalog, tnode)?;
        let accepts = tschema.input(tport).map(|p| p.types).unwrap_or(&[]);
        if accepts.iter().any(|t| ft.can_feed(*t)) {
            return Ok(());
        }
        Err(GraphError::TypeMismatch {
            from: format!("{fnode}.{fport}"),
            to: format!("{tnode}.{tport}"),
            from_type: ft,
            to_types: accepts
                .iter()
                .map(|t| t.name())
                .collect::<Vec<_>>()
                .join(" | "),
        })
    }

    /// The first of `edges` (file order) that closes a cycle, as adding them one by one finds
    /// it — for naming the edge after [`Graph::check_acyclic`] found that there is one. Its
    /// index in `edges` and the error.
    pub(super) fn first_cycle_edge(
        &self,
        catalog: &Catalog,
        edges: &[(String, String)],
    ) -> Option<(usize, GraphError)> {
        let mut probe = Graph::new();
        for n in self.nodes() {
            probe.insert_node(catalog, n.clone()).ok()?;
        }
        edges.iter().enumerate().find_map(|(i, (from, to))| {
            match probe.connect_deferred(catalog, from, to) {
                Err(e @ GraphError::Cycle { .. }) => Some((i, e)),
                _ => None,
            }
        })
    }
}
