//! Readers of older format versions, each migrated step by step to the current shape.

use ron::value::Value;
use serde::Deserialize;

use super::{pairs, ron_options, FileGraph, FileNode, FileTrack};

/// Version 1 of the format: the key-frame table was called `keyframes` and node positions
/// `position`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileGraphV1 {
    #[allow(dead_code)]
    version: u32,
    #[serde(default, with = "pairs")]
    nodes: Vec<(String, FileNodeV1)>,
    #[serde(default)]
    edges: Vec<(String, String)>,
    #[serde(default, with = "pairs")]
    keyframes: Vec<(String, FileTrack)>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileNodeV1 {
    kind: String,
    #[serde(default, with = "pairs")]
    params: Vec<(String, Value)>,
    #[serde(default)]
    position: Option<(f32, f32)>,
    #[serde(default)]
    data: Option<crate::graph::NodeData>,
}

/// Version 2: version 3 without `groups`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileGraphV2 {
    #[allow(dead_code)]
    version: u32,
    #[serde(default, with = "pairs")]
    nodes: Vec<(String, FileNode)>,
    #[serde(default)]
    edges: Vec<(String, String)>,
    #[serde(default, with = "pairs")]
    keys: Vec<(String, FileTrack)>,
}

/// Version 2 → 3: nothing changes but the version (a graph without groups).
fn migrate_v2_to_v3(v: FileGraphV2) -> FileGraph {
    FileGraph {
        colour: None,
        version: 3,
        nodes: v.nodes,
        edges: v.edges,
        keys: v.keys,
        groups: Vec::new(),
    }
}

pub(super) fn read_v2(text: &str) -> Result<FileGraph, ron::error::SpannedError> {
    ron_options()
        .from_str::<FileGraphV2>(text)
        .map(migrate_v2_to_v3)
}

/// Version 1 → 2: `keyframes` → `keys`, `position` → `pos`.
fn migrate_v1_to_v2(v: FileGraphV1) -> FileGraphV2 {
    FileGraphV2 {
        version: 2,
        nodes: v
            .nodes
            .into_iter()
            .map(|(id, n)| {
                (
                    id,
                    FileNode {
                        kind: n.kind,
                        params: n.params,
                        pos: n.position,
                        data: n.data,
                    },
                )
            })
            .collect(),
        edges: v.edges,
        keys: v.keyframes,
    }
}

pub(super) fn read_v1(text: &str) -> Result<FileGraph, ron::error::SpannedError> {
    ron_options()
        .from_str::<FileGraphV1>(text)
        .map(migrate_v1_to_v2)
        .map(migrate_v2_to_v3)
}
