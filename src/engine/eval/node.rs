//! What a node kind implements, and the context it runs in.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::Arc;

use thiserror::Error;

use super::paths::output_path;
use super::value::PortValue;
use crate::gpu::{GpuError, Recorder, Shader, UniformLayout};
use crate::graph::{NodeData, NodeSchema, ParamValue};

/// A failure inside a node, before the evaluator adds the node's id and kind.
#[derive(Debug, Error, Clone)]
pub enum NodeError {
    /// A problem with one input port.
    #[error("input '{port}': {message}")]
    Input {
        /// Port name.
        port: String,
        /// What is wrong.
        message: String,
    },
    /// A problem with one parameter.
    #[error("parameter '{param}': {message}")]
    Param {
        /// Parameter name.
        param: String,
        /// What is wrong.
        message: String,
    },
    /// A problem with the node's data block.
    #[error("data block: {0}")]
    Data(String),
    /// Reading or writing a file.
    #[error("{0}")]
    Io(String),
    /// The GPU reported an error.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// An input file that is malformed, truncated or of an unsupported kind: bad input, which
    /// the command line reports with exit code 2 (a file that cannot be written, or a failure
    /// while running, is [`NodeError::Io`] or another variant: exit 1). The message names the
    /// file.
    #[error("{0}")]
    BadFile(String),
    /// Anything else.
    #[error("{0}")]
    Other(String),
    /// The node failed at an earlier frame that a node with a history
    /// ([`super::NodeKind::history`]) reads: the time it failed at, how far back, and who asked.
    #[error("at time {time} (the frame {offset} back that node '{by}' reads): {error}")]
    EarlierFrame {
        /// The earlier frame's time.
        time: f64,
        /// How many frames before the evaluated one.
        offset: f64,
        /// The node with the history.
        by: String,
        /// What went wrong there.
        error: Box<NodeError>,
    },
    /// The node is inside a group node (its id is `group/inner` in the flattened graph): the
    /// group node's id and the group's name, so a message says where the node came from.
    #[error("inside group node '{group}' ({definition}): {error}")]
    InGroup {
        /// The group node's id in the document.
        group: String,
        /// The group's name (its kind in the document).
        definition: String,
        /// What went wrong.
        error: Box<NodeError>,
    },
}

impl NodeError {
    /// The error itself, seen through any [`NodeError::EarlierFrame`] or
    /// [`NodeError::InGroup`] around it.
    pub fn innermost(&self) -> &NodeError {
        match self {
            NodeError::EarlierFrame { error, .. } | NodeError::InGroup { error, .. } => {
                error.innermost()
            }
            other => other,
        }
    }
}

impl From<crate::io::IoError> for NodeError {
    fn from(e: crate::io::IoError) -> Self {
        NodeError::Io(e.to_string())
    }
}

/// Everything a node sees while it runs.
pub struct RunCtx<'a> {
    /// The evaluation's command recorder: passes recorded through it go into the evaluation's
    /// encoder (see `gpu/recorder.rs`); it derefs to the [`crate::gpu::Gpu`] context for everything else.
    pub gpu: &'a Recorder<'a>,
    /// The node's id (for messages).
    pub id: &'a str,
    /// Parameter values at the evaluation time (all declared parameters present).
    pub params: &'a BTreeMap<String, ParamValue>,
    /// The node's data block, if it has one.
    pub data: Option<&'a NodeData>,
    /// The evaluation time (frames), for nodes that interpolate key-frames in their data.
    pub time: f64,
    /// Where to report progress of long work (see [`RunCtx::report`]).
    pub progress: Option<&'a super::ProgressSink>,
    /// Values on connected input ports.
    pub inputs: &'a BTreeMap<String, PortValue>,
    /// Output ports some consumer needs; a node may skip the others.
    pub wanted: &'a BTreeSet<String>,
    /// The evaluation's default image size (`--size`), for nodes that make images from nothing.
    pub size: (u32, u32),
    /// Suffix added to file names written by sinks (wedges), before the extension.
    pub output_suffix: &'a str,
    /// The frame, for file names (see [`output_path`]).
    pub frame: Option<i64>,
    /// Outputs produced so far.
    pub outputs: BTreeMap<String, PortValue>,
    /// Set by [`RunCtx::pass_through`]: the statistics say "passed through" instead of "ran".
    pub passed_through: bool,
    /// The connected inputs at earlier frames, one entry per offset of [`NodeKind::history`]
    /// in its order; empty for a node without history.
    pub earlier: &'a [Earlier],
    /// The evaluation's colour settings (config, working space); read only by nodes that
    /// declare [`NodeDecl::colour`].
    pub colour: &'a crate::colour::ColourCtx,
    /// What the node said about this run ([`RunCtx::note`]).
    pub notes: Vec<String>,
}

/// A node's connected inputs evaluated at an earlier frame (see [`NodeKind::history`]).
#[derive(Debug, Clone)]
pub struct Earlier {
    /// How many frames before the evaluation time (> 0).
    pub offset: f64,
    /// The values on the connected input ports at that frame, by port name.
    pub inputs: BTreeMap<String, PortValue>,
}

impl RunCtx<'_> {
    /// An `Int` parameter's value giving a texture's side (`dims` = 2 for a 2D texture, 3 for a
    /// volume), checked against the adapter's limit: a value beyond it fails naming the
    /// parameter `name` and the limit instead of failing later inside the GPU layer.
    pub fn side(&self, name: &str, value: i64, dims: u32) -> Result<u32, NodeError> {
        let limits = &self.gpu.limits;
        let limit = if dims == 3 {
            limits.max_texture_dimension_3d
        } else {
            limits.max_texture_dimension_2d
        };
        check_side(name, value, limit, dims)
    }

    /// Refuse an allocation of `bytes` that the parameter(s) `params` ask for (e.g.
    /// `"resolution, slices"`) when it exceeds [`crate::gpu::Gpu::allocation_limit`], naming them and the
    /// limit — before the driver fails with a bare out-of-memory error, or the machine swaps.
    pub fn check_bytes(&self, params: &str, bytes: u64) -> Result<(), NodeError> {
        let (limit, source) = self.gpu.allocation_limit();
        if bytes <= limit {
            return Ok(());
        }
        let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
        Err(NodeError::Param {
            param: params.to_string(),
            message: format!(
                "asks for one allocation of {:.0} MiB, beyond this adapter's limit of {:.0} MiB \
                 ({source})",
                mib(bytes),
                mib(limit)
            ),
        })
    }

    /// The data block parsed into the node's structure; `T::default()` when the node has none.
    pub fn data<T: serde::de::DeserializeOwned + Default>(&self) -> Result<T, NodeError> {
        match self.data {
            Some(d) => d.parse().map_err(NodeError::Data),
            None => Ok(T::default()),
        }
    }

    /// Declare that this run forwards its input unchanged because the parameters and inputs
    /// make the node's work an identity (e.g. `Heterogeneity` with α ≡ 0, I ≡ 1): the
    /// evaluator's statistics show the node as `passed through`, so a user sees that nothing
    /// was modelled there.
    pub fn pass_through(&mut self) {
        self.passed_through = true;
    }

    /// Say something the user should know about this run that is not an error — a file's grid
    /// filtered down to fit a limit, say. The evaluation's [`Stats::notes`](super::Stats::notes)
    /// carry it, and the command line prints it on stderr.
    pub fn note(&mut self, message: impl Into<String>) {
        self.notes.push(message.into());
    }

    /// Report progress of long work: `done` of `total` steps and a short message (shown by the
    /// CLI's progress bar and the editor's top bar).
    pub fn report(&self, done: u64, total: u64, message: impl Into<String>) {
        if let Some(sink) = self.progress {
            (sink.0)(&super::Progress {
                node: self.id.to_string(),
                done,
                total,
                message: message.into(),
            });
        }
    }

    /// The value on input `port`, if connected.
    pub fn input(&self, port: &str) -> Option<&PortValue> {
        self.inputs.get(port)
    }

    /// The value on a required input `port`.
    pub fn require(&self, port: &str) -> Result<&PortValue, NodeError> {
        self.input(port).ok_or_else(|| NodeError::Input {
            port: port.to_string(),
            message: "must be connected".into(),
        })
    }

    /// The texture on a required image-like input `port` (Scalar, Image, Depth, ShadowMap).
    pub fn require_texture(
        &self,
        port: &str,
    ) -> Result<std::sync::Arc<crate::gpu::GpuTexture>, NodeError> {
        self.require(port)?
            .texture()
            .cloned()
            .ok_or_else(|| NodeError::Input {
                port: port.to_string(),
                message: "is not an image".into(),
            })
    }

    /// Whether output `port` is needed downstream.
    pub fn wants(&self, port: &str) -> bool {
        self.wanted.contains(port)
    }

    /// Set output `port`.
    pub fn set(&mut self, port: &str, value: PortValue) {
        self.outputs.insert(port.to_string(), value);
    }

    /// `path` with the evaluation's output suffix inserted before the extension.
    pub fn suffixed(&self, path: &str) -> PathBuf {
        output_path(path, self.output_suffix, self.frame)
    }
}

/// `value` as a texture side if it is within 1..=`limit` (the adapter's
/// `max_texture_dimension_{dims}d`), else an error naming `param` and the limit.
pub fn check_side(param: &str, value: i64, limit: u32, dims: u32) -> Result<u32, NodeError> {
    match u32::try_from(value) {
        Ok(v) if (1..=limit).contains(&v) => Ok(v),
        _ => Err(NodeError::Param {
            param: param.to_string(),
            message: format!(
                "{value} texels per side is beyond this adapter's limit of {limit} for a {dims}D \
                 texture (max_texture_dimension_{dims}d)"
            ),
        }),
    }
}

/// What [`NodeKind::volatile_key`] may look at.
pub struct KeyInput<'a> {
    /// Parameter values at the evaluation time.
    pub params: &'a BTreeMap<String, ParamValue>,
    /// The node's data block.
    pub data: Option<&'a NodeData>,
    /// The evaluation time.
    pub time: f64,
}

/// What a node kind declares as data: its schema (ports, parameters, docs), its shader, the
/// uniform structs the layout test checks, and how the evaluator treats it. One `static` per
/// kind, built with [`NodeDecl::new`] and the `const` setters:
///
/// ```text
/// static DECL: NodeDecl = NodeDecl::new(NodeSchema { kind: "Blur", … })
///     .shaders(&[crate::shader("blur", include_str!("../shaders/blur.wgsl"))])
///     .uniforms(&[BlurParams::LAYOUT]);
/// ```
#[derive(Debug)]
pub struct NodeDecl {
    /// Ports, parameters and docs.
    pub schema: NodeSchema,
    /// The node's shaders: `shaders/<stem>.wgsl`, or for a technique in a folder one file per
    /// pass or family of passes in `shaders/<stem>/` (see [`Shader`]); empty for a node that
    /// runs no GPU pass.
    pub shaders: &'static [Shader],
    /// Those of `shaders` that only some parameter values dispatch (a `method` other than the
    /// default): the adapter is not required to run them before the node runs, as it is for
    /// the others; choosing one the adapter cannot run fails at its dispatch, in one line
    /// naming what the adapter lacks. Empty by default.
    pub on_demand: &'static [Shader],
    /// Uniform structs bound by the shader (declared with [`uniforms!`](crate::uniforms)), for
    /// the layout test.
    pub uniforms: &'static [UniformLayout],
    /// Parameters that do not change the node's outputs (e.g. an output file path), left out of
    /// the cache key.
    pub key_exempt: &'static [&'static str],
    /// Whether the node is a sink: it writes something outside the graph and is evaluated when
    /// the graph's outputs are requested.
    pub sink: bool,
    /// Text parameters naming files, and whether the node reads or writes them (the CLI resolves
    /// them: see [`crate::eval::resolve_files`]).
    pub files: &'static [(&'static str, FileRole)],
    /// The editor tools that edit this node (their ids; empty: parameters only). The editor
    /// offers a node the tools its declaration names, in this order, and knows no node kind;
    /// a tool works on one shape of data block, so a new node reuses a tool by keeping that
    /// shape. The ids Tyndall's tools answer to (`src/tools/`): `layer_list` (a
    /// `TransferFunction`-shaped layer stack, and a viewer click adding a constraint anchored
    /// to the surface under it, at [`NodeKind::table_coordinates`]), `stroke_painting` (strokes
    /// painted over the viewer per view, `LightMapSolve`-shaped), `splat_brush` (the 3D splat
    /// brush shown with this node) and `splat_volume` (no panel of its own: marks a volume the
    /// splat brush paints into, `BlendVolume`-shaped).
    pub tools: &'static [&'static str],
    /// The parts of its scene inputs the node reads (`None`: all of them). Its cache key then
    /// covers only those parts of an incoming scene, not the scene node's whole key: a
    /// G-buffer (camera and geometry) is reused when only the sun changed. Declare only parts
    /// the node's outputs cannot depend on the others of.
    pub scene_parts: Option<&'static [crate::scene::ScenePart]>,
    /// Whether the node reads the evaluation's colour settings ([`RunCtx::colour`]: the config
    /// and the graph's working space); its cache key then covers them.
    pub colour: bool,
}

/// How a node uses a file named by a text parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileRole {
    /// The node reads the file (relative paths are relative to the graph file's folder).
    Read,
    /// The node writes the file (relative paths are relative to the output directory; absolute
    /// paths and `..` escapes need `--allow-any-path`).
    Write,
}

impl NodeDecl {
    /// A declaration with no shaders, no uniforms, no exempt parameters, not a sink.
    pub const fn new(schema: NodeSchema) -> Self {
        Self {
            schema,
            shaders: &[],
            on_demand: &[],
            uniforms: &[],
            key_exempt: &[],
            sink: false,
            files: &[],
            tools: &[],
            scene_parts: None,
            colour: false,
        }
    }

    /// Mark the node as reading the evaluation's colour settings (config, working space).
    pub const fn colour(self) -> Self {
        Self {
            colour: true,
            ..self
        }
    }

    /// Set the shaders.
    pub const fn shaders(self, shaders: &'static [Shader]) -> Self {
        Self { shaders, ..self }
    }

    /// Set the shaders (of those set with [`NodeDecl::shaders`]) only some parameter values
    /// dispatch: see [`NodeDecl::on_demand`].
    pub const fn on_demand(self, on_demand: &'static [Shader]) -> Self {
        Self { on_demand, ..self }
    }

    /// Set the uniform structs the shader binds.
    pub const fn uniforms(self, uniforms: &'static [UniformLayout]) -> Self {
        Self { uniforms, ..self }
    }

    /// Set the parameters left out of the cache key.
    pub const fn key_exempt(self, key_exempt: &'static [&'static str]) -> Self {
        Self { key_exempt, ..self }
    }

    /// Mark the node as a sink.
    pub const fn sink(self) -> Self {
        Self { sink: true, ..self }
    }

    /// Declare the text parameters that name files the node reads or writes.
    pub const fn files(self, files: &'static [(&'static str, FileRole)]) -> Self {
        Self { files, ..self }
    }

    /// Declare the editor tools that edit the node's data block.
    pub const fn tools(self, tools: &'static [&'static str]) -> Self {
        Self { tools, ..self }
    }

    /// Set the parts of its scene inputs the node reads (see [`NodeDecl::scene_parts`]).
    pub const fn scene_parts(self, parts: &'static [crate::scene::ScenePart]) -> Self {
        Self {
            scene_parts: Some(parts),
            ..self
        }
    }
}

/// A node kind: its declaration (data) and its behaviour (GPU work).
///
/// Each implementation also carries a plain-Rust CPU reference of its maths (a free function in
/// its file), used by the tests as the oracle. What every kind would write the same way (schema,
/// shader, uniform layouts, sink flag) is read from [`NodeKind::decl`] by the methods on
/// `dyn NodeKind` ([`schema`](#method.schema), [`shaders`](#method.shaders), …).
pub trait NodeKind: Send + Sync {
    /// The kind's declaration.
    fn decl(&self) -> &'static NodeDecl;

    /// Extra cache-key material the parameters and the data block do not capture (an input
    /// file's size and modification time; the time, for data with key-frames). Called every
    /// evaluation; the evaluator already hashes the parameters and the data block's text.
    fn volatile_key(&self, _key: &KeyInput) -> u64 {
        0
    }

    /// For a node that also reads its inputs at earlier frames (temporal accumulation): the
    /// offsets in frames, each > 0, at which the evaluator evaluates every connected input
    /// again, at time − offset, before the node runs ([`RunCtx::earlier`]). Those evaluations
    /// use the same cache (in a sequential render the earlier frames are cache hits) and their
    /// keys enter the node's own key, so a frame evaluated alone gives the same picture as in a
    /// sequence. Empty (the default): the node reads the evaluation time only.
    fn history(&self, _params: &BTreeMap<String, ParamValue>) -> Result<Vec<f64>, NodeError> {
        Ok(Vec::new())
    }

    /// For kinds whose data block names files to read (a transfer function's image layers):
    /// the block with each such path passed through `resolve`, or `None` when it names none.
    /// [`crate::eval::resolve_files`] calls it so that these paths, like file parameters, are
    /// read from the graph's folder.
    fn data_files(
        &self,
        _data: &crate::graph::NodeData,
        _resolve: &dyn Fn(&str) -> String,
    ) -> Result<Option<crate::graph::NodeData>, String> {
        Ok(None)
    }

    /// For a node that places what it reads in a 2D table (a transfer function): where the
    /// picked pixel lands in it (`tyndall pick`, the editor's 3D constraints; see
    /// [`crate::eval::pick`]). `None`: the kind has no table.
    fn table_coordinates(
        &self,
        _at: &super::pick::PickAt,
    ) -> Option<Result<super::pick::TablePick, NodeError>> {
        None
    }

    /// Times (frames) of the key-frames inside the node's data block, for the editor's
    /// timeline (key-frames of parameters are the graph's and need no hook).
    fn data_key_times(&self, _data: &NodeData) -> Vec<f64> {
        Vec::new()
    }

    /// What the node finds in the files its parameters name, for `tyndall validate` (a glTF
    /// file's animations and their frame ranges; a problem reading the file): one line each,
    /// from the parameters at frame 0. Empty by default.
    fn describe_files(&self, _params: &BTreeMap<String, crate::graph::ParamValue>) -> Vec<String> {
        Vec::new()
    }

    /// Compute the wanted outputs (GPU work).
    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError>;

    /// For sinks: the side effect (write a file) from the node's (possibly cached) outputs.
    /// Runs every evaluation in which the sink is requested.
    fn commit(
        &self,
        _ctx: &RunCtx,
        _outputs: &BTreeMap<String, PortValue>,
    ) -> Result<(), NodeError> {
        Ok(())
    }
}

impl dyn NodeKind + '_ {
    /// Ports, parameters and docs.
    pub fn schema(&self) -> &'static NodeSchema {
        &self.decl().schema
    }

    /// The node's shaders (empty when it runs no GPU pass).
    pub fn shaders(&self) -> &'static [Shader] {
        self.decl().shaders
    }

    /// Uniform structs bound by the shader, for the layout test.
    pub fn uniform_layouts(&self) -> &'static [UniformLayout] {
        self.decl().uniforms
    }

    /// Parameters left out of the cache key.
    pub fn key_exempt(&self) -> &'static [&'static str] {
        self.decl().key_exempt
    }

    /// Whether the node is a sink.
    pub fn is_sink(&self) -> bool {
        self.decl().sink
    }

    /// Whether the node's declaration names the editor tool `id` ([`NodeDecl::tools`]).
    pub fn has_tool(&self, id: &str) -> bool {
        self.decl().tools.contains(&id)
    }

    /// The text parameters naming files the node uses in `role` ([`NodeDecl::files`]), in
    /// declaration order.
    pub fn file_params(&self, role: FileRole) -> impl Iterator<Item = &'static str> + '_ {
        self.decl()
            .files
            .iter()
            .filter(move |(_, r)| *r == role)
            .map(|(name, _)| *name)
    }
}

/// The set of node kinds the evaluator can run, and the catalog the document checks against.
#[derive(Default, Clone)]
pub struct Registry {
    kinds: BTreeMap<&'static str, Arc<dyn NodeKind>>,
    catalog: crate::graph::Catalog,
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Self::default()
    }

    /// Add a node kind.
    pub fn add(&mut self, kind: Arc<dyn NodeKind>) {
        self.catalog.add(kind.schema());
        self.kinds.insert(kind.schema().kind, kind);
    }

    /// The implementation of `kind`.
    pub fn get(&self, kind: &str) -> Option<&Arc<dyn NodeKind>> {
        self.kinds.get(kind)
    }

    /// All kinds, ordered by name.
    pub fn iter(&self) -> impl Iterator<Item = &Arc<dyn NodeKind>> {
        self.kinds.values()
    }

    /// The catalog of schemas.
    pub fn catalog(&self) -> &crate::graph::Catalog {
        &self.catalog
    }
}
