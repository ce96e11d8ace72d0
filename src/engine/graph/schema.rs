//! Node schemas (what a node kind declares) and the catalog of known kinds.
//!
//! The graph knows no individual node kind: the registry in `nodes/` hands it a [`Catalog`].

use std::collections::BTreeMap;

use super::types::{ParamSpec, PortSpec};

/// Everything the document needs to know about a node kind.
#[derive(Debug)]
pub struct NodeSchema {
    /// Stable kind name used in files (`"Math"`).
    pub kind: &'static str,
    /// Category for the catalog and the editor's menu (`"Image"`, `"Input/Output"`).
    pub category: &'static str,
    /// What the node does, in a sentence or two.
    pub doc: &'static str,
    /// Input ports.
    pub inputs: &'static [PortSpec],
    /// Output ports.
    pub outputs: &'static [PortSpec],
    /// Parameters.
    pub params: &'static [ParamSpec],
}

impl NodeSchema {
    /// The input port named `name`.
    pub fn input(&self, name: &str) -> Option<&PortSpec> {
        self.inputs.iter().find(|p| p.name == name)
    }

    /// The output port named `name`.
    pub fn output(&self, name: &str) -> Option<&PortSpec> {
        self.outputs.iter().find(|p| p.name == name)
    }

    /// The parameter named `name`.
    pub fn param(&self, name: &str) -> Option<&ParamSpec> {
        self.params.iter().find(|p| p.name == name)
    }

    /// Comma-separated parameter names, for messages.
    pub fn param_names(&self) -> String {
        join(self.params.iter().map(|p| p.name))
    }

    /// Comma-separated input port names, for messages.
    pub fn input_names(&self) -> String {
        join(self.inputs.iter().map(|p| p.name))
    }

    /// Comma-separated output port names, for messages.
    pub fn output_names(&self) -> String {
        join(self.outputs.iter().map(|p| p.name))
    }
}

fn join<'a>(it: impl Iterator<Item = &'a str>) -> String {
    let v: Vec<&str> = it.collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// The set of node kinds a document may use.
#[derive(Debug, Default, Clone)]
pub struct Catalog {
    schemas: BTreeMap<&'static str, &'static NodeSchema>,
}

impl Catalog {
    /// An empty catalog.
    pub fn new() -> Self {
        Self::default()
    }

    /// Add a kind (a later schema with the same kind name replaces the earlier one).
    pub fn add(&mut self, schema: &'static NodeSchema) {
        self.schemas.insert(schema.kind, schema);
    }

    /// The schema of `kind`.
    pub fn get(&self, kind: &str) -> Option<&'static NodeSchema> {
        self.schemas.get(kind).copied()
    }

    /// All schemas, ordered by kind name.
    pub fn iter(&self) -> impl Iterator<Item = &'static NodeSchema> + '_ {
        self.schemas.values().copied()
    }

    /// Comma-separated kind names, for messages.
    pub fn kind_names(&self) -> String {
        join(self.schemas.keys().copied())
    }
}
