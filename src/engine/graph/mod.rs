//! The document: nodes, typed ports, parameters, key-frames and edges (petgraph
//! `StableDiGraph`), validation, and the RON file format with versions and migrations.
//!
//! This module knows no GPU and no individual node kind: kinds are described by
//! [`NodeSchema`]s gathered in a [`Catalog`] that the node registry provides.

mod data;
mod document;
mod edges;
mod error;
mod format;
mod group;
mod layout;
mod library;
mod port_types;
mod proxy_scale;
mod schema;
mod types;
mod value;

pub use data::NodeData;
pub use document::{check_param_value, split_endpoint, EdgeRefs, Graph, Node, Wire};
pub use error::{GraphError, LoadError, Location};
pub use format::{
    load_file, load_str, save_file, save_string, write_atomic, Migration, FORMAT_VERSION,
    MIGRATIONS,
};
pub use group::{GroupDef, GroupPort, Knob, LibraryRef};
pub use layout::{nominal_size, COLUMN_GAP, NODE_WIDTH, ROW_GAP};
pub use library::{
    is_library_text, library_folders, library_text, list_library, load_library_file,
    load_library_group, reference_entry, user_library,
};
pub use port_types::type_for_file;
pub use schema::{Catalog, NodeSchema};
pub use types::{
    condition_holds, position, sample_keys, Choice, DefaultValue, Direction, Interp, Key,
    ParamKind, ParamSpec, PortSpec, PortType, ProxyScale,
};
pub use value::{num, ParamProblem, ParamValue};
